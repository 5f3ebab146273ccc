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
