"""Summaries of a run: success rates with Wilson intervals, failure modes, timing, metric AUCs.

`summarize` turns the stored trials into a `Report` (plain data, JSON-able);
`write_markdown` writes ``report.md`` with PNG plots beside it.
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from manigrasp.bench.stats import roc_auc, wilson_interval
from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.protocol.result import Status, TrialResult

# Metrics whose power to predict physical success is reported (column, higher-is-better sign).
PREDICTORS = {
    "epsilon_l1": ("planned", "epsilon_l1", 1.0),
    "force_closure": ("planned", "force_closure", 1.0),
    "min_friction": ("planned", "min_friction", -1.0),
    "sim_epsilon_l1": ("simulated", "epsilon_l1", 1.0),
    "planner_score": (None, "score", 1.0),
}


@dataclass(frozen=True)
class Rate:
    """Trials, successes, their rate and its Wilson 95 % interval, the failure-mode counts."""

    trials: int
    successes: int
    success_rate: float
    ci_low: float
    ci_high: float
    failure_modes: dict[str, int] = field(default_factory=dict)
    median_planning_time_s: float = math.nan

    @classmethod
    def of(cls, results: list[TrialResult]) -> Rate:
        """The rate of a list of trial results."""
        n = len(results)
        k = sum(r.success for r in results)
        low, high = wilson_interval(k, n)
        modes = Counter(_mode(r) for r in results if not r.success)
        times = [r.planning_time_s for r in results if not math.isnan(r.planning_time_s)]
        return cls(n, k, k / n if n else math.nan, low, high, dict(sorted(modes.items())),
                   float(np.median(times)) if times else math.nan)


def _mode(result: TrialResult) -> str:
    """The failure mode: the status, with the direction for `dropped_perturb` ("dropped_perturb+x")."""
    direction = result.detail.split(":")[0].strip()
    if result.status is Status.DROPPED_PERTURB and direction:
        return f"dropped_perturb{direction}" if direction[0] in "+-" else f"dropped_perturb ({direction})"
    return result.status.value


@dataclass(frozen=True)
class PoseErrors:
    """Errors of the estimated object poses of one hand x planner x observation (one per object).

    Attributes:
        objects: objects with an estimated pose.
        median_rotation_deg, p90_rotation_deg, median_translation_mm, p90_translation_mm,
        median_add_s_mm: statistics over those objects.
        share_within_5deg_1cm: fraction of objects whose pose is good: ADD-S < 5 mm and translation < 1 cm
            (ADD-S, not the rotation error, so a symmetric object turned onto itself counts as good;
            the rotation statistics are not meaningful for symmetric objects).
    """

    objects: int
    median_rotation_deg: float
    p90_rotation_deg: float
    median_translation_mm: float
    p90_translation_mm: float
    median_add_s_mm: float
    share_within_5deg_1cm: float

    @classmethod
    def of(cls, per_object: list[tuple[float, float, float]]) -> PoseErrors:
        """From (rotation [deg], translation [mm], ADD-S [mm]) per object."""
        rot, trans, adds = (np.array(v, float) for v in zip(*per_object, strict=True))
        within = float(np.mean((adds < 5.0) & (trans < 10.0)))
        return cls(len(per_object), float(np.median(rot)), float(np.percentile(rot, 90)),
                   float(np.median(trans)), float(np.percentile(trans, 90)), float(np.median(adds)), within)


@dataclass(frozen=True)
class Report:
    """A run's summary: overall, per hand x planner x observation, per group (+ object), AUCs, pose errors."""

    overall: Rate
    by_method: dict[tuple[str, str, str], Rate]
    groups: dict[tuple[str, str, str, str], Rate]
    auc: dict[str, float]
    pose_errors: dict[tuple[str, str, str], PoseErrors] = field(default_factory=dict)

    def to_json(self) -> dict:
        """The JSON form printed by ``manigrasp report --json``."""
        def rate(r: Rate) -> dict:
            return asdict(r)

        return {
            "overall": rate(self.overall),
            "methods": [{"hand": h, "planner": p, "observation": o, **rate(r)}
                        for (h, p, o), r in self.by_method.items()],
            "groups": [{"hand": h, "planner": p, "observation": o, "object": obj, **rate(r)}
                       for (h, p, o, obj), r in self.groups.items()],
            "auc": self.auc,
            "pose_errors": [{"hand": h, "planner": p, "observation": o, **asdict(e)}
                            for (h, p, o), e in self.pose_errors.items()],
        }


def report_from_json(data: dict) -> Report:
    """Inverse of `Report.to_json` (for baselines committed as JSON)."""
    fields = Rate.__dataclass_fields__

    def rate(d: dict) -> Rate:
        return Rate(**{k: d[k] for k in fields if k in d})

    return Report(
        pose_errors={(e["hand"], e["planner"], e["observation"]): PoseErrors(
            **{k: e[k] for k in PoseErrors.__dataclass_fields__}) for e in data.get("pose_errors", [])},
        overall=rate(data["overall"]),
        by_method={(m["hand"], m["planner"], m["observation"]): rate(m) for m in data.get("methods", [])},
        groups={(g["hand"], g["planner"], g["observation"], g["object"]): rate(g) for g in data["groups"]},
        auc=dict(data.get("auc", {})),
    )


def load_results(run_dir: Path) -> list[tuple[TrialKey, TrialResult]]:
    """Every stored trial of `run_dir`."""
    with ResultsStore(Path(run_dir) / "results.sqlite") as store:
        return list(store.results())


def summarize(results: list[tuple[TrialKey, TrialResult]]) -> Report:
    """Aggregate trial results into a `Report`."""
    by_group: dict[tuple[str, str, str, str], list[TrialResult]] = defaultdict(list)
    by_method: dict[tuple[str, str, str], list[TrialResult]] = defaultdict(list)
    for key, result in results:
        by_group[(key.hand, key.planner, key.observation, key.object)].append(result)
        by_method[(key.hand, key.planner, key.observation)].append(result)
    every = [r for _, r in results]
    return Report(
        overall=Rate.of(every),
        by_method={k: Rate.of(v) for k, v in sorted(by_method.items())},
        groups={k: Rate.of(v) for k, v in sorted(by_group.items())},
        auc=metric_aucs(every),
        pose_errors=pose_errors(by_group),
    )


def pose_errors(by_group: dict[tuple[str, str, str, str], list[TrialResult]]) -> dict[tuple[str, str, str], PoseErrors]:
    """Pose-error statistics per hand x planner x observation, over the objects whose pose was estimated."""
    per_method: dict[tuple[str, str, str], list[tuple[float, float, float]]] = defaultdict(list)
    for (hand, planner, observation, _), results in sorted(by_group.items()):
        first = results[0]
        if not math.isnan(first.pose_rotation_error_deg):
            per_method[(hand, planner, observation)].append(
                (first.pose_rotation_error_deg, first.pose_translation_error_mm, first.pose_add_s_mm))
    return {k: PoseErrors.of(v) for k, v in per_method.items()}


def metric_aucs(results: list[TrialResult]) -> dict[str, float]:
    """ROC AUC of each analytic metric predicting physical success (0.5 = no better than chance).

    Only trials that reached the simulator count (planner errors and invalid grasps have no metrics).
    """
    simulated = [r for r in results if r.status not in (Status.PLANNER_ERROR, Status.INVALID_GRASP)]
    labels = np.array([r.success for r in simulated], bool)
    out = {}
    for name, (part, attr, sign) in PREDICTORS.items():
        values = np.array([getattr(getattr(r, part) if part else r, attr) for r in simulated], float)
        values = np.where(np.isinf(values), np.sign(values) * 1e9, values)
        out[name] = roc_auc(sign * values, labels) if len(values) else math.nan
    return out


def format_rate(rate: Rate) -> str:
    """"0.85 [0.64, 0.95]" style."""
    if rate.trials == 0:
        return "-"
    return f"{rate.success_rate:.2f} [{rate.ci_low:.2f}, {rate.ci_high:.2f}]"
