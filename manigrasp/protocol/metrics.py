"""Analytic grasp quality of the planned contacts and of the contacts the simulation produced.

Both are computed about the object's centre of mass, with torques divided by
the object's radius of gyration sqrt(trace(I) / 2m) [m] unless a
`torque_scale` is given, and with unit total normal force (epsilon L1).
The simulated contacts carry the friction, torsion and condim MuJoCo gave
each (MuJoCo condim 1: frictionless, 3: hard finger, 4/6: soft finger).
Planned contacts are where the grasping surfaces are meant to touch, so they
are modelled as those surfaces touch in the scene (`grasping_contact`): the
compliant pads' elements (rubber, `pad_friction` 1.0, each with its cell's
torsion) or rubber fingertips, as compiled; the rigid pads or, for a hand with
neither, the hand geoms (`hand_friction`, `hand_torsional_friction`,
`hand_condim`). Before, planned contacts were always judged at the hand
geoms' 0.5 while the pads touched at 1.0. A planner that knows which surface
each contact lies on says so (`GraspCandidate.contact_friction`: the power
planner gives each contact its touching geom's friction, so a contact on a
phalanx or the palm is judged at the hand geoms' 0.5); the other planners'
contacts are on the pads or fingertips. NaN means "not computed" (no
planned contacts, the metric is undefined for these contacts, or the hull
could not be built), never a score; no contact at all is a computed "no
closure" (0).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from manigrasp.contact import Contact, ContactError, ContactSet, ContactType
from manigrasp.grasp import (
    GraspError,
    ferrari_canny,
    ferrari_canny_batch,
    min_friction_for_closure,
    min_friction_for_closure_batch,
)
from manigrasp.grasp.closure import EPSILON_TOLERANCE
from manigrasp.hands.pads import ELEMENT_PREFIX
from manigrasp.protocol.result import GraspMetrics
from manigrasp.sim import Scene, read_hand_contacts, to_contacts
from manigrasp.sim.compose import HAND_PREFIX


def radius_of_gyration(scene: Scene) -> float:
    """The object's radius of gyration sqrt(trace(I) / 2m) [m]: its RMS distance from the centre of mass."""
    mass = scene.object_mass()
    inertia = scene.model.body_inertia[scene.object_body]
    return float(np.sqrt(np.sum(inertia) / (2.0 * mass))) if mass > 0 else 1.0


def contact_metrics(contacts: Sequence[Contact], center: np.ndarray, torque_scale: float, edges: int = 8,
                    friction_tol: float = 0.01, min_friction: bool = True) -> GraspMetrics:
    """Force closure, Ferrari-Canny epsilon (L1) and the smallest friction for closure of `contacts`.

    Force closure is "epsilon > `EPSILON_TOLERANCE`" (the origin strictly inside the wrench hull), the
    same definition as `planned_metrics_batch` uses, so planned and simulated contacts are judged alike.

    Args:
        contacts: the contacts (normals into the object).
        center: (3,) point torques are taken about (the object's centre of mass) [m].
        torque_scale: characteristic length dividing torques [m].
        edges: edges of the linearised friction cones.
        friction_tol: tolerance of the smallest-friction bisection [-].
        min_friction: compute the smallest friction for closure (else NaN).
    """
    n = len(contacts)
    if n == 0:
        return GraspMetrics(n_contacts=0, force_closure=0.0, epsilon_l1=0.0, min_friction=math.inf)
    try:
        epsilon = ferrari_canny(contacts, center, torque_scale, norm="L1", m=edges)
        mu_min = min_friction_for_closure(contacts, center, torque_scale, tol=friction_tol, m=edges) \
            if min_friction and contacts[0].kind is not ContactType.FRICTIONLESS else math.nan
    except (GraspError, ContactError, ValueError) as exc:  # degenerate input: not computed, recorded as NaN
        del exc
        return GraspMetrics(n_contacts=n)
    closure, epsilon = closure_and_epsilon(epsilon)
    return GraspMetrics(n_contacts=n, force_closure=closure, epsilon_l1=epsilon, min_friction=float(mu_min))


def closure_and_epsilon(epsilon: float) -> tuple[float, float]:
    """(force closure 1.0 / 0.0, epsilon or 0) from an L1 epsilon; (NaN, NaN) when it was not computed.

    Closure is "epsilon > `EPSILON_TOLERANCE`", the batched test's definition and the planners' (the LP test
    `manigrasp.grasp.force_closure` asks a margin above `manigrasp.grasp.closure.MARGIN_TOLERANCE`, 1e-6,
    instead: the two differ only for grasps within about 1e-6 of losing closure), so the stored closure and
    epsilon always agree; a NaN epsilon (Qhull could not build the hull) stays "not
    computed" rather than becoming "no closure".
    """
    if math.isnan(epsilon):
        return math.nan, math.nan
    closed = epsilon > EPSILON_TOLERANCE
    return float(closed), float(epsilon) if closed else 0.0


def _contact_type(condim: int) -> ContactType:
    if condim == 1:
        return ContactType.FRICTIONLESS
    return ContactType.HARD_FINGER if condim == 3 else ContactType.SOFT_FINGER


def grasping_contact(scene: Scene) -> tuple[float, ContactType, float]:
    """(friction mu [-], contact type, torsional friction gamma [m]; 0 unless a soft finger) of the hand's grasping
    surfaces as `scene` compiled them: the colliding geoms among the pads' compliant elements, the pad geoms and the
    fingertip geoms (`Hand.pad_geoms`, `Hand.fingertip_geoms`), the least mu and gamma among them (they share one
    model); a hand with none of them, the scene config's hand model."""
    model, hand = scene.model, scene.hand
    named = {HAND_PREFIX + name for name in (*hand.pad_geoms, *hand.fingertip_geoms)}
    element = HAND_PREFIX + ELEMENT_PREFIX
    surfaces = [g for g in np.flatnonzero(scene.geom_is_hand)
                if (model.geom_contype[g] or model.geom_conaffinity[g])
                and ((name := model.geom(g).name) in named or name.startswith(element))]
    if surfaces:
        mu, condim = float(model.geom_friction[surfaces, 0].min()), int(model.geom_condim[surfaces[0]])
        gamma = float(model.geom_friction[surfaces, 1].min())
    else:
        cfg = scene.config
        mu, condim, gamma = float(cfg.hand_friction), int(cfg.hand_condim), float(cfg.hand_torsional_friction)
    kind = _contact_type(condim)
    return mu, kind, gamma if kind is ContactType.SOFT_FINGER else 0.0


def contact_frictions(surfaces: tuple[float, ContactType, float], k: int, given: np.ndarray | None = None
                      ) -> tuple[np.ndarray, ContactType, np.ndarray]:
    """(mu (k,), contact type, gamma (k,) [m]) of `k` planned contacts: `given` (k, 2) sliding and torsional
    friction where the planner knows the surface each lies on (`GraspCandidate.contact_friction`), else the
    grasping `surfaces`' (`grasping_contact` of the scene); gamma 0 unless the contacts are soft fingers."""
    mu, kind, gamma = surfaces
    if given is None:
        return np.full(k, mu), kind, np.full(k, gamma)
    given = np.asarray(given, float).reshape(k, 2)
    return given[:, 0].copy(), kind, given[:, 1].copy() if kind is ContactType.SOFT_FINGER else np.zeros(k)


def planned_metrics(scene: Scene, points: np.ndarray, normals: np.ndarray, center: np.ndarray,
                    torque_scale: float, edges: int = 8, friction_tol: float = 0.01,
                    friction: np.ndarray | None = None) -> GraspMetrics:
    """Metrics of planned contacts `points`, `normals` (k, 3) with the friction `friction` (k, 2) of the surface
    each lies on, or None: the model of the hand's grasping surfaces (`contact_frictions`).

    Returns all-NaN metrics when there are no planned contacts or they are not finite.
    """
    points, normals = np.asarray(points, float).reshape(-1, 3), np.asarray(normals, float).reshape(-1, 3)
    if len(points) == 0 or len(points) != len(normals) or not (np.isfinite(points).all()
                                                               and np.isfinite(normals).all()):
        return GraspMetrics()
    mu, kind, gamma = contact_frictions(grasping_contact(scene), len(points), friction)
    norms = np.linalg.norm(normals, axis=1, keepdims=True)
    if np.any(norms < 1e-9):
        return GraspMetrics(n_contacts=len(points))
    contacts = [Contact(position=p, normal=nrm, mu=m, kind=kind, gamma=g)
                for p, nrm, m, g in zip(points, normals / norms, mu, gamma, strict=True)]
    return contact_metrics(contacts, center, torque_scale, edges, friction_tol)


def simulated_metrics(scene: Scene, torque_scale: float, edges: int = 8, friction_tol: float = 0.01,
                      min_friction: bool = False) -> GraspMetrics:
    """Metrics of the hand-object contacts in the scene's current state, about the object's centre of mass."""
    contacts = to_contacts(read_hand_contacts(scene, "object"))
    return contact_metrics(contacts, scene.data.xipos[scene.object_body].copy(), torque_scale, edges,
                           friction_tol, min_friction)


def planned_metrics_batch(scene: Scene, grasps: Sequence[tuple], object_pose: np.ndarray,
                          torque_scale: float | None = None, edges: int = 8,
                          friction_tol: float = 0.01) -> list[GraspMetrics]:
    """`planned_metrics` of many grasps at once (the harness computes them once per planning call).

    Grasps with the same number of contacts are scored together with the batched metrics of
    `manigrasp.grasp` (force closure as epsilon > tolerance, the batched equivalent of the LP test).

    Args:
        scene: the scene whose grasping surfaces' contact model (`grasping_contact`) is used.
        grasps: per grasp, (points (k, 3), inward normals (k, 3)) in the world [m], and optionally the friction
            (k, 2) of the surface each contact lies on (None: the grasping surfaces', `contact_frictions`).
        object_pose: (4, 4) settled object pose; torques are about its centre of mass.
        torque_scale: characteristic length [m] (default: the object's radius of gyration).
    """
    center = (np.asarray(object_pose, float) @ np.append(scene.model.body_ipos[scene.object_body], 1.0))[:3]
    scale = torque_scale or radius_of_gyration(scene)
    out: list[GraspMetrics] = [GraspMetrics() for _ in grasps]
    groups: dict[int, list[int]] = {}
    for i, (points, normals, *_) in enumerate(grasps):
        points, normals = np.asarray(points, float).reshape(-1, 3), np.asarray(normals, float).reshape(-1, 3)
        if len(points) and points.shape == normals.shape and np.isfinite(points).all() and \
                np.isfinite(normals).all() and (np.linalg.norm(normals, axis=1) > 1e-9).all():
            groups.setdefault(len(points), []).append(i)
    for members in groups.values():
        metrics = _batch(scene, [grasps[i] for i in members], center, scale, edges, friction_tol)
        for i, m in zip(members, metrics, strict=True):
            out[i] = m
    return out


def _batch(scene: Scene, grasps: list[tuple], center: np.ndarray, scale: float,
           edges: int, friction_tol: float) -> list[GraspMetrics]:
    points = np.stack([np.asarray(g[0], float).reshape(-1, 3) for g in grasps])
    normals = np.stack([np.asarray(g[1], float).reshape(-1, 3) for g in grasps])
    normals = normals / np.linalg.norm(normals, axis=2, keepdims=True)
    k, surfaces = points.shape[1], grasping_contact(scene)  # read from the compiled scene once per batch
    per_grasp = [contact_frictions(surfaces, k, g[2] if len(g) > 2 else None) for g in grasps]
    kind = per_grasp[0][1]
    mu, gamma = np.stack([f[0] for f in per_grasp]), np.stack([f[2] for f in per_grasp])
    try:
        contacts = ContactSet(points, normals, mu, kind, gamma if kind is ContactType.SOFT_FINGER else None)
        epsilon = ferrari_canny_batch(contacts, center, scale, "L1", edges)
        mu_min = (min_friction_for_closure_batch(contacts, center, scale, tol=friction_tol, m=edges)
                  if kind is not ContactType.FRICTIONLESS else np.full(len(grasps), math.nan))
    except (GraspError, ContactError, ValueError):  # degenerate input: not computed, recorded as NaN
        return [GraspMetrics(n_contacts=points.shape[1]) for _ in grasps]
    out = []
    for e, m in zip(epsilon, mu_min, strict=True):
        closure, eps = closure_and_epsilon(float(e))
        out.append(GraspMetrics(n_contacts=points.shape[1], force_closure=closure, epsilon_l1=eps,
                                min_friction=float(m)))
    return out
