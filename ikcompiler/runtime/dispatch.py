"""Which path a target takes, and the batch driver (docs/design.md section 6).

Paths, cheapest first: the C chain (where the chain has one: ``NATIVE``), the Python fast chain
(``_fast_chain``), the reference runtime (:mod:`ikcompiler.runtime.reference`).  Each runs at most
once per target: a target the C chain hands back goes straight to what settles it (the reference
runtime; a search or snapped plan's Python fast path, whose search / continuation the C does not
finish), and the Python fast chain's leaves, when its finish cannot settle them, are routed once
(Newton steps on them, or the reference runtime) instead of being computed again.
"""

from __future__ import annotations

import math

import numpy as np

from ikcompiler.runtime import fastchain, reference, selection, selfmotion, targets
from ikcompiler.runtime.robot import Robot
from subproblems import fast as _fk

# Bytes of intermediate arrays a batch holds at a time (its output excluded): chunks of targets are
# sized so that a search plan's grid x targets instances, or the reference runtime's branches, stay
# within it; issue 10's bound is a 100,000-pose batch within 2 GB in all.
MEMORY_BUDGET = 256 * 1024 * 1024
CHUNK = 4096  # targets per chunk of the Python paths (no search)
NATIVE_CHUNK = 65536  # targets per call of the C batch driver


class Solver:
    """The runtime of one generated module, built from its namespace (``Solver(globals())``).

    The module's ``FAST_PATH`` and ``NATIVE`` switches are read at each call.
    """

    def __init__(self, namespace: dict, *, memory_budget: int = MEMORY_BUDGET):
        self._ns = namespace
        self.robot = Robot.from_namespace(namespace)
        self.memory_budget = memory_budget
        self._native = []  # [NativeChain] or [None] once bound
        self._general6 = []  # the true robot's general 6R solver, for doubtful snapped targets
        self._free_ends = []  # [NativeFreeEnds or None] once bound
        self._free_columns = None  # _free_limits(), once

    # -- the paths -------------------------------------------------------------------------------

    def fast_path(self) -> bool:
        return bool(self._ns.get("FAST_PATH")) and self.robot.fast_chain is not None

    def native_chain(self):
        """The C build of the fast chain (printed from the module's data and compiled on first use, both
        cached: ikcompiler.codegen.csource.native_source, subproblems.native), or None."""
        if not (self.fast_path() or self.general6_native()) or not self._ns.get("NATIVE"):
            return None
        if not self._native:
            from ikcompiler.codegen.csource import native_source
            from subproblems import native

            r = self.robot
            source = native_source(self._ns)
            self._native.append(source and native.bind(source, dof=len(r.joint_names), slots=r.slots,
                                                       nfree=len(r.free_joints), target=r.target))
        return self._native[0]

    def general6_native(self) -> bool:
        """A general-6r module: no Python fast chain, but a native one, the C elimination
        (subproblems/general6.h, switched by NATIVE); the Python general6 stays the reference for the
        targets the C hands back."""
        r = self.robot
        # free joints move the target (reference.general6_rows), which the C elimination does not do
        return r.method == "general-6r" and r.general6 is not None and not r.free_joints

    def free_ends_native(self):
        """A general-6r module with free end joints: the C elimination of its six solved joints on the
        moved targets (runtime.freeends), or None (another method, NATIVE off, no C build)."""
        r = self.robot
        if r.method != "general-6r" or not r.free_joints or r.general6 is None or not self._ns.get("NATIVE"):
            return None
        if not self._free_ends:
            from ikcompiler.runtime.freeends import NativeFreeEnds

            self._free_ends.append(NativeFreeEnds.bind(r))
        return self._free_ends[0]

    def general6(self):
        if not self._general6:
            self._general6.append(reference.true_general6(self.robot))
        return self._general6[0]

    def correct(self, TH, owner, goals, family):
        """Snapped plan: candidates of the snapped robot carried to the true one (reference.correct):
        (TH, owner, continuum)."""
        return reference.correct(self.robot, TH, owner, goals, self.general6, family)

    def search_chunk(self) -> int:
        """Targets a search (or the reference runtime) works on at a time: its grid instances, at
        ``fastchain.BYTES_PER_INSTANCE`` each, within ``memory_budget``."""
        width = fastchain.BYTES_PER_INSTANCE * fastchain.search_width(self.robot)
        return max(1, self.memory_budget // width)

    def reference_chunk(self, goals, Td, init, limits, alternative=None, leaves=None):
        """The reference runtime on targets (chunked so that a search stays within the budget);
        ``alternative`` marks the targets that also take the plan's alternative chain; ``leaves``: a
        snapped plan's fast-chain leaves of the targets, extra candidates (reference.candidates)."""
        step = self.search_chunk()
        if len(goals) <= step:
            return self._reference(goals, Td, init, limits, alternative, leaves)
        return _joined([self._reference(goals[i:i + step], Td[i:i + step], init[i:i + step], limits,
                                        None if alternative is None else alternative[i:i + step],
                                        None if leaves is None else tuple(x[i:i + step] for x in leaves))
                        for i in range(0, len(goals), step)])

    def _reference(self, goals, Td, init, limits, alternative=None, leaves=None):
        r = self.robot
        return reference.complete(r, *reference.candidates(r, goals, Td, init, self.correct, alternative,
                                                           leaves), goals, limits)

    def lock_targets(self, flag):
        """Targets (N,) whose fast-chain leaves met a gimbal lock (FAMILY) where the plan has an
        alternative chain: the reference runtime settles them with it (reference.with_alternative)."""
        if not self.robot.alt_steps:
            return np.zeros(len(flag), dtype=bool)
        return ((flag & _fk.FAMILY) != 0).any(axis=1)

    def settle_leaves(self, goals, Td, init, limits, Q, err, flag):
        """Finish the fast chain's leaves of targets: done here, Newton steps on the near misses, or the
        reference runtime for targets near a degenerate geometry (fast.finish_many's routes)."""
        r = self.robot
        lock = self.lock_targets(flag)
        flag = np.where(lock[:, None], flag | _fk.DEFER, flag)  # to the reference runtime
        parts, route = _fk.finish_many(Q, err, flag, **r.finish_kwargs(limits))
        newton = np.nonzero(route == _fk.ROUTE_NEWTON)[0]
        if len(newton):
            rows, leaf = np.nonzero(_fk.usable(Q[newton], flag[newton]))
            TH = Q[newton[rows], leaf] @ r.A.T + r.B
            cont = (flag[newton[rows], leaf] & _fk.FAMILY) != 0
            done = reference.complete(r, TH, rows, np.zeros(len(TH), dtype=bool), cont, goals[newton], limits)
            _scatter(parts, newton, _fk.merge_split_roots(done, r.joint_types))
        defer = np.nonzero(route == _fk.ROUTE_REFERENCE)[0]
        if len(defer):
            _scatter(parts, defer, self.reference_chunk(goals[defer], Td[defer], init[defer], limits,
                                                        lock[defer]))
        return tuple(parts)

    def python_chunk(self, goals, Td, init, limits):
        """Targets on the Python paths: the fast chain on arrays (its search, or its snapped plan's
        continuation) and the reference runtime for what it cannot settle."""
        r = self.robot
        if not self.fast_path():
            return self.reference_chunk(goals, Td, init, limits)
        if r.search:
            # the whole search (grid, seeds, Newton, finish) on chunks of search_chunk() targets: its
            # grid instances stay within the memory budget and its seeds with them
            step = self.search_chunk()
            return _joined([reference.complete(r, *fastchain.search_candidates(r, goals[i:i + step],
                                                                               init[i:i + step],
                                                                               self.memory_budget),
                                               goals[i:i + step], limits)
                            for i in range(0, len(goals), step)])
        Q, err, flag = fastchain.leaves(r, goals, init)
        if not r.polish:
            return self.settle_leaves(goals, Td, init, limits, Q, err, flag)
        # snapped plan: the leaves are candidates on the snapped robot; the continuation corrects them
        # A gimbal lock goes to the reference runtime, which takes the alternative chain, only on a chain
        # of fewer than 6 independent joints (a 5-joint arm's O-RRR gimbal, whose waist value the
        # position fixes).  On a 6-joint chain the snapped lock is a self-motion: the family path below
        # keeps its representatives (puma560_robot.urdf at q5 = 0: sent away, 4 of 30 poses missed).
        lock = self.lock_targets(flag) & (len(r.vary) < 6)
        defer = (flag & _fk.HAND_BACK).any(axis=1) | lock
        rows, leaf = np.nonzero(~defer[:, None] & _fk.usable(Q, flag))
        # a leaf on a self-motion of the snapped robot stays a representative of it where the true
        # robot leaves it unresolved (the relation missed by ~1e-9: numerically the same family)
        family = (flag[rows, leaf] & _fk.FAMILY) != 0
        TH, rows, cont = self.correct(Q[rows, leaf] @ r.A.T + r.B, rows, goals, family)
        none = np.zeros(len(TH), dtype=bool)
        # rows of one target that the continuation left on one solution (a double root tracked from its
        # two snapped copies) are one row: merged as the Newton route merges split roots
        parts = list(_fk.merge_split_roots(reference.complete(r, TH, rows, none, cont, goals, limits),
                                           r.joint_types))
        near_lock = self.tangent_misses(parts, flag) & ~defer
        lock, defer = lock | near_lock, defer | near_lock
        idx = np.nonzero(defer)[0]
        if len(idx):
            # a gimbal lock's fast leaves join the reference steps' candidates (reference._with_leaves)
            L = Q[idx] @ r.A.T + r.B
            leaves = (L, lock[idx, None] & _fk.usable(Q[idx], flag[idx]), (flag[idx] & _fk.FAMILY) != 0)
            _scatter(parts, idx, self.reference_chunk(goals[idx], Td[idx], init[idx], limits, lock[idx],
                                                      leaves))
        return tuple(parts)

    def tangent_misses(self, parts, flag):
        """Targets (N,) of a snapped plan of fewer than 6 joints with an alternative chain where no row
        ended exact and a leaf met a tangent root: the snapped O-RRR near its gimbal lock (the true
        target's rotation aligns its outer axes only to about the change in geometry, so the lock is
        no FAMILY leaf), whose outer angles the chain then reads off nearly parallel vectors.  The
        reference runtime takes the alternative chain there, as at a lock (reference.with_alternative;
        the C finish hands them back: ikc_polished).  trossen px150 of rtb-data at 1e-6, seed 8, q =
        (pi/2, -pi/2, pi/2, pi/2, pi/2): two least-squares rows of the other waist branch came back."""
        r = self.robot
        if not r.alt_steps or len(r.vary) >= 6:
            return np.zeros(len(flag), dtype=bool)
        _, valid, ls, _, _ = parts
        tangent = ((flag & _fk.TANGENT_ROOT) != 0) & ((flag & _fk.EMPTY) == 0)
        return tangent.any(axis=1) & ~(valid & ~ls).any(axis=1)

    def handed_back(self, goals, Td, init, limits):
        """Targets the C chain could not settle.  It ran the fast path already: what is left is the
        reference runtime, except for a search plan (its Python search is much cheaper than the
        reference runtime's) and a snapped plan (the continuation starts from the fast leaves)."""
        if self.robot.search or self.robot.polish:
            return self.python_chunk(goals, Td, init, limits)
        return self.reference_chunk(goals, Td, init, limits)

    # -- one target ------------------------------------------------------------------------------

    def rows(self, T, free, limits, exact_only=False):
        """(q, residual, ls, continuum) of one target, exact rows first; with ``exact_only`` just the
        exact rows' q (``solve``'s answer)."""
        found = self._rows(T, free, limits, exact_only)
        if self.robot.free:
            found = self._free_as_given_one(found, free, limits, exact_only)
        if exact_only or not self.flags_rows():
            return found
        q, res, ls, cont = found
        goals = targets.check_targets(self.robot, np.asarray(T, dtype=float)[None])[0]
        return q, res, ls, cont | self.row_flags(q, ~ls, np.repeat(goals, len(q), axis=0))

    def flags_rows(self) -> bool:
        """Whether returned rows get continuum flags here: a near-redundant robot's rows, and a search
        plan's rows on a self-motion (the grid's seeds are isolated points, as the general 6R's rows)."""
        return self.robot.near_redundant or bool(self.robot.search)

    def row_flags(self, Q, exact, goals) -> np.ndarray:
        """(M,) continuum flags of returned rows Q (M, JOINT_NAMES) with their goals (M, 4, 4):
        selfmotion.near_redundant on a near-redundant robot; on a search plan selfmotion.flags of the
        exact rows (Jacobian rank-deficient and the family goes on through the row)."""
        r = self.robot
        out = np.zeros(len(Q), dtype=bool)
        if r.near_redundant:
            out |= selfmotion.near_redundant(r, Q)
        if r.search:
            idx = np.nonzero(exact & ~out)[0]
            full = np.concatenate([Q[idx], np.zeros((len(idx), len(r.vary) - Q.shape[1]))], axis=1)
            out[idx] = selfmotion.flags(r, full @ r.A.T + r.B, goals[idx])
        return out

    def _rows(self, T, free, limits, exact_only=False):
        r = self.robot
        fe = self.free_ends_native()
        if fe is not None:
            given = _plain_free(free, len(r.free))
            # the scalar route (NativeFreeEnds.one: the C checks T), else the batch form's
            if given is not None:
                found = fe.one(T, given, limits)
                if found is not None:
                    return found[0][~found[2]] if exact_only else found
            goals, Td, init = self._one_target(T, free)
            parts = self._free_ends_batch(goals, Td, init, np.array([""], dtype=object), limits)
            return _unpack(parts, exact_only)
        native = self.native_chain()
        if native is not None:
            found = native.exact(T, free, limits) if exact_only else native.one(T, free, limits)
            if found is not None:
                return found
            goals, Td, init = self._one_target(T, free)
            return _unpack(self.handed_back(goals, Td, init, limits), exact_only)
        # the scalar fast chain once; its leaves, if its finish cannot settle them, routed once
        leaves = fastchain.scalar_leaves(r, T, free) if self.fast_path() else None
        if leaves is not None and not (r.alt_steps and any(int(leaf[-1]) & _fk.FAMILY for leaf in leaves)):
            found = _fk.finish_one(leaves, **r.finish_kwargs(limits))
            if found is not None:
                q, res, ls, cont = fastchain.rows_of_one(found, len(r.joint_names))
                return q[~ls] if exact_only else (q, res, ls, cont)
        goals, Td, init = self._one_target(T, free)
        if leaves is not None:
            Q, err, flag = _fk.leaf_arrays(leaves, 1, len(r.joint_names))
            parts = self.settle_leaves(goals, Td, init, limits, Q, err, flag)
        else:
            parts = self.python_chunk(goals, Td, init, limits)
        return _unpack(parts, exact_only)

    def _one_target(self, T, free):
        """One validated target (goals, Td, init); an invalid target or free value raises."""
        goals, Td = targets.valid_targets(self.robot, np.asarray(T, dtype=float)[None])
        return goals, Td, targets.initial_values(self.robot, 1, free)

    # -- many targets ----------------------------------------------------------------------------

    def solve_batch_info(self, Ts, *free, limits=True, chunk=CHUNK):
        """Every solution of N targets: Q (N, K, n), valid, ls, residual and continuum (N, K).

        Rows with ls True are least-squares answers (their residual says how far they miss); valid marks
        the filled slots; continuum marks solutions that are one representative of a self-motion (the
        target is at a singular configuration with infinitely many solutions).  Vectorised over the
        targets; processed in chunks to bound memory.  With ``limits`` (the default) solutions outside
        the joint limits LOWER..UPPER are left out (a revolute value counts in any 2 pi representation).
        """
        Q, *rest = self._batch(Ts, self._free_in(free), limits, chunk, flags=True)
        return (self._out(Q, free), *rest)

    def _batch(self, Ts, free, limits, chunk=CHUNK, flags=True):
        """solve_batch_info in the values the chain solves for (see :meth:`_out`); ``flags`` False skips
        the continuum flags set here (solve_batch drops them)."""
        done = checked = None
        if self.free_ends_native() is not None:
            checked = targets.check_targets(self.robot, Ts)
            goals, Td, reasons = checked
            init = targets.initial_values(self.robot, len(goals), free)
            done = self._free_ends_batch(goals, Td, init, reasons, limits)
        else:
            done = self._native_batch(Ts, free, limits)
        if done is None:
            checked = checked or targets.check_targets(self.robot, Ts)
            goals, Td, reasons = checked
            init = targets.initial_values(self.robot, len(goals), free)
            parts = [targets.without_invalid(self.python_chunk(goals[i:i + chunk], Td[i:i + chunk],
                                                               init[i:i + chunk], limits),
                                             reasons[i:i + chunk])
                     for i in range(0, len(goals), chunk)]
            done = _joined(parts) if parts else self._empty()
        if self.robot.free:
            done = self._free_as_given(done, free, limits)
        if flags and self.flags_rows():
            Q, valid, ls, res, cont = done
            goals = (checked or targets.check_targets(self.robot, Ts))[0]
            n, k = np.nonzero(valid)
            cont = cont.copy()
            for i in range(0, len(n), NATIVE_CHUNK):  # in chunks: a Jacobian of every row at once is big
                rows = n[i:i + NATIVE_CHUNK], k[i:i + NATIVE_CHUNK]
                cont[rows] |= self.row_flags(Q[rows], ~ls[rows], goals[rows[0]])
            done = (Q, valid, ls, res, cont)
        return done

    def _free_as_given(self, parts, free, limits):
        """Rows (Q, valid, ls, res, cont) of N targets with each free joint's column set to the value the
        user gave, not to the 2 pi alias the finish represents it by: a free value is a command, as given
        (docs/design.md section 5, "Redundant robots"; pr2's upper-arm roll at -3.22, inside its limits
        [-3.9, 0.8], came back as 3.06, outside them).  With ``limits`` a target whose given free value
        lies outside its joint's limits has no valid row (solve_info names the joint among the excluded)."""
        r = self.robot
        Q, valid, ls, res, cont = parts
        if not len(Q):
            return parts
        given = targets.free_columns(r, targets.initial_values(r, len(Q), free))  # (N, n_free)
        Q = np.array(Q)
        pos = list(r.free)
        Q[:, :, pos] = np.where(valid[:, :, None], given[:, None, :], Q[:, :, pos])
        if limits:
            inside = ((given >= r.lower[pos]) & (given <= r.upper[pos])).all(axis=1)
            valid = valid & inside[:, None]
        return Q, valid, ls, res, cont

    def _free_as_given_one(self, found, free, limits, exact_only):
        """_free_as_given of one target's rows (``rows``' layout: exact rows, or (q, residual, ls,
        continuum)) on scalars: the batch form's (1, K, n) arrays, masks and fancy indexing cost ~25 us
        a call, five times panda's C solve (docs/design.md section 14 item 6).  Free values that are not
        each one finite real number take the batch form, which raises the documented error for them."""
        given = _plain_free(free, len(self.robot.free))
        if given is None:
            return _unpack(self._free_as_given(_packed(found, exact_only), free, limits), exact_only)
        columns = self._free_limits()
        inside = not limits or all(lo <= v <= hi for (_, lo, hi), v in zip(columns, given))
        keep = slice(None) if inside else slice(0)
        if exact_only:
            return _with_free(np.array(found, dtype=float)[keep], columns, given)
        q, res, ls, cont = found
        return (_with_free(np.array(q)[keep], columns, given), np.array(res)[keep],
                np.array(ls, dtype=bool)[keep], np.array(cont, dtype=bool)[keep])

    def _free_limits(self):
        """[(column, lower, upper)] of the free joints as Python numbers, computed once per module."""
        if self._free_columns is None:
            r = self.robot
            self._free_columns = [(int(p), float(r.lower[p]), float(r.upper[p])) for p in r.free]
        return self._free_columns

    def _native_batch(self, Ts, free, limits):
        """solve_batch_info on the C chain (it checks the targets itself), or None when there is none or
        the targets' shape is not the target's (the Python path then raises the error)."""
        native = self.native_chain()
        if native is None:
            return None
        from ikcompiler.codegen.csource import block_c_source

        native.bind_block(lambda: block_c_source(self._ns))  # built on the first batch (section 14)
        Ts = np.asarray(Ts, dtype=float)
        shape = native.target_shape
        if Ts.ndim < len(shape) or Ts.shape[Ts.ndim - len(shape):] != shape:
            return None
        raw = Ts.reshape((-1,) + shape)
        init = targets.initial_values(self.robot, len(raw), free)
        from subproblems.native import PYTHON

        parts = []
        for i in range(0, len(raw), NATIVE_CHUNK):
            free_values = targets.free_columns(self.robot, init[i:i + NATIVE_CHUNK])
            part, code = native.many(raw[i:i + NATIVE_CHUNK], free_values, limits)
            idx = np.nonzero(code == PYTHON)[0]  # invalid targets (code INVALID) keep their empty slots
            for j in range(0, len(idx), CHUNK):
                sub = idx[j:j + CHUNK]
                goals, Td, reasons = targets.check_targets(self.robot, raw[i + sub])
                done = self.handed_back(goals, Td, init[i + sub], limits)
                _scatter(part, sub, targets.without_invalid(done, reasons))
            parts.append(part)
        return _joined(parts) if parts else self._empty()

    def _free_ends_batch(self, goals, Td, init, reasons, limits):
        """solve_batch_info of checked goals on the C elimination of the six solved joints; the targets
        it cannot settle on the Python path (reference.general6_rows)."""
        fe = self.free_ends_native()
        parts = []
        for i in range(0, len(goals), NATIVE_CHUNK):
            sl = slice(i, i + NATIVE_CHUNK)
            part, redo = fe.many(goals[sl], init[sl], limits)
            idx = np.nonzero(redo & (reasons[sl] == ""))[0]
            for j in range(0, len(idx), CHUNK):
                sub = idx[j:j + CHUNK] + i
                _scatter(part, sub - i, self.python_chunk(goals[sub], Td[sub], init[sub], limits))
            parts.append(targets.without_invalid(part, reasons[sl]))
        return _joined(parts) if parts else self._empty()

    def _empty(self):
        n, K = len(self.robot.joint_names), self.robot.slots
        empty = np.zeros((0, K), bool)
        return np.zeros((0, K, n)), empty, empty, np.zeros((0, K)), empty

    def solve_batch(self, Ts, *free, limits=True):
        """Exact solutions of N targets: Q (N, K, n) and valid (N, K)."""
        Q, valid, ls, _, _ = self._batch(Ts, self._free_in(free), limits, flags=False)
        return self._out(Q, free), valid & ~ls

    # -- the public API of one target -------------------------------------------------------------

    def solve(self, T, *free, limits=True, aliases=False, q_seed=None, weights=None):
        """Every exact solution of one target inside the joint limits, one row each in JOINT_NAMES order;
        (0, n) if unreachable.  ``limits=False`` also returns solutions outside the limits.

        ``aliases=True``: a revolute joint whose range exceeds 2 pi gives one row per value of the angle
        inside its limits (every combination; with ``limits=False`` rows are as solved).  ``q_seed``:
        rows sorted by their distance to q_seed (radians; prismatic joints in units of SCALE; times the
        optional per-joint ``weights``; wrapped to [-pi, pi] only with ``limits=False``); with limits,
        without aliases, each wide-range revolute value is the alias nearest the seed.
        """
        q = self.rows(T, self._free_in(free), limits, exact_only=True)
        if aliases or q_seed is not None:
            q_seed, weights = self._seed_in(q_seed, weights)
            q = selection.select(self.robot, q, np.ones(len(q), dtype=bool), limits, aliases, q_seed,
                                 weights)[0]
        return self._out(q, free)

    def solve_info(self, T, *free, limits=True, aliases=False, q_seed=None, weights=None):
        """Every candidate of one target with residuals and flags: a SolveInfo.

        ``q, residual, ls, continuum`` per row (exact rows first); ``sigma_min`` per row (the smallest
        singular value of the Jacobian with its length rows divided by SCALE: near 0 at a singular
        configuration); ``excluded``: with ``limits`` (the default) the solutions that the joint limits
        leave out, each with the joints outside their limits.  ``aliases`` and ``q_seed`` / ``weights`` as
        in ``solve``.
        """
        given, free = free, self._free_in(free)
        found = self.rows(T, free, limits)
        unlimited = self.rows(T, free, False) if limits else None
        q_seed, weights = self._seed_in(q_seed, weights)
        return self._info_out(selection.info(self.robot, found, unlimited, limits, aliases, q_seed, weights),
                              given)

    def nearest(self, T, q_seed, *free, limits=True, aliases=True, weights=None):
        """The exact solution closest to q_seed (see solve), or None when there is none.

        With ``aliases`` (the default here) every in-limit alias of a wide-range joint competes.
        """
        q = self.solve(T, *free, limits=limits, aliases=aliases, q_seed=q_seed, weights=weights)
        return q[0] if len(q) else None

    def fk(self, q):
        """Tool pose (4x4) for joint values q in JOINT_NAMES order (exactly len(JOINT_NAMES) of them)."""
        sp = self.robot.speed
        if sp is not None and np.shape(q) == sp.shape:
            q = np.asarray(q, dtype=float) * sp
        return self.robot.fk(q)

    # -- folded slides: the chain solves for speed * q, the API takes and returns q -----------------
    # (ikcompiler/model/fold.py; docs/design.md section 2).  Without folded slides these are identities.

    def _out(self, Q, given=()):
        """Rows (..., n) solved for, as returned: each folded slide's value over its speed.  ``given``:
        the free values as the user gave them; a free slide's column that holds the given value (times
        its speed, _free_as_given) returns it bit for bit (f * s / s need not be f)."""
        sp = self.robot.speed
        if sp is None:
            return Q
        out = Q / sp
        if len(given) == len(self.robot.free):
            for f, p in zip(given, self.robot.free):
                if sp[p] != 1.0:
                    f = np.asarray(f, dtype=float)
                    f = f.reshape(f.shape + (1,) * (Q.ndim - 1 - f.ndim))  # (N,) -> (N, 1) for (N, K, n)
                    out[..., p] = np.where(Q[..., p] == f * sp[p], f, out[..., p])
        return out

    def _free_in(self, free):
        """Free joint values as the chain solves for them (a wrong count is left to the checks)."""
        r = self.robot
        if r.speed is None or len(free) != len(r.free):
            return free
        return tuple(f if r.speed[p] == 1.0 else np.asarray(f, dtype=float) * r.speed[p]
                     for f, p in zip(free, r.free))

    def _seed_in(self, q_seed, weights):
        """A seed and weights in the solved values: the same distances as in the returned ones."""
        sp = self.robot.speed
        if sp is None or q_seed is None:
            return q_seed, weights
        w = np.ones(len(sp)) if weights is None else np.asarray(weights, dtype=float)
        return np.asarray(q_seed, dtype=float) * sp, w / sp

    def _info_out(self, info, given=()):
        """A SolveInfo as returned; sigma_min of the Jacobian in the returned values."""
        r = self.robot
        if r.speed is None:
            return info
        from subproblems import select as _sel

        q = self._out(info.q, given)
        A = r.A.copy()
        A[:, :len(r.speed)] *= r.speed  # d th / d q of the returned values (a virtual roll's column kept)
        sig = _sel.sigma_min(q, twists=r.twists, A=A, b=r.B, home=r.home, scale=r.scale, target=r.target)
        excluded = tuple(e._replace(q=self._out(e.q, given)) for e in info.excluded)
        return info._replace(q=q, sigma_min=sig, excluded=excluded)

    def invalid_reasons(self, Ts):
        """{index: reason} of the targets that are not valid (NaN or infinity, a bottom row not [0, 0, 0, 1],
        a rotation that is not one to 1e-6); ``solve_batch`` and ``solve_batch_info`` leave their slots
        empty (all False) instead of failing the batch.  A wrong shape raises."""
        return targets.invalid_reasons(self.robot, Ts)


def _scatter(parts, idx, done):
    for whole, part in zip(parts, done):
        whole[idx] = part


def _joined(parts):
    return tuple(np.concatenate(x) for x in zip(*parts))


_REAL = (int, float, np.integer, np.floating)


def _plain_free(free, count):
    """The free values as floats when there are ``count`` of them and each is one finite real number
    (what targets.initial_values takes without a question), else None."""
    if len(free) != count:
        return None
    out = []
    for v in free:
        if not isinstance(v, _REAL):
            return None
        try:
            f = float(v)
        except (OverflowError, ValueError):
            return None
        if not math.isfinite(f):
            return None
        out.append(f)
    return out


def _with_free(q, columns, given):
    """Rows q (k, n), copied already, with each free joint's column set to its given value."""
    for (p, _, _), v in zip(columns, given):
        q[:, p] = v
    return q


def _packed(found, exact_only):
    """One target's rows as _unpack returns them, back in the batch layout (N = 1)."""
    if exact_only:
        q = np.asarray(found, dtype=float)
        none = np.zeros((1, len(q)), dtype=bool)
        return q[None], ~none, none, np.zeros((1, len(q))), none
    q, res, ls, cont = (np.asarray(x) for x in found)
    return (q[None], np.ones((1, len(q)), dtype=bool), np.asarray(ls, dtype=bool)[None], res[None],
            np.asarray(cont, dtype=bool)[None])


def _unpack(parts, exact_only):
    Q, valid, ls, res, cont = parts
    v = valid[0]
    if exact_only:
        return Q[0][v & ~ls[0]]
    return Q[0][v], res[0][v], ls[0][v], cont[0][v]
