"""The standard protocol in closed loop: each outcome from a grasp whose physics decides it.

Scenes: `parallel_jaw` (70 N max grip, pads with friction 0.5, 8 cm opening)
with a 5 cm cube of 0.3 kg, and the same cube at 2 kg. A top grasp is the TCP
at the cube's centre, approach straight down, closing along world -y.
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh

from manigrasp.errors import ConfigError, UnknownNameError
from manigrasp.objects import build_object
from manigrasp.protocol import PROTOCOLS, Grasp, Status, TrialResult, settle_object
from manigrasp.sim import Scene, build_scene

BOX = 0.05  # [m] cube edge
LIGHT, HEAVY = 0.3, 2.0  # [kg]


def _scene(root: Path, mass: float) -> Scene:
    asset = build_object(trimesh.creation.box((BOX,) * 3), name=f"box_{mass:g}kg", mass=mass, cache_root=root).asset
    return build_scene("parallel_jaw", asset)


@pytest.fixture(scope="module")
def scenes(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Scene, np.ndarray]]:
    root = tmp_path_factory.mktemp("protocol_objects")
    out = {}
    for name, mass in (("light", LIGHT), ("heavy", HEAVY)):
        scene = _scene(root, mass)
        out[name] = (scene, settle_object(scene))
    return out


def top_grasp(rest: np.ndarray, offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """(4, 4) TCP at the cube's centre (+ offset), approach down (-z), closing along -y."""
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[:3, 3] = rest[:3, 3] + np.asarray(offset)
    return pose


def _run(scene: Scene, grasp: object, rest: np.ndarray, name: str = "standard", deadline: float | None = None,
         seed: int = 0, **params: object) -> TrialResult:
    protocol = PROTOCOLS.load(name, **params)
    return protocol.run(scene, grasp, np.random.default_rng(seed), deadline, object_pose=rest, seed=seed)


def test_settle_returns_the_resting_pose(scenes: dict) -> None:
    scene, rest = scenes["light"]
    assert rest.shape == (4, 4)
    assert rest[2, 3] == pytest.approx(BOX / 2, abs=1e-3)  # centre of mass half an edge above the table
    assert np.allclose(rest[:3, :3], np.eye(3), atol=1e-3)


def test_registry_names_and_strict_params() -> None:
    assert {"standard", "lift"} <= set(PROTOCOLS.names())
    with pytest.raises(ConfigError, match="did you mean 'hold_s'"):
        PROTOCOLS.load("standard", hold_ss=1.0)
    with pytest.raises(ConfigError, match="perturbation direction"):
        PROTOCOLS.load("standard", perturb_directions=["up"])
    with pytest.raises(UnknownNameError, match="available: .*standard"):
        PROTOCOLS.load("standrad")


def test_top_grasp_on_box_succeeds_with_two_fingers(scenes: dict) -> None:
    scene, rest = scenes["light"]
    result = _run(scene, top_grasp(rest), rest)
    assert result.status is Status.SUCCESS, result.detail
    assert result.last_phase == "perturb"
    assert result.fingers_in_contact == ("finger1", "finger2")
    assert result.grip_force_n == pytest.approx(0.5 * scene.hand.max_grip_force, rel=0.1)
    assert result.max_translation_m < 0.02 and result.max_rotation_deg < 15.0
    assert result.simulated.force_closure == 1.0 and result.simulated.n_contacts >= 2
    assert result.sim_steps > 0 and result.sim_time_s == pytest.approx(result.sim_steps * 0.002)


def test_grasp_beside_the_object_is_no_contact(scenes: dict) -> None:
    """TCP 5 cm beside the cube's centre: the pads (x in [4, 6] cm) close on air next to it (x <= 2.5 cm)."""
    scene, rest = scenes["light"]
    result = _run(scene, top_grasp(rest, (0.05, 0.0, 0.0)), rest)
    assert result.status is Status.NO_CONTACT, result.detail
    assert result.last_phase == "approach"
    assert result.fingers_in_contact == ()
    assert result.detail == "the hand closed without touching the object"  # it reached the grasp pose in free air


def test_a_grasp_below_the_table_top_says_where_the_approach_stopped(scenes: dict) -> None:
    """The same grasp beside the cube, 4 cm lower: the fingertips meet the table on the way down, the hand
    closes where it stopped, and the detail says so rather than only 'without touching the object'."""
    scene, rest = scenes["light"]
    result = _run(scene, top_grasp(rest, (0.05, 0.0, -0.04)), rest)
    assert result.status is Status.NO_CONTACT, result.detail
    match = re.fullmatch(r"the hand closed without touching the object \(the hand stopped (\d+) mm short of the "
                         r"grasp pose, against the table\)", result.detail)
    assert match, result.detail
    assert 5 < int(match.group(1)) <= 40


def test_pregrasp_inside_the_table_is_pregrasp_collision(scenes: dict) -> None:
    """A side grasp 1 cm above the table, approach along +x: the palm (3 cm either side of the TCP
    along the TCP x axis = world -z) reaches 2 cm into the table at the pre-grasp pose."""
    scene, rest = scenes["light"]
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    pose[:3, 3] = [rest[0, 3], rest[1, 3], 0.01]
    result = _run(scene, pose, rest)
    assert result.status is Status.PREGRASP_COLLISION, result.detail
    assert "table" in result.detail
    assert result.sim_steps == 0 and result.last_phase == "settle"


def test_low_grip_force_on_heavy_object_slips_at_lift(scenes: dict) -> None:
    """2 N of grip on a 2 kg cube: two pads with friction 0.5 hold at most 2 x 0.5 x 2 N = 2 N of
    the 19.6 N weight (torsional friction resists no vertical force), so the cube cannot rise
    with the hand: it slips past 2 cm in the hand during the lift, whatever the controller does."""
    scene, rest = scenes["heavy"]
    result = _run(scene, top_grasp(rest), rest, grip_force=2.0)
    assert result.status is Status.SLIPPED_LIFT, result.detail
    assert result.last_phase == "close"
    assert result.grip_force_n == pytest.approx(2.0, rel=0.25)
    assert result.max_translation_m > 0.02


def test_same_grasp_with_enough_grip_lifts_the_heavy_object(scenes: dict) -> None:
    """Control for the test above: at 35 N the pads can hold 35 N > 19.6 N, so the same cube stays."""
    scene, rest = scenes["heavy"]
    result = _run(scene, top_grasp(rest), rest, "lift", hold_s=0.5)
    assert result.status is Status.SUCCESS, result.detail


@pytest.mark.parametrize("pose", [np.full((4, 4), np.nan), np.array([0, 0, 0.1, 1.0, 0.2, 0, 0]),
                                  np.diag([2.0, 1.0, 1.0, 1.0])])
def test_invalid_pose_is_invalid_grasp(scenes: dict, pose: np.ndarray) -> None:
    scene, rest = scenes["light"]
    result = _run(scene, Grasp(pose=pose, planning_time_s=0.25), rest)
    assert result.status is Status.INVALID_GRASP
    assert result.sim_steps == 0 and result.planning_time_s == 0.25


def test_tiny_deadline_is_timeout(scenes: dict) -> None:
    scene, rest = scenes["light"]
    result = _run(scene, top_grasp(rest), rest, deadline=time.monotonic() + 1e-4)
    assert result.status is Status.TIMEOUT, result.detail
    assert 0 < result.sim_steps <= 10


def test_diverging_simulation_is_unstable(scenes: dict) -> None:
    """A perturbation of 1e7 m g accelerates the cube past any sane speed within one check."""
    scene, rest = scenes["light"]
    result = _run(scene, top_grasp(rest), rest, perturb_force_multiple=1e7)
    assert result.status is Status.UNSTABLE, result.detail
    assert result.last_phase == "lift"


def _comparable(result: TrialResult) -> str:
    return repr(replace(result, wall_time_s=math.nan))  # repr: NaN fields compare equal


def test_same_seed_gives_identical_result(scenes: dict) -> None:
    scene, rest = scenes["light"]
    first = _run(scene, top_grasp(rest), rest, seed=7)
    _run(scene, top_grasp(rest, (0.0, 0.01, 0.0)), rest, seed=3)  # something else in between
    again = _run(scene, top_grasp(rest), rest, seed=7)
    assert _comparable(first) == _comparable(again)
    assert first.seed == 7


def test_result_round_trips_through_flat(scenes: dict) -> None:
    scene, rest = scenes["light"]
    result = _run(scene, top_grasp(rest), rest, "lift", hold_s=0.2)
    assert _comparable(TrialResult.from_flat(result.flat())) == _comparable(result)


def test_lift_runs_end_to_end(scenes: dict) -> None:
    scene, rest = scenes["light"]
    result = _run(scene, top_grasp(rest), rest, "lift")
    assert result.status is Status.SUCCESS, result.detail
    assert result.last_phase == "lift"
    assert result.fingers_in_contact == ("finger1", "finger2")
    assert result.sim_time_s > 3.0  # approach 1 s + close + lift 1 s + hold 2 s
