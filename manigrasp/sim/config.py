"""`SceneConfig`: the physics and scene parameters of one compiled scene.

Defaults are DESIGN.md's standard protocol: 2 ms steps, `implicitfast`,
elliptic friction cones, impratio 10, hand-object friction 0.5, gravity on,
the object resting on a table whose top is the plane z = 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco

from manigrasp.config import OMIT_DEFAULT
from manigrasp.contact.defaults import STANDARD_GRAVITY, STANDARD_MU, STANDARD_TORSION_M
from manigrasp.errors import ConfigError
from manigrasp.hands.pads import PAD_FRICTION, PadModel

INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
}
PAD_MODES = ("compliant", "rigid")
REST_MODES = ("file", "most_stable", "stable_k")
MAX_REST_K = 64
"""Upper bound of `SceneConfig.rest_k` (each resting pose is a group of trials)."""
CONES = {"pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL, "elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC}


LEGACY_SCENE = {"ccd_tolerance": 1e-6}
"""Scene parameters added after runs were recorded, with the value such a run used (MuJoCo's default then): a
recorded config without one ran at it (`with_legacy_scene`), not at today's default."""


def with_legacy_scene(config: dict) -> dict:
    """A copy of a recorded config (run.json's ``config``) whose scene holds each `LEGACY_SCENE` parameter it lacks, at
    the value the run used: replay, resume checks and reports then read the physics the run had."""
    scene = config.get("scene")
    if scene is not None and not isinstance(scene, dict):
        return config
    missing = {k: v for k, v in LEGACY_SCENE.items() if k not in (scene or {})}
    return {**config, "scene": {**(scene or {}), **missing}} if missing else config


@dataclass(frozen=True)
class SceneConfig:
    """Physics and scene parameters (every number a config field).

    Attributes:
        timestep: simulation step [s].
        integrator: one of "euler", "rk4", "implicit", "implicitfast".
        cone: friction cone, "elliptic" or "pyramidal".
        impratio: ratio of frictional to normal constraint impedance [-].
        gravity: (3,) [m/s^2].
        ccd_tolerance: MuJoCo's convex collision tolerance [m] (`opt.ccd_tolerance`, 1e-6 by default): its EPA
            stops refining a penetration there, and a contact shallower than about that could come back with its
            normal reversed. The compliant pads' ellipsoid elements meet objects at such depths: on quick, at
            1e-6, 124 of 200 compliant trials had reversed element contacts (4,451 contact-steps, 26 of them
            over 10 N, up to 79 N), at 1e-9 none above 0.07 N; no outcome of quick changed, rigid pads' and
            dexterous hands' trials are bit for bit the same (their contacts are between flat faces or deeper),
            and a compliant step costs about 6 % more (`manigrasp.sim.padtest`, the validation rig, found it).
        hand_friction: sliding friction of every hand collision geom; the hand
            geoms get a higher contact priority than the object and table, so
            this is the hand-object (and hand-table) friction coefficient [-].
        hand_torsional_friction: torsional friction of hand geoms [m].
        hand_condim: contact dimensionality of hand geoms (4: soft finger).
        hand_gravcomp: compensate the hand's weight in MuJoCo (body gravcomp
            = 1 on every hand body). If False, `control.ImpedanceController`
            adds the gravity term itself.
        table_half_extents: (3,) half sizes of the table box [m]; its top is z = 0.
        table_friction: sliding friction of the table [-].
        open_settle_time: simulated time [s] the hand alone is driven with its
            open command to find its open joint configuration (done once per scene).
        pads: "compliant" (the default: the hands' pad boxes become elastic-foundation
            patches, `manigrasp.hands.pads`, and a dexterous hand's rubber-covered fingertips,
            `Hand.fingertip_geoms`, touch with `pad_friction`) or "rigid" (the pad boxes as
            modelled, at `hand_friction`: the model of runs before the switch, kept to reproduce
            them; every run.json records which).
        pad_modulus: Young's modulus of the compliant pads' rubber [Pa].
        pad_pitch: longest side of a compliant pad's cells, one contact element each [m]: the face is cut
            into the fewest equal cells no longer than it, at least 2 x 2 (`manigrasp.hands.pads.cell_sides`).
        pad_friction: sliding friction of the compliant pads' rubber against objects [-]
            (sourced in `manigrasp.hands.pads`), and of a dexterous hand's fingertips with
            compliant pads; rigid pads and the rest of the hand use `hand_friction`.
        rest: the object's resting orientation before it settles: "file" (as its mesh
            file has it), "most_stable" (the most probable quasi-static stable pose,
            `manigrasp.objects.poses`) or "stable_k" (the `rest_k` most probable poses, each
            a group of its own: `manigrasp.bench.trials` sets `rest_index` per group).
        rest_k: how many stable poses "stable_k" runs (required with it, refused otherwise); an
            object with fewer stable poses runs as many as it has.
        rest_index: the stable pose of this scene, by rank (0: the most probable); above 0 only
            with "stable_k", below `rest_k`. Set per group by the benchmark's enumeration.
        rest_k and rest_index are left out of run.json while at their defaults, so a config
            that does not use them keeps its run identity and compares with older baselines.
    """

    timestep: float = 0.002
    integrator: str = "implicitfast"
    cone: str = "elliptic"
    impratio: float = 10.0
    gravity: tuple[float, float, float] = (0.0, 0.0, -STANDARD_GRAVITY)
    ccd_tolerance: float = 1e-9
    hand_friction: float = STANDARD_MU
    hand_torsional_friction: float = STANDARD_TORSION_M
    hand_condim: int = 4
    hand_gravcomp: bool = True
    table_half_extents: tuple[float, float, float] = (0.4, 0.4, 0.02)
    table_friction: float = STANDARD_MU
    open_settle_time: float = 0.5
    pads: str = "compliant"
    pad_modulus: float = 3.4e5
    pad_pitch: float = 0.015
    pad_friction: float = PAD_FRICTION
    rest: str = "file"
    rest_k: int | None = field(default=None, metadata={OMIT_DEFAULT: True})
    rest_index: int = field(default=0, metadata={OMIT_DEFAULT: True})

    def __post_init__(self) -> None:
        if self.integrator not in INTEGRATORS:
            raise ConfigError(f"unknown integrator {self.integrator!r}; available: {', '.join(INTEGRATORS)}")
        if self.cone not in CONES:
            raise ConfigError(f"unknown cone {self.cone!r}; available: {', '.join(CONES)}")
        if self.pads not in PAD_MODES:
            raise ConfigError(f"unknown pads {self.pads!r}; available: {', '.join(PAD_MODES)}")
        if self.rest not in REST_MODES:
            raise ConfigError(f"unknown rest {self.rest!r}; available: {', '.join(REST_MODES)}")
        self._check_rest_k()
        if self.hand_condim not in (1, 3, 4, 6):
            raise ConfigError(f"hand_condim must be 1, 3, 4 or 6, got {self.hand_condim}")
        positive = {"pad_modulus": self.pad_modulus, "pad_pitch": self.pad_pitch, "pad_friction": self.pad_friction,
                    "timestep": self.timestep, "ccd_tolerance": self.ccd_tolerance,
                     "impratio": self.impratio, "table_friction": self.table_friction}
        for key, value in positive.items():
            if not value > 0:
                raise ConfigError(f"{key} must be > 0, got {value}")
        if self.hand_friction < 0 or self.open_settle_time < 0:
            raise ConfigError("hand_friction and open_settle_time must be >= 0")
        if len(self.gravity) != 3 or len(self.table_half_extents) != 3 or min(self.table_half_extents) <= 0:
            raise ConfigError("gravity and table_half_extents must have 3 components (extents > 0)")

    def _check_rest_k(self) -> None:
        if self.rest == "stable_k":
            if self.rest_k is None or not 1 <= self.rest_k <= MAX_REST_K:
                raise ConfigError(f"rest: stable_k needs rest_k, the number of stable poses to run, in 1..{MAX_REST_K}"
                                  f" (got {self.rest_k})")
            if not 0 <= self.rest_index < self.rest_k:
                raise ConfigError(f"rest_index must be in 0..{self.rest_k - 1} (rest_k {self.rest_k}), "
                                  f"got {self.rest_index}")
        elif self.rest_k is not None or self.rest_index != 0:
            raise ConfigError(f"rest_k and rest_index apply to rest: stable_k only (rest is {self.rest!r})")

    def pad_model(self) -> PadModel:
        """The compliant pads' parameters (`manigrasp.hands.pads`) of this scene."""
        return PadModel(modulus=self.pad_modulus, pitch=self.pad_pitch, timestep=self.timestep,
                        friction=self.pad_friction)

    def apply(self, option: mujoco.MjOption | object) -> None:
        """Write the physics options into a spec's or model's `option`."""
        option.timestep = self.timestep
        option.integrator = INTEGRATORS[self.integrator]
        option.cone = CONES[self.cone]
        option.impratio = self.impratio
        option.gravity = list(self.gravity)
        option.ccd_tolerance = self.ccd_tolerance
