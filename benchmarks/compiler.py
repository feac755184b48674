"""Speed of the generated solvers, side by side with EAIK on the same poses (issue 4, "Speed").

For every zoo robot (or those named with ``--robots``):

* compile time: median of a few ``compile_robot`` calls;
* single-pose ``solve``: median time per call over distinct reachable poses (FK of
  ``sample_configurations``), plus solution counts, recovery of the sampled joint vector and the worst
  pose error, all checked with our chain's FK;
* batch throughput of ``solve_batch`` in poses/s (10 000 poses, fewer for slow solvers: see ``--budget``);
* all on the module's default path: the native backend where the module's fast chain has a C
  translation (``NATIVE``; printed and built with the system C compiler on first use, into a fresh temporary
  ``IKC_CACHE`` for this run, and the one-off build timed apart from the Python compile), else the
  Python fast path where the plan has one, else the reference runtime;
* for modules with a fast path, the same timings again on the Python fast path (``NATIVE = False``)
  and on the reference runtime (``FAST_PATH = False``), same poses and budget: the speed-ups, whether
  the paths give the same solutions (native vs Python fast path, default path vs reference runtime),
  and the fraction of poses each hands on (native: to the Python path, ``_native_chain().many`` /
  ``.one``; Python fast path: to the reference runtime, its first stage ``_fast_leaves`` +
  ``subproblems.fast.finish_many``), counted untimed;
* the same figures for EAIK where it applies (revolute joints only, no coupled joints, at most 6
  unlocked joints; a 7R arm locks its free joint at one value for all poses).  EAIK is built from our
  chain's twists (axis directions H, axis points turned into offsets P, home rotation as the tool
  rotation) and runs in a subprocess per robot and stage, so an abort in its batch call is reported
  and does not end the run.

Then one closed-form robot's single-pose ``solve`` on its default (native or fast) path is profiled
(cProfile, top entries by own time).

Results: ``benchmarks/results/compiler.md`` (tables and notes) and ``benchmarks/results/compiler.json``.

Usage::

    .venv/bin/python benchmarks/compiler.py [--robots NAME ...] [--poses N] [--batch N] [--quick]
"""

from __future__ import annotations

import argparse
import contextlib
import cProfile
import datetime as _dt
import importlib.metadata as _md
import json
import math
import os
import platform
import pstats
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# Run as a script, this folder is first on sys.path: a sibling script named like one of the project's
# packages (benchmarks/subproblems.py) would shadow it.  Import the project from the repository root.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != ROOT / "benchmarks"]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
RESULTS = ROOT / "benchmarks" / "results"
SEED_SINGLE = 1
SEED_BATCH = 2
WRONG_TOL = 1e-9  # relative to the robot's size, as docs/design.md section 9
SAME_TOL = 1e-6  # joint-space distance for "the sampled joint vector is among the solutions"
SINGULAR_TOL = 1e-7  # smallest singular value of the normalised Jacobian below which a pose is singular
WORKER_TIMEOUT = 300


# ---- helpers ---------------------------------------------------------------------------------------


def _median(xs) -> float:
    return float(np.median(xs)) if len(xs) else float("nan")


def _pose_errors(chain, sols: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Relative pose error of each solution row: max(|dp|, scale * max|dR|) / scale."""
    if len(sols) == 0:
        return np.zeros(0)
    G = chain.fk_batch(sols)
    dp = np.linalg.norm(G[:, :3, 3] - T[:3, 3], axis=1)
    dr = np.abs(G[:, :3, :3] - T[:3, :3]).max(axis=(1, 2))
    return np.maximum(dp, chain.scale * dr) / chain.scale


def _joint_distance(sols: np.ndarray, q: np.ndarray, kinds: str) -> np.ndarray:
    d = sols - q
    for c, k in enumerate(kinds):
        if k == "R":
            d[:, c] = np.remainder(d[:, c] + math.pi, 2 * math.pi) - math.pi
    return np.abs(d).max(axis=1) if len(d) else np.zeros(0)


def _unique_rows(sols: np.ndarray, kinds: str, tol: float) -> np.ndarray:
    keep: list[np.ndarray] = []
    for row in sols:
        if not keep or _joint_distance(np.array(keep), row, kinds).min() > tol:
            keep.append(row)
    return np.array(keep) if keep else sols[:0]


def _singular(chain, q, free_cols) -> bool:
    """Whether the sampled joint vector is a singular configuration of the solved joints.

    There the solutions form a continuum (or merge) and the sampled vector need not be among the
    returned representatives.  Body Jacobian, linear rows in units of the robot's size.
    """
    J = chain.body_jacobian(q)
    J = np.delete(J, list(free_cols), axis=1)
    J[:3] /= chain.scale
    return bool(np.linalg.svd(J, compute_uv=False).min() < SINGULAR_TOL)


def _accuracy(chain, Ts, Q, per_pose_sols, kinds: str, free_cols=()) -> dict:
    """Counts and errors of exact solutions, checked with our chain's FK."""
    counts, in_limits, recovered, worst, wrong, missed = [], [], 0, 0.0, 0, []
    singular = [_singular(chain, q, free_cols) for q in Q]
    regular_hits = 0
    tol = SAME_TOL * max(1.0, chain.scale)
    lo, hi = chain.lower - 1e-12, chain.upper + 1e-12
    rev = np.array([k == "R" for k in kinds])
    for T, q, sols in zip(Ts, Q, per_pose_sols):
        counts.append(len(sols))
        if len(sols) == 0:
            in_limits.append(0)
            if len(missed) < 5 and not singular[len(counts) - 1]:
                missed.append([float(x) for x in q])
            continue
        w = np.where(rev, np.remainder(sols + math.pi, 2 * math.pi) - math.pi, sols)
        in_limits.append(int(((w >= lo) & (w <= hi)).all(axis=1).sum()))
        e = _pose_errors(chain, sols, T)
        worst = max(worst, float(e.max()))
        wrong += int((e > WRONG_TOL).sum())
        if (_joint_distance(sols, q, kinds) <= tol).any():
            recovered += 1
            regular_hits += not singular[len(counts) - 1]
        elif len(missed) < 5 and not singular[len(counts) - 1]:
            missed.append([float(x) for x in q])
    n = len(counts)
    n_reg = n - sum(singular)
    return {
        "poses": n,
        "solutions_median": _median(counts),
        "solutions_max": int(max(counts)) if counts else 0,
        "in_limits_median": _median(in_limits),
        "found_fraction": float(np.mean([c > 0 for c in counts])) if n else float("nan"),
        "recovered_fraction": recovered / n if n else float("nan"),
        "singular_poses": int(sum(singular)),
        "recovered_regular_fraction": regular_hits / n_reg if n_reg else float("nan"),
        "max_error": worst,
        "wrong": wrong,
        "missed_examples": missed,  # regular sampled joint vectors not among the solutions (first 5)
    }


def _free_setup(chain):
    """Free joints (beyond 6 DOF: the last ones) and their one value for every pose."""
    free = tuple(chain.independent_names[6:]) if chain.dof > 6 else ()
    cols = [chain.independent_names.index(f) for f in free]
    values = []
    for c in cols:
        lo, hi = chain.lower[c], chain.upper[c]
        values.append(float(np.clip(0.3, lo, hi)))
    return free, cols, values


def _poses(chain, count: int, seed: int, cols, values):
    from ikcompiler.verify import sample_configurations

    Q = sample_configurations(chain, count, seed)
    for c, v in zip(cols, values):
        Q[:, c] = v
    return Q, chain.fk_batch(Q)


# ---- EAIK ------------------------------------------------------------------------------------------


def eaik_reason(chain, free) -> str | None:
    """Why EAIK does not apply to ``chain`` (None when it does)."""
    if chain.couplings:
        return "coupled (mimic) joints"
    if any(k != "R" for k in chain.joint_types):
        return f"prismatic joint(s) ({chain.joint_types})"
    if chain.n - len(free) > 6:
        return f"{chain.n} joints"
    return None


def eaik_geometry(chain, free_cols, free_values):
    """H (n, 3), P (n+1, 3), R6T (3, 3) and fixed axes from the chain's home twists."""
    tw = chain.twists
    v, w = tw[:, :3], tw[:, 3:]
    r = np.cross(w, v)  # the axis point closest to the origin (w unit, v = -w x r)
    P = np.vstack([r[0], np.diff(r, axis=0), chain.home[:3, 3] - r[-1]])
    idx = list(chain.independent)
    fixed = [(idx[c], val) for c, val in zip(free_cols, free_values)]
    return w.copy(), P, np.array(chain.home[:3, :3]), fixed


def run_npz_worker(argv, payload: dict, inp: Path, out: Path, *, what: str, timeout: float, env=None):
    """Run a worker process (``python argv...``) that reads the arrays ``payload`` from ``inp`` and
    writes a JSON ``meta`` and its arrays to ``out`` (numpy .npz files); shared with
    benchmarks/compare.py.  Returns ``(meta, arrays, None)``, or ``(None, {}, why)`` naming ``what`` ran:
    it timed out, a signal ended it (EAIK aborts on chains it cannot solve) or it exited non-zero."""
    np.savez(inp, **payload)
    cmd = [sys.executable, *map(str, argv), str(inp), str(out)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return None, {}, f"{what} timed out after {timeout} s"
    if proc.returncode != 0:
        if proc.returncode < 0:
            try:
                sig = signal.Signals(-proc.returncode).name
            except ValueError:
                sig = f"signal {-proc.returncode}"
            return None, {}, f"{what} aborted the process ({sig})"
        tail = [ln for ln in (proc.stderr or "").strip().splitlines() if ln.strip()][-1:] or [""]
        return None, {}, f"{what} exited {proc.returncode}: {tail[0][:160]}"
    with np.load(out, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    return json.loads(str(arrays.pop("meta"))), arrays, None


def _run_worker(stage: str, payload: dict, tmp: Path) -> tuple[dict | None, str | None, dict]:
    meta, arrays, err = run_npz_worker([Path(__file__).resolve(), "--eaik-worker", stage], payload,
                                       tmp / f"{stage}_in.npz", tmp / f"{stage}_out.npz",
                                       what=f"its {stage} call", timeout=WORKER_TIMEOUT)
    return meta, err, arrays


def eaik_robot(H, P, R6T, fixed=()):
    """EAIK's robot of the geometry :func:`eaik_geometry` gives (inside a worker process)."""
    import eaik.pybindings.EAIK as EAIK

    return EAIK.Robot(H.T.copy(), P.T.copy(), R6T.copy(), list(fixed), True)


def eaik_solve(robot, T, n: int):
    """EAIK's rows for one pose: joint values (k, n) and their least-squares flags (k,)."""
    s = robot.calculate_IK(T)
    return np.asarray(s.Q, dtype=float).reshape(-1, n), np.asarray(s.is_LS, dtype=bool).reshape(-1)


def eaik_batch(robot, Ts, threads: int, runs: int = 3):
    """EAIK's batched IK on poses Ts: the best wall time of ``runs`` calls, and the last call's results."""
    poses = [np.ascontiguousarray(T) for T in Ts]
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        res = robot.calculate_IK_batched(poses, threads)
        times.append(time.perf_counter() - t0)
    return min(times), res


def _eaik_worker(stage: str, inp: str, out: str) -> None:
    """Runs in a subprocess: build EAIK's robot, time IK, save solutions (single) or timing (batch)."""
    z = np.load(inp)
    H, P, R6T, Ts = z["H"], z["P"], z["R6T"], z["Ts"]
    fixed = [(int(i), float(q)) for i, q in z["fixed"]]
    threads = int(z["threads"])

    def build():
        return eaik_robot(H, P, R6T, fixed)

    meta: dict = {}
    arrays: dict = {}
    if stage == "single":
        times = []
        for _ in range(50):
            t0 = time.perf_counter()
            robot = build()
            times.append(time.perf_counter() - t0)
        meta["build_us"] = _median(times) * 1e6
        meta["known"] = bool(robot.has_known_decomposition())
        meta["family"] = str(robot.get_kinematic_family())
        if not meta["known"]:
            try:
                robot.calculate_IK(Ts[0])
                meta["ik_error"] = "IK call returned without error"
            except Exception as exc:  # what EAIK says when it has no decomposition
                first = str(exc).split("!")[0].split(".")[0]
                meta["ik_error"] = f"its IK call raises {type(exc).__name__}: {first}"[:160]
        else:
            n = H.shape[0]
            times, sols, ls = [], [], []
            for T in Ts:
                t0 = time.perf_counter()
                q, f = eaik_solve(robot, T, n)
                times.append(time.perf_counter() - t0)
                sols.append(q)
                ls.append(f)
            meta["single_us"] = _median(times) * 1e6
            k = max([len(q) for q in sols] + [1])
            Qp = np.full((len(Ts), k, n), np.nan)
            LSp = np.ones((len(Ts), k), dtype=bool)
            for i, (q, f) in enumerate(zip(sols, ls)):
                Qp[i, : len(q)] = q
                LSp[i, : len(f)] = f
            arrays = {"Q": Qp, "LS": LSp, "count": np.array([len(q) for q in sols])}
    else:
        best, res = eaik_batch(build(), Ts, threads)
        meta["batch_s"] = best
        meta["batch_n"] = len(Ts)
        meta["batch_pps"] = len(Ts) / best
        meta["batch_solutions_mean"] = float(np.mean([r.num_solutions() for r in res]))
        meta["threads"] = threads
    np.savez(out, meta=np.array(json.dumps(meta)), **arrays)


def bench_eaik(chain, free_cols, free_values, Q1, T1, Tb, threads: int) -> dict:
    H, P, R6T, fixed = eaik_geometry(chain, free_cols, free_values)
    base = {
        "H": H,
        "P": P,
        "R6T": R6T,
        "fixed": np.array(fixed, dtype=float).reshape(-1, 2),
        "threads": np.array(threads),
    }
    res: dict = {"applies": True}
    with tempfile.TemporaryDirectory(prefix="ikc_bench_") as tmpdir:
        tmp = Path(tmpdir)
        meta, err, arrays = _run_worker("single", {**base, "Ts": T1}, tmp)
        if err:
            res["error"] = err
            return res
        res.update(meta)
        if not meta["known"]:
            res["error"] = f"no known decomposition; {meta.get('ik_error', '')}"
            # what its batch call does then (known to abort the process)
            meta, err, _ = _run_worker("batch", {**base, "Ts": Tb[:100]}, tmp)
            res["batch_error"] = err or "batch call returned"
            return res
        kinds = chain.joint_types
        tol = SAME_TOL * max(1.0, chain.scale)
        exact, ls_counts, dupes = [], [], 0
        for i in range(len(T1)):
            k = int(arrays["count"][i])
            q, ls = arrays["Q"][i, :k], arrays["LS"][i, :k]
            ex = q[~ls]
            u = _unique_rows(ex, kinds, tol)
            dupes += len(ex) - len(u)
            exact.append(u)
            ls_counts.append(int(ls.sum()))
        res["accuracy"] = _accuracy(chain, T1, Q1, exact, kinds, free_cols)
        res["ls_median"] = _median(ls_counts)
        res["duplicates"] = dupes
        meta, err, _ = _run_worker("batch", {**base, "Ts": Tb}, tmp)
        if err:
            res["batch_error"] = err
        else:
            res.update(meta)
    return res


# ---- ours ------------------------------------------------------------------------------------------


def _time_single(module, T1, Q1, cols, opts):
    """Time ``solve`` per pose over the targets in order, within the budget; (times, solutions)."""
    times, sols = [], []
    start = time.perf_counter()
    for i in range(len(T1)):
        fv = [Q1[i, c] for c in cols]
        t0 = time.perf_counter()
        s = module.solve(T1[i], *fv)
        times.append(time.perf_counter() - t0)
        sols.append(np.asarray(s, dtype=float))
        if time.perf_counter() - start > opts.budget and i + 1 >= opts.min_poses:
            break
    return times, sols


def _time_batch(module, Tb, Qb, cols, opts):
    """Best of up to 3 ``solve_batch`` calls on the first n poses, n cut to fit the budget.

    Returns (n, poses/s, output of the last call).
    """
    probe = min(len(Tb), 200)
    fv = [Qb[:probe, c] for c in cols]
    t0 = time.perf_counter()
    out = module.solve_batch(Tb[:probe], *fv)
    dt = time.perf_counter() - t0
    n_b = len(Tb)
    if dt * len(Tb) / probe > opts.budget:
        n_b = max(probe, int(opts.budget * probe / dt) // 100 * 100)
    runs = []
    if n_b == probe and dt * 3 > opts.budget:
        runs.append(dt)
    else:
        fv = [Qb[:n_b, c] for c in cols]
        for _ in range(3):
            t0 = time.perf_counter()
            out = module.solve_batch(Tb[:n_b], *fv)
            runs.append(time.perf_counter() - t0)
            if sum(runs) > opts.budget:
                break
    return n_b, n_b / min(runs), out


PYTHON_FAST = {"NATIVE": False}  # module flags of each path besides the default one
REFERENCE = {"FAST_PATH": False}


@contextlib.contextmanager
def _flags(module, flags: dict):
    """Run the block with the module's path flags (``FAST_PATH``, ``NATIVE``) set, then restore them."""
    old = {k: getattr(module, k) for k in flags}
    try:
        for k, v in flags.items():
            setattr(module, k, v)
        yield module
    finally:
        for k, v in old.items():
            setattr(module, k, v)


def _deferred_batch(module, Ts, free_values) -> float:
    """Fraction of the batch targets the Python fast path hands to the reference runtime.

    The module's own first stage, untimed: its fast chain on the array backend (``_fast_leaves``) and
    ``subproblems.fast.finish_many`` with the module's settings (limits on, as ``solve_batch``), whose
    route marks the targets sent to the reference runtime (``ROUTE_REFERENCE``).  One call over all
    the poses (``solve_batch`` cuts them in chunks of 4096; the route is per target, so the count is
    the same).  NaN for search and snapped plans, whose batches always take Newton steps on the fast
    chain's candidates.
    """
    from ikcompiler.runtime import fastchain, targets
    from subproblems import fast as _fk

    if module._SEARCH or module._POLISH:
        return float("nan")
    robot = module._SOLVER.robot
    goals, _ = targets.valid_targets(robot, Ts)
    init = targets.initial_values(robot, len(goals), free_values)
    Q, err, flag = fastchain.leaves(robot, goals, init)
    _, route = _fk.finish_many(Q, err, flag, **robot.finish_kwargs(True))
    sent = route == _fk.ROUTE_REFERENCE
    return float(np.mean(sent)) if len(sent) else float("nan")


def _deferred_one(module, T, free_values) -> bool:
    """Whether a single-pose ``solve`` of T leaves the scalar Python fast path (its leaves, finished by
    ``subproblems.fast.finish_one``, give None)."""
    from ikcompiler.runtime import fastchain
    from subproblems import fast as _fk

    robot = module._SOLVER.robot
    with np.errstate(all="ignore"):
        leaves = fastchain.scalar_leaves(robot, T, tuple(free_values))
        return leaves is None or _fk.finish_one(leaves, **robot.finish_kwargs(True)) is None


def _native_deferred_batch(module, Ts, free_values) -> tuple[float, int]:
    """Fraction of the batch targets the native backend hands to the Python path (its per-target code
    from ``_native_chain().many`` below 0, as ``_native_batch`` reads it), and how many it calls
    invalid (code -2; the sampled poses are all valid)."""
    from ikcompiler.runtime import targets
    from subproblems import native as _native

    raw = np.asarray(Ts, dtype=float)
    robot = module._SOLVER.robot
    init = targets.initial_values(robot, len(raw), free_values)
    _, code = module._native_chain().many(raw, targets.free_columns(robot, init), True)
    return (float(np.mean(code < 0)) if len(code) else float("nan")), int((code == _native.INVALID).sum())


def _native_deferred_one(module, T, free_values) -> bool:
    """Whether the native backend hands a single-pose target to the Python path (``one`` gives None)."""
    return module._native_chain().one(T, tuple(free_values), True) is None


SPLIT_TOL = 1e-4  # two copies of one tangent root can be this far apart (see _compare)


def _outcomes(module, flags: dict, Ts, free_cols, batch: bool = False) -> list:
    """Per pose, (exact solutions, whether a row flags a continuum) on the path that ``flags`` select:
    ``solve_batch_info`` over all the poses at once, or ``solve_info`` pose by pose."""
    with _flags(module, flags):
        if batch:
            Q, valid, ls, _, cont = module.solve_batch_info(Ts, *free_cols)
            return [(Q[i][valid[i] & ~ls[i]], cont[i][valid[i]].any()) for i in range(len(Ts))]
        out = []
        for i, T in enumerate(Ts):
            q, _, ls, cont = module.solve_info(T, *[f[i] for f in free_cols])[:4]
            out.append((q[~ls], cont.any()))
        return out


def _compare(first: list, second: list, kinds: str) -> dict:
    """Poses whose exact solutions differ between two paths' outcomes (pose by pose, the shorter list).

    Self-motion poses (either path flags a continuum) are left out, since each path returns its own
    representative of the family; elsewhere the exact solution sets must match both ways within
    SPLIT_TOL (the two copies of a tangent root can stay that far apart and both pass the pose check,
    so counts alone may differ by such copies).  Also the largest distance between matched rows.
    """
    differ, skipped, worst = [], 0, 0.0
    for i, ((a, ca), (b, cb)) in enumerate(zip(first, second)):
        if ca or cb:
            skipped += 1
            continue
        if len(a) == len(b) == 0:
            continue
        if len(a) == 0 or len(b) == 0:
            differ.append(i)
            continue
        d = max(
            max(_joint_distance(b, r, kinds).min() for r in a),
            max(_joint_distance(a, r, kinds).min() for r in b),
        )
        if d > SPLIT_TOL:
            differ.append(i)
        else:
            worst = max(worst, float(d))
    return {
        "differ": differ,
        "self_motion": skipped,
        "poses": min(len(first), len(second)),
        "max_distance": worst,
    }


def _agreement(result: dict, key: str, cmp_single: dict, cmp_batch: dict, Q1, Qb) -> None:
    """Store two comparisons (single, batch) in ``result`` under ``key``: counts, examples, distances."""
    for kind, cmp, Q in (("single", cmp_single, Q1), ("batch", cmp_batch, Qb)):
        result[f"{kind}_{key}"] = len(cmp["differ"])
        result[f"{kind}_{key}_poses"] = cmp["poses"]
        result[f"{kind}_{key}_self_motion"] = cmp["self_motion"]
        result[f"{kind}_{key}_max_distance"] = cmp["max_distance"]
        result[f"{kind}_{key}_examples"] = [
            {"pose": int(i), "q": [float(x) for x in Q[i]]} for i in cmp["differ"][:5]
        ]


def _bench_path(module, flags: dict, cols, opts, T1, Q1, base_times, Tb, Qb, base_pps) -> dict:
    """The same single-pose and batch timings on another path (``flags``: the Python fast path or the
    reference runtime), same poses as the default path (the first ones of each set when the budget cuts
    the run short).  Speed-ups are of the default path over this one: the single-pose one compares
    medians over the poses both timed, the batch one throughputs."""
    with _flags(module, flags):
        times, _ = _time_single(module, T1, Q1, cols, opts)
        n_b, pps, _ = _time_batch(module, Tb, Qb, cols, opts)
    n1 = len(times)
    res: dict = {"single_n": n1, "single_us": _median(times) * 1e6, "batch_n": n_b, "batch_pps": pps}
    res["single_speedup"] = _median(times) / _median(base_times[:n1])
    res["batch_speedup"] = base_pps / pps  # per pose; this path's poses may be the first of the set
    return res


def _native_reason(module) -> str:
    """Why a module with a fast path runs it in Python (no C chain, or the C chain did not build)."""
    from subproblems import native as _native

    if getattr(module, "NATIVE", False):
        return f"C build unavailable: {_native.last_error}"
    if module._SEARCH:
        return "no C chain (search plan)"
    if module._POLISH:
        return "no C chain (snapped plan, Newton steps on the true robot)"
    return "no C chain (a step has no C port)"


def bench_robot(name: str, opts) -> dict:
    from ikcompiler import load_robot
    from ikcompiler.compiler import compile_robot

    row: dict = {"robot": name}
    chain = load_robot(name)
    free, cols, values = _free_setup(chain)
    row.update(joints=chain.joint_types, dof=chain.dof, free=list(free), free_values=values)
    kinds = "".join(chain.joints[i].kind for i in chain.independent)

    times = []
    for _ in range(opts.compiles):
        t0 = time.perf_counter()
        module = compile_robot(chain, free=free)
        times.append(time.perf_counter() - t0)
    row["compile_s"] = _median(times)  # the Python compile only: the C build is timed below
    row["method"] = module.METHOD

    fast = bool(getattr(module, "FAST_PATH", False)) and getattr(module, "_fast_chain", None) is not None
    native = None
    if fast and getattr(module, "NATIVE", False):
        # the one-off C print and build (into this run's fresh IKC_CACHE) and load, before any timing
        t0 = time.perf_counter()
        native = module._native_chain()
        row["native_build_s"] = time.perf_counter() - t0
    row["path"] = "native" if native is not None else "fast" if fast else "reference"
    if fast and native is None:
        row["native_reason"] = _native_reason(module)

    Q1, T1 = _poses(chain, opts.poses, SEED_SINGLE, cols, values)
    times, sols = _time_single(module, T1, Q1, cols, opts)
    n1 = len(times)
    row["single_n"] = n1
    row["single_us"] = _median(times) * 1e6
    row["accuracy"] = _accuracy(chain, T1[:n1], Q1[:n1], sols, kinds, cols)

    Qb, Tb = _poses(chain, opts.batch, SEED_BATCH, cols, values)
    n_b, pps, _ = _time_batch(module, Tb, Qb, cols, opts)
    row["batch_n"] = n_b
    row["batch_pps"] = pps

    if fast:
        T1, Q1, Tn, Qn = T1[:n1], Q1[:n1], Tb[:n_b], Qb[:n_b]  # EAIK's batch keeps the full set
        free1, freeb = [Q1[:, c] for c in cols], [Qn[:, c] for c in cols]
        py = {
            "deferred_fraction": _deferred_batch(module, Tn, freeb),
            "deferred_single_fraction": float(
                np.mean([_deferred_one(module, T1[i], [Q1[i, c] for c in cols]) for i in range(n1)])
            ),
        }
        # agreement, untimed: each path's outcomes once, compared pairwise (see _compare)
        base1, baseb = _outcomes(module, {}, T1, free1), _outcomes(module, {}, Tn, freeb, batch=True)
        if native is not None:
            row["native"] = dict(
                zip(("deferred_fraction", "invalid"), _native_deferred_batch(module, Tn, freeb))
            )
            row["native"]["deferred_single_fraction"] = float(
                np.mean([_native_deferred_one(module, T1[i], [Q1[i, c] for c in cols]) for i in range(n1)])
            )
            py.update(_bench_path(module, PYTHON_FAST, cols, opts, T1, Q1, times, Tn, Qn, pps))
            py1 = _outcomes(module, PYTHON_FAST, T1[: py["single_n"]], [f[: py["single_n"]] for f in free1])
            pyb = _outcomes(
                module, PYTHON_FAST, Tn[: py["batch_n"]], [f[: py["batch_n"]] for f in freeb], True
            )
            _agreement(py, "disagree", _compare(base1, py1, kinds), _compare(baseb, pyb, kinds), Q1, Qn)
        else:  # the Python fast path is the default one: its figures are the row's
            py.update(single_n=n1, single_us=row["single_us"], batch_n=n_b, batch_pps=pps)
        row["python_fast"] = py
        ref = _bench_path(module, REFERENCE, cols, opts, T1, Q1, times, Tn, Qn, pps)
        ref1 = _outcomes(module, REFERENCE, T1[: ref["single_n"]], [f[: ref["single_n"]] for f in free1])
        refb = _outcomes(module, REFERENCE, Tn[: ref["batch_n"]], [f[: ref["batch_n"]] for f in freeb], True)
        _agreement(ref, "disagree", _compare(base1, ref1, kinds), _compare(baseb, refb, kinds), Q1, Qn)
        if native is not None:  # the Python fast path against the reference too (JSON only)
            n1p, nbp = min(py["single_n"], ref["single_n"]), min(py["batch_n"], ref["batch_n"])
            _agreement(
                ref,
                "python_disagree",
                _compare(py1[:n1p], ref1, kinds),
                _compare(pyb[:nbp], refb, kinds),
                Q1,
                Qn,
            )
        row["reference"] = ref
        row["deferred_fraction"] = (row.get("native") or py)["deferred_fraction"]  # of the default path

    reason = eaik_reason(chain, free)
    if opts.no_eaik:
        row["eaik"] = {"applies": False, "reason": "skipped (--no-eaik)"}
    elif reason:
        row["eaik"] = {"applies": False, "reason": reason}
    else:
        row["eaik"] = bench_eaik(chain, cols, values, Q1[:n1], T1[:n1], Tb, opts.threads)
    row["_module"] = module
    row["_poses"] = (T1[:n1], [[Q1[i, c] for c in cols] for i in range(n1)])
    return row


def _short(path: str) -> str:
    for prefix in (str(ROOT) + "/", "site-packages/"):
        if prefix in path:
            path = path.split(prefix, 1)[1]
    return path


def profile_solve(row: dict, lines: int = 10, seconds: float = 1.0) -> dict:
    """cProfile of ``solve`` on the module's default path (native or fast where it has one) over the
    robot's single-pose targets, repeated to about ``seconds`` of unprofiled time: where one call goes."""
    module, (Ts, fvs) = row["_module"], row["_poses"]
    Ts, fvs = Ts[:200], fvs[:200]
    per_call = (row.get("single_us") or 1e3) * 1e-6
    rounds = max(1, min(100, math.ceil(seconds / per_call / len(Ts))))
    path = row.get("path", "reference")
    handed = {"native": _native_deferred_one, "fast": _deferred_one}.get(path)
    deferred = sum(handed(module, T, fv) for T, fv in zip(Ts, fvs)) if handed else None
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    for _ in range(rounds):
        for T, fv in zip(Ts, fvs):
            module.solve(T, *fv)
    prof.disable()
    wall = time.perf_counter() - t0
    stats = pstats.Stats(prof)
    n = len(Ts) * rounds
    total = sum(v[2] for v in stats.stats.values())  # own time of every function adds up to the total
    entries = []
    for (fname, line, func), (_, ncalls, tt, ct, _) in stats.stats.items():
        where = f"{_short(fname)}:{line}({func})" if line else func
        entries.append((where, ncalls, tt, ct))

    def table(key, rows):
        out = [f"{'calls/solve':>11} {'own us':>8} {'cum us':>8} {'cum %':>6}  function"]
        for where, ncalls, tt, ct in sorted(rows, key=key, reverse=True)[:lines]:
            out.append(
                f"{ncalls / n:11.1f} {tt / n * 1e6:8.0f} {ct / n * 1e6:8.0f} {ct / total:6.0%}  {where}"
            )
        return "\n".join(out)

    ours = [e for e in entries if e[0].startswith(("subproblems/", "ikcompiler/", "<ikcompiler:"))]
    ours = [e for e in ours if e[3] < 0.98 * total or e[0].endswith("(solve)")]  # drop the wrappers
    own = {}
    for where, _, tt, _ in entries:
        builtin = where.startswith(("<built-in", "<method", "{"))
        if where.startswith("<ikc"):
            group = "generated module"
        elif where.startswith("subproblems/fast.py"):
            group = "subproblems/fast.py"
        elif where.startswith("subproblems/native.py"):
            group = "subproblems/native.py (with the C call, which the profiler does not see apart)"
        elif where.startswith("subproblems/"):
            group = "reference runtime and subproblems"
        elif "numpy" in where:
            group = "numpy"
        elif builtin:
            group = "other built-ins (math, list, ...)"
        else:
            group = where
        own[group] = own.get(group, 0.0) + tt
    return {
        "robot": row["robot"],
        "method": row["method"],
        "path": path,
        "poses": len(Ts),
        "rounds": rounds,
        "deferred_poses": deferred,
        "calls": n,
        "profiled_us_per_solve": wall / n * 1e6,
        "unprofiled_us_per_solve": row["single_us"],
        "function_calls_per_solve": sum(v[1] for v in stats.stats.values()) / n,
        "by_own_time": table(lambda e: e[2], entries),
        "by_cumulative_time": table(lambda e: e[3], ours),
        "own_time_shares": {k: v / total for k, v in sorted(own.items(), key=lambda kv: -kv[1])[:4]},
    }


# ---- report ----------------------------------------------------------------------------------------


def _fmt(x, spec: str = ".3g", none: str = "-") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return none
    return format(x, spec)


def _ratio(a, b) -> str:
    if a is None or b is None or not b or not math.isfinite(a) or not math.isfinite(b):
        return "-"
    r = a / b
    return f"{r:,.0f}x" if r >= 100 else f"{r:.3g}x"


def _machine() -> dict:
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass

    def ver(pkg):
        try:
            return _md.version(pkg)
        except _md.PackageNotFoundError:
            return None

    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
        ).stdout.strip()
        dirty = bool(
            subprocess.run(
                ["git", "status", "--porcelain", "--", "ikcompiler", "subproblems"],
                cwd=ROOT,
                capture_output=True,
                text=True,
            ).stdout.strip()
        )
    except OSError:
        commit, dirty = "", False
    from subproblems import native as _native

    cc, cc_id = _native.compiler(), None
    if cc:
        try:
            done = subprocess.run(cc.split() + ["--version"], capture_output=True, text=True, timeout=30)
            cc_id = (done.stdout.splitlines() or [cc])[0]
        except (OSError, subprocess.SubprocessError):
            cc_id = cc
    return {
        "date": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "ikcompiler": ver("ikcompiler"),
        "eaik": ver("eaik"),
        "commit": commit + (" + uncommitted changes in ikcompiler/ or subproblems/" if dirty else ""),
        "load_average": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        "cc": cc_id,
        "native_enabled": _native.enabled(),
        "native_threads": _native.threads(),
    }


def render_markdown(rows, profile, meta, opts) -> str:
    out = [
        "# Compiler speed: generated solvers vs EAIK",
        "",
        f"Generated by `benchmarks/compiler.py` on {meta['date']}. Machine: {meta['cpu']}, "
        f"{meta['cores']} cores, {meta['platform']}; Python {meta['python']}, numpy {meta['numpy']}, "
        f"ikcompiler {meta['ikcompiler']} at {meta['commit']}, EAIK {meta['eaik']}; C compiler "
        f"{meta.get('cc') or 'none'}, native batches in {meta.get('native_threads', '?')} threads. "
        f"1-min load average at the start: {_fmt(meta['load_average'], '.2f')}.",
        "",
        "## Speed",
        "",
        "Ours is each module's default path: `path` native (the fast chain compiled to C, built with the "
        "system C compiler on first use and cached; targets it cannot settle go to the Python path in "
        "the same call), fast (the same straight-line arithmetic in Python, targets near a degenerate "
        "geometry deferred to the reference runtime) or reference (the plan interpreted by "
        "`subproblems.plan_runtime`; the module has no fast path). Compile ms is the Python "
        "`compile_robot` alone; C build ms the one-off build and load of the native chain (first "
        "`_native_chain()` call, into an empty cache made for this run), done before any timing. Ratios "
        "are ours / EAIK in time per pose (above 1x: we are slower). Batch: the native path runs "
        f"{meta.get('native_threads', '?')} C threads (`subproblems.native.threads()`), targets it hands "
        "to the Python path run in numpy in the calling thread; the fast and reference paths run numpy "
        f"in one thread; EAIK's `calculate_IK_batched` runs {opts.threads} worker threads.",
        "",
        "| robot | joints | method | path | compile ms | C build ms | EAIK build us | ratio | solve us "
        "| EAIK us | ratio | batch poses/s | EAIK poses/s | ratio |",
        "|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        e = r.get("eaik") or {}
        if "error" in r and "method" not in r:
            out.append(f"| {r['robot']} | {r.get('joints', '?')} | failed: {r['error']} |||||||||||")
            continue
        comp = r.get("compile_s")
        build = r.get("native_build_s")
        joints = r["joints"] + (f" (free {', '.join(r['free'])})" if r.get("free") else "")
        batch = f"{_fmt(r.get('batch_pps'), ',.0f')}" + (
            f" ({r['batch_n']} poses)" if r.get("batch_n", opts.batch) < opts.batch else ""
        )
        eb = e.get("batch_pps")
        out.append(
            "| "
            + " | ".join(
                [
                    r["robot"],
                    joints,
                    r.get("method", "-"),
                    r.get("path", "-"),
                    _fmt(comp * 1e3 if comp is not None else None, ".0f"),
                    _fmt(build * 1e3 if build is not None else None, ",.0f"),
                    _fmt(e.get("build_us"), ".1f"),
                    _ratio(comp * 1e6 if comp is not None else None, e.get("build_us")),
                    _fmt(r.get("single_us"), ".1f" if (r.get("single_us") or 100) < 100 else ".0f"),
                    _fmt(e.get("single_us"), ".1f"),
                    _ratio(r.get("single_us"), e.get("single_us")),
                    batch,
                    _fmt(eb, ",.0f"),
                    _ratio(eb, r.get("batch_pps")),
                ]
            )
            + " |"
        )
    fast_rows = [r for r in rows if r.get("path") in ("native", "fast")]
    native_rows = [r for r in fast_rows if r["path"] == "native"]
    ref_rows = [r["robot"] for r in rows if r.get("path") == "reference"]

    def cut(res, key, n):  # a figure, with its pose count when the budget cut the phase short
        x = res.get("single_us" if key == "single" else "batch_pps")
        spec = (".1f" if (x or 100) < 100 else ".0f") if key == "single" else ",.0f"
        return _fmt(x, spec) + (f" ({res[f'{key}_n']} poses)" if res.get(f"{key}_n", n) < n else "")

    out += [
        "",
        "## Native, Python fast path and reference runtime",
        "",
        "The same module and poses on each path: native (the default where the module has it), the "
        "Python fast path (`NATIVE = False`) and the reference runtime (`FAST_PATH = False`); a module "
        "without a C chain has its Python fast path as default (native columns empty). Speed-ups: "
        "other path / default path in time per pose (single: ratio of medians over the poses both "
        "timed; batch: ratio of throughputs).",
        "",
        "| robot | path | solve us native | Python fast | reference | speed-up vs Python fast "
        "| vs reference | batch poses/s native | Python fast | reference | speed-up vs Python fast "
        "| vs reference |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in fast_rows:
        ref, py = r.get("reference") or {}, r.get("python_fast") or {}
        nat = r["path"] == "native"
        n1, nb = r["single_n"], r["batch_n"]
        out.append(
            "| "
            + " | ".join(
                [
                    r["robot"],
                    r["path"] if nat else f"fast ({r.get('native_reason', 'no C chain')})",
                    _fmt(r.get("single_us"), ".1f") if nat else "-",
                    cut(py, "single", n1),
                    cut(ref, "single", n1),
                    _ratio(py.get("single_speedup"), 1.0) if nat else "-",
                    _ratio(ref.get("single_speedup"), 1.0),
                    _fmt(r.get("batch_pps"), ",.0f") if nat else "-",
                    cut(py, "batch", nb),
                    cut(ref, "batch", nb),
                    _ratio(py.get("batch_speedup"), 1.0) if nat else "-",
                    _ratio(ref.get("batch_speedup"), 1.0),
                ]
            )
            + " |"
        )
    out += [
        "",
        "Handed on and agreement. Native to Python: fraction of the batch poses (in brackets: of the "
        "single poses) the native backend hands to the Python path (batch: `_native_chain().many` codes "
        "below 0; single: `_native_chain().one` gives None). Python fast to reference: the same for the "
        "Python fast path and the reference runtime (batch: the route of `subproblems.fast.finish_many`; "
        "single: the scalar `_fast_one` gives up, which it also does on near misses the batch path "
        "settles with Newton steps). Disagree: poses where the exact solution sets of two paths differ "
        f"(rows matched both ways within {SPLIT_TOL:g}: two copies of one tangent root can lie that far "
        "apart), single / batch, native vs Python fast path and default path vs reference runtime; "
        "self-motion poses (either path flags a continuum) are left out, since each path returns its "
        "own representative of the family (their count is in the JSON). Max distance: the largest "
        "joint-space distance between matched rows of native and Python fast path (single and batch).",
        "",
        "| robot | native to Python | Python fast to reference | disagree native / Python fast "
        "| max distance | disagree vs reference | self-motion poses left out vs reference |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]

    def handed(res):  # batch (single) fractions handed on
        batch, single = res.get("deferred_fraction"), res.get("deferred_single_fraction")
        return f"{_fmt(batch, '.1%')} ({_fmt(single, '.1%')})"

    for r in fast_rows:
        ref, py, nv = r.get("reference") or {}, r.get("python_fast") or {}, r.get("native") or {}
        nat = r["path"] == "native"
        dist = max(
            py.get("single_disagree_max_distance") or 0.0, py.get("batch_disagree_max_distance") or 0.0
        )
        out.append(
            "| "
            + " | ".join(
                [
                    r["robot"],
                    handed(nv) if nat else "-",
                    handed(py),
                    f"{py.get('single_disagree', '-')} / {py.get('batch_disagree', '-')}" if nat else "-",
                    _fmt(dist, ".1e") if nat else "-",
                    f"{ref.get('single_disagree', '-')} / {ref.get('batch_disagree', '-')}",
                    f"{ref.get('single_disagree_self_motion', '-')} / "
                    f"{ref.get('batch_disagree_self_motion', '-')}",
                ]
            )
            + " |"
        )
    if ref_rows:
        out += [
            "",
            f"Reference runtime only (no fast path; their figures above are the reference's): "
            f"{', '.join(ref_rows)}.",
        ]
    out += [
        "",
        "## Solutions and accuracy (single-pose calls, same poses for both)",
        "",
        "Solutions: median exact solutions per pose, in brackets those inside the joint limits (EAIK: "
        "least-squares rows dropped, duplicates merged; it has no limits). Recovered: fraction of poses "
        "whose sampled joint vector is among the solutions, over the regular poses and over all (at a "
        "singular sampled vector, smallest singular value of the normalised Jacobian below "
        f"{SINGULAR_TOL:g}, the solutions form a continuum and a representative is returned). Max "
        "error: worst pose error of a returned exact solution through our chain's FK, relative to "
        f"the robot's size (wrong above {WRONG_TOL:g}).",
        "",
        "| robot | poses | solutions | EAIK | singular | recovered (regular) | EAIK | recovered (all) | EAIK "
        "| max error | EAIK | wrong | EAIK | EAIK notes |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        if "accuracy" not in r:
            continue
        a, e = r["accuracy"], r.get("eaik") or {}
        ea = e.get("accuracy") or {}
        notes = []
        if not e.get("applies"):
            notes.append(f"n/a: {e.get('reason', '-')}")
        if e.get("family"):
            notes.append(e["family"])
        if e.get("error"):
            notes.append(e["error"])
        if e.get("batch_error"):
            notes.append(e["batch_error"])
        if ea:
            notes.append(f"median {_fmt(e.get('ls_median'), 'g')} least-squares rows/pose")
            if e.get("duplicates"):
                notes.append(f"{e['duplicates']} duplicate rows")
        ours = f"{_fmt(a['solutions_median'], 'g')} ({_fmt(a['in_limits_median'], 'g')})"
        eas = (
            f"{_fmt(ea.get('solutions_median'), 'g')} ({_fmt(ea.get('in_limits_median'), 'g')})"
            if ea
            else "-"
        )
        out.append(
            "| "
            + " | ".join(
                [
                    r["robot"],
                    str(a["poses"]),
                    ours,
                    eas,
                    str(a["singular_poses"]),
                    _fmt(a["recovered_regular_fraction"], ".1%"),
                    _fmt(ea.get("recovered_regular_fraction"), ".1%"),
                    _fmt(a["recovered_fraction"], ".1%"),
                    _fmt(ea.get("recovered_fraction"), ".1%"),
                    _fmt(a["max_error"], ".1e"),
                    _fmt(ea.get("max_error"), ".1e"),
                    str(a["wrong"]),
                    _fmt(ea.get("wrong"), "d"),
                    "; ".join(notes),
                ]
            )
            + " |"
        )
    failed = [r for r in rows if "error" in r]
    out += ["", "## Notes", ""]
    both = [r for r in rows if (r.get("eaik") or {}).get("single_us")]
    if both:

        def spread(key_ours, key_eaik, scale=1.0, invert=False):
            vals = []
            for r in both:
                a, b = r.get(key_ours), r["eaik"].get(key_eaik)
                if a and b:
                    vals.append(b / a if invert else a * scale / b)
            if not vals:
                return "-"
            lo, mid, hi = (_ratio(x, 1.0) for x in (min(vals), _median(vals), max(vals)))
            return f"median {mid} (range {lo}-{hi})"

        paths = {}
        for r in both:
            paths[r.get("path", "-")] = paths.get(r.get("path", "-"), 0) + 1
        out.append(
            f"- Summary over the {len(both)} robots EAIK solves (ours on the default path: "
            + ", ".join(f"{k} {v}" for k, v in sorted(paths.items()))
            + f"): single-pose time ours/EAIK {spread('single_us', 'single_us')}; batch time per pose "
            f"{spread('batch_pps', 'batch_pps', invert=True)} (ours native: "
            f"{meta.get('native_threads', '?')} C threads, EAIK {opts.threads} threads); compile time vs "
            f"EAIK's constructor {spread('compile_s', 'build_us', scale=1e6)} (the Python compile; the "
            "one-off C build comes on top, see below)."
        )

    def spread_of(vals, fmt=None):
        vals = [v for v in vals if v is not None and math.isfinite(v)]
        if not vals:
            return "-"
        lo, mid, hi = (fmt(x) if fmt else _ratio(x, 1.0) for x in (min(vals), _median(vals), max(vals)))
        return f"median {mid} (range {lo}-{hi})"

    def pct(x):
        return _fmt(x, ".1%")

    if native_rows:
        py = [r.get("python_fast") or {} for r in native_rows]
        ref = [r.get("reference") or {} for r in native_rows]
        nv = [r.get("native") or {} for r in native_rows]
        most = max(native_rows, key=lambda r: (r.get("native") or {}).get("deferred_fraction") or 0.0)
        out.append(
            f"- Native backend over the {len(native_rows)} robots that have it: speed-up over the Python "
            f"fast path single-pose {spread_of([p.get('single_speedup') for p in py])}, batch "
            f"{spread_of([p.get('batch_speedup') for p in py])}; over the reference runtime single-pose "
            f"{spread_of([x.get('single_speedup') for x in ref])}, batch "
            f"{spread_of([x.get('batch_speedup') for x in ref])}. One-off C build "
            f"{spread_of([r.get('native_build_s') for r in native_rows], lambda x: f'{x * 1e3:,.0f} ms')}. "
            f"Poses handed to the Python path: batch "
            f"{spread_of([x.get('deferred_fraction') for x in nv], pct)}, single "
            f"{spread_of([x.get('deferred_single_fraction') for x in nv], pct)}"
            + (f" (most: {most['robot']})" if (most.get("native") or {}).get("deferred_fraction") else "")
            + "; "
            f"poses native calls invalid: {sum(x.get('invalid') or 0 for x in nv)}."
        )
        slower = [r for r in native_rows if ((r.get("python_fast") or {}).get("batch_speedup") or 2.0) < 1.0]
        if slower:
            out.append(
                "- Native batch throughput below the Python fast path's: "
                + ", ".join(
                    f"{r['robot']} ({_ratio(r['python_fast']['batch_speedup'], 1.0)}; it hands "
                    f"{pct((r.get('native') or {}).get('deferred_fraction'))} of the batch poses to the "
                    f"Python path, which sends {pct(r['python_fast'].get('deferred_fraction'))} of all the "
                    "poses on to the reference runtime)"
                    for r in slower
                )
                + "."
            )
    others = [r for r in fast_rows if r["path"] == "fast"]
    if others:
        out.append(
            "- Python fast path as default (no native backend): "
            + ", ".join(f"{r['robot']} ({r.get('native_reason', '-')})" for r in others)
            + "; speed-up over the reference runtime single-pose "
            f"{spread_of([(r.get('reference') or {}).get('single_speedup') for r in others])}, batch "
            f"{spread_of([(r.get('reference') or {}).get('batch_speedup') for r in others])}."
        )
    if fast_rows:
        out.append(
            f"- Python fast path over the reference runtime, the {len(fast_rows)} robots that have one "
            "(ratio of the two speed-ups above for native modules): single-pose "
            + spread_of(
                [
                    (r.get("reference") or {}).get("single_speedup")
                    / ((r.get("python_fast") or {}).get("single_speedup") or 1.0)
                    if (r.get("reference") or {}).get("single_speedup")
                    else None
                    for r in fast_rows
                ]
            )
            + ", batch "
            + spread_of(
                [
                    (r.get("reference") or {}).get("batch_speedup")
                    / ((r.get("python_fast") or {}).get("batch_speedup") or 1.0)
                    if (r.get("reference") or {}).get("batch_speedup")
                    else None
                    for r in fast_rows
                ]
            )
            + " (what the default path gave before the native backend)."
        )
    out.append(
        f"- Poses: FK of `sample_configurations` (seed {SEED_SINGLE} single, {SEED_BATCH} batch); "
        f"single-pose time is the median per `solve` call over up to {opts.poses} poses (fewer when the "
        f"solver is slow: about {opts.budget:g} s per robot and phase), batch throughput the best of up "
        f"to 3 `solve_batch` calls on {opts.batch} poses (fewer when slow, shown in brackets). EAIK gets "
        "the same pose sets (its batch the full set) and one value of each free joint for all poses."
    )
    out.append(
        "- Ours is the module as compiled: its default path (`NATIVE` and `FAST_PATH` True where the "
        "module has a C chain and a fast path). The Python fast path and reference figures time the "
        "same module with `NATIVE = False` and with `FAST_PATH = False` on the same poses, as more "
        "phases under the same budget (the first poses of each set when it cuts them short: pose counts "
        "in brackets). Accuracy and the EAIK ratios are of the default path. Batch threads: the native "
        f"path {meta.get('native_threads', '?')} C threads, EAIK {opts.threads} threads; the Python paths "
        "one thread (numpy)."
    )
    out.append(
        "- Handed-on fractions are counted untimed, by running the module's own first stage. A pose the "
        "native backend hands on costs the C attempt plus the Python path (which may in turn defer it to "
        "the reference runtime); one the Python fast path defers costs the fast attempt plus a reference "
        "solve: the medians hide them but batch throughput does not. The sampled joint values include "
        "special angles (each revolute value with probability 0.25), so a few percent of the poses sit on "
        "degenerate geometry (a wrist at 0, aligned axes)."
    )
    pairs = (
        ("python_fast", "disagree", "native and the Python fast path"),
        ("reference", "disagree", "the default path and the reference runtime"),
        ("reference", "python_disagree", "the Python fast path and the reference runtime"),
    )

    def python_as_default(res, kind):  # the Python fast path disagrees with the reference on the same poses
        return bool(res.get(f"{kind}_disagree")) and all(
            res.get(f"{kind}_python_disagree{x}") == res.get(f"{kind}_disagree{x}")
            for x in ("", "_poses", "_examples")
        )

    for r in fast_rows:
        for part, key, what in pairs:
            res = r.get(part) or {}
            for kind in ("single", "batch"):
                if not res.get(f"{kind}_{key}"):
                    continue
                same = part == "reference" and python_as_default(res, kind)
                if same and key == "python_disagree":
                    continue  # said on the default path's line
                ex = ", ".join(str(e["pose"]) for e in res[f"{kind}_{key}_examples"])
                out.append(
                    f"- {r['robot']}: {what} disagree on {res[f'{kind}_{key}']} of "
                    f"{res[f'{kind}_{key}_poses']} {kind} pose(s) (first: {ex}; joint vectors in the JSON)"
                    + (
                        "; so do the Python fast path and the reference runtime, on the same poses."
                        if same
                        else "."
                    )
                )
    out.append(
        "- EAIK is built from our chain's home twists: H = axis directions, P = differences of axis "
        "points (home tool position last), tool rotation = home rotation; its FK and solutions are "
        "checked with our chain's FK above. Compile time is a median of "
        f"{opts.compiles} `compile_robot` calls; EAIK's build is a median of 50 constructor calls."
    )
    out.append(
        "- Other sessions may run tests on this 2-core machine at the same time: absolute figures are "
        "noisy, ratios less so."
    )
    for r in failed:
        out.append(f"- {r['robot']}: {r['error']}")
    if profile:
        out += [
            "",
            f"## Where a single-pose solve goes ({profile['robot']}, {profile['method']}, "
            f"{profile['path']} path)",
            "",
            f"cProfile of the default path over {profile['calls']} `solve` calls ({profile['poses']} poses "
            f"x {profile['rounds']}"
            + (
                f"; {profile['deferred_poses']} of the poses handed to the "
                + ("Python path" if profile["path"] == "native" else "reference runtime")
                if profile.get("deferred_poses") is not None
                else ""
            )
            + f"): {profile['profiled_us_per_solve']:.1f} us "
            f"per call under the profiler ({profile['unprofiled_us_per_solve']:.1f} us without, median), "
            f"{profile['function_calls_per_solve']:.0f} function calls per solve. Own time: "
            + ", ".join(f"{k} {v:.0%}" for k, v in profile["own_time_shares"].items())
            + ". The profiler adds a cost to every function call, so the shares lean toward functions "
            "called many times per solve (the small kernels of `subproblems/fast.py` on the Python path); "
            "a ctypes call is not a profiled function, so the time spent in C counts as own time of its "
            "caller (the `NativeChain` method in `subproblems/native.py`).",
            "",
            "Project functions by cumulative time (per solve):",
            "",
            "```",
            profile["by_cumulative_time"],
            "```",
            "",
            "All functions by own time (per solve):",
            "",
            "```",
            profile["by_own_time"],
            "```",
        ]
    else:
        out += ["", "No closed-form robot among those benchmarked: no profile."]
    return "\n".join(out) + "\n"


def _json_clean(x):
    """Plain JSON: non-finite floats become null, numpy scalars Python numbers."""
    if isinstance(x, dict):
        return {k: _json_clean(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_json_clean(v) for v in x]
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


# ---- main ------------------------------------------------------------------------------------------


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robots", nargs="+", metavar="NAME", help="zoo robots (default: the whole zoo)")
    p.add_argument("--poses", type=int, help="single-pose targets per robot (300; --quick 50)")
    p.add_argument("--batch", type=int, help="poses in the batch call (10000; --quick 1000)")
    p.add_argument("--compiles", type=int, help="compiles per robot, median (3; --quick 1)")
    p.add_argument("--budget", type=float, help="seconds per robot and timing phase (8; --quick 2)")
    p.add_argument(
        "--threads",
        type=int,
        default=os.cpu_count() or 1,
        help="EAIK batch threads (ours: IKC_THREADS, default the usable cores)",
    )
    p.add_argument("--quick", action="store_true", help="smaller defaults (see above) for a smoke run")
    p.add_argument("--no-eaik", action="store_true", help="skip EAIK")
    p.add_argument("--profile-robot", help="robot to profile (default: a closed-form one benchmarked)")
    p.add_argument("--out", type=Path, default=RESULTS, help="results folder")
    p.add_argument("--eaik-worker", nargs=3, metavar=("STAGE", "IN", "OUT"), help=argparse.SUPPRESS)
    opts = p.parse_args(argv)
    defaults = (50, 1000, 1, 2.0) if opts.quick else (300, 10000, 3, 8.0)
    for key, value in zip(("poses", "batch", "compiles", "budget"), defaults):
        if getattr(opts, key) is None:
            setattr(opts, key, value)
    opts.min_poses = min(20, opts.poses)
    return opts


def main(argv=None) -> int:
    opts = parse_args(argv)
    if opts.eaik_worker:
        _eaik_worker(*opts.eaik_worker)
        return 0
    # An empty native cache for this run: every robot's C chain is really built (and the build timed).
    cache = tempfile.mkdtemp(prefix="ikc_bench_cache_")
    os.environ["IKC_CACHE"] = cache
    try:
        return _bench_all(opts)
    finally:
        shutil.rmtree(cache, ignore_errors=True)


def _bench_all(opts) -> int:
    from ikcompiler.inputs.zoo import zoo_names

    names = opts.robots or zoo_names()
    meta = _machine()
    print(f"ikcompiler speed benchmark: {len(names)} robots, {meta['cpu']}, EAIK {meta['eaik']}", flush=True)
    rows = []
    t_all = time.perf_counter()
    for name in names:
        t0 = time.perf_counter()
        try:
            row = bench_robot(name, opts)
        except Exception as exc:  # one robot's failure is a table row, not the end of the run
            row = {"robot": name, "error": f"{type(exc).__name__}: {exc}".splitlines()[0][:200]}
            traceback.print_exc()
        rows.append(row)
        e = row.get("eaik") or {}
        print(
            f"  {name:14s} {row.get('method', 'FAILED'):12s} {row.get('path', '-'):9s}"
            f" compile {_fmt(row.get('compile_s'), '.3f')} s"
            f"  solve {_fmt(row.get('single_us'), '.1f')} us  batch {_fmt(row.get('batch_pps'), ',.0f')}/s"
            + (
                f"  C build {_fmt(row['native_build_s'] * 1e3, ',.0f')} ms"
                f" [python fast {_fmt(py.get('single_us'), '.0f')} us {_fmt(py.get('batch_pps'), ',.0f')}/s,"
                f" x{_fmt(py.get('single_speedup'), '.3g')}/x{_fmt(py.get('batch_speedup'), '.3g')},"
                f" disagree {py.get('single_disagree')}/{py.get('batch_disagree')}]"
                if row.get("path") == "native" and (py := row.get("python_fast"))
                else ""
            )
            + (
                f"  [ref {_fmt(ref.get('single_us'), '.0f')} us {_fmt(ref.get('batch_pps'), ',.0f')}/s,"
                f" x{_fmt(ref.get('single_speedup'), '.3g')}/x{_fmt(ref.get('batch_speedup'), '.3g')},"
                f" deferred {_fmt(row.get('deferred_fraction'), '.1%')},"
                f" disagree {ref.get('single_disagree')}/{ref.get('batch_disagree')}]"
                if (ref := row.get("reference"))
                else ""
            )
            + f"  | EAIK {_fmt(e.get('single_us'), '.1f')} us {_fmt(e.get('batch_pps'), ',.0f')}/s"
            f" {e.get('reason') or e.get('error') or e.get('batch_error') or ''}"
            f"  ({time.perf_counter() - t0:.1f} s)",
            flush=True,
        )

    profile = None
    target = opts.profile_robot
    if target is None:
        closed = [r for r in rows if r.get("method") == "closed-form"]
        closed = [r for r in closed if r.get("path") in ("native", "fast")] or closed  # a fast default
        if closed:
            target = max(closed, key=lambda r: (r["robot"] == "puma560", r["dof"] == 6, r["dof"]))["robot"]
    if target is not None:
        prow = next((r for r in rows if r["robot"] == target and "_module" in r), None)
        try:
            if prow is None:
                prow = bench_robot(target, argparse.Namespace(**{**vars(opts), "no_eaik": True}))
            profile = profile_solve(prow)
            print(
                f"profile of {target}:\n{profile['by_cumulative_time']}\n{profile['by_own_time']}", flush=True
            )
        except Exception as exc:
            print(f"profile of {target} failed: {exc}", flush=True)

    for r in rows:
        r.pop("_module", None)
        r.pop("_poses", None)
    opts.out.mkdir(parents=True, exist_ok=True)
    settings = {k: str(v) if isinstance(v, Path) else v for k, v in vars(opts).items()}
    settings.pop("eaik_worker", None)
    doc = _json_clean({"meta": meta, "settings": settings, "robots": rows, "profile": profile})
    (opts.out / "compiler.json").write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n")
    (opts.out / "compiler.md").write_text(render_markdown(rows, profile, meta, opts))
    print(f"wrote {opts.out / 'compiler.md'} and compiler.json ({time.perf_counter() - t_all:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
