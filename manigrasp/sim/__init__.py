"""Simulation: scene composition, state reset and contact read-out (the only owner of MjModel/MjData).

    >>> from manigrasp.sim import build_scene
    >>> scene = build_scene("parallel_jaw", asset)
    >>> scene.reset(mount=grasp_pose)
"""

from manigrasp.sim.config import SceneConfig
from manigrasp.sim.contacts import (
    HandContacts,
    contact_forces,
    current_grip_force,
    grip_force,
    hand_contact_wrench,
    read_hand_contacts,
    to_contacts,
)
from manigrasp.sim.scene import FloatingBase, Scene, build_scene
from manigrasp.sim.tabletop import Tabletop, build_tabletop

__all__ = [
    "FloatingBase",
    "HandContacts",
    "Scene",
    "SceneConfig",
    "Tabletop",
    "build_scene",
    "build_tabletop",
    "contact_forces",
    "current_grip_force",
    "grip_force",
    "hand_contact_wrench",
    "read_hand_contacts",
    "to_contacts",
]
