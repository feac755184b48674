"""All roots of a scalar function on an interval: the 1-D search helper of the compiler's fallback.

Problem: given a continuous ``f`` on ``[a, b]`` (or on the circle ``[a, a + P)`` for a periodic angle),
return **every** ``x`` with ``f(x) = 0``, sorted and without duplicates.

When the compiler finds no closed-form chain it treats one joint as known, solves the rest in closed
form and searches the residual of the remaining equation over that joint's range (docs/design.md section 5).
This module is that search.  It is not a registered subproblem (it has no twists); it is called with a
function.

Method
------
1. **Grid.**  ``f`` is sampled on ``grid + 1`` equally spaced points (``grid`` points for a periodic
   interval, whose last cell wraps back to ``a``; ``b = a + P`` is never returned next to ``a``).
2. **Sign changes.**  Every cell whose end values have strictly opposite signs holds a root; it is
   refined by a safeguarded secant (Illinois false position, with bisection whenever a step does not
   halve the bracket) until the bracket is a few ulps wide or ``f`` is exactly zero.  Grid values that
   are exactly zero are roots as they stand.
3. **Tangential roots.**  Every local minimum of ``|f|`` over the grid without a sign change (the ends
   of a non-periodic interval included, one-sided) is polished by golden-section minimisation of
   ``s f`` (``s`` the sign there) over its two neighbouring cells.  If the minimum reaches ``|f| <=
   ftol`` it is a double (even-multiplicity) root; if the minimisation finds a point of the opposite
   sign, the two simple roots on either side are bracketed and refined as in step 2.
4. **Deduplication.**  Roots closer than ``merge`` (default ``1e-8 (b - a)``) are one; the one with the
   smaller ``|f|`` is kept.

Guarantees (for ``f`` continuous; ``h = (b - a) / grid`` the grid step):

* every simple root that is alone in its grid cell is found to machine precision (``|f| = 0`` or a
  bracket of a few ulps);
* a cell with an odd number of roots yields at least one of them;
* two roots in one cell (a cell with an even count: no sign change) are found only when ``|f|`` has a
  grid local minimum next to them; double roots and pairs of roots closer than about ``h`` may be
  missed when ``f`` is not convex-like on the scale of ``h`` -- **root spacing below ``h`` is the blind
  spot**; raise ``grid`` when the function oscillates faster;
* a double root is located to about ``sqrt(eps)`` relative (the problem is ill-conditioned: ``f`` is
  flat there), with ``|f| <= ftol``; ``ftol`` defaults to ``1e-12`` times the largest ``|f|`` on the
  grid, so a near miss ``0 < min |f| <= ftol`` is reported as a root (by design: it is a root to that
  tolerance);
* roots at the interval ends are found (an end value of exactly zero, or a one-sided local minimum of
  ``|f|`` within ``ftol``).

Two forms: :func:`find_roots` (one scalar function, plain floats) and :func:`find_roots_batch` (``N``
functions given as one vectorised callable ``f(X)`` on an ``(N, k)`` array, row ``i`` evaluated with
function ``i``; no Python loop over the ``N`` functions).

>>> import math
>>> [round(x, 12) for x in find_roots(math.sin, -math.pi, math.pi, periodic=True)]
[-3.14159265359, 0.0]
>>> [round(x, 9) for x in find_roots(lambda x: (x - 1.0) ** 2 * (x + 2.0), -3.0, 3.0)]
[-2.0, 1.0]
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["find_roots", "find_roots_batch"]

_GOLD = (math.sqrt(5.0) - 1.0) / 2.0
_EPS = np.finfo(float).eps


# ----------------------------------------------------------------------------------------- scalar


def _refine_bracket(f: Callable[[float], float], lo: float, hi: float, flo: float, fhi: float) -> float:
    """A root of f in [lo, hi] with f(lo) f(hi) < 0, to a few ulps (Illinois + bisection)."""
    side = 0
    width = abs(hi - lo)
    for _ in range(200):
        if abs(hi - lo) <= 4.0 * _EPS * max(abs(lo), abs(hi), 1e-300):
            break
        x = (lo * fhi - hi * flo) / (fhi - flo)
        if not (min(lo, hi) < x < max(lo, hi)):
            x = 0.5 * (lo + hi)
        fx = f(x)
        if fx == 0.0:
            return x
        if (fx > 0) == (flo > 0):
            lo, flo = x, fx
            if side == -1:
                fhi *= 0.5
            side = -1
        else:
            hi, fhi = x, fx
            if side == 1:
                flo *= 0.5
            side = 1
        new_width = abs(hi - lo)
        if new_width > 0.5 * width:  # slow progress: bisect once
            m = 0.5 * (lo + hi)
            fm = f(m)
            if fm == 0.0:
                return m
            if (fm > 0) == (flo > 0):
                lo, flo = m, fm
            else:
                hi, fhi = m, fm
            side = 0
        width = abs(hi - lo)
    return lo if abs(f(lo)) <= abs(f(hi)) else hi


def _minimise(g: Callable[[float], float], lo: float, hi: float, iters: int = 80):
    """Golden-section minimum of g on [lo, hi]; stops early when g becomes negative.

    Returns (x, g(x)).
    """
    x1 = hi - _GOLD * (hi - lo)
    x2 = lo + _GOLD * (hi - lo)
    g1, g2 = g(x1), g(x2)
    for _ in range(iters):
        if g1 < 0.0:
            return x1, g1
        if g2 < 0.0:
            return x2, g2
        if abs(hi - lo) <= 4.0 * _EPS * max(abs(lo), abs(hi), 1e-300):
            break
        if g1 <= g2:
            hi, x2, g2 = x2, x1, g1
            x1 = hi - _GOLD * (hi - lo)
            g1 = g(x1)
        else:
            lo, x1, g1 = x1, x2, g2
            x2 = lo + _GOLD * (hi - lo)
            g2 = g(x2)
    return (x1, g1) if g1 <= g2 else (x2, g2)


def find_roots(
    f: Callable[[float], float],
    a: float,
    b: float,
    *,
    grid: int = 256,
    periodic: bool = False,
    ftol: float | None = None,
    merge: float | None = None,
) -> list[float]:
    """Every root of the scalar function ``f`` on ``[a, b]``, sorted, deduplicated.

    ``periodic=True`` treats ``[a, b)`` as a circle of period ``b - a`` (angles): a root at ``b`` is
    returned as ``a``.  ``ftol`` is the ``|f|`` accepted for a tangential (double) root, by default
    ``1e-12 max |f(grid)|``; ``merge`` is the distance under which two roots are one (default
    ``1e-8 (b - a)``).  See the module docstring for what can be missed.

    >>> import math
    >>> [round(x, 12) for x in find_roots(lambda x: math.cos(x) - 0.5, 0.0, 2 * math.pi, periodic=True)]
    [1.047197551197, 5.235987755983]
    >>> find_roots(lambda x: x * x + 1.0, -1.0, 1.0)
    []
    """
    a, b = float(a), float(b)
    if not (b > a) or grid < 2:
        raise ValueError(f"find_roots needs b > a and grid >= 2, got [{a}, {b}], grid={grid}")
    P = b - a
    n = int(grid)
    xs = [a + P * k / n for k in range(n + 1)]
    fs = [float(f(x)) for x in xs[:n]]
    fs.append(fs[0] if periodic else float(f(b)))
    if not all(math.isfinite(v) for v in fs):
        raise ValueError("find_roots: f is not finite on the grid")
    fmax = max(abs(v) for v in fs)
    if ftol is None:
        ftol = 1e-12 * fmax
    if merge is None:
        merge = 1e-8 * P
    found: list[float] = []

    def add_bracket(lo, hi, flo, fhi):
        found.append(_refine_bracket(f, lo, hi, flo, fhi))

    npts = n if periodic else n + 1
    for k in range(npts):
        if fs[k] == 0.0:
            found.append(xs[k])
    for k in range(n):
        if fs[k] * fs[k + 1] < 0.0:
            add_bracket(xs[k], xs[k + 1], fs[k], fs[k + 1])
    # tangential candidates: local minima of |f| without a sign change
    for k in range(npts):
        fk = fs[k]
        if fk == 0.0:
            continue
        if periodic:
            left, right = (k - 1) % n, k + 1
            nb = [(xs[k] - P / n, fs[left]), (xs[k] + P / n, fs[right])]
        else:
            nb = []
            if k > 0:
                nb.append((xs[k - 1], fs[k - 1]))
            if k < n:
                nb.append((xs[k + 1], fs[k + 1]))
        if any(abs(fv) < abs(fk) or fv * fk <= 0.0 for _, fv in nb):
            continue
        s = 1.0 if fk > 0 else -1.0
        lo = min(x for x, _ in nb + [(xs[k], fk)])
        hi = max(x for x, _ in nb + [(xs[k], fk)])
        xm, gm = _minimise(lambda x, s=s: s * float(f(x)), lo, hi)
        if gm < 0.0:  # two simple roots hidden in one neighbourhood
            fm, flo, fhi = s * gm, float(f(lo)), float(f(hi))
            if flo * fm < 0.0:
                add_bracket(lo, xm, flo, fm)
            if fhi * fm < 0.0:
                add_bracket(xm, hi, fm, fhi)
        elif abs(gm) <= ftol:
            found.append(xm)
    if periodic:
        found = [a + (x - a) % P for x in found]
        found = [a if x >= b - merge else x for x in found]
    found = [x for x in found if a <= x <= b]
    found.sort()
    out: list[float] = []
    for x in found:
        if out and x - out[-1] <= merge:
            if abs(f(x)) < abs(f(out[-1])):
                out[-1] = x
            continue
        out.append(x)
    if periodic and len(out) > 1 and (out[0] + P) - out[-1] <= merge:
        if abs(f(out[-1])) < abs(f(out[0])):
            out[0] = out[-1] - P if out[-1] - P >= a else out[-1]
        out.pop()
        out.sort()
    return out


# --------------------------------------------------------------------------------------- vectorised


def _eval(f, X) -> np.ndarray:
    Y = np.asarray(f(X), dtype=float)
    if Y.shape != X.shape:
        raise ValueError(f"find_roots_batch: f returned shape {Y.shape} for input shape {X.shape}")
    return Y


def _compact(mask: np.ndarray):
    """Rows/columns of the True entries of an (N, G) mask, packed to (N, K): (cols, valid)."""
    count = mask.sum(axis=1)
    K = int(count.max()) if mask.size else 0
    K = max(K, 1)
    order = np.argsort(~mask, axis=1, kind="stable")[:, :K]
    valid = np.arange(K)[None, :] < count[:, None]
    return order, valid


def _refine_batch(f, lo, hi, flo, fhi, active, iters: int = 100):
    """Vectorised Illinois + bisection on (N, K) brackets; inactive entries are carried along."""
    lo, hi, flo, fhi = lo.copy(), hi.copy(), flo.copy(), fhi.copy()
    side = np.zeros(lo.shape, dtype=int)
    done = ~active
    root = np.where(np.abs(flo) <= np.abs(fhi), lo, hi)
    for it in range(iters):
        tiny = np.abs(hi - lo) <= 4.0 * _EPS * np.maximum(np.maximum(np.abs(lo), np.abs(hi)), 1e-300)
        done |= tiny
        if done.all():
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            x = (lo * fhi - hi * flo) / (fhi - flo)
        bad = ~((np.minimum(lo, hi) < x) & (x < np.maximum(lo, hi)))
        if it % 3 == 2:  # every third step bisects: guarantees halving
            bad[:] = True
        x = np.where(bad, 0.5 * (lo + hi), x)
        x = np.where(done, lo, x)
        fx = _eval(f, x)
        exact = (fx == 0.0) & ~done
        root = np.where(exact, x, root)
        done |= exact
        same = (fx > 0) == (flo > 0)
        upd_lo = same & ~done
        upd_hi = ~same & ~done
        fhi = np.where(upd_lo & (side == -1), 0.5 * fhi, fhi)
        flo = np.where(upd_hi & (side == 1), 0.5 * flo, flo)
        lo, flo = np.where(upd_lo, x, lo), np.where(upd_lo, fx, flo)
        hi, fhi = np.where(upd_hi, x, hi), np.where(upd_hi, fx, fhi)
        side = np.where(upd_lo, -1, np.where(upd_hi, 1, side))
        side = np.where(bad, 0, side)
    flo_t, fhi_t = _eval(f, lo), _eval(f, hi)
    best = np.where(np.abs(flo_t) <= np.abs(fhi_t), lo, hi)
    # entries that stopped on an exact zero keep it
    fr = _eval(f, root)
    return np.where(fr == 0.0, root, best)


def _minimise_batch(g, lo, hi, iters: int = 80):
    """Vectorised golden-section minimum of g on (N, K) intervals; stops where g < 0 is found."""
    x1 = hi - _GOLD * (hi - lo)
    x2 = lo + _GOLD * (hi - lo)
    g1, g2 = g(x1), g(x2)
    xneg = np.where(g1 < 0, x1, x2)
    gneg = np.minimum(g1, g2)
    found = (g1 < 0) | (g2 < 0)
    for _ in range(iters):
        left = g1 <= g2
        hi = np.where(left & ~found, x2, hi)
        lo = np.where(~left & ~found, x1, lo)
        nx1 = np.where(left, hi - _GOLD * (hi - lo), x2)
        nx2 = np.where(left, x1, lo + _GOLD * (hi - lo))
        ng = g(np.where(left, nx1, nx2))
        g1, g2 = np.where(left, ng, g2), np.where(left, g1, ng)
        x1, x2 = nx1, nx2
        neg = ((g1 < 0) | (g2 < 0)) & ~found
        xneg = np.where(neg, np.where(g1 < 0, x1, x2), xneg)
        gneg = np.where(neg, np.minimum(g1, g2), gneg)
        found |= neg
    xm = np.where(found, xneg, np.where(g1 <= g2, x1, x2))
    gm = np.where(found, gneg, np.minimum(g1, g2))
    return xm, gm


def find_roots_batch(
    f: Callable[[np.ndarray], np.ndarray],
    a: float,
    b: float,
    n: int,
    *,
    grid: int = 256,
    periodic: bool = False,
    ftol=None,
    merge: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Every root of ``n`` functions at once; ``f(X)`` maps an ``(n, k)`` array to ``(n, k)`` values.

    Row ``i`` of ``X`` is evaluated with function ``i``.  Returns ``(X, valid)``: roots ``(n, K)``
    sorted ascending in the valid slots (``valid`` is ``(n, K)``; invalid slots hold ``a``), with
    ``K`` the largest root count.  Same method, options and guarantees as :func:`find_roots`;
    ``ftol`` may be a scalar or an ``(n,)`` array.

    >>> import numpy as np
    >>> c = np.array([[0.5], [2.0], [1.0]])
    >>> X, ok = find_roots_batch(lambda x: np.cos(x) - c, -np.pi, np.pi, 3, periodic=True)
    >>> [np.round(X[i, ok[i]], 9).tolist() for i in range(3)]
    [[-1.047197551, 1.047197551], [], [0.0]]
    """
    a, b = float(a), float(b)
    if not (b > a) or grid < 2:
        raise ValueError(f"find_roots_batch needs b > a and grid >= 2, got [{a}, {b}], grid={grid}")
    P = b - a
    G = int(grid)
    h = P / G
    xs = a + P * np.arange(G + 1) / G
    X = np.broadcast_to(xs, (n, G + 1)).copy()
    if periodic:
        F = _eval(f, X[:, :G])
        F = np.concatenate([F, F[:, :1]], axis=1)
    else:
        F = _eval(f, X)
    if not np.all(np.isfinite(F)):
        raise ValueError("find_roots_batch: f is not finite on the grid")
    fmax = np.abs(F).max(axis=1) if G else np.zeros(n)
    ftol_arr = 1e-12 * fmax if ftol is None else np.broadcast_to(np.asarray(ftol, dtype=float), (n,))
    if merge is None:
        merge = 1e-8 * P
    npts = G if periodic else G + 1
    cand = []  # list of (roots (n, K), valid (n, K))

    # exact zeros on the grid
    zero = F[:, :npts] == 0.0
    cols, ok = _compact(zero)
    cand.append((np.take_along_axis(X[:, :npts], cols, axis=1), ok & np.take_along_axis(zero, cols, axis=1)))

    # sign changes
    sc = F[:, :-1] * F[:, 1:] < 0.0
    cols, ok = _compact(sc)
    lo = np.take_along_axis(X[:, :-1], cols, axis=1)
    hi = lo + h
    flo = np.take_along_axis(F[:, :-1], cols, axis=1)
    fhi = np.take_along_axis(F[:, 1:], cols, axis=1)
    if ok.any():
        r = _refine_batch(f, lo, hi, np.where(ok, flo, -1.0), np.where(ok, fhi, 1.0), ok)
        cand.append((r, ok))

    # tangential candidates: grid local minima of |f| without sign change
    A = np.abs(F[:, :npts])
    Fk = F[:, :npts]
    if periodic:
        Fl = np.roll(F[:, :G], 1, axis=1)
        Fr = F[:, 1 : G + 1]
        has_l = has_r = np.ones_like(zero)
    else:
        Fl = np.concatenate([F[:, :1], F[:, :-1]], axis=1)
        Fr = np.concatenate([F[:, 1:], F[:, -1:]], axis=1)
        has_l = np.broadcast_to(np.arange(npts) > 0, zero.shape)
        has_r = np.broadcast_to(np.arange(npts) < G, zero.shape)
    okl = ~has_l | ((np.abs(Fl) >= A) & (Fl * Fk > 0))
    okr = ~has_r | ((np.abs(Fr) >= A) & (Fr * Fk > 0))
    tmin = okl & okr & (Fk != 0.0)
    if tmin.any():
        cols, ok = _compact(tmin)
        xk = np.take_along_axis(X[:, :npts], cols, axis=1)
        fk = np.take_along_axis(Fk, cols, axis=1)
        hl = np.take_along_axis(np.broadcast_to(has_l, zero.shape), cols, axis=1)
        hr = np.take_along_axis(np.broadcast_to(has_r, zero.shape), cols, axis=1)
        lo = np.where(hl, xk - h, xk)
        hi = np.where(hr, xk + h, xk)
        s = np.where(fk > 0, 1.0, -1.0)
        xm, gm = _minimise_batch(lambda x: s * _eval(f, x), lo, hi)
        tang = ok & (gm >= 0.0) & (gm <= ftol_arr[:, None])
        cand.append((xm, tang))
        split = ok & (gm < 0.0)
        if split.any():
            fm = np.where(split, s * gm, -1.0)
            flo, fhi = _eval(f, lo), _eval(f, hi)
            s1 = split & (flo * fm < 0.0)
            s2 = split & (fhi * fm < 0.0)
            r1 = _refine_batch(f, lo, xm, np.where(s1, flo, 1.0), np.where(s1, fm, -1.0), s1)
            r2 = _refine_batch(f, xm, hi, np.where(s2, fm, -1.0), np.where(s2, fhi, 1.0), s2)
            cand.append((r1, s1))
            cand.append((r2, s2))

    R = np.concatenate([c[0] for c in cand], axis=1)
    V = np.concatenate([c[1] for c in cand], axis=1)
    if periodic:
        R = a + np.mod(R - a, P)
        R = np.where(R >= b - merge, a, R)
    V &= (R >= a) & (R <= b)
    R = np.where(V, R, np.inf)
    order = np.argsort(R, axis=1)
    R = np.take_along_axis(R, order, axis=1)
    V = np.take_along_axis(V, order, axis=1)
    Rv = np.where(V, R, a)
    absf = np.where(V, np.abs(_eval(f, Rv)), np.inf)
    # dedup: a root within `merge` of the previous valid one is dropped (keep the smaller |f|)
    keep = np.zeros_like(V)
    rows = np.arange(n)
    last_idx = np.full(n, -1)
    last_x = np.full(n, -np.inf)
    last_f = np.full(n, np.inf)
    for j in range(R.shape[1]):  # a loop over candidate slots (few), not over instances
        vj = V[:, j]
        close = vj & (R[:, j] - last_x <= merge)
        better = close & (absf[:, j] < last_f)
        keep[rows[better], last_idx[better]] = False
        take = vj & (~close | better)
        keep[:, j] = take
        last_idx = np.where(take, j, last_idx)
        last_x = np.where(vj & ~close, R[:, j], last_x)  # a merged run is measured from its first root
        last_f = np.where(take, absf[:, j], last_f)
    if periodic:
        # first and last valid roots may be the same point across the wrap
        nv = keep.sum(axis=1)
        firsti = np.argmax(keep, axis=1)
        lasti = R.shape[1] - 1 - np.argmax(keep[:, ::-1], axis=1)
        rf = Rv[np.arange(n), firsti]
        rl = Rv[np.arange(n), lasti]
        wrapdup = (nv > 1) & ((rf + P) - rl <= merge)
        keep[np.arange(n)[wrapdup], lasti[wrapdup]] = False
    cols, ok = _compact(keep)
    out = np.take_along_axis(Rv, cols, axis=1)
    out = np.where(ok, out, a)
    return out, ok
