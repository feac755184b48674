"""Shared machinery of the class II solvers (``prod exp(xi_i th_i) p = q``): private.

Every class II solver works the same way, in two stages:

1. **Candidates.**  A geometric construction (scalar path) or an algebraic elimination (vectorised
   path) proposes joint vectors.  Candidates may be approximate (roots of an eliminant found by
   eigenvalues, intersections with a clamped discriminant, roots projected onto the unit circle when
   no real root exists): they only have to include every true solution.
2. **Verification.**  :func:`finalize` polishes each candidate with a few Gauss-Newton steps on the
   *original* equation, measures its residual ``|| prod exp(xi_i th_i) p - q ||``, keeps the exact ones
   (residual <= ``EXACT_TOL`` times the problem scale), removes duplicates (angles modulo 2 pi) and,
   when none is exact, returns the best least-squares candidate flagged ``ls``.  An exact row on a
   curve of exact solutions (found by :func:`on_continuum_rows`: a walk along the null direction of a
   singular Jacobian) flags the instance ``continuum``; that row is then one representative of the
   curve, returned with every other exact row (isolated solutions, other branches).

So a wrong solution can never be returned as exact, and the least-squares answer of an unreachable
instance is a local minimiser of the residual.  :func:`finalize_batch` does the same for N instances
at once with fixed candidate slots (no Python loop over instances).

Also here: the Paden-Kahan rotation angle (``rotation_angle``, the heart of S2-R, used by every solver
that ends with "rotate this point onto that one"), roots of trigonometric polynomials of degree <= 2
(``trig_roots``), and the inversion that maps ``RT``-type codes onto ``TR``-type ones.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np

from subproblems import tolerances as tol
from subproblems.angles import wrap, wrap_array, wrap_joints
from subproblems.core import BatchResult, Solution
from subproblems.screw import cross as _cross
from subproblems.screw import cross3
from subproblems.screw import twist_exp

# Tolerances: subproblems/tolerances.py (each with its reason there; docs/design.md section 10).
EXACT_TOL = tol.EXACT
DEDUP_TOL = tol.S2_SAME_SOLUTION
FREE_TOL = tol.S2_POINT_ON_AXIS
FREE_POINT_TOL = tol.S2_POLISHED_POINT_ON_AXIS
SAME_TOL = tol.S2_SAME_ROOT
COEF_TOL = tol.S2_ZERO_COEFFICIENT
#: Floating-point error of evaluating a chain, per unit of translation (one eps): added to a row's
#: residual before the exactness check, so a row whose joint values are too large to verify (~5e6
#: times the problem's size) is never flagged exact.
ROUNDOFF = float(np.finfo(float).eps)
POLISH_TOL = tol.S2_NO_POLISH
MERGE_TOL = tol.S2_TANGENT_MERGE
MERGE_SPREAD = tol.S2_TANGENT_SPREAD
FAR_TOL = tol.S2_FAR
TANGENT_TOL = tol.S2_TANGENT
NEAR_FREE_TOL = tol.S2_NEAR_POINT_ON_AXIS
SINGULAR_TOL = tol.S2_SINGULAR
#: The probe's steps along the curve (radians; prismatic values relative to the scale) and their number.
PROBE_STEP = 0.5
PROBE_STEPS = 2

TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------------------------------
# scalar helpers
# ----------------------------------------------------------------------------------------------------


def kinds_of(code: str) -> str:
    return code.split("-", 1)[1]


def _largest_length(twists, p, q) -> float:
    """max(|p|, |q|, distance of each revolute axis from the origin)."""
    L = max(float(np.linalg.norm(p)), float(np.linalg.norm(q)))
    for xi in np.asarray(twists, dtype=float):
        if xi[3:].any():
            L = max(L, float(np.linalg.norm(np.cross(xi[3:], xi[:3]))))
    return L


def problem_scale(twists, p, q) -> float:
    """Length scale of one instance: max(1, |p|, |q|, distance of each revolute axis from the origin)."""
    return max(1.0, _largest_length(twists, p, q))


def length_scale(twists, p, q) -> float:
    """The instance's own length: max(|p|, |q|, distance of each revolute axis from the origin), or 1
    when all vanish.  Unlike :func:`problem_scale` not floored at 1: candidate constructions run on the
    instance divided by it, so that their relative tolerances mean the same at every scale."""
    L = _largest_length(twists, p, q)
    return L if L > 0.0 and math.isfinite(L) else 1.0


def normalized(twists, p, q):
    """``(twists, p, q, L)`` of the same instance in units of its length ``L`` (:func:`length_scale`):
    angles are unchanged, translations divided by ``L``."""
    L = length_scale(twists, p, q)
    tw = np.array(twists, dtype=float)
    rev = tw[:, 3:].any(axis=1)
    tw[rev, :3] /= L
    return tw, np.asarray(p, dtype=float) / L, np.asarray(q, dtype=float) / L, L


def _largest_length_batch(tw, p, q) -> np.ndarray:
    """Vectorised :func:`_largest_length` over a leading axis N."""
    ap = np.linalg.norm(np.cross(tw[..., 3:], tw[..., :3]), axis=-1)
    return np.maximum(np.maximum(np.linalg.norm(p, axis=-1), np.linalg.norm(q, axis=-1)), ap.max(axis=-1))


def length_scale_batch(tw, p, q) -> np.ndarray:
    L = _largest_length_batch(tw, p, q)
    return np.where((L > 0.0) & np.isfinite(L), L, 1.0)


def normalized_batch(tw, p, q):
    """Vectorised :func:`normalized` over a leading axis N."""
    L = length_scale_batch(tw, p, q)
    tw = np.array(tw, dtype=float)
    rev = tw[..., 3:].any(axis=-1)
    tw[..., :3] = np.where(rev[..., None], tw[..., :3] / L[:, None, None], tw[..., :3])
    return tw, p / L[:, None], q / L[:, None], L


def wrap_row(kinds: str, th) -> np.ndarray:
    return wrap_joints(np.asarray(th, dtype=float).reshape(len(kinds)), kinds)


def joint_distance(kinds: str, a, b) -> float:
    err = 0.0
    for k, x, y in zip(kinds, a, b):
        err = max(err, abs(math.remainder(x - y, TWO_PI)) if k == "R" else abs(x - y) / max(1.0, abs(y)))
    return err


def chain_point_jac(twists, th, p) -> tuple[np.ndarray, np.ndarray]:
    """``x = prod exp(xi_i th_i) p`` and its Jacobian ``dx/dth`` (3, m)."""
    R, t = np.eye(3), np.zeros(3)
    cols = []
    for xi, a in zip(twists, th):
        wp = R @ xi[3:]
        vp = R @ xi[:3] + cross3(t, wp)
        cols.append((vp, wp))
        g = twist_exp(xi, a)
        t = R @ g[:3, 3] + t
        R = R @ g[:3, :3]
    x = R @ p + t
    J = np.column_stack([vp + cross3(wp, x) for vp, wp in cols])
    return x, J


def polish(twists, p, q, th, scale: float, iters: int = 6) -> np.ndarray:
    """A few Gauss-Newton steps on ``prod exp(xi_i th_i) p - q`` (each accepted only if it helps)."""
    th = np.array(th, dtype=float)
    x, J = chain_point_jac(twists, th, p)
    f = x - q
    r = float(np.linalg.norm(f))
    for _ in range(iters):
        if r <= 1e-15 * scale:
            break
        step = np.linalg.lstsq(J, -f, rcond=1e-12)[0]
        th2 = th + step
        x2, J2 = chain_point_jac(twists, th2, p)
        r2 = float(np.linalg.norm(x2 - q))
        if not r2 < r:
            break
        th, J, f, r = th2, J2, x2 - q, r2
    return th


def has_free_joint(twists, p, th, scale: float) -> bool:
    """True when some revolute joint acts on a point of its own axis (its angle is then free)."""
    x = np.asarray(p, dtype=float)
    for xi, a in zip(twists[::-1], th[::-1]):
        if xi[3:].any():
            u = x - cross3(xi[3:], xi[:3])
            if np.linalg.norm(u - xi[3:] * (xi[3:] @ u)) <= FREE_POINT_TOL * scale:
                return True
        g = twist_exp(xi, a)
        x = g[:3, :3] @ x + g[:3, 3]
    return False


def residual(twists, p, q, th) -> float:
    return float(np.linalg.norm(chain_point_jac(twists, th, p)[0] - q))


def roundoff(kinds: str, th) -> float:
    """Evaluation error of the chain at ``th``: :data:`ROUNDOFF` times the sum of the translations."""
    return ROUNDOFF * float(sum(abs(float(t)) for k, t in zip(kinds, th) if k == "T"))


def finalize(code: str, twists, p, q, candidates, continuum: bool = False) -> list[Solution]:
    """Polish, verify, deduplicate ``candidates`` (iterable of ``(th, free)``); see the module doc.

    ``free`` marks a candidate built with a free joint set to its representative value; ``continuum``
    marks the whole instance.  Without any exact candidate the best least-squares one is returned.
    Only candidates whose residual exceeds ``POLISH_TOL`` are polished; those farther than
    ``FAR_TOL`` only when no candidate of the instance is exact (then the best least-squares
    answer is wanted).  Two exact rows joined by a segment of exact joint values (a tangency: a double
    root located only to about the square root of the tolerance) are one solution: see
    :func:`merge_tangent`.
    """
    from subproblems.core import max_solutions

    kinds = kinds_of(code)
    twists = np.asarray(twists, dtype=float)
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    scale = problem_scale(twists, p, q)
    rows = []
    for th, free in candidates:
        th = np.asarray(th, dtype=float)
        if th.shape != (len(kinds),) or not np.all(np.isfinite(th)):
            continue
        th = wrap_row(kinds, th)
        rows.append([residual(twists, p, q, th), th, bool(free)])
    if not rows:  # nothing usable: the zero vector as a flagged least-squares answer
        th = np.zeros(len(kinds))
        return [Solution(tuple(th), ls=True, continuum=continuum)]

    def polish_row(row):
        row[1] = wrap_row(kinds, polish(twists, p, q, row[1], scale))
        row[0] = residual(twists, p, q, row[1])

    for row in rows:
        if POLISH_TOL * scale < row[0] <= FAR_TOL * scale:
            polish_row(row)
    if not any(row[0] <= EXACT_TOL * scale for row in rows):
        for row in rows:
            if row[0] > FAR_TOL * scale:
                polish_row(row)
    rows += _snapped_rows(kinds, twists, p, q, rows, scale)
    # a row's residual counts its own evaluation error: translations of ~1e8 on a unit problem (nearly
    # parallel prismatic directions) cannot be verified to EXACT_TOL, so they are not exact
    scored = [
        (r + roundoff(kinds, th), th, free or has_free_joint(twists, p, th, scale)) for r, th, free in rows
    ]
    exact = [s for s in scored if s[0] <= EXACT_TOL * scale]
    exact = _mark_continuum_rows(kinds, twists, p, q, exact, scale)
    if not exact:
        r, th, free = min(scored, key=lambda s: s[0])
        return [Solution(tuple(float(a) for a in th), ls=True, continuum=continuum or free)]
    exact.sort(key=lambda s: s[0])
    # kept: [residual, representative, free, anchor, sum of offsets from the anchor, members]; a
    # cluster of tangent rows is represented by its centroid (the roots of a k-fold root straddle
    # it), or by a member with a free joint
    kept: list[list] = []

    def join(k, s):  # s is one more root of k's cluster
        if s[2] and not k[2]:
            k[1], k[2] = s[1], True
        elif not k[2]:
            k[4], k[5] = k[4] + joint_offset(kinds, k[3], s[1]), k[5] + 1
            cen = wrap_row(kinds, polish(twists, p, q, k[3] + k[4] / k[5], scale))
            # not worse than the cluster's best member: an exact row joined by a looser copy of
            # itself (the other path's, 1e-12 off) keeps its place (S2-RRR lattice #68 seed 3)
            if residual(twists, p, q, cen) <= min(EXACT_TOL * scale, max(k[0], 4 * ROUNDOFF * scale)):
                k[1] = cen

    for s in exact:
        dup = next((k for k in kept if joint_distance(kinds, s[1], k[1]) <= DEDUP_TOL), None)
        if dup is not None:
            # a double root split by roundoff (+-sqrt(eps)) is one of these: the centroid, not
            # the first of the pair, is the tangent point
            if joint_distance(kinds, s[1], dup[1]) > SAME_TOL:
                join(dup, s)
            continue
        for k in kept:
            if merge_tangent(kinds, twists, p, q, k[1], s[1], scale, max(k[0], s[0])) is not None:
                join(k, s)
                break
        else:
            kept.append([s[0], s[1], s[2], s[1], np.zeros(len(kinds)), 1])
    kept = [(k[0], k[1], k[2]) for k in kept]
    kept = _tangent_points(kinds, twists, p, q, kept, scale)
    # Never return more rows than the type can have: merge the closest pairs.
    while len(kept) > max_solutions(code):
        i, j = min(
            ((i, j) for i in range(len(kept)) for j in range(i + 1, len(kept))),
            key=lambda ij: joint_distance(kinds, kept[ij[0]][1], kept[ij[1]][1]),
        )
        del kept[j]  # kept is sorted by residual: j has the larger one
    kept.sort(key=lambda s: tuple(s[1]))
    out = [Solution(tuple(float(a) for a in th), continuum=continuum or free) for _, th, free in kept]
    if near_rows_active():
        out += _near_rows(kinds, [k[1] for k in kept], scored, scale, max_solutions(code) - len(out))
    return out


def _near_rows(kinds: str, kept, scored, scale: float, room: int) -> list[Solution]:
    """Up to ``room`` least-squares rows among ``scored`` ``(residual, th, free)``: inexact ones within
    ``FAR_TOL`` of the size (polished), lowest residual first, none within ``DEDUP_TOL`` of a kept row
    or of each other (:func:`near_miss_rows`)."""
    out: list = []
    taken = list(kept)
    for r, th, _ in sorted(scored, key=lambda s: s[0]):
        if len(out) >= room:
            break
        distinct = all(joint_distance(kinds, th, k) > DEDUP_TOL for k in taken)
        if EXACT_TOL * scale < r <= FAR_TOL * scale and distinct:
            out.append(Solution(tuple(float(a) for a in th), ls=True))
            taken.append(th)
    return out


def _tangent_points(kinds: str, twists, p, q, kept, scale: float) -> list:
    """Kept ``(residual, th, free)`` rows with a singular Jacobian moved to the tangent point
    (:func:`refine_singular`), then deduplicated again (two rows of one multiple root meet there)."""
    out: list = []
    for r, th, free in kept:
        if not free:
            th = refine_singular(kinds, twists, p, q, th, scale)
        if not any(joint_distance(kinds, th, k[1]) <= DEDUP_TOL for k in out):
            out.append((r, th, free))
    return out


def _smallest_singular(twists, th, p):
    """``(x, J, Jn, sigma_min of Jn, u, v)`` at ``th``; ``Jn`` has unit columns (None if one vanishes)."""
    x, J = chain_point_jac(twists, th, p)
    n = np.linalg.norm(J, axis=0)
    if n.min() == 0.0:
        return x, J, None, 0.0, None, None
    Jn = J / n
    U, S, Vt = np.linalg.svd(Jn, full_matrices=False)
    return x, J, Jn, float(S[-1]), U[:, -1], Vt[-1]


def refine_singular(kinds: str, twists, p, q, th, scale: float, iters: int = 10) -> np.ndarray:
    """An exact row at a multiple root moved onto the root.

    There the Jacobian is singular and the residual grows only quadratically (or slower) along its
    null direction, so every point within ~1e-8 of the root is exact to roundoff and the
    constructions return any of them.  The root is where, in addition, the Jacobian is singular:
    Gauss-Newton on ``(f(th), scale * u^T Jn(th) v)`` (``u``, ``v`` the singular vectors of the smallest
    singular value of the column-scaled Jacobian, held fixed per step) converges to it.  The moved row
    is kept only if it stays exact to roundoff, lowers the singular value and moved less than
    TANGENT_TOL; two distinct roots close together (no multiple root between them) fail that.
    """
    th = np.asarray(th, dtype=float)
    x, J, Jn, sig0, u, v = _smallest_singular(twists, th, p)
    if Jn is None or sig0 >= UNCERTAIN_SING_TOL:
        return th
    r0 = float(np.linalg.norm(x - q))
    h = 1e-7
    t = th.copy()
    for _ in range(iters):
        x, J, Jn, sig, u, v = _smallest_singular(twists, t, p)
        if Jn is None:
            return th
        grad = []
        for k in range(len(t)):
            e = np.zeros(len(t))
            e[k] = h
            Jp = chain_point_jac(twists, t + e, p)[1]
            Jm = chain_point_jac(twists, t - e, p)[1]
            n = np.linalg.norm(J, axis=0)
            grad.append(float(u @ ((Jp - Jm) / n) @ v) / (2 * h))
        A = np.vstack([J, scale * np.array(grad)])
        b = np.concatenate([x - q, [scale * sig]])
        step = -np.linalg.lstsq(A, b, rcond=1e-12)[0]
        t = t + step
        if np.abs(step).max() <= 1e-15 * max(1.0, float(np.abs(t).max())):
            break
    t = wrap_row(kinds, t)
    x, _, Jn, sig, _, _ = _smallest_singular(twists, t, p)
    r = float(np.linalg.norm(x - q))
    if (
        np.all(np.isfinite(t))
        and r <= max(r0, 4 * ROUNDOFF * scale)
        and sig <= sig0
        and joint_distance(kinds, t, th) <= TANGENT_TOL
    ):
        return t
    return th


def _mark_continuum_rows(kinds: str, twists, p, q, exact, scale: float) -> list:
    """Scalar use of :func:`on_continuum_rows`: the exact ``(residual, th, free)`` rows, with ``free``
    set on those that lie on a continuum."""
    probe = [i for i, s in enumerate(exact) if not s[2]]
    if not probe:
        return exact
    M = len(probe)
    TH = np.array([exact[i][1] for i in probe])
    TW = np.broadcast_to(twists, (M,) + twists.shape)
    on = on_continuum_rows(
        kinds, TW, np.broadcast_to(p, (M, 3)), np.broadcast_to(q, (M, 3)), TH, np.full(M, scale)
    )
    exact = list(exact)
    for i, c in zip(probe, on):
        if c:
            exact[i] = (exact[i][0], exact[i][1], True)
    return exact


def _snapped_rows(kinds: str, twists, p, q, rows, scale: float) -> list:
    """Scalar use of :func:`snap_free_rows` on the exact rows near a free joint: new rows, free."""
    exact = [row[1] for row in rows if row[0] <= EXACT_TOL * scale]
    if not exact:
        return []
    TH = np.array(exact)
    M = len(TH)
    TW = np.broadcast_to(twists, (M,) + twists.shape)
    P, Qr, S = np.broadcast_to(p, (M, 3)), np.broadcast_to(q, (M, 3)), np.full(M, scale)
    _, _, dist = point_chain_rows(kinds, TW, TH, P, jac=False)
    dmin = dist.min(axis=1)
    sel = np.flatnonzero((dmin > FREE_POINT_TOL * scale) & (dmin <= NEAR_FREE_TOL * scale))
    if sel.size == 0:
        return []
    th, ok = snap_free_rows(kinds, TW[sel], P[sel], Qr[sel], TH[sel], dist[sel], S[sel])
    out = []
    for t in th[ok]:
        t = wrap_row(kinds, t)
        out.append([residual(twists, p, q, t), t, True])
    return out


def joint_offset(kinds: str, a, b) -> np.ndarray:
    """``b - a`` with angle differences along the shorter arc."""
    return np.array([math.remainder(y - x, TWO_PI) if k == "R" else y - x for k, x, y in zip(kinds, a, b)])


def joint_midpoint(kinds: str, a, b) -> np.ndarray:
    """The midpoint of two joint vectors (angles along the shorter arc)."""
    return wrap_row(kinds, np.asarray(a, dtype=float) + joint_offset(kinds, a, b) / 2)


def merge_tangent(kinds: str, twists, p, q, a, b, scale: float, res: float = 0.0):
    """One representative of two exact rows that are one (multiple) root, or None.

    Near a tangency (a double root: two circles touching, a line touching a circle; or a root of
    higher multiplicity) the computed roots straddle the true one by about ``eps^(1/k)`` relative,
    so several exact rows stand for one solution.  Two rows closer than ``TANGENT_TOL`` are one when
    their midpoint, polished, satisfies the equation to ``MERGE_TOL`` (1000 times tighter than
    exactness) and to ``MERGE_SPREAD`` times ``res``, the larger of the rows' own residuals (at least
    one eps of the scale), and polishing moved it by less than a tenth of their half-distance.  Two
    genuinely distinct roots fail this: between them the residual is ~curvature x (d/2)^2, far above
    their own, and polishing either stalls there or runs to one of them (near a fold, roots a few 1e-6
    apart leave less than ``MERGE_TOL`` between them: the residual relative to the rows' own is what
    tells them apart; tolerances.S2_TANGENT_SPREAD).  Returns the polished midpoint.
    """
    d = joint_distance(kinds, a, b)
    if d > TANGENT_TOL:
        return None
    mid = joint_midpoint(kinds, a, b)
    pm = wrap_row(kinds, polish(twists, p, q, mid, problem_scale(twists, p, q)))
    bound = min(MERGE_TOL * scale, MERGE_SPREAD * max(res, ROUNDOFF * scale))
    if residual(twists, p, q, pm) <= bound and joint_distance(kinds, pm, mid) <= 0.05 * d:
        return pm
    return None


def rotation_angle(xi, a, b, scale: float) -> tuple[float, bool]:
    """Paden-Kahan problem 1: the angle rotating point ``a`` about revolute ``xi`` closest to ``b``.

    Returns ``(theta, free)``; ``free`` is True when ``a`` lies on the axis (every angle does the same).
    """
    w = xi[3:]
    r = np.cross(w, xi[:3])
    u = a - r
    u = u - w * (w @ u)
    v = b - r
    v = v - w * (w @ v)
    if np.linalg.norm(u) <= FREE_TOL * scale:
        return 0.0, True
    return math.atan2(float(w @ np.cross(u, v)), float(u @ v)), False


def circle_of(xi, a):
    """Rotation of ``a`` about revolute ``xi`` as ``c0 + cc cos th + cs sin th``."""
    w = xi[3:]
    r = np.cross(w, xi[:3])
    u = a - r
    par = w * (w @ u)
    perp = u - par
    return r + par, perp, np.cross(w, perp)


def trig_roots(
    f0: float, c1: float, s1: float, c2: float = 0.0, s2: float = 0.0, ref: float = 0.0
) -> list[float] | None:
    """Roots of ``f0 + c1 cos th + s1 sin th + c2 cos 2th + s2 sin 2th``.

    Returns the arguments of all roots of the equivalent polynomial in ``z = exp(i th)`` (degree 4, or 2
    when the second harmonic vanishes): real roots exactly, complex ones projected onto the unit
    circle, which is where the polynomial's modulus is smallest nearby (least-squares candidates).
    Returns None when the polynomial vanishes identically (every coefficient at most ``COEF_TOL * ref``:
    every angle is a root) and ``[]`` when it is a non-zero constant.
    """
    a = np.array([(c2 - 1j * s2) / 2, (c1 - 1j * s1) / 2, f0, (c1 + 1j * s1) / 2, (c2 + 1j * s2) / 2])
    m = float(np.abs(a).max())
    if m <= COEF_TOL * ref or m == 0.0:
        return None
    if abs(a[0]) <= COEF_TOL * m:
        if abs(a[1]) <= COEF_TOL * m:
            return None if abs(f0) <= COEF_TOL * m else []
        a = a[1:4]
    roots = np.roots(a)
    return [float(np.angle(z)) for z in roots if abs(z) > 0.0]


def lin_trig_roots(f0: float, c1: float, s1: float, at0: float | None = None) -> list[float]:
    """Roots of ``f0 + c1 cos th + s1 sin th`` (not identically zero) to full relative accuracy.

    Half-angle substitution, ``u = tan(th / 2)``: ``(f0 - c1) u^2 + 2 s1 u + (f0 + c1) = 0``, solved by
    the cancellation-free quadratic formula in ``u`` or in ``1 / u`` (whichever keeps the roots within
    the unit disc).  Unlike the eigenvalues of :func:`trig_roots`, two roots ``delta`` apart come back
    with errors ~eps relative to the coefficients' size, not ~eps / delta (a circle nearly tangent
    to a plane).  Without real roots: the angle where ``|f|`` is smallest, twice (as :func:`trig_roots`).
    ``at0``: ``f(0) = f0 + c1`` when the caller has it without the cancellation of that sum.
    """
    A, B, C = f0 - c1, s1, f0 + c1 if at0 is None else at0
    disc = B * B - A * C
    if disc < 0.0 or (A == 0.0 and B == 0.0 and C == 0.0):
        th = math.atan2(s1, c1) if f0 < 0 else math.atan2(-s1, -c1)
        return [th, th]
    sq = math.copysign(math.sqrt(disc), B) if B != 0.0 else math.sqrt(disc)
    qq = -(B + sq)
    flip = abs(C) > abs(A)  # solve for w = 1 / u = cot(th / 2)
    a, c = (C, A) if flip else (A, C)
    if a == 0.0:  # linear (a double root at infinity when b vanishes too)
        roots = [-c / (2 * B), math.inf] if B != 0.0 else [math.inf, math.inf]
    else:
        roots = [qq / a, c / qq if qq != 0.0 else 0.0]
    out = []
    for r in roots:
        if flip:
            out.append(math.pi if r == 0.0 else 2 * math.atan2(1.0, r) if math.isfinite(r) else 0.0)
        else:
            out.append(2 * math.atan(r) if math.isfinite(r) else math.pi)
    return [wrap(t) for t in out]


@np.errstate(all="ignore")
def lin_trig_roots_batch(f0, c1, s1, at0=None):
    """Vectorised :func:`lin_trig_roots`: roots (N, 2) of ``f0 + c1 cos th + s1 sin th`` (0 twice when
    ``c1 = s1 = 0``, as :func:`trig_roots_batch`)."""
    A, B, C = f0 - c1, s1, f0 + c1 if at0 is None else at0
    disc = B * B - A * C
    lsq = (disc < 0.0) | ((A == 0.0) & (B == 0.0) & (C == 0.0))
    th_ls = np.where(f0 < 0, np.arctan2(s1, c1), np.arctan2(-s1, -c1))
    sq = np.sqrt(np.maximum(disc, 0.0))
    sq = np.where(B < 0, -sq, sq)
    qq = -(B + sq)
    flip = np.abs(C) > np.abs(A)
    a, c = np.where(flip, C, A), np.where(flip, A, C)
    lin = a == 0.0
    bb = np.where(B != 0.0, B, 1.0)
    r1 = np.where(lin, np.where(B != 0.0, -c / (2 * bb), np.inf), qq / np.where(lin, 1.0, a))
    r2 = np.where(lin, np.inf, np.where(qq != 0.0, c / np.where(qq != 0.0, qq, 1.0), 0.0))
    r = np.stack([r1, r2], -1)
    th_u = np.where(np.isfinite(r), 2 * np.arctan(r), np.pi)
    th_w = np.where(r == 0.0, np.pi, np.where(np.isfinite(r), 2 * np.arctan2(1.0, r), 0.0))
    th = np.where(flip[..., None], th_w, th_u)
    th = np.where(lsq[..., None], th_ls[..., None], th)
    th = np.where(((c1 == 0.0) & (s1 == 0.0))[..., None], 0.0, th)
    return wrap_array(th)  # th in (-pi, 2 pi): the one wrap, exact


def quadratic_form_to_fourier(A, B, C, D, E, F):
    """``A c^2 + B s c + C s^2 + D c + E s + F`` as ``(f0, c1, s1, c2, s2)`` for :func:`trig_roots`."""
    return F + (A + C) / 2, D, E, (A - C) / 2, B / 2


def real_quadratic_roots(a: float, b: float, c: float) -> list[float]:
    """Real roots of ``a t^2 + b t + c`` (the vertex when they are complex; [] when a = b = 0)."""
    m = max(abs(a), abs(b), abs(c))
    if m == 0.0:
        return []
    if abs(a) <= COEF_TOL * m:
        return [-c / b] if abs(b) > COEF_TOL * m else []
    disc = b * b - 4 * a * c
    if disc <= 0:
        return [-b / (2 * a)]
    sq = math.sqrt(disc)
    t1 = (-b - math.copysign(sq, b)) / (2 * a)
    return [t1, c / (a * t1)] if t1 != 0 else [t1, -b / a]


def inverted(twists) -> np.ndarray:
    """Twists of the inverted equation: ``exp(-xi_m th_m) ... exp(-xi_1 th_1) q = p``."""
    return -np.asarray(twists, dtype=float)[::-1]


def revert(solutions: list[Solution]) -> list[Solution]:
    """Solutions of the inverted equation in the original joint order."""
    return [Solution(s.q[::-1], ls=s.ls, continuum=s.continuum) for s in solutions]


# ----------------------------------------------------------------------------------------------------
# vectorised helpers: leading axis N (instances), then C (candidate slots)
# ----------------------------------------------------------------------------------------------------


def _mv(R, v):
    return np.einsum("...ij,...j->...i", R, v)


def problem_scale_batch(tw, p, q) -> np.ndarray:
    return np.maximum(1.0, _largest_length_batch(tw, p, q))


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def _turn(w, c, s, u):
    """Rodrigues: the vectors ``u`` (M, 3) turned about unit axes ``w`` (M, 3) by angles with cos/sin c, s."""
    return u * c[:, None] + _cross(w, u) * s[:, None] + w * ((1.0 - c) * _dot(w, u))[:, None]


def point_chain_rows(kinds: str, tw, th, p, jac: bool = True):
    """``x = prod exp(xi_i th_i) p`` per row, with no 4x4 matrices.

    ``tw`` (M, m, 6), ``th`` (M, m), ``p`` (M, 3).  Returns ``x`` (M, 3), the Jacobian ``dx/dth``
    (M, 3, m) (None unless ``jac``) and, per joint, the distance of the point it acts on from its
    axis (M, m; ``inf`` for prismatic joints), which reveals free joints.
    """
    M, m = th.shape
    c, s = np.cos(th), np.sin(th)
    x = p
    dist = np.full((M, m), np.inf)
    local = [None] * m  # d/dth_j of exp(xi_j th_j) y, at the current y
    for j in range(m - 1, -1, -1):
        v = tw[:, j, :3]
        if kinds[j] == "R":
            w = tw[:, j, 3:]
            r = _cross(w, v)
            u = x - r
            perp = u - w * _dot(w, u)[:, None]
            dist[:, j] = np.sqrt(_dot(perp, perp))
            x = r + _turn(w, c[:, j], s[:, j], u) + w * (_dot(w, v) * th[:, j])[:, None]
            if jac:
                local[j] = _cross(w, x - r) + w * _dot(w, v)[:, None]
        else:
            x = x + v * th[:, j, None]
            local[j] = v
    if not jac:
        return x, None, dist
    cols = []
    for j in range(m):
        d = local[j]
        for k in range(j - 1, -1, -1):  # turned by the joints before it
            if kinds[k] == "R":
                d = _turn(tw[:, k, 3:], c[:, k], s[:, k], d)
        cols.append(d)
    return x, np.stack(cols, axis=-1), dist


@np.errstate(all="ignore")
def on_continuum_rows(kinds: str, tw, p, q, th, scale) -> np.ndarray:
    """Mask (M,) of the exact rows ``th`` (M, m) that lie on a curve of exact solutions (a continuum).

    Joints with a short lever arm (their point within ``NEAR_FREE_TOL`` of their axis: free joints and
    their neighbourhood, see :func:`snap_free_rows`) stay fixed.  Rows whose Jacobian over the other
    joints, columns scaled to unit length, is singular (:data:`SINGULAR_TOL`) are probed: from the
    row, both ways, :data:`PROBE_STEPS` steps of :data:`PROBE_STEP` along the null direction, each
    followed by Gauss-Newton in the directions across it; every step exact means a continuum through
    the row (coincident axes, a translation along a revolute axis, ...: relations the constructions'
    own free-joint tests need not see).  A tangency (a double root, also singular) fails: across its
    null direction the residual grows as the square of the step.
    """
    M, m = th.shape
    out = np.zeros(M, dtype=bool)
    if M == 0 or m < 2:
        return out
    _, J, _ = point_chain_rows(kinds, tw, th, p)
    cs = np.where(np.array([k == "R" for k in kinds]), 1.0, scale[:, None])  # prismatic per unit scale
    norms = np.linalg.norm(J, axis=1) * cs
    long = norms > NEAR_FREE_TOL * scale[:, None]
    patterns = {tuple(row) for row in long}
    for pat in patterns:
        cols = np.flatnonzero(pat)
        if cols.size < 2:
            continue
        rows = np.flatnonzero((long == np.array(pat)).all(axis=1))
        Ju = J[rows][:, :, cols] / norms[rows][:, None, cols] * cs[rows][:, None, cols]
        Su = np.linalg.svd(Ju, compute_uv=False)
        rows = rows[np.isfinite(Su).all(-1) & (Su[:, -1] <= SINGULAR_TOL)]
        if rows.size:
            out[rows] = _walk_is_exact(kinds, tw[rows], p[rows], q[rows], th[rows], scale[rows], cols)
    return out


def _walk_is_exact(kinds, T, P, Qr, th, sc, cols) -> np.ndarray:
    """:func:`on_continuum_rows` on rows with a singular Jacobian over joints ``cols``: the walk."""
    cs = np.where(np.array([kinds[j] == "R" for j in cols]), 1.0, sc[:, None])  # (k, c)
    ok = np.ones(len(th), dtype=bool)
    for sign in (1.0, -1.0):
        t, prev = th.copy(), None
        for _ in range(PROBE_STEPS):
            _, J, _ = point_chain_rows(kinds, T, t, P)
            Vt = np.linalg.svd(J[:, :, cols] * cs[:, None, :])[2]
            null, across = Vt[:, -1, :], Vt[:, :-1, :]  # scaled coordinates of the joints cols
            if prev is None:
                null = sign * null
            else:  # keep walking the same way along the curve
                null = np.where((_dot(null, prev) < 0)[:, None], -null, null)
            prev = null
            t[:, cols] += PROBE_STEP * null * cs
            t, r = _correct_across(kinds, T, P, Qr, t, across, cs, cols)
            ok &= r <= EXACT_TOL * sc
    return ok


def _correct_across(kinds, T, P, Qr, t, across, cs, cols, iters: int = 8):
    """Gauss-Newton on rows ``t`` moving joints ``cols`` only along ``across`` (k, c - 1, c; scaled)."""
    m1 = across.shape[1]
    for _ in range(iters):
        x, J, _ = point_chain_rows(kinds, T, t, P)
        Jb = (J[:, :, cols] * cs[:, None, :]) @ np.swapaxes(across, -1, -2)  # (k, 3, c - 1)
        A = np.swapaxes(Jb, -1, -2) @ Jb
        mu = 1e-14 * (np.trace(A, axis1=-2, axis2=-1) + 1e-300)
        rhs = np.einsum("kji,kj->ki", Jb, x - Qr)[..., None]
        d = -np.linalg.solve(A + mu[:, None, None] * np.eye(m1), rhs)[..., 0]
        t[:, cols] += (np.where(np.isfinite(d), d, 0.0)[:, None, :] @ across)[:, 0, :] * cs
    x, _, _ = point_chain_rows(kinds, T, t, P, jac=False)
    return t, np.linalg.norm(x - Qr, axis=-1)


def snap_free_rows(kinds: str, tw, p, q, th, dist, scale, iters: int = 8):
    """Rows (M, m) moved so that the point of their nearest revolute joint lies on its axis.

    Gauss-Newton on the equation together with the offset of that point from the axis (the joint's
    own angle does not enter the offset and stays where it is).  Returns the moved rows and the mask
    of those that are then exact with the point on the axis (within ``FREE_POINT_TOL``): the joint is
    free there, the instance a continuum, and the moved row its representative.
    """
    M, m = th.shape
    th = th.copy()
    ok = np.zeros(M, dtype=bool)
    jsel = np.argmin(dist, axis=1)
    for j in range(m):
        rows = np.flatnonzero(jsel == j)
        if kinds[j] != "R" or rows.size == 0:
            continue
        T, P, Qr, S = tw[rows], p[rows], q[rows], scale[rows]
        w = T[:, j, 3:]
        r = _cross(w, T[:, j, :3])
        t = th[rows]
        for it in range(iters + 1):
            x, J, _ = point_chain_rows(kinds, T, t, P)
            Jg = np.zeros_like(J)
            if j == m - 1:
                xj = P
            else:
                xj, Jj, _ = point_chain_rows(kinds[j + 1 :], T[:, j + 1 :], t[:, j + 1 :], P)
                Jg[:, :, j + 1 :] = Jj - w[:, :, None] * np.einsum("ki,kij->kj", w, Jj)[:, None, :]
            u = xj - r
            g = u - w * _dot(w, u)[:, None]
            f = x - Qr
            if it == iters:
                break
            A = np.concatenate([J, Jg], axis=1)
            b = np.concatenate([f, g], axis=1)
            AtA = np.swapaxes(A, -1, -2) @ A
            mu = 1e-12 * (np.trace(AtA, axis1=-2, axis2=-1) + 1e-300)
            with np.errstate(all="ignore"):
                step = -np.linalg.solve(
                    AtA + mu[:, None, None] * np.eye(m), np.einsum("kji,kj->ki", A, b)[..., None]
                )[..., 0]
            t = t + np.where(np.isfinite(step), step, 0.0)
        good = (np.linalg.norm(f, axis=-1) <= EXACT_TOL * S) & (
            np.linalg.norm(g, axis=-1) <= FREE_POINT_TOL * S
        )
        th[rows[good]] = t[good]
        ok[rows[good]] = True
    return th, ok


def polish_rows(kinds: str, tw, p, q, th, r, scale, iters: int = 6):
    """Gauss-Newton on rows (M, m) of ``prod exp(xi_i th_i) p - q`` from residuals ``r`` (M,).

    A step is kept only if it lowers the residual; a row stops at the first step that does not (as
    :func:`polish`) or once it is exact to roundoff.  Returns the polished ``th`` and residuals.
    """
    th, r = th.copy(), r.copy()
    m = th.shape[1]
    act = np.flatnonzero(r > 1e-15 * scale)
    for _ in range(iters):
        if act.size == 0:
            break
        T, P, Qa = tw[act], p[act], q[act]
        x, J, _ = point_chain_rows(kinds, T, th[act], P)
        f = x - Qa
        JtJ = np.swapaxes(J, -1, -2) @ J
        mu = 1e-14 * (np.trace(JtJ, axis1=-2, axis2=-1) + 1e-300)
        A = JtJ + mu[:, None, None] * np.eye(m)
        with np.errstate(all="ignore"):
            step = -np.linalg.solve(A, np.einsum("kji,kj->ki", J, f)[..., None])[..., 0]
        step = np.where(np.isfinite(step), step, 0.0)
        th2 = th[act] + step
        x2, _, _ = point_chain_rows(kinds, T, th2, P, jac=False)
        r2 = np.sqrt(_dot(x2 - Qa, x2 - Qa))
        better = r2 < r[act]
        th[act[better]] = th2[better]
        r[act[better]] = r2[better]
        act = act[better]
        act = act[r[act] > 1e-15 * scale[act]]
    return th, r


@np.errstate(all="ignore")  # a huge candidate (a near-vanishing leading coefficient) gives inf: skipped
def rotation_angle_batch(xi, a, b, scale):
    """Vectorised :func:`rotation_angle`: broadcasting over leading axes; returns (theta, free)."""
    w = xi[..., 3:]
    r = np.cross(w, xi[..., :3])
    u = a - r
    u = u - w * np.sum(w * u, axis=-1, keepdims=True)
    v = b - r
    v = v - w * np.sum(w * v, axis=-1, keepdims=True)
    free = np.linalg.norm(u, axis=-1) <= FREE_TOL * scale
    th = np.arctan2(np.sum(w * np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))
    return np.where(free, 0.0, th), free


def circle_of_batch(xi, a):
    w = xi[..., 3:]
    r = np.cross(w, xi[..., :3])
    u = a - r
    par = w * np.sum(w * u, axis=-1, keepdims=True)
    perp = u - par
    return r + par, perp, np.cross(w, perp)


@np.errstate(all="ignore")
def trig_roots_batch(F):
    """Vectorised :func:`trig_roots` for ``F`` (N, 5) = (f0, c1, s1, c2, s2): angles (N, 4).

    Instances whose second harmonic vanishes give their two roots twice; identically zero or constant
    ones give zeros (callers always add their own representative candidates).
    """
    f0, c1, s1, c2, s2 = (F[:, i] for i in range(5))
    a4, a3, a2, a1, a0 = (
        (c2 - 1j * s2) / 2,
        (c1 - 1j * s1) / 2,
        f0 + 0j,
        (c1 + 1j * s1) / 2,
        (c2 + 1j * s2) / 2,
    )
    m = np.maximum.reduce([np.abs(a4), np.abs(a3), np.abs(a2)])
    quartic = np.abs(a4) > COEF_TOL * m
    lead = np.where(quartic, a4, 1.0)
    N = F.shape[0]
    z4 = np.ones((N, 4), dtype=complex)
    idx = np.flatnonzero(quartic)  # companion eigenvalues only where the second harmonic is there
    if idx.size:
        comp = np.zeros((idx.size, 4, 4), dtype=complex)
        comp[:, 0, :] = -np.stack([a3[idx], a2[idx], a1[idx], a0[idx]], axis=-1) / lead[idx, None]
        comp[:, 1, 0] = comp[:, 2, 1] = comp[:, 3, 2] = 1.0
        comp = np.where(np.isfinite(comp), comp, 0.0)
        z4[idx] = np.linalg.eigvals(comp)
    quad = np.abs(a3) > COEF_TOL * m
    aa = np.where(quad, a3, 1.0)
    sq = np.sqrt(a2 * a2 - 4 * aa * a1)
    z2 = np.stack([(-a2 + sq) / (2 * aa), (-a2 - sq) / (2 * aa)], axis=-1)
    z2 = np.where(quad[:, None], z2, 1.0)
    z = np.where(quartic[:, None], z4, np.concatenate([z2, z2], axis=-1))
    return np.angle(z)


@np.errstate(all="ignore")
def trig_roots_nan_batch(F, ref):
    """:func:`trig_roots` for ``F`` (N, 5), as the scalar one decides: roots (N, 4), NaN-padded, and
    the mask of identically vanishing instances (``None`` of the scalar function; no roots then)."""
    f0 = F[:, 0]
    h1, h2 = np.hypot(F[:, 1], F[:, 2]) / 2, np.hypot(F[:, 3], F[:, 4]) / 2
    m = np.maximum.reduce([np.abs(f0), h1, h2])
    none = (m <= COEF_TOL * ref) | (m == 0.0)
    lin = h2 <= COEF_TOL * m
    const = lin & (h1 <= COEF_TOL * m)
    roots = trig_roots_batch(F)
    roots = np.where(lin[:, None], np.concatenate([roots[:, :2], np.full((len(f0), 2), np.nan)], 1), roots)
    return np.where((none | const)[:, None], np.nan, roots), none


def lin_roots_nan_batch(f0, c1, s1, ref):
    """Roots (..., 2) of ``f0 + c1 cos + s1 sin`` (NaN: none) and the identically-zero mask (...)."""
    shape = np.shape(f0)
    z = np.zeros(int(np.prod(shape)))
    F = np.stack([np.ravel(f0), np.ravel(c1), np.ravel(s1), z, z], -1)
    roots, none = trig_roots_nan_batch(F, np.broadcast_to(ref, shape).ravel())
    return roots[:, :2].reshape(shape + (2,)), none.reshape(shape)


@np.errstate(all="ignore")
def quadratic_roots_batch(a, b, c):
    """Two candidate real roots of ``a t^2 + b t + c`` per instance (vertex twice when complex;
    the linear root twice when ``a`` vanishes; zeros when both vanish)."""
    m = np.maximum.reduce([np.abs(a), np.abs(b), np.abs(c)])
    lin = np.abs(a) <= COEF_TOL * m
    aa = np.where(lin, 1.0, a)
    disc = b * b - 4 * aa * c
    sq = np.sqrt(np.maximum(disc, 0.0))
    sgn = np.where(b >= 0, 1.0, -1.0)
    t1 = (-b - sgn * sq) / (2 * aa)
    t2 = np.where(t1 != 0, c / (aa * np.where(t1 != 0, t1, 1.0)), -b / aa)
    bb = np.where(np.abs(b) > COEF_TOL * m, b, 1.0)
    tl = np.where(np.abs(b) > COEF_TOL * m, -c / bb, 0.0)
    r1 = np.where(lin, tl, t1)
    r2 = np.where(lin, tl, t2)
    return np.stack([r1, r2], axis=-1)


@np.errstate(all="ignore")
def finalize_batch(code: str, tw, p, q, cand, cand_free=None, inst_cont=None) -> BatchResult:
    """Vectorised :func:`finalize`: candidates (N, C, m) -> a BatchResult with ``max_solutions`` slots.

    Non-finite candidates are skipped (callers mark unused slots with NaN).  Candidates are flattened
    to rows; only rows that fail the polish check (``POLISH_TOL``) are polished, the far ones
    (``FAR_TOL``) only in instances without any exact row, exactly as the scalar path.
    """
    from subproblems.core import max_solutions

    kinds = kinds_of(code)
    K = max_solutions(code)
    N, C, m = cand.shape
    cand_free = np.zeros((N, C), dtype=bool) if cand_free is None else np.broadcast_to(cand_free, (N, C))
    inst_cont = np.zeros(N, dtype=bool) if inst_cont is None else np.asarray(inst_cont, dtype=bool)
    rev = np.array([k == "R" for k in kinds])
    scale = problem_scale_batch(tw, p, q)
    tw = np.ascontiguousarray(tw)

    # --- rows: every finite candidate ----------------------------------------------------------
    ok = np.all(np.isfinite(cand), axis=-1)
    ni, ci = np.nonzero(ok)
    TW, P, Qr, S = tw[ni], p[ni], q[ni], scale[ni]
    th = np.where(rev, wrap_array(cand[ni, ci]), cand[ni, ci])
    x, _, dist = point_chain_rows(kinds, TW, th, P, jac=False)
    r = np.linalg.norm(x - Qr, axis=-1)

    def polish_sel(sel):
        if sel.size == 0:
            return
        t2, _ = polish_rows(kinds, TW[sel], P[sel], Qr[sel], th[sel], r[sel], S[sel])
        t2 = np.where(rev, wrap_array(t2), t2)
        x2, _, d2 = point_chain_rows(kinds, TW[sel], t2, P[sel], jac=False)
        th[sel], dist[sel] = t2, d2
        r[sel] = np.linalg.norm(x2 - Qr[sel], axis=-1)

    polish_sel(np.flatnonzero((r > POLISH_TOL * S) & (r <= FAR_TOL * S)))
    has_exact = np.zeros(N, dtype=bool)
    has_exact[ni[r <= EXACT_TOL * S]] = True
    polish_sel(np.flatnonzero((r > FAR_TOL * S) & ~has_exact[ni]))
    # exact rows next to a free joint: add the row with the joint's point on its axis (a continuum)
    dmin = dist.min(axis=1)
    sel = np.flatnonzero((r <= EXACT_TOL * S) & (dmin > FREE_POINT_TOL * S) & (dmin <= NEAR_FREE_TOL * S))
    if sel.size:
        t2, good = snap_free_rows(kinds, TW[sel], P[sel], Qr[sel], th[sel], dist[sel], S[sel])
        sel, t2 = sel[good], np.where(rev, wrap_array(t2[good]), t2[good])
    if sel.size:
        x2, _, d2 = point_chain_rows(kinds, TW[sel], t2, P[sel], jac=False)
        ni, ci = np.concatenate([ni, ni[sel]]), np.concatenate([ci, ci[sel] + C])
        TW, P, Qr, S = (np.concatenate([a, a[sel]]) for a in (TW, P, Qr, S))
        th, dist = np.concatenate([th, t2]), np.concatenate([dist, d2])
        r = np.concatenate([r, np.linalg.norm(x2 - Qr[-len(sel) :], axis=-1)])
        cand_free = np.concatenate([cand_free, np.zeros((N, C), dtype=bool)], axis=1)
        cand_free[ni[-len(sel) :], ci[-len(sel) :]] = True
        C = 2 * C
    free_row = np.any(dist <= FREE_POINT_TOL * S[:, None], axis=-1)

    Cand = np.zeros((N, C, m))
    Cand[ni, ci] = th
    res = np.full((N, C), np.inf)
    res[ni, ci] = r + ROUNDOFF * np.abs(np.where(rev, 0.0, th)).sum(axis=-1)
    exact_row = res[ni, ci] <= EXACT_TOL * S
    probe = np.flatnonzero(exact_row & ~free_row & ~cand_free[ni, ci])
    if probe.size:
        on = on_continuum_rows(kinds, TW[probe], P[probe], Qr[probe], th[probe], S[probe])
        free_row[probe[on]] = True
    cfree = cand_free.copy()
    cfree[ni, ci] |= free_row
    exact = res <= EXACT_TOL * scale[:, None]

    # --- the best least-squares row of instances without an exact one ------------------------
    best = np.argmin(res, axis=1)
    any_exact = exact.any(axis=1)
    ar = np.arange(N)
    q_best, free_best = Cand[ar, best], cfree[ar, best]

    near_miss = None
    if near_rows_active():  # near-miss least-squares rows, for near_miss_rows (appended below)
        near_miss = (Cand.copy(), res.copy(), any_exact & ((res > EXACT_TOL * scale[:, None])
                                                           & (res <= FAR_TOL * scale[:, None])).any(axis=1))

    # --- exact rows first (lowest residual first), then deduplicate the few columns that hold them
    order = np.argsort(np.where(exact, res, np.inf), axis=1, kind="stable")
    Ce = max(1, int(exact.sum(axis=1).max()))
    order = order[:, :Ce]
    Cand = np.take_along_axis(Cand, order[..., None], axis=1)
    keep = np.take_along_axis(exact, order, axis=1)
    cfree = np.take_along_axis(cfree, order, axis=1)
    res_kept = np.take_along_axis(res, order, axis=1)  # each kept row's own residual (merge_tangent)

    def jdist(a, b):
        d = np.abs(a - b)
        d = np.where(rev, np.abs(np.remainder(d + math.pi, TWO_PI) - math.pi), d / np.maximum(1.0, np.abs(b)))
        return d.max(axis=-1)

    def offset(a, b):
        return np.where(rev, np.remainder(b - a + math.pi, TWO_PI) - math.pi, b - a)

    def polished(n, th_):
        th_ = np.where(rev, wrap_array(th_), th_)
        xm, _, _ = point_chain_rows(kinds, tw[n], th_, p[n], jac=False)
        t2, r2 = polish_rows(kinds, tw[n], p[n], q[n], th_, np.linalg.norm(xm - q[n], axis=-1), scale[n])
        return np.where(rev, wrap_array(t2), t2), r2

    # clusters of tangent rows (see the scalar path): anchor, sum of offsets, members
    anchor, dsum, cnt = Cand.copy(), np.zeros_like(Cand), np.ones((N, Ce))
    for j in range(1, Ce):
        for i in range(j):
            both = keep[:, i] & keep[:, j]
            if not both.any():
                continue
            d = jdist(Cand[:, i], Cand[:, j])
            dup = both & (d <= DEDUP_TOL)
            split = np.flatnonzero(dup & (d > SAME_TOL))  # a double root split by roundoff, maybe
            keep[:, j] &= ~dup
            near = np.flatnonzero(both & keep[:, j] & (d <= TANGENT_TOL))
            hit = split
            if near.size:
                a, b = Cand[near, i], Cand[near, j]
                mid = a + offset(a, b) / 2
                pm, rm = polished(near, mid)
                moved = jdist(pm, np.where(rev, wrap_array(mid), mid))
                own = np.maximum(np.maximum(res_kept[near, i], res_kept[near, j]), ROUNDOFF * scale[near])
                bound = np.minimum(MERGE_TOL * scale[near], MERGE_SPREAD * own)
                hit = np.concatenate([split, near[(rm <= bound) & (moved <= 0.05 * d[near])]])
            if hit.size == 0:
                continue
            fi, fj = cfree[hit, i], cfree[hit, j]
            dsum[hit, i] += offset(anchor[hit, i], Cand[hit, j])
            cnt[hit, i] += 1
            cen, rc = polished(hit, anchor[hit, i] + dsum[hit, i] / cnt[hit, i, None])
            cen_ok = rc <= EXACT_TOL * scale[hit]
            rep = np.where(fj[:, None], Cand[hit, j], np.where(cen_ok[:, None], cen, Cand[hit, i]))
            Cand[hit, i] = np.where(fi[:, None], Cand[hit, i], rep)
            cfree[hit, i] = fi | fj
            keep[hit, j] = False

    Kc = min(K, Ce)
    slot = np.argsort(~keep, axis=1, kind="stable")[:, :Kc]
    Q = np.zeros((N, K, m))
    valid = np.zeros((N, K), dtype=bool)
    free = np.zeros((N, K), dtype=bool)
    Q[:, :Kc] = np.take_along_axis(Cand, slot[..., None], axis=1)
    valid[:, :Kc] = np.take_along_axis(keep, slot, axis=1)
    free[:, :Kc] = np.take_along_axis(cfree, slot, axis=1)
    Q[:, 0] = np.where(any_exact[:, None], Q[:, 0], q_best)
    free[:, 0] = np.where(any_exact, free[:, 0], free_best)
    valid[:, 0] |= ~any_exact
    ls = np.zeros((N, K), dtype=bool)
    ls[:, 0] = ~any_exact
    free &= valid
    cont = inst_cont | free.any(axis=1)
    Q = np.where(valid[..., None], Q, 0.0)
    if near_miss is not None:
        _add_near_rows(kinds, Q, valid, ls, near_miss, scale)
    return BatchResult(code, Q, valid, ls, cont)


def _add_near_rows(kinds: str, Q, valid, ls, near, scale) -> None:
    """:func:`_near_rows` for the batch path: in place, into the free slots of the instances that have
    exact rows and near-miss candidates (``near``: candidates, residuals and that mask)."""
    Cand, res, has = near
    for n in np.flatnonzero(has):
        kept = [Q[n, k] for k in np.flatnonzero(valid[n])]
        scored = [(res[n, c], Cand[n, c], False) for c in np.flatnonzero(np.isfinite(res[n]))]
        for s in _near_rows(kinds, kept, scored, scale[n], int((~valid[n]).sum())):
            k = int(np.argmin(valid[n]))
            Q[n, k], valid[n, k], ls[n, k] = s.q, True, True


def inverted_batch(tw) -> np.ndarray:
    return -np.asarray(tw, dtype=float)[:, ::-1]


def revert_batch(r: BatchResult, code: str) -> BatchResult:
    return BatchResult(code, r.q[..., ::-1].copy(), r.valid, r.ls, r.continuum, r.vectorised)


# ----------------------------------------------------------------------------------------------------
# one answer from both paths: least squares and the instances the batch path leaves to the scalar one
# ----------------------------------------------------------------------------------------------------

#: Least-squares refinement: Newton steps on the squared residual (gradient ``J^T f``, Hessian by central
#: differences of the gradient) until a step is below LS_STEP_TOL; ties within LS_TIE_TOL.
LS_STEP_TOL = tol.S2_LS_STEP
LS_TIE_TOL = tol.S2_LS_TIE


def _ls_gradient(twists, p, q, th):
    x, J = chain_point_jac(twists, th, p)
    return J.T @ (x - q), float(np.linalg.norm(x - q))


def refine_ls(kinds: str, twists, p, q, th, scale: float, iters: int = 40) -> np.ndarray:
    """A least-squares row moved to the minimiser of the residual it lies near.

    Gauss-Newton (``polish``) converges only linearly when the residual does not vanish and stops
    ~1e-5 short in flat valleys, so two paths starting from different points return different rows.
    Newton on ``|f|^2 / 2`` with the Hessian's eigenvalues taken in absolute value (a descent step
    even off the convex region) converges quadratically to the local minimiser.
    """
    th = wrap_row(kinds, th)
    h = np.array([1e-6 if k == "R" else 1e-6 * scale for k in kinds])
    g, r = _ls_gradient(twists, p, q, th)
    for _ in range(iters):
        H = np.column_stack(
            [
                (_ls_gradient(twists, p, q, th + h[j] * e)[0] - _ls_gradient(twists, p, q, th - h[j] * e)[0])
                / (2 * h[j])
                for j, e in enumerate(np.eye(len(kinds)))
            ]
        )
        lam, V = np.linalg.eigh((H + H.T) / 2)
        # a flat direction (a valley of minimisers) gets no step from the gradient's roundoff
        lam = np.maximum(np.abs(lam), 1e-9 * max(float(np.abs(lam).max()), 1e-300))
        step = -V @ ((V.T @ g) / lam)
        for _ in range(10):  # halve until the residual does not grow beyond roundoff
            th2 = wrap_row(kinds, th + step)
            g2, r2 = _ls_gradient(twists, p, q, th2)
            if r2 <= r * (1 + 1e-14) + 1e-16 * scale:
                break
            step = step / 2
        else:
            break
        moved = joint_distance(kinds, th2, th)
        stalled = moved <= 1e-8 and np.linalg.norm(g2) > 0.5 * np.linalg.norm(g)  # the gradient's noise
        th, g, r = th2, g2, r2
        if moved <= LS_STEP_TOL or stalled:
            break
    return th


def _best_ls(kinds: str, twists, p, q, rows, scale: float):
    """The lowest-residual row among ``rows`` (each refined), ties broken lexicographically."""
    refined = [refine_ls(kinds, twists, p, q, th, scale) for th in rows]
    res = [residual(twists, p, q, th) + roundoff(kinds, th) for th in refined]
    low = min(res)
    ties = [i for i, r in enumerate(res) if r <= low + LS_TIE_TOL * scale]
    i = min(ties, key=lambda k: tuple(np.round(refined[k], 9)))
    return refined[i], res[i]


# Whether the class II solvers skip their agreement step in the current context (thread, task): a
# context variable, not a module global, so one thread's reference runtime never switches off another
# thread's agreement (docs/design.md section 10).
_INDEPENDENT: ContextVar[bool] = ContextVar("subproblems_class2_independent_paths", default=False)


def agreement_active() -> bool:
    """True unless the caller is inside :func:`independent_paths` (in this thread or task)."""
    return not _INDEPENDENT.get()


# Whether the class II solvers also return their near-miss least-squares rows beside exact ones, in the
# current context: a snapped plan's steps (docs/calibrated.md, "Rescue seeds").
_NEAR_ROWS: ContextVar[bool] = ContextVar("subproblems_class2_near_rows", default=False)


def near_rows_active() -> bool:
    """True inside :func:`near_miss_rows` (in this thread or task)."""
    return _NEAR_ROWS.get()


@contextmanager
def near_miss_rows():
    """Within this block an instance with exact rows also returns its polished candidates that miss by
    at most ``FAR_TOL`` of its size, flagged least-squares, in the slots the exact rows leave free.

    Without it such candidates are dropped once a row is exact.  A snapped plan needs them: a pair of
    complex roots of the snapped robot's eliminant, near a fold, is a pair of real solutions of the
    true robot; the continuation seeds Newton from least-squares leaves that nearly reach the target
    and finds them (talos_full_v2.urdf perturbed by 1e-3: S2-RRR with 2 exact rows and a complex pair
    at residual 5.2e-5, the true robot 8 solutions, 4 returned; docs/calibrated.md)."""
    token = _NEAR_ROWS.set(True)
    try:
        yield
    finally:
        _NEAR_ROWS.reset(token)


@contextmanager
def independent_paths():
    """Within this block the class II solvers skip their agreement step (:func:`agreeing`,
    :func:`defer_to_scalar`): each path returns its own rows.  For callers that want the exact rows and
    a least-squares point but not the same point from both paths, at a fraction of the cost: the
    compiler's reference runtime, whose search grids hand mostly unreachable instances to the batch
    solver (measured: a 1-D search arm's verify 20 s with the agreement step, 0.7 s without).  The
    setting belongs to the current thread (or asyncio task) only; the scalar path's own call of the
    batch solver uses it too, so that it does not defer back to itself."""
    token = _INDEPENDENT.set(True)
    try:
        yield
    finally:
        _INDEPENDENT.reset(token)


#: An exact row is uncertain (its residual, or its scaled Jacobian's smallest singular value: the two
#: paths' constructions then return different rows, so both paths answer with the union of both).
UNCERTAIN_RES_TOL = tol.S2_UNCERTAIN_RESIDUAL
UNCERTAIN_SING_TOL = tol.S2_UNCERTAIN_SINGULAR


def uncertain_rows(kinds: str, tw, p, q, th, scale) -> np.ndarray:
    """Mask (M,) of exact rows ``th`` (M, m) whose location the constructions do not pin down."""
    x, J, _ = point_chain_rows(kinds, tw, th, p)
    res = np.linalg.norm(x - q, axis=-1)
    n = np.linalg.norm(J, axis=1)
    Jn = J / np.where(n > 0.0, n, 1.0)[:, None, :]
    smin = np.linalg.svd(Jn, compute_uv=False)[:, -1]
    return (res > UNCERTAIN_RES_TOL * scale) | (smin < UNCERTAIN_SING_TOL) | (n.min(axis=1) == 0.0)


def uncertain_instance(kinds: str, tw, p, q, rows, scale: float) -> bool:
    """True when the exact ``rows`` (k, m) of one instance need the other path's rows too: an
    uncertain row, or two rows within TANGENT_TOL (a root split in two, or two roots run together)."""
    rows = np.asarray(rows, dtype=float).reshape(-1, len(kinds))
    k = len(rows)
    if k == 0:
        return False
    for i in range(k):
        for j in range(i + 1, k):
            if joint_distance(kinds, rows[i], rows[j]) <= TANGENT_TOL:
                return True
    T = np.broadcast_to(tw, (k,) + np.shape(tw))
    P, Qr = np.broadcast_to(p, (k, 3)), np.broadcast_to(q, (k, 3))
    return bool(uncertain_rows(kinds, T, P, Qr, rows, np.full(k, scale)).any())


def agreeing(code: str, batch_raw):
    """Decorator of a class II scalar solver: one answer for both paths where they can differ.

    When the scalar construction leaves no exact row, the instance is a continuum, or an exact row is
    uncertain (:func:`uncertain_instance`), the batch solver's answer for the same instance is taken
    too: the exact rows of both go through :func:`finalize` together (deduplicated, merged, probed);
    without any, both least-squares rows are refined (:func:`refine_ls`) and the better one is
    returned.  The batch path hands the same kinds of instances to this function
    (:func:`defer_to_scalar`), so both paths return the same rows.
    """

    def deco(scalar):
        def solve_one(twists, p, q):
            sols = scalar(twists, p, q)
            if not agreement_active() or any(s.continuum and not s.ls for s in sols):
                return sols  # a continuum's representatives: the batch path defers it here
            kinds = kinds_of(code)
            exact = [s.q for s in sols if not s.ls]
            if exact:
                tw, pp, qq = (np.asarray(a, dtype=float) for a in (twists, p, q))
                if not uncertain_instance(kinds, tw, pp, qq, exact, problem_scale(tw, pp, qq)):
                    return sols
            return _union(code, twists, p, q, sols, batch_raw)

        solve_one.__doc__, solve_one.__name__ = scalar.__doc__, scalar.__name__
        return solve_one

    return deco


def _union(code: str, twists, p, q, sols, batch_raw) -> list[Solution]:
    kinds = kinds_of(code)
    twists = np.asarray(twists, dtype=float)
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    with independent_paths():  # the batch solver's own answer, not deferred back here
        b = batch_raw(twists[None], p[None], q[None])
    v = b.valid[0] & np.all(np.isfinite(b.q[0]), axis=-1)
    cont = any(s.continuum for s in sols) or bool(b.continuum[0])
    exact = [np.array(s.q, dtype=float) for s in sols if not s.ls] + list(b.q[0][v & ~b.ls[0]])
    if exact:
        return finalize(code, twists, p, q, [(row, False) for row in exact], continuum=cont)
    scale = problem_scale(twists, p, q)
    rows = [np.array(s.q, dtype=float) for s in sols] + list(b.q[0][v])
    th, res = _best_ls(kinds, twists, p, q, rows, scale)
    cont = any(s.continuum for s in sols) or has_free_joint(twists, p, th, scale)
    return [Solution(tuple(float(a) for a in th), ls=res > EXACT_TOL * scale, continuum=cont)]


def defer_to_scalar(code: str, r: BatchResult, tw, p, q) -> BatchResult:
    """The batch result with the instances the scalar path answers from both paths (least squares,
    continuum, uncertain rows: see :func:`agreeing`) solved by it (a loop over those only)."""
    from subproblems.core import solve

    if not agreement_active():
        return r
    idx = np.flatnonzero(_to_defer(kinds_of(code), r, tw, p, q))
    if idx.size == 0:
        return r
    Q, valid, ls, cont = r.q.copy(), r.valid.copy(), r.ls.copy(), r.continuum.copy()
    for i in idx:
        s = solve(code, np.array(tw[i]), p=np.array(p[i]), q=np.array(q[i]))
        k = min(len(s.q), Q.shape[1])
        Q[i], valid[i], ls[i] = 0.0, False, False
        Q[i, :k], valid[i, :k], ls[i, :k], cont[i] = s.q[:k], True, s.ls[:k], s.continuum
    return BatchResult(code, Q, valid, ls, cont, r.vectorised)


def _to_defer(kinds: str, r: BatchResult, tw, p, q) -> np.ndarray:
    """(N,) instances answered least-squares, flagged continuum, or with an uncertain exact row or two
    exact rows within TANGENT_TOL."""
    out = r.ls.any(axis=1) | r.continuum
    ex = r.valid & ~r.ls & ~out[:, None]
    ni, ki = np.nonzero(ex)
    if ni.size:
        scale = problem_scale_batch(tw, p, q)
        unc = uncertain_rows(kinds, tw[ni], p[ni], q[ni], r.q[ni, ki], scale[ni])
        out[ni[unc]] = True
    K = r.q.shape[1]
    rev = np.array([k == "R" for k in kinds])
    for i in range(K):
        for j in range(i + 1, K):
            d = np.abs(r.q[:, i] - r.q[:, j])
            d = np.where(
                rev,
                np.abs(np.remainder(d + math.pi, TWO_PI) - math.pi),
                d / np.maximum(1.0, np.abs(r.q[:, j])),
            )
            out |= ex[:, i] & ex[:, j] & (d.max(axis=-1) <= TANGENT_TOL)
    return out
