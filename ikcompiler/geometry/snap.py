"""Snap near-relations so that the closed form applies: the "ideal" robot of a calibrated one.

A calibrated URDF misses its design structure by a little (axes parallel to 1e-4 rad, wrist axes that
miss one another by 1e-4 of the robot's size).  The compiler builds its chain of subproblems on the
*snapped* robot, where those relations hold exactly, and every solution is then corrected by Newton
steps on the true robot and checked there (docs/design.md section 5).  Snapping only ever moves a relation
that already holds to ``Tolerance.snap``; exact relations and clear non-relations are left alone.

Rules, in chain order:

* directions: a revolute axis (or prismatic direction) within ``snap`` of a parallel to an earlier
  revolute axis takes that axis's direction (sign kept);
* points: each maximal run of three or more consecutive revolute axes that nearly meet in one point is
  moved to pass exactly through their least-squares common point (each axis keeps its direction and
  moves perpendicularly to it); two runs may share an axis (an elbow and a wrist point on one forearm
  axis): the later run's point is then taken on the shared axis, which stays put; then each other
  consecutive pair that nearly meets has one axis (not in such a run) shifted parallel to itself
  through the other axis's nearest point.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ikcompiler.geometry.relations import Tolerance, lines_meet, parallel_miss, twist_line
from ikcompiler.model import Chain, Joint
from subproblems import tolerances
from subproblems.screw import prismatic_twist, revolute_twist

ROUNDS = 4  # snapping rounds at most (each round only moves relations within the snap tolerance)
# A chain with fewer unknowns than its target has DOF snaps a run of concurrent axes up to this many
# times the snap tolerance (see snap_chain).
REDUCED_RUN_FACTOR = 2.0


def snap_chain(
    chain: Chain, tol: Tolerance | None = None, run_factor: float = 1.0
) -> tuple[Chain, list[str]]:
    """The snapped chain and one note per relation that was snapped (empty when nothing moved).

    ``run_factor``: a run of three or more concurrent axes is snapped when they miss their common point
    by at most this times ``tol.snap``.  The compiler passes :data:`REDUCED_RUN_FACTOR` for a chain with
    fewer unknowns than its target has DOF: such a chain's snapped leaves never reach the target (the
    true robot's reachable set is another one), so they are carried over by plain Newton and must lie
    close to the true solutions, and no general solver takes the robot beyond the tolerance.  Measured
    on example-robot-data's human torso (middle_pelvis -> middle_thorax, 5 joints) perturbed by 1e-3
    (seed 7): its thoracic triple misses one point by 1.44e-3 (its pairs by 3.7e-5 .. 1.3e-3, the
    lumbar pair by 4.7e-4), so only pairs were snapped and the plan became an S2-RRR on a near-spherical
    triple, unreachable on the snapped robot: 210 of 230 poses recovered; with the run snapped, 230.
    Chains with a general solver (6R pose chains) keep 1: beyond the tolerance they are general
    robots (docs/calibrated.md, "Policy").

    Snapping is repeated on its own result until nothing moves: a snap can create a near-relation the
    first round did not see.  Measured on kuka_kr16_2 (rtb-data) perturbed by 1e-3 (seed 7): its
    wrist axes 4, 5, 6 miss a common point by 1.4e-3 (no run), the pairs 4-5 and 5-6 by 8.7e-4 and
    4e-5 (snapped); after that the three miss one point by 8.2e-4, within the snap tolerance, so the
    planner took them for a spherical wrist that the snapped robot did not have: its closed form was
    inexact and half of the solutions were lost (118 of 230 poses recovered).
    """
    tol = tol or Tolerance()
    notes: list[str] = []
    for _ in range(ROUNDS):
        snapped, more = _snap_once(chain, tol, run_factor)
        if not more:
            break
        chain, notes = snapped, notes + more
    if notes and not chain.name.endswith("(snapped)"):
        chain = dataclasses.replace(chain, name=f"{chain.name} (snapped)")
    return chain, notes


def snap_move(true: Chain, snapped: Chain) -> float:
    """How far the snap moved the geometry: the largest change of an axis direction (rad; a prismatic
    joint's direction is its twist's ``v``) or of a revolute axis's moment ``v = p x w`` over the size."""
    a, b = np.asarray(true.twists, dtype=float), np.asarray(snapped.twists, dtype=float)
    slide = np.array([k == "T" for k in true.joint_types])
    turn = np.where(slide, np.abs(a[:, :3] - b[:, :3]).max(axis=1), np.abs(a[:, 3:] - b[:, 3:]).max(axis=1))
    shift = np.where(slide, 0.0, np.abs(a[:, :3] - b[:, :3]).max(axis=1) / true.scale)
    return float(max(turn.max(initial=0.0), shift.max(initial=0.0)))


def _snap_once(chain: Chain, tol: Tolerance, run_factor: float = 1.0) -> tuple[Chain, list[str]]:
    """One round of the rules of the module docstring: (chain, notes), the chain unchanged without notes."""
    dirs = [j.axis.copy() for j in chain.joints]
    points = [j.point.copy() if j.kind == "R" else None for j in chain.joints]
    notes: list[str] = []
    names = [j.name for j in chain.joints]
    for i in range(chain.n):
        for k in range(i):
            if chain.joints[k].kind != "R":
                continue
            miss = parallel_miss(dirs[i], dirs[k])
            if tol.exact < miss <= tol.snap:
                dirs[i] = dirs[k] * (1.0 if dirs[i] @ dirs[k] > 0 else -1.0)
                notes.append(f"{names[i]} snapped parallel to {names[k]} (missed by {miss:.1e} rad)")
                break
    runs: list[list[int]] = []  # snapped runs of three or more concurrent axes
    i = 0
    while i < chain.n:
        run = [i]
        while run[-1] + 1 < chain.n and chain.joints[run[-1] + 1].kind == "R" and chain.joints[i].kind == "R":
            cand = run + [run[-1] + 1]
            x, miss = lines_meet([(dirs[j], points[j]) for j in cand], chain.scale)
            if x is None or miss > run_factor * tol.snap:
                break
            run = cand
        if len(run) < 3:
            i += 1
            continue
        # Runs may share their end axis (pr2's arm: upper-arm roll, elbow and forearm roll meet at the
        # elbow; forearm roll, wrist flex and roll at the wrist).  The shared axis already passes
        # through the earlier run's point: this run's point is taken on it and the axis stays put, so
        # that both relations hold on the snapped robot.  Before, the second run was never looked at:
        # pr2.urdf perturbed by 1e-6 kept a wrist that missed one point by 3.4e-7, the planner took it
        # for spherical, and one wrist branch of every arm branch was lost (117 of 230 poses recovered).
        shared = [j for j in run if any(j in r for r in runs)]
        x, miss = _run_point(run, shared, dirs, points, chain.scale)
        if x is not None and miss <= run_factor * tol.snap:
            runs.append(run)
            if miss > tol.exact:
                for j in run:
                    if j not in shared:
                        points[j] = x
                notes.append(
                    f"axes of {', '.join(names[j] for j in run)} snapped to meet at one point "
                    f"(missed by {miss:.1e} of the robot's size)"
                )
        # the next run may start at this run's last axis (a shorter one may end there too: j3 meets
        # j4, and j4, j5, j6 form the wrist)
        i = run[-1]
    # Consecutive pairs that nearly meet outside such runs (UR-type wrists: 4-5 and 5-6 meet, not all
    # three): shift one axis (one not in a snapped run) parallel to itself through the other's point.
    in_run = [any(j in r for r in runs) for j in range(chain.n)]
    for i in range(chain.n - 1):
        j = i + 1
        if chain.joints[i].kind != "R" or chain.joints[j].kind != "R" or any(i in r and j in r for r in runs):
            continue
        x, miss = lines_meet([(dirs[i], points[i]), (dirs[j], points[j])], chain.scale)
        if x is None or not tol.exact < miss <= tol.snap:
            continue
        mover, keeper = (j, i) if not in_run[j] else (i, j)
        if in_run[mover]:
            continue
        d, r = dirs[keeper], points[keeper]
        points[mover] = r + d * float(d @ (x - r))
        notes.append(
            f"axes of {names[i]}, {names[j]} snapped to meet (missed by {miss:.1e} of the robot's size)"
        )
    if not notes:
        return chain, []
    joints = tuple(
        Joint(j.name, j.kind, revolute_twist(d, p) if j.kind == "R" else prismatic_twist(d), j.lower, j.upper)
        for j, d, p in zip(chain.joints, dirs, points)
    )
    return dataclasses.replace(chain, joints=joints), notes


def _run_point(run, shared, dirs, points, scale):
    """The common point of a run of concurrent axes and the largest distance of an axis to it (/scale):
    the least-squares point of all the run's lines, or, when some axes are ``shared`` with an earlier
    run (they already pass through its point and must not move), the point on the shared axis nearest
    the other lines in the least-squares sense.  (None, inf) where it is not unique."""
    lines = [(dirs[j], points[j]) for j in run]
    if not shared:
        return lines_meet(lines, scale)
    d, r = dirs[shared[0]], points[shared[0]]
    a = b = 0.0
    for j in run:
        if j in shared:
            continue
        P = np.eye(3) - np.outer(dirs[j], dirs[j])
        a += float((P @ d) @ (P @ d))
        b += float((P @ d) @ (P @ (r - points[j])))
    if a * tolerances.LINES_MEET_CONDITION <= 1.0:  # the others (nearly) parallel to the shared axis
        return None, np.inf
    x = r - d * (b / a)
    miss = max(float(np.linalg.norm((np.eye(3) - np.outer(w, w)) @ (x - p))) for w, p in lines)
    return x, miss / scale


__all__ = ["REDUCED_RUN_FACTOR", "ROUNDS", "snap_chain", "twist_line"]
