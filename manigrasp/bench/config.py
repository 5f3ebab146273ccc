"""Benchmark configuration: which objects, hands, planners, protocol(s) and how many grasps.

A config is a YAML file (see configs/) validated into a frozen `BenchConfig`.
Unknown keys are errors naming the nearest valid key; every value is checked
for its type and range (`manigrasp.config.from_mapping`, then each class's
`__post_init__`); a duplicate object, hand, planner or camera setup entry is
refused; a list field takes a single value as a one-element list (and ``camera:``
a single mapping as one setup). One protocol is ``protocol:``; several, run side by
side, are ``protocols:`` (a list of names or {name, params}); giving both is an
error, but an override of one replaces the other (``protocols=[standard,lift]`` on a
config with ``protocol:``, ``protocol=lift`` on one with ``protocols:``). An object entry may leave out
hands that cannot hold it, each with the reason (``exclude: {allegro_right: "reason"}``, `ObjectEntry.exclude`);
every key must be a hand of the config, and an override ``hands=[...]`` drops the exclusions of the hands it
leaves out. ``key=value`` overrides (dotted for nested keys) are applied before validation. Every error is one
`ConfigError` line, raised before anything is written.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import yaml

from manigrasp.config import OMIT_DEFAULT, apply_overrides, from_mapping, to_mapping
from manigrasp.errors import ConfigError, ManigraspError
from manigrasp.objects import catalog
from manigrasp.objects.pipeline import DEFAULT_DENSITY
from manigrasp.perception.setup import CameraSetup
from manigrasp.registry import nearest
from manigrasp.sim.config import SceneConfig

OBSERVATIONS = ("ground_truth", "estimated_pose", "point_cloud")


@dataclass(frozen=True)
class ObjectEntry:
    """One object of a config: a shipped `name`, or a `mesh` file, or a `ycb` folder.

    Attributes:
        name: shipped object name ("025_mug" or "mug"), or the name given to a mesh or a YCB folder (default: the
            mesh's file stem, the folder's name + "_ycb").
        mesh: path of a mesh file (OBJ, STL, PLY, OFF, GLB/GLTF), relative to the config file.
        ycb: one object folder of a real YCB download.
        scale: factor applied to a mesh's vertices (0.001 for millimetres).
        mass: mass [kg] (default: the shipped figure, else from density).
        density: [kg/m^3] when no mass is known.
        exclude: hands of the config that do not run this object, each with the reason it is left out
            (``{allegro_right: "1.9 kg: more than its 9 N squeeze holds"}``); None: every hand runs it.
            `manigrasp.bench.trials.groups` makes no group of a left-out pair, `manigrasp.bench.trials.left_out`
            lists them for the report, and `manigrasp.bench.compare` refuses to compare two runs that leave
            out different pairs of a hand and object they share. Left out of run.json when None, so a config
            without exclusions keeps its run identity (an empty mapping is None).
    """

    name: str | None = None
    mesh: str | None = None
    ycb: str | None = None
    scale: float = 1.0
    mass: float | None = None
    density: float = DEFAULT_DENSITY
    exclude: Mapping[str, str] | None = field(default=None, metadata={OMIT_DEFAULT: True})

    def __post_init__(self) -> None:
        for key in ("scale", "density", "mass"):
            value = getattr(self, key)
            if value is not None and not value > 0:
                raise ConfigError(f"object {self.label}: {key} must be > 0, got {value}")
        for key, least, unit, what in (("mass", MIN_MASS, "kg", "1 mg"), ("density", MIN_DENSITY, "kg/m^3", "air's")):
            value = getattr(self, key)
            if value is not None and value < least:
                raise ConfigError(f"object {self.label}: {key} {value:g} {unit} is below {least:g} {unit} ({what}): "
                                  "the simulator cannot integrate so light a body (every trial would fail to set up)")
        unused = [k for k, default in (("scale", 1.0), ("density", DEFAULT_DENSITY)) if getattr(self, k) != default]
        if unused and not self.mesh:
            kind = "a YCB folder" if self.ycb else "a shipped object"
            raise ConfigError(f"object {self.label}: {' and '.join(unused)} apply to a mesh entry only (`mesh:`); "
                              f"{kind} has its real size and mass (give `mass` to change its mass)")
        if self.exclude is not None:
            for hand, reason in self.exclude.items():
                if not isinstance(reason, str) or not reason.strip():
                    raise ConfigError(f"object {self.label}: exclude.{hand}: give the reason the hand is left out "
                                      f"(a non-empty string), got {reason!r}")
            object.__setattr__(self, "exclude", dict(self.exclude) or None)

    @property
    def label(self) -> str:
        """How error messages name the entry: its name, mesh or ycb folder."""
        return self.name or self.mesh or self.ycb or ""

    def trial_name(self, base: Path | None = None) -> str:
        """The object's name in trial ids and reports: its source's name (a shipped alias "mug" is "025_mug", a
        mesh given no name its file's stem), or its `label` when the source cannot be resolved here (a YCB
        folder or a shipped name of another machine or version); `base` resolves relative paths."""
        try:
            return self.source(base).name
        except (ManigraspError, OSError):
            return self.label

    @classmethod
    def recorded(cls, data: Mapping[str, Any]) -> ObjectEntry:
        """An object entry as a run.json records it, read even where it no longer validates (written by other
        code): the entry itself if it does, else one with only its `name`, `mesh` and `ycb` that are strings."""
        try:
            return from_mapping(cls, data, "run.json object")
        except (ConfigError, TypeError):
            return cls(**{k: data[k] for k in ("name", "mesh", "ycb") if isinstance(data.get(k), str)})

    def excluded(self, hand: str) -> str | None:
        """The reason `hand` is left out of this object, or None if it runs it."""
        return (self.exclude or {}).get(hand)

    def source(self, base: Path | None = None) -> catalog.ObjectSource:
        """The `ObjectSource` this entry names (paths resolved against `base`)."""
        given = [k for k in ("mesh", "ycb") if getattr(self, k)]
        if len(given) > 1:
            raise ConfigError(f"object entry {self}: give one of 'mesh' or 'ycb', not both")
        base = base or Path.cwd()
        if self.mesh:
            path = (base / self.mesh).resolve()
            name = self.name if self.name is not None else catalog.default_mesh_name(path)
            return catalog.ObjectSource(name=name, mesh=str(path), scale=self.scale,
                                        mass=self.mass, density=self.density)
        if self.ycb:
            return catalog.from_ycb_folder((base / self.ycb).resolve(), mass=self.mass, name=self.name)
        if not self.name:
            raise ConfigError("object entry needs 'name', 'mesh' or 'ycb'")
        source = catalog.shipped(self.name)
        return source if self.mass is None else catalog.ObjectSource(source.name, recipe=source.recipe,
                                                                     mass=self.mass)


@dataclass(frozen=True)
class NamedEntry:
    """A registry name (or ``module:attribute``) with keyword parameters.

    A ``module:attribute`` name imports that module and calls that attribute: a config that
    names one runs code (treat it like a script).
    """

    name: str
    params: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.name.strip():
            raise ConfigError("a planner/protocol name must not be empty")

    @property
    def label(self) -> str:
        """Name used in result tables: the registry name, or the attribute of ``module:attribute``.

        Two entries with the same label in one config are told apart by `labels`.
        """
        return self.name.rpartition(":")[2] if ":" in self.name else self.name

    def identity(self) -> str:
        """The entry's name and parameters as canonical JSON (equal entries give equal strings)."""
        return json.dumps({"name": self.name, "params": dict(self.params)}, sort_keys=True, default=str)


def labels(entries: Sequence[NamedEntry], kind: str = "planner") -> tuple[str, ...]:
    """Distinct readable labels of `entries`: each `NamedEntry.label`, and where two share one, a suffix
    with the parameters that set them apart (``side[lift=0.04]``; a short hash if that is not enough).

    Raises:
        ConfigError: two entries are identical (same name and parameters).
    """
    seen: dict[str, int] = {}
    for i, entry in enumerate(entries):
        if entry.identity() in seen:
            raise ConfigError(f"{kind} {entry.name!r} with params {dict(entry.params)} is listed twice "
                              f"(entries {seen[entry.identity()] + 1} and {i + 1})")
        seen[entry.identity()] = i
    out = [e.label for e in entries]
    for base in {b for b in out if out.count(b) > 1}:
        same = [i for i, b in enumerate(out) if b == base]
        keys = sorted({k for i in same for k in entries[i].params})
        differing = [k for k in keys if len({_param_text(entries[i].params, k) for i in same}) > 1]
        names_differ = len({entries[i].name for i in same}) > 1
        for i in same:
            parts = [f"{k}={_param_text(entries[i].params, k)}" for k in differing if k in entries[i].params]
            if names_differ:
                parts.insert(0, entries[i].name.rpartition(":")[0] or entries[i].name)
            out[i] = f"{base}[{','.join(parts)}]" if parts else base
    if len(set(out)) < len(out):  # the readable suffixes did not tell them apart
        out = [f"{lab}#{hashlib.sha256(e.identity().encode()).hexdigest()[:6]}" if out.count(lab) > 1 else lab
               for lab, e in zip(out, entries, strict=True)]
    return tuple(out)


def _refuse_same_effective(entries: Sequence[NamedEntry], kind: str) -> None:
    """Refuse two built-in entries that run the same (every parameter at its effective value equal: one writes
    out a default the other leaves out): the same trials would run twice under two labels and be pooled twice."""
    seen: dict[str, int] = {}
    for i, entry in enumerate(entries):
        effective = effective_entry({"name": entry.name, "params": dict(entry.params)}, kind)
        if effective is None:
            continue
        text = json.dumps(effective, sort_keys=True, default=str)
        if text in seen:
            raise ConfigError(f"{kind}s {seen[text] + 1} and {i + 1} ({entry.name!r}) run the same: their parameters "
                              f"differ only by values written out at their defaults ({dict(entry.params)} against "
                              f"{dict(entries[seen[text]].params)})")
        seen[text] = i


def _param_text(params: Mapping[str, Any], key: str) -> str:
    if key not in params:
        return "default"
    value = params[key]
    text = value if isinstance(value, str) else json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)
    readable = len(text) <= 24 and re.fullmatch(r"[\w.+\-=,:\[\]{}]*", text)  # trial ids are paths: no / or spaces
    return text if readable else hashlib.sha256(text.encode()).hexdigest()[:6]


# Lightest object mass [kg] and density [kg/m^3] a config may give: below them MuJoCo's inertia falls under its
# numerical floor and the scene does not compile (an audit's 1e-12 kg made every trial a harness fault).
MIN_MASS = 1e-6
MIN_DENSITY = 1.0

MAX_GRASPS_PER_OBJECT = 10_000
"""Upper bound of `grasps_per_object` (each is one planned candidate and one simulated trial)."""

MAX_SEED = 2**63 - 1


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
        protocol: the trial protocol ("standard", "six_direction", "shake", "lift") and its parameters
            (default "standard"); None when `protocols` lists several.
        protocols: several protocols run side by side (``protocols: [standard, six_direction]``): every group
            runs under each, with the same planning and trial seeds (a paired comparison: the same
            grasps unless the planner adapts its plan to the protocol, see `manigrasp.bench.trials`),
            labelled by `protocol_labels` in trial ids and the report. Not given together with `protocol`;
            a one-element list is that one protocol (the same config and run identity). Left out of
            run.json when empty, so a one-protocol run's identity is unchanged.
        observation: what planners see, one or several of "ground_truth", "estimated_pose" and
            "point_cloud" (several: every group runs under each, and the report puts them side by side).
        scene: physics and scene parameters.
        camera: the cameras of the perception observations (`manigrasp.perception.setup.CameraSetup`: views,
            azimuths, elevation, distance, noise), or a list of setups: then every group of a perception
            observation runs under each setup, its observation labelled by the setup (`camera_labels`,
            ``point_cloud@2views``), side by side in the report. A one-element list is that one setup.
        trial_timeout_s: wall-clock budget of one trial [s]; beyond it the trial is a `timeout`.
    """

    name: str = "bench"
    seed: int = 0
    objects: tuple[ObjectEntry, ...] = ()
    hands: tuple[str, ...] = ("parallel_jaw",)
    planners: tuple[NamedEntry, ...] = (NamedEntry("antipodal"),)
    grasps_per_object: int = 20
    protocol: NamedEntry | None = None
    observation: tuple[str, ...] = ("ground_truth",)
    scene: SceneConfig = field(default_factory=SceneConfig)
    camera: CameraSetup | tuple[CameraSetup, ...] = field(default_factory=CameraSetup)
    trial_timeout_s: float = 120.0
    protocols: tuple[NamedEntry, ...] = field(default=(), metadata={OMIT_DEFAULT: True})

    def __post_init__(self) -> None:
        self._resolve_protocols()
        if not self.objects:
            raise ConfigError("config lists no objects")
        if not self.hands or not self.planners:
            raise ConfigError("config needs at least one hand and one planner")
        if not 1 <= self.grasps_per_object <= MAX_GRASPS_PER_OBJECT:
            raise ConfigError(f"grasps_per_object must be in 1..{MAX_GRASPS_PER_OBJECT}, got {self.grasps_per_object}")
        if not 0 <= self.seed <= MAX_SEED:
            raise ConfigError(f"seed must be an integer in 0..2**63-1, got {self.seed}")
        for kind in self.observation:
            if kind not in OBSERVATIONS:
                raise ConfigError(f"unknown observation {kind!r}; available: {', '.join(OBSERVATIONS)}")
        if not self.observation or len(set(self.observation)) != len(self.observation):
            raise ConfigError(f"observation must list distinct kinds, got {list(self.observation)}")
        if not self.trial_timeout_s > 0:
            raise ConfigError("trial_timeout_s must be > 0")
        _refuse_duplicates("hand", self.hands)
        _refuse_duplicates("object", self.objects)
        self._check_exclusions()
        labels(self.planners)  # refuses identical planner entries
        _refuse_same_effective(self.planners, "planner")
        if isinstance(self.camera, tuple):
            if not self.camera:
                raise ConfigError("camera must be a setup or a non-empty list of setups")
            if len(self.camera) == 1:  # one setup, however written: the same config and run identity
                object.__setattr__(self, "camera", self.camera[0])
        camera_labels(self.camera_setups)  # refuses identical setups

    def _check_exclusions(self) -> None:
        """Every `ObjectEntry.exclude` key is a hand of the config, and some hand runs some object."""
        for entry in self.objects:
            for hand in entry.exclude or {}:
                if hand not in self.hands:
                    hint = nearest(hand, list(self.hands))
                    raise ConfigError(f"object {entry.label}: exclude.{hand}: {hand!r} is not a hand of this config"
                                      f"{f' (did you mean {hint!r}?)' if hint else ''}; its hands: "
                                      f"{', '.join(self.hands)}")
        if all(entry.excluded(hand) for entry in self.objects for hand in self.hands):
            raise ConfigError("every object excludes every hand of the config: nothing would run")

    def _resolve_protocols(self) -> None:
        """`protocol` or `protocols`, not both; one protocol however written is `protocol` (default standard)."""
        if self.protocols and self.protocol is not None:
            raise ConfigError("give either 'protocol' (one protocol) or 'protocols' (a list run side by side), "
                              "not both")
        if len(self.protocols) == 1:
            object.__setattr__(self, "protocol", self.protocols[0])
            object.__setattr__(self, "protocols", ())
        elif self.protocol is None and not self.protocols:
            object.__setattr__(self, "protocol", NamedEntry("standard"))
        labels(self.protocol_entries, "protocol")  # refuses identical protocol entries
        _refuse_same_effective(self.protocol_entries, "protocol")

    @property
    def protocol_entries(self) -> tuple[NamedEntry, ...]:
        """The protocols every group runs under: `protocol`, or the several of `protocols`."""
        return self.protocols if self.protocols else (self.protocol,)  # type: ignore[return-value]

    @property
    def protocol_labels(self) -> tuple[str, ...]:
        """The protocols' labels in trial ids and tables, aligned with `protocol_entries`: the protocol's name
        for a config with one (trial ids as before), else `labels` of the entries (``standard``,
        ``six_direction``; ``standard[grip_force=10.0]`` where two share a name)."""
        if not self.protocols:
            return (self.protocol.name,)  # type: ignore[union-attr]
        return labels(self.protocols, "protocol")

    @property
    def planner_labels(self) -> tuple[str, ...]:
        """The planners' labels in result tables (see `labels`), aligned with `planners`."""
        return labels(self.planners)

    @property
    def camera_setups(self) -> tuple[CameraSetup, ...]:
        """The camera setups, one or several."""
        return self.camera if isinstance(self.camera, tuple) else (self.camera,)

    @property
    def camera_labels(self) -> tuple[str, ...]:
        """The setups' suffixes of a perception observation's label, aligned with `camera_setups`: ``""``
        for a single setup (trial ids as before), else ``@<views>view(s)`` (see `camera_labels`)."""
        return camera_labels(self.camera_setups)


def camera_labels(setups: Sequence[CameraSetup]) -> tuple[str, ...]:
    """Distinct readable suffixes of several camera setups: ``""`` for one setup; else ``@1view``,
    ``@2views``..., and where setups share a view count, the fields that set them apart
    (``@2views[elevation_deg=60.0]``; a short hash if that is not enough).

    Raises:
        ConfigError: two setups are identical.
    """
    if len(setups) <= 1:
        return ("",) * len(setups)
    fields = [to_mapping(s) for s in setups]
    for i, f in enumerate(fields):
        if f in fields[:i]:
            raise ConfigError(f"camera setup {fields.index(f) + 1} and {i + 1} are identical; list each setup once")
    out = [f"@{s.views}view{'s' * (s.views != 1)}" for s in setups]
    for base in {b for b in out if out.count(b) > 1}:
        same = [i for i, b in enumerate(out) if b == base]
        differing = [k for k in fields[same[0]] if len({_param_text(fields[i], k) for i in same}) > 1]
        for i in same:
            out[i] = f"{base}[{','.join(f'{k}={_param_text(fields[i], k)}' for k in differing)}]"
    if len(set(out)) < len(out):  # the readable suffixes did not tell them apart
        out = [f"{lab}#{hashlib.sha256(json.dumps(f, sort_keys=True, default=str).encode()).hexdigest()[:6]}"
               if out.count(lab) > 1 else lab for lab, f in zip(out, fields, strict=True)]
    return tuple(out)


def _refuse_duplicates(kind: str, items: Sequence[Any]) -> None:
    for i, item in enumerate(items):
        if item in items[:i]:
            shown = item if isinstance(item, str) else {k: v for k, v in vars(item).items() if v is not None}
            raise ConfigError(f"{kind} {shown} is listed twice; each {kind} may appear once")


LIST_FIELDS = ("objects", "hands", "planners", "observation")
"""Fields that hold a list; a single value (``objects=mug``, ``hands=panda``) is a one-element list."""


def _normalise(data: dict[str, Any], where: str = "config") -> dict[str, Any]:
    """Accept the short forms: a single value for a list field, an object or planner as a bare name; the
    camera setup (a mapping) or setups (a list) are validated here, so an error names the list entry."""
    data = dict(data)
    camera = data.get("camera")
    if isinstance(camera, list):
        data["camera"] = tuple(_camera_setup(c, f"{where}.camera[{i}]") for i, c in enumerate(camera))
    elif isinstance(camera, Mapping):
        data["camera"] = _camera_setup(camera, f"{where}.camera")
    elif camera is not None and not isinstance(camera, CameraSetup | tuple):
        raise ConfigError(f"{where}.camera: expected a camera setup (a mapping) or a list of them, "
                          f"got {type(camera).__name__}")
    for key in LIST_FIELDS:
        if key in data and not isinstance(data[key], list):
            data[key] = [data[key]]
    if "objects" in data:
        data["objects"] = [{"name": o} if isinstance(o, str) else o for o in data["objects"]]
        for i, entry in enumerate(data["objects"]):
            exclude = entry.get("exclude") if isinstance(entry, Mapping) else None
            if exclude is not None and not isinstance(exclude, Mapping):
                raise ConfigError(f"{where}.objects[{i}].exclude: map each hand left out to the reason "
                                  f"({{allegro_right: \"too heavy for its grip\"}}), got {type(exclude).__name__}")
    if "planners" in data:
        data["planners"] = [{"name": p} if isinstance(p, str) else p for p in data["planners"]]
    if data.get("protocol") is not None and "protocols" in data:  # run.json of several holds protocol: null
        raise ConfigError(f"{where}: give either 'protocol' (one protocol) or 'protocols' (a list run side by "
                          "side), not both (on the command line, protocol=NAME or protocols=[...] replaces the "
                          "config's)")
    if isinstance(data.get("protocol"), str):
        data["protocol"] = {"name": data["protocol"]}
    if "protocols" in data:
        listed = data["protocols"] if isinstance(data["protocols"], list) else [data["protocols"]]
        if not listed:
            raise ConfigError(f"{where}.protocols: list at least one protocol")
        data["protocols"] = [{"name": p} if isinstance(p, str) else p for p in listed]
    return data


def _camera_setup(data: Any, where: str) -> CameraSetup:
    """One entry of a list of camera setups; its errors name the entry."""
    try:
        return from_mapping(CameraSetup, data, where)
    except ConfigError as exc:
        if str(exc).startswith(where):
            raise
        raise ConfigError(f"{where}: {exc}") from None


def parse_config(data: Mapping[str, Any], overrides: Sequence[str] = (), where: str = "config") -> BenchConfig:
    """Validate a config mapping (after applying `overrides`): keys, types, ranges and duplicates.

    Raises:
        ConfigError: the first problem, in one line naming the key.
    """
    if not isinstance(data, Mapping):
        raise ConfigError(f"{where}: expected a mapping at the top level, got {type(data).__name__}")
    try:
        data = apply_overrides(_protocol_replaced(dict(data), overrides), overrides)
        data = _normalise(data, where)
        if any(item.partition("=")[0].strip() == "hands" for item in overrides if "=" in item):
            data = _exclusions_of(data)
        return from_mapping(BenchConfig, data, where)
    except RecursionError:
        raise ConfigError(f"{where}: nested too deeply") from None


PROTOCOL_KEYS = ("protocol", "protocols")
"""The two ways of naming the protocol(s): an override of one (``protocols=[standard,lift]``) replaces the other."""


def _protocol_replaced(data: dict[str, Any], overrides: Sequence[str]) -> dict[str, Any]:
    """`data` without its ``protocol:`` when an override sets ``protocols=`` (and without its ``protocols:`` when
    one sets ``protocol=``): the command line names the protocol(s) of the run. A dotted override
    (``protocol.params.grip_force=10``) edits the section it names and replaces nothing.

    Raises:
        ConfigError: the overrides set both ``protocol=`` and ``protocols=``.
    """
    given = {item.partition("=")[0].strip() for item in overrides if "=" in item} & set(PROTOCOL_KEYS)
    if len(given) > 1:
        raise ConfigError("overrides give both protocol= and protocols=; give one (protocols=[standard,lift] "
                          "runs several side by side)")
    for key in given:
        data.pop(PROTOCOL_KEYS[1 - PROTOCOL_KEYS.index(key)], None)
    return data


def _exclusions_of(data: dict[str, Any]) -> dict[str, Any]:
    """`data` (normalised) with each object's ``exclude`` keeping only the hands it lists: an override
    ``hands=[...]`` names the hands of the run, and leaves out the exclusions of the others with them."""
    hands = data.get("hands")
    if not isinstance(hands, list) or not isinstance(data.get("objects"), list):
        return data
    objects = []
    for entry in data["objects"]:
        if isinstance(entry, Mapping) and isinstance(entry.get("exclude"), Mapping):
            kept = {h: r for h, r in entry["exclude"].items() if h in hands}
            entry = {k: v for k, v in entry.items() if k != "exclude"} | ({"exclude": kept} if kept else {})
        objects.append(entry)
    return {**data, "objects": objects}


class _UniqueKeyLoader(yaml.SafeLoader):
    """YAML's safe loader refusing a mapping that gives one key twice (the last one silently won: `seed: 0` then
    `seed: 7` ran seed 7)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: set = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":  # `<<: *anchor`: merged by the base loader
                continue
            key = self.construct_object(key_node, deep=deep)
            if isinstance(key, str | int | float | bool) and key in seen:
                raise yaml.constructor.ConstructorError(None, None, f"key {key!r} is given twice",
                                                        key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep)


def scene_overrides(scene: Mapping[str, Any]) -> dict[str, Any]:
    """The parameters of a recorded scene (`SceneConfig` as run.json holds it: plain JSON values) that differ
    from this version's defaults (a parameter the defaults do not record compares with the default's value)."""
    plain = SceneConfig()
    defaults = json.loads(json.dumps(to_mapping(plain), default=str))
    return {k: v for k, v in scene.items()
            if v != defaults.get(k, json.loads(json.dumps(getattr(plain, k, None), default=str)))}


def load_config(path: str | Path, overrides: Sequence[str] = ()) -> BenchConfig:
    """Read and validate a YAML config file (a key given twice in one mapping is an error)."""
    path = Path(path)
    try:
        data = yaml.load(path.read_text(encoding="utf-8"), Loader=_UniqueKeyLoader)  # noqa: S506 (a safe loader)
    except OSError as exc:
        raise ConfigError(f"cannot read config {path}: {exc.strerror}") from exc
    except UnicodeDecodeError:
        raise ConfigError(f"config {path} is not a text (UTF-8) file") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"config {path} is not valid YAML: {' '.join(str(exc).split())}") from exc
    except RecursionError:
        raise ConfigError(f"config {path} is nested too deeply") from None
    overrides = [_cwd_paths(item) for item in overrides]
    return resolve_paths(parse_config({} if data is None else data, overrides, where=path.name), path.parent)


def _cwd_paths(item: str) -> str:
    """An ``objects=[...]`` override with each relative ``mesh`` or ``ycb`` path made absolute against the current
    folder, where the person typing it is (a config file's own paths are relative to its folder, and a shipped
    config's folder is inside the package). Anything else, or a value that does not parse, is returned as given."""
    key, sep, raw = item.partition("=")
    if not sep or key.strip() != "objects":
        return item
    try:
        value = yaml.safe_load(raw)
    except yaml.YAMLError:
        return item  # (apply_overrides says what is wrong with it)
    if not isinstance(value, list):
        return item
    changed = False
    for entry in value:
        for kind in ("mesh", "ycb"):
            path = entry.get(kind) if isinstance(entry, dict) else None
            if isinstance(path, str) and path and not Path(path).is_absolute():
                entry[kind] = str(Path.cwd() / path)
                changed = True
    return f"{key}={yaml.safe_dump(value, default_flow_style=True, width=1 << 20).strip()}" if changed else item


def resolve_paths(config: BenchConfig, folder: Path) -> BenchConfig:
    """`config` with a relative `path` of a `file` planner made absolute against `folder` (the config file's
    folder, as relative mesh paths are), so the run does not depend on the working directory."""
    planners = []
    for entry in config.planners:
        path = dict(entry.params).get("path")
        if entry.name == "file" and isinstance(path, str) and path and not Path(path).expanduser().is_absolute():
            entry = replace(entry, params={**dict(entry.params), "path": str(Path(folder).resolve() / path)})
        planners.append(entry)
    return replace(config, planners=tuple(planners))


def effective_entry(entry: object, kind: str, ran_with: dict | None = None) -> dict | None:
    """A recorded protocol or planner entry ({name, params} or a name) as {name, params} with every parameter it
    leaves out at its default, so that a config writing out a default value compares equal to one that leaves it
    out. The defaults are those the run recorded it ran with (`ran_with`: run.json's ``effective``, for the
    parameters this code knows), else this code's: a baseline recorded without them is read as if it had run
    this code's, as when neither side writes the parameter out; a parameter this code added since is at its
    default on both sides. None for an entry this code cannot build (a parameter it no longer knows, say) and
    for a ``module:attribute`` entry (not imported to be compared)."""
    name = entry.get("name") if isinstance(entry, dict) else entry
    params = entry.get("params") if isinstance(entry, dict) else {}
    if not isinstance(name, str) or ":" in name or not isinstance(params, dict):
        return None
    params = _built_params(name, params, kind)
    if params is None:
        return None
    for key, value in (ran_with or {}).items():
        if key in params:
            params[key] = value
    return {"name": name, "params": params}


def _built_params(name: str, params: dict, kind: str) -> dict | None:
    """Every parameter of the protocol or planner `name` built here with `params`, as run.json writes a dataclass
    (nested ones, dexopt's `weights`, by their fields) and JSON reads it; None if it cannot be built here."""
    from manigrasp.planners import PLANNERS
    from manigrasp.protocol import PROTOCOLS

    try:
        built = (PROTOCOLS.load(name, **params).params if kind == "protocol" else PLANNERS.load(name, **params))
        return json.loads(json.dumps(to_mapping(built), default=str))
    except (ManigraspError, TypeError, ValueError, OSError):  # unknown or invalid here: compared as recorded
        return None


def effective_entries(config: BenchConfig) -> dict:
    """What a run records in run.json as ``effective``: each built-in protocol and planner of `config` (a
    `BenchConfig`) by label with every parameter at the value this code runs it with (`_built_params`), so a
    later comparison reads the defaults the run had, not those of the code that compares. A ``module:attribute``
    entry, or one that does not build, is left out."""
    out: dict[str, dict] = {}
    for kind, entries, names in (("protocol", config.protocol_entries, config.protocol_labels),
                                 ("planner", config.planners, config.planner_labels)):
        built = {label: effective_entry({"name": e.name, "params": dict(e.params)}, kind)
                 for label, e in zip(names, entries, strict=True)}
        out[f"{kind}s"] = {label: entry for label, entry in built.items() if entry is not None}
    return out
