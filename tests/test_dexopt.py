"""The energy terms of `manigrasp.planners.dexopt` on a sphere and a box: analytic values and analytic gradients."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from manigrasp.errors import ConfigError
from manigrasp.grasp.forces import balanced_forces
from manigrasp.planners import dexopt
from manigrasp.planners.dexopt import Box, EnergyWeights, Sphere

SPHERE = Sphere((0.01, -0.02, 0.1), 0.04)
ROT = np.array([[np.cos(0.4), -np.sin(0.4), 0.0], [np.sin(0.4), np.cos(0.4), 0.0], [0.0, 0.0, 1.0]]) @ np.array(
    [[1.0, 0.0, 0.0], [0.0, np.cos(0.3), -np.sin(0.3)], [0.0, np.sin(0.3), np.cos(0.3)]])
BOX = Box((0.02, 0.01, 0.08), (0.03, 0.05, 0.02), ROT)


def _numeric_gradient(f, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    g = np.zeros_like(x)
    for idx in np.ndindex(x.shape):
        step = np.zeros_like(x)
        step[idx] = h
        g[idx] = (f(x + step) - f(x - step)) / (2 * h)
    return g


def test_sphere_sdf_values_and_derivatives() -> None:
    c = np.array(SPHERE.centre)
    points = c + np.array([[0.08, 0.0, 0.0], [0.0, 0.0, -0.01], [0.03, 0.04, 0.0]])
    dist, grad, hess = SPHERE.sdf(points)
    np.testing.assert_allclose(dist, [0.04, -0.03, 0.01], atol=1e-12)
    np.testing.assert_allclose(grad[0], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(grad[1], [0, 0, -1], atol=1e-12)
    for p, g, h in zip(points, grad, hess, strict=True):
        np.testing.assert_allclose(_numeric_gradient(lambda x: SPHERE.sdf(x[None])[0][0], p), g, atol=1e-6)
        np.testing.assert_allclose(_numeric_gradient(lambda x: SPHERE.sdf(x[None])[1][0] @ np.ones(3), p),
                                   h @ np.ones(3), atol=1e-4)


def test_box_sdf_face_edge_corner_and_inside() -> None:
    box = Box((0.0, 0.0, 0.0), (0.03, 0.05, 0.02))
    points = np.array([[0.05, 0.0, 0.0],  # 2 cm off the +x face
                       [0.06, 0.09, 0.0],  # off the (+x, +y) edge by (3, 4) cm
                       [-0.04, -0.07, 0.04],  # off the corner by (1, 2, 2) cm
                       [0.0, 0.01, 0.015]])  # inside, 5 mm under the +z face
    dist, grad, _ = box.sdf(points)
    np.testing.assert_allclose(dist, [0.02, 0.05, 0.03, -0.005], atol=1e-12)
    np.testing.assert_allclose(grad[0], [1, 0, 0])
    np.testing.assert_allclose(grad[1], [0.6, 0.8, 0])
    np.testing.assert_allclose(grad[2], [-1 / 3, -2 / 3, 2 / 3])
    np.testing.assert_allclose(grad[3], [0, 0, 1])


def test_rotated_box_gradient_and_hessian_match_finite_differences() -> None:
    rng = np.random.default_rng(3)
    centre = np.array(BOX.centre)
    for _ in range(20):
        p = centre + ROT @ (np.array(BOX.half) * rng.uniform(-2.0, 2.0, 3))
        d, g, h = BOX.sdf(p[None])
        if np.min(np.abs(np.abs(ROT.T @ (p - centre)) - np.array(BOX.half))) < 1e-3:
            continue  # too close to a kink of the distance field for a finite difference
        np.testing.assert_allclose(_numeric_gradient(lambda x: BOX.sdf(x[None])[0][0], p), g[0], atol=1e-6)
        for k in range(3):
            np.testing.assert_allclose(_numeric_gradient(lambda x, k=k: BOX.sdf(x[None])[1][0, k], p), h[0][k],
                                       atol=1e-3)


def test_force_closure_is_zero_for_balanced_sphere_grasps_and_not_for_a_one_sided_one() -> None:
    c, r = np.array(SPHERE.centre), SPHERE.radius
    three = c + r * np.array([[np.cos(a), np.sin(a), 0.0] for a in (0.3, 0.3 + 2 * np.pi / 3, 0.3 + 4 * np.pi / 3)])
    two = c + r * np.array([[0.0, 0.6, 0.8], [0.0, -0.6, -0.8]])
    assert dexopt.force_closure(three, SPHERE)[0] == pytest.approx(0.0, abs=1e-20)
    assert dexopt.force_closure(two, SPHERE)[0] == pytest.approx(0.0, abs=1e-20)
    cap = c + r * np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, 0.6, 0.8]])
    # The normals' sum of a one-sided grasp: |(0.6, 0.6, 2.6)|^2; radial normals exert no torque about c,
    # and their torque about the origin is c x (sum n).
    force = np.array([0.6, 0.6, 2.6])
    assert dexopt.force_closure(cap, SPHERE)[0] == pytest.approx(force @ force + np.cross(c, -force) @ np.cross(
        c, -force))


def test_force_closure_of_two_offset_box_contacts_is_the_squared_torque_arm() -> None:
    """Opposite contacts on the +-x faces at heights a and b: the forces cancel, the torque is (a - b) about z."""
    box = Box((0.0, 0.0, 0.0), (0.03, 0.05, 0.02))
    a, b = 0.01, -0.015
    points = np.array([[0.03, a, 0.0], [-0.03, b, 0.0]])
    assert dexopt.force_closure(points, box)[0] == pytest.approx((a - b) ** 2)
    assert dexopt.force_closure(np.array([[0.03, a, 0.0], [-0.03, a, 0.0]]), box)[0] == pytest.approx(0.0)


@pytest.mark.parametrize("shape", [SPHERE, BOX], ids=["sphere", "box"])
def test_analytic_gradients_match_finite_differences(shape) -> None:
    rng = np.random.default_rng(7)
    centre = np.array(shape.centre)
    points = centre + rng.normal(scale=0.05, size=(4, 3))
    for term in (dexopt.force_closure, dexopt.contact_distance, dexopt.penetration):
        value, gradient = term(points, shape)
        numeric = _numeric_gradient(lambda x, term=term: term(x, shape)[0], points)
        np.testing.assert_allclose(gradient, numeric, rtol=1e-5, atol=1e-7, err_msg=term.__name__)


def test_penetration_table_and_joint_limits_measure_depths() -> None:
    c, r = np.array(SPHERE.centre), SPHERE.radius
    samples = np.array([c + [0.0, 0.0, r - 0.004], c + [0.0, 0.0, r + 0.01], [0.0, 0.0, -0.003]])
    value, gradient = dexopt.penetration(samples, SPHERE)
    assert value == pytest.approx(0.004)
    np.testing.assert_allclose(gradient, [[0, 0, -1], [0, 0, 0], [0, 0, 0]])  # descent pushes the sample out
    value, gradient = dexopt.table_penetration(samples, 0.0)
    assert value == pytest.approx(0.003) and gradient[2].tolist() == [0, 0, -1] and not gradient[:2].any()
    value, gradient = dexopt.joint_limits(np.array([0.5, 1.8, -0.3]), np.zeros(3), np.full(3, 1.6))
    assert value == pytest.approx(0.5) and gradient.tolist() == [0.0, 1.0, -1.0]


def test_descent_on_the_energy_brings_three_contacts_to_a_balanced_grasp() -> None:
    """Plain gradient descent on E_fc + 100 E_dis from three points near one side of the sphere."""
    c, r = np.array(SPHERE.centre), SPHERE.radius
    points = c + np.array([[0.05, 0.01, 0.0], [0.01, 0.05, 0.01], [-0.02, 0.045, -0.01]])
    weights = EnergyWeights()
    first = None
    for _ in range(3000):
        e_fc, g_fc = dexopt.force_closure(points, SPHERE)
        e_dis, g_dis = dexopt.contact_distance(points, SPHERE)
        first = first if first is not None else e_fc
        points = points - 1e-4 * (weights.force_closure * g_fc + weights.distance * g_dis)
    assert first > 0.5
    assert dexopt.force_closure(points, SPHERE)[0] < 1e-10
    np.testing.assert_allclose(SPHERE.sdf(points)[0], 0.0, atol=1e-6)  # on the surface
    # Three unit normals summing to zero: the contacts lie on a great circle, 120 degrees apart.
    unit = (points - c) / r
    for i, j in ((0, 1), (1, 2), (0, 2)):
        assert np.degrees(np.arccos(unit[i] @ unit[j])) == pytest.approx(120.0, abs=0.01)


def test_weights_must_be_non_negative() -> None:
    with pytest.raises(ConfigError, match="distance"):
        EnergyWeights(distance=-1.0)


FINGER = """
<mujoco>
  <worldbody>
    <body name="palm">
      <freejoint/>
      <geom type="box" size="0.02 0.02 0.01"/>
      <body name="link" pos="0 0 0.02">
        <joint name="bend" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.05" size="0.008"/>
        <body name="tip" pos="0 0 0.05">
          <joint name="tip_bend" type="hinge" axis="0 1 0"/>
          <geom type="sphere" size="0.01"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_chain_rule_through_mujoco_jacobians_matches_finite_differences_over_the_dofs() -> None:
    model = mujoco.MjModel.from_xml_string(FINGER)
    data = mujoco.MjData(model)
    qpos0 = np.array([0.01, 0.02, 0.03, 0.9, 0.1, -0.2, 0.3, 0.4, 0.5])
    qpos0[3:7] /= np.linalg.norm(qpos0[3:7])
    bodies = np.array([model.body("tip").id, model.body("link").id])
    local = np.array([[0.0, 0.0, 0.01], [0.008, 0.0, 0.03]])  # points fixed on the bodies

    def points_at(qpos: np.ndarray) -> np.ndarray:
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        return np.array([data.xpos[b] + data.xmat[b].reshape(3, 3) @ p for b, p in zip(bodies, local, strict=True)])

    def value(qpos: np.ndarray) -> float:
        return dexopt.force_closure(points_at(qpos), SPHERE)[0] + dexopt.contact_distance(points_at(qpos), SPHERE)[0]

    points = points_at(qpos0)
    grad_points = dexopt.force_closure(points, SPHERE)[1] + dexopt.contact_distance(points, SPHERE)[1]
    analytic = dexopt.chain_to_dofs(model, data, bodies, points, grad_points)
    numeric = np.zeros(model.nv)
    for k in range(model.nv):
        shifted = []
        for sign in (1.0, -1.0):
            q = qpos0.copy()
            dv = np.zeros(model.nv)
            dv[k] = sign * 1e-6
            mujoco.mj_integratePos(model, q, dv, 1.0)
            shifted.append(value(q))
        numeric[k] = (shifted[0] - shifted[1]) / 2e-6
    np.testing.assert_allclose(analytic, numeric, rtol=1e-4, atol=1e-8)


# ---------------------------------------------------------------------- hold margin (load feasibility)
MU, CAP, MASS, G = 0.5, 10.0, 0.8, 9.81
WEIGHT = np.array([[0.0, 0.0, -MASS * G]])


def test_friction_pyramid_spans_the_cone_exactly_along_the_vertical() -> None:
    normals = np.array([[1.0, 0.0, 0.0], [0.0, -0.6, 0.8]])
    gen = dexopt.friction_pyramid(normals, MU, 8)
    assert gen.shape == (2, 8, 3)
    for n, g in zip(normals, gen, strict=True):
        np.testing.assert_allclose(g @ n, 1.0)  # unit normal component
        np.testing.assert_allclose(np.linalg.norm(g - n, axis=1), MU)  # on the cone
    # The first contact's normal is horizontal: two edges point straight up and down, mu off the normal.
    assert np.any(np.all(np.isclose(gen[0], [1.0, 0.0, MU]), axis=1))
    assert np.any(np.all(np.isclose(gen[0], [1.0, 0.0, -MU]), axis=1))


def test_two_opposed_contacts_hold_a_box_iff_two_mu_f_reaches_its_weight() -> None:
    x = np.array([[-0.03, 0.0, 0.0], [0.03, 0.0, 0.0]])
    n = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    h = dexopt.hold_margin(x, n, [CAP, CAP], np.zeros(3), WEIGHT, MU)
    assert h == pytest.approx(2 * MU * CAP / (MASS * G), rel=1e-6)
    f_just = MASS * G / (2 * MU)  # the squeeze at which 2 mu F = m g
    assert dexopt.hold_margin(x, n, [1.01 * f_just] * 2, np.zeros(3), WEIGHT, MU) >= 1.0
    assert dexopt.hold_margin(x, n, [0.99 * f_just] * 2, np.zeros(3), WEIGHT, MU) < 1.0
    # Homogeneous: twice the caps, twice the margin; twice the load, half.
    assert dexopt.hold_margin(x, n, [2 * CAP] * 2, np.zeros(3), WEIGHT, MU) == pytest.approx(2 * h, rel=1e-6)
    assert dexopt.hold_margin(x, n, [CAP] * 2, np.zeros(3), 2 * WEIGHT, MU) == pytest.approx(h / 2, rel=1e-6)
    # A push along the grasp line beyond one contact's cap cannot be held: the far contact must push F + cap.
    push = np.array([[2.5 * CAP, 0.0, 0.0]])
    assert dexopt.hold_margin(x, n, [CAP] * 2, np.zeros(3), push, MU) == pytest.approx(0.4, rel=1e-6)


def test_a_pinch_off_the_centre_of_mass_needs_torsion_against_the_weights_torque() -> None:
    x = np.array([[-0.03, 0.02, 0.0], [0.03, 0.02, 0.0]])  # the grasp line 2 cm beside the centre of mass
    n = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    assert dexopt.hold_margin(x, n, [CAP] * 2, np.zeros(3), WEIGHT, MU) == 0.0  # point contacts: it turns
    h = dexopt.hold_margin(x, n, [CAP] * 2, np.zeros(3), WEIGHT, MU, torsion=0.005)
    assert h == pytest.approx(min(2 * MU * CAP / (MASS * G), 2 * 0.005 * CAP / (MASS * G * 0.02)), rel=1e-6)


def test_three_contacts_around_a_sphere_share_its_weight_and_the_protocol_loads() -> None:
    from manigrasp.planners.hold import loads

    angle = 2 * np.pi * np.arange(3) / 3
    x = 0.04 * np.stack([np.cos(angle), np.sin(angle), np.zeros(3)], axis=1)
    n = -x / 0.04
    assert dexopt.hold_margin(x, n, [CAP] * 3, np.zeros(3), WEIGHT, MU) == pytest.approx(
        3 * MU * CAP / (MASS * G), rel=1e-6)
    # Weight plus m g down (the standard protocol's -z perturbation): 2 m g shared by three contacts; the
    # sideways perturbations also take normal force from the contacts, so all seven loads hold less.
    down = dexopt.hold_margin(x, n, [CAP] * 3, np.zeros(3), loads(MASS, 1.0)[[0, 6]], MU)
    assert down == pytest.approx(3 * MU * CAP / (2 * MASS * G), rel=1e-6)
    assert 0.5 * down < dexopt.hold_margin(x, n, [CAP] * 3, np.zeros(3), loads(MASS, 1.0), MU) < down
    # Two contacts pressing from one side cannot balance a sideways load whatever the squeeze.
    assert dexopt.hold_margin(x[:1], n[:1], [CAP], np.zeros(3), loads(MASS, 1.0), MU) == 0.0
    # A single contact under the object carries its weight without friction: margin F / (m g).
    below = dexopt.hold_margin(np.array([[0.0, 0.0, -0.04]]), np.array([[0.0, 0.0, 1.0]]), [CAP], np.zeros(3),
                               WEIGHT, 0.0)
    assert below == pytest.approx(CAP / (MASS * G), rel=1e-6)
    assert dexopt.hold_margin(x, n, [CAP] * 3, np.zeros(3), np.zeros((1, 3)), MU) == float("inf")
    with pytest.raises(ConfigError, match="caps"):
        dexopt.hold_margin(x, n, [CAP] * 2, np.zeros(3), WEIGHT, MU)


def _pinch(height: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two contacts across a sphere's centre along x (at `height` above it), each on its own Cartesian finger."""
    r = 0.03
    x = np.array([[r, 0.0, height], [-r, 0.0, height]])
    n = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    jac = np.zeros((2, 3, 6))
    jac[0, :, :3], jac[1, :, 3:] = np.eye(3), np.eye(3)
    return x, n, jac


def test_grasp_stiffness_of_a_symmetric_pinch_is_the_series_springs_times_the_lever() -> None:
    """Each contact is the series of its pad (k_c) and its finger (k_f): 2 k_e in translation, 2 k_e r^2 in
    rotation across the pinch line, nothing about it but the contacts' torsion."""
    x, n, jac = _pinch()
    kc, kf, kt = 1e4, 5e3, 0.1
    k_e = 1.0 / (1.0 / kc + 1.0 / kf)
    stiffness = dexopt.grasp_stiffness(x, n, jac, kf * np.eye(6), np.zeros(3), kc)
    np.testing.assert_allclose(stiffness, np.diag([2 * k_e] * 3 + [0.0, 2 * k_e * 0.03**2, 2 * k_e * 0.03**2]),
                               atol=1e-9)
    twisted = dexopt.grasp_stiffness(x, n, jac, kf * np.eye(6), np.zeros(3), kc, torsion_stiffness=kt)
    assert twisted[3, 3] == pytest.approx(2 * kt)
    # A finger joint no servo holds lets its contact go: only the other finger holds.
    free = kf * np.eye(6)
    free[3:, 3:] = 0.0
    one = dexopt.grasp_stiffness(x, n, jac, free, np.zeros(3), kc)
    assert one[0, 0] == pytest.approx(k_e, rel=1e-4)


def test_load_rotation_of_a_pinch_above_the_centre_of_mass_is_the_torque_over_the_torsion() -> None:
    """A side load m g at the centre of mass, h below the pinch line, turns the object about the line by
    m g h / (2 k_t); the weight (along the arm) does not turn it; without torsion the turn is unbounded."""
    x, n, jac = _pinch(height=0.02)
    kt = 0.1
    stiffness = dexopt.grasp_stiffness(x, n, jac, 5e3 * np.eye(6), np.zeros(3), 1e4, torsion_stiffness=kt)
    rotation, _ = dexopt.load_rotation(stiffness, np.array([[0.0, 0.0, -5.0], [0.0, 5.0, 0.0], [5.0, 0.0, 0.0]]))
    assert rotation[0] == pytest.approx(0.0, abs=1e-9)
    assert rotation[1] == pytest.approx(5.0 * 0.02 / (2 * kt))
    assert rotation[2] < 0.1 * rotation[1]  # along the line: held by the fingers' lateral stiffness
    loose = dexopt.grasp_stiffness(x, n, jac, 5e3 * np.eye(6), np.zeros(3), 1e4)
    assert np.isinf(dexopt.load_rotation(loose, np.array([[0.0, 5.0, 0.0]]))[0][0])


def _wedge_pinch(tilt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two contacts at x = -+5 cm whose inward normals lean `tilt` [rad] up from the line between them (a wedge),
    each pushed by a slide joint of its own along the line (joint 0 moves contact 0 along +x, joint 1 contact 1
    along -x)."""
    points = np.array([[-0.05, 0.0, 0.0], [0.05, 0.0, 0.0]])
    normals = np.array([[np.cos(tilt), 0.0, np.sin(tilt)], [-np.cos(tilt), 0.0, np.sin(tilt)]])
    jac = np.zeros((2, 3, 2))
    jac[0, 0, 0], jac[1, 0, 1] = 1.0, -1.0
    return points, normals, jac


@pytest.mark.parametrize("tilt", [0.0, 0.2, 0.6])
def test_squeeze_friction_of_a_pinch_is_the_tangent_of_the_normals_tilt(tilt: float) -> None:
    # Two contacts can only squeeze each other along their line: the tangential part over the normal is tan(tilt),
    # whatever the size of the squeeze.
    points, normals, jac = _wedge_pinch(tilt)
    for size in (1.0, 7.0):
        used = dexopt.squeeze_friction(points, normals, jac, size * np.ones(2), np.zeros(3))
        assert used == pytest.approx(np.tan(tilt), abs=1e-9)


def test_squeeze_friction_is_infinite_when_the_joints_pull_the_contacts_apart() -> None:
    points, normals, jac = _wedge_pinch(0.2)
    assert dexopt.squeeze_friction(points, normals, jac, -np.ones(2), np.zeros(3)) == float("inf")


def test_squeeze_friction_of_three_fingers_pressing_a_sphere_along_its_normals_is_zero() -> None:
    # Three contacts 120 deg apart on a sphere's equator, each on a slide joint along its inward normal: the
    # internal forces along the normals produce the joint torques exactly, with no friction. A second joint
    # pushing contact 0 up cannot be balanced by the object (three contacts in a plane press no vertical forces
    # that cancel in force and torque): the fit leaves it over (the finger moves), the friction stays 0.
    angles = 2.0 * np.pi * np.arange(3) / 3.0
    points = 0.04 * np.stack([np.cos(angles), np.sin(angles), np.zeros(3)], axis=1)
    normals = -points / 0.04
    jac = np.zeros((3, 3, 4))
    for i in range(3):
        jac[i, :, i] = normals[i]
    jac[0, 2, 3] = 1.0
    assert dexopt.squeeze_friction(points, normals, jac, np.array([1.0, 1.0, 1.0, 0.0]), np.zeros(3)) == \
        pytest.approx(0.0, abs=1e-9)
    assert dexopt.squeeze_friction(points, normals, jac, np.array([1.0, 1.0, 1.0, 0.5]), np.zeros(3)) == \
        pytest.approx(0.0, abs=1e-9)
    # Unequal pushes (1, 2, 1) along the normals: the extra unit at contact 1 must be balanced by the tangential
    # forces of contacts 0 and 2 (b and -b, no net torque), 2 b sin(60 deg) = 1: sum |t| / sum f_n = (2 / sqrt 3) / 4.
    assert dexopt.squeeze_friction(points, normals, jac, np.array([1.0, 2.0, 1.0, 0.0]), np.zeros(3)) == \
        pytest.approx(np.sqrt(3.0) / 6.0, rel=1e-9)


@pytest.mark.parametrize("tilt", [0.0, 0.3])
def test_balanced_squeeze_of_a_wedge_pinch_needs_the_tangent_of_its_tilt(tilt: float) -> None:
    """Two contacts whose normals lean `tilt` up from their line: the only internal forces press along that line,
    each a normal part cos and a tangential part sin of it: friction tan(tilt), equal forces, mean normal 1."""
    points, normals, _ = _wedge_pinch(tilt)
    forces = balanced_forces(points, normals, np.zeros(3))
    assert forces is not None
    np.testing.assert_allclose(forces.sum(axis=0), 0.0, atol=1e-9)
    np.testing.assert_allclose(forces[:, 1:], 0.0, atol=1e-9)  # along the line (x) only
    normal = np.einsum("ki,ki->k", forces, normals)
    np.testing.assert_allclose(normal, 1.0, atol=1e-9)
    tangential = np.linalg.norm(forces - normal[:, None] * normals, axis=1)
    assert tangential.sum() / normal.sum() == pytest.approx(np.tan(tilt), abs=1e-9)


def test_balanced_squeeze_of_a_thumb_against_two_fingers_takes_no_friction() -> None:
    """A thumb at -x against two fingers at +x, +-2 cm in y, all pressing along x: balanced by normal forces alone
    (the thumb twice each finger), where equal unit pushes (the planner's first squeeze) leave a net push of 1."""
    points = np.array([[-0.03, 0.0, 0.0], [0.03, 0.02, 0.0], [0.03, -0.02, 0.0]])
    normals = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    forces = balanced_forces(points, normals, np.zeros(3))
    np.testing.assert_allclose(forces, [[1.5, 0, 0], [-0.75, 0, 0], [-0.75, 0, 0]], atol=1e-9)
    assert np.linalg.norm(normals.sum(axis=0)) == pytest.approx(1.0)


def test_balanced_forces_carry_a_load_by_friction_shared_between_a_pinch() -> None:
    """A pinch along x at +-3 cm about the centre, a weight of 0.5 (in units of the mean normal force) along -z: the
    contacts carry it as 0.25 each of upward friction, pressing 1 each; with friction bounded at 0.2 nothing does."""
    points = np.array([[0.03, 0.0, 0.0], [-0.03, 0.0, 0.0]])
    normals = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    forces = balanced_forces(points, normals, np.zeros(3), load=np.array([0.0, 0.0, -0.5]))
    np.testing.assert_allclose(forces, [[-1.0, 0.0, 0.25], [1.0, 0.0, 0.25]], atol=1e-9)
    assert balanced_forces(points, normals, np.zeros(3), load=np.array([0.0, 0.0, -0.5]), friction=0.3) is not None
    assert balanced_forces(points, normals, np.zeros(3), load=np.array([0.0, 0.0, -0.5]), friction=0.2) is None


def test_balanced_forces_of_a_contact_without_a_normal_is_none_not_an_lp_error() -> None:
    """A link pressing from opposite sides of itself has no net normal: its NaN direction reached the LP, which
    raised (a harness fault on every resume)."""
    points = np.array([[0.03, 0.0, 0.0], [-0.03, 0.0, 0.0]])
    normals = np.array([[np.nan, np.nan, np.nan], [1.0, 0.0, 0.0]])
    assert balanced_forces(points, normals, np.zeros(3)) is None


def test_balanced_squeeze_is_none_where_the_normals_cannot_oppose() -> None:
    points = np.array([[0.0, 0.0, 0.0], [0.02, 0.0, 0.0]])
    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])  # both pushing up: no internal force presses them
    assert balanced_forces(points, normals, np.zeros(3)) is None
    assert balanced_forces(points[:1], normals[:1], np.zeros(3)) is None


def test_the_planner_squeezes_with_whichever_forces_use_less_friction_through_its_actuators() -> None:
    """Random grasps of three contacts on random underactuated hands (9 joints, 5 actuators through a random
    joint -> command map): the squeeze's actuator forces are the balanced squeeze's where the friction they use
    (`squeeze_friction` of the torques the actuators produce) is below that of unit pushes along the normals, the
    unit pushes' otherwise; never more friction than the unit pushes, and in some grasps less. Off: unit pushes."""
    from types import SimpleNamespace

    from manigrasp.planners.dexopt_planner import DexOptPlanner

    rng = np.random.default_rng(3)
    hk = SimpleNamespace(hand=SimpleNamespace(open_ctrl=np.zeros(5), closed_ctrl=np.ones(5)))
    on, off = DexOptPlanner(close_only=False, balanced_squeeze=True), DexOptPlanner(close_only=False)
    lower = 0
    for _ in range(20):
        angles = np.array([0.0, 2.3, 3.9]) + rng.normal(0.0, 0.3, 3)
        points = 0.03 * np.stack([np.cos(angles), np.sin(angles), rng.normal(0.0, 0.3, 3)], axis=1)
        normals = -points + rng.normal(0.0, 0.01, (3, 3))
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        jac = rng.normal(0.0, 1.0, (3, 3, 9))
        a = rng.normal(0.0, 1.0, (5, 9))
        rows = np.einsum("ki,kij->kj", normals, jac)
        chosen = on._squeeze_force(hk, a, rows, jac, points, normals, np.zeros(3))
        unit = off._squeeze_force(hk, a, rows, jac, points, normals, np.zeros(3))
        np.testing.assert_allclose(unit, np.linalg.lstsq(a.T, rows.sum(axis=0), rcond=None)[0], atol=1e-9)
        forces = balanced_forces(points, normals, np.zeros(3))
        balanced = np.linalg.lstsq(a.T, np.einsum("ki,kij->j", forces, jac), rcond=None)[0]
        used = {name: dexopt.squeeze_friction(points, normals, jac, a.T @ f, np.zeros(3))
                for name, f in (("unit", unit), ("balanced", balanced))}
        expected = balanced if used["balanced"] < used["unit"] else unit
        np.testing.assert_allclose(chosen, expected, atol=1e-9)
        assert dexopt.squeeze_friction(points, normals, jac, a.T @ chosen, np.zeros(3)) <= used["unit"] + 1e-9
        lower += used["balanced"] < used["unit"] - 1e-6
    assert lower >= 5
