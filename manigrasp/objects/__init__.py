"""Objects: meshes in, validated and decomposed `ObjectAsset`s out.

    >>> from manigrasp import objects
    >>> asset = objects.build_object("my_part.stl", scale=0.001, mass=0.2).asset
"""

from manigrasp.objects.asset import ObjectAsset
from manigrasp.objects.decompose import DecompositionParams
from manigrasp.objects.pipeline import (
    DEFAULT_DENSITY,
    DEFAULT_FRICTION,
    BuildResult,
    build_object,
    build_object_from_mesh,
)

__all__ = [
    "DEFAULT_DENSITY",
    "DEFAULT_FRICTION",
    "BuildResult",
    "DecompositionParams",
    "ObjectAsset",
    "build_object",
    "build_object_from_mesh",
]
