"""Solid builders for the shipped YCB-like objects (used by `manigrasp.objects.recipes`).

Each builder takes keyword parameters in metres and returns a closed
`manifold3d.Manifold`, so unions and cuts stay watertight. The canonical frame
(bottom at z = 0, centred in x and y) is applied by the caller; a builder only
has to put the object in its natural resting pose with z up.

Conventions for elongated objects lying on a table: the long axis is x, the
width is y, the thickness is z.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from manifold3d import CrossSection, JoinType, Manifold, OpType

SEGMENTS = 64  # facets around a full circle; a multiple of 4 keeps round extents exact

Builder = Callable[..., Manifold]


def _union(*solids: Manifold) -> Manifold:
    return Manifold.batch_boolean(list(solids), OpType.Add)


def _block(lo: Sequence[float], hi: Sequence[float]) -> Manifold:
    """Axis-aligned block spanning corners `lo` to `hi` [m]."""
    size = np.subtract(hi, lo)
    return Manifold.cube(tuple(size)).translate(tuple(lo))


def _rounded_rect(width: float, depth: float, radius: float) -> CrossSection:
    """A `width` x `depth` rectangle with rounded corners, centred at the origin [m]."""
    core = CrossSection.square((width - 2 * radius, depth - 2 * radius), center=True)
    return core.offset(radius, JoinType.Round, circular_segments=SEGMENTS // 2)


def _ellipse(cx: float, cy: float, ax: float, ay: float) -> CrossSection:
    """Ellipse with centre (cx, cy) and semi-axes ax, ay [m]."""
    return CrossSection.circle(1.0, SEGMENTS).scale((ax, ay)).translate((cx, cy))


def _revolved(profile: Sequence[tuple[float, float]]) -> Manifold:
    """Revolve a closed (r, z) profile about the z axis."""
    return CrossSection([np.asarray(profile, dtype=float)]).revolve(SEGMENTS)


def box(size_m: Sequence[float]) -> Manifold:
    """A rectangular box of `size_m` = (x, y, z) [m]."""
    return Manifold.cube(tuple(size_m), center=True)


def rounded_box(size_m: Sequence[float], corner_radius_m: float) -> Manifold:
    """A box with vertical edges rounded by `corner_radius_m` (a rectangular can)."""
    x, y, z = size_m
    return _rounded_rect(x, y, corner_radius_m).extrude(z)


def cylinder(radius_m: float, height_m: float) -> Manifold:
    """An upright solid cylinder (a can)."""
    return Manifold.cylinder(height_m, radius_m, circular_segments=SEGMENTS)


def sphere(radius_m: float) -> Manifold:
    """A solid ball that rests on a small flat facet at its bottom pole.

    A revolved UV sphere with N = 16 latitude bands whose rings sit half a
    step off the poles, so both poles are flat discs (radius about r pi / 2N,
    3 mm for a tennis ball) instead of single vertices. Dropped on a table, a
    ball standing on a vertex tips over and rolls on, and one on a facet much
    smaller than that keeps rocking (MuJoCo has no rolling resistance at
    condim 4); with 16 bands it is at rest within 0.5 s. The profile is scaled
    by 1 / cos(pi / 2N) so the extents are exactly 2 r.
    """
    n = SEGMENTS // 4
    phi = -np.pi / 2 + (np.arange(n) + 0.5) * np.pi / n
    ring = radius_m / np.cos(np.pi / (2 * n)) * np.column_stack([np.cos(phi), np.sin(phi)])
    profile = [(0.0, ring[0, 1]), *map(tuple, ring), (0.0, ring[-1, 1])]
    return _revolved(profile)


def bottle(
    width_m: float,
    depth_m: float,
    height_m: float,
    shoulder_z_m: float,
    neck_z_m: float,
    cap_width_m: float,
) -> Manifold:
    """A squeeze bottle: elliptic body, shoulder, cap and a pointed nozzle.

    A profile revolved about z and then scaled to `width_m` (x) by `depth_m` (y).
    The body is straight up to `shoulder_z_m`, narrows to the cap at `neck_z_m`,
    and the cap tapers to a nozzle at `height_m`.
    """
    cap = cap_width_m / width_m  # profile radii are in units of the half-width
    rim = min(0.01, 0.1 * shoulder_z_m)  # rounded base edge [m]
    profile = [
        (0.0, 0.0),
        (0.9, 0.0),
        (1.0, rim),
        (1.0, shoulder_z_m),
        (0.8, shoulder_z_m + 0.5 * (neck_z_m - shoulder_z_m)),
        (cap, neck_z_m),
        (cap, height_m - 0.4 * (height_m - neck_z_m)),
        (0.35 * cap, height_m),
        (0.0, height_m),
    ]
    return _revolved(profile).scale((width_m / 2, depth_m / 2, 1.0))


def bowl(radius_m: float, height_m: float, wall_m: float, foot_radius_m: float) -> Manifold:
    """A concave bowl: a revolved shell whose outer wall curves from the foot to the rim."""
    t = np.linspace(0.0, 1.0, 17)
    z = height_m * t
    outer = foot_radius_m + (radius_m - foot_radius_m) * np.sin(0.5 * np.pi * t) ** 0.6
    inner = outer - wall_m
    keep = z > wall_m
    profile = [(0.0, 0.0), *zip(outer, z, strict=True)]
    profile += [(r, h) for r, h in zip(inner[::-1], z[::-1], strict=True) if h > wall_m]
    profile += [(float(inner[keep][0]) - wall_m, wall_m), (0.0, wall_m)]
    return _revolved(profile)


def mug(
    radius_m: float,
    height_m: float,
    wall_m: float,
    bottom_m: float,
    handle_x_m: float,
    handle_z_m: float,
    handle_radius_m: float,
    handle_tube_m: float,
) -> Manifold:
    """A mug: a cylindrical cup plus a ring handle whose opening is a through-hole.

    The handle is a torus (axis along y, centre at x = `handle_x_m`,
    z = `handle_z_m`, major radius `handle_radius_m`, tube radius
    `handle_tube_m`) fused to the outer wall; the cavity is cut afterwards, so
    nothing of the handle shows inside the cup.
    """
    torus = CrossSection.circle(handle_tube_m, SEGMENTS // 2).translate((handle_radius_m, 0.0))
    handle = torus.revolve(SEGMENTS).rotate((90.0, 0.0, 0.0))
    handle = handle.translate((handle_x_m, 0.0, handle_z_m))
    solid = _union(cylinder(radius_m, height_m), handle)
    cavity = Manifold.cylinder(height_m, radius_m - wall_m, circular_segments=SEGMENTS)
    return solid - cavity.translate((0.0, 0.0, bottom_m))


def banana(length_m: float, thickness_m: float, height_m: float, bend_deg: float) -> Manifold:
    """A curved spindle resting on its convex side: an elongated ellipsoid bent by `bend_deg`.

    The curve lies in the xz plane with both ends up, so the body rocks on its
    middle with the centre of mass straight above the contact (a stable rest).
    The result is scaled to `length_m` (x), `thickness_m` (y, the diameter) and
    `height_m` (z, the bounding height of the curved body).
    """
    half_angle = np.radians(bend_deg) / 2
    bend_radius = 0.5 * length_m / half_angle

    def bend(points: np.ndarray) -> np.ndarray:
        s, v, w = points[:, 2], points[:, 0], points[:, 1]  # s along the spine, in [-1, 1]
        phi = s * half_angle
        rho = bend_radius - v * thickness_m / 2
        # (x, y, z) = (along, -across, up): the sign keeps the outward winding
        return np.column_stack([rho * np.sin(phi), -w * thickness_m / 2, bend_radius - rho * np.cos(phi)])

    spindle = Manifold.sphere(1.0, circular_segments=SEGMENTS).warp_batch(bend)
    return fit_extents(spindle, (length_m, thickness_m, height_m))


def scissors(length_m: float, width_m: float, thickness_m: float, blade_thickness_m: float, rim_m: float) -> Manifold:
    """Scissors lying flat: two finger rings (two through-holes) and a tapered blade.

    The rings span x in [0, ~0.36 length] and the full `width_m` in y; they are
    `thickness_m` thick, the blade `blade_thickness_m`; `rim_m` is the ring rim width.
    """
    half = width_m / 2
    b = width_m / 4 + 0.002  # ring semi-axis in y; the rings overlap around y = 0
    cy = half - b
    ax_a, ax_b = 0.16 * length_m, 0.18 * length_m
    rings = _union_2d(
        _ellipse(ax_a, cy, ax_a, b),
        _ellipse(ax_b, -cy, ax_b, b),
        _rounded_rect(0.28 * length_m, 0.022, 0.005).translate((0.38 * length_m, 0.0)),
    )
    holes = _union_2d(_ellipse(ax_a, cy, ax_a - rim_m, b - rim_m), _ellipse(ax_b, -cy, ax_b - rim_m, b - rim_m))
    handle = (rings - holes).extrude(thickness_m)
    blade = CrossSection(
        [np.array([[0.45 * length_m, -0.011], [length_m, -0.001], [length_m, 0.001], [0.45 * length_m, 0.011]])]
    )
    return _union(handle, blade.extrude(blade_thickness_m))


def _union_2d(*sections: CrossSection) -> CrossSection:
    return CrossSection.batch_boolean(list(sections), OpType.Add)


def hammer(
    length_m: float,
    head_length_m: float,
    head_width_m: float,
    head_thickness_m: float,
    handle_width_m: float,
    handle_thickness_m: float,
) -> Manifold:
    """A claw hammer lying on its side: handle along x, head along y at the +x end.

    The head is a core block, a round striking face toward -y and a tapering
    claw toward +y; the handle is a rounded bar resting on the table.
    """
    x0 = length_m - head_width_m
    hw, ht, hl = head_width_m, head_thickness_m, head_length_m
    core = _block((x0, -0.02, 0.0), (length_m, 0.02, ht))
    face_r = 0.48 * min(hw, ht)
    face = Manifold.cylinder(hl / 2, face_r, circular_segments=SEGMENTS).rotate((90.0, 0.0, 0.0))
    face = face.translate((x0 + hw / 2, 0.0, ht / 2))
    claw = _union(
        _block((x0, 0.0, 0.0), (length_m, 0.02, ht)),
        _block((x0 + 0.2 * hw, hl / 2 - 0.002, 0.3 * ht), (length_m - 0.2 * hw, hl / 2, 0.6 * ht)),
    ).hull()
    grip = _rounded_rect(handle_thickness_m, handle_width_m, 0.3 * handle_thickness_m)
    handle = grip.extrude(x0 + 0.01).rotate((0.0, 90.0, 0.0))
    handle = handle.translate((0.0, 0.0, handle_thickness_m / 2))
    return _union(core, face, claw, handle)


def power_drill(
    length_m: float,
    height_m: float,
    body_radius_m: float,
    body_length_m: float,
    handle_x_m: float,
    handle_size_m: Sequence[float],
    battery_size_m: Sequence[float],
) -> Manifold:
    """A pistol-grip drill standing on its battery: body, chuck, handle, battery.

    Non-convex on purpose: the gap between body, handle and battery (where the
    fingers go) is open. Body axis along x at the top; the chuck points to +x.
    """
    axis_z = height_m - body_radius_m

    def barrel(x_from: float, x_to: float, radius: float) -> Manifold:
        tube = Manifold.cylinder(x_to - x_from, radius, circular_segments=SEGMENTS)
        return tube.rotate((0.0, 90.0, 0.0)).translate((x_from, 0.0, axis_z))

    collar_end = body_length_m + 0.3 * (length_m - body_length_m)
    hx, hy = handle_size_m
    bx, by, bz = battery_size_m
    return _union(
        barrel(0.0, body_length_m, body_radius_m),
        barrel(body_length_m - 0.005, collar_end, 0.7 * body_radius_m),
        barrel(collar_end - 0.005, length_m, 0.45 * body_radius_m),
        _block((handle_x_m, -hy / 2, bz - 0.005), (handle_x_m + hx, hy / 2, axis_z)),
        _block((0.0, -by / 2, 0.0), (bx, by / 2, bz)),
    )


def fit_extents(solid: Manifold, extents_m: Sequence[float]) -> Manifold:
    """Scale `solid` per axis so its bounding box is exactly `extents_m` [m]."""
    lo = np.array(solid.bounding_box()[:3])
    hi = np.array(solid.bounding_box()[3:])
    return solid.scale(tuple(np.asarray(extents_m, dtype=float) / (hi - lo)))


SHAPES: dict[str, Builder] = {
    "box": box,
    "rounded_box": rounded_box,
    "cylinder": cylinder,
    "sphere": sphere,
    "bottle": bottle,
    "bowl": bowl,
    "mug": mug,
    "banana": banana,
    "scissors": scissors,
    "hammer": hammer,
    "power_drill": power_drill,
}
