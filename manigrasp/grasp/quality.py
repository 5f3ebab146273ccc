"""Ferrari-Canny epsilon (L1 and Linf) and the grasp wrench space volume.

The grasp wrench space (GWS) is built from the primitive wrenches of
`manigrasp.contact.primitive_wrenches` (unit normal force each):

- L1: conv(union of all primitives): total normal force <= 1.
- Linf: Minkowski sum over contacts of conv({0} u primitives_i): each
  normal force <= 1.

Epsilon is the radius of the largest origin-centred ball inside the GWS, in
scaled wrench units [N per N of normal force]; 0 when the origin is not
strictly inside (no force closure), NaN when it could not be computed (a
Qhull failure that joggling did not cure): "not computed" is never reported
as "no closure". Both are exact for the linearised cone.
L1 GWS is contained in Linf GWS, so eps_L1 <= eps_Linf.

Epsilon is computed by one of three methods, chosen by ``method``:

- ``"enumerate"`` (`facets`): vectorised facet-normal enumeration; the fast
  path for many grasps with few contacts.
- ``"qhull"``: one Qhull hull per grasp (L1: the primitives; Linf: all
  (P+1)^n sums of one element of {0} u primitives_i per contact), then the
  smallest facet offset. About 2 ms per 3-contact L1 grasp. Robust to flat
  pads (many coplanar contacts), duplicated contacts and flat wrench sets
  (see `hull_epsilon`).
- ``"auto"``: enumerate when it needs at most `MAX_CANDIDATES` candidates per
  grasp, else qhull.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from manigrasp.contact import DEFAULT_EDGES, Contact, ContactSet, as_contact_set, primitive_wrenches
from manigrasp.grasp.errors import GraspError
from manigrasp.grasp.facets import ROUNDING, candidate_count, epsilon_enumerated

NORMS = ("L1", "Linf")
METHODS = ("auto", "enumerate", "qhull")
MAX_CANDIDATES = 10_000
"""Above this many candidate normals per grasp, "auto" uses Qhull."""
MAX_MINKOWSKI_POINTS = 200_000
"""Largest Linf Minkowski point set handed to Qhull."""
QHULL_OPTIONS = ("Qx", "QJ")
"""Qhull options tried in turn by `hull_epsilon`: scipy's default for 6-D (exact merging), then joggled
input. Never "Qbb": it rescales the last coordinate, so the facet equations (and, in scipy, the caller's
array) would no longer be those of the input points."""
FLAT_WIDTH = 1e-10
"""A point set thinner than this x its extent, across its thinnest direction, is flat (epsilon 0)."""


def _check_choice(value: str, choices: tuple[str, ...], what: str) -> None:
    """Raise a GraspError listing `choices` unless `value` is one of them."""
    if value not in choices:
        raise GraspError(f"unknown {what} {value!r}; valid: {', '.join(choices)}")


def _is_flat(points: np.ndarray) -> bool:
    """Whether points (N, d) lie within FLAT_WIDTH x their extent of a hyperplane (no d-D interior)."""
    centred = points - points.mean(axis=0)
    _, s, vt = np.linalg.svd(centred, full_matrices=False)
    if len(s) < points.shape[1] or s[0] == 0.0:
        return True
    width = np.ptp(centred @ vt[-1])
    return bool(width <= FLAT_WIDTH * np.max(np.linalg.norm(centred, axis=1)))


def hull_epsilon(points: np.ndarray) -> float:
    """Distance from the origin to the nearest facet of conv(points (N, 6)); 0 if not inside, NaN if not computed.

    Duplicated points are merged first. A flat set (fewer than 7 distinct
    points, or all within `FLAT_WIDTH` of a hyperplane) spans no 6-D volume:
    the origin cannot be strictly inside, so epsilon is 0. Otherwise Qhull
    builds the hull with each of `QHULL_OPTIONS` in turn: many coplanar
    contacts (flat pads) put dozens of primitives on one facet, which can
    stop the default merging with a precision error ("wide merge" of a
    duplicate ridge); joggling the input ("QJ", perturbations ~1e-11 of the
    extent) then gives simplicial facets whose offsets are exact to that
    size. If every option fails, or the input is not finite, the result is
    NaN ("not computed"), never 0 ("no closure").
    """
    hull = _hull(points)
    if isinstance(hull, float):
        return hull
    eps = float(np.min(-hull.equations[:, -1]))
    return eps if eps > ROUNDING * np.max(np.linalg.norm(points, axis=1)) else 0.0


def _hull(points: np.ndarray) -> ConvexHull | float:
    """conv(points (N, d)) by Qhull, tried with each of `QHULL_OPTIONS` in turn after merging duplicated points;
    0.0 for a flat set (at most d distinct points, or all within `FLAT_WIDTH` of a hyperplane: no d-D interior),
    NaN if the input is not finite or every option fails (`hull_epsilon`)."""
    points = np.asarray(points, dtype=float)
    if not np.isfinite(points).all():
        return math.nan
    points = np.unique(points, axis=0)
    if len(points) <= points.shape[1] or _is_flat(points):
        return 0.0
    for options in QHULL_OPTIONS:
        try:
            return ConvexHull(points, qhull_options=options)
        except QhullError:
            continue
    return math.nan


def minkowski_points(w: np.ndarray) -> np.ndarray:
    """All sums of one element of {0} u w[i] per contact: w (n, P, 6) -> ((P+1)^n, 6)."""
    count = (w.shape[1] + 1) ** w.shape[0]
    if count > MAX_MINKOWSKI_POINTS:
        raise GraspError(f"Linf by qhull needs {count} points (> {MAX_MINKOWSKI_POINTS}); "
                         "use fewer contacts or edges, or method='enumerate'")
    points = np.zeros((1, w.shape[-1]))
    for options in w:
        options = np.concatenate([np.zeros((1, w.shape[-1])), options])
        points = (points[:, None, :] + options[None, :, :]).reshape(-1, w.shape[-1])
    return points


def _epsilon_qhull(w: np.ndarray, norm: str) -> np.ndarray:
    """Epsilon per grasp with one Qhull call each: w (B, n, P, 6) -> (B,)."""
    if norm == "L1":
        return np.array([hull_epsilon(g.reshape(-1, 6)) for g in w])
    return np.array([hull_epsilon(minkowski_points(g)) for g in w])


def ferrari_canny_batch(
    contacts: ContactSet,
    center: np.ndarray,
    torque_scale: np.ndarray | float,
    norm: str = "L1",
    m: int = DEFAULT_EDGES,
    method: str = "auto",
) -> np.ndarray:
    """Ferrari-Canny epsilon of B grasps at once.

    Args:
        contacts: B grasps of n contacts of one type.
        center: (3,) or (B, 3) point torques are taken about (the centre of mass) [m].
        torque_scale: characteristic length [m] dividing torques, scalar or (B,).
        norm: "L1" (sum of normal forces <= 1) or "Linf" (each <= 1).
        m: edges of the linearised friction cone.
        method: "auto", "enumerate" or "qhull" (see module docstring).

    Returns:
        (B,) epsilon [N per N of normal force], 0 where not in force closure,
        NaN where it could not be computed (see `hull_epsilon`), never 0 for that.
    """
    _check_choice(norm, NORMS, "norm")
    _check_choice(method, METHODS, "method")
    w = primitive_wrenches(contacts, center, torque_scale, m)
    if method == "auto":
        many = candidate_count(contacts.kind, m, contacts.n_contacts, norm) > MAX_CANDIDATES
        method = "qhull" if many else "enumerate"
    if method == "qhull":
        return _epsilon_qhull(w, norm)
    return epsilon_enumerated(w, contacts.kind, m, norm)


def ferrari_canny(
    contacts: Sequence[Contact] | ContactSet,
    center: np.ndarray,
    torque_scale: float,
    norm: str = "L1",
    m: int = DEFAULT_EDGES,
    method: str = "auto",
) -> float:
    """Ferrari-Canny epsilon of one grasp (see `ferrari_canny_batch`)."""
    cs = as_contact_set(contacts)
    if cs.batch_size != 1:
        raise GraspError("ferrari_canny takes one grasp; use ferrari_canny_batch for many")
    return float(ferrari_canny_batch(cs, center, torque_scale, norm, m, method)[0])


def gws_volume(
    contacts: Sequence[Contact] | ContactSet,
    center: np.ndarray,
    torque_scale: float,
    m: int = DEFAULT_EDGES,
) -> float:
    """6-D volume of the L1 grasp wrench space (Qhull); 0 for a flat wrench set, NaN if the hull could not be built.

    Units: [N^6 per N^6 of normal force] in scaled wrench coordinates. Qhull is tried with each of
    `QHULL_OPTIONS`, as for epsilon: flat pads (many coplanar contacts) stop its default merging with a
    precision error although the set spans 6-D, where the joggled input ("QJ") builds the hull.
    """
    hull = _hull(primitive_wrenches(as_contact_set(contacts), center, torque_scale, m).reshape(-1, 6))
    return hull if isinstance(hull, float) else float(hull.volume)
