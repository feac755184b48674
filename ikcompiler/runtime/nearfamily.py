"""The isolated solutions along a near-self-motion of a snapped robot (docs/calibrated.md, "How a
solution is carried over", item 10; docs/design.md section 5, "Snapping").

Where the snapped robot has a self-motion (rhino at q2 = 0 or pi: the slide q1 lies in the plane of
the parallel axes q3, q4, q5, which then reach a point of that plane along a one-parameter family),
the true robot, whose relations hold only to ~1e-4, has isolated solutions along the former family:
the target is met where the one equation the family breaks, g(s), crosses zero.  Each is resolved
(the Jacobian's weakest singular value is about |g'(s)|, 2e-5 on rhino at 1e-4), but Newton reaches
one only from within about that distance: further out, a step along the weak direction is
|g| / sigma long and leaves the curved family.  The snapped closed form gives no start near them (its
H-T step divides by sin q2 ~ 3e-4 and its leaves miss by 50-1700 mm), and the rescue seeds along the
straight weakest direction leave the family within a few tenths of a radian.

So the family is walked (:func:`candidates`): from a row on it (exact, or missing by no more than the
change in geometry makes it miss; the continuation's rows and the snapped plan's other branches near
them, :func:`branch_rows`) in both directions along its weakest direction, steps of ``STEP`` in the
joint that moves most, each predicted along the secant of the last two points and corrected by Newton
steps with that joint held (a least-squares point of the other joints, well conditioned).  The error
along the walk is |g(s)|; each local minimum within the bound seeds free Newton steps on every joint,
and the seeds that end exact and resolved are candidates like any other (the finish checks and
dedupes them).  Measured on rhino perturbed by 1e-4 (seed 3) at q = (-278.6, pi, -0.21, 2.62, 0.81,
0): 6 distinct solutions, of which the continuation and the rescue seeds had found 3 (not the sampled
one); on 2000 special-angle poses 1933 -> 1986 recovered (benchmarks/near_family.py).
"""

from __future__ import annotations

import numpy as np

from subproblems import continuation as _ct
from subproblems import plan_runtime as _rt
from subproblems._class2 import near_miss_rows

STEP = 0.1  # rad (revolute) or of the size (prismatic) in the joint that moves most, per step
STEPS = 32  # steps each way: about pi of the joint that moves most along the family
HELD_NEWTON = 2  # Newton steps with that joint held, from the secant's prediction (error ~ STEP^2)
FREE_NEWTON = 15  # Newton steps (then Robot.singular_newton's) on every joint from a local minimum
STARTS = 8  # start rows a target at most, least error first
SAME_START = 0.5  # start rows closer than this (joint distance) walk the same stretch of family
GRID = 32  # values of a single-joint step's joint at which the other steps seed the family's loops


def square(robot) -> bool:
    """Whether the moving joints are as many as the equations they solve (a self-motion is then the
    only way the solutions form a curve; a chain with fewer joints misses every target by a little)."""
    rows = {"position": 3, "orientation": 3}.get(robot.solve_target, 6)
    return len(robot.vary) - len(robot.free) == rows


def candidates(robot, TH, owner, goals, doubt):
    """Exact, resolved rows (every joint) and their owners along the near-self-motions of the targets
    in ``doubt`` (the continuation's rows TH of targets ``owner``): start rows among TH, the snapped
    plan's branches near them (:func:`branch_rows`), the walk from both (:func:`walk`).  The bound on
    a start's error and weakest singular value is the continuation's ``near_singular``."""
    bound = _ct.near_singular(robot.plan_twists, robot.twists, robot.scale)
    start = starts(robot, TH, owner, goals, doubt, bound)
    if not len(start):
        return np.zeros((0, TH.shape[1])), np.zeros(0, dtype=int)
    B, own_b = branch_rows(robot, TH[start], owner[start], goals)
    pool, pool_owner = np.concatenate([TH[start], B]), np.concatenate([owner[start], own_b])
    start = starts(robot, pool, pool_owner, goals, doubt, bound)
    X, at = walk(robot, pool[start], goals[pool_owner[start]], bound)
    return X, pool_owner[start][at]


def starts(robot, TH, owner, goals, doubt, bound):
    """Rows of TH (every joint) to walk from: on a target in ``doubt``, finite, their weakest singular
    value below ``bound`` and their error at most ``bound`` of the size; at most ``STARTS`` a target,
    least error first, none within ``SAME_START`` of another.  Returns their indices."""
    look = np.nonzero(np.isin(owner, doubt) & np.isfinite(TH).all(axis=1))[0]
    if not len(look):
        return look
    err = robot.error(_rt.fk_batch(robot.twists, TH[look], robot.home), goals[owner[look]])
    sv, _ = _weakest(robot, TH[look])
    near = (err <= bound * robot.scale) & (sv < bound)
    look, err = look[near], err[near]
    picked: list[int] = []
    per_target: dict[int, list[int]] = {}
    unit = _unit(robot)
    vary = list(robot.vary)
    for i in look[np.lexsort((err, owner[look]))]:
        mine = per_target.setdefault(int(owner[i]), [])
        if len(mine) >= STARTS:
            continue
        q = TH[i, vary]
        if any(_distance(q, TH[k, vary], robot, unit) <= SAME_START for k in mine):
            continue
        mine.append(int(i))
        picked.append(int(i))
    return np.array(sorted(picked), dtype=int)


def branch_rows(robot, TH, owner, goals):
    """The snapped plan's rows near rows TH (every joint) of targets ``owner``: for every step that
    solves one joint (H-T, H-R, ...), the other steps run with that joint at each row's value and, once
    a target, at ``GRID`` values across its range (revolute: the circle; prismatic: its limits, else
    +- the size).  Returns (TH', owner').

    At a near-self-motion that step is the one the snapped robot nearly cannot solve (rhino's H-T: the
    slide nearly in the plane of q3, q4; its root C / A with A ~ sin q2 ~ 3e-4 is meaningless), so its
    joint is the family's parameter, and the other steps' branches across its range (both elbows of
    S2-RR, kept as near misses: they miss the snapped target by about the change in geometry) lie on
    every loop of the family.  Rhino at q2 = pi: the wrist point's line crosses the annulus the arm
    q3, q4 reaches in two intervals of q1, two loops; no row of the continuation was on the sampled
    vector's one, and no walk leaves its loop."""
    known = [robot.independent[p] for p in robot.free]
    _, first = np.unique(owner, return_index=True)
    out, own = [np.zeros((0, TH.shape[1]))], [np.zeros(0, dtype=int)]
    for step in robot.steps:
        if step["kind"] == "SUM" or len(step.get("solve", ())) != 1:
            continue
        j = step["solve"][0]
        values = _grid(robot, j)
        grid = np.repeat(TH[first], len(values), axis=0)  # the targets' free values, j on the grid
        grid[:, j] = np.tile(values, len(first))
        init = np.full((len(TH) + len(grid), TH.shape[1]), np.nan)
        init[:, known + [j]] = np.concatenate([TH, grid])[:, known + [j]]
        targets = np.concatenate([owner, np.repeat(owner[first], len(values))])
        rest = [s for s in robot.steps if s is not step]
        with near_miss_rows():  # the other elbow misses the snapped target by ~the change in geometry
            X, o, _, _, _ = _rt.run_plan(rest, robot.plan_twists, robot.kinds, _td(robot, goals[targets]),
                                         robot.couplings, robot.n_groups, init)
        ok = np.isfinite(X).all(axis=1)
        out.append(X[ok])
        own.append(targets[o[ok]])
    return np.concatenate(out), np.concatenate(own)


def _td(robot, goals):
    """The chain's targets g_d g_st(0)^-1 of goals (runtime/targets.py check_targets)."""
    if robot.target == "position":
        Td = goals.copy()
        Td[:, :3, 3] = goals[:, :3, 3] - robot.home[:3, 3]
        return Td
    return goals @ robot.home_inv


def _grid(robot, j):
    """``GRID`` values of chain joint j across its range (independent joints only; else none)."""
    if j not in robot.vary:
        return np.zeros(0)
    pos = list(robot.vary).index(j)
    if robot.vary_kinds[pos] == "R":
        return np.linspace(-np.pi, np.pi, GRID, endpoint=False)
    lo, hi = robot.vary_lower[pos], robot.vary_upper[pos]
    lo, hi = (lo if np.isfinite(lo) else -robot.scale), (hi if np.isfinite(hi) else robot.scale)
    return np.linspace(lo, hi, GRID)


def walk(robot, TH, goals, bound):
    """Candidate rows (every joint) and their goal indices: the zeros of the broken equation along the
    near-self-motion through each row TH[m] (module docstring), exact and resolved."""
    if not len(TH):
        return TH, np.zeros(0, dtype=int)
    vary = list(robot.vary)
    unit = _unit(robot)
    Q0 = TH[:, vary]
    _, n = _weakest(robot, TH)
    M = len(Q0)
    # both directions as rows of their own: (2M, vary), the first secant along +-n
    cur = np.concatenate([Q0, Q0])
    prev = cur - STEP * np.concatenate([n, -n])
    goal = np.concatenate([goals, goals])
    path = [cur]
    errs = [robot.error(_rt.fk_batch(robot.twists, _full(robot, cur), robot.home), goal)]
    live = np.ones(2 * M, dtype=bool)
    for _ in range(STEPS):
        s = (cur - prev) / unit
        held = np.argmax(np.abs(s), axis=1)
        big = np.abs(s[np.arange(len(s)), held])
        d = s / np.where(big > 0.0, big, 1.0)[:, None]
        nxt = cur + STEP * d * unit
        for j in np.unique(held[live]):
            sel = np.nonzero(live & (held == j))[0]
            hold = tuple(sorted(set(robot.free) | {int(j)}))
            nxt[sel] = robot.newton(_full(robot, nxt[sel]), goal[sel], HELD_NEWTON, hold=hold)[:, vary]
        e = robot.error(_rt.fk_batch(robot.twists, _full(robot, np.nan_to_num(nxt)), robot.home), goal)
        e = np.where(live & np.isfinite(nxt).all(axis=1), e, np.inf)
        live &= e <= bound * robot.scale  # off the family (or through a turning point): this way ends
        prev, cur = cur, np.where(live[:, None], nxt, cur)
        path.append(cur)
        errs.append(e)
        if not live.any():
            break
    P, E = np.stack(path, axis=1), np.stack(errs, axis=1)  # (2M, k)
    # one path a row: the backward half reversed, then the forward half (its start once)
    P = np.concatenate([P[M:, :0:-1], P[:M]], axis=1)
    E = np.concatenate([E[M:, :0:-1], E[:M]], axis=1)
    lower = np.concatenate([np.full((M, 1), np.inf), E[:, :-1]], axis=1)
    upper = np.concatenate([E[:, 1:], np.full((M, 1), np.inf)], axis=1)
    rows, at = np.nonzero(np.isfinite(E) & (E <= bound * robot.scale) & (E < lower) & (E <= upper))
    if not len(rows):
        return np.zeros((0, TH.shape[1])), np.zeros(0, dtype=int)
    X = robot.newton_until_exact(_full(robot, P[rows, at]), goals[rows], FREE_NEWTON)
    err = robot.error(_rt.fk_batch(robot.twists, np.nan_to_num(X), robot.home), goals[rows])
    keep = np.isfinite(X).all(axis=1) & (err <= robot.tol * robot.scale)
    if keep.any():  # an unresolved row is one arbitrary point of a numerical self-motion (RESOLVED)
        sv, _ = _weakest(robot, X[keep])
        keep[np.nonzero(keep)[0][~(sv >= _ct.RESOLVED)]] = False
    return X[keep], rows[keep]


def _weakest(robot, TH):
    return _ct.weakest(TH[:, list(robot.vary)], robot.twists, A=robot.A, b=robot.B, home=robot.home,
                       kinds=robot.vary_kinds, target=robot.solve_target, hold=robot.free, scale=robot.scale)


def _unit(robot):
    return np.where(np.array([k == "R" for k in robot.vary_kinds]), 1.0, robot.scale)


def _full(robot, Q):
    return Q @ robot.A.T + robot.B


def _distance(a, b, robot, unit):
    d = np.abs(a - b) / unit
    rev = np.array([k == "R" for k in robot.vary_kinds])
    d = np.where(rev, np.abs(np.remainder(d + np.pi, 2 * np.pi) - np.pi), d)
    return float(d.max())
