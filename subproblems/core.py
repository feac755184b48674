"""The uniform contract every canonical subproblem solver follows, and the registry behind ``solve``.

A solver module registers one or more codes (``"S2-RR"``, ``"S1-TRR"``, ...) with :func:`register`.
Each registration names the maximum number of solutions (the fixed number of slots of the vectorised
path) and two callables:

* ``scalar(twists, **inputs) -> list[Solution]``: one instance, every solution; the reference path.
* ``batch(twists, **inputs) -> BatchResult`` (optional): N instances at once, no Python loop over them.
  Without one, :func:`solve_batch` loops over the scalar path (correct, slow) and says so in
  ``BatchResult.vectorised``.

Inputs use the names of the equations in docs/design.md section 4: ``T`` (4x4 target of class I),
``p``/``q`` (points of class II and III), ``d`` (distances of class III, or plane offsets), ``h``
(plane normals of the rotate-to-plane extras).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from subproblems.tolerances import TWIST_UNIT, ZERO_AXIS

__all__ = [
    "Solution",
    "Result",
    "BatchResult",
    "SubproblemError",
    "SubproblemInputError",
    "register",
    "solve",
    "solve_batch",
    "codes",
    "max_solutions",
]


class SubproblemError(Exception):
    """Base of every error raised by the ``subproblems`` package."""


class SubproblemInputError(SubproblemError, ValueError):
    """An input does not fit the subproblem: wrong code, shapes, twist kinds or non-finite numbers."""


@dataclass(frozen=True)
class Solution:
    """One solution of a scalar solver: joint values, least-squares flag, continuum flag."""

    q: tuple[float, ...]
    ls: bool = False
    continuum: bool = False


@dataclass(frozen=True)
class Result:
    """Every solution of one subproblem instance.

    ``q`` is (k, m) with joint values in the order of the twists; ``ls[i]`` is True where no exact
    solution exists and row i is a least-squares answer; ``continuum`` is True when the solutions form
    a continuum, ``q`` then holds documented representatives.  ``residual[i]`` is how far row i misses
    the whole equation (a distance, in the user's units, or radians for pure orientation parts).
    """

    code: str
    q: np.ndarray
    ls: np.ndarray
    continuum: bool
    residual: np.ndarray = field(default_factory=lambda: np.zeros(0))


@dataclass(frozen=True)
class BatchResult:
    """Solutions of N instances: ``q`` (N, K, m), ``valid`` (N, K), ``ls`` (N, K), ``continuum`` (N,)."""

    code: str
    q: np.ndarray
    valid: np.ndarray
    ls: np.ndarray
    continuum: np.ndarray
    vectorised: bool = True


@dataclass(frozen=True)
class _Entry:
    code: str
    kinds: str
    max_solutions: int
    scalar: Callable
    batch: Callable | None
    residual: Callable | None


_REGISTRY: dict[str, _Entry] = {}


def register(code: str, max_solutions: int, batch: Callable | None = None, residual=None):
    """Decorator registering ``scalar`` as the solver of ``code``.

    ``residual(twists, q_row, **inputs) -> float`` measures one solution against the whole equation;
    when omitted, the residual is computed from the generic class equation.
    """

    def deco(scalar: Callable) -> Callable:
        kinds = code.split("-", 1)[1]
        _REGISTRY[code] = _Entry(code, kinds, max_solutions, scalar, batch, residual)
        return scalar

    return deco


def codes() -> list[str]:
    """Every registered subproblem code, sorted."""
    _load_all()
    return sorted(_REGISTRY)


def max_solutions(code: str) -> int:
    """The number of solution slots of ``code`` in the vectorised path."""
    return _entry(code).max_solutions


def _load_all() -> None:
    # Importing the package registers every solver; kept lazy so that core has no import cycle.
    import subproblems  # noqa: F401


def _entry(code: str) -> _Entry:
    _load_all()
    try:
        return _REGISTRY[code]
    except KeyError:
        raise SubproblemInputError(
            f"unknown subproblem code {code!r}; known codes: {', '.join(sorted(_REGISTRY))}"
        ) from None


def check_twists(code: str, kinds: str, twists) -> np.ndarray:
    """Validate twists against the joint kinds of ``code``; returns an (m, 6) float array."""
    tw = np.asarray(twists, dtype=float)
    if tw.ndim != 2 or tw.shape != (len(kinds), 6):
        raise SubproblemInputError(
            f"{code}: expected {len(kinds)} twists of 6 numbers, got shape {np.shape(twists)}"
        )
    if not np.all(np.isfinite(tw)):
        raise SubproblemInputError(f"{code}: twists contain NaN or infinity")
    for i, (kind, xi) in enumerate(zip(kinds, tw)):
        wn, vn = np.linalg.norm(xi[3:]), np.linalg.norm(xi[:3])
        if kind == "R" and abs(wn - 1.0) > TWIST_UNIT:
            raise SubproblemInputError(f"{code}: twist {i + 1} must be revolute with unit w, |w|={wn:g}")
        if kind == "R" and abs(float(xi[:3] @ xi[3:])) > TWIST_UNIT * max(1.0, vn):
            raise SubproblemInputError(f"{code}: twist {i + 1} has pitch (v.w != 0); joints have none")
        if kind == "T" and (wn > ZERO_AXIS or abs(vn - 1.0) > TWIST_UNIT):
            raise SubproblemInputError(
                f"{code}: twist {i + 1} must be prismatic (w = 0, unit v), |w|={wn:g}, |v|={vn:g}"
            )
    return tw


def _check_finite(code: str, name: str, value, shape) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if shape is not None and arr.shape != shape:
        raise SubproblemInputError(f"{code}: {name} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise SubproblemInputError(f"{code}: {name} contains NaN or infinity")
    return arr


def _inputs_for(code: str, kinds: str, T, p, q, d, h) -> dict:
    cls = code[:2]
    m = len(kinds)
    if cls == "S1":
        if T is None:
            raise SubproblemInputError(f"{code}: class I needs T (a 4x4 rigid transform)")
        return {"T": _check_finite(code, "T", T, (4, 4))}
    if cls == "S2":
        if p is None or q is None:
            raise SubproblemInputError(f"{code}: class II needs points p and q")
        return {"p": _check_finite(code, "p", p, (3,)), "q": _check_finite(code, "q", q, (3,))}
    if cls == "S3":
        if p is None or q is None or d is None:
            raise SubproblemInputError(f"{code}: class III needs p, q and d")
        shape = (3,) if m == 1 else (m, 3)
        dshape = () if m == 1 else (m,)
        return {
            "p": _check_finite(code, "p", p, shape),
            "q": _check_finite(code, "q", q, shape),
            "d": _check_finite(code, "d", d, dshape),
        }
    # Extras declare their own inputs; pass through what was given, checked for finiteness.
    given = {"T": T, "p": p, "q": q, "d": d, "h": h}
    return {k: _check_finite(code, k, v, None) for k, v in given.items() if v is not None}


def solve(code: str, twists, T=None, p=None, q=None, d=None, h=None) -> Result:
    """Solve one instance of subproblem ``code`` and return every solution.

    >>> import numpy as np
    >>> from subproblems.screw import revolute_twist
    >>> r = solve("S2-R", twists=[revolute_twist([0, 0, 1], [0, 0, 0])], p=[1, 0, 0], q=[0, 1, 0])
    >>> np.round(r.q, 12), r.ls, r.continuum
    (array([[1.57079633]]), array([False]), False)
    """
    entry = _entry(code)
    tw = check_twists(code, entry.kinds, twists)
    inputs = _inputs_for(code, entry.kinds, T, p, q, d, h)
    sols = entry.scalar(tw, **inputs)
    m = len(entry.kinds)
    qs = np.array([s.q for s in sols], dtype=float).reshape(len(sols), m)
    ls = np.array([s.ls for s in sols], dtype=bool)
    continuum = any(s.continuum for s in sols)
    if entry.residual is not None:
        res = np.array([entry.residual(tw, row, **inputs) for row in qs])
    else:
        res = np.array([equation_residual(code, tw, row, **inputs) for row in qs])
    return Result(code, qs, ls, continuum, res)


def solve_batch(code: str, twists, T=None, p=None, q=None, d=None, h=None) -> BatchResult:
    """Solve N instances at once.

    ``twists`` is (m, 6) shared by all instances or (N, m, 6); the other inputs carry a leading N axis.
    Solutions fill ``max_solutions(code)`` slots; ``valid`` marks the filled ones.
    """
    entry = _entry(code)
    given = {k: v for k, v in {"T": T, "p": p, "q": q, "d": d, "h": h}.items() if v is not None}
    arrays = {k: np.asarray(v, dtype=float) for k, v in given.items()}
    n = next(iter(arrays.values())).shape[0] if arrays else 0
    tw = np.asarray(twists, dtype=float)
    if tw.ndim == 2:
        tw = np.broadcast_to(tw, (n,) + tw.shape)
    if entry.batch is not None:
        return entry.batch(tw, **arrays)
    K, m = entry.max_solutions, len(entry.kinds)
    Q = np.zeros((n, K, m))
    valid = np.zeros((n, K), dtype=bool)
    ls = np.zeros((n, K), dtype=bool)
    cont = np.zeros(n, dtype=bool)
    for i in range(n):
        r = solve(code, tw[i], **{k: v[i] for k, v in arrays.items()})
        k = min(len(r.q), K)
        Q[i, :k], valid[i, :k], ls[i, :k], cont[i] = r.q[:k], True, r.ls[:k], r.continuum
    return BatchResult(code, Q, valid, ls, cont, vectorised=False)


def equation_residual(code: str, twists, qrow, T=None, p=None, q=None, d=None, **_) -> float:
    """How far joint values ``qrow`` miss the class equation of ``code`` (0 for an exact solution).

    Class I: max of the position error and the rotation error times the target's distance scale;
    class II: the point distance; class III: the largest distance error over the equations.
    """
    from subproblems.screw import apply, twist_exp

    g = np.eye(4)
    for xi, th in zip(twists, qrow):
        g = g @ twist_exp(xi, th)
    cls = code[:2]
    if cls == "S1":
        T = np.asarray(T, dtype=float)
        scale = max(1.0, float(np.linalg.norm(T[:3, 3])))
        return float(
            max(
                np.linalg.norm(g[:3, 3] - T[:3, 3]),
                scale * np.abs(g[:3, :3] - T[:3, :3]).max(),
            )
        )
    if cls == "S2":
        return float(np.linalg.norm(apply(g, p) - np.asarray(q, dtype=float)))
    if cls == "S3":
        P = np.atleast_2d(p)
        Qp = np.atleast_2d(q)
        D = np.atleast_1d(d)
        return float(max(abs(np.linalg.norm(apply(g, a) - b) - c) for a, b, c in zip(P, Qp, D)))
    return math.nan
