"""`dexopt`: dexterous grasps by descent on a grasp energy (DexGraspNet-style synthesis), for any dexterous hand.

1. The object: the signed distance of the union of its convex collision parts (the geometry MuJoCo simulates;
   the convex hull of the mesh without a built asset) on a grid (`dexopt.GridSdf`, `grid_spacing`).
2. Restarts: `restarts` hand configurations around the object: the palm (TCP z) toward the centre of mass from
   a random direction that does not come from below (z component <= `max_approach_z`), rolled at random about
   it, the TCP a random depth inside the object's surface along that line (the optimisation backs it out),
   shifted sideways by a few mm; the fingers a random fraction (0 to `init_closure`) of the way from the open
   to the closed pre-shape, with noise. `INIT_DRAWS` times as many are drawn; those whose hand is clear of the
   table are kept first (a hand started in the table stays trapped against it).
3. Descent: `iterations` steps of Adam (per restart, per coordinate) on the energy over the root pose
   (translation, rotation in the root frame) and the hand's independent joints (coupled joints follow), all
   gradients analytic: over points in the world, then to the coordinates through MuJoCo's body Jacobians
   (`dexopt_hand`). Step sizes (`step_translation`, `step_rotation`, `step_joints`) decay on a cosine to a
   tenth; joints are projected onto their ranges after each step. The energy (weights `weights`):
   - force closure of one pad per finger (the finger's pad candidate nearest the object, re-chosen every
     `SWITCH_EVERY` steps): |sum_i l_i n_i|^2 + |sum_i l_i (x_i - c) / r x n_i|^2 with n_i the inward unit
     normals, c the centre of mass, r the object's radius and l_i >= `min_force_share` the force shares
     that balance best (`force_shares`; 1 for all is Liu et al.'s estimate);
   - the pads' distance to the surface sum |d_i| (L1, as DexGraspNet: a constant pull);
   - the depth of the hand's surface samples inside the object and below the table top + `table_clearance`;
   - the fingers' mutual penetration (spheres along their links, each pair counted from the least distance the
     hand's own closing motion brings it to with the real links clear, `HandKinematics.sphere_reach`: spheres as
     wide as the link overlapped by 16 mm on the Fourier's side-by-side fingers in the open hand, 10 of its final
     energies of 10-15, its score's AUC 0.31 in trials; counted so no longer: standard 10 N, 7 objects x 10, Fourier
     seed 0 37 -> 59/70, seed 1 40 -> 55/70, Inspire (3 mm) 44 -> 44, 40 -> 42; the Allegro has no such pair);
     joint limits;
   - the pads' centroid away from the centre of mass, |mean_i (x_i - c) / r|^2, meant to let the weight
     hang between the fingers rather than twist out of them (`CENTROID_WEIGHT`).
   The weights (`DEFAULT_WEIGHTS`): the depths (object, table, fingers) at 100, the centroid at 10, since 4 Dec
   2026; before, the depths at 1000 and the centroid at 1. At 1000 the depth barrier ruled the descent: the
   returned grasps ended with their pads off the surface (distance term 2.8 mm summed over the pads, median of
   10, Allegro banana and mustard bottle, planning seed 0, `manigrasp bench`'s 80 restarts x 300 steps) and a
   force-closure residual of 0.068-0.079; at 100 the pads reach it (0.8-0.9 mm) and the residual falls to
   0.026-0.039, the pads' centroid 4-12 mm from the banana's centre of mass instead of 9-56 mm, with the same
   MuJoCo check (deepest planned penetration 0.94 against 0.96 mm). Measured (the dexterous config's 7 objects
   x 10, standard 10 N, paired seeds, `manigrasp bench` with dexopt's `weights` set, the balanced hold),
   successes of 350 (seeds 0-4) -> with the new weights:
   - allegro_right 248 -> 293 (0.71 -> 0.84; pairs held only with them 70, only without 25, exact McNemar
     p = 4e-6): banana 21 -> 43, mustard bottle 10 -> 24, sugar box 27 -> 36 of 50, the rest within 3; on seeds
     5-9, held out, 243 -> 284 (67 / 26, p = 3e-5);
   - the centroid at 10 alone (depths at 1000): 248 -> 259 (55 / 44, p = 0.32); the depths at 100 alone (the
     centroid at 1): 248 -> 277 (63 / 34, p = 0.004);
   - fourier_right seeds 0-2, of 210: 179 -> 183 (25 / 21, p = 0.66); inspire_right 160 -> 158 (27 / 29,
     p = 0.89): no change beyond noise.
   (Earlier, with the depths at 1000 and the floor hold, a centroid weight of 10 gave no gain: 04ffbb2, Allegro
   seed 0 sugar box 2 -> 4, mustard 1 -> 4, can 10 -> 8, mug 8 -> 6/10; Fourier and Inspire mustard 2 and 4/10
   against 6 and 8/10.)
   With `wrap`, every moving finger link is a pad of its own; with `palm`, the palm's front is one more. (Both
   on the Allegro, same runs: sugar box 3/10, mustard 2/10, against 2 and 1/10: the caps of step 6 credit a
   wrap with no more than a fingertip grasp, so the ranking cannot prefer what it would press harder.)
4. Selection, lowest energy first: at least `min_contacts` pads within `contact_tolerance` of the surface;
   a MuJoCo check at the planned configuration in the real scene (hand geoms vs object parts and table,
   `mj_collision`, no margin): a hand that penetrates is first moved out along the contact normals (a few
   mm at most: the surface samples miss what lies between them); fingers that still press in (from opposite
   sides, where moving the hand cannot help) are opened out along their contact normals (`_retract_fingers`; the
   pads are then re-found on the moved hand; Inspire mug: 28 -> 7 of 80 restarts rejected for penetration, 17 -> 27
   candidates; standard 10 N, 7 objects x 10, seed 0: Fourier 59 -> 64, Inspire 44 -> 53/70, Allegro 40 -> 40); then
   its deepest contact must be at most
   `max_penetration`, and so must the hand's own (geoms of different fingers); then non-maximum
   suppression (`nms_distance`, `nms_angle`) for diversity. (The hand's surface samples cover what MuJoCo
   collides, a mesh's convex hull and a box's edges and corners, `dexopt_hand`; with those and the pre-shape's
   `OPEN_TRIES`, over the dexterous config's 21 groups x 80 restarts at 8ac99d2: rejected for penetration
   534 -> 309, for the pre-shape 565 -> 288, passing 459 -> 951; distinct grasps at hold margin >= 2 after
   NMS 96 -> 167 (Allegro 31 -> 53, Fourier 30 -> 75, Inspire 35 -> 39). Success, standard 10 N, same seeds:
   Allegro 32 -> 40/70 (tennis ball 5 -> 10, no `no_grasp` left), Fourier 36 -> 37, Inspire 43 -> 44; 37, 31,
   43 before the `OPEN_TRIES` pre-shapes were ranked after the others (step 6). Those are the seeds the
   changes were chosen on; on seed 1, held out, 8ac99d2 -> f5768df: Allegro 37 -> 44, Fourier 35 -> 40, Inspire
   44 -> 40/70, pooled 116 -> 124/210, as seed 0's 111 -> 121: no single hand's change is significant.)
5. Hand path (`GraspCandidate.joints`, actuator commands): first the pads' remaining gaps are closed (the
   least-norm joint motion moving each pad its distance along its normal, damped least squares): the contact
   command. The squeeze is the actuator forces f that best produce the joint torques sum_i J_i^T n_i pushing
   every pad into the object (least squares through the joint -> command map; with `close_only`, a force
   against the hand's own closing direction is dropped), as a command offset f / kp scaled so the most
   loaded actuator reaches its force limit: row 1 = contact command + `SQUEEZE_REACH` offsets, within the
   command ranges (the protocol's grip regulation stops along the line where the grip force is reached; a
   short line would leave the close slow: its command may run only a fixed fraction of the line ahead of
   the fingers). Row 0, the pre-shape, lies on the same line backwards, far enough that the pads back off
   `preshape_backoff` [m] (first order, within the command ranges); it must be clear (penetration at most
   `max_penetration`) at the grasp pose and along the approach from the pre-grasp pose; if not, the back-off
   is doubled (up to `PRESHAPE_TRIES` tries), then it moves toward the hand's open command (`OPEN_TRIES`: the
   fingers that wrap the object sweep through it along the approach, and those the squeeze leaves idle stay at
   contact on the line; without these tries, 24-50 of 80 Allegro / Inspire mustard-bottle restarts failed here).
   (Pushing each pad with the share the force-closure term balances it with, `force_shares`, instead of the same
   force at every pad: tried on the dexterous config, standard 10 N, seed 0, with the fixes of steps 3-4: Allegro
   40 -> 43, Fourier 64 -> 64, Inspire 53 -> 48/70; not kept.)
   With `balanced_squeeze` (opt-in) the torques may instead be those of the internal forces at the pads that need
   the least friction (`grasp.forces.balanced_forces`: grasp force optimisation over forces that balance the object
   among themselves, each pad pressed at least `min_force_share` of the mean), taken where the actuators turn them
   into a squeeze using less friction than the unit pushes (`dexopt.squeeze_friction` of the torques A^T f each
   produces; in one planning call 32-74 of 42-80 candidates, Allegro mug, Inspire mug, Fourier can; the median
   friction used 0.62 -> 0.46, 1.80 -> 1.09, 2.98 -> 1.37). Why: a replayed Allegro banana grasp ended its close
   with three of five contacts on their friction cones, the object held by the table, and its grip fell from 9.4
   to 1.9 N in the first 0.2 s of the lift. Measured on the dexterous config's 7 objects x 10, standard 10 N, seeds
   0-2, paired (the same planning and trial seeds, `manigrasp bench` with dexopt alone and the parameter set),
   off -> on, of 210: Allegro 124 -> 131 (pairs held only with it 27, only without 20, exact McNemar p = 0.38),
   Fourier 180 -> 190 (19 / 9, p = 0.09), Inspire 162 -> 150 (17 / 29, p = 0.10): no hand's change is beyond
   noise, and the Inspire's goes the other way, below 0.75. With `close_only` off as well, so that the actuators
   can press the balanced forces whole (the planned friction then equals the least, 0.02-0.44 on the Allegro
   banana and mug): Allegro seed 0 30/70 against 40 (mug 4, can 6 against 8, 10). So it stays off. Measured again
   on the Allegro with the fingertip hold of 4 Dec 2026 (`finger_hold: fingertips`), seeds 0-4, of 350: 238 -> 250
   (32 / 20, p = 0.13; sugar box 22 -> 31 of 50, the rest within 2): a lead for a fully actuated hand, not
   beyond noise, so still off.
   (Variants of one planner in one config are not paired: the label enters the group's seed, and two draws of
   the planning seeds moved these hands by up to 16 of 210 with the code unchanged: the same comparison run as
   two planner entries of one config read +20, +15, +4.)

6. Load feasibility (as BODex asks of a grasp, in the protocol's terms): the normal force the squeeze presses
   each pad with (`pad_forces`: lambda >= 0 with sum_i lambda_i J_i^T n_i = A^T f, the squeeze's actuator
   forces f through the joint -> command map A, scipy nnls) is scaled, each side of the grasp (the thumb's
   pads, the others') on its own, so that the side's total is the grip force the protocol regulates,
   min(thumb, rest) of the normal forces (`PlanContext.grip_force_for`): `squeeze_caps`. The regulator holds
   the weaker side at the grip and the stronger side cannot press harder than the weaker pushes back (the
   object moves until they balance; the sum of normal forces in the simulation is about twice the grip).
   `dexopt.hold_margin` (one LP) then asks whether contact forces within those caps, inside
   linearised friction cones (`friction`) with soft-contact torsion (`torsion`), balance the object's
   weight alone and with each of the protocol's perturbations (`hold.loads`; the object's mass from its
   asset). Candidates whose margin reaches `min_hold_margin` come first (lowest energy first among them),
   the rest after them by margin; within each of the two, pre-shapes along the squeeze line before those of
   the `OPEN_TRIES` (in trials on the dexterous config the latter succeeded 16/45, the former 95/165; at
   margin >= 2, 14/29 and 52/73); diversity (non-maximum suppression) is applied to that order.
   Each candidate also gets the turn [rad] the held object would take under those loads, from the grasp's
   stiffness (`dexopt.grasp_stiffness` over the pads in contact: `CONTACT_STIFFNESS` in series with the held
   servos, `held_joint_stiffness`; `dexopt.load_rotation`): recorded (`Synthesis.rotation`), not used to rank.
   On the dexterous config at fd0aae5 (240 dexopt trials, `bench_dexopt.py --run`) it predicts 0.1-4 deg
   where the drops turned 4-12 deg in the simulation (slip and rolling, which it does not model), and among
   the grasps that pass the load test it adds nothing to the margin: Allegro < 1 deg 18/26 succeed, >= 1 deg
   6/13, but at margin >= 2 the low turns are no better (< 0.3 deg 6/9, 0.3-1 deg 5/7); Inspire and Fourier
   all under 1 deg. The margin separates: successes at margin [1, 1.3) 10/23, [1.3, 2) 19/37, >= 2 63/78
   (three hands), hence `min_hold_margin` 2.
   Each candidate also gets the friction its squeeze alone uses (`dexopt.squeeze_friction` over the touching
   pads and the squeeze's joint torques, divided by `friction`; `Synthesis.friction_used`), the planner's
   estimate of the simulated close's `friction_used` (`CloseResult`): recorded, not used to rank. On the
   Allegro at 04ffbb2 (standard 10 N; 90 trials matched to their grasps by TCP pose: seed 0 can, mug, sugar
   box, potted meat, banana, tennis ball, seed 1 can, mug, sugar box) it predicts: successes at < 0.3
   29/33, [0.3, 0.45) 23/35, [0.45, 0.6) 8/12, >= 0.6 1/10 (banana 0/5, sugar box 0/2, mug 1/3); the
   banana's slip out in the lift (replayed trial 0003 ends its close with every contact on its cone,
   0.99-1.00, and the grip falls from 6 to 0.8 N in the lift). Ranking those over 0.6
   after the others (tried, not kept; banana, mug, sugar box, potted meat x 10 on the Allegro, seed 0 / seed 1,
   against 19 / 24 of 40): within each group of the hold test 20 / 24, after every other candidate 20 / 23: no
   gain, because the benchmark runs all `n` candidates returned and the diverse pool seldom has another one
   to bring in (the banana keeps 7 that hold). A term of the energy is the next thing to try. On the five-finger
   hands (tendon-coupled joints) the estimate reads 2-10 on a test can (12 restarts x 100 steps): unchecked.
7. The closing check (opt-in, `close_check` > 0; GraspIt!-style: simulate the close, then judge the contacts):
   after steps 4-6 and the non-maximum suppression, the first `close_check` candidates in that order are closed
   in MuJoCo as the protocol closes (`CloseSimulation`: `protocol.phases.close` on a `TrialRun` in a scene of
   the hand and the object free on the table, gravity on, the grip force `PlanContext.grip_force_for`; the hand
   starts at the grasp pose with its fingers at the pre-shape, as at the end of the approach; no lift, no
   perturbation), until `n` pass. A candidate passes when the close grips the object without a defect of
   benchmarks/diagnose_dexterous.py's `close_defects` (object pushed over 5 mm, a finger's contacts over
   15 mm from its planned pad, the thumb pressing mostly off its planned pads, over 0.55 of the friction used
   by the squeeze alone) and the load test of step 6 on the simulated contacts (each link's contacts lumped,
   the simulated normal forces as caps) reaches `min_hold_margin`. Passing candidates come first, those whose
   close failed (`no_contact`, `unstable`) last, the rest in between, each in the order of step 6. (Ranking
   the unchecked before those that gripped but did not pass, and these by fewest defects then simulated
   margin, lost 26 -> 19/40 Allegro and 20 -> 14/40 Fourier on the runs measured next.) (In the replayed dexterous
   trials at margin >= 2, those without a defect succeeded 18/20, at margin >= 1.3 32/35;
   diagnose_dexterous.py.) Measured (tomato soup can, mustard bottle, potted meat can, mug x allegro_right,
   fourier_right x 10 grasps, standard 10 N, `manigrasp bench`; off -> `close_check: 30` -> with
   `close_defects: false`): seed 0 Allegro 26 -> 25 -> 26/40, Fourier 20 -> 21 -> 22/40; seed 1 Allegro
   25 -> 26 -> 25/40, Fourier 24 -> 24 -> 26/40: no gain beyond noise. The benchmark runs every one of the
   `n` candidates returned, so only a candidate the check brings into the first `n` (or pushes out) can move
   its figures, not the order within them; and few candidates pass: of the 10
   returned per group (same objects, planning seed 0, in-process trials), Allegro 15/40 (13 of them succeeded,
   against 12 of the other 25; the can's 10 passed already ranked first), Fourier 0/40 (its fingers' contacts
   over 15 mm (up to 67 mm) from the planned pads in 32 of 40; 24 of the 40 succeeded all the same). The
   simulated margin alone separates them better: >= 1.3 Allegro 24/33 succeeded, Fourier 14/18; < 1.3 1/7 and
   10/22 (hence `close_defects`; on a larger sample it is untested). Planning
   CPU per Allegro grasp (10 asked, one call, `time.process_time`): can 1.25 -> 1.52 s (15 closes), mustard
   1.41 -> 1.59 s (30), potted meat 1.26 -> 1.38 s (30), mug 1.52 -> 1.81 s (24).
   The check can also judge by the simulated contacts' Ferrari-Canny epsilon (`close_min_epsilon`, `CloseResult.
   epsilon`: computed as the trials compute their `sim_epsilon_l1` at the end of the close), name the defects
   that fail (`close_defects: [friction-used]`), set its own margin (`close_min_margin`) and order each class by
   that epsilon (`close_order: epsilon`). Why: in the trials the end-of-close epsilon separates successes best
   (dexterous config at 62178f2, standard, seed 0: >= 0.2 Allegro 33/38, Fourier 13/13, Inspire 20/20; < 0.1
   1/9, 10/34, 12/30; report AUC 0.85-0.91; benchmarks/diagnose_dexterous.py). Measured on the dexterous config's
   7 objects x 10, standard 10 N (`manigrasp bench` with a config of dexopt's params; Allegro, Fourier, Inspire
   of 70; the defaults give 40, 37, 44 on seed 0):
   - `close_check: 30, close_defects: [friction-used]`: -, 41, 45;
   - `close_check: 40, close_defects: false, close_min_epsilon: 0.15`: 39, 42, 46;
   - `close_check: 60`, the same with `close_min_margin: 0, close_order: epsilon`: 42, 43, 44;
   - the same with `restarts: 160, close_check: 100`: 44, 41, 55, planning 52-58 s per call of 10 against about
     30 s (two jobs on a shared 2-core machine); on seed 1: 39, 38, 45 against the defaults' 44, 40, 40/70.
     Pooled over the two seeds the Inspire's 84/140 -> 100/140 (Fisher p = 0.06): a lead for that hand, not yet
     a result, and not the 0.75 on seed 1 (0.64); the Allegro's 84 -> 83 and the Fourier's 77 -> 79: nothing.
     Few candidates close well: at 80 restarts, 14-48 per group after the suppression, of them closes at epsilon >=
     0.15 Fourier soup can 16/34, potted meat 12/30, Inspire mug 3/14, Allegro mustard 20/48 (all closed,
     `close_check: 1000`, `benchmarks/bench_dexopt.py --closes`); and the trials' own close does not always
     reproduce the check's (Fourier: 43 of its 70 trials end the close at epsilon >= 0.15, 34 of them succeed). So
     it stays opt-in; a larger pool of well-closing candidates (the closing motion in the energy) is what it needs.

Score = 1 / (1 + E) (in (0, 1], higher is better) with E the final energy.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar

import mujoco
import numpy as np
import trimesh

from manigrasp.contact.defaults import STANDARD_MU, STANDARD_TORSION_M
from manigrasp.control.hold import HOLD_GAIN
from manigrasp.errors import ConfigError
from manigrasp.geometry import perpendicular_basis
from manigrasp.grasp.closure import EPSILON_TOLERANCE
from manigrasp.grasp.forces import balanced_forces
from manigrasp.hands.base import Hand
from manigrasp.objects.pipeline import DEFAULT_DENSITY
from manigrasp.planners.base import PREGRASP_OFFSET, GraspCandidate, Observation, ObservationKind
from manigrasp.planners.collision import HandProbe
from manigrasp.planners.context import PlanContext, resolve
from manigrasp.planners.dexopt import (
    EnergyWeights,
    GridSdf,
    grasp_stiffness,
    hold_margin,
    load_rotation,
    squeeze_friction,
)
from manigrasp.planners.dexopt_hand import HandKinematics
from manigrasp.planners.geometry import tcp_frames
from manigrasp.planners.hold import loads
from manigrasp.planners.metrics import ContactModel, grasp_metrics, torque_scale
from manigrasp.planners.nms import DEFAULT_ANGLE, DEFAULT_DISTANCE, suppress
from manigrasp.sim.compose import HAND_PREFIX

CENTROID_WEIGHT = 10.0  # the pads' centroid a tenth of the object's radius from the centre of mass costs 0.1
# Weights of the energy's terms for this planner [-] (DexGraspNet's relative scale, distances in m): a pad 1 cm
# off the surface costs as much as a unit force imbalance of the normals, and so does 1 cm of summed sample depth
# (object, table, fingers); the MuJoCo check of the selection (step 4), not the energy, keeps the planned hand
# within `max_penetration`. (At 1000 for the depths the barrier ruled the descent: module docstring, step 3.)
DEFAULT_WEIGHTS = EnergyWeights(force_closure=1.0, distance=100.0, penetration=100.0, table=100.0, joints=10.0,
                                self_penetration=100.0, centroid=CENTROID_WEIGHT)
GRID_MARGIN = 0.03  # [m] the SDF grid extends this far beyond the object's parts
# Adam's moment decays: a short second-moment memory, so the early penetration gradients (100 x the late ones)
# do not freeze the end of the descent.
ADAM_BETAS = (0.9, 0.95)
PRESHAPE_TRIES = 4  # pre-shape back-offs tried: 1, 2, 4, 8 x preshape_backoff
# Then these fractions of the way from the last back-off to the hand's open command (every actuator opens, also
# those the squeeze leaves idle, which stay at contact along the line).
OPEN_TRIES = (0.5, 1.0)
SWITCH_EVERY = 10  # descent steps between re-choosing each finger's pad (the candidate nearest the object)
SQUEEZE_REACH = 3.0  # the squeeze row lies this many saturating offsets past contact (`hand_path`)
GAP_DAMPING = 1e-4  # [m^2] damping of the least-squares gap closure of the pads (`hand_path`)
BACK_OFF_STEPS = 4  # moves of a penetrating hand out of the object and table (`_back_off`)
BACK_OFF_EXTRA = 2e-4  # [m] each move goes this much past the deepest penetration
INIT_DRAWS = 4  # initial configurations drawn per restart (those clear of the table are kept)
FORCE_SHARE_STEPS = 30  # projected-gradient steps of the contact force shares (`force_shares`)
# Normal and tangential stiffness of a fingertip contact [N/m] in the grasp-stiffness estimate (`grasp_stiffness`;
# an assumed order of magnitude for the rubber fingertips: the parallel jaw's pad is 3.4e4 N/m).
CONTACT_STIFFNESS = 1e4
APPROACH_CHECKS = 6  # poses checked along the approach from the pre-grasp pose to the grasp pose
# The simulated close's defects (`CloseSimulation`; the thresholds of benchmarks/diagnose_dexterous.py's
# `close_defects`) and what counts as touching.
PUSHED_MAX = 0.005  # [m] the object pushed on the table by the close
GAP_MAX = 0.015  # [m] a finger's contacts from its planned pad
FRICTION_USED_MAX = 0.55  # [-] friction used by the squeeze alone
TOUCH_N = 0.1  # [N] a finger or link pressing at least this touches
CLOSE_DEFECTS = ("pushed", "off-plan", "thumb-off-pad", "friction-used")  # `CloseResult.defects`, in that order
CLOSE_ORDERS = ("plan", "epsilon")  # `DexOptPlanner.close_order`


@dataclass
class Synthesis:
    """The result of `DexOptPlanner.synthesise` for one restart that passed the checks.

    Attributes:
        pose: (4, 4) TCP pose in the world [m].
        q: (n_q,) the hand's independent joints at contact [rad or m].
        joints: (2, n_act) pre-shape and squeeze commands.
        energy: final energy and `terms` its parts (unweighted).
        contacts, normals: (k, 3) pad points in the world [m], inward unit normals (pads within tolerance).
        penetration: deepest hand-object/table penetration measured in MuJoCo [m] (>= 0).
        hold: hold margin of the contacts at the protocol's squeeze and loads (`dexopt.hold_margin`; >= 1:
            contact forces the hand can press hold them all).
        rotation: the largest turn [rad] of the held object under those loads that the grasp's stiffness
            predicts (`dexopt.grasp_stiffness`, `dexopt.load_rotation`; inf: a load along a direction the
            contacts cannot hold); recorded, not used to rank (module docstring, step 6).
        opened: the pre-shape is one of the `OPEN_TRIES` toward the open hand (ranked after the others).
        friction_used: the friction the squeeze alone uses over the friction the hold test assumes
            (`dexopt.squeeze_friction` / `friction`; > 1: the squeeze pushes some pad outside its cone); recorded,
            not used to rank (module docstring, step 6).
        fingers, bodies: (k,) the finger (index into `Hand.finger_bodies`, 0 the thumb) and the body (id in
            `HandKinematics.model`) of each pad in `contacts`.
        friction: (k, 2) sliding [-] and torsional [m] friction of the hand geom each pad lies on, as the scene
            compiled it (`surface_friction`), or None where a pad's geom cannot be found there.
        close: what the simulated close gave (`CloseSimulation.check`), None if not simulated (step 7).
    """

    pose: np.ndarray
    q: np.ndarray
    joints: np.ndarray
    energy: float
    terms: dict[str, float]
    contacts: np.ndarray
    normals: np.ndarray
    penetration: float
    hold: float = float("inf")
    rotation: float = 0.0
    opened: bool = False
    friction_used: float = 0.0
    fingers: np.ndarray | None = None
    bodies: np.ndarray | None = None
    friction: np.ndarray | None = None
    close: CloseResult | None = None


@dataclass(frozen=True)
class DexOptPlanner:
    """Optimisation-based dexterous grasp synthesis (module docstring).

    After each call, `last["rejected"]` counts the restarts each check of step 4-5 turned down, and
    `last["retracted"]` those whose fingers `_retract_fingers` opened out of the object (step 4).

    Attributes:
        restarts: random initial configurations optimised together (80 with 300 `iterations`: 1.43-1.54 s CPU
            per Allegro grasp (2.02-2.05 s before the batched Jacobians of `HandKinematics.evaluate`, the same
            grasps bit for bit, measured side by side on one shared machine), `bench_dexopt.py --hands
            allegro_right --objects 005_tomato_soup_can 025_mug --grasps 10`; against 96 x 150, 1.09 s, on the
            dexterous config (standard only, 10 N, compliant pads, same seeds) at cd46f5e: Allegro 30 -> 37/80
            (sugar box 1 -> 5, mug 6 -> 7, potted meat 5 -> 6, banana 2 -> 3, can 9 -> 10, tennis ball 7 -> 5:
            fewer than 10 diverse grasps passed, 5 `no_grasp`), Fourier 36 -> 36, Inspire 43 -> 44; at fd0aae5
            28, 36, 43 -> 32, 36, 44. The longer descent brings more restarts' pads onto the surface (96
            restarts, 150 -> 300 steps): Allegro mug 54 -> 24 of them rejected for fewer than 3 pads in contact,
            banana 51 -> 19, and more of them hold (margin >= 1.5 after NMS: mug 6 -> 12, banana 3 -> 8).
            Earlier: 96 x 150 gave 31, 27, 18/80 (rigid pads) against 26, 22, 12/80 for 48 and 26, 18, 8/80
            for 32 restarts.)
        iterations: descent steps.
        step_translation: [m], step_rotation: [rad], step_joints: [rad]: initial Adam steps.
        weights: the energy's weights (`dexopt.EnergyWeights`; a mapping of its fields in a config).
        grid_spacing: [m] of the object's signed-distance grid.
        table_clearance: [m] the hand's samples are penalised below the table top + this.
        init_closure: largest fraction of the open -> closed pre-shape of the initial fingers [-].
        max_approach_z: largest z component of the initial approach direction (0: horizontal or from above).
        palm: the palm's front is one more contact of the energy (a power grasp), besides one pad per finger;
            the load test credits it with what the fingers press the object into it (`palm_reaction`,
            `squeeze_caps`; before, it was credited nothing: Allegro, `palm` and `wrap`, sugar box and mustard
            bottle x 10, standard 10 N, seed 0: 6 -> 8/20, against 3/20 for the fingertip default).
        wrap: every moving finger link is a contact of its own (the fingers wrap), not only the fingertips.
        close_only: the squeeze moves each actuator only along the hand's own closing direction (open ->
            closed command); an actuator whose best force would open it stays put. On (the default): on the
            dexterous config it raised the successes from 22, 11, 5/80 to 26, 18, 8/80 (Inspire, Fourier,
            Allegro; fewer stalled closes), docs/planners.md.
        balanced_squeeze: the squeeze may press the pads with the internal forces that need the least friction
            (`grasp.forces.balanced_forces`) instead of equal pushes along their normals, where the actuators turn
            them into a squeeze using less friction (module docstring, step 5). Off (the default): measured no
            better beyond noise, and worse on the Inspire.
        min_force_share: smallest force of a pad relative to the mean in the force-closure term (1: all
            pads push equally, Liu et al.; `force_shares`).
        contact_tolerance: [m] a pad this close to the surface is in contact.
        min_contacts: fewest pads in contact (capped at the hand's number of fingers).
        max_penetration: [m] deepest penetration allowed in the MuJoCo check.
        preshape_backoff: [m] how far the pre-shape opens the pads from the object (first order).
        nms_distance: [m]; nms_angle: [rad] (non-maximum suppression thresholds).
        pregrasp_offset: pre-grasp distance back along the approach [m] over which the pre-shape is checked;
            None: the protocol's (`PlanContext.pregrasp_offset`).
        friction: sliding friction [-] of the hand-object contacts the hold test assumes; None (the
            default): the scene's, `PlanContext.contact_friction` (the fingertips' rubber, 1.0, with
            ``scene.pads: compliant``; the hand's 0.5 with rigid pads), or 0.5 (`STANDARD_MU`) when the
            context does not know it (a planner called directly, `manigrasp plan`). `contact_friction`. That
            friction is the fingertips' (`Hand.fingertip_geoms`); pads elsewhere (`palm`, `wrap`) are held at the
            scene's own friction of their link, the hand's 0.5 (`hold_friction`), unless `friction` is set.
            The candidates carry each contact's friction as the scene compiled it
            (`GraspCandidate.contact_friction`), which the trial's planned metrics use.
        torsion: torsional friction [m] of those contacts (soft fingers).
        min_hold_margin: grasps whose hold margin (step 6) reaches this come first [-] (2: at margin >= 2, 63
            of 78 dexopt trials of the dexterous config succeeded, at [1, 2) 29 of 60, step 6; the order alone,
            2 instead of 1 at 96 x 150, moved nothing: Allegro, Fourier, Inspire 29, 37, 42/80 against 28, 36, 43).
        density: of an object without a built asset, for its mass [kg/m^3].
        close_check: how many of the best-ranked candidates the closing check (step 7) closes in the
            simulation at most (it stops once the `n` asked for pass); 0 (the default): off.
        close_defects: which defects of the simulated close fail a candidate in the closing check: True all of
            `CLOSE_DEFECTS`, False none (only the load test on the simulated contacts decides, step 7), or a list
            of their names (e.g. ``[friction-used]``).
        close_min_epsilon: a candidate passes the closing check only if the simulated contacts' Ferrari-Canny
            epsilon (L1, the trials' `sim_epsilon_l1`, `CloseResult.epsilon`) reaches this [-]; 0: not asked.
        close_min_margin: the simulated contacts' load-test margin a candidate needs to pass the closing check;
            None: `min_hold_margin`.
        close_order: within each class of the closing check's ranking (passed, not checked or gripped without
            passing, failed), "plan": the order of step 6; "epsilon": the simulated epsilon, highest first.
    """

    name: ClassVar[str] = "dexopt"
    needs: ClassVar[ObservationKind] = "mesh"
    hand_kinds: ClassVar[tuple[str, ...]] = ("dexterous",)

    restarts: int = 80
    iterations: int = 300
    step_translation: float = 0.003
    step_rotation: float = 0.03
    step_joints: float = 0.05
    weights: EnergyWeights = DEFAULT_WEIGHTS
    grid_spacing: float = 0.0025
    table_clearance: float = 0.003
    init_closure: float = 0.3
    max_approach_z: float = 0.0
    min_force_share: float = 0.3
    palm: bool = False
    wrap: bool = False
    close_only: bool = True
    balanced_squeeze: bool = False
    contact_tolerance: float = 0.02
    min_contacts: int = 3
    max_penetration: float = 0.001
    preshape_backoff: float = 0.02
    nms_distance: float = DEFAULT_DISTANCE
    nms_angle: float = DEFAULT_ANGLE
    pregrasp_offset: float | None = None
    friction: float | None = None
    torsion: float = STANDARD_TORSION_M
    min_hold_margin: float = 2.0
    density: float = DEFAULT_DENSITY
    close_check: int = 0
    close_defects: bool | tuple[str, ...] = True
    close_min_epsilon: float = 0.0
    close_min_margin: float | None = None
    close_order: str = "plan"
    _hands: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    last: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if isinstance(self.weights, dict):  # the terms named change, the others keep the planner's defaults
            try:
                object.__setattr__(self, "weights",
                                   EnergyWeights(**{**dataclasses.asdict(DEFAULT_WEIGHTS), **self.weights}))
            except TypeError as exc:
                raise ConfigError(f"dexopt: bad weights {sorted(self.weights)}; valid: "
                                  f"{[f.name for f in dataclasses.fields(EnergyWeights)]}") from exc
        for key in ("restarts", "iterations", "min_contacts"):
            if int(getattr(self, key)) < 1:
                raise ConfigError(f"dexopt: {key} must be >= 1, got {getattr(self, key)}")
        for key in ("step_translation", "step_rotation", "step_joints", "grid_spacing", "contact_tolerance",
                    "preshape_backoff"):
            if not float(getattr(self, key)) > 0:
                raise ConfigError(f"dexopt: {key} must be > 0, got {getattr(self, key)}")
        negative_friction = self.friction is not None and self.friction < 0
        if negative_friction or self.torsion < 0 or self.min_hold_margin < 0 or not self.density > 0:
            raise ConfigError("dexopt: friction, torsion and min_hold_margin must be >= 0, density > 0")
        if int(self.close_check) < 0:
            raise ConfigError(f"dexopt: close_check must be >= 0 (0: off), got {self.close_check}")
        if not self.close_min_epsilon >= 0:
            raise ConfigError(f"dexopt: close_min_epsilon must be >= 0, got {self.close_min_epsilon}")
        if self.close_min_margin is not None and not self.close_min_margin >= 0:
            raise ConfigError(f"dexopt: close_min_margin must be >= 0 or None, got {self.close_min_margin}")
        if self.close_order not in CLOSE_ORDERS:
            raise ConfigError(f"dexopt: unknown close_order {self.close_order!r}; valid: {', '.join(CLOSE_ORDERS)}")
        if not isinstance(self.close_defects, bool):
            names = (self.close_defects,) if isinstance(self.close_defects, str) else tuple(self.close_defects)
            unknown = [d for d in names if d not in CLOSE_DEFECTS]
            if unknown:
                raise ConfigError(f"dexopt: unknown close_defects {unknown}; valid: true, false or a list of "
                                  f"{', '.join(CLOSE_DEFECTS)}")
            object.__setattr__(self, "close_defects", names)
        if self.max_penetration < 0 or self.table_clearance < 0 or not 0 <= self.init_closure <= 1:
            raise ConfigError("dexopt: max_penetration and table_clearance must be >= 0, init_closure in [0, 1]")

    @property
    def failing_defects(self) -> tuple[str, ...]:
        """The defects of the simulated close that fail a candidate (`close_defects` resolved)."""
        if isinstance(self.close_defects, bool):
            return CLOSE_DEFECTS if self.close_defects else ()
        return self.close_defects

    def contact_friction(self, context: PlanContext | None = None) -> float:
        """The sliding friction [-] the hold test assumes: `friction` if set, else the scene's
        (`PlanContext.contact_friction` of `context`), else `STANDARD_MU`."""
        if self.friction is not None:
            return float(self.friction)
        if context is not None and context.contact_friction is not None:
            return float(context.contact_friction)
        return STANDARD_MU

    def hold_friction(self, hk: HandKinematics, geoms: np.ndarray, surface: np.ndarray | None,
                      context: PlanContext | None = None) -> np.ndarray:
        """(k,) the sliding friction [-] the hold test assumes at pads on the hand geoms `geoms` (ids in
        `hk.model`): `friction` if set; else, in a scene whose grasping surfaces' friction the context knows,
        `contact_friction` on those surfaces (`Hand.fingertip_geoms`, `Hand.pad_geoms`) and the scene's compiled
        friction `surface` (k, 2) (`surface_friction`) on the other links and the palm (`wrap`, `palm`: the
        hand's 0.5, not the fingertips' rubber); else `contact_friction` everywhere."""
        context = resolve(context)
        tip = self.contact_friction(context)
        k = len(geoms)
        if self.friction is not None or context.contact_friction is None or surface is None:
            return np.full(k, tip)
        grasping = set(hk.hand.fingertip_geoms) | set(hk.hand.pad_geoms)
        on_tip = np.array([hk.model.geom(int(g)).name in grasping for g in geoms], bool)
        return np.where(on_tip, tip, surface[:, 0])

    # ------------------------------------------------------------------ planner interface
    def plan(self, observation: Observation, hand: Hand, n: int, rng: np.random.Generator,
             context: PlanContext | None = None) -> list[GraspCandidate]:
        """At most `n` grasps, lowest energy first, for the protocol described by `context` (None: standard)."""
        context = resolve(context, self.pregrasp_offset)
        offset = context.pregrasp_offset
        found = self.synthesise(observation, hand, n, rng, offset, context)
        center = observation.center_of_mass
        scale = torque_scale(observation.world_mesh().vertices, center)
        out = []
        for s in found:
            eps = None
            if len(s.contacts) >= 2:
                eps = float(grasp_metrics(s.contacts[None], s.normals[None], center, scale,
                                          ContactModel(min_friction=False)).epsilon_l1[0])
            out.append(GraspCandidate(
                pose=s.pose, score=1.0 / (1.0 + s.energy), width=None, preshape=0.0, contacts=s.contacts,
                contact_normals=s.normals, contact_friction=s.friction, epsilon_l1=eps,
                force_closure=None if eps is None else bool(eps > EPSILON_TOLERANCE),
                pregrasp_offset=offset, planner=self.name, joints=s.joints))
        return out

    def kinematics(self, hand: Hand) -> HandKinematics:
        """The hand's kinematic model, built once per hand name."""
        if hand.name not in self._hands:
            self._hands[hand.name] = HandKinematics(hand, palm=self.palm, wrap=self.wrap)
        return self._hands[hand.name]

    def object_sdf(self, observation: Observation) -> GridSdf:
        """The signed-distance grid of the observed object's collision parts in the world."""
        pose = observation.object_pose
        if observation.asset is not None and observation.asset.part_paths:
            parts = [np.asarray(trimesh.load(str(p), force="mesh", process=False).vertices, float)
                     for p in observation.asset.part_paths]
        else:
            parts = [np.asarray(observation.mesh.convex_hull.vertices, float)]
        parts = [v @ pose[:3, :3].T + pose[:3, 3] for v in parts]
        return GridSdf.from_convex_parts(parts, self.grid_spacing, GRID_MARGIN)

    # ------------------------------------------------------------------ synthesis
    def synthesise(self, observation: Observation, hand: Hand, n: int, rng: np.random.Generator,
                   pregrasp_offset: float | None = None, context: PlanContext | None = None) -> list[Synthesis]:
        """Optimise `restarts` configurations and return at most `n` that pass the checks, best first; the
        pre-shape is checked over `pregrasp_offset` [m] (None: this planner's, else the standard protocol's),
        the hold margin at `context`'s grip force and loads (None: the standard protocol's)."""
        offset = resolve(None, pregrasp_offset if pregrasp_offset is not None else self.pregrasp_offset
                         ).pregrasp_offset
        hk = self.kinematics(hand)
        sdf = self.object_sdf(observation)
        center = observation.center_of_mass
        scale = torque_scale(observation.world_mesh().vertices, center)
        pos, quat, q = self.initial(hk, sdf, center, hand.max_width, rng, observation.table_height)
        pos, quat, q, energy, terms = self.descend(hk, sdf, center, scale, observation.table_height, pos, quat, q)
        return self.select(hk, sdf, observation, pos, quat, q, energy, terms, n, offset, context)

    def initial(self, hk: HandKinematics, sdf: GridSdf, center: np.ndarray, width: float,
                rng: np.random.Generator, table_z: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Root positions (R, 3), quaternions (R, 4) and joints (R, n_q) of the restarts (module docstring):
        `INIT_DRAWS` x R drawn, those clear of the table (+ clearance) kept first, in the order drawn."""
        pos, quat, q = self._draw(hk, sdf, center, width, rng, INIT_DRAWS * self.restarts)
        xpos, xmat, *_ = hk.evaluate(pos, quat, q, jacobians=False)
        lowest = hk.world(hk.samples, xpos, xmat)[..., 2].min(axis=1)
        order = np.argsort(lowest < table_z + self.table_clearance, kind="stable")[:self.restarts]
        return pos[order], quat[order], q[order]

    def _draw(self, hk: HandKinematics, sdf: GridSdf, center: np.ndarray, width: float, rng: np.random.Generator,
              r: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        approach = np.zeros((0, 3))
        while len(approach) < r:
            a = rng.normal(size=(2 * r, 3))
            a /= np.linalg.norm(a, axis=1, keepdims=True)
            approach = np.concatenate([approach, a[a[:, 2] <= self.max_approach_z]])[:r]
        u, v = perpendicular_basis(approach)
        roll = rng.uniform(0.0, 2.0 * np.pi, r)
        closing = np.cos(roll)[:, None] * u + np.sin(roll)[:, None] * v
        surface = _ray_to_surface(sdf, center, -approach)  # distance centre -> surface, per restart
        depth = rng.uniform(0.0, 0.5, r) * 0.5 * width
        lateral = rng.normal(scale=0.005, size=(r, 2))
        tcp_pos = (center - approach * (surface - depth)[:, None] + lateral[:, :1] * u + lateral[:, 1:] * v)
        tcp = tcp_frames(tcp_pos, approach, closing)
        root = tcp @ hk.root_in_tcp
        s = rng.uniform(0.0, self.init_closure, (r, 1))
        q = hk.q_open + s * (hk.q_closed - hk.q_open) + rng.normal(scale=0.05, size=(r, hk.n_q))
        return root[:, :3, 3].copy(), _mat_quats(root[:, :3, :3]), np.clip(q, hk.low, hk.high)

    def energy(self, hk: HandKinematics, sdf: GridSdf, center: np.ndarray, scale: float, table_z: float,
               pos: np.ndarray, quat: np.ndarray, q: np.ndarray, gradient: bool = True,
               chosen: np.ndarray | None = None) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray | None]:
        """Energies (R,), their unweighted terms (R,) each, and the gradient (R, 6 + n_q) (module docstring).

        `chosen` (R, fingers): the pad candidate of each finger (default: the one nearest the object now).
        """
        w = self.weights
        xpos, xmat, jp, jr, _ = hk.evaluate(pos, quat, q, jacobians=gradient)
        r = len(pos)
        # Pads: force closure and distance.
        if chosen is None:
            chosen = choose_pads(sdf, hk.world(hk.contacts, xpos, xmat), hk.pad_finger)  # (R, fingers)
        rows = np.arange(r)[:, None]
        slot = hk._slot[hk.contacts.bodies[chosen]]  # (R, k)
        x = xpos[rows, slot] + np.einsum("rkij,rkj->rki", xmat[rows, slot], hk.contacts.local[chosen])  # (R, k, 3)
        k = x.shape[1]
        d, g, hess = sdf.sdf(x.reshape(-1, 3))
        d, g, hess = d.reshape(r, k), g.reshape(r, k, 3), hess.reshape(r, k, 3, 3)
        gnorm = np.maximum(np.linalg.norm(g, axis=2, keepdims=True), 1e-9)
        normal = -g / gnorm
        proj = np.eye(3) - normal[..., :, None] * normal[..., None, :]
        d_normal = -np.einsum("rkij,rkjl->rkil", proj, hess) / gnorm[..., None]  # dn/dx (R, k, 3, 3)
        arm = (x - center) / scale
        share = force_shares(np.concatenate([normal, np.cross(arm, normal)], axis=2), self.min_force_share)
        force = np.einsum("rk,rki->ri", share, normal)
        torque = np.einsum("rk,rki->ri", share, np.cross(arm, normal))
        e_fc = (force**2).sum(axis=1) + (torque**2).sum(axis=1)
        d_cross = -_skew(normal) / scale + np.einsum("rkij,rkjl->rkil", _skew(arm), d_normal)
        g_fc = 2.0 * share[..., None] * (np.einsum("rkji,rj->rki", d_normal, force)
                                         + np.einsum("rkji,rj->rki", d_cross, torque))
        e_dis = np.abs(d).sum(axis=1)
        offset = arm.mean(axis=1)  # (R, 3) the pads' centroid from the centre of mass, over the object's radius
        e_cen = (offset**2).sum(axis=1)
        g_pad = (w.force_closure * g_fc + w.distance * np.sign(d)[..., None] * g
                 + w.centroid * 2.0 * offset[:, None] / (k * scale))
        # Surface samples: object and table penetration.
        # Only the samples of bodies that may reach into the object's box or below the table's top are placed.
        top = table_z + self.table_clearance
        lo, hi = (sdf.solid if sdf.solid is not None else (np.full(3, -np.inf), np.full(3, np.inf)))
        s_row, s_col, p = hk.world_near(hk.samples, xpos, xmat, lo, hi, top)  # (N,), (N,), (N, 3)
        which, ds, gs = sdf.penetrating(p)
        e_pen = np.bincount(s_row[which], weights=-ds, minlength=r)
        g_samples = np.zeros(p.shape)
        g_samples[which] = -w.penetration * gs
        low = p[:, 2] < top
        e_tab = np.bincount(s_row[low], weights=top - p[low, 2], minlength=r)
        g_samples[low, 2] -= w.table
        # Finger spheres: mutual penetration of different fingers.
        c = hk.world(hk.spheres, xpos, xmat)  # (R, s, 3)
        diff = c[:, :, None] - c[:, None]
        dist = np.linalg.norm(diff, axis=3)
        reach = hk.sphere_reach
        pairs = dist < reach  # pairs on different fingers only (reach 0 on one finger)
        e_self = 0.5 * np.where(pairs, reach - dist, 0.0).sum(axis=(1, 2))
        unit = diff / np.maximum(dist, 1e-9)[..., None]
        g_spheres = -w.self_penetration * np.where(pairs[..., None], unit, 0.0).sum(axis=2)
        # Joint limits (the descent projects onto the ranges; the term is for completeness).
        over, under = np.maximum(q - hk.high, 0.0), np.maximum(hk.low - q, 0.0)
        e_jnt = (over + under).sum(axis=1)
        total = (w.force_closure * e_fc + w.distance * e_dis + w.penetration * e_pen + w.table * e_tab
                 + w.self_penetration * e_self + w.joints * e_jnt + w.centroid * e_cen)
        terms = {"force_closure": e_fc, "distance": e_dis, "penetration": e_pen, "table": e_tab,
                 "self_penetration": e_self, "joints": e_jnt, "centroid": e_cen}
        if not gradient:
            return total, terms, None
        torque = np.cross(x - xpos[rows, slot], g_pad)
        grad = (np.einsum("rki,rkij->rj", g_pad, jp[rows, slot]) + np.einsum("rki,rkij->rj", torque, jr[rows, slot])
                + _pair_backprop(hk, hk.samples, s_row, s_col, p, g_samples, xpos, jp, jr,
                                 np.union1d(which, np.flatnonzero(low)))
                + _sparse_backprop(hk, hk.spheres, c, g_spheres, xpos, jp, jr))
        grad[:, 6:] += w.joints * ((q > hk.high).astype(float) - (q < hk.low).astype(float))
        return total, terms, grad

    def descend(self, hk: HandKinematics, sdf: GridSdf, center: np.ndarray, scale: float, table_z: float,
                pos: np.ndarray, quat: np.ndarray, q: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Adam descent from the given configurations; returns them optimised with their energies and terms."""
        pos, quat, q = pos.copy(), quat.copy(), q.copy()
        steps = np.concatenate([np.full(3, self.step_translation), np.full(3, self.step_rotation),
                                np.full(hk.n_q, self.step_joints)])
        m1, m2 = np.zeros((len(pos), len(steps))), np.zeros((len(pos), len(steps)))
        b1, b2 = ADAM_BETAS
        chosen = None
        for it in range(self.iterations):
            if it % SWITCH_EVERY == 0:
                xpos, xmat, *_ = hk.evaluate(pos, quat, q, jacobians=False)
                chosen = choose_pads(sdf, hk.world(hk.contacts, xpos, xmat), hk.pad_finger)
            _, _, grad = self.energy(hk, sdf, center, scale, table_z, pos, quat, q, chosen=chosen)
            m1 = b1 * m1 + (1 - b1) * grad
            m2 = b2 * m2 + (1 - b2) * grad**2
            rate = 0.1 + 0.9 * 0.5 * (1.0 + np.cos(np.pi * it / self.iterations))
            step = rate * steps * (m1 / (1 - b1 ** (it + 1))) / (np.sqrt(m2 / (1 - b2 ** (it + 1))) + 1e-12)
            pos -= step[:, :3]
            for i in range(len(quat)):
                mujoco.mju_quatIntegrate(quat[i], -step[i, 3:6], 1.0)
                mujoco.mju_normalize4(quat[i])
            q = np.clip(q - step[:, 6:], hk.low, hk.high)
        energy, terms, _ = self.energy(hk, sdf, center, scale, table_z, pos, quat, q, gradient=False)
        return pos, quat, q, energy, terms

    # ------------------------------------------------------------------ checks and the hand path
    def select(self, hk: HandKinematics, sdf: GridSdf, observation: Observation, pos: np.ndarray,
               quat: np.ndarray, q: np.ndarray, energy: np.ndarray, terms: dict[str, np.ndarray],
               n: int, offset: float = PREGRASP_OFFSET, context: PlanContext | None = None) -> list[Synthesis]:
        """The restarts that pass the checks, diverse, those that hold the protocol's loads first (module
        docstring, steps 4-6)."""
        context = resolve(context)
        grip = context.grip_force_for(hk.hand)
        external = loads(observation.object_mass(self.density), context.perturbation)
        probe = HandProbe(hk.hand, observation, clearance=0.0, config=context.scene)
        addresses = probe.hand_qpos_addresses()
        need = min(self.min_contacts, len(np.unique(hk.pad_finger)))
        passed: list[Synthesis] = []
        rejected = self.last.setdefault("rejected", {})
        rejected.clear()
        self.last["retracted"] = 0
        for i in np.argsort(energy, kind="stable"):
            if not np.isfinite(energy[i]):
                continue
            qpos, xpos, jp, jr, chosen, x, d, g = _placed_pads(hk, sdf, pos[i:i + 1], quat[i:i + 1], q[i])
            touching = np.abs(d) <= self.contact_tolerance
            if touching.sum() < need:
                rejected["contacts"] = rejected.get("contacts", 0) + 1
                continue
            root = np.eye(4)
            root[:3, :3] = _quat_mat(quat[i])
            root[:3, 3] = pos[i]
            tcp = root @ np.linalg.inv(hk.root_in_tcp)
            qi = q[i]
            tcp, depth = _back_off(probe, tcp, _hand_q(hk, qpos, addresses), self.max_penetration)
            if depth > self.max_penetration:
                # Fingers pinching from opposite sides: moving the hand cannot take both out; open them instead.
                qi, depth = _retract_fingers(hk, probe, tcp, qi, addresses, self.max_penetration)
                if depth <= self.max_penetration:  # the pads where they now are, on the backed-off hand
                    root = tcp @ hk.root_in_tcp
                    qpos, xpos, jp, jr, chosen, x, d, g = _placed_pads(hk, sdf, root[None, :3, 3],
                                                                       _mat_quats(root[None, :3, :3]), qi)
                    touching = np.abs(d) <= self.contact_tolerance
                    if touching.sum() < need:
                        rejected["contacts"] = rejected.get("contacts", 0) + 1
                        continue
                    self.last["retracted"] += 1
            if depth > self.max_penetration:
                rejected["penetration"] = rejected.get("penetration", 0) + 1
                continue
            if hk.finger_overlap(qpos) > self.max_penetration:
                rejected["self_penetration"] = rejected.get("self_penetration", 0) + 1
                continue
            normal = -g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-9)
            path = self.hand_path(hk, probe, tcp, qi, x, hk.contacts.bodies[chosen], normal, d, jp[0],
                                  jr[0], xpos[0], addresses, offset, observation.center_of_mass)
            if path is None:
                rejected["preshape"] = rejected.get("preshape", 0) + 1
                continue
            joints, press, opened, torque = path
            caps = squeeze_caps(press[touching], hk.pad_finger[chosen][touching] == 0, grip,
                                hk.body_finger[hk.contacts.bodies[chosen][touching]] < 0)
            surface = surface_friction(probe, hk, hk.pad_geom[chosen][touching])
            mu_k = self.hold_friction(hk, hk.pad_geom[chosen][touching], surface, context)
            hold = hold_margin(x[touching], normal[touching], caps, observation.center_of_mass, external,
                               mu_k, self.torsion)
            jac = pad_jacobians(x, hk._slot[hk.contacts.bodies[chosen]], jp[0], jr[0], xpos[0])
            least = float(mu_k.min())
            used = squeeze_friction(x[touching], normal[touching], jac[touching], torque,
                                    observation.center_of_mass) / least if least > 0 else float("inf")
            stiffness = grasp_stiffness(x[touching], normal[touching], jac[touching],
                                        held_joint_stiffness(hk, qi, joints[1] - joints[0]),
                                        observation.center_of_mass, CONTACT_STIFFNESS)
            rotation = float(load_rotation(stiffness, external)[0].max())
            passed.append(Synthesis(pose=tcp, q=qi.copy(), joints=joints, energy=float(energy[i]),
                                    terms={key: float(v[i]) for key, v in terms.items()},
                                    contacts=x[touching], normals=normal[touching], penetration=depth, hold=hold,
                                    rotation=rotation, opened=opened, friction_used=used,
                                    fingers=hk.pad_finger[chosen][touching],
                                    bodies=hk.contacts.bodies[chosen][touching], friction=surface))
        if not passed:
            return []
        # Grasps that hold the loads first (lowest energy first among them), then the rest by hold margin; in
        # each, those whose pre-shape closes along the squeeze line before those opened toward the open hand.
        holds = np.array([s.hold >= self.min_hold_margin for s in passed])
        order = sorted(range(len(passed)), key=lambda j: (not holds[j], passed[j].opened,
                                                          0.0 if holds[j] else -passed[j].hold))
        passed = [passed[j] for j in order]
        self.last["holding"] = int(holds.sum())
        keep = suppress(np.stack([s.pose for s in passed]), self.nms_distance, self.nms_angle)
        diverse = [passed[k] for k in keep]
        if self.close_check > 0:
            diverse = self.rerank_by_close(hk, observation, diverse, n, context)
        return diverse[:n]

    def rerank_by_close(self, hk: HandKinematics, observation: Observation, ranked: list[Synthesis], n: int,
                        context: PlanContext | None = None) -> list[Synthesis]:
        """`ranked` re-ordered by the simulated close (module docstring, step 7): the first `close_check`
        candidates are closed in the simulation in order (until `n` pass), each gets its `Synthesis.close`; those
        that pass first, then those not checked and those whose close gripped the object but did not pass, then
        those whose close failed (`CloseResult.status`), each in the given order. `last["close"]` lists the
        results in the given order."""
        context = resolve(context)
        sim = CloseSimulation(hk.hand, observation, context)
        external = loads(observation.object_mass(self.density), context.perturbation)
        mu = self.contact_friction(context)
        margin = self.min_hold_margin if self.close_min_margin is None else self.close_min_margin
        good = 0
        for s in ranked[:self.close_check]:
            if good >= n:
                break
            s.close = sim.check(s, hk, external, mu, self.torsion, margin, self.failing_defects,
                                self.close_min_epsilon)
            good += s.close.passed
        self.last["close"] = [s.close for s in ranked if s.close is not None]

        def rank(s: Synthesis) -> tuple[int, float]:
            if s.close is None:
                return 1, 0.0
            order = -s.close.epsilon if self.close_order == "epsilon" else 0.0
            return (0 if s.close.passed else (2 if s.close.status else 1)), order

        return sorted(ranked, key=rank)

    def hand_path(self, hk: HandKinematics, probe: HandProbe, tcp: np.ndarray, q: np.ndarray, x: np.ndarray,
                  bodies: np.ndarray, normal: np.ndarray, dist: np.ndarray, jp: np.ndarray, jr: np.ndarray,
                  xpos: np.ndarray, addresses: dict[str, int], offset: float = PREGRASP_OFFSET,
                  center: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, bool, np.ndarray] | None:
        """(2, n_act) pre-shape and squeeze commands (module docstring, step 5), the normal forces (k,) the
        squeeze presses the pads with (relative; with a palm pad, in newtons with the palm's reaction,
        `palm_reaction`), whether the pre-shape is one of the `OPEN_TRIES` and the
        squeeze's joint torques (n_q,) (relative, A^T f); or None if
        no pre-shape of the `PRESHAPE_TRIES` back-offs and the `OPEN_TRIES` toward the open hand is collision-free
        along the approach."""
        jac = pad_jacobians(x, hk._slot[bodies], jp, jr, xpos)
        rows = np.einsum("ki,kij->kj", normal, jac)  # (k, n_q): how fast each pad moves into the object
        # Close the pads' gaps: the least-norm joint motion moving pad i by its distance d_i along its normal
        # (damped least squares), so the line below runs through a configuration with every pad on the surface.
        dq_gap = rows.T @ np.linalg.solve(rows @ rows.T + GAP_DAMPING * np.eye(len(rows)), dist)
        q_touch = np.clip(q + dq_gap, hk.low, hk.high)
        ctrl_c, a = hk.ctrl(q_touch)
        force = self._squeeze_force(hk, a, rows, jac, x, normal, center)
        load = np.max(np.abs(force) / hk.force_limit)
        if not load > 0:
            return None
        direction = force / load / hk.kp  # command offset past contact at which the most loaded actuator saturates
        squeeze = np.clip(ctrl_c + SQUEEZE_REACH * direction, hk.ctrl_low, hk.ctrl_high)
        dq = np.linalg.lstsq(a, direction, rcond=None)[0]
        motion = np.linalg.norm(np.einsum("kij,j->ki", jac, dq), axis=1).max()
        beta = self.preshape_backoff / max(motion, 1e-9)
        backed = [np.clip(ctrl_c - 2**attempt * beta * direction, hk.ctrl_low, hk.ctrl_high)
                  for attempt in range(PRESHAPE_TRIES)]
        toward_open = [(1.0 - s) * backed[-1] + s * np.asarray(hk.hand.open_ctrl, float) for s in OPEN_TRIES]
        for attempt, pre in enumerate(backed + toward_open):
            pre_q = hk.q_from_ctrl(pre)
            qpos = hk.full_qpos(np.zeros(3), np.array([1.0, 0, 0, 0]), pre_q)
            hand_q = _hand_q(hk, qpos, addresses)
            if all(_probe_contacts(probe, pose, hand_q)[0] <= self.max_penetration
                   for pose in _approach_poses(tcp, offset)):
                torque = a.T @ force
                palm = hk.body_finger[bodies] < 0  # the palm's pads (`palm`), which no joint moves
                # With the palm: in newtons (the most loaded actuator at its limit), with the palm's reaction.
                press = palm_reaction(pad_forces(rows, torque / load), normal, palm) if palm.any() \
                    else pad_forces(rows, torque)
                return np.stack([pre, squeeze]), press, attempt >= PRESHAPE_TRIES, torque
        return None

    def _squeeze_force(self, hk: HandKinematics, a: np.ndarray, rows: np.ndarray, jac: np.ndarray, x: np.ndarray,
                       normal: np.ndarray, center: np.ndarray | None) -> np.ndarray:
        """(n_act,) the squeeze's actuator forces (relative; module docstring, step 5): those that best produce
        (least squares through the joint -> command map `a`) the joint torques of unit inward pushes at every pad
        (`rows`), or, with `balanced_squeeze` and the object's `center`, of the internal forces that need the
        least friction (`grasp.forces.balanced_forces`, pads pressed at least `min_force_share`), whichever of the two
        the hand's actuators turn into the squeeze using less friction (`dexopt.squeeze_friction` of the torques
        they produce); with `close_only`, no actuator pushes against the hand's closing direction."""
        closing = np.sign(hk.hand.closed_ctrl - hk.hand.open_ctrl)

        def actuated(tau: np.ndarray) -> np.ndarray:
            force = np.linalg.lstsq(a.T, tau, rcond=None)[0]  # actuator forces f with A^T f = tau (least squares)
            return np.where(force * closing > 0, force, 0.0) if self.close_only else force

        force = actuated(rows.sum(axis=0))  # joint torques of unit inward pushes at every pad
        if not self.balanced_squeeze or center is None:
            return force
        internal = balanced_forces(x, normal, center, self.min_force_share)
        if internal is None:
            return force
        balanced = actuated(np.einsum("ki,kij->j", internal, jac))
        used = [squeeze_friction(x, normal, jac, a.T @ f, center) for f in (force, balanced)]
        return balanced if used[1] < used[0] else force


@dataclass(frozen=True)
class CloseResult:
    """The simulated close of one candidate (`CloseSimulation.check`, module docstring step 7).

    Attributes:
        status: "" if the close ended gripping the object, else the protocol's failure status (`no_contact`,
            `unstable`).
        pushed: [m] how far the close moved the object's centre of mass on the table (also of a failed close).
        gap: [m] the largest distance of a planned finger's contacts (normal-force-weighted centre) from its
            planned pad (fingers that do not touch are left out: the load test sees them missing).
        thumb_on_pad: share of the thumb's normal force on its planned pads' links [-] (1 without a thumb force).
        friction_used: the friction the squeeze already uses, normal-force-weighted |f_t| / (mu f_n) [-].
        margin: `dexopt.hold_margin` of the simulated contacts (each link's contacts lumped at their
            force-weighted centre and mean normal, capped at the normal force the simulation presses there)
            about the object's centre of mass now, under the planner's loads.
        epsilon: Ferrari-Canny epsilon (L1) of the simulated contacts at the end of the close, computed as the trials
            compute their `sim_epsilon_l1` (`protocol.metrics.simulated_metrics`; 0 where undefined).
        fingers: the fingers touching the object (at least `TOUCH_N` each).
        defects: the close's defects: "pushed" (more than `PUSHED_MAX`), "off-plan" (a gap over `GAP_MAX`),
            "thumb-off-pad" (under half its force on its pads), "friction-used" (over `FRICTION_USED_MAX`).
        passed: no failure status, none of the planner's failing defects, `margin` >= its `min_hold_margin` and
            `epsilon` >= its `close_min_epsilon`.
    """

    status: str
    pushed: float = float("nan")
    gap: float = float("nan")
    thumb_on_pad: float = float("nan")
    friction_used: float = float("nan")
    margin: float = 0.0
    epsilon: float = 0.0
    fingers: tuple[int, ...] = ()
    defects: tuple[str, ...] = ()
    passed: bool = False


class CloseSimulation:
    """The protocol's close phase (`protocol.phases.close`) run for planned candidates in a scene of their own:
    the hand on its mount at the grasp pose, its joints at the pre-shape (the end of the approach, which the
    planner checked clear), the object free at its observed pose on the table, the scene's gravity, the grip
    force of `context` (`PlanContext.grip_force_for`) and otherwise the protocol's default execution parameters;
    after the settle the protocol holds before closing (`approach_settle_s`), the close, then the contacts.

    The scene: the run's (`PlanContext.scene_config`: its pads, friction and physics; the default `SceneConfig`
    when the context carries none).
    """

    def __init__(self, hand: Hand, observation: Observation, context: PlanContext) -> None:
        from manigrasp.planners.collision import mesh_object_spec
        from manigrasp.sim import build_scene

        config = context.scene_config()
        obj = observation.asset if observation.asset is not None else mesh_object_spec(observation.mesh)
        self.scene = build_scene(hand, obj, config)
        self.shift = np.eye(4)  # the scene's table top is z = 0
        self.shift[2, 3] = -float(observation.table_height)
        self.object_pose = observation.object_pose
        self.grip = context.grip_force_for(hand)
        model = self.scene.model
        hand_bodies = set(self.scene.hand_bodies.tolist())
        self.addresses = {model.joint(j).name.removeprefix("hand/"): int(model.jnt_qposadr[j])
                          for j in range(model.njnt)
                          if model.jnt_bodyid[j] in hand_bodies and model.joint(j).name.startswith("hand/")}
        self.body_names = [model.body(b).name.removeprefix("hand/") for b in range(model.nbody)]

    def check(self, s: Synthesis, hk: HandKinematics, external: np.ndarray, mu: float, torsion: float,
              min_margin: float, failing: tuple[str, ...] = CLOSE_DEFECTS, min_epsilon: float = 0.0) -> CloseResult:
        """Close on candidate `s` (its pose, pre-shape and squeeze rows) and judge the contacts at the end: it
        passes with none of the `failing` defects (names of `CLOSE_DEFECTS`; empty: only the simulated margin
        counts), the margin at least `min_margin` and the simulated epsilon at least `min_epsilon`."""
        from manigrasp.protocol import phases
        from manigrasp.protocol.execution import Abort, GraspParams, TrialRun
        from manigrasp.protocol.metrics import simulated_metrics
        from manigrasp.sim import read_hand_contacts

        scene = self.scene
        run = TrialRun(scene, GraspParams(grip_force=self.grip), None)
        run.joints = np.array(s.joints, float)
        mount = self.shift @ s.pose
        phases.reset(run, mount, self.shift @ self.object_pose, 0.0)
        qpos = hk.full_qpos(np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), hk.q_from_ctrl(s.joints[0]))
        for adr, value in _hand_q(hk, qpos, self.addresses).items():  # the fingers at the pre-shape, as at the
            scene.data.qpos[adr] = value  # end of the approach
        mujoco.mj_forward(scene.model, scene.data)
        start = scene.data.xipos[scene.object_body].copy()
        try:
            run.hold_for(run.params.approach_settle_s)
            phases.close(run, 0.0, metrics=False)
            p = run.params  # the trials' simulated metrics (`phases.close`), before the hold is released
            epsilon = simulated_metrics(scene, run.torque_scale, p.metric_edges, p.metric_friction_tol).epsilon_l1
        except Abort as abort:  # how far the failed close moved the object (knocked away, or not)
            moved = float(np.linalg.norm(scene.data.xipos[scene.object_body] - start))
            return CloseResult(status=abort.status.value, pushed=moved)
        finally:
            phases.release_hold(run)
            scene.set_hand_path()
        c = read_hand_contacts(scene, "object")
        com = scene.data.xipos[scene.object_body].copy()
        fn = np.clip(c.normal_force, 0.0, None)
        pos, center = c.position - self.shift[:3, 3], com - self.shift[:3, 3]  # in the observation's world
        total = max(float(fn.sum()), 1e-12)
        used = float((c.tangential_force / np.maximum(c.friction * fn, 1e-9) * fn).sum() / total)
        planned = {hk.model.body(int(b)).name for b in s.bodies}
        on_pad = np.array([self.body_names[b] in planned for b in c.hand_body], bool)
        thumb = c.finger == 0
        thumb_force = float(fn[thumb].sum())
        thumb_on_pad = float(fn[thumb & on_pad].sum()) / thumb_force if thumb_force > 0 else 1.0
        gaps = []
        for p, f in zip(s.contacts, s.fingers, strict=True):
            sel = (c.finger == f) & (fn > 0)
            if fn[sel].sum() >= TOUCH_N:
                gaps.append(float(np.linalg.norm(fn[sel] @ pos[sel] / fn[sel].sum() - p)))
        gap = max(gaps, default=0.0)
        pushed = float(np.linalg.norm(com - start))
        points, normals, caps = [], [], []
        for body in np.unique(c.hand_body):
            sel = (c.hand_body == body) & (fn > 0)
            if fn[sel].sum() < TOUCH_N:
                continue
            w = fn[sel] / fn[sel].sum()
            points.append(w @ pos[sel])
            normal = w @ c.normal[sel]
            normals.append(normal / np.linalg.norm(normal))
            caps.append(fn[sel].sum())
        margin = (hold_margin(np.array(points), np.array(normals), np.array(caps), center, external, mu, torsion)
                  if caps else 0.0)
        fingers = tuple(int(f) for f in np.unique(c.finger[fn > 0]) if fn[c.finger == f].sum() >= TOUCH_N)
        bad = {"pushed": pushed > PUSHED_MAX, "off-plan": gap > GAP_MAX, "thumb-off-pad": thumb_on_pad < 0.5,
               "friction-used": used > FRICTION_USED_MAX}
        defects = tuple(name for name in CLOSE_DEFECTS if bad[name])
        epsilon = float(epsilon) if np.isfinite(epsilon) else 0.0
        return CloseResult(status="", pushed=pushed, gap=gap, thumb_on_pad=thumb_on_pad, friction_used=used,
                           margin=float(margin), epsilon=epsilon, fingers=fingers, defects=defects,
                           passed=not set(defects) & set(failing) and margin >= min_margin and epsilon >= min_epsilon)


def pad_jacobians(x: np.ndarray, slot: np.ndarray, jp: np.ndarray, jr: np.ndarray, xpos: np.ndarray) -> np.ndarray:
    """(k, 3, n_q) Jacobians of the points `x` (k, 3) fixed on the bodies in `slot` (k,) over the hand's independent
    joints (R = 1 layout of `HandKinematics.evaluate`: jp, jr (bodies, 3, 6 + n_q), xpos (bodies, 3)):
    Jp - [x - x_b]x Jr."""
    return jp[slot][..., 6:] - np.einsum("kij,kjl->kil", _skew(x - xpos[slot]), jr[slot][..., 6:])


def held_joint_stiffness(hk: HandKinematics, q: np.ndarray, closing: np.ndarray) -> np.ndarray:
    """(n_q, n_q) joint stiffness [N m/rad] of the hand at `q` once the protocol holds the grasp: A^T diag(kp') A
    with A the joint -> command Jacobian and kp' the servos' gains, `HOLD_GAIN` times stiffer for those that
    move with the squeeze (`closing` (n_act,) != 0: `manigrasp.control.hold.FingerHold`)."""
    a = hk.ctrl(q)[1]
    kp = hk.kp * np.where(np.asarray(closing) != 0, HOLD_GAIN, 1.0)
    return a.T @ (kp[:, None] * a)


def pad_forces(rows: np.ndarray, torque: np.ndarray) -> np.ndarray:
    """(k,) normal forces lambda >= 0 at the pads whose joint torques rows^T lambda best balance the actuators'
    joint `torque` (n_q,) (scipy nnls): the pads the squeeze presses, and how hard; `rows` (k, n_q) holds each
    pad's inward normal through its Jacobian, n_i^T J_i."""
    from scipy.optimize import nnls

    return nnls(np.asarray(rows, float).T, np.asarray(torque, float))[0]


def surface_friction(probe: HandProbe, hk: HandKinematics, geoms: np.ndarray) -> np.ndarray | None:
    """(k, 2) sliding [-] and torsional [m] friction of the hand geoms `geoms` (ids in `hk.model`) as the probe's
    scene compiled them (the hand geoms have contact priority, so theirs is the contact's), or None if one cannot
    be found there. A geom is found as the same geom of its body (many hand geoms have no name): the body by
    name, the geom by its rank among the body's geoms, checked by its type and size."""
    model, own = probe.scene.model, hk.model
    found = []
    for g in np.asarray(geoms, int):
        body = int(own.geom_bodyid[g])
        there = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, HAND_PREFIX + own.body(body).name)
        rank = g - int(own.body_geomadr[body])
        if there < 0 or rank >= int(model.body_geomnum[there]):
            return None
        sid = int(model.body_geomadr[there]) + rank
        if model.geom_type[sid] != own.geom_type[g] or not np.allclose(model.geom_size[sid], own.geom_size[g]):
            return None
        found.append(sid)
    return model.geom_friction[np.array(found, int), :2].reshape(-1, 2).copy()


def palm_reaction(press: np.ndarray, normals: np.ndarray, rigid: np.ndarray) -> np.ndarray:
    """`press` (k,) [N] with the `rigid` pads' (the palm's, which no joint moves: `pad_forces` gives them
    nothing) normal forces set to what balances the others' net push on the object, sum_i press_i n_i, as far as
    their inward `normals` (k, 3) can (nonnegative least squares): the palm pushes back what the fingers press
    the object into it."""
    from scipy.optimize import nnls

    out = np.asarray(press, float).copy()
    rigid = np.asarray(rigid, bool)
    if rigid.any() and (~rigid).any():
        net = out[~rigid] @ np.asarray(normals, float)[~rigid]
        out[rigid] = nnls(np.asarray(normals, float)[rigid].T, -net)[0]
    return out


def squeeze_caps(press: np.ndarray, thumb: np.ndarray, grip: float, palm: np.ndarray | None = None) -> np.ndarray:
    """(k,) the largest normal force [N] of each contact at the protocol's squeeze: the pads' relative forces
    `press` (k,) scaled, the `thumb` (k,) contacts and the others each on their own, so that each side's total
    is `grip` [N], the grip force the protocol regulates (`manigrasp.sim.grip_force`: the smaller of the two
    sides' totals). The stronger side is not credited with more: it presses only as hard as the weaker side
    pushes back. (Scaling both sides by the weaker one's factor gave the Allegro's grasps caps summing to 44 N
    (median) where the simulation presses 21 N at its 9 N grip, and passed grasps that then dropped in the
    perturbations; benchmarks/diagnose_dexterous.py.) With `palm` (k,) contacts that press (the palm's reaction,
    `palm_reaction`), the palm takes up the difference instead (below)."""
    press = np.clip(np.asarray(press, float), 0.0, None)
    thumb = np.asarray(thumb, bool)
    if palm is not None and np.any(np.asarray(palm, bool) & (press > 0)):
        # With the palm pushing back (`palm_reaction`, `press` then in newtons at the actuators' limits) the
        # fingers are not held to what the thumb opposes: the squeeze scaled down only as far as the grip loop
        # stops it, when the smaller of the thumb's and the rest's totals reaches `grip` (a hand whose thumb
        # cannot reach it, the Allegro's 9 N at a 10 N grip, squeezes at its limits; so does a grasp without the
        # thumb, whose grip reads 0).
        rest = press[~thumb].sum()
        weaker = min(press[thumb].sum(), rest) if thumb.any() else rest
        return press * min(1.0, grip / weaker) if weaker > 0 else press
    out = np.zeros_like(press)
    for side in (thumb, ~thumb):
        total = press[side].sum()
        if total > 0:
            out[side] = grip * press[side] / total
    return out


def choose_pads(sdf: GridSdf, pads: np.ndarray, finger: np.ndarray) -> np.ndarray:
    """(R, fingers) index into the pads (R, c, 3) of each finger's pad with the smallest signed distance."""
    d, _ = sdf.distance(pads.reshape(-1, 3))
    d = d.reshape(pads.shape[:2])
    fingers = np.unique(finger)
    masked = np.where(finger[None, None, :] == fingers[None, :, None], d[:, None, :], np.inf)  # (R, f, c)
    return np.argmin(masked, axis=2)


def force_shares(wrenches: np.ndarray, floor: float, iterations: int = FORCE_SHARE_STEPS) -> np.ndarray:
    """(R, k) contact force magnitudes lambda that best balance unit `wrenches` (R, k, 6): argmin |sum_i
    lambda_i w_i|^2 subject to lambda_i >= `floor` and sum_i lambda_i = k (mean 1), by projected gradient.

    With `floor` = 1 every contact pushes equally (Liu et al.'s estimate); below 1 a thumb opposing three
    fingers may push as hard as the three together, as it does in a real grasp. The energy's gradient holds
    lambda fixed (envelope theorem: lambda minimises the energy).
    """
    r, k, _ = wrenches.shape
    lam = np.ones((r, k))
    if floor >= 1.0 or k < 2:
        return lam
    gram = np.einsum("rki,rli->rkl", wrenches, wrenches)
    rate = 1.0 / (2.0 * np.maximum(np.trace(gram, axis1=1, axis2=2), 1e-12))[:, None]
    budget = k * (1.0 - floor)
    for _ in range(iterations):
        y = lam - rate * 2.0 * np.einsum("rkl,rl->rk", gram, lam) - floor
        # Euclidean projection of y onto {mu >= 0, sum mu = budget} (sort-based, batched).
        u = -np.sort(-y, axis=1)
        css = np.cumsum(u, axis=1) - budget
        ind = np.arange(1, k + 1)
        rho = np.sum(u - css / ind > 0, axis=1)
        theta = css[np.arange(r), rho - 1] / rho
        lam = np.maximum(y - theta[:, None], 0.0) + floor
    return lam


def _approach_poses(tcp: np.ndarray, offset: float) -> list[np.ndarray]:
    out = []
    for t in np.linspace(0.0, offset, APPROACH_CHECKS):
        pose = tcp.copy()
        pose[:3, 3] -= t * tcp[:3, 2]
        out.append(pose)
    return out


def _back_off(probe: HandProbe, tcp: np.ndarray, hand_q: dict[int, float], tolerance: float
              ) -> tuple[np.ndarray, float]:
    """The TCP pose moved out of the object and table by MuJoCo's contact normals (at most `BACK_OFF_STEPS`
    moves, each by the deepest penetration + `BACK_OFF_EXTRA` along the depth-weighted mean normal), and the
    deepest penetration left [m]: the optimiser's surface samples miss what lies between them."""
    pose = tcp.copy()
    for _ in range(BACK_OFF_STEPS):
        depth, push = _probe_contacts(probe, pose, hand_q)
        if depth <= tolerance or not np.any(push):
            return pose, depth
        pose = pose.copy()
        pose[:3, 3] += (depth + BACK_OFF_EXTRA) * push / np.linalg.norm(push)
    return pose, _probe_contacts(probe, pose, hand_q)[0]


def _placed_pads(hk: HandKinematics, sdf: GridSdf, pos: np.ndarray, quat: np.ndarray, q: np.ndarray) -> tuple:
    """One configuration (root position (1, 3), quaternion (1, 4), joints (n_q,)) placed: its qpos, the bodies'
    positions and Jacobians (`HandKinematics.evaluate`, R = 1), each finger's pad nearest the object (indices into
    `hk.contacts`), their positions (k, 3) and the object's signed distances (k,) and gradients (k, 3) there."""
    xpos, xmat, jp, jr, qpos = hk.evaluate(pos, quat, q[None])
    pads = hk.world(hk.contacts, xpos, xmat)
    chosen = choose_pads(sdf, pads, hk.pad_finger)[0]
    x = pads[0, chosen]
    d, g = sdf.distance(x)
    return qpos[0], xpos, jp, jr, chosen, x, d, g


def _hand_q(hk: HandKinematics, qpos: np.ndarray, addresses: dict[str, int]) -> dict[int, float]:
    """The hand's joints of `qpos` (a `HandKinematics` qpos) as another model's qpos address -> value (`addresses`:
    joint name -> address, `HandProbe.hand_qpos_addresses`)."""
    return {addresses[nm]: float(qpos[hk.model.jnt_qposadr[j]])
            for nm, j in zip(hk.joint_names, hk.joints, strict=True)}


def _retract_fingers(hk: HandKinematics, probe: HandProbe, tcp: np.ndarray, q: np.ndarray,
                     addresses: dict[str, int], tolerance: float) -> tuple[np.ndarray, float]:
    """Joints `q` (n_q,) moved so that the fingers come out of the object and table at the hand pose `tcp`, and
    the deepest penetration left [m]. Where `_back_off` cannot help (fingers pressing into the object from
    opposite sides: the hand's samples miss 1-2 mm between them, the Inspire's fingertips most), each
    penetrating finger link's contact point is moved out along its contact normal by its depth +
    `BACK_OFF_EXTRA` (the least-norm joint motion, damped least squares over every such contact at once; the
    palm cannot move), at most `BACK_OFF_STEPS` times. The pads then stand a millimetre or two off the surface,
    which the hand path closes (`hand_path`)."""
    root = tcp @ hk.root_in_tcp
    root_pos, root_quat = root[None, :3, 3], _mat_quats(root[None, :3, :3])
    q = q.copy()
    depth = np.inf
    for step in range(BACK_OFF_STEPS + 1):
        qpos = hk.full_qpos(root_pos[0], root_quat[0], q)
        depth, contacts = _penetrations(probe, tcp, _hand_q(hk, qpos, addresses))
        if depth <= tolerance:
            break
        keep = [(hk.body_id(body), p, n, dep) for body, p, n, dep in contacts]
        keep = [(b, p, n, dep) for b, p, n, dep in keep if b >= 0 and hk.body_finger[b] >= 0]
        if not keep or step == BACK_OFF_STEPS:
            break
        xpos, _xmat, jp, jr, _q = hk.evaluate(root_pos, root_quat, q[None])
        slot = hk._slot[np.array([b for b, *_ in keep])]
        points = np.array([p for _b, p, *_ in keep])
        jac = pad_jacobians(points, slot, jp[0], jr[0], xpos[0])  # (k, 3, n_q)
        rows = np.einsum("ki,kij->kj", np.array([n for *_, n, _d in keep]), jac)
        rhs = np.array([dep for *_, dep in keep]) + BACK_OFF_EXTRA
        q = np.clip(q + rows.T @ np.linalg.solve(rows @ rows.T + GAP_DAMPING * np.eye(len(rows)), rhs),
                    hk.low, hk.high)
    return q, depth


def _penetrations(probe: HandProbe, tcp: np.ndarray, hand_q: dict[int, float]
                  ) -> tuple[float, list[tuple[str, np.ndarray, np.ndarray, float]]]:
    """Deepest penetration [m] (>= 0) of the hand at `tcp` with joints `hand_q` into object or table, and each
    penetrating contact: the hand body's (unprefixed) name, the point in the observation's world (3,), the unit
    normal out of the object or table into the hand (3,) and the depth [m]."""
    probe.set_hand_qpos(hand_q)
    pos, quat = probe.roots(tcp[None])
    probe.place(pos[0], quat[0])
    model, data = probe.scene.model, probe.scene.data
    out = []
    for c in range(data.ncon):
        g1, g2 = data.contact.geom[c]
        hand_second = probe.is_hand[g2] and probe.is_other[g1]
        if not (hand_second or (probe.is_hand[g1] and probe.is_other[g2])) or data.contact.dist[c] >= 0:
            continue
        hand_geom = g2 if hand_second else g1
        body = model.body(model.geom_bodyid[hand_geom]).name.removeprefix("hand/")
        normal = data.contact.frame[c, :3] * (1.0 if hand_second else -1.0)
        out.append((body, data.contact.pos[c] - probe.shift[:3, 3], normal.copy(), -float(data.contact.dist[c])))
    probe.restore()
    return max((dep for *_, dep in out), default=0.0), out


def _probe_contacts(probe: HandProbe, tcp: np.ndarray, hand_q: dict[int, float]) -> tuple[float, np.ndarray]:
    """Deepest penetration [m] (>= 0) of the hand at `tcp` with joints `hand_q` into object or table, and the
    depth-weighted sum of the contact normals pointing out of them into the hand (3,)."""
    depth, contacts = _penetrations(probe, tcp, hand_q)
    return depth, sum((dep * n for *_, n, dep in contacts), np.zeros(3))


def _ray_to_surface(sdf: GridSdf, start: np.ndarray, directions: np.ndarray, far: float = 1.0) -> np.ndarray:
    """(n,) distances [m] along the unit `directions` (n, 3) from `start` (3,) (inside the object) to its surface
    (bisection, all rays at once)."""
    lo, hi = np.zeros(len(directions)), np.full(len(directions), far)
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        inside = sdf.distance(start + mid[:, None] * directions)[0] < 0
        lo, hi = np.where(inside, mid, lo), np.where(inside, hi, mid)
    return hi


def _sparse_backprop(hk: HandKinematics, points: Any, world: np.ndarray, grad: np.ndarray, xpos: np.ndarray,
                     jp: np.ndarray, jr: np.ndarray) -> np.ndarray:
    """`hk.backprop` of the gradients `grad` (R, n, 3) at `world` (R, n, 3) over the (restart, point) pairs with a
    non-zero gradient only (`_pair_backprop`)."""
    rows, cols = np.nonzero(np.any(grad != 0.0, axis=2))
    return _pair_backprop(hk, points, rows, cols, world[rows, cols], grad[rows, cols], xpos, jp, jr,
                          np.arange(len(rows)))


def _pair_backprop(hk: HandKinematics, points: Any, rows: np.ndarray, cols: np.ndarray, world: np.ndarray,
                   grad: np.ndarray, xpos: np.ndarray, jp: np.ndarray, jr: np.ndarray, sel: np.ndarray) -> np.ndarray:
    """`hk.backprop` of the gradients `grad` (N, 3) at the points `world` (N, 3), point `cols` (N,) of `points` in
    restart `rows` (N,), over the pairs `sel` only (those with a non-zero gradient)."""
    out = np.zeros((len(xpos), jp.shape[-1]))
    if len(sel) == 0:
        return out
    r = rows[sel]
    slot = hk._slot[points.bodies[cols[sel]]]
    g = grad[sel]
    torque = np.cross(world[sel] - xpos[r, slot], g)
    contrib = np.einsum("ni,nij->nj", g, jp[r, slot]) + np.einsum("ni,nij->nj", torque, jr[r, slot])
    np.add.at(out, r, contrib)
    return out


def _skew(v: np.ndarray) -> np.ndarray:
    """(..., 3, 3) cross-product matrices of the last axis of `v`."""
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def _mat_quats(mats: np.ndarray) -> np.ndarray:
    """(n, 4) unit quaternions (w, x, y, z) of rotation matrices (n, 3, 3)."""
    out = np.zeros((len(mats), 4))
    for i, mat in enumerate(mats):
        mujoco.mju_mat2Quat(out[i], np.ascontiguousarray(mat, float).ravel())
    return out


def _quat_mat(quat: np.ndarray) -> np.ndarray:
    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, np.asarray(quat, float))
    return out.reshape(3, 3)
