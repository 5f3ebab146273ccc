"""Issue 14, harness and command line: recording never changes a result, `--record` on stored trials,
relative paths against the config's folder, extras checked before any trial, one-line CLI errors, run.json."""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path

import pytest
import trimesh

from manigrasp.bench import extras, rundir
from manigrasp.bench.config import load_config, parse_config
from manigrasp.bench.replay import record_trials
from manigrasp.bench.runner import run_benchmark
from manigrasp.bench.store import ResultsStore
from manigrasp.cli import main
from manigrasp.errors import ConfigError
from manigrasp.record.policy import RecordingWarning, RecordSettings, trial_file_name, trial_recording

ONE = {"objects": ["004_sugar_box"], "planners": ["random"], "grasps_per_object": 1, "protocol": "lift"}


def _statuses(run_dir: Path) -> dict[str, str]:
    with ResultsStore(run_dir / "results.sqlite") as store:
        return {row["trial_id"]: row["status"] for row in store.rows()}


# ------------------------------------------------------- recording never changes a result
def test_a_recording_folder_that_is_a_file_drops_the_recording_only(tmp_path):
    (tmp_path / "recordings").write_text("in the way")
    settings = RecordSettings.for_run(tmp_path, "all")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with trial_recording(settings, "a/b/c/d/e/0000", 0) as rec:
            rec.observer.on_start(None, None, None)  # a NullObserver: nothing is recorded, nothing raises
    assert rec.path is None and isinstance(rec.error, FileExistsError)
    assert any(issubclass(w.category, RecordingWarning) and "is a file" in str(w.message) for w in caught)


def test_record_all_with_a_file_named_recordings_stores_the_real_statuses(tmp_path, capsys):
    run = tmp_path / "run"
    run_benchmark(parse_config(ONE), run, progress=False, in_process=True)
    clean = _statuses(run)
    (run / "results.sqlite").unlink()  # the same run again, this time with --record all
    (run / "recordings").write_text("a file where the folder goes")
    summary = run_benchmark(parse_config(ONE), run, progress=False, record="all", in_process=True)
    assert summary.ran == 1 and _statuses(run) == clean and "harness_fault" not in clean.values()
    err = capsys.readouterr().err
    assert "nothing can be recorded" in err and "is a file" in err and "stored without recordings" in err


# --------------------------------------------- --record on stored trials, paths against the config's folder
@pytest.fixture
def mesh_run(tmp_path, monkeypatch):
    """A finished run of a config whose mesh path is relative to the config's folder, made from elsewhere."""
    folder = tmp_path / "configs"
    folder.mkdir()
    trimesh.creation.box((0.05, 0.05, 0.05)).export(folder / "block.stl")
    (folder / "c.yaml").write_text("objects: [{mesh: block.stl, name: block_relpath}]\nplanners: [random]\n"
                                   "grasps_per_object: 2\nprotocol: lift\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    config = load_config(folder / "c.yaml")
    run = tmp_path / "run"
    run_benchmark(config, run, progress=False, base=folder, in_process=True)
    return config, folder, run


def test_record_on_a_finished_run_records_its_stored_trials(mesh_run, capsys):
    config, folder, run = mesh_run
    stored = _statuses(run)
    again = run_benchmark(config, run, progress=False, base=folder, record="all", in_process=True)
    assert again.ran == 0 and again.already_done == 2
    assert sorted(r.trial_id for r in again.recorded) == sorted(stored)
    assert all(r.recording == run / "recordings" / trial_file_name(r.trial_id) and r.recording.is_file()
               for r in again.recorded)
    assert all(r.replayed.status.value == stored[r.trial_id] for r in again.recorded)  # the same trials
    assert "recorded 2 stored trial(s)" in again.record_note
    # recorded once: a second --record all skips them, and says so
    third = run_benchmark(config, run, progress=False, base=folder, record="all", in_process=True)
    assert not third.recorded and "2 not recorded (2: already recorded)" in third.record_note
    capsys.readouterr()
    assert main(["view", str(run), "--print-only"]) == 0
    assert "2 recording(s)" in capsys.readouterr().out


def test_record_selecting_no_stored_trial_says_so(tmp_path, capsys):
    run = tmp_path / "run"
    run_benchmark(parse_config(ONE), run, progress=False, in_process=True)
    (status,) = _statuses(run).values()
    wanted = "failures" if status == "success" else "successes"
    summary = run_benchmark(parse_config(ONE), run, progress=False, record=wanted, in_process=True)
    assert not summary.recorded and summary.record_note is None
    assert f"none of the 1 trials stored before this run is among {wanted}" in capsys.readouterr().err
    assert not list((run / "recordings").glob("*.rrd"))
    assert main(["view", str(run)]) == 2  # and view says how to record them: the command that does
    assert "with --record failures|successes|all|N (its stored trials are re-simulated" in capsys.readouterr().err


def test_run_json_keeps_the_config_folder_for_replay_and_record(mesh_run):
    _, folder, run = mesh_run
    assert json.loads((run / "run.json").read_text())["config_dir"] == str(folder.resolve())
    assert rundir.config_dir(run) == folder.resolve()
    first = sorted(_statuses(run))[0]
    done = record_trials(run, [first], directory=run / "elsewhere")  # no base: the mesh is found via run.json
    assert [r.trial_id for r in done.replays] == [first] and done.replays[0].recording.is_file()


def test_a_file_planner_path_is_relative_to_the_config_folder(tmp_path, monkeypatch):
    folder = tmp_path / "cfg"
    folder.mkdir()
    (folder / "c.yaml").write_text("objects: [mug]\nplanners: [{name: file, params: {path: grasps/mug.json}}, "
                                   f"{{name: file, params: {{path: {tmp_path / 'abs.json'}}}}}]\n")
    monkeypatch.chdir(tmp_path)
    config = load_config(folder / "c.yaml")
    paths = [dict(p.params)["path"] for p in config.planners]
    assert paths == [str(folder.resolve() / "grasps" / "mug.json"), str(tmp_path / "abs.json")]


# ------------------------------------------------------------ extras checked before any trial
def test_a_config_needing_a_missing_extra_is_refused_before_any_trial(tmp_path, monkeypatch):
    monkeypatch.setattr(extras, "_installed", lambda extra: extra != "perception")
    with pytest.raises(ConfigError, match=r"observation estimated_pose: needs the optional `perception` extra "
                                          r"\(open3d\): in the manigrasp clone run `make setup EXTRAS=dev,perception`"):
        run_benchmark(parse_config(dict(ONE, observation=["estimated_pose"])), tmp_path / "run", progress=False)
    assert not (tmp_path / "run").exists()
    monkeypatch.setattr(extras, "_installed", lambda extra: extra != "allegro")
    with pytest.raises(ConfigError, match=r"hand allegro_right: .*pip install -c constraints.txt -e '.\[allegro\]'"):
        run_benchmark(parse_config(dict(ONE, hands=["allegro_right"])), tmp_path / "run", progress=False)
    monkeypatch.setattr(extras, "_installed", lambda extra: extra != "parquet")
    code = main(["bench", "quick", "objects=004_sugar_box", "--export", "parquet", "--out", str(tmp_path / "run")])
    assert code == 2 and not (tmp_path / "run").exists()


def test_open3d_without_libusb_is_named_with_the_apt_command(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(extras, "_libusb_loads", lambda: False)
    libusb = "install libusb-1.0-0: apt-get install libusb-1.0-0"
    with pytest.raises(ConfigError, match="open3d is installed but the system library libusb-1.0"):
        run_benchmark(parse_config(dict(ONE, observation=["point_cloud"])), tmp_path / "run", progress=False)
    assert main(["perceive", "--object", "mug"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and libusb in err and "`manigrasp perceive`" in err
    assert extras.main(["dev", "perception"]) == 1 and libusb in capsys.readouterr().err


def test_ray_without_the_extra_gives_the_clone_command(monkeypatch):
    monkeypatch.setattr(extras, "_installed", lambda extra: extra != "ray")
    with pytest.raises(ConfigError, match=r"--executor ray: .*make setup EXTRAS=dev,ray"):
        extras.check(parse_config(ONE), "ray")
    assert extras.required(parse_config(ONE)) == {}


# ------------------------------------------------------------------ one-line CLI errors
PLAN = ["plan", "--object", "mug", "--hand", "parallel_jaw", "--planner", "random", "-n", "2"]


@pytest.mark.parametrize(("extra", "phrase"), [
    (["--seed", "-1"], "--seed must be an integer in 0..2**63-1, got -1"),
    (["--record", "{tmp}/missing/plan.rrd"], "the folder {tmp}/missing does not exist"),
    (["--record", "{tmp}"], "is a folder"),
])
def test_plan_bad_seed_and_record_target_are_one_line_errors(tmp_path, capsys, extra, phrase):
    args = [a.replace("{tmp}", str(tmp_path)) for a in extra]
    assert main(PLAN + args) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and phrase.replace("{tmp}", str(tmp_path)) in err


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_plan_record_into_a_read_only_folder_is_a_one_line_error(tmp_path, capsys):
    folder = tmp_path / "ro"
    folder.mkdir(mode=0o555)
    assert main(PLAN + ["--record", str(folder / "p.rrd")]) == 2
    assert "is not writable" in capsys.readouterr().err


def test_a_cache_that_is_a_file_is_a_one_line_error(tmp_path, monkeypatch, capsys):
    (tmp_path / "cache").write_text("not a folder")
    monkeypatch.setenv("MANIGRASP_CACHE", str(tmp_path / "cache"))
    assert main(PLAN) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "is a file, not a folder" in err and "MANIGRASP_CACHE" in err
    (tmp_path / "out").write_text("x")
    monkeypatch.setenv("MANIGRASP_CACHE", str(tmp_path / "good_cache"))  # never the user's own cache
    assert main(["bench", "quick", "objects=004_sugar_box", "--out", str(tmp_path / "out")]) == 2
    assert "is a file, not a run directory" in capsys.readouterr().err


# ------------------------------------------------------------------------------ run.json
def test_run_json_records_dm_env_and_the_installed_extras():
    found = rundir.versions()
    assert "dm-control" not in found and found["dm-env"] not in ("", "not installed")
    for name in ("h5py", "pyarrow", "example-robot-data"):
        assert (name in found) == (extras._installed({"h5py": "datasets", "pyarrow": "parquet",
                                                       "example-robot-data": "allegro"}[name]))


@pytest.mark.parametrize("command", [["bench", "quick"], ["label", "quick"], ["evaluate", "grasps.json"]])
def test_an_empty_run_directory_is_refused(command, capsys, tmp_path, monkeypatch):
    """`--out ""` wrote the run into the current folder."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        main([*command, "--out", ""])
    assert exit_.value.code == 2 and "the run directory must not be empty" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_a_ctrl_c_while_the_commands_load_is_one_line_not_a_traceback(capsys, monkeypatch):
    """A Ctrl-C while `build_parser` imported the commands' modules printed an import traceback."""
    import manigrasp.cli

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(manigrasp.cli, "build_parser", interrupted)
    assert main(["bench", "quick"]) == 130
    assert capsys.readouterr().err == "manigrasp: interrupted\n"


def test_perceive_takes_a_shipped_scan_and_report_out_a_file_is_one_line(tmp_path, monkeypatch, capsys):
    """`perceive` looked names up among the recipes only: a shipped scan, which bench and plan take, was unknown.
    `report --out FILE` ended in a FileExistsError traceback after the tables."""
    from manigrasp.objects import catalog

    def build(source, *args, **kwargs):
        raise ConfigError(f"reached the build of {source.name}")

    monkeypatch.setattr(catalog, "build", build)
    assert main(["perceive", "--object", "005_tomato_soup_can_scan", "--among", "005_tomato_soup_can_scan"]) == 2
    assert "reached the build of 005_tomato_soup_can_scan" in capsys.readouterr().err
    from test_bench_report import _results, make_run

    run = make_run(tmp_path / "run", _results({("025_mug", "antipodal"): 3}))
    (tmp_path / "afile").write_text("")
    assert main(["report", str(run), "--out", str(tmp_path / "afile")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--out" in err and "cannot write the report there" in err


def test_a_reader_that_closes_the_pipe_gets_no_traceback():
    """`manigrasp report RUN --json | head -1` ended in a BrokenPipeError traceback (exit 1)."""
    import subprocess
    import sys

    code = ("import sys\nfrom manigrasp.cli import main\nfrom manigrasp.cli import objects\n"
            "def flood(args):\n    while True:\n        print('x' * 1000)\n"
            "objects._list = flood\nsys.exit(main(['objects', 'list']))\n")
    reader = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    reader.stdout.readline()
    reader.stdout.close()  # as `head -1` does
    err = reader.stderr.read().decode()
    assert reader.wait(timeout=60) == 0 and "Traceback" not in err


def test_a_ctrl_c_swallowed_while_the_commands_load_still_stops_the_program(tmp_path):
    """trimesh guards its optional imports (networkx, scipy...) with ``except BaseException``: a Ctrl-C in the CLI's
    first second, while `build_parser` imported them, was swallowed and the command ran on (`bench quick` to its
    end, exit code 0). Here the SIGINT lands in such a guard; the program must stop with 130 and one line."""
    import subprocess
    import sys

    script = tmp_path / "swallow.py"
    script.write_text(
        "import os, signal, sys, time\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)  # as from a terminal, whatever launched the tests\n"
        "import manigrasp.cli as cli\n"
        "real = cli.build_parser\n"
        "def build_parser():\n"
        "    try:  # as trimesh guards an optional import\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "        time.sleep(2.0)\n"
        "    except BaseException:\n"
        "        pass\n"
        "    return real()\n"
        "cli.build_parser = build_parser\n"
        "print('the command ran on')\n"
        "sys.exit(cli.main(['hands', 'list']))\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(Path(__file__).parents[1]),
                                                                    os.environ.get("PYTHONPATH")])))
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120, env=env)
    assert (done.returncode, done.stderr) == (130, "manigrasp: interrupted\n"), (done.stdout[-500:], done.stderr)
    assert "parallel_jaw" not in done.stdout  # no command ran
