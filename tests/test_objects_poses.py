"""Stable resting poses: a box rests most probably on its largest face; a scene can start there."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from manigrasp.errors import MeshError
from manigrasp.objects import build_object
from manigrasp.objects.poses import stable_poses
from manigrasp.protocol.settle import settle_object
from manigrasp.sim import SceneConfig, build_scene

EXTENTS = (0.02, 0.04, 0.1)  # a tall box, standing on its smallest face in its file


def test_box_rests_most_probably_on_its_largest_face() -> None:
    poses = stable_poses(trimesh.creation.box(EXTENTS).vertices)
    assert len(poses) == 6
    assert sum(p.probability for p in poses) == pytest.approx(1.0)
    assert [p.probability for p in poses] == sorted((p.probability for p in poses), reverse=True)
    best = poses[0]
    assert best.height == pytest.approx(0.01)  # half the smallest extent
    np.testing.assert_allclose(best.rotation @ best.rotation.T, np.eye(3), atol=1e-9)
    assert abs(best.rotation[2, 0]) == pytest.approx(1.0)  # the object's x (thinnest) axis is vertical
    assert poses[-1].height == pytest.approx(0.05)  # standing on end is the least probable


def test_tied_poses_come_in_the_same_order_whatever_the_order_of_the_points() -> None:
    """A box's opposite faces are equally probable (but for float noise): which one is rest 0 must not depend on
    how the mesh lists its vertices (it did: shuffled, the box rested on -x instead of +x)."""
    box = trimesh.creation.box((0.04, 0.09, 0.175)).vertices
    rng = np.random.default_rng(0)
    ups = [[tuple(np.round(p.rotation[2], 6) + 0.0) for p in stable_poses(box[rng.permutation(len(box))])]
           for _ in range(6)]
    assert all(u == ups[0] for u in ups)
    assert ups[0][:4] == [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0)]
    # a side whose tied probabilities straddle a rounding boundary (0.34988115750000026 vs ...4999995)
    box = trimesh.creation.box((0.04, 0.09000000062333482, 0.175)).vertices
    rest0 = {tuple(np.round(stable_poses(box[rng.permutation(len(box))])[0].rotation[2], 6) + 0.0) for _ in range(6)}
    assert rest0 == {(1.0, 0.0, 0.0)}


def test_flat_points_are_refused() -> None:
    with pytest.raises(MeshError, match="no 3-D convex hull"):
        stable_poses(np.c_[np.random.default_rng(0).random((10, 2)), np.zeros(10)])


@pytest.mark.parametrize(("rest", "height"), [("file", 0.05), ("most_stable", 0.01)])
def test_scene_rest_option_chooses_the_starting_pose(tmp_path, rest: str, height: float) -> None:
    asset = build_object(trimesh.creation.box(EXTENTS), name="tall_box", mass=0.1, cache_root=tmp_path).asset
    scene = build_scene("parallel_jaw", asset, SceneConfig(rest=rest))
    assert scene.object_rest_pose()[2, 3] == pytest.approx(height, abs=1e-6)
    settled = settle_object(scene)
    assert settled[2, 3] == pytest.approx(height, abs=1e-3)  # it stays where it was put


def test_stable_k_scene_rests_in_the_chosen_pose_of_the_object_alone(tmp_path) -> None:
    """`object_stable_poses` (the object compiled alone, as the benchmark counts poses) ranks the same poses a
    scene starts from: pose 2 of the tall box lies on a middle face (height 20 mm), and stays there."""
    from manigrasp.sim.scene import object_stable_poses

    asset = build_object(trimesh.creation.box(EXTENTS), name="tall_box", mass=0.1, cache_root=tmp_path).asset
    alone = object_stable_poses(asset)
    assert [round(p.height, 6) for p in alone] == [0.01, 0.01, 0.02, 0.02, 0.05, 0.05]
    scene = build_scene("parallel_jaw", asset, SceneConfig(rest="stable_k", rest_k=3, rest_index=2))
    np.testing.assert_allclose(scene.rest.rotation, alone[2].rotation, atol=1e-12)
    assert scene.rest.probability == pytest.approx(alone[2].probability)
    assert scene.object_rest_pose()[2, 3] == pytest.approx(0.02, abs=1e-6)
    assert settle_object(scene)[2, 3] == pytest.approx(0.02, abs=1e-3)
