"""The `power` planner, variants side by side: do its grasps envelop the object, and do they hold?

For each variant (a set of `power` parameters; "old" reproduces the planner as it was before the
wrap changes, "new" is the current default, "palm0.3" / "palm0.6" weight the palm term),
each hand and each object, one planning call asks for --grasps candidates on the settled object
(ground-truth observation, the same planning seed for every variant) and every candidate is run
through the project's own trial protocol
(`manigrasp.bench.worker`: the `standard` lift-and-perturb protocol, the seeds the bench would use).
Printed per variant x hand:

- palm<5 / palm<10: fraction of candidates whose open hand's palm is within 5 / 10 mm of the object
  at the grasp pose (`manigrasp.planners.wrap.palm_gaps`);
- gap: median palm-object gap [mm];
- toward: mean over candidates of the mean inward contact normal against the palm normal
  (`wrap.toward_palm`: +1 all contacts push the object into the palm, -1 all push it away);
  toward>0: fraction of candidates whose contacts push toward the palm on average;
- plan [s]: mean planning time per object; success: simulated successes / trials; then the
  failure statuses.

    .venv/bin/python benchmarks/bench_power.py                       # 4 objects x 5 grasps x 2 hands, old vs palm terms
    .venv/bin/python benchmarks/bench_power.py --objects 025_mug --grasps 3 --variants new
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from manigrasp.bench.config import NamedEntry  # noqa: E402
from manigrasp.bench.trials import Group, stable_seed  # noqa: E402
from manigrasp.objects import catalog  # noqa: E402
from manigrasp.sim.config import SceneConfig  # noqa: E402

# The palm term (palm_weight > 0) is off by default: it brings the palm to the object but measured lower success.
VARIANTS: dict[str, dict] = {
    # The planner before the wrap changes: first-touch stand-offs (0, 5, 20) mm, approach through the centre,
    # whole fingers stopping at first touch, score = 0.5 epsilon + 0.5 fingers (no palm term, no wrap test).
    "old": {"standoffs": [0.0, 0.005, 0.02], "lateral_offsets": [0.0], "palm_weight": 0.0, "min_inward": None},
    "new": {},  # the current defaults
    "palm0.3": {"palm_weight": 0.3},
    "palm0.6": {"palm_weight": 0.6},
}
OBJECTS = ("005_tomato_soup_can", "006_mustard_bottle", "025_mug", "004_sugar_box")
HANDS = ("inspire_right", "fourier_right")


@dataclass(frozen=True)
class GroupOutcome:
    """One variant x object x hand: the candidates' wrap measures and the trials' statuses."""

    variant: str
    object_name: str
    hand: str
    planning_time_s: float
    gaps: tuple[float, ...]
    toward: tuple[float, ...]
    statuses: tuple[str, ...]


def run_group(variant: str, params: dict, object_name: str, hand: str, n: int, seed: int) -> GroupOutcome:
    """Plan, measure the candidates and run every trial of one group (in a worker process)."""
    from manigrasp import planners
    from manigrasp.bench.worker import _asset, plan_group, run_trial, scene_for
    from manigrasp.planners.collision import HandProbe
    from manigrasp.planners.wrap import palm_gaps, toward_palm

    source = catalog.shipped(object_name)
    # The planning seed of the bench's "power" group, whatever the variant: variants differ only in parameters.
    group_seed = stable_seed(seed, source.name, hand, "power", "ground_truth")
    group = Group(source, hand, NamedEntry("power", params), NamedEntry("standard"), "ground_truth",
                  SceneConfig(), n, group_seed, 300.0)
    plan = plan_group(group)
    if plan.error is not None:
        return GroupOutcome(variant, object_name, hand, plan.planning_time_s, (), (), ("planner_error",) * n)
    observation = planners.Observation.from_asset(_asset(group), plan.object_pose)
    probe = HandProbe(scene_for(group).hand, observation)
    poses = np.array([c.pose for c in plan.candidates]).reshape(-1, 4, 4)
    gaps = palm_gaps(probe, poses)
    toward = [toward_palm(c.contact_normals, c.pose[:3, 2]) for c in plan.candidates]
    statuses = [str(run_trial(group, i, plan)[1].status) for i in range(n)]
    return GroupOutcome(variant, object_name, hand, plan.planning_time_s, tuple(gaps.tolist()), tuple(toward),
                        tuple(statuses))


def summary(rows: list[GroupOutcome]) -> str:
    """One line of figures for the outcomes of one variant x hand."""
    gaps = np.array([g for r in rows for g in r.gaps]) * 1000.0
    toward = np.array([t for r in rows for t in r.toward])
    statuses = Counter(s for r in rows for s in r.statuses)
    trials, wins = sum(statuses.values()), statuses.pop("success", 0)
    fails = " ".join(f"{k}:{v}" for k, v in sorted(statuses.items()))
    plan = np.mean([r.planning_time_s for r in rows])
    return (f"{len(gaps):5d} {np.mean(gaps < 5):8.2f} {np.mean(gaps < 10):8.2f} {np.median(gaps):8.1f} "
            f"{np.nanmean(toward):+7.2f} {np.mean(toward > 0):9.2f} {plan:8.2f} {wins:3d}/{trials:<3d} "
            f"({wins / max(trials, 1):.2f})  {fails}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--objects", nargs="+", default=list(OBJECTS), help="shipped object names")
    parser.add_argument("--hands", nargs="+", default=list(HANDS), help="hand names")
    parser.add_argument("--variants", nargs="+", default=["old", "palm0.3", "palm0.6"], choices=list(VARIANTS))
    parser.add_argument("--grasps", type=int, default=5, help="candidates planned and trials run per group")
    parser.add_argument("--seed", type=int, default=0, help="root seed (planning and trial seeds derive from it)")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes")
    args = parser.parse_args()
    catalog.build_many([catalog.shipped(o) for o in args.objects], jobs=args.jobs)
    jobs = [(v, VARIANTS[v], o, h, args.grasps, args.seed) for v in args.variants for h in args.hands
            for o in args.objects]
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.jobs, mp_context=get_context("spawn")) as pool:
        outcomes = list(pool.map(run_group, *zip(*jobs, strict=True)))
    print(f"# power: {len(args.objects)} objects x {args.grasps} grasps, seed {args.seed}, standard protocol; "
          f"{args.jobs} jobs, {os.cpu_count()} cores, {platform.processor() or platform.machine()}; "
          f"{time.perf_counter() - start:.0f} s")
    print(f"{'variant':8s} {'hand':15s} {'cands':>5s} {'palm<5':>8s} {'palm<10':>8s} {'gap[mm]':>8s} "
          f"{'toward':>7s} {'toward>0':>9s} {'plan[s]':>8s} success")
    for variant in args.variants:
        for hand in [*args.hands, "all"]:
            rows = [r for r in outcomes if r.variant == variant and hand in (r.hand, "all")]
            print(f"{variant:8s} {hand:15s} {summary(rows)}")
    print("\n# per object (success / trials, median palm gap [mm])")
    for variant in args.variants:
        cells = []
        for r in (r for r in outcomes if r.variant == variant):
            wins = sum(s == "success" for s in r.statuses)
            gap = np.median(r.gaps) * 1000 if r.gaps else float("nan")
            cells.append(f"{r.object_name}/{r.hand}: {wins}/{len(r.statuses)} gap {gap:.0f}")
        print(f"{variant:8s} " + "; ".join(cells))


if __name__ == "__main__":
    main()
