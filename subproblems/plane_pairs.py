"""H-RR, H-RT, H-TR, H-TT: two rotate-to-plane equations sharing two joints (addition).

Equations:

    h_k^T exp(xi_1 x) exp(xi_2 y) p_k = d_k,      k = 1, 2.

Inputs: ``twists=[xi_1, xi_2]``, ``p`` and ``h`` (2, 3), ``d`` (2,).  ``h_k`` need not be unit (each
equation is divided by ``|h_k|``); the residual is the larger point-to-plane distance.  ``p_k`` may be
a direction instead of a point (then use twists through the origin: ``(0, w)``).

Why the compiler needs them (docs/design.md section 3, rule 6, and section 4 "additions"): robots with
three parallel revolute axes and no intersecting wrist (UR-type arms, planar 3R parts) have no point
fixed by three trailing axes, so rule 1 alone does not split the chain.  Projecting on the common
direction ``h`` of the parallel run removes the whole run (a revolute joint keeps a point's coordinate
along its own axis).  With one unknown left this is H-R (UR: the wrist point, fixed by axes 5-6 after
its offset, projected on the direction of axes 2-3-4 gives ``th_1``; then the tool axis projected on
the same direction gives ``th_5``; with ``th_1, th_5, th_6`` known the parallel axes leave a planar
3-link problem, S2-RR parallel plus a sum).  When **two** unknown joints stand outside the parallel
run and two known quantities project (a point fixed by the trailing axes and a tool direction, or two
points), each projection is one equation of this form in the same two unknowns: H-XY.

Method: each equation is bilinear in ``(1, cos, sin)`` of a revolute value and ``(1, t)`` of a
prismatic one; eliminating one unknown (Cramer on ``(cos x, sin x)``) leaves one polynomial (see
``subproblems/_class3_pairs.py``): degree 8 in ``exp(i y)`` for H-RR (a quartic trigonometric
polynomial; it falls to a quartic in special geometry such as UR's), degree 4 for H-RT,
and a 2x2 linear system for H-TT.

Max solutions: H-RR 8, H-RT 4, H-TR 2 (the equations are linear in the prismatic value: eliminating it
leaves one ``A cos y + B sin y = C``), H-TT 1.

Degenerate cases and what is returned:

* no exact solution: the least-squares point of the two plane distances (Levenberg-Marquardt from a
  fixed grid of starts), flagged ``ls``;
* a continuum (the eliminant vanishes identically: a normal along the axis it is carried by, a
  point on a revolute axis it is moved by, the two equations the same, H-TT with a singular system):
  one representative, flagged ``continuum``; a joint the equations do not constrain is returned as 0.

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import apply, revolute_twist, twist_exp
>>> tw = [revolute_twist([0, 0, 1], [0, 0, 0]), revolute_twist([1, 0, 0], [0, 0, 1])]
>>> p, h = np.array([[1.0, 1, 0], [0.0, 1, 2]]), np.array([[1.0, 0, 0], [0.0, 1, 1]])
>>> g = twist_exp(tw[0], 0.5) @ twist_exp(tw[1], 1.2)
>>> d = np.sum(h * apply(g, p), axis=1)
>>> r = solve("H-RR", tw, p=p, h=h, d=d)
>>> bool(np.any(np.all(np.abs(r.q - [0.5, 1.2]) < 1e-12, axis=1))), bool(r.ls.any())
(True, False)
"""

from __future__ import annotations

import numpy as np

from subproblems._class3_pairs import Pair, solve_pairs, to_solutions
from subproblems.core import SubproblemInputError, register
from subproblems.screw import twist_exp

MAX = {"H-RR": 8, "H-RT": 4, "H-TR": 2, "H-TT": 1}


def pair_plane_residual(twists, qrow, p=None, h=None, d=None, **_) -> float:
    """The larger distance of ``exp(xi_1 x) exp(xi_2 y) p_k`` from its plane ``h_k . x = d_k``."""
    g = twist_exp(twists[0], float(qrow[0])) @ twist_exp(twists[1], float(qrow[1]))
    P, H = np.asarray(p, dtype=float).reshape(2, 3), np.asarray(h, dtype=float).reshape(2, 3)
    D = np.asarray(d, dtype=float).reshape(2)
    out = 0.0
    for k in range(2):
        x = g[:3, :3] @ P[k] + g[:3, 3]
        m = float(np.abs(H[k]).max())  # (h / m: a normal ~1e-200 long does not square to 0)
        hk, dk = (H[k] / m, D[k] / m) if m > 0 else (H[k], D[k])
        hn = float(np.linalg.norm(hk))
        out = max(out, abs(D[k]) if hn == 0 else abs(float(hk @ x) - dk) / hn)
    return out


def _batch(code, tw, p=None, h=None, d=None, **_):
    tw = np.asarray(tw, dtype=float)
    n = tw.shape[0]
    if p is None or h is None or d is None:
        raise SubproblemInputError(f"{code}: needs p, h (N, 2, 3) and d (N, 2)")
    try:
        P = np.asarray(p, dtype=float).reshape(n, 2, 3)
        H = np.asarray(h, dtype=float).reshape(n, 2, 3)
        D = np.asarray(d, dtype=float).reshape(n, 2)
    except ValueError as exc:
        raise SubproblemInputError(f"{code}: p, h must be (2, 3) and d (2,) per instance") from exc
    return solve_pairs(code, Pair("H", code[2:], tw, P, H, D), MAX[code])


def _make(code):
    @register(
        code,
        MAX[code],
        batch=lambda tw, p=None, h=None, d=None, **_: _batch(code, tw, p, h, d),
        residual=pair_plane_residual,
    )
    def scalar(twists, p=None, h=None, d=None, **_):
        tw = np.asarray(twists, dtype=float)[None]
        if p is None or h is None or d is None:
            raise SubproblemInputError(f"{code}: needs p, h (2, 3) and d (2,)")
        return to_solutions(_batch(code, tw, np.asarray(p)[None], np.asarray(h)[None], np.asarray(d)[None]))

    scalar.__name__ = "solve_" + code.lower().replace("-", "_")
    scalar.__doc__ = f"Every solution of {code} (module docstring); runs the batch engine with N = 1."
    return scalar


solve_h_rr = _make("H-RR")
solve_h_rt = _make("H-RT")
solve_h_tr = _make("H-TR")
solve_h_tt = _make("H-TT")
