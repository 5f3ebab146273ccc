"""Per-hand object lists: an object entry's ``exclude`` leaves out hands, each with its reason."""

from __future__ import annotations

import json
import re

import pytest

from manigrasp.bench.compare import Side, check_comparable
from manigrasp.bench.config import load_config, parse_config
from manigrasp.bench.report import summarize
from manigrasp.bench.rundir import identity, prepare
from manigrasp.bench.store import ResultsStore
from manigrasp.bench.trials import LeftOut, groups, left_out
from manigrasp.cli import main
from manigrasp.config import to_mapping
from manigrasp.errors import ConfigError
from manigrasp.protocol.result import Status, TrialResult

DRILL = {"name": "035_power_drill", "exclude": {"panda": "1.9 kg: more than its grip holds"}}
CONFIG = {"seed": 3, "objects": ["025_mug", DRILL], "hands": ["parallel_jaw", "panda"],
          "planners": ["antipodal", "random"], "grasps_per_object": 2, "protocol": "lift"}


def _config(**change):
    return parse_config({**CONFIG, **change})


def test_an_excluded_hand_runs_no_group_of_that_object_and_the_others_keep_their_ids_and_seeds():
    every = groups(_config(objects=["025_mug", "035_power_drill"]))
    kept = groups(_config())
    pairs = [(g.object_source.name, g.hand) for g in kept]
    assert ("035_power_drill", "panda") not in pairs and len(kept) == len(every) - 2  # 2 planners of the pair
    assert {g.hand for g in kept if g.object_source.name == "035_power_drill"} == {"parallel_jaw"}
    expected = [(g.key(1), g.seed, g.trial_seed(1)) for g in every
                if (g.object_source.name, g.hand) != ("035_power_drill", "panda")]
    assert [(g.key(1), g.seed, g.trial_seed(1)) for g in kept] == expected
    assert left_out(_config()) == [LeftOut("035_power_drill", "panda", "1.9 kg: more than its grip holds")]
    assert left_out(_config(objects=["025_mug"])) == []


def test_an_alias_is_reported_by_the_objects_name_and_a_resting_pose_is_left_out_too():
    config = _config(objects=[{"name": "mug", "exclude": {"parallel_jaw": "handle"}}], scene={"rest": "stable_k",
                                                                                               "rest_k": 2})
    assert {g.hand for g in groups(config)} == {"panda"} and len({g.object_label for g in groups(config)}) == 2
    assert left_out(config) == [LeftOut("025_mug", "parallel_jaw", "handle")]


@pytest.mark.parametrize(("exclude", "phrase"), [
    ({"pnada": "heavy"}, "object 035_power_drill: exclude.pnada: 'pnada' is not a hand of this config "
                         "(did you mean 'panda'?); its hands: parallel_jaw, panda"),
    ({"robotiq_2f85": "heavy"}, "exclude.robotiq_2f85: 'robotiq_2f85' is not a hand of this config"),
    ({"panda": None}, "exclude.panda: give the reason the hand is left out (a non-empty string), got None"),
    ({"panda": "  "}, "exclude.panda: give the reason"),
    ({"panda": 3}, "exclude.panda: give the reason"),
    (["panda"], "config.objects[1].exclude: map each hand left out to the reason"),
    ("panda", "config.objects[1].exclude: map each hand left out to the reason"),
    ({3: "heavy"}, "keys must be strings"),
])
def test_a_bad_exclusion_is_refused_naming_the_object_and_key(exclude, phrase):
    with pytest.raises(ConfigError, match=re.escape(phrase)):
        _config(objects=["025_mug", {"name": "035_power_drill", "exclude": exclude}])


def test_a_misspelled_key_and_a_config_that_runs_nothing_are_refused():
    with pytest.raises(ConfigError, match=r"config.objects\[0\]: unknown key 'exlude'; did you mean 'exclude'"):
        _config(objects=[{"name": "035_power_drill", "exlude": {"panda": "heavy"}}])
    with pytest.raises(ConfigError, match="every object excludes every hand"):
        _config(objects=[{"name": "035_power_drill", "exclude": {"panda": "heavy", "parallel_jaw": "wide"}}])


def test_a_hands_override_drops_the_exclusions_of_the_hands_it_leaves_out():
    config = parse_config(CONFIG, ["hands=parallel_jaw"])
    assert config.objects[1].exclude is None and left_out(config) == []
    assert to_mapping(config) == to_mapping(parse_config({**CONFIG, "objects": ["025_mug", "035_power_drill"]},
                                                          ["hands=parallel_jaw"]))
    kept = parse_config(CONFIG, ["hands=[panda, robotiq_2f85]"])
    assert kept.objects[1].exclude == {"panda": "1.9 kg: more than its grip holds"}
    with pytest.raises(ConfigError, match="every object excludes every hand"):
        parse_config({**CONFIG, "objects": [DRILL]}, ["hands=panda"])


def test_exclusions_are_part_of_the_run_identity_and_an_empty_one_is_none(tmp_path):
    plain = _config(objects=["025_mug", "035_power_drill"])
    assert identity(_config()) != identity(plain)
    assert identity(_config(objects=["025_mug", {"name": "035_power_drill", "exclude": {}}])) == identity(plain)
    assert "exclude" not in json.dumps(to_mapping(plain))  # run.json of a config without exclusions is as before
    reworded = {"name": "035_power_drill", "exclude": {"panda": "too heavy"}}
    assert identity(_config(objects=["025_mug", reworded])) != identity(_config())
    prepare(tmp_path / "run", _config())
    with pytest.raises(ConfigError, match="holds a run with a different config"):
        prepare(tmp_path / "run", plain)
    assert prepare(tmp_path / "run", _config())["config"]["objects"][1]["exclude"] == DRILL["exclude"]


def _side(config, source: str) -> Side:
    return Side(summarize([]), {"config": to_mapping(config)}, source)


def test_compare_refuses_a_baseline_that_ran_a_pair_the_run_leaves_out_and_the_reverse():
    base, new = _side(_config(objects=["025_mug", "035_power_drill"]), "base"), _side(_config(), "new")
    with pytest.raises(ConfigError, match="object '035_power_drill' x hand 'panda' \\(left out here: 1.9 kg: more "
                                          "than its grip holds; run in the baseline\\)"):
        check_comparable(new, base)
    with pytest.raises(ConfigError, match="'panda' \\(run here; left out in the baseline: 1.9 kg"):
        check_comparable(base, new)
    reworded = _config(objects=["025_mug", {"name": "035_power_drill", "exclude": {"panda": "too heavy"}}])
    assert check_comparable(_side(reworded, "reworded"), new) == []  # the reason's wording changes no trial
    jaw_only = _side(_config(objects=["025_mug", "035_power_drill"], hands=["parallel_jaw"]), "jaw")
    assert check_comparable(new, jaw_only) == []  # the left-out hand is not in the baseline: same groups


def _run(tmp_path, config):
    """A complete run directory of `config`: its run.json and every enumerated trial (all successes)."""
    run = tmp_path / "run"
    prepare(run, config)
    with ResultsStore(run / "results.sqlite") as store:
        for group in groups(config):
            for i in range(group.n_grasps):
                store.add(group.key(i), TrialResult(Status.SUCCESS, seed=group.trial_seed(i)))
    return run


def test_the_report_names_each_left_out_pair_and_its_reason(tmp_path, capsys):
    run = _run(tmp_path, _config(planners=["antipodal"]))
    assert main(["report", str(run)]) == 0
    out = capsys.readouterr().out
    assert "left out by the config: panda x 035_power_drill (1.9 kg: more than its grip holds)" in out
    assert "WARNING" not in out  # the left-out pair is not missing from the run
    markdown = (run / "report.md").read_text()
    assert "## Left out by the config" in markdown and "incomplete" not in markdown
    assert "| panda | 035_power_drill | 1.9 kg: more than its grip holds |" in markdown
    assert main(["report", str(run), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["left_out"] == [{"object": "035_power_drill", "hand": "panda",
                                    "reason": "1.9 kg: more than its grip holds"}]
    assert payload["completeness"]["complete"] and payload["completeness"]["expected"] == 6


def test_a_report_without_exclusions_has_no_left_out_section(tmp_path, capsys):
    run = _run(tmp_path, _config(objects=["025_mug"], planners=["antipodal"], hands=["parallel_jaw"]))
    assert main(["report", str(run), "--json"]) == 0
    assert "left_out" not in json.loads(capsys.readouterr().out)
    assert main(["report", str(run)]) == 0
    assert "left out" not in capsys.readouterr().out and "Left out" not in (run / "report.md").read_text()


def test_the_documented_yaml_reads(tmp_path):
    path = tmp_path / "hands.yaml"
    path.write_text("""objects:
  - 025_mug
  - name: 035_power_drill
    exclude: {panda: "1.9 kg: more than its grip holds"}
hands: [parallel_jaw, panda]
""")
    config = load_config(path)
    assert config.objects[1].excluded("panda") == "1.9 kg: more than its grip holds"
    assert config.objects[1].excluded("parallel_jaw") is None and config.objects[0].exclude is None


@pytest.mark.parametrize("entry, name", [
    ({"name": "mug", "exclude": {"panda": "handle"}}, "025_mug"),  # an alias: named as in the trial ids
    ({"name": "035_power_drill", "exclude": {"panda": "heavy"}}, "035_power_drill"),
    ({"mesh": "gone/part.stl", "name": "part", "scale": 0.001, "exclude": {"panda": "wide"}}, "part"),
    ({"mesh": "gone/part.stl", "exclude": {"panda": "wide"}}, "part"),  # a mesh named by its file
    ({"ycb": "gone/077_rubiks_cube", "exclude": {"panda": "wide"}}, "gone/077_rubiks_cube"),  # not here: its entry
])
def test_a_recorded_config_that_no_longer_parses_names_left_out_objects_as_one_that_parses(tmp_path, entry, name):
    """`left_out_of` reads a run.json whose config no longer parses (written by other code) entry by entry: each
    left-out object is named as the parsed config names it (`ObjectEntry.trial_name`, the one definition). Before,
    that fallback named an entry by its raw text, so an alias read "mug" where the trial ids say "025_mug"."""
    from manigrasp.bench.markdown import left_out_of

    config = {**CONFIG, "objects": ["025_mug", entry]}
    meta = {"config": config, "config_dir": str(tmp_path)}
    parsed = left_out_of(meta)
    assert parsed == [LeftOut(name, "panda", next(iter(entry["exclude"].values())))]
    assert left_out_of({**meta, "config": {**config, "a_key_of_other_code": 1}}) == parsed
    assert left_out_of({**meta, "config": {**config, "objects": ["025_mug", {**entry, "mass": -1}]}}) == parsed


@pytest.mark.parametrize("entry, phrase", [
    ({"name": "025_mug", "scale": 1000}, "scale apply to a mesh entry only"),
    ({"name": "025_mug", "density": 5}, "density apply to a mesh entry only"),
    ({"ycb": "some/folder", "scale": 2.0}, "a YCB folder has its real size"),
])
def test_scale_and_density_of_an_entry_that_ignores_them_are_refused(entry, phrase):
    """They were recorded in run.json and silently not applied (the trials ran the mug at its real size)."""
    with pytest.raises(ConfigError, match=phrase):
        parse_config({"objects": [entry]})
    assert parse_config({"objects": [{"name": "025_mug", "mass": 0.5}]}).objects[0].mass == 0.5


@pytest.mark.parametrize("entry, phrase", [
    ({"mesh": "box.stl", "mass": 1e-12}, "mass 1e-12 kg is below 1e-06 kg"),
    ({"mesh": "box.stl", "density": 1e-20}, "density 1e-20 kg/m\\^3 is below 1 kg/m\\^3"),
])
def test_an_object_too_light_to_simulate_is_refused_before_anything_runs(entry, phrase):
    """It passed, and every trial then ended `harness_fault` (the scene's inertia below MuJoCo's floor)."""
    with pytest.raises(ConfigError, match=phrase):
        parse_config({"objects": [entry]})
    assert parse_config({"objects": [{"mesh": "box.stl", "mass": 1e-6}]}).objects[0].mass == 1e-6
