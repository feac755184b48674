"""A row Newton placed after clamping a value onto its limit is merged with a copy of its solution
within SPLIT_ROOT (1e-6, verify's recovery tolerance), in the C finish and in the reference runtime
(docs/design.md section 11, "Duplicates").

Measured (benchmarks/results/real_robots_unseen.md, 722bff9: the one duplicate of 94,070 poses):
example-robot-data's Alexander, PELVIS_LINK -> LEFT_FOOT_IMU_LINK, a general-6r chain, at the sampled
vector below (knee straight, q4 = 0 at its lower limit, a root of higher multiplicity: the general-6r
path returns exact points of it spread by 1e-6..3e-6).  One of them, 1.3e-6 below the knee's limit,
was clamped onto it and polished with the knee held: it stopped 9.9e-7 from another exact row, and the
finish, merging at 1e-9 there, returned both.
"""

from __future__ import annotations

import numpy as np
import pytest

from ikcompiler import configs, robotdb
from ikcompiler.verify import SAME_ANGLE

SAMPLED = np.array([0.0, -0.18728665247138304, -0.49601244788073773, 0.0, 0.0, 0.3641606842536483])


@pytest.fixture(scope="module")
def module():
    try:
        robotdb.require(["example-robot-data"])
    except robotdb.RobotPackageError as exc:
        pytest.fail(f"{exc} (this test needs the robots extra)", pytrace=False)
    files = [p for p, rel in robotdb.description_files("example-robot-data")
             if rel.endswith("alexander_v1.lowerBodyOnly.urdf")]
    assert files, "example-robot-data: alexander_v1.lowerBodyOnly.urdf not found (did the package change?)"
    from ikcompiler import load_robot

    chain = load_robot(files[0], base="PELVIS_LINK", tip="LEFT_FOOT_IMU_LINK")
    return configs.compile_chain(chain).module


def _closest_pair(rows) -> float:
    best = np.inf
    for a in range(len(rows)):
        for b in range(a):
            d = np.abs(np.remainder(rows[a] - rows[b] + np.pi, 2 * np.pi) - np.pi).max()
            best = min(best, d)
    return best


@pytest.mark.parametrize("native", [True, False], ids=["C finish", "reference runtime"])
def test_no_two_rows_within_the_recovery_tolerance(module, native):
    module.NATIVE = native
    try:
        T = module.fk(SAMPLED)
        rows = np.asarray(module.solve(T))
    finally:
        module.NATIVE = True
    assert len(rows)
    for q in rows:  # every row exact on the true robot (recomputed by FK)
        G = module.fk(q)
        assert max(np.abs(G[:3, 3] - T[:3, 3]).max() / module.SCALE, np.linalg.norm(G[:3, :3] - T[:3, :3])) < 1e-12
    assert np.abs(np.remainder(rows - SAMPLED + np.pi, 2 * np.pi) - np.pi).max(axis=1).min() <= SAME_ANGLE
    assert _closest_pair(rows) > SAME_ANGLE
