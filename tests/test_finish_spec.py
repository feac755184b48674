"""The C finish against its specification in Python (``subproblems/settle.py``; docs/design.md
section 6, "The finish, specified once").

For the same candidates in -- the module's chain (and its alternative chain) on one goal -- the C finish
(``NativeChain.one``) and :func:`subproblems.settle.settle` must give the same rows out: both hand the
target back, or both return the same number of rows, equal joint values, residuals and flags.  Poses:
random ones inside the limits, special ones inside them (every revolute value 0, +-pi/2 or pi where the
limits allow) and special ones drawn regardless of the limits (branches outside them: the self-motions
that the straight-line test settles), with and without limits.
"""

from __future__ import annotations

import numpy as np
import pytest

from ikcompiler.codegen.fastpath import ChainData, build_program
from ikcompiler.codegen.printers import python_source
from ikcompiler.verify import sample_configurations
from subproblems import fast, native, settle
from tests.test_native import NATIVE_ROBOTS, _compiled

pytestmark = pytest.mark.skipif(native.compiler() is None, reason="no C compiler")

SPECIAL = (0.0, np.pi / 2, -np.pi / 2, np.pi)
POSES = 40  # per set and robot


def _spec_robot(module):
    """The finish's robot of a module, with its alternative chain as Python (the C prints the same IR)."""
    ns = vars(module)
    alt = None
    if ns["_ALT_STEPS"] and not ns["_SEARCH"]:
        program = build_program(ChainData.from_module(ns, "_ALT_STEPS"))
        if program is not None:
            scope = dict(ns)
            exec(python_source(program, "_fast_chain_alt"), scope)  # noqa: S102 - our own printed IR
            alt = scope["_fast_chain_alt"]
    return settle.FinishRobot.from_namespace(ns, chain_alt=alt)


def _pose_sets(module, robot):
    rng = np.random.default_rng(5)
    inside = sample_configurations(robot, POSES, seed=21, special=0.0)
    taught = sample_configurations(robot, POSES, seed=22, special=1.0)
    anywhere = inside.copy()
    revolute = np.array([k == "R" for k in module.JOINT_TYPES])
    anywhere[:, revolute] = rng.choice(SPECIAL, size=(POSES, int(revolute.sum())))
    return {"random": inside, "special in limits": taught, "special": anywhere}


@pytest.mark.parametrize("name", sorted(NATIVE_ROBOTS))
def test_c_finish_gives_its_specifications_rows(name):
    module, robot, chain = _compiled(name)
    assert chain is not None
    rb = _spec_robot(module)
    free_cols = [module.JOINT_NAMES.index(f) for f in module.FREE_JOINTS]
    compared = handed_back = settled = 0
    for label, Q in _pose_sets(module, robot).items():
        for q in Q:
            T = module.fk(q)
            goal = fast.goal_entries(T, module.TARGET if module.TARGET != "pose" else "pose")
            if goal is None:  # a target the C checks itself differently (not exact to 1e-14)
                continue
            free = tuple(float(q[c]) for c in free_cols)
            for limits in (True, False):
                c_rows = chain.one(T, free, limits)
                spec = settle.settle(rb, goal, free, limits)
                what = (name, label, q.tolist(), limits)
                compared += 1
                if spec == settle.PYTHON:
                    assert c_rows is None, what
                    handed_back += 1
                    continue
                assert c_rows is not None, what
                settled += 1
                cq, cres, cls, ccont = c_rows
                assert len(cq) == len(spec), (what, cq, spec)
                for k, (sq, sres, sls, scont) in enumerate(spec):
                    assert np.array_equal(cq[k], np.array(sq)), (what, k, cq[k], sq)
                    assert cres[k] == sres, (what, k, cres[k], sres)
                    assert (bool(cls[k]), bool(ccont[k])) == (sls, scont), (what, k)
    assert settled > 0 and compared == settled + handed_back


def _same_sets(a, b, kinds):
    """Rows a and b equal as sets (angles modulo 2 pi, to 1e-9)."""
    if len(a) != len(b):
        return False
    rev = np.array([k == "R" for k in kinds])
    left = list(range(len(b)))
    for row in a:
        d = np.abs(b[left] - row)
        d[:, rev] = np.abs(np.remainder(d[:, rev] + np.pi, 2 * np.pi) - np.pi)
        hit = np.nonzero((d <= 1e-9).all(axis=1))[0]
        if not len(hit):
            return False
        left.pop(int(hit[0]))
    return True


@pytest.mark.parametrize("name, label, expect", [
    # measured: settled in C before this finish 26, 22 and 30 of the 40 poses; now all 40
    ("puma560", "special", 40),  # self-motions whose line lies outside the limits
    ("kr6_r700", "special", 40),
    ("shadow_index", "special in limits", 40),  # values at their limits, clamped
])
def test_special_poses_settle_in_c_with_the_reference_runtimes_solutions(name, label, expect):
    """Self-motions lying outside the limits (a straight line alone in joint space) and values clamped
    onto a limit are settled in C; the exact isolated rows are those of the Python path (the reference
    runtime), and an exact self-motion representative comes back where the Python path has one."""
    module, robot, chain = _compiled(name)
    Q = _pose_sets(module, robot)[label]
    settled = 0
    for q in Q:
        T = module.fk(q)
        settled += chain.one(T, (), True) is not None
        module.NATIVE = True
        c = module.solve_info(T)
        module.NATIVE = False
        try:
            p = module.solve_info(T)
        finally:
            module.NATIVE = True
        cx, px = ~c.ls & ~c.continuum, ~p.ls & ~p.continuum
        assert _same_sets(c.q[cx], p.q[px], module.JOINT_TYPES), (name, q.tolist(), c.q[cx], p.q[px])
        assert (~p.ls & p.continuum).any() <= (~c.ls & c.continuum).any(), (name, q.tolist())
        sampled_found = any(np.allclose(np.cos(r - q), 1.0) for r in c.q[~c.ls])
        inside = ((q >= module.LOWER) & (q <= module.UPPER)).all()
        assert sampled_found or not inside or c.continuum.any(), (name, q.tolist())
    assert settled >= expect, (name, settled)


def test_wrist_locked_copies_take_their_newton_steps_once_with_the_same_rows(monkeypatch):
    """ur5 with q5 = 0: the wrong shoulder branch meets the wrist lock too, its family leaves miss the
    target at every representative, and each copy's best variant gets 60 Newton steps -- copies that
    start bit for bit alike, which the C takes once (fast_finish.h ikc_newton_once).  The C rows must be
    the specification's, and the case must be met (starts repeated within one target)."""
    module, robot, chain = _compiled("ur5")
    rb = _spec_robot(module)
    starts, repeated = [], [0]
    plain = settle.newton_steps

    def counted(rb_, g, q, iters, *args, **kw):
        if iters == 60:
            key = tuple(float(x).hex() for x in q)
            repeated[0] += key in starts
            starts.append(key)
        return plain(rb_, g, q, iters, *args, **kw)

    monkeypatch.setattr(settle, "newton_steps", counted)
    rng = np.random.default_rng(13)
    Q = rng.uniform(-np.pi, np.pi, size=(120, 6))
    Q[:, 4] = 0.0
    Q[::2, 2] = rng.choice(SPECIAL, size=60)  # half of them with the elbow at a special value too
    settled = 0
    for q in Q:
        T = module.fk(q)
        goal = fast.goal_entries(T, "pose")
        if goal is None:
            continue
        del starts[:]
        c_rows = chain.one(T, (), True)
        spec = settle.settle(rb, goal, (), True)
        if spec == settle.PYTHON:
            assert c_rows is None, q
            continue
        assert c_rows is not None, q
        settled += 1
        cq, cres, cls, ccont = c_rows
        assert len(cq) == len(spec), q
        for k, (sq, sres, sls, scont) in enumerate(spec):
            assert np.array_equal(cq[k], np.array(sq)) and cres[k] == sres, (q, k)
            assert (bool(cls[k]), bool(ccont[k])) == (sls, scont), (q, k)
    assert settled > 0 and repeated[0] > 0, (settled, repeated)


def test_representatives_run_only_while_a_family_leaf_needs_one(monkeypatch):
    """ur5 with q5 = 0: a family leaf that misses at rep 0 takes the first exact representative inside
    the limits, so the chain runs at later representatives only while some leaf has none
    (settle._polish_pending, fast_finish.h ikc_polish_pending).  The rows must be those of running the
    chain at every representative (the pending test forced true), and fewer chains must run; the C
    gives the specification's rows (test above and the wrist-locked test)."""
    module, robot, chain = _compiled("ur5")
    rb = _spec_robot(module)
    runs = [0]
    leaves = settle.FinishRobot.leaves

    def counted(self, *args):
        runs[0] += 1
        return leaves(self, *args)

    monkeypatch.setattr(settle.FinishRobot, "leaves", counted)
    rng = np.random.default_rng(29)
    Q = rng.uniform(-np.pi, np.pi, size=(60, 6))
    Q[:, 4] = 0.0
    lazy_runs = eager_runs = 0
    for q in Q:
        goal = fast.goal_entries(module.fk(q), "pose")
        if goal is None:
            continue
        runs[0] = 0
        lazy = settle.settle(rb, goal, (), True)
        lazy_runs += runs[0]
        with monkeypatch.context() as m:
            m.setattr(settle, "_polish_pending", lambda *a: True)
            runs[0] = 0
            eager = settle.settle(rb, goal, (), True)
            eager_runs += runs[0]
        assert lazy == eager, q
        c_rows = chain.one(module.fk(q), (), True)
        assert (c_rows is None) == (lazy == settle.PYTHON), q
        if c_rows is not None:
            assert [tuple(r) for r in c_rows[0]] == [tuple(r[0]) for r in lazy], q
    assert lazy_runs < eager_runs, (lazy_runs, eager_runs)
