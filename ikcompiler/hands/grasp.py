"""The hand-object equations of seed 002: grasp matrix, hand Jacobian, joint-object equation (14), class.

With ``n`` contacts, ``G^T u = J th'`` (7) where ``G^T`` stacks ``H_i G_i^T`` (5) and ``J`` is
``diag(H_i J_i)`` (6).  The joint-object equation (14) follows from three null spaces:

* ``N_J``: basis of N(J), the joint self-motions (8);
* ``N_B``: basis of N(B), ``B = N_J^T``: joint motions orthogonal to the self-motions (9)-(10);
* ``N_C``: basis of N(C), ``C = [G^T  -J N_B]`` (12)-(13), split into rows ``N_CA`` (object) and
  ``N_CB``;

then ``[u; th'] = [[D, 0], [E, N_J]] [y_C; y_J]`` with ``D = N_CA`` and ``E = N_B N_CB`` (14).  The system
is *degenerate* when rank(D) is below the object's degrees of freedom (6 in space, 3 in the plane), else
*non-redundant* when rank(N_J) = 0 and *redundant* otherwise.

Rank tolerance.  The matrices mix lengths and pure numbers, so they are first made dimensionless: every
translational row is divided by the problem's length scale ``L`` (the object's size) and the object's
translational velocity is measured in ``L`` per second.  A singular value then counts when it exceeds
``RANK_RTOL * max(rows, cols) * max(1, s_max)``: well above rounding (1e-16 of unit-size entries) and well
below any physical near-singularity a hand would be operated at.  :data:`RANK_RTOL` is the one tolerance.

>>> a = analyse(np.eye(3), np.eye(3)[:, :2], dof=3)
>>> a.rank_D, a.rank_NJ, a.kind
(2, 0, 'degenerate')
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RANK_RTOL = 1e-9

KINDS = {
    "degenerate": "degenerate: the hand can move the object only in R(D), a subspace of its twists",
    "non-redundant": "non-degenerate, non-redundant: any object motion, the contact motion is determined",
    "redundant": "redundant: any object motion, and joint self-motions adjust the contacts",
}


def null_space(A: np.ndarray) -> tuple[np.ndarray, int]:
    """Orthonormal basis (columns) of N(A) and rank(A), with the tolerance of the module docstring.

    >>> N, r = null_space(np.array([[1.0, 1.0]]))
    >>> r, N.shape, bool(abs(N[0, 0] + N[1, 0]) < 1e-15)
    (1, (2, 1), True)
    """
    A = np.atleast_2d(np.asarray(A, dtype=float))
    rows, cols = A.shape
    if rows == 0 or cols == 0:
        return np.eye(cols), 0
    _, s, Vt = np.linalg.svd(A)
    tol = RANK_RTOL * max(rows, cols) * max(1.0, float(s[0]) if s.size else 0.0)
    rank = int(np.sum(s > tol))
    return Vt[rank:].T.copy(), rank


@dataclass(frozen=True)
class JointObject:
    """The joint-object equation (14) and what it says about the system."""

    N_J: np.ndarray
    N_B: np.ndarray
    N_C: np.ndarray
    D: np.ndarray
    E: np.ndarray
    rank_J: int
    rank_D: int
    rank_NJ: int
    dof: int  # object degrees of freedom (3 planar, 6 spatial)
    indeterminate: int  # dim N(G^T): object motions the contacts do not see (0 in a real grasp)

    @property
    def kind(self) -> str:
        if self.rank_D < self.dof:
            return "degenerate"
        return "redundant" if self.rank_NJ > 0 else "non-redundant"

    def joint_rates(self, u: np.ndarray) -> tuple[np.ndarray, float]:
        """Step 2a: ``th'_c = E y_C`` with ``D y_C = u`` (least squares); also the part of u outside R(D),
        relative to |u| (0 for a reachable twist)."""
        y, *_ = np.linalg.lstsq(self.D, u, rcond=None)
        norm = float(np.linalg.norm(u))
        miss = float(np.linalg.norm(self.D @ y - u)) / norm if norm > 0 else 0.0
        return self.E @ y, miss


def analyse(Gt: np.ndarray, J: np.ndarray, *, dof: int, row_scale=None, twist_scale=None) -> JointObject:
    """Null spaces, D, E and ranks from ``G^T`` (rows x dof) and ``J`` (rows x joints).

    ``row_scale`` (per row) and ``twist_scale`` (per object twist component) make the matrices
    dimensionless (module docstring); D is returned in the caller's (unscaled) units.
    """
    Gt = np.asarray(Gt, dtype=float)
    J = np.asarray(J, dtype=float)
    rs = np.ones(Gt.shape[0]) if row_scale is None else np.asarray(row_scale, dtype=float)
    ts = np.ones(Gt.shape[1]) if twist_scale is None else np.asarray(twist_scale, dtype=float)
    Gs = rs[:, None] * Gt * ts[None, :]
    Js = rs[:, None] * J
    N_J, rank_J = null_space(Js)
    N_B, _ = null_space(N_J.T) if N_J.shape[1] else (np.eye(J.shape[1]), 0)
    C = np.hstack([Gs, -Js @ N_B])
    N_C, _ = null_space(C)
    m = Gt.shape[1]
    D = ts[:, None] * N_C[:m]
    E = N_B @ N_C[m:]
    _, rank_D = null_space(N_C[:m].T) if N_C.shape[1] else (None, 0)
    _, rank_G = null_space(Gs)
    return JointObject(N_J, N_B, N_C, D, E, rank_J, rank_D, N_J.shape[1], dof, m - rank_G)


def report(jo: JointObject, *, contacts: int, joints: int, rows: int) -> str:
    """The classification as text (``ikc manipulate --describe``)."""
    lines = [
        f"contacts: {contacts}, joints: {joints}, contact constraints: {rows}, object dof: {jo.dof}",
        f"rank J = {jo.rank_J}   rank N_J (self-motions) = {jo.rank_NJ}   "
        f"rank D (object motions) = {jo.rank_D}",
        f"indeterminate object motions dim N(G^T) = {jo.indeterminate}"
        + ("" if jo.indeterminate == 0 else "  (the contacts do not hold the object: not a grasp)"),
        f"class: {KINDS[jo.kind]}",
    ]
    return "\n".join(lines)
