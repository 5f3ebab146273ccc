"""Summaries of a run: success rates with Wilson intervals, failure modes, timing, metric AUCs per planner.

Every figure is per hand x planner x observation x protocol (a "method"; a run lists several protocols side by
side, `manigrasp.bench.trials`), and per object within it (the object's label: ``<name>@rest<i>`` for resting
pose i under ``rest: stable_k``).

`summarize` turns the stored trials into a `Report` (plain data, JSON-able);
`write_markdown` writes ``report.md`` with PNG plots beside it.
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from dataclasses import asdict, dataclass, field, replace
from fractions import Fraction
from pathlib import Path

import numpy as np

from manigrasp.bench.stats import AUC_INTERVAL_MIN_CLASS, AucEstimate, auc_with_interval, wilson_interval
from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.errors import ConfigError
from manigrasp.perception.metrics import pose_good
from manigrasp.protocol.result import PERCEPTION_FAILED, PLANNER_FAILURES, Status, TrialResult
from manigrasp.runfiles import STORE_NAME

# Metrics whose power to predict physical success is reported (column, higher-is-better sign).
PREDICTORS = {
    "epsilon_l1": ("planned", "epsilon_l1", 1.0),
    "force_closure": ("planned", "force_closure", 1.0),
    "min_friction": ("planned", "min_friction", -1.0),
    "sim_epsilon_l1": ("simulated", "epsilon_l1", 1.0),
    "planner_score": (None, "score", 1.0),
}


def metric_label(name: str) -> str:
    """A metric as tables and plots name it: its name, with " (lower = better)" where its AUC ranks the trials
    from low to high values (`PREDICTORS`' sign -1: ``min_friction``, the least friction coefficient that gives
    force closure), so an AUC above 0.5 always means that the better value goes with success. (The bare name read
    as an AUC of the value itself: min_friction's 0.44 on quick looked like "a higher friction need goes a little
    with success", the reverse of what it says.)"""
    sign = PREDICTORS.get(name, (None, None, 1.0))[2]
    return f"{name} (lower = better)" if sign < 0 else name


@dataclass(frozen=True)
class Rate:
    """Trials, successes, their rate and its Wilson 95 % interval, failure-mode counts, planning time.

    A trial that ended as `harness_fault` (a bug of manigrasp itself, neither physics nor the planner) is
    not mixed into the physics statistics (DESIGN.md): it is counted in `harness_faults` only, outside
    `trials`, `successes`, the rate and `failure_modes`. A failure of the planner (`planner_error`, or
    `no_grasp`: no candidate for the trial) is a failed trial like any other.

    Attributes:
        harness_faults: trials of this set that ended as `harness_fault`, left out of every other figure.
        median_planning_time_s: median over the planning calls of this set of trials of one call's wall
            time [s] (the ``planning_time_s`` that ``manigrasp plan`` prints: one call plans every candidate
            of an object x hand x planner x observation); NaN when no call was timed.
        planning_calls: how many planning calls that median is over.
        planning_timeouts: planning calls that ran out of their budget, left out of that median (their trials
            store the budget as their time, a bound and not a measurement: `planning_timed_out`).
    """

    trials: int
    successes: int
    success_rate: float
    ci_low: float
    ci_high: float
    failure_modes: dict[str, int] = field(default_factory=dict)
    median_planning_time_s: float = math.nan
    planning_calls: int = 0
    harness_faults: int = 0
    planning_timeouts: int = 0

    @classmethod
    def of(cls, results: list[TrialResult], plan_times: list[float] | None = None,
           plan_timeouts: int | None = None) -> Rate:
        """The rate of a list of trial results; `plan_times`: one wall time per planning call [s] (default: from
        `results`, as of one group), `plan_timeouts`: the planning calls that timed out (default: as of one
        group, 1 if any of `results` did)."""
        faults = sum(r.status is Status.HARNESS_FAULT for r in results)
        times = plan_times if plan_times is not None else planning_call_times(results)
        timeouts = plan_timeouts if plan_timeouts is not None else int(any(map(planning_timed_out, results)))
        results = [r for r in results if r.status is not Status.HARNESS_FAULT]
        n = len(results)
        k = sum(r.success for r in results)
        low, high = wilson_interval(k, n)
        modes = Counter(_mode(r) for r in results if not r.success)
        return cls(n, k, k / n if n else math.nan, low, high, dict(sorted(modes.items())),
                   float(np.median(times)) if times else math.nan, len(times), faults, timeouts)


def pooled_rate(rates: list[Rate]) -> Rate:
    """One rate of several sets of trials: their trials and successes summed, the Wilson interval of the sums (the
    failure modes and planning times are not carried over)."""
    n, k = sum(r.trials for r in rates), sum(r.successes for r in rates)
    return Rate(n, k, k / n if n else math.nan, *wilson_interval(k, n))


def planning_timed_out(result: TrialResult) -> bool:
    """Whether the trial's planning call ran out of its budget (`timeout` in planning: the trial's
    ``plan_time_s`` is the budget, not a measured time)."""
    return result.status is Status.TIMEOUT and result.detail.startswith("planning")


def planning_call_times(results: list[TrialResult]) -> list[float]:
    """One wall time per planning call among the results of one group (trials of one call share it); a call
    that timed out is left out (its time is the budget: `planning_timed_out`)."""
    return sorted({r.plan_time_s for r in results if math.isfinite(r.plan_time_s) and not planning_timed_out(r)})


def _mode(result: TrialResult) -> str:
    """The failure mode: the status, with its `perturb_direction` for `dropped_perturb` ("dropped_perturb+x")."""
    return result.status.value + (result.perturb_direction if result.status is Status.DROPPED_PERTURB else "")


# What each trial status means, one line each: report.md's legend of the outcomes that occur in a run
# (`manigrasp.bench.markdown.status_legend`) and docs/results.md's list (a test keeps them the same). The limits
# named are the `standard` protocol's defaults (docs/protocol.md); another protocol, or other params, has its own.
STATUS_MEANINGS: dict[Status, str] = {
    Status.SUCCESS: "every phase passed (lift, hold, the perturbations) and at least 2 finger bodies touch the "
                    "object at the end",
    Status.PREGRASP_COLLISION: "the open hand, placed 10 cm back along the approach before moving in, already "
                               "touches the object or the table",
    Status.NO_CONTACT: "no finger touches the object at the end of the close: the hand closed without touching it, "
                       "or gripped it and squeezed it out (the detail says which)",
    Status.SLIPPED_LIFT: "the object moved over 2 cm or 15 deg in the hand during the lift and hold, or was left "
                         "behind",
    Status.DROPPED_PERTURB: "with a direction (`dropped_perturb+x`...): the object moved over 2 cm or 15 deg in the "
                            "hand under the push along it (`six_direction`: or fewer than 2 fingers touched it after "
                            "that push); without one: it went through every push within those limits but fewer "
                            "than 2 finger bodies touch it at the end (detail \"only N finger(s) touch the object at "
                            "the end (need 2)\"), or (`shake`) it moved too far in the shake",
    Status.UNSTABLE: "the simulation failed: a NaN state, a MuJoCo warning or a divergence",
    Status.PLANNER_ERROR: "the planner (or the perception before it) raised, crashed its worker or returned an "
                          "invalid candidate; never simulated, counted against the planner",
    Status.NO_GRASP: "the planner returned fewer candidates than the trials asked for, so this trial had no grasp "
                     "to try; never simulated, counted against the planner",
    Status.INVALID_GRASP: "the grasp could not be executed as given (it cannot be read, or its pose or joints are "
                          "invalid); never simulated",
    Status.TIMEOUT: "a time budget ran out: the planning call's (the detail begins \"planning\") or the trial's",
    Status.HARNESS_FAULT: "a fault of manigrasp itself, neither the planner nor the physics: left out of every "
                          "rate and count",
}

# The rule of `PoseErrors.share_good`, as report.md says it under its perception table.
GOOD_POSE_RULE = ("One pose estimate per object (or object x resting pose). A pose is good when its translation error "
                  "is below 1 cm and its rotation error below 5 deg, or, for an object with a symmetry, its ADD-S "
                  "below 5 mm (every pose of the symmetry is as good as the truth, so the rotation error is given for "
                  "objects without one only); a failed estimate is not good.")


@dataclass(frozen=True)
class PoseErrors:
    """Errors of the estimated object poses of one hand x planner x observation (one per group: per object, or
    per object x resting pose under ``rest: stable_k``).

    Attributes:
        objects: estimated poses (groups with one; the JSON field keeps this name).
        median_rotation_deg, p90_rotation_deg: the rotation error over the estimates of objects without a
            symmetry (for one with a symmetry a pose of that symmetry is as good as the truth, so its rotation
            error says nothing); NaN if there are none.
        median_translation_mm, p90_translation_mm, median_add_s_mm: statistics over every estimate (NaN if none).
        share_good: fraction of the attempted estimates (`objects` + `failed`) whose pose is good by the perception
            pipeline's own rule (`manigrasp.perception.metrics.pose_good`): translation < 1 cm and rotation
            < 5 deg, or ADD-S < 5 mm for an object with a symmetry; a failed estimate is not good. A trial stored
            before its object's symmetry was recorded (`TrialResult.pose_symmetric` NaN) is judged by ADD-S, as
            every estimate was then; so did the older reports' ``share_add_s_5mm_translation_1cm`` (and, older
            still, ``share_within_5deg_1cm``), which `report_from_json` reads as this share.
        failed: estimates that failed (the object not in view, no model fits: the group's trials are
            `planner_error` "perception failed"); an older report has none recorded (0).
        symmetric: estimates of objects with a symmetry (left out of the rotation statistics).
        unrecorded: estimates whose object's symmetry was not recorded (trials stored before it was: in the
            rotation statistics, judged by ADD-S).
    """

    objects: int
    median_rotation_deg: float
    p90_rotation_deg: float
    median_translation_mm: float
    p90_translation_mm: float
    median_add_s_mm: float
    share_good: float
    failed: int = 0
    symmetric: int = 0
    unrecorded: int = 0

    @classmethod
    def of(cls, per_object: list[tuple[float, float, float, float]], failed: int = 0) -> PoseErrors:
        """From (rotation [deg], translation [mm], ADD-S [mm], symmetric: 1.0, 0.0 or NaN if not recorded) per
        object, and the count of failed estimates."""
        if not per_object:
            return cls(0, *[math.nan] * 5, 0.0, failed)
        rot, trans, adds, sym = (np.array(v, float) for v in zip(*per_object, strict=True))
        judged_by_add_s = sym != 0.0  # NaN (not recorded): by ADD-S, as every estimate was judged before
        good = sum(pose_good(*e) for e in zip(rot, trans, adds, judged_by_add_s, strict=True))
        asymmetric = rot[sym != 1.0]
        rotation = (float(np.median(asymmetric)), float(np.percentile(asymmetric, 90))) if len(asymmetric) else (
            math.nan, math.nan)
        return cls(len(per_object), *rotation, float(np.median(trans)), float(np.percentile(trans, 90)),
                   float(np.median(adds)), good / (len(per_object) + failed), failed, int(np.sum(sym == 1.0)),
                   int(np.sum(np.isnan(sym))))

    def notes(self) -> list[str]:
        """What the estimates' count leaves unsaid, as the console line and report.md give it: how many failed, are
        of objects with a symmetry, or were judged by ADD-S for want of their symmetry ("2 failed")."""
        return [f"{n} {what}" for n, what in ((self.failed, "failed"), (self.symmetric, "with a symmetry"),
                                              (self.unrecorded, "judged by ADD-S, stored before the symmetry was "
                                                                "recorded")) if n]


# The observation of a method is the trial key's observation label: its kind, with the camera setup's suffix
# when the run lists several setups (point_cloud@1view, point_cloud@2views: `BenchConfig.camera_labels`),
# so each setup is a method of its own, side by side with the others.
Method = tuple[str, str, str, str]  # hand, planner (its label), observation (its label), protocol (its label)
Group = tuple[str, str, str, str, str]  # hand, planner, observation, protocol, object (its label)

# What the all-trials line and the pooled AUCs pool, said wherever they are shown.
POOLED = "all trials of every hand x planner x observation x protocol"


@dataclass(frozen=True)
class Report:
    """A run's summary.

    Attributes:
        overall: every trial pooled (`POOLED`): mixes planners, so it is never the lead figure.
        by_method: per hand x planner x observation x protocol: the lead figures.
        groups: per hand x planner x observation x protocol x object.
        auc: per hand x planner x observation x protocol, each metric's AUC for success with its interval.
        auc_pooled: the same over every trial pooled (`POOLED`).
        pose_errors: estimated-pose errors per method.
        views: cameras the planner's observation came from, per method
            (0: no camera, ground truth; the largest if a method's trials differ).
    """

    overall: Rate
    by_method: dict[Method, Rate]
    groups: dict[Group, Rate]
    auc: dict[Method, dict[str, AucEstimate]] = field(default_factory=dict)
    auc_pooled: dict[str, AucEstimate] = field(default_factory=dict)
    pose_errors: dict[Method, PoseErrors] = field(default_factory=dict)
    views: dict[Method, int] = field(default_factory=dict)

    @property
    def protocols(self) -> list[str]:
        """The protocols (labels) of the run's trials, sorted."""
        return sorted({m[3] for m in self.by_method})

    def to_json(self) -> dict:
        """The JSON form printed by ``manigrasp report --json`` (NaN as null); ``scan_vs_recipe``: the rows of
        report.md's "Scan vs recipe" (`manigrasp.bench.twins.TwinRow.to_json`), empty without scans."""
        from manigrasp.bench import twins

        return _finite({
            "overall": {"pools": POOLED, **asdict(self.overall)},
            "methods": [{**_method(m), **asdict(r)} for m, r in self.by_method.items()],
            "groups": [{**_method(g[:4]), "object": g[4], **asdict(r)} for g, r in self.groups.items()],
            "auc": [{**_method(k), "metric": m, **asdict(e)} for k, per in self.auc.items() for m, e in per.items()],
            "auc_pooled": [{"pools": POOLED, "metric": m, **asdict(e)} for m, e in self.auc_pooled.items()],
            "pose_errors": [{**_method(k), **asdict(e)} for k, e in self.pose_errors.items()],
            "views": [{**_method(k), "views": v} for k, v in self.views.items()],
            "scan_vs_recipe": twins.json_rows(self.groups),
        })


def _method(method: tuple) -> dict[str, str]:
    return dict(zip(("hand", "planner", "observation", "protocol"), method, strict=True))


def _finite(value: object) -> object:
    """`value` with every NaN float replaced by None (JSON null), recursively."""
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return value


def _nan(value: object) -> object:
    return math.nan if value is None else value


def report_from_json(data: dict) -> Report:
    """Inverse of `Report.to_json` (for baselines committed as JSON); KeyError/TypeError on a malformed one. Each
    rate and its Wilson interval are recomputed from the stored counts.

    A report written before trials were keyed by protocol has entries without one: they get the run's protocol
    (``run.config.protocol.name``; "standard" if the run is not recorded).
    """
    default = _recorded_protocol(data)

    def method(d: dict) -> Method:
        return d["hand"], d["planner"], d["observation"], d.get("protocol", default)

    def rate(d: dict) -> Rate:
        r = Rate(**{k: _nan(d[k]) for k in Rate.__dataclass_fields__ if k in d})
        n, k = r.trials, r.successes
        if all(isinstance(v, int) and not isinstance(v, bool) for v in (n, k)) and 0 <= k <= n:
            # the rate and interval of the counts, not as stored: a hand-edited or stale file shows no figure
            # its counts do not give (counts that are not counts are refused by `compare.check_counts`)
            r = replace(r, success_rate=k / n if n else math.nan, **dict(zip(("ci_low", "ci_high"),
                                                                             wilson_interval(k, n), strict=True)))
        return r

    def auc(d: dict) -> AucEstimate:
        return AucEstimate(**{k: _nan(d[k]) for k in AucEstimate.__dataclass_fields__})

    per_method: dict[Method, dict[str, AucEstimate]] = defaultdict(dict)
    for a in data.get("auc", []):
        per_method[method(a)][a["metric"]] = auc(a)
    return Report(
        overall=rate(data["overall"]),
        by_method={method(m): rate(m) for m in data.get("methods", [])},
        groups={(*method(g), g["object"]): rate(g) for g in data["groups"]},
        auc=dict(per_method),
        auc_pooled={a["metric"]: auc(a) for a in data.get("auc_pooled", [])},
        pose_errors={method(e): _pose_errors(e) for e in data.get("pose_errors", [])},
        views={method(v): int(v["views"]) for v in data.get("views", [])},
    )


def _pose_errors(data: dict) -> PoseErrors:
    """`PoseErrors` from its JSON form (an older report's ``share_add_s_5mm_translation_1cm`` or
    ``share_within_5deg_1cm`` is `PoseErrors.share_good` as it was judged then)."""
    data = dict(data)
    for old in ("share_add_s_5mm_translation_1cm", "share_within_5deg_1cm"):
        if old in data:
            data.setdefault("share_good", data.pop(old))
    counts = ("failed", "symmetric", "unrecorded")  # an older report records none of them: 0
    values = {k: data[k] for k in PoseErrors.__dataclass_fields__ if k in data or k not in counts}
    return PoseErrors(**{k: _nan(v) for k, v in values.items()})  # JSON writes NaN as null


def _recorded_protocol(data: dict) -> str:
    """The protocol name a report's run recorded (``run.config.protocol.name``), else "standard"."""
    run = data.get("run")
    config = run.get("config") if isinstance(run, dict) else None
    protocol = config.get("protocol") if isinstance(config, dict) else None
    name = protocol.get("name") if isinstance(protocol, dict) else None
    return name if isinstance(name, str) else "standard"


def load_results(run_dir: Path) -> list[tuple[TrialKey, TrialResult]]:
    """Every stored trial of `run_dir`, read without writing (a read-only run directory works).

    Raises `ConfigError` when `run_dir` holds no ``results.sqlite`` (nothing is created).
    """
    path = Path(run_dir) / STORE_NAME
    if not path.is_file():
        raise ConfigError(f"{run_dir} holds no {STORE_NAME}: no trial has been run there "
                          "(run `manigrasp bench CONFIG --out RUN_DIR` first)")
    with ResultsStore(path, readonly=True) as store:
        return list(store.results())


def summarize(results: list[tuple[TrialKey, TrialResult]]) -> Report:
    """Aggregate trial results into a `Report`."""
    by_group: dict[Group, list[TrialResult]] = defaultdict(list)
    by_method: dict[Method, list[TrialResult]] = defaultdict(list)
    for key, result in results:
        method = (key.hand, key.planner, key.observation, key.protocol)
        by_group[(*method, key.object)].append(result)
        by_method[method].append(result)
    plan_times = {k: planning_call_times(v) for k, v in by_group.items()}
    timed_out = {k: int(any(map(planning_timed_out, v))) for k, v in by_group.items()}  # one call per group
    method_times: dict[Method, list[float]] = defaultdict(list)
    method_timeouts: dict[Method, int] = defaultdict(int)
    for group, times in sorted(plan_times.items()):
        method_times[group[:4]] += times
        method_timeouts[group[:4]] += timed_out[group]
    every = [r for _, r in results]
    return Report(
        overall=Rate.of(every, [t for times in method_times.values() for t in times], sum(timed_out.values())),
        by_method={k: Rate.of(v, method_times[k], method_timeouts[k]) for k, v in sorted(by_method.items())},
        groups={k: Rate.of(v, plan_times[k], timed_out[k]) for k, v in sorted(by_group.items())},
        auc={k: metric_aucs(v) for k, v in sorted(by_method.items())},
        auc_pooled=metric_aucs(every),
        pose_errors=pose_errors(by_group),
        views={k: max(int(r.camera_views or 0) for r in v) for k, v in sorted(by_method.items())},
    )


def pose_errors(by_group: dict[Group, list[TrialResult]]) -> dict[Method, PoseErrors]:
    """Pose-error statistics per method, over the objects whose pose was estimated: one estimate per group (its
    trials share it), read from the first of its trials that stores it (a trial that timed out or whose worker
    died stores none, `runner._failed_trial`); an estimate that failed (`PoseErrors.failed`) counts as not good."""
    per_method: dict[Method, list[tuple[float, float, float, float]]] = defaultdict(list)
    failed: dict[Method, int] = defaultdict(int)
    for group, results in sorted(by_group.items()):
        first = next((r for r in results if not math.isnan(r.pose_rotation_error_deg)), None)
        if first is not None:
            per_method[group[:4]].append(
                (first.pose_rotation_error_deg, first.pose_translation_error_mm, first.pose_add_s_mm,
                 first.pose_symmetric))
        elif group[2].partition("@")[0] == "estimated_pose" and any(
                r.status is Status.PLANNER_ERROR and r.detail.startswith(PERCEPTION_FAILED) for r in results):
            failed[group[:4]] += 1
    return {k: PoseErrors.of(per_method.get(k, []), failed.get(k, 0)) for k in sorted({*per_method, *failed})}


# Statuses of trials that never reached the simulator: they have no metrics to rank.
_NOT_SIMULATED = PLANNER_FAILURES | {Status.INVALID_GRASP, Status.HARNESS_FAULT}


def metric_aucs(results: list[TrialResult]) -> dict[str, AucEstimate]:
    """ROC AUC of each analytic metric predicting physical success, with n and a 95 % interval.

    Only trials that reached the simulator count (planner errors, trials without a grasp (`no_grasp`),
    invalid grasps and harness faults have no metrics); NaN values of a metric are dropped (its n says how
    many remain). A metric with one value in the set, or a set with one outcome, has an undefined AUC
    (`AucEstimate.undefined` says why).
    """
    simulated = [r for r in results if r.status not in _NOT_SIMULATED]
    labels = np.array([r.success for r in simulated], bool)
    out = {}
    for name, (part, attr, sign) in PREDICTORS.items():
        values = np.array([getattr(getattr(r, part) if part else r, attr) for r in simulated], float)
        values = np.where(np.isinf(values), np.sign(values) * 1e9, values)
        out[name] = auc_with_interval(sign * values, labels)
    return out


def round_half_up(value: Fraction | float | int, places: int = 2) -> str:
    """`value` as a decimal with `places` digits, rounded half up on its exact value (a float is read as the binary
    fraction it holds, never through its shortest decimal text): the one rounding rule of every printed rate and
    share, so a rate reads the same in a table, a console line and a plot. ``round_half_up(Fraction(5, 8))`` is
    "0.63" (Python's format gives "0.62": half to even); a negative value rounds its magnitude (-0.625: "-0.63")."""
    exact = Fraction(value)
    scale = 10 ** places
    units = math.floor(abs(exact) * scale + Fraction(1, 2))
    sign = "-" if exact < 0 and units else ""
    whole, part = divmod(units, scale)
    return f"{sign}{whole}" + (f".{part:0{places}d}" if places else "")


def format_share(successes: int, trials: int, percent: bool = False) -> str:
    """The share `successes` / `trials` from its counts (`round_half_up` of the exact fraction): "0.63" for 250 of
    400, or "63%" with `percent` (a plot's label: the same figure in hundredths); "-" without trials."""
    return "-" if trials == 0 else _share_text(Fraction(successes, trials), percent)


def format_stored_share(share: float, percent: bool = False) -> str:
    """A share held as a float that is a count over a count (`PoseErrors.share_good`), printed as `format_share`
    prints one from its counts: its fraction recovered (denominators of a few hundred at most) and rounded half up;
    "-" for NaN."""
    return _share_text(Fraction(share).limit_denominator(10 ** 6), percent) if math.isfinite(share) else "-"


def _share_text(share: Fraction, percent: bool) -> str:
    """An exact share as `round_half_up` prints it: "0.63", or "63%" with `percent`."""
    return f"{round_half_up(100 * share, 0)}%" if percent else round_half_up(share)


def format_rate(rate: Rate) -> str:
    """"0.85 [0.64, 0.95]" style: the rate from its counts (`format_share`) and its Wilson interval's bounds by the
    same rule (`round_half_up` of the floats' exact values)."""
    if rate.trials == 0:
        return "-"
    return f"{format_share(rate.successes, rate.trials)} [{round_half_up(rate.ci_low)}, {round_half_up(rate.ci_high)}]"


def format_auc(estimate: AucEstimate) -> str:
    """"0.81 [0.72, 0.89]", "1.00 [no interval: ...]" (too few of an outcome), or "undefined (metric
    constant)"."""
    if not estimate.defined:
        return f"undefined ({estimate.undefined})"
    if not estimate.bounded:
        return f"{estimate.auc:.2f} [no interval: under {AUC_INTERVAL_MIN_CLASS} of an outcome]"
    return f"{estimate.auc:.2f} [{estimate.low:.2f}, {estimate.high:.2f}]"


PLANNING_TIME_HEADER = "median planning call [s] (calls)"
"""The column of `format_planning_time` (not the export's per-candidate ``planning_time_s``)."""


def format_planning_time(rate: Rate) -> str:
    """"0.412 (5 calls)", or "-" when no planning call was timed: three significant digits (whole seconds from
    100 s), so a call of 0.42 ms reads 0.000420, not 0.000; calls that ran out of their budget are not timed and
    are said: "0.412 (5 calls; 1 more timed out)", "- (1 call timed out)"."""
    out = f"{rate.planning_timeouts} more timed out" if rate.planning_calls else \
        f"{rate.planning_timeouts} call{'s' * (rate.planning_timeouts != 1)} timed out"
    if not rate.planning_calls:
        return f"- ({out})" if rate.planning_timeouts else "-"
    seconds = rate.median_planning_time_s
    text = f"{seconds:#.3g}"
    if abs(float(text)) >= 100:  # (99.95 s rounds to "100." at three digits)
        text = f"{seconds:.0f}"
    calls = f"{rate.planning_calls} call{'s' * (rate.planning_calls != 1)}"
    return f"{text} ({calls}; {out})" if rate.planning_timeouts else f"{text} ({calls})"
