"""Chains of one or two joints with a pose target: the legs, fingers, wheels and gripper slides of the
robot-description packages (docs/design.md section 5, "2-joint chains with a pose target").

Such a chain used to be one S1-RR / S1-TR / S1-T step, which has no fast kernel: every pose ran the
reference class I solver (1.3-40 ms a solve on the quadruped legs).  The planner now takes a point step
and an orientation step (kernels, C) and a single slide the ``slide1`` kernel.  Checked here on chains
built from their axes (no robot packages needed): the plan's step codes, the native backend, and
``verify`` (round trip by forward kinematics, the sampled joint vector among the rows, limits) on
random and special-angle poses, including a pair whose axes miss parallel by a CAD rounding.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ikcompiler import compile_robot
from ikcompiler.model import Chain, Joint
from ikcompiler.verify import verify
from subproblems import native
from subproblems.screw import prismatic_twist, revolute_twist


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _home(x, y, z):
    home = np.eye(4)
    home[:3, 3] = (x, y, z)
    return home


def _chain(name, joints, home):
    return Chain(name, tuple(joints), home)


# name -> (chain, the plan's step codes)
CASES = {
    # a planar leg: hip and knee parallel (the double pendulum, solo's legs)
    "parallel-RR": (
        _chain("leg", [Joint("hip", "R", revolute_twist([1, 0, 0], [0, 0.035, 0])),
                       Joint("knee", "R", revolute_twist([1, 0, 0], [0, 0.135, 0]))],
               _home(0.03, 0.0, 0.135)),
        ["S2-R", "O-R"],
    ),
    # the same with the knee axis off parallel by 4.6e-5 rad (pybullet's quadruped as shipped)
    "cad-rounded-RR": (
        _chain("leg-cad", [Joint("hip", "R", revolute_twist(_unit([0, -1, 4.63267949e-5]), [0.0, 0.21, 0.0])),
                           Joint("knee", "R", revolute_twist([0, 1, 0], [-0.21, 0.0, -0.115]))],
               _home(-0.21, -0.08, 0.115)),
        ["S2-R", "O-R"],
    ),
    # a wheel on a suspension slide (tiago_dual), the cart-pole
    "slide-turn": (
        _chain("wheel", [Joint("suspension", "T", prismatic_twist([0, 0, 1]), -0.02, 0.02),
                         Joint("wheel", "R", revolute_twist([0, 1, 0], [0.1, 0.2, 0.05]))],
               _home(0.1, 0.25, 0.05)),
        ["S2-T", "O-R"],
    ),
    # a gripper finger
    "slide": (
        _chain("finger", [Joint("finger", "T", prismatic_twist(_unit([0, 1, 0.2])), 0.0, 0.04)],
               _home(0.0, 0.01, 0.06)),
        ["S1-T"],
    ),
}


def _step_codes(module):
    """The best chain's step codes, read from the printed plan (the alternative chain left out)."""
    text = module.PLAN.split("alternative chain")[0]
    return [line.split(":", 1)[1].split(" in ")[0].strip()
            for line in text.splitlines() if line.strip().startswith("step ")]


@pytest.mark.parametrize("case", sorted(CASES))
def test_two_joint_pose_chains_take_kernel_steps_and_lose_nothing(case):
    chain, codes = CASES[case]
    module = compile_robot(chain)
    assert _step_codes(module) == codes, module.PLAN
    if native.compiler() is not None:
        assert module.NATIVE, "every step has a C kernel: the module must build its C chain"
    for special, seed in ((1.0, 3), (0.0, 4)):
        rep = verify(chain, module, samples=150, seed=seed, scalar_checks=5, special=special)
        assert rep.ok and rep.missed == 0 and rep.recovered + rep.self_motion == rep.poses, rep
        assert rep.max_error <= 1e-12 * module.SCALE, rep


def test_a_pose_the_pair_cannot_reach_gives_no_exact_row():
    """The rotation about the pair's common axis is all a parallel pair can do: a target tilted off that
    axis has no exact solution, so ``solve`` returns nothing (least-squares rows only in solve_info)."""
    chain, _ = CASES["parallel-RR"]
    module = compile_robot(chain)
    T = chain.fk(np.array([0.4, -1.1]))
    tilt = np.eye(4)
    c, s = math.cos(1e-3), math.sin(1e-3)
    tilt[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]  # about z, across the joints' x axes
    assert len(module.solve(T @ tilt, limits=False)) == 0
    info = module.solve_info(T @ tilt, limits=False)
    assert all(info.ls), info
