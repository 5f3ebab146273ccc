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


def mcnemar_p(only_first: int, only_second: int) -> float:
    """Exact two-sided McNemar p of paired outcomes: the binomial test of the discordant pairs (those only the first
    side held against those only the second held), how likely a split this uneven is if both sides were equally
    good; 1.0 with no discordant pair."""
    total = only_first + only_second
    return float(stats.binomtest(only_first, total).pvalue) if total else 1.0


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


def stratified_lower_than_baseline(strata: list[tuple[int, int, int, int]]) -> ProportionTest:
    """Test whether success rates are lower than a baseline's over several strata (the objects of a hand x
    planner), each (successes, trials, base_successes, base_trials): the Cochran-Mantel-Haenszel test, one-sided,
    without continuity correction (Z = sum_k (a_k - E a_k) / sqrt(sum_k Var a_k), a_k a stratum's successes of the
    run, E and Var its hypergeometric mean and variance given the stratum's margins). Pooling the counts instead
    tests the mix of strata too: with fewer trials of an easy object on one side (harness faults, an interrupted
    run) the pooled rate drops while no stratum's does. `difference` is the Mantel-Haenszel rate difference
    (strata weighted n_k m_k / (n_k + m_k)). A single stratum gives the pooled z-test's Z times
    sqrt((N - 1) / N)."""
    observed = expected = variance = weighted = weights = 0.0
    for k, n, kb, nb in strata:
        total = n + nb
        if n == 0 or nb == 0:
            continue
        m = k + kb
        observed += k
        expected += n * m / total
        if total > 1:
            variance += n * nb * m * (total - m) / (total ** 2 * (total - 1))
        w = n * nb / total
        weighted += w * (k / n - kb / nb)
        weights += w
    difference = weighted / weights if weights > 0 else 0.0
    if variance <= 0:
        return ProportionTest(float(difference), 0.0, 1.0)
    z = (observed - expected) / np.sqrt(variance)
    return ProportionTest(float(difference), float(z), float(stats.norm.cdf(z)))


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


# Bootstrap of the AUC interval: resamples and seed are fixed, so a report is reproducible byte for byte.
AUC_BOOTSTRAP_RESAMPLES = 2000
AUC_BOOTSTRAP_SEED = 0
# Fewest trials of each outcome for an AUC interval: with fewer, the resamples take a handful of values and a
# perfect split reads [1.00, 1.00] from one success and one failure (certainty from n = 2); the AUC is still given.
AUC_INTERVAL_MIN_CLASS = 5


@dataclass(frozen=True)
class AucEstimate:
    """ROC AUC of a metric predicting success in one group, with its 95 % interval.

    Attributes:
        auc: the area (NaN when undefined).
        low, high: 95 % percentile interval of a bootstrap stratified by outcome (fixed seed); NaN when undefined
            or when either outcome has fewer than `AUC_INTERVAL_MIN_CLASS` trials (`bounded`).
        n: trials with a value of the metric (NaN values dropped).
        successes: of those, the successful ones.
        undefined: why the AUC is undefined ("" when it is defined): "no successes", "no failures",
            "metric constant" (a metric with one value cannot rank: its AUC is not 0.5 "chance"),
            "no values" (the metric was not computed for any trial).
    """

    auc: float
    low: float
    high: float
    n: int
    successes: int
    undefined: str = ""

    @property
    def defined(self) -> bool:
        """Whether the AUC is a number."""
        return not self.undefined

    @property
    def bounded(self) -> bool:
        """Whether the AUC has an interval (defined, with `AUC_INTERVAL_MIN_CLASS` trials of each outcome)."""
        return self.defined and np.isfinite(self.low) and np.isfinite(self.high)


def auc_with_interval(scores: np.ndarray, labels: np.ndarray, confidence: float = 0.95,
                      resamples: int = AUC_BOOTSTRAP_RESAMPLES, seed: int = AUC_BOOTSTRAP_SEED) -> AucEstimate:
    """ROC AUC of `scores` predicting boolean `labels`, with a stratified bootstrap percentile interval.

    NaN scores are dropped. Successes and failures are resampled separately (each resample keeps both
    classes, so every resample has an AUC); the interval is the central `confidence` share of the resampled
    AUCs, from a `numpy.random.Generator` seeded with `seed`. With fewer than `AUC_INTERVAL_MIN_CLASS` trials of
    either outcome there is no interval (NaN bounds).
    """
    scores = np.asarray(scores, float)
    labels = np.asarray(labels, bool)
    keep = ~np.isnan(scores)
    scores, labels = scores[keep], labels[keep]
    n, k = len(scores), int(labels.sum())
    reason = ("no values" if n == 0 else "no successes" if k == 0 else "no failures" if k == n
              else "metric constant" if np.all(scores == scores[0]) else "")
    if reason:
        return AucEstimate(float("nan"), float("nan"), float("nan"), n, k, reason)
    pos, neg = scores[labels], scores[~labels]
    if min(len(pos), len(neg)) < AUC_INTERVAL_MIN_CLASS:
        return AucEstimate(roc_auc(scores, labels), float("nan"), float("nan"), n, k)
    rng = np.random.default_rng(seed)
    boot_pos = pos[rng.integers(0, len(pos), (resamples, len(pos)))]
    boot_neg = neg[rng.integers(0, len(neg), (resamples, len(neg)))]
    aucs = _auc_rows(boot_pos, boot_neg)
    tail = 100 * (1 - confidence) / 2
    low, high = np.percentile(aucs, [tail, 100 - tail])
    return AucEstimate(roc_auc(scores, labels), float(low), float(high), n, k)


def _auc_rows(pos: np.ndarray, neg: np.ndarray) -> np.ndarray:
    """AUC of each row: `pos` (b, p) scores of successes against `neg` (b, q) of failures (ties one half)."""
    ranks = stats.rankdata(np.concatenate([pos, neg], axis=1), axis=1)
    p, q = pos.shape[1], neg.shape[1]
    return (ranks[:, :p].sum(axis=1) - p * (p + 1) / 2) / (p * q)
