"""The one wrap (``subproblems.angles``) and the one forward kinematics (``subproblems.screw.fk``).

The wrap is exact: ``wrap(x) = x - 2 pi k`` for the float ``2 pi`` and an integer ``k``, in (-pi, pi],
so a value already there comes back unchanged; the array wrap and the C finish's ``ikc_wrap`` agree
with it bit for bit (they replaced ten copies, some of which rounded, one of which returned -pi)."""

from __future__ import annotations

import ctypes
import math
from fractions import Fraction

import numpy as np
import pytest

from subproblems import native
from subproblems.angles import TWO_PI, wrap, wrap_array, wrap_joints
from subproblems.screw import fk, fk_batch, prismatic_twist, revolute_twist, twist_exp


def _values():
    rng = np.random.default_rng(11)
    edges = [0.0, -0.0, 1e-300, -1e-300, 1e-20, math.pi, -math.pi, TWO_PI, -TWO_PI, 3 * math.pi,
             -3 * math.pi, math.nextafter(math.pi, 4.0), math.nextafter(-math.pi, -4.0),
             math.nextafter(-math.pi, 0.0), 1e6 + 0.5, -1e15, 1e300]
    return np.concatenate([edges, rng.uniform(-4, 4, 2000), rng.uniform(-1e3, 1e3, 2000),
                           math.pi * rng.integers(-9, 10, 200)])


def test_wrap_is_exact_and_in_the_half_open_interval():
    for x in _values():
        w = wrap(x)
        assert -math.pi < w <= math.pi
        k = (Fraction(float(x)) - Fraction(w)) / Fraction(TWO_PI)  # exact rational arithmetic
        assert k.denominator == 1, (x, w)
        if -math.pi < x <= math.pi:
            assert w == x


def test_array_wrap_and_joint_wrap_agree_with_the_scalar_bit_for_bit():
    x = _values()
    np.testing.assert_array_equal(wrap_array(x), [wrap(v) for v in x])
    Q = np.stack([x, x * 0.5], axis=1)
    W = wrap_joints(Q, "RT")
    np.testing.assert_array_equal(W[:, 0], wrap_array(x))
    np.testing.assert_array_equal(W[:, 1], x * 0.5)  # prismatic values untouched


def test_c_finish_wrap_is_the_same_function():
    if native.compiler() is None:
        pytest.skip("no C compiler found (set CC, or install gcc)")
    path = native.build("double shim_wrap(double x) { return ikc_wrap(x); }\n")
    assert path is not None, native.last_error
    fn = ctypes.CDLL(str(path)).shim_wrap
    fn.restype, fn.argtypes = ctypes.c_double, [ctypes.c_double]
    for x in _values():
        assert fn(float(x)) == wrap(x), x


def test_fk_batch_is_fk_row_by_row():
    rng = np.random.default_rng(4)
    twists = np.array([
        revolute_twist(rng.normal(size=3), rng.normal(size=3)),
        prismatic_twist(rng.normal(size=3)),
        revolute_twist(rng.normal(size=3), rng.normal(size=3)),
    ])
    home = twist_exp(revolute_twist([0, 1, 0], [1, 0, 0]), 0.4)
    Q = rng.uniform(-4, 4, size=(7, 3))
    G = fk_batch(twists, Q, home)
    for q, g in zip(Q, G):
        np.testing.assert_allclose(g, fk(twists, q, home), rtol=0, atol=1e-14)
        direct = twist_exp(twists[0], q[0]) @ twist_exp(twists[1], q[1]) @ twist_exp(twists[2], q[2]) @ home
        np.testing.assert_allclose(g, direct, rtol=0, atol=1e-14)
    # one chain per row, broadcast over a second axis of joint vectors
    per_row = np.stack([twists, twists[::-1]])
    QQ = rng.uniform(-4, 4, size=(2, 5, 3))
    GG = fk_batch(per_row[:, None], QQ)
    for i in range(2):
        for k in range(5):
            np.testing.assert_allclose(GG[i, k], fk(per_row[i], QQ[i, k]), rtol=0, atol=1e-14)
