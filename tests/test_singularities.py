"""Jacobians and singular configurations (issue 12): numeric against finite differences of FK, symbolic
against numeric, conditions against sampling on every zoo robot, the literature's sets of PUMA 560, UR5
and Stanford, seed 004's worked example, the CLI's JSON and PNG.

Every check recomputes from forward kinematics or from the Jacobian's singular values; nothing is taken
from the analysis' own report where it can be recomputed.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import sympy as sp

from ikcompiler import load_robot
from ikcompiler.analysis import jacobian as jac
from ikcompiler.analysis.singularities import (
    RADIUS,
    THRESHOLD,
    _Numeric,
    analyse,
    reciprocal_free_rows,
    reduced_conditions,
)
from ikcompiler.analysis.symbolic import symbolic_jacobian
from ikcompiler.cli import main
from ikcompiler.inputs.zoo import zoo_names
from ikcompiler.model.chain import Chain, Joint
from subproblems.conditioning import sigma_min
from subproblems.screw import inverse_transform

SAMPLES = 400  # per zoo robot in CI; `ikc singularities` defaults to 10000


@pytest.fixture(scope="module")
def reports():
    cache = {}

    def get(name):
        if name not in cache:
            # a generous sympy budget: CI shares 2 cores (panda's seven 6x6 minors take ~5 s unloaded)
            cache[name] = analyse(load_robot(name), samples=SAMPLES, seed=3, budget=60)
        return cache[name]

    return get


def _random_q(chain, rng, n):
    num = _Numeric(chain)
    lo, hi = num.box()
    return rng.uniform(lo, hi, (n, chain.dof))


# ---- numeric Jacobians ------------------------------------------------------------------------------------


def _vee(X):
    return np.array([X[0, 3], X[1, 3], X[2, 3], X[2, 1], X[0, 2], X[1, 0]])


@pytest.mark.parametrize("name", ["puma560", "stanford", "shadow_index", "gantry", "ur5"])
def test_space_and_body_jacobians_match_finite_differences_of_fk(name):
    # V_s^ = (dg/dq) g^-1, V_b^ = g^-1 dg/dq: prismatic (stanford, gantry) and mimic (shadow_index) joints
    chain = load_robot(name)
    Q = _random_q(chain, np.random.default_rng(1), 4)
    Js, Jb = jac.space_jacobians(chain, Q), jac.body_jacobians(chain, Q)
    h = 1e-6
    for n, q in enumerate(Q):
        gi = inverse_transform(chain.fk(q))
        for k in range(chain.dof):
            d = np.zeros(chain.dof)
            d[k] = h
            dg = (chain.fk(q + d) - chain.fk(q - d)) / (2 * h)
            assert np.allclose(_vee(dg @ gi), Js[n, :, k], atol=1e-7 * chain.scale), (name, k)
            assert np.allclose(_vee(gi @ dg), Jb[n, :, k], atol=1e-7 * chain.scale), (name, k)
        assert np.allclose(chain.space_jacobian(q), Js[n], atol=1e-12 * chain.scale)


def test_size_free_sigma_min_ignores_units_and_base_placement():
    chain = load_robot("puma560")
    Q = _random_q(chain, np.random.default_rng(2), 20)
    A, b = chain.coupling_matrix()
    ref = sigma_min(chain.twists, A, b, chain.home, Q, chain.scale)
    # the same robot in mm
    tw_mm = chain.twists.copy()
    tw_mm[:, :3] *= 1000
    home_mm = chain.home.copy()
    home_mm[:3, 3] *= 1000
    assert np.allclose(sigma_min(tw_mm, A, b, home_mm, Q, 1000 * chain.scale), ref, rtol=1e-9, atol=1e-12)
    # the base moved by a rigid transform G: twists Ad_G xi, home G g0 (same tool motion)
    from subproblems.screw import adjoint, rotation_exp

    G = np.eye(4)
    G[:3, :3] = rotation_exp([0.3, -0.5, 0.8] / np.linalg.norm([0.3, -0.5, 0.8]), 0.7)
    G[:3, 3] = [0.4, -0.2, 1.1]
    tw_g = (adjoint(G) @ chain.twists.T).T
    assert np.allclose(sigma_min(tw_g, A, b, G @ chain.home, Q, chain.scale), ref, rtol=1e-9, atol=1e-12)


def test_measures_are_consistent_with_the_singular_values():
    chain = load_robot("ur5")
    Q = _random_q(chain, np.random.default_rng(4), 10)
    m = jac.measures(chain, Q)
    s = np.linalg.svd(jac.scaled_jacobians(chain, Q), compute_uv=False)
    J = jac.scaled_jacobians(chain, Q)
    assert np.allclose(m.manipulability, np.sqrt(np.linalg.det(J @ np.swapaxes(J, 1, 2))), rtol=1e-9)
    assert np.allclose(m.condition, s[:, 0] / s[:, -1])
    assert np.allclose(m.sigma_min, s[:, -1])


# ---- symbolic Jacobians -----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["puma560", "stanford", "shadow_index", "ur5", "rhino"])
def test_symbolic_jacobian_equals_numeric(name):
    chain = load_robot(name)
    syms = [sp.Symbol(n, real=True) for n in chain.independent_names]
    Q = _random_q(chain, np.random.default_rng(5), 5)
    for frame, numeric in (("space", jac.space_jacobians), ("body", jac.body_jacobians)):
        J = symbolic_jacobian(chain, frame)
        assert J.free_symbols <= set(syms)
        f = sp.lambdify(syms, J, "numpy")
        want = numeric(chain, Q)
        for n, q in enumerate(Q):
            got = np.array(f(*q), dtype=float)
            assert np.abs(got - want[n]).max() <= 1e-12 * max(1.0, chain.scale), (name, frame)


# ---- the singular set on every zoo robot ------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(zoo_names()))
def test_conditions_agree_with_sampling(name, reports):
    rep = reports(name)
    chain = load_robot(name)
    assert rep.status == "factored", rep.text()
    num = _Numeric(chain)
    rng = np.random.default_rng(11)
    for c in rep.conditions:
        # recomputed here: points on the condition (Gauss-Newton on its equations) are rank deficient
        P, ok = num.project(c.equations, _random_q(chain, rng, 16))
        assert ok.sum() >= 4, (name, c.equations)
        sv = num.sv(P[ok])[:, rep.generic_rank - 1]
        assert sv.max() < 1e-7, (name, c.equations, sv.max())
    # every sampled near-singular configuration lies near a condition (recount from the samples)
    s = rep.sampling
    assert s.samples == SAMPLES and s.threshold == THRESHOLD
    near = s.sigma < s.threshold
    assert near.sum() == s.near_singular
    assert np.allclose(num.sv(s.Q)[:, rep.generic_rank - 1], s.sigma)
    if name == "panda":
        # 7R: sigma_min has local minima below the threshold that are not 0 (no singular point there)
        assert s.explained + s.nonsingular_minima == s.near_singular, rep.text()
    else:
        assert s.explained == s.near_singular, rep.text()
    if rep.conditions and near.any() and name != "panda":
        rev = np.array([k == "R" for k in num.kinds])
        Qn = s.Q[near]
        best = np.full(len(Qn), np.inf)
        for c in rep.conditions:
            P, ok = num.project(c.equations, Qn)
            d = np.where(rev, (P - Qn + math.pi) % (2 * math.pi) - math.pi, (P - Qn) / chain.scale)
            best = np.minimum(best, np.where(ok, np.linalg.norm(d, axis=1), np.inf))
        assert best.max() <= RADIUS, (name, best.max())


def test_a_chain_with_two_coincident_axes_is_singular_everywhere():
    z = [0, 0, 0, 0, 0, 1.0]
    home = np.eye(4)
    home[0, 3] = 2.0
    joints = (Joint("a", "R", z), Joint("b", "R", z), Joint("c", "R", [0, -1.0, 0, 0, 0, 1]))
    chain = Chain("coincident", joints, home=home)
    rep = analyse(chain, samples=200)
    assert rep.singular_everywhere and rep.generic_rank == 2
    assert rep.to_json()["singular_everywhere"] is True


def test_a_budget_too_short_says_so_and_still_samples():
    rep = analyse(load_robot("puma560"), samples=300, budget=0.01)
    assert rep.status == "timeout" and "did not finish" in rep.message
    assert rep.conditions == ()
    assert rep.sampling.samples == 300 and len(rep.sampling.lowest) == 5
    assert rep.sampling.lowest[0][0] == pytest.approx(rep.sampling.sigma.min())


def test_a_calibrated_puma_is_analysed_on_its_ideal_robot():
    # axes and points moved by ~1e-4 of the size (a calibrated URDF): dense numbers would time out
    from subproblems.screw import revolute_twist

    puma = load_robot("puma560")
    rng = np.random.default_rng(0)
    joints = tuple(Joint(j.name, "R", revolute_twist(j.axis + rng.normal(size=3) * 1e-4,
                                                     j.point + rng.normal(size=3) * 1e-4), j.lower, j.upper)
                   for j in puma.joints)
    chain = Chain("puma_calibrated", joints, puma.home)
    rep = analyse(chain, samples=1500, budget=30)
    assert rep.status == "factored" and any("ideal robot" in n for n in rep.notes)
    assert sorted(c.name for c in rep.conditions) == ["elbow", "shoulder", "wrist"]
    s = rep.sampling
    assert s.near_singular > 0 and s.explained == s.near_singular
    # recomputed on the robot as loaded: sigma_min at points on each ideal condition is of the size of
    # the calibration error, far below a generic value
    num = _Numeric(chain)
    for c in rep.conditions:
        P, ok = num.project(c.equations, _random_q(chain, rng, 12))
        assert num.sv(P[ok])[:, -1].max() < 1e-2 * np.median(s.sigma)


# ---- known sets from the literature -----------------------------------------------------------------------


def _same_zero_set(chain, got_eqs, want_eqs, rng):
    """Points on each set satisfy the other's equations (first-order distance below 1e-8)."""
    num = _Numeric(chain)
    for a, b in ((got_eqs, want_eqs), (want_eqs, got_eqs)):
        P, ok = num.project(a, _random_q(chain, rng, 24))
        if ok.sum() < 4:
            return False
        if not all(num.vanishes(e, P[ok]).all() for e in b):
            return False
    return True


def _find(rep, chain, want, rng):
    return [c for c in rep.conditions if _same_zero_set(chain, c.equations, want, rng)]


def test_puma560_wrist_elbow_and_shoulder(reports):
    chain = load_robot("puma560")
    rep = reports("puma560")
    j2, j3, j5 = (sp.Symbol(n, real=True) for n in ("j2", "j3", "j5"))
    a2, a3, d4 = 0.4318, 0.0203, 0.4318  # the DH table of robots/puma560.dh.toml (Corke)
    rng = np.random.default_rng(6)
    assert [c.name for c in _find(rep, chain, [sp.sin(j5)], rng)] == ["wrist"]
    # elbow: the reach |p_wc - p_2|**2 = a2**2 + a3**2 + d4**2 + 2 a2 (a3 cos j3 - d4 sin j3) is stationary
    # in j3 (stretched or folded); its derivative vanishes where a3 sin j3 + d4 cos j3 = 0 (the geometry
    # itself is checked in test_puma560_elbow_condition_is_the_stretched_arm)
    assert [c.name for c in _find(rep, chain, [d4 * sp.cos(j3) + a3 * sp.sin(j3)], rng)] == ["elbow"]
    # shoulder: the wrist centre in the plane of axis 1 and the shoulder axis (Craig's condition)
    shoulder = a2 * sp.cos(j2) + a3 * sp.cos(j2 + j3) - d4 * sp.sin(j2 + j3)
    assert [c.name for c in _find(rep, chain, [shoulder], rng)] == ["shoulder"]
    assert len(rep.conditions) == 3 and all(c.inside_limits for c in rep.conditions)


def test_puma560_elbow_condition_is_the_stretched_arm():
    # independent of the factoring: on the reported elbow condition, d|p_wc - p_shoulder| / dj3 = 0
    chain = load_robot("puma560")
    rep = analyse(chain, samples=50)
    (elbow,) = [c for c in rep.conditions if c.name == "elbow"]
    num = _Numeric(chain)
    P, ok = num.project(elbow.equations, _random_q(chain, np.random.default_rng(7), 8))

    def reach(q):  # tool origin = wrist centre for this DH table (d6 = 0)
        return np.linalg.norm(chain.fk(q)[:3, 3] - np.array([0, 0, 0.6718]))

    for q in P[ok]:
        d = np.zeros(6)
        d[2] = 1e-6
        assert abs(reach(q + d) - reach(q - d)) / 2e-6 < 1e-7


def test_ur5_wrist_elbow_and_shoulder(reports):
    chain = load_robot("ur5")
    rep = reports("ur5")
    q2, q3, q4, q5 = (sp.Symbol(n, real=True) for n in
                      ("shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint"))
    a2, a3, d5 = 0.425, 0.39225, 0.09465  # UR5 datasheet
    rng = np.random.default_rng(8)
    assert [c.name for c in _find(rep, chain, [sp.sin(q5)], rng)] == ["wrist"]
    assert [c.name for c in _find(rep, chain, [sp.sin(q3)], rng)] == ["elbow"]
    shoulder = d5 * sp.sin(q2 + q3 + q4) - a2 * sp.cos(q2) - a3 * sp.cos(q2 + q3)
    assert [c.name for c in _find(rep, chain, [shoulder], rng)] == ["shoulder"]
    assert len(rep.conditions) == 3


def test_stanford_arm(reports):
    chain = load_robot("stanford")
    rep = reports("stanford")
    j2, d3, j5 = (sp.Symbol(n, real=True) for n in ("j2", "d3", "j5"))
    rng = np.random.default_rng(9)
    assert [c.name for c in _find(rep, chain, [sp.sin(j5)], rng)] == ["wrist"]
    assert [c.name for c in _find(rep, chain, [sp.sin(j2)], rng)] == ["shoulder"]  # arm along axis 1
    (ext,) = _find(rep, chain, [d3], rng)  # no extension: the wrist centre on the shoulder axis
    assert ext.inside_limits == (chain.lower[2] <= 0 <= chain.upper[2])


# ---- seed 004 ---------------------------------------------------------------------------------------------


def test_seed_004_arm_is_singular_stretched_upwards():
    # the paper: th2 = 90 deg, th3 = 90 deg (th3 = -90 deg folds the forearm onto the vehicle)
    chain = load_robot("grasp4dof")
    rep = analyse(chain, samples=2000, seed=1)
    assert rep.status == "factored" and not rep.singular_everywhere
    (cond,) = rep.conditions
    assert cond.name == "boundary" and cond.inside_limits
    assert set(cond.joints) == {"shoulder", "elbow"}
    num = _Numeric(chain)
    lo, hi = num.box()
    P, ok = num.project(cond.equations, np.random.default_rng(2).uniform(lo, hi, (64, 4)))
    P = P[ok]
    wrapped = lo + np.mod(P - lo, 2 * math.pi)
    inside = P[np.all((wrapped >= lo - 1e-9) & (wrapped <= hi + 1e-9), axis=1)]
    inside = lo + np.mod(inside - lo, 2 * math.pi)
    assert len(inside) >= 4
    assert np.allclose(np.degrees(inside[:, 1]), 90, atol=1e-6)  # th2 = 90 deg
    assert np.allclose(np.abs(np.degrees(inside[:, 2])), 90, atol=1e-6)  # th3 = +-90 deg
    assert (np.degrees(inside[:, 2]) > 0).any()
    # there the wrist axis lies on the waist axis: the Jacobian loses rank (recomputed)
    assert num.sv(np.array([[0.4, math.pi / 2, math.pi / 2, -1.0]]))[0, -1] < 1e-12
    # and the sampled sigma_min stays away from 0 elsewhere
    assert rep.sampling.explained == rep.sampling.near_singular


def test_seed_004_method_removes_vx_vy_and_finds_the_papers_factors():
    chain = load_robot("grasp4dof")
    q = np.random.default_rng(3).uniform(-1, 1, 4)
    assert reciprocal_free_rows(chain, q) == ("vx", "vy")  # the paper's free variables
    rows, factors = reduced_conditions(chain)
    assert rows == ("vz", "wx", "wy", "wz")
    shoulder, elbow = (sp.Symbol(n, real=True) for n in ("shoulder", "elbow"))
    assert set(factors) == {sp.cos(shoulder), sp.sin(elbow + shoulder)}
    # recomputed: the 4x4 determinant of those rows vanishes on each factor and not elsewhere
    from ikcompiler.analysis.jacobian import space_jacobians

    Q = np.random.default_rng(4).uniform(-3, 3, (50, 4))
    J = space_jacobians(chain, Q)[:, [2, 3, 4, 5], :]
    det = np.linalg.det(J)
    prod = np.cos(Q[:, 1]) * np.sin(Q[:, 1] + Q[:, 2])
    k = det / prod
    assert np.allclose(k, k[0], rtol=1e-9)  # det = const * cos(th2) sin(th2 + th3)


# ---- CLI --------------------------------------------------------------------------------------------------


def test_cli_json_schema(capsys):
    assert main(["singularities", "stanford", "--samples", "300", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert {"robot", "joints", "conditions", "singular_everywhere", "sampling", "png"} <= set(data)
    assert data["robot"] == "stanford" and data["joints"] == ["j1", "j2", "d3", "j4", "j5", "j6"]
    assert data["png"] is None and data["singular_everywhere"] is False
    assert set(data["sampling"]) == {"samples", "threshold", "near_singular", "explained"}
    assert data["sampling"]["samples"] == 300
    syms = {n: sp.Symbol(n, real=True) for n in data["joints"]}
    chain = load_robot("stanford")
    num = _Numeric(chain)
    for c in data["conditions"]:
        assert set(c) == {"name", "expr", "joints", "inside_limits"}
        assert isinstance(c["inside_limits"], bool) and c["joints"]
        e = sp.sympify(c["expr"], locals=syms)
        assert {str(s) for s in e.free_symbols} == set(c["joints"])
        P, ok = num.project([e], _random_q(chain, np.random.default_rng(0), 8))
        assert ok.any() and num.sv(P[ok])[:, -1].max() < 1e-7


def test_cli_png_and_errors(tmp_path, capsys):
    out = tmp_path / "s.png"
    assert main(["singularities", "scara", "--samples", "200", "--png", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 10000
    assert f"wrote {out}" in capsys.readouterr().out
    assert main(["singularities", "scara", "--samples", "0"]) == 2
    assert "--samples" in capsys.readouterr().err
    assert main(["singularities", "no_such_robot"]) == 2
