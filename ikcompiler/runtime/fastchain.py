"""The fast chain of a generated module run on arrays of targets, and the search on it (docs/design.md
section 6): leaves, the fast finish's routes (done / Newton / reference), the grid search's seeds
within an explicit memory budget.
"""

from __future__ import annotations

import contextlib
import math

import numpy as np

from ikcompiler.runtime.reference import SEARCH_NEWTON, twin_seeds
from subproblems import fast as _fk
from subproblems import tolerances as _tol
from subproblems._class2 import near_miss_rows

# Bytes one search instance (a target at one grid value, through the fast chain) may hold at its peak:
# an estimate with margin (its leaves are L x (n + 2) floats, the chain's temporaries a few hundred
# floats), not a measurement: no zoo robot takes the search by default.
BYTES_PER_INSTANCE = 16 * 1024
SEED_ERROR = _tol.SEARCH_SEED_ERROR  # search seeds missing by more (of the size) are dropped


def leaves(robot, goals, init, searched=()):
    """Leaves of the fast chain for N targets as arrays: Q (N, L, n), error (N, L), flag (N, L)."""
    free = tuple(init[:, robot.independent[pos]] for pos in robot.free) + tuple(searched)
    # a snapped plan's reference steps keep their near-miss least-squares rows: seeds of the true
    # robot's solutions that the snapped one lacks (reference.candidates)
    with np.errstate(all="ignore"), _near_rows(robot):  # degenerate instances may divide by ~0: deferred
        found = robot.fast_chain(_fk.ARRAY, _fk.goal_columns(goals, robot.target), free)
    return _fk.leaf_arrays(found, len(goals), len(robot.joint_names))


def _near_rows(robot):
    """subproblems._class2.near_miss_rows on a snapped plan, else nothing."""
    return near_miss_rows() if robot.polish else contextlib.nullcontext()


def search_candidates(robot, goals, init, budget: int):
    """Search fallback on the fast chain: every grid value of the searched joints through the closed
    form; the local minima of each branch's error along the grid are polished by Newton steps.  At
    most ``budget`` bytes of instances at a time (targets x grid values)."""
    axes = [np.linspace(-np.pi, np.pi, robot.grid, endpoint=False)] * len(robot.search)
    mesh = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(robot.search))
    P = len(mesh)
    THs, owners = [], []
    step = max(1, budget // (BYTES_PER_INSTANCE * P))  # targets per pass
    for start in range(0, len(goals), step):
        n = min(step, len(goals) - start)
        rep = np.repeat(np.arange(start, start + n), P)
        searched = [np.tile(mesh[:, k], n) for k in range(len(robot.search))]
        Q, err, flag = leaves(robot, goals[rep], init[rep], searched)
        E = np.where(np.isnan(err) | ((flag & _fk.EMPTY) != 0), np.inf, err)
        E = E.reshape((n,) + (robot.grid,) * len(robot.search) + (err.shape[1],))
        # Local minima along the grid (circular); on a plateau of equal values (a clamped, unreachable
        # branch is flat) only its first cell, and only seeds within SEED_ERROR of the target.
        is_min = np.isfinite(E) & (E <= SEED_ERROR * robot.scale)
        for ax in range(1, 1 + len(robot.search)):
            is_min &= E < np.roll(E, 1, axis=ax)
            is_min &= E <= np.roll(E, -1, axis=ax)
        rows, leaf = np.nonzero(is_min.reshape(n * P, -1))
        THs.append(Q[rows, leaf] @ robot.A.T + robot.B)
        owners.append(rep[rows])
    TH, owner = np.concatenate(THs), np.concatenate(owners)
    TH = robot.newton(TH, goals[owner], SEARCH_NEWTON)
    TH, owner = twin_seeds(robot, TH, owner, goals)
    none = np.zeros(len(TH), dtype=bool)
    return TH, owner, none, none



def search_width(robot) -> int:
    """Grid values per target of the search (1 without a search)."""
    return robot.grid ** len(robot.search) if robot.search else 1


def scalar_leaves(robot, T, free):
    """(goal entries, leaves) of one target on the scalar fast chain, or None when the scalar chain
    does not apply (no fast chain, a search or snapped plan) or the target is no finite transform."""
    if robot.fast_chain is None or robot.search or robot.polish or len(free) != len(robot.free_joints):
        return None
    try:
        free = tuple(float(f) for f in free)
    except (TypeError, ValueError):
        return None
    if not all(map(math.isfinite, free)):
        return None
    goal = _fk.goal_entries(T, robot.target)
    if goal is None:
        return None
    return robot.fast_chain(_fk.SCALAR, goal, free)


def rows_of_one(found, dof: int) -> tuple:
    """The fast finish's rows of one target as (q, residual, ls, continuum) arrays."""
    q = np.array([r[2] for r in found], dtype=float).reshape(len(found), dof)
    return (q, np.array([r[1] for r in found], dtype=float), np.array([r[0] for r in found], dtype=bool),
            np.array([r[3] for r in found], dtype=bool))

