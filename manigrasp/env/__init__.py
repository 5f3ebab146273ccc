"""Learning on manigrasp: one grasp trial of the benchmark as a `dm_env` environment.

    >>> from manigrasp.env import GraspEnv
    >>> env = GraspEnv("061_foam_brick", "parallel_jaw", seed=0, yaw_range=np.pi)
    >>> first = env.reset()                       # the object settled; its pose and surface points
    >>> last = env.step({"position": p, "quaternion": q, "preshape": np.float64(0.0)})
    >>> last.reward, env.last_result.status       # 1.0 / "success", or 0.0 and the failure mode

Each episode is one grasp (a contextual bandit: the setting of learned grasp
samplers), judged by the same scene, protocol and success criteria as a
benchmark trial. manigrasp depends on `dm-env` for this (not on dm-control: nothing uses its code).
"""

from manigrasp.env.grasp import GraspEnv, load_asset
from manigrasp.env.points import POINT_SOURCES
from manigrasp.env.spaces import ACTION_FRAMES, action_spec, observation_spec

__all__ = ["ACTION_FRAMES", "POINT_SOURCES", "GraspEnv", "action_spec", "load_asset", "observation_spec"]
