"""S2-RRR's least-squares th3 at a complex root's projection (``s2_rrr.least_squares_b``): the b that
minimises ``|M (cos b, sin b) - E|``, checked against a dense scan of the circle (scalar and batch)."""

from __future__ import annotations

import numpy as np

from subproblems.s2_rrr import least_squares_b, least_squares_b_batch


def _scan(M, E, n=200_001):
    b = np.linspace(-np.pi, np.pi, n)
    r = np.linalg.norm(np.stack([np.cos(b), np.sin(b)], -1) @ M.T - E, axis=-1)
    return b[r.argmin()], r.min()


def _cost(M, E, b):
    return float(np.linalg.norm(M @ [np.cos(b), np.sin(b)] - E))


def test_on_the_circle_the_least_squares_b_is_the_root():
    rng = np.random.default_rng(3)
    for _ in range(20):
        M = rng.normal(size=(2, 2))
        b0 = rng.uniform(-np.pi, np.pi)
        E = M @ [np.cos(b0), np.sin(b0)]
        b = least_squares_b(M, E)
        assert abs(np.angle(np.exp(1j * (b - b0)))) < 1e-9


def test_off_the_circle_it_is_the_global_minimum_also_for_a_nearly_singular_matrix():
    rng = np.random.default_rng(4)
    Ms, Es = [], []
    for k in range(30):
        M = rng.normal(size=(2, 2))
        if k % 2:  # nearly rank 1 (axes 2 and 3 nearly parallel): Cramer's direction says little
            U, _, Vt = np.linalg.svd(M)
            M = U @ np.diag([1.0, 3e-3]) @ Vt
        E = rng.normal(size=2)
        b_scan, r_scan = _scan(M, E)
        b = least_squares_b(M, E)
        assert _cost(M, E, b) <= r_scan + 1e-9
        Ms.append(M)
        Es.append(E)
    bb = least_squares_b_batch(np.array(Ms), np.array(Es)[:, None])
    for M, E, b in zip(Ms, Es, bb[:, 0]):
        assert abs(_cost(M, E, b) - _cost(M, E, least_squares_b(M, E))) <= 1e-12
