"""Shared machinery of the class I solvers (``prod exp(xi_i th_i) = T``, m <= 3): private.

Every class I type is solved the same way (seed 003 section 2; docs/design.md section 3, rule 2):

1. **Orientation.**  Only the revolute joints rotate: ``prod_R exp([w_i] th_i) = R_T`` is an orientation
   subproblem (:func:`subproblems.rotation.rotation_families`).  It gives isolated candidates, or a
   one-parameter family ``th + tau n`` (two revolute axes parallel in space: consecutive parallel axes,
   or axes 1 and 3 lined up at a gimbal lock), or, for three parallel axes, only their signed sum.
2. **Translation.**  With the revolute angles fixed, the translation is affine in the prismatic values:
   ``p(th, d) = a + B d``; ``d`` is its linear least-squares solution (minimum norm when the directions
   are dependent: a continuum, flagged).  On a one-parameter family the translation selects ``tau``:
   the residual ``a(tau) - p_T`` (no prismatic joint) or ``b(tau) x (p_T - a(tau))`` (one prismatic joint
   along ``b``) is a trigonometric polynomial of degree <= 2 in ``tau``, recovered exactly from five
   samples; its roots are the candidates (complex ones projected onto the unit circle: least-squares
   candidates).  If it vanishes identically the family is a true continuum: ``tau = 0``.  Three parallel
   axes (planar 3R) are solved as the planar two-link problem for a point on axis 3.  Axes parallel only
   to within :data:`NEAR_TOL` (or axes 1 and 3 lined up to within ``GIMBAL_TOL``) also get these
   candidates from the nearby degenerate geometry, polished: there the rotation alone determines the
   angles only to ~1e-16 / |w_i x w_j|, the translation still determines them well.
3. **Verification.**  Every candidate is measured against the whole equation (6 equations, <= 3
   unknowns: the rest of the equations is checked, not assumed); near-exact ones get a few Gauss-Newton
   steps; exact ones (residual <= ``EXACT_TOL`` times the problem scale) are kept and deduplicated; if
   none is exact the best candidate alone is returned, flagged ``ls``.  A continuum representative that
   is exact is kept first: a family that holds to the tolerance (e.g. axes coincident to 1e-11) is
   flagged ``continuum`` even when the translation's tiny variation along it has isolated roots.

Continuum representatives: the first joint of a parallel revolute pair is 0 (``t1 = 0`` at a gimbal
lock), the minimum-norm prismatic values for dependent directions.
"""

from __future__ import annotations

import math

import numpy as np

from subproblems import tolerances
from subproblems.angles import wrap_array, wrap_joints
from subproblems.core import BatchResult, Solution
from subproblems.rotation import (
    GIMBAL_TOL,
    PAR_TOL,
    _angle_about,
    _angle_r,
    rotation_families,
    rotation_families_batch,
)
from subproblems.screw import adjoint, fk, fk_batch, inverse_transform, twist_exp, twist_exp_batch

# Tolerances: subproblems/tolerances.py (each with its reason there; docs/design.md section 10).
EXACT_TOL = tolerances.EXACT
POLISH_TOL = tolerances.S1_POLISH
DEDUP_TOL = tolerances.S1_SAME_SOLUTION
RANK_TOL = tolerances.S1_DEPENDENT_SLIDES
NEAR_TOL = tolerances.S1_NEAR_PARALLEL
NEAR_POLISH_TOL = tolerances.S1_NEAR_POLISH
MERGE_SPAN = tolerances.S1_DOUBLE_ROOT_SPAN
DOUBLE_ROOT_ULPS = tolerances.S1_DOUBLE_ROOT_ULPS

TWO_PI = 2.0 * math.pi
_TAU5 = TWO_PI * np.arange(5) / 5.0


def kinds_of(code: str) -> str:
    return code.split("-", 1)[1]


def problem_scale(twists, T) -> float:
    """max(1, |p_T|, distance of each revolute axis from the origin)."""
    s = max(1.0, float(np.linalg.norm(T[:3, 3])))
    for xi in twists:
        if xi[3:].any():
            s = max(s, float(np.linalg.norm(np.cross(xi[3:], xi[:3]))))
    return s


def residual(twists, q, T) -> float:
    """Same measure as :func:`subproblems.core.equation_residual` for class I."""
    g = fk(twists, q)
    sT = max(1.0, float(np.linalg.norm(T[:3, 3])))
    return float(max(np.linalg.norm(g[:3, 3] - T[:3, 3]), sT * np.abs(g[:3, :3] - T[:3, :3]).max()))


def joint_distance(kinds, a, b) -> float:
    err = 0.0
    for k, x, y in zip(kinds, a, b):
        err = max(err, abs(math.remainder(x - y, TWO_PI)) if k == "R" else abs(x - y) / max(1.0, abs(y)))
    return err


# ----------------------------------------------------------------------------------------------------
# translation given the revolute angles
# ----------------------------------------------------------------------------------------------------


def affine_translation(twists, kinds, q) -> tuple[np.ndarray, np.ndarray]:
    """``a, B`` with translation ``a + B d`` (prismatic values ``d``) at the revolute angles of ``q``."""
    g = np.eye(4)
    cols = []
    for xi, k, t in zip(twists, kinds, q):
        if k == "T":
            cols.append(g[:3, :3] @ xi[:3])
        else:
            g = g @ twist_exp(xi, t)
    return g[:3, 3], np.array(cols).reshape(-1, 3).T


def prismatic_lstsq(twists, kinds, q, pT) -> tuple[np.ndarray, bool]:
    """Fill the prismatic values of ``q`` by linear least squares; True when the directions are dependent."""
    q = np.array(q, dtype=float)
    ip = [i for i, k in enumerate(kinds) if k == "T"]
    if not ip:
        return q, False
    a, B = affine_translation(twists, kinds, q)
    sv = np.linalg.svd(B, compute_uv=False)
    rhs = pT - a
    d = np.linalg.lstsq(B, rhs, rcond=RANK_TOL)[0]
    dep = bool(sv.min() <= RANK_TOL * max(1.0, sv.max()))
    if dep and sv.min() > 0.0:
        # nearly dependent directions: prefer the full solve when only it satisfies the translation
        tol = EXACT_TOL * max(1.0, float(np.linalg.norm(pT)))
        d_full = np.linalg.lstsq(B, rhs, rcond=1e-15)[0]
        if np.linalg.norm(B @ d - rhs) > tol and np.linalg.norm(B @ d_full - rhs) <= tol:
            d, dep = d_full, False
    q[ip] = d
    return q, dep


# ----------------------------------------------------------------------------------------------------
# roots of trigonometric polynomials of degree <= 2
# ----------------------------------------------------------------------------------------------------


def trig_coefficients(samples) -> np.ndarray:
    """``(f0, c1, s1, c2, s2)`` (rows) of a degree-2 trigonometric polynomial from values at 2 pi k / 5."""
    f = np.asarray(samples, dtype=float)
    c, s = np.cos(_TAU5), np.sin(_TAU5)
    c2, s2 = np.cos(2 * _TAU5), np.sin(2 * _TAU5)
    return np.stack([f.mean(0), 0.4 * c @ f, 0.4 * s @ f, 0.4 * c2 @ f, 0.4 * s2 @ f])


def trig_roots(co, tol: float = 1e-12) -> list[float] | None:
    """Roots of ``f0 + c1 cos t + s1 sin t + c2 cos 2t + s2 sin 2t`` (complex ones projected).

    None when the polynomial vanishes identically, [] when it is a non-zero constant.
    """
    f0, c1, s1, c2, s2 = (float(x) for x in co)
    a = np.array([(c2 - 1j * s2) / 2, (c1 - 1j * s1) / 2, f0, (c1 + 1j * s1) / 2, (c2 + 1j * s2) / 2])
    m = float(np.abs(a).max())
    if m <= 1e-150:  # zero, or subnormal roundoff (np.roots would overflow): vanishes identically
        return None
    a = a / m  # scaled, so the companion matrix stays finite
    if abs(a[0]) <= tol:
        if abs(a[1]) <= tol:
            return None if abs(a[2]) <= tol else []
        a = a[1:4]
    return _merge_double_roots(co, [float(np.angle(z)) for z in np.roots(a) if abs(z) > 0.0])


def _trig_value(co, t: float) -> float:
    f0, c1, s1, c2, s2 = (float(x) for x in co)
    return f0 + c1 * math.cos(t) + s1 * math.sin(t) + c2 * math.cos(2 * t) + s2 * math.sin(2 * t)


def _merge_double_roots(co, roots: list[float]) -> list[float]:
    """Two roots that are one double root split by roundoff become their midpoint.

    Roundoff of size ``e`` in the coefficients splits a double root into two roots ``~sqrt(e)`` apart
    (real or a complex pair, projected): each is only ``sqrt(eps)`` accurate, their midpoint is accurate
    to ``O(eps)``.  A pair is merged when the polynomial vanishes at the midpoint to the roundoff of
    its coefficients (two distinct close roots leave a value ~ half split squared there).
    """
    floor = DOUBLE_ROOT_ULPS * np.finfo(float).eps * float(np.abs(co).sum())
    out: list[float] = []
    for t in roots:
        for i, u in enumerate(out):
            mid = u + 0.5 * math.remainder(t - u, TWO_PI)
            if abs(math.remainder(t - u, TWO_PI)) <= MERGE_SPAN and abs(_trig_value(co, mid)) <= floor:
                out[i] = mid
                break
        else:
            out.append(t)
    return out


# ----------------------------------------------------------------------------------------------------
# candidates
# ----------------------------------------------------------------------------------------------------


def _family_candidates(twists, kinds, q0, nfull, T, scale):
    """Candidates on the orientation family ``q0 + tau nfull`` selected by the translation."""
    pT = T[:3, 3]
    ip = [i for i, k in enumerate(kinds) if k == "T"]

    def f(tau):
        a, B = affine_translation(twists, kinds, q0 + tau * nfull)
        if not ip:
            return a - pT
        return np.cross(B[:, 0], pT - a)

    co = trig_coefficients([f(t) for t in _TAU5])  # (5, 3)
    rep = int(np.argmax(nfull != 0))
    taus: list[float] = []
    big = np.abs(co).max()
    for j in range(3):
        if np.abs(co[:, j]).max() > 1e-9 * big:
            r = trig_roots(co[:, j])
            taus += r or []
    out = []
    if big <= EXACT_TOL * scale:
        # a continuum to the tolerance: the representative; when the translation still varies a
        # little along the family (axes nearly coincident, ~1e-9 apart), its roots are candidates
        # too, and where the representative itself misses by more than the tolerance they win
        q, _ = prismatic_lstsq(twists, kinds, q0, pT)
        out.append((q, True, (rep,)))
        if big <= 1e-15 * scale:
            return out
    elif not taus:
        taus = [0.0]
    for tau in taus:
        q, _ = prismatic_lstsq(twists, kinds, q0 + tau * nfull, pT)
        out.append((q, False, ()))
    return out


def _planar_candidates(twists, T, scale):
    """S1-RRR with three parallel axes: planar two-link problem for a point on axis 3, then the sum."""
    w = twists[0, 3:]
    s2 = 1.0 if w @ twists[1, 3:] > 0 else -1.0
    s3 = 1.0 if w @ twists[2, 3:] > 0 else -1.0
    phi, _ = _angle_r(w, T[:3, :3])
    r1, r2, r3 = (np.cross(xi[3:], xi[:3]) for xi in twists)  # axis points, all perpendicular to w
    q = T[:3, :3] @ r3 + T[:3, 3]
    q = q - w * float(w @ q)
    tol = 1e-9 * scale
    rho2, D = np.linalg.norm(r3 - r2), np.linalg.norm(r2 - r1)
    out = []

    def add(t1, t2, fixed):
        out.append((np.array([t1, t2, s3 * (phi - t1 - s2 * t2)]), bool(fixed), tuple(fixed)))

    if rho2 <= tol:  # axes 2 and 3 coincide: t2 free
        t1, free = _angle_about(w, r3 - r1, q - r1, scale)
        add(t1, 0.0, (0, 1) if free else (1,))
    elif D <= tol:  # axes 1 and 2 coincide: t1 free
        t2, _ = _angle_about(w, r3 - r2, q - r2, scale)
        add(0.0, s2 * t2, (0,))
    else:
        for u in _elbow_links(w, r1, r2, q, rho2):
            t2, _ = _angle_about(w, r3 - r2, u, scale)
            t1, free = _angle_about(w, (r2 - r1) + u, q - r1, scale)
            add(t1, s2 * t2, (0,) if free else ())
    return out


def _elbow_links(w, r1, r2, q, rho2) -> list[np.ndarray]:
    """The second link ``u`` (length ``rho2``, perpendicular to ``w``) with ``|r2 - r1 + u| = |q - r1|``.

    The angle ``a`` of ``u`` from ``e = (r2 - r1) / D`` has ``2 D rho2 cos a = |q - r1|^2 - D^2 - rho2^2``,
    with ``|q - r1|^2 - D^2 = (q - r2) . (q + r2 - 2 r1)`` formed without cancellation: a short second
    link (nearly coincident axes 2 and 3) keeps its angle to the data's conditioning, where the
    intersection of the two circles loses it entirely.  ``|cos a| = 1`` within a few ulps is the
    stretched or folded elbow: one link, not two ``sqrt(eps)`` apart.  Out of reach: clamped (least
    squares).
    """
    d = r2 - r1
    D = float(np.linalg.norm(d))
    e = d / D
    c = (float((q - r2) @ (q + r2 - 2.0 * r1)) - rho2 * rho2) / (2.0 * D * rho2)
    if abs(c) >= 1.0 - 8.0 * np.finfo(float).eps:
        return [rho2 * math.copysign(1.0, c) * e]
    sa = math.sqrt(1.0 - c * c)
    return [rho2 * (c * e + sg * np.cross(w, e)) for sg in (sa, -sa)]


def _near_families(ws, R) -> list[tuple[np.ndarray, np.ndarray]]:
    """Representatives and directions ``(th, n)`` of the orientation families of the nearby degenerate
    geometry: revolute axes parallel within :data:`NEAR_TOL` (but not within ``PAR_TOL``), axes 1 and 3
    lined up within ``GIMBAL_TOL``.

    There the rotation alone fixes the angles only up to ~1e-16 / |w_i x w_j| (its isolated solutions
    slide along the nearby family), while the translation still fixes them well: the true solutions lie
    within ~|w_i x w_j| of the family, where the translation picks them (then Gauss-Newton finishes).
    """
    out = []
    k = len(ws)
    if k == 2 and _sin_between(ws[0], ws[1]) <= NEAR_TOL:
        s = _sign(ws[0] @ ws[1])
        out.append((np.array([0.0, s * _angle_r(ws[0], R)[0]]), np.array([1.0, -s])))
    if k != 3:
        return out
    w1, w2, w3 = ws
    if _sin_between(w1, w2) <= NEAR_TOL:
        ((th, _, _),) = rotation_families([w1, w3], R)
        s = _sign(w1 @ w2)
        out.append((np.array([0.0, s * th[0], th[1]]), np.array([1.0, -s, 0.0])))
    if _sin_between(w2, w3) <= NEAR_TOL:
        ((th, _, _),) = rotation_families([w1, w2], R)
        s = _sign(w2 @ w3)
        out.append((np.array([th[0], 0.0, s * th[1]]), np.array([0.0, 1.0, -s])))
    Rw3 = R @ w3
    if _sin_between(w1, Rw3) <= GIMBAL_TOL:
        ((th, _, _),) = rotation_families([w2, w3], R)
        out.append((np.array([0.0, th[0], th[1]]), np.array([1.0, 0.0, -_sign(w1 @ Rw3)])))
    return out


def _sin_between(a, b) -> float:
    """|a x b|: the sine of the angle between unit vectors a and b."""
    return float(np.linalg.norm(np.cross(a, b)))


def _sign(x) -> float:
    return 1.0 if x > 0 else -1.0


def _near_candidates(kinds, twists, T, scale, ir, ws, found=()):
    """Candidates from the nearby degenerate geometry (:func:`_near_families` other than the families
    ``found`` already, three axes nearly parallel: the planar problem), polished here: they miss by up
    to ~|w_i x w_j| times the scale."""
    m = len(kinds)
    raw = []
    if len(ir) == 3 and max(_sin_between(ws[0], w) for w in ws[1:]) <= NEAR_TOL:
        raw += _planar_candidates(twists, T, scale)
    for th, n in _near_families(ws, T[:3, :3]):
        if any(np.array_equal(n, f) for f in found):
            continue
        q0, nfull = np.zeros(m), np.zeros(m)
        q0[ir], nfull[ir] = th, n
        raw += _family_candidates(twists, kinds, q0, nfull, T, scale)
    out = []
    for q, cont, fixed in raw:
        if residual(twists, q, T) <= NEAR_POLISH_TOL * scale:
            q = polish(twists, q, T, scale, fixed, iters=10)
        out.append((q, cont, fixed))
    return out


def candidates(kinds: str, twists, T, scale):
    """Candidate joint vectors ``(q, continuum, fixed_joints)`` of one class I instance."""
    ir = [i for i, k in enumerate(kinds) if k == "R"]
    ws = [twists[i, 3:] for i in ir]
    m = len(kinds)
    if len(ir) == 3 and all(np.linalg.norm(np.cross(ws[0], w)) <= PAR_TOL for w in ws[1:]):
        return _planar_candidates(twists, T, scale)
    out = []
    families = rotation_families(ws, T[:3, :3])
    for th, n, dim in families:
        q0 = np.zeros(m)
        q0[ir] = th
        if dim == 0:
            q, dep = prismatic_lstsq(twists, kinds, q0, T[:3, 3])
            out.append((q, dep, tuple(i for i, k in enumerate(kinds) if k == "T") if dep else ()))
        else:
            nfull = np.zeros(m)
            nfull[ir] = n
            out += _family_candidates(twists, kinds, q0, nfull, T, scale)
    found = [n for _, n, dim in families if dim == 1]
    out += _near_candidates(kinds, twists, T, scale, ir, ws, found)
    return out


# ----------------------------------------------------------------------------------------------------
# verification
# ----------------------------------------------------------------------------------------------------


def _body_error(twists, q, T, scale):
    g = fk(twists, q)
    R, p = g[:3, :3], g[:3, 3]
    M = R.T @ T[:3, :3]
    ew = 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
    return np.concatenate([R.T @ (T[:3, 3] - p), scale * ew])


def _body_jacobian(twists, q, scale):
    m = len(q)
    J = np.zeros((6, m))
    h = np.eye(4)
    for i in range(m - 1, -1, -1):
        J[:, i] = adjoint(inverse_transform(h)) @ twists[i]
        h = twist_exp(twists[i], q[i]) @ h
    J[3:] *= scale
    return J


def polish(twists, q, T, scale, fixed=(), iters: int = 5) -> np.ndarray:
    """Gauss-Newton on the body-frame pose error over the joints not in ``fixed`` (steps kept if better)."""
    q = np.array(q, dtype=float)
    free = [i for i in range(len(q)) if i not in fixed]
    if not free:
        return q
    err = residual(twists, q, T)
    for _ in range(iters):
        if err <= 1e-15 * scale:
            break
        e = _body_error(twists, q, T, scale)
        J = _body_jacobian(twists, q, scale)[:, free]
        q2 = q.copy()
        q2[free] += np.linalg.lstsq(J, e, rcond=1e-14)[0]
        err2 = residual(twists, q2, T)
        if not err2 < err:
            break
        q, err = q2, err2
    return q


def finalize(kinds: str, twists, T, cands, scale, max_count: int = 0) -> list[Solution]:
    scored = []
    for q, cont, fixed in cands:
        q = np.asarray(q, dtype=float)
        if not np.all(np.isfinite(q)):
            continue
        err = residual(twists, q, T)
        if err <= POLISH_TOL * scale:
            q = polish(twists, q, T, scale, fixed)
        q = wrap_joints(q, kinds)
        scored.append((residual(twists, q, T), q, bool(cont)))
    if not scored:
        return [Solution(tuple(0.0 for _ in kinds), ls=True)]
    # a continuum representative first: when a family holds to the tolerance, its flag must survive the
    # cut to max_count below even if isolated roots on it have smaller residuals
    exact = sorted((s for s in scored if s[0] <= EXACT_TOL * scale), key=lambda s: (not s[2], s[0]))
    if not exact:
        err, q, cont = next(s for s in scored if s[0] <= _tie(min(s[0] for s in scored)))
        return [Solution(tuple(float(a) for a in q), ls=True, continuum=cont)]
    kept: list = []
    for s in exact:
        if all(joint_distance(kinds, s[1], k[1]) > DEDUP_TOL for k in kept):
            kept.append(s)
    # Never more than theory allows: near a continuum (e.g. nearly coincident parallel axes) several
    # distinct candidates can each meet the tolerance; the best ones are kept.
    kept = kept[:max_count] if max_count else kept
    kept.sort(key=lambda s: tuple(s[1]))
    return [Solution(tuple(float(a) for a in q), continuum=cont) for _, q, cont in kept]


def _tie(best):
    """Least-squares candidates with residuals within this of the best tie: the first one is returned,
    so that both paths (whose residuals differ in the last bits) pick the same one."""
    return best * (1.0 + 1e-9) + 1e-300


def solve_class1(code: str, twists, T) -> list[Solution]:
    """Every solution of ``prod exp(xi_i th_i) = T`` for the joint kinds of ``code``."""
    kinds = kinds_of(code)
    twists = np.asarray(twists, dtype=float)
    T = np.asarray(T, dtype=float)
    scale = problem_scale(twists, T)
    from subproblems.core import max_solutions

    return finalize(kinds, twists, T, candidates(kinds, twists, T, scale), scale, max_solutions(code))


# ----------------------------------------------------------------------------------------------------
# vectorised path
# ----------------------------------------------------------------------------------------------------


def _fk_batch(tw, Q) -> np.ndarray:
    """``prod exp(xi_i q_i)`` for twists (N, m, 6) and joint values (N, K, m): (N, K, 4, 4)."""
    return fk_batch(tw[:, None], Q)


def _residual_batch(tw, Q, T) -> np.ndarray:
    g = _fk_batch(tw, Q)
    sT = np.maximum(1.0, np.linalg.norm(T[:, :3, 3], axis=-1))[:, None]
    pos = np.linalg.norm(g[..., :3, 3] - T[:, None, :3, 3], axis=-1)
    rot = np.abs(g[..., :3, :3] - T[:, None, :3, :3]).max(axis=(-2, -1))
    return np.maximum(pos, sT * rot)


def _affine_batch(tw, kinds, Q):
    """Batched :func:`affine_translation`: ``a`` (N, K, 3) and ``B`` (N, K, 3, p)."""
    N, K, m = Q.shape
    g = np.broadcast_to(np.eye(4), (N, K, 4, 4)).copy()
    cols = []
    for i, k in enumerate(kinds):
        if k == "T":
            cols.append(np.einsum("nkij,nj->nki", g[..., :3, :3], tw[:, i, :3]))
        else:
            g = g @ twist_exp_batch(np.repeat(tw[:, None, i], K, 1), Q[..., i])
    B = np.stack(cols, -1) if cols else np.zeros((N, K, 3, 0))
    return g[..., :3, 3], B


def _polish_batch(tw, Q, T, scale, iters: int = 5) -> np.ndarray:
    """Batched Gauss-Newton on the body-frame pose error (steps kept where they help)."""
    N, K, m = Q.shape
    err = _residual_batch(tw, Q, T)
    sc = scale[:, None]
    for _ in range(iters):
        g = _fk_batch(tw, Q)
        R, p = g[..., :3, :3], g[..., :3, 3]
        Rt = np.swapaxes(R, -1, -2)
        M = Rt @ T[:, None, :3, :3]
        ew = 0.5 * np.stack(
            [M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]], -1
        )
        ev = np.einsum("nkij,nkj->nki", Rt, T[:, None, :3, 3] - p)
        e = np.concatenate([ev, sc[..., None] * ew], -1)
        J = np.zeros((N, K, 6, m))
        h = np.broadcast_to(np.eye(4), (N, K, 4, 4)).copy()
        for i in range(m - 1, -1, -1):
            hi = inverse_transform(h)
            Rh, ph = hi[..., :3, :3], hi[..., :3, 3]
            xi = np.repeat(tw[:, None, i], K, 1)
            w = np.einsum("nkij,nkj->nki", Rh, xi[..., 3:])
            v = np.einsum("nkij,nkj->nki", Rh, xi[..., :3]) + np.cross(ph, w)
            J[..., :3, i] = v
            J[..., 3:, i] = sc[..., None] * w
            h = twist_exp_batch(xi, Q[..., i]) @ h
        step = np.einsum("nkij,nkj->nki", np.linalg.pinv(J, rcond=1e-10), e)
        Q2 = Q + step
        err2 = _residual_batch(tw, Q2, T)
        better = (err2 < err) & (err > 1e-15 * sc)
        Q = np.where(better[..., None], Q2, Q)
        err = np.where(better, err2, err)
    return Q


def _near_degenerate_batch(W, R) -> np.ndarray:
    """(N,) instances whose scalar path adds :func:`_near_candidates` (nearly parallel revolute axes,
    nearly lined-up axes 1 and 3 of three)."""
    N, k = W.shape[:2]
    near = np.zeros(N, bool)
    for i in range(k - 1):
        near |= np.linalg.norm(np.cross(W[:, i], W[:, i + 1]), axis=-1) <= NEAR_TOL
    if k == 3:
        Rw3 = np.einsum("nij,nj->ni", R, W[:, 2])
        near |= np.linalg.norm(np.cross(W[:, 0], Rw3), axis=-1) <= GIMBAL_TOL
    return near


def batch_class1(code: str, twists, T) -> BatchResult:
    """N instances at once: twists (N, m, 6), targets (N, 4, 4); slots ``max_solutions(code)``.

    Instances whose orientation has a continuum family (parallel revolute axes, gimbal lock, three
    parallel axes), whose axes are near such geometry (:func:`_near_degenerate_batch`) or whose
    prismatic directions are dependent are the degenerate ones: they go
    through the scalar path (a loop over those instances only); every other instance is solved
    without a Python loop: orientation candidates (vectorised ``O-*``), prismatic values by batched
    least squares, batched Gauss-Newton polish, verification and deduplication.
    """
    from subproblems.core import max_solutions

    kinds = kinds_of(code)
    tw = np.asarray(twists, dtype=float)
    T = np.asarray(T, dtype=float)
    N, m, K = len(T), len(kinds), max_solutions(code)
    ir = [i for i, k in enumerate(kinds) if k == "R"]
    ip = [i for i, k in enumerate(kinds) if k == "T"]
    W = tw[:, ir, 3:]
    R, pT = T[:, :3, :3], T[:, :3, 3]
    scale = np.maximum(1.0, np.linalg.norm(pT, axis=-1))
    for i in ir:
        scale = np.maximum(scale, np.linalg.norm(np.cross(tw[:, i, 3:], tw[:, i, :3]), axis=-1))
    TH, cvalid, _, dim = rotation_families_batch(W, R)
    Kr = TH.shape[1]
    Q = np.zeros((N, Kr, m))
    Q[..., ir] = TH
    degenerate = (dim > 0) | _near_degenerate_batch(W, R)
    if ip:
        a, B = _affine_batch(tw, kinds, Q)
        sv = np.linalg.svd(B, compute_uv=False)
        # nearly dependent directions too: there the least-squares values are ~1/sigma_min^2 sensitive to
        # the last bit of B, which the two paths compute differently (the scalar path answers for both)
        dep = sv.min(-1) <= NEAR_TOL * np.maximum(1.0, sv.max(-1))
        degenerate |= (dep & cvalid).any(1)
        d = np.einsum("nkij,nkj->nki", np.linalg.pinv(B, rcond=RANK_TOL), pT[:, None] - a)
        Q[..., ip] = d
    err = _residual_batch(tw, Q, T)
    near = (err <= POLISH_TOL * scale[:, None]) & cvalid
    Q = np.where(near[..., None], _polish_batch(tw, Q, T, scale), Q)
    rev = np.array([k == "R" for k in kinds])
    Q = np.where(rev, wrap_array(Q), Q)
    err = np.where(cvalid, _residual_batch(tw, Q, T), np.inf)
    exact = err <= EXACT_TOL * scale[:, None]
    valid = exact.copy()
    if Kr == 2:
        diff = np.abs(Q[:, 0] - Q[:, 1])
        diff = np.where(
            rev,
            np.abs(np.remainder(diff + math.pi, TWO_PI) - math.pi),
            diff / np.maximum(1.0, np.abs(Q[:, 1])),
        )
        valid[:, 1] &= ~(valid[:, 0] & (diff.max(-1) <= DEDUP_TOL))
    none = ~exact.any(1)
    best = np.argmax(err <= _tie(err.min(1))[:, None], axis=1)
    valid[np.arange(N), best] |= none
    ls = valid & ~exact
    Qo = np.zeros((N, K, m))
    Vo = np.zeros((N, K), bool)
    Lo = np.zeros((N, K), bool)
    Qo[:, :Kr], Vo[:, :Kr], Lo[:, :Kr] = Q, valid, ls
    cont = np.zeros(N, bool)
    for i in np.flatnonzero(degenerate):  # degenerate instances only: the scalar path
        sols = solve_class1(code, tw[i], T[i])[:K]
        Qo[i], Vo[i], Lo[i] = 0.0, False, False
        for j, sol in enumerate(sols):
            Qo[i, j], Vo[i, j], Lo[i, j] = sol.q, True, sol.ls
        cont[i] = any(sol.continuum for sol in sols)
    return BatchResult(code, Qo, Vo, Lo, cont, vectorised=True)
