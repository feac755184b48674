"""S2-RRR and S2-RTR: a point carried onto a point by three joints whose outer two are revolute.

Equations: ``exp(xi_1 th_1) exp(xi_2 th_2) exp(xi_3 th_3) p = q`` (S2-RRR) and
``exp(xi_1 th_1) exp(xi_2 t) exp(xi_3 th_3) p = q`` (S2-RTR).

Both reduce to the same algebra.  Let ``y(th_1) = exp(-xi_1 th_1) q`` (circle of ``q`` about axis 1)
and ``z(th_3) = exp(xi_3 th_3) p`` (circle of ``p`` about axis 3); the middle joint must carry ``z`` to
``y``.  Two scalar conditions say when it can, both linear in ``(cos th_3, sin th_3)`` on the left and
in ``(cos th_1, sin th_1)`` on the right: ``M (cos th_3, sin th_3) = E_0 + E_c cos th_1 + E_s sin th_1``.

* S2-RRR (geometry: circle about axis 1 meets the torus swept by the circle of ``p``): ``z`` and ``y``
  have the same coordinate along axis 2 and the same distance from a point ``r_2`` of it.
* S2-RTR (geometry: the projections of the two circles along ``v`` meet, two ellipses): ``y - z`` is
  parallel to ``v``: its two components across ``v`` vanish; then ``t = v . (y - z)``.

Elimination (``pair_candidates``): when ``M`` is regular, Cramer's rule gives
``(cos th_3, sin th_3) = adj(M) E(th_1) / det M`` and the unit-norm condition
``|adj(M) E(th_1)|^2 = det(M)^2`` is a trigonometric polynomial of degree 2 in ``th_1``: a quartic in
``exp(i th_1)`` solved by companion-matrix eigenvalues (``th_1 = pi`` needs no special care).  When
``M`` has rank 1 (S2-RRR: axes 2 and 3 intersect, the cheap geometric case, or are parallel; S2-RTR:
``v`` perpendicular to axis 3), its left null vector gives one equation linear in
``(cos th_1, sin th_1)`` (at most two ``th_1``) and the other row one linear in ``(cos th_3, sin th_3)``
(at most two ``th_3`` each).  Finally ``th_2`` (S2-R) or ``t``, and Gauss-Newton polishing of every
candidate on the full equation.

Max solutions: 4 for both (regular ``M``: the quartic has at most four roots and each gives one
``th_3``; rank 1: two ``th_1`` times two ``th_3``).

Degenerate cases and what is returned:

* unreachable ``q``: the best local least-squares solution, flagged ``ls``;
* ``th_1`` free (the eliminant vanishes identically: ``q`` on axis 1, axes 1 and 2 coincident,
  three parallel axes, ...): representatives ``th_1 = 0`` if that leaves a solution, otherwise the
  roots and extremes of the remaining condition; flagged ``continuum``;
* ``th_3`` free (``M = 0``: ``p`` on axis 3, axes 2 and 3 coincident): ``th_3 = 0``, ``continuum``;
* ``th_2`` free (the intermediate point on axis 2): ``th_2 = 0``, ``continuum``.

* any other curve of solutions through a row found (axes 1 and 3 one line with ``th_2 = 0``: only
  ``th_1 + th_3`` counts; S2-RTR with the translation along coincident axes 1 and 3): that row is
  the representative, ``continuum`` (the finalizer's probe, ``_class2.on_continuum_rows``).

The candidates are computed on the instance divided by its own length (``_class2.normalized``), so
that the elimination's relative tests mean the same at scale 1e-3 as at scale 1; the verification
runs on the instance as given.

Vectorised path (``rrr_batch``): the same elimination for all instances at once, with fixed slots:
four for the quartic's roots, four for the rank-1 construction, four for a free ``th_3``, and a
second group of eight for the representatives of a free ``th_1`` (used, as in the scalar path, only
where the first group leaves no exact solution); then the common polishing and verification.

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import revolute_twist
>>> tw = [revolute_twist([0, 0, 1], [0, 0, 0]), revolute_twist([0, 1, 0], [0, 0, 1]),
...       revolute_twist([1, 0, 0], [0, 1, 2])]
>>> th = [0.3, -1.2, 2.0]
>>> from subproblems.screw import twist_exp
>>> g = twist_exp(tw[0], th[0]) @ twist_exp(tw[1], th[1]) @ twist_exp(tw[2], th[2])
>>> q = g[:3, :3] @ [1.0, 0.5, 0.2] + g[:3, 3]
>>> r = solve("S2-RRR", tw, p=[1.0, 0.5, 0.2], q=q)
>>> bool(np.any(np.abs(r.q - th).max(axis=1) < 1e-9)), bool(r.ls.any())
(True, False)
"""

from __future__ import annotations

import math

import numpy as np

from subproblems import tolerances as tol
from subproblems._class2 import (
    COEF_TOL,
    EXACT_TOL,
    agreeing,
    circle_of,
    circle_of_batch,
    defer_to_scalar,
    finalize,
    finalize_batch,
    lin_roots_nan_batch,
    normalized,
    normalized_batch,
    problem_scale,
    problem_scale_batch,
    quadratic_form_to_fourier,
    rotation_angle,
    rotation_angle_batch,
    trig_roots,
    trig_roots_batch,
    trig_roots_nan_batch,
)
from subproblems.core import BatchResult, Solution, register

RANK_TOL = tol.S2_RRR_RANK  # subproblems/tolerances.py


def _lin_roots(f0, c1, s1, ref):
    """Roots of ``f0 + c1 cos + s1 sin`` (None: identically zero)."""
    return trig_roots(f0, c1, s1, ref=ref)


def _flat(f0, c1, s1, ref):
    """``f0 + c1 cos + s1 sin`` is within the exactness tolerance of zero for every angle."""
    return np.abs(f0) + np.hypot(c1, s1) <= EXACT_TOL * ref


#: Cramer's point ``adj(M) E(a) / det M`` off the unit circle by more than this: ``a`` is a complex root
#: of the quartic projected onto the circle, and ``b`` also gets its least-squares value.
OFF_CIRCLE = 1e-9


def _ls_b_coefficients(M, E):
    """Fourier coefficients (f0, c1, s1, c2, s2) of the derivative of ``|M (cos b, sin b) - E|^2 / 2``
    over ``b`` (``M`` (..., 2, 2), ``E`` (..., 2))."""
    A = np.einsum("...ki,...kj->...ij", M, M)
    e = np.einsum("...ki,...k->...i", M, E)
    zero = np.zeros_like(e[..., 0])
    return zero, -e[..., 1], e[..., 0], A[..., 0, 1], 0.5 * (A[..., 1, 1] - A[..., 0, 0])


def least_squares_b(M, E) -> float:
    """The ``b`` minimising ``|M (cos b, sin b) - E|``.

    At a complex root ``a`` of the quartic projected onto the circle Cramer's point is off the circle,
    and where ``M`` is nearly singular (axes 2 and 3 nearly parallel) its direction says little: the
    puma560 of rtb-data perturbed by 1e-3 (seed 8) had a complex pair whose Cramer candidate missed by
    1.5e-2 of the size, dropped, while the residual's local minimum beside it (2.6e-4) was the true
    robot's sampled solution across a fold (benchmarks/real_robots.py --perturb-seed 8)."""
    f = _ls_b_coefficients(np.asarray(M, dtype=float), np.asarray(E, dtype=float))
    roots = trig_roots(*(float(x) for x in f)) or []
    if not roots:
        return math.atan2(E[1], E[0])
    cost = [float(np.linalg.norm(M @ [math.cos(b), math.sin(b)] - E)) for b in roots]
    return roots[int(np.argmin(cost))]


def least_squares_b_batch(M, E):
    """Vectorised :func:`least_squares_b`: ``M`` (N, 2, 2), ``E`` (N, k, 2) -> b (N, k)."""
    N, k = E.shape[:2]
    Mk = np.broadcast_to(M[:, None], (N, k, 2, 2))
    F = np.stack(_ls_b_coefficients(Mk, E), -1).reshape(N * k, 5)
    F = np.where(np.isfinite(F), F, 0.0)
    b = trig_roots_batch(F).reshape(N, k, 4)
    u = np.stack([np.cos(b), np.sin(b)], -1)  # (N, k, 4, 2)
    r = np.linalg.norm(np.einsum("nkij,nkrj->nkri", Mk, u) - E[:, :, None], axis=-1)
    r = np.where(np.isfinite(r), r, np.inf)
    return np.take_along_axis(b, r.argmin(-1)[..., None], -1)[..., 0]


def pair_candidates(M, E0, Ec, Es, ref: float):
    """Angle pairs ``(a, b)`` with ``M (cos b, sin b) = E0 + Ec cos a + Es sin a``.

    Returns ``(groups, free_a, free_b)``: candidate lists in order of preference (representatives of
    a free angle come in later groups) and whether ``a`` / ``b`` is free.
    """
    nm = float(np.abs(M).max())
    sv = np.linalg.svd(M, compute_uv=False)
    if nm <= COEF_TOL * ref:  # b free: b = 0, then E(a) = M (1, 0) ~ 0: two linear equations in a
        pairs = []
        for row in range(2):
            roots = _lin_roots(E0[row] - M[row, 0], Ec[row], Es[row], ref)
            pairs += [(a, 0.0) for a in (roots if roots is not None else [0.0])]
        return [pairs], False, True
    groups: list[list] = [[]]
    free_a = False
    if sv[1] > RANK_TOL * sv[0]:
        det = float(np.linalg.det(M))
        adj = np.array([[M[1, 1], -M[0, 1]], [-M[1, 0], M[0, 0]]])
        G0, Gc, Gs = adj @ E0, adj @ Ec, adj @ Es
        coef = (Gc @ Gc, 2 * Gc @ Gs, Gs @ Gs, 2 * G0 @ Gc, 2 * G0 @ Gs, G0 @ G0 - det * det)
        roots = trig_roots(*quadratic_form_to_fourier(*coef), ref=ref * nm * nm)
        if roots is None:
            free_a = True
            roots = [0.0]
        for a in roots:
            G = (G0 + Gc * math.cos(a) + Gs * math.sin(a)) / det
            groups[0].append((a, math.atan2(G[1], G[0])))
            if abs(math.hypot(G[0], G[1]) - 1.0) > OFF_CIRCLE:  # a complex root's projection
                groups[0].append((a, least_squares_b(M, E0 + Ec * math.cos(a) + Es * math.sin(a))))
    if sv[1] <= 1e-6 * sv[0]:  # (near) rank 1: left null vector u2, row direction v1
        U, S, Vt = np.linalg.svd(M)
        u1, u2, v1 = U[:, 0], U[:, 1], Vt[0]
        # the condition on a alone; satisfied within the exactness tolerance by every a (e.g. axes
        # 1 and 2 parallel up to a tilt of 1e-12), a is free: the roots of such a residue are noise
        f0, c1, s1 = u2 @ E0, u2 @ Ec, u2 @ Es
        roots = None if _flat(f0, c1, s1, ref) else _lin_roots(f0, c1, s1, ref)
        alts: list[float] = []
        if roots is None:
            free_a = True
            e0, ec, es = u1 @ E0, u1 @ Ec, u1 @ Es
            alts = list(_lin_roots(e0, ec, es, ref) or []) + [math.atan2(es, ec), math.atan2(-es, -ec)]
            roots = [0.0]
        for grp, as_ in ((groups[0], roots), (None, alts)):
            if not as_:
                continue
            if grp is None:
                grp = []
                groups.append(grp)
            for a in as_:
                rhs = u1 @ (E0 + Ec * math.cos(a) + Es * math.sin(a))
                bs = _lin_roots(-rhs, S[0] * v1[0], S[0] * v1[1], ref)
                grp += [(a, b) for b in (bs if bs is not None else [0.0])]
    return groups, free_a, False


def _solve(code, twists, p, q, build):
    tw_n, p_n, q_n, L = normalized(twists, p, q)  # candidates from the instance at unit length
    scale = problem_scale(tw_n, p_n, q_n)
    x1, x2, x3 = tw_n
    c0, cc, cs = circle_of(x1, q_n)  # y = c0 + cc cos th1 - cs sin th1
    e0, ec, es = circle_of(x3, p_n)  # z = e0 + ec cos th3 + es sin th3
    M, E0, Ec, Es = build(x2, c0, cc, -cs, e0, ec, es, scale)
    groups, free1, free3 = pair_candidates(M, E0, Ec, Es, scale)
    cont = free1 or free3
    sols: list[Solution] = []
    for grp in groups:
        cands = []
        for a, b in grp:
            y = c0 + cc * math.cos(a) - cs * math.sin(a)
            z = e0 + ec * math.cos(b) + es * math.sin(b)
            if code == "S2-RRR":
                th2, free = rotation_angle(x2, z, y, scale)
            else:
                th2, free = float(x2[:3] @ (y - z)) * L, False
            cands.append(((a, th2, b), free))
        sols = finalize(code, twists, p, q, cands, continuum=cont)
        if not all(s.ls for s in sols):
            break
    return sols


def _rrr_system(x2, c0, cc, cs, e0, ec, es, scale):
    w2 = x2[3:]
    r2 = np.cross(w2, x2[:3])
    k, h = e0 - r2, c0 - r2
    M = np.array([[w2 @ ec, w2 @ es], [2 * (k @ ec) / scale, 2 * (k @ es) / scale]])
    E0 = np.array([w2 @ (c0 - e0), (h @ h + cc @ cc - k @ k - ec @ ec) / scale])
    Ec = np.array([w2 @ cc, 2 * (h @ cc) / scale])
    Es = np.array([w2 @ cs, 2 * (h @ cs) / scale])
    return M, E0, Ec, Es


def _rtr_system(x2, c0, cc, cs, e0, ec, es, scale):
    v = x2[:3]
    a = np.cross(v, [1.0, 0, 0]) if abs(v[0]) < 0.9 else np.cross(v, [0, 1.0, 0])
    a = a / np.linalg.norm(a)
    B = np.array([a, np.cross(v, a)])
    M = np.column_stack([B @ ec, B @ es])
    return M, B @ (c0 - e0), B @ cc, B @ cs


def _dot(a, b):
    return np.sum(a * b, -1)


def _rrr_system_batch(x2, c0, cc, cs, e0, ec, es, scale):
    w2 = x2[:, 3:]
    r2 = np.cross(w2, x2[:, :3])
    k, h = e0 - r2, c0 - r2
    sc = scale
    M = np.stack(
        [
            np.stack([_dot(w2, ec), _dot(w2, es)], -1),
            np.stack([2 * _dot(k, ec) / sc, 2 * _dot(k, es) / sc], -1),
        ],
        -2,
    )
    E0 = np.stack([_dot(w2, c0 - e0), (_dot(h, h) + _dot(cc, cc) - _dot(k, k) - _dot(ec, ec)) / sc], -1)
    Ec = np.stack([_dot(w2, cc), 2 * _dot(h, cc) / sc], -1)
    Es = np.stack([_dot(w2, cs), 2 * _dot(h, cs) / sc], -1)
    return M, E0, Ec, Es


def _rtr_system_batch(x2, c0, cc, cs, e0, ec, es, scale):
    v = x2[:, :3]
    ref = np.where(np.abs(v[:, :1]) < 0.9, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
    a = np.cross(v, ref)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    B = np.stack([a, np.cross(v, a)], -2)  # (N, 2, 3)
    M = np.stack([np.einsum("nij,nj->ni", B, ec), np.einsum("nij,nj->ni", B, es)], -1)
    E0, Ec, Es = (np.einsum("nij,nj->ni", B, u) for u in (c0 - e0, cc, cs))
    return M, E0, Ec, Es


@np.errstate(all="ignore")
def pair_candidates_batch(M, E0, Ec, Es, ref):
    """Vectorised :func:`pair_candidates`: pairs ``(a, b)`` of the first group (N, 16, 2) and of the
    second (free ``a`` representatives, N, 8, 2), NaN where unused; ``free_a``, ``free_b`` (N,)."""
    N = len(M)
    nm = np.abs(M).max(axis=(-1, -2))
    U, S, Vt = np.linalg.svd(M)
    bfree = nm <= COEF_TOL * ref
    regular = ~bfree & (S[:, 1] > RANK_TOL * S[:, 0])
    rank1 = ~bfree & (S[:, 1] <= 1e-6 * S[:, 0])
    nan = np.nan
    g0 = np.full((N, 16, 2), nan)
    g1 = np.full((N, 8, 2), nan)

    # regular M: Cramer's rule and the unit-norm condition, a quartic in exp(i a)
    det = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0]
    adj = np.stack([np.stack([M[:, 1, 1], -M[:, 0, 1]], -1), np.stack([-M[:, 1, 0], M[:, 0, 0]], -1)], -2)
    G0, Gc, Gs = (np.einsum("nij,nj->ni", adj, E) for E in (E0, Ec, Es))
    coef = (_dot(Gc, Gc), 2 * _dot(Gc, Gs), _dot(Gs, Gs), 2 * _dot(G0, Gc), 2 * _dot(G0, Gs))
    coef = coef + (_dot(G0, G0) - det * det,)
    F = np.stack(quadratic_form_to_fourier(*coef), -1)
    ra, none_q = trig_roots_nan_batch(F, ref * nm * nm)
    ra = np.where(none_q[:, None], np.array([0.0, nan, nan, nan]), ra)
    G = (G0[:, None] + Gc[:, None] * np.cos(ra)[..., None] + Gs[:, None] * np.sin(ra)[..., None]) / det[
        :, None, None
    ]
    rb = np.arctan2(G[..., 1], G[..., 0])
    g0[:, 0:4] = np.where(regular[:, None, None], np.stack([ra, rb], -1), nan)
    # a complex root's projection: b also at its least-squares value (least_squares_b)
    off = regular[:, None] & (np.abs(np.hypot(G[..., 0], G[..., 1]) - 1.0) > OFF_CIRCLE)
    if off.any():
        Ea = E0[:, None] + Ec[:, None] * np.cos(ra)[..., None] + Es[:, None] * np.sin(ra)[..., None]
        g0[:, 12:16] = np.where(off[..., None], np.stack([ra, least_squares_b_batch(M, Ea)], -1), nan)
    free_a = regular & none_q

    # (near) rank 1: left null vector u2 gives the equation in a, the row direction v1 the one in b
    u1, u2, v1 = U[:, :, 0], U[:, :, 1], Vt[:, 0, :]
    f0, c1, s1 = _dot(u2, E0), _dot(u2, Ec), _dot(u2, Es)
    a1, none_a = lin_roots_nan_batch(f0, c1, s1, ref)
    none_a |= _flat(f0, c1, s1, ref)
    a1 = np.where(none_a[:, None], np.array([0.0, nan]), a1)
    e0, ec, es = _dot(u1, E0), _dot(u1, Ec), _dot(u1, Es)
    alts, _ = lin_roots_nan_batch(e0, ec, es, ref)
    alts = np.concatenate(
        [alts, np.arctan2(es, ec)[:, None], np.arctan2(-es, -ec)[:, None]], axis=1
    )  # (N, 4)

    def with_b(a_s):
        rhs = e0[:, None] + ec[:, None] * np.cos(a_s) + es[:, None] * np.sin(a_s)
        k = a_s.shape[1]
        sv = np.broadcast_to((S[:, 0] * v1[:, 0])[:, None], (N, k))
        sw = np.broadcast_to((S[:, 0] * v1[:, 1])[:, None], (N, k))
        bs, none_b = lin_roots_nan_batch(-rhs, sv, sw, np.broadcast_to(ref[:, None], (N, k)))
        bs = np.where(none_b[..., None], np.array([0.0, nan]), bs)  # (N, k, 2)
        pairs = np.stack([np.broadcast_to(a_s[..., None], bs.shape), bs], -1)
        return pairs.reshape(N, 2 * k, 2)

    g0[:, 4:8] = np.where(rank1[:, None, None], with_b(a1), nan)
    g1[:] = np.where((rank1 & none_a)[:, None, None], with_b(alts), nan)
    free_a |= rank1 & none_a

    # M = 0: b free, b = 0, then E(a) = M (1, 0) ~ 0: two linear equations in a
    for row in range(2):
        rr, nn_ = lin_roots_nan_batch(E0[:, row] - M[:, row, 0], Ec[:, row], Es[:, row], ref)
        rr = np.where(nn_[:, None], np.array([0.0, nan]), rr)
        pr = np.stack([rr, np.zeros_like(rr)], -1)
        g0[:, 8 + 2 * row : 10 + 2 * row] = np.where(bfree[:, None, None], pr, nan)
    return g0, g1, free_a, bfree


def _triples_batch(code, x2, c0, cc, cs, e0, ec, es, pairs, scale, L):
    a, b = pairs[..., 0], pairs[..., 1]
    y = c0[:, None] + cc[:, None] * np.cos(a)[..., None] - cs[:, None] * np.sin(a)[..., None]
    z = e0[:, None] + ec[:, None] * np.cos(b)[..., None] + es[:, None] * np.sin(b)[..., None]
    if code == "S2-RRR":
        th2, free = rotation_angle_batch(x2[:, None], z, y, scale[:, None])
    else:
        th2, free = _dot(x2[:, None, :3], y - z) * L[:, None], np.zeros(a.shape, dtype=bool)
    return np.stack([a, th2, b], -1), free


def _solve_batch(code, tw, p, q, build) -> BatchResult:
    tw_n, p_n, q_n, L = normalized_batch(tw, p, q)  # candidates from the instances at unit length
    scale = problem_scale_batch(tw_n, p_n, q_n)
    x1, x2, x3 = tw_n[:, 0], tw_n[:, 1], tw_n[:, 2]
    c0, cc, cs = circle_of_batch(x1, q_n)  # y = c0 + cc cos th1 - cs sin th1
    e0, ec, es = circle_of_batch(x3, p_n)  # z = e0 + ec cos th3 + es sin th3
    M, E0, Ec, Es = build(x2, c0, cc, -cs, e0, ec, es, scale)
    g0, g1, free1, free3 = pair_candidates_batch(M, E0, Ec, Es, scale)
    cont = free1 | free3
    cand, free = _triples_batch(code, x2, c0, cc, cs, e0, ec, es, g0, scale, L)
    r = finalize_batch(code, tw, p, q, cand, free, cont)
    # second group (representatives of a free th_1) where the first leaves no exact solution
    redo = np.flatnonzero(r.ls.any(axis=1) & np.isfinite(g1).all(-1).any(-1))
    if redo.size == 0:
        return r

    def sub(a):
        return a[redo]

    cand1, free1_ = _triples_batch(
        code, sub(x2), sub(c0), sub(cc), sub(cs), sub(e0), sub(ec), sub(es), sub(g1), sub(scale), sub(L)
    )
    r1 = finalize_batch(code, sub(tw), sub(p), sub(q), cand1, free1_, sub(cont))
    Q, valid, ls, cc_ = r.q.copy(), r.valid.copy(), r.ls.copy(), r.continuum.copy()
    Q[redo], valid[redo], ls[redo], cc_[redo] = r1.q, r1.valid, r1.ls, r1.continuum
    return BatchResult(code, Q, valid, ls, cc_)


def rrr_batch(tw, p, q) -> BatchResult:
    """Vectorised S2-RRR (module docstring)."""
    return _solve_batch("S2-RRR", tw, p, q, _rrr_system_batch)


def rtr_batch(tw, p, q) -> BatchResult:
    """Vectorised S2-RTR (module docstring)."""
    return _solve_batch("S2-RTR", tw, p, q, _rtr_system_batch)


@register("S2-RRR", 4, batch=lambda tw, p, q: defer_to_scalar("S2-RRR", rrr_batch(tw, p, q), tw, p, q))
@agreeing("S2-RRR", rrr_batch)
def solve_s2_rrr(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 th_1) exp(xi_2 th_2) exp(xi_3 th_3) p = q`` (module docstring)."""
    return _solve("S2-RRR", twists, p, q, _rrr_system)


@register("S2-RTR", 4, batch=lambda tw, p, q: defer_to_scalar("S2-RTR", rtr_batch(tw, p, q), tw, p, q))
@agreeing("S2-RTR", rtr_batch)
def solve_s2_rtr(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 th_1) exp(xi_2 t) exp(xi_3 th_3) p = q`` (module docstring)."""
    return _solve("S2-RTR", twists, p, q, _rtr_system)
