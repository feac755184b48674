"""Read the kinematic part of a URDF file with lxml: typed joint records, every number checked.

One job: XML text -> :class:`UrdfModel` (link names, :class:`UrdfJoint` records with their origin as a
4x4 matrix, axis, limits and mimic, and the line each joint element starts on).  What the records mean
for the chain is :mod:`ikcompiler.inputs.urdf`'s job (docs/design.md section 2).

Only lxml is imported (it parses strictly enough to give line numbers, which the standard library's
ElementTree does not keep).  Before session 9 the records came from ``yourdfpy``, whose import pulls in
trimesh (and scipy where installed): ~0.7 s before anything of ours ran (docs/design.md section 13,
"yourdfpy").  The records are the same numbers, bit for bit, as yourdfpy's data model gave the chain
builder: ``tests/test_urdf_reader.py`` compares both readers on every file of the ``robots`` extra.

Read: ``<robot name>``, ``<link name>``, and per ``<joint>`` its name, type, ``<parent link>``,
``<child link>``, ``<origin xyz rpy>``, ``<axis xyz>``, ``<limit lower upper effort velocity>`` and
``<mimic joint multiplier offset>``.  Not read (the kinematics need none of them): visuals,
collisions, inertials, materials, ``<dynamics>``, ``<calibration>``, ``<safety_controller>``,
transmissions and elements of other namespaces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ikcompiler.errors import RobotInputError, UnsupportedJointError

KNOWN_TYPES = {"revolute", "continuous", "prismatic", "fixed", "planar", "floating"}

# Errors libxml2 reports that leave the URDF content intact: a prefix such as ``drake:`` on an element
# URDF ignores anyway (airo-models' Robotiq 2F-85), and an XML declaration with version "0.0" (pybullet's
# data).  Every other error is fatal.
HARMLESS_XML_ERRORS = {"NS_ERR_UNDEFINED_NAMESPACE", "ERR_UNKNOWN_VERSION"}


@dataclass(frozen=True)
class UrdfLimit:
    """``<limit lower upper>``: either may be missing (None)."""

    lower: float | None
    upper: float | None


@dataclass(frozen=True)
class UrdfMimic:
    """``<mimic joint multiplier offset>``: ``th = multiplier * th[joint] + offset`` (defaults 1 and 0)."""

    joint: str
    multiplier: float
    offset: float


@dataclass(frozen=True, eq=False)
class UrdfJoint:
    """One ``<joint>`` element.  ``origin`` is None without an ``<origin>`` element (identity);
    ``axis`` is as written, not normalised, (1, 0, 0) without ``<axis>``."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray | None
    axis: np.ndarray
    limit: UrdfLimit | None
    mimic: UrdfMimic | None
    line: int


@dataclass(frozen=True)
class UrdfModel:
    """The file's robot name (None when the attribute is missing), link names and joints, in file order."""

    name: str | None
    links: tuple[str, ...]
    joints: tuple[UrdfJoint, ...]


def parse_xml(path: Path | str):
    """The root element of an XML file, parsed strictly except for :data:`HARMLESS_XML_ERRORS`;
    malformed XML raises :class:`RobotInputError` with the file and line."""
    from lxml import etree

    src = str(path)
    parser = etree.XMLParser(remove_blank_text=True, resolve_entities=False, recover=True)
    try:
        tree = etree.parse(src, parser)
    except etree.XMLSyntaxError as exc:  # even recovery failed
        line = exc.lineno if exc.lineno else None
        raise RobotInputError(
            f"malformed XML: {exc.msg}", source=src, where=f"line {line}" if line else None
        ) from exc
    except OSError as exc:
        raise RobotInputError(f"cannot read the file ({exc})", source=src) from exc
    for err in parser.error_log:
        if err.type_name not in HARMLESS_XML_ERRORS:
            raise RobotInputError(f"malformed XML: {err.message}", source=src, where=f"line {err.line}")
    root = tree.getroot()
    if root is None:
        raise RobotInputError("malformed XML: no root element", source=src)
    return root


def _floats(text: str | None, n: int) -> bool:
    """True when ``text`` is absent or holds exactly ``n`` finite numbers."""
    if text is None:
        return True
    parts = text.split()
    try:
        return len(parts) == n and all(math.isfinite(float(x)) for x in parts)
    except ValueError:
        return False


def _number(text: str | None) -> bool:
    """True when ``text`` is absent or one number (infinite allowed: ``effort`` and ``velocity`` are not
    read, the check only catches text such as an unexpanded ``${max_effort}``)."""
    if text is None:
        return True
    try:
        float(text)
    except ValueError:
        return False
    return True


def _vector(text: str) -> np.ndarray:
    return np.array([float(x) for x in text.split()])


def origin_matrix(xyz: np.ndarray, rpy: np.ndarray) -> np.ndarray:
    """``Trans(xyz) Rz(yaw) Ry(pitch) Rx(roll)``, the URDF origin, as a 4x4 matrix.

    The entries are grouped as the yourdfpy reader computed them (a product ``I T R`` of 4x4 matrices,
    the rotation's entries from the half products ``cos roll cos yaw``, ...), so that every chain keeps
    its bits (signed zeros included) across the change of reader.

    >>> g = origin_matrix(np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, np.pi / 2]))
    >>> np.round(g, 12).tolist()
    [[0.0, -1.0, 0.0, 1.0], [1.0, 0.0, 0.0, 2.0], [0.0, 0.0, 1.0, 3.0], [0.0, 0.0, 0.0, 1.0]]
    """
    roll, pitch, yaw = rpy[0], rpy[1], rpy[2]
    sr, sp, sy = np.sin(roll), np.sin(pitch), np.sin(yaw)
    cr, cp, cy = np.cos(roll), np.cos(pitch), np.cos(yaw)
    cr_cy, cr_sy = cr * cy, cr * sy
    sr_cy, sr_sy = sr * cy, sr * sy
    rot = np.eye(4)
    rot[0, 0] = cp * cy
    rot[0, 1] = sp * sr_cy - cr_sy
    rot[0, 2] = sp * cr_cy + sr_sy
    rot[1, 0] = cp * sy
    rot[1, 1] = sp * sr_sy + cr_cy
    rot[1, 2] = sp * cr_sy - sr_cy
    rot[2, 0] = -sp
    rot[2, 1] = cp * sr
    rot[2, 2] = cp * cr
    trans = np.identity(4)
    trans[:3, 3] = xyz[:3]
    g = np.dot(np.dot(np.identity(4), trans), rot)
    g /= g[3, 3]
    return g


def _check_joint(el, src: str) -> None:
    """Every attribute the chain reads is present and a number where it must be (file, line, joint)."""
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
    limit = el.find("limit")
    for attr in ("effort", "velocity"):
        if limit is not None and not _number(limit.get(attr)):
            raise RobotInputError(
                f"<limit {attr}={limit.get(attr)!r}> needs a number (an unexpanded xacro expression?)",
                source=src,
                where=f"line {limit.sourceline}, joint {name!r}",
            )
    mimic = el.find("mimic")
    if mimic is not None and not mimic.get("joint"):
        raise RobotInputError(
            "<mimic> needs a joint attribute",
            source=src,
            where=f"line {mimic.sourceline}, joint {name!r}",
        )


def _joint(el) -> UrdfJoint:
    """The record of a checked ``<joint>`` element."""
    origin = el.find("origin")
    if origin is not None:
        origin = origin_matrix(_vector(origin.get("xyz", "0 0 0")), _vector(origin.get("rpy", "0 0 0")))
    axis = el.find("axis")
    axis = np.array([1.0, 0, 0]) if axis is None else _vector(axis.get("xyz", "1 0 0"))
    limit = el.find("limit")
    if limit is not None:
        lower, upper = limit.get("lower"), limit.get("upper")
        limit = UrdfLimit(None if lower is None else float(lower), None if upper is None else float(upper))
    mimic = el.find("mimic")
    if mimic is not None:
        mimic = UrdfMimic(
            mimic.get("joint"), float(mimic.get("multiplier", 1.0)), float(mimic.get("offset", 0.0))
        )
    return UrdfJoint(
        name=el.get("name"),
        type=el.get("type"),
        parent=el.find("parent").get("link"),
        child=el.find("child").get("link"),
        origin=origin,
        axis=axis,
        limit=limit,
        mimic=mimic,
        line=el.sourceline,
    )


def read_urdf(path: Path | str) -> UrdfModel:
    """The kinematic records of a URDF file; malformed XML, a root other than ``<robot>``, an unnamed
    link or a malformed joint element raise :class:`RobotInputError` naming the file, line and joint."""
    src = str(path)
    root = parse_xml(path)
    if root.tag != "robot":
        raise RobotInputError(
            f"the root element is <{root.tag}>, a URDF needs <robot>",
            source=src,
            where=f"line {root.sourceline}",
        )
    links = []
    for link in root.findall("link"):
        if not link.get("name"):
            raise RobotInputError("<link> without a name", source=src, where=f"line {link.sourceline}")
        links.append(link.get("name"))
    elements = root.findall("joint")
    for el in elements:
        _check_joint(el, src)
    return UrdfModel(name=root.get("name"), links=tuple(links), joints=tuple(_joint(el) for el in elements))
