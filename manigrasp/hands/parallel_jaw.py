"""`parallel_jaw`: manigrasp's own Franka-hand-like gripper (assets/hands/parallel_jaw.xml).

Two coupled prismatic fingers (jaw width 0 to 8 cm), one force-limited
position actuator on the width tendon (grip force saturates at 70 N), rubber
pads with friction 0.5 and torsional friction, 0.70 kg. Primitives only, so
it is the fast default hand.

The closed command is a width of -3.5 cm, past the closed stop by
GRIP_FORCE / kp (kp = 2000 N/m, the lower end of the actuator's ctrlrange):
a jaw blocked by an object of any width >= 0 pushes with kp x (width + 3.5 cm)
>= 70 N at the closed command, so the grip loop can set any grip force up to
70 N on a 4 mm rim as on a 7 cm box. Below the limit the grip force grows by
kp x span = 230 N per unit synergy at every width
(`Hand.grip_stiffness`, the grip loop's gain).
"""

from __future__ import annotations

import mujoco
import numpy as np

from manigrasp.hands.base import Hand
from manigrasp.paths import assets_dir

MAX_WIDTH = 0.08  # [m], jaw opening at the open command
GRIP_FORCE = 70.0  # [N], the width actuator's force limit = push of each pad


def parallel_jaw_xml() -> str:
    """Path of the gripper's MJCF file (as a string)."""
    return str(assets_dir() / "hands" / "parallel_jaw.xml")


def build_parallel_jaw_spec() -> mujoco.MjSpec:
    """A fresh `MjSpec` of the gripper alone (root body `palm`, no joint)."""
    return mujoco.MjSpec.from_file(parallel_jaw_xml())


def make_parallel_jaw() -> Hand:
    """The `parallel_jaw` hand; its mass is read from the compiled model."""
    model = build_parallel_jaw_spec().compile()
    palm = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "palm")
    mass = float(model.body_subtreemass[palm])
    gripper = model.actuator("gripper")
    kp, closed_width = float(gripper.gainprm[0]), float(gripper.ctrlrange[0])  # the XML's 2000 N/m and -3.5 cm
    return Hand(
        name="parallel_jaw",
        kind="parallel",
        build_spec=build_parallel_jaw_spec,
        root_body="palm",
        tcp_site="tcp",
        finger_bodies=("finger1", "finger2"),
        actuators=("gripper",),
        open_ctrl=np.array([MAX_WIDTH]),
        closed_ctrl=np.array([closed_width]),
        max_width=MAX_WIDTH,
        max_grip_force=GRIP_FORCE,
        grip_stiffness=kp * (MAX_WIDTH - closed_width),
        mass=mass,
        source="manigrasp (assets/hands/parallel_jaw.xml)",
        pad_geoms=("finger1_pad", "finger2_pad"),
        notes=("fingers coupled by an equality constraint; one position actuator on the width tendon, "
               f"force-limited to {GRIP_FORCE:g} N (the push of each pad)",
               f"closed command {100 * closed_width:g} cm, past the closed stop, so a blocked jaw "
               f"reaches {GRIP_FORCE:g} N at any width"),
    )
