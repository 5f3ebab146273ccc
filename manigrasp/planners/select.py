"""Choosing poses from a ranking: neither duplicates (NMS) nor colliding (MuJoCo).

`select_free` walks down the ranking (greedy NMS, lazy collision tests: the
usual path). `pack_free` tests every pose and packs as many distinct free
poses as it can (for objects where the walk comes up short).
"""

from __future__ import annotations

import numpy as np

from manigrasp.geometry import pregrasp_pose
from manigrasp.planners.collision import HandProbe
from manigrasp.planners.nms import Suppressor, conflicts, pack, pack_prefix, pairwise_close, representatives

CHUNK = 256  # poses whose root transforms are computed at once


def select_free(probe: HandProbe, nms: Suppressor, ranked: np.ndarray, n: int, pregrasp_offset: float,
                max_checks: int) -> np.ndarray:
    """Indices into `ranked` (k, 4, 4), best first, of at most `n` kept poses.

    A pose is kept when it is not within the NMS thresholds of a pose kept
    before it, and the open hand is clear of object and table both at the
    pose and at its pre-grasp pose. At most `max_checks` poses are tested for
    collision (a pose rejected by NMS costs no test).
    """
    kept: list[int] = []
    checks = 0
    for start in range(0, len(ranked), CHUNK):
        chunk = ranked[start:start + CHUNK]
        fresh = np.flatnonzero(~nms.duplicates(chunk))
        if len(fresh) == 0:
            continue
        close = pairwise_close(chunk[fresh], chunk[fresh, :3, 3], chunk[fresh, :3, :3], nms.distance, nms.angle,
                               nms.symmetric)
        grasp_pos, grasp_quat = probe.roots(chunk[fresh])
        pre_pos, pre_quat = probe.roots(pregrasp_pose(chunk[fresh], pregrasp_offset))
        kept_here: list[int] = []
        for i in range(len(fresh)):
            if kept_here and close[i, kept_here].any():
                continue
            if checks >= max_checks:
                return np.array(kept, dtype=int)
            checks += 1
            probe.place(grasp_pos[i], grasp_quat[i])
            if probe.touching():
                continue
            probe.place(pre_pos[i], pre_quat[i])
            if probe.touching():
                continue
            nms.keep(chunk[fresh[i]])
            kept_here.append(i)
            kept.append(start + int(fresh[i]))
            if len(kept) >= n:
                return np.array(kept, dtype=int)
    return np.array(kept, dtype=int)


PACK_CELL = 0.005  # [m], representatives' position grid (`nms.representatives`)
PACK_BINS = 12  # representatives' axis bins per unit component (about 5 degrees)
PACK_LIMIT = 6000  # the most representatives packed (the best ranked): bounds the conflict graph


def pack_free(probe: HandProbe, ranked: np.ndarray, n: int, distance: float, angle: float, symmetric: bool,
              pregrasp_offset: float, max_checks: int) -> np.ndarray:
    """Indices into `ranked` (k, 4, 4), best first, of at most `n` free poses, no two within the NMS thresholds.

    The first `max_checks` poses of the ranking are tested for collision at
    the pose and its pre-grasp pose; the best ranked free pose of each small
    cell of pose space stands for its cell (`nms.representatives`), and the
    representatives are packed into as large a set of mutually distinct poses
    as `nms.pack` finds, of which the `n` best ranked are returned.

    Args:
        distance, angle, symmetric: the NMS thresholds [m], [rad] and the finger-swap symmetry.
    """
    ranked = ranked[:max_checks]
    free = _representatives(ranked, _clear(probe, ranked, pregrasp_offset), symmetric)
    return free[pack(conflicts(ranked[free], distance, angle, symmetric), len(free))][:n]


def pack_ranked(probe: HandProbe, ranked: np.ndarray, n: int, distance: float, angle: float, symmetric: bool,
                pregrasp_offset: float, max_checks: int, first: int = 4 * CHUNK) -> np.ndarray:
    """Indices into `ranked` (k, 4, 4), best first, of at most `n` free poses, no two within the NMS thresholds,
    drawn from as short a prefix of the ranking as packing allows (`nms.pack_prefix`).

    Tests the ranking for collision (pose and pre-grasp pose) in blocks from the top (`first` poses, then
    doubling, at most `max_checks` in all) until the free poses' representatives (`nms.representatives`) pack
    into `n` distinct poses; then packs the shortest prefix of them that still gives `n`. Unlike
    `select_free`, a pose near a kept one is not discarded because a better-ranked pose took its place: on a
    scanned can, greedy NMS in rank order keeps about half as many distinct body grasps as there are.
    """
    free = np.zeros(0, int)
    checked, size = 0, first
    limit = min(len(ranked), max_checks)
    reps, chosen = np.zeros(0, int), np.zeros(0, int)
    while checked < limit:
        block = np.arange(checked, min(checked + size, limit))
        free = np.concatenate([free, block[_clear(probe, ranked[block], pregrasp_offset)]])
        checked, size = block[-1] + 1, 2 * size
        reps = _representatives(ranked, free, symmetric)
        chosen = pack_prefix(conflicts(ranked[reps], distance, angle, symmetric), len(reps), n)
        if len(chosen) >= n:  # all of them pack into n: `chosen` is the shortest prefix's packing
            break
    return reps[chosen][:n]


def _clear(probe: HandProbe, poses: np.ndarray, pregrasp_offset: float) -> np.ndarray:
    """Indices of `poses` (k, 4, 4) at which the open hand is clear of object and table, and at their pre-grasp."""
    free = np.flatnonzero(~probe.collides(poses))
    return free[~probe.collides(pregrasp_pose(poses[free], pregrasp_offset))]


def _representatives(ranked: np.ndarray, free: np.ndarray, symmetric: bool) -> np.ndarray:
    """Of the indices `free` into `ranked`, the best ranked of each small cell of pose space (at most `PACK_LIMIT`)."""
    return free[representatives(ranked[free], PACK_CELL, PACK_BINS, symmetric)][:PACK_LIMIT]
