"""Dexterous fingertips, rigid vs compliant pads: what one fingertip holds, and how soft its contact already is.

For each dexterous hand, its index fingertip geom (`Hand.fingertip_geoms`) as the scene compiles it with
``pads: rigid`` and ``pads: compliant`` is pressed on a box with F = 2, 5, 10 N and the box pulled along the contact
plane (`manigrasp.sim.tiptest.press_fingertip`). Printed: the fingertip's sliding friction, the normal force it
returns, MuJoCo's contact penetration at rest, the number of contacts and the pull at which the box slid, over F.

Then the elastic-foundation estimate (the pads' model, `manigrasp.hands.pads`: p = E u / h) of a silicone layer
of thickness h on a sphere of radius R pressed with F: compression d = sqrt(F h / (pi E R)), contact radius
a = sqrt(2 R d), and the torsional friction of that patch per newton, (8/15) a mu; for the Allegro's 12 mm tip
spheres, E the pads' 0.34 MPa and h = 1, 2, 3 mm. MuJoCo's soft contact (solref 0.02, solimp 0.9-0.95 over 1 mm,
set per geom pair and scaled by the bodies' inverse weights at compile time) already lets the fingertip sink by as
much (this is why no softer contact is applied to the fingertips; docs/protocol.md "Dexterous fingertips").

    .venv/bin/python benchmarks/bench_fingertips.py
"""

from __future__ import annotations

import argparse
import math

import mujoco

from manigrasp import hands
from manigrasp.sim import build_scene
from manigrasp.sim.compose import HAND_PREFIX
from manigrasp.sim.config import SceneConfig
from manigrasp.sim.tiptest import press_fingertip

ALLEGRO_TIP_RADIUS = 0.012  # [m]


def rubber_cap(force: float, radius: float, modulus: float, thickness: float, mu: float) -> tuple[float, float, float]:
    """Elastic-foundation sphere: compression d [m], contact radius a [m] and torsional friction (8/15) a mu [m]."""
    d = math.sqrt(force * thickness / (math.pi * modulus * radius))
    a = math.sqrt(2.0 * radius * d)
    return d, a, 8.0 / 15.0 * a * mu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hands", nargs="+", default=[n for n in ("inspire_right", "fourier_right", "allegro_right")
                                                       if n in hands.names()])
    parser.add_argument("--forces", nargs="+", type=float, default=[2.0, 5.0, 10.0])
    args = parser.parse_args()
    print(f"{'hand':15s} {'pads':9s} {'geom':28s} {'mu':>4s} {'F [N]':>6s} {'fn [N]':>7s} {'pen [mm]':>8s} "
          f"{'ncon':>4s} {'slip/F':>6s}")
    for name in args.hands:
        hand = hands.load(name)
        tip = hand.fingertip_geoms[1]
        for pads in ("rigid", "compliant"):
            model = build_scene(hand, None, SceneConfig(pads=pads)).model
            geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, HAND_PREFIX + tip)
            for force in args.forces:
                r = press_fingertip(model, geom, force)
                print(f"{name:15s} {pads:9s} {tip:28s} {r.friction:4.2f} {force:6.1f} {r.normal_force:7.3f} "
                      f"{1000 * r.penetration:8.3f} {r.contacts:4d} {r.slip_force / force:6.3f}")
    config = SceneConfig()
    print(f"\nelastic-foundation silicone cap on a {1000 * ALLEGRO_TIP_RADIUS:.0f} mm sphere, E "
          f"{config.pad_modulus / 1e6:.2f} MPa, mu {config.pad_friction:g} (the hand's soft-finger torsion: "
          f"{1000 * config.hand_torsional_friction:.1f} mm)")
    print(f"{'h [mm]':>6s} {'F [N]':>6s} {'d [mm]':>7s} {'a [mm]':>7s} {'torsion [mm]':>12s}")
    for thickness in (0.001, 0.002, 0.003):
        for force in args.forces:
            d, a, torsion = rubber_cap(force, ALLEGRO_TIP_RADIUS, config.pad_modulus, thickness, config.pad_friction)
            print(f"{1000 * thickness:6.0f} {force:6.1f} {1000 * d:7.3f} {1000 * a:7.2f} {1000 * torsion:12.2f}")


if __name__ == "__main__":
    main()
