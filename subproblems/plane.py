"""H-R and H-T: move a point onto a plane with one joint (rotate-to-plane; addition to the 28 types).

Equation: ``h^T exp(xi th) p = d``: after the joint moves ``p``, it lies on the plane ``h . x = d``.
``h`` need not be unit (the equation is divided by ``|h|``); the residual is the point's distance to
the plane.  Inputs: ``twists=[xi]``, ``p`` (3,), ``h`` (3,), ``d`` (a number).

Where it comes from: axial-projection invariance (docs/design.md section 3, rule 6).  A revolute joint does
not change a point's coordinate along its own axis, so projecting the POE equation onto the common
direction ``h`` of a run of parallel axes removes every joint of the run; if one unknown joint is left,
the projection reads ``h^T exp(xi th) p = d``.  Typical use: the first joint of a UR-type arm (axes
2-3-4 parallel; the wrist point projected on their direction), and, with ``p`` a direction and ``xi``
through the origin, orientation steps that project an axis direction on another (``p`` is then a
direction and the "plane" a cone condition).

**H-R** (revolute): ``p`` turns on the circle ``a + b cos th + e sin th`` about the axis, so the
equation is ``A cos th + B sin th = C`` with ``A = h.b``, ``B = h.e``, ``C = d - h.a``.
Max solutions: 2.

* the circle crosses the plane: two solutions; touches it: one;
* the circle misses the plane: the angle bringing ``p`` closest to the plane, flagged ``ls``;
* ``p`` on the axis, or the plane parallel to the circle's plane (``h`` along the axis): every angle
  does the same; ``th = 0``, flagged ``continuum`` (and ``ls`` unless that circle lies in the plane);
* ``h = 0``: the equation is ``0 = d``; as the previous case.

**H-T** (prismatic along ``v``): ``(h.v) t = d - h.p``.  Max solutions: 1.

* ``h.v != 0``: one solution;
* ``h.v = 0`` (travel parallel to the plane): every ``t`` does the same; ``t = 0``, flagged
  ``continuum`` (and ``ls`` unless ``p`` is on the plane).

>>> from subproblems import solve
>>> from subproblems.screw import prismatic_twist, revolute_twist
>>> r = solve("H-R", [revolute_twist([0, 0, 1], [0, 0, 0])], p=[1, 0, 0], h=[0, 1, 0], d=0.5)
>>> [round(float(x), 12) for x in r.q[:, 0]], r.ls.tolist()
([0.523598775598, 2.617993877991], [False, False])
>>> r = solve("H-T", [prismatic_twist([1, 1, 0])], p=[0, 0, 0], h=[1, 0, 0], d=2.0)
>>> round(float(r.q[0, 0]), 12)
2.828427124746
"""

from __future__ import annotations

import math

import numpy as np

from subproblems._class3 import (
    EXACT_TOL,
    FREE_TOL,
    batch_inputs,
    circle,
    circle_batch,
    dot,
    need,
    norm,
    number,
    pack,
    point,
    trig_linear,
    trig_linear_batch,
)
from subproblems.core import Solution, register
from subproblems.screw import twist_exp

__all__ = ["rotate_to_plane", "slide_to_plane", "plane_residual"]


def plane_residual(twists, qrow, p=None, h=None, d=None, **_) -> float:
    """Distance of ``exp(xi th) p`` from the plane ``h . x = d`` (``|d|`` when ``h = 0``)."""
    g = twist_exp(np.asarray(twists, dtype=float)[0], float(qrow[0]))
    x = g[:3, :3] @ np.asarray(p, dtype=float) + g[:3, 3]
    h = np.asarray(h, dtype=float)
    hn = float(np.linalg.norm(h))
    d = float(np.asarray(d, dtype=float).reshape(()))
    return abs(d) if hn == 0.0 else abs(float(h @ x) - d) / hn


def _scale(*norms) -> float:
    # Floored at 1 (user units), as in class II: geometry at the origin (p = 0, d = 0) has no size of
    # its own, and a zero scale would call roundoff of 1e-18 inexact.
    return max(max(norms), 1.0)


def rotate_to_plane(xi, p, h, d: float) -> list[Solution]:
    """Every ``th`` with ``h^T exp(xi th) p = d`` for a revolute twist ``xi`` (H-R; module docstring).

    ``xi`` is a 6-sequence, ``p`` and ``h`` 3-sequences, ``d`` a float; plain floats throughout.

    >>> from subproblems.screw import revolute_twist
    >>> [s.q for s in rotate_to_plane(revolute_twist([0, 0, 1], [0, 0, 0]), (1, 0, 0), (1, 0, 0), 1.0)]
    [(0.0,)]
    """
    a, b, e = circle(xi, p)
    hn = norm(h)
    rho = norm(b)
    dn = d / hn if hn > 0.0 else d
    scale = _scale(norm(p), norm(a), abs(dn), rho)
    if hn == 0.0:
        A = B = 0.0
        C = d
    else:
        hu = (h[0] / hn, h[1] / hn, h[2] / hn)
        A, B, C = dot(hu, b), dot(hu, e), dn - dot(hu, a)
    ths, free = trig_linear(A, B, C, scale)
    out = []
    for th in ths:
        c, s = math.cos(th), math.sin(th)
        res = abs(A * c + B * s - C)
        out.append(Solution((th,), ls=res > EXACT_TOL * scale, continuum=free))
    return out


def slide_to_plane(xi, p, h, d: float) -> list[Solution]:
    """The ``t`` with ``h^T exp(xi t) p = d`` for a prismatic twist ``xi`` (H-T; module docstring).

    >>> from subproblems.screw import prismatic_twist
    >>> slide_to_plane(prismatic_twist([0, 0, 1]), (0, 0, 1), (0, 0, 2), 4.0)[0].q
    (1.0,)
    """
    v = (float(xi[0]), float(xi[1]), float(xi[2]))
    hn = norm(h)
    dn = d / hn if hn > 0.0 else d
    scale = _scale(norm(p), abs(dn))
    if hn == 0.0:
        A, C = 0.0, d
    else:
        hu = (h[0] / hn, h[1] / hn, h[2] / hn)
        A, C = dot(hu, v), dn - dot(hu, p)
    free = abs(A) <= FREE_TOL
    t = 0.0 if free else C / A
    res = abs(A * t - C)
    return [Solution((t,), ls=res > EXACT_TOL * scale, continuum=free)]


@register(
    "H-R", 2, batch=lambda tw, p=None, h=None, d=None, **_: _h_r_batch(tw, p, h, d), residual=plane_residual
)
def solve_h_r(twists, p=None, h=None, d=None, **_) -> list[Solution]:
    """Registered scalar path of H-R: checks the inputs and calls :func:`rotate_to_plane`."""
    need("H-R", p=p, h=h, d=d)
    return rotate_to_plane(twists[0], point("H-R", "p", p), point("H-R", "h", h), number("H-R", "d", d))


@register(
    "H-T", 1, batch=lambda tw, p=None, h=None, d=None, **_: _h_t_batch(tw, p, h, d), residual=plane_residual
)
def solve_h_t(twists, p=None, h=None, d=None, **_) -> list[Solution]:
    """Registered scalar path of H-T: checks the inputs and calls :func:`slide_to_plane`."""
    need("H-T", p=p, h=h, d=d)
    return slide_to_plane(twists[0], point("H-T", "p", p), point("H-T", "h", h), number("H-T", "d", d))


def _normalised(h, d):
    hn = np.linalg.norm(h, axis=1)
    zero = hn == 0.0
    safe = np.where(zero, 1.0, hn)
    return h / safe[:, None], d / safe, zero


def _h_r_batch(tw, p, h, d):
    x = batch_inputs("H-R", tw, p=p, h=h, d=d)
    xi, p, h, d = x["xi"], x["p"], x["h"], x["d"]
    a, b, e = circle_batch(xi, p)
    hu, dn, zero = _normalised(h, d)
    scale = np.maximum.reduce(
        [np.linalg.norm(p, axis=1), np.linalg.norm(a, axis=1), np.abs(dn), np.linalg.norm(b, axis=1)]
    )
    scale = np.maximum(scale, 1.0)
    A = np.where(zero, 0.0, np.sum(hu * b, axis=1))
    B = np.where(zero, 0.0, np.sum(hu * e, axis=1))
    C = np.where(zero, d, dn - np.sum(hu * a, axis=1))
    th, valid, free = trig_linear_batch(A, B, C, scale)
    res = np.abs(A[:, None] * np.cos(th) + B[:, None] * np.sin(th) - C[:, None])
    ls = res > EXACT_TOL * scale[:, None]
    return pack("H-R", th, valid, ls, free)


def _h_t_batch(tw, p, h, d):
    x = batch_inputs("H-T", tw, p=p, h=h, d=d)
    xi, p, h, d = x["xi"], x["p"], x["h"], x["d"]
    hu, dn, zero = _normalised(h, d)
    scale = np.maximum(np.maximum(np.linalg.norm(p, axis=1), np.abs(dn)), 1.0)
    A = np.where(zero, 0.0, np.sum(hu * xi[:, :3], axis=1))
    C = np.where(zero, d, dn - np.sum(hu * p, axis=1))
    free = np.abs(A) <= FREE_TOL
    t = np.where(free, 0.0, C / np.where(free, 1.0, A))
    ls = np.abs(A * t - C) > EXACT_TOL * scale
    n = len(t)
    return pack("H-T", t[:, None], np.ones((n, 1), bool), ls[:, None], free)
