"""`manigrasp bench` on mistyped input: one line naming the nearest valid choice, exit 2, nothing written."""

from __future__ import annotations

import pytest

from manigrasp.cli import main


@pytest.mark.parametrize("args, message", [
    (["quik"], "no config file 'quik' (did you mean 'quick'?); shipped configs: dexterous, "),
    (["./nowhere.yaml"], "no config file './nowhere.yaml'; shipped configs: "),
    (["quick", "grasps_per_objet=3"], "unknown key 'grasps_per_objet'; did you mean 'grasps_per_object'?"),
    (["quick", "scene.padz=rigid"], "quick.yaml.scene: unknown key 'padz'; did you mean 'pads'?"),
    (["quick", "objects=[mugg]"], "unknown object 'mugg' (did you mean '025_mug'?)"),
    (["quick", "hands=[pandaa]"], "unknown hand 'pandaa' (did you mean 'panda'?)"),
    (["quick", "planners=[antipodall]"], "unknown planner 'antipodall' (did you mean 'antipodal'?)"),
    (["quick", "protocol=standrd"], "unknown protocol 'standrd' (did you mean 'standard'?)"),
    (["quick", "planners=[{name: antipodal, parms: {n_samples: 4}}]"],
     "planners[0]: unknown key 'parms'; did you mean 'params'?"),
])
def test_a_mistyped_config_name_key_or_registry_name_is_one_line_and_exit_2(tmp_path, capsys, args, message):
    out = tmp_path / "run"
    assert main(["bench", *args, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not out.exists()
