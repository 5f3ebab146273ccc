"""Grasp force optimisation: the contact forces that balance an object (and a load on it) with the least friction.

Kerr and Roth, "Analysis of multifingered hands", IJRR 1986; Buss, Hashimoto and Moore, "Dextrous hand grasping
force optimization", IEEE T-RA 1996. Used twice: the `dexopt` planner squeezes with them (`balanced_squeeze`),
and the protocols' `finger_hold: balanced` presses them at the contacts a fully actuated hand's close reached
(`manigrasp.protocol.phases.balanced_torques`). Pure NumPy/SciPy.
"""

from __future__ import annotations

import numpy as np

from manigrasp.geometry import perpendicular_basis

TANGENT_SIDES = 8  # sides of the polygon bounding each tangential force in `balanced_forces`' LP


def balanced_forces(points: np.ndarray, normals: np.ndarray, center: np.ndarray, floor: float = 0.3,
                    load: np.ndarray | None = None, friction: float | np.ndarray | None = None
                    ) -> np.ndarray | None:
    """(k, 3) contact forces on the object that balance it with the least friction: sum_i f_i + load = 0 and
    sum_i (x_i - c) x f_i = 0 about `center` (3,) (the load acts there: a weight at the centre of mass), with the
    least sum_i |t_i| of their tangential parts, each contact's normal part a_i = f_i . n_i at least `floor` and
    their mean 1. Without a load, internal forces (the least friction ratio sum_i |t_i| / sum_i a_i,
    `manigrasp.planners.dexopt.squeeze_friction`'s measure). None if no such forces exist (fewer than two
    contacts, normals that cannot oppose each other, or, with `friction`, none keeping every |t_i| <= friction
    a_i).

    Args:
        points: (k, 3) contact points [m].
        normals: (k, 3) inward normals (into the object).
        center: (3,) the point the load acts at and torques are taken about [m].
        floor: least normal part of each contact, in units of their mean [-], in [0, 1).
        load: (3,) force on the object besides the contacts (e.g. its weight m g), in units of the mean normal
            force (None: none).
        friction: largest friction ratio |t_i| / a_i of each contact [-] (a scalar for all, or (k,); None:
            unbounded).

    One linear programme (HiGHS): each |t_i| is bounded by a `TANGENT_SIDES`-gon circumscribing its circle
    (within cos(pi / 8) = 0.92 of the true norm).
    """
    from scipy.optimize import linprog

    x = np.atleast_2d(np.asarray(points, float))
    n = np.atleast_2d(np.asarray(normals, float))
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    k = len(x)
    if k < 2 or not 0 <= floor < 1 or not (np.all(np.isfinite(x)) and np.all(np.isfinite(n))):
        return None
    bound = None if friction is None else np.broadcast_to(np.asarray(friction, float), (k,))
    u, v = perpendicular_basis(n)
    arm = x - np.asarray(center, float)
    arm = arm / max(float(np.linalg.norm(arm, axis=1).max()), 1e-9)
    # Variables: a (k), p (k), q (k), s (k); f_i = a_i n_i + p_i u_i + q_i v_i, |(p_i, q_i)| <= s_i.
    columns = np.concatenate([n, u, v], axis=0)  # (3k, 3): the force direction of each of a, p, q
    force = np.zeros((3, 4 * k))
    torque = np.zeros((3, 4 * k))
    for block in range(3):
        for i in range(k):
            direction = columns[block * k + i]
            force[:, block * k + i] = direction
            torque[:, block * k + i] = np.cross(arm[i], direction)
    total = np.zeros((1, 4 * k))
    total[0, :k] = 1.0
    a_eq = np.concatenate([force, torque, total])
    outer = np.zeros(3) if load is None else -np.asarray(load, float)
    b_eq = np.concatenate([outer, np.zeros(3), [float(k)]])
    angles = 2 * np.pi * np.arange(TANGENT_SIDES) / TANGENT_SIDES
    rows = []
    for i in range(k):
        for angle in angles:  # cos(t) p_i + sin(t) q_i - cos(pi / sides) s_i <= 0
            row = np.zeros(4 * k)
            row[k + i], row[2 * k + i], row[3 * k + i] = np.cos(angle), np.sin(angle), -np.cos(np.pi / TANGENT_SIDES)
            rows.append(row)
        if bound is not None:  # s_i - friction_i a_i <= 0
            row = np.zeros(4 * k)
            row[3 * k + i], row[i] = 1.0, -float(bound[i])
            rows.append(row)
    cost = np.concatenate([np.zeros(3 * k), np.ones(k)])
    bounds = [(floor, None)] * k + [(None, None)] * (2 * k) + [(0, None)] * k
    found = linprog(cost, A_ub=np.array(rows), b_ub=np.zeros(len(rows)), A_eq=a_eq, b_eq=b_eq, bounds=bounds,
                    method="highs")
    if found.status != 0:
        return None
    a, p, q = found.x[:k], found.x[k:2 * k], found.x[2 * k:3 * k]
    return a[:, None] * n + p[:, None] * u + q[:, None] * v
