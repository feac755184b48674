"""The block chain of a batch (SIMD over poses) against the scalar driver and EAIK, on a shared machine.

One command::

    python benchmarks/batch_simd.py [--robots NAME ...] [--batch N] [--rounds R]

Why this and not compare.py's batch columns alone: at a load of 4-5 on 2 cores compare.py's wall-clock
throughputs (each tool in its own process, minutes apart) moved EAIK's own figure by 2-4x between runs.
Here one process holds, for each robot (labels of ``benchmarks/compare.py``, its batch poses and its
EAIK geometry), the module's batch path with its block chain, the same with ``IKC_BLOCK=0`` (the
scalar driver ``ikc_solve_many``), and EAIK's ``calculate_IK_batched``; they run in interleaved rounds
(block, scalar, EAIK, ...) and each keeps its best round: CPU time a pose in one thread (what the
machine's other jobs disturb least), and wall time in 2 threads.  Also: the block chain's build (print +
compile, lazily on the first batch), and the rows of the two paths compared as sets (angles modulo
2 pi): the largest distance between matched exact rows, in radians and in ulps of pi.

Writes ``benchmarks/results/batch_simd.md``; progress to stderr.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
RESULTS = ROOT / "benchmarks" / "results"
ROBOTS = ("puma560", "ur5", "kr6_r700")


def log(msg: str) -> None:
    print(f"[batch_simd {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def _compare():
    spec = importlib.util.spec_from_file_location("cmp", ROOT / "benchmarks" / "compare.py")
    cmp = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cmp)
    return cmp


def _timed(fn):
    c0, w0 = time.process_time(), time.perf_counter()
    fn()
    return time.process_time() - c0, time.perf_counter() - w0


def _row_gap(Q0, v0, ls0, Q1, v1) -> float:
    """The largest distance (rad, modulo 2 pi) from an exact row of one path to the nearest of the other."""
    worst = 0.0
    for p in range(len(Q0)):
        A, B = Q0[p][v0[p] & ~ls0[p]], Q1[p][v1[p]]
        if not len(A):
            continue
        d = np.abs(A[:, None, :] - B[None, :, :]) % (2 * np.pi)
        worst = max(worst, float(np.minimum(d, 2 * np.pi - d).max(axis=2).min(axis=1).max()))
    return worst


def measure(cmp, label: str, batch: int, rounds: int) -> dict:
    from ikcompiler.codegen import csource
    from subproblems import native

    bc = cmp._bench_compiler()
    entry = [s for s in cmp.robot_specs([label]) if s["label"].split()[0] == label][0]
    chain = cmp.load_chain(entry["spec"])
    _, Tb = bc._poses(chain, batch, cmp.SEED_BATCH, [], [])
    module = cmp.compile_spec(entry["spec"])
    nc = module._native_chain()
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    nc.bind_block(lambda: csource.block_c_source(vars(module)))
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cc_ms = 1e3 * (r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
    H, P, R6T, _fixed = bc.eaik_geometry(chain, [], [])
    robot = bc.eaik_robot(H, P, R6T)
    free = np.zeros((len(Tb), 0))
    poses = [T for T in Tb]

    def ours(block: bool, threads: int):
        def run():
            os.environ["IKC_BLOCK"] = "1" if block else "0"
            return nc.many(Tb, free, True, threads)
        return run

    runs = {
        "block 1": ours(True, 1), "scalar 1": ours(False, 1), "eaik 1": lambda: robot.calculate_IK_batched(poses, 1),
        "block 2": ours(True, 2), "scalar 2": ours(False, 2), "eaik 2": lambda: robot.calculate_IK_batched(poses, 2),
    }
    best = {k: (np.inf, np.inf) for k in runs}
    for _ in range(rounds):
        for k, fn in runs.items():
            cpu, wall = _timed(fn)
            best[k] = (min(best[k][0], cpu), min(best[k][1], wall))
    os.environ["IKC_BLOCK"] = "0"
    (Q0, v0, ls0, _, _), k0 = nc.many(Tb, free, True, 1)
    os.environ["IKC_BLOCK"] = "1"
    (Q1, v1, ls1, _, _), k1 = nc.many(Tb, free, True, 1)
    gap = max(_row_gap(Q0, v0, ls0, Q1, v1), _row_gap(Q1, v1, ls1, Q0, v0))
    n = len(Tb)
    return {
        "label": label, "n": n, "build_ms": nc.block_build_ms, "cc_ms": cc_ms, "has_block": nc._block is not None,
        "cpu_us": {k: 1e6 * v[0] / n for k, v in best.items()},
        "wall_pps": {k: n / v[1] for k, v in best.items()},
        "same_codes": bool(np.array_equal(k0, k1)), "rows": int(v0.sum()), "rows_block": int(v1.sum()),
        "gap": gap, "ulps": gap / np.spacing(np.pi),
    }


ULPS = r"""
#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
typedef double v4 __attribute__((vector_size(32)));
extern v4 _ZGVdN4vv_atan2(v4, v4);
extern v4 _ZGVdN4v_acos(v4);
static int64_t ord(double x) { int64_t i; memcpy(&i, &x, 8); return i < 0 ? INT64_MIN - i : i; }
static double rnd(void) { return 2.0 * rand() / RAND_MAX - 1.0; }
int main(void) {
    srand(1);
    long n = 4000000, da = 0, dc = 0;
    int64_t wa = 0, wc = 0;
    for (long k = 0; k < n; k += 4) {
        v4 y, x, c;
        for (int l = 0; l < 4; l++) {
            y[l] = rnd() * pow(10, 3 * rnd()); x[l] = rnd() * pow(10, 3 * rnd()); c[l] = rnd();
        }
        v4 a = _ZGVdN4vv_atan2(y, x), b = _ZGVdN4v_acos(c);
        for (int l = 0; l < 4; l++) {
            int64_t d = llabs(ord(a[l]) - ord(atan2(y[l], x[l]))), e = llabs(ord(b[l]) - ord(acos(c[l])));
            da += d != 0; dc += e != 0; wa = d > wa ? d : wa; wc = e > wc ? e : wc;
        }
    }
    printf("%ld %ld %lld %ld %lld\n", n, da, (long long)wa, dc, (long long)wc);
    return 0;
}
"""


def libmvec_ulps() -> str:
    """How far libmvec's atan2 and acos are from libm's (4 million random arguments), or why not known."""
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        src, exe = Path(tmp) / "ulps.c", Path(tmp) / "ulps"
        src.write_text(ULPS)
        done = subprocess.run([os.environ.get("CC", "cc"), "-O2", "-mavx2", "-o", str(exe), str(src), "-lmvec",
                               "-lm"], capture_output=True, text=True)
        if done.returncode != 0:
            return "libmvec not measured (no AVX2 build with -lmvec here)"
        n, da, wa, dc, wc = map(int, subprocess.run([str(exe)], capture_output=True, text=True).stdout.split())
    return (f"libmvec against libm on {n:,} random arguments (atan2: y, x = +-[0, 1] 10^[-3, 3]; acos: [-1, 1]):"
            f" atan2 differs on {da / n:.0%} of them, by at most {wa} ulp; acos on {dc / n:.0%}, at most {wc} ulp.")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="*", default=list(ROBOTS))
    ap.add_argument("--batch", type=int, default=10000)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--warm", action="store_true", help="the usual cache (the block chain's build warm)")
    ap.add_argument("--out", default=str(RESULTS / "batch_simd.md"))
    opts = ap.parse_args(argv)
    cmp = _compare()
    if not opts.warm:  # a fresh cache: the block chain's build is cold (the finish and chain built first)
        import tempfile

        os.environ["IKC_CACHE"] = tempfile.mkdtemp(prefix="ikc_batch_simd_")
    load0 = os.getloadavg()[0]
    rows = []
    for label in opts.robots:
        log(label)
        rows.append(measure(cmp, label, opts.batch, opts.rounds))
    load1 = os.getloadavg()[0]
    lines = [
        "# The block chain of a batch (SIMD over poses): CPU a pose beside the scalar driver and EAIK",
        "",
        f"`python benchmarks/batch_simd.py --robots {' '.join(opts.robots)} --batch {opts.batch} --rounds"
        f" {opts.rounds}{' --warm' if opts.warm else ''}` ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; load average {load0:.1f}"
        f" at the start, {load1:.1f} at the end, on {os.cpu_count()} cores): compare.py's batch poses, the"
        " three calls in interleaved rounds in one process, each its best round.  *us a pose*: CPU time"
        " in one thread; *poses/s*: wall time in 2 threads; *EAIK / ours*: EAIK's time over ours (above"
        " 1x ours is faster); *block build*: printing and compiling the block chain on the first batch"
        " (a fresh cache unless --warm; in square brackets the compiler's CPU time);"
        " *row gap*: the largest distance between an exact row of one path and the nearest row of the"
        " other (modulo 2 pi), the codes (solution counts, hand-backs) equal on every pose.",
        "",
        "| robot | block us a pose | scalar us | EAIK us | EAIK / block (1 thread, CPU) | EAIK / scalar |"
        " block poses/s (2 threads) | scalar poses/s | EAIK poses/s | EAIK / block (2 threads, wall) |"
        " block build ms | codes equal | rows | row gap |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|",
    ]
    for r in rows:
        c, w = r["cpu_us"], r["wall_pps"]
        lines.append(
            f"| {r['label']} | {c['block 1']:.2f} | {c['scalar 1']:.2f} | {c['eaik 1']:.2f} |"
            f" {c['eaik 1'] / c['block 1']:.2f}x | {c['eaik 1'] / c['scalar 1']:.2f}x |"
            f" {w['block 2']:,.0f} | {w['scalar 2']:,.0f} | {w['eaik 2']:,.0f} | {w['block 2'] / w['eaik 2']:.2f}x |"
            f" {r['build_ms']:.0f} [cc CPU {r['cc_ms']:.0f}] | {'yes' if r['same_codes'] else 'NO'} | {r['rows']} / {r['rows_block']} |"
            f" {r['gap']:.1e} rad ({r['ulps']:.0f} ulp of pi) |")
    lines += ["", libmvec_ulps()]
    Path(opts.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
