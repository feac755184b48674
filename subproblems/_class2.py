"""Shared machinery of the class II solvers (``prod exp(xi_i th_i) p = q``): private.

Every class II solver works the same way, in two stages:

1. **Candidates.**  A geometric construction (scalar path) or an algebraic elimination (vectorised
   path) proposes joint vectors.  Candidates may be approximate (roots of an eliminant found by
   eigenvalues, intersections with a clamped discriminant, roots projected onto the unit circle when
   no real root exists): they only have to include every true solution.
2. **Verification.**  :func:`finalize` polishes each candidate with a few Gauss-Newton steps on the
   *original* equation, measures its residual ``|| prod exp(xi_i th_i) p - q ||``, keeps the exact ones
   (residual <= ``EXACT_TOL`` times the problem scale), removes duplicates (angles modulo 2 pi) and,
   when none is exact, returns the best least-squares candidate flagged ``ls``.

So a wrong solution can never be returned as exact, and the least-squares answer of an unreachable
instance is a local minimiser of the residual.  :func:`finalize_batch` does the same for N instances
at once with fixed candidate slots (no Python loop over instances).

Also here: the Paden-Kahan rotation angle (``rotation_angle``, the heart of S2-R, used by every solver
that ends with "rotate this point onto that one"), roots of trigonometric polynomials of degree <= 2
(``trig_roots``), and the inversion that maps ``RT``-type codes onto ``TR``-type ones.
"""

from __future__ import annotations

import math

import numpy as np

from subproblems.core import BatchResult, Solution
from subproblems.screw import twist_exp, twist_exp_batch

#: A solution is exact when its residual is at most this times the problem scale.
EXACT_TOL = 1e-9
#: Two exact solutions closer than this (angles modulo 2 pi; prismatic values relative) are one.
DEDUP_TOL = 1e-6
#: A point closer than this (relative) to a revolute axis does not determine the joint angle.
FREE_TOL = 1e-10
#: After polishing, a solution whose point on a revolute joint is this close (relative) to the joint's
#: axis leaves that angle undetermined at the EXACT_TOL level (near a double root the polished point
#: may stay ~sqrt(eps) off the axis): the instance is flagged continuum.
FREE_POINT_TOL = 10 * EXACT_TOL
#: Relative size under which an eliminant coefficient counts as zero.
COEF_TOL = 1e-12

TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------------------------------
# scalar helpers
# ----------------------------------------------------------------------------------------------------


def kinds_of(code: str) -> str:
    return code.split("-", 1)[1]


def problem_scale(twists, p, q) -> float:
    """Length scale of one instance: max(1, |p|, |q|, distance of each revolute axis from the origin)."""
    s = max(1.0, float(np.linalg.norm(p)), float(np.linalg.norm(q)))
    for xi in np.asarray(twists, dtype=float):
        if xi[3:].any():
            s = max(s, float(np.linalg.norm(np.cross(xi[3:], xi[:3]))))
    return s


def wrap(a: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    a = math.remainder(float(a), TWO_PI)
    return math.pi if a <= -math.pi else a


def wrap_row(kinds: str, th) -> np.ndarray:
    return np.array([wrap(a) if k == "R" else float(a) for k, a in zip(kinds, th)])


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
        vp = R @ xi[:3] + np.cross(t, wp)
        cols.append((vp, wp))
        g = twist_exp(xi, a)
        t = R @ g[:3, 3] + t
        R = R @ g[:3, :3]
    x = R @ p + t
    J = np.column_stack([vp + np.cross(wp, x) for vp, wp in cols])
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
            u = x - np.cross(xi[3:], xi[:3])
            if np.linalg.norm(u - xi[3:] * (xi[3:] @ u)) <= FREE_POINT_TOL * scale:
                return True
        g = twist_exp(xi, a)
        x = g[:3, :3] @ x + g[:3, 3]
    return False


def residual(twists, p, q, th) -> float:
    return float(np.linalg.norm(chain_point_jac(twists, th, p)[0] - q))


def finalize(code: str, twists, p, q, candidates, continuum: bool = False) -> list[Solution]:
    """Polish, verify, deduplicate ``candidates`` (iterable of ``(th, free)``); see the module doc.

    ``free`` marks a candidate built with a free joint set to its representative value; ``continuum``
    marks the whole instance.  Without any exact candidate the best least-squares one is returned.
    """
    kinds = kinds_of(code)
    twists = np.asarray(twists, dtype=float)
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    scale = problem_scale(twists, p, q)
    scored = []
    for th, free in candidates:
        th = np.asarray(th, dtype=float)
        if th.shape != (len(kinds),) or not np.all(np.isfinite(th)):
            continue
        th = wrap_row(kinds, polish(twists, p, q, th, scale))
        free = bool(free) or has_free_joint(twists, p, th, scale)
        scored.append((residual(twists, p, q, th), th, free))
    if not scored:  # nothing usable: the zero vector as a flagged least-squares answer
        th = np.zeros(len(kinds))
        return [Solution(tuple(th), ls=True, continuum=continuum)]
    exact = [s for s in scored if s[0] <= EXACT_TOL * scale]
    if not exact:
        r, th, free = min(scored, key=lambda s: s[0])
        return [Solution(tuple(float(a) for a in th), ls=True, continuum=continuum or free)]
    exact.sort(key=lambda s: s[0])
    kept: list[tuple[float, np.ndarray, bool]] = []
    for s in exact:
        if all(joint_distance(kinds, s[1], k[1]) > DEDUP_TOL for k in kept):
            kept.append(s)
    # Near a double root two polished copies can both pass the residual test yet differ by more than
    # DEDUP_TOL; never return more rows than the type can have: merge the closest pairs.
    from subproblems.core import max_solutions

    while len(kept) > max_solutions(code):
        i, j = min(
            ((i, j) for i in range(len(kept)) for j in range(i + 1, len(kept))),
            key=lambda ij: joint_distance(kinds, kept[ij[0]][1], kept[ij[1]][1]),
        )
        del kept[j]  # kept is sorted by residual: j has the larger one
    kept.sort(key=lambda s: tuple(s[1]))
    return [Solution(tuple(float(a) for a in th), continuum=continuum or free) for _, th, free in kept]


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
    ap = np.linalg.norm(np.cross(tw[..., 3:], tw[..., :3]), axis=-1)
    s = np.maximum(np.linalg.norm(p, axis=-1), np.linalg.norm(q, axis=-1))
    return np.maximum(1.0, np.maximum(s, ap.max(axis=-1)))


def wrap_batch(a):
    a = np.remainder(a + math.pi, TWO_PI) - math.pi
    return np.where(a <= -math.pi, math.pi, a)


def chain_points_batch(tw, th, p):
    """``x`` (N, C, 3) and Jacobian (N, C, 3, m) for twists (N, m, 6), angles (N, C, m), points (N, 3)."""
    N, C, m = th.shape
    R = np.broadcast_to(np.eye(3), (N, C, 3, 3)).copy()
    t = np.zeros((N, C, 3))
    cols = []
    for i in range(m):
        xi = np.broadcast_to(tw[:, None, i, :], (N, C, 6))
        wp = _mv(R, xi[..., 3:])
        vp = _mv(R, xi[..., :3]) + np.cross(t, wp)
        cols.append((vp, wp))
        g = twist_exp_batch(xi, th[..., i])
        t = _mv(R, g[..., :3, 3]) + t
        R = R @ g[..., :3, :3]
    x = _mv(R, np.broadcast_to(p[:, None, :], (N, C, 3))) + t
    J = np.stack([vp + np.cross(wp, x) for vp, wp in cols], axis=-1)
    return x, J


def polish_batch(tw, p, q, th, scale, iters: int = 6):
    m = th.shape[-1]
    x, J = chain_points_batch(tw, th, p)
    f = x - q[:, None, :]
    r = np.linalg.norm(f, axis=-1)
    for _ in range(iters):
        if not np.any(r > 1e-15 * scale[:, None]):
            break  # every candidate is already exact to roundoff: skip the remaining iterations
        JtJ = np.swapaxes(J, -1, -2) @ J
        mu = 1e-14 * (np.trace(JtJ, axis1=-2, axis2=-1) + 1e-300)
        A = JtJ + mu[..., None, None] * np.eye(m)
        step = -np.linalg.solve(A, np.einsum("...ji,...j->...i", J, f)[..., None])[..., 0]
        step = np.where(np.isfinite(step), step, 0.0)
        th2 = th + step
        x2, J2 = chain_points_batch(tw, th2, p)
        f2 = x2 - q[:, None, :]
        r2 = np.linalg.norm(f2, axis=-1)
        better = (r2 < r) & (r > 1e-15 * scale[:, None])
        th = np.where(better[..., None], th2, th)
        J = np.where(better[..., None, None], J2, J)
        f = np.where(better[..., None], f2, f)
        r = np.where(better, r2, r)
    return th, r


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
    comp = np.zeros((N, 4, 4), dtype=complex)
    comp[:, 0, :] = -np.stack([a3, a2, a1, a0], axis=-1) / lead[:, None]
    comp[:, 1, 0] = comp[:, 2, 1] = comp[:, 3, 2] = 1.0
    comp = np.where(quartic[:, None, None] & np.isfinite(comp), comp, 0.0)
    z4 = np.linalg.eigvals(comp)
    quad = np.abs(a3) > COEF_TOL * m
    aa = np.where(quad, a3, 1.0)
    sq = np.sqrt(a2 * a2 - 4 * aa * a1)
    z2 = np.stack([(-a2 + sq) / (2 * aa), (-a2 - sq) / (2 * aa)], axis=-1)
    z2 = np.where(quad[:, None], z2, 1.0)
    z = np.where(quartic[:, None], z4, np.concatenate([z2, z2], axis=-1))
    return np.angle(z)


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
    """Vectorised :func:`finalize`: candidates (N, C, m) -> a BatchResult with ``max_solutions`` slots."""
    from subproblems.core import max_solutions

    kinds = kinds_of(code)
    K = max_solutions(code)
    N, C, m = cand.shape
    cand_free = np.zeros((N, C), dtype=bool) if cand_free is None else np.broadcast_to(cand_free, (N, C))
    if inst_cont is None:
        inst_cont = np.zeros(N, dtype=bool)
    rev = np.array([k == "R" for k in kinds])
    ok = np.all(np.isfinite(cand), axis=-1)
    cand = np.where(ok[..., None], cand, 0.0)
    scale = problem_scale_batch(tw, p, q)
    cand, _ = polish_batch(tw, p, q, cand, scale)
    cand = np.where(rev, wrap_batch(cand), cand)
    x, _ = chain_points_batch(tw, cand, p)
    res = np.where(ok, np.linalg.norm(x - q[:, None, :], axis=-1), np.inf)
    cand_free = cand_free | _free_joint_batch(tw, p, cand, scale)
    exact = res <= EXACT_TOL * scale[:, None]
    # prefer low residuals when deduplicating
    order = np.argsort(np.where(exact, res, np.inf), axis=1, kind="stable")
    cand = np.take_along_axis(cand, order[..., None], axis=1)
    res = np.take_along_axis(res, order, axis=1)
    exact = np.take_along_axis(exact, order, axis=1)
    cand_free = np.take_along_axis(cand_free, order, axis=1)
    keep = exact.copy()
    for j in range(1, C):
        for i in range(j):
            d = np.abs(cand[:, i] - cand[:, j])
            d = np.where(
                rev,
                np.abs(np.remainder(d + math.pi, TWO_PI) - math.pi),
                d / np.maximum(1.0, np.abs(cand[:, j])),
            )
            keep[:, j] &= ~(keep[:, i] & (d.max(axis=-1) <= DEDUP_TOL))
    any_exact = keep.any(axis=1)
    slot = np.argsort(~keep, axis=1, kind="stable")[:, :K]
    best = np.argmin(res, axis=1)
    slot[:, 0] = np.where(any_exact, slot[:, 0], best)
    Q = np.take_along_axis(cand, slot[..., None], axis=1)
    valid = np.take_along_axis(keep, slot, axis=1)
    valid[:, 0] |= ~any_exact
    ls = np.zeros((N, K), dtype=bool)
    ls[:, 0] = ~any_exact
    free = np.take_along_axis(cand_free, slot, axis=1) & valid
    cont = inst_cont | free.any(axis=1)
    # order valid rows lexicographically like the scalar path (cosmetic; keeps outputs comparable)
    Q = np.where(valid[..., None], Q, 0.0)
    return BatchResult(code, Q, valid, ls, cont)


def _free_joint_batch(tw, p, th, scale):
    """Vectorised :func:`has_free_joint` over candidates (N, C, m)."""
    N, C, m = th.shape
    x = np.broadcast_to(p[:, None, :], (N, C, 3))
    free = np.zeros((N, C), dtype=bool)
    for j in range(m - 1, -1, -1):
        xi = np.broadcast_to(tw[:, None, j, :], (N, C, 6))
        w = xi[..., 3:]
        u = x - np.cross(w, xi[..., :3])
        d = np.linalg.norm(u - w * np.sum(w * u, -1, keepdims=True), axis=-1)
        free |= np.any(w != 0, axis=-1) & (d <= FREE_POINT_TOL * scale[:, None])
        g = twist_exp_batch(xi, th[..., j])
        x = _mv(g[..., :3, :3], x) + g[..., :3, 3]
    return free


def inverted_batch(tw) -> np.ndarray:
    return -np.asarray(tw, dtype=float)[:, ::-1]


def revert_batch(r: BatchResult, code: str) -> BatchResult:
    return BatchResult(code, r.q[..., ::-1].copy(), r.valid, r.ls, r.continuum, r.vectorised)
