"""Class III subproblems ``|| prod exp(xi_i th_i) p - q || = d``: S3-R, S3-T and the two-equation types.

Hypothesis draws the geometry (general and degenerate relations of ``twist_lists``; points general,
at the origin or on a joint axis, pairs of points equal or not), joint values (special angles
included); ``d`` is built by evaluating the left side.  ``tests/subproblems/_checks3.py`` says what
each instance must pass (drawn values recovered, exact rows satisfy the equations, scalar and
vectorised paths agree).  Budgets follow the active hypothesis profile (``HYPOTHESIS_PROFILE``).
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from hypothesis import Phase, given, settings
from hypothesis import strategies as st

from subproblems import codes, max_solutions, solve, solve_batch
from subproblems.screw import prismatic_twist, revolute_twist
from tests.strategies import contains_solution, joint_values, twist_lists

from ._checks3 import check_instance, distance, fk_point, random_twists

EXAMPLES = settings().max_examples
_coord = st.floats(-2.0, 2.0, allow_nan=False, allow_infinity=False)
_vec = st.tuples(_coord, _coord, _coord).map(np.array)
_REGISTERED = set(codes())


def budget(factor: float = 1.0) -> settings:
    return settings(max_examples=max(5, int(EXAMPLES * factor)))


@st.composite
def points(draw, twists):
    """General, the origin, or on one of the revolute axes."""
    kind = draw(st.integers(0, 6))
    if kind == 0:
        return np.zeros(3)
    revs = [xi for xi in twists if xi[3:].any()]
    if kind == 1 and revs:
        xi = draw(st.sampled_from(revs))
        return np.cross(xi[3:], xi[:3]) + draw(_coord) * xi[3:]
    return draw(_vec)


# ------------------------------------------------------------------------------------- S3-R, S3-T


@pytest.mark.parametrize("code", ["S3-R", "S3-T"])
@budget(1.5)
@given(data=st.data())
def test_one_joint_roundtrip(code, data):
    kinds = code[3:]
    tw, _ = data.draw(twist_lists(kinds))
    th = data.draw(joint_values(kinds))
    p, q = data.draw(points(tw)), data.draw(points(tw))
    d = float(distance(fk_point(tw, th, p) - q))
    r = check_instance(code, kinds, tw, {"p": p, "q": q, "d": d}, th)
    assert 1 <= len(r.q) <= 2


@pytest.mark.parametrize("code", ["S3-R", "S3-T"])
@budget()
@given(data=st.data())
def test_one_joint_unreachable(code, data):
    kinds = code[3:]
    tw, _ = data.draw(twist_lists(kinds))
    p, q = data.draw(points(tw)), data.draw(points(tw))
    xi = tw[0]
    if code == "S3-R":
        w, c = xi[3:], np.cross(xi[3:], xi[:3])
        a = c + w * (w @ (p - c))
        rho, m = np.linalg.norm(p - a), a - q
        m_par = abs(m @ w)
        m_perp = np.linalg.norm(m - w * (m @ w))
        lo, hi = math.hypot(m_par, m_perp - rho), math.hypot(m_par, m_perp + rho)
    else:
        u = p - q
        lo = float(np.linalg.norm(u - xi[:3] * (u @ xi[:3])))
        hi = math.inf
    gap = data.draw(st.floats(1e-3, 2.0))
    above = data.draw(st.booleans()) and hi < math.inf
    d = hi + gap if above else lo - gap
    r = check_instance(code, kinds, tw, {"p": p, "q": q, "d": d})
    assert r.ls.all() and len(r.q) == 1
    # the least-squares answer is the extreme distance
    assert abs(r.residual[0] - gap) <= 1e-6 * max(1.0, gap)


def test_s3_r_cases():
    z = revolute_twist([0, 0, 1], [0, 0, 0])
    assert len(solve("S3-R", [z], p=[1, 0, 0], q=[2, 0, 0], d=1.5).q) == 2
    r = solve("S3-R", [z], p=[1, 0, 0], q=[2, 0, 0], d=1.0)  # tangent: nearest point
    assert r.q.tolist() == [[0.0]] and not r.ls[0]
    r = solve("S3-R", [z], p=[1, 0, 0], q=[2, 0, 0], d=3.0)  # tangent: farthest point
    assert len(r.q) == 1 and abs(abs(r.q[0, 0]) - math.pi) < 1e-15 and not r.ls[0]
    r = solve("S3-R", [z], p=[1, 0, 0], q=[2, 0, 0], d=5.0)
    assert r.ls.all() and math.isclose(r.residual[0], 2.0)
    r = solve("S3-R", [z], p=[1, 0, 0], q=[2, 0, 0], d=-1.0)
    assert r.ls.all() and r.q.tolist() == [[0.0]]
    # q on the axis: continuum, exact iff the constant distance is d
    r = solve("S3-R", [z], p=[3, 0, 0], q=[0, 0, 4], d=5.0)
    assert r.continuum and not r.ls[0] and r.q.tolist() == [[0.0]]
    r = solve("S3-R", [z], p=[3, 0, 0], q=[0, 0, 4], d=6.0)
    assert r.continuum and r.ls[0]
    # p on the axis
    assert solve("S3-R", [z], p=[0, 0, 1], q=[1, 2, 3], d=1.0).continuum


def test_s3_t_cases():
    x = prismatic_twist([1, 0, 0])
    r = solve("S3-T", [x], p=[0, 0, 0], q=[0, 1, 0], d=1.0)
    assert r.q.tolist() == [[0.0]] and not r.ls[0]
    r = solve("S3-T", [x], p=[1e8, 0, 0], q=[0, 0, 0], d=1e8 + 1e-3)  # no cancellation
    assert np.allclose(np.sort(r.q[:, 0]), [-2e8 - 1e-3, 1e-3], rtol=1e-12)
    r = solve("S3-T", [x], p=[0, 0, 0], q=[5, 2, 0], d=1.0)
    assert r.ls.all() and r.q.tolist() == [[5.0]] and math.isclose(r.residual[0], 1.0)


@pytest.mark.parametrize("code", ["S3-R", "S3-T"])
def test_one_joint_batch_many(code):
    rng = np.random.default_rng(3)
    n = 400
    if code == "S3-R":
        w = rng.normal(size=(n, 3))
        tw = np.array([revolute_twist(wi, ri) for wi, ri in zip(w, rng.normal(size=(n, 3)))])
        th = rng.uniform(-math.pi, math.pi, n)
    else:
        tw = np.array([prismatic_twist(v) for v in rng.normal(size=(n, 3))])
        th = rng.uniform(-2, 2, n)
    tw = tw[:, None, :]
    p, q = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    d = np.array([distance(fk_point(tw[i], [th[i]], p[i]) - q[i]) for i in range(n)])
    d[::5] += 3.0
    b = solve_batch(code, tw, p=p, q=q, d=d)
    assert b.vectorised and b.q.shape == (n, max_solutions(code), 1)
    for i in range(0, n, 20):
        r = solve(code, tw[i], p=p[i], q=q[i], d=d[i])
        rows = b.q[i][b.valid[i]]
        assert len(rows) == len(r.q)
        assert np.allclose(np.sort(rows[:, 0]), np.sort(r.q[:, 0]), atol=1e-12)
        assert b.ls[i][b.valid[i]].tolist() == r.ls.tolist()


# -------------------------------------------------------------------------- two-equation types

PAIRS = ["S3-RR", "S3-RT", "S3-TR", "S3-TT"]


@st.composite
def point_pairs(draw, twists):
    """Two points: independent, equal, or differing along a joint axis."""
    a = draw(points(twists))
    kind = draw(st.integers(0, 5))
    if kind == 0:
        b = a.copy()
    elif kind == 1:
        xi = twists[draw(st.integers(0, len(twists) - 1))]
        ax = xi[3:] if xi[3:].any() else xi[:3]
        b = a + draw(_coord) * ax
    else:
        b = draw(points(twists))
    return np.array([a, b])


def _general_points(draw):
    return np.array([draw(_vec), draw(_vec)])


# Strict, and in the thorough profile only: in the ci profile these tests pass and must keep passing.
_MULTIPLE_ROOT_GAP = pytest.mark.xfail(
    os.environ.get("HYPOTHESIS_PROFILE", "ci") == "thorough",
    strict=True,
    reason="known gap (thorough profile only): instances ill-conditioned in their data (a point ~1e-8 "
    "from an axis, an axis ~1e-5 from a point's plane: a value fixed only to ~1e-4 by the 1e-9 "
    "tolerance, a near-continuum) return an exact row that is not the drawn one; the clusters of "
    "multiple roots are merged (test_pair_multiple_root_one_row)",
)


@_MULTIPLE_ROOT_GAP
@pytest.mark.parametrize("code", PAIRS)
@budget()
@given(data=st.data())
def test_pair_roundtrip(code, data):
    # degenerate twist relations, special angles, general points
    kinds = code[3:]
    tw, _ = data.draw(twist_lists(kinds))
    th = data.draw(joint_values(kinds))
    P, Q = _general_points(data.draw), _general_points(data.draw)
    D = np.array([distance(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
    r = check_instance(code, kinds, tw, {"p": P, "q": Q, "d": D}, th)
    assert len(r.q) <= max_solutions(code)


@_MULTIPLE_ROOT_GAP
@pytest.mark.parametrize("code", PAIRS)
@settings(max_examples=max(5, EXAMPLES // 2), phases=[Phase.explicit, Phase.reuse, Phase.generate])
@given(data=st.data())
def test_pair_roundtrip_degenerate_points(code, data):
    kinds = code[3:]
    tw, _ = data.draw(twist_lists(kinds))
    th = data.draw(joint_values(kinds))
    P, Q = data.draw(point_pairs(tw)), data.draw(point_pairs(tw))
    D = np.array([distance(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
    r = check_instance(code, kinds, tw, {"p": P, "q": Q, "d": D}, th)
    assert len(r.q) <= max_solutions(code)


@pytest.mark.parametrize("code", PAIRS)
@budget(0.5)
@given(data=st.data())
def test_pair_unreachable(code, data):
    kinds = code[3:]
    tw, _ = data.draw(twist_lists(kinds))
    P, Q = data.draw(point_pairs(tw)), data.draw(point_pairs(tw))
    th = data.draw(joint_values(kinds))
    D = np.array([distance(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
    if "T" in kinds:
        D[1] = -1.0  # a prismatic joint reaches far spheres: make one distance impossible
    else:
        D[1] = np.linalg.norm(P[1]) + np.linalg.norm(Q[1]) + 2 * np.abs(tw[:, :3]).sum() + 1.0
    r = check_instance(code, kinds, tw, {"p": P, "q": Q, "d": D})
    assert r.ls.all() and len(r.q) == 1


def test_pair_counts_reach_the_bound():
    # random general instances: counts stay within the bound and S3-RR reaches 8 solutions
    rng = np.random.default_rng(0)
    seen = 0
    for _ in range(200):
        tw = np.array([revolute_twist(rng.normal(size=3), rng.normal(size=3)) for _ in range(2)])
        th = rng.uniform(-3, 3, 2)
        P, Q = rng.normal(size=(2, 3)), rng.normal(size=(2, 3))
        D = np.array([distance(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
        r = solve("S3-RR", tw, p=P, q=Q, d=D)
        assert len(r.q) <= 8 and not r.ls.any()
        seen = max(seen, len(r.q))
    assert seen == 8


def test_pair_continuum_cases():
    z = revolute_twist([0, 0, 1], [0, 0, 0])
    x = revolute_twist([1, 0, 0], [0, 0, 1])
    # q_1, q_2 on the first axis: th_1 free (representative 0), th_2 from the two distances
    P = np.array([[0.0, 1.0, 1.0], [0.0, 0.0, 2.0]])
    Q = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 5.0]])
    D = np.array([distance(fk_point([z, x], [0.7, 0.4], P[k]) - Q[k]) for k in range(2)])
    r = solve("S3-RR", [z, x], p=P, q=Q, d=D)
    assert r.continuum and not r.ls.any() and r.residual.max() < 1e-9 and r.q[0, 0] == 0.0
    # parallel prismatic joints: only their sum matters
    t1, t2 = prismatic_twist([1, 0, 0]), prismatic_twist([-1, 0, 0])
    P = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    Q = np.array([[3.0, 0.0, 0.0], [1.0, 2.0, 0.0]])
    D = np.array([distance(fk_point([t1, t2], [0.5, -1.0], P[k]) - Q[k]) for k in range(2)])
    r = solve("S3-TT", [t1, t2], p=P, q=Q, d=D)
    assert r.continuum and not r.ls.any() and r.residual.max() < 1e-9


def _pair_instance(code, tw, th, P, Q):
    tw, P, Q = np.array(tw), np.array(P), np.array(Q)
    D = np.array([distance(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
    return tw, {"p": P, "q": Q, "d": D}


def _min_gap(Q, kinds):
    """Smallest joint-value distance between two rows (angles modulo 2 pi)."""
    gaps = [
        max(
            abs(math.remainder(a - b, 2 * math.pi)) if k == "R" else abs(a - b)
            for k, a, b in zip(kinds, r, s)
        )
        for i, r in enumerate(Q)
        for s in Q[:i]
    ]
    return min(gaps, default=math.inf)


# drawn instances (thorough-profile style) at roots of multiplicity ~4 of the eliminant: parallel axes,
# th_2 = pi (the point at its largest distance from the other axis: the equations are tangent there)
_MULTIPLE_ROOTS = {
    # p_1 = q_1 = the origin, on axis 1: equation 1 is independent of th_1, F is a square with a double
    # root at th_2 = pi; at bc06aaf (before the merge) the eight candidates stalled ~1e-2 away
    # (Levenberg-Marquardt's damping), none was exact, and the drawn solution was lost
    "lost": (
        [
            [0.0, 0.0, 0.0, -0.39839104481058246, 0.8653991266329428, 0.3039225675030934],
            [
                0.9273115322503649,
                0.9635408799982439,
                -1.528069566017882,
                -0.39839104481058246,
                0.8653991266329428,
                0.3039225675030934,
            ],
        ],
        [0.0, math.pi],
        [[0.0, 0.0, 0.0], [-2.0, -0.4, -1.8]],
        [[0.0, 0.0, 0.0], [0.6, -1.4, -0.5]],
    ),
    # p_1 = p_2: two exact rows 1.5e-6 apart, one root split in two
    "cluster": (
        [
            [
                0.4205799687283314,
                1.0003634777368415,
                -0.45329331467227896,
                -0.7491347333202377,
                0.014871845641332886,
                -0.6622506923668987,
            ],
            [
                -0.14380775127949103,
                -0.2692165578183885,
                0.15662895563227525,
                0.7491347333202377,
                -0.014871845641332886,
                0.6622506923668987,
            ],
        ],
        [0.8997642972258149, math.pi],
        [[-0.23460023879302938, -0.600431879776756, -1.5427500513621468]] * 2,
        [[0.0, 0.0, 0.0], [1.82, -1.04, 0.79]],
    ),
    # q_1 = q_2 at a point the axes leave: a split root 1.5e-7 apart next to a genuine pair 4.5e-4 apart
    "cluster and pair": (
        [
            [
                0.7696814441877597,
                -0.5807580819305578,
                -2.102895979561664,
                0.7484844358854488,
                0.6566547881597645,
                0.09260420305848083,
            ],
            [
                0.46680580171779423,
                -0.5429883996576959,
                0.07730810424571016,
                -0.7484844358854488,
                -0.6566547881597645,
                -0.09260420305848083,
            ],
        ],
        [-2.5293700510431054, 0.15025496620603862],
        [[-0.71, -1.57, 0.33], [0.0, 0.0, 0.0]],
        [[1.9, -0.97, 0.43]] * 2,
    ),
}


@pytest.mark.parametrize("name", list(_MULTIPLE_ROOTS))
def test_pair_multiple_root_one_row(name):
    # the eliminant's multiple root split by roundoff comes back as one row (Newton-polished mean of
    # the cluster), the drawn values among the rows; both failed before the merge (see the dict)
    tw, inputs = _pair_instance("S3-RR", *_MULTIPLE_ROOTS[name])
    r = check_instance("S3-RR", "RR", tw, inputs, _MULTIPLE_ROOTS[name][1])
    assert not r.continuum and not r.ls.any()
    assert _min_gap(r.q, "RR") > 1e-5, r.q


def test_pair_distinct_nearby_roots_stay_apart():
    # genuine roots closer than the merge tolerance (1e-3): each is fixed by its Jacobian to ~1e-11 or
    # better, far below their distance, so neither is merged into the other
    tw, inputs = _pair_instance("S3-RR", *_MULTIPLE_ROOTS["cluster and pair"])
    r = solve("S3-RR", tw, **inputs)
    x = np.sort(r.q[:, 0])
    assert len(r.q) == 4 and np.allclose(x[:2], [-2.9994683087, -2.9990224028], atol=1e-9), r.q
    # S3-RT with p_1 = q_1 = q_2 = the origin: two well-conditioned roots 3.5e-4 apart
    tw = [
        [
            0.789748964574648,
            0.2627091717511874,
            -0.6740737302592767,
            0.22359916815846312,
            0.7905745260676312,
            0.5700836173157265,
        ],
        [-0.22359916815846312, -0.7905745260676312, -0.5700836173157265, 0.0, 0.0, 0.0],
    ]
    th = [-0.00034220099942272597, 0.0]
    tw, inputs = _pair_instance("S3-RT", tw, th, [[0.0, 0.0, 0.0], [2.0, 1.0, 0.0]], [[0.0, 0.0, 0.0]] * 2)
    r = check_instance("S3-RT", "RT", tw, inputs, th)
    assert len(r.q) == 2 and 3e-4 < _min_gap(r.q, "RT") < 1e-3, r.q
    assert contains_solution(r.q, [-0.00010867233581546287, 0.0003475338012957881], "RT", 1e-12), r.q


@pytest.mark.parametrize("code", PAIRS)
def test_pair_batch_many(code):
    rng = np.random.default_rng(5)
    n = 300
    kinds = code[3:]
    tw = random_twists(rng, kinds, n)
    th = rng.uniform(-math.pi, math.pi, (n, 2))
    P, Q = rng.normal(size=(n, 2, 3)), rng.normal(size=(n, 2, 3))
    D = np.array(
        [[distance(fk_point(tw[i], th[i], P[i, k]) - Q[i, k]) for k in range(2)] for i in range(n)]
    )
    D[::6, 0] = -1.0
    b = solve_batch(code, tw, p=P, q=Q, d=D)
    assert b.vectorised and b.q.shape == (n, max_solutions(code), 2)
    for i in range(0, n, 30):
        r = solve(code, tw[i], p=P[i], q=Q[i], d=D[i])
        assert b.ls[i][b.valid[i]].tolist() == r.ls.tolist()
        if not r.ls.any():  # least-squares answers: local minimisers, equal only up to LM convergence
            assert np.allclose(b.q[i][b.valid[i]], r.q, atol=1e-12)
    exact = ~b.ls & b.valid
    ok = [i for i in range(n) if i % 6]
    assert exact[ok].any(axis=1).all()
