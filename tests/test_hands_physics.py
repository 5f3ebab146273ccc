"""Physics of every registered hand in a scene: smoke, open/close, grip force, lift and hold.

Parameterised over `manigrasp.hands.names()`; a hand whose factory cannot be
imported yet is skipped with the reason. Parallel jaws take a box with a top
grasp; dexterous hands take a can with a side power grasp (can axis along the
TCP x axis, thumb side up).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import trimesh

from manigrasp import hands
from manigrasp.control import GripController, ImpedanceController, default_gains
from manigrasp.errors import UnknownNameError
from manigrasp.hands.placement import side_power_grasp, top_grasp
from manigrasp.objects import build_object
from manigrasp.sim import Scene, SceneConfig, build_scene, grip_force, read_hand_contacts

BOX_SIZE = 0.05  # [m] cube
CAN_RADIUS, CAN_HEIGHT = 0.033, 0.12  # [m]
WIDE_CAN_RADIUS = 0.038  # [m] a second size for the dexterous maximum grip force
DT_STEPS_PER_S = 500  # 2 ms steps


def _load(name: str) -> hands.Hand:
    try:
        return hands.load(name)
    except (ImportError, UnknownNameError) as exc:
        pytest.skip(f"hand {name!r} factory not importable yet: {exc}")


@pytest.fixture(scope="module")
def objects(tmp_path_factory: pytest.TempPathFactory) -> dict:
    root = tmp_path_factory.mktemp("objects")
    box = build_object(trimesh.creation.box((BOX_SIZE,) * 3), name="box", mass=0.3, cache_root=root).asset
    can = build_object(trimesh.creation.cylinder(CAN_RADIUS, CAN_HEIGHT, sections=48), name="can", mass=0.35,
                       cache_root=root).asset
    wide = build_object(trimesh.creation.cylinder(WIDE_CAN_RADIUS, CAN_HEIGHT, sections=48), name="wide_can",
                        mass=0.35, cache_root=root).asset
    return {"box": box, "can": can, "wide_can": wide}


_SCENES: dict[str, Scene] = {}


def _scene(name: str, objects: dict) -> Scene:
    if name not in _SCENES:
        hand = _load(name)
        _SCENES[name] = build_scene(hand, objects["box" if hand.kind == "parallel" else "can"])
    return _SCENES[name]


def grasp_pose(scene: Scene) -> np.ndarray:
    """Hand-placed grasp: top grasp at the box centre, or side power grasp on the can, thumb side up."""
    centre = [0.0, 0.0, scene.object_rest_height]
    return top_grasp(centre) if scene.hand.kind == "parallel" else side_power_grasp(scene.hand, centre)


def _hold(scene: Scene, pose: np.ndarray) -> ImpedanceController:
    ctrl = ImpedanceController(scene.base, default_gains(scene.base))
    ctrl.set_target(pose)
    return ctrl


def _run(scene: Scene, ctrl: ImpedanceController, steps: int, grip: GripController | None = None,
         follow: bool = False) -> None:
    dt = scene.model.opt.timestep
    for _ in range(steps):
        ctrl.apply()
        if grip is not None:
            where, reach = (scene.hand_synergy(), scene.closing_reach()) if follow else (None, None)
            scene.set_synergy(grip.update(grip_force(read_hand_contacts(scene)), dt, where, reach))
        scene.step()


@pytest.mark.parametrize("name", hands.names())
def test_smoke_build_reset_step(name: str, objects: dict) -> None:
    scene = _scene(name, objects)
    pregrasp = grasp_pose(scene)
    pregrasp[:3, 3] -= 0.1 * pregrasp[:3, 2]  # 10 cm back along approach
    scene.reset(mount=pregrasp)
    ctrl = _hold(scene, pregrasp)
    _run(scene, ctrl, 1000)
    assert scene.is_finite()
    assert scene.warnings() == {}
    assert len(read_hand_contacts(scene, "any")) == 0  # the open hand touches nothing at pre-grasp


@pytest.mark.parametrize("name", hands.names())
def test_open_hand_encloses_its_max_width_and_closes(name: str, objects: dict) -> None:
    scene = _scene(name, objects)
    pose = grasp_pose(scene)
    # Open: the object frame sits on the TCP; a box 90% of max_width across the jaws or
    # a can of diameter 90% of max_width fits without touching.
    scene.reset(mount=pose)
    ctrl = _hold(scene, pose)
    _run(scene, ctrl, 50)
    width = 0.9 * scene.hand.max_width
    across = 2 * CAN_RADIUS if scene.hand.kind == "dexterous" else BOX_SIZE
    assert across < width or pytest.fail(f"test object {across} m wider than 90% of max_width {width}")
    assert len(read_hand_contacts(scene, "object")) == 0, "open hand touches an object narrower than max_width"
    # Closes: far from the object, the fingers move in.
    far = pose.copy()
    far[:3, 3] += [0.0, 0.0, 0.3]
    scene.reset(mount=far, synergy=0.0)
    ctrl = _hold(scene, far)
    fingers = [scene.model.body(f"hand/{f}").id for f in scene.hand.finger_bodies]
    tcp = scene.tcp_pose()
    if scene.hand.kind == "parallel":  # the open jaws span max_width along the closing axis, pad face to pad face
        # measured on the rigid pads' boxes: a compliant pad's box does not collide and a ray from the centre passes
        # between its elements, to the finger behind it (`pads.clear_backing` cuts the Panda's hull 6 mm back)
        rigid = build_scene(scene.hand, None, SceneConfig(pads="rigid"))
        rigid.reset(mount=far, synergy=0.0)
        mujoco.mj_forward(rigid.model, rigid.data)
        start, across = rigid.tcp_pose()[:3, 3], rigid.tcp_pose()[:3, 1]
        gap = sum(_ray(rigid, start, sign * across) for sign in (-1.0, 1.0))
        assert abs(gap - scene.hand.max_width) <= 0.05 * scene.hand.max_width, f"open jaw gap {gap:.4f} m"
    com0 = scene.data.subtree_com[fingers].copy()
    scene.set_synergy(1.0)
    _run(scene, ctrl, 400)
    com1 = scene.data.subtree_com[fingers].copy()
    spread0 = np.linalg.norm(com0 - tcp[:3, 3], axis=1)
    spread1 = np.linalg.norm(com1 - scene.tcp_pose()[:3, 3], axis=1)
    assert np.all(spread1 < spread0 - 0.005), f"fingers did not close: {spread0} -> {spread1}"
    if scene.hand.kind == "parallel":  # the jaws meet
        gap = _finger_distance(scene)
        assert gap < 0.003, f"closed jaws are {gap:.4f} m apart"


def _finger_distance(scene: Scene) -> float:
    """Smallest distance [m] between collision geoms of finger 0 and finger 1 (and their subtrees)."""
    m = scene.model
    geoms = [np.flatnonzero((scene.finger_of_body[m.geom_bodyid] == f) & ((m.geom_contype | m.geom_conaffinity) > 0))
             for f in (0, 1)]
    fromto = np.zeros(6)
    return min(mujoco.mj_geomDistance(m, scene.data, int(a), int(b), 0.05, fromto) for a in geoms[0] for b in geoms[1])


def _ray(scene: Scene, start: np.ndarray, direction: np.ndarray) -> float:
    """Distance [m] from `start` to the first geom along `direction`, of any group (inf if none)."""
    geom = np.array([-1], dtype=np.int32)
    groups = np.ones(6, dtype=np.uint8)
    dist = mujoco.mj_ray(scene.model, scene.data, start, direction, groups, 1, -1, geom)
    return float(dist) if geom[0] >= 0 else np.inf


@pytest.mark.parametrize("name", hands.names())
def test_grip_force_saturates_at_set_force(name: str, objects: dict) -> None:
    scene = _scene(name, objects)
    pose = grasp_pose(scene)
    target = 0.5 * scene.hand.max_grip_force
    scene.reset(mount=pose)
    ctrl = _hold(scene, pose)
    grip = GripController(target, scene.hand.max_grip_force, close_speed=2.0)
    _run(scene, ctrl, 750, grip, follow=True)
    contacts = read_hand_contacts(scene)
    measured = grip_force(contacts)
    assert grip.mode == "force"
    assert abs(measured - target) <= 0.1 * target, f"grip {measured:.2f} N, set {target:.2f} N"
    assert len(contacts.fingers_touching) >= 2


@pytest.mark.parametrize("name", [n for n in hands.names() if n in ("parallel_jaw", "panda", "robotiq_2f85")])
def test_parallel_jaw_full_close_saturates_at_max_grip_force(name: str, objects: dict) -> None:
    scene = _scene(name, objects)
    assert scene.hand.kind == "parallel"
    pose = grasp_pose(scene)
    scene.reset(mount=pose, synergy=1.0)
    _run(scene, _hold(scene, pose), 400)
    measured = grip_force(read_hand_contacts(scene))
    assert abs(measured - scene.hand.max_grip_force) <= 0.1 * scene.hand.max_grip_force, measured


@pytest.mark.parametrize("name", [n for n in hands.names() if n.startswith(("inspire", "fourier"))])
def test_dexterous_grip_reaches_max_grip_force(name: str, objects: dict) -> None:
    """The declared maximum (thumb tendon at its force limit, analytic) is reached on a wider can, and held."""
    hand = _load(name)
    assert hand.kind == "dexterous"
    scene = build_scene(hand, objects["wide_can"])
    pose = grasp_pose(scene)
    scene.reset(mount=pose)
    grip = GripController(hand.max_grip_force, hand.max_grip_force, close_speed=2.0)
    _run(scene, _hold(scene, pose), 1500, grip, follow=True)
    contacts = read_hand_contacts(scene)
    measured = grip_force(contacts)
    assert abs(measured - hand.max_grip_force) <= 0.1 * hand.max_grip_force, f"grip {measured:.2f} N"
    assert len(contacts.fingers_touching) >= 2


@pytest.mark.parametrize("name", [n for n in hands.names() if n.startswith(("inspire", "fourier"))])
def test_dexterous_thumb_stays_opposed_under_the_squeeze(name: str, objects: dict) -> None:
    """The fingers' squeeze on a can must not push the thumb out of opposition (its rotation servo is stiff).

    With the bending tendons' soft servo on the rotation too, its tendon moved 0.018-0.057 (0.005 now) and the
    object rolled toward it: the main cause of `slipped_lift` for power grasps.
    """
    scene = _scene(name, objects)
    pose = grasp_pose(scene)
    scene.reset(mount=pose)
    rotation = scene.model.tendon("hand/thumb_rotation").id
    opposed = float(scene.data.ten_length[rotation])
    grip = GripController(0.7 * scene.hand.max_grip_force, scene.hand.max_grip_force, close_speed=2.0)
    ctrl, turned = _hold(scene, pose), 0.0
    for _ in range(15):  # 1.5 s of closing and regulated squeeze
        _run(scene, ctrl, 50, grip, follow=True)
        turned = max(turned, abs(float(scene.data.ten_length[rotation]) - opposed))
    assert grip.mode == "force" and len(read_hand_contacts(scene).fingers_touching) >= 3
    assert turned < 0.01, f"the thumb's rotation tendon moved {turned:.3f} off its opposed length"


@pytest.mark.parametrize("name", hands.names())
def test_lift_and_hold_two_seconds(name: str, objects: dict) -> None:
    scene = _scene(name, objects)
    pose = grasp_pose(scene)
    scene.reset(mount=pose)
    ctrl = _hold(scene, pose)
    grip = None
    if scene.hand.kind == "parallel":  # a full close saturates at the jaw force
        scene.set_synergy(1.0)
    else:  # a dexterous hand holds a grip force under regulation (see GripController), 70% of its maximum
        grip = GripController(0.7 * scene.hand.max_grip_force, scene.hand.max_grip_force, close_speed=2.0)
    _run(scene, ctrl, 400 if scene.hand.kind == "parallel" else 1000, grip, follow=True)  # close
    start_obj = scene.object_pose()
    weight = np.array([0.0, 0.0, scene.object_mass() * 9.81, 0.0, 0.0, 0.0])
    lift = pose.copy()
    for i in range(250):  # 10 cm in 0.5 s
        lift[2, 3] = pose[2, 3] + 0.1 * (i + 1) / 250
        ctrl.set_target(lift, feedforward=weight)
        _run(scene, ctrl, 1, grip, follow=True)
    rel0 = np.linalg.inv(scene.tcp_pose()) @ scene.object_pose()
    _run(scene, ctrl, 2 * DT_STEPS_PER_S, grip, follow=True)  # hold 2 s
    rel = np.linalg.inv(scene.tcp_pose()) @ scene.object_pose()
    assert scene.object_pose()[2, 3] - start_obj[2, 3] > 0.09, "object left behind"
    assert np.linalg.norm(rel[:3, 3] - rel0[:3, 3]) < 0.01, "object slipped more than 1 cm during the hold"
    assert len(read_hand_contacts(scene).fingers_touching) >= 2
    assert scene.warnings() == {}


@pytest.mark.parametrize("name", [n for n in hands.names() if n.startswith(("inspire", "fourier", "allegro"))])
def test_side_power_grasp_puts_the_thumb_above_the_palm_facing_the_object(name: str, objects: dict) -> None:
    """The hand-placed power grasp (`manigrasp.hands.placement`): approach along world +x, thumb up, for both
    sides of each hand (the left hands' thumbs lie on the other side of the TCP's x axis)."""
    scene = _scene(name, objects)
    centre = np.array([0.0, 0.0, scene.object_rest_height])
    pose = side_power_grasp(scene.hand, centre)
    np.testing.assert_allclose(pose[:3, :3] @ pose[:3, :3].T, np.eye(3), atol=1e-12)
    assert np.linalg.det(pose[:3, :3]) == pytest.approx(1.0)
    np.testing.assert_allclose(pose[:3, 2], [1.0, 0.0, 0.0])  # approach
    scene.reset(mount=pose)
    np.testing.assert_allclose(scene.tcp_pose(), pose, atol=1e-9)
    thumb = scene.data.xipos[scene.model.body(f"hand/{scene.hand.finger_bodies[0]}").id]
    assert thumb[2] > centre[2] + 0.01
