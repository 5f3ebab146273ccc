"""Trial recordings: valid .rrd files that hold the scene, the trial over sim_time, and its status.

Scene: the shared `parallel_jaw` and 5 cm, 0.3 kg cube (conftest `box_scene`). A
trial is either the real standard protocol (when its `run` takes an
`observer`) or `drive` (tests/helpers.py): a small scripted trial that calls the observer the
way a protocol does (start, phases, a sample every period, end).
"""

from __future__ import annotations

import inspect
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from manigrasp.errors import ConfigError
from manigrasp.objects import ObjectAsset
from manigrasp.protocol import PROTOCOLS, Status, TrialResult, settle_object
from manigrasp.protocol.observer import NullObserver, TrialObserver
from manigrasp.record import RecordOptions, SimClock, TrialRecorder
from manigrasp.record.readback import summarize
from manigrasp.sim import Scene, build_scene
from tests.helpers import drive, top_grasp

RERUN = Path(sys.executable).parent / "rerun"
HAS_HOOK = "observer" in inspect.signature(PROTOCOLS.load("standard").run).parameters


@pytest.fixture(scope="module")
def box(box_scene) -> tuple[Scene, np.ndarray]:
    """The shared cube scene (conftest) and the cube's settled pose."""
    return box_scene.scene, box_scene.rest


def run_trial(scene: Scene, rest: np.ndarray, observer: TrialObserver | None) -> TrialResult:
    """The real standard protocol when it takes an observer, else `drive`."""
    if HAS_HOOK:
        protocol = PROTOCOLS.load("standard")
        return protocol.run(scene, top_grasp(rest), np.random.default_rng(0), None, object_pose=rest,
                            observer=observer or NullObserver())
    return drive(scene, observer or NullObserver(), rest)


@pytest.fixture(scope="module")
def recorded(box: tuple[Scene, np.ndarray], tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, TrialResult]:
    scene, rest = box
    path = tmp_path_factory.mktemp("recordings") / "trial.rrd"
    recorder = TrialRecorder(path, recording_id="box_rec/parallel_jaw/test/gt/standard/0000")
    result = run_trial(scene, rest, recorder)
    assert recorder.error is None and recorder.closed
    return path, result


def test_recorded_trial_passes_rerun_verify(recorded: tuple[Path, TrialResult]) -> None:
    if not RERUN.is_file() and shutil.which("rerun") is None:
        pytest.skip("the rerun CLI is not installed next to this interpreter or on PATH")
    exe = str(RERUN) if RERUN.is_file() else "rerun"
    done = subprocess.run([exe, "rrd", "verify", "--check-footers", "true", str(recorded[0])],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "verified without error" in done.stderr + done.stdout


def test_recording_holds_scene_trial_and_status(recorded: tuple[Path, TrialResult]) -> None:
    path, result = recorded
    summary = summarize(path)
    expected = {
        "/world/table/top",                                   # the table, by its MJCF name
        "/world/object/object", "/world/object/object/visual/object_visual",
        "/world/object/object/collision/object_part_000",    # convex parts, separate (hidden in the blueprint)
        "/world/hand/palm", "/world/hand/finger1", "/world/hand/finger2",
        "/world/hand/finger1/collision/finger1_link",
        # compliant pads (the default): the elements are drawn, the pad box they replace is not
        "/world/hand/padel_finger1_pad_00/collision/padel_finger1_pad_00",
        "/world/contacts", "/world/contacts/force",
        "/world/plan/grasp", "/world/plan/pregrasp", "/world/plan/contacts",
        "/plots/grip_force", "/plots/in_hand/displacement_mm", "/plots/in_hand/rotation_deg",
        "/plots/perturb_force", "/trial/phase", "/trial/log", "/trial/status", "/trial/plan",
    }
    assert expected <= set(summary.entities), expected - set(summary.entities)
    assert not any(e.endswith("/finger1_pad") for e in summary.entities)
    assert summary.n_blueprints == 1
    assert summary.status == result.status.value
    low, high = summary.time_range
    assert low == pytest.approx(0.0, abs=1e-9)
    assert high == pytest.approx(result.sim_time_s, abs=1e-6)


def test_recording_is_small(recorded: tuple[Path, TrialResult]) -> None:
    assert recorded[0].stat().st_size < 5e6


def test_contacts_appear_once_the_hand_closes(recorded: tuple[Path, TrialResult]) -> None:
    from rerun.chunk import RrdReader

    counts = []
    for chunk in RrdReader(recorded[0]).stream().to_chunks():
        if chunk.entity_path == "/world/contacts" and not chunk.is_static:
            counts += [len(p) for p in chunk.to_record_batch().column("Points3D:positions").to_pylist()]
    assert counts and counts[0] == 0 and max(counts) >= 2  # open hand first, then both jaws touch


def test_recording_does_not_change_the_trial(box: tuple[Scene, np.ndarray], tmp_path: Path) -> None:
    scene, rest = box
    plain = run_trial(scene, rest, None)
    state_plain = scene.data.qpos.copy()
    recorder = TrialRecorder(tmp_path / "t.rrd")
    recorded = run_trial(scene, rest, recorder)
    assert recorder.error is None and recorder.path.stat().st_size > 0
    assert np.array_equal(scene.data.qpos, state_plain)  # the same final state, bit for bit
    # every field but the wall-clock time; repr so that NaN equals NaN
    assert repr(replace(plain, wall_time_s=0.0)) == repr(replace(recorded, wall_time_s=0.0))


@pytest.mark.skipif(not HAS_HOOK, reason="protocol.run(..., observer=...) has not landed yet")
def test_real_protocol_recording_matches_its_result(recorded: tuple[Path, TrialResult]) -> None:
    path, result = recorded
    assert result.status is Status.SUCCESS, result.detail
    assert summarize(path).status == "success"


def test_full_rate_samples_every_step(box: tuple[Scene, np.ndarray], tmp_path: Path) -> None:
    scene, rest = box
    dt = scene.model.opt.timestep
    recorder = TrialRecorder(tmp_path / "full.rrd", options=RecordOptions.full_rate(dt))
    assert recorder.sample_period_s == pytest.approx(dt)
    result = drive(scene, recorder, rest, seconds=0.2)
    assert summarize(tmp_path / "full.rrd").time_range[1] == pytest.approx(result.sim_time_s, abs=1e-9)
    assert len(recorder._samples.time) >= result.sim_steps  # one sample per step (and the end state)
    with pytest.raises(ConfigError, match="rate_hz must be > 0"):
        RecordOptions(rate_hz=0.0)


def test_sim_clock_keeps_increasing_across_resets() -> None:
    clock = SimClock()
    assert clock.stamp(5.0, sample=False) == 0.0  # stale time of the previous trial before the first sample
    stamps = [clock.stamp(t, sample=True) for t in (0.0, 0.5, 1.0, 0.0, 0.25)]
    assert stamps == [0.0, 0.5, 1.0, 1.0, 1.25]


def test_a_failing_recorder_never_raises_into_the_trial(box: tuple[Scene, np.ndarray], tmp_path: Path) -> None:
    scene, rest = box
    recorder = TrialRecorder(tmp_path / "no" / "such" / "dir" / "t.rrd")  # rerun cannot create the file
    result = drive(scene, recorder, rest, seconds=0.05)
    assert isinstance(recorder.error, RuntimeError) and recorder.closed
    assert recorder.result is None and result.sim_steps == 25  # the trial ran to its end regardless


def test_dexterous_hand_recording_names_bodies_and_stays_small(tmp_path: Path, box_asset: ObjectAsset) -> None:
    from manigrasp.record.static import scene_geometry

    scene = build_scene("inspire_left", box_asset)
    meshes, hidden = scene_geometry(scene.model)
    entities = {m.entity for m in meshes}
    assert "world/hand/l_palm/visual/l_palm_vis" in entities and "world/hand/l_palm/collision/l_palm_col" in entities
    assert "world/hand/l_palm/collision" in hidden  # collision meshes hidden where a visual mesh exists
    assert all(not m.visual for m in meshes if m.entity.split("/")[-2] == "collision")
    path = tmp_path / "dex.rrd"
    drive(scene, TrialRecorder(path), settle_object(scene), seconds=0.5)
    summary = summarize(path)
    assert "/world/hand/l_thumb_distal" in summary.entities
    assert path.stat().st_size < 5e6  # ~3 MB of which almost all is the hand's meshes, once


def test_blueprint_hides_the_convex_parts_only(recorded: tuple[Path, TrialResult]) -> None:
    from rerun.chunk import RrdReader

    reader = RrdReader(recorded[0])
    hidden = {}
    for chunk in reader.stream(store=reader.blueprints()[0]).to_chunks():
        batch = chunk.to_record_batch()
        if "EntityBehavior:visible" in batch.schema.names and "/overrides/" in chunk.entity_path:
            target = chunk.entity_path.split("/overrides/", 1)[1]
            hidden[target] = batch.column("EntityBehavior:visible").to_pylist()[0] == [False]
    assert any(t.startswith("world/object/object/collision") and v for t, v in hidden.items()), hidden
    assert not any("hand" in t for t in hidden)  # parallel_jaw has only collision geoms: they stay visible


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts OS threads through /proc (Linux)")
def test_recordings_do_not_leave_threads_behind(box: tuple[Scene, np.ndarray], tmp_path: Path) -> None:
    scene, rest = box

    def record(i: int) -> None:
        drive(scene, TrialRecorder(tmp_path / f"{i}.rrd"), rest, seconds=0.02)

    record(0)
    before = len(list(Path("/proc/self/task").iterdir()))
    for i in range(1, 11):
        record(i)
    assert len(list(Path("/proc/self/task").iterdir())) <= before + 2  # rerun alone would add 2 per recording


@pytest.mark.parametrize("own", [None, 0.04])
def test_the_pregrasp_is_drawn_where_the_protocol_starts_the_hand(box, tmp_path, monkeypatch, own) -> None:
    """A grasp that names its own pre-grasp offset is executed there (`TrialRun.use_grasp`), so it is drawn
    there; one that names none is drawn at the options' offset (the protocol's)."""
    from manigrasp.record import recorder as recorder_module

    drawn = []
    monkeypatch.setattr(recorder_module.static, "log_planned_grasp",
                        lambda stream, pose, pregrasp, *rest: drawn.append((pose, pregrasp)))
    _, rest = box
    grasp = replace(top_grasp(rest), pregrasp_offset=own)
    recorder = TrialRecorder(tmp_path / "p.rrd", options=RecordOptions(pregrasp_offset=0.12))
    recorder._log_plan(grasp)
    (pose, pregrasp), = drawn
    offset = 0.12 if own is None else own
    np.testing.assert_allclose(pregrasp[:3, 3], pose[:3, 3] - offset * pose[:3, 2], atol=1e-12)
