"""A regularised Coulomb friction law with static and kinetic coefficients.

The friction force opposes the slip velocity v (tangential, [m/s]):

    f = -mu(s) * f_n * tanh(s / v_reg) * v / s,        s = |v|
    mu(s) = mu_k + (mu_s - mu_k) * exp(-(s / v_stribeck)^2)

- Continuous everywhere, zero at s = 0: ``tanh(s / v_reg) / s`` is evaluated
  as a bounded function (its limit 1 / v_reg near 0), never as a division by
  a vanishing speed.
- Its magnitude never exceeds mu_s * f_n; far above v_reg and v_stribeck it is
  the kinetic force mu_k * f_n.
- A negative normal force (separating contact) gives no friction.
"""

from __future__ import annotations

import numpy as np

from manigrasp.contact.model import ContactError

SMALL_SPEED_FACTOR = 1e-8
"""Below SMALL_SPEED_FACTOR * v_reg, tanh(s / v_reg) / s is replaced by its limit 1 / v_reg."""


def _tanh_over_speed(speed: np.ndarray, v_reg: float) -> np.ndarray:
    """tanh(speed / v_reg) / speed, bounded and smooth at speed = 0 [s/m]."""
    small = speed < SMALL_SPEED_FACTOR * v_reg
    safe = np.where(small, 1.0, speed)
    return np.where(small, 1.0 / v_reg, np.tanh(speed / v_reg) / safe)


def friction_coefficient(speed: np.ndarray, mu_s: float, mu_k: float, v_stribeck: float) -> np.ndarray:
    """Slip-speed-dependent coefficient: mu_s at rest, decaying smoothly to mu_k."""
    speed = np.asarray(speed, dtype=float)
    return mu_k + (mu_s - mu_k) * np.exp(-((speed / v_stribeck) ** 2))


def coulomb_friction(
    slip_velocity: np.ndarray,
    normal_force: np.ndarray | float,
    mu_s: float,
    mu_k: float,
    v_reg: float = 1e-3,
    v_stribeck: float = 1e-2,
) -> np.ndarray:
    """Friction force opposing slip, continuous at zero slip speed.

    Args:
        slip_velocity: (..., k) tangential slip velocity [m/s] (k = 2 or 3).
        normal_force: (...,) normal force magnitude [N]; values < 0 give no friction.
        mu_s: static coefficient (>= mu_k).
        mu_k: kinetic coefficient (>= 0).
        v_reg: regularisation speed [m/s]: the force reaches tanh(1) = 76% of
            its Coulomb value at this slip speed.
        v_stribeck: speed [m/s] over which mu falls from mu_s to mu_k.

    Returns:
        (..., k) friction force [N].
    """
    if not 0.0 <= mu_k <= mu_s:
        raise ContactError(f"need 0 <= mu_k <= mu_s, got mu_k={mu_k}, mu_s={mu_s}")
    if v_reg <= 0.0 or v_stribeck <= 0.0:
        raise ContactError("v_reg and v_stribeck must be > 0 [m/s]")
    v = np.asarray(slip_velocity, dtype=float)
    speed = np.linalg.norm(v, axis=-1)
    f_n = np.maximum(np.asarray(normal_force, dtype=float), 0.0)
    scale = friction_coefficient(speed, mu_s, mu_k, v_stribeck) * f_n * _tanh_over_speed(speed, v_reg)
    return -scale[..., None] * v
