"""Diversity of grasp sets: the sparse conflict graph, packing (a large independent set) and representatives.

Pure NumPy: poses are built by hand, so every expected set is known exactly.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from manigrasp.planners.geometry import random_rotations
from manigrasp.planners.nms import Suppressor, conflicts, pack, representatives, rotation_angles, suppress


def _poses_along_x(xs, rotations=None) -> np.ndarray:
    poses = np.tile(np.eye(4), (len(xs), 1, 1))
    poses[:, 0, 3] = xs
    if rotations is not None:
        poses[:, :3, :3] = rotations
    return poses


def _random_poses(n: int, seed: int, spread: float = 0.05) -> np.ndarray:
    rng = np.random.default_rng(seed)
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, 3] = rng.uniform(-spread, spread, (n, 3))
    poses[:, :3, :3] = random_rotations(n, rng)
    return poses


def _is_independent(poses: np.ndarray, kept: np.ndarray, symmetric: bool) -> bool:
    nms = Suppressor(symmetric=symmetric, capacity=len(kept) + 1)
    for i in kept:
        if nms.is_duplicate(poses[i]):
            return False
        nms.keep(poses[i])
    return True


@pytest.mark.parametrize("symmetric", [False, True])
def test_conflicts_equal_the_suppressor_pair_by_pair(symmetric):
    poses = _random_poses(300, seed=1, spread=0.02)
    found = {(int(i), int(j)) for i, j in conflicts(poses, symmetric=symmetric, block=37)}
    expected = set()  # independently: distances and rotation angles pair by pair
    for i in range(len(poses)):
        near = np.linalg.norm(poses[i + 1:, :3, 3] - poses[i, :3, 3], axis=1) < 0.03
        turned = rotation_angles(poses[i, :3, :3], poses[i + 1:, :3, :3], symmetric) < np.radians(30.0)
        expected |= {(i, i + 1 + int(j)) for j in np.flatnonzero(near & turned)}
    assert found == expected and len(expected) > 50  # enough conflicts for the test to mean something


def test_pack_beats_rank_order_on_a_line_and_finds_the_optimum():
    # Ten poses 1.01 cm apart on a line, same orientation: two conflict when closer than 3 cm (two steps).
    # The most that can be kept is 4 (steps 0, 3, 6, 9); in the rank order 1, 5, 9, ... greedy NMS keeps 3.
    poses = _poses_along_x(np.arange(10) * 0.0101)
    ranked = poses[[1, 5, 9, 0, 2, 3, 4, 6, 7, 8]]
    assert len(suppress(ranked)) == 3
    kept = pack(conflicts(ranked), len(ranked))
    assert len(kept) == 4 and _is_independent(ranked, kept, symmetric=False)
    assert sorted(np.round(ranked[kept, 0, 3] / 0.0101).astype(int)) == [0, 3, 6, 9]


def test_pack_takes_the_leaves_of_a_star_not_its_centre():
    # A centre pose and four poses 2 cm from it, each turned 25 degrees about its own horizontal axis: each
    # conflicts with the centre (2 cm, 25 deg) but not with the others (2.8 cm apart and 35 deg, or 4 cm).
    # Ranked centre first, greedy NMS keeps the centre alone; packing keeps the four.
    directions = np.array([[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], [0, -1.0, 0]])
    axes = np.array([[0, 1.0, 0], [-1.0, 0, 0], [0, -1.0, 0], [1.0, 0, 0]])
    leaves = _poses_along_x(np.zeros(4), Rotation.from_rotvec(np.radians(25.0) * axes).as_matrix())
    leaves[:, :3, 3] = 0.02 * directions
    poses = np.concatenate([np.eye(4)[None], leaves])
    graph = conflicts(poses)
    assert sorted(map(tuple, graph)) == [(0, 1), (0, 2), (0, 3), (0, 4)]
    assert list(suppress(poses)) == [0]
    assert list(pack(graph, len(poses))) == [1, 2, 3, 4]


def test_pack_finds_the_optimum_of_small_graphs():
    # Known optima: a path a-b-c-d-e with a chord b-d (3: a, c, e) and a 6-cycle (3); every result independent.
    for graph, count, best in ((np.array([[0, 1], [1, 2], [2, 3], [3, 4], [1, 3]]), 5, 3),
                               (np.array([[0, 1], [1, 2], [2, 3], [3, 4], [4, 5], [0, 5]]), 6, 3)):
        kept = set(pack(graph, count).tolist())
        assert len(kept) == best
        assert not any(a in kept and b in kept for a, b in graph)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pack_is_independent_and_at_least_as_large_as_rank_order(seed):
    poses = _random_poses(400, seed, spread=0.04)
    kept = pack(conflicts(poses, symmetric=True), len(poses))
    assert _is_independent(poses, kept, symmetric=True)
    assert len(kept) >= len(suppress(poses, symmetric=True))


def test_pack_with_no_conflicts_keeps_everything():
    assert list(pack(np.zeros((0, 2), int), 4)) == [0, 1, 2, 3]
    assert len(pack(np.zeros((0, 2), int), 0)) == 0


def test_representatives_one_per_cell_fingers_swapped_alike():
    base = np.eye(4)
    near = base.copy()
    near[:3, 3] = [0.001, 0.001, 0.0]  # same 5 mm cell, same axes
    far = base.copy()
    far[:3, 3] = [0.02, 0.0, 0.0]
    flipped = base.copy()
    flipped[:3, :3] = np.diag([-1.0, -1.0, 1.0])  # turned 180 degrees about the approach: fingers swapped
    poses = np.stack([base, near, far, flipped])
    assert list(representatives(poses, 0.005, 12)) == [0, 2, 3]
    assert list(representatives(poses, 0.005, 12, symmetric=True)) == [0, 2]


def test_poses_exactly_the_threshold_apart_are_distinct_on_every_path():
    # Approaches 30 degrees apart about one grasp axis (12 per turn), as the planner makes them: rounding puts
    # their angle at 29.99999999999998 degrees; every code path must call them distinct, not some of them.
    theta = np.arange(12) * 2.0 * np.pi / 12 + 0.3
    turns = Rotation.from_rotvec(theta[:, None] * np.array([[0.0, 1.0, 0.0]])).as_matrix()
    poses = _poses_along_x(np.zeros(12), turns)
    assert len(suppress(poses)) == 12 and len(suppress(poses, symmetric=True)) == 12
    assert len(conflicts(poses)) == 0 and len(conflicts(poses, symmetric=True)) == 0
    nms = Suppressor(capacity=1)
    nms.keep(poses[0])
    assert not nms.is_duplicate(poses[1]) and not nms.duplicates(poses[1:2])[0]
