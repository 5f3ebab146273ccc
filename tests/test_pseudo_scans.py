"""The pseudo-scan generator (`manigrasp.objects.pseudoscan`, used by benchmarks/bench_pseudo_scans.py): deterministic
for a seed, close to the source surface, of the source's size, bumpy like a scan. Not of benchmark success rates."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from manigrasp.objects import recipes
from manigrasp.objects.pseudoscan import PseudoScanParams, bumpiness, pseudo_scan, sample_cloud

pytest.importorskip("open3d")

# small settings so that the test stays fast (the benchmark's defaults: 80000 points, depth 9, 16384 faces)
FAST = dict(n_points=12_000, depth=6, target_faces=2000)


@pytest.fixture(scope="module")
def box() -> trimesh.Trimesh:
    return recipes.build_mesh("009_gelatin_box")


@pytest.fixture(scope="module")
def scan(box) -> trimesh.Trimesh:
    return pseudo_scan(box, PseudoScanParams(seed=0, **FAST))


def test_deterministic_for_a_seed(box, scan):
    again = pseudo_scan(box, PseudoScanParams(seed=0, **FAST))
    assert np.array_equal(scan.vertices, again.vertices) and np.array_equal(scan.faces, again.faces)
    other = sample_cloud(box, PseudoScanParams(seed=1, **FAST))[0]
    assert not np.array_equal(sample_cloud(box, PseudoScanParams(seed=0, **FAST))[0][:100], other[:100])


def test_close_to_the_source_surface(box, scan):
    distance = np.abs(trimesh.proximity.signed_distance(box, scan.vertices[::4]))
    assert np.median(distance) < 0.0006  # noise 0.7 mm sd, averaged by the reconstruction
    assert distance.max() < 0.004  # edges rounded by the 4 mm blur, nothing far off


def test_size_and_character(box, scan):
    assert np.all(np.abs(scan.extents - box.extents) < 0.004)
    assert len(scan.faces) <= FAST["target_faces"] * 1.05
    assert len(scan.split(only_watertight=False)) == 1
    assert bumpiness(scan) > 0.0002  # millimetre bumps: a recipe's flat faces have none
    # rounded edges: the box's vertical edge at mid-height is cut off by more than a millimetre
    x, y = box.bounds[1, :2]
    z = box.bounds[1, 2] / 2
    corner_gap = np.min(np.linalg.norm(scan.vertices - [x, y, z], axis=1))
    assert corner_gap > 0.001


def test_noise_free_without_blur_is_tight(box):
    clean = pseudo_scan(box, PseudoScanParams(noise_m=0.0, blur_m=0.0, underside_drop=0.0, **FAST))
    distance = np.abs(trimesh.proximity.signed_distance(box, clean.vertices[::4]))
    assert np.median(distance) < 0.0003


def test_params_are_checked():
    with pytest.raises(ValueError, match="noise_m"):
        PseudoScanParams(noise_m=-1.0)
    with pytest.raises(ValueError, match="underside_drop"):
        PseudoScanParams(underside_drop=1.0)
