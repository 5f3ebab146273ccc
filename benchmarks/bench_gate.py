"""How often does the regression gate fail a run that is as good as its baseline? (its false-alarm rate)

Both sides of each compare are drawn binomially at a committed baseline's own group rates (the null hypothesis:
nothing changed), `--draws` times (seeded), and each pair goes through `manigrasp.bench.compare.compare` at
`--alpha`. Printed per baseline: the share of pairs the gate fails (any line flagged), and the share each family
flags (the pooled line, the method lines, the group lines), beside the rule of before 4 Dec 2026 on the same
draws, each family at the whole alpha (a line of a family flags under it where its adjusted p is below alpha
times the number of families the gate now splits alpha over; the split only multiplies the p-values). Then the
chance that `make regression` fails on its two compares, each at alpha 0.025 (1 - the product of passing both).

    .venv/bin/python benchmarks/bench_gate.py                 # quick.json and dexterous.json, 2000 draws
    .venv/bin/python benchmarks/bench_gate.py --draws 5000 --alpha 0.05 --baselines quick.json

Measured (4 Dec 2026, the defaults: 2000 draws, alpha 0.05, seed 0): quick fails 2.3 % of null pairs (each family
at the whole alpha: 8.5 %), dexterous 3.3 % (8.6 %); `make regression` 2.7 %.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from manigrasp.bench.compare import compare
from manigrasp.bench.report import Rate, Report
from manigrasp.bench.stats import wilson_interval

BASELINES = Path(__file__).resolve().parent / "baselines"
KINDS = ("pooled", "method", "group")


def group_counts(path: Path) -> dict[tuple[str, ...], tuple[int, int]]:
    """(successes, trials) per group of a baseline JSON (`manigrasp report RUN --json`)."""
    payload = json.loads(path.read_text())
    return {(g["hand"], g["planner"], g["observation"], g["protocol"], g["object"]): (g["successes"], g["trials"])
            for g in payload["groups"]}


def draw(counts: dict[tuple[str, ...], tuple[int, int]], rng: np.random.Generator) -> Report:
    """A run whose every group's successes are drawn at the baseline's rate of that group."""
    groups = {}
    for key, (successes, trials) in counts.items():
        k = int(rng.binomial(trials, successes / trials))
        groups[key] = Rate(trials, k, k / trials, *wilson_interval(k, trials))
    return Report(overall=Rate(0, 0, 0.0, 0.0, 1.0), by_method={}, groups=groups)


def false_alarms(counts: dict[tuple[str, ...], tuple[int, int]], draws: int, alpha: float, seed: int
                 ) -> tuple[dict[str, float], dict[str, float]]:
    """Shares of null pairs flagged (any line, and per family) by the gate and by the rule of before."""
    rng = np.random.default_rng(seed)
    methods = {k[:4] for k in counts}
    families = 1 + (len(methods) > 1) + (len(counts) > len(methods))  # as `compare` counts them
    now = dict.fromkeys(("any", *KINDS), 0)
    before = dict.fromkeys(("any", *KINDS), 0)
    for _ in range(draws):
        verdict = compare(draw(counts, rng), draw(counts, rng), alpha=alpha)
        flagged = {c.kind for c in verdict.comparisons if c.regression}
        old = {c.kind for c in verdict.comparisons if c.adjusted_p < families * alpha}
        for tally, kinds in ((now, flagged), (before, old)):
            tally["any"] += bool(kinds)
            for kind in kinds:
                tally[kind] += 1
    return {k: v / draws for k, v in now.items()}, {k: v / draws for k, v in before.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--baselines", nargs="+", default=["quick.json", "dexterous.json"],
                        help="baseline JSON files in benchmarks/baselines/ (or paths)")
    parser.add_argument("--draws", type=int, default=2000)
    parser.add_argument("--alpha", type=float, default=0.05)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print(f"# false alarms of the regression gate, {args.draws} null draws per baseline, alpha {args.alpha}")
    print(f"{'baseline':16s} {'rule':28s} {'any':>6s} " + " ".join(f"{k:>7s}" for k in KINDS))
    for name in args.baselines:
        path = Path(name) if Path(name).exists() else BASELINES / name
        now, before = false_alarms(group_counts(path), args.draws, args.alpha, args.seed)
        for rule, shares in (("now (alpha split by family)", now), ("before (each at alpha)", before)):
            print(f"{path.name:16s} {rule:28s} {shares['any']:6.3f} " + " ".join(f"{shares[k]:7.3f}" for k in KINDS))
    both = [false_alarms(group_counts(BASELINES / b), args.draws, 0.025, args.seed)[0]["any"]
            for b in ("quick.json", "dexterous.json")]
    print(f"make regression (two compares at alpha 0.025): fails a run as good as its baselines "
          f"{1 - (1 - both[0]) * (1 - both[1]):.3f} of the time")


if __name__ == "__main__":
    main()
