"""resists_wrench: a linear program that agrees with force closure and hand-derived limits."""

from __future__ import annotations

import numpy as np
import pytest

from manigrasp.contact import Contact, in_friction_cone
from manigrasp.grasp import GraspError, ferrari_canny, force_closure, grasp_matrix, resists_wrench

R = 0.05
ORIGIN = np.zeros(3)


def equator(mu: float = 0.5) -> list[Contact]:
    angles = np.deg2rad([0.0, 120.0, 240.0])
    points = R * np.stack([np.cos(angles), np.sin(angles), 0 * angles], axis=1)
    return [Contact(p, -p / R, mu) for p in points]


def box_pinch(mu: float, half_width: float = 0.03) -> list[Contact]:
    """Two opposing hard fingers on the x faces of a box, edge 0 of each cone along +z."""
    up = [0, 0, 1.0]
    return [Contact([half_width, 0, 0], [-1.0, 0, 0], mu, tangent=up),
            Contact([-half_width, 0, 0], [1.0, 0, 0], mu, tangent=up)]


def check_forces(contacts: list[Contact], wrench: np.ndarray, limit: float, scale: float) -> None:
    ok, forces = resists_wrench(contacts, ORIGIN, scale, wrench, limit)
    assert ok and forces is not None
    normals = np.array([c.normal for c in contacts])
    mu = np.array([c.mu for c in contacts])
    assert np.all(in_friction_cone(forces.force, normals, mu, tol=1e-7))
    assert np.all(np.sum(forces.force * normals, axis=1) <= limit + 1e-7)
    scaled = np.concatenate([wrench[:3], wrench[3:] / scale])
    np.testing.assert_allclose(grasp_matrix(contacts, ORIGIN, scale) @ forces.local, -scaled, atol=1e-7)
    np.testing.assert_allclose(forces.force.sum(axis=0), -wrench[:3], atol=1e-7)


def test_gravity_on_a_pinched_box_is_resisted_only_above_the_friction_threshold() -> None:
    """Box of mass 0.5 kg squeezed along x, gravity -z. Balance along x needs equal
    normal forces; along z the two friction forces carry m g, each at most
    mu f_n <= mu f_max, so it holds iff 2 mu f_max >= m g, i.e. f_max >= m g / (2 mu)
    = 0.5 * 9.81 / 1.0 = 4.905 N at mu = 0.5. Edge 0 of both cones points along +z,
    so the linearised cone is exact in that direction. The two friction forces
    are equal and opposite in lever arm, so no torque is left over."""
    gravity = np.array([0, 0, -0.5 * 9.81, 0, 0, 0])
    threshold = 0.5 * 9.81 / (2 * 0.5)
    assert resists_wrench(box_pinch(0.5), ORIGIN, 0.03, gravity, threshold * 1.001).resisted
    assert not resists_wrench(box_pinch(0.5), ORIGIN, 0.03, gravity, threshold * 0.999).resisted
    check_forces(box_pinch(0.5), gravity, threshold * 1.001, 0.03)
    ok, forces = resists_wrench(box_pinch(0.5), ORIGIN, 0.03, gravity, threshold * 0.999)
    assert forces is None and not ok


def test_in_closure_every_wrench_inside_the_epsilon_ball_is_resisted() -> None:
    """With per-contact limit f_max, the L1 wrench space scaled by f_max is feasible,
    so every wrench of scaled norm below eps_L1 * f_max must be resisted."""
    contacts, f_max = equator(), 10.0
    assert force_closure(contacts, ORIGIN, R)
    eps = ferrari_canny(contacts, ORIGIN, R)
    rng = np.random.default_rng(9)
    for direction in rng.normal(size=(25, 6)):
        scaled = 0.99 * eps * f_max * direction / np.linalg.norm(direction)
        wrench = np.concatenate([scaled[:3], scaled[3:] * R])
        check_forces(contacts, wrench, f_max, R)


def test_without_closure_the_unresisted_direction_stays_unresisted() -> None:
    """Two antipodal hard fingers on the x axis cannot apply any torque about x."""
    two = [Contact([R, 0, 0], [-1.0, 0, 0], 1.0), Contact([-R, 0, 0], [1.0, 0, 0], 1.0)]
    assert not resists_wrench(two, ORIGIN, R, np.array([0, 0, 0, 1e-3, 0, 0]), 1e3).resisted
    assert resists_wrench(two, ORIGIN, R, np.array([0, 0, -1.0, 0, 0, 0]), 1e3).resisted


def test_soft_fingers_report_the_torsion_they_use() -> None:
    """Two antipodal soft fingers resist a torque of 1e-3 N m about their axis only
    through torsion: each can give gamma f_n, so with f_max = 1 N and gamma = 0.01 m
    the limit is 2 * 0.01 = 0.02 N m."""
    soft = [Contact([R, 0, 0], [-1.0, 0, 0], 0.5, "soft_finger", 0.01),
            Contact([-R, 0, 0], [1.0, 0, 0], 0.5, "soft_finger", 0.01)]
    ok, forces = resists_wrench(soft, ORIGIN, R, np.array([0, 0, 0, 1e-3, 0, 0]), 1.0)
    assert ok and forces is not None
    # Torsion tau about the inward normal n gives torque tau n: -tau1 + tau2 = -1e-3.
    assert forces.torsion[1] - forces.torsion[0] == pytest.approx(-1e-3, abs=1e-9)
    assert not resists_wrench(soft, ORIGIN, R, np.array([0, 0, 0, 0.021, 0, 0]), 1.0).resisted
    assert resists_wrench(soft, ORIGIN, R, np.array([0, 0, 0, 0.019, 0, 0]), 1.0).resisted
    with pytest.raises(GraspError, match="shape"):
        resists_wrench(soft, ORIGIN, R, np.zeros(3), 1.0)
