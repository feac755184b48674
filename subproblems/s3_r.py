"""S3-R: rotate a point to a given distance from another point (Paden-Kahan subproblem 3).

Equation: ``|| exp(xi th) p - q || = d`` with ``xi`` revolute.  Inputs: ``twists=[xi]``, ``p``, ``q``
(3,), ``d`` (a number).

Geometry: ``p`` turns on the circle ``a + b cos th + e sin th`` about the axis; the sphere of radius
``d`` about ``q`` cuts that circle in 0, 1 or 2 points.  Squaring, with ``m = a - q``, ``rho = |b|``:

    2 (m.b) cos th + 2 (m.e) sin th = d^2 - |m|^2 - rho^2,

one equation ``A cos th + B sin th = C``; ``th = phi +- acos(C / r)``, ``phi = atan2(B, A)``,
``r = hypot(A, B)``.

Max solutions: 2.

Degenerate cases and what is returned:

* the sphere misses the circle (``d`` out of range ``[min, max]`` of the distance, or ``d < 0``):
  the angle whose distance is closest to ``d`` (the nearest or the farthest point of the circle),
  flagged ``ls``;
* the sphere touches the circle: one solution;
* ``p`` on the axis, or ``q`` on the axis: the distance is the same for every angle; ``th = 0``,
  flagged ``continuum`` (and ``ls`` unless that distance is ``d``).

>>> from subproblems import solve
>>> from subproblems.screw import revolute_twist
>>> r = solve("S3-R", [revolute_twist([0, 0, 1], [0, 0, 0])], p=[1, 0, 0], q=[0, 0, 0], d=1.0)
>>> r.q.tolist(), r.continuum
([[0.0]], True)
>>> r = solve("S3-R", [revolute_twist([0, 0, 1], [0, 0, 0])], p=[1, 0, 0], q=[1, 1, 0], d=1.0)
>>> [round(float(x), 12) for x in r.q[:, 0]]
[0.0, 1.570796326795]
"""

from __future__ import annotations

import math

import numpy as np

from subproblems._class3 import (
    EXACT_TOL,
    TINY,
    batch_inputs,
    circle,
    circle_batch,
    dot,
    need,
    norm,
    number,
    pack,
    point,
    sub,
    trig_linear,
    trig_linear_batch,
)
from subproblems.core import Solution, register

__all__ = ["distance_angle"]


def distance_angle(xi, p, q, d: float) -> list[Solution]:
    """Every ``th`` with ``|| exp(xi th) p - q || = d`` (S3-R; see the module docstring).

    Plain floats: ``xi`` a 6-sequence, ``p``, ``q`` 3-sequences.

    >>> from subproblems.screw import revolute_twist
    >>> [s.q for s in distance_angle(revolute_twist([0, 0, 1], [0, 0, 0]), (1, 0, 0), (3, 0, 0), 2.0)]
    [(0.0,)]
    """
    a, b, e = circle(xi, p)
    m = sub(a, q)
    rho2 = dot(b, b)
    mm = dot(m, m)
    scale = max(norm(p), norm(q), abs(d), norm(a), TINY)
    mag = d * d + mm + rho2 + TINY
    A, B = 2.0 * dot(m, b), 2.0 * dot(m, e)
    C = d * d - mm - rho2 if d >= 0.0 else -(math.hypot(A, B) + mag)
    ths, free = trig_linear(A, B, C, mag, scale * scale)
    out = []
    for th in ths:
        c, s = math.cos(th), math.sin(th)
        x = (
            a[0] + b[0] * c + e[0] * s - q[0],
            a[1] + b[1] * c + e[1] * s - q[1],
            a[2] + b[2] * c + e[2] * s - q[2],
        )
        res = abs(norm(x) - d)
        out.append(Solution((th,), ls=res > EXACT_TOL * scale, continuum=free))
    return out


def _batch(tw, p=None, q=None, d=None, **_):
    x = batch_inputs("S3-R", tw, p=p, q=q, d=d)
    xi, p, q, d = x["xi"], x["p"], x["q"], x["d"]
    a, b, e = circle_batch(xi, p)
    m = a - q
    rho2 = np.sum(b * b, axis=1)
    mm = np.sum(m * m, axis=1)
    nrm = np.linalg.norm
    scale = np.maximum.reduce([nrm(p, axis=1), nrm(q, axis=1), np.abs(d), nrm(a, axis=1)])
    scale = np.maximum(scale, TINY)
    mag = d * d + mm + rho2 + TINY
    A, B = 2.0 * np.sum(m * b, axis=1), 2.0 * np.sum(m * e, axis=1)
    C = np.where(d >= 0.0, d * d - mm - rho2, -(np.hypot(A, B) + mag))
    th, valid, free = trig_linear_batch(A, B, C, mag, scale * scale)
    c, s = np.cos(th)[..., None], np.sin(th)[..., None]
    xs = a[:, None] + b[:, None] * c + e[:, None] * s - q[:, None]
    ls = np.abs(np.linalg.norm(xs, axis=2) - d[:, None]) > EXACT_TOL * scale[:, None]
    return pack("S3-R", th, valid, ls, free)


@register("S3-R", 2, batch=_batch)
def solve_s3_r(twists, p, q, d) -> list[Solution]:
    """Registered scalar path of S3-R: checks the inputs and calls :func:`distance_angle`."""
    need("S3-R", p=p, q=q, d=d)
    return distance_angle(twists[0], point("S3-R", "p", p), point("S3-R", "q", q), number("S3-R", "d", d))
