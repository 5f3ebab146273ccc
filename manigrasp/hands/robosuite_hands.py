"""Factories of the hands that ship inside robosuite (registered in `manigrasp.hands.registry`).

The models are read from the installed robosuite package and adapted at load;
see `manigrasp.hands.from_robosuite` for what is changed and why.
"""

from __future__ import annotations

from manigrasp.hands.from_robosuite.dexterous import (
    make_fourier_left,
    make_fourier_right,
    make_inspire_left,
    make_inspire_right,
)
from manigrasp.hands.from_robosuite.parallel import make_panda, make_robotiq_2f85

__all__ = [
    "make_fourier_left",
    "make_fourier_right",
    "make_inspire_left",
    "make_inspire_right",
    "make_panda",
    "make_robotiq_2f85",
]
