"""`dexopt`: the energy of optimisation-based dexterous grasp synthesis and its analytic gradient.

The energy follows DexGraspNet (Wang et al., 2023), with the differentiable force-closure estimate of Liu et al.
(2021), over a hand configuration whose contact points x_i (n, 3) [m] are points fixed on the hand's links
(e.g. fingertip pads) and whose surface samples p_j (m, 3) cover its collision geometry:

    E = w_fc E_fc + w_dis E_dis + w_pen E_pen + w_table E_table + w_joint E_joint

- force closure: E_fc = |G n|^2 = |sum_i n_i|^2 + |sum_i x_i x n_i|^2, with n_i = -grad d(x_i) the inward
  surface normal at x_i (d: the object's signed distance, negative inside) and G = [I ...; [x_i]x ...] the
  grasp matrix: zero when unit forces along the normals balance in force and torque (Liu et al.'s estimate,
  squared here so that it is smooth);
- contact distance: E_dis = sum_i d(x_i)^2 (the contact points on the surface);
- penetration: E_pen = sum_j max(0, -d(p_j)) (hand samples inside the object, by depth);
- table: E_table = sum_j max(0, z_table - p_j,z) (hand samples below the table top);
- joint limits: E_joint = sum_k max(0, q_k - hi_k) + max(0, lo_k - q_k).

Weights (`EnergyWeights`) default to DexGraspNet's relative scale (distance and penetration 100 x force closure);
they also weigh two terms the planner adds (the fingers' mutual penetration and the pads' centroid off the centre
of mass, `dexopt_planner`), which has its own defaults.
Every term returns its value and its gradient with respect to the points (or joints) in closed form, including
the normals' dependence on the points through the signed distance's Hessian; `chain_to_dofs` takes a points'
gradient to the hand's generalised coordinates with MuJoCo's Jacobians (`mj_jac`), so a descent step is
``mj_integratePos(model, qpos, -step * g, 1)`` on a hand mounted on a free joint.

`hold_margin` is the planner's load test (not a term of the energy): one linear programme over contact forces
in linearised friction cones (`friction_pyramid`) with per-contact normal-force caps (what the hand's squeeze
presses each contact with) that must balance the object's weight and the protocol's perturbations.
`squeeze_friction` is how much friction the squeeze alone uses: the contact forces that best produce the
squeeze's joint torques while balancing the object among themselves (internal forces), their tangential over
their normal parts (recorded per grasp, `Synthesis.friction_used`; not a term, not a ranking).
`grasp_stiffness` (Cutkosky & Kao, 1989) and `load_rotation` estimate how far a held object turns and moves in
the hand under those loads (the contacts and the finger servos as springs; no slip, no preload term); the
planner records it per grasp (`Synthesis.rotation`), it does not select on it.

The planner (restarts, the batched descent, the pads, the MuJoCo checks, the squeeze direction) is
`manigrasp.planners.dexopt_planner` (registered as ``dexopt``); it evaluates these terms batched over restarts
on `GridSdf`, the signed distance of the object's convex parts sampled on a grid.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from manigrasp.errors import ConfigError


@dataclass(frozen=True)
class EnergyWeights:
    """Weights of the energy's terms [-] (see the module docstring)."""

    force_closure: float = 1.0
    distance: float = 100.0
    penetration: float = 100.0
    table: float = 100.0
    joints: float = 10.0
    self_penetration: float = 100.0
    centroid: float = 0.0

    def __post_init__(self) -> None:
        for name in ("force_closure", "distance", "penetration", "table", "joints", "self_penetration", "centroid"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ConfigError(f"EnergyWeights.{name} must be finite and >= 0, got {value}")


class Shape(Protocol):
    """A solid with an exact signed distance (negative inside), its gradient and Hessian."""

    def sdf(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(n,) distances [m], (n, 3) gradients and (n, 3, 3) Hessians at `points` (n, 3)."""
        ...


@dataclass(frozen=True)
class Sphere:
    """Sphere of `radius` [m] about `centre` (3,)."""

    centre: tuple[float, float, float]
    radius: float

    def sdf(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        rel = np.atleast_2d(points) - np.asarray(self.centre, float)
        norm = np.linalg.norm(rel, axis=1)
        safe = np.maximum(norm, 1e-12)
        unit = rel / safe[:, None]
        hess = (np.eye(3)[None] - unit[:, :, None] * unit[:, None, :]) / safe[:, None, None]
        return norm - self.radius, unit, hess


@dataclass(frozen=True)
class Box:
    """Box of half extents `half` (3,) [m] centred at `centre`, rotated by `rotation` (3, 3) (box -> world)."""

    centre: tuple[float, float, float]
    half: tuple[float, float, float]
    rotation: np.ndarray | None = None

    def sdf(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        rot = np.eye(3) if self.rotation is None else np.asarray(self.rotation, float)
        local = (np.atleast_2d(points) - np.asarray(self.centre, float)) @ rot
        sign = np.where(local < 0, -1.0, 1.0)
        q = np.abs(local) - np.asarray(self.half, float)
        outside = np.maximum(q, 0.0)
        out_norm = np.linalg.norm(outside, axis=1)
        n = len(local)
        dist = np.empty(n)
        grad = np.zeros((n, 3))
        hess = np.zeros((n, 3, 3))
        out = out_norm > 0
        # Outside: distance to the nearest face, edge or corner: |max(q, 0)|; its Hessian lives on the axes
        # that are outside (an edge's distance curves about the edge, a face's is flat).
        if out.any():
            u = outside[out] / out_norm[out, None]
            dist[out] = out_norm[out]
            grad[out] = sign[out] * u
            mask = (q[out] > 0).astype(float)
            proj = mask[:, :, None] * np.eye(3)[None] * mask[:, None, :] - u[:, :, None] * u[:, None, :]
            hess[out] = sign[out][:, :, None] * proj * sign[out][:, None, :] / out_norm[out, None, None]
        inside = ~out
        if inside.any():  # inside (or on the surface): minus the distance to the nearest face; flat
            axis = np.argmax(q[inside], axis=1)
            dist[inside] = q[inside][np.arange(inside.sum()), axis]
            g = np.zeros((inside.sum(), 3))
            g[np.arange(inside.sum()), axis] = sign[inside][np.arange(inside.sum()), axis]
            grad[inside] = g
        return dist, grad @ rot.T, np.einsum("ij,njk,lk->nil", rot, hess, rot)


@dataclass(frozen=True, eq=False)
class GridSdf:
    """A signed distance sampled on a regular grid, read by trilinear interpolation.

    `values` (nx, ny, nz) [m] at ``origin + spacing * (i, j, k)``. Inside the grid the distance and its
    gradient are those of the trilinear interpolant (exact on planes, O(spacing^2) error on curved surfaces);
    the Hessian is the central difference of that gradient over one grid step (the interpolant's own is
    piecewise constant). Outside the grid, a point's distance is the one at its nearest grid point plus the
    distance to it (an upper bound), its gradient the direction away from the grid.
    """

    origin: np.ndarray
    spacing: float
    values: np.ndarray
    solid: tuple[np.ndarray, np.ndarray] | None = None  # (lo, hi) box holding every negative value, if known

    @classmethod
    def from_convex_parts(cls, parts: list[np.ndarray], spacing: float, margin: float) -> GridSdf:
        """The grid of the union of the convex hulls of `parts` (each (v, 3) vertices [m]) over their bounding
        box grown by `margin` [m], `spacing` [m] apart.

        Inside a part the distance is exact (minus the distance to its nearest face plane); outside every
        part it is the Euclidean distance to the nearest part, from open3d's ray-casting scene over the parts'
        hull triangles (exact). Inside the union, the depth is the largest depth into any one part (the union's
        own depth can be larger where parts overlap: a lower bound).
        """
        import open3d as o3d
        import scipy.spatial

        vertices = np.concatenate(parts)
        lo, hi = vertices.min(axis=0) - margin, vertices.max(axis=0) + margin
        axes = [np.arange(a, b + spacing, spacing) for a, b in zip(lo, hi, strict=True)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        scene = o3d.t.geometry.RaycastingScene()
        depth = np.zeros(len(grid))
        for verts in parts:
            verts = np.asarray(verts, float)
            hull = scipy.spatial.ConvexHull(verts)
            scene.add_triangles(o3d.core.Tensor(verts.astype(np.float32)),
                                o3d.core.Tensor(hull.simplices.astype(np.uint32)))
            sel = np.flatnonzero(np.all((grid >= verts.min(axis=0)) & (grid <= verts.max(axis=0)), axis=1))
            # hull.equations: (normal, offset) rows with normal @ x + offset <= 0 inside.
            inner = -np.max(grid[sel] @ hull.equations[:, :3].T + hull.equations[:, 3], axis=1)
            depth[sel] = np.maximum(depth[sel], inner)
        outside = scene.compute_distance(o3d.core.Tensor(grid.astype(np.float32))).numpy().astype(float)
        values = np.where(depth > 0, -depth, outside).reshape(tuple(len(a) for a in axes))
        return cls(origin=lo, spacing=float(spacing), values=values,
                   solid=(vertices.min(axis=0) - spacing, vertices.max(axis=0) + spacing))

    def penetrating(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Indices (j,) of the `points` (n, 3) inside the solid, their distances (j,) (< 0) and gradients (j, 3).

        Only points in the `solid` box are interpolated (the rest cannot be inside).
        """
        p = np.atleast_2d(np.asarray(points, float))
        if self.solid is None:
            near = np.arange(len(p))
        else:  # per coordinate: np.all over a length-3 axis costs more than the six comparisons
            lo, hi = self.solid
            x, y, z = p[:, 0], p[:, 1], p[:, 2]
            near = np.flatnonzero((x >= lo[0]) & (x <= hi[0]) & (y >= lo[1]) & (y <= hi[1])
                                  & (z >= lo[2]) & (z <= hi[2]))
        dist, grad = self.distance(p[near])
        inside = dist < 0
        return near[inside], dist[inside], grad[inside]

    def distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n,) distances [m] and (n, 3) gradients at `points` (n, 3)."""
        p = np.atleast_2d(np.asarray(points, float))
        shape = np.array(self.values.shape)
        upper = self.origin + self.spacing * (shape - 1)
        inside = np.clip(p, self.origin, upper)
        cell = (inside - self.origin) / self.spacing
        idx = np.clip(np.floor(cell).astype(int), 0, shape - 2)
        t = cell - idx
        nx, ny, nz = self.values.shape
        base = (idx[:, 0] * ny + idx[:, 1]) * nz + idx[:, 2]
        corners = np.array([(a * ny + b) * nz + e for a in (0, 1) for b in (0, 1) for e in (0, 1)])
        c = self.values.ravel()[base[:, None] + corners].reshape(-1, 2, 2, 2)
        tx, ty, tz = t[:, 0, None, None], t[:, 1, None], t[:, 2]
        cx = c[:, 0] * (1 - tx) + c[:, 1] * tx  # (n, 2, 2) over y, z
        cxy = cx[:, 0] * (1 - ty) + cx[:, 1] * ty  # (n, 2) over z
        dist = cxy[:, 0] * (1 - tz) + cxy[:, 1] * tz
        dz = cxy[:, 1] - cxy[:, 0]
        dy_ = cx[:, 1] - cx[:, 0]
        dy = dy_[:, 0] * (1 - tz) + dy_[:, 1] * tz
        dx_ = c[:, 1] - c[:, 0]  # (n, 2, 2)
        dx1 = dx_[:, 0] * (1 - ty) + dx_[:, 1] * ty
        dx = dx1[:, 0] * (1 - tz) + dx1[:, 1] * tz
        grad = np.stack([dx, dy, dz], axis=1) / self.spacing
        away = p - inside
        gap = np.linalg.norm(away, axis=1)
        out = gap > 0
        if out.any():
            dist[out] += gap[out]
            grad[out] = away[out] / gap[out, None]
        return dist, grad

    def sdf(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(n,) distances, (n, 3) gradients and (n, 3, 3) Hessians (central differences of the gradient)."""
        p = np.atleast_2d(np.asarray(points, float))
        dist, grad = self.distance(p)
        h = self.spacing
        steps = np.concatenate([p[:, None] + h * np.eye(3)[None], p[:, None] - h * np.eye(3)[None]], axis=1)
        _, g = self.distance(steps.reshape(-1, 3))
        g = g.reshape(len(p), 6, 3)
        hess = (g[:, :3] - g[:, 3:]).transpose(0, 2, 1) / (2 * h)  # hess[n, i, k] = d grad_i / d x_k
        return dist, grad, 0.5 * (hess + hess.transpose(0, 2, 1))


def force_closure(points: np.ndarray, shape: Shape) -> tuple[float, np.ndarray]:
    """E_fc = |sum n_i|^2 + |sum x_i x n_i|^2 with n_i = -grad d(x_i); returns (E, dE/dx (n, 3))."""
    x = np.atleast_2d(np.asarray(points, float))
    _, grad, hess = shape.sdf(x)
    normal, d_normal = -grad, -hess  # dn_i/dx_i = -Hessian
    force = normal.sum(axis=0)
    torque = np.cross(x, normal).sum(axis=0)
    energy = float(force @ force + torque @ torque)
    # d(x cross n)/dx = -[n]x + [x]x dn/dx; the gradient is 2 (dn/dx^T f + d(x cross n)/dx^T t).
    d_cross = -_skew(normal) + np.einsum("nij,njk->nik", _skew(x), d_normal)
    gradient = 2.0 * (np.einsum("nji,j->ni", d_normal, force) + np.einsum("nji,j->ni", d_cross, torque))
    return energy, gradient


def contact_distance(points: np.ndarray, shape: Shape) -> tuple[float, np.ndarray]:
    """E_dis = sum d(x_i)^2; returns (E, dE/dx (n, 3))."""
    dist, grad, _ = shape.sdf(np.atleast_2d(np.asarray(points, float)))
    return float(dist @ dist), 2.0 * dist[:, None] * grad


def penetration(samples: np.ndarray, shape: Shape) -> tuple[float, np.ndarray]:
    """E_pen = sum max(0, -d(p_j)): total depth [m] of the hand samples inside the object; (E, dE/dp (m, 3))."""
    dist, grad, _ = shape.sdf(np.atleast_2d(np.asarray(samples, float)))
    inside = dist < 0
    return float(-dist[inside].sum()), np.where(inside[:, None], -grad, 0.0)


def table_penetration(samples: np.ndarray, table_z: float = 0.0) -> tuple[float, np.ndarray]:
    """E_table = sum max(0, table_z - p_j,z) [m]; returns (E, dE/dp (m, 3))."""
    p = np.atleast_2d(np.asarray(samples, float))
    below = p[:, 2] < table_z
    gradient = np.zeros_like(p)
    gradient[below, 2] = -1.0
    return float((table_z - p[below, 2]).sum()), gradient


def joint_limits(q: np.ndarray, low: np.ndarray, high: np.ndarray) -> tuple[float, np.ndarray]:
    """E_joint = sum max(0, q - hi) + max(0, lo - q) [rad]; returns (E, dE/dq)."""
    q, low, high = (np.asarray(v, float) for v in (q, low, high))
    over, under = np.maximum(q - high, 0.0), np.maximum(low - q, 0.0)
    return float(over.sum() + under.sum()), (q > high).astype(float) - (q < low).astype(float)


def energy(contacts: np.ndarray, samples: np.ndarray, q: np.ndarray, low: np.ndarray, high: np.ndarray,
           shape: Shape, weights: EnergyWeights = EnergyWeights(), table_z: float | None = 0.0,
           ) -> tuple[float, dict[str, float], np.ndarray, np.ndarray, np.ndarray]:
    """The weighted energy, its terms, and its gradients w.r.t. `contacts`, `samples` and `q`."""
    e_fc, g_fc = force_closure(contacts, shape)
    e_dis, g_dis = contact_distance(contacts, shape)
    e_pen, g_pen = penetration(samples, shape)
    e_tab, g_tab = table_penetration(samples, table_z) if table_z is not None else (0.0, np.zeros_like(samples))
    e_jnt, g_jnt = joint_limits(q, low, high)
    w = weights
    terms = {"force_closure": e_fc, "distance": e_dis, "penetration": e_pen, "table": e_tab, "joints": e_jnt}
    total = (w.force_closure * e_fc + w.distance * e_dis + w.penetration * e_pen + w.table * e_tab
             + w.joints * e_jnt)
    return (float(total), terms, w.force_closure * g_fc + w.distance * g_dis,
            w.penetration * g_pen + w.table * g_tab, w.joints * g_jnt)


def chain_to_dofs(model, data, bodies: np.ndarray, points: np.ndarray, gradient: np.ndarray) -> np.ndarray:
    """(nv,) gradient over the model's dofs of a function of world `points` (n, 3) fixed on `bodies` (n,).

    g = sum_i J_i^T dE/dx_i with J_i the translational Jacobian (`mj_jac`) of point i on its body; the
    kinematics of `data` must be current (`mj_kinematics`, `mj_comPos`). A free joint's rotational dofs are
    in its body frame, as `mj_integratePos` expects.
    """
    import mujoco

    jacp = np.zeros((3, model.nv))
    out = np.zeros(model.nv)
    for body, point, grad in zip(np.asarray(bodies, int), np.atleast_2d(points), np.atleast_2d(gradient),
                                 strict=True):
        if not grad.any():
            continue
        mujoco.mj_jac(model, data, jacp, None, np.asarray(point, float), int(body))
        out += jacp.T @ grad
    return out


def _skew(v: np.ndarray) -> np.ndarray:
    """(n, 3, 3) cross-product matrices of the rows of `v` (n, 3): [v]x w = v x w."""
    v = np.atleast_2d(v)
    out = np.zeros((len(v), 3, 3))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out


FREE_COMPLIANCE = 1e6  # a joint no servo holds: this many times the compliance of the stiffest held direction
PYRAMID_EDGES = 8  # edges of the linearised friction cone (`hold_margin`); a multiple of 4 keeps the vertical exact


def friction_pyramid(normals: np.ndarray, mu: float | np.ndarray, edges: int = PYRAMID_EDGES) -> np.ndarray:
    """(k, edges, 3) generators n_i + mu (cos a_j u_i + sin a_j v_i), a_j = 2 pi j / edges, of the pyramids
    inscribed in the friction cones of half-angle atan(mu) about the unit inward `normals` (k, 3).

    u_i is horizontal and v_i = n_i x u_i the world vertical projected onto the tangent plane
    (`perpendicular_basis`), so with `edges` a multiple of 4 the pyramid is exact along the vertical (the
    weight's direction) and the horizontal; elsewhere it keeps at least cos(pi / edges) of the cone's
    friction (conservative). The generators are `contact.cone_edges` with its first tangent u_i."""
    from manigrasp.contact import cone_edges
    from manigrasp.geometry import perpendicular_basis

    n = np.atleast_2d(np.asarray(normals, float))
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    return cone_edges(n, mu, edges, tangents=perpendicular_basis(n)[0])


def hold_margin(points: np.ndarray, normals: np.ndarray, caps: np.ndarray, center: np.ndarray, loads: np.ndarray,
                mu: float | np.ndarray, torsion: float = 0.0, edges: int = PYRAMID_EDGES) -> float:
    """The factor h by which every one of `loads` could grow and still be held by contact forces the hand can press.

    Contacts at `points` (k, 3) [m] with inward unit `normals` (k, 3) press with normal forces f_i in [0, caps_i]
    [N] (what the hand's squeeze can give each contact); each contact force lies in its linearised friction cone
    (`friction_pyramid`, sliding friction `mu`, one for all or (k,) one per contact), and a soft contact adds a
    torque about its normal of at most `torsion` [m] x f_i. Each load (L, 3) [N] acts at `center` (3,) [m] (a force
    through the centre of mass: the weight, a perturbation). One linear programme (scipy's HiGHS) finds the smallest
    t such that every load is balanced, sum_i f_i = -F and sum_i (x_i - c) x f_i + tau_i n_i = 0, with f_i . n_i <=
    t caps_i; h = 1 / t (inf if nothing is required, 0 if no forces in the cones balance some load).
    h >= 1: the grasp holds every load at its squeeze; homogeneous (h doubles with the caps, halves with the
    loads).
    """
    from scipy.optimize import linprog

    x = np.atleast_2d(np.asarray(points, float))
    n = np.atleast_2d(np.asarray(normals, float))
    caps = np.asarray(caps, float)
    loads = np.atleast_2d(np.asarray(loads, float))
    if len(x) != len(n) or len(caps) != len(x):
        raise ConfigError(f"hold_margin: {len(x)} points, {len(n)} normals and {len(caps)} caps differ")
    mu = np.asarray(mu, float)
    if mu.ndim > 0 and mu.shape != (len(x),):
        raise ConfigError(f"hold_margin: {mu.size} frictions for {len(x)} points")
    if np.any(mu < 0) or torsion < 0 or np.any(caps < 0):
        raise ConfigError("hold_margin: mu, torsion and caps must be >= 0")
    loads = loads[np.linalg.norm(loads, axis=1) > 0]
    if len(loads) == 0:
        return float("inf")
    k = len(x)
    if k == 0:
        return 0.0
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    gen = friction_pyramid(n, mu, edges).reshape(k * edges, 3)  # force generators
    arm = np.repeat(x - np.asarray(center, float), edges, axis=0)
    wrench = np.concatenate([gen, np.cross(arm, gen)], axis=1).T  # (6, k E)
    # Per load: k E cone weights, then k torsion torques (+ and -); the last variable is t.
    per = k * edges + 2 * k
    twist = np.concatenate([np.zeros((3, k)), n.T], axis=0)  # (6, k): unit torsion of each contact
    block_eq = np.concatenate([wrench, twist, -twist], axis=1)  # (6, per)
    normal = np.kron(np.eye(k), np.ones(edges))  # (k, k E): f_i . n_i = sum of its weights (n . gen = 1)
    cap_rows = np.concatenate([normal, np.zeros((k, 2 * k))], axis=1)  # f_i - t caps_i <= 0
    torsion_rows = np.concatenate([-torsion * normal, np.eye(k), np.eye(k)], axis=1)  # |tau_i| <= torsion f_i
    n_loads = len(loads)
    a_eq = np.zeros((6 * n_loads, per * n_loads + 1))
    a_ub = np.zeros((2 * k * n_loads, per * n_loads + 1))
    b_eq = np.zeros(6 * n_loads)
    for j, force in enumerate(loads):
        cols = slice(j * per, (j + 1) * per)
        a_eq[6 * j:6 * j + 6, cols] = block_eq
        b_eq[6 * j:6 * j + 3] = -force
        a_ub[2 * k * j:2 * k * j + k, cols] = cap_rows
        a_ub[2 * k * j:2 * k * j + k, -1] = -caps
        a_ub[2 * k * j + k:2 * k * (j + 1), cols] = torsion_rows
    cost = np.zeros(per * n_loads + 1)
    cost[-1] = 1.0
    result = linprog(cost, A_ub=a_ub, b_ub=np.zeros(len(a_ub)), A_eq=a_eq, b_eq=b_eq, bounds=(0, None),
                     method="highs")
    if result.status != 0:  # infeasible: no forces in the cones balance some load, whatever the squeeze
        return 0.0
    t = float(result.x[-1])
    return float("inf") if t <= 0 else 1.0 / t


def grasp_stiffness(points: np.ndarray, normals: np.ndarray, jacobians: np.ndarray, joint_stiffness: np.ndarray,
                    center: np.ndarray, contact_stiffness: float, torsion_stiffness: float = 0.0) -> np.ndarray:
    """(6, 6) stiffness of a held object about `center` [N/m, N, N m/rad] (Cutkosky & Kao, 1989, without the
    preload's geometric term): K = G (C + J K_q^-1 J^T)^-1 G^T.

    The contacts at `points` (k, 3) [m] do not slip (point contacts with friction): each moves with the object,
    dx_i = dp + dtheta x (x_i - c), against the series of its own compliance C_i = I / `contact_stiffness`
    [N/m] (the pad) and the fingers', J K_q^-1 J^T: `jacobians` (k, 3, n) of the contact points over the hand's
    n joints, `joint_stiffness` (n, n) [N m/rad] (the servos' A^T diag(kp) A; a joint no servo holds has a
    zero row: it gives way, and so do the contacts it moves). G = [I ...; [x_i - c]x ...] is the grasp matrix.
    A soft contact adds `torsion_stiffness` [N m/rad] about its normal `normals` (k, 3) (0: a point contact).
    Directions the contacts cannot hold (e.g. the rotation about the line of a two-point pinch) have K's
    eigenvalue 0.
    """
    x = np.atleast_2d(np.asarray(points, float))
    k = len(x)
    jac = np.asarray(jacobians, float).reshape(3 * k, -1)
    kq = np.asarray(joint_stiffness, float)
    # Joint compliance: the pseudo-inverse on the held joints; a joint direction no servo holds is free, its
    # compliance (numerically) infinite: FREE_COMPLIANCE x the stiffest held direction's.
    w, v = np.linalg.eigh(0.5 * (kq + kq.T))
    top = max(float(w.max(initial=0.0)), 1e-12)
    held = w > 1e-9 * top
    comp_q = (v * np.where(held, 1.0 / np.where(held, w, 1.0), FREE_COMPLIANCE / top)) @ v.T
    compliance = np.eye(3 * k) / contact_stiffness + jac @ comp_q @ jac.T
    kc = np.linalg.inv(0.5 * (compliance + compliance.T))
    grasp = np.zeros((6, 3 * k))
    for i, r in enumerate(x - np.asarray(center, float)):
        grasp[:3, 3 * i:3 * i + 3] = np.eye(3)
        grasp[3:, 3 * i:3 * i + 3] = _skew(r[None])[0]
    stiffness = grasp @ kc @ grasp.T
    if torsion_stiffness > 0:
        n = np.atleast_2d(np.asarray(normals, float))
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        stiffness[3:, 3:] += torsion_stiffness * n.T @ n
    return 0.5 * (stiffness + stiffness.T)


def load_rotation(stiffness: np.ndarray, loads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation [rad] (L,) and translation [m] (L,) of a held object of `stiffness` (6, 6) about its centre of
    mass (`grasp_stiffness`) under each of `loads` (L, 3) [N] through the centre of mass: the linear
    displacement K^-1 (F, 0). A load with a component along a direction the grasp cannot hold (eigenvalue
    below 1e-9 of the largest) moves it without bound (inf)."""
    w, v = np.linalg.eigh(np.asarray(stiffness, float))
    top = max(float(np.abs(w).max(initial=0.0)), 1e-12)
    wrench = np.concatenate([np.atleast_2d(np.asarray(loads, float)), np.zeros((len(np.atleast_2d(loads)), 3))],
                            axis=1)
    along = wrench @ v  # (L, 6) the loads in the eigenbasis
    free = w <= 1e-9 * top
    unbounded = np.any(free[None] & (np.abs(along) > 1e-9 * np.linalg.norm(wrench, axis=1, keepdims=True)),
                       axis=1)
    d = (np.where(free, 0.0, along / np.where(free, 1.0, w))) @ v.T  # (L, 6)
    rotation = np.where(unbounded, np.inf, np.linalg.norm(d[:, 3:], axis=1))
    translation = np.where(unbounded, np.inf, np.linalg.norm(d[:, :3], axis=1))
    return rotation, translation


def squeeze_friction(points: np.ndarray, normals: np.ndarray, jacobians: np.ndarray, torque: np.ndarray,
                     center: np.ndarray) -> float:
    """The friction [-] the squeeze alone uses: sum_i |t_i| / sum_i max(0, f_i . n_i) over the contact forces f_i
    (tangential parts t_i) that best produce the squeeze's joint `torque` (n_q,) while the object stays in
    equilibrium (weightless, nothing else touching it).

    The hand's statics: the fingers press the object with f_i at `points` (k, 3) [m], the joints feel
    sum_i J_i^T f_i, `jacobians` (k, 3, n_q); the object is balanced when sum_i f_i = 0 and
    sum_i (x_i - c) x f_i = 0 about `center` (3,). Among the forces that balance the object (the grasp map's null
    space: the internal forces), the least-squares fit of the joint torques (the servos' forces the joints must
    carry; what the fit leaves over moves the fingers). The ratio is homogeneous of degree zero in `torque`
    (the grip's size does not change it): 0 when the squeeze presses along the inward unit `normals` (k, 3) only,
    1 at a contact force on a cone of friction 1; a contact pulled (normal part <= 0) adds its whole tangential
    part and no normal force (inf if no contact is pressed). It is the planner's estimate of the simulated close's
    `friction_used` (`dexopt_planner.CloseResult`) divided by the friction coefficient.
    """
    from scipy.linalg import null_space

    x = np.atleast_2d(np.asarray(points, float))
    n = np.atleast_2d(np.asarray(normals, float))
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    jac = np.asarray(jacobians, float)
    k = len(x)
    if k < 2:
        return float("inf")
    arm = x - np.asarray(center, float)
    scale = max(float(np.linalg.norm(arm, axis=1).max()), 1e-9)
    grasp = np.concatenate([np.tile(np.eye(3), k), np.concatenate(_skew(arm / scale), axis=1)], axis=0)  # (6, 3k)
    internal = null_space(grasp)  # (3k, m) forces that balance the object
    if internal.shape[1] == 0:
        return float("inf")
    joint_map = np.concatenate(list(jac.transpose(0, 2, 1)), axis=1)  # (n_q, 3k): sum_i J_i^T f_i
    z = np.linalg.lstsq(joint_map @ internal, np.asarray(torque, float), rcond=None)[0]
    f = (internal @ z).reshape(k, 3)
    normal = np.einsum("ki,ki->k", f, n)
    tangential = np.linalg.norm(f - normal[:, None] * n, axis=1)
    pressed = np.clip(normal, 0.0, None).sum()
    if not pressed > 0:
        return float("inf")
    return float(tangential.sum() / pressed)
