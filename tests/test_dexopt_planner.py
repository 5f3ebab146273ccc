"""The `dexopt` planner: its signed-distance grid, force shares, hand kinematics, descent and candidates."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
import trimesh

from manigrasp.errors import ConfigError
from manigrasp.hands.registry import load as load_hand
from manigrasp.planners import Observation
from manigrasp.planners import registry as planner_registry
from manigrasp.planners.collision import HandProbe
from manigrasp.planners.dexopt import Box, GridSdf, Sphere
from manigrasp.planners.dexopt_hand import HandKinematics
from manigrasp.planners.dexopt_planner import (
    CLOSE_DEFECTS,
    DEFAULT_WEIGHTS,
    DexOptPlanner,
    _hand_q,
    _mat_quats,
    _penetrations,
    _probe_contacts,
    _retract_fingers,
    choose_pads,
    force_shares,
)


def _sphere_grid(centre=(0.0, 0.0, 0.3), radius=0.04) -> GridSdf:
    mesh = trimesh.creation.icosphere(subdivisions=4, radius=radius)
    return GridSdf.from_convex_parts([mesh.vertices + np.asarray(centre)], 0.0025, 0.03)


@pytest.mark.slow
def test_grid_sdf_of_convex_parts_matches_the_exact_distances_near_the_surface() -> None:
    box = trimesh.creation.box(extents=[0.06, 0.1, 0.04])
    grid = GridSdf.from_convex_parts([box.vertices], 0.0025, 0.03)
    exact = Box((0.0, 0.0, 0.0), (0.03, 0.05, 0.02))
    points = np.random.default_rng(0).uniform(-0.06, 0.06, (3000, 3))
    d, g = grid.distance(points)
    d0, g0, _ = exact.sdf(points)
    near = np.abs(d0) < 0.01
    assert np.abs(d - d0)[near].max() < 1e-3  # trilinear error, largest where the field curves: edges, corners
    excess = np.sort(np.abs(points) - [0.03, 0.05, 0.02], axis=1)
    faces = near & (excess[:, 2] > 0.003) & (excess[:, 1] < -0.005)  # in front of a face, away from its edges
    assert faces.sum() > 50
    np.testing.assert_allclose(g[faces], g0[faces], atol=1e-6)
    sphere = _sphere_grid((0.0, 0.0, 0.0), 0.04)
    d, g = sphere.distance(points)
    d0, g0, _ = Sphere((0.0, 0.0, 0.0), 0.04).sdf(points)
    near = np.abs(d0) < 0.01
    assert np.abs(d - d0)[near].max() < 3e-4  # the icosphere's facets lie up to 0.1 mm inside the sphere
    assert np.linalg.norm(g - g0, axis=1)[near & (d0 > 0.003)].max() < 0.05
    # Union of two overlapping boxes: inside either, outside both; beyond the grid, distance grows.
    other = box.copy().apply_translation([0.05, 0.0, 0.0])
    union = GridSdf.from_convex_parts([box.vertices, other.vertices], 0.0025, 0.02)
    d, _ = union.distance(np.array([[0.0, 0.0, 0.0], [0.06, 0.0, 0.0], [0.025, 0.08, 0.0], [0.5, 0.0, 0.0]]))
    assert d[0] == pytest.approx(-0.02, abs=1e-9) and d[1] == pytest.approx(-0.02, abs=1e-9)
    assert d[2] == pytest.approx(0.03, abs=1e-6) and d[3] == pytest.approx(0.42, abs=1e-6)
    which, depth, _ = union.penetrating(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.05], [0.2, 0.0, 0.0]]))
    assert which.tolist() == [0] and depth[0] < 0


def test_force_shares_let_a_thumb_balance_three_fingers() -> None:
    """Thumb normal +x against three finger normals tilted about -x: equal unit forces cannot balance, shares can."""
    normals = np.array([[1.0, 0.0, 0.0], [-0.9, 0.3, 0.0], [-0.9, -0.3, 0.0], [-1.0, 0.0, 0.0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    wrenches = np.concatenate([normals, np.zeros((4, 3))], axis=1)[None]
    shares = force_shares(wrenches, 0.3)[0]
    assert shares.sum() == pytest.approx(4.0) and shares.min() >= 0.3 - 1e-12
    assert np.linalg.norm(shares @ normals) < 1e-3
    assert shares[0] == pytest.approx(shares[1:] @ -normals[1:, 0], rel=1e-3)  # the thumb pushes as much as all
    assert np.linalg.norm(np.ones(4) @ normals) > 1.5  # equal forces leave a large imbalance
    np.testing.assert_array_equal(force_shares(wrenches, 1.0), np.ones((1, 4)))


@pytest.fixture(scope="module")
def inspire() -> HandKinematics:
    return HandKinematics(load_hand("inspire_right"))


def test_hand_kinematics_maps_joints_to_commands_and_back(inspire: HandKinematics) -> None:
    hand = inspire.hand
    np.testing.assert_allclose(inspire.ctrl(inspire.q_open)[0], hand.open_ctrl, atol=1e-9)
    q = inspire.low + 0.4 * (inspire.high - inspire.low)
    ctrl, jac = inspire.ctrl(q)
    np.testing.assert_allclose(inspire.q_from_ctrl(ctrl), q, atol=1e-9)
    h = 1e-6
    numeric = np.stack([(inspire.ctrl(q + h * e)[0] - inspire.ctrl(q - h * e)[0]) / (2 * h)
                        for e in np.eye(inspire.n_q)], axis=1)
    np.testing.assert_allclose(jac, numeric, atol=1e-6)
    assert inspire.n_q == hand.n_actuators == 6  # the distal joints follow their couplings
    # One pad set per finger, on finger links only.
    assert sorted(set(inspire.pad_finger.tolist())) == list(range(len(hand.finger_bodies)))
    assert np.all(inspire.body_finger[inspire.contacts.bodies] == inspire.pad_finger)
    # A wrap: one contact per moving finger link (3 on the thumb, 2 on each finger) and the palm's front.
    wrap = HandKinematics(hand, palm=True, wrap=True)
    groups = np.unique(wrap.pad_finger)
    palm = wrap.pad_finger == groups[-1]
    links = wrap.contacts.bodies[~palm]
    assert len(groups) == len(np.unique(links)) + 1 == 3 + 2 * 4 + 1
    assert all(len(set(links[wrap.pad_finger[~palm] == g])) == 1 for g in groups[:-1])  # one link per contact
    assert np.all(wrap.body_finger[wrap.contacts.bodies[palm]] < 0) and np.all(wrap.body_finger[links] >= 0)


def test_batched_body_jacobians_equal_mujocos_per_body_jacobians(inspire: HandKinematics) -> None:
    """`evaluate` builds every body's Jacobian from MuJoCo's dof axes at once; they must be what `mj_jacBody`
    gives body by body (through the free joint and the tendon couplings), and the placement must not depend on
    whether Jacobians are asked for."""
    rng = np.random.default_rng(5)
    pos = rng.normal(scale=0.1, size=(3, 3))
    quat = rng.normal(size=(3, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    q = inspire.low + rng.random((3, inspire.n_q)) * (inspire.high - inspire.low)
    xpos, xmat, jp, jr, qpos = inspire.evaluate(pos, quat, q)
    m, d = inspire.model, mujoco.MjData(inspire.model)
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    for i in range(3):
        d.qpos[:] = qpos[i]
        mujoco.mj_forward(m, d)
        reduce = inspire.reduce_matrix(qpos[i])
        for k, b in enumerate(inspire.bodies):
            mujoco.mj_jacBody(m, d, jacp, jacr, int(b))
            np.testing.assert_allclose(jp[i, k], jacp @ reduce, rtol=0, atol=1e-12)
            np.testing.assert_allclose(jr[i, k], jacr @ reduce, rtol=0, atol=1e-12)
    assert np.abs(jp).max() > 0.05 and np.abs(jr).max() > 0.5  # not trivially zero
    bare = inspire.evaluate(pos, quat, q, jacobians=False)
    assert np.array_equal(bare[0], xpos) and np.array_equal(bare[1], xmat) and not bare[2].any()


def test_backprop_matches_finite_differences_through_the_free_joint_and_couplings(inspire: HandKinematics) -> None:
    """E = sum_j a_j . p_j over the hand's surface samples: the chain rule over (root twist, joints)."""
    rng = np.random.default_rng(2)
    weights = rng.normal(size=(len(inspire.samples.bodies), 3))
    pos, quat = np.array([[0.01, -0.02, 0.3]]), np.array([[0.9, 0.1, -0.3, 0.2]])
    quat /= np.linalg.norm(quat)
    q = (inspire.low + 0.3 * (inspire.high - inspire.low))[None]

    def value(p, qu, j) -> float:
        xpos, xmat, *_ = inspire.evaluate(p, qu, j)
        return float(np.sum(weights * inspire.world(inspire.samples, xpos, xmat)[0]))

    xpos, xmat, jp, jr, _ = inspire.evaluate(pos, quat, q)
    world = inspire.world(inspire.samples, xpos, xmat)
    analytic = inspire.backprop(inspire.samples, world, weights[None], xpos, jp, jr)[0]
    numeric = np.zeros_like(analytic)
    for k in range(len(analytic)):
        out = []
        for sign in (1.0, -1.0):
            p, qu, j = pos.copy(), quat.copy(), q.copy()
            if k < 3:
                p[0, k] += sign * 1e-6
            elif k < 6:
                twist = np.zeros(3)
                twist[k - 3] = sign * 1e-6
                mujoco.mju_quatIntegrate(qu[0], twist, 1.0)
            else:
                j[0, k - 6] += sign * 1e-6
            out.append(value(p, qu, j))
        numeric[k] = (out[0] - out[1]) / 2e-6
    np.testing.assert_allclose(analytic, numeric, rtol=1e-5, atol=1e-6)


@pytest.mark.slow
def test_descent_lowers_the_energy_and_brings_pads_onto_a_sphere_without_penetration(
        inspire: HandKinematics) -> None:
    planner = DexOptPlanner(restarts=8, iterations=150)
    planner._hands[inspire.hand.name] = inspire
    sdf, centre = _sphere_grid(), np.array([0.0, 0.0, 0.3])
    rng = np.random.default_rng(0)
    pos, quat, q = planner.initial(inspire, sdf, centre, inspire.hand.max_width, rng, table_z=0.0)
    before, _, _ = planner.energy(inspire, sdf, centre, 0.04, 0.0, pos, quat, q, gradient=False)
    pos, quat, q, after, terms = planner.descend(inspire, sdf, centre, 0.04, 0.0, pos, quat, q)
    assert np.all(after < before)
    best = int(np.argmin(after))
    xpos, xmat, *_ = inspire.evaluate(pos[best:best + 1], quat[best:best + 1], q[best:best + 1])
    pads = inspire.world(inspire.contacts, xpos, xmat)
    chosen = choose_pads(sdf, pads, inspire.pad_finger)[0]
    d = np.abs(Sphere(tuple(centre), 0.04).sdf(pads[0, chosen])[0])
    assert np.sum(d < 0.002) >= 3  # at least three fingers' pads on the surface (within 2 mm)
    # [m] summed over the hand's samples: the energy keeps it small (1 cm costs as much as a unit force imbalance),
    # the selection's MuJoCo check bounds it (`test_planner_returns_deterministic_valid_grasps_that_do_not_penetrate`)
    assert terms["penetration"][best] < 5e-4 and terms["table"][best] == 0.0
    assert terms["force_closure"][best] < 0.5 < np.median(before)


def test_bad_parameters_are_refused() -> None:
    with pytest.raises(ConfigError, match="restarts"):
        DexOptPlanner(restarts=0)
    with pytest.raises(ConfigError, match="weights"):
        DexOptPlanner(weights={"nonsense": 1.0})
    planner = planner_registry.load("dexopt", weights={"distance": 50.0})
    assert planner.weights.distance == 50.0 and planner.name == "dexopt"
    # the terms not named keep the planner's defaults (not EnergyWeights' own: centroid 10, not 0)
    assert dataclasses.replace(planner.weights, distance=DEFAULT_WEIGHTS.distance) == DEFAULT_WEIGHTS


@pytest.mark.slow
def test_planner_returns_deterministic_valid_grasps_that_do_not_penetrate(tmp_path) -> None:
    from manigrasp.objects import build_object

    asset = build_object(trimesh.creation.cylinder(0.033, 0.10, sections=48), name="dexopt_test_can", mass=0.35,
                         cache_root=tmp_path).asset
    observation = Observation.from_asset(asset)
    hand = load_hand("inspire_right")
    planner = DexOptPlanner(restarts=12, iterations=100)
    first = planner.synthesise(observation, hand, 3, np.random.default_rng(5))
    again = planner.synthesise(observation, hand, 3, np.random.default_rng(5))
    assert 1 <= len(first) <= 3
    assert [s.energy for s in first] == [s.energy for s in again]
    np.testing.assert_array_equal(first[0].pose, again[0].pose)
    hk = planner.kinematics(hand)
    probe = HandProbe(hand, observation, clearance=0.0)
    addresses = probe.hand_qpos_addresses()
    for s in first:
        assert np.all(np.isfinite(s.pose)) and np.allclose(s.pose[:3, :3] @ s.pose[:3, :3].T, np.eye(3), atol=1e-9)
        assert s.joints.shape == (2, hand.n_actuators)
        assert np.all(s.joints >= hk.ctrl_low - 1e-12) and np.all(s.joints <= hk.ctrl_high + 1e-12)
        closing = np.sign(hand.closed_ctrl - hand.open_ctrl)
        assert np.all((s.joints[1] - s.joints[0]) * closing >= -1e-12)  # close_only: the path only closes
        assert np.any((s.joints[1] - s.joints[0]) * closing > 0.1)
        # Independently re-measured in MuJoCo: the planned configuration penetrates at most 1 mm.
        qpos = hk.full_qpos(np.zeros(3), np.array([1.0, 0, 0, 0]), s.q)
        assert _probe_contacts(probe, s.pose, _hand_q(hk, qpos, addresses))[0] <= 0.001
        assert s.penetration <= 0.001
    # The hold test: grasps that hold the standard protocol's loads at its squeeze come first.
    holds = [s.hold >= planner.min_hold_margin for s in first]
    assert holds == sorted(holds, reverse=True) and all(s.hold >= 0 for s in first)
    assert all(s.rotation >= 0 for s in first)  # the stiffness estimate's turn under the loads (recorded)
    candidates = planner.plan(observation, hand, 2, np.random.default_rng(5))
    assert candidates and all(c.planner == "dexopt" and 0 < c.score <= 1 for c in candidates)
    for c, s in zip(candidates, first, strict=False):
        np.testing.assert_array_equal(c.joints, s.joints)  # the hand path travels with the candidate
        np.testing.assert_array_equal(c.pose, s.pose)


def test_squeeze_caps_put_the_protocols_grip_on_the_weaker_side_and_pad_forces_balance_the_torques() -> None:
    from manigrasp.planners.dexopt_planner import pad_forces, squeeze_caps

    # Thumb presses 2, three fingers 1 each: the thumb is the weaker side (2 < 3); the grip 10 N is its force,
    # and the fingers press back with no more than it: 10 N shared as their presses are (not 15 N).
    caps = squeeze_caps(np.array([2.0, 1.0, 1.0, 1.0]), np.array([True, False, False, False]), 10.0)
    np.testing.assert_allclose(caps, [10.0, 10 / 3, 10 / 3, 10 / 3])
    uneven = squeeze_caps(np.array([1.0, 3.0, 1.0]), np.array([False, True, False]), 9.0)
    np.testing.assert_allclose(uneven, [4.5, 9.0, 4.5])  # the thumb (3) the stronger side: the fingers' 9 N
    one_side = squeeze_caps(np.array([1.0, 1.0]), np.array([False, False]), 4.0)
    np.testing.assert_allclose(one_side, [2.0, 2.0])  # one side only: its total is the grip
    # Pads on independent joints (rows = I): each pad presses its joint's torque; a pulling torque gives 0.
    np.testing.assert_allclose(pad_forces(np.eye(3), np.array([1.0, 2.0, -1.0])), [1.0, 2.0, 0.0], atol=1e-12)
    # Two pads on one joint (a finger with two links): any split with the sum = torque; nnls finds one >= 0.
    forces = pad_forces(np.array([[1.0], [2.0]]), np.array([4.0]))
    assert np.all(forces >= 0) and forces @ [1.0, 2.0] == pytest.approx(4.0)


def test_the_palm_pushes_back_what_the_fingers_press_into_it_and_the_load_test_credits_it() -> None:
    """A palm pad has no joint, so the squeeze's pad forces gave it nothing, and the caps held the fingers to the
    thumb's force: a wrap that presses the fingers' 23 N into the Allegro's palm read as a 9 N fingertip grasp."""
    from manigrasp.planners.dexopt_planner import palm_reaction, squeeze_caps

    # Thumb (+y push, 4 N) and two fingers (-y, 3 N each) press a box; the palm faces +x and takes nothing of
    # a push along y. A finger pushing along -x (5 N) is pushed back by the palm with its 5 N.
    normals = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    press = palm_reaction(np.array([4.0, 3.0, 3.0, 5.0, 0.0]), normals, np.array([0, 0, 0, 0, 1], bool))
    np.testing.assert_allclose(press, [4.0, 3.0, 3.0, 5.0, 5.0])
    thumb, palm = np.array([1, 0, 0, 0, 0], bool), np.array([0, 0, 0, 0, 1], bool)
    # The grip loop stops when the smaller side (the thumb's 4 N) reaches the grip: at 2 N everything halves;
    # at 10 N (more than the thumb can) the hand squeezes at its limits and the palm keeps its 5 N.
    np.testing.assert_allclose(squeeze_caps(press, thumb, 2.0, palm), press / 2)
    np.testing.assert_allclose(squeeze_caps(press, thumb, 10.0, palm), press)
    # Without the palm's reaction the old rule holds: each side's total is the grip.
    np.testing.assert_allclose(squeeze_caps(press[:4], thumb[:4], 10.0, palm[:4]), [10.0, 30 / 11, 30 / 11, 50 / 11])
    # A palm facing away from the fingers' push takes nothing (nonnegative).
    away = palm_reaction(np.array([0.0, 0.0, 0.0, 5.0, 0.0]), normals * [[1], [1], [1], [1], [-1]],
                         np.array([0, 0, 0, 0, 1], bool))
    assert away[-1] == 0.0


def test_the_hold_test_assumes_the_scenes_contact_friction_unless_the_planner_sets_its_own(tmp_path) -> None:
    """The same grasps (same seed): their hold margins at the rubber's 1.0 exceed those at 0.5 (friction
    carries the weight), 0.5 is what a context without a friction gives, and an explicit `friction` wins."""
    from dataclasses import replace

    from manigrasp.contact.defaults import STANDARD_MU
    from manigrasp.objects import build_object
    from manigrasp.planners.context import PlanContext

    asset = build_object(trimesh.creation.cylinder(0.033, 0.10, sections=48), name="dexopt_test_can", mass=0.35,
                         cache_root=tmp_path).asset
    observation = Observation.from_asset(asset)
    hand = load_hand("inspire_right")
    base = replace(PlanContext.standard(), grip_force=10.0)
    rubber = replace(base, contact_friction=1.0)

    def margins(planner: DexOptPlanner, context: PlanContext) -> dict[float, float]:
        found = planner.synthesise(observation, hand, 100, np.random.default_rng(5), None, context)
        return {round(s.energy, 9): s.hold for s in found}

    planner = DexOptPlanner(restarts=8, iterations=60)
    assert planner.contact_friction(base) == STANDARD_MU and planner.contact_friction(rubber) == 1.0
    assert DexOptPlanner(friction=0.7).contact_friction(rubber) == 0.7
    unknown, rigid, soft = margins(planner, base), margins(planner, replace(base, contact_friction=0.5)), \
        margins(planner, rubber)
    assert unknown == rigid and soft.keys() == rigid.keys()
    assert all(soft[e] >= rigid[e] for e in rigid) and any(soft[e] > rigid[e] > 0 for e in rigid)
    assert margins(DexOptPlanner(restarts=8, iterations=60, friction=0.5), rubber) == rigid


def test_pads_off_the_fingertips_are_held_at_the_links_friction_not_the_rubbers(tmp_path) -> None:
    """With `palm` and `wrap` the pads on the palm and the phalanges touch with the hand's 0.5 in the scene, only
    the fingertips with the rubber's 1.0: the hold test and the candidates' `contact_friction` say so (both read
    1.0 everywhere before), and the default fingertip pads are all on the rubber."""
    from dataclasses import replace

    from manigrasp.objects import build_object
    from manigrasp.planners.context import PlanContext
    from manigrasp.planners.dexopt import hold_margin

    asset = build_object(trimesh.creation.cylinder(0.033, 0.10, sections=48), name="dexopt_test_can", mass=0.35,
                         cache_root=tmp_path).asset
    observation = Observation.from_asset(asset)
    hand = load_hand("allegro_right")
    rubber = replace(PlanContext.standard(), grip_force=10.0, contact_friction=1.0)
    tips = set(hand.fingertip_geoms)
    for hk in (HandKinematics(hand), HandKinematics(hand, palm=True, wrap=True)):
        on_tip = np.array([hk.model.geom(int(g)).name in tips for g in hk.pad_geom])
        assert on_tip.all() == (not hk.palm)  # the default pads lie on the rubber tips; the palm is not rubber
    planner = DexOptPlanner(restarts=8, iterations=60, palm=True, wrap=True)
    found = planner.synthesise(observation, hand, 8, np.random.default_rng(0), None, rubber)
    assert found
    rows = np.concatenate([s.friction for s in found])
    assert set(np.round(rows[:, 0], 6)) == {0.5, 1.0}  # phalanx or palm contacts at 0.5, tips at 1.0
    for s in found:
        assert len(s.friction) == len(s.contacts)
    candidates = planner.plan(observation, hand, 4, np.random.default_rng(0), rubber)
    assert all(c.contact_friction is not None and len(c.contact_friction) == len(c.contacts) for c in candidates)
    # The hold test with per-contact friction: the same as a scalar when all agree, lower when some are 0.5.
    x = np.array([[0.03, 0.0, 0.0], [-0.03, 0.0, 0.0]])
    n = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    weight = np.array([[0.0, 0.0, -3.0]])
    caps = np.array([5.0, 5.0])
    assert hold_margin(x, n, caps, np.zeros(3), weight, np.array([1.0, 1.0])) == \
        pytest.approx(hold_margin(x, n, caps, np.zeros(3), weight, 1.0))
    # Two opposed pads pressing at most 5 N each: the moment balance splits the 3 N weight 1.5 / 1.5, and the pads
    # press alike, so the 0.5 pad needs 3 N: margin 5 / 3 (both at 1.0: 1.5 N, margin 10 / 3).
    assert hold_margin(x, n, caps, np.zeros(3), weight, np.array([1.0, 0.5])) == pytest.approx(5 / 3, rel=1e-6)
    assert hold_margin(x, n, caps, np.zeros(3), weight, 1.0) == pytest.approx(10 / 3, rel=1e-6)
    with pytest.raises(ConfigError, match="frictions"):
        hold_margin(x, n, caps, np.zeros(3), weight, np.array([1.0, 0.5, 0.5]))


def test_held_joint_stiffness_is_the_servos_gains_through_the_joint_to_command_map(inspire: HandKinematics) -> None:
    """A^T diag(kp') A: each servo that closes with the squeeze HOLD_GAIN times stiffer; for the Inspire hand
    (one servo per independent joint) the stiffness a joint resists with is its servo's kp' times dctrl/dq^2."""
    from manigrasp.control.hold import HOLD_GAIN
    from manigrasp.planners.dexopt_planner import held_joint_stiffness

    q = inspire.low + 0.4 * (inspire.high - inspire.low)
    _, a = inspire.ctrl(q)
    closing = np.zeros(len(inspire.actuators))
    closing[1:] = 1.0  # the thumb's rotation (actuator 0) does not take part in the squeeze
    stiffness = held_joint_stiffness(inspire, q, closing)
    gains = inspire.kp * np.where(closing != 0, HOLD_GAIN, 1.0)
    np.testing.assert_allclose(stiffness, a.T @ np.diag(gains) @ a, atol=1e-12)
    np.testing.assert_allclose(stiffness, stiffness.T, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(stiffness) > 0)  # every independent joint is held by a servo
    # Direct-drive joints: the joint stiffness is the gain (the Inspire's actuators drive one joint each).
    direct = np.flatnonzero(np.count_nonzero(np.abs(a) > 1e-12, axis=1) == 1)
    for k in direct:
        j = int(np.flatnonzero(np.abs(a[k]) > 1e-12)[0])
        if np.count_nonzero(np.abs(a[:, j]) > 1e-12) == 1:
            assert stiffness[j, j] == pytest.approx(gains[k] * a[k, j] ** 2)


def test_edge_points_put_a_boxs_corners_and_edges_between_its_face_samples() -> None:
    """A 4 x 2 x 1 cm box: its 8 corners and points along its 12 edges (4 cm edges at 5 mm: 9 points each), none
    on the faces' diagonals (flat: no edge there)."""
    from manigrasp.planners.dexopt_hand import _edge_points

    half = np.array([0.02, 0.01, 0.005])
    pts = _edge_points(trimesh.creation.box(extents=2 * half), 0.005)
    on_edge = np.sum(np.isclose(np.abs(pts), half, atol=1e-9), axis=1) >= 2  # two coordinates at the box's extent
    assert on_edge.all()
    corners = np.all(np.isclose(np.abs(pts), half, atol=1e-9), axis=1)
    assert corners.sum() == 8
    # Per edge direction: 4 parallel edges with ceil(length / 5 mm) + 1 points, corners shared by three edges.
    counts = [4 * (int(np.ceil(2 * h / 0.005)) + 1) for h in half]
    assert len(pts) == sum(counts) - 2 * 8


def test_a_mesh_geoms_samples_lie_on_its_convex_hull_as_mujoco_collides_it(inspire: HandKinematics) -> None:
    """The Inspire's meshes are concave (its palm's hull holds 2.5 x its volume): the samples the optimiser checks
    for penetration lie on the hulls (within rounding), not inside them in the meshes' hollows."""
    m = inspire.model
    geoms = [g for g in np.unique(inspire.sample_geom) if int(m.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_MESH)]
    assert any(abs(inspire._geom_mesh(g).volume) < 0.5 * inspire._geom_mesh(g).convex_hull.volume for g in geoms)
    for g in geoms:
        hull = inspire._geom_mesh(g).convex_hull
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, m.geom_quat[g])
        local = (inspire.samples.local[inspire.sample_geom == g] - m.geom_pos[g]) @ rot.reshape(3, 3)
        # signed distance to the hull's face planes: 0 on the hull, negative inside
        depth = np.max(local @ hull.face_normals.T - np.sum(hull.face_normals * hull.triangles[:, 0], axis=1),
                       axis=1)
        assert np.abs(depth).max() < 1e-6


def test_world_near_returns_every_point_in_the_box_or_below_the_height(inspire: HandKinematics) -> None:
    """Closed loop against `world`: every sample inside an object's box or below the table height is among the
    culled points, at the same position."""
    rng = np.random.default_rng(3)
    r = 6
    pos = rng.normal(scale=0.05, size=(r, 3)) + [0.0, 0.0, 0.1]
    quat = rng.normal(size=(r, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    q = inspire.low + rng.uniform(size=(r, inspire.n_q)) * (inspire.high - inspire.low)
    xpos, xmat, *_ = inspire.evaluate(pos, quat, q)
    world = inspire.world(inspire.samples, xpos, xmat)
    lo, hi, below = np.array([-0.03, -0.03, 0.05]), np.array([0.03, 0.03, 0.12]), 0.02
    rows, cols, pts = inspire.world_near(inspire.samples, xpos, xmat, lo, hi, below)
    np.testing.assert_allclose(pts, world[rows, cols], atol=1e-12)
    wanted = np.all((world >= lo) & (world <= hi), axis=2) | (world[..., 2] < below)
    got = np.zeros(wanted.shape, bool)
    got[rows, cols] = True
    assert wanted.sum() > 0 and np.all(got[wanted]) and got.sum() < got.size  # all of them, and fewer than all


def test_the_close_check_simulates_the_close_and_ranks_a_hand_closing_on_nothing_last(tmp_path) -> None:
    """`close_check`: a planned grasp and the same grasp 10 cm above the can (the hand closes on air) are closed in
    the simulation; the raised one ends `no_contact` and goes last whatever its place in the input, a candidate
    left unchecked (`close_check` 1) goes before a close that failed, and a grasp's verdict is its own figures'."""
    from dataclasses import replace

    from manigrasp.objects import build_object
    from manigrasp.planners.context import PlanContext

    asset = build_object(trimesh.creation.cylinder(0.033, 0.10, sections=48), name="dexopt_test_can", mass=0.35,
                         cache_root=tmp_path).asset
    observation = Observation.from_asset(asset)
    hand = load_hand("inspire_right")
    context = replace(PlanContext.standard(), grip_force=10.0, contact_friction=1.0)
    with pytest.raises(ConfigError, match="close_check"):
        DexOptPlanner(close_check=-1)
    planner = DexOptPlanner(restarts=8, iterations=60, close_check=2)
    found = planner.synthesise(observation, hand, 1, np.random.default_rng(5), None, context)
    checked = planner.last["close"]  # synthesise closed the first candidates, at most close_check of them
    assert found and 1 <= len(checked) <= 2 and (found[0].close is None or found[0].close.passed
                                                 or not any(c.passed for c in checked))
    unchecked = DexOptPlanner(restarts=8, iterations=60).synthesise(observation, hand, 100,
                                                                    np.random.default_rng(5), None, context)
    assert all(s.close is None for s in unchecked)
    grasp = next(s for s in unchecked if 0 in s.fingers)  # the best-ranked grasp with a thumb pad
    raised_pose = grasp.pose.copy()
    raised_pose[2, 3] += 0.10
    raised = replace(grasp, pose=raised_pose)
    hk = planner.kinematics(hand)
    order = planner.rerank_by_close(hk, observation, [raised, grasp], 2, context)
    assert order == [grasp, raised]
    assert raised.close.status == "no_contact" and not raised.close.passed
    c = grasp.close
    assert c.status == "" and c.fingers  # it grips the can
    assert c.passed == (not c.defects and c.margin >= planner.min_hold_margin)
    assert ("pushed" in c.defects) == (c.pushed > 0.005) and ("off-plan" in c.defects) == (c.gap > 0.015)
    # close_check 1: only the raised grasp is closed (it fails); the unchecked grasp goes before it.
    one = DexOptPlanner(restarts=8, iterations=60, close_check=1)
    fresh, up = replace(grasp, close=None), replace(raised, close=None)
    assert one.rerank_by_close(hk, observation, [up, fresh], 2, context) == [fresh, up]
    assert fresh.close is None and up.close.status == "no_contact"
    # close_defects off: the simulated margin alone decides (the same close, so the same figures).
    loose = replace(grasp, close=None)
    DexOptPlanner(close_check=1, close_defects=False).rerank_by_close(hk, observation, [loose], 1, context)
    assert loose.close.passed == (loose.close.margin >= planner.min_hold_margin)
    assert loose.close.defects == c.defects and loose.close.margin == pytest.approx(c.margin, rel=1e-6)
    # The simulated contacts' epsilon (the trials' sim_epsilon_l1): positive for the grip, 0 for the close on air;
    # close_min_epsilon fails a candidate below it.
    assert c.epsilon > 0 and raised.close.epsilon == 0
    for bar, passes in ((c.epsilon * 0.99, True), (c.epsilon * 1.01, False)):
        strict = replace(grasp, close=None)
        DexOptPlanner(close_check=1, close_defects=False, min_hold_margin=0.0,
                      close_min_epsilon=bar).rerank_by_close(hk, observation, [strict], 1, context)
        assert strict.close.epsilon == pytest.approx(c.epsilon, rel=1e-6) and strict.close.passed == passes
    with pytest.raises(ConfigError, match="close_min_epsilon"):
        DexOptPlanner(close_min_epsilon=-0.1)
    # close_order epsilon: within a class (here none passes: epsilon 10 is out of reach) the simulated epsilon
    # decides, highest first, the close on air last; close_min_margin replaces min_hold_margin in the check.
    pool = [replace(s, close=None) for s in unchecked[:3]] + [replace(raised, close=None)]
    ordered = DexOptPlanner(close_check=4, close_defects=False, close_min_epsilon=10.0,
                            close_order="epsilon").rerank_by_close(hk, observation, pool, 4, context)
    assert ordered[-1].close.status == "no_contact" and not any(s.close.passed for s in ordered)
    eps = [s.close.epsilon for s in ordered[:-1]]
    assert eps == sorted(eps, reverse=True) and len(set(eps)) > 1
    lenient = replace(grasp, close=None)
    DexOptPlanner(close_check=1, close_defects=False, close_min_margin=0.0).rerank_by_close(
        hk, observation, [lenient], 1, context)
    assert lenient.close.passed  # it grips, and no margin or epsilon is asked
    with pytest.raises(ConfigError, match="close_order"):
        DexOptPlanner(close_order="score")
    # close_defects as a list: only the named defects fail a candidate.
    for named in (["friction-used"], ["pushed", "off-plan"]):
        picky = replace(grasp, close=None)
        DexOptPlanner(close_check=1, close_defects=named).rerank_by_close(hk, observation, [picky], 1, context)
        assert picky.close.defects == c.defects
        assert picky.close.passed == (not set(c.defects) & set(named) and c.margin >= planner.min_hold_margin)
    assert DexOptPlanner(close_defects=True).failing_defects == CLOSE_DEFECTS
    assert DexOptPlanner(close_defects=False).failing_defects == ()
    assert DexOptPlanner(close_defects="pushed").failing_defects == ("pushed",)
    with pytest.raises(ConfigError, match="unknown close_defects.*friction-used"):
        DexOptPlanner(close_defects=["slipped"])


def test_finger_spheres_count_no_penetration_along_the_hands_free_close_but_do_where_the_links_collide() -> None:
    """The Fourier's neighbouring fingers lie side by side: their link-wide spheres overlap in the open hand though
    the links never touch. Along the open -> closed path the term is zero while MuJoCo finds the fingers clear,
    and positive once their real geoms collide (the thumb on the index at the full close)."""
    hk = HandKinematics(load_hand("fourier_right"))
    planner = DexOptPlanner()
    sdf = _sphere_grid(centre=(0.5, 0.5, 0.5))  # far from the hand: only the hand's own terms matter here
    full = hk.sphere_radius[:, None] + hk.sphere_radius[None]
    cross = hk.sphere_finger[:, None] != hk.sphere_finger[None]
    assert np.all(hk.sphere_reach[~cross] == 0) and np.all(hk.sphere_reach[cross] <= full[cross])
    pos, quat = np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0, 0.0]])
    xpos, xmat, *_ = hk.evaluate(pos, quat, hk.q_open[None])
    c = hk.world(hk.spheres, xpos, xmat)[0]
    dist = np.linalg.norm(c[:, None] - c[None], axis=2)
    assert 0.5 * np.where(cross & (dist < full), full - dist, 0.0).sum() > 0.01  # the spheres' own overlap
    for t in np.linspace(0.0, 1.0, 11):
        q = hk.q_open + t * (hk.q_closed - hk.q_open)
        overlap = hk.finger_overlap(hk.full_qpos(pos[0], quat[0], q))
        _, terms, _ = planner.energy(hk, sdf, np.array([0.5, 0.5, 0.5]), 0.04, -1.0, pos, quat, q[None],
                                     gradient=False)
        if overlap == 0.0:
            assert terms["self_penetration"][0] == 0.0, t
        else:
            assert terms["self_penetration"][0] > 0.001, t
    assert hk.finger_overlap(hk.full_qpos(pos[0], quat[0], hk.q_closed)) > 0.005  # the test reaches a collision


@pytest.mark.slow
def test_fingers_pressed_into_the_object_are_retracted_out_of_it_by_opening(tmp_path) -> None:
    """A planned grasp's fingers closed further, into the can from every side (the hand's back-off cannot take
    them out: it moves the whole hand): `_retract_fingers` opens them until the deepest penetration is within the
    tolerance, moving the joints toward the open hand only as far as needed."""
    from manigrasp.objects import build_object

    asset = build_object(trimesh.creation.cylinder(0.033, 0.10, sections=48), name="dexopt_test_can", mass=0.35,
                         cache_root=tmp_path).asset
    observation = Observation.from_asset(asset)
    hand = load_hand("inspire_right")
    # A grasp planned with fixed weights (those of before 4 Dec 2026): the test is of `_retract_fingers`, not of the
    # energy, and another grasp presses other joints in.
    weights = dataclasses.replace(DEFAULT_WEIGHTS, penetration=1000.0, table=1000.0, self_penetration=1000.0,
                                  centroid=1.0)
    planner = DexOptPlanner(restarts=8, iterations=60, weights=weights)
    grasp = planner.synthesise(observation, hand, 1, np.random.default_rng(5))[0]
    hk = planner.kinematics(hand)
    probe = HandProbe(hand, observation, clearance=0.0)
    addresses = probe.hand_qpos_addresses()
    root = grasp.pose @ hk.root_in_tcp

    def depth(q: np.ndarray) -> tuple[float, list]:
        qpos = hk.full_qpos(root[:3, 3], _mat_quats(root[None, :3, :3])[0], q)
        return _penetrations(probe, grasp.pose, _hand_q(hk, qpos, addresses))

    assert depth(grasp.q)[0] <= 0.001
    closing = hk.q_closed - hk.q_open
    pressed = np.clip(grasp.q + 0.15 * closing, hk.low, hk.high)
    deep, contacts = depth(pressed)
    assert deep > 0.003 and any(hk.body_finger[hk.body_id(body)] >= 0 for body, *_ in contacts)  # finger links
    q, left = _retract_fingers(hk, probe, grasp.pose, pressed, addresses, 0.001)
    assert left <= 0.001 and depth(q)[0] == pytest.approx(left)
    assert np.dot(q - pressed, closing) < 0  # opened
    assert np.all(np.abs(q - pressed) <= np.abs(pressed - grasp.q) + 0.05)  # not much past where it was planned
    # Nothing to do: the planned grasp is returned as it is.
    same, _ = _retract_fingers(hk, probe, grasp.pose, grasp.q, addresses, 0.001)
    np.testing.assert_array_equal(same, grasp.q)
