"""Follow a sequence of tool poses with one continuous joint path (issue 13 item 2).

Every waypoint is solved for all its solutions inside the joint limits, each in-limit 2 pi alias of a
wide-range joint a solution of its own.  The path is the least joint motion through one solution per
waypoint (dynamic programming over the waypoints' solutions, i.e. a shortest path in the layered
graph), where a step may move no joint by more than its jump limit (an absolute angle for a revolute
joint, a length for a prismatic one).  Where the chosen step moves a joint by more than half its limit
the segment is split (its midpoint pose solved and added) and the search repeated, up to ``refine``
halvings of one input step.  Where the path still jumps, the branch is continued by Newton steps from
the previous row (a self-motion's representative at a singular waypoint need not be the one next to the
path).  What neither cures is reported as an event, never passed over silently:

- ``workspace``: a waypoint has no solution at all: the path ends before it;
- ``joint_limit``: a waypoint has solutions only outside the joint limits (the path ends before it), or
  the branch followed so far leaves the limits there and the path jumps to another branch;
- ``singularity``: the branch must change (every continuation jumps even at the finest step; the path
  passes a singular configuration where solutions merge); the event sits at the row of the two around
  the jump with the smaller ``sigma_min`` and names the joints that jump.

A path with an event is not ``complete``.  docs/motion.md has the details.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ikcompiler.errors import MotionError
from ikcompiler.motion.poses import interpolate, rotation_log
from subproblems import plan_runtime as _rt
from subproblems import select

__all__ = ["Event", "Path", "follow", "continue_branch", "module_target"]

BREAK = 1e9  # cost of a step over a jump limit: fewer jumps always win over less motion


@dataclasses.dataclass(frozen=True)
class Event:
    """Something the path meets: at row ``index`` of ``Path.q``; ``kind`` is ``workspace``,
    ``joint_limit`` or ``singularity``; ``joints`` the joints involved."""

    index: int
    kind: str
    joints: tuple[str, ...]
    detail: str = ""

    def to_json(self) -> dict:
        """The issue's event object: index, kind, joints (``detail`` is for people: text output only)."""
        return {"index": self.index, "kind": self.kind, "joints": list(self.joints)}


@dataclasses.dataclass
class Path:
    """A followed path: rows ``q`` (M, n) in ``joints`` order, ``q[0]`` the start configuration;
    ``poses[k]`` the pose ``q[k]`` reaches (forward kinematics), ``targets[k]`` the waypoint it was
    solved for, ``s[k]`` its place along the input poses (waypoint index plus fraction: refinement adds
    rows between input waypoints), ``sigma_min[k]`` its conditioning (0 at a singular configuration)."""

    joints: tuple[str, ...]
    kinds: str
    q: np.ndarray
    poses: np.ndarray
    targets: np.ndarray
    s: np.ndarray
    sigma_min: np.ndarray
    events: list[Event]
    complete: bool

    def steps(self) -> np.ndarray:
        """(M-1, n) joint motion of each step."""
        return np.diff(self.q, axis=0)

    def to_json(self) -> dict:
        """The CLI's JSON object: joints, q, poses (4x4 each), events, complete."""
        return {
            "joints": list(self.joints),
            "q": self.q.tolist(),
            "poses": self.poses.tolist(),
            "events": [e.to_json() for e in self.events],
            "complete": self.complete,
        }


def module_target(module, T) -> np.ndarray:
    """The 4x4 pose ``T`` in the form ``module.solve`` takes for its TARGET."""
    T = np.asarray(T, dtype=float)
    if module.TARGET == "position":
        return T[:3, 3]
    if module.TARGET == "orientation":
        return T[:3, :3]
    return T


def target_error(module, G, T) -> float:
    """How far pose G misses waypoint T, in what the module's TARGET constrains (length units): the
    runtime's measure (``plan_runtime.target_error``)."""
    G, T = np.asarray(G, dtype=float)[None], np.asarray(T, dtype=float)[None]
    return float(_rt.target_error(G, T, module.TARGET, module.SCALE)[0])


def _jump_limits(module, max_jump) -> np.ndarray:
    kinds = module.JOINT_TYPES
    if max_jump is None:
        max_jump = (math.radians(30.0), 0.1)
    m = np.asarray(max_jump, dtype=float).reshape(-1)
    if m.shape == (2,) and len(kinds) != 2:
        return np.array([m[0] if k == "R" else m[1] * module.SCALE for k in kinds])
    if m.shape != (len(kinds),) or np.any(m <= 0):
        raise MotionError(f"max_jump must be (revolute radians, prismatic fraction of the size) or "
                          f"{len(kinds)} positive per-joint values; got {max_jump!r}")
    return m


@dataclasses.dataclass
class _Layer:
    s: float
    target: np.ndarray  # 4x4
    rows: np.ndarray  # (k, n) exact solutions inside the limits, aliases included
    depth: int  # halvings of an input step that made this waypoint
    link: tuple | None = None  # (previous layer, motion, over) of the last search, reused while unchanged


def follow(module, poses, q_start, *free, max_jump=None, weights=None, refine: int = 8,
           singular: float = 1e-6, progress=None) -> Path:
    """Follow ``poses`` (N, 4, 4) from ``q_start``; ``poses[0]`` must be the pose ``q_start`` reaches.

    ``module`` is a generated solver module (``ikcompiler.compile_robot``); ``free`` the values of its
    free joints (default: those of ``q_start``, held along the path).  ``max_jump``: the largest motion
    of one joint in one step, ``(radians, fraction of SCALE)`` by joint type or one value per joint
    (default 30 degrees and 0.1 of the size); ``weights`` per joint for the motion cost; ``refine``: the
    most halvings of one input step; ``singular``: a row whose ``sigma_min`` is below this (and below
    its neighbours') is reported as a singularity even where the path passes it smoothly.  Returns a
    :class:`Path`.
    """
    kinds, names = module.JOINT_TYPES, tuple(module.JOINT_NAMES)
    n = len(kinds)
    q0 = np.asarray(q_start, dtype=float).reshape(-1)
    if q0.shape != (n,) or not np.all(np.isfinite(q0)):
        raise MotionError(f"q_start needs {n} finite values ({', '.join(names)}); got {q_start!r}")
    P = np.asarray(poses, dtype=float)
    if P.ndim != 3 or P.shape[1:] != (4, 4) or len(P) < 1:
        raise MotionError(f"poses must be (N, 4, 4) with N >= 1; got shape {P.shape}")
    start_err = target_error(module, module.fk(q0), P[0])
    if start_err > 1e-6 * module.SCALE:
        raise MotionError(f"q_start reaches a pose {start_err:.3g} away from poses[0]; start the poses "
                          "at module.fk(q_start) (straight_line(module.fk(q_start), goal, ...) does)")
    if not free and module.FREE_JOINTS:
        free = tuple(float(q0[names.index(f)]) for f in module.FREE_JOINTS)
    jump = _jump_limits(module, max_jump)

    def solve(T):
        return module.solve(module_target(module, T), *free, aliases=True)

    layers = [_Layer(0.0, P[0], q0[None, :], 0)]
    for k in range(1, len(P)):
        layers.append(_Layer(float(k), P[k], solve(P[k]), 0))
        if progress:
            progress(k, len(P) - 1)
    for _ in range(refine + 1):
        choice = _search(layers, kinds, module.SCALE, weights, jump)
        split = []
        for k in range(len(layers) - 1):
            a, b = layers[k], layers[k + 1]
            if max(a.depth, b.depth) >= refine:
                continue
            if len(b.rows) == 0:
                if len(a.rows):  # localise where the path leaves the workspace or its limits
                    split.append(k)
                break
            ratio = np.max(np.abs(b.rows[choice[k + 1]] - a.rows[choice[k]]) / jump)
            if ratio > 0.5:
                split.append(k)
        if not split:
            break
        for k in reversed(split):
            a, b = layers[k], layers[k + 1]
            T = interpolate(a.target, b.target, [0.5])[0]
            layers.insert(k + 1, _Layer((a.s + b.s) / 2, T, solve(T), max(a.depth, b.depth) + 1))
    choice = _search(layers, kinds, module.SCALE, weights, jump)  # layers may have grown in the last round
    hold = [names.index(f) for f in module.FREE_JOINTS]
    for _ in range(4):  # where the path still jumps, try to continue the branch by Newton steps
        added = False
        for k in range(1, len(choice)):
            a, b = layers[k - 1], layers[k]
            qa = a.rows[choice[k - 1]]
            if np.all(np.abs(b.rows[choice[k]] - qa) <= jump):
                continue
            qn = continue_branch(module, qa, b.target, hold)
            if qn is None or np.any(np.abs(qn - qa) > jump) or np.any(qn < module.LOWER - select.LIMIT_EPS) \
                    or np.any(qn > module.UPPER + select.LIMIT_EPS):
                continue
            b.rows = np.vstack([b.rows, qn])
            b.link = None
            if k + 1 < len(layers):
                layers[k + 1].link = None
            added = True
        if not added:
            break
        choice = _search(layers, kinds, module.SCALE, weights, jump)
    return _assemble(module, layers, choice, jump, free, names, kinds, singular)


def continue_branch(module, q, T, hold=(), iters: int = 30):
    """An exact solution of waypoint ``T`` reached from ``q`` by Newton steps (least-norm, on the true
    robot; the joints ``hold`` fixed), or None.

    Used only where the chosen path jumps: a self-motion's representative (at a singular waypoint the
    solver returns one of infinitely many, not necessarily the one next to the path) or a solution the
    solver did not return near a double root.  A row found here is checked like any other: it must
    reproduce the waypoint to the module's TOLERANCE (it is polished to 1e-12 of the size when the
    steps allow) and lie inside the limits.
    """
    if module.TARGET not in ("pose", "position", "orientation"):
        return None
    q = np.array(q, dtype=float)
    rows = {"pose": slice(0, 6), "position": slice(0, 3), "orientation": slice(3, 6)}[module.TARGET]
    best = None
    for _ in range(iters):
        G = module.fk(q)
        err = target_error(module, G, T)
        if err <= module.TOLERANCE * module.SCALE:
            best = q.copy()
            if err <= 1e-12 * module.SCALE:
                break
        e = np.concatenate([T[:3, 3] - G[:3, 3], rotation_log(T[:3, :3] @ G[:3, :3].T)])[rows]
        J = select.jacobian(q[None], twists=module._TWISTS, A=module._A, b=module._B, home=module._HOME,
                            scale=1.0)[0][rows]
        J[:, list(hold)] = 0.0
        dq = np.linalg.lstsq(J, e, rcond=1e-10)[0]
        big = np.abs(dq).max()
        q = q + (dq * (0.5 / big) if big > 0.5 else dq)  # at most half a radian a step
    return best


def _search(layers, kinds, scale, weights, jump) -> list[int]:
    """Least-cost choice of one row per layer (up to the first empty layer): jumps first, then motion.

    The motion of a step is select.distance's (radians, prismatic over scale, times the weights), here
    written out for all pairs of two layers at once.
    """
    w = np.array([1.0 if k == "R" else 1.0 / scale for k in kinds])
    if weights is not None:
        w = w * np.asarray(weights, dtype=float).reshape(-1)
    cost = np.zeros(1)
    back = []
    m = len(layers)
    for k in range(1, m):
        rows, prev = layers[k].rows, layers[k - 1].rows
        if len(rows) == 0:
            break
        if layers[k].link is not None and layers[k].link[0] is layers[k - 1]:
            motion, over = layers[k].link[1:]
        else:
            D = np.abs(rows[None, :, :] - prev[:, None, :])  # (prev, rows, n)
            over = (D > jump).any(axis=2)
            D *= w
            motion = np.sqrt(np.einsum("prn,prn->pr", D, D))
            layers[k].link = (layers[k - 1], motion, over)
        # a forced jump is cheaper the later it comes: it then sits where the old branch ends
        total = cost[:, None] + motion + BREAK * (1 + (m - k) / m) * over
        best = np.argmin(total, axis=0)
        back.append(best)
        cost = total[best, np.arange(len(rows))]
    choice = [int(np.argmin(cost))]
    for best in reversed(back):
        choice.append(int(best[choice[-1]]))
    return choice[::-1]


def _null_joints(module, q, names) -> tuple[str, ...]:
    """Joints that move in the direction a singular configuration loses (its Jacobian's null vector)."""
    J = select.jacobian(q[None], twists=module._TWISTS, A=module._A, b=module._B, home=module._HOME,
                        scale=module.SCALE, target=module.TARGET)[0]
    v = np.abs(np.linalg.svd(J)[2][-1])
    return tuple(names[j] for j in np.nonzero(v > 0.3 * v.max())[0])


def _merge(events: list[Event]) -> list[Event]:
    """One event per (row, kind): the joints of both, in joint order of first appearance."""
    out: dict[tuple[int, str], Event] = {}
    for e in events:
        key = (e.index, e.kind)
        if key in out:
            old = out[key]
            joints = old.joints + tuple(j for j in e.joints if j not in old.joints)
            out[key] = dataclasses.replace(old, joints=joints)
        else:
            out[key] = e
    return sorted(out.values(), key=lambda e: (e.index, e.kind))


def _assemble(module, layers, choice, jump, free, names, kinds, singular) -> Path:
    m = len(choice)
    Q = np.array([layers[k].rows[choice[k]] for k in range(m)])
    targets = np.array([layers[k].target for k in range(m)])
    poses = np.array([module.fk(q) for q in Q])
    sig = select.sigma_min(Q, twists=module._TWISTS, A=module._A, b=module._B, home=module._HOME,
                           scale=module.SCALE, target=module.TARGET)
    events: list[Event] = []
    lower, upper = module.LOWER, module.UPPER
    for k in range(1, m):
        d = np.abs(Q[k] - Q[k - 1])
        if np.all(d <= jump):
            continue
        # the branch changes here: because it leaves the limits, or because it ends at a singularity
        T = module_target(module, layers[k].target)
        loose = module.solve(T, *free, limits=False)
        if len(loose):
            # the old branch continued: its nearest solution without limits, as a motor position
            rev = np.array([c == "R" for c in kinds])
            diff = loose - Q[k - 1]
            diff[:, rev] = np.remainder(diff[:, rev] + math.pi, 2 * math.pi) - math.pi
            best = int(np.argmin(np.max(np.abs(diff) / jump, axis=1)))
            cont = Q[k - 1] + diff[best]
            out = (cont < lower - select.LIMIT_EPS) | (cont > upper + select.LIMIT_EPS)
            if np.all(np.abs(diff[best]) <= jump) and out.any():
                events.append(Event(k, "joint_limit", tuple(names[j] for j in np.nonzero(out)[0]),
                                    "the branch followed leaves the joint limits; the path jumps to another"))
                continue
        at = k if sig[k] <= sig[k - 1] else k - 1
        events.append(Event(at, "singularity", tuple(names[j] for j in np.nonzero(d > jump)[0]),
                            f"the branch must change (sigma_min {min(sig[k], sig[k - 1]):.2g}); the "
                            "joints named jump"))
    for k in range(m):  # passing a singular configuration, even smoothly
        lower_than = all(sig[k] <= sig[j] for j in (k - 1, k + 1) if 0 <= j < m)
        if sig[k] < singular and lower_than:
            events.append(Event(k, "singularity", _null_joints(module, Q[k], names),
                                f"the path passes a singular configuration (sigma_min {sig[k]:.2g})"))
    if m < len(layers):  # the path stops before a waypoint with no solution inside the limits
        T = module_target(module, layers[m].target)
        loose = module.solve(T, *free, limits=False)
        if len(loose):
            dist = select.distance(loose, Q[-1], kinds, module.SCALE, wrap=True)
            out = select.excluding_joints(loose[int(np.argmin(dist))][None], kinds, lower, upper)[0]
            events.append(Event(m - 1, "joint_limit", tuple(names[j] for j in np.nonzero(out)[0]),
                                f"no solution inside the joint limits at waypoint s = {layers[m].s:.6g}"))
        else:
            events.append(Event(m - 1, "workspace", (),
                                f"no solution at waypoint s = {layers[m].s:.6g}: the pose is out of reach"))
    s = np.array([layers[k].s for k in range(m)])
    events = _merge(events)
    return Path(names, kinds, Q, poses, targets, s, sig, events, complete=not events)
