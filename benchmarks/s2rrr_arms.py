"""pr2's arms and tiago's arm as shipped: single-solve CPU time, round trip and completeness, and, with
``--against DIR``, the same poses on another checkout (before/after, solution sets compared).

One command::

    nice python benchmarks/s2rrr_arms.py [--against DIR] [--poses 200] [--special 100]

Why: their plans solve the shoulder and elbow by S2-RRR (the upper-arm roll free), which had no fast
kernel: the fast chain called the reference solver (4-9 ms a solve; docs/design.md section 14,
"S2-RRR without a fast kernel").  Each arm is compiled by ``configs.compile_chain`` as shipped and
perturbed by 1e-6 and 1e-3 of its size (``configs.perturbed``, seed 7) where the plan still takes
S2-RRR.  Poses: ``--poses`` random joint vectors inside the limits (seed 7) and ``--special`` at
special angles (every revolute value 0, +-pi/2 or pi, drawn among those inside its limits), the free
joint at its sampled value.  Each pose is solved by ``module.solve`` (limits on), timed in CPU time
(fastest of 2);
every row is checked by the chain's forward kinematics (position 1e-12 of the size, rotation 1e-12
Frobenius) and the sampled vector must be among the rows (1e-6 rad).  With ``--against``, a pose
*differs* when a row of one checkout has no row of the other within 1e-6 rad (counted apart where both
return representatives of a self-motion, ``solve_info``'s continuum flag: a wrist lock's representative
is the C finish's there, the Python runtime's before).  Writes ``benchmarks/results/s2rrr_arms.md``;
exits 1 on a wrong row, more misses than the other checkout, or a pose that differs off a self-motion
where this checkout does not recover a sample the other misses.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
ARMS = {  # name: (package, file, tip)
    "pr2_left": ("example-robot-data", "pr2.urdf", "l_gripper_palm_link"),
    "pr2_right": ("example-robot-data", "pr2.urdf", "r_gripper_palm_link"),
    "tiago": ("example-robot-data", "tiago.urdf", "hand_palm_link"),
}
EPS = (0.0, 1e-6, 1e-3)
SAME = 1e-6  # rad: a row recovers the sampled vector / matches the other checkout's row
EXACT = 1e-12  # of the size (position), Frobenius (rotation)

# runs in a subprocess per checkout and case: the poses solved and timed, rows saved for the parent
SOLVE = r"""
import sys, time
import numpy as np
root, name, eps, n_rand, n_special, out = sys.argv[1:7]
eps, n_rand, n_special = float(eps), int(n_rand), int(n_special)
sys.path.insert(0, root)
from ikcompiler import configs, robotdb
ARMS = __ARMS__
package, file, tip = ARMS[name]
entry = next(e for e in robotdb.discover(packages=robotdb.EXTRA).chains
             if e.package == package and e.rel.rsplit("/", 1)[-1] == file and e.tip == tip)
chain = entry.load()
if eps:
    chain = configs.perturbed(chain, eps, seed=7)
compiled = configs.compile_chain(chain)
module = compiled.module
codes = [s["code"] for s in module._STEPS]
if "S2-RRR" not in codes:  # nothing to measure here
    np.savez(out, codes=np.array(codes))
    sys.exit(0)
cols = [module.JOINT_NAMES.index(f) for f in module.FREE_JOINTS]
rng = np.random.default_rng(7)
lo, hi = np.maximum(module.LOWER, -np.pi), np.minimum(module.UPPER, np.pi)
Q = rng.uniform(lo, hi, (n_rand, len(lo)))
S = rng.uniform(lo, hi, (n_special, len(lo)))
for j in range(len(lo)):  # each joint at a special angle inside its limits (none inside: random)
    ok = [a for a in (0.0, np.pi / 2, -np.pi / 2, np.pi) if module.LOWER[j] <= a <= module.UPPER[j]]
    if ok:
        S[:, j] = rng.choice(ok, n_special)
Q = np.concatenate([Q, S])
T = np.array([chain.fk(q) for q in Q])
rows, times = {}, []
for i in range(len(T)):
    free = [float(Q[i, c]) for c in cols]
    best = np.inf
    for _ in range(2):
        t0 = time.process_time()
        r = module.solve(T[i], *free)
        best = min(best, time.process_time() - t0)
    times.append(best)
    info = module.solve_info(T[i], *free)
    exact = ~np.asarray(info.ls, dtype=bool)
    rows[f"rows_{i}"] = np.asarray(r, dtype=float).reshape(-1, len(lo))
    rows[f"cont_{i}"] = bool(np.asarray(info.continuum, dtype=bool)[exact].any())
np.savez(out, Q=Q, T=T, times=np.array(times), codes=np.array(codes), native=bool(module.NATIVE),
         scale=chain.scale, revolute=np.array([k == "R" for k in module.JOINT_TYPES]),
         free=" ".join(module.FREE_JOINTS), **rows)
"""


def log(msg: str) -> None:
    print(f"[s2rrr_arms {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def run(root: Path, name: str, eps: float, n_rand: int, n_special: int, out: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(root)}
    source = SOLVE.replace("__ARMS__", repr(ARMS))
    argv = [str(root), name, str(eps), str(n_rand), str(n_special), str(out)]
    subprocess.run([sys.executable, "-c", source, *argv], env=env, check=True, capture_output=True, text=True)
    with np.load(out) as data:
        return {k: data[k] for k in data.files}


def _close(a, b, revolute) -> bool:
    d = np.abs(a - b)
    d = np.where(revolute, np.abs(np.remainder(d + np.pi, 2 * np.pi) - np.pi), d)
    return bool(d.max() <= SAME)


def check(res: dict, chain_fk) -> tuple[int, int, int]:
    """(wrong rows, missed samples, rows) of one checkout's results; a pose whose rows represent a
    self-motion (continuum) is not counted as missed (its sample is one member of the family)."""
    wrong = missed = total = 0
    rev = res["revolute"]
    for i in range(len(res["Q"])):
        rows = res[f"rows_{i}"]
        total += len(rows)
        for r in rows:
            G = chain_fk(r)
            dp = np.linalg.norm(G[:3, 3] - res["T"][i][:3, 3]) / res["scale"]
            dr = np.linalg.norm(G[:3, :3] - res["T"][i][:3, :3])
            wrong += int(dp > EXACT or dr > EXACT)
        missed += int(not res[f"cont_{i}"] and not any(_close(r, res["Q"][i], rev) for r in rows))
    return wrong, missed, total


def differing(a: dict, b: dict) -> tuple[int, int, int]:
    """(poses whose rows differ as sets; of them those where both checkouts return representatives of
    a self-motion, another member of the same family being as right; and those where ``a`` recovers
    the sample and ``b`` does not)."""
    rev = a["revolute"]
    n = fam = fixed = 0
    for i in range(len(a["Q"])):
        ra, rb = a[f"rows_{i}"], b[f"rows_{i}"]
        one = all(any(_close(x, y, rev) for y in rb) for x in ra)
        two = all(any(_close(x, y, rev) for x in ra) for y in rb)
        if not (one and two):
            n += 1
            if bool(a[f"cont_{i}"]) and bool(b[f"cont_{i}"]):
                fam += 1
            else:
                q = a["Q"][i]
                fixed += int(any(_close(r, q, rev) for r in ra) and not any(_close(r, q, rev) for r in rb))
    return n, fam, fixed


def _chain(name: str, eps: float):
    sys.path.insert(0, str(ROOT))
    from ikcompiler import configs, robotdb

    package, file, tip = ARMS[name]
    entry = next(e for e in robotdb.discover(packages=robotdb.EXTRA).chains
                 if e.package == package and e.rel.rsplit("/", 1)[-1] == file and e.tip == tip)
    chain = entry.load()
    return configs.perturbed(chain, eps, seed=7) if eps else chain


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--against", type=Path, help="another checkout: its times and rows beside these")
    ap.add_argument("--poses", type=int, default=200)
    ap.add_argument("--special", type=int, default=100)
    ap.add_argument("--cases", nargs="*", default=list(ARMS))
    ap.add_argument("--jobs", type=int, default=1, help="cases measured at once (one process each)")
    ap.add_argument("--out", type=Path, default=RESULTS / "s2rrr_arms.md")
    args = ap.parse_args(argv)
    lines = [
        "# pr2 / tiago arms (S2-RRR plans): single-solve CPU time, round trip, completeness",
        "",
        f"`python benchmarks/s2rrr_arms.py{' --against DIR' if args.against else ''} --poses {args.poses} "
        f"--special {args.special}`; {platform.machine()}, load {os.getloadavg()[0]:.1f} at the start.",
        "Median / 90th percentile CPU ms of `module.solve` (limits on), fastest of 2 a pose; wrong: rows off",
        "the target by more than 1e-12; missed: samples not among the rows (1e-6 rad), poses at a",
        "self-motion (a continuum row) left out; differ: poses whose rows differ from the other",
        "checkout's as sets (1e-6 rad), in parentheses those where both return representatives of a",
        "self-motion and those where only this checkout recovers the sample.",
        "",
        "| arm | perturbed | plan | C | poses | rows | wrong | missed | median ms | p90 ms |"
        + (" before median | before p90 | before C | before missed | differ (self-motion, fixed) |"
           if args.against else ""),
        "|---|---|---|---|---|---|---|---|---|---|" + ("---|---|---|---|---|" if args.against else ""),
    ]
    def case(name: str, eps: float, tmp: Path) -> tuple[str, int]:
        log(f"{name} eps={eps:g}")
        now = run(ROOT, name, eps, args.poses, args.special, tmp / f"now_{name}_{eps:g}.npz")
        codes = [str(c) for c in now["codes"]]
        if "S2-RRR" not in codes:
            return (f"| {name} | {eps:g} | {' '.join(codes)} (no S2-RRR) | | | | | | | |"
                    + (" | | | | |" if args.against else "")), 0
        chain = _chain(name, eps)
        wrong, missed, total = check(now, chain.fk)
        bad = wrong
        t = now["times"] * 1e3
        row = (f"| {name} | {eps:g} | {' + '.join(codes)} | {'yes' if now['native'] else 'no'} | "
               f"{len(now['Q'])} | {total} | {wrong} | {missed} | {np.median(t):.3f} | "
               f"{np.percentile(t, 90):.3f} |")
        if args.against:
            before = run(args.against.resolve(), name, eps, args.poses, args.special,
                         tmp / f"before_{name}_{eps:g}.npz")
            tb = before["times"] * 1e3
            d, fam, fixed = differing(now, before)
            _, missed_before, _ = check(before, chain.fk)
            bad += d - fam - fixed + max(0, missed - missed_before)
            row += (f" {np.median(tb):.3f} | {np.percentile(tb, 90):.3f} | "
                    f"{'yes' if before['native'] else 'no'} | {missed_before} | {d} ({fam}, {fixed}) |")
        log(row)
        return row, bad

    work = [(name, eps) for name in args.cases for eps in EPS]
    with tempfile.TemporaryDirectory() as tmp, concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        done = list(pool.map(lambda w: case(*w, Path(tmp)), work))
    lines += [row for row, _ in done]
    bad = sum(b for _, b in done)
    lines += ["", f"load {os.getloadavg()[0]:.1f} at the end."]
    args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
