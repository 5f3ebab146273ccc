"""Rigid-pose helpers in pure NumPy (no MuJoCo): the one home for pose arithmetic shared across layers.

Quaternions are MuJoCo's (w, x, y, z); poses are (..., 4, 4) homogeneous matrices [m].
"""

from __future__ import annotations

import numpy as np


def pose_from_pos_quat(position: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """(n, 4, 4) poses from positions (n, 3) [m] and quaternions (n, 4) (w, x, y, z), NOT normalised.

    The rotation block is the standard quaternion-to-matrix formula applied as given: for
    q = s q' (q' unit) it is I + s^2 (R(q') - I), a non-rotation that a caller's rigidity check
    can report, except when R(q') = I (q = (w, 0, 0, 0)), which gives the identity for any w.
    """
    w, x, y, z = np.moveaxis(np.asarray(quat, float), -1, 0)
    out = np.zeros((len(position), 4, 4))
    out[:, :3, :3] = np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)
    out[:, :3, 3] = position
    out[:, 3, 3] = 1.0
    return out
