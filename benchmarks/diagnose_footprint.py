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

With --loads, each trial is re-simulated instead (as `manigrasp replay`) and, at the end of the lift, the hand's
normal force on the object is split between the pads' elements (`hands.pads`) and the hand's other geoms: the
footprint only describes the grip if the pads carry it. Printed per object: the pads' share of the normal force
(median and range over the successes and over the failures) and the fewest elements touching on either pad.

    .venv/bin/python benchmarks/diagnose_footprint.py /tmp/bs/compliant/s0 --loads --objects 003_cracker_box_scan

What --loads found (panda x antipodal, compliant, seed 0, 20 grasps each; `bench_scans.py --hands panda`): on the
cracker box recipe the pads carry 12.8 of each jaw's 35 N (share 0.37, all 4 elements of each pad touching; 16/20)
and the fingers' rigid collision hulls (`finger1_collision`, `finger2_collision`) the other 22 N; on its scan the
pads carry 0.14-0.32 of it on the successes and 0.09-0.30 on the failures (9/20; median fewest elements touching
on a pad 3 and 2). The Panda's finger hull lies 0.4 mm (fingertip half of the pad) to 1.25 mm (palm end) behind
the pad face, so its 8 mm pad meets the rigid hull after 4-13 N, and the hull touches a scan's bumps at a few
points. With the hulls set back 5 mm (a scratch experiment) the pads carry 0.98-1.00 with all 4
elements on both meshes, and scan and recipe agree (seeds 0-2, of 60: 17 vs 20, against 22 vs 48 as shipped).
The recipe's grasps that the hulls held then turn in the 1.6 cm pads: standard, panda x antipodal, seed 0, of 400,
259 -> 240 (cracker box 16 -> 6, power drill 19 -> 14, sugar box 20 -> 17; `manigrasp compare` flags the cracker
box as a significant regression, p 0.015 Holm-adjusted, the pooled rate not, p 0.083).
`hands.pads.clear_backing` (86911a7) now moves the hulls back to the pads' 6.4 mm travel (6.02 mm) for every
compliant Panda: the pads carry 1.00 [1.00, 1.00] of the grip on the successes and failures of both meshes (seed 0;
recipe 6/20, scan 7/20; 4 elements on each pad), and scan vs recipe, seeds 0-2, of 60, is 17 vs 20 (6, 8, 6 and
7, 6, 4 per seed; every failure `dropped_perturb`). Standard, panda x antipodal, seed 0: 240/400 as with the 5 mm
experiment (the same per object but gelatin box 10 and phone box 8 against 9 and 9; against the shipped 259:
cracker box 6 vs 16, all 14 failures `dropped_perturb`, the one significant regression of `manigrasp compare`):

    .venv/bin/python benchmarks/bench_scans.py --out /tmp/bs --hands panda --modes compliant --seeds 0 1 2 \
        --objects 003_cracker_box_scan 003_cracker_box
    .venv/bin/python benchmarks/diagnose_footprint.py /tmp/bs/compliant/s0 --loads
    .venv/bin/manigrasp bench standard "hands=[panda]" "planners=[antipodal]" --out /tmp/std_panda

Other hands, same objects and seed: `parallel_jaw`'s pads carry 1.00 on both meshes (6 elements each; 20/20 and
20/20), `robotiq_2f85`'s 0.78 on the recipe and 0.84 on the scan (medians; 20/20 and 20/20; the rest is its inner
knuckles pressing on the box in deep grasps, the pads keeping their 6 x 7.5 N). `clear_backing` moves no
`parallel_jaw` geom, and only `robotiq_2f85`'s fingertip blocks, which do not collide with compliant pads: their
80 trials of this run (seed 0) are the same before and after in every stored column but the timings.
Since 6e28c99 `clear_backing` cuts such geoms at the travel instead of moving them whole (moved, the Panda's hulls
stood 6 mm out of the back of the real finger, and planning's collision checks saw them there): cracker box scan vs
recipe, seeds 0-2, of 60, 15 vs 20; standard, panda x antipodal, seed 0 (fcf9700): 250/400 against the shipped
259 (cracker box 9, power drill 16, sugar box 17, hammer 5, scissors 7, gelatin box 16, phone box 12 of 20).
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

LIFT = "lift"  # the phase at whose end --loads reads the contacts (`protocol.result.Phase.LIFT`)


def lift_loads(run_dir: Path, objects: list[str] | None) -> None:
    """--loads: replay the stored trials of `run_dir` (of `objects`, None: all) and print per object how much of
    the hand's normal force on the object its pads' elements carry at the end of the lift (module docstring)."""
    from manigrasp.bench.replay import _replay, stored_trials
    from manigrasp.protocol import execution

    rows = defaultdict(list)  # (hand, object) -> (success, pad share, fewest elements touching on a pad)
    for trial_id, trial in sorted(stored_trials(run_dir).items()):
        if objects is not None and trial.group.object_source.name not in objects:
            continue
        seen: dict = {}
        original = execution.TrialRun.check

        def check(run, seen=seen, original=original):  # noqa: ANN001, ANN202
            if (run.watch[2] if run.watch else str(run.last_phase)) == LIFT:
                seen["loads"] = _pad_loads(run.scene)
            return original(run)

        execution.TrialRun.check = check
        try:
            replayed = _replay(trial_id, trial, None).replayed
        finally:
            execution.TrialRun.check = original
        if "loads" in seen:
            key = (trial.group.hand, trial.group.object_source.name)
            rows[key].append((replayed.status.value == "success", *seen["loads"]))
    print(f"{'hand':13s} {'object':26s} succ   pads' share of the normal force: successes | failures   "
          "fewest elements on a pad: succ | fail")
    for (hand_name, name), values in sorted(rows.items()):
        ok = np.array([v[0] for v in values])
        share, fewest = np.array([v[1] for v in values]), np.array([v[2] for v in values])
        cells = [f"{np.median(share[m]):.2f} [{share[m].min():.2f}, {share[m].max():.2f}]" if m.any() else "-"
                 for m in (ok, ~ok)]
        counts = [f"{int(np.median(fewest[m]))}" if m.any() else "-" for m in (ok, ~ok)]
        print(f"{hand_name:13s} {name:26s} {ok.sum():2d}/{len(ok):<3d} {cells[0]:>20s} | {cells[1]:<20s} "
              f"{counts[0]:>12s} | {counts[1]}")


def _pad_loads(scene) -> tuple[float, int]:  # noqa: ANN001
    """The pads' elements' share of the hand's normal force on the object (NaN: no force) and the fewest elements
    touching on one pad, in the scene's current state."""
    import mujoco

    from manigrasp.hands.pads import ELEMENT_PREFIX
    from manigrasp.sim.contacts import read_hand_contacts

    contacts = read_hand_contacts(scene)
    names = [(mujoco.mj_id2name(scene.model, mujoco.mjtObj.mjOBJ_GEOM, g) or "").rsplit("/", 1)[-1]
             for g in contacts.hand_geom]
    force = np.clip(contacts.normal_force, 0.0, None)
    element = np.array([n.startswith(ELEMENT_PREFIX) for n in names], bool)
    total = force.sum()
    pads = [n[len(ELEMENT_PREFIX):].rsplit("_", 1)[0] for n, e in zip(names, element, strict=True) if e]
    touching = [sum(1 for p, f in zip(pads, force[element], strict=True) if p == pad and f > 0)
                for pad in scene.hand.pad_geoms]
    return (float(force[element].sum() / total) if total > 0 else float("nan")), min(touching, default=0)


def _object_sources(run_dir: Path) -> dict:
    """Object name -> its `ObjectSource` as the run's config gives it (user meshes too: `{mesh: FILE, name: ..}`)."""
    from manigrasp.bench.config import parse_config
    from manigrasp.bench.rundir import config_dir, load_meta
    from manigrasp.bench.trials import groups

    config = parse_config(load_meta(run_dir)["config"], where=f"{run_dir}/run.json")
    return {g.object_source.name: g.object_source for g in groups(config, config_dir(run_dir))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--objects", nargs="+", default=None, help="objects (default: every one of the run)")
    parser.add_argument("--below", type=float, default=0.85, help="ratio counted as poorly seated (default 0.85)")
    parser.add_argument("--loads", action="store_true",
                        help="replay the trials and print the pads' share of the grip at the end of the lift instead")
    args = parser.parse_args()
    if args.loads:
        lift_loads(args.run_dir, args.objects)
        return
    trials = defaultdict(list)
    for key, result in load_results(args.run_dir):
        if (args.objects is None or key.object in args.objects) and np.isfinite(result.grasp.x_m):
            trials[(key.hand, key.planner, key.object)].append((key.grasp_index, result))
    sources = _object_sources(args.run_dir)
    print(f"{'hand':13s} {'planner':10s} {'object':26s} succ   ratio mean  min   <{args.below:g} (succ)  "
          "succ. tilt  kern succ/fail [mm]  failures' ratio/tilt [deg]")
    for (hand_name, planner, name), rows in sorted(trials.items()):
        hand = hands.load(hand_name)
        asset = catalog.build(sources.get(name) or catalog.shipped(name)).asset
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
