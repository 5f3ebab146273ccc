"""Two-jaw TCP poses around antipodal grasp lines, and their ranking (steps 4 and 5 of `antipodal`).

Pure NumPy. A grid is a number of approach directions around each grasp
line and TCP offsets from the contacts' midpoint: back along the approach
(depths) and across the pads (laterals), as fractions of the fingers'
extents (`HandProbe.finger_extents`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from manigrasp.geometry import perpendicular_basis
from manigrasp.planners.geometry import tcp_frames
from manigrasp.planners.pairs import Pairs


@dataclass(frozen=True)
class PoseGrid:
    """Approaches per grasp line and TCP offsets, as fractions of the fingers' reach and half-width.

    Attributes:
        approaches: approach directions evenly spaced about each grasp line (random phase).
        depths: offsets back along the approach, fractions of the fingers' reach beyond the TCP [-].
        laterals: offsets across the pads (the TCP's x axis), fractions of the fingers' half-width [-].
    """

    approaches: int
    depths: tuple[float, ...]
    laterals: tuple[float, ...]


@dataclass(frozen=True)
class RankedPoses:
    """Poses (k, 4, 4) of a grid, the pair each belongs to (k,), a ranking (indices, best first) and each
    pose's score (k,)."""

    poses: np.ndarray
    pair_of: np.ndarray
    order: np.ndarray
    score: np.ndarray


def jaw_poses(pairs: Pairs, depths: np.ndarray, laterals: np.ndarray, approaches: int, max_approach_z: float,
              table_height: float, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """TCP poses (k, 4, 4) around every pair's line at `depths` [m] back along the approach and `laterals` [m]
    across the pads, `approaches` per line (random phase) with approach z at most `max_approach_z`, TCP above
    the table; with their pair (k,), depth index (k,) and lateral index (k,)."""
    m = len(pairs)
    a, b = perpendicular_basis(pairs.axis)
    theta = rng.random(m)[:, None] * 2.0 * np.pi + np.arange(approaches)[None, :] * 2.0 * np.pi / approaches
    approach = np.cos(theta)[..., None] * a[:, None] + np.sin(theta)[..., None] * b[:, None]  # (m, count, 3)
    pair_of = np.repeat(np.arange(m), approaches)
    approach = approach.reshape(-1, 3)
    ok = approach[:, 2] <= max_approach_z
    pair_of, approach = pair_of[ok], approach[ok]
    across = np.cross(pairs.axis[pair_of], approach)  # the TCP's x axis
    d, s = np.meshgrid(np.arange(len(depths)), np.arange(len(laterals)), indexing="ij")
    d, s = d.ravel(), s.ravel()  # (o,) every depth x lateral combination
    centre = 0.5 * (pairs.p + pairs.q)[pair_of]
    positions = (centre[None] - depths[d][:, None, None] * approach[None]
                 - laterals[s][:, None, None] * across[None])  # (o, k, 3)
    o, k = len(d), len(pair_of)
    poses = tcp_frames(positions.reshape(-1, 3), np.tile(approach, (o, 1)), np.tile(pairs.axis[pair_of], (o, 1)))
    above = poses[:, 2, 3] >= table_height
    return poses[above], np.tile(pair_of, o)[above], np.repeat(d, k)[above], np.repeat(s, k)[above]


def jaw_clears_table(pairs: Pairs, open_width: float, lift: float, table_height: float) -> np.ndarray:
    """(m,) False where a pair's lower open jaw lies below the table whatever the approach.

    The open jaws sit `open_width` / 2 [m] from the contacts' midpoint along
    the grasp line; the TCP offsets (at most `lift` [m]) move them
    perpendicular to it. A nearly vertical line through a thin object (its
    lower contact on the table) fails. A heuristic (the jaw's own extent is not
    modelled), used to rank such pairs last and to spend a dense grid's budget elsewhere.
    """
    midpoint_z = 0.5 * (pairs.p[:, 2] + pairs.q[:, 2])
    return midpoint_z - 0.5 * open_width * np.abs(pairs.axis[:, 2]) + lift >= table_height


def ranked_poses(pairs: Pairs, score: np.ndarray, grid: PoseGrid, extents: tuple[float, float], open_width: float,
                 max_approach_z: float, table_height: float, rng: np.random.Generator,
                 keep_unclear: bool = True,
                 pose_score: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> RankedPoses:
    """The poses of `grid` around every pair, ranked by pair `score` (m,), best first.

    With `pose_score`, each pose's own score (k,) from its pose (k, 4, 4) and pair (k,) (what the pads
    touch there: `footprint`) ranks it instead of its pair's.

    Ties: centred contacts first (lateral index), then the deepest (depth
    index). Poses of pairs whose lower open jaw cannot clear the table
    (`jaw_clears_table`) are ranked last, or left out without `keep_unclear`.

    Args:
        extents: the fingers' (reach, half-width) [m] (`HandProbe.finger_extents`).
        open_width: the hand's maximum width [m].
    """
    reach, half_width = extents
    depths, laterals = reach * np.asarray(grid.depths), half_width * np.asarray(grid.laterals)
    poses, pair_of, depth_of, lateral_of = jaw_poses(pairs, depths, laterals, grid.approaches, max_approach_z,
                                                     table_height, rng)
    clear = jaw_clears_table(pairs, open_width, float(depths.max() + np.abs(laterals).max()), table_height)
    if not keep_unclear:
        keep = clear[pair_of]
        poses, pair_of, depth_of, lateral_of = poses[keep], pair_of[keep], depth_of[keep], lateral_of[keep]
    scores = score[pair_of] if pose_score is None else np.asarray(pose_score(poses, pair_of), float)
    order = np.lexsort((depth_of, lateral_of, -scores, ~clear[pair_of]))
    return RankedPoses(poses, pair_of, order, scores)
