"""Compliant finger pads (elastic foundation) against computable physics, closed loop in MuJoCo.

The rig (`manigrasp.sim.padtest`) presses one `parallel_jaw` pad (2 x 3 cm) on a fixed
surface with a force F, then ramps a torque about the pad normal until the pad turns.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from manigrasp.errors import ConfigError
from manigrasp.hands import load, pads
from manigrasp.sim import SceneConfig, build_scene
from manigrasp.sim.padtest import PAD_HALF, SURFACE_HALF, bumps, jaw_closed_on, pad_rig, press_pad

MU_RIGID = SceneConfig().hand_friction  # the rigid pads and the rest of the hand
MU_PAD = SceneConfig().pad_friction  # the compliant pads' rubber
FORCE = 35.0  # [N], the standard protocol's grip (half of parallel_jaw's 70 N)
GRIP_MAX = 70.0  # [N], parallel_jaw's full grip


def patch_torque(force: float, mu: float = MU_PAD) -> float:
    return pads.uniform_patch_torque(mu, force, PAD_HALF[:2])


def test_uniform_patch_torque_matches_closed_forms() -> None:
    # A square of half side a: mean distance from the centre = a (sqrt(2) + asinh(1)) / 3.
    a = 0.01
    assert pads.uniform_patch_torque(1.0, 1.0, (a, a)) == pytest.approx(a * (np.sqrt(2) + np.arcsinh(1)) / 3, rel=1e-4)
    # Linear in mu and F.
    assert pads.uniform_patch_torque(0.5, 20.0, (a, 2 * a)) == pytest.approx(
        10.0 * pads.uniform_patch_torque(1.0, 1.0, (a, 2 * a)), rel=1e-9)


def test_element_stiffnesses_sum_to_the_pad_stiffness() -> None:
    pad = pads.PadGeometry(center=np.zeros(3), normal=np.array([0, 0, -1.0]), axes=np.eye(3)[:2],
                           half=np.array([0.01, 0.015]), thickness=0.006)
    model = pads.PadModel()
    points, area, semi = pads.element_grid(pad, model.pitch)
    assert len(points) == 2 * 2  # one element per cell of about 1.5 cm: 1 x 1.5 cm
    np.testing.assert_allclose(semi, [0.005, 0.0075])  # each spans its cell
    assert area.sum() == pytest.approx(4 * 0.01 * 0.015)
    np.testing.assert_allclose(np.abs(points[:, :2]).max(axis=0) + semi, [0.01, 0.015])  # they reach the rims
    np.testing.assert_allclose(area, 1.5e-4)  # equal cells
    k = pads.element_stiffness(model, area, pad.thickness)
    assert k.sum() == pytest.approx(model.modulus * 6e-4 / 0.006)  # E A / h
    # A finer pitch: 2 x 3 cells of 1 cm, round elements.
    points, area, semi = pads.element_grid(pad, 0.01)
    assert len(points) == 2 * 3
    np.testing.assert_allclose(semi, [0.005, 0.005])
    assert area.sum() == pytest.approx(4 * 0.01 * 0.015)


def test_cell_centres_give_the_patch_mean_radius() -> None:
    """The midpoint rule: sum A_i r_i / A of the element grid is within 10 % of the uniform patch's mean
    distance from the centre (what the torsion capacity mu F mean(r) needs), for each hand's pad size."""
    for half in ((0.01, 0.015), (0.008, 0.008), (0.01, 0.01675)):
        pad = pads.PadGeometry(center=np.zeros(3), normal=np.array([0, 0, -1.0]), axes=np.eye(3)[:2],
                               half=np.array(half), thickness=0.006)
        points, area, _ = pads.element_grid(pad, pads.PadModel().pitch)
        grid = float(area @ np.hypot(points[:, 0], points[:, 1]) / area.sum())
        assert 0.9 < grid / pads.uniform_patch_torque(1.0, 1.0, half) < 1.0  # slightly low: r is 0 at the centre


@pytest.mark.parametrize("mode", ["compliant", "rigid"])
def test_pressing_a_flat_face_returns_the_press_force(mode: str) -> None:
    for force in (10.0, FORCE):
        assert press_pad(mode, force).normal_force == pytest.approx(force, rel=0.02)


def test_compliant_pad_holds_the_uniform_patch_torque_and_rigid_pad_overshoots_it() -> None:
    compliant = press_pad("compliant", FORCE)
    assert compliant.contacts == 4  # every element of the 2 x 2 grid touches the flat face
    assert compliant.holding_torque == pytest.approx(patch_torque(FORCE), rel=0.15)
    # The rigid box touches at its corners (1.8 cm out) plus soft-finger torsion: about 2x too much.
    assert press_pad("rigid", FORCE).holding_torque > 1.5 * patch_torque(FORCE, MU_RIGID)


@pytest.mark.parametrize("hand", ["panda", "robotiq_2f85"])
def test_the_other_hands_pads_pass_the_validation_cases(hand: str) -> None:
    """The validation of the parallel_jaw pad, on the pad sizes of the other parallel-jaw hands (panda:
    1.6 x 1.6 cm, 8 mm thick, a 2 x 2 grid whose centre, under the egg-crate's crest, is a gap between
    elements; robotiq_2f85: 2 x 3.35 cm, 2 mm thick, 2 x 3)."""
    spec = load(hand).build_spec()
    name, toward = pads.pad_directions(spec, load(hand).pad_geoms, load(hand).tcp_site)[0]
    pad = pads.pad_geometry(spec.geom(name), toward)
    half = (*pad.half, pad.thickness / 2)
    compliant = press_pad("compliant", FORCE, half=half)
    assert compliant.normal_force == pytest.approx(FORCE, rel=0.02)
    assert compliant.holding_torque == pytest.approx(pads.uniform_patch_torque(MU_PAD, FORCE, pad.half), rel=0.15)
    rigid = press_pad("rigid", FORCE, half=half)
    assert rigid.holding_torque > 1.3 * pads.uniform_patch_torque(MU_RIGID, FORCE, pad.half)
    bumpy = press_pad("compliant", FORCE, bumps(), half=half)
    assert bumpy.normal_force == pytest.approx(FORCE, rel=0.02)
    assert bumpy.holding_torque == pytest.approx(compliant.holding_torque, rel=0.25)
    assert press_pad("rigid", FORCE, bumps(), half=half).holding_torque < 0.75 * rigid.holding_torque


def test_the_pad_rubber_friction_is_the_elements_own() -> None:
    """The surface keeps MuJoCo's default friction 1; the pad has contact priority, so the patch holds
    in proportion to the pad's own friction (with MuJoCo's max rule of equal priorities both would hold
    at 1)."""
    low = press_pad("compliant", FORCE, config=SceneConfig(pad_friction=0.5)).holding_torque
    high = press_pad("compliant", FORCE, config=SceneConfig(pad_friction=1.0)).holding_torque
    assert low == pytest.approx(patch_torque(FORCE, 0.5), rel=0.15)
    assert high / low == pytest.approx(2.0, rel=0.1)


def test_a_post_under_one_element_meets_that_cells_torsion() -> None:
    """An object touching the pad on one element only (an edge or corner on the pad's rim): the element
    stands for its 1 x 1.5 cm cell of rubber, so it resists the cell's patch torque mu F mean(r) (mean(r)
    over a rectangle of half sides a, b in closed form: (2 a b d + a^3 ln((b + d) / a) + b^3 ln((a + d) / b))
    / (6 a b), d = hypot(a, b)), besides its sliding friction. The rig turns the pad about its centre, 9 mm
    from the post: MuJoCo's elliptic cone lets the element resist F hypot(mu r, mu_t) there, where a point
    contact gives mu F r."""
    n = 161  # 0.5 mm: the post's top is 4 x 4 mm and its walls steep (at 1 mm an element meets them too)
    grid = np.linspace(-SURFACE_HALF, SURFACE_HALF, n)
    x, y = np.meshgrid(grid, grid, indexing="xy")
    a, b = PAD_HALF[0] / 2, PAD_HALF[1] / 2  # the cell's half sides, and where the element's centre is
    heights = np.where((np.abs(x - a) < 0.002) & (np.abs(y - b) < 0.002), 0.002, 0.0)
    post = press_pad("compliant", 10.0, heights)
    model = pad_rig("compliant", heights)
    elements = [g for g in range(model.ngeom) if pads.is_element(model.geom(g).name)]
    cell = model.geom_friction[elements[0], 1]
    d = np.hypot(a, b)
    mean_r = (2 * a * b * d + a**3 * np.log((b + d) / a) + b**3 * np.log((a + d) / b)) / (6 * a * b)
    assert cell == pytest.approx(MU_PAD * mean_r, rel=0.01)
    r = d  # the post is under the element at (5 mm, 7.5 mm)
    assert post.holding_torque == pytest.approx(10.0 * np.hypot(MU_PAD * r, cell), rel=0.05)
    assert post.holding_torque > 1.08 * MU_PAD * 10.0 * r  # hypot(r, mu_t / mu) = 1.135 r


def test_the_thin_pad_on_bumps_reads_the_same_at_every_field_resolution() -> None:
    """`robotiq_2f85`'s 2 mm pad at 70 N on the egg-crate sampled 81 x 81 and 121 x 121: the same physics, so
    the same holding torque, within 25 % of the flat face's. Its element contacts there are under a micrometre
    deep, where MuJoCo's default CCD tolerance (1e-6 m) let a third of them come back with reversed normals and
    the pad turned by itself during the press (0.011 and 0.17 of the flat torque; every scene now resolves them,
    `SceneConfig.ccd_tolerance`, and the rig calls a slip over 20 ms, not on one jolt)."""
    spec = load("robotiq_2f85").build_spec()
    name, toward = pads.pad_directions(spec, load("robotiq_2f85").pad_geoms, load("robotiq_2f85").tcp_site)[0]
    pad = pads.pad_geometry(spec.geom(name), toward)
    half = (*pad.half, pad.thickness / 2)
    flat = press_pad("compliant", GRIP_MAX, half=half).holding_torque
    ratios = [press_pad("compliant", GRIP_MAX, bumps(n), half=half).holding_torque / flat for n in (81, 121)]
    assert abs(ratios[0] - ratios[1]) < 0.03
    assert min(ratios) > 0.75


def test_scenes_resolve_contacts_to_a_nanometre() -> None:
    """MuJoCo's EPA stops at `ccd_tolerance`; the compliant elements' contacts can be shallower than its default
    1e-6 m, and then came back with reversed normals in quick's trials: the scenes set 1e-9."""
    spec = mujoco.MjSpec()
    SceneConfig().apply(spec.option)
    assert spec.compile().opt.ccd_tolerance == pytest.approx(1e-9)
    assert pad_rig("compliant").opt.ccd_tolerance == pytest.approx(1e-9)  # the validation rig's scene too
    with pytest.raises(ConfigError, match="ccd_tolerance"):
        SceneConfig(ccd_tolerance=0.0)


def test_compliant_pad_keeps_its_torque_on_1mm_bumps_and_rigid_pad_loses_it() -> None:
    field = bumps()  # crest to trough 1 mm, crest under the pad centre
    assert np.ptp(field) == pytest.approx(0.001, rel=0.01)
    flat, bumpy = press_pad("compliant", FORCE), press_pad("compliant", FORCE, field)
    assert bumpy.normal_force == pytest.approx(FORCE, rel=0.02)
    assert bumpy.holding_torque == pytest.approx(flat.holding_torque, rel=0.25)
    rigid_flat, rigid_bumpy = press_pad("rigid", FORCE), press_pad("rigid", FORCE, field)
    assert rigid_bumpy.holding_torque < 0.75 * rigid_flat.holding_torque  # fails the 25 % criterion


def test_press_is_deterministic() -> None:
    assert press_pad("compliant", FORCE, bumps()) == press_pad("compliant", FORCE, bumps())


@pytest.mark.parametrize("hand", ["parallel_jaw", "panda", "robotiq_2f85"])
def test_every_parallel_jaw_hand_gets_compliant_pads(hand: str) -> None:
    rigid = build_scene(hand, config=SceneConfig(pads="rigid")).model
    compliant = build_scene(hand, config=SceneConfig(pads="compliant")).model
    elements = [g for g in range(compliant.ngeom) if pads.is_element(compliant.geom(g).name.split("/")[-1])]
    # cells no longer than 1.5 cm: 2 x 2 on parallel_jaw's 2 x 3 cm and panda's 1.6 x 1.6 cm pads, 2 x 3 on
    # robotiq_2f85's 2 x 3.35 cm (rounding the count would give it 2 x 2 cells of 1.68 cm)
    assert len(elements) == 2 * {"parallel_jaw": 4, "panda": 4, "robotiq_2f85": 6}[hand]
    assert not any(pads.is_element(rigid.geom(g).name.split("/")[-1]) for g in range(rigid.ngeom))
    for name in load(hand).pad_geoms + load(hand).pad_backing:  # the rigid boxes stay, without collisions
        g = mujoco.mj_name2id(compliant, mujoco.mjtObj.mjOBJ_GEOM, f"hand/{name}")
        assert compliant.geom_contype[g] == 0 and compliant.geom_conaffinity[g] == 0
    assert (compliant.geom_condim[elements] == 4).all()  # soft fingers: each element's cell has a torsion
    np.testing.assert_allclose(compliant.geom_friction[elements, 0], MU_PAD)  # the rubber's own friction
    spec = load(hand).build_spec()
    pad = pads.pad_geometry(spec.geom(load(hand).pad_geoms[0]), pads.pad_directions(spec, load(hand).pad_geoms,
                                                                                   load(hand).tcp_site)[0][1])
    np.testing.assert_allclose(compliant.geom_friction[elements, 1],
                               pads.cell_torsion(MU_PAD, pads.cell_sides(pad, SceneConfig().pad_pitch)))
    others = [g for g in range(compliant.ngeom) if g not in elements and compliant.geom_contype[g]
              and compliant.geom_bodyid[g] != 0 and compliant.geom(g).name.startswith("hand/")]
    np.testing.assert_allclose(compliant.geom_friction[others, 0], MU_RIGID)  # the rest of the hand keeps 0.5


def test_bad_pad_options_are_config_errors() -> None:
    with pytest.raises(ConfigError, match="unknown pads"):
        SceneConfig(pads="soft")
    with pytest.raises(ConfigError, match="pad_pitch"):
        SceneConfig(pad_pitch=0.0)
    with pytest.raises(ConfigError, match="pad_friction"):
        SceneConfig(pad_friction=-0.1)


def test_an_element_pressed_alone_bottoms_out_at_its_travel() -> None:
    # A 8 mm post under one element carries the jaw's whole 70 N: the element's spring (one 1 x 1.5 cm
    # cell, 8.5e3 N/m: 8.2 mm unstopped) bottoms out at its travel (80 % of the 6 mm pad) and the rigid
    # backing takes the rest. A soft limit let it sink 2x deeper, past the pad's own thickness.
    n = 81
    grid = np.linspace(-SURFACE_HALF, SURFACE_HALF, n)
    x, y = np.meshgrid(grid, grid, indexing="xy")
    heights = np.where((np.abs(x - PAD_HALF[0] / 2) < 0.002) & (np.abs(y - PAD_HALF[1] / 2) < 0.002), 0.008, 0.0)
    model = pad_rig("compliant", heights)
    data = mujoco.MjData(model)
    while data.time < 0.6:
        data.ctrl[0] = -GRIP_MAX * min(1.0, data.time / 0.3)
        mujoco.mj_step(model, data)
    joints = [j for j in range(model.njnt) if pads.is_element(model.joint(j).name)]
    compression = np.array([abs(data.qpos[model.jnt_qposadr[j]]) for j in joints])
    travel = model.jnt_range[joints[0]][1]
    assert compression.max() > 0.95 * travel  # the post's element is bottomed out
    assert compression.max() < travel + 0.0005
    assert np.sort(compression)[-2] < 0.001  # and it is the only one loaded


def test_a_trial_executes_its_pose_as_the_store_keeps_it() -> None:
    from manigrasp.bench.worker import as_stored
    from manigrasp.protocol.result import PoseRecord

    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.normal(size=4)
        pose = np.eye(4)
        pose[:3, :3] = PoseRecord(0, 0, 0, *(q / np.linalg.norm(q))).matrix()[:3, :3] @ np.diag([1.0, -1.0, -1.0])
        pose[:3, 3] = rng.normal(size=3) * 0.1
        stored = as_stored(pose)
        np.testing.assert_array_equal(stored, PoseRecord.of(pose).matrix())  # bit for bit what a replay runs
        assert np.abs(stored - pose).max() < 1e-12
    skewed = pose.copy()
    skewed[0, 0] += 5e-6  # not a rotation: left for the protocol to refuse, not silently orthonormalised
    np.testing.assert_array_equal(as_stored(skewed), skewed)


@pytest.mark.slow
def test_a_compliant_pad_run_replays_to_its_stored_statuses(tmp_path) -> None:
    """A replay of a compliant-pad mug trial ended `dropped_perturb` where its run stored `success`: the run
    executed the planner's pose, the replay the stored quaternion's, 2e-16 apart, and a grasp on the edge of
    holding is chaotic (one of the 20 flipped). The run now executes the pose as stored."""
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.replay import replay_trial, stored_trials
    from manigrasp.bench.runner import run_benchmark

    config = {"objects": ["025_mug"], "planners": ["antipodal"], "grasps_per_object": 20, "protocol": "standard",
              "scene": {"pads": "compliant"}}
    out = tmp_path / "run"
    run_benchmark(parse_config(config), out, progress=False)
    trials = stored_trials(out)
    assert len(trials) == 20
    for trial_id in sorted(trials):
        replay = replay_trial(out, trial_id)
        assert replay.object_pose_error == 0.0
        assert replay.same_status, (trial_id, replay.stored.status, replay.replayed.status)


def _torsion_regularisers(mode: str) -> np.ndarray:
    """efc_R of the torsion rows of the pad-object contacts, `parallel_jaw` closed on a 5 cm cube (mesh)."""
    import trimesh

    from manigrasp.objects import build_object

    cube = build_object(trimesh.creation.box((0.05,) * 3), name="box", mass=0.3).asset
    scene = jaw_closed_on(cube, SceneConfig(pads=mode))
    model, data = scene.model, scene.data
    rows = []
    for i in range(data.ncon):
        c = data.contact[i]
        names = {model.geom(g).name.split("/")[-1] for g in (c.geom1, c.geom2)}
        if any(n.endswith("_pad") or pads.is_element(n) for n in names) and c.efc_address >= 0:
            assert c.dim == 4
            rows.append(data.efc_R[c.efc_address + 3])
    assert rows
    return np.array(rows)


def test_an_element_holds_torsion_with_no_more_creep_than_the_rigid_pad() -> None:
    """MuJoCo's soft friction lets a held contact slide at R f / b; an elliptic cone's torsion row has the normal
    row's regulariser times (mu / mu_t)^2 / impratio. A thin object resting on one element per pad holds its
    torsion by that row alone; with the first version's element contacts (solimp 0.99, armature k (dt / 0.5)^2) its R
    was twice the rigid pad's, and a phone box turned 4-5 deg/s in the grip at 28 % of its torsion capacity."""
    assert _torsion_regularisers("compliant").max() < _torsion_regularisers("rigid").min()


def _pad_share_closed_on_a_box(hand: str, mode: str) -> float:
    """The pads' elements' share of the hand's normal force on a flat 8 x 5 x 6 cm box (300 g) on the table, the
    hand closed across its 5 cm from above at the standard grip (half the hand's force, the protocol's close:
    `GripController`), its TCP at the box's centre, the base held there; read after 1 s."""
    import trimesh

    from manigrasp.control import GripController, ImpedanceController, default_gains
    from manigrasp.objects import build_object
    from manigrasp.sim import current_grip_force, read_hand_contacts

    box = build_object(trimesh.creation.box((0.08, 0.05, 0.06)), name="box", mass=0.3).asset
    scene = build_scene(hand, box, SceneConfig(pads=mode))
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = np.diag([1.0, -1.0, -1.0]), [0.0, 0.0, 0.03]  # approach down, closing along y
    scene.reset(mount=pose)
    base = ImpedanceController(scene.base, default_gains(scene.base))
    base.set_target(pose)
    spec = scene.hand
    grip = GripController(0.5 * spec.max_grip_force, spec.max_grip_force, stiffness=spec.grip_stiffness,
                          stall_check=True)
    grip.reset(0.0)
    dt, chunk = scene.model.opt.timestep, 10
    for _ in range(50):  # 1 s
        scene.set_synergy(grip.update(current_grip_force(scene), chunk * dt, scene.hand_synergy(),
                                      scene.closing_reach()))
        for _ in range(chunk):
            base.apply()
            scene.step()
    assert grip.mode == "force"
    contacts = read_hand_contacts(scene)
    force = np.clip(contacts.normal_force, 0.0, None)
    names = [scene.model.geom(g).name.rsplit("/", 1)[-1] for g in contacts.hand_geom]
    element = np.array([pads.is_element(n) for n in names], bool)
    assert force.sum() > 0.9 * spec.max_grip_force  # both jaws press at the standard grip
    return float(force[element].sum() / force.sum())


@pytest.mark.parametrize("hand", ["panda", "parallel_jaw"])
def test_the_compliant_pads_carry_the_grip_on_a_flat_face(hand: str) -> None:
    """A rigid geom of the finger closer behind the pad face than the elements' travel bottoms the pad out on
    it: the Panda's finger hulls, 0.4 mm behind its 8 mm pads, carried 0.62 of the grip on a flat box (the pads
    0.38) before `pads.clear_backing` moved them back to the travel."""
    assert _pad_share_closed_on_a_box(hand, "compliant") >= 0.95


def _behind(model: mujoco.MjModel, geom: int, pad: str, normal: np.ndarray, face: np.ndarray) -> tuple[float, float]:
    """(front, back) [m] of compiled `geom` (a mesh's hull or a box) behind the face of `pad` (outward `normal`, face
    centre `face`, both in the pad's body frame): its nearest and farthest points along -normal."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    body = model.geom_bodyid[geom]
    if model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_MESH:
        points = data.xpos[body] + pads.geom_vertices(model, geom) @ data.xmat[body].reshape(3, 3).T
    else:
        corners = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3, indexing="ij")).reshape(3, -1).T * model.geom_size[geom]
        points = data.geom_xpos[geom] + corners @ data.geom_xmat[geom].reshape(3, 3).T
    pad_body = model.geom_bodyid[model.geom(pad).id]
    rot = data.xmat[pad_body].reshape(3, 3)
    depth = (data.xpos[pad_body] + rot @ face) @ (rot @ normal) - points @ (rot @ normal)
    return float(depth.min()), float(depth.max())


@pytest.mark.parametrize("hand", ["parallel_jaw", "panda", "robotiq_2f85"])
def test_no_rigid_geom_lies_within_the_pads_travel(hand: str) -> None:
    """`clear_backing` cuts exactly the finger geoms that lie closer behind a pad face than the travel, by the
    difference: their front then lies at the travel, their back where it was (the Panda's hulls are meshes, the
    Robotiq's fingertip blocks boxes); the rigid mode's model is the hand's own, and so are, in a compliant scene,
    the geoms the hand lists as `pad_backing` (they stop colliding before `clear_backing` runs)."""
    spec, travel_fraction = load(hand).build_spec(), SceneConfig().pad_model().travel_fraction
    directions = pads.pad_directions(spec, load(hand).pad_geoms, load(hand).tcp_site)
    faces = [pads.pad_geometry(spec.geom(n), t) for n, t in directions]
    travels = [travel_fraction * face.thickness for face in faces]
    before = pads.backing_depths(spec, directions)
    assert any(before)  # every hand has a rigid geom behind its pads
    expected = {}
    for near, travel in zip(before, travels, strict=True):
        for geom, depth in near.items():
            if depth < travel:
                expected[geom] = max(expected.get(geom, 0.0), travel - depth)
    own = spec.copy().compile()
    moved = pads.clear_backing(spec, directions, travel_fraction)
    assert moved.keys() == expected.keys()
    for geom, distance in moved.items():
        assert distance == pytest.approx(expected[geom], abs=1e-9)
    for near, travel in zip(pads.backing_depths(spec, directions), travels, strict=True):
        assert all(depth >= travel - 1e-9 for depth in near.values())
    cut = spec.compile()
    for (name, _), face, travel, near in zip(directions, faces, travels, before, strict=True):
        for geom, depth in near.items():
            if depth < travel:
                front, back = _behind(own, geom, name, face.normal, face.center)
                assert _behind(cut, geom, name, face.normal, face.center) == pytest.approx((travel, back), abs=1e-7)
                assert front < travel
    for mode, model in (("rigid", build_scene(hand, config=SceneConfig(pads="rigid")).model),
                        ("compliant", build_scene(hand, config=SceneConfig(pads="compliant")).model)):
        for g in range(own.ngeom):
            backing = own.geom(g).name in load(hand).pad_backing  # a scene makes them non-colliding first
            there = model.geom(f"hand/{own.geom(g).name}").id
            reference = own if mode == "rigid" or backing else cut
            assert np.array_equal(model.geom_pos[there], reference.geom_pos[g]), (mode, own.geom(g).name)
            assert np.array_equal(model.geom_size[there], reference.geom_size[g]), (mode, own.geom(g).name)
            if reference.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
                assert np.allclose(pads.geom_vertices(model, there), pads.geom_vertices(reference, g), atol=1e-9)


def _finger_spec() -> mujoco.MjSpec:
    """A finger on a slide joint, turned at a slant: a 2 x 3 cm box pad 8 mm thick facing its -z (face at
    z = -4 mm, 6.4 mm travel: to z = 2.4 mm), behind it a 2 cm cube mesh on a welded, turned link (front at
    z = -3 mm, back at 17 mm), an unnamed box (front at -3.5 mm, back at 6.5 mm), an unnamed sphere (front at
    -2 mm) and, out of the cut, a non-colliding box and a box on a body with its own joint (both front at -3 mm)."""
    spec = mujoco.MjSpec()
    cube = np.array(np.meshgrid(*[[-0.01, 0.01]] * 3, indexing="ij")).reshape(3, -1).T
    spec.add_mesh(name="cube", uservert=cube.ravel().tolist())
    axis, angle = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0), 0.7
    finger = spec.worldbody.add_body(name="finger", pos=[0.1, 0.2, 0.3],
                                     quat=[np.cos(angle / 2), *(np.sin(angle / 2) * axis)])
    finger.add_joint(name="slide", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])
    box = mujoco.mjtGeom.mjGEOM_BOX
    finger.add_geom(name="pad", type=box, size=[0.01, 0.015, 0.004])
    link = finger.add_body(name="link", pos=[0.0, 0.0, 0.006], quat=[np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0])
    link.add_geom(name="hull", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="cube", pos=[0.0, 0.001, 0.0])
    finger.add_geom(type=box, size=[0.005, 0.005, 0.005], pos=[0.0, 0.0, 0.0015])
    finger.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.003, 0, 0], pos=[0.0, 0.0, 0.001])
    finger.add_geom(name="ghost", type=box, size=[0.005, 0.005, 0.005], pos=[0.0, 0.0, 0.002], contype=0,
                    conaffinity=0)
    moving = finger.add_body(name="moving")
    moving.add_joint(name="moving", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0])
    moving.add_geom(name="other", type=box, size=[0.005, 0.005, 0.005], pos=[0.0, 0.0, 0.002])
    return spec


def test_clear_backing_cuts_the_front_and_keeps_the_back() -> None:
    """On `_finger_spec` (travel 6.4 mm): the cube mesh 1 mm behind the face is cut to the travel, 5.4 mm, its back
    17 + 4 = 21 mm behind the face as before (a translation would have moved it to 26.4); the unnamed box too (front
    0.5 -> 6.4 mm, back 10.5 mm kept); the unnamed sphere, 2 mm behind, moves back whole by 4.4 mm; the
    non-colliding box and the jointed one stay."""
    spec, toward = _finger_spec(), np.array([0.0, 0.0, -1.0])
    own = spec.copy().compile()
    face = pads.pad_geometry(spec.geom("pad"), toward)
    assert face.thickness == pytest.approx(0.008) and np.allclose(face.center, [0.0, 0.0, -0.004])
    hull = own.geom("hull").id
    unnamed_box, sphere = (g for g in range(own.ngeom) if own.geom(g).name == "")
    assert own.geom_type[unnamed_box] == mujoco.mjtGeom.mjGEOM_BOX
    assert _behind(own, hull, "pad", face.normal, face.center) == pytest.approx((0.001, 0.021), abs=1e-9)
    moved = pads.clear_backing(spec, [("pad", toward)], 0.8)
    assert moved == pytest.approx({hull: 0.0054, unnamed_box: 0.0059, sphere: 0.0044}, abs=1e-9)
    cut = spec.compile()
    assert _behind(cut, hull, "pad", face.normal, face.center) == pytest.approx((0.0064, 0.021), abs=1e-9)
    assert _behind(cut, unnamed_box, "pad", face.normal, face.center) == pytest.approx((0.0064, 0.0105), abs=1e-9)
    assert cut.geom_type[hull] == mujoco.mjtGeom.mjGEOM_MESH and cut.geom_type[unnamed_box] == mujoco.mjtGeom.mjGEOM_BOX
    assert np.allclose(cut.geom_pos[sphere], own.geom_pos[sphere] + [0.0, 0.0, 0.0044], atol=1e-12)
    assert cut.geom_size[sphere][0] == own.geom_size[sphere][0]
    for name in ("ghost", "other"):
        g = own.geom(name).id
        assert np.array_equal(cut.geom_pos[g], own.geom_pos[g]) and np.array_equal(cut.geom_size[g], own.geom_size[g])
    assert [set(near) for near in pads.backing_depths(spec, [("pad", toward)])] == [{hull, unnamed_box, sphere}]
