"""Issue 14, messages a user can act on: `objects show` prints rounded figures, MeshFix's stderr
becomes one line per object in the build summary, and a benchmark says which object it builds."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from manigrasp.cli import main
from manigrasp.cli.objects import rounded
from manigrasp.objects import catalog
from manigrasp.objects.pipeline import build_object


def test_rounded_drops_float_noise_and_round_off():
    assert rounded(0.11800000000000001) == 0.118
    assert rounded([0.11699999999999999, 0.08]) == [0.117, 0.08]
    inertia = np.array([[1.4569002916467946e-4, -5.9e-21], [-5.9e-21, 1.856818520834517e-4]])
    assert rounded(inertia, noise=1e-9 * 1.9e-4) == [[0.00014569, 0.0], [0.0, 0.000185682]]
    assert str(rounded(-1e-21, noise=1e-12)) == "0.0"  # no -0.0


def test_objects_show_prints_rounded_figures(isolated_cache, capsys):
    assert main(["objects", "show", "004_sugar_box", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["mass_kg"] == 0.514 and info["extents_m"] == [0.089, 0.038, 0.175]
    inertia = np.array(info["inertia_kg_m2"])
    assert np.all(inertia[~np.eye(3, dtype=bool)] == 0.0)  # a box about its centre: no 1e-21 noise
    m, (x, y, z) = 0.514, (0.089, 0.038, 0.175)  # textbook box: m (b^2 + c^2) / 12
    assert np.allclose(np.diag(inertia), [m * (y * y + z * z) / 12, m * (x * x + z * z) / 12,
                                          m * (x * x + y * y) / 12], rtol=1e-5)
    assert main(["objects", "show", "004_sugar_box"]) == 0
    text = capsys.readouterr().out
    assert "mass_kg        0.514\n" in text and "e-2" not in text and "000000" not in text


@pytest.fixture
def open_cap(tmp_path):
    """A sphere with its top cut off: a hole trimesh cannot fill, so MeshFix runs (and complains)."""
    sphere = trimesh.creation.icosphere(3, radius=0.04)
    cap = trimesh.Trimesh(sphere.vertices, sphere.faces[sphere.triangles_center[:, 2] < 0.02])
    path = tmp_path / "cap.stl"
    cap.export(path)
    return path


@pytest.mark.slow
def test_meshfix_stderr_becomes_a_warning_of_the_object(open_cap, isolated_cache, capfd):
    asset = build_object(open_cap, name="cap", mass=0.1, convex_hull_fallback=True).asset
    assert asset.metadata["warnings"] == ["MeshFix: could not fix everything (the mesh ended closed)"]
    assert "could not fix everything" not in capfd.readouterr().err  # not on the terminal raw
    assert main(["objects", "build", "--mesh", str(open_cap), "--convex-hull"]) == 0
    printed = capfd.readouterr()
    lines = [line for line in (printed.out + printed.err).splitlines() if "could not fix" in line]
    assert len(lines) == 1 and lines[0].startswith("cap: ") and \
        lines[0].endswith("; MeshFix: could not fix everything (the mesh ended closed)")


def test_a_watertight_mesh_has_no_warnings(isolated_cache):
    assert build_object(trimesh.creation.box((0.05, 0.05, 0.05)), name="box", mass=0.1).asset.metadata[
        "warnings"] == []


@pytest.mark.slow
def test_a_benchmark_says_which_object_it_builds_before_the_trials(tmp_path, isolated_cache, capsys):
    args = ["bench", "quick", "objects=004_sugar_box", "planners=random", "grasps_per_object=1", "protocol=lift"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    err = capsys.readouterr().err
    assert "object 004_sugar_box: building..." in err
    assert err.index("object 004_sugar_box: 1 hulls") < err.index("trials")
    assert catalog.is_built("004_sugar_box")
    assert main([*args, "--out", str(tmp_path / "b")]) == 0  # built: nothing said about it
    assert "004_sugar_box: building" not in capsys.readouterr().err
