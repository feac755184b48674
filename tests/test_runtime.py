"""The runtime the generated modules call (ikcompiler/runtime; docs/design.md section 6): each path
runs at most once per pose, the continuum pull stops on exact rows, and the memory budget chunks a
search without changing its rows."""

from __future__ import annotations

import numpy as np
import pytest

from ikcompiler import compile_robot, load_robot
from ikcompiler.runtime import fastchain, reference

SPECIAL = (0.0, np.pi / 2, -np.pi / 2, np.pi)


@pytest.fixture(scope="module")
def puma():
    return compile_robot("puma560")


def _special_targets(module, n, seed):
    Q = np.random.default_rng(seed).choice(SPECIAL, size=(n, len(module.JOINT_NAMES)))
    return np.array([module.fk(q) for q in Q])


def _counting(monkeypatch, owner, name, counts):
    original = getattr(owner, name)

    def counted(*args, **kwargs):
        counts[name] = counts.get(name, 0) + 1
        return original(*args, **kwargs)

    monkeypatch.setattr(owner, name, counted)


def _same_rows(a, b, kinds):
    """Exact row sets equal (revolute values modulo 2 pi), in any order."""
    if a.shape != b.shape:
        return False
    for row in a:
        d = np.abs(b - row)
        rev = np.array([k == "R" for k in kinds])
        d[:, rev] = np.minimum(d[:, rev] % (2 * np.pi), 2 * np.pi - d[:, rev] % (2 * np.pi))
        if not (d.max(axis=1) <= 1e-6).any():
            return False
    return True


@pytest.fixture(scope="module")
def rhino():
    return compile_robot("rhino")


def test_each_path_runs_at_most_once_per_pose(rhino, monkeypatch):
    """A pose the C chain hands back costs one C run, one scalar fast chain, at most one reference run
    (before the runtime: three C runs and two Python fast runs).  rhino: its special poses on the
    planar self-motion are handed back (the C finish settles every special puma560 pose and, since its
    S2-RR locks, every grasp4dof one: docs/design.md section 6)."""
    solver = rhino._SOLVER
    native = solver.native_chain()
    handed_back = []
    for T in _special_targets(rhino, 200, seed=1):
        if native is not None and native.one(T, (), True) is None:
            handed_back.append(T)
        elif native is None:
            handed_back.append(T)
    assert len(handed_back) >= 5  # special poses on a self-motion: the test is not vacuous
    counts: dict = {}
    if native is not None:
        _counting(monkeypatch, native, "one", counts)
        _counting(monkeypatch, native, "exact", counts)
    _counting(monkeypatch, fastchain, "scalar_leaves", counts)
    _counting(monkeypatch, fastchain, "leaves", counts)
    _counting(monkeypatch, reference, "candidates", counts)
    for T in handed_back:
        for call in (rhino.solve, rhino.solve_info):
            counts.clear()
            call(T)
            if native is not None:
                assert counts.get("one", 0) + counts.get("exact", 0) <= (2 if call is rhino.solve_info else 1)
            runs = 2 if call is rhino.solve_info else 1  # solve_info asks with and without the limits
            assert counts.get("scalar_leaves", 0) + counts.get("leaves", 0) <= runs, counts
            assert counts.get("candidates", 0) <= runs, counts


def test_newton_until_exact_leaves_exact_rows_and_converges_the_others(puma):
    """The continuum pull stops on rows already exact (they are returned bit for bit) and brings the
    others where plain Newton steps bring them."""
    robot = puma._SOLVER.robot
    Ts = _special_targets(puma, 40, seed=2)
    rows, goals = [], []
    for T in Ts:
        for q in puma.solve(T, limits=False):
            rows.append(q)
            goals.append(T)
    TH = np.array(rows) @ robot.A.T + robot.B
    goals = np.array(goals)
    assert len(TH) >= 20
    moved = TH.copy()
    moved[::2] += 1e-4  # every other row off its solution
    pulled = robot.newton_until_exact(moved, goals, 60)
    start = robot.error(reference._rt.fk_batch(robot.twists, moved, robot.home), goals)
    still = start <= 1e-2 * robot.tol * robot.scale  # exact with the pull's margin: no step taken
    assert still[1::2].sum() >= 10
    np.testing.assert_array_equal(pulled[still], moved[still])
    plain = robot.newton(moved[::2], goals[::2], 60)
    err = robot.error(reference._rt.fk_batch(robot.twists, pulled[::2], robot.home), goals[::2])
    err_plain = robot.error(reference._rt.fk_batch(robot.twists, plain, robot.home), goals[::2])
    assert (err <= np.maximum(err_plain, 1e-2 * robot.tol * robot.scale)).all()


def test_search_memory_budget_chunks_without_changing_rows(monkeypatch):
    """The fast chain's search in passes bounded by the budget gives the rows of one pass."""
    from ikcompiler import compiler
    from ikcompiler.verify import sample_configurations

    monkeypatch.setattr(compiler, "USE_GENERAL6", False)
    module = compile_robot("jaco")
    assert module._SEARCH
    module.NATIVE = False
    Q = sample_configurations(load_robot("jaco"), 12, seed=3, special=0.0)
    Ts = np.array([module.fk(q) for q in Q])
    solver = module._SOLVER
    width = fastchain.BYTES_PER_INSTANCE * fastchain.search_width(solver.robot)
    big = module.solve_batch_info(Ts)
    solver.memory_budget = 2 * width  # two targets a pass
    seen = []  # targets each stage of the search is given at once: the whole search runs in chunks
    search, complete = fastchain.search_candidates, reference.complete
    monkeypatch.setattr(fastchain, "search_candidates",
                        lambda r, goals, *a: seen.append(("search", len(goals))) or search(r, goals, *a))
    monkeypatch.setattr(reference, "complete",
                        lambda r, TH, owner, ls, cont, goals, *a: seen.append(("finish", len(goals)))
                        or complete(r, TH, owner, ls, cont, goals, *a))
    small = module.solve_batch_info(Ts)
    for a, b in zip(big, small):
        np.testing.assert_array_equal(a, b)
    assert {stage for stage, _ in seen} == {"search", "finish"}
    assert max(n for _, n in seen) == 2 and sum(n for stage, n in seen if stage == "search") == len(Ts)
