"""Contact records: one `Contact`, and `ContactSet` for many grasps at once.

A contact is where a finger touches the object. Its normal points INTO the
object (the direction in which the finger can push). Friction follows the
contact type:

- ``frictionless``: only a non-negative force along the normal.
- ``hard_finger``: a point contact with Coulomb friction, ``|f_t| <= mu f_n``.
- ``soft_finger``: a hard finger that also resists torsion about the normal;
  the cone is elliptic, ``(|f_t| / mu)^2 + (tau_n / gamma)^2 <= f_n^2``, with
  ``gamma`` [m] the torsional coefficient (as MuJoCo's condim=4 contacts).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from manigrasp.contact.defaults import STANDARD_MU
from manigrasp.errors import ManigraspError

UNIT_TOLERANCE = 1e-6
"""Allowed deviation of a normal or tangent from unit length (and of their dot product from 0)."""


class ContactError(ManigraspError, ValueError):
    """A contact (or set of contacts) with a bad shape, normal, friction or type."""


class ContactType(StrEnum):
    """The contact models manigrasp knows."""

    FRICTIONLESS = "frictionless"
    HARD_FINGER = "hard_finger"
    SOFT_FINGER = "soft_finger"


def as_contact_type(kind: ContactType | str) -> ContactType:
    """`kind` as a `ContactType`; an unknown name lists the valid ones."""
    try:
        return ContactType(kind)
    except ValueError:
        valid = ", ".join(t.value for t in ContactType)
        raise ContactError(f"unknown contact type {kind!r}; valid: {valid}") from None


def _frozen(array: object, shape_tail: tuple[int, ...], name: str) -> np.ndarray:
    """A read-only float64 copy of `array`, checked to end in `shape_tail` and be finite."""
    out = np.array(array, dtype=float)
    if out.shape[out.ndim - len(shape_tail) :] != shape_tail or out.ndim < len(shape_tail):
        raise ContactError(f"{name} must have shape (..., {', '.join(map(str, shape_tail))}), "
                           f"got {out.shape}")
    if not np.all(np.isfinite(out)):
        raise ContactError(f"{name} contains NaN or inf")
    out.setflags(write=False)
    return out


def _check_unit(vectors: np.ndarray, name: str) -> None:
    """Raise unless every row of `vectors` (..., 3) has unit length."""
    bad = np.abs(np.linalg.norm(vectors, axis=-1) - 1.0) > UNIT_TOLERANCE
    if np.any(bad):
        raise ContactError(f"{name} must be unit vectors (|v| = 1 within {UNIT_TOLERANCE})")


def _check_friction(mu: np.ndarray, gamma: np.ndarray, kind: ContactType) -> None:
    """Raise on negative mu, or gamma that does not fit the contact type."""
    if np.any(mu < 0):
        raise ContactError("friction coefficient mu must be >= 0")
    if kind is ContactType.SOFT_FINGER and np.any(gamma <= 0):
        raise ContactError("soft_finger contacts need a torsional coefficient gamma > 0 [m]")
    if kind is not ContactType.SOFT_FINGER and np.any(gamma != 0):
        raise ContactError(f"gamma is only used by soft_finger contacts, not {kind.value}")


def _check_tangent(tangents: np.ndarray, normals: np.ndarray) -> None:
    """Raise unless the tangents are unit vectors orthogonal to the normals."""
    _check_unit(tangents, "tangent")
    if np.any(np.abs(np.sum(tangents * normals, axis=-1)) > UNIT_TOLERANCE):
        raise ContactError("tangent must be orthogonal to the normal")


@dataclass(frozen=True, eq=False)
class Contact:
    """One contact between a finger and the object.

    Attributes:
        position: (3,) contact point in the world [m].
        normal: (3,) unit normal pointing INTO the object.
        mu: Coulomb friction coefficient (ignored by frictionless contacts).
        kind: the contact model (a `ContactType` or its string value).
        gamma: torsional friction coefficient [m] of a soft finger
            (``|tau_n| <= gamma f_n``); must be 0 for the other types.
        tangent: optional (3,) unit tangent orthogonal to `normal` that fixes
            the phase of the linearised friction cone (e.g. MuJoCo's contact
            frame); None picks a deterministic one from the normal.
    """

    position: np.ndarray
    normal: np.ndarray
    mu: float = STANDARD_MU
    kind: ContactType = ContactType.HARD_FINGER
    gamma: float = 0.0
    tangent: np.ndarray | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "kind", as_contact_type(self.kind))
        set_(self, "position", _frozen(self.position, (3,), "position").reshape(3))
        set_(self, "normal", _frozen(self.normal, (3,), "normal").reshape(3))
        set_(self, "mu", float(self.mu))
        set_(self, "gamma", float(self.gamma))
        _check_unit(self.normal, "normal")
        _check_friction(np.array(self.mu), np.array(self.gamma), self.kind)
        if self.tangent is not None:
            set_(self, "tangent", _frozen(self.tangent, (3,), "tangent").reshape(3))
            _check_tangent(self.tangent, self.normal)


@dataclass(frozen=True, eq=False)
class ContactSet:
    """Contacts of B grasps with n contacts each, all of one type (array form).

    Attributes:
        positions: (B, n, 3) contact points [m].
        normals: (B, n, 3) unit normals pointing into the object.
        mu: (B, n) friction coefficients (a scalar or any broadcastable shape is accepted).
        kind: the contact model shared by every contact of the set.
        gamma: (B, n) torsional coefficients [m] for soft fingers; None means 0.
        tangents: optional (B, n, 3) unit tangents fixing the cone phase.
    """

    positions: np.ndarray
    normals: np.ndarray
    mu: np.ndarray
    kind: ContactType = ContactType.HARD_FINGER
    gamma: np.ndarray | None = None
    tangents: np.ndarray | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "kind", as_contact_type(self.kind))
        positions = _frozen(self.positions, (3,), "positions")
        if positions.ndim != 3 or positions.shape[1] == 0:
            raise ContactError(f"positions must have shape (B, n, 3) with n >= 1, got {positions.shape}")
        set_(self, "positions", positions)
        set_(self, "normals", self._per_contact(self.normals, (3,), "normals"))
        set_(self, "mu", self._per_contact(self.mu, (), "mu"))
        set_(self, "gamma", self._per_contact(0.0 if self.gamma is None else self.gamma, (), "gamma"))
        _check_unit(self.normals, "normals")
        _check_friction(self.mu, self.gamma, self.kind)
        if self.tangents is not None:
            set_(self, "tangents", self._per_contact(self.tangents, (3,), "tangents"))
            _check_tangent(self.tangents, self.normals)

    def _per_contact(self, value: object, tail: tuple[int, ...], name: str) -> np.ndarray:
        """`value` broadcast to (B, n, *tail), read-only."""
        target = self.positions.shape[:2] + tail
        try:
            out = np.broadcast_to(_frozen(value, tail, name), target).copy()
        except ValueError:
            raise ContactError(f"{name} cannot be broadcast to shape {target}") from None
        out.setflags(write=False)
        return out

    @property
    def batch_size(self) -> int:
        """B, the number of grasps."""
        return int(self.positions.shape[0])

    @property
    def n_contacts(self) -> int:
        """n, the number of contacts per grasp."""
        return int(self.positions.shape[1])

    @classmethod
    def from_contacts(cls, contacts: Sequence[Contact]) -> ContactSet:
        """A set with B = 1 holding `contacts` (which must share one type)."""
        return cls.stack([contacts])

    @classmethod
    def stack(cls, grasps: Sequence[Sequence[Contact]]) -> ContactSet:
        """A set of B grasps, each a sequence of n contacts of one shared type."""
        flat = [c for grasp in grasps for c in grasp]
        if not flat or len({len(g) for g in grasps}) != 1:
            raise ContactError("need at least one contact, and the same number in every grasp")
        kinds = {c.kind for c in flat}
        if len(kinds) != 1:
            raise ContactError(f"all contacts of a set must share one type, got {sorted(kinds)}")
        shape = (len(grasps), len(grasps[0]))
        has_tangent = [c.tangent is not None for c in flat]
        tangents = None
        if all(has_tangent):
            tangents = np.array([c.tangent for c in flat]).reshape(*shape, 3)
        elif any(has_tangent):
            raise ContactError("give a tangent for every contact of a set or for none")
        return cls(
            positions=np.array([c.position for c in flat]).reshape(*shape, 3),
            normals=np.array([c.normal for c in flat]).reshape(*shape, 3),
            mu=np.array([c.mu for c in flat]).reshape(shape),
            kind=kinds.pop(),
            gamma=np.array([c.gamma for c in flat]).reshape(shape),
            tangents=tangents,
        )


def as_contact_set(contacts: Sequence[Contact] | ContactSet) -> ContactSet:
    """`contacts` as a `ContactSet` (a sequence of `Contact` becomes B = 1)."""
    if isinstance(contacts, ContactSet):
        return contacts
    return ContactSet.from_contacts(contacts)
