"""`manigrasp plan`: plan grasps on one object with one hand and one planner; print the ranking."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from manigrasp import hands, planners
from manigrasp.cli.output import format_table, print_json
from manigrasp.errors import ConfigError
from manigrasp.planners.base import GraspCandidate

_HEADERS = ["rank", "score", "planner's epsilon L1", "width [mm]", "force closure", "approach (unit vector, world)"]


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `plan`."""
    p = subparsers.add_parser(
        "plan", help="plan grasps on an object and print them ranked",
        description="Plan grasps for one object (shipped name or mesh file) with one hand and one planner "
                    "(built-in name or package.module:attribute). The object rests upright on the table.")
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--object", help="shipped object name, e.g. 025_mug or mug")
    source.add_argument("--mesh", help="a mesh file (OBJ, STL, PLY, OFF, GLB/GLTF), built and decomposed first")
    p.add_argument("--scale", type=float, default=1.0, help="scale the --mesh vertices (0.001: mm to m)")
    p.add_argument("--hand", required=True, help="hand name or package.module:attribute")
    p.add_argument("--planner", required=True, help=f"one of {', '.join(planners.names())} or package.module:attr")
    p.add_argument("-n", type=int, default=100, help="most grasps to return (default 100)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table: each candidate's TCP pose "
                   "in the world, and the object's pose (object_pose; a grasp file's poses are "
                   "inv(object_pose) @ pose)")
    p.add_argument("--record", type=Path, metavar="FILE.rrd",
                   help="also write the object and the candidates (frames coloured by score) as a rerun recording")
    p.set_defaults(func=_plan)


def _asset(args: argparse.Namespace):  # noqa: ANN202 (ObjectAsset; imported lazily)
    from manigrasp.objects import catalog

    if args.object:
        if args.scale != 1.0:  # a shipped object has its real size; --scale is for a mesh file's units
            from manigrasp.errors import ConfigError

            raise ConfigError(f"--scale applies to a --mesh file, not to the shipped object {args.object!r}")
        return catalog.build(catalog.shipped(args.object)).asset
    source = catalog.ObjectSource(name=catalog.default_mesh_name(args.mesh), mesh=args.mesh, scale=args.scale)
    return catalog.build(source).asset


def _finite(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


def candidate_record(c: GraspCandidate) -> dict[str, Any]:
    """The JSON record of one candidate (lengths in m; the pose is the TCP's in the world): with a dexterous hand's
    pre-shape synergy and, when the planner gives one, its own hand path (``joints``: pre-shape and squeeze
    actuator commands), so that, with the printed ``object_pose`` (a grasp file's poses are in the object's frame:
    inv(object_pose) @ pose), the record holds everything `manigrasp evaluate` needs to run the grasp again."""
    record = {"pose": c.pose.tolist(), "width_m": _finite(c.width), "score": c.score,
              "epsilon_l1": _finite(c.epsilon_l1), "force_closure": c.force_closure,
              "min_friction": _finite(c.min_friction), "contacts": c.contacts.tolist(), "preshape": c.preshape}
    if c.joints is not None:
        record["joints"] = np.asarray(c.joints, float).tolist()
    return record


def _row(rank: int, c: GraspCandidate) -> list[str]:
    eps = "-" if c.epsilon_l1 is None else f"{c.epsilon_l1:.4f}"
    width = "-" if c.width is None else f"{1000 * c.width:.1f}"
    closure = "-" if c.force_closure is None else ("yes" if c.force_closure else "no")
    approach = "(" + ", ".join(f"{v:+.2f}" for v in c.approach) + ")"
    return [str(rank), f"{c.score:.3f}", eps, width, closure, approach]


def _check_record_target(path: Path) -> None:
    """Refuse, before planning, a --record file that cannot be written (one line)."""
    import os

    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise ConfigError(f"--record {path} is a folder; give a file name such as {path / 'plan.rrd'}")
    if not folder.is_dir():
        raise ConfigError(f"--record {path}: the folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ConfigError(f"--record {path}: the folder {folder} is not writable")


def _plan(args: argparse.Namespace) -> int:
    from manigrasp.bench.config import MAX_SEED

    if args.n < 1:
        raise ConfigError(f"-n must be >= 1, got {args.n}")
    if not 0 <= args.seed <= MAX_SEED:
        raise ConfigError(f"--seed must be an integer in 0..2**63-1, got {args.seed}")
    if args.record:
        _check_record_target(args.record)
    hand = hands.load(args.hand)
    planner = planners.load(args.planner)
    observation = planners.Observation.from_asset(_asset(args))
    result = planners.plan(planner, observation, hand, args.n, np.random.default_rng(args.seed))
    if args.record:
        from manigrasp.record.plan import record_plan

        try:
            record_plan(args.record, observation, result.candidates,
                        title=f"{result.planner} on {observation.asset.name} ({hand.name})")
        except OSError as exc:  # the folder went away or filled up while planning
            raise ConfigError(f"--record {args.record}: cannot write it: {exc.strerror or exc}") from None
        print(f"recording written: {args.record}", file=sys.stderr)
    if args.json:
        print_json({"object": observation.asset.name, "object_pose": observation.object_pose.tolist(),
                    "hand": hand.name, "planner": result.planner, "seed": args.seed,
                    "planning_time_s": result.planning_time_s,
                    "candidates": [candidate_record(c) for c in result.candidates]})
        return 0
    print(format_table(_HEADERS, [_row(i + 1, c) for i, c in enumerate(result.candidates)]))
    print(f"{len(result.candidates)} candidates from {result.planner!r} for {hand.name!r} on "
          f"{observation.asset.name!r} in {result.planning_time_s:.3f} s (seed {args.seed})")
    if any(c.epsilon_l1 is not None for c in result.candidates):
        print("epsilon L1 and force closure are the planner's own figures (its contact model and torque scale); "
              "a benchmark trial stores its own as planned_epsilon_l1 (docs/grasp-mechanics.md)")
    if not result.candidates:
        print("manigrasp: note: the planner found no grasp (is the object wider than the hand opens?)",
              file=sys.stderr)
    return 0
