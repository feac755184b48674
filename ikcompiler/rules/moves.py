"""The rewriting rules of docs/design.md section 3 as *moves*: from the joints solved so far, rewrite the POE
equation into one canonical subproblem whose inputs are computable, and say which joints it solves.

A move is proposed from the axis geometry of the *current* equation: the unsolved joints' twists
carried by the solved joints (rules 5 and 7).  A relation such as "the last three axes meet in a point"
must hold for every value of the solved joints; that is judged on random configurations
(``Context.samples``), not assumed.  The search (``ikcompiler.search``) then validates each proposed
move numerically before it trusts it.

Each move is a typed plan step (:mod:`ikcompiler.steps`, docs/design.md section 12) carrying its rule in
words; the search reads what it solves (``solves``) and the group sums it gives (``gives_sums``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ikcompiler.geometry.relations import Tolerance, lines_meet, parallel_miss, twist_line
from ikcompiler.steps import (
    CoupledDistanceStep,
    DistanceStep,
    LeadingAxialStep,
    OrientationAxialStep,
    OrientationStep,
    PointStep,
    S1Step,
    Step,
    SumStep,
    TrailingAxialStep,
)
from subproblems.screw import adjoint, inverse_transform, twist_exp


@dataclass
class Context:
    """What every move needs to know about the robot and the target."""

    twists: np.ndarray
    kinds: str
    names: tuple[str, ...]
    scale: float
    home: np.ndarray
    target: str = "pose"
    tol: Tolerance = field(default_factory=Tolerance)
    samples: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    couplings: tuple = ()  # (joint, master, a, b) index tuples

    @property
    def n(self) -> int:
        return len(self.kinds)

    def frames(self, solved: frozenset) -> list[dict[int, tuple[np.ndarray, np.ndarray]]]:
        """Per sample: unsolved joint -> (transformed twist, K_u) for the given solved set."""
        out = []
        for th in self.samples:
            G = np.eye(4)
            fr = {}
            for i in range(self.n):
                if i in solved:
                    G = G @ twist_exp(self.twists[i], th[i])
                else:
                    fr[i] = (adjoint(G) @ self.twists[i], G.copy())
            out.append(fr)
        return out


def _name_list(ctx, joints) -> str:
    return ", ".join(ctx.names[j] for j in joints)


def _concurrent(ctx, frames, group) -> tuple[np.ndarray | None, bool]:
    """Home-frame point p0 (p = K_{group[0]} p0) common to the group's axes in every sample."""
    p0s, exact = [], True
    for fr in frames:
        x, miss = lines_meet([twist_line(fr[j][0]) for j in group], ctx.scale)
        if x is None or miss > ctx.tol.snap:
            return None, False
        exact &= miss <= ctx.tol.exact
        K = fr[group[0]][1]
        p0s.append(inverse_transform(K)[:3, :3] @ x + inverse_transform(K)[:3, 3])
    spread = max(float(np.linalg.norm(p - p0s[0])) for p in p0s) / ctx.scale
    if spread > ctx.tol.snap:
        return None, False
    return np.mean(p0s, axis=0), exact and spread <= ctx.tol.exact


def _parallel(ctx, frames, group) -> tuple[list[float] | None, bool]:
    """Signs s_i with w_i = s_i w_first in every sample, or None when the group is not parallel."""
    signs, exact = None, True
    for fr in frames:
        w0 = fr[group[0]][0][3:]
        cur = []
        for j in group:
            w = fr[j][0][3:]
            miss = parallel_miss(w0, w)
            if miss > ctx.tol.snap:
                return None, False
            exact &= miss <= ctx.tol.exact
            cur.append(1.0 if w @ w0 > 0 else -1.0)
        if signs is not None and cur != signs:
            return None, False
        signs = cur
    return signs, exact


def _axis_point(ctx, joint) -> np.ndarray:
    """A point on the home axis of ``joint``: the one closest to the home tool position."""
    w, r = twist_line(ctx.twists[joint])
    t = ctx.home[:3, 3]
    return r + w * float(w @ (t - r))


def _group_runs(ctx, frames, joints):
    """Split revolute joints (in equation order) into maximal runs of parallel axes."""
    runs = []
    for j in joints:
        if runs:
            signs, _ = _parallel(ctx, frames, runs[-1] + [j])
            if signs is not None:
                runs[-1].append(j)
                continue
        runs.append([j])
    return runs


def _code(prefix, ctx, joints) -> str:
    return prefix + "-" + "".join(ctx.kinds[j] for j in joints)


def propose(ctx: Context, solved: frozenset, sums: frozenset) -> list[Step]:
    """Every move the rules allow from the state (solved joints, known group sums)."""
    unknown = [i for i in range(ctx.n) if i not in solved]
    if not unknown:
        return []
    frames = ctx.frames(solved)
    moves: list[Step] = []
    known = sorted(solved)

    # SUM: a group sum known and one member left.
    for group in sums:
        left = [j for j, _ in group if j not in solved]
        if len(left) == 1:
            moves.append(
                SumStep(
                    code="SUM",
                    known=known,
                    solve=left,
                    members=group,
                    rule=f"{ctx.names[left[0]]} from the known sum of joints "
                    f"{_name_list(ctx, [j for j, _ in group])} (parallel axes add up, rule 2)",
                )
            )

    if ctx.target == "pose":
        moves += _orientation_moves(ctx, frames, unknown, known, sums)
        for inverted in (False, True):
            seq = unknown[::-1] if inverted else unknown
            inv_txt = " on the inverted equation (rule 5)" if inverted else ""
            if len(seq) <= 3:
                moves.append(
                    S1Step(
                        code=_code("S1", ctx, seq),
                        known=known,
                        inverted=inverted,
                        solve=seq,
                        rule=f"rigid motion of the last unknowns{inv_txt} (rules 5, 7)",
                    )
                )
            for j in (3, 2, 1):
                trail = seq[-j:]
                if len(seq) <= j or any(ctx.kinds[t] != "R" for t in trail):
                    continue
                if j == 1:
                    p0, exact = _axis_point(ctx, trail[0]), True
                else:
                    p0, exact = _concurrent(ctx, frames, trail)
                    if p0 is None:
                        continue
                why = (
                    f"a point on the axis of {ctx.names[trail[0]]}"
                    if j == 1
                    else f"the point where the axes of {_name_list(ctx, trail)} meet"
                )
                moves += _point_moves(
                    ctx, frames, seq[:-j], trail, p0, exact, known, inverted, f"rule 1: {why}{inv_txt}"
                )
    elif ctx.target == "orientation":
        moves += _orientation_moves(ctx, frames, unknown, known, sums)
    elif ctx.target == "position":
        p0 = ctx.home[:3, 3]
        moves += _point_moves(ctx, frames, unknown, [], p0, True, known, False, "the tool point")
    return moves


def _orientation_moves(ctx, frames, unknown, known, sums) -> list[Step]:
    moves = []
    revs = [j for j in unknown if ctx.kinds[j] == "R"]
    if not revs:
        return moves
    runs = _group_runs(ctx, frames, revs)
    snapped = False
    if len(runs) <= 3:
        groups, gives = [], []
        for run in runs:
            signs, exact = _parallel(ctx, frames, run)
            snapped |= not exact
            groups.append([[j, s] for j, s in zip(run, signs)])
            gives.append(tuple((j, s) for j, s in zip(run, signs)))
        new = [g for g in gives if len(g) == 1 or g not in sums]
        if new:
            txt = ", ".join(
                ctx.names[g[0][0]] if len(g) == 1 else "(" + "+".join(ctx.names[j] for j, _ in g) + ")"
                for g in gives
            )
            moves.append(
                OrientationStep(
                    code="O-" + "R" * len(runs),
                    known=known,
                    groups=groups,
                    solve=[g[0][0] for g in gives if len(g) == 1],
                    snapped=snapped,
                    rule=f"rule 2: orientation separation; the rotation gives {txt}",
                )
            )
    # OH: leading parallel run, one joint, trailing parallel run: h^T R_mid x = h^T R' x.
    if len(runs) == 3:
        lead, mid, trail = runs
        if len(mid) == 1:
            moves.append(
                OrientationAxialStep(
                    code="H-R",
                    known=known,
                    inverted=False,
                    lead=lead,
                    trail=trail,
                    solve=mid,
                    snapped=snapped,
                    rule="rules 2 and 6: the axis of "
                    f"{ctx.names[trail[-1]]} keeps its direction under its own run, its component "
                    f"along the axis of {ctx.names[lead[0]]} is unchanged by that run: "
                    f"rotate-to-plane in {ctx.names[mid[0]]}",
                )
            )
    return moves


def _coupled_distance_move(ctx, frames, base, lead, mid, why) -> list[Step]:
    """Rule 3 when the two middle joints are coupled revolute joints: one unknown, a root search."""
    pair = {(dep, master): (a, b) for dep, master, a, b in ctx.couplings}
    j, k = mid
    if ctx.kinds[j] != "R" or ctx.kinds[k] != "R":
        return []
    if (k, j) in pair:
        var, coupling = j, pair[(k, j)]
    elif (j, k) in pair:
        var, coupling = k, pair[(j, k)]
    else:
        return []
    if abs(coupling[0]) > 3:
        return []
    c0, c_exact = _fixed_center(ctx, frames, lead)
    if c0 is None:
        return []
    rule = (
        f"{why}; rule 3: distance to a point fixed by {_name_list(ctx, lead)}; "
        f"{_name_list(ctx, mid)} are coupled: one angle, all roots of the distance equation"
    )
    extra = {"solve_pair": list(mid), "var": var, "coupling": [float(coupling[0]), float(coupling[1])]}
    centre = [float(x) for x in c0]
    return [_lead_move(base, c_exact, CoupledDistanceStep, "S3-1D", [var], lead, rule, c0=centre, **extra)]


def _fixed_center(ctx, frames, lead):
    """A point fixed by the leading revolute joints: on the axis (one joint) or their common point."""
    if len(lead) == 1:
        return _axis_point(ctx, lead[0]), True
    return _concurrent(ctx, frames, lead)


def _lead_move(base, exact, step_type, code, solve, lead, rule, **extra) -> Step:
    """A point move that also uses the leading joints ``lead`` (rules 3 and 6)."""
    fields = dict(base, snapped=base["snapped"] or not exact)
    return step_type(**fields, code=code, solve=list(solve), lead=lead, rule=rule, **extra)


def _point_moves(ctx, frames, rest, trail, p0, exact, known, inverted, why) -> list[Step]:
    base = {"known": known, "inverted": inverted, "trail": trail, "p0": [float(x) for x in p0]}
    base["snapped"] = not exact
    moves = []
    if 1 <= len(rest) <= 3:
        code = _code("S2", ctx, rest)
        moves.append(PointStep(**base, code=code, solve=list(rest), rule=f"{why}: point to point"))
    for i in range(1, len(rest)):
        lead, mid = rest[:i], rest[i:]
        if any(ctx.kinds[j] != "R" for j in lead):
            continue
        if len(mid) == 2:
            moves += _coupled_distance_move(ctx, frames, base, lead, mid, why)
            continue
        if len(mid) != 1:
            continue
        c0, c_exact = _fixed_center(ctx, frames, lead)
        if c0 is not None:
            rule = f"{why}; rule 3: distance to a point fixed by {_name_list(ctx, lead)}"
            code = _code("S3", ctx, mid)
            centre = [float(x) for x in c0]
            moves.append(_lead_move(base, c_exact, DistanceStep, code, mid, lead, rule, c0=centre))
        signs, p_exact = _parallel(ctx, frames, lead)
        if signs is not None:
            rule = f"{why}; rule 6: projection on the common axis of {_name_list(ctx, lead)}"
            moves.append(_lead_move(base, p_exact, LeadingAxialStep, _code("H", ctx, mid), mid, lead, rule))
    if len(rest) >= 2 and all(ctx.kinds[j] == "R" for j in rest[1:]):
        signs, p_exact = _parallel(ctx, frames, rest[1:])
        if signs is not None:
            rule = (
                f"{why}; rule 6: the parallel axes of {_name_list(ctx, rest[1:])} keep the "
                "component along their direction"
            )
            code = _code("H", ctx, rest[:1])
            moves.append(_lead_move(base, p_exact, TrailingAxialStep, code, rest[:1], rest[1:], rule))
    return moves
