"""Read a robosuite gripper XML from the installed package and apply the common fixes.

Fixes applied to every model (each is recorded in the returned notes):

- Mesh files are made absolute. robosuite's XMLs name meshes relative to their
  own folder (``meshes/panda_gripper/hand.stl``) and rely on being merged into
  a robot XML; an absolute path survives `MjSpec.attach` into any scene.
- A mesh name declared twice is dropped after its first declaration (the
  Robotiq 2F-85 declares ``robotiq_arg2f_base_link`` twice, which MuJoCo
  refuses to parse); see `drop_duplicate_meshes`.
- Angles are radians: robosuite merges grippers into robot XMLs compiled with
  ``angle="radian"``, but the gripper files alone (Panda, Robotiq) fall back to
  MJCF's degree default, which would read the Robotiq's 0.8 rad joint range as
  0.8 degrees.
- Visual-only geoms (contype = conaffinity = 0) weigh nothing. The five-finger
  hands give each collision mesh a mass but leave their visual duplicates at
  MuJoCo's default density of water, which adds about 0.5 kg of phantom mass
  to a hand (the Panda and Robotiq bodies carry explicit inertials and are
  unaffected).
- robosuite's own bookkeeping is removed: the ``eef`` body with its
  visualisation sites (one is a 10 m cylinder), the ``ft_frame`` site and the
  force/torque sensors on it. manigrasp adds its own TCP site instead.
"""

from __future__ import annotations

import importlib.util
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco

from manigrasp.errors import HandError

_ROBOSUITE_SITES = ("ft_frame",)
_ROBOSUITE_BODIES = ("eef",)


def grippers_dir() -> Path:
    """Folder of robosuite's gripper XMLs in the installed package (nothing is imported)."""
    spec = importlib.util.find_spec("robosuite")
    if spec is None or not spec.submodule_search_locations:
        raise HandError("the robosuite hands need the robosuite package (pip install robosuite==1.5.1)")
    folder = Path(next(iter(spec.submodule_search_locations))) / "models" / "assets" / "grippers"
    if not folder.is_dir():
        raise HandError(f"robosuite is installed but has no gripper folder at {folder}")
    return folder


def drop_duplicate_meshes(root: ET.Element) -> list[str]:
    """Remove every ``<mesh>`` whose name was declared before; return the dropped names.

    Geoms keep referring to the name, which now means its first declaration.
    """
    seen: set[str] = set()
    dropped: list[str] = []
    for asset in root.iter("asset"):
        for mesh in list(asset.findall("mesh")):
            name = mesh.get("name") or Path(mesh.get("file", "")).stem
            if name in seen:
                asset.remove(mesh)
                dropped.append(f"{name} ({mesh.get('file')})")
            seen.add(name)
    return dropped


def load_gripper_spec(filename: str) -> tuple[mujoco.MjSpec, tuple[str, ...]]:
    """A fresh `MjSpec` of robosuite's ``grippers/<filename>`` with the common fixes, and notes on them."""
    folder = grippers_dir()
    path = folder / filename
    if not path.is_file():
        raise HandError(f"robosuite gripper model not found: {path}")
    root = ET.fromstring(path.read_text())
    notes = [f"model: robosuite {path.relative_to(folder.parents[2])}"]
    dropped = drop_duplicate_meshes(root)
    if dropped:
        notes.append("dropped duplicated mesh declaration(s): " + ", ".join(dropped))
    spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
    spec.compiler.degree = False
    spec.meshdir = ""
    for mesh in spec.meshes:
        mesh.file = str((folder / mesh.file).resolve())
    _strip_robosuite_extras(spec)
    if _massless_visuals(spec):
        notes.append("visual-only geoms made massless (they carried density-based mass)")
    return spec, tuple(notes)


def _massless_visuals(spec: mujoco.MjSpec) -> int:
    """Set mass 0 on visual-only geoms of bodies whose inertia comes from their geoms; return how many."""
    changed = 0
    for geom in spec.geoms:
        if geom.contype == 0 and geom.conaffinity == 0 and not geom.parent.explicitinertial:
            geom.mass = 0.0
            changed += 1
    return changed


def _strip_robosuite_extras(spec: mujoco.MjSpec) -> None:
    for sensor in list(spec.sensors):
        spec.delete(sensor)
    for name in _ROBOSUITE_BODIES:
        body = spec.body(name)
        if body is not None:
            spec.delete(body)
    for name in _ROBOSUITE_SITES:
        site = spec.site(name)
        if site is not None:
            spec.delete(site)
