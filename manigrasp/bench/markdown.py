"""``report.md``: the tables of a run and its plots, for people to read."""

from __future__ import annotations

from pathlib import Path

from manigrasp.bench import plots, twins
from manigrasp.bench.plots import method_label
from manigrasp.bench.report import POOLED, Report, format_auc, format_planning_time, format_rate
from manigrasp.bench.store import TrialKey
from manigrasp.protocol.result import TrialResult
from manigrasp.runfiles import REPORT_NAME


def _table(headers: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _modes(modes: dict[str, int]) -> str:
    return ", ".join(f"{m} {n}" for m, n in sorted(modes.items(), key=lambda kv: -kv[1])) or "-"


def _perception(report: Report) -> list[str]:
    """The side-by-side table of observations with their pose errors (empty without estimated poses): one row
    per hand x planner x observation label, so the camera setups of one kind (``point_cloud@1view``,
    ``point_cloud@2views``) are rows of their own: ground truth, estimated pose, point cloud, each by views."""
    if not report.pose_errors and {o for _, _, o in report.by_method} <= {"ground_truth"}:
        return []
    rows = []
    kinds = ("ground_truth", "estimated_pose", "point_cloud")

    def order(method: tuple[str, str, str]) -> tuple:
        kind = method[2].partition("@")[0]
        return (*method[:2], kinds.index(kind) if kind in kinds else len(kinds), kind, report.views.get(method, 0),
                method[2])

    for (h, p, o), r in sorted(report.by_method.items(), key=lambda item: order(item[0])):
        e = report.pose_errors.get((h, p, o))
        errors = (f"{e.median_rotation_deg:.1f} / {e.p90_rotation_deg:.1f}", f"{e.median_translation_mm:.1f} / "
                  f"{e.p90_translation_mm:.1f}", f"{e.median_add_s_mm:.1f}", f"{e.share_within_5deg_1cm:.2f}"
                  ) if e else ("-", "-", "-", "-")
        views = report.views.get((h, p, o), 0)
        rows.append([h, p, o, views or "-", format_rate(r), *errors])
    return ["## Observations side by side (perception in the loop)",
            _table(["hand", "planner", "observation", "camera views", "rate [95% CI]",
                    "rotation error deg (median / p90; not meaningful for symmetric objects)",
                    "translation error mm (median / p90)", "ADD-S mm (median)",
                    "share with ADD-S < 5 mm & translation < 1 cm"], rows)]


def auc_rows(report: Report) -> list[list[str]]:
    """AUC table rows per hand x planner x observation x metric, then pooled rows (`all`) if several."""
    rows = [[h, p, o, metric, f"{e.n} ({e.successes})", format_auc(e)]
            for (h, p, o), per in report.auc.items() for metric, e in per.items()]
    if len(report.auc) > 1:
        rows += [["all", "all (pooled)", "all", metric, f"{e.n} ({e.successes})", format_auc(e)]
                 for metric, e in report.auc_pooled.items()]
    return rows


def lead_lines(report: Report) -> list[str]:
    """One line per hand x planner x observation: the figures a reader should quote."""
    return [f"{method_label(m)}: {r.successes}/{r.trials} successes, rate {format_rate(r)}"
            for m, r in report.by_method.items()]


def pooled_line(report: Report) -> str:
    """The all-trials line, saying what it pools."""
    r, n = report.overall, len(report.by_method)
    what = (f"{n} combinations, so it mixes planners" if len({p for _, p, _ in report.by_method}) > 1
            else f"{n} combinations of one planner" if n > 1 else "one combination, the line above")
    return f"Pooled ({POOLED}, {what}): {r.successes}/{r.trials}, rate {format_rate(r)}"


def write_markdown(report: Report, results: list[tuple[TrialKey, TrialResult]], run_dir: Path,
                   meta: dict) -> Path:
    """Write ``report.md`` and its PNGs into `run_dir`; returns the markdown path."""
    run_dir = Path(run_dir)
    images = {
        "Success rate per object": plots.success_by_object(report, run_dir / "success_by_object.png"),
        "Success rate per hand and planner": plots.success_by_method(report, run_dir / "success_by_method.png"),
        "Outcomes": plots.failure_modes(report, run_dir / "failure_modes.png"),
        "Planning time": plots.planning_times(results, run_dir / "planning_time.png"),
        "How well each analytic metric predicts success": plots.metric_auc(report, run_dir / "metric_auc.png"),
    }
    config = meta.get("config", {})
    parts = [
        f"# manigrasp report: {config.get('name', run_dir.name)}",
        f"Protocol `{config.get('protocol', {}).get('name')}`, seed {meta.get('seed')}, "
        f"manigrasp {meta.get('versions', {}).get('manigrasp')}, mujoco {meta.get('versions', {}).get('mujoco')}, "
        f"commit {meta.get('git_commit') or 'unknown'}, started {meta.get('started')}.",
        "\n".join(f"- **{line}**" for line in lead_lines(report))
        + "\n\nRates with 95 % Wilson intervals. " + pooled_line(report) + ".",
        "## Per hand and planner",
        _table(["hand", "planner", "observation", "trials", "successes", "rate [95% CI]", "failure modes",
                "median planning_time_s (calls)"],
               [[h, p, o, r.trials, r.successes, format_rate(r), _modes(r.failure_modes), format_planning_time(r)]
                for (h, p, o), r in report.by_method.items()]),
        "Planning time: the wall time of one planning call, which plans every candidate of one object "
        "(what `manigrasp plan` prints as `planning_time_s`); the median is over the calls.",
        "## Per object",
        _table(["hand", "planner", "observation", "object", "trials", "successes", "rate [95% CI]", "failure modes"],
               [[h, p, o, obj, r.trials, r.successes, format_rate(r), _modes(r.failure_modes)]
                for (h, p, o, obj), r in report.groups.items()]),
        *_perception(report),
        *twins.markdown_section(report),
        "## Analytic metrics as predictors of success",
        "ROC AUC of each metric for telling successes from failures within one hand x planner (0.5 = chance), "
        "with a 95 % bootstrap interval (resampled within successes and failures, fixed seed). n counts the "
        "simulated trials with a value of the metric (successes in brackets). A metric with a single value in a "
        "group cannot rank its trials: its AUC is undefined, not 0.5."
        + (" Rows `all` pool every trial of every planner: there a metric partly tells planners apart."
           if len(report.auc) > 1 else ""),
        _table(["hand", "planner", "observation", "metric", "n (successes)", "AUC [95% CI]"], auc_rows(report)),
    ]
    parts += [f"## {title}\n\n![{title}]({path.name})" for title, path in images.items()]
    out = run_dir / REPORT_NAME
    out.write_text("\n\n".join(parts) + "\n")
    return out
