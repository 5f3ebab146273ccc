"""`Tabletop`: the table and one object of a scene, without a hand, for perception on its own.

    >>> table = build_tabletop(asset)
    >>> table.place(pose)            # the object at a (4, 4) world pose, positions computed
    >>> perceive(table, camera, database, rng)

It is composed by `manigrasp.sim.compose` exactly as a `Scene` composes its
table and object (same names, same table, same object MJCF), so a camera sees
the same geometry in both; the benchmark's perception runs on its `Scene`.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from manigrasp.errors import SimulationError
from manigrasp.geometry import check_rigid, mat_to_quat
from manigrasp.sim.compose import OBJECT_BODY, ObjectSource, compile_spec, name_to_id, tabletop_spec
from manigrasp.sim.config import SceneConfig


@dataclass(frozen=True, eq=False)
class Tabletop:
    """A compiled table (top at z = 0) and one free object (see `build_tabletop`).

    Attributes:
        model, data: the MuJoCo model and its data.
        object_body: id of the object's body (``object/object``).
    """

    model: mujoco.MjModel
    data: mujoco.MjData
    object_body: int

    def place(self, pose: np.ndarray) -> None:
        """Put the object at `pose` (4, 4) [m] and compute positions (`mj_forward`)."""
        pose = check_rigid(pose, "object pose")
        adr = self.model.jnt_qposadr[self.model.body_jntadr[self.object_body]]
        self.data.qpos[adr:adr + 3] = pose[:3, 3]
        self.data.qpos[adr + 3:adr + 7] = mat_to_quat(pose[:3, :3])
        mujoco.mj_forward(self.model, self.data)


def build_tabletop(obj: ObjectSource, config: SceneConfig | None = None) -> Tabletop:
    """Compile the table of `config` (default `SceneConfig()`) and `obj` (an `ObjectAsset`, an object MJCF
    path or an `MjSpec` of one, whose body ``object`` has a free joint)."""
    model = compile_spec(tabletop_spec(obj, config or SceneConfig()), "tabletop")
    body = name_to_id(model, mujoco.mjtObj.mjOBJ_BODY, OBJECT_BODY, "body")
    if model.body_jntnum[body] != 1 or model.jnt_type[model.body_jntadr[body]] != mujoco.mjtJoint.mjJNT_FREE:
        raise SimulationError("a tabletop's object needs a free joint")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return Tabletop(model, data, body)
