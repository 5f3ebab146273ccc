"""Evaluation of one grasp: protocols (phases, success criteria, failure modes) and their registry.

    >>> from manigrasp.protocol import PROTOCOLS, settle_object
    >>> rest = settle_object(scene)                      # what the planner sees
    >>> result = PROTOCOLS.load("standard").run(scene, candidate, rng, deadline, object_pose=rest)

Registered: `standard` (lift and perturb, DESIGN.md), `lift`, `six_direction`
(DexGraspBench), `shake` (ACRONYM-style).
"""

from manigrasp.protocol import lift as _lift
from manigrasp.protocol import shake as _shake
from manigrasp.protocol import six_direction as _six_direction
from manigrasp.protocol import standard as _standard
from manigrasp.protocol.base import PROTOCOLS, Protocol, load, names
from manigrasp.protocol.execution import GraspParams
from manigrasp.protocol.grasp import Grasp, as_grasp
from manigrasp.protocol.lift import LiftParams, LiftProtocol
from manigrasp.protocol.result import GraspMetrics, Phase, Status, TrialResult
from manigrasp.protocol.settle import settle_object
from manigrasp.protocol.shake import ShakeParams, ShakeProtocol
from manigrasp.protocol.six_direction import SixDirectionParams, SixDirectionProtocol
from manigrasp.protocol.standard import StandardParams, StandardProtocol

del _lift, _shake, _six_direction, _standard

__all__ = [
    "PROTOCOLS",
    "Grasp",
    "GraspMetrics",
    "GraspParams",
    "LiftParams",
    "LiftProtocol",
    "Phase",
    "Protocol",
    "ShakeParams",
    "ShakeProtocol",
    "SixDirectionParams",
    "SixDirectionProtocol",
    "StandardParams",
    "StandardProtocol",
    "Status",
    "TrialResult",
    "as_grasp",
    "load",
    "names",
    "settle_object",
]
