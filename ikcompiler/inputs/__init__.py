"""Robot inputs: URDF files, robot spec files, DH tables and the zoo, all loaded into a :class:`Chain`.

``load_robot`` dispatches on what it is given: a path ending in ``.urdf`` (or ``.xml``) is read as URDF;
a ``.toml`` file is a DH table when it has ``convention``/``[[row]]`` and a spec file otherwise; a bare
name is looked up in the zoo (``robots/``).
"""

from __future__ import annotations

from pathlib import Path

from ikcompiler.errors import ChainSelectionError, RobotInputError, UnknownRobotError
from ikcompiler.model import Chain

__all__ = ["load_robot", "dump_spec"]


def _locate(robot) -> Path:
    from ikcompiler.inputs.zoo import resolve

    if isinstance(robot, Path):
        path = robot
    else:
        text = str(robot)
        path = Path(text)
        if not path.exists() and "/" not in text and "\\" not in text and "." not in text:
            return resolve(text)
    if not path.exists():
        raise UnknownRobotError(
            "no such file. Give a path to a .urdf or .toml robot file, or the name of a zoo robot "
            "(list them with `ikc zoo`)",
            source=str(path),
        )
    if path.is_dir():
        raise RobotInputError("is a folder, not a robot file", source=str(path))
    return path


def load_robot(robot: str | Path, *, base: str | None = None, tip: str | None = None) -> Chain:
    """Load a robot from a ``.urdf`` / spec ``.toml`` / DH ``.toml`` path or a zoo name.

    ``base`` and ``tip`` choose the chain's links in a URDF; spec and DH files define one chain, so
    there they may only repeat its frame names.

    >>> load_robot("rhino").joint_types
    'TRRRRR'
    """
    path = _locate(robot)
    name = path.name.lower()
    if name.endswith((".urdf", ".xml")):
        from ikcompiler.inputs.urdf import load_urdf

        return load_urdf(path, base=base, tip=tip)
    if name.endswith(".toml"):
        from ikcompiler.inputs._common import read_toml
        from ikcompiler.inputs.zoo import MANIPULATION_HINT, is_manipulation_spec

        if is_manipulation_spec(path):
            raise RobotInputError(MANIPULATION_HINT.format(path), source=str(path))

        data = read_toml(path)
        stem = path.name.split(".")[0]
        if "row" in data or "convention" in data:
            from ikcompiler.inputs.dh import dh_from_dict

            chain = dh_from_dict(data, str(path), default_name=stem)
        else:
            from ikcompiler.inputs.spec import spec_from_dict

            chain = spec_from_dict(data, str(path), default_name=stem)
        for role, want, have in (("base", base, chain.base), ("tip", tip, chain.tip)):
            if want is not None and want != have:
                raise ChainSelectionError(
                    f"--{role} {want!r}: this file defines one chain, from {chain.base!r} to {chain.tip!r}",
                    source=str(path),
                )
        return chain
    raise RobotInputError(
        "unknown robot file type: expected .urdf (URDF) or .toml (robot spec or DH table)", source=str(path)
    )


def dump_spec(chain: Chain) -> str:
    """Write a chain as robot-spec TOML text (see :mod:`ikcompiler.inputs.spec`)."""
    from ikcompiler.inputs.spec import dump_spec as _dump

    return _dump(chain)
