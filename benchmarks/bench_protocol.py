"""Trials per second of a protocol against the raw `mj_step` rate of the same compiled scene.

For each object (a 5 cm cube of 0.3 kg, the shipped mug) with `parallel_jaw`:
settle, plan `--trials` grasps with the antipodal planner (hand-placed top
grasps with random jitter if the planner is unavailable or fails), run them
under the protocol, then step the same compiled model, reset with the hand
closed on the object at the first grasp, for the same total number of steps
with no Python in the loop. The ratio is the protocol's share of the physics
limit (1.0: the controllers and checks cost nothing). The analytic metrics of
the planned and simulated contacts (`manigrasp.grasp`, computed once per
trial) are timed separately; "w/o metrics" is the ratio with their time left out.

    .venv/bin/python benchmarks/bench_protocol.py [--trials 20] [--protocol standard] [--objects box mug]
"""

from __future__ import annotations

import argparse
import collections
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np
import trimesh

from manigrasp.objects import ObjectAsset, build_object
from manigrasp.protocol import PROTOCOLS, phases, settle_object, trial
from manigrasp.sim import Scene, build_scene


def _asset(name: str, cache: Path) -> ObjectAsset:
    if name == "box":
        return build_object(trimesh.creation.box((0.05,) * 3), name="box", mass=0.3, cache_root=cache).asset
    from manigrasp.objects import catalog

    return catalog.build(catalog.shipped(name)).asset


def _grasps(scene: Scene, asset: ObjectAsset, rest: np.ndarray, n: int, rng: np.random.Generator) -> tuple[list, str]:
    """`n` grasps from the antipodal planner, else jittered top grasps; and where they came from."""
    try:
        from manigrasp import planners

        observation = planners.Observation.from_asset(asset, rest)
        result = planners.plan(planners.load("antipodal"), observation, scene.hand, n, rng)
        candidates = list(result.candidates)
        if candidates:
            return [candidates[i % len(candidates)] for i in range(n)], "antipodal"
    except Exception as exc:  # noqa: BLE001 - a benchmark falls back, and says so
        print(f"  (antipodal planner unavailable: {type(exc).__name__}: {exc}; using top grasps)")
    out = []
    for _ in range(n):
        pose = np.diag([1.0, -1.0, -1.0, 1.0])
        pose[:3, 3] = rest[:3, 3] + np.append(rng.uniform(-0.005, 0.005, 2), 0.0)
        out.append(pose)
    return out, "top"


def _raw_rate(scene: Scene, grasp: object, rest: np.ndarray, steps: int) -> float:
    """mj_step per second of `scene` with the hand closed on the object at `grasp`, no Python per step."""
    pose = np.asarray(getattr(grasp, "pose", grasp), float)
    scene.reset(mount=pose, object_pose=rest, synergy=1.0)
    model, data = scene.model, scene.data
    start = time.perf_counter()
    mujoco.mj_step(model, data, nstep=steps)
    return steps / (time.perf_counter() - start)


class MetricTimer:
    """Adds up the time in the protocol's metric functions (wrapped where the protocol looks them up)."""

    PLACES = ((trial, "planned_metrics"), (phases, "simulated_metrics"))

    def __init__(self) -> None:
        self.seconds = 0.0
        self.originals = [getattr(module, name) for module, name in self.PLACES]

    def __enter__(self) -> MetricTimer:
        for (module, name), original in zip(self.PLACES, self.originals, strict=True):
            setattr(module, name, self._wrap(original))
        return self

    def _wrap(self, original):  # noqa: ANN001, ANN202 - a transparent wrapper
        def timed(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start

        return timed

    def __exit__(self, *exc: object) -> None:
        for (module, name), original in zip(self.PLACES, self.originals, strict=True):
            setattr(module, name, original)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--protocol", default="standard", choices=PROTOCOLS.names())
    parser.add_argument("--objects", nargs="+", default=["box", "025_mug"])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    protocol = PROTOCOLS.load(args.protocol)
    print(f"protocol {args.protocol}, hand parallel_jaw, {args.trials} trials per object, seed {args.seed}")
    header = (f"{'object':<10} {'grasps':<9} {'trials/s':>9} {'succ':>5} {'steps/trial':>11} "
              f"{'proto steps/s':>13} {'raw steps/s':>11} {'ratio':>6} {'metrics s':>9} {'w/o metrics':>11}")
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        for name in args.objects:
            rng = np.random.default_rng(args.seed)
            asset = _asset(name, Path(cache))
            scene = build_scene("parallel_jaw", asset)
            rest = settle_object(scene)
            grasps, source = _grasps(scene, asset, rest, args.trials, rng)
            start = time.perf_counter()
            with MetricTimer() as metrics:
                results = [protocol.run(scene, g, rng, None, object_pose=rest, seed=i) for i, g in enumerate(grasps)]
            elapsed = time.perf_counter() - start
            steps = sum(r.sim_steps for r in results)
            raw = _raw_rate(scene, grasps[0], rest, max(steps, 1))
            proto_rate = steps / elapsed
            statuses = collections.Counter(r.status.value for r in results)
            rows.append(f"{name:<10} {source:<9} {len(results) / elapsed:>9.2f} {statuses['success']:>5} "
                        f"{steps / len(results):>11.0f} {proto_rate:>13.0f} {raw:>11.0f} {proto_rate / raw:>6.3f} "
                        f"{metrics.seconds:>9.2f} {steps / (elapsed - metrics.seconds) / raw:>11.3f}")
            rows.append(f"{'':<10} statuses: {dict(statuses)}")
    print(header)
    print("\n".join(rows))


if __name__ == "__main__":
    main()
