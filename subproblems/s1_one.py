"""S1-R and S1-T: one joint carries the base frame onto a target frame.

Equation: ``exp(xi_1 th_1) = T`` with ``T`` a 4x4 rigid transform.

* **S1-R** (``xi_1`` revolute, axis ``w`` through ``r``): ``T`` must be a rotation about that axis.  The
  angle comes from the rotation (``O-R``: ``th = atan2(w . vee(R - R^T), tr R - w^T R w)``); the
  translation ``(I - R) r`` is then checked.
* **S1-T** (``xi_1`` prismatic along ``v``): ``T`` must be a pure translation along ``v``; ``th = v . p``
  (linear least squares), the rotation and the rest of the translation are checked.

Max solutions: 1.  Six equations, one unknown: the rest of the equation is reported as the residual;
``ls`` when it does not hold to 1e-9 of the problem scale (``max(1, |p_T|, axis distance)``).

Degenerate cases: S1-R with ``R`` a half-turn about an axis perpendicular to ``w`` (every angle is
equally far): ``th = 0``, flagged ``ls`` and ``continuum``.  S1-T has none.

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import revolute_twist, twist_exp
>>> xi = revolute_twist([0, 0, 1], [1, 0, 0])
>>> r = solve("S1-R", [xi], T=twist_exp(xi, 0.5))
>>> round(float(r.q[0, 0]), 12), bool(r.ls[0])
(0.5, False)
"""

from __future__ import annotations

from subproblems._class1 import batch_class1, solve_class1
from subproblems.core import register


@register("S1-R", 1, batch=lambda tw, T: batch_class1("S1-R", tw, T))
def solve_s1_r(twists, T):
    """Every solution of ``exp(xi th) = T``, ``xi`` revolute (module docstring)."""
    return solve_class1("S1-R", twists, T)


@register("S1-T", 1, batch=lambda tw, T: batch_class1("S1-T", tw, T))
def solve_s1_t(twists, T):
    """Every solution of ``exp(xi th) = T``, ``xi`` prismatic (module docstring)."""
    return solve_class1("S1-T", twists, T)
