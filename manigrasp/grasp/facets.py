"""Exact Ferrari-Canny epsilon by enumerating candidate facet normals, vectorised.

Why this works. For a polytope Q and any direction u, the support
h(u) = max_{q in Q} u.q satisfies h(u) >= eps |u| when the ball of radius eps
about the origin lies in Q, with equality when u is the normal of a nearest
facet. So eps = max(0, min over u in U of h(u) / |u|) for ANY set U that
contains every facet normal; extra candidates can never lower the result, and
a set U that missed a facet could only over-estimate it. (If the origin is
outside or on the boundary, the separating facet gives a value <= 0.)

Candidate facet normals come from the face structure of each contact's
primitive polytope (a point, an m-gon, or an m-gon bipyramid for soft
fingers). A supporting hyperplane of the hull meets each contact's polytope
in one of its faces; picking for each contact a face (or nothing) with
affinely independent representative points adding up to 6 determines the
hyperplane. This is enumerated contact by contact with wedge products
(`_exterior`), then all candidates are scored with one matrix product.

- L1 (hull of the union of primitives): hyperplanes u.w = h through 6 points,
  i.e. vectors orthogonal to 6 rows (w, 1) in R^7.
- Linf (Minkowski sum of conv({0} u primitives_i)): facet normals are
  orthogonal to 5 edge directions drawn from the faces of the pyramids
  conv({0} u P_i); h(u) = sum_i max(0, max_k u.w_ik).

The best-fit hyperplane of all primitives is always added as a candidate, so a
flat (lower-dimensional) wrench set scores 0. Cost per grasp: the number of
candidates (`candidate_count`; 899 for three hard fingers with m = 8 in L1,
4710 in Linf) times the number of primitives, times 6.
"""

from __future__ import annotations

from collections import defaultdict
from functools import cache

import numpy as np
import numpy.polynomial.polynomial as poly

from manigrasp.contact import ContactType
from manigrasp.grasp._exterior import wedge_outer, wedge_rows

Faces = dict[int, np.ndarray]
"""weight -> (B, n_faces, C(d, weight)) k-vectors of one contact's candidate faces."""

ROUNDING = 1e-12
"""Epsilons below ROUNDING x the largest primitive wrench norm are rounding noise, reported as 0."""
ELEMENT_BUDGET = 1_000_000
"""Largest candidates x primitives array scored at once: grasps are chunked so the
working set stays in cache (measured: 1e6 is ~2x faster than 4e6 on 3 hard fingers)."""


@cache
def polytope_faces(kind: ContactType, m: int) -> tuple[tuple[int, ...], ...]:
    """Faces of one contact's primitive polytope (itself included), as index tuples
    of affinely independent representative primitives (see `primitive_forces` order)."""
    ring = [(k, (k + 1) % m) for k in range(m)]
    if kind is ContactType.FRICTIONLESS:
        return ((0,),)
    if kind is ContactType.HARD_FINGER:
        return tuple((k,) for k in range(m)) + tuple(ring) + ((0, 1, 2),)
    apexes = (m, m + 1)
    vertices = tuple((k,) for k in range(m + 2))
    edges = tuple(ring) + tuple((k, a) for a in apexes for k in range(m))
    triangles = tuple(e + (a,) for a in apexes for e in ring)
    return vertices + edges + triangles + ((0, 1, m, m + 1),)


def _face_sets(kind: ContactType, m: int, norm: str) -> dict[int, list[tuple[tuple[int, ...], bool]]]:
    """weight -> list of (representative indices, is_affine_direction) for one contact."""
    sets: dict[int, list[tuple[tuple[int, ...], bool]]] = defaultdict(list)
    for face in polytope_faces(kind, m):
        if norm == "L1":
            sets[len(face)].append((face, False))
            continue
        sets[len(face)].append((face, False))  # pyramid conv({0} u face): linear span
        if len(face) > 1:
            sets[len(face) - 1].append((face, True))  # the face itself: its directions
    return sets


def candidate_count(kind: ContactType, m: int, n_contacts: int, norm: str) -> int:
    """Number of candidate normals per grasp (without the best-fit one)."""
    sets = _face_sets(kind, m, norm)
    weights = np.zeros(max(sets) + 1)
    weights[0] = 1.0
    for w, faces in sets.items():
        weights[w] += len(faces)
    coeffs = poly.polypow(weights, n_contacts)
    target = 6 if norm == "L1" else 5
    return int(coeffs[target]) if len(coeffs) > target else 0


def _contact_faces(w: np.ndarray, sets: dict[int, list[tuple[tuple[int, ...], bool]]], norm: str) -> Faces:
    """k-vectors of every candidate face of one contact; w is (B, P, 6)."""
    rows = np.concatenate([w, np.ones(w.shape[:-1] + (1,))], axis=-1) if norm == "L1" else w
    out: Faces = {0: np.ones((w.shape[0], 1, 1))}
    for weight, faces in sets.items():
        vectors = []
        for face, affine in faces:
            pts = rows[:, list(face)]
            steps = pts[:, 1:] - pts[:, :1]  # explicit differences: a small face keeps its relative precision
            vectors.append(wedge_rows(steps if affine else np.concatenate([pts[:, :1], steps], axis=1)))
        out[weight] = np.stack(vectors, axis=1)
    return out


def _enumerate(per_contact: list[Faces], d: int) -> np.ndarray:
    """(B, C, d) wedges of d-1 rows picked across contacts (see module doc).

    A wedge `top` stands for the normal x_i = (-1)^i top[d-1-i] (`hodge_vector`).
    """
    target = d - 1
    top = [max(f) for f in per_contact]
    rest = np.cumsum(top[::-1])[::-1].tolist()[1:] + [0]
    partial: Faces = {0: per_contact[0][0]}
    for faces, remaining in zip(per_contact, rest, strict=True):
        grown: dict[int, list[np.ndarray]] = defaultdict(list)
        for w, a in partial.items():
            for wf, f in faces.items():
                if w + wf <= target <= w + wf + remaining:
                    grown[w + wf].append(wedge_outer(a, f, d, w, wf))
        partial = {w: np.concatenate(v, axis=1) for w, v in grown.items()}
    if target not in partial:
        return np.zeros((per_contact[0][0].shape[0], 0, d))
    return partial[target]


def _best_fit(w: np.ndarray, norm: str) -> np.ndarray:
    """(B, 1, 6) normal of the least-squares hyperplane of all primitives (B, N, 6)."""
    rows = np.concatenate([w, np.ones(w.shape[:-1] + (1,))], axis=-1) if norm == "L1" else w
    _, vectors = np.linalg.eigh(np.swapaxes(rows, 1, 2) @ rows)
    return vectors[:, None, :6, 0]


def _support_pair(u: np.ndarray, w: np.ndarray, n: int, norm: str) -> tuple[np.ndarray, np.ndarray]:
    """Support values h(u), h(-u): (B, C) each, for u (B, C, 6), w (B, n*P, 6).

    The products are laid out (B, n, P, C) so that every reduction runs over a
    leading axis with C contiguous (several times faster than reducing a short
    last axis).
    """
    s = (w @ np.swapaxes(u, 1, 2)).reshape(w.shape[0], n, -1, u.shape[1])
    hi, lo = s.max(axis=2), -s.min(axis=2)
    if norm == "L1":
        return hi.max(axis=1), lo.max(axis=1)
    return np.maximum(hi, 0.0).sum(axis=1), np.maximum(lo, 0.0).sum(axis=1)


def _min_value(u: np.ndarray, w: np.ndarray, n: int, norm: str) -> np.ndarray:
    """min over candidates of min(h(u), h(-u)) / |u| per grasp, ignoring u = 0 (B,).

    There is no floor on |u| below which a candidate is dropped: any non-zero
    u, however small or inaccurate, gives an upper bound h(u) / |u| >= eps
    (up to rounding of order 1e-16 |w|), so keeping it can never lower the
    result, while dropping a small but exact facet normal (tiny mu, a torque
    scale far from the lever arms) would over-estimate it.
    """
    if u.shape[1] == 0:  # e.g. a single contact: no 6-point hyperplane to pick
        return np.full(u.shape[0], np.inf)
    length = np.sqrt(np.einsum("bci,bci->bc", u, u))
    valid = (length > 0.0) & np.isfinite(length)
    hi, lo = _support_pair(u, w, n, norm)
    values = np.where(valid, np.minimum(hi, lo) / np.where(valid, length, 1.0), np.inf)
    return values.min(axis=1, initial=np.inf)


def _epsilon_chunk(w: np.ndarray, kind: ContactType, m: int, norm: str) -> np.ndarray:
    """Exact epsilon of each grasp of a chunk: w is (B, n, P, 6)."""
    b, n = w.shape[:2]
    d = 7 if norm == "L1" else 6
    sets = _face_sets(kind, m, norm)
    top = _enumerate([_contact_faces(w[:, i], sets, norm) for i in range(n)], d)
    flat = w.reshape(b, -1, 6)
    # Candidate u_i = (-1)^i top[d-1-i] (i < 6): fold the signs and reversal into w.
    signed = (flat * (-1.0) ** np.arange(6))[..., ::-1]
    scale = np.max(np.linalg.norm(flat, axis=-1), axis=-1) + 1.0
    value = _min_value(top[..., d - 6 :], signed, n, norm)
    best = _min_value(_best_fit(flat, norm), flat, n, norm)
    eps = np.minimum(value, best)
    return np.where(eps > ROUNDING * scale, eps, 0.0)


def epsilon_enumerated(w: np.ndarray, kind: ContactType, m: int, norm: str) -> np.ndarray:
    """Exact Ferrari-Canny epsilon for B grasps of primitive wrenches w (B, n, P, 6) -> (B,)."""
    b, n, p = w.shape[:3]
    per_grasp = (candidate_count(kind, m, n, norm) + 1) * n * p
    chunk = max(1, ELEMENT_BUDGET // max(per_grasp, 1))
    parts = [_epsilon_chunk(w[i : i + chunk], kind, m, norm) for i in range(0, b, chunk)]
    return np.concatenate(parts)
