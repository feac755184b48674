"""The reference runtime of a generated module: candidates from the interpreted steps (or the search,
the numerical seeds, the general 6R elimination), checked on the true robot (docs/design.md
sections 5 and 6; docs/finish.md).

Everything here works on arrays of targets; :func:`settle` is the path that settles any target the
fast chain (Python or C) hands back.
"""

from __future__ import annotations

import numpy as np

from subproblems import continuation as _ct
from subproblems import fast as _fk
from subproblems import plan_runtime as _rt
from subproblems import tolerances as _tol

CONTINUUM_NEWTON = 60  # Newton steps pulling a self-motion's representative onto the family
SEARCH_NEWTON = 8  # Newton steps on the search's seeds
NEAR_MISS = _tol.NEAR_MISS  # rows missing by less (of the size) get more Newton steps in _complete
FINISH_MARGIN = _tol.FINISH_MARGIN  # as the C finish: on to well inside the precision


def correct(robot, TH, owner, goals, general6):
    """Snapped plan: carry the snapped robot's candidates to the true robot by continuation in the
    geometry, re-tracking rows that collide (subproblems.continuation; docs/calibrated.md).  Targets
    where the count may differ (rescue seeds were needed) are also given to the general 6R solver of
    the true robot when there is one: its rows join the candidates."""
    report = {}
    TH, owner = _ct.correct(TH, goals[owner], owner, twists0=robot.plan_twists, twists1=robot.twists,
                            home=robot.home, A=robot.A, b=robot.B, independent=robot.vary,
                            kinds=robot.vary_kinds, target=robot.solve_target, hold=robot.free,
                            scale=robot.scale, tol=robot.tol, plain=robot.polish, report=report)
    doubt = report.get("uncertain", ())
    solver = general6() if len(doubt) else None
    if solver is not None:
        TH2, own2 = solver.rows(goals[doubt])  # a plain 6R chain: its rows are all joint values
        TH, owner = np.concatenate([TH, TH2]), np.concatenate([owner, np.asarray(doubt)[own2]])
    return TH, owner


def true_general6(robot):
    """The true robot's general 6R solver (subproblems.general6), or None when the robot is no plain
    6R pose chain or the package has no general solver.

    Built here without the plan's arrangements: a snapped plan (the only caller) has none, and
    ``General6`` chooses them on fixed sample poses of the robot itself, so the order is the one the
    compiler would record (same twists, home and seed).  A general-6r module's own solver is reused."""
    if robot.general6 is not None:
        return robot.general6
    if robot.kinds != "RRRRRR" or robot.solve_target != "pose" or robot.free_joints or robot.couplings:
        return None
    try:
        from subproblems import general6
    except ImportError:
        return None
    try:
        return general6.General6(robot.twists, robot.home, robot.scale)
    except general6.General6Error:
        return None


def candidates(robot, goals, Td, init, correct):
    """Candidate joint vectors of the reference runtime: (TH, owner, ls, continuum)."""
    N = len(goals)
    if robot.method == "numerical":
        step = robot.steps[0]
        lo, hi = np.maximum(robot.vary_lower, -robot.scale), np.minimum(robot.vary_upper, robot.scale)
        Q0, owner = _rt.numerical_seeds(N, step["starts"], lo, hi)
        TH = Q0 @ robot.A.T + robot.B
        TH = np.where(~np.isnan(init[owner]), init[owner], TH)
        TH = robot.newton(TH, goals[owner], step["iters"])
        return TH, owner, *_no_flags(len(TH))
    if robot.method == "general-6r":
        TH, owner = robot.general6.rows(goals)
        return TH, owner, *_no_flags(len(TH))
    if robot.search:
        step = {"search": list(robot.search), "grid": robot.grid, "steps": robot.steps, "home": robot.home,
                "scale": robot.scale, "target": robot.solve_target}
        TH, owner = _rt.run_search(step, robot.plan_twists, robot.kinds, Td, robot.couplings,
                                   robot.n_groups, init)
        TH = robot.newton(TH, goals[owner], SEARCH_NEWTON)
        return TH, owner, *_no_flags(len(TH))
    TH, owner, ls, _, cont = _rt.run_plan(robot.steps, robot.plan_twists, robot.kinds, Td,
                                          robot.couplings, robot.n_groups, init)
    if robot.alt_steps and cont.any():
        redo = np.unique(owner[cont])
        TH2, own2, ls2, _, cont2 = _rt.run_plan(robot.alt_steps, robot.plan_twists, robot.kinds,
                                                Td[redo], robot.couplings, robot.n_groups, init[redo])
        TH, owner = np.concatenate([TH, TH2]), np.concatenate([owner, redo[own2]])
        ls, cont = np.concatenate([ls, ls2]), np.concatenate([cont, cont2])
    if cont.any():
        # A self-motion: the representative a step chose may not complete the pose; Newton steps
        # on every joint pull it onto a nearby exact solution of the continuum.
        TH[cont] = robot.newton_until_exact(TH[cont], goals[owner[cont]], CONTINUUM_NEWTON)
    if robot.polish and len(TH):
        TH, owner = correct(TH, owner, goals)
        extra = np.zeros(len(TH) - len(ls), dtype=bool)
        ls, cont = np.concatenate([ls, extra]), np.concatenate([cont, extra])
    return TH, owner, ls, cont


def _no_flags(n):
    return np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)


def complete(robot, TH, owner, ls, cont, goals, limits):
    """Check candidates on the true robot (a few Newton steps for near misses), wrap, pack slots."""
    if len(TH):
        scale, exact = robot.scale, robot.tol * robot.scale
        # Tangent geometry (a double root) costs about half the digits; a few Newton steps restore them.
        err = robot.error(_rt.fk_batch(robot.twists, np.nan_to_num(TH), robot.home), goals[owner])
        # At a double root Newton converges only linearly (the residual falls about 4x a step): rows
        # still above the precision get more steps, in rounds of 3, up to 15 in all.
        near = (err > exact) & (err < NEAR_MISS * scale)
        TH = robot.newton_until_exact(TH, goals[owner], 15, FINISH_MARGIN, rows=near, per_round=3)
        if limits:
            TH = clamped_onto_limits(robot, TH, owner, goals)
    dedupe = _fk.SPLIT_ROOT if robot.search or robot.method == "numerical" else None
    return _rt.finish(TH, owner, ls, len(goals), twists=robot.twists, kinds=robot.kinds, home=robot.home,
                      independent=robot.independent, targets=goals, scale=robot.scale, tol=robot.tol,
                      slots=robot.slots, error=robot.error, cont=cont,
                      limits=(robot.lower, robot.upper) if limits else None, A=robot.A, b=robot.B,
                      vary=robot.vary, dedupe=dedupe)


def clamped_onto_limits(robot, TH, owner, goals):
    """Rows with a value just outside a limit (a double root at a limit is located to sqrt(eps) only):
    the value clamped onto the limit, then Newton steps on the other joints (the clamped and free ones
    held), so that the row as returned is exact or flagged, never outside its limits."""
    ind = list(robot.independent)
    ok = ~np.isnan(TH).any(axis=1)
    Qr, _, out, clamped = _fk.represent(np.nan_to_num(TH[:, ind]), robot.joint_types, robot.lower,
                                        robot.upper, True, clamps=True)
    rows = ok & ~out & clamped.any(axis=1)
    if not rows.any():
        return TH
    TH = TH.copy()
    TH[np.ix_(rows, ind)] = Qr[rows]
    TH[rows] = TH[rows][:, list(robot.vary)] @ robot.A.T + robot.B
    for pattern in np.unique(clamped[rows], axis=0):
        sel = np.nonzero(rows & (clamped == pattern).all(axis=1))[0]
        hold = tuple(robot.free) + tuple(int(j) for j in np.nonzero(pattern)[0])
        TH[sel] = robot.newton(TH[sel], goals[owner[sel]], 3, hold=hold)
    return TH
