"""Grip force a parallel-jaw hand reaches and holds, by object width (the protocol's own close phase).

For each hand, pad model and width, a box `width` thick across the jaws (6 x 6 cm otherwise, 0.1 kg)
stands on the table; the hand, its TCP at the box centre (top grasp), runs the standard protocol's
close phase (`protocol.phases.close`: the grip loop `control.GripController` at the control rate, then
the finger command held where it left it), then holds still `--hold` s. Printed: the grip force at
the end of the close phase and after the hold [N], the held force as a fraction of the target, and
how long the close phase took. An empty close (no object) is run too: its status, duration and final
jaw-actuator length (parallel_jaw, panda: the jaw width [m]; robotiq_2f85: the driver angle [rad]).

    .venv/bin/python benchmarks/bench_grip_force.py                                    # parallel_jaw
    .venv/bin/python benchmarks/bench_grip_force.py --hands parallel_jaw panda robotiq_2f85 --target 35
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from manigrasp import hands  # noqa: E402
from manigrasp.protocol import phases  # noqa: E402
from manigrasp.protocol.execution import Abort, GraspParams, TrialRun  # noqa: E402
from manigrasp.sim import SceneConfig, build_scene, current_grip_force  # noqa: E402

WIDTHS = (0.004, 0.008, 0.013, 0.02, 0.035, 0.05, 0.07)  # [m] object thickness across the jaws
HEIGHT = 0.06  # [m] box height (and depth along the jaws' x)
MASS = 0.1  # [kg]


def box_spec(width: float) -> mujoco.MjSpec:
    """An object MJCF: a free box `width` [m] across y, HEIGHT along x and z."""
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="object")
    body.add_freejoint()
    half = [HEIGHT / 2, width / 2, HEIGHT / 2]
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=half, mass=MASS)
    return spec


def top_grasp() -> np.ndarray:
    """(4, 4) TCP at the box centre, approach down (-z), closing along -y."""
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[2, 3] = HEIGHT / 2
    return pose


def rest_pose() -> np.ndarray:
    """(4, 4) the box standing on the table (its top z = HEIGHT)."""
    pose = np.eye(4)
    pose[2, 3] = HEIGHT / 2
    return pose


def close_on(hand: hands.Hand, width: float | None, pads: str, params: GraspParams,
             hold_s: float) -> tuple[str, float, float, float]:
    """(status and the close phase's duration, grip force after the close phase [N], after `hold_s` more [N],
    final jaw-actuator length)."""
    scene = build_scene(hand, None if width is None else box_spec(width), SceneConfig(pads=pads))
    run = TrialRun(scene, params, None)
    run.reset(top_grasp(), rest_pose(), 0.0)
    status = "closed"
    try:
        phases.close(run, 0.0, metrics=False)
    except Abort as abort:
        status = abort.status.value
    closed, close_s = current_grip_force(scene), run.sim_time
    run.hold_for(hold_s)
    length = float(scene.data.actuator_length[scene.hand_actuators][0])
    return f"{status} in {close_s:.2f} s", closed, current_grip_force(scene), length


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--hands", nargs="+", default=["parallel_jaw"], help="parallel-jaw hands")
    parser.add_argument("--pads", nargs="+", default=["rigid", "compliant"], help="pad models")
    parser.add_argument("--widths", nargs="+", type=float, default=list(WIDTHS), help="object widths [m]")
    parser.add_argument("--target", type=float, default=None,
                        help="grip force [N] (default: the protocol's fraction of the hand's maximum)")
    parser.add_argument("--hold", type=float, default=0.5, help="hold after the close phase [s]")
    args = parser.parse_args()
    params = GraspParams(grip_force=args.target)
    print(f"{'hand':13s} {'pads':9s} {'width[mm]':>9s} {'target[N]':>9s} {'closed[N]':>9s} {'held[N]':>8s} "
          f"{'held/target':>11s}")
    for name in args.hands:
        hand = hands.load(name)
        target = min(args.target or params.grip_force_fraction * hand.max_grip_force, hand.max_grip_force)
        for pads in args.pads:
            for width in args.widths:
                if width >= 0.95 * hand.max_width:
                    continue
                status, closed, held, _ = close_on(hand, width, pads, params, args.hold)
                print(f"{name:13s} {pads:9s} {1000 * width:9.1f} {target:9.1f} {closed:9.2f} {held:8.2f} "
                      f"{held / target:11.3f}  {status}", flush=True)
            status, _, held, length = close_on(hand, None, pads, params, args.hold)
            print(f"{name:13s} {pads:9s} {'empty':>9s} {target:9.1f} {'':9s} {held:8.2f} {'':11s}  {status}, "
                  f"actuator length {length:.4f}", flush=True)


if __name__ == "__main__":
    main()
