"""Single-pose ``solve`` time on special poses against random ones, and the peak memory of a large
batch, for every zoo robot (issue 11 item 6, issue 10; docs/design.md section 6).

Special poses: FK of joint vectors whose values are drawn from {0, +-pi/2, pi} (home and taught
positions are such poses; wrists line up, self-motions appear); random poses: joint values uniform
inside the limits (at most +-pi).  300 of each per robot (fixed seeds); each pose is timed three
times and its fastest time kept (the machine is shared).  Reported: median and 99th percentile of
each set and their ratios to the random median (goal: special median <= 3x, p99 <= 30x).

Memory: ``solve_batch`` of 100,000 random poses in a fresh subprocess per robot; its peak resident
set (``resource.getrusage`` ``ru_maxrss``) before and after the batch (goal: within 2 GB).

``python benchmarks/special_poses.py`` writes ``benchmarks/results/special_poses.md``;
``--robots NAME ...`` a subset, ``--batch N`` another batch size, ``--no-memory`` timing only;
``--causes`` counts instead why the C finish hands each special pose back (``special_causes.md``).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SPECIAL = (0.0, np.pi / 2, -np.pi / 2, np.pi)
POSES = 300
REPEATS = 3
MEMORY_GOAL_MB = 2048


def _setup(name: str):
    """(chain, module, free joint positions) of a zoo robot as the other benchmarks compile it."""
    from ikcompiler import load_robot
    from ikcompiler.compiler import compile_robot

    chain = load_robot(name)
    free = (chain.independent_names[-1],) if chain.dof > 6 else ()
    module = compile_robot(chain, free=free)
    module._native_chain()  # the one-off C build before any timing
    return chain, module, [module.JOINT_NAMES.index(f) for f in free]


def _targets(module, Q: np.ndarray) -> np.ndarray:
    G = np.array([module.fk(q) for q in Q])
    return {"position": G[:, :3, 3], "orientation": G[:, :3, :3]}.get(module.TARGET, G)


def _joint_sets(module, rng, n: int):
    lo = np.maximum(module.LOWER, -np.pi)
    hi = np.minimum(module.UPPER, np.pi)
    random = rng.uniform(lo, hi, size=(n, len(lo)))
    special = rng.choice(SPECIAL, size=(n, len(lo)))
    prismatic = np.array([k == "T" for k in module.JOINT_TYPES])
    special[:, prismatic] = random[:, prismatic]  # a prismatic joint has no special angle: in range
    return special, random


def _taught(module, rng, n: int, random: np.ndarray) -> np.ndarray:
    """Special values inside each joint's limits only (taught positions lie inside the limits; the
    plain special set also draws poses whose sampled branch is outside them)."""
    Q = random.copy()
    for j, kind in enumerate(module.JOINT_TYPES):
        allowed = [v for v in SPECIAL if module.LOWER[j] <= v <= module.UPPER[j]]
        if kind == "R" and allowed:
            Q[:, j] = rng.choice(allowed, size=n)
    return Q


def _times(module, T, Q, free_cols) -> np.ndarray:
    out = np.empty(len(T))
    for i in range(len(T)):
        free = tuple(Q[i, free_cols])
        best = np.inf
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            module.solve(T[i], *free)
            best = min(best, time.perf_counter() - t0)
        out[i] = best
    return out


def time_robot(name: str) -> dict:
    chain, module, free_cols = _setup(name)
    special, random = _joint_sets(module, np.random.default_rng(7), POSES)
    row = {"robot": name, "method": module.METHOD,
           "path": "native" if module._native_chain() is not None else
           ("fast" if module.FAST_PATH else "reference")}
    taught = _taught(module, np.random.default_rng(8), POSES, random)
    for label, Q in (("random", random), ("special", special), ("taught", taught)):
        T = _targets(module, Q)
        module.solve(T[0], *tuple(Q[0, free_cols]))  # warm
        t = _times(module, T, Q, free_cols)
        row[f"{label}_median_us"] = float(np.median(t) * 1e6)
        row[f"{label}_p99_us"] = float(np.percentile(t, 99) * 1e6)
        row[f"{label}_over_1ms"] = int((t > 1e-3).sum())
    base = row["random_median_us"]
    row["special_median_ratio"] = row["special_median_us"] / base
    row["special_p99_ratio"] = row["special_p99_us"] / base
    row["taught_median_ratio"] = row["taught_median_us"] / base
    row["taught_p99_ratio"] = row["taught_p99_us"] / base
    return row


REASONS = {0: "settled", 1: "defer", 2: "nan", 3: "clamped", 4: "reps", 5: "family", 6: "rotation",
           7: "search", 8: "snapped", 9: "lock"}  # subproblems/fast_finish.h IKC_WHY_*


def causes_robot(name: str) -> dict:
    """Why the C finish hands each special (and taught) pose back: {cause: count} per pose set, the
    cause of the main chain and, after '+', of the alternative chain (fast_finish.h IKC_WHY_*)."""
    _, module, free_cols = _setup(name)
    native = module._native_chain()
    special, random = _joint_sets(module, np.random.default_rng(7), POSES)
    taught = _taught(module, np.random.default_rng(8), POSES, random)
    out = {"robot": name}
    for label, Q in (("special", special), ("taught", taught)):
        counts: dict[str, int] = {}
        T = _targets(module, Q)
        for i in range(len(T)):
            if native is None:
                cause = "no C"
            elif native.one(T[i], tuple(Q[i, free_cols]), True) is not None:
                cause = "settled"
            else:
                why = native.last_reason()
                cause = "unknown" if why is None else REASONS.get(why % 16, str(why % 16))
                if why is not None and why >= 16:
                    cause += "+" + REASONS.get(why // 16, str(why // 16))
            counts[cause] = counts.get(cause, 0) + 1
        out[label] = counts
    return out


def _causes_table(rows) -> str:
    lines = ["# Why the C finish hands special poses back", "",
             "Written by `python benchmarks/special_poses.py --causes`: for the 300 special and 300 taught "
             "poses of each robot (the same poses as `special_poses.md`), the C finish's cause "
             "(`subproblems/fast_finish.h` `IKC_WHY_*`) for each pose it hands back to Python; "
             "`a+b`: main chain a, alternative chain b.", "",
             "| robot | set | settled in C | handed back, by cause |", "|---|---|---:|---|"]
    for r in rows:
        for label in ("special", "taught"):
            c = dict(r.get(label, {}))
            settled = c.pop("settled", 0)
            rest = ", ".join(f"{k} {v}" for k, v in sorted(c.items(), key=lambda kv: -kv[1])) or "none"
            lines.append(f"| {r['robot']} | {label} | {settled} | {rest} |")
    return "\n".join(lines) + "\n"


def memory_robot(name: str, batch: int) -> dict:
    """Peak RSS (MB) before and after solve_batch of ``batch`` random poses (run in its own process)."""
    import resource

    _, module, free_cols = _setup(name)
    rng = np.random.default_rng(3)
    _, Q = _joint_sets(module, rng, 2000)
    T = _targets(module, Q)
    reps = -(-batch // len(T))
    Ts = np.concatenate([T] * reps)[:batch]
    free = [np.concatenate([Q[:, c]] * reps)[:batch] for c in free_cols]
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    t0 = time.perf_counter()
    module.solve_batch(Ts, *free)
    dt = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return {"robot": name, "rss_before_mb": before, "rss_peak_mb": after, "batch": batch, "batch_s": dt}


def _subprocess(args: list[str]) -> dict:
    res = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True)
    if res.returncode != 0:
        return {"error": (res.stderr.strip().splitlines() or ["failed"])[-1]}
    return json.loads(res.stdout.strip().splitlines()[-1])


def _table(rows, mem, batch, load=None) -> str:
    lines = [
        "# Special poses and batch memory",
        "",
        f"Written by `python benchmarks/special_poses.py` on {datetime.date.today()}, "
        f"{platform.machine()}, Python {platform.python_version()} (2 cores shared with other jobs).",
        f"{POSES} special poses (joint values in {{0, +-pi/2, pi}}) and {POSES} random ones per robot; "
        f"single-pose `solve`, fastest of {REPEATS} runs per pose, in us.  Goal (issue 11): special "
        "median <= 3x and p99 <= 30x the random median.  Memory: peak RSS of a fresh process around "
        f"`solve_batch` of {batch:,} random poses (goal: <= {MEMORY_GOAL_MB} MB).  *Taught*: {POSES} "
        "more special poses with each revolute value drawn only among the special values inside its "
        "limits (a taught position lies inside them; the plain special set also draws branches outside "
        "the limits, where the fast finish cannot show that nothing is left inside them).",
        "",
        "| robot | method | path | random median | random p99 | special median | special p99 | "
        "median ratio | p99 ratio | special > 1 ms | taught median ratio | taught p99 ratio | "
        "taught > 1 ms | "
        "RSS before (MB) | peak RSS (MB) | batch (s) |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        m = mem.get(r["robot"], {})
        if "error" in r:
            lines.append(f"| {r['robot']} | error: {r['error']} |" + " |" * 15)
            continue
        mb = (f"{m['rss_before_mb']:.0f} | {m['rss_peak_mb']:.0f} | {m['batch_s']:.1f}" if "rss_peak_mb" in m
              else f"{m.get('error', 'not measured')} | | ")
        lines.append(
            f"| {r['robot']} | {r['method']} | {r['path']} | {r['random_median_us']:.1f} | "
            f"{r['random_p99_us']:.1f} | {r['special_median_us']:.1f} | {r['special_p99_us']:.1f} | "
            f"{r['special_median_ratio']:.2f} | {r['special_p99_ratio']:.1f} | {r['special_over_1ms']} | "
            f"{r['taught_median_ratio']:.2f} | {r['taught_p99_ratio']:.1f} | {r['taught_over_1ms']} | "
            f"{mb} |")
    miss = [r["robot"] for r in rows if "error" not in r
            and (r["special_median_ratio"] > 3 or r["special_p99_ratio"] > 30)]
    taught = [r["robot"] for r in rows if "error" not in r
              and (r["taught_median_ratio"] > 3 or r["taught_p99_ratio"] > 30)]
    over = [n for n, m in mem.items() if m.get("rss_peak_mb", 0) > MEMORY_GOAL_MB or "error" in m]
    lines += ["", f"Timing goal missed by: {', '.join(miss) or 'none'}; on taught poses by: "
              f"{', '.join(taught) or 'none'}.  "
              f"Memory goal missed by: {', '.join(over) or 'none'}.", ""]
    if load:  # the machine is shared: its 1-minute load average when the run started and ended
        lines += [f"Load average (1 min) at the start and end of the run: {load[0]:.1f}, {load[1]:.1f}.", ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="*")
    ap.add_argument("--batch", type=int, default=100_000)
    ap.add_argument("--no-memory", action="store_true")
    ap.add_argument("--causes", action="store_true", help="count why poses are handed back instead")
    ap.add_argument("--causes-one", help=argparse.SUPPRESS)
    ap.add_argument("--time-one", help=argparse.SUPPRESS)
    ap.add_argument("--memory-one", help=argparse.SUPPRESS)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "special_poses.md"))
    args = ap.parse_args(argv)
    if args.time_one:
        print(json.dumps(time_robot(args.time_one)))
        return 0
    if args.causes_one:
        print(json.dumps(causes_robot(args.causes_one)))
        return 0
    if args.memory_one:
        print(json.dumps(memory_robot(args.memory_one, args.batch)))
        return 0
    from ikcompiler.inputs.zoo import zoo_names

    if args.causes:
        rows = []
        for name in args.robots or zoo_names():
            rows.append(_subprocess(["--causes-one", name]) | {"robot": name})
            print(json.dumps(rows[-1]), flush=True)
        out = Path(args.out)
        if args.out == ap.get_default("out"):
            out = out.with_name("special_causes.md")
        out.write_text(_causes_table(rows))
        print(f"wrote {out}")
        return 0
    rows, mem = [], {}
    load = [os.getloadavg()[0]]
    for name in args.robots or zoo_names():
        row = _subprocess(["--time-one", name])
        row.setdefault("robot", name)
        rows.append(row)
        print(json.dumps(row), flush=True)
        if not args.no_memory:
            mem[name] = _subprocess(["--memory-one", name, "--batch", str(args.batch)])
            print(json.dumps(mem[name]), flush=True)
    load.append(os.getloadavg()[0])
    Path(args.out).write_text(_table(rows, mem, args.batch, load))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
