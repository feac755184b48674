"""The finish of one target on the scalar fast chain: the specification that the C finish
(``fast_finish.h``: ``ikc_settle``, ``ikc_finish``, ``ikc_newton_steps`` and their helpers) ports,
statement for statement (docs/design.md section 6, "The finish, specified once").

Given a chain (the module's ``_fast_chain``, and its alternative chain where the plan has one) and one
goal (12 entries, :func:`subproblems.fast.goal_entries`), :func:`settle` returns the rows the C finish
returns for that goal -- ``(q, residual, ls, continuum)`` each, exact rows first -- or :data:`PYTHON`
where the C finish hands the target back to the reference runtime.  The steps: the leaves at the
self-motion representative ``rep = 0``; near misses (a tangent root) polished by Newton steps on the
true robot; values wrapped and brought inside the limits (a value within ``LIMIT_EPS`` of a limit
clamped onto it and the row re-converged with that joint held); duplicates merged; and where a
self-motion has no exact representative inside the limits, the chain again at other representatives,
the straight-line test (a self-motion that is a line alone in joint space is dropped where it misses
the limits, or taken inside them) and Newton steps along the family.

Plain floats and lists, in the C's order of operations, so that the two agree bit for bit
(``tests/test_finish_spec.py`` compares them on random and special poses of the zoo).  Search and
snapped plans (``ikc_search``, ``ikc_polished``) are not specified here: their Python paths are
``ikcompiler.runtime.fastchain`` and ``subproblems.continuation``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from subproblems import fast as _fk
from subproblems.angles import wrap

PYTHON = -1  # IKC_PYTHON: the reference runtime takes the target
FAMILY_MISS = -3  # IKC_FAMILY_MISS: a self-motion whose representatives all miss (internal)
REPS = 16  # IKC_REPS: representatives tried, rep = k pi / 8
# The fast finish's constants (IKC_NEAR_MISS, IKC_SPLIT_ROOT, IKC_LIMIT_EPS, IKC_PI_SNAP and the
# represent statuses) are fast.py's, from subproblems/tolerances.py (docs/design.md section 10).
NEAR_MISS, SPLIT_ROOT, LIMIT_EPS = _fk.NEAR_MISS, _fk.SPLIT_ROOT, _fk.LIMIT_EPS
INSIDE, ADJUSTED, OUTSIDE, CLAMPED = _fk.INSIDE, _fk.ADJUSTED, _fk.OUTSIDE, _fk.CLAMPED
CLAMPED_NEWTON = 3  # IKC_CLAMPED_NEWTON
SETTLED = 0.5  # IKC_SETTLED: a step ending this far inside the tolerance, not halving the error, is the last
LINE_FIT = 1e-9  # IKC_LINE_FIT
LINE_RANK = 1e-5  # IKC_LINE_RANK
TWO_PI = 2.0 * math.pi
PI = math.pi
TARGET_CODES = {"pose": 0, "position": 1, "orientation": 2}


@dataclass(frozen=True)
class FinishRobot:
    """What the C finish knows of a module (its ``ikc_robot``): returned joints, limits, the true robot."""

    dof: int
    slots: int
    target: int  # 0 pose, 1 position, 2 orientation
    revolute: tuple
    lower: tuple
    upper: tuple
    scale: float
    tol: float
    twists: tuple  # every joint of the true robot, (v, w) each
    home: tuple  # rotation row-major, then translation
    A: tuple  # all joint values = A q + b, row-major (nall x dof)
    b: tuple
    is_free: tuple
    chain: Callable[..., Any]
    chain_alt: Callable[..., Any] | None

    @classmethod
    def from_namespace(cls, ns: dict, chain_alt=None) -> FinishRobot:
        """The finish's robot of a generated module (``csource.chain_c_source`` reads the same fields)."""
        dof = len(ns["JOINT_TYPES"])
        H = [[float(x) for x in row] for row in ns["_HOME"]]
        return cls(
            dof=dof, slots=int(ns["MAX_SOLUTIONS"]), target=TARGET_CODES[ns["TARGET"]],
            revolute=tuple(k == "R" for k in ns["JOINT_TYPES"]),
            lower=tuple(float(x) for x in ns.get("_LOWER", ns["LOWER"])),
            upper=tuple(float(x) for x in ns.get("_UPPER", ns["UPPER"])),
            scale=float(ns["SCALE"]), tol=float(ns["TOLERANCE"]),
            twists=tuple(tuple(float(x) for x in t) for t in ns["_TWISTS"]),
            home=tuple([H[i][j] for i in range(3) for j in range(3)] + [H[i][3] for i in range(3)]),
            A=tuple(float(x) for row in ns["_A"] for x in row), b=tuple(float(x) for x in ns["_B"]),
            is_free=tuple(j in list(ns["_FREE"]) for j in range(dof)),
            chain=ns["_fast_chain"], chain_alt=chain_alt)

    def leaves(self, chain, goal, free, rep):
        """(Q rows, errors, flags) of a chain at representative rep; an S2-RR lock (LOCK) is a candidate
        self-motion (FAMILY too), kept only where its representatives are a line (ikc_lock_leaves)."""
        found = chain(_fk.SCALAR, goal, free, rep)
        return ([list(leaf[:-2]) for leaf in found], [leaf[-2] for leaf in found],
                [leaf[-1] | _fk.FAMILY if leaf[-1] & _fk.LOCK else leaf[-1] for leaf in found])


# -- forward kinematics, error and Newton steps (ikc_fk_jacobian, ikc_pose_error, ikc_newton_steps) --

def fk_jacobian(rb: FinishRobot, q):
    """Tool pose G (12 entries) and space Jacobian J (6 x dof row-major) at returned joint values q."""
    dof = rb.dof
    R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    p = [0.0, 0.0, 0.0]
    cols = []
    for i, tw in enumerate(rb.twists):
        th = rb.b[i]
        for j in range(dof):
            th += rb.A[i * dof + j] * q[j]
        v, w = tw[:3], tw[3:]
        Rw = [R[3 * r] * w[0] + R[3 * r + 1] * w[1] + R[3 * r + 2] * w[2] for r in range(3)]
        Rv = [R[3 * r] * v[0] + R[3 * r + 1] * v[1] + R[3 * r + 2] * v[2] for r in range(3)]
        pxw = [p[1] * Rw[2] - p[2] * Rw[1], p[2] * Rw[0] - p[0] * Rw[2], p[0] * Rw[1] - p[1] * Rw[0]]
        cols.append([Rv[r] + pxw[r] for r in range(3)] + Rw)
        if w[0] == 0.0 and w[1] == 0.0 and w[2] == 0.0:
            E = [1.0 if k % 4 == 0 else 0.0 for k in range(9)]
            t = [v[k] * th for k in range(3)]
        else:
            c, s = math.cos(th), math.sin(th)
            C = 1.0 - c
            E = [c + w[0] * w[0] * C, w[0] * w[1] * C - w[2] * s, w[0] * w[2] * C + w[1] * s,
                 w[1] * w[0] * C + w[2] * s, c + w[1] * w[1] * C, w[1] * w[2] * C - w[0] * s,
                 w[2] * w[0] * C - w[1] * s, w[2] * w[1] * C + w[0] * s, c + w[2] * w[2] * C]
            wv = [w[1] * v[2] - w[2] * v[1], w[2] * v[0] - w[0] * v[2], w[0] * v[1] - w[1] * v[0]]
            wdv = w[0] * v[0] + w[1] * v[1] + w[2] * v[2]
            t = []
            for k in range(3):
                Ewv = E[3 * k] * wv[0] + E[3 * k + 1] * wv[1] + E[3 * k + 2] * wv[2]
                t.append(wv[k] - Ewv + w[k] * wdv * th)
        R2 = [R[3 * r] * E[k] + R[3 * r + 1] * E[3 + k] + R[3 * r + 2] * E[6 + k]
              for r in range(3) for k in range(3)]
        p = [R[3 * r] * t[0] + R[3 * r + 1] * t[1] + R[3 * r + 2] * t[2] + p[r] for r in range(3)]
        R = R2
    H = rb.home
    G = [R[3 * r] * H[k] + R[3 * r + 1] * H[3 + k] + R[3 * r + 2] * H[6 + k]
         for r in range(3) for k in range(3)]
    G += [R[3 * r] * H[9] + R[3 * r + 1] * H[10] + R[3 * r + 2] * H[11] + p[r] for r in range(3)]
    tp = G[9:]
    J = [0.0] * (6 * dof)
    for j in range(dof):
        col = [0.0] * 6
        for i, c in enumerate(cols):
            a = rb.A[i * dof + j]
            if a == 0.0:
                continue
            wxp = [c[4] * tp[2] - c[5] * tp[1], c[5] * tp[0] - c[3] * tp[2], c[3] * tp[1] - c[4] * tp[0]]
            for r in range(3):
                col[r] += a * (c[r] + wxp[r])
                col[3 + r] += a * c[3 + r]
        for r in range(6):
            J[r * dof + j] = col[r]
    return G, J


def _max2(a, b):
    if a != a or b != b:
        return math.nan
    return a if a > b else b


def pose_error(rb: FinishRobot, G, g) -> float:
    dp = 0.0
    for k in range(3):
        dp += (G[9 + k] - g[9 + k]) * (G[9 + k] - g[9 + k])
    dp = math.sqrt(dp)
    dr = 0.0
    for k in range(9):
        d = G[k] - g[k]
        if d != d:
            return math.nan
        dr += d * d
    dr = rb.scale * math.sqrt(dr)
    if rb.target == 1:
        return dp
    if rb.target == 2:
        return dr
    return _max2(dp, dr)


def measure(rb: FinishRobot, g, q) -> float:
    return pose_error(rb, fk_jacobian(rb, q)[0], g)


def solve_linear(n: int, M):
    """x of M x = M[:, n] by Gaussian elimination with partial pivoting (M changed), or None."""
    for k in range(n):
        piv = k
        for r in range(k + 1, n):
            if abs(M[r][k]) > abs(M[piv][k]):
                piv = r
        if piv != k:
            M[k], M[piv] = M[piv], M[k]
        if M[k][k] == 0.0:
            return None
        for r in range(k + 1, n):
            f = M[r][k] / M[k][k]
            for c in range(k, n + 1):
                M[r][c] -= f * M[k][c]
    x = [0.0] * n
    for k in range(n - 1, -1, -1):
        s = M[k][n]
        for c in range(k + 1, n):
            s -= M[k][c] * x[c]
        x[k] = s / M[k][k]
    return x


def newton_steps(rb: FinishRobot, g, q, iters: int, guarded: bool = True, held=None) -> float:
    """Damped Gauss-Newton steps on q (in place; free and ``held`` joints kept); the new pose error.
    A guarded step ending inside SETTLED of the tolerance without halving the error is the last (Newton's
    linear regime at a singular configuration)."""
    dof = rb.dof
    done = 1e-3 * rb.tol * rb.scale
    exact = rb.tol * rb.scale
    slow = False
    lam = 1e-12
    G, J = fk_jacobian(rb, q)
    now = pose_error(rb, G, g)
    r0, r1 = (3 if rb.target == 2 else 0), (3 if rb.target == 1 else 6)
    for _ in range(iters):
        if now != now:
            return math.nan
        if now <= done:
            return now
        e = [g[9 + k] - G[9 + k] for k in range(3)] + [0.0, 0.0, 0.0]
        for c in range(3):
            a0, a1, a2, b0, b1, b2 = G[c], G[3 + c], G[6 + c], g[c], g[3 + c], g[6 + c]
            e[3] += 0.5 * (a1 * b2 - a2 * b1)
            e[4] += 0.5 * (a2 * b0 - a0 * b2)
            e[5] += 0.5 * (a0 * b1 - a1 * b0)
        col, Js = [0.0] * dof, [0.0] * (6 * dof)
        for j in range(dof):
            s = 0.0
            for r in range(r0, r1):
                s += J[r * dof + j] * J[r * dof + j]
            col[j] = math.sqrt(s) if math.sqrt(s) > 1e-300 else 1e-300
            hold = rb.is_free[j] or (held is not None and held[j])
            for r in range(r0, r1):
                Js[r * dof + j] = 0.0 if hold else J[r * dof + j] / col[j]
        JtJ = [[0.0] * dof for _ in range(dof)]
        Jte = [0.0] * dof
        for a in range(dof):
            for c in range(dof):
                s = 0.0
                for r in range(r0, r1):
                    s += Js[r * dof + a] * Js[r * dof + c]
                JtJ[a][c] = s
            s = 0.0
            for r in range(r0, r1):
                s += Js[r * dof + a] * e[r]
            Jte[a] = s
        accepted = False
        for _attempt in range(8):
            M = [[JtJ[a][c] + (lam if a == c else 0.0) for c in range(dof)] + [Jte[a]] for a in range(dof)]
            dq = solve_linear(dof, M)
            if dq is None:
                return now
            trial = [q[j] + (0.0 if (rb.is_free[j] or (held is not None and held[j])) else dq[j] / col[j])
                     for j in range(dof)]
            G2, J2 = fk_jacobian(rb, trial)
            nxt = pose_error(rb, G2, g)
            if nxt < now or not guarded:
                q[:] = trial
                slow = guarded and nxt <= SETTLED * exact and nxt > 0.5 * now
                G, J, now = G2, J2, nxt
                lam = lam * 0.1 if lam > 1e-11 else 1e-12
                accepted = True
                break
            lam *= 100.0
        if not accepted or slow:
            break
    return now


# -- values as returned (ikc_represent) and the finish of the leaves (ikc_finish) ---------------------

def represent(rb: FinishRobot, q, limits: bool, clamped=None) -> int:
    """q (in place) as returned; INSIDE, ADJUSTED, OUTSIDE or CLAMPED (and which joints were clamped)."""
    out, status = _fk.represent_one(q, rb.revolute, list(zip(rb.lower, rb.upper)), limits, clamped)
    q[:len(out)] = out
    return status


def row_inside(rb: FinishRobot, q) -> bool:
    return represent(rb, list(q), True) != OUTSIDE


def finish(rb: FinishRobot, g, Q, E, F, limits: bool):
    """Rows of one target from its leaves (exact first, by error; duplicates and rows outside the limits
    left out), or PYTHON, or FAMILY_MISS."""
    dof = rb.dof
    exact_tol, near = rb.tol * rb.scale, NEAR_MISS * rb.scale
    same = 1e-9 * (rb.scale if rb.scale > 1.0 else 1.0)
    kept_rows, inexact, err, W = [], {}, {}, {}
    polished = {}  # k -> (row, error) after the Newton steps
    family_any = family_exact = False
    for k, flag in enumerate(F):
        if flag & _fk.EMPTY:
            continue
        err[k] = E[k]
        if flag & _fk.DEFER or err[k] != err[k]:
            return PYTHON
        if flag & _fk.LOCK:  # settled by settle_chain's line test (its leaves read FAMILY there)
            return FAMILY_MISS if flag & _fk.FAMILY else PYTHON
        w = list(Q[k])
        if exact_tol < err[k] < near:
            # a copy of a leaf polished already (equal values and error: a tangent root's) takes its polish
            before = next((b for b in polished if E[b] == E[k] and list(Q[b]) == w), None)
            if before is not None:
                w, err[k] = list(polished[before][0]), polished[before][1]
            else:
                err[k] = newton_steps(rb, g, w, 15)
            if err[k] != err[k]:
                return PYTHON
            polished[k] = (list(w), err[k])
            same = SPLIT_ROOT
        if flag & _fk.TANGENT_ROOT:
            same = SPLIT_ROOT
        if any(x != x for x in w):
            return PYTHON
        held = [False] * dof
        status = represent(rb, w, limits, held)
        if status == CLAMPED:
            newton_steps(rb, g, w, CLAMPED_NEWTON, True, held)
            same = SPLIT_ROOT  # Newton placed this row: a copy of it may stop 1e-7 away (as the C, 814886d)
            if any(x != x for x in w):
                return PYTHON
            status = represent(rb, w, limits, held)
            if status == CLAMPED:
                return PYTHON
            if status != OUTSIDE:
                status = ADJUSTED
        ok = status != OUTSIDE
        if status == ADJUSTED:
            err[k] = measure(rb, g, w)
        inexact[k] = not err[k] <= exact_tol
        W[k] = w
        if flag & _fk.FAMILY:
            family_any = True
            if ok and not inexact[k]:
                family_exact = True
        if ok:
            kept_rows.append(k)
    if family_any and not family_exact:
        return FAMILY_MISS
    kept_rows.sort(key=lambda k: (inexact[k], err[k]))  # stable, as the C's insertion sort
    out = []
    for k in kept_rows:
        if len(out) == rb.slots:
            break
        w = W[k]
        duplicate = False
        for o in out:
            differs = False
            for j in range(dof):
                d = w[j] - o[0][j] if w[j] > o[0][j] else o[0][j] - w[j]
                if rb.revolute[j]:
                    d = math.fmod(d, TWO_PI)
                    if d > PI:
                        d = TWO_PI - d
                if d > same:
                    differs = True
                    break
            if not differs:
                duplicate = True
                break
        if not duplicate:
            out.append((w, err[k], inexact[k], bool(F[k] & _fk.FAMILY)))
    return out


# -- self-motions that are straight lines (ikc_two_weakest, ikc_line_*) --------------------------------

def jtj_eigen(rb: FinishRobot, q, vectors: bool = False):
    """(col, eigenvalues ascending, eigenvectors as columns V[k][a] or None) of the size-free J^T J over
    the joints that are not free; (col, None, None) when fewer than 2 or more than the target's rows."""
    dof = rb.dof
    _, J = fk_jacobian(rb, q)
    r0, r1 = (3 if rb.target == 2 else 0), (3 if rb.target == 1 else 6)
    col = [j for j in range(dof) if not rb.is_free[j]]
    m = len(col)
    if m < 2 or m > r1 - r0:
        return col, None, None
    S = [[0.0] * m for _ in range(m)]
    U = [[1.0 if a == c else 0.0 for c in range(m)] for a in range(m)]
    for a in range(m):
        for c in range(m):
            t = 0.0
            for r in range(r0, r1):
                f = 1.0 / (rb.scale * rb.scale) if r < 3 else 1.0
                t += f * J[r * dof + col[a]] * J[r * dof + col[c]]
            ua = 1.0 if rb.revolute[col[a]] else rb.scale
            uc = 1.0 if rb.revolute[col[c]] else rb.scale
            S[a][c] = t * ua * uc
    for _ in range(30):
        off = diag = 0.0
        for a in range(m):
            diag += S[a][a] * S[a][a]
            for c in range(a + 1, m):
                off += S[a][c] * S[a][c]
        if off <= 1e-34 * diag:
            break
        for a in range(m):
            for c in range(a + 1, m):
                if S[a][c] == 0.0:
                    continue
                theta = (S[c][c] - S[a][a]) / (2.0 * S[a][c])
                t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                cs = 1.0 / math.sqrt(t * t + 1.0)
                sn = t * cs
                for k in range(m):
                    x, y = S[k][a], S[k][c]
                    S[k][a] = cs * x - sn * y
                    S[k][c] = sn * x + cs * y
                    x, y = U[k][a], U[k][c]
                    U[k][a] = cs * x - sn * y
                    U[k][c] = sn * x + cs * y
                for k in range(m):
                    x, y = S[a][k], S[c][k]
                    S[a][k] = cs * x - sn * y
                    S[c][k] = sn * x + cs * y
    order = sorted(range(m), key=lambda a: S[a][a])  # stable, as the C's insertion sort
    lam = [S[a][a] for a in order]
    V = [[U[k][a] for a in order] for k in range(m)] if vectors else None
    return col, lam, V


def two_weakest(rb: FinishRobot, q):
    """The two smallest singular values of the size-free Jacobian at q (free joints left out)."""
    _, lam, _ = jtj_eigen(rb, q)
    if lam is None:
        return 0.0, 0.0
    return math.sqrt(lam[0] if lam[0] > 0.0 else 0.0), math.sqrt(lam[1] if lam[1] > 0.0 else 0.0)


def joint_step(rb: FinishRobot, j: int, a: float, b: float) -> float:
    return wrap(a - b) if rb.revolute[j] else a - b


def rank_clear(rb: FinishRobot, q, s) -> bool:
    """A sufficient test that the second smallest eigenvalue of the size-free J^T J at q is at least
    LINE_RANK^2, cheaper than :func:`jtj_eigen`'s sweeps: J^T J compressed onto the complement of the
    line's unit direction f (an orthonormal basis by Gram-Schmidt), less twice that floor, has a Cholesky
    factor.  By Courant-Fischer the second eigenvalue is at least the compression's smallest, so where
    this holds the eigenvalue test holds too (the factor 2 keeps roundoff off the floor); where it
    fails the caller asks the eigenvalues (ikc_rank_clear)."""
    dof = rb.dof
    _, J = fk_jacobian(rb, q)
    r0, r1 = (3 if rb.target == 2 else 0), (3 if rb.target == 1 else 6)
    col = [j for j in range(dof) if not rb.is_free[j]]
    m = len(col)
    if m < 2 or m > r1 - r0:
        return False
    fn = 0.0
    for a in range(m):
        fn += s[col[a]] * s[col[a]]
    if not fn > 0.0:
        return False
    f = [s[col[a]] / math.sqrt(fn) for a in range(m)]
    S = [[0.0] * m for _ in range(m)]
    for a in range(m):
        for c in range(m):
            t = 0.0
            for r in range(r0, r1):
                w = 1.0 / (rb.scale * rb.scale) if r < 3 else 1.0
                t += w * J[r * dof + col[a]] * J[r * dof + col[c]]
            ua = 1.0 if rb.revolute[col[a]] else rb.scale
            uc = 1.0 if rb.revolute[col[c]] else rb.scale
            S[a][c] = t * ua * uc
    top = 0
    for a in range(1, m):
        if abs(f[a]) > abs(f[top]):
            top = a
    U = []  # orthonormal basis of the complement of f: e_a (a != top) less its parts along f and U
    for a in range(m):
        if a == top:
            continue
        u = [(1.0 if c == a else 0.0) - f[a] * f[c] for c in range(m)]
        for b in U:
            d = 0.0
            for c in range(m):
                d += b[c] * u[c]
            for c in range(m):
                u[c] -= d * b[c]
        norm = 0.0
        for c in range(m):
            norm += u[c] * u[c]
        norm = math.sqrt(norm)
        if not norm > 0.0:
            return False
        U.append([u[c] / norm for c in range(m)])
    k = m - 1
    C = [[0.0] * k for _ in range(k)]
    for a in range(k):
        Su = [0.0] * m
        for r in range(m):
            t = 0.0
            for c in range(m):
                t += S[r][c] * U[a][c]
            Su[r] = t
        for b in range(a + 1):
            t = 0.0
            for r in range(m):
                t += U[b][r] * Su[r]
            C[a][b] = t
    floor = 2.0 * LINE_RANK * LINE_RANK
    L = [[0.0] * k for _ in range(k)]
    for a in range(k):
        for b in range(a + 1):
            t = C[a][b] - (floor if a == b else 0.0)
            for c in range(b):
                t -= L[a][c] * L[b][c]
            if a == b:
                if not t > 0.0:
                    return False
                L[a][a] = math.sqrt(t)
            else:
                L[a][b] = t / L[b][b]
    return True


def line_alone(rb: FinishRobot, q0, s, g=None) -> bool:
    """Whether the line q0 + s t is a self-motion alone at t = 0, +-2 pi / 3.  With ``g`` (the goal; a
    line whose leaves are a tangent root, exact there), a point with a second null direction counts
    where that direction is a double root's (:func:`tangent_line_alone` at the point)."""
    if not any(x != 0.0 for x in s):
        return False
    for t in (0.0, TWO_PI / 3.0, -1.0 * TWO_PI / 3.0):
        q = [q0[j] + s[j] * t for j in range(rb.dof)]
        if rank_clear(rb, q, s):
            continue
        if not two_weakest(rb, q)[1] >= LINE_RANK and not (g is not None and tangent_line_alone(rb, g, q, s)):
            return False
    return True


def _null_across(rb: FinishRobot, col, V, f):
    """The unit null vector (of the two weakest, V's first columns) least along the unit f, made
    orthogonal to it, and its squared length before that (ikc_null_across)."""
    m = len(col)
    n, best = None, 0.0
    for v in range(2):
        d = 0.0
        for a in range(m):
            d += V[a][v] * f[a]
        w = [V[a][v] - d * f[a] for a in range(m)]
        length = 0.0
        for a in range(m):
            length += w[a] * w[a]
        if length > best:
            best, n = length, [w[a] / math.sqrt(length) for a in range(m)]
    return n, best


def _joint_inside(rb: FinishRobot, j: int, x: float, slack: float, slide_slack: float) -> bool:
    """Whether value x of joint j (or an alias) lies inside its limits widened by the slack."""
    sl = slack if rb.revolute[j] else slide_slack
    lo, hi = rb.lower[j] - sl, rb.upper[j] + sl
    if rb.revolute[j]:
        if hi - lo >= TWO_PI:
            return True
        x = lo + math.fmod(math.fmod(x - lo, TWO_PI) + TWO_PI, TWO_PI)
    return lo <= x <= hi


def line_inside(rb: FinishRobot, q0, s, t: float, slack: float, slide_slack: float) -> bool:
    return all(_joint_inside(rb, j, q0[j] + s[j] * t, slack, slide_slack) for j in range(rb.dof))


def line_in_limits(rb: FinishRobot, q0, s, slack: float, slide_slack: float):
    """(0, None) when the line q0 + s t, t in [-pi, pi], misses the limits; (1, t) with t the middle of
    its widest in-limit stretch; (-1, None) when undecided."""
    cut = [-PI, PI]
    for j in range(rb.dof):
        if s[j] == 0.0:
            continue
        if rb.revolute[j] and rb.upper[j] - rb.lower[j] >= TWO_PI:
            continue
        wraps = int(math.ceil(abs(s[j]))) + 1 if rb.revolute[j] else 0
        for bound in (rb.lower[j], rb.upper[j]):
            for k in range(-wraps, wraps + 1):
                t = (bound + TWO_PI * k - q0[j]) / s[j]
                if -PI < t < PI:
                    if len(cut) == 256:
                        return -1, None
                    cut.append(t)
    cut.sort()
    widest, t_mid, any_inside = -1.0, None, False
    for a in range(len(cut) - 1):
        mid, width = 0.5 * (cut[a] + cut[a + 1]), cut[a + 1] - cut[a]
        if line_inside(rb, q0, s, mid, slack, slide_slack):
            any_inside = True
        if width > widest and line_inside(rb, q0, s, mid, 0.0, 0.0):
            widest, t_mid = width, mid
    if not any_inside:
        any_inside = any(line_inside(rb, q0, s, t, slack, slide_slack) for t in cut)
    if not any_inside:
        return 0, None
    return (1, t_mid) if widest > 0.0 else (-1, None)


TANGENT_MARGIN = 1e-3  # IKC_TANGENT_MARGIN
TANGENT_PROBE = 1e-3  # IKC_TANGENT_PROBE
# IKC_TANGENT_PROBE_STEPS: Newton steps from a probe; a double root's halve the distance each, and 4
# halvings bring it inside the tenth of the probe that the test asks (8: a margin of 16)
TANGENT_PROBE_STEPS = 8


def row_distance(rb: FinishRobot, x, y) -> float:
    """ikc_row_distance: revolute values modulo 2 pi, prismatic ones over the size; NaN wins."""
    m = 0.0
    for j in range(rb.dof):
        d = abs(x[j] - y[j])
        if rb.revolute[j]:
            d = math.fmod(d, TWO_PI)
            if d > PI:
                d = TWO_PI - d
        else:
            d /= rb.scale
        if not d <= m:
            m = d
    return m


def _line_and_across(rb: FinishRobot, col, V, s):
    """The line's unit direction f (its slopes s on the moving columns col) and the null direction n
    across it (_null_across), or None when the slopes vanish or no null direction lies well across
    the line (ikc_tangent_line_alone and ikc_plane_misses inline the same steps)."""
    fn = 0.0
    for a in range(len(col)):
        fn += s[col[a]] * s[col[a]]
    if not fn > 0.0:
        return None
    f = [s[col[a]] / math.sqrt(fn) for a in range(len(col))]
    n, best = _null_across(rb, col, V, f)
    if not best > 0.25:
        return None
    return f, n


def _probe(rb: FinishRobot, g, p0, col, step: float, v, iters: int):
    """Newton steps from p0 moved by step * v (v over the columns col, in radians or sizes): the end
    point, its error and its step from p0 per column, in the same units (the probes of the line and
    plane tests)."""
    x = list(p0)
    for a in range(len(col)):
        u = 1.0 if rb.revolute[col[a]] else rb.scale
        x[col[a]] += step * v[a] * u
    err = newton_steps(rb, g, x, iters)
    d = []
    for a in range(len(col)):
        u = 1.0 if rb.revolute[col[a]] else rb.scale
        d.append(joint_step(rb, col[a], x[col[a]], p0[col[a]]) / u)
    return x, err, d


def _dot(d, f) -> float:
    """sum d[a] f[a], summed in order (as the C accumulates it beside the steps)."""
    total = 0.0
    for a in range(len(d)):
        total += d[a] * f[a]
    return total


def tangent_line_alone(rb: FinishRobot, g, p0, s) -> bool:
    """Whether the tangent line through its exact point p0 is a self-motion alone: a null space of two
    directions, the line's and one along which Newton steps come back to the line (a double root),
    or of one."""
    col, lam, V = jtj_eigen(rb, p0, vectors=True)
    m = len(col)
    floor = LINE_RANK * LINE_RANK
    if lam is None or m < 3 or not lam[2] >= floor:
        return False
    if lam[1] >= floor:
        return True
    found = _line_and_across(rb, col, V, s)
    if found is None:
        return False
    f, n = found
    for side in (-1, 1):
        x, _, d = _probe(rb, g, p0, col, side * TANGENT_PROBE, n, TANGENT_PROBE_STEPS)
        along = _dot(d, f)
        off = 0.0
        for a in range(m):
            off += (d[a] - along * f[a]) * (d[a] - along * f[a])
        if not math.sqrt(off) <= 0.1 * TANGENT_PROBE:
            return False
    return True


# -- the chain and its self-motions (ikc_settle_chain, ikc_settle) ------------------------------------

def _plain_family(flag) -> bool:
    return bool(flag & _fk.FAMILY) and not flag & (_fk.DEFER | _fk.EMPTY)


PLANE_PROBE = 0.5  # IKC_PLANE_PROBE: the step along a plane's second direction (radians, or over the size)
PLANE_FIXED = 1e-6  # IKC_PLANE_FIXED: a joint neither direction of the plane moves (unit direction)


def plane_misses(rb: FinishRobot, g, p0, s, slack: float, slide_slack: float) -> bool:
    """Whether the self-motion through the exact point p0 of a family line (slopes s) is a plane alone
    of which a joint that neither of its directions moves lies outside its limits: the Jacobian's null
    space at p0 has exactly two directions, the line's f and n; the points p0 +- PLANE_PROBE n are
    exact (a sheet of solutions: Newton keeps them off the line, where a double root's would come
    back), keep that joint's value and have two null directions again.  Near each of those points the
    solutions are that sheet, so the self-motion keeps the joint where it misses its limits: no
    solution (ikc_plane_misses)."""
    col, lam, V = jtj_eigen(rb, p0, vectors=True)
    m = len(col)
    floor = LINE_RANK * LINE_RANK
    if lam is None or m < 3 or not (lam[1] < floor and lam[2] >= floor):
        return False
    found = _line_and_across(rb, col, V, s)
    if found is None:
        return False
    f, n = found
    out = [a for a in range(m) if abs(f[a]) <= PLANE_FIXED and abs(n[a]) <= PLANE_FIXED
           and not _joint_inside(rb, col[a], p0[col[a]], slack, slide_slack)]
    if not out:
        return False
    exact = rb.tol * rb.scale
    for side in (-1, 1):
        x, err, d = _probe(rb, g, p0, col, side * PLANE_PROBE, n, 15)
        if not err <= exact:
            return False
        along = _dot(d, f)
        off = 0.0
        for a in range(m):
            off += (d[a] - along * f[a]) * (d[a] - along * f[a])
        if not math.sqrt(off) >= 0.5 * PLANE_PROBE:
            return False  # back towards the line: no sheet
        for a in out:
            if not abs(d[a]) <= LINE_FIT:
                return False
        _, lam_x, _ = jtj_eigen(rb, x)
        if not (lam_x[1] < floor and lam_x[2] >= floor):
            return False
    return True


# IKC_ROOT_FIXED: a joint the sheet's direction n leaves, where a double root's direction shares the null
# space at p0: there p0 is exact only to the double root's flat error (joint values to ~1e-8, the error
# their square), the null vectors of the triple eigenvalue mix by ~1e-6 and Newton's end points on the
# sheet keep the joint to ~1e-8; the joint is also asked to stay outside its limits at those points
ROOT_FIXED = 1e-4


def _sheet_and_root(rb: FinishRobot, g, p0, col, f, n, r, slack: float, slide_slack: float) -> bool:
    """plane_root_misses for one choice of the sheet's second direction n and the double root's r (unit,
    across f and each other): a joint that neither f nor n moves lies outside its limits; Newton steps
    from p0 +- TANGENT_PROBE r come back to the sheet's tangent plane (a double root: no solutions
    along r); the points p0 +- PLANE_PROBE n are exact, off the line, keep that joint and have two null
    directions (the sheet alone there), the joint within ROOT_FIXED and outside its limits
    (ikc_sheet_and_root)."""
    m = len(col)
    out = [a for a in range(m) if abs(f[a]) <= PLANE_FIXED and abs(n[a]) <= ROOT_FIXED
           and not _joint_inside(rb, col[a], p0[col[a]], slack, slide_slack)]
    if not out:
        return False
    for side in (-1, 1):
        x, _, d = _probe(rb, g, p0, col, side * TANGENT_PROBE, r, TANGENT_PROBE_STEPS)
        along, across = _dot(d, f), _dot(d, n)
        off = 0.0
        for a in range(m):
            off += (d[a] - along * f[a] - across * n[a]) * (d[a] - along * f[a] - across * n[a])
        if not math.sqrt(off) <= 0.1 * TANGENT_PROBE:
            return False  # not back on the sheet: no double root's direction
    exact = rb.tol * rb.scale
    floor = LINE_RANK * LINE_RANK
    for side in (-1, 1):
        x, err, d = _probe(rb, g, p0, col, side * PLANE_PROBE, n, 15)
        if not err <= exact:
            return False
        along = _dot(d, f)
        off = 0.0
        for a in range(m):
            off += (d[a] - along * f[a]) * (d[a] - along * f[a])
        if not math.sqrt(off) >= 0.5 * PLANE_PROBE:
            return False  # back towards the line: no sheet
        for a in out:
            if not (abs(d[a]) <= ROOT_FIXED and not _joint_inside(rb, col[a], x[col[a]], slack, slide_slack)):
                return False
        _, lam_x, _ = jtj_eigen(rb, x)
        if not (lam_x[1] < floor and lam_x[2] >= floor):
            return False
    return True


def plane_root_misses(rb: FinishRobot, g, p0, s, slack: float, slide_slack: float) -> bool:
    """Whether the self-motion through the exact point p0 of a family line (slopes s) is a plane alone
    of which a joint lies outside its limits, where a double root adds a third null direction at p0
    (prob at q5 = pi: joints 1, 4 and 6 coaxial and the S2-RR of joints 2 and 3 at a double root): the
    null space at p0 has exactly three directions, the line's f and, across it, a sheet's n and a double
    root's r (tried in each order of the null vectors across f: at a triple null eigenvalue the sweeps'
    vectors are any basis of it, so a mixed basis finds no order and refuses), each as
    :func:`_sheet_and_root` asks (ikc_plane_root_misses)."""
    col, lam, V = jtj_eigen(rb, p0, vectors=True)
    m = len(col)
    floor = LINE_RANK * LINE_RANK
    if lam is None or m < 4 or not (lam[2] < floor and lam[3] >= floor):
        return False
    fn = 0.0
    for a in range(m):
        fn += s[col[a]] * s[col[a]]
    if not fn > 0.0:
        return False
    f = [s[col[a]] / math.sqrt(fn) for a in range(m)]
    W = []  # the three null vectors made orthogonal to f
    for v in range(3):
        d = 0.0
        for a in range(m):
            d += V[a][v] * f[a]
        W.append([V[a][v] - d * f[a] for a in range(m)])
    for i in range(3):
        for k in range(3):
            if i == k:
                continue
            ni = 0.0
            for a in range(m):
                ni += W[i][a] * W[i][a]
            if not ni > 0.25:
                continue
            n = [W[i][a] / math.sqrt(ni) for a in range(m)]
            d = 0.0
            for a in range(m):
                d += W[k][a] * n[a]
            r = [W[k][a] - d * n[a] for a in range(m)]
            nr = 0.0
            for a in range(m):
                nr += r[a] * r[a]
            if not nr > 0.25:
                continue
            r = [r[a] / math.sqrt(nr) for a in range(m)]
            if _sheet_and_root(rb, g, p0, col, f, n, r, slack, slide_slack):
                return True
    return False


def line_verdict(rb: FinishRobot, g, q0, s, tangent: bool, root: bool = False):
    """(found, t) of family leaf q0 (its leaf at rep = 0) with slopes s: found -2 where it is not shown
    a line alone (a tangent line: its exact point near q0 is found first; ``root``: an exact line whose
    leaves are flagged a tangent root, see :func:`line_alone`), else :func:`line_in_limits`'s 0, 1 or -1
    (ikc_line_verdict)."""
    p0 = list(q0)
    if tangent and not (newton_steps(rb, g, p0, 15) <= rb.tol * rb.scale
                        and row_distance(rb, p0, q0) <= TANGENT_MARGIN):
        return -2, 0.0
    slack = TANGENT_MARGIN if tangent else LIMIT_EPS
    if not (tangent_line_alone(rb, g, p0, s) if tangent else line_alone(rb, q0, s, g if root else None)):
        # not a line alone: a plane alone that misses the limits has no solution either (also where a
        # double root adds a third null direction at p0)
        slide = slack * rb.scale if tangent else slack
        return (0 if plane_misses(rb, g, p0, s, slack, slide) or plane_root_misses(rb, g, p0, s, slack, slide)
                else -2), 0.0
    found, t = line_in_limits(rb, q0, s, slack, slack * rb.scale if tangent else slack)
    return found, (0.0 if t is None else t)


def _given_verdict(rb: FinishRobot, verdict, j, line, Q0, S, tangent, root):
    """The verdict already given to an earlier leaf of the same line: the same test and slopes, and leaf
    values equal (a tangent line's: within SPLIT_ROOT, where the finish takes two copies of a tangent
    root for one solution).  :func:`line_verdict` depends on those alone, and a double root's split
    copies would each pay for its Newton steps and probes again (ikc_given_verdict); or None."""
    for k in range(j):
        if k in verdict and line[k] and tangent[k] == tangent[j] and root[k] == root[j] and S[k] == S[j] \
                and (row_distance(rb, Q0[k], Q0[j]) <= SPLIT_ROOT if tangent[j] else Q0[k] == Q0[j]):
            return verdict[k]
    return None


def _reps():
    """(r, rep) of the other representatives, in the C's order: pi/8, -pi/8, pi/4, -pi/4, ... pi."""
    for r in range(1, REPS):
        step = (r + 1) // 2
        rep = (1.0 if r % 2 else -1.0) * step * (TWO_PI / REPS)
        if rep > -PI:
            yield r, rep


def settle_chain(rb: FinishRobot, chain, g, free, limits: bool, try_alt: bool = False):
    dof = rb.dof
    Q, E, F = rb.leaves(chain, g, free, 0.0)
    if try_alt and _any_flag(F, _fk.FAMILY):  # a gimbal lock: the alternative chain first
        k = settle_alternative(rb, g, free, limits)
        if k != FAMILY_MISS:
            return k
    n = len(Q)
    k = finish(rb, g, Q, E, F, limits)
    if k != FAMILY_MISS:
        return k
    exact_tol, near = rb.tol * rb.scale, NEAR_MISS * rb.scale
    Q0 = [list(row) for row in Q]
    B = [list(row) for row in Q]
    EB = [E[j] if (not limits or row_inside(rb, Q[j])) else math.inf for j in range(n)]
    E0, F0 = list(E), list(F)
    line = [limits and _plain_family(F[j])
            and (E[j] <= exact_tol or bool(F[j] & _fk.TANGENT_ROOT) and E[j] < near) for j in range(n)]
    S = [[0.0] * dof for _ in range(n)]
    kept = {}  # r -> the leaves of representative r, for the polish below
    tangent = [not E0[j] <= exact_tol for j in range(n)]
    root = [bool(F0[j] & _fk.TANGENT_ROOT) for j in range(n)]
    for r, rep in _reps():
        if r > 1 and not any(line):
            break  # no line left to fit: the polish below runs the chain where a leaf still needs it
        Q2, E2, F2 = kept[r] = rb.leaves(chain, g, free, rep)
        if len(Q2) != n:
            return PYTHON
        _fit_lines(rb, r, rep, Q2, E2, F2, Q0, line, S)
        if r == 1:
            quick = quick_lines(rb, chain, g, free, Q, E, F, Q0, line, S, tangent, root, kept[1])
            if quick is not None:
                return quick

    # a tangent line shown to miss the limits has no solution: decided before the polish (moot there)
    verdict = {}
    for j in range(n):
        if line[j] and tangent[j]:
            verdict[j] = _given_verdict(rb, verdict, j, line, Q0, S, tangent, root) \
                or line_verdict(rb, g, Q0[j], S[j], True)
            if verdict[j][0] == 0:
                F[j] |= _fk.EMPTY
    for r, rep in _reps():
        if not any(_polish_pending(rb, Q, E, F, j, limits) for j in range(n)):
            break  # every family leaf settled: the later representatives change nothing
        if r not in kept:
            kept[r] = rb.leaves(chain, g, free, rep)
            if len(kept[r][0]) != n:
                return PYTHON
        Q2, E2, F2 = kept[r]
        for j in range(n):
            if not F[j] & _fk.FAMILY or F[j] & (_fk.EMPTY | _fk.LOCK) or not F2[j] & _fk.FAMILY \
                    or F2[j] & (_fk.DEFER | _fk.EMPTY):
                continue  # a lock is settled by its line alone (below)
            if E[j] <= exact_tol and (not limits or row_inside(rb, Q[j])):
                continue
            row, e = Q2[j], E2[j]
            if exact_tol < e < near:
                e = newton_steps(rb, g, row, 8)
            inside = not limits or row_inside(rb, row)
            if e <= exact_tol and inside:
                Q[j], E[j], F[j] = list(row), e, F2[j]
            elif inside and e < EB[j]:
                B[j], EB[j] = list(row), e
    for j in range(n):
        if not F[j] & _fk.FAMILY or F[j] & (_fk.DEFER | _fk.EMPTY):
            continue
        lock = F[j] & _fk.LOCK  # exact or not, a lock needs its line
        if not lock and E[j] <= exact_tol and (not limits or row_inside(rb, Q[j])):
            continue
        if j in verdict:
            found, t = verdict[j]
        elif line[j]:
            found, t = verdict[j] = _given_verdict(rb, verdict, j, line, Q0, S, tangent, root) \
                or line_verdict(rb, g, Q0[j], S[j], False, root[j])
        else:
            found, t = -2, 0.0
        if found != -2:
            if found == 0:
                F[j] |= _fk.EMPTY
                continue
            e3, row3 = math.inf, None
            if found == 1:
                Q3, E3, F3 = rb.leaves(chain, g, free, t)
                if len(Q3) == n and _plain_family(F3[j]):
                    row3, e3 = Q3[j], E3[j]
                    if exact_tol < e3 < near:
                        e3 = newton_steps(rb, g, row3, 15)
            if e3 <= exact_tol and row_inside(rb, row3):
                Q[j], E[j], F[j] = list(row3), e3, F3[j] & ~_fk.LOCK
                continue
        if lock:
            return PYTHON  # no line: the rest of the chain may fix the angle
        e = newton_steps(rb, g, B[j], 60)
        if e <= exact_tol and (not limits or row_inside(rb, B[j])):
            Q[j], E[j] = list(B[j]), e
    k = finish(rb, g, Q, E, F, limits)
    return PYTHON if k == FAMILY_MISS else k


def _polish_pending(rb: FinishRobot, Q, E, F, j: int, limits: bool) -> bool:
    """Whether family leaf j still looks for an exact representative inside the limits in
    :func:`settle_chain`'s polish (ikc_polish_pending): a later representative can change only those."""
    if not F[j] & _fk.FAMILY or F[j] & (_fk.EMPTY | _fk.LOCK):
        return False
    return not (E[j] <= rb.tol * rb.scale and (not limits or row_inside(rb, Q[j])))


def _fit_lines(rb: FinishRobot, r, rep, Q2, E2, F2, Q0, line, S):
    """Whether each candidate line's leaf at representative rep (the r-th) still lies on it, exactly;
    the first (r = 1) sets its slopes S (ikc_fit_lines)."""
    exact_tol, near = rb.tol * rb.scale, NEAR_MISS * rb.scale
    for j in range(len(Q0)):
        if line[j]:
            row, q0 = Q2[j], Q0[j]
            fits = _plain_family(F2[j]) and (
                E2[j] <= exact_tol or bool(F2[j] & _fk.TANGENT_ROOT) and E2[j] < near)
            for c in range(rb.dof):
                if not fits:
                    break
                d = joint_step(rb, c, row[c], q0[c])
                unit = 1.0 if rb.revolute[c] else rb.scale
                if r == 1:
                    sl = d / rep
                    whole = float(round(sl))
                    fits = (abs(sl - whole) <= LINE_FIT / rep if rb.revolute[c]
                            else abs(d) <= LINE_FIT * unit)
                    S[j][c] = whole if rb.revolute[c] else 0.0
                else:
                    fits = abs(joint_step(rb, c, d, S[j][c] * rep)) <= LINE_FIT * unit
            line[j] = fits


def _line_points_exact(rb: FinishRobot, g, q0, s, bound: float) -> bool:
    """Whether the line q0 + s rep misses the goal by at most ``bound`` (forward kinematics) at the
    representatives k pi / 4 (k = +-1, +-2, +-3, 4): with the chain's leaves at 0 and pi / 8, nine points
    around the closed line, the chain's grid at half its resolution (each point costs a quarter of a
    chain run; ikc_line_points_exact)."""
    for r, rep in _reps():
        if ((r + 1) // 2) % 2:
            continue
        if not measure(rb, g, [q0[c] + s[c] * rep for c in range(rb.dof)]) <= bound:
            return False
    return True


def quick_lines(rb: FinishRobot, chain, g, free, Q, E, F, Q0, line, S, tangent, root, first):
    """The settling of a target whose self-motion leaves are all straight-line candidates after the
    first other representative (first = its leaves), without running the chain at the other 14
    (docs/design.md section 6, "Lines checked by forward kinematics"): each line's points at every
    other of those representatives are checked by forward kinematics instead (exact, or for a tangent
    line within NEAR_MISS, as its leaves were: :func:`_line_points_exact`); a tangent line is judged
    first, as in the full loop, and must be dropped; an exact line's leaf takes the first
    representative whose line point lies inside the limits (the chain run there, its leaf on the line,
    exact and inside: what the full loop would take), or, with none, the line's verdict drops it (the
    line misses the limits) or takes the chain at its in-limit middle.  The rows of the full loop, or
    None where any step leaves the quick case (the full loop then runs from the start:
    ikc_quick_lines)."""
    dof, n = rb.dof, len(Q)
    exact_tol, near = rb.tol * rb.scale, NEAR_MISS * rb.scale
    Q1, E1, F1 = first
    pending = []
    for j in range(n):
        if not F[j] & _fk.FAMILY or F[j] & (_fk.DEFER | _fk.EMPTY):
            continue
        lock = F[j] & _fk.LOCK
        if not lock and E[j] <= exact_tol and row_inside(rb, Q[j]):
            continue
        if not line[j] or not (tangent[j] or E1[j] <= exact_tol):
            return None
        pending.append(j)
    if not pending:
        return None
    checked = []  # (q0, s) of the lines checked
    for j in pending:
        if not any(Q0[j] == q and S[j] == sl for q, sl in checked):
            if not _line_points_exact(rb, g, Q0[j], S[j], near if tangent[j] else exact_tol):
                return None
            checked.append((Q0[j], S[j]))
    runs = {1: first}  # the chain at a representative, run once
    verdict = {}
    Q, E, F = [list(row) for row in Q], list(E), list(F)  # the full loop starts afresh where this fails
    for j in pending:  # tangent lines first, as the full loop judges them before its polish
        if tangent[j]:
            verdict[j] = _given_verdict(rb, verdict, j, line, Q0, S, tangent, root) \
                or line_verdict(rb, g, Q0[j], S[j], True)
            if verdict[j][0] != 0:
                return None
            F[j] |= _fk.EMPTY
    for j in pending:
        if tangent[j]:
            continue
        taken = False
        if not F[j] & _fk.LOCK:
            for r, rep in _reps():
                if not row_inside(rb, [Q0[j][c] + S[j][c] * rep for c in range(dof)]):
                    continue
                if r not in runs:
                    runs[r] = rb.leaves(chain, g, free, rep)
                Q2, E2, F2 = runs[r]
                if len(Q2) != n or not _plain_family(F2[j]) or not E2[j] <= exact_tol \
                        or not row_inside(rb, Q2[j]):
                    return None
                for c in range(dof):
                    unit = 1.0 if rb.revolute[c] else rb.scale
                    d = joint_step(rb, c, Q2[j][c], Q0[j][c])
                    if not abs(joint_step(rb, c, d, S[j][c] * rep)) <= LINE_FIT * unit:
                        return None
                Q[j], E[j], F[j] = list(Q2[j]), E2[j], F2[j]
                taken = True
                break
        if taken:
            continue
        found, t = verdict[j] = _given_verdict(rb, verdict, j, line, Q0, S, tangent, root) \
            or line_verdict(rb, g, Q0[j], S[j], False, root[j])
        if found == 0:
            F[j] |= _fk.EMPTY
            continue
        if found != 1:
            return None
        Q3, E3, F3 = rb.leaves(chain, g, free, t)
        if len(Q3) != n or not _plain_family(F3[j]):
            return None
        row3, e3 = Q3[j], E3[j]
        if exact_tol < e3 < near:
            e3 = newton_steps(rb, g, row3, 15)
        if not (e3 <= exact_tol and row_inside(rb, row3)):
            return None
        Q[j], E[j], F[j] = list(row3), e3, F3[j] & ~_fk.LOCK
    k = finish(rb, g, Q, E, F, True)
    return PYTHON if k == FAMILY_MISS else k


def _any_flag(F, bit) -> bool:
    return any(not f & _fk.EMPTY and f & bit for f in F)


def settle_alternative(rb: FinishRobot, g, free, limits: bool):
    """A gimbal lock of the chain where the plan has an alternative chain: the alternative chain's
    finish where it meets no lock and no degenerate geometry, else FAMILY_MISS (ikc_settle_alternative)."""
    Qa, Ea, Fa = rb.leaves(rb.chain_alt, g, free, 0.0)
    if all(f & _fk.EMPTY for f in Fa) or _any_flag(Fa, _fk.FAMILY | _fk.DEFER | _fk.LOCK):
        return FAMILY_MISS
    k = finish(rb, g, Qa, Ea, Fa, limits)
    return PYTHON if k == FAMILY_MISS else k


def settle(rb: FinishRobot, g, free=(), limits: bool = True):
    """Rows ``(q, residual, ls, continuum)`` of one goal as the C finish gives them, or PYTHON."""
    k = settle_chain(rb, rb.chain, g, tuple(free), limits, try_alt=rb.chain_alt is not None)
    if k == PYTHON and rb.chain_alt is not None:
        k = settle_chain(rb, rb.chain_alt, g, tuple(free), limits)
    return k
