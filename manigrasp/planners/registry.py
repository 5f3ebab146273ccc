"""The planner registry: ``antipodal``, ``dexopt``, ``file``, ``power``, ``random``, and users'
``package.module:attribute``.

A user attribute is a planner class (one with a ``plan`` method; it is built
with the keyword parameters) or a ready planner object (then without
parameters). Anything else (a function, ``os:system``) is refused before it is
called; but importing the module runs its code, so a config that names
``module:attribute`` is code: run only configs you trust.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from manigrasp.errors import ConfigError, ManigraspError, PlannerError
from manigrasp.planners.base import Planner
from manigrasp.registry import Registry, import_attribute

PLANNERS: Registry[Planner] = Registry("planner")

_BUILTIN: dict[str, str] = {
    "antipodal": "manigrasp.planners.antipodal:AntipodalPlanner",
    "dexopt": "manigrasp.planners.dexopt_planner:DexOptPlanner",
    "file": "manigrasp.planners.file:FilePlanner",
    "power": "manigrasp.planners.power:PowerPlanner",
    "random": "manigrasp.planners.random_planner:RandomPlanner",
}


def _lazy(spec: str) -> Any:
    def factory(**params: Any) -> Planner:
        return import_attribute(spec, "planner")(**params)  # type: ignore[operator]

    return factory


for _name, _spec in _BUILTIN.items():
    PLANNERS.add(_name, _lazy(_spec))


def names() -> tuple[str, ...]:
    """Names of the built-in planners."""
    return PLANNERS.names()


def load(name: str, **params: Any) -> Planner:
    """The planner `name` (built-in or ``package.module:attribute``) built with keyword `params`.

    Raises:
        UnknownNameError: an unknown name (the message lists the available ones)
            or a ``module:attribute`` that cannot be imported.
        ConfigError: a parameter the planner does not take.
        PlannerError: the attribute does not give a planner (no ``plan`` method).
    """
    entry = _entry(name)
    if name not in PLANNERS and not (_is_planner(entry) or _is_planner_class(entry)):
        raise PlannerError(f"planner {name!r} is a {type(entry).__name__} with no plan(observation, hand, n, rng) "
                           "method: only a planner class or object is accepted (it was not called)")
    if callable(entry) and not _is_planner(entry):
        try:
            planner = entry(**params)
        except TypeError as exc:
            raise ConfigError(f"planner {name!r}: bad parameters {sorted(params)}: {exc}"
                              f"{_valid_fields(name)}") from exc
        except ManigraspError:
            raise
        except Exception as exc:  # the planner's own constructor failed: a planner error, not a traceback
            raise PlannerError(f"planner {name!r}: building it raised {type(exc).__name__}: {exc}") from exc
    else:
        if params:
            raise ConfigError(f"planner {name!r} is a ready object and takes no parameters, got {sorted(params)}")
        planner = entry
    if not _is_planner(planner):
        raise PlannerError(f"planner {name!r} gives a {type(planner).__name__}, which has no "
                           "plan(observation, hand, n, rng) method")
    return planner  # type: ignore[return-value]


def _entry(name: str) -> object:
    if name in PLANNERS or ":" not in name:
        return PLANNERS.resolve(name)
    return import_attribute(name, "planner")


def _is_planner(obj: object) -> bool:
    return not isinstance(obj, type) and callable(getattr(obj, "plan", None))


def _is_planner_class(obj: object) -> bool:
    return isinstance(obj, type) and callable(getattr(obj, "plan", None))


def _valid_fields(name: str) -> str:
    spec = _BUILTIN.get(name)
    if spec is None:
        return ""
    cls = import_attribute(spec, "planner")
    if not dataclasses.is_dataclass(cls):
        return ""
    return "; valid parameters: " + ", ".join(f.name for f in dataclasses.fields(cls))
