"""Dexterous fingertips with `pads: compliant`: the rubber-covered fingertip geoms touch with the pad rubber's
friction (`SceneConfig.pad_friction`), every other hand geom with the hand's; `pads: rigid` is unchanged.

Closed loop (`manigrasp.sim.tiptest`): one fingertip geom, copied from the compiled scene (shape, friction,
priority, condim, solver parameters), is fixed in a gravity-free rig; a box on three slide joints is pressed
onto it with a force F and then pulled along the contact plane by a slowly growing force. The box holds until
that force reaches mu F, mu the fingertip's sliding friction in the scene: 0.5 with rigid pads, the rubber's 1.0
with compliant ones.
"""

from __future__ import annotations

import dataclasses
import time

import mujoco
import numpy as np
import pytest

from manigrasp import hands
from manigrasp.errors import SimulationError
from manigrasp.hands.placement import side_power_grasp
from manigrasp.planners.base import GraspCandidate
from manigrasp.protocol import PROTOCOLS, settle_object
from manigrasp.sim import build_scene
from manigrasp.sim.compose import HAND_PREFIX
from manigrasp.sim.config import SceneConfig
from manigrasp.sim.tiptest import press_fingertip

DEXTEROUS = [n for n in ("inspire_right", "inspire_left", "fourier_right", "fourier_left", "allegro_right",
                         "allegro_left") if n in hands.names()]
PRESS = 5.0  # [N], the force pressing the box onto the fingertip


def _hand_model(name: str, pads: str) -> mujoco.MjModel:
    return build_scene(hands.load(name), None, SceneConfig(pads=pads)).model


def _geom(model: mujoco.MjModel, name: str) -> int:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, HAND_PREFIX + name)


@pytest.mark.parametrize("name", DEXTEROUS)
def test_compliant_pads_give_the_fingertips_the_rubber_friction_and_nothing_else(name: str) -> None:
    hand = hands.load(name)
    assert len(hand.fingertip_geoms) == (5 if not name.startswith("allegro") else 4)
    config = SceneConfig(pads="compliant")
    model = _hand_model(name, "compliant")
    tips = {_geom(model, g) for g in hand.fingertip_geoms}
    assert -1 not in tips
    hand_geoms = [g for g in range(model.ngeom) if model.geom_priority[g] >= 1 and model.geom_contype[g]]
    for g in hand_geoms:
        want = config.pad_friction if g in tips else config.hand_friction
        assert model.geom_friction[g, 0] == want, mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
        assert model.geom_friction[g, 1] == config.hand_torsional_friction


@pytest.mark.parametrize("name", DEXTEROUS)
def test_rigid_pads_leave_the_dexterous_hand_as_modelled(name: str) -> None:
    """Bit for bit: declaring fingertips changes nothing under `pads: rigid` (the model of the same hand
    without fingertip geoms is identical in every numeric array)."""
    hand = hands.load(name)
    with_tips = build_scene(hand, None, SceneConfig(pads="rigid")).model
    without = build_scene(dataclasses.replace(hand, fingertip_geoms=()), None, SceneConfig(pads="rigid")).model
    arrays = [a for a in dir(with_tips) if not a.startswith("_") and isinstance(getattr(with_tips, a), np.ndarray)]
    assert len(arrays) > 100
    for attr in arrays:
        np.testing.assert_array_equal(getattr(with_tips, attr), getattr(without, attr), err_msg=attr)
    assert set(with_tips.geom_friction[with_tips.geom_priority >= 1, 0]) == {SceneConfig().hand_friction}


def test_a_fingertip_that_is_not_a_colliding_geom_is_refused() -> None:
    hand = dataclasses.replace(hands.load("inspire_right"), fingertip_geoms=("no_such_geom",))
    with pytest.raises(SimulationError, match="fingertip geom 'no_such_geom'"):
        build_scene(hand, None, SceneConfig(pads="compliant"))
    build_scene(hand, None, SceneConfig(pads="rigid"))  # rigid pads never look at them


@pytest.mark.parametrize("pads", ["rigid", "compliant"])
@pytest.mark.parametrize("name", [n for n in DEXTEROUS if n.endswith("right")])
def test_a_pressed_fingertip_holds_its_friction_times_the_press(name: str, pads: str) -> None:
    scene = _hand_model(name, pads)
    press = press_fingertip(scene, _geom(scene, hands.load(name).fingertip_geoms[1]), PRESS)  # the index fingertip
    assert press.friction == (1.0 if pads == "compliant" else 0.5)
    assert press.normal_force == pytest.approx(PRESS, rel=0.02)
    assert press.slip_force == pytest.approx(press.friction * PRESS, rel=0.05)


@pytest.mark.slow
@pytest.mark.parametrize("name", DEXTEROUS)
def test_hand_placed_can_holds_with_rubber_fingertips_and_creeps_less_than_2_mm(name: str, can) -> None:
    """The standard protocol (lift 10 cm, hold, six m g perturbations) on a side power grasp of a 0.35 kg can,
    as `tests/test_dexterous_grip.py` runs it with rigid pads (`benchmarks/bench_grip_hold.py`)."""
    scene = build_scene(hands.load(name), can, SceneConfig(pads="compliant"))
    object_pose = settle_object(scene)
    pose = side_power_grasp(scene.hand, [object_pose[0, 3], object_pose[1, 3], scene.object_rest_height])
    result = PROTOCOLS.load("standard").run(scene, GraspCandidate(pose=pose, score=1.0), np.random.default_rng(0),
                                            deadline=time.monotonic() + 300, object_pose=object_pose, seed=0)
    assert result.status.value == "success", result.detail
    assert result.max_translation_m < 0.002, f"the can crept {1000 * result.max_translation_m:.1f} mm"
