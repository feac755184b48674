"""Helpers shared by the TOML readers (spec and DH files): reading, typed fields, frames and units.

Every helper raises :class:`~ikcompiler.errors.RobotInputError` naming the file (``source``) and the
place in it (``where``: a table, a row or a field), never a bare ``KeyError`` or ``ValueError``.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np

from ikcompiler.errors import RobotInputError
from subproblems import tolerances as tol
from subproblems.screw import rigid_residual

ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}


def read_toml(path: Path) -> dict:
    """Parse a TOML file; a syntax error becomes a :class:`RobotInputError` with the line."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise RobotInputError(f"cannot read the file ({exc.strerror})", source=str(path)) from exc
    return parse_toml(text, str(path))


def parse_toml(text: str, source: str) -> dict:
    """Parse TOML text; ``source`` names it in error messages."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RobotInputError(f"not valid TOML: {exc}", source=source) from exc


def check_keys(table: dict, allowed: set[str], source: str, where: str) -> None:
    """Reject unknown keys (usually typos such as ``uper``), listing the allowed ones."""
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise RobotInputError(
            f"unknown field(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(sorted(allowed))}",
            source=source,
            where=where,
        )


def number(table: dict, key: str, source: str, where: str, default: float | None = None) -> float:
    """A finite (or +-inf) number field; missing fields take ``default`` or raise."""
    if key not in table:
        if default is None:
            raise RobotInputError(f"field {key!r} is missing", source=source, where=where)
        return float(default)
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
        raise RobotInputError(f"field {key!r} must be a number, got {value!r}", source=source, where=where)
    return float(value)


def vector(table: dict, key: str, n: int, source: str, where: str, default=None) -> np.ndarray:
    """A list of ``n`` finite numbers."""
    if key not in table:
        if default is None:
            raise RobotInputError(f"field {key!r} is missing", source=source, where=where)
        return np.array(default, dtype=float)
    value = table[key]
    ok = (
        isinstance(value, list)
        and len(value) == n
        and all(isinstance(x, int | float) and not isinstance(x, bool) for x in value)
    )
    if not ok or not np.all(np.isfinite(np.array(value, dtype=float))):
        raise RobotInputError(
            f"field {key!r} must be a list of {n} finite numbers, got {value!r}", source=source, where=where
        )
    return np.array(value, dtype=float)


def string(table: dict, key: str, source: str, where: str, default: str | None = None) -> str:
    """A string field."""
    if key not in table:
        if default is None:
            raise RobotInputError(f"field {key!r} is missing", source=source, where=where)
        return default
    value = table[key]
    if not isinstance(value, str):
        raise RobotInputError(f"field {key!r} must be a string, got {value!r}", source=source, where=where)
    return value


def angle_scale(data: dict, source: str) -> float:
    """Radians per unit of the file's ``angles`` field ("rad", the default, or "deg")."""
    unit = string(data, "angles", source, "angles", default="rad")
    if unit not in ANGLE_UNITS:
        raise RobotInputError(f"angles must be 'rad' or 'deg', got {unit!r}", source=source, where="angles")
    return ANGLE_UNITS[unit]


def cos_sin(t: float) -> tuple[float, float]:
    """``(cos t, sin t)``, exact at multiples of 90 degrees (so that 90 deg gives 0, not 6e-17).

    >>> cos_sin(math.pi / 2), cos_sin(-math.pi)
    ((0.0, 1.0), (-1.0, 0.0))
    """
    k = round(t / (math.pi / 2))
    if abs(t - k * (math.pi / 2)) <= tol.INPUT_RIGHT_ANGLE * max(1.0, abs(t)):
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[k % 4]
    return math.cos(t), math.sin(t)


def rpy_matrix(rpy) -> np.ndarray:
    """Rotation ``Rz(yaw) Ry(pitch) Rx(roll)`` (the URDF convention: fixed axes x, then y, then z).

    >>> np.round(rpy_matrix([0, 0, np.pi / 2]) @ [1, 0, 0], 12) + 0.0
    array([0., 1., 0.])
    """
    r, p, y = (float(a) for a in rpy)
    (cr, sr), (cp, sp), (cy, sy) = cos_sin(r), cos_sin(p), cos_sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def frame(table, source: str, where: str, scale: float) -> np.ndarray:
    """A rigid transform written as ``xyz`` + ``rpy`` (rpy in the file's angle unit) or ``matrix`` (4x4).

    ``scale`` converts rpy angles to radians.  A matrix must be rigid to 1e-9 (write rpy for rounded data).
    """
    if not isinstance(table, dict):
        raise RobotInputError(
            "must be a table with xyz/rpy or matrix, e.g. {xyz = [0, 0, 1], rpy = [0, 0, 0]}",
            source=source,
            where=where,
        )
    check_keys(table, {"xyz", "rpy", "matrix"}, source, where)
    if "matrix" in table:
        if "xyz" in table or "rpy" in table:
            raise RobotInputError("give either matrix or xyz/rpy, not both", source=source, where=where)
        m = table["matrix"]
        ok = isinstance(m, list) and len(m) == 4 and all(isinstance(r, list) and len(r) == 4 for r in m)
        try:
            g = np.array(m, dtype=float) if ok else None
        except (TypeError, ValueError):
            g = None
        if g is None or not np.all(np.isfinite(g)):
            raise RobotInputError("matrix must be 4 rows of 4 numbers", source=source, where=where)
        if rigid_residual(g) > tol.INPUT_RIGID:
            raise RobotInputError(
                "matrix is not a rigid transform (rotation part not orthonormal or last row not 0 0 0 1)",
                source=source,
                where=where,
            )
        return g
    g = np.eye(4)
    g[:3, :3] = rpy_matrix(vector(table, "rpy", 3, source, where, default=[0, 0, 0]) * scale)
    g[:3, 3] = vector(table, "xyz", 3, source, where, default=[0, 0, 0])
    return g


def unit_axis(v, source: str, where: str) -> np.ndarray:
    """Normalise a direction; a zero (or tiny) one is an error naming ``where``."""
    v = np.asarray(v, dtype=float)
    n = float(np.linalg.norm(v))
    if not n > tol.ZERO_AXIS:
        raise RobotInputError(f"axis {list(v)} has zero length", source=source, where=where)
    return v / n
