"""Statistics with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from manigrasp.bench.stats import auc_with_interval, lower_than_baseline, roc_auc, wilson_interval


def test_wilson_interval_matches_the_closed_form():
    """Wilson: (p + z^2/2n +- z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n); for 8/10 at 95 %: [0.4902, 0.9433]."""
    low, high = wilson_interval(8, 10)
    z, n, p = 1.959963984540054, 10, 0.8
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    assert low == pytest.approx(centre - half, abs=1e-9) and high == pytest.approx(centre + half, abs=1e-9)
    assert low == pytest.approx(0.4902, abs=1e-4)


def test_wilson_interval_edges():
    assert wilson_interval(0, 0) == (0.0, 1.0)
    low, high = wilson_interval(0, 20)
    assert low == 0.0 and 0.1 < high < 0.2
    low, high = wilson_interval(20, 20)
    assert high == pytest.approx(1.0) and 0.8 < low < 0.9


def test_two_proportion_test_flags_a_real_drop_and_not_noise():
    drop = lower_than_baseline(50, 100, 80, 100)
    assert drop.difference == pytest.approx(-0.3) and drop.p_value < 1e-4
    # z = -0.3 / sqrt(0.65 * 0.35 * 0.02) = -4.447
    assert drop.z == pytest.approx(-0.3 / np.sqrt(0.65 * 0.35 * 0.02))
    assert lower_than_baseline(78, 100, 80, 100).p_value > 0.3
    assert lower_than_baseline(90, 100, 80, 100).p_value > 0.9  # higher is never "lower"


def test_roc_auc_known_values():
    labels = np.array([0, 0, 1, 1], bool)
    assert roc_auc(np.array([0.1, 0.2, 0.3, 0.4]), labels) == 1.0
    assert roc_auc(np.array([0.4, 0.3, 0.2, 0.1]), labels) == 0.0
    assert roc_auc(np.array([0.1, 0.3, 0.2, 0.4]), labels) == 0.75  # 3 of 4 pairs ordered
    assert roc_auc(np.array([0.5, 0.5, 0.5, 0.5]), labels) == 0.5
    assert np.isnan(roc_auc(np.array([0.1, 0.2]), np.array([1, 1], bool)))
    assert roc_auc(np.array([np.nan, 0.1, 0.2, 0.3, 0.4]), np.r_[True, labels]) == 1.0


def _delong_interval(scores: np.ndarray, labels: np.ndarray) -> tuple[float, float, float]:
    """AUC and its 95 % DeLong interval (structural components), an independent check of the bootstrap."""
    pos, neg = scores[labels], scores[~labels]
    psi = (pos[:, None] > neg[None, :]) + 0.5 * (pos[:, None] == neg[None, :])
    auc = psi.mean()
    v10, v01 = psi.mean(axis=1), psi.mean(axis=0)
    se = np.sqrt(v10.var(ddof=1) / len(pos) + v01.var(ddof=1) / len(neg))
    return auc, auc - 1.959964 * se, auc + 1.959964 * se


def test_auc_interval_agrees_with_delong_and_is_reproducible():
    """Binormal scores (d' = 1.2, 150 successes, 250 failures): the stratified bootstrap's 95 % interval matches
    DeLong's within 0.015 at each end, contains the AUC, and is identical on a second call (fixed seed)."""
    rng = np.random.default_rng(7)
    labels = np.r_[np.ones(150, bool), np.zeros(250, bool)]
    scores = rng.normal(size=400) + 1.2 * labels
    estimate = auc_with_interval(scores, labels)
    auc, low, high = _delong_interval(scores, labels)
    assert estimate.auc == pytest.approx(auc, abs=1e-12) and estimate.defined
    assert estimate.low == pytest.approx(low, abs=0.015) and estimate.high == pytest.approx(high, abs=0.015)
    assert estimate.low < estimate.auc < estimate.high
    assert (estimate.n, estimate.successes) == (400, 150)
    assert auc_with_interval(scores, labels) == estimate


def test_auc_of_a_constant_metric_or_one_outcome_is_undefined_not_chance():
    labels = np.array([1, 1, 0, 0, 0], bool)
    constant = auc_with_interval(np.full(5, 1.0), labels)
    assert constant.undefined == "metric constant" and np.isnan(constant.auc) and not constant.defined
    assert roc_auc(np.full(5, 1.0), labels) == 0.5  # the bare statistic says "chance": the report must not
    assert auc_with_interval(np.arange(5.0), np.ones(5, bool)).undefined == "no failures"
    assert auc_with_interval(np.arange(5.0), np.zeros(5, bool)).undefined == "no successes"
    missing = auc_with_interval(np.full(5, np.nan), labels)
    assert missing.undefined == "no values" and missing.n == 0
    # NaN values are dropped and counted out of n.
    partial = auc_with_interval(np.array([0.9, np.nan, 0.1, 0.2, 0.3]), labels)
    assert (partial.auc, partial.n, partial.successes) == (1.0, 4, 1)


def test_auc_of_too_few_of_an_outcome_has_no_interval_rather_than_a_certain_one():
    """One success and one failure split perfectly: the bootstrap read [1.00, 1.00], certainty from n = 2."""
    from manigrasp.bench.report import format_auc
    from manigrasp.bench.stats import AUC_INTERVAL_MIN_CLASS

    two = auc_with_interval(np.array([0.9, 0.1]), np.array([True, False]))
    assert two.auc == 1.0 and two.defined and not two.bounded and np.isnan(two.low) and np.isnan(two.high)
    assert format_auc(two) == f"1.00 [no interval: under {AUC_INTERVAL_MIN_CLASS} of an outcome]"
    k = AUC_INTERVAL_MIN_CLASS
    scores = np.r_[np.linspace(0.5, 1.0, k), np.linspace(0.0, 0.6, k)]
    enough = auc_with_interval(scores, np.r_[[True] * k, [False] * k])
    assert enough.bounded and enough.low < enough.auc <= enough.high
