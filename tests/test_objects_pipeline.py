"""The mesh -> ObjectAsset pipeline: bad input, repairs, cache, MJCF, CLI errors."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from manigrasp.cli import main
from manigrasp.errors import MeshError, MeshUnitsError
from manigrasp.objects import build_object
from manigrasp.objects.cache import HullCache
from manigrasp.objects.meshio import load_mesh, ycb_dataset
from manigrasp.objects.validate import validate_and_repair


def _write(mesh: trimesh.Trimesh, path: Path) -> Path:
    mesh.export(path)
    return path


@pytest.fixture
def broken_meshes(tmp_path: Path) -> dict[str, Path]:
    """A folder of generated broken meshes, one per failure the pipeline must name."""
    box = trimesh.creation.box((0.05, 0.04, 0.03))
    folder = tmp_path / "broken"
    folder.mkdir()
    (folder / "empty.stl").write_bytes(b"")
    (folder / "garbage.stl").write_bytes(np.random.default_rng(0).bytes(300))
    nan = box.copy()
    nan.vertices[3] = [np.nan, 0.0, 0.0]
    (folder / "nan.obj").write_text(
        "\n".join([f"v {x} {y} {z}" for x, y, z in nan.vertices] + [f"f {a+1} {b+1} {c+1}" for a, b, c in nan.faces]))
    _write(box.copy().apply_scale(1000.0), folder / "millimetre.stl")
    # a closed tetrahedron whose four corners lie in one plane: watertight, zero volume
    flat = trimesh.Trimesh([[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0], [0.015, 0.015, 0]],
                           [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]], process=False)
    (folder / "zero_volume.obj").write_text(
        "\n".join([f"v {x} {y} {z}" for x, y, z in flat.vertices] + [f"f {a+1} {b+1} {c+1}" for a, b, c in flat.faces]))
    sheet = trimesh.Trimesh([[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0]], [[0, 1, 2]], process=False)
    _write(sheet, folder / "open_sheet.stl")
    return {p.stem: p for p in folder.iterdir()}


@pytest.mark.parametrize(("case", "error", "phrase"), [
    ("empty", MeshError, "file is empty"),
    ("garbage", MeshError, "cannot read mesh"),
    ("nan", MeshError, "NaN or infinite"),
    ("millimetre", MeshUnitsError, "in millimetres, `--scale 0.001`"),
    ("zero_volume", MeshError, "no volume"),
    ("open_sheet", MeshError, "hole filling failed"),
])
def test_broken_mesh_gives_the_right_error(broken_meshes, isolated_cache, case, error, phrase):
    with pytest.raises(error, match=phrase):
        build_object(broken_meshes[case])


def test_broken_mesh_at_the_cli_is_one_line_and_exit_2(broken_meshes, isolated_cache, capsys):
    code = main(["objects", "build", "--mesh", str(broken_meshes["millimetre"])])
    err = capsys.readouterr().err
    assert code == 1
    assert "--scale 0.001" in err and "Traceback" not in err
    assert main(["objects", "show", "no_such_object"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "available:" in err


def test_scale_option_makes_a_millimetre_mesh_usable(broken_meshes, isolated_cache):
    asset = build_object(broken_meshes["millimetre"], scale=0.001, mass=0.1).asset
    np.testing.assert_allclose(sorted(asset.extents), [0.03, 0.04, 0.05], atol=1e-9)


def test_open_can_is_closed_and_the_repair_recorded(tmp_path, isolated_cache):
    can = trimesh.creation.cylinder(0.033, 0.1, sections=48)
    open_can = trimesh.Trimesh(can.vertices, can.faces[can.face_normals[:, 2] < 0.9], process=False)
    asset = build_object(_write(open_can, tmp_path / "open_can.stl"), mass=0.35).asset
    assert any("closed holes" in r for r in asset.metadata["repairs"])
    assert asset.volume == pytest.approx(can.volume, rel=1e-6)


def test_inconsistent_winding_and_duplicates_are_repaired_and_recorded():
    box = trimesh.creation.box((0.05, 0.05, 0.05))
    faces = box.faces.copy()
    faces[0] = faces[0][::-1]
    faces = np.vstack([faces, faces[5:6]])
    mesh, report = validate_and_repair(trimesh.Trimesh(box.vertices, faces, process=False))
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume == pytest.approx(0.05**3)
    assert any("duplicate faces" in r for r in report.repairs)
    assert any("winding" in r for r in report.repairs)


def test_debris_is_dropped_and_recorded():
    body = trimesh.creation.box((0.1, 0.1, 0.1))
    speck = trimesh.creation.box((0.002, 0.002, 0.002)).apply_translation([0.2, 0, 0])
    mesh, report = validate_and_repair(trimesh.util.concatenate([body, speck]))
    assert mesh.volume == pytest.approx(1e-3)
    assert report.pieces == 2 and any("dropped 1 small" in r for r in report.repairs)


def _open_tube() -> trimesh.Trimesh:
    """A 4 cm wide, 6 cm tall cylinder without its caps: 32-sided holes that trimesh's fill_holes leaves open."""
    cylinder = trimesh.creation.cylinder(radius=0.02, height=0.06)
    tube = trimesh.Trimesh(cylinder.vertices, cylinder.faces[np.abs(cylinder.face_normals[:, 2]) < 0.5])
    tube.remove_unreferenced_vertices()
    return tube


def test_meshfix_repairs_each_piece_and_loses_none():
    """MeshFix keeps only the largest connected piece of what it is given: a closed box beside an open tube came
    out as the tube alone, and two boxes sharing an edge (non-manifold) as one box, recorded as "closed holes (0
    open edges)": half the object lost without a word."""
    box = trimesh.creation.box((0.05, 0.04, 0.03))
    tube = _open_tube().apply_translation([0.1, 0, 0])
    mesh, report = validate_and_repair(trimesh.util.concatenate([box, tube]))
    assert mesh.volume == pytest.approx(box.volume + trimesh.creation.cylinder(radius=0.02, height=0.06).volume,
                                        rel=1e-6)
    assert report.pieces == 2 and any("one by one" in r for r in report.repairs)
    twin = box.copy().apply_translation([0.05, 0.04, 0])  # shares one edge with `box`
    mesh, report = validate_and_repair(trimesh.util.concatenate([box, twin]))
    assert mesh.volume == pytest.approx(2 * box.volume, rel=1e-6) and report.pieces == 2
    assert any("made manifold (1 edges" in r for r in report.repairs), report.repairs
    speck = _open_tube().apply_scale(0.05).apply_translation([0, 0.2, 0])  # debris is still dropped
    pair = validate_and_repair(trimesh.util.concatenate([box, tube]))[0].volume
    mesh, report = validate_and_repair(trimesh.util.concatenate([box, tube, speck]))
    assert mesh.volume == pytest.approx(pair, rel=1e-9) and any("dropped 1 small" in r for r in report.repairs)


def test_an_inside_out_piece_beside_the_body_is_turned_outward_not_taken_for_a_cavity():
    """A 5 cm cube beside an inverted 4 cm cube enclosed 61 cm^3 (125 - 64: the second cube's volume subtracted,
    as if it were a hollow), with the mass, centre of mass and inertia to match; an inverted cube inside the
    first is a cavity and stays one."""
    body = trimesh.creation.box((0.05, 0.05, 0.05))
    beside = trimesh.creation.box((0.04, 0.04, 0.04)).apply_translation([0.2, 0, 0])
    beside.invert()
    mesh, report = validate_and_repair(trimesh.util.concatenate([body, beside]))
    assert mesh.volume == pytest.approx(189e-6) and any("turned 1 inside-out" in r for r in report.repairs)
    cavity = trimesh.creation.box((0.02, 0.02, 0.02))
    cavity.invert()
    mesh, report = validate_and_repair(trimesh.util.concatenate([body, cavity]))
    assert mesh.volume == pytest.approx(117e-6) and not any("turned" in r for r in report.repairs)


def test_overlapping_shells_count_their_shared_volume_once_and_a_cavity_stays():
    """Two closed boxes sharing 30 mm of length were concatenated: 4.8e-4 m^3 where the solid is 3.36e-4 (its
    mass and inertia with it); a box inside a box counted both. A cavity (an inward-facing inner shell) is kept."""
    a = trimesh.creation.box((0.05, 0.06, 0.08))
    b = trimesh.creation.box((0.05, 0.06, 0.08)).apply_translation([0.02, 0.0, 0.0])
    mesh, report = validate_and_repair(trimesh.util.concatenate([a, b]))
    assert mesh.volume == pytest.approx(0.07 * 0.06 * 0.08, rel=1e-5)  # manifold3d works in single precision
    assert mesh.center_mass == pytest.approx([0.01, 0.0, 0.0], abs=1e-6)
    assert any("merged into their union" in r for r in report.repairs)
    assert not any("pieces kept" in r for r in report.repairs)  # one piece left
    inner = trimesh.creation.box((0.08, 0.08, 0.08))
    mesh, _ = validate_and_repair(trimesh.util.concatenate([trimesh.creation.box((0.1, 0.1, 0.1)), inner]))
    assert mesh.volume == pytest.approx(1e-3, rel=1e-5)  # the outer box: the inner one lies inside it
    inner.invert()  # now a cavity
    mesh, report = validate_and_repair(trimesh.util.concatenate([trimesh.creation.box((0.1, 0.1, 0.1)), inner]))
    assert mesh.volume == pytest.approx(1e-3 - 0.08**3, rel=1e-9)
    assert not any("union" in r for r in report.repairs)
    rattle = trimesh.creation.icosphere(subdivisions=3, radius=0.02)  # a solid inside the cavity: kept whole
    mesh, report = validate_and_repair(trimesh.util.concatenate([trimesh.creation.box((0.1, 0.1, 0.1)), inner,
                                                                 rattle]))
    assert mesh.volume == pytest.approx(1e-3 - 0.08**3 + rattle.volume, rel=1e-9)
    assert not any("union" in r for r in report.repairs)


@pytest.mark.parametrize(("size", "phrases", "absent"), [
    (30.0, ["in millimetres, `--scale 0.001` (0.03 m)", "in centimetres, `--scale 0.01` (0.3 m)"], []),
    (600.0, ["in millimetres, `--scale 0.001` (0.6 m)"], ["centimetres"]),
    (1e7, ["scale it to metres"], ["millimetres"]),
])
def test_a_mesh_not_in_metres_is_given_the_scale_of_each_unit_it_fits(size, phrases, absent):
    """The power of ten nearest 0.15 m was suggested: a 30 mm part in mm got 0.01 (30 cm), a 600 mm crate
    0.0001 (6 cm)."""
    with pytest.raises(MeshUnitsError) as error:
        validate_and_repair(trimesh.creation.box((size, size / 2, size / 3)))
    for phrase in phrases:
        assert phrase in str(error.value)
    for phrase in absent:
        assert phrase not in str(error.value)


def test_the_units_hint_is_for_the_file_when_a_scale_was_given():
    """A 30 mm part in mm given scale 0.1 (3 m): the hint said `--scale 0.01` (0.03 m), which gives 0.3 m."""
    with pytest.raises(MeshUnitsError) as error:
        validate_and_repair(trimesh.creation.box((3.0, 1.5, 1.0)), scale=0.1)
    assert "at scale 0.1" in str(error.value) and "in millimetres, `--scale 0.001` (0.03 m)" in str(error.value)


def test_mass_inertia_and_frame_of_a_box():
    """A 0.1 x 0.06 x 0.04 m box of 0.3 kg: I = m/12 (b^2 + c^2) about each axis, frame at the COM."""
    box = trimesh.creation.box((0.1, 0.06, 0.04)).apply_translation([0.3, -0.2, 0.1])
    asset = build_object(box, name="box", mass=0.3).asset
    a, b, c, m = 0.1, 0.06, 0.04, 0.3
    expected = np.diag([m / 12 * (b * b + c * c), m / 12 * (a * a + c * c), m / 12 * (a * a + b * b)])
    np.testing.assert_allclose(asset.inertia, expected, atol=1e-12)
    visual = trimesh.load(asset.visual_path, force="mesh")
    np.testing.assert_allclose(visual.center_mass, 0.0, atol=1e-9)


def test_mjcf_compiles_with_the_right_mass_and_names(isolated_cache):
    asset = build_object(trimesh.creation.cylinder(0.03, 0.1), name="can", mass=0.35).asset
    model = mujoco.MjModel.from_xml_path(str(asset.mjcf_path))
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "object")
    assert model.body_mass[body] == pytest.approx(0.35)
    visual = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "object_visual")
    assert model.geom_contype[visual] == 0 and model.geom_conaffinity[visual] == 0
    part = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "object_part_000")
    assert model.geom_friction[part][0] == pytest.approx(0.5)
    assert model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE


def _count_coacd_calls(monkeypatch) -> list[int]:
    import coacd

    calls = [0]
    real = coacd.run_coacd

    def counting(*args, **kwargs):
        calls[0] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(coacd, "run_coacd", counting)
    return calls


@pytest.mark.slow
def test_second_build_calls_coacd_zero_times(isolated_cache, monkeypatch):
    calls = _count_coacd_calls(monkeypatch)
    mesh = trimesh.creation.annulus(0.03, 0.05, 0.02)
    first = build_object(mesh, name="ring", mass=0.1)
    second = build_object(mesh, name="ring", mass=0.1)
    assert calls[0] == 1 and not first.cached and second.cached
    assert second.asset.n_parts == first.asset.n_parts >= 3  # a ring needs several hulls


@pytest.mark.parametrize("damage", ["truncate", "garbage", "flip_bytes"])
@pytest.mark.slow
def test_corrupted_cache_entry_is_detected_and_rebuilt(isolated_cache, monkeypatch, damage):
    calls = _count_coacd_calls(monkeypatch)
    mesh = trimesh.creation.annulus(0.03, 0.05, 0.02)
    first = build_object(mesh, name="ring", mass=0.1)
    entry = HullCache(isolated_cache / "coacd").path(first.asset.metadata["hull_key"])
    data = entry.read_bytes()
    if damage == "truncate":
        entry.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        entry.write_bytes(b"not a zip file at all")
    else:  # same size, a few payload bytes changed: only the checksum can tell
        with np.load(entry) as z:
            arrays = {k: z[k] for k in z.files}
        arrays["v0"] = arrays["v0"] + 1e-3
        with open(entry, "wb") as f:
            np.savez(f, **arrays)
    again = build_object(mesh, name="ring", mass=0.1)
    assert calls[0] == 2 and not again.cached
    assert HullCache(isolated_cache / "coacd").get(first.asset.metadata["hull_key"]) is not None


def test_leftover_temp_file_from_a_killed_write_is_not_an_entry(isolated_cache):
    cache = HullCache(isolated_cache / "coacd")
    (cache.root / ".abc.123.tmp").write_bytes(b"half written")
    assert cache.get("abc") is None


def test_ycb_dataset_layout_is_found(tmp_path):
    box = trimesh.creation.box((0.05, 0.05, 0.1))
    for name, sub in [("003_cracker_box", "google_16k/textured.obj"), ("004_sugar_box", "poisson/textured.obj"),
                      ("005_tomato_soup_can", "tsdf/textured.obj")]:
        (tmp_path / name / Path(sub).parent).mkdir(parents=True)
        box.export(tmp_path / name / sub)
    (tmp_path / "README").mkdir()
    found = ycb_dataset(tmp_path)
    assert sorted(found) == ["003_cracker_box", "004_sugar_box", "005_tomato_soup_can"]
    assert found["004_sugar_box"].parts[-2] == "poisson"
    assert load_mesh(found["003_cracker_box"]).is_watertight


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply", ".glb", ".gltf", ".off"])
def test_every_supported_format_loads_the_same_mesh(tmp_path, suffix):
    box = trimesh.creation.box((0.05, 0.04, 0.03))
    path = tmp_path / f"box{suffix}"
    box.export(path)
    loaded = load_mesh(path)
    assert loaded.volume == pytest.approx(box.volume, rel=1e-6)
    np.testing.assert_allclose(loaded.extents, box.extents, atol=1e-9)


def test_open_box_is_closed_and_the_repair_recorded(tmp_path, isolated_cache):
    box = trimesh.creation.box((0.05, 0.04, 0.03))
    top = box.face_normals[:, 2] > 0.9
    asset = build_object(_write(trimesh.Trimesh(box.vertices, box.faces[~top], process=False),
                                tmp_path / "open_box.stl"), mass=0.1).asset
    assert asset.volume == pytest.approx(box.volume, rel=1e-6)  # STL stores float32
    assert asset.metadata["repairs"] and "closed holes" in " ".join(asset.metadata["repairs"])


def test_unsupported_suffix_and_missing_file(tmp_path):
    (tmp_path / "part.step").write_text("ISO-10303-21;")
    with pytest.raises(MeshError, match="unsupported mesh type"):
        load_mesh(tmp_path / "part.step")
    with pytest.raises(MeshError, match="no such mesh file"):
        load_mesh(tmp_path / "missing.obj")
    (tmp_path / "folder.obj").mkdir()  # was "no such mesh file": it exists, as a folder
    with pytest.raises(MeshError, match="folder.obj: a folder, not a mesh file"):
        load_mesh(tmp_path / "folder.obj")


def test_objects_list_json_has_the_documented_keys(capsys):
    import json

    assert main(["objects", "list", "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    assert len(records) >= 15
    mug = next(r for r in records if r["name"] == "025_mug")
    assert {"name", "ycb_id", "extents_m", "mass_kg"} <= set(mug)
    assert mug["ycb_id"] == "025" and mug["mass_kg"] == pytest.approx(0.118) and len(mug["extents_m"]) == 3


def test_the_convex_hull_of_a_flat_mesh_is_a_mesh_error_not_a_qhull_traceback():
    """`objects build --mesh triangle.obj --convex-hull` ended in scipy's QhullError ("not enough points to
    construct initial simplex"), a traceback that stopped the whole build."""
    triangle = trimesh.Trimesh([[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0]], [[0, 1, 2]], process=False)
    with pytest.raises(MeshError, match="encloses no volume .*convex hull cannot be built"):
        validate_and_repair(triangle, convex_hull_fallback=True)


def test_a_loose_default_cover_is_decomposed_again_finer_and_kept_if_closer(isolated_cache, monkeypatch):
    """A mesh whose default decomposition covers more than REFINE_ABOVE of its volume (a scanned bowl's cavity
    filled) is decomposed again with REFINED and the closer cover kept, recorded in the metadata and the build
    line; explicit settings are used as given. CoACD is stood in for by exact parts of an L (the default: its
    hull, 1.4 of its volume; finer: its two boxes)."""
    from manigrasp.objects import catalog, pipeline
    from manigrasp.objects.decompose import DecompositionParams

    long_arm = trimesh.creation.box((0.06, 0.02, 0.02), trimesh.transformations.translation_matrix([0.03, 0.01, 0]))
    short_arm = trimesh.creation.box((0.02, 0.04, 0.02), trimesh.transformations.translation_matrix([0.01, 0.04, 0]))
    ell = trimesh.boolean.union([long_arm, short_arm], engine="manifold")
    calls = []

    def standin(mesh, params):
        calls.append((params.threshold, params.max_convex_hull))
        if params.threshold == pipeline.REFINED["threshold"]:
            return [part.convex_hull.apply_translation(mesh.centroid - ell.centroid) for part in (long_arm, short_arm)]
        return [mesh.convex_hull]

    monkeypatch.setattr(pipeline, "decompose", standin)
    result = build_object(ell, name="ell", mass=0.1)
    assert calls == [(0.04, 32), (0.03, -1)]
    meta = result.asset.metadata
    assert result.asset.n_parts == 2 and meta["coverage"] == pytest.approx(1.0, abs=0.01)
    assert meta["decomposition"]["threshold"] == 0.03 and meta["decomposition"]["max_convex_hull"] == -1
    assert meta["refined_from"]["coverage"] == pytest.approx(28 / 20, rel=0.01) and meta["refined_from"]["n_hulls"] == 1
    line = catalog.summary(catalog.BuildOutcome("ell", result, None))
    assert "(the default CoACD settings covered 1.40 of its volume with 1 hulls; decomposed again at threshold " \
           "0.03, no hull cap)" in line
    again = build_object(ell, name="ell", mass=0.1)  # both decompositions cached: none runs, the same is kept
    assert again.cached and calls == [(0.04, 32), (0.03, -1)] and again.asset.n_parts == 2
    calls.clear()
    given = build_object(ell, name="ell_given", mass=0.1, params=DecompositionParams())
    assert calls == [] and given.asset.n_parts == 1  # explicit settings: as given (the default's cached cover)
    assert "refined_from" not in given.asset.metadata


def test_a_finer_cover_that_misses_more_than_the_default_adds_is_not_kept(isolated_cache, monkeypatch):
    """The closer cover is kept, not the smaller: a finer decomposition that leaves out part of the object (0.4 of
    the L's volume, 0.6 off) loses to the default's hull (1.4, 0.4 off)."""
    from manigrasp.objects import pipeline

    long_arm = trimesh.creation.box((0.06, 0.02, 0.02), trimesh.transformations.translation_matrix([0.03, 0.01, 0]))
    short_arm = trimesh.creation.box((0.02, 0.04, 0.02), trimesh.transformations.translation_matrix([0.01, 0.04, 0]))
    ell = trimesh.boolean.union([long_arm, short_arm], engine="manifold")

    def standin(mesh, params):
        if params.threshold == pipeline.REFINED["threshold"]:
            return [short_arm.convex_hull.apply_translation(mesh.centroid - ell.centroid)]
        return [mesh.convex_hull]

    monkeypatch.setattr(pipeline, "decompose", standin)
    meta = build_object(ell, name="ell", mass=0.1).asset.metadata
    assert meta["coverage"] == pytest.approx(1.4, rel=0.01) and "refined_from" not in meta
    assert meta["decomposition"]["threshold"] == 0.04
