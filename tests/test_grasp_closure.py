"""Force closure on textbook cases, and the smallest friction for closure."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from manigrasp.contact import Contact, ContactSet
from manigrasp.grasp import (
    closure_margin,
    ferrari_canny,
    force_closure,
    force_closure_batch,
    min_friction_for_closure,
    min_friction_for_closure_batch,
)

R = 0.05  # sphere radius [m]
ORIGIN = np.zeros(3)


def antipodal(kind: str = "hard_finger") -> list[Contact]:
    gamma = 0.01 if kind == "soft_finger" else 0.0
    return [Contact([R, 0, 0], [-1.0, 0, 0], 0.5, kind, gamma),
            Contact([-R, 0, 0], [1.0, 0, 0], 0.5, kind, gamma)]


def equator(mu: float = 0.5, tilt: float = 0.0) -> list[Contact]:
    """Three hard fingers 120 degrees apart on the equator; normals tilted by `tilt`
    [rad] about z (all the same way), with edge 0 of each cone pointing along the tilt."""
    out = []
    for angle in np.deg2rad([0.0, 120.0, 240.0]):
        radial = -np.array([np.cos(angle), np.sin(angle), 0.0])
        side = np.cross([0, 0, 1.0], radial)
        normal = np.cos(tilt) * radial + np.sin(tilt) * side
        tangent = np.cos(tilt) * side - np.sin(tilt) * radial  # the tilt direction, unit, ⊥ normal
        out.append(Contact(-R * radial, normal, mu, tangent=-tangent))
    return out


def cube_seven() -> list[Contact]:
    """Seven frictionless face contacts on a cube of half-size 4 (torque scale 1).

    Wrench (n, tau) at -4 n + n x tau: six with one normal per face, and a
    seventh equal to minus (u1 + 2 u2 + u3 + u4 + u5 + u6), so the seven
    wrenches have a strictly positive combination summing to zero.
    """
    specs = [((1, 0, 0), (0, 1, 0)), ((-1, 0, 0), (0, 0, 1)), ((0, 1, 0), (1, 0, 0)),
             ((0, -1, 0), (-2, 0, 1)), ((0, 0, 1), (0, 1, 0)), ((0, 0, -1), (1, -1, 0)),
             ((1, 0, 0), (0, -1, -3))]
    out = []
    for n, tau in specs:
        n, tau = np.array(n, float), np.array(tau, float)
        out.append(Contact(-4.0 * n + np.cross(n, tau), n, 0.0, "frictionless"))
    return out


def test_two_antipodal_hard_fingers_are_not_in_closure_but_soft_fingers_are() -> None:
    assert not force_closure(antipodal(), ORIGIN, R)
    assert ferrari_canny(antipodal(), ORIGIN, R) == 0.0
    assert force_closure(antipodal("soft_finger"), ORIGIN, R)
    assert ferrari_canny(antipodal("soft_finger"), ORIGIN, R) > 0.01


def test_a_single_contact_is_not_in_closure() -> None:
    one = antipodal()[:1]
    assert not force_closure(one, ORIGIN, R)
    assert closure_margin(one, ORIGIN, R) == 0.0
    assert ferrari_canny(one, ORIGIN, R) == 0.0 and ferrari_canny(one, ORIGIN, R, "Linf") == 0.0


def test_seven_frictionless_contacts_on_a_cube_close_and_fewer_never_do() -> None:
    seven = cube_seven()
    assert force_closure(seven, ORIGIN, 1.0)
    assert ferrari_canny(seven, ORIGIN, 1.0) > 0.01
    for k in range(1, 7):
        for subset in itertools.combinations(seven, k):
            assert not force_closure(list(subset), ORIGIN, 1.0)
    rng = np.random.default_rng(3)  # any six frictionless face contacts: never
    axes = np.concatenate([np.eye(3), -np.eye(3)])
    normals = axes[rng.integers(0, 6, size=(200, 6))]
    positions = -4.0 * normals + rng.uniform(-3, 3, size=(200, 6, 3)) * (normals == 0)
    assert not force_closure_batch(ContactSet(positions, normals, 0.0, "frictionless"), ORIGIN, 1.0).any()


def test_three_hard_fingers_on_the_equator_with_mu_half_are_in_closure() -> None:
    assert force_closure(equator(0.5), ORIGIN, R)
    assert closure_margin(equator(0.5), ORIGIN, R) > 0.05


def test_lp_closure_agrees_with_facet_enumeration_and_brackets_epsilon() -> None:
    """The LP margin s satisfies s / sqrt(6) <= eps_L1 <= s (closure module docstring)."""
    rng = np.random.default_rng(4)
    p = rng.normal(size=(40, 3, 3))
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    cs = ContactSet(R * p, -p, rng.uniform(0.1, 1.0, size=(40, 3)))
    batch = force_closure_batch(cs, ORIGIN, R)
    assert 5 < batch.sum() < 35  # both outcomes are exercised
    for b in range(40):
        one = ContactSet(cs.positions[b : b + 1], cs.normals[b : b + 1], cs.mu[b : b + 1])
        s, eps = closure_margin(one, ORIGIN, R), ferrari_canny(one, ORIGIN, R)
        assert force_closure(one, ORIGIN, R) == batch[b]
        assert s / np.sqrt(6) - 1e-6 <= eps <= s + 1e-6


def test_min_friction_matches_the_tilt_of_the_normals() -> None:
    """Tilting every normal by alpha about z (all the same way) makes each radial
    force leave the cone unless mu >= tan(alpha); the three contact forces can only
    balance with no torque about z if they are radial, so the threshold is tan(alpha).
    Edge 0 of each linearised cone points along the tilt, so it is exact there."""
    for alpha in (0.2, 0.35):
        mu = min_friction_for_closure(equator(tilt=alpha), ORIGIN, R, tol=1e-5)
        assert np.tan(alpha) < mu <= np.tan(alpha) + 2e-5
    assert min_friction_for_closure(antipodal(), ORIGIN, R) == np.inf


def test_min_friction_batch_matches_single_and_handles_bracket_ends() -> None:
    cs = ContactSet.stack([equator(tilt=0.2), equator(tilt=0.6)])
    got = min_friction_for_closure_batch(cs, ORIGIN, R, mu_max=0.5)
    assert got[0] == pytest.approx(min_friction_for_closure(equator(tilt=0.2), ORIGIN, R), abs=1e-12)
    assert got[1] == np.inf  # tan(0.6) = 0.68 > mu_max
    # Two antipodal soft fingers close with any friction at all (torsion resists the
    # twist): the bisection goes down to its tolerance.
    assert 0.0 < min_friction_for_closure(antipodal("soft_finger"), ORIGIN, R, tol=1e-3) <= 1e-3
