"""`antipodal`: two-finger grasps on antipodal point pairs of the object's mesh.

1. Sample surface points, uniform by area; outward normals are interpolated
   over each face with creases kept sharp (`geometry.SmoothNormals`).
2. From each point cast rays inward, along the inward normal (and, with
   `rays_per_sample` > 1, more rays inside `ray_cone` of the friction cone);
   the first hit is where the ray leaves the object: the opposite contact.
   All rays of a plan are cast at once (trimesh, with embree when installed).
3. Keep pairs whose connecting line lies inside the friction cone at both
   contacts, whose width fits the open jaw, and whose line is free outside the
   two contacts as far as the open fingers reach (so the fingers meet these
   two points first when they close, not another part of the object); thin
   them to the most antipodal pair per 1 cm / ~10 degree cell.
4. Around each grasp axis, `n_approaches` approach directions evenly spaced
   (random phase), none from below the table, at TCP depths back along the
   approach (fractions of how far the fingers reach beyond the TCP, so a
   thin object can be pinched near the fingertips above the table) and at
   lateral offsets across the pads (fractions of the fingers' half-width, so
   the contacts may sit near a pad's edge: a tilted approach to a thin object
   keeps the pads' lower corner above the table; none by default, the dense
   grid of step 6 has them).
5. Rank by the score (ties: centred contacts first, then the deepest; pairs
   whose lower open jaw cannot clear the table last: `jaw_poses`),
   then walk down the ranking: skip a pose that duplicates a kept one (NMS,
   3 cm / 30 deg, fingers swapped = same grasp), keep it if the open hand's
   collision geometry is clear of object and table at the grasp and at the
   pre-grasp pose (MuJoCo), until `n` are kept. Then (`repack`; on a mesh or
   a cloud checked against its hull, not under ``completion="free_space"``)
   the ranking's free poses are packed from the top
   (`select.pack_ranked`: as short a prefix of the ranking as still gives `n`
   mutually distinct poses); that set replaces the walk's if it is larger, or
   as large with a better worst score. Greedy NMS in rank order lets the best
   pose of a region suppress its equally good neighbours and fills up from far
   down the ranking: on the potted meat can's scan the walk keeps 16-18 of its
   body grasps and 2-4 pinches on its 2 mm lip (score ~0.05, they slip), the
   packing 20 body grasps; on the cracker box scan (seed 1, 12 approaches)
   the 20th grasp's score goes from 0.106 to 0.116 (its tail is
   torsion-limited, 70-100 mm from the centre of mass).
6. If fewer than min(`n`, `dense_below`) poses scoring at least `dense_floor`
   (default 0: any) were kept (thin or narrow objects, whose grasps form one narrow band; or a
   scanned mesh whose walk, its good poses used up by NMS, fills up with
   pinches on a lip or seam that score ~0.05), plan again on a denser grid of
   approaches, depths and lateral offsets (`dense_*`) for the pairs whose
   jaws clear the table, test the best-ranked `dense_checks` of its poses
   for collision, and pack the free ones into as many mutually distinct
   poses as possible (`nms.pack`: fewest conflicts first, then swaps). The
   larger of the two sets is returned, best first; of two sets as large, the
   one with more poses scoring at least `dense_floor` (greedy NMS in rank
   order keeps about half as many distinct poses as packing: on the potted
   meat can's scan 16-18 of its 28-30 body grasps, the rest of its 20 lip
   pinches).

Score (in [0, 1], higher is better), per contact pair:

    score = hold * (0.5 * antipodality + 0.5 * min(1, epsilon_L1 / epsilon_ref))
    hold = min(1, h / hold_ref),   h = G / G_required
    antipodality = 1 - max(alpha_1, alpha_2) / atan(mu)

with alpha_i the angle between the grasp line and the inward normal at
contact i (0: perfectly antipodal, atan(mu): on the cone's edge), and
epsilon_L1 the Ferrari-Canny epsilon of the two contacts as soft fingers
(`metrics`). epsilon_ref (0.1) is about the epsilon of an ideal two-finger
grasp through the centre of mass with mu = 0.5, gamma = 5 mm, on a 5 cm object.

h is the hold margin (`hold`): G is the grip force the protocol closes to
(`PlanContext.grip_force_for`: by default half the hand's max_grip_force, 35 N
for parallel_jaw), and G_required the smallest grip force with which the two
contacts, as soft fingers (mu, gamma) squeezed along the grasp line, hold the
object's weight m g and the weight plus each of the protocol's perturbations
(`PlanContext.perturbation` m g along +-x, +-y, +-z; 1 m g for the standard
protocol) at its centre of mass: the tangential load and its tipping couple, and
the gravity torque about the grasp line (m g d for a grasp a distance d from
the centre of mass) that only the contacts' torsional friction gamma f can
resist. h >= 1 holds every load; hold_ref (3) asks for a safety factor, since
the lift's accelerations and the contacts' compliance come on top. Mass:
the asset's, else the mesh's volume x `density`.

Pads' footprint (mesh plans, hands with `pad_geoms`; `pad_footprint`): a pad
is a patch, not the pair's point. Each pose of step 5 is scored on what its
pads touch there (`footprint`): rays from a grid of cells over each open pad's
face find the surface's gap under every cell, an elastic foundation that
sinks `pad_compression` on a flat face shares the grip among the cells within
reach, and the patch's torsion radius about the point it pivots on (the
weighted geometric median of the cells' loads) is compared with a flat face
under the whole pad. The pose's hold margin is the pair's, computed on the
grasp line moved to that pivot with gamma times that ratio, with each
contact's tilt that of the plane fitted to the surface its pad touches
(`footprint.patch_tilt`: what a pad pressed on a patch feels; a scan's point
normals carry its noise, and contact p's tilt is 0 by construction; a pad
on a single row of cells takes the tilt of the faces it touches), and with
the torque across the grasp line taken in part by the pads' pressure, up to
the grip times the patch's kern (`footprint.patch_support`: a pad along a
bowl's wall holds it up where a pad touching the rim with its end lets it
tip about that line); the pose's score is the pair's with that hold margin,
and ranks it. A pad half over an edge,
or on a face that bulges or curves away by millimetres (a scanned carton,
whose grasps near its rounded edges load one end of each pad and let it turn
in the grip), ranks below a pose whose pads sit flat; on a flat face fully
under both pads nothing changes. A viewed cloud's plan (``completion="free_space"``) scores each pose
on the views' blocked space instead of a mesh (`partial.SpaceProbe.seat`): a pad's cell touches
where that space crosses the jaws' midplane under it, else it hangs over an edge or over space a
view saw through; only the torsion ratio of that patch lowers the pair's hold margin (the gaps, tilt
and pressure are not measured there). Under one camera the single-sided grasps of the sugar box
with a pad half over an edge (true seat ratio < 0.7) held 1 of 9 trials, the others 71 of 71.
The other point-cloud completions score pairs only.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, NamedTuple

import numpy as np
import trimesh

from manigrasp.errors import ConfigError, PlannerError
from manigrasp.grasp.closure import EPSILON_TOLERANCE
from manigrasp.hands.base import Hand
from manigrasp.objects.pipeline import DEFAULT_DENSITY
from manigrasp.planners.base import GraspCandidate, Observation, ObservationKind
from manigrasp.planners.cloud import cloud_pairs, collision_hull, complete, hull_volume
from manigrasp.planners.collision import DEFAULT_CLEARANCE, HandProbe
from manigrasp.planners.context import PlanContext, resolve
from manigrasp.planners.footprint import DEFAULT_COMPRESSION, DEFAULT_GRID, on_pivot, pad_footprint
from manigrasp.planners.free_space import DEFAULT_TAU
from manigrasp.planners.geometry import SmoothNormals, sample_surface
from manigrasp.planners.hold import hold_margin, loads, required_grip
from manigrasp.planners.jaw_poses import PoseGrid, ranked_poses
from manigrasp.planners.metrics import ContactModel, grasp_metrics, torque_scale
from manigrasp.planners.nms import DEFAULT_ANGLE, DEFAULT_DISTANCE, Suppressor
from manigrasp.planners.pairs import Pairs, cone_rays, find_pairs, thin_pairs
from manigrasp.planners.partial import DENSE_CHECKS, SpaceProbe, free_space_target, select_clear
from manigrasp.planners.select import pack_free, pack_ranked, select_free
from manigrasp.sim.config import SceneConfig

COMPLETIONS = ("free_space", "point_symmetry", "none")


class _Target(NamedTuple):
    """What the shared stages need from either path: pairs, centre of mass (3,) [m], torque scale [m],
    mass [kg], the collision probe, a confidence (m,) multiplying each pair's score (None: 1), and the object's
    mesh in the world when planning on one (the pads' footprint is evaluated on it)."""

    pairs: Pairs
    center: np.ndarray
    scale: float
    mass: float
    probe: HandProbe
    confidence: np.ndarray | None = None
    mesh: trimesh.Trimesh | None = None


@dataclass(frozen=True)
class AntipodalPlanner:
    """Antipodal two-finger grasps (module docstring); parameters are config fields.

    Attributes:
        n_samples: surface points sampled per plan.
        rays_per_sample: inward rays per point (the first along the inward normal).
        ray_cone: extra rays lie within this fraction of the friction cone half-angle [-].
        n_approaches: approach directions around each grasp axis (24: 15 degrees apart, half the NMS angle, so
            that `repack` can shift a grasp's approach to fit one more distinct grasp beside it; at 12 (30
            degrees, one per NMS cell) the cracker box scan held 53/60 over seeds 0-2, at 24 56/60).
        depth_fractions: TCP offsets back along the approach from the contacts' midpoint, as fractions
            of the fingers' reach beyond the TCP (`HandProbe.finger_extents`; 1.5 cm for parallel_jaw) [-].
        lateral_fractions: TCP offsets across the pads (the TCP's x axis) from the contacts' midpoint, as
            fractions of the fingers' half-width (`HandProbe.finger_extents`; 1 cm for parallel_jaw) [-].
        dense_approaches, dense_depth_fractions, dense_lateral_fractions: the denser grid of step 6.
        dense_checks: the most poses of the dense grid tested for collision (the best ranked; on a viewed
            cloud at most `partial.DENSE_CHECKS`).
        dense_below: step 6 runs when step 5 keeps fewer than min(n, dense_below) poses scoring at least
            `dense_floor`: objects with few distinct grasps, where its cost (about 1-2 s) buys most; 0: never.
        repack: after the walk of step 5, pack the ranking's free poses from its top (module docstring, step 5)
            and keep that set if larger, or as large with more poses scoring at least `dense_floor`, or as large
            and as many with a better worst score; not under ``completion="free_space"``; False: the walk's set.
        dense_floor: score below which a kept pose does not count as a grasp for step 6 [-] (0, the default:
            every pose counts). 0.1 is above a pinch on a scan's lip or seam (0.03-0.08): on the potted meat
            can's scan it takes the 20 grasps from the packed body grasps (seeds 0-2: 47 -> 60/60), but it
            costs the gelatin box scan 60 -> 55/60 (the packed set holds worse there), so it is opt-in
            (both measured without `repack`, which now gives the potted meat can's scan its body grasps).
        contact: contact model of the analysis (friction mu, torsion gamma).
        min_width: narrowest grasp [m].
        width_margin: the open jaw must be this much wider than the grasp [m].
        max_approach_z: largest z component of the approach direction (0: horizontal at most, never from below).
        epsilon_ref: epsilon that counts as full marks in the score [scaled N].
        nms_distance: [m]; nms_angle: [rad] (non-maximum suppression thresholds).
        clearance: hand-object/table distance that counts as a collision [m].
        pregrasp_offset: pre-grasp distance back along the approach [m] where the open hand is checked for
            collisions; None: the protocol's (`PlanContext.pregrasp_offset`).
        max_checks: the most poses tested for collision per plan.
        grip_fraction: grip force as a fraction of the hand's max_grip_force for the hold margin [-]; None: the
            protocol's grip force (`PlanContext.grip_force_for`).
        perturbation: load beyond the weight in units of the object's weight for the hold margin [-]; None: the
            protocol's (`PlanContext.perturbation`).
        hold_ref: hold margin that counts as full marks in the score (a safety factor) [-].
        density: of an object without a built asset (mesh or point cloud), for its mass [kg/m^3].
        completion: how a point cloud's unseen side is handled: "free_space" (visible and single-sided pairs,
            the hand tested against the space the depth views saw through: `partial`; needs a
            `free_space.ViewedObservation`), "point_symmetry" (reflection through an estimated centre) or
            "none" (visible pairs only, collision against the cloud's hull) (`cloud`).
        cloud_radius: smallest distance from a ray at which a cloud point still lies on it [m]
            (1.5 x the cloud's point spacing if larger).
        cloud_margin: the collision hull of a point cloud is pushed out this far [m].
        hidden_weight: score factor of a single-sided pair (its far contact unseen) [-] (`partial`).
        hidden_uncertainty: largest distance the object may extend beyond a single-sided pair's far contact [m].
        free_space_tau: half-width of the measured surface band of the free-space test [m].
        region_margin: the object's region is the cloud's bounding box grown by this much [m].
        hidden_margin: unknown (occluded) space blocks the hand only within this distance [m] of the seen
            points' footprint (the object's hidden part lies under its seen surfaces), and a single-sided
            line's far contact is bounded by the same footprint (`partial`, step 2); None: all of it
            inside the region (strict).
        pad_footprint: score each pose of a mesh plan, or of a viewed cloud's (``completion="free_space"``), on
            what its pads touch (module docstring, "Pads' footprint"); False: the pair's score for all its
            poses (as before).
        pad_compression: the pads' compression on a flat face at the grip [m] (the compliant pads' 1 mm at
            35 N, `hands.pads`): how far below the nearest point the surface may lie and still be touched.
        footprint_grid: cells across and along each pad's face where the surface is sampled.
        pair_cell: pairs are thinned to the most antipodal one per cell of this size [m] and ~10 degrees
            of line direction before scoring (`thin_pairs`).
    """

    name: ClassVar[str] = "antipodal"
    needs: ClassVar[tuple[ObservationKind, ...]] = ("mesh", "points")
    hand_kinds: ClassVar[tuple[str, ...]] = ("parallel",)

    n_samples: int = 2048
    rays_per_sample: int = 1
    ray_cone: float = 0.5
    n_approaches: int = 24
    depth_fractions: tuple[float, ...] = (0.0, 0.4, 0.8)
    lateral_fractions: tuple[float, ...] = (0.0,)
    dense_approaches: int = 36
    dense_depth_fractions: tuple[float, ...] = (0.0, 0.3, 0.6, 0.9)
    dense_lateral_fractions: tuple[float, ...] = (0.0, -0.4, 0.4, -0.8, 0.8)
    dense_checks: int = 40_000
    dense_below: int = 25
    dense_floor: float = 0.0
    repack: bool = True
    contact: ContactModel = field(default_factory=ContactModel)
    min_width: float = 0.002
    width_margin: float = 0.005
    max_approach_z: float = 0.0
    epsilon_ref: float = 0.1
    nms_distance: float = DEFAULT_DISTANCE
    nms_angle: float = DEFAULT_ANGLE
    clearance: float = DEFAULT_CLEARANCE
    pregrasp_offset: float | None = None
    max_checks: int = 20_000
    pair_cell: float = 0.01
    grip_fraction: float | None = None
    perturbation: float | None = None
    hold_ref: float = 3.0
    density: float = DEFAULT_DENSITY
    completion: str = "free_space"
    cloud_radius: float = 0.003
    cloud_margin: float = 0.003
    hidden_weight: float = 0.8
    hidden_uncertainty: float = 0.025
    free_space_tau: float = DEFAULT_TAU
    region_margin: float = 0.03
    hidden_margin: float | None = 0.002
    pad_footprint: bool = True
    pad_compression: float = DEFAULT_COMPRESSION
    footprint_grid: tuple[int, int] = DEFAULT_GRID

    def __post_init__(self) -> None:
        for key in ("n_samples", "rays_per_sample", "n_approaches", "max_checks", "dense_approaches", "dense_checks"):
            if int(getattr(self, key)) < 1:
                raise ConfigError(f"antipodal: {key} must be >= 1, got {getattr(self, key)}")
        if not 0.0 <= self.ray_cone <= 1.0:
            raise ConfigError(f"antipodal: ray_cone must be in [0, 1], got {self.ray_cone}")
        depth, lateral = ("[0, 1)", lambda x: 0.0 <= x < 1.0), ("(-1, 1)", lambda x: -1.0 < x < 1.0)
        for key, (interval, valid) in (("depth_fractions", depth), ("dense_depth_fractions", depth),
                                       ("lateral_fractions", lateral), ("dense_lateral_fractions", lateral)):
            fractions = tuple(float(x) for x in np.atleast_1d(getattr(self, key)))
            if not fractions or not all(valid(x) for x in fractions):
                raise ConfigError(f"antipodal: {key} must be a non-empty list in {interval}, got {getattr(self, key)}")
            object.__setattr__(self, key, fractions)
        if self.epsilon_ref <= 0 or self.clearance < 0 or self.dense_below < 0 or not 0 <= self.dense_floor <= 1:
            raise ConfigError("antipodal: epsilon_ref must be > 0, clearance and dense_below >= 0, "
                              "dense_floor in [0, 1]")
        if not (self.hold_ref > 0 and self.density > 0):
            raise ConfigError("antipodal: hold_ref and density must be > 0")
        try:
            resolve(None, self.pregrasp_offset, self.grip_fraction, self.perturbation)
        except ConfigError as exc:
            raise ConfigError(f"antipodal: {exc}") from None
        if self.completion not in COMPLETIONS:
            raise ConfigError(f"antipodal: unknown completion {self.completion!r}; valid: {', '.join(COMPLETIONS)}")
        if not self.pad_compression > 0 or len(self.footprint_grid) != 2 or min(self.footprint_grid) < 1:
            raise ConfigError("antipodal: pad_compression must be > 0 and footprint_grid two counts >= 1, got "
                              f"{self.pad_compression}, {self.footprint_grid}")
        object.__setattr__(self, "footprint_grid", tuple(int(c) for c in self.footprint_grid))
        if self.cloud_radius <= 0 or self.cloud_margin < 0:
            raise ConfigError("antipodal: cloud_radius must be > 0 and cloud_margin >= 0")
        if not (0 < self.hidden_weight <= 1 and self.hidden_uncertainty >= 0 and self.free_space_tau > 0
                and self.region_margin >= 0 and (self.hidden_margin is None or self.hidden_margin >= 0)):
            raise ConfigError("antipodal: hidden_weight must be in (0, 1], hidden_uncertainty, region_margin and "
                              "hidden_margin >= 0, free_space_tau > 0")

    def plan(self, observation: Observation, hand: Hand, n: int, rng: np.random.Generator,
             context: PlanContext | None = None) -> list[GraspCandidate]:
        """At most `n` collision-free antipodal grasps for a two-jaw `hand`, best first, for the protocol and
        scene described by `context` (None: the standard protocol's defaults, the default scene).

        Plans on the mesh when the observation has one, else on its point cloud: by default visible and
        single-sided pairs against the depth views' free space (`partial`), or a completed cloud (`cloud`).
        """
        context = resolve(context, self.pregrasp_offset, self.grip_fraction, self.perturbation)
        if hand.kind != "parallel":
            raise PlannerError(f"antipodal plans two-jaw grasps; hand {hand.name!r} is {hand.kind} "
                               "(use the 'power' planner)")
        target = self._mesh_target if observation.mesh is not None else self._cloud_target
        pairs, center, scale, mass, probe, confidence, mesh = target(observation, hand, rng, context.scene)
        eps = grasp_metrics(*self._contacts(pairs), center, scale,
                            ContactModel(self.contact.mu, self.contact.gamma, min_friction=False)).epsilon_l1
        score = self.score(pairs, eps, self.hold(pairs, center, mass, hand, context))
        if confidence is not None:
            score = score * confidence
        pose_score = None
        if self.pad_footprint and (mesh is not None or isinstance(probe, SpaceProbe)):
            pose_score = self._pose_score(pairs, eps, center, mass, hand, context, probe, mesh, confidence)
        extents = probe.finger_extents()
        ranked = ranked_poses(pairs, score, self.grid, extents, hand.max_width, self.max_approach_z,
                              observation.table_height, rng, pose_score=pose_score)
        nms = Suppressor(self.nms_distance, self.nms_angle, symmetric=True, capacity=max(n, 1))
        select = select_clear if isinstance(probe, SpaceProbe) else select_free
        chosen = ranked.order[select(probe, nms, ranked.poses[ranked.order], n, context.pregrasp_offset,
                                     self.max_checks)]
        if self.repack and not isinstance(probe, SpaceProbe) and len(chosen):
            packed = ranked.order[pack_ranked(probe, ranked.poses[ranked.order], n, self.nms_distance,
                                              self.nms_angle, True, context.pregrasp_offset, self.max_checks)]
            if _better(ranked.score[packed], ranked.score[chosen], self.dense_floor, True):
                chosen = packed
        if (ranked.score[chosen] >= self.dense_floor).sum() < min(n, self.dense_below) and len(pairs):
            dense = ranked_poses(pairs, score, self.dense_grid, extents, hand.max_width, self.max_approach_z,
                                 observation.table_height, rng, keep_unclear=False, pose_score=pose_score)
            checks = min(self.dense_checks, DENSE_CHECKS) if isinstance(probe, SpaceProbe) else self.dense_checks
            packed = dense.order[pack_free(probe, dense.poses[dense.order], n, self.nms_distance, self.nms_angle,
                                           True, context.pregrasp_offset, checks)]
            if _better(dense.score[packed], ranked.score[chosen], self.dense_floor, False):
                ranked, chosen = dense, packed
        return self._candidates(pairs, ranked.score, eps, ranked.poses, ranked.pair_of, chosen, center, scale,
                                context.pregrasp_offset)

    def _mesh_target(self, observation: Observation, hand: Hand, rng: np.random.Generator,
                     scene: SceneConfig | None = None) -> _Target:
        """Pairs on the mesh; centre of mass = the object frame's origin; the asset's mass (else volume x density);
        the hand probed in a scene of `scene` (`PlanContext.scene`)."""
        mesh = observation.world_mesh()
        center = observation.center_of_mass
        mass = observation.object_mass(self.density)
        return _Target(self.pairs(mesh, hand, rng), center, torque_scale(mesh.vertices, center), mass,
                       HandProbe(hand, observation, self.clearance, config=scene), mesh=mesh)

    def _cloud_target(self, observation: Observation, hand: Hand, rng: np.random.Generator,
                      scene: SceneConfig | None = None) -> _Target:
        """Pairs on the completed point cloud (`cloud`); its centre and hull; collision against the hull, the hand
        probed in a scene of `scene` (`PlanContext.scene`). With ``completion="free_space"``: visible and
        single-sided pairs, the views' free space (`partial`; its probe is compiled in the same scene)."""
        if self.completion == "free_space":
            return _Target(*free_space_target(self, observation, hand, rng, scene))
        done = complete(observation.points, observation.normals, observation.table_height, self.completion)
        radius = max(self.cloud_radius, 1.5 * done.spacing)
        widths = (self.min_width, hand.max_width - self.width_margin)
        pairs = cloud_pairs(done, self.n_samples, self.rays_per_sample, self.ray_cone, self.contact.mu, widths,
                            0.5 * hand.max_width, radius, rng)
        pairs = pairs.take(thin_pairs(pairs, self.pair_cell))
        hull = collision_hull(done, self.cloud_margin)
        mass = self.density * hull_volume(done.points)
        return _Target(pairs, done.center, torque_scale(done.points, done.center), mass,
                       HandProbe(hand, observation, self.clearance, config=scene, hull=hull))

    @property
    def grid(self) -> PoseGrid:
        """The grid of steps 4-5."""
        return PoseGrid(self.n_approaches, self.depth_fractions, self.lateral_fractions)

    @property
    def dense_grid(self) -> PoseGrid:
        """The denser grid of step 6."""
        return PoseGrid(self.dense_approaches, self.dense_depth_fractions, self.dense_lateral_fractions)

    def hold(self, pairs: Pairs, center: np.ndarray, mass: float, hand: Hand,
             context: PlanContext | None = None, torsion: np.ndarray | None = None,
             tilt: np.ndarray | None = None, support: np.ndarray | None = None,
             across: np.ndarray | None = None) -> np.ndarray:
        """(m,) hold margin h of each pair at the protocol's grip force and loads (module docstring, `hold`;
        `context` None: the standard protocol's, with this planner's own settings); `torsion` (m,) scales
        each pair's torsional friction gamma (the pads' footprint ratio; None: 1); `tilt` (m, 2) [rad] the
        contacts' normals off the grasp line where known (the pads' patches; NaN or None: the pair's normals);
        `support` (m, 2, 2) [m] and `across` (m, 3) the pads' kerns and the axis across their faces
        (`hold.required_grip`; None: point contacts)."""
        context = resolve(context, grip_fraction=self.grip_fraction, perturbation=self.perturbation)
        own = np.arccos(np.clip(np.stack([-np.einsum("ij,ij->i", pairs.n_p, pairs.axis),
                                          np.einsum("ij,ij->i", pairs.n_q, pairs.axis)], axis=1), -1.0, 1.0))
        tilt = own if tilt is None else np.where(np.isnan(tilt), own, tilt)
        gamma = self.contact.gamma if torsion is None else self.contact.gamma * np.asarray(torsion, float)
        required = required_grip(pairs.p, pairs.q, center, loads(mass, context.perturbation), self.contact.mu,
                                 gamma, tilt, support, across)
        return hold_margin(context.grip_force_for(hand), required)

    def _pose_score(self, pairs: Pairs, eps: np.ndarray, center: np.ndarray, mass: float, hand: Hand,
                    context: PlanContext, probe: HandProbe, mesh: trimesh.Trimesh | None,
                    confidence: np.ndarray | None):
        """The per-pose score of a mesh plan, or of a viewed cloud's on its views' blocked space (`mesh` None,
        `probe` a `SpaceProbe`: `SpaceProbe.seat`) (module docstring, "Pads' footprint"), or None for a hand
        without pads: a function of poses (k, 4, 4) and their pairs (k,)."""
        footprint = pad_footprint(probe, self.footprint_grid, self.pad_compression)
        if footprint is None:
            return None
        quality = self.score(pairs, eps, np.full(len(pairs), self.hold_ref))
        if confidence is not None:
            quality = quality * confidence

        def pose_score(poses: np.ndarray, pair_of: np.ndarray) -> np.ndarray:
            if mesh is None:  # the views' space: the share of each pad over the object, not its pressure
                seat = probe.seat(footprint, poses)
                hold = self.hold(pairs.take(pair_of), center, mass, hand, context, torsion=seat.ratio)
                return np.clip(hold / self.hold_ref, 0.0, 1.0) * quality[pair_of]
            seat = footprint.seat(mesh, poses)
            seated = on_pivot(pairs.take(pair_of), poses, seat.pivot)
            hold = self.hold(seated, center, mass, hand, context, torsion=seat.ratio, tilt=seat.tilt,
                             support=seat.support, across=poses[:, :3, 0])
            return np.clip(hold / self.hold_ref, 0.0, 1.0) * quality[pair_of]

        return pose_score

    # ------------------------------------------------------------ steps
    def pairs(self, mesh: trimesh.Trimesh, hand: Hand, rng: np.random.Generator) -> Pairs:
        """Antipodal pairs of `mesh` (world frame) that fit `hand` (steps 1-3)."""
        half_angle = float(np.arctan(self.contact.mu))
        samples = sample_surface(mesh, self.n_samples, rng)
        normals = SmoothNormals(mesh)
        n_out = normals.at(samples.faces, samples.barycentric)
        rays = cone_rays(-n_out, self.rays_per_sample, self.ray_cone * half_angle, rng).reshape(-1, 3)
        reps = self.rays_per_sample
        widths = (self.min_width, hand.max_width - self.width_margin)
        pairs = find_pairs(mesh, normals, np.repeat(samples.points, reps, axis=0), np.repeat(n_out, reps, axis=0),
                           rays, half_angle, widths, 0.5 * hand.max_width)
        return pairs.take(thin_pairs(pairs, self.pair_cell))

    def score(self, pairs: Pairs, epsilon: np.ndarray, hold: np.ndarray) -> np.ndarray:
        """(m,) the documented score of each pair (module docstring) from its epsilon (m,) and hold margin (m,)."""
        antipodality = np.clip(1.0 - pairs.alpha / np.arctan(self.contact.mu), 0.0, 1.0)
        quality = 0.5 * antipodality + 0.5 * np.clip(epsilon / self.epsilon_ref, 0.0, 1.0)
        return np.clip(hold / self.hold_ref, 0.0, 1.0) * quality

    @staticmethod
    def _contacts(pairs: Pairs) -> tuple[np.ndarray, np.ndarray]:
        """Contact positions (m, 2, 3) and inward normals (m, 2, 3) of the pairs."""
        return np.stack([pairs.p, pairs.q], axis=1), -np.stack([pairs.n_p, pairs.n_q], axis=1)

    def _candidates(self, pairs: Pairs, score: np.ndarray, eps: np.ndarray, poses: np.ndarray,
                    pair_of: np.ndarray, chosen: np.ndarray, center: np.ndarray,
                    scale: float, pregrasp_offset: float) -> list[GraspCandidate]:
        """The chosen poses (indices into `poses`, with their pairs `pair_of` and scores `score`, one per pose)
        as candidates."""
        used = pair_of[chosen]
        unique, inverse = np.unique(used, return_inverse=True)
        positions, normals = self._contacts(pairs.take(unique))
        min_mu = np.full(len(unique), np.nan)
        if self.contact.min_friction and len(unique):
            min_mu = grasp_metrics(positions, normals, center, scale, self.contact).min_friction
        out = []
        for k, i in enumerate(chosen):
            j, u = used[k], inverse[k]
            out.append(GraspCandidate(
                pose=poses[i], score=float(score[i]), width=float(pairs.width[j]), preshape=0.0,
                contacts=positions[u], contact_normals=normals[u], epsilon_l1=float(eps[j]),
                force_closure=bool(eps[j] > EPSILON_TOLERANCE),
                min_friction=None if np.isnan(min_mu[u]) else float(min_mu[u]),
                pregrasp_offset=pregrasp_offset, planner=self.name))
        return out


def _better(packed: np.ndarray, walked: np.ndarray, floor: float, compete: bool) -> bool:
    """Whether a packed set (scores `packed`) replaces the walk's (`walked`): the larger set; of two as large, the
    one with more poses scoring at least `floor`, then (with `compete`) the one whose worst pose scores higher."""
    if len(packed) != len(walked):
        return len(packed) > len(walked)
    good_p, good_w = (packed >= floor).sum(), (walked >= floor).sum()
    if good_p != good_w:
        return bool(good_p > good_w)
    return bool(compete and len(packed) and packed.min() > walked.min())
