"""Time every registered subproblem: scalar per call and vectorised per instance.

Not a test and not run by CI.  Run from the repository root::

    .venv/bin/python benchmarks/subproblems.py [--n 10000] [--calls 200] [--codes S3-RR,H-R]

For each code of ``subproblems.codes()`` (whatever is registered: the classes are written in
parallel), random valid instances are built by evaluating the left side of the equation at random
joint values on random geometry, so every instance has an exact solution.  Reported: the median time
of one ``solve`` call (scalar path, microseconds), and the time of one ``solve_batch`` call over
``N`` instances divided by ``N`` (microseconds per instance and instances per second), with whether
that path is really vectorised.  Results go to ``benchmarks/results/subproblems.md``.

Inputs are chosen by the code's class: ``S1`` (T), ``S2`` (p, q), ``S3`` (p, q, d; two pairs for
m = 2), ``H`` (p, h, d; two for m = 2), ``O`` (rotation: T with zero translation, twists through the
origin).  An unknown class is skipped with a note.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from subproblems import codes, max_solutions, solve, solve_batch  # noqa: E402
from subproblems.screw import prismatic_twist, revolute_twist, twist_exp_batch  # noqa: E402


def _twists(rng, kinds, n, origin=False):
    tw = np.zeros((n, len(kinds), 6))
    for j, k in enumerate(kinds):
        w = rng.normal(size=(n, 3))
        w /= np.linalg.norm(w, axis=1, keepdims=True)
        if k == "R":
            r = np.zeros((n, 3)) if origin else rng.normal(size=(n, 3))
            tw[:, j] = np.array([revolute_twist(a, b) for a, b in zip(w, r)])
        else:
            tw[:, j] = np.array([prismatic_twist(a) for a in w])
    return tw


def _fk(tw, th):
    n = tw.shape[0]
    g = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    for j in range(tw.shape[1]):
        g = g @ twist_exp_batch(tw[:, j], th[:, j])
    return g


def _apply(g, p):
    return np.einsum("nij,nj->ni", g[:, :3, :3], p) + g[:, :3, 3]


def instances(code: str, n: int, rng):
    """(twists (n, m, 6), inputs dict with leading n) or None for an unknown class."""
    cls, kinds = code.split("-", 1)
    m = len(kinds)
    if cls == "O" or (set(kinds) - {"R", "T"}):
        if set(kinds) - {"R"}:
            return None
        tw = _twists(rng, kinds, n, origin=True)
        g = _fk(tw, rng.uniform(-np.pi, np.pi, (n, m)))
        g[:, :3, 3] = 0.0
        return tw, {"T": g}
    tw = _twists(rng, kinds, n)
    th = np.where(
        np.array([k == "R" for k in kinds]), rng.uniform(-np.pi, np.pi, (n, m)), rng.uniform(-2, 2, (n, m))
    )
    g = _fk(tw, th)
    if cls == "S1":
        return tw, {"T": g}
    if cls == "S2":
        p = rng.normal(size=(n, 3))
        return tw, {"p": p, "q": _apply(g, p)}
    if cls == "S3":
        k = 1 if m == 1 else 2
        P, Q = rng.normal(size=(n, k, 3)), rng.normal(size=(n, k, 3))
        D = np.stack([np.linalg.norm(_apply(g, P[:, i]) - Q[:, i], axis=1) for i in range(k)], axis=1)
        if m == 1:
            return tw, {"p": P[:, 0], "q": Q[:, 0], "d": D[:, 0]}
        return tw, {"p": P, "q": Q, "d": D}
    if cls == "H":
        k = 1 if m == 1 else 2
        P, H = rng.normal(size=(n, k, 3)), rng.normal(size=(n, k, 3))
        D = np.stack([np.sum(H[:, i] * _apply(g, P[:, i]), axis=1) for i in range(k)], axis=1)
        if m == 1:
            return tw, {"p": P[:, 0], "h": H[:, 0], "d": D[:, 0]}
        return tw, {"p": P, "h": H, "d": D}
    return None


def bench(code: str, n: int, calls: int, rng) -> dict | None:
    inst = instances(code, max(n, calls), rng)
    if inst is None:
        return None
    tw, inputs = inst
    times = []
    for i in range(calls):
        args = {k: v[i] for k, v in inputs.items()}
        t0 = time.perf_counter()
        solve(code, tw[i], **args)
        times.append(time.perf_counter() - t0)
    scalar_us = statistics.median(times) * 1e6
    args = {k: v[:n] for k, v in inputs.items()}
    solve_batch(code, tw[:10], **{k: v[:10] for k, v in inputs.items()})  # warm-up
    t0 = time.perf_counter()
    b = solve_batch(code, tw[:n], **args)
    dt = time.perf_counter() - t0
    found = float(np.mean((b.valid & ~b.ls).any(axis=1)))
    return {
        "code": code,
        "slots": max_solutions(code),
        "scalar_us": scalar_us,
        "batch_us": dt / n * 1e6,
        "per_s": n / dt,
        "vectorised": b.vectorised,
        "exact": found,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=10_000, help="instances of the vectorised call")
    ap.add_argument("--calls", type=int, default=200, help="scalar calls timed per code")
    ap.add_argument("--codes", default="", help="comma-separated codes (default: every registered one)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "subproblems.md"))
    a = ap.parse_args(argv)
    todo = [c for c in a.codes.split(",") if c] or codes()
    rng = np.random.default_rng(2024)
    rows, skipped = [], []
    for code in todo:
        print(f"{code:8s} ...", end=" ", flush=True)
        r = bench(code, a.n, a.calls, rng)
        if r is None:
            skipped.append(code)
            print("skipped (unknown input class)")
            continue
        rows.append(r)
        print(
            f"scalar {r['scalar_us']:9.1f} us/call   batch {r['batch_us']:8.2f} us/inst "
            f"({r['per_s']:,.0f}/s, {'vectorised' if r['vectorised'] else 'scalar loop'}), "
            f"exact found {r['exact']:.1%}",
            flush=True,
        )
    lines = [
        "# Subproblem timings",
        "",
        f"`benchmarks/subproblems.py`: N = {a.n} instances per vectorised call, median of {a.calls} scalar "
        f"calls; random valid instances (right-hand side from the left side). Python "
        f"{platform.python_version()}, numpy {np.__version__}, {platform.machine()}.",
        "",
        "| code | slots | scalar µs/call | vectorised µs/instance | instances/s | vectorised | exact found |",
        "|---|---:|---:|---:|---:|---|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['code']} | {r['slots']} | {r['scalar_us']:.1f} | {r['batch_us']:.2f} "
            f"| {r['per_s']:,.0f} | "
            f"{'yes' if r['vectorised'] else 'no (scalar loop)'} | {r['exact']:.1%} |"
        )
    if skipped:
        lines += ["", "Skipped (inputs unknown to the benchmark): " + ", ".join(skipped)]
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
