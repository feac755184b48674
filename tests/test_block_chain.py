"""The block chain of a batch (4 poses a call, docs/design.md section 14, "SIMD over poses") against the
scalar driver it stands in for.

With libm's angles in the lanes (``IKC_LIBMVEC=0``) the block path must return what ``ikc_solve_many``
returns, bit for bit: every value of a lane is the scalar IEEE operation, and a lane the scalar path
would treat specially goes to it whole; a lane mixed up with another, a slot or a flag lost, a pose
count that is not a multiple of 4, an invalid target inside a block, all show as a difference.  With
libmvec's angles (the default on AVX2) the rows are the scalar path's as sets to 1e-12 rad, the same
exact / least-squares / self-motion marks, and every exact row reproduces its target through the
module's FK to the contract's precision.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from ikcompiler import compile_robot, load_robot
from ikcompiler.codegen import csource
from ikcompiler.verify import sample_configurations
from subproblems import native

pytestmark = pytest.mark.skipif(native.compiler() is None, reason="no C compiler")

BLOCK_ROBOTS = ("puma560", "ur5", "kr6_r700", "prob")  # the zoo chains with a lane form (Pieper, UR-type)
ROW_SAME = 1e-12  # rad: the brief's bound for rows of the two paths

_MODULES: dict[str, tuple] = {}


def _module(name):
    """(module, robot), compiled once per session."""
    if name not in _MODULES:
        robot = load_robot(name)
        _MODULES[name] = (compile_robot(robot), robot)
    return _MODULES[name]


def _chains(name, monkeypatch, libmvec: bool):
    """(module, a NativeChain bound to a block chain built with or without libmvec)."""
    module, _ = _module(name)
    monkeypatch.delenv("IKC_NATIVE", raising=False)
    monkeypatch.setenv("IKC_LIBMVEC", "1" if libmvec else "0")
    source = csource.native_source(vars(module))
    r = module._SOLVER.robot
    nc = native.bind(source, dof=len(r.joint_names), slots=r.slots, nfree=0, target=r.target)
    assert nc is not None and nc.bind_block(lambda: csource.block_c_source(vars(module)))
    return module, nc


def _targets(name, n=403, seed=5):
    """Sampled poses (30% of the joint values at 0, +-pi/2, pi), every joint vector of a grid over
    {0, +-pi/2, pi} on the first three joints and the last three, and two invalid targets inside a
    block; n sampled (not a multiple of 4: a partial block at the end)."""
    module, robot = _module(name)
    Q = sample_configurations(robot, n, seed=seed, special=0.3)
    special = [0.0, math.pi / 2, -math.pi / 2, math.pi]
    grid = [list(a) + list(b) for a in itertools.product(special, repeat=3)
            for b in [(0.0, 0.0, 0.0), (0.3, math.pi / 2, -0.7), (math.pi, -math.pi / 2, 0.0)]]
    Ts = [module.fk(q) for q in Q] + [module.fk(np.array(q)) for q in grid]
    bad = np.eye(4)
    bad[0, 0] = np.nan
    skew = np.eye(4)
    skew[0, 1] = 0.5
    Ts[5], Ts[6] = bad, skew
    return np.array(Ts)


def _both(nc, Ts, monkeypatch, workers=1, limits=True):
    free = np.zeros((len(Ts), 0))
    monkeypatch.setenv("IKC_BLOCK", "0")
    scalar = nc.many(Ts, free, limits, workers)
    monkeypatch.setenv("IKC_BLOCK", "1")
    block = nc.many(Ts, free, limits, workers)
    return scalar, block


@pytest.mark.parametrize("name", BLOCK_ROBOTS)
def test_block_path_with_libm_angles_is_the_scalar_path_bit_for_bit(name, monkeypatch):
    module, nc = _chains(name, monkeypatch, libmvec=False)
    Ts = _targets(name)
    for workers, limits in ((1, True), (2, True), (1, False)):
        ((Q0, v0, ls0, r0, c0), k0), ((Q1, v1, ls1, r1, c1), k1) = _both(nc, Ts, monkeypatch, workers, limits)
        assert np.array_equal(k0, k1)
        assert (k0 > 0).sum() > 0.9 * len(Ts) - 2 and (k0 == native.INVALID).sum() == 2
        for a, b in ((Q0, Q1), (v0, v1), (ls0, ls1), (r0, r1), (c0, c1)):
            assert np.array_equal(a, b)


def _row_distance(A, B):
    d = np.abs(A[:, None, :] - B[None, :, :]) % (2 * np.pi)
    return np.minimum(d, 2 * np.pi - d).max(axis=2)


@pytest.mark.parametrize("name", BLOCK_ROBOTS)
def test_block_path_with_libmvec_angles_gives_the_scalar_rows(name, monkeypatch):
    if "-mavx2" not in native.machine_flags():
        pytest.skip("libmvec's AVX2 variants need an AVX2 build")
    module, nc = _chains(name, monkeypatch, libmvec=True)
    Ts = _targets(name, seed=11)
    ((Q0, v0, ls0, r0, c0), k0), ((Q1, v1, ls1, r1, c1), k1) = _both(nc, Ts, monkeypatch)
    assert np.array_equal(k0, k1)
    tol = module.TOLERANCE * module.SCALE
    for p in np.nonzero(k0 > 0)[0]:
        A, B = Q0[p][v0[p]], Q1[p][v1[p]]
        d = _row_distance(A, B)
        match = d.argmin(axis=1)
        assert d.min(axis=1).max() <= ROW_SAME and d.min(axis=0).max() <= ROW_SAME, p
        assert np.array_equal(ls0[p][v0[p]], ls1[p][v1[p]][match])
        assert np.array_equal(c0[p][v0[p]], c1[p][v1[p]][match])
        for row, inexact in zip(B, ls1[p][v1[p]]):
            if not inexact:  # an exact row of the block path reproduces its target through our FK
                assert np.abs(module.fk(row) - Ts[p]).max() <= tol


def test_block_chain_is_built_on_the_first_batch_only():
    module = compile_robot(load_robot("puma560"))
    nc = module._native_chain()
    assert nc is not None and nc.block_build_ms is None
    module.solve(module.fk(np.full(6, 0.3)))
    assert nc.block_build_ms is None  # a single pose builds no block chain
    module.solve_batch(np.array([module.fk(np.full(6, 0.3))] * 3))
    assert nc.block_build_ms is not None and nc._block is not None


def test_chains_without_a_lane_form_have_no_block_source():
    for name, kw in (("jaco", {}), ("panda", {"free": ("panda_joint7",)})):
        module = compile_robot(load_robot(name), **kw)
        assert csource.block_c_source(vars(module)) is None, name


def _lane_leaves(nc, goals):
    """The block chain's leaves of 4 goals (12 entries each): Q (leaves, 4, dof), E, F (leaves, 4)."""
    import ctypes

    dof, leaves = nc.dof, nc.slots * 4  # more leaf rows than any chain writes
    G = np.ascontiguousarray(np.array(goals, dtype=float).T)  # entry i of lane l at G[4 i + l]
    Q, E = np.zeros((leaves, dof, 4)), np.zeros((leaves, 4))
    F = np.zeros((leaves, 4), dtype=np.int64)
    fn = nc._block_lib.ikc_block_leaves
    fn.argtypes, fn.restype = [ctypes.c_void_p] * 4, ctypes.c_int
    n = fn(G.ctypes.data, Q.ctypes.data, E.ctypes.data, F.ctypes.data)
    return Q[:n].transpose(0, 2, 1), E[:n], F[:n]


@pytest.mark.parametrize("libmvec", [False, True])
def test_a_wrist_lock_is_settled_in_the_lanes_with_the_scalar_chains_leaves(libmvec, monkeypatch):
    """ur5 with q5 = 0 (its O-RRR in a gimbal lock, a self-motion of q4 + q6): the lane takes the scalar
    kernel's lock values (lane_kernels.h ikc_v_rot_rrr_lane), flagged FAMILY, not irregular, so such a
    pose is settled by the finish from the lanes' leaves (fast_finish.h ikc_block_pose).  With libm's
    angles every leaf is the scalar chain's bit for bit, flags too; with libmvec's the flags are, and
    the values agree to a few ulps.  Fails on a lane mixed up, a lock value or flag lost, or a lock lane
    handed to the scalar chain."""
    from subproblems import fast

    if libmvec and "-mavx2" not in native.machine_flags():
        pytest.skip("libmvec's AVX2 variants need an AVX2 build")
    module, nc = _chains("ur5", monkeypatch, libmvec=libmvec)
    _, robot = _module("ur5")
    Q = sample_configurations(robot, 16, seed=3, special=0.0)
    Q[:, 4] = 0.0
    locks = 0
    for block in range(0, len(Q), 4):
        goals = [fast.goal_entries(module.fk(q), "pose") for q in Q[block:block + 4]]
        LQ, LE, LF = _lane_leaves(nc, goals)
        for lane, goal in enumerate(goals):
            scalar = module._fast_chain(fast.SCALAR, goal, (), 0.0)
            assert len(scalar) == len(LQ)
            for k, leaf in enumerate(scalar):
                flags = int(LF[k, lane])
                assert not flags & 256, (block, lane, k)  # lane_kernels.h IKC_IRREGULAR
                assert flags == leaf[-1], (block, lane, k, flags, leaf[-1])
                locks += bool(flags & fast.FAMILY)
                if libmvec:
                    assert np.allclose(LQ[k, lane], leaf[:-2], rtol=0, atol=1e-13)
                else:
                    assert np.array_equal(LQ[k, lane], np.array(leaf[:-2])) and LE[k, lane] == leaf[-2]
    assert locks >= 16, locks  # every pose has its lock leaves


def test_tangent_lanes_run_again_with_libm_angles_and_give_the_scalar_rows(monkeypatch):
    """A lane with a tangent root (or a near miss) under libmvec's angles is flagged IKC_LANE_AGAIN
    (512) and runs the block chain again with libm's angles, 4 such lanes a call (lane_kernels.h,
    fast_finish.h ikc_run_block); those leaves are the scalar chain's, so the rows of such poses are
    the scalar path's bit for bit.  Fails where such a lane goes to the finish from libmvec's leaves
    (rows moved by Newton at the double root), where the flag is lost, or where a gathered lane is mixed
    up with another (measured: a gathered pose's index swapped fails this and the libmvec tests above)."""
    from subproblems import fast

    if "-mavx2" not in native.machine_flags():
        pytest.skip("libmvec's AVX2 variants need an AVX2 build")
    module, nc = _chains("ur5", monkeypatch, libmvec=True)
    _, robot = _module("ur5")
    Q = sample_configurations(robot, 600, seed=17, special=0.5)
    Ts, goals = [], []
    for q in Q:
        T = module.fk(q)
        goal = fast.goal_entries(T, "pose")
        leaves = module._fast_chain(fast.SCALAR, goal, (), 0.0)
        flags = [leaf[-1] for leaf in leaves]
        if any(f & fast.TANGENT_ROOT for f in flags) and not any(f & ~fast.TANGENT_ROOT for f in flags):
            Ts.append(T)
            goals.append(goal)
    assert len(Ts) >= 9, len(Ts)  # more than two calls' worth, and a partial one
    Ts, goals = Ts[:9], goals[:9]
    again = 0
    for block in range(0, 8, 4):
        _, _, LF = _lane_leaves(nc, goals[block:block + 4])
        again += int(((LF & 512) != 0).any(axis=0).sum())
    assert again == 8, again
    ((Q0, v0, ls0, r0, c0), k0), ((Q1, v1, ls1, r1, c1), k1) = _both(nc, np.array(Ts), monkeypatch)
    assert np.array_equal(k0, k1) and (k0 > 0).all()
    for a, b in ((Q0, Q1), (v0, v1), (ls0, ls1), (r0, r1), (c0, c1)):
        assert np.array_equal(a, b)


def _imported(nc):
    """The names the block chain's library imports (nm -D, the version suffixes left off)."""
    import subprocess

    out = subprocess.run(["nm", "-D", "--undefined-only", nc._block_lib._name], capture_output=True,
                         text=True, check=True).stdout
    return {word.split("@")[0] for word in out.split()}


def test_cos_and_sin_of_a_chain_value_come_from_libmvec_with_its_angles(monkeypatch):
    """ur5's q4 is a difference of the lanes' angles (libmvec's, a few ulps from libm's), so its cos and
    sin come from libmvec's AVX2 variants too, 4 lanes a call (lane_kernels.h ikc_v_cos / ikc_v_sin;
    libm's in ikc_block_libm's run, whose lanes must be the scalar chain's, which
    test_tangent_lanes_run_again_with_libm_angles_and_give_the_scalar_rows holds).  Fails where the
    block chain built with libmvec takes them from libm lane by lane (the sincos calls of before:
    ~1.6k of ur5's 14.3k instructions a pose)."""
    import shutil

    if "-mavx2" not in native.machine_flags():
        pytest.skip("libmvec's AVX2 variants need an AVX2 build")
    if shutil.which("nm") is None:
        pytest.skip("no nm to list the block chain's symbols")
    _, nc = _chains("ur5", monkeypatch, libmvec=True)
    listed = _imported(nc)
    assert "_ZGVdN4vv_atan2" in listed  # built with libmvec at all
    assert "_ZGVdN4v_cos" in listed and "_ZGVdN4v_sin" in listed, listed
    _, nc = _chains("ur5", monkeypatch, libmvec=False)  # libm's lane by lane without libmvec
    listed = _imported(nc)
    assert "_ZGVdN4v_cos" not in listed and "_ZGVdN4v_sin" not in listed
