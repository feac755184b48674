"""Robot spec files: a joint string with one screw axis per joint and the home pose, in TOML.

The format (README "Robot files" has a full example)::

    name = "rhino"            # optional; default: the file name
    units = "mm"              # length unit of points, twists and the home pose (the user's choice)
    angles = "deg"            # unit of revolute limits, coupling offsets and rpy: "rad" (default) or "deg"
    joints = "TRRRRR"         # the joint string: one letter per [[joint]] table, R or T
    base = "base"             # optional frame names (default "base" and "tool")
    tip = "tool"

    [[joint]]                 # one table per joint, in chain order
    name = "q1"               # optional; default q1, q2, ...
    axis = [1, 0, 0]          # R: rotation axis; T: direction of travel (normalised when loaded)
    point = [0, 0, 0]         # R only: any point on the axis
    # twist = [v1, v2, v3, w1, w2, w3]   # instead of axis/point: the twist (v, w) itself
    lower = -100              # optional limits: units for T, angles for R
    upper = 100               # (defaults: -180..180 deg for R, unbounded for T)

    [[coupling]]              # optional: th[joint] = a * th[master] + b  (a mimic joint)
    joint = "q4"
    master = "q3"
    a = 1.0
    b = 0.0

    [home]                    # g_st(0): xyz + rpy (fixed axes x, y, z as in URDF) or matrix = [[...]]
    xyz = [600, 0, 200]
    rpy = [0, 0, 0]

:func:`dump_spec` writes any chain in this format (twists as axis + point, the home pose as a matrix,
radians), and :func:`load_spec_text` reads it back to the same chain.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ikcompiler.errors import RobotInputError
from ikcompiler.inputs._common import (
    angle_scale,
    check_keys,
    frame,
    number,
    parse_toml,
    read_toml,
    string,
    unit_axis,
    vector,
)
from ikcompiler.model import Chain, Coupling, Joint
from subproblems import tolerances as tol
from subproblems.screw import axis_point, revolute_twist

TOP_KEYS = {"name", "units", "angles", "joints", "base", "tip", "joint", "coupling", "home", "description"}
JOINT_KEYS = {"name", "axis", "point", "twist", "lower", "upper"}
COUPLING_KEYS = {"joint", "master", "a", "b"}


def load_spec(path: Path | str) -> Chain:
    """Load a robot spec file (see the module docstring for the format)."""
    path = Path(path)
    return spec_from_dict(read_toml(path), str(path), default_name=path.name.split(".")[0])


def load_spec_text(text: str, source: str = "<spec>") -> Chain:
    """Load a robot spec from TOML text; ``source`` names it in error messages.

    >>> chain = load_spec_text('''
    ... joints = "R"
    ... [[joint]]
    ... axis = [0, 0, 1]
    ... point = [1, 0, 0]
    ... [home]
    ... xyz = [2, 0, 0]
    ... ''')
    >>> chain.joint_types, chain.joints[0].twist + 0.0
    ('R', array([ 0., -1.,  0.,  0.,  0.,  1.]))
    """
    return spec_from_dict(parse_toml(text, source), source)


def _joint(tbl, kind: str, i: int, scale: float, source: str) -> Joint:
    where = f"[[joint]] #{i + 1}"
    if not isinstance(tbl, dict):
        raise RobotInputError("must be a table", source=source, where=where)
    check_keys(tbl, JOINT_KEYS, source, where)
    name = string(tbl, "name", source, where, default=f"q{i + 1}")
    where = f"joint {i + 1} {name!r}"
    if "twist" in tbl:
        if "axis" in tbl or "point" in tbl:
            raise RobotInputError("give either twist or axis/point, not both", source=source, where=where)
        tw = vector(tbl, "twist", 6, source, where)
        v, w = tw[:3], tw[3:]
        if kind == "R":
            nw = float(np.linalg.norm(w))
            if nw <= tol.ZERO_AXIS:
                raise RobotInputError(
                    "revolute twist has w = 0 (that is a prismatic twist)", source=source, where=where
                )
            v, w = v / nw, w / nw
            if abs(float(v @ w)) > tol.TWIST_UNIT * max(1.0, float(np.linalg.norm(v))):
                raise RobotInputError(
                    "revolute twist has a non-zero pitch (v . w != 0): not a pure rotation",
                    source=source,
                    where=where,
                )
            twist = np.concatenate([v, w])
        else:
            if np.linalg.norm(w) > tol.ZERO_AXIS:
                raise RobotInputError("prismatic twist needs w = 0", source=source, where=where)
            twist = np.concatenate([unit_axis(v, source, where + ": twist"), np.zeros(3)])
    else:
        axis = unit_axis(vector(tbl, "axis", 3, source, where), source, where)
        if kind == "R":
            twist = revolute_twist(axis, vector(tbl, "point", 3, source, where))
        else:
            if "point" in tbl:
                raise RobotInputError(
                    "a prismatic joint has no axis point; remove 'point'", source=source, where=where
                )
            twist = np.concatenate([axis, np.zeros(3)])
    s = scale if kind == "R" else 1.0
    lo_default, hi_default = (-math.pi / s, math.pi / s) if kind == "R" else (-math.inf, math.inf)
    lower = number(tbl, "lower", source, where, default=lo_default) * s
    upper = number(tbl, "upper", source, where, default=hi_default) * s
    if not lower <= upper:
        raise RobotInputError("lower limit is above upper limit", source=source, where=where)
    return Joint(name, kind, twist, lower, upper)


def spec_from_dict(data: dict, source: str, default_name: str = "robot") -> Chain:
    """Build a chain from the parsed TOML of a spec file."""
    check_keys(data, TOP_KEYS, source, "top level")
    kinds = string(data, "joints", source, "joints").strip().upper()
    bad = [f"{c!r} at position {i + 1}" for i, c in enumerate(kinds) if c not in "RT"]
    if bad or not kinds:
        raise RobotInputError(
            "the joint string may contain only R (revolute) and T (prismatic); "
            f"found {', '.join(bad) or 'none'}",
            source=source,
            where="joints",
        )
    tables = data.get("joint", [])
    if not isinstance(tables, list) or len(tables) != len(kinds):
        n = len(tables) if isinstance(tables, list) else 0
        raise RobotInputError(
            f"joint string {kinds!r} has {len(kinds)} joints but the file has {n} [[joint]] tables",
            source=source,
            where="joint",
        )
    scale = angle_scale(data, source)
    joints = tuple(_joint(t, k, i, scale, source) for i, (t, k) in enumerate(zip(tables, kinds)))
    if "home" not in data:
        raise RobotInputError("the home pose [home] (g_st(0)) is missing", source=source, where="home")
    home = frame(data["home"], source, "[home]", scale)
    couplings = []
    ctables = data.get("coupling", [])
    if not isinstance(ctables, list):
        raise RobotInputError("use [[coupling]] tables", source=source, where="coupling")
    kind_of = {j.name: j.kind for j in joints}
    for i, c in enumerate(ctables):
        where = f"[[coupling]] #{i + 1}"
        if not isinstance(c, dict):
            raise RobotInputError("must be a table", source=source, where=where)
        check_keys(c, COUPLING_KEYS, source, where)
        jn, mn = string(c, "joint", source, where), string(c, "master", source, where)
        for role, n in (("joint", jn), ("master", mn)):
            if n not in kind_of:
                raise RobotInputError(
                    f"{role} {n!r} is not a joint of the chain ({', '.join(kind_of)})",
                    source=source,
                    where=where,
                )
        b = number(c, "b", source, where, default=0.0) * (scale if kind_of[jn] == "R" else 1.0)
        couplings.append(Coupling(jn, mn, number(c, "a", source, where, default=1.0), b))
    return Chain(
        name=string(data, "name", source, "name", default=default_name),
        joints=joints,
        home=home,
        couplings=tuple(couplings),
        base=string(data, "base", source, "base", default="base"),
        tip=string(data, "tip", source, "tip", default="tool"),
        units=string(data, "units", source, "units", default=""),
        source=source,
    )


def _num(x: float) -> str:
    x = float(x) + 0.0  # no negative zero
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(x)


def _list(v) -> str:
    return "[" + ", ".join(_num(x) for x in v) + "]"


def dump_spec(chain: Chain) -> str:
    """The chain as spec-file text (radians, twists as axis + point, home as a matrix).

    ``load_spec_text(dump_spec(chain))`` gives the same chain (to rounding in the last digit).

    >>> from ikcompiler.model import Joint
    >>> c = Chain("one", (Joint("a", "T", [0, 0, 1, 0, 0, 0], 0.0, 2.0),), np.eye(4), units="m")
    >>> print(dump_spec(c).splitlines()[3])
    joints = "T"
    """
    q = json.dumps  # TOML basic strings accept JSON string escapes
    out = [
        f"name = {q(chain.name)}",
        f"units = {q(chain.units)}",
        'angles = "rad"',
        f"joints = {q(chain.joint_types)}",
        f"base = {q(chain.base)}",
        f"tip = {q(chain.tip)}",
    ]
    for j in chain.joints:
        out += ["", "[[joint]]", f"name = {q(j.name)}", f"axis = {_list(j.axis)}"]
        if j.kind == "R":
            out.append(f"point = {_list(axis_point(j.twist))}")
        out += [f"lower = {_num(j.lower)}", f"upper = {_num(j.upper)}"]
    for c in chain.couplings:
        out += ["", "[[coupling]]", f"joint = {q(c.joint)}", f"master = {q(c.master)}"]
        out += [f"a = {_num(c.a)}", f"b = {_num(c.b)}"]
    out += ["", "[home]", "matrix = ["]
    out += [f"    {_list(row)}," for row in np.asarray(chain.home)]
    out.append("]")
    return "\n".join(out) + "\n"
