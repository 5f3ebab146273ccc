"""Which trials of a benchmark run are recorded, and where their files go.

    --record none | failures | successes | all | N      (N: the first N trials of each group)

`all` and `N` are decided before a trial; `failures` and `successes` only
after it, so such a trial is recorded to a temporary file that is kept or
deleted once its status is known:

    >>> settings = RecordSettings(run_dir / "recordings", RecordPolicy.parse("failures"))
    >>> with trial_recording(settings, key.trial_id, index, candidate) as rec:
    ...     result = protocol.run(scene, candidate, rng, deadline, object_pose=rest, observer=rec.observer)
    >>> rec.path                  # the kept .rrd, or None
"""

from __future__ import annotations

import hashlib
import os
import re
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from manigrasp.errors import ConfigError
from manigrasp.protocol.observer import NullObserver, TrialObserver
from manigrasp.protocol.result import Status, TrialResult
from manigrasp.record.recorder import RecordOptions, TrialRecorder
from manigrasp.runfiles import RECORDINGS_DIR

POLICIES = ("none", "failures", "successes", "all")
SUFFIX = ".rrd"
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]")


class RecordingWarning(UserWarning):
    """A recording failed or was dropped; the trial's result is unaffected."""


@dataclass(frozen=True)
class RecordPolicy:
    """Which trials to record.

    Attributes:
        kind: "none", "failures", "successes", "all", or "first" (the first `first_n` of each group).
        first_n: with kind "first", how many trials of each group.
    """

    kind: str = "none"
    first_n: int = 0

    def __post_init__(self) -> None:
        if self.kind not in (*POLICIES, "first"):
            raise ConfigError(f"unknown record policy {self.kind!r}; available: {', '.join(POLICIES)} or a count N")
        if self.kind == "first" and self.first_n < 0:
            raise ConfigError(f"record count must be >= 0, got {self.first_n}")

    @classmethod
    def parse(cls, text: str | int) -> RecordPolicy:
        """From the CLI's value: none, failures, successes, all, or a count N (`ConfigError` otherwise)."""
        value = str(text).strip().lower()
        if value.isdigit():
            return cls("first", int(value))
        if value not in POLICIES:
            raise ConfigError(f"--record must be one of {', '.join(POLICIES)} or a count N, got {text!r}")
        return cls(value)

    def may_record(self, index: int) -> bool:
        """Before the trial: whether trial `index` of its group could be kept at all."""
        if self.kind == "none":
            return False
        return index < self.first_n if self.kind == "first" else True

    def keeps(self, status: Status) -> bool:
        """After the trial: whether a recording that ended with `status` is kept."""
        if self.kind == "failures":
            return status is not Status.SUCCESS
        if self.kind == "successes":
            return status is Status.SUCCESS
        return self.kind in ("all", "first")


def should_record(policy: RecordPolicy | str, index: int, result: TrialResult | None = None) -> bool:
    """Whether trial `index` of its group is recorded under `policy`; without `result` the decision
    before the trial (True means: record, and ask again with the result)."""
    policy = policy if isinstance(policy, RecordPolicy) else RecordPolicy.parse(policy)
    if not policy.may_record(index):
        return False
    return True if result is None else policy.keeps(result.status)


def safe_name(text: str) -> str:
    """`text` with every character unsafe in a file name (not a letter, digit, '.', '_' or '-') as '_'."""
    return _UNSAFE.sub("_", text)


def trial_file_name(trial_id: str) -> str:
    """A safe file name for `trial_id`: '/' becomes '__', other unsafe characters '_' (`safe_name`; plus a
    short hash of the id when any were replaced, so distinct ids never share a file)."""
    joined = trial_id.replace("/", "__")
    safe = safe_name(joined)
    if safe != joined or not safe:
        safe += "-" + hashlib.sha1(trial_id.encode()).hexdigest()[:8]
    return safe + SUFFIX


@dataclass(frozen=True)
class RecordSettings:
    """Recording settings of a run (picklable: passed to worker processes).

    Attributes:
        directory: where recordings go (RUN_DIR/recordings).
        policy: which trials.
        options: what a recording holds.
    """

    directory: Path
    policy: RecordPolicy = field(default_factory=RecordPolicy)
    options: RecordOptions = field(default_factory=RecordOptions)

    @classmethod
    def for_run(cls, run_dir: str | Path, policy: str | RecordPolicy) -> RecordSettings | None:
        """Settings writing to RUN_DIR/recordings, or None when the policy records nothing."""
        policy = policy if isinstance(policy, RecordPolicy) else RecordPolicy.parse(policy)
        if policy.kind == "none" or (policy.kind == "first" and policy.first_n == 0):
            return None
        return cls(Path(run_dir) / RECORDINGS_DIR, policy)


class TrialRecording:
    """One trial's recording under a policy: `observer` to pass to the protocol, `path` once done."""

    def __init__(self, settings: RecordSettings | None, trial_id: str, index: int, candidate: Any = None) -> None:
        self.settings, self.trial_id = settings, trial_id
        self.path: Path | None = None
        self.error: Exception | None = None
        self._result: TrialResult | None = None
        self.recorder: TrialRecorder | None = None
        if settings is not None and settings.policy.may_record(index):
            self.final = settings.directory / trial_file_name(trial_id)
            self.partial = self.final.with_name(self.final.name + ".partial")
            try:  # a folder that cannot be made (a file named `recordings`, read-only) drops the recording only
                settings.directory.mkdir(parents=True, exist_ok=True)
                self.recorder = TrialRecorder(self.partial, recording_id=trial_id, candidate=candidate,
                                              options=settings.options)
            except Exception as exc:  # noqa: BLE001 - recording never changes a trial's result
                self.error = exc
                warnings.warn(f"recording of trial {trial_id} failed and was dropped: {_reason(exc)}",
                              RecordingWarning, stacklevel=3)

    @property
    def observer(self) -> TrialObserver:
        """The observer for the protocol (a `NullObserver` when this trial is not recorded)."""
        return self.recorder if self.recorder is not None else NullObserver()

    def finish(self, result: TrialResult) -> None:
        """The trial's final result, if it differs from what the protocol reported (optional)."""
        self._result = result

    def close(self, exc: BaseException | None = None) -> Path | None:
        """Close the file, then keep it (returns its path) or delete it, by the policy and the final status."""
        if self.recorder is None:
            return None
        recorder, settings = self.recorder, self.settings
        result = self._result or recorder.result
        if result is None and exc is not None:
            result = TrialResult(Status.UNSTABLE, detail=f"{type(exc).__name__}: {exc}"[:500])
        recorder.close(result)
        self.error = recorder.error
        keep = self.error is None and result is not None and settings.policy.keeps(result.status)
        try:  # a file-system error here must not turn into the trial's error
            if keep and self.partial.exists():
                self.partial.replace(self.final)
                self.path = self.final
            else:
                self.partial.unlink(missing_ok=True)
        except OSError as exc:
            self.error, self.path = self.error or exc, None
        if self.error is not None:
            warnings.warn(f"recording of trial {self.trial_id} failed and was dropped: {_reason(self.error)}",
                          RecordingWarning, stacklevel=2)
        return self.path


def _reason(exc: BaseException) -> str:
    if isinstance(exc, FileExistsError) and exc.filename:
        return f"{exc.filename} is a file, not a folder"
    if isinstance(exc, OSError) and exc.strerror:
        where = f": {exc.filename}" if exc.filename else ""
        return f"{exc.strerror}{where}"
    return f"{type(exc).__name__}: {exc}"


def recording_problem(settings: RecordSettings | None) -> str | None:
    """Why nothing can be recorded into `settings.directory` (it is a file, or cannot be created), or None.

    The run checks this once before its trials, to say so in one line; the trials run and are stored regardless.
    """
    if settings is None:
        return None
    try:
        settings.directory.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return f"nothing can be recorded: {_reason(exc)}"
    if not os.access(settings.directory, os.W_OK | os.X_OK):
        return f"nothing can be recorded: {settings.directory} is not writable"
    return None


@contextmanager
def trial_recording(settings: RecordSettings | None, trial_id: str, index: int,
                    candidate: Any = None) -> Iterator[TrialRecording]:
    """Record trial `index` (`trial_id`) of a group under `settings` (None: no recording).

    On exit the file is closed, then kept as ``<directory>/<trial_file_name(trial_id)>`` or deleted;
    an exception from the body is not suppressed (the trial then counts as `unstable` for the policy).
    """
    recording = TrialRecording(settings, trial_id, index, candidate)
    try:
        yield recording
    except BaseException as exc:
        recording.close(exc)
        raise
    recording.close()
