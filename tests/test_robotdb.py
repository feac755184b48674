"""How ikcompiler.robotdb cuts a URDF tree into chains (hand-made files; no package needed)."""

from __future__ import annotations

import pytest

from ikcompiler import robotdb


def _joint(name, kind, parent, child, mimic=None):
    m = f'<mimic joint="{mimic}"/>' if mimic else ""
    lim = '<limit lower="-1" upper="1" effort="1" velocity="1"/>' if kind in ("revolute", "prismatic") else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>{lim}{m}</joint>'
    )


def _urdf(tmp_path, joints, name="t.urdf"):
    links = sorted({x for j in joints for x in (j[2], j[3])})
    text = '<?xml version="1.0"?><robot name="r">' + "".join(f'<link name="{lk}"/>' for lk in links)
    text += "".join(_joint(*j) for j in joints) + "</robot>"
    path = tmp_path / name
    path.write_text(text)
    return path


def test_arm_with_gripper_and_mobile_base_is_cut_at_the_branch_point(tmp_path):
    joints = [
        ("float", "floating", "world", "base"),
        *[(f"j{i}", "revolute", f"l{i - 1}" if i > 1 else "base", f"l{i}") for i in range(1, 7)],
        ("camera", "fixed", "l3", "cam"),  # a fixed branch: not a branch point
        ("left", "prismatic", "l6", "left_pad"),
        ("right", "prismatic", "l6", "right_pad", "left"),  # mimics the other finger
        ("flange", "fixed", "l6", "tool0"),  # fixed child of a branch point: no chain
    ]
    found, skipped = robotdb.chains_in_urdf(_urdf(tmp_path, joints), "pkg", "t.urdf")
    chains = {e.tip: e for e, _ in found}
    assert not skipped
    assert set(chains) == {"l6", "left_pad", "right_pad"}
    arm = chains["l6"]
    assert (arm.base, arm.kind, arm.dof, arm.joints) == (
        "base",
        "limb",
        6,
        tuple(f"j{i}" for i in range(1, 7)),
    )
    pad = chains["right_pad"]
    assert (pad.base, pad.kind, pad.dof, pad.joints) == ("l6", "leaf", 1, ("right",))
    chain = pad.load()  # the external master 'left' is the chain's joint
    assert chain.independent_names == ("left",)


def test_single_chain_is_an_arm_to_the_tool_frame_and_long_chains_are_skipped(tmp_path):
    joints = [(f"j{i}", "revolute", f"l{i - 1}", f"l{i}") for i in range(1, 4)]
    joints += [("tool", "fixed", "l3", "tool0")]
    found, _ = robotdb.chains_in_urdf(_urdf(tmp_path, joints), "pkg", "t.urdf")
    ((entry, _),) = found
    assert (entry.base, entry.tip, entry.kind, entry.dof) == ("l0", "tool0", "arm", 3)
    long = [(f"j{i}", "revolute", f"l{i - 1}", f"l{i}") for i in range(1, 10)]
    found, skipped = robotdb.chains_in_urdf(_urdf(tmp_path, long, "long.urdf"), "pkg", "long.urdf")
    assert not found and "9 independent joints" in skipped[0].reason


def test_missing_package_error_says_what_to_install():
    with pytest.raises(robotdb.RobotPackageError, match=r'pip install -e "\.\[robots\]"'):
        robotdb.require(["no-such-robot-package-xyz"])
