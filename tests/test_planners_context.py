"""The protocol's parameters reach the planners (`PlanContext`): the pre-grasp offset a planner checks for
collisions is the one the protocol executes, and planners written without a context still work."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from manigrasp import planners
from manigrasp.bench import worker
from manigrasp.bench.config import NamedEntry
from manigrasp.bench.trials import Group
from manigrasp.errors import ConfigError
from manigrasp.geometry import pregrasp_pose
from manigrasp.objects.catalog import ObjectSource
from manigrasp.planners.collision import HandProbe
from manigrasp.planners.context import PlanContext, grasping_friction, takes_context
from manigrasp.protocol import PROTOCOLS
from manigrasp.sim import SceneConfig

UPWARD = 0.7  # largest z of the approach: the planner may approach from below, where a pre-grasp meets the table


@pytest.fixture(scope="module")
def box_obs(box_asset) -> planners.Observation:
    return planners.Observation.from_asset(box_asset)


def _context(offset: float) -> PlanContext:
    return replace(PlanContext.standard(), pregrasp_offset=offset)


# ------------------------------------------------------------ the protocol's parameters
def test_the_standard_context_is_the_standard_protocols_defaults() -> None:
    params = PROTOCOLS.load("standard").params
    assert PlanContext.standard() == PlanContext(params.pregrasp_offset, None, params.grip_force_fraction,
                                                 params.perturb_force_multiple)


@pytest.mark.parametrize(("name", "params", "perturbation"), [
    ("standard", {"perturb_force_multiple": 2.5}, 2.5),
    ("six_direction", {}, 10.0 / 9.81),  # DexGraspBench's 10 N per kg of the object's mass
    ("lift", {}, 0.0),  # the weight only
    ("shake", {"shake_amplitude": 0.02, "shake_frequency": 2.0}, 0.02 * (4 * math.pi) ** 2 / 9.81),  # A w^2 / g
])
def test_each_protocol_gives_its_own_load_and_offset(name: str, params: dict, perturbation: float) -> None:
    protocol = PROTOCOLS.load(name, pregrasp_offset=0.04, **params)
    context = PlanContext.from_params(protocol.params)
    assert context.pregrasp_offset == 0.04
    assert context.perturbation == pytest.approx(perturbation)


def test_the_grip_force_is_the_protocols_capped_at_the_hands_maximum(jaw) -> None:
    assert PlanContext.standard().grip_force_for(jaw) == pytest.approx(0.5 * jaw.max_grip_force)
    fixed = PlanContext.from_params(PROTOCOLS.load("standard", grip_force=10.0).params)
    assert fixed.grip_force_for(jaw) == 10.0
    assert replace(fixed, grip_force=1e3).grip_force_for(jaw) == jaw.max_grip_force


def test_a_bad_context_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="pregrasp_offset"):
        _context(-0.01)
    with pytest.raises(ConfigError, match="contact_friction"):
        replace(PlanContext.standard(), contact_friction=-0.1)
    with pytest.raises(ConfigError, match="antipodal: pregrasp_offset"):
        planners.load("antipodal", pregrasp_offset=float("nan"))


# ------------------------------------------------------------ planners with and without a context
class OldPlanner:
    """A user planner written before contexts: plan(observation, hand, n, rng)."""

    name = "old"

    def plan(self, observation, hand, n, rng):
        return [planners.GraspCandidate(pose=np.eye(4), score=1.0)]


class NewPlanner:
    name = "new"

    def __init__(self) -> None:
        self.seen: list[Any] = []

    def plan(self, observation, hand, n, rng, context=None):
        self.seen.append(context)
        return [planners.GraspCandidate(pose=np.eye(4), score=1.0, pregrasp_offset=context.pregrasp_offset)]


class KeywordPlanner(NewPlanner):
    def plan(self, observation, hand, n, rng, **options):
        return super().plan(observation, hand, n, rng, options["context"])


def test_a_context_reaches_planners_that_take_it_and_old_planners_still_run(box_obs, jaw) -> None:
    assert not takes_context(OldPlanner()) and takes_context(NewPlanner()) and takes_context(KeywordPlanner())
    context = _context(0.05)
    old = planners.plan(OldPlanner(), box_obs, jaw, 1, np.random.default_rng(0), context=context)
    assert old.candidates[0].pregrasp_offset is None  # it said nothing: the protocol's offset holds
    for planner in (NewPlanner(), KeywordPlanner()):
        result = planners.plan(planner, box_obs, jaw, 1, np.random.default_rng(0), context=context)
        assert planner.seen == [context] and result.candidates[0].pregrasp_offset == 0.05


# ------------------------------------------------------------ the offset changes the collision check
def _pregrasp_collides(box_obs, jaw, candidates, offset: float) -> np.ndarray:
    """(n,) whether the open hand at each candidate's pre-grasp pose `offset` back touches the object or table."""
    probe = HandProbe(jaw, box_obs)
    return probe.collides(pregrasp_pose(np.stack([c.pose for c in candidates]), offset))


def test_the_planner_checks_the_pre_grasp_where_the_protocol_puts_it(box_obs, jaw) -> None:
    """Approaches from below are allowed: their pre-grasp lies lower than the grasp, so a long offset
    reaches into the table. Planned for 15 cm, no pre-grasp 15 cm back collides and every candidate says
    15 cm; planned for 0 cm, some of the same kind of grasps would hit the table 15 cm back."""
    antipodal = planners.load("antipodal", max_approach_z=UPWARD)
    far = planners.plan(antipodal, box_obs, jaw, 20, np.random.default_rng(0), context=_context(0.15)).candidates
    near = planners.plan(antipodal, box_obs, jaw, 20, np.random.default_rng(0), context=_context(0.0)).candidates
    assert {c.pregrasp_offset for c in far} == {0.15} and {c.pregrasp_offset for c in near} == {0.0}
    assert not _pregrasp_collides(box_obs, jaw, far, 0.15).any()
    assert _pregrasp_collides(box_obs, jaw, near, 0.15).any()
    assert not _pregrasp_collides(box_obs, jaw, near, 0.0).any()


def test_a_planners_own_offset_overrides_the_protocols(box_obs, jaw) -> None:
    own = planners.load("antipodal", pregrasp_offset=0.07)
    result = planners.plan(own, box_obs, jaw, 5, np.random.default_rng(0), context=_context(0.15))
    assert {c.pregrasp_offset for c in result.candidates} == {0.07}


# ------------------------------------------------------------ the offset changes the executed pre-grasp
class StartWatcher:
    """Records the TCP pose when the approach begins (the hand still at its pre-grasp pose)."""

    sample_period_s = math.inf

    def __init__(self) -> None:
        self.start: np.ndarray | None = None

    def on_start(self, scene, grasp, object_pose) -> None:
        pass

    def on_phase(self, scene, phase, detail: str = "") -> None:
        if phase == "approach" and self.start is None:
            self.start = scene.tcp_pose()

    def on_sample(self, scene) -> None:
        pass

    def on_end(self, scene, result) -> None:
        pass


@pytest.mark.parametrize("offset", [0.05, 0.12])
def test_the_protocol_starts_the_hand_at_its_own_offset_with_a_grasp_planned_for_it(box_scene, offset) -> None:
    protocol = PROTOCOLS.load("lift", pregrasp_offset=offset)
    observation = planners.Observation.from_asset(box_scene.asset, box_scene.rest)
    context = PlanContext.from_params(protocol.params)
    grasp = planners.plan(planners.load("antipodal"), observation, box_scene.scene.hand, 1,
                          np.random.default_rng(0), context=context).candidates[0]
    watcher = StartWatcher()
    result = protocol.run(box_scene.scene, grasp, np.random.default_rng(0), object_pose=box_scene.rest,
                          observer=watcher)
    assert result.status.value == "success", result.detail
    np.testing.assert_allclose(watcher.start[:3, 3], grasp.position - offset * grasp.approach, atol=1e-6)


def test_a_grasp_whose_planner_named_no_offset_starts_at_the_protocols(box_scene) -> None:
    """A user planner that takes no context (and a grasp file) names no offset: the protocol's holds."""
    protocol = PROTOCOLS.load("lift", pregrasp_offset=0.05)
    observation = planners.Observation.from_asset(box_scene.asset, box_scene.rest)
    planned = planners.plan(planners.load("antipodal"), observation, box_scene.scene.hand, 1,
                            np.random.default_rng(0), context=PlanContext.from_params(protocol.params)).candidates[0]
    grasp = planners.GraspCandidate(pose=planned.pose, score=1.0, width=planned.width)
    assert grasp.pregrasp_offset is None
    watcher = StartWatcher()
    result = protocol.run(box_scene.scene, grasp, np.random.default_rng(0), object_pose=box_scene.rest,
                          observer=watcher)
    assert result.status.value == "success", result.detail
    np.testing.assert_allclose(watcher.start[:3, 3], grasp.position - 0.05 * grasp.approach, atol=1e-6)


def test_the_harness_plans_for_the_groups_protocol(tmp_path: Path) -> None:
    mesh = tmp_path / "ctx_box.obj"
    trimesh.creation.box((0.05,) * 3).export(mesh)
    source = ObjectSource(name="ctx_box", mesh=str(mesh), mass=0.3)
    group = Group(source, "parallel_jaw", NamedEntry("antipodal"), NamedEntry("standard", {"pregrasp_offset": 0.06}),
                  "ground_truth", SceneConfig(), 4, 3, 60.0)
    plan = worker.plan_group(group)
    assert plan.error is None, plan.error
    assert len(plan.candidates) == 4 and {c.pregrasp_offset for c in plan.candidates} == {0.06}


# ------------------------------------------------------------ the scene's contact friction
@pytest.mark.parametrize("hand_name", ["parallel_jaw", "inspire_right", "allegro_right"])
def test_the_grasping_friction_is_the_rubbers_with_compliant_pads_and_the_hands_with_rigid(hand_name) -> None:
    from manigrasp.hands.registry import load as load_hand

    hand = load_hand(hand_name)  # pads (parallel_jaw) or rubber-covered fingertips (the dexterous hands)
    assert grasping_friction(SceneConfig(pads="compliant"), hand) == 1.0
    assert grasping_friction(SceneConfig(pads="rigid"), hand) == 0.5
    assert grasping_friction(SceneConfig(pads="compliant", pad_friction=0.8, hand_friction=0.3), hand) == 0.8
    assert grasping_friction(SceneConfig(pads="rigid", pad_friction=0.8, hand_friction=0.3), hand) == 0.3
    bare = replace(hand, pad_geoms=(), fingertip_geoms=())  # nothing rubber-covered: the hand's own friction
    assert grasping_friction(SceneConfig(pads="compliant", hand_friction=0.3), bare) == 0.3
    assert PlanContext.standard().contact_friction is None  # no scene: each planner assumes its own


@pytest.mark.parametrize(("pads", "friction"), [("compliant", 1.0), ("rigid", 0.5)])
def test_the_harness_tells_the_planner_the_scenes_contact_friction(tmp_path: Path, monkeypatch, pads: str,
                                                                    friction: float) -> None:
    """The planner gets the group's scene (`PlanContext.scene`, which its probes compile) and the friction of
    the hand's grasping surfaces in it."""
    seen: list[PlanContext] = []
    real = planners.plan

    def spy(planner, observation, hand, n, rng, context=None):
        seen.append(context)
        return real(planner, observation, hand, n, rng, context=context)

    monkeypatch.setattr(planners, "plan", spy)
    mesh = tmp_path / "ctx_box.obj"
    trimesh.creation.box((0.05,) * 3).export(mesh)
    source = ObjectSource(name="ctx_box", mesh=str(mesh), mass=0.3)
    scene = SceneConfig(pads=pads, table_friction=0.8)
    group = Group(source, "parallel_jaw", NamedEntry("antipodal"), NamedEntry("standard"), "ground_truth",
                  scene, 2, 3, 60.0)
    plan = worker.plan_group(group)
    assert plan.error is None, plan.error
    assert [c.contact_friction for c in seen] == [friction]
    assert [c.scene for c in seen] == [scene]
    assert seen[0].perturbation == PROTOCOLS.load("standard").params.perturb_force_multiple
