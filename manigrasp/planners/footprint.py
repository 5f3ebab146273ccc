"""What a finger pad touches at a two-jaw pose: the surface under each pad's whole face, not one point.

A grasp pair is two points with their normals, but a pad is a patch (2 x 3 cm on
`parallel_jaw`). On a clean box face it touches everywhere and the grip resists
torsion about the grasp axis over the whole patch. On a scanned face that bulges
by millimetres, or near an edge (real or rounded by the scan) that part of the
pad overhangs, the pad touches only where the surface comes within its
compression: the pressure piles onto one end and the object pivots about it
under a far smaller torque. Two surface points with their normals cannot tell
these apart; the surface under the pad can.

Model (vectorised over poses; pure NumPy and trimesh ray casts):

1. Each pad's face (its geom's extent across the pads, x, and along the approach,
   z, in the TCP frame) is cut into `grid` cells. From each cell's centre on the
   open jaw a ray is cast along the closing direction; the distance to the
   first hit, minus the smallest of that pad, is the cell's gap g_i (inf: the
   cell overhangs the object).
2. Elastic foundation (K. L. Johnson, *Contact Mechanics*, 1985, section 4.3):
   pressed with the grip force the pad sinks by delta until sum max(0, delta -
   g_i) = n delta_0, where delta_0 is its compression on a flat face
   (`compression`, 1 mm: the compliant pad at the standard 35 N grip). Cell i
   carries f_i proportional to max(0, delta - g_i).
3. The object turns about the grasp axis through the point c of the pad plane
   that minimises T(c) = sum_i f_i |r_i - c| over both pads' cells (the
   weighted geometric median: there the friction forces' resultant vanishes,
   so a pure torque turns the object about it; Weiszfeld iterations).
   T(c) / (2 G) is the patch's torsion radius; on a flat face fully under both
   pads it is the uniform patch's mean |r| (0.0097 m for 2 x 3 cm).

4. Each pad's patch resists a torque across the grasp line with its pressure,
   up to its force times its kern (`patch_support`): a pad touching one row of
   cells (a bowl's rim under the pad's end) has none across the row, and the
   object tips about it. Each pad's tilt (`patch_tilt`) is that of the plane
   fitted to its cells' gaps, or, on one row, that of the faces it touches.

`PadFootprint.evaluate` returns, per pose, the ratio of that torsion radius to
the flat face's (1: seated like on a flat face; 0.5: half the torsion) and the
pivot c in the TCP frame (x, z) [m], where the planner puts the grasp line.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import mujoco
import numpy as np
import trimesh

from manigrasp.planners.collision import HandProbe
from manigrasp.planners.geometry import first_hits
from manigrasp.planners.pairs import Pairs

WEISZFELD_STEPS = 8  # relative error of the torsion < 0.1 % from the centroid start
DEFAULT_COMPRESSION = 0.001  # [m], the compliant pad's compression at the standard grip (hands.pads)
DEFAULT_GRID = (4, 6)  # cells across (x) and along (z) a pad face


class Seat(NamedTuple):
    """How two pads sit on the surface at k TCP poses (`PadFootprint.seat`).

    Attributes:
        ratio: (k,) torsion ratio (`patch_torsion`).
        pivot: (k, 2) the point the object turns about, (x, z) in the TCP frame [m].
        tilt: (k, 2) each pad's patch tilt [rad] (`patch_tilt`; NaN where the pad touches nothing).
        support: (k, 2, 2) how far each pad's centre of pressure can move along x and z [m] (`patch_support`).
    """

    ratio: np.ndarray
    pivot: np.ndarray
    tilt: np.ndarray
    support: np.ndarray


@dataclass(frozen=True)
class PadFootprint:
    """The two pad faces of a two-jaw hand in its TCP frame and the cells their surface is sampled at.

    Attributes:
        x: (2,) [min, max] of the pad faces across the pads (TCP x) [m].
        z: (2,) [min, max] of the pad faces along the approach (TCP z) [m].
        open_half_width: the open jaw's pad faces are this far from the TCP along y [m]; rays start there.
        grid: cells across (x) and along (z) each face.
        compression: the pad's compression on a flat face under the grip [m].
    """

    x: tuple[float, float]
    z: tuple[float, float]
    open_half_width: float
    grid: tuple[int, int] = DEFAULT_GRID
    compression: float = DEFAULT_COMPRESSION

    @property
    def cells(self) -> np.ndarray:
        """(n, 2) cell centres (x, z) in the TCP frame [m]."""
        nx, nz = self.grid
        xs = self.x[0] + (np.arange(nx) + 0.5) * (self.x[1] - self.x[0]) / nx
        zs = self.z[0] + (np.arange(nz) + 0.5) * (self.z[1] - self.z[0]) / nz
        gx, gz = np.meshgrid(xs, zs, indexing="ij")
        return np.stack([gx.ravel(), gz.ravel()], axis=1)

    def cast(self, mesh: trimesh.Trimesh, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gaps (k, 2, n) [m] of each cell of each pad (finger 1, 2; inf: off the object) and the inward normal of
        the face each cell's ray hits, in the TCP frame (k, 2, n, 3) (NaN: off the object), at TCP poses
        (k, 4, 4)."""
        cells = self.cells
        k, n = len(poses), len(cells)
        out = np.empty((k, 2, n))
        inward = np.full((k, 2, n, 3), np.nan)
        normals = np.asarray(mesh.face_normals, float)
        for finger, side in enumerate((-1.0, 1.0)):
            local = np.column_stack([cells[:, 0], np.full(n, side * self.open_half_width), cells[:, 1]])
            origins = np.einsum("kij,nj->kni", poses[:, :3, :3], local) + poses[:, None, :3, 3]
            direction = -side * poses[:, :3, 1]  # finger 1 closes along +y, finger 2 along -y
            faces, dist = first_hits(mesh, origins.reshape(-1, 3), np.repeat(direction, n, axis=0))
            out[:, finger] = dist.reshape(k, n)
            world = np.where((faces >= 0)[:, None], -normals[np.maximum(faces, 0)], np.nan).reshape(k, n, 3)
            inward[:, finger] = np.einsum("kji,knj->kni", poses[:, :3, :3], world)
        nearest = out.min(axis=2, keepdims=True)
        gaps = np.where(np.isfinite(out), out - np.where(np.isfinite(nearest), nearest, 0.0), np.inf)
        return gaps, np.where(np.isfinite(gaps)[..., None], inward, np.nan)

    def evaluate(self, mesh: trimesh.Trimesh, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Torsion ratio (k,) and pivot (k, 2) (x, z in the TCP frame [m]) at TCP poses (k, 4, 4) (module docstring)."""
        seat = self.seat(mesh, poses)
        return seat.ratio, seat.pivot

    def seat(self, mesh: trimesh.Trimesh, poses: np.ndarray) -> Seat:
        """How the pads sit at TCP poses (k, 4, 4) (`Seat`)."""
        if len(poses) == 0:
            return Seat(np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2, 2)))
        gaps, inward = self.cast(mesh, poses)
        weights = pressure(gaps, self.compression)
        ratio, pivot = patch_torsion(weights, self.cells)
        return Seat(ratio, pivot, patch_tilt(weights, gaps, self.cells, inward), patch_support(weights, self.cells))


def pressure(gaps: np.ndarray, compression: float) -> np.ndarray:
    """(..., n) share of a pad's force carried by each of its n cells, from their gaps (..., n) [m].

    Elastic foundation with equal cells: the pad sinks by delta with sum max(0, delta - g_i) = n * compression
    (a flat face: delta = compression, equal shares). All cells off the object: zeros.
    """
    g = np.sort(gaps, axis=-1)
    n = g.shape[-1]
    k = np.arange(1, n + 1)
    finite = np.isfinite(g)
    csum = np.cumsum(np.where(finite, g, 0.0), axis=-1)
    delta = (n * compression + csum) / k  # the sinking if exactly the k nearest cells touch
    nxt = np.concatenate([g[..., 1:], np.full(g.shape[:-1] + (1,), np.inf)], axis=-1)
    valid = finite & (delta <= nxt)
    first = np.argmax(valid, axis=-1)
    d = np.take_along_axis(delta, first[..., None], axis=-1)
    share = np.clip(d - np.where(np.isfinite(gaps), gaps, np.inf), 0.0, None)
    total = share.sum(axis=-1, keepdims=True)
    return np.where(total > 0, share / np.where(total > 0, total, 1.0), 0.0)


def patch_torsion(weights: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Torsion ratio (k,) and pivot (k, 2) of two pads whose cells at `cells` (n, 2) [m] carry the shares
    `weights` (k, 2, n) of their pad's force (`pressure` of the cells' gaps).

    The ratio is min_c sum f_i |r_i - c| over both pads (each pad's shares summing to 1) divided by the same
    on a flat face fully under both pads (module docstring, steps 2-3). A pad off the object: ratio 0.
    """
    points = np.concatenate([cells, cells])  # (2n, 2)
    flat = _median_torsion(np.full((1, len(points)), 1.0 / len(cells)), points)[0][0]
    torsion, pivot = _median_torsion(weights.reshape(len(weights), -1), points)  # over both pads' 2n cells
    seated = (weights.sum(axis=2) > 0).all(axis=1)
    return np.where(seated, torsion / flat, 0.0), pivot


def patch_tilt(weights: np.ndarray, gaps: np.ndarray, cells: np.ndarray,
               inward: np.ndarray | None = None) -> np.ndarray:
    """(k, 2) angle [rad] between the closing axis and the normal of the surface each pad touches, from the cell
    gaps (k, 2, n) at `cells` (n, 2) [m]: the slope of the plane fitted to the touched cells' gaps (least
    squares weighted by their loads `weights` (k, 2, n), `pressure` of the gaps). What a pad pressed flat on a
    patch feels, where a scan's per-point normals carry the scan's noise.

    Where the touched cells do not span a plane (fewer than three off one line: a pad on a strip, such as a
    thin rim or the pad's end on an edge), the gaps cannot tell the slope across the strip; the load-weighted
    mean of the touched faces' inward normals `inward` (k, 2, n, 3) in the TCP frame (`PadFootprint.cast`)
    gives the tilt there. Without `inward`: NaN there."""
    w = weights
    g = np.where(w > 0, gaps, 0.0)
    mean_x, mean_g = w @ cells, (w * g).sum(axis=-1)  # (k, 2, 2), (k, 2) (the shares sum to 1)
    dx = cells[None, None] - mean_x[..., None, :]  # (k, 2, n, 2)
    dg = g - mean_g[..., None]
    a = np.einsum("...n,...ni,...nj->...ij", w, dx, dx)  # (k, 2, 2, 2)
    b = np.einsum("...n,...ni,...n->...i", w, dx, dg)
    det = a[..., 0, 0] * a[..., 1, 1] - a[..., 0, 1] * a[..., 1, 0]
    scale = np.einsum("...ii->...", a) ** 2
    ok = det > 1e-6 * np.maximum(scale, 1e-300)
    det = np.where(ok, det, 1.0)
    sx = (a[..., 1, 1] * b[..., 0] - a[..., 0, 1] * b[..., 1]) / det
    sz = (a[..., 0, 0] * b[..., 1] - a[..., 1, 0] * b[..., 0]) / det
    fitted = np.arctan(np.hypot(sx, sz))
    if inward is None:
        return np.where(ok, fitted, np.nan)
    mean = np.einsum("...n,...ni->...i", w, np.where(w[..., None] > 0, inward, 0.0))  # (k, 2, 3)
    closing = np.array([1.0, -1.0])[None, :] * mean[..., 1]  # finger 1 closes along +y, finger 2 along -y
    norm = np.linalg.norm(mean, axis=-1)
    strip = np.where(norm > 0, np.arccos(np.clip(closing / np.maximum(norm, 1e-300), -1.0, 1.0)), np.nan)
    return np.where(ok, fitted, strip)


def patch_support(weights: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(k, 2, 2) [m] how far each pad's centre of pressure can move across (x) and along (z) its face before
    part of its patch lets go, from the cells' loads `weights` (k, 2, n) (`pressure`) at `cells` (n, 2) [m]:
    the kern of the patch.

    A pad pressed with force f on a patch that reaches distances d_i from its centre of pressure (loads w_i,
    `pressure`) resists a torque about the other axis of its face with its normal pressure, up to f e. For a
    uniform rectangle of length L the elastic foundation keeps every part in contact up to e = L / 6 (the
    kern: its moment of the pressure over its extreme distance); here e = sum w_i d_i^2 / (2 sum w_i |d_i|),
    which is that kern on a uniform patch (L / 6, and 4.9 mm on the 6 cells of a 3 cm face) and varies
    continuously with the loads, so a cell barely within reach adds little. A pad touching one row of cells (a
    thin rim, or its end on an edge) has none along the rows' normal: the object pivots about that line."""
    w = weights
    centre = w @ cells  # (k, 2, 2) the centres of pressure
    d = np.abs(cells[None, None] - centre[..., None, :])  # (k, 2, n, 2)
    second = np.einsum("...n,...ni->...i", w, d**2)
    first = np.einsum("...n,...ni->...i", w, d)
    return np.where(first > 1e-12, second / (2.0 * np.maximum(first, 1e-12)), 0.0)


def _median_torsion(weights: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """min over c of sum_i w_i |p_i - c| (k,) and the minimiser (k, 2): weighted geometric median (Weiszfeld),
    iterated only where the weights differ (equal weights on the symmetric grid: the centroid)."""
    total = np.maximum(weights.sum(axis=1, keepdims=True), 1e-300)
    c = weights @ points / total  # start at the centroid
    px, pz = points[:, 0], points[:, 1]
    moving = np.flatnonzero(np.ptp(weights, axis=1) > 1e-12 * total[:, 0])
    w0, cm = weights[moving], c[moving]
    for _ in range(WEISZFELD_STEPS):
        w = w0 / np.maximum(np.hypot(px - cm[:, :1], pz - cm[:, 1:]), 1e-6)
        cm = w @ points / np.maximum(w.sum(axis=1, keepdims=True), 1e-300)
    c[moving] = cm
    torsion = (weights * np.hypot(px - c[:, :1], pz - c[:, 1:])).sum(axis=1)
    return torsion, c


def pad_footprint(probe: HandProbe, grid: tuple[int, int] = DEFAULT_GRID,
                  compression: float = DEFAULT_COMPRESSION) -> PadFootprint | None:
    """The open hand's pad faces (its `Hand.pad_geoms`' bounding boxes in the TCP frame) in `probe`'s scene;
    None for a hand without pads."""
    model, data, scene = probe.scene.model, probe.scene.data, probe.scene
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(model.ngeom)]
    geoms = [g for pad in probe.hand.pad_geoms for g, name in enumerate(names)
             if name == pad or name.endswith("/" + pad)]
    if not geoms:
        return None
    probe.place(*[x[0] for x in probe.roots(np.eye(4)[None])])
    tcp = scene.tcp_pose()
    corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    points = []
    for g in geoms:
        local = model.geom_aabb[g, :3] + corners * model.geom_aabb[g, 3:]
        world = local @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
        points.append((world - tcp[:3, 3]) @ tcp[:3, :3])
    probe.restore()
    x, y, z = np.concatenate(points).T
    return PadFootprint((float(x.min()), float(x.max())), (float(z.min()), float(z.max())),
                        float(np.abs(y).min()), grid, compression)


def on_pivot(pairs: Pairs, poses: np.ndarray, pivot: np.ndarray) -> Pairs:
    """The pairs (k) moved across the grasp line, within the pad plane of their poses (k, 4, 4), so that the line
    passes through the pivot (k, 2) (x, z in the TCP frame [m]): the line the object turns about."""
    rot, origin = poses[:, :3, :3], poses[:, :3, 3]
    mid = np.einsum("kji,kj->ki", rot, 0.5 * (pairs.p + pairs.q) - origin)  # the contacts' midpoint in the TCP frame
    shift = rot[:, :, 0] * (pivot[:, :1] - mid[:, :1]) + rot[:, :, 2] * (pivot[:, 1:] - mid[:, 2:])
    return replace(pairs, p=pairs.p + shift, q=pairs.q + shift)
