"""S2-TT and S2-TTT: translate a point onto a point with two or three prismatic joints.

Equations: ``p + t_1 v_1 + t_2 v_2 = q`` (S2-TT) and ``p + t_1 v_1 + t_2 v_2 + t_3 v_3 = q`` (S2-TTT).
Prismatic motions commute, so the order of the joints does not matter: this is the linear system
``V t = q - p`` with the unit directions as the columns of ``V`` (3 x m).

Geometry: S2-TT asks for ``q`` on the plane through ``p`` spanned by ``v_1, v_2`` and decomposes
``q - p`` along them; S2-TTT decomposes ``q - p`` in the basis ``v_1, v_2, v_3``.

Max solutions: 1 (a linear system).

Degenerate cases and what is returned (``t = V^+ (q - p)``, the pseudo-inverse solution):

* S2-TT, ``q`` off the plane: the least-squares decomposition of ``q - p``, flagged ``ls``;
* dependent directions (S2-TT: parallel; S2-TTT: coplanar or with two parallel): the solutions form
  a continuum; the minimum-norm one is returned, flagged ``continuum`` (and ``ls`` when ``q - p`` is
  outside the span).

>>> from subproblems import solve
>>> tw = [[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0]]
>>> r = solve("S2-TTT", tw, p=[0, 0, 0], q=[1, 2, 3])
>>> r.q.tolist(), bool(r.ls[0]), r.continuum
([[1.0, 2.0, 3.0]], False, False)
"""

from __future__ import annotations

import numpy as np

from subproblems import tolerances as tol
from subproblems._class2 import EXACT_TOL, problem_scale, problem_scale_batch
from subproblems.core import BatchResult, Solution, register

RANK_TOL = tol.S2_TT_RANK  # subproblems/tolerances.py


@np.errstate(all="ignore")
def _min_norm_lstsq(V, d):
    """``V^+ d`` for a stack of ``V`` (N, 3, m), ``d`` (N, 3), and whether ``V`` is rank-deficient.

    Through the SVD applied to ``d`` (``U^T d``, then divided by the singular values), not through
    the explicit pseudo-inverse: with nearly parallel directions (singular values ~1e-9) the product
    ``pinv(V) @ d`` loses ~1e-9 of ``|d|`` to cancellation and the exact solution looks unreachable.
    """
    U, S, Vt = np.linalg.svd(V, full_matrices=False)
    keep = S > RANK_TOL * S[:, :1]
    y = np.where(keep, np.einsum("nji,nj->ni", U, d) / np.where(keep, S, 1.0), 0.0)
    return np.einsum("nji,nj->ni", Vt, y), ~keep.all(axis=-1)


def _solve(code: str, twists, p, q) -> list[Solution]:
    V = np.asarray(twists, dtype=float)[:, :3].T
    d = np.asarray(q, dtype=float) - np.asarray(p, dtype=float)
    t, cont = _min_norm_lstsq(V[None], d[None])
    t, continuum = t[0], bool(cont[0])
    ls = float(np.linalg.norm(V @ t - d)) > EXACT_TOL * problem_scale(twists, p, q)
    return [Solution(tuple(float(x) for x in t), ls=ls, continuum=continuum)]


def _batch(code: str, tw, p, q) -> BatchResult:
    V = np.swapaxes(tw[..., :3], -1, -2)
    d = q - p
    t, continuum = _min_norm_lstsq(V, d)
    err = np.linalg.norm(np.einsum("nij,nj->ni", V, t) - d, axis=-1)
    ls = err > EXACT_TOL * problem_scale_batch(tw, p, q)
    n = len(t)
    return BatchResult(code, t[:, None, :], np.ones((n, 1), bool), ls[:, None], continuum)


@register("S2-TT", 1, batch=lambda tw, p, q: _batch("S2-TT", tw, p, q))
def solve_s2_tt(twists, p, q) -> list[Solution]:
    """Every solution of ``p + t_1 v_1 + t_2 v_2 = q`` (see the module docstring)."""
    return _solve("S2-TT", twists, p, q)


@register("S2-TTT", 1, batch=lambda tw, p, q: _batch("S2-TTT", tw, p, q))
def solve_s2_ttt(twists, p, q) -> list[Solution]:
    """Every solution of ``p + t_1 v_1 + t_2 v_2 + t_3 v_3 = q`` (see the module docstring)."""
    return _solve("S2-TTT", twists, p, q)
