"""Analytic metrics of planned contacts, through `manigrasp.grasp` (batched).

Planned contacts are modelled as MuJoCo's hand contacts are simulated: soft
fingers (condim 4) with sliding friction `mu` and torsional coefficient
`gamma` [m]. Torques are taken about the object's centre of mass and divided
by `torque_scale`, the object's radius about its centre of mass (largest
distance of a surface vertex from it) [m].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.contact import ContactSet, ContactType
from manigrasp.contact.defaults import STANDARD_MU, STANDARD_TORSION_M
from manigrasp.grasp import ferrari_canny_batch, min_friction_for_closure_batch
from manigrasp.grasp.closure import EPSILON_TOLERANCE

MIN_FRICTION_TOLERANCE = 1e-3  # [-], bisection tolerance of the minimum friction


@dataclass(frozen=True)
class ContactModel:
    """How planned contacts are analysed.

    Attributes:
        mu: sliding friction coefficient [-].
        gamma: torsional friction coefficient of a soft finger [m].
        min_friction: also compute the smallest friction for closure (a bisection; costs ~10 epsilon evaluations).
    """

    mu: float = STANDARD_MU
    gamma: float = STANDARD_TORSION_M
    min_friction: bool = True


@dataclass(frozen=True)
class Metrics:
    """Metrics of B grasps: epsilon L1 (B,), force closure (B,) and minimum friction (B,) (NaN if not computed)."""

    epsilon_l1: np.ndarray
    force_closure: np.ndarray
    min_friction: np.ndarray


def torque_scale(vertices: np.ndarray, center: np.ndarray) -> float:
    """The object's radius about `center`: max distance of `vertices` (n, 3) from it [m]."""
    return float(np.max(np.linalg.norm(np.asarray(vertices) - center, axis=1)))


def grasp_metrics(positions: np.ndarray, normals: np.ndarray, center: np.ndarray, scale: float,
                  model: ContactModel) -> Metrics:
    """Metrics of B grasps of n contacts each: positions, inward normals (B, n, 3)."""
    b = len(positions)
    if b == 0:
        return Metrics(np.zeros(0), np.zeros(0, bool), np.zeros(0))
    contacts = ContactSet(positions=positions, normals=normals, mu=model.mu, kind=ContactType.SOFT_FINGER,
                          gamma=model.gamma)
    eps = ferrari_canny_batch(contacts, center, scale, "L1")
    min_mu = np.full(b, np.nan)
    if model.min_friction:
        min_mu = min_friction_for_closure_batch(contacts, center, scale, tol=MIN_FRICTION_TOLERANCE)
    return Metrics(epsilon_l1=eps, force_closure=eps > EPSILON_TOLERANCE, min_friction=min_mu)


def unit_rows(vectors: np.ndarray) -> np.ndarray:
    """`vectors` (..., 3) normalised to unit length (rows of length 0 stay 0)."""
    norm = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return np.divide(vectors, norm, out=np.zeros_like(vectors), where=norm > 0)
