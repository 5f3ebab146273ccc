"""Plain registries: a name -> factory mapping with `names()` and `load()`.

Objects, hands, planners and protocols each have one. A user's own entry is
named ``package.module:attribute`` and imported on demand, so nothing is
imported or registered as a side effect of naming it.
"""

from __future__ import annotations

import difflib
import importlib
from collections.abc import Callable, Iterator, Mapping
from typing import Generic, TypeVar

from manigrasp.errors import UnknownNameError

T = TypeVar("T")


def nearest(name: str, choices: list[str] | tuple[str, ...]) -> str | None:
    """The closest of `choices` to `name` (for 'did you mean' hints), or None."""
    match = difflib.get_close_matches(name, list(choices), n=1, cutoff=0.5)
    return match[0] if match else None


def unknown_name_message(kind: str, name: str, choices: list[str] | tuple[str, ...]) -> str:
    """A one-line message for an unknown name that lists what is available."""
    hint = nearest(name, choices)
    did_you_mean = f" (did you mean {hint!r}?)" if hint else ""
    return f"unknown {kind} {name!r}{did_you_mean}; available: {', '.join(sorted(choices))}"


def import_attribute(spec: str, kind: str = "entry") -> object:
    """Import ``package.module:attribute`` and return the attribute."""
    module_name, _, attr = spec.partition(":")
    if not module_name or not attr:
        raise UnknownNameError(f"{kind} {spec!r} is not of the form 'package.module:attribute'")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise UnknownNameError(f"cannot import module {module_name!r} for {kind} {spec!r}: {exc}") from exc
    try:
        return getattr(module, attr)
    except AttributeError:
        raise UnknownNameError(f"module {module_name!r} has no attribute {attr!r} ({kind} {spec!r})") from None


class Registry(Mapping[str, Callable[..., T]], Generic[T]):
    """A mapping from names to factories of one kind of thing.

    Args:
        kind: what is registered ("hand", "planner", ...), used in messages.
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._factories: dict[str, Callable[..., T]] = {}

    def register(self, name: str) -> Callable[[Callable[..., T]], Callable[..., T]]:
        """Decorator that registers a factory under `name`."""

        def decorate(factory: Callable[..., T]) -> Callable[..., T]:
            if name in self._factories:
                raise ValueError(f"{self.kind} {name!r} is registered twice")
            self._factories[name] = factory
            return factory

        return decorate

    def add(self, name: str, factory: Callable[..., T]) -> None:
        """Register `factory` under `name` (non-decorator form)."""
        self.register(name)(factory)

    def names(self) -> tuple[str, ...]:
        """The registered names, sorted."""
        return tuple(sorted(self._factories))

    def resolve(self, name: str) -> Callable[..., T]:
        """The factory for `name`, or for a ``module:attribute`` spec."""
        if name in self._factories:
            return self._factories[name]
        if ":" in name:
            attr = import_attribute(name, self.kind)
            if not callable(attr):
                raise UnknownNameError(f"{self.kind} {name!r} is not callable")
            return attr  # type: ignore[return-value]
        raise UnknownNameError(unknown_name_message(self.kind, name, self.names()))

    def load(self, name: str, **params: object) -> T:
        """Build the entry named `name` with keyword `params`."""
        return self.resolve(name)(**params)

    def __getitem__(self, name: str) -> Callable[..., T]:
        return self.resolve(name)

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        return len(self._factories)

    def __contains__(self, name: object) -> bool:
        return name in self._factories
