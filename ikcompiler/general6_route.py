"""Which solver a 6R pose chain without a closed form gets: the 1-D search or the general elimination.

The general 6R elimination (subproblems.general6) is complete on every geometry it accepts; the 1-D
search (one joint gridded, a closed-form chain for the other five, in C where the native backend
builds) is complete only on some arms but, where it is, it can be several times faster (rtb-data's
abb_irb140: 0.44 ms against 44 ms a pose before the doubtful-pose fix).  Issue 10 item 1: "the 1-D
search stays only where it is measured faster and complete".  So it is measured, at compile time, on
a fixed sample of poses (docs/design.md section 5, "General 6R"; docs/general6.md, "When it is used"):

* complete: every sampled joint vector is among the 1-D search's exact rows (1e-6 rad, the
  verification's tolerance) and so is every row the elimination returns for the same poses;
* faster: its module's ``solve_batch`` on the sample takes no more process CPU time than the general-6r
  module's (both warm: their native libraries are built, and cached, before the timed call; each
  runs the path it will run for the user, the C chain where a compiler exists).

The decision and its numbers go into the plan's notes (``ikc explain``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ikcompiler.verify import joint_distance
from subproblems import tolerances as _tol

SAMPLE_POSES = 64
SAMPLE_SEED = 140
FIRST = 8  # poses measured first; the rest only if the 1-D search is complete and faster on them
SAME = _tol.VERIFY_SAME_ANGLE  # a row is "among" the other's rows (verify's tolerance)
SPECIAL = (0.0, 0.5 * math.pi, -0.5 * math.pi, math.pi)
SPECIAL_SHARE = 0.25  # revolute values drawn from SPECIAL (verify.sample_configurations' default share)


@dataclass(frozen=True)
class Verdict:
    """The measured comparison on the sample: keep_search True when the 1-D search is complete and
    no slower; note says so with the numbers."""

    keep_search: bool
    note: str


def sample_joints(chain, count: int = SAMPLE_POSES, seed: int = SAMPLE_SEED,
                  special: float = SPECIAL_SHARE) -> np.ndarray:
    """Joint vectors inside the limits (revolute ranges clipped to one turn, prismatic ones to the
    robot size either side of zero), fixed seed; a share ``special`` of the revolute values at 0, +-pi/2
    or pi where the limits allow (home and taught poses: where the general 6R elimination's doubtful
    targets and the search's misses are, as in ``ikc verify``'s sample)."""
    reach = np.array([math.pi if k == "R" else chain.scale for k in chain.joint_types])
    lo = np.maximum(np.asarray(chain.lower, float), -reach)
    hi = np.minimum(np.asarray(chain.upper, float), reach)
    rng = np.random.default_rng(seed)
    Q = rng.uniform(lo, hi, size=(count, len(lo)))
    pick = np.array(SPECIAL)[rng.integers(0, len(SPECIAL), size=Q.shape)]
    snap = (rng.random(Q.shape) < special) & (pick >= lo) & (pick <= hi)
    snap &= np.array([k == "R" for k in chain.joint_types])
    return np.where(snap, pick, Q)


def _found(rows: np.ndarray, wanted: np.ndarray, chain) -> int:
    """How many of the rows ``wanted`` (k, n) have one of ``rows`` (m, n) within SAME (verify's joint
    distance: revolute modulo 2 pi, prismatic over the size); all pairs at once."""
    if not len(wanted) or not len(rows):
        return 0
    d = joint_distance(rows[:, None, :], wanted[None, :, :], chain.joint_types, chain.scale)
    return int((d.min(axis=0) < SAME).sum())


def _cpu(call):
    t = time.process_time()
    out = call()
    return out, time.process_time() - t


def compare(chain, search_module, general_module, method: str, free=()) -> Verdict:
    """Measure the 1-D search module (``search_module``, ``method`` e.g. '1d-search') against the
    general-6r module ``general_module`` on the sample poses of ``chain``, each through its own
    ``solve_batch`` (limits off): the path each module runs, native where its C chain builds (the
    Python general6 is several times slower than the C elimination, and timing it kept rtb-data's
    abb_irb140 on its 1-D search).  Each side's completeness is counted against the other's rows and
    the sampled vectors: the search is kept when it is complete there and either faster or the
    elimination is not (abb_irb140 at wrist-singular special poses: the elimination's doubtful targets
    missed 21 of 1,000 ``ikc verify`` poses the search recovers).  First on FIRST poses, and on the
    rest only while the search is still the choice (a slow search, 26 ms a pose on a general TTRRRR
    arm, is not run 64 times); a search that misses a sampled vector gives general-6r without timing
    it (on the Jaco its one doubtful target of the first 8 took ~0.1 s of compile time).

    ``free``: chain indices of free joints (no couplings: chain and JOINT_NAMES agree), given their
    sampled values (a general-6r plan folded at its free joint, runtime/freefold.py)."""
    Q = sample_joints(chain)
    T = chain.fk_batch(Q)

    def solve(module, part):
        return module.solve_batch(T[part], *(Q[part, j] for j in free), limits=False)

    solve(search_module, slice(0, 1))  # builds (or loads) the native library
    warm = False
    n = hit = total = covered = g_hit = g_total = g_covered = 0
    spent = np.zeros(2)  # process CPU: search, general
    for part in (slice(0, FIRST), slice(FIRST, len(Q))):
        (S, V), t_search = _cpu(lambda part=part: solve(search_module, part))
        spent[0] += t_search
        q = Q[part]
        n += len(q)
        hit += sum(_found(S[k][V[k]], q[k:k + 1], chain) for k in range(len(q)))
        if hit < n:  # the search missed a sampled vector: general-6r, whatever its numbers
            numbers = (f"on {n} sampled poses (seed {SAMPLE_SEED}, {SPECIAL_SHARE:.0%} of the values "
                       "special) "
                       f"the {method} recovered {hit}/{n} sampled joint vectors, {spent[0] / n * 1e3:.3f} "
                       "ms/pose (process CPU, solve_batch; general-6r not timed)")
            return Verdict(False, f"general 6R elimination chosen over the {method} (incomplete on the "
                                  f"sample): {numbers}")
        if not warm:
            solve(general_module, slice(0, 1))  # its native library too
            warm = True
        (G, W), t_general = _cpu(lambda part=part: solve(general_module, part))
        spent[1] += t_general
        for k in range(len(q)):
            s_rows, g_rows = S[k][V[k]], G[k][W[k]]
            g_hit += _found(g_rows, q[k:k + 1], chain)
            total, g_total = total + len(g_rows), g_total + len(s_rows)
            covered += _found(s_rows, g_rows, chain)
            g_covered += _found(g_rows, s_rows, chain)
        complete = covered == total
        general_complete = g_hit == n and g_covered == g_total
        faster = spent[0] <= spent[1]
        keep = complete and (faster or not general_complete)
        if not keep:
            break
    numbers = (
        f"on {n} sampled poses (seed {SAMPLE_SEED}, {SPECIAL_SHARE:.0%} of the values special) the {method} "
        f"recovered {hit}/{n} sampled joint vectors and {covered}/{total} general-6r rows, general-6r "
        f"{g_hit}/{n} and {g_covered}/{g_total} {method} rows; {spent[0] / n * 1e3:.3f} ms/pose against "
        f"{spent[1] / n * 1e3:.3f} ms/pose for general-6r (process CPU, solve_batch)"
    )
    if keep:
        why = "complete and faster" if faster else "complete where general-6r is not"
        return Verdict(True, f"{method} kept ({why} on the sample): {numbers}")
    why = "incomplete" if not complete else "slower"
    return Verdict(False, f"general 6R elimination chosen over the {method} ({why} on the sample): {numbers}")
