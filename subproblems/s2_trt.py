"""S2-TRT: translate, rotate, translate a point onto a point.

Equation: ``exp(xi_1 t_1) exp(xi_2 th) exp(xi_3 t_3) p = q`` (prismatic, revolute, prismatic).

Geometry: with ``a = p - r``, ``b = q - r`` (``r`` on the axis ``w``), the vector ``a + t_3 v_3`` turned
about ``w`` must equal ``b - t_1 v_1``.  A rotation about ``w`` exists iff the two vectors have the same
axial component and the same length:

* ``w . v_1 t_1 + w . v_3 t_3 = w . (b - a)``: a line in the ``(t_1, t_3)`` plane;
* ``|a + t_3 v_3|^2 = |b - t_1 v_1|^2``: a conic; the line meets it in at most two points;

then ``th`` from S2-R.

Max solutions: 2.

Degenerate cases and what is returned:

* the line misses the conic (unreachable): its point closest to it, flagged ``ls``;
* the conic contains the line (e.g. both translations along the axis): ``(t_1, t_3)`` on the line
  nearest the origin of the ``(t_1, t_3)`` plane, flagged ``continuum``;
* both translations perpendicular to the axis (planar chain): ``t_3 = 0`` if the circle of ``p`` then
  reaches the line ``q - t_1 v_1``, otherwise the smallest ``t_3`` that makes it reach; then S2-TR;
  flagged ``continuum``;
* the moved point on the axis: ``th = 0``, flagged ``continuum``.

Vectorised path: the same construction for all instances at once (two slots for the line meeting
the conic; six for the planar case: two ``t_3`` times the three S2-TR candidates), then the common
polishing and verification of ``finalize_batch``.

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import prismatic_twist, revolute_twist
>>> tw = [prismatic_twist([0, 0, 1]), revolute_twist([0, 0, 1], [0, 0, 0]), prismatic_twist([1, 0, 1])]
>>> r = solve("S2-TRT", tw, p=[1, 0, 0], q=[0, 2, 3])
>>> np.round(r.q, 6) + 0.0, r.ls.tolist()
(array([[ 2.      ,  1.570796,  1.414214],
       [ 6.      , -1.570796, -4.242641]]), [False, False])
"""

from __future__ import annotations

import math

import numpy as np

from subproblems._class2 import (
    COEF_TOL,
    agreeing,
    defer_to_scalar,
    finalize,
    finalize_batch,
    problem_scale,
    problem_scale_batch,
    quadratic_roots_batch,
    real_quadratic_roots,
    rotation_angle,
    rotation_angle_batch,
)
from subproblems.core import BatchResult, Solution, register
from subproblems.s2_rt import tr_candidates, tr_candidates_batch


def trt_candidates(twists, p, q, scale):
    x1, x2, x3 = twists
    v1, v3, w = x1[:3], x3[:3], x2[3:]
    r = np.cross(w, x2[:3])
    a, b = p - r, q - r
    al1, al3 = float(w @ v1), float(w @ v3)
    na = math.hypot(al1, al3)
    if na <= COEF_TOL:  # both translations perpendicular to the axis: planar, a continuum
        ap = a - w * (w @ a)
        bp = b - w * (w @ b)
        dq = float(np.linalg.norm(bp - v1 * (v1 @ bp)))
        t3s = [0.0]
        if float(np.linalg.norm(ap)) < dq:
            t3s = real_quadratic_roots(1.0, 2 * float(ap @ v3), float(ap @ ap) - dq * dq)
        out = []
        for t3 in t3s:
            for (t1, th), free in tr_candidates([x1, x2], p + t3 * v3, q, scale):
                out.append(((t1, th, t3), free))
        return out, True
    beta = float(w @ (b - a))
    t10, t30 = beta * al1 / na**2, beta * al3 / na**2
    d1, d3 = -al3 / na, al1 / na
    A3, B3 = a + v3 * t30, v3 * d3
    A1, B1 = b - v1 * t10, v1 * d1
    coef = (float(B3 @ B3 - B1 @ B1), 2 * float(A3 @ B3 + A1 @ B1), float(A3 @ A3 - A1 @ A1))
    cont = max(abs(c) for c in coef) <= COEF_TOL * scale * scale
    ss = [] if cont else real_quadratic_roots(*coef)
    out = []
    for s in ss or [0.0]:
        t1, t3 = t10 + d1 * s, t30 + d3 * s
        th, free = rotation_angle(x2, p + t3 * v3, q - t1 * v1, scale)
        out.append(((t1, th, t3), free))
    return out, cont


def _dot(a, b):
    return np.sum(a * b, -1)


@np.errstate(all="ignore")
def trt_batch(tw, p, q) -> BatchResult:
    """Vectorised S2-TRT: the construction of :func:`trt_candidates` in six slots per instance."""
    x1, x2, x3 = tw[:, 0], tw[:, 1], tw[:, 2]
    v1, v3, w = x1[:, :3], x3[:, :3], x2[:, 3:]
    scale = problem_scale_batch(tw, p, q)
    N = len(p)
    r = np.cross(w, x2[:, :3])
    a, b = p - r, q - r
    al1, al3 = _dot(w, v1), _dot(w, v3)
    na = np.hypot(al1, al3)
    planar = na <= COEF_TOL
    # general: the line in the (t_1, t_3) plane meets the conic
    nz = np.where(planar, 1.0, na)
    beta = _dot(w, b - a)
    t10, t30 = beta * al1 / nz**2, beta * al3 / nz**2
    d1, d3 = -al3 / nz, al1 / nz
    A3, B3 = a + v3 * t30[:, None], v3 * d3[:, None]
    A1, B1 = b - v1 * t10[:, None], v1 * d1[:, None]
    coef = (_dot(B3, B3) - _dot(B1, B1), 2 * (_dot(A3, B3) + _dot(A1, B1)), _dot(A3, A3) - _dot(A1, A1))
    cmax = np.maximum.reduce([np.abs(c) for c in coef])
    flat = cmax <= COEF_TOL * scale * scale
    ss = np.where(flat[:, None], 0.0, quadratic_roots_batch(*coef))  # (N, 2)
    t1, t3 = t10[:, None] + d1[:, None] * ss, t30[:, None] + d3[:, None] * ss
    src = p[:, None] + t3[..., None] * v3[:, None]
    dst = q[:, None] - t1[..., None] * v1[:, None]
    th, free = rotation_angle_batch(x2[:, None], src, dst, scale[:, None])
    gen = np.stack([t1, th, t3], -1)
    gen = np.concatenate([gen, np.full((N, 4, 3), np.nan)], axis=1)
    gen_free = np.concatenate([free, np.zeros((N, 4), dtype=bool)], axis=1)
    # planar: t_3 = 0 when the circle of p reaches the line q - t_1 v_1, else the smallest t_3 that
    # makes it reach; then S2-TR for (t_1, th)
    ap = a - w * _dot(w, a)[:, None]
    bp = b - w * _dot(w, b)[:, None]
    dq = np.linalg.norm(bp - v1 * _dot(v1, bp)[:, None], axis=-1)
    reach = np.linalg.norm(ap, axis=-1) >= dq
    t3s = quadratic_roots_batch(np.ones(N), 2 * _dot(ap, v3), _dot(ap, ap) - dq * dq)
    t3s = np.where(reach[:, None], np.array([0.0, np.nan]), t3s)
    pl, pl_free = [], []
    for k in range(2):
        c, f = tr_candidates_batch(x1, x2, p + np.nan_to_num(t3s[:, k, None]) * v3, q, scale)
        t3k = np.broadcast_to(t3s[:, k, None], c.shape[:2])
        pl.append(np.stack([c[..., 0], c[..., 1], t3k], -1))
        pl_free.append(f)
    pl, pl_free = np.concatenate(pl, axis=1), np.concatenate(pl_free, axis=1)
    cand = np.where(planar[:, None, None], pl, gen)
    cfree = np.where(planar[:, None], pl_free, gen_free)
    return finalize_batch("S2-TRT", tw, p, q, cand, cfree, planar | (flat & ~planar))


@register("S2-TRT", 2, batch=lambda tw, p, q: defer_to_scalar("S2-TRT", trt_batch(tw, p, q), tw, p, q))
@agreeing("S2-TRT", trt_batch)
def solve_s2_trt(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 t_1) exp(xi_2 th) exp(xi_3 t_3) p = q`` (module docstring)."""
    cands, cont = trt_candidates(twists, p, q, problem_scale(twists, p, q))
    return finalize("S2-TRT", twists, p, q, cands, continuum=cont)
