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

The LP takes its points from W u {0}: that hull equals W when the origin
is in W, and has the origin as a vertex (so s = 0) when it is not, so the
margin is unchanged while the LP is always feasible (lambda on the origin,
s = 0), which lets many grasps share one LP and spares HiGHS the
infeasible degenerate problems on which its simplex can stop undecided.
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
LP_METHODS = ("highs", "highs-ipm")
"""HiGHS solvers tried in turn, should the default one stop without an answer on degenerate input."""
LP_BATCH = 20
"""Grasps per block-diagonal LP in `closure_margin_batch`."""
EPSILON_TOLERANCE = 1e-9
"""Epsilon [scaled N] below which the facet test says a grasp is not in closure."""


def _cross_polytope_lp(w: np.ndarray) -> tuple[np.ndarray, sparse.csr_matrix, np.ndarray, np.ndarray]:
    """LP data (c, A_eq, b_eq, bounds) of `closure_margin_batch` for primitives w (B, P, 6).

    The origin is added to each grasp's primitives (module docstring). Variables of grasp g: lambda
    (12 blocks of P + 1, one per direction +-e_j) then s_g; block k of grasp g has the rows
    sum_i lambda_i w_i - s_g d_k = 0 and sum_i lambda_i = 1. Maximising sum_g s_g maximises each
    s_g, since the grasps share no variable.
    """
    w = np.concatenate([w, np.zeros((w.shape[0], 1, 6))], axis=1)
    b, p = w.shape[:2]
    stride = 12 * p + 1
    directions = np.concatenate([np.eye(6), -np.eye(6)])
    block = np.concatenate([np.swapaxes(w, 1, 2), np.ones((b, 1, p))], axis=1)  # (B, 7, P)
    g, k, i, j = np.meshgrid(np.arange(b), np.arange(12), np.arange(7), np.arange(p), indexing="ij")
    gs, ks, is_ = np.meshgrid(np.arange(b), np.arange(12), np.arange(6), indexing="ij")
    rows = np.concatenate([(84 * g + 7 * k + i).ravel(), (84 * gs + 7 * ks + is_).ravel()])
    cols = np.concatenate([(stride * g + p * k + j).ravel(), (stride * gs + 12 * p).ravel()])
    data = np.concatenate([np.broadcast_to(block[:, None], (b, 12, 7, p)).ravel(),
                           np.broadcast_to(-directions, (b, 12, 6)).ravel()])
    a_eq = sparse.csr_matrix((data, (rows, cols)), shape=(84 * b, stride * b))
    b_eq = np.tile(np.append(np.zeros(6), 1.0), 12 * b)
    c = np.zeros(stride * b)
    c[stride - 1 :: stride] = -1.0
    return c, a_eq, b_eq, np.array([0.0, np.inf])


def _solve_margins(w: np.ndarray) -> np.ndarray:
    """(B,) LP margins of primitives w (B, P, 6), one HiGHS call."""
    c, a_eq, b_eq, bounds = _cross_polytope_lp(w)
    for method in LP_METHODS:
        result = linprog(c, A_eq=a_eq, b_eq=b_eq, bounds=bounds, method=method)
        if result.status == 0:
            # HiGHS may return -0.0 or -1e-17 for "no margin": clip, and + 0.0 turns -0.0 into +0.0.
            return np.maximum(result.x[c < 0], 0.0) + 0.0
    raise GraspError(f"force-closure LP failed: {result.message}")


def closure_margin_batch(
    contacts: ContactSet,
    center: np.ndarray,
    torque_scale: np.ndarray | float,
    m: int = DEFAULT_EDGES,
) -> np.ndarray:
    """(B,) LP margins s >= 0 of many grasps (module docstring) [scaled N]; +0.0 when not in closure.

    Grasps are solved `LP_BATCH` at a time as one block-diagonal LP.
    """
    w = primitive_wrenches(contacts, center, torque_scale, m)
    w = w.reshape(w.shape[0], -1, 6)
    return np.concatenate([_solve_margins(w[i : i + LP_BATCH]) for i in range(0, len(w), LP_BATCH)])


def closure_margin(
    contacts: Sequence[Contact] | ContactSet,
    center: np.ndarray,
    torque_scale: float,
    m: int = DEFAULT_EDGES,
) -> float:
    """LP margin s >= 0 of one grasp (module docstring) [scaled N]; +0.0 when not in closure."""
    return float(closure_margin_batch(_single(contacts), center, torque_scale, m)[0])


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
    """(B,) force closure of many grasps: L1 epsilon > tol (facets enumerated, or Qhull).

    A grasp whose epsilon could not be computed (NaN: Qhull failed even on
    joggled input) is decided by the LP of `force_closure` instead.
    """
    eps = ferrari_canny_batch(contacts, center, torque_scale, "L1", m)
    closed = eps > tol
    centers = np.broadcast_to(np.asarray(center, float), (contacts.batch_size, 3))
    scales = np.broadcast_to(np.asarray(torque_scale, float), (contacts.batch_size,))
    for b in np.flatnonzero(np.isnan(eps)):
        closed[b] = closure_margin(_grasp(contacts, b), centers[b], float(scales[b]), m) > MARGIN_TOLERANCE
    return closed


def _grasp(contacts: ContactSet, b: int) -> ContactSet:
    """Grasp b of `contacts` as a one-grasp set."""
    keep = slice(b, b + 1)
    tangents = None if contacts.tangents is None else contacts.tangents[keep]
    return ContactSet(contacts.positions[keep], contacts.normals[keep], contacts.mu[keep], contacts.kind,
                      contacts.gamma[keep], tangents)


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
    ignored). The bracket is [0, mu_max]; closure is monotone in mu for any
    m (an edge n + mu' t of a smaller cone is (mu'/mu) (n + mu t) + (1 - mu'/mu) n,
    and n is the mean of the larger cone's m edges), so bisection is valid. Returns mu in (mu*, mu* + tol]: the
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
