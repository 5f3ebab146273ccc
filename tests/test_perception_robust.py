"""Pose estimation of a near-symmetric object (the mug) and per-model RANSAC generators (needs open3d).

The mug from the benchmark's camera (configs/perception.yaml: azimuth 30 deg, elevation 45 deg) at the
default depth noise: before near-symmetries and local refinement (`manigrasp.perception.recognition`) its
estimate came out turned 100-180 deg about its axis or upside down in 7 of 8 seeds (the body fits, the
handle decides). And one generator fed every model's RANSAC, so adding a model to the database changed
another model's estimate.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("open3d")

from manigrasp.objects import catalog  # noqa: E402
from manigrasp.perception.models import ModelDatabase, find_near_symmetries  # noqa: E402
from manigrasp.perception.pipeline import PerceptionConfig, perceive  # noqa: E402
from manigrasp.perception.setup import CameraSetup  # noqa: E402
from manigrasp.planners.base import resting_pose  # noqa: E402
from manigrasp.sim import build_tabletop  # noqa: E402

MUG = "025_mug"


@pytest.fixture(scope="module")
def mug():
    return catalog.build(catalog.shipped(MUG)).asset


@pytest.fixture(scope="module")
def mug_database(mug):
    return ModelDatabase.from_assets([mug])


def _view(asset, seed: int):
    """The asset upright at a seeded yaw on a table, the benchmark's first camera on it, the view's generator."""
    rng = np.random.default_rng([seed, 25])
    pose = resting_pose(asset)
    yaw = rng.uniform(0, 2 * math.pi)
    pose[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    table = build_tabletop(asset)
    table.place(pose)
    setup = CameraSetup()
    return table, setup.cameras(pose[:2, 3])[0], pose, rng, setup.perception()


@pytest.mark.slow
@pytest.mark.parametrize("seeds", [(0, 1, 2), (3, 4, 5)])
def test_the_mug_is_not_flipped_at_the_default_noise(mug, mug_database, seeds):
    """Rotation < 5 deg and translation < 1 cm for every seed (the old code: 134-180 deg off in most)."""
    errors = {}
    for seed in seeds:
        table, camera, pose, rng, config = _view(mug, seed)
        result = perceive(table, camera, mug_database, rng, config, object_name=MUG, true_pose=pose)
        errors[seed] = (round(result.errors.rotation_deg, 1), round(result.errors.translation_mm, 1),
                        round(result.estimate.score, 3))
    bad = {s: e for s, e in errors.items() if not (e[0] < 5.0 and e[1] < 10.0)}
    assert not bad, f"(rotation deg, translation mm, score) off: {bad}"


@pytest.mark.slow
def test_a_models_estimate_does_not_depend_on_the_other_models(mug, mug_database):
    """The mug's estimate is the same whether the database holds it alone or after the hammer, by recognition
    or as the known object (one generator fed every model's RANSAC: the hammer's draws moved the mug's)."""
    hammer = catalog.build(catalog.shipped("048_hammer")).asset
    both = ModelDatabase([ModelDatabase.from_assets([hammer]).get("048_hammer"), mug_database.get(MUG)],
                         mug_database.params)
    config = PerceptionConfig(restarts=1)
    estimates = {}
    for label, database, name in (("alone", mug_database, None), ("after the hammer", both, None),
                                  ("known", both, MUG)):
        table, camera, pose, _, _ = _view(mug, 2)
        result = perceive(table, camera, database, np.random.default_rng(11), config, object_name=name,
                          true_pose=pose)
        assert result.estimate.name == MUG
        estimates[label] = result.estimate.pose
    # Open3D's registration is reproducible to rounding only (two calls on one scene differ by 1e-16 at times).
    for label in ("after the hammer", "known"):
        np.testing.assert_allclose(estimates[label], estimates["alone"], rtol=0, atol=1e-9, err_msg=label)


def _cylinder(handle: bool, n: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    """Surface samples and outward normals of a closed cylinder (radius 4 cm, height 10 cm), with a
    2 x 2 x 4 cm block on its side if `handle`."""
    rng = np.random.default_rng(0)
    angle, z = rng.uniform(0, 2 * math.pi, n), rng.uniform(-0.05, 0.05, n)
    points = [np.stack([0.04 * np.cos(angle), 0.04 * np.sin(angle), z], axis=1)]
    normals = [np.stack([np.cos(angle), np.sin(angle), 0 * z], axis=1)]
    for sign in (1, -1):
        r, a = 0.04 * np.sqrt(rng.uniform(0, 1, n // 3)), rng.uniform(0, 2 * math.pi, n // 3)
        points.append(np.stack([r * np.cos(a), r * np.sin(a), np.full(n // 3, sign * 0.05)], axis=1))
        normals.append(np.tile([0.0, 0.0, sign], (n // 3, 1)))
    if handle:  # the block's outer face and its top and bottom
        y, z = rng.uniform(-0.01, 0.01, 300), rng.uniform(-0.02, 0.02, 300)
        points.append(np.stack([np.full(300, 0.06), y, z], axis=1))
        normals.append(np.tile([1.0, 0.0, 0.0], (300, 1)))
        for sign in (1, -1):
            x, y = rng.uniform(0.04, 0.06, 150), rng.uniform(-0.01, 0.01, 150)
            points.append(np.stack([x, y, np.full(150, sign * 0.02)], axis=1))
            normals.append(np.tile([0.0, 0.0, sign], (150, 1)))
    return np.concatenate(points), np.concatenate(normals)


def test_near_symmetries_of_a_cylinder_with_and_without_a_handle():
    """With a handle: turns about the axis map most of it onto itself (near-symmetries); without: every turn
    found is an exact symmetry, so none is kept. Which turns pass varies between runs: Open3D's ICP differs in the
    last bits from call to call (its parallel reductions, whatever OMP_NUM_THREADS says), and the ICP from a 30 deg
    start ended at 28.6 deg in one whole-suite run; a turn of 20 deg or more moves the 2 cm wide handle, 6 cm out,
    wholly off itself (its half-width is 9.5 deg)."""
    assert len(find_near_symmetries(*_cylinder(handle=False), voxel=0.005)) == 0
    near = find_near_symmetries(*_cylinder(handle=True), voxel=0.005)
    upright = near[:, 2, 2] > 0.999  # turns about z (the rest: the cylinder upside down)
    angles = np.degrees(np.arctan2(near[upright, 1, 0], near[upright, 0, 0]))
    assert upright.sum() >= 4 and np.all(np.abs(angles) >= 20.0), angles  # each puts the handle elsewhere
    assert np.all(np.abs(near[~upright, 2, 2] + 1.0) < 1e-3)
