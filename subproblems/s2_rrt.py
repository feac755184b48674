"""S2-RRT and S2-TRR: two rotations and a translation carry a point onto a point.

Equations: ``exp(xi_1 th_1) exp(xi_2 th_2) exp(xi_3 t) p = q`` (S2-RRT) and
``exp(xi_1 t) exp(xi_2 th_2) exp(xi_3 th_3) p = q`` (S2-TRR), the latter solved as S2-RRT through
inversion: ``exp(-xi_3 th_3) exp(-xi_2 th_2) exp(-xi_1 t) q = p``.

Geometry (S2-RRT): ``z = p + t v`` slides on a line; it is then turned about axis 2 and axis 1.  The
point ``y = exp(-xi_1 th_1) q`` runs on a circle about axis 1 and must lie on the surface swept by the
line turning about axis 2 (a hyperboloid, cone, cylinder or plane): circle meets quadric, up to four
points.

* Axes 1 and 2 intersecting at ``c`` (the core paper's Fig. 2): rotations about both keep ``|x - c|``,
  so ``|p + t v - c| = |q - c|`` gives ``t`` from a quadratic (law of cosines), then S2-RR for each ``t``.
* General position (skew axes; the core paper solves it algebraically): with ``h`` the coordinate
  along axis 2 and ``D`` the squared distance from a point ``r_2`` of axis 2, ``y`` is on the swept
  surface iff some ``t`` has ``h(z(t)) = h(y)`` and ``D(z(t)) = D(y)``.  ``h(y)``, ``D(y)`` are linear
  in ``(cos th_1, sin th_1)``; ``h(z(t)) = k_0 + k_1 t`` is linear in ``t``; eliminating ``t`` gives
  ``k_1^2 D(y) - k_1^2 D(z_0) - 2 k_1 P_1 g - g^2 = 0`` with ``g = h(y) - k_0``: a trigonometric
  polynomial of degree 2 in ``th_1``, i.e. a quartic in ``exp(i th_1)`` whose roots come from the
  eigenvalues of its companion matrix.  Then ``t = g / k_1`` (or, when ``v`` is perpendicular to axis
  2, the two roots of ``D(z(t)) = D(y)``), and ``th_2`` from S2-R.  Every root is polished by
  Gauss-Newton on the full equation and verified.

Max solutions: 4 (at most four roots of the quartic, one ``t`` each; perpendicular case: two angles
times two ``t``).

Degenerate cases and what is returned:

* unreachable ``q``: the best local least-squares solution, flagged ``ls``;
* the eliminant vanishes identically (``q`` on axis 1, axes 1 and 2 coincident, or parallel axes with
  the line perpendicular to them: a planar chain), so ``th_1`` is free: ``th_1 = 0`` if that leaves a
  solution, otherwise the ``th_1`` that moves ``y`` farthest from ``r_2`` (always feasible in the
  planar case); flagged ``continuum``;
* the slid point on axis 2 with ``y`` on it too: ``th_2 = 0``, flagged ``continuum``.

The vectorised path is the algebraic one for skew and parallel axes 1, 2 (there it checks the
scalar path's own algebra with another root finder); for intersecting axes it takes the same
law-of-cosines shortcut as the scalar path, followed by the algebraic S2-RR candidates of
``solve_s2_rr_batch`` (the eliminant's multiple roots there are not accurate enough to decide
duplicates or free joints).

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import prismatic_twist, revolute_twist
>>> tw = [revolute_twist([0, 0, 1], [0, 0, 0]), revolute_twist([0, 1, 0], [1, 0, 0]),
...       prismatic_twist([1, 0, 0])]
>>> r = solve("S2-RRT", tw, p=[0, 0, 0], q=[0, 2, 0.5])
>>> len(r.q), bool(r.ls.any()), r.continuum
(4, False, False)
"""

from __future__ import annotations

import math

import numpy as np

from subproblems import tolerances as tol
from subproblems._class2 import (
    COEF_TOL,
    FREE_TOL,
    agreeing,
    circle_of,
    circle_of_batch,
    defer_to_scalar,
    finalize,
    finalize_batch,
    inverted,
    inverted_batch,
    lin_trig_roots,
    lin_trig_roots_batch,
    problem_scale,
    problem_scale_batch,
    quadratic_form_to_fourier,
    quadratic_roots_batch,
    real_quadratic_roots,
    revert,
    revert_batch,
    rotation_angle,
    rotation_angle_batch,
    trig_roots,
    trig_roots_batch,
)
from subproblems.core import BatchResult, Solution, register
from subproblems.s2_rr import PARALLEL_TOL, rr_candidates, rr_theta1_candidates_batch

K1_TOL = tol.S2_RRT_AXIAL  # subproblems/tolerances.py


def _eliminant(x1, x2, x3, p, q):
    """Coefficients of the eliminant in th_1 and the pieces needed to back-substitute (see doc)."""
    c0, cc, cs = circle_of(x1, q)  # y = c0 + cc cos th1 - cs sin th1
    w2 = x2[3:]
    r2 = np.cross(w2, x2[:3])
    v = x3[:3]
    hy = (float(w2 @ (c0 - r2)), float(w2 @ cc), -float(w2 @ cs))
    k0, k1 = float(w2 @ (p - r2)), float(w2 @ v)
    P0, P1 = float((p - r2) @ (p - r2)), float((p - r2) @ v)
    d0 = float((c0 - r2) @ (c0 - r2) + cc @ cc)
    dc, ds = 2 * float((c0 - r2) @ cc), -2 * float((c0 - r2) @ cs)
    g0, gc, gs = hy[0] - k0, hy[1], hy[2]
    A, B, C = -gc * gc, -2 * gc * gs, -gs * gs
    D = k1 * k1 * dc - 2 * k1 * P1 * gc - 2 * g0 * gc
    E = k1 * k1 * ds - 2 * k1 * P1 * gs - 2 * g0 * gs
    F = k1 * k1 * (d0 - P0) - 2 * k1 * P1 * g0 - g0 * g0
    return (A, B, C, D, E, F), (c0, cc, cs, k1, P0, P1, g0, gc, gs, d0, dc, ds, r2)


def _candidates_for(th1_list, x2, x3, p, q, aux, scale):
    c0, cc, cs, k1, P0, P1, g0, gc, gs, d0, dc, ds, r2 = aux
    v = x3[:3]
    out = []
    for th1 in th1_list:
        c, s = math.cos(th1), math.sin(th1)
        y = c0 + cc * c - cs * s
        # D(z(t)) = D(y): t^2 + 2 P1 t + |p - r2|^2 - |y - r2|^2 = 0, the constant as a product
        # (P0 - D(y) cancels to ~eps absolute: p and y near axis 2 lose t, hence th_2)
        ts = real_quadratic_roots(1.0, 2 * P1, float((p - y) @ (p + y - 2 * r2)))
        if abs(k1) > COEF_TOL:
            ts.append((g0 + gc * c + gs * s) / k1)
        for t in ts:
            th2, free = rotation_angle(x2, p + t * v, y, scale)
            out.append(((th1, th2, t), free))
    return out


def rrt_candidates(twists, p, q, scale):
    """Candidates and continuum flag of S2-RRT (geometric when axes 1, 2 intersect, else algebraic)."""
    x1, x2, x3 = twists
    w1, w2, v = x1[3:], x2[3:], x3[:3]
    r1, r2 = np.cross(w1, x1[:3]), np.cross(w2, x2[:3])
    n = np.cross(w1, w2)
    nn = float(np.linalg.norm(n))
    if nn > PARALLEL_TOL and abs(float((r2 - r1) @ n)) / nn <= FREE_TOL * scale:
        ab = np.linalg.lstsq(np.column_stack([w1, -w2]), r2 - r1, rcond=None)[0]
        c = r1 + ab[0] * w1
        b = float((p - c) @ v)
        out = []
        for t in real_quadratic_roots(1.0, 2 * b, float((p - q) @ (p + q - 2 * c))):  # |p-c|^2 - |q-c|^2
            pt = p + t * v
            for (th1, th2), free in rr_candidates(twists[:2], pt, q, scale)[0]:
                out.append(((th1, th2, t), free))
        return [out], False
    coef, aux = _eliminant(x1, x2, x3, p, q)
    roots = trig_roots(*quadratic_form_to_fourier(*coef), ref=scale * scale)
    if roots is None:  # th_1 free: representatives, preferred in this order
        c0, cc, cs, *_rest = aux
        dc, ds = aux[10], aux[11]
        return [
            _candidates_for([0.0], x2, x3, p, q, aux, scale),
            _candidates_for([math.atan2(ds, dc)], x2, x3, p, q, aux, scale),
        ], True
    k1, g0, gc, gs = aux[3], aux[6], aux[7], aux[8]
    if abs(k1) <= K1_TOL:
        # v (nearly) perpendicular to axis 2: the eliminant is (nearly) -g^2, every root double and
        # located only to sqrt(eps); the roots of g itself are the accurate candidates (half-angle
        # formula: two roots ~1e-7 apart, a circle nearly tangent to the plane h = k0, keep full
        # accuracy, not ~eps / 1e-7 as eigenvalues)
        # (with k1 below COEF_TOL, where t never comes from g / k1, the eliminant is -g^2 to roundoff
        # and its eigenvalue roots are only noise near those of g: not candidates)
        roots = [] if abs(k1) <= COEF_TOL else list(roots)
        if max(abs(gc), abs(gs)) > COEF_TOL * max(abs(g0), scale):
            roots += lin_trig_roots(g0, gc, gs)
    return [_candidates_for(roots, x2, x3, p, q, aux, scale)], False


def solve_rrt(code, twists, p, q) -> list[Solution]:
    scale = problem_scale(twists, p, q)
    groups, cont = rrt_candidates(twists, p, q, scale)
    sols = []
    for cands in groups:
        sols = finalize(code, twists, p, q, cands, continuum=cont)
        if not all(s.ls for s in sols):
            break
    return sols


@register("S2-RRT", 4, batch=lambda tw, p, q: defer_to_scalar("S2-RRT", rrt_batch(tw, p, q), tw, p, q))
@agreeing("S2-RRT", lambda tw, p, q: rrt_batch(tw, p, q))
def solve_s2_rrt(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 th_1) exp(xi_2 th_2) exp(xi_3 t) p = q`` (module docstring)."""
    return solve_rrt("S2-RRT", twists, p, q)


@register("S2-TRR", 4, batch=lambda tw, p, q: defer_to_scalar("S2-TRR", _trr_batch(tw, p, q), tw, p, q))
@agreeing("S2-TRR", lambda tw, p, q: _trr_batch(tw, p, q))
def solve_s2_trr(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 t) exp(xi_2 th_2) exp(xi_3 th_3) p = q``, by inversion to S2-RRT."""
    return revert(solve_rrt("S2-RRT", inverted(twists), q, p))


def _trr_batch(tw, p, q) -> BatchResult:
    return revert_batch(rrt_batch(inverted_batch(tw), q, p), "S2-TRR")


def rrt_batch(tw, p, q) -> BatchResult:
    """Vectorised S2-RRT: the algebraic path for every instance."""
    x1, x2, x3 = tw[:, 0], tw[:, 1], tw[:, 2]
    scale = problem_scale_batch(tw, p, q)
    c0, cc, cs = circle_of_batch(x1, q)
    w2, v = x2[:, 3:], x3[:, :3]
    r2 = np.cross(w2, x2[:, :3])

    def dot(a, b):
        return np.sum(a * b, -1)

    k0, k1 = dot(w2, p - r2), dot(w2, v)
    P0, P1 = dot(p - r2, p - r2), dot(p - r2, v)
    d0 = dot(c0 - r2, c0 - r2) + dot(cc, cc)
    dc, ds = 2 * dot(c0 - r2, cc), -2 * dot(c0 - r2, cs)
    g0, gc, gs = dot(w2, c0 - r2) - k0, dot(w2, cc), -dot(w2, cs)
    A, B, C = -gc * gc, -2 * gc * gs, -gs * gs
    D = k1 * k1 * dc - 2 * k1 * P1 * gc - 2 * g0 * gc
    E = k1 * k1 * ds - 2 * k1 * P1 * gs - 2 * g0 * gs
    F = k1 * k1 * (d0 - P0) - 2 * k1 * P1 * g0 - g0 * g0
    four = np.stack(quadratic_form_to_fourier(A, B, C, D, E, F), -1)
    free1 = np.abs(four).max(-1) <= COEF_TOL * scale * scale
    z = np.zeros_like(g0)
    gok = np.maximum(np.abs(gc), np.abs(gs)) > COEF_TOL * np.maximum(np.abs(g0), scale)
    groots = np.where(gok[:, None], lin_trig_roots_batch(g0, gc, gs), np.nan)
    groots = np.where((np.abs(k1) <= K1_TOL)[:, None], groots, np.nan)  # see rrt_candidates
    eroots = np.where((np.abs(k1) <= COEF_TOL)[:, None], np.nan, trig_roots_batch(four))  # as scalar
    reps = [np.zeros((len(F), 1)), np.arctan2(ds, dc)[:, None]]
    th1 = np.concatenate([eroots, *reps, groots], axis=1)  # (N, 8)
    c, s = np.cos(th1), np.sin(th1)
    y = c0[:, None] + cc[:, None] * c[..., None] - cs[:, None] * s[..., None]
    ts = quadratic_roots_batch(
        np.ones_like(c),
        2 * P1[:, None] * np.ones_like(c),
        dot(p[:, None] - y, p[:, None] + y - 2 * r2[:, None]),  # as _candidates_for
    )
    ok = np.abs(k1) > COEF_TOL
    tl = np.where(
        ok[:, None], (g0[:, None] + gc[:, None] * c + gs[:, None] * s) / np.where(ok, k1, 1.0)[:, None], 0.0
    )
    t = np.concatenate([ts, tl[..., None]], axis=-1)  # (N, 6, 3)
    N = len(F)
    TH1 = np.repeat(th1[..., None], 3, axis=-1).reshape(N, -1)
    Y = np.repeat(y[:, :, None, :], 3, axis=2).reshape(N, -1, 3)
    T = t.reshape(N, -1)
    z = p[:, None] + T[..., None] * v[:, None]
    th2, free2 = rotation_angle_batch(x2[:, None], z, Y, scale[:, None])
    cand = np.stack([TH1, th2, T], -1)
    # representatives of a free th_1 (slots 4, 5 of th1) count only when the eliminant vanishes
    rep = np.zeros(th1.shape[1], dtype=bool)
    rep[4:6] = True
    is_rep = np.repeat(rep, 3)[None, :]
    fin = np.isfinite(cand).all(-1) & (~is_rep | free1[:, None])
    # Intersecting axes 1, 2: the construction of the scalar path (law of cosines for t, then S2-RR).
    # At a multiple root of the eliminant (tangent circles, a slid point on axis 2, ...) its
    # eigenvalues are only accurate to eps^(1/k); the polished copies then stay up to ~1e-6 apart or
    # ~1e-6 off an axis, so they neither deduplicate nor reveal a free joint.  The law of cosines
    # clamps its discriminant and hands S2-RR the exact slid point, as the scalar path does.
    inter, cand_i, free_i = _intersecting_candidates(tw, p, q, scale)
    fin &= ~inter[:, None]
    free1 = free1 & ~inter
    cand = np.where(fin[..., None], cand, np.nan)
    cand = np.concatenate([cand, cand_i], axis=1)
    free2 = np.concatenate([free2, free_i], axis=1)
    r = finalize_batch("S2-RRT", tw, p, q, cand, free2, free1)
    # with a free th_1, prefer the th_1 = 0 representative when it works (as the scalar path)
    return _prefer_zero_rep(r, free1)


@np.errstate(all="ignore")
def _intersecting_candidates(tw, p, q, scale):
    """Vectorised intersecting-axes branch of :func:`rrt_candidates`.

    Returns the mask of instances whose axes 1 and 2 intersect (N,), candidates (N, 12, 3) (NaN for
    the other instances) and their free flags (N, 12).
    """
    x1, x2, x3 = tw[:, 0], tw[:, 1], tw[:, 2]
    w1, w2, v = x1[:, 3:], x2[:, 3:], x3[:, :3]
    r1, r2 = np.cross(w1, x1[:, :3]), np.cross(w2, x2[:, :3])
    n = np.cross(w1, w2)
    nn = np.linalg.norm(n, axis=-1)
    nz = np.where(nn > PARALLEL_TOL, nn, 1.0)
    inter = (nn > PARALLEL_TOL) & (np.abs(np.sum((r2 - r1) * n, -1)) / nz <= FREE_TOL * scale)
    # the common point c = r1 + a w1 (least squares of r1 + a w1 = r2 + b w2, as the scalar path)
    c12 = np.sum(w1 * w2, -1)
    d = r2 - r1
    det = np.where(inter, nn * nn, 1.0)  # |w1 x w2|^2 = 1 - (w1 . w2)^2, accurately
    a = (np.sum(w1 * d, -1) - c12 * np.sum(w2 * d, -1)) / det
    c = r1 + a[:, None] * w1
    pc, qc = p - c, q - c
    t = quadratic_roots_batch(np.ones_like(a), 2 * np.sum(pc * v, -1), np.sum((p - q) * (pc + qc), -1))
    N = len(a)
    # S2-RR for each t: instances (N, 2) flattened to (2N,)
    pt = (p[:, None] + t[..., None] * v[:, None]).reshape(-1, 3)
    x1r, x2r = np.repeat(x1, 2, axis=0), np.repeat(x2, 2, axis=0)
    qr, sr = np.repeat(q, 2, axis=0), np.repeat(scale, 2)
    th1, _ = rr_theta1_candidates_batch(x1r, x2r, pt, qr, sr)  # (2N, 6)
    c0, cc, cs = circle_of_batch(x1r, qr)
    y = c0[:, None] + cc[:, None] * np.cos(th1)[..., None] - cs[:, None] * np.sin(th1)[..., None]
    th2, f2 = rotation_angle_batch(x2r[:, None], pt[:, None], y, sr[:, None])
    f1 = np.linalg.norm(cc, axis=-1)[:, None] <= FREE_TOL * sr[:, None]
    K = th1.shape[1]
    T = np.broadcast_to(t.reshape(-1)[:, None], th1.shape)
    cand = np.stack([th1, th2, T], -1).reshape(N, 2 * K, 3)
    free = np.broadcast_to(f1 | f2, th1.shape).reshape(N, 2 * K)
    cand = np.where(inter[:, None, None], cand, np.nan)
    return inter, cand, free


def _prefer_zero_rep(r: BatchResult, free1) -> BatchResult:
    """With a free th_1, keep the th_1 = 0 representatives when one of them is exact."""
    zero = np.abs(r.q[..., 0]) <= 1e-12
    has_zero = (zero & r.valid & ~r.ls).any(axis=1)
    drop = free1[:, None] & has_zero[:, None] & ~zero
    valid = r.valid & ~drop
    return BatchResult(r.code, r.q, valid, r.ls, r.continuum, r.vectorised)
