"""Relations between joint axes, judged with tolerances relative to the robot's size.

Tolerance policy (adjustable through :class:`Tolerance`):

* ``exact``: a relation that holds to ``exact * scale`` (lengths) or ``exact`` (radians) is structural;
  the default 1e-9 (``subproblems.tolerances.EXACT``) matches the quality bar of docs/design.md section 9.
* ``snap``: a relation that holds only to ``snap * scale`` / ``snap`` rad (default 1e-3; a calibrated URDF
  whose axes miss by 1e-4 of its size) is *snapped*: the plan is built as if it held, and every
  solution is then corrected by Newton steps on the true robot and checked there.  Solutions that do
  not converge are flagged, never returned as exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from subproblems import tolerances
from subproblems.screw import cross3  # np.cross of 3-vectors written out: same bits, no axis handling


@dataclass(frozen=True)
class Tolerance:
    exact: float = tolerances.EXACT
    snap: float = tolerances.SNAP


def lines_meet(lines, scale: float) -> tuple[np.ndarray | None, float]:
    """Least-squares common point of lines ``[(w, r), ...]`` and the largest distance to it (/scale).

    Returns ``(None, inf)`` when the lines are (nearly) all parallel, so no unique point exists.
    """
    A = np.zeros((3, 3))
    b = np.zeros(3)
    for w, r in lines:
        P = np.eye(3) - np.outer(w, w)
        A += P
        b += P @ r
    if np.linalg.cond(A) > tolerances.LINES_MEET_CONDITION:
        return None, np.inf
    x = np.linalg.solve(A, b)
    miss = max(float(np.linalg.norm((np.eye(3) - np.outer(w, w)) @ (x - r))) for w, r in lines)
    return x, miss / scale


def parallel_miss(w1, w2) -> float:
    """Angle-like measure of how far two unit directions are from (anti)parallel."""
    return float(np.linalg.norm(cross3(w1, w2)))


def twist_line(xi) -> tuple[np.ndarray, np.ndarray]:
    """(direction, point) of a revolute twist's axis."""
    xi = np.asarray(xi, dtype=float)
    return xi[3:], cross3(xi[3:], xi[:3])


@dataclass(frozen=True)
class PairRelation:
    i: int
    j: int
    relation: str  # "coincident", "parallel", "intersecting", "skew"
    perpendicular: bool
    point: np.ndarray | None
    exact: bool


def pair_relation(chain, i: int, j: int, tol: Tolerance = Tolerance()) -> PairRelation | None:
    """Relation of the home axes of joints i and j (None when either is prismatic)."""
    a, b = chain.joints[i], chain.joints[j]
    if a.kind != "R" or b.kind != "R":
        return None
    (w1, r1), (w2, r2) = twist_line(a.twist), twist_line(b.twist)
    s = chain.scale
    par = parallel_miss(w1, w2)
    perp = abs(float(w1 @ w2))
    if par <= tol.snap:
        dist = float(np.linalg.norm(cross3(w1, r2 - r1))) / s
        rel = "coincident" if dist <= tol.snap else "parallel"
        exact = par <= tol.exact and (rel == "parallel" or dist <= tol.exact)
        return PairRelation(i, j, rel, False, None, exact)
    x, miss = lines_meet([(w1, r1), (w2, r2)], s)
    if miss <= tol.snap:
        return PairRelation(i, j, "intersecting", perp <= tol.snap, x, miss <= tol.exact)
    return PairRelation(i, j, "skew", perp <= tol.snap, None, True)


def persists(chain, i: int, j: int, rel: PairRelation, tol: Tolerance, samples: int = 4) -> bool:
    """Does the home relation of axes i < j hold for every value of the joints between them?  Judged on
    the compiler's sampled configurations (:func:`ikcompiler.geometry.facts.configurations`)."""
    from ikcompiler.geometry.facts import configurations
    from subproblems.screw import adjoint, fk

    if j == i + 1:
        return True
    for th in configurations(chain.joint_types, chain.scale, samples):
        G = fk(chain.twists[i + 1 : j], th[i + 1 : j])
        moved = adjoint(G) @ chain.joints[j].twist
        (w1, r1), (w2, r2) = twist_line(chain.joints[i].twist), twist_line(moved)
        if rel.relation in ("parallel", "coincident"):
            if parallel_miss(w1, w2) > tol.snap:
                return False
        elif rel.relation == "intersecting":
            x, miss = lines_meet([(w1, r1), (w2, r2)], chain.scale)
            if x is None or miss > tol.snap:
                return False
        elif rel.perpendicular and abs(float(w1 @ w2)) > tol.snap:
            return False
    return True


def analyse(chain, tol: Tolerance = Tolerance()) -> list[str]:
    """Human-readable lines describing the axis relations that hold in every configuration."""
    out = []
    names = [j.name for j in chain.joints]
    for i in range(chain.n):
        for j in range(i + 1, chain.n):
            rel = pair_relation(chain, i, j, tol)
            if rel is None or rel.relation == "skew" and not rel.perpendicular:
                continue
            if not persists(chain, i, j, rel, tol):
                continue
            txt = f"{names[i]} & {names[j]}: {rel.relation}"
            if rel.perpendicular:
                txt += ", perpendicular"
            if rel.point is not None:
                txt += " at (" + ", ".join(f"{x:.6g}" for x in rel.point + 0.0) + ")"
            if not rel.exact:
                txt += "  [near-relation: snapped, corrected on the true robot]"
            out.append(txt)
    for j in chain.joints:
        if j.kind == "T":
            for k, other in enumerate(chain.joints):
                if other.kind == "R" and parallel_miss(j.axis, other.axis) <= tol.snap:
                    out.append(f"{j.name} (prismatic) moves along the axis direction of {names[k]}")
    return out
