"""Class I with three joints: S1-RRR, S1-RRT, S1-TRR, S1-RTR, S1-TTR, S1-RTT, S1-TRT, S1-TTT.

Equation: ``exp(xi_1 th_1) exp(xi_2 th_2) exp(xi_3 th_3) = T`` (``T`` 4x4 rigid).  Six equations,
three unknowns: a sufficient subset is solved and the rest is checked (``residual``; ``ls`` when it
does not hold to 1e-9 of the problem scale).

Method (seed 003 section 2, docs/design.md section 3, rule 2): the revolute joints' angles come from
the rotation alone (``O-R``/``O-RR``/``O-RRR``), the prismatic values from the translation by linear
least squares; where the rotation leaves a one-parameter family (two revolute axes parallel in space),
the translation selects it: a trigonometric polynomial of degree <= 2 in the family parameter, whose
roots are the candidates.  Every candidate is checked against the whole equation.

Per type, maximum number of solutions and degenerate cases:

* **S1-RRR** (max 2).  Three axes through one point: the two Euler-type solutions of ``O-RRR`` both
  hold (2 solutions).  Skew axes in general position: **1 solution** for a target built by forward
  kinematics.  Derivation: every solution must solve the orientation part ``O-RRR``, which has exactly
  two solutions ``a`` and ``b`` for a generic ``R``.  With ``r_i`` any point on axis ``i`` and
  ``R_1 = exp([w_1] t_1)``, ``R_12 = R_1 exp([w_2] t_2)``, the translation of the product is
  ``p(t) = r_1 + R_1 (r_2 - r_1) + R_12 (r_3 - r_2) - R r_3``, so the two sheets differ by
  ``p(a) - p(b) = (R_1^a - R_1^b)(r_2 - r_1) + (R_12^a - R_12^b)(r_3 - r_2)``.  Concurrent axes
  (``r_1 = r_2 = r_3``) make it vanish identically: both sheets hold.  Otherwise it is a non-zero
  analytic function of ``a`` and it vanishes only on a set of measure zero (3 equations on the
  3-torus of ``a``): ``T = g(a)`` is then missed by sheet ``b``, and exactly one solution exists.
  (Measured: 2000 random skew instances, the second sheet misses the target by at least 7e-4.)  The
  "two solutions" of the general-position count are the two of ``O-RRR`` (or of concurrent axes).
  ``w_1 || w_2`` or ``w_2 || w_3``: only the pair's signed sum follows from the rotation,
  the translation fixes the split (Paden-Kahan 1); coincident pair: continuum, first of the pair = 0.
  Gimbal lock (axes 1 and 3 line up in space, ``R w_3 = +-w_1``): the same, ``th_1 = 0`` when the lined-up
  axes coincide.  Three parallel axes: planar 3R, two solutions (elbow up/down) from the two-link
  problem of a point on axis 3, then ``th_3`` from the angle sum; coincident axes give continua
  (``th_1 = 0`` or ``th_2 = 0``).
* **S1-RRT / S1-TRR** (max 2).  ``O-RR`` gives both angles unless the axes are parallel; then the
  family parameter and the prismatic value solve "rotate a point onto a line" (up to 2 solutions:
  the travel direction perpendicular to the axes gives a quadratic).  Coincident axes with the travel
  along them: continuum, ``th = 0`` for the first revolute joint.
* **S1-RTR** (max 2).  As above with the prismatic joint between the revolute ones (``w_1 || w_3``).
* **S1-TTR, S1-RTT, S1-TRT** (max 1).  ``O-R`` gives the angle, the two prismatic values solve a 3x2
  linear least-squares problem; dependent directions: continuum, minimum-norm values.
* **S1-TTT** (max 1).  The rotation must be the identity; ``[v_1 v_2 v_3] th = p``: one solution when the
  directions are independent; dependent: continuum (minimum-norm values), ``ls`` if ``p`` is outside
  their span.

Unreachable targets: the best candidate, flagged ``ls``.  Never NaN; degenerate input never raises.

>>> import numpy as np
>>> from subproblems import solve
>>> from subproblems.screw import revolute_twist, twist_exp
>>> tw = [revolute_twist([0, 0, 1], [0, 0, 0]), revolute_twist([0, 1, 0], [0, 0, 0]),
...       revolute_twist([0, 0, 1], [0, 0, 0])]
>>> T = twist_exp(tw[0], 0.3) @ twist_exp(tw[1], 0.4) @ twist_exp(tw[2], 0.5)
>>> r = solve("S1-RRR", tw, T=T)
>>> len(r.q), bool(r.ls.any()), r.continuum
(2, False, False)
"""

from __future__ import annotations

from subproblems._class1 import batch_class1, solve_class1
from subproblems.core import register

#: Maximum number of solutions per code (the slots of the vectorised path).
MAX_SOLUTIONS = {
    "S1-RRR": 2,
    "S1-RRT": 2,
    "S1-TRR": 2,
    "S1-RTR": 2,
    "S1-TTR": 1,
    "S1-RTT": 1,
    "S1-TRT": 1,
    "S1-TTT": 1,
}


def _make(code: str):
    def scalar(twists, T):
        return solve_class1(code, twists, T)

    scalar.__name__ = scalar.__qualname__ = f"solve_{code.replace('-', '_').lower()}"
    scalar.__doc__ = f"Every solution of the class I equation ``{code}`` (module docstring)."
    return register(code, MAX_SOLUTIONS[code], batch=lambda tw, T: batch_class1(code, tw, T))(scalar)


solve_s1_rrr = _make("S1-RRR")
solve_s1_rrt = _make("S1-RRT")
solve_s1_trr = _make("S1-TRR")
solve_s1_rtr = _make("S1-RTR")
solve_s1_ttr = _make("S1-TTR")
solve_s1_rtt = _make("S1-RTT")
solve_s1_trt = _make("S1-TRT")
solve_s1_ttt = _make("S1-TTT")
