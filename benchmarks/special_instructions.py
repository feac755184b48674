"""Instructions a pose of the C single-pose path on special poses against random ones, counted by
callgrind per pose (load-free twin of ``special_poses.py``'s wall times; issue 11 item 6).

One command::

    python benchmarks/special_instructions.py [--robot jaco] [--out FILE]

The robot's poses are ``special_poses.py``'s (same seeds: 300 random, 300 special, 300 taught).  A
small C driver (built here with ``cc``; needs valgrind and its ``callgrind.h``) loads the module's
chain library and calls ``ikc_solve_many`` one pose at a time in one thread, dumping callgrind's
counters after each (``CALLGRIND_DUMP_STATS``), so each pose's instructions are known; nothing of
Python is counted.  Reported: median and 99th percentile a set and their ratios to the random
median (the goal: special median <= 3x, p99 <= 30x).  Appends to ``--out`` (default: print only).
"""

from __future__ import annotations

import argparse
import os
import re
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.append(str(ROOT / "benchmarks"))

import special_poses as sp  # noqa: E402  (the benchmark's poses, same seeds)

DRIVER = r"""
#include <dlfcn.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <valgrind/callgrind.h>
typedef void (*many_fn)(int64_t, const double *, const double *, int, double *, double *, int *, int *,
                        int *, int);
int main(int argc, char **argv) {
    void *h = dlopen(argv[1], RTLD_NOW);
    many_fn many = h ? (many_fn)dlsym(h, "ikc_solve_many") : NULL;
    FILE *f = fopen(argv[2], "rb");
    int64_t n; int slots, dof;
    if (!many || !f || fread(&n, 8, 1, f) != 1 || fread(&slots, 4, 1, f) != 1 || fread(&dof, 4, 1, f) != 1)
        return 1;
    double *T = malloc(sizeof(double) * n * 16), fr[1];
    if (fread(T, 8, n * 16, f) != (size_t)(n * 16)) return 1;
    double *q = malloc(sizeof(double) * slots * dof), *res = malloc(sizeof(double) * slots);
    int *ls = malloc(sizeof(int) * slots), *cont = malloc(sizeof(int) * slots), count[1];
    many(1, T, fr, 1, q, res, ls, cont, count, 1);  /* warm: the first call's one-off costs */
    CALLGRIND_ZERO_STATS;
    for (int64_t i = 0; i < n; i++) {
        many(1, T + 16 * i, fr, 1, q, res, ls, cont, count, 1);
        CALLGRIND_DUMP_STATS;
    }
    return 0;
}
"""


def per_pose(driver: Path, lib: str, poses: Path, tmp: Path) -> np.ndarray:
    """Instructions of each pose (callgrind's summary of each dump, in pose order)."""
    out = tmp / f"{poses.stem}.cg"
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", str(driver), lib, str(poses)],
                   capture_output=True, check=True)
    parts = sorted(tmp.glob(f"{out.name}.*"), key=lambda p: int(p.name.rsplit(".", 1)[1].split("-")[0]))
    counts = []
    for part in parts:
        m = re.search(r"^summary:\s+(\d+)", part.read_text(), re.M)
        counts.append(int(m.group(1)))
        part.unlink()
    return np.array(counts, dtype=float)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="jaco")
    ap.add_argument("--out", help="append the table to this file")
    args = ap.parse_args(argv)
    from ikcompiler.codegen import csource
    from subproblems import native

    _, module, _ = sp._setup(args.robot)
    nc = module._native_chain()
    special, random = sp._joint_sets(module, np.random.default_rng(7), sp.POSES)
    taught = sp._taught(module, np.random.default_rng(8), sp.POSES, random)
    lib = str(native.build(csource.native_source(vars(module))))
    counts = {}
    with tempfile.TemporaryDirectory(prefix="ikc_special_") as tmpdir:
        tmp = Path(tmpdir)
        (tmp / "driver.c").write_text(DRIVER)
        driver = tmp / "driver"
        subprocess.run([os.environ.get("CC", "cc"), "-O2", "-o", str(driver), str(tmp / "driver.c"), "-ldl"],
                       check=True)
        for label, Q in (("random", random), ("special", special), ("taught", taught)):
            T = np.ascontiguousarray(sp._targets(module, Q), dtype="<f8")
            poses = tmp / f"{label}.poses"
            poses.write_bytes(struct.pack("<qii", len(T), nc.slots, nc.dof) + T.tobytes())
            counts[label] = per_pose(driver, lib, poses, tmp)
            print(f"{label}: median {np.median(counts[label]):,.0f}", file=sys.stderr, flush=True)
    base = np.median(counts["random"])
    lines = ["| robot | set | median instructions | p99 instructions | median / random median "
             "| p99 / random median |", "|---|---|---:|---:|---:|---:|"]
    for label, c in counts.items():
        med, p99 = np.median(c), np.percentile(c, 99)
        lines.append(f"| {args.robot} | {label} | {med:,.0f} | {p99:,.0f} | {med / base:.2f} | {p99 / base:.1f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        with open(args.out, "a") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
