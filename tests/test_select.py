"""Selection among one target's solutions (issue 13 item 1; issue 12 item 4): joint-limit aliases on
hand-made ranges (exactly 2 pi, wider, one-sided), exclusion, nearest with weights, sigma_min."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ikcompiler import load_robot
from ikcompiler.compiler import compile_robot

TWO_PI = 2 * math.pi

# A SCARA (RRTR, mm): j1 exactly 2 pi of range, j2 wider than 2 pi, j3 a quill, j4 one-sided.
SPEC = """
name = "scara_limits"
units = "mm"
angles = "deg"
joints = "RRTR"
[[joint]]
name = "j1"
axis = [0, 0, 1]
point = [0, 0, 0]
lower = -180
upper = 180
[[joint]]
name = "j2"
axis = [0, 0, 1]
point = [325, 0, 0]
lower = {j2_lower}
upper = {j2_upper}
[[joint]]
name = "j3"
axis = [0, 0, -1]
lower = 0
upper = 200
[[joint]]
name = "j4"
axis = [0, 0, -1]
point = [600, 0, 0]
lower = 0
upper = inf
[home]
xyz = [600, 0, 0]
rpy = [180, 0, 0]
"""


def _scara(tmp_path, j2_lower=-400, j2_upper=400):
    f = tmp_path / f"scara_{j2_lower}_{j2_upper}.toml".replace("-", "m")
    f.write_text(SPEC.format(j2_lower=j2_lower, j2_upper=j2_upper))
    return load_robot(str(f)), compile_robot(str(f))


@pytest.fixture(scope="module")
def scara(tmp_path_factory):
    return _scara(tmp_path_factory.mktemp("scara"))


def _pose_error(module, q, T):
    G = module.fk(q)
    return max(np.linalg.norm(G[:3, 3] - T[:3, 3]), module.SCALE * np.abs(G[:3, :3] - T[:3, :3]).max())


def test_aliases_every_in_limit_value(scara):
    chain, m = scara
    q = np.array([math.radians(100), math.radians(30), 50.0, 1.0])
    T = m.fk(q)
    plain = m.solve(T)
    assert len(plain) == 2  # elbow left / right
    rows = m.solve(T, aliases=True)
    # j1 (range exactly 2 pi, value inside): one value; j2 (+-400 deg): v - 2pi, v, v + 2pi all inside
    # (|v| < 40 deg); j4 one-sided: one value; so 3 rows per solution
    assert len(rows) == 6
    for r in rows:
        assert _pose_error(m, r, T) <= 1e-9 * m.SCALE
        assert chain.lower[1] <= r[1] <= chain.upper[1] and r[3] >= 0  # as returned, no modulo
    for base in plain:
        mine = rows[np.abs(np.remainder(rows[:, 1] - base[1] + math.pi, TWO_PI) - math.pi) < 1e-9]
        mine = mine[np.abs(mine[:, 0] - base[0]) < 1e-9]
        v = math.remainder(base[1], TWO_PI)
        assert sorted(mine[:, 1]) == pytest.approx([v - TWO_PI, v, v + TWO_PI], abs=1e-9)


def test_alias_at_both_ends_of_an_exactly_2pi_range(scara):
    _, m = scara
    q = np.array([math.pi, math.radians(20), 10.0, 2.0])
    T = m.fk(q)
    rows = m.solve(T, aliases=True)
    j1 = rows[np.abs(np.abs(rows[:, 0]) - math.pi) < 1e-9][:, 0]
    assert np.any(j1 > 3) and np.any(j1 < -3)  # pi and -pi: both inside [-180, 180] deg
    assert np.all(np.abs(rows[:, 0]) <= math.pi + 1e-7)


def test_one_sided_limit_takes_the_alias_inside(scara):
    _, m = scara
    q = np.array([0.3, 0.4, 20.0, 5.5])  # j4 = 5.5 rad: its wrapped value 5.5 - 2 pi < 0 is outside
    T = m.fk(q)
    rows = m.solve(T, aliases=True)
    assert len(rows) and np.all(rows[:, 3] >= 0)
    assert np.any(np.abs(rows[:, 3] - 5.5) < 1e-9)
    near = m.nearest(T, q)
    assert near is not None and np.abs(near - q).max() < 1e-9


def test_limits_exclude_and_solve_info_says_which_joint(tmp_path):
    _, m = _scara(tmp_path, j2_lower=0, j2_upper=180)  # the elbow-right branch (j2 < 0) is outside
    q = np.array([0.3, 0.8, 20.0, 1.0])
    T = m.fk(q)
    info = m.solve_info(T)
    assert len(info.q) == 1 and info.q[0][1] > 0
    assert len(info.excluded) == 1 and info.excluded[0].joints == ("j2",)
    assert info.excluded[0].q[1] < 0
    assert _pose_error(m, info.excluded[0].q, T) <= 1e-9 * m.SCALE
    # the quill out of its range: every solution excluded, by j3
    q_out = np.array([0.3, 0.8, 250.0, 1.0])
    info = m.solve_info(m.fk(q_out))
    assert len(info.q) == 0 and len(info.excluded) == 2
    assert {e.joints for e in info.excluded} <= {("j3",), ("j2", "j3")}
    assert m.nearest(m.fk(q_out), q_out) is None


def test_q_seed_order_and_nearest_with_weights(scara):
    _, m = scara
    q = np.array([0.3, 0.8, 20.0, 1.0])
    T = m.fk(q)
    a, b = sorted(m.solve(T), key=lambda r: -r[1])  # a: j2 > 0, b: j2 < 0
    seed = np.array([b[0], a[1], 20.0, (a[3] + b[3]) / 2])  # half of each branch

    def expected(w):
        rows = m.solve(T, aliases=True)
        d = (rows - seed) * np.asarray(w)
        d[:, 2] /= m.SCALE
        return rows[int(np.argmin(np.sqrt((d * d).sum(axis=1))))]

    heavy_j1 = m.nearest(T, seed, weights=[10, 1, 1, 1])
    heavy_j2 = m.nearest(T, seed, weights=[1, 10, 1, 1])
    assert np.allclose(heavy_j1, expected([10, 1, 1, 1])) and abs(heavy_j1[0] - b[0]) < 1e-9
    assert np.allclose(heavy_j2, expected([1, 10, 1, 1])) and abs(heavy_j2[1] - a[1]) < 1e-9
    rows = m.solve(T, q_seed=seed, weights=[1, 10, 1, 1])
    assert np.allclose(rows[0], heavy_j2)
    with pytest.raises(ValueError, match="4 joints"):
        m.solve(T, q_seed=[0.0, 0.0])


@pytest.fixture(scope="module")
def prob():
    return compile_robot("prob")


def _fd_sigma(m, q, h=1e-6):
    """sigma_min from a central-difference Jacobian of fk (independent of the module's own)."""
    cols = []
    for j in range(len(q)):
        e = np.zeros(len(q))
        e[j] = h
        Gp, Gm = m.fk(q + e), m.fk(q - e)
        v = (Gp[:3, 3] - Gm[:3, 3]) / (2 * h) / m.SCALE
        W = (Gp[:3, :3] - Gm[:3, :3]) / (2 * h) @ m.fk(q)[:3, :3].T
        cols.append(np.concatenate([v, [W[2, 1], W[0, 2], W[1, 0]]]))
    return np.linalg.svd(np.array(cols).T, compute_uv=False)[-1]


def test_solve_info_fields_and_sigma_min(prob):
    m = prob
    q = np.radians([10, 30, 40, 20, 50, 10])
    info = m.solve_info(m.fk(q))
    assert info._fields == ("q", "residual", "ls", "continuum", "sigma_min", "excluded")
    assert len(info.sigma_min) == len(info.q) >= 1
    for row, s in zip(info.q, info.sigma_min):
        assert s == pytest.approx(_fd_sigma(m, row), rel=1e-5)
    assert info.sigma_min.min() > 1e-2
    for q_sing in (np.radians([10, 30, 40, 20, 0, 10]), np.radians([30, 60, 90, 45, -90, 0])):  # wrist, elbow
        sig = m.solve_info(m.fk(q_sing), q_seed=q_sing).sigma_min
        assert sig[0] < 1e-6


@given(v=st.floats(-20, 20), lo=st.floats(-15, 15), width=st.floats(0, 20))
def test_aliases_are_exactly_the_in_limit_values(v, lo, width):
    """Against brute force: every v + 2 pi k inside [lo, lo + width], and nothing else."""
    from subproblems.select import aliases, excluding_joints

    hi = lo + width
    rows, src = aliases(np.array([[v, 0.5]]), "RT", [lo, 0.0], [hi, 1.0])
    expect = [v + TWO_PI * k for k in range(-10, 11) if lo - 1e-7 <= v + TWO_PI * k <= hi + 1e-7]
    if expect:
        assert sorted(rows[:, 0]) == pytest.approx(sorted(expect), abs=1e-12)
        assert np.all(rows[:, 1] == 0.5) and np.all(src == 0)
        assert not excluding_joints(rows, "RT", [lo, 0.0], [hi, 1.0]).any()
    else:  # no alias inside: the row is kept as solved, and its joint excludes it
        assert rows.tolist() == [[v, 0.5]]
        assert excluding_joints(rows, "RT", [lo, 0.0], [hi, 1.0]).tolist() == [[True, False]]
