"""A run directory: `run.json` (resolved config, versions, seed, host) beside `results.sqlite`.

Re-running into an existing directory resumes it, but only with the same
run identity (resolved config and the content of its mesh files): a different
one is refused with the keys that differ, so one results file never mixes two
experiments. A directory with results but no run.json is refused too, and
`locked` keeps a second process out of a directory that is in use. `check`
refuses without writing, so a run can validate its inputs (build its objects)
before `prepare` writes run.json: a run refused for a broken input leaves
nothing that blocks the corrected rerun. Trials stored by other code than
the run's start are recorded in run.json (`record_other_code`), and only then.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import platform
import socket
import subprocess
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from manigrasp import __version__
from manigrasp.bench.config import BenchConfig, effective_entries
from manigrasp.config import to_mapping
from manigrasp.errors import ConfigError, ManigraspError
from manigrasp.runfiles import META_NAME, RECORDINGS_DIR, STORE_NAME

KEY_PACKAGES = ("mujoco", "numpy", "scipy", "trimesh", "coacd", "manifold3d", "robosuite", "dm-env",
                "rerun-sdk", "pymeshfix", "embreex")
OPTIONAL_PACKAGES = ("open3d-cpu", "open3d", "h5py", "example-robot-data", "pyarrow", "ray")
"""Recorded only when installed (the optional extras)."""


def versions() -> dict[str, str]:
    """Versions of manigrasp, Python, its key dependencies and the optional extras that are installed."""
    out = {"manigrasp": __version__, "python": platform.python_version()}
    for name in KEY_PACKAGES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    for name in OPTIONAL_PACKAGES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            pass
    return out


def git_commit() -> str | None:
    """The commit of the manigrasp checkout, if it is one (with '+dirty' for local changes)."""
    root = Path(__file__).resolve().parents[2]
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                                timeout=5, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return commit + ("+dirty" if dirty else "")


def identity(config: BenchConfig, base: Path | None = None) -> dict:
    """The run's identity: a hash of the resolved config, the content hash of every mesh file it names and, where
    a `file` planner reads grasps, of its grasp file (or folder) by planner label (``grasp_file_sha256``, only then).

    Two runs with equal identities enumerate the same trials with the same inputs; a run directory
    accepts only its own identity.
    """
    resolved = recorded_config(config)
    text = json.dumps(resolved, sort_keys=True, separators=(",", ":"))
    meshes = {}
    for entry in config.objects:
        for kind in ("mesh", "ycb"):
            if getattr(entry, kind):
                path = ((base or Path.cwd()) / getattr(entry, kind)).resolve()
                meshes[entry.name or path.stem] = _content_hash(path)
    out = {"config_sha256": hashlib.sha256(text.encode()).hexdigest(), "mesh_sha256": meshes}
    grasps = {label: _content_hash(((base or Path.cwd()) / str(entry.params["path"])).resolve())
              for label, entry in zip(config.planner_labels, config.planners, strict=True)
              if entry.name == "file" and isinstance(entry.params.get("path"), str | Path)}
    if grasps:
        out["grasp_file_sha256"] = grasps
    return out


def recorded_config(config: BenchConfig) -> dict:
    """`config` as run.json records it: plain data, each shipped object by its object's name (`shipped_names`)."""
    return shipped_names(json.loads(json.dumps(to_mapping(config), default=str)))


def shipped_names(recorded: dict) -> dict:
    """A recorded config with each object entry that names a shipped object (no mesh or ycb) by that object's
    name, as the trial ids name it: "mug" is "025_mug", so the two spellings of one object are one run (and a
    run.json written before names were resolved still resumes). A name not shipped here stays as written."""
    from manigrasp.objects import catalog

    objects = recorded.get("objects")
    if not isinstance(objects, list):
        return recorded
    out = []
    for entry in objects:
        name = entry.get("name") if isinstance(entry, dict) else None
        if isinstance(name, str) and not entry.get("mesh") and not entry.get("ycb"):
            try:
                entry = {**entry, "name": catalog.full_name(name)}
            except (ManigraspError, OSError):
                pass
        out.append(entry)
    return {**recorded, "objects": out}


def _content_hash(path: Path) -> str:
    """sha256 of a file, or of every file under a folder (names and bytes); "" if unreadable."""
    digest = hashlib.sha256()
    try:
        files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
        for file in files:
            digest.update(str(file.relative_to(path) if path.is_dir() else file.name).encode())
            digest.update(file.read_bytes())
    except OSError:
        return ""
    return digest.hexdigest()


def differing_keys(old: object, new: object, prefix: str = "") -> list[str]:
    """Dotted keys whose values differ between two plain-data trees. Two lists of as many entries, of which some
    are mappings (objects, planners: ``objects[0].mass``), compare entry by entry; other lists as a whole (an
    object's mass was shown as ``objects: [{"name": "025_mug", "mesh": null, ... -> [{"name": ...``, cut before
    the value that differs)."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for key in sorted(set(old) | set(new), key=str):
            out += differing_keys(old.get(key), new.get(key), f"{prefix}{key}.")
        return out
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new) and old != new \
            and any(isinstance(v, dict) for v in old + new):
        base = prefix.rstrip(".")
        return [k for i, (a, b) in enumerate(zip(old, new, strict=True))
                for k in differing_keys(a, b, f"{base}[{i}].")]
    return [] if old == new else [prefix.rstrip(".") or "(whole config)"]


def _describe(keys: list[str], old: dict, new: dict) -> str:
    parts = []
    for key in keys[:6]:
        was, now = _get(old, key), _get(new, key)
        parts.append(f"{key}: {_short(was)} -> {_short(now)}")
    more = f" (and {len(keys) - 6} more)" if len(keys) > 6 else ""
    return "; ".join(parts) + more


def _get(tree: object, dotted: str) -> object:
    """The value at a key of `differing_keys` (``protocol.name``, ``objects[0].mass``), or None."""
    for part in dotted.split("."):
        name, _, index = part.partition("[")
        tree = tree.get(name) if isinstance(tree, dict) else None
        if index:
            position = int(index.rstrip("]"))
            tree = tree[position] if isinstance(tree, list) and position < len(tree) else None
    return tree


def _short(value: object) -> str:
    text = json.dumps(value, default=str)
    return text if len(text) <= 60 else text[:57] + "..."


def check(run_dir: Path, config: BenchConfig, base: Path | None = None) -> dict | None:
    """Refuse `run_dir` if it cannot take the run of `config`, writing nothing: its run.json if it holds this run,
    None if it holds no run yet.

    Raises:
        ConfigError: `run_dir` is a file; it holds a run of a different config (the message names the keys
            that differ) or of changed mesh files; or it holds results but no readable run.json.
    """
    if run_dir.exists() and not run_dir.is_dir():
        raise ConfigError(f"--out {run_dir} is a file, not a run directory")
    meta_path = run_dir / META_NAME
    if meta_path.exists() or meta_path.is_symlink():
        existing = read_meta(run_dir)
        old_config, resolved = shipped_names(existing["config"]), recorded_config(config)
        if old_config != resolved:
            keys = differing_keys(old_config, resolved)
            from manigrasp.sim.config import LEGACY_SCENE

            older = [k.removeprefix("scene.") for k in keys if k.removeprefix("scene.") in LEGACY_SCENE]
            hint = "".join(f"; a run recorded before scene.{k} was recorded ran at {LEGACY_SCENE[k]:g}: give "
                           f"scene.{k}={LEGACY_SCENE[k]:g} to resume it with that physics" for k in older)
            raise ConfigError(f"{run_dir} holds a run with a different config ({_describe(keys, old_config, resolved)}"
                              f"); use another --out to start a new run{hint}")
        old, ident = existing.get("identity", {}), identity(config, base)
        _refuse_changed_files(run_dir, old, ident, "mesh_sha256", "mesh file of {}", str, "")
        _refuse_changed_files(run_dir, old, ident, "grasp_file_sha256", "grasp file of planner {}", repr,
                              " (its stored trials ran the old grasps)")
        return existing
    stray = [p.name for p in (run_dir / STORE_NAME, run_dir / RECORDINGS_DIR) if p.exists()]
    if stray:
        raise ConfigError(f"{run_dir} holds {' and '.join(stray)} but no run.json, so the config that made them is "
                          "unknown; use another --out (or restore run.json)")
    return None


def _refuse_changed_files(run_dir: Path, old: dict, new: dict, key: str, what: str, name: Callable[[str], str],
                          stored: str) -> None:
    """Raise `ConfigError` if a file recorded under identity `key` (`_changed_files`) is gone (missing or unreadable:
    `_content_hash` gave "", which another --out does not mend: put it back) or changed (start a new run); `what`
    names the files ("mesh file of {}", filled with their `name`s), `stored` says what the stored trials ran."""
    changed = _changed_files(old, new, key)
    gone = [n for n in changed if not new[key][n]]
    listed = ", ".join(map(name, gone or changed))
    if gone:
        raise ConfigError(f"{run_dir}: the {what.format(listed)} is missing or unreadable (it was read when this run "
                          "started); put it back to resume the run")
    if changed:
        raise ConfigError(f"{run_dir}: the {what.format(listed)} changed since this run started{stored}; use another "
                          "--out to start a new run")


def _changed_files(old: dict, new: dict, key: str) -> list[str]:
    """The names under identity `key` (``mesh_sha256``, ``grasp_file_sha256``) whose content hash differs between
    a recorded identity `old` and `new` (a name recorded on one side only is not a change: older run.json files)."""
    recorded = old.get(key, {})
    return sorted(k for k, v in new.get(key, {}).items() if k in recorded and recorded[k] != v)


def prepare(run_dir: Path, config: BenchConfig, base: Path | None = None,
            grip_limits: dict[str, float] | None = None) -> dict:
    """Create `run_dir` with run.json, or check that an existing one holds the same run (`check`) and add the
    time of this resumption to its ``resumed``.

    `grip_limits` (each hand's `Hand.max_grip_force` [N], `runner.grip_limits`) is recorded in a new run.json as
    ``hand_grip_limits``, so that its report says which hands closed below an asked grip force with the forces
    of the hands that ran, not of the hand models installed when the report is made. A new run.json also records
    as ``effective`` every parameter its built-in protocols and planners run with (`config.effective_entries`),
    so that a comparison made by later code reads the defaults this code ran with. A resumed run keeps what it
    recorded (an older run.json without them stays without).

    Whether it is resumed by other code is not recorded here: `record_other_code` does that once trials are
    stored by it (re-running a finished run to export or record runs none, and mixes nothing).

    Raises:
        ConfigError: as `check`.
    """
    return start(run_dir, config, check(run_dir, config, base), base, grip_limits)


def start(run_dir: Path, config: BenchConfig, existing: dict | None, base: Path | None = None,
          grip_limits: dict[str, float] | None = None) -> dict:
    """`prepare` after its `check` (which gave `existing`), for a caller that checked the folder itself (under
    `locked`, so run.json cannot have changed since): a resumed run's mesh files are not hashed again."""
    meta_path = run_dir / META_NAME
    if existing is not None:
        if "identity" not in existing:  # (not setdefault: its argument would hash every mesh file again)
            existing["identity"] = identity(config, base)
        existing.setdefault("config_dir", str((base or Path.cwd()).resolve()))
        existing.setdefault("resumed", []).append(datetime.now(UTC).isoformat())
        _write_json(meta_path, existing)
        return existing
    run_dir.mkdir(parents=True, exist_ok=True)
    meta = {
        "config": recorded_config(config),
        "seed": config.seed,
        "identity": identity(config, base),
        "config_dir": str((base or Path.cwd()).resolve()),
        "versions": versions(),
        "git_commit": git_commit(),
        "host": socket.gethostname(),
        "platform": platform.platform(),
        "started": datetime.now(UTC).isoformat(),
    }
    if grip_limits is not None:
        meta["hand_grip_limits"] = {hand: float(force) for hand, force in grip_limits.items()}
    meta["effective"] = effective_entries(config)
    _write_json(meta_path, meta)
    return meta


def warn_other_code(run_dir: Path, changes: list[str]) -> None:
    """Warn that trials are about to run under other code (`code_changes`) than the run of `run_dir` started with."""
    warnings.warn(f"{run_dir} was started by other code ({'; '.join(changes)}): the trials run now may "
                  "differ from the stored ones if a default or the physics changed (recorded in run.json "
                  "under 'resumed_with_other_code'); use another --out for a run of one code version",
                  RuntimeWarning, stacklevel=3)


def record_other_code(run_dir: Path, at: str, changes: list[str], trials: int) -> None:
    """Record in run.json's ``resumed_with_other_code`` that the session resumed at `at` stored `trials` trials
    under other code (`changes`): one entry per session, its count updated in place (the report warns of each
    entry: the stored trials mix code versions). A run.json that cannot be written is a warning: the trials
    are stored all the same."""
    try:
        meta = read_meta(run_dir)
        entries = meta.setdefault("resumed_with_other_code", [])
        entry = next((e for e in entries if isinstance(e, dict) and e.get("at") == at), None)
        if entry is None:
            entries.append({"at": at, "changes": list(changes), "trials": trials})
        else:
            entry["trials"] = trials
        _write_json(run_dir / META_NAME, meta)
    except (OSError, ConfigError) as exc:
        warnings.warn(f"{run_dir}: could not record in run.json that {trials} trial(s) ran under other code: {exc}",
                      RuntimeWarning, stacklevel=2)


def code_changes(meta: dict) -> list[str]:
    """What differs between the code that started the run of `meta` and the code running now: the git
    commit and each recorded package version ("manigrasp 0.3.0 -> 0.4.0"); empty if nothing (or nothing
    was recorded)."""
    out = []
    old_commit, new_commit = meta.get("git_commit"), git_commit()
    if old_commit and new_commit and old_commit != new_commit:
        out.append(f"git commit {_short_commit(old_commit)} -> {_short_commit(new_commit)}")
    old_versions, new_versions = meta.get("versions") or {}, versions()
    for name, was in old_versions.items():
        now = new_versions.get(name, "not installed")
        if was != now:
            out.append(f"{name} {was} -> {now}")
    return out


def _short_commit(commit: str) -> str:
    return commit[:12] + ("+dirty" if commit.endswith("+dirty") else "")


def _write_json(path: Path, data: dict) -> None:
    """Write `data` as JSON atomically (a kill never leaves a half-written run.json)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2))
    os.replace(tmp, path)


def read_meta(run_dir: Path) -> dict:
    """The run.json of `run_dir` as a mapping; `ConfigError` if it is missing, unreadable or not a JSON object."""
    path = Path(run_dir) / META_NAME
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"{run_dir} is not a run directory (no run.json)") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ConfigError(f"{path} is not readable run metadata ({type(exc).__name__}); use another --out") from None
    if not isinstance(meta, dict) or not isinstance(meta.get("config"), dict):
        raise ConfigError(f"{path} is not run metadata (expected a JSON object with a 'config'); use another --out")
    from manigrasp.sim.config import with_legacy_scene

    return {**meta, "config": with_legacy_scene(meta["config"])}  # what an older run's scene ran at


@contextmanager
def locked(run_dir: Path) -> Iterator[None]:
    """Hold an exclusive lock on `run_dir` (its `.lock` file) for the block; released when the process ends.

    A block that raises in a folder this call created, before anything but the lock was written in it (a
    run refused for a broken input), removes the folder again: an error leaves nothing behind.

    Raises:
        ConfigError: another process holds it (the message says which: pid, host, since when).
    """
    if run_dir.exists() and not run_dir.is_dir():
        raise ConfigError(f"--out {run_dir} is a file, not a run directory")
    created = not run_dir.exists()
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot create run directory {run_dir}: {exc.strerror}") from None
    path = run_dir / ".lock"
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:  # a folder removed under us by another process's refused run
        raise ConfigError(f"cannot create {path}: {exc.strerror}; try again") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "another process"
            raise ConfigError(f"{run_dir} is in use by {holder}; wait for it to finish or use another --out") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()} since {datetime.now(UTC):%Y-%m-%d %H:%M:%S} UTC"
                  .encode(), 0)
        try:
            yield
        except BaseException:
            if created:
                _remove_if_only_lock(run_dir, path)
            raise
    finally:
        os.close(fd)


def _remove_if_only_lock(run_dir: Path, lock: Path) -> None:
    """Remove `run_dir` if it holds nothing but its `lock` (still held, so no other process is inside)."""
    try:
        if [p.name for p in run_dir.iterdir()] == [lock.name]:
            lock.unlink()
            run_dir.rmdir()
    except OSError:  # another process came in: the folder is theirs now
        pass


def config_dir(run_dir: Path) -> Path | None:
    """The folder the run's config file was in (run.json's ``config_dir``): what its relative mesh and grasp
    file paths are relative to; None for a run made before it was stored, or without a readable run.json."""
    try:
        folder = read_meta(run_dir).get("config_dir")
    except ConfigError:
        return None
    return Path(folder) if isinstance(folder, str) and folder else None


def load_meta(run_dir: Path) -> dict:
    """The run.json of `run_dir` (see `read_meta`)."""
    return read_meta(run_dir)
