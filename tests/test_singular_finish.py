"""Newton steps at a singular configuration (docs/design.md section 10, "Newton at a singular
configuration"): a row the damped steps leave just above the precision is brought to it by undamped
pseudo-inverse steps, in the reference runtime, the Python fast path and the C finish (which hands such
a row back).

The robot is pybullet's ``xarm6_robot.urdf`` (base world, tip link6) as ``dump_spec`` writes it (the
twists agree with the URDF's to 2.2e-16), so the test needs no robot package.  Its q5 limit is
3.14159265359 = pi + 2.1e-13; at q = (0, -pi/2, -pi/2, pi, pi, pi/2) the pose lies on a self-motion
(q1, q4 and q6 move together, q5 = pi + c s^2 along it) and the search's representative lies 2.1e-11
past that limit: clamped onto it, three damped steps (1e-12 on unit columns) halve its error each and
stop at 2.3e-12 of the size, so the sampled joint vector came back only as a least-squares row
(benchmarks/results/real_robots.md: 229/230).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ikcompiler import configs
from ikcompiler.inputs.spec import load_spec_text
from ikcompiler.runtime import reference
from ikcompiler.verify import joint_distance
from subproblems import newton
from subproblems.plan_runtime import fk_batch, pose_error

PRECISION = 1e-12
XARM6 = """
name = "xarm6"
units = "m"
angles = "rad"
joints = "RRRRRR"
base = "world"
tip = "link6"

[[joint]]
name = "joint1"
axis = [0.0, 0.0, 1.0]
point = [0.0, 0.0, 0.0]
lower = -6.28318530718
upper = 6.28318530718

[[joint]]
name = "joint2"
axis = [0.0, 0.9999999999932537, -3.673205103346574e-06]
point = [0.0, 9.807457625869188e-07, 0.26699999999639745]
lower = -2.059
upper = 2.0944

[[joint]]
name = "joint3"
axis = [0.0, 0.9999999999932537, -3.673205103346574e-06]
point = [0.05349999999999999, 2.0257726144890194e-06, 0.5514999999944782]
lower = -3.927
upper = 0.19198

[[joint]]
name = "joint4"
axis = [0.0, -7.346410206643587e-06, -0.999999999973015]
point = [0.13099999999999998, -1.7484456291325552e-06, 1.284479881596739e-11]
lower = -6.28318530718
upper = 6.28318530718

[[joint]]
name = "joint5"
axis = [0.0, 0.9999999999932536, -3.673205103346574e-06]
point = [0.13099999999999998, 7.676998665928176e-07, 0.20899999999678878]
lower = -1.69297
upper = 3.14159265359

[[joint]]
name = "joint6"
axis = [0.0, -7.346410206643586e-06, -0.9999999999730149]
point = [0.2069999999999999, -1.3921447341175521e-06, 1.0227266284122291e-11]
lower = -6.28318530718
upper = 6.28318530718

[home]
matrix = [
    [1.0, 0.0, 0.0, 0.20700000000000002],
    [0.0, -0.9999999999730149, -7.346410206643586e-06, -5.693467910187193e-07],
    [0.0, 7.346410206643586e-06, -0.9999999999730149, 0.11200000000104571],
    [0.0, 0.0, 0.0, 1.0],
]
"""
SINGULAR_Q = np.array([0.0, -math.pi / 2, -math.pi / 2, math.pi, math.pi, math.pi / 2])


@pytest.fixture(scope="module")
def xarm6():
    chain = load_spec_text(XARM6, "xarm6 (pybullet_data/xarm/xarm6_robot.urdf, dump_spec)")
    return chain, configs.compile_chain(chain).module


def _errors(chain, rows, T):
    """Pose errors of rows (M, 6) against T on the chain's own forward kinematics, over the size."""
    G = np.array([chain.fk(q) for q in rows])
    return pose_error(G, T[None], chain.scale) / chain.scale


@pytest.mark.parametrize("path", ["native", "python", "reference"])
def test_xarm6_singular_pose_at_its_limit_is_recovered(xarm6, path):
    """The sampled joint vector is among the exact rows on every path, each row exact."""
    chain, module = xarm6
    assert chain.upper[4] > math.pi  # the limit rounded up: the sampled q5 = pi is inside it
    switches = {"native": (True, True), "python": (True, False), "reference": (False, False)}[path]
    saved = module.FAST_PATH, module.NATIVE
    module.FAST_PATH, module.NATIVE = switches
    try:
        T = chain.fk(SINGULAR_Q)
        rows = np.asarray(module.solve(T))
        info = module.solve_info(T)
    finally:
        module.FAST_PATH, module.NATIVE = saved
    assert len(rows)
    assert (_errors(chain, rows, T) <= PRECISION).all()
    assert (rows[:, 4] <= chain.upper[4]).all()
    assert joint_distance(rows, SINGULAR_Q[None], chain.joint_types, chain.scale).min() <= 1e-6
    # no least-squares row near the sampled vector is left behind (it used to be one at 2.3e-12)
    near_ls = info.ls & (joint_distance(info.q, SINGULAR_Q[None], chain.joint_types, chain.scale) <= 1e-4)
    assert not near_ls.any(), info.residual[near_ls]


def test_clamped_row_at_a_singular_configuration_is_brought_to_the_precision(xarm6):
    """An exact row of the self-motion just past the q5 limit: clamped onto it, the damped steps alone
    stall above the precision (the measured defect); clamped_onto_limits brings it to the precision
    with q5 held on the limit."""
    chain, module = xarm6
    robot = module._SOLVER.robot
    T = chain.fk(SINGULAR_Q)[None]
    _, J = newton.tool_jacobian(robot.twists, SINGULAR_Q[None], robot.home, robot.A)
    family = np.linalg.svd(J[0])[2][-1]  # the self-motion's direction (q1, q4, q6)
    assert np.abs(family[[0, 3, 5]]).min() > 0.1 and np.abs(family[[1, 2, 4]]).max() < 1e-3
    start = robot.newton((SINGULAR_Q - 1e-6 * family / family[0])[None], T, 4)
    assert _errors(chain, start, T[0])[0] <= PRECISION  # on the family ...
    assert start[0, 4] - chain.upper[4] > 1e-12  # ... past the limit, within the clamp's reach
    assert start[0, 4] - chain.upper[4] < 1e-7
    clamped = start.copy()
    clamped[0, 4] = chain.upper[4]
    damped = robot.newton(clamped, T, reference.CLAMPED_NEWTON, hold=(4,))
    assert _errors(chain, damped, T[0])[0] > PRECISION  # what the damped steps alone leave
    done, moved = reference.clamped_onto_limits(robot, start, np.zeros(1, dtype=int), T)
    assert moved and done[0, 4] == chain.upper[4]
    assert _errors(chain, done, T[0])[0] <= PRECISION


def test_pseudo_inverse_step_keeps_held_columns():
    """A held column (clamped onto a limit) gets exactly no undamped step, and the other columns the
    step of the chain without it (the SVD of a zero column leaves ~1e-15 in its entries of V, which the
    TINY column floor turned into ~1e285)."""
    rng = np.random.default_rng(4)
    J = rng.normal(size=(30, 6, 6))
    e = rng.normal(size=(30, 6)) * 1e-9
    dq = newton.gauss_newton_step(J, e, hold=(2,), cutoff=1e-13)
    assert np.isfinite(dq).all()
    assert (dq[:, 2] == 0.0).all()
    free = newton.gauss_newton_step(np.delete(J, 2, axis=2), e, cutoff=1e-13)
    np.testing.assert_allclose(np.delete(dq, 2, axis=1), free, rtol=1e-9, atol=1e-20)


def test_singular_newton_keeps_rows_it_cannot_bring_to_the_precision(xarm6):
    """A row far from every solution is returned as given (nothing is lost by the undamped steps)."""
    chain, module = xarm6
    robot = module._SOLVER.robot
    T = chain.fk(SINGULAR_Q)[None]
    far = (SINGULAR_Q + 0.5)[None]
    out = robot.singular_newton(far, T, iters=1)
    np.testing.assert_array_equal(out, far)
    G = fk_batch(robot.twists, out, robot.home)
    assert pose_error(G, T, chain.scale)[0] > 1e-3 * chain.scale
