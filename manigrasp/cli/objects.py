"""`manigrasp objects list|show|build`: the object set and the build pipeline."""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from manigrasp.cli import check_jobs
from manigrasp.cli.output import format_table, print_json
from manigrasp.errors import ConfigError
from manigrasp.objects import catalog, recipes, scans
from manigrasp.objects.catalog import BuildOutcome, ObjectSource
from manigrasp.objects.pipeline import DEFAULT_DENSITY


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `objects` and its sub-commands."""
    parser = subparsers.add_parser("objects", help="list, inspect and build objects",
                                   description="The shipped YCB-like object set and your own meshes.")
    sub = parser.add_subparsers(dest="objects_command", metavar="SUBCOMMAND", required=True)

    p = sub.add_parser("list", help="the shipped objects (the recipes, then the real scans `<stem>_scan`): YCB id, "
                                    "extents, mass, volume (- for a scan not watertight as shipped), built or not "
                                    "(- for a scan: not tracked)")
    p.add_argument("--json", action="store_true", help="print a JSON list instead of a table")
    p.set_defaults(func=_list)

    p = sub.add_parser("show", help="one object's metadata (builds it first if needed)")
    p.add_argument("name", help="shipped object name, e.g. 025_mug, mug or 003_cracker_box_scan")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=_show)

    p = sub.add_parser(
        "build", help="validate, repair, decompose (CoACD, cached) and write MJCF",
        description="Build shipped objects by name (or --all), a mesh file (--mesh), or a YCB download (--ycb).")
    p.add_argument("names", nargs="*", metavar="NAME", help="shipped object names")
    p.add_argument("--all", action="store_true", help="build every shipped object")
    p.add_argument("--mesh", help="a mesh file (OBJ, STL, PLY, OFF, GLB/GLTF) to build")
    p.add_argument("--name", help="name of the --mesh object (or of one --ycb object folder): letters, digits, "
                   "_-. (at most 64), not a shipped object's (default: the file stem, + _mesh if shipped); later "
                   "runs name the mesh by its file")
    p.add_argument("--scale", type=float, help="scale the --mesh vertices (0.001: mm to m; default 1)")
    p.add_argument("--mass", type=float, help="mass of the --mesh object (or of one --ycb object folder) [kg] "
                   "(default: from --density)")
    p.add_argument("--density", type=float, help=f"density of the --mesh object [kg/m^3] when no mass is given "
                   f"(default {DEFAULT_DENSITY:g})")
    p.add_argument("--convex-hull", action="store_true",
                   help="accept the convex hull of a mesh whose holes cannot be closed")
    p.add_argument("--ycb", metavar="FOLDER",
                   help="a real YCB download (folder of 025_mug/google_16k/textured.obj ...) or one object folder")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    p.set_defaults(func=_build)


def _list(args: argparse.Namespace) -> int:
    rows = []
    for name in recipes.names():
        recipe = recipes.get(name)
        rows.append({
            "name": recipe.name, "ycb_id": recipe.ycb_id, "common_name": recipe.common_name,
            "extents_m": list(recipe.extents_m), "mass_kg": recipe.mass_kg,
            "volume_m3": float(recipes.build_mesh(recipe).volume), "built": catalog.is_built(name),
        })
    rows += [_scan_row(name) for name in scans.names()]
    if args.json:
        print_json(rows)
        return 0
    headers = ["name", "ycb_id", "extents [mm]", "mass [kg]", "volume [cm^3]", "built"]
    table = [[r["name"], r["ycb_id"], " x ".join(f"{1000 * e:.0f}" for e in r["extents_m"]),
              f"{r['mass_kg']:.3f}", "-" if r["volume_m3"] is None else f"{1e6 * r['volume_m3']:.0f}",
              "-" if r["built"] is None else "yes" if r["built"] else "no"] for r in rows]
    print(format_table(headers, table))
    return 0


def _scan_row(name: str) -> dict[str, Any]:
    """A shipped real scan as a row of `objects list`: its twin's YCB id and common name, the extents of its mesh
    as shipped, the YCB table's mass, and its volume where the mesh is watertight as shipped (None otherwise: a
    mesh with holes has no volume until it is repaired; `objects show` gives the built one). Whether it is built
    is None (unknown): the cache marks recipe builds only (`catalog.is_built` is False for every scan)."""
    import trimesh

    scan = scans.get(name)
    twin = recipes.get(scan.twin)
    mesh = trimesh.load(scan.path, force="mesh")
    return {"name": name, "ycb_id": twin.ycb_id, "common_name": f"{twin.common_name} (scan)",
            "extents_m": [float(e) for e in mesh.extents], "mass_kg": scan.mass_kg,
            "volume_m3": float(mesh.volume) if scan.watertight else None, "built": None}


def _show(args: argparse.Namespace) -> int:
    source = catalog.shipped(args.name)
    asset = catalog.build(source).asset
    if scans.is_scan(source.name):  # a real scan: described by its recipe twin and the scans' README
        scan = scans.get(source.name)
        twin = recipes.get(scan.twin)
        ycb_id, common_name = twin.ycb_id, f"{twin.common_name} (scan)"
        origin = f"YCB scan {scan.path.name} (assets/scans/README.md: source, licence, masses)"
        notes = (f"real scan of {scan.twin} (its recipe twin); watertight as shipped: "
                 f"{'yes' if scan.watertight else 'no'}")
    else:
        recipe = recipes.get(source.name)
        ycb_id, common_name, origin, notes = recipe.ycb_id, recipe.common_name, recipe.source, recipe.notes
    info = {
        "name": asset.name, "ycb_id": ycb_id, "common_name": common_name,
        "extents_m": rounded(asset.extents), "mass_kg": rounded(asset.mass), "volume_m3": rounded(asset.volume),
        "inertia_kg_m2": rounded(asset.inertia, noise=1e-9 * float(np.max(np.abs(asset.inertia)))),
        "n_hulls": asset.n_parts, "mjcf": str(asset.mjcf_path),
        "visual_mesh": str(asset.visual_path), "source": origin, "notes": notes,
        "metadata": asset.metadata,
    }
    if args.json:
        print_json(info)
        return 0
    for key, value in info.items():
        if key == "inertia_kg_m2":
            print(f"{key:14s} " + "\n".ljust(16).join(" ".join(f"{v:>12.6g}" for v in row) for row in value))
        elif key != "metadata":
            print(f"{key:14s} {' '.join(f'{v:g}' for v in value) if isinstance(value, list) else value}")
    print(f"{'repairs':14s} {asset.metadata.get('repairs') or 'none'}")
    print(f"{'coverage':14s} {asset.metadata.get('coverage'):.3f} (hull union volume / mesh volume)")
    refined = catalog.refinement_note(asset.metadata)
    if refined:
        print(f"{'':14s} {refined}")
    return 0


def rounded(value: Any, digits: int = 6, noise: float = 0.0) -> Any:
    """`value` (a number or array) as plain floats or nested lists of `digits` significant digits;
    entries no larger than `noise` in magnitude (round-off, e.g. 1e-21 off-diagonal inertia) are 0."""
    array = np.asarray(value, dtype=float)
    cleaned = np.where(np.abs(array) <= noise, 0.0, array)
    out = np.vectorize(lambda v: float(f"{v:.{digits}g}") + 0.0, otypes=[float])(cleaned)  # + 0.0: no -0.0
    return out.tolist() if array.ndim else float(out)


def _sources(args: argparse.Namespace) -> list[ObjectSource]:
    """The objects to build. The per-object options (--name, --scale, --mass, --density, --convex-hull) are the
    --mesh file's; without --mesh, --name and --mass are one --ycb object folder's; given where nothing takes
    them, they are refused (they were ignored: `--ycb FOLDER --mass 0.2` built the default mass)."""
    from pathlib import Path

    sources = [catalog.shipped(n) for n in (recipes.names() if args.all else args.names)]
    given = [flag for flag, value in (("--name", args.name), ("--scale", args.scale), ("--mass", args.mass),
                                      ("--density", args.density), ("--convex-hull", args.convex_hull or None))
             if value is not None]
    if args.mesh:
        mesh = Path(args.mesh).resolve()
        sources.append(ObjectSource(name=args.name if args.name is not None else catalog.default_mesh_name(mesh),
                                    mesh=str(mesh), scale=1.0 if args.scale is None else args.scale,
                                    mass=args.mass, density=DEFAULT_DENSITY if args.density is None else args.density,
                                    convex_hull_fallback=args.convex_hull))
        given = []
    folders: list[Path] = []
    if args.ycb:
        from manigrasp.objects.meshio import ycb_dataset

        folder = Path(args.ycb)
        folders = [folder] if (folder / "google_16k").is_dir() or (folder / "poisson").is_dir() or (
            folder / "tsdf").is_dir() else [folder / n for n in ycb_dataset(folder)]
    own = len(folders) == 1 and not args.mesh  # one YCB object: --name and --mass are its own
    unused = [flag for flag in given if not (own and flag in ("--name", "--mass"))]
    if unused:
        raise ConfigError(f"{', '.join(unused)}: not used here: --name, --scale, --mass, --density and --convex-hull "
                          "are the options of a --mesh file (--name and --mass also of one --ycb object folder), not "
                          "of a shipped object or a YCB dataset of several folders")
    if own:
        sources.append(catalog.from_ycb_folder(folders[0], mass=args.mass, name=args.name))
    else:
        sources.extend(catalog.from_ycb_folder(f) for f in folders)
    if not sources:
        raise ConfigError("nothing to build: name objects, or use --all, --mesh FILE or --ycb FOLDER")
    return sources


def _build(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    sources = _sources(args)
    bar = tqdm(total=len(sources), desc="building", unit="obj", file=sys.stderr, disable=None)

    def done(outcome: BuildOutcome) -> None:
        bar.update(1)
        if outcome.error:
            bar.write(f"{outcome.name}: FAILED: {outcome.error}", file=sys.stderr)
        else:
            bar.write(catalog.summary(outcome))

    check_jobs(args.jobs)
    outcomes = catalog.build_many(sources, jobs=args.jobs, on_done=done)
    bar.close()
    failed = [o for o in outcomes if o.error]
    print(f"{len(outcomes) - len(failed)} built, {len(failed)} failed")
    return 1 if failed else 0
