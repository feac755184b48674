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

No vectorised path yet: ``solve_batch`` loops over the scalar one (``vectorised=False``).

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

from subproblems._class2 import (
    COEF_TOL,
    circle_of,
    finalize,
    problem_scale,
    quadratic_form_to_fourier,
    rotation_angle,
    trig_roots,
)
from subproblems.core import Solution, register

RANK_TOL = 1e-9


def _lin_roots(f0, c1, s1, ref):
    """Roots of ``f0 + c1 cos + s1 sin`` (None: identically zero)."""
    return trig_roots(f0, c1, s1, ref=ref)


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
    if sv[1] <= 1e-6 * sv[0]:  # (near) rank 1: left null vector u2, row direction v1
        U, S, Vt = np.linalg.svd(M)
        u1, u2, v1 = U[:, 0], U[:, 1], Vt[0]
        roots = _lin_roots(u2 @ E0, u2 @ Ec, u2 @ Es, ref)
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
    scale = problem_scale(twists, p, q)
    x1, x2, x3 = twists
    c0, cc, cs = circle_of(x1, q)  # y = c0 + cc cos th1 - cs sin th1
    e0, ec, es = circle_of(x3, p)  # z = e0 + ec cos th3 + es sin th3
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
                th2, free = float(x2[:3] @ (y - z)), False
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


@register("S2-RRR", 4)
def solve_s2_rrr(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 th_1) exp(xi_2 th_2) exp(xi_3 th_3) p = q`` (module docstring)."""
    return _solve("S2-RRR", twists, p, q, _rrr_system)


@register("S2-RTR", 4)
def solve_s2_rtr(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi_1 th_1) exp(xi_2 t) exp(xi_3 th_3) p = q`` (module docstring)."""
    return _solve("S2-RTR", twists, p, q, _rtr_system)
