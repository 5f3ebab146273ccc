"""Where manigrasp finds its shipped assets and configs, and keeps its cache."""

from __future__ import annotations

import os
from pathlib import Path


def _shipped(folder: str) -> Path:
    """A shipped folder: ``manigrasp/_<folder>`` in a wheel, or ``<folder>/`` of the checkout."""
    here = Path(__file__).resolve().parent
    for candidate in (here / f"_{folder}", here.parent / folder):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"manigrasp {folder} not found next to {here}")


def assets_dir() -> Path:
    """The shipped `assets/` folder (hand models, object recipes)."""
    return _shipped("assets")


def configs_dir() -> Path:
    """The shipped benchmark configs (`configs/`)."""
    return _shipped("configs")


def cache_dir() -> Path:
    """The on-disk cache: ``$MANIGRASP_CACHE`` or ``~/.cache/manigrasp``."""
    env = os.environ.get("MANIGRASP_CACHE")
    root = Path(env).expanduser() if env else Path.home() / ".cache" / "manigrasp"
    if root.exists() and not root.is_dir():
        from manigrasp.errors import ConfigError

        raise ConfigError(f"the object cache {root} is a file, not a folder ({'MANIGRASP_CACHE' if env else 'default'}"
                          "); point MANIGRASP_CACHE at a folder")
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        from manigrasp.errors import ConfigError

        raise ConfigError(f"cannot create the object cache {root}: {exc.strerror}; point MANIGRASP_CACHE at a "
                          "writable folder") from None
    return root
