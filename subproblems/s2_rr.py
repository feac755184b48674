"""S2-RR: two rotations carry a point onto a point (Paden-Kahan subproblem 2, generalised to skew axes).

Equation: ``exp(xi_1 th_1) exp(xi_2 th_2) p = q`` with both twists revolute.

Geometry: the intermediate point ``x = exp(xi_2 th_2) p = exp(-xi_1 th_1) q`` lies on two circles:
``C2`` (``p`` turned about axis 2) and ``C1`` (``q`` turned about axis 1).  Each circle is a plane
(``w_i . x`` fixed) cut by a sphere centred on its axis.

* Non-parallel axes: the two planes meet in a line; the line meets each sphere in at most two points;
  the points on both circles are the solutions (intersecting axes: the classical case with a common
  sphere; skew axes: generically one point of the line is on both circles).
* Parallel, distinct axes: the planar path; both circles lie in the plane ``w . x = w . p``, and two
  coplanar circles meet in at most two points.

Max solutions: 2 (two circles meet in at most two points).

Three equations, two unknowns: for skew axes one scalar condition beyond the two unknowns must hold
(it does for reachable ``q``); the residual of every row is reported.

Vectorised (algebraic) path: with ``y(th_1) = exp(-xi_1 th_1) q``, the conditions "``y`` on the plane
of ``C2``" and "``|y - r_2| = |p - r_2|``" are two equations linear in ``(cos th_1, sin th_1)``; their
roots (each equation alone, and the 2x2 solve when it is regular) are the candidates for ``th_1``;
``th_2`` follows from S2-R.  Every candidate is polished and verified on the full equation.

Degenerate cases and what is returned:

* no exact solution (circles do not meet, or planes/heights mismatch): the best least-squares pair,
  flagged ``ls``;
* coincident axes: only ``th_1 + th_2`` matters; ``th_2 = 0`` and ``th_1`` from S2-R, ``continuum``;
* ``p`` on axis 2 (``th_2`` free) or ``q`` on axis 1 (``th_1`` free): the free angle is 0, ``continuum``.

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import revolute_twist
>>> tw = [revolute_twist([0, 0, 1], [0, 0, 0]), revolute_twist([1, 0, 0], [0, 0, 0])]
>>> r = solve("S2-RR", tw, p=[0, 0, 1], q=[1, 0, 0])
>>> np.round(r.q, 6) + 0.0, r.ls.tolist()
(array([[-1.570796, -1.570796],
       [ 1.570796,  1.570796]]), [False, False])
"""

from __future__ import annotations

import math

import numpy as np

from subproblems import tolerances as tol
from subproblems._class2 import (
    FREE_TOL,
    agreeing,
    circle_of,
    circle_of_batch,
    defer_to_scalar,
    finalize,
    finalize_batch,
    lin_trig_roots_batch,
    problem_scale,
    problem_scale_batch,
    real_quadratic_roots,
    rotation_angle,
    rotation_angle_batch,
)
from subproblems.core import BatchResult, Solution, register

PARALLEL_TOL = tol.S2_RR_PARALLEL  # subproblems/tolerances.py
NEAR_PARALLEL_TOL = tol.S2_RR_NEAR_PARALLEL


def _planar_points(w1, r1, r2, p, q) -> list[np.ndarray]:
    """The two meeting points of the circles of ``p`` (about axis 2) and ``q`` (about axis 1) in the
    plane of ``p`` normal to ``w1`` (parallel axes)."""
    c1 = r1 + w1 * (w1 @ (p - r1))  # centres of the two circles in the plane of p
    c2 = r2 + w1 * (w1 @ (p - r2))
    qr = (q - r1) - w1 * (w1 @ (q - r1))
    rho1, rho2 = float(np.linalg.norm(qr)), float(np.linalg.norm(p - c2))
    e = c1 - c2
    de = float(np.linalg.norm(e))
    if de == 0.0:
        return []
    e = e / de
    a = (rho2**2 - rho1**2 + de**2) / (2 * de)
    h = math.sqrt(max(rho2**2 - a * a, 0.0))
    n = np.cross(w1, e)
    return [c2 + a * e + h * n, c2 + a * e - h * n]


def rr_candidates(twists, p, q, scale: float) -> tuple[list, bool]:
    """Geometric candidates ``[((th_1, th_2), free), ...]`` and the coincident-axes flag."""
    x1, x2 = twists
    w1, w2 = x1[3:], x2[3:]
    r1, r2 = np.cross(w1, x1[:3]), np.cross(w2, x2[:3])
    d = np.cross(w1, w2)
    nd = float(np.linalg.norm(d))
    xs: list[np.ndarray] = []
    if nd <= PARALLEL_TOL:
        off = (r2 - r1) - w1 * (w1 @ (r2 - r1))
        if np.linalg.norm(off) <= FREE_TOL * scale:  # coincident axes: th_1 + th_2 is what counts
            th1, free = rotation_angle(x1, p, q, scale)
            return [((th1, 0.0), True)], True
    if nd <= NEAR_PARALLEL_TOL:
        # parallel, or so nearly (sine <= 1e-6) that the planar construction's roots are exact to the
        # tolerance too: the skew one below finds one of the two (audit S2-RR near, sine 1e-10)
        xs += _planar_points(w1, r1, r2, p, q)
    if nd > PARALLEL_TOL:
        d = d / nd
        h1, h2 = float(w1 @ q), float(w2 @ p)
        x0 = (h1 * np.cross(w2, d) + h2 * np.cross(d, w1)) / (float(np.cross(w1, w2) @ d))
        # |x0 + s d - c|^2 = |a - c|^2 with the constant |x0 - c|^2 - |a - c|^2 as a product: the
        # difference of squares cancels to ~eps |a - c|^2 absolute, which a point near the other
        # axis turns into a wrong angle (axes 1e-7 from meeting, tangent line)
        for c, a in ((r1, q), (r2, p)):
            b = float(d @ (x0 - c))
            for s in real_quadratic_roots(1.0, 2 * b, float((x0 - a) @ (x0 + a - 2 * c))):
                xs.append(x0 + s * d)
    out = []
    for x in xs:
        th2, f2 = rotation_angle(x2, p, x, scale)
        th1, f1 = rotation_angle(x1, x, q, scale)
        out.append(((th1, th2), f1 or f2))
    return out, False


@register("S2-RR", 2, batch=lambda tw, p, q: defer_to_scalar("S2-RR", solve_s2_rr_batch(tw, p, q), tw, p, q))
@agreeing("S2-RR", lambda tw, p, q: solve_s2_rr_batch(tw, p, q))
def solve_s2_rr(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 th_1) exp(xi_2 th_2) p = q`` (see the module docstring)."""
    scale = problem_scale(twists, p, q)
    cands, cont = rr_candidates(twists, p, q, scale)
    return finalize("S2-RR", twists, p, q, cands, continuum=cont)


def rr_theta1_candidates_batch(x1, x2, p, q, scale):
    """Algebraic candidates for ``th_1`` (N, 6) and the coincident-axes flag (N,)."""
    c0, cc, cs = circle_of_batch(x1, q)  # y(th) = c0 + cc cos th - cs sin th
    w2 = x2[:, 3:]
    r2 = np.cross(w2, x2[:, :3])
    m1 = np.stack([np.sum(w2 * cc, -1), -np.sum(w2 * cs, -1)], -1)
    e1 = np.sum(w2 * (p - c0), -1)
    k = c0 - r2
    m2 = 2 * np.stack([np.sum(k * cc, -1), -np.sum(k * cs, -1)], -1)
    e2 = np.sum((p - r2) ** 2, -1) - np.sum(k * k, -1) - np.sum(cc * cc, -1)
    # roots of -e_i + m_i . (cos, sin) by the half-angle formula, with the values at th = 0 free of
    # the cancellation in e_i (y(0) = q): two roots ~1e-7 apart keep full accuracy (see lin_trig_roots)
    at1 = np.sum(w2 * (q - p), -1)
    at2 = np.sum((q - p) * (q + p - 2 * r2), -1)
    roots = [
        lin_trig_roots_batch(-e1, m1[:, 0], m1[:, 1], at1),
        lin_trig_roots_batch(-e2, m2[:, 0], m2[:, 1], at2),
    ]
    M = np.stack([m1, m2], -2)
    det = np.linalg.det(M)
    regular = np.abs(det) > 1e-12 * (np.abs(M).max(axis=(-1, -2)) ** 2 + 1e-300)
    Ms = np.where(regular[:, None, None], M, np.eye(2))
    cs_ = np.linalg.solve(Ms, np.stack([e1, e2], -1)[..., None])[..., 0]
    roots.append(np.arctan2(cs_[:, 1], cs_[:, 0])[:, None])
    th_rep, _ = rotation_angle_batch(x1, p, q, scale)
    roots.append(th_rep[:, None])
    w1 = x1[:, 3:]
    r1 = np.cross(w1, x1[:, :3])
    off = (r2 - r1) - w1 * np.sum(w1 * (r2 - r1), -1, keepdims=True)
    coincident = (np.linalg.norm(np.cross(w1, w2), axis=-1) <= PARALLEL_TOL) & (
        np.linalg.norm(off, axis=-1) <= FREE_TOL * scale
    )
    return np.concatenate(roots, axis=1), coincident


def solve_s2_rr_batch(tw, p, q) -> BatchResult:
    """Vectorised S2-RR (algebraic path, see the module docstring)."""
    x1, x2 = tw[:, 0], tw[:, 1]
    scale = problem_scale_batch(tw, p, q)
    th1, coincident = rr_theta1_candidates_batch(x1, x2, p, q, scale)
    C = th1.shape[1]
    c0, cc, cs = circle_of_batch(x1, q)
    y = c0[:, None] + cc[:, None] * np.cos(th1)[..., None] - cs[:, None] * np.sin(th1)[..., None]
    sc = scale[:, None]
    th2, f2 = rotation_angle_batch(x2[:, None], p[:, None], y, sc)
    f1 = np.linalg.norm(cc, axis=-1)[:, None] <= FREE_TOL * sc
    th2 = np.where(coincident[:, None] & (np.arange(C) == C - 1), 0.0, th2)
    cand = np.stack([th1, th2], -1)
    return finalize_batch("S2-RR", tw, p, q, cand, f1 | f2, coincident)


_ = circle_of  # scalar twin of circle_of_batch, used by the other class II modules
