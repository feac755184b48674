"""Jacobians of a POE chain vectorised over configurations, and how far each configuration is from singular.

Plain numpy, so that generated solver modules (which may import only numpy and ``subproblems``) can flag
solutions at or near a singular configuration.  Conventions (docs/design.md section 16, "Jacobians"):

* ``twists`` (n, 6): the home twists ``(v, w)`` of every joint in chain order, coupled joints included;
* ``A`` (n, dof), ``b`` (n,): the coupling map ``th_full = A @ q + b`` (identity and zero without mimics);
* ``Q`` (N, dof): independent joint values, one configuration per row.

The space Jacobian has one twist column per independent joint (a coupled joint adds ``a`` times its
column to its master's).  The *size-free* Jacobian used by :func:`sigma_min` is the space Jacobian
referred to the tool origin (linear rows are the tool origin's velocity, angular rows the angular
velocity, both in base axes, so the base origin's placement does not matter), with the linear rows
divided by the robot's size ``scale`` and the prismatic columns multiplied by it.  Every entry is then
dimensionless: a revolute column holds its unit axis and ``w x (p_tool - r) / scale`` (at most about
1), a prismatic column its unit direction; ``sigma_min`` is 0 exactly at a singular configuration and of
order 1 far from one, whatever the unit of length.

>>> import numpy as np
>>> tw = np.array([[0, 0, 0, 0, 0, 1.0], [0, 0, 0, 1.0, 0, 0], [0, 0, 0, 0, 0, 1.0]])  # a ZXZ wrist
>>> home = np.eye(4); home[2, 3] = 0.1
>>> A, b = np.eye(3), np.zeros(3)
>>> Q = np.array([[0.3, 0.0, 0.2], [0.3, 0.5, 0.2]])     # axes 1 and 3 in line, then not
>>> s = sigma_min(tw, A, b, home, Q, scale=0.1)
>>> bool(s[0] < 1e-12), bool(s[1] > 0.1)
(True, True)
"""

from __future__ import annotations

import numpy as np

__all__ = ["space_jacobian", "tool_jacobian", "sigma_min", "singular_values"]


def _rodrigues_batch(w: np.ndarray, th: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations about the unit axis ``w`` by the angles ``th`` (N,)."""
    W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]], dtype=float)
    s, c = np.sin(th)[:, None, None], np.cos(th)[:, None, None]
    return np.eye(3) + s * W + (1.0 - c) * (W @ W)


def _joint_values(A, b, Q) -> np.ndarray:
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    return Q @ np.asarray(A, dtype=float).T + np.asarray(b, dtype=float)


def _space_columns(twists: np.ndarray, th: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Columns ``Ad_{g_1..g_{i-1}} xi_i`` (N, 6, n) and the product ``R, p`` of all joint exponentials."""
    N, n = th.shape
    cols = np.empty((N, 6, n))
    R = np.broadcast_to(np.eye(3), (N, 3, 3)).copy()
    p = np.zeros((N, 3))
    for i in range(n):
        v, w = twists[i, :3], twists[i, 3:]
        Rw = R @ w
        cols[:, 3:, i] = Rw
        cols[:, :3, i] = R @ v + np.cross(p, Rw)
        t = th[:, i]
        if not w.any():  # prismatic: a pure translation v t
            Ri, pi = None, v[None, :] * t[:, None]
        else:
            Ri = _rodrigues_batch(w, t)
            wxv = np.cross(w, v)
            pi = wxv[None, :] - np.einsum("nij,j->ni", Ri, wxv) + (w @ v) * w[None, :] * t[:, None]
        p = p + np.einsum("nij,nj->ni", R, pi)
        if Ri is not None:
            R = R @ Ri
    return cols, R, p


def space_jacobian(twists, A, b, Q) -> np.ndarray:
    """(N, 6, dof) space Jacobians ``V_s = J_s(q) dq`` at the configurations ``Q`` (N, dof).

    >>> import numpy as np
    >>> J = space_jacobian(np.array([[0, 0, 0, 0, 0, 1.0]]), np.eye(1), np.zeros(1), [[0.5]])
    >>> J.shape, J[0, 5, 0]
    ((1, 6, 1), np.float64(1.0))
    """
    twists = np.asarray(twists, dtype=float)
    cols, _, _ = _space_columns(twists, _joint_values(A, b, Q))
    return cols @ np.asarray(A, dtype=float)


def tool_jacobian(twists, A, b, home, Q, scale: float) -> np.ndarray:
    """(N, 6, dof) size-free Jacobian: at the tool origin, linear rows / scale, prismatic columns * scale."""
    twists = np.asarray(twists, dtype=float)
    A = np.asarray(A, dtype=float)
    cols, R, p = _space_columns(twists, _joint_values(A, b, Q))
    J = cols @ A
    tool = np.einsum("nij,j->ni", R, np.asarray(home, dtype=float)[:3, 3]) + p  # tool origin in base
    # v_tool = v_s + w x p_tool  (the velocity of the base-frame point that coincides with the tool origin)
    lin = J[:, :3, :] + np.cross(J[:, 3:, :], tool[:, :, None], axis=1)
    out = np.concatenate([lin / scale, J[:, 3:, :]], axis=1)
    prismatic = ~np.abs(twists[:, 3:]).any(axis=1)
    # a column of an independent joint counts as prismatic when its own joint is (couplings keep kinds)
    col_prismatic = np.array([bool(prismatic[np.argmax(A[:, k] != 0)]) for k in range(A.shape[1])])
    out[:, :, col_prismatic] *= scale
    return out


def singular_values(twists, A, b, home, Q, scale: float) -> np.ndarray:
    """(N, min(6, dof)) singular values of the size-free Jacobian, largest first."""
    return np.linalg.svd(tool_jacobian(twists, A, b, home, Q, scale), compute_uv=False)


def sigma_min(twists, A, b, home, Q, scale: float) -> np.ndarray:
    """(N,) smallest singular value of the size-free Jacobian (the min(6, dof)-th): 0 at a singularity.

    A redundant chain (dof > 6) is singular where it loses a direction of the 6-D twist space; a chain
    with fewer than 6 joints where its joints' twists become dependent.
    """
    return singular_values(twists, A, b, home, Q, scale)[:, -1]
