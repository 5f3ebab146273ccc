"""`manigrasp evaluate`: run the grasps of a file (native JSON / NPZ, or ACRONYM's HDF5) on their object."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from manigrasp.cli import run_dir_path

FORMATS_HELP = """\
grasp files:
  native (.json, .npz): per grasp the TCP pose in the object's frame (origin at the centre of mass),
    as "pose" (4x4) or "position" + "quaternion" (w, x, y, z) [m]; optional "width" (jaw opening [m]; absent or
    null: not given; NaN or Infinity: invalid_grasp),
    "preshape" (synergy in [0, 1]), "joints" (dexterous hands: the grasp's own hand path
    [[pre-shape...], [squeeze target...]], actuator commands in the hand's actuator order, e.g. joint
    angles [rad]), "score" (higher first); the file may name "hand", "hand_kind" and "object"
    {name | mesh, scale, mass, built}. TCP: z = approach (hand toward object), y = closing. A quaternion must
    be unit within 1e-5 (else the file is refused, naming the grasp). NPZ: arrays poses (n,4,4) or
    positions + quaternions, widths (NaN: not given; +-inf: invalid_grasp), preshapes, scores, joints
    (n,2,n_act; all-NaN: the hand's own path). Full layout: manigrasp/graspsets/native.py.
  ACRONYM (.h5, .hdf5): grasps/transforms (n,4,4) Panda gripper poses in the frame of object/file
    scaled by object/scale (a relative object/file is looked for beside the .h5 file, then in its
    parent and grandparent folders: ACRONYM's meshes/ beside grasps/). manigrasp's TCP =
    transform @ [Rz(-90 deg), 0.1034 m along z] for every parallel jaw (manigrasp/graspsets/acronym.py).
    Its object is named by object/file's stem (a file `manigrasp label` wrote: object/manigrasp/name;
    its hand: gripper/manigrasp/hand).
    Needs h5py (`make setup EXTRAS=dev,datasets`).
  Grasps are placed on the object's settled pose and run best score first: every trial's detail begins
  "file grasp i" (i: the grasp's index in the file, from 0). One that cannot be placed (another hand, NaN, not a
  rotation, a width the hand cannot open to) is recorded as invalid_grasp, never dropped. A file with
  missing keys, wrong shapes or types, NaN scores, an unknown hand_kind or version, or a grasp with both
  "pose" and "position" is refused with a one-line error, and so is a file (of either format) whose grasps
  are of another object than --object (--any-object runs them anyway)."""


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `evaluate`."""
    p = subparsers.add_parser(
        "evaluate", help="run every grasp of a grasp file (JSON, NPZ or ACRONYM HDF5) in simulation",
        description="Place every grasp of GRASPS on the object's settled pose and run it under the protocol; "
                    "results go to RUN_DIR like `manigrasp bench` (resumable, `manigrasp report RUN_DIR`). In a "
                    "config the same is planners: [{name: file, params: {path: GRASPS}}].",
        epilog=FORMATS_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("grasps", type=Path, metavar="GRASPS", help="the grasp file")
    p.add_argument("--out", required=True, type=run_dir_path, metavar="RUN_DIR", help="run directory")
    p.add_argument("--object", help="a shipped object name or a mesh file (default: the object the file names)")
    p.add_argument("--name", help="name of a mesh --object (default: the object name the file gives, else the "
                                  "mesh file's stem); one of its own when the file names a shipped object")
    p.add_argument("--any-object", action="store_true",
                   help="run the grasps on --object even if the file names another object (default: refused, "
                        "as their poses are in that object's frame)")
    p.add_argument("--scale", type=float, help="scale of a mesh --object (default: the file's, else 1); refused "
                                               "for a shipped object, which has its real size")
    p.add_argument("--mass", type=float, help="object mass [kg] (default: the file's, else from density)")
    p.add_argument("--hand", help="hand name (default: the file's hand, else parallel_jaw)")
    p.add_argument("--protocol", help="trial protocol (default: the one the file's labels were measured under, "
                                      "with its parameters, as `manigrasp label` records it; else standard). The "
                                      "scene the file records (rigid pads, say) is used either way")
    p.add_argument("--transfer", action="store_true",
                   help="run grasps made for another hand of the same kind (default: invalid_grasp)")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_evaluate)


def _evaluate(args: argparse.Namespace) -> int:
    from manigrasp.bench import runner
    from manigrasp.bench.config import MAX_GRASPS_PER_OBJECT, parse_config
    from manigrasp.cli import check_jobs, report
    from manigrasp.errors import ConfigError
    from manigrasp.graspsets import read

    check_jobs(args.jobs)
    grasps = read(args.grasps)
    # Every grasp of the file is one trial (grasps_per_object = the file's count): an empty file has nothing
    # to run (not one made-up trial), and the config's bound on trials per object is the file's grasp count.
    if len(grasps) == 0:
        raise ConfigError(f"{args.grasps} holds no grasps: nothing to evaluate")
    if len(grasps) > MAX_GRASPS_PER_OBJECT:
        raise ConfigError(f"{args.grasps} holds {len(grasps)} grasps; evaluate runs at most {MAX_GRASPS_PER_OBJECT} "
                          "(one trial each): split the file")
    entry = _object_entry(args, grasps)
    params = {"path": str(args.grasps.resolve()), "transfer": args.transfer}
    if _other_object(args, grasps, entry):
        params["check_object"] = False  # checked here (left out otherwise: the run's identity stays as it was)
    under = grasps.labelled_under or {}
    protocol = args.protocol or under.get("protocol") or "standard"
    data = {
        "name": f"evaluate {args.grasps.name}",
        "objects": [entry],
        "hands": [args.hand or grasps.hand or "parallel_jaw"],
        "planners": [{"name": "file", "params": params}],
        "grasps_per_object": len(grasps),
        "protocol": protocol,
    }
    if under.get("scene"):
        data["scene"] = under["scene"]
    if under:
        shown = protocol if isinstance(protocol, str) else _entry_text(protocol)
        from manigrasp.bench.config import scene_overrides

        scene = ", ".join(f"{k}={v}" for k, v in sorted(scene_overrides(under.get("scene", {})).items())) \
            or "today's defaults"
        print(f"evaluate: protocol {shown}{' (--protocol)' if args.protocol else ', as the file was labelled'}; "
              f"scene {scene}, as the file was labelled", file=sys.stderr)
    config = parse_config(data, where=f"evaluate ({args.grasps.name}: labelled_under)" if under else "evaluate")
    summary = runner.run_benchmark(config, args.out, jobs=args.jobs, progress=not args.quiet)
    print(f"{summary.ran} grasps run, {summary.already_done} already stored ({summary.seconds:.0f} s)",
          file=sys.stderr)
    return report.print_report(args.out, as_json=False)


def _entry_text(entry: dict) -> str:
    """"lift" or "standard(grip_force=10.0)": a protocol entry of a file's `labelled_under`."""
    params = entry.get("params") or {}
    return entry["name"] + (f"({', '.join(f'{k}={v}' for k, v in sorted(params.items()))})" if params else "")


def _object_entry(args: argparse.Namespace, grasps) -> dict:
    """The config's object: --object (a mesh file or a shipped name), else the one the file names. A mesh is
    named --name, else as the file names its object, else by its file's stem. A `manigrasp label` ACRONYM file
    of a shipped object (`ObjectRef.built`) names that object: it is built by its name."""
    from manigrasp.errors import ConfigError
    from manigrasp.objects import catalog, scans
    from manigrasp.objects.meshio import names_a_path

    ref = grasps.object
    entry: dict = {}
    if args.object:
        given = Path(args.object)
        if not given.is_file() and (names_a_path(args.object) or given.exists()):
            what = "a folder, not a mesh file" if given.is_dir() else "no such mesh file"
            raise ConfigError(f"--object {args.object}: {what} (--object is a shipped object's name or a mesh file)")
        entry = {"mesh": str(given.resolve()), "name": args.name or ref.name or given.stem} if given.is_file() \
            else {"name": args.object}
    elif ref.mesh and ref.built and ref.name and catalog.is_shipped_name(ref.name):
        entry = {"name": ref.name}  # `label`'s ACRONYM file of a shipped object: its mesh is that object's build
    elif ref.mesh:
        from manigrasp.graspsets import mesh_path

        mesh = mesh_path(grasps)
        entry = {"mesh": str(mesh.resolve()), "name": args.name or ref.name or mesh.stem}
    elif ref.name:
        entry = {"name": ref.name}
    else:
        raise ConfigError(f"{args.grasps} names no object: give --object NAME or --object MESH")
    if args.name and "mesh" not in entry:
        raise ConfigError(f"--name is the name of a mesh --object; {entry['name']!r} is a shipped object")
    if "mesh" in entry and not args.name and catalog.is_shipped_name(entry["name"]) \
            and not scans.is_scan(entry["name"]):  # a scan's own mesh is its; another is refused by the catalog
        raise ConfigError(f"{args.grasps} names the shipped object {entry['name']!r}, not the mesh {entry['mesh']}: "
                          "give the mesh a name of its own with --name (and --any-object to run the file's grasps "
                          "on it)")
    if args.scale is not None and "mesh" not in entry:  # as the config refuses `scale` of a shipped object
        raise ConfigError(f"--scale applies to a mesh --object; {entry['name']!r} is a shipped object, which has its "
                          "real size (--mass changes its mass)")
    scale = args.scale if args.scale is not None else ref.scale
    if "mesh" in entry and scale != 1.0:
        entry["scale"] = scale  # the config refuses a scale <= 0
    mass = args.mass if args.mass is not None else ref.mass
    if mass is not None:
        entry["mass"] = mass  # the config refuses a mass <= 0 or below 1 mg
    return entry


def _other_object(args: argparse.Namespace, grasps, entry: dict) -> bool:
    """Whether the file names its object otherwise than the object `entry` is built as, so that the file
    planner's check (by name) must be left off: another name of the same shipped object ("mug" for
    "025_mug"), or another object with --any-object (refused without it: the grasps' poses are in the frame
    of the object the file names; of an ACRONYM file, in the frame of its mesh, placed by the centre of mass of
    the object built). A mesh-frame set whose mesh file is the mesh --object is that object's, whatever it is
    named (an ACRONYM file names its object by its mesh file's stem)."""
    from manigrasp.errors import ConfigError
    from manigrasp.objects import catalog
    from manigrasp.planners.file import mesh_file_is

    named = grasps.object.name
    built = entry["name"] if "mesh" in entry else catalog.full_name(entry["name"])
    if not named or named == built:
        return False
    own_mesh = "mesh" in entry and mesh_file_is(grasps, [entry["mesh"]])
    if not args.any_object and catalog.full_name(named) != built and not own_mesh:
        raise ConfigError(f"{args.grasps} holds grasps of object {named!r}, not {entry['name']!r}: their poses are "
                          f"in the frame of {named!r} (--any-object runs them on {entry['name']!r} anyway)")
    return True
