"""Hand models: a registry of `Hand` descriptions.

    >>> from manigrasp import hands
    >>> hands.names()            # the registered hands
    >>> hand = hands.load("parallel_jaw")

A user's own hand is named ``package.module:attribute`` where the attribute
is a `Hand` or a callable returning one; it is validated before use.
"""

from manigrasp.hands.base import Hand, HandKind
from manigrasp.hands.registry import HANDS, load, names

__all__ = ["HANDS", "Hand", "HandKind", "load", "names"]
