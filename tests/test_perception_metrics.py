"""Pose metrics against hand-computed values (pure NumPy, no Open3D)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from manigrasp.perception import metrics


def _pose(rot=None, pos=(0.0, 0.0, 0.0)):
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = np.eye(3) if rot is None else rot, pos
    return pose


def _rz(deg):
    a = math.radians(deg)
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


SQUARE = np.array([[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], [0, -1.0, 0]])  # 4-fold symmetric about z


def test_add_of_pure_translation_is_the_offset():
    assert metrics.add(SQUARE, _pose(), _pose(pos=(0.003, 0.004, 0))) == pytest.approx(0.005)


def test_add_and_add_s_of_a_symmetric_rotation():
    """A 90 deg turn of the square: every point moves by sqrt(2) (ADD), but lands on another point (ADD-S 0)."""
    est = _pose(_rz(90))
    assert metrics.add(SQUARE, _pose(), est) == pytest.approx(math.sqrt(2))
    assert metrics.add_s(SQUARE, _pose(), est) == pytest.approx(0.0, abs=1e-12)


def test_add_s_hand_computed():
    """A 45 deg turn: each corner's nearest turned corner is 2 sin(22.5 deg) away."""
    assert metrics.add_s(SQUARE, _pose(), _pose(_rz(45))) == pytest.approx(2 * math.sin(math.radians(22.5)))


def test_rotation_and_translation_errors():
    true = _pose(_rz(10), (0.1, 0.2, 0.3))
    est = _pose(_rz(-20), (0.1, 0.2, 0.31))
    assert metrics.rotation_error_deg(true, est) == pytest.approx(30.0)
    assert metrics.translation_error_mm(true, est) == pytest.approx(10.0)
    assert metrics.rotation_error_deg(true, _pose(_rz(190))) == pytest.approx(180.0)


def test_nearest_distances_blocks_match_brute_force():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(5000, 3)), rng.normal(size=(300, 3))
    brute = np.linalg.norm(a[:, None] - b[None], axis=2).min(axis=1)
    np.testing.assert_allclose(metrics.nearest_distances(a, b), brute, atol=1e-9)


def test_metrics_are_pure_numpy():
    source = open(metrics.__file__).read()
    assert "open3d" not in source.replace("no Open3D", "")
