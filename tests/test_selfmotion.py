"""Self-motion flags on the general 6R elimination's rows (ikcompiler/runtime/selfmotion.py; docs/design.md
section 6): a row on a continuum of solutions is flagged, an isolated double root is not."""

from __future__ import annotations

import math

import numpy as np

from ikcompiler import compile_robot, configs
from ikcompiler.runtime import selfmotion
from ikcompiler.verify import verify


def _det(chain, q):
    J = chain.space_jacobian(q).copy()
    J[:3] /= chain.scale
    return np.linalg.det(J)


def _singular_configuration(chain, seed=0):
    """A configuration of ``chain`` with det J = 0, by bisection on joint 5 (fixed seed)."""
    q = np.random.default_rng(seed).uniform(-math.pi, math.pi, 6)
    at = lambda x: _det(chain, np.r_[q[:4], x, q[5]])  # noqa: E731
    xs = np.linspace(-math.pi, math.pi, 721)
    vals = [at(x) for x in xs]
    i = next(i for i in range(720) if vals[i] * vals[i + 1] < 0)
    a, b = xs[i], xs[i + 1]
    for _ in range(80):
        c = 0.5 * (a + b)
        a, b = (a, c) if at(a) * at(c) <= 0 else (c, b)
    return np.r_[q[:4], 0.5 * (a + b), q[5]]


def test_an_isolated_double_root_is_not_flagged():
    chain = configs.random_6r_chain(3)
    module = compile_robot(chain)
    assert module.METHOD == "general-6r"
    q = _singular_configuration(chain)
    J = chain.space_jacobian(q).copy()
    J[:3] /= chain.scale
    assert np.linalg.svd(J, compute_uv=False)[-1] < selfmotion.RANK_DEFICIENT  # the test's premise
    T = chain.fk(q)
    assert not selfmotion.flags(module._SOLVER.robot, q[None], T[None]).any()
    info = module.solve_info(T, limits=False)
    assert not info.continuum.any(), info


def test_modular_trrrrt_special_poses_are_recovered_or_flagged_self_motions():
    """The configuration zoo's modular TRRRRT (seed 0) at special angles: 8 of 10 sampled poses lie on
    a self-motion (two axes lined up), where the elimination returns points of the family; before the
    flags verify counted 8 misses (benchmarks/results/configurations.md, 2/10 recovered)."""
    chain = configs.modular_chain("TRRRRT", seed=0, geometry="modular")
    module = configs.compile_chain(chain).module
    assert module.METHOD == "general-6r"
    report = verify(chain, module, samples=10, seed=1, special=1.0, scalar_checks=2)
    assert report.wrong == 0 and report.missed == 0, report.text()
    assert report.self_motion > 0 and report.recovered + report.self_motion == report.poses, report.text()
    info = module.solve_info(chain.fk(np.array([0.19662, math.pi / 2, math.pi / 2, math.pi / 2, -math.pi / 2,
                                                0.02289])), limits=False)
    assert len(info.q) and info.continuum.all(), info
