"""The singular configurations of a chain: exact conditions from the Jacobian's minors, confirmed by sampling.

A configuration is singular where the Jacobian (6 x dof) has rank below its generic rank ``r`` (``r`` is
``min(6, dof)`` unless the chain is singular everywhere).  That happens exactly where every ``r x r`` minor
vanishes.  Method (docs/singularities.md):

1. The minors are computed exactly (:mod:`ikcompiler.analysis.symbolic`, in the frame after joint
   ``n // 2`` where entries are small) and each is factored over the rationals through the half-angle
   tangent (:mod:`ikcompiler.analysis.trigfactor`), in a child process with a time budget.
2. The singular set is split into components by a search over the factors: start from the whole joint
   space; on a set ``V(S)`` (the common zeros of the equations ``S``) take a minor that does not vanish on
   it; the singular part of ``V(S)`` lies in ``V(S + [f])`` for the factors ``f`` of that minor.  A set
   ``V(S)`` on which the Jacobian is rank deficient at every one of a few random points (found by
   Gauss-Newton from random starts) is recorded as a condition; one without real points is dropped.  For a
   6-joint arm this is the factored ``det J``; for fewer joints the maximal minors have no common factor
   in general and the conditions are systems of two or more equations (reported as a sum of squares).
3. Sampling: N uniform configurations inside the limits; the smallest singular value of the size-free
   Jacobian (:mod:`subproblems.conditioning`) at each; those below ``threshold`` are near-singular, and
   each is projected (Gauss-Newton) onto every condition: it is *explained* when one lies within
   ``radius`` (radians; prismatic joints in units of the robot's size).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import multiprocessing
import time
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np
import sympy as sp

from subproblems.conditioning import singular_values

#: Default sampling parameters (documented in docs/singularities.md).
THRESHOLD = 1e-3
RADIUS = 0.2
SINGULAR_TOL = 1e-8  # sigma at a point found on a condition to 1e-12 rad
MAX_MINORS = 60


@dataclass(frozen=True)
class Condition:
    """One component of the singular set: every equation of ``equations`` is 0 there."""

    name: str
    equations: tuple[sp.Expr, ...]
    joints: tuple[str, ...]
    inside_limits: bool
    checked: int  # points found on it
    rank_deficient: int  # of those, how many have a rank-deficient Jacobian (all, for a reported one)
    description: str = ""

    @property
    def expr(self) -> sp.Expr:
        """One expression that is 0 exactly on the condition (a sum of squares for a system)."""
        if len(self.equations) == 1:
            return self.equations[0]
        return sp.Add(*[e**2 for e in self.equations])


@dataclass(frozen=True)
class Sampling:
    samples: int
    threshold: float
    near_singular: int
    explained: int
    lowest: tuple[tuple[float, tuple[float, ...]], ...] = ()  # (sigma_min, q) of the smallest samples
    Q: np.ndarray | None = None  # the samples and their sigma_min, for plotting
    sigma: np.ndarray | None = None
    nonsingular_minima: int = 0  # unexplained samples whose local minimum of sigma_min is not 0


@dataclass(frozen=True)
class SingularityReport:
    robot: str
    joints: tuple[str, ...]
    conditions: tuple[Condition, ...]
    singular_everywhere: bool
    generic_rank: int
    sampling: Sampling
    status: str  # "factored", "timeout", "unsupported"
    message: str = ""
    seconds: float = 0.0
    png: str | None = None
    notes: tuple[str, ...] = field(default=())

    def to_json(self) -> dict:
        """The object ``ikc singularities --json`` prints (schema of issue 12, plus ``symbolic``)."""
        return {
            "robot": self.robot,
            "joints": list(self.joints),
            "conditions": [
                {"name": c.name, "expr": sp.sstr(c.expr), "joints": list(c.joints),
                 "inside_limits": bool(c.inside_limits)}
                for c in self.conditions
            ],
            "singular_everywhere": bool(self.singular_everywhere),
            "sampling": {
                "samples": self.sampling.samples,
                "threshold": self.sampling.threshold,
                "near_singular": self.sampling.near_singular,
                "explained": self.sampling.explained,
            },
            "png": self.png,
            "symbolic": {
                "status": self.status,
                "message": self.message,
                "seconds": round(self.seconds, 3),
                "sigma_min_lowest": [{"sigma_min": s, "q": list(q)} for s, q in self.sampling.lowest],
                "unexplained_nonsingular_minima": self.sampling.nonsingular_minima,
            },
        }

    def text(self) -> str:
        lines = [f"{self.robot}: joints {', '.join(self.joints)}; generic Jacobian rank {self.generic_rank}"]
        if self.singular_everywhere:
            lines.append(
                f"  SINGULAR EVERYWHERE: the Jacobian never has rank {min(6, len(self.joints))}; "
                f"conditions below are where it drops below {self.generic_rank}"
            )
        if self.status != "factored":
            lines.append(f"  symbolic: {self.status}: {self.message}")
        if not self.conditions:
            lines.append("  no singular conditions found")
        for c in self.conditions:
            eqs = ", ".join(f"{sp.sstr(e)} = 0" for e in c.equations)
            where = "inside the limits" if c.inside_limits else "outside the limits"
            lines.append(f"  {c.name:9s} {eqs}   ({where}; rank deficient at {c.rank_deficient}/{c.checked}"
                         f" points on it{'; ' + c.description if c.description else ''})")
        s = self.sampling
        lines.append(
            f"  sampling: {s.samples} configurations, {s.near_singular} with sigma_min < {s.threshold:g}, "
            f"{s.explained} of them within {RADIUS} of a condition"
        )
        if s.lowest:
            lo = ", ".join(f"{v:.2e}" for v, _ in s.lowest[:5])
            lines.append(f"  smallest sigma_min sampled: {lo}")
        for n in self.notes:
            lines.append(f"  note: {n}")
        if self.png:
            lines.append(f"  wrote {self.png}")
        return "\n".join(lines)


# ---- numeric helpers -----------------------------------------------------------------------------------


class _Numeric:
    """Jacobian singular values and compiled equations of one chain."""

    def __init__(self, chain):
        self.chain = chain
        self.A, self.b = chain.coupling_matrix()
        self.syms = tuple(sp.Symbol(n, real=True) for n in chain.independent_names)
        self.kinds = "".join(chain.joints[i].kind for i in chain.independent)
        self.metric = np.array([1.0 if k == "R" else 1.0 / chain.scale for k in self.kinds])
        self._fns: dict = {}

    def sv(self, Q) -> np.ndarray:
        c = self.chain
        return singular_values(c.twists, self.A, self.b, c.home, np.atleast_2d(Q), c.scale)

    def box(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.chain.lower.copy(), self.chain.upper.copy()
        s = self.chain.scale
        lo[~np.isfinite(lo)] = -s
        hi[~np.isfinite(hi)] = s
        return lo, hi

    def fn(self, e: sp.Expr):
        """(value, gradient) functions of ``e`` over Q (N, dof)."""
        if e not in self._fns:
            f = sp.lambdify(self.syms, e, "numpy")

            def val(Q, f=f):
                return np.broadcast_to(np.asarray(f(*Q.T), dtype=float), Q.shape[:1])

            def grad(Q, val=val):
                # central differences: the gradient only steers Gauss-Newton and scales the distance
                # tests; the equations themselves are evaluated exactly
                h = 1e-6 / np.maximum(self.metric, 1e-300)
                out = np.empty(Q.shape)
                for k in range(Q.shape[1]):
                    d = np.zeros(Q.shape[1])
                    d[k] = h[k]
                    out[:, k] = (val(Q + d) - val(Q - d)) / (2 * h[k])
                return out

            self._fns[e] = (val, grad)
        return self._fns[e]

    def project(self, eqs, Q0, iters: int = 40) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-Newton from each row of Q0 onto ``eqs = 0``; (points, converged mask)."""
        Q = np.array(Q0, dtype=float)
        fns = [self.fn(e) for e in eqs]
        W = self.metric  # work in scaled coordinates so prismatic steps count like angles
        for _ in range(iters):
            F = np.stack([f(Q) for f, _ in fns], axis=1)  # (N, m)
            G = np.stack([g(Q) for _, g in fns], axis=1) / W  # (N, m, dof) w.r.t. scaled coordinates
            step = np.einsum("nij,nj->ni", np.linalg.pinv(G), F)
            step = np.clip(step, -0.5, 0.5)
            Q = Q - step / W
            if not np.any(np.abs(step) > 1e-15):  # NaN rows stop too: they never converge
                break
        F = np.stack([f(Q) for f, _ in fns], axis=1)
        G = np.stack([g(Q) for _, g in fns], axis=1) / W
        gn = np.linalg.norm(G, axis=2)
        ok = np.all(np.abs(F) <= 1e-11 * np.maximum(gn, 1e-300), axis=1) & np.all(gn > 0, axis=1)
        return Q, ok & np.all(np.isfinite(Q), axis=1)

    def vanishes(self, e: sp.Expr, Q, tol: float = 1e-8) -> np.ndarray:
        """First-order distance test |e| / |grad e| < tol (default: a polynomial that is 0 to rounding)."""
        f, g = self.fn(e)
        v = np.abs(f(Q))
        gn = np.linalg.norm(g(Q) / self.metric, axis=1)
        return (v <= tol * gn) | (v <= 1e-12 * (1 + np.abs(v)))

    def descend(self, Q0, rank: int, iters: int = 80) -> tuple[np.ndarray, np.ndarray]:
        """Damped Newton steps on sigma(q) = 0 (the rank-th singular value), from each row of Q0.

        Near a singular set sigma is about |a linear function| of the distance, so the full step
        ``sigma grad / |grad|**2`` lands on the set; a step that does not lower sigma is halved.  Returns
        (points, sigma at them).
        """
        Q = np.array(Q0, dtype=float)
        h = 1e-7 / self.metric
        s = self.sv(Q)[:, rank - 1]
        damp = np.ones(len(Q))
        for _ in range(iters):
            live = (s >= 1e-12) & (damp > 1e-6)
            if not live.any():
                break
            n, dof = Q.shape
            D = np.diag(h)  # every +-h_k perturbation of every row in one batch
            S = self.sv(np.concatenate([(Q[:, None, :] + D).reshape(-1, dof),
                                        (Q[:, None, :] - D).reshape(-1, dof)]))[:, rank - 1]
            G = (S[: n * dof] - S[n * dof:]).reshape(n, dof) / (2 * h)
            g2 = np.maximum((G * G).sum(axis=1), 1e-300)
            step = np.clip((damp * s / g2)[:, None] * G, -0.2, 0.2)
            trial = Q - np.where(live[:, None], step, 0.0)
            st = self.sv(trial)[:, rank - 1]
            better = live & (st < s)
            Q[better], s[better] = trial[better], st[better]
            damp = np.where(better, np.minimum(1.0, damp * 2), np.where(live, damp / 2, damp))
        return Q, s


def generic_rank(chain, rng) -> int:
    """Largest numeric rank of the size-free Jacobian over a few random configurations."""
    num = _Numeric(chain)
    lo, hi = num.box()
    sv = num.sv(rng.uniform(lo, hi, (8, chain.dof)))
    return int((sv > 1e-8 * sv[:, :1]).sum(axis=1).max())


# ---- symbolic stage (child process) ---------------------------------------------------------------------


class _LazyMinors:
    """The nonzero ``rank x rank`` minors, smallest first, each factored only when first asked for."""

    def __init__(self, chain, rank: int):
        from sympy.polys.matrices import DomainMatrix

        from ikcompiler.analysis.symbolic import build

        self.sc = sc = build(chain)
        J = sc.jacobian_in_frame(chain.n // 2)
        dof = len(J[0])
        dom = sc.ring.to_domain()
        minors = []
        for rows, cols in itertools.product(itertools.combinations(range(6), rank),
                                            itertools.combinations(range(dof), rank)):
            if len(minors) >= MAX_MINORS:
                break
            d = sc.nf(DomainMatrix([[J[r][c] for c in cols] for r in rows], (rank, rank), dom).det())
            if d != 0:
                minors.append(d)
        minors.sort(key=lambda p: len(p.terms()))
        self.minors = minors
        self._factored: dict[int, list[sp.Expr]] = {}

    def __len__(self) -> int:
        return len(self.minors)

    def __iter__(self):
        for i in range(len(self.minors)):
            yield self[i]

    def __getitem__(self, i: int) -> list[sp.Expr]:
        from ikcompiler.analysis.trigfactor import factor_trig

        if i not in self._factored:
            _, fl = factor_trig(self.sc, self.minors[i])
            self._factored[i] = [_tidy(f.expr) for f in fl]
        return self._factored[i]

    def factored(self) -> list[list[sp.Expr]]:
        return [self._factored[i] for i in sorted(self._factored)]


def _tidy(e: sp.Expr) -> sp.Expr:
    """A shorter equivalent form when trigsimp finds one quickly (sin(a)cos(b) + ... -> sin(a + b))."""
    if sp.count_ops(e) > 40:
        return e
    s = sp.trigsimp(e)
    s = sp.factor_terms(s)
    c, rest = s.as_coeff_Mul()
    if sp.count_ops(rest) < sp.count_ops(e) and rest.free_symbols == e.free_symbols:
        return rest
    return e


def _symbolic_stage(chain, rank: int, seed: int):
    """Minors, component search and simplest equations: [(equations, points, singular mask)]."""
    rng = np.random.default_rng(seed)
    minors = _LazyMinors(chain, rank)
    if not len(minors):
        return 0, []
    num = _Numeric(chain)
    found = _search(num, minors, rank, rng, max_depth=min(3, chain.dof))
    return len(minors), [(_simplest(num, S, P, minors.factored(), rng), P, sing) for S, P, sing in found]


def _child(chain, rank, seed, conn):
    try:
        conn.send(("ok", _symbolic_stage(chain, rank, seed)))
    except Exception as exc:  # reported to the parent, which says so and falls back to sampling
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
    conn.close()


def symbolic_components(chain, rank: int, budget: float, seed: int = 0):
    """Run :func:`_symbolic_stage` in a child process for at most ``budget`` seconds.

    Returns (status, message, components); status is "factored", "timeout" or "unsupported".
    """
    ctx = multiprocessing.get_context("fork")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(chain, rank, seed, child), daemon=True)
    proc.start()
    child.close()
    if parent.poll(budget):
        try:
            kind, payload = parent.recv()
        except EOFError:
            kind, payload = "error", "the symbolic process died"
    else:
        kind, payload = "timeout", None
    if proc.is_alive():
        proc.kill()
    proc.join(1)
    if kind == "ok":
        n_minors, comps = payload
        return "factored", "" if n_minors else "every minor of the Jacobian is identically zero", comps
    if kind == "timeout":
        return "timeout", f"sympy did not finish within {budget:g} s (raise --budget)", []
    return "unsupported", str(payload), []


# ---- the component search -------------------------------------------------------------------------------


def _search(num: _Numeric, minors: list[list[sp.Expr]], rank: int, rng, max_depth: int):
    """Equation sets S whose zero sets are singular everywhere (see the module docstring)."""
    lo, hi = num.box()
    span_lo = np.where(np.array([k == "R" for k in num.kinds]), -math.pi, lo)
    span_hi = np.where(np.array([k == "R" for k in num.kinds]), math.pi, hi)
    found: list[tuple[tuple[sp.Expr, ...], np.ndarray, np.ndarray]] = []

    def sing(Q):
        return num.sv(Q)[:, rank - 1] < SINGULAR_TOL

    def explore(S: tuple[sp.Expr, ...], depth: int):
        starts = rng.uniform(span_lo, span_hi, (12, num.chain.dof))
        if S:
            P, ok = num.project(S, starts)
            P = P[ok]
            if len(P) == 0:
                return  # no real points
        else:
            P = starts
        s = sing(P)
        if s.all():
            found.append((S, P, s))
            return
        if depth >= max_depth:
            return
        free = P[~s]
        for factors in minors:
            prod_vanishes = np.zeros(len(free), dtype=bool)
            for f in factors:
                prod_vanishes |= num.vanishes(f, free)
            if not prod_vanishes.all():
                break
        else:
            return
        for f in factors:
            if f in S or num.vanishes(f, P).all():
                continue
            explore(S + (f,), depth + 1)

    explore((), 0)
    # drop sets contained in another one (points of V(S1) satisfy S2), keep the first of equal ones
    keep = []
    for i, (S1, P1, s1) in enumerate(found):
        contained = False
        for j, (S2, P2, _) in enumerate(found):
            if i == j:
                continue
            in2 = all(num.vanishes(e, P1).all() for e in S2)
            in1 = all(num.vanishes(e, P2).all() for e in S1)
            if in2 and (not in1 or j < i):
                contained = True
                break
        if not contained:
            keep.append((S1, P1, s1))
    return keep


def _simplest(num: _Numeric, S, P, minors, rng) -> tuple[sp.Expr, ...]:
    """The simplest equations among the minors' factors with the same zero set as ``S`` (same count)."""
    if len(S) == 1:
        return tuple(S)
    lo, hi = num.box()

    def same(eqs) -> bool:  # V(eqs) contains V(S) by construction; is it inside V(S)?
        Q, ok = num.project(eqs, rng.uniform(lo, hi, (12, num.chain.dof)))
        return bool(ok.any()) and all(num.vanishes(e, Q[ok]).all() for e in S)

    for k in range(1, len(S)):  # fewer equations with the same zero set (sin(q) + cos(q) - 1, sin(q))
        sub = next((c for c in itertools.combinations(S, k) if same(c)), None)
        if sub is not None:
            S = sub
            break
    if len(S) == 1:
        return tuple(S)
    cands = sorted({f for fs in minors for f in fs if num.vanishes(f, P).all()}, key=sp.count_ops)[:8]
    combos = sorted(itertools.combinations(cands, len(S)), key=lambda c: sum(sp.count_ops(e) for e in c))
    for combo in combos:
        if sum(sp.count_ops(e) for e in combo) >= sum(sp.count_ops(e) for e in S):
            break
        if same(combo):
            return tuple(combo)
    return tuple(S)


def _inside(num: _Numeric, S, rng, n: int = 64) -> bool:
    lo, hi = num.box()
    P, ok = num.project(S, rng.uniform(lo, hi, (n, num.chain.dof)))
    P = P[ok]
    if len(P) == 0:
        return False
    rev = np.array([k == "R" for k in num.kinds])
    # a revolute angle is inside when some th + 2 pi k is
    shifted = np.where(rev, lo + np.mod(P - lo, 2 * math.pi), P)
    inside = np.all((shifted >= lo - 1e-9) & (shifted <= hi + 1e-9), axis=1)
    return bool(inside.any())


def _name(num: _Numeric, S, P, joints: tuple[str, ...]) -> tuple[str, str]:
    """(name, description) from the joints involved and the axes' geometry at the points P on it."""
    chain = num.chain
    names = chain.independent_names
    dof = chain.dof
    pos = sorted(names.index(j) for j in joints)
    from subproblems.conditioning import space_jacobian

    J = space_jacobian(chain.twists, num.A, num.b, P)  # (N, 6, dof)
    g = chain.fk_batch(P)
    tool = g[:, :3, 3]
    rev = [i for i, k in enumerate(num.kinds) if k == "R"]

    def line(i):  # point and direction of revolute joint i's axis at each P
        w = J[:, 3:, i]
        return np.cross(w, J[:, :3, i]), w

    def on_axis(pts, i):
        r, w = line(i)
        d = np.linalg.norm(np.cross(pts - r, w), axis=1)
        return bool(np.all(d < 1e-6 * chain.scale))

    desc = []
    for a, b in itertools.combinations(rev, 2):
        ra, wa = line(a)
        rb, wb = line(b)
        if np.all(np.linalg.norm(np.cross(wa, wb), axis=1) < 1e-7) and \
                np.all(np.linalg.norm(np.cross(rb - ra, wa), axis=1) < 1e-7 * chain.scale):
            desc.append(f"axes of {names[a]} and {names[b]} collinear")
    centre = None
    last = rev[-3:] if len(rev) >= 3 else []
    if len(last) == 3 and last[0] >= dof - 3:
        # the wrist centre: the least-squares common point of the last three axes, if they meet
        pts = []
        for n_ in range(len(P)):
            Ms, vs = [], []
            for i in last:
                r, w = line(i)
                Pm = np.eye(3) - np.outer(w[n_], w[n_])
                Ms.append(Pm)
                vs.append(Pm @ r[n_])
            c = np.linalg.lstsq(np.sum(Ms, axis=0), np.sum(vs, axis=0), rcond=None)[0]
            if max(np.linalg.norm(np.cross(c - line(i)[0][n_], line(i)[1][n_])) for i in last) \
                    < 1e-6 * chain.scale:
                pts.append(c)
        if len(pts) == len(P):
            centre = np.array(pts)
    point = centre if centre is not None else tool
    what = "wrist centre" if centre is not None else "tool origin"
    first = rev[0] if rev else None
    if first is not None and first not in last and on_axis(point, first):
        desc.append(f"{what} on the axis of {names[first]}")
    lin = J[:, :3, :] + np.cross(J[:, 3:, :], tool[:, :, None], axis=1)
    lin_rank = min(np.linalg.matrix_rank(L, tol=1e-7 * chain.scale) for L in lin)
    pos_deficient = lin_rank < min(3, dof)
    if pos_deficient:
        desc.append("the tool origin cannot move in some direction")
    on_first = any("on the axis" in d for d in desc)
    if dof >= 5 and pos and pos[0] >= dof - 3:
        name = "wrist"  # only the last three joints: the wrist's axes line up
    elif dof >= 6 and pos == [2]:
        name = "elbow"  # the third joint alone: the arm stretched or folded
    elif dof >= 6 and (on_first or (pos and pos[0] >= 1 and pos[-1] <= dof - 3)):
        name = "shoulder"  # the first three joints: the wrist centre on (or degenerate about) axis 1
    elif pos_deficient:
        name = "boundary"  # the tool origin loses a direction: the edge of its workspace
    elif on_first:
        name = "shoulder"
    else:
        name = "interior"
    return name, "; ".join(desc)


# ---- sampling -------------------------------------------------------------------------------------------


def sample(chain, conditions, rank: int, n: int, threshold: float, rng) -> Sampling:
    num = _Numeric(chain)
    lo, hi = num.box()
    Q = rng.uniform(lo, hi, (n, chain.dof))
    sigma = num.sv(Q)[:, rank - 1]
    near = np.flatnonzero(sigma < threshold)
    explained = np.zeros(len(near), dtype=bool)
    nonsingular = 0
    rev = np.array([k == "R" for k in num.kinds])
    for c in conditions:
        if not len(near):
            break
        P, ok = num.project(c.equations, Q[near])
        dw = (P - Q[near] + math.pi) % (2 * math.pi) - math.pi  # angles modulo 2 pi
        d = np.linalg.norm(np.where(rev, dw, (P - Q[near]) * num.metric), axis=1)
        explained |= ok & (d <= RADIUS)
    if (~explained).any():
        # farther than RADIUS from every condition: follow sigma_min down to the singular point the sample
        # leads to, and accept when that point lies on a reported condition
        idx = near[~explained]
        P, s_end = num.descend(Q[idx], rank)
        on = np.zeros(len(idx), dtype=bool)
        for c in conditions:
            on |= np.all([num.vanishes(e, P, tol=1e-6) for e in c.equations], axis=0)
        rest = np.flatnonzero(~explained)
        explained[rest[(s_end < 1e-10) & on]] = True
        # the others: a local minimum of sigma_min that is not 0 (no singular configuration there), or a
        # singular point no condition describes (a missing component: reported)
        nonsingular = int(((s_end >= 1e-8) & ~on).sum())
    order = np.argsort(sigma)[:5]
    lowest = tuple((float(sigma[i]), tuple(float(x) for x in Q[i])) for i in order)
    return Sampling(n, threshold, int(len(near)), int(explained.sum()), lowest, Q, sigma, nonsingular)


# ---- the ideal robot of a calibrated one ----------------------------------------------------------------


def _nice(chain) -> bool:
    """Every twist entry is a short exact number (at most 6 decimals or a small radical)."""
    from ikcompiler.analysis.symbolic import exact_number

    atol = [1e-9 * chain.scale] * 3 + [1e-9] * 3
    for j in chain.joints:
        for x, a in zip(j.twist, atol):
            e = exact_number(x, atol=a)
            if any(r.q > 10**6 for r in e.atoms(sp.Rational)):
                return False
    return True


def ideal_chain(chain, tol: float = 1e-3):
    """(ideal chain, largest twist change relative to the size) of a calibrated chain.

    Near-parallel and near-meeting axes are snapped (:func:`ikcompiler.geometry.snap.snap_chain`, the
    compiler's own ideal robot), then every axis direction is replaced by the nearest ``p/q * sqrt(k)``
    components (q <= 12, within ``tol``) when those make a unit vector, and every axis point by the
    shortest decimals within ``tol`` of the size: the design robot the numbers were calibrated from.
    """
    from ikcompiler.analysis.symbolic import exact_number
    from ikcompiler.geometry.snap import snap_chain
    from ikcompiler.model.chain import Joint
    from subproblems.screw import prismatic_twist, revolute_twist

    snapped, _ = snap_chain(chain)
    size = chain.scale
    joints = []
    for j in snapped.joints:
        w = j.axis
        we = []
        for x in w:
            e = None
            for k in (1, 2, 3, 6):
                f = Fraction(x / math.sqrt(k)).limit_denominator(12)
                if abs(float(f) * math.sqrt(k) - x) <= tol:
                    e = sp.Rational(f.numerator, f.denominator) * sp.sqrt(k)
                    break
            we.append(e)
        if all(e is not None for e in we) and sp.simplify(sum(e**2 for e in we) - 1) == 0:
            w = np.array([float(e) for e in we])
        if j.kind == "R":
            r = np.array([float(exact_number(x, tol=0.0, atol=tol * size)) for x in j.point])
            tw = revolute_twist(w, r)
        else:
            tw = prismatic_twist(w)
        joints.append(Joint(j.name, j.kind, tw, j.lower, j.upper))
    ideal = dataclasses.replace(chain, joints=tuple(joints), name=chain.name)
    change = np.abs(ideal.twists - chain.twists)
    change[:, :3] /= size
    return ideal, float(change.max())


# ---- entry point ----------------------------------------------------------------------------------------


def analyse(chain, samples: int = 10000, threshold: float = THRESHOLD, budget: float = 8.0,
            seed: int = 0) -> SingularityReport:
    """The singular set of ``chain`` (symbolic conditions + sampling).

    >>> from ikcompiler import load_robot
    >>> rep = analyse(load_robot("stanford"), samples=500)
    >>> sorted(sp.sstr(c.expr) for c in rep.conditions)
    ['d3', 'sin(j2)', 'sin(j5)']
    """
    start = time.perf_counter()
    rng = np.random.default_rng(seed)
    rank = generic_rank(chain, rng)
    everywhere = rank < min(6, chain.dof)
    notes = []
    sym_chain = chain
    nice = _nice(chain)
    # long decimals (a calibrated URDF, or derived lengths such as jaco's): try the robot as loaded with
    # part of the budget, then the ideal robot, whose short numbers factor fast
    first = budget if nice else 0.4 * budget
    status, message, found = symbolic_components(chain, rank, first, seed)
    if status == "timeout" and not nice:
        sym_chain, change = ideal_chain(chain)
        status, message, found = symbolic_components(sym_chain, rank, budget - first, seed)
        notes.append(
            f"the robot as loaded did not factor within {first:g} s: conditions derived on its ideal robot "
            f"(axes snapped and rounded to 1e-3 of the size; largest twist change {change:.1e} of the size) "
            "and checked rank deficient there; sampled on the robot as loaded"
        )
    conditions = []
    num_sym = _Numeric(sym_chain)
    for S, P, sing in found:
        joints = tuple(n for n in chain.independent_names
                       if any(sp.Symbol(n, real=True) in e.free_symbols for e in S))
        name, desc = _name(num_sym, S, P, joints)
        inside = _inside(num_sym, S, rng)
        conditions.append(Condition(name, tuple(S), joints, inside, len(P), int(sing.sum()), desc))
    conditions.sort(key=lambda c: (len(c.equations), c.joints[::-1] if c.joints else ()))
    sampling = sample(chain, conditions, rank, samples, threshold, rng)
    unexplained = sampling.near_singular - sampling.explained
    if unexplained:
        notes.append(
            f"{unexplained} near-singular samples lie farther than {RADIUS} from every condition"
            + (" (no symbolic conditions)" if not conditions else "")
            + f"; {sampling.nonsingular_minima} of them lead down to a local minimum of sigma_min that is "
            "not 0 (no singular configuration there)"
        )
    return SingularityReport(
        robot=chain.name, joints=chain.independent_names, conditions=tuple(conditions),
        singular_everywhere=everywhere, generic_rank=rank, sampling=sampling, status=status,
        message=message, seconds=time.perf_counter() - start, notes=tuple(notes),
    )


# ---- seed 004's method: reciprocal screws, then the determinant of the remaining rows --------------------

ROWS = ("vx", "vy", "vz", "wx", "wy", "wz")  # the rows of a twist (v, w)


def reciprocal_free_rows(chain, q) -> tuple[str, ...]:
    """The twist components seed 004 removes: the free variables of ``W^T V = 0`` at configuration ``q``.

    ``W`` spans the screws reciprocal to the joint twists (the left null space of the space Jacobian:
    a wrench (f, m) does no work on every twist the chain can make); the ``6 - dof`` equations ``W^T V = 0``
    tie the twist components together, and Gaussian elimination in the order v_x, v_y, v_z, w_x, w_y, w_z
    picks ``6 - dof`` of them as the ones the others determine.  A chain with dof >= 6 removes none.
    """
    from ikcompiler.analysis.jacobian import space_jacobians

    J = space_jacobians(chain, np.asarray(q, dtype=float)[None, :])[0]
    u, s, _ = np.linalg.svd(J)
    rank = int((s > 1e-9 * s[0]).sum())
    W = u[:, rank:]  # (6, 6 - rank)
    free, M = [], W.T.copy()
    for col in range(6):  # pivots of the row echelon form of W^T
        if len(free) == M.shape[0]:
            break
        r = len(free)
        piv = r + int(np.argmax(np.abs(M[r:, col]))) if r < M.shape[0] else None
        if piv is None or abs(M[piv, col]) < 1e-9:
            continue
        M[[r, piv]] = M[[piv, r]]
        M[r] /= M[r, col]
        for k in range(M.shape[0]):
            if k != r:
                M[k] -= M[k, col] * M[r]
        free.append(ROWS[col])
    return tuple(free)


def reduced_conditions(chain, rows=None, q=None) -> tuple[tuple[str, ...], list[sp.Expr]]:
    """Seed 004's singular conditions: the factors of det of the space Jacobian's kept ``rows``.

    ``rows`` defaults to the complement of :func:`reciprocal_free_rows` at ``q`` (default: a fixed generic
    configuration).  This is a *task* singularity (the chain cannot produce every velocity of the kept
    components); the full singular set (:func:`analyse`) is where the whole Jacobian loses rank, which
    implies every such determinant vanishes.  Returns (kept rows, factors).

    >>> from ikcompiler import load_robot
    >>> rows, factors = reduced_conditions(load_robot("grasp4dof"))
    >>> rows, sorted(map(str, factors))
    (('vz', 'wx', 'wy', 'wz'), ['cos(shoulder)', 'sin(elbow + shoulder)'])
    """
    from sympy.polys.matrices import DomainMatrix

    from ikcompiler.analysis.symbolic import build
    from ikcompiler.analysis.trigfactor import factor_trig

    if rows is None:
        if q is None:
            q = np.random.default_rng(12).uniform(-1.0, 1.0, chain.dof)
        free = reciprocal_free_rows(chain, q)
        rows = tuple(r for r in ROWS if r not in free)
    rows = tuple(rows)
    if len(rows) != chain.dof or any(r not in ROWS for r in rows):
        raise ValueError(f"need {chain.dof} distinct rows among {', '.join(ROWS)}, got {rows}")
    sc = build(chain)
    J = sc.jacobian_in_frame(0)
    M = DomainMatrix([[J[ROWS.index(r)][c] for c in range(chain.dof)] for r in rows], (len(rows),) * 2,
                     sc.ring.to_domain())
    _, fl = factor_trig(sc, sc.nf(M.det()))
    return rows, [_tidy(f.expr) for f in fl]
