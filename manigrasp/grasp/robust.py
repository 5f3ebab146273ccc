"""Robust Ferrari-Canny epsilon under contact noise (as Dex-Net's robust metric).

Each sample perturbs every contact independently: position + N(0,
position_std^2) per axis [m]; normal + N(0, normal_std^2) per axis, then
renormalised (normal_std is roughly an angle in radians for small values);
mu + N(0, mu_std^2), clipped at 0. A given tangent is re-projected onto the
perturbed tangent plane. The centre and torque scale are not perturbed. All
samples of all grasps are scored in one batched call.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from manigrasp.contact import DEFAULT_EDGES, Contact, ContactSet
from manigrasp.grasp.errors import GraspError
from manigrasp.grasp.matrix import _single
from manigrasp.grasp.quality import ferrari_canny_batch


@dataclass(frozen=True)
class RobustEpsilon:
    """Epsilon of one grasp under noise: mean, and the `quantile` quantile `low`."""

    mean: float
    low: float
    quantile: float
    n_samples: int


@dataclass(frozen=True, eq=False)
class RobustEpsilonBatch:
    """Per-grasp mean (B,) and low quantile (B,), with all samples (B, S)."""

    mean: np.ndarray
    low: np.ndarray
    quantile: float
    samples: np.ndarray


@dataclass(frozen=True)
class ContactNoise:
    """Standard deviations of the Gaussian noise on contacts."""

    position_std: float = 0.002
    """Per-axis position noise [m]."""
    normal_std: float = 0.05
    """Per-axis noise added to the unit normal before renormalising [-]."""
    mu_std: float = 0.05
    """Noise on the friction coefficient [-]."""


def _unit(v: np.ndarray) -> np.ndarray:
    """Rows of v (..., 3) scaled to unit length."""
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def perturb(contacts: ContactSet, noise: ContactNoise, n_samples: int, rng: np.random.Generator) -> ContactSet:
    """(B * S, n) perturbed copies, grasp-major: row b * S + s is sample s of grasp b."""
    rep = lambda a: np.repeat(a, n_samples, axis=0)  # noqa: E731
    positions, normals, mu = rep(contacts.positions), rep(contacts.normals), rep(contacts.mu)
    positions = positions + rng.normal(0.0, noise.position_std, positions.shape)
    normals = _unit(normals + rng.normal(0.0, noise.normal_std, normals.shape))
    mu = np.maximum(mu + rng.normal(0.0, noise.mu_std, mu.shape), 0.0)
    tangents = None
    if contacts.tangents is not None:
        t = rep(contacts.tangents)
        tangents = _unit(t - np.sum(t * normals, axis=-1, keepdims=True) * normals)
    return ContactSet(positions, normals, mu, contacts.kind, rep(contacts.gamma), tangents)


def robust_ferrari_canny_batch(
    contacts: ContactSet,
    center: np.ndarray,
    torque_scale: float,
    rng: np.random.Generator,
    n_samples: int = 100,
    noise: ContactNoise = ContactNoise(),  # noqa: B008 (frozen, immutable)
    quantile: float = 0.05,
    norm: str = "L1",
    m: int = DEFAULT_EDGES,
) -> RobustEpsilonBatch:
    """Mean and low quantile of epsilon for B grasps under `noise` (module docstring).

    Args:
        contacts: B nominal grasps.
        center: (3,) or (B, 3) torque reference point [m].
        torque_scale: characteristic length [m].
        rng: the random generator (the only source of randomness).
        n_samples: samples S per grasp.
        noise: standard deviations of the noise.
        quantile: the low quantile reported, in (0, 1).
        norm: "L1" or "Linf".
        m: edges of the linearised cone.
    """
    if n_samples < 1 or not 0.0 < quantile < 1.0:
        raise GraspError("need n_samples >= 1 and 0 < quantile < 1")
    b = contacts.batch_size
    centers = np.repeat(np.broadcast_to(np.asarray(center, float), (b, 3)), n_samples, axis=0)
    samples = perturb(contacts, noise, n_samples, rng)
    eps = ferrari_canny_batch(samples, centers, torque_scale, norm, m).reshape(b, n_samples)
    return RobustEpsilonBatch(eps.mean(axis=1), np.quantile(eps, quantile, axis=1), quantile, eps)


def robust_ferrari_canny(
    contacts: Sequence[Contact] | ContactSet,
    center: np.ndarray,
    torque_scale: float,
    rng: np.random.Generator,
    n_samples: int = 100,
    noise: ContactNoise = ContactNoise(),  # noqa: B008 (frozen, immutable)
    quantile: float = 0.05,
    norm: str = "L1",
    m: int = DEFAULT_EDGES,
) -> RobustEpsilon:
    """Robust epsilon of one grasp (see `robust_ferrari_canny_batch`)."""
    result = robust_ferrari_canny_batch(_single(contacts), center, torque_scale, rng, n_samples,
                                        noise, quantile, norm, m)
    return RobustEpsilon(float(result.mean[0]), float(result.low[0]), quantile, n_samples)
