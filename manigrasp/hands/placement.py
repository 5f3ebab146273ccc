"""Hand-placed grasps: TCP poses a test or a benchmark script can give a hand without a planner.

`side_power_grasp` is the dexterous hands' reference grasp (their registry tests, the Allegro's tests and the
grip-hold benchmark): an upright cylinder taken from the side at mid-height, its axis across the palm.
`top_grasp` is the parallel jaws' (a top-down grasp, closing along the world y axis). Poses are (4, 4) world
matrices [m] in the TCP convention (z = approach, y = closing).
"""

from __future__ import annotations

import mujoco
import numpy as np

from manigrasp.hands.base import Hand


def thumb_side(hand: Hand) -> float:
    """+1 or -1: the side of the TCP's x axis the first finger body (the thumb) lies on, in the open hand.

    Read from the hand's own model at its default (open) configuration: the thumb's centre of mass in the TCP
    frame. 0 (a thumb on the TCP's y-z plane) counts as +1.
    """
    model = hand.build_spec().compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    site = model.site(hand.tcp_site).id
    thumb = data.xipos[model.body(hand.finger_bodies[0]).id] - data.site_xpos[site]
    along = float(data.site_xmat[site].reshape(3, 3)[:, 0] @ thumb)
    return -1.0 if along < 0 else 1.0


def side_power_grasp(hand: Hand, centre: np.ndarray) -> np.ndarray:
    """(4, 4) TCP pose of a side power grasp of an upright cylinder, thumb side up.

    Args:
        hand: a dexterous hand (its thumb is its first finger body).
        centre: (3,) world point the TCP is placed on [m], e.g. the cylinder's axis at mid-height.

    The hand approaches along the world +x axis (TCP z), the cylinder's axis runs along the TCP x axis (across
    the palm) and the thumb lies above the fingers, so the fingers close upward around the cylinder.
    """
    side = thumb_side(hand)
    pose = np.eye(4)
    pose[:3, 3] = np.asarray(centre, dtype=float).reshape(3)
    pose[:3, :3] = np.column_stack([[0.0, 0.0, side], [0.0, -side, 0.0], [1.0, 0.0, 0.0]])
    return pose


def top_grasp(centre: np.ndarray) -> np.ndarray:
    """(4, 4) TCP pose of a top-down grasp at `centre` (3,) [m]: approach down, closing along world -y."""
    pose = np.eye(4)
    pose[:3, 3] = np.asarray(centre, dtype=float).reshape(3)
    pose[:3, :3] = np.diag([1.0, -1.0, -1.0])
    return pose
