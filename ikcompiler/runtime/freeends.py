"""General-6r modules whose free joints sit at the chain's ends (docs/design.md section 5, "General 6R").

With ``P`` the motion of the free joints before the six solved ones and ``S`` of those after, the pose
equation ``P X(q) S M = T`` is the 6R problem ``X(q) M = P^-1 T M^-1 S^-1 M`` of fixed twists: the free
values move the target, not the robot.  :class:`FreeEnds` maps targets to that problem and its rows
back (the free values inserted); :class:`NativeFreeEnds` runs the C elimination of the six solved
joints on the moved targets and takes the Python path wherever a row does not hold on the whole robot;
one pose (``solve``, ``solve_info``) takes :meth:`NativeFreeEnds.one`, the same rows without the batch
arrays.  The moved target and the whole-robot check of the C's exact rows are done in the same C call
(``subproblems/free_ends.h``): in Python around it they cost ~10x the call (docs/design.md section 14,
"Single pose with free end joints").
"""

from __future__ import annotations

import numpy as np

from subproblems import plan_runtime as _rt


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
    """The C of a general-6r robot with free end joints (``csource.free_ends_c_source``): the moved
    target, the elimination of the six solved joints on it and the check of every exact row on the
    whole robot, in one call per target (``subproblems/free_ends.h``).  A target goes to the Python path
    when the C hands it back (its finish, or an exact row missing the precision on the whole robot).  A
    free value is used as given (its motion is 2 pi periodic): the caller (dispatch ``_free_as_given``)
    puts it in its column as given and drops the rows of a value outside its limits, as on the Python
    path.  Sending a value outside (-pi, pi] to Python as well sent half of xarm7.urdf's random poses
    there (joint7 limits +-2 pi; 35-50 ms each).  ``native``: the six's chain alone on a moved target
    (its ``exact``: the benchmarks' *C call*)."""

    def __init__(self, robot, lib, native):
        import ctypes
        import threading

        self.split = robot.free_ends
        self.robot = robot
        self.native = native
        n, K = len(robot.joint_names), robot.slots
        P, I, L = ctypes.c_void_p, ctypes.c_int, ctypes.c_int64  # noqa: E741
        self._one = lib.ikc_free_solve_one
        self._one.argtypes, self._one.restype = [P, P, I, P, P, P, P], I
        self._many = lib.ikc_free_solve_many
        self._many.argtypes, self._many.restype = [L, P, P, I, P, P, P, P, P, I], None
        self.nfree = len(robot.free)
        # one target: buffers reused under a lock (the call and the copies out are one critical section)
        self._lock = threading.Lock()
        self._T, self._F = np.zeros((4, 4)), np.zeros(max(1, self.nfree))
        self._q, self._res = np.zeros((K, n)), np.zeros(K)
        self._ls, self._cont = np.zeros(K, dtype=np.intc), np.zeros(K, dtype=np.intc)
        self._addr = [a.ctypes.data for a in (self._T, self._F, self._q, self._res, self._ls, self._cont)]

    @classmethod
    def bind(cls, robot):
        """The C build for ``robot`` (a general-6r module with free end joints), or None."""
        from ikcompiler.codegen.csource import free_ends_c_source
        from ikcompiler.runtime.freefold import FoldedGeneral6
        from subproblems import native

        if robot.general6 is None or isinstance(robot.general6, FoldedGeneral6):  # folded: Python only
            return None
        split = robot.free_ends
        if len(split.solved) != 6 or robot.couplings:
            return None
        source = free_ends_c_source(
            robot.general6, joint_types=robot.joint_types, lower=robot.lower, upper=robot.upper,
            scale=robot.scale, tol=robot.tol, slots=robot.slots, twists=robot.twists, home=robot.home,
            home_inv=robot.home_inv, A=robot.A, b=robot.B, solved=split.solved,
            solved_pos=[robot.independent.index(j) for j in split.solved],
            free_cols=[robot.independent[p] for p in robot.free], free_pos=list(robot.free))
        lib = source and native.load(source)
        if not lib:
            return None
        return cls(robot, lib, native.NativeChain(lib, dof=6, slots=robot.slots, nfree=0, target="pose"))

    def many(self, goals, init, limits: bool):
        """(Q, valid, ls, residual, continuum) of N checked goals in JOINT_NAMES order, and (N,) True for
        the targets the Python path must take over."""
        from subproblems.native import threads

        r = self.robot
        N, K, n = len(goals), r.slots, len(r.joint_names)
        goals = np.ascontiguousarray(goals, dtype=float)
        free = np.ascontiguousarray(init[:, [r.independent[p] for p in r.free]], dtype=float)
        Q = np.zeros((N, K, n))
        res = np.full((N, K), np.inf)
        ls, cont = np.zeros((N, K), dtype=np.intc), np.zeros((N, K), dtype=np.intc)
        code = np.zeros(N, dtype=np.intc)
        self._many(N, goals.ctypes.data, free.ctypes.data, 1 if limits else 0, Q.ctypes.data,
                   res.ctypes.data, ls.ctypes.data, cont.ctypes.data, code.ctypes.data, threads())
        valid = np.arange(K)[None, :] < code[:, None]
        res[~valid] = np.inf
        Q[~valid] = 0.0
        # code < 0: handed back (PYTHON), or a checked goal the C's own check refuses (INVALID): Python
        return (Q, valid, (ls != 0) & valid, res, (cont != 0) & valid), code < 0

    def one(self, T, given, limits: bool):
        """``(q, residual, ls, continuum)`` of one raw target T (4, 4) with free values ``given`` (floats),
        the rows :meth:`many` gives it; None where the Python path must decide (the C hands the target
        back or finds it invalid, T not a 4 x 4 array of numbers: the batch form raises the error).
        One pose on :meth:`many`'s (N, K, n) arrays cost ~5x the C call (docs/design.md section 14)."""
        with self._lock:
            try:
                if np.shape(T) != (4, 4):
                    return None
                self._T[...] = T
            except (ValueError, TypeError):
                return None
            self._F[:self.nfree] = given
            aT, aF, aq, ares, als, acont = self._addr
            k = self._one(aT, aF, 1 if limits else 0, aq, ares, als, acont)
            if k < 0:
                return None
            return self._q[:k].copy(), self._res[:k].copy(), self._ls[:k] != 0, self._cont[:k] != 0
