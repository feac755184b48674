"""The reference runtime of a generated module: candidates from the interpreted steps (or the search,
the numerical seeds, the general 6R elimination), checked on the true robot (docs/design.md
sections 5 and 6; docs/finish.md).

Everything here works on arrays of targets; :func:`settle` is the path that settles any target the
fast chain (Python or C) hands back.
"""

from __future__ import annotations

import contextlib

import numpy as np

from ikcompiler.runtime import freefold, nearfamily, selfmotion
from subproblems import continuation as _ct
from subproblems import fast as _fk
from subproblems import plan_runtime as _rt
from subproblems import tolerances as _tol
from subproblems._class2 import near_miss_rows

CONTINUUM_NEWTON = 60  # Newton steps pulling a self-motion's representative onto the family
SEARCH_NEWTON = 8  # Newton steps on the search's seeds
NEAR_MISS = _tol.NEAR_MISS  # rows missing by less (of the size) get more Newton steps in _complete
FINISH_MARGIN = _tol.FINISH_MARGIN  # as the C finish: on to well inside the precision
# Offsets (rad, or lengths over the size) along a self-motion at which a representative that misses or
# lies outside the limits is tried again: the circle in 64 steps.  A numerical self-motion (a relation
# missed by ~1e-9) is exact to the precision only on an arc around the true solution, ~0.3 rad wide on
# puma560.urdf (rtb-data) at q5 = 0; Newton's damped steps do not move along it (docs/calibrated.md).
SELF_MOTION_OFFSETS = np.arange(-31, 33) * (np.pi / 32)
SELF_MOTION_NEWTON = 5  # Newton steps at each offset (across the family: it converges fast)
#: Exact rows of one target closer than this (rad, or lengths over the size) are tried as a stalled
#: copy of one root (without_stalled_copies); the merge itself needs SPLIT_ROOT after a step.
STALLED_PAIR = 1e-4
CLAMPED_NEWTON = 3  # damped Newton steps on a row with a value clamped onto its limit (the C finish's too)


def correct(robot, TH, owner, goals, general6, family):
    """Snapped plan: carry the snapped robot's candidates to the true robot by continuation in the
    geometry, re-tracking rows that collide (subproblems.continuation; docs/calibrated.md).  Targets
    where the count may differ (rescue seeds were needed) are also given to the general 6R solver of
    the true robot when there is one: its rows join the candidates.  ``family``: the rows that are
    representatives of a self-motion of the snapped robot.  Returns (TH, owner, continuum): the
    representatives of a self-motion among the rows are those the true robot leaves unresolved."""
    report = {}
    held, held_owner = np.asarray(TH), np.asarray(owner)  # the free joints' values, before rows change
    TH, owner = _ct.correct(TH, goals[owner], owner, twists0=robot.plan_twists, twists1=robot.twists,
                            home=robot.home, A=robot.A, b=robot.B, independent=robot.vary,
                            kinds=robot.vary_kinds, target=robot.solve_target, hold=robot.free,
                            scale=robot.scale, tol=robot.tol, plain=robot.polish, family=family,
                            report=report)
    # a corrected row on a numerical self-motion of the true robot (a relation the file misses by a
    # little, near a lock of the snapped wrist whose leaves were no family) is a representative too:
    # reachback.urdf perturbed by 1e-6 at q = (pi, 0, 0, pi/2, pi, pi/2), sigma 3e-9, its one row 2e-3
    # rad from the sampled vector came back as an isolated solution (docs/calibrated.md)
    cont = report["continuum"] | selfmotion.flags(robot, TH, goals[owner], exact_only=True)
    doubt = report["uncertain"]
    solver = general6() if len(doubt) else None
    if len(doubt) and solver is None and nearfamily.square(robot):
        # no complete solver of the true robot: walk the near-self-motions the doubtful rows lie on,
        # whose isolated zeros Newton reaches only from close by (rhino at q2 = pi; nearfamily.py)
        X, own_x = nearfamily.candidates(robot, TH, owner, goals, doubt)
        if len(X):
            TH, owner = np.concatenate([TH, X]), np.concatenate([owner, own_x])
            cont = np.concatenate([cont, selfmotion.flags(robot, X, goals[own_x])])
    if solver is not None:
        if robot.free_joints:  # folded at each target's free value, held in its rows (freefold.py)
            order = np.argsort(held_owner, kind="stable")
            first = np.searchsorted(held_owner[order], doubt)
            TH2, own2 = solver.rows(goals[doubt], held[order[first], solver.column])
        else:
            TH2, own2 = solver.rows(goals[doubt])  # a plain 6R chain: its rows are all joint values
        own2 = np.asarray(doubt)[own2]
        TH, owner = np.concatenate([TH, TH2]), np.concatenate([owner, own2])
        # the elimination's rows on a self-motion are its representatives, as on a general-6r plan
        cont = np.concatenate([cont, selfmotion.flags(robot, TH2, goals[own2])])
    return TH, owner, cont


def true_general6(robot):
    """The true robot's general 6-joint solver (subproblems.general6), or None when the robot is no
    plain 6-joint pose chain (nor a 7R one with one free joint: freefold.FoldedGeneral6), the
    elimination refuses it (adjacent prismatic joints 3 and 4) or the package has no general solver.

    Prismatic joints count: the calibrated Rhino (TRRRRR, 1e-4) lost 8 of 2,000 special poses on the
    walk along its near-self-motions (nearfamily.py) and loses none with its doubtful targets given to
    the elimination (benchmarks/results/near_family.md, session 13).

    Built here without the plan's arrangements: a snapped plan (the only caller) has none, and
    ``General6`` chooses them on fixed sample poses of the robot itself, so the order is the one the
    compiler would record (same twists, home and seed)."""
    try:
        from subproblems import general6
    except ImportError:
        return None
    if freefold.eligible(robot):  # a 7-joint arm with one free joint
        return freefold.FoldedGeneral6.from_robot(robot)
    if len(robot.kinds) != 6 or robot.solve_target != "pose" or robot.free_joints or robot.couplings:
        return None
    try:
        return general6.General6(robot.twists, robot.home, robot.scale)
    except general6.General6Error:
        return None


def general6_rows(robot, goals, init):
    """The general 6R elimination's exact rows of N targets: (TH (M, chain joints), owner (M,)).
    Free joints at the chain's ends move the target of the six solved joints (runtime.freeends); a free
    joint between solved ones folds their twists at its value (runtime.freefold; docs/design.md
    section 5, "General 6R")."""
    if not robot.free:
        return robot.general6.rows(goals)
    if isinstance(robot.general6, freefold.FoldedGeneral6):  # a free joint between solved ones
        return robot.general6.rows(goals, init[:, robot.general6.column])
    split = robot.free_ends
    Q, owner = robot.general6.rows(split.targets(goals, init))
    return split.rows(Q, init[owner]), owner


def candidates(robot, goals, Td, init, correct, alternative=None, leaves=None):
    """Candidate joint vectors of the reference runtime: (TH, owner, ls, continuum).

    ``alternative`` (N,) marks targets that take the plan's alternative chain whatever the chain
    gives (the fast chain saw a gimbal lock there that the reference step may not flag).  ``leaves``:
    a snapped plan's fast-chain leaves of these targets, ``(TH (N, L, n), usable (N, L), family
    (N, L))``, which join the steps' rows (see :func:`_with_leaves`)."""
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
        TH, owner = general6_rows(robot, goals, init)
        # isolated points of the elimination; those on a self-motion are flagged as its representatives
        return TH, owner, np.zeros(len(TH), dtype=bool), selfmotion.flags(robot, TH, goals[owner])
    if robot.search:
        step = {"search": list(robot.search), "grid": robot.grid, "steps": robot.steps, "home": robot.home,
                "scale": robot.scale, "target": robot.solve_target}
        TH, owner = _rt.run_search(step, robot.plan_twists, robot.kinds, Td, robot.couplings,
                                   robot.n_groups, init)
        TH, owner = twin_seeds(robot, robot.newton(TH, goals[owner], SEARCH_NEWTON), owner, goals)
        return TH, owner, *_no_flags(len(TH))
    # a snapped plan's steps keep their near-miss least-squares rows beside the exact ones: a complex
    # pair of the snapped robot near a fold is a real pair of the true one, which the continuation's
    # seeds find from them (talos_full_v2.urdf at 1e-3; subproblems._class2.near_miss_rows)
    with near_miss_rows() if robot.polish else contextlib.nullcontext():
        TH, owner, ls, _, cont = _rt.run_plan(robot.steps, robot.plan_twists, robot.kinds, Td,
                                              robot.couplings, robot.n_groups, init)
        if robot.alt_steps:
            TH, owner, ls, cont = with_alternative(robot, Td, init, TH, owner, ls, cont, alternative)
    if leaves is not None:
        TH, owner, ls, cont = _with_leaves(TH, owner, ls, cont, *leaves)
    if cont.any():
        # A self-motion: the representative a step chose may not complete the pose; Newton steps
        # on every joint pull it onto a nearby exact solution of the continuum.
        TH[cont] = robot.newton_until_exact(TH[cont], goals[owner[cont]], CONTINUUM_NEWTON)
    if robot.polish and len(TH):
        TH, owner, cont = correct(TH, owner, goals, cont)
        ls = np.concatenate([ls, np.zeros(len(TH) - len(ls), dtype=bool)])
    return TH, owner, ls, cont


# Offsets along the weakest direction (largest entry 1 in joint units) at which a polished search row
# near a singular configuration seeds its twin: two roots of one branch closer than a grid cell or two
# give one local minimum of the error along the grid, and near a singular configuration they lie along
# the Jacobian's null direction (modular RRRRT, seed 0: twins 0.1-0.2 rad apart at sigma 6e-4..2e-2;
# 2 of 40 random poses missed).  The C search does the same (fast_finish.h ikc_search), the
# Python one in runtime/fastchain.py and here.
TWIN_OFFSETS = (-0.6, -0.2, -0.05, 0.05, 0.2, 0.6)
TWIN_SINGULAR = 0.05  # weakest singular value (size-free Jacobian) below which a row seeds twins


def twin_seeds(robot, TH, owner, goals):
    """The search's polished rows (TH, owner) and, for those exact ones near a singular configuration,
    Newton-polished seeds along their weakest direction (TWIN_OFFSETS): candidates the finish checks
    and dedupes like every other."""
    if not len(TH):
        return TH, owner
    exact = robot.error(_rt.fk_batch(robot.twists, np.nan_to_num(TH), robot.home), goals[owner])
    rows = np.nonzero(np.isfinite(TH).all(axis=1) & (exact <= robot.tol * robot.scale))[0]
    if not len(rows):
        return TH, owner
    vary = list(robot.vary)
    sv, n = _ct.weakest(TH[rows][:, vary], robot.twists, A=robot.A, b=robot.B, home=robot.home,
                        kinds=robot.vary_kinds, target=robot.solve_target, hold=robot.free, scale=robot.scale)
    rows, n = rows[sv < TWIN_SINGULAR], n[sv < TWIN_SINGULAR]
    if not len(rows):
        return TH, owner
    Q = TH[rows][:, vary]
    X = np.concatenate([Q + t * n for t in TWIN_OFFSETS])
    own = np.tile(owner[rows], len(TWIN_OFFSETS))
    X = robot.newton(X @ robot.A.T + robot.B, goals[own], SEARCH_NEWTON)
    return np.concatenate([TH, X]), np.concatenate([owner, own])

def with_alternative(robot, Td, init, TH, owner, ls, cont, alternative=None):
    """The chain's candidates (TH, owner, ls, cont) with the alternative chain's on the targets where
    the chain met a continuum (or ``alternative`` marks them).  A target where the alternative chain
    meets none is no self-motion: a closed-form chain is complete wherever no step degenerates, so its
    rows are every solution and replace the chain's representatives (a 5-joint arm's O-RRR gimbal:
    the family's waist value is fixed by the position equations, which the representative ignores;
    docs/design.md section 5, "Alternative chain").  Elsewhere both chains' rows are candidates."""
    redo = np.zeros(len(Td), dtype=bool)
    redo[owner[cont]] = True
    if alternative is not None:
        redo |= alternative
    redo = np.nonzero(redo)[0]
    if not len(redo):
        return TH, owner, ls, cont
    TH2, own2, ls2, _, cont2 = _rt.run_plan(robot.alt_steps, robot.plan_twists, robot.kinds, Td[redo],
                                            robot.couplings, robot.n_groups, init[redo])
    own2 = redo[own2]
    settled = np.zeros(len(Td), dtype=bool)
    settled[own2] = True
    settled[own2[cont2]] = False
    keep = ~settled[owner]
    return (np.concatenate([TH[keep], TH2]), np.concatenate([owner[keep], own2]),
            np.concatenate([ls[keep], ls2]), np.concatenate([cont[keep], cont2]))


def _with_leaves(TH, owner, ls, cont, leaf_TH, usable, family):
    """The steps' candidates joined by a snapped plan's fast-chain leaves (every joint's value, the
    family ones flagged as representatives).

    A chain with fewer joints than its target has DOF (a 5-joint arm for a pose) solves a subset of the
    equations, and the snapped robot reaches almost no target of the true one: a step with more
    equations than unknowns (S2-RR on parallel axes: a point at the wrong height) gives the reference
    step one least-squares row, the nearest of its branches, where the fast kernels, which solve the
    consistent part, give every branch.  The dropped branch held the sampled solution
    (hextilt_flying_arm_5 of example-robot-data at q4 = pi/2, a gimbal lock of its O-RRR: the
    other elbow's rows alone came back; docs/calibrated.md)."""
    rows, leaf = np.nonzero(usable)
    return (np.concatenate([TH, leaf_TH[rows, leaf]]), np.concatenate([owner, rows]),
            np.concatenate([ls, np.zeros(len(rows), dtype=bool)]),
            np.concatenate([cont, family[rows, leaf]]))


def _no_flags(n):
    return np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)


def complete(robot, TH, owner, ls, cont, goals, limits):
    """Check candidates on the true robot (a few Newton steps for near misses), wrap, pack slots."""
    moved = False  # rows Newton placed with a value clamped onto its limit (clamped_onto_limits)
    if len(TH):
        scale, exact = robot.scale, robot.tol * robot.scale
        # Tangent geometry (a double root) costs about half the digits; a few Newton steps restore them.
        err = robot.error(_rt.fk_batch(robot.twists, np.nan_to_num(TH), robot.home), goals[owner])
        # At a double root Newton converges only linearly (the residual falls about 4x a step): rows
        # still above the precision get more steps, in rounds of 3, up to 15 in all.
        near = (err > exact) & (err < NEAR_MISS * scale)
        TH = robot.newton_until_exact(TH, goals[owner], 15, FINISH_MARGIN, rows=near, per_round=3)
        TH, owner, ls, cont = resolved_families(robot, TH, owner, ls, cont, goals)
        # a step's ls flag on a representative says only that its last angle 0 missed; Newton may have
        # pulled it onto the family since (onto_self_motion moves only rows that miss or lie outside)
        TH = onto_self_motion(robot, TH, owner, cont, goals, limits)
        if limits:
            TH, clamped = clamped_onto_limits(robot, TH, owner, goals)
            moved = moved or clamped
    # Rows Newton carried to where they are (a search's, a snapped plan's: the Python snapped route
    # merges them within SPLIT_ROOT too) and representatives onto_self_motion moved along their family
    # stop where their starts lead: two copies of one solution may land ~1e-8 apart (pybullet's panda
    # at q4 = 0: two rows 8e-9 apart; pr2 perturbed by 1e-6: 7e-9).  docs/design.md section 11.
    moved = moved or robot.search or robot.method == "numerical" or robot.polish
    dedupe = _fk.SPLIT_ROOT if moved else None
    parts = _rt.finish(TH, owner, ls, len(goals), twists=robot.twists, kinds=robot.kinds, home=robot.home,
                       independent=robot.independent, targets=goals, scale=robot.scale, tol=robot.tol,
                       slots=robot.slots, error=robot.error, cont=cont,
                       limits=(robot.lower, robot.upper) if limits else None, A=robot.A, b=robot.B,
                       vary=robot.vary, dedupe=dedupe, family_dedupe=_fk.SPLIT_ROOT)
    return without_stalled_copies(robot, parts, goals) if moved else parts


def without_stalled_copies(robot, parts, goals):
    """Finished rows (Q, valid, ls, res, cont) without the exact rows that are a stalled copy of an
    earlier exact row of their target: one undamped pseudo-inverse step from the row
    (``tolerances.SINGULAR_CUTOFF``) lands within ``SPLIT_ROOT`` of it.  The damped steps move a row
    only ~5e-8 a step along a direction whose singular value is ~1e-7, so a copy of one root stops
    where its residual first passes the precision, up to its tolerance over that singular value from
    the root (tiago_dual's right arm perturbed by 1e-6 at a wrist lock: two exact rows 1.1e-6 apart,
    residuals 1.7e-16 and 3.1e-13; the step from the second lands 6.9e-10 from the first).  Only the
    pairs within STALLED_PAIR are tried; no kept row changes."""
    Q, valid, ls, res, cont = (np.array(x) for x in parts)
    exact = valid & ~ls
    N, S, _ = Q.shape
    kinds = [robot.kinds[i] for i in robot.independent]
    pairs = []  # (target, earlier slot, later slot)
    for j in range(1, S):
        near = exact[:, :j] & exact[:, j:j + 1]
        dist = np.zeros(near.shape)
        for k, kind in enumerate(kinds):
            dist = np.maximum(dist, _fk.angle_distance(Q[:, :j, k] - Q[:, j:j + 1, k], kind == "R"))
        near &= (dist > _fk.SPLIT_ROOT) & (dist <= STALLED_PAIR)
        pairs += [(n, i, j) for n, i in zip(*np.nonzero(near))]
    if not pairs:
        return parts
    n, i, j = (np.array(x) for x in zip(*pairs))
    dof = Q.shape[2]  # the rows' joints; virtual joints (the rest of vary) at 0, as Robot.fk
    rows = np.concatenate([Q[n, j], np.zeros((len(n), len(robot.vary) - dof))], axis=1)
    stepped = _rt.polish(rows @ robot.A.T + robot.B, goals[n], twists=robot.twists, home=robot.home,
                         A=robot.A, b=robot.B, independent=robot.vary, target=robot.solve_target, iters=1,
                         hold=robot.free, cutoff=_tol.SINGULAR_CUTOFF)[:, list(robot.vary)[:dof]]
    dist = np.zeros(len(n))
    for k, kind in enumerate(kinds):
        dist = np.maximum(dist, _fk.angle_distance(stepped[:, k] - Q[n, i, k], kind == "R"))
    copy = dist <= _fk.SPLIT_ROOT
    if not copy.any():
        return parts
    valid[n[copy], j[copy]] = False
    order = np.argsort(~valid, axis=1, kind="stable")
    out = [np.take_along_axis(Q, order[..., None], axis=1)]
    out += [np.take_along_axis(x, order, axis=1) for x in (valid, ls, res, cont)]
    out[3] = np.where(out[1], out[3], np.inf)
    return tuple(out)


def resolved_families(robot, TH, owner, ls, cont, goals):
    """Representatives of a step's continuum (rows ``cont``) that are exact at a full-rank Jacobian
    of the true robot: the other equations fix the family's parameter, so the row is one isolated
    solution of a few on that family, not a self-motion.  Its flag is cleared and the family is swept
    (:func:`_along_family`: its most moving joint held across its range, Newton on the others); every
    exact end point joins the candidates (the finish dedupes them).  Modular TRRRT (seed 0) at
    q = (q1, pi, pi, 0, q5): the O-RRR gimbal leaves q2 - q4 fixed, the position picks two points of
    that family, the chain's representative was one of them and the pose came back with one row
    flagged a self-motion at sigma_min 0.05 (docs/design.md section 5, "Alternative chain")."""
    if not cont.any():
        return TH, owner, ls, cont
    exact = robot.tol * robot.scale
    err = robot.error(_rt.fk_batch(robot.twists, np.nan_to_num(TH), robot.home), goals[owner])
    resolved = cont & (err <= exact)  # a step's ls flag is stale once Newton made the row exact
    resolved[resolved] = selfmotion.full_rank(robot, TH[resolved])
    rows = np.nonzero(resolved)[0]
    if not len(rows):
        return TH, owner, ls, cont
    Q = TH[rows][:, list(robot.vary)]
    _, n = _ct.weakest(Q, robot.twists, A=robot.A, b=robot.B, home=robot.home, kinds=robot.vary_kinds,
                       target=robot.solve_target, hold=robot.free, scale=robot.scale)
    X = _along_family(robot, Q, n, goals[owner[rows]])
    k = X.shape[1]
    X = X.reshape(len(rows) * k, -1)
    own = np.repeat(owner[rows], k)
    X = robot.newton_until_exact(X, goals[own], 15, FINISH_MARGIN, per_round=3)
    keep = robot.error(_rt.fk_batch(robot.twists, np.nan_to_num(X), robot.home), goals[own]) <= exact
    keep[keep] = selfmotion.full_rank(robot, X[keep])  # isolated points only (no self-motion's samples)
    cont = cont & ~resolved
    none = np.zeros(int(keep.sum()), dtype=bool)
    return (np.concatenate([TH, X[keep]]), np.concatenate([owner, own[keep]]), np.concatenate([ls, none]),
            np.concatenate([cont, none]))


def onto_self_motion(robot, TH, owner, cont, goals, limits):
    """Representatives of a self-motion (rows ``cont``) that miss the precision or lie outside the
    limits, moved along their family: Newton steps from points at SELF_MOTION_OFFSETS along the
    Jacobian's weakest direction; the exact point (inside the limits) of least error replaces the row.
    A step's representative (its last angle 0) may lie outside the limits, and on a numerical
    self-motion far from the arc that is exact, while the family has exact points inside them."""
    ind = list(robot.independent)
    ok = ~np.isnan(TH).any(axis=1)
    exact = robot.tol * robot.scale
    bad = np.zeros(len(TH), dtype=bool)
    look = np.nonzero(cont & ok)[0]
    if not len(look):
        return TH
    bad[look] = ~(robot.error(_rt.fk_batch(robot.twists, TH[look], robot.home), goals[owner[look]]) <= exact)
    if limits:
        bad |= ~_rt.within_limits(np.nan_to_num(TH[:, ind]), robot.joint_types, robot.lower, robot.upper)
    rows = np.nonzero(cont & ok & bad)[0]
    if not len(rows):
        return TH
    vary = list(robot.vary)
    Q = TH[rows][:, vary]
    _, n = _ct.weakest(Q, robot.twists, A=robot.A, b=robot.B, home=robot.home, kinds=robot.vary_kinds,
                       target=robot.solve_target, hold=robot.free, scale=robot.scale)
    k = len(SELF_MOTION_OFFSETS)
    X = (Q[:, None, :] + SELF_MOTION_OFFSETS[None, :, None] * n[:, None, :]).reshape(-1, len(vary))
    g = goals[np.repeat(owner[rows], k)]
    X = robot.newton(X @ robot.A.T + robot.B, g, SELF_MOTION_NEWTON)
    # The straight line leaves a curved family within a few steps: also the family's points at the
    # joint that moves most along it held at values across its range, the others by Newton steps
    # (modular RRTRR at q4 = 0, a planar 3R with a slide: the representative's slide outside its
    # limits, no offset along the line reached an exact point inside them; 2 of 8 special poses)
    X = np.concatenate([X.reshape(len(rows), k, -1), _along_family(robot, Q, n, goals[owner[rows]])], axis=1)
    k = X.shape[1]
    X = X.reshape(len(rows) * k, -1)
    g = goals[np.repeat(owner[rows], k)]
    e = robot.error(_rt.fk_batch(robot.twists, X, robot.home), g)
    good = e <= exact
    if limits:
        good &= _rt.within_limits(X[:, ind], robot.joint_types, robot.lower, robot.upper)
    good = good.reshape(len(rows), k)
    if not good.any():
        return TH
    best = np.argmin(np.where(good, e.reshape(len(rows), k), np.inf), axis=1)  # the deepest point
    moved = good.any(axis=1)
    TH = TH.copy()
    TH[rows[moved]] = X.reshape(len(rows), k, -1)[moved, best[moved]]
    return TH


def _along_family(robot, Q, n, goals):
    """Points of each row's self-motion (rows Q (M, vary), weakest directions n): the joint with the
    largest entry of n held at len(SELF_MOTION_OFFSETS) values across its range (a revolute joint the
    circle, a slide its limits, or +- the size), the others moved onto the target by Newton steps, then
    SELF_MOTION_NEWTON free steps.  (M, len(SELF_MOTION_OFFSETS), n) rows of every joint."""
    k = len(SELF_MOTION_OFFSETS)
    held = np.argmax(np.abs(n), axis=1)
    X = np.repeat(Q[:, None, :], k, axis=1)
    for j in np.unique(held):
        sel = np.nonzero(held == j)[0]
        if robot.vary_kinds[j] == "R":
            values = SELF_MOTION_OFFSETS
        else:
            lo, hi = robot.vary_lower[j], robot.vary_upper[j]
            lo, hi = (lo if np.isfinite(lo) else -robot.scale), (hi if np.isfinite(hi) else robot.scale)
            values = np.linspace(lo, hi, k)
        X[sel, :, j] = values
        Y = X[sel].reshape(-1, Q.shape[1]) @ robot.A.T + robot.B
        g = np.repeat(goals[sel], k, axis=0)
        Y = robot.newton(Y, g, 2 * SELF_MOTION_NEWTON, hold=tuple(sorted(set(robot.free) | {int(j)})))
        Y = robot.newton(Y, g, SELF_MOTION_NEWTON)
        X[sel] = Y[:, list(robot.vary)].reshape(len(sel), k, -1)
    return (X.reshape(-1, Q.shape[1]) @ robot.A.T + robot.B).reshape(len(Q), k, -1)


def clamped_onto_limits(robot, TH, owner, goals):
    """Rows with a value just outside a limit (a double root at a limit is located to sqrt(eps) only):
    the value clamped onto the limit, then Newton steps on the other joints (the clamped and free ones
    held), so that the row as returned is exact or flagged, never outside its limits.  Returns the rows
    and whether any was clamped (Newton placed it: the finish then merges rows within SPLIT_ROOT, as the
    C finish does; the Alexander leg at its straight knee, a clamped row 9.9e-7 from an exact one)."""
    ind = list(robot.independent)
    ok = ~np.isnan(TH).any(axis=1)
    Qr, _, out, clamped = _fk.represent(np.nan_to_num(TH[:, ind]), robot.joint_types, robot.lower,
                                        robot.upper, True, clamps=True)
    rows = ok & ~out & clamped.any(axis=1)
    if not rows.any():
        return TH, False
    TH = TH.copy()
    TH[np.ix_(rows, ind)] = Qr[rows]
    TH[rows] = TH[rows][:, list(robot.vary)] @ robot.A.T + robot.B
    for pattern in np.unique(clamped[rows], axis=0):
        sel = np.nonzero(rows & (clamped == pattern).all(axis=1))[0]
        hold = tuple(robot.free) + tuple(int(j) for j in np.nonzero(pattern)[0])
        # at a singular configuration the damped steps stall above the precision: singular_newton's
        # steps after them (pybullet's xarm6 at q5 = pi, its limit pi + 2e-13; docs/design.md section 10)
        TH[sel] = robot.newton_until_exact(TH[sel], goals[owner[sel]], CLAMPED_NEWTON, FINISH_MARGIN,
                                           rows=np.ones(len(sel), dtype=bool), per_round=CLAMPED_NEWTON,
                                           hold=hold)
    return TH, True
