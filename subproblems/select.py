"""Choosing among the solutions of one target: joint-limit aliases, distance to a seed, the nearest row,
which joint excludes a solution, and each row's conditioning (issue 13; issue 12 item 4).

The generated solver modules call these functions from their public ``solve`` / ``solve_info`` /
``nearest``, so the logic lives here once instead of being copied into every module.  Everything is
vectorised over rows and uses numpy only.

Conventions (docs/motion.md):

- A revolute value and its 2 pi aliases are the same angle but not the same motor position.  Inside
  the limits, a joint whose range exceeds 2 pi (a UR's +-2 pi) can hold an angle in two or more ways;
  ``aliases`` lists them all, one row each.
- Distance to a seed is the motion a controller would command: revolute values in radians, prismatic
  ones in units of the robot's size ``scale``, each times its optional weight, Euclidean norm.  With
  limits, values are positions inside the limits and their difference is taken as it stands (the joint
  cannot pass through its stops; with ``aliases`` the alias itself is the choice).  Without limits a
  revolute difference is wrapped to [-pi, pi] (the joint may turn either way).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from subproblems import conditioning
from subproblems import tolerances as tol

__all__ = ["SolveInfo", "Excluded", "aliases", "nearest_alias", "distance", "excluding_joints",
           "jacobian", "sigma_min"]

TWO_PI = 2 * math.pi


class Excluded(NamedTuple):
    """A solution left out by the joint limits: its row (as solved), the joints outside their limits."""

    q: np.ndarray
    joints: tuple
    residual: float
    ls: bool


class SolveInfo(NamedTuple):
    """Every candidate of one target (k rows) with what it is worth: a generated module's solve_info."""

    q: np.ndarray  # (k, n) JOINT_NAMES order
    residual: np.ndarray  # (k,) target error on the true robot (length units)
    ls: np.ndarray  # (k,) least-squares rows: they miss by residual
    continuum: np.ndarray  # (k,) one representative of a self-motion
    sigma_min: np.ndarray  # (k,) smallest singular value of the size-free Jacobian (0: singular)
    excluded: tuple  # Excluded solutions (limits=True only): which joints leave each one out
LIMIT_EPS = tol.LIMIT_SLACK  # roundoff forgiven at a limit, as the finish does (subproblems/tolerances.py)


def _candidates(v, lo, hi, eps=LIMIT_EPS):
    """Every value v + 2 pi k inside [lo - eps, hi + eps], sorted; for one revolute value."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        # an unbounded side: the aliases are infinitely many; keep the value itself (or the one alias
        # inside a one-sided limit nearest to it)
        if lo - eps <= v <= hi + eps:
            return [v]
        k = math.ceil((lo - eps - v) / TWO_PI) if math.isfinite(lo) else math.floor((hi + eps - v) / TWO_PI)
        return [v + k * TWO_PI]
    k_lo = math.ceil((lo - eps - v) / TWO_PI)
    k_hi = math.floor((hi + eps - v) / TWO_PI)
    return [v + k * TWO_PI for k in range(k_lo, k_hi + 1)]


def aliases(Q, kinds: str, lower, upper):
    """Every combination of in-limit 2 pi aliases of the revolute values of each row of ``Q`` (k, n).

    Returns ``(rows (m, n), source (m,))``: ``source[i]`` is the row of ``Q`` that row ``i`` came from.
    A row keeps its given value first where that lies inside the limits, then the other aliases in
    increasing order.  A value with no alias inside its limits (possible only for rows solved without
    limits) is kept as it is.

    >>> import numpy as np
    >>> rows, src = aliases(np.array([[0.5, 1.0]]), "RT", [-2 * np.pi, -1.0], [2 * np.pi, 1.0])
    >>> np.round(rows, 4).tolist(), src.tolist()
    ([[0.5, 1.0], [-5.7832, 1.0]], [0, 0])
    """
    Q = np.asarray(Q, dtype=float).reshape(-1, len(kinds))
    out, src = [], []
    for r, row in enumerate(Q):
        options = []
        for j, kind in enumerate(kinds):
            v = float(row[j])
            if kind != "R":
                options.append([v])
                continue
            vals = _candidates(v, float(lower[j]), float(upper[j]))
            if not vals:
                options.append([v])
                continue
            # the value as returned first (the solver's representative), then the others
            vals.sort(key=lambda x: (abs(x - v) > 1e-12, x))
            options.append(vals)
        for combo in _product(options):
            out.append(combo)
            src.append(r)
    rows = np.array(out, dtype=float).reshape(len(out), len(kinds))
    return rows, np.array(src, dtype=int)


def _product(options):
    combos = [[]]
    for vals in options:
        combos = [c + [v] for c in combos for v in vals]
    return combos


def nearest_alias(Q, q_seed, kinds: str, lower, upper):
    """Each row of ``Q`` with every revolute value replaced by its in-limit alias nearest ``q_seed``.

    For joints whose range is at most 2 pi this changes nothing (one alias, or two at the two ends of
    an exactly 2 pi range); a joint with a wider range takes the alias the seed reaches by the least
    motion.

    >>> import numpy as np
    >>> nearest_alias(np.array([[0.0]]), [6.0], "R", [-7.0], [7.0]).round(4).tolist()
    [[6.2832]]
    """
    Q = np.array(Q, dtype=float).reshape(-1, len(kinds))
    seed = _seed(q_seed, kinds)
    for j, kind in enumerate(kinds):
        if kind != "R":
            continue
        for r in range(len(Q)):
            vals = _candidates(float(Q[r, j]), float(lower[j]), float(upper[j]))
            if vals:
                Q[r, j] = min(vals, key=lambda x: (abs(x - seed[j]), x))
    return Q


def _seed(q_seed, kinds: str) -> np.ndarray:
    seed = np.asarray(q_seed, dtype=float).reshape(-1)
    if seed.shape != (len(kinds),):
        raise ValueError(f"q_seed has {seed.size} values; the robot has {len(kinds)} joints {kinds}")
    if not np.all(np.isfinite(seed)):
        raise ValueError("q_seed contains NaN or infinity")
    return seed


def distance(Q, q_seed, kinds: str, scale: float, weights=None, wrap: bool = False) -> np.ndarray:
    """Weighted joint-space distance of each row of ``Q`` (k, n) from ``q_seed`` (n,).

    Revolute differences in radians (wrapped to [-pi, pi] when ``wrap``), prismatic ones divided by
    ``scale``; each times its weight (default 1); Euclidean norm.

    >>> import numpy as np
    >>> distance(np.array([[3.0, 0.5], [-3.0, 0.0]]), [3.1, 0.0], "RT", scale=0.5).round(4).tolist()
    [1.005, 6.1]
    >>> distance(np.array([[-3.0, 0.0]]), [3.1, 0.0], "RT", scale=0.5, wrap=True).round(4).tolist()
    [0.1832]
    """
    Q = np.asarray(Q, dtype=float).reshape(-1, len(kinds))
    d = Q - _seed(q_seed, kinds)
    rev = np.array([k == "R" for k in kinds])
    if wrap:
        d[:, rev] = np.remainder(d[:, rev] + math.pi, TWO_PI) - math.pi
    d[:, ~rev] /= scale
    if weights is not None:
        w = np.asarray(weights, dtype=float).reshape(-1)
        if w.shape != (len(kinds),) or np.any(w < 0) or not np.all(np.isfinite(w)):
            raise ValueError(f"weights must be {len(kinds)} finite values >= 0 (one per joint); "
                             f"got {weights!r}")
        d = d * w
    return np.sqrt((d * d).sum(axis=1))


def excluding_joints(Q, kinds: str, lower, upper, eps=LIMIT_EPS) -> np.ndarray:
    """(k, n) bool: joints whose value (in any 2 pi alias for a revolute joint) lies outside its limits.

    >>> import numpy as np
    >>> excluding_joints(np.array([[3.0, 2.0]]), "RT", [-1.0, -1.0], [1.0, 1.0]).tolist()
    [[True, True]]
    >>> excluding_joints(np.array([[3.0 - 2 * np.pi, 0.0]]), "RT", [0.0, -1.0], [np.pi, 1.0]).tolist()
    [[False, False]]
    """
    Q = np.asarray(Q, dtype=float).reshape(-1, len(kinds))
    out = np.zeros(Q.shape, dtype=bool)
    for j, kind in enumerate(kinds):
        lo, hi = float(lower[j]), float(upper[j])
        for r in range(len(Q)):
            v = float(Q[r, j])
            if kind == "R":
                out[r, j] = not _candidates(v, lo, hi, eps)
            else:
                out[r, j] = not (lo - eps <= v <= hi + eps)
    return out


def jacobian(Q, *, twists, A, b, home, scale: float, target: str = "pose") -> np.ndarray:
    """The size-free Jacobian of each row of ``Q`` (k, n): (k, r, n), r = 6 (3 for position or
    orientation targets); ``subproblems.conditioning.tool_jacobian`` (virtual joints at 0) restricted to
    the returned joints and to the rows the target constrains.  ``scale=1`` gives the plain Jacobian of
    the tool origin's velocity and the tool's angular velocity."""
    Q = np.asarray(Q, dtype=float)
    A = np.asarray(A, dtype=float)
    n = Q.shape[1]
    full = np.concatenate([Q, np.zeros((len(Q), A.shape[1] - n))], axis=1)
    J = conditioning.tool_jacobian(twists, A, b, home, full, scale)[:, :, :n]
    if target == "position":
        return J[:, :3, :]
    if target == "orientation":
        return J[:, 3:, :]
    return J


def sigma_min(Q, *, twists, A, b, home, scale: float, target: str = "pose") -> np.ndarray:
    """Smallest singular value of each row's Jacobian, made size-free (issue 12 item 4).

    ``Q`` (k, n) holds the returned joint values; the chain's joints are ``A @ [q, 0...] + b`` (mimic
    joints follow their masters, virtual joints sit at 0).  The Jacobian is that of the tool origin's
    linear velocity divided by ``scale`` and of the tool's angular velocity, both in base axes, with
    respect to the returned joints (mimic columns folded in by the chain rule; a prismatic column times
    ``scale``, its value counting in units of the robot's size); only the rows the target constrains
    count (position: the 3 linear rows; orientation: the 3 angular rows).  Its smallest of
    min(rows, n) singular values is 0 at a singular configuration and of order 1 for a
    well-conditioned one; it does not depend on where the base frame is put or on the length unit.

    ``subproblems.conditioning.sigma_min`` of the returned joints, with the rows the target constrains.

    >>> import numpy as np
    >>> tw = np.array([[0, 0, 0, 0, 0, 1.0], [0, -1.0, 0, 0, 0, 1.0]])   # planar 2R, links 1 and 1
    >>> home = np.eye(4); home[0, 3] = 2.0
    >>> s = sigma_min(np.array([[0.3, 0.0], [0.3, 1.2]]), twists=tw, A=np.eye(2), b=np.zeros(2), home=home,
    ...               scale=2.0, target="position")
    >>> bool(s[0] < 1e-12), bool(s[1] > 0.1)
    (True, True)
    """
    Q = np.asarray(Q, dtype=float)
    if Q.ndim != 2 or len(Q) == 0:
        return np.zeros(0)
    J = jacobian(Q, twists=twists, A=A, b=b, home=home, scale=scale, target=target)
    return np.linalg.svd(J, compute_uv=False)[:, -1]
