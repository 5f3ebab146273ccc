"""The parallel-jaw grip reaches the commanded grip force at any width (closed loop, the protocol's close phase).

A box `width` thick across the jaws stands on the table, the hand's TCP at its centre; the standard
protocol's close phase (`protocol.phases.close`: `GripController` at the control rate, then the finger
command held where it left it) closes on it, and the grip force is read after a further hold. A closed
command of width 0 on the 2000 N/m servo capped the push at 2000 x width (8 N on a 4 mm rim against the
35 N target); the closed command past the stop and the loop gain from the servo's own stiffness reach
the target within a few percent at every width, with rigid and with compliant pads, except where the jaw is
already at its closed stop: the Panda's 8 mm compliant pads need 3.2 mm of compression each for 35 N, more than a
4 mm object leaves them (0.92 of the target there).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from manigrasp import hands
from manigrasp.control import GripController
from manigrasp.protocol import phases
from manigrasp.protocol.execution import Abort, GraspParams, TrialRun
from manigrasp.protocol.result import Status
from manigrasp.sim import SceneConfig, build_scene, current_grip_force

HEIGHT, MASS = 0.06, 0.1  # [m] box height and depth, [kg]
WIDTHS = (0.004, 0.008, 0.013, 0.025, 0.05, 0.075)  # [m] a bowl rim, scissors, a mug wall ... the widest box
HOLD_S = 0.3  # [s] after the close phase, with the finger command held


def _box(width: float) -> mujoco.MjSpec:
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="object")
    body.add_freejoint()
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[HEIGHT / 2, width / 2, HEIGHT / 2], mass=MASS)
    return spec


def _close(hand: hands.Hand, width: float | None, pads: str, params: GraspParams) -> tuple[TrialRun, Status | None]:
    """Close the standard protocol's way on a box of `width` (None: nothing), hold HOLD_S; (run, abort status).
    `run.close_s` is how long the close phase took [s]."""
    scene = build_scene(hand, None if width is None else _box(width), SceneConfig(pads=pads))
    run = TrialRun(scene, params, None)
    grasp = np.diag([1.0, -1.0, -1.0, 1.0])  # approach down, closing along -y
    grasp[2, 3] = HEIGHT / 2
    rest = np.eye(4)
    rest[2, 3] = HEIGHT / 2
    run.reset(grasp, rest, 0.0)
    status = None
    try:
        phases.close(run, 0.0, metrics=False)
    except Abort as abort:
        status = abort.status
    run.close_s = run.sim_time
    run.hold_for(HOLD_S)
    return run, status


@pytest.mark.parametrize("pads", ["rigid", "compliant"])
@pytest.mark.parametrize("name", ["parallel_jaw", "panda", "robotiq_2f85"])
def test_held_grip_force_is_the_target_at_every_width(name: str, pads: str) -> None:
    hand = hands.load(name)
    params = GraspParams()  # the standard protocol: half the hand's maximum
    target = params.grip_force_fraction * hand.max_grip_force
    held, stopped = {}, {}
    for width in WIDTHS:
        if width < 0.95 * hand.max_width:
            run, status = _close(hand, width, pads, params)
            assert status is None, f"{1000 * width:g} mm: {status}"
            held[width] = current_grip_force(run.scene)
            stopped[width] = _at_closed_stop(run.scene)
    assert min(held) == WIDTHS[0] and max(held) >= 0.07
    ratio = {f"{1000 * w:g} mm": round(f / target, 3) for w, f in held.items()}
    # Only a jaw already at its closed stop may hold less: the Panda's 8 mm compliant pads need 3.2 mm of
    # compression each for 35 N, more than a 4 mm object leaves them before the fingers reach their stop
    # (`pads.clear_backing`); never more than the target, and never short anywhere else.
    for r, width in zip(ratio.values(), held, strict=True):
        short_at_stop = stopped[width] and 0.8 < r <= 1.05
        assert abs(r - 1) < 0.05 or short_at_stop, f"held / target {target:.1f} N: {ratio}, at stop: {stopped}"
    assert pads == "compliant" or not any(stopped.values()), f"rigid pads reached the stop: {stopped}"


def _at_closed_stop(scene) -> bool:
    """Whether a joint of the hand's finger bodies (not the pads' element bodies below them) is within 0.2 mm (or
    0.2 mrad) of a limit of its range, or past it (a squeezing jaw can only be at its closed one)."""
    m, d = scene.model, scene.data
    fingers = {m.body(f"hand/{f}").id for f in scene.hand.finger_bodies}
    kinds = (int(mujoco.mjtJoint.mjJNT_SLIDE), int(mujoco.mjtJoint.mjJNT_HINGE))
    limited = [j for j in range(m.njnt) if m.jnt_limited[j] and m.jnt_type[j] in kinds and m.jnt_bodyid[j] in fingers]
    assert limited, "no limited finger joint"
    q = np.array([d.qpos[m.jnt_qposadr[j]] for j in limited])
    lo, hi = m.jnt_range[limited].T
    return bool(np.any(np.minimum(q - lo, hi - q) < 2e-4))


@pytest.mark.parametrize("target", [5.0, 60.0])
def test_parallel_jaw_holds_a_set_grip_force_on_a_thin_and_a_wide_box(target: float) -> None:
    hand = hands.load("parallel_jaw")
    for width in (0.004, 0.07):
        run, status = _close(hand, width, "rigid", GraspParams(grip_force=target))
        assert status is None
        assert current_grip_force(run.scene) == pytest.approx(target, rel=0.05), f"{1000 * width:g} mm"


@pytest.mark.parametrize("pads", ["rigid", "compliant"])
def test_parallel_jaw_empty_close_ends_at_the_joint_stop(pads: str) -> None:
    run, status = _close(hands.load("parallel_jaw"), None, pads, GraspParams())
    assert status is Status.NO_CONTACT  # not unstable: the stops take the closed command's push
    # the jaw stops at width 0 (synergy 0.70, the closed command is past it): the close ends once the fingers
    # stand still there (`GripController.stalled`), not at the protocol's 2 s timeout
    assert run.close_s < 0.8
    scene = run.scene
    width = float(scene.data.actuator_length[scene.hand_actuators][0])
    assert -0.002 < width < 0.001  # the fingers at their closed stops (width 0), not through each other
    assert np.all(np.abs(scene.data.qvel) < 0.05)


PARALLEL = [n for n in hands.names() if hands.load(n).kind == "parallel"]


@pytest.mark.parametrize("name", PARALLEL)
def test_every_parallel_jaw_empty_close_ends_when_the_fingers_stall(name: str) -> None:
    # the Robotiq 2F-85 has no grip_stiffness (its linkage's is not constant): its empty close ran to the 2 s
    # timeout, its pads meeting at synergy 0.81, short of the 0.995 that ends a position-mode close
    run, status = _close(hands.load(name), None, "rigid", GraspParams())
    assert status is Status.NO_CONTACT
    assert run.close_s < 0.8
    assert np.all(np.abs(run.scene.data.qvel) < 0.05)


@pytest.mark.parametrize("name", ["parallel_jaw", "panda"])
def test_closed_command_pushes_at_the_force_limit_at_every_width(name: str) -> None:
    """Analytic: kp x (width - closed command) >= max_grip_force for every width in [0, max_width], and the
    hand's grip_stiffness is kp x span (both hands' tendon force is each pad's push)."""
    hand = hands.load(name)
    model = hand.build_spec().compile()
    act = model.actuator(hand.actuators[0])
    kp, limit = float(act.gainprm[0]), float(act.forcerange[1])
    closed, opened = float(hand.closed_ctrl[0]), float(hand.open_ctrl[0])
    assert act.ctrlrange[0] <= closed and limit == pytest.approx(hand.max_grip_force)
    assert kp * (0.0 - closed) >= hand.max_grip_force - 1e-9  # the narrowest: width 0
    assert hand.grip_stiffness == pytest.approx(kp * (opened - closed))


def _regulate(controller: GripController, contact: float, stiffness: float, seconds: float = 0.3) -> list[float]:
    """Grip force [N] per 10 ms tick of `controller` from the tick it touches a jaw blocked at synergy `contact`
    on, for `seconds`: F = stiffness (s - contact), capped at the controller's full force (a static plant)."""
    dt, force, forces = 0.01, 0.0, []
    controller.reset(contact - 0.05)
    s = controller.update(0.0, dt, contact - 0.05)
    while len(forces) < seconds / dt:
        force = float(np.clip(stiffness * (s - contact), 0.0, controller.full_force))
        s = controller.update(force, dt, min(s, contact))
        if force > 0 or forces:
            forces.append(force)
    return forces


def test_known_stiffness_regulates_at_the_same_rate_at_every_width() -> None:
    """With the servo's stiffness k the force loop is the same at every contact synergy (width) and meets the
    target from the first tick; with the old estimate full_force / (1 - s_c) the loop gain is k (1 - s_c) /
    full_force times its design: slow where the jaw meets the object late (a narrow grip)."""
    k, target, full = 230.0, 35.0, 70.0
    known = [_regulate(GripController(target, full, close_speed=2.0, stiffness=k), c, k) for c in (0.1, 0.4, 0.65)]
    for forces in known:
        assert forces[1:] == pytest.approx([target] * (len(forces) - 1), rel=1e-6)
    # a plant 20 % softer than the model (compliant pads in series): the integral brings it to the target
    soft = _regulate(GripController(target, full, close_speed=2.0, stiffness=k), 0.4, 0.8 * k)
    assert soft[1] == pytest.approx(0.8 * target, rel=0.01) and soft[-1] == pytest.approx(target, rel=0.03)
    # the estimate on a narrow grip (contact at 0.65 of a 0 ... 1 span whose force reaches `full` at s = 1 + 0.3)
    estimated = _regulate(GripController(target, full, close_speed=2.0), 0.65, k)
    assert abs(estimated[10] - target) > 0.1 * target


def test_a_brush_on_the_way_in_does_not_start_the_force_phase_early() -> None:
    """A grip force pulse at synergy 0.15 (a pad brushing a rim), then none while the fingers move on: the
    controller returns to the position phase and regulates from the real contact at 0.57 (static plant)."""
    k, target, dt = 230.0, 35.0, 0.01
    grip = GripController(target, 70.0, close_speed=2.0, stiffness=k)
    grip.reset(0.0)
    hand, s, modes, force = 0.0, 0.0, [], 0.0
    for _ in range(100):
        hand = min(s, 0.57)  # the fingers follow the command until the object stops them
        force = 5.0 if 0.13 < hand < 0.17 else float(np.clip(k * (s - 0.57), 0.0, 70.0))
        s = grip.update(force, dt, hand)
        modes.append(grip.mode)
    switches = [m for i, m in enumerate(modes) if i == 0 or m != modes[i - 1]]
    assert switches == ["position", "force", "position", "force"]  # the brush, closing on, the object
    assert grip.mode == "force" and grip.contact_synergy == pytest.approx(0.57)
    assert force == pytest.approx(target, rel=1e-6)


def test_an_object_squeezed_out_of_the_grip_is_not_a_brush() -> None:
    """A grip that carried the target and is then lost (the object squeezed out) stays in the force phase: the
    protocol's lift judges it, the controller does not close on as if nothing had been touched."""
    grip = GripController(35.0, 70.0, close_speed=2.0, stiffness=230.0)
    grip.reset(0.5)
    grip.update(5.0, 0.01, 0.5)
    grip.update(40.0, 0.01, 0.5)
    grip.update(0.0, 0.01, 0.6)
    assert grip.mode == "force" and grip.contact_synergy == pytest.approx(0.5)
    assert grip.peak_force == pytest.approx(40.0)  # what close() names in its `no_contact` detail
    grip.reset(0.0)
    assert grip.peak_force == 0.0


@pytest.mark.parametrize("bad", [0.0, -230.0, float("nan")])
def test_a_hand_with_a_bad_grip_stiffness_is_refused(bad: float) -> None:
    from dataclasses import replace

    from manigrasp.errors import ConfigError, HandError
    from manigrasp.hands.validate import validate_hand

    with pytest.raises(HandError, match="grip_stiffness must be a positive finite number or None"):
        validate_hand(replace(hands.load("parallel_jaw"), grip_stiffness=bad))
    with pytest.raises(ConfigError, match="grip stiffness must be finite and > 0"):
        GripController(35.0, 70.0, stiffness=bad)
