"""The compiler routes 6R pose targets without a closed form to the general 6R elimination."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np

from ikcompiler import compile_robot, load_robot
from ikcompiler.compiler import compile_source
from ikcompiler.model import Chain, Joint
from ikcompiler.verify import verify
from subproblems.screw import revolute_twist


def _random_chain(seed: int) -> Chain:
    """Axis directions uniform on the sphere, axis points in a 1 m cube: no closed form."""
    rng = np.random.default_rng(seed)
    joints = []
    for i in range(6):
        twist = revolute_twist(rng.normal(size=3), rng.uniform(-0.5, 0.5, 3))
        joints.append(Joint(f"j{i + 1}", "R", twist, -math.pi, math.pi))
    home = np.eye(4)
    home[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    return Chain(f"random-6r-{seed}", tuple(joints), home)


def _recovered_and_exact(chain, module, Q):
    T = chain.fk_batch(Q)
    S, V = module.solve_batch(T)
    size = chain.scale
    for n in range(len(Q)):
        rows = S[n][V[n]]
        assert len(rows), n
        d = np.abs(np.angle(np.exp(1j * (rows - Q[n])))).max(axis=1)
        assert d.min() < 1e-6, (n, Q[n])
        G = chain.fk_batch(rows)
        assert np.linalg.norm(G[:, :3, 3] - T[n, :3, 3], axis=1).max() <= 1e-12 * size
        assert np.linalg.norm(G[:, :3, :3] - T[n, :3, :3], axis=(1, 2)).max() <= 1e-12


def test_random_arm_compiles_to_general_6r_and_recovers_every_pose():
    chain = _random_chain(4)
    module = compile_robot(chain)
    assert module.METHOD == "general-6r"
    assert module.MAX_SOLUTIONS == 16
    Q = np.random.default_rng(2).uniform(-math.pi, math.pi, size=(60, 6))
    _recovered_and_exact(chain, module, Q)
    # the single-pose API agrees with the batch
    T = chain.fk_batch(Q[:5])
    S, V = module.solve_batch(T)
    for n in range(5):
        assert len(module.solve(T[n])) == V[n].sum()


def test_generated_module_imports_only_numpy_subproblems_and_the_runtime(tmp_path):
    source = compile_source(_random_chain(5))
    lines = [line for line in source.splitlines() if line.startswith(("import ", "from "))]
    imports = {line.split()[1] for line in lines}
    assert imports <= {"math", "numpy", "subproblems", "__future__", "ikcompiler"}, imports
    # of ikcompiler only its runtime (docs/design.md section 6)
    assert [x for x in lines if "ikcompiler" in x] == ["from ikcompiler import runtime as _runtime"]
    assert "from subproblems import general6 as _g6" in source
    assert "METHOD = 'general-6r'" in source
    path = tmp_path / "random_ik.py"
    path.write_text(source)
    cmd = [sys.executable, "-m", "ruff", "check", "--no-cache", "--isolated", str(path)]
    res = subprocess.run(cmd, capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr


def test_jaco_generic_poses_complete_with_nothing_wrong():
    """The Jaco's wrist obeys no closed-form rule: it was a 1-D search (94-96% recovered), now general-6r."""
    chain = load_robot("jaco")
    module = compile_robot(chain)
    assert module.METHOD == "general-6r"
    report = verify(chain, module, samples=120, seed=1, scalar_checks=10, special=0.0)
    assert report.wrong == 0 and report.missed == 0 and report.recovered == report.poses, report.text()
    assert report.max_error <= 1e-12, report.text()


def test_jaco_with_limits_returns_rows_inside_them():
    chain = load_robot("jaco")
    module = compile_robot(chain)
    Q = np.random.default_rng(3).uniform(chain.lower, chain.upper, size=(30, 6))
    S, V = module.solve_batch(chain.fk_batch(Q))
    rows = S[V]
    assert len(rows)
    assert np.all(rows >= chain.lower - 1e-9) and np.all(rows <= chain.upper + 1e-9)


def test_five_joint_arm_position_direction_target_through_the_virtual_roll():
    """A 5R arm's position + direction target is a 6R pose problem with the virtual tool roll."""
    rng = np.random.default_rng(3)
    twists = [revolute_twist(rng.normal(size=3), rng.uniform(-0.5, 0.5, 3)) for _ in range(5)]
    joints = tuple(Joint(f"j{i + 1}", "R", tw, -math.pi, math.pi) for i, tw in enumerate(twists))
    home = np.eye(4)
    home[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    chain = Chain("random-5r", joints, home)
    module = compile_robot(chain, target="position+direction")
    assert module.METHOD == "general-6r" and len(module.JOINT_NAMES) == 5
    report = verify(chain, module, samples=60, seed=1, scalar_checks=5, special=0.0)
    assert report.wrong == 0 and report.recovered == report.poses, report.text()
