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
  needs a wide grasp); with pads (`support`, from `footprint.patch_support`)
  each pad's normal pressure first takes up to f_i e_i of each component of
  tau_perp (e_i: how far its centre of pressure can move along the other
  axis of its face), and the couple only what is left;
- about a: only the contacts' torsion resists tau_a = a.(r x F), the
  gravity torque m g d of a grasp a distance d from the centre of mass:
  gamma (sqrt(f_1^2 - (|t_1|/mu_1)^2) + sqrt(f_2^2 - (|t_2|/mu_2)^2)) >= |tau_a|.

`required_grip` is the smallest G meeting all three for every load (a
bisection on G, exact to `GRIP_TOLERANCE`; every condition is monotone in G).
Contact normals tilted by alpha_i from the grasp line use part of their
friction against the squeeze: mu_i = tan(atan(mu) - alpha_i), the load
carried across the line per unit of squeeze along it
(`hands.capacity.friction_per_squeeze`; an approximation; exact for
alpha = 0). Everything is homogeneous of degree one in (G, loads), so the
hold margin

    h = G_protocol / required_grip

is the factor by which the loads could grow before the grasp slips or turns
in the jaws (h >= 1: it holds). The loads (`loads`) are the weight alone and
the weight plus the standard protocol's perturbation (`perturbation` m g
along +-x, +-y, +-z in turn).
"""

from __future__ import annotations

import numpy as np

from manigrasp.contact.defaults import STANDARD_GRAVITY as GRAVITY  # [m/s^2]
from manigrasp.hands.capacity import friction_per_squeeze

GRIP_TOLERANCE = 1e-4  # relative precision of the bisection on the grip force
BISECTION_STEPS = 24  # 2^-24 of the initial bracket: well under GRIP_TOLERANCE
AXES = np.vstack([np.eye(3), -np.eye(3)])  # +x, +y, +z, -x, -y, -z


def loads(mass: float, perturbation: float = 1.0, gravity: float = GRAVITY) -> np.ndarray:
    """(7, 3) external forces on the object at its centre of mass [N]: the weight m g (down) alone, then
    the weight plus `perturbation` m g along each of +x, +y, +z, -x, -y, -z."""
    weight = np.array([0.0, 0.0, -mass * gravity])
    return np.vstack([weight, weight + perturbation * mass * gravity * AXES])


def _split(p: np.ndarray, q: np.ndarray, center: np.ndarray,
           forces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Unit axis (m, 3) and width (m,) of the grasp line, axial load (m, L), load across the line (m, L, 3),
    torque across the line (m, L, 3) and |torque about the line| (m, L) [N, N m]."""
    line = q - p
    width = np.linalg.norm(line, axis=1)
    a = line / np.maximum(width, 1e-12)[:, None]
    r = center[None] - 0.5 * (p + q)  # (m, 3) from the line's midpoint to the centre of mass
    axial = np.einsum("lj,mj->ml", forces, a)  # (m, L)
    f_perp = forces[None] - axial[..., None] * a[:, None]  # (m, L, 3)
    torque = np.cross(r[:, None], forces[None])  # (m, L, 3)
    tau_a = np.einsum("mlj,mj->ml", torque, a)
    tau_perp = torque - tau_a[..., None] * a[:, None]
    return a, width, axial, f_perp, tau_perp, np.abs(tau_a)


def _tangential(a: np.ndarray, width: np.ndarray, f_perp: np.ndarray,
                tau_perp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """|tangential load| of contacts 1 and 2 (m, L) [N]: their sum balances the load across the line, their
    couple (arm: the width) the torque across it."""
    couple = (2.0 / np.maximum(width, 1e-12))[:, None, None] * np.cross(a[:, None], tau_perp)
    return np.linalg.norm(-f_perp - couple, axis=2) / 2.0, np.linalg.norm(-f_perp + couple, axis=2) / 2.0


def required_grip(p: np.ndarray, q: np.ndarray, center: np.ndarray, forces: np.ndarray, mu: float,
                  gamma: float | np.ndarray, tilt: np.ndarray | None = None,
                  support: np.ndarray | None = None, across: np.ndarray | None = None) -> np.ndarray:
    """(m,) the smallest grip force [N] with which contacts p, q (m, 3) [m] hold every one of `forces` (L, 3) [N]
    acting at `center` (3,) [m] (module docstring).

    Args:
        mu: sliding friction [-]; gamma: torsional friction of a soft finger [m], one for all or one per
            pair (m,) (e.g. scaled by how the pads sit on the surface: `footprint`); at least 1e-9.
        tilt: (m, 2) angles [rad] between each contact's inward normal and the grasp line (default 0).
        support: (m, 2, 2) [m] how far each pad's (1, 2) centre of pressure can move, along `across` and along
            the third axis a x `across`, before part of its patch lets go (`footprint.patch_support`): a pad
            pressed with f resists up to f times that of the torque across the line about the other axis
            with its normal pressure, on top of the contacts' friction couple. None: points (no such moment).
        across: (m, 3) unit vectors across the grasp line (the pads' faces' first axis); with `support`.
    """
    m = len(p)
    if m == 0:
        return np.zeros(0)
    gamma = np.maximum(np.broadcast_to(np.asarray(gamma, float), (m,)), 1e-9)[:, None]
    tilt = np.zeros((m, 2)) if tilt is None else np.asarray(tilt, float)
    mu_eff = np.maximum(friction_per_squeeze(mu, tilt), 1e-9)  # (m, 2); 0 past the cone: no load is held
    a, width, axial, f_perp, tau_perp, tau = _split(p, q, np.asarray(center, float), np.asarray(forces, float))
    t1, t2 = _tangential(a, width, f_perp, tau_perp)
    need1, need2 = t1 / mu_eff[:, :1], t2 / mu_eff[:, 1:]  # (m, L) normal force each contact needs for sliding
    lo = np.maximum.reduce([need1 + axial / 2.0, need2 - axial / 2.0, np.abs(axial) / 2.0])
    hi = lo + tau / (2.0 * gamma)  # there sqrt(f^2 - need^2) >= f - need >= tau / (2 gamma) at both contacts
    if support is not None:
        # the pads' pressure only lowers what the friction must take: the point-contact requirement bounds it
        lo = np.abs(axial) / 2.0
        u = np.asarray(across, float)
        u = u - np.einsum("mj,mj->m", u, a)[:, None] * a
        u = u / np.maximum(np.linalg.norm(u, axis=1), 1e-12)[:, None]
        v = np.cross(a, u)
        tau_u, tau_v = np.einsum("mlj,mj->ml", tau_perp, u), np.einsum("mlj,mj->ml", tau_perp, v)
        f_u, f_v = np.einsum("mlj,mj->ml", f_perp, u), np.einsum("mlj,mj->ml", f_perp, v)
        arm = (2.0 / np.maximum(width, 1e-12))[:, None]
        s = np.asarray(support, float)  # torque about u: pressure moving along v, and about v: along u

    def holds(grip: np.ndarray) -> np.ndarray:
        f1, f2 = grip - axial / 2.0, grip + axial / 2.0
        n1, n2 = need1, need2
        if support is not None:
            about_u = np.maximum(np.abs(tau_u) - (f1 * s[:, :1, 1] + f2 * s[:, 1:, 1]), 0.0) * np.sign(tau_u)
            about_v = np.maximum(np.abs(tau_v) - (f1 * s[:, :1, 0] + f2 * s[:, 1:, 0]), 0.0) * np.sign(tau_v)
            # `_tangential` in the (u, v) basis: the couple (2 / w) a x (about_u u + about_v v)
            cu, cv = -arm * about_v, arm * about_u
            n1 = np.hypot(f_u + cu, f_v + cv) / 2.0 / mu_eff[:, :1]
            n2 = np.hypot(f_u - cu, f_v - cv) / 2.0 / mu_eff[:, 1:]
        ok = (f1 >= n1) & (f2 >= n2)
        torsion = np.sqrt(np.clip(f1**2 - n1**2, 0.0, None)) + np.sqrt(np.clip(f2**2 - n2**2, 0.0, None))
        return ok & (gamma * torsion >= tau)

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
