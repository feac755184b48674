"""The general 6R elimination (subproblems.general6) against the search fallback it replaces (issue 10).

* random general 6R arms (axis directions uniform on the sphere, axis points in a 1 m cube, random
  tool offset; fixed seeds 0..ARMS-1), POSES poses each from forward kinematics of uniform joint vectors:
  completeness (the sampled vector among the solutions to 1e-6 rad), the count of real solutions, the
  worst residual of any returned row recomputed by FK (``subproblems.plan_runtime.fk_batch`` on the
  given twists; position / size and Frobenius rotation), batched time per pose (wall and process CPU),
  single-pose ``solve`` time (median over calls), ``prepare`` time and the compile time of the module;
* the same arms compiled with the general solver switched off (``compiler.USE_GENERAL6 = False``: the
  1-D or 2-D search), on the first SEARCH_POSES poses of the first SEARCH_ARMS arms (it is slow), in
  chunks of 4 poses to bound its memory;
* the zoo's Jaco (no closed form): general-6r vs the 1-D search on the same generic poses;
* the native general-6r path (``subproblems/general6.h``, the generated module's default): targets
  handed back to the Python general6, single-pose ``solve`` median and 90th percentile, batch CPU per
  pose, on the random arms and on the Jaco (generic and special-angle poses inside its limits);
* 6-joint chains with prismatic joints (the random arms with joints made prismatic along their drawn
  directions, for each joint string the elimination accepts): recovery, real solutions, residual, CPU;
* the compile-time choice between the 1-D search and general-6r (``ikcompiler.general6_route``) on
  rtb-data's abb_irb140 (where the 1-D search is complete) and the Jaco (where it is not): the plan's
  verdict, both solvers' times on 200 poses inside the limits, and general-6r's doubtful poses (the
  costly re-solve path) with its chosen order and with the plain joint order.

The machine is shared (2 cores, several engineers): the load average is written with the results and
times are inflated by it; the CPU-time column is less affected.  Results: ``benchmarks/results/general6.md``.

Usage::

    .venv/bin/python benchmarks/general6.py [--arms 10] [--poses 500] [--search-arms 3] [--search-poses 20]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
# Run as a script, this folder is first on sys.path: benchmarks/subproblems.py would shadow the package.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != ROOT / "benchmarks"]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ikcompiler import compile_robot, load_robot  # noqa: E402
from ikcompiler import compiler as _compiler  # noqa: E402
from ikcompiler.configs import random_6r_chain  # noqa: E402
from subproblems import general6 as g6  # noqa: E402
from subproblems.plan_runtime import fk_batch  # noqa: E402

OUT = Path(__file__).parent / "results" / "general6.md"


def _gap(rows, q):
    if len(rows) == 0:
        return math.inf
    return float(np.abs(np.angle(np.exp(1j * (rows - q)))).max(axis=1).min())


def _residual(twists, home, size, rows, T):
    if len(rows) == 0:
        return 0.0
    G = fk_batch(twists, rows, home)
    dp = np.linalg.norm(G[:, :3, 3] - T[:3, 3], axis=1).max() / size
    return max(dp, np.linalg.norm(G[:, :3, :3] - T[:3, :3], axis=(1, 2)).max())


def _recovery(S, V, Q):
    return sum(_gap(S[n][V[n]], Q[n]) < 1e-6 for n in range(len(Q)))


def bench_arm(seed, poses, log):
    chain = random_6r_chain(seed)
    tw, home = chain.twists, np.asarray(chain.home)
    t = time.perf_counter()
    solver = g6.prepare(tw, home, chain.scale)
    t_prep = time.perf_counter() - t
    t = time.perf_counter()
    module = compile_robot(chain)
    t_compile = time.perf_counter() - t
    Q = np.random.default_rng(1000 + seed).uniform(-math.pi, math.pi, size=(poses, 6))
    T = chain.fk_batch(Q)
    t, c = time.perf_counter(), time.process_time()
    b = solver.solve_batch(T)
    wall, cpu = (time.perf_counter() - t) / poses, (time.process_time() - c) / poses
    counts = b.valid.sum(axis=1)
    hits = _recovery(b.Q, b.valid, Q)
    worst = max(_residual(tw, home, chain.scale, b.Q[n][b.valid[n]], T[n]) for n in range(poses))
    single = []
    for n in range(min(60, poses)):
        t = time.perf_counter()
        solver.solve(T[n])
        single.append(time.perf_counter() - t)
    t = time.perf_counter()
    Sm, Vm = module.solve_batch(T)
    wall_mod = (time.perf_counter() - t) / poses
    hits_mod = _recovery(Sm, Vm, Q)
    worst_mod = max(_residual(tw, home, chain.scale, Sm[n][Vm[n]], T[n]) for n in range(poses))
    native = _native_numbers(module, T)
    log(f"arm {seed}: recovered {hits}/{poses}, module {hits_mod}/{poses}, {wall * 1e6:.0f} us/pose; "
        f"native single {native['single'] * 1e6:.0f} us, handed back {native['back']}")
    return {
        "seed": seed, "method": module.METHOD, "poses": poses, "hits": hits, "hits_mod": hits_mod,
        "counts": np.bincount(counts, minlength=17), "worst": worst, "wall": wall, "cpu": cpu,
        "single": float(np.median(single)), "wall_mod": wall_mod, "prep": t_prep, "compile": t_compile,
        "arr": solver.usable, "worst_mod": worst_mod, **{f"native_{k}": v for k, v in native.items()},
    }


def _native_numbers(module, T):
    """The module's native general-6r path (subproblems/general6.h) on targets T: targets handed back
    to the Python general6 (``NativeChain.exact`` None), median and 90th percentile of one ``solve``
    (wall, warm, every target), and one ``solve_batch`` in process CPU per pose (C threads included)."""
    nc = module._SOLVER.native_chain()
    if nc is None:
        return {"back": -1, "single": math.nan, "p90": math.nan, "batch_cpu": math.nan}
    back = sum(nc.exact(t, (), True) is None for t in T)
    module.solve(T[0])
    single = []
    for t in T:
        s = time.perf_counter()
        module.solve(t)
        single.append(time.perf_counter() - s)
    c = time.process_time()
    module.solve_batch(T)
    batch = (time.process_time() - c) / len(T)
    return {"back": int(back), "single": float(np.median(single)), "p90": float(np.percentile(single, 90)),
            "batch_cpu": batch}


def native_jaco_section(log, poses):
    """The zoo's Jaco (general-6r) through its module: poses inside the limits, generic and special."""
    from ikcompiler.verify import sample_configurations

    chain = load_robot("jaco")
    t = time.perf_counter()
    module = compile_robot(chain)
    t_compile = time.perf_counter() - t
    lines = ["", "## Native path on the zoo's Jaco", "",
             f"{poses} poses inside the limits (seed 21), generic and with a third of the joint values at "
             "0, +-pi/2, pi. Handed back: targets the C gives to the Python general6. Single: module `solve` "
             "per pose (wall, median / 90th percentile); batch: one module `solve_batch` (process CPU per "
             "pose). Python: the same module with `NATIVE = False`.", "",
             "| poses | recovered | handed back | native single us (median / p90) | native batch CPU us "
             "| Python single us (median) | Python batch CPU us | compile s |",
             "|---|---|---|---|---|---|---|---|"]
    for special in (0.0, 0.3):
        Q = sample_configurations(chain, poses, seed=21, special=special)
        T = chain.fk_batch(Q)
        nat = _native_numbers(module, T)
        S, V = module.solve_batch(T)
        hits = _recovery(S, V, Q)
        module.NATIVE = False
        try:
            py_single = []
            for t in T[:60]:
                s = time.perf_counter()
                module.solve(t)
                py_single.append(time.perf_counter() - s)
            c = time.process_time()
            module.solve_batch(T)
            py_batch = (time.process_time() - c) / len(T)
        finally:
            module.NATIVE = True
        label = "generic" if special == 0 else "special (1/3)"
        log(f"jaco {label}: native single {nat['single'] * 1e6:.0f} us, handed back {nat['back']}")
        lines.append(f"| {label} | {hits}/{poses} | {nat['back']}/{poses} | {nat['single'] * 1e6:.0f} / "
                     f"{nat['p90'] * 1e6:.0f} | {nat['batch_cpu'] * 1e6:.0f} "
                     f"| {np.median(py_single) * 1e6:.0f} "
                     f"| {py_batch * 1e6:.0f} | {t_compile:.2f} |")
    return lines


def bench_search(chain, Q, log):
    """The search fallback (general solver off) on poses Q: (method, hits, s/pose, rows)."""
    _compiler.USE_GENERAL6 = False
    try:
        module = compile_robot(chain)
    finally:
        _compiler.USE_GENERAL6 = True
    T = chain.fk_batch(Q)
    S, V, spent = [], [], 0.0
    for start in range(0, len(Q), 4):
        t = time.perf_counter()
        s, v = module.solve_batch(T[start:start + 4], limits=False)
        spent += time.perf_counter() - t
        S.append(s)
        V.append(v)
        log(f"  {chain.name} search: {start + len(s)}/{len(Q)} poses")
    width = max(s.shape[1] for s in S)
    S = np.concatenate([np.pad(s, ((0, 0), (0, width - s.shape[1]), (0, 0))) for s in S])
    V = np.concatenate([np.pad(v, ((0, 0), (0, width - v.shape[1]))) for v in V])
    return module.METHOD, _recovery(S, V, Q), spent / len(Q), S, V


def _cpu_per_pose(solver, T, single=60, **kw):
    """Process CPU per pose of one solve_batch over T and of solve on each of the first ``single``."""
    c = time.process_time()
    solver.solve_batch(T, **kw)
    batch = (time.process_time() - c) / len(T)
    c = time.process_time()
    for t in T[:single]:
        solver.solve(t)
    return batch, (time.process_time() - c) / min(single, len(T))


def prismatic_section(log, poses, arms=3):
    """Prismatic joints at positions the elimination accepts (docs/general6.md, "Prismatic joints")."""
    from ikcompiler.configs import random_6r_geometry

    lines = ["", "## 6-joint chains with prismatic joints", "",
             f"Random arms (seeds 0..{arms - 1}) with the joints marked T sliding along their drawn axis "
             f"directions; {poses} poses each, prismatic values uniform in +-size. Recovered: revolute "
             "values to 1e-6 rad, prismatic to 1e-6 of the size. CPU: one `solve_batch`, per pose.", "",
             "| joints | recovered | real solutions 2/4/6/8/10/12/14/16 | odd counts | worst residual "
             "| batch CPU us |",
             "|---|---|---|---|---|---|"]
    for kinds in ("TRRRRR", "RRRRRT", "RTRRRR", "TTRRRR", "RRRRTT"):
        prism = np.array([k == "T" for k in kinds])
        hits = total = 0
        counts = np.zeros(17, dtype=int)
        worst, cpu = 0.0, []
        for seed in range(arms):
            tw, home = random_6r_geometry(seed)
            tw[prism] = np.concatenate([tw[prism, 3:], np.zeros((int(prism.sum()), 3))], axis=1)
            solver = g6.prepare(tw, home)
            size = solver.scale
            rng = np.random.default_rng(300 + seed)
            Q = rng.uniform(-math.pi, math.pi, size=(poses, 6))
            Q[:, prism] = rng.uniform(-size, size, size=(poses, int(prism.sum())))
            T = fk_batch(tw, Q, home)
            c = time.process_time()
            b = solver.solve_batch(T)
            cpu.append((time.process_time() - c) / poses)
            for n in range(poses):
                rows = b.Q[n][b.valid[n]]
                counts[len(rows)] += 1
                total += 1
                if len(rows):
                    turn = np.abs(np.angle(np.exp(1j * (rows - Q[n]))))
                    gap = np.where(prism, np.abs(rows - Q[n]) / size, turn)
                    hits += gap.max(axis=1).min() < 1e-6
                    worst = max(worst, _residual(tw, home, size, rows, T[n]))
        log(f"prismatic {kinds}: {hits}/{total}")
        dist = "/".join(str(int(counts[k])) for k in range(2, 17, 2))
        odd = int(counts[1::2].sum())
        us = np.median(cpu) * 1e6
        lines.append(f"| {kinds} | {hits}/{total} | {dist} | {odd} | {worst:.1e} | {us:.0f} |")
    return lines


def route_section(log, poses=200):
    """The sampled 1-D search / general-6r decision and the doubtful-pose path (issue 10 item 1)."""
    from ikcompiler import robotdb
    from ikcompiler.compiler import compile_plan

    robots = [load_robot("jaco")]
    if robotdb.installed("rtb-data"):
        entry = next(e for e in robotdb.discover(["rtb-data"]).chains if e.urdf.name == "irb140.urdf")
        robots.insert(0, entry.load())
    lines = ["", "## The 1-D search or general-6r: the compile-time decision", "",
             f"Times: process CPU per pose on {poses} poses inside the limits (seed 9), warm; batch = one "
             "`solve_batch`, single = `solve` per pose. Doubtful: poses sent down general-6r's re-solve path "
             "by its first order (chosen order / the plain joint order).", "",
             "| robot | plan method | verdict (plan note) | 1-D search batch us | 1-D search single us "
             "| general-6r batch us | general-6r single us | general-6r plain order batch / single us "
             "| doubtful chosen / plain |",
             "|---|---|---|---|---|---|---|---|---|"]
    for chain in robots:
        log(f"route: {chain.name}")
        plan = compile_plan(chain)
        verdict = next((n for n in plan.notes if "1d-search kept" in n or "chosen over" in n), "-")
        lo, hi = np.maximum(chain.lower, -math.pi), np.minimum(chain.upper, math.pi)
        Q = np.random.default_rng(9).uniform(lo, hi, size=(poses, 6))
        T = chain.fk_batch(Q)
        _compiler.USE_GENERAL6 = False
        try:
            search = compile_robot(chain)
        finally:
            _compiler.USE_GENERAL6 = True
        search.solve_batch(T[:1], limits=False)
        s_batch, s_single = _cpu_per_pose(search, T, limits=False)
        out = []
        for arrangement in (None, list(range(6))):
            solver = g6.General6(chain.twists, chain.home, chain.scale, arrangement=arrangement)
            solver.solve_batch(T[:1])
            batch, single = _cpu_per_pose(solver, T)
            Gn = solver._norm(T) @ g6._inv(solver.Mn)
            _, _, doubt = solver._candidates(solver._arr[solver.usable[0]], Gn)
            out.append((batch, single, int(doubt.sum())))
        (gb, gs, gd), (pb, ps, pd) = out
        us = [f"{x * 1e6:.0f}" for x in (s_batch, s_single, gb, gs)]
        lines.append(f"| {chain.name} | {plan.method} | {verdict} | " + " | ".join(us)
                     + f" | {pb * 1e6:.0f} / {ps * 1e6:.0f} | {gd} / {pd} of {poses} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arms", type=int, default=10)
    ap.add_argument("--poses", type=int, default=500)
    ap.add_argument("--search-arms", type=int, default=3)
    ap.add_argument("--search-poses", type=int, default=20)
    args = ap.parse_args(argv)

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    load = os.getloadavg()
    rows = [bench_arm(seed, args.poses, log) for seed in range(args.arms)]
    lines = [
        "# General 6R elimination (subproblems.general6)",
        "",
        f"Command: `.venv/bin/python benchmarks/general6.py --arms {args.arms} --poses {args.poses} "
        f"--search-arms {args.search_arms} --search-poses {args.search_poses}`.",
        f"Machine: shared, 2 cores, load average at start {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} "
        "(1/5/15 min): wall times are inflated by the other jobs; the CPU column is process CPU time.",
        "",
        "## Random general 6R arms",
        "",
        "Recovered: the sampled joint vector among the returned rows (1e-6 rad). Residual: worst returned "
        "row, recomputed by FK, max(position / size, Frobenius rotation). Times per pose.",
        "",
        "Python: `subproblems.general6` alone (batch, and single-pose `solve` median over 60). Module: the "
        "generated module, whose default path is now the native general-6r elimination "
        "(`subproblems/general6.h`): handed back = targets it gives to the Python general6; native single = "
        "module `solve` per pose (wall, median over every pose); native batch = one module `solve_batch` "
        "(process CPU per pose, its C threads included).",
        "",
        "| arm | method | recovered | module recovered | real solutions 2/4/6/8/10/12/14/16 | worst residual "
        "| module worst residual | Python batch wall us | Python batch CPU us | Python single us "
        "| handed back | native single us (median / p90) | native batch CPU us | prepare s | compile s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        c = r["counts"]
        dist = "/".join(str(int(c[k])) for k in range(2, 17, 2))
        lines.append(
            f"| {r['seed']} | {r['method']} | {r['hits']}/{r['poses']} | {r['hits_mod']}/{r['poses']} "
            f"| {dist} "
            f"| {r['worst']:.1e} | {r['worst_mod']:.1e} | {r['wall'] * 1e6:.0f} | {r['cpu'] * 1e6:.0f} "
            f"| {r['single'] * 1e6:.0f} | {r['native_back']}/{r['poses']} | {r['native_single'] * 1e6:.0f} / "
            f"{r['native_p90'] * 1e6:.0f} | {r['native_batch_cpu'] * 1e6:.0f} | {r['prep']:.2f} "
            f"| {r['compile']:.2f} |"
        )
    total = sum(r["poses"] for r in rows)
    hits = sum(r["hits"] for r in rows)
    lines += [
        "",
        f"Total: {hits}/{total} poses recovered; median batch wall "
        f"{np.median([r['wall'] for r in rows]) * 1e6:.0f} "
        f"us/pose, CPU {np.median([r['cpu'] for r in rows]) * 1e6:.0f} us/pose; median single-pose solve "
        f"{np.median([r['single'] for r in rows]) * 1e6:.0f} us (Python); native: median single-pose "
        f"`solve` {np.median([r['native_single'] for r in rows]) * 1e6:.0f} us, batch CPU "
        f"{np.median([r['native_batch_cpu'] for r in rows]) * 1e6:.0f} us/pose, handed back "
        f"{sum(r['native_back'] for r in rows)}/{total}; median compile "
        f"{np.median([r['compile'] for r in rows]):.2f} s.",
    ]
    K = np.random.default_rng(0).normal(size=(2000, 24, 24))
    c = time.process_time()
    np.linalg.eigvals(K)
    floor = (time.process_time() - c) / 2000
    lines.append(f"Floor on this machine now: `numpy.linalg.eigvals` of one 24 x 24 in a stack of 2000: "
                 f"{floor * 1e6:.0f} us CPU.")
    lines += ["", "## Against the search fallback (general solver off), same arms and poses", "",
              "Rows: returned exact rows (limits off). Search only / general only: rows of one not among the "
              "other's (1e-6 rad). Search duplicates: search rows with another within 1e-6 rad. Times: one "
              "`solve_batch` per 4 poses (search) and one for all poses (general).", "",
              "| robot | search method | search recovered | search ms/pose | search rows | general recovered "
              "| general us/pose | general rows | search only | general only | search duplicates |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    targets = [(random_6r_chain(s), 1000 + s) for s in range(args.search_arms)] + [(load_robot("jaco"), 77)]
    for chain, seed in targets:
        Q = np.random.default_rng(seed).uniform(-math.pi, math.pi, size=(args.search_poses, 6))
        if chain.name == "jaco":
            Q = np.random.default_rng(seed).uniform(chain.lower, chain.upper, size=(args.search_poses, 6))
        method, s_hits, s_time, Ss, Vs = bench_search(chain, Q, log)
        module = compile_robot(chain)
        T = chain.fk_batch(Q)
        t = time.perf_counter()
        S, V = module.solve_batch(T, limits=False)
        g_time = (time.perf_counter() - t) / len(Q)
        only_s = only_g = dup = 0
        for n in range(len(Q)):
            rs, rg = Ss[n][Vs[n]], S[n][V[n]]
            only_s += sum(_gap(rg, r) > 1e-6 for r in rs)
            only_g += sum(_gap(rs, r) > 1e-6 for r in rg)
            dup += sum(_gap(np.delete(rs, i, 0), rs[i]) < 1e-6 for i in range(len(rs)))
        lines.append(f"| {chain.name} | {method} | {s_hits}/{len(Q)} | {s_time * 1e3:.1f} | {int(Vs.sum())} "
                     f"| {_recovery(S, V, Q)}/{len(Q)} | {g_time * 1e6:.0f} | {int(V.sum())} | {only_s} "
                     f"| {only_g} | {dup} |")
    lines += native_jaco_section(log, args.poses)
    lines += prismatic_section(log, args.poses)
    lines += route_section(log)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n")
    log(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
