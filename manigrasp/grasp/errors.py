"""The error grasp analysis raises for bad arguments."""

from __future__ import annotations

from manigrasp.errors import ManigraspError


class GraspError(ManigraspError, ValueError):
    """A bad argument to a grasp metric (unknown norm or method, wrong shape)."""
