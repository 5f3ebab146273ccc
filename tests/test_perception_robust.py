"""Per-model RANSAC generators (needs open3d).

One generator fed every model's RANSAC, so adding a model to the database changed another model's estimate.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("open3d")

from manigrasp.objects import catalog  # noqa: E402
from manigrasp.perception.models import ModelDatabase  # noqa: E402
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
