"""`manigrasp.hands.capacity`: the load a protocol puts on a frictional grasp, against textbook values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from manigrasp.errors import ConfigError
from manigrasp.hands import capacity as cap

G = cap.STANDARD_GRAVITY


def test_standard_load_is_weight_plus_the_downward_perturbation() -> None:
    assert cap.frictional_load(1.0) == pytest.approx(2 * G)
    assert cap.frictional_load(0.5, perturb_multiple=0.0) == pytest.approx(0.5 * G)  # a plain lift


def test_six_direction_load_is_its_push_without_gravity() -> None:
    # DexGraspBench's push: 10 N per kg, no weight on top of it
    assert cap.frictional_load(0.349, perturb_multiple=10.0 / G, gravity=False) == pytest.approx(10 * 0.349)


def test_load_broadcasts_over_masses() -> None:
    np.testing.assert_allclose(cap.frictional_load(np.array([0.1, 0.2, 0.4])), 2 * G * np.array([0.1, 0.2, 0.4]))


def test_required_grip_of_the_soup_can_at_mu_half() -> None:
    # two pads, each pushing F: mu * 2F >= 2 m g, so F >= m g / mu = 2 m g at mu 0.5
    load = cap.frictional_load(0.349)
    assert cap.required_grip(load, 0.5) == pytest.approx(2 * 0.349 * G)
    assert cap.required_normal_force(load, 0.5) == pytest.approx(4 * 0.349 * G)


def test_max_mass_inverts_required_grip() -> None:
    # 10 N at mu 0.5 holds 10 / (2 g) = 0.51 kg: the sugar box's 0.514 kg is just past it
    heaviest = float(cap.max_mass(10.0, 0.5))
    assert heaviest == pytest.approx(10.0 / (2 * G))
    assert heaviest < 0.514
    assert cap.required_grip(cap.frictional_load(heaviest), 0.5) == pytest.approx(10.0)
    assert float(cap.max_mass(10.0, 0.5, squeeze_ratio=4.0)) == pytest.approx(2 * heaviest)


def test_no_tilt_on_objects_at_least_as_tall_as_the_fingertip() -> None:
    assert float(cap.edge_tilt(0.02, 0.012)) == 0.0
    assert float(cap.edge_tilt(0.012, 0.012)) == 0.0


def test_edge_tilt_of_a_fingertip_on_a_low_object() -> None:
    # a sphere of radius r resting on the table touches the top edge at height r/2: sin(theta) = (r - h) / r = 1/2
    assert float(cap.edge_tilt(0.006, 0.012)) == pytest.approx(math.pi / 6)


def test_the_friction_per_normal_force_vanishes_at_the_cone_angle() -> None:
    assert float(cap.friction_per_normal_force(0.5)) == pytest.approx(0.5)
    assert float(cap.friction_per_normal_force(0.5, math.atan(0.5))) == pytest.approx(0.0, abs=1e-12)
    assert float(cap.friction_per_normal_force(0.5, 0.6)) == 0.0  # past the cone: clipped, the squeeze pushes it out
    # 30 degrees at mu 1: cos 30 - sin 30
    assert float(cap.friction_per_normal_force(1.0, math.pi / 6)) == pytest.approx(math.sqrt(3) / 2 - 0.5)


def test_the_friction_per_squeeze_is_the_cone_left_beyond_the_tilt() -> None:
    assert float(cap.friction_per_squeeze(0.5)) == pytest.approx(0.5)
    assert float(cap.friction_per_squeeze(1.0, math.pi / 6)) == pytest.approx(math.tan(math.pi / 12))  # 45 - 30 deg
    assert float(cap.friction_per_squeeze(0.5, math.atan(0.5))) == 0.0
    assert float(cap.friction_per_squeeze(0.5, 0.6)) == 0.0


@pytest.mark.parametrize("mu", [0.3, 0.5, 1.0])
@pytest.mark.parametrize("tilt", [0.0, 0.1, 0.25])  # within every cone (atan 0.3 = 0.29)
def test_both_frictions_are_the_cone_edge_force_measured_against_the_normal_and_the_squeeze(mu, tilt) -> None:
    """A contact force at its friction cone's edge, per N of normal force (normal tilted by `tilt` from the squeeze
    line x, its friction turned against the load along z): its load component per N of normal force is
    `friction_per_normal_force`, per N of its squeeze component `friction_per_squeeze` (the same at no tilt)."""
    normal = np.array([math.cos(tilt), 0.0, -math.sin(tilt)])  # pushes along x and down
    tangent = np.array([math.sin(tilt), 0.0, math.cos(tilt)])  # up the object's face
    force = normal + mu * tangent
    assert float(cap.friction_per_normal_force(mu, tilt)) == pytest.approx(force[2], abs=1e-12)
    assert float(cap.friction_per_squeeze(mu, tilt)) == pytest.approx(force[2] / force[0], abs=1e-12)


def test_zero_effective_friction_needs_infinite_force() -> None:
    assert math.isinf(float(cap.required_normal_force(1.0, 0.0)))


def test_min_width_of_a_rotated_rectangle() -> None:
    angle = math.radians(30)
    rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    corners = np.array([[0, 0], [0.1, 0], [0.1, 0.04], [0, 0.04]]) @ rot.T + [0.3, -0.2]
    width, direction = cap.min_width_2d(np.vstack([corners, corners.mean(axis=0)]))
    assert width == pytest.approx(0.04)
    assert abs(direction @ (rot @ [0.0, 1.0])) == pytest.approx(1.0)


def test_min_width_of_a_triangle_and_a_circle() -> None:
    side = 0.05
    triangle = np.array([[0, 0], [side, 0], [side / 2, side * math.sqrt(3) / 2]])
    assert cap.min_width_2d(triangle)[0] == pytest.approx(side * math.sqrt(3) / 2)
    theta = np.linspace(0, 2 * math.pi, 360, endpoint=False)
    circle = 0.033 * np.column_stack([np.cos(theta), np.sin(theta)])
    assert cap.min_width_2d(circle)[0] == pytest.approx(0.066, rel=1e-4)


def test_min_width_refuses_collinear_and_malformed_points() -> None:
    with pytest.raises(ConfigError, match="collinear"):
        cap.min_width_2d(np.array([[0, 0], [1, 1], [2, 2]]))
    with pytest.raises(ConfigError, match="points"):
        cap.min_width_2d(np.zeros((5, 3)))


def test_check_hold_takes_the_first_criterion_that_fails() -> None:
    need = 4 * 0.349 * G
    assert cap.check_hold(False, 0.1, 0.349, 0.006, 1e3, 0.5).verdict == "does not fit"
    # 2 mm tall, 12 mm fingertip: the edge normal is far past the cone at mu 0.5
    assert cap.check_hold(True, 0.002, 0.05, 0.012, 1e3, 0.5).verdict == "too thin"
    held = cap.check_hold(True, 0.1, 0.349, 0.006, need, 0.5)
    assert held.verdict == "holdable" and held.margin == pytest.approx(1.0)
    short = cap.check_hold(True, 0.1, 0.349, 0.006, 0.9 * need, 0.5)
    assert short.verdict == "too heavy" and short.margin == pytest.approx(0.9)
    assert short.required == pytest.approx(need) and short.load == pytest.approx(2 * 0.349 * G)


def test_rubber_halves_the_required_force() -> None:
    rigid = cap.check_hold(True, 0.1, 0.5, 0.006, 15.0, 0.5)
    rubber = cap.check_hold(True, 0.1, 0.5, 0.006, 15.0, 1.0)
    assert rubber.required == pytest.approx(rigid.required / 2)
    assert (rigid.verdict, rubber.verdict) == ("too heavy", "holdable")


@pytest.mark.parametrize(("call", "match"), [
    (lambda: cap.frictional_load(-1.0), "mass"),
    (lambda: cap.frictional_load(1.0, perturb_multiple=-1.0), "perturb_multiple"),
    (lambda: cap.friction_per_normal_force(0.0), "mu"),
    (lambda: cap.friction_per_squeeze(-0.1), "mu"),
    (lambda: cap.edge_tilt(0.01, 0.0), "tip_radius"),
    (lambda: cap.required_grip(1.0, 0.5, squeeze_ratio=0.0), "squeeze_ratio"),
])
def test_bad_input_is_a_one_line_error(call, match) -> None:  # noqa: ANN001
    with pytest.raises(ConfigError, match=match):
        call()


@pytest.mark.parametrize(("factor", "dropped_at"), [(1.5, None), (0.85, "-z"), (0.6, "+x")])
def test_the_required_grip_separates_holding_from_dropping_in_closed_loop(box_scene, factor, dropped_at) -> None:  # noqa: ANN001
    """The 0.3 kg cube in the parallel jaw (two pads of the scene's pad friction mu: the compliant pads' rubber,
    1.0, by default) under `standard`: the capacity model asks for a grip of F = 2 m g / (2 mu), so friction
    2 mu F carries 2 m g. At 1.5 F the grasp passes. At 0.85 F
    (1.7 m g) it carries the weight with a sideways m g (sqrt(2) m g) and drops only under the downward
    perturbation, the model's worst direction; at 0.6 F (1.2 m g) already under the first sideways one."""
    from manigrasp.protocol import PROTOCOLS, Status

    config = box_scene.scene.config
    mu = config.pad_friction if config.pads == "compliant" else config.hand_friction
    need = float(cap.required_grip(cap.frictional_load(box_scene.asset.mass), mu))
    assert need == pytest.approx(2 * 0.3 * G / (2 * mu))
    protocol = PROTOCOLS.load("standard", grip_force=factor * need)
    result = protocol.run(box_scene.scene, box_scene.top_grasp, np.random.default_rng(0), None,
                          object_pose=box_scene.rest, seed=0)
    if dropped_at is None:
        assert result.status is Status.SUCCESS, result.detail
    else:
        assert result.status is Status.DROPPED_PERTURB, result.detail
        assert result.perturb_direction == dropped_at
