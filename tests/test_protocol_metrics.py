"""Planned-contact metrics: the batched form (one call per plan) agrees with the per-trial form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from manigrasp.protocol.metrics import planned_metrics, planned_metrics_batch, radius_of_gyration


@pytest.fixture(scope="module")
def scene(box_scene):
    """The shared cube scene (conftest: a 5 cm cube of 0.3 kg and `parallel_jaw`)."""
    return box_scene.scene


def test_batched_planned_metrics_equal_the_single_ones(scene):
    rest = scene.object_rest_pose()
    center = rest[:3, 3]
    rng = np.random.default_rng(0)
    grasps = []
    for _ in range(12):  # two opposing contacts, tilted and offset at random
        offset = rng.normal(0, 0.01, 3)
        axis = rng.normal([0, 1, 0], 0.2)
        axis /= np.linalg.norm(axis)
        points = np.array([center + offset - 0.025 * axis, center + offset + 0.025 * axis])
        normals = np.array([axis, -axis]) + rng.normal(0, 0.1, (2, 3))
        grasps.append((points, normals / np.linalg.norm(normals, axis=1, keepdims=True)))
    grasps.append((np.zeros((0, 3)), np.zeros((0, 3))))  # no planned contacts: NaN metrics
    grasps.append((np.full((2, 3), np.nan), np.ones((2, 3))))  # non-finite: NaN metrics
    batch = planned_metrics_batch(scene, grasps, rest)
    scale = radius_of_gyration(scene)
    for (points, normals), got in zip(grasps[:12], batch, strict=False):
        want = planned_metrics(scene, points, normals, center, scale)
        assert got.n_contacts == want.n_contacts == 2
        assert got.force_closure == want.force_closure
        assert got.epsilon_l1 == pytest.approx(want.epsilon_l1, abs=1e-9)
        assert abs(got.min_friction - want.min_friction) <= 0.011 or got.min_friction == want.min_friction
    assert sum(m.force_closure for m in batch[:12]) >= 3  # the sample has grasps in closure: the test can fail
    assert all(math.isnan(m.epsilon_l1) for m in batch[12:])


def test_simulated_flat_pad_contacts_are_stored_in_closure_and_a_failed_hull_as_nan(monkeypatch):
    """The issue's drill grasp (two flat pads, eight soft contacts, as `simulated_metrics` reads them):
    force closure 1 with epsilon > 0, consistent with the LP; when the hull cannot be built at all
    (Qhull restricted to non-joggled options), both are NaN ("not computed"), never 0 ("no closure")."""
    from test_grasp_degenerate import DRILL_CENTER, DRILL_SCALE, drill_contacts

    from manigrasp.grasp import closure_margin
    from manigrasp.grasp.closure import EPSILON_TOLERANCE
    from manigrasp.protocol.metrics import contact_metrics

    contacts = drill_contacts()
    got = contact_metrics(contacts, DRILL_CENTER, DRILL_SCALE, min_friction=False)
    assert got.n_contacts == 8
    assert got.force_closure == 1.0
    margin = closure_margin(contacts, DRILL_CENTER, DRILL_SCALE)
    assert margin / np.sqrt(6) <= got.epsilon_l1 <= margin
    one_pad = contact_metrics(contacts[:4], DRILL_CENTER, DRILL_SCALE, min_friction=False)
    assert (one_pad.force_closure, one_pad.epsilon_l1) == (0.0, 0.0)  # computed: one pad cannot hold
    for m in (got, one_pad):
        assert m.force_closure == float(m.epsilon_l1 > EPSILON_TOLERANCE)
    monkeypatch.setattr("manigrasp.grasp.quality.QHULL_OPTIONS", ("Qx",))
    failed = contact_metrics(contacts, DRILL_CENTER, DRILL_SCALE, min_friction=False)
    assert failed.n_contacts == 8
    assert math.isnan(failed.force_closure) and math.isnan(failed.epsilon_l1)


@pytest.mark.parametrize("pads", ["compliant", "rigid"])
def test_planned_contacts_are_judged_as_the_simulation_judges_the_pads_contacts(box_asset, pads):
    """The jaws closed on the cube: the contacts MuJoCo made, given to `planned_metrics` as planned points and
    normals, score what `simulated_metrics` scores for them. Planned contacts were judged at the hand geoms'
    friction 0.5 while the compliant pads touch at their rubber's 1.0 (epsilon 0.21 against 0.42 here)."""
    from manigrasp.control import ImpedanceController, default_gains
    from manigrasp.protocol import settle_object
    from manigrasp.protocol.metrics import grasping_contact, simulated_metrics
    from manigrasp.sim import SceneConfig, build_scene, read_hand_contacts

    scene = build_scene("parallel_jaw", box_asset, SceneConfig(pads=pads))
    rest = settle_object(scene)
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[:3, 3] = rest[:3, 3]
    scene.reset(mount=pose, object_pose=rest, synergy=1.0)
    hold = ImpedanceController(scene.base, default_gains(scene.base))
    hold.set_target(pose)
    for _ in range(300):
        hold.apply()
        scene.step()
    contacts = read_hand_contacts(scene, "object")
    mu, _, gamma = grasping_contact(scene)
    assert len(contacts.friction) >= 4 and np.allclose(contacts.friction, mu)  # only the pads touch
    assert np.allclose(contacts.torsional_friction, gamma)
    # compliant: an element's 1 x 1.5 cm cell, mu mean(r) = 4.84 mm at mu 1 (tests/test_pads.py: closed form)
    assert (mu, round(gamma, 5)) == ((1.0, 0.00484) if pads == "compliant" else (0.5, 0.005))
    center, scale = scene.data.xipos[scene.object_body].copy(), radius_of_gyration(scene)
    simulated = simulated_metrics(scene, scale)
    planned = planned_metrics(scene, contacts.position, contacts.normal, center, scale)  # normals into the object
    assert simulated.force_closure == planned.force_closure == 1.0
    assert planned.epsilon_l1 == pytest.approx(simulated.epsilon_l1, rel=1e-9)
    (batched,) = planned_metrics_batch(scene, [(contacts.position, contacts.normal)], scene.object_pose())
    assert batched.epsilon_l1 == pytest.approx(simulated.epsilon_l1, rel=1e-6)


def test_planners_and_trials_draw_the_closure_line_at_the_same_epsilon():
    """Two antipodal soft fingers at mu 1e-10 have epsilon ~6.5e-11: the planners' metrics called that closure
    (epsilon > 0) where the stored metrics do not (epsilon > `EPSILON_TOLERANCE`); at mu 0.5 both say closure."""
    from manigrasp.grasp.closure import EPSILON_TOLERANCE
    from manigrasp.planners.metrics import ContactModel, grasp_metrics
    from manigrasp.protocol.metrics import closure_and_epsilon

    positions = np.array([[[0.03, 0.0, 0.0], [-0.03, 0.0, 0.0]]])
    normals = np.array([[[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]])
    for mu, closed in ((1e-10, False), (0.5, True)):
        got = grasp_metrics(positions, normals, np.zeros(3), 0.03, ContactModel(mu=mu, min_friction=False))
        assert (0.0 < got.epsilon_l1[0] < EPSILON_TOLERANCE) is not closed
        assert bool(got.force_closure[0]) is closed
        assert closure_and_epsilon(float(got.epsilon_l1[0]))[0] == float(closed)


@pytest.mark.parametrize("pads", ["compliant", "rigid"])
def test_the_compiled_grasping_surfaces_have_the_friction_the_planners_are_told(box_asset, pads):
    """`grasping_contact` reads the compiled scene; `planners.context.grasping_friction` predicts the same friction
    from the config, for every hand kind (pads, rubber fingertips, rigid)."""
    from manigrasp import hands
    from manigrasp.planners.context import grasping_friction
    from manigrasp.protocol.metrics import grasping_contact
    from manigrasp.sim import SceneConfig, build_scene

    config = SceneConfig(pads=pads)
    for name in ("parallel_jaw", "robotiq_2f85", "inspire_right", "allegro_right"):
        scene = build_scene(name, box_asset, config)
        assert grasping_contact(scene)[0] == grasping_friction(config, hands.load(name)), name


def test_a_candidates_contact_friction_must_give_one_row_per_contact():
    from manigrasp.planners.base import GraspCandidate
    from manigrasp.planners.run import candidate_defect

    pose, points = np.eye(4), np.array([[0.0, 0.03, 0.0], [0.0, -0.03, 0.0]])
    normals = np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]])
    good = GraspCandidate(pose, 1.0, contacts=points, contact_normals=normals,
                          contact_friction=np.array([[1.0, 0.004], [0.5, 0.005]]))
    assert candidate_defect(good) is None
    for bad in (np.array([[1.0, 0.004]]), np.array([[1.0, np.nan], [0.5, 0.005]]), np.array([[-1.0, 0.0]] * 2)):
        defect = candidate_defect(GraspCandidate(pose, 1.0, contacts=points, contact_normals=normals,
                                                 contact_friction=bad))
        assert defect is not None and defect.startswith("contact_friction")
