"""Friction cones: exact membership and the linearised (polyhedral) cone.

The linearised cone with m edges is INSCRIBED in the exact circular cone:
edge k is ``n + mu (cos(2 pi k / m) t1 + sin(2 pi k / m) t2)``, so every edge lies
on the exact cone and the polyhedral cone is a conservative approximation
(it loses at most a factor cos(pi / m) of the friction, at mid-edge angles;
a soft finger's primitives lose more where sliding and torsion combine, down
to cos(pi/m) / sqrt(1 + cos^2(pi/m)) of the reach, 0.68 for m = 8:
`manigrasp.contact.wrench.primitive_forces`).
Each edge has unit normal component: a non-negative combination of the edges
with weights summing to s is a force with normal component s.
"""

from __future__ import annotations

import numpy as np

from manigrasp.contact.model import ContactError, ContactType, as_contact_type

DEFAULT_EDGES = 8
"""Default number of edges m of the linearised friction cone."""


def tangent_basis(normals: np.ndarray, tangents: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangents (t1, t2) with (n, t1, t2) a right-handed orthonormal frame.

    Without `tangents`, t1 comes from the branch-free construction of Duff et
    al. (2017), continuous except across the plane n_z = 0 and deterministic.

    Args:
        normals: (..., 3) unit normals.
        tangents: optional (..., 3) unit t1 orthogonal to `normals`.

    Returns:
        t1, t2: (..., 3) each, with t2 = n x t1.
    """
    normals = np.asarray(normals, dtype=float)
    if tangents is None:
        x, y, z = normals[..., 0], normals[..., 1], normals[..., 2]
        sign = np.where(z >= 0.0, 1.0, -1.0)
        a = -1.0 / (sign + z)
        b = x * y * a
        t1 = np.stack([1.0 + sign * x * x * a, sign * b, -sign * x], axis=-1)
    else:
        t1 = np.broadcast_to(np.asarray(tangents, dtype=float), normals.shape)
    return t1, np.cross(normals, t1)


def edge_directions(m: int) -> np.ndarray:
    """(m, 2) unit vectors (cos, sin) of the m edge angles 2 pi k / m, k = 0..m-1."""
    if int(m) != m or m < 3:
        raise ContactError(f"a linearised friction cone needs m >= 3 edges, got {m}")
    angles = 2.0 * np.pi * np.arange(m) / m
    return np.stack([np.cos(angles), np.sin(angles)], axis=-1)


def cone_edges(
    normals: np.ndarray,
    mu: np.ndarray | float,
    m: int = DEFAULT_EDGES,
    tangents: np.ndarray | None = None,
) -> np.ndarray:
    """Generators of the linearised friction cone, each with unit normal component.

    Args:
        normals: (..., 3) unit normals pointing into the object.
        mu: friction coefficients, broadcastable to normals.shape[:-1].
        m: number of edges (>= 3).
        tangents: optional (..., 3) first tangent fixing the phase of edge 0.

    Returns:
        (..., m, 3) edge forces [N per N of normal force].
    """
    normals = np.asarray(normals, dtype=float)
    t1, t2 = tangent_basis(normals, tangents)
    cs = edge_directions(m)
    mu = np.asarray(mu, dtype=float)[..., None, None]
    tangential = cs[:, :1] * t1[..., None, :] + cs[:, 1:] * t2[..., None, :]
    return normals[..., None, :] + mu * tangential


def _ratio(numerator: np.ndarray, limit: np.ndarray, tol: float) -> np.ndarray:
    """numerator / limit, with 0/0 -> 0 and x/0 -> inf (x > tol): never a division by ~0."""
    safe = np.where(limit > 0.0, limit, 1.0)
    zero_limit = np.where(numerator <= tol, 0.0, np.inf)
    return np.where(limit > 0.0, numerator / safe, zero_limit)


def in_friction_cone(
    forces: np.ndarray,
    normals: np.ndarray,
    mu: np.ndarray | float,
    kind: ContactType | str = ContactType.HARD_FINGER,
    torsion: np.ndarray | float = 0.0,
    gamma: np.ndarray | float = 0.0,
    tol: float = 1e-9,
) -> np.ndarray:
    """Exact membership of contact forces in their (circular or elliptic) cone.

    A force with negative normal component (pulling) is never inside; a zero
    normal force is inside only when the tangential force (and torsion) are
    zero within `tol`.

    Args:
        forces: (..., 3) forces the fingers apply to the object [N].
        normals: (..., 3) unit inward normals.
        mu: friction coefficients, broadcastable to forces.shape[:-1].
        kind: contact type; frictionless allows no tangential force at all.
        torsion: torsional moments about the normal [N m] (soft finger only).
        gamma: torsional coefficients [m] (soft finger only).
        tol: absolute tolerance [N].

    Returns:
        (...,) bool.
    """
    kind = as_contact_type(kind)
    forces, normals = np.asarray(forces, dtype=float), np.asarray(normals, dtype=float)
    f_n = np.sum(forces * normals, axis=-1)
    f_t = np.linalg.norm(forces - f_n[..., None] * normals, axis=-1)
    limit = np.maximum(f_n, 0.0)
    if kind is ContactType.FRICTIONLESS:
        return (f_n >= -tol) & (f_t <= tol)
    t_ratio = _ratio(f_t, np.asarray(mu, dtype=float) * limit, tol)
    if kind is ContactType.SOFT_FINGER:
        tau = np.abs(np.asarray(torsion, dtype=float))
        q_ratio = _ratio(tau, np.asarray(gamma, dtype=float) * limit, tol)
        inside = np.hypot(t_ratio, q_ratio) <= 1.0 + tol
    else:
        inside = (t_ratio <= 1.0 + tol) | (f_t <= tol)
    return (f_n >= -tol) & inside
