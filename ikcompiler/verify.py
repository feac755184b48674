"""Round-trip and completeness checks of a compiled solver on random joint values.

Sample joint values inside the limits (a quarter of them snapped to the special angles 0, +-pi/2, pi),
compute their poses with the *chain's own* forward kinematics, solve, and count: poses, solutions,
recovered (the sampled vector is among the solutions, to 1e-6 of the robot's size; at a singular
sampled vector, to 1e-4: a double root is only located to about the square root of the tolerance, and
every joint vector that close reproduces the pose as well — those are counted apart as "at a double
root"), wrong (a returned solution whose FK misses the target by more than the tolerance),
self-motion (not recovered, but the pose is singular with a
continuum of solutions, flagged; "unsolved" when no exact representative came back), missed (the
rest).  The batch path is checked against the single-pose path on a subset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SPECIAL = np.array([0.0, math.pi / 2, -math.pi / 2, math.pi])
SAME = 1e-6  # joint distance (relative to the robot's size, at least 1) of a recovered sample
SAME_SINGULAR = 1e-4  # the same at a singular sampled vector (a double root)
SINGULAR = 1e-7  # smallest singular value of the normalised Jacobian below which a vector is singular


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
    double_root: int  # recovered only to SAME_SINGULAR, at a singular sampled vector
    max_error: float
    median_error: float
    batch_mismatch: int
    scalar_checked: int

    @property
    def ok(self) -> bool:
        return self.wrong == 0 and self.batch_mismatch == 0

    def text(self) -> str:
        rate = self.recovered / self.poses if self.poses else 0.0
        return (
            f"{self.robot}: method {self.method}\n"
            f"  poses {self.poses}  solutions {self.solutions}  recovered {self.recovered} ({rate:.4%}; "
            f"{self.double_root} at a double root)  "
            f"wrong {self.wrong}  missed {self.missed}  at a self-motion {self.self_motion} "
            f"(of which {self.self_motion_unsolved} with no exact representative)\n"
            f"  error of returned solutions (relative to robot size): max {self.max_error:.2e}, "
            f"median {self.median_error:.2e}\n"
            f"  single-pose vs batch: {self.scalar_checked} poses compared, {self.batch_mismatch} differ"
        )


def sample_configurations(chain, count: int, seed: int = 0, special: float = 0.25) -> np.ndarray:
    """Joint values inside the limits; each revolute value is a special angle with probability ``special``."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(chain.lower), chain.lower, -math.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, math.pi)
    kinds = [chain.joints[i].kind for i in chain.independent]
    for c, k in enumerate(kinds):
        if k == "T" and not (np.isfinite(chain.lower[c]) and np.isfinite(chain.upper[c])):
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
    d = a - b
    for c, k in enumerate(kinds):
        if k == "R":
            d[..., c] = np.remainder(d[..., c] + math.pi, 2 * math.pi) - math.pi
    return np.abs(d).max(axis=-1)


VERIFY_CHUNK = 500


def _singular(chain, q, free_cols) -> bool:
    """Whether q is a singular configuration of the solved joints (body Jacobian, linear rows in units
    of the robot's size, free joints' columns left out)."""
    J = np.delete(chain.body_jacobian(q), list(free_cols), axis=1)
    J[:3] /= chain.scale
    return bool(np.linalg.svd(J, compute_uv=False).min() < SINGULAR)


def verify(
    chain, module, samples: int = 200, seed: int = 0, scalar_checks: int = 20, progress=None, special=0.25
) -> VerifyReport:
    """Sample, solve and count (see the module docstring); ``progress(done, total)`` after each chunk."""
    Q = sample_configurations(chain, samples, seed, special)
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
    errs, wrong, recovered, solutions, self_motion, unsolved, double_root = [], 0, 0, 0, 0, 0, 0
    tol = module.TOLERANCE * scale
    for i in range(samples):
        sols = S[i][valid[i]]
        solutions += len(sols)
        if len(sols) == 0:
            if (cont[i] & filled[i]).any():
                self_motion += 1
                unsolved += 1
            continue
        Gs = chain.fk_batch(sols)
        if module.TARGET == "position":
            e = np.linalg.norm(Gs[:, :3, 3] - G[i, :3, 3], axis=1)
        elif module.TARGET == "orientation":
            e = scale * np.abs(Gs[:, :3, :3] - G[i, :3, :3]).max(axis=(1, 2))
        elif module.TARGET == "position+direction":
            e = np.maximum(
                np.linalg.norm(Gs[:, :3, 3] - G[i, :3, 3], axis=1),
                scale * np.abs(Gs[:, :3, 2] - G[i, :3, 2]).max(axis=1),
            )
        else:
            e = np.maximum(
                np.linalg.norm(Gs[:, :3, 3] - G[i, :3, 3], axis=1),
                scale * np.abs(Gs[:, :3, :3] - G[i, :3, :3]).max(axis=(1, 2)),
            )
        errs.extend((e / scale).tolist())
        wrong += int((e > tol).sum())
        nearest = _same(sols, Q[i], kinds).min()
        if nearest <= SAME * max(1.0, scale):
            recovered += 1
        elif nearest <= SAME_SINGULAR * max(1.0, scale) and _singular(chain, Q[i], free_pos):
            recovered += 1
            double_root += 1
        elif (cont[i] & valid[i]).any():
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
            if not (_same(batch, row, kinds) <= 1e-9 * max(1.0, scale)).any():
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
    )
