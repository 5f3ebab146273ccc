"""Cost of recording: trials per second with recording on vs off, side by side in one run, and .rrd sizes.

For each object x hand: settle, plan `--trials` grasps (antipodal for jaws,
power for dexterous hands; jittered top grasps if the planner finds none),
then run every grasp twice under the standard protocol, once with a
`NullObserver` and once with a `TrialRecorder` at `--rate` Hz, alternating
which goes first so drift in machine load hits both. Reports trials/s off
and on, the overhead, whether the results were identical (they must be),
and the median / largest recording (target: under 5 MB per trial).

Needs `protocol.run(..., observer=...)`. Without it (`--scripted`, or when the
hook is missing) each trial is a scripted one instead: the hand closes on
the grasp and the object is pushed, stepped with plain `mj_step`, calling the
observer the way a protocol does; that measures the recorder against bare
physics, a harder baseline than the protocol.

    .venv/bin/python benchmarks/bench_record.py [--trials 10] [--objects box 025_mug] [--hands parallel_jaw]
"""

from __future__ import annotations

import argparse
import inspect
import statistics
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import trimesh

from manigrasp.objects import ObjectAsset, build_object
from manigrasp.protocol import PROTOCOLS, Status, TrialResult, as_grasp, settle_object
from manigrasp.protocol.observer import NullObserver
from manigrasp.record import RecordOptions, TrialRecorder
from manigrasp.sim import Scene, build_scene

DEXTEROUS_PREFIXES = ("inspire", "fourier")


def _asset(name: str, cache: Path) -> ObjectAsset:
    if name == "box":
        return build_object(trimesh.creation.box((0.05,) * 3), name="box", mass=0.3, cache_root=cache).asset
    from manigrasp.objects import catalog

    return catalog.build(catalog.shipped(name)).asset


def _grasps(scene: Scene, asset: ObjectAsset, rest: np.ndarray, n: int, rng: np.random.Generator) -> tuple[list, str]:
    from manigrasp import planners

    name = "power" if scene.hand.name.startswith(DEXTEROUS_PREFIXES) else "antipodal"
    observation = planners.Observation.from_asset(asset, rest)
    candidates = list(planners.plan(planners.load(name), observation, scene.hand, n, rng).candidates)
    if candidates:
        return [candidates[i % len(candidates)] for i in range(n)], name
    out = []
    for _ in range(n):
        pose = np.diag([1.0, -1.0, -1.0, 1.0])
        pose[:3, 3] = rest[:3, 3] + np.append(rng.uniform(-0.005, 0.005, 2), 0.0)
        out.append(pose)
    return out, "top"


def scripted_trial(scene: Scene, grasp: object, rest: np.ndarray, observer: object, seconds: float = 4.0
                   ) -> TrialResult:
    """Close the hand at the grasp pose, then push the object +x: plain stepping with observer calls."""
    pose = as_grasp(grasp).pose
    observer.on_start(scene, grasp, rest)
    scene.reset(mount=pose, object_pose=rest, synergy=0.0)
    n = int(round(seconds / scene.model.opt.timestep))
    period, next_sample, start = observer.sample_period_s, 0.0, time.perf_counter()
    observer.on_phase(scene, "close")
    for i in range(n):
        if i == n // 2:
            observer.on_phase(scene, "perturb", "+x")
            scene.data.xfrc_applied[scene.object_body, :3] = [scene.object_mass() * 9.81, 0.0, 0.0]
        scene.set_synergy(min(1.0, i / (n // 4)))
        if scene.time >= next_sample - 1e-12:
            observer.on_sample(scene)
            next_sample += period
        scene.step()
    scene.data.xfrc_applied[:] = 0.0
    result = TrialResult(Status.SUCCESS, sim_steps=n, sim_time_s=scene.time, wall_time_s=time.perf_counter() - start)
    observer.on_end(scene, result)
    return result


def _same(a: TrialResult, b: TrialResult) -> bool:
    return repr(replace(a, wall_time_s=0.0)) == repr(replace(b, wall_time_s=0.0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trials", type=int, default=10)
    parser.add_argument("--objects", nargs="+", default=["box", "025_mug"])
    parser.add_argument("--hands", nargs="+", default=["parallel_jaw", "inspire_left"])
    parser.add_argument("--rate", type=float, default=60.0, help="samples per simulated second")
    parser.add_argument("--scripted", action="store_true", help="scripted trials instead of the protocol")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    protocol = PROTOCOLS.load("standard")
    scripted = args.scripted or "observer" not in inspect.signature(protocol.run).parameters
    mode = "scripted trials (plain mj_step)" if scripted else "standard protocol"

    def run(scene: Scene, grasp: object, rest: np.ndarray, observer: object, i: int) -> TrialResult:
        if scripted:
            return scripted_trial(scene, grasp, rest, observer)
        return protocol.run(scene, grasp, np.random.default_rng(i), None, object_pose=rest, seed=i,
                            observer=observer)

    print(f"{mode}, {args.trials} trials per object x hand, recording at {args.rate:g} Hz, seed {args.seed}")
    print(f"{'object':<10} {'hand':<14} {'grasps':<9} {'off tr/s':>8} {'on tr/s':>8} {'overhead':>9} "
          f"{'same':>5} {'median MB':>9} {'max MB':>7} {'sim s/trial':>11}")
    options = RecordOptions(rate_hz=args.rate)
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.objects:
            asset = _asset(name, Path(tmp))
            for hand in args.hands:
                scene = build_scene(hand, asset)
                rest = settle_object(scene)
                grasps, source = _grasps(scene, asset, rest, args.trials, np.random.default_rng(args.seed))
                off_s = on_s = 0.0
                sizes, same, sim = [], 0, []
                for i, grasp in enumerate(grasps):
                    path = Path(tmp) / f"{name}_{hand}_{i}.rrd"
                    order = ("off", "on") if i % 2 == 0 else ("on", "off")
                    results = {}
                    for which in order:
                        observer = NullObserver() if which == "off" else TrialRecorder(path, options=options)
                        start = time.perf_counter()
                        results[which] = run(scene, grasp, rest, observer, i)
                        elapsed = time.perf_counter() - start
                        off_s, on_s = (off_s + elapsed, on_s) if which == "off" else (off_s, on_s + elapsed)
                    sizes.append(path.stat().st_size / 1e6 if path.exists() else float("nan"))
                    same += _same(results["off"], results["on"])
                    sim.append(results["off"].sim_time_s)
                n = len(grasps)
                print(f"{name:<10} {hand:<14} {source:<9} {n / off_s:>8.2f} {n / on_s:>8.2f} "
                      f"{100 * (on_s / off_s - 1):>8.1f}% {same:>2}/{n:<2} {statistics.median(sizes):>9.2f} "
                      f"{max(sizes):>7.2f} {statistics.mean(sim):>11.2f}")


if __name__ == "__main__":
    main()
