"""The grasp a protocol executes (`manigrasp.protocol.grasp`): one rigidity tolerance from the planner to the
scene, so a trial records a status and never raises; a (7,) pose's pre-shape is checked as a matrix's is."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from manigrasp.geometry import RIGID_TOLERANCE, check_rigid, is_rigid, rigid_defect
from manigrasp.objects import build_object
from manigrasp.planners import GraspCandidate, candidate_defect
from manigrasp.protocol import PROTOCOLS, Status, settle_object
from manigrasp.protocol.grasp import Grasp, as_grasp, check_grasp, grasp_tcp_pose
from manigrasp.sim import build_scene


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    asset = build_object(trimesh.creation.box((0.05,) * 3), name="box_grasp", mass=0.3,
                         cache_root=tmp_path_factory.mktemp("objects")).asset
    scene = build_scene("parallel_jaw", asset)
    rest = settle_object(scene)
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[:3, 3] = rest[:3, 3]
    return scene, rest, pose


def _sheared(pose: np.ndarray, amount: float) -> np.ndarray:
    out = pose.copy()
    out[0, 1] += amount
    return out


@pytest.mark.parametrize("amount", [0.5 * RIGID_TOLERANCE, 2.0 * RIGID_TOLERANCE])
def test_every_layer_agrees_on_a_pose_near_the_tolerance(box, amount):
    """R^T R - I of a pose sheared by a in one entry is a in two entries (and a^2 on the diagonal)."""
    scene, _, pose = box
    sheared = _sheared(pose, amount)
    rigid = amount < RIGID_TOLERANCE
    assert is_rigid(sheared) is rigid
    assert (check_grasp(Grasp(sheared)) is None) is rigid
    assert (candidate_defect(GraspCandidate(pose=sheared, score=1.0)) is None) is rigid
    if rigid:
        scene.set_mount(sheared)  # the scene's own check (hand mount) accepts it too
        np.testing.assert_array_equal(scene.mount, sheared)
    else:
        with pytest.raises(ValueError, match="not a rotation"):
            scene.set_mount(sheared)


def test_a_pose_5e_6_off_gives_a_recorded_status_never_an_exception(box):
    """Such a pose passed check_grasp (1e-5) and raised ValueError in Scene.set_mount (1e-6), out of Protocol.run."""
    scene, rest, pose = box
    for amount, expected in ((5e-6, Status.SUCCESS), (5e-5, Status.INVALID_GRASP)):
        result = PROTOCOLS.load("lift").run(scene, _sheared(pose, amount), np.random.default_rng(0), object_pose=rest)
        assert result.status is expected, result.detail
    assert "|R^T R - I| up to 5e-05" in result.detail and result.sim_steps == 0


def test_a_pos_quat_grasp_with_a_bad_preshape_is_invalid_grasp(box):
    scene, rest, pose = box
    pos_quat = np.concatenate([pose[:3, 3], [0.0, 1.0, 0.0, 0.0]])  # 180 deg about x: approach down
    np.testing.assert_allclose(grasp_tcp_pose(Grasp(pos_quat)), pose, atol=1e-15)
    ok = PROTOCOLS.load("lift").run(scene, Grasp(pos_quat), np.random.default_rng(0), object_pose=rest)
    assert ok.status is Status.SUCCESS, ok.detail
    bad = PROTOCOLS.load("lift").run(scene, Grasp(pos_quat, preshape=1.5), np.random.default_rng(0), object_pose=rest)
    assert bad.status is Status.INVALID_GRASP and "pre-shape must be in [0, 1], got 1.5" in bad.detail
    assert "not a unit quaternion" in check_grasp(Grasp(np.concatenate([pose[:3, 3], [0.0, 1.1, 0.0, 0.0]])))


def test_rigid_defect_names_each_fault():
    assert "shape (3, 3)" in rigid_defect(np.eye(3))
    assert "NaN" in rigid_defect(np.full((4, 4), np.nan))
    assert "last row" in rigid_defect(np.diag([1.0, 1.0, 1.0, 2.0]))
    assert "det -1" in rigid_defect(np.diag([1.0, 1.0, -1.0, 1.0]))
    with pytest.raises(ValueError, match="^mount has a rotation block"):
        check_rigid(np.diag([2.0, 1.0, 1.0, 1.0]), "mount")


def test_as_grasp_keeps_the_candidates_joints_and_pregrasp_offset(box):
    _, _, pose = box
    candidate = GraspCandidate(pose=pose, score=1.0, pregrasp_offset=0.05, joints=np.zeros((2, 6)))
    grasp = as_grasp(candidate)
    assert grasp.pregrasp_offset == 0.05 and grasp.joints.shape == (2, 6)
    assert as_grasp(pose).pregrasp_offset is None and as_grasp(pose).joints is None


def test_the_grasps_pregrasp_offset_places_the_open_hand(box):
    """A candidate 3 cm back starts 3 cm back (the protocol's 10 cm is for grasps that carry no offset)."""
    scene, rest, pose = box
    starts = {}

    class Start:
        sample_period_s = float("inf")

        def __init__(self, key: str) -> None:
            self.key = key

        def on_start(self, scene, grasp, object_pose):
            pass

        def on_phase(self, scene, phase, detail=""):
            if str(getattr(phase, "value", phase)) == "approach":  # the hand is at the pre-grasp pose
                starts[self.key] = scene.tcp_pose()[2, 3]

        def on_sample(self, scene):
            pass

        def on_end(self, scene, result):
            pass

    for key, grasp in (("candidate", GraspCandidate(pose=pose, score=1.0, pregrasp_offset=0.03)),
                       ("bare", pose)):
        PROTOCOLS.load("lift").run(scene, grasp, np.random.default_rng(0), object_pose=rest, observer=Start(key))
    assert starts["candidate"] - pose[2, 3] == pytest.approx(0.03, abs=1e-6)
    assert starts["bare"] - pose[2, 3] == pytest.approx(0.10, abs=1e-6)


@pytest.mark.parametrize("offset, ok", [(0.0, True), (0.1, True), (1.0, True), (1.5, False), (1000.0, False)])
def test_a_pregrasp_offset_past_a_metre_is_an_invalid_candidate(offset, ok):
    """A planner's 1000 m offset was accepted and each trial waited out its whole time budget in the approach,
    stored as a timeout; now the candidate is refused (a planner error naming the bound)."""
    defect = candidate_defect(GraspCandidate(pose=np.eye(4), score=1.0, pregrasp_offset=offset))
    assert (defect is None) is ok
    if not ok:
        assert "in [0, 1] m back along the approach" in defect
