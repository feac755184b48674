"""The general-6r native path (subproblems/general6.h; docs/general6.md, "Native path") against the
Python elimination (subproblems/general6.py) it stands beside: the same solution sets on random 6R
arms and on 6-joint arms with prismatic joints, complete and exact at 1e-12 of the size on the zoo's
Jaco (random and special-angle poses), roots at th = pi of the eliminated joint, and the doubtful
targets handed back to Python still answered completely.

The C answers a target itself or hands it back (``NativeChain.exact`` returns None); both are counted
here, and a handed-back target must be solved by the module all the same."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ikcompiler import compile_robot, load_robot
from ikcompiler.configs import random_6r_chain, random_6r_geometry
from ikcompiler.model import Chain, Joint
from ikcompiler.verify import sample_configurations
from subproblems import native

pytestmark = pytest.mark.skipif(native.compiler() is None, reason="no C compiler on this machine")

SAME = 1e-6  # two rows are one solution (rad; prismatic values relative to the size)
PRECISION = 1e-12  # the contract: position / size and Frobenius rotation
HANDED_BACK = 0.05  # at most this share of random targets may go to the Python path (measured: ~1%)
COLLIDE = 1e-4  # general6's G6_COLLIDE: rows at a double root are found to 1e-6..4e-5 rad (see _covers)

_MODULES: dict[str, tuple] = {}


def _module(key, chain):
    """(module, its NativeChain), compiled once per session."""
    if key not in _MODULES:
        module = compile_robot(chain)
        assert module.METHOD == "general-6r", module.METHOD
        with pytest.MonkeyPatch.context() as mp:
            mp.delenv("IKC_NATIVE", raising=False)
            nc = module._SOLVER.native_chain()
        assert nc is not None, native.last_error
        _MODULES[key] = (module, nc)
    return _MODULES[key]


def _prismatic_chain(kinds: str, seed: int) -> Chain:
    """A random general arm whose joints marked T slide along their drawn directions (limits +-size)."""
    twists, home = random_6r_geometry(seed)
    joints = []
    for i, kind in enumerate(kinds):
        if kind == "T":
            joints.append(Joint(f"j{i + 1}", "T", np.r_[twists[i, 3:], 0.0, 0.0, 0.0], -2.0, 2.0))
        else:
            joints.append(Joint(f"j{i + 1}", "R", twists[i], -math.pi, math.pi))
    return Chain(f"random-{kinds.lower()}-{seed}", tuple(joints), home)


def _gap(rows, Q, prism, size):
    """(len(rows), len(Q)) joint distance: revolute modulo 2 pi, prismatic over the size."""
    d = rows[:, None, :] - Q[None, :, :]
    turn = np.abs(np.angle(np.exp(1j * d)))
    return np.where(prism, np.abs(d) / size, turn).max(axis=2)


def _exact(module, rows, T):
    """Round trip of every row at the contract's precision, recomputed by forward kinematics."""
    for row in rows:
        G = module.fk(row)
        dp = np.linalg.norm(G[:3, 3] - T[:3, 3]) / module.SCALE
        dR = np.linalg.norm(G[:3, :3] - T[:3, :3])
        assert max(dp, dR) <= PRECISION, (row, dp, dR)


def _compare(module, nc, Q, T):
    """C rows against the Python general6 rows (limits off) on every target; returns the handed-back
    count.  Each C answer must be the Python set, exact, and hold the sampled vector."""
    prism = np.array([k == "T" for k in module.JOINT_TYPES])
    back = 0
    for n in range(len(T)):
        rows = nc.exact(T[n], (), False)
        module.NATIVE = False
        try:
            reference = module.solve(T[n], limits=False)
        finally:
            module.NATIVE = True
        if rows is None:
            back += 1
            rows = module.solve(T[n], limits=False)  # the module's own answer: Python for this target
        assert len(rows) == len(reference), (n, len(rows), len(reference))
        if len(rows):
            d = _gap(rows, reference, prism, module.SCALE)
            assert d.min(axis=1).max() < SAME and d.min(axis=0).max() < SAME, n
        assert _gap(rows, Q[n:n + 1], prism, module.SCALE).min() < SAME, (n, Q[n])
        _exact(module, rows, T[n])
    return back


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_arms_same_sets_as_python(seed):
    module, nc = _module(f"r{seed}", random_6r_chain(seed))
    rng = np.random.default_rng(100 + seed)
    Q = rng.uniform(-math.pi, math.pi, size=(150, 6))
    T = np.array([module.fk(q) for q in Q])
    back = _compare(module, nc, Q, T)
    assert back <= HANDED_BACK * len(T), back


def test_deflated_pencil_stays_python():
    """An arm whose preferred arrangement needs the deflated 9 x 9 pencil (a prismatic joint on each
    side of the split: TRTRRR here) has no C chain, and its module says so (NATIVE False: one rule,
    csource.general6_native_arrangements)."""
    module = compile_robot(_prismatic_chain("TRTRRR", 1))
    assert module.METHOD == "general-6r"
    arr = module._GENERAL6._arr[module._GENERAL6.usable[0]]
    assert arr.deflate is not None and module._SOLVER.native_chain() is None
    assert module.NATIVE is False


@pytest.mark.parametrize("kinds", ["TRRRRR", "RRRRRT", "TTRRRR", "RRRRTT", "RTRRRR", "RRTRRR", "RRRTRR"])
def test_prismatic_same_sets_as_python(kinds):
    """Prismatic joints at a, b (TRRRRR ...) and at d or e (RTRRRR: general6.py prefers its joint 2 at
    d; RRTRRR, RRRTRR): the C's rows are the Python general6's."""
    chain = _prismatic_chain(kinds, 1)
    module, nc = _module(kinds, chain)
    prism = np.array([k == "T" for k in kinds])
    rng = np.random.default_rng(7)
    Q = rng.uniform(-math.pi, math.pi, size=(80, 6))
    Q[:, prism] = rng.uniform(-1.0, 1.0, size=(80, int(prism.sum()))) * module.SCALE
    T = np.array([module.fk(q) for q in Q])
    back = _compare(module, nc, Q, T)
    assert back <= HANDED_BACK * len(T), back


def test_jaco_complete_and_exact():
    """The zoo's Jaco on random poses inside its limits: every sampled vector among ``solve``'s rows
    (native single pose) and ``solve_batch``'s (native batch), every row exact."""
    robot = load_robot("jaco")
    module, nc = _module("jaco", robot)
    Q = sample_configurations(robot, 200, seed=3, special=0.0)
    T = np.array([module.fk(q) for q in Q])
    S, V = module.solve_batch(T)
    prism = np.zeros(6, dtype=bool)
    back = 0
    for n in range(len(T)):
        back += nc.exact(T[n], (), True) is None
        rows = module.solve(T[n])
        assert _gap(rows, Q[n:n + 1], prism, module.SCALE).min() < SAME, (n, Q[n])
        _exact(module, rows, T[n])
        batch = S[n][V[n]]
        assert len(batch) == len(rows) and _gap(batch, rows, prism, module.SCALE).min(axis=1).max() < SAME, n
    assert back <= HANDED_BACK * len(T), back


def _covers(module, nc, Q, T):
    """C rows against the reference runtime's (NATIVE False), limits off, where double roots are common:
    every reference row within COLLIDE of a C row, every C row exact, the C's distinct solutions (1e-4
    apart) at least the reference's.  At a double root the rows of both paths are found only to
    1e-6..4e-5 rad (each exact; the pose error is quadratic or flatter in the distance there), so the two
    clouds are compared at general6's G6_COLLIDE.  Returns (handed back, C recovered, reference
    recovered) at SAME."""
    prism = np.zeros(6, dtype=bool)
    back = c_hit = r_hit = 0
    for n in range(len(T)):
        rows = nc.exact(T[n], (), False)
        module.NATIVE = False
        try:
            reference = module.solve(T[n], limits=False)
        finally:
            module.NATIVE = True
        if rows is None:
            back += 1
            rows = module.solve(T[n], limits=False)
        _exact(module, rows, T[n])
        if len(reference):
            assert len(rows) and _gap(reference, rows, prism, module.SCALE).min(axis=1).max() < COLLIDE, n
        assert _distinct(rows) >= _distinct(reference), n
        c_hit += bool(len(rows)) and _gap(rows, Q[n:n + 1], prism, module.SCALE).min() < SAME
        r_hit += bool(len(reference)) and _gap(reference, Q[n:n + 1], prism, module.SCALE).min() < SAME
    return back, c_hit, r_hit


def _distinct(rows):
    """Solutions among rows: rows within COLLIDE of an earlier kept one are that one."""
    kept = []
    for q in rows:
        if not kept or _gap(np.array(kept), q[None], np.zeros(6, dtype=bool), 1.0).min() >= COLLIDE:
            kept.append(q)
    return len(kept)


def test_jaco_special_poses_as_python():
    """Special-angle poses of the Jaco (a third of the joint values at 0, +-pi/2, pi: double roots
    and aligned axes are common there): the C answers them (its certified path, or for the targets
    doubtful under every arrangement general6.py's eigenvalue path in C, g6_eigen_leaves) with the
    reference runtime's solutions, exact, recovering at least as many sampled vectors."""
    robot = load_robot("jaco")
    module, nc = _module("jaco", robot)
    Q = sample_configurations(robot, 150, seed=4, special=0.3)
    T = np.array([module.fk(q) for q in Q])
    back, c_hit, r_hit = _covers(module, nc, Q, T)
    assert back <= 2, back
    assert c_hit >= r_hit, (c_hit, r_hit)


def test_eliminated_joint_at_pi():
    """th_c = pi is an ordinary point of the trigonometric form: targets whose solution has the
    eliminated joint (and every other joint in turn) at pi are answered by the C, complete."""
    module, nc = _module("r0", random_6r_chain(0))
    solver = module._GENERAL6
    c = solver._arr[solver.usable[0]].order[2]
    rng = np.random.default_rng(5)
    Q = rng.uniform(-math.pi, math.pi, size=(24, 6))
    Q[:12, c] = math.pi
    Q[12:, np.arange(12) % 6] = math.pi
    T = np.array([module.fk(q) for q in Q])
    back = _compare(module, nc, Q, T)
    assert back <= 2, back


def test_header_thresholds_are_the_tolerances():
    """general6.h's G6_* thresholds are subproblems/tolerances.py's (the C mirrors the Python names)."""
    import re
    from pathlib import Path

    from subproblems import tolerances

    text = (Path(native.__file__).with_name("general6.h")).read_text()
    found = dict(re.findall(r"#define (G6_[A-Z_]+) ([0-9.e+-]+)", text))
    mirrored = {k: v for k, v in found.items() if hasattr(tolerances, k)}
    assert {"G6_RANK", "G6_CLOSE", "G6_NEAR_DOUBLE", "G6_NOISE", "G6_CLEAN"} <= set(mirrored)
    for name, value in mirrored.items():
        assert float(value) == getattr(tolerances, name), name


def _first_arrangement_only(module, robot):
    """The module's C with its first arrangement alone (what the C ran before the re-solve)."""
    from ikcompiler.codegen import csource
    from subproblems import general6 as g6

    ns = vars(module)
    solver = g6.General6(robot.twists, robot.home, robot.scale, arrangement=[module._GENERAL6.usable[0]])
    src = csource.module_c_source(ns, general6=solver)
    return native.bind(src, dof=6, slots=ns["MAX_SOLUTIONS"], nfree=0, target="pose")


def test_jaco_first_arrangement_alone_settles_special_poses_in_c():
    """The module's C with its first arrangement alone: before the eigenvalue path (general6.h
    g6_eigen_leaves) it handed back the targets doubtful under that arrangement (the re-solve under the
    next one rescued some, as this test counted); now the targets doubtful under it take the eigenvalue
    path, and its answers cover the reference runtime's, exact, with as many sampled vectors."""
    robot = load_robot("jaco")
    module, _ = _module("jaco", robot)
    assert len(csource_arrangements(module)) >= 2
    first = _first_arrangement_only(module, robot)
    Q = sample_configurations(robot, 150, seed=4, special=0.3)
    T = np.array([module.fk(q) for q in Q])
    back, c_hit, r_hit = _covers(module, first, Q, T)
    assert back <= 2, back
    assert c_hit >= r_hit, (c_hit, r_hit)


def csource_arrangements(module):
    from ikcompiler.codegen.csource import general6_native_arrangements

    return general6_native_arrangements(module._GENERAL6)


def test_jaco_all_special_poses_settle_in_c():
    """Poses with every Jaco joint at 0, +-pi/2 or pi: 56% of them have the sampled vector at a singular
    configuration (a double root of det M) and 17% a pencil singular at the target, which the certified
    root isolation cannot answer; before the eigenvalue path in C (g6_eigen_leaves) 198 of these 400 went
    to the Python general6 at ~0.1 s each.  Now the C settles them with the reference runtime's
    solutions (every reference row within COLLIDE of a C row, exact), recovering at least as many
    sampled vectors."""
    robot = load_robot("jaco")
    module, nc = _module("jaco", robot)
    Q = sample_configurations(robot, 400, seed=21, special=1.0)
    T = np.array([module.fk(q) for q in Q])
    back, c_hit, r_hit = _covers(module, nc, Q, T)
    assert back <= 4, back
    assert c_hit >= r_hit, (c_hit, r_hit)


def test_a_later_arrangements_clean_zero_after_a_doubtful_one_is_not_taken():
    """example-robot-data's xarm7.urdf perturbed by 1e-6 (seed 7), joint7 free (configs.compile_chain's
    choice), at a nearly singular special pose: the first two C arrangements find the target doubtful and
    the third answered cleanly with no root (its noisy D stayed above zero at the solutions' pair), so
    the batch path returned no row for a pose with three.  docs/general6.md, "Native path" item 5."""
    from ikcompiler import configs, robotdb
    from ikcompiler.verify import joint_distance

    try:
        robotdb.require(robotdb.EXTRA)
    except robotdb.RobotPackageError as exc:
        pytest.fail(f"{exc} (this test needs the robots extra)", pytrace=False)
    entry = next(e for e in robotdb.discover(packages=("example-robot-data",)).chains
                 if e.rel.endswith("/xarm7.urdf") and e.tip == "link_eef")
    chain = configs.perturbed(entry.load(), 1e-6, seed=7)
    compiled = configs.compile_chain(chain)
    module = compiled.module
    assert module.METHOD == "general-6r" and compiled.free == ("joint7",)
    q = np.array([-math.pi / 2, -0.04497680711458196, 0.0, math.pi / 2, -math.pi / 2, -math.pi / 2, math.pi])
    G = chain.fk_batch(q[None])  # the target verify builds (bits matter here)
    S, filled, ls, _, _ = module.solve_batch_info(G, np.array([math.pi]))
    rows = S[0][filled[0] & ~ls[0]]
    assert len(rows), "no row for a reachable pose"
    err = [max(np.linalg.norm(chain.fk(r)[:3, 3] - G[0, :3, 3]),
               chain.scale * np.linalg.norm(chain.fk(r)[:3, :3] - G[0, :3, :3])) for r in rows]
    assert max(err) <= PRECISION * chain.scale
    assert joint_distance(rows, q[None], chain.joint_types, chain.scale).min() <= SAME
