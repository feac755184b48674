"""Denavit-Hartenberg tables in TOML, standard or modified (Craig) convention, converted to POE.

Format::

    name = "puma560"
    convention = "standard"   # "standard": A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)
                              # "modified": A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i) (Craig)
    units = "m"               # length unit of a, d, base and tool
    angles = "deg"            # unit of alpha, theta, revolute limits and rpy: "rad" (default) or "deg"

    [base]                    # optional: world -> frame 0, xyz + rpy or matrix = [[...]]
    xyz = [0, 0, 0]
    [tool]                    # optional: frame n -> tool
    xyz = [0, 0, 0.1]

    [[row]]                   # one row per joint, in chain order
    name = "j1"               # optional; default j1, j2, ...
    type = "R"                # R: theta_i = q_i + theta   |   T: d_i = q_i + d
    a = 0.0                   # in the modified convention a row holds a_{i-1} and alpha_{i-1}
    alpha = 90
    d = 0.0                   # the constant d (R) or the offset of d (T)
    theta = 0                 # the offset of theta (R) or the constant theta (T)
    lower = -160              # optional limits on q_i: angles for R, units for T
    upper = 160

With ``q = 0`` every row sits at its offsets: that is the home pose ``g_st(0)``.  Each joint's twist is
the z axis of the frame its ``Rz``/``Tz`` factor acts in, carried to the base by the product of the
factors before it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ikcompiler.errors import RobotInputError
from ikcompiler.inputs._common import (
    angle_scale,
    check_keys,
    cos_sin,
    frame,
    number,
    read_toml,
    string,
)
from ikcompiler.model import Chain, Joint
from subproblems.screw import adjoint

TOP_KEYS = {"name", "convention", "units", "angles", "base", "tool", "row", "description"}
ROW_KEYS = {"name", "type", "a", "alpha", "d", "theta", "lower", "upper"}
CONVENTIONS = ("standard", "modified")


def rot_x(t: float) -> np.ndarray:
    c, s = cos_sin(t)
    g = np.eye(4)
    g[1:3, 1:3] = [[c, -s], [s, c]]
    return g


def rot_z(t: float) -> np.ndarray:
    c, s = cos_sin(t)
    g = np.eye(4)
    g[0:2, 0:2] = [[c, -s], [s, c]]
    return g


def trans(x: float, y: float, z: float) -> np.ndarray:
    g = np.eye(4)
    g[:3, 3] = (x, y, z)
    return g


def load_dh(path: Path | str) -> Chain:
    """Load a DH table file (see the module docstring for the format)."""
    path = Path(path)
    return dh_from_dict(read_toml(path), str(path), default_name=path.name.split(".")[0])


def dh_from_dict(data: dict, source: str, default_name: str = "robot") -> Chain:
    """Build a POE chain from the parsed TOML of a DH file.

    >>> c = dh_from_dict({"convention": "standard", "row": [{"type": "R", "a": 1.0}]}, "<dh>")
    >>> c.home[:3, 3] + 0.0, c.joints[0].twist + 0.0
    (array([1., 0., 0.]), array([0., 0., 0., 0., 0., 1.]))
    """
    check_keys(data, TOP_KEYS, source, "top level")
    convention = string(data, "convention", source, "convention")
    if convention not in CONVENTIONS:
        raise RobotInputError(
            f"convention must be 'standard' or 'modified' (Craig), got {convention!r}",
            source=source,
            where="convention",
        )
    scale = angle_scale(data, source)
    rows = data.get("row")
    if not isinstance(rows, list) or not rows:
        raise RobotInputError("the table needs at least one [[row]]", source=source, where="row")
    base = frame(data["base"], source, "[base]", scale) if "base" in data else np.eye(4)
    tool = frame(data["tool"], source, "[tool]", scale) if "tool" in data else np.eye(4)

    g = base.copy()  # pose of the frame reached so far, at q = 0
    joints = []
    for i, row in enumerate(rows):
        where = f"row {i + 1}"
        if not isinstance(row, dict):
            raise RobotInputError("must be a [[row]] table", source=source, where=where)
        check_keys(row, ROW_KEYS, source, where)
        name = string(row, "name", source, where, default=f"j{i + 1}")
        where = f"row {i + 1} ({name})"
        kind = string(row, "type", source, where + ": field 'type'").strip().upper()
        if kind not in ("R", "T"):
            raise RobotInputError(
                f"field 'type' must be 'R' (revolute) or 'T' (prismatic), got {row['type']!r}",
                source=source,
                where=where,
            )
        a = number(row, "a", source, where, default=0.0)
        alpha = number(row, "alpha", source, where, default=0.0) * scale
        d = number(row, "d", source, where, default=0.0)
        theta = number(row, "theta", source, where, default=0.0) * scale
        for key, val in (("a", a), ("alpha", alpha), ("d", d), ("theta", theta)):
            if not math.isfinite(val):
                raise RobotInputError(f"field {key!r} must be finite", source=source, where=where)
        if convention == "standard":
            pre, post = np.eye(4), trans(a, 0, 0) @ rot_x(alpha)
        else:
            pre, post = rot_x(alpha) @ trans(a, 0, 0), np.eye(4)
        at_joint = g @ pre  # the frame in which the joint's Rz(theta) Tz(d) acts
        z_twist = np.array([0, 0, 0, 0, 0, 1.0]) if kind == "R" else np.array([0, 0, 1.0, 0, 0, 0])
        twist = adjoint(at_joint) @ z_twist
        s = scale if kind == "R" else 1.0
        lo_default, hi_default = (-math.pi / s, math.pi / s) if kind == "R" else (-math.inf, math.inf)
        lower = number(row, "lower", source, where, default=lo_default) * s
        upper = number(row, "upper", source, where, default=hi_default) * s
        if not lower <= upper:
            raise RobotInputError("lower limit is above upper limit", source=source, where=where)
        joints.append(Joint(name, kind, twist, lower, upper))
        g = at_joint @ rot_z(theta) @ trans(0, 0, d) @ post
    home = g @ tool
    return Chain(
        name=string(data, "name", source, "name", default=default_name),
        joints=tuple(joints),
        home=home,
        units=string(data, "units", source, "units", default=""),
        source=source,
        notes=(f"from a {convention} DH table",),
    )
