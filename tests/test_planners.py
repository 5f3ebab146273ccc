"""Planners: analytic antipodal checks on a box and a sphere, independent collision checks in MuJoCo,
seeds, validation of a planner's output, the registry with user planners, NMS, and `manigrasp plan`."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from manigrasp import hands, planners
from manigrasp.errors import ConfigError, PlannerError, UnknownNameError
from manigrasp.objects import build_object, catalog
from manigrasp.planners.jaw_poses import jaw_clears_table
from manigrasp.planners.nms import rotation_angles, suppress
from manigrasp.planners.pairs import Pairs
from tests.helpers import TALL_BOX as BOX
from tests.helpers import assert_collision_free

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
SPHERE_RADIUS = 0.03  # [m]


@pytest.fixture(scope="module")
def box_obs(tall_box_asset) -> planners.Observation:
    return planners.Observation.from_asset(tall_box_asset)


@pytest.fixture(scope="module")
def sphere_obs() -> planners.Observation:
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=SPHERE_RADIUS)
    asset = build_object(mesh, name="planner_test_sphere", mass=0.1).asset
    return planners.Observation.from_asset(asset)


@pytest.fixture(scope="module")
def box_plan(box_obs, jaw) -> planners.PlanResult:
    return planners.plan(planners.load("antipodal"), box_obs, jaw, 100, np.random.default_rng(0))


# ------------------------------------------------------------ antipodal, analytic
def test_box_contacts_on_opposite_faces_width_is_the_dimension(box_plan, box_obs):
    candidates = box_plan.candidates
    assert len(candidates) >= 20
    half = np.array(BOX) / 2
    for c in candidates:
        local = (c.contacts - box_obs.center_of_mass)  # the box is upright: object axes = world axes
        on_face = np.abs(np.abs(local) - half) < 1e-4  # (2, 3): which face each contact lies on
        axis = np.flatnonzero(on_face[0] & on_face[1])
        assert len(axis) >= 1, f"contacts {local} are not on faces across one axis"
        k = axis[0]
        assert np.sign(local[0, k]) == -np.sign(local[1, k]), "contacts on the same face"
        assert abs(c.width - BOX[k]) < 1e-3
        assert np.linalg.norm(c.contacts[1] - c.contacts[0]) == pytest.approx(c.width)
        assert k in (0, 1), "the 12 cm dimension does not fit the 8 cm jaw"
        # Contact normals point into the box, along the closing axis.
        assert np.allclose(np.abs(c.contact_normals[:, k]), 1.0, atol=1e-6)
        assert np.allclose(np.abs(c.closing[k]), 1.0, atol=1e-6)
        assert c.force_closure and c.epsilon_l1 > 0


def test_sphere_grasp_axes_pass_through_the_centre(sphere_obs, jaw):
    result = planners.plan(planners.load("antipodal"), sphere_obs, jaw, 50, np.random.default_rng(1))
    assert len(result.candidates) >= 20
    centre = sphere_obs.center_of_mass
    for c in result.candidates:
        p, q = c.contacts
        axis = (q - p) / np.linalg.norm(q - p)
        miss = np.linalg.norm(np.cross(centre - p, axis))
        assert miss < 1e-3, f"grasp axis misses the centre by {1000 * miss:.2f} mm"
        assert np.allclose(c.pose[:3, 3], (p + q) / 2, atol=0.02)


def test_antipodal_candidates_do_not_collide(box_obs, jaw, box_plan):
    assert_collision_free(box_obs, jaw, box_plan.candidates)


def test_the_independent_collision_check_sees_a_collision(box_obs, jaw):
    """A TCP at the box's centre, approaching from above, puts the palm into the box's top."""
    pose = np.eye(4)
    pose[:3, :3] = np.diag([-1.0, 1.0, -1.0])
    pose[:3, 3] = box_obs.center_of_mass
    bad = planners.GraspCandidate(pose=pose, score=0.0)
    with pytest.raises(AssertionError, match="touches something at its grasp pose"):
        assert_collision_free(box_obs, jaw, [bad])
    pose[2, 3] = 0.5  # far above: clear; its "pre-grasp" 45 cm further down (negative offset) is not
    low = planners.GraspCandidate(pose=pose, score=0.0, pregrasp_offset=-0.45)
    with pytest.raises(AssertionError, match="touches something at its pre-grasp pose"):
        assert_collision_free(box_obs, jaw, [low])


def test_candidates_come_from_above_the_table_and_follow_the_frame_convention(box_plan):
    for c in box_plan.candidates:
        rot = c.pose[:3, :3]
        assert np.allclose(rot.T @ rot, np.eye(3), atol=1e-9) and np.linalg.det(rot) > 0
        assert c.approach[2] <= 1e-9
        assert np.allclose(c.pose[:3, 0], np.cross(c.closing, c.approach))
        assert np.allclose(c.pregrasp_pose[:3, 3], c.position - 0.10 * c.approach)
        assert c.planner == "antipodal" and c.planning_time_s == box_plan.planning_time_s > 0


def test_ranked_by_score_and_diverse(box_plan):
    scores = [c.score for c in box_plan.candidates]
    assert scores == sorted(scores, reverse=True)
    poses = np.array([c.pose for c in box_plan.candidates])
    assert len(suppress(poses, symmetric=True)) == len(poses), "NMS should leave nothing to suppress"


def test_same_seed_same_candidates_different_seed_different(box_obs, jaw, box_plan):
    again = planners.plan(planners.load("antipodal"), box_obs, jaw, 100, np.random.default_rng(0))
    other = planners.plan(planners.load("antipodal"), box_obs, jaw, 100, np.random.default_rng(1))
    same = np.array([c.pose for c in box_plan.candidates])
    assert np.array_equal(same, np.array([c.pose for c in again.candidates]))
    assert [c.score for c in again.candidates] == [c.score for c in box_plan.candidates]
    different = np.array([c.pose for c in other.candidates])
    assert same.shape != different.shape or not np.allclose(same, different)


def test_antipodal_refuses_a_dexterous_hand(box_obs):
    with pytest.raises(PlannerError, match="power"):
        planners.plan(planners.load("antipodal"), box_obs, hands.load("inspire_right"), 5, np.random.default_rng(0))


def test_an_object_wider_than_the_jaw_gets_no_grasp(jaw):
    asset = build_object(trimesh.creation.box((0.09, 0.09, 0.09)), name="planner_test_wide", mass=0.3).asset
    obs = planners.Observation.from_asset(asset)
    assert planners.plan(planners.load("antipodal"), obs, jaw, 10, np.random.default_rng(0)).candidates == ()


def test_a_vertical_line_through_a_thin_plate_cannot_clear_the_table():
    # A 1 cm plate on the table: the vertical line through it would put the lower open jaw 3 cm under the
    # table (4 cm from the midpoint at 5 mm); a horizontal line across it keeps both jaws at 5 mm.
    p, q = np.array([[0.0, 0.0, 0.01], [0.0, -0.03, 0.005]]), np.array([[0.0, 0.0, 0.0], [0.0, 0.03, 0.005]])
    axis = (q - p) / np.linalg.norm(q - p, axis=1)[:, None]
    pairs = Pairs(p=p, q=q, n_p=-axis, n_q=axis, axis=axis, width=np.linalg.norm(q - p, axis=1), alpha=np.zeros(2))
    assert list(jaw_clears_table(pairs, open_width=0.08, lift=0.0, table_height=0.0)) == [False, True]
    assert list(jaw_clears_table(pairs, open_width=0.08, lift=0.036, table_height=0.0)) == [True, True]


# ------------------------------------------------------------ power and random
@pytest.mark.slow
def test_power_on_the_sphere_with_a_dexterous_hand(sphere_obs):
    hand = hands.load("inspire_right")
    result = planners.plan(planners.load("power"), sphere_obs, hand, 10, np.random.default_rng(0))
    assert len(result.candidates) >= 5
    for c in result.candidates:
        assert c.approach[2] <= 1e-9
        assert len(c.contacts) >= 2 and c.epsilon_l1 is not None and 0.0 <= c.score <= 1.0
        # Planned contacts lie on the sphere (kinematic closing stops within one closing step).
        radii = np.linalg.norm(c.contacts - sphere_obs.center_of_mass, axis=1)
        assert np.all(np.abs(radii - SPHERE_RADIUS) < 0.01)
    assert_collision_free(sphere_obs, hand, result.candidates)
    again = planners.plan(planners.load("power"), sphere_obs, hand, 10, np.random.default_rng(0))
    assert np.array_equal([c.pose for c in result.candidates], [c.pose for c in again.candidates])


def test_random_planner_is_a_seeded_unfiltered_floor(box_obs, jaw):
    first = planners.plan(planners.load("random"), box_obs, jaw, 30, np.random.default_rng(3))
    again = planners.plan(planners.load("random"), box_obs, jaw, 30, np.random.default_rng(3))
    other = planners.plan(planners.load("random"), box_obs, jaw, 30, np.random.default_rng(4))
    assert len(first.candidates) == 30
    poses = np.array([c.pose for c in first.candidates])
    assert np.array_equal(poses, [c.pose for c in again.candidates])
    assert not np.allclose(poses, [c.pose for c in other.candidates])
    assert np.all(poses[:, 2, 2] <= 0.0)
    radius = np.linalg.norm(np.array(BOX) / 2)
    assert np.all(np.linalg.norm(poses[:, :3, 3] - box_obs.center_of_mass, axis=1) <= 0.5 * radius + 1e-9)


# ------------------------------------------------------------ validation of a planner's output
class _Raising:
    name, needs = "raising", "mesh"

    def plan(self, observation, hand, n, rng):
        raise RuntimeError("lost my marbles")


class _NaNPose:
    name, needs = "nan_pose", "mesh"

    def plan(self, observation, hand, n, rng):
        pose = np.eye(4)
        pose[0, 3] = np.nan
        return [planners.GraspCandidate(pose=np.eye(4), score=1.0), planners.GraspCandidate(pose=pose, score=0.5)]


class _Sheared:
    name, needs = "sheared", "mesh"

    def plan(self, observation, hand, n, rng):
        return [planners.GraspCandidate(pose=np.diag([1.2, 1.0, 1.0, 1.0]), score=1.0)]


class _TooMany:
    name, needs = "too_many", "mesh"

    def plan(self, observation, hand, n, rng):
        return [planners.GraspCandidate(pose=np.eye(4), score=0.0)] * (n + 1)


@pytest.mark.parametrize(("planner", "message"), [
    (_Raising(), r"planner 'raising' raised RuntimeError: lost my marbles"),
    (_NaNPose(), r"planner 'nan_pose': candidate 1 is invalid: pose contains NaN"),
    (_Sheared(), r"planner 'sheared': candidate 0 is invalid: .*not a rotation"),
    (_TooMany(), r"planner 'too_many' returned 4 candidates, more than the 3 asked for"),
])
def test_a_broken_planner_is_reported_clearly(box_obs, jaw, planner, message):
    with pytest.raises(PlannerError, match=message):
        planners.plan(planner, box_obs, jaw, 3, np.random.default_rng(0))


def test_non_unit_quaternion_is_refused():
    with pytest.raises(PlannerError, match="not a finite unit quaternion"):
        planners.GraspCandidate.from_pos_quat([0, 0, 0], [1.0, 0.2, 0.0, 0.0], score=1.0)
    c = planners.GraspCandidate.from_pos_quat([0, 0, 0.1], [0.0, 1.0, 0.0, 0.0], score=1.0)
    assert np.allclose(c.approach, [0, 0, -1]) and planners.candidate_defect(c) is None


def test_planner_needing_points_refuses_a_mesh_only_observation(box_obs, jaw):
    class NeedsPoints(_Raising):
        name, needs = "cloud", "points"

    with pytest.raises(PlannerError, match="needs a points observation"):
        planners.plan(NeedsPoints(), box_obs, jaw, 1, np.random.default_rng(0))


# ------------------------------------------------------------ registry and user planners
def test_user_planner_from_module_attribute(monkeypatch, box_obs, jaw):
    monkeypatch.syspath_prepend(str(EXAMPLES))
    planner = planners.load("top_down_planner:TopDownPlanner", height=0.01)
    result = planners.plan(planner, box_obs, jaw, 4, np.random.default_rng(0))
    assert result.planner == "top_down" and len(result.candidates) == 4
    assert np.allclose(result.candidates[0].position, box_obs.center_of_mass + [0, 0, 0.01])
    assert all(c.planner == "top_down" for c in result.candidates)


def test_registry_errors_are_clear():
    assert {"antipodal", "power", "random"} <= set(planners.names())
    listed = r"did you mean 'antipodal'.*available: antipodal, dexopt, file, power, random"
    with pytest.raises(UnknownNameError, match=listed):
        planners.load("antipodl")
    with pytest.raises(UnknownNameError, match="cannot import module"):
        planners.load("no_such_module_xyz:Planner")
    with pytest.raises(ConfigError, match="valid parameters: .*n_samples"):
        planners.load("antipodal", n_sample=10)
    with pytest.raises(ConfigError, match="n_approaches must be >= 1"):
        planners.load("antipodal", n_approaches=0)
    with pytest.raises(ConfigError, match="dense_approaches must be >= 1"):
        planners.load("antipodal", dense_approaches=0)
    with pytest.raises(ConfigError, match=r"dense_lateral_fractions must be a non-empty list in \(-1, 1\)"):
        planners.load("antipodal", dense_lateral_fractions=[0.0, 1.0])
    with pytest.raises(ConfigError, match=r"depth_fractions must be a non-empty list in \[0, 1\)"):
        planners.load("antipodal", depth_fractions=[-0.1])
    with pytest.raises(PlannerError, match="no plan"):
        planners.load("numpy:pi")


# ------------------------------------------------------------ NMS and geometry
def test_nms_thresholds_and_finger_swap_symmetry():
    def turned(angle_deg: float, about: int = 0, shift: float = 0.0) -> np.ndarray:
        pose = np.eye(4)
        axis = np.zeros(3)
        axis[about] = np.radians(angle_deg)
        quat = np.empty(4)
        mujoco.mju_axisAngle2Quat(quat, axis / max(np.linalg.norm(axis), 1e-12), np.linalg.norm(axis))
        mat = np.empty(9)
        mujoco.mju_quat2Mat(mat, quat)
        pose[:3, :3] = mat.reshape(3, 3)
        pose[0, 3] = shift
        return pose

    base = turned(0)
    assert list(suppress(np.array([base, turned(20)]))) == [0]
    assert list(suppress(np.array([base, turned(40)]))) == [0, 1]
    assert list(suppress(np.array([base, turned(5, shift=0.04)]))) == [0, 1]
    flipped = turned(180, about=2)
    assert list(suppress(np.array([base, flipped]))) == [0, 1]
    assert list(suppress(np.array([base, flipped]), symmetric=True)) == [0]
    assert rotation_angles(base[:3, :3], turned(25)[None, :3, :3])[0] == pytest.approx(np.radians(25))


# ------------------------------------------------------------ CLI
def test_cli_plan_table_and_json(capsys, monkeypatch):
    from manigrasp.cli import main

    assert main(["plan", "--object", "foam_brick", "--hand", "parallel_jaw", "--planner", "antipodal",
                 "-n", "5", "--seed", "2", "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["planning_time_s"] > 0 and 1 <= len(payload["candidates"]) <= 5
    first = payload["candidates"][0]
    assert set(first) >= {"pose", "width_m", "score", "epsilon_l1", "force_closure", "contacts"}
    assert np.array(first["pose"]).shape == (4, 4) and np.array(first["contacts"]).shape == (2, 3)

    monkeypatch.syspath_prepend(str(EXAMPLES))
    assert main(["plan", "--object", "foam_brick", "--hand", "parallel_jaw", "--planner",
                 "top_down_planner:TopDownPlanner", "-n", "3"]) == 0
    out = capsys.readouterr().out
    assert "rank" in out and "approach" in out and "3 candidates from 'top_down'" in out

    assert main(["plan", "--object", "foam_brick", "--hand", "parallel_jaw", "--planner", "nope"]) == 2
    assert "unknown planner 'nope'" in capsys.readouterr().err


def test_a_scans_lip_pinches_do_not_count_as_grasps_for_the_dense_pass():
    # The potted meat can's scan has a 2-9 mm lip whose pinches score ~0.05. Greedy NMS in rank order keeps only
    # 16-18 of the scan's distinct body grasps, so without `dense_floor` the walk's last few are pinches (which slip
    # in the lift) and step 6 does not run; with dense_floor 0.1, step 6 packs the body grasps and no pinch is returned.
    # The default's repack (the top of the ranking packed into n distinct grasps) returns no pinch either.
    assert planners.load("antipodal").dense_floor == 0.0  # opt-in: the default keeps the walk's behaviour
    asset = catalog.build(catalog.shipped("010_potted_meat_can_scan")).asset
    obs, hand = planners.Observation.from_asset(asset), hands.load("parallel_jaw")
    widths = {}
    for key, params in (("walk", {"repack": False}), ("floor", {"repack": False, "dense_floor": 0.1}), ("default", {})):
        plan = planners.plan(planners.load("antipodal", **params), obs, hand, 20, np.random.default_rng(0))
        widths[key] = np.array([c.width for c in plan.candidates])
    assert len(widths["walk"]) == len(widths["floor"]) == len(widths["default"]) == 20
    assert (widths["walk"] < 0.01).sum() >= 2, widths["walk"]
    assert (widths["floor"] < 0.01).sum() == 0, widths["floor"]
    assert (widths["default"] < 0.01).sum() == 0, widths["default"]
