"""Selection glue of one target's rows: aliases, the order by distance to a seed, and what
``solve_info`` adds (sigma_min, the solutions the limits exclude) (docs/motion.md; subproblems/select.py).
"""

from __future__ import annotations

import numpy as np

from subproblems import select as _sel


def alias_kinds(robot) -> str:
    """The joint types with each free joint marked prismatic: a free value is taken as given, never
    replaced by a 2 pi alias, and checked against its limits as given (dispatch.Solver._free_as_given)."""
    kinds = list(robot.joint_types)
    for pos in robot.free:
        kinds[pos] = "T"
    return "".join(kinds)


def select(robot, q, keep, limits, aliases, q_seed, weights):
    """Alias expansion and seed ordering of rows q (k, n): (rows, index into the original rows)."""
    idx = np.arange(len(q))
    if aliases and limits:
        q, idx = _sel.aliases(q, alias_kinds(robot), robot.lower, robot.upper)
    if q_seed is not None:
        if limits and not aliases:  # the in-limit alias the seed reaches with least motion
            q = _sel.nearest_alias(q, q_seed, alias_kinds(robot), robot.lower, robot.upper)
        dist = _sel.distance(q, q_seed, robot.joint_types, robot.scale, weights, wrap=not limits)
        order = np.lexsort((dist, ~keep[idx]))  # exact rows first (keep False last), then by distance
        q, idx = q[order], idx[order]
    return q, idx


def info(robot, found, unlimited, limits, aliases, q_seed, weights):
    """The SolveInfo of rows ``found`` (q, residual, ls, continuum); ``unlimited``: the rows without
    limits, whose out-of-limit ones become ``excluded`` (with ``limits``)."""
    q, res, ls, cont = found
    q, idx = select(robot, q, ~ls, limits, aliases, q_seed, weights)
    res, ls, cont = res[idx], ls[idx], cont[idx]
    sig = _sel.sigma_min(q, twists=robot.twists, A=robot.A, b=robot.B, home=robot.home, scale=robot.scale,
                         target=robot.target)
    excluded = ()
    if limits:
        q_all, res_all, ls_all, _ = unlimited
        out = _sel.excluding_joints(q_all, alias_kinds(robot), robot.lower, robot.upper)
        pos = list(robot.free)  # a given free value: inside its limits exactly as _free_as_given asks
        out[:, pos] = ~((q_all[:, pos] >= robot.lower[pos]) & (q_all[:, pos] <= robot.upper[pos]))
        excluded = tuple(_sel.Excluded(q_all[r], tuple(robot.joint_names[j] for j in np.nonzero(out[r])[0]),
                                       float(res_all[r]), bool(ls_all[r]))
                         for r in np.nonzero(out.any(axis=1))[0])
    return _sel.SolveInfo(q, res, ls, cont, sig, excluded)
