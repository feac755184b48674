"""A readable text description of a chain: joint string, axes, limits, couplings, home pose."""

from __future__ import annotations

import math

import numpy as np


def _fmt(v) -> str:
    return "(" + ", ".join(f"{x: .6g}" for x in np.asarray(v, dtype=float) + 0.0) + ")"


def _limit(x: float) -> str:
    return "inf" if math.isinf(x) else f"{x:.6g}"


def describe(chain) -> str:
    """Multi-line description, e.g. for ``ikc describe``.

    One line per joint: index, name, kind, axis direction, a point on the axis (revolute) and limits.
    """
    unit = f" [{chain.units}]" if chain.units else ""
    lines = [
        f"robot   {chain.name}",
        f"joints  {chain.joint_types}  ({chain.n} joints, {chain.dof} independent){unit}",
        f"frames  base {chain.base!r} -> tip {chain.tip!r}",
    ]
    if chain.source:
        lines.append(f"source  {chain.source}")
    lines.append("")
    lines.append(f"  {'#':>2} {'name':<16} {'type':<4} {'axis':<32} {'point on axis':<32} limits")
    for i, j in enumerate(chain.joints, start=1):
        point = _fmt(j.point) if j.kind == "R" else "-"
        lim = f"[{_limit(j.lower)}, {_limit(j.upper)}]"
        lines.append(f"  {i:>2} {j.name:<16} {j.kind:<4} {_fmt(j.axis):<32} {point:<32} {lim}")
    for c in chain.couplings:
        lines.append(f"  coupling: {c.joint} = {c.a:g} * {c.master} + {c.b:g}")
    lines.append("")
    lines.append("home pose g_st(0):")
    for row in np.asarray(chain.home):
        lines.append("  " + "  ".join(f"{x: .6g}" for x in row + 0.0))
    for note in chain.notes:
        lines.append(f"note: {note}")
    return "\n".join(lines)
