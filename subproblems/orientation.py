"""Orientation subproblems ``O-R``, ``O-RR``, ``O-RRR``: rotations about axes through the origin.

Equation (only the rotation part of the 4x4 input ``T`` is used; the twists must be revolute and only
their axes ``w_i`` matter):

    exp([w_1] t_1) ... exp([w_m] t_m) = R,   m = 1, 2, 3

This is what orientation separation (rule 2) leaves: the revolute joints' rotations, with parallel runs
already merged by the compiler (consecutive axes are not parallel).

* ``O-R``: one solution ``t = atan2(tr(W^T R), -tr(W^2^T R))``, the exact angle when R is a rotation
  about w, otherwise the least-squares (Frobenius-closest) angle, flagged ``ls``.
* ``O-RR``: apply both sides to ``w_2``: ``exp([w_1] t_1) w_2 = R w_2`` gives ``t_1`` (rotate one unit
  vector onto another about ``w_1``), then ``t_2`` from the ``O-R`` of ``exp(-[w_1] t_1) R``.  One
  solution; least-squares flagged when ``w_1 . w_2 != w_1 . R w_2``.
* ``O-RRR``: apply to ``w_3``: ``exp([w_1] t_1) exp([w_2] t_2) w_3 = R w_3``.  The intermediate vector
  ``z = exp([w_2] t_2) w_3`` satisfies ``w_1 . z = w_1 . R w_3``, ``w_2 . z = w_2 . w_3`` and ``|z| = 1``:
  two solutions ``z = a w_1 + b w_2 +- c (w_1 x w_2)`` (one when ``c = 0``; a least-squares one with
  ``c = 0`` when ``c^2 < 0``).  Then ``t_2``, ``t_1`` by rotating unit vectors, ``t_3`` by ``O-R``.
  Gimbal lock (``z`` parallel to ``w_1``, so axes 1 and 3 line up) is a continuum: ``t_1 = 0`` is the
  documented representative, flagged ``continuum``.

The scalar path runs the vectorised one on a single instance, so the two agree by construction.
"""

from __future__ import annotations

import numpy as np

from subproblems.core import BatchResult, Solution, register

_EPS = 1e-12


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _cross(a, b):
    return np.stack(
        [
            a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
            a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
            a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0],
        ],
        axis=-1,
    )


def _rot(w, t):
    """Rodrigues rotation matrices for axes w (N, 3) and angles t (N,)."""
    W = np.zeros(w.shape[:-1] + (3, 3))
    W[..., 0, 1], W[..., 0, 2] = -w[..., 2], w[..., 1]
    W[..., 1, 0], W[..., 1, 2] = w[..., 2], -w[..., 0]
    W[..., 2, 0], W[..., 2, 1] = -w[..., 1], w[..., 0]
    s, c = np.sin(t)[..., None, None], np.cos(t)[..., None, None]
    return np.eye(3) + s * W + (1 - c) * (W @ W)


def _rotate_onto(w, u, v):
    """Angle rotating unit vector u toward v about w (N,), and True where u is parallel to w."""
    uu = u - _dot(u, w)[..., None] * w
    vv = v - _dot(v, w)[..., None] * w
    degenerate = np.linalg.norm(uu, axis=-1) < 1e-9
    t = np.arctan2(_dot(w, _cross(uu, vv)), _dot(uu, vv))
    return np.where(degenerate, 0.0, t), degenerate


def _single(w, R):
    """O-R angle (N,) and whether it is exact."""
    Wt_R = _dot(
        w,
        np.stack(
            [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], axis=-1
        ),
    )
    wRw = np.einsum("...i,...ij,...j->...", w, R, w)
    b = wRw - np.trace(R, axis1=-2, axis2=-1)
    t = np.arctan2(Wt_R, -b)
    err = np.abs(_rot(w, t) - R).max(axis=(-2, -1))
    return t, err <= 1e-9


def _batch_r(tw, T):
    w, R = tw[:, 0, 3:], T[:, :3, :3]
    t, exact = _single(w, R)
    return BatchResult(
        "O-R", t[:, None, None], np.ones((len(t), 1), bool), ~exact[:, None], np.zeros(len(t), bool)
    )


def _solve_rr(w1, w2, R):
    y = np.einsum("nij,nj->ni", R, w2)
    t1, deg = _rotate_onto(w1, w2, y)
    R2 = np.swapaxes(_rot(w1, t1), -1, -2) @ R
    t2, exact2 = _single(w2, R2)
    return t1, t2, exact2, deg


def _batch_rr(tw, T):
    w1, w2, R = tw[:, 0, 3:], tw[:, 1, 3:], T[:, :3, :3]
    t1, t2, exact, deg = _solve_rr(w1, w2, R)
    n = len(t1)
    return BatchResult(
        "O-RR", np.stack([t1, t2], axis=1)[:, None, :], np.ones((n, 1), bool), ~exact[:, None], deg
    )


def _batch_rrr(tw, T):
    w1, w2, w3, R = tw[:, 0, 3:], tw[:, 1, 3:], tw[:, 2, 3:], T[:, :3, :3]
    n = len(w1)
    y = np.einsum("nij,nj->ni", R, w3)
    c12 = _dot(w1, w2)
    a1, a2 = _dot(w1, y), _dot(w2, w3)
    den = np.maximum(1 - c12**2, _EPS)
    alpha = (a1 - c12 * a2) / den
    beta = (a2 - c12 * a1) / den
    n12 = _cross(w1, w2)
    g2 = (1 - alpha**2 - beta**2 - 2 * alpha * beta * c12) / np.maximum(_dot(n12, n12), _EPS)
    reach = g2 >= -1e-12
    gamma = np.sqrt(np.maximum(g2, 0.0))
    Q = np.zeros((n, 2, 3))
    valid = np.zeros((n, 2), bool)
    ls = np.zeros((n, 2), bool)
    cont = np.zeros(n, bool)
    for k, sgn in enumerate((1.0, -1.0)):
        z = alpha[:, None] * w1 + beta[:, None] * w2 + (sgn * gamma)[:, None] * n12
        z = z / np.linalg.norm(z, axis=1, keepdims=True)
        t2, _ = _rotate_onto(w2, w3, z)
        t1, deg = _rotate_onto(w1, z, y)
        R3 = np.swapaxes(_rot(w1, t1) @ _rot(w2, t2), -1, -2) @ R
        t3, exact = _single(w3, R3)
        Q[:, k] = np.stack([t1, t2, t3], axis=1)
        valid[:, k] = True if k == 0 else gamma > 1e-9
        ls[:, k] = ~(exact & reach)
        cont |= deg & reach
    return BatchResult("O-RRR", Q, valid, ls, cont)


def _scalar(batch):
    def solve_one(tw, T):
        r = batch(np.asarray(tw)[None], np.asarray(T)[None])
        return [
            Solution(tuple(float(x) for x in r.q[0, k]), bool(r.ls[0, k]), bool(r.continuum[0]))
            for k in range(r.q.shape[1])
            if r.valid[0, k]
        ]

    return solve_one


def _orientation_residual(tw, row, T, **_):
    R = np.eye(3)
    for xi, t in zip(tw, row):
        R = R @ _rot(np.asarray(xi[3:])[None], np.array([t]))[0]
    return float(np.abs(R - np.asarray(T)[:3, :3]).max())


register("O-R", 1, batch=_batch_r, residual=_orientation_residual)(_scalar(_batch_r))
register("O-RR", 1, batch=_batch_rr, residual=_orientation_residual)(_scalar(_batch_rr))
register("O-RRR", 2, batch=_batch_rrr, residual=_orientation_residual)(_scalar(_batch_rrr))
