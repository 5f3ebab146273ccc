"""Statistics of benchmark results: intervals, comparisons, metric predictiveness.

Pure functions of counts and arrays; no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats


def wilson_interval(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a success rate; (0, 1) when there are no trials."""
    if trials == 0:
        return 0.0, 1.0
    ci = stats.binomtest(successes, trials).proportion_ci(confidence_level=confidence, method="wilson")
    return float(ci.low), float(ci.high)


@dataclass(frozen=True)
class ProportionTest:
    """One-sided two-proportion z-test of "new rate < baseline rate".

    Attributes:
        difference: new rate - baseline rate.
        z: the pooled z statistic (negative when the new rate is lower).
        p_value: P(Z <= z) under equal rates; small means significantly lower.
    """

    difference: float
    z: float
    p_value: float


def lower_than_baseline(successes: int, trials: int, base_successes: int, base_trials: int) -> ProportionTest:
    """Test whether a success rate is lower than a baseline's (pooled z-test, one-sided)."""
    if trials == 0 or base_trials == 0:
        return ProportionTest(0.0, 0.0, 1.0)
    p_new, p_base = successes / trials, base_successes / base_trials
    pooled = (successes + base_successes) / (trials + base_trials)
    se = np.sqrt(pooled * (1 - pooled) * (1 / trials + 1 / base_trials))
    if se == 0:
        return ProportionTest(p_new - p_base, 0.0, 1.0)
    z = (p_new - p_base) / se
    return ProportionTest(float(p_new - p_base), float(z), float(stats.norm.cdf(z)))


def roc_auc(scores: np.ndarray, labels: np.ndarray) -> float:
    """Area under the ROC curve of `scores` predicting boolean `labels` (ties count one half).

    NaN scores are dropped; NaN when only one class remains. Computed as the
    Mann-Whitney U statistic divided by n_pos * n_neg.
    """
    scores = np.asarray(scores, float)
    labels = np.asarray(labels, bool)
    keep = ~np.isnan(scores)
    scores, labels = scores[keep], labels[keep]
    n_pos, n_neg = int(labels.sum()), int((~labels).sum())
    if n_pos == 0 or n_neg == 0:
        return float("nan")
    u = stats.mannwhitneyu(scores[labels], scores[~labels], alternative="two-sided").statistic
    return float(u / (n_pos * n_neg))
