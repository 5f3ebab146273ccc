"""ACRONYM's HDF5 layout (Eppner et al., ICRA 2021), read and written (needs the `datasets` extra: h5py).

Layout::

    grasps/transforms        (n, 4, 4) gripper poses in the frame of the scaled object mesh [m]
    grasps/qualities/<...>   (n,) per-grasp labels (ACRONYM: flex/object_in_gripper, 1 = success)
    object/file              path of the object mesh (relative: to the .h5 file)
    object/scale             factor applied to the mesh's vertices
    object/mass              [kg] (optional)

The gripper frame is the Franka Panda hand's (`panda_hand`): origin at the hand's base, z = approach,
the fingers at x = +-4.1 cm closing along x. manigrasp's TCP (every parallel hand's: the centre
between the finger pads, z = approach, y = closing) is that frame moved `ACRONYM_TCP_DEPTH` along z
and turned -90 degrees about z, so TCP y = gripper x and TCP x = -gripper y:

    T_tcp = T_acronym @ ACRONYM_TO_TCP

The same transform serves every parallel hand (panda, parallel_jaw, robotiq_2f85): each one's TCP
sits between its own pads, where ACRONYM's grasp puts the object. Jaws are symmetric, so the sign
of the closing axis does not matter. ACRONYM grasps are parallel-jaw grasps: on a dexterous hand
they are `invalid_grasp`.

Files written by manigrasp add ``grasps/qualities/manigrasp/*`` (the planner's score as ``planner_score``, read
back as the scores, and the set's labels, read back by their own names, ``status`` not ``manigrasp/status``:
from `manigrasp label` status, success (1 = the protocol's success; no ``flex/*`` key, which would claim
ACRONYM's FleX physics), trial id, seed, measures), ``grasps/manigrasp/widths``,
``grasps/manigrasp/labelled_under`` (JSON text: the protocol and scene the labels were measured under,
`GraspSet.labelled_under`),
``object/manigrasp/name``, the manigrasp object's name, and ``gripper/manigrasp/hand``, the hand the grasps were
made for (`GraspSet.hand`, read back; ACRONYM's ``gripper/type`` is written, as ``panda``, only when that hand
is the Panda: the transforms are always in the Panda gripper's frame, the widths and labels are the named hand's).
ACRONYM's own keys are as above, so ACRONYM's tools read the file. `manigrasp label` sets ``object/file`` to
the object's built visual mesh, whose frame is manigrasp's object frame, and ``object/manigrasp/built`` to 1: a
reader then names the object by ``object/manigrasp/name`` (`ObjectRef.built`), where a file without it is named
by its mesh file's stem.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from manigrasp.graspsets.model import GraspFileError, GraspSet, ObjectRef, labelled_under_from_text

# Franka's documented flange-to-TCP distance of the Panda hand (`panda_hand_tcp` in franka_description),
# the fingertip pads' centre; Contact-GraspNet's "gripper depth" for ACRONYM grasps is the same 0.1034 m.
ACRONYM_TCP_DEPTH = 0.1034  # [m]
ACRONYM_TO_TCP = np.array([[0.0, 1.0, 0.0, 0.0],
                           [-1.0, 0.0, 0.0, 0.0],
                           [0.0, 0.0, 1.0, ACRONYM_TCP_DEPTH],
                           [0.0, 0.0, 0.0, 1.0]])
SUFFIXES = (".h5", ".hdf5")
LABEL_PREFIX = "manigrasp/"  # under grasps/qualities/: a set's own labels (read back without it)
SCORE_KEY = f"{LABEL_PREFIX}planner_score"  # under grasps/qualities/: the scores (not a label)
WIDTH_KEY = "grasps/manigrasp/widths"
NAME_KEY = "object/manigrasp/name"
BUILT_KEY = "object/manigrasp/built"
HAND_KEY = "gripper/manigrasp/hand"
LABELLED_UNDER_KEY = "grasps/manigrasp/labelled_under"  # JSON text: `GraspSet.labelled_under`
PANDA = "panda"  # ACRONYM's gripper/type of the Franka Panda hand, and manigrasp's name of that hand


def tcp_from_acronym(transforms: np.ndarray) -> np.ndarray:
    """(..., 4, 4) TCP poses of ACRONYM gripper poses (..., 4, 4), in the same frame."""
    return np.asarray(transforms, float) @ ACRONYM_TO_TCP


def acronym_from_tcp(poses: np.ndarray) -> np.ndarray:
    """(..., 4, 4) ACRONYM gripper poses of TCP poses (..., 4, 4): the inverse of `tcp_from_acronym`."""
    return np.asarray(poses, float) @ np.linalg.inv(ACRONYM_TO_TCP)


def _h5py() -> Any:
    try:
        import h5py
    except ImportError as exc:
        raise GraspFileError("ACRONYM's HDF5 layout needs h5py, the `datasets` extra: in the manigrasp clone run "
                             "`make setup EXTRAS=dev,datasets` (or "
                             "`.venv/bin/pip install -c constraints.txt -e '.[datasets]'`)") from exc
    return h5py


def read(path: str | Path) -> GraspSet:
    """Read an ACRONYM-layout file: TCP poses in the scaled mesh's frame ("mesh"), labels from
    ``grasps/qualities``; `GraspFileError` names a missing key or a wrong shape."""
    h5py = _h5py()
    path = Path(path)
    if not path.is_file():
        raise GraspFileError(f"{path}: no such grasp file")
    try:
        handle = h5py.File(path, "r")
    except OSError as exc:
        raise GraspFileError(f"{path}: not a readable HDF5 file ({exc})") from exc
    with handle:
        transforms = _dataset(handle, "grasps/transforms", path)
        if transforms.ndim != 3 or transforms.shape[1:] != (4, 4):
            raise GraspFileError(f"{path}: 'grasps/transforms' must be (n, 4, 4), got shape {transforms.shape}")
        n = len(transforms)
        mesh = _dataset(handle, "object/file", path)
        scale = _scalar(_dataset(handle, "object/scale", path), "object/scale", path)
        mass = _scalar(_dataset(handle, "object/mass", path), "object/mass", path) if "object/mass" in handle \
            else None
        labels = _qualities(handle, n, path)
        widths = _numbers(_dataset(handle, WIDTH_KEY, path), WIDTH_KEY, path) if WIDTH_KEY in handle \
            else np.full(n, np.nan)
        name = _string(_dataset(handle, NAME_KEY, path), NAME_KEY, path) if NAME_KEY in handle else None
        built = bool(_scalar(_dataset(handle, BUILT_KEY, path), BUILT_KEY, path)) if BUILT_KEY in handle else False
        hand = _string(_dataset(handle, HAND_KEY, path), HAND_KEY, path) if HAND_KEY in handle else None
        under = labelled_under_from_text(_string(_dataset(handle, LABELLED_UNDER_KEY, path), LABELLED_UNDER_KEY,
                                                 path), f"{path}: {LABELLED_UNDER_KEY}") \
            if LABELLED_UNDER_KEY in handle else None
    scores = _numbers(labels.pop(SCORE_KEY, np.zeros(n)), f"grasps/qualities/{SCORE_KEY}", path)
    labels = _unprefixed(labels, path)
    mesh_path = _string(mesh, "object/file", path)
    ref = ObjectRef(name=name or Path(mesh_path).stem, mesh=mesh_path, scale=scale, mass=mass,
                    built=built and bool(name))
    poses = tcp_from_acronym(_numbers(transforms, "grasps/transforms", path))
    return GraspSet(poses, widths, np.zeros(n), scores, frame="mesh", hand=hand, hand_kind="parallel", object=ref,
                    labels=labels, source=str(path), labelled_under=under)



def _string(value: Any, key: str, path: Path) -> str:
    """A scalar string dataset's text (h5py gives bytes); `GraspFileError` if it is not one string."""
    array = np.asarray(value)
    if array.size != 1 or array.dtype.kind not in "SOU":
        raise GraspFileError(f"{path}: {key!r} must be one string, got shape {array.shape}, dtype {array.dtype}")
    item = array.item()
    return item.decode() if isinstance(item, bytes) else str(item)


def _numbers(value: Any, key: str, path: Path) -> np.ndarray:
    """A dataset's values as floats; `GraspFileError` if it holds something else (text)."""
    array = np.asarray(value)
    if array.dtype.kind not in "biuf":
        raise GraspFileError(f"{path}: {key!r} must be numbers, got dtype {array.dtype}")
    return array.astype(float)


def _dataset(handle: Any, key: str, path: Path) -> np.ndarray:
    if key not in handle:
        raise GraspFileError(f"{path}: missing key {key!r} (ACRONYM layout: grasps/transforms, object/file, "
                             "object/scale)")
    item = handle[key]
    if not hasattr(item, "shape"):  # an HDF5 group, not a dataset
        raise GraspFileError(f"{path}: {key!r} must be a dataset, not a group of {', '.join(sorted(item))}")
    return np.asarray(item[()])


def _scalar(value: Any, key: str, path: Path) -> float:
    array = np.asarray(value)
    if array.size != 1 or not np.issubdtype(array.dtype, np.number):
        raise GraspFileError(f"{path}: {key!r} must be one number, got shape {array.shape}")
    number = float(array.reshape(()))
    if not np.isfinite(number):
        raise GraspFileError(f"{path}: {key!r} is {number}")
    return number


def _qualities(handle: Any, n: int, path: Path) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    if "grasps/qualities" not in handle:
        return out

    def visit(name: str, item: Any) -> None:
        if hasattr(item, "shape"):
            value = np.asarray(item[()])
            if value.shape[:1] != (n,):
                raise GraspFileError(f"{path}: 'grasps/qualities/{name}' must have one value per grasp ({n}), "
                                     f"got shape {value.shape}")
            out[name] = _text(value) if value.dtype.kind in "SO" else value

    handle["grasps/qualities"].visititems(visit)
    return out


def _unprefixed(labels: dict[str, np.ndarray], path: Path) -> dict[str, np.ndarray]:
    """The labels by the names `write` was given: ``manigrasp/status`` as ``status`` (ACRONYM's, ``flex/...``, as
    they are)."""
    out: dict[str, np.ndarray] = {}
    for key, value in labels.items():
        name = key.removeprefix(LABEL_PREFIX)
        if name in out:
            raise GraspFileError(f"{path}: label {name!r} is stored twice (grasps/qualities/{name} and "
                                 f"grasps/qualities/{LABEL_PREFIX}{name})")
        out[name] = value
    return out


def _text(value: np.ndarray) -> np.ndarray:
    """Strings stored as bytes (fixed or variable length) as a str array."""
    return np.array([v.decode("utf-8") if isinstance(v, bytes) else str(v) for v in value.ravel()]).reshape(
        value.shape)


def write(grasps: GraspSet, path: str | Path) -> Path:
    """Write a parallel-jaw `grasps` set in ACRONYM's layout. Its poses must be in the frame of
    ``grasps.object.mesh`` (scaled by ``object.scale``); labels go to ``grasps/qualities/manigrasp/``, the
    object's name (and `ObjectRef.built`) to ``object/manigrasp/``, the hand to ``gripper/manigrasp/hand``
    (``gripper/type`` is ``panda`` for the Panda's set only)."""
    h5py = _h5py()
    path = Path(path)
    if grasps.object.mesh is None:
        raise GraspFileError(f"{path}: ACRONYM's layout needs the object's mesh file (object/file)")
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as handle:
        handle["grasps/transforms"] = acronym_from_tcp(grasps.poses)
        handle[WIDTH_KEY] = grasps.widths
        handle[f"grasps/qualities/{SCORE_KEY}"] = grasps.scores
        for key, value in grasps.labels.items():
            value = np.asarray(value)
            name = key if "/" in key else f"{LABEL_PREFIX}{key}"
            if name == SCORE_KEY:
                raise GraspFileError(f"{path}: label {key!r} is the name of the scores' key; rename the label")
            if value.dtype.kind == "U":  # UTF-8 variable-length strings (a detail may hold any character)
                handle.create_dataset(f"grasps/qualities/{name}", data=value.astype(object),
                                      dtype=h5py.string_dtype())
            else:
                handle[f"grasps/qualities/{name}"] = value
        handle["object/file"] = str(grasps.object.mesh)
        if grasps.object.name is not None:
            handle[NAME_KEY] = str(grasps.object.name)
            if grasps.object.built:
                handle[BUILT_KEY] = 1
        handle["object/scale"] = float(grasps.object.scale)
        if grasps.object.mass is not None:
            handle["object/mass"] = float(grasps.object.mass)
        if grasps.hand is not None:
            handle[HAND_KEY] = str(grasps.hand)
        if grasps.hand == PANDA:
            handle["gripper/type"] = PANDA
        if grasps.labelled_under is not None:
            handle[LABELLED_UNDER_KEY] = json.dumps(grasps.labelled_under)
    return path
