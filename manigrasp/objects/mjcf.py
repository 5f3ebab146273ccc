"""MJCF of one object: a visual mesh (no collision) and its convex parts.

The document's worldbody holds one body, ``object``, with a free joint
``object_joint``, an explicit inertial at the centre of mass (the body origin),
a visual geom ``object_visual`` (class ``object_visual``: group 2, no contact)
and collision geoms ``object_part_NNN`` (class ``object_collision``: group 3,
friction from the build options). Mesh files are referenced as given: the
pipeline gives names relative to the document's folder, which MuJoCo resolves
against that folder (also once attached into a scene), so an entry of the cache
can be moved or copied whole.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

import numpy as np


def _fmt(values: Sequence[float] | np.ndarray) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


def object_mjcf(
    name: str,
    visual_path: Path,
    part_paths: Sequence[Path],
    mass: float,
    inertia: np.ndarray,
    friction: Sequence[float],
    condim: int = 4,
) -> str:
    """The MJCF document (a string) of one object.

    Args:
        name: model name.
        visual_path: visual mesh file, object frame (origin at the COM) [m]; a relative path is
            resolved by MuJoCo against the folder of the document.
        part_paths: convex collision part files, object frame [m] (same rule).
        mass: [kg].
        inertia: (3, 3) inertia about the COM in the object frame [kg m^2].
        friction: (sliding, torsional, rolling) coefficients of the parts.
        condim: contact dimensionality of the parts (4: with torsional friction).
    """
    root = ET.Element("mujoco", model=name)
    ET.SubElement(root, "compiler", angle="radian")
    default = ET.SubElement(root, "default")
    visual = ET.SubElement(default, "default", {"class": "object_visual"})
    ET.SubElement(visual, "geom", type="mesh", contype="0", conaffinity="0", group="2",
                  density="0", rgba="0.75 0.6 0.4 1")
    collision = ET.SubElement(default, "default", {"class": "object_collision"})
    ET.SubElement(collision, "geom", type="mesh", group="3", density="0", condim=str(condim),
                  friction=_fmt(friction), rgba="0.4 0.6 0.8 0.5")
    asset = ET.SubElement(root, "asset")
    ET.SubElement(asset, "mesh", name="object_visual", file=Path(visual_path).as_posix())
    for i, part in enumerate(part_paths):
        ET.SubElement(asset, "mesh", name=f"object_part_{i:03d}", file=Path(part).as_posix())
    body = ET.SubElement(ET.SubElement(root, "worldbody"), "body", name="object")
    ET.SubElement(body, "freejoint", name="object_joint")
    ixx, iyy, izz = np.diag(inertia)
    ixy, ixz, iyz = inertia[0, 1], inertia[0, 2], inertia[1, 2]
    ET.SubElement(body, "inertial", pos="0 0 0", mass=f"{mass:.9g}",
                  fullinertia=_fmt([ixx, iyy, izz, ixy, ixz, iyz]))
    ET.SubElement(body, "geom", {"name": "object_visual", "class": "object_visual", "mesh": "object_visual"})
    for i in range(len(part_paths)):
        ET.SubElement(body, "geom", {"name": f"object_part_{i:03d}", "class": "object_collision",
                                     "mesh": f"object_part_{i:03d}"})
    ET.indent(root)
    return ET.tostring(root, encoding="unicode")
