"""The real YCB scans shipped in assets/scans/ (attribution and licence: assets/scans/README.md).

Each scan is the object ``<stem>_scan`` (e.g. "003_cracker_box_scan"), a mesh
in metres in the scan's own frame (z up, resting on z = 0) with the YCB
table's mass. Its *recipe twin* is the shipped recipe named by the stem
("003_cracker_box"): the same physical object built from clean primitives.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from manigrasp.errors import UnknownNameError
from manigrasp.paths import assets_dir

SCAN_SUFFIX = "_scan"


@dataclass(frozen=True)
class Scan:
    """One shipped scan: manigrasp name, mesh file, mass [kg], recipe twin, watertight as shipped."""

    name: str
    path: Path
    mass_kg: float
    twin: str
    watertight: bool


# stem -> (mass [kg] from the YCB table, watertight as shipped)
_SCANS: dict[str, tuple[float, bool]] = {
    "002_master_chef_can": (0.414, True),
    "003_cracker_box": (0.411, True),
    "005_tomato_soup_can": (0.349, False),
    "009_gelatin_box": (0.097, False),
    "010_potted_meat_can": (0.370, True),
}


def scans_dir() -> Path:
    """Folder of the shipped scans."""
    return assets_dir() / "scans"


def names() -> tuple[str, ...]:
    """Names of the shipped scans, sorted ("002_master_chef_can_scan", ...)."""
    return tuple(sorted(stem + SCAN_SUFFIX for stem in _SCANS))


def is_scan(name: str) -> bool:
    """Whether `name` names a shipped scan."""
    return name.endswith(SCAN_SUFFIX) and name[: -len(SCAN_SUFFIX)] in _SCANS


def get(name: str) -> Scan:
    """The shipped scan `name`; an unknown name raises `UnknownNameError` listing the scans."""
    if not is_scan(name):
        raise UnknownNameError(f"unknown scan {name!r}; available: {', '.join(names())}")
    stem = name[: -len(SCAN_SUFFIX)]
    mass, watertight = _SCANS[stem]
    return Scan(name=name, path=scans_dir() / f"{stem}.obj", mass_kg=mass, twin=stem, watertight=watertight)


def twins() -> dict[str, str]:
    """Scan name -> recipe twin name, for every shipped scan."""
    return {name: get(name).twin for name in names()}
