"""Optional extras a run needs, checked before any trial, with the install command that works from a clone.

    perception  open3d (observation estimated_pose or point_cloud; `manigrasp perceive`); on Linux its
                wheel also needs the system library libusb-1.0 (apt-get install libusb-1.0-0)
    ray         --executor ray
    allegro     example-robot-data (hands allegro_right, allegro_left)
    datasets    h5py (a `file` planner reading ACRONYM .h5/.hdf5 grasp files)
    parquet     pyarrow (--export parquet)

``python -m manigrasp.bench.extras EXTRA ...`` checks extras from the shell (`make setup` runs it): one
line per missing piece, exit 1.
"""

from __future__ import annotations

import ctypes
import importlib.metadata
import importlib.util
import sys
from pathlib import Path

from manigrasp.errors import ConfigError

MODULES = {"perception": "open3d", "ray": "ray", "datasets": "h5py", "parquet": "pyarrow"}
DISTRIBUTIONS = {"allegro": "example-robot-data"}
EXTRAS = (*MODULES, *DISTRIBUTIONS)
ALLEGRO_HANDS = ("allegro_right", "allegro_left")
LIBUSB = "libusb-1.0.so.0"
LIBUSB_HINT = "install libusb-1.0-0: apt-get install libusb-1.0-0"


def install_hint(extra: str) -> str:
    """The command that installs `extra` into a clone's virtual environment."""
    return (f"in the manigrasp clone run `make setup EXTRAS=dev,{extra}` "
            f"(or `.venv/bin/pip install -c constraints.txt -e '.[{extra}]'`)")


def _installed(extra: str) -> bool:
    if extra in DISTRIBUTIONS:
        try:
            importlib.metadata.distribution(DISTRIBUTIONS[extra])
        except importlib.metadata.PackageNotFoundError:
            return False
        return True
    return importlib.util.find_spec(MODULES[extra]) is not None


def _libusb_loads() -> bool:
    """Whether the system library libusb-1.0 (which Open3D's Linux wheel links) can be loaded."""
    if not sys.platform.startswith("linux"):
        return True
    try:
        ctypes.CDLL(LIBUSB)
    except OSError:
        return False
    return True


def problem(extra: str, import_it: bool = False) -> str | None:
    """What is missing for `extra` (one line with the command that installs it), or None.

    `import_it` also imports the module (perception: open3d), so a broken install is named too.
    """
    module = MODULES.get(extra, DISTRIBUTIONS.get(extra, extra))
    if not _installed(extra):
        return f"needs the optional `{extra}` extra ({module}): {install_hint(extra)}"
    if extra == "perception" and not _libusb_loads():
        return f"open3d is installed but the system library libusb-1.0 ({LIBUSB}) is missing: {LIBUSB_HINT}"
    if import_it and extra in MODULES:
        try:
            importlib.import_module(MODULES[extra])
        except (ImportError, OSError) as exc:
            text = " ".join(str(exc).split())
            if "libusb" in text:
                return f"open3d is installed but the system library libusb-1.0 is missing ({text}): {LIBUSB_HINT}"
            return f"{module} is installed but cannot be imported ({type(exc).__name__}: {text[:200]}): " \
                   f"reinstall it: {install_hint(extra)}"
    return None


def required(config, executor: str = "local", export: str | None = None) -> dict[str, str]:  # noqa: ANN001
    """The extras a run of `config` (a `BenchConfig`) needs, each with the reason."""
    out: dict[str, str] = {}
    perceived = [kind for kind in config.observation if kind != "ground_truth"]
    if perceived:
        out["perception"] = f"observation {perceived[0]}"
    if executor == "ray":
        out["ray"] = "--executor ray"
    allegro = [hand for hand in config.hands if hand in ALLEGRO_HANDS]
    if allegro:
        out["allegro"] = f"hand {allegro[0]}"
    for planner in config.planners:
        path = dict(planner.params).get("path")
        if planner.name == "file" and isinstance(path, str) and Path(path).suffix.lower() in (".h5", ".hdf5"):
            out["datasets"] = f"planner file reading {Path(path).name}"
    if export == "parquet":
        out["parquet"] = "--export parquet"
    return out


def check(config, executor: str = "local", export: str | None = None) -> None:  # noqa: ANN001
    """Raise a one-line `ConfigError` naming the first extra the run needs and lacks, and how to install it."""
    for extra, why in required(config, executor, export).items():
        missing = problem(extra)
        if missing:
            raise ConfigError(f"{why}: {missing}")


def main(argv: list[str]) -> int:
    """Check the named extras (unknown names, such as `dev`, are ignored); exit 1 if any is not usable."""
    bad = [f"{extra}: {text}" for extra in argv if extra in EXTRAS and (text := problem(extra, import_it=True))]
    for line in bad:
        print(f"manigrasp: {line}", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main([part for arg in sys.argv[1:] for part in arg.split(",") if part]))
