"""S3-RR, S3-RT, S3-TR, S3-TT: two points at given distances, moved by the same two joints.

Equations (two point/distance pairs through the same product, docs/design.md section 4):

    || exp(xi_1 x) exp(xi_2 y) p_k - q_k || = d_k,      k = 1, 2.

Inputs: ``twists=[xi_1, xi_2]``, ``p`` and ``q`` (2, 3), ``d`` (2,).

Geometry: each equation says that the point ``p_k``, carried by both joints, lies on the sphere of
radius ``d_k`` about ``q_k``; equivalently ``|| exp(xi_2 y) p_k - exp(-xi_1 x) q_k || = d_k``: a point
on a circle/line in ``y`` at distance ``d_k`` from a point on a circle/line in ``x``.  Both equations
are bilinear in ``(1, cos, sin)`` of a revolute value and ``(1, t, t^2)`` of a prismatic one, so
eliminating one unknown leaves one polynomial (see ``subproblems/_class3_pairs.py``):

* **S3-RR**: ``x`` by Cramer on ``(cos x, sin x)``, a trigonometric polynomial of degree 4 in ``y``.
  Max solutions: 8.
* **S3-RT**, **S3-TR**: the revolute value by Cramer, a polynomial of degree 6 in the prismatic one
  (two of the 8 intersections of the two curves are at infinity).  Max solutions: 6.
* **S3-TT**: the two quadrics share their quadratic part; the resultant has degree 2.  Max 2.

Degenerate cases and what is returned:

* no exact solution (the spheres cannot both be reached): the least-squares point of the two
  distance errors reached by Levenberg-Marquardt from a fixed grid of starts, flagged ``ls``;
* a continuum (the eliminant vanishes identically: e.g. ``q_1, q_2`` both on the first axis, ``p_1, p_2``
  both on the second axis, the two equations the same, coincident axes or parallel prismatic
  directions so that only a sum of the values matters): one
  representative on the solution set, flagged ``continuum``; a joint the equations do not constrain
  is returned as 0 (the Levenberg-Marquardt start);
* tangential solutions (the two curves touch) come back once, at the tangent point;
* a zero distance ``d_k`` (``p_k`` must reach ``q_k``): that equation is the point coincidence of
  class II (S2-XY of the same joints), whose points satisfying the other equation are returned.

Every instance is solved in units of its own scale: scaling all lengths scales the prismatic values.

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import apply, revolute_twist, twist_exp
>>> tw = [revolute_twist([0, 0, 1], [0, 0, 0]), revolute_twist([0, 1, 0], [1, 0, 0])]
>>> p, q = np.array([[2.0, 0, 0], [1.0, 1, 1]]), np.array([[0.0, 1, 0], [1.0, 0, 2]])
>>> g = twist_exp(tw[0], 0.3) @ twist_exp(tw[1], -0.7)
>>> d = np.linalg.norm(apply(g, p) - q, axis=1)
>>> r = solve("S3-RR", tw, p=p, q=q, d=d)
>>> bool(np.any(np.all(np.abs(r.q - [0.3, -0.7]) < 1e-12, axis=1))), bool(r.ls.any()), len(r.q) <= 8
(True, False, True)
"""

from __future__ import annotations

import numpy as np

from subproblems._class3_pairs import Pair, solve_pairs, to_solutions
from subproblems.core import SubproblemInputError, register

MAX = {"S3-RR": 8, "S3-RT": 6, "S3-TR": 6, "S3-TT": 2}


def _batch(code, tw, p=None, q=None, d=None, **_):
    tw = np.asarray(tw, dtype=float)
    n = tw.shape[0]
    if p is None or q is None or d is None:
        raise SubproblemInputError(f"{code}: needs p, q (N, 2, 3) and d (N, 2)")
    P = np.asarray(p, dtype=float).reshape(n, 2, 3)
    Q = np.asarray(q, dtype=float).reshape(n, 2, 3)
    D = np.asarray(d, dtype=float).reshape(n, 2)
    return solve_pairs(code, Pair("S3", code[3:], tw, P, Q, D), MAX[code])


def _scalar(code, twists, p, q, d):
    b = _batch(
        code,
        np.asarray(twists, dtype=float)[None],
        np.asarray(p)[None],
        np.asarray(q)[None],
        np.asarray(d)[None],
    )
    return to_solutions(b)


def _make(code):
    @register(code, MAX[code], batch=lambda tw, p=None, q=None, d=None, **_: _batch(code, tw, p, q, d))
    def scalar(twists, p, q, d):
        return _scalar(code, twists, p, q, d)

    scalar.__name__ = "solve_" + code.lower().replace("-", "_")
    scalar.__doc__ = f"Every solution of {code} (module docstring); runs the batch engine with N = 1."
    return scalar


solve_s3_rr = _make("S3-RR")
solve_s3_rt = _make("S3-RT")
solve_s3_tr = _make("S3-TR")
solve_s3_tt = _make("S3-TT")
