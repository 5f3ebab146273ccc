"""PNG plots of a run (matplotlib, headless Agg backend).

Every outcome has one fixed colour in every run (`STATUS_COLOURS`): success is the only green, the six
`dropped_perturb` directions are shades of one orange family, the planner's two failures (`planner_error`,
`no_grasp`) two shades of magenta, and each other failure has its own hue.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from manigrasp.bench.report import (
    PREDICTORS,
    Method,
    Rate,
    Report,
    format_share,
    metric_label,
    planning_call_times,
)
from manigrasp.bench.store import TrialKey
from manigrasp.protocol.result import TrialResult

# One colour per outcome, the same in every run; the order is the legend's and the stacking's.
DROPPED_DIRECTIONS = ("+x", "-x", "+y", "-y", "+z", "-z")
STATUS_COLOURS: dict[str, str] = {
    "success": "#1a9641",
    "pregrasp_collision": "#7b3294",
    "no_contact": "#969696",
    "slipped_lift": "#2c7fb8",
    # dropped_perturb: one orange family, light to dark by direction; without a direction, the darkest.
    **{f"dropped_perturb{d}": c for d, c in zip(
        DROPPED_DIRECTIONS, ("#fdd49e", "#fdbb84", "#fc8d59", "#ef6548", "#d7301f", "#b30000"), strict=True)},
    "dropped_perturb": "#7f0000",
    "unstable": "#252525",
    "planner_error": "#e7298a",
    "no_grasp": "#f1b6da",  # a light shade of planner_error: both are failures of the planner
    "invalid_grasp": "#41b6c4",
    "timeout": "#08306b",
    "harness_fault": "#9e9ac8",
}
_UNKNOWN_COLOUR = "#ffffff"  # an outcome without a colour (none today: a test checks) shows white, outlined


def status_colour(mode: str) -> str:
    """The fixed colour of an outcome ("success", a failure status, or "dropped_perturb+x")."""
    if mode.startswith("dropped_perturb") and mode not in STATUS_COLOURS:
        return STATUS_COLOURS["dropped_perturb"]
    return STATUS_COLOURS.get(mode, _UNKNOWN_COLOUR)


def _outcome_order(mode: str) -> tuple[int, str]:
    order = list(STATUS_COLOURS)
    return (order.index(mode), mode) if mode in order else (len(order), mode)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


DPI = 110


def _save(fig, path: Path) -> Path:
    """Lay out, write `fig` to `path` as PNG, close it; returns `path`. The image is cropped to what is drawn,
    not to the figure's size: a title, axis label or legend wider than the figure is kept whole, not cut off."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=DPI, bbox_inches="tight", pad_inches=0.1)
    plt.close(fig)
    return path


def method_label(method: Method, with_protocol: bool = False, with_observation: bool = False) -> str:
    """"hand / planner" (and " / observation" unless ground truth in a run of ground truth alone,
    `with_observation` False; " / protocol" if `with_protocol`: a run with several protocols)."""
    hand, planner, observation, protocol = method
    return (f"{hand} / {planner}" + ("" if observation == "ground_truth" and not with_observation
                                     else f" / {observation}")
            + (f" / {protocol}" if with_protocol else ""))


def label_of(report: Report, method: Method) -> str:
    """`method_label` of `method` as `report`'s figures name it: with its protocol and its observation where the
    run has several of them (a ground-truth line of a run with perception says so)."""
    return method_label(method, _several_protocols(report), len({m[2] for m in report.by_method}) > 1)


def _several_protocols(report: Report) -> bool:
    return len(report.protocols) > 1


def method_colours(n: int) -> list:
    """`n` distinct colours, one per method of a grouped-bar plot: matplotlib's 10-colour cycle up to 10 (the
    default, so smaller runs keep their look), its 20-colour table (dark and light pairs: a run's methods are
    sorted, so a hand x planner's protocols sit side by side in one hue) up to 20, else evenly spaced hues.
    (The default cycle repeats after 10: the dexterous config's 12 methods drew two pairs in one colour.)"""
    import matplotlib

    if n <= 10:
        return [matplotlib.colormaps["tab10"](i) for i in range(n)]
    if n <= 20:
        return [matplotlib.colormaps["tab20"](i) for i in range(n)]
    return [matplotlib.colormaps["hsv"](i / n) for i in range(n)]


def _legend_outside(ax) -> None:
    """The legend right of the axes, where it hides no bar, interval or label."""
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))


def _errorbars(rates: list[Rate]) -> np.ndarray:
    rate = np.array([r.success_rate for r in rates])
    return np.vstack([rate - [r.ci_low for r in rates], [r.ci_high for r in rates] - rate])


# success_by_object's layout: at most this many bars in one row of a panel (objects wrap into further rows),
# and the figure's width bounds [in] (at `DPI` 110: 1540 px at most, readable at page width).
BARS_PER_ROW = 30
OBJECT_PLOT_WIDTH = (6.0, 14.0)


def success_by_object(report: Report, path: Path) -> Path:
    """Success rate per object: one panel per hand x planner, stacked, with one bar per object (per observation x
    protocol side by side, coloured, where the run has several), Wilson 95 % intervals, k/n over each bar. The
    objects of a panel wrap into further rows past `BARS_PER_ROW` bars, so a large run keeps its width (20 objects x
    3 hands x 2 planners drew one 3510 px row of 120 thin bars)."""
    plt = _pyplot()
    panels: dict[tuple[str, str], list[Method]] = defaultdict(list)
    for method in report.by_method:
        panels[method[:2]].append(method)
    variants = list(dict.fromkeys(m[2:] for m in report.by_method))  # observation x protocol, in report order
    colours = dict(zip(variants, method_colours(len(variants)), strict=True))
    several = len(variants) > 1
    differ = [len({v[i] for v in variants}) > 1 for i in range(2)]  # the legend names what differs (observation...)
    rows = []  # (hand x planner, objects of the row)
    for key, methods in panels.items():
        objects = sorted({g[4] for g in report.groups if g[:4] in methods})
        per_row = max(1, BARS_PER_ROW // max(1, len(methods)))
        rows += [(key, objects[i:i + per_row]) for i in range(0, max(1, len(objects)), per_row)]
    if not rows:  # no trial stored yet (a run stopped while planning): one empty panel
        rows = [(("", ""), [])]
    widest = max((len(objs) * len(panels.get(key, ())) for key, objs in rows), default=1)
    low, high = OBJECT_PLOT_WIDTH
    fig, axes = plt.subplots(len(rows), 1, figsize=(max(low, min(high, 0.38 * widest + 2.5)), 3.0 * len(rows)),
                             squeeze=False)
    for ax, (key, objects) in zip(axes[:, 0], rows, strict=True):
        methods = panels.get(key, [])
        width = 0.8 / max(1, len(methods))
        x = np.arange(len(objects))
        for i, method in enumerate(methods):
            present = [(j, report.groups[(*method, obj)]) for j, obj in enumerate(objects)
                       if (*method, obj) in report.groups and report.groups[(*method, obj)].trials]
            if not present:
                continue
            xs = x[[j for j, _ in present]] + (i - (len(methods) - 1) / 2) * width
            rates = [r for _, r in present]
            ax.bar(xs, [r.success_rate for r in rates], width, yerr=_errorbars(rates), capsize=2,
                   color=colours[method[2:]], label=" / ".join(v for v, d in zip(method[2:], differ, strict=True) if d))
            for xi, r in zip(xs, rates, strict=True):
                ax.text(xi, r.ci_high + 0.02, f"{r.successes}/{r.trials}", ha="center", va="bottom", fontsize=7,
                        rotation=90 if len(methods) > 2 else 0)
        ax.set_xticks(x, objects, rotation=30, ha="right", fontsize=8)
        ax.set_xlim(-0.6, max(len(objects), 1) - 0.4)
        ax.set_ylim(0, 1.4 if len(methods) > 2 else 1.2)
        ax.set_yticks(np.linspace(0, 1, 6))
        ax.set_ylabel("success rate")
        first = ax is axes[0, 0]
        ax.set_title(("Success per object (95 % Wilson intervals, successes/trials over each bar)\n" if first else "")
                     + (f"{key[0]} / {key[1]}" if methods else "no trial stored yet"), fontsize=10, loc="left")
        if several:
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return _save(fig, path)


def success_by_method(report: Report, path: Path) -> Path:
    """Horizontal bars: success rate per hand x planner (x observation x protocol: protocols side by side), with
    intervals and k/n."""
    plt = _pyplot()
    methods = list(report.by_method)
    rates = [report.by_method[m] for m in methods]
    fig, ax = plt.subplots(figsize=(7, 1.2 + 0.5 * len(methods)))
    y = np.arange(len(methods))
    ax.barh(y, [r.success_rate for r in rates], xerr=_errorbars(rates), capsize=3,
            color=STATUS_COLOURS["success"])
    for yi, r in zip(y, rates, strict=True):
        ax.text(min(r.ci_high + 0.02, 1.0), yi, f"{r.successes}/{r.trials}", va="center", fontsize=8)
    ax.set_yticks(y, [label_of(report, m) for m in methods])
    ax.invert_yaxis()
    ax.set_xlim(0, 1.15)
    ax.set_xticks(np.linspace(0, 1, 6))
    ax.set_xlabel("success rate (95 % Wilson interval)")
    return _save(fig, path)


def failure_modes(report: Report, path: Path) -> Path:
    """Stacked bars: the share of each outcome per hand x planner, in the fixed outcome colours."""
    plt = _pyplot()
    methods = list(report.by_method)
    modes = sorted({m for r in report.by_method.values() for m in r.failure_modes}, key=_outcome_order)
    fig, ax = plt.subplots(figsize=(9, 1.6 + 0.55 * len(methods)))
    y = np.arange(len(methods))
    left = np.zeros(len(methods))
    for mode in ["success", *modes]:
        counts = [report.by_method[m].successes if mode == "success"
                  else report.by_method[m].failure_modes.get(mode, 0) for m in methods]
        trials = [report.by_method[m].trials for m in methods]
        share = np.array(counts, float) / np.maximum(1, trials)
        colour = status_colour(mode)
        ax.barh(y, share, left=left, color=colour, edgecolor="black" if colour == _UNKNOWN_COLOUR else "white",
                linewidth=0.5, label=mode)
        for yi, li, si, k, n in zip(y, left, share, counts, trials, strict=True):
            if si >= 0.06:  # the share from its counts, rounded as the tables round it (`format_share`)
                ax.text(li + si / 2, yi, format_share(k, n, percent=True), ha="center", va="center", fontsize=7,
                        color=_label_colour(colour))
        left = left + share
    ax.set_yticks(y, [f"{label_of(report, m)}\n(n = {report.by_method[m].trials})"
                      for m in methods])
    ax.invert_yaxis()
    ax.set_xlim(0, 1)
    ax.set_xlabel("share of trials")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), title="outcome", title_fontsize=8)
    return _save(fig, path)


def _label_colour(fill: str) -> str:
    """Black or white, whichever contrasts more with `fill` (WCAG 2's contrast ratio of relative luminances); a
    fixed list of dark outcomes left the navy `timeout` bar's figure black."""
    from matplotlib.colors import to_rgb

    linear = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in to_rgb(fill)]
    luminance = 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]
    return "white" if 1.05 / (luminance + 0.05) > (luminance + 0.05) / 0.05 else "black"


def planning_times(results: list[tuple[TrialKey, TrialResult]], path: Path, methods: list[Method] | None = None
                   ) -> Path:
    """One point per planning call (its wall time for every candidate of one object), box per hand x planner, in
    the order of `methods` (the report's; default sorted)."""
    plt = _pyplot()
    groups: dict[tuple, list[TrialResult]] = defaultdict(list)
    for key, result in results:
        groups[(key.hand, key.planner, key.observation, key.protocol, key.object)].append(result)
    protocols = len({k[3] for k in groups}) > 1
    observations = len({k[2] for k in groups}) > 1
    rank = {m: i for i, m in enumerate(methods or [])}
    by_method: dict[str, list[float]] = defaultdict(list)
    for group_key, group in sorted(groups.items(), key=lambda kv: (rank.get(kv[0][:4], len(rank)), kv[0])):
        label = method_label(group_key[:4], protocols, observations)
        by_method[label] += [t for t in planning_call_times(group) if t > 0]
    by_method = {k: v for k, v in by_method.items() if v}
    fig, ax = plt.subplots(figsize=(7, 1.4 + 0.6 * max(1, len(by_method))))
    if by_method:
        labels = [f"{k}\n({len(v)} call{'s' * (len(v) != 1)})" for k, v in by_method.items()]
        ax.boxplot(list(by_method.values()), orientation="horizontal", tick_labels=labels, widths=0.5)
        for i, values in enumerate(by_method.values(), start=1):
            ax.plot(values, np.full(len(values), i), "o", color="black", markersize=3, alpha=0.6)
        ax.set_xscale("log")
        ax.invert_yaxis()
        ax.set_xlabel("planning time\nwall time of one planning call (it plans every candidate of one object)")
        _log_ticks(ax)
    else:
        ax.axis("off")
        ax.text(0.5, 0.5, "no planning call was timed in this run", ha="center", va="center")
    return _save(fig, path)


def _log_ticks(ax) -> None:
    """Label the log x axis of `ax` in seconds with SI prefixes ("200 µs", "50 ms", "2 s") at 1, 2 and 5 times each
    power of ten, or, where those labels would run into each other (sub-millisecond calls beside seconds-long
    ones: "0.00050.001"), at fewer powers of ten: each, then every other..., the first that fits."""
    from matplotlib.ticker import EngFormatter, LogLocator, NullFormatter

    axis = ax.xaxis
    axis.set_major_formatter(EngFormatter(unit="s"))
    axis.set_minor_formatter(NullFormatter())
    for subs, numticks in (((1.0, 2.0, 5.0), "auto"), ((1.0,), "auto"), ((1.0,), 6), ((1.0,), 4), ((1.0,), 3)):
        axis.set_major_locator(LogLocator(base=10, subs=subs, numticks=numticks))
        if not _labels_overlap(ax.figure, axis):
            return


def _labels_overlap(fig, axis) -> bool:
    """Whether two neighbouring tick labels of `axis` (those drawn, within the view) overlap, laid out as `_save`
    lays the figure out."""
    fig.tight_layout()
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    low, high = sorted(axis.get_view_interval())
    boxes = sorted((label.get_window_extent(renderer) for tick, label in zip(
        axis.get_majorticklocs(), axis.get_majorticklabels(), strict=True)
        if low <= tick <= high and label.get_visible() and label.get_text()), key=lambda box: box.x0)
    gap = 2.0  # [px] at least between two labels
    return any(b.x0 < a.x1 + gap for a, b in zip(boxes, boxes[1:], strict=False))


def metric_auc(report: Report, path: Path) -> Path:
    """Grouped bars: each metric's ROC AUC for success per hand x planner (x observation x protocol: the legend's
    labels), 95 % bootstrap intervals.

    An undefined AUC (a constant metric, one outcome only) is written as such where its bar would be.
    """
    plt = _pyplot()
    methods = list(report.auc)
    metrics = list(PREDICTORS)
    defined = [(m, k) for m in methods for k in metrics if k in report.auc[m] and report.auc[m][k].defined]
    if not defined:
        fig, ax = plt.subplots(figsize=(7, 1.6))
        ax.axis("off")
        ax.text(0.5, 0.5, "No metric AUC is defined in this run\n(every group has one outcome only, "
                "or metrics constant)", ha="center", va="center")
        return _save(fig, path)
    width = 0.8 / len(methods)
    fig, ax = plt.subplots(figsize=(max(8.0, min(14.0, 0.35 * len(metrics) * len(methods) + 3)), 4.5))
    x = np.arange(len(metrics))
    colours = method_colours(len(methods))
    for i, method in enumerate(methods):
        xs = x + (i - (len(methods) - 1) / 2) * width
        estimates = [report.auc[method].get(k) for k in metrics]
        auc = np.array([e.auc if e is not None and e.defined else np.nan for e in estimates])
        low = np.array([e.low if e is not None and e.bounded else np.nan for e in estimates])
        high = np.array([e.high if e is not None and e.bounded else np.nan for e in estimates])
        bars = ax.bar(xs, np.nan_to_num(auc), width, yerr=np.vstack([auc - low, high - auc]), capsize=2,
                      color=colours[i], label=label_of(report, method))
        for xi, e in zip(xs, estimates, strict=True):
            if e is not None and e.defined:  # without an interval (too few of an outcome): "n=2, no CI"
                ax.text(xi, (e.high if e.bounded else e.auc) + 0.01, f"n={e.n}" + ("" if e.bounded else ", no CI"),
                        ha="center", va="bottom", fontsize=6, rotation=90 if len(methods) > 3 else 0)
            elif e is not None:
                ax.text(xi, 0.02, f"undefined: {e.undefined}", rotation=90, ha="center", va="bottom", fontsize=7,
                        color=bars.patches[0].get_facecolor())
    ax.axhline(0.5, color="grey", linestyle="--", linewidth=1, label="chance (0.5)")
    ax.set_xticks(x, [metric_label(k).replace(" (", "\n(") for k in metrics], fontsize=8)
    ax.set_ylim(0, 1.15)
    ax.set_ylabel("ROC AUC for success (95 % bootstrap interval)")
    ax.set_title("Each metric's power to predict success (n: trials with a value)", fontsize=10)
    _legend_outside(ax)
    return _save(fig, path)
