"""Validation of targets and free-joint values (docs/design.md section 6; docs/finish.md).

A wrong shape raises for the whole call; a target that is not a finite rigid transform gets a reason
(a batch leaves its slots empty, a single pose raises the module's ``InvalidTargetError``).
"""

from __future__ import annotations

import numpy as np

from subproblems import tolerances as _tol

NOT_ROTATION = "rotation is not a rotation matrix (R^T R != I or det != 1)"
RIGID = _tol.TARGET_RIGID  # orthonormal to this: projected onto the nearest rotation; worse: invalid
EXACT_ROTATION = _tol.TARGET_EXACT_ROTATION  # no projection needed below this defect
BOTTOM_ROW = _tol.TARGET_BOTTOM_ROW


def _goals(robot, Ts) -> np.ndarray:
    """Targets of the robot's target kind as (N, 4, 4) goals; a wrong shape raises."""
    err = robot.target_error
    if robot.target == "orientation":
        if Ts.ndim < 2 or Ts.shape[-2:] != (3, 3):
            raise err(f"an orientation target is a 3x3 rotation or (N, 3, 3); got shape {Ts.shape}")
        R = Ts.reshape(-1, 3, 3)
        goals = np.broadcast_to(np.eye(4), (len(R), 4, 4)).copy()
        goals[:, :3, :3] = R
    elif robot.target == "position":
        if Ts.ndim < 1 or Ts.shape[-1:] != (3,):
            raise err(f"a position target is (3,) or (N, 3); got shape {Ts.shape}")
        P = Ts.reshape(-1, 3)
        goals = np.broadcast_to(np.eye(4), (len(P), 4, 4)).copy()
        goals[:, :3, 3] = P
    else:
        if Ts.ndim < 2 or Ts.shape[-2:] != (4, 4):
            raise err(f"a pose target is a 4x4 transform or (N, 4, 4); got shape {Ts.shape}")
        goals = Ts.reshape(-1, 4, 4).copy()
    return goals


def check_targets(robot, Ts):
    """Validate targets one by one: (goals (N, 4, 4), Td (N, 4, 4), reasons (N,)), Td = g_d g_st(0)^-1.

    ``reasons[i]`` is "" for a valid target, else why it is not one (its goal is replaced by the
    identity).  A rotation orthonormal to 1e-6 but not to 1e-14 is projected onto the nearest rotation
    (Newton-Schulz steps): the precision contract is measured against that projection.
    """
    goals = _goals(robot, np.asarray(Ts, dtype=float))
    reasons = np.full(len(goals), "", dtype=object)
    finite = np.isfinite(goals).all(axis=(1, 2))
    reasons[~finite] = "contains NaN or infinity"
    if robot.target in ("pose", "position+direction"):
        bottom = np.abs(goals[:, 3] - [0.0, 0.0, 0.0, 1.0]).max(axis=1) > BOTTOM_ROW
        reasons[finite & bottom] = "bottom row is not [0, 0, 0, 1]"
    if robot.target != "position":
        R = np.where(finite[:, None, None], goals[:, :3, :3], np.eye(3))
        defect = np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max(axis=(1, 2))
        skew = (defect > RIGID) | (np.abs(np.linalg.det(R) - 1) > RIGID)
        reasons[(reasons == "") & skew] = NOT_ROTATION
        fix = (reasons == "") & (defect > EXACT_ROTATION)
        if fix.any():
            X = R[fix]
            for _ in range(3):  # X (3 I - X^T X) / 2: quadratic convergence from a 1e-6 defect
                X = X @ (3 * np.eye(3) - np.swapaxes(X, 1, 2) @ X) / 2
            goals[np.nonzero(fix)[0], :3, :3] = X
    goals[reasons != ""] = np.eye(4)
    if robot.target == "position":
        Td = goals.copy()
        Td[:, :3, 3] = goals[:, :3, 3] - robot.home[:3, 3]
    else:
        Td = goals @ robot.home_inv
    return goals, Td, reasons


def valid_targets(robot, Ts):
    """Validated targets (goals, Td) as :func:`check_targets`; the first invalid one raises."""
    goals, Td, reasons = check_targets(robot, Ts)
    bad = np.nonzero(reasons != "")[0]
    if len(bad):
        where = "target" if len(goals) == 1 else f"target {bad[0]} of {len(goals)} (see invalid_reasons())"
        raise robot.target_error(f"{where} {reasons[bad[0]]}")
    return goals, Td


def invalid_reasons(robot, Ts) -> dict:
    """{index: reason} of the targets that are not valid."""
    reasons = check_targets(robot, Ts)[2]
    return {int(i): str(reasons[i]) for i in np.nonzero(reasons != "")[0]}


def initial_values(robot, N: int, free) -> np.ndarray:
    """(N, chain joints) NaN except the free joints' given values; a wrong count or NaN raises."""
    if len(free) != len(robot.free_joints):
        raise robot.free_error(
            f"expected {len(robot.free_joints)} free joint values {robot.free_joints}, got {len(free)}")
    init = np.full((N, len(robot.kinds)), np.nan)
    for pos, value in zip(robot.free, free):
        v = np.broadcast_to(np.asarray(value, dtype=float), (N,))
        if not np.all(np.isfinite(v)):
            raise robot.free_error(
                f"free joint {robot.joint_names[pos]!r}: value NaN or infinite; give a finite value")
        init[:, robot.independent[pos]] = v
    return init


def free_columns(robot, init) -> np.ndarray:
    """The free joints' values of ``init`` as (N, n_free) columns (the C chain's input)."""
    return init[:, [robot.independent[pos] for pos in robot.free]]


def without_invalid(parts, reasons):
    """Empty the slots of the invalid targets (reasons != "")."""
    bad = np.asarray(reasons != "", dtype=bool)
    if not bad.any():
        return parts
    Q, valid, ls, res, cont = (np.array(x) for x in parts)
    Q[bad], valid[bad], ls[bad], res[bad], cont[bad] = 0.0, False, False, np.inf, False
    return Q, valid, ls, res, cont
