"""Shared machinery of the one-equation class III solvers and the rotate-to-plane extras: private.

Every one-unknown problem here (S3-R, S3-T, H-R, H-T) reduces to one scalar equation in the joint
value, either ``A cos th + B sin th = C`` (revolute) or a quadratic/linear in ``t`` (prismatic):

* a revolute joint moves ``p`` on the circle ``x(th) = a + b cos th + e sin th`` with centre ``a``
  (the foot of ``p`` on the axis), ``b = p - a`` and ``e = w x b`` (``|b| = |e|``, ``b . e = 0``);
* a prismatic joint moves it on the line ``x(t) = p + v t``.

Conventions shared by the solvers:

* **Exact** means the residual of the original equation (a distance, in the user's units) is at most
  ``EXACT_TOL`` times the problem scale (the largest point/offset magnitude); anything else is flagged
  ``ls``.  So a flag never depends on which branch of a case split ran.
* **Tangent merge**: two roots ``phi +- delta`` of ``A cos + B sin = C`` are one when
  ``r - |C| <= TANGENT_TOL`` times the size of the terms of ``C`` (``r = hypot(A, B)``): rounding alone
  would otherwise split an exact tangency into two roots ``~1e-8`` apart.
* **Continuum** when ``r`` (the equation's sensitivity to the angle) is at most ``FREE_TOL`` times its
  natural size: every angle does the same; the representative is ``th = 0``.
"""

from __future__ import annotations

import math

import numpy as np

from subproblems import tolerances as tol
from subproblems.angles import wrap, wrap_array
from subproblems.core import SubproblemInputError
from subproblems.screw import cross_tuple as cross

# Tolerances: subproblems/tolerances.py (each with its reason there; docs/design.md section 10).
EXACT_TOL = tol.EXACT
TANGENT_TOL = tol.S3_TANGENT
FREE_TOL = tol.S3_FREE_ANGLE
TINY = tol.TINY


# ------------------------------------------------------------------------------------ small vectors


def dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def sub(a, b) -> tuple[float, float, float]:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def add(a, b) -> tuple[float, float, float]:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def scale_vec(s: float, a) -> tuple[float, float, float]:
    return (s * a[0], s * a[1], s * a[2])


def norm(a) -> float:
    return math.sqrt(dot(a, a))


# ------------------------------------------------------------------------------------------ inputs


def point(code: str, name: str, value) -> tuple[float, float, float]:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (3,):
        raise SubproblemInputError(f"{code}: {name} must be a 3-vector, got shape {arr.shape}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def number(code: str, name: str, value) -> float:
    arr = np.asarray(value, dtype=float)
    if arr.size != 1:
        raise SubproblemInputError(f"{code}: {name} must be one number, got shape {arr.shape}")
    return float(arr.reshape(()))


def need(code: str, **given) -> None:
    missing = [k for k, v in given.items() if v is None]
    if missing:
        raise SubproblemInputError(f"{code}: missing input(s) {', '.join(missing)}")


# ---------------------------------------------------------------------------------- circle of a point


def circle(xi, p):
    """Centre ``a``, radius vectors ``b, e`` of the circle a revolute twist moves ``p`` on.

    ``exp(xi th) p = a + b cos th + e sin th``.
    """
    v, w = (float(xi[0]), float(xi[1]), float(xi[2])), (float(xi[3]), float(xi[4]), float(xi[5]))
    c = cross(w, v)  # axis point closest to the origin
    u = sub(p, c)
    a = add(c, scale_vec(dot(w, u), w))
    b = sub(p, a)
    return a, b, cross(w, b)


def circle_batch(xi, p):
    """Vectorised :func:`circle`: xi (N, 6), p (N, 3) -> a, b, e (N, 3)."""
    v, w = xi[:, :3], xi[:, 3:]
    c = np.cross(w, v)
    a = c + w * np.sum(w * (p - c), axis=1, keepdims=True)
    b = p - a
    return a, b, np.cross(w, b)


# ------------------------------------------------------------------------- A cos th + B sin th = C


def trig_linear(
    A: float, B: float, C: float, mag: float, free_mag: float | None = None
) -> tuple[list[float], bool]:
    """Candidate angles of ``A cos th + B sin th = C`` and whether the angle is free.

    ``mag`` is the natural size of the terms (same units as ``C``); ``free_mag`` (default ``mag``) the
    size against which ``r ~ 0`` is judged (the problem's scale in those units).  Returns the exact
    roots (one at a tangency, two otherwise), or, when ``|C| > r``, the angle closest to satisfying it; with
    ``r ~ 0`` the representative ``[0.0]`` and ``True``.
    """
    r = math.hypot(A, B)
    if r <= FREE_TOL * max(mag, free_mag or 0.0):
        return [0.0], True
    phi = math.atan2(B, A)
    if abs(C) >= r - TANGENT_TOL * mag:
        return [wrap(phi if C > 0 else phi + math.pi)], False
    delta = math.atan2(math.sqrt((r - C) * (r + C)), C)
    return sorted({wrap(phi - delta), wrap(phi + delta)}), False


def trig_linear_batch(A, B, C, mag, free_mag=None):
    """Vectorised :func:`trig_linear`: returns th (N, 2), valid (N, 2), free (N,)."""
    r = np.hypot(A, B)
    free = r <= FREE_TOL * (mag if free_mag is None else np.maximum(mag, free_mag))
    phi = np.arctan2(B, A)
    single = (np.abs(C) >= r - TANGENT_TOL * mag) | free
    t0 = np.where(C > 0, phi, phi + np.pi)
    disc = np.maximum((r - C) * (r + C), 0.0)
    delta = np.arctan2(np.sqrt(disc), C)
    th1 = np.where(single, t0, phi - delta)
    th2 = phi + delta
    th1 = np.where(free, 0.0, th1)
    th = wrap_array(np.stack([th1, th2], axis=1))
    th = np.sort(np.where(single[:, None] & (np.arange(2) == 1), np.inf, th), axis=1)
    valid = np.stack([np.ones_like(single), ~single], axis=1)
    th = np.where(valid, th, 0.0)
    return th, valid, free


def pack(code: str, th, valid, ls, cont):
    """BatchResult of a one-unknown solver from (N, K) slots."""
    from subproblems.core import BatchResult

    return BatchResult(code, th[:, :, None], valid, ls & valid, cont)


def batch_inputs(code: str, tw, **arrays):
    """Shapes of a one-unknown batch call: tw (N, 1, 6) -> (N, 6); points (N, 3); numbers (N,)."""
    out = {"xi": np.asarray(tw, dtype=float)[:, 0, :]}
    n = out["xi"].shape[0]
    for k, v in arrays.items():
        if v is None:
            raise SubproblemInputError(f"{code}: missing input {k}")
        a = np.asarray(v, dtype=float)
        out[k] = a.reshape(n, 3) if a.size == 3 * n and k != "d" else a.reshape(n)
    return out
