"""S3-T: slide a point to a given distance from another point.

Equation: ``|| exp(xi t) p - q || = d`` with ``xi`` prismatic along the unit ``v``: ``|| p + v t - q || = d``.
Inputs: ``twists=[xi]``, ``p``, ``q`` (3,), ``d`` (a number).

Geometry: the line ``p + v t`` cuts the sphere of radius ``d`` about ``q``.  With ``u = p - q`` and
``s = u.v``: ``t^2 + 2 s t + |u|^2 - d^2 = 0``, ``t = -s +- sqrt(d^2 - |u_perp|^2)`` where ``u_perp``
is ``u`` without its component along ``v`` (evaluated in the cancellation-free form: the larger root
first, the smaller from the product of the roots).

Max solutions: 2.

Degenerate cases and what is returned:

* the line misses the sphere (``d`` smaller than the distance from ``q`` to the line, or ``d < 0``):
  ``t = -s``, the point of the line nearest ``q``, flagged ``ls``;
* the line touches the sphere: one solution ``t = -s``;
* no continuum: a unit ``v`` always determines ``t``.

>>> from subproblems import solve
>>> from subproblems.screw import prismatic_twist
>>> r = solve("S3-T", [prismatic_twist([1, 0, 0])], p=[0, 0, 0], q=[0, 3, 0], d=5.0)
>>> r.q[:, 0].tolist()
[-4.0, 4.0]
"""

from __future__ import annotations

import math

import numpy as np

from subproblems._class3 import (
    EXACT_TOL,
    TANGENT_TOL,
    TINY,
    batch_inputs,
    cross,
    dot,
    need,
    norm,
    number,
    pack,
    point,
    sub,
)
from subproblems.core import Solution, register

__all__ = ["distance_slide"]


def distance_slide(xi, p, q, d: float) -> list[Solution]:
    """Every ``t`` with ``|| p + v t - q || = d`` (S3-T; see the module docstring).

    >>> from subproblems.screw import prismatic_twist
    >>> [s.q for s in distance_slide(prismatic_twist([0, 0, 1]), (0, 0, 0), (1, 0, 0), 1.0)]
    [(0.0,)]
    """
    v = (float(xi[0]), float(xi[1]), float(xi[2]))
    u = sub(p, q)
    s = dot(u, v)
    un = norm(u)
    perp = norm(cross(u, v))
    scale = max(norm(p), norm(q), abs(d), TINY)
    mag = d * d + un * un + TINY
    disc = (d - perp) * (d + perp) if d >= 0.0 else -math.inf
    if disc <= TANGENT_TOL * mag:
        ts = [-s]
    else:
        t1 = -(s + math.copysign(math.sqrt(disc), s))
        t2 = (un - d) * (un + d) / t1
        ts = sorted([t1, t2])
    out = []
    for t in ts:
        res = abs(norm((u[0] + v[0] * t, u[1] + v[1] * t, u[2] + v[2] * t)) - d)
        out.append(Solution((t,), ls=res > EXACT_TOL * scale))
    return out


def _batch(tw, p=None, q=None, d=None, **_):
    x = batch_inputs("S3-T", tw, p=p, q=q, d=d)
    xi, p, q, d = x["xi"], x["p"], x["q"], x["d"]
    v = xi[:, :3]
    u = p - q
    s = np.sum(u * v, axis=1)
    un = np.linalg.norm(u, axis=1)
    perp = np.linalg.norm(np.cross(u, v), axis=1)
    scale = np.maximum.reduce([np.linalg.norm(p, axis=1), np.linalg.norm(q, axis=1), np.abs(d)])
    scale = np.maximum(scale, TINY)
    mag = d * d + un * un + TINY
    disc = np.where(d >= 0.0, (d - perp) * (d + perp), -np.inf)
    single = disc <= TANGENT_TOL * mag
    root = np.sqrt(np.maximum(disc, 0.0))
    t1 = -(s + np.where(s >= 0.0, root, -root))
    t1s = np.where(single | (t1 == 0.0), 1.0, t1)
    t2 = (un - d) * (un + d) / t1s
    T = np.sort(np.stack([t1, t2], axis=1), axis=1)
    T = np.where(single[:, None], np.stack([-s, np.zeros_like(s)], axis=1), T)
    valid = np.stack([np.ones_like(single), ~single], axis=1)
    xs = u[:, None] + v[:, None] * T[..., None]
    ls = np.abs(np.linalg.norm(xs, axis=2) - d[:, None]) > EXACT_TOL * scale[:, None]
    return pack("S3-T", T, valid, ls, np.zeros(len(d), dtype=bool))


@register("S3-T", 2, batch=_batch)
def solve_s3_t(twists, p, q, d) -> list[Solution]:
    """Registered scalar path of S3-T: checks the inputs and calls :func:`distance_slide`."""
    need("S3-T", p=p, q=q, d=d)
    return distance_slide(twists[0], point("S3-T", "p", p), point("S3-T", "q", q), number("S3-T", "d", d))
