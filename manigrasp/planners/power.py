"""`power`: enveloping grasps for dexterous hands (also usable with parallel jaws).

1. Approach directions: a Fibonacci sphere of `n_directions`, turned about
   the vertical by a random angle, keeping those that do not come from below
   the table; for each, `n_rolls` rolls of the hand about the approach (random phase).
2. Stand-off: the open hand slides along the approach line through the
   object's centre of mass (shifted by each of `lateral_offsets` x the hand's
   `max_width` along the closing axis, toward the fingers); a bisection finds the nearest TCP position where
   its real collision geometry (MuJoCo) is clear of object and table; the
   hand is then backed off by each of `standoffs`. Poses whose pre-grasp pose
   collides are dropped.
3. Close: the fingers follow the hand's own free closing path
   (`closing.closing_path`), each stopping where it first touches the object
   or the table (kinematic closing, no dynamics). The contacts where fingers
   stopped are the planned contacts.
4. Keep poses with at least `min_fingers` fingers on the object;
   those that wrap the object (below) rank before those that do not;
   non-maximum suppression (3 cm / 30 deg) over them ordered by fingers
   touching keeps diverse ones; the contacts' epsilon and the open hand's
   palm-object gap (`wrap.palm_gaps`) of the first 3 n are computed and the
   best `n` by the score are returned.

Score (in [0, 1], higher is better):

    grip  = 0.5 * min(1, epsilon_L1 / epsilon_ref) + 0.5 * fingers_touching / fingers
    palm  = max(0, 1 - max(0, palm_gap) / palm_ref)
    score = (1 - palm_weight) * grip + palm_weight * palm
    score = (wraps + score) / 2          (with the wrap test, below: wraps is 1 or 0)

with epsilon_L1 the Ferrari-Canny epsilon of the found contacts as soft
fingers (`metrics`), fingers_touching the number of distinct fingers in
contact with the object (the contact count, not inflated by several contact
points of one finger) and palm_gap the smallest distance [m] between the palm
(every hand geom on no finger) and the object at the grasp pose, open hand:
a power grasp holds the object against the palm. The default palm_weight = 0
is the earlier score (fingers and epsilon only): `benchmarks/bench_power.py`
measured palm_weight 0.3 and 0.6 bringing the palm within 10 mm of the object
in 95-100% of the candidates (68% without) but lowering the simulated success
of the dexterous hands (with the stiff thumb rotation: 14/40 and 13/40 vs
18/40), so the term is off by default.

The wrap test ranks candidates before the grip and palm terms do: a closure wraps the object when no touching
finger pushes it out of the hand, i.e. every finger's contacts push it toward the palm or across it
(`wrap.finger_inward`: the least over the fingers of the mean -n . z of a finger's contacts, n the inward
contact normal, z the approach, is >= `min_inward`, default 0). Those that wrap score in [0.5, 1], the others
in [0, 0.5] (so `n` are still returned, the others last); min_inward None: no test, the score above. Why: the
kinematic close stops each finger at its first touch of an object held still; in the simulated close the first
finger to touch pushes the object until something opposes it. On the Allegro (its opposed thumb reaches 133 mm
out of the palm, so a 65 mm tennis ball on the table is reached from 45-65 mm off the palm), its 29 3-finger
closures (of 357 poses) had the ball's centre 33-62 mm beyond the TCP, the middle and ring fingertips mostly on
its palm-side half (their pushes -n . z down to -0.7); the thumb touched 4-5 path steps (of 16) before the fingers and
rolled the ball 30-60 mm along the table, and the two tips left squeezed it out: 0/10 at seed 0. The closures
whose fingers push toward the palm (mostly thumb and middle, the palm 1-45 mm off) held, the thumb pressing
the ball into the palm: of the 90 candidates with 2+ fingers of one planning call (seed 0), each simulated
under `standard` at 10 N, 22 of the 24 that pass the test succeeded, 3 of the 66 others. The dexterous
config's 7 objects x 10, `standard` at 10 N, with the test against without: docs/planners.md, "power: the
wrap test".
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.geometry import perpendicular_basis
from manigrasp.grasp.closure import EPSILON_TOLERANCE
from manigrasp.hands.base import Hand
from manigrasp.planners.base import GraspCandidate, Observation, ObservationKind
from manigrasp.planners.closing import ClosingPath, Closure, FingerSweep, closing_path
from manigrasp.planners.collision import DEFAULT_CLEARANCE, HandProbe
from manigrasp.planners.context import PlanContext, resolve
from manigrasp.planners.geometry import fibonacci_sphere, tcp_frames
from manigrasp.planners.metrics import ContactModel, grasp_metrics, torque_scale
from manigrasp.planners.nms import DEFAULT_ANGLE, DEFAULT_DISTANCE, suppress
from manigrasp.planners.wrap import finger_inward, palm_gaps

BISECTION_STEPS = 8  # resolution (2 radius + FAR) / 256, about 1 mm
EVALUATED = 3  # epsilon is computed for this many times n NMS survivors, the best n are returned
FAR = 0.15  # [m] beyond the object's radius, the open hand is assumed clear of it


@dataclass(frozen=True)
class PowerPlanner:
    """Enveloping grasps found by kinematic closing (module docstring).

    Attributes:
        n_directions: points of the Fibonacci sphere (about half come from above the table).
        n_rolls: rolls of the hand about each approach direction.
        standoffs: gaps [m] between the hand and its first touch of the object along the approach.
        lateral_offsets: shifts of the approach line along the closing axis y (from the thumb toward the
            fingers), as fractions of `hand.max_width` [-]: the object's centre then lies that far from the
            TCP toward the fingers. Default (0,): the approach line runs through the centre of mass.
        closing_steps: shapes along the closing path (resolution of the kinematic close).
        min_fingers: fewest fingers that must touch the object.
        contact: contact model of the analysis (friction mu, torsion gamma). The minimum friction for
            closure is off by default here (a bisection of ~10 hull computations per grasp of 5+
            contacts, about 0.1 s each): candidates then carry min_friction None.
        max_approach_z: largest z component of the approach (0: horizontal at most, never from below).
        epsilon_ref: epsilon that counts as full marks in the score [scaled N].
        palm_weight: weight of the palm term in the score [-], in [0, 1]. Default 0: the palm is ignored
            (measured to lower the simulated success, module docstring).
        palm_ref: palm-object gap [m] at which the palm term reaches 0 (1 at contact).
        min_inward: the wrap test's threshold on `wrap.finger_inward` [-] (module docstring): closures at or
            above it rank before the others; None: no test (the ranking before 4 Dec 2026).
        nms_distance: [m]; nms_angle: [rad] (non-maximum suppression thresholds).
        clearance: hand-object/table distance that counts as a collision [m].
        pregrasp_offset: pre-grasp distance back along the approach [m] where the open hand is checked for
            collisions; None: the protocol's (`PlanContext.pregrasp_offset`).
    """

    name: ClassVar[str] = "power"
    needs: ClassVar[ObservationKind] = "mesh"

    n_directions: int = 64
    n_rolls: int = 6
    standoffs: tuple[float, ...] = (0.0, 0.005, 0.02)
    lateral_offsets: tuple[float, ...] = (0.0,)
    closing_steps: int = 16
    min_fingers: int = 2
    contact: ContactModel = field(default_factory=lambda: ContactModel(min_friction=False))
    max_approach_z: float = 0.0
    epsilon_ref: float = 0.1
    palm_weight: float = 0.0
    palm_ref: float = 0.02
    min_inward: float | None = 0.0
    nms_distance: float = DEFAULT_DISTANCE
    nms_angle: float = DEFAULT_ANGLE
    clearance: float = DEFAULT_CLEARANCE
    pregrasp_offset: float | None = None
    _paths: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for key in ("n_directions", "n_rolls", "closing_steps", "min_fingers"):
            if int(getattr(self, key)) < 1:
                raise ConfigError(f"power: {key} must be >= 1, got {getattr(self, key)}")
        if not self.standoffs or min(self.standoffs) < 0 or self.epsilon_ref <= 0:
            raise ConfigError("power: standoffs must be non-empty and >= 0, epsilon_ref > 0")
        object.__setattr__(self, "standoffs", tuple(float(s) for s in self.standoffs))
        if not self.lateral_offsets:
            raise ConfigError("power: lateral_offsets must be non-empty")
        object.__setattr__(self, "lateral_offsets", tuple(float(s) for s in self.lateral_offsets))
        if self.min_inward is not None and not -1.0 <= self.min_inward <= 1.0:
            raise ConfigError(f"power: min_inward must be None or in [-1, 1], got {self.min_inward}")
        if not (0.0 <= self.palm_weight <= 1.0 and self.palm_ref > 0):
            raise ConfigError(f"power: palm_weight must be in [0, 1] and palm_ref > 0, got {self.palm_weight}, "
                              f"{self.palm_ref}")

    def plan(self, observation: Observation, hand: Hand, n: int, rng: np.random.Generator,
             context: PlanContext | None = None) -> list[GraspCandidate]:
        """At most `n` enveloping grasps, best first, for the protocol and scene described by `context` (None:
        the standard protocol's defaults, the default scene)."""
        context = resolve(context, self.pregrasp_offset)
        offset = context.pregrasp_offset
        mesh = observation.world_mesh()
        center = observation.center_of_mass
        scale = torque_scale(mesh.vertices, center)
        probe = HandProbe(hand, observation, self.clearance, config=context.scene)
        poses = self.standoff_poses(probe, self.directions(rng), center, scale, hand.max_width, offset)
        sweep = FingerSweep(probe, self._path(hand))
        pos, quat = probe.roots(poses)
        closures = [sweep.close(pos[i], quat[i]) for i in range(len(poses))]
        need = min(self.min_fingers, sweep.n_fingers)
        good = np.array([i for i, c in enumerate(closures) if c.n_fingers >= need], int)
        # NMS on the contact count first; epsilon (the costly part) only for the best EVALUATED x n survivors.
        count = np.array([closures[i].n_fingers for i in good], float)
        wraps = np.ones(len(closures))
        if self.min_inward is not None:  # closures that push the object out of the hand rank after the others
            wraps[good] = [finger_inward(closures[i], poses[i][:3, 2]) >= self.min_inward for i in good]
        order = good[np.argsort(-(count + (sweep.n_fingers + 1) * wraps[good]), kind="stable")]
        survivors = order[suppress(poses[order], self.nms_distance, self.nms_angle, hand.kind == "parallel")]
        top = survivors[:EVALUATED * n]
        eps, min_mu = self._metrics([closures[i] for i in top], center, scale)
        fraction = np.array([closures[i].n_fingers for i in top], float) / sweep.n_fingers
        grip = 0.5 * np.clip(eps / self.epsilon_ref, 0.0, 1.0) + 0.5 * fraction
        palm = np.zeros(len(top)) if self.palm_weight == 0 else self._palm_term(probe, poses[top])
        score = (1.0 - self.palm_weight) * grip + self.palm_weight * palm
        if self.min_inward is not None:  # the wrap test first (the harness ranks candidates by their score)
            score = 0.5 * (wraps[top] + score)
        return [self._candidate(poses[top[k]], score[k], closures[top[k]], eps[k], min_mu[k], offset)
                for k in np.argsort(-score, kind="stable")[:n]]

    def _path(self, hand: Hand) -> ClosingPath:
        """The hand's closing path, computed once per hand name and planner."""
        key = (hand.name, self.closing_steps)
        if key not in self._paths:
            self._paths[key] = closing_path(hand, self.closing_steps)
        return self._paths[key]

    # ------------------------------------------------------------ steps
    def directions(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Approach (k, 3) and closing (k, 3) directions: sphere points from above x rolls (step 1)."""
        turn = rng.random() * 2.0 * np.pi
        c, s = np.cos(turn), np.sin(turn)
        approach = fibonacci_sphere(self.n_directions) @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        approach = approach[approach[:, 2] <= self.max_approach_z]
        a, b = perpendicular_basis(approach)
        roll = rng.random(len(approach))[:, None] + np.arange(self.n_rolls)[None, :] / self.n_rolls
        roll = 2.0 * np.pi * roll  # (k, rolls)
        closing = np.cos(roll)[..., None] * a[:, None] + np.sin(roll)[..., None] * b[:, None]
        return np.repeat(approach, self.n_rolls, axis=0), closing.reshape(-1, 3)

    def standoff_poses(self, probe: HandProbe, directions: tuple[np.ndarray, np.ndarray], center: np.ndarray,
                       radius: float, width: float = 0.0, pregrasp_offset: float | None = None) -> np.ndarray:
        """Collision-free TCP poses (m, 4, 4) backed off from the first touch along each approach (step 2), the
        open hand clear at each and at its pre-grasp pose `pregrasp_offset` [m] back (None: the standard protocol's).

        Each approach line runs through the centre shifted by each lateral offset (x `width` [m], along
        the closing axis y), so the object's centre lies that far toward the fingers in the TCP frame.
        """
        approach, closing = directions
        far = radius + FAR  # [m] TCP distance from the centre at which the hand is clear of the object
        offset = resolve(None, pregrasp_offset).pregrasp_offset
        out = []
        for a, y in zip(approach, closing, strict=True):
            base = tcp_frames(center[None], a[None], y[None])[0]
            for offset in self.lateral_offsets:
                frame = base.copy()
                frame[:3, 3] = center - offset * width * base[:3, 1]
                touch = self._first_touch(probe, frame, a, -radius, far)
                if touch is None:
                    continue
                for gap in self.standoffs:
                    pose = frame.copy()
                    pose[:3, 3] = frame[:3, 3] - (touch + gap) * a
                    if probe.free(pose, offset):
                        out.append(pose)
        return np.array(out).reshape(-1, 4, 4)

    @staticmethod
    def _first_touch(probe: HandProbe, frame: np.ndarray, approach: np.ndarray, near: float,
                     far: float) -> float | None:
        """Smallest back-off t in [near, far] (TCP at centre - t approach) that is collision-free, or None."""
        root_pos, root_quat = (x[0] for x in probe.roots(frame[None]))

        def clear(t: float) -> bool:
            probe.place(root_pos - t * approach, root_quat)
            return not probe.touching()

        if not clear(far):
            return None
        lo, hi = near, far
        if clear(lo):
            return lo
        for _ in range(BISECTION_STEPS):
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if clear(mid) else (mid, hi)
        return hi

    def _palm_term(self, probe: HandProbe, poses: np.ndarray) -> np.ndarray:
        """(m,) palm term of the score in [0, 1] of TCP poses (m, 4, 4) (module docstring)."""
        gaps = np.maximum(palm_gaps(probe, poses), 0.0)
        return np.clip(1.0 - gaps / self.palm_ref, 0.0, 1.0)

    def _metrics(self, closures: list[Closure], center: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
        """Epsilon (m,) and minimum friction (m,) of each closure, batched by contact count."""
        eps, min_mu = np.zeros(len(closures)), np.full(len(closures), np.nan)
        counts = np.array([len(c.positions) for c in closures], int)
        for k in np.unique(counts):
            rows = np.flatnonzero(counts == k)
            positions = np.stack([closures[i].positions for i in rows])
            normals = np.stack([closures[i].normals for i in rows])
            metrics = grasp_metrics(positions, normals, center, scale, self.contact)
            eps[rows], min_mu[rows] = metrics.epsilon_l1, metrics.min_friction
        return eps, min_mu

    def _candidate(self, pose: np.ndarray, score: float, closure: Closure, eps: float,
                   min_mu: float, pregrasp_offset: float) -> GraspCandidate:
        return GraspCandidate(
            pose=pose, score=float(score), width=None, preshape=0.0, contacts=closure.positions,
            contact_normals=closure.normals, contact_friction=closure.friction, epsilon_l1=float(eps),
            force_closure=bool(eps > EPSILON_TOLERANCE),
            min_friction=None if np.isnan(min_mu) else float(min_mu),
            pregrasp_offset=pregrasp_offset, planner=self.name)

