"""`GraspEnv`: one grasp trial of the benchmark as a `dm_env.Environment` (a contextual bandit).

An episode is one object x hand scene with the object settled on the table:

- ``reset()`` drops the object (at a random yaw and table position if asked, from
  the environment's seeded generator), lets it settle exactly as the benchmark's
  `manigrasp.protocol.settle_object` does, and returns the FIRST timestep whose
  observation describes the settled object (`manigrasp.env.spaces.observation_spec`);
- ``step(action)`` executes the action's grasp with the protocol from the protocol
  registry, as the harness runs a planner's candidate (`manigrasp.bench.worker`), and
  returns a LAST timestep: reward 1.0 for ``success``, 0.0 for every other status,
  discount 0, and the observation of the episode. The full `TrialResult` is
  `env.last_result`. An action that cannot be executed (unreadable, NaN, a non-unit
  quaternion, a pre-shape outside [0, 1]) is an ``invalid_grasp`` trial with reward 0,
  never an exception.

Stepping after a LAST timestep (or before any reset) starts a new episode and ignores
the action, as `dm_env.Environment` specifies.

    >>> env = GraspEnv("061_foam_brick", "parallel_jaw", seed=0, yaw_range=np.pi)
    >>> timestep = env.reset()
    >>> timestep = env.step({"position": p, "quaternion": q, "preshape": np.float64(0.0)})
    >>> timestep.reward, env.last_result.status
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import dm_env
import numpy as np
import trimesh

from manigrasp.env import points as _points
from manigrasp.env import spaces
from manigrasp.errors import ConfigError
from manigrasp.hands.base import Hand
from manigrasp.objects.asset import ObjectAsset
from manigrasp.objects.catalog import ObjectSource
from manigrasp.protocol import PROTOCOLS, Grasp, Status, TrialResult, settle_object
from manigrasp.protocol.result import PoseRecord
from manigrasp.sim import Scene, SceneConfig, build_scene


def load_asset(obj: str | ObjectSource | ObjectAsset, cache_root: Any = None) -> ObjectAsset:
    """The built object of a shipped name ("061_foam_brick", "003_cracker_box_scan"), an
    `ObjectSource` (built through the object cache) or an `ObjectAsset` (used as is)."""
    from manigrasp.objects import catalog

    if isinstance(obj, ObjectAsset):
        return obj
    if isinstance(obj, str):
        obj = catalog.shipped(obj)
    if not isinstance(obj, ObjectSource):
        raise ConfigError(f"an object is a shipped name, an ObjectSource or an ObjectAsset, got {type(obj).__name__}")
    return catalog.build(obj, cache_root=cache_root).asset


class GraspEnv(dm_env.Environment):
    """One grasp per episode on one object x hand scene, judged by a registered protocol.

    Args:
        obj: the object (`load_asset`: a shipped name, an `ObjectSource` or an `ObjectAsset`).
        hand: a hand registry name (or ``module:attribute``) or a `Hand`.
        protocol: a protocol registry name ("standard", "lift", "six_direction", "shake").
        protocol_params: the protocol's parameters (unknown keys refused, as in a config).
        scene_config: the physics (default: the standard protocol's `SceneConfig`).
        seed: seed of the environment's generator (an int, a `numpy.random.Generator`, or None:
            fresh entropy); every draw (drop pose, points, trial seeds) comes from it.
        action_frame: "world" (the action's pose is the TCP in the world) or "object" (in the
            settled object's frame, the frame of a grasp set: DESIGN.md, "Grasp sets").
        points: what the observation's ``points``/``normals`` are (`manigrasp.env.points`):
            "mesh" (samples of the object's surface), "depth" (a simulated depth cloud; the
            perception extra) or "none" (no points in the observation).
        n_points: number of points per observation.
        yaw_range: the object is dropped at a yaw uniform in [-yaw_range, yaw_range] about the
            world z axis [rad] (0: its resting orientation as `scene_config.rest` chooses).
        position_range: and at x, y each uniform in [-position_range, position_range] [m].
        timeout_s: wall-clock budget of one trial [s] (the trial is then ``timeout``), or None:
            no budget, so that results depend on the seed alone.
        cache_root: object cache of an `ObjectSource` to build (None: the user's cache).

    Raises:
        ConfigError, UnknownNameError, HandError: a bad argument, named in the message.
    """

    def __init__(self, obj: str | ObjectSource | ObjectAsset, hand: str | Hand = "parallel_jaw", *,
                 protocol: str = "standard", protocol_params: Mapping[str, Any] | None = None,
                 scene_config: SceneConfig | None = None, seed: int | np.random.Generator | None = None,
                 action_frame: str = "world", points: str = "mesh", n_points: int = 512,
                 yaw_range: float = 0.0, position_range: float = 0.0, timeout_s: float | None = None,
                 cache_root: Any = None) -> None:
        if action_frame not in spaces.ACTION_FRAMES:
            raise ConfigError(f"unknown action_frame {action_frame!r}; available: {', '.join(spaces.ACTION_FRAMES)}")
        _points.check_source(points, n_points)
        for name, value in (("yaw_range", yaw_range), ("position_range", position_range)):
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(f"{name} must be a finite number >= 0, got {value}")
        if timeout_s is not None and not timeout_s > 0:
            raise ConfigError(f"timeout_s must be > 0 or None, got {timeout_s}")
        self.protocol = PROTOCOLS.load(protocol, **dict(protocol_params or {}))
        self.asset = load_asset(obj, cache_root)
        self.scene: Scene = build_scene(hand, self.asset, scene_config)
        self.action_frame, self.point_source = action_frame, points
        self.n_points = n_points if points != "none" else 0
        self.yaw_range, self.position_range, self.timeout_s = float(yaw_range), float(position_range), timeout_s
        self._rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self._mesh = trimesh.load(str(self.asset.visual_path), force="mesh", process=False) if points == "mesh" \
            else None
        self.object_pose: np.ndarray | None = None
        """(4, 4) settled object pose of the current episode (None before the first reset)."""
        self.episode_seed: int | None = None
        """The seed the current episode's draws and its trial's generator derive from."""
        self.last_result: TrialResult | None = None
        """The `TrialResult` of the last grasp run (`step` or `run_grasp`; None since `reset`)."""
        self.last_grasp_pose: np.ndarray | None = None
        """(4, 4) world TCP pose of the last grasp (quaternion normalised; NaN if unreadable), or None."""
        self._observation: dict[str, np.ndarray] | None = None
        self._ended, self._trials = True, 0

    # ---------------------------------------------------------------- specs
    def action_spec(self) -> dict[str, dm_env.specs.Array]:
        """`manigrasp.env.spaces.action_spec` (position, quaternion, preshape)."""
        return spaces.action_spec()

    def observation_spec(self) -> dict[str, dm_env.specs.Array]:
        """`manigrasp.env.spaces.observation_spec` with this environment's number of points."""
        return spaces.observation_spec(self.n_points)

    def reward_spec(self) -> dm_env.specs.BoundedArray:
        """A float64 scalar in [0, 1]: 1.0 for success, 0.0 otherwise."""
        return spaces.reward_spec()

    # ------------------------------------------------------------- episodes
    def reset(self) -> dm_env.TimeStep:
        """Settle the object (at a drawn yaw/position) and return the FIRST timestep.

        Raises:
            SimulationError: the object's state became non-finite while settling.
            PerceptionError: with points="depth", the camera saw no object points.
        """
        self.episode_seed = int(self._rng.integers(2**63))
        rng = np.random.default_rng(self.episode_seed)
        drop = self._drop_pose(rng)
        self.object_pose = settle_object(self.scene, drop)
        self._observation = self._observe(rng)
        self.last_result, self.last_grasp_pose, self._ended, self._trials = None, None, False, 0
        return dm_env.restart(self._observation)

    def step(self, action: Any) -> dm_env.TimeStep:
        """Execute the grasp of `action` and return the LAST timestep (reward 1.0 on success).

        After a LAST timestep, or before any `reset`, this starts a new episode instead
        (the action is ignored) and returns its FIRST timestep.
        """
        if self._ended:
            return self.reset()
        self.run_grasp(action)
        self._ended = True
        reward = 1.0 if self.last_result.status == Status.SUCCESS else 0.0
        return dm_env.termination(np.float64(reward), self._observation)

    def run_grasp(self, action: Any) -> TrialResult:
        """The `TrialResult` of executing `action` on the current episode's settled object, also kept as
        `last_result`. It does not end the episode (`step` does): several grasps can be tried on one
        settled object, as the harness runs a group's candidates. Never raises for a bad action.

        Raises:
            ConfigError: no episode has been started (`reset`).
        """
        if self.object_pose is None or self.episode_seed is None:
            raise ConfigError("call reset() before running a grasp")
        self._trials += 1
        trial_seed = int(np.random.default_rng([self.episode_seed, self._trials]).integers(2**63))
        try:
            position, quaternion, preshape = spaces.read_action(action)
        except ValueError as exc:
            return self._record(TrialResult(Status.INVALID_GRASP, detail=f"action cannot be read: {exc}"[:500],
                                            seed=trial_seed), None, math.nan)
        pose = np.concatenate([position, quaternion]) if self.action_frame == "world" \
            else spaces.to_world(position, quaternion, self.object_pose)
        problem = spaces.preshape_problem(preshape)
        if problem is not None:
            return self._record(TrialResult(Status.INVALID_GRASP, detail=problem, seed=trial_seed), pose, preshape)
        deadline = None if self.timeout_s is None else time.monotonic() + self.timeout_s
        result = self.protocol.run(self.scene, Grasp(pose=pose, preshape=preshape), np.random.default_rng(trial_seed),
                                   deadline, object_pose=self.object_pose, seed=trial_seed)
        return self._record(result, pose, preshape)

    # -------------------------------------------------------------- helpers
    def _record(self, result: TrialResult, pose: np.ndarray | None, preshape: float) -> TrialResult:
        """The result with the object's pose and the grasp filled in, as the harness stores them."""
        matrix = np.full((4, 4), np.nan) if pose is None else _pose_matrix(pose)
        self.last_grasp_pose = matrix
        self.last_result = replace(result, object_pose=PoseRecord.of(self.object_pose),
                                   grasp=PoseRecord.of(matrix), grasp_preshape=preshape)
        return self.last_result

    def _drop_pose(self, rng: np.random.Generator) -> np.ndarray:
        """(4, 4) pose the object is dropped from: its resting pose, turned by a drawn yaw, moved by a drawn x, y."""
        yaw = rng.uniform(-self.yaw_range, self.yaw_range) if self.yaw_range > 0 else 0.0
        xy = rng.uniform(-self.position_range, self.position_range, 2) if self.position_range > 0 else np.zeros(2)
        turn = np.eye(4)
        turn[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
        turn[:2, 3] = xy
        return turn @ self.scene.object_rest_pose()

    def _observe(self, rng: np.random.Generator) -> dict[str, np.ndarray]:
        pose = self.object_pose
        record = PoseRecord.of(pose)
        out = {
            "object_position": pose[:3, 3].copy(),
            "object_quaternion": np.array([record.qw, record.qx, record.qy, record.qz]),
            "object_extents": np.asarray(self.asset.extents, np.float64).copy(),
            "hand": np.array(self.scene.hand.name, dtype=object),
            "hand_max_width": np.float64(self.scene.hand.max_width),
        }
        if self.point_source == "mesh":
            out["points"], out["normals"] = _points.mesh_points(self._mesh, pose, self.n_points, rng)
        elif self.point_source == "depth":
            seed = int(rng.integers(2**31))
            out["points"], out["normals"] = _points.depth_points(self.asset, self.scene, pose, self.n_points, seed, rng)
        for key in ("normals", "object_quaternion"):  # unit vectors: keep a rounding error inside the spec's bounds
            if key in out:
                out[key] = np.clip(out[key], -1.0, 1.0)
        return out


def _pose_matrix(pose: np.ndarray) -> np.ndarray:
    """(4, 4) of a (7,) pos + quat, the quaternion normalised as the protocol reads it (NaN when it cannot be)."""
    if not np.all(np.isfinite(pose)) or np.linalg.norm(pose[3:]) == 0:
        return np.full((4, 4), np.nan)
    return PoseRecord(*(float(v) for v in pose)).matrix()
