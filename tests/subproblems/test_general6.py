"""The general 6R solver (subproblems.general6): completeness and precision measured by forward
kinematics computed independently of the solver (subproblems.plan_runtime.fk_batch on the given twists)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ikcompiler.configs import random_6r_geometry
from subproblems import general6 as g6
from subproblems.core import SubproblemInputError
from subproblems.plan_runtime import fk_batch

EXACT = 1e-12  # the contract: position / size and rotation (Frobenius)
SAME = 1e-6  # rad: the sampled joint vector is among the solutions


def _fk(twists, home, Q):
    return fk_batch(np.asarray(twists), np.asarray(Q, dtype=float).reshape(-1, 6), home)


def _size(twists, home):
    r = np.cross(twists[:, 3:], twists[:, :3])
    pts = np.vstack([r, home[:3, 3]])
    return float(np.max(np.linalg.norm(pts - r.mean(axis=0), axis=1)))


def _distance(rows, q):
    """Smallest joint distance (max over joints, modulo 2 pi) from q to the rows; inf for none."""
    if len(rows) == 0:
        return math.inf
    return float(np.abs(np.angle(np.exp(1j * (rows - q)))).max(axis=1).min())


def _check(twists, home, Q, batch):
    """Every sampled vector recovered; every returned row exact by independent FK."""
    T = _fk(twists, home, Q)
    size = _size(twists, home)
    for n in range(len(Q)):
        rows = batch.Q[n][batch.valid[n]]
        assert _distance(rows, Q[n]) < SAME, (n, Q[n], rows)
        G = _fk(twists, home, rows)
        dp = np.linalg.norm(G[:, :3, 3] - T[n, :3, 3], axis=1) / size
        dR = np.linalg.norm(G[:, :3, :3] - T[n, :3, :3], axis=(1, 2))
        assert dp.max() <= EXACT and dR.max() <= EXACT, (n, dp.max(), dR.max())
        assert np.all(rows > -math.pi) and np.all(rows <= math.pi)
        assert len(rows) % 2 == 0, (n, len(rows))  # complex roots pair up: a generic pose has an even count


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_arms_every_sampled_vector_recovered_and_exact(seed):
    twists, home = random_6r_geometry(seed)
    solver = g6.prepare(twists, home)
    Q = np.random.default_rng(100 + seed).uniform(-math.pi, math.pi, size=(80, 6))
    _check(twists, home, Q, solver.solve_batch(_fk(twists, home, Q)))


MANY_SEED, MANY_POSE = 35, 1  # a search over 40 arms x 400 poses: 12 real solutions (docs/general6.md)


def test_constructed_pose_with_many_real_solutions():
    twists, home = random_6r_geometry(MANY_SEED)
    solver = g6.prepare(twists, home)
    Q = np.random.default_rng(1000 + MANY_SEED).uniform(-math.pi, math.pi, size=(400, 6))
    Q = Q[MANY_POSE:MANY_POSE + 1]
    batch = solver.solve_batch(_fk(twists, home, Q))
    _check(twists, home, Q, batch)
    assert batch.valid[0].sum() >= 12, batch.valid[0].sum()
    # every one of them is a distinct joint vector that reaches the pose (checked above) and is found
    # again as the sampled vector of its own pose: the set is closed
    rows = batch.Q[0][batch.valid[0]]
    again = solver.solve_batch(_fk(twists, home, rows))
    for k, q in enumerate(rows):
        assert _distance(again.Q[k][again.valid[k]], q) < SAME


@pytest.mark.parametrize("value", ["pi", "shift-pi"])
def test_elimination_joint_at_pi_and_at_the_shifted_infinity(value):
    """th_c = pi is the half-angle's infinity; th_c = delta + pi that of the shifted variable."""
    twists, home = random_6r_geometry(3)
    solver = g6.prepare(twists, home)
    c = solver._arr[solver.arrangement].order[2]
    Q = np.random.default_rng(5).uniform(-math.pi, math.pi, size=(40, 6))
    Q[:, c] = math.pi if value == "pi" else g6._wrap(np.array([g6.SHIFTS[0] - math.pi]))[0]
    _check(twists, home, Q, solver.solve_batch(_fk(twists, home, Q)))


def test_special_angles_every_joint():
    twists, home = random_6r_geometry(4)
    solver = g6.prepare(twists, home)
    special = np.array([0.0, math.pi / 2, -math.pi / 2, math.pi])
    Q = special[np.random.default_rng(6).integers(0, 4, size=(60, 6))]
    _check(twists, home, Q, solver.solve_batch(_fk(twists, home, Q)))


def test_unreachable_pose_has_no_rows():
    twists, home = random_6r_geometry(0)
    solver = g6.prepare(twists, home)
    T = np.eye(4)
    T[:3, 3] = [20.0, 0.0, 0.0]  # far outside the workspace of a 1 m arm
    batch = solver.solve_batch(T[None])
    assert not batch.valid.any() and not batch.reachable[0]
    assert solver.solve(T).shape == (0, 6)


def test_batch_equals_scalar():
    twists, home = random_6r_geometry(1)
    solver = g6.prepare(twists, home)
    Q = np.random.default_rng(8).uniform(-math.pi, math.pi, size=(25, 6))
    T = _fk(twists, home, Q)
    batch = solver.solve_batch(T)
    for n in range(len(Q)):
        one = solver.solve(T[n])
        many = batch.Q[n][batch.valid[n]]
        assert len(one) == len(many)
        for q in one:
            assert _distance(many, q) < 1e-9


@pytest.mark.parametrize("name", ["puma560", "ur5", "kr6_r700"])
def test_special_geometry_matches_the_closed_form(name):
    """Parallel and intersecting axes make some arrangements' pencils singular; the chosen one must
    return every solution of the zoo's closed form (generic poses) and nothing the closed form lacks."""
    from ikcompiler import compile_robot, load_robot

    chain = load_robot(name)
    module = compile_robot(chain)
    solver = g6.prepare(chain.twists, chain.home, chain.scale)
    Q = np.random.default_rng(21).uniform(-math.pi, math.pi, size=(60, 6))
    T = chain.fk_batch(Q)
    batch = solver.solve_batch(T)
    closed, valid = module.solve_batch(T, limits=False)
    for n in range(len(Q)):
        ours, theirs = batch.Q[n][batch.valid[n]], closed[n][valid[n]]
        assert _distance(ours, Q[n]) < SAME, (name, n)
        for q in theirs:
            assert _distance(ours, q) < SAME, (name, n, q)
        for q in ours:
            assert _distance(theirs, q) < SAME, (name, n, q)


def test_prismatic_joints_no_order_takes_are_refused_with_a_reason():
    """TTRRRT: every joint order of the chain, rotated or inverted, puts a prismatic joint at the
    eliminated position c or at the last position f (whose axis point must stay fixed)."""
    twists, home = _with_prismatic(0, "TTRRRT")
    with pytest.raises(g6.General6Error, match="joint 1 is prismatic"):
        g6.prepare(twists, home)


def test_adjacent_prismatic_joints_in_the_middle_are_refused_as_a_singular_pencil():
    """RRTTRR: the two orders with c and f revolute put the prismatic joints at d and e together, and
    their pencil is singular: refused with the orders and the reason, so that the compiler keeps its
    search (docs/general6.md, "Prismatic joints")."""
    twists, home = _with_prismatic(0, "RRTTRR")
    with pytest.raises(g6.General6Error, match="pencil is singular"):
        g6.prepare(twists, home)


def _with_prismatic(seed, kinds):
    """A general arm whose joints marked T in ``kinds`` slide along the drawn axis direction."""
    twists, home = random_6r_geometry(seed)
    for i, k in enumerate(kinds):
        if k == "T":
            twists[i] = np.concatenate([twists[i, 3:], np.zeros(3)])
    return twists, home


@pytest.mark.parametrize("kinds", ["TRRRRR", "RRRRRT", "RTRRRR", "TTRRRR", "RRRRTT", "RRTRRR", "RRRTRR",
                                   "RRRTRT", "TRRRTR", "RTRRRT", "RRTRTR", "RTRRTR", "TRTRRT"])
def test_prismatic_joints_every_sampled_vector_recovered_and_exact(kinds):
    """A prismatic joint where an arrangement puts it at position a or b (joints 1, 2, 5, 6), or at
    position d or e: its displacement enters the 14 quantities as (1, d, d^2); with prismatic joints on
    both sides of the split the deflated 9 x 9 pencil (docs/general6.md, "Prismatic joints")."""
    prism = np.array([k == "T" for k in kinds])
    for seed in (0, 1):
        twists, home = _with_prismatic(seed, kinds)
        solver = g6.prepare(twists, home)
        size = _size(twists[~prism], home)
        rng = np.random.default_rng(200 + seed)
        Q = rng.uniform(-math.pi, math.pi, size=(60, 6))
        Q[:, prism] = rng.uniform(-size, size, size=(60, int(prism.sum())))
        T = _fk(twists, home, Q)
        b = solver.solve_batch(T)
        for n in range(len(Q)):
            rows = b.Q[n][b.valid[n]]
            assert len(rows) and len(rows) % 2 == 0, (kinds, seed, n, len(rows))
            gap = np.where(prism, np.abs(rows - Q[n]) / size, np.abs(np.angle(np.exp(1j * (rows - Q[n])))))
            assert gap.max(axis=1).min() < SAME, (kinds, seed, n, Q[n], rows)
            G = _fk(twists, home, rows)
            assert np.linalg.norm(G[:, :3, 3] - T[n, :3, 3], axis=1).max() <= EXACT * size
            assert np.linalg.norm(G[:, :3, :3] - T[n, :3, :3], axis=(1, 2)).max() <= EXACT
            assert np.all(rows[:, ~prism] > -math.pi) and np.all(rows[:, ~prism] <= math.pi)
        assert np.allclose(solver.fk(Q[:3]), T[:3], atol=1e-12 * size)


def test_bad_input_is_refused():
    twists, home = random_6r_geometry(0)
    with pytest.raises(SubproblemInputError, match="6 finite twists"):
        g6.prepare(twists[:5], home)
    solver = g6.prepare(twists, home)
    T = np.eye(4)
    T[0, 3] = np.nan
    with pytest.raises(SubproblemInputError, match="NaN"):
        solver.solve(T)


def test_two_solutions_sharing_the_eliminated_angle_are_both_read():
    """The configuration zoo's modular RRRRTT (seed 0) at q2 = pi: four solutions, two pairs of which
    share th_c (joint 4) and th_e (joint 2) and differ in joint 3: a double eigenvalue whose null space
    is 2-dimensional.  Its single mixed null vector converged to one of each pair; the sampled vector
    was lost (before: 2 rows, now 4, the sampled vector among them)."""
    from ikcompiler.configs import modular_chain

    chain = modular_chain("RRRRTT", seed=0, geometry="modular")
    solver = g6.General6(chain.twists, chain.home, chain.scale)
    q = np.array([-math.pi / 2, math.pi, -math.pi / 2, -math.pi / 2, 0.0678, 0.25038])
    T = chain.fk(q)
    rows = solver.solve(T)
    prism = np.array([k == "T" for k in chain.joint_types])
    gap = np.where(prism, np.abs(rows - q) / chain.scale, np.abs(np.angle(np.exp(1j * (rows - q)))))
    assert len(rows) == 4 and gap.max(axis=1).min() < SAME, rows
    G = chain.fk_batch(rows)
    assert np.linalg.norm(G[:, :3, 3] - T[:3, 3], axis=1).max() <= EXACT * chain.scale


def test_a_target_gets_the_same_rows_alone_and_in_a_batch():
    """At a self-motion the rows depend on the last bits of the null vectors: one exactly singular
    matrix in a batch's stack used to switch every root of the batch to SVD null vectors (modular
    RRTRRR seed 5, special angles: a representative 6.8e-3 rad away from the single-pose one)."""
    from ikcompiler.configs import modular_chain
    from ikcompiler.verify import sample_configurations

    chain = modular_chain("RRTRRR", seed=5, geometry="modular")
    solver = g6.General6(chain.twists, chain.home, chain.scale)
    T = chain.fk_batch(sample_configurations(chain, 10, seed=1, special=1.0))
    many = solver.solve_batch(T)
    for n in range(len(T)):
        one = solver.solve_batch(T[n:n + 1])
        assert np.array_equal(many.valid[n], one.valid[0]), n
        assert np.array_equal(many.Q[n][many.valid[n]], one.Q[0][one.valid[0]]), n
