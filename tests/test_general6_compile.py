"""The compiler routes 6R pose targets without a closed form to the general 6R elimination."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from ikcompiler import compile_robot, load_robot
from ikcompiler import verify as verify_mod
from ikcompiler.compiler import compile_source
from ikcompiler.model import Chain, Joint
from ikcompiler.verify import verify
from subproblems.screw import revolute_twist


def _random_chain(seed: int) -> Chain:
    """Axis directions uniform on the sphere, axis points in a 1 m cube: no closed form."""
    rng = np.random.default_rng(seed)
    joints = []
    for i in range(6):
        twist = revolute_twist(rng.normal(size=3), rng.uniform(-0.5, 0.5, 3))
        joints.append(Joint(f"j{i + 1}", "R", twist, -math.pi, math.pi))
    home = np.eye(4)
    home[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    return Chain(f"random-6r-{seed}", tuple(joints), home)


def _recovered_and_exact(chain, module, Q):
    T = chain.fk_batch(Q)
    S, V = module.solve_batch(T)
    size = chain.scale
    for n in range(len(Q)):
        rows = S[n][V[n]]
        assert len(rows), n
        d = np.abs(np.angle(np.exp(1j * (rows - Q[n])))).max(axis=1)
        assert d.min() < 1e-6, (n, Q[n])
        G = chain.fk_batch(rows)
        assert np.linalg.norm(G[:, :3, 3] - T[n, :3, 3], axis=1).max() <= 1e-12 * size
        assert np.linalg.norm(G[:, :3, :3] - T[n, :3, :3], axis=(1, 2)).max() <= 1e-12


def test_random_arm_compiles_to_general_6r_and_recovers_every_pose():
    chain = _random_chain(4)
    module = compile_robot(chain)
    assert module.METHOD == "general-6r"
    assert module.MAX_SOLUTIONS == 16
    Q = np.random.default_rng(2).uniform(-math.pi, math.pi, size=(60, 6))
    _recovered_and_exact(chain, module, Q)
    # the single-pose API agrees with the batch
    T = chain.fk_batch(Q[:5])
    S, V = module.solve_batch(T)
    for n in range(5):
        assert len(module.solve(T[n])) == V[n].sum()


def test_generated_module_imports_only_numpy_subproblems_and_the_runtime(tmp_path):
    source = compile_source(_random_chain(5))
    lines = [line for line in source.splitlines() if line.startswith(("import ", "from "))]
    imports = {line.split()[1] for line in lines}
    assert imports <= {"math", "numpy", "subproblems", "__future__", "ikcompiler"}, imports
    # of ikcompiler only its runtime (docs/design.md section 6)
    assert [x for x in lines if "ikcompiler" in x] == ["from ikcompiler import runtime as _runtime"]
    assert "from subproblems import general6 as _g6" in source
    assert "METHOD = 'general-6r'" in source
    path = tmp_path / "random_ik.py"
    path.write_text(source)
    cmd = [sys.executable, "-m", "ruff", "check", "--no-cache", "--isolated", str(path)]
    res = subprocess.run(cmd, capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr


def test_jaco_generic_poses_complete_with_nothing_wrong():
    """The Jaco's wrist obeys no closed-form rule: it was a 1-D search (94-96% recovered), now general-6r."""
    chain = load_robot("jaco")
    module = compile_robot(chain)
    assert module.METHOD == "general-6r"
    report = verify(chain, module, samples=120, seed=1, scalar_checks=10, special=0.0)
    assert report.wrong == 0 and report.missed == 0 and report.recovered == report.poses, report.text()
    assert report.max_error <= 1e-12, report.text()


def test_jaco_with_limits_returns_rows_inside_them():
    chain = load_robot("jaco")
    module = compile_robot(chain)
    Q = np.random.default_rng(3).uniform(chain.lower, chain.upper, size=(30, 6))
    S, V = module.solve_batch(chain.fk_batch(Q))
    rows = S[V]
    assert len(rows)
    assert np.all(rows >= chain.lower - 1e-9) and np.all(rows <= chain.upper + 1e-9)


def test_five_joint_arm_position_direction_target_through_the_virtual_roll():
    """A 5R arm's position + direction target is a 6R pose problem with the virtual tool roll."""
    rng = np.random.default_rng(3)
    twists = [revolute_twist(rng.normal(size=3), rng.uniform(-0.5, 0.5, 3)) for _ in range(5)]
    joints = tuple(Joint(f"j{i + 1}", "R", tw, -math.pi, math.pi) for i, tw in enumerate(twists))
    home = np.eye(4)
    home[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    chain = Chain("random-5r", joints, home)
    module = compile_robot(chain, target="position+direction")
    assert module.METHOD == "general-6r" and len(module.JOINT_NAMES) == 5
    report = verify(chain, module, samples=60, seed=1, scalar_checks=5, special=0.0)
    assert report.wrong == 0 and report.recovered == report.poses, report.text()


# ------------------------------------------------------------------ the 1-D search where it is measured
def _irb140():
    from ikcompiler import robotdb

    robotdb.require(["rtb-data"])
    entry = next(e for e in robotdb.discover(["rtb-data"]).chains if e.urdf.name == "irb140.urdf")
    return entry.load()


def test_irb140_keeps_the_1d_search_measured_complete_and_faster():
    """rtb-data's abb_irb140: the C 1-D search is complete on the sample (a quarter of the values
    special) and faster than the general-6r module, which misses rows at its wrist-singular special
    poses (issue 10 item 1); the sampled decision keeps it and says so in the notes."""
    from ikcompiler.compiler import compile_plan

    chain = _irb140()
    plan = compile_plan(chain)
    assert plan.method == "1d-search", plan.notes
    note = next(n for n in plan.notes if "1d-search kept" in n)
    assert "recovered 64/64 sampled joint vectors" in note, note
    module = compile_robot(chain)
    report = verify(chain, module, samples=120, seed=4, scalar_checks=10, special=0.0)
    assert report.wrong == 0 and report.missed == 0 and report.recovered == report.poses, report.text()


def test_irb140_general6_prefers_an_order_with_few_doubtful_poses():
    """The plain joint order leaves 46 of 64 irb140 poses doubtful (the costly re-solve path); the
    arrangement chosen first must leave few (measured: 1 of 64)."""
    from ikcompiler.general6_route import sample_joints
    from subproblems import general6 as g6

    chain = _irb140()
    solver = g6.General6(chain.twists, chain.home, chain.scale)
    Q = sample_joints(chain, special=0.0)
    Tn = solver._norm(chain.fk_batch(Q))
    _, _, doubt = solver._candidates(solver._arr[solver.usable[0]], Tn @ g6._inv(solver.Mn))
    assert doubt.sum() <= 4, (solver.usable, solver.why)
    b = solver.solve_batch(chain.fk_batch(Q))
    for n in range(len(Q)):
        rows = b.Q[n][b.valid[n]]
        assert np.abs(np.angle(np.exp(1j * (rows - Q[n])))).max(axis=1).min() < 1e-6, n


def test_jaco_notes_say_the_1d_search_was_measured_incomplete():
    from ikcompiler.compiler import compile_plan

    plan = compile_plan(load_robot("jaco"))
    assert plan.method == "general-6r"
    assert any("chosen over the 1d-search (incomplete on the sample)" in n for n in plan.notes), plan.notes


class _Dropping:
    """A stand-in 1-D search module: the general solver's rows with the last row of some poses dropped
    (``drop``) and every call repeated ``work`` times (a slower solver)."""

    def __init__(self, solver, drop, work=1):
        self.solver, self.drop, self.work = solver, drop, work

    def solve_batch(self, T, limits=True):
        for _ in range(self.work):
            b = self.solver.solve_batch(T)
        V = b.valid.copy()
        for n in range(0, len(T), self.drop) if self.drop else ():
            V[n, np.nonzero(V[n])[0][-1:]] = False
        return b.Q, V


def test_route_refuses_an_incomplete_or_slower_search():
    from ikcompiler.general6_route import compare
    from subproblems import general6 as g6

    chain = _random_chain(4)
    solver = g6.General6(chain.twists, chain.home, chain.scale)
    general = _Dropping(solver, drop=0)  # the general-6r module's solve_batch: every row
    missing = compare(chain, _Dropping(solver, drop=7), general, "1d-search")
    assert not missing.keep_search and "incomplete" in missing.note, missing.note
    slow = compare(chain, _Dropping(solver, drop=0, work=3), general, "1d-search")
    assert not slow.keep_search and "slower" in slow.note, slow.note
    assert "on 8 sampled poses" in slow.note and "recovered 8/8 sampled joint vectors" in slow.note, slow.note


def test_route_keeps_a_slower_search_where_general6r_misses_rows():
    """Both sides' completeness is measured: a complete search is kept, slower or not, where the
    general-6r module misses a row it finds (abb_irb140's doubtful targets at special poses)."""
    from ikcompiler.general6_route import compare
    from subproblems import general6 as g6

    chain = _random_chain(4)
    solver = g6.General6(chain.twists, chain.home, chain.scale)
    kept = compare(chain, _Dropping(solver, drop=0, work=3), _Dropping(solver, drop=5), "1d-search")
    assert kept.keep_search and "complete where general-6r is not" in kept.note, kept.note
    assert "on 64 sampled poses" in kept.note, kept.note
    assert "recovered 64/64 sampled joint vectors" in kept.note, kept.note


def test_general_trrrrr_chain_compiles_to_general_6r_and_verifies():
    """Issue 10 item 1: 6-joint chains with prismatic joints by the same elimination (TRRRRR-type
    general geometry from the configuration zoo; before, the 1-D / 2-D search)."""
    from ikcompiler.configs import modular_chain

    for kinds in ("TRRRRR", "RRRRRT"):
        chain = modular_chain(kinds, 0, "general")
        module = compile_robot(chain)
        assert module.METHOD == "general-6r", kinds
        report = verify(chain, module, samples=80, seed=2, scalar_checks=5, special=0.25)
        assert report.wrong == 0 and report.missed == 0 and report.recovered == report.poses, report.text()
        assert report.max_error <= 1e-12, report.text()


@pytest.mark.parametrize("kinds", ["RRTRRR", "RRRTRR", "RRRTRT", "TRRRTR", "RTRRRT"])
def test_prismatic_joint_3_or_4_compiles_to_general_6r_and_verifies(kinds):
    """A prismatic joint 3 or 4 sits at position d or e of an arrangement (configuration zoo, general
    geometry, seed 0; before, the 2-D search (RRTRRR) or the 1-D search, which missed 1-3 of 40 random
    poses (benchmarks/results/configurations.md of 2026-12-02 01:27))."""
    from ikcompiler.configs import modular_chain

    chain = modular_chain(kinds, 0, "general")
    module = compile_robot(chain)
    assert module.METHOD == "general-6r", kinds
    for seed, special in ((1, 1.0), (2, 0.0)):
        report = verify(chain, module, samples=40, seed=seed, scalar_checks=3, special=special)
        assert report.wrong == 0 and report.missed == 0 and report.recovered == report.poses, report.text()
        assert report.max_error <= 1e-12, report.text()


def test_prismatic_joints_on_both_sides_keep_the_search_with_a_note():
    from ikcompiler.compiler import compile_plan
    from ikcompiler.configs import modular_chain

    plan = compile_plan(modular_chain("RRTTRR", 0, "general"))
    assert plan.method != "general-6r"
    refused = [n for n in plan.notes if "general 6R elimination not used" in n]
    assert refused and "pencil is singular" in refused[0], plan.notes
    assert "joints 3 and 4 are adjacent prismatic joints" in refused[0], refused[0]


@pytest.mark.parametrize("kinds, joints", [("RTTRRR", "2 and 3"), ("RRRTTR", "4 and 5")])
def test_adjacent_prismatic_joints_are_refused_by_name(kinds, joints):
    """The known gap (adjacent prismatic joints at d and e of every usable order) is a typed refusal
    (General6Error) that names the joints."""
    from ikcompiler.configs import modular_chain
    from subproblems import general6 as g6

    chain = modular_chain(kinds, 0, "general")
    with pytest.raises(g6.General6Error, match=f"joints {joints} are adjacent prismatic joints"):
        g6.General6(chain.twists, chain.home, chain.scale)


def _random_7r(seed: int) -> Chain:
    rng = np.random.default_rng(seed)
    joints = tuple(Joint(f"j{i + 1}", "R", revolute_twist(rng.normal(size=3), rng.uniform(-0.5, 0.5, 3)),
                         -math.pi, math.pi) for i in range(7))
    home = np.eye(4)
    home[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    return Chain(f"random-7r-{seed}", joints, home)


@pytest.mark.parametrize("free", ["j1", "j7"])
def test_a_free_joint_at_either_end_leaves_a_general_6r_problem(free):
    # P X(q) S M = T: a free first (P) or last (S) joint moves the target, not the six solved twists
    chain = _random_7r(3)
    module = compile_robot(chain, free=(free,))
    assert module.METHOD == "general-6r" and module.FREE_JOINTS == (free,)
    eliminated = [f"j{i}" for i in range(1, 8) if f"j{i}" != free]
    assert f"G6R in ({', '.join(eliminated)})" in module.PLAN  # the explain line names the six solved joints
    Q = np.random.default_rng(4).uniform(-math.pi, math.pi, size=(25, 7))
    T = chain.fk_batch(Q)
    k = chain.independent_names.index(free)
    S, V = module.solve_batch(T, Q[:, k])
    for n in range(len(Q)):
        rows = S[n][V[n]]
        assert np.all(rows[:, k] == Q[n, k])  # the free value as given
        d = np.abs(np.angle(np.exp(1j * (rows - Q[n])))).max(axis=1)
        assert d.min() < 1e-6, n
        G = chain.fk_batch(rows)
        assert np.linalg.norm(G[:, :3, 3] - T[n, :3, 3], axis=1).max() <= 1e-12 * chain.scale
        assert np.linalg.norm(G[:, :3, :3] - T[n, :3, :3], axis=(1, 2)).max() <= 1e-12
        assert len(module.solve(T[n], Q[n, k])) == V[n].sum()
    report = verify(chain, module, samples=30, seed=5)
    assert report.ok and report.recovered + report.self_motion == report.poses, report.text()
    # the C elimination of the six solved joints on moved targets (runtime/freeends.py) and the Python
    # reference give the same rows
    assert module.NATIVE and module._SOLVER.free_ends_native() is not None
    module.NATIVE = False
    S2, V2 = module.solve_batch(T, Q[:, k])
    np.testing.assert_array_equal(V.sum(axis=1), V2.sum(axis=1))
    for n in range(len(Q)):
        a, b = S[n][V[n]], S2[n][V2[n]]
        gap = np.abs(np.angle(np.exp(1j * (a[:, None, :] - b[None, :, :])))).max(axis=2)
        assert gap.min(axis=1).max() < 1e-9, n


@pytest.mark.parametrize("free", ["j1", "j7"])
def test_one_pose_with_a_free_end_joint_gives_the_batch_forms_rows(free):
    # solve / solve_info of one pose take NativeFreeEnds.one (scalars, no (N, K, n) arrays); the batch
    # form takes NativeFreeEnds.many: the same rows, residuals and flags bit for bit, at random and
    # special poses, free values outside the limits and at -pi (not its own representative)
    chain = _random_7r(3)
    module = compile_robot(chain, free=(free,))
    k = chain.independent_names.index(free)
    Q = np.concatenate([np.random.default_rng(8).uniform(-math.pi, math.pi, size=(20, 7)),
                        verify_mod.sample_configurations(chain, 20, seed=9, special=1.0)])
    T = chain.fk_batch(Q)
    F = Q[:, k].copy()
    F[:3] = (3.5, -3.5, -math.pi)
    for limits in (True, False):
        S, V, LS, R, C = module.solve_batch_info(T, F, limits=limits)
        for n in range(len(Q)):
            info = module.solve_info(T[n], float(F[n]), limits=limits)
            v = V[n]
            for got, want in ((info.q, S[n][v]), (info.residual, R[n][v]), (info.ls, LS[n][v]),
                              (info.continuum, C[n][v])):
                np.testing.assert_array_equal(got, want, err_msg=f"pose {n}, limits {limits}")
            np.testing.assert_array_equal(module.solve(T[n], float(F[n]), limits=limits), S[n][v & ~LS[n]])
        assert not (limits and V[:2].any())  # free values outside the limits: no row with them


def test_a_free_end_value_and_its_2pi_alias_take_the_same_path_and_give_the_reference_rows():
    # a free value outside (-pi, pi] (or -pi) moves the target as its alias does: the C decides alike
    # (no hand-back for being an alias: xarm7's joint7, limits +-2 pi, sent half its poses to Python),
    # and the rows are the Python reference's with the value as given
    chain = _random_7r(3)
    module = compile_robot(chain, free=("j7",), tol=None)
    fe = module._SOLVER.free_ends_native()
    robot = module._SOLVER.robot
    column = robot.independent[robot.free[0]]
    Q = np.random.default_rng(12).uniform(-math.pi, math.pi, size=(20, 7))
    T = chain.fk_batch(Q)
    goals = np.asarray(T, dtype=float)
    for shift in (2 * math.pi, -2 * math.pi):
        init, alias = np.full((20, 7), np.nan), np.full((20, 7), np.nan)
        init[:, column], alias[:, column] = Q[:, 6], Q[:, 6] + shift
        _, redo = fe.many(goals, init, limits=False)
        _, redo_alias = fe.many(goals, alias, limits=False)
        np.testing.assert_array_equal(redo, redo_alias)
        S, V = module.solve_batch(T, alias[:, column], limits=False)
        module.NATIVE = False
        try:
            S2, V2 = module.solve_batch(T, alias[:, column], limits=False)
        finally:
            module.NATIVE = True
        np.testing.assert_array_equal(V.sum(axis=1), V2.sum(axis=1))
        for n in range(len(Q)):
            a, b = S[n][V[n]], S2[n][V2[n]]
            assert np.all(a[:, 6] == alias[n, column])  # as given
            gap = np.abs(np.angle(np.exp(1j * (a[:, None, :] - b[None, :, :])))).max(axis=2)
            assert gap.min(axis=1).max() < 1e-9, n


def _moved_in_python(fe, robot, T, value):
    """The rows of one raw target as the free-end layer made them in Python (session 17): the moved
    target by FreeEnds.targets, the six's C call on it, each exact row checked by our FK on the whole
    robot; (q, residual, ls) or None where that layer handed the target to the batch form."""
    init = np.full((1, len(robot.kinds)), np.nan)
    init[0, robot.independent[robot.free[0]]] = value
    found = fe.native.one(fe.split.targets(np.asarray(T, float)[None], init)[0], (), True)
    if found is None:
        return None
    q6, res, ls, _ = found
    Q = np.zeros((len(q6), len(robot.joint_names)))
    Q[:, [robot.independent.index(j) for j in fe.split.solved]] = q6
    Q[:, robot.free[0]] = value
    err = robot.error(np.array([robot.fk(q) for q in Q]).reshape(-1, 4, 4), np.asarray(T, float)[None])
    if not (err[~ls] <= robot.tol * robot.scale).all():
        return None
    res = res.copy()
    res[~ls] = err[~ls]
    return Q, res, ls


@pytest.mark.parametrize("free", ["j1", "j7"])
def test_one_free_end_pose_is_moved_solved_and_checked_in_one_c_call(free):
    # NativeFreeEnds.one takes the raw target: the C (subproblems/free_ends.h) checks it, moves it by the
    # free value, solves the six and checks every exact row on the whole robot; the rows are those of the
    # Python layer it replaces (moved target, C call, our FK check) as sets to 1e-12, the residuals of
    # exact rows the whole robot's error; a target that is not a rigid transform comes back None (the
    # batch form then raises the module's typed error)
    chain = _random_7r(3)
    module = compile_robot(chain, free=(free,))
    fe, robot = module._SOLVER.free_ends_native(), module._SOLVER.robot
    k = chain.independent_names.index(free)
    Q = np.concatenate([np.random.default_rng(21).uniform(-math.pi, math.pi, size=(15, 7)),
                        verify_mod.sample_configurations(chain, 15, seed=22, special=1.0)])
    T = chain.fk_batch(Q)
    compared = 0
    for n in range(len(Q)):
        got = fe.one(T[n], [float(Q[n, k])], True)
        want = _moved_in_python(fe, robot, T[n], float(Q[n, k]))
        assert (got is None) == (want is None), n
        if got is None:
            continue
        compared += 1
        q, res, ls, _ = got
        assert np.all(q[:, k] == Q[n, k])  # the free value as given, in its column
        assert len(q) == len(want[0]) and np.array_equal(ls, want[2]), n
        gap = np.abs(np.angle(np.exp(1j * (q[:, None, :] - want[0][None, :, :])))).max(axis=2)
        assert gap.min(axis=1).max() <= 1e-12 and gap.min(axis=0).max() <= 1e-12, n
        # an exact row's residual is the whole robot's error of that row (our FK's, to its roundoff)
        ours = robot.error(np.array([robot.fk(row) for row in q[~ls]]).reshape(-1, 4, 4), T[n][None])
        np.testing.assert_allclose(res[~ls], ours, rtol=0, atol=1e-2 * robot.tol * robot.scale)
        assert (res[~ls] <= robot.tol * robot.scale).all()
    assert compared >= 25
    bad = T[0].copy()
    bad[0, 0] = np.nan
    skew = T[0].copy()
    skew[:3, :3] *= 1.01
    lifted = T[0].copy()
    lifted[3, 0] = 1e-9
    for target in (bad, skew, lifted):
        assert fe.one(target, [float(Q[0, k])], True) is None
        with pytest.raises(module.InvalidTargetError):
            module.solve(target, float(Q[0, k]))
    # a rotation orthonormal only to ~1e-10 is projected (the Python check), then solved exactly
    near = T[0].copy()
    near[:3, :3] += 1e-10 * np.random.default_rng(23).normal(size=(3, 3))
    assert fe.one(near, [float(Q[0, k])], True) is None
    rows = module.solve(near, float(Q[0, k]))
    assert len(rows) and np.abs(np.angle(np.exp(1j * (rows - Q[0])))).max(axis=1).min() < 1e-6


def test_the_c_hands_back_a_target_whose_exact_rows_miss_on_the_whole_robot():
    # the whole-robot check in C is live: printed with M^-1 off by 1e-9 (the moved target wrong, the
    # six's rows exact for it), every target goes back to Python, the reason IKC_WHY_WHOLE (10); with
    # the true M^-1 the same targets are settled in C
    from ikcompiler.codegen.csource import free_ends_c_source
    from ikcompiler.runtime.freeends import NativeFreeEnds
    from subproblems import native

    chain = _random_7r(3)
    module = compile_robot(chain, free=("j7",))
    robot = module._SOLVER.robot
    Q = np.random.default_rng(31).uniform(-math.pi, math.pi, size=(8, 7))
    T = chain.fk_batch(Q)

    def bound(home_inv):
        source = free_ends_c_source(
            robot.general6, joint_types=robot.joint_types, lower=robot.lower, upper=robot.upper,
            scale=robot.scale, tol=robot.tol, slots=robot.slots, twists=robot.twists, home=robot.home,
            home_inv=home_inv, A=robot.A, b=robot.B, solved=list(range(6)), solved_pos=list(range(6)),
            free_cols=[6], free_pos=[6])
        lib = native.load(source)
        return NativeFreeEnds(robot, lib, native.NativeChain(lib, dof=6, slots=robot.slots, nfree=0,
                                                             target="pose"))

    off = robot.home_inv.copy()
    off[:3, 3] += 1e-9 * robot.scale
    good, bad = bound(robot.home_inv), bound(off)
    for n in range(len(Q)):
        assert good.one(T[n], [float(Q[n, 6])], False) is not None, n
        assert bad.one(T[n], [float(Q[n, 6])], False) is None, n
        assert bad.native.last_reason() == 10, n
    _, redo = bad.many(T, np.where(np.arange(7) == 6, Q, np.nan), limits=False)
    assert redo.all()


def test_free_joints_at_both_ends_move_the_target_from_both_sides_in_c():
    # an 8-joint chain with j1 and j8 free, given last-first: the C's moved target has both P and S
    # (free_ends.h ikc_fe_moved), each free value from its own slot; rows those of the Python reference
    rng = np.random.default_rng(3)
    joints = tuple(Joint(f"j{i + 1}", "R", revolute_twist(rng.normal(size=3), rng.uniform(-0.5, 0.5, 3)),
                         -math.pi, math.pi) for i in range(8))
    home = np.eye(4)
    home[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    chain = Chain("random-8r", joints, home)
    module = compile_robot(chain, free=("j8", "j1"))
    assert module.METHOD == "general-6r" and module._SOLVER.free_ends_native() is not None
    Q = np.random.default_rng(4).uniform(-math.pi, math.pi, size=(20, 8))
    T = chain.fk_batch(Q)
    S, V = module.solve_batch(T, Q[:, 7], Q[:, 0])
    module.NATIVE = False
    try:
        S2, V2 = module.solve_batch(T, Q[:, 7], Q[:, 0])
    finally:
        module.NATIVE = True
    np.testing.assert_array_equal(V.sum(axis=1), V2.sum(axis=1))
    for n in range(len(Q)):
        a, b = S[n][V[n]], S2[n][V2[n]]
        assert np.all(a[:, 0] == Q[n, 0]) and np.all(a[:, 7] == Q[n, 7])
        gap = np.abs(np.angle(np.exp(1j * (a[:, None, :] - b[None, :, :])))).max(axis=2)
        assert gap.min(axis=1).max() < 1e-9, n
        assert np.abs(np.angle(np.exp(1j * (a - Q[n])))).max(axis=1).min() < 1e-6, n
        np.testing.assert_array_equal(module.solve(T[n], Q[n, 7], Q[n, 0]), a)


@pytest.mark.parametrize("free", ["j3", "j4"])
def test_a_free_joint_between_solved_ones_folds_the_six_twists(free):
    # E = exp(xi_f q_f): the twists after the free joint become Ad_E xi_k, one 6R chain per free value
    # (runtime/freefold.py), its arrangements chosen at compile time; no closed form for any free joint
    chain = _random_7r(3)
    module = compile_robot(chain, free=(free,))
    assert module.METHOD == "general-6r" and module.FREE_JOINTS == (free,)
    assert module.NATIVE is False  # the C elimination does not fold (Python only)
    assert "folded at the free joint" in module.PLAN
    k = chain.independent_names.index(free)
    random = np.random.default_rng(6).uniform(-math.pi, math.pi, size=(30, 7))
    special = verify_mod.sample_configurations(chain, 30, seed=7, special=0.5)
    special[:4, k] = (0.0, 0.5 * math.pi, -0.5 * math.pi, math.pi)  # the free joint special too
    Q = np.concatenate([random, special])
    T = chain.fk_batch(Q)
    S, V = module.solve_batch(T, Q[:, k])
    for n in range(len(Q)):
        rows = S[n][V[n]]
        assert len(rows), n
        assert np.all(rows[:, k] == Q[n, k])  # the free value as given
        d = np.abs(np.angle(np.exp(1j * (rows - Q[n])))).max(axis=1)
        assert d.min() < 1e-6, (n, Q[n])
        G = chain.fk_batch(rows)
        assert np.linalg.norm(G[:, :3, 3] - T[n, :3, 3], axis=1).max() <= 1e-12 * chain.scale
        assert np.linalg.norm(G[:, :3, :3] - T[n, :3, :3], axis=(1, 2)).max() <= 1e-12
    for n in (0, 30):
        assert len(module.solve(T[n], Q[n, k])) == V[n].sum()


def test_a_free_joint_between_solved_ones_of_an_eight_joint_chain_has_a_note():
    rng = np.random.default_rng(8)
    joints = tuple(Joint(f"j{i + 1}", "R", revolute_twist(rng.normal(size=3), rng.uniform(-0.5, 0.5, 3)),
                         -math.pi, math.pi) for i in range(8))
    module = compile_robot(Chain("random-8r", joints, np.eye(4)), free=("j3", "j5"))
    assert module.METHOD != "general-6r"
    assert "a free joint between solved joints" in module.PLAN


def test_compile_chain_prefers_free_end_joints_to_the_fold():
    # free end joints keep the six twists fixed (the C elimination); the fold is Python only
    from ikcompiler import configs
    from ikcompiler.runtime.freefold import FoldedGeneral6

    chain = _random_7r(3)
    best = configs.compile_chain(chain)
    assert best.module.METHOD == "general-6r" and not isinstance(best.module._GENERAL6, FoldedGeneral6)
    assert best.free in (("j7",), ("j1",))
    elbow = configs.compile_chain(chain, first_only=True)
    assert elbow.free == ("j3",) and isinstance(elbow.module._GENERAL6, FoldedGeneral6)


def test_a_fold_built_from_a_robot_chooses_its_arrangements_once():
    # a snapped plan's doubtful targets (reference.true_general6): the arrangements are chosen as the
    # compiler chooses them, once, on the first call, not again for every free value (~70 ms each)
    from ikcompiler.runtime import freefold

    chain = _random_7r(3)
    column = chain.independent_names.index("j3")
    joint = chain.joints[column]
    lazy = freefold.FoldedGeneral6(chain.twists, chain.home, chain.scale, column,
                                   choose_within=(joint.lower, joint.upper))
    assert lazy.arrangement is None
    Q = np.random.default_rng(4).uniform(-math.pi, math.pi, size=(6, 7))
    T = chain.fk_batch(Q)
    rows, owner = lazy.rows(T, Q[:, column])
    chosen = freefold.choose_arrangements(chain.twists, chain.home, chain.scale, column, joint.lower,
                                          joint.upper)
    assert lazy.arrangement == chosen
    fixed = freefold.FoldedGeneral6(chain.twists, chain.home, chain.scale, column, arrangement=chosen)
    rows2, owner2 = fixed.rows(T, Q[:, column])
    assert np.array_equal(owner, owner2) and np.array_equal(rows, rows2)
    for n in range(len(Q)):
        d = np.abs(np.angle(np.exp(1j * (rows[owner == n] - Q[n])))).max(axis=1)
        assert d.min() < 1e-6, n
