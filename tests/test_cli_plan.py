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


def test_the_json_gives_the_object_pose_that_turns_its_world_poses_into_a_grasp_file(capsys, tmp_path):
    """`plan --json` printed world TCP poses without the object's pose, while a grasp file (what `evaluate` runs)
    holds poses in the object's frame: the mug's 6 cm of resting height could not be taken out."""
    import json

    from manigrasp.graspsets import read

    assert main(["plan", "--object", "025_mug", "--hand", "parallel_jaw", "--planner", "random", "-n", "2",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    object_pose = np.array(out["object_pose"])
    assert object_pose.shape == (4, 4) and object_pose[2, 3] > 0.01  # resting on the table, not at the origin
    grasps = [{"pose": (np.linalg.inv(object_pose) @ np.array(c["pose"])).tolist(), "width": c["width_m"]}
              for c in out["candidates"]]
    path = tmp_path / "g.json"
    path.write_text(json.dumps({"hand": out["hand"], "object": {"name": out["object"]}, "grasps": grasps}))
    assert len(read(path)) == 2
