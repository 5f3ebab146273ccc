"""What a planner sees of the settled object, per the config's `observation` switch."""

from __future__ import annotations

import numpy as np

from manigrasp.errors import ConfigError


def observe(kind: str, asset, object_pose: np.ndarray, scene=None):
    """The `Observation` of `asset` resting at `object_pose` (4, 4).

    "ground_truth": the object's mesh at its true pose. "estimated_pose" and
    "point_cloud" come from the perception pipeline.
    """
    from manigrasp.planners.base import Observation

    if kind == "ground_truth":
        return Observation.from_asset(asset, object_pose)
    raise ConfigError(f"observation {kind!r} needs the perception pipeline, which is not available yet; "
                      "use observation: ground_truth")
