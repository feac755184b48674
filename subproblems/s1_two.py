"""S1-RR, S1-RT, S1-TR, S1-TT: two joints carry the base frame onto a target frame.

Equation: ``exp(xi_1 th_1) exp(xi_2 th_2) = T`` (``T`` 4x4 rigid).  Six equations, two unknowns.

Geometry and method (orientation first, then translation, then the whole equation is checked):

* **S1-RR**: the rotation gives both angles (``O-RR``: ``th_1`` turns ``w_2`` onto ``R w_2`` about ``w_1``).
  Parallel axes: only ``th_1 + s th_2`` follows from the rotation; the translation then places the
  composite rotation's axis: a point on axis 2 must go to ``T`` times it under joint 1 (Paden-Kahan 1).
  Coincident axes: a continuum, ``th_1 = 0``.
* **S1-RT / S1-TR**: the rotation gives the angle (``O-R``), the translation the prismatic value by
  linear least squares.  (``RT`` and ``TR`` are each other's inverse equations,
  ``exp(-xi_2 th_2) exp(-xi_1 th_1) = T^-1``; the common method handles both orders directly.)
* **S1-TT**: the rotation must be the identity; the values solve ``v_1 th_1 + v_2 th_2 = p`` by least
  squares.  Parallel directions: a continuum, minimum-norm values.

Max solutions: 1 for each type.

Degenerate cases and what is returned: unreachable targets (the rest of the equation fails) give the
sequential answer (angles from the rotation, prismatic values by least squares) flagged ``ls``, with
its ``residual``; continua as above, flagged ``continuum`` (and ``ls`` if also unreachable).

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import prismatic_twist, revolute_twist, twist_exp
>>> tw = [revolute_twist([0, 0, 1], [1, 0, 0]), prismatic_twist([1, 0, 0])]
>>> T = twist_exp(tw[0], 0.3) @ twist_exp(tw[1], 2.0)
>>> np.round(solve("S1-RT", tw, T=T).q, 12)
array([[0.3, 2. ]])
"""

from __future__ import annotations

from subproblems._class1 import batch_class1, solve_class1
from subproblems.core import register


def _make(code: str):
    def scalar(twists, T):
        return solve_class1(code, twists, T)

    scalar.__name__ = scalar.__qualname__ = f"solve_{code.replace('-', '_').lower()}"
    scalar.__doc__ = f"Every solution of the class I equation ``{code}`` (module docstring)."
    return register(code, 1, batch=lambda tw, T: batch_class1(code, tw, T))(scalar)


solve_s1_rr = _make("S1-RR")
solve_s1_rt = _make("S1-RT")
solve_s1_tr = _make("S1-TR")
solve_s1_tt = _make("S1-TT")
