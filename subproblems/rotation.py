"""Pure-rotation subproblems through the origin (orientation separation, docs/design.md section 3, rule 2).

Equations, with unit axes ``w_i`` and ``R`` a rotation matrix:

* ``exp([w1] t1) = R``                                        :func:`orientation_r`   (code ``O-R``)
* ``exp([w1] t1) exp([w2] t2) = R``                           :func:`orientation_rr`  (code ``O-RR``)
* ``exp([w1] t1) exp([w2] t2) exp([w3] t3) = R``              :func:`orientation_rrr` (code ``O-RRR``)
* ``exp([w1] t1) u = v``  (rotate a vector onto a vector)      :func:`direction_r`
* ``exp([w1] t1) exp([w2] t2) u = v``                         :func:`direction_rr`

Geometric meaning: the orientation part of a chain of revolute joints, every axis moved to pass through
the origin.  A rotation has 3 degrees of freedom, so ``O-R`` and ``O-RR`` are overdetermined (3
equations, 1 or 2 unknowns) and ``O-RRR`` is square.

Maximum number of solutions: ``O-R`` 1, ``O-RR`` 1, ``O-RRR`` 2 (Euler angles: ``t2`` and its mirror),
``direction_r`` 1, ``direction_rr`` 2 (Paden-Kahan problem 2 through the origin).

Registered codes (for :func:`subproblems.solve`): ``"O-R"``, ``"O-RR"``, ``"O-RRR"``.  Their input is ``T``
(4x4; only its rotation is used) and revolute twists (only their ``w`` is used, ``v`` is ignored).  The
residual of a solution is the angle of ``E(t)^T R`` in radians.

How each is solved and what is returned in degenerate cases:

* ``O-R``: ``t = atan2(w . vee(R - R^T), tr R - w^T R w)``, the least-squares angle (Frobenius norm).
  ``ls`` when ``R`` is not a rotation about ``w``; when ``R`` is a half-turn about an axis perpendicular to
  ``w`` every angle is equally good: ``t = 0`` flagged ``ls`` and ``continuum``.
* ``O-RR``: ``t1`` rotates ``w2`` onto ``R w2`` about ``w1``, then ``t2`` is ``O-R`` on ``exp(-[w1]t1) R``.
  Parallel axes (``w2 = s w1``): only ``t1 + s t2`` is determined; ``t1 = 0`` is returned, ``continuum``.
* ``O-RRR``: ``w1^T exp([w2]t2) w3 = w1^T R w3`` gives ``t2`` (two roots), ``t1`` rotates ``exp([w2]t2) w3``
  onto ``R w3`` about ``w1``, ``t3`` is ``O-R`` on the rest; near a gimbal lock or nearly parallel
  consecutive axes also ``t1`` first and Gauss-Newton restarts (see :func:`_general_rrr_b`; the scalar
  path runs the vectorised one on one instance).  A double root (``|w1^T R w3 - alpha|`` equal to the
  amplitude within a few ulps: a singular configuration such as ``t2 = +-pi/2`` on lattice axes) is
  solved at its tangent point, accurate to roundoff, not as two roots ``sqrt(eps)`` apart.  Degenerate
  cases, all ``continuum``:
  ``w1 || w2``: ``t1 = 0`` (``w1 || w2 || w3``: ``t1 = t2 = 0``); ``w2 || w3``: ``t2 = 0``; gimbal lock
  (``exp([w2]t2) w3 = +-w1``, i.e. ``R w3 = +-w1``, e.g. ``t2 = 0`` of ZYZ Euler angles): ``t1 = 0``.
  Unreachable ``R`` (possible unless the axes allow every rotation): the root of the clamped equation,
  flagged ``ls``.
* ``direction_r``: Paden-Kahan problem 1 about an axis through the origin; ``u`` on the axis: ``t = 0``,
  ``continuum``; ``ls`` when the components along ``w`` or the lengths differ.
* ``direction_rr``: the intermediate vector ``z = exp([w2]t2) u = exp(-[w1]t1) v`` has ``w2.z = w2.u``,
  ``w1.z = w1.v``, ``|z| = |u|``: two candidates.  ``w1 || w2``: ``t1 = 0``, ``continuum``; ``u || w2``:
  ``t2 = 0``; ``v || w1``: ``t1 = 0`` (both ``continuum``); no real ``z``: the nearest one, ``ls``.
  Nearly parallel axes, ``v`` nearly on axis 1 or ``u`` nearly on axis 2 (within 1e-6): Gauss-Newton
  also starts from eight points of the degenerate family; at most the two best exact points are kept.

Every function returns a list of :class:`~subproblems.core.Solution` (plain floats, angles wrapped to
(-pi, pi]); exact solutions are polished by Gauss-Newton and verified; without an exact one, the best
least-squares answer alone is returned.  The ``*_batch`` functions solve N instances at once (fixed
slots and a validity mask, no Python loop over instances) and return a
:class:`~subproblems.core.BatchResult`.

>>> import numpy as np
>>> from subproblems.screw import rotation_exp
>>> R = rotation_exp([0, 0, 1], 0.3) @ rotation_exp([0, 1, 0], 0.4) @ rotation_exp([0, 0, 1], 0.5)
>>> sols = orientation_rrr([0, 0, 1], [0, 1, 0], [0, 0, 1], R)
>>> [tuple(round(a, 6) for a in s.q) for s in sols]
[(-2.841593, -0.4, -2.641593), (0.3, 0.4, 0.5)]
"""

from __future__ import annotations

import math

import numpy as np

from subproblems import tolerances as tol
from subproblems.angles import wrap, wrap_array
from subproblems.core import BatchResult, Solution, SubproblemInputError, register
from subproblems.screw import rotation_exp

__all__ = [
    "orientation_r",
    "orientation_rr",
    "orientation_rrr",
    "direction_r",
    "direction_rr",
    "orientation_r_batch",
    "orientation_rr_batch",
    "orientation_rrr_batch",
    "rotation_error",
    "rotation_families",
]

# Tolerances: subproblems/tolerances.py (each with its reason there; docs/design.md section 10).
EXACT_TOL = tol.EXACT  # radians here
PAR_TOL = tol.O_PARALLEL
_DEGEN = tol.O_DEGENERATE
GIMBAL_TOL = tol.O_GIMBAL
FREE_TOL = tol.O_VECTOR_ON_AXIS
DEDUP_TOL = tol.O_SAME_SOLUTION
POLISH_TOL = tol.O_POLISH
#: Gauss-Newton steps on the general ``O-RRR`` candidates (linear convergence near a singularity).
GN_ITERS = 12
NEAR_PAR = tol.O_NEAR_PARALLEL
WELL_COND = tol.O_WELL_CONDITIONED
TANGENT_ULPS = tol.O_TANGENT_ULPS
TANGENT_FLOOR = tol.O_TANGENT_FLOOR

_TWO_PI = 2.0 * math.pi
_SQRT8 = math.sqrt(8.0)


# ----------------------------------------------------------------------------------------------------
# small scalar helpers
# ----------------------------------------------------------------------------------------------------


def _unit(w) -> np.ndarray:
    w = np.asarray(w, dtype=float).reshape(3)
    n = float(np.linalg.norm(w))
    if not math.isfinite(n) or n < 1e-12:
        raise SubproblemInputError(f"rotation axis {w} is zero or not finite")
    return w / n


def _rot(R) -> np.ndarray:
    R = np.asarray(R, dtype=float)
    if R.shape == (4, 4):
        R = R[:3, :3]
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise SubproblemInputError(f"expected a finite 3x3 rotation (or 4x4 transform), got shape {R.shape}")
    return R


def rotation_error(E, R) -> float:
    """Angle (radians) of the rotation ``E^T R``; 0 when ``E = R``.

    >>> round(rotation_error(np.eye(3), rotation_exp([1, 0, 0], 0.25)), 12)
    0.25
    """
    d = float(np.linalg.norm(np.asarray(E, dtype=float) - np.asarray(R, dtype=float)))
    return 2.0 * math.asin(min(1.0, d / _SQRT8))


def _angle_about(w, a, b, scale: float = 1.0) -> tuple[float, bool]:
    """Angle about ``w`` (through 0) turning ``a`` closest to ``b``; ``free`` if ``a`` is on the axis."""
    u = a - w * float(w @ a)
    v = b - w * float(w @ b)
    if float(np.linalg.norm(u)) <= FREE_TOL * scale:
        return 0.0, True
    return math.atan2(float(w @ np.cross(u, v)), float(u @ v)), False


def _angle_r(w, R) -> tuple[float, bool]:
    """Least-squares angle of ``exp([w] t) = R``; ``free`` when every angle is equally good."""
    vee = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    a = float(w @ vee)
    b = float(np.trace(R) - w @ R @ w)
    if math.hypot(a, b) <= 1e-12:
        return 0.0, True
    return math.atan2(a, b), False


def _product(ws, th) -> np.ndarray:
    E = np.eye(3)
    for w, t in zip(ws, th):
        E = E @ rotation_exp(w, t)
    return E


def _polish(ws, R, th, fixed=(), iters: int = 4) -> np.ndarray:
    """Gauss-Newton on ``prod exp([w_i] t_i) = R`` over the joints not in ``fixed`` (accept if better)."""
    th = np.array(th, dtype=float)
    free = [i for i in range(len(ws)) if i not in fixed]
    if not free:
        return th
    err = rotation_error(_product(ws, th), R)
    for _ in range(iters):
        if err <= 1e-15:
            break
        # body-frame error: E^T R = exp([e]); d(E)/dt_i = E [J_i] with J_i = (E_{i+1..k})^T w_i
        E = _product(ws, th)
        M = E.T @ R
        e = 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
        J = np.zeros((3, len(free)))
        for c, i in enumerate(free):
            J[:, c] = _product(ws[i + 1 :], th[i + 1 :]).T @ ws[i]
        step = np.linalg.lstsq(J, e, rcond=1e-10)[0]
        th2 = th.copy()
        th2[free] += step
        err2 = rotation_error(_product(ws, th2), R)
        if not err2 < err:
            break
        th, err = th2, err2
    return th


def _finish(ws, R, cands, allow_continuum=True) -> list[Solution]:
    """Polish, verify, deduplicate candidates ``(th, continuum, fixed)``; best ``ls`` one if none exact."""
    scored = []
    for th, cont, fixed in cands:
        th = np.asarray(th, dtype=float)
        err = rotation_error(_product(ws, th), R)
        if err <= POLISH_TOL:
            th = _polish(ws, R, th, fixed)
            err = rotation_error(_product(ws, th), R)
        scored.append((err, tuple(wrap(a) for a in th), bool(cont and allow_continuum)))
    exact = sorted((s for s in scored if s[0] <= EXACT_TOL), key=lambda s: s[0])
    if not exact:
        err, th, cont = min(scored, key=lambda s: s[0])
        return [Solution(th, ls=True, continuum=cont)]
    kept: list[tuple[float, tuple, bool]] = []
    for s in exact:
        if all(
            max(abs(math.remainder(a - b, _TWO_PI)) for a, b in zip(s[1], k[1])) > DEDUP_TOL for k in kept
        ):
            kept.append(s)
    kept.sort(key=lambda s: s[1])
    return [Solution(th, continuum=cont) for _, th, cont in kept]


# ----------------------------------------------------------------------------------------------------
# candidates with their continuum families (shared with the class I solvers)
# ----------------------------------------------------------------------------------------------------


def rotation_families(ws, R) -> list[tuple[np.ndarray, np.ndarray | None, int]]:
    """Candidate solutions of ``prod exp([w_i] t_i) = R`` (k = 0..3 unit axes) with their families.

    Each entry is ``(th, n, dim)``: ``dim = 0`` an isolated candidate (``n`` is None); ``dim = 1`` every
    ``th + tau n`` has the same orientation (``n`` has entries 0 and +-1; ``th`` is the documented
    representative); ``dim = 2`` (three parallel axes) only ``sum s_i t_i`` is determined, ``n`` is None.
    Candidates are not verified: unreachable instances give least-squares candidates.
    """
    ws = [np.asarray(w, dtype=float) for w in ws]
    k = len(ws)
    if k == 0:
        return [(np.zeros(0), None, 0)]
    if k == 1:
        return [(np.array([_angle_r(ws[0], R)[0]]), None, 0)]

    # A degenerate branch (parallel axes) is taken when its representative is exact, or when the axes
    # are so close to parallel that the general formulas cannot be evaluated; otherwise the general
    # formulas run (and a near-parallel unreachable instance gets a general least-squares answer).
    def exact(cand) -> bool:
        return rotation_error(_product(ws, cand), R) <= EXACT_TOL

    if k == 2:
        w1, w2 = ws
        c12 = float(np.linalg.norm(np.cross(w1, w2)))
        if c12 <= PAR_TOL:
            s = 1.0 if w1 @ w2 > 0 else -1.0
            cand = np.array([0.0, s * _angle_r(w1, R)[0]])
            if c12 <= _DEGEN or exact(cand):
                return [(cand, np.array([1.0, -s]), 1)]
        t1, _ = _angle_about(w1, w2, R @ w2, 0.0)
        t2, _ = _angle_r(w2, rotation_exp(w1, -t1) @ R)
        return [(np.array([t1, t2]), None, 0)]
    w1, w2, w3 = ws
    c12 = float(np.linalg.norm(np.cross(w1, w2)))
    c23 = float(np.linalg.norm(np.cross(w2, w3)))
    general_ok = min(c12, c23) > _DEGEN
    if c12 <= PAR_TOL and c23 <= PAR_TOL:
        s3 = 1.0 if w1 @ w3 > 0 else -1.0
        cand = np.array([0.0, 0.0, s3 * _angle_r(w1, R)[0]])
        # forced only when no pair is resolvable: w1 || w2 exactly with w3 ~1e-9 off is a 1-D family
        # (taken below), not the 2-D one
        if exact(cand) or (not general_ok and float(np.linalg.norm(np.cross(w1, w3))) <= _DEGEN):
            return [(cand, None, 2)]
    if c12 <= PAR_TOL:
        ((th, _, _),) = rotation_families([w1, w3], R)
        s = 1.0 if w1 @ w2 > 0 else -1.0
        cand = np.array([0.0, s * th[0], th[1]])
        if c12 <= _DEGEN or exact(cand):
            return [(cand, np.array([1.0, -s, 0.0]), 1)]
    if c23 <= PAR_TOL:
        ((th, _, _),) = rotation_families([w1, w2], R)
        s = 1.0 if w2 @ w3 > 0 else -1.0
        cand = np.array([th[0], 0.0, s * th[1]])
        if c23 <= _DEGEN or exact(cand):
            return [(cand, np.array([0.0, 1.0, -s]), 1)]
    Rw3 = R @ w3
    if np.linalg.norm(np.cross(w1, Rw3)) <= GIMBAL_TOL:
        # gimbal lock: exp([w2]t2) w3 = sigma w1, so exp([w2]t2) exp([w3]t3) = exp([w1] sigma t3) exp([w2]t2)
        ((th, _, _),) = rotation_families([w2, w3], R)
        cand = np.array([0.0, th[0], th[1]])
        if exact(cand):
            sigma = 1.0 if w1 @ Rw3 > 0 else -1.0
            return [(cand, np.array([1.0, 0.0, -sigma]), 1)]
    # the general case shares the vectorised code (one instance), so both paths give the same rows
    C = _general_rrr_b(np.array([ws])[:, :3], R[None], Rw3[None])[0]
    return [(C[0], None, 0), (C[1], None, 0)]


# ----------------------------------------------------------------------------------------------------
# public scalar solvers
# ----------------------------------------------------------------------------------------------------


def _solve_orientation(ws, R) -> list[Solution]:
    if len(ws) == 3:
        # O-RRR: the vectorised path on one instance (near singular configurations the polished rows
        # and their least-squares flags would otherwise depend on the path's rounding)
        W = np.array([ws])
        b = _finish_b("O-RRR", W, R[None], *rotation_families_batch(W, R[None]))
        rows = sorted(
            (tuple(float(a) for a in q), bool(f)) for q, f in zip(b.q[0][b.valid[0]], b.ls[0][b.valid[0]])
        )
        return [Solution(q, ls=f, continuum=bool(b.continuum[0])) for q, f in rows]
    cands = []
    for th, n, dim in rotation_families(ws, R):
        if dim == 0:
            cands.append((th, False, ()))
        else:
            fixed = (0, 1) if dim == 2 else tuple(i for i in range(len(ws)) if n[i] > 0)[:1]
            cands.append((th, True, fixed))
    return _finish(ws, R, cands)


def orientation_r(w, R) -> list[Solution]:
    """Every solution of ``exp([w] t) = R`` (one; least squares when ``R`` is not about ``w``).

    >>> orientation_r([0, 0, 1], rotation_exp([0, 0, 1], 0.7))
    [Solution(q=(0.7,), ls=False, continuum=False)]
    """
    w, R = _unit(w), _rot(R)
    t, free = _angle_r(w, R)
    err = rotation_error(rotation_exp(w, t), R)
    return [Solution((wrap(t),), ls=err > EXACT_TOL, continuum=free)]


def orientation_rr(w1, w2, R) -> list[Solution]:
    """Every solution of ``exp([w1] t1) exp([w2] t2) = R`` (at most one, or a continuum).

    >>> R = rotation_exp([0, 0, 1], 0.2) @ rotation_exp([1, 0, 0], -0.4)
    >>> [round(a, 12) for a in orientation_rr([0, 0, 1], [1, 0, 0], R)[0].q]
    [0.2, -0.4]
    """
    return _solve_orientation([_unit(w1), _unit(w2)], _rot(R))


def orientation_rrr(w1, w2, w3, R) -> list[Solution]:
    """Every solution of ``exp([w1] t1) exp([w2] t2) exp([w3] t3) = R`` (at most two, or a continuum).

    See the module docstring for the degenerate cases and their representatives.
    """
    return _solve_orientation([_unit(w1), _unit(w2), _unit(w3)], _rot(R))


def direction_r(w, u, v) -> list[Solution]:
    """Solution of ``exp([w] t) u = v`` (Paden-Kahan 1 through the origin; least squares if unreachable).

    >>> direction_r([0, 0, 1], [1, 0, 0], [0, 1, 0])
    [Solution(q=(1.5707963267948966,), ls=False, continuum=False)]
    """
    w = _unit(w)
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    scale = max(1.0, float(np.linalg.norm(u)), float(np.linalg.norm(v)))
    t, free = _angle_about(w, u, v, scale)
    err = float(np.linalg.norm(rotation_exp(w, t) @ u - v))
    return [Solution((wrap(t),), ls=err > EXACT_TOL * scale, continuum=free)]


def _polish_direction(w1, w2, u, v, t1, t2, scale, iters: int = 4) -> tuple[float, float]:
    """Gauss-Newton on ``exp([w1]t1) exp([w2]t2) u - v`` from a candidate (steps kept if better)."""

    def f(a, b):
        E1, E2 = rotation_exp(w1, a), rotation_exp(w2, b)
        x2 = E2 @ u
        x = E1 @ x2
        return x - v, np.column_stack([np.cross(w1, x), E1 @ np.cross(w2, x2)])

    r, J = f(t1, t2)
    err = float(np.linalg.norm(r))
    if err > 1e-4 * scale:
        return t1, t2
    for _ in range(iters):
        if err <= 1e-16 * scale:
            break
        d = np.linalg.lstsq(J, -r, rcond=1e-10)[0]
        r2, J2 = f(t1 + d[0], t2 + d[1])
        e2 = float(np.linalg.norm(r2))
        if not e2 < err:
            break
        t1, t2, r, J, err = t1 + float(d[0]), t2 + float(d[1]), r2, J2, e2
    return t1, t2


def direction_rr(w1, w2, u, v) -> list[Solution]:
    """Every solution of ``exp([w1] t1) exp([w2] t2) u = v`` (at most two, or a continuum).

    >>> sols = direction_rr([0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, 1])
    >>> [tuple(round(a, 12) + 0.0 for a in s.q) for s in sols]
    [(0.0, 1.570796326795)]
    """
    w1, w2 = _unit(w1), _unit(w2)
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    scale = max(1.0, float(np.linalg.norm(u)), float(np.linalg.norm(v)))
    cands = []
    v_on_1 = np.linalg.norm(v - w1 * float(w1 @ v)) <= FREE_TOL * scale
    u_on_2 = np.linalg.norm(u - w2 * float(w2 @ u)) <= FREE_TOL * scale
    if np.linalg.norm(np.cross(w1, w2)) <= PAR_TOL or v_on_1:
        t2, _ = _angle_about(w2, u, v, scale)
        cands.append((0.0, t2, True))
    elif u_on_2:
        t1, _ = _angle_about(w1, u, v, scale)
        cands.append((t1, 0.0, True))
    else:
        k = float(w1 @ w2)
        a1, a2 = float(w1 @ v), float(w2 @ u)
        c = np.cross(w1, w2)
        cc = float(c @ c)  # = 1 - k^2 without its cancellation for nearly parallel axes (> PAR_TOL^2 here)
        al = (a1 - k * a2) / cc
        be = (a2 - k * a1) / cc
        g2 = (float(u @ u) - al * al - be * be - 2.0 * al * be * k) / cc
        g = math.sqrt(max(0.0, g2))
        starts = []
        for sg in (g, -g) if g > 0 else (0.0,):
            z = al * w1 + be * w2 + sg * c
            t2, _ = _angle_about(w2, u, z, scale)
            t1, _ = _angle_about(w1, z, v, scale)
            starts.append((t1, t2))
        iters = 4
        if cc < 1e-12 or np.linalg.norm(np.cross(w1, v)) < 1e-6 * scale:
            # nearly parallel axes, or v nearly on axis 1: the formulas above lose the angles
            # (~eps / |w1 x w2|^2, or t1 entirely); the solutions lie near the family of the
            # degenerate case (t1 = tau, t2 turning u towards exp(-[w1]tau) v): Gauss-Newton from
            # eight points of it finds them
            iters = 30
            for tau in np.arange(8) * (math.pi / 4):
                t2, _ = _angle_about(w2, u, rotation_exp(w1, -tau) @ v, scale)
                starts.append((float(tau), t2))
        if np.linalg.norm(np.cross(w2, u)) < 1e-6 * scale:
            # u nearly on axis 2: the same with the roles of the joints swapped
            iters = 30
            for tau in np.arange(8) * (math.pi / 4):
                t1, _ = _angle_about(w1, rotation_exp(w2, tau) @ u, v, scale)
                starts.append((t1, float(tau)))
        for t1, t2 in starts:
            t1, t2 = _polish_direction(w1, w2, u, v, t1, t2, scale, iters=iters)
            cands.append((t1, t2, False))
    scored = []
    for t1, t2, cont in cands:
        err = float(np.linalg.norm(rotation_exp(w1, t1) @ rotation_exp(w2, t2) @ u - v))
        scored.append((err, (wrap(t1), wrap(t2)), cont))
    exact = [s for s in scored if s[0] <= EXACT_TOL * scale]
    if not exact:
        err, th, cont = min(scored, key=lambda s: s[0])
        return [Solution(th, ls=True, continuum=cont)]
    kept: list = []
    for s in sorted(exact, key=lambda s: s[0]):
        if all(
            max(abs(math.remainder(a - b, _TWO_PI)) for a, b in zip(s[1], k_[1])) > DEDUP_TOL for k_ in kept
        ):
            kept.append(s)
    # never more than theory allows (2): near a tangency several polished starts stall at different
    # points that all meet the tolerance; the best ones are kept
    kept = kept[:2]
    kept.sort(key=lambda s: s[1])
    return [Solution(th, continuum=cont) for _, th, cont in kept]


# ----------------------------------------------------------------------------------------------------
# vectorised helpers: N instances, no Python loop over them
# ----------------------------------------------------------------------------------------------------


def _hat_b(w) -> np.ndarray:
    W = np.zeros(w.shape[:-1] + (3, 3))
    W[..., 0, 1], W[..., 0, 2] = -w[..., 2], w[..., 1]
    W[..., 1, 0], W[..., 1, 2] = w[..., 2], -w[..., 0]
    W[..., 2, 0], W[..., 2, 1] = -w[..., 1], w[..., 0]
    return W


def rexp_batch(w, t) -> np.ndarray:
    """``exp([w] t)`` for stacked unit axes ``w`` (..., 3) and angles ``t`` (...): (..., 3, 3)."""
    W = _hat_b(w)
    s, c = np.sin(t)[..., None, None], np.cos(t)[..., None, None]
    return np.eye(3) + s * W + (1.0 - c) * (W @ W)


def _mv(M, x) -> np.ndarray:
    return np.einsum("...ij,...j->...i", M, x)


def _dot(a, b) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def _tr(M) -> np.ndarray:
    return np.swapaxes(M, -1, -2)


def rotation_error_batch(E, R) -> np.ndarray:
    """:func:`rotation_error` over stacked matrices."""
    d = np.linalg.norm(E - R, axis=(-2, -1))
    return 2.0 * np.arcsin(np.minimum(1.0, d / _SQRT8))


def _angle_r_b(w, R):
    vee = np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1
    )
    a = _dot(w, vee)
    b = np.trace(R, axis1=-2, axis2=-1) - _dot(w, _mv(R, w))
    free = np.hypot(a, b) <= 1e-12
    return np.where(free, 0.0, np.arctan2(a, b)), free


def _angle_about_b(w, a, b, scale=1.0):
    u = a - w * _dot(w, a)[..., None]
    v = b - w * _dot(w, b)[..., None]
    free = np.linalg.norm(u, axis=-1) <= FREE_TOL * scale
    t = np.arctan2(_dot(w, np.cross(u, v)), _dot(u, v))
    return np.where(free, 0.0, t), free


def product_batch(W, TH) -> np.ndarray:
    """``prod_i exp([w_i] t_i)`` for axes (..., k, 3) and angles (..., k): (..., 3, 3)."""
    E = np.broadcast_to(np.eye(3), TH.shape[:-1] + (3, 3)).copy()
    for i in range(TH.shape[-1]):
        E = E @ rexp_batch(W[..., i, :], TH[..., i])
    return E


def _polish_b(W, R, TH, fixed, iters: int = 4) -> np.ndarray:
    """Batched Gauss-Newton on the orientation (``fixed``: (..., k) joints kept); steps kept if better."""
    k = TH.shape[-1]
    if k == 0:
        return TH
    err = rotation_error_batch(product_batch(W, TH), R)
    for _ in range(iters):
        if not np.any(err > 1e-15):
            break
        E = product_batch(W, TH)
        M = _tr(E) @ R
        e = 0.5 * np.stack(
            [M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]], -1
        )
        cols = []
        for i in range(k):
            tail = product_batch(W[..., i + 1 :, :], TH[..., i + 1 :])
            cols.append(_mv(_tr(tail), W[..., i, :]))
        J = np.stack(cols, -1) * (~fixed)[..., None, :]
        step = np.einsum("...ij,...j->...i", np.linalg.pinv(J, rcond=1e-10), e)
        TH2 = TH + step
        err2 = rotation_error_batch(product_batch(W, TH2), R)
        better = (err2 < err) & (err > 1e-15)
        if not better.any():
            break
        TH = np.where(better[..., None], TH2, TH)
        err = np.where(better, err2, err)
    return TH


def _half_split(rhs, rho):
    """Half the angle between the two roots of ``rho cos(t - psi) = rhs``, and where they are a double root.

    ``|rhs| >= rho`` up to the roundoff of the coefficients (a few ulps of ``rho``) is a tangency: the
    half split is exactly 0 or pi, so both roots are the tangent point itself (accurate to roundoff),
    not ``+- sqrt(2 * roundoff)`` from it (accurate to ``sqrt(eps)`` only).  Beyond it the root is
    clamped (least squares); ``rho = 0`` gives 0.
    """
    with np.errstate(over="ignore", invalid="ignore"):  # rho subnormal or 0
        c = np.where(rho > 0, rhs / np.where(rho > 0, rho, 1.0), 0.0)
    tangent = (rho > 0) & (np.abs(c) >= 1.0 - TANGENT_ULPS * np.finfo(float).eps)
    return np.where(tangent, np.where(c > 0, 0.0, math.pi), np.arccos(np.clip(c, -1.0, 1.0))), tangent


def _general_rrr_b(W, R, Rw3) -> np.ndarray:
    """(N, 2, 3): the two isolated candidates of ``O-RRR`` from both eliminations, polished.

    ``t2`` first: ``w1^T exp([w2]t2) w3 = w1^T R w3`` (``alpha + beta cos t2 + gamma sin t2 = delta``),
    then ``t1`` turns ``exp([w2]t2) w3`` onto ``R w3``.  Near a gimbal lock (``R w3`` close to ``+-w1``)
    this equation has a double root and ``t1`` is lost.  ``t1`` first: ``z = exp([w2]t2) w3 =
    exp(-[w1]t1) R w3`` keeps its component along ``w2``, so ``w2^T exp(-[w1]t1) R w3 = w2^T w3``
    (``A cos t1 + B sin t1 = C``), then ``t2`` turns ``w3`` onto ``z``: accurate near a gimbal lock (all
    coefficients small but relatively accurate), yet it has the double root when ``w2`` and ``w3`` are
    nearly parallel, where the ``t2``-first form is fine.  Neither is uniformly better.  The ``t2``-first
    pair is polished (:data:`GN_ITERS` Gauss-Newton steps) and final when both rows are exact, distinct
    and well conditioned (``|det J| >= WELL_COND``); otherwise the ``t1``-first pair is added, and for
    consecutive axes nearly parallel (below :data:`NEAR_PAR`, where both eliminations lose the angles:
    their coefficients are of size ``|w1 x w2|`` or ``|w2 x w3|``, squared when all three line up)
    Gauss-Newton restarts from eight points of the parallel family; the best candidate and the best one
    farther than :data:`DEDUP_TOL` from it are returned (it again when all agree).  Without an exact
    candidate these are least-squares candidates (the clamped roots, polished).  The scalar path calls
    this with one instance.
    """
    N = W.shape[0]
    w1, w2, w3 = W[:, 0], W[:, 1], W[:, 2]
    # t2 first
    w3par = w2 * _dot(w2, w3)[:, None]
    alpha = _dot(w1, w3par)
    beta = _dot(w1, w3 - w3par)
    gamma = _dot(w1, np.cross(w2, w3))
    delta = _dot(w1, Rw3)
    rho = np.hypot(beta, gamma)
    psi = np.arctan2(gamma, beta)
    half2, tangent = _half_split(delta - alpha, rho)
    t2 = psi[:, None] + np.array([1.0, -1.0]) * half2[:, None]  # (N, 2)
    W2 = np.repeat(W[:, None], 2, 1)
    t1, _ = _angle_about_b(W2[:, :, 0], _mv(rexp_batch(W2[:, :, 1], t2), w3[:, None]), Rw3[:, None])
    E12 = rexp_batch(W2[:, :, 0], t1) @ rexp_batch(W2[:, :, 1], t2)
    t3, _ = _angle_r_b(W2[:, :, 2], _tr(E12) @ R[:, None])
    C = _polish_b(
        W2, np.repeat(R[:, None], 2, 1), np.stack([t1, t2, t3], -1), np.zeros((N, 2, 3), bool), iters=GN_ITERS
    )
    err = rotation_error_batch(product_batch(W2, C), R[:, None])
    settled = (err.max(1) <= EXACT_TOL) & (np.max(np.abs(wrap_array(C[:, 0] - C[:, 1])), -1) > DEDUP_TOL)
    settled &= _jac_det_b(W2, C).min(1) >= WELL_COND
    idx = np.nonzero(~settled)[0]
    if not len(idx):
        return C
    n = len(idx)
    Ws, Rs, Rw3s = W[idx], R[idx], Rw3[idx]
    v1, v2, v3 = Ws[:, 0], Ws[:, 1], Ws[:, 2]
    # t1 first (where R w3 is off the axis w1)
    u_par = v1 * _dot(v1, Rw3s)[:, None]
    bb = Rw3s - u_par
    first1 = np.linalg.norm(bb, axis=-1) > FREE_TOL
    A1 = _dot(v2, bb)
    B1 = -_dot(v2, np.cross(v1, bb))
    C1 = _dot(v2, v3) - _dot(v2, u_par)
    d1, _ = _half_split(C1, np.hypot(A1, B1))
    t1b = np.arctan2(B1, A1)[:, None] + np.array([1.0, -1.0]) * d1[:, None]
    V2 = np.repeat(Ws[:, None], 2, 1)
    zb = _mv(rexp_batch(V2[:, :, 0], -t1b), Rw3s[:, None])
    t2b, _ = _angle_about_b(V2[:, :, 1], V2[:, :, 2], zb)
    E12 = rexp_batch(V2[:, :, 0], t1b) @ rexp_batch(V2[:, :, 1], t2b)
    t3b, _ = _angle_r_b(V2[:, :, 2], _tr(E12) @ Rs[:, None])
    rows = [np.stack([t1b, t2b, t3b], -1)]
    oks = [np.repeat(first1[:, None], 2, 1)]
    # restarts from the parallel families where consecutive axes are nearly parallel
    c12 = np.linalg.norm(np.cross(v1, v2), axis=-1)
    c23 = np.linalg.norm(np.cross(v2, v3), axis=-1)
    if (np.minimum(c12, c23) < NEAR_PAR).any():
        for tau in np.arange(8) * (math.pi / 4):
            tt = np.full(n, tau)
            th23, _, _ = _rr_b(v2, v3, _tr(rexp_batch(v1, tt)) @ Rs)
            rows.append(np.stack([tt, th23[:, 0], th23[:, 1]], -1)[:, None])
            oks.append((c12 < NEAR_PAR)[:, None])
            th12, _, _ = _rr_b(v1, v2, Rs @ _tr(rexp_batch(v3, tt)))
            rows.append(np.stack([th12[:, 0], th12[:, 1], tt], -1)[:, None])
            oks.append((c23 < NEAR_PAR)[:, None])
    S = np.concatenate(rows, 1)
    Sok = np.concatenate(oks, 1)
    M = S.shape[1]
    Wm = np.repeat(Ws[:, None], M, 1)
    S = _polish_b(
        Wm, np.repeat(Rs[:, None], M, 1), S, ~Sok[..., None] | np.zeros(S.shape, bool), iters=GN_ITERS
    )
    Serr = np.where(Sok, rotation_error_batch(product_batch(Wm, S), Rs[:, None]), np.inf)
    Call = np.concatenate([C[idx], S], 1)
    eall = np.concatenate([err[idx], Serr], 1)
    # the best candidate and the best one farther than DEDUP_TOL from it (or it again); a double root
    # of the t2 equation at the roundoff floor wins: its tangent point is accurate to roundoff, the
    # other candidates there (same residual floor) only to sqrt(eps)
    ar = np.arange(n)
    at_tangent = np.zeros(eall.shape, bool)
    at_tangent[:, :2] = tangent[idx, None] & (err[idx] <= TANGENT_FLOOR)
    i0 = np.argmin(np.where(at_tangent, 0.0, eall), axis=1)
    first = Call[ar, i0]
    dist = np.max(np.abs(wrap_array(Call - first[:, None])), axis=-1)
    e2 = np.where(dist > DEDUP_TOL, eall, np.inf)
    i1 = np.where(np.isfinite(e2).any(1), np.argmin(e2, axis=1), i0)
    C = C.copy()
    C[idx] = np.stack([first, Call[ar, i1]], 1)
    return C


def _jac_det_b(W, TH) -> np.ndarray:
    """Vectorised :func:`_jac_det` for axes (..., 3, 3) and angles (..., 3)."""
    E1 = rexp_batch(W[..., 0, :], TH[..., 0])
    a = _mv(E1, W[..., 1, :])
    b = _mv(E1 @ rexp_batch(W[..., 1, :], TH[..., 1]), W[..., 2, :])
    return np.abs(_dot(W[..., 0, :], np.cross(a, b)))


def rotation_families_batch(W, R):
    """Vectorised :func:`rotation_families` for N instances: axes (N, k, 3), rotations (N, 3, 3).

    Returns ``TH`` (N, K, k) candidates (K = 1, or 2 for k = 3), ``cvalid`` (N, K), family direction
    ``n`` (N, k) (zeros without a family; it belongs to slot 0) and ``dim`` (N,) in {0, 1, 2}.
    """
    N, k = W.shape[0], W.shape[1]
    if k == 0:
        return np.zeros((N, 1, 0)), np.ones((N, 1), bool), np.zeros((N, 0)), np.zeros(N, int)
    if k == 1:
        t, _ = _angle_r_b(W[:, 0], R)
        return t[:, None, None], np.ones((N, 1), bool), np.zeros((N, 1)), np.zeros(N, int)
    if k == 2:
        TH, n, dim = _rr_b(W[:, 0], W[:, 1], R)
        return TH[:, None], np.ones((N, 1), bool), n, dim
    w1, w2, w3 = W[:, 0], W[:, 1], W[:, 2]
    p12 = np.linalg.norm(np.cross(w1, w2), axis=-1) <= PAR_TOL
    p23 = np.linalg.norm(np.cross(w2, w3), axis=-1) <= PAR_TOL
    Rw3 = _mv(R, w3)
    TH = _general_rrr_b(W, R, Rw3)
    cvalid = np.ones((N, 2), bool)
    n = np.zeros((N, 3))
    dim = np.zeros(N, int)
    # w1 || w2 (not w3): t1 = 0
    th13, _, _ = _rr_b(w1, w3, R)
    s12 = np.where(_dot(w1, w2) > 0, 1.0, -1.0)
    a12 = np.stack([np.zeros(N), s12 * th13[:, 0], th13[:, 1]], -1)
    # w2 || w3 (not w1): t2 = 0
    th12, _, _ = _rr_b(w1, w2, R)
    s23 = np.where(_dot(w2, w3) > 0, 1.0, -1.0)
    a23 = np.stack([th12[:, 0], np.zeros(N), s23 * th12[:, 1]], -1)
    # all parallel: t1 = t2 = 0
    s13 = np.where(_dot(w1, w3) > 0, 1.0, -1.0)
    phi, _ = _angle_r_b(w1, R)
    aall = np.stack([np.zeros(N), np.zeros(N), s13 * phi], -1)
    # gimbal lock: t1 = 0, (t2, t3) from O-RR on axes 2, 3
    th23, _, _ = _rr_b(w2, w3, R)
    agim = np.stack([np.zeros(N), th23[:, 0], th23[:, 1]], -1)

    def exact(cand):
        return rotation_error_batch(product_batch(W, cand), R) <= EXACT_TOL

    c12 = np.linalg.norm(np.cross(w1, w2), axis=-1)
    c23 = np.linalg.norm(np.cross(w2, w3), axis=-1)
    gen_bad = np.minimum(c12, c23) <= _DEGEN
    c13 = np.linalg.norm(np.cross(w1, w3), axis=-1)
    use_all = p12 & p23 & ((gen_bad & (c13 <= _DEGEN)) | exact(aall))
    use_12 = ~use_all & p12 & ((c12 <= _DEGEN) | exact(a12))
    use_23 = ~use_all & ~use_12 & p23 & ((c23 <= _DEGEN) | exact(a23))
    taken = use_all | use_12 | use_23
    gim = ~taken & (np.linalg.norm(np.cross(w1, Rw3), axis=-1) <= GIMBAL_TOL) & exact(agim)
    sig = np.where(_dot(w1, Rw3) > 0, 1.0, -1.0)
    one = np.ones(N)
    zero = np.zeros(N)
    for mask, rep, nn, dd in (
        (gim, agim, np.stack([one, zero, -sig], -1), 1),
        (use_23, a23, np.stack([zero, one, -s23], -1), 1),
        (use_12, a12, np.stack([one, -s12, zero], -1), 1),
        (use_all, aall, np.zeros((N, 3)), 2),
    ):
        TH[:, 0] = np.where(mask[:, None], rep, TH[:, 0])
        cvalid[:, 1] &= ~mask
        n = np.where(mask[:, None], nn, n)
        dim = np.where(mask, dd, dim)
    return TH, cvalid, n, dim


def _rr_b(w1, w2, R):
    c12 = np.linalg.norm(np.cross(w1, w2), axis=-1)
    t1, _ = _angle_about_b(w1, w2, _mv(R, w2), 0.0)
    t2, _ = _angle_r_b(w2, _tr(rexp_batch(w1, t1)) @ R)
    s = np.where(_dot(w1, w2) > 0, 1.0, -1.0)
    phi, _ = _angle_r_b(w1, R)
    rep = np.stack([np.zeros_like(phi), s * phi], -1)
    ex = rotation_error_batch(product_batch(np.stack([w1, w2], -2), rep), R) <= EXACT_TOL
    par = (c12 <= PAR_TOL) & ((c12 <= _DEGEN) | ex)
    TH = np.where(par[:, None], rep, np.stack([t1, t2], -1))
    n = np.where(par[:, None], np.stack([np.ones_like(s), -s], -1), 0.0)
    return TH, n, par.astype(int)


def _finish_b(code, W, R, TH, cvalid, n, dim) -> BatchResult:
    """Batched counterpart of :func:`_finish`: polish, verify, deduplicate, keep the best ``ls`` one."""
    N, K, k = TH.shape
    cont = dim > 0
    fixed = np.zeros((N, K, k), bool)
    if k:
        first = np.argmax(n > 0, axis=-1)  # the representative joint of a 1-D family
        fam = np.zeros((N, k), bool)
        fam[np.arange(N), first] = dim == 1
        if k >= 2:
            fam[:, 0] |= dim == 2
            fam[:, 1] |= dim == 2
        fixed[:, 0] = fam
    Wk = np.repeat(W[:, None], K, 1)
    Rk = np.repeat(R[:, None], K, 1)
    err = rotation_error_batch(product_batch(Wk, TH), Rk)
    TH = np.where((err <= POLISH_TOL)[..., None], _polish_b(Wk, Rk, TH, fixed), TH)
    TH = wrap_array(TH)
    err = np.where(cvalid, rotation_error_batch(product_batch(Wk, TH), Rk), np.inf)
    exact = err <= EXACT_TOL
    valid = exact.copy()
    if K == 2:
        dist = np.max(np.abs(wrap_array(TH[:, 0] - TH[:, 1])), axis=-1)
        valid[:, 1] &= ~(valid[:, 0] & (dist <= DEDUP_TOL))
    none = ~exact.any(axis=1)
    best = np.argmin(err, axis=1)
    valid[np.arange(N), best] |= none
    ls = valid & ~exact
    return BatchResult(code, TH, valid, ls, cont)


def _batch_inputs(ws, R):
    W = np.asarray(ws, dtype=float)
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] == (4, 4):
        R = R[..., :3, :3]
    W = W / np.linalg.norm(W, axis=-1, keepdims=True)
    return W, R


def orientation_r_batch(w, R) -> BatchResult:
    """Vectorised :func:`orientation_r`: ``w`` (N, 3), ``R`` (N, 3, 3) or (N, 4, 4); ``q`` (N, 1, 1)."""
    W, R = _batch_inputs(np.asarray(w, dtype=float)[:, None], R)
    t, free = _angle_r_b(W[:, 0], R)
    t = wrap_array(t)
    err = rotation_error_batch(rexp_batch(W[:, 0], t), R)
    N = len(t)
    return BatchResult("O-R", t.reshape(N, 1, 1), np.ones((N, 1), bool), (err > EXACT_TOL)[:, None], free)


def orientation_rr_batch(w1, w2, R) -> BatchResult:
    """Vectorised :func:`orientation_rr`: axes (N, 3) each, ``R`` (N, 3, 3); ``q`` (N, 1, 2)."""
    W, R = _batch_inputs(np.stack([np.asarray(w1, float), np.asarray(w2, float)], 1), R)
    return _finish_b("O-RR", W, R, *rotation_families_batch(W, R))


def orientation_rrr_batch(w1, w2, w3, R) -> BatchResult:
    """Vectorised :func:`orientation_rrr`: axes (N, 3) each, ``R`` (N, 3, 3); ``q`` (N, 2, 3)."""
    W, R = _batch_inputs(np.stack([np.asarray(w, float) for w in (w1, w2, w3)], 1), R)
    return _finish_b("O-RRR", W, R, *rotation_families_batch(W, R))


# ----------------------------------------------------------------------------------------------------
# registration: codes O-R, O-RR, O-RRR for subproblems.solve / solve_batch
# ----------------------------------------------------------------------------------------------------


def _target_rotation(code, T) -> np.ndarray:
    T = np.asarray(T, dtype=float)
    if T.shape[-2:] not in ((4, 4), (3, 3)):
        raise SubproblemInputError(f"{code}: T must be a 4x4 transform (or a 3x3 rotation), got {T.shape}")
    return T[..., :3, :3]


def _residual(twists, qrow, T=None, **_) -> float:
    ws = [np.asarray(xi, dtype=float)[3:] for xi in twists]
    return rotation_error(_product(ws, qrow), _target_rotation("O", T))


def _make(code: str, k: int):
    def batch(twists, T) -> BatchResult:
        W, R = _batch_inputs(np.asarray(twists, dtype=float)[..., 3:], _target_rotation(code, T))
        if k == 1:
            b = orientation_r_batch(W[:, 0], R)
            return BatchResult(code, b.q, b.valid, b.ls, b.continuum)
        return _finish_b(code, W, R, *rotation_families_batch(W, R))

    def scalar(twists, T) -> list[Solution]:
        ws = [np.asarray(xi, dtype=float)[3:] for xi in twists]
        R = _target_rotation(code, T)
        if k == 1:
            return orientation_r(ws[0], R)
        return _solve_orientation([_unit(w) for w in ws], R)

    scalar.__name__ = scalar.__qualname__ = f"solve_{code.replace('-', '_').lower()}"
    scalar.__doc__ = (
        f"``{code}``: orientation of {k} revolute joint(s) through the origin (module docstring)."
    )
    return register(code, max_solutions=2 if k == 3 else 1, batch=batch, residual=_residual)(scalar)


solve_o_r = _make("O-R", 1)
solve_o_rr = _make("O-RR", 2)
solve_o_rrr = _make("O-RRR", 3)
