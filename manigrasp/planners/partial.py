"""Antipodal grasps on a partial view: visible pairs, single-sided pairs into unseen space, a free-space probe.

The `antipodal` planner's cloud path with ``completion="free_space"`` (its
default) plans here. It needs only what the cameras saw: the observed cloud
with normals and the depth views it came from (`free_space.ViewedObservation`).

1. Visible pairs: antipodal pairs whose two contacts were both seen
   (`cloud.cloud_pairs` on the denoised observed cloud, no completion).
2. Single-sided pairs (`hidden_pairs`): from a seen point p with outward
   normal n, on a face (its neighbours' normals within 15 degrees of n, not
   an edge), the jaws close along d = -n (not within 25 degrees of vertical:
   the hidden side of a top or bottom face is the table or the object's
   inside). Along the line p + t d the views give two bounds on where the
   object ends: it ends before t_free, the first point of a 3 mm run of
   FREE space (a camera ray passed there) or, with `hidden_margin` (the
   default), of occluded space outside the seen points' footprint (`Footprint`:
   the object's hidden part lies under its seen surfaces, as step 3 assumes for
   the hand; without it the shadow behind a box seen from 45 degrees left the
   lines of its lower part 3 cm of uncertainty, more than `max_uncertainty`,
   and only lines near its top and side edges were kept), and it reaches at least t_seen,
   the farthest seen point s lying vertically over the line (within `radius`
   of its vertical sheet, at or above it, before t_free: a box's top face
   over a line below it; sides are taken as vertical). The seen surface ends
   between s and b, the first FREE point from s horizontally along d at s's height (a view saw past it there; 0.5 mm
   steps, at most `EDGE_REACH`; else b = s + the point spacing) and, the
   surface being sampled, within about one sampling gap (2 x the point
   spacing) of s. The far contact is put midway, w = t_seen +
   min(|b - s|, 2 spacing) / 2, within [min_width,
   t_free], its normal assumed antipodal (d); the line is kept when w fits
   the open jaw, the uncertainty u = t_free - w is at most `max_uncertainty`
   (the object may reach farther: the far finger's own volume must then be
   seen free, step 3, which bounds it where the finger is), and the far
   contact was not seen (no observed point within 2 `radius` whose normal
   faces along d: a seen exit is a visible pair's, with its measured normal).
3. Collision (`SpaceProbe`): the open hand's collision geometry (MuJoCo, as
   `collision.HandProbe`) against the table, and points on its geoms'
   boxes against the views' blocked space: the part of the object's region
   (the observed cloud's bounding box grown by `region_margin`, down to the
   table) that no view saw through (OCCUPIED: on a seen surface; UNKNOWN:
   occluded, e.g. the object's hidden part). So no jaw is placed in space the
   views could not see. The ranking is filtered by this test in chunks
   before the usual NMS walk (`select_clear`).

Ranking: the antipodal score (hold x quality) of every pair, times a
confidence of 1 for a visible pair and
``hidden_weight * (1 - 0.5 * u / max_uncertainty)`` for a single-sided one
(less trust in a contact nobody saw, and less the farther the object may
extend); with the planner's `pad_footprint` (the default) each pose's hold
margin takes the torsion ratio of what its pads touch in the blocked space of
step 3 (`SpaceProbe.seat`), so a pad half over an edge ranks lower; mass:
density x the volume of the convex hull of the cloud and its footprint on the
table (the object rests on it), centre of mass at that hull's centroid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from manigrasp.errors import PlannerError
from manigrasp.geometry import pregrasp_pose
from manigrasp.hands.base import Hand
from manigrasp.planners.cloud import CompletedCloud
from manigrasp.planners.collision import HandProbe
from manigrasp.planners.context import resolve
from manigrasp.planners.footprint import PadFootprint, Seat
from manigrasp.planners.free_space import OCCUPIED, UNKNOWN, FreeSpace
from manigrasp.planners.pairs import Pairs
from manigrasp.sim.config import SceneConfig

MAX_VERTICAL = 0.9  # |d_z| above which a single-sided line is not tried (within ~25 degrees of vertical)
FLAT_COS = np.cos(np.radians(15.0))  # a single-sided line starts where the neighbours' normals agree this well
DENSE_CHECKS = 8000  # the most poses of the antipodal planner's dense grid tested on a viewed cloud (planning time)
FREE_RUN = 3  # consecutive FREE samples that end the object along a line
FOOTPRINT_VOXEL = 0.002  # [m] cell of the footprint map that bounds single-sided lines (the probe's voxel)
EDGE_REACH = 0.006  # [m] how far beyond the farthest seen point its surface's edge is looked for
PLACEHOLDER = np.array([[50.0, 50.0, 50.0], [50.1, 50.0, 50.0], [50.0, 50.1, 50.0], [50.0, 50.0, 50.1]])


@dataclass(frozen=True)
class HiddenPairs:
    """Single-sided pairs and the uncertainty u (m,) [m] of each far contact (module docstring, step 2)."""

    pairs: Pairs
    uncertainty: np.ndarray


def object_region(points: np.ndarray, table_height: float, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) (3,) corners [m] of the box where the object may be: the cloud's bounds grown by
    `margin` [m] sideways and up, down to the table."""
    low, high = points.min(axis=0) - margin, points.max(axis=0) + margin
    low[2] = table_height
    return low, high


def _blocked(space: FreeSpace, points: np.ndarray, low: np.ndarray, high: np.ndarray,
             table_height: float, footprint: Footprint | None = None) -> np.ndarray:
    """(n,) True for points no view saw through inside the region [low, high], or below the table.

    Within 2 `space.tau` above the table the measured surface is the table's (MuJoCo tests the table):
    only occluded (UNKNOWN) points there are blocked. With a `footprint`, an occluded point is blocked only
    under it (`Footprint.covers`: the object's hidden part lies under its seen surfaces).
    """
    inside = np.all((points >= low) & (points <= high), axis=1)
    out = points[:, 2] < table_height
    check = np.flatnonzero(inside & ~out)
    state = space.classify(points[check])
    band = points[check, 2] < table_height + 2.0 * space.tau
    unknown = state == UNKNOWN
    if footprint is not None:
        unknown[unknown] = footprint.covers(points[check[unknown]])
    out[check] = unknown | ((state == OCCUPIED) & ~band)
    return out


@dataclass(frozen=True)
class Footprint:
    """Where an object resting on the table, whose hidden part lies under its seen surfaces, can be: within
    `margin` horizontally of the seen points' vertical projection and at most `margin` above the highest seen
    point there (`footprint_mask`, point-wise).

    Attributes:
        low: (3,) corner of the map [m]; voxel: its cell edge [m]; margin: [m].
        top: (nx, ny) the highest seen point within `margin` (a square of cells) of each cell [m] (-inf: none).
    """

    low: np.ndarray
    voxel: float
    margin: float
    top: np.ndarray

    @classmethod
    def of(cls, points: np.ndarray, low: np.ndarray, high: np.ndarray, voxel: float, margin: float) -> Footprint:
        """The footprint of the seen `points` (n, 3) [m] over the box [low, high] (3,) [m]."""
        low = np.asarray(low, float)
        shape = np.ceil((np.asarray(high, float) - low) / voxel).astype(int) + 1
        return cls(low, voxel, margin, _footprint_top(points, low, shape, voxel, margin))

    def covers(self, points: np.ndarray) -> np.ndarray:
        """(n,) True for `points` (n, 3) [m] within the footprint (and not above it)."""
        cells = np.floor((points[:, :2] - self.low[:2]) / self.voxel).astype(int)
        inside = np.all((cells >= 0) & (cells < np.array(self.top.shape)), axis=1)
        out = np.zeros(len(points), bool)
        top = self.top[cells[inside, 0], cells[inside, 1]]
        out[inside] = np.isfinite(top) & (points[inside, 2] <= top + self.margin)
        return out


def hidden_pairs(cloud: CompletedCloud, chosen: np.ndarray, space: FreeSpace, widths: tuple[float, float],
                 radius: float, max_uncertainty: float, region: tuple[np.ndarray, np.ndarray],
                 table_height: float, step: float = 0.001, footprint: Footprint | None = None) -> HiddenPairs:
    """Single-sided pairs from the observed points `chosen` (indices) of `cloud` (module docstring, step 2).

    Args:
        widths: (min, max) jaw width [m]; radius: half-width of a line's vertical sheet [m].
        max_uncertainty: largest t_free - w kept [m]; region: the object's box (`object_region`).
        step: spacing of the samples along each line [m].
        footprint: None: all occluded space in `region` may hold the object; a `Footprint`: only occluded
            space under it (the hidden part lies under the seen surfaces), so t_free is where the line leaves
            the footprint, as the hand's probe assumes (`SpaceProbe` with `hidden_margin`).
    """
    p, n = cloud.points[chosen], cloud.normals[chosen]
    d = -n
    keep = (np.abs(d[:, 2]) < MAX_VERTICAL) & _flat(cloud, chosen)
    p, n, d = p[keep], n[keep], d[keep]
    t = np.arange(step, widths[1] + max_uncertainty + (FREE_RUN + 1) * step, step)
    samples = p[:, None] + t[None, :, None] * d[:, None]  # (m, T, 3)
    blocked = _blocked(space, samples.reshape(-1, 3), *region, table_height, footprint).reshape(len(p), len(t))
    free = ~blocked
    run = np.ones((len(p), len(t) - FREE_RUN + 1), bool)
    for k in range(FREE_RUN):
        run &= free[:, k:len(t) - FREE_RUN + 1 + k]
    found = run.any(axis=1)
    t_free = np.where(found, t[np.argmax(run, axis=1)], np.inf)
    p, n, d, t_free = p[found], n[found], d[found], t_free[found]
    t_seen, last = _seen_over(cloud.points[:cloud.observed], p, d, t_free, radius)
    beyond = _edge_beyond(space, cloud.points[np.maximum(last, 0)], d, np.full(len(p), cloud.spacing),
                          0.5 * step, EDGE_REACH)
    gap = np.minimum(beyond, 2.0 * cloud.spacing)  # the edge lies within about one sampling gap of s
    width = np.clip(t_seen + 0.5 * np.where(last >= 0, gap, 0.0), widths[0], t_free)
    uncertainty = t_free - width
    unseen = ~_seen_exit(cloud, p + width[:, None] * d, d, 2.0 * radius)
    ok = (uncertainty <= max_uncertainty) & unseen & (width <= widths[1])
    pairs = Pairs(p=p, q=p + width[:, None] * d, n_p=n, n_q=d.copy(), axis=d, width=width,
                  alpha=np.zeros(len(p)))
    return HiddenPairs(pairs.take(ok), uncertainty[ok])


def _seen_exit(cloud: CompletedCloud, q: np.ndarray, d: np.ndarray, radius: float) -> np.ndarray:
    """(m,) True where a seen surface facing along d (m, 3) (normal within 60 degrees) lies within `radius` [m]
    of the far contact q (m, 3): the line leaves the object through a surface a view saw."""
    near = cKDTree(cloud.points[:cloud.observed]).query_ball_point(q, radius)
    return np.array([bool(idx) and bool(np.any(cloud.normals[idx] @ d[i] > 0.5)) for i, idx in enumerate(near)],
                    bool)


def _flat(cloud: CompletedCloud, chosen: np.ndarray, k: int = 12) -> np.ndarray:
    """(m,) True where the normals of a point's `k` nearest neighbours all lie within ~15 degrees of its own
    (a face, not an edge or a corner, whose PCA normal points between the faces)."""
    observed = cloud.points[:cloud.observed]
    _, idx = cKDTree(observed).query(cloud.points[chosen], k=min(k, len(observed)))
    cos = np.einsum("mkj,mj->mk", cloud.normals[idx], cloud.normals[chosen])
    return cos.min(axis=1) > FLAT_COS


def _seen_over(points: np.ndarray, p: np.ndarray, d: np.ndarray, t_free: np.ndarray, radius: float,
               chunk: int = 128) -> tuple[np.ndarray, np.ndarray]:
    """The farthest t (m,) along each line p + t d of a seen point vertically over it (horizontally within
    `radius` of the line, at most `radius` below it, before t_free; 0 where none), and that point's index
    (m,) (-1 where none). The object's sides are taken as vertical: "over" is along world z."""
    horizontal = d[:, :2] / np.sum(d[:, :2] ** 2, axis=1, keepdims=True)  # t of a horizontal offset
    across = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.linalg.norm(d[:, :2], axis=1, keepdims=True)
    out, which = np.zeros(len(p)), np.full(len(p), -1)
    for start in range(0, len(p), chunk):
        s = slice(start, start + chunk)
        rel = points[None] - p[s, None]  # (c, N, 3)
        along = np.einsum("cnk,ck->cn", rel[..., :2], horizontal[s])
        over = ((np.abs(np.einsum("cnk,ck->cn", rel[..., :2], across[s])) <= radius)
                & (rel[..., 2] - along * d[s, None, 2] >= -radius)
                & (along > 0) & (along <= t_free[s, None] + radius))
        masked = np.where(over, along, 0.0)
        out[s] = np.max(masked, axis=1)
        which[s] = np.where(over.any(axis=1), np.argmax(masked, axis=1), -1)
    return out, which


def _edge_beyond(space: FreeSpace, points: np.ndarray, d: np.ndarray, fallback: np.ndarray, step: float,
                 reach: float) -> np.ndarray:
    """(m,) how far along each line [t, m] beyond a seen point (m, 3) a view saw past its surface: the first
    FREE sample from the point, horizontally along d (m, 3) at the point's own height (its surface ends
    there); `fallback` (m,) where none is within `reach` [m]."""
    offsets = np.arange(step, reach + step, step)
    flat = np.column_stack([d[:, :2], np.zeros(len(d))])
    scale = np.linalg.norm(flat, axis=1)
    samples = points[:, None] + offsets[None, :, None] * (flat / scale[:, None])[:, None]
    free = space.free(samples.reshape(-1, 3)).reshape(len(points), len(offsets))
    return np.where(free.any(axis=1), (offsets[np.argmax(free, axis=1)] - 0.5 * step) / scale, fallback)


def footprint_hull(points: np.ndarray, table_height: float) -> trimesh.Trimesh:
    """The convex hull of `points` (n, 3) and their vertical projection on the table [m]."""
    foot = points.copy()
    foot[:, 2] = table_height
    try:
        return trimesh.convex.convex_hull(np.vstack([points, foot]))
    except Exception as exc:  # qhull refuses a flat set
        raise PlannerError(f"the point cloud spans no volume ({exc.__class__.__name__})") from exc


def _box_surface(half: np.ndarray, spacing: float) -> np.ndarray:
    """(k, 3) points on the surface of a box of half-extents `half` (3,) [m], at most `spacing` [m] apart."""
    axes = [np.linspace(-h, h, max(2, int(np.ceil(2 * h / spacing)) + 1)) for h in half]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return grid[np.any(np.isclose(np.abs(grid), half), axis=1)]


def footprint_mask(points: np.ndarray, low: np.ndarray, shape: np.ndarray, voxel: float,
                   margin: float) -> np.ndarray:
    """(nx, ny, nz) True for the voxels of a grid (corner `low` (3,), `shape`, edge `voxel` [m]) within
    `margin` [m] horizontally of the vertical projection of `points` (n, 3) and at most `margin` above the
    highest point over them: where an object resting on the table, whose hidden part lies under its
    seen surfaces, can be."""
    top = _footprint_top(points, low, shape, voxel, margin)
    near = np.isfinite(top)
    z = low[2] + voxel * (np.arange(shape[2]) + 0.5)
    return near[:, :, None] & (z[None, None, :] <= top[:, :, None] + margin)


def _footprint_top(points: np.ndarray, low: np.ndarray, shape: np.ndarray, voxel: float,
                   margin: float) -> np.ndarray:
    """(nx, ny) the highest of `points` (n, 3) [m] within `margin` [m] (a square of cells) of each cell of a
    grid (corner `low`, `shape`, edge `voxel` [m]); -inf where none."""
    from scipy.ndimage import maximum_filter

    cells = np.floor((points[:, :2] - low[:2]) / voxel).astype(int)
    keep = np.all((cells >= 0) & (cells < shape[:2]), axis=1)
    top = np.full(tuple(shape[:2]), -np.inf)
    np.maximum.at(top, (cells[keep, 0], cells[keep, 1]), points[keep, 2])
    reach = int(np.ceil(margin / voxel))
    return maximum_filter(top, size=2 * reach + 1, mode="constant", cval=-np.inf)


class SpaceProbe(HandProbe):
    """A `HandProbe` that also keeps the hand out of the space no view saw through (module docstring, step 3).

    MuJoCo tests the open hand against the table (its object is a placeholder
    far away). The views' blocked space (not FREE inside `region`) is sampled
    on a voxel grid once, with its distance transform (scipy); points on the
    faces of the hand's collision boxes (at most `finger_spacing` apart,
    `palm_spacing` on the root body's geoms) are tested against it, and a pose
    is blocked when one lies closer to blocked space than the clearance +
    half a voxel's diagonal. `clear` tests many poses at once; `collides` and
    `free` test both.

    Args:
        hand, observation, clearance, config: as `HandProbe`.
        space: the views' free space; region: (low, high) the object's box [m].
        voxel: edge of the grid's voxels [m]; finger_spacing, palm_spacing: of the test points [m].
        hidden_margin: None: all unknown space in `region` is blocked; a distance [m]: only unknown space
            within it (horizontally) of the seen points' footprint and not above them (`footprint_mask`).
    """

    def __init__(self, hand: Hand, observation, space: FreeSpace, region: tuple[np.ndarray, np.ndarray],
                 clearance: float, voxel: float = 0.002, finger_spacing: float = 0.005,
                 palm_spacing: float = 0.015, hidden_margin: float | None = None,
                 config: SceneConfig | None = None) -> None:
        from scipy.ndimage import distance_transform_edt

        super().__init__(hand, observation, clearance, config=config, hull=PLACEHOLDER)
        self.region, self.voxel = region, voxel
        self.points = self._hand_points(finger_spacing, palm_spacing)
        pad = clearance + 2 * voxel
        self.low = np.asarray(region[0], float) - pad
        shape = np.ceil((np.asarray(region[1], float) + pad - self.low) / voxel).astype(int)
        axes = [self.low[i] + voxel * (np.arange(shape[i]) + 0.5) for i in range(3)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        blocked = _blocked(space, grid, *region, float(observation.table_height))
        inside = np.all((grid >= region[0]) & (grid <= region[1]), axis=1)
        blocked &= inside
        if hidden_margin is not None:  # unknown space counts only over the object's footprint
            seen = space.classify(grid[blocked]) == OCCUPIED
            near = footprint_mask(observation.points, self.low, shape, voxel, hidden_margin)
            blocked[np.flatnonzero(blocked)[~seen]] = near.reshape(-1)[np.flatnonzero(blocked)[~seen]]
        self._solid = np.pad(blocked.reshape(shape), 1).ravel()  # the blocked space itself (`seat`)
        self.distance = distance_transform_edt(~blocked.reshape(shape), sampling=voxel)
        self.margin = clearance + 0.5 * np.sqrt(3.0) * voxel
        hit = np.pad(self.distance <= self.margin, 1)  # a free border for points off the grid
        self._hit, self._limit = hit.ravel(), np.array(hit.shape, np.int32) - 1
        self._strides = (hit.shape[1] * hit.shape[2], hit.shape[2])

    def _hand_points(self, finger_spacing: float, palm_spacing: float) -> np.ndarray:
        """(k, 3) points on the faces of the open hand's collision boxes, TCP frame [m]."""
        model, data = self.scene.model, self.scene.data
        self.place(*[x[0] for x in self.roots(np.eye(4)[None])])
        tcp = self.scene.tcp_pose()
        out = []
        for g in np.flatnonzero(self.is_hand & (model.geom_contype != 0)):
            spacing = palm_spacing if model.geom_bodyid[g] == self.root else finger_spacing
            local = _box_surface(model.geom_aabb[g, 3:], spacing) + model.geom_aabb[g, :3]
            world = local @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
            out.append((world - tcp[:3, 3]) @ tcp[:3, :3])
        self.restore()
        return np.vstack(out)

    def clear(self, poses: np.ndarray, chunk: int = 1024) -> np.ndarray:
        """(n,) True where the open hand at TCP poses (n, 4, 4) [m] keeps out of the blocked space.

        Every third test point first, then all of them for the poses that pass.
        """
        poses = np.asarray(poses, float)
        out = np.zeros(len(poses), bool)
        for start in range(0, len(poses), chunk):
            block = poses[start:start + chunk]
            passed = np.flatnonzero(~self._hits(block, self.points[::3]))
            out[start + passed[~self._hits(block[passed], self.points)]] = True
        return out

    def _hits(self, poses: np.ndarray, points: np.ndarray) -> np.ndarray:
        """(b,) True where some of `points` (k, 3) (TCP frame) at TCP poses (b, 4, 4) lies in the grown
        blocked space (a padded flat lookup: points off the grid land on its free border)."""
        world = poses[:, :3, :3].astype(np.float32) @ points.T.astype(np.float32)  # (b, 3, k)
        world += poses[:, :3, 3, None].astype(np.float32)
        index = np.floor((world - self.low[None, :, None].astype(np.float32)) / self.voxel).astype(np.int32) + 1
        np.clip(index, 0, self._limit[None, :, None], out=index)
        flat = (index[:, 0] * self._strides[0] + index[:, 1] * self._strides[1] + index[:, 2])
        return self._hit[flat].any(axis=1)

    def _lookup(self, grid: np.ndarray, poses: np.ndarray, points: np.ndarray) -> np.ndarray:
        """(b, k) `grid` (a padded flat boolean grid of the probe's voxels) at `points` (k, 3) (TCP frame) at TCP
        poses (b, 4, 4); points off the grid land on its False border."""
        world = poses[:, :3, :3].astype(np.float32) @ points.T.astype(np.float32)  # (b, 3, k)
        world += poses[:, :3, 3, None].astype(np.float32)
        index = np.floor((world - self.low[None, :, None].astype(np.float32)) / self.voxel).astype(np.int32) + 1
        np.clip(index, 0, self._limit[None, :, None], out=index)
        return grid[index[:, 0] * self._strides[0] + index[:, 1] * self._strides[1] + index[:, 2]]

    def seat(self, footprint: PadFootprint, poses: np.ndarray, chunk: int = 4096) -> Seat:
        """How the pads of `footprint` sit at TCP poses (k, 4, 4) [m] on the space the views saw blocked (the
        object as the views know it: its seen surfaces, and under `hidden_margin` the occluded space under
        them), as `footprint.PadFootprint.seat` on a mesh: a cell touches where the blocked space lies across
        the jaws' midplane under it (the TCP's y = 0), else it overhangs the object (off an edge, over space
        a view saw through). Both pads take the cells of that midplane (a grasp across parallel faces, which
        is what a single-sided pair assumes); the gaps of touching cells are taken as 0 (a voxel is coarser
        than the pad's compression), so the patch's tilt is not measured (NaN: the pair's normals)."""
        from manigrasp.planners.footprint import patch_support, patch_torsion, pressure

        cells = footprint.cells
        local = np.column_stack([cells[:, 0], np.zeros(len(cells)), cells[:, 1]])
        poses = np.asarray(poses, float)
        touch = np.zeros((len(poses), len(cells)), bool)
        for start in range(0, len(poses), chunk):
            touch[start:start + chunk] = self._lookup(self._solid, poses[start:start + chunk], local)
        gaps = np.where(touch, 0.0, np.inf)[:, None, :].repeat(2, axis=1)  # (k, 2, n)
        weights = pressure(gaps, footprint.compression)
        ratio, pivot = patch_torsion(weights, cells)
        return Seat(ratio, pivot, np.full((len(poses), 2), np.nan), patch_support(weights, cells))

    def collides(self, poses: np.ndarray) -> np.ndarray:
        """(n,) True where the open hand at TCP poses (n, 4, 4) meets blocked space or the table."""
        out = ~self.clear(poses)
        rest = np.flatnonzero(~out)
        out[rest] = super().collides(np.asarray(poses)[rest])
        return out

    def free(self, pose: np.ndarray, offset: float | None = None) -> bool:
        """True if the open hand is clear of blocked space and table at `pose` (4, 4) and its pre-grasp pose
        `offset` [m] back (None: the standard protocol's `pregrasp_offset`)."""
        offset = resolve(None, offset).pregrasp_offset
        both = np.stack([pose, pregrasp_pose(pose, offset)])
        return bool(self.clear(both).all()) and super().free(pose, offset)


def select_clear(probe: SpaceProbe, nms, ranked: np.ndarray, n: int, pregrasp_offset: float, max_checks: int,
                 chunk: int = 2048) -> np.ndarray:
    """Indices into `ranked` (k, 4, 4), best first, of at most `n` poses kept by `select.select_free` among
    those whose hand, at the pose and at its pre-grasp pose, keeps out of the blocked space (`probe.clear`)."""
    from manigrasp.planners.select import select_free

    kept: list[np.ndarray] = []
    total = 0
    for start in range(0, len(ranked), chunk):
        block = ranked[start:start + chunk]
        ok = np.flatnonzero(probe.clear(block))
        ok = ok[probe.clear(pregrasp_pose(block[ok], pregrasp_offset))]
        found = select_free(probe, nms, block[ok], n - total, pregrasp_offset, max_checks)
        kept.append(start + ok[found])
        total += len(found)
        if total >= n:
            break
    return np.concatenate(kept) if kept else np.zeros(0, int)


def free_space_target(planner, observation, hand: Hand, rng: np.random.Generator,
                      scene: SceneConfig | None = None) -> tuple:
    """(pairs, centre of mass (3,), torque scale, mass, probe, confidence (m,)) of `planner` (an
    `AntipodalPlanner`) on a viewed point cloud (module docstring); the probe is compiled in a scene of
    `scene` (None: the default `SceneConfig`; `PlanContext.scene`).

    Raises:
        PlannerError: the observation carries no depth views, or too few points.
    """
    from manigrasp.planners.cloud import cloud_pairs, complete
    from manigrasp.planners.metrics import torque_scale
    from manigrasp.planners.pairs import thin_pairs

    views = getattr(observation, "views", ())
    if not views:
        raise PlannerError("completion 'free_space' needs the depth views of the cloud (a ViewedObservation, "
                           "as the point_cloud observation gives); use completion='point_symmetry' or 'none' "
                           "for a bare cloud")
    space = FreeSpace(views, planner.free_space_tau)
    done = complete(observation.points, observation.normals, observation.table_height, "none")
    radius = max(planner.cloud_radius, 1.5 * done.spacing)
    widths = (planner.min_width, hand.max_width - planner.width_margin)
    seen = cloud_pairs(done, planner.n_samples, planner.rays_per_sample, planner.ray_cone, planner.contact.mu,
                       widths, 0.5 * hand.max_width, radius, rng)
    region = object_region(done.points, observation.table_height, planner.region_margin)
    chosen = rng.choice(done.observed, size=min(planner.n_samples, done.observed), replace=False)
    footprint = None if planner.hidden_margin is None else Footprint.of(
        done.points, region[0], region[1], FOOTPRINT_VOXEL, planner.hidden_margin)
    hidden = hidden_pairs(done, chosen, space, widths, radius, planner.hidden_uncertainty, region,
                          observation.table_height, footprint=footprint)
    seen = seen.take(thin_pairs(seen, planner.pair_cell))
    keep = thin_pairs(hidden.pairs, planner.pair_cell)  # each kind thinned on its own: visible pairs stay
    unseen, uncertainty = hidden.pairs.take(keep), hidden.uncertainty[keep]
    pairs = Pairs(*(np.concatenate([getattr(seen, f), getattr(unseen, f)])
                    for f in ("p", "q", "n_p", "n_q", "axis", "width", "alpha")))
    confidence = np.concatenate([np.ones(len(seen)), planner.hidden_weight
                                 * (1.0 - 0.5 * uncertainty / max(planner.hidden_uncertainty, 1e-9))])
    hull = footprint_hull(done.points, observation.table_height)
    center = np.asarray(hull.center_mass, float)
    probe = SpaceProbe(hand, observation, space, region, planner.clearance, hidden_margin=planner.hidden_margin,
                       config=scene)
    return (pairs, center, torque_scale(done.points, center), planner.density * float(hull.volume), probe,
            confidence)
