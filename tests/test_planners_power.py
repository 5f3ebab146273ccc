"""The power planner's kinematic closing on the dexterous hands: the free closing path and candidates."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from manigrasp import hands, planners
from manigrasp.objects import build_object
from manigrasp.planners.closing import closing_path

DEXTEROUS = [n for n in hands.names() if hands.load(n).kind == "dexterous"]


@pytest.mark.parametrize("name", DEXTEROUS)
def test_closing_path_stays_within_the_joint_stops_and_closes_every_finger(name: str) -> None:
    """The free close runs to its end with the palm filtered from its own fingers and stiff stops.

    A root welded to the world let the palm push the Fourier fingers' proximal joints to -0.36 rad for the
    whole path (the planner then found at most one finger on any object); soft stops let the tendons push
    joints up to 1.2 rad through them; a fixed 1.5 s close stopped the fingers half-way.
    """
    hand = hands.load(name)
    spec = hand.build_spec()
    path = closing_path(hand, 16)
    low = np.array([spec.joint(j).range[0] for j in path.joints])
    high = np.array([spec.joint(j).range[1] for j in path.joints])
    assert np.all(path.shapes >= low - 0.01) and np.all(path.shapes <= high + 0.01), path.shapes[-1]
    leads = [j for j in path.joints if "proximal" in j.lower() and "thumb" not in j.lower()]
    moved = {j: path.shapes[-1, path.joints.index(j)] - path.shapes[0, path.joints.index(j)] for j in leads}
    assert len(moved) == 4 and all(v > 0.3 for v in moved.values()), moved
    # The path reaches the hand's closed shape: some distal joint ends near its stop.
    distal = [i for i, j in enumerate(path.joints) if j not in leads and "thumb" not in j.lower()]
    assert np.max(path.shapes[-1, distal] - high[distal]) > -0.05


@pytest.mark.parametrize("name", DEXTEROUS)
def test_power_wraps_a_can_with_at_least_three_fingers(name: str) -> None:
    asset = build_object(trimesh.creation.cylinder(0.033, 0.10, sections=48), name="power_test_can", mass=0.35).asset
    obs = planners.Observation.from_asset(asset)
    result = planners.plan(planners.load("power"), obs, hands.load(name), 5, np.random.default_rng(0))
    assert len(result.candidates) == 5
    touching = [len(c.contacts) for c in result.candidates]  # one planned contact per touching finger geom
    assert min(touching) >= 3, touching
