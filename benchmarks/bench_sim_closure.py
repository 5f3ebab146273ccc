"""Force closure of the simulated contacts among successful trials, and the ROC AUC of sim epsilon.

Run: .venv/bin/python benchmarks/bench_sim_closure.py RUN_DIR [RUN_DIR ...]

Reads RUN_DIR/results.sqlite (written by `manigrasp bench`) and prints, per run
and per hand x planner (then all trials, labelled as pooled):

- successes whose stored `sim_force_closure` is 0 ("held through lift and
  perturbation, yet recorded as not in force closure"), and those stored NaN
  (not computed);
- the ROC AUC of `sim_epsilon_l1` for success (Mann-Whitney, ties counted
  half), over the trials where it was computed (n given), and how many of
  them are not computed.

A success with sim_force_closure = 0 is not necessarily a metric bug (a grasp
can be held by the pads' compliance or a wedge against the table), but a
textbook closure grasp stored as 0 is.
"""

from __future__ import annotations

import argparse
import sqlite3
from pathlib import Path

import numpy as np
from scipy.stats import rankdata


def roc_auc(scores: np.ndarray, labels: np.ndarray) -> float:
    """Probability that a random positive outscores a random negative (ties count half); NaN if one class is empty."""
    pos, neg = int(labels.sum()), int((~labels).sum())
    if pos == 0 or neg == 0:
        return float("nan")
    ranks = rankdata(scores)
    return float((ranks[labels].sum() - pos * (pos + 1) / 2) / (pos * neg))


def load(run: Path) -> list[tuple[str, str, str, float | None, float | None]]:
    """(hand, planner, status, sim_force_closure, sim_epsilon_l1) per trial."""
    with sqlite3.connect(run / "results.sqlite") as db:
        return db.execute("SELECT hand, planner, status, sim_force_closure, sim_epsilon_l1 FROM trials").fetchall()


def summary(rows: list[tuple[str, str, str, float | None, float | None]]) -> str:
    """One line of figures for a group of trials."""
    success = np.array([r[2] == "success" for r in rows])
    closure = np.array([np.nan if r[3] is None else r[3] for r in rows], dtype=float)
    eps = np.array([np.nan if r[4] is None else r[4] for r in rows], dtype=float)
    ok = np.isfinite(eps)
    zero = int(np.sum(success & (closure == 0.0)))
    nan = int(np.sum(success & ~np.isfinite(closure)))
    auc = roc_auc(eps[ok], success[ok])
    return (f"{len(rows):>6} {int(success.sum()):>9} {zero:>10} {nan:>10} "
            f"{auc:>9.3f} {int(ok.sum()):>6} {int((~ok).sum()):>6}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories holding results.sqlite")
    args = parser.parse_args()
    header = (f"{'run':<24} {'group':<26} {'trials':>6} {'successes':>9} {'succ fc=0':>10} {'succ fc=NaN':>10} "
              f"{'AUC eps':>9} {'n eps':>6} {'NaN':>6}")
    print(header)
    for run in args.runs:
        rows = load(run)
        groups = sorted({(r[0], r[1]) for r in rows})
        for hand, planner in groups:
            members = [r for r in rows if (r[0], r[1]) == (hand, planner)]
            print(f"{run.name:<24} {hand + ' x ' + planner:<26} {summary(members)}")
        print(f"{run.name:<24} {'all trials (pooled)':<26} {summary(rows)}")


if __name__ == "__main__":
    main()
