"""The specs of `GraspEnv` (dm_env.specs) and how an action becomes a grasp.

An action is a dict of arrays (`action_spec`):

- ``position`` (3,) float64 [m]: the TCP's position,
- ``quaternion`` (4,) float64, (w, x, y, z), unit: the TCP's orientation (z = approach,
  y = closing direction of a parallel jaw; DESIGN.md's TCP convention),
- ``preshape`` () float64 in [0, 1]: the hand's open pre-shape synergy (0 = fully open),

in the world frame or in the settled object's frame (`GraspEnv(action_frame=...)`).
Nothing here decides whether a pose is valid: `action_grasp` passes the pose on as
(pos, quat) and the protocol's own check (the benchmark's rule) judges it, so an
action is refused exactly when a planner's grasp would be. The one thing checked
here is what the protocol does not see in a (pos, quat) pose: an action that cannot
be read as numbers of the right shapes, and a pre-shape outside [0, 1].
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np
from dm_env import specs

ACTION_FRAMES = ("world", "object")
ACTION_KEYS = ("position", "quaternion", "preshape")


def action_spec() -> dict[str, specs.Array]:
    """The spec of one action (a grasp): see the module docstring."""
    return {
        "position": specs.Array((3,), np.float64, name="position"),
        "quaternion": specs.BoundedArray((4,), np.float64, -1.0, 1.0, name="quaternion"),
        "preshape": specs.BoundedArray((), np.float64, 0.0, 1.0, name="preshape"),
    }


def observation_spec(n_points: int) -> dict[str, specs.Array]:
    """The spec of one observation; ``points``/``normals`` only when `n_points` > 0.

    Keys: ``object_position`` (3,) [m] and ``object_quaternion`` (4,) (w, x, y, z, w >= 0): the
    settled object's true pose in the world (the frame of ``action_frame="object"``);
    ``object_extents`` (3,) [m]: its bounding box in its own frame; ``points``/``normals``
    (n_points, 3): surface points [m] and outward unit normals in the world; ``hand`` (): the
    hand's name; ``hand_max_width`` () [m]: the open hand's jaw opening.
    """
    out: dict[str, specs.Array] = {
        "object_position": specs.Array((3,), np.float64, name="object_position"),
        "object_quaternion": specs.BoundedArray((4,), np.float64, -1.0, 1.0, name="object_quaternion"),
        "object_extents": specs.BoundedArray((3,), np.float64, 0.0, np.inf, name="object_extents"),
        "hand": specs.StringArray((), name="hand"),
        "hand_max_width": specs.BoundedArray((), np.float64, 0.0, np.inf, name="hand_max_width"),
    }
    if n_points > 0:
        out["points"] = specs.Array((n_points, 3), np.float64, name="points")
        out["normals"] = specs.BoundedArray((n_points, 3), np.float64, -1.0, 1.0, name="normals")
    return out


def reward_spec() -> specs.BoundedArray:
    """1.0 for a successful trial, 0.0 for any other status."""
    return specs.BoundedArray((), np.float64, 0.0, 1.0, name="reward")


def read_action(action: Any) -> tuple[np.ndarray, np.ndarray, float]:
    """(position (3,), quaternion (4,), preshape) of an action, as floats, unchecked in value.

    Raises:
        ValueError: the action is not a mapping with the three keys of the right shapes.
    """
    if not isinstance(action, Mapping):
        raise ValueError(f"an action is a dict with keys {', '.join(ACTION_KEYS)}, got {type(action).__name__}")
    missing = [key for key in ACTION_KEYS if key not in action]
    if missing:
        raise ValueError(f"the action has no {', '.join(missing)} (keys: {', '.join(ACTION_KEYS)})")
    try:
        position = np.asarray(action["position"], dtype=float)
        quaternion = np.asarray(action["quaternion"], dtype=float)
        preshape = np.asarray(action["preshape"], dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"the action's values are not numbers: {exc}") from exc
    if position.shape != (3,) or quaternion.shape != (4,) or preshape.size != 1:
        raise ValueError(f"position must be (3,), quaternion (4,) and preshape a scalar, got {position.shape}, "
                         f"{quaternion.shape}, {preshape.shape}")
    return position, quaternion, float(preshape.reshape(()))


def preshape_problem(preshape: float) -> str | None:
    """Why `preshape` cannot be executed (the protocol's wording), or None."""
    if not (np.isfinite(preshape) and 0.0 <= preshape <= 1.0):
        return f"pre-shape must be in [0, 1], got {preshape}"
    return None


def to_world(position: np.ndarray, quaternion: np.ndarray, object_pose: np.ndarray) -> np.ndarray:
    """(7,) world (pos, quat) of a TCP pose given in the frame of `object_pose` (4, 4).

    The quaternion is composed by a Hamilton product, which keeps its norm: a non-unit
    (or NaN) quaternion stays non-unit (NaN) for the protocol to refuse.
    """
    object_quat = np.empty(4)
    mujoco.mju_mat2Quat(object_quat, np.ascontiguousarray(object_pose[:3, :3], float).ravel())
    quat = np.empty(4)
    mujoco.mju_mulQuat(quat, object_quat, np.ascontiguousarray(quaternion, float))
    return np.concatenate([object_pose[:3, :3] @ position + object_pose[:3, 3], quat])
