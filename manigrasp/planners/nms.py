"""Non-maximum suppression of grasp poses: keep the top candidates diverse.

Two poses are duplicates when their TCP positions are closer than `distance`
[m] AND their orientations differ by less than `angle` [rad]. For a
two-jaw hand, a pose and the same pose turned 180 degrees about its approach
axis (fingers swapped) are the same grasp (`symmetric=True`).

`Suppressor` / `suppress` keep poses greedily in rank order (the usual
NMS). `conflicts` lists every duplicate pair of a set of poses and `pack`
picks a large set with no duplicate pair in it (a maximum independent set
heuristic), for when rank order keeps too few; `pack_prefix` packs only the
best-ranked poses, as few of them as still give a set of the size asked for.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix

DEFAULT_DISTANCE = 0.03  # [m]
DEFAULT_ANGLE = np.radians(30.0)  # [rad]
ANGLE_TOLERANCE = 1e-9  # [rad]: poses exactly `angle` apart (up to rounding) are distinct, on every code path


def rotation_angles(rot: np.ndarray, others: np.ndarray, symmetric: bool = False) -> np.ndarray:
    """Angles [rad] between rotation `rot` (3, 3) and each of `others` (n, 3, 3).

    With `symmetric`, the smaller of the angle to R and to R turned by pi about its z axis.
    """
    m = np.einsum("ji,njk->nik", rot, others)  # rot.T @ other
    cos = (np.trace(m, axis1=1, axis2=2) - 1.0) / 2.0
    if symmetric:
        cos_flip = (-m[:, 0, 0] - m[:, 1, 1] + m[:, 2, 2] - 1.0) / 2.0
        cos = np.maximum(cos, cos_flip)
    return np.arccos(np.clip(cos, -1.0, 1.0))


def pairwise_close(poses: np.ndarray, positions: np.ndarray, rotations: np.ndarray, distance: float,
                   angle: float, symmetric: bool) -> np.ndarray:
    """(k, m) True where pose i (k, 4, 4) is within `distance` and `angle` of pose j (positions (m, 3),
    rotations (m, 3, 3))."""
    a = poses[:, :3, 3]
    squared = (a * a).sum(axis=1)[:, None] + (positions * positions).sum(axis=1)[None] - 2.0 * a @ positions.T
    near = squared < distance * distance
    # (R_i.T @ R_j)[b, b] is column b of R_i dotted with column b of R_j.
    diag = [poses[:, :3, b] @ rotations[:, :, b].T for b in range(3)]  # 3 x (k, m)
    cos = (diag[0] + diag[1] + diag[2] - 1.0) / 2.0
    if symmetric:
        cos = np.maximum(cos, (-diag[0] - diag[1] + diag[2] - 1.0) / 2.0)
    return near & (cos > np.cos(angle - ANGLE_TOLERANCE))


def conflicts(poses: np.ndarray, distance: float = DEFAULT_DISTANCE, angle: float = DEFAULT_ANGLE,
              symmetric: bool = False, block: int = 256) -> np.ndarray:
    """(e, 2) index pairs i < j of the poses (n, 4, 4) that are duplicates of each other (both thresholds).

    Computed `block` rows at a time against the poses after them (`pairwise_close`).
    """
    positions, rotations = poses[:, :3, 3], poses[:, :3, :3]
    found = [np.zeros((0, 2), int)]
    for first in range(0, len(poses), block):
        rows = slice(first, first + block)
        close = pairwise_close(poses[rows], positions[first:], rotations[first:], distance, angle, symmetric)
        i, j = np.nonzero(close)
        keep = j > i
        found.append(np.stack([i[keep] + first, j[keep] + first], axis=1))
    return np.concatenate(found)


def representatives(poses: np.ndarray, cell: float, bins: int, symmetric: bool = False) -> np.ndarray:
    """Indices (sorted) of the first of `poses` (n, 4, 4) in each cell of (TCP position on a `cell` [m] grid,
    approach and closing axes binned to 1 / `bins` per component).

    Poses far closer than the NMS thresholds are interchangeable for packing;
    keeping one per cell shrinks the conflict graph. With `symmetric`, the
    closing axis's sign is ignored (fingers swapped).
    """
    if len(poses) == 0:
        return np.zeros(0, int)
    closing = poses[:, :3, 1]
    if symmetric:
        closing = closing * np.where(first_nonzero_sign(closing) < 0, -1.0, 1.0)[:, None]
    keys = np.concatenate([np.floor(poses[:, :3, 3] / cell), np.round(poses[:, :3, 2] * bins),
                           np.round(closing * bins)], axis=1).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return np.sort(first)


def first_nonzero_sign(vectors: np.ndarray) -> np.ndarray:
    """(n,) sign of the first component of each row (n, 3) that is not ~0."""
    signs = np.sign(np.where(np.abs(vectors) > 1e-9, vectors, 0.0))
    return signs[np.arange(len(vectors)), np.argmax(signs != 0, axis=1)]


def pack(conflict: np.ndarray, count: int) -> np.ndarray:
    """Indices (sorted) of many of `count` poses, no two of them in conflict: a large independent set.

    Greedy maximum independent set: take the pose with the fewest free
    conflicting poses, drop it and its conflicts, repeat; then improve by
    (1, 2)-swaps (Andrade, Resende and Werneck 2012): a kept pose is replaced
    by two non-conflicting poses whose only kept conflict it is. Taking the
    least-conflicting pose first keeps far more poses than taking them in rank
    order when many have equal scores (a thin object's grasps).

    Args:
        conflict: (e, 2) index pairs that are duplicates of each other (`conflicts`).
    """
    graph = coo_matrix((np.ones(len(conflict), np.int8), (conflict[:, 0], conflict[:, 1])), shape=(count, count))
    graph = (graph + graph.T).tocsr()
    neighbours, start = graph.indices, graph.indptr
    degree = np.diff(start).astype(np.int64)
    alive = np.ones(count, bool)
    kept = np.zeros(count, bool)
    while alive.any():
        i = int(np.argmin(np.where(alive, degree, np.iinfo(np.int64).max)))
        kept[i] = True
        gone = neighbours[start[i]:start[i + 1]]
        gone = np.concatenate([[i], gone[alive[gone]]])
        alive[gone] = False
        degree -= np.bincount(_gather(neighbours, start, gone), minlength=count)
    _improve(kept, neighbours, start)
    return np.flatnonzero(kept)


def pack_prefix(conflict: np.ndarray, count: int, n: int) -> np.ndarray:
    """Indices (sorted) of at least `n` (where possible) of `count` poses given best first, no two in conflict,
    packed (`pack`) from the shortest prefix of the ranking that still gives `n`.

    Greedy NMS in rank order spends the best region of pose space on a few
    poses that suppress many equally good ones, and fills up from far down the
    ranking; packing all the poses fills up from poses chosen for their few
    conflicts, whatever their rank. Packing only the best r poses, with r the
    smallest (bisection) for which `pack` finds `n` distinct ones, maximises
    (for this heuristic) the worst rank, hence the worst score, of the `n`
    grasps. If even all `count` poses do not give `n`: the packing of all.

    Args:
        conflict: (e, 2) index pairs (in rank order) that are duplicates of each other (`conflicts`).
    """
    def packed(r: int) -> np.ndarray:
        inside = conflict[(conflict[:, 0] < r) & (conflict[:, 1] < r)]
        return pack(inside, r)

    best = packed(count)
    if len(best) < n:
        return best
    lo, hi = min(n, count), count  # packed(hi) has >= n poses; the first r with n may be lo itself
    while lo < hi:
        mid = (lo + hi) // 2
        found = packed(mid)
        if len(found) >= n:
            hi, best = mid, found
        else:
            lo = mid + 1
    return best


def _improve(kept: np.ndarray, neighbours: np.ndarray, start: np.ndarray, rounds: int = 50) -> None:
    """(1, 2)-swaps on the independent set `kept` (count,) bool, in place, until none is left (or `rounds`)."""
    count = len(kept)
    tight = np.bincount(_gather(neighbours, start, np.flatnonzero(kept)), minlength=count)
    for _ in range(rounds):
        improved = False
        for u in np.flatnonzero(kept):
            near = neighbours[start[u]:start[u + 1]]
            solo = near[~kept[near] & (tight[near] == 1)]
            pair = _two_apart(solo, neighbours, start)
            if pair is None:
                continue
            kept[u] = False
            tight[neighbours[start[u]:start[u + 1]]] -= 1
            for v in pair:
                kept[v] = True
                tight[neighbours[start[v]:start[v + 1]]] += 1
            for v in near[~kept[near] & (tight[near] == 0)]:  # freed by the swap and still free
                if tight[v] == 0:
                    kept[v] = True
                    tight[neighbours[start[v]:start[v + 1]]] += 1
            improved = True
        if not improved:
            return


def _two_apart(nodes: np.ndarray, neighbours: np.ndarray, start: np.ndarray) -> tuple[int, int] | None:
    """Two of `nodes` that do not conflict with each other, or None."""
    for k, a in enumerate(nodes[:-1]):
        rest = nodes[k + 1:]
        apart = rest[~np.isin(rest, neighbours[start[a]:start[a + 1]])]
        if len(apart):
            return int(a), int(apart[0])
    return None


def _gather(values: np.ndarray, start: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The concatenated slices values[start[r]:start[r + 1]] of the `rows` (a CSR row gather)."""
    lengths = start[rows + 1] - start[rows]
    offsets = np.repeat(start[rows] - np.cumsum(lengths) + lengths, lengths)
    return values[offsets + np.arange(int(lengths.sum()))]


class Suppressor:
    """Greedy NMS over candidates offered best first: `offer` keeps a pose unless it duplicates a kept one.

    Args:
        distance: position threshold [m].
        angle: orientation threshold [rad].
        symmetric: treat a 180-degree turn about the approach axis as the same pose.
        capacity: the most poses that will be kept.
    """

    def __init__(self, distance: float = DEFAULT_DISTANCE, angle: float = DEFAULT_ANGLE,
                 symmetric: bool = False, capacity: int = 1024) -> None:
        self.distance, self.angle, self.symmetric = float(distance), float(angle), symmetric
        self._pos = np.zeros((capacity, 3))
        self._rot = np.zeros((capacity, 3, 3))
        self.count = 0

    def is_duplicate(self, pose: np.ndarray) -> bool:
        """Whether `pose` (4, 4) is within both thresholds of a kept pose."""
        return bool(self.duplicates(np.asarray(pose)[None])[0])

    def duplicates(self, poses: np.ndarray) -> np.ndarray:
        """(k,) whether each of `poses` (k, 4, 4) is within both thresholds of a kept pose (vectorised)."""
        if self.count == 0 or len(poses) == 0:
            return np.zeros(len(poses), bool)
        return pairwise_close(poses, self._pos[:self.count], self._rot[:self.count], self.distance,
                              self.angle, self.symmetric).any(axis=1)

    def keep(self, pose: np.ndarray) -> None:
        """Add `pose` (4, 4) to the kept set."""
        if self.count == len(self._pos):
            self._pos = np.concatenate([self._pos, np.zeros_like(self._pos)])
            self._rot = np.concatenate([self._rot, np.zeros_like(self._rot)])
        self._pos[self.count], self._rot[self.count] = pose[:3, 3], pose[:3, :3]
        self.count += 1


def suppress(poses: np.ndarray, distance: float = DEFAULT_DISTANCE, angle: float = DEFAULT_ANGLE,
             symmetric: bool = False) -> np.ndarray:
    """Indices of the poses (n, 4, 4), given best first, that survive greedy NMS (in order)."""
    nms = Suppressor(distance, angle, symmetric, capacity=max(1, len(poses)))
    kept = []
    for i, pose in enumerate(poses):
        if not nms.is_duplicate(pose):
            nms.keep(pose)
            kept.append(i)
    return np.array(kept, dtype=int)
