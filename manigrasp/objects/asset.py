"""`ObjectAsset`: one object ready for simulation (mesh, parts, mass, MJCF)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class ObjectAsset:
    """An object built by the pipeline: repaired mesh, convex parts, inertia.

    All geometry is in the object frame: origin at the centre of mass, axes
    those of the source mesh (a recipe's canonical frame: z up when resting).

    Attributes:
        name: object name ("025_mug" style for the shipped set).
        visual_path: OBJ file of the visual mesh, object frame [m].
        part_paths: OBJ files of the convex collision parts, object frame [m].
        mass: [kg].
        inertia: (3, 3) inertia tensor about the centre of mass, object frame [kg m^2].
        extents: (3,) axis-aligned extents of the mesh in the object frame [m].
        volume: mesh volume [m^3].
        mjcf_path: standalone MJCF of the object (see `manigrasp.objects.mjcf`).
        metadata: facts about its making: source, ycb_id, repairs done,
            number of hulls, decomposition coverage, cache key.
    """

    name: str
    visual_path: Path
    part_paths: tuple[Path, ...]
    mass: float
    inertia: np.ndarray
    extents: np.ndarray
    volume: float
    mjcf_path: Path
    metadata: dict = field(default_factory=dict, compare=False)

    @property
    def n_parts(self) -> int:
        """Number of convex collision parts."""
        return len(self.part_paths)
