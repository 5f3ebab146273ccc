"""Check that a `Hand` (ours or a user's) has everything manigrasp needs.

`validate_hand` builds the hand's spec, compiles it once and looks every
declared name up by name. The first problem found raises `HandError` with a
message that names the hand and exactly what is missing or wrong.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from manigrasp.errors import HandError
from manigrasp.hands.base import HAND_KINDS, Hand


def validate_hand(hand: object) -> None:
    """Raise `HandError` unless `hand` is a usable `Hand`; return None when it is."""
    if not isinstance(hand, Hand):
        raise HandError(f"expected a manigrasp.hands.Hand, got {type(hand).__name__}")
    _check_metadata(hand)
    model = _compile(hand)
    _check_root(hand, model)
    _check_names(hand, model)
    _check_ctrl(hand, model)


def _fail(hand: Hand, message: str) -> HandError:
    return HandError(f"hand {hand.name!r}: {message}")


def _check_metadata(hand: Hand) -> None:
    if hand.kind not in HAND_KINDS:
        raise _fail(hand, f"kind {hand.kind!r} is not one of {', '.join(HAND_KINDS)}")
    if not hand.tcp_site:
        raise _fail(hand, "no TCP site declared (tcp_site is empty)")
    if not hand.finger_bodies:
        raise _fail(hand, "no finger bodies declared (finger_bodies is empty)")
    if not hand.actuators:
        raise _fail(hand, "no actuators declared (actuators is empty)")
    for field in ("max_width", "max_grip_force", "mass"):
        value = getattr(hand, field)
        if not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
            raise _fail(hand, f"{field} must be a positive finite number, got {value!r}")
    stiffness = hand.grip_stiffness
    if stiffness is not None and (not isinstance(stiffness, int | float) or not math.isfinite(stiffness)
                                  or stiffness <= 0):
        raise _fail(hand, f"grip_stiffness must be a positive finite number or None, got {stiffness!r}")
    for field in ("approach_axis", "closing_axis"):
        axis = np.asarray(getattr(hand, field), dtype=float)
        if axis.shape != (3,) or not np.isclose(np.linalg.norm(axis), 1.0):
            raise _fail(hand, f"{field} must be a unit 3-vector, got {getattr(hand, field)!r}")


def _compile(hand: Hand) -> mujoco.MjModel:
    spec = hand.build_spec()
    if not isinstance(spec, mujoco.MjSpec):
        raise _fail(hand, f"build_spec() must return a mujoco.MjSpec, got {type(spec).__name__}")
    try:
        return spec.compile()
    except ValueError as exc:
        raise _fail(hand, f"its model does not compile: {exc}") from None


def _lookup(model: mujoco.MjModel, obj: mujoco.mjtObj, name: str) -> int:
    return mujoco.mj_name2id(model, obj, name)


def _available(model: mujoco.MjModel, obj: mujoco.mjtObj, count: int) -> str:
    names = [mujoco.mj_id2name(model, obj, i) for i in range(count)]
    return ", ".join(repr(n) for n in names if n) or "none"


def _check_root(hand: Hand, model: mujoco.MjModel) -> None:
    top = [b for b in range(1, model.nbody) if model.body_parentid[b] == 0]
    top_names = [model.body(b).name for b in top]
    if len(top) != 1:
        raise _fail(hand, f"the worldbody must hold exactly one body, found {len(top)}: {top_names}")
    if top_names[0] != hand.root_body:
        raise _fail(hand, f"root body {hand.root_body!r} not found; the top-level body is {top_names[0]!r}")
    if model.body_jntnum[top[0]] > 0:
        raise _fail(hand, f"root body {hand.root_body!r} has a joint; it must have none "
                          "(manigrasp mounts it on its own floating base)")


def _check_names(hand: Hand, model: mujoco.MjModel) -> None:
    obj = mujoco.mjtObj
    if _lookup(model, obj.mjOBJ_SITE, hand.tcp_site) < 0:
        raise _fail(hand, f"no TCP site {hand.tcp_site!r} in the model (sites: "
                          f"{_available(model, obj.mjOBJ_SITE, model.nsite)})")
    for body in hand.finger_bodies:
        if _lookup(model, obj.mjOBJ_BODY, body) < 0:
            raise _fail(hand, f"finger body {body!r} not found (bodies: "
                              f"{_available(model, obj.mjOBJ_BODY, model.nbody)})")
    if model.nu == 0:
        raise _fail(hand, "its model has no actuators")
    for name in hand.actuators:
        if _lookup(model, obj.mjOBJ_ACTUATOR, name) < 0:
            raise _fail(hand, f"actuator {name!r} not found (actuators: "
                              f"{_available(model, obj.mjOBJ_ACTUATOR, model.nu)})")


def _check_ctrl(hand: Hand, model: mujoco.MjModel) -> None:
    n_act = len(hand.actuators)
    for field in ("open_ctrl", "closed_ctrl"):
        ctrl = np.asarray(getattr(hand, field), dtype=float)
        if ctrl.shape != (n_act,):
            raise _fail(hand, f"{field} has shape {ctrl.shape}, expected ({n_act},): one command per actuator")
        if not np.all(np.isfinite(ctrl)):
            raise _fail(hand, f"{field} is not finite: {ctrl}")
        for name, value in zip(hand.actuators, ctrl, strict=True):
            act = _lookup(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
            if model.actuator_ctrllimited[act]:
                low, high = model.actuator_ctrlrange[act]
                if not low - 1e-9 <= value <= high + 1e-9:
                    raise _fail(hand, f"{field} of actuator {name!r} is {value}, outside its ctrlrange "
                                      f"[{low}, {high}] (MuJoCo would clamp it)")
