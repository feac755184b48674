"""General-6r modules whose free joints sit at the chain's ends (docs/design.md section 5, "General 6R").

With ``P`` the motion of the free joints before the six solved ones and ``S`` of those after, the pose
equation ``P X(q) S M = T`` is the 6R problem ``X(q) M = P^-1 T M^-1 S^-1 M`` of fixed twists: the free
values move the target, not the robot.  :class:`FreeEnds` maps targets to that problem and its rows
back (the free values inserted); :class:`NativeFreeEnds` runs the C elimination of the six solved
joints on the moved targets and takes the Python path wherever a row does not hold on the whole robot;
one pose (``solve``, ``solve_info``) takes :meth:`NativeFreeEnds.one`, the same rows without the batch
arrays.  The whole-robot check multiplies per-joint constants computed once (``screw.FixedTwistsFK``):
fk_batch's ~40 us a joint was most of a single solve (docs/design.md section 14, "Single pose with
free end joints").
"""

from __future__ import annotations

import numpy as np

from subproblems import plan_runtime as _rt
from subproblems.screw import FixedTwistsFK


class FreeEnds:
    """The split of a general-6r robot with free joints: solved joints and the free ones around them."""

    def __init__(self, robot):
        self.robot = robot
        free = [robot.independent[pos] for pos in robot.free]
        self.solved = [j for j in range(len(robot.kinds)) if j not in free]
        self.before = [j for j in free if j < self.solved[0]]
        self.after = [j for j in free if j > self.solved[-1]]

    def targets(self, goals, init) -> np.ndarray:
        """The 6R problem's targets ``P^-1 T M^-1 S^-1 M`` (N, 4, 4) of goals T with free values in init.
        Kept bit for bit as first written (fk_batch, inverse_transform, the identity factors): at special
        poses the elimination's rows move with the last bits of its target (xarm7: a change of 1e-16
        moved a row by 7e-10, and another pose had 10 rows instead of 11; docs/design.md section 14)."""
        r, N = self.robot, len(goals)
        eye = np.broadcast_to(np.eye(4), (N, 4, 4))
        P = _rt.fk_batch(r.twists[self.before], init[:, self.before]) if self.before else eye
        S = _rt.fk_batch(r.twists[self.after], init[:, self.after]) if self.after else eye
        return _rt.inverse_transform(P) @ goals @ r.home_inv @ _rt.inverse_transform(S) @ r.home

    def rows(self, Q, init_rows) -> np.ndarray:
        """Rows of every chain joint: the solved joints' values Q (M, 6), the free ones from init_rows."""
        TH = np.array(init_rows, dtype=float)
        TH[:, self.solved] = Q
        return TH


class NativeFreeEnds:
    """The C elimination of the six solved joints (``csource.general6_c_source`` on them) behind
    :class:`FreeEnds`.  A target goes to the Python path when the C hands it back, or when a row the C
    calls exact misses the precision on the whole robot (the moved target's error is the whole robot's
    up to the right factor ``M^-1 S M``).  A free value is used as given (its motion is 2 pi periodic):
    the caller (dispatch ``_free_as_given``) puts it in its column as given and drops the rows of a value
    outside its limits, as on the Python path.  Sending a value outside (-pi, pi] to Python as well sent
    half of xarm7.urdf's random poses there (joint7 limits +-2 pi; 35-50 ms each)."""

    def __init__(self, robot, native):
        self.split = split = robot.free_ends
        self.robot = robot
        self.native = native
        self.positions = [robot.independent.index(j) for j in split.solved]  # JOINT_NAMES positions
        self.fk = FixedTwistsFK(robot.twists, robot.home)  # the whole robot's check of the C's rows
        # (JOINT_NAMES position, chain column) of each free joint
        self.free = [(int(pos), robot.independent[pos]) for pos in robot.free]

    @classmethod
    def bind(cls, robot):
        """The C build for ``robot`` (a general-6r module with free end joints), or None."""
        from ikcompiler.codegen.csource import general6_c_source
        from ikcompiler.runtime.freefold import FoldedGeneral6
        from subproblems import native

        if robot.general6 is None or isinstance(robot.general6, FoldedGeneral6):  # folded: Python only
            return None
        split = robot.free_ends
        if len(split.solved) != 6 or robot.couplings:
            return None
        pos = [robot.independent.index(j) for j in split.solved]  # JOINT_NAMES positions
        source = general6_c_source(robot.general6, kinds="".join(robot.joint_types[p] for p in pos),
                                   lower=robot.lower[pos], upper=robot.upper[pos], target="pose",
                                   scale=robot.scale, tol=robot.tol, slots=robot.slots,
                                   twists=robot.twists[split.solved], home=robot.home, A=np.eye(6),
                                   b=np.zeros(6))
        chain = source and native.bind(source, dof=6, slots=robot.slots, nfree=0, target="pose")
        return cls(robot, chain) if chain is not None else None

    def many(self, goals, init, limits: bool):
        """(Q, valid, ls, residual, continuum) of N checked goals in JOINT_NAMES order, and (N,) True for
        the targets the Python path must take over."""
        from subproblems.native import PYTHON

        r = self.robot
        N = len(goals)
        (Q6, valid, ls, res, cont), code = self.native.many(self.split.targets(goals, init),
                                                            np.zeros((N, 0)), limits)
        Q = np.zeros(Q6.shape[:2] + (len(r.joint_names),))
        Q[:, :, self.positions] = Q6
        for pos in r.free:
            Q[:, :, pos] = init[:, r.independent[pos], None]
        n, k = np.nonzero(valid & ~ls)
        full = Q[n, k] @ r.A.T + r.B
        err = r.error(self.fk(full), goals[n])
        redo = code == PYTHON
        redo[n[~(err <= r.tol * r.scale)]] = True
        res = res.copy()
        res[n, k] = err  # the whole robot's error (the C measured the moved target's)
        Q[~valid] = 0.0
        return (Q, valid, ls, res, cont), redo

    def one(self, goals, given, limits: bool):
        """``(q, residual, ls, continuum)`` of one checked goal (1, 4, 4) with free values ``given``
        (floats), the rows :meth:`many` gives it; None where :meth:`many` must decide (the C hands the
        target back, an exact row misses on the whole robot).  One pose on :meth:`many`'s (N, K, n)
        arrays cost ~5x the C call (docs/design.md section 14)."""
        r = self.robot
        init = np.full((1, len(r.kinds)), np.nan)
        for (_, col), x in zip(self.free, given):
            init[0, col] = x
        found = self.native.one(self.split.targets(goals, init)[0], (), limits)
        if found is None:
            return None
        q6, res, ls, cont = found
        Q = np.zeros((len(q6), len(r.joint_names)))
        Q[:, self.positions] = q6
        for (pos, _), x in zip(self.free, given):
            Q[:, pos] = x
        exact = ~ls
        err = r.error(self.fk(Q[exact] @ r.A.T + r.B), goals)
        if not (err <= r.tol * r.scale).all():
            return None
        res[exact] = err  # the whole robot's error (the C measured the moved target's)
        return Q, res, ls, cont
