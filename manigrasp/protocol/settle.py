"""Settle: let the object come to rest on the table; its resting pose is what the planner sees."""

from __future__ import annotations

import numpy as np

from manigrasp.control import ImpedanceController, default_gains
from manigrasp.errors import SimulationError
from manigrasp.sim import Scene


def parked_mount(scene: Scene, height: float) -> np.ndarray:
    """(4, 4) TCP pose `height` [m] above the table, pointing down: the hand out of the way."""
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[2, 3] = height
    return pose


def settle_object(scene: Scene, object_pose: np.ndarray | None = None, duration_s: float = 2.0,
                  min_duration_s: float = 0.2, speed_tol: float = 1e-3, park_height: float = 0.6) -> np.ndarray:
    """Drop the object onto the table from `object_pose` and return its (4, 4) resting pose.

    The open hand is held `park_height` [m] above the table meanwhile. Stepping
    stops once the object moves slower than `speed_tol` [m/s, rad/s] after at
    least `min_duration_s` [s], or after `duration_s` [s] (then the pose reached
    is returned: a slowly rocking object is still planned on). Deterministic.

    Args:
        scene: a compiled scene (it is reset).
        object_pose: (4, 4) starting pose (default: upright on the table at x = y = 0).

    Raises:
        SimulationError: the object's state becomes non-finite.
    """
    mount = parked_mount(scene, park_height)
    scene.reset(mount=mount, object_pose=object_pose)
    hold = ImpedanceController(scene.base, default_gains(scene.base))
    hold.set_target(mount)
    dt = scene.model.opt.timestep
    chunk = max(1, round(0.02 / dt))
    body = scene.object_body
    while scene.time < duration_s:
        for _ in range(chunk):
            hold.apply()
            scene.step()
        if not scene.is_finite():
            raise SimulationError("the object's state became non-finite while settling on the table")
        speed = float(np.abs(scene.data.cvel[body]).max())
        if scene.time >= min_duration_s and speed < speed_tol:
            return scene.object_pose()
    return scene.object_pose()
