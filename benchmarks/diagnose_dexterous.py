"""Why do dexterous grasps slip at lift? Re-simulate stored trials of a run and print, at the end of the close
and through the lift, what holds the object.

Usage:
    .venv/bin/python benchmarks/diagnose_dexterous.py RUN_DIR [TRIAL_ID ...] [--status slipped_lift] [--max 4]

Each trial is replayed exactly as `manigrasp replay` does (same scene, settled object, stored grasp, seed) with
an observer that only reads the scene. Printed per snapshot (end of close = start of lift; then every 0.1 s of
the lift and hold):

- each hand body touching the object: its finger, summed normal force [N], tangential force [N] and the worst
  friction-cone usage (1 = sliding);
- the grip force the protocol regulates (`manigrasp.sim.grip_force`: min(thumb, rest)), the total normal force
  and the object's weight m g; the largest "friction capacity" mu * sum f_n vs m g;
- each squeezing actuator's force against its limit (saturated = within 2 % of it), and its command minus its
  length (how far past the finger the servo is wound);
- the object's translation [mm] and rotation [deg] in the hand since the start of the lift.

Measured (dexopt, 8 dexterous objects x inspire/fourier/allegro x 5 grasps, standard, grip_force 10; run with
`manigrasp bench` into RUN, then `--summary` over its 120 dexopt trials; 116 reached the lift):
- friction capacity at the end of the close, mu sum f_n / m g: <= 3 in 53 trials, 3 successes (43 slipped_lift);
  > 3 in 63 trials, 36 successes. The grip loop regulates the thumb's side (min(thumb, rest)); with fingertips
  only, sum f_n is 2.3 x that grip (median), so at 10 N mu sum f_n ~ 11.5 N (the power planner's palm grasps of
  the can: 42-44 N sum f_n at the same 9 N grip);
- the heavy objects (sugar box, mustard, drill: 45 trials) 2 successes; the same grasps with the object's mass
  x 0.5: 8, x 0.25: 21 (`--mass-scale`);
- hand-object friction 1.0 instead of 0.5 (`--friction 1.0`): 54/120 instead of 39/120 (slipped_lift 32, was 60);
- contacts already on the friction cone at the end of the close (share of the normal force with cone usage
  >= 0.95): > 0.9 in 28 trials, 5 successes; <= 0.5 in 53 trials, 24 successes.

Why the Allegro's dexopt grasps drop in the perturbations (`--summary` over the Allegro's 26 `dropped_perturb`
and 26 `success` trials of the dexterous config, standard only, 10 N, `scene.pads=compliant`, dexopt at 694eace;
its thumb regulates to 9 N, its maximum):
- at the end of the close both sets press alike: sum f_n median 21.3 N (drops) vs 21.4 N (successes), about
  2.3 x the 9 N grip, i.e. the two sides of the grasp press each other with about the grip; by the first
  perturbation 15.7 vs 18.3 N;
- the drops have already turned in the hand during the lift and hold: rotation at the first perturbation median
  5.2 deg (13 of 26 over 5 deg; the protocol fails a trial at 15 deg or 2 cm) against 1.4 deg (2 of 26) for the
  successes; the perturbation then turns them past the limit (the mustard bottle: the two fingers opposite the
  thumb lose contact and the object rolls on the thumb-index pinch);
- the planner's load test credited them with forces the hand does not press: `squeeze_caps` scaled both sides
  of the grasp by the weaker side's factor, so the stronger side got the rest: the caps of a grasp summed to
  44 N (median; quartiles 34-59 N) where the simulation presses 21 N.
  Re-planned at the run's seeds (`bench_dexopt.py --run`, the margins of each trial's grasp at mu 1.0,
  the rubber's): with those caps 51 of 78 grasps pass and 23 of them succeed (13 `dropped_perturb`); with each
  side capped at the grip (the fix, 7352105) 33 pass, 22 succeed (7 `dropped_perturb`), and the failing 45
  hold 4 successes. (At the planner's old mu 0.5 with the old caps: 34 pass, 21 succeed, 7 drop.) The 7 drops
  that still pass are mostly the potted meat can (5 of 10; margins 1.3-1.9): they turn 4-12 deg in the lift,
  which the load test (a rigid object on ideal force sources) does not see.

What the heavy objects lack (dexopt at 80 restarts x 300 steps, standard, 10 N, compliant pads, seed 0; the
largest load-test margin among all candidates of one planning call, `dexopt_planner.DexOptPlanner.synthesise`):
power drill 0.41 (Allegro), 0.47 (Fourier), 0.48 (Inspire): no fingertip grasp found carries it at 10 N, and
no trial held it (0-1/10 per hand); sugar box 1.26, 1.31, 0.42 and mustard bottle 1.13, 1.10, 0.97: a few
grasps pass at margins where 29 of 60 trials succeed ([1, 2)), and the trials give 1-5/10 per hand (the
Inspire's 5/10 on both at margins < 1: its palm and finger links touch, which the load test does not count).
The grasps that pass and still fail with margins >= 3 (Inspire mug 0006: mu sum f_n 31 x m g) lose the
object in the first 0.2 s of the lift: 3 of 5 fingers touch (thumb, ring, pinky), the thumb presses 24.6 N against 12 N
(the table balanced the rest) and the object is pushed out.

Tried on these findings, none a gain (005_tomato_soup_can, 004_sugar_box, 056_tennis_ball, 010_potted_meat_can x
allegro_right, fourier_right x dexopt x 5 grasps, standard, grip_force 10, seed 0; `manigrasp bench CFG --jobs 1`;
successes of 40, Allegro + Fourier, against 15 = 7 + 8 for dexopt's defaults; +-4 is within noise at 20 per hand):
- the squeeze as closing-only least squares (scipy nnls over the closing-signed actuator forces) instead of the
  free least squares with its opening forces cut to 0: 15 = 7 + 8, the same outcome in all 40 trials;
- the palm as a contact (`palm: true`; the sugar box is the only object over the pinch limit mu 2.3 grip / 3 g =
  0.39 kg at 10 N): 8 = 2 + 6, sugar box 0/10 (was 1/10);
- `contact_tolerance: 0.005` (was 0.02): 14 = 7 + 7; `min_contacts: 4`: 13 = 5 + 8;
- `wrap: true` (every finger link a pad): 12 = 4 + 8 (sugar box 2, potted meat 4, can 2, ball 4);
- `min_force_share: 1.0` (equal pushes): 11 = 0 + 11, the Fourier hand's best (was 8/20), the Allegro's worst.
  Not confirmed for the Fourier hand on other objects (mustard, mug, banana, can, potted meat x 5, seed 1): 5/25
  against 7/25 at the default 0.3.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

from manigrasp.bench.replay import find_trial, stored_grasp, stored_trials
from manigrasp.geometry import relative_pose
from manigrasp.protocol.result import Phase
from manigrasp.sim import grip_force, read_hand_contacts

G = 9.81


class Probe:
    """Observer printing the grasp's contact and actuator state at the start of the lift and through it."""

    sample_period_s = 0.1

    def __init__(self, out=sys.stdout, quiet: bool = False) -> None:
        self.out, self.quiet = out, quiet
        self.phase = None
        self.ref = None
        self.rows: list[dict] = []

    def on_start(self, scene, grasp, object_pose) -> None:  # noqa: D102
        joints = getattr(grasp, "joints", None)
        if joints is not None:
            if not self.quiet:
                print(f"  hand path: pre-shape {np.round(joints[0], 2)}\n"
                      f"             squeeze   {np.round(joints[1], 2)}", file=self.out)

    def on_phase(self, scene, phase, detail: str = "") -> None:  # noqa: D102
        self.phase = phase
        if phase == Phase.LIFT:
            self.ref = relative_pose(scene.tcp_pose(), scene.object_pose())
            self.snapshot(scene, "end of close")
        elif phase in (Phase.HOLD, Phase.PERTURB):
            self.snapshot(scene, f"{phase.value} begins {detail}")

    def on_sample(self, scene) -> None:  # noqa: D102
        if self.phase in (Phase.LIFT, Phase.HOLD):
            self.snapshot(scene, f"{self.phase.value} t={scene.time:.2f}", brief=True)

    def on_end(self, scene, result) -> None:  # noqa: D102
        self.snapshot(scene, f"end ({result.status.value}: {result.detail[:80]})")

    def snapshot(self, scene, label: str, brief: bool = False) -> None:
        """Print the state now."""
        m, d = scene.model, scene.data
        c = read_hand_contacts(scene, "object")
        weight = scene.object_mass() * G
        drift = ""
        shift = angle = 0.0
        if self.ref is not None:
            now = relative_pose(scene.tcp_pose(), scene.object_pose())
            move = relative_pose(self.ref, now)
            angle = float(np.degrees(np.arccos(np.clip((np.trace(move[:3, :3]) - 1) / 2, -1, 1))))
            shift = 1000 * float(np.linalg.norm(move[:3, 3]))
            drift = f" drift {shift:5.1f} mm {angle:5.1f} deg"
        fn = np.clip(c.normal_force, 0, None)
        table = read_hand_contacts(scene, "table")
        if len(table):
            drift += f" | hand on table {np.clip(table.normal_force, 0, None).sum():.2f} N"
        capacity = float(np.sum(c.friction * fn))
        row = dict(label=label, grip=grip_force(c), total=float(fn.sum()), capacity=capacity, weight=weight,
                   shift=shift, angle=angle)
        bodies = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or "" for b in c.hand_body]
        tips = np.array([("tip" in n) or ("distal" in n) for n in bodies], bool)
        total = max(row["total"], 1e-9)
        row.update(on_cone=float(fn[c.cone_ratio >= 0.95].sum() / total), tips=float(fn[tips].sum() / total) if
                   len(fn) else 0.0, palm=float(fn[c.finger < 0].sum()), n_fingers=len(c.fingers_touching),
                   saturated=int(np.sum(np.abs(d.actuator_force[scene.hand_actuators]) >= 0.98 * np.where(
                       m.actuator_forcelimited[scene.hand_actuators].astype(bool),
                       m.actuator_forcerange[scene.hand_actuators, 1], np.inf))))
        self.rows.append(row)
        if self.quiet:
            return
        print(f"  [{label}] grip {row['grip']:5.2f} N  sum fn {row['total']:5.2f} N  mu*sum fn {capacity:5.2f} N"
              f"  mg {weight:4.2f} N  fingers {c.fingers_touching}{drift}", file=self.out)
        if brief:
            return
        names = {}
        for b in np.unique(c.hand_body):
            sel = c.hand_body == b
            names[mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)] = (
                int(c.finger[sel][0]), fn[sel].sum(), c.tangential_force[sel].sum(), c.cone_ratio[sel].max(),
                int(sel.sum()))
        for name, (finger, f, t, cone, n) in sorted(names.items(), key=lambda kv: kv[1][0]):
            print(f"      {name:32s} finger {finger:2d}  fn {f:6.2f} N  ft {t:5.2f} N  cone {cone:4.2f}  ({n} pts)",
                  file=self.out)
        acts = scene.hand_actuators
        force = d.actuator_force[acts]
        limit = np.where(m.actuator_forcelimited[acts].astype(bool),
                         np.where(force >= 0, m.actuator_forcerange[acts, 1], -m.actuator_forcerange[acts, 0]), np.inf)
        wound = d.ctrl[acts] - d.actuator_length[acts]
        open_, closed = scene.hand_path
        closing = np.sign(closed - open_)
        parts = []
        for i, a in enumerate(acts):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a).split("/")[-1][-10:]
            sat = "*" if np.isfinite(limit[i]) and abs(force[i]) >= 0.98 * limit[i] else " "
            parts.append(f"{name}:{force[i]:+.2f}/{limit[i]:.2f}{sat} w{wound[i]:+.2f} c{closing[i]:+.0f}")
        for k in range(0, len(parts), 4):
            print("      " + "  ".join(parts[k:k + 4]), file=self.out)
        print(f"      hand synergy {scene.hand_synergy():.3f}", file=self.out)


_ORIGINAL: dict[int, tuple[np.ndarray, float, np.ndarray]] = {}


def counterfactual(scene, friction: float | None, mass_scale: float) -> None:
    """Change the physics of `scene` for a what-if replay: the hand geoms' sliding friction (the hand-object
    coefficient: hand geoms have contact priority) and the object's mass and inertia (x `mass_scale`).
    The model's own values are kept and restored when called with (None, 1.0)."""
    m = scene.model
    if id(m) not in _ORIGINAL:
        _ORIGINAL[id(m)] = (m.geom_friction[:, 0].copy(), float(m.body_mass[scene.object_body]),
                            m.body_inertia[scene.object_body].copy())
    mu, mass, inertia = _ORIGINAL[id(m)]
    m.geom_friction[:, 0] = np.where(scene.geom_is_hand, friction, mu) if friction is not None else mu
    m.body_mass[scene.object_body] = mass * mass_scale
    m.body_inertia[scene.object_body] = inertia * mass_scale


def replay_probe(run_dir: Path, trial_id: str, quiet: bool = False, friction: float | None = None,
                 mass_scale: float = 1.0) -> tuple[object, Probe]:
    """Replay `trial_id` of `run_dir` with a `Probe`; returns (result, probe). `friction`, `mass_scale`: a
    what-if (`counterfactual`), applied after the object has settled."""
    from manigrasp.bench.worker import scene_for
    from manigrasp.protocol import PROTOCOLS, settle_object

    trial = find_trial(run_dir, trial_id)
    group = trial.group
    scene = scene_for(group)
    counterfactual(scene, None, 1.0)
    object_pose = settle_object(scene)
    counterfactual(scene, friction, mass_scale)
    probe = Probe(quiet=quiet)
    protocol = PROTOCOLS.load(group.protocol.name, **dict(group.protocol.params))
    seed = group.trial_seed(trial.index)
    result = protocol.run(scene, stored_grasp(trial.result), np.random.default_rng(seed),
                          deadline=time.monotonic() + 600, object_pose=object_pose, observer=probe, seed=seed)
    return result, probe


def summary(run_dir: Path, ids: list[str], friction: float | None = None, mass_scale: float = 1.0) -> int:
    """One line per trial: the state at the end of the close (start of the lift)."""
    ids = ids or sorted(stored_trials(run_dir))
    print("trial | status | grip N | sum fn N | mu sum fn / mg | fn on cone | fn on tips | palm N | fingers | "
          "saturated actuators | at the first perturbation: drift mm, deg, sum fn N, fingers")
    for trial_id in ids:
        result, probe = replay_probe(run_dir, trial_id, quiet=True, friction=friction, mass_scale=mass_scale)
        first = next((r for r in probe.rows if r["label"] == "end of close"), None)
        if first is None:
            print(f"{trial_id} | {result.status.value} | (no lift)")
            continue
        perturb = next((r for r in probe.rows if r["label"].startswith("perturb begins")), None)
        at_perturb = (f"{perturb['shift']:.1f} | {perturb['angle']:.1f} | {perturb['total']:.1f} | "
                      f"{perturb['n_fingers']}") if perturb else "(no perturbation)"
        print(f"{trial_id} | {result.status.value} | {first['grip']:.1f} | {first['total']:.1f} | "
              f"{first['capacity'] / first['weight']:.2f} | {first['on_cone']:.2f} | {first['tips']:.2f} | "
              f"{first['palm']:.1f} | {first['n_fingers']} | {first['saturated']} | {at_perturb}", flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("trials", nargs="*")
    ap.add_argument("--status", default="slipped_lift", help="pick stored trials with this status (no ids given)")
    ap.add_argument("--max", type=int, default=4)
    ap.add_argument("--friction", type=float, help="what-if: hand-object sliding friction (default: the run's)")
    ap.add_argument("--mass-scale", type=float, default=1.0, help="what-if: the object's mass x this")
    ap.add_argument("--summary", action="store_true", help="one line per trial (every stored trial if no ids)")
    args = ap.parse_intermixed_args(argv)
    ids = args.trials
    if args.summary:
        return summary(args.run_dir, ids, args.friction, args.mass_scale)
    if not ids:
        trials = stored_trials(args.run_dir)
        ids = [t for t, s in sorted(trials.items()) if s.result.status.value == args.status][:args.max]
    for trial_id in ids:
        stored = find_trial(args.run_dir, trial_id).result
        print(f"== {trial_id}: stored {stored.status.value} (grip {stored.grip_force_n:.2f} N)")
        result, _ = replay_probe(args.run_dir, trial_id, friction=args.friction, mass_scale=args.mass_scale)
        print(f"   replayed: {result.status.value}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
