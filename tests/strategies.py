"""Hypothesis strategies for random screw geometry, degenerate families included, and joint values.

``twist_lists(kinds)`` draws one twist per joint kind ("R" or "T").  Each consecutive pair of joints is
placed in a relation drawn from ``RELATIONS``: general (skew), intersecting, parallel, perpendicular
(skew), perpendicular and intersecting, or coincident; unit axes along the coordinate axes and axis
points at the origin are drawn too.  ``joint_values(kinds)`` mixes the special angles 0, +-pi/2, pi into
uniform draws; prismatic values include 0.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

from subproblems.screw import prismatic_twist, revolute_twist

RELATIONS = ("general", "intersecting", "parallel", "perpendicular", "perp-intersecting", "coincident")
SPECIAL_ANGLES = (0.0, math.pi / 2, -math.pi / 2, math.pi)

_coord = st.floats(-2.0, 2.0, allow_nan=False, allow_infinity=False, width=64)
_vec = st.tuples(_coord, _coord, _coord).map(np.array)
_unit_axes = st.sampled_from([np.eye(3)[i] * s for i in range(3) for s in (1.0, -1.0)])


@st.composite
def unit_vectors(draw) -> np.ndarray:
    if draw(st.booleans()):
        return draw(_unit_axes)
    v = draw(_vec)
    while np.linalg.norm(v) < 0.3:
        v = v + np.array([0.5, 0.1, 0.2])
    return v / np.linalg.norm(v)


def _perpendicular_to(w, v) -> np.ndarray:
    u = v - (v @ w) * w
    if np.linalg.norm(u) < 1e-3:
        u = np.cross(w, [1.0, 0, 0]) if abs(w[0]) < 0.9 else np.cross(w, [0, 1.0, 0])
    return u / np.linalg.norm(u)


@st.composite
def twist_lists(draw, kinds: str, relations=RELATIONS):
    """(twists, relations_used): twists as an (m, 6) array."""
    twists, used = [], []
    prev_w, prev_r = None, None
    for kind in kinds:
        w = draw(unit_vectors())
        r = draw(_vec) if draw(st.integers(0, 4)) else np.zeros(3)
        rel = "general"
        if prev_w is not None:
            rel = draw(st.sampled_from(relations))
            if rel == "intersecting":
                r = prev_r.copy()
            elif rel == "parallel":
                w = prev_w.copy() * draw(st.sampled_from([1.0, -1.0]))
            elif rel == "perpendicular":
                w = _perpendicular_to(prev_w, w)
            elif rel == "perp-intersecting":
                w = _perpendicular_to(prev_w, w)
                r = prev_r.copy()
            elif rel == "coincident":
                w, r = prev_w.copy(), prev_r.copy()
            used.append(rel)
        twists.append(revolute_twist(w, r) if kind == "R" else prismatic_twist(w))
        prev_w, prev_r = w, r
    return np.array(twists), tuple(used)


@st.composite
def joint_values(draw, kinds: str):
    """One value per joint: revolute in (-pi, pi] with special angles, prismatic in [-2, 2] with 0."""
    out = []
    for kind in kinds:
        if kind == "R":
            if draw(st.integers(0, 3)) == 0:
                out.append(draw(st.sampled_from(SPECIAL_ANGLES)))
            else:
                out.append(draw(st.floats(-math.pi, math.pi, allow_nan=False)))
        else:
            if draw(st.integers(0, 5)) == 0:
                out.append(0.0)
            else:
                out.append(draw(st.floats(-2.0, 2.0, allow_nan=False)))
    return np.array(out)


def angle_distance(a, b) -> float:
    """Distance between two angles on the circle."""
    return abs(math.remainder(float(a) - float(b), 2 * math.pi))


def contains_solution(Q, q_true, kinds: str, tol: float = 1e-9) -> bool:
    """True when a row of Q equals q_true (angles modulo 2 pi), to ``tol`` relative."""
    for row in np.atleast_2d(Q):
        err = 0.0
        for k, a, b in zip(kinds, row, q_true):
            err = max(err, angle_distance(a, b) if k == "R" else abs(a - b) / max(1.0, abs(b)))
        if err <= tol:
            return True
    return False
