"""A chain whose joints all mimic a master outside it (a gripper's finger pad chain following
``finger_joint``) loads with the master as its independent joint, and its FK matches the URDF tree's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ikcompiler import load_robot
from ikcompiler.compiler import compile_robot
from ikcompiler.errors import ChainSelectionError, RobotInputError
from ikcompiler.verify import verify

GRIPPER = Path(__file__).parent / "data" / "external_mimic_gripper.urdf"


def _rot(axis, angle) -> np.ndarray:
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _tree_pose(q_master: float, tip: str) -> np.ndarray:
    """The tip's pose walking the URDF tree joint by joint (origin, then the joint's motion), every
    joint's value from its <mimic> (followed to the master): an FK independent of the POE model."""
    from lxml import etree

    root = etree.parse(str(GRIPPER)).getroot()
    by_child = {el.find("child").get("link"): el for el in root.findall("joint")}
    by_name = {el.get("name"): el for el in root.findall("joint")}

    def value(el) -> float:
        m = el.find("mimic")
        if m is None:
            return q_master
        return float(m.get("multiplier")) * value(by_name[m.get("joint")]) + float(m.get("offset"))

    chain, link = [], tip
    while link in by_child:
        chain.append(by_child[link])
        link = by_child[link].find("parent").get("link")
    g = np.eye(4)
    for el in reversed(chain):
        o = el.find("origin")
        xyz = [float(x) for x in o.get("xyz", "0 0 0").split()] if o is not None else [0, 0, 0]
        r, p, y = [float(x) for x in o.get("rpy", "0 0 0").split()] if o is not None else [0, 0, 0]
        step = np.eye(4)
        step[:3, :3] = _rot([0, 0, 1], y) @ _rot([0, 1, 0], p) @ _rot([1, 0, 0], r)
        step[:3, 3] = xyz
        g = g @ step
        if el.get("type") != "fixed":
            axis = [float(x) for x in el.find("axis").get("xyz").split()]
            motion = np.eye(4)
            if el.get("type") == "prismatic":
                motion[:3, 3] = value(el) * np.asarray(axis) / np.linalg.norm(axis)
            else:
                motion[:3, :3] = _rot(axis, value(el))
            g = g @ motion
    return g


def test_external_master_is_the_chain_joint():
    chain = load_robot(GRIPPER, tip="right_pad")
    assert chain.independent_names == ("finger_joint",)
    assert chain.joint_types == "RRT"
    # limits: finger_joint's own [0, 0.8] (right_knuckle = 0.1 - q in [-0.8, 0.1] allows q in [0, 0.9])
    assert (chain.lower[0], chain.upper[0]) == (0.0, 0.8)
    assert not any("are used" in n for n in chain.notes)
    assert any("finger_joint" in n and "right_knuckle_joint" in n for n in chain.notes)
    for q in (0.0, 0.13, 0.4, 0.8):
        assert np.allclose(chain.fk([q]), _tree_pose(q, "right_pad"), atol=1e-12), q


@pytest.mark.parametrize("target", ["pose", "position+direction", "position"])
def test_external_master_chain_compiles_and_verifies(target):
    chain = load_robot(GRIPPER, tip="right_pad")
    module = compile_robot(chain, target=target)
    assert list(module.JOINT_NAMES) == ["finger_joint"]
    report = verify(chain, module, samples=200, seed=1)
    assert report.wrong == 0 and report.missed == 0 and report.batch_mismatch == 0, report.text()
    assert report.recovered == report.poses, report.text()


def test_master_chain_unchanged_and_bad_masters_still_refused(tmp_path):
    left = load_robot(GRIPPER, tip="left_pad")
    assert left.independent_names == ("finger_joint",) and not left.couplings
    text = GRIPPER.read_text().replace(
        '<mimic joint="finger_joint" multiplier="1"', '<mimic joint="nojoint" multiplier="1"'
    )
    bad = tmp_path / "bad.urdf"
    bad.write_text(text)
    with pytest.raises(ChainSelectionError, match="'nojoint', which does not exist"):
        load_robot(bad, tip="right_pad")
    text = GRIPPER.read_text().replace('multiplier="-1" offset="0.1"', 'multiplier="-2" offset="0.1"')
    text = text.replace('multiplier="1" offset="-0.2"', 'multiplier="3" offset="-0.2"')
    bad.write_text(text)
    with pytest.raises(ChainSelectionError, match="multiplier other than"):
        load_robot(bad, tip="right_pad")


def test_harmless_xml_errors_are_tolerated_and_others_are_not(tmp_path):
    """airo-models' Robotiq 2F-85 carries ``drake:`` elements without the namespace declared, and
    pybullet's files declare XML version 0.0: both load; a broken tag still raises with its line."""
    text = GRIPPER.read_text().replace('<?xml version="1.0"?>', '<?xml version="0.0"?>')
    text = text.replace("</robot>", '<drake:collision_filter_group name="g"/>\n</robot>')
    path = tmp_path / "lenient.urdf"
    path.write_text(text)
    assert load_robot(path, tip="right_pad").independent_names == ("finger_joint",)
    path.write_text(text.replace("</robot>", "<link name='x'>\n</robot>"))
    with pytest.raises(RobotInputError, match="malformed XML") as err:
        load_robot(path, tip="right_pad")
    assert "line" in str(err.value)


def test_follower_limits_that_disagree_with_the_master_are_noted(tmp_path):
    """PR2's gripper gives the follower the master's range although the multiplier is -1: the master's
    own limits are used (as for every mimic joint) and the disagreement is noted."""
    text = GRIPPER.read_text().replace('lower="-0.8" upper="0.1"', 'lower="0" upper="0.8"')
    path = tmp_path / "pr2like.urdf"
    path.write_text(text)
    chain = load_robot(path, tip="right_pad")
    assert (chain.lower[0], chain.upper[0]) == (0.0, 0.8)
    assert any("'right_knuckle_joint' allow 'finger_joint' in [-0.7, 0.1] only" in n for n in chain.notes)
