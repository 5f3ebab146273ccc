"""A random grasp policy on manigrasp's dm_env environment (docs/learning.md).

Each episode settles one object at a random yaw and place; the policy aims the TCP at
the centroid of the observed surface points, moved by a random horizontal offset
(normal, `--noise` [m] per axis), approaching from above with a random jaw yaw, and
the benchmark's protocol judges the grasp: reward 1.0 for success, 0.0 otherwise.
The policy reads only the points, never the object's true pose. A learned policy
reads the same observation and should beat this baseline.

    python examples/dm_env_random_policy.py --object 061_foam_brick --episodes 20 --seed 0
"""

from __future__ import annotations

import argparse

import numpy as np

from manigrasp.env import GraspEnv


def random_top_grasp(observation: dict, rng: np.random.Generator, noise: float) -> dict:
    """A world-frame action: the TCP at the points' centroid + a random horizontal offset, approach -z."""
    position = observation["points"].mean(axis=0)
    position[:2] += rng.normal(0.0, noise, 2)
    yaw = rng.uniform(0.0, np.pi)
    # 180 deg about x (approach down), then `yaw` about the world z: q = (cos(yaw/2) k) * (0, 1, 0, 0)
    quaternion = np.array([0.0, np.cos(yaw / 2), np.sin(yaw / 2), 0.0])
    return {"position": position, "quaternion": quaternion, "preshape": np.float64(0.0)}


def main(argv: list[str] | None = None) -> float:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--object", default="061_foam_brick", help="a shipped object name")
    parser.add_argument("--hand", default="parallel_jaw")
    parser.add_argument("--protocol", default="standard")
    parser.add_argument("--points", default="mesh", choices=("mesh", "depth"),
                        help="observed points: mesh samples, or a depth cloud (the perception extra)")
    parser.add_argument("--noise", type=float, default=0.015, help="std of the TCP's horizontal offset [m]")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    env = GraspEnv(args.object, args.hand, protocol=args.protocol, points=args.points, seed=args.seed,
                   yaw_range=np.pi, position_range=0.05)
    policy_rng = np.random.default_rng(args.seed)
    rewards = []
    for episode in range(args.episodes):
        timestep = env.reset()
        timestep = env.step(random_top_grasp(timestep.observation, policy_rng, args.noise))
        rewards.append(timestep.reward)
        result = env.last_result
        print(f"episode {episode:3d}  reward {timestep.reward:.0f}  {result.status:<18} {result.detail[:60]}")
    rate = float(np.mean(rewards))
    print(f"success rate of the random policy: {rate:.2f} over {args.episodes} episodes "
          f"({args.object}, {args.hand}, {args.protocol})")
    return rate


if __name__ == "__main__":
    main()
