"""Grips that hold: how far a hand-placed can creeps in each dexterous hand, with and without `FingerHold`.

For each dexterous hand and each `finger_hold_gain` (0 = off; 40, the protocols' default), a 66 mm x 12 cm,
0.35 kg can standing on the table is grasped by hand (side power grasp at mid-height, can axis across the
palm, thumb side up) and run through the `standard` protocol (close to half the hand's maximum grip force,
lift 10 cm, hold 0.5 s, six 1 x m g perturbations). Printed per hand x gain: the status, the largest
displacement [mm] and rotation [deg] of the can in the hand over the whole trial, the grip force [N].
`--adaptive` also runs the five-finger hands with adaptive (uncoupled) fingers, as they were before the
fingers' joints were coupled. Measured (2 Dec 2026, the grip loop's closing reach and inspire_left's thumb
mirrored from the right's): creep at gains 0 / 20 / 40: inspire_right 19.5 / 2.4 / 1.5 mm, fourier_right
12.0 / 1.5 / 1.2 mm, allegro_right 1.0 / 1.4 / 1.4 mm, inspire_left 19.5 / 2.7 / 1.8 mm, fourier_left
12.3 / 1.4 / 1.1 mm, allegro_left 0.9 / 1.2 / 1.2 mm, every trial a success (the Allegro's fingers held per
finger, without a force floor: `manigrasp.control.hold`; with the floor on every joint it crept 1.2 and 1.0 mm).
With the Allegro's distal collision boxes trimmed to its link meshes (4 Dec 2026; the can is pressed into the
palm, so `finger_hold: fingertips` keeps the floor on every joint): allegro_right 1.98 / - / 1.39 mm, allegro_left
1.40 / - / 1.27 mm at gains 0 / 40.
(With robosuite's own left thumb,
inspire_left crept 2.4 mm at 40: its thumb flexes in a plane tilted 6.5 deg from the right's mirror image.)

    .venv/bin/python benchmarks/bench_grip_hold.py --hands inspire_right fourier_right allegro_right \
        inspire_left fourier_left allegro_left
    .venv/bin/python benchmarks/bench_grip_hold.py --hands inspire_right --gains 0 40 --adaptive

`--run RUN_DIR` instead replays the stored trials of a `manigrasp bench` run (`--only` filters their ids) and splits
the object's turn in the hand from the start of the lift to the first perturbation into what the fingers carried and
what slipped: the rotation of the contact points on the fingers (each contact's point on its finger link at the start
of the lift, seen in the hand frame; their best-fit rotation), the largest slip of a contact (its point on the object
against its point on the finger) [mm], and the largest motion of a hand joint [rad]. `--finger-hold MODE` replays with
the protocol's `finger_hold` set to MODE: "floor" (every held servo pushes on with the force floor), "joints" (a
finger with several closing servos held in its joint configuration, no floor), "fingertips" ("joints" for the fingers
of a grasp the palm does not touch that touch with their distal phalanx only, or not at all) or "balanced" (the default
since 4 Dec 2026: as "fingertips", the held fingers pressing least-friction forces; `control.hold`); without it, the
run's own parameters. Measured (2 Dec 2026; RUN: tomato soup can, potted meat can, mug, banana x
allegro_right, inspire_right x dexopt x 5 grasps, `standard` with grip_force 10, seed 0, planned at fd0aae5):
allegro_right, floor on every joint (the default then, `--finger-hold floor`): 12/20, the 5 `dropped_perturb` turned
8.7 deg (median), 4.8 deg of it carried by the fingers, largest slip 4.5 mm, largest joint motion 0.116 rad (the 12
successes: 1.3 deg, 0.8 deg, 1.6 mm, 0.022 rad); held per finger: 15/20, the 2 drops 2.1 deg, 0.5 deg, 2.6 mm, 0.028
rad (successes 1.5 deg, 0.6 deg, 1.6 mm, 0.008 rad); the 3 banana grasps slip in the lift either way (turn 15-18 deg,
largest slip up to 22 mm: squeezed out). inspire_right 17/20 either way (one closing actuator per finger). The same
planner at seed 1 on mustard bottle, tennis ball, sugar box, potted meat can, mug and tomato soup can: 10/30 -> 16/30.
Held per finger for every grasp (`joints`) costs the power planner's wraps (allegro_right, 7 dexterous objects x 10,
`standard` at 10 N, seed 0: power 19 -> 11/70, the soup can 8 -> 1/10; dexopt 32 -> 37/70): hence the default
`fingertips`, which holds by joints only the fingertip contacts of a grasp the palm does not touch.

    .venv/bin/python benchmarks/bench_grip_hold.py --run RUN --only allegro_right [--finger-hold joints]
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np
import trimesh

from manigrasp import hands
from manigrasp.geometry import relative_pose
from manigrasp.hands.placement import side_power_grasp
from manigrasp.objects import build_object
from manigrasp.planners.base import GraspCandidate
from manigrasp.protocol import PROTOCOLS, settle_object
from manigrasp.protocol.execution import FINGER_HOLDS
from manigrasp.protocol.result import Phase
from manigrasp.sim import build_scene, read_hand_contacts


def _pose(data, body: int) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = data.xmat[body].reshape(3, 3), data.xpos[body]
    return out


def _angle_deg(rot: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(rot) - 1.0) / 2.0, -1.0, 1.0))))


def _fit_rotation(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """The rotation that best maps the points `before` (n, 3) onto `after` about their centroids (Kabsch)."""
    u, _, vt = np.linalg.svd((before - before.mean(0)).T @ (after - after.mean(0)))
    return vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))]) @ u.T


class TurnSplit:
    """Observer: at the start of the lift, each hand-object contact's point on the object and on its hand body;
    at the first perturbation (or the end), the object's turn in the hand, the turn of the contact points on the
    fingers, the largest slip and the largest hand joint motion since."""

    sample_period_s = float("inf")

    def __init__(self) -> None:
        self.start: dict | None = None
        self.split: dict | None = None

    def on_start(self, scene, grasp, object_pose) -> None:  # noqa: D102
        pass

    def on_sample(self, scene) -> None:  # noqa: D102
        pass

    def on_phase(self, scene, phase, detail: str = "") -> None:  # noqa: D102
        if phase == Phase.LIFT and self.start is None:
            self._begin(scene)
        elif phase == Phase.PERTURB and self.split is None and self.start is not None:
            self.split = self._measure(scene)

    def on_end(self, scene, result) -> None:  # noqa: D102
        if self.split is None and self.start is not None:
            self.split = self._measure(scene)

    def _joints(self, scene) -> np.ndarray:
        """The angles [rad] of the hand's own hinges (not the floating base's), whatever drives them (joint
        servos or tendons)."""
        m = scene.model
        adr = m.jnt_qposadr[np.isin(m.jnt_bodyid, scene.hand_bodies) & (m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE)]
        return scene.data.qpos[adr[~np.isin(adr, scene.base_qpos)]].copy()

    def _begin(self, scene) -> None:
        d = scene.data
        c = read_hand_contacts(scene, "object")
        keep = c.normal_force > 0.05
        obj, points, bodies = _pose(d, scene.object_body), c.position[keep], c.hand_body[keep]
        self.start = dict(
            in_hand=relative_pose(scene.tcp_pose(), obj), bodies=bodies,
            on_object=[(np.linalg.inv(obj) @ np.r_[p, 1.0])[:3] for p in points],
            on_finger=[(np.linalg.inv(_pose(d, b)) @ np.r_[p, 1.0])[:3] for p, b in zip(points, bodies, strict=True)],
            joints=self._joints(scene))

    def _measure(self, scene) -> dict:
        d, s = scene.data, self.start
        hand_inv = np.linalg.inv(scene.tcp_pose())
        in_hand = hand_inv @ _pose(d, scene.object_body)
        out = dict(turn=_angle_deg(s["in_hand"][:3, :3].T @ in_hand[:3, :3]), carried=0.0, slip=0.0, joint=0.0)
        if len(s["bodies"]):
            was = np.array([(s["in_hand"] @ np.r_[p, 1.0])[:3] for p in s["on_object"]])
            on_object = np.array([(in_hand @ np.r_[p, 1.0])[:3] for p in s["on_object"]])
            on_finger = np.array([(hand_inv @ _pose(d, b) @ np.r_[p, 1.0])[:3]
                                  for p, b in zip(s["on_finger"], s["bodies"], strict=True)])
            out["carried"] = _angle_deg(_fit_rotation(was, on_finger)) if len(was) >= 2 else 0.0
            out["slip"] = 1000.0 * float(np.linalg.norm(on_object - on_finger, axis=1).max())
        if len(s["joints"]):
            out["joint"] = float(np.abs(self._joints(scene) - s["joints"]).max())
        return out


def replay_run(run_dir: Path, only: str, finger_hold: str | None) -> None:
    """`--run`: the turn of each stored trial's object in the hand, split (see the module docstring)."""
    from manigrasp.bench.replay import find_trial, stored_grasp, stored_trials
    from manigrasp.bench.worker import scene_for

    rows = []
    print(f"{'trial':64s} {'status':16s} {'turn':>5s} {'carried':>7s} {'slip mm':>7s} {'joint rad':>9s}")
    for trial_id in sorted(t for t in stored_trials(run_dir) if only in t):
        trial = find_trial(run_dir, trial_id)
        scene = scene_for(trial.group)
        object_pose = settle_object(scene)
        params = dict(trial.group.protocol.params)
        if finger_hold is not None:
            params["finger_hold"] = finger_hold
        protocol = PROTOCOLS.load(trial.group.protocol.name, **params)
        seed = trial.group.trial_seed(trial.index)
        watch = TurnSplit()
        result = protocol.run(scene, stored_grasp(trial.result), np.random.default_rng(seed),
                              deadline=time.monotonic() + 600, object_pose=object_pose, observer=watch, seed=seed)
        split = watch.split or dict(turn=np.nan, carried=np.nan, slip=np.nan, joint=np.nan)
        rows.append((result.status.value, split))
        print(f"{trial_id:64s} {result.status.value:16s} {split['turn']:5.1f} {split['carried']:7.1f} "
              f"{split['slip']:7.1f} {split['joint']:9.3f}", flush=True)
    for status in sorted({r[0] for r in rows}):
        got = [r[1] for r in rows if r[0] == status]
        med = {k: float(np.nanmedian([g[k] for g in got])) for k in ("turn", "carried", "slip", "joint")}
        print(f"{status:16s} {len(got):3d} of {len(rows)}  median turn {med['turn']:.1f} deg, carried by the "
              f"fingers {med['carried']:.1f} deg, largest slip {med['slip']:.1f} mm, largest joint motion "
              f"{med['joint']:.3f} rad")




def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hands", nargs="+", default=["inspire_right", "fourier_right", "allegro_right"])
    parser.add_argument("--gains", nargs="+", type=float, default=[0.0, 20.0, 40.0])
    parser.add_argument("--adaptive", action="store_true", help="also the five-finger hands with adaptive fingers")
    parser.add_argument("--run", type=Path, help="replay this bench run's stored trials instead (turn split)")
    parser.add_argument("--only", default="", help="with --run: trials whose id contains this")
    parser.add_argument("--finger-hold", choices=FINGER_HOLDS, help="with --run: the protocol's finger_hold "
                        "(default: the run's)")
    args = parser.parse_args()
    if args.run is not None:
        replay_run(args.run, args.only, args.finger_hold)
        return
    with tempfile.TemporaryDirectory() as cache:
        can = build_object(trimesh.creation.cylinder(0.033, 0.12, sections=48), name="can", mass=0.35,
                           cache_root=cache).asset
        print(f"{'hand':28s} {'gain':>5s} {'status':16s} {'creep [mm]':>10s} {'turn [deg]':>10s} {'grip [N]':>8s}")
        for name in args.hands:
            variants = [(name, hands.load(name))]
            if args.adaptive and not name.startswith("allegro"):
                from manigrasp.hands.from_robosuite.dexterous import MODELS, make_from

                variants.append((f"{name} (adaptive)", make_from(dataclasses.replace(MODELS[name], coupled=False))))
            for label, hand in variants:
                scene = build_scene(hand, can)
                for gain in args.gains:
                    object_pose = settle_object(scene)
                    pose = side_power_grasp(hand, [object_pose[0, 3], object_pose[1, 3], scene.object_rest_height])
                    protocol = PROTOCOLS.load("standard", finger_hold_gain=gain)
                    result = protocol.run(scene, GraspCandidate(pose=pose, score=1.0), np.random.default_rng(0),
                                          deadline=time.monotonic() + 300, object_pose=object_pose, seed=0)
                    print(f"{label:28s} {gain:5g} {result.status.value:16s} {1000 * result.max_translation_m:10.2f} "
                          f"{result.max_rotation_deg:10.1f} {result.grip_force_n:8.2f}")


if __name__ == "__main__":
    main()
