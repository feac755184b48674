"""URDF to POE: the chain of moving joints from a base link to a tip link.

The file is read with :mod:`yourdfpy` (its data model only: no meshes, no scene graph).  Before that it
is parsed strictly with lxml so that malformed XML and malformed joint elements are reported with their
line numbers instead of being silently "recovered".

Mapping (docs/design.md section 2):

- every link's pose at zero joint values is the product of the joint origins (xyz + rpy) from the base;
  the home pose ``g_st(0)`` is the tip link's pose in the base link's frame;
- a revolute/continuous joint gives ``w = R a`` (its axis ``a``, normalised, in the base frame) through
  the joint frame's origin; a prismatic joint gives ``v = R a``; fixed joints only move the frames;
- limits come from ``<limit>``; a continuous joint gets (-pi, pi] (the IK wraps angles there); a
  revolute joint without ``<limit>`` gets (-pi, pi] and a prismatic one no bounds, each with a note;
- ``<mimic joint= multiplier= offset=>`` becomes a :class:`Coupling`; the master must be in the chain;
- planar and floating joints inside the chain are rejected (:class:`UnsupportedJointError`).

Default base: the root link.  Default tip: the only leaf link below the base reached through at least
one moving joint; with several such leaves (a hand) the tip must be named.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ikcompiler.errors import ChainSelectionError, RobotInputError, UnsupportedJointError
from ikcompiler.model import Chain, Coupling, Joint

MOVING = {"revolute": "R", "continuous": "R", "prismatic": "T"}
KNOWN_TYPES = {"revolute", "continuous", "prismatic", "fixed", "planar", "floating"}


def _floats(text: str | None, n: int) -> bool:
    if text is None:
        return True
    parts = text.split()
    try:
        return len(parts) == n and all(math.isfinite(float(x)) for x in parts)
    except ValueError:
        return False


def _strict_parse(path: Path):
    """Parse the XML with lxml (strict) and check every joint element; returns the root element."""
    from lxml import etree

    src = str(path)
    try:
        tree = etree.parse(src, etree.XMLParser(remove_blank_text=True, resolve_entities=False))
    except etree.XMLSyntaxError as exc:
        line = exc.lineno if exc.lineno else None
        raise RobotInputError(
            f"malformed XML: {exc.msg}", source=src, where=f"line {line}" if line else None
        ) from exc
    except OSError as exc:
        raise RobotInputError(f"cannot read the file ({exc})", source=src) from exc
    root = tree.getroot()
    if root.tag != "robot":
        raise RobotInputError(
            f"the root element is <{root.tag}>, a URDF needs <robot>",
            source=src,
            where=f"line {root.sourceline}",
        )
    for link in root.findall("link"):
        if not link.get("name"):
            raise RobotInputError("<link> without a name", source=src, where=f"line {link.sourceline}")
    for el in root.findall("joint"):
        name = el.get("name")
        where = f"line {el.sourceline}, joint {name!r}"
        if not name:
            raise RobotInputError("<joint> without a name", source=src, where=f"line {el.sourceline}")
        if el.get("type") not in KNOWN_TYPES:
            raise UnsupportedJointError(
                f"joint type {el.get('type')!r} is not a URDF joint type ({', '.join(sorted(KNOWN_TYPES))})",
                source=src,
                where=where,
            )
        for tag in ("parent", "child"):
            sub = el.find(tag)
            if sub is None or not sub.get("link"):
                raise RobotInputError(f"missing <{tag} link=...>", source=src, where=where)
        checks = [("origin", "xyz", 3), ("origin", "rpy", 3), ("axis", "xyz", 3)]
        checks += [("limit", "lower", 1), ("limit", "upper", 1)]
        checks += [("mimic", "multiplier", 1), ("mimic", "offset", 1)]
        for tag, attr, n in checks:
            sub = el.find(tag)
            if sub is not None and not _floats(sub.get(attr), n):
                raise RobotInputError(
                    f"<{tag} {attr}={sub.get(attr)!r}> needs {n} finite number(s)",
                    source=src,
                    where=f"line {sub.sourceline}, joint {name!r}",
                )
        mimic = el.find("mimic")
        if mimic is not None and not mimic.get("joint"):
            raise RobotInputError(
                "<mimic> needs a joint attribute",
                source=src,
                where=f"line {mimic.sourceline}, joint {name!r}",
            )
    return root


def load_urdf(path: Path | str, *, base: str | None = None, tip: str | None = None) -> Chain:
    """Load the chain from link ``base`` to link ``tip`` of a URDF file (defaults: root and sole leaf)."""
    import yourdfpy

    path = Path(path)
    src = str(path)
    root = _strict_parse(path)
    lines = {el.get("name"): el.sourceline for el in root.findall("joint")}
    try:
        model = yourdfpy.URDF.load(
            src, build_scene_graph=False, load_meshes=False, load_collision_meshes=False
        ).robot
    except Exception as exc:  # yourdfpy raises assorted types; report them as input errors
        raise RobotInputError(f"yourdfpy could not read the URDF: {exc}", source=src) from exc

    def where(joint) -> str:
        return f"line {lines.get(joint.name, '?')}, joint {joint.name!r}"

    links = [link.name for link in model.links]
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
        if not norm > 1e-12:
            raise RobotInputError("<axis xyz> has zero length", source=src, where=where(j))
        if abs(norm - 1.0) > 1e-12:
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
    in_chain = {jt.name for jt in joints}
    for c in couplings:
        if c.master not in in_chain:
            j = joint_by_name[c.joint]
            if c.master in joint_by_name:
                m = joint_by_name[c.master]
                what = "a fixed joint" if m.type == "fixed" else f"outside the chain {base!r} -> {tip!r}"
                msg = f"joint {c.joint!r} mimics joint {c.master!r} (line {lines.get(c.master, '?')}), {what}"
            else:
                msg = f"joint {c.joint!r} mimics joint {c.master!r}, which does not exist"
            raise ChainSelectionError(msg, source=src, where=where(j))
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
    return float(lim.lower), float(lim.upper)


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
