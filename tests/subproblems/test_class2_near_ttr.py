"""S2-TTR / S2-RTT with two translation directions parallel (or antiparallel) to within ~1e-12.

Audit ``near`` family (``benchmarks/subproblem_audit.py``): the plane normal ``v_1 x v_2`` computed by
``np.cross`` lost most of its digits (products rounded to ~1e-16 against a result of ~1e-12), the plane
condition then missed the real root and the solver returned a least-squares row 10..1e5 away from the
drawn values, flagged ``ls`` although the instance is reachable.

The translations of such an instance are conditioned like ``1 / angle``: a 1-ulp change of ``q`` moves
the exact root of the float data by up to ~1e-4 relative (checked with mpmath).  At this angle the
equation holds to the exactness tolerance along a curve (``t_1 -+ t_2`` trading against the angle), so
the solver may flag the instance ``continuum`` with representative rows; otherwise the drawn values
must come back to 1e-3 of the problem size.  Either way the answer is exact, not least-squares, and
every exact row satisfies the equation to 1e-9.  Instances: drawn twists, ``p`` and joint values of
the audit dump (seed 7, near family); ``q`` evaluated from the left side.  Before the fix three of the
four came back least-squares (the ``ttr-parallel-large`` one passed by luck of rounding)."""

from __future__ import annotations

import numpy as np
import pytest

from subproblems import solve, solve_batch
from tests.subproblems.test_class2 import fk_point

CASES = {
    "ttr-antiparallel-1e-13": (
        "S2-TTR",
        [
            [-0.3566861707490032, -0.2260627203567544, -0.906460491175052, 0.0, 0.0, 0.0],
            [0.3566861707486907, 0.22606272035769767, 0.9064604911749399, 0.0, 0.0, 0.0],
            [-0.8024006708668401, 0.35206190150828454, -0.8347227919245441]
            + [-0.6931993480241306, -0.5864279840839831, 0.41901895348792506],
        ],
        [0.7057664574265643, -0.5799415859258913, -0.3949012483435399],
        [0.08465009708004034, 0.0, 1.3203128319299369],
    ),
    "ttr-parallel-large": (
        "S2-TTR",
        [
            [0.817954914589408, -0.3154638180048618, 0.48107414940820686, 0.0, 0.0, 0.0],
            [0.8179549145866384, -0.3154638180143507, 0.48107414940669374, 0.0, 0.0, 0.0],
            [648.2825338173287, 354.9573609012123, -902.9709710384427]
            + [-0.007904945286096305, -0.9287003167042368, -0.3707468591822109],
        ],
        [0.0, 0.0, 0.0],
        [810.1251448285942, -587.2800451801545, 0.3584557252503675],
    ),
    "rtt-parallel-quarter-turn": (
        "S2-RTT",
        [
            [-0.23296912898607725, -0.34401662111386033, 0.7859669667125736]
            + [-0.949342962686399, -0.061266088274291725, -0.3082116247408218],
            [-0.949342962686399, -0.061266088274291725, -0.3082116247408218, 0.0, 0.0, 0.0],
            [-0.9493429626878753, -0.06126608826476393, -0.30821162473816827, 0.0, 0.0, 0.0],
        ],
        [1.426547785340282, 1.3692261292594834, -0.2406941834086329],
        [1.5707963267948966, 0.0, -0.808741959459689],
    ),
    "rtt-antiparallel-large": (
        "S2-RTT",
        [
            [208.49075187774812, 367.2070652065965, -107.17547630958082]
            + [-0.2184573834704428, 0.3856647148931656, 0.8964034244098029],
            [0.2184573834805266, -0.3856647149836408, -0.8964034243684198, 0.0, 0.0, 0.0],
            [0.2184573834704428, -0.3856647148931656, -0.8964034244098029, 0.0, 0.0, 0.0],
        ],
        [404.7234576370782, 1343.2612317245848, -891.1520718994794],
        [-1.5707963267948966, -1448.359771890733, 1942.485915808546],
    ),
}


def _joint_distance(code, rows, th, size):
    d = rows - th
    for j, k in enumerate(code[3:]):
        d[:, j] = (d[:, j] + np.pi) % (2 * np.pi) - np.pi if k == "R" else d[:, j] / size
    return np.abs(d).max(axis=1)


@pytest.mark.parametrize("name", sorted(CASES))
def test_nearly_parallel_translations_answer_exactly(name):
    code, tw, p, th = CASES[name]
    tw, p, th = np.array(tw), np.array(p), np.array(th)
    q = fk_point(tw, th, p)
    size = max(1.0, float(np.abs(p).max()), float(np.abs(q).max()), float(np.abs(tw[:, :3]).max()))
    r = solve(code, tw, p=p, q=q)
    b = solve_batch(code, tw[None], p=p[None], q=q[None])
    ok = b.valid[0]
    for rows, flags, cont in ((r.q, r.ls, r.continuum), (b.q[0][ok], b.ls[0][ok], b.continuum[0])):
        assert len(rows) and not flags.all(), "reachable instance flagged least-squares"
        for row, ls in zip(rows, flags):
            if not ls:
                assert np.linalg.norm(fk_point(tw, row, p) - q) <= 1e-9 * size
        assert cont or _joint_distance(code, rows.copy(), th, size).min() <= 1e-3
