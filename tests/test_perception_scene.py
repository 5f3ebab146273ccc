"""Perception's scene comes from `manigrasp.sim`, and `perceive` takes one validated config.

The reference is the model `perception.pipeline.tabletop` compiled by hand before the scene moved to
`sim` (a table box with its top at z = 0 and the object attached under ``object/``), rebuilt here
from its old code: the same seeds must give the same depth frame, cloud and pose through the new path.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
import trimesh

from manigrasp.errors import ConfigError
from manigrasp.objects import build_object
from manigrasp.perception.noise import DepthNoise
from manigrasp.perception.pipeline import CameraConfig, PerceptionConfig, object_geoms, observe_cloud
from manigrasp.perception.registration import RegistrationParams
from manigrasp.sim import build_tabletop

BOX = (0.05, 0.03, 0.12)  # [m]


@pytest.fixture(scope="module")
def box(tmp_path_factory: pytest.TempPathFactory):
    return build_object(trimesh.creation.box(BOX), name="box", mass=0.2,
                        cache_root=tmp_path_factory.mktemp("perception_scene")).asset


def _hand_built(asset) -> SimpleNamespace:
    """The old `perception.pipeline.tabletop`: its own MjSpec, the object found as "object/object"."""
    spec = mujoco.MjSpec()
    half = np.array([0.4, 0.4, 0.02])
    spec.worldbody.add_geom(name="table/top", type=mujoco.mjtGeom.mjGEOM_BOX, size=half, pos=[0, 0, -half[2]])
    child = mujoco.MjSpec.from_file(str(asset.mjcf_path))
    spec.worldbody.add_frame().attach_body(child.body("object"), "object/", "")
    model = spec.compile()
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "object/object")
    return SimpleNamespace(model=model, data=mujoco.MjData(model), object_body=body)


def _pose(yaw_deg: float) -> np.ndarray:
    yaw = math.radians(yaw_deg)
    pose = np.eye(4)
    pose[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    pose[:3, 3] = [0.01, -0.02, BOX[2] / 2]
    return pose


def _place(scene, pose: np.ndarray) -> None:
    """Place the object of a hand-built model as the old `Tabletop.place` did."""
    from manigrasp.geometry import mat_to_quat

    adr = scene.model.jnt_qposadr[scene.model.body_jntadr[scene.object_body]]
    scene.data.qpos[adr:adr + 3], scene.data.qpos[adr + 3:adr + 7] = pose[:3, 3], mat_to_quat(pose[:3, :3])
    mujoco.mj_forward(scene.model, scene.data)


def test_the_sim_tabletop_is_the_hand_built_model(box) -> None:
    old, new = _hand_built(box), build_tabletop(box)
    assert (old.model.ngeom, old.model.nbody, old.object_body) == (new.model.ngeom, new.model.nbody, new.object_body)
    np.testing.assert_array_equal(object_geoms(old), object_geoms(new))
    for name in ("geom_type", "geom_size", "geom_pos", "geom_quat", "geom_group", "geom_bodyid", "body_mass"):
        np.testing.assert_array_equal(getattr(old.model, name), getattr(new.model, name), err_msg=name)


@pytest.mark.parametrize("yaw_deg", [0.0, 37.0])
def test_same_seed_gives_the_same_frame_and_cloud_as_the_hand_built_model(box, yaw_deg: float) -> None:
    pytest.importorskip("open3d")
    old, new = _hand_built(box), build_tabletop(box)
    _place(old, _pose(yaw_deg))
    new.place(_pose(yaw_deg))
    camera = CameraConfig(azimuth_deg=30.0, elevation_deg=45.0).camera(_pose(yaw_deg)[:2, 3])
    config = PerceptionConfig()
    (old_image, old_cloud), (new_image, new_cloud) = (
        observe_cloud(scene, camera, np.random.default_rng(7), config) for scene in (old, new))
    np.testing.assert_array_equal(old_image.depth, new_image.depth)
    np.testing.assert_array_equal(old_cloud.points, new_cloud.points)
    np.testing.assert_array_equal(old_cloud.normals, new_cloud.normals)
    assert len(new_cloud) > 500  # two side faces and the top of the box are in view


def test_perceive_on_the_sim_tabletop_equals_perceive_on_the_hand_built_model(box) -> None:
    """The whole view (cloud, estimated pose) is the same through both scenes with the same generator."""
    pytest.importorskip("open3d")
    from manigrasp.perception.models import ModelDatabase
    from manigrasp.perception.pipeline import perceive

    database = ModelDatabase.from_assets([box])
    pose = _pose(20.0)
    old, new = _hand_built(box), build_tabletop(box)
    _place(old, pose)
    new.place(pose)
    camera = CameraConfig().camera(pose[:2, 3])
    first, second = (perceive(scene, camera, database, np.random.default_rng(3), PerceptionConfig(restarts=2),
                              object_name="box", true_pose=pose) for scene in (old, new))
    np.testing.assert_array_equal(first.cloud.points, second.cloud.points)
    # Open3D's registration is reproducible to rounding only (two calls on one scene differ by 1e-16 at times).
    np.testing.assert_allclose(first.estimate.pose, second.estimate.pose, rtol=0, atol=1e-12)
    assert second.errors.add_s_mm < 20.0  # and the box is found, roughly (one noisy view, two restarts)
    assert list(second.timings) == ["depth", "cloud", "features", "registration"]
    assert all(t > 0 for t in second.timings.values())


@pytest.mark.parametrize(("fields", "match"), [
    ({"restarts": 0}, "restarts"), ({"restarts": 2.5}, "restarts"), ({"threshold": 1.5}, "threshold"),
    ({"backend": "lidar"}, "backend"), ({"noise": {"sigma_0": 0.001}}, "DepthNoise"),
    ({"registration": 0.005}, "RegistrationParams"), ({"table_height": math.nan}, "table_height"),
])
def test_perception_config_refuses_bad_fields(fields: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        PerceptionConfig(**fields)


def test_perception_config_holds_what_it_is_given() -> None:
    config = PerceptionConfig(noise=DepthNoise(sigma_0=0.0), registration=RegistrationParams(voxel=0.004),
                              restarts=2, threshold=0.5, backend="auto", table_height=0.1)
    assert (config.restarts, config.threshold, config.backend, config.table_height) == (2, 0.5, "auto", 0.1)
    with pytest.raises(AttributeError):
        config.restarts = 3  # type: ignore[misc]  # frozen
