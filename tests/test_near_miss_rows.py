"""A snapped plan's class II steps keep their near-miss least-squares rows beside the exact ones
(``subproblems._class2.near_miss_rows``; docs/calibrated.md, "Rescue seeds").

Near a fold a pair of complex roots of the snapped robot's eliminant is a pair of real solutions of the
true robot.  Measured: talos_full_v2.urdf (example-robot-data), torso_2_link -> gripper_left_base_link,
perturbed by 1e-3 (``configs.perturbed``, seed 7), free arm_left_3_joint: at the sampled vector below
the snapped S2-RRR (joints 1, 2, 4 carrying the wrist centre) had 2 exact rows and a complex pair whose
projection misses by 5.2e-5 of the instance's size; the solver dropped it, the true robot has 8
solutions (the sampled one and its twin 0.033 rad away, sigma 2.7e-3), 4 came back and none inside the
limits (benchmarks/results/real_robots_unseen.md: 229/230; the right arm likewise at seed 13).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from subproblems import solve, solve_batch
from subproblems._class2 import EXACT_TOL, FAR_TOL, near_miss_rows, problem_scale, residual

# The S2-RRR instance of that pose, as the snapped plan's step 1 gave it to the solver (twists (v, w)).
TWISTS = np.array([
    [1.5729192475015477e-01, 4.0782134851416940e-04, -3.1541446435040116e-07,
     1.2304906266180467e-06, 2.9882744408422224e-04, 9.9999995535032127e-01],
    [-5.1856462841200560e-04, 2.7889300248311716e-01, -2.9422439056032851e-01,
     9.9999898090206552e-01, 1.3401332793005671e-03, -4.9217641568193059e-04],
    [1.7201735511730167e-03, -4.6111410237159233e-03, 2.6939479841028480e-01,
     -8.6249252846728153e-01, -5.0605996265468300e-01, -3.1547640255809519e-03],
])
P = np.array([0.00495615658703541, 0.29295496514670194, -0.25882969344684376])
Q = np.array([-0.08063472332415982, 0.24881917072820364, 0.5027326687063178])
SAMPLED = np.array([-0.7278679197146986, 2.6535110029401543, 2.0995088157062485, -2.1693635538641654,
                    -0.42263802263724237, 0.2842793906155652, -0.12539975904498657])


def _scalar(near: bool):
    if near:
        with near_miss_rows():
            r = solve("S2-RRR", TWISTS, p=P, q=Q)
    else:
        r = solve("S2-RRR", TWISTS, p=P, q=Q)
    return np.asarray(r.q), np.asarray(r.ls)


def _batch(near: bool):
    args = (TWISTS[None], P[None], Q[None])
    if near:
        with near_miss_rows():
            r = solve_batch("S2-RRR", args[0], p=args[1], q=args[2])
    else:
        r = solve_batch("S2-RRR", args[0], p=args[1], q=args[2])
    v = r.valid[0]
    return r.q[0][v], r.ls[0][v]


@pytest.mark.parametrize("path", [_scalar, _batch], ids=["scalar", "batch"])
def test_the_complex_pair_of_a_fold_is_kept_as_least_squares_rows(path):
    scale = problem_scale(TWISTS, P, Q)
    q0, ls0 = path(False)
    assert len(q0) == 2 and not ls0.any()  # the two real roots alone: the pair is dropped
    q1, ls1 = path(True)
    exact = q1[~ls1]
    assert len(exact) == 2
    for a in q0:  # the exact rows are unchanged
        assert min(np.abs(np.angle(np.exp(1j * (exact - a)))).max(axis=1)) <= 1e-12
    near = q1[ls1]
    assert len(near) >= 1
    res = np.array([residual(TWISTS, P, Q, th) for th in near]) / scale
    assert ((res > EXACT_TOL) & (res <= FAR_TOL)).all()
    assert res.min() < 1e-4  # the projection of a near-real pair: close to the target (5.2e-5)


def test_scalar_and_batch_keep_the_same_near_rows():
    qs, ls_s = _scalar(True)
    qb, ls_b = _batch(True)
    assert ls_s.sum() == ls_b.sum()
    for a in qs[ls_s]:
        assert min(np.abs(np.angle(np.exp(1j * (qb[ls_b] - a)))).max(axis=1)) <= 1e-9


def test_talos_perturbed_arm_recovers_the_pair_born_at_a_fold(monkeypatch):
    """The sampled vector (and its twin) come back on the true robot; needs the robots extra.  At 1e-3
    the default policy takes the elimination (tolerances.SNAP_GENERAL); the snapped path is kept here
    by lifting that limit."""
    from ikcompiler import compiler, configs, robotdb

    monkeypatch.setattr(compiler, "SNAP_GENERAL", math.inf)
    from ikcompiler.verify import joint_distance

    try:
        robotdb.require(robotdb.EXTRA)
    except robotdb.RobotPackageError as exc:
        pytest.fail(f"{exc} (tests/test_near_miss_rows.py needs the robots extra)", pytrace=False)
    cat = robotdb.discover(packages=("example-robot-data",))
    entry = [e for e in cat.chains
             if e.rel.endswith("/talos_full_v2.urdf") and e.tip == "gripper_left_base_link"][0]
    chain = configs.perturbed(entry.load(), 1e-3, seed=7)
    compiled = configs.compile_chain(chain)
    module = compiled.module
    assert module.METHOD == "closed-form" and module._POLISH  # the snapped plan (the case here)
    assert compiled.free == ("arm_left_3_joint",)
    T = chain.fk(SAMPLED)
    rows = np.asarray(module.solve(T, SAMPLED[2]))
    assert len(rows)
    G = np.array([chain.fk(r) for r in rows])
    err = np.maximum(np.linalg.norm(G[:, :3, 3] - T[:3, 3], axis=1),
                     chain.scale * np.linalg.norm(G[:, :3, :3] - T[:3, :3], axis=(1, 2)))
    assert (err <= 1e-12 * chain.scale).all()
    assert joint_distance(rows, SAMPLED[None], chain.joint_types, chain.scale).min() <= 1e-6
    everything = np.asarray(module.solve(T, SAMPLED[2], limits=False))
    assert len(everything) == 8  # the true robot's count (its general 6R elimination finds 8)


def test_tiago_perturbed_arm_recovers_a_sample_on_a_branch_the_snapped_arm_lacks():
    """tiago.urdf (example-robot-data), torso_lift_link -> hand_palm_link, perturbed by 1e-6 (seed 7),
    free arm_3_joint: at verify's seed-11 pose 35 the sampled vector lies on an arm branch born within
    the perturbation at a near-fold of the snapped S2-RRR (no real root there); only its near-miss
    least-squares rows seed the continuation onto the sample and its twin ~0.01 rad away.  Without
    them no row inside the limits came back (benchmarks/results/perturbed_7r.md: 229/230)."""
    from ikcompiler import configs, robotdb
    from ikcompiler.verify import joint_distance, sample_configurations

    try:
        robotdb.require(robotdb.EXTRA)
    except robotdb.RobotPackageError as exc:
        pytest.fail(f"{exc} (tests/test_near_miss_rows.py needs the robots extra)", pytrace=False)
    cat = robotdb.discover(packages=("example-robot-data",))
    entry = [e for e in cat.chains if e.rel.endswith("tiago_description/robots/tiago.urdf")
             and e.base == "torso_lift_link" and e.tip == "hand_palm_link"][0]
    chain = configs.perturbed(entry.load(), 1e-6, seed=7)
    compiled = configs.compile_chain(chain)
    module = compiled.module
    assert module.METHOD == "closed-form" and module._POLISH and compiled.free == ("arm_3_joint",)
    # the pose as verify samples it (real_robots.py's fourth random stage of 50 at seed 11)
    sampled = sample_configurations(chain, 50, 11, 0.0, (module.LOWER, module.UPPER))[35]
    T = chain.fk(sampled)
    rows = np.asarray(module.solve(T, sampled[2]))
    assert len(rows) >= 2
    G = np.array([chain.fk(r) for r in rows])
    err = np.maximum(np.linalg.norm(G[:, :3, 3] - T[:3, 3], axis=1),
                     chain.scale * np.linalg.norm(G[:, :3, :3] - T[:3, :3], axis=(1, 2)))
    assert (err <= 1e-12 * chain.scale).all()
    d = joint_distance(rows, sampled[None], chain.joint_types, chain.scale)
    assert d.min() <= 1e-6
    assert ((d > 1e-6) & (d < 0.05)).any()  # its twin across the fold, also a solution


@pytest.mark.parametrize("native", [True, False])
def test_puma_perturbed_arm_recovers_the_elbow_its_snapped_s2rrr_lost(native, monkeypatch):
    """puma560_robot.urdf.xacro (rtb-data) perturbed by 1e-3 (seed 8): joints 2 and 3 stay parallel
    only to ~1e-3 (not snapped), so the snapped S2-RRR's matrix M is nearly singular (sigma ratio
    2.8e-3).  At verify's seed-11 pose 16 its quartic had two real roots (one elbow) and a complex pair
    (the other, the sampled one): Cramer's point of that pair's projection gave a th3 0.9 rad off, a
    candidate missing by 1.5e-2 of the size, beyond S2_FAR, so no near row came back and 4 of the true
    robot's 8 solutions were lost, the sampled one among them.  Its least-squares th3
    (s2_rrr.least_squares_b) gives a near row, whose rescue asks the true robot's general 6R solver.
    The default policy compiles this arm as a general robot (moved by more than
    tolerances.SNAP_GENERAL); the snapped path is kept here by lifting that limit."""
    from ikcompiler import compiler

    monkeypatch.setattr(compiler, "SNAP_GENERAL", math.inf)
    from ikcompiler import configs, robotdb
    from ikcompiler.verify import joint_distance, sample_configurations

    try:
        robotdb.require(robotdb.EXTRA)
    except robotdb.RobotPackageError as exc:
        pytest.fail(f"{exc} (tests/test_near_miss_rows.py needs the robots extra)", pytrace=False)
    cat = robotdb.discover(packages=("rtb-data",))
    entry = [e for e in cat.chains
             if e.rel.endswith("puma560_robot.urdf.xacro") and e.tip == "link7"][0]
    chain = configs.perturbed(entry.load(), 1e-3, seed=8)
    module = configs.compile_chain(chain).module
    assert module.METHOD == "closed-form" and module._POLISH
    assert "S2-RRR" in module.PLAN
    module.NATIVE = native
    sampled = sample_configurations(chain, 50, 11, 0.0, (module.LOWER, module.UPPER))[16]
    T = chain.fk(sampled)
    rows = np.asarray(module.solve(T, limits=False))
    G = np.array([chain.fk(r) for r in rows])
    err = np.maximum(np.linalg.norm(G[:, :3, 3] - T[:3, 3], axis=1),
                     chain.scale * np.linalg.norm(G[:, :3, :3] - T[:3, :3], axis=(1, 2)))
    assert (err <= 1e-12 * chain.scale).all()
    assert joint_distance(rows, sampled[None], chain.joint_types, chain.scale).min() <= 1e-6
    # both elbows, both wrists: as many as the true robot's general 6R elimination finds (8)
    from subproblems import general6

    robot = module._SOLVER.robot
    assert len(rows) == len(general6.General6(robot.twists, robot.home, robot.scale).solve(T)) == 8
