"""S2-R: rotate a point onto a point (Paden-Kahan subproblem 1).

Equation: ``exp(xi th) p = q`` with ``xi`` revolute (axis ``w`` through ``r``).

Geometry: ``p`` turns on a circle about the axis; ``q`` must lie on that circle.  With ``u, v`` the
components of ``p - r`` and ``q - r`` perpendicular to ``w``, ``th = atan2(w . (u x v), u . v)``.

Max solutions: 1.

Three equations, one unknown: the angle comes from the perpendicular components; the axial
components (``w.p = w.q``) and the radii (``|u| = |v|``) are the rest of the equation.

Degenerate cases and what is returned:

* radii or axial coordinates differ (q not on p's circle): the angle that brings ``p`` closest to
  ``q``, flagged ``ls``;
* ``p`` on the axis: every angle does the same; ``th = 0``, flagged ``continuum`` (and ``ls`` unless
  ``q = p``);
* ``q`` on the axis but ``p`` not: unreachable; ``th`` is ``atan2(0, 0) = 0``, flagged ``ls``.

>>> from subproblems import solve
>>> from subproblems.screw import revolute_twist
>>> r = solve("S2-R", [revolute_twist([0, 0, 1], [1, 0, 0])], p=[2, 0, 5], q=[1, 1, 5])
>>> round(float(r.q[0, 0]), 12), bool(r.ls[0])
(1.570796326795, False)
"""

from __future__ import annotations

import numpy as np

from subproblems._class2 import (
    EXACT_TOL,
    problem_scale,
    problem_scale_batch,
    residual,
    rotation_angle,
    rotation_angle_batch,
)
from subproblems.core import BatchResult, Solution, register
from subproblems.screw import twist_exp_batch


def _batch(tw, p, q) -> BatchResult:
    scale = problem_scale_batch(tw, p, q)
    th, free = rotation_angle_batch(tw[:, 0], p, q, scale)
    g = twist_exp_batch(tw[:, 0], th)
    x = np.einsum("nij,nj->ni", g[:, :3, :3], p) + g[:, :3, 3]
    ls = np.linalg.norm(x - q, axis=-1) > EXACT_TOL * scale
    n = len(th)
    return BatchResult("S2-R", th.reshape(n, 1, 1), np.ones((n, 1), bool), ls[:, None], free)


@register("S2-R", 1, batch=_batch)
def solve_s2_r(twists, p, q) -> list[Solution]:
    """Every solution of ``exp(xi th) p = q`` (see the module docstring)."""
    scale = problem_scale(twists, p, q)
    th, free = rotation_angle(twists[0], p, q, scale)
    ls = residual(twists, p, q, [th]) > EXACT_TOL * scale
    return [Solution((th,), ls=ls, continuum=free)]
