"""S2-T: translate a point onto a point.

Equation: ``exp(xi t) p = q`` with ``xi`` prismatic along unit ``v``: ``p + t v = q``.

Geometry: ``q`` must lie on the line through ``p`` along ``v``; ``t = v . (q - p)``.

Max solutions: 1.

Three equations, one unknown: ``t`` comes from the component along ``v``; the two perpendicular
components are the rest.  When ``q`` is off the line, ``t`` is still the least-squares answer (the
foot of the perpendicular), flagged ``ls``.  No continuum is possible (``v`` is a unit vector).

>>> from subproblems import solve
>>> r = solve("S2-T", [[0, 0, 1, 0, 0, 0]], p=[1, 2, 3], q=[1, 2, 7.5])
>>> float(r.q[0, 0]), bool(r.ls[0])
(4.5, False)
"""

from __future__ import annotations

import numpy as np

from subproblems._class2 import EXACT_TOL, problem_scale, problem_scale_batch
from subproblems.core import BatchResult, Solution, register


def _batch(tw, p, q) -> BatchResult:
    v = tw[:, 0, :3]
    d = q - p
    t = np.sum(v * d, axis=-1)
    ls = np.linalg.norm(d - v * t[:, None], axis=-1) > EXACT_TOL * problem_scale_batch(tw, p, q)
    n = len(t)
    return BatchResult("S2-T", t.reshape(n, 1, 1), np.ones((n, 1), bool), ls[:, None], np.zeros(n, bool))


@register("S2-T", 1, batch=_batch)
def solve_s2_t(twists, p, q) -> list[Solution]:
    """Every solution of ``p + t v = q`` (see the module docstring)."""
    v = twists[0][:3]
    d = q - p
    t = float(v @ d)
    ls = float(np.linalg.norm(d - t * v)) > EXACT_TOL * problem_scale(twists, p, q)
    return [Solution((t,), ls=ls)]
