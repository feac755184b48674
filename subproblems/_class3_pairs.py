"""Two equations in two joint values (S3-XY and H-XY): elimination engine, private.

Both families have two scalar equations in ``(x, y)`` (the values of joints 1 and 2) that are
*bilinear* in the bases ``phi(x)`` and ``psi(y)``, where a revolute value has the basis
``(1, cos, sin)`` and a prismatic one ``(1, t, t^2)``:

    E_k(x, y) = sum_ij M_k[i, j] phi_i(x) psi_j(y) = 0,      k = 1, 2.

* S3 (``|| g1(x) g2(y) p_k - q_k || = d_k``): with ``Y = g2(y) p_k`` and ``Z = g1(x)^-1 q_k``,
  ``|Y - Z|^2 - d_k^2 = |Y|^2 + |Z|^2 - 2 Y.Z - d_k^2``; ``Y`` is a circle or line in ``y``, ``Z`` one in
  ``x``, and the squared norm of a circle point is linear in ``(1, cos, sin)`` (``|b| = |e|, b.e = 0``).
* H (``h_k^T g1(x) g2(y) p_k = d_k``): linear in ``Y`` and in the rotated normal ``g1(x)^-T h_k``.

Elimination (one unknown at a time, docs/design.md section 4 notes):

* a revolute unknown ``x`` is eliminated by Cramer's rule: each equation reads
  ``alpha_k cos x + beta_k sin x = g_k`` with coefficients polynomial in ``y``; ``cos x = Nc / D``,
  ``sin x = Ns / D`` and the unit circle gives ``F(y) = Nc^2 + Ns^2 - D^2 = 0``;
* two prismatic unknowns: the resultant of the two quadratics in ``x``; H-TT, linear in both, is the
  2x2 linear system it is (:func:`_solve_linear`: one solution, or a continuum when singular);
* ``F`` is a polynomial of degree <= 8 in ``z = exp(i y)`` (revolute ``y``, roots on the unit circle)
  or in ``y`` itself (prismatic, real roots); roots come from companion-matrix eigenvalues (batched).

Then every root gives ``x`` by back-substitution (Cramer, or the better-conditioned single equation when
``D ~ 0``), every candidate is polished by Gauss-Newton on the *original* equations and kept only if
its residual is at most ``EXACT_TOL`` times the problem scale (so eigenvalue noise, near-double roots
and spurious roots never come back as solutions); duplicates (1e-7) are removed.

Units: every instance is solved in units of a power of two near its scale (:meth:`Pair.normalised`),
so every tolerance below is relative and the eliminant's coefficients in a prismatic value do not
span ``scale^8``; scaling an instance by a power of two scales its prismatic values exactly.

Tangencies: at a double root of the system (the two curves touch, the Jacobian is singular there)
the equations are flat to second order, so roundoff leaves the polished row anywhere within
~sqrt(eps) of it (two rows, or one ~3e-8 off).  A row whose Jacobian is nearly singular is moved onto
the point where, in addition, ``det J = 0`` (or ``J = 0`` where both equations are stationary;
Gauss-Newton), if the equations hold there to ``MERGE_SPREAD`` times its own residual; two rows of one
split tangency then coincide, and a tangent point represents its cluster in the merge below.

Weak values: where one value barely acts on the equations (a point ~1e-8 from an axis), the
candidates of a multiple root give it anywhere and polishing stalls; such candidates start again from
each equation solved for that value with the other fixed (:func:`_reseed`), and where one equation's
dependence on the eliminated value vanishes at a root, the other equation alone also gives it.

Zero distances (S3, ``d_k`` at roundoff): ``|g p_k - q_k| = 0`` is a cone, not a smooth equation;
the class II solver of the same joints gives its points exactly, and those that satisfy the other
equation are the solutions near them (:func:`_point_coincidences`).

Multiple roots: a root of multiplicity ~4 of ``F`` (e.g. parallel axes, ``p_1 = q_1`` on the first
axis and ``th_2 = pi``: equation 1 does not depend on ``x`` and is tangent there) is split by roundoff
into a cluster of roots ~1e-4 apart, each a candidate.  The equations are nearly flat there (rank-
deficient Jacobian): Gauss-Newton with LM's damping stalls ~1e-2 away, so the candidates are then
polished by plain Newton (best point kept), which converges linearly to the roundoff floor; exact rows
within ``MERGE_TOL`` of each other whose midpoint satisfies the equations to ``MERGE_SPREAD`` times
their own residual are one root: their Newton-polished mean (or the member of smallest residual)
replaces them if it is exact.  Distinct roots closer than ``MERGE_TOL`` leave a residual of order
curvature x distance^2 between them and stay apart.  More exact rows than slots: the ``K`` of
smallest residual stay.

Special geometry (points at the origin, on an axis or at an intersection of the axes, equal pairs):

* an eliminant of lower degree (roots at infinity, e.g. parallel axes) is deflated, never nudged
  (a nudged leading coefficient scatters every double root);
* an equation that does not depend on ``x`` (``q_k`` on the first axis) makes ``F`` a square with
  double roots and ``D = 0`` there; ``D`` is judged against both rows together so that the other
  equation alone then gives both values of ``x``;
* every tensor entry at roundoff level (``M_FLOOR`` of the problem's size) means both equations hold
  for every ``(x, y)``: a continuum, whatever the roundoff in ``F``;
* of close exact candidates the best-converged one is kept;
* an eliminant at roundoff relative to its terms (a near-continuum) still gives candidates: when no
  start of the continuum fallback below reaches an exact point, its exact candidates are the answer.

When ``F`` vanishes identically (the equations share a curve: a continuum) or no candidate is exact
(unreachable), Levenberg-Marquardt runs from a fixed grid of starts, ``(0, 0)`` first; the first start
that reaches an exact point gives the **representative** (``continuum``); the starts include the
points where one value is a grid start and one equation is solved exactly for the other (on a
continuum in which one value is free those already satisfy both).  Otherwise the smallest
residual is returned flagged ``ls``, polished until its gradient stops falling (each instance on its
own, so a batch and ``solve`` agree).  A joint the equations do not constrain keeps its start value
``0`` (LM steps are minimum-norm).

Everything works on ``N`` instances at once (no Python loop over instances); the scalar path runs
the same code with ``N = 1``.
"""

from __future__ import annotations

import numpy as np

from subproblems import tolerances
from subproblems._class3 import EXACT_TOL, TINY
from subproblems.angles import wrap_array
from subproblems.core import BatchResult, Solution, solve_batch

# Tolerances: subproblems/tolerances.py (each with its reason there; docs/design.md section 10).
DEDUP_TOL = tolerances.S3P_SAME_SOLUTION
ZERO_TOL = tolerances.S3P_ZERO_ELIMINANT
M_FLOOR = tolerances.S3P_TENSOR_FLOOR
FREE_REL = tolerances.S3P_FREE_VALUE
LM_ITERS = 40
ZERO_DIST = tolerances.S3P_ZERO_DISTANCE
APEX_TOL = tolerances.S3P_APEX
RESEED_TOL = tolerances.S3P_RESEED
LS_POLISH_ITERS = 200  # further LM iterations of a least-squares answer, at most (_polish_lsq)
NEWTON_ITERS = 24
MERGE_TOL = tolerances.S3P_MULTIPLE_ROOT
MERGE_SPREAD = 100.0  # ... and the equations hold between them to this many times their residual
ROUNDOFF = tolerances.S3P_ROUNDOFF
FOLD_SV = tolerances.S3P_FOLD_SINGULAR
FOLD_FLAT = tolerances.S3P_FOLD_FLAT
FOLD_STEP = 1e-7  # finite-difference step of the tangency refinement (units of the normalised problem)
FOLD_ITERS = 8
MIN_UNIT = 2.0**-500  # smallest unit of length an instance is solved in (Pair.normalised)
CLUSTER_TOL = tolerances.S3P_CLUSTER
RANK_TOL = tolerances.S3P_RANK


# --------------------------------------------------------------------------------- parametrisation


def _length(v):
    """Euclidean length over the last axis without underflow (components ~1e-200 square to 0)."""
    m = np.abs(v).max(axis=-1)
    safe = np.where(m == 0, 1.0, m)
    return m * np.linalg.norm(v / safe[..., None], axis=-1)


def _rot(w, c, s, u):
    """Rodrigues rotation of vectors u by angle (c = cos, s = sin) about unit w (broadcasting)."""
    wu = np.sum(w * u, axis=-1, keepdims=True)
    return u * c + np.cross(w, u) * s + w * wu * (1.0 - c)


def param(kind: str, xi, pts, inverse: bool = False):
    """Basis vectors (N, 3, 3) of ``g(x) pts`` (or ``g(x)^-1 pts``) in ``phi(x)``.

    Revolute: ``a + b cos + e sin`` (``e`` negated for the inverse); prismatic: ``p + v t``.
    """
    v, w = xi[:, :3], xi[:, 3:]
    if kind == "R":
        c = np.cross(w, v)
        a = c + w * np.sum(w * (pts - c), axis=1, keepdims=True)
        b = pts - a
        e = np.cross(w, b)
        return np.stack([a, b, -e if inverse else e], axis=1)
    return np.stack([pts, -v if inverse else v, np.zeros_like(pts)], axis=1)


def direction_param(kind: str, xi, h):
    """Basis of ``g(x)^-T h`` (a normal carried back by the inverse rotation) in ``phi(x)``."""
    w = xi[:, 3:]
    if kind == "R":
        a = w * np.sum(w * h, axis=1, keepdims=True)
        b = h - a
        return np.stack([a, b, -np.cross(w, b)], axis=1)
    return np.stack([h, np.zeros_like(h), np.zeros_like(h)], axis=1)


def norm2(kind: str, B):
    """Coefficients (N, 3) of ``|point|^2`` in the basis, for a basis from :func:`param`."""
    A, U, V = B[:, 0], B[:, 1], B[:, 2]
    dot = lambda a, b: np.sum(a * b, axis=1)  # noqa: E731
    if kind == "R":
        return np.stack([dot(A, A) + dot(U, U), 2 * dot(A, U), 2 * dot(A, V)], axis=1)
    return np.stack([dot(A, A), 2 * dot(A, U), dot(U, U)], axis=1)


def s3_tensor(kinds, tw, P, Q, D):
    """M (N, 2, 3, 3) of the S3 pair."""
    kx, ky = kinds
    Ms = []
    for k in range(2):
        Y = param(ky, tw[:, 1], P[:, k])
        Z = param(kx, tw[:, 0], Q[:, k], inverse=True)
        M = -2.0 * np.einsum("nix,njx->nij", Z, Y)
        M[:, 0, :] += norm2(ky, Y)
        M[:, :, 0] += norm2(kx, Z)
        M[:, 0, 0] -= D[:, k] ** 2
        Ms.append(M)
    return np.stack(Ms, axis=1)


def h_tensor(kinds, tw, P, H, D):
    """M (N, 2, 3, 3) of the H pair (normals divided by their length)."""
    kx, ky = kinds
    hn = _length(H)
    safe = np.where(hn == 0.0, 1.0, hn)
    H = H / safe[..., None]
    D = np.where(hn == 0.0, D, D / safe)
    Ms = []
    for k in range(2):
        Y = param(ky, tw[:, 1], P[:, k])
        if kx == "R":
            c1 = np.cross(tw[:, 0, 3:], tw[:, 0, :3])
            Hd = direction_param("R", tw[:, 0], H[:, k])
            Yc = Y.copy()
            Yc[:, 0] -= c1
            M = np.einsum("nix,njx->nij", Hd, Yc)
            M[:, 0, 0] += np.sum(H[:, k] * c1, axis=1)
        else:
            M = np.zeros((len(D), 3, 3))
            M[:, 0, :] = np.einsum("nx,njx->nj", H[:, k], Y)
            M[:, 1, 0] += np.sum(H[:, k] * tw[:, 0, :3], axis=1)
        M[:, 0, 0] -= D[:, k]
        Ms.append(M)
    return np.stack(Ms, axis=1)


# ------------------------------------------------------------------------------------ the problem


class Pair:
    """N instances of one two-equation type: kinds, twists (N, 2, 6), points and right-hand sides."""

    def __init__(self, family: str, kinds: str, tw, P, R, D):
        self.family, self.kinds = family, kinds
        self.tw, self.P, self.R, self.D = tw, P, R, D  # R: q points (S3) or normals h (H)
        n = len(D)
        norms = [_length(P).max(axis=1), np.abs(D).max(axis=1)]
        if family == "S3":
            norms.append(_length(R).max(axis=1))
        else:
            hn = _length(R)
            norms.append((np.abs(D) / np.where(hn == 0, 1.0, hn)).max(axis=1))
        for j in range(2):
            norms.append(_length(np.cross(tw[:, j, 3:], tw[:, j, :3])))
        self.scale = np.maximum(np.maximum.reduce(norms), TINY) if n else np.zeros(0)

    def subset(self, idx) -> Pair:
        return Pair(self.family, self.kinds, self.tw[idx], self.P[idx], self.R[idx], self.D[idx])

    def normalised(self):
        """The same instances in units of a power of two near their scale, and those units (N,).

        Every length is divided by the unit (exactly: a power of two), so the solver sees problems of
        size ~1 whatever the user's units: its tolerances and the eliminant's coefficient thresholds are
        then relative (the eliminant's coefficients in a prismatic value span ``scale^8`` otherwise,
        and a leading coefficient ~1e-24 of the largest at scale 1e3 was dropped as a root at
        infinity).  Prismatic values of the result are in the unit: multiply them back.
        """
        # (an instance of size below MIN_UNIT, ~1e-150, is all roundoff: it is solved as of size 1/2
        # in units of MIN_UNIT, its lengths then ~0)
        unit = np.exp2(np.maximum(np.round(np.log2(self.scale)), np.log2(MIN_UNIT)))
        u = unit[:, None, None]
        tw = self.tw.copy()
        for j, kind in enumerate(self.kinds):
            if kind == "R":  # v = -w x r: a length; a prismatic direction is not (its value is)
                tw[:, j, :3] /= unit[:, None]
        R = self.R / u if self.family == "S3" else self.R  # q points, or plane normals (directions)
        out = Pair(self.family, self.kinds, tw, self.P / u, R, self.D / unit[:, None])
        out.scale = np.maximum(out.scale, 0.5)
        return out, unit

    def tensor(self):
        f = s3_tensor if self.family == "S3" else h_tensor
        return f(self.kinds, self.tw, self.P, self.R, self.D)

    def residual(self, x, y):
        """r (N, C, 2) and J (N, C, 2, 2) of the original equations at (x, y) (N, C)."""
        kx, ky = self.kinds
        tw = self.tw[:, None, None, :, :]  # (N, 1, 1, 2, 6)
        P = self.P[:, None, :, :]  # (N, 1, 2, 3)
        xs, ys = x[..., None, None], y[..., None, None]
        v2, w2 = tw[..., 1, :3], tw[..., 1, 3:]
        v1, w1 = tw[..., 0, :3], tw[..., 0, 3:]
        if ky == "R":
            c2 = np.cross(w2, v2)
            Y = c2 + _rot(w2, np.cos(ys), np.sin(ys), P - c2)
            dY = np.cross(w2, Y - c2)
        else:
            Y = P + v2 * ys
            dY = np.broadcast_to(v2, Y.shape)
        if kx == "R":
            c1 = np.cross(w1, v1)
            cx, sx = np.cos(xs), np.sin(xs)
            X = c1 + _rot(w1, cx, sx, Y - c1)
            dXx = np.cross(w1, X - c1)
            dXy = _rot(w1, cx, sx, dY)
        else:
            X = Y + v1 * xs
            dXx = np.broadcast_to(v1, X.shape)
            dXy = dY
        if self.family == "S3":
            diff = X - self.R[:, None]
            dist = np.linalg.norm(diff, axis=-1)
            r = dist - self.D[:, None]
            u = diff / np.where(dist == 0, 1.0, dist)[..., None]
        else:
            hn = _length(self.R)
            safe = np.where(hn == 0, 1.0, hn)[:, None, :, None]
            u = self.R[:, None] / safe
            # h . X - d before the division: no rounding of h / |h| and d / |h| in the difference
            r = (np.sum(self.R[:, None] * X, axis=-1) - self.D[:, None]) / safe[..., 0]
            r = np.where(hn[:, None] == 0, -self.D[:, None], r)
        J = np.stack([np.sum(u * dXx, axis=-1), np.sum(u * dXy, axis=-1)], axis=-1)
        return r, J


# --------------------------------------------------------------------------------- polynomial part


def _conv(a, b):
    out = np.zeros(a.shape[:-1] + (a.shape[-1] + b.shape[-1] - 1,), dtype=np.result_type(a, b))
    for i in range(a.shape[-1]):
        for j in range(b.shape[-1]):
            out[..., i + j] += a[..., i] * b[..., j]
    return out


_BASIS_R = np.array([[0, 1, 0], [0.5, 0, 0.5], [0.5j, 0, -0.5j]], dtype=complex)  # in z = e^{iy}, times z
_BASIS_T = np.eye(3)


def _eliminant(M, ke):
    """Eliminant coefficients (N, 9) (low to high) in the kept variable's polynomial variable."""
    row = M  # (N, 2, 3 (i), 3 (coeffs))
    if ke == "R":
        al, be, g = row[:, :, 1], row[:, :, 2], -row[:, :, 0]
        D = _conv(al[:, 0], be[:, 1]) - _conv(al[:, 1], be[:, 0])
        Nc = _conv(g[:, 0], be[:, 1]) - _conv(g[:, 1], be[:, 0])
        Ns = _conv(al[:, 0], g[:, 1]) - _conv(al[:, 1], g[:, 0])
        return _conv(Nc, Nc) + _conv(Ns, Ns) - _conv(D, D)
    A, B, C = row[:, :, 2], row[:, :, 1], row[:, :, 0]
    AC = _conv(A[:, 0], C[:, 1]) - _conv(A[:, 1], C[:, 0])
    AB = _conv(A[:, 0], B[:, 1]) - _conv(A[:, 1], B[:, 0])
    BC = _conv(B[:, 0], C[:, 1]) - _conv(B[:, 1], C[:, 0])
    return _conv(AC, AC) - _conv(AB, BC)


def _poly_roots(F):
    """All roots (N, 8) of degree-8 polynomials (low to high).

    A polynomial of lower degree (leading coefficients below 1e-14 of the largest: roots at infinity,
    e.g. S3-RR with parallel axes) is multiplied by ``z^L`` instead: its roots plus ``L`` roots at 0,
    which are never on the unit circle and, as prismatic values, are verified like every candidate.
    (Nudging the leading coefficient to a tiny value instead gives a companion matrix with entries
    ~1e14 whose eigenvalues lose the double roots entirely.)
    """
    n = F.shape[0]
    big = np.abs(F).max(axis=1)
    tiny = big < 1e-250  # (sub)normal-range coefficients: complex division would overflow; zero instead
    Fn = np.where(tiny[:, None], 0.0, F) / np.where(tiny, 1.0, big)[:, None]
    small = np.abs(Fn) < 1e-14
    lz = np.minimum(np.cumprod(small[:, ::-1], axis=1).sum(axis=1), 8)  # leading (near-)zeros
    src = np.arange(9)[None, :] - lz[:, None]
    Fn = np.where(src >= 0, np.take_along_axis(Fn, np.maximum(src, 0), axis=1), 0.0)
    lead = Fn[:, 8]
    lead = np.where(np.abs(lead) < 1e-14, 1e-14, lead)
    Cm = np.zeros((n, 8, 8), dtype=Fn.dtype)
    Cm[:, 0, :] = -Fn[:, 7::-1] / lead[:, None]
    Cm[:, np.arange(1, 8), np.arange(7)] = 1.0
    return np.linalg.eigvals(Cm)


# -------------------------------------------------------------------------------------- the solver


def _basis_values(kind, u):
    if kind == "R":
        return np.stack([np.ones_like(u), np.cos(u), np.sin(u)], axis=-1)
    return np.stack([np.ones_like(u), u, u * u], axis=-1)


def _with_cluster_centres(ku, u, ok):
    """The roots (N, 8) and, appended, the centre of each cluster of roots closer than ``CLUSTER_TOL``.

    A multiple root of the eliminant is split by roundoff into a cluster (spread ~eps^(1/m), 1e-3 for
    four); back-substitution at a member is off by that spread amplified where the eliminated value
    barely acts, while the cluster's mean is the root to ~1e-8 or better.  One centre per cluster (at
    its first member), valid only for clusters of two or more.
    """
    d = u[:, :, None] - u[:, None, :]
    if ku == "R":
        d = wrap_array(d)
    else:
        d = d / np.maximum(1.0, np.abs(u))[:, :, None]
    member = ok[:, :, None] & ok[:, None, :] & (np.abs(d) <= CLUSTER_TOL)
    count = member.sum(axis=2)
    centre = u - np.sum(np.where(member, d, 0.0), axis=2) / np.maximum(count, 1)
    if ku == "R":
        centre = wrap_array(centre)
    first = np.argmax(member, axis=2) == np.arange(u.shape[1])[None]
    # (a cluster has distinct members: roots z and 1 / conj(z), or a complex pair of a prismatic value,
    # give the same value twice, and their candidates are already there)
    spread = np.any(member & (np.abs(d) > 1e-9), axis=2)
    valid = ok & spread & first
    return np.concatenate([u, np.where(valid, centre, 0.0)], axis=1), np.concatenate([ok, valid], axis=1)


def _candidates(Mr, ke, ku, u):
    psi = _basis_values(ku, u)
    n, C = u.shape
    rv = np.swapaxes(Mr.reshape(n, 6, 3) @ np.swapaxes(psi, 1, 2), 1, 2).reshape(n, C, 2, 3)
    # an equation whose dependence on x nearly vanishes at this root (against its own size): Cramer's
    # x then follows the root's error in u, amplified; the other equation alone also gives x
    eq_size = np.abs(Mr).max(axis=(2, 3))[:, None, :] + TINY  # (n, 1, 2)
    faint = np.any(np.abs(rv[..., 1:]).max(axis=-1) <= 1e-2 * eq_size, axis=-1)
    if ke == "R":
        al, be, g = rv[..., 1], rv[..., 2], -rv[..., 0]
        D = al[..., 0] * be[..., 1] - al[..., 1] * be[..., 0]
        Nc = g[..., 0] * be[..., 1] - g[..., 1] * be[..., 0]
        Ns = al[..., 0] * g[..., 1] - al[..., 1] * g[..., 0]
        # D is judged against both rows together: when one equation does not depend on x at this
        # root (its row vanishes, e.g. q_k on the first axis), D ~ 0 and the other equation alone
        # gives x (two roots); a product of the row sizes would vanish with the row and hide that
        ref = (np.abs(al[..., 0]) + np.abs(be[..., 0]) + np.abs(al[..., 1]) + np.abs(be[..., 1])) ** 2 + TINY
        nondeg = np.abs(D) > 1e-8 * ref
        sg = np.where(D < 0, -1.0, 1.0)
        x0 = np.arctan2(Ns * sg, Nc * sg)
        k = (np.hypot(al[..., 1], be[..., 1]) > np.hypot(al[..., 0], be[..., 0])).astype(int)[..., None]
        A = np.take_along_axis(al, k, -1)[..., 0]
        B = np.take_along_axis(be, k, -1)[..., 0]
        C = np.take_along_axis(g, k, -1)[..., 0]
        r = np.hypot(A, B)
        phi = np.arctan2(B, A)
        delta = np.arccos(np.clip(C / np.where(r == 0, 1.0, r), -1.0, 1.0))
        X = np.stack([x0, phi - delta, phi + delta], axis=-1)
        weak = (np.abs(D) <= 1e-2 * ref) | faint  # ill-conditioned Cramer: also try the single equation
        V = np.stack([nondeg, weak, weak], axis=-1)
        return X, V
    A, B, C = rv[..., 2], rv[..., 1], rv[..., 0]
    den = A[..., 1] * B[..., 0] - A[..., 0] * B[..., 1]
    ref = (np.abs(A[..., 0]) + np.abs(B[..., 0]) + np.abs(A[..., 1]) + np.abs(B[..., 1])) ** 2 + TINY
    nondeg = np.abs(den) > 1e-8 * ref
    x0 = (A[..., 0] * C[..., 1] - A[..., 1] * C[..., 0]) / np.where(nondeg, den, 1.0)
    k = (np.abs(A[..., 1]) + np.abs(B[..., 1]) > np.abs(A[..., 0]) + np.abs(B[..., 0])).astype(int)[..., None]
    a = np.take_along_axis(A, k, -1)[..., 0]
    b = np.take_along_axis(B, k, -1)[..., 0]
    c = np.take_along_axis(C, k, -1)[..., 0]
    lin = np.abs(a) <= 1e-12 * (np.abs(b) + np.abs(c) + TINY)
    sq = np.sqrt(np.maximum(b * b - 4 * a * c, 0.0))
    safe_a = np.where(lin, 1.0, a)
    r1 = np.where(lin, -c / np.where(b == 0, 1.0, b), (-b - sq) / (2 * safe_a))
    r2 = np.where(lin, r1, (-b + sq) / (2 * safe_a))
    X = np.stack([x0, r1, r2], axis=-1)
    weak = (np.abs(den) <= 1e-2 * ref) | faint
    V = np.stack([nondeg, weak, weak & ~lin], axis=-1)
    return X, V


def _single_roots(kind, c, scale):
    """Both roots (..., 2, 2 -> flattened by the caller) of one equation in one value.

    ``c`` (n, S, 2, 3): coefficients of ``(1, cos, sin)`` (revolute) or ``(1, t, t^2)`` (prismatic) for S
    fixed values of the other joint and the two equations.  No real root: the clamped / real-part
    value (a start point only).  Prismatic values are kept within 100 times the problem scale.
    """
    if kind == "R":
        A, B, C = c[..., 1], c[..., 2], -c[..., 0]
        r = np.hypot(A, B)
        phi = np.arctan2(B, A)
        delta = np.arccos(np.clip(C / np.where(r == 0, 1.0, r), -1.0, 1.0))
        return np.stack([phi - delta, phi + delta], axis=-1)
    a, b, cc = c[..., 2], c[..., 1], c[..., 0]
    lin = np.abs(a) <= 1e-12 * (np.abs(b) + np.abs(cc) + TINY)
    sq = np.sqrt(np.maximum(b * b - 4 * a * cc, 0.0))
    safe_a = np.where(lin, 1.0, a)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):  # clipped below
        r1 = np.where(lin, -cc / np.where(b == 0, 1.0, b), (-b - sq) / (2 * safe_a))
        r2 = np.where(lin, r1, (-b + sq) / (2 * safe_a))
    r1, r2 = np.nan_to_num(r1), np.nan_to_num(r2)
    lim = 100.0 * scale[:, None, None, None]
    return np.clip(np.stack([r1, r2], axis=-1), -lim, lim)


def _basis_deriv(kind, u):
    if kind == "R":
        return np.stack([np.zeros_like(u), -np.sin(u), np.cos(u)], axis=-1)
    return np.stack([np.zeros_like(u), np.ones_like(u), 2.0 * u], axis=-1)


def _snap_free(M, kx, ky, X, Y, scale, iters: int = 12):
    """Continuum points: where every coefficient of one value's basis vanishes, that value is free.

    From each candidate, Gauss-Newton on the six coefficients ``sum_j M[k, i, j] psi_j(y)`` (all ``k, i``)
    as functions of ``y`` alone finds a ``y*`` where the equations hold for every ``x`` (and
    symmetrically for ``x``).  Returns the snapped (X, Y) and the (x free, y free) flags; a free value
    is set to 0, its documented representative.
    """
    ref = np.abs(M).max(axis=(1, 2, 3))[:, None] + TINY

    def solve_1d(kind, u0, contract):
        u = u0
        for _ in range(iters):
            c = contract(_basis_values(kind, u))  # (N, C, 6)
            g = contract(_basis_deriv(kind, u))
            gg = np.sum(g * g, axis=-1)
            step = np.sum(g * c, axis=-1) / np.where(gg == 0, 1.0, gg)
            u = np.where(gg == 0, u, u - _cap(kind, step, scale))
            u = np.where(np.isfinite(u), u, 0.0)
        c = contract(_basis_values(kind, u))
        moved = u - u0
        if kind == "R":
            moved = wrap_array(moved)
        near = np.abs(moved) <= 1e-3 * (1.0 if kind == "R" else np.maximum(1.0, np.abs(u0)))
        return u, near & (np.abs(c).max(axis=-1) <= FREE_REL * ref)

    n = M.shape[0]
    Mj = M.reshape(n, 6, 3)  # rows (k, i), contracted over j
    Mi = np.swapaxes(M, 2, 3).reshape(n, 6, 3)  # rows (k, j), contracted over i
    ys, xfree = solve_1d(ky, Y, lambda psi: np.swapaxes(Mj @ np.swapaxes(psi, 1, 2), 1, 2))
    xs, yfree = solve_1d(kx, X, lambda phi: np.swapaxes(Mi @ np.swapaxes(phi, 1, 2), 1, 2))
    X = np.where(xfree, 0.0, np.where(yfree, xs, X))
    Y = np.where(xfree, ys, np.where(yfree, 0.0, Y))
    return X, Y, xfree, yfree


def _cap(kind, step, scale):
    lim = np.pi if kind == "R" else 100.0 * scale.reshape((-1,) + (1,) * (step.ndim - 1))
    return np.clip(step, -lim, lim)


def _lm(pb: Pair, x, y, iters: int, damping0: float):
    """Levenberg-Marquardt (or Gauss-Newton with tiny damping) on (N, C) starts; returns x, y, cost."""
    r, J = pb.residual(x, y)
    cost = np.sum(r * r, axis=-1)
    lam = np.full(x.shape, damping0)
    for _ in range(iters):
        JtJ = np.einsum("...ki,...kj->...ij", J, J)
        Jtr = np.einsum("...ki,...k->...i", J, r)
        tr = JtJ[..., 0, 0] + JtJ[..., 1, 1]
        mu = lam * tr + TINY
        a, b, c = JtJ[..., 0, 0] + mu, JtJ[..., 0, 1], JtJ[..., 1, 1] + mu
        det = a * c - b * b
        det = np.where(det == 0, TINY, det)
        dx = -(c * Jtr[..., 0] - b * Jtr[..., 1]) / det
        dy = -(a * Jtr[..., 1] - b * Jtr[..., 0]) / det
        # a step never longer than half a turn / 100 problem scales (a flat spot, J ~ 0, would
        # otherwise jump to overflow; such a step is rejected anyway)
        dx, dy = _cap(pb.kinds[0], dx, pb.scale), _cap(pb.kinds[1], dy, pb.scale)
        nx, ny = x + dx, y + dy
        r2, J2 = pb.residual(nx, ny)
        with np.errstate(over="ignore", invalid="ignore"):
            c2 = np.sum(r2 * r2, axis=-1)
        better = np.isfinite(c2) & (c2 < cost)
        x, y = np.where(better, nx, x), np.where(better, ny, y)
        cost = np.where(better, c2, cost)
        r = np.where(better[..., None], r2, r)
        J = np.where(better[..., None, None], J2, J)
        lam = np.where(better, lam / 3.0, lam * 4.0)
    return x, y, cost


def _newton(pb: Pair, x, y, iters: int):
    """Plain Newton on the two equations from (N, C) points; returns the best point seen (x, y, r, J).

    Near a multiple root (the Jacobian nearly singular) Levenberg-Marquardt stalls ~1e-2 from the
    root: its damping swamps the small singular value, and a step that raises the cost on the way
    (Newton's path to a multiple root does) is rejected.  Plain Newton (the pseudo-inverse step along
    the gradient when the Jacobian is singular) converges linearly there, down to the roundoff floor;
    every step is taken and the point of least cost is returned, so a point never gets worse.
    """
    r, J = pb.residual(x, y)
    cost = np.sum(r * r, axis=-1)
    bx, by, br, bJ, bc = x, y, r, J, cost
    for _ in range(iters):
        a, b, c, d = J[..., 0, 0], J[..., 0, 1], J[..., 1, 0], J[..., 1, 1]
        det = a * d - b * c
        T = a * a + b * b + c * c + d * d
        reg = np.abs(det) > 1e-14 * T
        sdet = np.where(reg, det, 1.0)
        dx = np.where(
            reg, -(d * r[..., 0] - b * r[..., 1]) / sdet, -(a * r[..., 0] + c * r[..., 1]) / (T + TINY)
        )
        dy = np.where(
            reg, -(a * r[..., 1] - c * r[..., 0]) / sdet, -(b * r[..., 0] + d * r[..., 1]) / (T + TINY)
        )
        x = x + _cap(pb.kinds[0], dx, pb.scale)
        y = y + _cap(pb.kinds[1], dy, pb.scale)
        x, y = np.where(np.isfinite(x), x, bx), np.where(np.isfinite(y), y, by)
        r, J = pb.residual(x, y)
        with np.errstate(over="ignore", invalid="ignore"):
            cost = np.sum(r * r, axis=-1)
        better = np.isfinite(cost) & (cost < bc)
        bx, by, bc = np.where(better, x, bx), np.where(better, y, by), np.where(better, cost, bc)
        br = np.where(better[..., None], r, br)
        bJ = np.where(better[..., None, None], J, bJ)
    return bx, by, br, bJ


def _distance(kx, ky, X1, Y1, X2, Y2):
    """Joint-value distance (angles modulo 2 pi, prismatic values relative to max(1, |value|))."""
    dx, dy = X1 - X2, Y1 - Y2
    dx = wrap_array(dx) if kx == "R" else dx / np.maximum(1.0, np.abs(X2))
    dy = wrap_array(dy) if ky == "R" else dy / np.maximum(1.0, np.abs(Y2))
    return np.maximum(np.abs(dx), np.abs(dy))


def _merge_clusters(pb: Pair, X, Y, exact, res, tangent=None):
    """Merge exact rows that are one multiple root split by roundoff (module docstring).

    Two exact rows are the same root when they are within ``MERGE_TOL`` of each other *and* the
    equations hold at their midpoint to ``MERGE_SPREAD`` times the smaller of their residuals (at
    least the roundoff floor): at a multiple root the equations are flat across the cluster; two
    distinct roots, however close, leave a residual of order curvature x distance^2 between them
    (distinct roots ~1e-6 apart or more stay apart), and a row that only meets the tolerance (the
    residual between a close pair) links neither.  A group's representative is its mean,
    Newton-polished, or the member of smallest residual if that is not larger; kept only if it
    satisfies the equations, otherwise the rows are left as they are.  Returns X, Y, res and the rows
    dropped (merged into another).
    """
    kx, ky = pb.kinds
    n, C = X.shape
    if C < 2 or not exact.any():
        return X, Y, res, np.zeros((n, C), dtype=bool)
    dist = _distance(kx, ky, X[:, :, None], Y[:, :, None], X[:, None, :], Y[:, None, :])
    # (duplicates within DEDUP_TOL are removed later anyway: they alone never start a group)
    link = exact[:, :, None] & exact[:, None, :] & (dist <= MERGE_TOL) & (dist > DEDUP_TOL)
    link &= ~np.eye(C, dtype=bool)[None]
    if not link.any():
        return X, Y, res, np.zeros((n, C), dtype=bool)
    # one root when the equations hold at the midpoint to the rows' own roundoff floor (two distinct
    # roots, however close, leave a residual of order curvature x distance^2 between them)
    idx = np.nonzero(link.any(axis=(1, 2)))[0]
    sub = pb.subset(idx)
    Xs, Ys = X[idx], Y[idx]
    ox = Xs[:, None, :] - Xs[:, :, None]
    oy = Ys[:, None, :] - Ys[:, :, None]
    if kx == "R":
        ox = wrap_array(ox)
    if ky == "R":
        oy = wrap_array(oy)
    mx = (Xs[:, :, None] + 0.5 * ox).reshape(len(idx), -1)
    my = (Ys[:, :, None] + 0.5 * oy).reshape(len(idx), -1)
    mr, _ = sub.residual(mx, my)
    mid = np.abs(mr).max(axis=-1).reshape(len(idx), C, C)
    floor = np.maximum(
        np.minimum(res[idx][:, :, None], res[idx][:, None, :]), ROUNDOFF * sub.scale[:, None, None]
    )
    link[idx] &= mid <= MERGE_SPREAD * floor
    link |= np.eye(C, dtype=bool)[None]
    for _ in range(int(np.ceil(np.log2(C))) + 1):  # transitive closure
        link = link | np.einsum("nij,njk->nik", link.astype(np.int8), link.astype(np.int8)).astype(bool)
    leader = np.argmax(link, axis=2)  # the first row of each row's group
    members = link.sum(axis=2)
    is_leader = (leader == np.arange(C)[None]) & (members > 1) & exact
    if not is_leader.any():
        return X, Y, res, np.zeros((n, C), dtype=bool)
    # group means relative to the leader (angles unwrapped about it)
    LX = np.take_along_axis(X, leader, axis=1)
    LY = np.take_along_axis(Y, leader, axis=1)
    ox, oy = X - LX, Y - LY
    if kx == "R":
        ox = wrap_array(ox)
    if ky == "R":
        oy = wrap_array(oy)
    w = link.astype(float)
    MX = LX + np.einsum("nij,nj->ni", w, ox) / members
    MY = LY + np.einsum("nij,nj->ni", w, oy) / members
    MX, MY, mr, _ = _newton(pb, _wrap(kx, MX), _wrap(ky, MY), NEWTON_ITERS)
    MX, MY = _wrap(kx, MX), _wrap(ky, MY)
    mres = np.abs(mr).max(axis=-1)
    # a member with a residual no larger than the polished mean's represents the group instead (the
    # equations are flat across the cluster: the residual is the only evidence of where the root is),
    # a tangent point (_refine_folds) first: it is the root itself
    tangent = np.zeros((n, C), dtype=bool) if tangent is None else tangent
    Rg = np.where(link, np.where(tangent, -1.0, res)[:, None, :], np.inf)
    bi = np.argmin(Rg, axis=2)
    bres = np.take_along_axis(res, bi, axis=1)
    use = (bres <= mres) | np.take_along_axis(tangent, bi, axis=1)
    MX = np.where(use, np.take_along_axis(X, bi, axis=1), MX)
    MY = np.where(use, np.take_along_axis(Y, bi, axis=1), MY)
    mres = np.where(use, bres, mres)
    ok = is_leader & (mres <= EXACT_TOL * pb.scale[:, None])
    X, Y, res = np.where(ok, MX, X), np.where(ok, MY, Y), np.where(ok, mres, res)
    merged_into = np.take_along_axis(ok, leader, axis=1) & ~ok & (leader != np.arange(C)[None])
    return X, Y, res, merged_into


def _fold_equations(pb: Pair, x, y, flat):
    """The two equations and what vanishes at a tangency, (N, C, 6).

    Where the Jacobian has rank one there, its determinant (over its size: a length); where it
    vanishes altogether (``flat``: both equations stationary, e.g. both points at their farthest from
    the axes), its four entries (the determinant is then of second order and pins nothing).
    """
    r, J = pb.residual(x, y)
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    size = np.sqrt(np.sum(J * J, axis=(-2, -1)))
    rank1 = np.zeros(J.shape[:-2] + (4,))
    rank1[..., 0] = det / (size + TINY)
    extra = np.where(flat[..., None], J.reshape(J.shape[:-2] + (4,)), rank1)
    return np.concatenate([r, extra], axis=-1)


def _refine_folds(pb: Pair, X, Y, exact, res, J):
    """Exact rows near a tangency moved onto the tangent point (see the module docstring).

    At a double root of the system (the two curves touch: a singular Jacobian there) the equations are
    flat to second order, so every point within ~sqrt(eps) of it meets them to roundoff and Newton
    stops anywhere in that band.  The tangent point is where, in addition, the Jacobian is singular:
    Gauss-Newton on the equations and ``det J`` (or all of ``J`` where it nearly vanishes) pins it to
    roundoff.  A row whose Jacobian is nearly singular (against the problem's natural size: in the
    normalised problem, 1) moves there if the equations still hold at that point to ``MERGE_SPREAD``
    times its own residual (two distinct close roots leave curvature x distance^2 between them, and
    their rows stay); rows of one split tangency land on the same point and are then duplicates.
    """
    kx, ky = pb.kinds
    size2 = np.sum(J * J, axis=(-2, -1))
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    natural2 = np.maximum(size2, pb.scale[:, None] ** 2)
    near = exact & (np.abs(det) <= FOLD_SV * natural2)
    idx = np.nonzero(near.any(axis=1))[0]
    tangent = np.zeros(X.shape, dtype=bool)
    if not len(idx):
        return X, Y, res, tangent
    sub = pb.subset(idx)
    flat = size2[idx] <= (FOLD_FLAT * sub.scale[:, None]) ** 2
    x, y = X[idx], Y[idx]
    for _ in range(FOLD_ITERS):
        G = _fold_equations(sub, x, y, flat)
        Gx, Gy = _fold_equations(sub, x + FOLD_STEP, y, flat), _fold_equations(sub, x, y + FOLD_STEP, flat)
        A = np.stack([Gx - G, Gy - G], axis=-1) / FOLD_STEP  # (n, C, 6, 2) forward differences
        AtA = np.einsum("...ki,...kj->...ij", A, A)
        AtG = np.einsum("...ki,...k->...i", A, G)
        a, b, c = AtA[..., 0, 0], AtA[..., 0, 1], AtA[..., 1, 1]
        d = a * c - b * b
        ok = np.isfinite(d) & (np.abs(d) > 1e-14 * (a * c + TINY))
        d = np.where(ok, d, 1.0)
        dx = np.where(ok, -(c * AtG[..., 0] - b * AtG[..., 1]) / d, 0.0)
        dy = np.where(ok, -(a * AtG[..., 1] - b * AtG[..., 0]) / d, 0.0)
        x, y = x + _cap(kx, dx, sub.scale), y + _cap(ky, dy, sub.scale)
    x, y = _wrap(kx, x), _wrap(ky, y)
    r, _ = sub.residual(x, y)
    fres = np.abs(r).max(axis=-1)
    moved = _distance(kx, ky, x, y, X[idx], Y[idx])
    floor = np.maximum(res[idx], ROUNDOFF * sub.scale[:, None])
    take = near[idx] & (fres <= MERGE_SPREAD * floor) & (moved <= MERGE_TOL) & np.isfinite(x + y)
    X[idx], Y[idx] = np.where(take, x, X[idx]), np.where(take, y, Y[idx])
    res[idx] = np.where(take, fres, res[idx])
    tangent[idx] = take
    return X, Y, res, tangent


def _wrap(kind, v):
    return wrap_array(v) if kind == "R" else v


def _starts(kind, scale):
    if kind == "R":
        return np.broadcast_to(np.array([0.0, np.pi / 2, np.pi, -np.pi / 2]), (len(scale), 4))
    return np.array([0.0, 1.0, -1.0, 2.0])[None, :] * scale[:, None]


def solve_pairs(code: str, pb: Pair, K: int) -> BatchResult:
    """All solutions of N instances (see the module docstring); ``K`` solution slots.

    Solved in units of the instance's scale (:meth:`Pair.normalised`), so that scaling an instance's
    lengths by a power of two scales its prismatic values exactly and changes nothing else.
    """
    pb, unit = pb.normalised()
    out = _solve_linear(code, pb) if pb.family == "H" and pb.kinds == "TT" else _solve_normalised(code, pb, K)
    out = _point_coincidences(pb, out, K)
    for j, kind in enumerate(pb.kinds):
        if kind == "T":
            out.q[:, :, j] *= unit[:, None]
    return out


def _point_coincidences(pb: Pair, out: BatchResult, K: int) -> BatchResult:
    """S3 pairs with a zero distance (to ``ZERO_DIST``): the point coincidence ``g p_k = q_k`` (class II).

    ``|g p_k - q_k| = 0`` is a cone in the joint values, not a smooth equation: the polished rows of
    the engine stop up to ~sqrt(eps) from its apex where the other equation is tangent there, and a
    continuum judged from it can miss the point.  The class II solver of the same two joints gives
    the apex points exactly; those satisfying the other equation replace the engine's rows near them
    (or its ls / continuum answer when there are any).
    """
    # (a distance at roundoff of the scale: the same coincidence, evaluated by another forward kinematics)
    zero = np.abs(pb.D) <= ZERO_DIST * pb.scale[:, None]
    # An exact continuum of the engine is checked too: the solutions lie on the coincidence's set, so
    # when class II finds that set finite (S3-TT with both distances 0: a linear system of full rank)
    # the answer is finite; when class II reports a continuum itself, the engine's answer stays.
    todo = zero.any(axis=1)
    todo = np.nonzero(todo)[0] if pb.family == "S3" else np.zeros(0, dtype=int)
    if not len(todo):
        return out
    sub = pb.subset(todo)
    k = np.argmax(zero[todo], axis=1)  # the first zero-distance equation
    rows = np.arange(len(todo))
    s2 = solve_batch("S2-" + pb.kinds, sub.tw, p=sub.P[rows, k], q=sub.R[rows, k])
    r, _ = sub.residual(s2.q[..., 0], s2.q[..., 1])
    good = s2.valid & ~s2.ls & ~s2.continuum[:, None]
    good &= np.abs(r).max(axis=-1) <= EXACT_TOL * sub.scale[:, None]
    has = good.any(axis=1)
    if not has.any():
        return out
    todo, good, Sq = todo[has], good[has], s2.q[has]
    kx, ky = pb.kinds
    Q, valid = out.q[todo], out.valid[todo]
    exact_old = valid & ~out.ls[todo] & ~out.continuum[todo, None]
    near = _distance(kx, ky, Q[:, :, None, 0], Q[:, :, None, 1], Sq[:, None, :, 0], Sq[:, None, :, 1])
    stays = exact_old & ~np.any((near <= APEX_TOL) & good[:, None, :], axis=2)
    allq = np.concatenate([Sq, Q], axis=1)
    keep = np.concatenate([good, stays], axis=1)
    key = np.where(keep, allq[..., 0], np.inf)
    order = np.lexsort((np.where(keep, allq[..., 1], np.inf), key), axis=1)[:, :K]
    allq = np.take_along_axis(allq, order[..., None], axis=1)
    keep = np.take_along_axis(keep, order, axis=1)
    q, valid, ls, cont = out.q.copy(), out.valid.copy(), out.ls.copy(), out.continuum.copy()
    q[todo] = np.where(keep[..., None], allq, 0.0)
    valid[todo], ls[todo], cont[todo] = keep, False, False
    return BatchResult(out.code, q, valid, ls, cont)


def _solve_linear(code: str, pb: Pair) -> BatchResult:
    """H-TT: two plane equations linear in both prismatic values, ``A (x, y) = b``.

    Nonsingular (``sigma_2`` above ``RANK_TOL`` of the directions' size): the one solution, never a
    continuum.  Singular to roundoff: a continuum, represented by the minimum-norm solution when it
    holds; otherwise by the untruncated solve when that holds (the roundoff-sized singular value then
    carries the right-hand side: the float data's own solution, judged against its travel);
    otherwise the minimum-norm least-squares point, flagged ``ls``.
    """
    n = len(pb.D)
    hn = _length(pb.R)
    safe = np.where(hn == 0.0, 1.0, hn)
    V = pb.tw[:, :, :3]  # (N, 2 joints, 3)
    vn = np.linalg.norm(V, axis=2)
    A = np.einsum("nkx,njx->nkj", pb.R, V) / safe[..., None]
    b = (pb.D - np.sum(pb.R * pb.P, axis=2)) / safe
    U, S, Wt = np.linalg.svd(A)
    Ub = np.einsum("nki,nk->ni", U, b)  # U^T b
    nonzero = S > RANK_TOL * np.maximum(vn.max(axis=1), TINY)[:, None]

    def back(keep):
        with np.errstate(over="ignore", invalid="ignore"):
            inv = np.where(keep, 1.0 / np.where(keep, S, 1.0), 0.0)
            q = np.einsum("nij,ni->nj", Wt, inv * Ub)
        return np.where(np.isfinite(q), q, 0.0)

    full, least = back(S > 0), back(nonzero)

    singular = ~nonzero[:, 1]

    def exact(q, travel):
        # (travel: of a singular system, relative to the travel too: the moved point's size bounds
        # the roundoff of h . X - d; data of size ~0 with a travel of 1e3 evaluate to ~1e-13)
        r, _ = pb.residual(q[:, None, 0], q[:, None, 1])
        size = np.where(travel, np.maximum(pb.scale, np.sum(vn * np.abs(q), axis=1)), pb.scale)
        return np.abs(r[:, 0]).max(axis=-1) <= EXACT_TOL * size

    least_ok, full_ok = exact(least, False), exact(full, singular)
    use_full = ~singular | (~least_ok & full_ok)
    q = np.where(use_full[:, None], full, least)
    ls = np.where(use_full, ~full_ok, ~least_ok)
    return BatchResult(code, q[:, None, :], np.ones((n, 1), dtype=bool), ls[:, None], singular)


def _polish_lsq(pb: Pair, x, y, chunk: int = 20):
    """Least-squares points (N, 1) converged until the gradient ``J^T r`` stops falling (its roundoff
    floor is ~1e-9 of ``|J| |r|``)."""
    last = np.full(x.shape, np.inf)
    active = np.ones(x.shape, dtype=bool)  # (each point stops on its own: a batch answers as solve)
    for _ in range(LS_POLISH_ITERS // chunk):
        nx, ny, _ = _lm(pb, x, y, chunk, 1e-6)
        x, y = np.where(active, nx, x), np.where(active, ny, y)
        r, J = pb.residual(x, y)
        grad = np.abs(np.einsum("...ki,...k->...i", J, r)).max(axis=-1)
        grad = grad / (np.abs(J).max(axis=(-2, -1)) * np.abs(r).max(axis=-1) + TINY)
        active &= (grad > 1e-9) & (grad <= 0.5 * last)
        if not active.any():
            break
        last = grad
    return x, y


def _polish(pb: Pair, X, Y, V):
    """Candidates polished on the original equations: Gauss-Newton, then plain Newton where needed."""
    X, Y, cost = _lm(pb, X, Y, NEWTON_ITERS, 1e-12)
    # undamped Newton: LM's damping stalls ~1e-2 from a multiple root (rank-deficient Jacobian)
    # (only instances with a candidate LM left above the roundoff floor: converged ones need none)
    slow = np.nonzero(np.any(V & (cost > (1e-13 * pb.scale[:, None]) ** 2), axis=1))[0]
    if len(slow):
        NX, NY, _, _ = _newton(pb.subset(slow), X[slow], Y[slow], NEWTON_ITERS)
        X[slow], Y[slow] = NX, NY
    return _wrap(pb.kinds[0], X), _wrap(pb.kinds[1], Y)


def _reseed(pb: Pair, M, X, Y, V):
    """Candidates where one value barely acts start again from the roots of one equation in one value.

    A candidate from a multiple root of the eliminant has its kept value off by ~eps^(1/m) (1e-3 for a
    cluster of six); where the other value is only weakly determined (a point 1e-8 from an axis
    moves it by 1e-8 per radian) back-substitution gives it anywhere, and polishing then stalls at an
    extremum of that equation or reaches only one of its roots.  From the polished values of each such
    near miss or exact candidate, each equation is solved for one value with the other fixed: those
    points are polished and added.
    """
    kx, ky = pb.kinds
    r, J = pb.residual(X, Y)
    res = np.abs(r).max(axis=-1) / pb.scale[:, None]
    weak = np.linalg.norm(J, axis=-2).min(axis=-1) <= RESEED_TOL * pb.scale[:, None]  # a value barely acts
    # (exact ones too: within the tolerance such a value is anywhere in a band, and every candidate
    # may have gone to one root; a spurious root of the eliminant misses by much more)
    stalled = V & (res <= RESEED_TOL) & weak
    idx = np.nonzero(stalled.any(axis=1))[0]
    if not len(idx):
        return X, Y, V
    sub, Ms = pb.subset(idx), M[idx]
    cnt = stalled[idx].sum(axis=1)
    order = np.argsort(~stalled[idx], axis=1, kind="stable")[:, : int(cnt.max())]
    SX, SY = np.take_along_axis(X[idx], order, axis=1), np.take_along_axis(Y[idx], order, axis=1)
    SV = np.arange(order.shape[1])[None, :] < cnt[:, None]
    n, S = SX.shape
    ex_x = _single_roots(kx, np.einsum("nsj,nkij->nski", _basis_values(ky, SY), Ms), sub.scale)
    ex_y = _single_roots(ky, np.einsum("nsi,nkij->nskj", _basis_values(kx, SX), Ms), sub.scale)
    rep = lambda a: np.repeat(a, 4, axis=1)  # noqa: E731 - one value fixed, four roots of the other
    NX = np.concatenate([ex_x.reshape(n, -1), rep(SX)], axis=1)
    NY = np.concatenate([rep(SY), ex_y.reshape(n, -1)], axis=1)
    NV = np.concatenate([rep(SV), rep(SV)], axis=1)
    NX, NY = _polish(sub, np.where(NV, NX, 0.0), np.where(NV, NY, 0.0), NV)
    width = NX.shape[1]
    pad = lambda a, fill: np.concatenate([a, np.full((a.shape[0], width), fill, dtype=a.dtype)], axis=1)  # noqa: E731
    X, Y, V = pad(X, 0.0), pad(Y, 0.0), pad(V, False)
    X[idx, -width:], Y[idx, -width:], V[idx, -width:] = NX, NY, NV
    X[idx], Y[idx] = _weak_newton(sub, X[idx], Y[idx])
    return X, Y, V


def _weak_newton(pb: Pair, X, Y, iters: int = 6):
    """Newton along the value that barely acts, on the equation it acts on most (the other fixed).

    Where the Jacobian is singular otherwise (a zero distance makes an equation a cone, whose
    gradient vanishes at its apex), Newton on both values stalls, and a row off by 1e-4 in the weak
    value still meets the tolerance; one value at a time converges.  A step is kept if it lowers the
    residual.
    """
    kx, ky = pb.kinds
    for _ in range(iters):
        r, J = pb.residual(X, Y)
        res = np.abs(r).max(axis=-1)
        col = np.abs(J)  # (n, C, 2 equations, 2 values)
        j = np.argmin(col.max(axis=-2), axis=-1)  # the weaker value
        Jj = np.take_along_axis(J, j[..., None, None], axis=-1)[..., 0]  # (n, C, 2)
        k = np.argmax(np.abs(Jj), axis=-1)[..., None]
        den = np.take_along_axis(Jj, k, axis=-1)[..., 0]
        step = -np.take_along_axis(r, k, axis=-1)[..., 0] / np.where(den == 0, 1.0, den)
        step = np.where(den == 0, 0.0, step)
        NX = X + _cap(kx, np.where(j == 0, step, 0.0), pb.scale)
        NY = Y + _cap(ky, np.where(j == 1, step, 0.0), pb.scale)
        nr, _ = pb.residual(NX, NY)
        better = np.abs(nr).max(axis=-1) < res
        X, Y = np.where(better, NX, X), np.where(better, NY, Y)
    return _wrap(kx, X), _wrap(ky, Y)


def _solve_normalised(code: str, pb: Pair, K: int) -> BatchResult:
    kx, ky = pb.kinds
    n = len(pb.D)
    M = pb.tensor()
    swap = kx == "T" and ky == "R"
    Mr = np.swapaxes(M, 2, 3) if swap else M
    ke, ku = (ky, kx) if swap else (kx, ky)
    basis = _BASIS_R if ku == "R" else _BASIS_T
    rowpoly = np.einsum("nkij,jc->nkic", Mr.astype(basis.dtype), basis)  # (N, 2, 3, 3 coeffs)
    F = _eliminant(rowpoly, ke)
    mmax = np.abs(M).max(axis=(1, 2, 3))
    ref = mmax**4 + TINY
    identically_zero = np.abs(F).max(axis=1) <= ZERO_TOL * ref
    # M's entries carry roundoff of a few ulps of the problem's size (scale^2 for squared distances,
    # scale for plane offsets): when every entry is at that level, both equations hold for every
    # (x, y) (e.g. p_k or q_k at an intersection point of the axes), whatever F's roundoff says
    unit = pb.scale**2 if pb.family == "S3" else pb.scale
    identically_zero |= mmax <= M_FLOOR * unit
    # coincident revolute axes / parallel prismatic directions: only the sum of the values matters
    if kx == ky:
        w1 = pb.tw[:, 0, 3:] if kx == "R" else pb.tw[:, 0, :3]
        w2 = pb.tw[:, 1, 3:] if kx == "R" else pb.tw[:, 1, :3]
        same = np.linalg.norm(np.cross(w1, w2), axis=1) <= 1e-12
        if kx == "R":
            c1, c2 = np.cross(w1, pb.tw[:, 0, :3]), np.cross(w2, pb.tw[:, 1, :3])
            same &= np.linalg.norm(np.cross(c2 - c1, w1), axis=1) <= 1e-12 * pb.scale
        identically_zero |= same
    z = _poly_roots(F)
    if ku == "R":
        mod = np.abs(z)
        ok = (np.abs(np.log(np.where(mod == 0, 1e-300, mod))) < 0.05) & np.isfinite(mod)
        u = np.angle(z)
    else:
        ok = (np.abs(z.imag) <= 0.05 * (pb.scale[:, None] + np.abs(z.real))) & np.isfinite(z.real)
        u = z.real
    # (an eliminant judged identically zero still gives candidates: if no point of the supposed
    # continuum holds below, its exact candidates are the answer)
    u = np.where(ok, u, 0.0)
    u, ok = _with_cluster_centres(ku, u, ok)
    E, V = _candidates(Mr, ke, ku, u)  # (N, 8 + 8, 3)
    V &= ok[..., None]
    U = np.broadcast_to(u[..., None], E.shape)
    X, Y = (U, E) if swap else (E, U)
    X, Y, V = X.reshape(n, -1), Y.reshape(n, -1), V.reshape(n, -1)
    # keep only the valid candidates (compacted to the largest count over the instances)
    cnt = V.sum(axis=1)
    width = max(int(cnt.max()) if n else 1, 1)
    order = np.argsort(~V, axis=1, kind="stable")[:, :width]
    X, Y = np.take_along_axis(X, order, axis=1), np.take_along_axis(Y, order, axis=1)
    V = np.arange(width)[None, :] < cnt[:, None]
    X, Y = np.where(V, X, 0.0), np.where(V, Y, 0.0)
    X, Y = _polish(pb, X, Y, V)
    X, Y, V = _reseed(pb, M, X, Y, V)
    # a value the equations do not constrain at the other one (a continuum through this point)
    X, Y, xfree, yfree = _snap_free(M, kx, ky, X, Y, pb.scale)
    X, Y = _wrap(kx, X), _wrap(ky, Y)
    r, J = pb.residual(X, Y)
    res = np.abs(r).max(axis=-1)
    tol = EXACT_TOL * pb.scale[:, None]
    exact = V & (res <= tol)
    # a tangency (double root of the system) found ~sqrt(eps) off by roundoff: the tangent point itself
    X, Y, res, tangent = _refine_folds(pb, X, Y, exact & ~xfree & ~yfree, res, J)
    # a multiple root of the eliminant split by roundoff into several nearby roots: one row
    X, Y, res, merged = _merge_clusters(pb, X, Y, exact & ~xfree & ~yfree, res, tangent)
    exact &= ~merged
    # duplicates: a candidate close to an earlier exact one
    dx = X[:, :, None] - X[:, None, :]
    dy = Y[:, :, None] - Y[:, None, :]
    if kx == "R":
        dx = wrap_array(dx)
    else:
        dx = dx / np.maximum(1.0, np.abs(X))[:, None, :]
    if ky == "R":
        dy = wrap_array(dy)
    else:
        dy = dy / np.maximum(1.0, np.abs(Y))[:, None, :]
    close = np.maximum(np.abs(dx), np.abs(dy)) <= DEDUP_TOL
    C = X.shape[1]
    # of a group of close exact candidates the one with the smallest residual stays (ties: the earlier)
    earlier = np.tril(np.ones((C, C), dtype=bool), k=-1)
    better = (res[:, None, :] < res[:, :, None]) | ((res[:, None, :] == res[:, :, None]) & earlier)
    dup = np.any(close & better & exact[:, None, :], axis=2)
    keep = exact & ~dup
    # fallback: continuum or nothing exact
    cont = identically_zero | np.any(keep & (xfree | yfree), axis=1)
    need = identically_zero | ~keep.any(axis=1)
    LS = np.zeros((n, C), dtype=bool)
    if need.any():
        idx = np.nonzero(need)[0]
        sub = pb.subset(idx)
        sx, sy = _starts(kx, sub.scale), _starts(ky, sub.scale)
        SX = np.repeat(sx, sy.shape[1], axis=1)
        SY = np.tile(sy, (1, sx.shape[1]))
        # also start from the eliminant's candidates (near misses of unreachable instances) and from
        # the points where one value is a grid start and one equation holds exactly (solved for the
        # other value): on a continuum where one value is free these already satisfy both equations
        # where LM from the grid alone can stall between the two equations' roots
        Ms = M[idx]
        ex_y = _single_roots(ky, np.einsum("nsi,nkij->nskj", _basis_values(kx, sx), Ms), sub.scale)
        ex_x = _single_roots(kx, np.einsum("nsj,nkij->nski", _basis_values(ky, sy), Ms), sub.scale)
        SX = np.concatenate([SX, X[idx], np.repeat(sx, 4, axis=1), ex_x.reshape(len(idx), -1)], axis=1)
        SY = np.concatenate([SY, Y[idx], ex_y.reshape(len(idx), -1), np.repeat(sy, 4, axis=1)], axis=1)
        FX, FY, fcost = _lm(sub, SX, SY, LM_ITERS, 1e-3)
        FX, FY = _wrap(kx, FX), _wrap(ky, FY)
        fr, _ = sub.residual(FX, FY)
        fres = np.abs(fr).max(axis=-1)
        fexact = fres <= EXACT_TOL * sub.scale[:, None]
        first_exact = np.argmax(fexact, axis=1)
        best = np.where(fexact.any(axis=1), first_exact, np.argmin(fcost, axis=1))
        rows = np.arange(len(idx))
        # a near-continuum (the eliminant at roundoff relative to its terms) on which no start
        # reaches an exact point, but with exact candidates: those are the solutions
        found = fexact.any(axis=1)
        isolated = ~found & keep[idx].any(axis=1)
        cont[idx] &= ~isolated
        idx, rows, best = idx[~isolated], rows[~isolated], best[~isolated]
        bx, by, bexact = FX[rows, best], FY[rows, best], fexact[rows, best]
        # a least-squares point converged further (LM_ITERS leave it ~1e-5 from the minimiser in a
        # flat valley, where roundoff that differs between batch sizes then shows)
        lsq = np.nonzero(~bexact)[0]
        if len(lsq):
            px, py = _polish_lsq(sub.subset(rows[lsq]), bx[lsq, None], by[lsq, None])
            bx[lsq], by[lsq] = _wrap(kx, px[:, 0]), _wrap(ky, py[:, 0])
        X[idx, 0], Y[idx, 0] = bx, by
        keep[idx] = False
        keep[idx, 0] = True
        LS[idx, 0] = ~bexact
    # more exact rows than slots (a row that only meets the tolerance between two close roots): the
    # K of smallest residual stay
    rank = np.argsort(np.argsort(np.where(keep, res, np.inf), axis=1, kind="stable"), axis=1)
    keep &= rank < K
    # pack into K slots, sorted by x then y
    key = np.where(keep, X, np.inf)
    key2 = np.where(keep, Y, np.inf)
    order = np.lexsort((key2, key), axis=1)
    X = np.take_along_axis(X, order, axis=1)[:, :K]
    Y = np.take_along_axis(Y, order, axis=1)[:, :K]
    keep = np.take_along_axis(keep, order, axis=1)[:, :K]
    LS = np.take_along_axis(LS, order, axis=1)[:, :K]
    if X.shape[1] < K:
        pad = K - X.shape[1]
        X, Y = np.pad(X, ((0, 0), (0, pad))), np.pad(Y, ((0, 0), (0, pad)))
        keep, LS = np.pad(keep, ((0, 0), (0, pad))), np.pad(LS, ((0, 0), (0, pad)))
    Q = np.stack([np.where(keep, X, 0.0), np.where(keep, Y, 0.0)], axis=-1)
    return BatchResult(code, Q, keep, LS & keep, cont)


def to_solutions(b: BatchResult) -> list[Solution]:
    """Solutions of instance 0 of a batch result."""
    out = []
    for k in np.nonzero(b.valid[0])[0]:
        out.append(
            Solution(
                (float(b.q[0, k, 0]), float(b.q[0, k, 1])),
                ls=bool(b.ls[0, k]),
                continuum=bool(b.continuum[0]),
            )
        )
    return out
