"""Class II subproblems ``prod exp(xi_i th_i) p = q``: the 14 types, proof by randomised test.

For every type: hypothesis draws the geometry (general position and each degenerate relation of
``twist_lists``), joint values (special angles included) and the point ``p``; ``q`` is built by
forward kinematics.  The drawn joint values must come back (unless the result is flagged continuum,
then the representative must satisfy the equation), every exact solution must satisfy the equation,
the scalar and vectorised paths must agree, and unreachable instances must come back flagged ``ls``.
Budgets follow the active hypothesis profile (``HYPOTHESIS_PROFILE``: ``ci`` or ``thorough``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, note, settings
from hypothesis import strategies as st

from subproblems import codes, max_solutions, solve, solve_batch
from subproblems._class2 import chain_point_jac
from subproblems.screw import prismatic_twist, revolute_twist, twist_exp
from tests.strategies import RELATIONS, contains_solution, joint_values, twist_lists

CODES = [
    "S2-R",
    "S2-T",
    "S2-RR",
    "S2-RT",
    "S2-TR",
    "S2-TT",
    "S2-RRR",
    "S2-RRT",
    "S2-TRR",
    "S2-RTR",
    "S2-TTR",
    "S2-RTT",
    "S2-TRT",
    "S2-TTT",
]
VECTORISED = set(CODES)  # every class II type has a vectorised path
TOL = 1e-9
_REGISTERED = set(codes())


def params(cs):
    """The codes as test parameters; every one must be registered (a missing solver fails, not skips)."""
    missing = sorted(set(cs) - _REGISTERED)
    assert not missing, f"class II codes without a registered solver: {missing}"
    return list(cs)


# per-code budget: a share of the active profile's max_examples (ci keeps the file well under 90 s)
EXAMPLES = settings().max_examples


def budget(factor: float = 1.0) -> settings:
    return settings(max_examples=max(5, int(EXAMPLES * factor)))


_coord = st.floats(-2.0, 2.0, allow_nan=False, allow_infinity=False)


@st.composite
def points(draw, twists):
    """A point p: general, the origin, or on the last revolute axis (a free last joint)."""
    kind = draw(st.integers(0, 7))
    if kind == 0:
        return np.zeros(3)
    revs = [xi for xi in twists if xi[3:].any()]
    if kind == 1 and revs:
        xi = revs[-1]
        return np.cross(xi[3:], xi[:3]) + draw(_coord) * xi[3:]
    return np.array([draw(_coord), draw(_coord), draw(_coord)])


def fk_point(twists, th, p) -> np.ndarray:
    g = np.eye(4)
    for xi, a in zip(twists, th):
        g = g @ twist_exp(xi, a)
    return g[:3, :3] @ p + g[:3, 3]


def scale_of(twists, p, q) -> float:
    s = max(1.0, float(np.linalg.norm(p)), float(np.linalg.norm(q)))
    for xi in twists:
        s = max(s, float(np.linalg.norm(np.cross(xi[3:], xi[:3]))))
    return s


def check_exact_rows(code, twists, p, q, r) -> None:
    scale = scale_of(twists, p, q)
    assert r.q.shape[0] >= 1, f"{code}: no row at all"
    assert r.q.shape[0] <= max_solutions(code)
    assert np.all(np.isfinite(r.q))
    for row, ls in zip(r.q, r.ls):
        if not ls:
            err = float(np.linalg.norm(fk_point(twists, row, p) - q))
            assert err <= TOL * scale, f"{code}: wrong exact solution {row}, error {err:.3g}"


def recovered(code, twists, p, Q, th) -> bool:
    kinds = code[3:]
    if contains_solution(Q, th, kinds, TOL):
        return True
    # At a singular configuration (a double root: tangent circles, a point on an axis...) the joint
    # values are only determined to ~sqrt(machine epsilon); accept a nearby exact solution there.
    _, J = chain_point_jac(twists, th, p)
    sv = np.linalg.svd(J, compute_uv=False)
    if sv.min() <= 1e-6 * max(1.0, sv.max()):
        return contains_solution(Q, th, kinds, 1e-5)
    return False


@pytest.mark.parametrize("code", params(CODES))
@budget(3)
@given(data=st.data())
def test_recovers_drawn_joint_values(code, data):
    kinds = code[3:]
    twists, rel = data.draw(twist_lists(kinds), label="twists")
    th = data.draw(joint_values(kinds), label="th")
    p = data.draw(points(twists), label="p")
    q = fk_point(twists, th, p)
    r = solve(code, twists, p=p, q=q)
    note(f"exact inputs: {twists.tolist()} p={p.tolist()} th={th.tolist()}")
    note(f"relations={rel} result q={r.q} ls={r.ls} continuum={r.continuum} residual={r.residual}")
    check_exact_rows(code, twists, p, q, r)
    assert not r.ls.all(), f"{code}: a reachable instance came back least-squares only"
    if not r.continuum:
        assert recovered(code, twists, p, r.q[~r.ls], th), f"{code}: drawn joint values {th} missing"


def _perturbed(code, twists, th, p, q):
    """q moved off the reachable set along a normal of it (None when the set is 3-dimensional)."""
    m = len(code) - 3
    if m >= 3:
        return None
    _, J = chain_point_jac(twists, th, p)
    u, s, _ = np.linalg.svd(J)
    if s.min() < 1e-3 * max(1.0, s.max()):
        return None  # singular: the normal is not well defined
    n = u[:, -1]
    return q + 1e-3 * scale_of(twists, p, q) * n


@pytest.mark.parametrize("code", params([c for c in CODES if len(c) <= 5]))
@budget(0.5)
@given(data=st.data())
def test_unreachable_is_flagged_ls(code, data):
    kinds = code[3:]
    twists, rel = data.draw(twist_lists(kinds), label="twists")
    th = data.draw(joint_values(kinds), label="th")
    p = data.draw(points(twists), label="p")
    q = fk_point(twists, th, p)
    q2 = _perturbed(code, twists, th, p, q)
    if q2 is None:
        return
    r = solve(code, twists, p=p, q=q2)
    note(f"relations={rel} q={r.q} ls={r.ls} res={r.residual}")
    check_exact_rows(code, twists, p, q2, r)
    # Off the reachable surface locally; another sheet of it may pass through q2 (then the exact
    # answers are genuine, checked above); otherwise the answer must be flagged.
    if r.ls.all():
        assert len(r.q) == 1
    else:
        assert r.residual[~r.ls].max() <= TOL * scale_of(twists, p, q2)


def _exact_set(Q, ls):
    return [row for row, f in zip(Q, ls) if not f]


@pytest.mark.parametrize("code", params(CODES))
@budget(0.5)
@given(data=st.data())
def test_scalar_and_vectorised_paths_agree(code, data):
    kinds = code[3:]
    n = 3
    tws, ps, qs = [], [], []
    for _ in range(n):
        twists, _ = data.draw(twist_lists(kinds))
        th = data.draw(joint_values(kinds))
        p = data.draw(points(twists))
        q = fk_point(twists, th, p)
        if data.draw(st.booleans()):
            q = q + np.array([data.draw(_coord) for _ in range(3)]) * 1e-2
        tws.append(twists)
        ps.append(p)
        qs.append(q)
    tws, ps, qs = np.array(tws), np.array(ps), np.array(qs)
    b = solve_batch(code, tws, p=ps, q=qs)
    assert b.vectorised == (code in VECTORISED)
    K = max_solutions(code)
    assert b.q.shape == (n, K, len(kinds)) and b.valid.shape == (n, K)
    assert np.all(np.isfinite(b.q))
    for i in range(n):
        r = solve(code, tws[i], p=ps[i], q=qs[i])
        Qb, lsb = b.q[i][b.valid[i]], b.ls[i][b.valid[i]]
        note(
            f"instance {i}: scalar {r.q} ls={r.ls} cont={r.continuum}; "
            f"batch {Qb} ls={lsb} cont={b.continuum[i]}"
        )
        assert len(Qb) >= 1
        scale = scale_of(tws[i], ps[i], qs[i])
        for row, f in zip(Qb, lsb):
            if not f:
                assert np.linalg.norm(fk_point(tws[i], row, ps[i]) - qs[i]) <= TOL * scale
        assert bool(r.ls.all()) == bool(lsb.all())
        if r.ls.all():
            continue
        assert bool(r.continuum) == bool(b.continuum[i])
        if r.continuum:
            continue
        Es, Eb = _exact_set(r.q, r.ls), _exact_set(Qb, lsb)
        same = _same_root_check(code, tws[i], ps[i], qs[i], kinds, scale)
        for row in Es:
            assert any(same(row, other) for other in Eb), f"batch misses {row}"
        for row in Eb:
            assert any(same(row, other) for other in Es), f"scalar misses {row}"


def _same_root_check(code, tw, p, q, kinds, scale):
    """Two exact rows are the same solution: equal to 1e-6, or a hair apart (< 1e-3) around a double
    root, where both pass the residual test and so does every point between them: at a tangency the
    root is only located to about sqrt(tolerance), so the two paths may pick different points of it."""

    def same(a, b):
        if contains_solution(np.atleast_2d(b), a, kinds, 1e-6):
            return True
        if not contains_solution(np.atleast_2d(b), a, kinds, 1e-3):
            return False
        diff = np.array(
            [math.remainder(y - x, 2 * math.pi) if k == "R" else y - x for k, x, y in zip(kinds, a, b)]
        )
        return all(
            np.linalg.norm(fk_point(tw, a + f * diff, p) - q) <= TOL * scale for f in (0.25, 0.5, 0.75)
        )

    return same


# ---------------------------------------------------------------------------------------------------
# crisp counts and named degenerate cases
# ---------------------------------------------------------------------------------------------------

Z = revolute_twist([0, 0, 1], [0, 0, 0])
X = revolute_twist([1, 0, 0], [0, 0, 0])


def test_s2_r_unique_and_least_squares():
    r = solve("S2-R", [Z], p=[1, 0, 0], q=[0, 1, 0])
    assert r.q.shape == (1, 1) and not r.ls[0] and abs(r.q[0, 0] - math.pi / 2) < 1e-12
    r = solve("S2-R", [Z], p=[1, 0, 0], q=[0, 3, 1])  # radius and height mismatch
    assert r.ls[0] and abs(r.q[0, 0] - math.pi / 2) < 1e-12
    r = solve("S2-R", [Z], p=[0, 0, 1], q=[0, 0, 1])  # p on the axis
    assert r.continuum and not r.ls[0] and r.q[0, 0] == 0.0


def test_s2_rr_intersecting_two_solutions_and_coincident_continuum():
    r = solve("S2-RR", [Z, X], p=[0, 1, 1], q=fk_point([Z, X], [0.3, 0.4], np.array([0, 1.0, 1])))
    assert len(r.q) == 2 and not r.ls.any()
    r = solve("S2-RR", [Z, Z], p=[1, 0, 0], q=[0, 1, 0])
    assert r.continuum and not r.ls.any() and len(r.q) == 1


def test_s2_ttt_unique_and_singular_continuum():
    tw = [prismatic_twist([1, 0, 0]), prismatic_twist([1, 1, 0]), prismatic_twist([0, 1, 1])]
    r = solve("S2-TTT", tw, p=[0, 0, 0], q=[1, 2, 3])
    assert r.q.shape == (1, 3) and not r.ls[0] and not r.continuum
    tw = [prismatic_twist([1, 0, 0]), prismatic_twist([0, 1, 0]), prismatic_twist([1, 1, 0])]
    r = solve("S2-TTT", tw, p=[0, 0, 0], q=[1, 2, 0])
    assert r.continuum and not r.ls[0]
    r = solve("S2-TTT", tw, p=[0, 0, 0], q=[1, 2, 3])
    assert r.continuum and r.ls[0]


def test_s2_trr_rhino_example_step():
    """The core paper's worked example: S2-TRR in (th_1, th_3, th_4) of the Rhino-like robot."""
    tw = np.array(
        [[1, 0, 0, 0, 0, 0], [-200, 0, 200, 0, 1, 0], [-200, 0, 400, 0, 1, 0]],
        dtype=float,
    )
    # after the adjoint swap the prismatic twist is turned by th_2 about z (here th_2 = 0.5)
    tw[0, :3] = [math.cos(0.5), math.sin(0.5), 0.0]
    p = np.array([500.0, 0, 200])
    th = np.array([120.0, 0.4, -0.9])
    q = fk_point(tw, th, p)
    r = solve("S2-TRR", tw, p=p, q=q)
    assert not r.ls.any() and not r.continuum and len(r.q) == 2
    assert contains_solution(r.q, th, "TRR")


_DEGENERATE = tuple(r for r in RELATIONS if r != "general")


@pytest.mark.parametrize("code", params([c for c in CODES if len(c) >= 5]))
@budget(0.5)
@given(data=st.data())
def test_scalar_and_vectorised_paths_agree_degenerate(code, data):
    """Like the agreement test, on degenerate geometry only (every consecutive pair in a relation),
    with p at the origin or on an axis and q reachable, equal to p, or at the origin."""
    kinds = code[3:]
    tws, ps, qs = [], [], []
    for _ in range(3):
        twists, _ = data.draw(twist_lists(kinds, relations=_DEGENERATE))
        th = data.draw(joint_values(kinds))
        p = data.draw(points(twists))
        q = [fk_point(twists, th, p), p.copy(), np.zeros(3)][data.draw(st.integers(0, 2))]
        tws.append(twists)
        ps.append(p)
        qs.append(q)
    tws, ps, qs = np.array(tws), np.array(ps), np.array(qs)
    b = solve_batch(code, tws, p=ps, q=qs)
    assert b.vectorised and np.all(np.isfinite(b.q)) and b.valid.any(axis=1).all()
    for i in range(3):
        r = solve(code, tws[i], p=ps[i], q=qs[i])
        Qb, lsb = b.q[i][b.valid[i]], b.ls[i][b.valid[i]]
        note(
            f"instance {i}: scalar {r.q} ls={r.ls} cont={r.continuum}; "
            f"batch {Qb} ls={lsb} cont={b.continuum[i]}"
        )
        scale = scale_of(tws[i], ps[i], qs[i])
        for row, f in zip(Qb, lsb):
            if not f:
                assert np.linalg.norm(fk_point(tws[i], row, ps[i]) - qs[i]) <= TOL * scale
        assert bool(r.ls.all()) == bool(lsb.all())
        if r.ls.all() or r.continuum or b.continuum[i]:
            continue
        same = _same_root_check(code, tws[i], ps[i], qs[i], kinds, scale)
        for row in _exact_set(r.q, r.ls):
            assert any(same(row, other) for other in _exact_set(Qb, lsb)), f"batch misses {row}"
        for row in _exact_set(Qb, lsb):
            assert any(same(row, other) for other in _exact_set(r.q, r.ls)), f"scalar misses {row}"


def _both_paths(code, tw, p, q):
    tw, p, q = np.asarray(tw, dtype=float), np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    b = solve_batch(code, tw[None], p=p[None], q=q[None])
    return solve(code, tw, p=p, q=q), b.q[0][b.valid[0]], b.ls[0][b.valid[0]], bool(b.continuum[0])


def test_s2_rr_near_tangent_distinct_roots_both_kept():
    """Parallel axes whose circles are nearly internally tangent: two distinct roots 8e-4 apart (the
    midpoint misses by ~7e-10, under the exactness tolerance) are not merged into one."""
    tw = [[-0.0, -0.0, 0.0078125, 0.0, 1.0, 0.0], [-0.0, -0.0, -0.0, 0.0, 1.0, 0.0]]
    th = np.array([0.0, 0.00041163031113287333])
    p = np.array([1.0, 0.0, 0.0])
    q = fk_point(np.array(tw), th, p)
    r, Qb, lsb, _ = _both_paths("S2-RR", tw, p, q)
    assert len(r.q) == 2 and len(Qb) == 2 and not r.ls.any() and not lsb.any()
    assert contains_solution(r.q, th, "RR") and contains_solution(Qb, th, "RR")


def test_s2_rr_fold_roots_a_few_1e6_apart_both_kept():
    """The shadow thumb's S2-RR (parallel axes through x = 38 and x = 70, the point at x = 97.5) with
    the elbow 2.1e-6 rad from stretched: the roots th_2 = +-2.1e-6 are 4.3e-6 apart, distinct by the
    1e-6 of a recovered sample, and both exact to roundoff; their midpoint misses by 3.4e-11 (3.5e-13
    of the scale), under S2_TANGENT_MERGE.  Merged into the stretched row th_2 = 0, the thumb lost the
    in-limit root (its limits [0, pi/2]; tests/test_compiler.py)."""
    tw = [revolute_twist([0, 0, 1], [38.0, 0, 0]), revolute_twist([0, 0, 1], [70.0, 0, 0])]
    p = np.array([97.5, 0.0, 0.0])
    for th in (np.array([-0.45, 2.1364805193913288e-06]), np.array([0.3, -3e-6])):
        q = fk_point(np.array(tw), th, p)
        r, Qb, lsb, _ = _both_paths("S2-RR", tw, p, q)
        assert len(r.q) == 2 and len(Qb) == 2 and not r.ls.any() and not lsb.any()
        assert contains_solution(r.q, th, "RR") and contains_solution(Qb, th, "RR")
        assert abs(r.q[0, 1] + r.q[1, 1]) < 1e-9  # the fold's two mirror roots


def test_s2_rrt_fourfold_root_is_one_row():
    """Circle touching a cylinder from outside: one solution of multiplicity 4 in th_1, whose roots
    the eigenvalues scatter by ~eps^(1/4) ~ 2e-4; they come back as one row near the true one."""
    tw = [
        [-0.0, -1.0, -0.0, 0.0, 0.0, 1.0],
        [-0.0, -0.0, -0.0, 0.0, 1.0, 0.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
    ]
    th = np.array([0.0, math.pi / 2, 0.0])
    p = np.array([1.0, 0.0, 0.0])
    q = fk_point(np.array(tw), th, p)
    r, Qb, lsb, _ = _both_paths("S2-RRT", tw, p, q)
    assert len(r.q) == 1 and len(Qb) == 1 and not r.ls.any() and not lsb.any()
    assert contains_solution(r.q, th, "RRT", 1e-6) and contains_solution(Qb, th, "RRT", 1e-6)


def test_s2_rrt_free_joint_hidden_by_near_tangency_is_a_continuum():
    """Axes 1 and 2 skew by 1e-5, p on axis 2: th_2 is free at t = 0 (and two isolated roots sit
    2e-5 away); the root finder lands ~1e-8 off the axis; the rows are snapped onto it: continuum."""
    tw = [
        [-2.0, -0.0, 1e-05, 0.0, 1.0, 0.0],
        [-0.0, -0.0, -0.0, 0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ]
    p = np.zeros(3)
    q = fk_point(np.array(tw), np.array([math.pi / 2, math.pi / 2, 0.0]), p)
    r, Qb, lsb, cont = _both_paths("S2-RRT", tw, p, q)
    assert r.continuum and cont and not r.ls.any() and not lsb.any()
    assert any(abs(row[0] - math.pi / 2) < 1e-9 and abs(row[2]) < 1e-9 for row in r.q)


def test_s2_rrr_axes_parallel_to_roundoff_give_a_free_th1():
    """Axes 1 and 2 coincident up to a 2e-12 tilt: th_1 + th_2 is what counts (continuum), not
    'unreachable' because the height condition misses by 2e-12 for every th_1."""
    tw = [
        [-0.0, -0.0, -0.0, 0.0, 2e-12, 1.0],
        [-0.0, -0.0, -0.0, 0.0, 2e-12, 1.0],
        [-0.0, -1.0, -0.0, 0.0, 0.0, 1.0],
    ]
    tw = np.array(tw)
    tw[:2, 3:] /= np.linalg.norm(tw[0, 3:])
    p = np.zeros(3)
    q = fk_point(tw, np.array([0.0, 0.0, math.pi / 2]), p)
    r, Qb, lsb, cont = _both_paths("S2-RRR", tw, p, q)
    assert r.continuum and cont and not r.ls.any() and not lsb.any()


def test_s2_rrt_translation_perpendicular_to_axis_2_near_meeting_axes():
    """v perpendicular to axis 2 makes the eliminant a perfect square (every root double); the
    roots of the axial condition itself are used instead: the instance is solved exactly."""
    tw = [
        [-0.0, -0.0, -0.0, 0.0, 1.0, 0.0],
        [-0.0, -1e-05, -0.0, 0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ]
    p = np.array([0.0, 0.0, 1.0])
    q = fk_point(np.array(tw), np.array([0.0, 1.0, 0.0]), p)
    r, Qb, lsb, _ = _both_paths("S2-RRT", tw, p, q)
    assert not r.ls.any() and not lsb.any()
    check_exact_rows("S2-RRT", np.array(tw), p, q, r)


# Axes 1 and 2 1e-7 from meeting (or meeting at a point 1e-7 from the path of p), p 1e-7 from axis 2
# and q on a circle about axis 1 of radius ~1 that nearly touches the plane of p's circle: the
# solutions come in pairs ~1e-7 apart in th_1, and a 1e-16 error in th_1 or in a squared distance
# turns into ~0.1 rad of th_2.  (ci profile, run alone: test_recovers_drawn_joint_values[S2-RRT].)
_NEAR_MEETING = {
    # translation perpendicular to axis 2, axes skew by 1e-7: failed at 85f1b80 (th_2 0.915)
    "skew": [
        [-0.0, 1.0, -0.0, 1.0, 0.0, 0.0],
        [1e-07, -0.0, -0.0, 0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ],
    # axes meeting at (1e-7, 0, 2): the law-of-cosines path; failed at 85f1b80 (th_2 1.0004)
    "meeting": [
        [-0.0, 2.0, -0.0, 1.0, 0.0, 0.0],
        [-0.0, -1e-07, -0.0, 0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ],
}


@pytest.mark.parametrize("which", sorted(_NEAR_MEETING))
def test_s2_rrt_axes_1e7_from_meeting_recover_drawn_values(which):
    """The drawn joint values come back (scalar and vectorised paths, and S2-TRR by inversion): the
    axial condition's roots by the half-angle formula (not eigenvalues) and every difference of
    squared distances as a product, ``|a - c|^2 - |b - c|^2 = (a - b) . (a + b - 2 c)``."""
    tw = np.array(_NEAR_MEETING[which])
    th = np.array([0.0, 1.0, 0.0])
    p = np.zeros(3)
    q = fk_point(tw, th, p)
    r, Qb, lsb, _ = _both_paths("S2-RRT", tw, p, q)
    check_exact_rows("S2-RRT", tw, p, q, r)
    assert not r.ls.any() and not lsb.any() and not r.continuum
    assert contains_solution(r.q, th, "RRT", TOL) and contains_solution(Qb, th, "RRT", TOL)
    inv = -tw[::-1]
    r, Qb, lsb, _ = _both_paths("S2-TRR", inv, q, p)
    assert contains_solution(r.q, th[::-1], "TRR", TOL) and contains_solution(Qb, th[::-1], "TRR", TOL)
    if which == "meeting":  # its S2-RR step alone (geometric scalar path, algebraic vectorised path)
        r, Qb, lsb, _ = _both_paths("S2-RR", tw[:2], p, q)
        assert contains_solution(r.q, th[:2], "RR", TOL) and contains_solution(Qb, th[:2], "RR", TOL)


def test_lin_trig_roots_two_roots_1e7_apart_to_full_accuracy():
    """``1 - cos th + a sin th`` has the roots 0 and ``-2 atan(a)`` exactly; eigenvalues (trig_roots)
    place them only to ~eps / |a|."""
    from subproblems._class2 import lin_trig_roots, lin_trig_roots_batch

    for a in (4.6e-8, -3e-7, 1e-9):
        want = sorted([0.0, -2 * math.atan(a)])
        got = sorted(lin_trig_roots(1.0, -1.0, a))
        assert np.allclose(got, want, rtol=1e-12, atol=1e-22), (a, got)
        gb = np.sort(lin_trig_roots_batch(np.array([1.0]), np.array([-1.0]), np.array([a]))[0])
        assert np.allclose(gb, want, rtol=1e-12, atol=1e-22), (a, gb)
