"""Which shipped objects each dexterous hand can hold under `standard` (and `six_direction`), and why not.

For every hand x object (the 20 objects of configs/standard.yaml, which include configs/dexterous.yaml's 8),
measured in MuJoCo and judged by `manigrasp.hands.capacity` (where the model is written out):

- the object: its grasp width, the narrowest horizontal width of its collision parts in the resting pose the
  configs use (``rest: file``), and its height and mass;
- the squeeze: the open hand (root welded to the world, no gravity, the scene's contact settings) closes on a
  fixed rigid cylinder as wide as the object, its axis along the TCP's x (across the palm), placed at the
  first spot along the approach axis clear of the open hand, from the TCP or 15 mm toward the thumb or the
  fingers, and 0, 15 or 30 mm further out (`PLACEMENTS`; the best of the nine is kept, as a planner would
  choose). The synergy ramps from open to closed over 3 s, recording the grip (thumb vs rest,
  `manigrasp.sim.grip_force`, what the protocol regulates) and the total normal force sum(f_n) at every step,
  then the full close (every servo at its force limit) is held 1 s;
- size: the object fits if the full close squeezes its cylinder from both sides (grip >= 1 N); an object
  that does not is tried across its narrowest convex part (a local pinch: a rim, a handle); the hand's
  aperture printed is the widest cylinder (30-160 mm, 10 mm steps) it squeezes;
- edge contact: a fingertip (radius: half the thinnest side of its collision geom's box) on an object lower
  than its radius touches the top edge, and a squeeze along the tilted normal pushes the object down;
- strength (also printed for a plain pinch, a balanced two-sided squeeze: sum(f_n) = 2 x the grip):
  sum(f_n) when the ramp's grip reached the protocol's grip (10 N in configs/dexterous.yaml,
  capped at the hand's `max_grip_force`, as the protocol caps it; if never reached, the full close's) must
  be at least the frictional load / mu: (1 + 1) m g for `standard` (gravity plus the downward m g
  perturbation: nothing holds an object taken from a table from below), 1.02 m g for `six_direction`
  (gravity-free, DexGraspBench's 10 N per kg per direction: `SixDirectionParams.force_multiple`). If it is
  not, "grip F" says the ramp's grip at which it was (when within `max_grip_force`: the object is holdable
  at a higher `grip_force`).

Verdicts at mu 0.5 (rigid hand geoms, the configs' default) and 1.0 (rubber fingertips under
``scene.pads=compliant``). Not modelled: torque about the grasp (a grasp off the centre of mass needs more:
the hammer's head, the drill's body), partial caging of round objects, boxes' flat faces (a cylinder stands
in for every object).

Measured (2 Dec 2026; 10 N grip, the Allegro's 9 N; verdicts at mu 0.5): all three hands squeeze cylinders
up to 120 mm; the bowl (159 mm) and the hammer (its 135 mm head) only across a convex part (a 6 mm rim piece,
the 30 mm handle), and the Inspire not the rim piece. A pinch (sum(f_n) = 2 x grip) holds up to 0.51 kg
(Allegro 0.46 kg): not the sugar box, mustard, hammer, wood block or drill (10.1, 11.8, 13.0, 14.3, 17.6 N of
grip needed); the Allegro's 12 mm fingertips on the 8 mm phone box touch its edge (mu_eff 0.12). The measured
squeezes: Inspire and Fourier 21-28 N of sum(f_n) at 10 N (the Fourier's palm wrap of the hammer's handle
85 N): everything that fits but the drill and the wood block (14-18 N of grip) and for the Inspire the hammer
(12.8 N); sugar box and mustard at margins 1.0-1.3. Allegro 24-74 N at 9 N (its fingers wrap): everything
but the drill (x0.86) and the hammer (x0.91). At mu 1 every object that fits holds. `six_direction` at mu
0.5, under the 10 m g push the protocol had before 7c3f98d: only the objects of about 0.1 kg (mug, banana,
ball, foam brick, cube, gelatin box, scissors; for the Allegro also the soup and tuna cans and the bowl's
rim). Under its push now (1.02 m g, no weight) a balanced 10 N pinch at mu 0.5 carries up to 1.0 kg.

    .venv/bin/python benchmarks/holdable.py                   # about 12 min on a shared core
    .venv/bin/python benchmarks/holdable.py --hands allegro_right --grip 10 --objects 025_mug 035_power_drill
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh

from manigrasp import hands
from manigrasp.bench.config import load_config
from manigrasp.hands.base import Hand
from manigrasp.hands.capacity import BALANCED_SQUEEZE, HoldCheck, check_hold, min_width_2d
from manigrasp.objects import catalog
from manigrasp.paths import configs_dir
from manigrasp.protocol import SixDirectionParams
from manigrasp.sim.compose import measure_hand
from manigrasp.sim.config import SceneConfig

DEXTEROUS = ("inspire_right", "fourier_right", "allegro_right")
RAMP_S = 3.0  # the synergy ramps from open to closed over RAMP_S [s]
FULL_S = 1.0  # then the full close is held FULL_S [s] before its forces are read
AVERAGE_S = 0.2  # the forces are averaged over the last AVERAGE_S [s]
SHIFT_STEP = 0.002  # the cylinder moves out along the approach axis in these steps until it clears the hand [m]
MAX_OFFSET = 0.2  # [m]
SIX_DIRECTION_PUSH = SixDirectionParams().force_multiple  # six_direction's push in units of m g [-]
# Cylinder placements tried per width (TCP y, extra z) [m]: at the TCP, toward the thumb or the fingers, further out.
PLACEMENTS = tuple((y, z) for z in (0.0, 0.015, 0.03) for y in (-0.015, 0.0, 0.015))
MIN_GRIP = 1.0  # a full close squeezing the cylinder with less grip [N] has not closed on it from both sides
HALF_LENGTH = 0.1  # half length of the test cylinder [m]
MUS = (0.5, 1.0)


@dataclass(frozen=True)
class ObjectSize:
    """An object in its resting pose: grasp width, the narrowest convex part's width, height [m]; mass [kg]."""

    name: str
    width: float
    part_width: float
    height: float
    mass: float


@dataclass(frozen=True)
class Squeeze:
    """A close on a fixed cylinder: the full close's total normal force and grip (thumb vs rest) [N], the
    cylinder's offsets from the TCP along the approach and closing axes [m], the ramp's (n,) grip and total
    normal force at every step [N]."""

    normal: float
    grip: float
    offset: float
    along_y: float
    ramp_grip: np.ndarray
    ramp_normal: np.ndarray

    @property
    def fits(self) -> bool:
        """Both sides (thumb and rest) press the cylinder at the full close."""
        return self.grip >= MIN_GRIP

    def normal_at(self, grip: float) -> float:
        """Total normal force [N] when the ramp's grip first reached `grip` [N]; if it never did, the full
        close's (the protocol then closes as far as the hand goes)."""
        hit = np.flatnonzero(self.ramp_grip >= grip)
        return float(self.ramp_normal[hit[0]]) if len(hit) else self.normal

    def grip_for(self, normal: float) -> float:
        """The ramp's grip [N] when its total normal force first reached `normal` [N] (inf if it never did)."""
        hit = np.flatnonzero(self.ramp_normal >= normal)
        return float(self.ramp_grip[hit[0]]) if len(hit) else float("inf")


def object_size(name: str) -> ObjectSize:
    """Width, height and mass of a shipped object resting as in its file (the configs' ``rest: file``)."""
    asset = catalog.build(catalog.shipped(name)).asset
    parts = [trimesh.load(str(p), force="mesh").vertices for p in asset.part_paths]
    points = np.concatenate(parts)
    part_width = min(min_width_2d(part[:, :2])[0] for part in parts)
    return ObjectSize(name, min_width_2d(points[:, :2])[0], part_width, float(np.ptp(points[:, 2])),
                      float(asset.mass))


def _subtree(model: mujoco.MjModel, body: int) -> list[int]:
    return [b for b in range(model.nbody) if _descends(model, b, body)]


def _descends(model: mujoco.MjModel, body: int, ancestor: int) -> bool:
    while body > 0:
        if body == ancestor:
            return True
        body = int(model.body_parentid[body])
    return False


def _colliding(model: mujoco.MjModel, bodies: list[int]) -> list[int]:
    return [g for g in range(model.ngeom) if model.geom_bodyid[g] in bodies
            and (model.geom_contype[g] or model.geom_conaffinity[g])]


def _depth(model: mujoco.MjModel, body: int) -> int:
    depth = 0
    while body > 0:
        body, depth = int(model.body_parentid[body]), depth + 1
    return depth


def tip_geoms(model: mujoco.MjModel, finger: str) -> list[int]:
    """Colliding geoms of the deepest body of `finger`'s subtree that has any (the fingertip)."""
    bodies = [b for b in _subtree(model, model.body(finger).id) if _colliding(model, [b])]
    deepest = max(bodies, key=lambda b: _depth(model, b))
    return _colliding(model, [deepest])


def _model(hand: Hand, config: SceneConfig) -> tuple[mujoco.MjModel, int]:
    """The hand (free root welded to the world, no gravity) and a fixed test cylinder on a mocap body."""
    spec = hand.build_spec()
    spec.body(hand.root_body).add_freejoint()
    spec.add_equality(type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_BODY, name1=hand.root_body)
    config.apply(spec.option)
    spec.option.gravity = [0.0, 0.0, 0.0]
    for geom in spec.geoms:
        if geom.contype or geom.conaffinity:
            geom.friction = [config.hand_friction, config.hand_torsional_friction, 0.0001]
            geom.condim = config.hand_condim
    body = spec.worldbody.add_body(name="holdable/cylinder", mocap=True)
    body.add_geom(name="holdable/cylinder", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.03, HALF_LENGTH, 0],
                  friction=[config.hand_friction, config.hand_torsional_friction, 0.0001], condim=config.hand_condim)
    model = spec.compile()
    return model, model.geom("holdable/cylinder").id


def _set_radius(model: mujoco.MjModel, geom: int, radius: float) -> None:
    model.geom_size[geom, 0] = radius
    model.geom_rbound[geom] = float(np.hypot(radius, HALF_LENGTH))
    model.geom_aabb[geom, 3:] = [radius, radius, HALF_LENGTH]


class HandBench:
    """One dexterous hand's measurements in MuJoCo (see the module docstring)."""

    def __init__(self, hand: Hand, config: SceneConfig) -> None:
        self.hand = hand
        self.model, self.cylinder = _model(hand, config)
        self.data = mujoco.MjData(self.model)
        frames = measure_hand(hand, config.open_settle_time)
        self.open_qpos = [(self.model.jnt_qposadr[self.model.joint(j).id], q) for j, q in frames.open_qpos.items()]
        self.actuators = [self.model.actuator(a).id for a in hand.actuators]
        self.thumb = set(_subtree(self.model, self.model.body(hand.finger_bodies[0]).id))
        self._open()
        site = self.data.site(hand.tcp_site)
        self.tcp_pos, self.tcp_rot = site.xpos.copy(), site.xmat.reshape(3, 3).copy()
        thumb_tip = tip_geoms(self.model, hand.finger_bodies[0])
        self.gaps = {f: self._gap(thumb_tip, tip_geoms(self.model, f)) for f in hand.finger_bodies[1:]}
        self.tip_radius = min(float(np.min(self.model.geom_aabb[g, 3:])) for f in hand.finger_bodies
                              for g in tip_geoms(self.model, f))

    def _open(self) -> None:
        mujoco.mj_resetData(self.model, self.data)
        for adr, q in self.open_qpos:
            self.data.qpos[adr:adr + len(q)] = q
        self.data.ctrl[self.actuators] = self.hand.open_ctrl
        self.data.mocap_pos[0] = [0.0, 0.0, 10.0]  # out of the way
        mujoco.mj_forward(self.model, self.data)

    def _gap(self, geoms_a: list[int], geoms_b: list[int]) -> float:
        return min(mujoco.mj_geomDistance(self.model, self.data, a, b, 1.0, None) for a in geoms_a for b in geoms_b)

    def _touching(self) -> bool:
        con = self.data.contact[:self.data.ncon]
        return bool(np.any((con.dist < 0) & ((con.geom1 == self.cylinder) | (con.geom2 == self.cylinder))))

    def best_squeeze(self, width: float, grip: float) -> Squeeze:
        """The `squeeze` of the `PLACEMENTS` that puts the most normal force on the cylinder at `grip` [N]
        among those that close on it from both sides (else the one with the largest full-close grip)."""
        squeezes = [self.squeeze(width, along_y, along_z) for along_y, along_z in PLACEMENTS]
        return max(squeezes, key=lambda q: (q.fits, q.normal_at(grip) if q.fits else q.grip))

    def squeeze(self, width: float, along_y: float = 0.0, along_z: float = 0.0) -> Squeeze:
        """Close on a fixed cylinder of diameter `width` [m] (module docstring) placed `along_y` [m] from the
        TCP along its closing axis and `along_z` [m] past the first clear spot along its approach axis: the
        synergy ramps from 0 to 1 over `RAMP_S`, recording grip and total normal force at every step; then
        the full close is held."""
        _set_radius(self.model, self.cylinder, width / 2)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, self.tcp_rot[:, [1, 2, 0]].flatten())  # cylinder axis (its z) = TCP x
        self._open()
        self.data.mocap_quat[0] = quat
        offset = 0.0
        while True:
            self.data.mocap_pos[0] = self.tcp_pos + along_y * self.tcp_rot[:, 1] + offset * self.tcp_rot[:, 2]
            mujoco.mj_forward(self.model, self.data)
            if not self._touching() or offset > MAX_OFFSET:
                break
            offset += SHIFT_STEP
        offset += along_z
        self.data.mocap_pos[0] = self.tcp_pos + along_y * self.tcp_rot[:, 1] + offset * self.tcp_rot[:, 2]
        ramp = int(round(RAMP_S / self.model.opt.timestep))
        curve = np.zeros((ramp, 2))
        for i in range(ramp):
            self.data.ctrl[self.actuators] = self.hand.synergy_ctrl((i + 1) / ramp)
            mujoco.mj_step(self.model, self.data)
            total, thumb, rest = self._forces()
            curve[i] = min(thumb, rest), total
        full = int(round(FULL_S / self.model.opt.timestep))
        tail = int(round(AVERAGE_S / self.model.opt.timestep))
        sums = np.zeros(3)
        for i in range(full):
            mujoco.mj_step(self.model, self.data)
            if i >= full - tail:
                sums += self._forces()
        normal, thumb, rest = sums / tail
        return Squeeze(normal=normal, grip=min(thumb, rest), offset=offset, along_y=along_y, ramp_grip=curve[:, 0],
                       ramp_normal=curve[:, 1])

    def _forces(self) -> np.ndarray:
        """(total, thumb side, rest) normal force of the hand on the cylinder [N]."""
        out = np.zeros(3)
        force = np.zeros(6)
        for i in range(self.data.ncon):
            con = self.data.contact[i]
            if self.cylinder not in (con.geom1, con.geom2):
                continue
            other = con.geom2 if con.geom1 == self.cylinder else con.geom1
            mujoco.mj_contactForce(self.model, self.data, i, force)
            fn = max(force[0], 0.0)
            out[0] += fn
            out[1 if self.model.geom_bodyid[other] in self.thumb else 2] += fn
        return out


def _verdict(check: HoldCheck, squeeze: Squeeze, max_grip: float, width: float, widest: float) -> str:
    """'yes xM' (M = available / needed), 'grip F' (holds at a grip of F N, within the hand's maximum) or why not."""
    if check.verdict == "holdable":
        return f"yes x{check.margin:.1f}"
    if check.verdict == "too heavy" and squeeze.grip_for(check.required) <= max_grip:
        return f"grip {squeeze.grip_for(check.required):.1f} N"
    if check.verdict == "too heavy":
        return f"heavy x{check.margin:.2f}"
    if check.verdict == "does not fit":
        return "too wide" if width > widest else "too narrow"
    return check.verdict


def _pinch_verdict(check: HoldCheck, max_grip: float, width: float, widest: float) -> str:
    """`_verdict` of a balanced pinch: the grip it needs is half the normal force."""
    need = check.required / BALANCED_SQUEEZE
    if check.verdict == "too heavy" and need <= max_grip:
        return f"grip {need:.1f} N"
    if check.verdict == "too heavy":
        return f"heavy x{check.margin:.2f}"
    if check.verdict == "does not fit":
        return "too wide" if width > widest else "too narrow"
    return f"yes x{check.margin:.1f}" if check.verdict == "holdable" else check.verdict


def aperture(bench: HandBench, widths: np.ndarray) -> float:
    """The widest of `widths` [m] that the hand's full close squeezes from both sides (0 if none)."""
    held = [w for w in widths if bench.best_squeeze(float(w), 0.0).fits]
    return max(held, default=0.0)


def report(bench: HandBench, sizes: list[ObjectSize], grip: float) -> None:
    """Print the hand's measurements and one row per object (module docstring)."""
    hand = bench.hand
    protocol_grip = min(grip, hand.max_grip_force)
    gaps = ", ".join(f"{1000 * g:.0f}" for g in bench.gaps.values())
    widest = aperture(bench, np.arange(0.03, 0.17, 0.01))
    print(f"\n{hand.name}: squeezes cylinders up to {1000 * widest:.0f} mm wide (10 mm steps); open thumb tip to "
          f"fingertips {gaps} mm; max_width {1000 * hand.max_width:.0f} mm; fingertip radius "
          f"{1000 * bench.tip_radius:.1f} mm; max_grip_force {hand.max_grip_force:.1f} N; protocol grip "
          f"{protocol_grip:.1f} N")
    print(f"{'object':20s} {'w x h [mm]':>10s} {'m [kg]':>6s} {'y':>3s} {'off':>3s} {'grip full':>9s} "
          f"{'Fn full':>7s} {'Fn@grip':>7s} {'need .5':>7s} {'need 1':>6s} {'pinch mu 0.5':>12s} "
          f"{'standard mu 0.5':>15s} {'standard mu 1':>13s} {'six_dir mu 0.5':>14s} {'six_dir mu 1':>12s}")
    for size in sizes:
        width, squeeze = size.width, bench.best_squeeze(size.width, protocol_grip)
        if not squeeze.fits and size.part_width < size.width:  # a local pinch across the narrowest part
            width, squeeze = size.part_width, bench.best_squeeze(size.part_width, protocol_grip)
        available = squeeze.normal_at(protocol_grip)
        cases = [(mu, 1.0, True) for mu in MUS] + [(mu, SIX_DIRECTION_PUSH, False) for mu in MUS]
        checks = [check_hold(squeeze.fits, size.height, size.mass, bench.tip_radius, available, mu,
                             perturb_multiple=k, gravity=gravity) for mu, k, gravity in cases]
        pinch = check_hold(squeeze.fits, size.height, size.mass, bench.tip_radius,
                           BALANCED_SQUEEZE * protocol_grip, MUS[0])
        verdicts = [_pinch_verdict(pinch, hand.max_grip_force, width, widest),
                    *(_verdict(c, squeeze, hand.max_grip_force, width, widest) for c in checks)]
        part = "p" if width != size.width else " "
        print(f"{size.name:20s} {1000 * width:4.0f}{part}x{1000 * size.height:4.0f} {size.mass:6.3f} "
              f"{1000 * squeeze.along_y:3.0f} {1000 * squeeze.offset:3.0f} {squeeze.grip:9.1f} {squeeze.normal:7.1f} "
              f"{available:7.1f} {checks[0].required:7.1f} {checks[1].required:6.1f} {verdicts[0]:>12s} "
              f"{verdicts[1]:>15s} {verdicts[2]:>13s} {verdicts[3]:>14s} {verdicts[4]:>12s}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hands", nargs="+", default=list(DEXTEROUS))
    parser.add_argument("--objects", nargs="+", help="default: the objects of configs/standard.yaml")
    parser.add_argument("--grip", type=float, default=10.0, help="the protocol's grip force [N] (default 10)")
    args = parser.parse_args()
    names = args.objects or [entry.name for entry in load_config(configs_dir() / "standard.yaml").objects]
    sizes = [object_size(name) for name in names]
    print("columns: w x h: the object's grasp width (p: its narrowest convex part's, when the whole does not "
          "fit) x height at rest [mm]; y, off: the chosen cylinder's offsets from the TCP along y and z [mm]; "
          "grip full, Fn full: grip (thumb vs rest) and sum(f_n) of the full close [N]; Fn@grip: sum(f_n) when "
          "the closing grip reached the protocol's [N]; need: the sum(f_n) standard needs, 2 m g / mu_eff at "
          "mu 0.5 and 1 [N]; pinch: a balanced two-sided squeeze, sum(f_n) = 2 x the protocol grip, in place of "
          "the measured; verdicts: yes x(Fn@grip / need), grip F (holds at a grip force of F N, within "
          "max_grip_force), heavy x(Fn@grip / need), too wide, too narrow, too thin")
    for name in args.hands:
        report(HandBench(hands.load(name), SceneConfig()), sizes, args.grip)


if __name__ == "__main__":
    main()
