"""Config validation: strict keys with hints, overrides, object entries."""

from __future__ import annotations

import pytest

from manigrasp.bench.config import load_config, parse_config
from manigrasp.errors import ConfigError, UnknownNameError


def test_short_forms_and_overrides():
    config = parse_config({"objects": ["mug", {"name": "hammer", "mass": 0.7}], "planners": ["antipodal", "random"]},
                          ["grasps_per_object=5", "scene.timestep=0.001", "hands=[parallel_jaw, panda]"])
    assert config.grasps_per_object == 5 and config.scene.timestep == 0.001
    assert config.hands == ("parallel_jaw", "panda")
    assert [p.name for p in config.planners] == ["antipodal", "random"]
    assert config.objects[1].source().mass == 0.7
    assert config.objects[0].source().name == "025_mug"


@pytest.mark.parametrize(("data", "overrides", "phrase"), [
    ({"objects": ["mug"], "grasps_per_objct": 3}, [], "did you mean 'grasps_per_object'"),
    ({"objects": ["mug"], "scene": {"impratoi": 3}}, [], "did you mean 'impratio'"),
    ({"objects": [{"nmae": "mug"}]}, [], "did you mean 'name'"),
    ({"objects": ["mug"]}, ["sede=3"], "did you mean 'seed'"),
    ({"objects": ["mug"], "observation": "xray"}, [], "unknown observation 'xray'"),
    ({"objects": []}, [], "no objects"),
    ({"objects": ["mug"]}, ["grasps_per_object"], "key=value"),
    ({"objects": ["mug"], "scene": {"integrator": "verlet"}}, [], "unknown integrator"),
    # `hands=[panda, parallel_jaw]` unquoted: the shell passes `hands=[panda,` (once a multi-line YAML error)
    ({"objects": ["mug"]}, ["hands=[panda,"], r"split by the shell: write it without spaces, hands=\[a,b\]"),
])
def test_bad_configs_are_refused_with_a_clear_message(data, overrides, phrase):
    with pytest.raises(ConfigError, match=phrase):
        parse_config(data, overrides)


def test_unknown_object_name_lists_the_set():
    config = parse_config({"objects": ["mugg"]})
    with pytest.raises(UnknownNameError, match="did you mean '025_mug'"):
        config.objects[0].source()


def test_mesh_paths_are_relative_to_the_config_file(tmp_path):
    (tmp_path / "my.yaml").write_text("objects:\n  - {mesh: parts/widget.stl, scale: 0.001}\n")
    config = load_config(tmp_path / "my.yaml")
    source = config.objects[0].source(base=tmp_path)
    assert source.mesh == str(tmp_path / "parts" / "widget.stl") and source.scale == 0.001 and source.name == "widget"


def test_unreadable_and_invalid_yaml(tmp_path):
    with pytest.raises(ConfigError, match="cannot read config"):
        load_config(tmp_path / "missing.yaml")
    (tmp_path / "bad.yaml").write_text("objects: [mug\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(tmp_path / "bad.yaml")


def test_observation_is_one_kind_or_a_list():
    assert parse_config({"objects": ["mug"]}).observation == ("ground_truth",)
    both = parse_config({"objects": ["mug"], "observation": ["ground_truth", "point_cloud"]})
    assert both.observation == ("ground_truth", "point_cloud")
    with pytest.raises(ConfigError, match="distinct"):
        parse_config({"objects": ["mug"], "observation": ["point_cloud", "point_cloud"]})


def test_every_shipped_config_validates():
    from manigrasp.bench.trials import groups
    from manigrasp.paths import configs_dir

    for path in sorted(configs_dir().glob("*.yaml")):
        config = load_config(path)
        assert groups(config), path.name
    perception = load_config(configs_dir() / "perception.yaml")
    # ground truth and estimated_pose (first camera only) once, point_cloud under 1, 2 and 3 views
    assert len(groups(perception)) == 5 * (1 + 1 + 3)
    assert sorted({(g.observation_label, g.camera.views) for g in groups(perception)}) == [
        ("estimated_pose@1view", 1), ("ground_truth", 1), ("point_cloud@1view", 1), ("point_cloud@2views", 2),
        ("point_cloud@3views", 3)]


def test_one_protocol_or_several_side_by_side():
    one = parse_config({"objects": ["mug"], "protocol": "lift"})
    assert one.protocol.name == "lift" and one.protocols == () and one.protocol_labels == ("lift",)
    assert parse_config({"objects": ["mug"]}).protocol_entries[0].name == "standard"  # the default
    several = parse_config({"objects": ["mug"], "protocols": ["standard", {"name": "six_direction",
                                                                          "params": {"grip_force": 10.0}}]})
    assert several.protocol is None and several.protocol_labels == ("standard", "six_direction")
    assert dict(several.protocol_entries[1].params) == {"grip_force": 10.0}
    # two parameter sets of one protocol: labelled by what sets them apart
    forces = parse_config({"objects": ["mug"], "protocols": [{"name": "lift", "params": {"grip_force": 5.0}},
                                                             {"name": "lift", "params": {"grip_force": 10.0}}]})
    assert forces.protocol_labels == ("lift[grip_force=5.0]", "lift[grip_force=10.0]")
    # a one-element list is that protocol, with the same run identity as `protocol:`
    from manigrasp.config import to_mapping

    listed = parse_config({"objects": ["mug"], "protocols": ["lift"]})
    assert listed == one and to_mapping(listed) == to_mapping(one)
    assert "protocols" not in to_mapping(one)  # run.json of one-protocol runs as before (resume, compare)
    # run.json of several protocols (protocol: null beside the list) parses back to the same config (replay)
    assert parse_config(to_mapping(several)) == several and to_mapping(several)["protocol"] is None


@pytest.mark.parametrize(("data", "overrides", "phrase"), [
    ({"protocol": "lift", "protocols": ["standard", "six_direction"]}, [],
     "either 'protocol'.*or 'protocols'.*not both"),
    ({"protocol": "lift"}, ["protocols=[standard, six_direction]", "protocol=lift"], "both protocol= and protocols="),
    ({"protocols": ["standard", "lift"]}, ["protocol.params.grip_force=5"], "protocol=NAME or protocols=.* replaces"),
    ({"protocols": []}, [], "at least one protocol"),
    ({"protocols": ["lift", "lift"]}, [], "protocol 'lift' with params {} is listed twice"),
    # a default written out ran the same trials twice under two labels, pooled twice
    ({"protocols": ["standard", {"name": "standard", "params": {"grip_force_fraction": 0.5}}]}, [],
     "protocols 1 and 2 .* run the same"),
    ({"planners": ["random", {"name": "random", "params": {"spread": 0.5}}]}, [], "planners 1 and 2 .* run the same"),
    ({"protocols": [{"name": "lift", "parms": {}}]}, [], "did you mean 'params'"),
    ({"protocls": ["lift"]}, [], "did you mean 'protocol"),
])
def test_protocol_and_protocols_are_refused_together_and_checked(data, overrides, phrase):
    with pytest.raises(ConfigError, match=phrase):
        parse_config({"objects": ["mug"], **data}, overrides)


def test_a_protocols_override_replaces_the_configs_protocol_and_vice_versa():
    """`bench quick protocols=[standard, lift]` runs both side by side though quick.yaml names one `protocol:`;
    `protocol=lift` on a config of several runs that one, with the identity of a config that names it."""
    from manigrasp.cli.bench import resolve_config
    from manigrasp.config import to_mapping

    quick = load_config(resolve_config("quick"), ["protocols=[standard, lift]"])
    assert quick.protocol is None and quick.protocol_labels == ("standard", "lift")
    several = {"objects": ["mug"], "protocols": ["standard", {"name": "six_direction", "params": {"grip_force": 10}}]}
    one = parse_config(several, ["protocol=lift"])
    assert one == parse_config({"objects": ["mug"], "protocol": "lift"})
    assert "protocols" not in to_mapping(one)
    # a dotted override edits the section it names and replaces nothing
    edited = parse_config({"objects": ["mug"], "protocol": {"name": "lift"}}, ["protocol.params.grip_force=5"])
    assert edited.protocol.name == "lift" and dict(edited.protocol.params) == {"grip_force": 5}


def test_rest_stable_k_needs_k_and_leaves_other_configs_identity_alone():
    from manigrasp.config import to_mapping

    config = parse_config({"objects": ["mug"], "scene": {"rest": "stable_k", "rest_k": 3}})
    assert (config.scene.rest, config.scene.rest_k, config.scene.rest_index) == ("stable_k", 3, 0)
    assert to_mapping(config.scene)["rest_k"] == 3
    plain = to_mapping(parse_config({"objects": ["mug"]}).scene)
    assert "rest_k" not in plain and "rest_index" not in plain
    for scene, phrase in (({"rest": "stable_k"}, "needs rest_k"), ({"rest": "stable_k", "rest_k": 0}, "needs rest_k"),
                          ({"rest": "most_stable", "rest_k": 2}, "stable_k only"),
                          ({"rest": "stable_k", "rest_k": 2, "rest_index": 2}, r"rest_index must be in 0\.\.1"),
                          ({"rest": "stable_k", "rest_k": 2.5}, "expected an integer"),
                          ({"rest": "stable"}, "unknown rest 'stable'; available: file, most_stable, stable_k")):
        with pytest.raises(ConfigError, match=phrase):
            parse_config({"objects": ["mug"], "scene": scene})


def test_a_key_given_twice_in_a_config_file_is_refused(tmp_path):
    """`seed: 0` then `seed: 7` ran seed 7 silently (YAML's loaders keep the last); nested mappings too."""
    path = tmp_path / "c.yaml"
    path.write_text("objects: [mug]\nseed: 0\nseed: 7\n")
    with pytest.raises(ConfigError, match="key 'seed' is given twice"):
        load_config(path)
    path.write_text("objects: [mug]\nprotocol: {name: standard, params: {grip_force: 5, grip_force: 6}}\n")
    with pytest.raises(ConfigError, match="key 'grip_force' is given twice"):
        load_config(path)
    path.write_text("objects: [mug]\nseed: 7\n")
    assert load_config(path).seed == 7
    # anchors and merge keys still read (the first version of the check refused `<<`)
    path.write_text("base: &p {grip_force: 5}\nobjects: [mug]\nprotocol: {name: standard, params: {<<: *p}}\n")
    with pytest.raises(ConfigError, match="base"):  # (an unknown top-level key, as before)
        load_config(path)
    path.write_text("objects: [mug]\nprotocol: {name: standard, params: {grip_force: 5}}\n"
                    "scene: {<<: {timestep: 0.001}}\n")
    assert load_config(path).scene.timestep == 0.001


def test_a_mesh_given_on_the_command_line_is_found_where_the_command_runs(tmp_path, monkeypatch):
    """`manigrasp bench quick objects=[{mesh: block.stl}]` looked for block.stl in the package's configs folder (a
    config file's paths are relative to its folder); an override's path is relative to the current folder."""
    from manigrasp.cli.bench import resolve_config

    monkeypatch.chdir(tmp_path)
    config = load_config(resolve_config("quick"), ["objects=[{mesh: block.stl, name: block}, mug]", "seed=3"])
    assert config.objects[0].mesh == str(tmp_path / "block.stl") and config.objects[1].name == "mug"
    assert config.seed == 3
    given = tmp_path / "elsewhere.yaml"
    given.write_text("objects: [{mesh: sub/block.stl, name: block}]\n")
    assert load_config(given).objects[0].mesh == "sub/block.stl"  # a file's own paths: relative to its folder
