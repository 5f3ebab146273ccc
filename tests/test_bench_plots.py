"""The report's plots: fixed outcome colours, intervals and counts shown, no empty axes."""

from __future__ import annotations

import colorsys
from dataclasses import replace

import matplotlib.colors as mcolors
import numpy as np
import pytest
from matplotlib.container import BarContainer, ErrorbarContainer

from manigrasp.bench import plots
from manigrasp.bench.report import summarize
from manigrasp.bench.store import TrialKey
from manigrasp.protocol.result import GraspMetrics, Status, TrialResult


@pytest.fixture
def figures(monkeypatch):
    """The figures the plot functions draw, kept open instead of saved."""
    kept = []
    monkeypatch.setattr(plots, "_save", lambda fig, path: kept.append(fig) or path)
    yield kept
    import matplotlib.pyplot as plt

    for fig in kept:
        plt.close(fig)


def _hue(colour: str) -> float:
    r, g, b = mcolors.to_rgb(colour)
    return 360 * colorsys.rgb_to_hsv(r, g, b)[0]


def _trials(planner: str, outcomes: dict[str, int], objects=("025_mug",)) -> list[tuple[TrialKey, TrialResult]]:
    out = []
    for obj in objects:
        i = 0
        for mode, count in outcomes.items():
            dropped = mode.startswith("dropped_perturb")
            status = Status.DROPPED_PERTURB if dropped else Status(mode)
            direction = mode[len("dropped_perturb"):] if dropped else ""  # "+x"
            for _ in range(count):
                r = TrialResult(status, perturb_direction=direction, planned=GraspMetrics(2, 1.0, 0.01 * i, 0.3),
                                score=1.0, plan_time_s=0.5 + 0.1 * objects.index(obj))
                out.append((TrialKey(obj, "parallel_jaw", planner, "ground_truth", "standard", i), r))
                i += 1
    return out


def test_every_status_has_its_own_fixed_colour_and_success_is_the_only_green():
    for status in Status:
        assert status.value in plots.STATUS_COLOURS, f"no colour for {status.value}"
    failures = {m: c for m, c in plots.STATUS_COLOURS.items() if m != "success"}
    success = plots.STATUS_COLOURS["success"]
    assert success not in failures.values()
    for mode, colour in failures.items():  # no failure in the greens (hue 75..165 degrees) unless grey
        r, g, b = mcolors.to_rgb(colour)
        saturated = colorsys.rgb_to_hsv(r, g, b)[1] > 0.15
        assert not (saturated and 75 <= _hue(colour) <= 165), f"{mode} is drawn in a green"
    assert len(set(plots.STATUS_COLOURS.values())) == len(plots.STATUS_COLOURS)


def test_the_six_perturbation_directions_are_one_hue_family_apart_from_other_failures():
    dropped = [plots.status_colour(f"dropped_perturb{d}") for d in plots.DROPPED_DIRECTIONS]
    hues = [_hue(c) for c in dropped]
    assert max(hues) - min(hues) < 40 and len(set(dropped)) == 6
    others = [c for m, c in plots.STATUS_COLOURS.items() if not m.startswith("dropped_perturb")]
    family = (min(hues), max(hues))
    for colour in others:
        r, g, b = mcolors.to_rgb(colour)
        if colorsys.rgb_to_hsv(r, g, b)[1] > 0.15:
            assert not family[0] - 15 <= _hue(colour) <= family[1] + 15, colour
    assert plots.status_colour("dropped_perturb (odd)") == plots.STATUS_COLOURS["dropped_perturb"]


def _segment_colours(fig) -> dict[str, tuple]:
    ax = fig.axes[0]
    return {c.get_label(): c.patches[0].get_facecolor() for c in ax.containers if isinstance(c, BarContainer)}


def test_failure_modes_colours_are_the_same_in_every_run(figures, tmp_path):
    """The old plot coloured by position in the sorted list: 'dropped_perturb-z' was green in one run."""
    one = summarize(_trials("random", {"success": 11, "dropped_perturb-z": 4, "no_contact": 40}))
    two = summarize(_trials("antipodal", {"success": 80, "dropped_perturb+x": 3, "dropped_perturb-z": 2,
                                          "slipped_lift": 9, "pregrasp_collision": 6}))
    plots.failure_modes(one, tmp_path / "a.png")
    plots.failure_modes(two, tmp_path / "b.png")
    first, second = (_segment_colours(f) for f in figures)
    assert first["dropped_perturb-z"] == second["dropped_perturb-z"]
    assert first["success"] == second["success"] == mcolors.to_rgba(plots.STATUS_COLOURS["success"])
    assert first["dropped_perturb-z"] != first["success"] != first["no_contact"]
    # The success segment is 11 % wide, not 11 % plus the perturbation failures.
    bars = next(c for c in figures[0].axes[0].containers if c.get_label() == "success")
    assert bars.patches[0].get_width() == pytest.approx(11 / 55)


def test_success_by_object_shows_n_per_bar(figures, tmp_path):
    report = summarize(_trials("antipodal", {"success": 18, "no_contact": 2}, objects=("025_mug", "048_hammer"))
                       + _trials("random", {"success": 3, "no_contact": 17}, objects=("025_mug",)))
    plots.success_by_object(report, tmp_path / "s.png")
    texts = [t.get_text() for ax in figures[0].axes for t in ax.texts]
    assert sorted(texts) == ["18/20", "18/20", "3/20"]  # random has no bar (and no label) for the hammer


def test_metric_auc_has_intervals_per_planner(figures, tmp_path):
    results = _trials("antipodal", {"success": 10, "slipped_lift": 10}) + _trials("random", {"success": 5,
                                                                                             "no_contact": 15})
    plots.metric_auc(summarize(results), tmp_path / "m.png")
    ax = figures[0].axes[0]
    assert len([c for c in ax.containers if isinstance(c, ErrorbarContainer)]) == 2
    assert {"parallel_jaw / antipodal", "parallel_jaw / random"} <= {t.get_text() for t in ax.get_legend().texts}
    assert any("undefined: metric constant" in t.get_text() for t in ax.texts)  # force closure is 1 everywhere


def test_metric_auc_without_any_defined_auc_draws_a_message_not_empty_axes(figures, tmp_path):
    plots.metric_auc(summarize(_trials("antipodal", {"success": 5})), tmp_path / "m.png")
    (ax,) = figures[0].axes
    assert not ax.axison and not ax.patches
    assert "No metric AUC is defined" in ax.texts[0].get_text()


def test_planning_time_plots_one_point_per_planning_call(figures, tmp_path):
    results = _trials("antipodal", {"success": 20}, objects=("025_mug", "048_hammer", "011_banana"))
    results = [(k, replace(r, planning_time_s=r.plan_time_s / 20)) for k, r in results]
    plots.planning_times(results, tmp_path / "p.png")
    ax = figures[0].axes[0]
    points = np.concatenate([line.get_xdata() for line in ax.lines if line.get_marker() == "o"])
    assert sorted(points) == pytest.approx([0.5, 0.6, 0.7])  # 3 calls, not 60 trials
    assert "3 calls" in ax.get_yticklabels()[0].get_text()


@pytest.mark.parametrize("plot", ["success_by_object", "success_by_method", "failure_modes", "planning_times",
                                  "metric_auc"])
def test_the_saved_image_holds_every_title_label_and_legend_whole(tmp_path, monkeypatch, plot):
    """Long method labels (hand / planner / protocol) with a legend beside the axes: the PNG is as large as what
    is drawn, so no title, axis label or legend is cut at the figure's edge (metric_auc's title and
    planning_time's x label were, in a two-protocol run)."""
    import matplotlib.pyplot as plt
    from matplotlib.image import imread

    kept = []
    monkeypatch.setattr(plt, "close", kept.append)
    results = []
    for protocol, ok in (("standard", 6), ("six_direction", 2)):
        for key, r in _trials("power", {"success": ok, "no_contact": 3, "dropped_perturb+x": 3},
                              objects=("005_tomato_soup_can", "025_mug")):
            results.append((replace(key, hand="fourier_right", protocol=protocol), r))
    report = summarize(results)
    path = tmp_path / f"{plot}.png"
    getattr(plots, plot)(results if plot == "planning_times" else report, path)
    (fig,) = kept
    drawn = fig.get_tightbbox(fig.canvas.get_renderer())  # [inches]
    height, width = imread(path).shape[:2]
    monkeypatch.undo()
    plt.close(fig)
    assert width >= drawn.width * plots.DPI - 1 and height >= drawn.height * plots.DPI - 1


@pytest.mark.parametrize("plot", ["metric_auc"])
def test_twelve_methods_get_twelve_colours_and_the_legend_hides_no_bar(figures, tmp_path, plot):
    """The dexterous config's 12 hand x planner x protocol methods: matplotlib's default cycle repeats after 10,
    which drew two pairs of methods in one colour; the legend sat on the tallest bars' k/n labels."""
    results = []
    for hand in ("allegro_right", "fourier_right", "inspire_right"):
        for planner in ("dexopt", "power"):
            for protocol in ("standard", "six_direction"):
                for key, r in _trials(planner, {"success": 4, "no_contact": 2}, objects=("025_mug",)):
                    results.append((replace(key, hand=hand, protocol=protocol), r))
    report = summarize(results)
    assert len(report.by_method) == 12
    getattr(plots, plot)(report, tmp_path / "p.png")
    ax = figures[0].axes[0]
    bars = [c for c in ax.containers if isinstance(c, BarContainer)]
    colours = {mcolors.to_hex(c.patches[0].get_facecolor()) for c in bars}
    assert len(bars) == 12 and len(colours) == 12
    renderer = figures[0].canvas.get_renderer()
    legend, axes = ax.get_legend().get_window_extent(renderer), ax.get_window_extent(renderer)
    assert legend.x0 >= axes.x1  # beside the axes, not over them


def _overlapping_labels(fig, axis) -> list[tuple[str, str]]:
    """Pairs of neighbouring tick labels of `axis` (drawn, within the view) whose boxes overlap."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    low, high = sorted(axis.get_view_interval())
    drawn = sorted(((label.get_window_extent(renderer), label.get_text())
                    for tick, label in zip(axis.get_majorticklocs(), axis.get_majorticklabels(), strict=True)
                    if low <= tick <= high and label.get_visible() and label.get_text()), key=lambda b: b[0].x0)
    return [(a[1], b[1]) for a, b in zip(drawn, drawn[1:], strict=False) if b[0].x0 < a[0].x1]


@pytest.mark.parametrize("times", [
    {"file": [2e-4, 3e-4, 4e-4, 6e-4, 8e-4], "random": [1e-3, 2e-3], "antipodal": [0.3, 0.8, 1.5]},
    {"file": [5e-5, 1e-4], "dexopt": [12.0, 40.0]},  # six decades
    {"file": [2.1e-4, 2.3e-4, 2.6e-4]},  # within one decade
])
def test_planning_time_tick_labels_do_not_overlap(figures, tmp_path, times):
    """Sub-millisecond calls (the `file` planner's) beside others: the labels at 1, 2 and 5 times every power of ten
    ran into each other ("0.00050.001")."""
    results = [(TrialKey(f"object{j}", "parallel_jaw", planner, "ground_truth", "standard", 0),
                TrialResult(Status.SUCCESS, plan_time_s=t)) for planner, ts in times.items() for j, t in enumerate(ts)]
    plots.planning_times(results, tmp_path / "p.png")
    fig = figures[0]
    ax = fig.axes[0]
    fig.tight_layout()
    assert _overlapping_labels(fig, ax.xaxis) == []
    shown = [t for t in ax.xaxis.get_majorticklocs() if np.prod(ax.get_xlim()) and min(ax.get_xlim()) <= t <= max(
        ax.get_xlim())]
    assert len(shown) >= 2  # still labelled


def test_failure_mode_shares_read_as_the_tables_rates(figures, tmp_path):
    """294/400 read 0.73 in the tables and 74% in the plot, 34/400 0.09 and 8%: both now round the exact fraction
    half up (0.74 and 74%, 0.09 and 9%)."""
    from manigrasp.bench.report import format_rate

    results = _trials("antipodal", {"success": 294, "no_contact": 106}) + _trials(
        "random", {"success": 34, "no_contact": 366})
    report = summarize(results)
    plots.failure_modes(report, tmp_path / "f.png")
    texts = {t.get_text() for t in figures[0].axes[0].texts}
    assert {"74%", "27%", "9%", "92%"} <= texts  # 106/400 = 0.265: 27%
    rates = [format_rate(r) for r in report.by_method.values()]
    assert rates[0].startswith("0.74 [") and rates[1].startswith("0.09 [")


def test_success_by_object_stays_readable_for_a_large_run(tmp_path):
    """20 objects x 3 hands x 2 planners drew one row of 120 bars, 3510 px wide: now one panel per hand x planner,
    stacked, each with its objects' k/n labels, within about 1600 px."""
    from matplotlib.image import imread

    objects = tuple(f"{i:03d}_object_with_a_long_name" for i in range(20))
    results = [(replace(key, hand=hand), r) for hand in ("panda", "parallel_jaw", "robotiq_2f85")
               for planner in ("antipodal", "random")
               for key, r in _trials(planner, {"success": 3, "no_contact": 2}, objects=objects)]
    path = plots.success_by_object(summarize(results), tmp_path / "s.png")
    height, width = imread(path).shape[:2]
    assert width <= 1600 and height > width


def test_success_by_object_panels_hold_each_hand_and_planner_with_its_counts(figures, tmp_path):
    report = summarize(_trials("antipodal", {"success": 18, "no_contact": 2}, objects=("025_mug", "048_hammer"))
                       + _trials("random", {"success": 3, "no_contact": 17}, objects=("025_mug",)))
    plots.success_by_object(report, tmp_path / "s.png")
    first, second = figures[0].axes
    assert first.get_title(loc="left").endswith("parallel_jaw / antipodal")
    assert second.get_title(loc="left") == "parallel_jaw / random"
    assert [t.get_text() for t in first.texts] == ["18/20", "18/20"]
    assert [t.get_text() for t in second.texts] == ["3/20"] and first.get_legend() is None


def test_success_by_object_wraps_many_objects_into_rows(figures, tmp_path):
    objects = tuple(f"object{i:02d}" for i in range(45))
    plots.success_by_object(summarize(_trials("antipodal", {"success": 1}, objects=objects)), tmp_path / "s.png")
    axes = figures[0].axes
    assert [len(ax.get_xticks()) for ax in axes] == [30, 15]
