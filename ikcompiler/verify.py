"""Round-trip and completeness checks of a compiled solver on random joint values: a check that can fail.

Sample joint values inside the limits (a quarter of them snapped to the special angles 0, +-pi/2, pi),
compute their poses with the *chain's own* forward kinematics, solve, and count, every number
recomputed here from forward kinematics and the limits (nothing is taken from the solver's report):

* recovered: the sampled vector is among the exact solutions, to :data:`SAME_ANGLE` rad (revolute,
  modulo 2 pi) and :data:`SAME_LENGTH` of the robot's size (prismatic); at a singular sampled vector
  (the Jacobian shown rank-deficient) to 100 times that, counted apart as "at a double root": a double
  root is only located to about the square root of the precision;
* wrong: an exact row whose FK misses the target by more than :data:`WRONG` (relative position, or
  rotation in Frobenius norm);
* imprecise: an exact row above the module's precision contract (``TOLERANCE``, 1e-12) but not wrong;
* outside limits: a returned row with a value outside its joint's limits *as returned* (no modulo);
  non-canonical: a revolute value that is not its representative in (-pi, pi] (a value within
  ``subproblems.fast.PI_SNAP`` above -pi counts as -pi) although that representative lies inside the
  limits, or a free joint's value that is not the one given;
* duplicate: two returned rows of one pose closer than the recovery tolerance (as returned, modulo 2 pi);
* self-motion: not recovered, but a returned row is flagged ``continuum`` and the Jacobian at the
  sampled vector is rank-deficient (smallest normalised singular value below :data:`SINGULAR`);
  "unsolved" when no exact representative came back;
* missed: the rest.

:attr:`VerifyReport.ok` holds when nothing is wrong, imprecise, outside the limits, non-canonical or
duplicate, the batch and single-pose paths agree, and at most ``allow_missed`` poses are missed
(default 0); ``ikc verify`` exits non-zero otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from subproblems import tolerances as tol
from subproblems.angles import wrap_array
from subproblems.fast import PI_SNAP
from subproblems.plan_runtime import target_error

SPECIAL = np.array([0.0, math.pi / 2, -math.pi / 2, math.pi])
SAME_ANGLE = tol.VERIFY_SAME_ANGLE  # rad: a revolute value of a recovered sample (subproblems/tolerances.py)
SAME_LENGTH = tol.VERIFY_SAME_LENGTH  # of the robot's size: a prismatic value of a recovered sample
SINGULAR_FACTOR = 100.0  # tolerance factor at a singular sampled vector (a double root)
SINGULAR = tol.VERIFY_SINGULAR  # the normalised Jacobian's smallest singular value below which: singular
WRONG = tol.VERIFY_WRONG  # relative error of an exact row above which it is wrong


@dataclass
class VerifyReport:
    robot: str
    method: str
    poses: int
    solutions: int
    recovered: int
    wrong: int
    missed: int
    self_motion: int
    self_motion_unsolved: int
    double_root: int  # recovered only to SINGULAR_FACTOR times the tolerance, at a singular sampled vector
    max_error: float
    median_error: float
    batch_mismatch: int
    scalar_checked: int
    imprecise: int = 0  # exact rows above the module's TOLERANCE (not wrong)
    outside_limits: int = 0  # returned rows with a value outside its limits as returned
    non_canonical: int = 0  # returned rows with a revolute value not in (-pi, pi] where it could be
    duplicates: int = 0  # pairs of returned rows of one pose closer than the recovery tolerance
    allow_missed: int = 0  # missed poses tolerated by ok

    @property
    def ok(self) -> bool:
        return (
            self.wrong == 0
            and self.imprecise == 0
            and self.outside_limits == 0
            and self.non_canonical == 0
            and self.duplicates == 0
            and self.batch_mismatch == 0
            and self.missed <= self.allow_missed
        )

    def text(self) -> str:
        rate = self.recovered / self.poses if self.poses else 0.0
        return (
            f"{self.robot}: method {self.method}\n"
            f"  poses {self.poses}  solutions {self.solutions}  recovered {self.recovered} ({rate:.4%}; "
            f"{self.double_root} at a double root)  "
            f"missed {self.missed} (allowed {self.allow_missed})  at a self-motion {self.self_motion} "
            f"(of which {self.self_motion_unsolved} with no exact representative)\n"
            f"  wrong {self.wrong}  imprecise {self.imprecise}  outside limits {self.outside_limits}  "
            f"non-canonical {self.non_canonical}  duplicate {self.duplicates}\n"
            f"  error of returned solutions (relative to robot size): max {self.max_error:.2e}, "
            f"median {self.median_error:.2e}\n"
            f"  single-pose vs batch: {self.scalar_checked} poses compared, {self.batch_mismatch} differ\n"
            f"  {'OK' if self.ok else 'FAILED'}"
        )


def sample_configurations(chain, count: int, seed: int = 0, special: float = 0.25, limits=None) -> np.ndarray:
    """Joint values inside the limits; each revolute value is a special angle with probability ``special``.

    ``limits`` (lower, upper): narrower limits to sample in, where a module imposes them (folded slides
    intersect their members' limits into the master's: ikcompiler/model/fold.py)."""
    rng = np.random.default_rng(seed)
    lower, upper = chain.lower, chain.upper
    if limits is not None:
        lower, upper = np.maximum(lower, limits[0]), np.minimum(upper, limits[1])
    lo = np.where(np.isfinite(lower), lower, -math.pi)
    hi = np.where(np.isfinite(upper), upper, math.pi)
    kinds = [chain.joints[i].kind for i in chain.independent]
    for c, k in enumerate(kinds):
        if k == "T" and not (np.isfinite(lower[c]) and np.isfinite(upper[c])):
            lo[c], hi[c] = -chain.scale, chain.scale
    Q = rng.uniform(lo, hi, size=(count, chain.dof))
    snap = rng.random(size=Q.shape) < special
    pick = SPECIAL[rng.integers(0, len(SPECIAL), size=Q.shape)]
    for c, k in enumerate(kinds):
        if k == "R":
            ok = snap[:, c] & (pick[:, c] >= lo[c]) & (pick[:, c] <= hi[c])
            Q[ok, c] = pick[ok, c]
    return Q


def _same(a, b, kinds) -> np.ndarray:
    """Largest joint distance of rows a from b, revolute values modulo 2 pi."""
    d = a - b
    for c, k in enumerate(kinds):
        if k == "R":
            d[..., c] = np.remainder(d[..., c] + math.pi, 2 * math.pi) - math.pi
    return np.abs(d).max(axis=-1)


def joint_distance(a, b, kinds, scale: float) -> np.ndarray:
    """Largest joint distance of rows a from b: revolute values modulo 2 pi in rad, prismatic ones
    relative to the robot's size ``scale`` (what "the same joint vector" means in the tests)."""
    d = np.abs(np.asarray(a, dtype=float) - np.asarray(b, dtype=float))
    for c, k in enumerate(kinds):
        if k == "R":
            d[..., c] = np.abs(np.remainder(d[..., c] + math.pi, 2 * math.pi) - math.pi)
        else:
            d[..., c] /= scale
    return d.max(axis=-1)


def _recovery_distance(a, b, kinds, scale: float) -> np.ndarray:
    """Distance of rows a from b in units of the recovery tolerance: revolute values modulo 2 pi over
    SAME_ANGLE, prismatic ones over SAME_LENGTH * scale; <= 1 means the same joint vector."""
    d = np.abs(np.asarray(a, dtype=float) - b)
    for c, k in enumerate(kinds):
        if k == "R":
            d[..., c] = np.abs(np.remainder(d[..., c] + math.pi, 2 * math.pi) - math.pi) / SAME_ANGLE
        else:
            d[..., c] /= SAME_LENGTH * scale
    return d.max(axis=-1)


VERIFY_CHUNK = 500


def _singular(chain, q, free_cols, target: str = "pose") -> bool:
    """Whether the Jacobian of the solved joints is rank-deficient at q (body Jacobian, linear rows in
    units of the robot's size, free joints' columns left out, the target's rows only).

    A position+direction target constrains the tool origin and its z axis: a turn about the tool's own
    z axis (body row 5) changes neither, so its rows are the linear ones and the body turns about x
    and y.  With all six rows a 5-joint chain looked full-rank at its self-motions (shadow_thumb at
    q2 = q3 = 0: three parallel z axes reach a point of the plane, sigma 7e-18 on the five rows, 0.09
    on six)."""
    J = np.delete(chain.body_jacobian(q), list(free_cols), axis=1)
    J[:3] /= chain.scale
    if target == "position":
        J = J[:3]
    elif target == "orientation":
        J = J[3:]
    elif target == "position+direction":
        J = J[:5]
    sv = np.linalg.svd(J, compute_uv=False)
    rank_needed = min(J.shape)
    return bool(len(sv) < rank_needed or sv[:rank_needed].min() < SINGULAR)


def _errors(chain, target: str, Gs, G) -> np.ndarray:
    """Relative errors of poses Gs against the sampled pose G: max(|dp| / size, |dR|_F) for the target
    (the runtime's measure, ``plan_runtime.target_error``, over the size)."""
    return target_error(Gs, np.asarray(G)[None], target, chain.scale) / chain.scale


def _limit_checks(rows, kinds, lower, upper, given=None):
    """(outside, non_canonical) counts of returned rows, checked as returned.  ``given``: {column: value}
    of the free joints, whose value is the user's as given (never an alias): one that differs counts as
    non-canonical."""
    given = given or {}
    outside = ((rows < lower) | (rows > upper)).any(axis=1)
    non_canonical = np.zeros(len(rows), dtype=bool)
    for c, k in enumerate(kinds):
        if c in given:
            non_canonical |= rows[:, c] != given[c]
            continue
        if k != "R":
            continue
        v = rows[:, c]
        w = wrap_array(v)
        w = np.where(w <= -math.pi + PI_SNAP, math.pi, w)  # (-pi, pi]; a value at -pi is pi
        moved = (v <= -math.pi + PI_SNAP) | (v > math.pi)  # not in (-pi, pi] as returned
        non_canonical |= moved & (w >= lower[c]) & (w <= upper[c])
    return int(outside.sum()), int((non_canonical & ~outside).sum())


def verify(
    chain, module, samples: int = 200, seed: int = 0, scalar_checks: int = 20, progress=None, special=0.25,
    allow_missed: int = 0,
) -> VerifyReport:
    """Sample, solve and count (see the module docstring); ``progress(done, total)`` after each chunk."""
    Q = sample_configurations(chain, samples, seed, special, (module.LOWER, module.UPPER))
    kinds = [chain.joints[i].kind for i in chain.independent]
    G = chain.fk_batch(Q)
    targets = {"position": G[:, :3, 3], "orientation": G[:, :3, :3]}.get(module.TARGET, G)
    free_pos = [chain.independent_names.index(f) for f in module.FREE_JOINTS]
    free = [Q[:, p] for p in free_pos]
    parts = []
    for start in range(0, samples, VERIFY_CHUNK):
        stop = min(samples, start + VERIFY_CHUNK)
        parts.append(module.solve_batch_info(targets[start:stop], *[f[start:stop] for f in free]))
        if progress is not None:
            progress(stop, samples)
    S, filled, ls, _, cont = (np.concatenate(x) for x in zip(*parts))
    valid = filled & ~ls
    scale = chain.scale
    lower, upper = np.asarray(module.LOWER, dtype=float), np.asarray(module.UPPER, dtype=float)
    errs, recovered, solutions, self_motion, unsolved, double_root = [], 0, 0, 0, 0, 0
    wrong = imprecise = outside = non_canonical = duplicates = 0
    for i in range(samples):
        o, n = _limit_checks(S[i][filled[i]], kinds, lower, upper, {p: Q[i, p] for p in free_pos})
        outside, non_canonical = outside + o, non_canonical + n
        sols = S[i][valid[i]]
        solutions += len(sols)
        singular = None
        if len(sols) == 0:
            if (cont[i] & filled[i]).any() and _singular(chain, Q[i], free_pos, module.TARGET):
                self_motion += 1
                unsolved += 1
            continue
        e = _errors(chain, module.TARGET, chain.fk_batch(sols), G[i])
        errs.extend(e.tolist())
        wrong += int((e > WRONG).sum())
        imprecise += int(((e > module.TOLERANCE) & (e <= WRONG)).sum())
        for a in range(1, len(sols)):
            duplicates += int((_recovery_distance(sols[:a], sols[a], kinds, scale) <= 1.0).sum())
        nearest = _recovery_distance(sols, Q[i], kinds, scale).min()
        if nearest <= 1.0:
            recovered += 1
            continue
        singular = _singular(chain, Q[i], free_pos, module.TARGET)
        if nearest <= SINGULAR_FACTOR and singular:
            recovered += 1
            double_root += 1
        elif (cont[i] & valid[i]).any() and singular:
            self_motion += 1
    mismatch = 0
    n_check = min(scalar_checks, samples)
    for i in range(n_check):
        single = module.solve(targets[i], *[f[i] for f in free])
        batch = S[i][valid[i]]
        if len(single) != len(batch):
            mismatch += 1
            continue
        for row in single:
            if not (np.abs(batch - row).max(axis=1) <= 1e-9 * max(1.0, scale)).any():  # as returned
                mismatch += 1
                break
    errs = np.array(errs) if errs else np.zeros(1)
    return VerifyReport(
        chain.name,
        module.METHOD,
        samples,
        solutions,
        recovered,
        wrong,
        samples - recovered - self_motion,
        self_motion,
        unsolved,
        double_root,
        float(errs.max()),
        float(np.median(errs)),
        mismatch,
        n_check,
        imprecise=imprecise,
        outside_limits=outside,
        non_canonical=non_canonical,
        duplicates=duplicates,
        allow_missed=allow_missed,
    )
