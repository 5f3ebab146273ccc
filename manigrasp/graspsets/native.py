"""manigrasp's own grasp-set format, as JSON or NPZ (the file's suffix decides).

JSON::

    {"format": "manigrasp.grasps", "version": 1,   # optional; another version is refused
     "hand": "parallel_jaw",                 # optional: the hand the grasps were made for
     "hand_kind": "parallel",                # optional: "parallel" or "dexterous"
     "frame": "object",                      # optional: "object" (default) or "mesh"
     "object": {"name": "box", "mesh": "box.obj", "scale": 1.0, "mass": 0.2},   # optional, any of these;
                                             # "built": true: the mesh is the built visual mesh of the
                                             # manigrasp object "name" (`ObjectRef.built`, from `label`'s .h5)
     "labelled_under": {"protocol": {"name": "lift", "params": {}}, "scene": {"pads": "rigid"}},
                                             # optional (written by `manigrasp label`): what the labels were
                                             # measured under; `evaluate` runs under it
     "grasps": [
       {"pose": [[...4...], [...], [...], [0, 0, 0, 1]],   # TCP in the object frame [m], or:
        "position": [x, y, z], "quaternion": [w, x, y, z],   # (not both: refused)
        "width": 0.05,                       # optional jaw opening at contact [m]
        "preshape": 0.0,                     # optional synergy in [0, 1] (dexterous hands)
        "joints": [[...], [...]],            # optional, dexterous hands: the grasp's own hand path, actuator
                                             # commands (joint angles [rad]) in the hand's actuator order:
                                             # [pre-shape row, squeeze-target row]
        "score": 0.9,                        # optional (default 0), higher first
        "label": {"status": "success", ...}} # optional (written by `manigrasp label`): name: text, number,
                                             # true/false or null
     ]}

NPZ: arrays ``poses`` (n, 4, 4) or ``positions`` (n, 3) with ``quaternions`` (n, 4) (w, x, y, z);
optional ``widths``, ``preshapes``, ``scores`` (n,), ``joints`` (n, 2, n_actuators) (an all-NaN entry: that
grasp uses the hand's own path); optional scalars ``hand``, ``hand_kind``, ``frame``,
``object_name``, ``object_mesh``, ``object_scale``, ``object_mass``, ``object_built``, ``labelled_under``
(JSON text, as in the JSON file); labels as ``label_<name>`` (n,).

The object frame is manigrasp's (origin at the object's centre of mass, axes of its mesh); "mesh"
means the frame of the object's mesh file scaled by ``object.scale``. TCP: z = approach (hand
toward object), y = closing (finger 1 toward finger 2), x = y cross z. A JSON grasp without a width (or with
``"width": null``) and an NPZ NaN width mean "not given"; a JSON width of NaN or +-Infinity (and an infinite NPZ
width) is a width that is not a number: that grasp is `invalid_grasp`, like a NaN pose (the set keeps it as
+-inf, as NaN means "not given" there).
`write` stores a NaN in a pose, joints or label as null (standard JSON has no NaN; JSON.parse refuses it), read
back as NaN; older files with bare NaN tokens read the same.
A quaternion must be a unit quaternion within `manigrasp.geometry.RIGID_TOLERANCE` (a non-unit one is a
file error naming the grasp: it is not silently normalised, nor read as the identity).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from manigrasp.geometry import pose_from_pos_quat, quaternion_defect
from manigrasp.graspsets.model import GraspFileError, GraspSet, ObjectRef, labelled_under_from_text

FORMAT = "manigrasp.grasps"
VERSION = 1
SUFFIXES = (".json", ".npz")
_TOP_KEYS = ("format", "version", "hand", "hand_kind", "frame", "object", "labelled_under", "grasps")
_GRASP_KEYS = ("pose", "position", "quaternion", "width", "preshape", "score", "label", "joints")
_OBJECT_KEYS = ("name", "mesh", "scale", "mass", "built")
_NPZ_KEYS = ("poses", "positions", "quaternions", "widths", "preshapes", "scores", "joints", "hand", "hand_kind",
             "frame", "object_name", "object_mesh", "object_scale", "object_mass", "object_built", "labelled_under")


def read(path: str | Path) -> GraspSet:
    """Read a native grasp file (.json or .npz); `GraspFileError` names what is wrong with it."""
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise GraspFileError(f"{path}: a native grasp file ends in {' or '.join(SUFFIXES)}")
    if not path.is_file():
        raise GraspFileError(f"{path}: no such grasp file")
    return _read_json(path) if path.suffix.lower() == ".json" else _read_npz(path)


def _read_json(path: Path) -> GraspSet:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:  # ValueError: JSONDecodeError, UnicodeDecodeError, an integer of 4300+ digits
        raise GraspFileError(f"{path}: not valid JSON ({exc})") from exc
    except RecursionError as exc:  # arrays nested thousands deep: Python's parser gives up
        raise GraspFileError(f"{path}: JSON nested too deeply to read") from exc
    if not isinstance(data, dict):
        raise GraspFileError(f"{path}: the top level must be an object with a 'grasps' list")
    _unknown(data, _TOP_KEYS, str(path))
    if data.get("format", FORMAT) != FORMAT:
        raise GraspFileError(f"{path}: format is {data.get('format')!r}, expected {FORMAT!r}")
    if data.get("version", VERSION) != VERSION:
        raise GraspFileError(f"{path}: version is {data.get('version')!r}; this manigrasp reads version {VERSION}")
    for key in ("hand", "hand_kind", "frame"):
        _text(data.get(key), f"{path}: {key}")
    grasps = data.get("grasps")
    if not isinstance(grasps, list):
        raise GraspFileError(f"{path}: missing key 'grasps' (a list of grasps)")
    poses, widths, preshapes, scores, labels, joints = [], [], [], [], [], []
    for i, grasp in enumerate(grasps):
        where = f"{path}: grasp {i}"
        if not isinstance(grasp, dict):
            raise GraspFileError(f"{where} must be an object")
        _unknown(grasp, _GRASP_KEYS, where)
        poses.append(_pose(grasp, where))
        widths.append(_width(grasp.get("width"), f"{where}: width"))
        preshapes.append(_number(grasp.get("preshape"), f"{where}: preshape", 0.0))
        scores.append(_number(grasp.get("score"), f"{where}: score", 0.0))
        labels.append(_label(grasp.get("label"), f"{where}: label"))
        joints.append(None if grasp.get("joints") is None else _array(grasp["joints"], f"{where}: joints"))
    columns = _label_columns(labels, str(path))
    return GraspSet(np.array(poses).reshape(-1, 4, 4), np.array(widths), np.array(preshapes), np.array(scores),
                    frame=data.get("frame", "object"), hand=data.get("hand"), hand_kind=data.get("hand_kind"),
                    object=_object(data.get("object") or {}, str(path)), labels=columns, source=str(path),
                    joints=_joints_column(joints, str(path)), labelled_under=data.get("labelled_under"))


def _pose(grasp: dict, where: str) -> np.ndarray:
    if "pose" in grasp and ("position" in grasp or "quaternion" in grasp):
        raise GraspFileError(f"{where}: give 'pose' or 'position' and 'quaternion', not both")
    if "pose" in grasp:
        pose = _array(grasp["pose"], f"{where}: pose")
        if pose.shape != (4, 4):
            raise GraspFileError(f"{where}: pose must be 4x4, got shape {pose.shape}")
        return pose
    if "position" not in grasp or "quaternion" not in grasp:
        raise GraspFileError(f"{where}: missing key 'pose' (4x4) or 'position' and 'quaternion'")
    pos, quat = _array(grasp["position"], f"{where}: position"), _array(grasp["quaternion"], f"{where}: quaternion")
    if pos.shape != (3,) or quat.shape != (4,):
        raise GraspFileError(f"{where}: position must have 3 numbers and quaternion 4 (w, x, y, z), got "
                             f"shapes {pos.shape} and {quat.shape}")
    defect = quaternion_defect(quat) if np.all(np.isfinite(quat)) else None  # NaN stays: invalid_grasp
    if defect is not None:
        raise GraspFileError(f"{where}: quaternion {quat.tolist()} {defect}")
    return pose_from_pos_quat(pos[None], quat[None])[0]


def _check_quaternions(quats: np.ndarray, where: str) -> None:
    """A finite quaternion that is not unit is a file error naming its grasp (NaN ones stay: invalid_grasp)."""
    for index, quat in enumerate(quats):
        defect = quaternion_defect(quat) if np.all(np.isfinite(quat)) else None
        if defect is not None:
            raise GraspFileError(f"{where}: grasp {index}: quaternion {quat.tolist()} {defect}")


def _joints_column(rows: list[np.ndarray | None], where: str) -> np.ndarray | None:
    """(n, 2, n_act) from per-grasp joints (None: NaN rows), or None if no grasp has any."""
    given = [(i, j) for i, j in enumerate(rows) if j is not None]
    if not given:
        return None
    shape = given[0][1].shape
    if len(shape) != 2 or shape[0] != 2:
        raise GraspFileError(f"{where}: grasp {given[0][0]}: joints must be [[pre-shape...], [squeeze...]] "
                             f"(2 rows), got shape {shape}")
    for i, joints in given:
        if joints.shape != shape:
            raise GraspFileError(f"{where}: grasp {i}: joints have shape {joints.shape}, grasp {given[0][0]}'s "
                                 f"{shape} (one hand per file)")
    out = np.full((len(rows), *shape), np.nan)
    for i, joints in given:
        out[i] = joints
    return out


def _array(value: Any, where: str) -> np.ndarray:
    try:
        return np.array([np.nan if v is None else v for v in np.ravel(np.array(value, dtype=object))],
                        dtype=float).reshape(np.shape(value))
    except (TypeError, ValueError, OverflowError) as exc:  # OverflowError: an integer beyond a float's range
        raise GraspFileError(f"{where} must be numbers ({exc})") from exc


def _number(value: Any, where: str, default: float) -> float:
    if value is None:
        return default
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise GraspFileError(f"{where} must be a number, got {value!r}")
    try:
        return float(value)
    except OverflowError:  # a JSON integer of hundreds of digits: no float holds it
        raise GraspFileError(f"{where} must be a number a float can hold, got an integer of "
                             f"{value.bit_length()} bits") from None


def _width(value: Any, where: str) -> float:
    """A grasp's width [m]: NaN ("not given") when absent or null. One given as NaN or +-inf is kept as +-inf,
    not NaN, so that `placement_defect` makes the grasp `invalid_grasp` instead of reading it as not given."""
    width = _number(value, where, math.nan)
    if value is not None and not math.isfinite(width):
        return -math.inf if width < 0 else math.inf
    return width


def _text(value: Any, where: str) -> str | None:
    """`value` if it is a string or None; else `GraspFileError`."""
    if value is not None and not isinstance(value, str):
        raise GraspFileError(f"{where} must be a string, got {value!r}")
    return value


def _label(value: Any, where: str) -> dict:
    """A grasp's labels: an object of name: text, number, true/false or null ({} when absent)."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise GraspFileError(f"{where} must be an object of name: value, got {value!r}")
    for key, item in value.items():
        if item is not None and not isinstance(item, str | int | float):
            raise GraspFileError(f"{where} {key!r} must be a string, a number, true/false or null, got {item!r}")
    return value


def _object(data: Any, where: str) -> ObjectRef:
    if not isinstance(data, dict):
        raise GraspFileError(f"{where}: 'object' must be an object with name, mesh, scale, mass or built")
    _unknown(data, _OBJECT_KEYS, f"{where}: object")
    scale = _number(data.get("scale"), f"{where}: object scale", 1.0)
    mass = data.get("mass")
    built = data.get("built", False)
    if not isinstance(built, bool):
        raise GraspFileError(f"{where}: object built must be true or false, got {built!r}")
    return ObjectRef(name=_text(data.get("name"), f"{where}: object name"),
                     mesh=_text(data.get("mesh"), f"{where}: object mesh"), scale=scale,
                     mass=None if mass is None else _number(mass, f"{where}: object mass", math.nan), built=built)


def _unknown(data: dict, valid: tuple[str, ...], where: str) -> None:
    extra = sorted(set(data) - set(valid))
    if extra:
        raise GraspFileError(f"{where}: unknown key {extra[0]!r}; valid keys: {', '.join(valid)}")


def _label_columns(labels: list[dict], where: str) -> dict[str, np.ndarray]:
    names = sorted({k for label in labels for k in label})
    if not names:
        return {}
    missing = [i for i, label in enumerate(labels) if set(label) != set(names)]
    if missing:
        raise GraspFileError(f"{where}: grasp {missing[0]} has labels {sorted(labels[missing[0]])}, "
                             f"others have {names} (label every grasp alike, or none)")
    # null is how `write` stores NaN (standard JSON has no NaN); older files hold bare NaN, which reads the same.
    return {name: np.array([math.nan if label[name] is None else label[name] for label in labels]) for name in names}


def _read_npz(path: Path) -> GraspSet:
    import zipfile

    if not zipfile.is_zipfile(path):  # np.load reads anything else as a pickle and says so ("pickled data")
        raise GraspFileError(f"{path}: not an NPZ file (an NPZ is a zip archive of arrays, as numpy.savez writes)")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except (OSError, ValueError) as exc:
        raise GraspFileError(f"{path}: not a readable NPZ file ({exc})") from exc
    unknown = sorted(k for k in arrays if k not in _NPZ_KEYS and not k.startswith("label_"))
    if unknown:  # a misspelled array ('width', 'score') was ignored: every grasp ran without it
        from manigrasp.registry import nearest

        hint = nearest(unknown[0], _NPZ_KEYS)
        raise GraspFileError(f"{path}: unknown array {unknown[0]!r}" + (f" (did you mean {hint!r}?)" if hint else "")
                             + f"; valid: {', '.join(_NPZ_KEYS)}, label_<name>")
    if "poses" in arrays and ("positions" in arrays or "quaternions" in arrays):
        raise GraspFileError(f"{path}: give 'poses' or 'positions' and 'quaternions', not both")
    if "poses" in arrays:
        poses = _floats(arrays, "poses", path)
        if poses.ndim != 3 or poses.shape[1:] != (4, 4):
            raise GraspFileError(f"{path}: 'poses' must be (n, 4, 4), got shape {poses.shape}")
    elif "positions" in arrays and "quaternions" in arrays:
        pos, quat = _floats(arrays, "positions", path), _floats(arrays, "quaternions", path)
        if pos.ndim != 2 or pos.shape[1] != 3 or quat.shape != (len(pos), 4):
            raise GraspFileError(f"{path}: 'positions' must be (n, 3) and 'quaternions' (n, 4), got "
                                 f"{pos.shape} and {quat.shape}")
        _check_quaternions(quat, str(path))
        poses = pose_from_pos_quat(pos, quat)
    else:
        raise GraspFileError(f"{path}: missing key 'poses' (n, 4, 4) or 'positions' and 'quaternions'")
    n = len(poses)

    def column(key: str, default: float) -> np.ndarray:
        return _floats(arrays, key, path) if key in arrays else np.full(n, default)

    def text(key: str) -> str | None:
        return _npz_scalar(arrays, key, "U", path)

    def number(key: str) -> float | None:
        value = _npz_scalar(arrays, key, "biuf", path)
        return None if value is None else float(value)

    scale = number("object_scale")
    ref = ObjectRef(name=text("object_name"), mesh=text("object_mesh"), scale=1.0 if scale is None else scale,
                    mass=number("object_mass"), built=bool(number("object_built") or False))
    labels = {k.removeprefix("label_"): v for k, v in arrays.items() if k.startswith("label_")}
    joints = _floats(arrays, "joints", path) if "joints" in arrays else None
    under = text("labelled_under")
    under = None if under is None else labelled_under_from_text(under, str(path))
    return GraspSet(poses, column("widths", math.nan), column("preshapes", 0.0), column("scores", 0.0),
                    frame=text("frame") or "object", hand=text("hand"), hand_kind=text("hand_kind"),
                    object=ref, labels=labels, source=str(path), joints=joints, labelled_under=under)


def _floats(arrays: dict[str, np.ndarray], key: str, path: Path) -> np.ndarray:
    """NPZ array `key` as floats; `GraspFileError` if it holds something else (text)."""
    try:
        return arrays[key].astype(float)
    except (TypeError, ValueError) as exc:
        raise GraspFileError(f"{path}: {key!r} must be numbers, got dtype {arrays[key].dtype}") from exc


def _npz_scalar(arrays: dict[str, np.ndarray], key: str, kinds: str, path: Path) -> Any:
    """NPZ scalar `key` (a size-1 array of a dtype kind in `kinds`: "U" text, "biuf" a number), or None if absent."""
    if key not in arrays:
        return None
    value = arrays[key]
    if value.size != 1 or value.dtype.kind not in kinds:
        want = "a string" if kinds == "U" else "a number"
        raise GraspFileError(f"{path}: {key!r} must be one value, {want}; got shape {value.shape}, dtype {value.dtype}")
    return value.item()


def write(grasps: GraspSet, path: str | Path) -> Path:
    """Write `grasps` as a native file (.json or .npz by `path`'s suffix); returns the path."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise GraspFileError(f"{path}: a native grasp file ends in {' or '.join(SUFFIXES)}")
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".npz":
        _write_npz(grasps, path)
    else:
        # allow_nan: a width or pre-shape that is not a number (read from such a file) is written back as it came.
        path.write_text(json.dumps(_json_payload(grasps), indent=1, allow_nan=True))
    return path


def _json_payload(grasps: GraspSet) -> dict[str, Any]:
    ref = grasps.object
    obj = {k: v for k, v in (("name", ref.name), ("mesh", ref.mesh), ("scale", ref.scale), ("mass", ref.mass),
                             ("built", ref.built or None)) if v is not None}
    rows = []
    for i in range(len(grasps)):
        row: dict[str, Any] = {"pose": _nulls(grasps.poses[i].tolist()), "score": float(grasps.scores[i]),
                               "preshape": float(grasps.preshapes[i])}
        if not np.isnan(grasps.widths[i]):  # NaN: not given; +-inf (not a number) written as +-Infinity
            row["width"] = float(grasps.widths[i])
        joints = grasps.grasp_joints(i)
        if joints is not None:
            row["joints"] = _nulls(joints.tolist())
        if grasps.labels:
            row["label"] = {k: _nulls(v[i].item()) for k, v in grasps.labels.items()}
        rows.append(row)
    head = {"format": FORMAT, "version": VERSION, "hand": grasps.hand, "hand_kind": grasps.hand_kind,
            "frame": grasps.frame, "object": obj, "labelled_under": grasps.labelled_under}
    return {**{k: v for k, v in head.items() if v is not None}, "grasps": rows}


def _nulls(value: Any) -> Any:
    """`value` (a number, or nested lists of them) with NaN as None: JSON null, which every JSON parser reads
    (a bare NaN is not standard JSON), and which the reader reads back as NaN."""
    if isinstance(value, list):
        return [_nulls(v) for v in value]
    return None if isinstance(value, float) and math.isnan(value) else value


def _write_npz(grasps: GraspSet, path: Path) -> None:
    ref = grasps.object
    arrays: dict[str, Any] = {"poses": grasps.poses, "widths": grasps.widths, "preshapes": grasps.preshapes,
                              "scores": grasps.scores, "frame": np.array(grasps.frame),
                              "object_scale": np.array(ref.scale)}
    for key, value in (("hand", grasps.hand), ("hand_kind", grasps.hand_kind), ("object_name", ref.name),
                       ("object_mesh", ref.mesh), ("object_mass", ref.mass), ("object_built", ref.built or None)):
        if value is not None:
            arrays[key] = np.array(value)
    arrays.update({f"label_{k}": v for k, v in grasps.labels.items()})
    if grasps.joints is not None:
        arrays["joints"] = grasps.joints
    if grasps.labelled_under is not None:
        arrays["labelled_under"] = np.array(json.dumps(grasps.labelled_under))  # JSON text, as the .h5 holds it
    with path.open("wb") as handle:
        np.savez_compressed(handle, **arrays)
