"""`manigrasp plan`'s table: each column says what its figures are."""

from __future__ import annotations

import numpy as np

from manigrasp.cli import main


def test_the_approach_column_is_a_unit_vector_in_the_world_and_says_so(capsys):
    assert main(["plan", "--object", "025_mug", "--hand", "parallel_jaw", "--planner", "random", "-n", "3"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[-4:] == ["approach", "(unit", "vector,", "world)"]
    for line in lines[2:5]:
        vector = np.array([float(v) for v in line.partition("(")[2].rstrip(")").split(",")])
        assert abs(np.linalg.norm(vector) - 1) < 0.02  # two decimals each
