"""Pose estimation and recognition on the shipped set from single noisy ray-cast views (needs open3d)."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("open3d")

from manigrasp.objects import catalog, recipes  # noqa: E402
from manigrasp.perception.models import ModelDatabase, find_symmetries  # noqa: E402
from manigrasp.perception.pipeline import CameraConfig, PerceptionConfig, perceive  # noqa: E402
from manigrasp.perception.registration import evaluate  # noqa: E402
from manigrasp.planners.base import resting_pose  # noqa: E402
from manigrasp.sim import build_tabletop  # noqa: E402

VIEWS = ((0.0, 35.0), (120.0, 50.0), (240.0, 60.0))  # (azimuth, elevation) [deg], distance 0.55 m, 320 x 240
RECOGNITION_VIEW = (30.0, 50.0)
# Measured by `find_symmetries` (see manigrasp/perception/models.py); the boxes, cans, bowl, ball,
# banana and the (symmetric) recipe mustard bottle map onto themselves under a turn, the rest do not.
ASYMMETRIC = {"025_mug", "035_power_drill", "037_scissors", "048_hammer"}


@pytest.fixture(scope="module")
def assets():
    return {name: catalog.build(catalog.shipped(name)).asset for name in recipes.names()}


@pytest.fixture(scope="module")
def database(assets):
    return ModelDatabase.from_assets(assets.values())


def _true_pose(asset, rng):
    """Upright resting pose, random yaw, up to 3 cm off the table centre."""
    pose = resting_pose(asset)
    yaw = rng.uniform(0, 2 * math.pi)
    pose[:3, :3] = [[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]]
    pose[:2, 3] = rng.uniform(-0.03, 0.03, 2)
    return pose


@pytest.mark.slow
def test_symmetric_objects_are_the_expected_ones(database):
    assert {m.name for m in database.models.values() if not m.symmetric} == ASYMMETRIC


def test_find_symmetries_of_a_box_and_an_l_shape():
    grid = np.stack(np.meshgrid(np.linspace(-0.05, 0.05, 11), np.linspace(-0.03, 0.03, 7), [-0.01, 0.01]),
                    axis=-1).reshape(-1, 3)
    assert len(find_symmetries(grid)) == 3  # 180 deg about x, y and z
    l_shape = np.concatenate([grid, grid[grid[:, 0] > 0.03] + [0, 0.06, 0]])
    assert len(find_symmetries(l_shape)) == 0


@pytest.mark.slow
def test_pose_from_one_noisy_view_on_the_shipped_set(assets, database):
    """Rotation < 5 deg and translation < 1 cm (symmetric objects: ADD-S < 5 mm and translation < 1 cm)
    for at least 80 % of (object, view) pairs."""
    outcomes = {}
    for i, name in enumerate(recipes.names()):
        table = build_tabletop(assets[name])
        for v, (azimuth, elevation) in enumerate(VIEWS):
            rng = np.random.default_rng([i, v])
            pose = _true_pose(assets[name], rng)
            table.place(pose)
            camera = CameraConfig(azimuth_deg=azimuth, elevation_deg=elevation).camera(pose[:2, 3])
            result = perceive(table, camera, database, rng, object_name=name, true_pose=pose)
            outcomes[name, v] = result.errors
    rate = np.mean([e.success for e in outcomes.values()])
    failed = {k: (round(e.rotation_deg, 1), round(e.translation_mm, 1), round(e.add_s_mm, 1))
              for k, e in outcomes.items() if not e.success}
    assert rate >= 0.8, f"success {rate:.0%}; failed (rot deg, trans mm, ADD-S mm): {failed}"


@pytest.mark.slow
def test_recognition_picks_the_right_model(assets, database):
    """Each shipped object alone on the table, one fixed view: the best-scoring model is the object."""
    wrong = {}
    for i, name in enumerate(recipes.names()):
        table = build_tabletop(assets[name])
        pose = resting_pose(assets[name])
        table.place(pose)
        camera = CameraConfig(azimuth_deg=RECOGNITION_VIEW[0], elevation_deg=RECOGNITION_VIEW[1]).camera([0, 0])
        result = perceive(table, camera, database, np.random.default_rng(100 + i), PerceptionConfig(restarts=3),
                          true_pose=pose)
        if result.recognized_as != name:
            wrong[name] = (result.recognized_as, round(result.estimate.score, 2))
        # features and registration run per model inside recognition: one stage, not "features 0 ms"
        assert list(result.timings) == ["depth", "cloud", "recognition"] and result.timings["recognition"] > 0
    assert not wrong, f"misrecognised (as, score): {wrong}"


def test_evaluate_leaves_the_source_untouched():
    """The textbook transformed the caller's cloud in place; `evaluate` must not."""
    rng = np.random.default_rng(0)
    source = rng.normal(size=(200, 3))
    copy = source.copy()
    shift = np.eye(4)
    shift[:3, 3] = [0.01, 0.0, 0.0]
    result = evaluate(source, source + [0.01, 0, 0], shift, 1e-6)
    np.testing.assert_array_equal(source, copy)
    assert result.fitness == pytest.approx(1.0)
