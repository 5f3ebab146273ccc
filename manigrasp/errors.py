"""The one error hierarchy of manigrasp.

Every error a user can cause (a bad mesh, an unknown name, a misspelled config
key) is a `ManigraspError`; the CLI turns it into a one-line message and a
non-zero exit, never a traceback.
"""

from __future__ import annotations


class ManigraspError(Exception):
    """Base class of every error manigrasp raises on purpose."""


class UnknownNameError(ManigraspError, LookupError):
    """A name that is not in a registry; the message lists what is available."""


class ConfigError(ManigraspError, ValueError):
    """A configuration value or key that is not valid."""


class MeshError(ManigraspError, ValueError):
    """A mesh that cannot be read or used (empty, NaN, garbage, not closed)."""


class MeshUnitsError(MeshError):
    """A mesh whose size says it is not in metres."""


class DecompositionError(ManigraspError):
    """Convex decomposition failed or produced unusable parts."""


class HandError(ManigraspError):
    """A hand model that lacks something manigrasp needs (TCP site, fingers...)."""


class SimulationError(ManigraspError):
    """A scene that does not compile, or a simulation that diverged."""


class PlannerError(ManigraspError):
    """A planner that raised or returned an invalid grasp."""


class PerceptionError(ManigraspError):
    """Perception failed at run time on one view (object not in view, no model fits): a recorded result
    of the group that needed it, not a user error."""
