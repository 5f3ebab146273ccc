"""The antipodal planner's completion path on bare point clouds (``completion="point_symmetry"``): one noisy,
partial view of a shipped mesh, normals by PCA. (The default ``"free_space"`` path needs the depth views:
tests/test_planners_partial.py.)

Clouds are made here, without rendering: area-uniform samples (~2 mm apart)
of the true mesh that face a camera 0.55 m away at 45 degrees elevation and
are not occluded from it, 1 mm Gaussian noise, the table (4 mm) removed,
normals by the package's one estimate (`perception.cloud.estimate_normals`, here
Open3D's PCA of the 20 nearest points) turned toward the camera.
Grasps are checked against the true object: contacts on a box's faces,
collisions in a fresh MuJoCo scene, and lifts under the `lift` protocol.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from manigrasp import planners
from manigrasp.objects import catalog
from manigrasp.perception.cloud import estimate_normals
from manigrasp.planners.cloud import complete
from manigrasp.protocol import PROTOCOLS, settle_object
from manigrasp.protocol.result import Status
from manigrasp.sim import build_scene
from tests.helpers import TALL_BOX as BOX
from tests.helpers import assert_collision_free

pytest.importorskip("open3d", reason="normals are estimated with the perception extra (open3d)")

SPACING = 0.002  # [m]
NOISE = 0.001  # [m]
NEIGHBOURS = 20  # points in the neighbourhood of a normal
TABLE_MARGIN = 0.004  # [m]


def SYMMETRY():  # noqa: N802 (reads as a constant)
    """The antipodal planner completing the cloud by point symmetry."""
    return planners.load("antipodal", completion="point_symmetry")


def camera_at(azimuth_deg: float, distance: float = 0.55, elevation_deg: float = 45.0,
              target_height: float = 0.05) -> np.ndarray:
    """(3,) a camera position on a sphere around the table point above the origin [m]."""
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    return np.array([distance * np.cos(el) * np.cos(az), distance * np.cos(el) * np.sin(az),
                     target_height + distance * np.sin(el)])


def view_cloud(mesh: trimesh.Trimesh, camera: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) and estimated normals (n, 3) of `mesh` (world frame) as seen from `camera` (module docstring)."""
    points, faces = trimesh.sample.sample_surface(mesh, int(mesh.area / SPACING**2), seed=int(rng.integers(2**31)))
    to_camera = camera - points
    to_camera /= np.linalg.norm(to_camera, axis=1, keepdims=True)
    facing = np.einsum("ij,ij->i", mesh.face_normals[faces], to_camera) > 0.2
    visible = facing & ~mesh.ray.intersects_any(points + 1e-4 * to_camera, to_camera)
    points = points[visible] + rng.normal(0.0, NOISE, (int(visible.sum()), 3))
    points = points[points[:, 2] > TABLE_MARGIN]
    return points, estimate_normals(points, camera, radius=None, max_nn=NEIGHBOURS)


def cloud_observation(truth: planners.Observation, azimuth_deg: float, seed: int) -> planners.Observation:
    points, normals = view_cloud(truth.world_mesh(), camera_at(azimuth_deg), np.random.default_rng(seed))
    return planners.Observation(object_pose=np.eye(4), points=points, normals=normals)


@pytest.fixture(scope="module")
def box_truth(tall_box_asset) -> planners.Observation:
    return planners.Observation.from_asset(tall_box_asset)


def test_the_synthetic_view_is_partial_and_noisy(box_truth):
    obs = cloud_observation(box_truth, 30.0, 0)
    local = obs.points - box_truth.center_of_mass
    assert np.all(local[:, 0] > -BOX[0] / 2 - 0.005), "the far x face is hidden from a camera on the +x side"
    assert np.all(local[:, 1] > -BOX[1] / 2 - 0.005), "the far y face is hidden"
    off_face = np.min(np.abs(np.abs(local) - np.array(BOX) / 2), axis=1)
    assert 0.0005 < np.median(off_face) < 0.002
    assert np.median(np.einsum("ij,ij->i", obs.normals, camera_at(30.0) - obs.points)) > 0


@pytest.mark.parametrize("azimuth", [30.0, 120.0, 250.0])
def test_box_cloud_widths_are_the_box_dimensions_contacts_on_opposite_faces(box_truth, jaw, azimuth):
    obs = cloud_observation(box_truth, azimuth, 1)
    result = planners.plan(SYMMETRY(), obs, jaw, 20, np.random.default_rng(0))
    assert len(result.candidates) >= 10
    half = np.array(BOX) / 2
    for c in result.candidates:
        local = c.contacts - box_truth.center_of_mass
        on_face = np.abs(np.abs(local) - half) < 0.002  # (2, 3)
        axis = np.flatnonzero(on_face[0] & on_face[1] & (np.sign(local[0]) != np.sign(local[1])))
        assert len(axis) == 1, f"contacts {np.round(1000 * local, 1).tolist()} mm are not on opposite faces"
        k = axis[0]
        assert k in (0, 1), "the 12 cm dimension does not fit the 8 cm jaw"
        assert abs(c.width - BOX[k]) < 0.002, f"width {1000 * c.width:.1f} mm across a {1000 * BOX[k]:.0f} mm box"
        assert abs(c.closing[k]) > 0.95


def test_the_completion_centre_is_the_box_centre(box_truth):
    for azimuth in (30.0, 200.0):
        obs = cloud_observation(box_truth, azimuth, 2)
        done = complete(obs.points, obs.normals, 0.0, "point_symmetry")
        assert np.linalg.norm(done.center - box_truth.center_of_mass) < 0.0015
        without = complete(obs.points, obs.normals, 0.0, "none")
        assert len(without.points) == len(obs.points) < len(done.points)


def test_without_completion_a_single_box_view_has_no_antipodal_pair(box_truth, jaw):
    """The camera sees the +x, +y and top faces: no two opposite faces, so no grasp without the completion."""
    obs = cloud_observation(box_truth, 30.0, 1)
    result = planners.plan(planners.load("antipodal", completion="none"), obs, jaw, 10, np.random.default_rng(0))
    assert result.candidates == ()


def test_the_mesh_takes_priority_over_the_cloud(box_truth, jaw):
    cloud = cloud_observation(box_truth, 30.0, 3)
    both = planners.Observation(object_pose=box_truth.object_pose, mesh=box_truth.mesh, asset=box_truth.asset,
                                points=cloud.points + [1.0, 0.0, 0.0], normals=cloud.normals)
    planner = planners.load("antipodal")
    assert planners.accepted_kinds(planner) == ("mesh", "points")
    from_both = planners.plan(planner, both, jaw, 10, np.random.default_rng(0)).candidates
    from_mesh = planners.plan(planner, box_truth, jaw, 10, np.random.default_rng(0)).candidates
    assert np.array_equal([c.pose for c in from_both], [c.pose for c in from_mesh])
    assert planners.accepted_kinds(planners.load("power")) == ("mesh",)


@pytest.mark.parametrize(("name", "azimuth"), [("005_tomato_soup_can", 30.0), ("004_sugar_box", 200.0)])
def test_cloud_grasps_are_collision_free_and_lift_the_true_object(jaw, name, azimuth):
    asset = catalog.build(catalog.shipped(name)).asset
    scene = build_scene(jaw, asset)
    rest = settle_object(scene)
    truth = planners.Observation.from_asset(asset, rest)
    obs = cloud_observation(truth, azimuth, 4)
    top = planners.plan(SYMMETRY(), obs, jaw, 5, np.random.default_rng(0)).candidates
    assert len(top) == 5
    assert_collision_free(truth, jaw, top)
    lift = PROTOCOLS.load("lift")
    statuses = [lift.run(scene, c, np.random.default_rng(i), object_pose=rest).status for i, c in enumerate(top)]
    assert statuses.count(Status.SUCCESS) >= 4, statuses
