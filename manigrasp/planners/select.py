"""Walking down a ranking: keep poses that are neither duplicates (NMS) nor colliding (MuJoCo)."""

from __future__ import annotations

import numpy as np

from manigrasp.planners.base import pregrasp
from manigrasp.planners.collision import HandProbe
from manigrasp.planners.nms import Suppressor, pairwise_close

CHUNK = 256  # poses whose root transforms are computed at once


def select_free(probe: HandProbe, nms: Suppressor, ranked: np.ndarray, n: int, pregrasp_offset: float,
                max_checks: int) -> np.ndarray:
    """Indices into `ranked` (k, 4, 4), best first, of at most `n` kept poses.

    A pose is kept when it is not within the NMS thresholds of a pose kept
    before it, and the open hand is clear of object and table both at the
    pose and at its pre-grasp pose. At most `max_checks` poses are tested for
    collision (a pose rejected by NMS costs no test).
    """
    kept: list[int] = []
    checks = 0
    for start in range(0, len(ranked), CHUNK):
        chunk = ranked[start:start + CHUNK]
        fresh = np.flatnonzero(~nms.duplicates(chunk))
        if len(fresh) == 0:
            continue
        close = pairwise_close(chunk[fresh], chunk[fresh, :3, 3], chunk[fresh, :3, :3], nms.distance, nms.angle,
                               nms.symmetric)
        grasp_pos, grasp_quat = probe.roots(chunk[fresh])
        pre_pos, pre_quat = probe.roots(pregrasp(chunk[fresh], pregrasp_offset))
        kept_here: list[int] = []
        for i in range(len(fresh)):
            if kept_here and close[i, kept_here].any():
                continue
            if checks >= max_checks:
                return np.array(kept, dtype=int)
            checks += 1
            probe.place(grasp_pos[i], grasp_quat[i])
            if probe.touching():
                continue
            probe.place(pre_pos[i], pre_quat[i])
            if probe.touching():
                continue
            nms.keep(chunk[fresh[i]])
            kept_here.append(i)
            kept.append(start + int(fresh[i]))
            if len(kept) >= n:
                return np.array(kept, dtype=int)
    return np.array(kept, dtype=int)
