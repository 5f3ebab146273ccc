"""The shipped YCB-like set, and building many objects at once.

An object is named in one of three ways (`ObjectSource`): a shipped name (a
recipe, "025_mug" or "mug", or a shipped real scan, "003_cracker_box_scan"), a
mesh file (with name, scale, mass), or one object folder of a real YCB
download (named ``<folder>_ycb`` unless given a name). `build_many` builds a
list of them in parallel worker processes with a progress bar; CoACD results
are cached on disk.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass
from multiprocessing import get_context
from pathlib import Path

from manigrasp.errors import ConfigError, UnknownNameError
from manigrasp.objects import recipes, scans
from manigrasp.objects.cache import NAME_MAX as NAME_MAX
from manigrasp.objects.cache import check_name, inside, name_from_text
from manigrasp.objects.cache import name_from_path as name_from_path
from manigrasp.objects.decompose import DecompositionParams, coacd_version
from manigrasp.objects.meshio import ycb_mesh_file
from manigrasp.objects.pipeline import DEFAULT_DENSITY, BuildResult, build_object, entry_is_intact
from manigrasp.paths import cache_dir
from manigrasp.registry import unknown_name_message

YCB_SUFFIX = "_ycb"  # appended to a YCB download's folder name (`from_ycb_folder`)


def default_mesh_name(path: str | Path) -> str:
    """The name of a mesh given none: its file stem made a valid name (`name_from_path`), with
    ``_mesh`` appended if that is a shipped object's name (``mug.stl`` is ``mug_mesh``)."""
    name = name_from_path(path)
    return f"{name[:NAME_MAX - 5]}_mesh" if is_shipped_name(name) else name


def is_shipped_name(name: str) -> bool:
    """Whether `name` names a shipped object: a recipe (full name, common name or YCB id) or a scan."""
    if scans.is_scan(name):
        return True
    try:
        recipes.get(name)
    except UnknownNameError:
        return False
    return True


@dataclass(frozen=True)
class ObjectSource:
    """How to obtain one object: exactly one of `recipe`, `mesh` or `ycb_folder`.

    Attributes:
        name: object name (for a recipe: its full name).
        recipe: shipped recipe name.
        mesh: path of a mesh file.
        ycb_folder: one object's folder of a real YCB download.
        scale: factor applied to a mesh file's vertices (0.001 for mm).
        mass: mass [kg]; None: the recipe's, else from `density`.
        density: [kg/m^3] when no mass is known.
        convex_hull_fallback: accept the convex hull of a mesh that cannot be closed.
    """

    name: str
    recipe: str | None = None
    mesh: str | None = None
    ycb_folder: str | None = None
    scale: float = 1.0
    mass: float | None = None
    density: float = DEFAULT_DENSITY
    convex_hull_fallback: bool = False

    def __post_init__(self) -> None:
        check_name(self.name)
        # A scale <= 0 would mirror or collapse the mesh; a mass or density <= 0 gives no physical body.
        for key, value in (("scale", self.scale), ("mass", self.mass), ("density", self.density)):
            if value is not None and not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"object {self.name}: {key} must be a finite number > 0, got {value!r}")
        if self.mesh is not None and is_shipped_name(self.name) and not (
                scans.is_scan(self.name) and Path(self.mesh) == scans.get(self.name).path):
            raise ConfigError(f"mesh {self.mesh}: the name {self.name!r} is a shipped object's; give the mesh a name "
                              "of its own (--name / name:)")
        if self.ycb_folder is not None and is_shipped_name(self.name):
            raise ConfigError(f"YCB folder {self.ycb_folder}: the name {self.name!r} is a shipped object's; give it "
                              f"a name of its own (name:; by default {Path(self.ycb_folder).name + YCB_SUFFIX})")


def full_name(name: str) -> str:
    """A shipped object's full name ("025_mug" for "mug", as it is built and named in trial ids), else `name` as
    it is (a user mesh's name, or a name not shipped here)."""
    return shipped(name).name if is_shipped_name(name) else name


def shipped(name: str) -> ObjectSource:
    """The source of a shipped object: a recipe ("025_mug" or "mug") or a real scan
    ("003_cracker_box_scan", a mesh in assets/scans/ with its YCB mass)."""
    if scans.is_scan(name):
        scan = scans.get(name)
        return ObjectSource(name=scan.name, mesh=str(scan.path), mass=scan.mass_kg)
    try:
        recipe = recipes.get(name)
    except UnknownNameError:  # the shipped names are the recipes' and the scans' (a misspelled scan's nearest too)
        message = unknown_name_message("object", name, (*recipes.names(), *scans.names()))
        raise UnknownNameError(f"{message}{_user_mesh_hint(name)}") from None
    return ObjectSource(name=recipe.name, recipe=recipe.name, mass=recipe.mass_kg)


def _user_mesh_hint(name: str, cache_root: Path | None = None) -> str:
    """How to refer to a mesh built earlier as `name` (user objects are named by their mesh file), or to a mesh
    file given where a name goes (``plan --object part.obj``)."""
    from manigrasp.objects.meshio import names_a_path

    if names_a_path(name):
        return (f"; {name!r} is a path, not an object name: give a mesh file as one (plan --mesh {name}, "
                f"objects build --mesh {name}, {{mesh: {name}}} in a config)")
    try:
        check_name(name)
        folders = sorted(((Path(cache_root) if cache_root else cache_dir()) / "objects").glob(f"{name}-*"))
    except (ConfigError, OSError):
        return ""
    for folder in folders:
        try:
            meta = json.loads((folder / "meta.json").read_text())
        except (OSError, ValueError):
            continue
        if isinstance(meta, dict) and meta.get("name") == name and "recipe" not in str(meta.get("source", "")):
            mesh = meta.get("source")
            return (f"; {name!r} was built from the mesh {mesh}: a mesh is named by its file, e.g. "
                    f"objects: [{{mesh: {mesh}, name: {name}}}] in a config, or plan --mesh {mesh}")
    return ""


def from_ycb_folder(folder: str | Path, mass: float | None = None, name: str | None = None) -> ObjectSource:
    """The source of one object folder of a real YCB download (e.g. .../025_mug), named `name` or by default
    the folder's name with `YCB_SUFFIX` (``025_mug_ycb``: the folder's own name is the shipped recipe's, whose
    trials, reports and grasp sets it would pass for; the report pairs the two as scan and recipe), with the
    folder name's other characters made ``_`` as a mesh file's stem is (`name_from_path`): a folder ``001 thing``
    is ``001_thing_ycb``, where it was refused as an object name (and a YCB dataset holding it built nothing)."""
    folder = Path(folder)
    ycb_mesh_file(folder)  # fail early with a clear message
    default = (name_from_text(folder.name, NAME_MAX - len(YCB_SUFFIX)) or "object") + YCB_SUFFIX
    return ObjectSource(name=name if name is not None else default, ycb_folder=str(folder), mass=mass)


def recipe_params(name: str) -> DecompositionParams:
    """Decomposition settings of a shipped object: the defaults with its recipe's overrides."""
    return DecompositionParams(**recipes.get(name).decomposition)


def build(source: ObjectSource, params: DecompositionParams | None = None,
          cache_root: Path | None = None) -> BuildResult:
    """Build one object from its source.

    `params` defaults, for a shipped recipe, to `DecompositionParams()` with the recipe's own overrides; for a mesh
    or a YCB folder to `build_object`'s (the defaults, decomposed again finer where they cover the mesh loosely).
    """
    if params is None and source.recipe is not None:
        params = recipe_params(source.recipe)
    common = {"name": source.name, "params": params, "cache_root": cache_root}
    if source.recipe is not None:
        recipe = recipes.get(source.recipe)
        meta = {"source": f"recipe ({recipe.source})", "ycb_id": recipe.ycb_id, "common_name": recipe.common_name}
        result = build_object(recipes.build_mesh(recipe), mass=source.mass or recipe.mass_kg, metadata=meta, **common)
        _mark_built(source, params, result, cache_root)
        return result
    path = source.mesh if source.mesh is not None else ycb_mesh_file(source.ycb_folder or "")
    return build_object(path, scale=source.scale, mass=source.mass, density=source.density,
                        convex_hull_fallback=source.convex_hull_fallback, metadata={"source": str(path)}, **common)


def _fingerprint(source: ObjectSource, params: DecompositionParams) -> str:
    """What a build marker stands for: the recipe, its parameters, CoACD's version and the cache's format (a build of
    another format was decomposed under other keys: it is no build of this one's)."""
    from manigrasp.objects import cache

    recipe = recipes.get(source.recipe or source.name)
    payload = json.dumps({"recipe": repr(recipe), "source": asdict(source), "params": params.as_dict(),
                          "coacd": coacd_version(), "format": cache.CACHE_FORMAT}, sort_keys=True, default=str)
    return hashlib.sha256(payload.encode()).hexdigest()


def _marker(name: str, cache_root: Path | None) -> Path:
    return inside((Path(cache_root) if cache_root else cache_dir()) / "objects", f"{name}.built.json")


def _mark_built(source: ObjectSource, params: DecompositionParams, result: BuildResult,
                cache_root: Path | None) -> None:
    marker = _marker(source.name, cache_root)
    folder = result.asset.mjcf_path.parent.name  # relative to the marker's folder: the cache can move
    text = json.dumps({"fingerprint": _fingerprint(source, params), "folder": folder})
    try:
        if marker.read_text() == text:  # up to date: a built cache is only read (it may be read-only)
            return
    except OSError:
        pass
    tmp = marker.with_suffix(f".{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, marker)


def is_built(name: str, params: DecompositionParams | None = None, cache_root: Path | None = None) -> bool:
    """Whether the shipped object `name` has an up-to-date build in the cache."""
    source = shipped(name)
    marker = _marker(source.name, cache_root)
    try:
        data = json.loads(marker.read_text())
    except (OSError, ValueError):
        return False
    if not isinstance(data, dict) or data.get("fingerprint") != _fingerprint(source, params or recipe_params(
            source.name)):
        return False
    try:
        return entry_is_intact(inside(marker.parent, str(data.get("folder"))))
    except ConfigError:
        return False


@dataclass(frozen=True)
class BuildOutcome:
    """One object of `build_many`: its result, or the error message that stopped it."""

    name: str
    result: BuildResult | None
    error: str | None


def refinement_note(metadata: dict) -> str | None:
    """What a built object's decomposition was redone for (`pipeline.REFINE_ABOVE`), e.g. "the default CoACD
    settings covered 1.72 of its volume with 32 hulls; decomposed again at threshold 0.03, no hull cap"; None if
    it was not."""
    first, kept = metadata.get("refined_from"), metadata.get("decomposition") or {}
    if not first:
        return None
    cap = kept.get("max_convex_hull")
    return (f"the default CoACD settings covered {first['coverage']:.2f} of its volume with {first['n_hulls']} "
            f"hulls; decomposed again at threshold {kept.get('threshold')}, "
            f"{'no hull cap' if cap == -1 else f'at most {cap} hulls'}")


def summary(outcome: BuildOutcome) -> str:
    """One line on a built (or failed) object: hulls, coverage, time, cached, and what repair tools
    warned of (MeshFix's "could not fix everything"), e.g. ``mug: 24 hulls, coverage 1.12, 0.3 s, cached``."""
    if outcome.error or outcome.result is None:
        return f"{outcome.name}: FAILED: {outcome.error}"
    r = outcome.result
    line = (f"{outcome.name}: {r.asset.n_parts} hulls, coverage {r.asset.metadata['coverage']:.2f}, "
            f"{r.seconds:.1f} s, {'cached' if r.cached else 'built'}")
    refined = refinement_note(r.asset.metadata)
    if refined:
        line += f" ({refined})"
    warnings = r.asset.metadata.get("warnings") or []
    return line + (f"; {'; '.join(warnings)}" if warnings else "")


def _build_one(source: ObjectSource, params: DecompositionParams | None, cache_root: Path | None) -> BuildOutcome:
    from manigrasp.errors import ManigraspError

    try:
        return BuildOutcome(source.name, build(source, params, cache_root), None)
    except ManigraspError as exc:
        return BuildOutcome(source.name, None, str(exc))


def build_many(
    sources: Sequence[ObjectSource],
    jobs: int = 1,
    params: DecompositionParams | None = None,
    cache_root: Path | None = None,
    on_done: Callable[[BuildOutcome], None] | None = None,
    on_start: Callable[[ObjectSource], None] | None = None,
) -> list[BuildOutcome]:
    """Build `sources` with `jobs` worker processes; outcomes in input order.

    A failing object does not stop the others: its outcome carries the error.
    `on_done` is called in the parent as each object finishes (progress bars);
    `on_start` as each object not known to be built starts (or is queued, with jobs > 1).
    `params` None means each object's own defaults (see `build`).
    """
    outcomes: dict[str, BuildOutcome] = {}
    for outcome in _iter_builds(sources, jobs, params, cache_root, on_start):
        outcomes[outcome.name] = outcome
        if on_done is not None:
            on_done(outcome)
    return [outcomes[s.name] for s in sources]


def _iter_builds(sources: Sequence[ObjectSource], jobs: int, params: DecompositionParams | None,
                 cache_root: Path | None, on_start: Callable[[ObjectSource], None] | None = None,
                 ) -> Iterator[BuildOutcome]:
    """Shipped objects already in the cache load inline (no pool to start); the rest go to the pool."""
    cached = [s for s in sources if s.recipe is not None and is_built(s.recipe, params, cache_root)]
    rest = [s for s in sources if s not in cached]
    for source in (cached + rest if jobs <= 1 or len(rest) <= 1 else cached):
        if on_start is not None and source not in cached:
            on_start(source)
        yield _build_one(source, params, cache_root)
    if jobs <= 1 or len(rest) <= 1:
        return
    with ProcessPoolExecutor(max_workers=jobs, mp_context=get_context("spawn")) as pool:
        for source in rest if on_start is not None else ():
            on_start(source)
        futures = [pool.submit(_build_one, s, params, cache_root) for s in rest]
        for future in as_completed(futures):
            yield future.result()
