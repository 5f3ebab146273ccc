"""Ferrari-Canny epsilon, GWS volume and the grasp matrix metrics, against known values."""

from __future__ import annotations

import numpy as np
import pytest

from manigrasp.contact import Contact, ContactSet, primitive_wrenches
from manigrasp.grasp import (
    GraspError,
    ferrari_canny,
    ferrari_canny_batch,
    grasp_matrices,
    grasp_matrix,
    gws_volume,
    isotropies,
    isotropy,
    min_singular_value,
    min_singular_values,
)

ORIGIN = np.zeros(3)
E = np.eye(3)


def cube_twelve(half: float = 2.0, scale: float = 1.0) -> list[Contact]:
    """Twelve frictionless contacts whose wrenches are +-v_j for six orthogonal v_j.

    v1 = (e1, e2), v2 = (e2, e3), v3 = (e3, e1), v4 = (e1, -e2), v5 = (e2, -e3),
    v6 = (e3, -e1) (force, torque / scale). A frictionless contact with normal n
    at -half n + scale (n x tau) has wrench (n, tau) for tau orthogonal to n,
    so +v_j and -v_j are a contact on each of two opposite faces, offset by
    `scale` from the face centre: two contacts per face of a cube of half-size
    `half`.
    """
    pairs = [(E[0], E[1]), (E[1], E[2]), (E[2], E[0]), (E[0], -E[1]), (E[1], -E[2]), (E[2], -E[0])]
    out = []
    for sign in (1.0, -1.0):
        for n, tau in pairs:
            n, tau = sign * n, sign * tau
            out.append(Contact(-half * n + scale * np.cross(n, tau), n, 0.0, "frictionless"))
    return out


def sphere_grasps(rng: np.random.Generator, b: int, n: int, mu: float | np.ndarray = 0.5,
                  kind: str = "hard_finger") -> ContactSet:
    p = rng.normal(size=(b, n, 3))
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    gamma = 0.01 if kind == "soft_finger" else None
    return ContactSet(0.05 * p, -p, mu, kind, gamma)


def test_epsilon_of_the_twelve_contact_cube_derived_by_hand() -> None:
    """The six v_j are mutually orthogonal with |v_j| = sqrt(2) (check: v1.v4 =
    e1.e1 - e2.e2 = 0, v1.v2 = e1.e2 + e2.e3 = 0, ...).

    L1: the GWS is conv{+-v_j}, a regular cross-polytope of circumradius
    a = sqrt(2) in 6-D; its facets {sum_j s_j x_j / a = 1} in the v-frame lie at
    distance a / sqrt(6), so eps_L1 = sqrt(2) / sqrt(6) = 1 / sqrt(3).

    Linf: the GWS is sum_j ([0, v_j] + [0, -v_j]) = sum_j [-v_j, v_j], a cube with
    orthogonal half-edges v_j, whose inradius is |v_j| = sqrt(2).
    """
    for method in ("enumerate", "qhull"):
        assert ferrari_canny(cube_twelve(), ORIGIN, 1.0, "L1", method=method) == pytest.approx(
            1 / np.sqrt(3), abs=1e-6)
        assert ferrari_canny(cube_twelve(), ORIGIN, 1.0, "Linf", method=method) == pytest.approx(
            np.sqrt(2), abs=1e-6)


def test_volume_and_singular_values_of_the_twelve_contact_cube() -> None:
    """Cross-polytope volume (2 a)^6 / 6! with a = sqrt(2): 512 / 720. G = [+-v_j] has
    G G^T = 2 sum_j v_j v_j^T = 4 I, so every singular value is 2 and isotropy is 1."""
    assert gws_volume(cube_twelve(), ORIGIN, 1.0) == pytest.approx(512 / 720, rel=1e-9)
    assert min_singular_value(cube_twelve(), ORIGIN, 1.0) == pytest.approx(2.0, rel=1e-12)
    assert isotropy(cube_twelve(), ORIGIN, 1.0) == pytest.approx(1.0, rel=1e-12)


@pytest.mark.slow
def test_enumerated_epsilon_matches_qhull_facets_on_random_grasps() -> None:
    """Independent cross-check: the enumeration (candidate normals + support
    function) against Qhull's facet offsets of the same primitive wrenches."""
    rng = np.random.default_rng(5)
    cases = [(sphere_grasps(rng, 30, 3), "L1"), (sphere_grasps(rng, 6, 3), "Linf"),
             (sphere_grasps(rng, 10, 2, kind="soft_finger"), "L1"),
             (sphere_grasps(rng, 4, 4), "L1")]
    for cs, norm in cases:
        fast = ferrari_canny_batch(cs, ORIGIN, 0.05, norm, method="enumerate")
        slow = ferrari_canny_batch(cs, ORIGIN, 0.05, norm, method="qhull")
        np.testing.assert_allclose(fast, slow, atol=1e-10)
    assert (fast > 0).any()


def test_epsilon_is_invariant_under_a_rigid_transform() -> None:
    rng = np.random.default_rng(6)
    cs = sphere_grasps(rng, 8, 3)
    t1 = np.cross(cs.normals, rng.normal(size=3))
    cs = ContactSet(cs.positions, cs.normals, 0.6, tangents=t1 / np.linalg.norm(t1, axis=-1, keepdims=True))
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    rot = q * np.sign(np.linalg.det(q))
    shift = np.array([0.3, -1.2, 0.7])
    center = np.array([0.01, 0.0, -0.02])
    moved = ContactSet(cs.positions @ rot.T + shift, cs.normals @ rot.T, 0.6, tangents=cs.tangents @ rot.T)
    for norm in ("L1", "Linf"):
        before = ferrari_canny_batch(cs, center, 0.05, norm)
        after = ferrari_canny_batch(moved, rot @ center + shift, 0.05, norm)
        np.testing.assert_allclose(after, before, atol=1e-12)
        assert (before > 0).sum() >= 3
    frictionless = cube_twelve()
    turned = [Contact(rot @ c.position + shift, rot @ c.normal, 0.0, "frictionless") for c in frictionless]
    assert ferrari_canny(turned, shift, 1.0) == pytest.approx(1 / np.sqrt(3), abs=1e-9)


def test_epsilon_grows_with_mu_and_l1_never_exceeds_linf() -> None:
    rng = np.random.default_rng(7)
    base = sphere_grasps(rng, 12, 3)
    eps = {}
    for mu in (0.2, 0.4, 0.6, 0.9):
        cs = ContactSet(base.positions, base.normals, mu)
        eps[mu] = ferrari_canny_batch(cs, ORIGIN, 0.05)
        linf = ferrari_canny_batch(cs, ORIGIN, 0.05, "Linf")
        assert np.all(eps[mu] <= linf + 1e-12)
        assert np.any(linf > eps[mu] + 1e-3)
    values = np.array(list(eps.values()))
    assert np.all(np.diff(values, axis=0) >= -1e-12)
    closed = values[:-1] > 0
    assert np.all(np.diff(values, axis=0)[closed] > 1e-6)  # strictly, once in closure
    assert (values[-1] > 0).sum() >= 4


def test_flat_wrench_sets_score_zero() -> None:
    two = [Contact([0.05, 0, 0], [-1.0, 0, 0], 0.8), Contact([-0.05, 0, 0], [1.0, 0, 0], 0.8)]
    assert gws_volume(two, ORIGIN, 0.05) == 0.0
    assert ferrari_canny(two, ORIGIN, 0.05, method="qhull") == 0.0
    assert ferrari_canny(two, ORIGIN, 0.05, "Linf") == 0.0
    assert min_singular_value(two, ORIGIN, 0.05) == pytest.approx(0.0, abs=1e-12)


def test_batched_forms_match_single_calls_and_bad_arguments_raise() -> None:
    rng = np.random.default_rng(8)
    cs = sphere_grasps(rng, 5, 3)
    singles = [ContactSet(cs.positions[b : b + 1], cs.normals[b : b + 1], 0.5) for b in range(5)]
    np.testing.assert_allclose(grasp_matrices(cs, ORIGIN, 0.05)[2], grasp_matrix(singles[2], ORIGIN, 0.05))
    np.testing.assert_allclose(min_singular_values(cs, ORIGIN, 0.05)[3],
                               min_singular_value(singles[3], ORIGIN, 0.05))
    np.testing.assert_allclose(isotropies(cs, ORIGIN, 0.05)[4], isotropy(singles[4], ORIGIN, 0.05))
    np.testing.assert_allclose(ferrari_canny_batch(cs, ORIGIN, 0.05)[1], ferrari_canny(singles[1], ORIGIN, 0.05))
    with pytest.raises(GraspError, match="L1, Linf"):
        ferrari_canny(singles[0], ORIGIN, 0.05, norm="L2")
    with pytest.raises(GraspError, match="one grasp"):
        ferrari_canny(cs, ORIGIN, 0.05)


def test_grasp_matrix_maps_local_forces_to_the_object_wrench() -> None:
    """A 2 N push along the normal of a contact at (0.05, 0, 0.02) with normal -x,
    about the origin with torque scale 0.1: force (-2, 0, 0), torque
    r x f = (0, -0.04, 0) N m, scaled (0, -0.4, 0)."""
    g = grasp_matrix([Contact([0.05, 0, 0.02], [-1.0, 0, 0])], ORIGIN, 0.1)
    np.testing.assert_allclose(g @ [2.0, 0, 0], [-2, 0, 0, 0, -0.4, 0], atol=1e-12)
    w = primitive_wrenches(ContactSet.from_contacts([Contact([0.05, 0, 0.02], [-1.0, 0, 0])]), ORIGIN, 0.1)
    assert w.shape == (1, 1, 8, 6)


def test_the_volume_of_two_flat_pads_is_built_not_zero():
    """The drill grasp of two flat pads (eight coplanar soft contacts, epsilon 0.084) spans 6-D, but Qhull's
    default merging fails on its coplanar wrenches: the volume read 0, as for a flat set. It is now built from
    the joggled input, as epsilon is; a set perturbed by 1e-9 at random gives the same volume."""
    from scipy.spatial import ConvexHull
    from test_grasp_degenerate import DRILL_CENTER, DRILL_SCALE, drill_contacts

    contacts = drill_contacts()
    volume = gws_volume(contacts, DRILL_CENTER, DRILL_SCALE)
    points = primitive_wrenches(ContactSet.from_contacts(contacts), DRILL_CENTER, DRILL_SCALE, 8).reshape(-1, 6)
    noisy = points + np.random.default_rng(0).normal(0.0, 1e-9, points.shape)
    assert volume > 0.0 and volume == pytest.approx(ConvexHull(noisy).volume, rel=1e-5)
