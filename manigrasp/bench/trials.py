"""Enumerating a run: groups (object x hand x planner x observation) and their trials, with seeds.

Seeds derive from the run's seed and the identity of the group or trial
(names, not positions), so adding an object to a config changes no other
trial's seed, and a resumed run re-creates exactly the same trials.

A config with several camera setups runs every perception observation under
each (`BenchConfig.camera_labels`: ``point_cloud@1view``, ``point_cloud@2views``);
ground truth, which has no camera, runs once. The seed of a group does not
depend on its setup, so the setups are a paired comparison: the first camera
sees the same noisy frame under each, and a second camera only adds to it.
``estimated_pose`` uses only the first camera, so a setup whose first camera
(and noise) equals an earlier setup's adds no ``estimated_pose`` groups: they
would repeat that setup's trials exactly.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
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
        return TrialKey(self.object_source.name, self.hand, self.planner_label, self.observation_label,
                        self.protocol.name, index)

    def trial_seed(self, index: int) -> int:
        """Seed of trial `index` (independent of the planning seed)."""
        return stable_seed(self.seed, "trial", index)

    def rng(self) -> np.random.Generator:
        """The planner's random generator for this group."""
        return np.random.default_rng(self.seed)


def groups(config: BenchConfig, base: Path | None = None) -> list[Group]:
    """Every group of `config`, in config order (objects, then hands, planners, observations, camera setups).

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
    out = []
    for source in sources:
        for hand in config.hands:
            for planner, label in zip(config.planners, labels, strict=True):
                for observation in config.observation:
                    seed = stable_seed(config.seed, source.name, hand, label, observation)
                    out += [Group(source, hand, planner, config.protocol, observation, config.scene,
                                  config.grasps_per_object, seed, config.trial_timeout_s, label, camera, suffix)
                            for camera, suffix in setups[observation]]
    return out


def observation_setups(config: BenchConfig) -> dict[str, list[tuple[CameraSetup | None, str]]]:
    """Per observation kind, the (camera setup, label suffix) pairs it runs under (module docstring)."""
    pairs = list(zip(config.camera_setups, config.camera_labels, strict=True))
    first_cameras: list[tuple] = []
    estimated = []
    for setup, suffix in pairs:
        first = (setup.view(0), setup.noise)
        if first not in first_cameras:
            first_cameras.append(first)
            estimated.append((setup, suffix))
    return {"ground_truth": [(pairs[0][0], "")], "estimated_pose": estimated, "point_cloud": pairs}
