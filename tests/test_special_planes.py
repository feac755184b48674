"""Self-motions at special poses that the C finish now settles (docs/design.md section 6, "Exact
tangent lines and planes"): an exact self-motion line flagged a tangent root whose second null
direction is a double root's (stanford at q2 = pi, prob), and a self-motion plane whose fixed joint
lies outside its limits (panda's stretched elbow q4 = 0 with joints 1, 3 and 5 coaxial; prob's wrist
at q5 = pi).  Before this finish each of these poses went to the reference runtime (0.1-0.3 s).

Each pose: the C finish settles it, gives its specification's rows bit for bit (subproblems/settle.py),
and its exact rows are the reference runtime's (NATIVE off: the Python fast chain and the reference
runtime), as sets to 1e-9."""

from __future__ import annotations

import math

import numpy as np
import pytest

from subproblems import fast, native, settle
from tests.test_finish_spec import _same_sets, _spec_robot
from tests.test_native import _compiled

pytestmark = pytest.mark.skipif(native.compiler() is None, reason="no C compiler")

H, P = math.pi / 2, math.pi
POSES = [  # joint vectors of benchmarks/special_poses.py's special set (seed 7) that were handed back
    ("stanford", [P, P, 0.9313, 0.0, 0.0, P]),  # q2 = pi (outside its limits): double root + wrist lock
    ("stanford", [-H, P, 0.2150 * H, H, 0.0, -H]),
    ("panda", [0.0, 0.0, 0.0, 0.0, P, 0.0, 0.0]),  # q4 = 0 outside [-3.07, -0.07]: a plane, no row
    ("panda", [0.0, 0.0, P, 0.0, -H, 0.0, -H]),  # the same plane, and one isolated row inside the limits
    ("panda", [H, P, 0.0, 0.0, 0.0, 0.0, P]),
    ("prob", [0.0, P, -H, P, P, 0.0]),  # q5 = pi outside +-115 deg
    ("prob", [-H, H, -H, P, P, P]),
    ("prob", [0.0, H, H, 0.0, P, H]),
]


@pytest.mark.parametrize("name, q", POSES)
def test_special_self_motion_settles_in_c_with_the_reference_runtimes_rows(name, q):
    module, _, chain = _compiled(name)
    q = np.array(q)
    free_cols = [module.JOINT_NAMES.index(f) for f in module.FREE_JOINTS]
    free = tuple(float(q[c]) for c in free_cols)
    T = module.fk(q)
    found = chain.one(T, free, True)
    assert found is not None, (name, q.tolist(), chain.last_reason())
    spec = settle.settle(_spec_robot(module), fast.goal_entries(T, module.TARGET), free, True)
    assert spec != settle.PYTHON and len(spec) == len(found[0])
    for k, (sq, sres, sls, scont) in enumerate(spec):
        assert np.array_equal(found[0][k], np.array(sq)) and found[1][k] == sres
        assert (bool(found[2][k]), bool(found[3][k])) == (sls, scont)
    module.NATIVE = False
    try:
        ref = module.solve_info(T, *free)
    finally:
        module.NATIVE = True
    c = module.solve_info(T, *free)
    assert _same_sets(c.q[~c.ls], ref.q[~ref.ls], module.JOINT_TYPES), (name, q.tolist(), c.q, ref.q)
    for row in c.q[~c.ls]:
        assert np.abs(module.fk(row) - T).max() <= module.TOLERANCE * module.SCALE
