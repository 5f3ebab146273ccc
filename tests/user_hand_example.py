"""A tiny user hand, loaded in tests as ``user_hand_example:HAND`` (and broken variants of it)."""

from __future__ import annotations

from dataclasses import replace

import mujoco
import numpy as np

from manigrasp.hands import Hand

_MJCF = """
<mujoco model="tiny_gripper">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <body name="palm">
      <geom type="box" size="0.02 0.06 0.01" mass="0.3"/>
      {site}
      <body name="left" pos="0 -0.04 0.04">
        <joint name="left_slide" type="slide" axis="0 1 0" range="0 0.035" damping="10"/>
        <geom type="box" size="0.01 0.004 0.03" mass="0.05"/>
      </body>
      <body name="right" pos="0 0.04 0.04">
        <joint name="right_slide" type="slide" axis="0 -1 0" range="0 0.035" damping="10"/>
        <geom type="box" size="0.01 0.004 0.03" mass="0.05"/>
      </body>
    </body>
  </worldbody>
  <equality><joint joint1="right_slide" joint2="left_slide"/></equality>
  {actuator}
</mujoco>
"""
_SITE = '<site name="tcp" pos="0 0 0.05"/>'
_ACTUATOR = '<actuator><position name="close" joint="left_slide" kp="500" ctrlrange="0 0.035"/></actuator>'


def build(site: bool = True, actuator: bool = True) -> mujoco.MjSpec:
    """The tiny gripper's spec, optionally without its TCP site or its actuator."""
    return mujoco.MjSpec.from_string(_MJCF.format(site=_SITE if site else "", actuator=_ACTUATOR if actuator else ""))


HAND = Hand(
    name="tiny_gripper", kind="parallel", build_spec=build, root_body="palm", tcp_site="tcp",
    finger_bodies=("left", "right"), actuators=("close",), open_ctrl=np.array([0.0]),
    closed_ctrl=np.array([0.035]), max_width=0.072, max_grip_force=10.0, mass=0.4, source="user")


def make_hand() -> Hand:
    """The same hand through a factory (a user entry may be a callable)."""
    return HAND


NO_TCP_SITE = replace(HAND, build_spec=lambda: build(site=False))
NO_ACTUATORS = replace(HAND, build_spec=lambda: build(actuator=False))
NO_FINGERS_DECLARED = replace(HAND, finger_bodies=())
WRONG_FINGER = replace(HAND, finger_bodies=("left", "thumb"))
WRONG_ACTUATOR = replace(HAND, actuators=("squeeze",))
SHORT_CTRL = replace(HAND, closed_ctrl=np.array([0.035, 0.0]))


def _jointed_root() -> mujoco.MjSpec:
    spec = build()
    spec.body("palm").add_freejoint()
    return spec


JOINTED_ROOT = replace(HAND, build_spec=_jointed_root)


NOT_A_HAND = {"name": "tiny_gripper"}  # neither a Hand nor a callable returning one
