"""The pad validation cases, rigid vs compliant, side by side (the figures behind tests/test_pads.py).

For each hand's pad (default: the three parallel-jaw hands) and each press force F: the normal force the
flat surface returns (target F within 2 %), the
holding torque about the pad normal against the uniform-pressure patch value mu F mean(r) at the
pad's own friction (compliant: the rubber's `pad_friction`; rigid: `hand_friction`; target within
15 %), and the holding torque on 1 mm bumps against the flat value (target within 25 %). Then the
cost per simulation step of a `parallel_jaw` scene holding a 5 cm cube,
rigid vs compliant. Deterministic.

    .venv/bin/python benchmarks/bench_pads.py [--hands parallel_jaw] [--forces 10 35 70] [--pitch 0.01] [--friction 1.0]
"""

from __future__ import annotations

import argparse
import time

import trimesh

from manigrasp.hands import load
from manigrasp.hands.pads import pad_directions, pad_geometry, uniform_patch_torque
from manigrasp.objects import build_object
from manigrasp.sim import SceneConfig
from manigrasp.sim.padtest import bumps, jaw_closed_on, press_pad


def pad_half(hand: str) -> tuple[float, float, float]:
    """Half extents of `hand`'s first pad box: in the face (2) and half its thickness [m]."""
    spec = load(hand).build_spec()
    name, toward = pad_directions(spec, load(hand).pad_geoms, load(hand).tcp_site)[0]
    pad = pad_geometry(spec.geom(name), toward)
    return (float(pad.half[0]), float(pad.half[1]), pad.thickness / 2)


def step_cost(config: SceneConfig, asset, steps: int = 2000) -> tuple[float, int]:
    """Mean wall time of one step [ms] with the hand closed on a cube, and the contacts at the end."""
    scene = jaw_closed_on(asset, config)
    start = time.perf_counter()
    scene.step(steps)
    return (time.perf_counter() - start) / steps * 1e3, scene.data.ncon


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--hands", nargs="+", default=["parallel_jaw", "panda", "robotiq_2f85"], help="whose pads")
    parser.add_argument("--forces", type=float, nargs="+", default=[10.0, 35.0, 70.0], help="press forces [N]")
    parser.add_argument("--pitch", type=float, default=SceneConfig().pad_pitch, help="element pitch [m]")
    parser.add_argument("--friction", type=float, default=SceneConfig().pad_friction, help="compliant pad friction")
    args = parser.parse_args()
    config = SceneConfig(pad_pitch=args.pitch, pad_friction=args.friction)
    mus = {"rigid": config.hand_friction, "compliant": config.pad_friction}
    print(f"# mu rigid {mus['rigid']} / compliant {mus['compliant']}, E {config.pad_modulus:g} Pa, "
          f"pitch {args.pitch * 1000:g} mm; bumps: egg-crate 1 mm crest to trough, 3 cm wavelength")
    for hand in args.hands:
        half = pad_half(hand)
        print(f"\n## {hand}: pad {2 * half[0] * 100:g} x {2 * half[1] * 100:g} cm, {2 * half[2] * 1000:g} mm thick")
        print(f"{'F [N]':>6s} {'pads':9s} {'normal [N]':>10s} {'err %':>6s} {'torque [N m]':>12s} "
              f"{'patch [N m]':>11s} {'torque/patch':>12s} {'bumps [N m]':>11s} {'bumps/flat':>10s} "
              f"{'contacts flat/bumps':>19s}")
        for force in args.forces:
            for mode in ("rigid", "compliant"):
                patch = uniform_patch_torque(mus[mode], force, half[:2])
                flat = press_pad(mode, force, config=config, half=half)
                bumpy = press_pad(mode, force, bumps(), config=config, half=half)
                print(f"{force:6.1f} {mode:9s} {flat.normal_force:10.3f} {100 * (flat.normal_force / force - 1):+6.2f} "
                      f"{flat.holding_torque:12.4f} {patch:11.4f} {flat.holding_torque / patch:12.3f} "
                      f"{bumpy.holding_torque:11.4f} {bumpy.holding_torque / flat.holding_torque:10.3f} "
                      f"{flat.contacts:>9d}/{bumpy.contacts:<9d}")
    cube = build_object(trimesh.creation.box((0.05,) * 3), name="box", mass=0.3).asset
    print("\n# cost of one step, parallel_jaw closed on a 5 cm cube (2000 steps)")
    costs = {mode: step_cost(SceneConfig(pads=mode, pad_pitch=args.pitch, pad_friction=args.friction), cube)
             for mode in ("rigid", "compliant")}
    for mode, (ms, ncon) in costs.items():
        print(f"{mode:9s} {ms:.4f} ms/step, {ncon} contacts")
    print(f"compliant / rigid: {costs['compliant'][0] / costs['rigid'][0]:.2f}x per step")


if __name__ == "__main__":
    main()
