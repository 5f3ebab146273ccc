"""Where the fingers are along the hand's path (`Scene.finger_synergies`, `hand_synergy`), how far the closing
command may run ahead of them (`Scene.closing_reach`, `GripController`'s ceiling), and the stall check.

Fixed pre-shape joints (open command = closed command: the five-finger hands' thumb rotation, the Allegro's
spread and thumb rotation) are neither open nor closed and take no part in the estimate. The ceiling of the
position phase is max(hand synergy + lead, reach): a soft servo lags a ramp by its rate times its time constant,
so a fixed lead would set how fast it closes; the reach is the lead each finger's servo can still use (its force
limit / (kp x span)).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from manigrasp import hands
from manigrasp.control import GripController
from manigrasp.hands.from_robosuite.dexterous import KP
from manigrasp.sim import build_scene


def _fixed(hand: hands.Hand) -> np.ndarray:
    return np.isclose(hand.open_ctrl, hand.closed_ctrl)


@pytest.mark.parametrize("name", [n for n in hands.names() if n.startswith(("fourier", "allegro"))])
def test_fixed_preshape_joints_are_left_out_of_the_hand_synergy(name: str) -> None:
    hand = hands.load(name)
    scene = build_scene(hand, None)
    fixed = _fixed(hand)
    assert fixed.any()  # the thumb rotation (and the Allegro's spread): open = closed
    assert len(scene.finger_synergies()) == int((~fixed).sum())
    assert scene.hand_synergy() == pytest.approx(0.0, abs=1e-9)  # the open hand is open, not 1/6 closed
    # Every moving joint halfway along its path: the synergy is a half, whatever the fixed joints do.
    m, d = scene.model, scene.data
    for act, lo, hi in zip(scene.hand_actuators, hand.open_ctrl, hand.closed_ctrl, strict=True):
        if m.actuator_trntype[act] == mujoco.mjtTrn.mjTRN_JOINT and lo != hi:
            joint = m.actuator_trnid[act, 0]
            d.qpos[m.jnt_qposadr[joint]] = (lo + hi) / 2
    if all(m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT for a in scene.hand_actuators):
        scene.forward()
        np.testing.assert_allclose(scene.finger_synergies(), 0.5, atol=1e-9)
        assert scene.hand_synergy() == pytest.approx(0.5)


def test_closing_reach_is_the_lead_that_brings_the_first_finger_servo_to_its_force_limit() -> None:
    hand = hands.load("fourier_right")
    scene = build_scene(hand, None)
    span = hand.closed_ctrl - hand.open_ctrl
    # Open hand: a finger's tendon (0.6 N m over a 4.7 rad span) reaches its limit first, the thumb bend's
    # (0.9 N m over 4.26 rad) further ahead.
    thumb, finger = 0.9 / (KP * span[1]), 0.6 / (KP * span[2])
    assert scene.closing_reach() == pytest.approx(min(thumb, finger))
    assert 0.25 < scene.closing_reach() < 0.26
    # A grasp's path on which only the thumb bends: its own lead.
    scene.set_hand_path(hand.open_ctrl, np.where(np.arange(6) == 1, hand.closed_ctrl, hand.open_ctrl))
    assert scene.closing_reach() == pytest.approx(thumb)
    jaw = hands.load("parallel_jaw")
    scene = build_scene(jaw, None)
    kp, limit = scene.model.actuator_gainprm[scene.hand_actuators[0], 0], scene.model.actuator_forcerange[
        scene.hand_actuators[0], 1]
    assert scene.closing_reach() == pytest.approx(scene.hand_synergy() + limit / (kp * abs(jaw.closed_ctrl[0]
                                                                                        - jaw.open_ctrl[0])))


def test_position_phase_ceiling_is_the_larger_of_the_lead_and_the_reach() -> None:
    def first_command(hand_synergy: float, reach: float | None) -> float:
        grip = GripController(10.0, 20.0, close_speed=100.0, lead=0.1)  # a ramp that always hits the ceiling
        return grip.update(0.0, 0.01, hand_synergy, reach)

    assert first_command(0.2, None) == pytest.approx(0.3)
    assert first_command(0.2, 0.55) == pytest.approx(0.55)  # a soft servo's usable lead
    assert first_command(0.2, 0.25) == pytest.approx(0.3)  # never below hand synergy + lead
    assert first_command(0.95, 1.4) == 1.0
    assert GripController(10.0, 20.0, close_speed=1.0).update(0.0, 0.01, 0.0, 0.9) == pytest.approx(0.01)


def test_stall_check_follows_the_known_stiffness_unless_set() -> None:
    def stalls(**kwargs) -> bool:
        grip = GripController(10.0, 20.0, **kwargs)
        for _ in range(20):  # 0.2 s of fingers standing still at 0.5, nothing touched
            grip.update(0.0, 0.01, 0.5)
        return grip.stalled

    assert stalls(stiffness=230.0)
    assert not stalls()  # an estimated stiffness (the dexterous hands): closes until the timeout
    assert stalls(stall_check=True)  # the protocol asks it of every parallel-jaw hand
    assert not stalls(stiffness=230.0, stall_check=False)
