"""Exact symbolic Jacobians of a POE chain, as polynomials in ``cos``/``sin`` of the joint angles.

Numbers.  Each twist entry is turned into an exact number by :func:`exact_number`: ``p/q * sqrt(k)``
(q <= 1000, k in 2, 3, 6) when the float is within 1e-12 (relative) of one, so that unit axes at 30, 45
or 60 degrees (``0.7071067811865476``) become ``sqrt(2)/2``, keeping identities such as
``a**2 + b**2 = 1`` exact and the determinant factorable; any other number becomes the shortest decimal
within 1e-9 of the robot's size (lengths) or 1e-9 (directions), the project's structural tolerance: the
value the robot file wrote (``0.4318`` is ``2159/5000``; a URDF sum ``0.8172499999999999`` is
``0.81725``).  Never floats: a float determinant does not factor.

Algebra.  A revolute joint ``q`` enters as two ring generators ``c_q, s_q`` (its cosine and sine), a
prismatic joint as one ``d_q``; ``sqrt(2)``, ``sqrt(3)`` are generators too.  Every polynomial is kept
in the normal form modulo ``s**2 + c**2 - 1`` and ``r2**2 - 2``, ``r3**2 - 3`` (lex order with every
``s`` before its ``c``: the leading terms are coprime, so these relations are a Groebner basis and the
normal form is unique, of degree at most 1 in each ``s``).

Frames.  ``jacobian_in_frame(k)`` gives the Jacobian referred to the frame moved by the first ``k`` joints,
``J_k = Ad_{(g_1 ... g_k)^-1} J_s``: column ``i <= k`` depends on joints ``i+1..k`` only, column ``i > k``
on joints ``k+1..i-1`` only, so for ``k ~ n/2`` the entries are small.  Its maximal minors generate the
same ideal as those of ``J_s`` (``Ad`` is invertible with polynomial inverse), and for a square
Jacobian ``det J_k = det J_s`` (``det Ad = 1``): any ``k`` gives the same singular set.  See
docs/singularities.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import sympy as sp
from sympy import QQ

from ikcompiler.errors import IkcError
from subproblems.screw import cross_tuple

_IRRATIONALS = (sp.sqrt(2), sp.sqrt(3), sp.sqrt(6))


class SymbolicUnsupported(IkcError):
    """The chain has a feature the exact algebra does not cover (e.g. a non-integer revolute coupling)."""


def exact_number(x: float, tol: float = 1e-12, atol: float = 0.0) -> sp.Expr:
    """An exact number equal to ``x`` to ``tol`` (relative): ``p/q * sqrt(k)`` (q <= 1000, k in 1, 2, 3, 6),
    else the shortest decimal within ``max(tol * max(1, |x|), atol)``.

    >>> exact_number(0.7071067811865476), exact_number(0.4318), exact_number(-1e-17)
    (sqrt(2)/2, 2159/5000, 0)
    """
    x = float(x)
    if abs(x) <= max(tol, atol):
        return sp.Integer(0)
    # p/q or p/q * sqrt(k) with small q: unit axes at 30/45/60 degrees, halves, thirds ...
    for k in (1, 2, 3, 6):
        root = math.sqrt(k)
        f = Fraction(x / root).limit_denominator(1000)
        if abs(float(f) * root - x) <= tol * max(1.0, abs(x)) and abs(f.numerator) <= 10**6:
            return sp.Rational(f.numerator, f.denominator) * (sp.sqrt(k) if k > 1 else 1)
    # else the shortest decimal within tol: URDF sums such as 0.8172499999999999 are 0.81725
    for k in range(16):
        r = round(x * 10**k)
        if abs(r / 10**k - x) <= max(tol * max(1.0, abs(x)), atol):
            return sp.Rational(r, 10**k)
    return sp.Rational(repr(x))


@dataclass
class SymbolicChain:
    """The ring, its generators and the exact joint data of one chain (see the module docstring)."""

    chain: object
    ring: object
    names: tuple[str, ...]  # every joint, chain order
    gen_of: dict  # independent joint name -> (c, s) generators or (d,) for prismatic
    relations: list
    exprs: dict  # generator -> Expr in the joint-name symbols (cos(q), sin(q), q, sqrt(2))
    joint_cs: list  # per joint (every joint): (c, s) ring elements, or ("T", d) for prismatic
    twists: list  # per joint: 6 ring elements (exact)

    def nf(self, p):
        """Normal form modulo the trig and radical relations."""
        return p.rem(self.relations) if self.relations else p

    def to_expr(self, p) -> sp.Expr:
        """A ring element as a sympy expression over the joint-name symbols."""
        return p.as_expr().xreplace(self.exprs)

    # ---- twist algebra -----------------------------------------------------------------------------

    def _joint_motion(self, i: int, inverse: bool):
        """(R, p) of ``exp(xi_i th_i)`` (or its inverse) as 3x3 and 3 lists of ring elements."""
        R0 = self.ring
        v, w = self.twists[i][:3], self.twists[i][3:]
        one = R0.one
        cs = self.joint_cs[i]
        if cs[0] == "T":
            d = -cs[1] if inverse else cs[1]
            return [[one if a == b else R0.zero for b in range(3)] for a in range(3)], [x * d for x in v]
        c, s = cs
        if inverse:
            s = -s
        W = [[R0.zero, -w[2], w[1]], [w[2], R0.zero, -w[0]], [-w[1], w[0], R0.zero]]
        W2 = [[sum((W[a][k] * W[k][b] for k in range(3)), R0.zero) for b in range(3)] for a in range(3)]
        R = [[(one if a == b else R0.zero) + s * W[a][b] + (one - c) * W2[a][b] for b in range(3)]
             for a in range(3)]
        wxv = _cross(w, v)
        p = [wxv[a] - sum((R[a][k] * wxv[k] for k in range(3)), R0.zero) for a in range(3)]
        return [[self.nf(x) for x in row] for row in R], [self.nf(x) for x in p]

    def _adjoint(self, motion, xi):
        R, p = motion
        v, w = xi[:3], xi[3:]
        Rw = [sum((R[a][k] * w[k] for k in range(3)), self.ring.zero) for a in range(3)]
        Rv = [sum((R[a][k] * v[k] for k in range(3)), self.ring.zero) for a in range(3)]
        pxRw = _cross(p, Rw)
        return [self.nf(x) for x in [Rv[a] + pxRw[a] for a in range(3)] + Rw]

    def jacobian_in_frame(self, k: int) -> list[list]:
        """6 x dof ring-element Jacobian referred to the frame after joint ``k`` (0: the space Jacobian)."""
        n = len(self.names)
        cols = []
        for i in range(n):
            xi = list(self.twists[i])
            if i < k:  # Ad_{g_k^-1} ... Ad_{g_{i+1}^-1} xi_i   (0-based: joints i+1 .. k-1)
                for j in range(i + 1, k):
                    xi = self._adjoint(self._joint_motion(j, inverse=True), xi)
            else:  # Ad_{g_{k}} ... Ad_{g_{i-1}} xi_i, innermost first
                for j in range(i - 1, k - 1, -1):
                    xi = self._adjoint(self._joint_motion(j, inverse=False), xi)
            cols.append(xi)
        A, _ = self.chain.coupling_matrix()
        out = []
        for r in range(6):
            row = []
            for col in range(A.shape[1]):
                acc = self.ring.zero
                for i in range(n):
                    if A[i, col] != 0:
                        acc += self.ring(exact_number(A[i, col])) * cols[i][r]
                row.append(self.nf(acc))
            out.append(row)
        return out


def _cross(a, b):
    return list(cross_tuple(a, b))


def joint_symbols(chain) -> tuple[sp.Symbol, ...]:
    """One real sympy symbol per independent joint, named as the joint."""
    return tuple(sp.Symbol(n, real=True) for n in chain.independent_names)


def build(chain) -> SymbolicChain:
    """Exact ring, generators and twists of ``chain``; raises :class:`SymbolicUnsupported`."""
    indep = chain.independent_names
    kinds = {j.name: j.kind for j in chain.joints}
    qs = dict(zip(indep, joint_symbols(chain)))
    # lengths to 1e-9 of the robot's size (the project's structural tolerance), directions to 1e-9:
    # digits beyond that only slow the factoring down (a random 6R's 16-digit floats time out)
    atol = [1e-9 * chain.scale] * 3 + [1e-9] * 3
    twists_exact = [[exact_number(x, atol=a) for x, a in zip(j.twist, atol)] for j in chain.joints]
    radicals = [r for r in _IRRATIONALS if any(e.has(r) for tw in twists_exact for e in tw)]
    s_names = [f"s_{i}" for i, n in enumerate(indep) if kinds[n] == "R"]
    c_names = [f"c_{i}" for i, n in enumerate(indep) if kinds[n] == "R"]
    d_names = [f"d_{i}" for i, n in enumerate(indep) if kinds[n] == "T"]
    r_names = [f"r_{int(r.args[0])}" for r in radicals]
    gen_names = s_names + c_names + d_names + r_names
    if not gen_names:
        raise SymbolicUnsupported("the chain has no joints")
    R0, *gens = sp.ring(" ".join(gen_names), QQ)
    g = dict(zip(gen_names, gens))
    exprs, gen_of, relations = {}, {}, []
    for i, n in enumerate(indep):
        if kinds[n] == "R":
            c, s = g[f"c_{i}"], g[f"s_{i}"]
            gen_of[n] = (c, s)
            exprs[c.as_expr()] = sp.cos(qs[n])
            exprs[s.as_expr()] = sp.sin(qs[n])
            relations.append(s**2 + c**2 - 1)
        else:
            d = g[f"d_{i}"]
            gen_of[n] = (d,)
            exprs[d.as_expr()] = qs[n]
    rad_sub = {}
    for r, rn in zip(radicals, r_names):
        exprs[g[rn].as_expr()] = r
        rad_sub[r] = g[rn].as_expr()
        relations.append(g[rn] ** 2 - int(r.args[0]))

    def ring_num(e: sp.Expr):
        e = sp.expand(sp.sympify(e).xreplace(rad_sub))
        return R0.from_expr(e) if e.free_symbols else R0(e)

    # joint values of every joint from the independent ones: th_j = a th_k + b
    by_joint = {jn: (jn, 1.0, 0.0) for jn in indep}
    names = [j.name for j in chain.joints]
    for j, (k, a, b) in chain._resolve_couplings().items():
        by_joint[names[j]] = (names[k], a, b)
    joint_cs = []
    for jn in names:
        master, a, b = by_joint[jn]
        if kinds[jn] != kinds[master]:
            raise SymbolicUnsupported(f"joint {jn!r} ({kinds[jn]}) follows {master!r} ({kinds[master]})")
        if kinds[jn] == "T":
            (d,) = gen_of[master]
            joint_cs.append(("T", ring_num(exact_number(a)) * d + ring_num(exact_number(b))))
            continue
        c, s = gen_of[master]
        if abs(a - round(a)) > 1e-12 or round(a) == 0:
            raise SymbolicUnsupported(
                f"joint {jn!r} follows {master!r} with factor {a}: only integer factors are exact"
            )
        # cos(a t) + i sin(a t) = (c + i s)^|a|, then the sign of a and the offset b
        m = abs(int(round(a)))
        cm, sm = R0.one, R0.zero
        for _ in range(m):
            cm, sm = cm * c - sm * s, cm * s + sm * c
        if a < 0:
            sm = -sm
        cb, sb = ring_num(exact_number(math.cos(b))), ring_num(exact_number(math.sin(b)))
        cs = (cm * cb - sm * sb, sm * cb + cm * sb)
        rel = [x for x in relations]
        joint_cs.append(tuple(x.rem(rel) for x in cs))
    twists = [[ring_num(e) for e in tw] for tw in twists_exact]
    return SymbolicChain(chain, R0, tuple(names), gen_of, relations, exprs, joint_cs, twists)


def symbolic_jacobian(chain, frame: str = "space") -> sp.Matrix:
    """The exact 6 x dof Jacobian (rows v, w) in the joint-name symbols: ``"space"`` or ``"body"``.

    >>> from ikcompiler import load_robot
    >>> J = symbolic_jacobian(load_robot("arm4dof"))
    >>> J[5, 0], J[2, 2]
    (1, 250*sin(shoulder))
    """
    sc = build(chain)
    if frame == "space":
        J = sc.jacobian_in_frame(0)
    elif frame == "body":
        J = sc.jacobian_in_frame(len(sc.names))
        gi = np.linalg.inv(chain.home)
        Rh = [[sc.ring(0) + _ring_exact(sc, gi[a, b]) for b in range(3)] for a in range(3)]
        ph = [_ring_exact(sc, gi[a, 3]) for a in range(3)]
        cols = [sc._adjoint((Rh, ph), [J[r][c] for r in range(6)]) for c in range(len(J[0]))]
        J = [[cols[c][r] for c in range(len(cols))] for r in range(6)]
    else:
        raise ValueError(f"frame must be 'space' or 'body', got {frame!r}")
    return sp.Matrix([[sc.to_expr(x) for x in row] for row in J])


def _ring_exact(sc: SymbolicChain, x: float):
    e = exact_number(x)
    sub = {r: g for g, r in sc.exprs.items() if r in _IRRATIONALS}
    return sc.ring.from_expr(sp.expand(e.xreplace(sub))) if e.has(*_IRRATIONALS) else sc.ring(e)
