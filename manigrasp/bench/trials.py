"""Enumerating a run: groups (object [x resting pose] x hand x planner x observation [x protocol]) and their
trials, with seeds.

Seeds derive from the run's seed and the identity of the group or trial
(names, not positions), so adding an object to a config changes no other
trial's seed, and a resumed run re-creates exactly the same trials.

A config with several camera setups runs every perception observation under
each (`BenchConfig.camera_labels`: ``point_cloud@1view``, ``point_cloud@2views``);
ground truth, which has no camera, runs once. The seed of a group does not
depend on its setup, so the setups are a paired comparison: the first camera
sees the same noisy frame under each, and a second camera only adds to it.
``estimated_pose`` uses only the first camera, so setups that share their first
camera (and noise) add one ``estimated_pose`` group between them, labelled by the
one of them with the fewest views (``@1view`` when a one-view setup is listed,
wherever in the list): the others would repeat its trials exactly. Its trials store
``camera_views`` 1, the cameras its estimate used, whichever setup labels it.

A config with several protocols (``protocols: [standard, six_direction]``) runs
every group under each, labelled by the protocol in trial ids (a config with one
protocol keeps the ids it always had). The seed of a group does not depend on its
protocol either: the planner sees the same observation with the same generator, and
trial i gets the same seed, under every protocol. A planner that does not adapt its
plan to the protocol (`manigrasp.planners.context.PlanContext`: the protocol's grip
force and loads) so returns the same grasps, and the protocols are compared on the
very same grasps; one that adapts it is compared on the same draw, each grasp made
for its protocol. Pairing is the better comparison: it separates the protocol's
effect from the luck of the draw far better than independent samples would (the
report's paired outcomes and McNemar test, `manigrasp.bench.markdown.paired_rows`).

``rest: stable_k`` (`SceneConfig.rest_k`) runs each object in each of its `rest_k`
most probable stable poses (`manigrasp.sim.scene.object_stable_poses`; an object
with fewer runs as many as it has): one group per pose, its object labelled
``<name>@rest<i>`` (i = 0 the most probable) and its scene's `rest_index` set to i.
Counting an object's poses builds it (from the cache when built). Each resting
pose is its own experiment (the object lies differently), so its seed derives
from that label.

An object entry's ``exclude`` (`manigrasp.bench.config.ObjectEntry.exclude`) leaves
out the hands it names: `groups` makes no group of such an object x hand (in any
resting pose, planner, observation or protocol), and `left_out` lists the pairs with
their reasons for the report. Seeds derive from names, so leaving a pair out changes
no other group's seed or trial ids.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from manigrasp.bench.config import BenchConfig, NamedEntry
from manigrasp.bench.store import TrialKey
from manigrasp.errors import ConfigError
from manigrasp.objects.catalog import ObjectSource
from manigrasp.perception.setup import CameraSetup
from manigrasp.sim.config import SceneConfig


def stable_seed(root: int, *names: object) -> int:
    """A 63-bit seed from `root` and identifying names (stable across runs and machines)."""
    digest = hashlib.sha256(repr((root, *names)).encode()).digest()
    return int.from_bytes(digest[:8], "little") >> 1


@dataclass(frozen=True)
class Group:
    """All trials of one object x hand x planner: one planning call, `n_grasps` trials.

    Attributes:
        object_source: how to build the object.
        hand: hand name.
        planner: planner name and parameters.
        protocol: protocol name and parameters.
        observation: what the planner sees.
        scene: physics parameters.
        n_grasps: candidates requested from the planner = trials of the group.
        seed: the planning seed of the group.
        timeout_s: wall-clock budget per trial [s].
        label: the planner's label in trial ids and tables (`manigrasp.bench.config.labels`: distinct for
            every planner entry of a config, so two parameter sets of one planner never share a trial id).
        camera: the cameras of a perception observation (None: the default `CameraSetup`).
        camera_label: the setup's suffix of the observation's label in trial ids and tables ("" for a
            config with one setup, else ``@2views``...: `manigrasp.bench.config.camera_labels`).
        protocol_label: the protocol's label in trial ids and tables (`BenchConfig.protocol_labels`;
            "": the protocol's name).
        object_label: the object's label in trial ids and tables ("": its name; ``<name>@rest<i>``
            for resting pose i under ``rest: stable_k``).
        object_key: the hull key (``ObjectAsset.metadata["hull_key"]``: a hash of the repaired mesh, its
            decomposition parameters and CoACD's version) of the object as the run's main process built it before
            any trial ("": not checked). A worker builds its own copy from the mesh file; one whose build differs
            (the file edited during the run) refuses it, so that no trial of the run is of another object.
    """

    object_source: ObjectSource
    hand: str
    planner: NamedEntry
    protocol: NamedEntry
    observation: str
    scene: SceneConfig
    n_grasps: int
    seed: int
    timeout_s: float
    label: str = ""
    camera: CameraSetup | None = None
    camera_label: str = ""
    protocol_label: str = ""
    object_label: str = ""
    object_key: str = ""

    @property
    def observation_label(self) -> str:
        """The observation's label in trial ids and tables: its kind, with the camera setup's suffix."""
        return self.observation + self.camera_label

    @property
    def planner_label(self) -> str:
        """The planner's label (its `NamedEntry.label` when none was set)."""
        return self.label or self.planner.label

    def key(self, index: int) -> TrialKey:
        """The key of trial `index` of this group."""
        return TrialKey(self.object_label or self.object_source.name, self.hand, self.planner_label,
                        self.observation_label, self.protocol_label or self.protocol.name, index)

    def trial_seed(self, index: int) -> int:
        """Seed of trial `index` (independent of the planning seed)."""
        return stable_seed(self.seed, "trial", index)

    def rng(self) -> np.random.Generator:
        """The planner's random generator for this group."""
        return np.random.default_rng(self.seed)


def groups(config: BenchConfig, base: Path | None = None) -> list[Group]:
    """Every group of `config`, in config order (objects, resting poses, then hands, planners, observations,
    camera setups, protocols), but none of an object x hand that the object's entry excludes (`left_out`).

    Object sources are resolved here, so an unknown object or a missing mesh
    file is an error before any trial runs.
    """
    sources = [entry.source(base) for entry in config.objects]
    names = [s.name for s in sources]
    for i, name in enumerate(names):
        if name in names[:i]:
            raise ConfigError(f"two objects of the config are both named {name!r} (entries {names.index(name) + 1} "
                              f"and {i + 1}); give each a distinct 'name'")
    labels = config.planner_labels
    setups = observation_setups(config)
    protocols = list(zip(config.protocol_entries, config.protocol_labels, strict=True))
    several = len(protocols) > 1
    out = []
    for entry, source in zip(config.objects, sources, strict=True):
        hands = [hand for hand in config.hands if entry.excluded(hand) is None]
        for scene, object_label in rest_scenes(config.scene, source) if hands else ():
            name = object_label or source.name
            for hand in hands:
                for planner, label in zip(config.planners, labels, strict=True):
                    for observation in config.observation:
                        seed = stable_seed(config.seed, name, hand, label, observation)
                        out += [Group(source, hand, planner, protocol, observation, scene, config.grasps_per_object,
                                      seed, config.trial_timeout_s, label, camera, suffix,
                                      protocol_label if several else "", object_label)
                                for camera, suffix in setups[observation] for protocol, protocol_label in protocols]
    return out


@dataclass(frozen=True)
class LeftOut:
    """An object x hand of a config that runs no trial, and why (`manigrasp.bench.config.ObjectEntry.exclude`).

    Attributes:
        object: the object's name (as in trial ids, before any ``@rest<i>``).
        hand: the hand's name.
        reason: the config's reason.
    """

    object: str
    hand: str
    reason: str


def left_out(config: BenchConfig, base: Path | None = None) -> list[LeftOut]:
    """The object x hand pairs of `config` that `groups` leaves out, in config order, with their reasons.

    An object whose source cannot be resolved here (a mesh or YCB folder read on another machine) is named
    by its entry (`ObjectEntry.label`), so a report can always say what was left out.
    """
    from manigrasp.errors import ManigraspError

    out = []
    for entry in config.objects:
        pairs = [(hand, entry.excluded(hand)) for hand in config.hands if entry.excluded(hand) is not None]
        if not pairs:
            continue
        try:
            name = entry.source(base).name
        except (ManigraspError, OSError):
            name = entry.label
        out += [LeftOut(name, hand, str(reason)) for hand, reason in pairs]
    return out


def rest_scenes(scene: SceneConfig, source: ObjectSource) -> list[tuple[SceneConfig, str]]:
    """The (scene, object label) pairs `source` runs under: `scene` itself with no label, or under
    ``rest: stable_k`` one per stable pose of the object, up to `rest_k` (module docstring).

    Raises:
        ConfigError: the object cannot be built, or has no stable pose (no 3-D collision geometry).
    """
    if scene.rest != "stable_k":
        return [(scene, "")]
    count = min(scene.rest_k or 1, rest_pose_count(source))
    if count == 0:
        raise ConfigError(f"object {source.name}: no stable resting pose (its collision geometry has no 3-D hull)")
    return [(replace(scene, rest_index=i), f"{source.name}{REST_LABEL}{i}") for i in range(count)]


REST_LABEL = "@rest"
"""Between an object's name and its resting pose's rank in the object label of ``rest: stable_k`` groups."""


def rest_pose_count(source: ObjectSource) -> int:
    """How many stable resting poses the object of `source` has (built, or read from the cache)."""
    from manigrasp.errors import ManigraspError
    from manigrasp.objects import catalog
    from manigrasp.sim.scene import object_stable_poses

    try:
        outcome = catalog.build(source)
    except ManigraspError as exc:
        raise ConfigError(f"object {source.name}: {exc}") from exc
    return len(object_stable_poses(outcome.asset))


def observation_setups(config: BenchConfig) -> dict[str, list[tuple[CameraSetup | None, str]]]:
    """Per observation kind, the (camera setup, label suffix) pairs it runs under (module docstring)."""
    pairs = list(zip(config.camera_setups, config.camera_labels, strict=True))
    by_first: dict[tuple, tuple[CameraSetup, str]] = {}  # first camera and noise -> the setup with the fewest views
    for setup, suffix in pairs:
        first = (setup.view(0), setup.noise)
        if first not in by_first or setup.views < by_first[first][0].views:
            by_first[first] = (setup, suffix)
    return {"ground_truth": [(pairs[0][0], "")], "estimated_pose": list(by_first.values()), "point_cloud": pairs}
