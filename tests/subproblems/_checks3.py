"""Checks shared by the class III and extras tests (not a test module).

``check_instance`` is the proof-by-test of one instance whose right-hand side was built by evaluating
the left side at ``q_true``:

* the drawn values come back (1e-9, angles modulo 2 pi) unless the result is a continuum (then every
  representative must satisfy the equation); near a singular configuration (two roots merging, the
  Jacobian of the equations nearly rank-deficient) the problem itself is ill-conditioned and 1e-6 is
  accepted;
* every row not flagged ``ls`` satisfies the equation(s);
* the vectorised path returns the same solutions and flags.
"""

from __future__ import annotations

import math

import numpy as np

from subproblems import max_solutions, solve, solve_batch
from subproblems.screw import twist_exp
from tests.strategies import angle_distance, contains_solution

TOL = 1e-9
RESIDUAL_TOL = TOL  # an exact row of a pair solver: its equations hold to TOL of the instance scale


def distance(v) -> float:
    """``|v|`` without underflow (``np.linalg.norm`` squares first: a point 2.5e-247 from another read
    as distance 0, an instance inconsistent in its own data)."""
    return math.hypot(*np.asarray(v, dtype=float))


def fk_point(twists, th, p) -> np.ndarray:
    g = np.eye(4)
    for xi, a in zip(twists, th):
        g = g @ twist_exp(xi, a)
    return g[:3, :3] @ np.asarray(p, dtype=float) + g[:3, 3]


def signed_residuals(code, tw, qrow, inputs) -> np.ndarray:
    """The equations of ``code`` at ``qrow`` as a vector (0 at an exact solution)."""
    P = np.atleast_2d(inputs["p"])
    D = np.atleast_1d(inputs["d"])
    out = []
    for k in range(len(D)):
        x = fk_point(tw, qrow, P[k])
        if code.startswith("S3"):
            out.append(distance(x - np.atleast_2d(inputs["q"])[k]) - D[k])
        else:
            h = np.atleast_2d(inputs["h"])[k]
            hn = np.linalg.norm(h)
            out.append((h @ x - D[k]) / hn if hn > 0 else -D[k])
    return np.array(out)


def random_twists(rng, kinds: str, n: int) -> np.ndarray:
    """(n, m, 6) twists in general position, one row of joint kinds per instance."""
    from subproblems.screw import prismatic_twist, revolute_twist

    return np.array(
        [
            [
                revolute_twist(rng.normal(size=3), rng.normal(size=3))
                if k == "R"
                else prismatic_twist(rng.normal(size=3))
                for k in kinds
            ]
            for _ in range(n)
        ]
    )


def near_singular(code, tw, inputs, q_true, scale) -> bool:
    """True when the equations' Jacobian at q_true is nearly rank-deficient (ill-conditioned roots)."""
    eps = 1e-6
    q_true = np.asarray(q_true, dtype=float)
    cols = []
    for i in range(len(q_true)):
        dq = np.zeros_like(q_true)
        dq[i] = eps
        cols.append(
            (
                signed_residuals(code, tw, q_true + dq, inputs)
                - signed_residuals(code, tw, q_true - dq, inputs)
            )
            / (2 * eps)
        )
    J = np.array(cols).T
    sv = np.linalg.svd(J, compute_uv=False)
    return bool(sv.min() <= 1e-3 * scale)


def problem_scale(tw, inputs) -> float:
    vals = [1.0]
    for v in inputs.values():
        vals.append(float(np.abs(np.asarray(v, dtype=float)).max()))
    for xi in tw:
        vals.append(float(np.linalg.norm(np.cross(xi[3:], xi[:3]))))
    return max(vals)


def same_rows(A, B, kinds, tol=1e-7) -> bool:
    """Every row of A is near a row of B and vice versa."""

    def near(r, s):
        return all(
            (angle_distance(a, b) if k == "R" else abs(a - b) / max(1.0, abs(b))) <= tol
            for k, a, b in zip(kinds, r, s)
        )

    A, B = np.atleast_2d(A), np.atleast_2d(B)
    return all(any(near(r, s) for s in B) for r in A) and all(any(near(s, r) for r in A) for s in B)


def check_instance(code, kinds, tw, inputs, q_true=None, *, batch=True):
    """Run the checks of the module docstring; returns the scalar Result."""
    r = solve(code, tw, **inputs)
    scale = problem_scale(tw, inputs)
    m = len(kinds)
    assert r.q.shape[1] == m and len(r.q) <= max_solutions(code), r
    assert np.all(np.isfinite(r.q)) and np.all(np.isfinite(r.residual)), r
    assert len(r.q) >= 1, r  # every instance has an answer (exact, ls or a representative)
    exact = ~r.ls
    # the residual of every exact row recomputed from forward kinematics, not taken from the solver
    for row in r.q[exact]:
        got = np.abs(signed_residuals(code, tw, row, inputs)).max()
        assert got <= RESIDUAL_TOL * scale, (r, row, got)
    if q_true is not None:
        if r.continuum:
            assert exact.any(), r
        else:
            assert exact.any(), r
            ok = contains_solution(r.q[exact], q_true, kinds, TOL)
            if not ok and near_singular(code, tw, inputs, q_true, scale):
                ok = contains_solution(r.q[exact], q_true, kinds, 1e-6)
            assert ok, (r, q_true)
    if batch:
        arrays = {k: np.asarray(v, dtype=float)[None] for k, v in inputs.items()}
        b = solve_batch(code, np.asarray(tw)[None], **arrays)
        rows = b.q[0][b.valid[0]]
        assert bool(b.continuum[0]) == r.continuum, (b, r)
        assert same_rows(rows, r.q, kinds), (rows, r.q)
        assert sorted(b.ls[0][b.valid[0]].tolist()) == sorted(r.ls.tolist()), (b, r)
    return r
