"""The pads' footprint (`planners.footprint`): the elastic-foundation pressure, the torsion of the patch a pad
really touches on flat, overhanging and curved faces, and the antipodal planner seating its pads with it."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from manigrasp import hands, planners
from manigrasp.objects import build_object, catalog
from manigrasp.planners.footprint import PadFootprint, pressure

# parallel_jaw's pads: 2 x 3 cm faces centred on the TCP, 4 cm from it on the open jaw
PADS = PadFootprint(x=(-0.01, 0.01), z=(-0.015, 0.015), open_half_width=0.04)


def tcp(position, closing=(1.0, 0.0, 0.0), approach=(0.0, 0.0, -1.0)) -> np.ndarray:
    """TCP pose (4, 4): y along `closing`, z along `approach`."""
    y, z = np.asarray(closing, float), np.asarray(approach, float)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([np.cross(y, z), y, z])
    pose[:3, 3] = position
    return pose


def mean_distance(a: float, b: float, centre: tuple[float, float] = (0.0, 0.0), n: int = 800) -> float:
    """Mean distance of an a x b rectangle [m] from `centre` (relative to the rectangle's centre): the uniform
    patch's torsion radius, integrated on a fine grid."""
    x = (np.arange(n) + 0.5) / n * a - a / 2 - centre[0]
    z = (np.arange(n) + 0.5) / n * b - b / 2 - centre[1]
    return float(np.hypot(x[:, None], z[None, :]).mean())


def test_pressure_is_the_elastic_foundation():
    # a flat face: equal shares; one cell 3 mm back of a 1 mm compression on two cells: it stays off
    assert pressure(np.zeros(6), 0.001) == pytest.approx(np.full(6, 1 / 6))
    assert pressure(np.array([0.0, 0.003]), 0.001) == pytest.approx([1.0, 0.0])
    # both touch: the pad sinks delta = 1 mm + mean gap = 1.25 mm; shares 1.25 : 0.75
    assert pressure(np.array([0.0, 0.0005]), 0.001) == pytest.approx([0.625, 0.375])
    # a cell off the object carries nothing; a pad off the object carries nothing anywhere
    assert pressure(np.array([0.0, np.inf]), 0.001) == pytest.approx([1.0, 0.0])
    assert pressure(np.full(3, np.inf), 0.001) == pytest.approx(np.zeros(3))


def test_a_flat_face_seats_the_whole_pad():
    box = trimesh.creation.box((0.05, 0.12, 0.12))
    ratio, pivot = PADS.evaluate(box, tcp((0.0, 0.0, 0.0))[None])
    assert ratio[0] == pytest.approx(1.0)
    assert pivot[0] == pytest.approx([0.0, 0.0], abs=1e-9)


def test_a_pad_half_over_an_edge_keeps_the_torsion_of_the_half_patch():
    # TCP at the box's top edge, approach down: the upper half of each pad (TCP z in [-1.5, 0] cm) overhangs
    box = trimesh.creation.box((0.05, 0.12, 0.12))
    ratio, pivot = PADS.evaluate(box, tcp((0.0, 0.0, 0.06))[None])
    expected = mean_distance(0.02, 0.015) / mean_distance(0.02, 0.03)  # 2 x 1.5 cm about its centre
    assert ratio[0] == pytest.approx(expected, rel=0.03)
    assert pivot[0] == pytest.approx([0.0, 0.0075], abs=5e-4)  # the touching half's centre, TCP frame


def test_a_pad_off_the_object_holds_nothing():
    box = trimesh.creation.box((0.05, 0.12, 0.12))
    ratio, _ = PADS.evaluate(box, tcp((0.0, 0.0, 0.2))[None])
    assert ratio[0] == 0.0


@pytest.mark.parametrize("degrees", [0.0, 3.0, 8.0])
def test_the_patch_tilt_is_the_faces_tilt_under_the_pad(degrees):
    # the box turned about the approach axis: both faces meet the jaws tilted by that angle, whatever the pad
    # sinks into; a scan's per-point normals would add their noise to it
    box = trimesh.creation.box((0.05, 0.12, 0.12))
    box.apply_transform(trimesh.transformations.rotation_matrix(np.radians(degrees), [0.0, 0.0, 1.0]))
    tilt = PADS.seat(box, tcp((0.0, 0.0, 0.0))[None]).tilt
    assert np.degrees(tilt[0]) == pytest.approx([degrees, degrees], abs=0.05)


def test_a_flat_face_supports_the_pad_to_the_uniform_patch_kern():
    # a pad flat on a face resists a torque about either axis of its face with its pressure until its centre of
    # pressure reaches the kern, L / 6 of its side (the discrete 4 x 6 cells: 3.1 and 4.9 mm)
    box = trimesh.creation.box((0.05, 0.12, 0.12))
    support = PADS.seat(box, tcp((0.0, 0.0, 0.0))[None]).support[0]
    assert support[:, 0] == pytest.approx(0.02 / 6, rel=0.07)
    assert support[:, 1] == pytest.approx(0.03 / 6, rel=0.07)


@pytest.mark.parametrize("degrees", [0.0, 8.0])
def test_a_pad_on_a_strip_pivots_about_it_and_feels_the_strips_tilt(degrees):
    # a thin plate's edge (a bowl's rim) under one row of the 5 mm cells, its faces turned by `degrees` about the
    # row: the gaps along one row cannot tell that slope, the faces the rays hit can; and the pad's pressure has
    # no lever across the row (the object pivots about it), all of it along the row
    plate = trimesh.creation.box((0.01, 0.12, 0.004))
    plate.apply_transform(trimesh.transformations.rotation_matrix(np.radians(degrees), [0.0, 1.0, 0.0]))
    plate.apply_translation([0.0, 0.0, 0.0025])  # centred on the row of cells 2.5 mm off the TCP
    seat = PADS.seat(plate, tcp((0.0, 0.0, 0.0))[None])
    assert seat.ratio[0] > 0  # touching
    assert np.degrees(seat.tilt[0]) == pytest.approx([degrees, degrees], abs=0.05)
    assert seat.support[0, :, 1] == pytest.approx([0.0, 0.0], abs=1e-12)
    assert seat.support[0, :, 0] == pytest.approx(PADS.seat(trimesh.creation.box((0.05, 0.12, 0.12)),
                                                             tcp((0.0, 0.0, 0.0))[None]).support[0, :, 0])


def test_the_more_a_face_curves_under_the_pad_the_less_torsion():
    # upright cylinders squeezed across their axis: the face curves away across the pad's 2 cm width
    ratios = []
    for radius in (0.5, 0.04, 0.02, 0.012):
        cylinder = trimesh.creation.cylinder(radius=radius, height=0.1, sections=256)
        ratio, pivot = PADS.evaluate(cylinder, tcp((0.0, 0.0, 0.0))[None])
        assert pivot[0] == pytest.approx([0.0, 0.0], abs=2e-4)  # symmetric
        ratios.append(ratio[0])
    assert ratios[0] == pytest.approx(1.0, abs=0.01)
    assert ratios[0] > ratios[1] > ratios[2] > ratios[3]
    # a 1.2 cm radius: the outer columns sit 2.6 mm back; the load is on the central strip of the pad
    assert ratios[3] < 0.9


def bulged_box(half=(0.025, 0.06, 0.06), bulge=0.004, n=25) -> trimesh.Trimesh:
    """A box whose +-x faces bulge out by `bulge` [m] at their centre (a scanned carton's faces), watertight."""
    s = np.linspace(-1.0, 1.0, n)
    u, v = np.meshgrid(s, s)
    bump = bulge * (1 - u**2) * (1 - v**2)
    points = [np.column_stack([sign * (half[0] + bump.ravel()), half[1] * u.ravel(), half[2] * v.ravel()])
              for sign in (-1, 1)]
    return trimesh.convex.convex_hull(np.vstack(points))


@pytest.mark.slow
def test_the_planner_seats_its_pads_on_a_bulged_face(jaw, tmp_path):
    mesh = bulged_box()
    asset = build_object(mesh, name="footprint_test_bulged", mass=0.3, cache_root=tmp_path).asset
    obs = planners.Observation.from_asset(asset)
    world = obs.world_mesh()
    seated = {}
    for on in (False, True):
        result = planners.plan(planners.load("antipodal", pad_footprint=on), obs, jaw, 20, np.random.default_rng(0))
        assert len(result.candidates) == 20
        ratio, _ = PADS.evaluate(world, np.array([c.pose for c in result.candidates]))
        seated[on] = ratio
    # with the footprint, the pads sit on more of the face (where the bulge is flattest), never less on average
    assert seated[True].mean() > seated[False].mean() + 0.02
    assert seated[True].min() >= seated[False].min()


def test_the_planner_holds_a_bowl_by_the_wall_not_the_pads_ends():
    # a bowl held by its 4 mm rim hangs 8 cm off the grasp line: what holds it is the pads' pressure along the
    # wall. Poses whose pads only reach the rim with their ends (one row of cells) turn it in the grip (the
    # footprint without `patch_support` chose only those: 0 of 20 held on the standard protocol)
    jaw = hands.load("parallel_jaw")
    obs = planners.Observation.from_asset(catalog.build(catalog.shipped("024_bowl")).asset)
    result = planners.plan(planners.load("antipodal"), obs, jaw, 10, np.random.default_rng(0))
    assert len(result.candidates) == 10
    world = obs.world_mesh()
    poses = np.array([c.pose for c in result.candidates])
    assert np.all(np.array([c.width for c in result.candidates]) < 0.01)  # on the rim
    support = PADS.seat(world, poses).support
    assert support[:, :, 1].min() > 0.002  # every pad bears on the wall (a uniform patch over 12 mm: 2 mm)
