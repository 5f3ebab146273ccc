"""The hand registry. Entries are imported lazily, only when loaded."""

from __future__ import annotations

import types
from collections.abc import Callable
from functools import cache

from manigrasp.errors import ConfigError, HandError, ManigraspError
from manigrasp.hands.base import Hand
from manigrasp.registry import Registry, import_attribute

HANDS: Registry[Hand] = Registry("hand")

# name -> "module:factory"; each factory takes no argument and returns a Hand.
_BUILTIN: dict[str, str] = {
    "parallel_jaw": "manigrasp.hands.parallel_jaw:make_parallel_jaw",
    "panda": "manigrasp.hands.robosuite_hands:make_panda",
    "robotiq_2f85": "manigrasp.hands.robosuite_hands:make_robotiq_2f85",
    "inspire_right": "manigrasp.hands.robosuite_hands:make_inspire_right",
    "inspire_left": "manigrasp.hands.robosuite_hands:make_inspire_left",
    "fourier_right": "manigrasp.hands.robosuite_hands:make_fourier_right",
    "fourier_left": "manigrasp.hands.robosuite_hands:make_fourier_left",
    "allegro_right": "manigrasp.hands.allegro:make_allegro_right",  # the 'allegro' extra (example-robot-data)
    "allegro_left": "manigrasp.hands.allegro:make_allegro_left",
}


def _lazy(spec: str) -> Callable[[], Hand]:
    @cache
    def factory() -> Hand:
        return import_attribute(spec, "hand")()  # type: ignore[operator]

    return factory


for _name, _spec in _BUILTIN.items():
    HANDS.add(_name, _lazy(_spec))


def names() -> tuple[str, ...]:
    """Names of the registered hands."""
    return HANDS.names()


@cache
def registered_kind(name: str) -> str | None:
    """The kind ("parallel" or "dexterous") of the registered hand `name`, or None if no hand of that name is
    registered or it cannot be loaded (a missing extra). A ``module:attribute`` name is not imported."""
    if name not in HANDS:
        return None
    try:
        return HANDS.load(name).kind
    except ManigraspError:
        return None


def load(name: str) -> Hand:
    """The hand named `name`, or a user hand given as ``module:attribute``.

    A user entry may be a `Hand` or a callable returning one; either way it is
    validated (TCP site, finger bodies, actuators present) before it is returned.
    """
    if name in HANDS:
        return HANDS.load(name)
    entry = HANDS.resolve(name) if ":" not in name else import_attribute(name, "hand")
    if ":" in name and callable(entry) and not (isinstance(entry, types.FunctionType)
                                                or (isinstance(entry, type) and issubclass(entry, Hand))):
        # Refused before it is called, wherever a hand is named (`plan --hand`, `hands show`), as a config's is
        # (`bench.runner.validate`): `hands show os:system` called os.system (a TypeError traceback; os:abort
        # would have aborted).
        raise ConfigError(f"hand {name!r} is a {type(entry).__name__}: only a Hand, a Hand class or a Python function "
                        "returning one is accepted (it was not called)")
    try:
        hand = entry if isinstance(entry, Hand) or not callable(entry) else entry()
    except ManigraspError:
        raise
    except Exception as exc:  # a user factory's own failure: one line, not a traceback
        raise ConfigError(f"hand {name!r}: building it raised {type(exc).__name__}: {exc}") from exc
    if not isinstance(hand, Hand):
        raise HandError(f"hand {name!r} is a {type(hand).__name__}, not a manigrasp.hands.Hand "
                        "(or a callable that returns one)")
    from manigrasp.hands.validate import validate_hand

    validate_hand(hand)
    return hand
