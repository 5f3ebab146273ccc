"""The `file` planner: grasps read from a file (native JSON / NPZ, or ACRONYM's HDF5), placed on the object.

    planners: [{name: file, params: {path: grasps.json}}]          # in a benchmark config

The file's grasps are TCP poses in the object's frame; each is placed on the pose the planner
observes (the settled pose, or the estimated one under ``observation: estimated_pose``):
``world = object_pose @ mesh_to_object @ grasp``. A grasp that cannot be placed (made for another
hand, NaN, not a rotation, a width the hand cannot open to, a pre-shape outside [0, 1], joints on a parallel
hand) is returned
marked `invalid`: its trial is recorded as `invalid_grasp`, never dropped. The `n` best grasps by
score are returned (equal scores keep file order), so trial i is the i-th best grasp, not the file's grasp i:
each candidate's `source` is "file grasp j" (j: its index in the file, from 0), and every trial's detail begins
with it ("file grasp 7", "file grasp 7: <the protocol's detail>"), which joins results back to the file.

`path` may be a directory: the file named ``<object>__<hand>*`` (or ``<object>.*``, ``<object>__*``) with a grasp-file
suffix is used (the native one when a native and an ACRONYM file share a name), so one config can
evaluate a whole dataset written by `manigrasp label`. Under ``scene: {rest: stable_k}`` each resting pose's
group takes the file `label` wrote for it, ``<object>_rest<i>__<hand>*`` (`grasp_file_for`), before a plain one.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from manigrasp.errors import PlannerError
from manigrasp.graspsets import SUFFIXES, GraspSet, mesh_path, placement_defect, read
from manigrasp.graspsets.model import translation
from manigrasp.hands.base import Hand
from manigrasp.planners.base import GraspCandidate, Observation
from manigrasp.planners.context import PlanContext

SOURCE = "file grasp"  # a candidate's `source`: "file grasp <its index in the file>"


@functools.lru_cache(maxsize=16)
def _read_cached(path: str, mtime_ns: int) -> GraspSet:
    return read(path)


def load_grasps(path: str | Path) -> GraspSet:
    """`graspsets.read(path)`, cached per file version (a worker reads a file once)."""
    path = Path(path).resolve()
    if not path.is_file():
        from manigrasp.graspsets import GraspFileError

        raise GraspFileError(f"{path}: no such grasp file")
    return _read_cached(str(path), path.stat().st_mtime_ns)


def grasp_file_for(path: str | Path, object_name: str | None, hand_name: str, rest_index: int | None = None) -> Path:
    """`path` itself, or in a directory the one grasp file for `object_name` and `hand_name`: named
    ``<object>__<hand>*`` or ``<object>__*``; with `rest_index` (``rest: stable_k``) first the one `manigrasp label`
    writes for that resting pose's group, ``<object>_rest<i>__<hand>*`` (the group ``<object>@rest<i>``, its
    '@' made safe for a file name), then ``<object>_rest<i>__*``, then the plain names."""
    from manigrasp.bench.trials import REST_LABEL
    from manigrasp.record.policy import safe_name

    path = Path(path)
    if not path.is_dir():
        return path
    if object_name is None:
        raise PlannerError(f"file planner: {path} is a directory, and the observation names no object")
    by_stem: dict[str, Path] = {}  # one file per stem: native before ACRONYM (`label` writes both)
    for candidate in sorted(path.iterdir(), key=lambda p: (p.stem, _preference(p))):
        if candidate.suffix.lower() in SUFFIXES:
            by_stem.setdefault(candidate.stem, candidate)
    files = sorted(by_stem.values())
    objects = [safe_name(f"{object_name}{REST_LABEL}{rest_index}")] if rest_index is not None else []
    objects += [object_name, safe_name(object_name)]
    stems = [s for obj in objects for s in (f"{obj}__{safe_name(hand_name)}", obj)]
    for stem in dict.fromkeys(stems):
        found = [p for p in files if p.stem == stem or p.stem.startswith(stem + "__")]
        if len(found) == 1:
            return found[0]
        if len(found) > 1:
            raise PlannerError(f"file planner: {len(found)} grasp files in {path} match {stem!r}: "
                               f"{', '.join(p.name for p in found)}; give one as path")
    raise PlannerError(f"file planner: no grasp file for object {object_name!r} and hand {hand_name!r} in {path} "
                       f"(expected {stems[0]}.json or similar)")


def _preference(path: Path) -> int:
    suffix = path.suffix.lower()
    return SUFFIXES.index(suffix) if suffix in SUFFIXES else len(SUFFIXES)


@dataclass(frozen=True)
class FilePlanner:
    """Grasps from a file, placed on the observed object.

    Attributes:
        path: the grasp file (.json, .npz: manigrasp's format; .h5, .hdf5: ACRONYM's layout), or a
            directory of them named ``<object>__<hand>...`` (``<object>_rest<i>__<hand>...`` per resting pose
            under ``rest: stable_k``, `grasp_file_for`). Relative paths are relative to the
            working directory.
        transfer: run a set made for another hand of the same kind (default: such grasps are `invalid_grasp`);
            a set naming a registered hand but no ``hand_kind`` is of that hand's kind (`placement_defect`).
        check_object: refuse a file that names a different object than the one observed (in either frame: a
            mesh-frame set of another object would be placed by the observed object's centre of mass), unless
            it is a mesh-frame set of the observed object's own mesh file (`same_mesh`).
    """

    path: str
    transfer: bool = False
    check_object: bool = True

    name: ClassVar[str] = "file"
    needs: ClassVar[str] = "mesh"

    def plan(self, observation: Observation, hand: Hand, n: int, rng: np.random.Generator,
             context: PlanContext | None = None) -> Sequence[GraspCandidate]:
        """The `n` best grasps of the file on `observation`'s object pose (`rng` is not used; `context` names the
        resting pose under ``rest: stable_k``, which picks that pose's file of a directory)."""
        from manigrasp.objects import catalog  # a file may name a shipped object by its short name ("mug")

        asset = observation.asset
        object_name = asset.name if asset is not None else None
        rest_index = context.rest_index if context is not None else None
        grasps = load_grasps(grasp_file_for(self.path, object_name, hand.name, rest_index))
        if self.check_object and object_name and grasps.object.name \
                and catalog.full_name(grasps.object.name) != object_name and not same_mesh(grasps, asset):
            raise PlannerError(f"file planner: {grasps.source} holds grasps of object {grasps.object.name!r}, "
                               f"not {object_name!r} (planner param check_object: false runs them anyway)")
        base = observation.object_pose @ mesh_to_object(grasps, asset)
        out = []
        for index in grasps.ranked()[:n]:
            defect = placement_defect(grasps, int(index), hand.name, hand.kind, hand.max_width, self.transfer,
                                      hand.n_actuators)
            width = float(grasps.widths[index])
            fields = dict(score=float(grasps.scores[index]), width=width if np.isfinite(width) else None,
                          planner=self.name, source=f"{SOURCE} {index}")
            if defect:
                out.append(GraspCandidate(pose=np.full((4, 4), np.nan), invalid=defect, **fields))
            else:
                out.append(GraspCandidate(pose=base @ grasps.poses[index], preshape=float(grasps.preshapes[index]),
                                          joints=grasps.grasp_joints(int(index)), **fields))
        return out


def mesh_to_object(grasps: GraspSet, asset: object | None) -> np.ndarray:
    """(4, 4) from the set's frame to manigrasp's object frame (origin at the centre of mass).

    "object" frame: the identity. "mesh" frame (ACRONYM): the object's mesh file scaled by
    ``object.scale``, whose centre of mass the built object records (``com_offset_m``); a set whose
    mesh is the built object's own visual mesh (as `manigrasp label` writes, `ObjectRef.built`) is already in
    the object frame.
    """
    if grasps.frame == "object" or grasps.object.built:
        return np.eye(4)
    if asset is None:
        raise PlannerError(f"file planner: {grasps.source} is in its mesh's frame; placing it needs the built object")
    mesh = mesh_path(grasps)
    if mesh is not None and mesh.resolve() == Path(asset.visual_path).resolve():
        return np.eye(4)
    metadata = getattr(asset, "metadata", {}) or {}
    if "com_offset_m" not in metadata:
        raise PlannerError(f"file planner: object {asset.name!r} does not record its centre-of-mass offset "
                           "(rebuild it) to place mesh-frame grasps")
    scale = float(metadata.get("scale", 1.0))
    if not np.isclose(scale, grasps.object.scale):
        raise PlannerError(f"file planner: {grasps.source} is for the mesh at scale {grasps.object.scale:g}; "
                           f"object {asset.name!r} was built at scale {scale:g}")
    return translation(-np.asarray(metadata["com_offset_m"], float))


def same_mesh(grasps: GraspSet, asset: object | None) -> bool:
    """Whether `grasps` is a mesh-frame set whose mesh file is the built object's source or visual mesh: then it
    is that object's set whatever name the file gives it (an ACRONYM file names its object by its mesh's stem)."""
    if asset is None:
        return False
    metadata = getattr(asset, "metadata", {}) or {}
    return mesh_file_is(grasps, (getattr(asset, "visual_path", None), metadata.get("source")))


def mesh_file_is(grasps: GraspSet, paths: Iterable[object]) -> bool:
    """Whether `grasps` is a mesh-frame set whose mesh file is one of `paths` (None entries ignored)."""
    mesh = mesh_path(grasps) if grasps.frame == "mesh" else None
    return mesh is not None and any(Path(str(p)).resolve() == mesh.resolve() for p in paths if p)
