"""Report and compare on stored results with known counts."""

from __future__ import annotations

import json

import pytest

from manigrasp.bench.compare import compare
from manigrasp.bench.markdown import write_markdown
from manigrasp.bench.report import report_from_json, summarize
from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.cli import main
from manigrasp.protocol.result import GraspMetrics, Status, TrialResult


def _results(successes: dict[tuple[str, str], int], n: int = 20) -> list[tuple[TrialKey, TrialResult]]:
    """n trials per (object, planner); the first `k` succeed; epsilon is high exactly on successes."""
    out = []
    for (obj, planner), k in successes.items():
        for i in range(n):
            ok = i < k
            status = Status.SUCCESS if ok else (Status.DROPPED_PERTURB if i % 2 else Status.NO_CONTACT)
            result = TrialResult(status, detail="+x" if status is Status.DROPPED_PERTURB else "",
                                 planned=GraspMetrics(2, float(ok), 0.2 if ok else 0.01, 0.2),
                                 planning_time_s=0.01, score=float(i % 3), seed=i)
            out.append((TrialKey(obj, "parallel_jaw", planner, "ground_truth", "standard", i), result))
    return out


def test_summary_counts_rates_intervals_and_modes():
    report = summarize(_results({("025_mug", "antipodal"): 18, ("025_mug", "random"): 4}))
    mug = report.groups[("parallel_jaw", "antipodal", "ground_truth", "025_mug")]
    assert (mug.trials, mug.successes, mug.success_rate) == (20, 18, 0.9)
    assert mug.ci_low == pytest.approx(0.699, abs=1e-3) and mug.ci_high == pytest.approx(0.972, abs=1e-3)
    random = report.by_method[("parallel_jaw", "random", "ground_truth")]
    assert random.failure_modes == {"dropped_perturb+x": 8, "no_contact": 8}
    assert report.overall.trials == 40 and report.overall.successes == 22
    assert report.auc["epsilon_l1"] == 1.0  # epsilon separates successes perfectly here
    assert report.auc["force_closure"] == 1.0
    assert 0.3 < report.auc["planner_score"] < 0.7  # a score unrelated to the outcome is near chance


def test_report_json_round_trips():
    report = summarize(_results({("025_mug", "antipodal"): 18}))
    again = report_from_json(json.loads(json.dumps(report.to_json())))
    assert again.groups == report.groups and again.overall == report.overall


def test_compare_flags_a_drop_and_passes_equal_rates():
    base = summarize(_results({("025_mug", "antipodal"): 18, ("048_hammer", "antipodal"): 17}, n=40))
    same = summarize(_results({("025_mug", "antipodal"): 18, ("048_hammer", "antipodal"): 16}, n=40))
    worse = summarize(_results({("025_mug", "antipodal"): 5, ("048_hammer", "antipodal"): 17}, n=40))
    assert not any(c.regression for c in compare(same, base))
    flagged = {c.group for c in compare(worse, base) if c.regression}
    assert flagged == {"overall", "parallel_jaw/antipodal/ground_truth/025_mug"}


def test_report_and_compare_cli(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "run.json").write_text(json.dumps({"config": {"name": "t", "protocol": {"name": "standard"}}, "seed": 0}))
    with ResultsStore(run / "results.sqlite") as store:
        for key, result in _results({("025_mug", "antipodal"): 18, ("025_mug", "random"): 4}):
            store.add(key, result)
    assert main(["report", str(run), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    group = next(g for g in payload["groups"] if g["planner"] == "antipodal")
    assert {"hand", "planner", "object", "trials", "successes", "success_rate", "ci_low", "ci_high"} <= set(group)
    assert (run / "report.md").is_file() and (run / "success_by_object.png").stat().st_size > 1000
    baseline = tmp_path / "baseline.json"
    baseline.write_text(json.dumps(payload))
    assert main(["compare", str(run), str(baseline)]) == 0
    worse = dict(payload)
    worse["groups"] = [dict(g, successes=g["trials"]) for g in payload["groups"]]
    worse["overall"] = dict(payload["overall"], successes=payload["overall"]["trials"])
    baseline.write_text(json.dumps(worse))
    assert main(["compare", str(run), str(baseline)]) == 1
    assert "REGRESSION" in capsys.readouterr().out


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
    errors = report.pose_errors[("parallel_jaw", "antipodal", "estimated_pose")]
    assert (errors.objects, errors.median_rotation_deg, errors.median_translation_mm) == (3, 2.0, 4.0)
    assert errors.median_add_s_mm == 4.0
    assert errors.share_within_5deg_1cm == pytest.approx(2 / 3)
    assert ("parallel_jaw", "antipodal", "ground_truth") not in report.pose_errors
    assert report_from_json(json.loads(json.dumps(report.to_json()))).pose_errors == report.pose_errors
    text = write_markdown(report, results, tmp_path, {"config": {}}).read_text()
    assert "Observations side by side" in text and "estimated_pose" in text
