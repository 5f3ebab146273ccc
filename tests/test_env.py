"""`manigrasp.env.GraspEnv`: a grasp trial as a dm_env environment, agreeing with the benchmark trial for trial.

Scene: `parallel_jaw` with a 5 cm cube of 0.3 kg (a mesh file, built in a temporary
object cache). The harness side runs the antipodal planner's candidates through
`manigrasp.bench.worker` exactly as a benchmark run does.
"""

from __future__ import annotations

import importlib.util
import math
import tempfile
import unittest
from dataclasses import replace
from pathlib import Path

import dm_env
import numpy as np
import pytest
import trimesh
from dm_env import test_utils

from manigrasp.bench import worker
from manigrasp.bench.config import NamedEntry
from manigrasp.bench.trials import Group
from manigrasp.env import GraspEnv
from manigrasp.errors import ConfigError, UnknownNameError
from manigrasp.objects import build_object
from manigrasp.objects.catalog import ObjectSource
from manigrasp.protocol import PROTOCOLS, Status
from manigrasp.protocol.result import PoseRecord
from manigrasp.sim import SceneConfig

BOX = 0.05  # [m] cube edge
MASS = 0.3  # [kg]
TOP = np.array([0.0, 1.0, 0.0, 0.0])  # (w, x, y, z): 180 deg about x, approach -z (down), closing -y


def _box_file(folder: Path) -> str:
    path = folder / "env_box.obj"
    trimesh.creation.box((BOX,) * 3).export(path)
    return str(path)


@pytest.fixture(scope="module")
def harness(tmp_path_factory: pytest.TempPathFactory):
    """The box group of a benchmark (antipodal, standard protocol), planned, with its source; a private cache."""
    root = tmp_path_factory.mktemp("env")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MANIGRASP_CACHE", str(root / "cache"))
        source = ObjectSource(name="env_box", mesh=_box_file(root), mass=MASS)
        group = Group(source, "parallel_jaw", NamedEntry("antipodal"), NamedEntry("standard"), "ground_truth",
                      SceneConfig(), 5, 11, 120.0)
        plan = worker.plan_group(group)
        assert plan.error is None, plan.error
        yield group, plan, source, root / "cache"


def _action(pose: np.ndarray, preshape: float = 0.0) -> dict[str, np.ndarray]:
    record = PoseRecord.of(pose)
    return {"position": pose[:3, 3].copy(), "quaternion": np.array([record.qw, record.qx, record.qy, record.qz]),
            "preshape": np.float64(preshape)}


def _shifted(pose: np.ndarray, offset: tuple[float, float, float]) -> np.ndarray:
    out = pose.copy()
    out[:3, 3] += offset
    return out


def test_statuses_agree_with_the_harness_trial_for_trial(harness) -> None:
    """The antipodal candidates, plus two moved (10 cm up: into the air; 8 cm down: into the table), as the
    harness runs them (`worker.run_trial`) and as actions."""
    group, plan, source, cache = harness
    side = min(plan.candidates, key=lambda c: abs(c.pose[2, 2]))  # the most horizontal approach
    moved = (replace(plan.candidates[0], pose=_shifted(plan.candidates[0].pose, (0.0, 0.0, 0.10))),
             replace(side, pose=_shifted(side.pose, (0.0, 0.0, -0.08))))
    plan = replace(plan, candidates=(*plan.candidates, *moved), planned=())
    bench = [worker.run_trial(group, i, plan)[1] for i in range(len(plan.candidates))]
    env = GraspEnv(source, "parallel_jaw", seed=3, cache_root=cache)
    seen = []
    for candidate in plan.candidates:
        first = env.reset()
        assert np.array_equal(env.object_pose, plan.object_pose)  # the same settled pose the planner saw
        last = env.step(_action(candidate.pose))
        assert last.step_type == dm_env.StepType.LAST and last.discount == 0.0
        assert last.reward == (1.0 if env.last_result.status == Status.SUCCESS else 0.0)
        assert last.observation is first.observation
        seen.append(env.last_result)
    assert [r.status for r in seen] == [r.status for r in bench]
    assert [r.last_phase for r in seen] == [r.last_phase for r in bench]
    assert [r.fingers_in_contact for r in seen] == [r.fingers_in_contact for r in bench]
    assert Status.SUCCESS in {r.status for r in bench[:-2]}
    assert bench[-2].status == Status.NO_CONTACT  # the jaws close on air 10 cm above the cube
    assert bench[-1].status == Status.PREGRASP_COLLISION  # the TCP 5-6 cm under the table top
    for mine, theirs in zip(seen, bench, strict=True):
        assert mine.max_translation_m == pytest.approx(theirs.max_translation_m, abs=1e-6, nan_ok=True)
        assert mine.object_pose == theirs.object_pose


def test_object_frame_actions_give_the_world_frame_results(harness) -> None:
    group, plan, source, cache = harness
    world = GraspEnv(source, "parallel_jaw", seed=0, cache_root=cache, points="none")
    local = GraspEnv(source, "parallel_jaw", seed=0, cache_root=cache, points="none", action_frame="object",
                     yaw_range=math.pi, position_range=0.03)
    for candidate in plan.candidates[:2]:
        world.reset()
        world.step(_action(candidate.pose))
        local.reset()
        in_object = np.linalg.inv(plan.object_pose) @ candidate.pose
        local.step(_action(in_object))
        assert local.last_result.status == world.last_result.status
        # the grasp landed where the object now is: same relative pose to the object's settled frame
        expected = local.object_pose @ in_object
        assert np.allclose(local.last_grasp_pose, expected, atol=1e-9)
    assert not np.allclose(local.object_pose, plan.object_pose, atol=1e-3)  # it was really moved


def _box_env(seed: int, **kwargs) -> GraspEnv:
    asset = _box_asset()
    return GraspEnv(asset, "parallel_jaw", seed=seed, **kwargs)


_ASSETS: dict[str, object] = {}


def _box_asset():
    """The cube built once per test session in a private temporary cache."""
    if "box" not in _ASSETS:
        root = Path(tempfile.mkdtemp(prefix="manigrasp_env_"))
        _ASSETS["box"] = build_object(trimesh.creation.box((BOX,) * 3), name="env_box", mass=MASS,
                                      cache_root=root).asset
    return _ASSETS["box"]


def test_same_seed_same_episodes_and_results() -> None:
    kwargs = {"yaw_range": math.pi, "position_range": 0.03, "action_frame": "object", "n_points": 64}
    one, two, other = _box_env(7, **kwargs), _box_env(7, **kwargs), _box_env(8, **kwargs)
    action = {"position": np.zeros(3), "quaternion": TOP, "preshape": np.float64(0.0)}
    for _ in range(2):
        a, b, c = one.reset(), two.reset(), other.reset()
        for key in a.observation:
            assert np.array_equal(a.observation[key], b.observation[key]), key
        assert not np.array_equal(a.observation["object_position"], c.observation["object_position"])
        ra, rb = one.step(action), two.step(action)
        assert ra.reward == rb.reward
        assert replace(one.last_result, wall_time_s=0.0) == replace(two.last_result, wall_time_s=0.0)
    assert one.last_result.status == Status.SUCCESS  # a top grasp on the centre of a cube lifts it


def test_several_grasps_on_one_settled_object() -> None:
    """`run_grasp` keeps the episode: the protocol resets the scene, so a repeat gives the same trial."""
    env = _box_env(6, points="none", action_frame="object")
    env.reset()
    top = {"position": np.zeros(3), "quaternion": TOP, "preshape": np.float64(0.0)}
    first = env.run_grasp(top)
    air = env.run_grasp({**top, "position": np.array([0.0, 0.0, 0.10])})
    again = env.run_grasp(top)
    assert (first.status, air.status, again.status) == (Status.SUCCESS, Status.NO_CONTACT, Status.SUCCESS)
    assert replace(first, wall_time_s=0.0, seed=0) == replace(again, wall_time_s=0.0, seed=0)
    assert env.step(top).reward == 1.0  # the episode was still open


def test_reset_drops_the_object_at_a_drawn_yaw_and_place() -> None:
    env = _box_env(1, yaw_range=math.pi, position_range=0.04, points="none")
    yaws = []
    for _ in range(6):
        obs = env.reset().observation
        rotation = env.object_pose[:3, :3]
        assert rotation[2, 2] == pytest.approx(1.0, abs=1e-3)  # still upright: only turned about z
        assert np.all(np.abs(obs["object_position"][:2]) <= 0.04 + 1e-3)
        assert obs["object_position"][2] == pytest.approx(BOX / 2, abs=1e-3)  # resting on the table
        w, z = obs["object_quaternion"][[0, 3]]
        yaws.append(2 * math.atan2(z, w))
    assert np.ptp(yaws) > 0.5  # drawn, not fixed
    still = _box_env(1, points="none").reset().observation
    assert np.allclose(still["object_position"][:2], 0.0, atol=1e-3)


def test_mesh_points_lie_on_the_cube_with_outward_normals() -> None:
    env = _box_env(2, yaw_range=math.pi, n_points=200)
    obs = env.reset().observation
    pose = env.object_pose
    local = (obs["points"] - pose[:3, 3]) @ pose[:3, :3]  # world -> object frame
    assert np.allclose(np.abs(local).max(axis=1), BOX / 2, atol=1e-6)  # on a face
    normals = obs["normals"] @ pose[:3, :3]
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert np.all(np.einsum("ij,ij->i", normals, local) > 0)  # pointing out
    assert str(obs["hand"]) == "parallel_jaw" and obs["hand_max_width"] > BOX


@pytest.mark.skipif(importlib.util.find_spec("open3d") is None, reason="needs the perception extra")
def test_depth_points_see_the_cube_from_the_camera() -> None:
    env = _box_env(4, points="depth", n_points=300)
    obs = env.reset().observation
    assert obs["points"].shape == (300, 3)
    local = (obs["points"] - env.object_pose[:3, 3]) @ env.object_pose[:3, :3]
    assert np.all(np.abs(local) < BOX / 2 + 0.005)  # on the cube, within the depth noise
    assert np.all(local[:, 2] > -BOX / 2 + 0.002)  # the table is removed
    assert np.allclose(np.linalg.norm(obs["normals"], axis=1), 1.0, atol=1e-6)


BAD_ACTIONS = {
    "nan position": {"position": np.array([np.nan, 0.0, 0.0]), "quaternion": TOP, "preshape": 0.0},
    "non-unit quaternion": {"position": np.zeros(3), "quaternion": 2 * TOP, "preshape": 0.0},
    "zero quaternion": {"position": np.zeros(3), "quaternion": np.zeros(4), "preshape": 0.0},
    "pre-shape above 1": {"position": np.zeros(3), "quaternion": TOP, "preshape": 1.5},
    "nan pre-shape": {"position": np.zeros(3), "quaternion": TOP, "preshape": np.nan},
    "missing key": {"position": np.zeros(3), "quaternion": TOP},
    "wrong shape": {"position": np.zeros(2), "quaternion": TOP, "preshape": 0.0},
    "not numbers": {"position": ["a", "b", "c"], "quaternion": TOP, "preshape": 0.0},
    "not a dict": np.zeros(8),
}


@pytest.mark.parametrize("name", list(BAD_ACTIONS))
def test_an_invalid_action_is_an_invalid_grasp_with_reward_zero(name: str) -> None:
    env = _box_env(0, points="none", action_frame="object")
    env.reset()
    last = env.step(BAD_ACTIONS[name])
    assert last.step_type == dm_env.StepType.LAST and last.reward == 0.0
    assert env.last_result.status == Status.INVALID_GRASP and env.last_result.sim_steps == 0
    assert env.last_result.detail


def test_bad_arguments_are_one_line_errors() -> None:
    with pytest.raises(ConfigError, match="available: world, object"):
        _box_env(0, action_frame="tcp")
    with pytest.raises(ConfigError, match="available: mesh, depth, none"):
        _box_env(0, points="cloud")
    with pytest.raises(ConfigError, match="n_points"):
        _box_env(0, n_points=0)
    with pytest.raises(ConfigError, match="yaw_range"):
        _box_env(0, yaw_range=-1.0)
    with pytest.raises(ConfigError, match="did you mean"):
        _box_env(0, protocol_params={"hold_ss": 1.0})
    with pytest.raises(UnknownNameError, match="available"):
        _box_env(0, protocol="standrad")
    with pytest.raises(ConfigError, match="call reset"):
        _box_env(0).run_grasp({})


@pytest.mark.parametrize("name", PROTOCOLS.names())
def test_every_protocol_judges_a_top_grasp_on_the_cube(name: str) -> None:
    """A centred top grasp holds a 0.3 kg cube in every registered protocol (grip 35 N, friction 0.5)."""
    env = _box_env(0, points="none", action_frame="object", protocol=name)
    env.reset()
    last = env.step({"position": np.zeros(3), "quaternion": TOP, "preshape": np.float64(0.0)})
    assert last.step_type == dm_env.StepType.LAST
    assert (last.reward, env.last_result.status) == (1.0, Status.SUCCESS), env.last_result.detail


def test_protocol_parameters_reach_the_trial() -> None:
    """A push of 30 m g (88 N) along +x, tangential to the pads, beats the grip's friction (2 x 0.5 x 35 N)."""
    env = _box_env(0, points="none", action_frame="object",
                   protocol_params={"perturb_force_multiple": 30.0, "perturb_directions": ["+x"]})
    env.reset()
    assert env.step({"position": np.zeros(3), "quaternion": TOP, "preshape": np.float64(0.0)}).reward == 0.0
    assert env.last_result.status == Status.DROPPED_PERTURB and env.last_result.last_phase == "lift"


class GraspEnvConformance(test_utils.EnvironmentTestMixin, unittest.TestCase):
    """dm_env's own contract checks (specs, FIRST/LAST sequencing), with a real grasp in the action sequence."""

    def make_object_under_test(self) -> GraspEnv:
        return _box_env(5, action_frame="object", yaw_range=math.pi, n_points=32)

    def make_action_sequence(self):
        top = {"position": np.zeros(3), "quaternion": TOP, "preshape": np.float64(0.0)}
        yield top  # a successful grasp -> LAST
        yield self.make_action()  # ignored: starts a new episode
        yield self.make_action()  # the spec's minimum: a non-unit quaternion -> invalid_grasp, LAST
        yield top

    def test_specs_are_exact(self) -> None:
        spec = self.environment.action_spec()
        assert set(spec) == {"position", "quaternion", "preshape"}
        assert spec["preshape"].minimum == 0.0 and spec["preshape"].maximum == 1.0
        assert self.environment.observation_spec()["points"].shape == (32, 3)
        assert self.environment.reward_spec().maximum == 1.0
