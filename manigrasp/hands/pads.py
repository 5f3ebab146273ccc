"""Compliant finger pads: an elastic-foundation (Winkler) patch model in MuJoCo.

A rigid box pad on a flat face touches at its four corners, and on a scanned,
bumpy surface at one or two points: the grip then has almost no resistance to
torsion. A real rubber pad conforms and touches over a patch. This module
replaces a hand's rigid pad box by a grid of small contact elements, each a
flattened (oblate) ellipsoid on its own prismatic joint along the pad normal
with a linear spring (and damper) to the finger: every element penetrates and pushes independently,
so the pressure follows the surface. It is the classic elastic foundation of
contact mechanics (K. L. Johnson, *Contact Mechanics*, 1985, section 4.3) and
what Drake's hydroelastic contact computes for a compliant layer of thickness
h against a rigid body: pressure p = E d / h at local penetration d (Elandt
et al., "A pressure field model for fast, robust approximation of net contact
force and moment between nominally rigid objects", IROS 2019).

Parameters (`PadModel`) and their source:

- modulus E = 0.34 MPa: a soft silicone gripper pad (Smooth-On Dragon Skin 20,
  Shore 20A, 100 % tensile modulus 338 kPa in its technical bulletin);
  foundation stiffness per area E / h [N/m^3].
- thickness h: the pad box's own thickness in the hand model (6 mm on
  `parallel_jaw`, 8 mm on `panda`, 2 mm on `robotiq_2f85`).
- pitch 1.5 cm: the face is cut into the fewest equal cells no longer than the
  pitch along either side, at least 2 x 2 (`cell_sides`): 2 x 2 cells of
  1 x 1.5 cm on `parallel_jaw`'s 2 x 3 cm pad, 2 x 2 of 0.8 cm on `panda`'s
  1.6 x 1.6 cm, 2 x 3 of 1 x 1.12 cm on `robotiq_2f85`'s 2 x 3.35 cm. Each cell
  gets one element at its centre carrying the cell's area, whose ellipsoid spans
  the cell, so the elements cover the face to its rim. Centred nodes are the
  midpoint rule of the patch integrals: their torsion capacity mu F mean(r) is
  7 % below the uniform patch's on the 2 x 3 cm pad (8 % on 2 x 2 square cells,
  6 % on `robotiq_2f85`'s), where nodes on the rims and corners (the first
  version, 3 x 4) put twice the weight at the outline and cost twice the
  elements. Each element is one extra degree of freedom and up to one contact:
  the simulation cost grows with their number. The pitch was 1 cm (cells of about
  it, rounded) until 5 Dec 2026: its 2 x 3 round elements on `parallel_jaw` cost
  2.08x a rigid trial's simulation on quick (1.76x with planning), against a
  target of 1.5x. The 2 x 2 grid passes
  the same validation (flat-face torque, egg-crate, post under one element) with
  two thirds of the elements, at 1.38x a rigid trial with planning, 1.59x the
  simulation alone (docs/protocol.md, "The 1.5 cm grid").
  Its elements span their cells: round ones (5 mm, the smaller half side) held
  the egg-crate as well (0.93-0.95 of the flat torque against 0.87-0.89) but
  leave 5 mm of the face's middle and 2.5 mm at each end uncovered, where a thin
  rim would meet no element. No cell is longer than the pitch, rather than
  cells of about it, so that `robotiq_2f85` keeps its 2 x 3 grid (rounded, 2 x 2
  cells of 1.68 cm kept 0.67 of the flat torque on the egg-crate at every force,
  the 2 x 3 grid 0.47-0.90, below).
  Each carries k_i = E A_i / h, so the stiffnesses sum to the pad's k = E A / h
  (3.4e4 N/m on `parallel_jaw`, 1 mm compression at the standard 35 N grip:
  enough to conform to millimetre bumps).
- element shape: semi-axes half the cell's sides in the face and h / 3 (at most
  the smaller of those) along the normal, so an object edge pressing on one is
  pushed back mostly along the normal (a sphere's flank would push it sideways).
- damping: critical for each element (b_i = 2 sqrt(k_i m_i)).
- travel: 80 % of h, then the element bottoms out on the rigid backing (a joint
  limit), as rubber does.
- backing: a rigid geom of the finger closer behind the pad face than the travel
  makes the pad rigid: the object meets it once the elements have sunk that far,
  and from then on it carries the grip as the rigid pad did. The Panda's finger
  hulls (`finger1_collision`, `finger2_collision`) lay 0.38 mm (fingertip half of
  the pad) to 1.25 mm (palm end) behind its 8 mm pads (6.4 mm travel): closed at
  the standard 35 N on a flat box the elements carried 0.38 of the normal force,
  and 0.37 on the cracker box recipe's grasps, 0.09-0.32 on its scan's, which
  the hulls touched at a few bumps (`benchmarks/diagnose_footprint.py --loads`).
  So `clear_backing` cuts off what of every colliding geom rigidly attached to the
  pad's body lies in front of the plane parallel to the face at the travel behind it
  (found by rays cast along -normal from an 11 x 11 grid over the face, a mesh by its
  convex hull, on a compiled copy): a mesh's hull is clipped by that plane into a new
  mesh, a box with an axis along the normal shrinks from its front, and either keeps
  its back, so the finger's outer face stays where the real finger's is; other
  primitives are moved back whole along the normal. Cut: the Panda's two finger hulls
  by up to 6.02 mm (the whole plane: their inner faces lie 6.4 mm behind the pad faces, also
  outside the pads' outline); `robotiq_2f85`'s fingertip blocks by 1.28 mm (0.33 mm
  behind its 2 mm pad; they stop colliding anyway, `Hand.pad_backing`); nothing of
  `parallel_jaw` (its finger links lie 6 mm behind, past the 4.8 mm travel). The
  first version (86911a7) moved the hulls back whole, their outer faces 6 mm past the
  real finger's, so the planners' collision probe met a finger thicker than the
  real one. Standard antipodal on the Panda, seed 0, successes of 20 (mug, scissors,
  hammer, cracker box): hulls as modelled 20, 8, 8, 16; moved 20, 10, 6, 6; cut
  20, 7, 5, 9 (the cracker box's failures are all drops under the perturbation:
  the pads, not the hulls, now hold it). `benchmarks/bench_scans.py`, Panda
  compliant, seeds 0-2, cracker box scan and recipe: cut 15 and 20 of 60, moved 17
  and 20.
  Rigid pads keep the hand as modelled.
- friction mu = 1.0 (`PAD_FRICTION`, `SceneConfig.pad_friction`): the pad's own
  rubber, not the hand's 0.5 (which the rigid pads keep, to reproduce older
  runs). Gripper pads are silicone or polyurethane rubber: the Robotiq 2F-85's
  fingertips are a silicone overmould (MuJoCo Menagerie's `robotiq_2f85` models
  them at 0.6-0.7, a modelling choice), and Guo et al., "Design of parallel-jaw
  gripper tip surfaces for robust grasping" (ICRA 2017), found Shore A30
  silicone the most robust pad surface. Dry elastomers grip smooth hard surfaces
  at mu about 1 and above, because rubber friction is adhesive and hysteretic
  and grows as the rubber conforms (Roth, Driscoll and Holt, "Frictional
  properties of rubber", J. Res. NBS 28, 439, 1942; B. N. J. Persson, "Silicone
  rubber adhesion and sliding friction", Tribology Letters 62, 34, 2016; a
  skin-equivalent silicone (L7350) measured above 1 dry against polymer
  coatings in "Experimental investigation of a polymer coating in sliding
  contact with skin-equivalent silicone rubber in an aqueous environment").
  No measurement of silicone on printed cardboard was found; 1.0 is the round
  value of the dry-elastomer range for cardboard, painted metal, glazed ceramic
  and plastic, a sourced material value, not fitted to the benchmark
  (`benchmarks/bench_scans.py --modes compliant compliant:mu=0.5` shows what it
  changes). The patch's torsional resistance is sliding friction over its
  area, integral of mu p r dA (for a 2 x 3 cm pad under uniform pressure,
  0.0097 mu F; the rigid box touching at its corners gives about twice that).
  Each element stands for its cell of rubber, so its contact is a soft finger
  (condim 4) whose torsional friction is its own cell's patch, mu mean(r) over
  the cell (0.383 mu c for a square of side c, 4.84 mm at mu 1 on a 1 x 1.5 cm
  cell, `cell_torsion`). MuJoCo's elliptic cone couples it with the element's
  sliding friction, so on a full face it adds little (the 2 x 2 grid then holds
  1.06 of the uniform patch instead of 0.93) but an object touching one element,
  its edge or corner on the pad's rim, still meets its cell's torsion, not a
  point's zero.
  The hand geoms have contact priority over objects and the table, so MuJoCo
  uses the element's friction as it is (with equal priorities it would take the
  larger of the two geoms' values, element by element).
- element inertia: the spring-mass period must stay well above the 2 ms time
  step, so each joint gets armature k_i (dt / 0.15)^2 (an inertia along the
  joint only: it adds no weight and no hand inertia; the period is 42 steps);
  each element body has 1 g.
- contacts of the elements are near-rigid (solimp 0.995-0.999: the compliance is
  the springs'), and elements do not collide with each other.
- creep: MuJoCo's friction is soft, so a contact held below its friction limit
  still slides at v = R f / b (b = 2 / timeconst = 500 /s), and the regulariser
  of an elliptic cone's torsion row is the normal row's times (mu / mu_t)^2 /
  impratio, 6800 / 10 for an element (mu_t = 0.383 mu c). A thin object (a
  7.8 mm phone box, a scissors ring) rests on one element per pad, which holds
  its torsion with that row alone: with the first version's solimp 0.99 and
  armature k_i (dt / 0.5)^2 the row's R was 812 (the rigid pad's 413), and a
  phone box turned 4-5 deg/s at 28 % of its torsion capacity until it dropped
  (standard's antipodal on `parallel_jaw`: phone box 12, scissors 12 of 20
  against the rigid pads' 18, 19). The normal row's R is (1 - d) / d times the
  inverse weights of the element and the object: d 0.99 -> 0.995 and an 11x
  armature (a lighter inverse weight along the joint) bring the torsion row's
  R to 293 (`tests/test_pads.py`), and those grasps hold (the four replayed
  failures of the phone box and scissors held; docs/protocol.md, "The creep fix of the pad elements").
  Neither alone did (1 of 4 each). d 0.997 held them too, with less creep (R
  187), but cost 25 % more time per trial (the solver iterates more); 0.998 and
  above squeezed a scissors ring out of the grip during the close.

Known limits of the grid: a contact strip narrower than a cell (a pad
overlapping an object only by its rim, at a slant, or an object's edge) is
carried by one or two elements, each with the torsion of its whole cell, where a
real pad has a patch as small as the strip. A thin pad cannot follow bumps at a
light grip: `robotiq_2f85`'s 2 mm pad sinks 0.09 mm on average at 10 N, so on
the egg-crate little beyond the crest touches and it keeps 0.47 of its flat
torque (0.68-0.77 at 35 N, 0.89-0.90 at 70 N, at height fields of 81-161
samples; `benchmarks/bench_pads.py`); the 6 and 8 mm pads keep 0.87-0.95 at
every force. Figures before 5 Dec 2026 (1.59x at 10 N, 0.81 at 35 N on
`robotiq_2f85`) were the validation rig's artifacts: contacts shallower than
MuJoCo's default CCD tolerance came back with reversed normals and the pad
turned by itself; every scene now resolves contacts to 1e-9 m
(`SceneConfig.ccd_tolerance`).

Cost of the first version (`benchmarks/bench_pad_speed.py --profile`, quick on `parallel_jaw`, one
shared 2-core machine): a compliant trial took 1.70x a rigid one's time
(0.285 vs 0.168 s), nearly all of it inside `mj_step` (111 vs 54 us per step).
Of the extra 58 us per step, 28 are narrowphase tests of the elements against
the object's convex parts (ellipsoid vs mesh, penetrating, so an EPA each), 19
the constraint solver (12 more degrees of freedom, condim-4 elliptic contacts)
and 8 the rest of the step. Element pairs with the table and the other hand
geoms reach the collision filter every step but fail the bounding test: keeping
them out by contype/conaffinity saved 2-3 us per step on stored mid-grasp
states, which is why the elements still meet the table and the hand.
Measured and not taken (thread CPU time per step, `parallel_jaw` holding a mesh
cube: rigid 25 us, the first version 47 us): spheres as elements (MuJoCo's
convex collision treats a sphere as a point with a radius, so a shallow contact
needs no EPA) cost 38 us, but a sphere no wider than its cell is a hemisphere
whose flank pushes a thin object's edge sideways, and a wider one reaches past
the pad's rim and the finger's back (standard's antipodal `parallel_jaw`, of
20: scissors 9 and 2, phone box 10 and 1 with radius 5 and 15 mm, measured
before the creep fix above, against this model's 16 and 17; with the fix, 3 of
8 of the 5 mm spheres' failed trials held on replay); a 2 x 2 grid on the
2 x 3 cm pad costs 38 us but holds scissors 6, and on the egg-crate keeps 1.49x
its flat torque (round elements, before the creep fix and measured on the rig
before its reversed normals were found: the 2 x 2 grid of cell-spanning elements
is today's model, "pitch" above); a looser CCD tolerance (1e-4) saved 2 us; condim 3 saves about
1 us and loses the cell torsion a one-element contact needs. That (1 cm grid) model cost
2.08x a rigid trial's CPU time on quick (docs/protocol.md, "Cost of compliant pads").

The history below measured the 1 cm grid: 12 elements on `parallel_jaw`, where
today's has 8.

Where this version's time goes (thread CPU per step, `parallel_jaw` closing on a 5 cm mesh cube on the
table, 500 warm consecutive steps; quick's own from `benchmarks/bench_pad_speed.py`): rigid 15.5 us,
compliant 39-40 us. The collision adds 14 (19 vs 5: the elements against the object's convex parts, an
EPA each, about 0.9 us per element, and against the table 3.5 us while they are near it, 1.2 us 30 cm above
it: the table's bounding sphere spans the scene, so the 12 pairs pass MuJoCo's bounding-sphere test), the
constraint solver 5 (16 contacts and 65 rows against 12 and 49; it also iterates a little more, 1.3-1.7
Newton iterations per step in quick's trials against 1.0-1.3) and the rest 4: the same hand in free air
steps in 10.9 us against 4.2 (12 more bodies and damped joints; gravity compensation of the element bodies
alone is 0.7 of it). In a hold the element contacts are most of it (19 of the 24 us), the bodies and
joints the rest. Measured and not
taken, besides those above: MuJoCo's sparse constraint Jacobian (its default is dense below 60 DOFs) was
13-30 % faster on states stored from quick's trials (replayed 25 or 1 steps at a time) but within noise on
whole trials (sugar box 36.9 vs 37.0 us per step, banana 53.3 vs 52.5), 12-41 % slower holding the cube on
all three parallel-jaw hands, and its rounding flipped 2 of 80 trials; islands off (time unchanged), solver
tolerance 1e-6 or 1e-7 and line-search tolerance 0.1 or 0.3 (Newton iterations within 6 %, time
unchanged on stored steps: 94.4 vs 94.0 us at 1e-6); keeping the elements from the
hand's own geoms (they never touch them) gained nothing measurable, and from the table 3.5 us near it,
but the elements do touch the table (a low sugar-box grasp: 4 element-table contacts per step); fewer
CCD iterations (10) made the solver iterate twice as often (3.0 vs 1.6 Newton iterations, 81 vs 59 us per
step).

On quick's own trials (the same groups and grasps replayed with variants of the compliant model in one
process, trials interleaved, thread CPU inside `mj_step`, 20-30 trials of all ten groups; the spread between
runs on the shared machine is several microseconds, so only the differences within one run count): this
model 54-62 us per step, rigid pads 22-23 (`bench_pad_speed.py`). In one run: this model 60.8, the
elements welded to the finger (no spring joints, contacts kept; they then touch less, 6.0 vs 9.5 contacts
per step) 38.5, the elements as joints without contacts 31.8. So the 12 spring joints cost about 10 us per
step (31.8 against the rigid pads' 22) and the element contacts the other 29: the narrowphase of the
elements against the object's convex parts (an EPA for each touching one, a GJK for each near one; 14 us in
the cube hold above) and the solver on the larger system. The pairs with the table and the hand are cheap:
keeping the elements from the table altogether saved 2.6 us per step (55.1 vs 52.5), meeting the
table through an invisible plane at its top instead of the box (plane-convex needs one support point, no
GJK; the same contacts and statuses) 1.0 us (54.1 vs 55.1), too little for a
second table geom that every reader of the table's contacts would have to know; keeping them from the
hand's own geoms by body excludes nothing (55.0 vs 55.1); element bodies without gravity compensation
nothing (54.7); MuJoCo's sparse Jacobian was slower (65.0 vs 61.9); capsules as elements (in the
face, along its first axis, radius h / 3, spanning the cell: a shallow capsule contact needs no EPA) were
slower too (61.9 vs 55.1, with 12.2 contacts per step against 9.5). Outside `mj_step` a compliant trial
costs 0.010 s more (0.045 vs 0.035 s per trial on quick); 0.004 of it is the simulated-contact metrics
over the grip's more contacts (0.019 vs 0.015 s per trial; on the sugar box's antipodal grasps, 3 of them,
0.066 vs 0.035: the Ferrari-Canny hull of 40-130 primitive wrenches, 28 vs 23 ms per Qhull call).

Measured and not taken in MuJoCo 4.0 (quick's own trials replayed with variants of the compliant scene,
interleaved in one process, 2-3 grasps of each of the ten groups or of the sugar box and mug; thread CPU per
`mj_step` on a loaded machine, so larger than above; two identical variants in one run differed by up to 4-5 %,
so only larger differences count). 4.0's defaults have multi-CCD and native CCD on and sleeping off
(`opt.disableflags`, `opt.enableflags` 0). Per step, variant vs this model in the same run: multi-CCD off 86.6
vs 83.1 us and 90.2 vs 94.3 (an element is an ellipsoid, one contact either way; the object's contacts with the
table and the fingers drop to one each: 3 of 20 statuses changed); libccd instead of native CCD 92.0 vs 83.1;
sleeping islands 86.9 vs 83.1 and 88.7 vs 94.3; speculative contacts 129.9 vs 94.3; exact constraint diagonals
98.7 vs 94.3; the CG solver 190.8 vs 106.5 (33 iterations per step, 4 of 20 statuses changed), PGS 305.8. Element
geoms with a contact margin of 0.2, 0.5 or 1 mm (the ellipsoid shrunk by it, so that a held contact needs a GJK
distance and no EPA) 119-120 vs 110; armature 0.5, 2 or 4 times 115-119 vs 112 (Newton iterations 1.89-2.04 vs
1.88); no travel limit 102.8 vs 106.5 and 83.0 vs 81.6; box elements 174 vs 112 (19.7 contacts per step: multi-CCD
gives a box up to 4 against a mesh), with multi-CCD off 112.0 vs 112.2; a second, non-colliding geom on each
element body (MuJoCo then tests an element against the table, a single-geom world body, by boxes in its midphase
instead of by bounding spheres alone) 92.2 vs 91.9; element solimp 0.99 102.4 vs 106.5 (and the creep above).
Both modes simulate the same steps per trial (1834 vs 1841 here; 1980 vs 1951 in `bench_pad_speed.py`), and hold
as many contacts in the elliptic cone's middle zone (5.2 vs 5.1 per step); a compliant step takes 1.57 Newton
iterations against 1.29, on a system of 26 degrees of freedom against 14 (the Newton Hessian and its per-cone-contact
rank-1 updates, `HessianConeUpdate`, are dense nv x nv). By phase: hand on the object 121 vs 53 us per step (74 % of
the steps), near it 62 vs 40. `perf` over 40 trials of each mode (9.1 vs 4.9 s thread CPU): MuJoCo 5.8 vs 2.4 s;
of the difference 1.3 s is the elements' narrowphase (mesh hill-climbing support 0.35, ellipsoid support 0.27, GJK
0.26, its simplex and EPA 0.40), 1.1 s the solver (`HessianConeUpdate` 0.53, `mj_solPrimal` 0.30, Cholesky 0.14)
and 0.6 s Python, NumPy and Qhull outside MuJoCo (Qhull 0.12: the metrics' hull over more contacts).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from manigrasp.errors import HandError

ELEMENT_PREFIX = "padel_"  # element bodies, joints and geoms: padel_<pad geom>_<i>_<j>
ELEMENT_MASS = 0.001  # [kg]
PAD_FRICTION = 1.0  # sliding friction of the pads' rubber (module docstring: sources)
STABILITY_FACTOR = 0.15  # element spring-mass frequency times the time step (module docstring: creep)
# Elements are sibling bodies, which MuJoCo does not filter: contype 2 / conaffinity 1 keeps
# them from colliding with each other while they still meet everything of contype 1.
ELEMENT_CONTYPE, ELEMENT_CONAFFINITY = 2, 1
# Element contacts are near-rigid (the spring is the joint's): impedance close to 1 keeps
# MuJoCo's soft friction from creeping (module docstring: creep). 0.998 and above squeezed
# thin objects out of the grip during the close (scissors, standard, 1 of 4 replayed trials),
# and the stiffer the impedance the more the solver iterates (0.997: +25 % time per trial).
ELEMENT_SOLIMP = (0.995, 0.999, 0.001, 0.5, 2.0)
# The travel limit is the rigid backing: as stiff as the element contacts. MuJoCo's default
# limit (solref 0.02) is soft: an object edge resting on one or two corner elements at the
# 35 N grip pushed them 7.6-10.4 mm, past the 4.8 mm travel and the 6 mm pad itself.
LIMIT_SOLREF = (0.004, 1.0)
LIMIT_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)


@dataclass(frozen=True)
class PadModel:
    """Parameters of the elastic-foundation pad (see the module docstring for their source).

    Attributes:
        modulus: Young's modulus of the pad rubber [Pa].
        pitch: target spacing of the elements [m].
        travel_fraction: compression at which an element bottoms out, fraction of the thickness [-].
        damping_ratio: of each element's spring-mass pair [-].
        timestep: simulation step the element inertia is sized for [s].
        friction: sliding friction of the pad's rubber against objects [-].
    """

    modulus: float = 3.4e5
    pitch: float = 0.015
    travel_fraction: float = 0.8
    damping_ratio: float = 1.0
    timestep: float = 0.002
    friction: float = PAD_FRICTION

    def __post_init__(self) -> None:
        for key in ("modulus", "pitch", "travel_fraction", "damping_ratio", "timestep", "friction"):
            if not getattr(self, key) > 0:
                raise HandError(f"PadModel.{key} must be > 0, got {getattr(self, key)}")


@dataclass(frozen=True)
class PadGeometry:
    """A rigid box pad in its body's frame: face centre (3,), outward unit normal n (3,),
    the two in-face unit axes u, v (3,) with half extents (2,) along them [m], and thickness [m]."""

    center: np.ndarray
    normal: np.ndarray
    axes: np.ndarray
    half: np.ndarray
    thickness: float


def pad_geometry(geom: mujoco.MjsGeom, toward: np.ndarray) -> PadGeometry:
    """The face of box `geom` (spec element, body frame) whose outward normal points most along `toward`.

    The face is the one across the box's thinnest axis; `toward` (3,) is a direction in the
    body frame (from the pad toward the object, e.g. toward the TCP).
    """
    if geom.type != mujoco.mjtGeom.mjGEOM_BOX:
        raise HandError(f"pad geom {geom.name!r} is not a box; only box pads can be made compliant")
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, np.asarray(geom.quat, float))
    rot = rot.reshape(3, 3)
    size = np.asarray(geom.size[:3], float)
    k = int(np.argmin(size))
    sign = 1.0 if float(rot[:, k] @ toward) >= 0 else -1.0
    normal = sign * rot[:, k]
    others = [i for i in range(3) if i != k]
    return PadGeometry(center=np.asarray(geom.pos, float) + normal * size[k], normal=normal,
                       axes=rot[:, others].T.copy(), half=size[others], thickness=2.0 * float(size[k]))


def element_grid(pad: PadGeometry, pitch: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element nodes on the face (n, 3) [m] in the body frame, their areas (n,) [m^2], and the elements' in-face
    semi-axes (2,) [m], along the pad's two in-face axes.

    The face is cut into n_u x n_v equal cells no longer than `pitch` (`cell_sides`),
    one node at the centre of each carrying the cell's area (the midpoint rule of the
    patch integrals), so the areas sum to the face's; the semi-axes are half the cell's
    sides, so each element spans its cell and the elements reach the rims.
    """
    sides = cell_sides(pad, pitch)
    axes_nodes = [-h + side * (np.arange(round(2 * h / side)) + 0.5) for h, side in zip(pad.half, sides, strict=True)]
    aa, bb = np.meshgrid(*axes_nodes, indexing="ij")
    points = pad.center + aa.reshape(-1, 1) * pad.axes[0] + bb.reshape(-1, 1) * pad.axes[1]
    area = np.full(len(points), sides[0] * sides[1])
    return points, area, sides / 2


def cell_sides(pad: PadGeometry, pitch: float) -> np.ndarray:
    """(2,) sides [m] of the grid's cells along the pad's two in-face axes: n_i = max(2, ceil(2 half_i / pitch))
    equal cells per axis, the fewest no longer than `pitch` (a side within 1e-6 of it counts as equal)."""
    return np.array([2 * h / max(2, math.ceil(2 * h / pitch - 1e-6)) for h in pad.half])


def cell_torsion(friction: float, sides: Sequence[float]) -> float:
    """Torsional friction [m] of one element: its cell's own patch under uniform pressure, mu mean(r) over
    the cell (0.383 mu c on a square of side c), the torque per newton it resists about its centre."""
    return uniform_patch_torque(friction, 1.0, np.asarray(sides) / 2, n=100)


def element_stiffness(model: PadModel, area: np.ndarray, thickness: float) -> np.ndarray:
    """Winkler stiffness of each element, k_i = E A_i / h [N/m] (they sum to E A / h)."""
    return model.modulus * np.asarray(area, float) / thickness


def make_compliant(spec: mujoco.MjSpec, pads: Sequence[tuple[str, np.ndarray]],
                   model: PadModel) -> dict[int, float]:
    """Replace each rigid box pad of `spec` by a grid of spring-loaded contact elements (in place), after cutting
    off what of the finger's rigid geoms lies within the elements' travel behind a pad face (`clear_backing`;
    module docstring: backing).

    Args:
        spec: a hand's spec (not compiled).
        pads: (geom name, direction (3,) in the geom's body frame from the pad toward the object).
        model: pad parameters (`model.friction` is the elements' sliding friction).

    Returns:
        The geoms cut: id (in `spec` compiled before the elements were added) -> cut [m] (`clear_backing`).
    """
    moved = clear_backing(spec, pads, model.travel_fraction)
    for name, toward in pads:
        geom = spec.geom(name)
        if geom is None:
            raise HandError(f"pad geom {name!r} not in the hand model")
        pad = pad_geometry(geom, np.asarray(toward, float))
        points, area, semi = element_grid(pad, model.pitch)
        torsion = cell_torsion(model.friction, 2 * semi)
        thin = min(*semi, pad.thickness / 3)  # half-thickness of the flattened element
        stiffness = element_stiffness(model, area, pad.thickness)
        body = geom.parent
        geom.contype, geom.conaffinity = 0, 0  # kept (its face is the pad's geometry) but no longer touches,
        geom.rgba = [*np.asarray(geom.rgba, float)[:3], 0.0]  # nor drawn: the elements are the pad now
        for i, (point, k) in enumerate(zip(points, stiffness, strict=True)):
            _add_element(body, f"{ELEMENT_PREFIX}{name}_{i:02d}", point - thin * pad.normal, pad,
                         np.array([*semi, thin]), float(k), pad.thickness * model.travel_fraction, model,
                         torsion)
    return moved


def _add_element(body: mujoco.MjsBody, name: str, pos: np.ndarray, pad: PadGeometry, size: np.ndarray,
                 k: float, travel: float, model: PadModel, torsion: float) -> None:
    """One element: an oblate ellipsoid (semi-axes `size`: in the face, in the face, along the
    normal) whose lowest point lies on the pad face, on a slide joint along -normal
    (q = compression [m]) with spring k [N/m]. Flattened so that an object edge pressing on it
    is pushed back mostly along the pad normal, as by rubber, not sideways as by a sphere's flank.
    Its contact is a soft finger (condim 4) with `torsion` [m], its cell's own torsional friction."""
    armature = k * (model.timestep / STABILITY_FACTOR) ** 2
    mass = ELEMENT_MASS + armature
    u, v = pad.axes
    if float(np.cross(u, v) @ pad.normal) < 0:
        v = -v
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([u, v, pad.normal]).ravel())
    child = body.add_body(name=name, pos=pos, quat=quat, mass=ELEMENT_MASS, inertia=[1e-9, 1e-9, 1e-9],
                          explicitinertial=True)
    child.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, -1.0], stiffness=[k],
                    springref=0.0, damping=[2.0 * model.damping_ratio * np.sqrt(k * mass)], armature=armature,
                    limited=mujoco.mjtLimited.mjLIMITED_TRUE, range=[-travel, travel],
                    solref_limit=list(LIMIT_SOLREF), solimp_limit=list(LIMIT_SOLIMP),
                    frictionloss=0.0, margin=0.0)
    child.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_ELLIPSOID, size=list(size), condim=4,
                   friction=[model.friction, torsion, 0.0], priority=1, rgba=[0.15, 0.15, 0.15, 1.0],
                   contype=ELEMENT_CONTYPE, conaffinity=ELEMENT_CONAFFINITY, density=0.0, margin=0.0,
                   solref=[0.004, 1.0], solimp=list(ELEMENT_SOLIMP))


def clear_backing(spec: mujoco.MjSpec, pads: Sequence[tuple[str, np.ndarray]], travel_fraction: float,
                  samples: int = 11) -> dict[int, float]:
    """Cut off the rigid geoms behind each pad face where the pad's elements would meet them before their travel.

    For each pad (`make_compliant`'s `pads`), rays are cast along -normal from a `samples` x `samples` grid over the
    pad face (rims included) at every other colliding geom rigidly attached to the pad's body (the bodies welded to
    it, `model.body_weldid`), on a copy of `spec` compiled at its reference configuration (`backing_depths`). A geom
    whose surface comes closer behind the face than the travel (travel_fraction x pad thickness) is changed in place
    (`spec`) to lie behind the plane parallel to the face at the travel behind it (the whole plane, also outside
    the face's outline), its back, where it can, as it was:

    - a mesh: its compiled convex hull (body frame) is cut by that plane and the part behind it becomes a new mesh
      of the spec, which the geom now uses, at the body origin (pos 0, identity quat); type, contact and friction
      attributes are the geom's own;
    - a box with an axis along the pad normal: its half size along that axis shrinks by half the cut and its
      centre moves back by half the cut, so its front face lies on the plane;
    - any other primitive, a box at a slant, a geom placed through a frame, or one the cut would leave nothing of:
      moved back along the pad normal by the cut (its back moves too).

    One lying farther, or outside the face's outline, is left as it is. Geoms are keyed by their id in the compiled
    spec (the order of `spec.geoms`), so unnamed geoms count too.

    Returns:
        The geoms changed: id -> cut [m], travel minus the geom's depth behind the face (the largest over the pads,
        when several ask).
    """
    compiled, data = _compiled(spec)
    depths = _backing_depths(spec, compiled, data, pads, samples)
    geoms = list(spec.geoms)
    if len(geoms) != compiled.ngeom:
        raise HandError(f"spec has {len(geoms)} geoms, its compiled copy {compiled.ngeom}")
    cuts: dict[int, list[tuple[np.ndarray, np.ndarray, float]]] = {}  # id -> (point, normal, cut), its body frame
    for (name, toward), near in zip(pads, depths, strict=True):
        pad = pad_geometry(spec.geom(name), np.asarray(toward, float))
        travel = travel_fraction * pad.thickness
        pad_body = compiled.geom_bodyid[compiled.geom(name).id]
        rot, origin = data.xmat[pad_body].reshape(3, 3), data.xpos[pad_body]
        for other, depth in near.items():
            if depth >= travel:
                continue
            body = compiled.geom_bodyid[other]
            back = data.xmat[body].reshape(3, 3).T  # world -> the geom's body frame
            point = back @ (origin + rot @ (pad.center - travel * pad.normal) - data.xpos[body])
            cuts.setdefault(other, []).append((point, back @ rot @ pad.normal, travel - depth))
    for other, planes in cuts.items():
        _cut(spec, geoms[other], compiled, other, planes)
    return {other: float(max(cut for _, _, cut in planes)) for other, planes in cuts.items()}


def _cut(spec: mujoco.MjSpec, geom: mujoco.MjsGeom, model: mujoco.MjModel, g: int,
         planes: Sequence[tuple[np.ndarray, np.ndarray, float]]) -> None:
    """Keep only the part of geom `g` (`geom` in `spec`, id `g` in its compiled `model`) behind each plane (point,
    outward unit normal, cut; in the body frame); `clear_backing`."""
    if geom.frame is None and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
        vertices = geom_vertices(model, g)
        for point, normal, _ in planes:
            vertices = clip_hull(vertices, point, normal)
        if len(vertices) >= 4 and np.linalg.matrix_rank(vertices[1:] - vertices[0], tol=1e-9) == 3:
            mesh = f"{geom.meshname}_behind_pad_{g}"
            spec.add_mesh(name=mesh, uservert=vertices.ravel().tolist())
            geom.meshname = mesh
            geom.pos, geom.quat = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]
            return
    if geom.frame is None and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
        centre, size = model.geom_pos[g].copy(), model.geom_size[g].copy()
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, model.geom_quat[g])
        rot = rot.reshape(3, 3)
        for point, normal, _ in planes:
            along = rot.T @ normal
            k = int(np.argmax(np.abs(along)))
            if abs(along[k]) < 1 - 1e-9:
                break
            cut = float((centre - point) @ normal) + size[k]  # the box's front past the plane
            if cut <= 0:
                continue
            if cut >= 2 * size[k]:
                break
            size[k] -= cut / 2
            centre -= cut / 2 * normal
        else:
            geom.pos, geom.quat, geom.size = centre, model.geom_quat[g].copy(), size
            return
    point, normal, cut = max(planes, key=lambda plane: plane[2])
    geom.pos = np.asarray(geom.pos, float) - cut * normal


def clip_hull(vertices: np.ndarray, point: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Vertices (m, 3) of the part of the convex hull of `vertices` (n, 3) behind the plane through `point` (3,)
    with unit `normal` (3,), (x - point) . normal <= 0: the hull's vertices behind it and the points where its
    edges cross it (none: the hull lies in front)."""
    import trimesh

    hull = trimesh.Trimesh(vertices=np.asarray(vertices, float)).convex_hull
    v = np.asarray(hull.vertices, float)
    side = (v - point) @ normal
    a, b = np.asarray(hull.edges_unique).T
    crossing = side[a] * side[b] < 0
    a, b = a[crossing], b[crossing]
    t = (side[a] / (side[a] - side[b]))[:, None]
    return np.vstack([v[side <= 0], v[a] + t * (v[b] - v[a])])


def geom_vertices(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """(n, 3) vertices [m] of compiled mesh geom `geom` in its body's frame (their convex hull is what MuJoCo's
    collision uses)."""
    mesh = model.geom_dataid[geom]
    first = model.mesh_vertadr[mesh]
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, model.geom_quat[geom])
    return model.geom_pos[geom] + model.mesh_vert[first:first + model.mesh_vertnum[mesh]] @ rot.reshape(3, 3).T


def backing_depths(spec: mujoco.MjSpec, pads: Sequence[tuple[str, np.ndarray]],
                   samples: int = 11) -> list[dict[int, float]]:
    """For each pad, how far behind its face [m] each other colliding geom rigidly attached to the pad's body (welded
    to it, `model.body_weldid`) lies, by geom id: the shortest of the rays cast along -normal from a
    `samples` x `samples` grid over the face (rims included), started one pad thickness in front of it (negative:
    the geom reaches in front of the face). Geoms no ray meets are left out. Measured on a copy of `spec` compiled at
    its reference configuration; a mesh geom by its convex hull (what MuJoCo's collision uses), a primitive by
    `mujoco.mju_rayGeom`."""
    return _backing_depths(spec, *_compiled(spec), pads, samples)


def _compiled(spec: mujoco.MjSpec) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """A compiled copy of `spec` and its data at the reference configuration (body poses computed)."""
    model = spec.copy().compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    return model, data


def _backing_depths(spec: mujoco.MjSpec, model: mujoco.MjModel, data: mujoco.MjData,
                    pads: Sequence[tuple[str, np.ndarray]], samples: int) -> list[dict[int, float]]:
    """`backing_depths` on `model`, `spec` compiled, with `data` at its reference configuration."""
    hulls: dict[int, np.ndarray] = {}  # mesh geom id -> its convex hull's planes (world), computed once
    out = []
    for name, toward in pads:
        pad = pad_geometry(spec.geom(name), np.asarray(toward, float))
        g = model.geom(name).id
        body = model.geom_bodyid[g]
        rot, origin = data.xmat[body].reshape(3, 3), data.xpos[body]
        grid = [np.linspace(-h, h, samples) for h in pad.half]
        aa, bb = np.meshgrid(*grid, indexing="ij")
        face = pad.center + aa.reshape(-1, 1) * pad.axes[0] + bb.reshape(-1, 1) * pad.axes[1]
        starts = origin + (face + pad.thickness * pad.normal) @ rot.T  # world
        direction = -rot @ pad.normal
        welded = np.flatnonzero(model.body_weldid[model.geom_bodyid] == model.body_weldid[body])
        near = {}
        for other in map(int, welded):
            if other == g or (model.geom_contype[other] == 0 and model.geom_conaffinity[other] == 0):
                continue
            if model.geom_type[other] == mujoco.mjtGeom.mjGEOM_MESH:
                if other not in hulls:
                    from scipy.spatial import ConvexHull

                    frame = model.geom_bodyid[other]
                    world = data.xpos[frame] + geom_vertices(model, other) @ data.xmat[frame].reshape(3, 3).T
                    hulls[other] = ConvexHull(world).equations
                hits = [_ray_hull(hulls[other], start, direction) for start in starts]
            else:
                hits = [mujoco.mju_rayGeom(data.geom_xpos[other], data.geom_xmat[other], model.geom_size[other],
                                           start, direction, int(model.geom_type[other])) for start in starts]
            hits = [h for h in hits if h >= 0]
            if hits:
                near[other] = min(hits) - pad.thickness
        out.append(near)
    return out


def _ray_hull(planes: np.ndarray, start: np.ndarray, direction: np.ndarray) -> float:
    """Distance along unit `direction` from `start` to where the ray enters the convex hull with plane equations
    `planes` (m, 4: a . x + b <= 0 inside; -1: it misses)."""
    along, at = planes[:, :3] @ direction, planes[:, :3] @ start + planes[:, 3]
    parallel = np.abs(along) < 1e-15
    if np.any(at[parallel] > 0):  # parallel to a face it lies outside of
        return -1.0
    along, at = along[~parallel], at[~parallel]
    t = -at / along
    enter = max(0.0, float(t[along < 0].max(initial=0.0)))
    leave = float(t[along > 0].min(initial=np.inf))
    return enter if enter <= leave else -1.0


def pad_directions(spec: mujoco.MjSpec, pad_geoms: Sequence[str], tcp_site: str) -> list[tuple[str, np.ndarray]]:
    """For each pad geom, the direction (3,) in its body's frame from the pad toward the TCP site.

    Measured on a copy of the hand compiled at its reference configuration.
    """
    model = spec.copy().compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, tcp_site)
    out = []
    for name in pad_geoms:
        g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
        if g < 0 or site < 0:
            raise HandError(f"pad geom {name!r} or TCP site {tcp_site!r} not in the hand model")
        body = model.geom_bodyid[g]
        world = data.site_xpos[site] - data.geom_xpos[g]
        out.append((name, data.xmat[body].reshape(3, 3).T @ world))
    return out


def is_element(name: str) -> bool:
    """Whether a (hand-local, unprefixed) geom/body/joint name is a pad element."""
    return name.startswith(ELEMENT_PREFIX)


def uniform_patch_torque(mu: float, force: float, half: Sequence[float], n: int = 400) -> float:
    """Largest torque [N m] about the centre of a rectangle (half extents `half` [m]) under
    uniform pressure at total normal force `force` [N] before it slips: mu F mean(r) (midpoint rule, n x n)."""
    a = (np.arange(n) + 0.5) / n * 2 * half[0] - half[0]
    b = (np.arange(n) + 0.5) / n * 2 * half[1] - half[1]
    r = np.hypot(*np.meshgrid(a, b, indexing="ij"))
    return float(mu * force * r.mean())
