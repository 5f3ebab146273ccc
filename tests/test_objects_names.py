"""Issue 14, object names: no name writes outside the cache, a user mesh never takes a shipped name,
and a mesh built earlier under a name is found by the error that refuses that name."""

from __future__ import annotations

from pathlib import Path

import pytest
import trimesh

from manigrasp.bench.config import ObjectEntry
from manigrasp.cli import main
from manigrasp.errors import ConfigError, UnknownNameError
from manigrasp.objects import catalog
from manigrasp.objects.cache import NAME_MAX, check_name, inside, name_from_path
from manigrasp.objects.pipeline import build_object

BAD_NAMES = ["../../escape/evil", "/x/y", "a" * 300, "..", ".hidden", "a/b", "a\\b", "", "-rf", "x y", "é"]


@pytest.fixture
def cube(tmp_path: Path) -> Path:
    path = tmp_path / "cube.obj"
    trimesh.creation.box((0.05, 0.05, 0.05)).export(path)
    return path


def _files(root: Path) -> set[Path]:
    return {p for p in root.rglob("*") if p.is_file()}


@pytest.mark.parametrize("name", BAD_NAMES)
def test_bad_names_are_refused(name):
    with pytest.raises(ConfigError, match="object name"):
        check_name(name)


@pytest.mark.parametrize("name", ["part", "Part_2", "my-part.v1", "a" * NAME_MAX, "025_mug"])
def test_identifiers_are_names(name):
    assert check_name(name) == name


def test_inside_refuses_every_path_out_of_its_root(tmp_path):
    assert inside(tmp_path, "x-123") == (tmp_path / "x-123").resolve()
    for name in ("../x", "/etc/passwd", "a/../../x", "a/b", ".."):
        with pytest.raises(ConfigError, match="outside the cache"):
            inside(tmp_path, name)


def test_a_file_stem_becomes_a_valid_name():
    assert name_from_path("/a/my part (1).stl") == "my_part__1_"
    assert name_from_path("/a/.hidden.obj") == "hidden"
    assert len(name_from_path("/a/" + "b" * 300 + ".obj")) == NAME_MAX
    check_name(name_from_path("/a/über.obj"))


@pytest.mark.parametrize("name", ["../../escape/evil", "/x/y", "a" * 300])
def test_cli_build_refuses_a_name_out_of_the_cache_and_writes_nothing(tmp_path, cube, isolated_cache, capsys, name):
    code = main(["objects", "build", "--mesh", str(cube), "--name", name])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "object name" in err and "Traceback" not in err
    assert _files(tmp_path) == {cube}  # no cache entry, nothing next to it, nothing above it
    assert not (tmp_path.parent / "escape").exists() and not Path("/x/y").exists()


def test_build_object_refuses_a_bad_name_before_writing(tmp_path, cube, isolated_cache):
    with pytest.raises(ConfigError, match="object name"):
        build_object(cube, name="../../escape/evil")
    assert _files(tmp_path) == {cube}


def test_config_entry_with_a_bad_name_is_refused(tmp_path, cube):
    with pytest.raises(ConfigError, match="object name"):
        ObjectEntry(mesh="cube.obj", name="../../escape/x").source(tmp_path)


def test_config_mesh_named_by_an_odd_file_stem_gets_a_valid_name(tmp_path):
    assert ObjectEntry(mesh="my part.stl").source(tmp_path).name == "my_part"


def test_a_mesh_file_named_like_a_shipped_object_gets_its_own_name_by_default(tmp_path, isolated_cache, capsys):
    assert catalog.default_mesh_name("/a/mug.stl") == "mug_mesh"
    assert catalog.default_mesh_name("/a/part.stl") == "part"
    assert ObjectEntry(mesh="004_sugar_box.obj").source(tmp_path).name == "004_sugar_box_mesh"
    mug = tmp_path / "mug.obj"
    trimesh.creation.box((0.05, 0.05, 0.05)).export(mug)
    assert main(["objects", "build", "--mesh", str(mug)]) == 0
    assert "mug_mesh: 1 hulls" in capsys.readouterr().out
    assert main(["plan", "--mesh", str(mug), "--hand", "parallel_jaw", "--planner", "random", "-n", "1"]) == 0


@pytest.mark.parametrize("name", ["004_sugar_box", "mug", "025", "003_cracker_box_scan"])
def test_a_user_mesh_may_not_take_a_shipped_name(tmp_path, cube, isolated_cache, capsys, name):
    with pytest.raises(ConfigError, match="shipped object"):
        catalog.ObjectSource(name=name, mesh=str(cube))
    with pytest.raises(ConfigError, match="shipped object"):
        ObjectEntry(mesh="cube.obj", name=name).source(tmp_path)
    assert main(["objects", "build", "--mesh", str(cube), "--name", name]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "shipped object" in err
    assert not isolated_cache.exists() or not _files(isolated_cache)


@pytest.mark.parametrize("option", [["--mass", "0"], ["--density", "-5"], ["--mass", "nan"], ["--scale", "-1"]])
def test_a_mass_density_or_scale_that_is_not_positive_is_a_one_line_error(cube, isolated_cache, capsys, option):
    """Mass 0 raised a ValueError traceback from the mass properties; a negative scale mirrored the mesh."""
    assert main(["objects", "build", "--mesh", str(cube), "--name", "part", *option]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "must be a finite number > 0" in err and option[0][2:] in err
    assert not isolated_cache.exists() or not _files(isolated_cache)


def test_shipped_sources_still_build_their_names():
    assert catalog.shipped("mug").name == "025_mug"
    scan = catalog.shipped("003_cracker_box_scan")
    assert scan.mesh is not None and scan.name == "003_cracker_box_scan"


def test_unknown_name_of_a_built_mesh_says_how_to_refer_to_it(tmp_path, cube, isolated_cache, capsys):
    assert main(["objects", "build", "--mesh", str(cube), "--name", "part"]) == 0
    capsys.readouterr()
    with pytest.raises(UnknownNameError) as caught:
        catalog.shipped("part")
    message = str(caught.value)
    assert "unknown object 'part'" in message and f"{{mesh: {cube}, name: part}}" in message
    assert "\n" not in message
    # what the message says works: the config entry names the same object, from the cache
    source = ObjectEntry(mesh=str(cube), name="part").source(tmp_path)
    assert catalog.build(source).cached
    with pytest.raises(UnknownNameError) as caught:
        catalog.shipped("never_built")
    assert "was built from" not in str(caught.value)


def test_a_ycb_folder_of_an_odd_name_is_named_like_an_odd_file_stem(tmp_path, cube):
    """A YCB folder `001 thing` (or `café`) was refused as the object name '001 thing_ycb', and a dataset holding
    it built none of its objects; a mesh file's stem was made a valid name all along."""
    for folder, name in (("001 thing", "001_thing_ycb"), ("café", "caf__ycb"), ("025_mug", "025_mug_ycb"),
                         ("x" * 80, "x" * (NAME_MAX - 4) + "_ycb")):
        mesh = tmp_path / folder / "google_16k" / "textured.obj"
        mesh.parent.mkdir(parents=True)
        mesh.write_bytes(cube.read_bytes())
        assert catalog.from_ycb_folder(tmp_path / folder).name == name
        assert ObjectEntry(ycb=str(tmp_path / folder)).source(tmp_path).name == name
