"""`manigrasp perceive`: one simulated depth view of an object, recognition and pose estimation."""

from __future__ import annotations

import argparse
import math

import numpy as np

from manigrasp.cli.output import print_json
from manigrasp.errors import ConfigError


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register `perceive`."""
    p = subparsers.add_parser(
        "perceive", help="simulated depth view -> recognition and pose estimation (needs open3d)",
        description="Place a shipped object on the table (upright, yaw from --seed), take one noisy depth "
                    "view, recognise it among the shipped set (FPFH + RANSAC + ICP, verified) and print the "
                    "estimated pose and its errors.")
    p.add_argument("--object", required=True, help="shipped object name, e.g. 025_mug or mug")
    p.add_argument("--camera", default="30,45,0.55", metavar="AZ,EL[,DIST]",
                   help="camera azimuth and elevation [deg] and distance [m] about the object (default 30,45,0.55)")
    p.add_argument("--backend", choices=("raycast", "gl", "auto"), default="raycast",
                   help="depth by ray casting (default, needs no OpenGL), MuJoCo's renderer, or GL if available")
    p.add_argument("--among", nargs="*", metavar="NAME", help="candidate models (default: every shipped object)")
    p.add_argument("--seed", type=int, default=0, help="seed of the object's yaw, the depth noise and RANSAC")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=_perceive)


def _camera(text: str, backend: str):
    from manigrasp.perception.pipeline import CameraConfig

    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) not in (2, 3):
        raise ConfigError(f"--camera wants AZ,EL or AZ,EL,DIST (degrees, metres), got {text!r}")
    fields = dict(zip(("azimuth_deg", "elevation_deg", "distance"), values, strict=False))
    return CameraConfig(**fields, backend=backend)


def _perceive(args: argparse.Namespace) -> int:
    from manigrasp.bench.extras import problem

    missing = problem("perception", import_it=True)  # the extra, or libusb under an installed open3d
    if missing:
        raise ConfigError(f"`manigrasp perceive`: {missing}")
    from manigrasp.objects import catalog, recipes
    from manigrasp.perception.models import ModelDatabase
    from manigrasp.perception.pipeline import PerceptionConfig, perceive
    from manigrasp.planners.base import resting_pose
    from manigrasp.sim import build_tabletop

    name = catalog.shipped(args.object).name  # a recipe ("mug", "025_mug") or a shipped scan
    among = [catalog.shipped(n).name for n in (args.among or recipes.names())]
    if name not in among:
        among.append(name)
    assets = {n: catalog.build(catalog.shipped(n)).asset for n in among}
    rng = np.random.default_rng(args.seed)
    pose = resting_pose(assets[name])
    yaw = rng.uniform(0.0, 2 * math.pi)
    pose[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    table = build_tabletop(assets[name])
    table.place(pose)
    camera = _camera(args.camera, args.backend).camera(pose[:2, 3])
    result = perceive(table, camera, ModelDatabase.from_assets(assets.values()), rng,
                      PerceptionConfig(backend=args.backend), true_pose=pose)
    same = result.recognized_as == name
    errors = result.errors
    payload = {
        "object": name, "recognized_as": result.recognized_as, "fitness": result.estimate.fitness,
        "rotation_error_deg": errors.rotation_deg if same else None,
        "translation_error_mm": errors.translation_mm if same else None,
        "add_s_mm": errors.add_s_mm if same else None,
    }
    if args.json:
        print_json(payload)
        return 0
    print(f"object         {name}")
    print(f"recognized as  {result.recognized_as or '(nothing above the threshold)'} "
          f"(score {result.estimate.score:.3f}, fitness {result.estimate.fitness:.3f}, "
          f"inlier RMSE {1000 * result.estimate.inlier_rmse:.2f} mm)")
    print(f"depth backend  {result.backend}; {len(result.cloud)} object points")
    print("estimated pose\n" + np.array2string(result.estimate.pose, precision=4, suppress_small=True))
    if same:
        print(f"errors         rotation {errors.rotation_deg:.2f} deg, translation {errors.translation_mm:.2f} mm, "
              f"ADD {errors.add_mm:.2f} mm, ADD-S {errors.add_s_mm:.2f} mm"
              + (" (symmetric object: judged by ADD-S)" if errors.symmetric else ""))
    print("timings        " + ", ".join(f"{k} {1000 * v:.0f} ms" for k, v in result.timings.items()))
    return 0
