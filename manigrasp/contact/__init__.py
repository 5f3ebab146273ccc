"""Contact models: contact records, friction cones, Coulomb friction, contact wrenches.

Pure NumPy; no mujoco import. See `manigrasp.grasp` for grasp analysis.
"""

from manigrasp.contact.cone import (
    DEFAULT_EDGES,
    cone_edges,
    edge_directions,
    in_friction_cone,
    tangent_basis,
)
from manigrasp.contact.friction import coulomb_friction, friction_coefficient
from manigrasp.contact.model import (
    Contact,
    ContactError,
    ContactSet,
    ContactType,
    as_contact_set,
    as_contact_type,
)
from manigrasp.contact.wrench import (
    lever_arms,
    local_axes,
    primitive_forces,
    primitive_wrenches,
    wrench_basis,
)

__all__ = [
    "DEFAULT_EDGES",
    "Contact",
    "ContactError",
    "ContactSet",
    "ContactType",
    "as_contact_set",
    "as_contact_type",
    "cone_edges",
    "coulomb_friction",
    "edge_directions",
    "friction_coefficient",
    "in_friction_cone",
    "lever_arms",
    "local_axes",
    "primitive_forces",
    "primitive_wrenches",
    "tangent_basis",
    "wrench_basis",
]
