"""A run directory: `run.json` (resolved config, versions, seed, host) beside `results.sqlite`.

Re-running into an existing directory resumes it, but only with the same
resolved config: a different one is refused, so one results file never mixes
two experiments.
"""

from __future__ import annotations

import json
import platform
import socket
import subprocess
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from manigrasp import __version__
from manigrasp.bench.config import BenchConfig
from manigrasp.config import to_mapping
from manigrasp.errors import ConfigError

KEY_PACKAGES = ("mujoco", "numpy", "scipy", "trimesh", "coacd", "manifold3d", "robosuite", "dm-control",
                "rerun-sdk", "pymeshfix", "embreex")


def versions() -> dict[str, str]:
    """Versions of manigrasp, Python and its key dependencies."""
    out = {"manigrasp": __version__, "python": platform.python_version()}
    for name in KEY_PACKAGES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
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


def prepare(run_dir: Path, config: BenchConfig) -> dict:
    """Create `run_dir` with run.json, or check that an existing one holds the same config."""
    run_dir.mkdir(parents=True, exist_ok=True)
    meta_path = run_dir / "run.json"
    resolved = to_mapping(config)
    if meta_path.exists():
        existing = json.loads(meta_path.read_text())
        if existing.get("config") != json.loads(json.dumps(resolved)):
            raise ConfigError(f"{run_dir} holds a run with a different config; use another --out to start a new run")
        existing.setdefault("resumed", []).append(datetime.now(UTC).isoformat())
        meta_path.write_text(json.dumps(existing, indent=2))
        return existing
    meta = {
        "config": resolved,
        "seed": config.seed,
        "versions": versions(),
        "git_commit": git_commit(),
        "host": socket.gethostname(),
        "platform": platform.platform(),
        "started": datetime.now(UTC).isoformat(),
    }
    meta_path.write_text(json.dumps(meta, indent=2))
    return meta


def load_meta(run_dir: Path) -> dict:
    """The run.json of `run_dir`."""
    path = Path(run_dir) / "run.json"
    if not path.is_file():
        raise ConfigError(f"{run_dir} is not a run directory (no run.json)")
    return json.loads(path.read_text())
