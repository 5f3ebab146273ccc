"""Geometric measurements on a compiled hand: jaw opening along the TCP's y axis."""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np

# Rays see collision geoms only: robosuite puts them in group 0 (visual meshes are group 1).
_COLLISION_GROUPS = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)


class JawGap(NamedTuple):
    """Free distances [m] from the TCP to the first collision geom along -y and +y, and whose they are."""

    minus_y: float
    plus_y: float
    minus_body: str
    plus_body: str

    @property
    def width(self) -> float:
        """Opening between the jaws along the TCP y axis [m]."""
        return self.minus_y + self.plus_y


def _ray(model: mujoco.MjModel, data: mujoco.MjData, start: np.ndarray, direction: np.ndarray) -> tuple[float, str]:
    geom = np.array([-1], dtype=np.int32)
    dist = mujoco.mj_ray(model, data, start, direction, _COLLISION_GROUPS, 1, -1, geom)
    if geom[0] < 0:
        return float("inf"), ""
    return float(dist), model.body(model.geom_bodyid[geom[0]]).name


def jaw_gap(model: mujoco.MjModel, data: mujoco.MjData, tcp_site: str) -> JawGap:
    """Cast rays from the TCP site along its -y and +y axes (kinematics of `data` must be current)."""
    site = model.site(tcp_site).id
    start = data.site_xpos[site].copy()
    y_axis = data.site_xmat[site].reshape(3, 3)[:, 1].copy()
    minus, minus_body = _ray(model, data, start, -y_axis)
    plus, plus_body = _ray(model, data, start, y_axis)
    return JawGap(minus, plus, minus_body, plus_body)


def finger_of(model: mujoco.MjModel, body: str, fingers: tuple[str, ...]) -> str | None:
    """The finger body among `fingers` that `body` is or descends from, or None."""
    ids = {model.body(name).id: name for name in fingers}
    current = model.body(body).id
    while current > 0:
        if current in ids:
            return ids[current]
        current = int(model.body_parentid[current])
    return None
