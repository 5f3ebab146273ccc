"""``report.md``: the tables of a run and its plots, for people to read."""

from __future__ import annotations

import json
import math
from collections import defaultdict
from dataclasses import astuple, replace
from itertools import combinations
from pathlib import Path

from manigrasp.bench import plots, twins
from manigrasp.bench.completeness import Completeness
from manigrasp.bench.plots import label_of
from manigrasp.bench.report import (
    GOOD_POSE_RULE,
    PLANNING_TIME_HEADER,
    POOLED,
    PREDICTORS,
    STATUS_MEANINGS,
    Method,
    PoseErrors,
    Rate,
    Report,
    format_auc,
    format_planning_time,
    format_rate,
    format_stored_share,
    metric_label,
)
from manigrasp.bench.store import TrialKey
from manigrasp.bench.trials import REST_LABEL, LeftOut, left_out
from manigrasp.protocol.result import DIRECTIONS, PoseRecord, Status, TrialResult
from manigrasp.runfiles import REPORT_NAME


def _table(headers: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _modes(modes: dict[str, int]) -> str:
    return ", ".join(f"{m} {n}" for m, n in sorted(modes.items(), key=lambda kv: -kv[1])) or "-"


def method_headers(report: Report) -> list[str]:
    """The columns naming a method in tables: hand, planner, observation (and protocol when the run has several)."""
    return ["hand", "planner", "observation"] + (["protocol"] if len(report.protocols) > 1 else [])


def method_cells(report: Report, method: Method) -> list[str]:
    """A method's cells under `method_headers`."""
    return list(method[:3]) + ([method[3]] if len(report.protocols) > 1 else [])


def _perception(report: Report) -> list[str]:
    """The side-by-side table of observations with their pose errors (empty without estimated poses): one row
    per hand x planner x observation label, so the camera setups of one kind (``point_cloud@1view``,
    ``point_cloud@2views``) are rows of their own: ground truth, estimated pose, point cloud, each by views."""
    if not report.pose_errors and {m[2] for m in report.by_method} <= {"ground_truth"}:
        return []
    rows = []
    kinds = ("ground_truth", "estimated_pose", "point_cloud")

    def order(method: Method) -> tuple:
        kind = method[2].partition("@")[0]
        return (*method[:2], method[3], kinds.index(kind) if kind in kinds else len(kinds), kind,
                report.views.get(method, 0), method[2])

    for m, r in sorted(report.by_method.items(), key=lambda item: order(item[0])):
        views = report.views.get(m, 0)
        rows.append([*method_cells(report, m), views or "-", format_rate(r), *_pose_cells(report.pose_errors.get(m))])
    return ["## Observations side by side (perception in the loop)",
            _table([*method_headers(report), "camera views", "rate [95% CI]", "pose estimates",
                    "rotation error deg, objects without a symmetry (median / p90)",
                    "translation error mm (median / p90)", "ADD-S mm (median)", "share of good poses"], rows),
            GOOD_POSE_RULE]


def _pose_cells(e: PoseErrors | None) -> tuple[str, ...]:
    """The perception table's pose cells of a method: the estimates attempted (one per object, or object x resting
    pose) and how many failed or are of objects with a symmetry, the error statistics ("-" where no estimate
    succeeded, or for the rotation where every one is of an object with a symmetry) and the share of good ones."""
    if e is None:
        return ("-",) * 5
    notes = e.notes()
    estimates = f"{e.objects + e.failed}" + (f" ({', '.join(notes)})" if notes else "")
    rotation = f"{e.median_rotation_deg:.1f} / {e.p90_rotation_deg:.1f}" if e.objects > e.symmetric else "-"
    errors = (rotation, f"{e.median_translation_mm:.1f} / {e.p90_translation_mm:.1f}", f"{e.median_add_s_mm:.1f}"
              ) if e.objects else ("-",) * 3
    return estimates, *errors, format_stored_share(e.share_good)


def auc_rows(report: Report) -> list[list[str]]:
    """AUC table rows per method (`method_cells`) x metric, then pooled rows (`all`) if several methods."""
    rows = [[*method_cells(report, m), metric_label(metric), f"{e.n} ({e.successes})", format_auc(e)]
            for m, per in report.auc.items() for metric, e in per.items()]
    if len(report.auc) > 1:
        pooled = ["all", "all (pooled)", "all"] + (["all"] if len(report.protocols) > 1 else [])
        rows += [[*pooled, metric_label(metric), f"{e.n} ({e.successes})", format_auc(e)]
                 for metric, e in report.auc_pooled.items()]
    return rows


def status_legend(report: Report) -> str:
    """What the outcomes that occur in the run mean (`STATUS_MEANINGS`), one line each, in the plots' order of
    outcomes; `dropped_perturb` once for all its directions. Empty for a run without trials."""
    seen = {Status.SUCCESS} if any(r.successes for r in report.by_method.values()) else set()
    for r in report.by_method.values():
        seen |= {s for s in Status for mode in r.failure_modes if mode == s.value
                 or mode.startswith(s.value) and mode[len(s.value):] in DIRECTIONS}  # dropped_perturb+x
        seen |= {Status.HARNESS_FAULT} if r.harness_faults else set()
    if not seen:
        return ""
    lines = [f"- `{status.value}`: {STATUS_MEANINGS[status]}." for status in Status if status in seen]
    return ("Outcomes of this run's trials (the `standard` protocol's limits are named; docs/protocol.md has every "
            "protocol's):\n\n" + "\n".join(lines))


def simulated_contact_note() -> str:
    """What report.md says of the metrics measured on the simulated contacts after the close (`PREDICTORS`'
    ``simulated`` ones): a trial that never touched the object has no value of them, so their n is smaller than
    the planned metrics' and their AUC ranks the touching grasps only."""
    names = [metric_label(name) for name, (part, _, _) in PREDICTORS.items() if part == "simulated"]
    if not names:
        return ""
    listed = ", ".join(f"`{n}`" for n in names)
    one = len(names) == 1
    return (f"{listed} {'is' if one else 'are'} measured on the contacts the simulation produced at the end of the "
            "close, so a trial that did not hold the object there (`pregrasp_collision`, `no_contact`, or one stopped "
            f"before: `timeout`, `unstable`) has no value: {'its' if one else 'their'} n is smaller than "
            f"`planner_score`'s in the same group, and {'its' if one else 'their'} AUC ranks the grasps that touched "
            "the object only (it says nothing of telling those failures from successes).")


def lead_lines(report: Report, order: list[str] | None = None) -> list[str]:
    """One line per hand x planner x observation (x protocol, in `order`: the config's, `protocol_order`): the
    figures a reader should quote."""
    rank = {p: i for i, p in enumerate(order or report.protocols)}
    methods = sorted(report.by_method, key=lambda m: (m[:3], rank.get(m[3], len(rank)), m[3]))
    return [f"{label_of(report, m)}: {report.by_method[m].successes}/"
            f"{report.by_method[m].trials} successes, rate {format_rate(report.by_method[m])}" for m in methods]


def pooled_line(report: Report) -> str:
    """The all-trials line, saying what it pools."""
    r, n = report.overall, len(report.by_method)
    mixed = [name for i, name in enumerate(("hands", "planners", "observations", "protocols"))
             if len({m[i] for m in report.by_method}) > 1]
    what = (f"{n} combinations, so it mixes {' and '.join(mixed)}" if n > 1 else "one combination, the line above")
    return f"Pooled ({POOLED}, {what}): {r.successes}/{r.trials}, rate {format_rate(r)}"


def protocol_order(report: Report, meta: dict | None = None) -> list[str]:
    """The run's protocols in its config's order (``protocols:`` of run.json, labelled as in trial ids), those
    not found there after them, sorted."""
    from manigrasp.bench.config import NamedEntry, labels

    listed = ((meta or {}).get("config") or {}).get("protocols")
    try:
        order = list(labels([NamedEntry(str(p["name"]), dict(p.get("params") or {})) for p in listed]))
    except (TypeError, KeyError, AttributeError, ValueError):  # no list recorded (or not one of entries)
        order = []
    return [p for p in order if p in report.protocols] + [p for p in report.protocols if p not in order]


def in_protocol_order(report: Report, order: list[str]) -> Report:
    """`report` with its methods, groups and AUCs listed in `order` of protocols (`protocol_order`: the config's)
    within each hand x planner x observation, so that every table and plot lists them as the lead lines do (they
    are sorted by name otherwise: six_direction before standard). The figures are the same."""
    rank = {p: i for i, p in enumerate(order)}

    def key(item: tuple) -> tuple:
        m = item[0]
        return (*m[:3], rank.get(m[3], len(rank)), m[3], *m[4:])

    return replace(report, by_method=dict(sorted(report.by_method.items(), key=key)),
                   groups=dict(sorted(report.groups.items(), key=key)), auc=dict(sorted(report.auc.items(), key=key)))


def protocol_rows(report: Report, order: list[str] | None = None) -> list[list[str]]:
    """Protocols side by side: per hand x planner x observation (object ``all objects``), then per object, each
    protocol's successes/trials and rate [95% CI] (columns in `order`, default `Report.protocols`)."""
    order = order or report.protocols
    per_method: dict[tuple, dict[str, Rate]] = defaultdict(dict)
    per_object: dict[tuple, dict[str, Rate]] = defaultdict(dict)
    for m, r in report.by_method.items():
        per_method[(*m[:3], "all objects")][m[3]] = r
    for g, r in report.groups.items():
        per_object[(*g[:3], g[4])][g[3]] = r
    return [[*key, *(_rate_cell(per.get(p)) for p in order)]
            for rates in (per_method, per_object) for key, per in sorted(rates.items())]


def _rate_cell(rate: Rate | None) -> str:
    return "-" if rate is None else f"{rate.successes}/{rate.trials}, {format_rate(rate)}"


def paired_rows(report: Report, results: list[tuple[TrialKey, TrialResult]], order: list[str] | None = None
                ) -> list[list[str]]:
    """Per hand x planner x observation and pair of protocols (in `order`), over the trials run under both (same
    object, grasp rank and seed: the paired design of `manigrasp.bench.trials`): pairs, how many of them executed
    the very same grasp pose (all, unless the planner adapts its plan to the protocol), both succeed, only the
    first, only the second, neither, and the exact McNemar p-value (two-sided binomial test of the discordant
    pairs: how likely a split this uneven is if the protocols were equally hard). A pair with a `harness_fault`
    on either side is left out, as every rate leaves those trials out (a bug of manigrasp is neither outcome)."""
    from manigrasp.bench.stats import mcnemar_p

    outcome: dict[tuple, dict[str, TrialResult]] = defaultdict(dict)
    for key, result in results:
        if result.status is not Status.HARNESS_FAULT:
            outcome[(key.hand, key.planner, key.observation, key.object, key.grasp_index)][key.protocol] = result
    rows = []
    for method in sorted({m[:3] for m in report.by_method}):
        for a, b in combinations(order or report.protocols, 2):
            pairs = [(v[a], v[b]) for k, v in outcome.items() if k[:3] == method and a in v and b in v]
            if pairs:
                same = sum(_same_pose(x.grasp, y.grasp) for x, y in pairs)
                wins = [(x.success, y.success) for x, y in pairs]
                both, first, second = (sum(x and y for x, y in wins), sum(x and not y for x, y in wins),
                                       sum(y and not x for x, y in wins))
                p = mcnemar_p(first, second)
                rows.append([*method, f"{a} vs {b}", len(pairs), same, both, first, second,
                             len(pairs) - both - first - second, f"{p:.3g}"])
    return rows


def _same_pose(a: PoseRecord, b: PoseRecord) -> bool:
    """True if both poses are stored (no NaN) and equal."""
    values = [astuple(a), astuple(b)]
    return all(math.isfinite(v) for v in values[0]) and values[0] == values[1]


def _protocols(report: Report, results: list[tuple[TrialKey, TrialResult]], meta: dict) -> list[str]:
    """The "Protocols side by side" section (nothing for a run with one protocol)."""
    if len(report.protocols) < 2:
        return []
    order = protocol_order(report, meta)
    return ["## Protocols side by side",
            "Every group ran under each protocol with the same planning and trial seeds: the protocols are "
            "compared on the same draw of grasps (the very same grasps unless the planner adapts its plan to the "
            "protocol's grip force and loads; 'same grasp' below counts them). Rates with 95 % Wilson intervals.",
            _table(["hand", "planner", "observation", "object", *order], protocol_rows(report, order)),
            "Paired outcomes (the same object, grasp rank and seed under both protocols); McNemar p: exact two-sided "
            "test of the pairs that only one protocol held.",
            _table(["hand", "planner", "observation", "protocols (first vs second)", "pairs", "same grasp",
                    "both succeed",
                    "only the first", "only the second", "neither", "McNemar p"], paired_rows(report, results, order))]


def rest_rows(results: list[tuple[TrialKey, TrialResult]]) -> list[list[str]]:
    """One row per object label run in a computed stable pose (``rest: most_stable | stable_k``): the pose's
    rank, probability, rotation (quaternion w, x, y, z) and height as stored with its trials."""
    first: dict[str, TrialResult] = {}
    for key, result in results:
        if int(_finite_or(result.rest_index, -1)) >= 0:
            kept = first.get(key.object)
            if kept is None or (math.isnan(kept.rest_probability) and not math.isnan(result.rest_probability)):
                first[key.object] = result
    rows = []
    for obj, r in sorted(first.items()):
        pose = r.rest_pose
        known = not math.isnan(r.rest_probability)
        rows.append([obj, int(r.rest_index), f"{r.rest_probability:.3f}" if known else "-",
                     f"({pose.qw:.3f}, {pose.qx:.3f}, {pose.qy:.3f}, {pose.qz:.3f})" if known else "-",
                     f"{1000 * pose.z_m:.1f}" if known else "-"])
    return rows


def _finite_or(value: float, default: float) -> float:
    return default if isinstance(value, float) and math.isnan(value) else value


def _rests(results: list[tuple[TrialKey, TrialResult]], meta: dict) -> list[str]:
    """The "Resting poses" section: each object's computed stable pose(s), and which objects have fewer stable
    poses than ``rest_k`` asks for (they run as many as they have)."""
    rows = rest_rows(results)
    if not rows:
        return []
    scene = (meta.get("config") or {}).get("scene") or {}
    k = scene.get("rest_k")
    text = ("Each object rests in its stable poses (trimesh's quasi-static estimate), the most probable first; "
            "`<name>@rest<i>` is pose i, a group of its own.")
    if isinstance(k, int):
        per_object: dict[str, int] = defaultdict(int)
        for row in rows:
            per_object[str(row[0]).rpartition(REST_LABEL)[0] or str(row[0])] += 1
        fewer = [f"{name} ({n})" for name, n in sorted(per_object.items()) if n < k]
        text += f" rest_k = {k}." + (f" Fewer stable poses than {k}, so as many groups as poses: {', '.join(fewer)}."
                                     if fewer else "")
    return ["## Resting poses", text,
            _table(["object", "pose rank", "probability", "rotation (w, x, y, z)", "height [mm]"], rows)]


def warning_lines(meta: dict, done: Completeness | None = None, report: Report | None = None) -> list[str]:
    """What a reader must know before quoting a figure of the run: that it is incomplete (`Completeness`), that
    some trials are harness faults (a bug of manigrasp itself, left out of every rate: `Rate.harness_faults`), or
    that it was resumed by other code (run.json's ``resumed_with_other_code``: its trials mix two code versions)."""
    lines = [done.warning()] if done is not None and done.warning() else []
    faults = {m: r.harness_faults for m, r in (report.by_method.items() if report else ())}
    if any(faults.values()):
        where = ", ".join(f"{label_of(report, m)} {n}" for m, n in faults.items() if n)
        lines.append(f"{sum(faults.values())} trial(s) ended as harness_fault, a fault of manigrasp itself and not of "
                     f"the planner or the physics ({where}): they are left out of every rate and count (they are "
                     "not physics results); their detail in the results table says what failed")
    for entry in meta.get("resumed_with_other_code") or []:
        # An entry counts the trials stored by the other code (`rundir.record_other_code`); one without a count
        # was written by older code, which recorded every resumption, also one that ran no trial.
        if isinstance(entry, dict) and entry.get("trials", 1) != 0:
            changes = "; ".join(map(str, entry.get("changes") or []))
            count = f"{entry['trials']} trial(s) stored then" if isinstance(entry.get("trials"), int) else "the trials"
            lines.append(f"resumed at {entry.get('at')} by other code ({changes}): {count} and the trials stored "
                         "before may differ by that code")
    return lines


def left_out_of(meta: dict) -> list[LeftOut]:
    """The object x hand pairs the run's config (run.json) leaves out, with their reasons (`trials.left_out`).

    A recorded config that no longer parses (written by other code) is read as recorded: each object entry's
    ``exclude`` for the hands listed, the object named as a parsed config names it (`ObjectEntry.recorded`, then
    `ObjectEntry.trial_name`: a shipped alias by its object's name, as in the trial ids).
    """
    from manigrasp.bench.config import ObjectEntry, parse_config
    from manigrasp.errors import ManigraspError

    config = meta.get("config")
    objects = config.get("objects") if isinstance(config, dict) else None
    if not isinstance(objects, list) or not any(isinstance(o, dict) and o.get("exclude") for o in objects):
        return []
    folder = meta.get("config_dir")
    base = Path(folder) if isinstance(folder, str) else None
    try:
        return left_out(parse_config(config, where="run.json"), base)
    except (ManigraspError, TypeError, ValueError):
        hands = config.get("hands") if isinstance(config.get("hands"), list) else []
        return [LeftOut(ObjectEntry.recorded(o).trial_name(base), str(hand), str(reason))
                for o in objects if isinstance(o, dict) and isinstance(o.get("exclude"), dict)
                for hand, reason in o["exclude"].items() if hand in hands]


def left_out_section(pairs: list[LeftOut]) -> list[str]:
    """The "Left out by the config" section (nothing when every object x hand ran)."""
    if not pairs:
        return []
    return ["## Left out by the config",
            f"{len(pairs)} object x hand pair(s) ran no trial (the object entry's `exclude` in the config), so no rate "
            "or count of this report includes them; the reasons are the config's.",
            _table(["hand", "object", "reason"], [[p.hand, p.object, p.reason] for p in pairs])]


def _entry(entry: object) -> str:
    """A recorded protocol or planner entry as "`name`", with its parameters when it has any: the tables label a
    run's entries by name, so a `standard` run at a 10 N grip must say so where the figures are."""
    if not isinstance(entry, dict):
        return f"`{entry}`"
    params = entry.get("params") or {}
    return f"`{entry.get('name')}`" + (f" ({', '.join(f'{k}={v}' for k, v in params.items())})" if params else "")


def _capped_grips(config: dict, entries: list, limits: dict | None = None) -> str:
    """" (grip_force=500 is above a hand's force: parallel_jaw closes at its 70.6 N)" for the hands of `config`
    weaker than a protocol's absolute `grip_force` (the close caps the target at `Hand.max_grip_force`, so the
    parameter alone would state a force no trial applied); "" when none is. The forces are the run's own
    (`limits`: run.json's ``hand_grip_limits``, recorded when it started); a run recorded before them reads the
    hand models installed here, and says nothing of a hand that cannot be loaded here."""
    from manigrasp.hands.registry import load

    asked = [float(p["params"]["grip_force"]) for p in entries
             if isinstance(p, dict) and isinstance(p.get("params"), dict)
             and isinstance(p["params"].get("grip_force"), int | float)]
    if not asked:
        return ""
    weaker = []
    for name in config.get("hands") or []:
        if isinstance(limits, dict) and isinstance(limits.get(name), int | float):
            force = float(limits[name])
        else:
            try:
                force = float(load(str(name)).max_grip_force)
            except Exception:  # noqa: BLE001 (a user hand not importable where the report is made: say nothing)
                continue
        if force < max(asked):
            weaker.append(f"{name} closes at its {force:.1f} N")
    if not weaker:
        return ""
    return f" (grip_force={max(asked):g} N is above a hand's force: {', '.join(weaker)})"


def _protocol_line(config: dict, limits: dict | None = None) -> str:
    """"Protocol `standard`", "Protocols `standard` (grip_force=10.0), `six_direction` (...)", then the planners
    with their parameters; a grip force above a hand's maximum says which hands close at their maximum
    (`limits`: run.json's ``hand_grip_limits``)."""
    protocols = config.get("protocols")
    if isinstance(protocols, list) and protocols:
        line = "Protocols " + ", ".join(_entry(p) for p in protocols) + _capped_grips(config, protocols, limits)
    else:
        entry = config.get("protocol") or {"name": "standard"}
        line = f"Protocol {_entry(entry)}{_capped_grips(config, [entry], limits)}"
    planners = config.get("planners")
    if isinstance(planners, list) and planners:
        line += f"; planner{'s' * (len(planners) != 1)} " + ", ".join(_entry(p) for p in planners)
    return line


def _scene_text(config: dict) -> str:
    """"scene: pads=compliant, rest=stable_k, rest_k=3 (every other scene parameter at its default)": the pad model
    always (a rigid-pad run's figures differ from a compliant one's, and its header read the same), then each
    recorded scene parameter that differs from this version's default, sorted; "" when the run records no scene."""
    from manigrasp.bench.config import scene_overrides

    scene = config.get("scene")
    if not isinstance(scene, dict):
        return ""
    differ = {k: v for k, v in scene_overrides(scene).items() if k != "pads"}
    shown = ({"pads": scene["pads"]} if "pads" in scene else {}) | dict(sorted(differ.items()))
    text = ", ".join(f"{k}={v if isinstance(v, str) else json.dumps(v)}" for k, v in shown.items())
    return f"; scene: {text or 'defaults'} (every other scene parameter at its default)"


def write_markdown(report: Report, results: list[tuple[TrialKey, TrialResult]], run_dir: Path,
                   meta: dict, done: Completeness | None = None) -> Path:
    """Write ``report.md`` and its PNGs into `run_dir`; returns the markdown path. `done`: how complete the run
    is (`manigrasp.bench.completeness.completeness`; None: not checked), said first when it is not."""
    run_dir = Path(run_dir)
    report = in_protocol_order(report, protocol_order(report, meta))
    images = {
        "Success rate per object": plots.success_by_object(report, run_dir / "success_by_object.png"),
        "Success rate per hand and planner": plots.success_by_method(report, run_dir / "success_by_method.png"),
        "Outcomes": plots.failure_modes(report, run_dir / "failure_modes.png"),
        "Planning time": plots.planning_times(results, run_dir / "planning_time.png", list(report.by_method)),
        "How well each analytic metric predicts success": plots.metric_auc(report, run_dir / "metric_auc.png"),
    }
    config = meta.get("config", {})
    headers = method_headers(report)
    parts = [
        f"# manigrasp report: {config.get('name', run_dir.name)}",
        f"{_protocol_line(config, meta.get('hand_grip_limits'))}{_scene_text(config)}, seed {meta.get('seed')}, "
        f"manigrasp {meta.get('versions', {}).get('manigrasp')}, mujoco {meta.get('versions', {}).get('mujoco')}, "
        f"commit {meta.get('git_commit') or 'unknown'}, started {meta.get('started')}.",
        *(f"**Warning: {line}.**" for line in warning_lines(meta, done, report)),
        "\n".join(f"- **{line}**" for line in lead_lines(report, protocol_order(report, meta)))
        + "\n\nRates with 95 % Wilson intervals. " + pooled_line(report) + ".",
        *left_out_section(left_out_of(meta)),
        "## Per hand and planner",
        _table([*headers, "trials", "successes", "rate [95% CI]", "failure modes", PLANNING_TIME_HEADER],
               [[*method_cells(report, m), r.trials, r.successes, format_rate(r), _modes(r.failure_modes),
                 format_planning_time(r)] for m, r in report.by_method.items()]),
        "Planning time: the wall time of one planning call, which plans every candidate of one object (what "
        "`manigrasp plan` prints as `planning_time_s`; the exported table's `plan_time_s`, whose `planning_time_s` "
        "is that call divided by the number of candidates it returned, or the whole call where it returned none: "
        "its trials end `planner_error` or `no_grasp`); the median is over the calls. A call that ran out of its "
        "budget has no time (its trials end `timeout`) and is counted apart (\"1 more timed out\").",
        *filter(None, [status_legend(report)]),
        *_protocols(report, results, meta),
        "## Per object",
        _table([*headers, "object", "trials", "successes", "rate [95% CI]", "failure modes"],
               [[*method_cells(report, g[:4]), g[4], r.trials, r.successes, format_rate(r), _modes(r.failure_modes)]
                for g, r in report.groups.items()]),
        *_rests(results, meta),
        *_perception(report),
        *twins.markdown_section(report),
        "## Analytic metrics as predictors of success",
        f"ROC AUC of each metric for telling successes from failures within one {' x '.join(headers)} (0.5 = chance), "
        "ranking the trials by the metric's better values (higher, or lower where it says so: above 0.5 the better "
        "value goes with success), with a 95 % bootstrap interval (resampled within successes and failures, fixed "
        "seed). n counts the simulated trials with a value of the metric (successes in brackets). A metric with a "
        "single value in a group cannot rank its trials: its AUC is undefined, not 0.5. " + simulated_contact_note()
        + (f" Rows `all` pool every trial of every {' x '.join(headers)}: there a metric partly tells those "
           "apart (planners, protocols) instead of ranking the grasps of one." if len(report.auc) > 1 else ""),
        _table([*headers, "metric", "n (successes)", "AUC [95% CI]"], auc_rows(report)),
    ]
    parts += [f"## {title}\n\n![{title}]({path.name})" for title, path in images.items()]
    out = run_dir / REPORT_NAME
    out.write_text("\n\n".join(parts) + "\n")
    return out
