"""`nms.pack_prefix`: n distinct poses from as short a prefix of the ranking as packing allows.

Pure NumPy: poses on a line (1.01 cm apart, same orientation: two conflict within 3 cm, i.e. two steps) and
random poses, so the expected sets are known or checked against greedy NMS directly.
"""

from __future__ import annotations

import numpy as np
import pytest

from manigrasp.planners.geometry import random_rotations
from manigrasp.planners.nms import Suppressor, conflicts, pack, pack_prefix, suppress


def _line(steps) -> np.ndarray:
    poses = np.tile(np.eye(4), (len(steps), 1, 1))
    poses[:, 0, 3] = np.asarray(steps) * 0.0101
    return poses


def _independent(poses: np.ndarray, kept: np.ndarray) -> bool:
    nms = Suppressor(capacity=len(kept) + 1)
    for i in kept:
        if nms.is_duplicate(poses[i]):
            return False
        nms.keep(poses[i])
    return True


def test_the_best_pose_between_two_good_ones_does_not_push_the_set_down_the_ranking():
    # Ranked best first: the pose at step 2, then steps 0 and 4 (each within 3 cm of step 2, 4 cm apart), then 9.
    # Greedy NMS keeps step 2 and must go down to rank 3 (step 9) for a second pose; steps 0 and 4 (ranks 1, 2)
    # are two distinct poses from the first three.
    ranked = _line([2, 0, 4, 9, 6, 7])
    assert list(suppress(ranked)[:2]) == [0, 3]
    kept = pack_prefix(conflicts(ranked), len(ranked), 2)
    assert list(kept) == [1, 2]


def test_a_prefix_that_packs_n_is_used_and_short_of_n_everything_is_packed():
    ranked = _line([0, 1, 2, 3, 4, 5, 6, 7, 8, 9])  # in order: at most 4 distinct (0, 3, 6, 9)
    conflict = conflicts(ranked)
    assert list(pack_prefix(conflict, len(ranked), 2)) == [0, 3]  # the first 4 poses already give 2
    assert len(pack_prefix(conflict, len(ranked), 6)) == len(pack(conflict, len(ranked))) == 4


@pytest.mark.parametrize("seed", range(6))
def test_random_poses_n_distinct_no_further_down_than_greedy_nms(seed):
    rng = np.random.default_rng(seed)
    poses = np.tile(np.eye(4), (400, 1, 1))
    poses[:, :3, 3] = rng.uniform(-0.05, 0.05, (400, 3))
    poses[:, :3, :3] = random_rotations(400, rng)
    n = 20
    greedy = suppress(poses)
    kept = pack_prefix(conflicts(poses), len(poses), n)
    assert len(greedy) >= n and len(kept) >= n and _independent(poses, kept)
    assert kept[n - 1] <= greedy[n - 1]  # the n best of the packed set reach no deeper into the ranking


def test_when_all_poses_pack_to_exactly_n_a_shorter_prefix_is_still_searched():
    # Packing all seven gives exactly two; the first two (4.1 cm apart) are already distinct, so the set must not
    # reach to rank 5 (the bisection ran only when all of them packed to more than n).
    ranked = _line([3.5, 7.6, 4.0, 3.4, 5.0, 8.0, 7.6])
    assert len(pack(conflicts(ranked), len(ranked))) == 2
    assert list(pack_prefix(conflicts(ranked), len(ranked), 2)) == [0, 1]
