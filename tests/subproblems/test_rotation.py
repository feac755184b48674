"""Pure-rotation subproblems (``subproblems.rotation``; codes O-R, O-RR, O-RRR): proof by randomised test.

Hypothesis draws the axes (general, and the degenerate relations of ``twist_lists``: parallel,
perpendicular, coincident, ...) and joint values (special angles included); the target rotation is the
product of the exponentials.  The drawn angles must come back (or, when flagged continuum, the
representative must satisfy the equation), every exact solution must satisfy the equation, the scalar
and vectorised paths must agree, and unreachable targets must come back flagged ``ls``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, note, settings
from hypothesis import strategies as st

from subproblems import max_solutions, solve, solve_batch
from subproblems.rotation import (
    direction_r,
    direction_rr,
    orientation_r,
    orientation_r_batch,
    orientation_rr,
    orientation_rrr,
    orientation_rrr_batch,
    rotation_error,
)
from subproblems.screw import revolute_twist, rotation_exp
from tests.strategies import contains_solution, joint_values, twist_lists, unit_vectors

TOL = 1e-9
CODES = ["O-R", "O-RR", "O-RRR"]
EXAMPLES = settings().max_examples


def budget(factor: float = 1.0) -> settings:
    return settings(max_examples=max(5, int(EXAMPLES * factor)))


def product(twists, th) -> np.ndarray:
    E = np.eye(3)
    for xi, t in zip(twists, th):
        E = E @ rotation_exp(xi[3:], t)
    return E


def to_T(R) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = [0.3, -1.0, 2.0]  # ignored
    return T


def recovery_tol(twists, th) -> float:
    """1e-9, or looser where the orientation map is (nearly) singular at ``th``.

    Near a fold or a gimbal lock (smallest singular value ``s`` of the body Jacobian) the angles are
    determined only to about ``eps / s`` (or ``sqrt(eps)`` at the singularity itself).
    """
    cols = [product(twists[i + 1 :], th[i + 1 :]).T @ twists[i][3:] for i in range(len(th))]
    s = np.linalg.svd(np.column_stack(cols), compute_uv=False).min()
    return TOL if s > 1e-6 else min(1e-2, 1e-10 / max(s, 1e-300))


@pytest.mark.parametrize("code", CODES)
@budget(4)
@given(data=st.data())
def test_recovers_drawn_angles(code, data):
    kinds = code[2:]
    twists, rel = data.draw(twist_lists(kinds), label="twists")
    th = data.draw(joint_values(kinds), label="th")
    R = product(twists, th)
    r = solve(code, twists, T=to_T(R))
    note(f"relations={rel} q={r.q} ls={r.ls} continuum={r.continuum} residual={r.residual}")
    assert 1 <= len(r.q) <= max_solutions(code)
    assert np.all(np.isfinite(r.q))
    assert not r.ls.any(), "a reachable rotation came back least-squares"
    for row in r.q:
        assert rotation_error(product(twists, row), R) <= TOL
    assert np.all(r.residual <= TOL)
    if not r.continuum:
        assert contains_solution(r.q, th, kinds, recovery_tol(twists, th)), f"drawn angles {th} missing"


@pytest.mark.parametrize("code", ["O-R", "O-RR"])
@budget(2)
@given(data=st.data())
def test_unreachable_is_flagged_ls(code, data):
    kinds = code[2:]
    twists, rel = data.draw(twist_lists(kinds), label="twists")
    th = data.draw(joint_values(kinds), label="th")
    R = product(twists, th)
    # a direction normal to the reachable set (body frame): orthogonal to every joint's body axis
    cols = [product(twists[i + 1 :], th[i + 1 :]).T @ twists[i][3:] for i in range(len(th))]
    u, s, _ = np.linalg.svd(np.column_stack(cols))
    nrm = u[:, -1]
    R2 = R @ rotation_exp(nrm, 1e-3)
    r = solve(code, twists, T=to_T(R2))
    note(f"relations={rel} q={r.q} ls={r.ls} cont={r.continuum}")
    for row, f in zip(r.q, r.ls):
        if not f:  # another sheet of the reachable set may pass through R2 (near-parallel axes)
            assert rotation_error(product(twists, row), R2) <= TOL
    if r.ls.all():
        assert len(r.q) == 1 and TOL < r.residual[0] <= 1.01e-3


def test_orientation_rrr_unreachable_is_ls():
    w1, w3 = [0, 0, 1], [0, 0, 1]
    w2 = [math.sin(0.3), 0, math.cos(0.3)]  # z . R z >= cos 0.6 for every reachable R
    sols = orientation_rrr(w1, w2, w3, rotation_exp([1, 0, 0], 1.0))
    assert len(sols) == 1 and sols[0].ls and not sols[0].continuum


@pytest.mark.parametrize("code", CODES)
@budget(2)
@given(data=st.data())
def test_scalar_and_vectorised_paths_agree(code, data):
    kinds = code[2:]
    n = 4
    tws, Ts = [], []
    for _ in range(n):
        twists, _ = data.draw(twist_lists(kinds))
        th = data.draw(joint_values(kinds))
        R = product(twists, th)
        if data.draw(st.booleans()):
            R = R @ rotation_exp(data.draw(unit_vectors()), data.draw(st.floats(1e-6, 0.3)))
        tws.append(twists)
        Ts.append(to_T(R))
    tws, Ts = np.array(tws), np.array(Ts)
    b = solve_batch(code, tws, T=Ts)
    assert b.vectorised
    K = max_solutions(code)
    assert b.q.shape == (n, K, len(kinds)) and np.all(np.isfinite(b.q))
    for i in range(n):
        r = solve(code, tws[i], T=Ts[i])
        Qb, lsb = b.q[i][b.valid[i]], b.ls[i][b.valid[i]]
        note(f"{i}: scalar {r.q} ls={r.ls} cont={r.continuum}; batch {Qb} ls={lsb} cont={b.continuum[i]}")
        assert len(Qb) == len(r.q)
        assert list(lsb) == list(r.ls)
        assert bool(r.continuum) == bool(b.continuum[i])
        for row in Qb:
            assert contains_solution(r.q, row, kinds, 1e-6)
        for row, f in zip(Qb, lsb):
            if not f:
                assert rotation_error(product(tws[i], row), Ts[i][:3, :3]) <= TOL


@budget(2)
@given(data=st.data())
def test_direction_rr(data):
    twists, rel = data.draw(twist_lists("RR"), label="twists")
    th = data.draw(joint_values("RR"), label="th")
    u = data.draw(unit_vectors(), label="u") * data.draw(st.floats(0.1, 3.0))
    v = product(twists, th) @ u
    w1, w2 = twists[0][3:], twists[1][3:]
    sols = direction_rr(w1, w2, u, v)
    note(f"relations={rel} sols={sols}")
    assert 1 <= len(sols) <= 2
    for s in sols:
        assert not s.ls
        assert np.linalg.norm(product(twists, s.q) @ u - v) <= TOL * 3
    if not any(s.continuum for s in sols):
        J = np.column_stack([np.cross(w1, v), product(twists, th) @ np.cross(w2, u)])
        sv = np.linalg.svd(J, compute_uv=False).min() / max(1e-300, float(np.linalg.norm(u)))
        tol = TOL if sv > 1e-6 else min(1e-2, 1e-10 / max(sv, 1e-300))
        assert contains_solution([s.q for s in sols], th, "RR", tol)


def test_direction_r_and_rr_degenerate():
    assert direction_r([0, 0, 1], [0, 0, 2], [0, 0, 2])[0].continuum
    (s,) = direction_r([0, 0, 1], [1, 0, 0], [0, 2, 0])
    assert s.ls and abs(s.q[0] - math.pi / 2) < 1e-12
    sols = direction_rr([0, 0, 1], [1, 0, 0], [0, 1, 1], rotation_exp([0, 0, 1], 0.3) @ [0, 1, 1.0])
    assert len(sols) == 2 and not any(s.ls for s in sols)
    (s,) = direction_rr([0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0])
    assert s.continuum and s.q[0] == 0.0
    (s,) = direction_rr([0, 0, 1], [1, 0, 0], [1, 0, 0], [0, 0, 5])  # lengths differ
    assert s.ls


def test_named_cases():
    z, y, x = [0, 0, 1], [0, 1, 0], [1, 0, 0]
    # O-R half-turn about a perpendicular axis: every angle equally good
    (s,) = orientation_r(z, rotation_exp(x, math.pi))
    assert s.ls and s.continuum and s.q == (0.0,)
    # O-RR with parallel axes: t1 = 0 representative
    (s,) = orientation_rr(z, z, rotation_exp(z, 0.7))
    assert s.continuum and not s.ls and s.q[0] == 0.0 and abs(s.q[1] - 0.7) < 1e-12
    # ZYZ: two solutions in general, gimbal lock at t2 = 0 and t2 = pi
    R = rotation_exp(z, 0.3) @ rotation_exp(y, 1.1) @ rotation_exp(z, -2.0)
    sols = orientation_rrr(z, y, z, R)
    assert len(sols) == 2 and not any(s.ls or s.continuum for s in sols)
    for t2 in (0.0, math.pi):
        R = rotation_exp(z, 0.3) @ rotation_exp(y, t2) @ rotation_exp(z, -2.0)
        (s,) = orientation_rrr(z, y, z, R)
        assert s.continuum and not s.ls and s.q[0] == 0.0
        assert rotation_error(rotation_exp(y, s.q[1]) @ rotation_exp(z, s.q[2]), R) <= TOL
    # XYZ (roll-pitch-yaw) with pitch +-pi/2: gimbal lock for non-parallel w1, w3
    R = rotation_exp(x, 0.4) @ rotation_exp(y, math.pi / 2) @ rotation_exp(z, 0.9)
    (s,) = orientation_rrr(x, y, z, R)
    assert s.continuum and s.q[0] == 0.0 and not s.ls
    # general axes: exactly two
    rng = np.random.default_rng(3)
    for _ in range(20):
        ws = [v / np.linalg.norm(v) for v in rng.normal(size=(3, 3))]
        th = rng.uniform(-math.pi, math.pi, 3)
        R = rotation_exp(ws[0], th[0]) @ rotation_exp(ws[1], th[1]) @ rotation_exp(ws[2], th[2])
        sols = orientation_rrr(*ws, R)
        assert len(sols) == 2 and contains_solution([s.q for s in sols], th, "RRR", TOL)


def test_batch_functions_directly():
    rng = np.random.default_rng(1)
    N = 50
    w = rng.normal(size=(N, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    th = rng.uniform(-3, 3, N)
    R = np.array([rotation_exp(a, t) for a, t in zip(w, th)])
    b = orientation_r_batch(w, R)
    assert np.allclose(b.q[:, 0, 0], th) and not b.ls.any()
    z = np.tile([0.0, 0, 1], (N, 1))
    y = np.tile([0.0, 1, 0], (N, 1))
    b = orientation_rrr_batch(z, y, z, R)
    assert b.valid.all() and not b.ls.any()


def test_registered_signature_ignores_v():
    tw = [revolute_twist([0, 0, 1], [5, 5, 0])]
    r = solve("O-R", tw, T=to_T(rotation_exp([0, 0, 1], 1.0)))
    assert abs(r.q[0, 0] - 1.0) < 1e-12 and r.residual[0] < 1e-12


def _tilted(rng, w, eps):
    p = np.cross(w, rng.normal(size=3))
    v = w + eps * p / np.linalg.norm(p)
    return v / np.linalg.norm(v)


@pytest.mark.parametrize("family", ["near-gimbal", "axes-12-near-parallel", "axes-23-near-parallel"])
def test_orientation_rrr_near_singular_families(family):
    """Regression (issue 3): near a gimbal lock the t2 equation has a double root and t1 was lost
    (fixed by e1b6bdd's t1-first elimination), but that elimination has the double root for axes 2, 3
    nearly parallel and lost the drawn angles there (why e1b6bdd was reverted); axes 1, 2 nearly
    parallel (2e-8) lost them in both.  Every instance must come back exact with the drawn angles."""
    rng = np.random.default_rng(7)
    for eps in (1e-8, 2e-8, 1e-7):
        for _ in range(12):
            ws = [v / np.linalg.norm(v) for v in rng.normal(size=(3, 3))]
            th = rng.uniform(-math.pi, math.pi, 3)
            if family == "near-gimbal":  # exp([w2]t2) w3 within eps of w1
                ws[2] = rotation_exp(ws[1], -th[1]) @ _tilted(rng, ws[0], eps)
            elif family == "axes-12-near-parallel":
                ws[1] = _tilted(rng, ws[0], eps)
            else:
                ws[2] = _tilted(rng, ws[1], eps)
            tws = [revolute_twist(w, [0.0, 0.0, 0.0]) for w in ws]
            R = product(tws, th)
            r = solve("O-RRR", tws, T=to_T(R))
            assert not r.ls.any() and len(r.q) <= 2 and np.all(r.residual <= TOL), (eps, ws, th, r)
            if not r.continuum:
                assert contains_solution(r.q, th, "RRR", recovery_tol(tws, th)), (eps, ws, th, r)
            b = solve_batch("O-RRR", np.array([tws]), T=to_T(R)[None])
            assert b.valid[0].sum() == len(r.q) and not b.ls[0].any()


def test_orientation_rrr_axis_1e9_from_two_parallel_axes():
    """Regression (thorough profile): w2 = w3 exactly, w1 tilted by 1e-9: the family of the parallel
    pair (2, 3) is exact; the all-parallel and (1, 2) representatives are not and were forced."""
    tws = np.array([[0, 0, 0, 0, 1, 1e-9], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 1, 0.0]])
    th = [math.pi / 2, 0.0, 0.0]
    R = rotation_exp(tws[0, 3:] / np.linalg.norm(tws[0, 3:]), th[0])
    r = solve("O-RRR", tws, T=to_T(R))
    assert r.continuum and not r.ls.any() and np.all(r.residual <= TOL)


@pytest.mark.parametrize("family", ["axes-near-parallel", "v-near-axis-1", "u-near-axis-2"])
def test_direction_rr_near_degenerate_families(family):
    """Regression (issue 3): Gauss-Newton restarts from the degenerate family recover the angles."""
    rng = np.random.default_rng(11)
    for eps in (1e-8, 1e-7):
        for _ in range(12):
            w1, w2, u = (v / np.linalg.norm(v) for v in rng.normal(size=(3, 3)))
            th = rng.uniform(-math.pi, math.pi, 2)
            if family == "axes-near-parallel":
                w2 = _tilted(rng, w1, eps)
            elif family == "u-near-axis-2":
                u = _tilted(rng, w2, eps)
            E = rotation_exp(w1, th[0]) @ rotation_exp(w2, th[1])
            if family == "v-near-axis-1":
                u = E.T @ _tilted(rng, w1, eps)
            v = E @ u
            sols = direction_rr(w1, w2, u, v)
            assert 1 <= len(sols) <= 2
            for s in sols:
                assert not s.ls
                assert np.linalg.norm(rotation_exp(w1, s.q[0]) @ rotation_exp(w2, s.q[1]) @ u - v) <= TOL * 3
            if not any(s.continuum for s in sols):
                J = np.column_stack([np.cross(w1, v), E @ np.cross(w2, u)])
                sv = np.linalg.svd(J, compute_uv=False).min()
                tol = TOL if sv > 1e-6 else min(1e-2, 1e-10 / max(sv, 1e-300))
                assert contains_solution([s.q for s in sols], th, "RR", tol), (eps, family, th, sols)
