"""Report and compare on stored results with known counts."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from manigrasp.bench.markdown import write_markdown
from manigrasp.bench.report import POOLED, format_auc, report_from_json, summarize
from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.cli import main
from manigrasp.protocol.result import GraspMetrics, PoseRecord, Status, TrialResult


def _results(successes: dict[tuple[str, str], int], n: int = 20) -> list[tuple[TrialKey, TrialResult]]:
    """n trials per (object, planner); the first `k` succeed; epsilon is high exactly on successes."""
    out = []
    for (obj, planner), k in successes.items():
        for i in range(n):
            ok = i < k
            status = Status.SUCCESS if ok else (Status.DROPPED_PERTURB if i % 2 else Status.NO_CONTACT)
            dropped = status is Status.DROPPED_PERTURB
            result = TrialResult(status, detail="+x: object moved 3.0 cm / 0.0 deg in the hand" if dropped else "",
                                 perturb_direction="+x" if dropped else "",
                                 planned=GraspMetrics(2, float(ok), 0.2 if ok else 0.01, 0.2),
                                 planning_time_s=0.01, score=float(i % 3), seed=i)
            out.append((TrialKey(obj, "parallel_jaw", planner, "ground_truth", "standard", i), result))
    return out


def test_summary_counts_rates_intervals_and_modes():
    report = summarize(_results({("025_mug", "antipodal"): 18, ("025_mug", "random"): 4}))
    mug = report.groups[("parallel_jaw", "antipodal", "ground_truth", "standard", "025_mug")]
    assert (mug.trials, mug.successes, mug.success_rate) == (20, 18, 0.9)
    assert mug.ci_low == pytest.approx(0.699, abs=1e-3) and mug.ci_high == pytest.approx(0.972, abs=1e-3)
    random = report.by_method[("parallel_jaw", "random", "ground_truth", "standard")]
    assert random.failure_modes == {"dropped_perturb+x": 8, "no_contact": 8}
    assert report.overall.trials == 40 and report.overall.successes == 22
    antipodal = report.auc[("parallel_jaw", "antipodal", "ground_truth", "standard")]
    assert antipodal["epsilon_l1"].auc == 1.0  # epsilon separates successes perfectly here
    assert antipodal["force_closure"].auc == 1.0 and antipodal["force_closure"].n == 20
    assert 0.3 < antipodal["planner_score"].auc < 0.7  # a score unrelated to the outcome is near chance


def test_report_json_round_trips_as_strict_json():
    """NaN (an undefined AUC, an untimed plan) is written as null, so the JSON is standard; it reads back equal."""
    report = summarize(_results({("025_mug", "antipodal"): 18, ("025_mug", "random"): 0}))
    text = json.dumps(report.to_json(), allow_nan=False)
    again = report_from_json(json.loads(text))
    assert again.groups == report.groups and again.overall == report.overall
    assert again.by_method == report.by_method
    random = again.auc[("parallel_jaw", "random", "ground_truth", "standard")]["epsilon_l1"]
    assert random.undefined == "no successes" and math.isnan(random.auc)
    def same(e):  # NaN != NaN: compare the printed form and counts
        return format_auc(e), e.n, e.successes

    for method, per in report.auc.items():
        assert {k: same(e) for k, e in again.auc[method].items()} == {k: same(e) for k, e in per.items()}


RUN_META = {"config": {"name": "t", "protocol": {"name": "standard", "params": {}}, "hands": ["parallel_jaw"],
                       "scene": {"timestep": 0.002}, "objects": ["025_mug", "048_hammer"]},
            "seed": 0, "versions": {"manigrasp": "0.1.0", "mujoco": "4.0.0"}}


def make_run(path, results, meta=RUN_META):
    """A run directory with run.json and a store holding `results`."""
    path.mkdir(parents=True, exist_ok=True)
    (path / "run.json").write_text(json.dumps(meta))
    with ResultsStore(path / "results.sqlite") as store:
        for key, result in results:
            store.add(key, result)
    return path


def test_report_cli_prints_per_planner_lines_and_writes_markdown_and_plots(tmp_path, capsys):
    run = make_run(tmp_path / "run", _results({("025_mug", "antipodal"): 18, ("025_mug", "random"): 4}))
    assert main(["report", str(run)]) == 0
    out = capsys.readouterr().out
    assert "parallel_jaw / antipodal: 18/20 successes" in out and "parallel_jaw / random: 4/20 successes" in out
    assert "mixes planners" in out and "overall" not in out.lower()
    assert (run / "report.md").is_file() and (run / "success_by_object.png").stat().st_size > 1000


def test_report_json_is_json_only_with_the_runs_config_and_versions(tmp_path, capsys):
    """`report --json` prints JSON and writes nothing (no report.md, no PNGs): it is the baseline format."""
    run = make_run(tmp_path / "run", _results({("025_mug", "antipodal"): 18, ("025_mug", "random"): 4}))
    assert main(["report", str(run), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert _files(run) == ["results.sqlite", "run.json"]  # (SQLite's own -wal/-shm aside)
    group = next(g for g in payload["groups"] if g["planner"] == "antipodal")
    assert {"hand", "planner", "object", "trials", "successes", "success_rate", "ci_low", "ci_high"} <= set(group)
    assert payload["run"]["versions"]["mujoco"] == "4.0.0"
    # the config as recorded, its scene with the parameters it predates at the values it ran with (LEGACY_SCENE)
    from manigrasp.sim.config import with_legacy_scene

    assert payload["run"]["config"] == with_legacy_scene(RUN_META["config"]) != RUN_META["config"]
    assert payload["overall"]["pools"] == POOLED


def _files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if not p.name.endswith(("-wal", "-shm")))


def test_report_on_a_folder_with_only_run_json_is_an_error_and_creates_nothing(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "run.json").write_text(json.dumps(RUN_META))
    assert main(["report", str(run)]) == 2
    assert "holds no results.sqlite" in capsys.readouterr().err
    assert sorted(p.name for p in run.iterdir()) == ["run.json"]


def test_report_on_a_garbage_store_is_a_one_line_error(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "run.json").write_text(json.dumps(RUN_META))
    (run / "results.sqlite").write_bytes(b"not a database" * 100)
    assert main(["report", str(run)]) == 2
    assert "not a readable manigrasp results store" in capsys.readouterr().err


_READ_ONLY_MOUNT = 'mount --bind "$0" "$0" && mount -o remount,ro,bind "$0" "$0" && exec "$@"'


def _read_only_runner(folder: Path) -> list[str]:
    """A command prefix under which `folder` cannot be written: a read-only bind mount in a private mount
    namespace for root (who ignores file modes), the file modes otherwise; skips where neither works."""
    if os.geteuid() != 0:
        for path in [folder, *folder.rglob("*")]:
            path.chmod(0o555 if path.is_dir() else 0o444)
        return []
    prefix = ["unshare", "-m", "sh", "-c", _READ_ONLY_MOUNT, str(folder)]
    if shutil.which("unshare") is None or subprocess.run(
            [*prefix, "sh", "-c", f"! touch {folder}/probe 2>/dev/null"], capture_output=True).returncode != 0:
        pytest.skip("cannot make a read-only folder here (root without mount namespaces)")
    return prefix


@pytest.mark.slow
def test_report_and_compare_read_a_read_only_run_directory(tmp_path):
    """The store is opened read-only: report, report --json, compare and export (to a writable --out) work on
    a run directory that cannot be written, and nothing is written there."""
    pair = _results({("025_mug", "antipodal"): 18, ("025_mug", "random"): 4})
    run, baseline = make_run(tmp_path / "ro" / "run", pair), make_run(tmp_path / "ro" / "base", pair)
    before = _files(run)
    prefix = _read_only_runner(tmp_path / "ro")

    commands = [["report", str(run)], ["report", str(run), "--json"], ["compare", str(run), str(baseline)],
                ["export", str(run), "--out", str(tmp_path / "t.csv")]]
    script = ("import contextlib, io, json, sys\nfrom manigrasp.cli import main\nout = []\n"
              "for args in json.loads(sys.argv[1]):\n"
              "    o, e = io.StringIO(), io.StringIO()\n"
              "    with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):\n"
              "        code = main(args)\n"
              "    out.append([code, o.getvalue(), e.getvalue()])\n"
              "print(json.dumps(out))\n")
    done = subprocess.run([*prefix, sys.executable, "-c", script, json.dumps(commands)], capture_output=True,
                          text=True, timeout=120, env=dict(os.environ, MPLCONFIGDIR=str(tmp_path)))
    assert done.returncode == 0, done.stderr
    (report, report_json, compared, exported) = json.loads(done.stdout.splitlines()[-1])
    assert [report[0], report_json[0], compared[0], exported[0]] == [0, 0, 0, 0], (report, compared, exported)
    assert "parallel_jaw / antipodal: 18/20 successes" in report[1] and "read-only" in report[2]
    assert json.loads(report_json[1])["overall"]["trials"] == 40
    assert "0 significant regression(s)" in compared[1]
    assert (tmp_path / "t.csv").read_text().count("\n") == 41
    assert _files(run) == before


def test_planning_time_is_one_value_per_planning_call(tmp_path):
    """Two objects planned in 2.0 s and 4.0 s, 20 candidates each (0.1 and 0.2 s per candidate): the median
    planning time is over the 2 calls (3.0 s), not the per-candidate share repeated per trial (0.15 s)."""
    results = []
    for obj, call in (("025_mug", 2.0), ("048_hammer", 4.0)):
        for key, r in _results({(obj, "antipodal"): 10}):
            results.append((key, replace(r, plan_time_s=call, planning_time_s=call / 20)))
    report = summarize(results)
    method = report.by_method[("parallel_jaw", "antipodal", "ground_truth", "standard")]
    assert method.median_planning_time_s == 3.0 and method.planning_calls == 2
    hammer = report.groups[("parallel_jaw", "antipodal", "ground_truth", "standard", "048_hammer")]
    assert hammer.median_planning_time_s == 4.0
    text = write_markdown(report, results, tmp_path, RUN_META).read_text()
    assert "median planning call [s] (calls)" in text and "3.00 (2 calls)" in text


def test_a_planning_call_that_timed_out_is_not_a_measured_time(tmp_path):
    """Its trials store the budget (5 s) as their time: the column read "5.00 (1 call)" as if measured."""
    from manigrasp.bench.report import PLANNING_TIME_HEADER, format_planning_time

    key = lambda obj, i: TrialKey(obj, "parallel_jaw", "antipodal", "ground_truth", "standard", i)  # noqa: E731
    late = [(key("048_hammer", i), TrialResult(Status.TIMEOUT, detail="planning took longer than 5 s",
                                               plan_time_s=5.0)) for i in range(3)]
    timed = [(key("025_mug", i), TrialResult(Status.SUCCESS, plan_time_s=0.5)) for i in range(3)]
    report = summarize(late + timed)
    groups = report.groups
    hammer = groups[("parallel_jaw", "antipodal", "ground_truth", "standard", "048_hammer")]
    assert format_planning_time(hammer) == "- (1 call timed out)" and hammer.planning_calls == 0
    method = report.by_method[("parallel_jaw", "antipodal", "ground_truth", "standard")]
    assert method.median_planning_time_s == 0.5 and format_planning_time(method) == "0.500 (1 call; 1 more timed out)"
    text = write_markdown(report, late + timed, tmp_path, RUN_META).read_text()
    assert PLANNING_TIME_HEADER in text and "5.00" not in text


def test_planning_time_keeps_three_significant_digits():
    """A planner that takes 0.42 ms per call (the random planner) does not print as 0.000 s."""
    from manigrasp.bench.report import Rate, format_planning_time

    def shown(seconds: float) -> str:
        return format_planning_time(Rate(1, 1, 1.0, 0.0, 1.0, median_planning_time_s=seconds, planning_calls=5))

    assert [shown(s) for s in (0.00042, 0.0095157, 1.0726, 3.0, 251.3, 99.97, 99.94)] == [
        "0.000420 (5 calls)", "0.00952 (5 calls)", "1.07 (5 calls)", "3.00 (5 calls)", "251 (5 calls)",
        "100 (5 calls)", "99.9 (5 calls)"]  # (99.97 printed "100.")


def test_markdown_lists_every_group(tmp_path):
    results = _results({("025_mug", "antipodal"): 18, ("048_hammer", "random"): 2})
    path = write_markdown(summarize(results), results, tmp_path, {"config": {"name": "demo"}, "seed": 3})
    text = path.read_text()
    assert "025_mug" in text and "048_hammer" in text and "![Outcomes](failure_modes.png)" in text


def test_pose_errors_are_summarised_per_observation_and_shown_side_by_side(tmp_path):
    """Three objects with estimated poses (rotation 1, 2, 20 deg; translation = ADD-S = 3, 4, 6 mm): median
    2 deg, 4 mm; 2 of 3 with ADD-S < 5 mm and translation < 1 cm. Ground-truth groups have no pose errors."""
    results = []
    for obj, rot, trans in (("a", 1.0, 3.0), ("b", 20.0, 4.0), ("c", 2.0, 6.0)):
        for i in range(4):
            r = TrialResult(Status.SUCCESS if i else Status.NO_CONTACT, pose_rotation_error_deg=rot,
                            pose_translation_error_mm=trans, pose_add_s_mm=trans)
            results.append((TrialKey(obj, "parallel_jaw", "antipodal", "estimated_pose", "standard", i), r))
            results.append((TrialKey(obj, "parallel_jaw", "antipodal", "ground_truth", "standard", i),
                            TrialResult(Status.SUCCESS)))
    report = summarize(results)
    errors = report.pose_errors[("parallel_jaw", "antipodal", "estimated_pose", "standard")]
    assert (errors.objects, errors.median_rotation_deg, errors.median_translation_mm) == (3, 2.0, 4.0)
    assert errors.median_add_s_mm == 4.0
    assert errors.share_good == pytest.approx(2 / 3)  # the symmetry not recorded: judged by ADD-S, as before
    assert (errors.symmetric, errors.unrecorded) == (0, 3)
    assert ("parallel_jaw", "antipodal", "ground_truth", "standard") not in report.pose_errors
    assert report_from_json(json.loads(json.dumps(report.to_json()))).pose_errors == report.pose_errors
    for name in ("share_add_s_5mm_translation_1cm", "share_within_5deg_1cm"):  # reports written before the renames
        old = json.loads(json.dumps(report.to_json()).replace("share_good", name))
        for entry in old["pose_errors"]:
            del entry["symmetric"], entry["unrecorded"]
        assert replace(report_from_json(old).pose_errors[("parallel_jaw", "antipodal", "estimated_pose", "standard")],
                       unrecorded=3) == errors  # an older report records no counts: 0
    text = write_markdown(report, results, tmp_path, {"config": {}}).read_text()
    assert "Observations side by side" in text and "estimated_pose" in text



def test_a_group_whose_first_trial_timed_out_keeps_its_pose_estimate():
    """Trial 0000 of object "b" timed out in the runner (a bare result, no pose errors): the group's other trials
    store its estimate, so the object still counts (it was dropped: medians over 1 object instead of 2)."""
    results = []
    for obj, rot in (("a", 2.0), ("b", 30.0)):
        for i in range(3):
            r = TrialResult(Status.TIMEOUT) if (obj, i) == ("b", 0) else TrialResult(
                Status.SUCCESS, pose_rotation_error_deg=rot, pose_translation_error_mm=1.0, pose_add_s_mm=1.0)
            results.append((TrialKey(obj, "parallel_jaw", "antipodal", "estimated_pose", "standard", i), r))
    errors = summarize(results).pose_errors[("parallel_jaw", "antipodal", "estimated_pose", "standard")]
    assert (errors.objects, errors.median_rotation_deg) == (2, 16.0)

def test_perception_table_shows_the_number_of_camera_views(tmp_path):
    """A point-cloud method seen by 2 cameras says so; ground truth has no camera ("-")."""
    results = [(TrialKey("a", "parallel_jaw", "antipodal", obs, "standard", i),
                TrialResult(Status.SUCCESS if i % 2 else Status.NO_CONTACT, camera_views=views))
               for obs, views in (("point_cloud", 2), ("ground_truth", 0)) for i in range(4)]
    report = summarize(results)
    assert report.views == {("parallel_jaw", "antipodal", "ground_truth", "standard"): 0,
                            ("parallel_jaw", "antipodal", "point_cloud", "standard"): 2}
    assert report_from_json(json.loads(json.dumps(report.to_json()))).views == report.views
    text = write_markdown(report, results, tmp_path, {"config": {}}).read_text()
    assert "| camera views |" in text
    assert "| parallel_jaw | antipodal | point_cloud | 2 | 0.50" in text
    assert "| parallel_jaw | antipodal | ground_truth | - | 0.50" in text


def test_report_has_a_scan_vs_recipe_section_when_a_scan_and_its_twin_ran(tmp_path):
    results = _results({("003_cracker_box_scan", "antipodal"): 6, ("003_cracker_box", "antipodal"): 19})
    text = write_markdown(summarize(results), results, tmp_path, {"config": {}}).read_text()
    section = text[text.index("## Scan vs recipe"):]
    row = next(line for line in section.splitlines() if line.startswith("| parallel_jaw | antipodal | ground_truth"))
    assert "6/20" in row and "19/20" in row and "+65" in row and row.rstrip().endswith("| no | 3.9e-05 |")
    plain = _results({("025_mug", "antipodal"): 18})
    assert "Scan vs recipe" not in write_markdown(summarize(plain), plain, tmp_path, {"config": {}}).read_text()


def _two_planners() -> list[tuple[TrialKey, TrialResult]]:
    """Antipodal: force closure 1 and score 1 on every candidate, 16/20 succeed; random: closure 0 and score 0
    on every candidate, 2/20 succeed. Within each planner both metrics are constant; pooled, they only tell the
    planners apart."""
    out = []
    for planner, k, value in (("antipodal", 16, 1.0), ("random", 2, 0.0)):
        for i in range(20):
            result = TrialResult(Status.SUCCESS if i < k else Status.SLIPPED_LIFT,
                                 planned=GraspMetrics(2, value, 0.1 * value + 0.001 * i, 0.3), score=value)
            out.append((TrialKey("025_mug", "parallel_jaw", planner, "ground_truth", "standard", i), result))
    return out


def test_aucs_are_per_planner_and_a_constant_metric_is_undefined_not_chance(tmp_path):
    report = summarize(_two_planners())
    for planner in ("antipodal", "random"):
        per = report.auc[("parallel_jaw", planner, "ground_truth", "standard")]
        assert per["force_closure"].undefined == "metric constant" and math.isnan(per["force_closure"].auc)
        assert per["planner_score"].undefined == "metric constant" and per["planner_score"].n == 20
    # Pooled, a score constant per planner "predicts" success only by naming the planner (ties count one half).
    pooled = report.auc_pooled["planner_score"]
    assert pooled.auc == pytest.approx((16 * 18 + 0.5 * 2 * 18 + 0.5 * 16 * 4 + 0 * 2 * 4) / (18 * 22))
    # Within antipodal, epsilon rises with the index while successes are the first 16: AUC 0 (a worse ranking).
    antipodal = report.auc[("parallel_jaw", "antipodal", "ground_truth", "standard")]["epsilon_l1"]
    assert antipodal.auc == 0.0 and not antipodal.bounded  # 4 failures: too few for an interval ([0, 0] before)
    text = write_markdown(report, _two_planners(), tmp_path, RUN_META).read_text()
    assert "| parallel_jaw | antipodal | ground_truth | force_closure | 20 (16) | undefined (metric constant) |" in text
    assert "0.50" not in text.split("## Analytic metrics")[1].split("##")[0]


def test_report_leads_with_one_line_per_planner_and_labels_the_pooled_line(tmp_path):
    text = write_markdown(summarize(_two_planners()), _two_planners(), tmp_path, RUN_META).read_text()
    head = text.split("## Per hand and planner")[0]
    assert "- **parallel_jaw / antipodal: 16/20 successes, rate 0.80 [0.58, 0.92]**" in head
    assert "- **parallel_jaw / random: 2/20 successes" in head
    assert "Overall" not in text and "**Pooled" not in head
    assert f"Pooled ({POOLED}, 2 combinations, so it mixes planners): 18/40" in head
    one = _results({("025_mug", "antipodal"): 18})  # one planner: the pooled line claims no mixing
    head = write_markdown(summarize(one), one, tmp_path, RUN_META).read_text().split("## Per hand")[0]
    assert f"Pooled ({POOLED}, one combination, the line above): 18/20" in head and "mixes" not in head


def test_report_out_writes_the_report_elsewhere(tmp_path, capsys):
    run = make_run(tmp_path / "run", _results({("025_mug", "antipodal"): 18}))
    assert main(["report", str(run), "--out", str(tmp_path / "elsewhere")]) == 0
    assert f"report: {tmp_path / 'elsewhere' / 'report.md'}" in capsys.readouterr().out
    assert (tmp_path / "elsewhere" / "metric_auc.png").is_file() and _files(run) == ["results.sqlite", "run.json"]


def test_protocols_side_by_side_in_config_order_with_paired_outcomes(tmp_path):
    """20 grasps under two protocols: standard holds 14, six_direction 8, every grasp six_direction holds is also
    held by standard. The 6 discordant pairs all go one way: exact McNemar p = 2 * 0.5**6 = 0.03125."""
    from manigrasp.bench.markdown import paired_rows, protocol_order, protocol_rows

    results = [(TrialKey(obj, "inspire_right", "power", "ground_truth", protocol, i),
                TrialResult(Status.SUCCESS if i < held else Status.SLIPPED_LIFT,
                            grasp=PoseRecord.of(np.eye(4)) if i < 5 else PoseRecord()))  # 5 stored grasps per object
               for protocol, held in (("standard", 7), ("six_direction", 4)) for obj in ("025_mug", "004_sugar_box")
               for i in range(10)]
    report = summarize(results)
    meta = {"config": {"protocol": None, "protocols": [{"name": "standard", "params": {}}, {"name": "six_direction"}]}}
    order = protocol_order(report, meta)
    assert order == ["standard", "six_direction"] and report.protocols == ["six_direction", "standard"]
    assert protocol_order(report, {"config": {}}) == ["six_direction", "standard"]
    rows = protocol_rows(report, order)
    assert rows[0][3:] == ["all objects", "14/20, 0.70 [0.48, 0.85]", "8/20, 0.40 [0.22, 0.61]"]
    assert [r[3] for r in rows[1:]] == ["004_sugar_box", "025_mug"]
    (paired,) = paired_rows(report, results, order)
    assert paired[3:] == ["standard vs six_direction", 20, 10, 8, 6, 0, 6, "0.0312"]  # unstored grasps: not same
    text = write_markdown(report, results, tmp_path, meta).read_text()
    assert "| hand | planner | observation | protocol | trials |" in text
    assert "| inspire_right | power | ground_truth | standard | 025_mug | 10 | 7 |" in text
    single = summarize([r for r in results if r[0].protocol == "standard"])
    plain = write_markdown(single, results, tmp_path, {"config": {}}).read_text()
    assert "Protocols side by side" not in plain and "| protocol |" not in plain  # one protocol: as before
    # A harness fault (a bug of manigrasp) is neither outcome: its pair is left out, as the rates leave it out.
    faulty = [(k, TrialResult(Status.HARNESS_FAULT) if k.protocol == "six_direction" and k.grasp_index in (5, 6)
               else r) for k, r in results]
    (paired,) = paired_rows(summarize(faulty), faulty, order)
    assert paired[3:] == ["standard vs six_direction", 16, 10, 8, 2, 0, 6, "0.5"]


def test_an_interrupted_run_says_so_and_what_is_missing(tmp_path, capsys):
    """The config enumerates 2 objects x 2 planners x 20 grasps = 80 trials; the store holds the mug's 40 and 7 of
    the hammer's antipodal ones (a run killed there). The report says 47 of 80, names the partial and the missing
    group, and says the rates are over the stored trials; the complete run says nothing of the kind."""
    from manigrasp.bench.completeness import completeness
    from manigrasp.bench.config import parse_config
    from manigrasp.config import to_mapping

    config = to_mapping(parse_config({"name": "t", "objects": ["025_mug", "048_hammer"],
                                      "planners": ["antipodal", "random"]}))
    meta = {**RUN_META, "config": json.loads(json.dumps(config, default=str))}
    full = _results({("025_mug", "antipodal"): 18, ("025_mug", "random"): 4, ("048_hammer", "antipodal"): 9,
                     ("048_hammer", "random"): 1})
    assert completeness(full, meta).complete and completeness(full, meta).warning() == ""
    killed = [(k, r) for k, r in full if k.object == "025_mug" or (k.planner == "antipodal" and k.grasp_index < 7)]
    done = completeness(killed, meta)
    assert (done.expected, done.stored, done.unexpected) == (80, 47, 0) and not done.complete
    assert done.partial == ("048_hammer/parallel_jaw/antipodal/ground_truth/standard (7 of 20)",)
    assert done.not_run == ("048_hammer/parallel_jaw/random/ground_truth/standard",)
    run = make_run(tmp_path / "run", killed, meta)
    assert main(["report", str(run)]) == 0
    out = capsys.readouterr().out
    assert "WARNING: incomplete run: 47 of the 80 trials of its config are stored" in out
    assert "over the stored trials only" in out
    # First, as report.md has it (it came after the tables), and counted again after them.
    assert out.index("WARNING: incomplete run") < out.index("025_mug") < out.index("WARNING: 1 warning(s) printed")
    text = (run / "report.md").read_text()
    assert "**Warning: incomplete run: 47 of the 80 trials" in text and "(7 of 20)" in text
    assert main(["report", str(run), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["completeness"]["complete"] is False and payload["completeness"]["stored"] == 47
    complete = make_run(tmp_path / "complete", full, meta)
    assert main(["report", str(complete)]) == 0
    assert "WARNING" not in capsys.readouterr().out and "Warning" not in (complete / "report.md").read_text()
    assert main(["compare", str(run), str(complete)]) == 0  # the gate compares what is there, and says it
    assert f"note: the run {run}: incomplete run: 47 of the 80" in capsys.readouterr().out
    assert main(["report", str(run), "--json"]) == 0  # a baseline recorded from it says so in every compare
    (tmp_path / "base.json").write_text(capsys.readouterr().out)
    # The baseline holds the hammer's first 7 trials (all held) of 20: not compared with the run's 20 (9 held),
    # which read as a regression (exit 1); it is listed as held only in part.
    assert main(["compare", str(complete), str(tmp_path / "base.json")]) == 0
    out = capsys.readouterr().out
    assert "recorded from an incomplete run (47 of 80 trials stored)" in out
    assert "held only in part" in out and "048_hammer" in out.split("held only in part")[1]
    # a config that cannot be enumerated any more is said, not taken as complete
    gone = completeness(full, {"config": {**meta["config"], "objects": ["no_such_object"]}})
    assert gone.expected == -1 and "could not be enumerated" in gone.warning()


def test_a_run_resumed_by_other_code_says_so_in_the_report(tmp_path):
    results = _results({("025_mug", "antipodal"): 18})
    meta = {**RUN_META, "resumed_with_other_code": [{"at": "2026-01-02T00:00:00", "changes": ["mujoco 3.3 -> 4.0"]}]}
    text = write_markdown(summarize(results), results, tmp_path, meta).read_text()
    assert "**Warning: resumed at 2026-01-02T00:00:00 by other code (mujoco 3.3 -> 4.0)" in text
    # Entries count the trials the other code stored: 3 say so; 0 (a resumption that ran none) is no warning.
    for trials, warned in ((3, True), (0, False)):
        entry = {"at": "2026-01-03T00:00:00", "changes": ["manigrasp 0.1 -> 0.2"], "trials": trials}
        text = write_markdown(summarize(results), results, tmp_path, {**RUN_META, "resumed_with_other_code": [entry]}
                              ).read_text()
        assert ("by other code (manigrasp 0.1 -> 0.2): 3 trial(s) stored then" in text) == warned
        assert ("2026-01-03" in text) == warned


def test_header_says_which_hands_close_below_an_absolute_grip_force(tmp_path):
    """`grip_force: 500` on the parallel jaw (70.6 N) is capped by the close: the header said grip_force=500 alone."""
    from manigrasp.hands.registry import load

    results = [(TrialKey("025_mug", "parallel_jaw", "antipodal", "ground_truth", "standard", i),
                TrialResult(Status.SUCCESS)) for i in range(2)]
    strongest = load("parallel_jaw").max_grip_force
    for force, capped in ((500.0, True), (10.0, False)):
        meta = {"config": {"name": "t", "hands": ["parallel_jaw"],
                           "protocol": {"name": "standard", "params": {"grip_force": force}}}}
        text = write_markdown(summarize(results), results, tmp_path, meta).read_text()
        assert f"Protocol `standard` (grip_force={force})" in text
        assert (f"(grip_force={force:g} N is above a hand's force: parallel_jaw closes at its {strongest:.1f} N)"
                in text) == capped


def test_header_uses_the_grip_forces_the_run_recorded(tmp_path):
    """A run's header names the hands' forces recorded in its run.json when it started (`hand_grip_limits`), not
    those of the hand models installed when the report is made: a hand whose model changed since is described as
    it ran."""
    from manigrasp.bench import rundir
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.runner import grip_limits
    from manigrasp.hands.registry import load

    results = [(TrialKey("025_mug", "parallel_jaw", "antipodal", "ground_truth", "standard", i),
                TrialResult(Status.SUCCESS)) for i in range(2)]
    config = {"name": "t", "hands": ["parallel_jaw"], "protocol": {"name": "standard", "params": {"grip_force": 30.0}}}
    recorded = {"config": config, "hand_grip_limits": {"parallel_jaw": 12.5}}
    text = write_markdown(summarize(results), results, tmp_path, recorded).read_text()
    assert "parallel_jaw closes at its 12.5 N" in text  # the installed jaw's 70.6 N would say nothing at 30 N
    # A new run records each hand's force from the hand it loads; resuming keeps what was recorded.
    parsed = parse_config({"objects": ["025_mug"], "hands": ["parallel_jaw"], "planners": ["antipodal"]})
    meta = rundir.prepare(tmp_path / "run", parsed, grip_limits=grip_limits(parsed))
    assert meta["hand_grip_limits"] == {"parallel_jaw": load("parallel_jaw").max_grip_force}
    again = rundir.prepare(tmp_path / "run", parsed, grip_limits={"parallel_jaw": 1.0})
    assert again["hand_grip_limits"] == meta["hand_grip_limits"]

def test_header_names_each_protocols_and_planners_parameters_and_leads_in_config_order(tmp_path):
    """A run of `standard` at a 10 N grip is labelled `standard` in every table: the header says the 10 N. With
    several protocols the lead lines follow the config's order (standard, then lift), as the side-by-side table
    does, and the AUC caption names what one row is and what the pooled rows pool."""
    results = [(TrialKey("025_mug", "parallel_jaw", "antipodal", "ground_truth", protocol, i),
                TrialResult(Status.SUCCESS if i < held else Status.SLIPPED_LIFT))
               for protocol, held in (("standard", 7), ("lift", 9)) for i in range(10)]
    meta = {"config": {"name": "t", "protocol": None, "planners": [{"name": "antipodal", "params": {"top_k": 3}}],
                       "protocols": [{"name": "standard", "params": {"grip_force": 10.0}}, {"name": "lift"}]}}
    text = write_markdown(summarize(results), results, tmp_path, meta).read_text()
    assert "Protocols `standard` (grip_force=10.0), `lift`; planner `antipodal` (top_k=3)" in text
    assert "2 combinations, so it mixes protocols): 16/20" in text  # it said "of one planner"
    lead = "- **parallel_jaw / antipodal / "
    assert text.index(f"{lead}standard: 7/10") < text.index(f"{lead}lift: 9/10")
    assert "within one hand x planner x observation x protocol (0.5 = chance)" in text
    assert "Rows `all` pool every trial of every hand x planner x observation x protocol" in text


def test_a_group_that_failed_before_planning_adds_no_planning_call(monkeypatch):
    """A harness fault while setting up (the scene cannot be built) happens before the planner is called: its
    trials carry no planning time, so the report's median planning call counts calls that planned."""
    from manigrasp.bench import worker
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.trials import groups
    from manigrasp.errors import ConfigError

    def broken(group):
        raise ConfigError("no such scene")

    monkeypatch.setattr(worker, "scene_for", broken)
    (group,) = groups(parse_config({"objects": ["025_mug"], "grasps_per_object": 2}))
    plan = worker.plan_group(group)
    assert plan.status is Status.HARNESS_FAULT and "setting up" in plan.error
    results = [worker.run_trial(group, i, plan) for i in range(2)]
    assert all(math.isnan(r.plan_time_s) for _, r in results)
    assert summarize(results).by_method[("parallel_jaw", "antipodal", "ground_truth", "standard")].planning_calls == 0


def test_a_pose_is_judged_by_its_rotation_unless_its_object_has_a_symmetry(tmp_path, capsys):
    """A mug (no symmetry) estimated 177 deg off with ADD-S 1.2 mm is a wrong pose: the report counted it good, by
    ADD-S and translation alone, where the pipeline's own rule (`PoseErrors.success`) judges it by its rotation.
    A box turned 180 deg onto itself (a symmetry) is good, and its 180 deg stays out of the rotation figures."""
    rows = {"025_mug": (177.0, 0.0), "004_sugar_box": (180.0, 1.0), "005_tomato_soup_can": (2.0, 0.0)}
    results = [(TrialKey(obj, "parallel_jaw", "antipodal", "estimated_pose", "standard", i),
                TrialResult(Status.SUCCESS, pose_rotation_error_deg=rot, pose_translation_error_mm=0.2,
                            pose_add_s_mm=1.2, pose_symmetric=sym))
               for obj, (rot, sym) in rows.items() for i in range(2)]
    errors = summarize(results).pose_errors[("parallel_jaw", "antipodal", "estimated_pose", "standard")]
    assert errors.share_good == pytest.approx(2 / 3)  # the mug is not good
    assert (errors.objects, errors.symmetric, errors.unrecorded) == (3, 1, 0)
    assert (errors.median_rotation_deg, errors.p90_rotation_deg) == pytest.approx((89.5, 159.5))  # mug and can
    run = make_run(tmp_path / "run", results)
    assert main(["report", str(run)]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("pose errors"))
    assert "rotation median 89.5 deg (p90 159.5) over the 2 without a symmetry" in line
    assert "67% of 3 pose estimates (one per object, or object x resting pose; 1 with a symmetry) good" in line
    assert "| 3 (1 with a symmetry) | 89.5 / 159.5 | 0.2 / 0.2 | 1.2 | 0.67 |" in (run / "report.md").read_text()
    symmetric_only = [(k, r) for k, r in results if k.object == "004_sugar_box"]
    assert main(["report", str(make_run(tmp_path / "box", symmetric_only))]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("pose errors"))
    assert "rotation median" not in line and "100% of 1 pose estimate" in line  # no rotation figure to give
    assert "| 1 (1 with a symmetry) | - | 0.2 / 0.2 | 1.2 | 1.00 |" in (tmp_path / "box" / "report.md").read_text()


def test_pose_errors_count_estimates_of_resting_poses_not_objects(tmp_path, capsys):
    """Under ``rest: stable_k`` each object x resting pose is a group with its own estimate: two objects in two
    poses are 4 estimated poses (the line said "of 4 objects")."""
    results = [(TrialKey(f"{obj}@rest{k}", "parallel_jaw", "antipodal", "estimated_pose", "standard", 0),
                TrialResult(Status.SUCCESS, pose_rotation_error_deg=2.0, pose_translation_error_mm=0.2 + k,
                            pose_add_s_mm=1.0, pose_symmetric=0.0)) for obj in ("004_sugar_box", "025_mug")
               for k in range(2)]
    assert main(["report", str(make_run(tmp_path / "run", results))]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("pose errors"))
    assert "100% of 4 pose estimates (one per object, or object x resting pose)" in line


def test_failed_pose_estimates_are_counted_and_not_good(tmp_path, capsys):
    """Of three objects, two estimates failed (their trials planner_error "perception failed", no pose stored):
    the table read "share 1.00" over the one estimate left, with nothing saying two had failed."""
    results = []
    for obj, ok in (("a", True), ("b", False), ("c", False)):
        for i in range(2):
            r = (TrialResult(Status.SUCCESS, pose_rotation_error_deg=1.0, pose_translation_error_mm=0.2,
                             pose_add_s_mm=1.0, pose_symmetric=0.0) if ok else
                 TrialResult(Status.PLANNER_ERROR, detail="perception failed: estimated_pose of b: no model fits"))
            results.append((TrialKey(obj, "parallel_jaw", "antipodal", "estimated_pose", "standard", i), r))
    report = summarize(results)
    errors = report.pose_errors[("parallel_jaw", "antipodal", "estimated_pose", "standard")]
    assert (errors.objects, errors.failed) == (1, 2)
    assert errors.share_good == pytest.approx(1 / 3)
    assert report_from_json(json.loads(json.dumps(report.to_json()))).pose_errors == report.pose_errors
    old = json.loads(json.dumps(report.to_json()))
    del old["pose_errors"][0]["failed"]  # a report written before the count
    assert report_from_json(old).pose_errors[("parallel_jaw", "antipodal", "estimated_pose", "standard")].failed == 0
    run = make_run(tmp_path / "run", results)
    assert main(["report", str(run)]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("pose errors"))
    assert "33% of 3 pose estimates (one per object, or object x resting pose; 2 failed)" in line
    assert "| 3 (2 failed) |" in (run / "report.md").read_text()
    every = [(k, r) for k, r in results if k.object != "a"]  # every estimate failed: no figures, still counted
    errors = summarize(every).pose_errors[("parallel_jaw", "antipodal", "estimated_pose", "standard")]
    assert (errors.objects, errors.failed, errors.share_good) == (0, 2, 0.0)
    back = report_from_json(json.loads(json.dumps(summarize(every).to_json())))
    assert math.isnan(next(iter(back.pose_errors.values())).median_rotation_deg)  # not None
    run = make_run(tmp_path / "every", every)
    assert main(["report", str(run)]) == 0
    assert "every one of 2 pose estimates failed" in capsys.readouterr().out
    assert "| 2 (2 failed) | - | - | - | 0.00 |" in (run / "report.md").read_text()


def test_harness_faults_are_named_and_left_out_of_the_rates(tmp_path, capsys):
    """Two of 20 antipodal trials ended as harness_fault (a bug of manigrasp, not physics): they are left out
    of the physics statistics (DESIGN.md), so the rate is 16/18, not 16/20, with no harness_fault among the
    failure modes; the report says so first, naming the method."""
    results = _results({("025_mug", "antipodal"): 16, ("025_mug", "random"): 4})
    results = [(k, replace(r, status=Status.HARNESS_FAULT, detail="RuntimeError: bug"))
               if k.planner == "antipodal" and k.grasp_index >= 18 else (k, r) for k, r in results]
    run = make_run(tmp_path / "run", results)
    assert main(["report", str(run)]) == 0
    out = capsys.readouterr().out
    assert "WARNING: 2 trial(s) ended as harness_fault" in out and "(parallel_jaw / antipodal 2)" in out
    assert "**Warning: 2 trial(s) ended as harness_fault" in (run / "report.md").read_text()
    rate = next(r for m, r in summarize(results).by_method.items() if m[1] == "antipodal")
    assert (rate.trials, rate.successes, rate.harness_faults) == (18, 16, 2)
    assert "harness_fault" not in rate.failure_modes and sum(rate.failure_modes.values()) == 2
    clean = make_run(tmp_path / "clean", _results({("025_mug", "antipodal"): 16}))
    assert main(["report", str(clean)]) == 0
    assert "ended as harness_fault" not in capsys.readouterr().out


def test_a_metric_ranked_from_low_to_high_says_so_where_its_auc_is_shown(tmp_path, capsys):
    """min_friction (the least friction coefficient giving force closure) is ranked low-to-high: successes that
    needed mu 0.1 against failures that needed 0.8 give AUC 1.0, and every table names it "min_friction (lower =
    better)". Before, the bare name read as the AUC of the value itself (quick's 0.44 looked like a higher friction
    need going with success)."""
    results = [(key, replace(r, planned=GraspMetrics(2, 1.0, 0.1, 0.1 if r.success else 0.8)))
               for key, r in _results({("025_mug", "antipodal"): 12, ("025_mug", "random"): 5})]
    run = make_run(tmp_path / "run", results)
    report = summarize(results)
    assert report.auc[("parallel_jaw", "antipodal", "ground_truth", "standard")]["min_friction"].auc == 1.0
    assert main(["report", str(run)]) == 0
    out = capsys.readouterr().out
    rows = [" ".join(line.split()) for line in out.splitlines() if "min_friction" in line]
    assert [row.partition("min_friction")[2] for row in rows] == [
        " (lower = better) 20 (12) 1.00 [1.00, 1.00]", " (lower = better) 20 (5) 1.00 [1.00, 1.00]",
        " (lower = better) 40 (17) 1.00 [1.00, 1.00]"]
    text = (run / "report.md").read_text()
    assert text.count("| min_friction (lower = better) | 20 (12) | 1.00 [1.00, 1.00] |") == 1
    assert "| epsilon_l1 |" in text and "higher, or lower where it says so" in text
    assert main(["report", str(run), "--json"]) == 0  # the JSON (baselines) keeps the metric's key
    assert {a["metric"] for a in json.loads(capsys.readouterr().out)["auc"]} >= {"min_friction", "epsilon_l1"}


def test_every_table_and_plot_lists_the_protocols_in_the_configs_order(tmp_path, capsys):
    """dexterous lists standard, then six_direction: its lead lines did, but the tables, the plots' legends and bars
    listed six_direction first (sorted by name), so the first row under the lead line standard 14/20 was 8/20."""
    from manigrasp.bench.markdown import in_protocol_order

    results = [(TrialKey(obj, "inspire_right", "power", "ground_truth", protocol, i),
                TrialResult(Status.SUCCESS if i < held else Status.SLIPPED_LIFT))
               for protocol, held in (("standard", 7), ("six_direction", 4)) for obj in ("025_mug", "004_sugar_box")
               for i in range(10)]
    meta = {**RUN_META, "config": {**RUN_META["config"], "protocol": None,
                                   "protocols": [{"name": "standard", "params": {}}, {"name": "six_direction"}]}}
    run = make_run(tmp_path / "run", results, meta)
    report = summarize(results)
    ordered = in_protocol_order(report, ["standard", "six_direction"])
    assert [m[3] for m in ordered.by_method] == [m[3] for m in ordered.auc] == ["standard", "six_direction"]
    assert [g[3:] for g in ordered.groups] == [("standard", "004_sugar_box"), ("standard", "025_mug"),
                                                ("six_direction", "004_sugar_box"), ("six_direction", "025_mug")]
    assert ordered.by_method == report.by_method and ordered.groups == report.groups  # the same figures
    assert main(["report", str(run)]) == 0
    out = capsys.readouterr().out
    lines = [line for line in out.splitlines() if line.startswith("inspire_right")]
    assert [line.split()[3] for line in lines[:4]] == ["standard", "standard", "six_direction", "six_direction"]
    assert [line.split()[3] for line in lines[4:6]] == ["standard", "six_direction"]  # per hand and planner
    text = (run / "report.md").read_text()
    method_table = text.split("## Per hand and planner")[1]
    assert method_table.index("| standard | 20 | 14 |") < method_table.index("| six_direction | 20 | 8 |")
    assert text.index("| standard | 004_sugar_box | 10 | 7 |") < text.index("| six_direction | 004_sugar_box |")
    assert main(["report", str(run), "--json"]) == 0  # the JSON keeps its sorted order (baselines diff cleanly)
    assert [m["protocol"] for m in json.loads(capsys.readouterr().out)["methods"]] == ["six_direction", "standard"]


def test_the_header_names_the_pad_model_and_every_scene_parameter_off_its_default(tmp_path):
    """A run with `scene.pads=rigid` (the model of older figures) printed the very same header as one with the
    default compliant pads: nothing in report.md told the two apart. The header names the pad model always, and
    each other scene parameter that differs from this version's default."""
    from manigrasp.config import to_mapping
    from manigrasp.sim.config import SceneConfig

    results = _results({("025_mug", "antipodal"): 18})
    scene = json.loads(json.dumps(to_mapping(SceneConfig())))

    def header(**change):
        meta = {**RUN_META, "config": {**RUN_META["config"], "scene": {**scene, **change}}}
        return write_markdown(summarize(results), results, tmp_path, meta).read_text().splitlines()[2]

    assert "; scene: pads=compliant (every other scene parameter at its default), seed 0" in header()
    assert "; scene: pads=rigid (every other scene parameter at its default)" in header(pads="rigid")
    assert "; scene: pads=compliant, rest=stable_k, rest_k=3, timestep=0.001 (every other" in header(
        rest="stable_k", rest_k=3, timestep=0.001)


def test_a_ground_truth_line_names_its_observation_in_a_run_with_perception(tmp_path):
    """A run of ground truth beside estimated_pose: the lead line "parallel_jaw / antipodal: 5/6" read as the whole
    hand x planner (29/30 here), while it was the ground-truth trials alone. A run of ground truth alone keeps its
    short label."""
    from manigrasp.bench.markdown import lead_lines

    mixed = [(TrialKey("025_mug", "parallel_jaw", "antipodal", observation, "standard", i),
              TrialResult(Status.SUCCESS if i < 5 else Status.NO_CONTACT))
             for observation in ("ground_truth", "estimated_pose") for i in range(6)]
    lines = lead_lines(summarize(mixed))
    assert "parallel_jaw / antipodal / ground_truth: 5/6 successes, rate 0.83 [0.44, 0.97]" in lines
    assert any(line.startswith("parallel_jaw / antipodal / estimated_pose: 5/6") for line in lines)
    alone = [item for item in mixed if item[0].observation == "ground_truth"]
    assert lead_lines(summarize(alone)) == ["parallel_jaw / antipodal: 5/6 successes, rate 0.83 [0.44, 0.97]"]


@pytest.mark.parametrize(("k", "n", "table", "plot"), [
    (294, 400, "0.74", "74%"),  # 0.735: the float is 0.73499..., f"{:.2f}" gave 0.73 and the plot 74%
    (250, 400, "0.63", "63%"),  # 0.625 exactly: f"{:.2f}" rounds half to even, 0.62
    (34, 400, "0.09", "9%"),  # 0.085: the table read 0.09 and the plot 8%
    (1, 8, "0.13", "13%"),
    (0, 20, "0.00", "0%"),
    (20, 20, "1.00", "100%"),
])
def test_a_rate_reads_the_same_in_a_table_and_a_plot_rounded_half_up_from_its_counts(k, n, table, plot):
    from manigrasp.bench.report import Rate, format_rate, format_share
    from manigrasp.bench.stats import wilson_interval

    assert format_share(k, n) == table and format_share(k, n, percent=True) == plot
    rate = Rate(n, k, k / n, *wilson_interval(k, n))
    assert format_rate(rate).startswith(f"{table} [")


def test_wilson_bounds_print_by_the_same_rule():
    from fractions import Fraction

    from manigrasp.bench.report import Rate, format_rate, round_half_up

    assert round_half_up(0.125) == "0.13" and round_half_up(Fraction(-5, 8)) == "-0.63"
    assert round_half_up(Fraction(-1, 1000)) == "0.00" and round_half_up(Fraction(29, 2), 0) == "15"
    assert format_rate(Rate(8, 1, 0.125, 0.125, 0.625)) == "0.13 [0.13, 0.63]"


def test_report_json_lists_the_scan_vs_recipe_rows(tmp_path):
    results = _results({("003_cracker_box_scan", "antipodal"): 6, ("003_cracker_box", "antipodal"): 9})
    (row,) = json.loads(json.dumps(summarize(results).to_json(), allow_nan=False))["scan_vs_recipe"]
    assert row["scan"] == "003_cracker_box_scan" and row["object"] == "003_cracker_box"
    assert (row["scan_successes"], row["scan_trials"], row["recipe_successes"], row["recipe_trials"]) == (6, 20, 9, 20)
    assert row["gap_points"] == pytest.approx(15.0) and row["verdict"] == "no"
    assert row["fisher_p"] == pytest.approx(0.5145, abs=1e-4)
    plain = _results({("025_mug", "antipodal"): 18})
    assert summarize(plain).to_json()["scan_vs_recipe"] == []


def test_every_status_has_one_meaning_and_the_report_explains_those_of_its_run(tmp_path):
    from manigrasp.bench.report import STATUS_MEANINGS

    assert set(STATUS_MEANINGS) == set(Status)
    results = _results({("025_mug", "antipodal"): 18})
    results.append((TrialKey("025_mug", "parallel_jaw", "antipodal", "ground_truth", "standard", 20),
                    TrialResult(Status.DROPPED_PERTURB, detail="only 0 finger(s) touch the object at the end (need 2)",
                                last_phase="perturb")))
    text = write_markdown(summarize(results), results, tmp_path, RUN_META).read_text()
    legend = [line for line in text.splitlines() if line.startswith("- `")]
    assert [line.split("`")[1] for line in legend] == ["success", "no_contact", "dropped_perturb"]
    assert f"- `no_contact`: {STATUS_MEANINGS[Status.NO_CONTACT]}." in legend
    dropped = STATUS_MEANINGS[Status.DROPPED_PERTURB]
    assert "without one" in dropped and "fewer than 2 finger bodies touch it at the end" in dropped


def test_docs_results_lists_every_status_as_the_report_defines_it():
    from manigrasp.bench.report import STATUS_MEANINGS

    docs = " ".join((Path(__file__).parents[1] / "docs" / "results.md").read_text().split())
    for status, meaning in STATUS_MEANINGS.items():
        assert f"`{status.value}`: {meaning}" in docs, status


def test_the_auc_section_says_which_metrics_leave_out_trials_that_never_touched(tmp_path):
    results = _results({("025_mug", "antipodal"): 18})
    text = write_markdown(summarize(results), results, tmp_path, RUN_META).read_text()
    auc = text[text.index("## Analytic metrics"):]
    assert "`sim_epsilon_l1` is measured on the contacts the simulation produced" in auc
    assert "`pregrasp_collision`, `no_contact`" in auc and "touched the object only" in auc


def test_the_planning_time_note_says_a_call_without_candidates_is_not_divided(tmp_path):
    results = _results({("025_mug", "antipodal"): 18})
    text = " ".join(write_markdown(summarize(results), results, tmp_path, RUN_META).read_text().split())
    assert "divided by the number of candidates it returned, or the whole call where it returned none" in text


def test_the_plots_of_a_run_without_trials_are_drawn_empty(tmp_path):
    """A run stopped while planning stores no trial: its report (and the per-object plot, which lays out one panel
    per hand x planner) still comes out, with an empty panel, instead of failing on zero panels."""
    from manigrasp.bench.plots import success_by_object

    path = success_by_object(summarize([]), tmp_path / "success_by_object.png")
    assert path.is_file() and path.stat().st_size > 0
