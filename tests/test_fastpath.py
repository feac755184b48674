"""The generated fast path (straight-line arithmetic, floats and arrays) against the reference runtime.

Every zoo robot whose plan the fast path covers must give the same solution sets as the reference
runtime (``FAST_PATH = False``) on random poses with special angles, single and batched; targets the
fast path defers (near a degenerate geometry) are solved by the reference runtime inside the same call.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ikcompiler import compile_robot, load_robot
from ikcompiler.inputs.zoo import zoo_names
from ikcompiler.verify import sample_configurations

FREE = {"panda": ("panda_joint7",)}
COVERED = {  # zoo robots whose plans the fast path covers; the others must say FAST_PATH = False
    "arm4dof", "cylindrical", "gantry", "grasp4dof", "kr6_r700", "panda", "prob", "puma560", "rhino", "scara",
    "shadow_index", "shadow_thumb", "stanford", "ur5",
}  # jaco: the general 6R elimination (METHOD general-6r), solved by subproblems.general6, no fast chain
SEARCH = {"jaco"}  # compiled with the general 6R solver switched off: a search plan, on the fast chain
POSES = 60
SPLIT = 1e-4  # two copies of one tangent root can stay this far apart and both pass the pose check


def _set_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance from a row of ``a`` to its nearest row of ``b`` (angles modulo 2 pi)."""
    if len(a) == 0:
        return 0.0
    if len(b) == 0:
        return math.inf
    d = np.abs(a[:, None, :] - b[None, :, :])
    d = np.minimum(d, np.abs(d - 2 * math.pi))
    return float(d.max(axis=2).min(axis=1).max())


@pytest.fixture(scope="module", params=sorted(zoo_names()))
def robot(request):
    name = request.param
    module = compile_robot(name, free=FREE.get(name, ()))
    yield name, module, load_robot(name)
    module.FAST_PATH = module._fast_chain is not None


def test_fast_path_coverage(robot):
    name, module, _ = robot
    assert module.FAST_PATH == (name in COVERED), f"{name}: fast path {module.FAST_PATH}"


def _poses(module, chain):
    Q = sample_configurations(chain, POSES, seed=7, special=0.3)
    Ts = np.array([module.fk(q) for q in Q])
    free = [Q[:, module.JOINT_NAMES.index(f)] for f in module.FREE_JOINTS]
    return Q, Ts, free


@pytest.mark.parametrize("name", sorted(COVERED - SEARCH))
def test_scalar_fast_path_matches_reference(name):
    module, chain = compile_robot(name, free=FREE.get(name, ())), load_robot(name)
    assert module.FAST_PATH
    _, Ts, free = _poses(module, chain)
    for k, T in enumerate(Ts):
        fr = [f[k] for f in free]
        fast, _, fast_ls, fast_cont = module.solve_info(T, *fr)[:4]
        module.FAST_PATH = False
        ref, _, ref_ls, ref_cont = module.solve_info(T, *fr)[:4]
        module.FAST_PATH = True
        fast, ref = fast[~fast_ls], ref[~ref_ls]
        if fast_cont.any() or ref_cont.any():
            # a self-motion: each path returns its own representative of the family; both must be exact
            assert len(fast) or not len(ref), (name, k, ref)
            for row in fast:
                assert np.abs(module.fk(row) - T).max() <= 1e-8 * max(1.0, module.SCALE), (name, k, row)
            continue
        assert _set_distance(fast, ref) <= SPLIT and _set_distance(ref, fast) <= SPLIT, (name, k, fast, ref)


def test_batch_fast_path_matches_scalar_and_reference(robot):
    name, module, chain = robot
    _, Ts, free = _poses(module, chain)
    Q, valid, ls, _, cont = module.solve_batch_info(Ts, *free)
    module.FAST_PATH = False
    Qr, valid_r, ls_r, _, cont_r = module.solve_batch_info(Ts, *free)
    module.FAST_PATH = module._fast_chain is not None
    valid, valid_r = valid & ~ls, valid_r & ~ls_r
    for k, T in enumerate(Ts):
        single = module.solve(T, *[f[k] for f in free])
        assert len(single) == valid[k].sum(), (name, k)
        # numpy's and libm's sin/cos can differ in the last bit, which may pick the other copy of a
        # tangent root (the copies lie within SPLIT); elsewhere the two paths agree to roundoff
        assert _set_distance(Q[k][valid[k]], single) <= SPLIT, (name, k)
        assert _set_distance(single, Q[k][valid[k]]) <= SPLIT, (name, k)
        if name in SEARCH or cont[k].any() or cont_r[k].any():
            continue  # search: compared by recovery below; self-motion: representatives differ
        # the same solutions both ways; counts may differ only by split copies of a tangent root,
        # which the reference runtime can leave ~1e-5 apart (both pass the pose check)
        fast, ref = Q[k][valid[k]], Qr[k][valid_r[k]]
        assert _set_distance(ref, fast) <= SPLIT and _set_distance(fast, ref) <= SPLIT, (name, k, fast, ref)


def test_fast_solutions_round_trip(robot):
    name, module, chain = robot
    _, Ts, free = _poses(module, chain)
    q, res, ls, _ = module.solve_info(Ts[0], *[f[0] for f in free])[:4]
    for row, r, flag in zip(q, res, ls):
        err = np.abs(module.fk(row) - Ts[0]).max()
        if not flag:
            assert err <= 1e-9 * max(1.0, module.SCALE) * 4, (name, row, err)
        assert r >= 0.0 and np.isfinite(r)


@pytest.mark.parametrize("name", sorted(SEARCH))
def test_search_on_the_fast_chain_recovers_as_the_reference(name, monkeypatch):
    """A search plan grids its searched joints through the fast chain: on generic poses it must find
    the sampled joint vector about as often as the reference runtime, and return nothing wrong."""
    from ikcompiler import compiler

    monkeypatch.setattr(compiler, "USE_GENERAL6", False)
    module, chain = compile_robot(name), load_robot(name)
    assert module.METHOD == "1d-search", module.METHOD
    Q = sample_configurations(chain, 80, seed=4, special=0.0)
    Ts = np.array([module.fk(q) for q in Q])
    recovered = {}
    for fast in (True, False):
        module.FAST_PATH = fast
        S, V = module.solve_batch(Ts)
        hits = 0
        for k in range(len(Q)):
            for row in S[k][V[k]]:
                assert np.abs(module.fk(row) - Ts[k]).max() <= 1e-8 * module.SCALE, (name, k, row)
            hits += _set_distance(Q[k][None], S[k][V[k]]) <= 1e-6
        recovered[fast] = hits
    module.FAST_PATH = True
    assert recovered[True] >= recovered[False] - 2 and recovered[True] >= 0.95 * len(Q), recovered


GENERAL_STEPS = {  # arms whose closed form has a general step (found by fuzzing): S2-RRR's kernel (point_rrr,
    # the regular case), S2-TRR's reference solver inside the fast chain
    "S2-RRR": ("RRRRRR", [(0.1, -math.pi / 2, 0.1), (0.1, -math.pi / 2, 0.25), (0.25, math.pi / 3, 0.0),
                          (0.0, math.pi / 2, 0.4), (0.0, math.pi / 3, 0.0), (0.1, 0.0, 0.25)]),
    "S2-TRR": ("TRRRRR", [(0.0, math.pi / 2, 0.25), (0.25, -math.pi / 2, 0.4), (0.0, math.pi / 3, 0.4),
                          (0.0, math.pi / 2, 0.4), (0.0, math.pi / 3, 0.0), (0.0, 0.0, 0.0)]),
}


GENERAL_CALLS = {"S2-RRR": "_fk.point_rrr(", "S2-TRR": "_fk.reference("}


@pytest.mark.parametrize("code", sorted(GENERAL_STEPS))
def test_general_solver_inside_the_fast_chain(code):
    """A general step runs its kernel (S2-RRR: ``fast.point_rrr``, deferring its degenerate cases) or,
    without one, its reference solver inside the fast chain (``fast.reference``): the same solutions as
    the reference runtime, single and batch, and every one exact."""
    from tests.test_compiler_generality import _dh_chain

    kinds, rows = GENERAL_STEPS[code]
    chain = _dh_chain(rows, kinds)
    module = compile_robot(chain)
    assert module.FAST_PATH and code in module.PLAN and GENERAL_CALLS[code] in module.__source__
    Q = sample_configurations(chain, 25, seed=3, special=0.2)
    Ts = np.array([module.fk(q) for q in Q])
    S, V, L, _, C = module.solve_batch_info(Ts)
    module.FAST_PATH = False
    Sr, Vr, Lr, _, Cr = module.solve_batch_info(Ts)
    module.FAST_PATH = True
    for k, T in enumerate(Ts):
        fast, ref = S[k][V[k] & ~L[k]], Sr[k][Vr[k] & ~Lr[k]]
        for row in fast:
            assert np.abs(module.fk(row) - T).max() <= 1e-8 * max(1.0, module.SCALE), (code, k, row)
        if C[k].any() or Cr[k].any():
            continue
        assert _set_distance(fast, ref) <= SPLIT and _set_distance(ref, fast) <= SPLIT, (code, k, fast, ref)
        single = module.solve(T)
        assert _set_distance(single, fast) <= SPLIT and _set_distance(fast, single) <= SPLIT, (code, k)
