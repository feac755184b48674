"""Factor a polynomial in ``cos``/``sin`` of joint angles exactly, through the half-angle tangent.

The ring of trigonometric polynomials is not a unique factorisation domain (``s**2 = (1 - c)(1 + c)``),
so factoring the ``(c, s)`` normal form as if ``c`` and ``s`` were free misses factors: the PUMA's
``elbow * shoulder`` product does not split.  With ``t = tan(th/2)``, ``c = (1 - t**2)/(1 + t**2)``,
``s = 2t/(1 + t**2)``, a polynomial ``P`` of degree ``e`` in ``(c, s)`` becomes
``N(t) = P (1 + t**2)**e``, a polynomial over the rationals, where factorisation is unique.  The root
``th = pi`` (``t = oo``) shows as a drop of ``deg_t N`` below ``2e``; it is kept as the factor
``cos(th/2)``.  Each factor of ``N`` is mapped back to full angles (a factor of even degree ``2m`` in
``t`` times ``cos(th/2)**2m``: ``sin(th/2)**j cos(th/2)**(2m-j)`` is a polynomial in ``c, s``); a factor
of odd degree is paired with the ``th = pi`` factor of the same joint (``t * cos(th/2)**2`` is ``s/2``),
and one that cannot be paired is reported with half angles.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp
from sympy import QQ


@dataclass(frozen=True)
class TrigFactor:
    """One factor: the condition ``expr = 0`` over the joint-name symbols, and its multiplicity."""

    expr: sp.Expr
    multiplicity: int


def _degree_in(p, gens_idx) -> int:
    return max((sum(m[i] for i in gens_idx) for m in p.monoms()), default=0)


def factor_trig(sc, P) -> tuple[object, list[TrigFactor]]:
    """(constant, factors) of the ring element ``P`` of a ``SymbolicChain``.

    Each factor's zero set is part of ``P = 0``, and their union is all of it (``th = pi`` included).
    """
    R0 = sc.ring
    gnames = [str(g) for g in R0.gens]
    rev = [n for n in gnames if n.startswith("c_")]
    others = [n for n in gnames if not n.startswith(("c_", "s_"))]
    tnames = [f"t_{n[2:]}" for n in rev] + others
    T, *tg = sp.ring(" ".join(tnames), QQ)
    tmap = dict(zip(tnames, tg))
    idx = {n: i for i, n in enumerate(gnames)}
    # degree of P in each (c_i, s_i) pair
    e = {n[2:]: _degree_in(P, (idx[n], idx["s_" + n[2:]])) for n in rev}
    N = T.zero
    for monom, coeff in P.terms():
        term = T(coeff)
        for n, g in zip(gnames, monom):
            if n.startswith("c_") or n.startswith("s_"):
                continue
            term *= tmap[n] ** g
        for n in rev:
            k = n[2:]
            a, b = monom[idx[n]], monom[idx["s_" + k]]
            t = tmap[f"t_{k}"]
            term *= (1 - t**2) ** a * (2 * t) ** b * (1 + t**2) ** (e[k] - a - b)
        N += term
    if N == 0:
        return 0, []
    const, flist = N.factor_list()
    deficit = {k: 2 * e[k] - N.degree(tmap[f"t_{k}"]) for k in e}
    infinity = {k: d for k, d in deficit.items() if d > 0}
    out: list[TrigFactor] = []
    pending = []
    for f, m in flist:
        odd = {k for k in e if f.degree(tmap[f"t_{k}"]) % 2}
        if not odd:
            out.append(TrigFactor(_to_full(sc, T, f, {}), m))
        else:
            pending.append((f, m, odd))
    # t itself (th = 0) with the th = pi root first: t * cos(th/2)**2 is sin(th)/2
    rest = []
    for f, m, odd in pending:
        (k,) = odd if len(odd) == 1 else (None,)
        if k is not None and f == tmap[f"t_{k}"] and infinity.get(k, 0) >= m:
            infinity[k] -= m
            out.append(TrigFactor(_to_full(sc, T, f, {k: 1}), m))
        else:
            rest.append((f, m, odd))
    pending = rest
    # two odd factors of the same joints make an even product: (t - 1)(t + 1) is -cos(th) up to (1 + t**2)
    paired = []
    while pending:
        f, m, odd = pending.pop(0)
        mate = next((i for i, (g, mg, og) in enumerate(pending) if og == odd and mg == m), None)
        if mate is not None:
            g, _, _ = pending.pop(mate)
            out.append(TrigFactor(_to_full(sc, T, f * g, {}), m))
        else:
            paired.append((f, m, odd))
    for f, m, odd in paired:
        # else pair with the th = pi factor of every odd joint, as often as the multiplicities allow
        if all(infinity.get(k, 0) >= m for k in odd):
            for k in odd:
                infinity[k] -= m
            out.append(TrigFactor(_to_full(sc, T, f, {k: 1 for k in odd}), m))
        else:
            out.append(TrigFactor(_to_half(sc, T, f), m))
    for k, d in infinity.items():
        if d >= 2:
            out.append(TrigFactor(1 + _cos(sc, k), d // 2))  # cos(th/2)**2 = (1 + cos th)/2
        if d % 2:
            out.append(TrigFactor(sp.cos(_sym(sc, k) / 2), 1))
    return const, out


def _sym(sc, k: str) -> sp.Symbol:
    return sc.exprs[sc.ring.gens[[str(g) for g in sc.ring.gens].index(f"c_{k}")].as_expr()].args[0]


def _cos(sc, k: str) -> sp.Expr:
    return sp.cos(_sym(sc, k))


def _to_full(sc, T, f, extra: dict) -> sp.Expr:
    """``f(t) * prod cos(th/2)**(deg + extra)`` as a full-angle polynomial expression (even total degree)."""
    gn = [str(g) for g in T.gens]
    tk = [n[2:] for n in gn if n.startswith("t_")]
    R0 = sc.ring
    rg = {str(g): g for g in R0.gens}
    out = R0.zero
    K = {k: f.degree(T.gens[gn.index(f"t_{k}")]) + extra.get(k, 0) for k in tk}
    half = R0(sp.Rational(1, 2))
    for monom, coeff in f.terms():
        term = R0(coeff)
        for n, p in zip(gn, monom):
            if n.startswith("t_"):
                k = n[2:]
                c, s = rg[f"c_{k}"], rg[f"s_{k}"]
                m2, j = K[k], p
                sin2, cos2 = (1 - c) * half, (1 + c) * half
                if j % 2 == 0:
                    term *= sin2 ** (j // 2) * cos2 ** ((m2 - j) // 2)
                else:
                    term *= s * half * sin2 ** ((j - 1) // 2) * cos2 ** ((m2 - j - 1) // 2)
            else:
                term *= rg[n] ** p
        out += term
    out = sc.nf(out)
    _, out = out.primitive()
    if out.LC < 0:
        out = -out
    return sc.to_expr(out)


def _primitive(e: sp.Expr) -> sp.Expr:
    """``e`` without its numeric content (``2*sin(q)/3 -> sin(q)``)."""
    e = sp.factor(e)
    _, e = e.as_coeff_Mul()
    if e.is_Add:
        _, e = sp.primitive(e)
    return e


def _to_half(sc, T, f) -> sp.Expr:
    """``f`` with ``t = sin(th/2)/cos(th/2)`` cleared of denominators: a half-angle expression."""
    subs = {}
    gn = [str(g) for g in T.gens]
    for n, g in zip(gn, T.gens):
        if n.startswith("t_"):
            q = _sym(sc, n[2:])
            subs[g.as_expr()] = sp.tan(q / 2)
        else:
            subs[g.as_expr()] = sc.to_expr(sc.ring.gens[[str(x) for x in sc.ring.gens].index(n)])
    e = f.as_expr().xreplace(subs)
    return _primitive(sp.together(e.rewrite(sp.sin)).as_numer_denom()[0])
