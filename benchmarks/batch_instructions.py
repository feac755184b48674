"""Instructions a pose of the C batch path (chain + finish), counted by callgrind: a load-free measure.

One command::

    python benchmarks/batch_instructions.py [--robots NAME ...] [--poses N] [--against DIR] [--profile]

Why instructions: on a shared, loaded machine the wall and CPU times of a batch move by 1.5x between
runs, so before/after comparisons of the C runtime (docs/design.md section 14) are made on callgrind's
instruction counts, which do not depend on the load.  For each robot (labels of ``benchmarks/compare.py``)
the batch poses of compare.py (same sampler and seed, ``--poses`` of them) are solved by the module's
compiled chain through ``ikc_solve_many`` in one thread, from a small C driver (built here with ``cc``)
that loads the chain's shared library, so nothing of Python is counted.  ``--against DIR`` counts the
same poses on another checkout (e.g. the main worktree) in the same run, for a before/after table.
``--profile`` adds, per robot, where this checkout's instructions go: callgrind's exclusive counts per
function (``callgrind_annotate``), a pose's share of each, libm's functions named as such.

Needs valgrind on the PATH.  Writes ``benchmarks/results/batch_instructions.md``; progress to stderr.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
ROBOTS = ("puma560", "ur5", "kr6_r700", "prob", "irb140", "kinova")

DRIVER = r"""
#include <dlfcn.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
typedef void (*many_fn)(int64_t, const double *, const double *, int, double *, double *, int *, int *,
                        int *, int);
typedef void (*block_fn)(const void *, int64_t, const double *, const double *, int, double *, double *,
                         int *, int *, int *, int);
int main(int argc, char **argv) {
    void *h = dlopen(argv[1], RTLD_NOW);
    if (!h) { fprintf(stderr, "%s\n", dlerror()); return 1; }
    many_fn many = (many_fn)dlsym(h, "ikc_solve_many");
    block_fn block = NULL;  /* argv[4]: the block chain's library (the block path), if any */
    const void *rb = NULL;
    if (argc > 4) {
        void *hb = dlopen(argv[4], RTLD_NOW);
        const void *(*data)(void) = (const void *(*)(void))dlsym(h, "ikc_robot_data");
        if (!hb || !data) { fprintf(stderr, "no block chain\n"); return 1; }
        block = (block_fn)dlsym(hb, "ikc_solve_many_block");
        rb = data();
    }
    FILE *f = fopen(argv[2], "rb");
    int64_t n; int slots, dof;
    if (!many || !f || fread(&n, 8, 1, f) != 1 || fread(&slots, 4, 1, f) != 1 || fread(&dof, 4, 1, f) != 1)
        return 1;
    double *T = malloc(sizeof(double) * n * 16), fr[1];
    if (fread(T, 8, n * 16, f) != (size_t)(n * 16)) return 1;
    fclose(f);
    double *q = malloc(sizeof(double) * n * slots * dof), *res = malloc(sizeof(double) * n * slots);
    int *ls = malloc(sizeof(int) * n * slots), *cont = malloc(sizeof(int) * n * slots);
    int *count = malloc(sizeof(int) * n);
    if (atoi(argv[3]) && block) block(rb, n, T, fr, 1, q, res, ls, cont, count, 1);
    else if (atoi(argv[3])) many(n, T, fr, 1, q, res, ls, cont, count, 1);
    long rows = 0;
    for (int64_t i = 0; i < n && atoi(argv[3]); i++) rows += count[i] > 0 ? count[i] : 0;
    printf("%ld\n", rows);
    return 0;
}
"""

# runs in a subprocess per checkout: the library of the chain and the poses (compare.py's batch sample)
LIBRARY = r"""
import importlib.util, struct, sys
root, label, count, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
sys.path.insert(0, root)
spec = importlib.util.spec_from_file_location("cmp", root + "/benchmarks/compare.py")
cmp = importlib.util.module_from_spec(spec); spec.loader.exec_module(cmp)
from ikcompiler.codegen import csource
from subproblems import native
entry = [s for s in cmp.robot_specs([label]) if s["label"].split()[0] == label][0]
chain = cmp.load_chain(entry["spec"])
_, Tb = cmp._bench_compiler()._poses(chain, count, cmp.SEED_BATCH, [], [])
module = cmp.compile_spec(entry["spec"])
nc = module._native_chain()
with open(out, "wb") as f:
    f.write(struct.pack("<qii", count, nc.slots, nc.dof))
    f.write(Tb.astype("<f8").tobytes())
lib = native.build(csource.native_source(vars(module)))
block = getattr(csource, "block_c_source", None)  # the block chain (this checkout; not before it)
block = block and sys.argv[5] == "1" and block(vars(module))
print(lib, native.build_block(block) if block else "")
"""


def log(msg: str) -> None:
    print(f"[batch_instructions {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def _instructions(driver: Path, lib: str, poses: Path, solve: bool,
                  out: str = "/dev/null", block: str = "") -> tuple[int, int]:
    out = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", str(driver), lib,
                          str(poses), "1" if solve else "0"] + ([block] if block else []),
                         capture_output=True, text=True, check=True)
    refs = re.search(r"I\s+refs:\s+([\d,]+)", out.stderr)
    return int(refs.group(1).replace(",", "")), int(out.stdout.strip() or 0)


def _functions(profile: Path, poses: int, top: int = 14) -> list[tuple[str, float, float]]:
    """(function, instructions a pose, share of the solve) of the heaviest functions, exclusive counts."""
    text = subprocess.run(["callgrind_annotate", "--inclusive=no", str(profile)], capture_output=True,
                          text=True, check=True).stdout
    rows, total = [], None
    for line in text.splitlines():
        m = re.match(r"\s*([\d,]+)\s+(?:\(\s*[\d.]+%\)\s+)?(.*)$", line)
        if not m:
            continue
        n, what = int(m.group(1).replace(",", "")), m.group(2)
        if "PROGRAM TOTALS" in what:
            total = n
            continue
        if total is None or ":" not in what:
            continue
        name = what.split(":", 1)[1].split(" [")[0]
        lib = what.rsplit("/", 1)[-1].rstrip("]") if "[" in what else ""
        if "libm" in lib or name.startswith("__ieee754"):
            name = f"libm {name}"
        rows.append((name, n))
    merged: dict[str, int] = {}  # one name, several entries (libm's atan2 and its inlined fenv part)
    for name, n in rows:
        merged[name] = merged.get(name, 0) + n
    solve = sum(merged.values()) or 1
    heaviest = sorted(merged.items(), key=lambda item: -item[1])[:top]
    return [(name, n / poses, n / solve) for name, n in heaviest]


def count(root: Path, label: str, poses: int, driver: Path, tmp: Path, profile: bool = False,
          block: bool = True) -> dict:
    """Instructions a pose (the driver's fixed cost, counted without the solve, taken off) and rows.
    ``block``: through the block chain where the checkout has one (else ``ikc_solve_many``)."""
    data = tmp / f"{label}.{abs(hash(str(root)))}.poses"
    libs = subprocess.run([sys.executable, "-c", LIBRARY, str(root), label, str(poses), str(data),
                           "1" if block else "0"],
                          capture_output=True, text=True, check=True).stdout.strip().splitlines()[-1].split()
    lib, block_lib = libs[0], (libs[1] if len(libs) > 1 else "")
    out = tmp / f"{label}.callgrind" if profile else Path("/dev/null")
    total, rows = _instructions(driver, lib, data, True, str(out), block_lib)
    fixed, _ = _instructions(driver, lib, data, False, block=block_lib)
    result = {"per_pose": (total - fixed) / poses, "rows": rows}
    if profile:
        result["functions"] = _functions(out, poses)
    return result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="*", default=list(ROBOTS))
    ap.add_argument("--poses", type=int, default=2000)
    ap.add_argument("--against", help="another checkout, counted on the same poses (before/after)")
    ap.add_argument("--profile", action="store_true", help="where the instructions go, per function")
    ap.add_argument("--no-block", action="store_true",
                    help="this checkout through ikc_solve_many (the scalar driver), not its block chain")
    ap.add_argument("--out", default=str(RESULTS / "batch_instructions.md"))
    opts = ap.parse_args(argv)
    if shutil.which("valgrind") is None:
        print("valgrind is not installed", file=sys.stderr)
        return 2
    roots = [ROOT] + ([Path(opts.against).resolve()] if opts.against else [])
    with tempfile.TemporaryDirectory(prefix="ikc_instr_") as tmpdir:
        tmp = Path(tmpdir)
        (tmp / "driver.c").write_text(DRIVER)
        driver = tmp / "driver"
        subprocess.run([os.environ.get("CC", "cc"), "-O2", "-o", str(driver), str(tmp / "driver.c"), "-ldl"],
                       check=True)
        table = []
        for label in opts.robots:
            row = [label]
            for root in roots:
                log(f"{label}: {root}")
                row.append(count(root, label, opts.poses, driver, tmp, opts.profile and root == ROOT,
                                 block=not opts.no_block))
            table.append(row)
    head = ["robot", "instructions a pose", "rows"]
    if opts.against:
        head = ["robot", "instructions a pose", f"before ({Path(opts.against).name})", "change", "rows",
                "rows before"]
    lines = [
        "# Instructions a pose of the C batch path (chain + finish)",
        "",
        f"`python benchmarks/batch_instructions.py --poses {opts.poses}"
        + (f" --against {opts.against}" if opts.against else "")
        + (" --profile" if opts.profile else "") + (" --no-block" if opts.no_block else "") + "`"
        + f" ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}): callgrind instructions of"
        + (" `ikc_solve_many`" if opts.no_block else
           " the batch path (the block chain's `ikc_solve_many_block` where a checkout has one, else"
           " `ikc_solve_many`)")
        + " in one thread on compare.py's batch poses (a quarter of the joint values at"
        " 0, +-pi/2, pi), the driver's fixed cost taken off; rows: solutions returned in all.",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for row in table:
        now = row[1]
        if opts.against:
            before = row[2]
            change = now["per_pose"] / before["per_pose"] - 1.0
            lines.append(f"| {row[0]} | {now['per_pose']:,.0f} | {before['per_pose']:,.0f} | {change:+.0%} |"
                         f" {now['rows']} | {before['rows']} |")
        else:
            lines.append(f"| {row[0]} | {now['per_pose']:,.0f} | {now['rows']} |")
    for row in table:
        if "functions" not in row[1]:
            continue
        lines += ["", f"## Where {row[0]}'s instructions go (this checkout; exclusive counts)",
                  "",
                  "| function | instructions a pose | share |", "|---|---|---|"]
        lines += [f"| `{name}` | {n:,.0f} | {share:.1%} |" for name, n, share in row[1]["functions"]]
    Path(opts.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
