"""The per-finger guarded close (`FingerClose`, `GraspParams.close_mode` "per_finger").

Unit: the controller's logic on hand-made finger states (no simulation). Closed loop: a can grasped by hand (side
power grasp) under the `standard` protocol at 10 N: with the per-finger close every finger touches the can at the
end of the close, the grip force is at its target, and the can is not pushed away; the synergy close leaves the
Fourier hand's middle finger off the can. A parallel-jaw hand closes the same way in either mode.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from manigrasp import hands
from manigrasp.control import FingerClose
from manigrasp.control.fingers import CLOSING, PRELOAD, STOPPED, TOUCHED
from manigrasp.control.hybrid import STALL_S
from manigrasp.errors import ConfigError
from manigrasp.hands.placement import side_power_grasp
from manigrasp.planners.base import GraspCandidate
from manigrasp.protocol import PROTOCOLS, settle_object
from manigrasp.protocol.result import Phase
from manigrasp.sim import build_scene, grip_force, read_hand_contacts

DEXTEROUS = [n for n in ("inspire_right", "fourier_right", "allegro_right") if n in hands.names()]
DT = 0.01

# Three fingers (0 the thumb), one servo each, closing from 0 to 2 (lead 0.25 of the synergy to the force limit),
# and a fixed pre-shape joint (no finger; open = closed).
OPEN = np.array([0.0, 0.0, 0.0, 0.5])
CLOSED = np.array([2.0, 2.0, 2.0, 0.5])
FINGERS = np.array([0, 1, 2, -1])
LEADS = np.array([0.25, 0.25, 0.25, np.nan])


def _close(**kwargs) -> FingerClose:
    grip = FingerClose(OPEN, CLOSED, FINGERS, LEADS, 3, target_force=10.0, full_force=20.0, close_speed=2.0,
                       contact_force=0.5, touch_force=0.2, **kwargs)
    grip.reset(0.0)
    return grip


def test_fingers_close_on_their_own_until_each_touches() -> None:
    grip = _close()
    length = np.array([0.1, 0.1, 0.1, 0.5])  # each finger at synergy 0.05
    ctrl = grip.update(np.zeros(3), 0.0, length, DT)
    # the command ramps at close_speed from 0 (below the ceiling: the finger + its lead to the force limit)
    np.testing.assert_allclose(ctrl, [0.04, 0.04, 0.04, 0.5])
    length = np.array([0.6, 0.4, 0.2, 0.5])  # finger 1 (synergy 0.2) touches
    ctrl = grip.update(np.array([0.0, 1.0, 0.0]), 0.0, length, DT)
    assert grip.state.tolist() == [CLOSING, TOUCHED, CLOSING]
    # the touched finger is held just past where it stands; the others go on closing
    assert ctrl[1] == pytest.approx(0.4 + PRELOAD * 0.25 * 2.0)
    np.testing.assert_allclose(ctrl[[0, 2]], [0.08, 0.08])
    assert ctrl[3] == 0.5 and grip.mode == "position" and not grip.squeezing
    for _ in range(20):  # not touching: fingers 0 and 2 keep closing
        ctrl = grip.update(np.array([0.0, 1.0, 0.0]), 0.0, length + [0.01, 0, 0.01, 0], DT)
        length = length + [0.01, 0.0, 0.01, 0.0]
    assert ctrl[1] == pytest.approx(0.4 + PRELOAD * 0.25 * 2.0) and ctrl[0] > 0.5 and ctrl[2] > 0.5


def test_a_touched_finger_that_loses_the_object_before_the_squeeze_closes_again() -> None:
    grip = _close()
    length = np.array([0.2, 0.4, 0.2, 0.5])
    grip.update(np.array([0.0, 1.0, 0.0]), 0.0, length, DT)
    assert grip.state[1] == TOUCHED
    grip.update(np.zeros(3), 0.0, length, DT)
    assert grip.state[1] == CLOSING


def test_a_finger_that_stops_moving_is_stopped_and_the_squeeze_regulates_the_touched_ones() -> None:
    grip = _close()
    length = np.array([0.6, 0.6, 0.4, 0.5])
    forces = np.array([1.0, 1.0, 0.0])
    grip.update(forces, 0.0, length, DT)
    assert grip.state.tolist() == [TOUCHED, TOUCHED, CLOSING]
    for _ in range(int(STALL_S / DT) + 2):  # finger 2 blocked (by the table, say): it does not move
        ctrl = grip.update(forces, 0.0, length, DT)
    assert grip.state.tolist() == [TOUCHED, TOUCHED, STOPPED]
    assert ctrl[2] == pytest.approx(0.4 + PRELOAD * 0.25 * 2.0)  # held just past where it stopped
    assert grip.squeezing and grip.mode == "position"  # no finger closes: the squeeze began; no grip yet
    offsets = []
    for _ in range(10):  # the grip force below the target: the touched fingers are pushed on alike
        ctrl = grip.update(forces, 2.0, length, DT)
        offsets.append(grip.offset)
    assert grip.mode == "force" and np.all(np.diff(offsets) > 0)
    np.testing.assert_allclose(ctrl[:2] - length[:2], (PRELOAD * 0.25 + grip.offset) * 2.0)
    assert ctrl[2] == pytest.approx(0.4 + PRELOAD * 0.25 * 2.0)  # the stopped finger takes no part
    for _ in range(50):  # above the target: it backs off
        grip.update(forces, 14.0, length, DT)
    assert grip.offset < offsets[-1]
    assert grip.peak_force == 14.0


def test_the_squeeze_starts_after_wait_s_of_grip_with_a_finger_still_closing() -> None:
    grip = _close(wait_s=0.1)
    length = np.array([0.6, 0.6, 0.1, 0.5])
    for i in range(12):  # fingers 0 and 1 grip; finger 2 closes slowly
        grip.update(np.array([1.0, 1.0, 0.0]), 1.0, length + [0, 0, 0.01 * i, 0], DT)
    assert grip.squeezing and grip.state[2] == CLOSING


def test_a_close_without_a_touched_finger_is_stalled() -> None:
    grip = _close()
    length = np.array([1.995, 1.995, 1.995, 0.5])  # every finger at the end of its path, none touched
    grip.update(np.zeros(3), 0.0, length, DT)
    assert grip.state.tolist() == [STOPPED] * 3 and grip.stalled


def test_bad_arguments_are_refused() -> None:
    with pytest.raises(ConfigError):
        FingerClose(OPEN, CLOSED, FINGERS, LEADS, 3, target_force=30.0, full_force=20.0)
    with pytest.raises(ConfigError):
        FingerClose(OPEN, CLOSED, FINGERS[:3], LEADS, 3, target_force=10.0, full_force=20.0)


def test_close_mode_is_validated() -> None:
    with pytest.raises(ConfigError, match="close_mode"):
        PROTOCOLS.load("standard", close_mode="fingers")
    assert PROTOCOLS.load("standard", close_mode="per_finger").params.close_mode == "per_finger"


class _EndOfClose:
    """Reads the fingers' normal forces, the grip force and the object's push at the end of the close."""

    sample_period_s = float("inf")

    def __init__(self) -> None:
        self.start, self.forces, self.grip, self.push = None, None, np.nan, np.nan

    def on_start(self, scene, grasp, object_pose) -> None:  # noqa: D102
        pass

    def on_phase(self, scene, phase, detail: str = "") -> None:  # noqa: D102
        if phase is Phase.CLOSE:
            self.start = scene.object_pose()[:2, 3].copy()
        elif self.start is not None and self.forces is None:
            contacts = read_hand_contacts(scene)
            own = contacts.finger >= 0
            self.forces = np.bincount(contacts.finger[own], weights=np.clip(contacts.normal_force[own], 0, None),
                                      minlength=len(scene.hand.finger_bodies))
            self.grip = grip_force(contacts)
            self.push = float(np.linalg.norm(scene.object_pose()[:2, 3] - self.start))

    def on_sample(self, scene) -> None:  # noqa: D102
        pass

    def on_end(self, scene, result) -> None:  # noqa: D102
        pass


def _trial(scene, pose, object_pose, mode: str):
    seen = _EndOfClose()
    result = PROTOCOLS.load("standard", grip_force=10.0, close_mode=mode).run(
        scene, GraspCandidate(pose=pose, score=1.0), np.random.default_rng(0), deadline=time.monotonic() + 120,
        object_pose=object_pose, seed=0, observer=seen)
    return result, seen


@pytest.mark.parametrize("name", DEXTEROUS)
def test_per_finger_close_puts_every_finger_on_the_can_at_the_grip_force(name: str, can) -> None:
    scene = build_scene(hands.load(name), can)
    object_pose = settle_object(scene)
    pose = side_power_grasp(scene.hand, [object_pose[0, 3], object_pose[1, 3], scene.object_rest_height])
    result, seen = _trial(scene, pose, object_pose, "per_finger")
    assert result.status.value == "success", result.detail
    assert np.all(seen.forces > 0.5), seen.forces  # every finger presses on the can
    target = min(10.0, scene.hand.max_grip_force)  # the Allegro's maximum is 9 N
    assert seen.grip == pytest.approx(target, rel=0.1)
    assert result.max_translation_m < 0.002
    synergy, seen_synergy = _trial(scene, pose, object_pose, "synergy")
    assert synergy.status.value == "success", synergy.detail
    if name == "fourier_right":  # the synergy close stops at the grip force with the middle finger off the can
        assert seen_synergy.forces[2] == 0.0 and np.all(seen_synergy.forces[[0, 1, 3, 4]] > 0.5)
    if name != "allegro_right":  # the tendon fingers rest on the can before the squeeze: it is not pushed away
        assert seen.push < 0.005


def test_parallel_jaw_closes_alike_in_either_mode(box_scene) -> None:
    scene = box_scene.scene
    results = [PROTOCOLS.load("standard", close_mode=mode).run(
        scene, GraspCandidate(pose=box_scene.top_grasp, score=1.0), np.random.default_rng(0),
        deadline=time.monotonic() + 60, object_pose=box_scene.rest, seed=0) for mode in ("synergy", "per_finger")]
    assert results[0].status.value == "success"
    assert results[0].grip_force_n == results[1].grip_force_n
    assert results[0].max_translation_m == results[1].max_translation_m
