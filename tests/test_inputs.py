"""Robot inputs: random URDFs against yourdfpy, random DH tables against DH products, spec round trips,
and every kind of bad input giving the right error type with a message naming file and place."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ikcompiler.errors import (
    ChainSelectionError,
    RobotInputError,
    UnknownRobotError,
    UnsupportedJointError,
)
from ikcompiler.inputs import dump_spec, load_robot
from ikcompiler.inputs.spec import load_spec_text
from ikcompiler.inputs.zoo import zoo_names
from ikcompiler.model import Chain, Coupling, Joint
from subproblems.screw import prismatic_twist, revolute_twist, twist_exp
from tests.test_zoo import dh_fk, yourdfpy_fk

# ---- URDF ------------------------------------------------------------------------------------------------


def _f(x) -> str:
    return " ".join(repr(float(v)) for v in np.atleast_1d(x))


def urdf_text(joints, name="r", extra_links=(), extra_joints="") -> str:
    """A URDF chain l0 - l1 - ... from joint dicts (type, xyz, rpy, axis, limits, mimic)."""
    links = [f'<link name="l{i}"/>' for i in range(len(joints) + 1)] + [
        f'<link name="{n}"/>' for n in extra_links
    ]
    parts = []
    for i, j in enumerate(joints):
        s = f'<joint name="{j.get("name", f"j{i}")}" type="{j["type"]}">'
        s += f'<parent link="l{i}"/><child link="l{i + 1}"/>'
        s += f'<origin xyz="{_f(j["xyz"])}" rpy="{_f(j["rpy"])}"/>'
        if j["type"] != "fixed":
            s += f'<axis xyz="{_f(j["axis"])}"/>'
        if j["type"] in ("revolute", "prismatic"):
            s += '<limit lower="-2" upper="2" effort="1" velocity="1"/>'
        if j.get("mimic"):
            m, a, b = j["mimic"]
            s += f'<mimic joint="{m}" multiplier="{a!r}" offset="{b!r}"/>'
        parts.append(s + "</joint>")
    body = "\n".join(links + parts) + extra_joints
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}\n</robot>\n'


_num = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
_vec = st.tuples(_num, _num, _num)
_angle = st.floats(-math.pi, math.pi, allow_nan=False)


@st.composite
def random_urdf_joints(draw):
    n = draw(st.integers(2, 7))
    joints, moving = [], []
    for i in range(n):
        kind = draw(st.sampled_from(["revolute", "revolute", "continuous", "prismatic", "fixed"]))
        axis = np.array(draw(_vec))
        if np.linalg.norm(axis) < 0.2:
            axis = axis + np.array([0.3, -0.2, 0.5])
        if kind == "prismatic":  # yourdfpy does not normalise prismatic axes: compare with unit ones
            axis = axis / np.linalg.norm(axis)
        j = {"type": kind, "xyz": draw(_vec), "rpy": (draw(_angle), draw(_angle), draw(_angle)), "axis": axis}
        if kind != "fixed" and moving and draw(st.integers(0, 3)) == 0:
            j["mimic"] = (draw(st.sampled_from(moving)), draw(st.floats(-2, 2)), draw(st.floats(-0.5, 0.5)))
        if kind != "fixed" and "mimic" not in j:
            moving.append(f"j{i}")
        joints.append(j)
    if not moving:
        joints[0] = {**joints[0], "type": "revolute", "axis": np.array([0.0, 0.0, 2.0])}
        joints[0].pop("mimic", None)
    return joints


@settings(max_examples=30)
@given(random_urdf_joints(), st.integers(0, 2**32 - 1))
def test_random_urdf_fk_matches_yourdfpy(tmp_path_factory, joints, seed):
    path = tmp_path_factory.mktemp("urdf") / "r.urdf"
    path.write_text(urdf_text(joints))
    chain = load_robot(path)
    assert chain.units == "m" and chain.base == "l0" and chain.tip == f"l{len(joints)}"
    assert chain.n == sum(j["type"] != "fixed" for j in joints)
    rng = np.random.default_rng(seed)
    Q = rng.uniform(-2, 2, size=(5, chain.dof))
    want = yourdfpy_fk(path, chain, Q)
    assert np.abs(chain.fk_batch(Q) - want).max() <= 1e-12 * max(1.0, chain.scale)


def test_urdf_limits_continuous_and_normalised_axis(tmp_path):
    joints = [
        {"type": "continuous", "xyz": (0, 0, 0.1), "rpy": (0, 0, 0), "axis": np.array([0, 0, 3.0])},
        {"type": "prismatic", "xyz": (0.2, 0, 0), "rpy": (0.3, 0, 0), "axis": np.array([0, 2.0, 0])},
        {"type": "revolute", "xyz": (0.2, 0, 0), "rpy": (0, 0, 0), "axis": np.array([1.0, 0, 0])},
    ]
    path = tmp_path / "lim.urdf"
    path.write_text(urdf_text(joints))
    chain = load_robot(path)
    assert chain.joint_types == "RTR"
    assert (chain.joints[0].lower, chain.joints[0].upper) == (-math.pi, math.pi)
    assert (chain.joints[1].lower, chain.joints[1].upper) == (-2.0, 2.0)
    assert np.allclose(chain.joints[0].axis, [0, 0, 1]) and np.allclose(
        chain.joints[1].axis, [0, math.cos(0.3), math.sin(0.3)]
    )
    assert any("normalised" in note for note in chain.notes)


ROTOR = """<?xml version="1.0"?>
<robot name="rotor">
  <link name="base"/><link name="rotor"/>
  <joint name="rotor_joint" type="revolute"><parent link="base"/><child link="rotor"/>
    <origin xyz="0.13 0.22 0.023"/><axis xyz="0 0 1"/>
    <limit lower="-1e+16" upper="1e+16" effort="0" velocity="0"/></joint>
</robot>
"""


def test_revolute_limits_beyond_any_angle_read_as_continuous(tmp_path):
    """A revolute joint limited to +-1e16 rad (a quadrotor's rotor, example-robot-data's iris.urdf, as
    Gazebo writes "unbounded") loads as a continuous joint with a note.  Read literally, the compiler's
    trials and verify sampled values near 1e15 rad, where a double holds no angle: the plan fell to a
    1-D search and 30 of 230 poses were recovered (real_robots.py --left-out, session 8)."""
    from ikcompiler import configs
    from ikcompiler.inputs import urdf as urdf_input
    from ikcompiler.verify import verify

    path = tmp_path / "rotor.urdf"
    path.write_text(ROTOR)
    chain = load_robot(path)
    assert (chain.joints[0].lower, chain.joints[0].upper) == (-math.pi, math.pi)
    assert any("unbounded marker" in n and "rotor_joint" in n for n in chain.notes), chain.notes
    module = configs.compile_chain(chain).module
    assert module.METHOD == "closed-form", module.PLAN
    rep = verify(chain, module, samples=200, seed=3, special=0.25)
    assert rep.ok and rep.recovered == rep.poses, rep.text()
    # a wide but real range is kept as written
    path.write_text(ROTOR.replace("1e+16", repr(urdf_input.UNBOUNDED_ANGLE)))
    assert load_robot(path).joints[0].upper == urdf_input.UNBOUNDED_ANGLE


TREE = """<?xml version="1.0"?>
<robot name="hand">
  <link name="palm"/><link name="a1"/><link name="a2"/><link name="b1"/><link name="b2"/><link name="c"/>
  <joint name="ja1" type="revolute"><parent link="palm"/><child link="a1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="ja2" type="revolute"><parent link="a1"/><child link="a2"/><origin xyz="0.05 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="jb1" type="revolute"><parent link="palm"/><child link="b1"/><origin xyz="0 0.02 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="jb2" type="revolute"><parent link="b1"/><child link="b2"/><origin xyz="0.04 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
    <mimic joint="ja2" multiplier="1" offset="0"/></joint>
  <joint name="jc" type="planar"><parent link="palm"/><child link="c"/><axis xyz="0 0 1"/></joint>
</robot>
"""


def test_tree_needs_a_tip_and_chains_are_selected(tmp_path):
    path = tmp_path / "hand.urdf"
    path.write_text(TREE)
    with pytest.raises(ChainSelectionError) as err:
        load_robot(path)
    msg = str(err.value)
    assert "hand.urdf" in msg and "a2" in msg and "b2" in msg and "--tip" in msg
    chain = load_robot(path, tip="a2")  # the planar joint is outside this chain: fine
    assert chain.joint_types == "RR" and chain.base == "palm" and chain.tip == "a2"
    sub = load_robot(path, base="a1", tip="a2")
    assert sub.joint_types == "R" and np.allclose(sub.home[:3, 3], [0.05, 0, 0])
    with pytest.raises(ChainSelectionError, match="not below"):
        load_robot(path, base="a1", tip="b2")
    with pytest.raises(ChainSelectionError, match="'nowhere'"):
        load_robot(path, tip="nowhere")


def test_mimic_master_outside_chain_becomes_the_chain_joint(tmp_path):
    path = tmp_path / "hand.urdf"
    path.write_text(TREE)
    chain = load_robot(path, tip="b2")  # jb2 mimics ja2 (another finger): ja2 stands in for jb2
    assert chain.independent_names == ("jb1", "ja2")
    assert any("'jb2'" in n and "'ja2'" in n for n in chain.notes)


def test_planar_joint_in_chain_is_rejected(tmp_path):
    path = tmp_path / "hand.urdf"
    path.write_text(TREE)
    with pytest.raises(UnsupportedJointError) as err:
        load_robot(path, tip="c")
    msg = str(err.value)
    assert "hand.urdf" in msg and "'jc'" in msg and "planar" in msg and "line 13" in msg


def _bad_urdf(tmp_path, text: str, **kw):
    path = tmp_path / "bad.urdf"
    path.write_text(text)
    return load_robot(path, **kw)


def test_malformed_xml_names_file_and_line(tmp_path):
    text = '<?xml version="1.0"?>\n<robot name="x">\n  <link name="a">\n</robot>\n'
    with pytest.raises(RobotInputError) as err:
        _bad_urdf(tmp_path, text)
    msg = str(err.value)
    assert "bad.urdf" in msg and "malformed XML" in msg and "line 4" in msg


def test_missing_link_names_joint_and_link(tmp_path):
    joints = [{"type": "revolute", "xyz": (0, 0, 0), "rpy": (0, 0, 0), "axis": np.array([0, 0, 1.0])}]
    text = urdf_text(joints).replace('<link name="l1"/>', "")
    with pytest.raises(RobotInputError) as err:
        _bad_urdf(tmp_path, text)
    msg = str(err.value)
    assert "bad.urdf" in msg and "'j0'" in msg and "'l1'" in msg and "not defined" in msg


def test_zero_axis_names_joint(tmp_path):
    joints = [
        {"type": "revolute", "xyz": (0, 0, 0), "rpy": (0, 0, 0), "axis": np.array([0, 0, 1.0])},
        {"type": "revolute", "xyz": (0, 0, 1), "rpy": (0, 0, 0), "axis": np.zeros(3), "name": "elbow"},
    ]
    with pytest.raises(RobotInputError) as err:
        _bad_urdf(tmp_path, urdf_text(joints))
    msg = str(err.value)
    assert "bad.urdf" in msg and "'elbow'" in msg and "zero length" in msg


def test_bad_numbers_and_unknown_types_in_urdf(tmp_path):
    joints = [{"type": "revolute", "xyz": (0, 0, 0), "rpy": (0, 0, 0), "axis": np.array([0, 0, 1.0])}]
    text = urdf_text(joints).replace('xyz="0.0 0.0 0.0"', 'xyz="0 zero 0"', 1)
    with pytest.raises(RobotInputError, match=r"'j0'.*3 finite"):
        _bad_urdf(tmp_path, text)
    text = urdf_text(joints).replace('type="revolute"', 'type="spherical"')
    with pytest.raises(UnsupportedJointError, match="'spherical'"):
        _bad_urdf(tmp_path, text)


# ---- DH --------------------------------------------------------------------------------------------------


@st.composite
def dh_tables(draw):
    conv = draw(st.sampled_from(["standard", "modified"]))
    deg = draw(st.booleans())
    k = 180 / math.pi if deg else 1.0
    lines = [f'convention = "{conv}"', 'units = "m"', f'angles = "{"deg" if deg else "rad"}"']
    if draw(st.booleans()):
        lines.append(f"base = {{ xyz = [{_f(draw(_vec)).replace(' ', ', ')}], rpy = [0.1, -0.2, 0.3] }}")
    if draw(st.booleans()):
        lines.append("tool = { xyz = [0.0, 0.05, 0.1], rpy = [0.0, 0.5, 0.0] }")
    for _ in range(draw(st.integers(1, 7))):
        kind = draw(st.sampled_from("RRT"))
        a, d = draw(_num), draw(_num)
        alpha, theta = draw(_angle) * k, draw(_angle) * k
        lines += ["", "[[row]]", f'type = "{kind}"', f"a = {a!r}", f"alpha = {alpha!r}", f"d = {d!r}"]
        lines.append(f"theta = {theta!r}")
    return "\n".join(lines) + "\n"


@settings(max_examples=40)
@given(dh_tables(), st.integers(0, 2**32 - 1))
def test_random_dh_fk_matches_dh_product(tmp_path_factory, text, seed):
    path = tmp_path_factory.mktemp("dh") / "t.dh.toml"
    path.write_text(text)
    chain = load_robot(path)
    data = tomllib.loads(text)
    assert chain.joint_types == "".join(r["type"] for r in data["row"])
    rng = np.random.default_rng(seed)
    for q in rng.uniform(-3, 3, size=(4, chain.dof)):
        assert np.abs(chain.fk(q) - dh_fk(data, q)).max() <= 1e-12 * max(1.0, chain.scale)


def _bad_dh(tmp_path, rows: str, head: str = 'convention = "standard"\n'):
    path = tmp_path / "bad.dh.toml"
    path.write_text(head + rows)
    return load_robot(path)


def test_dh_errors_name_file_row_and_field(tmp_path):
    good = '[[row]]\ntype = "R"\na = 1.0\n'
    with pytest.raises(RobotInputError) as err:
        _bad_dh(tmp_path, good + '[[row]]\nname = "elbow"\ntype = "P"\n')
    msg = str(err.value)
    assert "bad.dh.toml" in msg and "row 2" in msg and "elbow" in msg and "'type'" in msg and "'P'" in msg
    with pytest.raises(RobotInputError, match=r"row 1.*'alpha' must be a number"):
        _bad_dh(tmp_path, '[[row]]\ntype = "R"\nalpha = "ninety"\n')
    with pytest.raises(RobotInputError, match=r"row 1.*unknown field.*'alfa'"):
        _bad_dh(tmp_path, '[[row]]\ntype = "R"\nalfa = 1.0\n')
    with pytest.raises(RobotInputError, match=r"row 1.*'type' is missing"):
        _bad_dh(tmp_path, "[[row]]\na = 1.0\n")
    with pytest.raises(RobotInputError, match="convention must be"):
        _bad_dh(tmp_path, good, head='convention = "craig"\n')
    with pytest.raises(RobotInputError, match=r"bad.dh.toml.*not valid TOML.*line"):
        _bad_dh(tmp_path, "[[row]\n")
    with pytest.raises(RobotInputError, match="not a rigid"):
        _bad_dh(
            tmp_path,
            good,
            head='convention = "modified"\ntool = { matrix = [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]] }\n',
        )


# ---- spec files ------------------------------------------------------------------------------------------


def random_chain(rng, kinds: str) -> Chain:
    joints = []
    for i, k in enumerate(kinds):
        if k == "R":
            tw = revolute_twist(rng.normal(size=3), rng.normal(size=3) * 100)
            lo, hi = sorted(rng.uniform(-3, 3, size=2))
        else:
            tw = prismatic_twist(rng.normal(size=3))
            lo, hi = (-math.inf, math.inf) if rng.random() < 0.3 else sorted(rng.uniform(-50, 50, size=2))
        joints.append(Joint(f'joint {i} "x"', k, tw, lo, hi))
    home = twist_exp(revolute_twist(rng.normal(size=3), rng.normal(size=3)), rng.uniform(-3, 3))
    home[:3, 3] += rng.normal(size=3) * 100
    couplings = (
        (Coupling(joints[-1].name, joints[0].name, rng.normal(), rng.normal()),) if len(joints) > 2 else ()
    )
    return Chain("rand", tuple(joints), home, couplings, base="b", tip="t", units="mm")


def assert_same_chain(a: Chain, b: Chain):
    assert (a.name, a.base, a.tip, a.units, a.joint_types) == (b.name, b.base, b.tip, b.units, b.joint_types)
    assert [j.name for j in a.joints] == [j.name for j in b.joints]
    tol = 1e-14 * max(1.0, a.scale)
    assert np.abs(a.twists - b.twists).max() <= tol
    assert np.abs(a.home - b.home).max() <= tol
    for ja, jb in zip(a.joints, b.joints):
        assert (ja.lower, ja.upper) == (jb.lower, jb.upper)
    assert a.couplings == b.couplings


@settings(max_examples=40)
@given(
    st.integers(0, 2**32 - 1), st.sampled_from(["R", "T", "RRTR", "TRRRRR", "RRTRRR", "TTTRRR", "RRRRRRR"])
)
def test_spec_round_trip(seed, kinds):
    chain = random_chain(np.random.default_rng(seed), kinds)
    again = load_spec_text(dump_spec(chain))
    assert_same_chain(chain, again)
    assert dump_spec(again) == dump_spec(chain) or np.allclose(again.twists, chain.twists)


@pytest.mark.parametrize("name", zoo_names())
def test_zoo_robots_round_trip_through_spec(name):
    chain = load_robot(name)
    assert_same_chain(chain, load_spec_text(dump_spec(chain)))


def test_spec_in_degrees_and_coupling(tmp_path):
    text = """
units = "mm"
angles = "deg"
joints = "RRT"
[[joint]]
axis = [0, 0, 1]
point = [0, 0, 0]
lower = -90
upper = 90
[[joint]]
axis = [0, 0, 2]
point = [100, 0, 0]
[[joint]]
axis = [0, 0, -1]
lower = 0
upper = 50
[[coupling]]
joint = "q2"
master = "q1"
a = -1
b = 90
[home]
xyz = [200, 0, 0]
rpy = [180, 0, 0]
"""
    path = tmp_path / "d.toml"
    path.write_text(text)
    c = load_robot(path)
    assert c.name == "d" and c.independent_names == ("q1", "q3")
    assert np.isclose(c.joints[0].lower, -math.pi / 2) and c.joints[1].upper == math.pi
    assert c.couplings == (Coupling("q2", "q1", -1.0, math.pi / 2),)
    assert np.allclose(c.home[:3, :3], np.diag([1, -1, -1]))
    assert np.allclose(c.fk([0.0, 10.0])[:3, 3], [100.0, 100.0, -10.0])


SPEC_HEAD = 'joints = "RT"\n[home]\nxyz = [1, 0, 0]\n'
R1 = "[[joint]]\naxis = [0, 0, 1]\npoint = [0, 0, 0]\n"
T2 = "[[joint]]\naxis = [1, 0, 0]\n"


@pytest.mark.parametrize(
    "body, match",
    [
        (
            R1 + '[[joint]]\nname = "slide"\naxis = [0, 0, 0]\n',
            r"joint 2 'slide'.*zero length",
        ),
        ("[[joint]]\naxis = [0, 0, 1]\n" + T2, r"joint 1 'q1'.*'point' is missing"),
        (R1, r"2 joints but the file has 1"),
        (
            R1 + "uper = 1\n" + T2,
            r"'uper'",
        ),
        ("[[joint]]\ntwist = [1, 0, 0, 1, 0, 0]\n" + T2, r"joint 1 'q1'.*pitch"),
        (
            "[[joint]]\naxis = [0, 0, 1]\npoint = [0, 0]\n" + T2,
            r"'point' must be a list of 3",
        ),
        (
            R1 + T2 + "point = [0, 0, 0]\n",
            r"prismatic",
        ),
        (
            R1 + "lower = 1\nupper = -1\n" + T2,
            r"lower limit",
        ),
        (
            R1 + T2 + '[[coupling]]\njoint = "q2"\nmaster = "q9"\n',
            r"'q9'",
        ),
    ],
)
def test_spec_errors_name_file_joint_and_field(tmp_path, body, match):
    path = tmp_path / "bad.toml"
    path.write_text(SPEC_HEAD.replace("[home]", body + "[home]"))
    with pytest.raises(RobotInputError, match=match) as err:
        load_robot(path)
    assert "bad.toml" in str(err.value)


def test_spec_bad_joint_string_and_missing_home(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('joints = "RPR"\n')
    with pytest.raises(RobotInputError, match=r"bad.toml: joints: .*'P' at position 2"):
        load_robot(path)
    path.write_text('joints = "R"\n[[joint]]\naxis = [0, 0, 1]\npoint = [0, 0, 0]\n')
    with pytest.raises(RobotInputError, match=r"bad.toml: home: .*missing"):
        load_robot(path)


# ---- dispatch --------------------------------------------------------------------------------------------


def test_load_robot_dispatch_and_names(tmp_path):
    with pytest.raises(UnknownRobotError, match="zoo"):
        load_robot("definitely_not_a_robot")
    with pytest.raises(UnknownRobotError, match=r"missing.urdf.*no such file"):
        load_robot(tmp_path / "missing.urdf")
    (tmp_path / "robot.json").write_text("{}")
    with pytest.raises(RobotInputError, match="unknown robot file type"):
        load_robot(tmp_path / "robot.json")
    assert load_robot("puma560").joint_types == load_robot(str(load_robot("puma560").source)).joint_types
    with pytest.raises(ChainSelectionError, match="one chain"):
        load_robot("puma560", base="world")
    assert load_robot("rhino", base="base", tip="tool").n == 6


def test_readme_spec_example_loads():
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = readme.split("## Robot files", 1)[1].split("```toml", 1)[1].split("```", 1)[0]
    chain = load_spec_text(block, "README.md")
    assert chain.joint_types == "RRT" and chain.dof == 2 and chain.units == "mm"
    assert np.allclose(chain.joints[1].point, [300, 0, 0])
