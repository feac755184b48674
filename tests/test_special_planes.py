"""Self-motions at special poses that the C finish now settles (docs/design.md section 6, "Exact
tangent lines and planes"): an exact self-motion line flagged a tangent root whose second null
direction is a double root's (stanford at q2 = pi, prob), a self-motion plane whose fixed joint
lies outside its limits (panda's stretched elbow q4 = 0 with joints 1, 3 and 5 coaxial; prob's wrist
at q5 = pi), and the same plane where a double root adds a third null direction at its point (prob at
q5 = pi with joints 2 and 3 at a double root: ``settle.plane_root_misses``).  Before this finish each of
these poses went to the reference runtime (0.1-0.3 s).

Lines settled after the chain's first other representative ("Lines checked by forward kinematics":
``settle.quick_lines``) give the rows of the full loop over all 16 with at most 4 chain runs, and the
Cholesky pre-test of the rank (``settle.rank_clear``) never passes where the eigenvalues would fail.

Each pose: the C finish settles it, gives its specification's rows bit for bit (subproblems/settle.py),
and its exact rows are the reference runtime's (NATIVE off: the Python fast chain and the reference
runtime), as sets to 1e-9."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from subproblems import fast, native, settle
from tests.test_finish_spec import _same_sets, _spec_robot
from tests.test_native import _compiled

pytestmark = pytest.mark.skipif(native.compiler() is None, reason="no C compiler")

H, P = math.pi / 2, math.pi
POSES = [  # joint vectors of benchmarks/special_poses.py's special set (seed 7) that were handed back
    ("stanford", [P, P, 0.9313, 0.0, 0.0, P]),  # q2 = pi (outside its limits): double root + wrist lock
    ("stanford", [-H, P, 0.2150 * H, H, 0.0, -H]),
    ("panda", [0.0, 0.0, 0.0, 0.0, P, 0.0, 0.0]),  # q4 = 0 outside [-3.07, -0.07]: a plane, no row
    ("panda", [0.0, 0.0, P, 0.0, -H, 0.0, -H]),  # the same plane, and one isolated row inside the limits
    ("panda", [H, P, 0.0, 0.0, 0.0, 0.0, P]),
    ("prob", [0.0, P, -H, P, P, 0.0]),  # q5 = pi outside +-115 deg
    ("prob", [-H, H, -H, P, P, P]),
    ("prob", [0.0, H, H, 0.0, P, H]),
    # q5 = pi and joints 2, 3 at a double root: three null directions at the plane's point (session 11)
    ("prob", [-H, H, H, H, P, P]),
    ("prob", [H, H, -H, -H, P, 0.0]),
    ("prob", [P, -H, -H, P, P, P]),
    ("prob", [-H, -H, -H, P, P, H]),
]


@pytest.mark.parametrize("name, q", POSES)
def test_special_self_motion_settles_in_c_with_the_reference_runtimes_rows(name, q):
    module, _, chain = _compiled(name)
    q = np.array(q)
    free_cols = [module.JOINT_NAMES.index(f) for f in module.FREE_JOINTS]
    free = tuple(float(q[c]) for c in free_cols)
    T = module.fk(q)
    found = chain.one(T, free, True)
    assert found is not None, (name, q.tolist(), chain.last_reason())
    spec = settle.settle(_spec_robot(module), fast.goal_entries(T, module.TARGET), free, True)
    assert spec != settle.PYTHON and len(spec) == len(found[0])
    for k, (sq, sres, sls, scont) in enumerate(spec):
        assert np.array_equal(found[0][k], np.array(sq)) and found[1][k] == sres
        assert (bool(found[2][k]), bool(found[3][k])) == (sls, scont)
    module.NATIVE = False
    try:
        ref = module.solve_info(T, *free)
    finally:
        module.NATIVE = True
    c = module.solve_info(T, *free)
    assert _same_sets(c.q[~c.ls], ref.q[~ref.ls], module.JOINT_TYPES), (name, q.tolist(), c.q, ref.q)
    for row in c.q[~c.ls]:
        assert np.abs(module.fk(row) - T).max() <= module.TOLERANCE * module.SCALE


QUICK = [  # special poses whose self-motion lines settle after the chain's first other representative
    ("panda", [-H, H, -H, 0.0, H, 0.0, -H]),  # tangent lock lines dropped (a plane), one isolated row
    ("panda", [-H, P, 0.0, -H, 0.0, -H, P]),  # an exact line at q2 = pi outside the limits: dropped
    ("panda", [H, 0.0, H, -H, 0.0, 0.0, H]),  # an exact line inside them: a representative taken
    ("puma560", [P, P, -H, H, 0.0, P]),  # wrist lock q5 = 0: lines inside the limits, 4 rows
    ("arm4dof", [H, 0.0, H, 0.0]),  # an S2-RR lock on a line: its in-limit middle
]


def _counted(rb, runs):
    """The finish's robot with its chain's representatives recorded in ``runs``."""
    def chain(mode, goal, free, rep):
        runs.append(rep)
        return rb.chain(mode, goal, free, rep)
    return dataclasses.replace(rb, chain=chain)


@pytest.mark.parametrize("name, q", QUICK)
def test_quick_lines_give_the_full_loops_rows_with_few_chain_runs(name, q, monkeypatch):
    module, _, chain = _compiled(name)
    T = module.fk(np.array(q))
    free_cols = [module.JOINT_NAMES.index(f) for f in module.FREE_JOINTS]
    free = tuple(float(q[c]) for c in free_cols)
    goal = fast.goal_entries(T, module.TARGET)
    rb = _spec_robot(module)
    runs = []
    quick = settle.settle(_counted(rb, runs), goal, free, True)
    assert quick != settle.PYTHON and len(runs) <= 4, (name, q, runs)
    found = chain.one(T, free, True)  # the C port: the same rows
    assert found is not None and len(found[0]) == len(quick)
    for k, (sq, sres, sls, scont) in enumerate(quick):
        assert np.array_equal(found[0][k], np.array(sq)) and found[1][k] == sres
        assert (bool(found[2][k]), bool(found[3][k])) == (sls, scont)
    monkeypatch.setattr(settle, "quick_lines", lambda *args: None)  # the full loop, every representative
    runs.clear()
    full = settle.settle(_counted(rb, runs), goal, free, True)
    assert len(runs) >= settle.REPS, runs
    assert repr(full) == repr(quick), (name, q, full, quick)


def test_rank_pre_test_never_passes_where_the_eigenvalues_fail():
    """rank_clear (a Cholesky factor of J^T J compressed across the line, less twice the floor) implies
    the second smallest singular value at least LINE_RANK (Courant-Fischer), on random and special
    configurations and random integer slopes; both outcomes occur."""
    rng = np.random.default_rng(3)
    cleared = refused = 0
    for name in ("panda", "puma560", "stanford", "prob", "arm4dof"):
        module, _, _ = _compiled(name)
        rb = _spec_robot(module)
        rev = [k == "R" for k in module.JOINT_TYPES]
        for i in range(120):
            drawn = rng.uniform(-P, P, rb.dof) if i % 2 else rng.choice([0.0, H, -H, P], rb.dof)
            q = [float(x) for x in drawn]
            s = [float(rng.integers(-2, 3)) if r else 0.0 for r in rev]
            if not any(s):
                continue
            if settle.rank_clear(rb, q, s):
                cleared += 1
                assert settle.two_weakest(rb, q)[1] >= settle.LINE_RANK, (name, q, s)
            else:
                refused += 1
    assert cleared > 0 and refused > 0, (cleared, refused)
