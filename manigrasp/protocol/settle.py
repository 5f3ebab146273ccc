"""Settle: let the object come to rest on the table; its resting pose is what the planner sees."""

from __future__ import annotations

import numpy as np

from manigrasp.control import NativeImpedance, default_gains
from manigrasp.errors import SimulationError
from manigrasp.protocol.observer import TrialObserver
from manigrasp.protocol.sampling import Sampler
from manigrasp.sim import Scene


def parked_mount(scene: Scene, height: float) -> np.ndarray:
    """(4, 4) TCP pose `height` [m] above the table, pointing down: the hand out of the way."""
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[2, 3] = height
    return pose


def settle_object(scene: Scene, object_pose: np.ndarray | None = None, duration_s: float = 2.0,
                  min_duration_s: float = 0.2, speed_tol: float = 1e-3, park_height: float = 0.6,
                  check_period_s: float = 0.02, observer: TrialObserver | None = None,
                  sampler: Sampler | None = None) -> np.ndarray:
    """Drop the object onto the table from `object_pose` and return its (4, 4) resting pose.

    The open hand is held `park_height` [m] above the table by the base servos
    (`control.NativeImpedance`) meanwhile. Stepping stops once the object moves
    slower than `speed_tol` [m/s, rad/s] after at least `min_duration_s` [s]
    (checked every `check_period_s` [s]), or after `duration_s` [s] (then the pose
    reached is returned: a slowly rocking object is still planned on). Deterministic.

    Args:
        scene: a compiled scene (it is reset).
        object_pose: (4, 4) starting pose (default: upright on the table at x = y = 0).
        observer: sampled while settling (its samples never change the outcome), or None.
        sampler: the trial's stepper, if settling is part of a trial (default: one for `observer`).

    Raises:
        SimulationError: the object's state becomes non-finite.
    """
    mount = parked_mount(scene, park_height)
    scene.reset(mount=mount, object_pose=object_pose)
    hold = NativeImpedance(scene.base, default_gains(scene.base))
    hold.engage()
    hold.set_target(mount)
    sampler = sampler or Sampler(scene, observer)
    chunk = max(1, round(check_period_s / scene.model.opt.timestep))
    body = scene.object_body
    while scene.time < duration_s:
        sampler.advance(chunk)
        if not scene.is_finite():
            raise SimulationError("the object's state became non-finite while settling on the table")
        speed = float(np.abs(scene.data.cvel[body]).max())
        if scene.time >= min_duration_s and speed < speed_tol:
            return scene.object_pose()
    return scene.object_pose()
