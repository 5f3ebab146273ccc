"""Shared fixtures. Tests never download anything; data is generated here.

Every test session builds objects into a private cache (`_private_object_cache`): a test never writes
into the user's object cache, and no test's setting of ``MANIGRASP_CACHE`` outlives it.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import BOX_EDGE, BOX_MASS, TALL_BOX


def _user_cache() -> Path:
    """The user's object cache (where `manigrasp.paths.cache_dir` points), without creating it."""
    env = os.environ.get("MANIGRASP_CACHE")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "manigrasp"


@pytest.fixture(scope="session", autouse=True)
def _private_object_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """``MANIGRASP_CACHE`` points at a fresh session folder for the whole session (subprocesses included),
    seeded with a copy of the user's cache (CoACD results and built objects, checksummed and verified on
    use: read, never written) so that shipped objects need not be decomposed again."""
    root = tmp_path_factory.mktemp("manigrasp-cache")
    for part in ("coacd", "objects"):
        if (_user_cache() / part).is_dir():
            shutil.copytree(_user_cache() / part, root / part, dirs_exist_ok=True)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MANIGRASP_CACHE", str(root))
        yield root


@pytest.fixture
def isolated_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A fresh, empty manigrasp cache for one test."""
    root = tmp_path / "cache"
    monkeypatch.setenv("MANIGRASP_CACHE", str(root))
    return root


@pytest.fixture(scope="session")
def jaw():
    """The `parallel_jaw` hand (`manigrasp.hands.Hand`)."""
    from manigrasp import hands

    return hands.load("parallel_jaw")


@pytest.fixture(scope="session")
def box_asset(tmp_path_factory: pytest.TempPathFactory):
    """The shared 5 cm, 0.3 kg cube (`manigrasp.objects.ObjectAsset`), built once per session."""
    import trimesh

    from manigrasp.objects import build_object

    mesh = trimesh.creation.box((BOX_EDGE,) * 3)
    return build_object(mesh, name="box", mass=BOX_MASS, cache_root=tmp_path_factory.mktemp("box")).asset


@pytest.fixture(scope="session")
def can(tmp_path_factory: pytest.TempPathFactory):
    """A soup-can-sized cylinder (66 mm wide, 120 mm tall, 0.35 kg) for the dexterous hands' hand-placed grasps,
    built once per session."""
    import trimesh

    from manigrasp.objects import build_object

    mesh = trimesh.creation.cylinder(0.033, 0.12, sections=48)
    return build_object(mesh, name="can", mass=0.35, cache_root=tmp_path_factory.mktemp("can")).asset


@dataclass(frozen=True)
class BoxScene:
    """The cube on the table with the parallel jaw (`box_scene`).

    Attributes:
        scene: the compiled `manigrasp.sim.Scene` (protocols reset it; a test that changes its model
            restores it).
        asset: the cube.
        rest: (4, 4) the cube's settled pose.
        top_grasp: (4, 4) a TCP pose through the cube's centre, approach down (-z), closing along -y.
    """

    scene: object
    asset: object
    rest: np.ndarray
    top_grasp: np.ndarray


@pytest.fixture(scope="session")
def box_scene(box_asset) -> BoxScene:
    """The cube with `parallel_jaw`, settled, and its top grasp: compiled once per session."""
    from manigrasp.protocol import settle_object
    from manigrasp.sim import build_scene

    scene = build_scene("parallel_jaw", box_asset)
    rest = settle_object(scene)
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[:3, 3] = rest[:3, 3]
    rest.setflags(write=False)
    pose.setflags(write=False)
    return BoxScene(scene, box_asset, rest, pose)


@pytest.fixture(scope="session")
def tall_box_asset(tmp_path_factory: pytest.TempPathFactory):
    """The planners' 5 x 3 x 12 cm box of 0.2 kg (`helpers.TALL_BOX`), built once per session."""
    import trimesh

    from manigrasp.objects import build_object

    return build_object(trimesh.creation.box(TALL_BOX), name="planner_test_box", mass=0.2,
                        cache_root=tmp_path_factory.mktemp("tall_box")).asset


@pytest.fixture(scope="module")
def box_table(tall_box_asset):
    """The tall box upright on a camera-ready tabletop (`sim.build_tabletop`; no hand)."""
    from manigrasp.sim import build_tabletop

    table = build_tabletop(tall_box_asset)
    pose = np.eye(4)
    pose[2, 3] = TALL_BOX[2] / 2
    table.place(pose)
    return table


# Test files whose tests (with their module fixtures) take a minute or more of CPU: collected first, so that
# `make test`'s workers (pytest-xdist, whole files each: --dist loadfile) start on them and finish together
# instead of one working alone through a long file at the end (a 3-minute tail of a 12-minute run on 2 cores).
# Longest first, by their summed `--durations=0` on 2 workers (3 Dec 2026): 202, 169, 131, 110, 110, 80 s, ...
# of 1387 s in all.
LONG_FILES = ("test_planners_shipped.py", "test_perception_pose.py", "test_reliability.py", "test_bench_e2e.py",
              "test_planners.py", "test_dexopt_planner.py", "test_antipodal_repack.py", "test_objects_shipped.py",
              "test_hands_physics.py")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    rank = {name: i for i, name in enumerate(LONG_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(LONG_FILES)))  # stable: file order kept otherwise


def pytest_configure(config: pytest.Config) -> None:
    # Keep CoACD / OpenMP from oversubscribing the 2-core CI machine.
    os.environ.setdefault("OMP_NUM_THREADS", "1")
