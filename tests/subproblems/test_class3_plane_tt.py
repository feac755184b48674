"""H-TT is a 2x2 linear system: one solution when it is nonsingular, a continuum only when singular.

Before, H-TT went through the pair engine, whose eliminant (the resultant of two quadratics) vanishes
identically for linear equations: every instance was answered by Levenberg-Marquardt and flagged
``continuum``, so the drawn values were never checked.  Every instance here is built from drawn values.
"""

from __future__ import annotations

import numpy as np

from subproblems import solve, solve_batch
from subproblems.screw import prismatic_twist

from ._checks3 import check_instance, fk_point


def _instance(tw, th, P, H):
    tw, P, H = np.asarray(tw, float), np.asarray(P, float), np.asarray(H, float)
    return tw, {"p": P, "h": H, "d": np.array([H[k] @ fk_point(tw, th, P[k]) for k in range(2)])}


def test_nonsingular_is_one_solution_not_a_continuum():
    rng = np.random.default_rng(3)
    for _ in range(20):
        tw = [prismatic_twist(rng.normal(size=3)) for _ in range(2)]
        th = rng.uniform(-2, 2, 2)
        tw, inputs = _instance(tw, th, rng.normal(size=(2, 3)), rng.normal(size=(2, 3)))
        r = check_instance("H-TT", "TT", tw, inputs, th)
        assert not r.continuum and not r.ls.any() and np.allclose(r.q[0], th, atol=1e-9), (r, th)


def test_singular_consistent_is_a_continuum_inconsistent_is_ls():
    x, y = prismatic_twist([1, 0, 0]), prismatic_twist([0, 1, 0])
    # both planes normal to x: y free, x = 0.3
    tw, inputs = _instance([x, y], [0.3, -0.8], [[0, 0, 0], [1, 2, 3]], [[1, 0, 0], [-2, 0, 0]])
    r = solve("H-TT", tw, **inputs)
    assert r.continuum and not r.ls[0] and abs(r.q[0, 0] - 0.3) < 1e-12 and r.q[0, 1] == 0.0, r
    # the same planes at inconsistent offsets: least squares
    r = solve("H-TT", tw, p=inputs["p"], h=inputs["h"], d=[0.3, 0.0])
    assert r.continuum and r.ls[0], r
    b = solve_batch("H-TT", tw[None], p=inputs["p"][None], h=inputs["h"][None], d=np.array([[0.3, 0.0]]))
    assert b.continuum[0] and b.ls[0, 0]


def test_prismatic_parallel_to_both_planes_to_roundoff():
    # audit (seed 1, related #29), scale 1e3: the second direction parallel to both planes up to
    # roundoff (h . v2 ~ 1e-16), p = 0, so d ~ 1e-13 comes from that roundoff times the drawn travel.
    # Before: the continuum representative missed the equations by 1.2e-14 and was flagged ls
    tw = np.array(
        [
            [-0.675271659631298, 0.03138590702986636, 0.7369010181419925, 0.0, 0.0, 0.0],
            [0.6761500847735945, 0.42549268976058635, 0.6014790385549297, 0.0, 0.0, 0.0],
        ]
    )
    H = [
        [1.305191897301194, 0.06607894764628254, -1.5139708332386295],
        [1.350543319262596, -0.06277181405973271, -1.473802036283985],
    ]
    th = np.array([0.0, -1028.8316655067877])
    tw, inputs = _instance(tw, th, np.zeros((2, 3)), H)
    r = check_instance("H-TT", "TT", tw, inputs, th)
    assert r.continuum and not r.ls.any(), r
