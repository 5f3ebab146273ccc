"""Physics-labelled grasp datasets: a benchmark run with many candidates, then an exporter.

    manigrasp label CONFIG --out DIR

runs CONFIG like `manigrasp bench` (resumable, local pool or Ray, progress bar) into DIR, then
writes every stored trial's grasp with its label to ``DIR/grasps/``, one file per object x hand x
planner (x observation, protocol):

    <object>__<hand>__<planner>.json   manigrasp's native format (or .npz)
    <object>__<hand>__<planner>.h5     ACRONYM's layout (parallel hands only; needs h5py)

A dexterous hand's grasps carry their joint configuration where the planner gave one (``joints`` in the
native file, the grasp's own hand path). ACRONYM's layout holds parallel-jaw gripper poses only, so a
dexterous set is written in the native format alone, and its `Exported.note` says so.

Grasps are written in the object's frame (``inv(object_pose) @ grasp``), best first (trial order),
with labels: status, success, trial id, seed, the protocol's measures, the object's settled pose and the
resting pose it was placed in (``rest_*``: ``rest_index`` -1 is its file's orientation). Under
``rest: stable_k`` a file names its object by its plain name (``005_tomato_soup_can``, not the group's
``005_tomato_soup_can@rest0``), so `manigrasp evaluate FILE` resolves it; ``rest_index`` says which pose.
Trials that executed no grasp have no grasp to write: those without a finite grasp pose (`no_grasp`: the
planner returned fewer than asked; `planner_error`: it failed; a `timeout` while planning). Nor has a
`harness_fault` a label (a bug of manigrasp stopped the trial, before or after the grasp: physics did not
judge it, and the reports leave it out of every rate). They are left out of the files and the summary counts
them by status.
"""

from __future__ import annotations

import json
import math
import time
from collections import defaultdict
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from manigrasp.bench.config import BenchConfig
from manigrasp.bench.store import ResultsStore, joints_from_text
from manigrasp.errors import ConfigError, ManigraspError
from manigrasp.graspsets import GraspSet, ObjectRef, acronym, native
from manigrasp.protocol.result import PoseRecord, Status
from manigrasp.runfiles import META_NAME, STORE_NAME

POSE_FIELDS = ("x_m", "y_m", "z_m", "qw", "qx", "qy", "qz")
LABEL_COLUMNS = ("status", "trial_id", "seed", "detail", "last_phase", "max_translation_m", "max_rotation_deg",
                 "grip_force_n", "sim_force_closure", "sim_epsilon_l1", "planned_epsilon_l1", "fingers_in_contact",
                 *(f"object_{f}" for f in POSE_FIELDS), "rest_index", "rest_probability",
                 *(f"rest_{f}" for f in POSE_FIELDS))
DATASET_DIR = "grasps"


@dataclass(frozen=True)
class Exported:
    """One exported grasp set: its files, how many grasps, how many succeeded.

    `object` is the group's object label (``<name>@rest<i>`` under ``rest: stable_k``; the files name the
    plain name); `trial_ids` the trials written, in file order.
    """

    group: str
    object: str
    hand: str
    grasps: int
    successes: int
    files: tuple[Path, ...]
    note: str = ""
    trial_ids: tuple[str, ...] = ()


@dataclass(frozen=True)
class LabelSummary:
    """What `label` did.

    Attributes:
        run_dir: the run directory (the dataset is in ``run_dir/grasps``).
        ran: trials run by this call (with or without a grasp); already_done: found in the store (resumed).
        seconds: wall time of the run (simulation and planning) [s].
        exported: the grasp sets written.
        without_grasp: per status, the trials of the run with no grasp or no label to write (`export_dataset`).
        labelled_now: grasps written whose trials this call ran.
    """

    run_dir: Path
    ran: int
    already_done: int
    seconds: float
    exported: tuple[Exported, ...]
    without_grasp: dict[str, int]
    labelled_now: int = 0

    @property
    def written(self) -> int:
        """Grasps written, over every exported set (this call's trials and those already stored)."""
        return sum(item.grasps for item in self.exported)

    @property
    def skipped(self) -> int:
        """Trials of the run without a grasp, left out of the files."""
        return sum(self.without_grasp.values())

    @property
    def labelled_per_second(self) -> float:
        """Grasps labelled (run by this call and written) per second of this call's wall time: trials without a
        grasp are not counted, as they label nothing."""
        return self.labelled_now / self.seconds if self.seconds > 0 else math.nan

    def success_share(self) -> dict[str, tuple[int, int]]:
        """Per object: (successes, grasps) over every exported set."""
        out: dict[str, list[int]] = defaultdict(lambda: [0, 0])
        for item in self.exported:
            out[item.object][0] += item.successes
            out[item.object][1] += item.grasps
        return {k: (v[0], v[1]) for k, v in out.items()}


def label(config: BenchConfig, run_dir: Path, jobs: int = 1, executor: str = "local", address: str | None = None,
          base: Path | None = None, progress: bool = True, native_suffix: str = ".json") -> LabelSummary:
    """Run (or resume) `config` into `run_dir` and export its labelled grasps to ``run_dir/grasps``."""
    from manigrasp.bench.runner import run_benchmark

    start = time.perf_counter()
    fresh: set[str] = set()  # the trials this call runs
    summary = run_benchmark(config, Path(run_dir), jobs=jobs, executor=executor, address=address, base=base,
                            progress=progress, on_result=lambda key, _: fresh.add(key.trial_id))
    seconds = time.perf_counter() - start
    exported, without_grasp = export_dataset(run_dir, config, base, native_suffix)
    now = sum(trial in fresh for item in exported for trial in item.trial_ids)
    return LabelSummary(Path(run_dir), summary.ran, summary.already_done, seconds, tuple(exported), without_grasp,
                        now)


def export_dataset(run_dir: Path, config: BenchConfig | None = None, base: Path | None = None,
                   native_suffix: str = ".json") -> tuple[list[Exported], dict[str, int]]:
    """Write every stored trial's grasp and label under ``run_dir/grasps``; returns (sets, trials not written
    per status). A trial without a finite grasp pose executed no grasp, and a `harness_fault` has no label
    (module docstring): they are left out.

    `config` (default: the run's own, from run.json) names each object's source, needed for the
    ACRONYM file's ``object/file`` (the built object's visual mesh, whose frame is the object frame).
    """
    from manigrasp import hands
    from manigrasp.bench.rundir import config_dir

    run_dir = Path(run_dir)
    config = config or _run_config(run_dir)
    sources = _sources(config, base or config_dir(run_dir))
    with ResultsStore(run_dir / STORE_NAME) as store:
        rows = list(store.rows())
    by_group: dict[str, list[dict]] = defaultdict(list)
    for row in rows:
        by_group[_group_id(row)].append(row)
    out: list[Exported] = []
    without_grasp: dict[str, int] = defaultdict(int)
    names = _file_names(by_group)
    for group, members in by_group.items():
        members.sort(key=lambda r: int(r["grasp_index"]))
        kept = [r for r in members if not _unlabelled(r)]
        for row in members:
            if _unlabelled(row):
                without_grasp[str(row["status"])] += 1
        stem = run_dir / DATASET_DIR / names[group]
        if not kept:  # no file: and none left of an earlier export (which wrote such trials as NaN grasps)
            for stale in (_with_suffix(stem, native_suffix), _with_suffix(stem, ".h5")):
                stale.unlink(missing_ok=True)
            continue
        first = kept[0]
        hand = hands.load(str(first["hand"]))
        source = sources.get(object_name(first))
        grasps = replace(grasp_set(kept, hand.kind), object=native_object(object_name(first), source),
                         labelled_under=labelled_under(config, str(first["protocol"])))
        files = [native.write(grasps, _with_suffix(stem, native_suffix))]
        note = ""
        if hand.kind != "parallel":
            note = (f"no ACRONYM file: its layout holds parallel-jaw grasps only, {hand.name!r} is {hand.kind} "
                    "(the native file has the grasps and their joints)")
        elif source is None:
            note = "no ACRONYM file: the object's mesh is not found (moved since the run?)"
        elif not _has_h5py():
            note = "no ACRONYM file: h5py is not installed (the `datasets` extra)"
        else:
            files.append(acronym.write(_in_visual_frame(grasps, source), _with_suffix(stem, ".h5")))
        successes = int(np.sum(grasps.labels["success"]))
        out.append(Exported(group, str(first["object"]), str(first["hand"]), len(grasps), successes, tuple(files),
                            note, tuple(str(r["trial_id"]) for r in kept)))
    return out, dict(without_grasp)


def labelled_under(config: BenchConfig, protocol_label: str) -> dict:
    """What a group's labels were measured under (`GraspSet.labelled_under`): the protocol its trials ran
    (``protocol_label``, a label of `BenchConfig.protocol_labels`) with its parameters, and the scene, every
    parameter (so that a default changed since, as the pads' grid on 5 Dec 2026, does not change what `evaluate`
    re-runs; ``rest: most_stable`` with them, the object's one resting pose
    the labels were measured in; ``stable_k``'s settings left out: each of its groups is one of the k poses,
    named by the grasps' ``rest_index`` labels, and `evaluate` places them on one pose), so that `manigrasp
    evaluate FILE` re-runs the grasps as they were labelled (under the defaults, a set labelled under `lift` or
    with rigid pads re-ran under `standard` with compliant pads)."""
    from manigrasp.config import to_mapping

    entries = dict(zip(config.protocol_labels, config.protocol_entries, strict=True))
    if protocol_label not in entries:
        raise ConfigError(f"the stored trials ran under protocol {protocol_label!r}, which the config does not "
                          f"list ({', '.join(entries)}): export with the run's own config")
    entry = entries[protocol_label]
    scene = json.loads(json.dumps(to_mapping(config.scene), default=str))
    return {"protocol": {"name": entry.name, "params": json.loads(json.dumps(dict(entry.params), default=str))},
            "scene": {k: v for k, v in scene.items() if k in _recorded_scene_keys(scene)}}


def _recorded_scene_keys(scene: dict) -> set[str]:
    """The scene parameters `labelled_under` may record: all but the resting-pose ones, and ``rest`` itself when
    it is ``most_stable`` (one pose, which evaluate can take)."""
    keep = {k for k in scene if not k.startswith("rest")}
    return keep | {"rest"} if scene.get("rest") == "most_stable" else keep


def native_object(name: str, source) -> ObjectRef:
    """The object as the native file names it, so that `manigrasp evaluate FILE.json` runs the grasps on the
    object their labels were measured on: a shipped object by its name, with the config's mass where that is not
    the shipped one (by name alone, a 3 kg sugar box's drops re-ran as successes at 0.514 kg); a mesh or a YCB
    download by its mesh file (absolute), scale and mass (by name alone, `evaluate` refused it: an unknown
    object). `source` None (a mesh moved since the run): the name alone."""
    from manigrasp.objects import catalog
    from manigrasp.objects.meshio import ycb_mesh_file
    from manigrasp.objects.pipeline import DEFAULT_DENSITY

    if source is None:
        return ObjectRef(name=name)
    try:
        if catalog.is_shipped_name(source.name):
            shipped = catalog.shipped(source.name).mass
            return ObjectRef(name=name, mass=None if source.mass in (None, shipped) else float(source.mass))
        mesh = source.mesh if source.mesh is not None else ycb_mesh_file(source.ycb_folder or "")
        mass = source.mass
        if mass is None and source.density != DEFAULT_DENSITY:  # evaluate has no density: give the mass it made
            mass = float(catalog.build(source).asset.mass)
    except ManigraspError:
        return ObjectRef(name=name)
    return ObjectRef(name=name, mesh=str(Path(mesh).resolve()), scale=float(source.scale),
                     mass=None if mass is None else float(mass))


def _with_suffix(stem: Path, suffix: str) -> Path:
    """`stem` with `suffix` appended (`Path.with_suffix` would replace the part after a dot in an object's name:
    every set of ``box.v2`` written to ``box.json``, each over the one before)."""
    return stem.with_name(stem.name + suffix)


def grasp_set(rows: list[dict], hand_kind: str) -> GraspSet:
    """The labelled `GraspSet` (object frame) of one group's stored rows, in row order."""
    poses = np.array([_object_frame(r) for r in rows]).reshape(-1, 4, 4)
    labels = {name: np.array([r.get(name, math.nan) for r in rows]) for name in LABEL_COLUMNS}
    labels["success"] = np.array([r["status"] == Status.SUCCESS.value for r in rows])
    first = rows[0]
    return GraspSet(poses, np.array([float(r["grasp_width_m"]) for r in rows], dtype=float),
                    np.nan_to_num(np.array([float(r["grasp_preshape"]) for r in rows], dtype=float)),
                    np.array([_finite(r["score"]) for r in rows]), frame="object", hand=str(first["hand"]),
                    hand_kind=hand_kind, object=ObjectRef(name=object_name(first)), labels=labels,
                    source=str(first["trial_id"]).rsplit("/", 1)[0], joints=_joints(rows))


def _joints(rows: list[dict]) -> np.ndarray | None:
    """(n, 2, n_act) the stored joints of each row (NaN: the hand's own path), or None if no row has any."""
    given = [joints_from_text(str(r.get("grasp_joints") or "")) for r in rows]
    shapes = {j.shape for j in given if j is not None}
    if not shapes:
        return None
    (shape,) = shapes  # one hand per group
    return np.stack([np.full(shape, np.nan) if j is None else j for j in given])


def _object_frame(row: dict) -> np.ndarray:
    """The grasp in the object's frame, inv(object) @ grasp (NaN if either is not stored)."""
    try:
        grasp = PoseRecord(*(float(row[f"grasp_{f}"]) for f in POSE_FIELDS)).matrix()
        obj = PoseRecord(*(float(row[f"object_{f}"]) for f in POSE_FIELDS)).matrix()
    except ValueError:
        return np.full((4, 4), np.nan)
    return np.linalg.inv(obj) @ grasp


def _unlabelled(row: dict) -> bool:
    """A stored trial with no grasp to write (no finite pose) or no label (a `harness_fault`)."""
    return _nan_grasp(row) or row["status"] == Status.HARNESS_FAULT.value


def _nan_grasp(row: dict) -> bool:
    """Whether the trial stores no finite grasp pose: it executed no grasp (whatever its status)."""
    return not np.all(np.isfinite([float(row[f"grasp_{f}"]) for f in POSE_FIELDS]))


def object_name(row: dict) -> str:
    """The object's plain name of a stored row: its label without the ``@rest<i>`` of ``rest: stable_k`` groups
    (the pose is in the row's ``rest_index``), as its source and `manigrasp evaluate` know it."""
    from manigrasp.bench.trials import REST_LABEL

    label = str(row["object"])
    try:
        index = int(row.get("rest_index", -1))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return label
    return label.removesuffix(f"{REST_LABEL}{index}") if index >= 0 else label


def _finite(value: object) -> float:
    value = float(value)  # type: ignore[arg-type]
    return value if math.isfinite(value) else 0.0


def _group_id(row: dict) -> str:
    """A trial's group: its id without the trailing grasp index."""
    return str(row["trial_id"]).rsplit("/", 1)[0]


def _file_names(groups: dict[str, list[dict]]) -> dict[str, str]:
    """``<object>__<hand>__<planner>`` per group, with observation and protocol added where needed to be unique."""
    from manigrasp.record.policy import trial_file_name

    def name(row: dict, full: bool) -> str:
        parts = [row["object"], row["hand"], row["planner"]] + ([row["observation"], row["protocol"]] if full else [])
        return trial_file_name("/".join(str(p) for p in parts)).removesuffix(".rrd")

    short = {g: name(rows[0], False) for g, rows in groups.items()}
    unique = len(set(short.values())) == len(short)
    return short if unique else {g: name(rows[0], True) for g, rows in groups.items()}


def _in_visual_frame(grasps: GraspSet, source) -> GraspSet:
    """The set as ACRONYM sees it: poses in the frame of the built object's visual mesh (= the object frame)."""
    from manigrasp.objects import catalog

    asset = catalog.build(source).asset
    return replace(grasps, frame="mesh", object=ObjectRef(name=grasps.object.name, mesh=str(asset.visual_path),
                                                          scale=1.0, mass=float(asset.mass), built=True))


def _sources(config: BenchConfig, base: Path | None) -> dict:
    out = {}
    for entry in config.objects:
        try:
            source = entry.source(base)
        except ManigraspError:  # a mesh moved since the run: the native export still works
            continue
        out[source.name] = source
    return out


def _run_config(run_dir: Path) -> BenchConfig:
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.rundir import load_meta

    return parse_config(load_meta(run_dir)["config"], where=f"{run_dir}/{META_NAME}")


def _has_h5py() -> bool:
    try:
        import h5py  # noqa: F401
    except ImportError:
        return False
    return True
