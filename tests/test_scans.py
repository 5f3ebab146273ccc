"""The shipped real YCB scans: names, sources, attribution, and one build through the repair path."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from manigrasp.errors import UnknownNameError
from manigrasp.objects import catalog, recipes, scans


def test_five_scans_each_with_a_file_a_mass_and_a_recipe_twin() -> None:
    assert scans.names() == ("002_master_chef_can_scan", "003_cracker_box_scan", "005_tomato_soup_can_scan",
                             "009_gelatin_box_scan", "010_potted_meat_can_scan")
    for name in scans.names():
        scan = scans.get(name)
        assert scan.path.is_file() and scan.path.stat().st_size < 1_000_000
        assert recipes.get(scan.twin).name == scan.twin
        assert 0.05 < scan.mass_kg < 0.5
    assert scans.get("003_cracker_box_scan").mass_kg == pytest.approx(0.411)
    assert scans.twins()["010_potted_meat_can_scan"] == "010_potted_meat_can"


def test_attribution_and_licence_ship_with_the_files() -> None:
    text = (scans.scans_dir() / "README.md").read_text()
    for needle in ("Calli", "CC BY 4.0", "YCB_sim", "Apache-2.0"):
        assert needle in text


def test_scans_are_shipped_names() -> None:
    source = catalog.shipped("009_gelatin_box_scan")
    assert source.recipe is None and source.mesh == str(scans.get("009_gelatin_box_scan").path)
    assert source.mass == pytest.approx(0.097)
    assert catalog.shipped("009_gelatin_box").recipe == "009_gelatin_box"  # the twin stays a recipe
    with pytest.raises(UnknownNameError, match="available: 002_master_chef_can_scan"):
        scans.get("004_sugar_box_scan")


@pytest.mark.slow
def test_an_open_scan_is_repaired_and_keeps_its_shape(tmp_path) -> None:
    """The gelatin box scan has open seams: the pipeline closes them without changing its size,
    and its thinnest side is within 3 mm of its recipe twin's (28 mm)."""
    scan = scans.get("009_gelatin_box_scan")
    raw = trimesh.load(scan.path, force="mesh")
    assert not raw.is_watertight
    asset = catalog.build(catalog.shipped(scan.name), cache_root=tmp_path).asset
    assert any("closed holes" in r for r in asset.metadata["repairs"])
    assert asset.mass == pytest.approx(0.097)
    np.testing.assert_allclose(asset.extents, raw.extents, atol=1e-3)
    twin = recipes.build_mesh(recipes.get(scan.twin))
    assert min(asset.extents) == pytest.approx(min(twin.extents), abs=0.003)
