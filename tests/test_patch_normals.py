"""The antipodal planner's pad-scale normals (`geometry.PatchNormals`, `AntipodalPlanner.normal_radius`): on a
scanned surface a facet tilted by its bumps must not make a pair with a face it is not opposite
(benchmarks/bench_pseudo_scans.py: 18-24 mm pinches across the gelatin box pseudo-scan's top edge)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from manigrasp.errors import ConfigError
from manigrasp.planners.antipodal import AntipodalPlanner
from manigrasp.planners.geometry import PatchNormals, SmoothNormals, sample_surface


def _bumpy_box(seed: int = 0) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """A 73 x 28 x 60 mm box, remeshed to ~2 mm edges, its vertices moved along their normals by 0.7 mm noise."""
    box = trimesh.creation.box((0.073, 0.028, 0.060))
    vertices, faces = trimesh.remesh.subdivide_to_size(box.vertices, box.faces, max_edge=0.002)
    clean = trimesh.Trimesh(vertices, faces)
    rng = np.random.default_rng(seed)
    noisy = clean.copy()
    noisy.vertices = clean.vertices + clean.vertex_normals * rng.normal(0.0, 0.0007, (len(vertices), 1))
    return clean, noisy


def _off_face_deg(mesh: trimesh.Trimesh, normals) -> np.ndarray:
    """Angle [deg] of the normals at points more than 6 mm from every edge off their face's true normal."""
    samples = sample_surface(mesh, 3000, np.random.default_rng(1))
    points = samples.points
    half = np.array([0.0365, 0.014, 0.030])
    axis = np.argmax(np.abs(points) / half, axis=1)  # the face a point lies on
    inner = np.all((np.abs(points) < half - 0.006) | (np.arange(3) == axis[:, None]), axis=1)
    true = np.zeros_like(points)
    true[np.arange(len(points)), axis] = np.sign(points[np.arange(len(points)), axis])
    n = normals.at(samples.faces, samples.barycentric)
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n, true), -1, 1)))[inner]


def test_patch_normals_follow_the_face_not_the_bumps():
    _, noisy = _bumpy_box()
    own = _off_face_deg(noisy, SmoothNormals(noisy))
    patch = _off_face_deg(noisy, PatchNormals(noisy, 0.005))
    assert np.percentile(own, 99) > 20  # facets tilted by the bumps
    assert np.percentile(patch, 99) < 8 and np.median(patch) < 3


def test_clean_faces_keep_their_normal():
    clean, _ = _bumpy_box()
    assert np.max(_off_face_deg(clean, PatchNormals(clean, 0.005))) < 1e-6


def test_pairs_on_a_bumpy_box_lie_across_it():
    _, noisy = _bumpy_box()

    class Hand:  # what `pairs` reads of a hand
        max_width = 0.08

    def widths(planner):
        pairs = planner.pairs(noisy, Hand(), np.random.default_rng(0))
        return np.asarray(pairs.width)

    def off(w):  # distance of each pair's width from the nearest of the box's three sizes
        return np.min(np.abs(w[:, None] - np.array([0.073, 0.028, 0.060])), axis=1)

    own, patch = widths(AntipodalPlanner()), widths(AntipodalPlanner(normal_radius=0.005))
    assert np.mean(off(own) > 0.008) > 0.2  # 2-10 mm pinches between bump-tilted facets (0.51 at this seed)
    assert np.mean(off(patch) > 0.008) < 0.01  # none at this seed


def test_normal_radius_is_checked():
    with pytest.raises(ConfigError, match="normal_radius"):
        AntipodalPlanner(normal_radius=-0.001)
