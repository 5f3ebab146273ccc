"""The hold margin of a two-jaw grasp: closed forms, agreement with the wrench-resistance LP, and the hammer."""

from __future__ import annotations

import numpy as np
import pytest

from manigrasp import hands, planners
from manigrasp.contact import ContactSet, ContactType
from manigrasp.grasp import resists_wrench
from manigrasp.objects import catalog
from manigrasp.planners.hold import GRAVITY, loads, required_grip
from manigrasp.protocol import PROTOCOLS, settle_object
from manigrasp.protocol.result import Status
from manigrasp.sim import build_scene

MU, GAMMA = 0.5, 0.005
WIDTH = 0.03  # [m]
P, Q = np.array([[-WIDTH / 2, 0.0, 0.0]]), np.array([[WIDTH / 2, 0.0, 0.0]])  # grasp line along x through 0


def test_weight_off_the_line_needs_the_torsion_closed_form():
    """Centre of mass d along y from a horizontal grasp line: each contact carries m g / 2 and half of m g d."""
    mass, d = 0.665, 0.04
    weight = loads(mass)[:1]
    need = mass * GRAVITY / 2 / MU
    expected = np.sqrt(need**2 + (mass * GRAVITY * d / (2 * GAMMA)) ** 2)
    assert required_grip(P, Q, np.array([0.0, d, 0.0]), weight, MU, GAMMA)[0] == pytest.approx(expected, rel=1e-4)


def test_a_torsion_per_pair_is_each_pairs_own_closed_form():
    """gamma given per pair (a pad's footprint scales it): each pair's grip is the closed form with its own."""
    mass, d = 0.665, 0.04
    gammas = np.array([GAMMA, 0.5 * GAMMA, 0.0])
    need = mass * GRAVITY / 2 / MU
    required = required_grip(np.repeat(P, 3, 0), np.repeat(Q, 3, 0), np.array([0.0, d, 0.0]), loads(mass)[:1], MU,
                             gammas)
    for got, gamma in zip(required[:2], gammas[:2], strict=True):
        assert got == pytest.approx(np.sqrt(need**2 + (mass * GRAVITY * d / (2 * gamma)) ** 2), rel=1e-4)
    assert required[2] > 1e6  # no torsion: the gravity torque about the line cannot be held


def test_a_grasp_through_the_centre_of_mass_needs_the_heaviest_load_over_the_friction():
    """Weight plus a downward perturbation (2 m g) over the two contacts' friction 2 mu: G = m g / mu."""
    mass = 0.3
    required = required_grip(P, Q, np.zeros(3), loads(mass, perturbation=1.0), MU, GAMMA)[0]
    assert required == pytest.approx(mass * GRAVITY / MU, rel=1e-4)
    assert required_grip(P, Q, np.zeros(3), loads(2 * mass), MU, GAMMA)[0] == pytest.approx(2 * required, rel=1e-4)


def test_a_tilted_normal_needs_more_grip():
    centre = np.array([0.0, 0.01, 0.0])
    straight = required_grip(P, Q, centre, loads(0.3), MU, GAMMA)[0]
    tilted = required_grip(P, Q, centre, loads(0.3), MU, GAMMA, tilt=np.array([[0.2, 0.0]]))[0]
    assert tilted > straight


def test_the_pads_pressure_takes_the_tipping_torque_of_a_thin_rim():
    """A bowl held by its 4 mm rim: the centre of mass R along the grasp line, so the weight tips it about the
    horizontal axis across the line. Point contacts take that with a friction couple 4 mm wide; pads whose
    centre of pressure can move e along the wall take 2 G e of it with their pressure (closed form below)."""
    mass, radius, width, e = 0.147, 0.08, 0.004, 0.005
    p, q = np.array([[-width / 2, 0.0, 0.0]]), np.array([[width / 2, 0.0, 0.0]])
    centre, weight = np.array([radius, 0.0, -0.02]), loads(mass)[:1]
    mg = mass * GRAVITY
    points = required_grip(p, q, centre, weight, MU, GAMMA)[0]
    assert points == pytest.approx(mg * (1 + 2 * radius / width) / (2 * MU), rel=1e-4)
    # across = y: the torque R m g about y is taken by pressure moving along z (support[..., 1])
    support = np.array([[[0.0, e], [0.0, e]]])
    pads = required_grip(p, q, centre, weight, MU, GAMMA, support=support, across=np.array([[0.0, 1.0, 0.0]]))[0]
    # 2 mu G = m g + 2 (R m g - 2 G e) / w while 2 G e < R m g
    expected = mg * (1 + 2 * radius / width) / (2 * MU + 4 * e / width)
    assert expected < radius * mg / (2 * e)
    assert pads == pytest.approx(expected, rel=1e-4)
    # support along the other axis (a pad on a strip across the wall) takes none of it
    strip = required_grip(p, q, centre, weight, MU, GAMMA, support=support[:, :, ::-1],
                          across=np.array([[0.0, 1.0, 0.0]]))[0]
    assert strip == pytest.approx(points, rel=1e-4)


@pytest.mark.parametrize("d", [0.0, 0.01, 0.03, 0.06])
def test_the_closed_form_agrees_with_the_wrench_resistance_lp(d):
    """The LP (linearised, inscribed cones) cannot hold below the exact elliptic requirement, and holds at twice it
    (its linear mix of friction and torsion costs at most a factor 2, its 8-edge polygon cos(pi/8))."""
    mass, centre = 0.4, np.array([0.0, d, 0.005])
    contacts = ContactSet(positions=np.vstack([P, Q])[None], normals=np.array([[[1.0, 0, 0], [-1.0, 0, 0]]]), mu=MU,
                          kind=ContactType.SOFT_FINGER, gamma=GAMMA)
    for force in loads(mass):
        if not np.any(force):  # the weight and an upward push of m g cancel
            continue
        wrench = np.concatenate([force, np.zeros(3)])  # at the centre of mass
        required = required_grip(P, Q, centre, force[None], MU, GAMMA)[0]
        assert not resists_wrench(contacts, centre, 0.05, wrench, 0.98 * required).resisted
        assert resists_wrench(contacts, centre, 0.05, wrench, 2.0 / np.cos(np.pi / 8) * required).resisted


@pytest.fixture(scope="module")
def hammer():
    jaw = hands.load("parallel_jaw")
    asset = catalog.build(catalog.shipped("048_hammer")).asset
    scene = build_scene(jaw, asset)
    rest = settle_object(scene)
    obs = planners.Observation.from_asset(asset, rest)
    return jaw, scene, rest, obs, planners.plan(planners.load("antipodal"), obs, jaw, 5, np.random.default_rng(0))


def test_hammer_grasps_are_ranked_near_the_centre_of_mass(hammer):
    """The hammer's centre of mass is by its head; grasps far from it turn in the jaws (m g d > 2 gamma G)."""
    _, _, _, obs, result = hammer
    for c in result.candidates[:3]:
        p, q = c.contacts
        axis = (q - p) / np.linalg.norm(q - p)
        d = np.linalg.norm(np.cross(obs.center_of_mass - p, axis))
        assert d < 0.025, f"grasp line {1000 * d:.0f} mm from the centre of mass"


def test_the_best_hammer_grasps_hold_in_simulation(hammer):
    _, scene, rest, _, result = hammer
    standard = PROTOCOLS.load("standard")
    statuses = [standard.run(scene, c, np.random.default_rng(i), object_pose=rest).status
                for i, c in enumerate(result.candidates[:3])]
    assert statuses == [Status.SUCCESS] * 3, statuses
