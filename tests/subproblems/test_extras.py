"""Extras: rotate-to-plane H-R / H-T and the two-equation plane problems H-RR, H-RT, H-TR, H-TT.

Hypothesis draws the geometry (general and degenerate relations of ``twist_lists``; plane normals
general, along an axis or perpendicular to it; points general, on an axis or at the origin) and
joint values (special angles included); ``d`` is built by evaluating the left side.  See
``tests/subproblems/_checks3.py`` for what each instance must pass.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from subproblems import solve, solve_batch
from subproblems.screw import prismatic_twist, revolute_twist
from tests.strategies import joint_values, twist_lists, unit_vectors

from ._checks3 import check_instance, fk_point, random_twists

EXAMPLES = settings().max_examples
_coord = st.floats(-2.0, 2.0, allow_nan=False, allow_infinity=False)
_vec = st.tuples(_coord, _coord, _coord).map(np.array)


def budget(factor: float = 1.0) -> settings:
    return settings(max_examples=max(5, int(EXAMPLES * factor)))


@st.composite
def points(draw, twists):
    kind = draw(st.integers(0, 6))
    if kind == 0:
        return np.zeros(3)
    revs = [xi for xi in twists if xi[3:].any()]
    if kind == 1 and revs:
        xi = draw(st.sampled_from(revs))
        return np.cross(xi[3:], xi[:3]) + draw(_coord) * xi[3:]
    return draw(_vec)


@st.composite
def normals(draw, twists):
    """A plane normal: general, along a joint axis/direction, or perpendicular to one; any length."""
    kind = draw(st.integers(0, 4))
    xi = twists[draw(st.integers(0, len(twists) - 1))]
    ax = xi[3:] if xi[3:].any() else xi[:3]
    if kind == 0:
        h = ax.copy()
    elif kind == 1:
        u = draw(unit_vectors())
        h = np.cross(ax, u)
        if np.linalg.norm(h) < 1e-3:
            h = np.cross(ax, [0.3, 0.5, 0.8])
    else:
        h = draw(unit_vectors())
    return h * draw(st.sampled_from([1.0, -1.0, 2.5]))


# --------------------------------------------------------------------------------------- H-R, H-T


@pytest.mark.parametrize("code", ["H-R", "H-T"])
@budget(1.5)
@given(data=st.data())
def test_one_joint_plane_roundtrip(code, data):
    kinds = code[2:]
    tw, _ = data.draw(twist_lists(kinds))
    th = data.draw(joint_values(kinds))
    p = data.draw(points(tw))
    h = data.draw(normals(tw))
    d = float(h @ fk_point(tw, th, p))
    r = check_instance(code, kinds, tw, {"p": p, "h": h, "d": d}, th)
    if code == "H-R":
        assert len(r.q) <= 2


@pytest.mark.parametrize("code", ["H-R", "H-T"])
@budget()
@given(data=st.data())
def test_one_joint_plane_unreachable(code, data):
    kinds = code[2:]
    tw, _ = data.draw(twist_lists(kinds))
    p = data.draw(points(tw))
    h = data.draw(unit_vectors())
    xi = tw[0]
    # the extreme values of h.x over the joint's motion, and a d beyond them
    if code == "H-R":
        c = np.cross(xi[3:], xi[:3])
        u = p - c
        b = u - xi[3:] * (xi[3:] @ u)
        hp = h - xi[3:] * (xi[3:] @ h)
        span = np.linalg.norm(b) * np.linalg.norm(hp)
        centre = h @ (c + xi[3:] * (xi[3:] @ u))
    else:
        if abs(h @ xi[:3]) > 1e-6:
            return  # a prismatic joint reaches every plane it is not parallel to
        span, centre = 0.0, h @ p
    gap = data.draw(st.floats(1e-3, 3.0))
    d = centre + span + gap
    r = check_instance(code, kinds, tw, {"p": p, "h": h, "d": d})
    assert r.ls.all()
    # the least-squares answer is the closest the point gets to the plane
    assert np.allclose(r.residual, gap, rtol=1e-9, atol=1e-9)


def test_h_r_cases():
    z = revolute_twist([0, 0, 1], [1, 0, 0])
    # two, one (tangent), none (ls at the closest angle)
    assert len(solve("H-R", [z], p=[2, 0, 0], h=[1, 0, 0], d=1.5).q) == 2
    r = solve("H-R", [z], p=[2, 0, 0], h=[1, 0, 0], d=2.0)
    assert len(r.q) == 1 and not r.ls[0] and abs(r.q[0, 0]) < 1e-15
    r = solve("H-R", [z], p=[2, 0, 0], h=[0, 1, 0], d=-5.0)
    assert r.ls.all() and math.isclose(r.q[0, 0], -math.pi / 2) and math.isclose(r.residual[0], 4.0)
    # p on the axis: continuum, th = 0; exact iff the point is on the plane
    r = solve("H-R", [z], p=[1, 0, 3], h=[1, 1, 0], d=1.0)
    assert r.continuum and r.q.tolist() == [[0.0]] and not r.ls[0]
    r = solve("H-R", [z], p=[1, 0, 3], h=[1, 1, 0], d=2.0)
    assert r.continuum and r.ls[0]
    # plane parallel to the circle: continuum when it contains the circle, ls otherwise
    r = solve("H-R", [z], p=[2, 0, 3], h=[0, 0, 2], d=6.0)
    assert r.continuum and not r.ls[0]
    r = solve("H-R", [z], p=[2, 0, 3], h=[0, 0, 2], d=0.0)
    assert r.continuum and r.ls[0] and math.isclose(r.residual[0], 3.0)
    # h = 0: 0 = d
    assert solve("H-R", [z], p=[2, 0, 3], h=[0, 0, 0], d=0.0).continuum


def test_h_t_cases():
    x = prismatic_twist([1, 0, 0])
    r = solve("H-T", [x], p=[0, 0, 0], h=[2, 0, 0], d=3.0)
    assert r.q.tolist() == [[1.5]] and not r.ls[0]
    r = solve("H-T", [x], p=[0, 1, 0], h=[0, 1, 0], d=1.0)
    assert r.continuum and r.q.tolist() == [[0.0]] and not r.ls[0]
    r = solve("H-T", [x], p=[0, 1, 0], h=[0, 1, 0], d=3.0)
    assert r.continuum and r.ls[0]


def test_bad_inputs():
    from subproblems import SubproblemInputError

    z = revolute_twist([0, 0, 1], [1, 0, 0])
    with pytest.raises(SubproblemInputError):
        solve("H-R", [z], p=[2, 0], h=[1, 0, 0], d=1.0)
    with pytest.raises(SubproblemInputError):
        solve("H-R", [z], p=[2, 0, 0], d=1.0)
    with pytest.raises(SubproblemInputError):
        solve("H-R", [z], p=[2, 0, 0], h=[1, 0, 0], d=[1.0, 2.0])


def test_one_joint_plane_batch_many():
    rng = np.random.default_rng(1)
    n = 500
    w = rng.normal(size=(n, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    tw = np.array([revolute_twist(wi, ri) for wi, ri in zip(w, rng.normal(size=(n, 3)))])[:, None, :]
    p, h = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    th = rng.uniform(-math.pi, math.pi, n)
    d = np.array([h[i] @ fk_point(tw[i], [th[i]], p[i]) for i in range(n)])
    d[::7] += 10.0  # some unreachable
    b = solve_batch("H-R", tw, p=p, h=h, d=d)
    assert b.vectorised
    for i in range(0, n, 25):
        r = solve("H-R", tw[i], p=p[i], h=h[i], d=d[i])
        rows = b.q[i][b.valid[i]]
        assert len(rows) == len(r.q)
        assert np.allclose(np.sort(rows[:, 0]), np.sort(r.q[:, 0]), atol=1e-12)
        assert b.ls[i][b.valid[i]].tolist() == r.ls.tolist()


# ------------------------------------------------------------------ H-RR, H-RT, H-TR, H-TT

H_PAIRS = ["H-RR", "H-RT", "H-TR", "H-TT"]


@pytest.mark.parametrize("code", H_PAIRS)
@budget()
@given(data=st.data())
def test_plane_pair_roundtrip(code, data):
    kinds = code[2:]
    tw, _ = data.draw(twist_lists(kinds))
    th = data.draw(joint_values(kinds))
    P = np.array([data.draw(points(tw)), data.draw(points(tw))])
    H = np.array([data.draw(normals(tw)), data.draw(normals(tw))])
    D = np.array([H[k] @ fk_point(tw, th, P[k]) for k in range(2)])
    check_instance(code, kinds, tw, {"p": P, "h": H, "d": D}, th)


@budget(0.5)
@given(data=st.data())
def test_plane_pair_unreachable(data):
    tw, _ = data.draw(twist_lists("RR"))
    P = np.array([data.draw(points(tw)), data.draw(points(tw))])
    H = np.array([data.draw(unit_vectors()), data.draw(unit_vectors())])
    D = np.array([0.0, np.linalg.norm(P[1]) + 2 * np.abs(tw[:, :3]).sum() + 1.0])
    r = check_instance("H-RR", "RR", tw, {"p": P, "h": H, "d": D})
    assert r.ls.all() and len(r.q) == 1


def test_plane_pair_ur_like():
    # UR-like: h along the (parallel) axes 2-3-4; the plane pair in th_1 (vertical axis) and th_5
    z = revolute_twist([0, 0, 1], [0, 0, 0])
    y5 = revolute_twist([0, 1, 0], [0.4, 0.1, 0.9])
    P = np.array([[0.5, 0.2, 1.0], [0.1, 0.8, 0.3]])
    H = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    th = np.array([0.8, -1.1])
    D = np.array([H[k] @ fk_point([z, y5], th, P[k]) for k in range(2)])
    check_instance("H-RR", "RR", [z, y5], {"p": P, "h": H, "d": D}, th)


@pytest.mark.parametrize("code", H_PAIRS)
def test_plane_pair_batch_many(code):
    rng = np.random.default_rng(7)
    n = 200
    kinds = code[2:]
    tw = random_twists(rng, kinds, n)
    th = rng.uniform(-math.pi, math.pi, (n, 2))
    P, H = rng.normal(size=(n, 2, 3)), rng.normal(size=(n, 2, 3))
    D = np.array([[H[i, k] @ fk_point(tw[i], th[i], P[i, k]) for k in range(2)] for i in range(n)])
    b = solve_batch(code, tw, p=P, h=H, d=D)
    assert b.vectorised
    assert (b.valid & ~b.ls).any(axis=1).all()
    for i in range(0, n, 25):
        r = solve(code, tw[i], p=P[i], h=H[i], d=D[i])
        assert np.allclose(b.q[i][b.valid[i]], r.q, atol=1e-12)
