"""Ferrari-Canny epsilon on degenerate input: flat pads, tilted normals, duplicated contacts, tiny friction.

The reference epsilon here is computed independently of the production code
(no face enumeration, no exterior algebra, no Qhull): every hyperplane through
6 of the grasp's distinct primitive wrenches (the null vector of the 6 x 7
matrix of rows (w, 1), from a complete QR factorisation, which is orthogonal
to the rows whatever their rank) plus the least-squares hyperplane of all of
them, each scored by the support function. Every facet of a 6-D polytope
passes through 6 affinely independent vertices, and any direction u has
min(h(u), h(-u)) >= eps |u|, so the smallest score over these candidates is
exactly epsilon (clipped at 0).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from manigrasp.contact import Contact, ContactSet, ContactType, as_contact_set, primitive_wrenches, tangent_basis
from manigrasp.grasp import (
    closure_margin,
    closure_margin_batch,
    ferrari_canny,
    ferrari_canny_batch,
    force_closure,
    force_closure_batch,
)
from manigrasp.grasp.closure import MARGIN_TOLERANCE

ORIGIN = np.zeros(3)

# The issue's reproducer: parallel_jaw closed on 035_power_drill, two flat pads of four contacts each.
DRILL_POINTS = np.array([
    [0.019737648034352656, -0.0006904453843539174, 0.08819945922784404],
    [0.019729826528858768, -0.0010914632734054202, 0.0682034815454039],
    [0.019729956597756483, -0.01750000048036452, 0.06853255352379647],
    [0.019737781282077982, -0.017500000144679343, 0.08853657358307934],
    [-0.026219072498952233, -0.017494394998325682, 0.08855442637426084],
    [-0.026226897202499606, -0.01749196993897871, 0.0685503576738632],
    [-0.026227027207660243, -0.0010914733334842683, 0.06822144694912766],
    [-0.026219205702166355, -0.0006904554444327644, 0.08821742463156779]])
DRILL_NORMALS = np.array([
    [-9.9999992340588129e-01, 5.4543738565432904e-08, 3.9139267829889921e-04],
    [-9.9999992340588140e-01, 5.4543737960684646e-08, 3.9139267830465247e-04],
    [-9.9999992340588117e-01, 5.4543719982834373e-08, 3.9139267850888396e-04],
    [-9.9999992340588117e-01, 5.4543708778391033e-08, 3.9139267849422831e-04],
    [9.9999992340588117e-01, -5.4543752411178740e-08, -3.9139267856961967e-04],
    [9.9999992340588117e-01, -5.4543742010640407e-08, -3.9139267857803649e-04],
    [9.9999992340588117e-01, -5.4543736429013000e-08, -3.9139267848939320e-04],
    [9.9999992340588117e-01, -5.4543738337197223e-08, -3.9139267849522090e-04]])
DRILL_CENTER = np.array([3.8367425723713817e-05, 1.1664128897492164e-09, 9.7489317356523761e-02])
DRILL_SCALE = 0.07475660005241441


def drill_contacts(points: np.ndarray = DRILL_POINTS) -> list[Contact]:
    return [Contact(position=p, normal=n, mu=0.5, kind=ContactType.SOFT_FINGER, gamma=0.005)
            for p, n in zip(points, DRILL_NORMALS, strict=True)]


def reference_epsilon(points: np.ndarray) -> np.ndarray:
    """Epsilon of conv(points[b]) for (B, N, 6) points with N distinct rows each (module docstring)."""
    b, n, _ = points.shape
    rows = np.concatenate([points, np.ones((b, n, 1))], axis=-1)
    subsets = np.array(list(itertools.combinations(range(n), 6)))
    picked = np.swapaxes(rows[:, subsets], -1, -2).reshape(-1, 7, 6)
    q, _ = np.linalg.qr(picked, mode="complete")
    normals = q[:, :, 6].reshape(b, len(subsets), 7)
    fit = np.linalg.svd(rows)[2][:, -1:, :]  # least-squares hyperplane: catches sets flatter than 5-D
    u = np.concatenate([normals, fit], axis=1)[..., :6]
    s = points @ np.swapaxes(u, 1, 2)  # (B, N, S)
    length = np.linalg.norm(u, axis=-1)
    score = np.minimum(s.max(axis=1), (-s).max(axis=1))
    value = np.where(length > 0, score / np.where(length > 0, length, 1.0), np.inf)
    return np.maximum(value.min(axis=1), 0.0)


def tilted(normals: np.ndarray, angle: float, rng: np.random.Generator) -> np.ndarray:
    """`normals` (..., 3) each turned by `angle` [rad] about a random axis orthogonal to it."""
    axis = np.cross(normals, rng.normal(size=normals.shape))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    return np.cos(angle) * normals + np.sin(angle) * np.cross(axis, normals)


def pad_grasps(rng: np.random.Generator, b: int, per_pad: tuple[int, int], duplicate: bool,
               kind: ContactType, noise: float = 1e-13) -> ContactSet:
    """B grasps between two flat pads, the contacts of each pad coplanar, as a parallel jaw makes them.

    Pad 1's normal is exactly -x in a third of the grasps, else tilted by 1e-4 rad; pad 2's is its
    opposite, in half of the tilted grasps tilted again by 1e-4. Tilted normals get per-contact
    noise of `noise` (MuJoCo's contact frames of one pad differ by ~1e-13), exact ones none.
    With `duplicate`, one contact is repeated.
    """
    exact = rng.random(b) < 1 / 3
    n1 = np.where(exact[:, None], [-1.0, 0.0, 0.0], tilted(np.tile([-1.0, 0.0, 0.0], (b, 1)), 1e-4, rng))
    again = ~exact & (rng.random(b) < 0.5)
    n2 = -np.where(again[:, None], tilted(n1, 1e-4, rng), n1)
    half = rng.uniform(0.01, 0.04, b)
    offset = rng.uniform(-0.01, 0.01, (b, 1, 2))
    positions, normals = [], []
    for n, k in zip((n1, n2), per_pad, strict=True):
        u = np.cross(n, [0.0, 0.0, 1.0])
        u /= np.linalg.norm(u, axis=-1, keepdims=True)
        v = np.cross(n, u)
        yz = rng.uniform(-0.02, 0.02, (b, k, 2)) + offset
        positions.append(-half[:, None, None] * n[:, None] + yz[..., :1] * u[:, None] + yz[..., 1:] * v[:, None])
        jitter = np.where(exact[:, None, None], 0.0, rng.normal(0.0, noise, (b, k, 3)))
        normals.append(n[:, None] + jitter)
    positions, normals = np.concatenate(positions, axis=1), np.concatenate(normals, axis=1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    if duplicate:
        pick = rng.integers(0, positions.shape[1], b)
        positions = np.concatenate([positions, positions[np.arange(b), pick][:, None]], axis=1)
        normals = np.concatenate([normals, normals[np.arange(b), pick][:, None]], axis=1)
    mu = rng.choice([0.05, 0.2, 0.5, 1.0], (b, 1))
    gamma = rng.uniform(0.002, 0.01, (b, 1)) if kind is ContactType.SOFT_FINGER else None
    return ContactSet(positions, normals, mu, kind, gamma)


def distinct(w: np.ndarray) -> np.ndarray:
    """(B, N, 6) distinct primitive wrenches of each grasp (every grasp here has the same count)."""
    return np.stack([np.unique(g.reshape(-1, 6), axis=0) for g in w])


def lp_closure(cs: ContactSet, center: np.ndarray, scale: float, m: int) -> np.ndarray:
    """(B,) the LP force-closure test of `force_closure` (margin > tolerance), batched."""
    return closure_margin_batch(cs, center, scale, m) > MARGIN_TOLERANCE


def test_the_issue_reproducer_flat_pads_on_the_drill() -> None:
    """Eight coplanar soft contacts on two flat pads: in force closure (LP margin s = 0.087), and
    epsilon lies in [s / sqrt(6), s] and matches the contacts moved by 1e-6 m (a generic position)."""
    contacts = drill_contacts()
    eps = ferrari_canny(contacts, DRILL_CENTER, DRILL_SCALE, norm="L1", m=8)
    margin = closure_margin(contacts, DRILL_CENTER, DRILL_SCALE)
    assert force_closure(contacts, DRILL_CENTER, DRILL_SCALE)
    assert margin / np.sqrt(6) <= eps <= margin
    moved = DRILL_POINTS + np.random.default_rng(0).normal(0.0, 1e-6, DRILL_POINTS.shape)
    eps_moved = ferrari_canny(drill_contacts(moved), DRILL_CENTER, DRILL_SCALE, norm="L1", m=8)
    assert eps == pytest.approx(eps_moved, rel=1e-3)
    assert eps == pytest.approx(0.0836, abs=5e-4)  # the issue's value for the moved contacts
    assert force_closure_batch(as_contact_set(contacts), DRILL_CENTER, DRILL_SCALE)[0]


@pytest.mark.parametrize(("kind", "per_pad", "duplicate", "m", "count"), [
    (ContactType.HARD_FINGER, (2, 1), False, 3, 300),
    (ContactType.HARD_FINGER, (1, 2), True, 3, 300),
    (ContactType.HARD_FINGER, (2, 2), False, 3, 75),
    (ContactType.SOFT_FINGER, (1, 1), True, 3, 250),
    (ContactType.SOFT_FINGER, (1, 1), False, 4, 75),
])
def test_epsilon_of_near_degenerate_pad_grasps_matches_an_independent_computation(
        kind: ContactType, per_pad: tuple[int, int], duplicate: bool, m: int, count: int) -> None:
    """1,000 grasps in all (coplanar pad contacts, normals exact or tilted by 1e-4, duplicated
    contacts): epsilon by both production methods equals the reference, and epsilon > 0 exactly
    when the LP says force closure."""
    rng = np.random.default_rng([len(kind.value), *per_pad, duplicate, m])
    cs = pad_grasps(rng, count, per_pad, duplicate, kind)
    center = rng.uniform(-0.005, 0.005, (count, 3))
    scale = 0.05
    want = reference_epsilon(distinct(primitive_wrenches(cs, center, scale, m)))
    for method in ("enumerate", "qhull"):
        got = ferrari_canny_batch(cs, center, scale, "L1", m, method=method)
        np.testing.assert_allclose(got, want, atol=1e-9, err_msg=method)
    lp = lp_closure(cs, center, scale, m)
    np.testing.assert_array_equal(got > 0.0, lp)  # no epsilon in (0, tolerance]: the two tests agree
    assert 0.1 * count < lp.sum() < 0.95 * count  # both outcomes occur: the comparison can fail


@pytest.mark.slow
def test_flat_pads_of_four_soft_contacts_each_like_the_drill() -> None:
    """40 grasps of the reproducer's kind (two pads of four soft contacts, 80 primitives, where Qhull
    without joggling stops on about a third): too large for the reference, so epsilon is checked
    against the LP on every grasp (closure agrees, and s / sqrt(6) <= eps <= s), and against the
    same grasp turned by a rotation, which changes every rounding error (equal within 1e-9)."""
    rng = np.random.default_rng(7)
    cs = pad_grasps(rng, 40, (4, 4), False, ContactType.SOFT_FINGER)
    eps = ferrari_canny_batch(cs, ORIGIN, 0.05, "L1", 8)
    margin = closure_margin_batch(cs, ORIGIN, 0.05, 8)
    np.testing.assert_array_equal(eps > 0.0, margin > MARGIN_TOLERANCE)
    assert np.all((margin / np.sqrt(6) - 1e-9 <= eps) & (eps <= margin + 1e-9))
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    t1, _ = tangent_basis(cs.normals)  # turned with the grasp, so the linearised cones turn too
    turned = ContactSet(cs.positions @ q.T, cs.normals @ q.T, cs.mu, cs.kind, cs.gamma, t1 @ q.T)
    np.testing.assert_allclose(ferrari_canny_batch(turned, ORIGIN, 0.05, "L1", 8), eps, atol=1e-9)
    assert 5 <= (eps > 0).sum() < 40


@pytest.mark.slow
def test_qhull_on_flat_pads_matches_the_enumeration() -> None:
    """Two pads of two soft contacts each (24 primitives, every contact on a pad in one plane):
    the Qhull path that "auto" picks equals the facet enumeration, which never calls Qhull."""
    rng = np.random.default_rng(3)
    cs = pad_grasps(rng, 20, (2, 2), False, ContactType.SOFT_FINGER)
    qhull = ferrari_canny_batch(cs, ORIGIN, 0.05, "L1", 4, method="auto")
    enum = ferrari_canny_batch(cs, ORIGIN, 0.05, "L1", 4, method="enumerate")
    np.testing.assert_allclose(qhull, enum, atol=1e-9)
    assert 5 <= (enum > 0).sum() < 20


@pytest.mark.parametrize("mu", [1e-4, 1e-5, 1e-6])
def test_epsilon_with_tiny_friction_is_the_analytic_value(mu: float) -> None:
    """Two antipodal soft fingers at distance r = torque_scale from the centre. For small mu the
    nearest facets are tangential: with equal normal forces 1/2 (they must cancel), the tangential
    force a and torque b span {((a1 + a2) / 2, J (a1 - a2) / 2)} over a1, a2 in the friction octagon,
    whose support in a unit direction (x, y) is mu/2 (h(x + y') + h(x - y')), h the unit octagon's;
    h(z) >= cos(pi/8) |z| and |x + y'| + |x - y'| >= sqrt(2), so eps = mu cos(pi/8) / sqrt(2)."""
    q = np.random.default_rng(2).normal(size=(6, 3))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    p = np.stack([q, -q], axis=1)
    cs = ContactSet(0.05 * p, -p, mu, "soft_finger", 0.01)
    for method in ("enumerate", "qhull"):
        eps = ferrari_canny_batch(cs, ORIGIN, 0.05, "L1", 8, method=method)
        np.testing.assert_allclose(eps, mu * np.cos(np.pi / 8) / np.sqrt(2), rtol=1e-6, err_msg=method)


def test_epsilon_with_a_torque_scale_far_from_the_lever_arms() -> None:
    """Torque scale 1e5 above and 1e5 below the 5 cm lever arms: the enumeration equals Qhull, and
    where torques limit (scale too large) epsilon falls exactly as 1 / torque_scale."""
    rng = np.random.default_rng(1)
    p = rng.normal(size=(20, 3, 3))
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    cs = ContactSet(0.05 * p, -p, 0.5)
    eps = {}
    for scale in (5e-7, 5e3, 5e4):
        eps[scale] = ferrari_canny_batch(cs, ORIGIN, scale, method="enumerate")
        qhull = ferrari_canny_batch(cs, ORIGIN, scale, method="qhull")
        np.testing.assert_allclose(eps[scale], qhull, rtol=1e-7, atol=1e-15)
    assert 5 <= (eps[5e4] > 0).sum() < 20
    np.testing.assert_allclose(eps[5e4] * 10, eps[5e3], rtol=1e-6)


def test_closure_margin_without_closure_is_plus_zero() -> None:
    """Two antipodal contacts cannot resist a torque about their axis: margin exactly +0.0."""
    for mu, kind in ((0.5, "hard_finger"), (0.0, "frictionless")):
        pair = [Contact([0.05, 0, 0], [-1.0, 0, 0], mu, kind), Contact([-0.05, 0, 0], [1.0, 0, 0], mu, kind)]
        margin = closure_margin(pair, ORIGIN, 0.05)
        assert margin == 0.0 and np.copysign(1.0, margin) == 1.0
        assert not force_closure(pair, ORIGIN, 0.05)


def test_a_hull_qhull_cannot_build_is_nan_never_zero(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without joggling, Qhull stops on the drill's flat pads: epsilon is then NaN ("not
    computed"), and the batched closure test falls back to the LP instead of saying "no"."""
    monkeypatch.setattr("manigrasp.grasp.quality.QHULL_OPTIONS", ("Qx",))
    contacts = drill_contacts()
    assert np.isnan(ferrari_canny(contacts, DRILL_CENTER, DRILL_SCALE))
    assert force_closure_batch(as_contact_set(contacts), DRILL_CENTER, DRILL_SCALE)[0]
    assert MARGIN_TOLERANCE < closure_margin(contacts, DRILL_CENTER, DRILL_SCALE)


def test_flat_and_duplicated_wrench_sets_are_zero_not_nan() -> None:
    """Contacts all on one pad (every wrench on the plane f_x = -1) and one contact repeated three
    times: no closure, a computed 0."""
    one_pad = [Contact([0.02, y, z], [-1.0, 0, 0], 0.5, "soft_finger", gamma=0.005)
               for y, z in ((-0.01, 0.0), (0.01, 0.01), (0.01, -0.01))]
    repeated = [Contact([0.02, 0, 0], [-1.0, 0, 0], 0.5, "soft_finger", gamma=0.005)] * 3
    for contacts in (one_pad, repeated):
        for method in ("enumerate", "qhull"):
            assert ferrari_canny(contacts, ORIGIN, 0.05, method=method) == 0.0


def test_lp_decides_a_degenerate_wrench_set_where_the_simplex_gave_up() -> None:
    """Two pads of two hard fingers, mu 0.05, normals tilted by 1e-4: the LP with the origin left
    out of the hull was infeasible here and HiGHS's simplex stopped with status "unknown"; the LP
    is now always feasible and answers "not in closure", as the reference does."""
    positions = [[0.03013435782188708, 0.013408699206639531, 0.0044704005009301735],
                 [0.03013435782188708, 0.0006265206754619383, -0.019174471776180813],
                 [-0.03013435782188708, 0.013387526470795618, 0.006584259635412525],
                 [-0.03013435782188708, -0.012785763499612756, 0.0007345845719526501]]
    normals = np.array([[-1.0, 9.6008804037031e-05, -2.7969796460568856e-05],
                        [-1.0, -4.7024874429509374e-05, 8.825339172833838e-05],
                        [1.0, 5.633167464430728e-05, -8.262410301137664e-05],
                        [1.0, 8.527524376423498e-05, -5.223153039704058e-05]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    center = np.array([-0.0037776919788380936, -0.003992187404998615, 0.0023841730548193356])
    one = ContactSet([positions], [normals], 0.05)
    assert closure_margin(one, center, 0.05, 3) == 0.0
    assert reference_epsilon(distinct(primitive_wrenches(one, center, 0.05, 3)))[0] == 0.0


def test_batched_lp_margins_equal_one_lp_per_grasp() -> None:
    """Grasps sharing one block-diagonal LP get the margins they get alone, in and out of closure."""
    rng = np.random.default_rng(4)
    cs = pad_grasps(rng, 30, (2, 1), True, ContactType.HARD_FINGER)
    batch = closure_margin_batch(cs, ORIGIN, 0.05, 4)
    alone = [closure_margin(ContactSet(cs.positions[b:b + 1], cs.normals[b:b + 1], cs.mu[b:b + 1]), ORIGIN, 0.05, 4)
             for b in range(30)]
    np.testing.assert_allclose(batch, alone, atol=1e-9)
    assert 3 <= (batch > MARGIN_TOLERANCE).sum() <= 27
