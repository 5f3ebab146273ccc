"""Group dimensions of a run: protocols side by side (paired) and an object's k most probable resting poses."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from manigrasp.bench.config import parse_config
from manigrasp.bench.markdown import write_markdown
from manigrasp.bench.report import load_results, summarize
from manigrasp.bench.runner import run_benchmark
from manigrasp.bench.store import ResultsStore
from manigrasp.bench.trials import groups, stable_seed
from manigrasp.errors import ConfigError

CONFIG = {"seed": 7, "objects": ["025_mug", "048_hammer"], "hands": ["parallel_jaw", "panda"],
          "planners": ["antipodal", {"name": "random"}], "grasps_per_object": 3,
          "protocol": {"name": "standard", "params": {"grip_force": 10.0}}}
# Computed with the enumeration as it was before protocols and resting poses became group dimensions
# (commit ecdcf42): a one-protocol config must keep these ids and seeds, or resuming its runs would re-run them.
BEFORE = {  # group index: (trial id of grasp 2, group seed, trial seed of grasp 2)
    0: ("025_mug/parallel_jaw/antipodal/ground_truth/standard/0002", 1830346917394902726, 1961357519985721882),
    1: ("025_mug/parallel_jaw/random/ground_truth/standard/0002", 5598590741302987568, 2741479808819452853),
    2: ("025_mug/panda/antipodal/ground_truth/standard/0002", 1038967424287655894, 2836187312973531826),
    7: ("048_hammer/panda/random/ground_truth/standard/0002", 6636192758928127740, 790521657490324422),
}
EXTENTS = (0.02, 0.04, 0.1)  # a tall box: stable poses on its 2 largest, 2 middle, 2 smallest faces


def test_one_protocol_keeps_the_trial_ids_and_seeds_it_had():
    found = groups(parse_config(CONFIG))
    assert len(found) == 8
    for index, (trial_id, seed, trial_seed) in BEFORE.items():
        assert (found[index].key(2).trial_id, found[index].seed, found[index].trial_seed(2)) == (
            trial_id, seed, trial_seed)
    # the same with the protocol written as a one-element list
    listed = groups(parse_config({**{k: v for k, v in CONFIG.items() if k != "protocol"},
                                  "protocols": [CONFIG["protocol"]]}))
    assert [g.key(2).trial_id for g in listed] == [g.key(2).trial_id for g in found]


def test_several_protocols_are_a_group_dimension_paired_on_the_same_seeds():
    config = parse_config({**{k: v for k, v in CONFIG.items() if k != "protocol"},
                           "protocols": [CONFIG["protocol"], "six_direction"]})
    found = groups(config)
    assert len(found) == 16
    standard = [g for g in found if g.protocol.name == "standard"]
    six = [g for g in found if g.protocol.name == "six_direction"]
    assert [g.key(2).trial_id for g in standard] == [g.key(2).trial_id for g in groups(parse_config(CONFIG))]
    assert six[0].key(0).trial_id == "025_mug/parallel_jaw/antipodal/ground_truth/six_direction/0000"
    assert dict(standard[0].protocol.params) == {"grip_force": 10.0} and not six[0].protocol.params
    # paired: the same planning seed and trial seeds under both protocols, so the same planned grasps
    assert [(g.seed, g.trial_seed(1)) for g in standard] == [(g.seed, g.trial_seed(1)) for g in six]
    assert len({g.key(0).trial_id for g in found}) == 16
    # two parameter sets of one protocol: told apart by their labels in trial ids
    forces = parse_config({"objects": ["mug"], "protocols": [{"name": "lift", "params": {"grip_force": 5.0}},
                                                             {"name": "lift", "params": {"grip_force": 10.0}}]})
    assert [g.key(0).protocol for g in groups(forces)] == ["lift[grip_force=5.0]", "lift[grip_force=10.0]"]


def _box_config(tmp_path: Path, **scene: object) -> dict:
    trimesh.creation.box(EXTENTS).export(tmp_path / "tall_box.obj")
    return {"objects": [{"mesh": str(tmp_path / "tall_box.obj"), "name": "tall_box", "mass": 0.1}],
            "planners": ["antipodal"], "grasps_per_object": 1, "protocol": "lift",
            "scene": {"rest": "stable_k", **scene}}


def test_stable_k_runs_each_resting_pose_as_a_group(tmp_path, isolated_cache):
    found = groups(parse_config(_box_config(tmp_path, rest_k=3)))
    assert [g.key(0).object for g in found] == ["tall_box@rest0", "tall_box@rest1", "tall_box@rest2"]
    assert [g.scene.rest_index for g in found] == [0, 1, 2] and {g.scene.rest_k for g in found} == {3}
    assert found[0].seed == stable_seed(0, "tall_box@rest0", "parallel_jaw", "antipodal", "ground_truth")
    assert len({g.seed for g in found}) == 3  # each resting pose is an experiment of its own
    # a box has 6 stable poses: asking for 10 runs the 6 it has
    assert len(groups(parse_config(_box_config(tmp_path, rest_k=10)))) == 6


def test_stable_k_counts_poses_before_any_trial_and_a_bad_mesh_is_a_clear_error(tmp_path, isolated_cache):
    """Counting an object's poses builds it during enumeration: a mesh that cannot be built (an open, flat
    square) is one ConfigError naming the object, before anything runs."""
    from manigrasp.bench.trials import rest_scenes
    from manigrasp.objects.catalog import ObjectSource

    trimesh.Trimesh([[0, 0, 0], [0.1, 0, 0], [0.1, 0.1, 0], [0, 0.1, 0]], [[0, 1, 2], [0, 2, 3]]).export(
        tmp_path / "quad.obj")
    scene = parse_config(_box_config(tmp_path, rest_k=2)).scene
    with pytest.raises(ConfigError, match="object quad: .*mesh is open"):
        rest_scenes(scene, ObjectSource("quad", mesh=str(tmp_path / "quad.obj"), mass=0.1))


def _rows(run_dir: Path) -> list[dict]:
    with ResultsStore(run_dir / "results.sqlite") as store:
        return list(store.rows())


@pytest.mark.slow
def test_stable_k_end_to_end_stores_each_trials_resting_pose_and_resumes(tmp_path, isolated_cache):
    """k = 7 on a box with 6 stable poses: 6 groups, each trial stored with its pose (rank, probability, rotation,
    height), the box settling where it was put; the report lists the poses and says the box has fewer than 7."""
    config = parse_config(_box_config(tmp_path, rest_k=7))
    summary = run_benchmark(config, tmp_path / "run", progress=False)
    rows = sorted(_rows(tmp_path / "run"), key=lambda r: r["rest_index"])
    assert summary.ran == len(rows) == 6
    assert [r["object"] for r in rows] == [f"tall_box@rest{i}" for i in range(6)]
    assert [r["rest_index"] for r in rows] == list(range(6))
    probabilities = [r["rest_probability"] for r in rows]
    assert probabilities == sorted(probabilities, reverse=True) and sum(probabilities) == pytest.approx(1.0)
    heights = [r["rest_z_m"] for r in rows]
    np.testing.assert_allclose(heights, [0.01, 0.01, 0.02, 0.02, 0.05, 0.05], atol=1e-6)  # half of each extent
    quats = np.array([[r[f"rest_{k}"] for k in ("qw", "qx", "qy", "qz")] for r in rows])
    for i in range(6):
        for j in range(i):  # distinct orientations (a quaternion and its negative are one rotation)
            assert abs(quats[i] @ quats[j]) < 1 - 1e-6, (i, j)
    for r in rows:  # the planner saw the box settled in the pose it was put in
        assert r["object_z_m"] == pytest.approx(r["rest_z_m"], abs=1e-3)
    from manigrasp.bench.replay import replay_trial

    replay = replay_trial(tmp_path / "run", rows[3]["trial_id"])  # rebuilt in pose 3 from run.json
    assert replay.same_status and replay.object_pose_error < 1e-9
    again = run_benchmark(config, tmp_path / "run", progress=False)
    assert again.ran == 0 and again.already_done == 6 and len(_rows(tmp_path / "run")) == 6
    results = load_results(tmp_path / "run")
    text = write_markdown(summarize(results), results, tmp_path / "run", {"config": {"scene": {"rest_k": 7}}}
                          ).read_text()
    section = text[text.index("## Resting poses"):]
    assert "Fewer stable poses than 7, so as many groups as poses: tall_box (6)" in section
    assert "| tall_box@rest0 | 0 |" in section and "| 10.0 |" in section and "| 50.0 |" in section


@pytest.mark.slow
def test_two_protocols_end_to_end_side_by_side_on_the_same_grasps(tmp_path):
    """A box under `lift` and `six_direction`: the same planned grasps under both, a report with both protocols
    side by side (rates with intervals, paired outcomes), and a resumed run that adds nothing."""
    config = parse_config({"objects": ["004_sugar_box"], "planners": ["antipodal"], "grasps_per_object": 2,
                           "protocols": ["lift", "six_direction"]})
    summary = run_benchmark(config, tmp_path / "run", progress=False)
    rows = _rows(tmp_path / "run")
    assert summary.ran == len(rows) == 4 and {r["protocol"] for r in rows} == {"lift", "six_direction"}
    by_protocol = {p: sorted((r for r in rows if r["protocol"] == p), key=lambda r: r["grasp_index"])
                   for p in ("lift", "six_direction")}
    keys = ("grasp_x_m", "grasp_y_m", "grasp_z_m", "grasp_qw", "grasp_qx", "grasp_qy", "grasp_qz")
    same = 0
    for a, b in zip(by_protocol["lift"], by_protocol["six_direction"], strict=True):
        assert a["seed"] == b["seed"]  # paired: the same draw under both protocols
        same += [a[k] for k in keys] == [b[k] for k in keys]  # the same grasp, unless antipodal adapts to each
    assert run_benchmark(config, tmp_path / "run", progress=False).ran == 0
    from manigrasp.bench.replay import replay_trial

    for row in rows:  # every trial re-runs from run.json under its own protocol to its stored status
        replay = replay_trial(tmp_path / "run", row["trial_id"])
        assert replay.same_status and replay.replayed.seed == row["seed"], row["trial_id"]
    results = load_results(tmp_path / "run")
    report = summarize(results)
    assert report.protocols == ["lift", "six_direction"]
    meta = {"config": {"protocol": None, "protocols": [{"name": "lift"}, {"name": "six_direction"}]}}
    text = write_markdown(report, results, tmp_path / "run", meta).read_text()
    assert text.count("Protocols `lift`, `six_direction`") == 1
    section = text[text.index("## Protocols side by side"):text.index("## Per object")]
    header = next(line for line in section.splitlines() if line.startswith("| hand |"))
    assert header.endswith("| lift | six_direction |")
    row = next(line for line in section.splitlines() if "| all objects |" in line)
    assert row.count("/2, ") == 2 and row.count("[") == 2  # k/n and a rate with its interval per protocol
    paired = next(line for line in section.splitlines() if "| lift vs six_direction |" in line)
    cells = [c.strip() for c in paired.strip("|").split("|")]
    assert cells[4] == "2" and cells[5] == str(same) and sum(int(c) for c in cells[6:10]) == 2
    assert "| protocol |" in text[text.index("## Per hand and planner"):]


def test_compare_keys_groups_by_protocol_and_reads_baselines_without_one():
    """A two-protocol run against a one-protocol baseline compares that protocol's groups and lists the others;
    a baseline written before groups carried a protocol gets its run's; a protocol's parameters must agree."""
    import copy
    import json

    from manigrasp.bench.compare import Side, compare_sides
    from manigrasp.bench.report import report_from_json
    from manigrasp.bench.store import TrialKey
    from manigrasp.protocol.result import Status, TrialResult

    def trials(protocol: str, successes: int) -> list:
        return [(TrialKey("025_mug", "parallel_jaw", "antipodal", "ground_truth", protocol, i),
                 TrialResult(Status.SUCCESS if i < successes else Status.SLIPPED_LIFT)) for i in range(20)]

    new_config = {"scene": {}, "protocol": None, "protocols": [{"name": "standard", "params": {}},
                                                                {"name": "six_direction", "params": {}}]}
    base_config = {"scene": {}, "protocol": {"name": "standard", "params": {}}}
    new = Side(summarize(trials("standard", 18) + trials("six_direction", 4)), {"config": new_config}, "new")
    old_json = summarize(trials("standard", 18)).to_json()
    for entry in old_json["groups"] + old_json["methods"]:  # as written before groups carried a protocol
        del entry["protocol"]
    base = Side(report_from_json({**old_json, "run": {"config": base_config}}), {"config": base_config}, "base")
    verdict = compare_sides(new, base)
    assert verdict.groups_compared == 1 and not verdict.regressions
    assert verdict.only_new == [("parallel_jaw", "antipodal", "ground_truth", "six_direction", "025_mug")]
    assert json.dumps(verdict.comparisons[-1].group) == '"parallel_jaw/antipodal/ground_truth/standard/025_mug"'
    other = copy.deepcopy(new_config)
    other["protocols"][0]["params"] = {"grip_force": 5.0}
    with pytest.raises(ConfigError, match=r"protocol 'standard'\.params\.grip_force"):
        compare_sides(Side(new.report, {"config": other}, "new"), base)
