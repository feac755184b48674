"""S2-TTR and S2-RTT: two translations and a rotation carry a point onto a point.

Equations: ``exp(xi_1 t_1) exp(xi_2 t_2) exp(xi_3 th) p = q`` (S2-TTR) and
``exp(xi_1 th) exp(xi_2 t_2) exp(xi_3 t_3) p = q`` (S2-RTT), the latter solved as S2-TTR through
inversion (``exp(-xi_3 t_3) exp(-xi_2 t_2) exp(-xi_1 th) q = p``).

Geometry (S2-TTR): translations commute, so ``q - exp(xi_3 th) p`` must lie in the plane spanned by
``v_1, v_2``.  With ``n = v_1 x v_2``, "rotate a point to a plane": ``n . exp(xi_3 th) p = n . q`` is
linear in ``(cos th, sin th)`` (at most two angles), then ``t_1, t_2`` decompose the rest (S2-TT).

Max solutions: 2.

Degenerate cases and what is returned:

* the circle of ``p`` misses the plane: the angle bringing it closest, then least-squares
  translations, flagged ``ls``;
* ``n`` parallel to the axis, or ``p`` on the axis: the plane condition holds for every angle (or
  none): ``th = 0``, flagged ``continuum`` (``ls`` if it holds for none); likewise when it holds to
  within the exactness tolerance for every angle (an axis nearly parallel to ``n``);
* parallel translations (``v_1 = +-v_2``): only ``t_1 +- t_2`` matters: ``t_2 = 0`` and S2-TR for
  ``(t_1, th)``, flagged ``continuum``.

Vectorised path: the same construction for all instances at once (the two roots of the plane
condition, or the S2-TR candidates of the parallel case, in fixed slots), then the common polishing
and verification of ``finalize_batch``.

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import prismatic_twist, revolute_twist
>>> tw = [prismatic_twist([1, 0, 0]), prismatic_twist([0, 1, 0]), revolute_twist([1, 0, 0], [0, 0, 0])]
>>> r = solve("S2-TTR", tw, p=[0, 0, 1], q=[2, 3, 0])
>>> np.round(r.q, 6) + 0.0
array([[ 2.      ,  2.      , -1.570796],
       [ 2.      ,  4.      ,  1.570796]])
"""

from __future__ import annotations

import numpy as np

from subproblems._class2 import (
    COEF_TOL,
    EXACT_TOL,
    agreeing,
    circle_of,
    circle_of_batch,
    defer_to_scalar,
    finalize,
    finalize_batch,
    inverted,
    inverted_batch,
    problem_scale,
    problem_scale_batch,
    revert,
    revert_batch,
    rotation_angle,
    rotation_angle_batch,
    trig_roots,
    trig_roots_batch,
)
from subproblems.core import BatchResult, Solution, register
from subproblems.s2_rr import PARALLEL_TOL
from subproblems.s2_rt import tr_candidates, tr_candidates_batch


def plane_normal(v1, v2):
    """``v_1 x v_2`` computed as ``v_1 x (v_2 -+ v_1)``, accurate for nearly (anti)parallel directions.

    The difference of two close directions is exact in floating point, while the products in
    ``np.cross(v1, v2)`` round to ~1e-16 of |v1||v2|: at an angle of 1e-12 the normal would tilt by
    ~1e-4 rad and the plane condition would miss real roots (answers flagged ls far from them).
    """
    sign = np.where(np.sum(v1 * v2, -1) < 0, -1.0, 1.0)[..., None]
    return np.cross(v1, v2 - sign * v1)


def ttr_candidates(twists, p, q, scale):
    x1, x2, x3 = twists
    v1, v2 = x1[:3], x2[:3]
    n = plane_normal(v1, v2)
    nn = float(np.linalg.norm(n))
    if nn <= PARALLEL_TOL:
        return [((t1, 0.0, th), free) for (t1, th), free in tr_candidates([x1, x3], p, q, scale)], True
    n = n / nn
    c0, cc, cs = circle_of(x3, p)
    f0, c1, s1 = float(n @ (c0 - q)), float(n @ cc), float(n @ cs)
    # With the translations solved by least squares, the whole residual is |f0 + c1 cos + s1 sin|.
    # When it is within EXACT_TOL * scale for every angle (e.g. an axis tilted from the plane's
    # normal by ~1e-10), every angle is an exact solution: a continuum at the exactness level.
    # Roots of such a tiny sinusoid are roundoff (a double root splits by ~1e-3), not solutions.
    flat = abs(f0) + float(np.hypot(c1, s1)) <= EXACT_TOL * scale
    roots = None if flat else trig_roots(f0, c1, s1, ref=scale)
    cont = roots is None
    if roots == []:  # p on the axis, off the plane: unreachable; th = 0, least-squares translations
        roots = [0.0]
    V = np.column_stack([v1, v2])
    out = []
    for th in [0.0] if cont else roots:
        _, free = rotation_angle(x3, p, q, scale)
        z = c0 + cc * np.cos(th) + cs * np.sin(th)
        t = np.linalg.lstsq(V, q - z, rcond=None)[0]
        out.append(((float(t[0]), float(t[1]), th), free))
    return out, cont


@np.errstate(all="ignore")
def ttr_batch(tw, p, q) -> BatchResult:
    """Vectorised S2-TTR: the construction of :func:`ttr_candidates` in three slots per instance."""
    x1, x2, x3 = tw[:, 0], tw[:, 1], tw[:, 2]
    v1, v2 = x1[:, :3], x2[:, :3]
    scale = problem_scale_batch(tw, p, q)
    n = plane_normal(v1, v2)
    nn = np.linalg.norm(n, axis=-1)
    par = nn <= PARALLEL_TOL
    n = n / np.where(par, 1.0, nn)[:, None]
    c0, cc, cs = circle_of_batch(x3, p)
    f0, c1, s1 = np.sum(n * (c0 - q), -1), np.sum(n * cc, -1), np.sum(n * cs, -1)
    h = np.hypot(c1, s1)
    flat = np.abs(f0) + h <= EXACT_TOL * scale
    mx = np.maximum(np.abs(f0), h / 2)
    none = (mx <= COEF_TOL * scale) | (mx == 0.0)  # trig_roots: identically zero
    const = ~none & (h / 2 <= COEF_TOL * mx)  # a non-zero constant: no root, th = 0 (scalar path)
    cont = par | flat | none
    z = np.zeros_like(f0)
    roots = trig_roots_batch(np.stack([f0, c1, s1, z, z], -1))[:, :2]
    zero_only = cont | const
    th = np.where(zero_only[:, None], np.array([0.0, np.nan]), roots)  # (N, 2)
    pt = c0[:, None] + cc[:, None] * np.cos(th)[..., None] + cs[:, None] * np.sin(th)[..., None]
    d = q[:, None] - pt
    b1, b2 = np.sum(v1[:, None] * d, -1), np.sum(v2[:, None] * d, -1)
    c12 = np.sum(v1 * v2, -1)[:, None]
    det = np.where(par, 1.0, nn * nn)[:, None]
    t1, t2 = (b1 - c12 * b2) / det, (b2 - c12 * b1) / det
    _, free = rotation_angle_batch(x3, p, q, scale)
    cand = np.stack([t1, t2, th], -1)
    cand = np.concatenate([cand, np.full((len(f0), 1, 3), np.nan)], axis=1)  # (N, 3, 3)
    # parallel translations: S2-TR for (t_1, th) with t_2 = 0
    tr, tr_free = tr_candidates_batch(x1, x3, p, q, scale)
    tr3 = np.stack([tr[..., 0], np.zeros_like(tr[..., 0]), tr[..., 1]], -1)
    cand = np.where(par[:, None, None], tr3, cand)
    cfree = np.where(par[:, None], tr_free, free[:, None])
    return finalize_batch("S2-TTR", tw, p, q, cand, cfree, cont)


def _rtt_batch(tw, p, q) -> BatchResult:
    return revert_batch(ttr_batch(inverted_batch(tw), q, p), "S2-RTT")


@register("S2-TTR", 2, batch=lambda tw, p, q: defer_to_scalar("S2-TTR", ttr_batch(tw, p, q), tw, p, q))
@agreeing("S2-TTR", ttr_batch)
def solve_s2_ttr(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 t_1) exp(xi_2 t_2) exp(xi_3 th) p = q`` (module docstring)."""
    cands, cont = ttr_candidates(twists, p, q, problem_scale(twists, p, q))
    return finalize("S2-TTR", twists, p, q, cands, continuum=cont)


@register("S2-RTT", 2, batch=lambda tw, p, q: defer_to_scalar("S2-RTT", _rtt_batch(tw, p, q), tw, p, q))
@agreeing("S2-RTT", lambda tw, p, q: _rtt_batch(tw, p, q))
def solve_s2_rtt(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 th) exp(xi_2 t_2) exp(xi_3 t_3) p = q``, by inversion to S2-TTR."""
    return revert(solve_s2_ttr(inverted(twists), q, p))
