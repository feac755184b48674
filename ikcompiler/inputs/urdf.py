"""URDF to POE: the chain of moving joints from a base link to a tip link.

The file is read by :mod:`ikcompiler.inputs.urdf_xml` (lxml, strictly, so that malformed XML and
malformed joint elements are reported with their line numbers instead of being silently "recovered")
into typed joint records; this module turns the records into the chain.

Mapping (docs/design.md section 2):

- every link's pose at zero joint values is the product of the joint origins (xyz + rpy) from the base;
  the home pose ``g_st(0)`` is the tip link's pose in the base link's frame;
- a revolute/continuous joint gives ``w = R a`` (its axis ``a``, normalised, in the base frame) through
  the joint frame's origin; a prismatic joint gives ``v = R a``; fixed joints only move the frames;
- limits come from ``<limit>``; a continuous joint gets (-pi, pi] (the IK wraps angles there); a
  revolute joint without ``<limit>``, or with a limit beyond +-2^12 rad (an "unbounded" marker such as
  Gazebo's 1e16: :data:`UNBOUNDED_ANGLE`), gets (-pi, pi] and a prismatic one without ``<limit>`` no
  bounds, each with a note;
- ``<mimic joint= multiplier= offset=>`` becomes a :class:`Coupling`.  A master outside the chain (a
  gripper's finger pad chain whose joints all follow ``finger_joint``) becomes the chain's independent
  joint under its own name: see :func:`_external_masters`;
- planar and floating joints inside the chain are rejected (:class:`UnsupportedJointError`).

Default base: the root link.  Default tip: the only leaf link below the base reached through at least
one moving joint; with several such leaves (a hand) the tip must be named.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ikcompiler.errors import ChainSelectionError, RobotInputError, UnsupportedJointError
from ikcompiler.inputs.urdf_xml import UrdfModel, read_urdf
from ikcompiler.model import Chain, Coupling, Joint
from subproblems import tolerances as tol
from subproblems.screw import transform_twist, twist_exp

MOVING = {"revolute": "R", "continuous": "R", "prismatic": "T"}


def load_urdf(path: Path | str, *, base: str | None = None, tip: str | None = None) -> Chain:
    """Load the chain from link ``base`` to link ``tip`` of a URDF file (defaults: root and sole leaf)."""
    return chain_from_model(read_urdf(path), path, base=base, tip=tip)


def chain_from_model(
    model: UrdfModel, path: Path | str, *, base: str | None = None, tip: str | None = None
) -> Chain:
    """The chain from ``base`` to ``tip`` of a URDF file's records (:mod:`ikcompiler.inputs.urdf_xml`)."""
    path = Path(path)
    src = str(path)
    lines = {j.name: j.line for j in model.joints}

    def where(joint) -> str:
        return f"line {lines.get(joint.name, '?')}, joint {joint.name!r}"

    links = list(model.links)
    link_set = set(links)
    parent_joint: dict[str, object] = {}
    children: dict[str, list] = {name: [] for name in links}
    joint_by_name = {}
    for j in model.joints:
        if j.name in joint_by_name:
            raise RobotInputError("duplicate joint name", source=src, where=where(j))
        joint_by_name[j.name] = j
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in link_set:
                raise RobotInputError(
                    f"{role} link {link!r} is not defined by any <link>", source=src, where=where(j)
                )
        if j.child in parent_joint:
            raise RobotInputError(
                f"link {j.child!r} has two parent joints ({parent_joint[j.child].name!r} and {j.name!r}): "
                "a URDF must be a tree",
                source=src,
                where=where(j),
            )
        parent_joint[j.child] = j
        children[j.parent].append(j)

    roots = [name for name in links if name not in parent_joint]
    if base is None:
        if len(roots) != 1:
            raise ChainSelectionError(
                f"the links form {len(roots)} trees (roots: {', '.join(roots) or 'none, a cycle'}); "
                "name the base link (--base)",
                source=src,
            )
        base = roots[0]
    elif base not in link_set:
        raise ChainSelectionError(f"base link {base!r} is not a link of the URDF", source=src)

    if tip is None:
        tip = _default_tip(base, children, src)
    elif tip not in link_set:
        raise ChainSelectionError(f"tip link {tip!r} is not a link of the URDF", source=src)

    # walk up from the tip to the base
    path_joints = []
    link = tip
    while link != base:
        if link not in parent_joint:
            raise ChainSelectionError(
                f"tip link {tip!r} is not below base link {base!r} in the tree "
                f"(the root above the tip is {link!r})",
                source=src,
            )
        j = parent_joint[link]
        path_joints.append(j)
        link = j.parent
        if len(path_joints) > len(links):
            raise ChainSelectionError("the joints form a cycle", source=src)
    path_joints.reverse()

    g = np.eye(4)
    joints, couplings, notes = [], [], []
    for j in path_joints:
        if j.origin is not None:
            g = g @ np.asarray(j.origin, dtype=float)
        if j.type in ("planar", "floating"):
            raise UnsupportedJointError(
                f"{j.type} joint between {j.parent!r} and {j.child!r} lies in the chain {base!r} -> {tip!r}; "
                "only revolute, continuous, prismatic and fixed joints can be modelled",
                source=src,
                where=where(j),
            )
        if j.type not in MOVING:
            continue
        kind = MOVING[j.type]
        axis = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), dtype=float)
        norm = float(np.linalg.norm(axis))
        if not norm > tol.ZERO_AXIS:
            raise RobotInputError("<axis xyz> has zero length", source=src, where=where(j))
        if abs(norm - 1.0) > tol.INPUT_UNIT_NOTE:
            notes.append(f"axis of joint {j.name!r} normalised (length {norm:g})")
        direction = g[:3, :3] @ (axis / norm)
        if kind == "R":
            twist = np.concatenate([np.cross(g[:3, 3], direction), direction])
        else:
            twist = np.concatenate([direction, np.zeros(3)])
        lower, upper = _limits(j, kind, notes)
        joints.append(Joint(j.name, kind, twist, lower, upper))
        if j.mimic is not None:
            couplings.append(
                Coupling(
                    j.name,
                    j.mimic.joint,
                    1.0 if j.mimic.multiplier is None else float(j.mimic.multiplier),
                    0.0 if j.mimic.offset is None else float(j.mimic.offset),
                )
            )
    joints, couplings, g = _external_masters(joints, couplings, g, joint_by_name, lines, notes, src)
    if not joints:
        raise ChainSelectionError(f"no moving joint between {base!r} and {tip!r}", source=src)
    return Chain(
        name=model.name or path.name.split(".")[0],
        joints=tuple(joints),
        home=g,
        couplings=tuple(couplings),
        base=base,
        tip=tip,
        units="m",
        source=src,
        notes=tuple(notes),
    )


# A revolute limit beyond this many radians is an "unbounded" marker, not a stop: past 2^12 rad a
# double resolves an angle to no better than the contract's 1e-12 (docs/design.md section 10), so no
# joint value there is a valid command.  Files write such markers for spinning joints (Gazebo's
# +-1e16 on a rotor, +-999999 on a mobile base's virtual yaw); read literally they made every sampled
# value meaningless (a value of 1e15 rad holds no angle) and a 2 pi alias list astronomically long.
UNBOUNDED_ANGLE = 2.0**12


def _limits(j, kind: str, notes: list[str]) -> tuple[float, float]:
    if j.type == "continuous":
        return -math.pi, math.pi
    lim = j.limit
    if lim is None or lim.lower is None or lim.upper is None:
        if kind == "R":
            notes.append(f"joint {j.name!r} has no <limit lower upper>: using (-pi, pi]")
            return -math.pi, math.pi
        notes.append(f"joint {j.name!r} has no <limit lower upper>: unbounded")
        return -math.inf, math.inf
    lower, upper = float(lim.lower), float(lim.upper)
    if kind == "R" and max(abs(lower), abs(upper)) > UNBOUNDED_ANGLE:
        notes.append(
            f"joint {j.name!r} has limits [{lower:g}, {upper:g}] rad, beyond +-{UNBOUNDED_ANGLE:g} rad: an "
            "unbounded marker, read as a continuous joint, (-pi, pi]"
        )
        return -math.pi, math.pi
    return lower, upper


def _default_tip(base: str, children: dict[str, list], src: str) -> str:
    """The only leaf below ``base`` reached through a moving joint (or the only leaf at all)."""
    leaves: list[tuple[str, bool]] = []
    stack = [(base, False)]
    while stack:
        link, moved = stack.pop()
        kids = children.get(link, [])
        if not kids and link != base:
            leaves.append((link, moved))
        for j in kids:
            stack.append((j.child, moved or j.type in MOVING))
    moving = sorted(name for name, m in leaves if m)
    candidates = moving or sorted(name for name, _ in leaves)
    if len(candidates) == 1:
        return candidates[0]
    if not candidates:
        raise ChainSelectionError(f"base link {base!r} has no child links", source=src)
    raise ChainSelectionError(
        f"the tree below {base!r} has {len(candidates)} tips; name one (--tip): {', '.join(candidates)}",
        source=src,
    )


def _follow_mimics(name: str, joint_by_name: dict, in_chain: set[str], src: str, where: str):
    """``(master, a, b)`` with ``th = a * th[master] + b``, following mimics outside the chain until a
    joint of the chain or a joint that mimics nothing (the external master) is reached."""
    a, b, seen = 1.0, 0.0, set()
    while name not in in_chain:
        j = joint_by_name.get(name)
        if j is None:
            raise ChainSelectionError(f"mimics joint {name!r}, which does not exist", source=src, where=where)
        if j.type not in MOVING:
            raise ChainSelectionError(
                f"mimics joint {name!r}, a {j.type} joint: a master must be revolute, continuous or "
                "prismatic",
                source=src,
                where=where,
            )
        if j.mimic is None or name in seen:
            if name in seen:
                raise ChainSelectionError(f"mimic cycle through joint {name!r}", source=src, where=where)
            break
        seen.add(name)
        m_a = 1.0 if j.mimic.multiplier is None else float(j.mimic.multiplier)
        m_b = 0.0 if j.mimic.offset is None else float(j.mimic.offset)
        a, b, name = a * m_a, a * m_b + b, j.mimic.joint
    return name, a, b


def _external_masters(joints, couplings, home, joint_by_name, lines, notes, src):
    """Make every master joint outside the chain the chain's independent joint, under its own name.

    Take the first chain joint j1 driven by an external master M: ``th1 = a1 q + b1`` with ``a1 = +-1``
    (a unit twist cannot be scaled).  Then ``exp(xi1 th1) = exp(a1 xi1 q) E`` with ``E = exp(xi1 b1)``, and
    carrying E past the later joints (``E exp(xi th) = exp(Ad_E xi th) E``) gives the chain joint M with
    twist ``a1 xi1``, every later twist ``Ad_E xi`` and the home pose ``E g_st(0)``; the other joints
    driven by M couple to it with their own (a, b).  M's limits are its own (a follower's are not
    imposed, as for any mimic joint; a disagreement is noted).

    >>> from ikcompiler.model import Coupling, Joint
    >>> from subproblems.screw import revolute_twist
    >>> j = Joint("pad", "R", revolute_twist([0, 0, 1], [0, 0, 0]), -0.8, 0.0)
    >>> class M:  # a stand-in for a UrdfJoint record: the external master "finger_joint"
    ...     type, mimic, limit = "revolute", None, type("L", (), {"lower": 0.0, "upper": 0.8})()
    >>> out, cs, _ = _external_masters([j], [Coupling("pad", "finger_joint", -1.0, 0.0)], np.eye(4),
    ...                                {"finger_joint": M}, {}, [], "g.urdf")
    >>> out[0].name, out[0].lower, out[0].upper, out[0].axis.tolist(), cs
    ('finger_joint', 0.0, 0.8, [-0.0, -0.0, -1.0], [])
    """
    in_chain = {jt.name for jt in joints}
    resolved: dict[str, tuple[str, float, float]] = {}
    for c in couplings:
        where = f"line {lines.get(c.joint, '?')}, joint {c.joint!r}"
        m, a, b = _follow_mimics(c.master, joint_by_name, in_chain, src, where)
        resolved[c.joint] = (m, c.a * a, c.a * b + c.b)
    external = [m for m, _, _ in resolved.values() if m not in in_chain]
    if not external:
        return joints, [Coupling(j, m, a, b) for j, (m, a, b) in resolved.items()], home
    joints, home = list(joints), np.asarray(home, dtype=float)
    for master in dict.fromkeys(external):  # each external master once, in order of first use
        driven = [i for i, jt in enumerate(joints) if resolved.get(jt.name, ("",))[0] == master]
        unit = [i for i in driven if abs(abs(resolved[joints[i].name][1]) - 1.0) <= tol.INPUT_MIMIC]
        if not unit:
            names = ", ".join(
                f"{joints[i].name!r} (multiplier {resolved[joints[i].name][1]:g})" for i in driven
            )
            raise ChainSelectionError(
                f"the joints {names} all mimic joint {master!r} outside the chain with a multiplier other "
                "than +-1: none of them can stand for the master; choose a chain through the master",
                source=src,
                where=f"line {lines.get(master, '?')}, joint {master!r}",
            )
        i1 = unit[0]
        j1 = joints[i1]
        _, a1, b1 = resolved.pop(j1.name)
        for name, (m, a, b) in list(resolved.items()):  # joints that mimic j1 itself now follow M
            if m == j1.name:
                resolved[name] = (master, a * a1, a * b1 + b)
        lower, upper = _limits(joint_by_name[master], j1.kind, notes)
        lo1, hi1 = sorted(((j1.lower - b1) / a1, (j1.upper - b1) / a1))
        if lo1 > lower + tol.INPUT_MIMIC or hi1 < upper - tol.INPUT_MIMIC:
            # as for every mimic joint, the follower's own limits are not imposed (files often give a
            # follower the master's range whatever the multiplier, PR2's gripper: [0, 0.548] at -1)
            notes.append(
                f"the limits of joint {j1.name!r} allow {master!r} in [{lo1:g}, {hi1:g}] only; "
                f"{master!r}'s own limits [{lower:g}, {upper:g}] are used"
            )
        E = twist_exp(j1.twist, b1)
        joints[i1] = Joint(master, j1.kind, a1 * j1.twist, lower, upper)
        for k in range(i1 + 1, len(joints)):
            jt = joints[k]
            joints[k] = Joint(jt.name, jt.kind, transform_twist(E, jt.twist), jt.lower, jt.upper)
        home = E @ home
        in_chain.add(master)
        notes.append(
            f"joint {j1.name!r} follows joint {master!r} outside the chain ({j1.name} = {a1:g} * {master} "
            f"+ {b1:g}): {master!r} is the chain's independent joint, limits [{lower:g}, {upper:g}]"
        )
    return joints, [Coupling(j, m, a, b) for j, (m, a, b) in resolved.items()], home
