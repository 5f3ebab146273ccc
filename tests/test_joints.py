"""Per-grasp joint configurations (JOINTS.md): a dexterous grasp carries its own hand path
(row 0 pre-shape, row 1 squeeze target); the protocol drives the synergy along it, and refuses
joints that do not fit the hand as `invalid_grasp`."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from joint_planners import own_path, side_grasp

from manigrasp import hands, planners
from manigrasp.errors import PlannerError
from manigrasp.objects import build_object
from manigrasp.planners import GraspCandidate
from manigrasp.protocol import PROTOCOLS, Status, settle_object
from manigrasp.protocol.grasp import Grasp, check_grasp
from manigrasp.sim import build_scene

HAND = "fourier_right"


@pytest.fixture(scope="module")
def scene(can):
    return build_scene(hands.load(HAND), can)


class _Commands:
    """A trial observer keeping the hand's actuator commands at each phase's start."""

    def __init__(self) -> None:
        self.at: dict[str, np.ndarray] = {}

    def on_start(self, scene, grasp, object_pose) -> None:
        pass

    def on_phase(self, scene, phase, detail: str = "") -> None:
        self.at[str(getattr(phase, "value", phase))] = scene.data.ctrl[scene.hand_actuators].copy()

    def on_sample(self, scene) -> None:
        pass

    def on_end(self, scene, result) -> None:
        pass

    sample_period_s = float("inf")


@pytest.mark.slow
def test_a_grasp_with_its_own_joints_drives_that_path_and_holds_the_can(scene) -> None:
    rest = settle_object(scene)
    joints = own_path(scene.hand)
    watch = _Commands()
    candidate = GraspCandidate(pose=side_grasp(scene.hand, rest), score=1.0, joints=joints)
    result = PROTOCOLS.load("lift", finger_hold_gain=0.0).run(scene, candidate, np.random.default_rng(0),
                                                           object_pose=rest, observer=watch)
    assert result.status is Status.SUCCESS, result.detail
    np.testing.assert_allclose(watch.at["approach"], joints[0], atol=1e-12)  # the pre-shape is row 0
    # After closing, the command lies on the segment from row 0 toward row 1, strictly inside it.
    after, (start, end) = watch.at["lift"], joints
    moving = np.abs(end - start) > 1e-12
    s = (after[moving] - start[moving]) / (end - start)[moving]
    assert np.ptp(s) < 1e-9 and 0.0 < s[0] <= 1.0
    np.testing.assert_allclose(after, start + s[0] * (end - start), atol=1e-9)
    # ... which is not the hand's own path: its commands never leave that one.
    own = scene.hand.open_ctrl + s[0] * (scene.hand.closed_ctrl - scene.hand.open_ctrl)
    assert not np.allclose(after, own, atol=1e-3)
    # The scene is given the hand's own path back for what comes next.
    np.testing.assert_array_equal(scene.hand_path[0], scene.hand.open_ctrl)


def test_set_hand_path_moves_the_synergy_along_the_given_rows(scene) -> None:
    hand = scene.hand
    joints = own_path(hand)
    scene.set_hand_path(*joints)
    scene.set_synergy(0.25)
    np.testing.assert_allclose(scene.data.ctrl[scene.hand_actuators], 0.75 * joints[0] + 0.25 * joints[1])
    scene.set_hand_path()
    scene.set_synergy(0.25)
    np.testing.assert_allclose(scene.data.ctrl[scene.hand_actuators], hand.synergy_ctrl(0.25))
    with pytest.raises(ValueError, match="two finite rows"):
        scene.set_hand_path(joints[0][:-1], joints[1])


def _bad_joints(hand: hands.Hand, low: np.ndarray, high: np.ndarray) -> dict[str, object]:
    good = own_path(hand)
    nan = good.copy()
    nan[1, 2] = np.nan
    outside = good.copy()
    limited = int(np.flatnonzero(np.isfinite(high))[-1])
    outside[1, limited] = high[limited] + 0.1
    return {"shape": good[:, :-1], "rows": good[:1], "NaN": nan, "ctrlrange": outside,
            "equal": np.stack([good[0], good[0]])}


@pytest.mark.parametrize("defect, message", [("shape", "must be (2, 6)"), ("rows", "must be (2, 6)"),
                                             ("NaN", "NaN"), ("ctrlrange", "outside its ctrlrange"),
                                             ("equal", "rows are equal")])
def test_joints_that_do_not_fit_the_hand_are_invalid_grasp(scene, defect: str, message: str) -> None:
    rest = settle_object(scene)
    low, high = scene.hand_ctrlrange().T
    joints = _bad_joints(scene.hand, low, high)[defect]
    grasp = Grasp(pose=side_grasp(scene.hand, rest), joints=np.asarray(joints))
    result = PROTOCOLS.load("lift").run(scene, grasp, np.random.default_rng(0), object_pose=rest)
    assert result.status is Status.INVALID_GRASP and message in result.detail, result.detail
    assert result.sim_steps == 0


def test_joints_on_a_parallel_hand_are_invalid_and_a_planner_returning_them_is_refused(tmp_path) -> None:
    box = build_object(trimesh.creation.box((0.05,) * 3), name="box_joints", mass=0.2, cache_root=tmp_path).asset
    scene = build_scene("parallel_jaw", box)
    rest = settle_object(scene)
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[:3, 3] = rest[:3, 3]
    joints = np.zeros((2, scene.hand.n_actuators))
    result = PROTOCOLS.load("lift").run(scene, Grasp(pose=pose, joints=joints), np.random.default_rng(0),
                                        object_pose=rest)
    assert result.status is Status.INVALID_GRASP and "parallel hand" in result.detail
    assert check_grasp(Grasp(pose=pose), scene.hand) is None  # the same grasp without joints is fine

    class WithJoints:
        name, needs = "with_joints", "mesh"

        def __init__(self, joints: np.ndarray) -> None:
            self.joints = joints

        def plan(self, observation, hand, n, rng):
            return [GraspCandidate(pose=pose, score=1.0, joints=self.joints)]

    observation = planners.Observation.from_asset(box, rest)
    with pytest.raises(PlannerError, match="parallel hand"):
        planners.plan(WithJoints(joints), observation, scene.hand, 1, np.random.default_rng(0))
    fourier = hands.load(HAND)
    with pytest.raises(PlannerError, match=r"must be \(2, 6\)"):
        planners.plan(WithJoints(np.zeros((2, 5))), observation, fourier, 1, np.random.default_rng(0))
    with pytest.raises(PlannerError, match="NaN"):
        planners.plan(WithJoints(np.full((2, 6), np.nan)), observation, fourier, 1, np.random.default_rng(0))
