"""The one damped Gauss-Newton step on the whole robot toward tool targets (docs/design.md section 10,
"one of each").

The runtime's polish (:func:`subproblems.plan_runtime.polish`) and the continuation's corrector
(:mod:`subproblems.continuation`, per-row twists of the homotopy robots) both step with these: the
tool's space Jacobian, the error vector of the target kind, and the step of the column-scaled normal
equations.  The C port of the Jacobian and the step is ``ikc_fk_jacobian`` / ``ikc_newton_steps`` in
``fast_finish.h``.
"""

from __future__ import annotations

import numpy as np

from subproblems.screw import cross, twist_exp_batch
from subproblems.tolerances import NEWTON_DAMPING, TINY

__all__ = ["tool_jacobian", "residual", "gauss_newton_step", "TARGET_ROWS", "ALL_ROWS"]

#: The rows of the tool Jacobian (position of the tool origin 0:3, rotation 3:6) a target constrains.
TARGET_ROWS = {"position": slice(0, 3), "orientation": slice(3, 6)}
ALL_ROWS = slice(0, 6)


def tool_jacobian(twists, full, home, A):
    """Tool poses G (M, 4, 4) and the space Jacobian of the tool (M, 6, dof): the velocity of the tool
    origin, then the angular velocity, per independent joint q, where ``full`` (M, n) = ``q A^T + b``
    holds every joint's value.  ``twists``: one set (n, 6) for every row, or (M, n, 6) one per row.

    >>> tw = np.array([[0, 0, 0, 0, 0, 1.0]])  # a revolute joint about z through the origin
    >>> home = np.eye(4); home[0, 3] = 1.0  # the tool at x = 1
    >>> G, J = tool_jacobian(tw, np.zeros((1, 1)), home, np.eye(1))
    >>> J[0, :, 0].tolist()  # the tool origin moves along y, turning about z
    [0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    """
    M, n = full.shape
    shared = twists.ndim == 2
    G = np.broadcast_to(np.eye(4), (M, 4, 4)).copy()
    cols = np.zeros((M, 6, n))
    for i in range(n):
        R, t = G[:, :3, :3], G[:, :3, 3]
        xi = twists[i] if shared else twists[:, i]
        w = R @ xi[3:] if shared else np.einsum("mij,mj->mi", R, xi[:, 3:])
        v = (R @ xi[:3] if shared else np.einsum("mij,mj->mi", R, xi[:, :3])) + cross(t, w)
        cols[:, :3, i], cols[:, 3:, i] = v, w
        G = G @ twist_exp_batch(xi, full[:, i])
    G = G @ np.asarray(home, dtype=float)
    p = G[:, :3, 3]
    v, w = cols[:, :3, :], cols[:, 3:, :]
    J = np.concatenate([v + cross(np.swapaxes(w, 1, 2), p[:, None, :]).swapaxes(1, 2), w], axis=1)
    return G, J @ A


def residual(G, goals, target):
    """Error vector of tool poses G (M, 4, 4) toward goals (M, 4, 4) for the target kind, and the rows
    of the tool Jacobian it matches: the position error, the rotation error (half the sum of the column
    cross products, the angle-axis vector to first order), or both (pose)."""
    e_pos = goals[:, :3, 3] - G[:, :3, 3]
    if target == "position":
        return e_pos, TARGET_ROWS[target]
    Rt, Rdt = np.swapaxes(G[:, :3, :3], 1, 2), np.swapaxes(goals[:, :3, :3], 1, 2)
    e_rot = 0.5 * cross(Rt, Rdt).sum(axis=1)
    if target == "orientation":
        return e_rot, TARGET_ROWS[target]
    return np.concatenate([e_pos, e_rot], axis=1), ALL_ROWS


def gauss_newton_step(J, e, hold=(), damping=NEWTON_DAMPING, cutoff=None):
    """The joint step dq (M, dof) toward error e (M, k) for the target's Jacobian rows J (M, k, dof).

    Columns are scaled to unit norm (lengths and angles mix), then a whisper of damping keeps a singular
    direction from blowing the step up or stalling the others.  ``hold``: columns that keep their
    values (free joints, clamped joints): a zero column gets a zero step.

    ``cutoff``: instead, the undamped pseudo-inverse step of the scaled columns, singular values below
    ``cutoff`` times the largest left out.  Near a double root or a numerical self-motion the weakest
    singular value is far below the damping's square root, and damped steps stop moving along it
    (subproblems/continuation.py ``_double_root``)."""
    if len(hold):
        J = J.copy()
        J[:, :, list(hold)] = 0.0
    col = np.maximum(np.linalg.norm(J, axis=1), TINY)
    Js = J / col[:, None, :]
    if cutoff is not None:
        # Only the columns that move the tool: the SVD of a zero column (a held one) gives its entries
        # of V a roundoff of ~1e-17, not 0, which the division by its TINY norm turned into a step of
        # ~1e290 rad on the free joint, an overflow in the next step's Jacobian (pr2.urdf perturbed by
        # 1e-6; docs/design.md section 5, "Snapping").
        live = ~(col <= TINY)
        dq = np.zeros(col.shape)
        for pattern in np.unique(live, axis=0):
            rows = np.nonzero((live == pattern).all(axis=1))[0]
            cols = np.nonzero(pattern)[0]
            if not len(cols):
                continue
            U, S, Vt = np.linalg.svd(Js[np.ix_(rows, np.arange(Js.shape[1]), cols)], full_matrices=False)
            inv = np.where(S > cutoff * S[:, :1], 1.0 / np.maximum(S, TINY), 0.0)
            step = np.einsum("mji,mj->mi", Vt, inv * np.einsum("mkj,mk->mj", U, e[rows]))
            dq[np.ix_(rows, cols)] = step / col[np.ix_(rows, cols)]
        return dq
    JtJ = np.einsum("mki,mkj->mij", Js, Js) + damping * np.eye(Js.shape[2])
    return np.linalg.solve(JtJ, np.einsum("mki,mk->mi", Js, e)[..., None])[..., 0] / col
