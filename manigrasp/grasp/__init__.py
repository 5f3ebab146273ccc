"""Grasp analysis: grasp matrix, force closure and quality metrics (pure NumPy/SciPy).

Single-grasp functions take a sequence of `manigrasp.contact.Contact`;
their ``*_batch`` / plural forms take a `manigrasp.contact.ContactSet` of B
grasps and return (B,) arrays. Wrenches are (force [N], torque / torque_scale
[N]) about `center`; see each module for the exact definitions.
"""

from manigrasp.grasp.closure import (
    closure_margin,
    closure_margin_batch,
    force_closure,
    force_closure_batch,
    min_friction_for_closure,
    min_friction_for_closure_batch,
)
from manigrasp.grasp.errors import GraspError
from manigrasp.grasp.matrix import (
    grasp_matrices,
    grasp_matrix,
    isotropies,
    isotropy,
    min_singular_value,
    min_singular_values,
)
from manigrasp.grasp.quality import ferrari_canny, ferrari_canny_batch, gws_volume, hull_epsilon
from manigrasp.grasp.resist import ContactForces, Resistance, resists_wrench
from manigrasp.grasp.robust import (
    ContactNoise,
    RobustEpsilon,
    RobustEpsilonBatch,
    robust_ferrari_canny,
    robust_ferrari_canny_batch,
)

__all__ = [
    "ContactForces",
    "ContactNoise",
    "GraspError",
    "Resistance",
    "RobustEpsilon",
    "RobustEpsilonBatch",
    "closure_margin",
    "closure_margin_batch",
    "ferrari_canny",
    "ferrari_canny_batch",
    "force_closure",
    "force_closure_batch",
    "grasp_matrices",
    "grasp_matrix",
    "gws_volume",
    "hull_epsilon",
    "isotropies",
    "isotropy",
    "min_friction_for_closure",
    "min_friction_for_closure_batch",
    "min_singular_value",
    "min_singular_values",
    "resists_wrench",
    "robust_ferrari_canny",
    "robust_ferrari_canny_batch",
]
