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

from collections.abc import Mapping
from dataclasses import dataclass

from manigrasp.bench.report import Rate, Report, format_rate, pooled_rate
from manigrasp.objects.catalog import YCB_SUFFIX
from manigrasp.objects.scans import SCAN_SUFFIX

GAP_POINTS = 10.0  # [percentage points], the largest scan-recipe gap the benchmark accepts


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
    def gap_points(self) -> float:
        """Recipe rate minus scan rate [percentage points] (positive: the scan does worse)."""
        return 100.0 * (self.recipe_rate.success_rate - self.scan_rate.success_rate)

    @property
    def within(self) -> bool:
        """True if the scan's rate is within `GAP_POINTS` of the recipe's (either way)."""
        return abs(self.gap_points) <= GAP_POINTS + 1e-9  # 16/20 - 14/20 is 10.000000000000009 points in floats

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


def _verdict(row: TwinRow) -> str:
    """"yes"/"no", or "n/a" where the recipe was never held (the benchmark asks for the gap only where the recipe
    can be grasped: 0 of 6 against 0 of 6, every trial a planner error, is no agreement)."""
    if row.recipe_rate.successes == 0:
        return "n/a (recipe never held)"
    return "yes" if row.within else "no"


def markdown_section(report: Report) -> list[str]:
    """The report's "Scan vs recipe" section (a title and a table), or nothing if the run has no pair."""
    rows = twin_rows(report.groups)
    if not rows:
        return []
    protocols = len({r.method[3:] for r in rows}) > 1  # a run with several protocols: say which
    header = ["hand", "planner", "observation", *(["protocol"] if protocols else []), "object (recipe twin)",
              "scan", "scan: successes/trials",
              "scan rate [95% CI]", "recipe: successes/trials", "recipe rate [95% CI]", "gap [points]",
              f"within {GAP_POINTS:g} points"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        cells = [*r.method[:4 if protocols else 3], r.recipe, r.scan, f"{r.scan_rate.successes}/{r.scan_rate.trials}",
                 format_rate(r.scan_rate),
                 f"{r.recipe_rate.successes}/{r.recipe_rate.trials}", format_rate(r.recipe_rate),
                 f"{r.gap_points:+.1f}", _verdict(r)]  # .0f showed 10.4 as "+10 | no"
        lines.append("| " + " | ".join(cells) + " |")
    note = ("The same physical object as a real scan (`<name>_scan`, or a YCB download's `<name>_ycb`) and as its "
            "clean recipe twin (`<name>`), each "
            "over all of its resting poses where the run has several (`rest: stable_k`: a pose's rank is not the "
            "same physical pose on two meshes); gap = recipe rate - scan rate. The benchmark asks for a gap within "
            f"{GAP_POINTS:g} points wherever the recipe can be grasped; rates with 95 % Wilson intervals.")
    return ["## Scan vs recipe", note, "\n".join(lines)]
