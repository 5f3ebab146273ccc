"""The grasp matrix G and the metrics of its singular values.

G maps the stacked local contact coordinates of all contacts to the scaled
object wrench (force [N], torque about `center` / torque_scale [N]).
Per contact, in contact order: frictionless (f_n); hard finger
(f_n, f_t1, f_t2); soft finger (f_n, f_t1, f_t2, tau_n [N m]); the tangent
frame is `manigrasp.contact.local_axes`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from manigrasp.contact import Contact, ContactSet, as_contact_set, wrench_basis
from manigrasp.grasp.errors import GraspError


def grasp_matrices(contacts: ContactSet, center: np.ndarray, torque_scale: np.ndarray | float) -> np.ndarray:
    """Grasp matrices of B grasps: (B, 6, k n), k = 1, 3 or 4 columns per contact."""
    basis = wrench_basis(contacts, center, torque_scale)  # (B, n, 6, k)
    b, n, _, k = basis.shape
    return basis.transpose(0, 2, 1, 3).reshape(b, 6, n * k)


def _single(contacts: Sequence[Contact] | ContactSet) -> ContactSet:
    """`contacts` as a one-grasp set."""
    cs = as_contact_set(contacts)
    if cs.batch_size != 1:
        raise GraspError("this function takes one grasp; use its batched form for many")
    return cs


def grasp_matrix(
    contacts: Sequence[Contact] | ContactSet, center: np.ndarray, torque_scale: float
) -> np.ndarray:
    """Grasp matrix G (6, k n) of one grasp about `center` (3,) [m], torques / torque_scale [m]."""
    return grasp_matrices(_single(contacts), center, torque_scale)[0]


def singular_values(matrices: np.ndarray) -> np.ndarray:
    """(B, 6) singular values of (B, 6, K) matrices, descending, zero-padded when K < 6."""
    s = np.linalg.svd(matrices, compute_uv=False)
    return np.pad(s, ((0, 0), (0, 6 - s.shape[1])))


def min_singular_values(contacts: ContactSet, center: np.ndarray, torque_scale: np.ndarray | float) -> np.ndarray:
    """(B,) smallest singular value of each G (0 when G cannot span all six wrench directions)."""
    return singular_values(grasp_matrices(contacts, center, torque_scale))[:, -1]


def isotropies(contacts: ContactSet, center: np.ndarray, torque_scale: np.ndarray | float) -> np.ndarray:
    """(B,) isotropy index sigma_min / sigma_max of each G, in [0, 1]."""
    s = singular_values(grasp_matrices(contacts, center, torque_scale))
    return np.divide(s[:, -1], s[:, 0], out=np.zeros(len(s)), where=s[:, 0] > 0)


def min_singular_value(
    contacts: Sequence[Contact] | ContactSet, center: np.ndarray, torque_scale: float
) -> float:
    """Smallest singular value of G for one grasp [scaled N per N]."""
    return float(min_singular_values(_single(contacts), center, torque_scale)[0])


def isotropy(contacts: Sequence[Contact] | ContactSet, center: np.ndarray, torque_scale: float) -> float:
    """Isotropy index sigma_min / sigma_max of G for one grasp (1 = isotropic)."""
    return float(isotropies(_single(contacts), center, torque_scale)[0])
