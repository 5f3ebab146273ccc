"""Robust epsilon: reproducible from the generator, exact without noise, sensible with it."""

from __future__ import annotations

import numpy as np
import pytest

from manigrasp.contact import Contact, ContactSet
from manigrasp.grasp import (
    ContactNoise,
    GraspError,
    ferrari_canny,
    robust_ferrari_canny,
    robust_ferrari_canny_batch,
)

R = 0.05
ORIGIN = np.zeros(3)


def equator(mu: float = 0.5) -> list[Contact]:
    angles = np.deg2rad([0.0, 120.0, 240.0])
    points = R * np.stack([np.cos(angles), np.sin(angles), 0 * angles], axis=1)
    return [Contact(p, -p / R, mu) for p in points]


def test_same_seed_same_result_other_seed_other_result() -> None:
    a = robust_ferrari_canny(equator(), ORIGIN, R, np.random.default_rng(1), n_samples=50)
    b = robust_ferrari_canny(equator(), ORIGIN, R, np.random.default_rng(1), n_samples=50)
    c = robust_ferrari_canny(equator(), ORIGIN, R, np.random.default_rng(2), n_samples=50)
    assert a == b
    assert a.mean != c.mean


def test_without_noise_the_robust_epsilon_is_the_nominal_epsilon() -> None:
    quiet = ContactNoise(0.0, 0.0, 0.0)
    result = robust_ferrari_canny(equator(), ORIGIN, R, np.random.default_rng(0), 10, quiet)
    nominal = ferrari_canny(equator(), ORIGIN, R)
    assert result.mean == pytest.approx(nominal, abs=1e-12)
    assert result.low == pytest.approx(nominal, abs=1e-12)


def test_noise_spreads_epsilon_and_the_low_quantile_is_below_the_mean() -> None:
    rng = np.random.default_rng(3)
    batch = robust_ferrari_canny_batch(ContactSet.stack([equator(0.5), equator(1.0)]), ORIGIN, R, rng,
                                       n_samples=200, noise=ContactNoise(0.003, 0.1, 0.1))
    assert batch.samples.shape == (2, 200)
    assert np.all(batch.low < batch.mean)
    assert batch.samples.std(axis=1).min() > 1e-3
    assert batch.mean[1] > batch.mean[0]  # more friction, more robust quality
    nominal = ferrari_canny(equator(0.5), ORIGIN, R)
    assert batch.low[0] < nominal  # noise can only be seen to hurt in the low tail
    np.testing.assert_allclose(batch.low, np.quantile(batch.samples, 0.05, axis=1))


def test_bad_arguments_raise() -> None:
    with pytest.raises(GraspError):
        robust_ferrari_canny(equator(), ORIGIN, R, np.random.default_rng(0), n_samples=0)
    with pytest.raises(GraspError):
        robust_ferrari_canny(equator(), ORIGIN, R, np.random.default_rng(0), quantile=1.5)
