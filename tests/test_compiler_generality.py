"""Generality: robots the zoo does not have.  Inverted zoo chains (a wrist at the base), and random
arms built from DH-like rows with special angles, must compile, and return no wrong solution."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ikcompiler import compiler as compiler_mod
from ikcompiler import load_robot
from ikcompiler.compiler import compile_robot
from ikcompiler.configs import generic_rank
from ikcompiler.errors import RedundantChainError
from ikcompiler.model import Chain, Joint
from ikcompiler.verify import verify
from subproblems.screw import prismatic_twist, revolute_twist


@pytest.mark.parametrize("name", ["puma560", "rhino", "stanford", "kr6_r700"])
def test_inverted_zoo_chain_compiles_and_verifies(name):
    chain = load_robot(name).inverted()
    module = compile_robot(chain)
    report = verify(chain, module, samples=60, seed=2, scalar_checks=5)
    assert report.wrong == report.imprecise == report.outside_limits == 0, report.text()
    assert report.non_canonical == 0, report.text()
    if module.METHOD == "closed-form":
        assert report.ok and report.missed == 0, report.text()


def _dh_chain(rows, kinds) -> Chain:
    """A chain from standard DH rows (a, alpha, d) with the joint along each frame's z axis."""
    g = np.eye(4)
    joints = []
    for i, ((a, alpha, d), k) in enumerate(zip(rows, kinds)):
        z, o = g[:3, 2], g[:3, 3]
        tw = revolute_twist(z, o) if k == "R" else prismatic_twist(z)
        lo, hi = (-math.pi, math.pi) if k == "R" else (-0.5, 0.5)
        joints.append(Joint(f"j{i + 1}", k, tw, lo, hi))
        ca, sa = math.cos(alpha), math.sin(alpha)
        step = np.array([[1, 0, 0, a], [0, ca, -sa, 0], [0, sa, ca, d], [0, 0, 0, 1.0]])
        g = g @ step
    return Chain("random-dh", tuple(joints), g)


_len = st.sampled_from([0.0, 0.0, 0.1, 0.25, 0.4])
_alpha = st.sampled_from([0.0, math.pi / 2, -math.pi / 2, math.pi / 3])


@settings(max_examples=12, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(
    st.lists(st.tuples(_len, _alpha, _len), min_size=6, max_size=6),
    st.sampled_from(["RRRRRR", "RRRRRR", "TRRRRR", "RRTRRR", "RRRTRR"]),
)
def test_random_six_joint_arm_never_returns_a_wrong_solution(rows, kinds):
    chain = _dh_chain(rows, kinds)
    try:
        module = compile_robot(chain)
    except RedundantChainError as refused:  # coaxial / parallel axes with no closed form: the refusal
        # names the dependent joints (docs/design.md section 5, "Rank-deficient chains"); free, they solve
        assert generic_rank(chain) == chain.dof - len(refused.dependent), str(refused)
        module = compile_robot(chain, free=refused.dependent)
    report = verify(chain, module, samples=15, seed=3, scalar_checks=2)
    assert report.wrong == report.imprecise == report.outside_limits == 0, report.text()
    assert report.non_canonical == 0, report.text()
    assert report.batch_mismatch == 0, report.text()
    if module.METHOD == "closed-form":
        assert report.ok and report.missed == 0, report.text()


def _calibrated(chain: Chain, eps: float, seed: int = 0) -> Chain:
    """The chain with every axis tilted and shifted by about ``eps`` (of radians / of the robot size)."""
    rng = np.random.default_rng(seed)
    joints = []
    for j in chain.joints:
        w = j.axis + eps * rng.normal(size=3)
        tw = revolute_twist(w, j.point + eps * chain.scale * rng.normal(size=3)) if j.kind == "R" else None
        joints.append(Joint(j.name, j.kind, tw if tw is not None else prismatic_twist(w), j.lower, j.upper))
    return Chain(chain.name + " (calibrated)", tuple(joints), chain.home, chain.couplings)


@pytest.mark.parametrize("name", ["puma560", "ur5", "kr6_r700"])
def test_calibrated_robot_snapped_closed_form_stays_exact(name, monkeypatch):
    # the snapped path itself, kept at 1e-4 by lifting the policy's limit (tolerances.SNAP_GENERAL)
    monkeypatch.setattr(compiler_mod, "SNAP_GENERAL", math.inf)
    _compiled_exact_and_complete(_calibrated(load_robot(name), 1e-4), "closed-form", "snapped")


def _compiled_exact_and_complete(chain, method: str, note: str) -> None:
    """Compiled to ``method`` with ``note`` in its plan: no wrong row, no missed pose on 60 samples."""
    module = compile_robot(chain)
    assert module.METHOD == method and note in module.PLAN, module.PLAN
    report = verify(chain, module, samples=60, seed=4, scalar_checks=3)
    assert report.wrong == 0 and report.missed == 0, report.text()


@pytest.mark.parametrize("name", ["puma560", "ur5", "kr6_r700"])
def test_calibrated_robot_beyond_snap_general_is_a_general_robot(name):
    # moved by more than SNAP_GENERAL (1e-5) from its design: the elimination (docs/calibrated.md,
    # "Policy"); nearer, the snapped closed form
    near = compile_robot(_calibrated(load_robot(name), 1e-7))
    assert near.METHOD == "closed-form" and "snapped" in near.PLAN
    _compiled_exact_and_complete(_calibrated(load_robot(name), 1e-4), "general-6r", "SNAP_GENERAL")


# A hypothesis-drawn arm (misc18, --hypothesis-seed=1 with 300 examples and scalar_checks=15) whose
# single-pose and batch rows differ at a fold of its wrist: j3, j5, j6 meet at a point, j3 and j6 can
# never align (60 and 90 degree twists), and at j5 = 0 (or pi) the O-RRR's t2 equation is tangent.  The
# kernels split the double root by roundoff into two exact copies ~3e-8 either side of it (TANGENT_ROOT);
# the finish merges copies within SPLIT_ROOT and keeps the one of smaller error, which the scalar and
# the array kernels order differently by ulps (at the second pose the scalar kernel even gives the
# centre twice): the rows differ by the split, 3e-8..6e-8 rad, above verify's 1e-9 comparison.  Both
# are exact; the fix would merge two copies into their midpoint (docs/design.md section 10, open).
_FOLD_ARM = ([(0.0, -math.pi / 2, 0.0), (0.4, 0.0, 0.0), (0.0, 0.0, 0.1), (0.0, math.pi / 3, 0.1),
              (0.0, -math.pi / 2, 0.0), (0.0, 0.0, 0.0)], "TRRRRR")


@pytest.mark.xfail(strict=True, reason="split copies of a tangent root: single and batch keep different "
                   "copies (open; see the comment above)")
def test_single_and_batch_rows_agree_at_a_wrist_fold():
    chain = _dh_chain(*_FOLD_ARM)
    try:
        module = compile_robot(chain)
    except RedundantChainError as refused:  # j3 and j4 coincide: j4 free, as the property test does
        module = compile_robot(chain, free=refused.dependent)
    from ikcompiler.verify import sample_configurations

    Q = sample_configurations(chain, 15, 3, 0.25, (module.LOWER, module.UPPER))[[2, 12]]
    free = [chain.independent_names.index(f) for f in module.FREE_JOINTS]
    G = chain.fk_batch(Q)
    S, filled, ls, _, _ = module.solve_batch_info(G, *[Q[:, p] for p in free])
    for n, q in enumerate(Q):
        assert q[4] in (0.0, math.pi)
        single = module.solve(G[n], *q[free])  # the same target, as verify compares them
        batch = S[n][filled[n] & ~ls[n]]
        assert len(single) == len(batch)
        for row in single:
            assert np.abs(batch - row).max(axis=1).min() <= 1e-9, (q, single, batch)
