"""Can a hand hold an object? The load a protocol puts on a frictional grasp against the squeeze a hand gives.

Pure math (NumPy and SciPy, no MuJoCo, no I/O); every function takes scalars or arrays and broadcasts.

The model. An object of mass m squeezed with total normal force sum(f_n) by contacts of friction coefficient
mu carries at most mu sum(f_n) of load by friction, in any direction the contact normals do not cover
(Coulomb; the elliptic cone of each contact, summed). A grasp of an object resting on a table comes from
above or the side, so nothing supports the object from below: the load along gravity is carried by friction
alone, and the worst direction of the `standard` protocol is gravity plus the downward perturbation,
(1 + k) m g with k = `perturb_force_multiple` (1). DexGraspBench's `six_direction` is gravity-free with
k = `force_multiple` (1.02: 10 N per kg). A squeeze between a thumb side and a finger side, each pushing
with the grip force F (`manigrasp.sim.grip_force`, what the protocol regulates), has sum(f_n) = rho F with
rho >= 2 (2 for a balanced two-sided squeeze, more when the fingers also press each other's sides of the
object); so the grip it needs is F >= (g_on + k) m g / (rho mu).

Fingertips on thin objects. A fingertip of radius r closing on an object of height h < r lying on the table
cannot reach its side face (its centre stays at least r above the table): it touches the top edge, the
contact normal tilted down by theta = asin((r - h) / r). A two-sided squeeze along such normals pushes the
object down with 2 F sin(theta) while friction lifts with at most 2 mu F cos(theta): the effective
coefficient against the vertical load, per unit of contact normal force F, is mu cos(theta) - sin(theta),
zero at theta = atan(mu) (`friction_per_normal_force`). Per unit of the squeeze along the grasp line instead
(the normal force's component along it plus its friction's, cos(theta) + mu sin(theta) per unit of F) it is
tan(atan(mu) - theta) (`friction_per_squeeze`, the planners' two-jaw hold model, `manigrasp.planners.hold`):
the same friction cone tilted by theta, measured against a different force.

Sizes. A hand closes across an object's narrowest horizontal width (its resting pose's minimum caliper
width, `min_width_2d`) at most as wide as the open hand's aperture between thumb and fingertips.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from manigrasp.contact.defaults import STANDARD_GRAVITY
from manigrasp.errors import ConfigError

BALANCED_SQUEEZE = 2.0  # sum(f_n) / grip force of a balanced two-sided squeeze [-]


def _positive(name: str, value: np.ndarray | float) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ConfigError(f"{name} must be finite and > 0, got {value}")
    return arr


def frictional_load(mass: np.ndarray | float, perturb_multiple: float = 1.0, gravity: bool = True,
                    g: float = STANDARD_GRAVITY) -> np.ndarray:
    """Largest load [N] friction must carry: (1 + k) m g with gravity on, k m g without (`six_direction`).

    Args:
        mass: object mass(es) [kg], > 0.
        perturb_multiple: the perturbation's magnitude in units of m g [-], >= 0.
        gravity: the protocol keeps gravity on (`standard`) or switches it off (`six_direction`).
        g: gravitational acceleration [m/s^2].
    """
    mass = _positive("mass", mass)
    if not perturb_multiple >= 0:
        raise ConfigError(f"perturb_multiple must be >= 0, got {perturb_multiple}")
    return (float(gravity) + perturb_multiple) * mass * g


def edge_tilt(height: np.ndarray | float, tip_radius: float) -> np.ndarray:
    """Downward tilt [rad] of a fingertip's contact normal on an object `height` [m] tall (0 if height >= r)."""
    height = _positive("height", height)
    radius = float(_positive("tip_radius", tip_radius))
    return np.arcsin(np.clip((radius - height) / radius, 0.0, 1.0))


def friction_per_squeeze(mu: np.ndarray | float, tilt: np.ndarray | float = 0.0) -> np.ndarray:
    """The load [N] friction carries across a squeeze line per N of squeeze along it, at contacts whose normals
    tilt by `tilt` [rad] from the line against the load: tan(atan(mu) - tilt), the friction cone's half-angle
    left beyond the tilt (clipped at 0: past the cone the squeeze only pushes the object out).

    Per N of the contacts' normal force instead: `friction_per_normal_force`."""
    mu = _positive("mu", mu)
    return np.tan(np.clip(np.arctan(mu) - np.asarray(tilt, dtype=float), 0.0, None))


def friction_per_normal_force(mu: np.ndarray | float, tilt: np.ndarray | float = 0.0) -> np.ndarray:
    """The load [N] friction carries across a squeeze line per N of the contacts' normal force, at contacts whose
    normals tilt by `tilt` [rad] from the line against the load: mu cos(tilt) - sin(tilt) (clipped at 0: past
    the cone the squeeze only pushes the object out). It is `friction_per_squeeze` times the squeeze per N of
    normal force at the cone's edge, cos(tilt) + mu sin(tilt) (module docstring), written out here so that
    neither rounds through the other (tan(atan(0.5)) is 0.49999999999999994).

    Per N of squeeze along the line instead: `friction_per_squeeze`."""
    mu = _positive("mu", mu)
    tilt = np.asarray(tilt, dtype=float)
    return np.clip(mu * np.cos(tilt) - np.sin(tilt), 0.0, None)


def required_normal_force(load: np.ndarray | float, mu_eff: np.ndarray | float) -> np.ndarray:
    """Total normal force [N] whose friction carries `load` [N]: load / mu_eff (inf where mu_eff is 0)."""
    load = np.asarray(load, dtype=float)
    mu_eff = np.asarray(mu_eff, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where(mu_eff > 0, load / np.where(mu_eff > 0, mu_eff, 1.0), np.inf)


def required_grip(load: np.ndarray | float, mu_eff: np.ndarray | float,
                  squeeze_ratio: np.ndarray | float = BALANCED_SQUEEZE) -> np.ndarray:
    """Grip force [N] (thumb side against finger side) whose squeeze carries `load`: load / (rho mu_eff)."""
    return required_normal_force(load, mu_eff) / _positive("squeeze_ratio", squeeze_ratio)


def max_mass(grip: np.ndarray | float, mu_eff: np.ndarray | float, perturb_multiple: float = 1.0,
             gravity: bool = True, squeeze_ratio: np.ndarray | float = BALANCED_SQUEEZE,
             g: float = STANDARD_GRAVITY) -> np.ndarray:
    """Heaviest object [kg] a grip force `grip` [N] holds: rho mu_eff F / ((g_on + k) g)."""
    per_kg = float(frictional_load(1.0, perturb_multiple, gravity, g))
    grip = np.asarray(grip, dtype=float)
    return np.asarray(squeeze_ratio, dtype=float) * np.asarray(mu_eff, dtype=float) * grip / per_kg


def min_width_2d(points: np.ndarray) -> tuple[float, np.ndarray]:
    """Minimum caliper width [m] of planar points (n, 2) and the unit direction (2,) it is measured along.

    The narrowest strip holding every point is bounded by a line through an edge of their convex hull
    (rotating calipers), so only the hull's edge normals are tried.
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3 or not np.all(np.isfinite(pts)):
        raise ConfigError(f"min_width_2d needs (n >= 3, 2) finite points, got shape {pts.shape}")
    try:
        hull = pts[ConvexHull(pts).vertices]
    except QhullError:
        raise ConfigError("min_width_2d: the points are collinear (a flat strip has no width)") from None
    edges = np.roll(hull, -1, axis=0) - hull
    normals = np.column_stack([-edges[:, 1], edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]
    proj = hull @ normals.T  # (n_vertices, n_edges)
    widths = proj.max(axis=0) - proj.min(axis=0)
    best = int(np.argmin(widths))
    return float(widths[best]), normals[best]


@dataclass(frozen=True)
class HoldCheck:
    """Whether one hand can hold one object under one protocol, and why.

    Attributes:
        fits: the hand closes on the object's grasp width from both sides.
        mu_eff: effective friction coefficient (after a thin object's edge tilt), per unit of normal force
            (`friction_per_normal_force`) [-].
        load: the load friction must carry [N].
        required: total normal force that carries it [N] (inf if mu_eff is 0).
        available: total normal force of the hand's squeeze [N].
        verdict: "holdable", "does not fit", "too thin" (edge contact outside the friction cone) or "too heavy".
    """

    fits: bool
    mu_eff: float
    load: float
    required: float
    available: float
    verdict: str

    @property
    def margin(self) -> float:
        """available / required [-] (>= 1: the squeeze carries the load by friction)."""
        return self.available / self.required if self.required > 0 else float("inf")


def check_hold(fits: bool, height: float, mass: float, tip_radius: float, available_normal: float, mu: float,
               perturb_multiple: float = 1.0, gravity: bool = True, g: float = STANDARD_GRAVITY) -> HoldCheck:
    """Size first, then the edge contact, then strength: the first criterion that fails is the verdict.

    Args:
        fits: the hand closes on the object's grasp width from both sides (e.g. width <= aperture).
        height: the object's height at rest [m].
        mass: [kg].
        tip_radius: the fingertips' radius (half their thickness) [m].
        available_normal: total normal force [N] the hand's squeeze puts on the object.
        mu: hand-object friction coefficient [-].
        perturb_multiple, gravity, g: the protocol's load (`frictional_load`).
    """
    mu_eff = float(friction_per_normal_force(mu, edge_tilt(height, tip_radius)))
    load = float(frictional_load(mass, perturb_multiple, gravity, g))
    required = float(required_normal_force(load, mu_eff))
    if not fits:
        verdict = "does not fit"
    elif mu_eff <= 0:
        verdict = "too thin"
    elif available_normal >= required:
        verdict = "holdable"
    else:
        verdict = "too heavy"
    return HoldCheck(fits, mu_eff, load, required, float(available_normal), verdict)
