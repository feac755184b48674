"""Runs of slides driven by one master fold into one slide (ikcompiler/model/fold.py; docs/design.md
section 2, "Folded slides"): the folded chain's FK is the URDF's, joint by joint, and the compiled module
solves in closed form, in the master's value, inside the intersected limits."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ikcompiler import load_robot
from ikcompiler.compiler import compile_plan, compile_robot
from ikcompiler.errors import RobotInputError
from ikcompiler.model import Chain, Coupling, Joint
from ikcompiler.model.fold import fold_slides
from ikcompiler.verify import sample_configurations, verify
from subproblems import native
from subproblems.screw import revolute_twist

URDF = Path(__file__).parent / "data" / "folded_slides.urdf"


def _rot(axis, angle) -> np.ndarray:
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _tree(tip: str):
    """The URDF's joints base -> tip, read with lxml (independent of the loader)."""
    from lxml import etree

    root = etree.parse(str(URDF)).getroot()
    by_child = {el.find("child").get("link"): el for el in root.findall("joint")}
    path, link = [], tip
    while link in by_child:
        path.append(by_child[link])
        link = by_child[link].find("parent").get("link")
    return list(reversed(path)), {el.get("name"): el for el in root.findall("joint")}


def _walk(values: dict, tip: str) -> np.ndarray:
    """The tip's pose walking the URDF joint by joint (origin, then the joint's motion); ``values`` gives
    the independent joints, every mimic joint's value follows its <mimic> (to its master)."""
    path, by_name = _tree(tip)

    def value(el) -> float:
        m = el.find("mimic")
        if m is None:
            return values[el.get("name")]
        return float(m.get("multiplier")) * value(by_name[m.get("joint")]) + float(m.get("offset"))

    g = np.eye(4)
    for el in path:
        o = el.find("origin")
        step = np.eye(4)
        r, p, y = [float(x) for x in o.get("rpy", "0 0 0").split()]
        step[:3, :3] = _rot([0, 0, 1], y) @ _rot([0, 1, 0], p) @ _rot([1, 0, 0], r)
        step[:3, 3] = [float(x) for x in o.get("xyz").split()]
        g = g @ step
        if el.get("type") != "fixed":
            axis = np.array([float(x) for x in el.find("axis").get("xyz").split()])
            motion = np.eye(4)
            if el.get("type") == "prismatic":
                motion[:3, 3] = value(el) * axis / np.linalg.norm(axis)
            else:
                motion[:3, :3] = _rot(axis, value(el))
            g = g @ motion
    return g


def _allowed(q1: float) -> bool:
    """Whether arm_1 = q1 keeps every slide of the run inside its own <limit>, from the URDF text."""
    path, by_name = _tree("tool")

    def value(el) -> float:
        m = el.find("mimic")
        if m is None:
            return q1
        return float(m.get("multiplier")) * value(by_name[m.get("joint")]) + float(m.get("offset"))

    for el in path:
        if el.get("name").startswith("arm_") and el.get("type") == "prismatic":
            lim = el.find("limit")
            if not float(lim.get("lower")) <= value(el) <= float(lim.get("upper")):
                return False
    return True


def _random_values(chain, rng, n):
    lo, hi = chain.lower, chain.upper
    return rng.uniform(lo, hi, size=(n, chain.dof))


def test_fold_gives_one_slide_with_the_urdf_fk():
    chain = load_robot(URDF, tip="tool")
    assert chain.joint_types == "TTTTTRRR"
    folding = fold_slides(chain)
    assert folding.chain.joint_types == "TTRRR"
    assert folding.chain.independent_names == chain.independent_names
    # arm_1 moves 2 v + w with v, w unit and perpendicular (multipliers 1 + 2 - 1 along x, 1 along y')
    assert folding.speed == pytest.approx((1.0, math.sqrt(5.0), 1.0, 1.0, 1.0), abs=1e-14)
    rng = np.random.default_rng(3)
    for q in _random_values(chain, rng, 20):
        values = dict(zip(chain.independent_names, q))
        walk = _walk(values, "tool")
        assert np.abs(chain.fk(q) - walk).max() <= 1e-14
        assert np.abs(folding.chain.fk(q * np.array(folding.speed)) - walk).max() <= 1e-14


def test_folded_limits_are_the_intersection_of_the_members():
    chain = load_robot(URDF, tip="tool")
    hi = fold_slides(chain).chain.upper[1] / fold_slides(chain).speed[1]
    lo = fold_slides(chain).chain.lower[1] / fold_slides(chain).speed[1]
    # the ends found from the URDF's limits by bisection on the mimic values, not by the fold's formula
    a, b = 0.0, 1.0
    for _ in range(60):
        a, b = (a, (a + b) / 2) if not _allowed((a + b) / 2) else ((a + b) / 2, b)
    assert hi == pytest.approx(a, abs=1e-12)
    assert _allowed(lo) and not _allowed(lo - 1e-9)
    assert hi < chain.upper[1]  # arm_2's limits narrow arm_1's own


def test_folded_chain_compiles_in_closed_form_and_verifies():
    chain = load_robot(URDF, tip="tool")
    plan = compile_plan(chain)
    assert plan.method == "closed-form"
    assert any("folded slides" in n for n in plan.notes)
    module = compile_robot(chain)
    assert module.JOINT_NAMES == chain.independent_names
    report = verify(chain, module, samples=230, seed=5)
    assert report.recovered == report.poses and report.wrong == 0, report
    assert report.ok, report
    rng = np.random.default_rng(7)
    for q in _random_values(chain, rng, 10):
        q[1] = min(q[1], module.UPPER[1])
        walk = _walk(dict(zip(chain.independent_names, q)), "tool")
        assert np.abs(module.fk(q) - walk).max() <= 1e-14
        rows = module.solve(walk)
        assert len(rows) and np.abs(rows - q).max(axis=1).min() <= 1e-9
        assert (rows[:, 1] >= module.LOWER[1]).all() and (rows[:, 1] <= module.UPPER[1]).all()


def test_master_value_outside_a_members_limits_is_left_out():
    chain = load_robot(URDF, tip="tool")
    module = compile_robot(chain)
    q = np.array([0.4, 0.19, 0.3, -0.4, 0.5])  # arm_1 inside its own limit, arm_2 = 0.39 above its own
    T = chain.fk(q)
    assert len(module.solve(T)) == 0
    rows = module.solve(T, limits=False)
    assert np.abs(rows - q).max(axis=1).min() <= 1e-9
    info = module.solve_info(T)
    assert any("arm_1" in e.joints for e in info.excluded)


def test_seed_free_joint_and_batch_use_the_master_value():
    chain = load_robot(URDF, tip="tool")
    module = compile_robot(chain)
    rng = np.random.default_rng(11)
    Q = _random_values(chain, rng, 30)
    Q[:, 1] = np.minimum(Q[:, 1], module.UPPER[1])
    S, valid = module.solve_batch(chain.fk_batch(Q))
    for i in range(len(Q)):
        assert np.abs(S[i][valid[i]] - Q[i]).max(axis=1).min() <= 1e-9
    near = module.nearest(chain.fk(Q[0]), Q[0])
    assert np.abs(near - Q[0]).max() <= 1e-9
    info = module.solve_info(chain.fk(Q[0]))
    assert (info.sigma_min > 0).all()
    # arm_1 free: a position target of the remaining lift and wrist, arm_1 given in its own value
    free = compile_robot(chain, target="position+direction", free=("arm_1",))
    T = chain.fk(Q[2])
    rows = free.solve(T, Q[2, 1])
    assert len(rows) and np.abs(rows - Q[2]).max(axis=1).min() <= 1e-9
    assert np.all(rows[:, 1] == pytest.approx(Q[2, 1], abs=1e-12))


def test_a_coupling_outside_the_run_follows_the_folded_master():
    chain = load_robot(URDF, tip="finger")
    folding = fold_slides(chain)
    assert folding.chain.joint_types == "TTRRRT"
    assert folding.chain.independent_names == chain.independent_names
    rng = np.random.default_rng(13)
    for q in _random_values(chain, rng, 20):
        walk = _walk(dict(zip(chain.independent_names, q)), "finger")
        assert np.abs(folding.chain.fk(q * np.array(folding.speed)) - walk).max() <= 1e-14


def _spec_chain() -> Chain:
    """A master slide elsewhere than its run: m (x) then a revolute joint, then a run of two slides that
    follow m (2 m + 0.1 along y, -0.5 m along z) and a revolute joint coupled to r1."""
    joints = (
        Joint("m", "T", [1, 0, 0, 0, 0, 0], -1.0, 1.0),
        Joint("r1", "R", revolute_twist([0, 0, 1], [0.2, 0, 0])),
        Joint("s1", "T", [0, 1, 0, 0, 0, 0], -5.0, 5.0),
        Joint("s2", "T", [0, 0, 1, 0, 0, 0], -5.0, 5.0),
        Joint("r2", "R", revolute_twist([1, 0, 0], [0.3, 0.1, 0.2])),
        Joint("r3", "R", revolute_twist([0, 1, 0], [0.4, 0.1, 0.2])),
    )
    home = np.eye(4)
    home[:3, 3] = [0.5, 0.1, 0.2]
    couplings = (Coupling("s1", "m", 2.0, 0.1), Coupling("s2", "m", -0.5, 0.0),
                 Coupling("r3", "r1", 0.5, 0.2))
    return Chain("spec", joints, home, couplings)


def test_run_driven_by_a_master_elsewhere_is_one_coupled_slide():
    chain = _spec_chain()
    folding = fold_slides(chain)
    assert folding.chain.joint_types == "TRTRR"
    assert folding.speed == (1.0, 1.0, 1.0)  # the master m keeps its own value
    rng = np.random.default_rng(17)
    for q in rng.uniform(-1, 1, size=(20, chain.dof)):
        assert np.abs(folding.chain.fk(q) - chain.fk(q)).max() <= 1e-14
    assert not fold_slides(folding.chain).folded  # folding is idempotent


def test_empty_intersection_of_limits_raises_naming_the_joints():
    joints = (Joint("a", "T", [1, 0, 0, 0, 0, 0], 0.0, 1.0), Joint("b", "T", [1, 0, 0, 0, 0, 0], 3.0, 4.0))
    chain = Chain("bad", joints, np.eye(4), (Coupling("b", "a", 1.0, 0.0),))
    with pytest.raises(RobotInputError, match="'a'.*no value"):
        fold_slides(chain)


def _gantry() -> Chain:
    """A gantry (x, y, a telescoping z of two slides: z2 = 2 z1 + 0.05) with a spherical wrist: after the
    fold TTTRRR, whose plan (S2-TTT at the wrist centre, O-RRR) has fast kernels and a C translation."""
    c = np.array([0.3, 0.1, 0.2])
    joints = (
        Joint("x", "T", [1, 0, 0, 0, 0, 0], -1.0, 1.0),
        Joint("y", "T", [0, 1, 0, 0, 0, 0], -1.0, 1.0),
        Joint("z1", "T", [0, 0, -1, 0, 0, 0], 0.0, 0.4),
        Joint("z2", "T", [0, 0, -1, 0, 0, 0], 0.0, 1.0),
        Joint("yaw", "R", revolute_twist([0, 0, 1], c), -3.0, 3.0),
        Joint("pitch", "R", revolute_twist([0, 1, 0], c), -3.0, 3.0),
        Joint("roll", "R", revolute_twist([1, 0, 0], c), -3.0, 3.0),
    )
    home = np.eye(4)
    home[:3, 3] = c + [0.05, 0.0, -0.1]
    return Chain("gantry", joints, home, (Coupling("z2", "z1", 2.0, 0.05),))


def test_folded_gantry_has_a_c_chain_and_verifies():
    chain = _gantry()
    assert fold_slides(chain).speed[2] == pytest.approx(3.0, abs=1e-15)
    module = compile_robot(chain)
    assert module.METHOD == "closed-form" and module.NATIVE
    report = verify(chain, module, samples=200, seed=19)
    # the spherical wrist's gimbal lock (pitch = +-pi/2 among the special angles) is a true self-motion
    assert report.ok and report.recovered == report.poses - report.self_motion, report


@pytest.mark.skipif(native.compiler() is None, reason="no C compiler")
def test_folded_chain_in_c_gives_the_python_rows():
    chain = _gantry()
    module = compile_robot(chain)
    assert module._native_chain() is not None
    # random poses only: at the gimbal lock the C and the Python return different representatives
    Q = sample_configurations(chain, 100, 23, 0.0, (module.LOWER, module.UPPER))
    Ts = chain.fk_batch(Q)
    S_c, v_c = module.solve_batch(Ts)
    module.NATIVE = False
    try:
        S_py, v_py = module.solve_batch(Ts)
    finally:
        module.NATIVE = True
    assert (v_c.sum(axis=1) == v_py.sum(axis=1)).all()
    for i in range(len(Q)):
        a, b = S_c[i][v_c[i]], S_py[i][v_py[i]]
        assert np.abs(a[:, None, :] - b[None, :, :]).max(axis=2).min(axis=1).max() <= 1e-9
        assert np.abs(a - Q[i]).max(axis=1).min() <= 1e-9
    assert np.abs(module.fk(Q[0]) - chain.fk(Q[0])).max() <= 1e-15
