"""The grasp phases every protocol is built from: pre-grasp, approach, close, lift, and the final finger check.

Each is a function of a `TrialRun` that runs inside ``with run.phase(Phase.X)``
(which tells the observer, watches the object in the hand and records the
phase passed); it returns when the phase passed and raises `Abort` with the
phase's failure status otherwise. Moving set-points are trajectories
(functions of time) that the run samples at its control rate. Poses are
(4, 4) world matrices [m].
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from manigrasp.control import FingerClose, FingerHold, GripController
from manigrasp.geometry import pregrasp_pose
from manigrasp.protocol.execution import Abort, Trajectory, TrialRun
from manigrasp.protocol.metrics import simulated_metrics
from manigrasp.protocol.result import Phase, Status
from manigrasp.sim import HandContacts, Scene, grip_force, read_hand_contacts

CLOSED_SYNERGY = 0.995  # [-] hand synergy (0 open, 1 closed) past which a position-mode close has finished
# `balanced_torques`: the least normal force of a link, in units of the mean [-], and the largest friction ratio
# of its contacts, as a share of their friction coefficient [-] (a margin below the cone).
BALANCED_FLOOR = 0.3
BALANCED_FRICTION = 0.8

# One `FingerHold` per scene, with the gain it was made for (its model's gains are edited while a dexterous grasp
# is held).
_HOLDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def finger_hold(run: TrialRun, gain: float) -> FingerHold:
    """The scene's `FingerHold` of `gain` (made on first use, from the model's own gains, with the finger of each
    actuator, `Scene.actuator_fingers`)."""
    scene = run.scene
    if scene not in _HOLDS or _HOLDS[scene][0] != gain:
        release_hold(run)
        _HOLDS[scene] = (gain, FingerHold(scene.model, scene.hand_actuators, gain, scene.actuator_fingers))
    return _HOLDS[scene][1]


def joint_held_fingers(scene: Scene, contacts: HandContacts, mode: str) -> tuple[int, ...]:
    """The fingers `FingerHold.engage` holds in their joint configuration under the protocols' `finger_hold`
    `mode`: none ("floor"), all ("joints"), or ("fingertips", "balanced") in a grasp the palm does not touch (a
    precision grasp; one pressed into the palm is a power grasp: none), the fingers that touch the object with
    their distal phalanx only (`Scene.distal_body`) or not at all (a finger that also touches with an inner link
    wraps it).
    Any contact of a hand body outside the fingers (`finger` -1: the palm, or a link `Hand.finger_bodies` does
    not reach) counts as the palm's."""
    every = range(len(scene.hand.finger_bodies))
    if mode == "floor" or (mode in ("fingertips", "balanced") and np.any(contacts.finger < 0)):
        return ()
    if mode == "joints":
        return tuple(every)
    wrapping = set(contacts.finger[(contacts.finger >= 0) & ~scene.distal_body[contacts.hand_body]].tolist())
    return tuple(f for f in every if f not in wrapping)


def balanced_torques(scene: Scene, contacts: HandContacts, held: tuple[int, ...], closing: np.ndarray
                     ) -> np.ndarray | None:
    """(n_act,) the force [N m] each hand actuator should press with so that a fully actuated hand's precision grasp
    holds the object with the least friction (`finger_hold: balanced`, the default; why and what it gave:
    `control.hold`), NaN for the actuators left as they are; None where it does not apply or no such forces exist
    (then the grasp is held as under "fingertips").

    It applies when every finger touching the object is held in its joint configuration (`held`) and has several
    joint servos that close (`closing` != 0): the Allegro's fingertip grasps (a five-finger hand's tendon finger
    has one). The contacts are lumped per hand link (normal-force weighted point, summed normal); the forces are
    `grasp.forces.balanced_forces` with the object's weight as the load (what the lift will ask of them), each
    link pressing at least `BALANCED_FLOOR` of the mean and none past `BALANCED_FRICTION` of its own contacts'
    friction (then, if no forces meet that, past the friction itself: never outside a cone), at the normal force
    the close reached (the grip the protocol regulated). The torques are sum_i J_i^T f_i over the links'
    Jacobians at their points, given to every joint servo (closing, spread and rotation) of those fingers; where a
    servo's share would pass its force range, the forces are solved again at a total normal force that much
    smaller (the weight then a larger share of it), and if a servo is still past its range, None.
    """
    import mujoco

    m = scene.model
    fingers, actuators = scene.actuator_fingers, scene.hand_actuators
    joint = np.isin(m.actuator_trntype[actuators], (mujoco.mjtTrn.mjTRN_JOINT, mujoco.mjtTrn.mjTRN_JOINTINPARENT))
    closes = joint & (np.asarray(closing) != 0)
    several = {f for f in held if np.sum(closes & (fingers == f)) > 1}
    if len(contacts) < 2 or np.any(contacts.finger < 0) or not set(contacts.finger.tolist()) <= several:
        return None
    links = np.unique(contacts.hand_body)
    on = [contacts.hand_body == b for b in links]  # each link's contacts
    pressed = np.maximum(contacts.normal_force, 1e-9)
    points = np.array([np.average(contacts.position[k], axis=0, weights=pressed[k]) for k in on])
    normals = np.array([np.sum(contacts.normal[k] * pressed[k, None], axis=0) for k in on])
    # A link pressing from opposite sides of itself has no net normal: no contact of its own to balance.
    if len(links) < 2 or not np.all(np.linalg.norm(normals, axis=1) > 1e-9 * float(pressed.sum())):
        return None
    mu = np.array([contacts.friction[k].min() for k in on])
    used = joint & np.isin(fingers, list(several))
    acts = actuators[used]
    dofs, gear = m.jnt_dofadr[m.actuator_trnid[acts, 0]], m.actuator_gear[acts, 0]
    low, high = m.actuator_forcerange[acts].T
    limited = m.actuator_forcelimited[acts].astype(bool)
    low, high = np.where(limited, low, -np.inf), np.where(limited, high, np.inf)
    total = float(np.sum(np.clip(contacts.normal_force, 0.0, None)))
    for _ in range(2):
        torques = _link_torques(scene, links, points, normals, mu, total)
        if torques is None:
            return None
        share = torques[dofs] / gear
        out = np.full(len(actuators), np.nan)
        out[used] = share
        with np.errstate(divide="ignore", invalid="ignore"):
            over = float(np.max(np.where(share > 0, share / high, np.where(share < 0, share / low, 0.0)),
                                initial=0.0))
        if over <= 1.0 + 1e-9:
            return out
        total /= over
    return None


def _link_torques(scene: Scene, links: np.ndarray, points: np.ndarray, normals: np.ndarray, mu: np.ndarray,
                  total: float) -> np.ndarray | None:
    """`balanced_torques`' joint torques (nv,) [N m]: the least-friction forces holding the object's weight at the
    lumped contacts, pressing `total` [N] of normal force in all; None if no forces inside the friction cones."""
    import mujoco

    from manigrasp.grasp.forces import balanced_forces

    m, data = scene.model, scene.data
    mean = total / len(links)
    if not mean > 0:
        return None
    weight = m.opt.gravity * float(m.body_subtreemass[scene.object_body]) / mean  # the load: m g, downward
    center = data.xipos[scene.object_body]
    forces = None
    for bound in (BALANCED_FRICTION * mu, mu):
        forces = balanced_forces(points, normals, center, BALANCED_FLOOR, weight, bound)
        if forces is not None:
            break
    if forces is None:
        return None
    torque = np.zeros(m.nv)
    jacp = np.zeros((3, m.nv))
    for body, point, force in zip(links, points, mean * forces, strict=True):
        mujoco.mj_jac(m, data, jacp, None, point, int(body))
        torque += jacp.T @ force
    return torque


def release_hold(run: TrialRun) -> None:
    """Give the hand its closing gains back if a previous close stiffened them (dexterous hands only)."""
    if run.scene in _HOLDS:
        _HOLDS[run.scene][1].release()


def reset(run: TrialRun, mount: np.ndarray, object_pose: np.ndarray, preshape: float) -> None:
    """`TrialRun.reset` with the hand's closing gains given back first (`release_hold`): the reset sets the hand
    path, whose servo leads (`Scene.closing_reach`) are read from the gains, and a held grasp's are stiffer (a
    close after a reset with the hold still engaged crept and timed out short of the object)."""
    release_hold(run)
    run.reset(mount, object_pose, preshape)


def place_pregrasp(run: TrialRun, pose: np.ndarray, object_pose: np.ndarray, preshape: float) -> np.ndarray:
    """Reset with the open hand at the pre-grasp pose of `pose`; any hand contact: `pregrasp_collision`."""
    start = pregrasp_pose(pose, run.pregrasp_offset)
    with run.phase(Phase.PREGRASP):
        reset(run, start, object_pose, preshape)
        touching = read_hand_contacts(run.scene, "any")
        if len(touching):
            other = "the object" if np.isin(touching.other_geom, run.scene.object_geoms).any() else "the table"
            raise Abort(Status.PREGRASP_COLLISION, f"the open hand at the pre-grasp pose touches {other}")
        run.hold_target(start)
    return start


def ramp(start: np.ndarray, delta: np.ndarray, duration: float) -> Trajectory:
    """Trajectory moving the TCP from pose `start` (4, 4) by `delta` (3,) [m] at constant speed in
    `duration` [s], then holding (orientation unchanged)."""
    velocity = np.concatenate([delta / duration, np.zeros(3)])
    still = np.zeros(6)

    def trajectory(t: float) -> tuple[np.ndarray, np.ndarray]:
        pose = start.copy()
        pose[:3, 3] += min(1.0, t / duration) * delta
        return pose, (velocity if t < duration else still)

    return trajectory


def approach(run: TrialRun, start: np.ndarray, goal: np.ndarray) -> None:
    """Move the impedance set-point in a straight line from `start` to `goal`, then settle there.

    A hand that ends over `APPROACH_SHORTFALL` from `goal` (it ran into the table or the object on the way in)
    leaves a note in `run.approach_note`, which a failed trial's detail ends with (`trial.execute`): the hand
    closed where it stopped, not where the grasp is."""
    with run.phase(Phase.APPROACH):
        delta = goal[:3, 3] - start[:3, 3]
        n = max(1, run.n_steps(float(np.linalg.norm(delta)) / run.params.approach_speed))
        run.step(n, ramp(start, delta, n * run.dt))
        run.hold_target(goal)
        run.hold_for(run.params.approach_settle_s)
        run.approach_note = approach_shortfall(run.scene, goal)


APPROACH_SHORTFALL = 0.005
"""[m] how far from the grasp pose the TCP may end the approach before a `no_contact` says where it stopped
(the impedance-controlled hand ends within a millimetre of it in free air)."""


def approach_shortfall(scene: Scene, goal: np.ndarray) -> str:
    """"the hand stopped N mm short of the grasp pose, against the table" (or the object, or the table and the
    object), or "" where the TCP is within `APPROACH_SHORTFALL` of `goal`."""
    short = float(np.linalg.norm(scene.tcp_pose()[:3, 3] - goal[:3, 3]))
    if short <= APPROACH_SHORTFALL:
        return ""
    touching = read_hand_contacts(scene, "any")
    on_object = np.isin(touching.other_geom, scene.object_geoms)
    against = [name for name, hit in (("the table", (~on_object).any()), ("the object", on_object.any())) if hit]
    where = f", against {' and '.join(against)}" if against else ""
    return f"the hand stopped {short * 1e3:.0f} mm short of the grasp pose{where}"


def close(run: TrialRun, preshape: float, metrics: bool = True, detail: str = "") -> None:
    """Close to the grip force (position until contact, then force); no contact at the end: `no_contact`
    (its detail says whether the hand never touched the object or gripped it and squeezed it out).

    The grip loop (`GripController`) runs at the control rate while closing; afterwards
    the finger command stays where it left it (unless `regulate_grip_after_close`), so
    the finger servos hold the grip with no Python in the loop; with `finger_hold_gain`, a
    dexterous hand's servos that close along its path are then held around the forces they
    reached (`FingerHold`: stiff against opening, and still pushing where the object yields; a finger with
    several closing joints that touches with its distal phalanx only, or not at all, in a grasp the palm does
    not touch, has its joint configuration held instead, `finger_hold`); the
    next pre-grasp or close, and the end of the trial (`trial.execute`), give the gains back. The object's pose in the
    hand is the reference of all later motion, and (with `metrics`) the grip force and
    simulated-contact metrics are recorded. `detail` goes to the observer's phase call.
    """
    with run.phase(Phase.CLOSE, detail):
        _close(run, preshape, metrics)


def _close(run: TrialRun, preshape: float, metrics: bool) -> None:
    """The close phase's work (`close`)."""
    p, hand = run.params, run.scene.hand
    target = p.grip_force if p.grip_force is not None else p.grip_force_fraction * hand.max_grip_force
    target = min(target, hand.max_grip_force)
    if p.close_mode == "per_finger" and hand.kind == "dexterous":
        scene = run.scene
        open_ctrl, closed_ctrl = scene.hand_path
        grip = FingerClose(open_ctrl, closed_ctrl, scene.actuator_fingers, scene.actuator_leads(),
                           len(hand.finger_bodies), target, hand.max_grip_force, close_speed=p.close_speed,
                           contact_force=p.contact_force)
    else:
        grip = GripController(target, hand.max_grip_force, close_speed=p.close_speed,
                              contact_force=p.contact_force, stiffness=hand.grip_stiffness,
                              stall_check=hand.grip_stiffness is not None or hand.kind == "parallel")
    grip.reset(preshape)
    release_hold(run)
    run.grip = grip
    chunk, elapsed, touched_at = run.chunk, 0, None
    limit = run.n_steps(p.close_timeout_s)
    while elapsed < limit:
        run.step(chunk)
        elapsed += chunk
        if grip.mode != "force":  # (again: a contact lost on the way in, `GripController.update`)
            touched_at = None
        elif touched_at is None:
            touched_at = elapsed
        if touched_at is not None and elapsed - touched_at >= run.n_steps(p.close_settle_s):
            break
        if grip.mode == "position" and (grip.stalled or (isinstance(grip, GripController)
                                                        and run.scene.hand_synergy() > CLOSED_SYNERGY)):
            break
    if not p.regulate_grip_after_close:
        run.grip = None
    contacts = read_hand_contacts(run.scene)
    if grip.mode == "position" or len(contacts.fingers_touching) == 0:
        if grip.mode == "force" and grip.peak_force > 0.0:  # it gripped, then lost the object on the way
            # The peak is of the instantaneous contact force: an impact can drive it past the hand's own force.
            impact = (f", above the hand's {hand.max_grip_force:.0f} N: an impact's instantaneous contact force"
                      if grip.peak_force > hand.max_grip_force else "")
            raise Abort(Status.NO_CONTACT, f"the object left the grip while closing (squeezed out; the grip force "
                                           f"peaked at {grip.peak_force:.1f} N{impact})")
        raise Abort(Status.NO_CONTACT, "the hand closed without touching the object")
    if hand.kind == "dexterous" and run.grip is None and p.finger_hold_gain > 0:
        closing = np.diff(run.scene.hand_path, axis=0)[0]
        held = joint_held_fingers(run.scene, contacts, p.finger_hold)
        pressed = balanced_torques(run.scene, contacts, held, closing) if p.finger_hold == "balanced" else None
        finger_hold(run, p.finger_hold_gain).engage(run.scene.data, closing, held, pressed)
    if metrics:
        run.grip_force_n = grip_force(contacts)
        run.simulated = simulated_metrics(run.scene, run.torque_scale, p.metric_edges, p.metric_friction_tol,
                                          p.simulated_min_friction)
    run.in_hand = run.object_in_hand()
    if math.isnan(run.max_translation):  # kept over several closings (six_direction)
        run.max_translation, run.max_rotation = 0.0, 0.0


def lift(run: TrialRun, height: float, speed: float, hold_s: float) -> None:
    """Raise the set-point `height` [m] at `speed` [m/s], hold `hold_s` [s]; slipping: `slipped_lift`.

    The object's weight is fed forward from the start of the lift (`payload_feedforward`). The
    object's motion in the hand is watched from its pose there after closing (`TrialRun.in_hand`);
    the hold at the top is a phase of its own inside the lift.
    """
    scene = run.scene
    with run.phase(Phase.LIFT, watch=Status.SLIPPED_LIFT, reference=run.in_hand):
        start_tcp, start_z = scene.tcp_pose(), float(scene.object_pose()[2, 3])
        start_tcp[:3, :3] = run.impedance.target[:3, :3]
        n = max(1, run.n_steps(height / speed))
        run.hold_target(start_tcp, run.payload())
        run.step(n, ramp(start_tcp, np.array([0.0, 0.0, height]), n * run.dt))
        end = start_tcp.copy()
        end[2, 3] += height
        run.hold_target(end)
        with run.phase(Phase.HOLD):
            run.hold_for(hold_s)
        risen = float(scene.object_pose()[2, 3]) - start_z
        if risen < height - run.params.translation_threshold:
            raise Abort(Status.SLIPPED_LIFT,
                        f"object left behind: it rose {100 * risen:.1f} cm of {100 * height:.0f}")


def require_fingers(run: TrialRun, status: Status, where: str = "") -> tuple[str, ...]:
    """The fingers touching the object; fewer than `min_fingers`: abort with `status` (its detail led by `where`,
    e.g. the perturbation's direction, if given)."""
    fingers = run.fingers_touching()
    if len(fingers) < run.params.min_fingers:
        raise Abort(status, f"{f'{where}: ' if where else ''}only {len(fingers)} finger(s) touch the object at the "
                            f"end (need {run.params.min_fingers})")
    return fingers
