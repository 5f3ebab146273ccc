"""Why a trial with compliant pads fails: re-simulate stored trials and trace pads and object in the hand.

For each trial id (default: every `dropped_perturb` / `slipped_lift` trial of RUN_DIR, up to --max), the
stored grasp is re-simulated (as `manigrasp replay`) while every check period records: the phase, the
object's rotation in the hand since the grip closed as a rotation vector in the TCP frame (its component
along the grip axis y is torsion about the pad normal, the others are tilt of the object about axes in the
pad plane), each pad's normal force, the number of its elements touching, bottomed out (compression at the
joint limit) and the element compressions [mm], and the friction-cone usage of the element contacts
(1 = sliding). Printed: a trace at the phase changes and around the failure, and per trial a summary.

With --theory, the analytic pad stiffnesses for the scene's pad model are printed first: normal stiffness
E A / h, tilt stiffness E I / h about each in-face axis, and the tilt of a pair of pads under a torque.

    .venv/bin/python benchmarks/diagnose_pads.py /tmp/sugar_compliant --max 3 --theory
    .venv/bin/python benchmarks/diagnose_pads.py /tmp/sugar_compliant 004_sugar_box/parallel_jaw/.../0007

What it found on the cracker box (`bench_scans.py --out /tmp/bs`, compliant run, parallel_jaw x antipodal,
after the force-controlled jaw, 770037f..006c624: scan 16/20, recipe 20/20), with --summary on each
object's 20 trials: on the recipe 19 grasps touch with all 6 elements of each pad after the lift (one
with 5/5; the two traced, 0015 and 0017, at 1.02-1.04 mm each) and all 20 hold at demand/capacity
0.34-0.67. The four scan failures (0015-0018, all `dropped_perturb`, the box
turning 13-18 deg about the grip axis) have 4-5 element contacts per pad after the lift (the successes
mostly 6/6): on one or both pads a whole row (2 of 6 elements, at one end of the pad's long axis) is
at 0 mm while the others are compressed 0.7-2.2 mm, increasing toward the other end (the scan's face
curves away from the pad). They turn at demand/capacity 0.60-0.89, below 1: the capacity sums mu Fn r
about the TCP, but with the force piled on one end the box pivots about the loaded elements, where
the resistance is smaller; the successes run at 0.37-0.63, the same range as the recipe's.
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from manigrasp.bench.replay import _replay, stored_trials  # noqa: E402
from manigrasp.hands.pads import ELEMENT_PREFIX  # noqa: E402
from manigrasp.protocol import execution  # noqa: E402
from manigrasp.sim.contacts import contact_forces  # noqa: E402


def rotvec(r: np.ndarray) -> np.ndarray:
    """Rotation vector [deg] of rotation matrix `r`."""
    angle = math.acos(min(1.0, max(-1.0, (np.trace(r) - 1) / 2)))
    if angle < 1e-9:
        return np.zeros(3)
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / (2 * math.sin(angle))
    return math.degrees(angle) * axis


class Tracer:
    """Records the pads' state at every `TrialRun.check`."""

    def __init__(self) -> None:
        self.rows: list[dict] = []
        self.pads: dict[str, list[int]] | None = None

    def _setup(self, model: mujoco.MjModel) -> None:
        self.pads = {}
        for j in range(model.njnt):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
            if ELEMENT_PREFIX in name:
                pad = name.split(ELEMENT_PREFIX, 1)[1].rsplit("_", 1)[0]
                self.pads.setdefault(pad, []).append(j)

    def record(self, run: execution.TrialRun) -> None:
        scene, model, data = run.scene, run.scene.model, run.scene.data
        if self.pads is None:
            self._setup(model)
        row: dict = {"t": run.sim_time, "phase": run.watch[2] if run.watch else run.last_phase,
                     "synergy": scene.hand_synergy(), "command": run.grip.synergy if run.grip else float("nan")}
        if run.in_hand is not None:
            cur = run.object_in_hand()
            row["rot"] = rotvec(cur[:3, :3] @ run.in_hand[:3, :3].T)
            row["shift_mm"] = 1000 * (cur[:3, 3] - run.in_hand[:3, 3])
        obj = set(np.flatnonzero(model.geom_bodyid == scene.object_body))
        idx = [i for i in range(data.ncon) if (data.contact[i].geom1 in obj) ^ (data.contact[i].geom2 in obj)]
        forces = contact_forces(model, data, np.array(idx, int)) if idx else np.zeros((0, 6))
        # Torsion about the grip axis (TCP y) through the TCP: demand of gravity + the applied force at the
        # object's centre of mass, and the friction capacity sum mu_i fn_i r_i (+ torsional friction fn_i mu_t).
        tcp = data.site_xpos[scene.tcp_site]
        axis = data.site_xmat[scene.tcp_site].reshape(3, 3)[:, 1]
        body = scene.object_body
        load = scene.object_mass() * model.opt.gravity + data.xfrc_applied[body][:3]
        row["torque_demand"] = abs(float(np.cross(data.xipos[body] - tcp, load) @ axis))
        cap = 0.0
        for k, i in enumerate(idx):
            c = data.contact[i]
            arm = c.pos - tcp
            r = float(np.linalg.norm(arm - (arm @ axis) * axis))
            cap += max(forces[k][0], 0.0) * (c.friction[0] * r + (c.friction[2] if c.dim >= 4 else 0.0))
        row["torque_capacity"] = cap
        for pad, joints in (self.pads or {}).items():
            q = np.array([data.qpos[model.jnt_qposadr[j]] for j in joints])
            lim = np.array([model.jnt_range[j][1] for j in joints])
            bodies = {model.jnt_bodyid[j] for j in joints}
            fn, n_touch, cone = 0.0, 0, []
            for k, i in enumerate(idx):
                c = data.contact[i]
                other = c.geom2 if c.geom1 in obj else c.geom1
                if model.geom_bodyid[other] in bodies:
                    f = forces[k]
                    fn += max(f[0], 0.0)
                    n_touch += 1
                    mu = c.friction[0]
                    if f[0] > 1e-6 and mu > 0:
                        cone.append(float(np.linalg.norm(f[1:3]) / (mu * f[0])))
            row[pad] = {"fn": fn, "touch": n_touch, "bottom": int(np.sum(np.abs(q) >= lim - 1e-4)),
                        "q_mm": 1000 * q, "cone_max": max(cone) if cone else 0.0,
                        "cone_mean": float(np.mean(cone)) if cone else 0.0}
        self.rows.append(row)


def fmt(row: dict, pads: list[str]) -> str:
    rot = row.get("rot")
    s = f"t={row['t']:6.3f} {row['phase']:>8s} s={row['synergy']:.3f}/{row['command']:.3f} "
    s += f"T={row['torque_demand']:.3f}/{row['torque_capacity']:.3f} Nm "
    if rot is not None:
        s += f"rot[x,y(grip),z]=({rot[0]:+5.1f},{rot[1]:+5.1f},{rot[2]:+5.1f}) deg |{np.linalg.norm(rot):4.1f}| "
    for p in pads:
        d = row[p]
        s += (f"| {p}: Fn={d['fn']:5.1f} N touch={d['touch']:2d} bot={d['bottom']:2d} "
              f"q=[{d['q_mm'].min():4.2f},{d['q_mm'].max():4.2f}] mm cone={d['cone_mean']:.2f}/{d['cone_max']:.2f} ")
    return s


def trace(trial_id: str, trial) -> tuple[Tracer, object]:
    """Replay one stored trial with a `Tracer` on every check; (tracer, `Replay`)."""
    tracer = Tracer()
    original = execution.TrialRun.check

    def check(self):  # noqa: ANN001, ANN202
        tracer.record(self)
        return original(self)

    execution.TrialRun.check = check
    try:
        rep = _replay(trial_id, trial, None)
    finally:
        execution.TrialRun.check = original
    return tracer, rep


PERTURB = ("+x", "-x", "+y", "-y", "+z", "-z")


def summary_line(trial_id: str, trial) -> tuple[str, float, bool]:
    """One line per trial: outcome, the in-hand rotation split into torsion (about the grip axis) and tilt,
    the largest ratio of torsion demand to friction capacity over the hold and perturbation phases
    (demand: largest over the phase; capacity: at the phase's first check, before anything moved), and
    per pad the number of its element-object contacts at the end of the lift (held, before the pushes; an
    element touching two convex parts of the object counts twice)."""
    tracer, rep = trace(trial_id, trial)
    worst, where, rot = 0.0, "", np.zeros(3)
    rows = [r for r in tracer.rows if "rot" in r]
    for phase in ("lift", *PERTURB):
        chunk = [r for r in rows if r["phase"] == phase]
        if chunk and chunk[0]["torque_capacity"] > 0:
            ratio = max(r["torque_demand"] for r in chunk) / chunk[0]["torque_capacity"]
            if ratio > worst:
                worst, where = ratio, phase
    if rows:
        rot = max((r["rot"] for r in rows), key=lambda v: float(np.linalg.norm(v)))
    failed = rep.replayed.status.value != "success"
    lifted = [r for r in rows if r["phase"] == "lift"]
    touch = "/".join(str(lifted[-1][p]["touch"]) for p in sorted(tracer.pads or {})) if lifted else "-"
    line = (f"{trial_id.rsplit('/', 1)[-1]} {rep.replayed.status.value:16s} {rep.replayed.detail[:48]:48s} "
            f"torsion {abs(rot[1]):5.1f} deg tilt {math.hypot(rot[0], rot[2]):4.1f} deg "
            f"demand/capacity {worst:4.2f} ({where}) element contacts after lift {touch}")
    return line, worst, failed


def diagnose(run_dir: Path, trial_id: str, trial, every: int) -> None:
    tracer, rep = trace(trial_id, trial)
    pads = sorted(tracer.pads or {})
    print(f"\n### {trial_id}: stored {trial.result.status.value} ({trial.result.detail}); "
          f"replayed {rep.replayed.status.value} ({rep.replayed.detail})")
    last_phase = None
    n = len(tracer.rows)
    for i, row in enumerate(tracer.rows):
        if row["phase"] != last_phase or i % every == 0 or i >= n - 4:
            print(fmt(row, pads))
        last_phase = row["phase"]
    if tracer.rows and pads:
        last = tracer.rows[-1]
        for p in pads:
            print(f"  final {p} element compressions [mm] (rows along the pad's first in-face axis):")
            q = last[p]["q_mm"]
            cols = 4 if len(q) == 12 else len(q)
            for r in range(0, len(q), cols):
                print("   " + " ".join(f"{v:5.2f}" for v in q[r:r + cols]))


def theory(modulus: float, half: tuple[float, float], h: float, grip: float, travel_fraction: float) -> None:
    a, b = 2 * half[0], 2 * half[1]
    k_n = modulus * a * b / h
    i_a = b * a ** 3 / 12  # about the axis along b (tilting across a)
    i_b = a * b ** 3 / 12
    print(f"# pad {100 * a:.0f} x {100 * b:.0f} cm, h = {1000 * h:.0f} mm, E = {modulus / 1e6:.2f} MPa: "
          f"k_n = E A / h = {k_n:.3g} N/m, compression at {grip:g} N = {1000 * grip / k_n:.2f} mm "
          f"(travel {1000 * travel_fraction * h:.1f} mm)")
    for name, inertia, width in (("across the 2 cm side", i_a, a), ("across the 3 cm side", i_b, b)):
        k_t = modulus * inertia / h
        m_lift = grip * width / 6  # edge pressure reaches zero (uniform preload)
        print(f"  tilt {name}: E I / h = {k_t:.3g} N m/rad per pad; edge lifts off at M = F w / 6 = "
              f"{m_lift:.3f} N m per pad, tilt then {math.degrees(m_lift / k_t):.1f} deg")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("trials", nargs="*", help="trial ids (default: the run's dropped/slipped trials)")
    parser.add_argument("--max", type=int, default=3, help="at most this many trials (default 3)")
    parser.add_argument("--every", type=int, default=25, help="print every N-th check besides phase changes")
    parser.add_argument("--theory", action="store_true", help="print the analytic pad stiffnesses first")
    parser.add_argument("--summary", action="store_true",
                        help="one line per trial (default: every trial of the run) instead of traces")
    args = parser.parse_intermixed_args()
    trials = stored_trials(args.run_dir)
    if args.summary:
        n = {(a, b): 0 for a in (True, False) for b in (True, False)}
        for t in args.trials or sorted(trials):
            line, ratio, failed = summary_line(t, trials[t])
            print(line, flush=True)
            n[(ratio > 1.0, failed)] += 1
        print(f"# demand/capacity > 1: {n[(True, True)]} failed, {n[(True, False)]} held; "
              f"<= 1: {n[(False, True)]} failed, {n[(False, False)]} held")
        return
    ids = args.trials or [t for t, s in sorted(trials.items())
                          if s.result.status.value in ("dropped_perturb", "slipped_lift")][:args.max]
    if args.theory:
        from manigrasp.bench.rundir import load_meta
        scene = load_meta(args.run_dir)["config"].get("scene", {})
        theory(float(scene.get("pad_modulus", 3.4e5)), (0.01, 0.015), 0.006, 33.0, 0.8)
    for t in ids:
        diagnose(args.run_dir, t, trials[t], args.every)


if __name__ == "__main__":
    main()
