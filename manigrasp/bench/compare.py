"""Regression gate: is any success rate significantly lower than a baseline's?

Overall and per group (hand x planner x observation x object), one-sided
pooled two-proportion z-tests. Per-group p-values are Holm-Bonferroni
corrected across groups, so that a config with many groups does not fail CI
by chance; the overall test is uncorrected.
"""

from __future__ import annotations

from dataclasses import dataclass

from manigrasp.bench.report import Rate, Report
from manigrasp.bench.stats import ProportionTest, lower_than_baseline


@dataclass(frozen=True)
class Comparison:
    """One compared rate: the group ("overall" or hand/planner/observation/object), both rates, the test."""

    group: str
    new: Rate
    base: Rate
    test: ProportionTest
    adjusted_p: float
    regression: bool


def _test(name: str, new: Rate, base: Rate) -> tuple[str, Rate, Rate, ProportionTest]:
    return name, new, base, lower_than_baseline(new.successes, new.trials, base.successes, base.trials)


def compare(new: Report, base: Report, alpha: float = 0.05) -> list[Comparison]:
    """Compare `new` against `base`; groups missing from either side are skipped."""
    overall = _test("overall", new.overall, base.overall)
    groups = [_test("/".join(k), new.groups[k], base.groups[k]) for k in new.groups if k in base.groups]
    out = [Comparison(*overall, overall[3].p_value, overall[3].p_value < alpha)]
    order = sorted(range(len(groups)), key=lambda i: groups[i][3].p_value)
    adjusted = [1.0] * len(groups)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(groups) - rank) * groups[i][3].p_value))
        adjusted[i] = running
    out += [Comparison(*g, adjusted[i], adjusted[i] < alpha) for i, g in enumerate(groups)]
    return out
