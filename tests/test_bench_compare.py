"""The regression gate: flags real drops, names what it does not compare, refuses what it cannot judge."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
from pathlib import Path

import pytest
from test_bench_report import RUN_META, _results, make_run

from manigrasp.bench.compare import POOLED_GROUP, compare, load_side
from manigrasp.bench.report import summarize
from manigrasp.cli import main
from manigrasp.errors import ConfigError

BASELINE = Path(__file__).resolve().parents[1] / "benchmarks" / "baselines" / "quick.json"


def test_compare_flags_a_drop_and_passes_equal_rates():
    base = summarize(_results({("025_mug", "antipodal"): 18, ("048_hammer", "antipodal"): 17}, n=40))
    same = summarize(_results({("025_mug", "antipodal"): 18, ("048_hammer", "antipodal"): 16}, n=40))
    worse = summarize(_results({("025_mug", "antipodal"): 5, ("048_hammer", "antipodal"): 17}, n=40))
    assert not compare(same, base).regressions
    flagged = {c.group for c in compare(worse, base).regressions}
    # 22/80 vs 35/80 for the planner: z = -2.15, p = 0.016; the mug alone 5/40 vs 18/40.
    assert flagged == {POOLED_GROUP, "parallel_jaw/antipodal/ground_truth/standard (objects in both)",
                       "parallel_jaw/antipodal/ground_truth/standard/025_mug"}


def test_only_groups_in_both_are_compared_and_the_others_are_named():
    """A one-object run against a two-object baseline: the pooled line covers the mug only, the hammer is listed.
    Before, 'overall' pooled the baseline's hammer too, and the missing object went unnamed."""
    base = summarize(_results({("025_mug", "antipodal"): 18, ("048_hammer", "antipodal"): 2}))
    new = summarize(_results({("025_mug", "antipodal"): 18, ("011_banana", "antipodal"): 20}))
    verdict = compare(new, base)
    pooled = verdict.comparisons[0]
    assert pooled.group == POOLED_GROUP and (pooled.new.trials, pooled.base.trials) == (20, 20)
    assert pooled.new.successes == pooled.base.successes == 18
    assert verdict.only_base == [("parallel_jaw", "antipodal", "ground_truth", "standard", "048_hammer")]
    assert verdict.only_new == [("parallel_jaw", "antipodal", "ground_truth", "standard", "011_banana")]
    assert [c.group for c in verdict.comparisons[1:]] == [
        "parallel_jaw/antipodal/ground_truth/standard (objects in both)",
        "parallel_jaw/antipodal/ground_truth/standard/025_mug"]
    assert verdict.comparisons[1].new.trials == 20 and verdict.groups_compared == 1


def test_a_run_with_zero_trials_or_no_common_group_cannot_pass():
    base = summarize(_results({("025_mug", "antipodal"): 18}))
    with pytest.raises(ConfigError, match="no trials"):
        compare(summarize([]), base)
    with pytest.raises(ConfigError, match="no hand/planner/observation/protocol/object group is in both.*048_hammer"):
        compare(summarize(_results({("048_hammer", "antipodal"): 18})), base)


@pytest.mark.parametrize("alpha", [-1.0, 0.0, 1.0, 1.5, math.nan, math.inf])
def test_alpha_outside_zero_one_is_refused(alpha):
    report = summarize(_results({("025_mug", "antipodal"): 18}))
    with pytest.raises(ConfigError, match="alpha must be"):
        compare(report, report, alpha)


@pytest.fixture
def run_and_payload(tmp_path, capsys):
    run = make_run(tmp_path / "run", _results({("025_mug", "antipodal"): 18, ("048_hammer", "antipodal"): 10}))
    assert main(["report", str(run), "--json"]) == 0
    return run, json.loads(capsys.readouterr().out)


def _gate(tmp_path, run, payload, *extra) -> int:
    path = tmp_path / "baseline.json"
    path.write_text(payload if isinstance(payload, str) else json.dumps(payload))
    return main(["compare", str(run), str(path), *extra])


def test_compare_cli_passes_itself_flags_a_drop_and_lists_missing_groups(tmp_path, capsys, run_and_payload):
    run, payload = run_and_payload
    assert _gate(tmp_path, run, payload) == 0
    worse = copy.deepcopy(payload)
    worse["groups"] = [dict(g, successes=g["trials"]) for g in payload["groups"]]
    assert _gate(tmp_path, run, worse) == 1
    assert "REGRESSION" in capsys.readouterr().out
    more = copy.deepcopy(payload)
    more["groups"].append(dict(payload["groups"][0], object="011_banana"))
    assert _gate(tmp_path, run, more) == 0
    out = capsys.readouterr().out
    assert ("1 group(s) in the baseline only (not compared): parallel_jaw/antipodal/ground_truth/standard/011_banana"
            in out)


def test_a_baselines_rates_are_its_counts_not_the_figures_it_stores(tmp_path, capsys, run_and_payload):
    """A baseline whose counts were edited (or written by other code) but not its rate showed "20/20 = 0.90
    [0.70, 0.97]": the figures shown are computed from the counts the tests use."""
    run, payload = run_and_payload
    edited = copy.deepcopy(payload)
    edited["groups"] = [dict(g, successes=g["trials"]) if g["object"] == "025_mug" else g for g in edited["groups"]]
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(edited))
    mug = next(r for g, r in load_side(path).report.groups.items() if g[-1] == "025_mug")
    assert (mug.trials, mug.successes, mug.success_rate) == (20, 20, 1.0)
    assert mug.ci_low == pytest.approx(0.839, abs=1e-3) and mug.ci_high == 1.0
    assert _gate(tmp_path, run, edited) == 0  # 18/20 against 20/20: p = 0.15 after Holm, no regression
    assert "20/20 = 1.00 [0.84, 1.00]" in capsys.readouterr().out


@pytest.mark.parametrize("broken, message", [
    (lambda p: p["groups"][0].update(successes=25), "25 successes of 20 trials"),
    (lambda p: p["groups"][0].update(trials=None), "18 successes of nan trials"),
    (lambda p: p["groups"][0].update(trials=-3, successes=-5), "not counts"),
    (lambda p: p["groups"][0].update(trials=20.5), "not counts"),
    (lambda p: p.pop("groups"), "not a valid report"),
    (lambda p: p["groups"][0].pop("hand"), "not a valid report"),
    (lambda p: p.pop("run"), "records no config"),
    (lambda p: p["run"]["config"]["protocol"].update(name="lift"),
     'different protocol.name ("standard" vs baseline "lift")'),
    (lambda p: p["run"]["config"]["protocol"]["params"].update(perturb_force_factor=2.0),
     "different protocol.params.perturb_force_factor (absent vs baseline 2.0)"),
    (lambda p: p["run"]["config"]["scene"].update(timestep=0.001),
     "different scene.timestep (0.002 vs baseline 0.001)"),
    (lambda p: p["run"]["config"].update(hands=[{"name": "parallel_jaw", "params": {"max_width": 0.1}}]),
     "different hand 'parallel_jaw'"),
])
def test_compare_cli_refuses_a_baseline_it_cannot_judge(tmp_path, capsys, run_and_payload, broken, message):
    run, payload = run_and_payload
    broken(payload)
    assert _gate(tmp_path, run, payload) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_compare_cli_refuses_nan_trials_written_as_json_nan(tmp_path, capsys, run_and_payload):
    run, payload = run_and_payload
    text = json.dumps(payload).replace('"trials": 20', '"trials": NaN', 1)
    assert _gate(tmp_path, run, text) == 2
    assert "not counts" in capsys.readouterr().err


@pytest.mark.parametrize("garbage", ["{not json", "[1, 2]", "\udcff", ""])
def test_compare_cli_on_a_malformed_baseline_is_exit_2_not_a_traceback(tmp_path, capsys, run_and_payload, garbage):
    run, _ = run_and_payload
    path = tmp_path / "baseline.json"
    path.write_bytes(garbage.encode("utf-8", "surrogateescape"))
    assert main(["compare", str(run), str(path)]) == 2
    assert "baseline" in capsys.readouterr().err


def test_compare_cli_on_missing_paths_is_exit_2(tmp_path, capsys, run_and_payload):
    run, _ = run_and_payload
    assert main(["compare", str(run), str(tmp_path / "nope.json")]) == 2
    assert main(["compare", str(tmp_path / "nope"), str(run)]) == 2
    assert capsys.readouterr().err.count("does not exist") == 2


@pytest.mark.parametrize("alpha", ["-1", "nan", "0"])
def test_compare_cli_alpha_is_checked(tmp_path, capsys, run_and_payload, alpha):
    run, payload = run_and_payload
    assert _gate(tmp_path, run, payload, "--alpha", alpha) == 2
    assert "alpha must be a number strictly between 0 and 1" in capsys.readouterr().err


def test_compare_cli_on_an_empty_run_is_exit_2(tmp_path, capsys, run_and_payload):
    _, payload = run_and_payload
    empty = make_run(tmp_path / "empty", [])
    assert _gate(tmp_path, empty, payload) == 2
    assert "the new run has no trials" in capsys.readouterr().err


def test_version_differences_are_noted_not_refused(tmp_path, capsys, run_and_payload):
    run, payload = run_and_payload
    payload["run"]["versions"]["mujoco"] = "3.3.0"
    assert _gate(tmp_path, run, payload) == 0
    assert "note: mujoco 4.0.0 here vs 3.3.0 in the baseline" in capsys.readouterr().out


def test_the_committed_baseline_is_valid_records_its_config_and_passes_against_itself():
    side = load_side(BASELINE)
    config = side.meta["config"]
    assert config["name"] == "quick" and {"protocol", "scene", "hands", "objects"} <= set(config)
    assert side.meta["versions"]["mujoco"] and len(side.report.groups) == 10
    assert main(["compare", str(BASELINE), str(BASELINE)]) == 0


@pytest.mark.parametrize("change, message", [
    (lambda c: c.update(grasps_per_object=40), "different grasps_per_object (20 vs baseline 40)"),
    (lambda c: c["planners"][0]["params"].update(top_k=3), "different planner 'antipodal'.params.top_k"),
])
def test_the_gate_refuses_another_draw_of_candidates_or_another_planner(tmp_path, capsys, change, message):
    """A ranked planner's first 40 candidates are not the population of its first 20, and antipodal with other
    parameters is another method: comparing their rates would gate on the config, not the code. (A baseline of
    the same config still passes: the committed baseline against itself, above.)"""
    payload = json.loads(BASELINE.read_text())
    change(payload["run"]["config"])
    other = tmp_path / "other.json"
    other.write_text(json.dumps(payload))
    assert main(["compare", str(BASELINE), str(other)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_a_parameter_written_out_at_its_default_is_the_same_config(tmp_path, capsys):
    """A config that writes out a protocol's or planner's default value runs what one leaving it out runs: the gate
    compares them (it refused them as different configs); a parameter this code does not know is compared as
    recorded, and any other value still differs."""
    payload = json.loads(BASELINE.read_text())
    payload["run"].pop("effective", None)  # a baseline recorded before run.json held `effective`
    old = tmp_path / "old_baseline.json"
    old.write_text(json.dumps(payload))
    config = payload["run"]["config"]
    config["protocol"]["params"].update(lift_height=0.1, finger_hold="balanced")
    config["planners"][0]["params"].update(n_samples=2048, depth_fractions=[0.0, 0.4, 0.8])
    other = tmp_path / "other.json"
    other.write_text(json.dumps(payload))
    assert main(["compare", str(old), str(other)]) == 0
    config["protocol"]["params"]["finger_hold_joints"] = False  # no longer a parameter
    other.write_text(json.dumps(payload))
    assert main(["compare", str(old), str(other)]) == 2
    assert "protocol.params.finger_hold_joints" in capsys.readouterr().err
    del config["protocol"]["params"]["finger_hold_joints"]
    config["planners"][0]["params"]["n_samples"] = 1024
    other.write_text(json.dumps(payload))
    assert main(["compare", str(old), str(other)]) == 2
    assert "planner 'antipodal'.params.n_samples (2048 vs baseline 1024)" in capsys.readouterr().err


def test_the_defaults_a_run_recorded_are_compared_not_this_codes(tmp_path, capsys):
    """A baseline whose run.json recorded the values its code ran with (``effective``) is compared on them: a
    default changed since (antipodal's n_samples 1024 then, 2048 now) is a different planner, where without the
    record both sides read as this code's and pass. A recorded parameter this code no longer knows is ignored,
    as one it added since is at its default on both sides."""
    payload = json.loads(BASELINE.read_text())
    payload["run"].pop("effective", None)  # a baseline recorded before run.json held `effective`
    old = tmp_path / "old_baseline.json"
    old.write_text(json.dumps(payload))
    assert "n_samples" not in payload["run"]["config"]["planners"][0]["params"]
    other = tmp_path / "other.json"
    other.write_text(json.dumps(payload))
    assert main(["compare", str(old), str(other)]) == 0
    payload["run"]["effective"] = {"planners": {"antipodal": {"name": "antipodal", "params": {"n_samples": 1024}}},
                                   "protocols": {"standard": {"name": "standard",
                                                              "params": {"finger_hold_joints": False}}}}
    other.write_text(json.dumps(payload))
    assert main(["compare", str(old), str(other)]) == 2
    err = capsys.readouterr().err
    assert "planner 'antipodal'.params.n_samples (2048 vs baseline 1024)" in err and "finger_hold" not in err
    payload["run"]["effective"]["planners"]["antipodal"]["params"]["n_samples"] = 2048
    other.write_text(json.dumps(payload))
    assert main(["compare", str(old), str(other)]) == 0


def test_a_new_run_records_every_parameter_it_runs_with_and_its_baseline_carries_them(tmp_path, capsys):
    """run.json's ``effective``: each built-in protocol and planner by label with all its parameters, those the
    config leaves out at this code's defaults; `report --json` (the baseline format) keeps it; a user's
    ``module:attribute`` planner is left out (not imported to be recorded)."""
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.rundir import prepare
    from manigrasp.planners.antipodal import AntipodalPlanner
    from manigrasp.protocol.standard import StandardParams

    config = parse_config({"name": "t", "objects": ["025_mug"], "planners": [
        {"name": "antipodal", "params": {"n_approaches": 3}}, "random", "conftest:NoSuchPlanner"],
        "protocols": [{"name": "standard", "params": {"grip_force": 10.0}}, "six_direction"]})
    meta = prepare(tmp_path / "run", config)
    effective = json.loads((tmp_path / "run" / "run.json").read_text())["effective"]
    assert effective == meta["effective"] and set(effective["planners"]) == {"antipodal", "random"}
    antipodal = effective["planners"]["antipodal"]["params"]
    assert antipodal["n_approaches"] == 3 and antipodal["n_samples"] == AntipodalPlanner().n_samples
    standard = effective["protocols"]["standard"]["params"]
    assert standard["grip_force"] == 10.0 and standard["lift_height"] == StandardParams().lift_height
    assert set(effective["protocols"]) == {"standard", "six_direction"}
    make_run(tmp_path / "run", _results({("025_mug", "antipodal"): 18}),
             meta=json.loads((tmp_path / "run" / "run.json").read_text()))
    assert main(["report", str(tmp_path / "run"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["run"]["effective"] == effective


def test_a_dataclass_parameter_written_out_at_its_default_is_the_same_config(tmp_path):
    """dexopt's `weights` written out in whole numbers (as YAML gives them) equal its defaults (they were compared
    as the text of the dataclass, 100 against 100.0); another weight differs."""
    baseline = BASELINE.parent / "dexterous.json"
    payload = json.loads(baseline.read_text())
    dexopt = next(p for p in payload["run"]["config"]["planners"] if p["name"] == "dexopt")
    dexopt["params"]["weights"] = {"force_closure": 1, "distance": 100, "penetration": 100, "table": 100,
                                   "joints": 10, "self_penetration": 100, "centroid": 10}
    payload["run"].pop("effective", None)  # compared as the config writes it (a run records both together)
    other = tmp_path / "other.json"
    other.write_text(json.dumps(payload))
    assert main(["compare", str(baseline), str(other)]) == 0
    dexopt["params"]["weights"]["centroid"] = 1
    other.write_text(json.dumps(payload))
    assert main(["compare", str(baseline), str(other)]) == 2


def test_cameras_must_match_only_where_perception_groups_are_compared(tmp_path, capsys):
    payload = json.loads(BASELINE.read_text())
    payload["run"]["config"]["camera"] = {"views": 2}
    other = tmp_path / "other.json"
    other.write_text(json.dumps(payload))
    assert main(["compare", str(BASELINE), str(other)]) == 0  # ground truth only: no camera in play
    for side in (payload, json.loads(BASELINE.read_text())):
        for g in side["groups"]:
            g["observation"] = "point_cloud"
    seen = tmp_path / "seen.json"
    seen.write_text(json.dumps(side))
    other.write_text(json.dumps(payload))
    assert main(["compare", str(seen), str(other)]) == 2
    assert "different camera" in capsys.readouterr().err


def test_the_verdict_line_counts_groups_lines_and_the_pooled_test_apart(tmp_path, capsys, run_and_payload):
    """Mug 18/20 and hammer 10/20 against a baseline whose hammer held 20/20: the hammer, the planner's line (28/40
    vs 38/40) and the pooled line regress. Before, the last line said "3 significant regression(s) ... over 2
    group(s) in both", as if 3 of 2 groups had dropped."""
    run, payload = run_and_payload
    better = copy.deepcopy(payload)
    better["groups"] = [dict(g, successes=20) if g["object"] == "048_hammer" else g for g in payload["groups"]]
    assert _gate(tmp_path, run, better) == 1
    out = capsys.readouterr().out.strip().splitlines()
    assert out[-1] == ("3 significant regression(s) at alpha = 0.05: 1 of the 2 hand x planner x observation x "
                       "protocol x object group(s) in both, 1 of the 1 hand x planner x observation x protocol "
                       "line(s) over their groups in both, and the pooled line (pooled (groups in both))")
    assert out[-2].startswith("p (adjusted): one-sided; Holm-adjusted across the")
    assert sum(line.endswith("REGRESSION") for line in out) == 3
    assert _gate(tmp_path, run, payload) == 0
    assert capsys.readouterr().out.strip().splitlines()[-1].endswith(
        "0 of the 2 hand x planner x observation x protocol x object group(s) in both, 0 of the 1 hand x planner x "
        "observation x protocol line(s) over their groups in both, not the pooled line (pooled (groups in both))")


def test_a_different_mix_of_groups_alone_is_no_regression():
    """Every group's rate equal on both sides, but the run lost most trials of its easy objects to harness faults
    (left out of every count): the pooled counts fall from 64/100 to 10/46 and were flagged (p < 1e-6); the lines
    are tested stratified by group and see no drop. A real drop in one group is still found by them."""
    from manigrasp.protocol.result import Status, TrialResult

    easy = {"025_mug": 20, "011_banana": 20, "005_tomato_soup_can": 20}
    hard = {"048_hammer": 2, "004_sugar_box": 2}
    base = summarize(_results({(o, "antipodal"): k for o, k in {**easy, **hard}.items()}))
    faults = []
    for key, result in _results({(o, "antipodal"): k for o, k in {**easy, **hard}.items()}):
        if key.object in easy and key.grasp_index >= 2:
            result = TrialResult(Status.HARNESS_FAULT, detail="worker died")
        faults.append((key, result))
    run = summarize(faults)
    verdict = compare(run, base)
    pooled = verdict.comparisons[0]
    assert (pooled.new.successes, pooled.new.trials) == (10, 46)  # the pooled counts are shown as they are
    assert not verdict.regressions and pooled.test.p_value == pytest.approx(0.5)
    dropped = summarize(_results({**{(o, "antipodal"): k for o, k in easy.items()}, ("048_hammer", "antipodal"): 2,
                                  ("004_sugar_box", "antipodal"): 2, ("025_mug", "antipodal"): 8}))
    assert {c.kind for c in compare(dropped, base).regressions} == {"pooled", "method", "group"}


def test_the_stratified_test_is_the_cochran_mantel_haenszel_statistic():
    """Two strata worked by hand: (8/10 vs 9/10) and (3/20 vs 10/20). E = 10*17/20 + 20*13/40 = 15.0, observed
    11; Var = 10*10*17*3/(400*19) + 20*20*13*27/(1600*39) = 0.67105 + 2.25 = 2.92105; Z = -4/sqrt(2.92105)."""
    from scipy.stats import norm

    from manigrasp.bench.stats import stratified_lower_than_baseline

    test = stratified_lower_than_baseline([(8, 10, 9, 10), (3, 20, 10, 20)])
    z = -4 / math.sqrt(10 * 10 * 17 * 3 / (400 * 19) + 20 * 20 * 13 * 27 / (1600 * 39))
    assert test.z == pytest.approx(z) and test.p_value == pytest.approx(norm.cdf(z))
    assert test.difference == pytest.approx((5 * -0.1 + 10 * -0.35) / 15)  # Mantel-Haenszel weights n m / (n + m)
    assert stratified_lower_than_baseline([(5, 5, 5, 5)]).p_value == 1.0  # no variance: nothing to judge


def test_groups_held_only_in_part_are_listed_not_compared(tmp_path, capsys):
    """An interrupted run holds the first 5 of the hammer's 20 trials (a ranked planner's best): they were
    compared with the baseline's 20 (5/5 vs 9/20). They are listed; the complete mug is compared."""
    full = _results({("025_mug", "antipodal"): 18, ("048_hammer", "antipodal"): 9})
    meta = {**RUN_META, "config": {**RUN_META["config"], "grasps_per_object": 20}}
    base = make_run(tmp_path / "base", full, meta)
    cut = [(k, r) for k, r in full if k.object == "025_mug" or k.grasp_index < 5]
    run = make_run(tmp_path / "run", cut, meta)
    assert main(["compare", str(run), str(base)]) == 0
    out = capsys.readouterr().out
    assert "1 group(s) held only in part by one side" in out and "048_hammer" in out.split("held only in part")[1]
    assert "0 of the 1 " in out  # one group compared: the mug
    only_hammer = make_run(tmp_path / "run2", [(k, r) for k, r in cut if k.object == "048_hammer"], meta)
    assert main(["compare", str(only_hammer), str(base)]) == 2
    assert "held only in part" in capsys.readouterr().err


def test_a_baseline_listing_a_group_twice_is_refused(tmp_path):
    data = json.loads(BASELINE.read_text())
    data["groups"].append(copy.deepcopy(data["groups"][0]))
    path = tmp_path / "twice.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ConfigError, match="listed more than once"):
        load_side(path)


def test_a_baselines_harness_faults_are_noted_as_a_runs_are(tmp_path, capsys):
    """5 of a baseline group's trials were harness faults (left out of its counts): the run's side said so, the
    baseline's did not."""
    from manigrasp.protocol.result import Status, TrialResult

    results = [(k, TrialResult(Status.HARNESS_FAULT, detail="worker died") if k.grasp_index >= 15 else r)
               for k, r in _results({("025_mug", "antipodal"): 10})]
    base_run = make_run(tmp_path / "base", results)
    assert main(["report", str(base_run), "--json"]) == 0
    baseline = tmp_path / "base.json"
    baseline.write_text(capsys.readouterr().out)
    assert any("5 trial(s) ended as harness_fault" in w for w in load_side(baseline).warnings)
    clean = load_side(make_run(tmp_path / "clean", _results({("025_mug", "antipodal"): 10})))
    assert not any("harness_fault" in w for w in clean.warnings)


def test_recorded_parameters_are_the_planners_own_not_its_caches():
    """A partial `weights` of dexopt changes only the terms it names (the others keep the planner's defaults, not
    `EnergyWeights`' own: `weights: {distance: 50}` ran with the centroid at 0, not the planner's), and the planner's
    caches (fields not set at construction) are not recorded as parameters."""
    from manigrasp.bench.config import effective_entry
    from manigrasp.planners.dexopt_planner import DEFAULT_WEIGHTS

    params = effective_entry({"name": "dexopt", "params": {"weights": {"distance": 50}}}, "planner")["params"]
    assert "_hands" not in params and "last" not in params
    assert params["weights"] == {**dataclasses.asdict(DEFAULT_WEIGHTS), "distance": 50}


@pytest.mark.parametrize("baseline", ["quick.json", "dexterous.json"])
def test_a_run_as_good_as_its_baseline_fails_the_gate_less_often_than_alpha(baseline):
    """Both sides drawn at the committed baseline's own group rates (the null hypothesis): the gate fails if any
    line flags, and with each family (pooled, methods, groups) at the whole alpha it failed 8.6 % of such pairs
    at alpha 0.05. Seeded: the same draws every run."""
    import numpy as np

    from manigrasp.bench.report import Rate, Report
    from manigrasp.bench.stats import wilson_interval

    payload = json.loads((BASELINE.parent / baseline).read_text())
    counts = {(g["hand"], g["planner"], g["observation"], g["protocol"], g["object"]): (g["successes"], g["trials"])
              for g in payload["groups"]}
    rng = np.random.default_rng(0)

    def draw() -> Report:
        groups = {}
        for key, (s, n) in counts.items():
            k = int(rng.binomial(n, s / n))
            groups[key] = Rate(n, k, k / n, *wilson_interval(k, n))
        return Report(overall=Rate(0, 0, 0.0, 0.0, 1.0), by_method={}, groups=groups)

    draws = 600
    failed = sum(bool(compare(draw(), draw(), alpha=0.05).regressions) for _ in range(draws))
    assert failed / draws < 0.05


def test_a_family_that_repeats_anothers_tests_takes_no_share_of_alpha():
    """One method of one group: the pooled, method and group lines are one test, and each was tested at a third of
    alpha (26/40 against 34/40: p = 0.02 on each line, adjusted to 0.06, no regression at 0.05)."""
    from manigrasp.bench.report import Rate, Report
    from manigrasp.bench.stats import wilson_interval

    def report(successes: int, objects: tuple[str, ...] = ("025_mug",)) -> Report:
        rate = Rate(40, successes, successes / 40, *wilson_interval(successes, 40))
        return Report(overall=rate, by_method={}, groups={("parallel_jaw", "antipodal", "ground_truth", "standard",
                                                           o): rate for o in objects})

    verdict = compare(report(26), report(34), alpha=0.05)
    assert {c.kind for c in verdict.regressions} == {"pooled", "method", "group"}
    assert all(c.adjusted_p < 0.025 for c in verdict.comparisons)  # not tripled: the families are one
    two = compare(report(26, ("025_mug", "048_hammer")), report(34, ("025_mug", "048_hammer")), alpha=0.05)
    pooled = next(c for c in two.comparisons if c.kind == "pooled")
    method = next(c for c in two.comparisons if c.kind == "method")
    assert pooled.adjusted_p == method.adjusted_p  # one method: its line is the pooled line, both at half of alpha
