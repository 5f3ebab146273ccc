"""Contact records, friction cones, the Coulomb law and contact wrenches."""

from __future__ import annotations

import numpy as np
import pytest

from manigrasp.contact import (
    Contact,
    ContactError,
    ContactSet,
    ContactType,
    cone_edges,
    coulomb_friction,
    in_friction_cone,
    local_axes,
    primitive_forces,
    primitive_wrenches,
    tangent_basis,
    wrench_basis,
)
from manigrasp.errors import ManigraspError


def random_units(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    v = rng.normal(size=shape + (3,))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_contact_validates_its_fields() -> None:
    with pytest.raises(ContactError, match="unit"):
        Contact([0, 0, 0], [0, 0, 2.0])
    with pytest.raises(ContactError, match="shape"):
        Contact([0, 0], [0, 0, 1.0])
    with pytest.raises(ContactError, match="mu"):
        Contact([0, 0, 0], [0, 0, 1.0], mu=-0.1)
    with pytest.raises(ContactError, match="gamma > 0"):
        Contact([0, 0, 0], [0, 0, 1.0], kind="soft_finger")
    with pytest.raises(ContactError, match="only used by soft_finger"):
        Contact([0, 0, 0], [0, 0, 1.0], gamma=0.01)
    with pytest.raises(ContactError, match="hard_finger"):  # unknown type lists valid ones
        Contact([0, 0, 0], [0, 0, 1.0], kind="sticky")
    with pytest.raises(ContactError, match="orthogonal"):
        Contact([0, 0, 0], [0, 0, 1.0], tangent=[0, 0.6, 0.8])
    assert issubclass(ContactError, ManigraspError)
    c = Contact([0, 0, 0], [0, 0, 1.0], kind="soft_finger", gamma=0.01)
    assert c.kind is ContactType.SOFT_FINGER and not c.position.flags.writeable


def test_contact_set_stacks_and_refuses_mixed_types() -> None:
    a = Contact([0.1, 0, 0], [-1.0, 0, 0], mu=0.3)
    b = Contact([-0.1, 0, 0], [1.0, 0, 0], mu=0.7)
    cs = ContactSet.stack([[a, b], [b, a]])
    assert cs.positions.shape == (2, 2, 3)
    np.testing.assert_allclose(cs.mu, [[0.3, 0.7], [0.7, 0.3]])
    with pytest.raises(ContactError, match="one type"):
        ContactSet.from_contacts([a, Contact([0, 0, 0], [0, 0, 1.0], kind="frictionless")])
    with pytest.raises(ContactError, match="broadcast"):
        ContactSet(np.zeros((2, 3, 3)), np.tile([0, 0, 1.0], (2, 3, 1)), mu=np.ones(2))


def test_tangent_basis_is_right_handed_orthonormal() -> None:
    n = random_units(np.random.default_rng(0), (500,))
    n[:3] = [[0, 0, 1.0], [0, 0, -1.0], [1.0, 0, 0]]
    t1, t2 = tangent_basis(n)
    frames = np.stack([n, t1, t2], axis=-1)
    np.testing.assert_allclose(frames.transpose(0, 2, 1) @ frames, np.broadcast_to(np.eye(3), (500, 3, 3)),
                               atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(frames), 1.0)


def test_cone_edges_lie_on_the_exact_cone_with_unit_normal_force() -> None:
    n = random_units(np.random.default_rng(1), (20,))
    edges = cone_edges(n, 0.4, m=8)
    normal_part = np.einsum("bkj,bj->bk", edges, n)
    tangential = np.linalg.norm(edges - normal_part[..., None] * n[:, None], axis=-1)
    np.testing.assert_allclose(normal_part, 1.0)
    np.testing.assert_allclose(tangential, 0.4)
    assert np.all(in_friction_cone(edges, n[:, None], 0.4))
    assert not np.any(in_friction_cone(edges, n[:, None], 0.39))


def test_exact_cone_membership_including_zero_and_negative_normal_force() -> None:
    n = np.array([0, 0, 1.0])
    forces = np.array([[0.3, 0.4, 1.0], [0.31, 0.4, 1.0], [0, 0, 0], [0.1, 0, 0], [0, 0, -1.0]])
    assert list(in_friction_cone(forces, n, 0.5)) == [True, False, True, False, False]
    assert list(in_friction_cone(forces, n, 0.0, kind="frictionless")) == [False, False, True, False, False]
    # Soft finger, elliptic: (|f_t| / mu)^2 + (tau / gamma)^2 <= f_n^2.
    soft = in_friction_cone(np.array([[0.3, 0, 1.0]] * 3), n, 0.5, "soft_finger",
                            torsion=np.array([0.0079, 0.0081, 0.0]), gamma=0.01)
    assert list(soft) == [True, False, True]  # 0.6^2 + 0.8^2 = 1 at tau = 0.008
    assert not in_friction_cone(np.zeros(3), n, 0.5, "soft_finger", torsion=1e-3, gamma=0.01)


def test_coulomb_friction_is_continuous_bounded_and_kinetic_when_sliding() -> None:
    speeds = np.concatenate([[0.0], np.logspace(-14, 1, 300)])
    v = speeds[:, None] * np.array([[0.6, 0.8, 0.0]])
    f = coulomb_friction(v, 10.0, mu_s=0.8, mu_k=0.5)
    magnitude = np.linalg.norm(f, axis=1)
    assert magnitude[0] == 0.0 and np.all(np.isfinite(f))
    assert np.all(np.diff(magnitude[:50]) >= 0)  # grows from 0 without a jump
    assert magnitude.max() <= 0.8 * 10.0 + 1e-12
    np.testing.assert_allclose(magnitude[-1], 0.5 * 10.0, rtol=1e-9)  # kinetic at 10 m/s
    np.testing.assert_allclose(f[-1] / magnitude[-1], -v[-1] / speeds[-1])  # opposes slip
    assert magnitude[1] < 1e-9  # 1e-14 m/s: a vanishing force, not a division blow-up
    assert np.all(coulomb_friction(v, -1.0, 0.8, 0.5) == 0.0)  # separating contact


def test_primitive_wrenches_are_the_wrench_basis_applied_to_local_forces() -> None:
    rng = np.random.default_rng(2)
    cs = ContactSet(rng.normal(size=(4, 3, 3)), random_units(rng, (4, 3)), 0.5,
                    kind="soft_finger", gamma=0.02)
    center, scale = rng.normal(size=3), 0.07
    basis = wrench_basis(cs, center, scale)  # (B, n, 6, 4)
    forces, torsion = primitive_forces(cs)
    local = np.concatenate([np.einsum("bnij,bnpj->bnpi", local_axes(cs), forces), torsion[..., None]], -1)
    expected = np.einsum("bnij,bnpj->bnpi", basis, local)
    np.testing.assert_allclose(primitive_wrenches(cs, center, scale), expected, atol=1e-12)
    # Torque of a force f at p about c is (p - c) x f, divided by the scale.
    w = primitive_wrenches(cs, center, scale)[1, 2, 3]
    np.testing.assert_allclose(w[3:], np.cross(cs.positions[1, 2] - center, w[:3]) / scale)
