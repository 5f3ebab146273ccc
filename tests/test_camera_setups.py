"""Several camera setups in one run: a set of groups per setup for the perception kinds, readable labels,
run identity, and the report's rows side by side."""

from __future__ import annotations

import json

import pytest

from manigrasp.bench import rundir
from manigrasp.bench.config import parse_config
from manigrasp.bench.markdown import write_markdown
from manigrasp.bench.report import report_from_json, summarize
from manigrasp.bench.store import ResultsStore
from manigrasp.bench.trials import groups, stable_seed
from manigrasp.errors import ConfigError
from manigrasp.protocol.result import Status, TrialResult

BASE = {"objects": ["025_mug", "011_banana"], "grasps_per_object": 2,
        "observation": ["ground_truth", "estimated_pose", "point_cloud"]}


def _ids(config) -> dict[str, set[str]]:
    """Trial ids per observation label."""
    out: dict[str, set[str]] = {}
    for g in groups(config):
        out.setdefault(g.observation_label, set()).update(g.key(i).trial_id for i in range(g.n_grasps))
    return out


def test_two_setups_make_two_sets_of_point_cloud_trials_and_one_of_ground_truth():
    config = parse_config({**BASE, "camera": [{"views": 1}, {"views": 2}]})
    ids = _ids(config)
    assert set(ids) == {"ground_truth", "estimated_pose@1view", "point_cloud@1view", "point_cloud@2views"}
    assert "025_mug/parallel_jaw/antipodal/point_cloud@2views/standard/0001" in ids["point_cloud@2views"]
    assert all(len(v) == 2 * 2 for v in ids.values())  # 2 objects x 2 grasps each, no trial id shared
    assert len(set().union(*ids.values())) == 4 * 4
    views = {g.observation_label: g.camera.views for g in groups(config) if g.observation == "point_cloud"}
    assert views == {"point_cloud@1view": 1, "point_cloud@2views": 2}
    # Paired: a group's seed (its planner's generator and its cameras' noise) does not depend on the setup.
    seeds = {(g.object_source.name, g.observation_label): g.seed for g in groups(config)}
    assert seeds[("025_mug", "point_cloud@1view")] == seeds[("025_mug", "point_cloud@2views")]


def test_estimated_pose_runs_once_per_distinct_first_camera():
    """It sees only the first camera: 1 vs 2 views from the same first camera would repeat its trials."""
    same_first = parse_config({**BASE, "camera": [{"views": 1}, {"views": 2}, {"views": 3}]})
    assert sorted(g.observation_label for g in groups(same_first) if g.observation == "estimated_pose") == \
        ["estimated_pose@1view"] * 2
    other_first = parse_config({**BASE, "camera": [{"views": 1}, {"views": 1, "elevation_deg": 60}]})
    labels = sorted({g.observation_label for g in groups(other_first) if g.observation == "estimated_pose"})
    assert labels == ["estimated_pose@1view[elevation_deg=45.0]", "estimated_pose@1view[elevation_deg=60.0]"]
    # Listed 3 views first, it was labelled by that setup, "estimated_pose@3views", and stored 3 camera views for
    # an estimate made from one camera: it is the one-view setup's, wherever that is listed.
    three_first = parse_config({**BASE, "camera": [{"views": 3}, {"views": 1}]})
    estimated = [g for g in groups(three_first) if g.observation == "estimated_pose"]
    assert {g.observation_label for g in estimated} == {"estimated_pose@1view"}
    assert {g.camera.views for g in estimated} == {1}


def test_estimated_pose_trials_store_the_one_camera_they_used():
    """A setup of 2 views labels the estimated_pose group (no one-view setup shares its first camera); the pose
    estimate used its first camera alone, and the trial says 1 camera view (the report's "camera views")."""
    from manigrasp.bench import worker

    config = parse_config({**BASE, "objects": ["025_mug"], "camera": [{"views": 2}, {"views": 1, "elevation_deg": 60}]})
    by_label = {g.observation_label: g for g in groups(config)}
    group = by_label["estimated_pose@2views"]

    def stored(g):  # a group whose perception failed still stores its setup's cameras
        return worker.run_trial(g, 0, worker.Plan.failed(g, Status.PLANNER_ERROR, "perception failed"))[1]

    assert stored(group).camera_views == 1
    assert stored(by_label["point_cloud@2views"]).camera_views == 2


def test_one_setup_keeps_the_trial_ids_seeds_and_identity_of_before():
    as_mapping = parse_config({**BASE, "camera": {"views": 2}})
    as_list = parse_config({**BASE, "camera": [{"views": 2}]})
    assert as_list == as_mapping and rundir.identity(as_list) == rundir.identity(as_mapping)
    by_kind = {g.observation: g for g in groups(as_list) if g.object_source.name == "025_mug"}
    assert {k: g.key(0).trial_id for k, g in by_kind.items()} == {
        k: f"025_mug/parallel_jaw/antipodal/{k}/standard/0000" for k in BASE["observation"]}
    assert all(g.seed == stable_seed(0, "025_mug", "parallel_jaw", "antipodal", k) and g.camera.views == 2
               for k, g in by_kind.items())
    several = parse_config({**BASE, "camera": [{"views": 2}, {"views": 3}]})
    assert rundir.identity(several) != rundir.identity(as_list)


def test_bad_setup_lists_are_one_line_errors():
    with pytest.raises(ConfigError, match="camera setup 1 and 3 are identical"):
        parse_config({**BASE, "camera": [{"views": 2}, {"views": 3}, {"views": 2}]})
    with pytest.raises(ConfigError, match=r"camera\[1\]: unknown key 'view'; did you mean 'views'"):
        parse_config({**BASE, "camera": [{"views": 2}, {"view": 3}]})
    with pytest.raises(ConfigError, match=r"camera\[0\].*views must be an integer"):
        parse_config({**BASE, "camera": [{"views": 0}]})
    with pytest.raises(ConfigError, match="non-empty list"):
        parse_config({**BASE, "camera": []})


def test_a_run_with_two_setups_resumes_and_refuses_another_setup_list(tmp_path):
    config = parse_config({**BASE, "camera": [{"views": 1}, {"views": 2}]})
    rundir.prepare(tmp_path, config)
    rundir.prepare(tmp_path, parse_config({**BASE, "camera": [{"views": 1}, {"views": 2}]}))  # resume: accepted
    with pytest.raises(ConfigError, match="different config.*camera"):
        rundir.prepare(tmp_path, parse_config({**BASE, "camera": [{"views": 1}, {"views": 3}]}))


def test_the_report_shows_each_setup_in_its_own_row_with_its_views(tmp_path):
    """The trial ids of two setups stored and read back: two point-cloud rows with 2 and 10 views, in that
    order (not the labels' alphabetical one), after ground truth."""
    config = parse_config({**BASE, "observation": ["point_cloud", "ground_truth"],
                           "camera": [{"views": 10}, {"views": 2}]})
    with ResultsStore(tmp_path / "results.sqlite") as store:
        for g in groups(config):
            views = 0 if g.observation == "ground_truth" else g.camera.views
            wins = {"ground_truth": 2, "point_cloud@2views": 1, "point_cloud@10views": 2}[g.observation_label]
            for i in range(g.n_grasps):
                store.add(g.key(i), TrialResult(Status.SUCCESS if i < wins else Status.NO_CONTACT,
                                                camera_views=views))
        results = list(store.results())
    report = summarize(results)
    assert {o: (r.trials, r.successes) for (_, _, o, _), r in report.by_method.items()} == {
        "ground_truth": (4, 4), "point_cloud@2views": (4, 2), "point_cloud@10views": (4, 4)}
    assert report.views[("parallel_jaw", "antipodal", "point_cloud@10views", "standard")] == 10
    assert report_from_json(json.loads(json.dumps(report.to_json()))).views == report.views
    text = write_markdown(report, results, tmp_path, {"config": {}}).read_text()
    table = text[text.index("## Observations side by side"):].split("\n\n")[1].splitlines()
    rows = [line.split(" | ")[2:5] for line in table[2:]]
    assert rows == [["ground_truth", "-", "1.00 [0.51, 1.00]"], ["point_cloud@2views", "2", "0.50 [0.15, 0.85]"],
                    ["point_cloud@10views", "10", "1.00 [0.51, 1.00]"]]


@pytest.mark.slow
def test_a_run_stores_each_setup_with_its_cameras_and_resumes(tmp_path):
    """End to end in simulation: every setup's trials are stored under their label with their camera count."""
    pytest.importorskip("open3d")
    from manigrasp.bench.runner import run_benchmark

    data = {"objects": ["004_sugar_box"], "grasps_per_object": 2, "protocol": "lift",
            "observation": ["ground_truth", "point_cloud"], "camera": [{"views": 1}, {"views": 2}]}
    summary = run_benchmark(parse_config(data), tmp_path / "run", progress=False, in_process=True)
    with ResultsStore(tmp_path / "run" / "results.sqlite") as store:
        rows = list(store.rows())
    assert summary.ran == len(rows) == 3 * 2
    views = {(r["observation"], r["camera_views"]) for r in rows}
    assert views == {("ground_truth", 0), ("point_cloud@1view", 1), ("point_cloud@2views", 2)}
    again = run_benchmark(parse_config(data), tmp_path / "run", progress=False, in_process=True)
    assert again.ran == 0 and again.already_done == 6


def test_a_trial_whose_perception_failed_still_stores_its_setup():
    """A setup whose view failed is still a row of its view count in the report (not "-")."""
    from manigrasp.bench.worker import Plan, run_trial

    config = parse_config({**BASE, "objects": ["025_mug"], "camera": [{"views": 1}, {"views": 3}]})
    for g in groups(config):
        _, result = run_trial(g, 0, Plan.failed(g, Status.PLANNER_ERROR, "perception failed: no points"))
        assert result.status is Status.PLANNER_ERROR
        assert result.camera_views == (0 if g.observation == "ground_truth" else g.camera.views)
