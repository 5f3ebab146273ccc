"""Where manigrasp finds its shipped assets and keeps its cache."""

from __future__ import annotations

import os
from pathlib import Path


def assets_dir() -> Path:
    """The shipped `assets/` folder (repository checkout or installed wheel)."""
    here = Path(__file__).resolve().parent
    for candidate in (here / "_assets", here.parent / "assets"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"manigrasp assets not found next to {here}")


def configs_dir() -> Path:
    """The shipped benchmark configs (`configs/` of the checkout or the installed wheel)."""
    here = Path(__file__).resolve().parent
    for candidate in (here / "_configs", here.parent / "configs"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"manigrasp configs not found next to {here}")


def cache_dir() -> Path:
    """The on-disk cache: ``$MANIGRASP_CACHE`` or ``~/.cache/manigrasp``."""
    env = os.environ.get("MANIGRASP_CACHE")
    root = Path(env).expanduser() if env else Path.home() / ".cache" / "manigrasp"
    root.mkdir(parents=True, exist_ok=True)
    return root
