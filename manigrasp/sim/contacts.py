"""Hand contacts read from MuJoCo: where, which way, how hard, which finger, inside the cone or not.

Sign conventions (all world frame): `normal` points from the hand into the
other geom, and `force` is the force the hand exerts ON the other geom (the
object or table), so for a squeezing grasp `force . normal > 0`. Forces are
what `mj_contactForce` gives (contact frame: normal, tangent1, tangent2, then
torsional / rolling torques), decoded from `data.efc_force` for all contacts
at once (`contact_forces`), and rotated into the world frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import mujoco
import numpy as np

if TYPE_CHECKING:
    from manigrasp.sim.scene import Scene

Other = Literal["object", "table", "any"]
_SIX, _TEN = np.arange(6), np.arange(10)


@dataclass(frozen=True)
class HandContacts:
    """n contacts between the hand and something else, as arrays.

    Attributes:
        position: (n, 3) contact points [m].
        normal: (n, 3) unit normals, from the hand into the other geom.
        force: (n, 3) force of the hand on the other geom [N].
        torque: (n, 3) torsional (and rolling) torque of the hand on the other geom [N m].
        normal_force: (n,) force along `normal` [N] (>= 0 for a pushing contact).
        tangential_force: (n,) magnitude of the tangential force [N].
        friction: (n,) sliding friction coefficient of each contact [-].
        torsional_friction: (n,) torsional coefficient of each contact [m] (used if condim >= 4).
        cone_ratio: (n,) elliptic cone usage: sqrt(sum (f_t,i / mu_i)^2) / f_n over
            the contact's frictional components; 1 means on the cone (sliding).
        in_cone: (n,) True where f_n > 0 and cone_ratio <= 1 + tolerance.
        finger: (n,) index into `hand.finger_bodies` of the touching finger, -1 for the palm.
        hand_body: (n,) body id on the hand side.
        hand_geom: (n,) geom id on the hand side.
        other_geom: (n,) geom id on the other side.
        condim: (n,) contact dimensionality.
    """

    position: np.ndarray
    normal: np.ndarray
    force: np.ndarray
    torque: np.ndarray
    normal_force: np.ndarray
    tangential_force: np.ndarray
    friction: np.ndarray
    torsional_friction: np.ndarray
    cone_ratio: np.ndarray
    in_cone: np.ndarray
    finger: np.ndarray
    hand_body: np.ndarray
    hand_geom: np.ndarray
    other_geom: np.ndarray
    condim: np.ndarray

    def __len__(self) -> int:
        return len(self.normal_force)

    @property
    def fingers_touching(self) -> tuple[int, ...]:
        """Distinct finger indices with a pushing contact (for the two-finger success rule)."""
        return tuple(sorted({int(f) for f, fn in zip(self.finger, self.normal_force, strict=True)
                             if f >= 0 and fn > 0}))


def _other_mask(scene: Scene, geoms: np.ndarray, other: Other) -> np.ndarray:
    if other == "object":
        return scene.geom_is_object[geoms]
    if other == "table":
        return geoms == scene.table_geom
    if other == "any":
        return np.ones(len(geoms), bool)
    raise ValueError(f"other must be 'object', 'table' or 'any', got {other!r}")


def _select(scene: Scene, other: Other) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices of active hand-`other` contacts, whether the hand is geom1 there, and their geoms (n, 2)."""
    con = scene.data.contact
    if scene.data.ncon == 0:
        return np.zeros(0, int), np.zeros(0, bool), np.zeros((0, 2), int)
    geom = con.geom
    is_hand = scene.geom_is_hand[geom]
    hand_first = is_hand[:, 0] & ~is_hand[:, 1]
    hand_second = is_hand[:, 1] & ~is_hand[:, 0]
    other_geom = np.where(hand_first, geom[:, 1], geom[:, 0])
    keep = (hand_first | hand_second) & _other_mask(scene, other_geom, other) & (con.efc_address >= 0)
    idx = np.flatnonzero(keep)
    return idx, hand_first[idx], geom[idx]


def contact_forces(model: mujoco.MjModel, data: mujoco.MjData, idx: np.ndarray) -> np.ndarray:
    """(n, 6) forces of contacts `idx` in their contact frames, as `mj_contactForce` gives them, at once.

    Read from `data.efc_force`: an elliptic (or frictionless) contact's rows are
    its normal force, then its frictional components; a pyramidal contact's
    2 (dim - 1) edge forces are decoded as MuJoCo's `mju_decodePyramid` does
    (normal = their sum, tangential j = (f_2j - f_2j+1) mu_j). Contacts without
    constraint rows (efc_address < 0) get zeros.
    """
    idx = np.asarray(idx, int)
    if len(idx) == 0:
        return np.zeros((0, 6))
    con, force = data.contact, data.efc_force
    adr, dim = con.efc_address[idx], con.dim[idx]
    live = adr >= 0
    if model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC:
        valid = live[:, None] & (_SIX[None, :] < dim[:, None])
        return np.where(valid, force[np.where(valid, adr[:, None] + _SIX[None, :], 0)], 0.0)
    edges = live[:, None] & (_TEN[None, :] < 2 * (dim[:, None] - 1))
    pyramid = np.where(edges, force[np.where(edges, adr[:, None] + _TEN[None, :], 0)], 0.0)  # (n, 10)
    out = np.zeros((len(idx), 6))
    out[:, 0] = np.where(dim == 1, np.where(live, force[np.where(live, adr, 0)], 0.0), pyramid.sum(axis=1))
    out[:, 1:] = (pyramid[:, 0::2] - pyramid[:, 1::2]) * con.friction[idx]
    return out


def read_hand_contacts(scene: Scene, other: Other = "object", cone_tolerance: float = 1e-3) -> HandContacts:
    """Active contacts between the hand and `other` ("object", "table" or "any") in the current state.

    Valid after `mj_step` or `mj_forward`. `cone_tolerance` is the relative slack
    of the friction-cone test (MuJoCo's soft contacts sit on the cone when sliding).
    Vectorised over contacts (`contact_forces`); no Python loop per contact.
    """
    model, data = scene.model, scene.data
    idx, hand_first, geoms = _select(scene, other)
    n = len(idx)
    local = contact_forces(model, data, idx)
    con = data.contact
    frames = con.frame[idx].reshape(n, 3, 3)  # rows: normal (geom1 -> geom2), tangent1, tangent2
    # The contact-frame force is the force of geom1 on geom2.
    sign = np.where(hand_first, 1.0, -1.0)[:, None]
    force = sign * np.einsum("nij,ni->nj", frames, local[:, :3])
    torque = sign * np.einsum("nij,ni->nj", frames, local[:, 3:])
    normal = sign * frames[:, 0, :]
    hand_geom = np.where(hand_first, geoms[:, 0], geoms[:, 1])
    dim = con.dim[idx]
    mu = con.friction[idx]  # (n, 5): tangent1, tangent2, spin, roll1, roll2
    ratio = _cone_ratio(local, mu, dim)
    fn = local[:, 0]
    return HandContacts(
        position=con.pos[idx].copy(), normal=normal, force=force, torque=torque, normal_force=fn,
        tangential_force=np.linalg.norm(local[:, 1:3], axis=1), friction=mu[:, 0].copy(),
        torsional_friction=mu[:, 2].copy(), cone_ratio=ratio,
        in_cone=(fn > 0) & (ratio <= 1.0 + cone_tolerance), finger=scene.geom_finger[hand_geom],
        hand_body=model.geom_bodyid[hand_geom], hand_geom=hand_geom,
        other_geom=np.where(hand_first, geoms[:, 1], geoms[:, 0]), condim=dim.copy())


def current_grip_force(scene: Scene) -> float:
    """`grip_force(read_hand_contacts(scene))` [N] without building the full record (the grip loop's read-out).

    Only the normal forces of the hand-object contacts and their fingers are read.
    """
    idx, hand_first, geoms = _select(scene, "object")
    if len(idx) == 0:
        return 0.0
    fn = np.clip(contact_forces(scene.model, scene.data, idx)[:, 0], 0.0, None)
    first = scene.geom_finger[np.where(hand_first, geoms[:, 0], geoms[:, 1])] == 0
    return float(min(fn[first].sum(), fn[~first].sum()))


def _cone_ratio(local: np.ndarray, mu: np.ndarray, dim: np.ndarray) -> np.ndarray:
    """Elliptic-cone usage of each contact: ||f_friction / mu|| / f_n (0 for frictionless)."""
    n_fric = np.clip(dim - 1, 0, 5)
    comp = np.arange(5)[None, :] < n_fric[:, None]
    scaled = np.where(comp, local[:, 1:6] / np.where(mu > 0, mu, np.inf), 0.0)
    norm = np.linalg.norm(scaled, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(local[:, 0] > 0, norm / local[:, 0], np.where(norm > 0, np.inf, 0.0))


def to_contacts(contacts: HandContacts) -> list:
    """The contacts as `manigrasp.contact.Contact` records, for the grasp metrics.

    The model follows MuJoCo's condim: 1 frictionless, 3 hard finger, 4 or 6
    soft finger (torsional coefficient from the contact); normals already point
    into the object. Contacts with f_n <= 0 are dropped (not touching).
    """
    from manigrasp.contact import Contact, ContactType

    out = []
    for i in np.flatnonzero(contacts.normal_force > 0):
        dim = int(contacts.condim[i])
        kind = ContactType.FRICTIONLESS if dim == 1 else (ContactType.HARD_FINGER if dim == 3
                                                           else ContactType.SOFT_FINGER)
        gamma = float(contacts.torsional_friction[i]) if kind is ContactType.SOFT_FINGER else 0.0
        out.append(Contact(position=contacts.position[i], normal=contacts.normal[i],
                           mu=float(contacts.friction[i]), kind=kind, gamma=gamma))
    return out


def grip_force(contacts: HandContacts) -> float:
    """Grip force [N]: the squeeze between the hand's first finger and the rest of the hand.

    The first entry of `Hand.finger_bodies` is the opposing digit: jaw 1 of a
    parallel jaw (the closing axis y runs from it toward jaw 2), the thumb of
    a dexterous hand. The grip force is the smaller of

    - the total normal force [N] of the first finger's contacts, and
    - the total normal force [N] of every other hand contact (other fingers, palm),

    i.e. the force with which the two sides of the grasp press the object
    between them: for a parallel jaw the squeeze of one jaw, for a dexterous
    hand the thumb's push against the fingers (or the fingers' against the
    thumb, whichever is smaller). A hand pushing the object from one side only
    has zero grip force. In a balanced two-sided grasp both sides are equal,
    and equal to half the total normal force.
    """
    fn = np.clip(contacts.normal_force, 0.0, None)
    first = contacts.finger == 0
    return float(min(np.sum(fn[first]), np.sum(fn[~first])))


def hand_contact_wrench(scene: Scene, point: np.ndarray, other: Other = "any") -> np.ndarray:
    """(6,) wrench [N, N m] the hand exerts on `other`, about `point` (3,) [m], world frame.

    This is what a wrist force-torque sensor would measure at `point`, with the
    sign of "hand pushes on the environment".
    """
    c = read_hand_contacts(scene, other)
    force = c.force.sum(axis=0)
    torque = c.torque.sum(axis=0) + np.cross(c.position - np.asarray(point, float), c.force).sum(axis=0)
    return np.concatenate([force, torque])
