"""Which solver a 6R pose chain without a closed form gets: the 1-D search or the general elimination.

The general 6R elimination (subproblems.general6) is complete on every geometry it accepts; the 1-D
search (one joint gridded, a closed-form chain for the other five, in C where the native backend
builds) is complete only on some arms but, where it is, it can be several times faster (rtb-data's
abb_irb140: 0.44 ms against 44 ms a pose before the doubtful-pose fix).  Issue 10 item 1: "the 1-D
search stays only where it is measured faster and complete".  So it is measured, at compile time, on
a fixed sample of poses (docs/design.md section 5, "General 6R"; docs/general6.md, "When it is used"):

* complete: every sampled joint vector is among the 1-D search's exact rows (1e-6 rad, the
  verification's tolerance) and so is every row the elimination returns for the same poses;
* faster: its ``solve_batch`` on the sample takes no more process CPU time than the elimination's
  (both warm: the native library is built, and cached, before the timed call).

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


@dataclass(frozen=True)
class Verdict:
    """The measured comparison on the sample: keep_search True when the 1-D search is complete and
    no slower; note says so with the numbers."""

    keep_search: bool
    note: str


def sample_joints(chain, count: int = SAMPLE_POSES, seed: int = SAMPLE_SEED) -> np.ndarray:
    """Joint vectors inside the limits (revolute ranges clipped to one turn, prismatic ones to the
    robot size either side of zero), fixed seed."""
    reach = np.array([math.pi if k == "R" else chain.scale for k in chain.joint_types])
    lo = np.maximum(np.asarray(chain.lower, float), -reach)
    hi = np.minimum(np.asarray(chain.upper, float), reach)
    return np.random.default_rng(seed).uniform(lo, hi, size=(count, len(lo)))


def _gap(rows: np.ndarray, q: np.ndarray, chain) -> float:
    """Smallest joint distance from q to the rows (verify's: revolute modulo 2 pi, prismatic over the
    size); inf without rows."""
    if not len(rows):
        return math.inf
    return float(joint_distance(rows, q, chain.joint_types, chain.scale).min())


def _cpu(call):
    t = time.process_time()
    out = call()
    return out, time.process_time() - t


def compare(chain, search_module, solver, method: str) -> Verdict:
    """Measure the 1-D search module (``search_module``, ``method`` e.g. '1d-search') against the
    general 6R ``solver`` on the sample poses of ``chain``: first on FIRST of them, and on the rest
    only when the 1-D search is complete and faster there (a slow search, 26 ms a pose on a general
    TTRRRR arm, is not run 64 times)."""
    Q = sample_joints(chain)
    T = chain.fk_batch(Q)
    search_module.solve_batch(T[:1], limits=False)  # builds (or loads) the native library
    solver.solve_batch(T[:1])
    tally = np.zeros(4)  # poses, sampled vectors recovered, general rows, rows covered
    spent = np.zeros(2)  # process CPU: search, general
    for part in (slice(0, FIRST), slice(FIRST, len(Q))):
        (S, V), t_search = _cpu(lambda part=part: search_module.solve_batch(T[part], limits=False))
        b, t_general = _cpu(lambda part=part: solver.solve_batch(T[part]))
        spent += (t_search, t_general)
        q = Q[part]
        rows = [b.Q[k][b.valid[k]] for k in range(len(q))]
        tally[0] += len(q)
        tally[1] += sum(_gap(S[k][V[k]], q[k], chain) < SAME for k in range(len(q)))
        tally[2] += sum(len(r) for r in rows)
        tally[3] += sum(_gap(S[k][V[k]], r, chain) < SAME for k in range(len(q)) for r in rows[k])
        complete = tally[1] == tally[0] and tally[3] == tally[2]
        faster = spent[0] <= spent[1]
        if not (complete and faster):
            break
    n, hit, total, covered = (int(x) for x in tally[:4])
    numbers = (
        f"on {n} sampled poses (seed {SAMPLE_SEED}) the {method} recovered {hit}/{n} sampled joint vectors "
        f"and {covered}/{total} general-6r rows, {spent[0] / n * 1e3:.3f} ms/pose against "
        f"{spent[1] / n * 1e3:.3f} ms/pose for general-6r (process CPU, solve_batch)"
    )
    if complete and faster:
        return Verdict(True, f"{method} kept (complete and faster on the sample): {numbers}")
    why = "incomplete" if not complete else "slower"
    return Verdict(False, f"general 6R elimination chosen over the {method} ({why} on the sample): {numbers}")
