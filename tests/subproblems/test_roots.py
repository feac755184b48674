"""subproblems.roots: every root of a scalar function over an interval, scalar and vectorised."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from subproblems.roots import find_roots, find_roots_batch

GRID = 256


def _matches(found, expected, tol):
    found, expected = sorted(found), sorted(expected)
    return len(found) == len(expected) and all(abs(a - b) <= tol for a, b in zip(found, expected))


# Roots at least 2 grid steps apart (the documented guarantee), in [-1, 1].
_spaced_roots = st.lists(st.integers(-100, 100), min_size=0, max_size=5, unique=True).map(
    lambda ks: sorted(k / 100.0 for k in ks)
)


def _spread(roots, min_gap):
    out = []
    for r in roots:
        if not out or r - out[-1] >= min_gap:
            out.append(r)
    return out


@given(_spaced_roots, st.floats(0.1, 10.0), st.lists(st.booleans(), min_size=5, max_size=5))
def test_polynomial_known_roots(roots, scale, double):
    roots = _spread(roots, 4 * 2.0 / GRID)
    mult = [2 if dbl else 1 for dbl, _ in zip(double, roots)]

    def f(x):
        v = scale
        for r, m in zip(roots, mult):
            v *= (x - r) ** m
        return v * (1.0 + 0.1 * x * x)

    found = find_roots(f, -1.0, 1.0, grid=GRID)
    # simple roots to ~machine precision, double roots to ~sqrt(eps)
    assert _matches(found, roots, 1e-6), (found, roots, mult)
    for r, m in zip(roots, mult):
        if m == 1:
            assert min(abs(r - x) for x in found) <= 1e-12
    X, ok = find_roots_batch(lambda x: np.vectorize(f)(x), -1.0, 1.0, 1, grid=GRID)
    assert _matches(X[0, ok[0]].tolist(), found, 1e-6)


@given(st.integers(1, 6), st.floats(-0.99, 0.99), st.floats(-math.pi, math.pi))
def test_trig_periodic(k, c, phase):
    # cos(k x + phase) = c has exactly 2k roots on the circle
    found = find_roots(lambda x: math.cos(k * x + phase) - c, -math.pi, math.pi, periodic=True)
    assert len(found) == 2 * k, found
    assert all(-math.pi <= x < math.pi for x in found)
    for x in found:
        assert abs(math.cos(k * x + phase) - c) <= 1e-13
    X, ok = find_roots_batch(lambda x: np.cos(k * x + phase) - c, -math.pi, math.pi, 2, periodic=True)
    for i in range(2):
        assert _matches(X[i, ok[i]].tolist(), found, 1e-12)


@given(st.integers(1, 4), st.floats(-math.pi, math.pi))
def test_trig_tangent(k, phase):
    # cos(k x + phase) = 1: k double roots
    found = find_roots(lambda x: math.cos(k * x + phase) - 1.0, -math.pi, math.pi, periodic=True)
    assert len(found) == k, found
    expected = sorted(
        -math.pi + (((2 * math.pi * j - phase) / k) + math.pi) % (2 * math.pi) for j in range(k)
    )
    for e in expected:
        assert min(abs(math.remainder(e - x, 2 * math.pi)) for x in found) <= 1e-6


def test_roots_at_interval_ends():
    assert _matches(find_roots(lambda x: x * (x - 1.0), 0.0, 1.0), [0.0, 1.0], 1e-15)
    assert _matches(find_roots(math.sin, 0.0, math.pi), [0.0, math.pi], 1e-15)
    # periodic: the root at pi is the same as the one at -pi
    assert _matches(find_roots(math.sin, -math.pi, math.pi, periodic=True), [-math.pi, 0.0], 1e-15)
    X, ok = find_roots_batch(np.sin, -math.pi, math.pi, 1, periodic=True)
    assert _matches(X[0, ok[0]].tolist(), [-math.pi, 0.0], 1e-15)
    # a double root at an end of a non-periodic interval
    assert _matches(find_roots(lambda x: (x - 1.0) ** 2, 0.0, 1.0), [1.0], 1e-7)


def test_no_roots_and_close_pairs():
    assert find_roots(lambda x: x * x + 1.0, -3.0, 3.0) == []
    # two roots in one coarse cell: found through the local minimum of |f|
    assert _matches(find_roots(lambda x: (x - 0.15) * (x - 0.1502), 0.0, 1.0, grid=10), [0.15, 0.1502], 1e-14)


def test_batch_mixed_counts():
    c = np.array([[-2.0], [-1.0], [0.0], [0.5], [1.0]])
    X, ok = find_roots_batch(lambda x: np.cos(x) - c, -math.pi, math.pi, 5, periodic=True)
    assert ok.sum(axis=1).tolist() == [0, 1, 2, 2, 1]
    for i in range(5):
        ref = find_roots(lambda x, i=i: math.cos(x) - c[i, 0], -math.pi, math.pi, periodic=True)
        assert _matches(X[i, ok[i]].tolist(), ref, 1e-7)


def test_bad_arguments():
    with pytest.raises(ValueError):
        find_roots(math.sin, 1.0, 0.0)
    with pytest.raises(ValueError):
        find_roots(lambda x: math.inf, 0.0, 1.0)
