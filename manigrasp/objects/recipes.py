"""The shipped YCB-like object set: a recipe table and the meshes built from it.

The table lives in ``assets/objects/ycb_like.yaml``; each entry names a solid
builder of `manigrasp.objects.shapes` and its parameters in metres, the
published extents and mass, and where those figures come from. `build_mesh`
turns a recipe into a watertight `trimesh.Trimesh` in the canonical frame:
natural resting pose, z up, bottom at z = 0, centred on its bounding box in x
and y. Building is deterministic: the same recipe gives the same mesh.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import trimesh
import yaml
from manifold3d import Manifold

from manigrasp.errors import ConfigError, MeshError, UnknownNameError
from manigrasp.objects.shapes import SHAPES
from manigrasp.paths import assets_dir
from manigrasp.registry import nearest, unknown_name_message

_REQUIRED = ("name", "ycb_id", "common_name", "shape", "params", "extents_m", "mass_kg", "source")
_OPTIONAL = ("notes", "decomposition")
_TOP_LEVEL = ("objects",)


@dataclass(frozen=True)
class Recipe:
    """One object of the shipped set.

    Attributes:
        name: "<ycb_id>_<common_name>", e.g. "025_mug".
        ycb_id: YCB id as printed by the set ("025"), or our own "x.." id.
        common_name: e.g. "mug".
        shape: name of the builder in `manigrasp.objects.shapes.SHAPES`.
        params: the builder's keyword arguments [m] (read-only mapping).
        extents_m: (x, y, z) extents of the built mesh, canonical frame [m].
        mass_kg: published mass [kg].
        source: where the figures come from.
        notes: what is approximated, and how.
        decomposition: CoACD settings that differ from `DecompositionParams`'s
            defaults for this object (e.g. a thin-walled bowl needs a lower
            concavity threshold to keep its cavity empty).
    """

    name: str
    ycb_id: str
    common_name: str
    shape: str
    params: Mapping[str, Any]
    extents_m: tuple[float, float, float]
    mass_kg: float
    source: str
    notes: str = ""
    decomposition: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))

    @property
    def density_kg_m3(self) -> float:
        """Uniform density that gives the built mesh its published mass [kg/m^3]."""
        return self.mass_kg / build_mesh(self).volume


def table_path() -> Path:
    """The shipped recipe table, ``assets/objects/ycb_like.yaml``."""
    return assets_dir() / "objects" / "ycb_like.yaml"


def load_table(path: str | Path | None = None) -> dict[str, Recipe]:
    """Read and validate a recipe table; `path` defaults to the shipped one.

    Returns:
        name -> Recipe, in the table's order.

    Raises:
        ConfigError: unreadable file, unknown or missing keys, bad values; the
            message names the object and the key.
    """
    path = Path(path) if path is not None else table_path()
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"cannot read recipe table {path}: {exc}") from exc
    if not isinstance(data, dict) or not isinstance(data.get("objects"), list):
        raise ConfigError(f"recipe table {path}: expected a mapping with an 'objects' list")
    _check_keys(data, _TOP_LEVEL, (), f"recipe table {path}")
    recipes: dict[str, Recipe] = {}
    for index, entry in enumerate(data["objects"]):
        recipe = _parse_entry(entry, index)
        if recipe.name in recipes:
            raise ConfigError(f"object {recipe.name!r} appears twice in {path}")
        recipes[recipe.name] = recipe
    _check_unique_common_names(recipes)
    return recipes


@functools.lru_cache(maxsize=1)
def _shipped() -> dict[str, Recipe]:
    return load_table()


def names() -> tuple[str, ...]:
    """Names of the shipped objects, sorted ("002_master_chef_can", ...)."""
    return tuple(sorted(_shipped()))


def get(name: str) -> Recipe:
    """The shipped recipe called `name`: full name ("025_mug"), common name ("mug") or id.

    Raises:
        UnknownNameError: no such object; the message lists the available names.
    """
    table = _shipped()
    if name in table:
        return table[name]
    for recipe in table.values():
        if name in (recipe.common_name, recipe.ycb_id):
            return recipe
    raise UnknownNameError(unknown_name_message("object", name, names()))


def build_mesh(recipe_or_name: Recipe | str) -> trimesh.Trimesh:
    """Build the mesh of a recipe (or of a shipped object's name) [m].

    Returns:
        A watertight, single-body mesh with consistent outward winding, in the
        canonical frame: bottom at z = 0, bounding box centred in x and y.

    Raises:
        UnknownNameError: unknown object name.
        MeshError: the builder produced something that is not one closed solid.
    """
    recipe = get(recipe_or_name) if isinstance(recipe_or_name, str) else recipe_or_name
    return _cached_build(recipe.name, recipe.shape, _freeze(recipe.params)).copy()


@functools.lru_cache(maxsize=64)
def _cached_build(name: str, shape: str, frozen_params: tuple) -> trimesh.Trimesh:
    solid: Manifold = SHAPES[shape](**_thaw(frozen_params))
    out = solid.to_mesh64()
    mesh = trimesh.Trimesh(np.asarray(out.vert_properties)[:, :3], np.asarray(out.tri_verts))
    lo, hi = mesh.bounds
    mesh.apply_translation([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
    if not (mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0):
        raise MeshError(f"recipe {name!r} ({shape}) did not build a closed solid")
    if mesh.body_count != 1:
        raise MeshError(f"recipe {name!r} ({shape}) built {mesh.body_count} separate pieces, not one body")
    return mesh


def _freeze(params: Mapping[str, Any]) -> tuple:
    return tuple(sorted((k, tuple(v) if isinstance(v, list | tuple) else v) for k, v in params.items()))


def _thaw(frozen: tuple) -> dict[str, Any]:
    return dict(frozen)


def _check_keys(entry: Mapping, allowed: tuple, required: tuple, where: str) -> None:
    for key in entry:
        if key not in allowed:
            hint = nearest(str(key), list(allowed))
            did_you_mean = f" (did you mean {hint!r}?)" if hint else ""
            raise ConfigError(f"{where}: unknown key {key!r}{did_you_mean}; allowed: {', '.join(allowed)}")
    for key in required:
        if key not in entry:
            raise ConfigError(f"{where}: missing key {key!r}")


def _parse_entry(entry: object, index: int) -> Recipe:
    if not isinstance(entry, dict):
        raise ConfigError(f"object #{index} of the recipe table is not a mapping")
    where = f"object {entry.get('name', f'#{index}')!r}"
    _check_keys(entry, _REQUIRED + _OPTIONAL, _REQUIRED, where)
    for key in ("name", "ycb_id", "common_name", "shape", "source"):
        if not isinstance(entry[key], str) or not entry[key]:
            raise ConfigError(
                f'{where}: key {key!r} must be a non-empty string (quote ids such as "025"), got {entry[key]!r}'
            )
    if entry["name"] != f"{entry['ycb_id']}_{entry['common_name']}":
        raise ConfigError(f"{where}: key 'name' must be '<ycb_id>_<common_name>'")
    _check_shape(entry["shape"], entry["params"], where)
    return Recipe(
        name=entry["name"],
        ycb_id=entry["ycb_id"],
        common_name=entry["common_name"],
        shape=entry["shape"],
        params=MappingProxyType(dict(entry["params"])),
        extents_m=_positive_vector(entry["extents_m"], 3, f"{where}: key 'extents_m'"),
        mass_kg=_positive_number(entry["mass_kg"], f"{where}: key 'mass_kg'"),
        source=entry["source"],
        notes=str(entry.get("notes") or ""),
        decomposition=MappingProxyType(_decomposition(entry.get("decomposition") or {}, where)),
    )


def _decomposition(overrides: object, where: str) -> dict[str, Any]:
    from manigrasp.objects.decompose import DecompositionParams

    if not isinstance(overrides, dict):
        raise ConfigError(f"{where}: key 'decomposition' must be a mapping")
    _check_keys(overrides, tuple(DecompositionParams.__dataclass_fields__), (), f"{where}: decomposition")
    return dict(overrides)


def _check_shape(shape: str, params: object, where: str) -> None:
    if shape not in SHAPES:
        raise ConfigError(f"{where}: key 'shape': {unknown_name_message('shape', shape, tuple(SHAPES))}")
    if not isinstance(params, dict):
        raise ConfigError(f"{where}: key 'params' must be a mapping")
    signature = inspect.signature(SHAPES[shape])
    _check_keys(params, tuple(signature.parameters), tuple(signature.parameters), f"{where}: params of shape {shape!r}")
    for key, value in params.items():
        if isinstance(value, list):
            _positive_vector(value, len(value), f"{where}: param {key!r}")
        else:
            _positive_number(value, f"{where}: param {key!r}")


def _positive_number(value: object, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
        raise ConfigError(f"{where} must be a positive number, got {value!r}")
    return float(value)


def _positive_vector(value: object, n: int, where: str) -> tuple[float, ...]:
    if not isinstance(value, list) or len(value) != n or n == 0:
        raise ConfigError(f"{where} must be a list of {n} positive numbers, got {value!r}")
    return tuple(_positive_number(v, where) for v in value)


def _check_unique_common_names(recipes: Mapping[str, Recipe]) -> None:
    seen: dict[str, str] = {}
    for recipe in recipes.values():
        for alias in (recipe.common_name, recipe.ycb_id):
            if alias in seen and seen[alias] != recipe.name:
                raise ConfigError(f"objects {seen[alias]!r} and {recipe.name!r} share the name {alias!r}")
            seen[alias] = recipe.name
