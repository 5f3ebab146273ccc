"""Grips that hold: how far a hand-placed can creeps in each dexterous hand, with and without `FingerHold`.

For each dexterous hand and each `finger_hold_gain` (0 = off; 40, the protocols' default), a 66 mm x 12 cm,
0.35 kg can standing on the table is grasped by hand (side power grasp at mid-height, can axis across the
palm, thumb side up) and run through the `standard` protocol (close to half the hand's maximum grip force,
lift 10 cm, hold 0.5 s, six 1 x m g perturbations). Printed per hand x gain: the status, the largest
displacement [mm] and rotation [deg] of the can in the hand over the whole trial, the grip force [N].
`--adaptive` also runs the five-finger hands with adaptive (uncoupled) fingers, as they were before the
fingers' joints were coupled. Measured (2 Dec 2026, the grip loop's closing reach and inspire_left's thumb
mirrored from the right's): creep at gains 0 / 20 / 40: inspire_right 19.5 / 2.4 / 1.5 mm, fourier_right
12.0 / 1.5 / 1.2 mm, allegro_right 1.0 / 1.4 / 1.4 mm, inspire_left 19.5 / 2.7 / 1.8 mm, fourier_left
12.3 / 1.4 / 1.1 mm, allegro_left 0.9 / 1.2 / 1.2 mm, every trial a success (the Allegro's fingers held per
finger, without a force floor: `manigrasp.control.hold`; with the floor on every joint it crept 1.2 and 1.0 mm).
(With robosuite's own left thumb,
inspire_left crept 2.4 mm at 40: its thumb flexes in a plane tilted 6.5 deg from the right's mirror image.)

    .venv/bin/python benchmarks/bench_grip_hold.py --hands inspire_right fourier_right allegro_right \
        inspire_left fourier_left allegro_left
    .venv/bin/python benchmarks/bench_grip_hold.py --hands inspire_right --gains 0 40 --adaptive
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time

import numpy as np
import trimesh

from manigrasp import hands
from manigrasp.hands.placement import side_power_grasp
from manigrasp.objects import build_object
from manigrasp.planners.base import GraspCandidate
from manigrasp.protocol import PROTOCOLS, settle_object
from manigrasp.sim import build_scene


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hands", nargs="+", default=["inspire_right", "fourier_right", "allegro_right"])
    parser.add_argument("--gains", nargs="+", type=float, default=[0.0, 20.0, 40.0])
    parser.add_argument("--adaptive", action="store_true", help="also the five-finger hands with adaptive fingers")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as cache:
        can = build_object(trimesh.creation.cylinder(0.033, 0.12, sections=48), name="can", mass=0.35,
                           cache_root=cache).asset
        print(f"{'hand':28s} {'gain':>5s} {'status':16s} {'creep [mm]':>10s} {'turn [deg]':>10s} {'grip [N]':>8s}")
        for name in args.hands:
            variants = [(name, hands.load(name))]
            if args.adaptive and not name.startswith("allegro"):
                from manigrasp.hands.from_robosuite.dexterous import MODELS, make_from

                variants.append((f"{name} (adaptive)", make_from(dataclasses.replace(MODELS[name], coupled=False))))
            for label, hand in variants:
                scene = build_scene(hand, can)
                for gain in args.gains:
                    object_pose = settle_object(scene)
                    pose = side_power_grasp(hand, [object_pose[0, 3], object_pose[1, 3], scene.object_rest_height])
                    protocol = PROTOCOLS.load("standard", finger_hold_gain=gain)
                    result = protocol.run(scene, GraspCandidate(pose=pose, score=1.0), np.random.default_rng(0),
                                          deadline=time.monotonic() + 300, object_pose=object_pose, seed=0)
                    print(f"{label:28s} {gain:5g} {result.status.value:16s} {1000 * result.max_translation_m:10.2f} "
                          f"{result.max_rotation_deg:10.1f} {result.grip_force_n:8.2f}")


if __name__ == "__main__":
    main()
