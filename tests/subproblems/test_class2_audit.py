"""Class II regressions from the black-box audit (``benchmarks/subproblem_audit.py``): instances that
came back wrong, each built from drawn joint values (``q`` by forward kinematics)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from subproblems import solve, solve_batch
from subproblems._class2 import on_continuum_rows, problem_scale
from subproblems.screw import prismatic_twist, revolute_twist
from tests.strategies import contains_solution
from tests.subproblems.test_class2 import check_exact_rows, fk_point

TOL = 1e-9


def _both(code, tw, p, q):
    b = solve_batch(code, tw[None], p=p[None], q=q[None])
    return solve(code, tw, p=p, q=q), b.q[0][b.valid[0]], b.ls[0][b.valid[0]], bool(b.continuum[0])


def _rev(w, r, s=1.0):
    w = np.asarray(w, dtype=float)
    return revolute_twist(w / np.linalg.norm(w), s * np.asarray(r, dtype=float))


def test_s2_rrr_axes_1_and_3_one_line_th2_zero_is_a_continuum():
    """Axes 1 and 3 the same line and th_2 = 0: only th_1 + th_3 counts (audit S2-RRR related #65,
    at scale 1e3: the quartic's vanishing was judged against an absolute reference, two points of
    the continuum came back unflagged)."""
    s = 1e3
    a1 = _rev([0.25, 0.83, 0.5], [0.3, -0.7, 0.4], s)
    tw = np.array([a1, _rev([0.26, 0.44, -0.86], [0.1, 0.6, -0.2], s), a1])
    th = np.array([math.pi / 2, 0.0, 1.2133])
    p = s * np.array([-0.77, -0.29, 1.19])
    q = fk_point(tw, th, p)
    r, Qb, lsb, cont = _both("S2-RRR", tw, p, q)
    assert r.continuum and cont and not r.ls.any() and not lsb.any()
    for row in r.q:  # the representative is a solution
        assert np.linalg.norm(fk_point(tw, row, p) - q) <= TOL * problem_scale(tw, p, q)


def test_s2_rrr_small_scale_antiparallel_axes_is_solved_exactly():
    """Scale 1e-3, axes 1 and 3 antiparallel (not the same line): reachable, four exact roots (audit
    S2-RRR related #86: the eliminant looked identically zero against a unit reference; one row
    came back flagged ls and continuum)."""
    tw = np.array(
        [
            [
                -1.1570147561111826e-04,
                -4.5932915688834408e-04,
                7.8636980363186383e-04,
                0.52224757555083612,
                -0.76760847590097525,
                -0.37153021082578952,
            ],
            [
                -8.3115129719153183e-04,
                2.3125872930984911e-04,
                3.8946768715476392e-04,
                0.37426240419734413,
                -0.18516310938771074,
                0.90864859859370195,
            ],
            [
                1.5997709934284068e-04,
                3.4050453086160456e-04,
                -4.7863271011353074e-04,
                -0.52224757555083612,
                0.76760847590097525,
                0.37153021082578952,
            ],
        ]
    )
    th = np.array([math.pi / 2, 0.9984976868912128, 1.2996302133160356])
    p = np.array([-0.0008704477665595019, 0.000623195056128381, -0.00017512980709671135])
    q = fk_point(tw, th, p)
    r, Qb, lsb, cont = _both("S2-RRR", tw, p, q)
    assert not r.continuum and not cont and not r.ls.any() and not lsb.any()
    check_exact_rows("S2-RRR", tw, p, q, r)
    assert contains_solution(r.q, th, "RRR", TOL) and contains_solution(Qb, th, "RRR", TOL)


def test_s2_rtr_translation_along_coincident_axes_is_a_continuum():
    """Axis 3 = axis 1 reversed and the translation along it: only th_1 - th_3 and t count (audit
    S2-RTR related #94)."""
    s = 1e3
    w = np.array([0.79878824560472694, -0.044095533595678596, -0.59999410213820836])
    a1 = _rev(w, [0.1, 0.3, 0.2], s)
    tw = np.array([a1, prismatic_twist(w), -a1])
    th = np.array([2.75, 0.0, math.pi])
    p = s * np.array([0.61, -0.96, 0.83])
    q = fk_point(tw, th, p)
    r, Qb, lsb, cont = _both("S2-RTR", tw, p, q)
    assert r.continuum and cont and not r.ls.any() and not lsb.any()


def test_continuum_probe_tells_a_curve_of_solutions_from_a_double_root():
    """``on_continuum_rows`` on points of a continuum (S2-RR, coincident axes) and on a tangency (two
    circles touching: a double root, singular Jacobian, isolated)."""
    tw = np.array([_rev([0, 0, 1], [0, 0, 0]), _rev([0, 0, 1], [0, 0, 0])])
    p = np.array([1.0, 0.0, 0.3])
    q = fk_point(tw, np.array([0.4, 0.5]), p)
    rows = np.array([[0.4, 0.5], [0.9, 0.0]])
    assert on_continuum_rows(
        "RR", tw[None].repeat(2, 0), p[None].repeat(2, 0), q[None].repeat(2, 0), rows, np.ones(2)
    ).all()
    # parallel axes 2 apart, p 1 from axis 2, q 1 from axis 1: the circles touch at (1, 0, 0)
    tw = np.array([_rev([0, 0, 1], [0, 0, 0]), _rev([0, 0, 1], [2, 0, 0])])
    th = np.array([0.0, math.pi])
    p = np.array([3.0, 0.0, 0.0])
    q = fk_point(tw, th, p)
    assert np.linalg.norm(q - [1.0, 0.0, 0.0]) < 1e-15
    assert not on_continuum_rows("RR", tw[None], p[None], q[None], th[None], np.ones(1)).any()


# Exact tangencies (double roots) on the lattice: the two computed roots straddle the tangent point by
# ~sqrt(eps); the finalizer kept the first of the pair (within DEDUP_TOL) instead of their centroid.
_TANGENT = {
    # S2-TTR: th_3 = -pi/2 came back -1.5707963121 (audit S2-TTR lattice #6)
    "S2-TTR": (
        [
            [1.0, 0, 0, 0, 0, 0],
            [0.7071067811865475, 0.7071067811865475, 0, 0, 0, 0],
            [-1.0, 0, 0.5, 0, 1.0, 0],
        ],
        [1.0, -0.5, 1.0],
        [1.0168289074386525, 0.3534322286554472, -math.pi / 2],
    ),
    # S2-RR: th_2 = pi came back 1.7e-8 off (audit n=300 seed 1, S2-RR lattice #27)
    "S2-RR": (
        [
            [0.5, 0, 0.5, 0, -1.0, 0],
            [
                0.35355339059327373,
                0.35355339059327373,
                -0.35355339059327373,
                0,
                0.7071067811865475,
                0.7071067811865475,
            ],
        ],
        [-0.5, -0.5, 0.5],
        [0.2229591457793645, math.pi],
    ),
}


@pytest.mark.parametrize("code", sorted(_TANGENT))
def test_exact_double_root_comes_back_as_the_tangent_point(code):
    tw, p, th = (np.array(a, dtype=float) for a in _TANGENT[code])
    q = fk_point(tw, th, p)
    r, Qb, lsb, cont = _both(code, tw, p, q)
    kinds = code.split("-")[1]
    assert not r.continuum and not cont and not r.ls.any() and not lsb.any()
    check_exact_rows(code, tw, p, q, r)
    assert contains_solution(r.q, th, kinds, 1e-12) and contains_solution(Qb, th, kinds, 1e-12)


def test_s2_ttt_directions_4e10_from_parallel_solved_exactly():
    """Directions 1 and 2 4e-10 apart (audit S2-TTT near #3, n=300 seed 1): the explicit pseudo-inverse
    left a residual of 2e-8 and the reachable instance came back ls; the solve through the SVD
    leaves ~eps.  The drawn values are determined only to ~cond * eps ~ 1e-7 by the float data."""
    tw = np.zeros((3, 6))
    tw[:, :3] = [
        [0.19615169010817946, -0.675052784291457, -0.71121603812629],
        [0.1961516909825861, -0.675052784499292, -0.7112160376878637],
        [0.12503527040912887, -0.16151268140078143, -0.9789176854569773],
    ]
    th = np.array([0.0, -1.0245352417610305, -0.4969888287951316])
    p = np.array([-1.0498676995951572, 1.4337421064834244, 1.4777796665183867])
    q = fk_point(tw, th, p)
    r, Qb, lsb, cont = _both("S2-TTT", tw, p, q)
    assert not r.ls.any() and not lsb.any() and not r.continuum and not cont
    check_exact_rows("S2-TTT", tw, p, q, r)
    assert contains_solution(r.q, th, "TTT", 1e-6) and contains_solution(Qb, th, "TTT", 1e-6)
