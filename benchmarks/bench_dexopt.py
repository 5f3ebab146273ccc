"""The `dexopt` planner per hand: planning time per grasp on one core, penetration, diversity, optionally success.

For each hand and object, the object is settled on the table in the hand's scene (as `manigrasp bench` does),
one planning call asks for --grasps grasps (ground truth, planning seed --seed) and each returned grasp is
measured:

- time/grasp [s]: CPU time of the planning call (one thread: OMP_NUM_THREADS=1) / grasps returned, and the
  wall time of the call (the machine may be shared);
- penetration [mm]: deepest hand-object/table penetration at the planned configuration, re-measured here in
  MuJoCo (`mj_collision` in the real scene, no margin; independent of the planner's own check), max and mean;
- diversity: mean pairwise distance between the grasps' TCP poses: translation [mm] and rotation [deg];
- pads<2mm: mean number of fingers whose pad is within 2 mm of the object's collision parts;
- hold: how many grasps hold the standard protocol's loads at its 10 N squeeze by the planner's own load test
  (hold margin >= 1, `dexopt.hold_margin`, at the friction of the hand's grasping surfaces in the default
  scene, `PlanContext.contact_friction`), and their median margin;
- with --trials: each grasp run through the `standard` protocol (grip force 10 N, as configs/dexterous.yaml)
  in the same scene: successes / grasps and the failure statuses.

    .venv/bin/python benchmarks/bench_dexopt.py                               # 3 hands x 3 objects x 5 grasps
    .venv/bin/python benchmarks/bench_dexopt.py --hands allegro_right --objects 025_mug --grasps 10 --trials

With --run RUN_DIR --config CONFIG (a `manigrasp bench` run of dexopt and its config): each group is planned
again exactly as the run planned it (same seed, protocol context, planner parameters; the same code must be
checked out), every candidate that passed the checks is kept, the run's trials are matched to them by TCP
position, and the hold margin of each trial's grasp is printed with its outcome, with the rotation the grasp's
stiffness predicts under the loads (`Synthesis.rotation`); then per hand and protocol the successes of the trials
whose grasp passes the load test (margin >= the planner's `min_hold_margin`) and of those that do not, and the
successes per margin bin (`MARGIN_BINS`: what margin a hand's grasps need to hold). `--set KEY=VALUE ...`
re-plans with those planner parameters changed (a what-if on the same trials; a grasp the changed checks reject
is reported as not planned).

With --closes --config CONFIG [--only TEXT ...]: each dexopt group of the config (those whose hand/object contains
one of the --only texts) is planned as `manigrasp bench` plans it, with its closing check (`close_check`, step 7
of `dexopt_planner`) run on every candidate left after the suppression; printed: the candidates, how many pass
the check as configured, how many closes grip, and how many end at a simulated epsilon (the trials'
`sim_epsilon_l1`) of at least 0.15 and 0.1, with the CPU time of the call. `--set` changes planner parameters.

    .venv/bin/python benchmarks/bench_dexopt.py --closes --config dexterous --only fourier_right/010_potted

With --closes --per-candidate, also per group the restarts each check rejected (`last["rejected"]`) and those whose
fingers were opened out of the object (`last["retracted"]`), then one line per candidate in the planner's order: its
energy and unweighted terms (`Synthesis.terms`), hold margin, pads in contact, the simulated close's status, epsilon
and whether it passed, the friction the planned squeeze uses and the close's, how far the close moved the object
(`CloseResult.pushed`, also when the close failed: a light object knocked away); last, each term's Spearman correlation
with the simulated epsilon (which of the energy's terms rank well-closing grasps first).

With --spheres HAND ...: along each hand's open -> closed path (21 points), the deepest penetration between the real
collision geoms of different fingers (MuJoCo), and the summed overlap of the fingers' spheres (the self-penetration
term) counted from the sum of their radii and from `HandKinematics.sphere_reach` [mm].

    .venv/bin/python benchmarks/bench_dexopt.py --spheres fourier_right inspire_right allegro_right
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from manigrasp.cli.bench import resolve_config  # noqa: E402
from manigrasp.config import apply_overrides  # noqa: E402
from manigrasp.hands.registry import load as load_hand  # noqa: E402
from manigrasp.objects import catalog  # noqa: E402
from manigrasp.planners.base import Observation  # noqa: E402
from manigrasp.planners.collision import HandProbe  # noqa: E402
from manigrasp.planners.context import PlanContext  # noqa: E402
from manigrasp.planners.dexopt_planner import DexOptPlanner, _probe_contacts, choose_pads  # noqa: E402
from manigrasp.protocol import PROTOCOLS, settle_object  # noqa: E402
from manigrasp.protocol.grasp import as_grasp  # noqa: E402
from manigrasp.sim import SceneConfig, build_scene  # noqa: E402

HANDS = ("allegro_right", "inspire_right", "fourier_right")
OBJECTS = ("005_tomato_soup_can", "025_mug", "004_sugar_box")


def pairwise_diversity(poses: np.ndarray) -> tuple[float, float]:
    """Mean pairwise TCP translation [mm] and rotation [deg] distances of poses (n, 4, 4) (NaN if n < 2)."""
    if len(poses) < 2:
        return float("nan"), float("nan")
    i, j = np.triu_indices(len(poses), 1)
    shift = np.linalg.norm(poses[i, :3, 3] - poses[j, :3, 3], axis=1)
    relative = np.einsum("nji,njk->nik", poses[i, :3, :3], poses[j, :3, :3])
    angle = np.arccos(np.clip((np.trace(relative, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0))
    return 1e3 * float(shift.mean()), float(np.degrees(angle).mean())


def run(hand_name: str, obj: str, args: argparse.Namespace) -> dict:
    from manigrasp.planners.dexopt_planner import _hand_q  # here: --closes and --run also run on older checkouts

    hand = load_hand(hand_name)
    asset = catalog.build(catalog.shipped(obj)).asset
    scene = build_scene(hand, asset, SceneConfig())
    rest = settle_object(scene)
    observation = Observation.from_asset(asset, rest)
    planner = DexOptPlanner(restarts=args.restarts, iterations=args.iterations)
    planner.kinematics(hand)  # the hand's model is built once per process, not per call: not timed
    cpu, wall = time.process_time(), time.perf_counter()
    protocol = PROTOCOLS.load("standard", grip_force=10.0)
    context = PlanContext.for_run(protocol.params, SceneConfig(), hand)
    found = planner.synthesise(observation, hand, args.grasps, np.random.default_rng(args.seed), None, context)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    hk, sdf = planner.kinematics(hand), planner.object_sdf(observation)
    probe = HandProbe(hand, observation, clearance=0.0)
    addresses = probe.hand_qpos_addresses()
    depths, pads = [], []
    for s in found:
        qpos = hk.full_qpos(np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), s.q)
        depths.append(_probe_contacts(probe, s.pose, _hand_q(hk, qpos, addresses))[0])
        root = s.pose @ hk.root_in_tcp
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, root[:3, :3].ravel())
        xpos, xmat, *_ = hk.evaluate(root[None, :3, 3], quat[None], s.q[None])
        world = hk.world(hk.contacts, xpos, xmat)
        chosen = choose_pads(sdf, world, hk.pad_finger)[0]
        pads.append(int(np.sum(np.abs(sdf.distance(world[0, chosen])[0]) < 0.002)))
    out = {"hand": hand_name, "object": obj, "n": len(found), "cpu": cpu, "wall": wall,
           "pen_max": 1e3 * max(depths, default=float("nan")), "pen_mean": 1e3 * float(np.mean(depths)) if depths
           else float("nan"), "div": pairwise_diversity(np.array([s.pose for s in found]).reshape(-1, 4, 4)),
           "pads": float(np.mean(pads)) if pads else float("nan"), "rejected": dict(planner.last["rejected"]),
           "statuses": Counter(), "holds": [s.hold for s in found]}
    if args.trials and found:
        for k, candidate in enumerate(planner.plan(observation, hand, args.grasps, np.random.default_rng(args.seed),
                                                   context)):
            result = protocol.run(scene, as_grasp(candidate), np.random.default_rng(k), object_pose=rest)
            out["statuses"][str(result.status.value)] += 1
    return out


def planning_inputs(g) -> tuple:
    """What `manigrasp bench` plans group `g` with: its scene, planning context and observation of the settled
    object."""
    from manigrasp.bench.observe import observe_with_info
    from manigrasp.bench.worker import _asset, scene_for

    scene = scene_for(g)
    context = PlanContext.for_run(PROTOCOLS.load(g.protocol.name, **dict(g.protocol.params)).params, g.scene,
                                  scene.hand)
    pose = settle_object(scene)
    observation, _ = observe_with_info(g.observation, _asset(g), pose, scene, seed=g.seed, camera=g.camera)
    return scene, context, observation


MARGIN_BINS = (0.0, 1.0, 1.5, 2.0, 3.0, np.inf)  # --run: successes per bin of the planned hold margin


def hold_vs_outcome(run_dir: str, config: str, override: dict | None = None) -> None:
    """Hold margin of each dexopt trial's grasp in a stored run against its outcome (module docstring);
    `override`: planner parameters replaced in the re-planning (a what-if: the margins the trials' grasps would
    get; a grasp the changed checks reject is reported as not planned)."""
    import sqlite3

    import manigrasp.planners.dexopt_planner as dexopt_planner
    from manigrasp.bench.config import load_config
    from manigrasp.bench.trials import groups

    keep_all = lambda poses, distance, angle: np.arange(len(poses))  # noqa: E731
    dexopt_planner.suppress = keep_all  # every candidate that passed the checks, to match the run's against
    db = sqlite3.connect(f"{run_dir}/results.sqlite")
    tally: dict[tuple[str, str], list[int]] = {}
    binned: dict[tuple[str, str], np.ndarray] = {}  # successes and trials per MARGIN_BINS bin
    for g in groups(load_config(resolve_config(config))):
        if g.planner.name != "dexopt":
            continue
        scene, context, observation = planning_inputs(g)
        planner = DexOptPlanner(**{**dict(g.planner.params), **(override or {})})
        found = planner.synthesise(observation, scene.hand, 10**6, g.rng(), context.pregrasp_offset, context)
        if not found:
            continue
        position = np.array([s.pose[:3, 3] for s in found])
        # This group's protocol only: a run of several protocols stores each grasp once per protocol (the tally
        # counted every trial once per protocol group before).
        rows = db.execute("select grasp_index, status, grasp_x_m, grasp_y_m, grasp_z_m from trials where object=? "
                          "and hand=? and planner=? and protocol=? and grasp_x_m is not null order by grasp_index",
                          (g.object_source.name, g.hand, g.planner_label, g.protocol.name)).fetchall()
        for index, status, *xyz in rows:
            gap = np.linalg.norm(position - np.asarray(xyz, float), axis=1)
            j = int(np.argmin(gap))
            if gap[j] > 1e-6:
                print(f"{g.hand} {g.object_source.name} {index}: no planned grasp at the trial's pose (other code?)")
                continue
            hold = found[j].hold
            print(f"{g.hand:<14} {g.protocol.name:<13} {g.object_source.name:<20} {index:>2} {status:<16} hold "
                  f"{hold:6.2f} rotation {np.degrees(found[j].rotation):7.2f} deg", flush=True)
            t = tally.setdefault((g.hand, g.protocol.name), [0, 0, 0, 0])
            t[0 if hold >= planner.min_hold_margin else 2] += status == "success"
            t[1 if hold >= planner.min_hold_margin else 3] += 1
            b = binned.setdefault((g.hand, g.protocol.name), np.zeros((2, len(MARGIN_BINS) - 1), int))
            k = int(np.clip(np.searchsorted(MARGIN_BINS, hold, side="right") - 1, 0, len(MARGIN_BINS) - 2))
            b[:, k] += (status == "success", 1)
    for (hand, protocol), (s1, n1, s0, n0) in tally.items():
        print(f"{hand} {protocol}: passing the load test {s1}/{n1} succeeded, failing it {s0}/{n0}")
    labels = [f"[{lo:g}, {hi:g})" for lo, hi in zip(MARGIN_BINS[:-1], MARGIN_BINS[1:], strict=True)]
    print("successes / trials by the grasp's hold margin: " + ", ".join(labels))
    for (hand, protocol), (ok, n) in binned.items():
        print(f"  {hand:<14} {protocol:<13} " + "  ".join(f"{a:>2}/{b:<2}" for a, b in zip(ok, n, strict=True)))


def closes(config: str, only: list[str], override: dict | None = None, per_candidate: bool = False) -> None:
    """How many of each group's candidates close well in the simulation (module docstring, --closes), with
    `per_candidate` each candidate's terms, margin and close."""
    from manigrasp.bench.config import load_config
    from manigrasp.bench.trials import groups

    print(f"{'hand':<14} {'object':<20} {'protocol':<13} {'candidates':>10} {'passed':>6} {'gripped':>7} "
          f"{'eps>=0.15':>9} {'eps>=0.1':>8} {'cpu s':>6}")
    for g in groups(load_config(resolve_config(config))):
        label = f"{g.hand}/{g.object_source.name}"
        if g.planner.name != "dexopt" or (only and not any(text in label for text in only)):
            continue
        scene, context, observation = planning_inputs(g)
        planner = DexOptPlanner(**{**dict(g.planner.params), **(override or {}), "close_check": 10**6})
        start = time.process_time()
        found = planner.synthesise(observation, scene.hand, 10**6, g.rng(), context.pregrasp_offset, context)
        cpu = time.process_time() - start
        checked = planner.last.get("close", [])
        eps = np.array([c.epsilon for c in checked])
        print(f"{g.hand:<14} {g.object_source.name:<20} {g.protocol.name:<13} {len(found):>10} "
              f"{sum(c.passed for c in checked):>6} {sum(not c.status for c in checked):>7} "
              f"{int(np.sum(eps >= 0.15)):>9} {int(np.sum(eps >= 0.1)):>8} {cpu:>6.1f}", flush=True)
        if per_candidate and found:
            candidate_lines(planner, found)


def candidate_lines(planner: DexOptPlanner, found: list) -> None:
    """--per-candidate: the rejections, one line per closed candidate, each term's rank correlation with the
    simulated epsilon."""
    from scipy.stats import spearmanr

    print(f"  rejected {planner.last.get('rejected')}, retracted {planner.last.get('retracted')}")
    keys = sorted(found[0].terms)
    print("  rank  energy " + " ".join(f"{k[:8]:>8}" for k in keys)
          + "   hold pads status     eps pass used close-used pushed-mm")
    for i, s in enumerate(found):
        c = s.close
        print(f"  {i:4d} {s.energy:7.3f} " + " ".join(f"{s.terms[k]:8.4f}" for k in keys)
              + f" {s.hold:6.2f} {len(s.contacts):4d} {c.status or 'gripped':<10} {c.epsilon:5.3f} {int(c.passed):4d}"
              + f" {s.friction_used:4.2f} {c.friction_used:10.2f} {1000 * c.pushed:9.1f}")
    eps = np.array([s.close.epsilon for s in found])
    for k in keys + ["energy", "hold"]:
        v = np.array([s.terms[k] if k in s.terms else getattr(s, k) for s in found])
        rho = spearmanr(v, eps)[0] if np.ptp(v) > 0 and np.ptp(eps) > 0 else float("nan")
        print(f"  {k:<16} Spearman vs simulated epsilon {rho:+.2f}")


def spheres(hands: list[str]) -> None:
    """--spheres: the fingers' real and sphere overlaps along each hand's closing path (module docstring)."""
    from manigrasp.planners.dexopt_hand import HandKinematics

    origin, unit = np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0, 0.0]])
    print(f"{'hand':<14} {'close':>5} {'MuJoCo mm':>9} {'radii mm':>8} {'reach mm':>8}")
    for name in hands:
        hk = HandKinematics(load_hand(name))
        radii = hk.sphere_radius[:, None] + hk.sphere_radius[None]
        cross = hk.sphere_finger[:, None] != hk.sphere_finger[None]
        for t in np.linspace(0.0, 1.0, 21):
            q = hk.q_open + t * (hk.q_closed - hk.q_open)
            xpos, xmat, *_ = hk.evaluate(origin, unit, q[None])
            c = hk.world(hk.spheres, xpos, xmat)[0]
            dist = np.linalg.norm(c[:, None] - c[None], axis=2)
            by_radii = 0.5 * np.where(cross & (dist < radii), radii - dist, 0.0).sum()
            by_reach = 0.5 * np.where(dist < hk.sphere_reach, hk.sphere_reach - dist, 0.0).sum()
            real = hk.finger_overlap(hk.full_qpos(origin[0], unit[0], q))
            print(f"{name:<14} {t:>5.2f} {1000 * real:>9.1f} {1000 * by_radii:>8.1f} {1000 * by_reach:>8.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--hands", nargs="+", default=list(HANDS))
    parser.add_argument("--objects", nargs="+", default=list(OBJECTS))
    parser.add_argument("--grasps", type=int, default=5)
    parser.add_argument("--restarts", type=int, default=DexOptPlanner.restarts)
    parser.add_argument("--iterations", type=int, default=DexOptPlanner.iterations)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--trials", action="store_true", help="run each grasp through the standard protocol")
    parser.add_argument("--run", help="a stored run of dexopt: its trials' hold margins against their outcomes")
    parser.add_argument("--config", help="the run's config (with --run), the config planned (with --closes): a path "
                        "or a shipped config's name")
    parser.add_argument("--closes", action="store_true",
                        help="with --config: how many of each group's candidates close well (module docstring)")
    parser.add_argument("--only", nargs="*", default=[], help="with --closes: groups whose hand/object contains these")
    parser.add_argument("--per-candidate", action="store_true",
                        help="with --closes: each candidate's energy terms, margin and simulated close")
    parser.add_argument("--spheres", nargs="+", metavar="HAND",
                        help="the fingers' real and sphere overlaps along these hands' closing paths")
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                        help="with --run or --closes: planner parameters changed (values read as YAML, "
                             "as `manigrasp bench` overrides: restarts=40 min_hold_margin=1.5)")
    args = parser.parse_args()
    if args.spheres:
        spheres(args.spheres)
        return
    if args.closes:
        if not args.config:
            parser.error("--closes needs --config")
        closes(args.config, args.only, apply_overrides({}, args.set), args.per_candidate)
        return
    if args.run:
        if not args.config:
            parser.error("--run needs --config")
        hold_vs_outcome(args.run, args.config, apply_overrides({}, args.set))
        return
    print(f"# dexopt: restarts {args.restarts}, iterations {args.iterations}, {args.grasps} grasps per call, seed "
          f"{args.seed}; {platform.processor() or platform.machine()}, OMP_NUM_THREADS="
          f"{os.environ['OMP_NUM_THREADS']}")
    header = (f"{'hand':<14} {'object':<20} {'grasps':>6} {'cpu/grasp':>9} {'wall':>6} {'pen max':>7} {'mean':>5} "
              f"{'div mm':>6} {'deg':>5} {'pads<2mm':>8} {'hold':>4} {'median':>6}  success / statuses; "
              "rejected restarts")
    print(header)
    totals: dict[str, list] = {}
    for hand in args.hands:
        for obj in args.objects:
            r = run(hand, obj, args)
            per = r["cpu"] / r["n"] if r["n"] else float("nan")
            success = r["statuses"].get("success", 0)
            trials = f"{success}/{sum(r['statuses'].values())} {dict(r['statuses'])}" if args.trials else "-"
            print(f"{hand:<14} {obj:<20} {r['n']:>6} {per:>9.2f} {r['wall']:>6.1f} {r['pen_max']:>7.2f} "
                  f"{r['pen_mean']:>5.2f} {r['div'][0]:>6.0f} {r['div'][1]:>5.0f} {r['pads']:>8.1f} "
                  f"{sum(h >= 1 for h in r['holds']):>4} {np.median(r['holds']) if r['holds'] else np.nan:>6.2f}  "
                  f"{trials}; "
                  f"{r['rejected']}", flush=True)
            t = totals.setdefault(hand, [0, 0.0, 0, 0])
            t[0] += r["n"]
            t[1] += r["cpu"]
            t[2] += success
            t[3] += sum(r["statuses"].values())
    for hand, (n, cpu, success, trials) in totals.items():
        rate = f", success {success}/{trials}" if args.trials else ""
        print(f"{hand}: {n} grasps, {cpu / max(n, 1):.2f} s CPU per grasp{rate}")


if __name__ == "__main__":
    main()
