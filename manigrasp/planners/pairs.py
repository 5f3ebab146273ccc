"""Antipodal contact pairs (`Pairs`) and the inward rays they are searched along (`cone_rays`).

Shared by the antipodal planner's mesh path (`antipodal`) and point-cloud path (`cloud`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigrasp.planners.geometry import perpendicular_basis


@dataclass(frozen=True)
class Pairs:
    """m antipodal contact pairs: contact 1 (finger 1) at `p`, contact 2 at `q`, line `axis` from p to q.

    Attributes:
        p, q: (m, 3) contact points [m]; n_p, n_q: (m, 3) outward unit normals there.
        axis: (m, 3) unit vectors from p to q; width: (m,) |q - p| [m].
        alpha: (m,) the larger angle between the line and an inward normal [rad].
    """

    p: np.ndarray
    q: np.ndarray
    n_p: np.ndarray
    n_q: np.ndarray
    axis: np.ndarray
    width: np.ndarray
    alpha: np.ndarray

    def take(self, keep: np.ndarray) -> Pairs:
        """The pairs selected by a mask or index array."""
        return Pairs(*(getattr(self, f)[keep] for f in ("p", "q", "n_p", "n_q", "axis", "width", "alpha")))

    def __len__(self) -> int:
        return len(self.width)


def cone_rays(axes: np.ndarray, count: int, half_angle: float, rng: np.random.Generator) -> np.ndarray:
    """(n, count, 3) unit rays per axis (n, 3): the axis itself, then count - 1 uniform inside `half_angle`."""
    n = len(axes)
    cos_t = 1.0 - rng.random((n, count)) * (1.0 - np.cos(half_angle))
    cos_t[:, 0] = 1.0
    phi = rng.random((n, count)) * 2.0 * np.pi
    sin_t = np.sqrt(np.clip(1.0 - cos_t**2, 0.0, None))
    a, b = perpendicular_basis(axes)
    return (cos_t[..., None] * axes[:, None] + sin_t[..., None] * (np.cos(phi)[..., None] * a[:, None]
                                                                   + np.sin(phi)[..., None] * b[:, None]))
