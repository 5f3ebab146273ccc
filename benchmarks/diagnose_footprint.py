"""What the pads touched at each stored parallel-jaw grasp: the footprint torsion ratio per trial, per object.

For every stored trial of RUN_DIR with a grasp pose (optionally only --objects), the pads' footprint
(`manigrasp.planners.footprint`, the antipodal planner's pose score) is evaluated on the object's mesh at its
stored resting pose: the torsion ratio of the patch both pads touch (1 = seated as on a flat face, 0 = one
pad touches one point or nothing) and the tilt of the more tilted pad's patch off the closing axis [deg]
(`footprint.patch_tilt`; -inf where the pad touches nothing), and the smallest kern of the two pads
(`footprint.patch_support`, how far a pad's centre of pressure can move across or along its face) [mm].
Printed per object: successes, the ratio's mean and minimum over the trials, how many grasps sit below --below
and how many of those succeeded, the successes' median tilt, the kern's median over the successes and over
the failures, and each failure's ratio/tilt.
Comparing a scan with its recipe twin, or a run with `pad_footprint: false` with one without, shows whether
the grasps that fail are the ones whose pads do not sit on the surface.

    .venv/bin/python benchmarks/diagnose_footprint.py /tmp/bs/compliant
    .venv/bin/python benchmarks/diagnose_footprint.py /tmp/bs/compliant --objects 003_cracker_box_scan 003_cracker_box

What it found (`bench_scans.py`, compliant, parallel_jaw x antipodal, seed 0, 20 grasps; before = the
planner with `pad_footprint: false`): on the cracker box scan the planned grasps' ratio was 0.90 on average,
5 of 20 below 0.85 (3 of them failed), and the four failures, all `dropped_perturb`, sat at 0.73-0.87; the
recipe's grasps 0.98 (one below 0.85, a success). The scan's faces bulge (its grasp widths 60-70 mm on a
60 mm box; mesh volume 2173 vs the recipe's 1991 cm^3) and its edges are rounded, so a pad near an edge
touches with one end. The planned grasps' distance from the centre of mass (scan 33-94 mm, recipe 33-88 mm),
score and face were alike. With the footprint's torsion in the score: ratio 0.92 on average, 2 below 0.85,
18/20. On the gelatin box scan the failures' patches were tilted 9-71 deg (the successes' median 12.6 deg)
where the pair's own tilt at contact p is 0 by construction. Footprint off -> on (torsion and tilt) on one
code base, compliant, seeds 0-2, of 60: cracker box scan 44 -> 51, recipe 57 -> 60; gelatin box scan
56 -> 57, recipe 56 -> 54; potted meat can scan 46 -> 48, recipe 58 -> 60. (A gelatin box gain of 47 -> 57
seen earlier came with the pads' own changes landing between the runs, not with the tilt.)
On the bowl (024_bowl, standard, seed 0, compliant) the footprint before its kern chose 20 grasps whose pads
reached the 4 mm rim with their last row of cells (kern 0.0 mm; 0/20 held); `pad_footprint: false` chose
grasps of kern 2.6 mm (median of its successes; 18/20), the footprint with its kern 3.0 mm (20/20).
"""

from __future__ import annotations

import argparse
import os
from collections import defaultdict
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from manigrasp import hands  # noqa: E402
from manigrasp.bench.report import load_results  # noqa: E402
from manigrasp.objects import catalog  # noqa: E402
from manigrasp.planners.base import Observation  # noqa: E402
from manigrasp.planners.collision import HandProbe  # noqa: E402
from manigrasp.planners.footprint import pad_footprint  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--objects", nargs="+", default=None, help="objects (default: every one of the run)")
    parser.add_argument("--below", type=float, default=0.85, help="ratio counted as poorly seated (default 0.85)")
    args = parser.parse_args()
    trials = defaultdict(list)
    for key, result in load_results(args.run_dir):
        if (args.objects is None or key.object in args.objects) and np.isfinite(result.grasp.x_m):
            trials[(key.hand, key.planner, key.object)].append((key.grasp_index, result))
    print(f"{'hand':13s} {'planner':10s} {'object':26s} succ   ratio mean  min   <{args.below:g} (succ)  "
          "succ. tilt  kern succ/fail [mm]  failures' ratio/tilt [deg]")
    for (hand_name, planner, name), rows in sorted(trials.items()):
        hand = hands.load(hand_name)
        asset = catalog.build(catalog.shipped(name)).asset
        rows.sort(key=lambda r: r[0])
        object_pose = rows[0][1].object_pose.matrix()
        observation = Observation.from_asset(asset, object_pose)
        footprint = pad_footprint(HandProbe(hand, observation))
        if footprint is None:
            print(f"{hand_name:13s} {planner:10s} {name:26s} (hand without pads)")
            continue
        mesh = observation.world_mesh()
        poses = np.array([r.grasp.matrix() for _, r in rows])
        ratio, _, tilt, support = footprint.seat(mesh, poses)
        kern = 1000 * support.min(axis=(1, 2))
        tilt = np.degrees(np.nanmax(np.where(np.isnan(tilt), -np.inf, tilt), axis=1))  # the more tilted pad
        ok = np.array([r.status.value == "success" for _, r in rows])
        low = ratio < args.below
        fails = " ".join(f"{x:.2f}/{t:.0f}" for x, t in zip(ratio[~ok], tilt[~ok], strict=True))
        seated_tilt = np.median(tilt[ok]) if ok.any() else np.nan
        kern_ok, kern_failed = (np.median(kern[m]) if m.any() else np.nan for m in (ok, ~ok))
        print(f"{hand_name:13s} {planner:10s} {name:26s} {ok.sum():2d}/{len(ok):<3d} {ratio.mean():5.2f} "
              f"{ratio.min():5.2f} {low.sum():5d} ({np.sum(ok & low)})   {seated_tilt:5.1f}      "
              f"{kern_ok:4.1f} {kern_failed:4.1f}   {fails}")


if __name__ == "__main__":
    main()
