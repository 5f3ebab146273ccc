"""Regression gate: is any success rate significantly lower than a baseline's?

Only groups (hand x planner x observation x protocol x object) present on both sides are compared; the ones
missing on either side are listed (a run with several protocols compares, against a baseline of one, the groups
of that protocol). One-sided pooled two-proportion z-tests per group, per hand x planner x observation x protocol
over its groups in both, and over all groups in both pooled. The gate fails if any of the three families (the
pooled line, the method lines, the group lines) flags, so each family gets a third of alpha (Bonferroni across
the families; a half or all of it where a family repeats another's tests: one method's line is the pooled line,
a method of one group is that group's test), and within one the p-values are Holm-Bonferroni corrected (across
groups, across methods): the chance that a run as good as its baseline fails the gate stays under alpha.
(Runs drawn at the committed baselines' own rates on both sides fail the gate 2.3 % (quick) and 3.3 %
(dexterous) of the time at alpha 0.05, against 8.5 and 8.6 % with each family at the whole alpha:
`benchmarks/bench_gate.py`.) The per-method and all-groups lines are stratified by group
(Cochran-Mantel-Haenszel, `stats.stratified_lower_than_baseline`): their pooled counts are shown, but pooled
counts would also test the mix of groups, and fewer trials of an easy object on one side (its harness faults,
left out of every count) read as a regression where no group's rate moved. A group that one side holds only part
of (fewer trials stored than its `grasps_per_object`, an interrupted run) is not compared and is listed: its
first trials are a ranked planner's first candidates, not the population of all of them. The z-tests are normal
approximations: with few trials per group they are anti-conservative (2/2 against 0/2 gives p = 0.023 where
Fisher's exact test gives 0.17); the corrections keep the gate's error rate, and a small group alone decides
little.

A gate that cannot fail is no gate: anything it cannot judge raises `ConfigError` (exit 2 at the CLI): an
alpha outside (0, 1), counts that are not counts (successes > trials, NaN, negative), no trials in common,
and two sides whose physics (scene) parameters, or the parameters of a protocol, hand, planner or object
present on both sides, differ; so do their `grasps_per_object` (a ranked planner's first 5 candidates are
not the population of its first 20) and, when perception groups are compared, their cameras. An object x hand
present on both sides that one side leaves out (`manigrasp.bench.config.ObjectEntry.exclude`) and the other
runs is refused too, so that a run does not quietly compare over a smaller set of groups than its baseline's;
the reason texts are not compared (they change no trial).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from manigrasp.bench.completeness import completeness
from manigrasp.bench.config import effective_entry
from manigrasp.bench.report import Group, Rate, Report, load_results, pooled_rate, report_from_json, summarize
from manigrasp.bench.stats import (
    ProportionTest,
    lower_than_baseline,
    stratified_lower_than_baseline,
)
from manigrasp.errors import ConfigError

POOLED_GROUP = "pooled (groups in both)"
METHOD_WORDS = "hand x planner x observation x protocol"
GROUP_WORDS = f"{METHOD_WORDS} x object"
P_NOTE = (f"p (adjusted): one-sided; Holm-adjusted across the {GROUP_WORDS} groups and, apart, across the "
          f"{METHOD_WORDS} lines, then each family (groups, methods, the pooled line) x the number of families "
          "(3; fewer where one repeats another: a single method, methods of one group each), its share of alpha, "
          "so that a run as good as its baseline fails by chance less often than alpha; the lines over several "
          "groups show their pooled counts and are tested stratified by group (Cochran-Mantel-Haenszel; difference: "
          "Mantel-Haenszel), so a different mix of groups alone is no regression")
# Config fields that must be equal on both sides for their success rates to be comparable (and every protocol,
# hand and object present on both sides).
_SAME = ("scene",)
# Versions whose difference is worth a note (physics may differ between them).
_NOTED_VERSIONS = ("manigrasp", "mujoco")


@dataclass(frozen=True)
class Side:
    """One side of a comparison: its report, the run's metadata (config, versions), where it came from, and what
    a reader must know of it (an incomplete run: `manigrasp.bench.markdown.warning_lines`)."""

    report: Report
    meta: dict
    source: str
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True)
class Comparison:
    """One compared rate: its name, both rates, the test, the corrected p-value, the verdict.

    Attributes:
        group: `POOLED_GROUP`, "hand/planner/observation/protocol (objects in both)" or
            "hand/planner/observation/protocol/object".
        kind: "pooled", "method" or "group".
    """

    group: str
    new: Rate
    base: Rate
    test: ProportionTest
    adjusted_p: float
    regression: bool
    kind: str = "group"


@dataclass(frozen=True)
class Verdict:
    """The comparisons, the groups found on one side only, notes (version differences, each side's warnings) and
    the groups in both that one side holds only in part (`partial_groups`: listed, not compared)."""

    comparisons: list[Comparison]
    only_new: list[Group]
    only_base: list[Group]
    notes: list[str]
    partial: list[Group] = field(default_factory=list)

    @property
    def regressions(self) -> list[Comparison]:
        """The comparisons flagged as significant regressions."""
        return [c for c in self.comparisons if c.regression]

    @property
    def groups_compared(self) -> int:
        """How many hand x planner x observation x protocol x object groups were compared."""
        return sum(c.kind == "group" for c in self.comparisons)

    def summary(self, alpha: float) -> str:
        """The verdict in one line, each kind of test counted apart: "2 significant regression(s) at alpha = 0.05:
        1 of the 10 ... group(s) in both, 1 of the 2 ... line(s) over their groups in both, not the pooled line
        (...)". (The regressions of all kinds counted "over 10 group(s)" read as 2 of 10 groups where one was.)"""
        def counted(kind: str) -> tuple[int, int]:
            tests = [c for c in self.comparisons if c.kind == kind]
            return sum(c.regression for c in tests), len(tests)

        (g, groups), (m, methods), (p, _) = counted("group"), counted("method"), counted("pooled")
        return (f"{len(self.regressions)} significant regression(s) at alpha = {alpha}: {g} of the {groups} "
                f"{GROUP_WORDS} group(s) in both, {m} of the {methods} {METHOD_WORDS} line(s) over their groups in "
                f"both, {'and' if p else 'not'} the pooled line ({POOLED_GROUP})")


def load_side(path: Path) -> Side:
    """A run directory (run.json + results.sqlite) or a baseline JSON file (`manigrasp report --json`)."""
    from manigrasp.bench.rundir import load_meta

    path = Path(path)
    if not path.exists():
        raise ConfigError(f"{path} does not exist (expected a run directory or a baseline JSON file)")
    if path.is_dir():
        from manigrasp.bench.markdown import warning_lines
        from manigrasp.bench.rundir import config_dir

        meta, results = load_meta(path), load_results(path)
        report = summarize(results)
        warnings = warning_lines(meta, completeness(results, meta, config_dir(path)), report)
        return Side(report, meta, str(path), tuple(warnings))
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConfigError(f"cannot read baseline {path}: {exc}") from exc
    if not isinstance(data, dict):
        raise ConfigError(f"baseline {path} is not a report (a JSON object from `manigrasp report --json`)")
    try:
        _refuse_repeated_groups(data)
        report = report_from_json(data)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ConfigError(f"baseline {path} is not a valid report ({type(exc).__name__}: {exc}); "
                          "write one with `manigrasp report RUN_DIR --json > FILE`") from exc
    from manigrasp.bench.markdown import warning_lines

    run = data.get("run") if isinstance(data.get("run"), dict) else {}
    done = data.get("completeness")  # written by `report --json` since it checks completeness
    warnings: list[str] = []
    if isinstance(done, dict) and done.get("complete") is False:
        warnings.append(f"recorded from an incomplete run ({done.get('stored')} of {done.get('expected')} trials "
                        "stored)")
    # Its harness faults and a resumption by other code, as a run directory's side says them (they were not).
    warnings += warning_lines(run, None, report)
    return Side(report, run, str(path), tuple(warnings))


def _refuse_repeated_groups(data: dict) -> None:
    """A baseline listing one group twice is malformed (reading it would keep one of the two silently)."""
    keys = [(g["hand"], g["planner"], g.get("observation"), g.get("protocol"), g["object"])
            for g in data["groups"]]
    repeated = sorted({"/".join(map(str, k)) for k in keys if keys.count(k) > 1})
    if repeated:
        raise ValueError(f"group(s) listed more than once: {', '.join(repeated)}")


def check_counts(report: Report, source: str) -> None:
    """Raise `ConfigError` unless every group holds whole trials >= 0 and 0 <= successes <= trials."""
    for group, rate in report.groups.items():
        t, k = rate.trials, rate.successes
        if not (_count(t) and _count(k) and k <= t):
            raise ConfigError(f"{source}: group {'/'.join(group)} has {k!r} successes of {t!r} trials: "
                              "not counts (need whole numbers with 0 <= successes <= trials)")


def _count(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def check_comparable(new: Side, base: Side, perception: bool = False) -> list[str]:
    """Raise `ConfigError` naming what differs when the two runs' physics cannot be compared.

    The scene (physics) must be equal; a protocol or planner (by label), hand or object present on both sides
    must be defined the same way (a built-in protocol's or planner's parameters at their effective values, the
    defaults each side's run.json recorded it ran with where it did, `_effective_pairs`: one written out at its
    default is the same as one left out); `grasps_per_object` must be equal where both record
    it, and the camera setup(s) too when `perception` groups are compared. Returns notes on version differences
    (not refused).
    """
    configs = [side.meta.get("config") for side in (new, base)]
    for side, config in zip((new, base), configs, strict=True):
        if not isinstance(config, dict):
            raise ConfigError(f"{side.source} records no config, so it cannot be checked as comparable; "
                              "write a baseline with `manigrasp report RUN_DIR --json > FILE`")
    new_config, base_config = configs
    differ = [d for key in _SAME for d in _differences(new_config.get(key), base_config.get(key), key)]
    used = [side.meta.get("effective") for side in (new, base)]
    ours, theirs = _effective_pairs(_protocols(new_config), _protocols(base_config), "protocol", used)
    if len(ours) == len(theirs) == 1:  # one protocol each: it must be the same one
        differ += _differences(*ours.values(), *theirs.values(), "protocol")
    for label in sorted(ours.keys() & theirs.keys()) if len(ours) > 1 or len(theirs) > 1 else ():
        differ += _differences(ours[label], theirs[label], f"protocol {label!r}")
    for key in ("hands", "objects"):
        ours, theirs = _entries(new_config.get(key)), _entries(base_config.get(key))
        for name in sorted(ours.keys() & theirs.keys()):
            differ += _differences(_without_exclude(ours[name]), _without_exclude(theirs[name]), f"{key[:-1]} {name!r}")
    differ += _exclusion_differences(new_config, base_config)
    ours, theirs = _effective_pairs(_planners(new_config), _planners(base_config), "planner", used)
    for label in sorted(ours.keys() & theirs.keys()):
        differ += _differences(ours[label], theirs[label], f"planner {label!r}")
    for key in ("grasps_per_object", *(("camera",) if perception else ())):
        if key in new_config and key in base_config:
            differ += _differences(new_config[key], base_config[key], key)
    if differ:
        raise ConfigError(f"{new.source} and {base.source} are not comparable: different " + "; ".join(differ))
    versions = [side.meta.get("versions") or {} for side in (new, base)]
    return [f"{name} {versions[0].get(name)} here vs {versions[1].get(name)} in the baseline"
            for name in _NOTED_VERSIONS if versions[0].get(name) != versions[1].get(name)]


def _protocols(config: dict) -> dict[str, object]:
    """A recorded config's protocols by label (`BenchConfig.protocol_labels`), as recorded."""
    from manigrasp.bench.config import NamedEntry, labels

    listed = config.get("protocols")
    if not isinstance(listed, list) or not listed:
        single = config.get("protocol")
        name = single.get("name") if isinstance(single, dict) else None
        return {str(name): single}
    try:
        entries = [NamedEntry(str(p["name"]), dict(p.get("params") or {})) for p in listed]
        return dict(zip(labels(entries, "protocol"), listed, strict=True))
    except (KeyError, TypeError, AttributeError, ConfigError) as exc:
        raise ConfigError(f"a recorded config's protocols are malformed ({exc})") from None


def _planners(config: dict) -> dict[str, dict]:
    """A recorded config's planners by label (`BenchConfig.planner_labels`) as {name, params}."""
    from manigrasp.bench.config import NamedEntry, labels

    listed = config.get("planners")
    if not isinstance(listed, list):
        return {}
    try:
        entries = [NamedEntry(p, {}) if isinstance(p, str) else NamedEntry(str(p["name"]), dict(p.get("params") or {}))
                   for p in listed]
        return {label: {"name": e.name, "params": dict(e.params)} for label, e in zip(labels(entries), entries,
                                                                                      strict=True)}
    except (KeyError, TypeError, AttributeError, ConfigError) as exc:
        raise ConfigError(f"a recorded config's planners are malformed ({exc})") from None


def _effective_pairs(ours: dict[str, object], theirs: dict[str, object], kind: str,
                     used: list[object] | None = None) -> tuple[dict[str, object], dict[str, object]]:
    """Both sides' protocol or planner entries by label, each label's pair with every parameter at its effective
    value (`effective_entry`) where both can be built here, else both as recorded (so a parameter this code does not
    know is named alone, "absent vs baseline 2.0").

    `used` (ours, theirs): each side's run.json ``effective`` (`effective_entries`, recorded when the run
    started; None for a run recorded before it): the values its code ran with override this code's defaults,
    so a default changed since a baseline was recorded is a difference, not read as the same run."""
    ours, theirs = dict(ours), dict(theirs)
    used = used or [None, None]
    for label in ours.keys() & theirs.keys():
        pair = [effective_entry(side[label], kind, _recorded_effective(record, kind, label))
                for side, record in zip((ours, theirs), used, strict=True)]
        if all(p is not None for p in pair):
            ours[label], theirs[label] = pair
    return ours, theirs


def _recorded_effective(record: object, kind: str, label: str) -> dict | None:
    """The parameters run.json's ``effective`` records for the `kind` ("protocol" or "planner") of `label`, or
    None (not recorded, or malformed)."""
    entries = record.get(f"{kind}s") if isinstance(record, dict) else None
    entry = entries.get(label) if isinstance(entries, dict) else None
    params = entry.get("params") if isinstance(entry, dict) else None
    return params if isinstance(params, dict) else None


def _entries(value: object) -> dict[str, object]:
    """Config list entries by name: a plain name, or a mapping with a label or name."""
    out: dict[str, object] = {}
    for entry in value if isinstance(value, list) else []:
        name = (entry.get("label") or entry.get("name")) if isinstance(entry, dict) else entry
        out[str(name)] = entry
    return out


def _without_exclude(entry: object) -> object:
    """An object entry without its ``exclude`` (compared by `_exclusion_differences`)."""
    return {k: v for k, v in entry.items() if k != "exclude"} if isinstance(entry, dict) else entry


def _exclusion_differences(new: dict, base: dict) -> list[str]:
    """Each object x hand present on both sides that one side leaves out (``exclude`` of its object entry) and
    the other runs: "object '035_power_drill' x hand 'allegro_right' (left out here: <reason>; run in the
    baseline)"."""
    hands = [h for h in _entries(new.get("hands")) if h in _entries(base.get("hands"))]
    ours, theirs = _entries(new.get("objects")), _entries(base.get("objects"))
    out = []
    for name in sorted(ours.keys() & theirs.keys()):
        left = [_exclusions(ours[name]), _exclusions(theirs[name])]
        for hand in hands:
            if (hand in left[0]) != (hand in left[1]):
                here = f"left out here: {left[0][hand]}" if hand in left[0] else "run here"
                there = f"left out in the baseline: {left[1][hand]}" if hand in left[1] else "run in the baseline"
                out.append(f"object {name!r} x hand {hand!r} ({here}; {there})")
    return out


def _exclusions(entry: object) -> dict[str, str]:
    """The hands a recorded object entry leaves out, with their reasons."""
    exclude = entry.get("exclude") if isinstance(entry, dict) else None
    return {str(k): str(v) for k, v in exclude.items()} if isinstance(exclude, dict) else {}


def _differences(new: object, base: object, where: str) -> list[str]:
    """Each leaf where `new` and `base` differ: "scene.timestep (0.001 vs baseline 0.002)"."""
    if new == base:
        return []
    if isinstance(new, dict) and isinstance(base, dict):
        return [d for key in sorted(new.keys() | base.keys(), key=str)
                for d in _differences(new.get(key, _ABSENT), base.get(key, _ABSENT), f"{where}.{key}")]
    return [f"{where} ({_short(new)} vs baseline {_short(base)})"]


_ABSENT = object()  # a key on one side only


def _short(value: object, limit: int = 80) -> str:
    if value is _ABSENT:
        return "absent"
    text = json.dumps(value, sort_keys=True, default=str)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def compare(new: Report, base: Report, alpha: float = 0.05, partial: set[Group] | frozenset = frozenset()
            ) -> Verdict:
    """Compare `new` against `base` over the groups present in both and not in `partial` (groups one side holds
    only part of, `partial_groups`: listed, not compared); `ConfigError` if it cannot judge."""
    if not (isinstance(alpha, float | int) and math.isfinite(alpha) and 0 < alpha < 1):
        raise ConfigError(f"alpha must be a number strictly between 0 and 1, got {alpha!r}")
    check_counts(new, "the new run")
    check_counts(base, "the baseline")
    both = [k for k in new.groups if k in base.groups]
    left = [k for k in both if k in partial]
    common = [k for k in both if k not in partial]
    if both and not common:
        raise ConfigError(f"nothing to compare: every group in both is held only in part by one side "
                          f"({_names(left)}); finish the run (re-run the same command) or use a complete baseline")
    only_new = [k for k in new.groups if k not in base.groups]
    only_base = [k for k in base.groups if k not in new.groups]
    if not new.groups:
        raise ConfigError("nothing to compare: the new run has no trials")
    if not common:
        raise ConfigError("nothing to compare: no hand/planner/observation/protocol/object group is in both the "
                          f"run and the baseline (run: {_names(only_new)}; baseline: {_names(only_base)})")
    empty = [k for k in common if new.groups[k].trials == 0 or base.groups[k].trials == 0]
    if empty:
        raise ConfigError(f"cannot judge groups with zero trials: {_names(empty)}")
    overall = _stratified(POOLED_GROUP, [(new.groups[k], base.groups[k]) for k in common])
    methods = sorted({k[:4] for k in common})
    tests = [_stratified("/".join(m) + " (objects in both)",
                         [(new.groups[k], base.groups[k]) for k in common if k[:4] == m]) for m in methods]
    groups = [_test("/".join(k), new.groups[k], base.groups[k]) for k in common]
    # A family that repeats another's tests is not counted: one method's line is the pooled line, and a method of
    # one group is that group's test.
    families = 1 + (len(methods) > 1) + (len(common) > len(methods))
    out = []
    for kind, family in (("pooled", [overall]), ("method", tests), ("group", groups)):
        adjusted = [min(1.0, families * p) for p in _holm([t[3].p_value for t in family])]
        out += [Comparison(*t, p, p < alpha, kind) for t, p in zip(family, adjusted, strict=True)]
    return Verdict(out, only_new, only_base, [], left)


def partial_groups(side: Side) -> set[Group]:
    """The groups `side` holds only part of: fewer trials stored (harness faults included) than its config's
    `grasps_per_object` (none when the config does not record it)."""
    config = side.meta.get("config") if isinstance(side.meta, dict) else None
    per = config.get("grasps_per_object") if isinstance(config, dict) else None
    if not _count(per):
        return set()
    return {k for k, r in side.report.groups.items()
            if _count(r.trials) and _count(r.harness_faults) and r.trials + r.harness_faults < per}


def _stratified(name: str, pairs: list[tuple[Rate, Rate]]) -> tuple[str, Rate, Rate, ProportionTest]:
    """A line over several groups: their pooled counts, tested stratified by group (module docstring)."""
    test = stratified_lower_than_baseline([(n.successes, n.trials, b.successes, b.trials) for n, b in pairs])
    return name, pooled_rate([n for n, _ in pairs]), pooled_rate([b for _, b in pairs]), test


def _names(groups: list[Group]) -> str:
    return ", ".join("/".join(g) for g in groups) or "none"


def _test(name: str, new: Rate, base: Rate) -> tuple[str, Rate, Rate, ProportionTest]:
    return name, new, base, lower_than_baseline(new.successes, new.trials, base.successes, base.trials)


def _holm(p_values: list[float]) -> list[float]:
    """Holm-Bonferroni adjusted p-values (step-down, monotone, capped at 1)."""
    order = sorted(range(len(p_values)), key=lambda i: p_values[i])
    adjusted = [1.0] * len(p_values)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(p_values) - rank) * p_values[i]))
        adjusted[i] = running
    return adjusted


def compare_sides(new: Side, base: Side, alpha: float = 0.05) -> Verdict:
    """Check that the sides are comparable, then `compare` them; the verdict carries the version notes and each
    side's warnings (an incomplete run)."""
    notes = [f"{where} {side.source}: {w}" for where, side in (("the run", new), ("the baseline", base))
             for w in side.warnings]
    perception = any(k[2] != "ground_truth" for k in new.report.groups if k in base.report.groups)
    notes += check_comparable(new, base, perception)
    verdict = compare(new.report, base.report, alpha, partial_groups(new) | partial_groups(base))
    return Verdict(verdict.comparisons, verdict.only_new, verdict.only_base, notes, verdict.partial)
