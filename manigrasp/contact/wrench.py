"""Wrenches that contacts can apply to the object.

A wrench is (force [N], torque about `center` / torque_scale [N]): dividing
the torque [N m] by a characteristic length `torque_scale` [m] makes the six
components commensurate. Shapes: B grasps, n contacts, P primitives each.
"""

from __future__ import annotations

import numpy as np

from manigrasp.contact.cone import DEFAULT_EDGES, cone_edges, tangent_basis
from manigrasp.contact.model import ContactError, ContactSet, ContactType


def lever_arms(contacts: ContactSet, center: np.ndarray) -> np.ndarray:
    """(B, n, 3) vectors from `center` ((3,) or (B, 3) [m]) to each contact [m]."""
    center = np.asarray(center, dtype=float)
    if center.shape not in {(3,), (contacts.batch_size, 3)}:
        raise ContactError(f"center must have shape (3,) or (B, 3), got {center.shape}")
    return contacts.positions - center.reshape(-1, 1, 3)


def _scale(torque_scale: np.ndarray | float, batch_size: int) -> np.ndarray:
    """torque_scale as a (B, 1, 1) array, checked > 0 and finite."""
    scale = np.asarray(torque_scale, dtype=float)
    if scale.shape not in {(), (batch_size,)} or not np.all(np.isfinite(scale) & (scale > 0)):
        raise ContactError(f"torque_scale must be a positive length [m], scalar or (B,), got {scale}")
    return np.broadcast_to(scale, (batch_size,)).reshape(-1, 1, 1)


def local_axes(contacts: ContactSet) -> np.ndarray:
    """(B, n, 3, 3) contact frames: rows normal, t1, t2 (t2 = n x t1)."""
    t1, t2 = tangent_basis(contacts.normals, contacts.tangents)
    return np.stack([contacts.normals, t1, t2], axis=-2)


def wrench_basis(contacts: ContactSet, center: np.ndarray, torque_scale: np.ndarray | float) -> np.ndarray:
    """Columns mapping local contact coordinates to scaled object wrenches.

    Local coordinates per contact: frictionless (f_n); hard finger
    (f_n, f_t1, f_t2) [N]; soft finger (f_n, f_t1, f_t2, tau_n) with tau_n [N m].

    Returns:
        (B, n, 6, k) with k = 1, 3 or 4.
    """
    axes = local_axes(contacts)
    r = lever_arms(contacts, center)
    scale = _scale(torque_scale, contacts.batch_size)[..., None]
    torques = np.cross(r[:, :, None, :], axes) / scale
    columns = np.concatenate([axes, torques], axis=-1)
    if contacts.kind is ContactType.FRICTIONLESS:
        columns = columns[:, :, :1]
    elif contacts.kind is ContactType.SOFT_FINGER:
        twist = np.concatenate([np.zeros_like(axes[:, :, :1]), axes[:, :, :1] / scale], axis=-1)
        columns = np.concatenate([columns, twist], axis=-2)
    return np.swapaxes(columns, -1, -2)


def primitive_forces(contacts: ContactSet, m: int = DEFAULT_EDGES) -> tuple[np.ndarray, np.ndarray]:
    """Forces and torsions of the primitives, each with unit normal force.

    Primitives: frictionless 1 (the normal); hard finger the m cone edges;
    soft finger the m edges then the two pure-torsion primitives
    (n, +gamma) and (n, -gamma). Their convex hull is inscribed in the exact
    (elliptic, for soft fingers) cone: for a soft finger, a load that combines
    sliding and torsion is inside the hull only up to cos(pi/m) / sqrt(1 +
    cos^2(pi/m)) of the elliptic cone's reach in the worst direction (0.68 for
    m = 8; conservative).

    Returns:
        forces (B, n, P, 3) [N per N normal], torsion (B, n, P) [N m per N normal].
    """
    normals = contacts.normals[:, :, None, :]
    if contacts.kind is ContactType.FRICTIONLESS:
        return normals.copy(), np.zeros(normals.shape[:-1])
    forces = cone_edges(contacts.normals, contacts.mu, m, contacts.tangents)
    torsion = np.zeros(forces.shape[:-1])
    if contacts.kind is ContactType.SOFT_FINGER:
        forces = np.concatenate([forces, normals, normals], axis=2)
        gamma = contacts.gamma[..., None]
        torsion = np.concatenate([torsion, gamma, -gamma], axis=2)
    return forces, torsion


def primitive_wrenches(
    contacts: ContactSet,
    center: np.ndarray,
    torque_scale: np.ndarray | float,
    m: int = DEFAULT_EDGES,
) -> np.ndarray:
    """Scaled wrenches of every primitive (see `primitive_forces`).

    Args:
        contacts: B grasps of n contacts.
        center: (3,) or (B, 3) point the torques are taken about [m].
        torque_scale: characteristic length [m], scalar or (B,).
        m: edges of the linearised cone.

    Returns:
        (B, n, P, 6) wrenches (force, torque / torque_scale).
    """
    forces, torsion = primitive_forces(contacts, m)
    r = lever_arms(contacts, center)[:, :, None, :]
    scale = _scale(torque_scale, contacts.batch_size)[..., None]
    moments = np.cross(r, forces) + torsion[..., None] * contacts.normals[:, :, None, :]
    return np.concatenate([forces, moments / scale], axis=-1)
