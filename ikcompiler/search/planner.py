"""Search for the cheapest chain of subproblems (docs/design.md section 5).

State: which joints are solved and which parallel-group sums are known.  A move (from
:mod:`ikcompiler.rules`) solves one canonical subproblem.  Every proposed move is validated on random
configurations of the robot before it is trusted: its subproblem must return the sampled joint values
among its solutions, never a continuum.  That makes the search sound for any geometry: a relation the
rules believed in but that does not hold shows up as a failed validation, with the reason kept for the
report.

The cost of a chain adds ``log2(branches)`` and a per-subproblem price, so it prefers fewer branches and
cheaper subproblems.  Expansion is Dijkstra in cost order over the lazily built state graph,
deterministic (fixed seeds, ordered moves) and bounded by a state budget.  Each state is accepted once,
from the cheapest validated move into it, so the accepted moves form a shortest-path tree: the chain is
read back along the parent links from the goal (no second graph search: docs/design.md section 13).
"""

from __future__ import annotations

import dataclasses
import heapq
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ikcompiler.rules.moves import Context, propose
from ikcompiler.steps import OrientationStep, Step, SumStep
from subproblems import codes, max_solutions
from subproblems.core import SubproblemError
from subproblems.plan_runtime import COUPLED_ROOT_SLOTS, solve_step
from subproblems.screw import twist_exp

# Price of each subproblem beyond its branching: closed-form geometry is cheap, eliminations are not.
PRICE = {"S1": 0.6, "S2": 0.5, "S3": 0.5, "O": 0.3, "H": 0.4, "SUM": 0.05}
GENERAL_PRICE = {"S2-RRR": 3.0, "S2-RRT": 1.0, "S2-TRR": 1.0, "S2-RTR": 1.5, "S1-RRR": 0.5}
# Class I pairs have no plain-arithmetic kernel: the fast chain calls their reference solver, 1-3 ms a
# pose (2-joint legs and fingers of the robot-description packages took 1.3-40 ms a solve, with the
# snapped robots' correction).  Priced so that a point step and an orientation step (S2-R or S2-T with
# a point on the other joint's axis, then O-R: kernels, ~4 us) win where the rules offer them; where
# they do not (two slides), the pair still solves.  docs/design.md section 5.
REFERENCE_PRICE = {"S1-RR": 0.5, "S1-RT": 0.5, "S1-TR": 0.5, "S1-TT": 0.5}


def move_cost(code: str) -> float:
    if code == "SUM":
        return PRICE["SUM"]
    if code == "S3-1D":  # a coupled pair's distance equation: a root search, priced above closed form
        return math.log2(COUPLED_ROOT_SLOTS) + 1.0
    prefix = code.split("-")[0]
    if code not in codes():
        return math.inf  # no solver registered for this subproblem type
    extra = GENERAL_PRICE.get(code, 0.0) + REFERENCE_PRICE.get(code, 0.0)
    return math.log2(max(1, max_solutions(code))) + PRICE.get(prefix, 1.0) + extra


@dataclass
class SearchReport:
    """What the search tried: per state, the moves proposed and why each failed."""

    tried: list[str] = field(default_factory=list)
    expanded: int = 0

    def summary(self, limit: int = 25) -> str:
        head = self.tried[:limit]
        more = len(self.tried) - len(head)
        return "\n".join(head + ([f"... and {more} more"] if more > 0 else []))


class Trials:
    """Random configurations of the robot and their targets, used to validate moves."""

    def __init__(self, ctx: Context, couplings, lower, upper, count: int = 6, seed: int = 7):
        rng = np.random.default_rng(seed)
        lo = np.where(np.isfinite(lower), lower, -ctx.scale)
        hi = np.where(np.isfinite(upper), upper, ctx.scale)
        th = rng.uniform(lo, hi, size=(count, ctx.n))
        _fill_coupled(th, couplings)
        self.theta = th
        g = np.empty((count, 4, 4))
        for k, t in enumerate(th):
            G = np.eye(4)
            for i in range(ctx.n):
                G = G @ twist_exp(ctx.twists[i], t[i])
            g[k] = G
        if ctx.target == "position":
            Td = np.broadcast_to(np.eye(4), (count, 4, 4)).copy()
            Td[:, :3, 3] = (g @ ctx.home)[:, :3, 3] - ctx.home[:3, 3]
        else:
            Td = g  # g_d g0^-1 = product of exponentials
        self.Td = Td


def _fill_coupled(th, couplings):
    for dep, master, a, b in couplings:
        th[:, dep] = a * th[:, master] + b


def _closure(solved: frozenset, couplings) -> frozenset:
    s = set(solved)
    changed = True
    while changed:
        changed = False
        for dep, master, _, _ in couplings:
            if master in s and dep not in s:
                s.add(dep)
                changed = True
            elif dep in s and master not in s:
                s.add(master)
                changed = True
    return frozenset(s)


def _angle_close(a, b, kinds, cols, tol):
    d = a - b
    for c, j in enumerate(cols):
        if kinds[j] == "R":
            d[..., c] = np.remainder(d[..., c] + math.pi, 2 * math.pi) - math.pi
    return np.abs(d).max(axis=-1) <= tol


def validate(ctx: Context, move: Step, trials: Trials, couplings, tol: float) -> str | None:
    """None when the move recovers the trial values; otherwise the reason it fails."""
    if isinstance(move, SumStep):
        return None
    th = trials.theta
    TH = np.where(np.isin(np.arange(ctx.n), move.needs), th, np.nan)
    try:
        res = solve_step(move, ctx.twists, ctx.kinds, trials.Td, TH)
    except (SubproblemError, KeyError, ValueError, np.linalg.LinAlgError) as exc:
        return f"{type(exc).__name__}: {exc}"
    if res.continuum.any():
        return "the subproblem has a continuum of solutions here"
    if isinstance(move, OrientationStep):
        truth = np.stack([sum(s * th[:, j] for j, s in g) for g in move.groups], axis=1)
        cols_kinds = "R" * truth.shape[1]
        ok = _angle_close(res.q, truth[:, None, :], cols_kinds, range(truth.shape[1]), tol)
    else:
        solve = list(move.solves)
        ok = _angle_close(res.q, th[:, solve][:, None, :], ctx.kinds, solve, tol * max(1.0, ctx.scale))
    found = np.any(ok & res.valid, axis=1)
    if not found.all():
        return f"misses the sampled joint values in {int((~found).sum())} of {len(found)} trials"
    return None


def move_key(move: Step) -> str:
    """A stable identity of a move (its fields, minus the prose)."""
    return repr(sorted((k, v) for k, v in move.to_dict().items() if k != "rule"))


def search(
    ctx: Context, couplings, lower, upper, start: frozenset, max_states: int = 400, banned_first=frozenset()
):
    """Cheapest validated chain from ``start`` to all joints solved: (steps, cost, report).

    ``banned_first`` holds :func:`move_key` of moves not to take from the start state (used to find an
    alternative chain for targets where the best one meets a continuum).
    """
    trials = Trials(ctx, couplings, lower, upper)
    report = SearchReport()
    start_state = (_closure(start, couplings), frozenset())
    # state -> (parent state, the validated move from it): the shortest-path tree of the accepted states
    parent_of: dict = {}
    counter = itertools.count()
    # Lazy Dijkstra: a move is validated only when the state it leads to is the cheapest one left, so
    # expensive subproblems that never beat a cheaper chain are never run.
    heap = [(0.0, next(counter), start_state, None, None)]
    done: dict = {}
    goal = None
    while heap and report.expanded < max_states:
        cost, _, state, parent, move = heapq.heappop(heap)
        if state in done:
            continue
        if move is not None:
            why = validate(ctx, move, trials, couplings, 1e-2 if move.get("snapped") else 1e-6)
            if why is not None:
                names = ", ".join(ctx.names[j] for j in move.solves)
                report.tried.append(f"{move.code} for ({names}) via {move.rule}: {why}")
                continue
            parent_of[state] = (parent, move)
        done[state] = cost
        report.expanded += 1
        solved, sums = state
        if len(solved) == ctx.n:
            goal = state
            break
        for mv in propose(ctx, solved, sums):
            if state == start_state and move_key(mv) in banned_first:
                continue
            new_sums = set(sums) | set(mv.gives_sums)
            nxt = (
                _closure(frozenset(solved) | frozenset(mv.solves), couplings),
                frozenset(new_sums),
            )
            step_cost = move_cost(mv.code)
            if math.isinf(step_cost):
                report.tried.append(f"{mv.code} via {mv.rule}: no solver for this subproblem type")
            elif nxt != state and nxt not in done:
                heapq.heappush(heap, (cost + step_cost, next(counter), nxt, state, mv))
    if goal is None:
        return None, math.inf, report
    steps = []
    state = goal
    while state != start_state:
        state, move = parent_of[state]
        steps.append(move)
    return steps[::-1], done[goal], report


def finalize_steps(steps: list[Step]) -> tuple[list[Step], int]:
    """Number the parallel groups (the ids the runtime keeps the sums under); returns (steps, count)."""
    ids: dict = {}
    out = []
    for s in steps:
        if isinstance(s, OrientationStep):
            gids = [ids.setdefault(g, len(ids)) if len(g) > 1 else -1 for g in s.groups]
            s = dataclasses.replace(s, group_ids=gids)
        if isinstance(s, SumStep):
            s = dataclasses.replace(s, group=ids[s.members])
        out.append(s)
    return out, len(ids)


__all__ = ["search", "validate", "finalize_steps", "move_cost", "SearchReport"]
