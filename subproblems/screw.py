"""Screw-theory primitives in the product-of-exponentials (POE) convention.

Twist coordinates are 6-vectors ``xi = (v, w)``:

* revolute joint: ``w`` is the unit axis direction and ``v = -w x r`` for any point ``r`` on the axis;
* prismatic joint: ``w = 0`` and ``v`` is the unit direction of travel.

Rigid transforms are 4x4 homogeneous matrices.  Everything here is plain numpy and is shared by the
subproblem solvers and by the compiler (which must not depend on anything heavier).

>>> import numpy as np
>>> xi = revolute_twist([0, 0, 1], [1, 0, 0])
>>> g = twist_exp(xi, np.pi / 2)
>>> np.round(g[:3, 3], 12) + 0.0
array([ 1., -1.,  0.])
"""

from __future__ import annotations

import math

import numpy as np

from subproblems.tolerances import ZERO_AXIS

__all__ = [
    "hat",
    "revolute_twist",
    "prismatic_twist",
    "is_prismatic",
    "axis_point",
    "twist_exp",
    "twist_exp_batch",
    "fk",
    "fk_batch",
    "rotation_exp",
    "adjoint",
    "transform_twist",
    "inverse_transform",
    "apply",
    "rigid_residual",
    "cross",
    "cross_tuple",
]


def hat(w) -> np.ndarray:
    """Skew-symmetric matrix ``[w]`` with ``[w] x = w x x``.

    >>> hat([1, 2, 3]) @ np.array([4, 5, 6]) - np.cross([1, 2, 3], [4, 5, 6])
    array([0, 0, 0])
    """
    x, y, z = w
    return np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])


def revolute_twist(w, r) -> np.ndarray:
    """Twist of a revolute joint with (not necessarily unit) axis ``w`` through point ``r``.

    >>> revolute_twist([0, 0, 2], [1, 0, 0])
    array([-0., -1., -0.,  0.,  0.,  1.])
    """
    w = np.asarray(w, dtype=float)
    w = w / np.linalg.norm(w)
    return np.concatenate([-np.cross(w, np.asarray(r, dtype=float)), w])


def prismatic_twist(v) -> np.ndarray:
    """Twist of a prismatic joint along (not necessarily unit) direction ``v``.

    >>> prismatic_twist([0, 3, 0])
    array([0., 1., 0., 0., 0., 0.])
    """
    v = np.asarray(v, dtype=float)
    return np.concatenate([v / np.linalg.norm(v), np.zeros(3)])


def is_prismatic(xi, tol: float = ZERO_AXIS) -> bool:
    """True when the twist has no rotational part.

    >>> is_prismatic(prismatic_twist([1, 0, 0])), is_prismatic(revolute_twist([1, 0, 0], [0, 0, 0]))
    (True, False)
    """
    return float(np.linalg.norm(np.asarray(xi, dtype=float)[3:])) <= tol


def axis_point(xi) -> np.ndarray:
    """The point of a revolute twist's axis closest to the origin (``w x v`` for unit ``w``).

    >>> axis_point(revolute_twist([0, 0, 1], [3, 4, 7])) + 0.0
    array([3., 4., 0.])
    """
    xi = np.asarray(xi, dtype=float)
    return cross3(xi[3:], xi[:3])


def rotation_exp(w, theta: float) -> np.ndarray:
    """Rodrigues' formula ``exp([w] theta)`` for a unit axis ``w``.

    >>> np.round(rotation_exp([0, 0, 1], np.pi / 2) @ [1, 0, 0], 12) + 0.0
    array([0., 1., 0.])
    """
    W = hat(np.asarray(w, dtype=float))
    return np.eye(3) + math.sin(theta) * W + (1.0 - math.cos(theta)) * (W @ W)


def twist_exp(xi, theta: float) -> np.ndarray:
    """Exponential ``exp(xi^ theta)`` of a unit twist (revolute or prismatic) as a 4x4 transform.

    >>> twist_exp(prismatic_twist([0, 0, 1]), 2.0)[:3, 3]
    array([0., 0., 2.])
    """
    xi = np.asarray(xi, dtype=float)
    v, w = xi[:3], xi[3:]
    g = np.eye(4)
    if not w.any():
        g[:3, 3] = v * theta
        return g
    R = rotation_exp(w, theta)
    g[:3, :3] = R
    g[:3, 3] = (np.eye(3) - R) @ cross3(w, v) + w * (w @ v) * theta
    return g


def twist_exp_batch(xi, theta) -> np.ndarray:
    """Vectorised ``exp(xi^ theta)`` over ``theta`` of shape (N,); returns (N, 4, 4).

    ``xi`` is one twist (6,) or one per instance (N, 6).

    >>> twist_exp_batch([0, 0, 0, 0, 0, 1], np.array([0.0, np.pi])).shape
    (2, 4, 4)
    """
    theta = np.asarray(theta, dtype=float)
    xi = np.broadcast_to(np.asarray(xi, dtype=float), theta.shape + (6,))
    v, w = xi[..., :3], xi[..., 3:]
    s, c = np.sin(theta)[..., None, None], np.cos(theta)[..., None, None]
    W = np.zeros(theta.shape + (3, 3))
    W[..., 0, 1], W[..., 0, 2] = -w[..., 2], w[..., 1]
    W[..., 1, 0], W[..., 1, 2] = w[..., 2], -w[..., 0]
    W[..., 2, 0], W[..., 2, 1] = -w[..., 1], w[..., 0]
    R = np.eye(3) + s * W + (1.0 - c) * (W @ W)
    revolute = np.any(w != 0.0, axis=-1)
    # w x v written out: numpy's cross spends most of its time on axis bookkeeping for small arrays
    wxv = np.stack(
        [
            w[..., 1] * v[..., 2] - w[..., 2] * v[..., 1],
            w[..., 2] * v[..., 0] - w[..., 0] * v[..., 2],
            w[..., 0] * v[..., 1] - w[..., 1] * v[..., 0],
        ],
        axis=-1,
    )
    t_rev = wxv - (R @ wxv[..., None])[..., 0] + w * (np.sum(w * v, axis=-1) * theta)[..., None]
    t_pri = v * theta[..., None]
    g = np.zeros(theta.shape + (4, 4))
    g[..., :3, :3] = R
    g[..., :3, 3] = np.where(revolute[..., None], t_rev, t_pri)
    g[..., 3, 3] = 1.0
    return g


def fk(twists, q, home=None) -> np.ndarray:
    """Forward kinematics ``exp(xi_1 q_1) ... exp(xi_n q_n) [home]`` (4x4) of one joint vector.

    The one product of exponentials of the package (docs/design.md section 10); :func:`fk_batch` is
    its vectorised form and agrees with it to roundoff.

    >>> fk([prismatic_twist([1, 0, 0]), revolute_twist([0, 0, 1], [0, 0, 0])], [2.0, 0.0])[:3, 3]
    array([2., 0., 0.])
    """
    g = np.eye(4)
    for xi, t in zip(twists, q):
        g = g @ twist_exp(xi, t)
    return g if home is None else g @ np.asarray(home, dtype=float)


def fk_batch(twists, Q, home=None) -> np.ndarray:
    """:func:`fk` over joint vectors ``Q`` (..., n): poses (..., 4, 4).

    ``twists`` is one chain (n, 6) for every row, or one per row, broadcast against ``Q``'s leading
    axes ((..., n, 6)); ``home`` (4x4) multiplies on the right when given.

    >>> fk_batch([[0, 0, 0, 0, 0, 1]], np.zeros((5, 1)), np.eye(4)).shape
    (5, 4, 4)
    """
    Q = np.asarray(Q, dtype=float)
    tw = np.asarray(twists, dtype=float)
    g = np.broadcast_to(np.eye(4), Q.shape[:-1] + (4, 4)).copy()
    for i in range(Q.shape[-1]):
        g = g @ twist_exp_batch(tw[..., i, :], Q[..., i])
    return g if home is None else g @ np.asarray(home, dtype=float)


def inverse_transform(g) -> np.ndarray:
    """Inverse of a rigid transform (4x4, or stacked (..., 4, 4)).

    >>> g = twist_exp(revolute_twist([1, 1, 0], [0, 2, 0]), 0.7)
    >>> bool(np.allclose(inverse_transform(g) @ g, np.eye(4)))
    True
    """
    g = np.asarray(g, dtype=float)
    R = g[..., :3, :3]
    Rt = np.swapaxes(R, -1, -2)
    out = np.zeros_like(g)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, g[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def adjoint(g) -> np.ndarray:
    """Adjoint ``Ad_g = [[R, [p] R], [0, R]]`` acting on twists ``(v, w)``.

    It satisfies ``g exp(xi^ th) g^-1 = exp((Ad_g xi)^ th)``.

    >>> g = twist_exp(revolute_twist([0, 1, 0], [1, 0, 0]), 0.3)
    >>> xi = revolute_twist([1, 0, 0], [0, 0, 1])
    >>> lhs = g @ twist_exp(xi, 0.5) @ inverse_transform(g)
    >>> bool(np.allclose(lhs, twist_exp(adjoint(g) @ xi, 0.5)))
    True
    """
    g = np.asarray(g, dtype=float)
    R, p = g[:3, :3], g[:3, 3]
    A = np.zeros((6, 6))
    A[:3, :3] = R
    A[:3, 3:] = hat(p) @ R
    A[3:, 3:] = R
    return A


def transform_twist(g, xi) -> np.ndarray:
    """``Ad_g xi``: the twist ``xi`` carried by the rigid motion ``g``.

    >>> transform_twist(np.eye(4), [1, 2, 3, 0, 0, 0])
    array([1., 2., 3., 0., 0., 0.])
    """
    return adjoint(g) @ np.asarray(xi, dtype=float)


def cross_tuple(a, b) -> tuple:
    """``a x b`` of two 3-sequences, component by component: floats, arrays of components or sympy
    expressions alike (the fast kernels' 3-tuples).  The one cross product formula of the package.

    >>> cross_tuple((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    (0.0, 0.0, 1.0)
    """
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def cross3(a, b) -> np.ndarray:
    """``np.cross`` of two 3-vectors written out: the same products and differences, so the same bits,
    without np.cross's axis handling (~8 us a call; the reference solvers' Newton steps make thousands).

    >>> cross3(np.array([1.0, 0, 0]), np.array([0.0, 1, 0])).tolist()
    [0.0, 0.0, 1.0]
    """
    a0, a1, a2 = a[0], a[1], a[2]
    b0, b1, b2 = b[0], b[1], b[2]
    return np.array((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), dtype=float)


def cross(a, b) -> np.ndarray:
    """``a x b`` over the last axis of (..., 3) arrays, broadcast (numpy's cross is slow on small stacks).

    >>> cross(np.array([[1.0, 0, 0]]), np.array([0.0, 1, 0])).tolist()
    [[0.0, 0.0, 1.0]]
    """
    columns = cross_tuple((a[..., 0], a[..., 1], a[..., 2]), (b[..., 0], b[..., 1], b[..., 2]))
    return np.stack(columns, axis=-1)


def apply(g, p) -> np.ndarray:
    """Apply a rigid transform to a point (3,) or points (..., 3).

    >>> apply(twist_exp(prismatic_twist([1, 0, 0]), 2.0), [0, 0, 0])
    array([2., 0., 0.])
    """
    g = np.asarray(g, dtype=float)
    p = np.asarray(p, dtype=float)
    return p @ g[:3, :3].T + g[:3, 3]


def rigid_residual(g) -> float:
    """How far a 4x4 matrix is from a rigid transform (0 for an exact one).

    >>> rigid_residual(np.eye(4))
    0.0
    """
    g = np.asarray(g, dtype=float)
    R = g[:3, :3]
    err = np.abs(R.T @ R - np.eye(3)).max()
    err = max(err, abs(np.linalg.det(R) - 1.0), np.abs(g[3] - [0, 0, 0, 1]).max())
    return float(err)
