"""The contract of every returned row (docs/finish.md), on hand-made cases, in C and in Python.

* precision: an exact row reproduces its target to 1e-12 of the robot's size in position and 1e-12 in
  rotation (Frobenius), recomputed here from the chain's own forward kinematics;
* representation: every value inside its joint's limits as returned; a revolute value in (-pi, pi]
  where that lies inside the limits, else its 2 pi alias (kr6_r700 q3 = 2.625 - 2 pi); never -pi
  where pi is allowed; no two rows of one pose closer than the dedupe tolerance;
* input: ``fk`` with the wrong number of values, a bottom row not [0, 0, 0, 1], NaN or non-rigid
  poses inside a batch (marked invalid, with reasons), NaN or infinite free values (typed errors);
* ``verify`` fails when a module breaks any of these.
"""

from __future__ import annotations

import math
import types

import numpy as np
import pytest

from ikcompiler import load_robot
from ikcompiler.cli import main
from ikcompiler.compiler import compile_robot
from ikcompiler.verify import _limit_checks, _singular, sample_configurations, verify
from subproblems import fast, solve
from subproblems.plan_runtime import InvalidFreeValueError, InvalidTargetError
from subproblems.screw import apply, twist_exp

PRECISION = 1e-12
_CACHE: dict = {}


def _module(name, **kw):
    key = (name, tuple(sorted(kw.items())))
    if key not in _CACHE:
        chain = load_robot(name)
        _CACHE[key] = (chain, compile_robot(chain, **kw))
    return _CACHE[key]


@pytest.fixture(params=["native", "python"])
def backend(request, monkeypatch):
    """Run a test on the C backend and on the Python fast path (module.NATIVE False)."""
    return request.param


def _use(module, backend, monkeypatch):
    if backend == "python":
        monkeypatch.setattr(module, "NATIVE", False)
    elif module.NATIVE and module._native_chain() is None:  # a module without C (no fast path) runs as is
        pytest.skip("no C compiler on this machine")


def _rel_errors(chain, target, rows, G):
    Gs = chain.fk_batch(rows)
    dp = np.linalg.norm(Gs[:, :3, 3] - G[:3, 3], axis=1) / chain.scale
    if target == "position":
        return dp
    return np.maximum(dp, np.linalg.norm(Gs[:, :3, :3] - G[:3, :3], axis=(1, 2)))


# --- representation ------------------------------------------------------------------------------------


def test_represent_picks_the_alias_inside_the_limits_and_pi_over_minus_pi():
    lo, hi = [-3.665], [1.152]
    Q0 = np.array([[2.625], [-math.pi], [1.5], [1.152 + 5e-8]])
    Q, adjusted, outside = fast.represent(Q0, "R", lo, hi, True)
    assert Q[0, 0] == pytest.approx(2.625 - 2 * math.pi, abs=1e-15)
    assert Q[1, 0] == -math.pi  # pi is outside [-3.665, 1.152]: its alias -pi is the value inside
    assert outside.tolist() == [False, False, True, False]
    assert Q[3, 0] == 1.152 and adjusted.tolist() == [False, False, False, True]  # clamped: measured again
    Q0 = np.array([[-math.pi], [-math.pi + 1e-15], [3 * math.pi]])
    Q, adjusted, _ = fast.represent(Q0, "R", [-4.0], [4.0], True)
    assert Q[:, 0].tolist() == [math.pi] * 3
    assert adjusted.tolist() == [False, True, False]  # moved by 1e-15: its error is measured again
    one = fast.represent_one([2.625, -math.pi], [True, True], [(-3.665, 1.152), (-4.0, 4.0)], True)
    assert one == ([2.625 - 2 * math.pi, math.pi], fast.INSIDE)


@pytest.mark.parametrize("path", ["solve", "solve_info", "solve_batch"])
def test_kr6_r700_q3_comes_back_as_its_alias_inside_the_limits(path, backend, monkeypatch):
    chain, module = _module("kr6_r700")
    _use(module, backend, monkeypatch)
    j = module.JOINT_NAMES.index(chain.independent_names[2])
    assert module.LOWER[j] < 2.625 - 2 * math.pi and module.UPPER[j] < 2.625
    q = np.array([0.3, -0.4, 2.625 - 2 * math.pi, 0.5, 0.7, -0.2])
    T = chain.fk(q)
    if path == "solve_batch":
        S, V = module.solve_batch(T[None])
        rows = S[0][V[0]]
    else:
        rows = module.solve(T) if path == "solve" else module.solve_info(T)[0]
    assert len(rows)
    assert np.all((rows >= module.LOWER) & (rows <= module.UPPER)), rows
    assert np.abs(rows - q).max(axis=1).min() <= 1e-9, rows  # the sampled row, as given
    assert _limit_checks(rows, module.JOINT_TYPES, module.LOWER, module.UPPER) == (0, 0)


def test_no_minus_pi_and_rows_inside_limits_on_special_angles(backend, monkeypatch):
    """Sampled values at pi (and -pi/2, 0, pi/2) on arms whose limits hold pi: never -pi, nothing outside."""
    for name in ("puma560", "kr6_r700", "ur5"):
        chain, module = _module(name)
        _use(module, backend, monkeypatch)
        Q = sample_configurations(chain, 150, seed=21, special=0.6)
        S, V = module.solve_batch(chain.fk_batch(Q))
        rows = S[V]
        assert _limit_checks(rows, module.JOINT_TYPES, module.LOWER, module.UPPER) == (0, 0), name
        rev = np.array([k == "R" for k in module.JOINT_TYPES])
        at_minus_pi = rows[:, rev] <= -math.pi + fast.PI_SNAP
        pi_allowed = (module.UPPER[rev] >= math.pi)[None, :].repeat(len(rows), 0)
        assert not (at_minus_pi & pi_allowed).any(), name
        for k in range(len(S)):  # no two rows of a pose within the dedupe tolerance
            r = S[k][V[k]]
            d = np.abs(r[:, None, :] - r[None, :, :])
            d[..., rev] = np.abs(np.remainder(d[..., rev] + math.pi, 2 * math.pi) - math.pi)
            d = d.max(axis=2) + np.eye(len(r))
            assert d.min(initial=1.0) > 1e-9 * max(1.0, chain.scale), (name, k, r)


# --- precision ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("name", "kw"), [("ur5", {}), ("jaco", {}), ("shadow_index", {"target": "position"}),
                                          ("panda", {"free": ("panda_joint7",)})])
def test_exact_rows_reproduce_the_target_to_1e_12(name, kw, backend, monkeypatch):
    chain, module = _module(name, **kw)
    _use(module, backend, monkeypatch)
    Q = sample_configurations(chain, 120 if name != "jaco" else 40, seed=5, special=0.4)
    G = chain.fk_batch(Q)
    targets = G[:, :3, 3] if module.TARGET == "position" else G
    free = [Q[:, chain.independent_names.index(f)] for f in module.FREE_JOINTS]
    S, V, LS, RES, _ = module.solve_batch_info(targets, *free)
    worst = 0.0
    for k in range(len(Q)):
        rows = S[k][V[k] & ~LS[k]]
        if len(rows):
            worst = max(worst, _rel_errors(chain, module.TARGET, rows, G[k]).max())
        assert np.all((S[k][V[k]] >= module.LOWER) & (S[k][V[k]] <= module.UPPER))
    assert worst <= PRECISION, worst
    for k in range(0, len(Q), 7):  # one pose at a time: the same contract
        fr = [f[k] for f in free]
        rows = module.solve(targets[k], *fr)
        if len(rows):
            assert _rel_errors(chain, module.TARGET, rows, G[k]).max() <= PRECISION


def test_a_rotation_orthonormal_to_1e_8_is_projected_and_solved_exactly(backend, monkeypatch):
    chain, module = _module("ur5")
    _use(module, backend, monkeypatch)
    T = chain.fk(np.array([0.3, -1.0, 1.2, -0.4, 0.9, 0.2]))
    T2 = T.copy()
    T2[:3, :3] += 1e-8 * np.array([[0.3, -0.2, 0.5], [0.1, 0.4, -0.3], [-0.6, 0.2, 0.1]])
    rows = module.solve(T2)
    assert len(rows) == len(module.solve(T))
    # exact for the nearest rotation (polar factor), to the contract
    U, _, Wt = np.linalg.svd(T2[:3, :3])
    P = T2.copy()
    P[:3, :3] = U @ Wt
    assert _rel_errors(chain, "pose", rows, P).max() <= PRECISION


# --- input -------------------------------------------------------------------------------------------------


def test_fk_needs_exactly_one_value_per_joint():
    _, module = _module("ur5")
    with pytest.raises(ValueError, match="fk expects 6 joint values"):
        module.fk([0.1] * 5)
    with pytest.raises(ValueError, match=r"got shape \(7,\)"):
        module.fk([0.1] * 7)
    assert module.fk([0.0] * 6).shape == (4, 4)


def test_bottom_row_and_bad_poses_in_a_batch(backend, monkeypatch):
    chain, module = _module("ur5")
    _use(module, backend, monkeypatch)
    T = chain.fk(np.array([0.3, -1.0, 1.2, -0.4, 0.9, 0.2]))
    bottom = T.copy()
    bottom[3, 0] = 0.5
    with pytest.raises(InvalidTargetError, match=r"bottom row is not \[0, 0, 0, 1\]"):
        module.solve(bottom)
    with pytest.raises(ValueError, match="bottom row"):
        module.solve_info(bottom)
    nan, skew = T.copy(), T.copy()
    nan[1, 2] = np.nan
    skew[0, 0] = 2.0
    Ts = np.stack([T, nan, skew, bottom, T])
    with np.errstate(invalid="ignore"):
        S, V = module.solve_batch(Ts)
        Si, Vi, LSi, RESi, _ = module.solve_batch_info(Ts)
    assert not V[1:4].any() and not Vi[1:4].any() and np.isinf(RESi[1:4]).all()
    good = module.solve(T)
    for k in (0, 4):
        assert V[k].sum() == len(good) and np.abs(np.sort(S[k][V[k]], 0) - np.sort(good, 0)).max() <= 1e-9
    reasons = module.invalid_reasons(Ts)
    assert sorted(reasons) == [1, 2, 3]
    assert "NaN" in reasons[1] and "rotation" in reasons[2] and "bottom row" in reasons[3]
    with pytest.raises(ValueError, match="pose target"):  # a wrong shape is the whole batch's fault
        module.solve_batch(np.zeros((3, 4, 3)))


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_nan_or_infinite_free_value_raises_a_typed_error(value, backend, monkeypatch):
    chain, module = _module("panda", free=("panda_joint7",))
    _use(module, backend, monkeypatch)
    T = chain.fk(np.array([0.1, 0.2, 0.3, -1.0, 0.2, 1.0, 0.3]))
    calls = [lambda: module.solve(T, value), lambda: module.solve_info(T, value),
             lambda: module.solve_batch(T[None], value),
             lambda: module.solve_batch(np.stack([T, T]), [0.3, value])]
    for call in calls:
        with pytest.raises(InvalidFreeValueError, match="panda_joint7.*NaN or infinite"):
            call()
    assert len(module.solve(T, 0.3))


def test_s3_tt_with_zero_distances_is_finite_not_a_continuum():
    rng = np.random.default_rng(4)
    for _ in range(20):
        v = rng.normal(size=(2, 3))
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        tw = [np.r_[v[0], 0, 0, 0], np.r_[v[1], 0, 0, 0]]
        p, (x, y) = rng.normal(size=(2, 3)), rng.normal(size=2)
        q = apply(twist_exp(tw[0], x) @ twist_exp(tw[1], y), p)
        r = solve("S3-TT", tw, p=p, q=q, d=np.zeros(2))
        assert not r.continuum and len(r.q) == 1 and not r.ls.any(), r
        assert np.abs(r.q[0] - [x, y]).max() <= 1e-9


# --- verify can fail ---------------------------------------------------------------------------------------


def _tampered(module, change):
    """A stand-in module whose batch answers are changed by ``change(S, V, LS, RES, C)``."""
    fake = types.SimpleNamespace(**{k: getattr(module, k) for k in dir(module) if not k.startswith("__")})

    def batch(Ts, *free):
        out = [np.array(x) for x in module.solve_batch_info(Ts, *free)]
        change(*out)
        return tuple(out)

    def single(T, *free):
        S, V, LS, _, _ = batch(np.asarray(T)[None], *free)
        return S[0][V[0] & ~LS[0]]

    fake.solve_batch_info, fake.solve = batch, single
    return fake


def test_verify_counts_every_kind_of_failure():
    chain, module = _module("puma560")
    clean = verify(chain, module, samples=40, seed=2, scalar_checks=3)
    assert clean.ok, clean.text()

    def outside(S, V, *_):
        S[0, 0, 0] += 2 * math.pi  # an alias outside the limits

    def imprecise(S, V, *_):
        S[1, 0, 3] += 1e-11

    def wrong(S, V, *_):
        S[2, 0, 1] += 1e-3

    def duplicate(S, V, *_):
        k = int(np.nonzero(V.sum(axis=1) >= 2)[0][0])
        S[k, 1] = S[k, 0] + 1e-8

    def missing(S, V, *_):
        V[3] = False

    for change, field in ((outside, "outside_limits"), (imprecise, "imprecise"), (wrong, "wrong"),
                          (duplicate, "duplicates"), (missing, "missed")):
        report = verify(chain, _tampered(module, change), samples=40, seed=2, scalar_checks=0)
        assert getattr(report, field) >= 1 and not report.ok, (field, report.text())
    report = verify(chain, _tampered(module, missing), samples=40, seed=2, scalar_checks=0, allow_missed=1)
    assert report.missed == 1 and report.ok, report.text()


def test_verify_rank_test_of_a_position_and_direction_target():
    """A position+direction target constrains five numbers: the rank test that counts a pose as a
    self-motion uses those rows (linear, and the body turns about the tool's x and y).  At q2 = q3 = 0
    the thumb's th1, th4, th5 axes are parallel to its tool z axis: a planar 3R reaching a point, a
    self-motion (five-row sigma 7e-18), which six rows (a turn about the tool z counted) called
    full-rank (0.09); a generic configuration is full-rank either way."""
    chain = load_robot("shadow_thumb")
    locked = np.array([0.29252769, 0.0, 0.0, 0.66208883, 1.41006869])
    assert _singular(chain, locked, [], "position+direction")
    assert not _singular(chain, locked, [], "pose")  # the six rows: what it was judged on
    assert not _singular(chain, np.array([0.3, 0.4, -0.1, 0.2, 0.9]), [], "position+direction")


def test_ikc_verify_exit_code(capsys):
    assert main(["verify", "scara", "--samples", "40"]) == 0
    assert "OK" in capsys.readouterr().out
