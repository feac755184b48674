"""The zoo: every robot loads, and its FK agrees with a computation that shares no code with the loader.

URDF robots are checked against yourdfpy's own forward kinematics, DH robots against a direct product of
DH matrices written here, spec robots against a product of twist exponentials computed here by a power
series.  All to 1e-12 relative to the robot's size.  The CLI is exercised on the zoo too.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from ikcompiler.cli import main
from ikcompiler.errors import UnknownRobotError
from ikcompiler.inputs import load_robot
from ikcompiler.inputs.zoo import resolve, zoo_dir, zoo_names

ZOO = zoo_names()
N_SAMPLES = 25


# ---- independent references --------------------------------------------------------------------------


def expm_series(A: np.ndarray) -> np.ndarray:
    """Matrix exponential by scaling and squaring of a Taylor series (no Rodrigues formula)."""
    norm = float(np.abs(A).sum(axis=1).max())
    s = max(0, int(math.ceil(math.log2(norm))) + 1) if norm > 0.5 else 0
    B = A / 2**s
    term, out = np.eye(4), np.eye(4)
    for k in range(1, 30):
        term = term @ B / k
        out = out + term
    for _ in range(s):
        out = out @ out
    return out


def twist_hat(v, w) -> np.ndarray:
    W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]], dtype=float)
    X = np.zeros((4, 4))
    X[:3, :3] = W
    X[:3, 3] = v
    return X


def rpy(r, p, y) -> np.ndarray:
    cx, sx, cy, sy, cz, sz = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx],
            [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx],
            [-sy, cy * sx, cy * cx],
        ]
    )


def pose_table(tbl, deg: bool) -> np.ndarray:
    if "matrix" in tbl:
        return np.array(tbl["matrix"], dtype=float)
    g = np.eye(4)
    k = math.pi / 180 if deg else 1.0
    g[:3, :3] = rpy(*(np.array(tbl.get("rpy", [0, 0, 0]), dtype=float) * k))
    g[:3, 3] = tbl.get("xyz", [0, 0, 0])
    return g


def spec_fk(data: dict, theta) -> np.ndarray:
    """``prod exp(xi_i^ th_i) g_st(0)`` straight from the spec file's numbers."""
    g = np.eye(4)
    for j, kind, t in zip(data["joint"], data["joints"], theta):
        if "twist" in j:
            tw = np.array(j["twist"], dtype=float)
            v, w = tw[:3], tw[3:]
            n = np.linalg.norm(w) if kind == "R" else np.linalg.norm(v)
            v, w = v / n, w / n
        else:
            a = np.array(j["axis"], dtype=float)
            a = a / np.linalg.norm(a)
            if kind == "R":
                w, v = a, np.cross(np.array(j["point"], dtype=float), a)
            else:
                w, v = np.zeros(3), a
        g = g @ expm_series(twist_hat(v, w) * t)
    return g @ pose_table(data["home"], data.get("angles") == "deg")


def dh_matrix(convention: str, a, alpha, d, theta) -> np.ndarray:
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    if convention == "standard":  # Rz(theta) Tz(d) Tx(a) Rx(alpha)
        return np.array(
            [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1]]
        )
    # modified (Craig): Rx(alpha) Tx(a) Rz(theta) Tz(d)
    return np.array(
        [
            [ct, -st, 0, a],
            [st * ca, ct * ca, -sa, -sa * d],
            [st * sa, ct * sa, ca, ca * d],
            [0, 0, 0, 1],
        ]
    )


def dh_fk(data: dict, q) -> np.ndarray:
    deg = data.get("angles") == "deg"
    k = math.pi / 180 if deg else 1.0
    g = pose_table(data["base"], deg) if "base" in data else np.eye(4)
    for row, qi in zip(data["row"], q):
        a, alpha = row.get("a", 0.0), row.get("alpha", 0.0) * k
        d, theta = row.get("d", 0.0), row.get("theta", 0.0) * k
        if row["type"] == "R":
            theta += qi
        else:
            d += qi
        g = g @ dh_matrix(data["convention"], a, alpha, d, theta)
    return g @ (pose_table(data["tool"], deg) if "tool" in data else np.eye(4))


def sample(chain, rng, n: int) -> np.ndarray:
    lo = np.where(np.isfinite(chain.lower), chain.lower, -1.0)
    hi = np.where(np.isfinite(chain.upper), chain.upper, 1.0)
    return rng.uniform(lo, hi, size=(n, chain.dof))


def yourdfpy_fk(path, chain, Q):
    import yourdfpy

    u = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=True)
    out = []
    for q in Q:
        u.update_cfg(dict(zip(chain.independent_names, q)))
        out.append(u.get_transform(chain.tip, chain.base))
    return np.array(out)


# ---- tests -----------------------------------------------------------------------------------------------


def test_zoo_has_every_format_and_the_required_robots():
    files = {name: resolve(name).name for name in ZOO}
    kinds = {f.rsplit(".", 1)[-1] for f in files.values()}
    assert kinds == {"urdf", "toml"}
    assert any(f.endswith(".dh.toml") for f in files.values())
    for name in ("rhino", "shadow_index", "shadow_thumb", "prob", "arm4dof", "puma560", "stanford", "scara"):
        assert name in ZOO
    strings = {name: load_robot(name).joint_types for name in ZOO}
    for js in ("TRRRRR", "RRTRRR", "RRTR", "TTTRRR", "RTT", "RRRRRRR", "RRRR", "RRRRR"):
        assert js in strings.values(), js


def test_every_zoo_file_cites_a_source():
    for name in ZOO:
        text = resolve(name).read_text()
        assert "Source:" in text, name


@pytest.mark.parametrize("name", ZOO)
def test_zoo_robot_fk_matches_independent_computation(name):
    path = resolve(name)
    chain = load_robot(name)
    assert chain.n >= 3 and chain.dof >= 3
    rng = np.random.default_rng(abs(hash(name)) % 2**32)
    Q = sample(chain, rng, N_SAMPLES)
    Q[0] = 0.0
    tol = 1e-12 * chain.scale
    got = chain.fk_batch(Q)
    if path.name.endswith(".urdf"):
        want = yourdfpy_fk(path, chain, Q)
    else:
        data = tomllib.loads(path.read_text())
        if "row" in data:
            want = np.array([dh_fk(data, q) for q in Q])
        else:
            want = np.array([spec_fk(data, chain.expand(q)) for q in Q])
    assert np.abs(got[:, :3, 3] - want[:, :3, 3]).max() <= tol
    assert np.abs(got[:, :3, :3] - want[:, :3, :3]).max() <= 1e-12
    # limits are realistic: finite for revolute joints, and not all the default +-pi
    assert all(math.isfinite(j.lower) and math.isfinite(j.upper) for j in chain.joints if j.kind == "R")


def test_rhino_is_exactly_the_design_example():
    chain = load_robot("rhino")
    want = [
        (1, 0, 0, 0, 0, 0),
        (0, -200, 0, 0, 0, 1),
        (-200, 0, 200, 0, 1, 0),
        (-200, 0, 400, 0, 1, 0),
        (-200, 0, 500, 0, 1, 0),
        (0, 200, 0, 1, 0, 0),
    ]
    assert chain.joint_types == "TRRRRR" and chain.units == "mm"
    assert np.array_equal(chain.twists, np.array(want, dtype=float))
    home = np.eye(4)
    home[:3, 3] = (600, 0, 200)
    assert np.array_equal(chain.home, home)
    # the paper's first solution reproduces its printed target to its 4 printed digits
    q = [20, 0.5236, 0.3491, 0.1745, -0.6981, 0.3491]
    R = [[0.8529, -0.5213, 0.0297], [0.4924, 0.7841, -0.3778], [0.1736, 0.3368, 0.9254]]
    assert np.abs(chain.fk(q)[:3, :3] - R).max() < 2e-4


def test_shadow_index_matches_paper_fk_and_mimic():
    chain = load_robot("shadow_index")
    assert chain.joint_types == "RRRR" and chain.dof == 3
    assert [(c.joint, c.master, c.a, c.b) for c in chain.couplings] == [("th4", "th3", 1.0, 0.0)]
    a2, a3, a4 = 0.045, 0.025, 0.026
    for t1, t2, t3 in np.random.default_rng(0).uniform(0, 1.2, size=(10, 3)):
        t4 = t3
        r = a2 * math.cos(t2) + a3 * math.cos(t2 + t3) + a4 * math.cos(t2 + t3 + t4)
        z = -a2 * math.sin(t2) - a3 * math.sin(t2 + t3) - a4 * math.sin(t2 + t3 + t4)
        p = chain.fk([t1, t2, t3])[:3, 3]
        assert np.allclose(p, [math.cos(t1) * r, math.sin(t1) * r, z], atol=1e-15)


@pytest.mark.parametrize(
    "name, convention, rows, base_rz",
    [
        (
            "ur5",
            "standard",  # (a, alpha, d) from Universal Robots' DH table; base_link = DH base turned by pi;
            # tool0 = flange rpy (0, -90, -90) then rpy (90, 0, 90) = frame 6 exactly
            [
                (0, 90, 0.089159),
                (-0.425, 0, 0),
                (-0.39225, 0, 0),
                (0, 90, 0.10915),
                (0, -90, 0.09465),
                (0, 0, 0.0823),
            ],
            math.pi,
        ),
        (
            "panda",
            "modified",  # (a_{i-1}, alpha_{i-1}, d_i) from Franka's table; flange d = 0.107, hand, TCP 0.1034
            [
                (0, 0, 0.333),
                (0, -90, 0),
                (0, 90, 0.316),
                (0.0825, 90, 0),
                (-0.0825, -90, 0.384),
                (0, 90, 0),
                (0.088, 90, 0),
            ],
            0.0,
        ),
    ],
)
def test_urdf_arms_match_their_published_dh_tables(name, convention, rows, base_rz):
    chain = load_robot(name)
    rng = np.random.default_rng(3)
    for q in sample(chain, rng, 10):
        g = np.eye(4)
        g[:3, :3] = rpy(0, 0, base_rz)
        for (a, alpha, d), t in zip(rows, q):
            g = g @ dh_matrix(convention, a, math.radians(alpha), d, t)
        if name == "panda":
            tool = np.eye(4)
            tool[:3, :3] = rpy(0, 0, -math.pi / 4)
            tool[2, 3] = 0.107 + 0.1034
            g = g @ tool
        assert np.allclose(chain.fk(q), g, atol=1e-12)


def test_zoo_dir_env_override(tmp_path, monkeypatch):
    (tmp_path / "mini.toml").write_text(
        'joints = "R"\n[[joint]]\naxis = [0, 0, 1]\npoint = [0, 0, 0]\n[home]\nxyz = [1, 0, 0]\n'
    )
    monkeypatch.setenv("IKC_ROBOTS", str(tmp_path))
    assert zoo_dir() == tmp_path
    assert zoo_names() == ["mini"]
    assert load_robot("mini").joint_types == "R"
    with pytest.raises(UnknownRobotError, match="mini"):
        load_robot("rhino")


def test_unknown_name_lists_the_zoo():
    with pytest.raises(UnknownRobotError) as err:
        load_robot("no_such_robot")
    msg = str(err.value)
    assert "no_such_robot" in msg and "rhino" in msg and "puma560" in msg and "path" in msg


def test_cli_describe_zoo_and_error_exit(capsys):
    assert main(["describe", "rhino"]) == 0
    out = capsys.readouterr().out
    assert "TRRRRR" in out and "home pose" in out
    assert main(["describe", "shadow_index"]) == 0
    assert "coupling: th4 = 1 * th3 + 0" in capsys.readouterr().out
    assert main(["zoo"]) == 0
    assert capsys.readouterr().out.split() == ZOO
    assert main(["describe", "no_such_robot"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ikc describe: error:") and "no_such_robot" in lines[0]
    assert main(["describe", "rhino", "--tip", "flange"]) == 2
    assert "flange" in capsys.readouterr().err
