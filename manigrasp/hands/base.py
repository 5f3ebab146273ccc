"""The `Hand` description every hand model provides.

A hand is described, not simulated, here: which MJCF builds it, which site is
its tool-centre point (TCP), which bodies are fingers, and how one scalar
"synergy" s in [0, 1] (0 = open, 1 = closed) maps to its actuator commands,
so planners and the protocol can treat a parallel jaw and a five-finger hand
alike. Simulation lives in `manigrasp.sim`.

Frame convention (DESIGN.md): in the TCP frame, z is the approach direction
(from the hand toward the object) and y is the closing direction of a parallel
jaw (finger 1 toward finger 2); x = y cross z.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal, get_args

import mujoco
import numpy as np

HandKind = Literal["parallel", "dexterous"]
HAND_KINDS: tuple[str, ...] = get_args(HandKind)  # ("parallel", "dexterous")


@dataclass(frozen=True)
class Hand:
    """Metadata and model factory of one hand.

    Attributes:
        name: registry name, e.g. "parallel_jaw".
        kind: "parallel" (two opposing jaws) or "dexterous".
        build_spec: returns a fresh `mujoco.MjSpec` of the hand alone. Its
            worldbody holds exactly one top-level body, `root_body`, with no
            joint: `manigrasp.sim` mounts it on a floating base.
        root_body: name of that top-level body.
        tcp_site: name of the TCP site (z = approach, y = closing).
        finger_bodies: bodies that count as fingers for the "two distinct
            fingers must touch" success rule; every hand geom that should
            count as touching belongs to one of these bodies or descendants.
        actuators: names of the hand's actuators, in the order of `open_ctrl`.
        open_ctrl: (n_act,) actuator commands of the open pre-shape.
        closed_ctrl: (n_act,) actuator commands of the fully closed shape.
        max_width: jaw opening [m] at s = 0 (for dexterous hands: the widest
            object the open hand can enclose).
        max_grip_force: largest grip force the hand can apply [N].
        mass: total mass of the hand [kg] (computed from the compiled model).
        source: where the model comes from (our assets, robosuite, user).
        notes: free-text facts worth showing (fixes applied at load...).
        pad_geoms: the box geoms of the finger pads that `manigrasp.hands.pads`
            makes compliant when a scene asks for ``pads: compliant`` (empty:
            the hand has no such pads and is always simulated as modelled).
        pad_backing: rigid geoms right behind the pads (a fingertip block) that lose
            their collisions with compliant pads: the pad elements then bottom out at
            their travel instead of the block taking the load after a fraction of a mm.
        grip_stiffness: how fast the grip force of a hand blocked on an object grows with the
            synergy below the force limit [N per unit synergy]: the servo's kp x the command span
            (closed - open) x the transmission from actuator force to pad force; None: unknown
            (`manigrasp.control.GripController` then estimates it from `max_grip_force`).
        fingertip_geoms: collision geoms of a dexterous hand's fingertips whose real counterparts are covered
            with rubber or silicone: with ``pads: compliant`` they touch with the pad rubber's friction
            (`manigrasp.sim.config.SceneConfig.pad_friction`) instead of the hand's (`manigrasp.sim.compose`);
            with ``pads: rigid`` they are simulated as modelled. Where the covering is sourced: the hand's notes.
    """

    name: str
    kind: HandKind
    build_spec: Callable[[], mujoco.MjSpec]
    root_body: str
    tcp_site: str
    finger_bodies: tuple[str, ...]
    actuators: tuple[str, ...]
    open_ctrl: np.ndarray
    closed_ctrl: np.ndarray
    max_width: float
    max_grip_force: float
    mass: float
    source: str = "manigrasp"
    notes: tuple[str, ...] = field(default_factory=tuple)
    pad_geoms: tuple[str, ...] = ()
    pad_backing: tuple[str, ...] = ()
    grip_stiffness: float | None = None
    fingertip_geoms: tuple[str, ...] = ()

    approach_axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    closing_axis: tuple[float, float, float] = (0.0, 1.0, 0.0)

    @property
    def n_actuators(self) -> int:
        """Number of actuated degrees of freedom of the hand."""
        return len(self.actuators)

    def synergy_ctrl(self, s: float) -> np.ndarray:
        """Actuator commands (n_act,) for synergy s in [0, 1] (0 open, 1 closed)."""
        s = float(np.clip(s, 0.0, 1.0))
        return (1.0 - s) * self.open_ctrl + s * self.closed_ctrl
