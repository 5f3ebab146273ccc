"""The run's scene reaches the planners (`PlanContext.scene`): they probe the hand the trials run.

With compliant pads (`pads.clear_backing`) the Panda's finger hulls are cut back behind the pad faces, also
beyond the pads' outline; with ``pads: rigid`` the trials run the uncut hulls, so a rigid-pad plan must be
checked against them. The pose below straddles a 5 mm plate 84 mm wide with the fingertips (beyond the
pads, which stay above the plate) at its long edges: the uncut inner face of each fingertip (12 mm from the
TCP, 0.3 mm behind the pad face) reaches over the plate's edge, the cut one (6 mm further back) does not.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from manigrasp import hands, planners
from manigrasp.errors import ConfigError
from manigrasp.objects import build_object
from manigrasp.planners import antipodal, power
from manigrasp.planners.collision import HandProbe
from manigrasp.planners.context import PlanContext, grasping_friction
from manigrasp.protocol import PROTOCOLS
from manigrasp.sim import SceneConfig

PLATE = (0.04, 0.084, 0.005)  # [m] x, y (across the fingers), z
STRADDLE = np.diag([1.0, -1.0, -1.0, 1.0])  # TCP pointing down, the fingers closing along y
STRADDLE[:3, 3] = (0.0, 0.0, 0.016)  # the pads' lower edges 8 mm above the TCP's height, the fingertips 12.8 mm


@pytest.fixture(scope="module")
def panda() -> hands.Hand:
    return hands.load("panda")


@pytest.fixture(scope="module")
def plate(tmp_path_factory: pytest.TempPathFactory) -> planners.Observation:
    mesh = trimesh.creation.box(PLATE)
    asset = build_object(mesh, name="plate", mass=0.05, cache_root=tmp_path_factory.mktemp("plate")).asset
    return planners.Observation.from_asset(asset)


def _context(pads: str, hand: hands.Hand) -> PlanContext:
    return PlanContext.for_run(PROTOCOLS.load("standard").params, SceneConfig(pads=pads), hand)


def test_the_straddle_meets_the_uncut_finger_hulls_only(panda, plate) -> None:
    """The premise: with rigid pads the fingertips reach over the plate's edges, with compliant pads they do not."""
    assert HandProbe(panda, plate, config=SceneConfig(pads="rigid")).collides(STRADDLE[None]).tolist() == [True]
    assert HandProbe(panda, plate, config=SceneConfig(pads="compliant")).collides(STRADDLE[None]).tolist() == [False]
    assert HandProbe(panda, plate).collides(STRADDLE[None]).tolist() == [False]  # the default scene: compliant


@pytest.mark.parametrize("module", [antipodal, power], ids=["antipodal", "power"])
def test_a_rigid_pad_plan_rejects_a_pose_that_only_the_uncut_hull_collides_at(monkeypatch, panda, plate,
                                                                               module) -> None:
    """The probe each planner builds for its collision checks, under each pad model."""
    built: list[HandProbe] = []

    class Recorded(HandProbe):
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            built.append(self)

    monkeypatch.setattr(module, "HandProbe", Recorded)
    name = module.__name__.rsplit(".", 1)[-1]
    verdicts = {}
    for pads in ("rigid", "compliant"):
        built.clear()
        candidates = planners.plan(planners.load(name), plate, panda, 2, np.random.default_rng(0),
                                   context=_context(pads, panda)).candidates
        assert len(built) == 1 and len(candidates) > 0
        assert built[0].scene.config.pads == pads
        verdicts[pads] = built[0].free(STRADDLE, 0.0)
    assert verdicts == {"rigid": False, "compliant": True}


def test_the_default_scene_plans_as_no_scene(jaw, box_asset) -> None:
    """A compliant-pad run's context (the default scene) plans the same grasps as no scene at all."""
    observation = planners.Observation.from_asset(box_asset)
    params = PROTOCOLS.load("standard").params
    plans = [planners.plan(planners.load("antipodal"), observation, jaw, 10, np.random.default_rng(3),
                           context=context).candidates
             for context in (PlanContext.from_params(params, grasping_friction(SceneConfig(), jaw)),
                             PlanContext.for_run(params, SceneConfig(), jaw))]
    assert len(plans[0]) == 10
    np.testing.assert_array_equal(np.stack([c.pose for c in plans[0]]), np.stack([c.pose for c in plans[1]]))
    assert [c.score for c in plans[0]] == [c.score for c in plans[1]]


def test_the_context_keeps_the_scene_but_not_its_object_rest(jaw) -> None:
    """The planner's scenes place the object themselves: the run's rest settings are dropped (a probe's
    stand-in object, a cloud's hull, may not have the run's `rest_index`-th stable pose)."""
    params = PROTOCOLS.load("standard").params
    run = SceneConfig(pads="rigid", hand_friction=0.7, rest="stable_k", rest_k=3, rest_index=2)
    context = PlanContext.for_run(params, run, jaw)
    assert context.scene == SceneConfig(pads="rigid", hand_friction=0.7)
    assert context.contact_friction == 0.7  # rigid pads: the hand's own friction
    assert PlanContext.from_params(params).scene is None and PlanContext.standard().scene_config() == SceneConfig()
    with pytest.raises(ConfigError, match="scene"):
        PlanContext.from_params(params, scene={"pads": "rigid"})


