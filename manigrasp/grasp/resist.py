"""Can a grasp resist a given external wrench? A linear program.

Sign convention: `wrench` is the external wrench acting ON the object
(force [N], torque [N m] about `center`), e.g. gravity (0, 0, -m g, 0, 0, 0)
about the centre of mass. The grasp resists it when contact forces exist,
inside their linearised cones with normal components <= max_normal_force,
whose total wrench balances it: G f + wrench = 0. Among those, the LP picks
the one with the smallest total normal force.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

from manigrasp.contact import (
    DEFAULT_EDGES,
    Contact,
    ContactSet,
    local_axes,
    primitive_forces,
    primitive_wrenches,
)
from manigrasp.grasp.errors import GraspError
from manigrasp.grasp.matrix import _single


@dataclass(frozen=True, eq=False)
class ContactForces:
    """Forces the fingers apply to the object, one row per contact.

    Attributes:
        force: (n, 3) world-frame force [N].
        torsion: (n,) moment about the contact normal [N m] (0 unless soft finger).
        local: (k n,) the same in grasp-matrix coordinates (`grasp_matrix` columns).
    """

    force: np.ndarray
    torsion: np.ndarray
    local: np.ndarray


class Resistance(NamedTuple):
    """Result of `resists_wrench`; unpacks as ``(resisted, forces)``."""

    resisted: bool
    forces: ContactForces | None


def _local(contacts: ContactSet, force: np.ndarray, torsion: np.ndarray) -> np.ndarray:
    """(k n,) grasp-matrix coordinates of world forces (n, 3) and torsions (n,)."""
    coords = np.einsum("nij,nj->ni", local_axes(contacts)[0], force)
    k = {"frictionless": 1, "hard_finger": 3, "soft_finger": 4}[contacts.kind.value]
    return np.concatenate([coords, torsion[:, None]], axis=1)[:, :k].reshape(-1)


def _normal_force_rows(n: int, p: int) -> sparse.csr_matrix:
    """(n, n p) rows summing each contact's primitive weights (= its normal force)."""
    return sparse.kron(sparse.eye(n), np.ones((1, p))).tocsr()


def resists_wrench(
    contacts: Sequence[Contact] | ContactSet,
    center: np.ndarray,
    torque_scale: float,
    wrench: np.ndarray,
    max_normal_force: np.ndarray | float,
    m: int = DEFAULT_EDGES,
) -> Resistance:
    """Whether one grasp can balance `wrench` (module docstring for the convention).

    Args:
        contacts: the n contacts of one grasp.
        center: (3,) point the torque of `wrench` is taken about [m].
        torque_scale: characteristic length [m] (scales the LP rows only; the
            answer does not depend on it).
        wrench: (6,) external wrench on the object (force [N], torque [N m]).
        max_normal_force: largest normal force per contact [N], scalar or (n,).
        m: edges of the linearised cone.

    Returns:
        (resisted, forces); forces is None when the wrench cannot be resisted.
    """
    cs = _single(contacts)
    wrench = np.asarray(wrench, dtype=float)
    if wrench.shape != (6,):
        raise GraspError(f"wrench must have shape (6,), got {wrench.shape}")
    n = cs.n_contacts
    limits = np.broadcast_to(np.asarray(max_normal_force, dtype=float), (n,))
    w = primitive_wrenches(cs, center, torque_scale, m)[0]  # (n, P, 6)
    target = -np.concatenate([wrench[:3], wrench[3:] / torque_scale])
    result = linprog(np.ones(w.shape[0] * w.shape[1]), A_ub=_normal_force_rows(*w.shape[:2]),
                     b_ub=limits, A_eq=w.reshape(-1, 6).T, b_eq=target, bounds=(0, None),
                     method="highs")
    if result.status == 2:
        return Resistance(False, None)
    if result.status != 0:
        raise GraspError(f"wrench-resistance LP failed: {result.message}")
    alpha = result.x.reshape(w.shape[:2])
    forces, torsion = primitive_forces(cs, m)
    force = np.einsum("np,npj->nj", alpha, forces[0])
    twist = np.einsum("np,np->n", alpha, torsion[0])
    return Resistance(True, ContactForces(force, twist, _local(cs, force, twist)))
