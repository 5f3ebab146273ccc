"""Scan vs recipe pairing and its report section."""

from __future__ import annotations

import pytest

from manigrasp.bench.report import Rate
from manigrasp.bench.twins import markdown_section, twin_rows


def rate(successes: int, trials: int = 20) -> Rate:
    from manigrasp.bench.stats import wilson_interval

    low, high = wilson_interval(successes, trials)
    return Rate(trials, successes, successes / trials, low, high)


GROUPS = {
    ("parallel_jaw", "antipodal", "ground_truth", "003_cracker_box"): rate(19),
    ("parallel_jaw", "antipodal", "ground_truth", "003_cracker_box_scan"): rate(6),
    ("parallel_jaw", "antipodal", "ground_truth", "010_potted_meat_can"): rate(19),
    ("parallel_jaw", "antipodal", "ground_truth", "010_potted_meat_can_scan"): rate(18),
    ("parallel_jaw", "random", "ground_truth", "010_potted_meat_can_scan"): rate(3),  # no twin in this method
    ("parallel_jaw", "antipodal", "ground_truth", "025_mug"): rate(15),
}


def test_scans_pair_with_their_recipe_twin_in_the_same_method() -> None:
    rows = twin_rows(GROUPS)
    assert [(r.scan, r.recipe) for r in rows] == [("003_cracker_box_scan", "003_cracker_box"),
                                                 ("010_potted_meat_can_scan", "010_potted_meat_can")]
    box, can = rows
    assert box.gap_points == pytest.approx(65.0) and not box.within and not box.intervals_overlap
    assert can.gap_points == pytest.approx(5.0) and can.within and can.intervals_overlap


def test_markdown_section_shows_counts_rates_and_verdicts() -> None:
    class FakeReport:
        groups = GROUPS

    title, _, table = markdown_section(FakeReport())  # type: ignore[arg-type]
    assert title == "## Scan vs recipe"
    lines = table.splitlines()
    assert len(lines) == 2 + 2
    assert "| 003_cracker_box | 003_cracker_box_scan | 6/20 |" in lines[2] and "| 19/20 |" in lines[2]
    assert "| +65.0 | no | 3.9e-05 |" in lines[2]
    assert lines[3].endswith("| +5.0 | yes | 1 |")


def test_a_gap_just_over_ten_points_does_not_print_as_ten() -> None:
    """Scan 15/18 against recipe 15/16 is a 10.4-point gap, not within 10: the table must not read "+10 | no"."""
    class FakeReport:
        groups = {("h", "p", "o", "x_scan"): rate(15, 18), ("h", "p", "o", "x"): rate(15, 16)}

    (_, _, table) = markdown_section(FakeReport())  # type: ignore[arg-type]
    assert table.splitlines()[2].endswith("| +10.4 | no | 0.6 |")


def test_no_pairs_no_section() -> None:
    class FakeReport:
        groups = {k: v for k, v in GROUPS.items() if not k[3].endswith("_scan")}

    assert markdown_section(FakeReport()) == []  # type: ignore[arg-type]


def test_a_gap_of_exactly_ten_points_is_within_whatever_the_float_rounding() -> None:
    """14 vs 16 of 20 is a 10-point gap (10.000000000000009 in floats), like 17 vs 19: both within."""
    from manigrasp.bench.report import Rate
    from manigrasp.bench.twins import twin_rows

    def rate(k: int) -> Rate:
        return Rate(trials=20, successes=k, success_rate=k / 20, ci_low=0.0, ci_high=1.0, failure_modes={})

    for scan, recipe in ((14, 16), (17, 19), (16, 14)):
        groups = {("h", "p", "o", "x_scan"): rate(scan), ("h", "p", "o", "x"): rate(recipe)}
        (row,) = twin_rows(groups)
        assert row.within, (scan, recipe, row.gap_points)
    groups = {("h", "p", "o", "x_scan"): rate(13), ("h", "p", "o", "x"): rate(16)}
    assert not twin_rows(groups)[0].within


def test_a_recipe_never_held_gets_no_verdict() -> None:
    """Both 0/6 (the planner found no grasp on either): the gap is 0, but there is nothing to agree on."""
    class FakeReport:
        groups = {("h", "p", "o", "x_scan"): rate(0, 6), ("h", "p", "o", "x"): rate(0, 6),
                  ("h", "p", "o", "y_scan"): rate(0, 6), ("h", "p", "o", "y"): rate(3, 6)}

    (_, _, table) = markdown_section(FakeReport())  # type: ignore[arg-type]
    rows = table.splitlines()[2:]
    assert rows[0].endswith("| +0.0 (not judged) | n/a (recipe never held) | 1 |")
    assert rows[1].endswith("| +50.0 | no | 0.18 |")


def test_resting_poses_are_pooled_not_paired_by_rank() -> None:
    """Under rest: stable_k the scan's rest0 (a can on its side) and the recipe's rest0 (standing on an end) are
    different physical poses: the pair compares each object over all of its poses (1+4 of 10 against 3+4 of 10),
    where it used to print a row per rank (0/5 vs 4/5: +80 points, "no")."""
    groups = {("h", "random", "o", "005_tomato_soup_can_scan@rest0"): rate(0, 5),
              ("h", "random", "o", "005_tomato_soup_can_scan@rest1"): rate(1, 5),
              ("h", "random", "o", "005_tomato_soup_can@rest0"): rate(4, 5),
              ("h", "random", "o", "005_tomato_soup_can@rest1"): rate(0, 5)}
    (row,) = twin_rows(groups)
    assert (row.scan, row.recipe) == ("005_tomato_soup_can_scan", "005_tomato_soup_can")
    assert (row.scan_rate.successes, row.scan_rate.trials, row.recipe_rate.successes, row.recipe_rate.trials) == \
        (1, 10, 4, 10)
    assert row.gap_points == pytest.approx(30.0)
    expected = rate(1, 10)
    assert (row.scan_rate.ci_low, row.scan_rate.ci_high) == pytest.approx((expected.ci_low, expected.ci_high))


def test_a_ycb_download_is_named_apart_from_its_recipe_and_paired_with_it(tmp_path) -> None:
    """A YCB folder was named as the folder (`025_mug`), the shipped recipe's name: its trials, reports and
    grasp sets passed for the recipe's, and a config could not run both (nor did it take a `name` for it)."""
    import trimesh

    from manigrasp.bench.config import parse_config
    from manigrasp.errors import ConfigError

    folder = tmp_path / "025_mug"
    (folder / "google_16k").mkdir(parents=True)
    trimesh.creation.cylinder(0.04, 0.09).export(folder / "google_16k" / "textured.obj")
    config = parse_config({"objects": ["025_mug", {"ycb": str(folder)}, {"ycb": str(folder), "name": "mug_real"}],
                           "planners": ["random"]})
    assert [o.trial_name() for o in config.objects] == ["025_mug", "025_mug_ycb", "mug_real"]
    for shipped in ("025_mug", "mug", "003_cracker_box_scan"):  # passing for a shipped object again: refused
        entry = parse_config({"objects": [{"ycb": str(folder), "name": shipped}], "planners": ["random"]}).objects[0]
        with pytest.raises(ConfigError, match="is a shipped object's"):
            entry.source()  # as a mesh entry's, when the run builds its objects
    groups = {("parallel_jaw", "antipodal", "ground_truth", "025_mug"): rate(15),
              ("parallel_jaw", "antipodal", "ground_truth", "025_mug_ycb"): rate(9)}
    (row,) = twin_rows(groups)
    assert (row.scan, row.recipe, row.gap_points) == ("025_mug_ycb", "025_mug", pytest.approx(30.0))


def test_a_gap_comes_with_its_fisher_p_and_the_text_says_what_it_means() -> None:
    """6/20 against 9/20: a 15-point gap, "no" on the point estimates, but Fisher p = 0.51: noise at 20 trials."""
    class FakeReport:
        groups = {("h", "p", "o", "x_scan"): rate(6), ("h", "p", "o", "x"): rate(9)}

    (row,) = twin_rows(FakeReport.groups)
    assert row.fisher_p == pytest.approx(0.5145, abs=1e-4) and row.verdict == "no"
    _, note, table = markdown_section(FakeReport())  # type: ignore[arg-type]
    assert table.splitlines()[0].endswith("| within 10 points | Fisher p |")
    assert table.splitlines()[2].endswith("| +15.0 | no | 0.51 |")
    assert "Fisher exact" in note and "not evidence that the meshes differ" in note
    assert "not evidence that they agree either" in note


def test_where_the_recipe_never_held_the_gap_is_shown_but_not_judged() -> None:
    class FakeReport:
        groups = {("h", "p", "o", "x_scan"): rate(3), ("h", "p", "o", "x"): rate(0),
                  ("h", "p", "o", "y_scan"): rate(0), ("h", "p", "o", "y"): rate(0)}

    _, note, table = markdown_section(FakeReport())  # type: ignore[arg-type]
    x, y = table.splitlines()[2:]
    assert "| -15.0 (not judged) | n/a (recipe never held) |" in x
    assert "| +0.0 (not judged) | n/a (recipe never held) |" in y  # 0/20 against 0/20 is no agreement
    assert "shown for information only" in note
