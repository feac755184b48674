"""Every inverse-kinematics solution of a general 6R chain by algebraic elimination (docs/general6.md).

The problem: joint values ``th`` with ``exp(xi_1 th_1) ... exp(xi_6 th_6) M = T`` for six revolute twists
``xi_i = (v_i, w_i)`` (space frame, home pose ``M``) and a target ``T``.  Write ``X_i = exp(xi_i th_i)``
and ``G = T M^-1``.  The method is Raghavan and Roth's, in Manocha and Canny's eigenvalue form, derived
here in product-of-exponentials terms so that no Denavit-Hartenberg frames are needed.

**1. Split.**  With the joints in the order (a, b, c, d, e, f) of a chosen *arrangement*, the line of
joint f (a point ``p_f`` on it and its direction ``w_f``) is fixed by ``X_f``, so

    X_c X_d X_e (p_f, w_f)  =  X_b^-1 X_a^-1 (G p_f, R_G w_f)          (6 scalar equations: p, l)

**2. Fourteen equations.**  From the point ``p`` and direction ``l`` of either side form the 14
quantities ``p, l, p.p, p.l, p x l, (p.p) l - 2 (p.l) p``.  With the origin on the outer axis (b on the
right, c on the left) the outer rotation only rotates the vectors and leaves the scalars alone, and the
inner rotation enters once, so every quantity is *linear* in (1, cos, sin) of each joint: the right side
lies in the span of (1, c_a, s_a) x (1, c_b, s_b) and the left side in that of (1, c_c, s_c) x (1, c_d,
s_d) x (1, c_e, s_e).  Moving the origin maps the 14 quantities by a constant invertible matrix (the
extra terms of ``(p.p) l - 2 (p.l) p`` recombine as ``t x (p x l)``), so this holds in any frame.
Because the functions are exactly trigonometric of degree one per joint, their coefficients are
computed by interpolation on the grid {0, 2 pi / 3, 4 pi / 3} per joint: 27 points for the left side
(robot constants, once per robot) and 9 for the right side (per target).  This is

    A(th_c) u(th_d, th_e)  =  B m(th_a, th_b),        A: 14 x 9, linear in (1, c_c, s_c);  B: 14 x 8

(the constant column of the right side moved to the left).

**3. Eliminate a, b.**  The 6 left null vectors ``N`` of B (its SVD) give ``N^T A(th_c) u = 0``: six
equations in the 9 products of (1, c_d, s_d) and (1, c_e, s_e).  The tangent half-angles ``x = tan(th /
2)`` turn them into polynomials: 6 equations in the monomials ``x_d^i x_e^j`` (i, j <= 2) with
coefficients quadratic in ``x_c``; multiplied by ``x_d`` they give 6 more, 12 equations in the 12
monomials ``x_d^i x_e^j`` (i <= 3, j <= 2): ``(M_0 + M_1 x_c + M_2 x_c^2) v = 0``.

**4. Eigenproblem.**  ``det(M(x_c)) = 0`` has degree 24: the 16 solutions and 8 spurious roots at
``x_c = +-i`` (they come from the half-angle factors).  It is the 24 x 24 companion eigenproblem
``[[0, I], [-L^-1 M_0, -L^-1 M_1]]`` with ``L = M_2``.  ``L`` is singular exactly when ``th_c = pi``
solves the pose; so the elimination joint is shifted, ``th_c = phi + delta``, with ``delta`` chosen per
target among fixed values so that ``L`` is well conditioned (a Moebius change of the variable ``x_c``).
Eigenvalues whose angle ``delta + 2 atan(y)`` has an imaginary part above ``IMAG_TOL`` are dropped
(the spurious ``y = +-i`` and genuinely complex roots); near-real ones are kept as candidates.

**5. Back-substitution.**  The eigenvector holds ``x_d^i x_e^j``: ``th_d = 2 atan2(x_d^(i+1) x_e^j,
x_d^i x_e^j)`` read from the pair of largest magnitude (valid at ``x_d = inf``), likewise ``th_e``;
then ``m = B^+ A(th_c) u`` gives (c_a, s_a) and (c_b, s_b) from its rank-one structure, and ``th_f``
from the remaining rotation about ``w_f``.

**6. Polish.**  Every candidate gets Newton steps on the true robot (all six joints) until the pose
error is at most ``1e-12`` of the robot size (position) and ``1e-12`` (rotation, Frobenius); candidates
that do not get there (near-real complex roots) are dropped, duplicates (double roots, a root found
twice) merged.  Unreachable poses give no rows and ``reachable`` False.

**Prismatic joints.**  A prismatic joint at position a or b enters the right side polynomially: its
displacement d (over the robot size) in ``p`` linearly and in ``p.p``, ``(p.p) l - 2 (p.l) p``
quadratically, so its basis (1, cos, sin) becomes (1, d, d^2), interpolated on d in {-1, 0, 1}, and
steps 3-6 stand.  Products of the (a, b) basis that never occur are structurally zero columns of B';
they are dropped (found once per arrangement), and a, b are read from the products of each alone
(``d = a_1 / a_0``).  On the left side a prismatic joint may sit at d or e (c is the eigenvalue's
half-angle; f's axis point must stay fixed): the same (1, d, d^2) basis on its grid, the identity as its
basis-to-monomial map, d read as a ratio of monomials.  With a prismatic joint on each side of the split
the 12 x 12 pencil is singular for every x_c (the 6 equations' d^2 terms span one dimension): the
deflated 9 x 9 pencil of :func:`_deflated` replaces it.  Adjacent prismatic d and e: refused.

**Special geometry.**  Parallel or intersecting axes can make B lose rank or the pencil M singular
(``det M(x) == 0`` for every x).  :func:`prepare` tries the arrangements (the joint order forward, and
reversed, i.e. the inverse chain ``X_6^-1 ... X_1^-1 = G^-1``) on sample poses and keeps the first whose
pencil is regular and which recovers every sampled joint vector; otherwise it raises
:class:`General6Error`.

>>> import numpy as np
>>> rng = np.random.default_rng(1)
>>> w = rng.normal(size=(6, 3)); w /= np.linalg.norm(w, axis=1, keepdims=True)
>>> r = rng.uniform(-0.5, 0.5, size=(6, 3))
>>> twists = np.concatenate([-np.cross(w, r), w], axis=1)
>>> g6 = prepare(twists, np.eye(4))
>>> q = np.array([0.3, -1.2, 2.0, 0.4, -0.7, 2.9])
>>> rows = g6.solve(g6.fk(q))
>>> bool(np.abs(np.angle(np.exp(1j * (rows - q)))).max(axis=1).min() < 1e-9)
True
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from subproblems import tolerances as _tol
from subproblems.core import SubproblemError, SubproblemInputError
from subproblems.screw import cross as _cross
from subproblems.screw import inverse_transform as _inv

__all__ = ["General6", "General6Error", "Batch", "prepare", "solve", "solve_batch", "MAX_SOLUTIONS"]

MAX_SOLUTIONS = 16
IMAG_TOL = _tol.G6_IMAG_TOL  # |imaginary part| of a candidate angle kept for Newton (near-real roots)
NEAR_REAL = _tol.G6_NEAR_REAL  # a kept candidate with a larger imaginary part makes its target doubtful
EXACT = _tol.PRECISION  # accepted pose error: position / size and rotation (Frobenius)
NEWTON_ITERS = 6
SAME = _tol.VERIFY_SAME_ANGLE  # polished rows closer than this (rad, max over joints) are one solution
SHIFTS = (0.6180339887498949, 2.0943951023931953, -1.3089969389957472, 2.6179938779914944)
TWIN = 1e-6  # roots of one target closer than this (rad): read as a double eigenvalue's two solutions
LEADING_OK = _tol.G6_LEADING_OK  # |det L| / prod(row norms of L) above which L is used as is
RANK = _tol.G6_RANK  # B' loses rank below this singular value ratio: doubtful
STALLED = _tol.G6_STALLED  # a candidate missing by less after Newton (of the size) stalled: doubtful

_GRID = np.array([0.0, 2 * math.pi / 3, 4 * math.pi / 3])
_PHI = np.stack([np.ones(3), np.cos(_GRID), np.sin(_GRID)], axis=1)  # PHI[p, t] = b_t(grid_p)
_INV3 = np.linalg.inv(_PHI)
_INV9 = np.linalg.inv(np.kron(_PHI, _PHI))
_INV27 = np.linalg.inv(np.kron(np.kron(_PHI, _PHI), _PHI))
# A prismatic joint on the right side (position a or b): its displacement d (normalised) enters the 14
# quantities as a polynomial of degree <= 2 (p linear, p.p and (p.p) l - 2 (p.l) p quadratic), so the
# basis (1, cos, sin) becomes (1, d, d^2), interpolated on d in {-1, 0, 1}: the same 3 coefficients.
_GRID_T = np.array([-1.0, 0.0, 1.0])
_PHI_T = np.stack([np.ones(3), _GRID_T, _GRID_T**2], axis=1)
# (1, cos, sin) times (1 + x^2) in powers of x = tan(th / 2): rows t, columns power
_HALF = np.array([[1.0, 0.0, 1.0], [1.0, 0.0, -1.0], [0.0, 2.0, 0.0]])


class General6Error(SubproblemError):
    """The elimination does not apply: not six revolute joints, or its matrices degenerate."""


@dataclass(frozen=True)
class Batch:
    """Solutions of N targets: Q (N, 16, 6) joint values in (-pi, pi], valid (N, 16), residual (N, 16)
    (pose error relative to the size, recomputed by forward kinematics), reachable (N,), singular (N, 16):
    the row is an exact solution at a (nearly) singular configuration, a near-double root (smallest over
    largest singular value of its Jacobian, lengths over the size, below ``VERIFY_SINGULAR``)."""

    Q: np.ndarray
    valid: np.ndarray
    residual: np.ndarray
    reachable: np.ndarray
    singular: np.ndarray | None = None


# ----------------------------------------------------------------------------------------------- rigid
def _rodrigues(w, th):
    """Rotations (..., 3, 3) about unit axes w (..., 3) by th (...): c I + s [w] + (1 - c) w w^T."""
    w = np.asarray(w, dtype=float)
    th = np.asarray(th, dtype=float)
    s, c = np.sin(th)[..., None], np.cos(th)[..., None]
    x, y, z = w[..., 0:1], w[..., 1:2], w[..., 2:3]
    v = 1 - c
    R = np.concatenate([
        c + v * x * x, v * x * y - s * z, v * x * z + s * y,
        v * x * y + s * z, c + v * y * y, v * y * z - s * x,
        v * x * z - s * y, v * y * z + s * x, c + v * z * z,
    ], axis=-1)
    return R.reshape(R.shape[:-1] + (3, 3))


def _joint_exp(w, r, th, prism: bool):
    """Joint transforms (..., 4, 4): a rotation by th about the line (r, w), or for a prismatic joint
    a translation by th along w."""
    if not prism:
        return _exp(w, r, th)
    th = np.asarray(th, dtype=float)
    w = np.asarray(w, dtype=float)
    g = np.zeros(np.broadcast_shapes(w.shape[:-1], th.shape) + (4, 4))
    g[..., 0, 0] = g[..., 1, 1] = g[..., 2, 2] = g[..., 3, 3] = 1.0
    g[..., :3, 3] = w * th[..., None]
    return g


def _exp(w, r, th):
    """Transforms (..., 4, 4) of rotations by th about the lines (point r, direction w)."""
    R = _rodrigues(w, th)
    g = np.zeros(R.shape[:-2] + (4, 4))
    g[..., :3, :3] = R
    g[..., :3, 3] = r - (R @ np.asarray(r, dtype=float)[..., None])[..., 0]
    g[..., 3, 3] = 1.0
    return g


def _hats(w, r):
    """The 4 x 4 twist matrices H1 = [[w^], -w x r], [0]] and H2 = H1 @ H1 of unit axes (..., 3): a
    revolute twist of pitch 0 has H1^3 = -H1, so exp(H1 th) = I + sin(th) H1 + (1 - cos(th)) H2."""
    w, r = np.broadcast_arrays(np.asarray(w, dtype=float), np.asarray(r, dtype=float))
    H1 = np.zeros(w.shape[:-1] + (4, 4))
    H1[..., 0, 1], H1[..., 0, 2], H1[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    H1[..., 1, 0], H1[..., 2, 0], H1[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    H1[..., :3, 3] = -_cross(w, r)
    return H1, H1 @ H1


def _hat_list(w, r, prism):
    """[(H1, H2, prismatic)] of each of the axes (6, 3); a prismatic joint's H1 = [[0, w], [0]]."""
    H1, H2 = _hats(w, r)
    out = []
    for i in range(len(H1)):
        if prism[i]:
            h = np.zeros((4, 4))
            h[:3, 3] = w[i]
            out.append((h, np.zeros((4, 4)), True))
        else:
            out.append((H1[i], H2[i], False))
    return out


_EYE4 = np.eye(4)


def _exp_h(H, th):
    """exp(H1 th) for the twist matrices H = (H1, H2, prismatic) of :func:`_hat_list`, values th (...)."""
    th = np.asarray(th, dtype=float)[..., None, None]
    if H[2]:
        return _EYE4 + th * H[0]
    return _EYE4 + np.sin(th) * H[0] + (1 - np.cos(th)) * H[1]


def _fourteen(p, l):
    """The 14 Raghavan-Roth quantities of a point p and direction l (..., 3) -> (..., 14)."""
    pp = np.einsum("...i,...i->...", p, p)[..., None]
    pl = np.einsum("...i,...i->...", p, l)[..., None]
    return np.concatenate([p, l, pp, pl, _cross(p, l), pp * l - 2 * pl * p], axis=-1)


# ----------------------------------------------------------------------------------------- arrangement
@dataclass(frozen=True)
class _Arrangement:
    """One joint order for the elimination, in normalised coordinates (origin at the axes' centroid,
    lengths divided by the robot size)."""

    order: tuple[int, ...]  # original joint index at each position a..f
    sign: float  # +1: the chain as given; -1: its inverse (twists negated, target inverted)
    conj: int  # the first `conj` joints are moved ahead of the rest: their axes are mapped by the target
    w: np.ndarray  # (6, 3) axis directions in arrangement order
    r: np.ndarray  # (6, 3) axis points
    A: np.ndarray  # (14, 3, 9) left side: quantity, (1, c_c, s_c), (1,c_d,s_d) x (1,c_e,s_e)
    E: np.ndarray  # (9, 4, 4) X_b^-1 X_a^-1 on the (a, b) grid
    u: np.ndarray  # unit vector normal to w_f (reads th_f)
    H: tuple  # per axis in arrangement order, its twist matrices (H1, H2, prismatic) (see _hat_list)
    prism: tuple  # (6,) bool in arrangement order; prismatic joints at a, b, d, e (c and f revolute)
    inv9: np.ndarray  # (9, 9) interpolation of the right side on the (a, b) grid
    grid_ab: np.ndarray  # (9, 2) the (a, b) grid values
    half9: np.ndarray  # (9, 9) (d, e) basis products -> monomials x_d^i x_e^j (i * 3 + j)
    cols: tuple = tuple(range(8))  # columns of B' (non-constant (a, b) monomials) present in the equations
    swap: bool = False  # the equations are multiplied by x_e instead of x_d (monomials x_e^i x_d^j)
    deflate: int | None = None  # rank of the multiplier's squared block: the 9 x 9 deflated pencil is used


def _arrangement_order(sign, conj) -> list[int]:
    base = list(range(6)) if sign > 0 else list(range(5, -1, -1))
    return base[6 - conj:] + base[:6 - conj]


def _arrangement(w, r, sign, conj, prism) -> _Arrangement:
    """Joint order: the chain (sign +1) or its inverse (-1), its last ``conj`` joints moved ahead.
    Prismatic joints must land on the right side (positions a, b)."""
    order = _arrangement_order(sign, conj)
    w = sign * w[list(order)]
    r = r[list(order)]
    prism = tuple(bool(prism[i]) for i in order)
    assert not (prism[2] or prism[5]), "the eliminated joint c and the last joint f must be revolute"
    # a prismatic d or e: its basis (1, cos, sin) becomes (1, d, d^2) on the grid {-1, 0, 1}, as on the
    # right side; c and f stay revolute (c is the eigenvalue's half-angle, f's axis point must be fixed)
    gd, ge = (_GRID_T if prism[3] else _GRID), (_GRID_T if prism[4] else _GRID)
    th = np.stack(np.meshgrid(_GRID, gd, ge, indexing="ij"), axis=-1).reshape(27, 3)
    X = (_exp(w[2], r[2], th[:, 0]) @ _joint_exp(w[3], r[3], th[:, 1], prism[3])
         @ _joint_exp(w[4], r[4], th[:, 2], prism[4]))
    p = np.einsum("kij,j->ki", X[:, :3, :3], r[5]) + X[:, :3, 3]
    lv = X[:, :3, :3] @ w[5]
    inv27 = _INV27 if not (prism[3] or prism[4]) else np.linalg.inv(
        np.kron(np.kron(_PHI, _PHI_T if prism[3] else _PHI), _PHI_T if prism[4] else _PHI))
    A = (inv27 @ _fourteen(p, lv)).T.reshape(14, 3, 9)
    ga, gb = (_GRID_T if prism[0] else _GRID), (_GRID_T if prism[1] else _GRID)
    ab = np.stack(np.meshgrid(ga, gb, indexing="ij"), axis=-1).reshape(9, 2)
    inv9 = np.linalg.inv(np.kron(_PHI_T if prism[0] else _PHI, _PHI_T if prism[1] else _PHI))
    E = _inv(_joint_exp(w[1], r[1], ab[:, 1], prism[1])) @ _inv(_joint_exp(w[0], r[0], ab[:, 0], prism[0]))
    u = np.cross(w[5], np.eye(3)[np.argmin(np.abs(w[5]))])
    # basis of d and e -> monomials: (1, cos, sin) (1 + x^2) in powers of x = tan(th / 2), or for a
    # prismatic joint (1, d, d^2), already monomials
    half9 = np.kron(np.eye(3) if prism[3] else _HALF, np.eye(3) if prism[4] else _HALF)
    return _Arrangement(tuple(order), sign, conj, w, r, A, E, u / np.linalg.norm(u), _hat_list(w, r, prism),
                        prism, inv9, ab, half9)


def _axes(arr: _Arrangement, H):
    """Axes (N, 6, 3) directions and points of the arrangement for targets H (N, 4, 4) of its chain:
    a joint moved ahead of the others, ``X_j -> H X_j H^-1``, has its axis mapped by H."""
    N = len(H)
    W = np.broadcast_to(arr.w, (N, 6, 3)).copy()
    R = np.broadcast_to(arr.r, (N, 6, 3)).copy()
    for k in range(arr.conj):
        W[:, k] = H[:, :3, :3] @ arr.w[k]
        R[:, k] = np.einsum("nij,j->ni", H[:, :3, :3], arr.r[k]) + H[:, :3, 3]
    return W, R


def _grid_ab(arr: _Arrangement, W, R):
    """X_b^-1 X_a^-1 (N, 9, 4, 4) on the (a, b) interpolation grid for per-target axes."""
    ab = arr.grid_ab
    Xb = _joint_exp(W[:, None, 1], R[:, None, 1], ab[None, :, 1], arr.prism[1])
    Xa = _joint_exp(W[:, None, 0], R[:, None, 0], ab[None, :, 0], arr.prism[0])
    return _inv(Xb) @ _inv(Xa)


class _Arrangements:
    """The arrangements of a revolute chain, each built when first read (indexable as the list is)."""

    def __init__(self, make, count: int):
        self._make, self._count, self._built = make, count, {}

    def __getitem__(self, k: int) -> _Arrangement:
        if k not in self._built:
            self._built[k] = self._make(k)
        return self._built[k]

    def __len__(self) -> int:
        return self._count

    def __iter__(self):
        return (self[k] for k in range(self._count))


class General6:
    """A prepared general 6R solver for one robot; see the module docstring.

    ``solve(T)`` -> (k, 6) exact solutions; ``solve_batch(Ts)`` -> :class:`Batch`; ``fk(q)`` -> 4x4.
    """

    def __init__(self, twists, home, scale: float | None = None, arrangement=None):
        """``arrangement``: None (choose on sample poses, ~0.1 s), or the index or list of indices of
        the arrangements to use, in order (``General6(...).usable`` of an earlier instance)."""
        tw = np.asarray(twists, dtype=float)
        if tw.shape != (6, 6) or not np.all(np.isfinite(tw)):
            raise SubproblemInputError(f"general6 needs 6 finite twists (6, 6); got shape {tw.shape}")
        nw = np.linalg.norm(tw[:, 3:], axis=1)
        self.prism = nw < _tol.G6_PRISMATIC_AXIS  # w = 0: a prismatic joint, its direction in v
        if np.any(self.prism & (np.linalg.norm(tw[:, :3], axis=1) < _tol.G6_PRISMATIC_AXIS)):
            k = int(np.argmax(self.prism & (np.linalg.norm(tw[:, :3], axis=1) < _tol.G6_PRISMATIC_AXIS)))
            raise SubproblemInputError(f"general6: joint {k + 1} has a zero twist")
        w = np.where(self.prism[:, None], tw[:, :3], tw[:, 3:])  # rotation axis, or translation direction
        w = w / np.linalg.norm(w, axis=1, keepdims=True)
        r = np.where(self.prism[:, None], 0.0, np.cross(w, tw[:, :3]))  # the foot of each axis nearest 0
        self.home = np.asarray(home, dtype=float)
        rev = ~self.prism
        self.center = r[rev].mean(axis=0) if rev.any() else np.zeros(3)
        size = float(np.max(np.linalg.norm(np.vstack([r[rev], self.home[:3, 3]]) - self.center, axis=1)))
        self.scale = float(scale) if scale else max(size, 1e-9)
        self._s = max(size, 1e-9)  # internal normalisation length (prismatic values are divided by it)
        self.w = w
        self.r = np.where(self.prism[:, None], 0.0, (r - self.center) / self._s)
        self.Mn = self._norm(self.home[None])[0]
        self._H = _hat_list(self.w, self.r, self.prism)
        # arrangements whose eliminated joint c and last joint f are revolute (prismatic at a, b, d, e);
        # given the arrangements to use (a generated module), only those are built
        wanted = None if arrangement is None else {int(k) for k in np.atleast_1d(arrangement)}
        layouts = [(sign, conj) for conj in range(3) for sign in (1.0, -1.0)]
        if wanted is not None and not self.prism.any():
            # given arrangements of a revolute chain: each built on first use (~2 ms each; a chain
            # folded at a new free value, runtime/freefold.py, mostly needs only the first)
            self._arr = _Arrangements(lambda k: _arrangement(self.w, self.r, *layouts[k], self.prism),
                                      len(layouts))
        else:
            self._arr = [_arrangement(self.w, self.r, sign, conj, self.prism)
                         if not self.prism[[_arrangement_order(sign, conj)[k] for k in (2, 5)]].any()
                         and (wanted is None or k in wanted) else None
                         for k, (sign, conj) in enumerate(layouts)]
        if self.prism.any():
            Gn = self._probe_targets()  # one draw for every arrangement's structural measurements
            self._arr = [self._present_columns(a, Gn) if a is not None else None for a in self._arr]
            self._arr = [self._regular_variant(a, Gn) if a is not None else None for a in self._arr]
        if isinstance(self._arr, list) and all(a is None for a in self._arr):
            k = int(np.nonzero(self.prism)[0][0])
            raise General6Error(
                f"general6: joint {k + 1} is prismatic and no joint order of the chain or of a rotated or "
                "inverted copy has a revolute joint at both the eliminated position (c) and the last (f): "
                "use the compiler's search fallback"
            )
        if arrangement is None:
            self.usable = [0]
            self.usable = self._choose()
        else:
            self.usable = [int(k) for k in np.atleast_1d(arrangement)]
        self.arrangement = self.usable[0]

    def _adjacent_prismatic(self) -> str:
        """The known gap, named (docs/general6.md "Known gaps"): where every arrangement with revolute
        c and f puts prismatic joints at both d and e (adjacent prismatic joints in the middle, RRTTRR,
        RTTRRR, RRRTTR), those joints and why; else ''."""
        pairs = {tuple(sorted((a.order[3] + 1, a.order[4] + 1))) for a in self._arr if a is not None}
        if not pairs or not all(a.prism[3] and a.prism[4] for a in self._arr if a is not None):
            return ""
        named = " / ".join(f"joints {i} and {j}" for i, j in sorted(pairs))
        return (f"{named} are adjacent prismatic joints that every joint order with revolute eliminated "
                "and last joints puts at positions d and e, where the 12 x 12 pencil is singular for "
                "every value (no deflation covers two there; a known gap); ")

    def _singular(self, arr: _Arrangement, Gn) -> bool:
        """Whether the arrangement's pencil is singular for every x (median over the targets Gn)."""
        _, _, C, _ = self._pencil(arr, Gn)
        M = self._matrices(C, np.full(len(Gn), SHIFTS[0]), arr)
        x = 0.37  # any value that is not a root: a singular pencil is singular everywhere
        sv = np.linalg.svd(M[:, 0] + x * M[:, 1] + x * x * M[:, 2], compute_uv=False)
        ratio = np.divide(sv[:, -1], sv[:, 0], out=np.zeros(len(Gn)), where=sv[:, 0] > 0)  # 0 / 0: singular
        return bool(np.median(ratio) < _tol.G6_SINGULAR_PENCIL)

    def _probe_targets(self, count: int = 8, seed: int = 21):
        """Normalised goals Gn (count, 4, 4) of random joint vectors (fixed seed): what the structural
        choices of a prismatic robot's arrangements are measured on, the same for every instance."""
        rng = np.random.default_rng(seed)
        Q = rng.uniform(-math.pi, math.pi, size=(count, 6))
        Q[:, self.prism] /= math.pi
        return self._fk_norm(Q) @ _inv(self.Mn)

    def _regular_variant(self, arr: _Arrangement, Gn) -> _Arrangement:
        """The arrangement, or where a prismatic d or e makes its 12 x 12 pencil singular, the deflated
        9 x 9 pencil multiplied by that joint (:func:`_deflated`) when that one is regular (measured on
        the probe targets Gn, so the choice is the same for every instance of the robot)."""
        if not (arr.prism[3] or arr.prism[4]):
            return arr
        count = len(Gn)
        if not self._singular(arr, Gn):
            return arr
        for swap in (False, True):
            if not arr.prism[4 if swap else 3]:
                continue
            _, _, C, _ = self._pencil(arr, Gn)
            P = self._powers(C, np.full(count, SHIFTS[0]), dataclasses.replace(arr, swap=swap))
            sv = np.linalg.svd(_squared_block(P), compute_uv=False)
            rank = int(np.max((sv > 1e-9 * sv[:, :1]).sum(axis=1)))
            if rank >= 3:
                continue
            variant = dataclasses.replace(arr, swap=swap, deflate=rank)
            if not self._singular(variant, Gn):
                return variant
        return arr

    def _present_columns(self, arr: _Arrangement, Gn):
        """The arrangement with B's structurally zero columns dropped (measured on the probe targets
        Gn), or None when an entry the back-substitution reads (a alone, b alone) is among them."""
        count = len(Gn)
        Gn = Gn if arr.sign > 0 else _inv(Gn)
        y = np.einsum("nij,j->ni", Gn[:, :3, :3], arr.r[5]) + Gn[:, :3, 3]
        m = Gn[:, :3, :3] @ arr.w[5]
        E = _grid_ab(arr, *_axes(arr, Gn)) if arr.conj else np.broadcast_to(arr.E, (count, 9, 4, 4))
        p = np.einsum("nkij,nj->nki", E[..., :3, :3], y) + E[..., :3, 3]
        lv = np.einsum("nkij,nj->nki", E[..., :3, :3], m)
        B = np.einsum("kq,nqj->nkj", arr.inv9, _fourteen(p, lv))  # (N, 9 monomials, 14)
        size = np.linalg.norm(B, axis=2).max(axis=0)  # per monomial (a_t b_u at t * 3 + u)
        present = size[1:] > _tol.G6_ABSENT_COLUMN * size.max()
        if not all(present[k - 1] for k in (1, 2, 3, 6)):  # a_0 b_1, a_0 b_2, a_1 b_0, a_2 b_0
            return None
        return dataclasses.replace(arr, cols=tuple(int(k) for k in np.nonzero(present)[0]))

    # --------------------------------------------------------------------------------- kinematics
    def fk(self, q) -> np.ndarray:
        """Tool pose(s) of joint values q (6,) or (M, 6)."""
        q = np.asarray(q, dtype=float)
        g = self._fk_norm(q.reshape(-1, 6) / np.where(self.prism, self._s, 1.0))
        out = g.copy()
        out[:, :3, 3] = g[:, :3, 3] * self._s + self.center
        return out.reshape(q.shape[:-1] + (4, 4))

    def _fk_norm(self, Q):
        g = np.broadcast_to(np.eye(4), (len(Q), 4, 4))
        for i in range(6):
            g = g @ _exp_h(self._H[i], Q[:, i])
        return g @ self.Mn

    def _norm(self, T):
        """Tool poses (N, 4, 4) in normalised coordinates (origin at the centroid, lengths / size)."""
        out = T.copy()
        out[:, :3, 3] = (T[:, :3, 3] - self.center) / self._s
        return out

    def _error(self, g, Tn):
        """Pose error of normalised tool poses: max(position / size, Frobenius rotation)."""
        dp = np.linalg.norm(g[:, :3, 3] - Tn[:, :3, 3], axis=1) * (self._s / self.scale)
        dR = np.linalg.norm(g[:, :3, :3] - Tn[:, :3, :3], axis=(1, 2))
        return np.maximum(dp, dR)

    # ------------------------------------------------------------------------------ elimination
    def _pencil(self, arr: _Arrangement, Gn):
        """Per target: B's constant column (N, 14), pinv(B') (N, 8, 14), C (N, 6, 3, 9), B' rank ratio."""
        Gn = Gn if arr.sign > 0 else _inv(Gn)
        y = np.einsum("nij,j->ni", Gn[:, :3, :3], arr.r[5]) + Gn[:, :3, 3]
        m = Gn[:, :3, :3] @ arr.w[5]
        if arr.conj:
            E = _grid_ab(arr, *_axes(arr, Gn))
            p = np.einsum("nkij,nj->nki", E[..., :3, :3], y) + E[..., :3, 3]
            lv = np.einsum("nkij,nj->nki", E[..., :3, :3], m)
        else:
            p = np.einsum("kij,nj->nki", arr.E[:, :3, :3], y) + arr.E[None, :, :3, 3]
            lv = np.einsum("kij,nj->nki", arr.E[:, :3, :3], m)
        B = np.einsum("kq,nqj->nkj", arr.inv9, _fourteen(p, lv))  # (N, 9 coeffs, 14)
        B = np.swapaxes(B, 1, 2)  # (N, 14, 9)
        cols = list(arr.cols)  # a prismatic joint leaves some monomials out: their columns are dropped
        U, s, Vh = np.linalg.svd(B[:, :, 1:][:, :, cols], full_matrices=True)
        Nl = U[:, :, 8:]  # (N, 14, 6): left null vectors (B' has rank <= 8)
        C = np.einsum("nqe,qtj->netj", Nl, arr.A)
        C[:, :, 0, 0] -= np.einsum("nqe,nq->ne", Nl, B[:, :, 0])  # the right side's constant column
        with np.errstate(divide="ignore", invalid="ignore"):
            sinv = np.where(s > _tol.G6_PINV_CUTOFF * s[:, :1], 1.0 / s, 0.0)
        pinv = np.zeros((len(B), 8, 14))
        pinv[:, cols] = np.einsum("nji,nj,nkj->nik", Vh, sinv, U[:, :, :len(cols)])
        return B[:, :, 0], pinv, C, s[:, -1] / s[:, 0]

    @staticmethod
    def _powers(C, delta, arr: _Arrangement):
        """The 6 equations (N, 3 powers of y, 6, 9 monomials) in y = tan((th_c - delta) / 2), monomials
        x_d^i x_e^j at i * 3 + j (x_e^i x_d^j when the arrangement multiplies by x_e)."""
        cd, sd = np.cos(delta)[:, None, None], np.sin(delta)[:, None, None]
        C0, C1, C2 = C[:, :, 0], C[:, :, 1], C[:, :, 2]
        Ct = np.stack([C0, C1 * cd + C2 * sd, C2 * cd - C1 * sd], axis=1)  # (N, 3 trig, 6, 9)
        P = np.einsum("tk,ntej->nkej", _HALF, Ct) @ arr.half9  # (N, 3 powers, 6, 9 monomials)
        if arr.swap:  # the multiplier's power first
            P = P.reshape(P.shape[:3] + (3, 3)).swapaxes(3, 4).reshape(P.shape)
        return P

    @staticmethod
    def _matrices(C, delta, arr: _Arrangement):
        """The 12 x 12 pencil (N, 3, 12, 12) in y = tan((th_c - delta) / 2), or the arrangement's
        deflated 9 x 9 one (:func:`_deflated`)."""
        P = General6._powers(C, delta, arr)
        if arr.deflate is not None:
            return _deflated(P, arr.deflate)
        N = len(C)
        M = np.zeros((N, 3, 12, 12))
        for i in range(3):
            M[:, :, :6, 3 * i:3 * i + 3] = P[:, :, :, 3 * i:3 * i + 3]
            M[:, :, 6:, 3 * i + 3:3 * i + 6] = P[:, :, :, 3 * i:3 * i + 3]
        scale = np.linalg.norm(M, axis=(1, 3), keepdims=True)  # rows of equal weight
        return M / np.where(scale > 0, scale, 1.0)

    def _candidates(self, arr: _Arrangement, Gn):
        """Candidate joint vectors (original order) and their owners from the eigenproblem."""
        N = len(Gn)
        B0, pinv, C, brank = self._pencil(arr, Gn)
        delta = np.full(N, SHIFTS[0])
        M = self._matrices(C, delta, arr)
        good = _leading_ok(M[:, 2])
        for d in SHIFTS[1:]:
            if good.all():
                break
            bad = np.nonzero(~good)[0]
            M2 = self._matrices(C[bad], np.full(len(bad), d), arr)
            ok = _leading_ok(M2[:, 2])
            take = bad[ok]
            M[take], delta[take], good[take] = M2[ok], d, True
        L = M[:, 2]
        n = M.shape[-1]  # 12, or 9 for a deflated pencil
        K = np.zeros((N, 2 * n, 2 * n))
        K[:, :n, n:] = np.eye(n)
        rhs = np.concatenate([M[:, 0], M[:, 1]], axis=2)  # (N, n, 2 n)
        with np.errstate(all="ignore"):
            K[:, n:, :] = -np.linalg.solve(L + (~good)[:, None, None] * 1e-14 * np.eye(n), rhs)
            lam = np.linalg.eigvals(np.nan_to_num(K))
            th_c = delta[:, None] + 2 * np.arctan(lam)
        keep = np.isfinite(th_c) & (np.abs(th_c.imag) < IMAG_TOL)
        # a near-real complex pair: a double root split by rounding (or a genuine pair close to real)
        split = (keep & (np.abs(th_c.imag) > NEAR_REAL)).any(axis=1)
        own, idx = np.nonzero(keep)
        th_c = th_c.real[own, idx]
        # no well-conditioned shift, B' loses rank, or a split double root: ask the other orders too
        doubt = ~good | (brank < RANK) | split
        if not len(own):  # no real root: the pose is unreachable
            return np.zeros((0, 6)), own, doubt
        y = np.tan(0.5 * (th_c - delta[own]))
        v = _null_vectors(M[own], y)
        twin = _twins(own, th_c)
        if twin.any():  # two solutions sharing th_c: both read from the 2-dimensional null space
            idx = np.nonzero(twin)[0]
            v2, pick = _two_monomial_vectors(M[own[idx]], y[idx])
            v, own, th_c = np.concatenate([v, v2]), np.concatenate([own, own[idx[pick]]]), \
                np.concatenate([th_c, th_c[idx[pick]]])
        v = v.reshape(-1, n // 3, 3)
        # v[i, j] = x_d^i x_e^j (x_e^i x_d^j when swapped): the first joint from rows, the other from columns
        first, second = (4, 3) if arr.swap else (3, 4)
        th_1 = _read_ratio(v[:, :-1, :], v[:, 1:, :], arr.prism[first])
        th_2 = _read_ratio(v[:, :, :2], v[:, :, 1:], arr.prism[second])
        th_d, th_e = (th_2, th_1) if arr.swap else (th_1, th_2)
        tc = np.stack([np.ones_like(th_c), np.cos(th_c), np.sin(th_c)], axis=1)
        ud, ue = _basis(th_d, arr.prism[3]), _basis(th_e, arr.prism[4])
        u = (ud[:, :, None] * ue[:, None, :]).reshape(-1, 9)
        rhs = np.einsum("qtj,nt->nqj", arr.A, tc)
        rhs = np.einsum("nqj,nj->nq", rhs, u) - B0[own]
        mab = np.einsum("niq,nq->ni", pinv[own], rhs)
        Kab = np.concatenate([np.ones((len(mab), 1)), mab], axis=1).reshape(-1, 3, 3)
        # rank one: Kab = a b^T, a = (1, c_a, s_a) or (1, d_a, d_a^2) up to scale, likewise b
        a0, a1, a2 = (np.einsum("ni,ni->n", Kab[:, t], Kab[:, 0]) for t in range(3))
        b0, b1, b2 = (np.einsum("ni,ni->n", Kab[:, :, t], Kab[:, :, 0]) for t in range(3))
        if arr.prism[0] or arr.prism[1]:
            # some products are absent from the equations (their entries of Kab are not solved for):
            # each joint from the entries of it alone, column 0 for a, row 0 for b (present by
            # construction: the arrangement is refused otherwise)
            a1, a2, b1, b2 = Kab[:, 1, 0], Kab[:, 2, 0], Kab[:, 0, 1], Kab[:, 0, 2]
            a0 = b0 = 1.0
        with np.errstate(all="ignore"):
            th_a = a1 / a0 if arr.prism[0] else np.arctan2(a2, a1)
            th_b = b1 / b0 if arr.prism[1] else np.arctan2(b2, b1)
        th = np.stack([th_a, th_b, th_c, th_d, th_e], axis=1)
        Gk = Gn[own] if arr.sign > 0 else _inv(Gn[own])
        W, R = _axes(arr, Gk) if arr.conj else (arr.w[None], arr.r[None])
        X = np.broadcast_to(np.eye(4), (len(th), 4, 4))
        for k in range(5):
            moved = k < arr.conj  # an axis mapped by the target: per-target twist
            X = X @ (_joint_exp(W[:, k], R[:, k], th[:, k], arr.prism[k]) if moved
                     else _exp_h(arr.H[k], th[:, k]))
        Rf = np.swapaxes(X[:, :3, :3], 1, 2) @ Gk[:, :3, :3]
        Ru = Rf @ arr.u
        th_f = np.arctan2(_cross(arr.u, Ru) @ arr.w[5], Ru @ arr.u)
        th = np.concatenate([th, th_f[:, None]], axis=1)
        Q = np.empty_like(th)
        Q[:, list(arr.order)] = th
        return Q, own, doubt

    # ----------------------------------------------------------------------------------- polish
    def _newton(self, Q, Gn, iters=NEWTON_ITERS):
        """Newton steps on all six joints toward normalised targets; returns (best Q, its error).

        Near a singular configuration (a double root) the plain step is amplified by the tiny singular
        value; those rows take the truncated least-squares step instead, and every row keeps the best
        iterate it met."""
        Q = Q.copy()
        best, best_err = Q.copy(), np.full(len(Q), np.inf)
        active = np.ones(len(Q), dtype=bool)
        for it in range(iters + 1):
            idx = np.nonzero(active)[0]
            if not len(idx):
                break
            g, J = self._jacobian(Q[idx])
            err = self._error(g, Gn[idx])
            better = err < best_err[idx]
            best[idx[better]], best_err[idx[better]] = Q[idx[better]], err[better]
            done = err <= 0.05 * EXACT
            active[idx[done]] = False
            if it == iters:
                break
            idx, g, J = idx[~done], g[~done], J[~done]
            T = Gn[idx]
            e_pos = T[:, :3, 3] - g[:, :3, 3]
            Rt, Tt = np.swapaxes(g[:, :3, :3], 1, 2), np.swapaxes(T[:, :3, :3], 1, 2)
            e_rot = 0.5 * _cross(Rt, Tt).sum(axis=1)
            e = np.concatenate([e_pos, e_rot], axis=1)
            with np.errstate(all="ignore"):
                try:
                    dq = np.linalg.solve(J, e[..., None])[..., 0]
                except np.linalg.LinAlgError:  # an exactly singular Jacobian somewhere
                    dq = np.full(e.shape, np.inf)
                size = np.abs(e).max(axis=1)
                wild = ~np.isfinite(dq).all(axis=1) | (np.abs(dq).max(axis=1) > 1e3 * size + 1e-3)
                if wild.any():
                    pinv = np.linalg.pinv(J[wild], rcond=_tol.G6_PINV_RCOND)
                    dq[wild] = np.einsum("nij,nj->ni", pinv, e[wild])
            step = np.abs(dq).max(axis=1)
            dq *= np.minimum(1.0, 0.5 / np.maximum(step, _tol.TINY))[:, None]  # a far candidate: bounded
            Q[idx] += np.nan_to_num(dq)
        return best, best_err

    def _jacobian(self, Q):
        """Tool poses (normalised) and the space Jacobian of the tool origin and rotation (M, 6, 6)."""
        g = np.broadcast_to(np.eye(4), (len(Q), 4, 4))
        W, V = np.zeros((len(Q), 6, 3)), np.zeros((len(Q), 6, 3))
        for i in range(6):
            if self.prism[i]:  # a translation along the moved direction: (v, w) = (R w_i, 0)
                V[:, i] = g[:, :3, :3] @ self.w[i]
                g = g @ _exp_h(self._H[i], Q[:, i])
                continue
            W[:, i] = g[:, :3, :3] @ self.w[i]
            r = np.einsum("nij,j->ni", g[:, :3, :3], self.r[i]) + g[:, :3, 3]
            V[:, i] = _cross(r, W[:, i])  # v = -w x r of the moved axis
            g = g @ _exp_h(self._H[i], Q[:, i])
        g = g @ self.Mn
        V += _cross(W, g[:, None, :3, 3])  # velocity of the tool origin: v + w x p
        return g, np.concatenate([V, W], axis=2).transpose(0, 2, 1)

    # ------------------------------------------------------------------------------------ solve
    def _solve_norm(self, Tn, arrangement=None):
        """Solutions of normalised targets.

        The preferred arrangement first.  A target is *doubtful* when no shift gave a well-conditioned
        leading matrix, B' lost rank, or a candidate stalled short of exact (the sign of a double root,
        where eigenvectors are poorly determined); doubtful targets are re-solved with the other usable
        arrangements in turn until one solves them cleanly, and those doubtful under every arrangement
        with two slightly rotated copies of the target (a double root splits, a degenerate pencil
        becomes regular); every candidate, pooled, is polished toward the true target: Newton and the
        final check decide."""
        N = len(Tn)
        Gn = Tn @ _inv(self.Mn)
        order = self.usable if arrangement is None else [arrangement]
        Qc, own, doubt = self._candidates(self._arr[order[0]], Gn)
        Qc, err = self._newton(Qc, Tn[own])
        stalled = np.zeros(N, dtype=bool)
        stalled[own[(err > EXACT) & (err < STALLED)]] = True
        todo = np.nonzero(doubt | stalled)[0]
        if len(todo) and arrangement is None:
            Qs, owns, errs = [Qc], [own], [err]
            # the other orders one at a time: a target leaves the doubtful set at the first order that
            # solves it cleanly (the same trust as a clean first order); on abb_irb140's plain order this
            # cut the doubtful path from 10 eigenproblems a target to ~2
            for k in order[1:]:
                if not len(todo):
                    break
                Qk, ok_, dk = self._candidates(self._arr[k], Gn[todo])
                Qk, ek = self._newton(Qk, Tn[todo[ok_]], iters=3 * NEWTON_ITERS)
                dk[ok_[(ek > EXACT) & (ek < STALLED)]] = True
                Qs.append(Qk), owns.append(todo[ok_]), errs.append(ek)
                todo = todo[dk]
            # still doubtful under every order (a double root, a degenerate pencil): two copies of the
            # target rotated by 1e-4 rad, whose candidates are polished toward the true target
            for i in range(2 if len(todo) else 0):
                R = _exp(_PERTURB[i], np.zeros(3), 1e-4)[None]
                for k in order[:2]:
                    Qk, ok_, _ = self._candidates(self._arr[k], R @ Gn[todo])
                    Qk, ek = self._newton(Qk, Tn[todo[ok_]], iters=3 * NEWTON_ITERS)
                    Qs.append(Qk), owns.append(todo[ok_]), errs.append(ek)
            Qc, own, err = np.concatenate(Qs), np.concatenate(owns), np.concatenate(errs)
        near = (err > EXACT) & (err < STALLED)  # stalled short of exact: a near-double root's candidates
        if near.any():
            Qn, en = self._undamped(Qc[near], Tn[own[near]])
            Qc, err = Qc.copy(), err.copy()
            Qc[near], err[near] = Qn, en
            err[near] = np.where(self._apart(Qc, own, err, near), err[near], np.inf)
        ok = err <= EXACT
        Qc, own, err = _wrap(Qc[ok], self.prism), own[ok], err[ok]
        b = _pack(Qc, own, err, N, self.prism)
        singular = np.zeros_like(b.valid)
        n, k = np.nonzero(b.valid)
        if len(n):
            sv = np.linalg.svd(self._jacobian(b.Q[n, k])[1], compute_uv=False)
            singular[n, k] = sv[:, -1] < _tol.VERIFY_SINGULAR * sv[:, 0]
        return dataclasses.replace(b, singular=singular)

    def _apart(self, Q, own, err, fresh):
        """Of the rows ``fresh`` (finished by :meth:`_undamped`), which are new solutions (a bool per
        fresh row): exact, farther than ``G6_COLLIDE`` from every other exact row of their target and
        from every better fresh one.  At an exact double root (the Jaco at all-special poses,
        sigma_min / sigma_max 1e-10) the pose error is quadratic in the distance, so plain steps from
        several stalled candidates end 1e-6..4e-5 apart, each exact: one solution, returned once (kept
        apart: 9 rows at one Jaco pose where there is 1)."""
        exact = err <= EXACT
        out = np.zeros(int(fresh.sum()), dtype=bool)
        where = np.nonzero(fresh)[0]
        for t in np.unique(own[fresh & exact]):
            kept = list(np.nonzero((own == t) & exact & ~fresh)[0])
            mine = [k for k in np.nonzero((own == t) & fresh & exact)[0]]
            for k in sorted(mine, key=lambda k: err[k]):
                if not kept or _angle_gap(Q[kept], Q[k], self.prism).max(axis=1).min() > _tol.G6_COLLIDE:
                    out[np.searchsorted(where, k)] = True
                    kept.append(k)
        return out

    def _undamped(self, Q, Tn, iters=_tol.G6_UNDAMPED_STEPS):
        """Plain Gauss-Newton steps (the Jacobian's pseudo-inverse, singular values below
        ``G6_UNDAMPED_RCOND`` of the largest left out; bounded to 0.5) for candidates that
        :meth:`_newton` left above the precision; returns (best Q, its error).

        At a near-double root the Jacobian's weakest singular value is tiny; ``_newton``'s truncated
        step (``G6_PINV_RCOND``) then never moves along it.  reachback.urdf perturbed by 1e-5 at q = (pi,
        0, 0, pi/2, pi, -pi/2) (sigma_min / sigma_max 7e-9): every candidate stalled at 3e-11..6e-9 and the
        target had no row; plain steps from the nearest (2.5e-3 rad away) reach 4e-16 in three.  Plain
        steps may climb before they converge, so none stops for not improving; a row counts only where
        its best iterate is exact (docs/general6.md "The hard cases", "Near-double roots").  The
        doubtful-target decisions are taken before, on ``_newton``'s errors, so no target's arrangements
        change."""
        Q = Q.copy()
        best, best_err = Q.copy(), np.full(len(Q), np.inf)
        live = np.arange(len(Q))
        for it in range(iters + 1):
            g, J = self._jacobian(Q[live])
            err = self._error(g, Tn[live])
            better = err < best_err[live]
            best[live[better]], best_err[live[better]] = Q[live[better]], err[better]
            more = np.isfinite(err) & (err > 0.05 * EXACT)
            live, g, J = live[more], g[more], J[more]
            if it == iters or not len(live):
                break
            T = Tn[live]
            Rt, Tt = np.swapaxes(g[:, :3, :3], 1, 2), np.swapaxes(T[:, :3, :3], 1, 2)
            e = np.concatenate([T[:, :3, 3] - g[:, :3, 3], 0.5 * _cross(Rt, Tt).sum(axis=1)], axis=1)
            with np.errstate(all="ignore"):
                pinv = np.linalg.pinv(np.nan_to_num(J), rcond=_tol.G6_UNDAMPED_RCOND)
                dq = np.einsum("nij,nj->ni", pinv, e)
                step = np.abs(dq).max(axis=1)
                dq *= np.minimum(1.0, 0.5 / np.maximum(step, _tol.TINY))[:, None]
            Q[live] += np.nan_to_num(dq)
        return best, best_err

    def solve_batch(self, Ts) -> Batch:
        """Every solution of N targets (N, 4, 4): a :class:`Batch` of up to 16 rows each."""
        Ts = np.asarray(Ts, dtype=float).reshape(-1, 4, 4)
        if not np.all(np.isfinite(Ts)):
            raise SubproblemInputError("general6: target contains NaN or infinity")
        b = self._solve_norm(self._norm(Ts))
        if self.prism.any():  # normalised displacements back to lengths
            b.Q[..., self.prism] *= self._s
        return b

    def describe(self, k: int, names=None) -> str:
        """One line on arrangement ``k``: its joint order and elimination variable."""
        arr = self._arr[k]
        names = names or [f"joint {i + 1}" for i in range(6)]
        order = ", ".join(names[i] for i in arr.order)
        how = "chain" if arr.sign > 0 else "inverse chain"
        moved = f", {arr.conj} moved ahead" if arr.conj else ""
        return f"#{k} {how} ({order}{moved}; eliminated {names[arr.order[2]]})"

    def rows(self, Ts):
        """The exact solutions of N targets as flat rows: (Q (M, 6), owner (M,) target index)."""
        b = self.solve_batch(Ts)
        n, k = np.nonzero(b.valid)
        return b.Q[n, k], n

    def solve(self, T) -> np.ndarray:
        """Every exact solution (k, 6) of one target 4x4; (0, 6) when the pose is unreachable."""
        b = self.solve_batch(np.asarray(T, dtype=float)[None])
        return b.Q[0][b.valid[0]]

    def _choose(self, count: int = 12, seed: int = 5) -> list[int]:
        """Arrangements whose pencil is regular, those recovering the most sampled joint vectors first,
        then those with the fewest doubtful samples (docs/general6.md, "Doubtful targets": on rtb-data's
        abb_irb140 the plain order leaves 46 of 64 poses doubtful, the best other one 1 of 64).

        ``count`` generic samples and as many with about a third of the joints at 0, +-pi/2 or pi
        (home and taught positions, where orders differ most: on the Jaco at 50% special values one
        usable order misses 12 of 400 sampled vectors and the other 31)."""
        rng = np.random.default_rng(seed)
        Q = rng.uniform(-math.pi, math.pi, size=(2 * count, 6))
        special = rng.random((count, 6)) < 1 / 3
        values = rng.choice([0.0, 0.5 * math.pi, -0.5 * math.pi, math.pi], size=int(special.sum()))
        Q[count:][special] = values
        Q[:, self.prism] /= math.pi  # prismatic: normalised displacements in [-1, 1] (0 and +-1/2 special)
        Tn = self._fk_norm(Q)
        Gn = Tn @ _inv(self.Mn)
        why, found = [], []
        for k, arr in enumerate(self._arr):
            if arr is None:  # a prismatic joint would sit at c or f
                continue
            if self._singular(arr, Gn[:count]):
                kind = "9 x 9 deflated" if arr.deflate is not None else "12 x 12"
                why.append(f"order {_joints(arr)} ({arr.conj} moved ahead): the {kind} pencil is singular")
                continue
            Qc, own, doubt = self._candidates(arr, Gn)
            Qc, err = self._newton(Qc, Tn[own])
            doubt[own[(err > EXACT) & (err < STALLED)]] = True
            ok = err <= EXACT
            b = _pack(_wrap(Qc[ok], self.prism), own[ok], err[ok], 2 * count, self.prism)
            d = np.abs(np.angle(np.exp(1j * (b.Q - Q[:, None, :])))).max(axis=2)
            hit = np.where(b.valid, d, np.inf).min(axis=1) < SAME
            generic, special_hits = int(hit[:count].sum()), int(hit[count:].sum())
            rows = int(b.valid[:count].sum())  # generic samples: special ones may hold double roots
            # more exact rows: fewer missed solutions (an order can recover the sampled vector and miss
            # others: on a RRRRTT arm the inverse order returned 6 of 10); then fewer doubtful samples,
            # which go down the costly re-solve path
            found.append((-(generic + special_hits), -rows, int(doubt.sum()), k, generic))
            why.append(f"order {_joints(arr)} ({arr.conj} moved ahead): recovered {generic} of {count} "
                       "generic "
                       f"and {special_hits} of {count} special-angle samples, {rows} generic rows, "
                       f"{int(doubt.sum())} doubtful")
        if not found or max(f[4] for f in found) < count // 2:
            raise General6Error(
                "general6: " + self._adjacent_prismatic() + "the elimination degenerates on this geometry ("
                + "; ".join(why) + "); the compiler falls back to its search"
            )
        self.why = tuple(why)
        return [f[3] for f in sorted(found)]


def _joints(arr) -> str:
    """An arrangement's joint order as 1-based joint numbers (the messages' and the notes' count)."""
    return "(joints " + ", ".join(str(j + 1) for j in arr.order) + ")"


def _leading_ok(L):
    """Leading matrices far enough from singular: |det| / product of row norms (Hadamard ratio)."""
    sign, logdet = np.linalg.slogdet(L)
    rows = np.log(np.maximum(np.linalg.norm(L, axis=2), _tol.TINY)).sum(axis=1)
    return (sign != 0) & (logdet - rows > math.log(LEADING_OK))


_PROBE = np.random.default_rng(12).normal(size=12)
_MIX = np.random.default_rng(14).normal(size=(9, 12))  # deflated pencil: 9 fixed combinations of its rows


def _squared_block(P):
    """(N, 6 equations, 9): the terms of the 6 equations P (N, 3, 6, 9) in the multiplier's square
    d^2 x^j, over every power of the elimination variable."""
    return P[:, :, :, 6:9].transpose(0, 2, 1, 3).reshape(len(P), 6, 9)


def _deflated(P, rank):
    """The 9 x 9 pencil (N, 3, 9, 9) of a prismatic multiplier joint whose squared block is
    rank-deficient (docs/general6.md, "Prismatic joints").

    With a prismatic joint on each side of the split, the 6 equations' terms in the multiplier's d^2
    span only ``rank`` < 3 dimensions (the displacements enter only p.p and (p.p) l - 2 (p.l) p), so
    multiplying all 6 by d gives d^3 columns that only ``rank`` rows touch: the 12 x 12 pencil is
    singular for every x_c.  Instead: the 6 equations, and d times the 6 - rank combinations of them
    free of d^2 (the left null space of the d^2 block over all powers of x_c), all in the 9 monomials
    d^i x^j (i, j <= 2): 12 - rank equations.  Any true solution satisfies every one, so the
    determinant of 9 fixed combinations of them vanishes at every true x_c (completeness); the extra
    roots it may have are removed by Newton and the final check like any spurious candidate."""
    N = len(P)
    U = np.linalg.svd(_squared_block(P))[0]
    low = np.einsum("nek,npej->npkj", U[:, :, rank:], P)  # (N, 3, 6 - rank, 9): no d^2 terms
    low[..., 6:9] = 0.0
    rows = np.zeros((N, 3, 12 - rank, 9))
    rows[:, :, :6] = P
    rows[:, :, 6:, 3:9] = low[..., 0:6]  # d * (d^i x^j) = d^(i+1) x^j
    M = np.einsum("re,npej->nprj", _MIX[:, :12 - rank], rows)
    scale = np.linalg.norm(M, axis=(1, 3), keepdims=True)
    return M / np.where(scale > 0, scale, 1.0)
_PERTURB = np.random.default_rng(13).normal(size=(2, 3))
_PERTURB /= np.linalg.norm(_PERTURB, axis=1, keepdims=True)


def _null_vectors(M, y):
    """Null vectors (K, n) of the pencils M (K, 3, n, n) at real roots y (K,): two steps of inverse
    iteration; y is moved by ~1e-11 so that an exact root cannot make the factorisation singular."""
    big = np.abs(y) > 1
    yi = np.where(big, 1 / np.where(big, y, 1), y)
    yi = yi + _tol.G6_ROOT_SHIFT * np.where(yi >= 0, 1, -1)
    # |y| <= 1: M0 + y M1 + y^2 M2; |y| > 1 (with yi = 1 / y): yi^2 M0 + yi M1 + M2, the same null vector
    c0 = np.where(big, yi * yi, 1.0)[:, None, None]
    c2 = np.where(big, 1.0, yi * yi)[:, None, None]
    P = c0 * M[:, 0] + yi[:, None, None] * M[:, 1] + c2 * M[:, 2]
    n = M.shape[-1]
    z = np.broadcast_to(_PROBE[:n], (len(y), n))[..., None]
    with np.errstate(all="ignore"):
        for _ in range(2):
            try:
                z = np.linalg.solve(P, z)
            except np.linalg.LinAlgError:  # an exactly singular P in the stack: that one's SVD null vector
                z = _solve_each(P, z)
            z = z / np.maximum(np.abs(z).max(axis=1, keepdims=True), _tol.TINY)
    return np.nan_to_num(z[..., 0])


def _twins(own, th_c):
    """Candidates (K,) with another root of the same target within TWIN of theirs: an eigenvalue of
    geometric multiplicity two, two solutions that share th_c (a modular arm's special poses: RRRRTT
    at q2 = pi has two solutions differing only in q1, q3, q6).  Both members of a pair are read
    (the review asked for one): their roots differ by rounding, and so do their null-space readings;
    reading one lost 2 of 2,294 rows on 400 Jaco poses with half the values special (measured)."""
    order = np.lexsort((th_c, own))
    o, t = own[order], th_c[order]
    close = (o[1:] == o[:-1]) & (np.abs(t[1:] - t[:-1]) < TWIN)
    out = np.zeros(len(own), dtype=bool)
    out[order[1:][close]] = out[order[:-1][close]] = True
    return out


_IDENTITIES: dict = {}


def _identities(rows: int) -> np.ndarray:
    """(K, 4) index quadruples (p, q, r, s) of a monomial vector laid out (rows, 3) at i * 3 + j with
    u_p u_q = u_r u_s (the exponents of p and q add up to those of r and s)."""
    if rows not in _IDENTITIES:
        cells = [(i, j) for i in range(rows) for j in range(3)]
        pairs: dict = {}
        for a in range(len(cells)):
            for b in range(a, len(cells)):
                key = (cells[a][0] + cells[b][0], cells[a][1] + cells[b][1])
                pairs.setdefault(key, []).append((a, b))
        quads = [(p, q, r, s) for group in pairs.values() for k, (p, q) in enumerate(group)
                 for (r, s) in group[k + 1:]]
        _IDENTITIES[rows] = np.array(quads, dtype=int)
    return _IDENTITIES[rows]


def _two_monomial_vectors(M, y):
    """At twin roots y (K,) of the pencils M (K, 3, n, n): the two monomial vectors in the pencil's
    2-dimensional null space.  With V1, V2 its basis (the SVD's last two right singular vectors), u =
    b V1 + a V2 is a monomial vector exactly when every identity u_p u_q = u_r u_s holds: each is a
    homogeneous quadratic in (b, a), all of them multiples of the one whose roots are the two
    solutions; it is read from the identities' stacked coefficients (their top singular vector).
    Returns (vectors (2 K, n), index into the K twins of each)."""
    n = M.shape[-1]
    big = np.abs(y) > 1
    yi = np.where(big, 1 / np.where(big, y, 1), y)
    c0 = np.where(big, yi * yi, 1.0)[:, None, None]
    c2 = np.where(big, 1.0, yi * yi)[:, None, None]
    P = c0 * M[:, 0] + yi[:, None, None] * M[:, 1] + c2 * M[:, 2]
    Vh = np.linalg.svd(P)[2]
    V1, V2 = Vh[:, -1, :], Vh[:, -2, :]
    p, q, r, s = _identities(n // 3).T
    quad = np.stack([V1[:, p] * V1[:, q] - V1[:, r] * V1[:, s],  # b^2
                     V1[:, p] * V2[:, q] + V2[:, p] * V1[:, q] - V1[:, r] * V2[:, s] - V2[:, r] * V1[:, s],
                     V2[:, p] * V2[:, q] - V2[:, r] * V2[:, s]], axis=2)  # a^2; (K, identities, 3)
    h = np.linalg.svd(quad)[2][:, 0, :]  # (K, 3): h0 b^2 + h1 a b + h2 a^2 = 0
    disc = np.sqrt(np.maximum(h[:, 1] ** 2 - 4 * h[:, 0] * h[:, 2], 0.0))
    out = []
    for sign in (1.0, -1.0):
        # the root of the larger coefficient's variable: a / b when |h2| >= |h0|, else b / a
        with np.errstate(all="ignore"):
            ratio_ab = (-h[:, 1] + sign * disc) / (2 * h[:, 2])
            ratio_ba = (-h[:, 1] + sign * disc) / (2 * h[:, 0])
        use_ab = np.abs(h[:, 2]) >= np.abs(h[:, 0])
        b = np.where(use_ab, 1.0, np.nan_to_num(ratio_ba))
        a = np.where(use_ab, np.nan_to_num(ratio_ab), 1.0)
        out.append(b[:, None] * V1 + a[:, None] * V2)
    K = len(y)
    return np.concatenate(out), np.concatenate([np.arange(K), np.arange(K)])


def _solve_each(P, z):
    """P^-1 z per matrix of the stack, the SVD's null vector for an exactly singular one: each root
    gets what it gets when solved alone (before, one singular P switched the whole stack to SVD null
    vectors, so at a self-motion a target's rows depended on the other targets of its batch)."""
    out = np.empty_like(z)
    for k in range(len(P)):
        try:
            out[k] = np.linalg.solve(P[k], z[k])
        except np.linalg.LinAlgError:
            out[k] = np.linalg.svd(P[k])[2][-1, :, None]
    return out


def _read_ratio(den, num, prism=False):
    """th = 2 atan2(num, den) from the (den, num) pair of largest magnitude: (M, ...) -> (M,); for a
    prismatic joint (monomials in its displacement d, not in a half-angle) d = num / den from the pair
    of largest den."""
    den, num = den.reshape(len(den), -1), num.reshape(len(num), -1)
    i = np.arange(len(den))
    if prism:
        k = np.argmax(np.abs(den), axis=1)
        with np.errstate(all="ignore"):
            return num[i, k] / den[i, k]
    k = np.argmax(den * den + num * num, axis=1)
    return 2 * np.arctan2(num[i, k], den[i, k])


def _basis(th, prism=False):
    """(M, 3): (1, cos th, sin th) of a revolute joint, (1, d, d^2) of a prismatic one."""
    if prism:
        return np.stack([np.ones_like(th), th, th * th], axis=1)
    return np.stack([np.ones_like(th), np.cos(th), np.sin(th)], axis=1)


def _wrap(Q, prism=None):
    """Revolute values in (-pi, pi]; prismatic columns (``prism`` True) unchanged.

    Not ``angles.wrap_array`` (exact): this rounding wrap moves an in-range value by up to an ulp of pi,
    and swapping it for the exact one turned a recovered sample of ur5_gripper.urdf at a numerical
    self-motion (tests/test_real_robots.py) into a miss; the sensitivity is open (session 6 note)."""
    W = np.mod(Q + math.pi, 2 * math.pi) - math.pi
    W = np.where(W <= -math.pi, W + 2 * math.pi, W)
    return W if prism is None else np.where(prism, Q, W)


def _angle_gap(a, b, prism=None):
    """|a - b| modulo 2 pi, in [0, pi]; plain |a - b| in prismatic columns (normalised lengths)."""
    gap = np.abs(np.mod(a - b + math.pi, 2 * math.pi) - math.pi)
    return gap if prism is None else np.where(prism, np.abs(a - b), gap)


def _pack(Q, own, err, N, prism=None) -> Batch:
    """Distinct rows per target into (N, 16) slots, best residual first among duplicates.

    Vectorised over targets in chunks (the pairwise distances are chunk x K x K x 6 floats, K the most
    rows of one target: ~160 on a doubtful target whose candidates are pooled from several orders)."""
    order = np.lexsort((err, own))
    Q, own, err = Q[order], own[order], err[order]
    starts = np.searchsorted(own, np.arange(N + 1))
    count = np.diff(starts)
    slot = np.arange(len(own)) - starts[own]
    out_q = np.zeros((N, MAX_SOLUTIONS, 6))
    out_v = np.zeros((N, MAX_SOLUTIONS), dtype=bool)
    out_e = np.full((N, MAX_SOLUTIONS), np.inf)
    if not len(own):
        return Batch(out_q, out_v, out_e, out_v.any(axis=1))
    # targets grouped by their row count (up to 16, 32, 64, ...), each group padded to its own largest
    bucket = np.ceil(np.log2(np.maximum(count, 16))).astype(int)
    for b in np.unique(bucket[count > 0]):
        members = np.nonzero((bucket == b) & (count > 0))[0]
        K = int(count[members].max())
        earlier = np.tril(np.ones((K, K), dtype=bool), -1)  # [i, j]: j before i
        chunk = max(1, int(4e6 // (K * K * 6)))
        for lo in range(0, len(members), chunk):
            tg = members[lo:lo + chunk]
            local = np.full(N, -1)
            local[tg] = np.arange(len(tg))
            sel = local[own] >= 0
            o, sl = local[own[sel]], slot[sel]
            q = np.zeros((len(tg), K, 6))
            v = np.zeros((len(tg), K), dtype=bool)
            e = np.full((len(tg), K), np.inf)
            q[o, sl], v[o, sl], e[o, sl] = Q[sel], True, err[sel]
            d = _angle_gap(q[:, :, None, :], q[:, None, :, :], prism).max(axis=3)
            v &= ~(earlier & (d <= SAME) & v[:, None, :]).any(axis=2)
            rank = np.cumsum(v, axis=1) - 1
            n, k = np.nonzero(v & (rank < MAX_SOLUTIONS))
            t, r = tg[n], rank[n, k]
            out_q[t, r], out_v[t, r], out_e[t, r] = q[n, k], True, e[n, k]
    return Batch(out_q, out_v, out_e, out_v.any(axis=1))


def prepare(twists, home, scale: float | None = None) -> General6:
    """A :class:`General6` solver for the robot (6 revolute twists (v, w), home pose 4x4)."""
    return General6(twists, home, scale)


def solve(twists, home, T) -> np.ndarray:
    """Every solution (k, 6) of one target; prepare the robot once with :func:`prepare` for many."""
    return prepare(twists, home).solve(T)


def solve_batch(twists, home, Ts) -> Batch:
    """Every solution of N targets (N, 4, 4)."""
    return prepare(twists, home).solve_batch(Ts)
