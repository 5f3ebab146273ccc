"""How much a hand pose envelops the object: the palm's gap to the object and where the contacts push.

A power (enveloping) grasp holds the object between the palm and the curled
fingers: the palm is at or near the object, and the fingers' contacts push the
object toward the palm. A fingertip pinch has the palm far away and contacts
that push across or away from the palm. Three measures tell them apart:

- `palm_gaps`: the smallest distance [m] between the palm's collision geometry
  (every hand geom on no finger) and the object, for the open hand at each TCP pose
  (MuJoCo's `mj_geomDistance`; negative when they overlap);
- `toward_palm`: the mean over a grasp's contacts of -n . z, the inward contact normal n
  (into the object) against the approach z, which is the palm's outward normal: +1 when every
  contact pushes the object straight into the palm, -1 when every contact pushes it away;
- `finger_inward`: the same push per finger (the mean over each finger's contacts), its least
  over the fingers of a kinematic closure: below 0 some finger pushes the object out of the hand
  (the `power` planner's wrap test).
"""

from __future__ import annotations

import mujoco
import numpy as np

from manigrasp.planners.closing import Closure
from manigrasp.planners.collision import HandProbe

GAP_CUTOFF = 0.1  # [m] distances beyond this are reported as this (mj_geomDistance's distmax)


def palm_geoms(probe: HandProbe) -> np.ndarray:
    """Ids of the probe's collidable hand geoms that belong to no finger (the palm and its fixed links)."""
    model, scene = probe.scene.model, probe.scene
    collidable = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    return np.flatnonzero(probe.is_hand & collidable & (scene.finger_of_body[model.geom_bodyid] < 0))


def palm_gaps(probe: HandProbe, poses: np.ndarray, geoms: np.ndarray | None = None) -> np.ndarray:
    """(n,) smallest palm-object distance [m] of the open hand at TCP poses (n, 4, 4), at most `GAP_CUTOFF`.

    `geoms`: the palm geoms (default `palm_geoms(probe)`). The probe's hand is restored to its open shape.
    """
    geoms = palm_geoms(probe) if geoms is None else geoms
    model, data = probe.scene.model, probe.scene.data
    probe.restore()
    pos, quat = probe.roots(np.asarray(poses, float).reshape(-1, 4, 4))
    out = np.full(len(pos), GAP_CUTOFF)
    for i in range(len(pos)):
        probe.place(pos[i], quat[i])
        for g in geoms:
            for o in probe.scene.object_geoms:
                out[i] = min(out[i], mujoco.mj_geomDistance(model, data, int(g), int(o), GAP_CUTOFF, None))
    return out


def toward_palm(normals: np.ndarray, approach: np.ndarray) -> float:
    """Mean of -n . `approach` over inward contact normals `normals` (k, 3); NaN without contacts."""
    normals = np.asarray(normals, float).reshape(-1, 3)
    if len(normals) == 0:
        return float("nan")
    return float(np.mean(-normals @ np.asarray(approach, float)))


def finger_inward(closure: Closure, approach: np.ndarray) -> float:
    """The least, over the fingers touching in `closure`, of the mean -n . `approach` of
    the finger's contacts: below 0 a finger pushes the object away from the palm, out of the hand; NaN without
    contacts."""
    normals = np.asarray(closure.normals, float).reshape(-1, 3)
    if len(normals) == 0:
        return float("nan")
    return min(toward_palm(normals[closure.fingers == f], approach) for f in np.unique(closure.fingers))
