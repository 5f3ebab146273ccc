"""The hand registry: every hand loads, validates and keeps the TCP/finger conventions; user hands."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from manigrasp import hands
from manigrasp.cli import main
from manigrasp.errors import HandError, UnknownNameError
from manigrasp.hands.from_robosuite.measure import finger_of, jaw_gap
from manigrasp.hands.validate import validate_hand

KINDS = {
    "parallel_jaw": "parallel", "panda": "parallel", "robotiq_2f85": "parallel",
    "inspire_right": "dexterous", "inspire_left": "dexterous",
    "fourier_right": "dexterous", "fourier_left": "dexterous",
    "allegro_right": "dexterous", "allegro_left": "dexterous",
}
PARALLEL = [name for name, kind in KINDS.items() if kind == "parallel"]
LIST_KEYS = {"name", "kind", "actuated_dof", "tcp_site", "approach_axis", "closing_axis", "finger_bodies",
             "max_width", "max_grip_force", "mass"}


def test_registry_names_are_the_declared_hands() -> None:
    assert set(hands.names()) == set(KINDS)


@pytest.mark.parametrize("name", sorted(KINDS))
def test_hand_loads_validates_and_declares_names(name: str) -> None:
    hand = hands.load(name)
    validate_hand(hand)
    assert hand.name == name and hand.kind == KINDS[name]
    model = hand.build_spec().compile()
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, hand.tcp_site) >= 0
    for body in hand.finger_bodies:
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body) >= 0
    for actuator in hand.actuators:
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, actuator) >= 0
    assert hand.mass == pytest.approx(model.body_subtreemass[0], rel=1e-6)
    assert hand.open_ctrl.shape == hand.closed_ctrl.shape == (hand.n_actuators,)
    if hand.kind == "dexterous":
        assert hand.n_actuators >= 3 and len(hand.finger_bodies) == (4 if name.startswith("allegro") else 5)


def test_build_spec_is_fresh_each_call() -> None:
    hand = hands.load("robotiq_2f85")
    first, second = hand.build_spec(), hand.build_spec()
    assert first is not second
    first.body(hand.root_body).add_freejoint()
    second.compile()  # untouched by the edit of the first


def _open_hand(name: str, steps: int = 400) -> tuple[hands.Hand, mujoco.MjModel, mujoco.MjData]:
    """The hand floating without gravity (so the root does not collide with its own links), opened."""
    hand = hands.load(name)
    spec = hand.build_spec()
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.body(hand.root_body).add_freejoint()
    model = spec.compile()
    data = mujoco.MjData(model)
    data.ctrl[:] = hand.open_ctrl
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return hand, model, data


@pytest.mark.parametrize("name", PARALLEL)
def test_parallel_tcp_lies_between_the_fingers_with_y_closing(name: str) -> None:
    hand, model, data = _open_hand(name)
    gap = jaw_gap(model, data, hand.tcp_site)
    # A ray from the TCP along -y meets finger 1, along +y finger 2: y runs finger 1 -> finger 2.
    assert finger_of(model, gap.minus_body, hand.finger_bodies) == hand.finger_bodies[0]
    assert finger_of(model, gap.plus_body, hand.finger_bodies) == hand.finger_bodies[1]
    assert abs(gap.minus_y - gap.plus_y) < 0.1 * gap.width  # centred
    assert gap.width == pytest.approx(hand.max_width, rel=0.05)


def test_robotiq_linkage_closes_and_opens_with_pads_moving_together() -> None:
    hand, model, data = _open_hand("robotiq_2f85")
    pads = [model.geom(f"{side}_fingerpad_collision").id for side in ("left", "right")]
    finger = model.body("left_inner_finger").id
    tilt = []
    for s, steps in ((1.0, 600), (0.0, 600)):
        data.ctrl[:] = hand.synergy_ctrl(s)
        for _ in range(steps):
            mujoco.mj_step(model, data)
            tilt.append(data.xmat[finger].reshape(3, 3)[:, 2] @ data.xmat[model.body(hand.root_body).id][6:9])
        left, right = data.geom_xpos[pads]
        assert left[1] == pytest.approx(-right[1], abs=5e-4)  # symmetric about the TCP plane
        assert left[2] == pytest.approx(right[2], abs=5e-4)
        gap = right[1] - left[1]
        assert gap < 0.01 if s == 1.0 else gap > 0.08
    assert min(tilt) > np.cos(np.radians(2.0))  # pads stay parallel to the approach axis throughout


@pytest.mark.parametrize("spec", ["user_hand_example:HAND", "user_hand_example:make_hand"])
def test_user_hand_loads_as_module_attribute(spec: str) -> None:
    hand = hands.load(spec)
    assert hand.name == "tiny_gripper" and hand.finger_bodies == ("left", "right")


@pytest.mark.parametrize(("attribute", "message"), [
    ("NO_TCP_SITE", "no TCP site 'tcp'"),
    ("NO_ACTUATORS", "has no actuators"),
    ("NO_FINGERS_DECLARED", "no finger bodies declared"),
    ("WRONG_FINGER", "finger body 'thumb' not found"),
    ("WRONG_ACTUATOR", "actuator 'squeeze' not found"),
    ("SHORT_CTRL", "closed_ctrl has shape (2,), expected (1,)"),
    ("JOINTED_ROOT", "root body 'palm' has a joint"),
])
def test_broken_user_hand_is_refused_naming_what_is_missing(attribute: str, message: str) -> None:
    with pytest.raises(HandError, match=message.replace("(", r"\(").replace(")", r"\)")):
        hands.load(f"user_hand_example:{attribute}")


def test_validate_refuses_what_is_not_a_hand() -> None:
    with pytest.raises(HandError, match="expected a manigrasp.hands.Hand, got dict"):
        validate_hand({"name": "tiny_gripper"})


def test_user_attribute_that_is_not_a_hand_is_refused() -> None:
    with pytest.raises(HandError, match="is a dict, not a manigrasp.hands.Hand"):
        hands.load("user_hand_example:NOT_A_HAND")


def test_unknown_hand_lists_the_available_ones() -> None:
    with pytest.raises(UnknownNameError, match="robotiq_2f85"):
        hands.load("robotiq")


def test_cli_list_json_parses_with_every_key(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["hands", "list", "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    assert {r["name"] for r in records} == set(KINDS)
    for record in records:
        assert set(record) == LIST_KEYS
        assert record["approach_axis"] == [0.0, 0.0, 1.0] and record["closing_axis"] == [0.0, 1.0, 0.0]


def test_cli_show_and_unknown_name(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["hands", "show", "panda", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["actuated_dof"] == 1
    assert main(["hands", "show", "pandaa"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "unknown hand 'pandaa'" in err


def test_a_user_hand_of_the_wrong_kind_is_refused_before_it_is_called(tmp_path, monkeypatch, capsys):
    """`hands show os:system` and `plan --hand os:system` called os.system (a TypeError traceback, exit 1; an
    attribute such as os:abort would have run); a config refused it before calling it, these did not. A factory
    that raises is one line too."""
    monkeypatch.chdir(tmp_path)
    for argv in (["hands", "show", "os:system"], ["hands", "show", "os:getcwd"],
                 ["plan", "--object", "025_mug", "--hand", "os:system", "--planner", "random", "-n", "1"],
                 ["hands", "show", "faulty_planners:raising_hand"]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.startswith("manigrasp: error: hand ") and "\n" not in err, err
        assert "it was not called" in err or "building it raised RuntimeError: no hand today" in err, err
