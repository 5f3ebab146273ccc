"""The shipped YCB-like recipes: published figures, closed solids, topology, inertia, errors."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial import ConvexHull

from manigrasp.errors import ConfigError, MeshError, UnknownNameError
from manigrasp.objects import recipes

NAMES = recipes.names()

# An independent transcription of the published figures (mm, g): the YCB table
# (Calli et al. 2015) and, for x01, a typical smartphone. A row lists only the
# dimensions the source gives: the banana's curvature, the mug's handle, the
# hammer's handle and the drill's height and width are not published.
PUBLISHED = {
    "002_master_chef_can": ((102, 102, 139), 414),
    "003_cracker_box": ((60, 158, 210), 411),
    "004_sugar_box": ((38, 89, 175), 514),
    "005_tomato_soup_can": ((66, 66, 101), 349),
    "006_mustard_bottle": ((50, 85, 175), 603),
    "007_tuna_fish_can": ((85, 85, 33), 171),
    "008_pudding_box": ((35, 110, 89), 187),
    "009_gelatin_box": ((28, 85, 73), 97),
    "010_potted_meat_can": ((50, 97, 82), 370),
    "011_banana": ((36, 190), 66),
    "024_bowl": ((159, 159, 53), 147),
    "025_mug": ((80, 82), 118),
    "035_power_drill": ((184,), 895),
    "036_wood_block": ((85, 85, 200), 729),
    "037_scissors": ((87, 200, 14), 82),
    "048_hammer": ((135, 34), 665),
    "056_tennis_ball": ((64.7, 64.7, 64.7), 58),
    "061_foam_brick": ((50, 75, 50), 28),
    "077_rubiks_cube": ((57, 57, 57), 94.5),
    "x01_phone_box": ((146.7, 71.5, 7.8), 172),
}

GENUS = {"025_mug": 1, "037_scissors": 2}  # every other object is genus 0


def _euler_genus(mesh) -> int:
    chi = len(mesh.vertices) - len(mesh.edges_unique) + len(mesh.faces)
    return (2 - chi) // 2


def _matches(published_mm: tuple[float, ...], extents_m: tuple[float, ...], tol_mm: float) -> bool:
    """True if each published figure matches a different extent within `tol_mm`."""
    free = [1000.0 * e for e in extents_m]
    for figure in sorted(published_mm, reverse=True):
        hit = next((e for e in free if abs(e - figure) <= tol_mm), None)
        if hit is None:
            return False
        free.remove(hit)
    return True


def test_the_set_has_the_objects_the_issue_asks_for() -> None:
    assert len(NAMES) >= 15
    required = [
        "025_mug",
        "037_scissors",
        "048_hammer",
        "011_banana",
        "x01_phone_box",
        "003_cracker_box",
        "004_sugar_box",
        "005_tomato_soup_can",
        "007_tuna_fish_can",
        "024_bowl",
        "035_power_drill",
        "061_foam_brick",
        "056_tennis_ball",
        "036_wood_block",
        "006_mustard_bottle",
    ]
    assert set(required) <= set(NAMES)
    assert set(NAMES) == set(PUBLISHED)


@pytest.mark.parametrize("name", NAMES)
def test_table_carries_the_published_figures(name: str) -> None:
    recipe = recipes.get(name)
    dims_mm, mass_g = PUBLISHED[name]
    assert recipe.mass_kg == pytest.approx(mass_g / 1000.0, abs=1e-9)
    assert _matches(dims_mm, recipe.extents_m, tol_mm=0.05), (dims_mm, recipe.extents_m)
    assert recipe.source and recipe.name == f"{recipe.ycb_id}_{recipe.common_name}"


@pytest.mark.parametrize("name", NAMES)
def test_mesh_is_a_closed_single_solid_in_the_canonical_frame(name: str) -> None:
    recipe = recipes.get(name)
    mesh = recipes.build_mesh(recipe)
    assert mesh.is_watertight
    assert mesh.is_winding_consistent
    assert mesh.volume > 0
    assert mesh.body_count == 1
    assert 12 <= len(mesh.faces) <= 10_000
    np.testing.assert_allclose(mesh.extents, recipe.extents_m, atol=0.002)
    lo, hi = mesh.bounds
    assert lo[2] == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose((lo[:2] + hi[:2]) / 2, 0.0, atol=1e-9)


@pytest.mark.parametrize("name", NAMES)
def test_topology_genus(name: str) -> None:
    assert _euler_genus(recipes.build_mesh(name)) == GENUS.get(name, 0)


@pytest.mark.parametrize("name", NAMES)
def test_canonical_pose_is_a_rest(name: str) -> None:
    """The centre of mass lies over the support: the hull of the vertices on z = 0, or a single contact point."""
    mesh = recipes.build_mesh(name)
    com = mesh.center_mass[:2]
    support = mesh.vertices[mesh.vertices[:, 2] < 1e-7, :2]
    if len(support) == 1:
        np.testing.assert_allclose(com, support[0], atol=1e-6)
        return
    hull = ConvexHull(support)
    # inside every edge's half-plane (hull.equations: outward normal . p + offset <= 0)
    assert np.all(hull.equations[:, :2] @ com + hull.equations[:, 2] < 0), name


def test_build_is_deterministic() -> None:
    first = {name: recipes.build_mesh(name) for name in ("025_mug", "011_banana", "037_scissors")}
    recipes._cached_build.cache_clear()
    for name, mesh in first.items():
        again = recipes.build_mesh(name)
        np.testing.assert_array_equal(mesh.vertices, again.vertices)
        np.testing.assert_array_equal(mesh.faces, again.faces)


@pytest.mark.parametrize(
    ("name", "max_fill"),
    [("024_bowl", 0.3), ("025_mug", 0.5), ("037_scissors", 0.6), ("048_hammer", 0.6), ("035_power_drill", 0.8)],
)
def test_concave_objects_are_far_from_their_convex_hull(name: str, max_fill: float) -> None:
    mesh = recipes.build_mesh(name)
    assert mesh.volume < max_fill * mesh.convex_hull.volume


def _inertia(name: str) -> tuple[np.ndarray, np.ndarray, float]:
    """(inertia about the centre of mass, centre of mass, mass) at the published mass."""
    recipe = recipes.get(name)
    mesh = recipes.build_mesh(recipe)
    mesh.density = recipe.mass_kg / mesh.volume
    return mesh.moment_inertia, mesh.center_mass, mesh.mass


BOXES = [n for n in NAMES if recipes.get(n).shape == "box"]
CYLINDERS = [n for n in NAMES if recipes.get(n).shape == "cylinder"]


@pytest.mark.parametrize("name", BOXES)
def test_box_inertia_matches_the_formula(name: str) -> None:
    inertia, com, mass = _inertia(name)
    a, b, c = recipes.get(name).extents_m
    m = recipes.get(name).mass_kg
    assert mass == pytest.approx(m)
    expected = m / 12.0 * np.diag([b**2 + c**2, a**2 + c**2, a**2 + b**2])
    np.testing.assert_allclose(inertia, expected, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(com, [0.0, 0.0, c / 2], atol=1e-12)


@pytest.mark.parametrize("name", CYLINDERS)
def test_cylinder_inertia_matches_the_formula(name: str) -> None:
    inertia, com, _ = _inertia(name)
    params = recipes.get(name).params
    r, h, m = params["radius_m"], params["height_m"], recipes.get(name).mass_kg
    expected = np.diag([m / 12.0 * (3 * r**2 + h**2)] * 2 + [m * r**2 / 2])
    # a 64-gon stands in for the circle: its r^2 terms are ~0.1 % low
    np.testing.assert_allclose(inertia, expected, rtol=3e-3, atol=1e-12)
    np.testing.assert_allclose(com, [0.0, 0.0, h / 2], atol=1e-9)


def test_ball_inertia_matches_the_formula() -> None:
    inertia, com, _ = _inertia("056_tennis_ball")
    recipe = recipes.get("056_tennis_ball")
    r = recipe.params["radius_m"]
    np.testing.assert_allclose(inertia, np.eye(3) * 0.4 * recipe.mass_kg * r**2, rtol=1e-2, atol=1e-12)
    np.testing.assert_allclose(com, [0.0, 0.0, r], atol=1e-6)


def test_lookup_by_full_common_name_and_id() -> None:
    assert recipes.get("mug") is recipes.get("025_mug") is recipes.get("025")
    assert recipes.get("phone_box").name == "x01_phone_box"
    assert recipes.build_mesh("mug").volume == pytest.approx(recipes.build_mesh("025_mug").volume)


def test_unknown_name_lists_the_available_ones() -> None:
    with pytest.raises(UnknownNameError) as info:
        recipes.get("026_mugg")
    message = str(info.value)
    assert "026_mugg" in message
    assert all(name in message for name in NAMES)
    with pytest.raises(UnknownNameError):
        recipes.build_mesh("teapot")


def _write_table(tmp_path: Path, mutate) -> Path:
    data = yaml.safe_load(recipes.table_path().read_text())
    mutate(data["objects"][0])
    path = tmp_path / "table.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_load_table_reads_the_shipped_file() -> None:
    table = recipes.load_table()
    assert tuple(sorted(table)) == NAMES
    assert table["025_mug"] == recipes.get("mug")


@pytest.mark.parametrize(
    ("mutate", "words"),
    [
        (lambda e: e.update(mas_kg=e.pop("mass_kg")), ["002_master_chef_can", "'mas_kg'", "mass_kg"]),
        (lambda e: e.pop("source"), ["002_master_chef_can", "missing", "'source'"]),
        (lambda e: e["params"].update(radius=e["params"].pop("radius_m")), ["002_master_chef_can", "'radius'"]),
        (lambda e: e["params"].pop("height_m"), ["002_master_chef_can", "'height_m'"]),
        (lambda e: e.update(shape="cylindre"), ["002_master_chef_can", "'cylindre'", "cylinder"]),
        (lambda e: e.update(ycb_id=2), ["002_master_chef_can", "'ycb_id'"]),
        (lambda e: e.update(mass_kg=-0.4), ["002_master_chef_can", "'mass_kg'"]),
        (lambda e: e.update(extents_m=[0.1, 0.1]), ["002_master_chef_can", "'extents_m'"]),
    ],
    ids=[
        "misspelled-key",
        "missing-key",
        "misspelled-param",
        "missing-param",
        "unknown-shape",
        "unquoted-id",
        "negative-mass",
        "short-extents",
    ],
)
def test_bad_table_gives_a_config_error_naming_object_and_key(tmp_path: Path, mutate, words) -> None:
    with pytest.raises(ConfigError) as info:
        recipes.load_table(_write_table(tmp_path, mutate))
    assert all(word in str(info.value) for word in words), str(info.value)


def test_unreadable_table_is_a_config_error(tmp_path: Path) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text("objects: [unclosed\n")
    with pytest.raises(ConfigError):
        recipes.load_table(path)
    with pytest.raises(ConfigError):
        recipes.load_table(tmp_path / "missing.yaml")


def test_a_recipe_that_falls_apart_is_refused() -> None:
    mug = recipes.get("025_mug")
    detached = dataclasses.replace(mug, params={**mug.params, "handle_x_m": 0.08})
    with pytest.raises(MeshError, match="separate pieces"):
        recipes.build_mesh(detached)
