"""Can a two-jaw grasp hold the object against its weight and the protocol's perturbations? (vectorised)

Line model of a parallel-jaw grasp on contacts p (finger 1) and q (finger 2):
the jaws squeeze along the grasp line, unit axis a = (q - p) / w, width w,
midpoint o, with the grip force G. An external force F acts at the centre of
mass c (torque r x F about o, r = c - o). Each contact is a soft finger as
MuJoCo simulates it (condim 4, elliptic cone):

    (|t_i| / mu_i)^2 + (tau_i / gamma)^2 <= f_i^2

The balance of the object splits exactly (two contacts on one line):

- along a: f_1 - f_2 = -F.a; a symmetric jaw shares it, f_1,2 = G -/+ (F.a) / 2;
- across a: the tangential forces t_1 + t_2 = -F_perp and their couple
  (w / 2) a x (t_2 - t_1) = -tau_perp fix t_1 and t_2 (a tipping torque
  needs a wide grasp);
- about a: only the contacts' torsion resists tau_a = a.(r x F), the
  gravity torque m g d of a grasp a distance d from the centre of mass:
  gamma (sqrt(f_1^2 - (|t_1|/mu_1)^2) + sqrt(f_2^2 - (|t_2|/mu_2)^2)) >= |tau_a|.

`required_grip` is the smallest G meeting all three for every load (a
bisection on G, exact to `GRIP_TOLERANCE`; every condition is monotone in G).
Contact normals tilted by alpha_i from the grasp line use part of their
friction against the squeeze: mu_i = tan(atan(mu) - alpha_i) (an
approximation; exact for alpha = 0). Everything is homogeneous of degree one
in (G, loads), so the hold margin

    h = G_protocol / required_grip

is the factor by which the loads could grow before the grasp slips or turns
in the jaws (h >= 1: it holds). The loads (`loads`) are the weight alone and
the weight plus the standard protocol's perturbation (`perturbation` m g
along +-x, +-y, +-z in turn).
"""

from __future__ import annotations

import numpy as np

GRAVITY = 9.81  # [m/s^2]
GRIP_TOLERANCE = 1e-4  # relative precision of the bisection on the grip force
BISECTION_STEPS = 24  # 2^-24 of the initial bracket: well under GRIP_TOLERANCE
AXES = np.vstack([np.eye(3), -np.eye(3)])  # +x, +y, +z, -x, -y, -z


def loads(mass: float, perturbation: float = 1.0, gravity: float = GRAVITY) -> np.ndarray:
    """(7, 3) external forces on the object at its centre of mass [N]: the weight m g (down) alone, then
    the weight plus `perturbation` m g along each of +x, +y, +z, -x, -y, -z."""
    weight = np.array([0.0, 0.0, -mass * gravity])
    return np.vstack([weight, weight + perturbation * mass * gravity * AXES])


def _split(p: np.ndarray, q: np.ndarray, center: np.ndarray,
           forces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Axial load (m, L), tangential loads of contacts 1 and 2 (m, L) and |torque about the line| (m, L) [N, N m]."""
    line = q - p
    width = np.linalg.norm(line, axis=1)
    a = line / np.maximum(width, 1e-12)[:, None]
    r = center[None] - 0.5 * (p + q)  # (m, 3) from the line's midpoint to the centre of mass
    axial = np.einsum("lj,mj->ml", forces, a)  # (m, L)
    f_perp = forces[None] - axial[..., None] * a[:, None]  # (m, L, 3)
    torque = np.cross(r[:, None], forces[None])  # (m, L, 3)
    tau_a = np.einsum("mlj,mj->ml", torque, a)
    tau_perp = torque - tau_a[..., None] * a[:, None]
    couple = (2.0 / np.maximum(width, 1e-12))[:, None, None] * np.cross(a[:, None], tau_perp)
    t1 = np.linalg.norm(-f_perp - couple, axis=2) / 2.0
    t2 = np.linalg.norm(-f_perp + couple, axis=2) / 2.0
    return axial, t1, t2, np.abs(tau_a)


def effective_friction(mu: float, tilt: np.ndarray) -> np.ndarray:
    """Friction left for the load at contacts whose normal is `tilt` [rad] off the grasp line: tan(atan(mu) - tilt),
    at least 1e-9."""
    return np.maximum(np.tan(np.clip(np.arctan(mu) - np.asarray(tilt, float), 0.0, None)), 1e-9)


def required_grip(p: np.ndarray, q: np.ndarray, center: np.ndarray, forces: np.ndarray, mu: float,
                  gamma: float | np.ndarray, tilt: np.ndarray | None = None) -> np.ndarray:
    """(m,) the smallest grip force [N] with which contacts p, q (m, 3) [m] hold every one of `forces` (L, 3) [N]
    acting at `center` (3,) [m] (module docstring).

    Args:
        mu: sliding friction [-]; gamma: torsional friction of a soft finger [m], one for all or one per
            pair (m,) (e.g. scaled by how the pads sit on the surface: `footprint`); at least 1e-9.
        tilt: (m, 2) angles [rad] between each contact's inward normal and the grasp line (default 0).
    """
    m = len(p)
    if m == 0:
        return np.zeros(0)
    gamma = np.maximum(np.broadcast_to(np.asarray(gamma, float), (m,)), 1e-9)[:, None]
    tilt = np.zeros((m, 2)) if tilt is None else np.asarray(tilt, float)
    mu_eff = effective_friction(mu, tilt)  # (m, 2)
    axial, t1, t2, tau = _split(p, q, np.asarray(center, float), np.asarray(forces, float))
    need1, need2 = t1 / mu_eff[:, :1], t2 / mu_eff[:, 1:]  # (m, L) normal force each contact needs for sliding
    lo = np.maximum.reduce([need1 + axial / 2.0, need2 - axial / 2.0, np.abs(axial) / 2.0])
    hi = lo + tau / (2.0 * gamma)  # there sqrt(f^2 - need^2) >= f - need >= tau / (2 gamma) at both contacts

    def holds(grip: np.ndarray) -> np.ndarray:
        f1, f2 = grip - axial / 2.0, grip + axial / 2.0
        torsion = np.sqrt(np.clip(f1**2 - need1**2, 0.0, None)) + np.sqrt(np.clip(f2**2 - need2**2, 0.0, None))
        return gamma * torsion >= tau

    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        ok = holds(mid)
        lo, hi = np.where(ok, lo, mid), np.where(ok, mid, hi)
    return hi.max(axis=1)


def hold_margin(grip: float, required: np.ndarray) -> np.ndarray:
    """(m,) grip / required (inf where nothing is required): >= 1 where the grasp holds every load."""
    required = np.asarray(required, float)
    with np.errstate(divide="ignore"):
        return np.where(required > 0, grip / np.maximum(required, 1e-300), np.inf)
