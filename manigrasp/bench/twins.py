"""Scan vs recipe: one physical object as a real scan and as its clean recipe twin, side by side.

A scan is paired with its twin by name: object ``<stem>_scan`` (the shipped scans,
`manigrasp.objects.scans`, or a user's mesh named that way) or ``<stem>_ycb`` (a real
YCB download's folder, `manigrasp.objects.catalog.from_ycb_folder`) with object ``<stem>``
in the same hand x planner x observation (x protocol). The same physical object should
get the same verdict whatever the mesh's fidelity; the gap between the two rates says
how far it does not.

Under ``rest: stable_k`` each object runs in its k most probable resting poses
(``<stem>_scan@rest0`` ...), and a pair compares the scan's trials over all of its
poses with the recipe's over all of its: the poses' ranks are not the same physical
poses on two meshes (the recipe can's side is split into 64 hull faces, none of which
outranks an end face, while the scan's side is one face, ranked first: rank 0 is the
can standing on one and lying on the other), and a scan in its own frame cannot be
matched pose for pose without registering the two meshes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

from manigrasp.bench.report import Rate, Report, format_rate, pooled_rate, round_half_up
from manigrasp.objects.catalog import YCB_SUFFIX
from manigrasp.objects.scans import SCAN_SUFFIX

GAP_POINTS = 10.0  # [percentage points], the largest scan-recipe gap the benchmark accepts
NOT_JUDGED = "n/a (recipe never held)"  # the verdict where the benchmark does not judge the gap (`TwinRow.verdict`)


@dataclass(frozen=True)
class TwinRow:
    """One scan and its recipe twin under one hand x planner x observation.

    Attributes:
        method: (hand, planner, observation[, protocol]): the group key without the object.
        scan, recipe: object names.
        scan_rate, recipe_rate: their success rates with Wilson intervals.
    """

    method: tuple[str, ...]
    scan: str
    recipe: str
    scan_rate: Rate
    recipe_rate: Rate

    @property
    def gap(self) -> Fraction | None:
        """Recipe rate minus scan rate [percentage points], exact from the counts (positive: the scan does worse);
        None if either has no trial (every one a harness fault)."""
        if not (self.recipe_rate.trials and self.scan_rate.trials):
            return None
        return 100 * (Fraction(self.recipe_rate.successes, self.recipe_rate.trials)
                      - Fraction(self.scan_rate.successes, self.scan_rate.trials))

    @property
    def gap_points(self) -> float:
        """`gap` as a float [percentage points] (NaN: none)."""
        return math.nan if self.gap is None else float(self.gap)

    @property
    def within(self) -> bool:
        """True if the scan's rate is within `GAP_POINTS` of the recipe's (either way), on the exact gap (16/20 -
        14/20 is 10.000000000000009 points in floats)."""
        return self.gap is not None and abs(self.gap) <= Fraction(GAP_POINTS)

    @property
    def fisher_p(self) -> float:
        """Two-sided Fisher exact p of the scan's successes/failures against the recipe's: how likely a split at
        least this uneven is if both meshes held equally often. At 20 trials each, 6/20 against 9/20 (a 15-point
        gap) gives p = 0.51: a gap with a large p is not evidence that the meshes differ, and a gap within
        `GAP_POINTS` with a large p is not evidence that they agree either."""
        from scipy.stats import fisher_exact

        s, r = self.scan_rate, self.recipe_rate
        return float(fisher_exact([[s.successes, s.trials - s.successes],
                                   [r.successes, r.trials - r.successes]]).pvalue)

    @property
    def verdict(self) -> str:
        """"yes"/"no", or "n/a" where the recipe was never held (the benchmark asks for the gap only where the
        recipe can be grasped: 0 of 6 against 0 of 6, every trial a planner error, is no agreement)."""
        if self.gap is None:
            return "n/a (no trials)"
        if self.recipe_rate.successes == 0:
            return NOT_JUDGED
        return "yes" if self.within else "no"

    def to_json(self) -> dict:
        """The row as ``manigrasp report --json`` gives it (under ``scan_vs_recipe``)."""
        return {**dict(zip(("hand", "planner", "observation", "protocol"), self.method, strict=False)),
                "object": self.recipe, "scan": self.scan,
                "scan_successes": self.scan_rate.successes, "scan_trials": self.scan_rate.trials,
                "scan_rate": self.scan_rate.success_rate,
                "recipe_successes": self.recipe_rate.successes, "recipe_trials": self.recipe_rate.trials,
                "recipe_rate": self.recipe_rate.success_rate, "gap_points": self.gap_points,
                "within_points": GAP_POINTS, "verdict": self.verdict, "fisher_p": self.fisher_p}

    @property
    def intervals_overlap(self) -> bool:
        """True if the two 95 % Wilson intervals overlap."""
        return self.scan_rate.ci_low <= self.recipe_rate.ci_high and self.recipe_rate.ci_low <= self.scan_rate.ci_high


def twin_rows(groups: Mapping[tuple[str, ...], Rate]) -> list[TwinRow]:
    """Every scan/recipe pair in `groups` ((hand, planner, observation[, protocol], object) -> Rate), sorted; an
    object's resting poses (``@rest<i>`` labels) pooled into one rate (module docstring)."""
    pooled = _pooled_over_rest(groups)
    rows = []
    for (*method, obj), rate in sorted(pooled.items()):
        suffix = next((s for s in (SCAN_SUFFIX, YCB_SUFFIX) if obj.endswith(s)), None)
        if suffix is None:
            continue
        twin = obj[: -len(suffix)]
        twin_rate = pooled.get((*method, twin))
        if twin_rate is not None:
            rows.append(TwinRow(tuple(method), obj, twin, rate, twin_rate))
    return rows


def _pooled_over_rest(groups: Mapping[tuple[str, ...], Rate]) -> dict[tuple[str, ...], Rate]:
    """`groups` keyed by the object's name without its resting pose (``<object>@rest<i>`` -> ``<object>``), the
    rates of its poses pooled (trials and successes summed, a Wilson interval of the sum); an object without
    resting-pose labels keeps its rate as it is."""
    from manigrasp.bench.trials import REST_LABEL

    parts: dict[tuple[str, ...], list[Rate]] = {}
    for (*method, obj), rate in groups.items():
        parts.setdefault((*method, obj.split(REST_LABEL)[0]), []).append(rate)
    return {key: rates[0] if len(rates) == 1 else pooled_rate(rates) for key, rates in parts.items()}


def json_rows(groups: Mapping[tuple[str, ...], Rate]) -> list[dict]:
    """Every scan/recipe pair of `groups` (`twin_rows`) as ``manigrasp report --json`` lists it."""
    return [row.to_json() for row in twin_rows(groups)]


def _gap_cell(row: TwinRow) -> str:
    """The gap [points] to one decimal (rounded half up on the exact gap, as every figure of the report), "(not
    judged)" after it where the recipe was never held: a "+0.0" of 0/20 against 0/20 is no agreement."""
    if row.gap is None:
        return "-"
    gap = ("+" if row.gap >= 0 else "") + round_half_up(row.gap, 1)
    return gap + (" (not judged)" if row.verdict == NOT_JUDGED else "")


def markdown_section(report: Report) -> list[str]:
    """The report's "Scan vs recipe" section (a title and a table), or nothing if the run has no pair."""
    rows = twin_rows(report.groups)
    if not rows:
        return []
    protocols = len({r.method[3:] for r in rows}) > 1  # a run with several protocols: say which
    header = ["hand", "planner", "observation", *(["protocol"] if protocols else []), "object (recipe twin)",
              "scan", "scan: successes/trials",
              "scan rate [95% CI]", "recipe: successes/trials", "recipe rate [95% CI]", "gap [points]",
              f"within {GAP_POINTS:g} points", "Fisher p"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        cells = [*r.method[:4 if protocols else 3], r.recipe, r.scan, f"{r.scan_rate.successes}/{r.scan_rate.trials}",
                 format_rate(r.scan_rate),
                 f"{r.recipe_rate.successes}/{r.recipe_rate.trials}", format_rate(r.recipe_rate),
                 _gap_cell(r), r.verdict, f"{r.fisher_p:.2g}"]  # .0f showed 10.4 as "+10 | no"
        lines.append("| " + " | ".join(cells) + " |")
    note = ("The same physical object as a real scan (`<name>_scan`, or a YCB download's `<name>_ycb`) and as its "
            "clean recipe twin (`<name>`), each "
            "over all of its resting poses where the run has several (`rest: stable_k`: a pose's rank is not the "
            "same physical pose on two meshes); gap = recipe rate - scan rate. The benchmark asks for a gap within "
            f"{GAP_POINTS:g} points wherever the recipe can be grasped: the verdict is on the two point estimates. "
            "Where the recipe was never held the verdict is n/a (the benchmark does not judge the gap there): the "
            "scan's rate and the gap are shown for information only. Fisher p is the two-sided Fisher exact test of "
            "the scan's successes and failures against the recipe's: how often a split at least this uneven comes "
            "from two meshes that hold equally often. With a few tens of trials a large gap can be noise (6/20 "
            "against 9/20, 15 points, p = 0.51): a gap with a large p is not evidence that the meshes differ, and a "
            "\"yes\" with a large p is not evidence that they agree either (only that the draw did not tell them "
            "apart). Rates with 95 % Wilson intervals.")
    return ["## Scan vs recipe", note, "\n".join(lines)]
