"""Completeness on the zoo's 6-joint arms at scale, and self-motions next to joint limits.

The quality bar of the compiler: on random poses (a quarter of the joint values at 0, +-pi/2, pi) the
sampled joint vector is among the returned solutions, except at a self-motion, where one exact
representative inside the limits comes back flagged ``continuum`` (a continuum cannot be listed).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ikcompiler import compile_robot, load_robot
from ikcompiler.verify import verify


# rhino was a strict xfail (3 of 2000 poses: representatives of a self-motion at 9e-11..6e-10 of the
# size after the damped Newton steps at the rank-deficient Jacobian); the undamped final steps bring
# them to the precision (runtime.Robot.singular_newton; docs/design.md section 10)
@pytest.mark.parametrize("name", ["puma560", "ur5", "prob", "rhino"])
def test_no_pose_missed_on_two_thousand_samples(name):
    chain = load_robot(name)
    module = compile_robot(chain)
    report = verify(chain, module, samples=2000, seed=0, scalar_checks=20)
    assert report.wrong == 0, report.text()
    assert report.missed == 0, report.text()
    assert report.self_motion_unsolved == 0, report.text()
    assert report.batch_mismatch == 0, report.text()


@pytest.mark.parametrize("native", [True, False])
def test_self_motion_representative_is_brought_inside_the_limits(native):
    # The Rhino with its parallel axes lined up (q2 = q3 = pi) and the wrist at pi: a self-motion whose
    # first representative needs the slide at ~308 mm, outside its +-300 mm limits.  A representative
    # inside the limits must come back (the C finish, or the reference runtime, moves along the family).
    chain = load_robot("rhino")
    module = compile_robot(chain)
    module.NATIVE = native
    q_sampled = np.array([108.36269, math.pi, math.pi, -math.pi / 2, math.pi, 1.12015])
    T = module.fk(q_sampled)
    q, residual, ls, continuum = module.solve_info(T, limits=False)[:4]
    assert continuum.any() and (np.abs(q[continuum][:, 0]) > 300.0).all() or len(q), "no representative"
    q, residual, ls, continuum = module.solve_info(T)[:4]
    exact = q[~ls]
    assert len(exact), (q, residual)
    assert continuum[~ls].any()
    assert ((exact >= module.LOWER - 1e-7) & (exact <= module.UPPER + 1e-7)).all()
    for row in exact:
        assert np.abs(module.fk(row) - T).max() <= module.TOLERANCE * module.SCALE
