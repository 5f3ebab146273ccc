"""`manigrasp evaluate`: run the grasps of a file (native JSON / NPZ, or ACRONYM's HDF5) on their object."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

FORMATS_HELP = """\
grasp files:
  native (.json, .npz): per grasp the TCP pose in the object's frame (origin at the centre of mass),
    as "pose" (4x4) or "position" + "quaternion" (w, x, y, z) [m]; optional "width" (jaw opening [m]),
    "preshape" (synergy in [0, 1]), "joints" (dexterous hands: the grasp's own hand path
    [[pre-shape...], [squeeze target...]], actuator commands in the hand's actuator order, e.g. joint
    angles [rad]), "score" (higher first); the file may name "hand", "hand_kind" and "object"
    {name | mesh, scale, mass}. TCP: z = approach (hand toward object), y = closing. A quaternion must
    be unit within 1e-5 (else the file is refused, naming the grasp). NPZ: arrays poses (n,4,4) or
    positions + quaternions, widths, preshapes, scores, joints (n,2,n_act; all-NaN: the hand's own
    path). Full layout: manigrasp/graspsets/native.py.
  ACRONYM (.h5, .hdf5): grasps/transforms (n,4,4) Panda gripper poses in the frame of object/file
    scaled by object/scale (a relative object/file is looked for beside the .h5 file, then in its
    parent and grandparent folders: ACRONYM's meshes/ beside grasps/). manigrasp's TCP =
    transform @ [Rz(-90 deg), 0.1034 m along z] for every parallel jaw (manigrasp/graspsets/acronym.py).
    Needs h5py (`make setup EXTRAS=dev,datasets`).
  Grasps are placed on the object's settled pose. One that cannot be placed (another hand, NaN, not a
  rotation, a width the hand cannot open to) is recorded as invalid_grasp, never dropped. A file with
  missing keys, wrong shapes or NaN scores is refused with a one-line error."""


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `evaluate`."""
    p = subparsers.add_parser(
        "evaluate", help="run every grasp of a grasp file (JSON, NPZ or ACRONYM HDF5) in simulation",
        description="Place every grasp of GRASPS on the object's settled pose and run it under the protocol; "
                    "results go to RUN_DIR like `manigrasp bench` (resumable, `manigrasp report RUN_DIR`). In a "
                    "config the same is planners: [{name: file, params: {path: GRASPS}}].",
        epilog=FORMATS_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("grasps", type=Path, metavar="GRASPS", help="the grasp file")
    p.add_argument("--out", required=True, type=Path, metavar="RUN_DIR", help="run directory")
    p.add_argument("--object", help="a shipped object name or a mesh file (default: the object the file names)")
    p.add_argument("--scale", type=float, help="scale of a mesh --object (default: the file's, else 1)")
    p.add_argument("--mass", type=float, help="object mass [kg] (default: the file's, else from density)")
    p.add_argument("--hand", help="hand name (default: the file's hand, else parallel_jaw)")
    p.add_argument("--protocol", default="standard", help="trial protocol (default standard)")
    p.add_argument("--transfer", action="store_true",
                   help="run grasps made for another hand of the same kind (default: invalid_grasp)")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_evaluate)


def _evaluate(args: argparse.Namespace) -> int:
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.runner import run_benchmark
    from manigrasp.cli.report import print_report
    from manigrasp.graspsets import read

    grasps = read(args.grasps)
    config = parse_config({
        "name": f"evaluate {args.grasps.name}",
        "objects": [_object_entry(args, grasps)],
        "hands": [args.hand or grasps.hand or "parallel_jaw"],
        "planners": [{"name": "file", "params": {"path": str(args.grasps.resolve()), "transfer": args.transfer}}],
        "grasps_per_object": max(1, len(grasps)),
        "protocol": args.protocol,
    }, where="evaluate")
    summary = run_benchmark(config, args.out, jobs=max(1, args.jobs), progress=not args.quiet)
    print(f"{summary.ran} grasps run, {summary.already_done} already stored ({summary.seconds:.0f} s)",
          file=sys.stderr)
    return print_report(args.out, as_json=False)


def _object_entry(args: argparse.Namespace, grasps) -> dict:
    """The config's object: --object (a mesh file or a shipped name), else the one the file names."""
    ref = grasps.object
    entry: dict = {}
    if args.object:
        given = Path(args.object)
        entry = {"mesh": str(given.resolve()), "name": ref.name or given.stem} if given.is_file() \
            else {"name": args.object}
    elif ref.mesh:
        from manigrasp.graspsets import mesh_path

        mesh = mesh_path(grasps)
        entry = {"mesh": str(mesh.resolve()), "name": ref.name or mesh.stem}
    elif ref.name:
        entry = {"name": ref.name}
    else:
        from manigrasp.errors import ConfigError

        raise ConfigError(f"{args.grasps} names no object: give --object NAME or --object MESH")
    if "mesh" in entry and (args.scale or ref.scale != 1.0):
        entry["scale"] = args.scale or ref.scale
    if args.mass or ref.mass:
        entry["mass"] = args.mass or ref.mass
    return entry
