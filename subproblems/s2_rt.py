"""S2-TR and S2-RT: a translation and a rotation carry a point onto a point.

Equations: ``exp(xi_1 t) exp(xi_2 th) p = q`` (S2-TR: prismatic first) and
``exp(xi_1 th) exp(xi_2 t) p = q`` (S2-RT: revolute first).  S2-RT is solved as S2-TR through
inversion: ``exp(-xi_2 t) exp(-xi_1 th) q = p``.

Geometry (S2-TR, unit direction ``v``, axis ``w`` through ``r``): the point ``exp(xi_2 th) p`` lies on
the circle ``C`` of ``p`` about the axis and on the line ``q - t v``.  A line meets a circle:

* ``v`` not perpendicular to ``w``: the line pierces the circle's plane ``w . x = w . p`` once,
  ``t = w . (q - p) / (w . v)``; the point must be on the circle (the remaining equation);
* ``v`` perpendicular to ``w``: the line is parallel to the plane and meets the circle's sphere
  ``|x - r| = |p - r|`` at up to two points, ``t`` from a quadratic; the heights must match.

Max solutions: 2.

Three equations, two unknowns: the residual of every row is reported; no exact solution gives the
best least-squares pair, flagged ``ls``.

Degenerate cases: ``p`` on the axis (S2-TR; ``q`` on the axis for S2-RT): the angle is free; 0 is
returned, flagged ``continuum``.  The translation is never free (``v`` is a unit vector).

Vectorised path: the same three candidates for ``t`` (plane piercing, the two sphere roots) for all
instances at once, ``th`` from S2-R, every candidate polished and verified.

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import prismatic_twist, revolute_twist
>>> tw = [prismatic_twist([1, 0, 0]), revolute_twist([0, 0, 1], [0, 0, 0])]
>>> r = solve("S2-TR", tw, p=[1, 0, 0], q=[3, 1, 0])
>>> np.round(r.q, 6) + 0.0, r.ls.tolist()
(array([[3.      , 1.570796]]), [False])
"""

from __future__ import annotations

import numpy as np

from subproblems._class2 import (
    COEF_TOL,
    agreeing,
    defer_to_scalar,
    finalize,
    finalize_batch,
    inverted,
    inverted_batch,
    problem_scale,
    problem_scale_batch,
    quadratic_roots_batch,
    real_quadratic_roots,
    revert,
    revert_batch,
    rotation_angle,
    rotation_angle_batch,
)
from subproblems.core import BatchResult, Solution, register


def tr_candidates(twists, p, q, scale: float) -> list:
    """Candidates ``[((t, th), free), ...]`` of ``exp(xi_1 t) exp(xi_2 th) p = q``."""
    x1, x2 = twists
    v, w = x1[:3], x2[3:]
    r = np.cross(w, x2[:3])
    ts = []
    wv = float(w @ v)
    if abs(wv) > COEF_TOL:
        ts.append(float(w @ (q - p)) / wv)
    b = float(v @ (q - r))
    ts += real_quadratic_roots(1.0, -2 * b, float((q - r) @ (q - r) - (p - r) @ (p - r)))
    out = []
    for t in ts:
        th, free = rotation_angle(x2, p, q - t * v, scale)
        out.append(((t, th), free))
    return out


def tr_candidates_batch(x1, x2, p, q, scale):
    """Vectorised :func:`tr_candidates`: candidates (N, 3, 2) and free flags (N, 3).

    The plane-piercing ``t`` (NaN when ``v`` is perpendicular to the axis) and the two sphere roots.
    """
    v, w = x1[:, :3], x2[:, 3:]
    r = np.cross(w, x2[:, :3])
    wv = np.sum(w * v, -1)
    ok = np.abs(wv) > COEF_TOL
    t_plane = np.where(ok, np.sum(w * (q - p), -1) / np.where(ok, wv, 1.0), np.nan)
    qr, pr = q - r, p - r
    t_sphere = quadratic_roots_batch(np.ones_like(wv), -2 * np.sum(v * qr, -1), np.sum(qr * qr - pr * pr, -1))
    t = np.concatenate([t_plane[:, None], t_sphere], axis=1)
    x = q[:, None] - np.nan_to_num(t)[..., None] * v[:, None]
    th, free = rotation_angle_batch(x2[:, None], p[:, None], x, scale[:, None])
    return np.stack([t, th], -1), np.broadcast_to(free, th.shape)


def _tr_batch(tw, p, q) -> BatchResult:
    scale = problem_scale_batch(tw, p, q)
    cand, free = tr_candidates_batch(tw[:, 0], tw[:, 1], p, q, scale)
    return finalize_batch("S2-TR", tw, p, q, cand, free)


@register("S2-TR", 2, batch=lambda tw, p, q: defer_to_scalar("S2-TR", _tr_batch(tw, p, q), tw, p, q))
@agreeing("S2-TR", _tr_batch)
def solve_s2_tr(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 t) exp(xi_2 th) p = q`` (see the module docstring)."""
    return finalize("S2-TR", twists, p, q, tr_candidates(twists, p, q, problem_scale(twists, p, q)))


def _rt_batch(tw, p, q) -> BatchResult:
    return revert_batch(_tr_batch(inverted_batch(tw), q, p), "S2-RT")


@register("S2-RT", 2, batch=lambda tw, p, q: defer_to_scalar("S2-RT", _rt_batch(tw, p, q), tw, p, q))
@agreeing("S2-RT", _rt_batch)
def solve_s2_rt(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 th) exp(xi_2 t) p = q``, by inversion to S2-TR."""
    return revert(solve_s2_tr(inverted(twists), q, p))
