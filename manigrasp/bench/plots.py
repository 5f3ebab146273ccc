"""PNG plots of a run (matplotlib, headless Agg backend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from manigrasp.bench.report import Rate, Report
from manigrasp.bench.store import TrialKey
from manigrasp.protocol.result import TrialResult


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    """Lay out, write `fig` to `path` as PNG, close it; returns `path`."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _method_label(method: tuple[str, str, str]) -> str:
    hand, planner, observation = method
    return f"{hand} / {planner}" + ("" if observation == "ground_truth" else f" / {observation}")


def _errorbars(rates: list[Rate]) -> np.ndarray:
    rate = np.array([r.success_rate for r in rates])
    return np.vstack([rate - [r.ci_low for r in rates], [r.ci_high for r in rates] - rate])


def success_by_object(report: Report, path: Path) -> Path:
    """Grouped bars: success rate per object, one bar per method, Wilson 95 % intervals."""
    plt = _pyplot()
    objects = sorted({k[3] for k in report.groups})
    methods = list(report.by_method)
    width = 0.8 / max(1, len(methods))
    fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(objects) + 2), 4.5))
    x = np.arange(len(objects))
    for i, method in enumerate(methods):
        rates = [report.groups.get((*method, obj), Rate(0, 0, np.nan, 0, 0)) for obj in objects]
        ax.bar(x + (i - (len(methods) - 1) / 2) * width, [r.success_rate for r in rates], width,
               yerr=_errorbars(rates), capsize=2, label=_method_label(method))
    ax.set_xticks(x, objects, rotation=45, ha="right")
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success rate (95 % Wilson interval)")
    ax.legend(fontsize=8)
    return _save(fig, path)


def success_by_method(report: Report, path: Path) -> Path:
    """Horizontal bars: overall success rate per hand x planner, with intervals."""
    plt = _pyplot()
    methods = list(report.by_method)
    rates = [report.by_method[m] for m in methods]
    fig, ax = plt.subplots(figsize=(7, 1.0 + 0.5 * len(methods)))
    y = np.arange(len(methods))
    ax.barh(y, [r.success_rate for r in rates], xerr=_errorbars(rates), capsize=3, color="tab:blue")
    ax.set_yticks(y, [_method_label(m) for m in methods])
    ax.set_xlim(0, 1.05)
    ax.set_xlabel("success rate (95 % Wilson interval)")
    return _save(fig, path)


def failure_modes(report: Report, path: Path) -> Path:
    """Stacked bars: the share of each outcome per hand x planner."""
    plt = _pyplot()
    methods = list(report.by_method)
    modes = sorted({m for r in report.by_method.values() for m in r.failure_modes})
    fig, ax = plt.subplots(figsize=(8, 1.2 + 0.5 * len(methods)))
    y = np.arange(len(methods))
    left = np.array([report.by_method[m].success_rate for m in methods])
    ax.barh(y, left, color="tab:green", label="success")
    cmap = plt.get_cmap("tab20")
    for i, mode in enumerate(modes):
        share = np.array([report.by_method[m].failure_modes.get(mode, 0) / max(1, report.by_method[m].trials)
                          for m in methods])
        ax.barh(y, share, left=left, color=cmap(i % 20), label=mode)
        left = left + share
    ax.set_yticks(y, [_method_label(m) for m in methods])
    ax.set_xlim(0, 1)
    ax.set_xlabel("share of trials")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return _save(fig, path)


def planning_times(results: list[tuple[TrialKey, TrialResult]], path: Path) -> Path:
    """Box plot of per-candidate planning time per hand x planner (log scale)."""
    plt = _pyplot()
    by_method: dict[str, list[float]] = {}
    for key, result in results:
        if np.isfinite(result.planning_time_s) and result.planning_time_s > 0:
            label = _method_label((key.hand, key.planner, key.observation))
            by_method.setdefault(label, []).append(result.planning_time_s)
    fig, ax = plt.subplots(figsize=(7, 1.2 + 0.5 * max(1, len(by_method))))
    if by_method:
        ax.boxplot(list(by_method.values()), orientation="horizontal", tick_labels=list(by_method))
        ax.set_xscale("log")
    ax.set_xlabel("planning time per candidate [s]")
    return _save(fig, path)


def metric_auc(report: Report, path: Path) -> Path:
    """Bars: ROC AUC of each analytic metric for predicting physical success."""
    plt = _pyplot()
    names = [n for n, v in report.auc.items() if np.isfinite(v)]
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.bar(names, [report.auc[n] for n in names], color="tab:purple")
    ax.axhline(0.5, color="grey", linestyle="--", linewidth=1, label="chance")
    ax.set_ylim(0, 1)
    ax.set_ylabel("ROC AUC for success")
    ax.tick_params(axis="x", rotation=30)
    ax.legend(fontsize=8)
    return _save(fig, path)
