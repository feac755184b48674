"""The native backend (the fast chain in C, ``subproblems.native``) against the Python fast path.

Every closed-form zoo robot has its chain in C (``NATIVE``; printed from the module's data by
``ikcompiler.codegen.csource.native_source``): its raw leaves must equal the
Python chain's, its solution sets those of the Python path (``NATIVE = False``), single and batched,
with and without threads; free joints keep their given values; bad input raises the Python path's
errors; without a compiler (or with ``IKC_NATIVE=0``) the module falls back to the Python path.
"""

from __future__ import annotations

import math
import shutil

from pathlib import Path

import numpy as np
import pytest

from ikcompiler import compile_robot, load_robot
from ikcompiler import compiler as compiler_policy
from ikcompiler.codegen import csource
from ikcompiler.inputs.zoo import zoo_names
from ikcompiler.verify import _same, sample_configurations
from subproblems import fast, native
from tests.test_fastpath import FREE, _set_distance

pytestmark = pytest.mark.skipif(native.compiler() is None, reason="no C compiler")

GENERAL6_NATIVE = {"jaco"}  # general-6r: the C elimination (general6.h; tests/test_general6_native.py)
NATIVE_ROBOTS = {  # zoo robots whose modules carry their fast chain in C
    "arm4dof", "cylindrical", "gantry", "grasp4dof", "kr6_r700", "panda", "prob", "puma560", "rhino", "scara",
    "shadow_index", "shadow_thumb", "stanford", "ur5",
}
CALIBRATED = "ur5 calibrated"  # a snapped plan: the chain on the snapped robot, Newton steps on the true one
ROBOTS = sorted(NATIVE_ROBOTS) + [CALIBRATED]
SAME = 1e-6  # solution sets agree to this (angles modulo 2 pi)

_CACHE: dict[tuple, tuple] = {}
_HAS_C: dict[int, bool] = {}  # id(module) -> NATIVE as compiled (tests switch it off and back)


def _compiled(name, **kw):
    """(module, chain, NativeChain or None), compiled once per test session and robot."""
    key = (name, tuple(sorted(kw.items())))
    if key not in _CACHE:
        kw.setdefault("free", FREE.get(name, ()))
        if name == CALIBRATED:
            from tests.test_compiler_generality import _calibrated

            robot = _calibrated(load_robot("ur5"), 1e-4)
        else:
            robot = load_robot(name)
        with pytest.MonkeyPatch.context() as mp:  # the snapped plan, not the policy's elimination
            mp.setattr(compiler_policy, "SNAP_GENERAL", math.inf)
            module = compile_robot(robot, **kw)
        _HAS_C[id(module)] = module.NATIVE
        with pytest.MonkeyPatch.context() as mp:  # a developer's IKC_NATIVE=0 must not hide the backend
            mp.delenv("IKC_NATIVE", raising=False)
            chain = module._native_chain()
        _CACHE[key] = (module, robot, chain)
    module, robot, chain = _CACHE[key]
    module.FAST_PATH, module.NATIVE = True, _HAS_C[id(module)]
    return module, robot, chain


def _poses(module, chain, n, seed, special=0.3):
    Q = sample_configurations(chain, n, seed=seed, special=special)
    Ts = np.array([module.fk(q) for q in Q])
    free = [Q[:, module.JOINT_NAMES.index(f)] for f in module.FREE_JOINTS]
    return Q, Ts, free


def _python(module, fn, *args, **kw):
    """``fn(*args)`` with the native backend switched off."""
    module.NATIVE = False
    try:
        return fn(*args, **kw)
    finally:
        module.NATIVE = _HAS_C[id(module)]


def _exact_round_trip(module, rows, T, what):
    for row in rows:
        err = np.abs(module.fk(row) - T).max()
        assert err <= 1e-8 * max(1.0, module.SCALE), (what, row, err)


# --- which modules carry C -----------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(zoo_names()))
def test_native_coverage(name):
    module, _, chain = _compiled(name)
    has = csource.native_source(vars(module)) is not None
    assert has == (name in NATIVE_ROBOTS | GENERAL6_NATIVE), f"{name}: C chain {has}"
    assert module.NATIVE == has
    assert (chain is not None) == has, native.last_error


# --- 1. raw leaves: C against the Python chain ---------------------------------------------------------


def _random_rotation(rng):
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _leaf_goals(module, chain):
    """(T, free) pairs: FK poses with special angles, then raw goals (out of reach, on the base axis,
    near the base: least-squares leaves and deferred degenerate ones) with special and NaN free values.
    A search plan's chain takes the searched joints' values after the free ones: the sampled value or
    a grid value."""
    Q, Ts, free = _poses(module, chain, 100, seed=11)
    searched = [Q[:, j] for j in module._SEARCH]
    grid = np.linspace(-np.pi, np.pi, max(module._GRID, 1), endpoint=False)
    out = [(T, tuple(float(f[k]) for f in free) + tuple(float(s[k] if k % 2 else grid[k % len(grid)])
                                                        for s in searched)) for k, T in enumerate(Ts)]
    rng = np.random.default_rng(3)
    for k in range(30):
        T = np.eye(4)
        T[:3, :3] = _random_rotation(rng)
        T[:3, 3] = rng.normal(size=3) * module.SCALE * (0.05, 0.5, 1.5)[k % 3]
        if k % 4 == 0:
            T[:2, 3] = 0.0
        fr = (math.nan if k % 10 == 9 else (0.0, math.pi / 2, 0.3)[k % 3],) * len(module.FREE_JOINTS)
        fr += tuple(float(grid[(7 * k) % len(grid)]) for _ in module._SEARCH)
        out.append((T, fr))
    return out


@pytest.mark.parametrize("name", ROBOTS)
def test_c_leaves_equal_python_leaves(name):
    module, chain, nc = _compiled(name)
    dof, errors = len(module.JOINT_NAMES), []
    for k, (T, fr) in enumerate(_leaf_goals(module, chain)):
        goal = fast.goal_entries(T, module.TARGET)
        leaves = module._fast_chain(fast.SCALAR, goal, fr)
        L, spare = len(leaves), 4  # spare rows: the C must not write past the Python leaf count
        Qc = np.full((L + spare, dof), -7.0)
        Ec = np.full(L + spare, -7.0)
        Fc = np.full(L + spare, -7, dtype=np.int32)
        g, f = np.array(goal, dtype=float), np.array(fr or (0.0,), dtype=float)
        n = nc.leaves_fn(g.ctypes.data, f.ctypes.data, Qc.ctypes.data, Ec.ctypes.data, Fc.ctypes.data)
        assert n == L, (name, k, n, L)
        assert (Qc[L:] == -7.0).all() and (Ec[L:] == -7.0).all() and (Fc[L:] == -7).all(), (name, k)
        Qp = np.array([leaf[:dof] for leaf in leaves], dtype=float).reshape(L, dof)
        Ep = np.array([leaf[dof] for leaf in leaves], dtype=float)
        Fp = np.array([int(leaf[dof + 1]) for leaf in leaves], dtype=np.int32)
        errors.extend(Ep.tolist())
        assert np.array_equal(Fp, Fc[:L]), (name, k, Fp, Fc[:L])
        for py, c in ((Qp, Qc[:L]), (Ep, Ec[:L])):
            assert np.array_equal(np.isnan(py), np.isnan(c)), (name, k, py, c)
            ok = ~np.isnan(py)
            assert (np.abs(py[ok] - c[ok]) <= 1e-12 * np.maximum(1.0, np.abs(py[ok]))).all(), (name, k, py, c)
    exact = (np.array(errors) <= module.TOLERANCE * module.SCALE).sum()
    assert exact >= (40 if module._SEARCH else 100), name  # the FK poses are reached (searched joints:
    # at their sampled values only)


# --- 2. solution sets: native against the Python path --------------------------------------------------


@pytest.mark.parametrize("name", ROBOTS)
def test_batch_native_matches_python_and_is_complete(name):
    module, chain, nc = _compiled(name)
    Q, Ts, free = _poses(module, chain, 200, seed=5)
    kinds, scale = list(module.JOINT_TYPES), max(1.0, module.SCALE)
    # the C settles most targets itself (the Python path takes the deferred ones)
    fr = np.stack(free, axis=1) if free else np.zeros((len(Ts), 0))
    _, code = nc.many(Ts, fr, True)
    assert not (code == native.INVALID).any(), name
    # a calibrated robot also hands over the targets whose correction is not certain (a near-singular
    # corrected leaf, a collision, a near-miss leaf: subproblems.continuation, docs/calibrated.md)
    handed = 0.35 if name == CALIBRATED else 0.2
    assert (code == native.PYTHON).mean() <= handed, (name, (code == native.PYTHON).mean())
    continuum = np.zeros(len(Ts), dtype=bool)  # a self-motion, inside the limits or not
    missed = 0
    for limits in (False, True):
        S, V, L, _, C = module.solve_batch_info(Ts, *free, limits=limits)
        Sp, Vp, Lp, _, Cp = _python(module, module.solve_batch_info, Ts, *free, limits=limits)
        continuum |= C.any(axis=1) | Cp.any(axis=1)
        for k, T in enumerate(Ts):
            mine, ref = S[k][V[k] & ~L[k]], Sp[k][Vp[k] & ~Lp[k]]
            if continuum[k]:  # each path returns its own representative of the family; both exact
                _exact_round_trip(module, mine, T, (name, k, limits))
                continue
            assert _set_distance(mine, ref) <= SAME and _set_distance(ref, mine) <= SAME, (name, k, mine, ref)
            if limits:  # completeness: the sampled vector (inside the limits) is found
                found = len(mine) and (_same(mine, Q[k], kinds) <= 1e-6 * scale).any()
                missed += not found
                assert found or module._SEARCH or name == CALIBRATED, (name, k, Q[k], mine)
    # a search seeds Newton steps from grid minima and a calibrated robot's Newton steps may slip to a
    # neighbour branch near a singularity (test_compiler_generality): most poses, as the Python path
    # the calibrated robot: measured 2 of 200 since the continuation (25% allowed before), both samples
    # at a near-self-motion of the snapped robot (docs/calibrated.md)
    assert missed <= (0.01 if name == CALIBRATED else 0.1) * len(Ts), (name, missed)


@pytest.mark.parametrize("name", ROBOTS)
def test_single_native_matches_python(name):
    module, chain, _ = _compiled(name)
    _, Ts, free = _poses(module, chain, 50, seed=9)
    for k, T in enumerate(Ts):
        fr = [f[k] for f in free]
        q, _, ls, cont = module.solve_info(T, *fr)[:4]
        qp, _, lsp, contp = _python(module, module.solve_info, T, *fr)[:4]
        mine, ref = q[~ls], qp[~lsp]
        assert _set_distance(module.solve(T, *fr), mine) == 0.0, (name, k)
        if cont.any() or contp.any():
            _exact_round_trip(module, mine, T, (name, k))
            continue
        assert _set_distance(mine, ref) <= SAME and _set_distance(ref, mine) <= SAME, (name, k, mine, ref)


# --- 3. threads --------------------------------------------------------------------------------------


def test_many_is_the_same_with_one_or_two_threads():
    module, chain, nc = _compiled("ur5")
    _, Ts, _ = _poses(module, chain, 2000, seed=21)
    for limits in (True, False):
        (one, code1), (two, code2) = (nc.many(Ts, np.zeros((len(Ts), 0)), limits, workers=w) for w in (1, 2))
        for a, b in zip(one + (code1,), two + (code2,)):
            assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
        assert one[1].sum() > len(Ts)  # solutions were found at all


# --- 4. free joints ----------------------------------------------------------------------------------

# panda with joint 4 where the S3-R distance of the plan's first step is largest (the elbow stretched):
# a tangent root; moving the target ~1e-6 (beyond reach half the time) makes near misses: Newton steps
ELBOW_STRETCHED = -0.4670023867321498


def _near_misses(module, chain, n=120):
    Q = sample_configurations(chain, n, seed=2, special=0.0)
    Q[:, 3] = ELBOW_STRETCHED
    Ts = np.array([module.fk(q) for q in Q])
    Ts[:, :3, 3] += np.random.default_rng(0).normal(size=(n, 3)) * 1e-6
    return Ts, Q[:, module.JOINT_NAMES.index("panda_joint7")]


def test_native_keeps_free_joints_on_sampled_poses():
    module, chain, nc = _compiled("panda")
    assert module.FREE_JOINTS == ("panda_joint7",)
    j = module.JOINT_NAMES.index("panda_joint7")
    Q, Ts, (fr,) = _poses(module, chain, 150, seed=4)
    for limits in (True, False):
        (S, V, *_), _ = nc.many(Ts, fr[:, None], limits)
        assert (S[:, :, j][V] == np.broadcast_to(fr[:, None], V.shape)[V]).all()
    for k in range(0, len(Ts), 5):
        q = module.solve(Ts[k], fr[k])
        assert len(q) and (q[:, j] == fr[k]).all(), (k, q[:, j], fr[k])


def test_native_newton_steps_hold_free_joints():
    module, chain, nc = _compiled("panda")
    j = module.JOINT_NAMES.index("panda_joint7")
    Ts, fr = _near_misses(module, chain)
    tol, near = module.TOLERANCE * module.SCALE, fast.NEAR_MISS * module.SCALE
    newton = [k for k, T in enumerate(Ts) if any(tol < leaf[-2] < near for leaf in
                                                 module._fast_chain(fast.SCALAR, fast.goal_entries(T, "pose"),
                                                                    (float(fr[k]),)))]
    assert len(newton) >= 20
    for limits in (True, False):
        (S, V, *_), code = nc.many(Ts, fr[:, None], limits)
        assert (code[newton] >= 0).all(), code[newton]  # the C finishes near misses itself
        assert (S[:, :, j][V] == np.broadcast_to(fr[:, None], V.shape)[V]).all()
        # every row the module returns (exact or least squares) keeps the given free value
        S, V, *_ = module.solve_batch_info(Ts, fr, limits=limits)
        assert (S[:, :, j][V] == np.broadcast_to(fr[:, None], V.shape)[V]).all()
    for k in newton[:20]:
        q, _, _, _ = module.solve_info(Ts[k], fr[k])[:4]
        assert (q[:, j] == fr[k]).all(), (k, q[:, j], fr[k])


def test_module_keeps_free_joints_exactly():
    """Sampled poses with many special angles: a few go through Newton steps (self-motions)."""
    module, chain, _ = _compiled("panda")
    j = module.JOINT_NAMES.index("panda_joint7")
    _, Ts, (fr,) = _poses(module, chain, 300, seed=1, special=0.6)
    S, V, *_ = module.solve_batch_info(Ts, fr)
    moved = [k for k in range(len(Ts)) if (S[k][V[k]][:, j] != fr[k]).any()]
    assert not moved, moved


# --- 5. bad input ------------------------------------------------------------------------------------


def _outcome(fn, *args, **kw):
    try:
        return "ok", fn(*args, **kw)
    except Exception as exc:  # noqa: BLE001 - the exception itself is what is compared
        return type(exc), str(exc)


def _same_outcome(module, fn, *args, what=None, **kw):
    mine, ref = _outcome(fn, *args, **kw), _python(module, _outcome, fn, *args, **kw)
    if mine[0] == "ok" and ref[0] == "ok":
        a, b = (np.asarray(x[0] if isinstance(x, tuple) else x) for x in (mine[1], ref[1]))
        # the same kind of answer; the rows themselves are compared by the solution-set tests (a good
        # target here can be a self-motion, where each path returns its own representatives)
        assert a.shape[1:] == b.shape[1:], (what, a, b)
        return None
    assert mine == ref, (what, mine, ref)
    return mine


def _bad_inputs(module):
    good = {"pose": np.eye(4), "orientation": np.eye(3), "position": np.array([0.1, 0.2, 0.3])}[module.TARGET]
    nan, skew = good.copy(), good.copy()
    nan.flat[1] = np.nan
    fr = (0.2,) * len(module.FREE_JOINTS)
    cases = {"nan": (nan, *fr), "inf": (np.where(good == 0, np.inf, good), *fr),
             "wrong shape": (np.eye(5), *fr), "vector": (np.ones(2), *fr), "scalar": (0.5, *fr),
             "ragged": ([[1.0, 0.0], [0.0]], *fr), "one free too many": (good, *fr, 0.1),
             "no free values": (good,), "free value NaN": (good, *(math.nan,) * len(fr))}
    if module.TARGET != "position":
        skew[0, 0] = 2.0
        flip = good.copy()
        flip[0, 0] = -1.0  # orthonormal, det -1
        cases.update({"not a rotation": (skew, *fr), "reflection": (flip, *fr)})
    if len(fr) > 1:
        cases["one free too few"] = (good, *fr[:-1])
        cases["a single free value"] = (good, fr[0])
    return cases


NAN_MATMUL = "ignore:invalid value encountered:RuntimeWarning"  # _targets multiplies before it checks


@pytest.mark.filterwarnings(NAN_MATMUL)
@pytest.mark.parametrize("name", ["panda", "ur5", "rhino"])
def test_bad_input_raises_the_python_paths_error(name):
    module, _, _ = _compiled(name)
    errors = 0
    for what, args in _bad_inputs(module).items():
        for fn in (module.solve, module.solve_info, module.solve_batch):
            got = _same_outcome(module, fn, *args, what=(what, fn.__name__))
            errors += got is not None and issubclass(got[0], ValueError)  # the modules' typed errors
    assert errors >= 15
    for T in (np.full((4, 4), np.nan), np.diag([2.0, 1.0, 1.0, 1.0])):
        with pytest.raises(ValueError, match="NaN|rotation"):
            module.solve(T, *(0.1,) * len(module.FREE_JOINTS))


REDUCED = [("ur5", "position", ("wrist_1_joint", "wrist_2_joint", "wrist_3_joint")),
           ("puma560", "orientation", ("j1", "j2", "j3"))]


@pytest.mark.filterwarnings(NAN_MATMUL)
@pytest.mark.parametrize(("name", "target", "free"), REDUCED)
def test_bad_input_on_reduced_targets(name, target, free):
    module, _, chain = _compiled(name, target=target, free=free)
    assert chain is not None
    for what, args in _bad_inputs(module).items():
        for fn in (module.solve, module.solve_info, module.solve_batch):
            _same_outcome(module, fn, *args, what=(what, fn.__name__))


# --- 6. fallback -------------------------------------------------------------------------------------


def _same_results(a, b, Ts):
    S, V, L, _, C = a.solve_batch_info(Ts)
    Sb, Vb, Lb, _, Cb = b.solve_batch_info(Ts)
    for k, T in enumerate(Ts):
        x, y = S[k][V[k] & ~L[k]], Sb[k][Vb[k] & ~Lb[k]]
        if C[k].any() or Cb[k].any():  # a self-motion: each path its own representatives, all exact
            _exact_round_trip(b, y, T, k)
            continue
        assert len(x) == len(y), (k, x, y)
        assert _set_distance(x, y) <= SAME and _set_distance(y, x) <= SAME, (k, x, y)


def test_ikc_native_0_falls_back_to_python(monkeypatch):
    module, chain, _ = _compiled("ur5")
    monkeypatch.setenv("IKC_NATIVE", "0")
    monkeypatch.setattr(native, "last_error", None)
    off = compile_robot("ur5")
    assert off.NATIVE and off._native_chain() is None
    assert "IKC_NATIVE" in native.last_error
    _, Ts, _ = _poses(module, chain, 60, seed=13)
    _same_results(module, off, Ts)


@pytest.mark.parametrize("cc", ["ikc-no-such-compiler", "false"])
def test_missing_or_failing_compiler_falls_back_to_python(cc, monkeypatch, tmp_path):
    if cc == "false" and shutil.which("false") is None:
        pytest.skip("no `false` command")
    module, chain, _ = _compiled("rhino")
    cache = tmp_path / "cache"
    monkeypatch.delenv("IKC_NATIVE", raising=False)
    monkeypatch.setenv("CC", cc)
    monkeypatch.setenv("IKC_CACHE", str(cache))
    monkeypatch.setattr(native, "_loaded", {})
    monkeypatch.setattr(native, "last_error", None)
    fresh = compile_robot("rhino")
    assert fresh._native_chain() is None
    if cc == "false":  # it runs and fails: the message names the compiler
        assert native.last_error.startswith("false failed"), native.last_error
    else:
        assert "C compiler" in native.last_error, native.last_error
    # nothing half-built left in the cache (the printed C text may be there: it is complete)
    assert not cache.exists() or all(p.name.startswith("ikc_src_") for p in cache.iterdir())
    _, Ts, _ = _poses(module, chain, 40, seed=17)
    _same_results(module, fresh, Ts)
    assert len(fresh.solve(Ts[0])) and fresh._native_chain() is None


def test_chains_share_one_finish_library(monkeypatch, tmp_path):
    """The split build (docs/design.md, section 14): the finish is built once into the cache, each
    chain alone against it, and a chain library names that finish library as its dependency."""
    monkeypatch.delenv("IKC_NATIVE", raising=False)
    monkeypatch.setenv("IKC_CACHE", str(tmp_path))
    monkeypatch.setattr(native, "_loaded", {})
    built = [compile_robot(name) for name in ("ur5", "puma560")]
    assert all(m._native_chain() is not None for m in built), native.last_error
    finish = sorted(tmp_path.glob("ikc_finish_*.so"))
    chains = sorted(p for p in tmp_path.glob("ikc_*.so") if p not in finish)
    assert len(finish) == 1 and len(chains) == 2, sorted(p.name for p in tmp_path.iterdir())
    for chain_lib in chains:
        assert str(finish[0]).encode() in chain_lib.read_bytes()


def test_one_piece_fallback_gives_the_split_builds_answers(monkeypatch, tmp_path):
    """Where the split build fails, the kernels, finish and chain are compiled as one file: same answers."""
    module, chain, split = _compiled("ur5")
    assert split is not None
    monkeypatch.delenv("IKC_NATIVE", raising=False)
    monkeypatch.setenv("IKC_CACHE", str(tmp_path))
    monkeypatch.setattr(native, "_loaded", {})
    monkeypatch.setattr(native, "_finish_library", lambda *args, **kw: None)  # as if the split build failed
    whole = compile_robot("ur5")
    assert whole._native_chain() is not None, native.last_error
    assert not list(tmp_path.glob("ikc_finish_*.so"))
    _, Ts, _ = _poses(module, chain, 60, seed=19)
    _same_results(module, whole, Ts)


def _rows_bit_for_bit(module, chain, a, b, seed):
    """``a``, ``b`` (NativeChain of one module's C) return the same rows bit for bit, limits on and off,
    on poses of which a third of the joint values are special (the alternative chain runs on some)."""
    _, Ts, _ = _poses(module, chain, 300, seed=seed, special=0.35)
    for limits in (True, False):
        x, y = a.many(Ts, np.zeros((len(Ts), 0)), limits), b.many(Ts, np.zeros((len(Ts), 0)), limits)
        for u, v in zip([*x[0], x[1]], [*y[0], y[1]]):
            assert np.array_equal(u, v, equal_nan=True)


@pytest.mark.parametrize("name", ["puma560", "ur5", "prob"])
def test_the_split_build_gives_the_rows_of_the_one_piece_build(name, monkeypatch, tmp_path):
    """The split build (the prelude precompiled, the out-of-line and the cold chain's kernels called in
    the finish library: docs/design.md section 14) and the one-piece build (every kernel compiled into
    the chain) return the same rows bit for bit."""
    module, chain, split = _compiled(name)
    assert split is not None
    source = csource.native_source(vars(module))
    monkeypatch.delenv("IKC_NATIVE", raising=False)
    monkeypatch.setenv("IKC_CACHE", str(tmp_path / "split"))
    shape = dict(dof=len(module.JOINT_TYPES), slots=module.MAX_SOLUTIONS, nfree=0, target="pose")
    monkeypatch.setattr(native, "_loaded", {})
    now = native.bind(source, **shape)
    assert now is not None, native.last_error
    assert list((tmp_path / "split").glob("ikc_prelude_*.h.gch")), "no precompiled prelude"
    called = {n for n in native.shared_kernels() if n.replace("ikc_", native.SHARED_PREFIX + "k_").encode()
              in Path(native.build(source)).read_bytes()}
    assert set(native.OUT_OF_LINE_KERNELS) <= called  # the chain calls the library's copies
    monkeypatch.setenv("IKC_CACHE", str(tmp_path / "whole"))
    monkeypatch.setattr(native, "_loaded", {})
    monkeypatch.setattr(native, "_finish_library", lambda *args, **kw: None)
    whole = native.bind(source, **shape)
    assert whole is not None, native.last_error
    _rows_bit_for_bit(module, chain, now, whole, seed=31)


@pytest.mark.parametrize("broken", ["garbage", "include_fails"])
def test_a_refused_precompiled_prelude_falls_back_to_the_plain_build(broken, monkeypatch, tmp_path):
    """A .gch the compiler refuses (here: not a .gch at all) is read from the header's text by GCC
    itself; a compile with ``-include`` that fails is retried on the whole text.  Either way the chain
    builds silently, with the rows of the precompiled build bit for bit."""
    module, chain, split = _compiled("puma560")
    assert split is not None
    source = csource.native_source(vars(module))
    monkeypatch.delenv("IKC_NATIVE", raising=False)
    shape = dict(dof=len(module.JOINT_TYPES), slots=module.MAX_SOLUTIONS, nfree=0, target="pose")
    monkeypatch.setenv("IKC_CACHE", str(tmp_path / "good"))
    monkeypatch.setattr(native, "_loaded", {})
    good = native.bind(source, **shape)
    assert good is not None, native.last_error
    bad_cache = tmp_path / "bad"
    monkeypatch.setenv("IKC_CACHE", str(bad_cache))
    monkeypatch.setattr(native, "_loaded", {})
    if broken == "garbage":
        real = native._precompiled

        def spoiled(cc, flags, prelude):
            header = real(cc, flags, prelude)
            header.with_name(header.name + ".gch").write_bytes(b"not a precompiled header")
            return header

        monkeypatch.setattr(native, "_precompiled", spoiled)
    else:
        bad_cache.mkdir()
        missing = bad_cache / "ikc_no_such_prelude.h"  # -include of a missing file: the compile fails
        monkeypatch.setattr(native, "_precompiled", lambda cc, flags, prelude: missing)
    monkeypatch.setattr(native, "last_error", None)
    plain = native.bind(source, **shape)
    assert plain is not None and native.last_error is None, native.last_error
    _rows_bit_for_bit(module, chain, good, plain, seed=37)


@pytest.mark.parametrize("name", ["puma560", "prob"])
def test_the_cold_alternative_chain_gives_the_answers_of_o2(name, monkeypatch, tmp_path):
    """The alternative chain is compiled as cold code (native.COLD: -O1 under GCC; docs/design.md
    section 14): the same C with it at -O2 gives the same rows bit for bit, on poses of which a sixth
    or more go through the alternative chain (puma560 49 and prob 74 of these 300, counted by hand)."""
    module, chain, split = _compiled(name)
    assert split is not None
    source = csource.native_source(vars(module))
    assert f"{native.COLD} static int ikc_chain_alt(" in source
    monkeypatch.delenv("IKC_NATIVE", raising=False)
    monkeypatch.setenv("IKC_CACHE", str(tmp_path))
    shape = dict(dof=len(module.JOINT_TYPES), slots=module.MAX_SOLUTIONS, nfree=0, target="pose")
    cold = native.bind(source, **shape)
    hot = native.bind(f"#define {native.COLD}\n" + source, **shape)  # the macro empty: -O2 throughout
    assert cold is not None and hot is not None, native.last_error
    _, Ts, _ = _poses(module, chain, 300, seed=23, special=0.6)
    for limits in (True, False):
        a, b = cold.many(Ts, np.zeros((len(Ts), 0)), limits), hot.many(Ts, np.zeros((len(Ts), 0)), limits)
        for x, y in zip([*a[0], a[1]], [*b[0], b[1]]):
            assert np.array_equal(x, y, equal_nan=True)


@pytest.mark.parametrize("name", ["puma560", "ur5", "prob"])
def test_the_build_flags_give_the_answers_of_plain_o2(name, monkeypatch, tmp_path):
    """The finish at -O3 and every build with the processor's flags (native.machine_flags: -mavx2 where
    the CPU has AVX2; docs/design.md section 14, "Compiler flags") give the rows of the plain -O2 build
    bit for bit, limits on and off, on poses of which a third of the joint values are special."""
    module, chain, split = _compiled(name)
    assert split is not None
    source = csource.native_source(vars(module))
    monkeypatch.delenv("IKC_NATIVE", raising=False)
    monkeypatch.setenv("IKC_CACHE", str(tmp_path))
    shape = dict(dof=len(module.JOINT_TYPES), slots=module.MAX_SOLUTIONS, nfree=0, target="pose")
    monkeypatch.setattr(native, "_loaded", {})
    now = native.bind(source, **shape)
    monkeypatch.setattr(native, "_loaded", {})
    monkeypatch.setattr(native, "FLAGS", ("-O2",) + native.FLAGS[1:])
    monkeypatch.setenv("IKC_SIMD", "0")
    plain = native.bind(source, **shape)
    assert now is not None and plain is not None, native.last_error
    assert len(list(tmp_path.glob("ikc_finish_*.so"))) == 2  # two finish libraries: the flags differ
    _, Ts, _ = _poses(module, chain, 400, seed=29, special=0.35)
    for limits in (True, False):
        a, b = now.many(Ts, np.zeros((len(Ts), 0)), limits), plain.many(Ts, np.zeros((len(Ts), 0)), limits)
        for x, y in zip([*a[0], a[1]], [*b[0], b[1]]):
            assert np.array_equal(x, y, equal_nan=True)


def test_machine_flags_are_the_processors_and_can_be_left_out(monkeypatch):
    monkeypatch.delenv("IKC_SIMD", raising=False)
    flags = native.machine_flags()
    assert flags in ((), ("-mavx2",))
    try:
        text = open("/proc/cpuinfo").read()
    except OSError:
        text = ""
    has_avx2 = any(line.startswith("flags") and "avx2" in line.split() for line in text.splitlines())
    assert (flags == ("-mavx2",)) == (has_avx2 and native.platform.machine().lower() in ("x86_64", "amd64"))
    monkeypatch.setenv("IKC_SIMD", "0")
    assert native.machine_flags() == ()


def test_a_compiler_refusing_the_machine_flags_builds_without_them(monkeypatch, tmp_path):
    """native.build retries without machine_flags when the compiler rejects them."""
    module, _, split = _compiled("puma560")
    assert split is not None
    monkeypatch.delenv("IKC_NATIVE", raising=False)
    monkeypatch.delenv("IKC_SIMD", raising=False)
    monkeypatch.setenv("IKC_CACHE", str(tmp_path))
    monkeypatch.setattr(native, "_loaded", {})
    monkeypatch.setattr(native, "_cpu_flags", lambda: ("-mno-such-flag-ikc",))
    path = native.build(csource.native_source(vars(module)))
    assert path is not None, native.last_error
    keys = {p.name for p in tmp_path.glob("ikc_*.so")}
    assert len(keys) == 2  # the finish and the chain, both built without the refused flag


# --- 7. the generated C --------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["panda", "rhino", "ur5"])
def test_native_source_is_deterministic(name):
    module, _, _ = _compiled(name)
    again = compile_robot(name, free=FREE.get(name, ()))
    first = csource.module_c_source(vars(module))  # printed anew each time (native_source caches)
    assert first is not None and csource.module_c_source(vars(again)) == first
    assert csource.native_source(vars(again)) == first


def test_native_source_lines_are_wrapped():
    modules = [_compiled(name)[0] for name in ROBOTS]
    modules += [_compiled(name, target=target, free=free)[0] for name, target, free in REDUCED]
    for module in modules:
        source = csource.native_source(vars(module))
        assert source, module.__name__
        long = [line for line in source.splitlines() if len(line) > 110]
        assert not long, (module.__name__, long[:3])


# --- 8. what the C finish settles beyond the Python fast path ------------------------------------------


def _exact_rows(module, T, found):
    q, residual, ls, continuum = found
    for row in q[~ls]:
        assert np.abs(module.fk(row) - T).max() <= module.TOLERANCE * max(1.0, module.SCALE), (row, T)
    return q[~ls], continuum[~ls]


def test_alternative_chain_settles_in_c():
    # arm4dof with the shoulder at 0 puts the elbow-wrist point on the waist axis: the chain's first
    # step (S2-RR waist, shoulder) defers, the Python fast path hands the pose to the reference runtime;
    # the C runs the plan's alternative chain and finds the sampled vector itself
    module, _, _ = _compiled("arm4dof")
    q = np.array([0.7009, 0.0, -1.6688, math.pi])
    T = module.fk(q)
    leaves = module._fast_chain(fast.SCALAR, fast.goal_entries(T, module.TARGET), ())
    assert any(leaf[-1] & fast.HAND_BACK for leaf in leaves)
    found = module._native_chain().one(T, (), True)
    assert found is not None
    rows, _ = _exact_rows(module, T, found)
    assert (_same(rows, q, module.JOINT_TYPES) <= 1e-9).any(), rows


@pytest.mark.parametrize("q, rows", [((math.pi / 2, 0.0, math.pi / 2, 0.0), 1),
                                     ((math.pi / 2, math.pi, -math.pi / 2, 0.0), 0)])
def test_an_s2_rr_lock_on_a_line_settles_in_c(q, rows):
    # arm4dof with the elbow at +-pi/2 and the shoulder at 0 or pi: the wrist centre on the waist axis
    # (S2-RR waist, shoulder locks the waist: fast.LOCK) and the wrist axis along it, so waist and
    # wrist turn against each other, a straight-line self-motion (docs/design.md section 6, "Locks in S2-RR
    # steps").  The C settles it: a representative of the line inside the limits, or none where the
    # whole line misses them (the shoulder at pi is outside its limits), as the reference runtime says
    module, _, _ = _compiled("arm4dof")
    q = np.array(q)
    T = module.fk(q)
    leaves = module._fast_chain(fast.SCALAR, fast.goal_entries(T, module.TARGET), ())
    assert any(leaf[-1] & fast.LOCK for leaf in leaves)
    found = module._native_chain().one(T, (), True)
    assert found is not None
    got, continuum = _exact_rows(module, T, found)
    assert len(got) == rows and continuum.all()
    ref = _python(module, lambda: module.solve_info(T))
    assert len(ref.q) >= rows and (len(ref.q) == 0) == (rows == 0)
    for row in got:  # on the sampled vector's line: waist + wrist fixed, the rest stays
        d = np.remainder(row - q + np.pi, 2 * np.pi) - np.pi
        assert abs(d[1]) <= 1e-9 and abs(d[2]) <= 1e-9
        assert abs(np.remainder(d[0] + d[3] + np.pi, 2 * np.pi) - np.pi) <= 1e-9, (row, q)


@pytest.mark.parametrize("q1, q4, q6", [(2.3228, -2.4637, 1.6936), (1.0, 2.0, -1.0), (-2.0, 0.5, 2.5)])
def test_shoulder_and_wrist_self_motion_settles_in_c(q1, q4, q6):
    # prob with the wrist centre on the first axis (a shoulder self-motion) and the wrist locked (q5 = 0):
    # two families at once, each step's representative moved on its own (rep x 1, -2, ...), until one
    # lies inside the joint limits; the result is exact and flagged a continuum
    module, _, _ = _compiled("prob")
    q = np.array([q1, -math.pi / 2, math.pi / 2, q4, 0.0, q6])
    T = module.fk(q)
    leaves = module._fast_chain(fast.SCALAR, fast.goal_entries(T, module.TARGET), ())
    assert all(leaf[-1] & fast.FAMILY for leaf in leaves)
    found = module._native_chain().one(T, (), True)
    assert found is not None
    rows, continuum = _exact_rows(module, T, found)
    assert len(rows) and continuum.all()
    assert ((rows >= module.LOWER - 1e-7) & (rows <= module.UPPER + 1e-7)).all()
