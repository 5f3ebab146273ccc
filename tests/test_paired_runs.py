"""benchmarks/paired_runs.py: two runs paired trial for trial, with the exact McNemar test of the discordant pairs."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

from manigrasp.bench.store import ResultsStore, TrialKey
from manigrasp.protocol.result import Status, TrialResult

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "paired_runs.py"


def _script():
    spec = importlib.util.spec_from_file_location("paired_runs", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _run(folder: Path, outcomes: dict[tuple[str, int], Status], seed: int = 0) -> Path:
    folder.mkdir(parents=True)
    (folder / "run.json").write_text(json.dumps({"config": {"seed": seed, "grasps_per_object": 10,
                                                            "scene": {"pad_pitch": 0.01 + 0.005 * seed}}}))
    with ResultsStore(folder / "results.sqlite") as store:
        for (obj, rank), status in outcomes.items():
            store.add(TrialKey(obj, "parallel_jaw", "antipodal", "ground_truth", "standard", rank), TrialResult(status))
    return folder


def test_mcnemar_is_the_exact_binomial_test_of_the_discordant_pairs() -> None:
    paired = _script()
    assert paired.mcnemar(0, 0) == 1.0
    assert paired.mcnemar(0, 6) == pytest.approx(2 * 0.5**6)  # all six discordant pairs one way
    assert paired.mcnemar(3, 3) == pytest.approx(1.0)
    assert paired.mcnemar(1, 9) == paired.mcnemar(9, 1) == pytest.approx(22 / 1024)


def test_two_runs_are_paired_by_trial_and_faults_and_unpaired_trials_left_out(tmp_path, monkeypatch, capsys) -> None:
    ok, drop = Status.SUCCESS, Status.DROPPED_PERTURB
    before = {("box", i): ok if i < 8 else drop for i in range(10)}  # 8/10
    after = {("box", i): drop if i < 2 else ok for i in range(10)}  # 8/10: only-before 2 (0, 1), only-after 2 (8, 9)
    before |= {("mug", i): drop for i in range(10)}
    after |= {("mug", i): ok for i in range(9)} | {("mug", 9): Status.HARNESS_FAULT}  # 9 discordant, one fault
    after[("can", 0)] = ok  # run on one side only
    a, b = _run(tmp_path / "a", before), _run(tmp_path / "b", after)
    monkeypatch.setattr(sys, "argv", ["paired_runs.py", str(a), str(b)])
    _script().main()
    out = capsys.readouterr().out
    assert "20 trials in both (1 with a harness_fault left out), 0 in A only, 1 in B only" in out
    rows = {line.split()[4]: line.split()[5:] for line in out.splitlines() if line.startswith("parallel_jaw")}
    assert rows["box"] == ["8/10", "8/10", "2", "2", "1"]
    assert rows["mug"] == ["0/9", "9/9", "0", "9", f"{2 * 0.5**9:.3g}", "*"]
    assert rows["(all)"] == ["8/19", "17/19", "2", "11", f"{_script().mcnemar(2, 11):.3g}"]


def test_runs_of_another_seed_are_refused_as_pairs(tmp_path, monkeypatch) -> None:
    """Trial ids of runs with other seeds name other draws of grasps: not pairs. A differing scene (the change being
    compared) is what the script is for."""
    a = _run(tmp_path / "a", {("box", 0): Status.SUCCESS})
    b = _run(tmp_path / "b", {("box", 0): Status.SUCCESS}, seed=1)
    monkeypatch.setattr(sys, "argv", ["paired_runs.py", str(a), str(b)])
    with pytest.raises(SystemExit, match="differ in seed"):
        _script().main()
