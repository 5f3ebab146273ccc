"""Issue 14, red-team 9 and 8: object folders of the cache are relocatable (mesh files relative to
object.xml), every file is checksummed (a damaged or edited entry is rebuilt, never read), and a
built cache is only read."""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from manigrasp.objects import catalog
from manigrasp.objects.pipeline import build_object, entry_is_intact

MASS = 0.25


def _ring() -> trimesh.Trimesh:
    return trimesh.creation.annulus(0.03, 0.05, 0.02)


def _compiled_mass(mjcf: Path) -> float:
    """Mass of the object attached into an empty scene, as compose.py attaches it (cwd is elsewhere)."""
    child = mujoco.MjSpec.from_file(str(mjcf))
    spec = mujoco.MjSpec()
    spec.worldbody.add_frame().attach_body(child.body("object"), "object/", "")
    model = spec.compile()
    return float(model.body_mass[1])


def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.stat().st_ino, p.stat().st_mtime_ns) for p in root.rglob("*")}


@pytest.mark.slow
def test_object_xml_names_its_meshes_relative_to_itself(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    asset = build_object(_ring(), name="ring", mass=MASS, cache_root=tmp_path / "cache").asset
    files = [m.get("file") for m in ET.parse(asset.mjcf_path).getroot().iter("mesh")]
    assert files == ["visual.obj"] + [f"part_{i:03d}.obj" for i in range(asset.n_parts)]
    assert str(tmp_path) not in asset.mjcf_path.read_text()


@pytest.mark.slow
def test_a_moved_cache_works_and_a_copy_reads_its_own_files(tmp_path, monkeypatch):
    monkeypatch.chdir("/")
    first = build_object(_ring(), name="ring", mass=MASS, cache_root=tmp_path / "a").asset
    shutil.move(tmp_path / "a", tmp_path / "b")  # moved: the old place is gone
    moved = build_object(_ring(), name="ring", mass=MASS, cache_root=tmp_path / "b")
    assert moved.cached and moved.asset.mjcf_path.parent.name == first.mjcf_path.parent.name
    assert _compiled_mass(moved.asset.mjcf_path) == pytest.approx(MASS)
    shutil.copytree(tmp_path / "b", tmp_path / "c")  # copied, then the original is damaged
    for part in (tmp_path / "b").rglob("part_*.obj"):
        part.write_text("garbage")
    copy = build_object(_ring(), name="ring", mass=MASS, cache_root=tmp_path / "c").asset
    assert _compiled_mass(copy.mjcf_path) == pytest.approx(MASS)  # would fail if it read b's parts


@pytest.mark.parametrize("damage", ["garbage_xml", "no_meta", "mass_edited", "part_deleted", "no_checksums"])
@pytest.mark.slow
def test_a_damaged_or_edited_entry_is_rebuilt(tmp_path, damage):
    cache = tmp_path / "cache"
    asset = build_object(_ring(), name="ring", mass=MASS, cache_root=cache).asset
    folder = asset.mjcf_path.parent
    good = {p.name: p.read_bytes() for p in folder.iterdir()}
    if damage == "garbage_xml":
        (folder / "object.xml").write_bytes(b"\x00\xffnot xml")
    elif damage == "no_meta":
        (folder / "meta.json").unlink()
    elif damage == "mass_edited":
        xml = (folder / "object.xml").read_text()
        assert f'mass="{MASS:.9g}"' in xml
        (folder / "object.xml").write_text(xml.replace(f'mass="{MASS:.9g}"', 'mass="5"'))
    elif damage == "part_deleted":
        (folder / "part_000.obj").unlink()
    else:
        (folder / "checksums.json").unlink()
    assert not entry_is_intact(folder)
    again = build_object(_ring(), name="ring", mass=MASS, cache_root=cache)
    assert again.cached  # the hulls were fine: no CoACD, only the folder rewritten
    assert again.asset.mjcf_path == asset.mjcf_path and entry_is_intact(folder)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == good
    assert _compiled_mass(folder / "object.xml") == pytest.approx(MASS)
    assert [p.name for p in (cache / "objects").iterdir()] == [folder.name]  # nothing left aside


def test_a_built_shipped_object_is_only_read(tmp_path):
    cache = tmp_path / "cache"
    first = catalog.build(catalog.shipped("004_sugar_box"), cache_root=cache)
    assert catalog.is_built("004_sugar_box", cache_root=cache)
    before = _snapshot(cache)
    again = catalog.build(catalog.shipped("004_sugar_box"), cache_root=cache)
    assert again.cached and again.asset.mjcf_path == first.asset.mjcf_path
    assert _snapshot(cache) == before  # no marker or file rewritten: a read-only cache works


def test_is_built_follows_a_moved_cache_and_sees_damage(tmp_path):
    catalog.build(catalog.shipped("004_sugar_box"), cache_root=tmp_path / "a")
    shutil.move(tmp_path / "a", tmp_path / "b")
    assert catalog.is_built("004_sugar_box", cache_root=tmp_path / "b")
    marker = json.loads((tmp_path / "b" / "objects" / "004_sugar_box.built.json").read_text())
    xml = tmp_path / "b" / "objects" / marker["folder"] / "object.xml"
    xml.write_text(xml.read_text().replace("mass=", "mass=\"9\" old="))
    assert not catalog.is_built("004_sugar_box", cache_root=tmp_path / "b")
    rebuilt = catalog.build(catalog.shipped("004_sugar_box"), cache_root=tmp_path / "b")
    assert np.isclose(_compiled_mass(rebuilt.asset.mjcf_path), rebuilt.asset.mass)
    assert catalog.is_built("004_sugar_box", cache_root=tmp_path / "b")


def test_a_mesh_over_the_face_bound_is_refused_before_coacd(tmp_path, monkeypatch, capsys):
    import coacd

    from manigrasp.cli import main
    from manigrasp.errors import MeshError
    from manigrasp.objects.pipeline import MAX_FACES

    monkeypatch.setenv("MANIGRASP_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(coacd, "run_coacd", lambda *a, **k: pytest.fail("CoACD called on an oversized mesh"))
    sphere = trimesh.creation.icosphere(subdivisions=7, radius=0.05)  # 327680 faces
    assert len(sphere.faces) > MAX_FACES
    with pytest.raises(MeshError, match=f"327680 faces, more than the {MAX_FACES}"):
        build_object(sphere, name="ball", mass=MASS)
    sphere.export(tmp_path / "ball.ply")
    assert main(["objects", "build", "--mesh", str(tmp_path / "ball.ply")]) == 1
    err = capsys.readouterr().err
    assert f"ball: FAILED: {tmp_path / 'ball.ply'}: 327680 faces, more than the {MAX_FACES}" in err
    assert not list((tmp_path / "cache").rglob("*.obj"))


def _edit_hull_meta(entry: Path, **changes) -> None:
    """Rewrite a CoACD cache entry with `changes` to its metadata, its arrays and stored checksum as they were."""
    with np.load(entry) as data:
        arrays = {name: data[name] for name in data.files}
    meta = json.loads(str(arrays["meta"]))
    arrays["meta"] = np.array(json.dumps({**meta, **changes}))
    with open(entry, "wb") as f:
        np.savez(f, **arrays)


@pytest.mark.parametrize("change", [{"coverage": 7.77}, {"key": "0" * 32}])
def test_an_edited_decomposition_metadata_is_a_miss_not_used(tmp_path, change):
    """The checksum of a CoACD cache entry covered its hulls only: an edited `coverage` was read as cached and
    became the object's coverage (and its folder's meta.json)."""
    box = trimesh.creation.box((0.04, 0.06, 0.08))  # convex: its hull is its only part, no CoACD run
    first = build_object(box, name="box", mass=MASS, cache_root=tmp_path)
    (entry,) = (tmp_path / "coacd").glob("*.npz")
    _edit_hull_meta(entry, **change)
    again = build_object(box, name="box", mass=MASS, cache_root=tmp_path)
    assert not again.cached  # decomposed again, not read
    assert again.asset.metadata == first.asset.metadata and again.asset.mjcf_path == first.asset.mjcf_path
    assert json.loads((again.asset.mjcf_path.parent / "meta.json").read_text())["coverage"] == pytest.approx(
        first.asset.metadata["coverage"])
    assert build_object(box, name="box", mass=MASS, cache_root=tmp_path).cached  # the rewritten entry is good


def test_a_build_of_another_cache_format_is_not_built(tmp_path, monkeypatch):
    """The build marker's fingerprint did not name the cache format: after a format change (whose decomposition keys
    differ) `is_built` still said built, and `objects list` and the run's object step took a shipped object that
    needed decomposing again for a cached one (decomposed silently, "building..." unsaid)."""
    from manigrasp.objects import cache

    catalog.build(catalog.shipped("004_sugar_box"), cache_root=tmp_path)
    assert catalog.is_built("004_sugar_box", cache_root=tmp_path)
    monkeypatch.setattr(cache, "CACHE_FORMAT", cache.CACHE_FORMAT + 1)
    assert not catalog.is_built("004_sugar_box", cache_root=tmp_path)
    assert not catalog.build(catalog.shipped("004_sugar_box"), cache_root=tmp_path).cached
    assert catalog.is_built("004_sugar_box", cache_root=tmp_path)
