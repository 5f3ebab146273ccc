"""Helpers several test modules share (a plain module, not a test module: pytest collects nothing here).

The fixtures built from them (the cube and its scene, the tall box and its tabletop) are in conftest.py.
"""

from __future__ import annotations

import numpy as np

BOX_EDGE = 0.05  # [m] the shared cube's edge
BOX_MASS = 0.3  # [kg]
TALL_BOX = (0.05, 0.03, 0.12)  # [m] the planners' box: x and y fit the 8 cm jaw, z does not


def assert_collision_free(obs, hand, candidates) -> None:
    """Independent check: a fresh standard scene (no planner settings), open hand at grasp and pre-grasp."""
    from manigrasp.sim import build_scene, read_hand_contacts

    scene = build_scene(hand, obs.asset)
    for i, c in enumerate(candidates):
        for label, pose in (("grasp", c.pose), ("pre-grasp", c.pregrasp_pose)):
            scene.reset(mount=pose, object_pose=obs.object_pose)
            touching = read_hand_contacts(scene, "any")
            assert len(touching) == 0, f"candidate {i} touches something at its {label} pose"


def fused(table, setup, seed: int = 0):
    """The fused observation (`perception.fusion.observe_views`) of `table` by camera `setup`, seeded."""
    from manigrasp.bench.observe import view_rngs
    from manigrasp.perception.fusion import observe_views

    return observe_views(table, setup.cameras(np.zeros(2)), view_rngs(seed, "box", setup.views), setup.perception())


def top_grasp(rest: np.ndarray):
    """The cube's top grasp (a `protocol.Grasp`): TCP at its centre, approach down, closing along -y, with its
    two planned contacts."""
    from manigrasp.protocol import Grasp

    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[:3, 3] = rest[:3, 3]
    contacts = rest[:3, 3] + np.array([[0.0, BOX_EDGE / 2, 0.0], [0.0, -BOX_EDGE / 2, 0.0]])
    return Grasp(pose=pose, contacts=contacts, contact_normals=np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]]))


def drive(scene, observer, rest: np.ndarray, seconds: float = 1.0):
    """A scripted trial on the cube: hand at the grasp, close, "lift" (phase only), push +x; calls
    `observer` like a protocol and returns a `TrialResult` (dropped_perturb)."""
    from manigrasp.protocol import Status, TrialResult

    grasp = top_grasp(rest)
    observer.on_start(scene, grasp, rest)
    observer.on_phase(scene, "pregrasp")
    scene.reset(mount=grasp.pose, object_pose=rest, synergy=0.0)
    dt, n = scene.model.opt.timestep, int(round(seconds / scene.model.opt.timestep))
    phases = {0: ("close", ""), n // 2: ("lift", ""), 3 * n // 4: ("perturb", "+x")}
    next_sample = 0.0
    for i in range(n):
        if i in phases:
            observer.on_phase(scene, *phases[i])
        if i == 3 * n // 4:
            scene.data.xfrc_applied[scene.object_body, :3] = [BOX_MASS * 9.81, 0.0, 0.0]
        scene.set_synergy(min(1.0, 4.0 * i * dt))
        if scene.time >= next_sample - 1e-12:
            observer.on_sample(scene)
            next_sample += observer.sample_period_s
        scene.step()
    scene.data.xfrc_applied[:] = 0.0
    result = TrialResult(Status.DROPPED_PERTURB, detail="+x", last_phase="lift", sim_steps=n, sim_time_s=n * dt)
    observer.on_end(scene, result)
    return result
