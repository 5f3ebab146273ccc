"""`FingerHold` per finger: a finger with several closing servos may have its joint configuration held (no force
floor), a finger that one actuator closes follows the object with the floor; `Scene.actuator_fingers` tells them
apart, and the protocols' `finger_hold` chooses (`phases.joint_held_fingers`: by default the fingers that touch with
their distal phalanx only, `Scene.distal_body`).

Closed loop: an Allegro fingertip grasp of the mug (planned by dexopt, stored below) turned 8.7 deg in the hand
during the lift and hold when every held joint followed the object at `FLOOR` of its force (its fingers curled
on and rolled it, `finger_hold: floor`); with the fingers' joints held (the default for fingertip contacts) it
turns 2.9 deg.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
import pytest

from manigrasp.control import FingerHold
from manigrasp.control.hold import FLOOR
from manigrasp.geometry import pose_distance, relative_pose
from manigrasp.protocol.result import Phase

# Three hinged links, each turned by its position servo against its own stop (the closing direction: negative).
LINKS = """
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
""" + "".join(f"""
    <geom type="box" size="0.01 0.01 0.05" pos="{x + 0.06} 0.1 0"/>
    <body name="link{i}" pos="{x} 0 0">
      <joint name="hinge{i}" type="hinge" axis="0 0 1" damping="0.01"/>
      <geom type="capsule" fromto="0 0 0 0 0.1 0" size="0.01"/>
    </body>""" for i, x in enumerate((0.0, 1.0, 2.0))) + """
  </worldbody>
  <actuator>
""" + "".join(f"""
    <position name="servo{i}" joint="hinge{i}" kp="0.5" kv="0.05" ctrlrange="-1 3" forcerange="-0.6 0.6"/>"""
              for i in range(3)) + """
  </actuator>
</mujoco>
"""
CLOSING = np.array([-1.0, -1.0, -1.0])


def _pressed() -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(LINKS)
    data = mujoco.MjData(model)
    data.ctrl[:] = -1.0
    mujoco.mj_step(model, data, nstep=2000)
    assert data.ncon >= 3
    return model, data


def test_servos_of_one_finger_are_held_without_a_floor_a_lone_servo_keeps_it() -> None:
    """Links 0 and 1 are two joints of finger 0, link 2 is finger 1 alone: pushed 0.05 rad further closed (the
    object moved away), the lone servo still pushes FLOOR f, the shared ones push nothing; pushed open 0.01 rad,
    each resists with its held stiffness, 20 x 0.5 x 0.01 = 0.1 N m more."""
    model, data = _pressed()
    force0 = data.actuator_force.copy()
    assert np.all((force0 < -0.1) & (force0 > -0.6))  # each presses its stop below its limit
    FingerHold(model, np.arange(3), gain=20.0, fingers=np.array([0, 0, 1])).engage(data, CLOSING, (0, 1))
    np.testing.assert_allclose(model.actuator_forcerange[:, 1], [0.0, 0.0, FLOOR * force0[2]], rtol=1e-3)
    mujoco.mj_forward(model, data)
    q0 = data.qpos.copy()
    data.qpos[:] = q0 - 0.05
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.actuator_force, [0.0, 0.0, FLOOR * force0[2]], atol=1e-3)
    data.qpos[:] = q0 + 0.01
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.actuator_force - force0, -0.1, atol=1e-3)


def test_without_fingers_every_held_servo_keeps_the_floor() -> None:
    model, data = _pressed()
    force0 = data.actuator_force.copy()
    FingerHold(model, np.arange(3), gain=20.0).engage(data, CLOSING, (0, 1))
    np.testing.assert_allclose(model.actuator_forcerange[:, 1], FLOOR * force0, rtol=1e-3)


def test_a_finger_not_named_to_hold_its_joints_keeps_the_floor_on_each() -> None:
    model, data = _pressed()
    force0 = data.actuator_force.copy()
    FingerHold(model, np.arange(3), gain=20.0, fingers=np.array([0, 0, 1])).engage(data, CLOSING, (1,))
    np.testing.assert_allclose(model.actuator_forcerange[:, 1], FLOOR * force0, rtol=1e-3)


def test_a_finger_with_one_closing_servo_keeps_the_floor_even_if_others_of_it_do_not_close() -> None:
    model, data = _pressed()
    force0 = data.actuator_force.copy()
    FingerHold(model, np.arange(3), gain=20.0, fingers=np.array([0, 0, 1])).engage(data, np.array([-1.0, 0.0, -1.0]))
    assert model.actuator_forcerange[0, 1] == pytest.approx(FLOOR * force0[0], rel=1e-3)


def test_given_forces_are_pressed_both_ways_within_each_servos_limit() -> None:
    """`engage(forces=...)` (the balanced hold): a held servo presses the force given, opening as well as closing,
    within its own 0.6 N m; NaN leaves a servo as engaged; release gives the model's force ranges back."""
    model, data = _pressed()
    force0 = data.actuator_force.copy()
    hold = FingerHold(model, np.arange(3), gain=20.0, fingers=np.array([0, 0, 1]))
    hold.engage(data, CLOSING, (0, 1), forces=np.array([0.2, -0.9, np.nan]))
    np.testing.assert_allclose(model.actuator_forcerange[:2], [[-0.6, 0.6], [-0.6, 0.6]])
    assert model.actuator_forcerange[2, 1] == pytest.approx(FLOOR * force0[2], rel=1e-3)
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.actuator_force[:2], [0.2, -0.6], atol=1e-9)  # -0.9 clipped to the limit
    assert data.actuator_force[2] == pytest.approx(force0[2], rel=1e-3)
    hold.release()
    np.testing.assert_array_equal(model.actuator_forcerange, [[-0.6, 0.6]] * 3)
    with pytest.raises(Exception, match="forces must be"):
        hold.engage(data, CLOSING, (0, 1), forces=np.zeros(2))


def test_given_forces_keep_a_lopsided_servo_range_as_it_is() -> None:
    """A servo of range [-0.2, 0.6] given -0.5 presses -0.2 and keeps its 0.6 closing strength (the first version cut
    such a range to +-0.2, and a one-sided one to nothing)."""
    model = mujoco.MjModel.from_xml_string(LINKS.replace('forcerange="-0.6 0.6"', 'forcerange="-0.2 0.6"', 1))
    data = mujoco.MjData(model)
    data.ctrl[:] = -1.0
    mujoco.mj_step(model, data, nstep=2000)
    FingerHold(model, np.arange(3), gain=20.0, fingers=np.array([0, 0, 1])).engage(
        data, CLOSING, (0, 1), forces=np.array([-0.5, 0.5, np.nan]))
    np.testing.assert_allclose(model.actuator_forcerange[:2], [[-0.2, 0.6], [-0.6, 0.6]])
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.actuator_force[:2], [-0.2, 0.5], atol=1e-9)


def test_fingers_must_match_the_actuators() -> None:
    from manigrasp.errors import ConfigError

    model, _ = _pressed()
    with pytest.raises(ConfigError, match="fingers"):
        FingerHold(model, np.arange(3), fingers=np.array([0, 1]))


def test_actuator_fingers_of_tendon_hands() -> None:
    """Each finger tendon of the five-finger hands moves one finger (thumb first); the thumb's rotation turns
    the thumb's base, outside its finger body."""
    from manigrasp.sim import build_scene

    scene = build_scene("inspire_right")
    np.testing.assert_array_equal(scene.actuator_fingers, [-1, 0, 1, 2, 3, 4])


# ------------------------------------------------------------------------------------------ closed loop (Allegro)
# dexopt's grasp 1 of 025_mug for allegro_right (configs: dexterous objects, seed 0, 5 grasps, `standard` at 10 N;
# stored by `manigrasp bench` at fd0aae5): TCP pose in the world and the hand path (pre-shape, squeeze).
MUG_POSE = np.array([[0.7748585962792984, -0.5477598440067459, 0.3155206951465797, -0.010766697618311174],
                     [-0.3066383302039924, -0.7621793021725871, -0.5701365150465418, 0.03118445302444883],
                     [0.5527812317922731, 0.3450244406319843, -0.758545348113614, 0.07338808675880482],
                     [0.0, 0.0, 0.0, 1.0]])
MUG_JOINTS = np.array([
    [-0.4236496072364861, 0.4702916522534879, 0.7189727739408587, 0.44445479213300143, -0.2901019697123088, -0.196,
     -0.174, 0.3999091956730058, -0.3633338489590428, 0.2991973430218138, 0.5038875173294259, 0.8820541479154507,
     1.223728757233764, 0.8357373760580775, -0.189, -0.162],
    [-0.4236496072364861, 2.205498483651973, 1.6249965504469288, 0.6764591106613932, -0.2901019697123088, 2.31,
     1.9713722974381627, 1.4522996435518118, -0.3633338489590428, 1.9869788939326736, 1.298780630796148,
     0.9862057747245528, 1.223728757233764, 0.8357373760580775, 2.344, 1.0680960247080167]])


class _TurnInHand:
    """Observer: the object's rotation in the hand from the start of the lift to the first perturbation [deg]."""

    sample_period_s = float("inf")

    def __init__(self) -> None:
        self.start = None
        self.turn = np.nan

    def on_start(self, scene, grasp, object_pose) -> None:  # noqa: D102
        pass

    def on_phase(self, scene, phase, detail: str = "") -> None:  # noqa: D102
        in_hand = relative_pose(scene.tcp_pose(), scene.object_pose())
        if phase == Phase.LIFT:
            self.start = in_hand
        elif phase == Phase.PERTURB and self.start is not None and np.isnan(self.turn):
            self.turn = pose_distance(self.start, in_hand)[1]

    def on_sample(self, scene) -> None:  # noqa: D102
        pass

    def on_end(self, scene, result) -> None:  # noqa: D102
        pass


@pytest.mark.parametrize("mode", ["fingertips", "floor", "balanced"])
def test_allegro_fingertip_grasp_of_the_mug_does_not_roll_during_the_lift(mode: str, monkeypatch) -> None:
    """Under `finger_hold: fingertips` the grasp's fingers, touching with their tips only, keep their joints: under
    5 deg of turn (2.9 deg measured); with the floor on every joint they curl on and roll the mug (10.2). "balanced"
    (the default) holds it as well, its fingers pressing the least-friction forces (`phases.balanced_torques`), each
    joint within the servo's 0.7 N m."""
    pytest.importorskip("cmeel", reason="the Allegro hand needs the 'allegro' extra (example-robot-data)")
    from manigrasp.objects import catalog
    from manigrasp.planners.base import GraspCandidate
    from manigrasp.protocol import PROTOCOLS, settle_object
    from manigrasp.sim import build_scene

    asset = catalog.build(catalog.ObjectSource(name="025_mug", recipe="025_mug", mass=0.118)).asset
    scene = build_scene("allegro_right", asset)
    np.testing.assert_array_equal(scene.actuator_fingers, [1] * 4 + [2] * 4 + [3] * 4 + [0] * 4)
    object_pose = settle_object(scene)
    watch = _TurnInHand()
    from manigrasp.protocol import phases

    pressed = []
    balanced = phases.balanced_torques
    monkeypatch.setattr(phases, "balanced_torques", lambda *a: pressed.append(balanced(*a)) or pressed[-1])
    result = PROTOCOLS.load("standard", grip_force=10.0, finger_hold=mode).run(
        scene, GraspCandidate(pose=MUG_POSE, score=1.0, preshape=0.0, joints=MUG_JOINTS), np.random.default_rng(0),
        deadline=time.monotonic() + 300, object_pose=object_pose, observer=watch, seed=0)
    assert np.isfinite(watch.turn), result.detail  # the grasp was lifted and held
    if mode == "floor":
        assert watch.turn > 7.0 and not pressed
    else:
        assert watch.turn < 5.0
    if mode == "balanced":
        (torques,) = pressed
        given = torques[np.isfinite(torques)]
        assert len(given) >= 8 and np.all(np.abs(given) <= 0.7 + 1e-9) and np.abs(given).max() > 0.05


def test_distal_bodies_of_the_hands() -> None:
    """`Scene.distal_body`: the bodies past each finger's last joint (the Allegro's distal links and the tip bodies
    welded to them; the five-finger hands' last link of each finger), no palm or inner link."""
    from manigrasp.sim import build_scene

    scene = build_scene("inspire_right")
    names = {scene.model.body(int(b)).name for b in scene.hand_bodies if scene.distal_body[b]}
    assert names == {f"hand/r_{f}_distal" for f in ("thumb", "index", "middle", "ring", "pinky")}
    pytest.importorskip("cmeel", reason="the Allegro hand needs the 'allegro' extra (example-robot-data)")
    scene = build_scene("allegro_right")
    names = {scene.model.body(int(b)).name for b in scene.hand_bodies if scene.distal_body[b]}
    assert names == {f"hand/link_{j}.0{tip}" for j in (3, 7, 11, 15) for tip in ("", "_tip")}


def test_compliant_pad_elements_belong_to_the_phalanx_they_sit_on() -> None:
    """A user's Allegro with pads on the index's middle and distal boxes: the pads' elements ride on slide joints
    (`hands.pads`), which must not make the distal link look inner nor a middle-phalanx pad look distal."""
    import dataclasses

    from manigrasp import hands
    from manigrasp.sim import build_scene

    pytest.importorskip("cmeel", reason="the Allegro hand needs the 'allegro' extra (example-robot-data)")
    base = hands.load("allegro_right")

    def spec() -> mujoco.MjSpec:
        out = base.build_spec()
        for link in ("link_2.0", "link_3.0"):
            [box] = [g for g in out.body(link).geoms if g.type == mujoco.mjtGeom.mjGEOM_BOX]
            box.name = f"pad_{link}"
        return out

    scene = build_scene(dataclasses.replace(base, name="allegro_padded", build_spec=spec,
                                            pad_geoms=("pad_link_2.0", "pad_link_3.0")))
    names = {int(b): scene.model.body(int(b)).name for b in scene.hand_bodies}
    middle = [b for b, n in names.items() if n.startswith("hand/padel_pad_link_2.0")]
    distal = [b for b, n in names.items() if n.startswith("hand/padel_pad_link_3.0")]
    assert middle and distal
    assert not scene.distal_body[middle].any() and scene.distal_body[distal].all()
    assert scene.distal_body[scene.model.body("hand/link_3.0").id]
    assert not scene.distal_body[scene.model.body("hand/link_2.0").id]


def test_fingers_held_in_their_joints_by_mode() -> None:
    """`joint_held_fingers`: "fingertips" holds the joints of every finger but one touching with an inner link, and
    none in a grasp the palm touches."""
    from manigrasp.protocol.phases import joint_held_fingers
    from manigrasp.sim import HandContacts, build_scene

    pytest.importorskip("cmeel", reason="the Allegro hand needs the 'allegro' extra (example-robot-data)")
    scene = build_scene("allegro_right")
    body = {name: scene.model.body(f"hand/{name}").id for name in ("link_3.0_tip", "link_6.0", "link_7.0_tip")}

    def touching(fingers: list[int], bodies: list[int]) -> HandContacts:
        n = len(fingers)
        return HandContacts(*[np.zeros((n, 3))] * 4, *[np.ones(n)] * 5, np.ones(n, bool), np.array(fingers),
                            np.array(bodies), np.zeros(n, int), np.zeros(n, int), np.full(n, 4))

    # index (1) at its tip, middle (2) at its middle link and its tip; thumb (0) and ring (3) off
    contacts = touching([1, 2, 2], [body["link_3.0_tip"], body["link_6.0"], body["link_7.0_tip"]])
    assert joint_held_fingers(scene, contacts, "fingertips") == (0, 1, 3)
    assert joint_held_fingers(scene, contacts, "joints") == (0, 1, 2, 3)
    assert joint_held_fingers(scene, contacts, "floor") == ()
    # the same with the palm (-1) touching: a power grasp, every finger keeps the floor
    palm = touching([1, 2, 2, -1], [body["link_3.0_tip"], body["link_6.0"], body["link_7.0_tip"], scene.root_body])
    assert joint_held_fingers(scene, palm, "fingertips") == ()
    assert joint_held_fingers(scene, palm, "joints") == (0, 1, 2, 3)


def test_the_old_key_names_its_replacement() -> None:
    """`finger_hold_joints` (before 4 Dec 2026) is refused with what replaced it, not the nearest spelling."""
    from manigrasp.errors import ConfigError
    from manigrasp.protocol import PROTOCOLS

    with pytest.raises(ConfigError, match="no longer a key: use finger_hold"):
        PROTOCOLS.load("standard", finger_hold_joints=True)
    with pytest.raises(ConfigError, match="finger_hold must be one of"):
        PROTOCOLS.load("standard", finger_hold="tips")
