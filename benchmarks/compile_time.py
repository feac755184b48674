"""Compile time of `ikc compile` with its C build: cold, warm, and the one-piece build it replaced.

Usage::

    python benchmarks/compile_time.py [--robots NAME ...] [--repeat N]

Per robot, each in a fresh process (so nothing is cached in memory), into one cache directory made for
the run (``IKC_CACHE``) whose shared finish library and precompiled chain prelude are built first
(once per machine in real use, docs/design.md section 14):

* *cold*: ``compile_robot`` then the C build of its chain (neither the chain's library nor its printed
  C text in the cache yet);
* *warm*: the same again, the chain found in the cache;
* *one-piece*: the C build of kernels, finish and chain in one translation unit (the build before the
  split, still the fallback), into a second fresh cache;
* *no bytecode cache*: *cold* with ``PYTHONDONTWRITEBYTECODE=1`` (the other kinds run with Python's
  bytecode cache on, as an installed package has it).

Wall times wait for the cores on a shared machine; the CPU times (the process's own plus its compiler
children's) are what a build costs on an idle one.  Median over ``--repeat`` runs.  Writes
``benchmarks/results/compile_time.md``.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
ROBOTS = ("puma560", "ur5", "kr6_r700", "prob", "stanford", "rhino")

# Runs in the child: one compile + C build, timed; `onepiece` forces the fallback build.
CHILD = r"""
import json, resource, sys, time
from subproblems import native
name, onepiece = sys.argv[1], sys.argv[2] == "1"
if onepiece:
    native._finish_library = lambda *a, **k: None
from ikcompiler import compile_robot
def cpu(who):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime
s0, c0, t0 = cpu(resource.RUSAGE_SELF), cpu(resource.RUSAGE_CHILDREN), time.perf_counter()
module = compile_robot(name)
t1, s1 = time.perf_counter(), cpu(resource.RUSAGE_SELF)
ok = module._native_chain() is not None
t2, s2, c2 = time.perf_counter(), cpu(resource.RUSAGE_SELF), cpu(resource.RUSAGE_CHILDREN)
print(json.dumps({"compile_ms": (t1 - t0) * 1e3, "compile_cpu_ms": (s1 - s0) * 1e3,
                  "cbuild_ms": (t2 - t1) * 1e3, "cbuild_cpu_ms": (s2 - s1 + c2 - c0) * 1e3,
                  "total_ms": (t2 - t0) * 1e3, "total_cpu_ms": (s2 - s0 + c2 - c0) * 1e3, "native": ok,
                  "error": native.last_error}))
"""


def run(name: str, cache: Path, onepiece: bool = False, bytecode: bool = True) -> dict:
    """One child's timings.  ``bytecode``: Python's bytecode cache on, as for any installed package (an
    environment with PYTHONDONTWRITEBYTECODE set, as this machine's, has every fresh process compile
    the source of each module it imports again: a cost of the environment, measured apart)."""
    env = {**os.environ, "IKC_CACHE": str(cache)}
    if bytecode:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
    else:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    out = subprocess.run([sys.executable, "-c", CHILD, name, "1" if onepiece else "0"], env=env,
                         capture_output=True, text=True, check=True, cwd=ROOT)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robots", nargs="*", default=list(ROBOTS))
    ap.add_argument("--repeat", type=int, default=3)
    opts = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    rows = []
    with tempfile.TemporaryDirectory(prefix="ikc_ctime_") as tmp:
        shared = Path(tmp) / "cache"
        run("rhino", shared)  # the shared finish library and prelude, once; the package's bytecode written
        for name in opts.robots:
            cold, warm, one, nobyte = [], [], [], []
            for r in range(opts.repeat):
                for kind, into in (("cold", cold), ("nobyte", nobyte)):
                    for p in list(shared.glob("ikc_*.so")) + list(shared.glob("ikc_src_*.c")):
                        if not p.name.startswith("ikc_finish_"):  # every chain out, the finish kept
                            p.unlink()
                    into.append(run(name, shared, bytecode=kind == "cold"))
                warm.append(run(name, shared))
                one.append(run(name, Path(tmp) / f"one_{name}_{r}", onepiece=True))
            med = {k: {f: float(np.median([x[f] for x in v])) for f in v[0] if f.endswith("_ms")}
                   for k, v in (("cold", cold), ("warm", warm), ("one", one), ("nobyte", nobyte))}
            med["native"] = all(x["native"] for x in cold + warm + one + nobyte)
            rows.append((name, med))
            print(f"{name}: {json.dumps(med)}", file=sys.stderr, flush=True)
    load1 = os.getloadavg()[0]
    cc = subprocess.run(["cc", "--version"], capture_output=True, text=True).stdout.splitlines()[:1]
    lines = [
        "# Compile time: `compile_robot` + the C build of the chain", "",
        f"Generated by `python benchmarks/compile_time.py` on "
        f"{_dt.datetime.now(_dt.UTC).strftime('%Y-%m-%d %H:%M UTC')}; {platform.platform()}, "
        f"{os.cpu_count()} cores, {cc[0] if cc else 'cc'}; 1-min load average {load0:.2f} at the start, "
        f"{load1:.2f} at the end (a shared machine: wall times wait for the cores, CPU times do not). "
        f"Median of {opts.repeat} runs, each in a fresh process.", "",
        "Cold: the chain not in the cache (the shared finish library and the precompiled prelude are: "
        "they are built once per machine and compiler, docs/design.md section 14). Warm: the chain found in the cache. One-piece: kernels, "
        "finish and chain compiled as one file (the build before the split; still the fallback). "
        "CPU: the process's own time plus its compiler's (the alternative chain compiled as cold code, "
        "-O1, the chain without -fschedule-insns2: docs/design.md section 14). Python's bytecode "
        "cache is on, as for an installed package; the last column is the cold total without it "
        "(PYTHONDONTWRITEBYTECODE=1, this machine's default environment: each fresh process compiles "
        "the source of the modules it imports lazily again).", "",
        "| robot | compile_robot ms (CPU) | cold C build ms (CPU) | cold total ms (CPU) "
        "| warm total ms (CPU) | one-piece C build ms (CPU) | one-piece total ms (CPU) "
        "| cold total, no bytecode cache, ms (CPU) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]

    def cell(d, key):
        return f"{d[key + '_ms']:.0f} ({d[key + '_cpu_ms']:.0f})"

    for name, m in rows:
        c, w, o, nb = m["cold"], m["warm"], m["one"], m["nobyte"]
        cells = [cell(c, "compile"), cell(c, "cbuild"), cell(c, "total"), cell(w, "total"), cell(o, "cbuild"),
                 cell(o, "total"), cell(nb, "total")]
        lines.append(f"| {name} | " + " | ".join(cells) + " |" + ("" if m["native"] else " (no C build)"))
    lines.append("")
    RESULTS.joinpath("compile_time.md").write_text("\n".join(lines))
    print(f"wrote {RESULTS / 'compile_time.md'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
