"""Two runs of one config side by side, trial for trial: what a change of physics or code moved, beyond noise or not.

`manigrasp compare` refuses runs whose physics differ (it is a regression gate); this script is for the change
itself, e.g. a contact-model parameter: the same config run before and after (`manigrasp bench CONFIG --out A`
at one commit, `--out B` at another, or `scene.X=...` overrides). Trials are paired by trial id (object, hand,
planner, observation, protocol, grasp rank: the same planning and trial seeds). Printed per group (hand x
planner x observation x protocol x object) with a change: successes on each side, the pairs only A held and only
B held, and the exact McNemar p (two-sided binomial test of the discordant pairs), then the totals per hand x
planner x observation x protocol. A pair with a `harness_fault` on either side, or a trial run on one side only,
is left out (and counted). Runs of another seed or number of grasps per object are refused (their trial ids name
other draws); other differences of the configs beyond the scene are printed. Groups are sorted by p; `*` marks
p < 0.05 before any correction for the many groups, so with 100 groups about five such marks come by chance.

    .venv/bin/python benchmarks/paired_runs.py runs/std_before runs/std_after
    .venv/bin/python benchmarks/paired_runs.py runs/A runs/B --all     # also the groups that did not move
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

from manigrasp.bench.stats import mcnemar_p as mcnemar
from manigrasp.bench.store import ResultsStore
from manigrasp.protocol.result import Status


def outcomes(run: Path) -> dict[str, tuple[tuple[str, ...], bool | None]]:
    """trial id -> (group key, success; None for a `harness_fault`) of the run directory `run`."""
    store = run / "results.sqlite"
    if not store.is_file():
        raise SystemExit(f"{run} holds no results.sqlite (give a run directory)")
    with ResultsStore(store, readonly=True) as db:
        return {key.trial_id: ((key.hand, key.planner, key.observation, key.protocol, key.object),
                               None if result.status is Status.HARNESS_FAULT else result.success)
                for key, result in db.results()}


def config_differences(a: Path, b: Path) -> list[str]:
    """Keys (dotted) of the two runs' recorded configs that differ, the scene's aside (the change compared);
    `SystemExit` if the seed or the grasps per object differ: then a trial id names other draws on each side."""
    from manigrasp.bench.rundir import differing_keys, load_meta

    configs = [{k: v for k, v in load_meta(run)["config"].items() if k != "scene"} for run in (a, b)]
    keys = differing_keys(*configs)
    drawn = [k for k in keys if k.split(".")[0] in ("seed", "grasps_per_object")]
    if drawn:
        raise SystemExit(f"{a} and {b} differ in {', '.join(drawn)}: their trials are other draws, not pairs")
    return keys


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", type=Path, help="run directory A (before)")
    parser.add_argument("b", type=Path, help="run directory B (after)")
    parser.add_argument("--all", action="store_true", help="also list the groups with no discordant pair")
    args = parser.parse_args()
    differ = config_differences(args.a, args.b)
    a, b = outcomes(args.a), outcomes(args.b)
    common = sorted(a.keys() & b.keys())
    faults = sum(a[t][1] is None or b[t][1] is None for t in common)
    cells: dict[tuple[str, ...], list[int]] = defaultdict(lambda: [0, 0, 0, 0, 0])  # n, a ok, b ok, only a, only b
    for trial in common:
        group, x = a[trial]
        y = b[trial][1]
        if x is None or y is None:
            continue
        cell = cells[group]
        cell[0] += 1
        cell[1] += x
        cell[2] += y
        cell[3] += x and not y
        cell[4] += y and not x
    print(f"# A = {args.a}, B = {args.b}: {len(common)} trials in both ({faults} with a harness_fault left out), "
          f"{len(a.keys() - b.keys())} in A only, {len(b.keys() - a.keys())} in B only")
    if differ:
        print(f"# the configs differ beyond the scene in {', '.join(differ)}: the trials of a group defined "
              "differently on each side are not the same experiment")
    header = f"{'hand':<14} {'planner':<10} {'observation':<12} {'protocol':<10} {'object':<22}"
    print(f"{header} {'A':>7} {'B':>7} {'only A':>6} {'only B':>6} {'McNemar p':>9}")
    rows = [(mcnemar(c[3], c[4]), g, c) for g, c in cells.items() if args.all or c[3] + c[4]]
    for p, group, c in sorted(rows):
        hand, planner, observation, protocol, obj = group
        mark = " *" if p < 0.05 else ""
        print(f"{hand:<14} {planner:<10} {observation:<12} {protocol:<10} {obj:<22} {c[1]:>3}/{c[0]:<3} "
              f"{c[2]:>3}/{c[0]:<3} {c[3]:>6} {c[4]:>6} {p:>9.3g}{mark}")
    totals: dict[tuple[str, ...], list[int]] = defaultdict(lambda: [0, 0, 0, 0, 0])
    for group, c in cells.items():
        totals[group[:4]] = [s + v for s, v in zip(totals[group[:4]], c, strict=True)]
    print("\n# totals per hand x planner x observation x protocol")
    for method, c in sorted(totals.items()):
        hand, planner, observation, protocol = method
        print(f"{hand:<14} {planner:<10} {observation:<12} {protocol:<10} {'(all)':<22} {c[1]:>3}/{c[0]:<3} "
              f"{c[2]:>3}/{c[0]:<3} {c[3]:>6} {c[4]:>6} {mcnemar(c[3], c[4]):>9.3g}")


if __name__ == "__main__":
    main()
