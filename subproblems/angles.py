"""Angle wrapping: the one representative of a revolute value in (-pi, pi] (docs/design.md section 10).

Every solver, the reference runtime and the fast finish wrap through here.  The wrap is exact: the
result is ``x - 2 pi k`` for the float ``2 pi``, computed without rounding (IEEE ``remainder`` for a
float; ``fmod`` and one subtraction that Sterbenz's lemma makes exact for an array), so a value that is
already in (-pi, pi] comes back unchanged and the scalar and array wraps agree bit for bit.  ``-pi``
itself is returned as ``pi`` (the contract's half-open interval).

>>> wrap(-math.pi), wrap(3 * math.pi / 2) == -math.pi / 2, wrap(0.1) == 0.1
(3.141592653589793, True, True)
>>> wrap_array(np.array([-math.pi, 1e-20, 7.0])).tolist() == [math.pi, 1e-20, wrap(7.0)]
True
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["TWO_PI", "wrap", "wrap_array", "wrap_joints"]

TWO_PI = 2.0 * math.pi


def wrap(x: float) -> float:
    """The representative of angle ``x`` in (-pi, pi]."""
    w = math.remainder(float(x), TWO_PI)
    return math.pi if w <= -math.pi else w


def wrap_array(x) -> np.ndarray:
    """:func:`wrap` elementwise, bit for bit (a new float array of the shape of ``x``)."""
    r = np.fmod(np.asarray(x, dtype=float), TWO_PI)  # exact, in (-2 pi, 2 pi)
    r = np.where(r > math.pi, r - TWO_PI, r)  # exact: r and 2 pi are within a factor 2
    return np.where(r <= -math.pi, r + TWO_PI, r)


def wrap_joints(Q, kinds) -> np.ndarray:
    """Joint values ``Q`` (..., n) with the revolute ones (``kinds[i] == "R"``) wrapped, the prismatic
    ones unchanged (a new array)."""
    Q = np.array(Q, dtype=float)
    for i, k in enumerate(kinds):
        if k == "R":
            Q[..., i] = wrap_array(Q[..., i])
    return Q
