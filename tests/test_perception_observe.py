"""The benchmark's observation switch with the perception kinds, on a settled object in a real scene."""

from __future__ import annotations

import numpy as np
import pytest

from manigrasp.bench.observe import observe, observe_with_info
from manigrasp.errors import ConfigError

pytest.importorskip("open3d")


@pytest.fixture(scope="module")
def settled():
    from manigrasp.objects import catalog
    from manigrasp.protocol import settle_object
    from manigrasp.sim import build_scene

    asset = catalog.build(catalog.shipped("048_hammer")).asset
    scene = build_scene("parallel_jaw", asset)
    return asset, scene, settle_object(scene)


def test_estimated_pose_observation(settled):
    asset, scene, pose = settled
    obs, info = observe_with_info("estimated_pose", asset, pose, scene, seed=1)
    assert obs.kinds == ("mesh",) and obs.asset is asset
    assert not np.allclose(obs.object_pose, pose, atol=1e-9)  # an estimate, not the truth
    assert info.rotation_error_deg < 5.0 and info.translation_error_mm < 10.0
    assert info.backend == "raycast" and info.n_points > 100
    assert info.symmetric is False and 0.0 < info.add_mm < 10.0  # a hammer has no symmetry: judged by rotation


def test_a_trial_stores_what_its_pose_is_judged_by(settled, tmp_path):
    """The trial keeps the estimate's ADD and its object's symmetry, through the results store, so the report
    judges the pose as the pipeline does (`perception.metrics.pose_good`); a ground-truth trial keeps NaN."""
    from manigrasp.bench.config import NamedEntry
    from manigrasp.bench.store import ResultsStore, TrialKey
    from manigrasp.bench.trials import Group
    from manigrasp.bench.worker import Plan, run_trial
    from manigrasp.objects import catalog
    from manigrasp.protocol.result import Status
    from manigrasp.sim.config import SceneConfig

    asset, scene, pose = settled
    _, info = observe_with_info("estimated_pose", asset, pose, scene, seed=1)
    plan = Plan((), None, 0.1, pose, info)
    group = Group(catalog.shipped("048_hammer"), "parallel_jaw", NamedEntry("antipodal"), NamedEntry("standard"),
                  "estimated_pose", SceneConfig(), 1, seed=1, timeout_s=60.0)
    _, result = run_trial(group, 0, plan)
    assert result.status is Status.NO_GRASP and result.pose_symmetric == 0.0 and result.pose_add_mm == info.add_mm
    with ResultsStore(tmp_path / "results.sqlite") as store:
        store.add(TrialKey(asset.name, "parallel_jaw", "antipodal", "estimated_pose", "standard", 0), result)
        (_, back), = store.results()
    assert (back.pose_symmetric, back.pose_add_mm) == (0.0, info.add_mm)
    _, truth = run_trial(group, 0, Plan((), None, 0.1, pose, observe_with_info("ground_truth", asset, pose, scene)[1]))
    assert np.isnan(truth.pose_symmetric) and np.isnan(truth.pose_add_mm)


def test_point_cloud_observation(settled):
    asset, scene, pose = settled
    obs, info = observe_with_info("point_cloud", asset, pose, scene, seed=1)
    assert obs.kinds == ("points",) and obs.mesh is None
    assert np.all(obs.points[:, 2] > 0.0)  # table removed
    np.testing.assert_allclose(np.linalg.norm(obs.normals, axis=1), 1.0, atol=1e-6)
    np.testing.assert_array_equal(obs.object_pose[:3, :3], np.eye(3))  # no true orientation leaks
    again = observe("point_cloud", asset, pose, scene, seed=1)
    np.testing.assert_array_equal(again.points, obs.points)
    other = observe("point_cloud", asset, pose, scene, seed=2)
    assert not np.array_equal(other.points, obs.points)
    assert np.isnan(info.rotation_error_deg)


def test_observation_errors(settled):
    asset, scene, pose = settled
    with pytest.raises(ConfigError, match="ground_truth, estimated_pose, point_cloud"):
        observe("lidar", asset, pose, scene)
    with pytest.raises(ConfigError, match="needs the simulated scene"):
        observe("point_cloud", asset, pose)


def test_point_cloud_of_several_cameras(settled):
    """A second camera adds its points and its depth frame; the first camera's frame stays the same."""
    from manigrasp.perception.setup import CameraSetup

    asset, scene, pose = settled
    one, info_one = observe_with_info("point_cloud", asset, pose, scene, seed=1)
    two, info_two = observe_with_info("point_cloud", asset, pose, scene, seed=1, camera=CameraSetup(views=2))
    assert len(one.views) == 1 and len(two.views) == 2
    np.testing.assert_array_equal(two.views[0].depth, one.views[0].depth)
    np.testing.assert_array_equal(two.points[:len(one.points)], one.points)
    assert len(two.points) > len(one.points) and info_two.n_points == len(two.points)
    assert info_one.camera.record()["camera_views"] == 1 and info_two.camera.record()["camera_views"] == 2


def test_the_config_camera_reaches_every_group():
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.trials import groups

    config = parse_config({"objects": ["mug"], "observation": "point_cloud",
                           "camera": {"views": 3, "elevation_deg": 60}})
    assert [(g.camera.views, g.camera.elevation_deg) for g in groups(config)] == [(3, 60.0)]
    with pytest.raises(ConfigError, match="did you mean 'views'"):
        parse_config({"objects": ["mug"], "camera": {"view": 2}})


def test_a_trial_stores_its_camera_setup():
    """The setup's record is a set of result columns: it survives the results store's flat round trip."""
    from manigrasp.perception.setup import CameraSetup
    from manigrasp.protocol.result import Status, TrialResult

    record = CameraSetup(views=3, elevation_deg=60.0, distance=0.7).record()
    result = TrialResult(Status.SUCCESS, **record)
    back = TrialResult.from_flat(result.flat())
    assert (back.camera_views, back.camera_elevation_deg, back.camera_distance_m) == (3, 60.0, 0.7)
    assert back.camera_azimuth_deg == 30.0 and back.camera_noise_sigma_m == pytest.approx(0.0012 + 0.0019 * 0.3**2)


def test_the_cameras_look_with_the_hand_out_of_view():
    """The settle parks the open hand 0.6 m above the table: an Allegro there hid the whole mug from a camera at
    85 deg elevation and 0.8 m (0 object pixels). The cameras now see the scene with the hand lifted out of view,
    and the simulation's state is left as it was; the default camera, which never saw the hand, sees the same."""
    from manigrasp.bench.observe import hand_out_of_view
    from manigrasp.objects import catalog
    from manigrasp.perception.camera import capture
    from manigrasp.perception.setup import CameraSetup
    from manigrasp.protocol import settle_object
    from manigrasp.sim import build_scene

    scene = build_scene("allegro_right", catalog.build(catalog.shipped("025_mug")).asset)
    pose = settle_object(scene)
    scene.forward()
    state = scene.data.qpos.copy()
    view = hand_out_of_view(scene)
    assert np.array_equal(scene.data.qpos, state)
    mug = np.flatnonzero(scene.model.geom_bodyid == scene.object_body)
    hand = np.flatnonzero(scene.geom_is_hand)
    (high,) = CameraSetup(elevation_deg=85.0, distance=0.8).cameras(pose[:2, 3], 0.0)
    before, after = capture(scene.model, scene.data, high), capture(view.model, view.data, high)
    assert np.isin(before.geom, mug).sum() == 0 and np.isin(before.geom, hand).sum() > 10000
    assert np.isin(after.geom, mug).sum() > 500 and np.isin(after.geom, hand).sum() == 0
    (default,) = CameraSetup().cameras(pose[:2, 3], 0.0)
    assert np.array_equal(capture(scene.model, scene.data, default).geom, capture(view.model, view.data, default).geom)
    _, info = observe_with_info("point_cloud", catalog.build(catalog.shipped("025_mug")).asset, pose, scene,
                                camera=CameraSetup(elevation_deg=85.0, distance=0.8))
    assert info.n_points > 300  # the planner gets the mug's points (after noise and dropout at grazing angles)
