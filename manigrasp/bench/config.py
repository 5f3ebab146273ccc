"""Benchmark configuration: which objects, hands, planners, protocol and how many grasps.

A config is a YAML file (see configs/) validated into a frozen `BenchConfig`.
Unknown keys are errors naming the nearest valid key; ``key=value``
overrides (dotted for nested keys) are applied before validation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from manigrasp.config import apply_overrides, from_mapping
from manigrasp.errors import ConfigError
from manigrasp.objects import catalog
from manigrasp.sim.config import SceneConfig

OBSERVATIONS = ("ground_truth", "estimated_pose", "point_cloud")


@dataclass(frozen=True)
class ObjectEntry:
    """One object of a config: a shipped `name`, or a `mesh` file, or a `ycb` folder.

    Attributes:
        name: shipped object name ("025_mug" or "mug"), or the name given to a mesh.
        mesh: path of a mesh file (OBJ, STL, PLY, GLB/GLTF), relative to the config file.
        ycb: one object folder of a real YCB download.
        scale: factor applied to a mesh's vertices (0.001 for millimetres).
        mass: mass [kg] (default: the shipped figure, else from density).
        density: [kg/m^3] when no mass is known.
    """

    name: str | None = None
    mesh: str | None = None
    ycb: str | None = None
    scale: float = 1.0
    mass: float | None = None
    density: float = 500.0

    def source(self, base: Path | None = None) -> catalog.ObjectSource:
        """The `ObjectSource` this entry names (paths resolved against `base`)."""
        given = [k for k in ("mesh", "ycb") if getattr(self, k)]
        if len(given) > 1:
            raise ConfigError(f"object entry {self}: give one of 'mesh' or 'ycb', not both")
        base = base or Path.cwd()
        if self.mesh:
            path = (base / self.mesh).resolve()
            return catalog.ObjectSource(name=self.name or path.stem, mesh=str(path), scale=self.scale,
                                        mass=self.mass, density=self.density)
        if self.ycb:
            return catalog.from_ycb_folder((base / self.ycb).resolve(), mass=self.mass)
        if not self.name:
            raise ConfigError("object entry needs 'name', 'mesh' or 'ycb'")
        source = catalog.shipped(self.name)
        return source if self.mass is None else catalog.ObjectSource(source.name, recipe=source.recipe,
                                                                     mass=self.mass)


@dataclass(frozen=True)
class NamedEntry:
    """A registry name (or ``module:attribute``) with keyword parameters."""

    name: str
    params: Mapping[str, Any] = field(default_factory=dict)

    @property
    def label(self) -> str:
        """Name used in result tables."""
        return self.name


@dataclass(frozen=True)
class BenchConfig:
    """A whole benchmark run.

    Attributes:
        name: label of the run.
        seed: root seed; every trial's seed derives from it and the trial's identity.
        objects: objects to grasp.
        hands: hand names (registry names or ``module:attribute``).
        planners: planners with their parameters.
        grasps_per_object: candidates planned (and trials run) per object x hand x planner.
        protocol: the trial protocol ("standard", "six_direction", "shake", "lift") and its parameters.
        observation: what planners see, one or several of "ground_truth", "estimated_pose" and
            "point_cloud" (several: every group runs under each, and the report puts them side by side).
        scene: physics and scene parameters.
        trial_timeout_s: wall-clock budget of one trial [s]; beyond it the trial is a `timeout`.
    """

    name: str = "bench"
    seed: int = 0
    objects: tuple[ObjectEntry, ...] = ()
    hands: tuple[str, ...] = ("parallel_jaw",)
    planners: tuple[NamedEntry, ...] = (NamedEntry("antipodal"),)
    grasps_per_object: int = 20
    protocol: NamedEntry = field(default_factory=lambda: NamedEntry("standard"))
    observation: tuple[str, ...] = ("ground_truth",)
    scene: SceneConfig = field(default_factory=SceneConfig)
    trial_timeout_s: float = 120.0

    def __post_init__(self) -> None:
        if not self.objects:
            raise ConfigError("config lists no objects")
        if not self.hands or not self.planners:
            raise ConfigError("config needs at least one hand and one planner")
        if self.grasps_per_object < 1:
            raise ConfigError(f"grasps_per_object must be >= 1, got {self.grasps_per_object}")
        for kind in self.observation:
            if kind not in OBSERVATIONS:
                raise ConfigError(f"unknown observation {kind!r}; available: {', '.join(OBSERVATIONS)}")
        if not self.observation or len(set(self.observation)) != len(self.observation):
            raise ConfigError(f"observation must list distinct kinds, got {list(self.observation)}")
        if not self.trial_timeout_s > 0:
            raise ConfigError("trial_timeout_s must be > 0")


def _normalise(data: dict[str, Any]) -> dict[str, Any]:
    """Accept the short forms: an object or planner given as a bare name string."""
    data = dict(data)
    if "objects" in data:
        data["objects"] = [{"name": o} if isinstance(o, str) else o for o in _as_list(data["objects"], "objects")]
    if "planners" in data:
        data["planners"] = [{"name": p} if isinstance(p, str) else p for p in _as_list(data["planners"], "planners")]
    if isinstance(data.get("protocol"), str):
        data["protocol"] = {"name": data["protocol"]}
    for key in ("hands", "observation"):
        if isinstance(data.get(key), str):
            data[key] = [data[key]]
    return data


def _as_list(value: Any, key: str) -> list:
    if not isinstance(value, list):
        raise ConfigError(f"'{key}' must be a list")
    return value


def parse_config(data: Mapping[str, Any], overrides: Sequence[str] = (), where: str = "config") -> BenchConfig:
    """Validate a config mapping (after applying `overrides`)."""
    if not isinstance(data, Mapping):
        raise ConfigError(f"{where}: expected a mapping at the top level")
    data = apply_overrides(dict(data), overrides)
    data = _normalise(data)
    config = from_mapping(BenchConfig, data, where)
    objects = tuple(o if isinstance(o, ObjectEntry) else from_mapping(ObjectEntry, o, f"{where}.objects")
                    for o in config.objects)
    planners = tuple(p if isinstance(p, NamedEntry) else from_mapping(NamedEntry, p, f"{where}.planners")
                     for p in config.planners)
    protocol = config.protocol if isinstance(config.protocol, NamedEntry) else from_mapping(
        NamedEntry, config.protocol, f"{where}.protocol")
    from dataclasses import replace

    return replace(config, objects=objects, planners=planners, protocol=protocol)


def load_config(path: str | Path, overrides: Sequence[str] = ()) -> BenchConfig:
    """Read and validate a YAML config file."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise ConfigError(f"cannot read config {path}: {exc.strerror}") from exc
    except yaml.YAMLError as exc:
        raise ConfigError(f"config {path} is not valid YAML: {exc}") from exc
    return parse_config(data or {}, overrides, where=path.name)
