"""Microseconds per grasp for force closure and L1 epsilon (8-edge cones).

Run: .venv/bin/python benchmarks/bench_grasp_metrics.py [--batch 10000]

Grasps are random hard-finger contacts on a 5 cm sphere with inward normals
and mu = 0.5 (seeded), then parallel-jaw grasps of two flat pads with four
soft contacts each, as the simulation reports them (the case where Qhull
needs joggling). Reports wall-clock and process CPU time per grasp: on a
shared machine the CPU time is the steadier figure. BLAS is pinned to one thread
(unless OPENBLAS_NUM_THREADS is already set) so that small matrix products do
not fight over the two cores.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402

from manigrasp.contact import ContactSet  # noqa: E402
from manigrasp.grasp import ferrari_canny, ferrari_canny_batch, force_closure, force_closure_batch  # noqa: E402
from manigrasp.grasp.facets import candidate_count  # noqa: E402
from manigrasp.grasp.quality import MAX_CANDIDATES  # noqa: E402

RADIUS = 0.05


def grasps(rng: np.random.Generator, b: int, n: int) -> ContactSet:
    """B random n-contact hard-finger grasps on a sphere of radius RADIUS."""
    p = rng.normal(size=(b, n, 3))
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    return ContactSet(RADIUS * p, -p, 0.5)


def flat_pads(rng: np.random.Generator, b: int, per_pad: int = 4) -> ContactSet:
    """B parallel-jaw grasps: two opposite flat pads of `per_pad` soft contacts each, as the simulation
    reports them (one pad's normals equal up to ~1e-13, pads tilted by ~1e-4 rad), about the origin."""
    n = np.array([-1.0, 1e-4, 0.0]) / np.hypot(1.0, 1e-4)  # pad 1's inward normal; pad 2's is -n
    u = np.cross(n, [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    side = np.repeat([1.0, -1.0], per_pad)[:, None]
    yz = rng.uniform(-0.02, 0.02, (b, 2 * per_pad, 2))
    positions = -side * n * RADIUS / 2 + yz[..., :1] * u + yz[..., 1:] * v
    normals = side * n + rng.normal(0.0, 1e-13, (b, 2 * per_pad, 3))
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    return ContactSet(positions, normals, 0.5, "soft_finger", 0.005)


def per_grasp(call: Callable[[], object], count: int) -> tuple[float, float]:
    """(wall, cpu) microseconds per grasp of one run of `call` over `count` grasps."""
    wall, cpu = time.perf_counter(), time.process_time()
    call()
    return (1e6 * (time.perf_counter() - wall) / count, 1e6 * (time.process_time() - cpu) / count)


def singles(cs: ContactSet, k: int) -> list[ContactSet]:
    """The first k grasps of `cs` as one-grasp sets."""
    return [ContactSet(cs.positions[b : b + 1], cs.normals[b : b + 1], 0.5) for b in range(k)]


def row(label: str, count: int, timing: tuple[float, float]) -> None:
    print(f"{label:<44} {count:>6} {timing[0]:>10.1f} {timing[1]:>10.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=10_000, help="grasps per batched call")
    parser.add_argument("--single", type=int, default=200, help="grasps timed one call each")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    center = np.zeros(3)
    print(f"BLAS threads: OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}")
    print(f"{'case':<44} {'grasps':>6} {'wall us':>10} {'cpu us':>10}")
    for n in (2, 3, 5):
        cands = candidate_count(grasps(rng, 1, n).kind, 8, n, "L1")
        path = "enumerate" if cands <= MAX_CANDIDATES else "qhull"
        batch = args.batch if path == "enumerate" else min(args.batch, 300)
        cs = grasps(rng, batch, n)
        one = singles(cs, args.single if path == "enumerate" else 50)
        eps = ferrari_canny_batch(cs, center, RADIUS)
        print(f"-- {n} contacts: {cands} candidate normals -> {path}; "
              f"{np.mean(eps > 0):.0%} in closure, mean eps {eps.mean():.4f}")
        row(f"L1 epsilon, batched ({path})", batch,
            per_grasp(lambda: ferrari_canny_batch(cs, center, RADIUS), batch))  # noqa: B023
        row("force closure, batched (eps > tol)", batch,
            per_grasp(lambda: force_closure_batch(cs, center, RADIUS), batch))  # noqa: B023
        row("L1 epsilon, single calls", len(one),
            per_grasp(lambda: [ferrari_canny(g, center, RADIUS) for g in one], len(one)))  # noqa: B023
        row("force closure, single calls (HiGHS LP)", len(one),
            per_grasp(lambda: [force_closure(g, center, RADIUS) for g in one], len(one)))  # noqa: B023
    pads = flat_pads(rng, 50)
    eps = ferrari_canny_batch(pads, center, RADIUS)
    print(f"-- two flat pads of 4 soft contacts (80 primitives) -> qhull; "
          f"{np.mean(eps > 0):.0%} in closure, mean eps {eps.mean():.4f}")
    row("L1 epsilon, batched (qhull)", 50, per_grasp(lambda: ferrari_canny_batch(pads, center, RADIUS), 50))
    one = [ContactSet(pads.positions[b : b + 1], pads.normals[b : b + 1], 0.5, "soft_finger", 0.005)
           for b in range(50)]
    row("force closure, single calls (HiGHS LP)", 50,
        per_grasp(lambda: [force_closure(g, center, RADIUS) for g in one], 50))


if __name__ == "__main__":
    main()
