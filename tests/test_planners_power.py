"""The power planner's kinematic closing on the dexterous hands: the free closing path and candidates."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import trimesh

from manigrasp import hands, planners
from manigrasp.errors import ConfigError
from manigrasp.objects import build_object
from manigrasp.planners.closing import Closure, FingerSweep, closing_path
from manigrasp.planners.collision import HandProbe
from manigrasp.planners.wrap import finger_inward, palm_gaps, palm_geoms, toward_palm

DEXTEROUS = [n for n in hands.names() if hands.load(n).kind == "dexterous"]


@pytest.mark.parametrize("name", DEXTEROUS)
def test_closing_path_stays_within_the_joint_stops_and_closes_every_finger(name: str) -> None:
    """The free close runs to its end with the palm filtered from its own fingers and stiff stops.

    A root welded to the world let the palm push the Fourier fingers' proximal joints to -0.36 rad for the
    whole path (the planner then found at most one finger on any object); soft stops let the tendons push
    joints up to 1.2 rad through them; a fixed 1.5 s close stopped the fingers half-way.
    """
    hand = hands.load(name)
    spec = hand.build_spec()
    path = closing_path(hand, 16)
    low = np.array([spec.joint(j).range[0] for j in path.joints])
    high = np.array([spec.joint(j).range[1] for j in path.joints])
    assert np.all(path.shapes >= low - 0.01) and np.all(path.shapes <= high + 0.01), path.shapes[-1]
    if name.startswith("allegro"):  # three fingers and a thumb; joints named by number
        from manigrasp.hands import allegro

        leads = [allegro.BENDING[f][0] for f in allegro.FINGERS]
    else:
        leads = [j for j in path.joints if "proximal" in j.lower() and "thumb" not in j.lower()]
    moved = {j: path.shapes[-1, path.joints.index(j)] - path.shapes[0, path.joints.index(j)] for j in leads}
    assert len(moved) == (3 if name.startswith("allegro") else 4) and all(v > 0.3 for v in moved.values()), moved
    # The path reaches the hand's closed shape: some distal joint ends near its stop.
    thumb = ({"joint_12.0", "joint_13.0", "joint_14.0", "joint_15.0"} if name.startswith("allegro")
             else {j for j in path.joints if "thumb" in j.lower()})
    distal = [i for i, j in enumerate(path.joints) if j not in leads and j not in thumb]
    assert np.max(path.shapes[-1, distal] - high[distal]) > -0.05


@pytest.mark.parametrize("name", DEXTEROUS)
@pytest.mark.slow
def test_power_wraps_a_can_with_at_least_three_fingers(name: str) -> None:
    asset = build_object(trimesh.creation.cylinder(0.033, 0.10, sections=48), name="power_test_can", mass=0.35).asset
    obs = planners.Observation.from_asset(asset)
    result = planners.plan(planners.load("power"), obs, hands.load(name), 5, np.random.default_rng(0))
    assert len(result.candidates) == 5
    touching = [len(c.contacts) for c in result.candidates]  # one planned contact per touching finger geom
    assert min(touching) >= 3, touching


def _can_observation() -> planners.Observation:
    asset = build_object(trimesh.creation.cylinder(0.033, 0.10, sections=48), name="power_test_can", mass=0.35).asset
    return planners.Observation.from_asset(asset)


def test_palm_term_puts_the_palm_against_the_can_with_the_can_in_front_of_it() -> None:
    """With the palm term weighted, the best candidate's open palm is within 5 mm of the can (5.7 mm
    unweighted), and the can's centre lies in front of the palm's nearest point along the approach
    (between the palm and the fingers)."""
    obs, hand = _can_observation(), hands.load("fourier_right")
    planner = planners.load("power", palm_weight=0.6)
    best = planners.plan(planner, obs, hand, 3, np.random.default_rng(0)).candidates[0]
    probe = HandProbe(hand, obs)
    assert palm_gaps(probe, best.pose[None])[0] < 0.005
    model, data = probe.scene.model, probe.scene.data
    fromto, nearest = np.zeros(6), (np.inf, None)
    for g in palm_geoms(probe):
        for o in probe.scene.object_geoms:
            d = mujoco.mj_geomDistance(model, data, int(g), int(o), 0.1, fromto)
            nearest = min(nearest, (d, fromto[:3].copy()), key=lambda x: x[0])
    palm_point = nearest[1] - probe.shift[:3, 3]
    assert (obs.center_of_mass - palm_point) @ best.pose[:3, 2] > 0.02  # the can's radius is 33 mm


def test_palm_weight_is_validated_by_message() -> None:
    with pytest.raises(ConfigError, match="palm_weight"):
        planners.load("power", palm_weight=1.5)
    with pytest.raises(ConfigError, match="min_inward"):
        planners.load("power", min_inward=float("nan"))


def test_toward_palm_is_plus_one_for_contacts_pushing_into_the_palm() -> None:
    approach = np.array([0.0, 0.0, 1.0])
    assert toward_palm(np.tile(-approach, (3, 1)), approach) == pytest.approx(1.0)
    assert toward_palm(np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]), approach) == pytest.approx(0.0)


def test_finger_inward_is_the_least_finger_mean_push_toward_the_palm() -> None:
    approach = np.array([0.0, 0.0, 1.0])
    normals = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    closure = Closure(positions=np.zeros((4, 3)), normals=normals, fingers=np.array([0, 0, 1, 2]), n_fingers=3)
    assert finger_inward(closure, approach) == pytest.approx(-1.0)  # finger 2 pushes the object out of the hand
    assert finger_inward(Closure(np.zeros((2, 3)), normals[:2], np.array([0, 0]), 1), approach) == pytest.approx(0.0)
    assert np.isnan(finger_inward(Closure(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int), 0), approach))


@pytest.mark.slow
def test_power_grasps_of_a_ball_on_the_allegro_push_it_into_the_hand() -> None:
    """A 65 mm ball on the table: the Allegro's opposed thumb stops the open hand 45-65 mm off the ball's top, and
    its 3-finger closures touch the ball with the fingertips on its palm-side half, pushing it out of the hand
    (the tennis ball 0/10 under `standard`). The planner ranks closures that wrap the ball first: every one of
    its candidates (there are enough here) has each finger pushing the ball toward the palm or across it."""
    try:
        hand = hands.load("allegro_right")
    except Exception as exc:  # the optional `allegro` extra
        pytest.skip(f"allegro_right unavailable: {exc}")
    asset = build_object(trimesh.creation.icosphere(3, radius=0.0325), name="power_test_ball", mass=0.058).asset
    obs = planners.Observation.from_asset(asset)
    planner = planners.load("power")
    candidates = planners.plan(planner, obs, hand, 5, np.random.default_rng(0)).candidates
    assert len(candidates) == 5
    probe = HandProbe(hand, obs, planner.clearance)
    sweep = FingerSweep(probe, closing_path(hand, planner.closing_steps))
    pos, quat = probe.roots(np.array([c.pose for c in candidates]))
    inward = [finger_inward(sweep.close(pos[i], quat[i]), c.pose[:3, 2]) for i, c in enumerate(candidates)]
    assert min(inward) >= 0.0, inward


@pytest.mark.slow
def test_power_contacts_carry_the_friction_of_the_link_they_touch_with() -> None:
    """The power planner's contacts lie on fingertips (rubber, 1.0 with compliant pads) and on phalanges or the
    palm (0.5): each candidate says which (`contact_friction`), and the stored planned metrics use it, so a
    phalanx contact is no longer judged at the fingertips' 1.0."""
    from manigrasp.contact import Contact
    from manigrasp.protocol.metrics import contact_metrics, planned_metrics, planned_metrics_batch
    from manigrasp.sim import build_scene

    obs = _can_observation()
    result = planners.plan(planners.load("power"), obs, hands.load("inspire_right"), 5, np.random.default_rng(0))
    rows = np.concatenate([c.contact_friction for c in result.candidates])
    assert all(c.contact_friction.shape == (len(c.contacts), 2) for c in result.candidates)
    assert set(np.round(rows[:, 0], 3)) == {0.5, 1.0}  # both kinds of link touch the can
    candidate = next(c for c in result.candidates if len(set(c.contact_friction[:, 0])) == 2)
    scene = build_scene("inspire_right", obs.asset)
    center, scale = obs.center_of_mass, 0.05
    got = planned_metrics(scene, candidate.contacts, candidate.contact_normals, center, scale,
                          friction=candidate.contact_friction)
    want = contact_metrics([Contact(p, n, mu, "soft_finger", gamma) for p, n, (mu, gamma) in
                            zip(candidate.contacts, candidate.contact_normals, candidate.contact_friction,
                                strict=True)], center, scale)
    assert got.epsilon_l1 == pytest.approx(want.epsilon_l1, rel=1e-9)
    mixed = [c for c in result.candidates if len(set(c.contact_friction[:, 0])) == 2]
    own = [planned_metrics(scene, c.contacts, c.contact_normals, center, scale, friction=c.contact_friction)
           for c in mixed]
    rubber = [planned_metrics(scene, c.contacts, c.contact_normals, center, scale) for c in mixed]
    assert all(o.epsilon_l1 <= r.epsilon_l1 + 1e-12 for o, r in zip(own, rubber, strict=True))
    assert any(o.epsilon_l1 < r.epsilon_l1 - 1e-6 for o, r in zip(own, rubber, strict=True))
    (batched,) = planned_metrics_batch(scene, [(candidate.contacts, candidate.contact_normals,
                                                candidate.contact_friction)], obs.object_pose, scale)
    assert batched.epsilon_l1 == pytest.approx(got.epsilon_l1, rel=1e-6)
