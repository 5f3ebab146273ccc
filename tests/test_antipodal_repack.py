"""antipodal's repacking of step 5 (`select.pack_ranked`): distinct grasps from the top of the ranking.

Closed loop on the shipped potted meat can scan (a real YCB scan with a 2-9 mm lip): greedy NMS in rank order
keeps 16-18 of its distinct body grasps and fills the 20 with pinches on the lip (score ~0.05, they slip in the
lift); packing the best-ranked free poses finds 20 body grasps.
"""

from __future__ import annotations

import numpy as np

from manigrasp import hands, planners
from manigrasp.objects import catalog
from manigrasp.planners.nms import suppress


def test_repacking_replaces_a_scans_lip_pinches_with_body_grasps():
    asset = catalog.build(catalog.shipped("010_potted_meat_can_scan")).asset
    obs, hand = planners.Observation.from_asset(asset), hands.load("parallel_jaw")
    plans = {repack: planners.plan(planners.load("antipodal", repack=repack), obs, hand, 20,
                                   np.random.default_rng(0)).candidates for repack in (False, True)}
    width = {k: np.array([c.width for c in v]) for k, v in plans.items()}
    score = {k: np.array([c.score for c in v]) for k, v in plans.items()}
    assert len(width[False]) == len(width[True]) == 20
    assert (width[False] < 0.01).sum() >= 2, width[False]  # the walk: pinches on the lip
    assert (width[True] < 0.01).sum() == 0, width[True]
    assert score[True].min() > score[False].min()  # the worst of the 20 scores higher
    poses = np.array([c.pose for c in plans[True]])
    assert len(suppress(poses, symmetric=True)) == 20  # still no two within 3 cm and 30 degrees
