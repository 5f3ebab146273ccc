"""Force closure (exact, by linear programming or facet enumeration) and the
smallest friction coefficient at which it holds.

A grasp is in force closure when the origin is strictly inside the convex
hull W of its primitive wrenches (linearised cones). This is not a rank test:
full rank of G is necessary, not sufficient.

`closure_margin` solves one LP: the largest s >= 0 such that s e_j and
-s e_j are in W for all six axes j. Their hull is a cross-polytope that holds
a ball of radius s / sqrt(6), and a ball of radius r in W holds those twelve
points with s = r, so s > 0 exactly when the origin is interior, and
s / sqrt(6) <= eps_L1 <= s. Degenerate (flat) wrench sets give s = 0.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

from manigrasp.contact import DEFAULT_EDGES, Contact, ContactSet, ContactType, primitive_wrenches
from manigrasp.grasp.errors import GraspError
from manigrasp.grasp.matrix import _single
from manigrasp.grasp.quality import ferrari_canny_batch

MARGIN_TOLERANCE = 1e-6
"""LP margin [scaled N] below which a grasp is not in closure (HiGHS feasibility is ~1e-7)."""
EPSILON_TOLERANCE = 1e-9
"""Epsilon [scaled N] below which the facet test says a grasp is not in closure."""


def _cross_polytope_lp(w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """LP data (c, A_eq, b_eq, bounds) of `closure_margin` for primitives w (P, 6)."""
    p = len(w)
    directions = np.concatenate([np.eye(6), -np.eye(6)])
    block = sparse.vstack([sparse.csr_matrix(w.T), sparse.csr_matrix(np.ones((1, p)))])
    a_lambda = sparse.block_diag([block] * len(directions))
    s_column = np.concatenate([np.append(-d, 0.0) for d in directions])[:, None]
    a_eq = sparse.hstack([a_lambda, sparse.csr_matrix(s_column)]).tocsr()
    b_eq = np.tile(np.append(np.zeros(6), 1.0), len(directions))
    c = np.zeros(a_eq.shape[1])
    c[-1] = -1.0
    return c, a_eq, b_eq, np.array([0.0, np.inf])


def closure_margin(
    contacts: Sequence[Contact] | ContactSet,
    center: np.ndarray,
    torque_scale: float,
    m: int = DEFAULT_EDGES,
) -> float:
    """LP margin s >= 0 of one grasp (module docstring) [scaled N]; 0 when not in closure."""
    w = primitive_wrenches(_single(contacts), center, torque_scale, m).reshape(-1, 6)
    c, a_eq, b_eq, bounds = _cross_polytope_lp(w)
    result = linprog(c, A_eq=a_eq, b_eq=b_eq, bounds=bounds, method="highs")
    if result.status == 2:  # infeasible: the origin is not even in the hull
        return 0.0
    if result.status != 0:
        raise GraspError(f"force-closure LP failed: {result.message}")
    return float(result.x[-1])


def force_closure(
    contacts: Sequence[Contact] | ContactSet,
    center: np.ndarray,
    torque_scale: float,
    m: int = DEFAULT_EDGES,
    tol: float = MARGIN_TOLERANCE,
) -> bool:
    """True when the origin is strictly inside the primitive wrench hull (LP margin > tol)."""
    return closure_margin(contacts, center, torque_scale, m) > tol


def force_closure_batch(
    contacts: ContactSet,
    center: np.ndarray,
    torque_scale: np.ndarray | float,
    m: int = DEFAULT_EDGES,
    tol: float = EPSILON_TOLERANCE,
) -> np.ndarray:
    """(B,) force closure of many grasps by exact facet enumeration (L1 epsilon > tol)."""
    return ferrari_canny_batch(contacts, center, torque_scale, "L1", m) > tol


def _with_mu(contacts: ContactSet, mu: np.ndarray) -> ContactSet:
    """A copy of `contacts` with every contact of grasp b given friction mu[b]."""
    return ContactSet(contacts.positions, contacts.normals, np.asarray(mu)[:, None],
                      contacts.kind, contacts.gamma, contacts.tangents)


def min_friction_for_closure_batch(
    contacts: ContactSet,
    center: np.ndarray,
    torque_scale: np.ndarray | float,
    mu_max: float = 2.0,
    tol: float = 1e-4,
    m: int = DEFAULT_EDGES,
) -> np.ndarray:
    """(B,) smallest friction coefficient giving force closure, by bisection.

    All contacts of a grasp share the trial mu (the contacts' own mu is
    ignored). The bracket is [0, mu_max]; closure is monotone in mu for an
    even m (a smaller cone is a convex combination of opposite edges of a
    larger one), so bisection is valid. Returns mu in (mu*, mu* + tol]: the
    closure test is strict, so the exact threshold mu* itself is not in
    closure. 0 when in closure without friction; inf when not in closure
    even at mu_max.
    """
    if contacts.kind is ContactType.FRICTIONLESS:
        raise GraspError("frictionless contacts have no friction coefficient to vary")
    b = contacts.batch_size
    closes = lambda mu: force_closure_batch(_with_mu(contacts, mu), center, torque_scale, m)  # noqa: E731
    lo, hi = np.zeros(b), np.full(b, float(mu_max))
    at_zero, at_top = closes(lo), closes(hi)
    while np.any((hi - lo > tol) & at_top & ~at_zero):
        mid = 0.5 * (lo + hi)
        ok = closes(mid)
        hi, lo = np.where(ok, mid, hi), np.where(ok, lo, mid)
    return np.where(at_zero, 0.0, np.where(at_top, hi, np.inf))


def min_friction_for_closure(
    contacts: Sequence[Contact] | ContactSet,
    center: np.ndarray,
    torque_scale: float,
    mu_max: float = 2.0,
    tol: float = 1e-4,
    m: int = DEFAULT_EDGES,
) -> float:
    """Smallest mu giving force closure of one grasp (see `min_friction_for_closure_batch`)."""
    cs = _single(contacts)
    return float(min_friction_for_closure_batch(cs, center, torque_scale, mu_max, tol, m)[0])
