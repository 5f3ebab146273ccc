"""Why do dexterous grasps slip at lift? Re-simulate stored trials of a run and print, at the end of the close
and through the lift, what holds the object.

Usage:
    .venv/bin/python benchmarks/diagnose_dexterous.py RUN_DIR [TRIAL_ID ...] [--status slipped_lift] [--max 4]
    .venv/bin/python benchmarks/diagnose_dexterous.py RUN_DIR --versus-plan [--only /standard/ fourier_right]
        [--save ROWS.pkl]                       # dexopt's plan against the replay (below)
    .venv/bin/python benchmarks/diagnose_dexterous.py RUN_DIR --versus-summary ROWS.pkl ...
    .venv/bin/python benchmarks/diagnose_dexterous.py RUN_DIR --with close_mode=per_finger [--only dexopt]
        # the stored grasps replayed with other protocol parameters (below)

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

The same grasps with other protocol parameters (`--with KEY=VALUE ...`, e.g. `close_mode=per_finger`): every
stored trial (or the ids; `--only` filters) is replayed with the run's protocol parameters so changed, and the
successes stored and replayed are printed per hand x planner (k/n), with, at the end of the close, the trials
with every finger on the object (>= 0.1 N) and the median push of the object on the table by the close. The
per-finger close against the synergy close (`manigrasp bench dexterous "protocols=[{name: standard, params:
{grip_force: 10.0}}]" --out RUN` at 04ffbb2, then `RUN --with close_mode=per_finger` and `RUN --with
close_mode=synergy --only dexopt`; the mug's dexopt group from a run of its own with `trial_timeout_s=900`, its
planning having overrun 120 s on the loaded machine): dexopt 40/37/44 -> 40/37/45 of 70 (Allegro, Fourier,
Inspire), power 19/53/54 -> 23/57/50, none beyond noise; every finger on at the end of the close (dexopt)
Fourier 1/64 -> 16/63, Inspire 20/67 -> 37/66, Allegro 61/69 -> 58/67; pushed over 5 mm 27/64 -> 15/63,
12/67 -> 12/66, 29/69 -> 25/67 (`manigrasp.control.fingers`). Replaying with the run's own parameters gives its
stored statuses (209 of the 210 dexopt trials).

The plan against the simulation (`--versus-plan`): each dexopt trial's group is planned again in the process
that replays it, every candidate kept, with what dexopt's load test (`dexopt_planner`, step 6) was given: the
pads in contact, their fingers and links, their normal-force caps, the loads, mu. A trial whose executed pose no
re-planned candidate matches (1e-6 m) is skipped with a message (the planner's code must be the run's: with
uncommitted changes to dexopt in the working tree the re-planned grasps moved by 10 mm; the committed code
re-plans them exactly, all 193 below matched). Per trial (`compare`): the planned
fingers and caps; at the end of the close (E), at the first perturbation (P) and at the last sample (F) the
fingers touching and each finger's normal force [N], the force on links other than the planned pads, the
friction used (force-weighted |f_t| / (mu f_n)), the load test on the simulated contacts with the simulated
normal forces as caps, the object's motion in the hand (mm, deg, |rotation axis . thumb-to-fingers line|); the
distance of each finger's simulated contacts from its planned pad, and how far the close pushed the object.

Measured: the dexterous config's dexopt trials under `standard` (10 N, compliant pads; `manigrasp bench
dexterous --out RUN` at 672a15f, the same grasps as at 8ac99d2: a 30-trial subset re-run at 8ac99d2 gave identical
statuses), replayed at 8ac99d2 (`RUN --versus-plan --only /standard/ --save ROWS`; the Allegro with the default
floor hold, 32/62 replayed; the five-finger statuses as stored), 193 trials that reached the lift
(`--versus-summary ROWS`):
- The grip loop presses the planned squeeze in total: at E the thumb presses 1.00-1.08 x its cap (median per
  hand, successes at margin >= 1.3; 0.95-1.64 in the failures), the other side 12-13 N for caps totalling 10 N
  (9 N on the Allegro, its maximum).
- Not with the planned fingers on the five-finger hands: the loop stops at the grip force with whichever fingers
  reached the object first (Fourier, tomato can 0000: thumb, index, ring and pinky at 0.35-0.62 of their planned
  joint angles; sugar box 0000: the hand's synergy 0.05 at the end of the close). Every planned finger touches
  at E in 1 of 25 (Fourier) and 3 of 24 (Inspire) grasps of margin >= 2, 23 of 29 on the Allegro (its 10 N
  target capped at its 9 N maximum);
  planned non-thumb pads within 5 mm of the surface that do not touch at E: Fourier 73/175, Inspire 84/254,
  Allegro 7/181. The load test also counts pads up to `contact_tolerance` (20 mm) off the surface: on the
  Fourier hand 69 of its 244 planned non-thumb pads are 5-20 mm off.
- Where the close misses the plan, grasps fail whatever their margin (`close_defects`; margin >= 2: 59/78
  succeed): object pushed over 5 mm on the table by the close 19/30 (40/48 otherwise); a finger's contacts more
  than 15 mm from its planned pad 20/33 (39/45); friction used at E above 0.55 (before any load: the squeeze's
  own tangential forces) 9/20 (50/58); none of the four defects (with the thumb pressing off its pad) 18/20, and
  at margin >= 1.3 32/35. The defects are common in successes too (41 of the 59 at margin >= 2 have one, 17 of
  the 19 failures). The Fourier thumb presses mostly off its planned distal pad (with its proximal link) in
  7 of the hand's 14 failures at margin >= 1.3 and 8 of its 29 successes (tomato can 0000: the thumb stops at
  pitch 0.19 rad of the planned 0.54, its proximal link on the can 31 mm from the planned pad).
- The load test with any one non-thumb finger left out (`fewer_fingers_margin`) separates the outcomes better
  than the plain margin: >= 2: 43/48 succeed, [1.3, 2): 20/25, [1, 1.3): 8/15, < 1: 40/105 (plain margin 59/78,
  24/37, 9/17, 19/61); at plain margin >= 2, 54/63 with it >= 1 and 5/15 below.
- How they fail: the five-finger `slipped_lift` grasps fall apart in the first 0.1 s of the lift (sum f_n 23 N at
  E, 0-2 N at the failure): the object drops straight out (Fourier: 21 mm, |z| / |shift| 0.99) turning
  14 deg about the thumb-to-fingers line (|axis . line| 0.91). The Allegro keeps its fingers on the object but
  loses 4 N of its 21 N squeeze in the lift (successes and failures alike); its drops turn 20 deg about the
  thumb-to-fingers line in the perturbations (0.95), and its failures at margin >= 2 are mostly the banana,
  pushed and rolled by the close (contacts 27-119 mm from the planned pads).
Tried on these findings, no gain (4 objects: mustard, potted meat, banana, sugar box x 3 hands x 10, standard
10 N, seed 0, dexopt only):
- candidates ranked by `fewer_fingers_margin` instead of the margin (min_hold_margin 2 on it): 47/120 (Allegro
  14, Fourier 13, Inspire 20) against 44/120 (12, 12, 20) for 8ac99d2 (the same as the dexterous run's trials of
  these groups), both in-process on the committed code: robust candidates are few for these objects (potted
  meat x Fourier: none of 24 candidates at margin >= 2, 4 with a finger left out >= 1.3; banana x Fourier: 12
  of 16 at margin >= 2, 2 with a finger left out >= 2);
- every squeezing actuator given at least half of its force limit when the most loaded one saturates (the
  squeeze row of `dexopt_planner.hand_path`; a finger given a small share stops short of the object when the
  grip loop stops): 45/120 (Allegro 14, Fourier 11, Inspire 20) against 44/120 (12, 12, 20) for 8ac99d2 (the
  same as the dexterous run's trials of these groups), both in-process on the committed code;
- a hold that lets a closing finger which presses nothing when the hold engages close in with 0.4 x the mean
  force of the pushing fingers (so a finger short of the object catches up): Fourier's 14 failures at margin
  >= 1.3 gave 1 success, its 8 successes stayed.

Neither creep nor link friction (3 Dec 2026; the dexterous config's run at 62178f2, `standard`, replayed at
f89b0bd+; the replays give the stored statuses):
- the Allegro's drops turn just past 15 deg, as a creep in MuJoCo's soft contacts would (the hand geoms keep
  MuJoCo's default solref 0.02, solimp 0.9-0.95). Stiffer hand contacts do not hold them: the 20 dexopt trials
  of the sugar box and mustard bottle (3 successes) replayed with `--solimp 0.95 0.99` gave 4, `--solimp 0.99
  0.995` 1, with `--solref 0.01` too 1 (the turns stay 15-20 deg: the grasp yields, it does not creep);
- the Inspire's finger and palm links at the fingertips' rubber friction (`--friction 1.0`; its RH56DFTP's
  tactile skins cover the fingers and palm): its 70 dexopt trials 44 -> 42, its 70 power trials 54 -> 54.
  What does separate them is the squeeze at the end of the close: on the Inspire, trials whose normal force
  lies mostly inside the friction cones (`--summary`'s "fn on cone" < 0.3) succeed 36/45, the others 8/22
  (sugar box 0003: every contact on its cone, the hand's synergy stopped at 0.08, the object drops in 0.1 s of
  the lift); on the Fourier 30/49 and 7/15. The trials' simulated epsilon at the end of the close
  (`sim_epsilon_l1`) separates them better still (>= 0.2: Allegro 33/38, Fourier 13/13, Inspire 20/20; < 0.1:
  1/9, 10/34, 12/30): what `dexopt_planner`'s closing check can rank by (`close_order: epsilon`, step 7).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from manigrasp.bench.replay import find_trial, stored_grasp, stored_trials
from manigrasp.geometry import relative_pose
from manigrasp.planners.dexopt_planner import FRICTION_USED_MAX, GAP_MAX, PUSHED_MAX
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


def counterfactual(scene, friction: float | None, mass_scale: float, solimp: Sequence[float] | None = None,
                   solref: float | None = None) -> None:
    """Change the physics of `scene` for a what-if replay: the hand geoms' sliding friction (the hand-object
    coefficient: hand geoms have contact priority, so their contact parameters are the contacts'), the object's
    mass and inertia (x `mass_scale`), the hand geoms' contact impedance `solimp` (dmin, dmax) and time constant
    `solref` [s]. The model's own values are kept and restored when called with (None, 1.0)."""
    m = scene.model
    if id(m) not in _ORIGINAL:
        _ORIGINAL[id(m)] = (m.geom_friction[:, 0].copy(), float(m.body_mass[scene.object_body]),
                            m.body_inertia[scene.object_body].copy(), m.geom_solimp.copy(), m.geom_solref.copy())
    mu, mass, inertia, imp, ref = _ORIGINAL[id(m)]
    hand = scene.geom_is_hand
    m.geom_friction[:, 0] = np.where(hand, friction, mu) if friction is not None else mu
    m.body_mass[scene.object_body] = mass * mass_scale
    m.body_inertia[scene.object_body] = inertia * mass_scale
    m.geom_solimp[:] = imp
    m.geom_solref[:] = ref
    if solimp is not None:
        m.geom_solimp[hand, :2] = solimp
    if solref is not None:
        m.geom_solref[hand, 0] = solref


def replay_probe(run_dir: Path, trial_id: str, quiet: bool = False, friction: float | None = None,
                 mass_scale: float = 1.0, **contact) -> tuple[object, Probe]:
    """Replay `trial_id` of `run_dir` with a `Probe`; returns (result, probe). `friction`, `mass_scale` and
    `contact` (`solimp`, `solref`): a what-if (`counterfactual`), applied after the object has settled."""
    from manigrasp.bench.worker import scene_for
    from manigrasp.protocol import PROTOCOLS, settle_object

    trial = find_trial(run_dir, trial_id)
    group = trial.group
    scene = scene_for(group)
    counterfactual(scene, None, 1.0)
    object_pose = settle_object(scene)
    counterfactual(scene, friction, mass_scale, **contact)
    probe = Probe(quiet=quiet)
    protocol = PROTOCOLS.load(group.protocol.name, **dict(group.protocol.params))
    seed = group.trial_seed(trial.index)
    result = protocol.run(scene, stored_grasp(trial.result), np.random.default_rng(seed),
                          deadline=time.monotonic() + 600, object_pose=object_pose, observer=probe, seed=seed)
    return result, probe


def summary(run_dir: Path, ids: list[str], friction: float | None = None, mass_scale: float = 1.0, **contact) -> int:
    """One line per trial: the state at the end of the close (start of the lift)."""
    ids = ids or sorted(stored_trials(run_dir))
    print("trial | status | grip N | sum fn N | mu sum fn / mg | fn on cone | fn on tips | palm N | fingers | "
          "saturated actuators | at the first perturbation: drift mm, deg, sum fn N, fingers")
    for trial_id in ids:
        result, probe = replay_probe(run_dir, trial_id, quiet=True, friction=friction, mass_scale=mass_scale,
                                     **contact)
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


# ---------------------------------------------------------------------------------------------------------------
# The plan against the simulation (`--versus-plan`): what dexopt's load test assumed, what the replay presses.

SAMPLE_S = 0.02  # [s] between the tracker's samples in the lift and hold
TOUCH_N = 0.1  # [N] a finger or link with at least this normal force touches


@dataclass
class PlannedGrasp:
    """What dexopt's load test (`dexopt.hold_margin`, step 6) assumed of one candidate: the pads in contact at
    `points` (k, 3) [m] with inward `normals`, on `bodies` (k,) (names in the hand's own model) of `fingers`
    (k,), their normal-force `caps` (k,) [N], the `loads` (L, 3) [N] at `center`, friction `mu`, `torsion` [m]
    and the resulting `margin`."""

    pose: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    caps: np.ndarray
    fingers: np.ndarray
    bodies: list[str]
    center: np.ndarray
    loads: np.ndarray
    mu: float
    torsion: float
    margin: float


def planned_grasps(group) -> list[PlannedGrasp]:
    """Plan `group` again as its run did (same seed and context; the same code must be checked out), keep every
    candidate that passed the checks (no diversity cut) and what its load test was given."""
    import manigrasp.planners.dexopt_planner as dp
    from manigrasp.bench.observe import observe_with_info
    from manigrasp.bench.worker import _asset, scene_for
    from manigrasp.planners.context import PlanContext
    from manigrasp.protocol import PROTOCOLS, settle_object

    scene = scene_for(group)
    context = PlanContext.for_run(PROTOCOLS.load(group.protocol.name, **dict(group.protocol.params)).params,
                                  group.scene, scene.hand)
    observation, _ = observe_with_info(group.observation, _asset(group), settle_object(scene), scene,
                                       seed=group.seed, camera=group.camera)
    planner = dp.DexOptPlanner(**dict(group.planner.params))
    hk = planner.kinematics(scene.hand)
    body_of_slot = np.full(len(hk.bodies), -1)
    body_of_slot[hk._slot[hk.bodies]] = hk.bodies
    seen: dict = {}
    calls: list[dict] = []
    saved = dp.pad_jacobians, dp.hold_margin, dp.suppress

    def jacobians(x, slot, *args):
        seen["x"], seen["slot"] = np.array(x), np.array(slot)
        return saved[0](x, slot, *args)

    def margin(points, normals, caps, center, loads, mu, torsion=0.0):
        value = saved[1](points, normals, caps, center, loads, mu, torsion)
        rows = [int(np.argmin(np.linalg.norm(seen["x"] - p, axis=1))) for p in points]
        calls.append(dict(points=np.array(points), normals=np.array(normals), caps=np.array(caps),
                          bodies=body_of_slot[seen["slot"][rows]], center=np.array(center), loads=np.array(loads),
                          mu=float(mu), torsion=float(torsion), margin=value))
        return value

    dp.pad_jacobians, dp.hold_margin = jacobians, margin
    dp.suppress = lambda poses, distance, angle: np.arange(len(poses))
    try:
        found = planner.synthesise(observation, scene.hand, 10**6, group.rng(), context.pregrasp_offset, context)
    finally:
        dp.pad_jacobians, dp.hold_margin, dp.suppress = saved
    out = []
    for s in found:
        c = next(c for c in calls if c["points"].shape == s.contacts.shape and np.array_equal(c["points"], s.contacts))
        names = [mujoco.mj_id2name(hk.model, mujoco.mjtObj.mjOBJ_BODY, int(b)) for b in c["bodies"]]
        out.append(PlannedGrasp(pose=s.pose, points=c["points"], normals=c["normals"], caps=c["caps"],
                                fingers=hk.body_finger[c["bodies"]], bodies=names, center=c["center"],
                                loads=c["loads"], mu=c["mu"], torsion=c["torsion"], margin=c["margin"]))
    return out


class Tracker:
    """Observer keeping, at the end of the close and every `SAMPLE_S` of the lift, hold and perturbations, the
    hand-object contacts, the actuator forces and the object's pose in the hand (read only)."""

    sample_period_s = SAMPLE_S

    def __init__(self) -> None:
        self.phase, self.detail = None, ""
        self.samples: list[dict] = []
        self.rest = np.eye(4)
        self.before_close: dict = {}

    def on_start(self, scene, grasp, object_pose) -> None:  # noqa: D102
        self.rest = np.array(object_pose, float)

    def on_phase(self, scene, phase, detail: str = "") -> None:  # noqa: D102
        self.phase, self.detail = phase, detail
        if phase == Phase.CLOSE:
            self.before_close = dict(tcp=scene.tcp_pose(), obj=scene.object_pose())
        if phase in (Phase.LIFT, Phase.PERTURB):
            self.take(scene, f"{phase.value}{detail}")

    def on_sample(self, scene) -> None:  # noqa: D102
        if self.phase in (Phase.LIFT, Phase.HOLD, Phase.PERTURB):
            self.take(scene, f"{self.phase.value}{self.detail}")

    def on_end(self, scene, result) -> None:  # noqa: D102
        if self.samples:
            self.take(scene, "end")

    def take(self, scene, label: str) -> None:
        """Keep the state now."""
        m, d = scene.model, scene.data
        c = read_hand_contacts(scene, "object")
        names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(b)) or "" for b in c.hand_body]
        acts = scene.hand_actuators
        self.samples.append(dict(
            label=label, t=float(scene.time), tcp=scene.tcp_pose(), obj=scene.object_pose(),
            com=d.xipos[scene.object_body].copy(),
            fn=np.clip(c.normal_force, 0.0, None), ft=c.tangential_force.copy(), mu=c.friction.copy(),
            cone=c.cone_ratio.copy(), finger=c.finger.copy(), body=names, pos=c.position.copy(), normal=c.normal.copy(),
            torque=c.torque.copy(), act_force=d.actuator_force[acts].copy(), table=float(np.clip(
                read_hand_contacts(scene, "table").normal_force, 0.0, None).sum())))


def _in_hand(sample: dict) -> np.ndarray:
    return relative_pose(sample["tcp"], sample["obj"])


def _motion(ref: dict, now: dict) -> tuple[np.ndarray, np.ndarray, float]:
    """The object's motion in the hand from `ref` to `now`, in world axes (the hand's orientation at `now`):
    translation of its centre (3,) [m], unit rotation axis (3,) and angle [deg]."""
    a, b = _in_hand(ref), _in_hand(now)
    rot_hand = now["tcp"][:3, :3]
    shift = rot_hand @ (b[:3, 3] - a[:3, 3])
    turn = b[:3, :3] @ a[:3, :3].T  # in hand axes
    angle = float(np.degrees(np.arccos(np.clip((np.trace(turn) - 1) / 2, -1, 1))))
    axis = np.array([turn[2, 1] - turn[1, 2], turn[0, 2] - turn[2, 0], turn[1, 0] - turn[0, 1]])
    axis = rot_hand @ axis / max(np.linalg.norm(axis), 1e-12)
    return shift, axis, angle


def _per_finger(sample: dict, n_fingers: int) -> tuple[np.ndarray, float]:
    """(n_fingers,) summed normal force [N] per finger, and the palm's."""
    f = np.array([sample["fn"][sample["finger"] == i].sum() for i in range(n_fingers)])
    return f, float(sample["fn"][sample["finger"] < 0].sum())


def _sim_margin(sample: dict, loads: np.ndarray, mu: float, torsion: float) -> float:
    """`dexopt.hold_margin` of the simulated contacts about the object's centre of mass now, each body's contacts
    lumped into one at their force-weighted centre and mean normal, capped at the normal force the simulation
    presses there (the forces of the moment: could they hold the planner's loads if they stayed?)."""
    from manigrasp.planners.dexopt import hold_margin

    fn = sample["fn"]
    points, normals, caps = [], [], []
    for body in sorted(set(sample["body"])):
        sel = np.array([b == body for b in sample["body"]]) & (fn > 0)
        if fn[sel].sum() < TOUCH_N:
            continue
        w = fn[sel] / fn[sel].sum()
        points.append(w @ sample["pos"][sel])
        normal = w @ sample["normal"][sel]
        normals.append(normal / np.linalg.norm(normal))
        caps.append(fn[sel].sum())
    if not caps:
        return 0.0
    return hold_margin(np.array(points), np.array(normals), np.array(caps), sample["com"], loads, mu, torsion)


def versus_plan(run_dir: Path, ids: list[str], out=sys.stdout, only: tuple[str, ...] = ()) -> list[dict]:
    """Replay dexopt trials and set each against what its plan assumed (module docstring); returns one row each.
    No `ids`: every stored dexopt trial whose id contains each of `only` (e.g. "/standard/", "fourier_right")."""
    from manigrasp.bench.worker import scene_for
    from manigrasp.protocol import PROTOCOLS, settle_object

    trials = stored_trials(run_dir)
    ids = ids or sorted(t for t, s in trials.items() if s.group.planner.name == "dexopt" and
                        all(part in t for part in only) and s.result.status.value != "no_grasp")
    plans: dict = {}
    rows = []
    for trial_id in ids:
        trial = trials[trial_id]
        group = trial.group
        key = group.key(0).trial_id.rsplit("/", 1)[0]
        if key not in plans:
            plans[key] = planned_grasps(group)
        grasp = stored_grasp(trial.result)
        if not np.all(np.isfinite(grasp.pose)) or not plans[key]:
            continue
        gap = [np.linalg.norm(p.pose[:3, 3] - grasp.pose[:3, 3]) for p in plans[key]]
        plan = plans[key][int(np.argmin(gap))]
        if min(gap) > 1e-6:
            print(f"{trial_id}: no planned grasp at the trial's pose (other code?)", file=out)
            continue
        scene = scene_for(group)
        object_pose = settle_object(scene)
        tracker = Tracker()
        protocol = PROTOCOLS.load(group.protocol.name, **dict(group.protocol.params))
        seed = group.trial_seed(trial.index)
        result = protocol.run(scene, grasp, np.random.default_rng(seed), deadline=time.monotonic() + 600,
                              object_pose=object_pose, observer=tracker, seed=seed)
        row = compare(trial_id, plan, tracker.samples, result, len(scene.hand.finger_bodies), scene)
        if tracker.samples and tracker.before_close:
            # the hand at the close against its planned pose, and the object pushed by the close [mm]
            row["tcp_error_mm"] = 1e3 * float(np.linalg.norm(tracker.before_close["tcp"][:3, 3] - plan.pose[:3, 3]))
            row["pushed_close_mm"] = 1e3 * float(np.linalg.norm(tracker.samples[0]["obj"][:3, 3]
                                                                - tracker.before_close["obj"][:3, 3]))
            row["pushed_total_mm"] = 1e3 * float(np.linalg.norm(tracker.samples[0]["obj"][:3, 3] - tracker.rest[:3, 3]))
        rows.append(row)
        print(format_row(row), file=out, flush=True)
    return rows


def compare(trial_id: str, plan: PlannedGrasp, samples: list[dict], result, n_fingers: int, scene) -> dict:
    """One trial's figures: the plan's assumptions against the simulation at the end of the close (E), at the
    first perturbation (P) or the end of the lift, and at the last sample before the failure (F)."""
    row = dict(trial=trial_id, status=result.status.value, detail=result.detail[:60], margin=plan.margin,
               planned=sorted({int(f) for f in plan.fingers}))
    cap_finger = np.array([plan.caps[plan.fingers == i].sum() for i in range(n_fingers)])
    row["cap_thumb"], row["cap_rest"] = float(cap_finger[0]), float(cap_finger[1:].sum())
    if not samples:
        return row
    end_close = samples[0]
    later = [s for s in samples[1:] if s["label"].startswith("perturb")]
    at_p = later[0] if later else samples[-1]
    last = samples[-1]
    row["plan"], row["samples"] = plan, (end_close, at_p, last)
    for tag, s in (("E", end_close), ("P", at_p), ("F", last)):
        f, palm = _per_finger(s, n_fingers)
        row[f"{tag}_fingers"] = [i for i in range(n_fingers) if f[i] >= TOUCH_N]
        row[f"{tag}_thumb"], row[f"{tag}_rest"], row[f"{tag}_palm"] = float(f[0]), float(f[1:].sum()), palm
        row[f"{tag}_finger"] = f
        pad = np.array([any(b.endswith(name) for name in plan.bodies) for b in s["body"]], bool)
        row[f"{tag}_off_pad"] = float(s["fn"][~pad].sum())
        total = max(float(s["fn"].sum()), 1e-9)
        row[f"{tag}_total"] = float(s["fn"].sum())
        row[f"{tag}_use"] = float((s["ft"] / np.maximum(s["mu"] * s["fn"], 1e-9) * s["fn"]).sum() / total)
        row[f"{tag}_on_cone"] = float(s["fn"][s["cone"] >= 0.95].sum() / total)
        row[f"{tag}_margin"] = _sim_margin(s, plan.loads, plan.mu, plan.torsion)
        row[f"{tag}_table"] = s["table"]
        shift, axis, angle = _motion(end_close, s)
        row[f"{tag}_shift"], row[f"{tag}_axis"], row[f"{tag}_angle"] = shift, axis, angle
    # the grasp's axis: from the thumb's planned pad to the others' mean (rolling about it: the weight's torque
    # about the pinch line, which only torsion and the pads' patches hold)
    thumb = plan.points[plan.fingers == 0]
    rest = plan.points[plan.fingers > 0]
    if len(thumb) and len(rest):
        line = rest.mean(axis=0) - thumb.mean(axis=0)
        line /= np.linalg.norm(line)
        row["grasp_axis"] = line
        for tag in ("P", "F"):
            row[f"{tag}_roll"] = float(abs(row[f"{tag}_axis"] @ line))
            row[f"{tag}_slide_along"] = float(row[f"{tag}_shift"] @ line)
        # the weight's lever about the pinch line: distance of the centre of mass from it [m]
        r = plan.center - thumb.mean(axis=0)
        row["com_off_line"] = float(np.linalg.norm(r - (r @ line) * line))
    # where the sim's contacts sit against the plan: per planned finger, the distance [mm] from its planned pad to
    # the force-weighted centre of the finger's contacts at the end of the close (object frame: both at rest)
    gaps = []
    for p, f in zip(plan.points, plan.fingers, strict=True):
        sel = (end_close["finger"] == f) & (end_close["fn"] > 0)
        if end_close["fn"][sel].sum() >= TOUCH_N:
            w = end_close["fn"][sel] / end_close["fn"][sel].sum()
            gaps.append(1e3 * float(np.linalg.norm(w @ end_close["pos"][sel] - p)))
        else:
            gaps.append(np.nan)
    row["pad_gap_mm"] = gaps
    return row


def fewer_fingers_margin(plan: PlannedGrasp) -> float:
    """The plan's load test with each non-thumb finger left out in turn (its pads dropped, the other non-thumb
    pads' caps scaled up so that their side still totals the grip, as `squeeze_caps` would): the smallest margin,
    0 if the thumb would face no finger. A grasp whose test passes only with every planned finger pressing its
    share scores low."""
    from manigrasp.planners.dexopt import hold_margin

    worst = plan.margin
    rest = plan.fingers > 0
    for finger in np.unique(plan.fingers[rest]):
        keep = plan.fingers != finger
        if not np.any(keep & rest):
            return 0.0
        caps = plan.caps.copy()
        caps[keep & rest] *= plan.caps[rest].sum() / max(caps[keep & rest].sum(), 1e-12)
        worst = min(worst, hold_margin(plan.points[keep], plan.normals[keep], caps[keep], plan.center, plan.loads,
                                       plan.mu, plan.torsion))
    return float(worst)


def close_defects(r: dict) -> list[str]:
    """How the close missed the plan in trial row `r` (`compare`): the object pushed more than `PUSHED_MM` on
    the table, a contact more than `GAP_MM` from its planned pad, the thumb pressing mostly off its planned
    pad, the friction already used at the end of the close (force-weighted |f_t| / (mu f_n)) above `USED`."""
    end = r["samples"][0]
    thumb = end["finger"] == 0
    pad = np.array([any(b.endswith(name) for name in r["plan"].bodies) for b in end["body"]], bool)
    out = []
    if r["pushed_close_mm"] > PUSHED_MM:
        out.append("pushed")
    if np.nanmax(np.append(r["pad_gap_mm"], 0.0)) > GAP_MM:
        out.append("off-plan")
    if end["fn"][thumb & pad].sum() < 0.5 * end["fn"][thumb].sum():
        out.append("thumb-off-pad")
    if r["E_use"] > USED:
        out.append("friction-used")
    return out


# thresholds of `close_defects`: the planner's closing check's (`dexopt_planner`, step 7), in mm
PUSHED_MM, GAP_MM, USED = 1000.0 * PUSHED_MAX, 1000.0 * GAP_MAX, FRICTION_USED_MAX


def versus_summary(rows: list[dict], out=sys.stdout) -> None:
    """Success rates of replayed trials (`versus_plan` rows) by the plan's margin, by `fewer_fingers_margin`, and
    by the close's defects (`close_defects`), per hand and in all."""
    rows = [r for r in rows if "E_total" in r]
    hands = sorted({r["trial"].split("/")[1] for r in rows})

    def rate(name, keep):
        sel = [r for r in rows if keep(r)]
        per = "  ".join(f"{h}: {sum(r['status'] == 'success' for r in sel if h in r['trial'])}/"
                        f"{sum(h in r['trial'] for r in sel)}" for h in hands)
        print(f"{name:<52s} {sum(r['status'] == 'success' for r in sel):>3d}/{len(sel):<3d}  {per}", file=out)

    for r in rows:
        r.setdefault("fewer", fewer_fingers_margin(r["plan"]))
        r.setdefault("defects", close_defects(r))
    bins = ((2.0, np.inf), (1.3, 2.0), (1.0, 1.3), (0.0, 1.0))
    for key, label in (("margin", "load-test margin"), ("fewer", "margin with a finger left out")):
        for lo, hi in bins:
            rate(f"{label} in [{lo}, {hi})", lambda r, lo=lo, hi=hi, key=key: lo <= r[key] < hi)
    for lo in (2.0, 1.3):
        for defect in ("pushed", "off-plan", "thumb-off-pad", "friction-used"):
            rate(f"margin >= {lo}, {defect}", lambda r, lo=lo, d=defect: r["margin"] >= lo and d in r["defects"])
        rate(f"margin >= {lo}, none of these", lambda r, lo=lo: r["margin"] >= lo and not r["defects"])


def format_row(r: dict) -> str:
    """One line of `versus_plan`'s output."""
    if "E_total" not in r:
        return f"{r['trial']} | {r['status']} | margin {r['margin']:.2f} | (no lift)"
    fmt = lambda v: " ".join(f"{x:4.1f}" for x in v)  # noqa: E731
    mm = lambda v: f"{1e3 * np.linalg.norm(v):.1f} mm (z {1e3 * v[2]:+.1f})"  # noqa: E731
    return (f"{r['trial']} | {r['status']:<15} | margin {r['margin']:5.2f} | planned {r['planned']} caps T "
            f"{r['cap_thumb']:.1f} R {r['cap_rest']:.1f} | E: fingers {r['E_fingers']} fn [{fmt(r['E_finger'])}] "
            f"palm {r['E_palm']:.1f} off-pad {r['E_off_pad']:.1f} table {r['E_table']:.1f} use {r['E_use']:.2f} "
            f"sim-margin {r['E_margin']:.2f} pad-gap {fmt(r['pad_gap_mm'])} mm | P: fingers {r['P_fingers']} fn "
            f"[{fmt(r['P_finger'])}] off-pad {r['P_off_pad']:.1f} use {r['P_use']:.2f} sim-margin "
            f"{r['P_margin']:.2f} moved {mm(r['P_shift'])} {r['P_angle']:.1f} deg roll {r.get('P_roll', np.nan):.2f}"
            f" | F: fingers {r['F_fingers']} fn [{fmt(r['F_finger'])}] moved {mm(r['F_shift'])} "
            f"{r['F_angle']:.1f} deg roll {r.get('F_roll', np.nan):.2f} | com-line "
            f"{1e3 * r.get('com_off_line', np.nan):.0f} mm | tcp-error {r.get('tcp_error_mm', np.nan):.1f} mm, "
            f"object pushed by the close {r.get('pushed_close_mm', np.nan):.1f} mm "
            f"(since rest {r.get('pushed_total_mm', np.nan):.1f})")


# ---------------------------------------------------------------------------------------------------------------
# The same grasps under other protocol parameters (`--with`): e.g. the per-finger close against the synergy close.


class CloseEnd:
    """Observer reading, at the end of the close (the next phase's start), the fingers pressing on the object (at
    least `TOUCH_N`) and how far the close pushed the object on the table [mm]."""

    sample_period_s = float("inf")

    def __init__(self) -> None:
        self.start: np.ndarray | None = None
        self.fingers, self.pushed_mm = -1, np.nan

    def on_start(self, scene, grasp, object_pose) -> None:  # noqa: D102
        pass

    def on_phase(self, scene, phase, detail: str = "") -> None:  # noqa: D102
        if phase is Phase.CLOSE:
            self.start = scene.object_pose()[:2, 3].copy()
        elif self.start is not None and self.fingers < 0:
            c = read_hand_contacts(scene)
            self.fingers = len({int(f) for f, fn in zip(c.finger, c.normal_force, strict=True)
                                if f >= 0 and fn >= TOUCH_N})
            self.pushed_mm = 1e3 * float(np.linalg.norm(scene.object_pose()[:2, 3] - self.start))

    def on_sample(self, scene) -> None:  # noqa: D102
        pass

    def on_end(self, scene, result) -> None:  # noqa: D102
        pass


def parse_value(text: str):
    """A --with value: a number, true/false/none, else the text."""
    low = text.lower()
    if low in ("true", "false"):
        return low == "true"
    if low in ("none", "null"):
        return None
    try:
        return float(text) if any(c in text for c in ".e") else int(text)
    except ValueError:
        return text


def replay_with(run_dir: Path, overrides: dict, ids: list[str], only: tuple[str, ...] = (), out=sys.stdout) -> list:
    """Replay stored trials (all, or `ids`; those containing every `only`) with the run's protocol parameters
    updated by `overrides` (same scene, settled object, stored grasp and seed as `manigrasp replay`), and print
    per hand x planner the successes stored and replayed (k/n), and at the end of the close the trials with
    every finger on the object and the median push by the close. Returns rows (trial id, stored status,
    replayed status, fingers at the end of the close, push [mm], the hand's fingers)."""
    import statistics
    from collections import defaultdict

    from manigrasp.bench.worker import scene_for
    from manigrasp.protocol import PROTOCOLS, settle_object

    trials = stored_trials(run_dir)
    ids = ids or [t for t in sorted(trials) if all(o in t for o in only)]
    rows = []
    for trial_id in ids:
        trial = trials[trial_id]
        stored = trial.result
        if not np.isfinite(stored.grasp.x_m):  # no grasp was executed (a planner error, planning timed out)
            rows.append((trial_id, stored.status.value, stored.status.value, -1, np.nan, -1))
            continue
        group = trial.group
        scene = scene_for(group)
        object_pose = settle_object(scene)
        protocol = PROTOCOLS.load(group.protocol.name, **{**dict(group.protocol.params), **overrides})
        seed = group.trial_seed(trial.index)
        seen = CloseEnd()
        result = protocol.run(scene, stored_grasp(stored), np.random.default_rng(seed),
                              deadline=time.monotonic() + 600, object_pose=object_pose, observer=seen, seed=seed)
        rows.append((trial_id, stored.status.value, result.status.value, seen.fingers, seen.pushed_mm,
                     len(scene.hand.finger_bodies)))
        print(f"{trial_id} | {stored.status.value} -> {result.status.value} | fingers {seen.fingers} | "
              f"pushed {seen.pushed_mm:.1f} mm", file=out, flush=True)
    table = defaultdict(list)
    for row in rows:
        table[tuple(row[0].split("/")[1:3])].append(row)
    print(f"hand x planner | stored | with {overrides} | all fingers on at the end of the close | median push mm",
          file=out)
    for (hand, planner), group_rows in sorted(table.items()):
        n = len(group_rows)
        n_fingers = max(r[5] for r in group_rows)
        closed = [r for r in group_rows if r[3] >= 0]
        pushes = [r[4] for r in closed]
        print(f"{hand} x {planner} | {sum(r[1] == 'success' for r in group_rows)}/{n} | "
              f"{sum(r[2] == 'success' for r in group_rows)}/{n} | "
              f"{sum(r[3] == n_fingers for r in closed)}/{len(closed)} | "
              f"{statistics.median(pushes) if pushes else np.nan:.1f}", file=out)
    return rows


def main(argv: list[str] | None = None) -> int:
    """Entry point."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("trials", nargs="*")
    ap.add_argument("--status", default="slipped_lift", help="pick stored trials with this status (no ids given)")
    ap.add_argument("--max", type=int, default=4)
    ap.add_argument("--friction", type=float, help="what-if: hand-object sliding friction (default: the run's)")
    ap.add_argument("--mass-scale", type=float, default=1.0, help="what-if: the object's mass x this")
    ap.add_argument("--solimp", type=float, nargs=2, metavar=("DMIN", "DMAX"),
                    help="what-if: the hand geoms' contact impedance (default: the run's, MuJoCo's 0.9 0.95)")
    ap.add_argument("--solref", type=float, metavar="TIMECONST",
                    help="what-if: the hand geoms' contact time constant [s] (default: the run's, MuJoCo's 0.02)")
    ap.add_argument("--summary", action="store_true", help="one line per trial (every stored trial if no ids)")
    ap.add_argument("--versus-plan", action="store_true",
                    help="dexopt trials (every stored one if no ids): its load test's assumptions against the replay")
    ap.add_argument("--only", nargs="*", default=[], help="with --versus-plan and no ids: trial ids containing these")
    ap.add_argument("--save", type=Path, help="with --versus-plan: pickle the rows here (for --versus-summary)")
    ap.add_argument("--versus-summary", nargs="*", type=Path, metavar="ROWS",
                    help="success rates by margin and by the close's defects of saved --versus-plan rows")
    ap.add_argument("--with", dest="overrides", nargs="*", metavar="KEY=VALUE",
                    help="replay stored trials (all, or ids; --only filters) with these protocol parameters changed "
                         "(e.g. close_mode=per_finger) and print success k/n per hand x planner, stored and replayed")
    args = ap.parse_intermixed_args(argv)
    ids = args.trials
    if args.overrides is not None:
        overrides = dict(kv.split("=", 1) for kv in args.overrides)
        replay_with(args.run_dir, {k: parse_value(v) for k, v in overrides.items()}, ids, only=tuple(args.only))
        return 0
    if args.versus_summary:
        import pickle

        versus_summary([r for path in args.versus_summary for r in pickle.loads(path.read_bytes())])
        return 0
    if args.versus_plan:
        rows = versus_plan(args.run_dir, ids, only=tuple(args.only))
        if args.save:
            import pickle

            args.save.write_bytes(pickle.dumps(rows))
        versus_summary(rows)
        return 0
    contact = dict(solimp=args.solimp, solref=args.solref)
    if args.summary:
        return summary(args.run_dir, ids, args.friction, args.mass_scale, **contact)
    if not ids:
        trials = stored_trials(args.run_dir)
        ids = [t for t, s in sorted(trials.items()) if s.result.status.value == args.status][:args.max]
    for trial_id in ids:
        stored = find_trial(args.run_dir, trial_id).result
        print(f"== {trial_id}: stored {stored.status.value} (grip {stored.grip_force_n:.2f} N)")
        result, _ = replay_probe(args.run_dir, trial_id, friction=args.friction, mass_scale=args.mass_scale,
                                 **contact)
        print(f"   replayed: {result.status.value}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
