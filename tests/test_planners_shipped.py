"""Planners on every shipped object: antipodal with `parallel_jaw`, power with a dexterous hand.

The shipped set is built once per session (the CoACD cache makes a repeat
build take milliseconds). Every returned candidate of the checked objects is
tested for collisions independently, in a fresh standard scene.
"""

from __future__ import annotations

import numpy as np
import pytest

from manigrasp import hands, planners
from manigrasp.objects import catalog, recipes
from manigrasp.objects.asset import ObjectAsset
from manigrasp.planners.nms import suppress
from tests.helpers import assert_collision_free

pytestmark = pytest.mark.slow  # plans on every shipped object (the power planner alone ~30 s)

# Objects the 8 cm jaw (7.5 cm with its margin) cannot hold from their resting pose: every horizontal
# width exceeds it (can 10.2 cm, tuna can 8.5 cm, wood block 8.5 cm) or the only fitting width is the
# height, whose lower face lies on the table (pudding box: 11 x 8.9 x 3.5 cm). The test certifies it.
TOO_WIDE = {"002_master_chef_can", "007_tuna_fish_can", "008_pudding_box", "036_wood_block"}
USABLE_WIDTH = 0.075  # [m]: parallel_jaw's 8 cm less the planner's 5 mm width margin
MIN_ANTIPODAL = 20
MIN_POWER = 10
DEXTEROUS = "inspire_right"
COLLISION_CHECKED = ("025_mug", "035_power_drill", "011_banana", "x01_phone_box", "009_gelatin_box", "037_scissors")


@pytest.fixture(scope="session")
def shipped_observations() -> dict[str, planners.Observation]:
    assets: dict[str, ObjectAsset] = {n: catalog.build(catalog.shipped(n)).asset for n in recipes.names()}
    return {name: planners.Observation.from_asset(asset) for name, asset in assets.items()}


@pytest.fixture(scope="session")
def antipodal_results(shipped_observations) -> dict[str, planners.PlanResult]:
    hand, planner = hands.load("parallel_jaw"), planners.load("antipodal")
    return {name: planners.plan(planner, obs, hand, 100, np.random.default_rng(0))
            for name, obs in shipped_observations.items()}


def test_every_shipped_object_gets_antipodal_grasps(antipodal_results):
    counts = {name: len(r.candidates) for name, r in antipodal_results.items()}
    for name, count in counts.items():
        if name in TOO_WIDE:
            assert count == 0, f"{name}: {count} grasps on an object wider than the jaw"
        else:
            assert count >= MIN_ANTIPODAL, f"{name}: only {count} antipodal grasps ({counts})"
    for result in antipodal_results.values():
        poses = np.array([c.pose for c in result.candidates]).reshape(-1, 4, 4)
        assert len(suppress(poses, symmetric=True)) == len(poses), "two candidates within 3 cm and 30 degrees"
        for c in result.candidates:
            assert c.width <= USABLE_WIDTH + 1e-9 and c.approach[2] <= 1e-9 and np.isfinite(c.score)


def test_the_dense_pass_finds_more_distinct_grasps_on_a_thin_object(shipped_observations, antipodal_results):
    # The phone box (0.78 cm thick) has one narrow band of grasps: without step 6 the ranked walk keeps few.
    hand, obs = hands.load("parallel_jaw"), shipped_observations["x01_phone_box"]
    walk_only = planners.plan(planners.load("antipodal", dense_below=0), obs, hand, 100, np.random.default_rng(0))
    assert len(walk_only.candidates) < MIN_ANTIPODAL <= len(antipodal_results["x01_phone_box"].candidates)


@pytest.mark.parametrize("name", sorted(TOO_WIDE))
def test_the_objects_without_grasps_are_wider_than_the_jaw(name, shipped_observations):
    """Every horizontal width of the resting object exceeds the jaw; a fitting height has its face on the table."""
    obs = shipped_observations[name]
    points = obs.world_mesh().convex_hull.vertices
    angles = np.radians(np.arange(0.0, 180.0, 0.5))
    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    projected = points @ directions.T
    horizontal = projected.max(axis=0) - projected.min(axis=0)
    assert horizontal.min() > USABLE_WIDTH, f"{name}: a horizontal width of {horizontal.min():.4f} m fits"
    height = points[:, 2].max() - points[:, 2].min()
    assert height > USABLE_WIDTH or points[:, 2].min() - obs.table_height < 1e-3


@pytest.mark.parametrize("name", COLLISION_CHECKED)
def test_shipped_antipodal_grasps_do_not_collide(name, antipodal_results, shipped_observations):
    assert_collision_free(shipped_observations[name], hands.load("parallel_jaw"), antipodal_results[name].candidates)


@pytest.fixture(scope="session")
def power_results(shipped_observations) -> dict[str, planners.PlanResult]:
    hand, planner = hands.load(DEXTEROUS), planners.load("power")
    return {name: planners.plan(planner, obs, hand, MIN_POWER, np.random.default_rng(0))
            for name, obs in shipped_observations.items()}


def test_every_shipped_object_gets_power_grasps(power_results):
    counts = {name: len(r.candidates) for name, r in power_results.items()}
    assert all(count >= MIN_POWER for count in counts.values()), counts
    for result in power_results.values():
        for c in result.candidates:
            assert len(c.contacts) >= 2 and c.approach[2] <= 1e-9 and 0.0 <= c.score <= 1.0


@pytest.mark.parametrize("name", COLLISION_CHECKED[:3])
def test_shipped_power_grasps_do_not_collide(name, power_results, shipped_observations):
    assert_collision_free(shipped_observations[name], hands.load(DEXTEROUS), power_results[name].candidates)
