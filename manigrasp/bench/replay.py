"""Re-simulating stored trials of a finished run: one to watch (`replay_trial`), or many to record
after the fact (`record_trials`, e.g. the failures of a run that was made without ``--record``).

A trial is re-created from its run: the resolved config in run.json gives its group (object, hand,
protocol, physics) and seed (`Group.trial_seed`), and results.sqlite its executed grasp (the TCP
pose in the world, width, pre-shape). The object is settled again in a freshly compiled scene (the
same deterministic drop as the run's), the stored grasp is executed under the group's protocol with
the trial's seed (with its own hand path if it had one), and the status is compared with the stored
one. The planner is not run again:
what is replayed is the grasp that was executed. A `file` planner's trial keeps the "file grasp j" its stored
detail begins with (`stored_source`), so the replayed detail reads as the run's.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Iterable
from dataclasses import dataclass, replace
from difflib import get_close_matches
from pathlib import Path

import numpy as np

from manigrasp.bench.store import ResultsStore, joints_from_text
from manigrasp.errors import ManigraspError
from manigrasp.protocol.result import PLANNER_FAILURES, PoseRecord, TrialResult
from manigrasp.runfiles import META_NAME, RECORDINGS_DIR, STORE_NAME

POSE_FIELDS = ("x_m", "y_m", "z_m", "qw", "qx", "qy", "qz")
OBJECT_POSE_TOLERANCE = 1e-6  # [m] / quaternion units: a re-settled object farther than this from the stored pose
# means the scene is not the run's (different manigrasp, mujoco or object build)


class ReplayError(ManigraspError):
    """A trial that cannot be replayed: unknown id, no stored grasp, not a run directory."""


@dataclass(frozen=True)
class Replay:
    """One re-simulated trial.

    Attributes:
        trial_id: the trial's id.
        stored: the result stored by the run.
        replayed: the result of the re-simulation.
        recording: the .rrd written, or None.
        object_pose_error: largest difference between the re-settled and the stored object pose
            (position [m] and quaternion components); above `OBJECT_POSE_TOLERANCE` the scene differs from the run's.
    """

    trial_id: str
    stored: TrialResult
    replayed: TrialResult
    recording: Path | None
    object_pose_error: float

    @property
    def same_status(self) -> bool:
        """Whether the replay ended with the stored status."""
        return self.stored.status is self.replayed.status


@dataclass(frozen=True)
class StoredTrial:
    """A trial located in its run: its group, index in the group and stored result."""

    group: object  # manigrasp.bench.trials.Group
    index: int
    result: TrialResult


def stored_trials(run_dir: Path, base: Path | None = None) -> dict[str, StoredTrial]:
    """Every stored trial of `run_dir` whose group the run's config still enumerates, by trial id.

    `base`: the directory relative mesh paths of the config were given against (default: the config's folder
    stored in run.json, else the working directory).
    """
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.rundir import config_dir, load_meta
    from manigrasp.bench.trials import groups

    run_dir = Path(run_dir)
    base = base or config_dir(run_dir)
    config = parse_config(load_meta(run_dir)["config"], where=f"{run_dir}/{META_NAME}")
    store_path = run_dir / STORE_NAME
    if not store_path.is_file():
        raise ReplayError(f"{run_dir} has no {STORE_NAME}: nothing to replay")
    with ResultsStore(store_path) as store:
        results = {key.trial_id: result for key, result in store.results()}
    out = {}
    for group in groups(config, base):
        for index in range(group.n_grasps):
            trial_id = group.key(index).trial_id
            if trial_id in results:
                out[trial_id] = StoredTrial(group, index, results[trial_id])
    return out


def find_trial(run_dir: Path, trial_id: str, base: Path | None = None) -> StoredTrial:
    """The stored trial `trial_id` of `run_dir` (`ReplayError` naming the closest ids if there is none)."""
    trials = stored_trials(run_dir, base)
    if trial_id not in trials:
        close = get_close_matches(trial_id, list(trials), n=3, cutoff=0.5)
        hint = f"; closest: {', '.join(close)}" if close else f"; the run holds {len(trials)} trials"
        raise ReplayError(f"no trial {trial_id!r} in {run_dir}{hint}")
    return trials[trial_id]


def stored_source(planner: str, result: TrialResult) -> str:
    """The `source` of a stored trial's candidate, which its detail begins with (`manigrasp.bench.worker.with_source`):
    the `file` planner's "file grasp j"; "" for a trial of another planner (none sets one)."""
    from manigrasp.planners.file import SOURCE

    if planner != "file":
        return ""
    match = re.match(rf"{re.escape(SOURCE)} \d+(?=: |$)", result.detail)
    return match.group(0) if match else ""


def stored_grasp(result: TrialResult, source: str = ""):
    """The executed grasp of a stored trial as a `GraspCandidate` in the world (a NaN pose if it was not a
    rigid transform: replaying it gives `invalid_grasp` again), with the `source` its trial's detail names
    (`stored_source`)."""
    from manigrasp.planners.base import GraspCandidate

    try:
        pose = result.grasp.matrix()
    except ValueError:
        pose = np.full((4, 4), np.nan)
    width = result.grasp_width_m
    preshape = result.grasp_preshape
    return GraspCandidate(pose=pose, score=result.score if math.isfinite(result.score) else 0.0,
                          width=width if math.isfinite(width) else None,
                          preshape=preshape if math.isfinite(preshape) else 0.0,
                          joints=joints_from_text(result.grasp_joints), source=source)


def replay_trial(run_dir: Path, trial_id: str, record: Path | None = None, base: Path | None = None) -> Replay:
    """Re-simulate trial `trial_id` of `run_dir` from its stored grasp and seed; optionally record it to `record`
    (a .rrd file).

    Raises:
        ReplayError: unknown trial, or a trial that executed no grasp (a planner error).
    """
    trial = find_trial(run_dir, trial_id, base)
    return _replay(trial_id, trial, record)


@dataclass(frozen=True)
class Recorded:
    """What `record_trials` did.

    Attributes:
        replays: the trials re-simulated and recorded (each `Replay.recording` is its file).
        skipped: (trial id, why) of the chosen trials not recorded: no grasp was executed (a planner
            error), or a recording of it already exists.
    """

    replays: tuple[Replay, ...]
    skipped: tuple[tuple[str, str], ...]


def record_trials(run_dir: Path, which: str | Iterable[str] = "failures", base: Path | None = None,
                  directory: Path | None = None, overwrite: bool = False) -> Recorded:
    """Record trials of a finished run after the fact, re-simulating each one from its stored grasp and seed
    (issue 14: ``bench --record`` on a finished run records nothing, since no trial runs again).

    Args:
        run_dir: the run directory.
        which: a recording policy (as ``--record``: "failures", "successes", "all" or a count N, the first
            N trials of each group), or an iterable of trial ids.
        base: the directory the run's config gave relative mesh paths against (default: the config file's folder
            stored in run.json, else the working directory).
        directory: where the files go (default ``run_dir/recordings``), named as the run names them
            (`manigrasp.record.policy.trial_file_name`), so `manigrasp view RUN_DIR` finds them.
        overwrite: re-record trials whose file already exists (default: skip them).

    Trials are taken in trial-id order.
    """
    from manigrasp.record.policy import RecordPolicy, trial_file_name

    trials = stored_trials(run_dir, base)
    if isinstance(which, str):
        policy = RecordPolicy.parse(which)
        chosen = [t for t, s in trials.items() if policy.may_record(s.index) and policy.keeps(s.result.status)]
    else:
        chosen = list(which)
        missing = [t for t in chosen if t not in trials]
        if missing:
            raise ReplayError(f"no trial {missing[0]!r} in {run_dir}")
    folder = Path(directory) if directory is not None else Path(run_dir) / RECORDINGS_DIR
    replays, skipped = [], []
    for trial_id in sorted(chosen):
        target = folder / trial_file_name(trial_id)
        result = trials[trial_id].result
        if _executed_nothing(result):
            skipped.append((trial_id, f"no grasp was executed ({result.status.value})"))
        elif target.exists() and not overwrite:
            skipped.append((trial_id, f"already recorded in {target}"))
        else:
            replays.append(_replay(trial_id, trials[trial_id], target))
    return Recorded(tuple(replays), tuple(skipped))


def _executed_nothing(result: TrialResult) -> bool:
    """A trial that failed in the planner (`planner_error`, `no_grasp`) and stored no grasp."""
    return result.status in PLANNER_FAILURES and not math.isfinite(result.grasp.x_m)


def _replay(trial_id: str, trial: StoredTrial, record: Path | None) -> Replay:
    from manigrasp.bench.worker import scene_for, with_source
    from manigrasp.protocol import PROTOCOLS, settle_object

    stored, group = trial.result, trial.group
    if _executed_nothing(stored):
        raise ReplayError(f"trial {trial_id} executed no grasp ({stored.status.value}: {stored.detail[:200]}); "
                          "there is nothing to re-simulate")
    scene = scene_for(group)
    object_pose = settle_object(scene)
    error = _pose_error(object_pose, stored.object_pose)
    candidate = stored_grasp(stored, stored_source(group.planner.name, stored))
    protocol = PROTOCOLS.load(group.protocol.name, **dict(group.protocol.params))
    seed = group.trial_seed(trial.index)
    with _recording(record, trial_id, trial.index, candidate) as recording:
        replayed = protocol.run(scene, candidate, np.random.default_rng(seed),
                                deadline=time.monotonic() + group.timeout_s, object_pose=object_pose,
                                observer=recording.observer if recording is not None else None, seed=seed)
    replayed = replace(replayed, detail=with_source(candidate.source, replayed.detail))  # as the run's worker does
    path = recording.path if recording is not None else None
    if path is not None and record is not None and path != Path(record):
        path = path.replace(record)
    return Replay(trial_id, stored, replayed, path, error)


def _recording(record: Path | None, trial_id: str, index: int, candidate):
    """The run's recording machinery (`record.policy.trial_recording`) writing every replayed trial."""
    from contextlib import nullcontext

    from manigrasp.record.policy import RecordPolicy, RecordSettings, trial_recording

    if record is None:
        return nullcontext(None)
    record = Path(record)
    settings = RecordSettings(record.parent, RecordPolicy("all"))
    return trial_recording(settings, trial_id, index, candidate)


def _pose_error(pose: np.ndarray, stored: PoseRecord) -> float:
    now = PoseRecord.of(pose)
    a = np.array([getattr(now, f) for f in POSE_FIELDS])
    b = np.array([getattr(stored, f) for f in POSE_FIELDS])
    return float(np.max(np.abs(a - b))) if np.all(np.isfinite(b)) else math.nan
