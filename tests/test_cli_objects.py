"""`manigrasp objects list | show` name every shipped object, the real scans (`<stem>_scan`) included."""

from __future__ import annotations

import json

import pytest

from manigrasp.cli import main
from manigrasp.objects import scans


def test_the_list_holds_the_scans_with_their_figures(capsys):
    """The five scans are shipped objects (`bench scans` runs them by name), but `objects list` listed only the 20
    recipes: a reader of a scans report could not look them up."""
    assert main(["objects", "list", "--json"]) == 0
    rows = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    assert len(rows) == 25 and set(scans.names()) <= set(rows)
    box, twin = rows["003_cracker_box_scan"], rows["003_cracker_box"]
    assert box["ycb_id"] == "003" and box["mass_kg"] == twin["mass_kg"] == 0.411
    assert box["common_name"] == f"{twin['common_name']} (scan)"
    assert sorted(box["extents_m"]) == pytest.approx(sorted(twin["extents_m"]), abs=0.012)  # the same box
    assert box["volume_m3"] == pytest.approx(twin["volume_m3"], rel=0.15)  # watertight as shipped
    assert rows["009_gelatin_box_scan"]["volume_m3"] is None  # not watertight as shipped: no volume to state
    assert main(["objects", "list"]) == 0
    table = capsys.readouterr().out
    line = next(x for x in table.splitlines() if x.startswith("009_gelatin_box_scan "))
    assert line.split()[-2:] == ["-", "-"]  # no volume (holes), build state not tracked for scans
    assert box["built"] is None and twin["built"] in (True, False)


def test_show_takes_a_scan_by_name(capsys):
    """Before: 'unknown object 003_cracker_box_scan (did you mean 003_cracker_box?)', exit 2."""
    assert main(["objects", "show", "003_cracker_box_scan", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["name"] == "003_cracker_box_scan" and info["ycb_id"] == "003" and info["mass_kg"] == 0.411
    assert "scan" in info["source"] and "003_cracker_box" in info["notes"]


def test_build_options_are_applied_to_one_ycb_folder_or_refused(tmp_path, isolated_cache, capsys):
    """`objects build --ycb FOLDER --mass 0.2 --name x` built `<folder>_ycb` at its density's mass, and
    `objects build mug --mass 2` built the shipped mug: the options were silently ignored."""
    import trimesh

    folder = tmp_path / "ycb" / "999_thing" / "google_16k"
    folder.mkdir(parents=True)
    trimesh.creation.box((0.05, 0.04, 0.03)).export(folder / "textured.obj")
    assert main(["objects", "build", "--ycb", str(folder.parent), "--mass", "0.2", "--name", "thing"]) == 0
    assert capsys.readouterr().out.startswith("thing: ")
    (meta,) = isolated_cache.glob("objects/thing-*/object.xml")
    assert 'mass="0.2"' in meta.read_text()
    other = tmp_path / "ycb" / "998_other" / "google_16k"
    other.mkdir(parents=True)
    trimesh.creation.box((0.05, 0.04, 0.02)).export(other / "textured.obj")
    for argv in (["--ycb", str(tmp_path / "ycb"), "--mass", "0.2"], ["025_mug", "--mass", "2"],
                 ["--ycb", str(folder.parent), "--scale", "0.001"], ["--all", "--density", "900"]):
        assert main(["objects", "build", *argv]) == 2, argv
        assert "not used here" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["objects", "build", "--help"], ["plan", "--help"]])
def test_the_mesh_option_names_every_mesh_type_read(argv, capsys):
    """--mesh's help listed OBJ, STL, PLY and GLB/GLTF; OFF is read too (`meshio.MESH_SUFFIXES`)."""
    from manigrasp.objects.meshio import MESH_SUFFIXES

    with pytest.raises(SystemExit):
        main(argv)
    text = " ".join(capsys.readouterr().out.split())
    for suffix in MESH_SUFFIXES:
        assert suffix[1:].upper() in text, suffix
