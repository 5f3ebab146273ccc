"""The observer hook: it sees every phase and a sample every `sample_period_s`, and changes nothing."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pytest

from manigrasp.protocol import PROTOCOLS, GraspParams, Phase, Status, TrialResult
from manigrasp.protocol.execution import Abort, TrialRun
from manigrasp.protocol.observer import NullObserver, TrialObserver
from manigrasp.sim import Scene


@dataclass
class Recorder:
    """Records what it is told, reading the scene only."""

    sample_period_s: float = 1.0 / 60.0
    events: list[tuple[str, str]] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    tcp_heights: list[float] = field(default_factory=list)
    result: TrialResult | None = None

    def on_start(self, scene: Any, grasp: Any, object_pose: Any) -> None:
        self.events.append(("start", ""))
        self.start_pose = np.array(object_pose)

    def on_phase(self, scene: Any, phase: str, detail: str = "") -> None:
        self.events.append((phase, detail))

    def on_sample(self, scene: Any) -> None:
        self.times.append(scene.time)
        self.tcp_heights.append(float(scene.tcp_pose()[2, 3]))

    def on_end(self, scene: Any, result: TrialResult) -> None:
        self.events.append(("end", ""))
        self.result = result


@pytest.fixture(scope="module")
def box(box_scene) -> tuple[Scene, np.ndarray, np.ndarray]:
    """The shared cube scene (conftest), the cube's resting pose and its top grasp (approach down, closing -y)."""
    return box_scene.scene, box_scene.rest, box_scene.top_grasp.copy()


def _same(a: TrialResult, b: TrialResult) -> bool:
    return repr(replace(a, wall_time_s=math.nan)) == repr(replace(b, wall_time_s=math.nan))


def _run(box: tuple, name: str, observer: TrialObserver | None, settle: bool = False, **params: Any) -> TrialResult:
    scene, rest, pose = box
    return PROTOCOLS.load(name, **params).run(scene, pose, np.random.default_rng(0), None,
                                              object_pose=None if settle else rest, observer=observer)


def test_recorder_satisfies_the_protocol() -> None:
    assert isinstance(Recorder(), TrialObserver) and isinstance(NullObserver(), TrialObserver)


@pytest.mark.parametrize("name", ["standard", "lift", "shake", "six_direction"])
def test_observed_trial_equals_unobserved_trial(box: tuple, name: str) -> None:
    params = {"hold_s": 0.3} if name != "six_direction" else {"force_s": 0.3, "directions": ("+x", "-z")}
    plain = _run(box, name, None, **params)
    recorder = Recorder()
    watched = _run(box, name, recorder, **params)
    assert plain.status is Status.SUCCESS, plain.detail
    assert _same(plain, watched), (plain, watched)
    assert _same(watched, recorder.result)
    assert _same(plain, _run(box, name, NullObserver(), **params))


def test_samples_every_period_with_increasing_time_and_phases_in_order(box: tuple) -> None:
    recorder = Recorder()
    result = _run(box, "standard", recorder)
    assert result.status is Status.SUCCESS, result.detail
    times = np.array(recorder.times)
    expected = result.sim_time_s / recorder.sample_period_s
    assert abs(len(times) - expected) <= 2, (len(times), expected)
    assert np.all(np.diff(times) > 0)
    # each sample sits at the first step at or after its multiple of the period
    k = np.arange(1, len(times) + 1) * recorder.sample_period_s
    assert np.all(times >= k - 1e-9) and np.all(times < k + 0.002 + 1e-9)
    heights = np.array(recorder.tcp_heights)  # pre-grasp 10 cm up, down to the grasp, lifted 10 cm
    assert heights[-1] > heights.min() + 0.09 and heights[0] > heights.min() + 0.09
    directions = ("+x", "-x", "+y", "-y", "+z", "-z")
    assert recorder.events == [("start", ""), ("pregrasp", ""), ("approach", ""), ("close", ""), ("lift", ""),
                               ("hold", ""), *(("perturb", d) for d in directions), ("end", "")]


def test_settling_is_observed_and_the_clock_runs_on(box: tuple) -> None:
    plain = _run(box, "lift", None, settle=True, hold_s=0.2)
    recorder = Recorder(sample_period_s=0.05)
    watched = _run(box, "lift", recorder, settle=True, hold_s=0.2)
    assert _same(plain, watched)
    assert recorder.events[:3] == [("start", ""), ("settle", ""), ("pregrasp", "")]
    assert np.all(np.diff(recorder.times) > 0)  # one time line through the settle and the trial's reset
    assert recorder.times[-1] > watched.sim_time_s  # settling time comes on top of the trial's own


def test_six_direction_phases_name_their_direction(box: tuple) -> None:
    recorder = Recorder(sample_period_s=0.1)
    result = _run(box, "six_direction", recorder, force_s=0.2, directions=("+x", "-y"))
    assert result.status is Status.SUCCESS, result.detail
    assert recorder.events == [("start", ""), ("pregrasp", ""), ("close", "+x"), ("perturb", "+x"),
                               ("close", "-y"), ("perturb", "-y"), ("end", "")]
    assert np.all(np.diff(recorder.times) > 0)


def test_an_invalid_grasp_is_still_started_and_ended(box: tuple) -> None:
    scene, rest, _ = box
    recorder = Recorder()
    result = PROTOCOLS.load("standard").run(scene, np.full((4, 4), np.nan), np.random.default_rng(0),
                                            object_pose=rest, observer=recorder)
    assert result.status is Status.INVALID_GRASP
    assert recorder.events == [("start", ""), ("end", "")] and recorder.times == []


@pytest.mark.parametrize(("name", "params", "after_lift"), [
    ("lift", {"hold_s": 0.2}, []),
    ("shake", {"hold_s": 0.2, "shake_cycles": 1}, [("shake", "")]),
])
def test_each_protocol_announces_its_phases_in_order_as_phases(box: tuple, name: str, params: dict,
                                                               after_lift: list) -> None:
    """`standard` and `six_direction` are checked above; every phase arrives as a `Phase`."""
    recorder = Recorder()
    result = _run(box, name, recorder, **params)
    assert result.status is Status.SUCCESS, result.detail
    assert recorder.events == [("start", ""), ("pregrasp", ""), ("approach", ""), ("close", ""), ("lift", ""),
                               ("hold", ""), *after_lift, ("end", "")]
    assert all(isinstance(phase, Phase) for phase, _ in recorder.events[1:-1])
    assert result.last_phase is (Phase.SHAKE if name == "shake" else Phase.LIFT)


def test_a_phase_owns_the_observer_call_the_watch_and_last_phase(box: tuple) -> None:
    """Nested phases (the hold in the lift) are told to the observer but only the enclosing one becomes
    `last_phase`; a phase that raises leaves `last_phase` as it was and is kept in `stopped_in`; each
    phase's watch is in force inside it only, named by the direction of a nested phase."""
    scene, rest, pose = box
    recorder = Recorder()
    run = TrialRun(scene, GraspParams(), None, observer=recorder)
    run.reset(pose, rest, 0.0)
    reference = run.object_in_hand()
    with run.phase(Phase.LIFT, watch=Status.SLIPPED_LIFT):
        assert run.watch is not None and run.watch[1:] == (Status.SLIPPED_LIFT, "lift")
        assert np.array_equal(run.watch[0], reference)  # the object in the hand as the phase began
        with run.phase(Phase.HOLD):
            assert run.watch[2] == "lift"
        with run.phase(Phase.PERTURB, "+y"):
            assert run.watch[1:] == (Status.SLIPPED_LIFT, "+y")
        assert run.last_phase == ""  # nested phases passed, the enclosing one not yet
    assert run.last_phase is Phase.LIFT and run.watch is None
    with pytest.raises(Abort):
        with run.phase(Phase.PERTURB, announce=False):
            with run.phase(Phase.PERTURB, "-z", watch=Status.DROPPED_PERTURB):
                raise Abort(Status.DROPPED_PERTURB, "pushed out")
    assert run.last_phase is Phase.LIFT and run.stopped_in == (Phase.PERTURB, "-z") and run.watch is None
    assert recorder.events == [("lift", ""), ("hold", ""), ("perturb", "+y"), ("perturb", "-z")]
