"""Solution sets of ``solve_batch_info`` on this checkout against another: a change to the C batch path
(flags, kernels, finish; docs/design.md section 14) must keep every answer.

One command::

    python benchmarks/batch_sets.py --against DIR [--robots LABEL ...] [--batch N] [--env NAME=VALUE]

For each robot (labels of ``benchmarks/compare.py``; default its Pieper and UR-type 6R arms) the batch
poses of compare.py (same sampler and seed, ``--batch`` of them) are solved by ``solve_batch_info`` in
a subprocess per checkout (``--env`` sets a variable in this checkout's subprocess only, e.g.
``IKC_SIMD=0``).  It fails (exit 1) when, on any pose,

* the two exact solution sets differ: a row of one with no row of the other within 1e-9 (revolute
  values modulo 2 pi, prismatic ones relative to the size), either way;
* an exact row of this checkout misses its target by more than 1e-12 of the size in position or 1e-12
  in rotation (Frobenius norm), measured by our forward kinematics (``module.fk``), not the reported
  residual;
* the valid or least-squares marks differ.

It also counts the poses whose rows are equal bit for bit.  Writes
``benchmarks/results/batch_sets.md``; progress to stderr.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
ROBOTS = ("puma560", "ur5", "kr6_r700", "prob", "puma560 (rtb DH)", "ur10", "kr5", "irb140")
SAME = 1e-9   # the two sets agree to this (docs/design.md section 9)
EXACT = 1e-12  # an exact row's round trip, relative to the size (docs/design.md section 10)

# runs in a subprocess per checkout: compare.py's batch poses, solve_batch_info, saved for the parent
SOLVE = r"""
import importlib.util, sys
import numpy as np
root, label, count, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
sys.path.insert(0, root)
spec = importlib.util.spec_from_file_location("cmp", root + "/benchmarks/compare.py")
cmp = importlib.util.module_from_spec(spec); spec.loader.exec_module(cmp)
entry = [s for s in cmp.robot_specs([label]) if s["label"] == label or s["label"].split()[0] == label][0]
chain = cmp.load_chain(entry["spec"])
_, Tb = cmp._bench_compiler()._poses(chain, count, cmp.SEED_BATCH, [], [])
module = cmp.compile_spec(entry["spec"])
assert module._native_chain() is not None, "no C chain"
Q, valid, ls, res, cont = module.solve_batch_info(Tb)
revolute = np.array([t == "R" for t in module.JOINT_TYPES])
np.savez(out, T=Tb, Q=Q, valid=valid, ls=ls, revolute=revolute, scale=float(module.SCALE))
"""


def log(msg: str) -> None:
    print(f"[batch_sets {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def solve(root: Path, label: str, count: int, out: Path, env: dict) -> dict:
    run_env = {**os.environ, **env, "PYTHONPATH": str(root)}
    subprocess.run([sys.executable, "-c", SOLVE, str(root), label, str(count), str(out)], env=run_env,
                   check=True, capture_output=True, text=True)
    with np.load(out) as data:
        return {k: data[k] for k in data.files}


def row_distance(a: np.ndarray, b: np.ndarray, revolute: np.ndarray, scale: float) -> float:
    d = np.abs(a - b)
    d = np.where(revolute, np.minimum(np.mod(d, 2 * np.pi), 2 * np.pi - np.mod(d, 2 * np.pi)),
                 d / max(scale, 1.0))
    return float(d.max()) if d.size else 0.0


def missing(rows_a, rows_b, revolute, scale) -> int:
    """Rows of a with no row of b within SAME."""
    return sum(1 for x in rows_a if not any(row_distance(x, y, revolute, scale) <= SAME for y in rows_b))


def compare(now: dict, before: dict, fk) -> dict:
    """Counts over the poses: differing sets, round-trip misses, mark differences, bit-equal poses."""
    revolute, scale = now["revolute"], float(now["scale"])
    out = {"poses": len(now["T"]), "rows": 0, "rows_before": 0, "set_differs": 0, "marks_differ": 0,
           "inexact_rows": 0, "worst": 0.0, "bit_equal": 0}
    for i, T in enumerate(now["T"]):
        ea = now["valid"][i] & ~now["ls"][i]
        eb = before["valid"][i] & ~before["ls"][i]
        A, B = now["Q"][i][ea], before["Q"][i][eb]
        out["rows"] += len(A)
        out["rows_before"] += len(B)
        if missing(A, B, revolute, scale) or missing(B, A, revolute, scale):
            out["set_differs"] += 1
        same_marks = np.array_equal(now["valid"][i], before["valid"][i]) and np.array_equal(now["ls"][i],
                                                                                         before["ls"][i])
        if not same_marks:
            out["marks_differ"] += 1
        elif np.array_equal(now["Q"][i][now["valid"][i]], before["Q"][i][before["valid"][i]]):
            out["bit_equal"] += 1
        for q in A:
            G = fk(q)
            err = max(np.linalg.norm(G[:3, 3] - T[:3, 3]) / scale, np.linalg.norm(G[:3, :3] - T[:3, :3]))
            out["worst"] = max(out["worst"], float(err))
            out["inexact_rows"] += int(err > EXACT)
    return out


def _fk_of(label: str):
    sys.path.insert(0, str(ROOT))
    import importlib.util

    spec = importlib.util.spec_from_file_location("cmp", ROOT / "benchmarks" / "compare.py")
    cmp = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cmp)
    entry = [s for s in cmp.robot_specs([label]) if s["label"] == label or s["label"].split()[0] == label][0]
    return cmp.compile_spec(entry["spec"]).fk


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", required=True, help="the other checkout (e.g. the main worktree)")
    ap.add_argument("--robots", nargs="*", default=list(ROBOTS))
    ap.add_argument("--batch", type=int, default=10000)
    ap.add_argument("--env", nargs="*", default=[], help="NAME=VALUE for this checkout's subprocess")
    ap.add_argument("--out", default=str(RESULTS / "batch_sets.md"))
    opts = ap.parse_args(argv)
    env = dict(item.split("=", 1) for item in opts.env)
    against = Path(opts.against).resolve()
    table, failed = [], False
    with tempfile.TemporaryDirectory(prefix="ikc_sets_") as tmpdir:
        for label in opts.robots:
            log(f"{label}: this checkout, then {against}")
            now = solve(ROOT, label, opts.batch, Path(tmpdir) / "now.npz", env)
            before = solve(against, label, opts.batch, Path(tmpdir) / "before.npz", {})
            if not np.array_equal(now["T"], before["T"]):
                raise SystemExit(f"{label}: the two checkouts sampled different poses")
            row = compare(now, before, _fk_of(label))
            failed |= bool(row["set_differs"] or row["marks_differ"] or row["inexact_rows"])
            table.append((label, row))
    lines = [
        "# Solution sets of the batch path, this checkout against another",
        "",
        f"`python benchmarks/batch_sets.py --against {opts.against} --batch {opts.batch}"
        + (f" --env {' '.join(opts.env)}" if opts.env else "")
        + f"` ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}): `solve_batch_info` on compare.py's"
        " batch poses; *sets differ*: poses whose exact rows differ by more than 1e-9 either way;"
        " *marks differ*:"
        " valid or least-squares marks not equal; *beyond 1e-12*: exact rows of this checkout whose round"
        " trip by our FK misses by more (position over the size, rotation Frobenius); *bit equal*: poses"
        " whose rows are equal bit for bit.",
        "",
        "| robot | poses | exact rows | rows before | sets differ | marks differ | beyond 1e-12 |"
        " worst round trip | bit equal |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for label, r in table:
        lines.append(f"| {label} | {r['poses']} | {r['rows']} | {r['rows_before']} | {r['set_differs']} |"
                     f" {r['marks_differ']} | {r['inexact_rows']} | {r['worst']:.1e} | {r['bit_equal']} |")
    verdict = "FAILED" if failed else "the same solution sets, every exact row within 1e-12."
    lines += ["", "Verdict: " + verdict]
    Path(opts.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
