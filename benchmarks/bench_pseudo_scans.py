"""Pseudo-scan transfer study: does the recipe-vs-scan verdict hold beyond the five shipped scans?

For each shipped recipe object (default: all 20) a scan-like mesh is made from the recipe's surface
(`manigrasp.objects.pseudoscan`: a dense point cloud with Gaussian noise along the normal, blurred like a
scanner, the underside seen sparsely, screened Poisson reconstruction with density cropping, decimated to the
16384 faces of a YCB scan): millimetre bumps, rounded edges, holes on the underside, not watertight. It keeps
the recipe's frame and mass and is written to OUT/meshes/<recipe>_pscan.obj (with the generator's settings in
OUT/meshes/params.json; a change of settings regenerates them). Then, for each pad mode and seed, one run of
the recipes and their pseudo-scans (user mesh objects `{mesh: FILE, name: <recipe>_pscan, mass: <recipe's>}`,
repaired and decomposed by manigrasp's own pipeline with the default CoACD settings, as a user's scan would be)
goes into OUT/<mode>/s<seed>/ under the `standard` protocol, ground-truth observation, `parallel_jaw` x
`antipodal` by default, 20 grasps per object. The table prints, per object and pad mode, the recipe's and the
pseudo-scan's successes (pooled over the seeds), the gap in points (recipe - pseudo-scan), the two-sided
Fisher exact p of the difference, and the failure modes of each; a gap over 10 points is flagged `GAP`
(`GAP*` when p < 0.05 too: beyond binomial noise). Before the runs, each pseudo-scan's build is summarised
(repairs, hulls, coverage) next to its recipe's.

    .venv/bin/python benchmarks/bench_pseudo_scans.py --out /tmp/pscan --jobs 2                 # seed 0, compliant
    .venv/bin/python benchmarks/bench_pseudo_scans.py --out /tmp/pscan --seeds 0 1 2 --objects 025_mug 024_bowl
    .venv/bin/python benchmarks/bench_pseudo_scans.py --out /tmp/pscan --modes compliant rigid --objects 024_bowl
    .venv/bin/python benchmarks/bench_pseudo_scans.py --out /tmp/pscan2 --noise-mm 1.0 --scan-seed 1  # other scans
    .venv/bin/python benchmarks/bench_pseudo_scans.py --out /tmp/pscan_np --planner-params '{"pad_footprint": false}'

`--graspable` keeps only the objects the 8 cm parallel jaw can grasp from their resting pose (it leaves out
the master chef can, tuna can, wood block and pudding box, whose recipes give `no_grasp`). Deterministic for
given seeds and settings on one machine. Runs resume: a re-run prints the stored results. Nothing is
downloaded. Needs Open3D (the `perception` extra).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import yaml  # noqa: E402
from scipy.stats import fisher_exact  # noqa: E402

from manigrasp.bench.config import load_config  # noqa: E402
from manigrasp.bench.report import load_results, summarize  # noqa: E402
from manigrasp.bench.runner import run_benchmark  # noqa: E402
from manigrasp.objects import recipes  # noqa: E402
from manigrasp.objects.catalog import ObjectSource, build_many, shipped  # noqa: E402
from manigrasp.objects.pseudoscan import PseudoScanParams, bumpiness, pseudo_scan  # noqa: E402

SUFFIX = "_pscan"
GAP_POINTS = 10.0
NO_JAW_GRASP = ("002_master_chef_can", "007_tuna_fish_can", "008_pudding_box", "036_wood_block")
"""Recipes the 8 cm parallel jaw cannot grasp from their resting pose (README, Planners)."""


def make_meshes(objects: list[str], folder: Path, params: PseudoScanParams) -> dict[str, Path]:
    """The pseudo-scan of each recipe in `objects`, written to folder/<recipe>_pscan.obj (reused when
    folder/params.json holds the same settings)."""
    import trimesh

    folder.mkdir(parents=True, exist_ok=True)
    stamp = folder / "params.json"
    same = stamp.is_file() and json.loads(stamp.read_text()) == params.as_dict()
    if not same:
        stamp.unlink(missing_ok=True)
    paths = {}
    for name in objects:
        path = folder / f"{name}{SUFFIX}.obj"
        if not (same and path.is_file()):
            source = recipes.build_mesh(name)
            scan = pseudo_scan(source, params)
            scan.export(path)
            edges = len(trimesh.grouping.group_rows(scan.edges_sorted, require_count=1))
            print(f"  {path.name}: {len(scan.vertices)} vertices, {len(scan.faces)} faces, "
                  f"{'watertight' if scan.is_watertight else f'{edges} open edges'}, "
                  f"bumps {bumpiness(scan) * 1e3:.2f} mm, extents {' x '.join(f'{e * 1e3:.1f}' for e in scan.extents)}"
                  f" mm (recipe {' x '.join(f'{e * 1e3:.1f}' for e in source.extents)})", flush=True)
        paths[name] = path
    stamp.write_text(json.dumps(params.as_dict(), indent=1))
    return paths


def write_config(out: Path, objects: list[str], meshes: dict[str, Path], args: argparse.Namespace) -> Path:
    """The run's config: each recipe and its pseudo-scan (a user mesh with the recipe's mass)."""
    entries: list = []
    for name in objects:
        entries += [name, {"mesh": os.path.relpath(meshes[name], out), "name": name + SUFFIX,
                           "mass": recipes.get(name).mass_kg}]
    params = json.loads(args.planner_params) if args.planner_params else {}
    planners = [{"name": p, "params": params} if params else p for p in args.planners]
    config = {"name": "pseudo_scans", "seed": 0, "objects": entries, "hands": args.hands, "planners": planners,
              "grasps_per_object": args.grasps, "protocol": args.protocol, "observation": "ground_truth",
              "scene": {"pads": "compliant", "rest": "file"}}
    path = out / "pseudo_scans.yaml"
    text = "# written by benchmarks/bench_pseudo_scans.py\n" + yaml.safe_dump(config, sort_keys=False)
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)
    return path


def build_summary(objects: list[str], meshes: dict[str, Path], jobs: int) -> list[str]:
    """Build (or load from the cache) every object, then one line per recipe: hulls and coverage of the recipe
    and of its pseudo-scan, and the pseudo-scan's repairs. Returns the recipes whose pair built (a pseudo-scan
    the pipeline refuses is reported and left out of the runs)."""
    sources = []
    for name in objects:
        sources += [shipped(name), ObjectSource(name=name + SUFFIX, mesh=str(meshes[name]),
                                                mass=recipes.get(name).mass_kg)]
    outcomes = {o.name: o for o in build_many(sources, jobs=jobs)}
    print("\n## builds (hulls, coverage = hull union / mesh volume; pseudo-scan repairs)")
    built = []
    for name in objects:
        rec, ps = outcomes[name], outcomes[name + SUFFIX]
        if rec.result is None or ps.result is None:
            print(f"{name:20s} NOT BUILT, left out of the runs: {rec.error or ''} {ps.error or ''}")
            continue
        built.append(name)
        rm, pm = rec.result.asset.metadata, ps.result.asset.metadata
        repairs = "; ".join(str(r) for r in pm.get("repairs", [])) or "none"
        print(f"{name:20s} recipe {rm['n_hulls']:3d} hulls cov {rm['coverage']:.3f} vol "
              f"{rec.result.asset.volume * 1e6:7.1f}"
              f" cm3 | pseudo-scan {pm['n_hulls']:3d} hulls cov {pm['coverage']:.3f} vol "
              f"{ps.result.asset.volume * 1e6:7.1f} cm3 | repairs: {repairs}")
    return built


def run(config_path: Path, out: Path, mode: str, seeds: list[int], jobs: int) -> dict:
    """Runs of every seed under one pad mode, pooled: group -> Rate."""
    results = []
    for seed in seeds:
        folder = out / mode / f"s{seed}"
        config = load_config(config_path, [f"seed={seed}", f"scene.pads={mode}"])
        run_benchmark(config, folder, jobs=jobs, base=config_path.parent, progress=False)
        results.extend(load_results(folder))
    return summarize(results).groups


def _is(label: str, planner: str) -> bool:
    """Whether a group's planner label names `planner` (a planner with params may be labelled name[key=value])."""
    return label == planner or label.startswith(planner + "[")


def modes_text(rate) -> str:
    return ",".join(f"{k}:{v}" for k, v in sorted(rate.failure_modes.items(), key=lambda kv: -kv[1])) or "-"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True,
                        help="output folder (meshes/, config, one run per mode x seed)")
    parser.add_argument("--objects", nargs="+", default=None, help="recipes (default: all 20 shipped)")
    parser.add_argument("--graspable", action="store_true",
                        help=f"leave out the recipes the parallel jaw cannot grasp ({', '.join(NO_JAW_GRASP)})")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0], help="benchmark root seeds, pooled (default 0)")
    parser.add_argument("--modes", nargs="+", default=["compliant"],
                        help="pad models: compliant, rigid (default compliant)")
    parser.add_argument("--hands", nargs="+", default=["parallel_jaw"])
    parser.add_argument("--planners", nargs="+", default=["antipodal"])
    parser.add_argument("--planner-params", default=None,
                        help='JSON parameters of every planner, e.g. \'{"pad_footprint": false}\' (default: none)')
    parser.add_argument("--protocol", default="standard")
    parser.add_argument("--grasps", type=int, default=20, help="grasps per object and seed (default 20)")
    parser.add_argument("--jobs", type=int, default=1)
    defaults = PseudoScanParams()
    parser.add_argument("--scan-seed", type=int, default=defaults.seed, help="seed of the pseudo-scans (default 0)")
    parser.add_argument("--noise-mm", type=float, default=defaults.noise_m * 1e3,
                        help=f"sd of the noise along the normal [mm] (default {defaults.noise_m * 1e3:g})")
    parser.add_argument("--blur-mm", type=float, default=defaults.blur_m * 1e3,
                        help=f"scanner blur radius [mm], rounds edges (default {defaults.blur_m * 1e3:g})")
    parser.add_argument("--underside-drop", type=float, default=defaults.underside_drop,
                        help=f"fraction of the underside's points not seen (default {defaults.underside_drop:g})")
    parser.add_argument("--points", type=int, default=defaults.n_points, help="points sampled per object")
    args = parser.parse_args()

    objects = [recipes.get(o).name for o in args.objects] if args.objects else list(recipes.names())
    if args.graspable:
        objects = [o for o in objects if o not in NO_JAW_GRASP]
    params = PseudoScanParams(noise_m=args.noise_mm * 1e-3, blur_m=args.blur_mm * 1e-3,
                              underside_drop=args.underside_drop, n_points=args.points, seed=args.scan_seed)
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"# pseudo-scans of {len(objects)} recipes: {params.as_dict()}")
    print(f"# {' '.join(args.hands)} x {' '.join(args.planners)} under {args.protocol}, {args.grasps} grasps, "
          f"seeds {args.seeds}, pads {args.modes}; {args.jobs} job(s); {os.cpu_count()} cores, "
          f"{platform.processor() or platform.machine()}", flush=True)
    meshes = make_meshes(objects, args.out / "meshes", params)
    objects = build_summary(objects, meshes, args.jobs)
    config_path = write_config(args.out, objects, meshes, args)
    groups = {mode: run(config_path, args.out, mode, args.seeds, args.jobs) for mode in args.modes}

    print(f"\n## recipe vs pseudo-scan (successes/trials pooled over seeds {args.seeds}; gap = recipe - pseudo-scan "
          f"in points; p: two-sided Fisher exact; GAP: |gap| > {GAP_POINTS:g}, GAP*: and p < 0.05)")
    flagged = []
    for mode in args.modes:
        rows = groups[mode]
        for hand in args.hands:
            for planner in args.planners:
                print(f"\n### {hand} x {planner}, pads {mode}")
                print(f"{'object':20s} {'recipe':>8s} {'pscan':>8s} {'gap':>5s} {'p':>6s} {'flag':4s}  "
                      f"failure modes recipe | pseudo-scan")
                for name in objects:
                    rk = next((k for k in rows if k[0] == hand and _is(k[1], planner) and k[-1] == name), None)
                    pk = next((k for k in rows if k[0] == hand and _is(k[1], planner) and k[-1] == name + SUFFIX),
                              None)
                    if rk is None or pk is None:
                        continue
                    r, s = rows[rk], rows[pk]
                    gap = 100.0 * (r.successes / r.trials - s.successes / s.trials)
                    p = fisher_exact([[r.successes, r.trials - r.successes], [s.successes, s.trials - s.successes]])[1]
                    flag = ("GAP*" if p < 0.05 else "GAP") if abs(gap) > GAP_POINTS else ""
                    if flag:
                        flagged.append(f"{name} ({mode}, {gap:+.0f}, p={p:.3f})")
                    print(f"{name:20s} {r.successes:>3d}/{r.trials:<4d} {s.successes:>3d}/{s.trials:<4d} {gap:+5.0f} "
                          f"{p:6.3f} {flag:4s}  {modes_text(r)} | {modes_text(s)}")
                tr = sum(rows[k].successes for k in rows if k[0] == hand and _is(k[1], planner) and k[-1] in objects)
                ts = sum(rows[k].successes for k in rows if k[0] == hand and _is(k[1], planner)
                         and k[-1].removesuffix(SUFFIX) in objects and k[-1].endswith(SUFFIX))
                print(f"{'total':20s} {tr:>8d} {ts:>8d}")
    print("\nflagged: " + ("; ".join(flagged) if flagged else "none"))


if __name__ == "__main__":
    main()
