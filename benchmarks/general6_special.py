"""Why the general-6r C path hands the Jaco's special poses back, and where their time goes (issue 10 /
11; docs/general6.md, "Special poses").

The poses are ``special_poses.py``'s (the same seeds): 300 random, 300 special (every joint value drawn
from {0, +-pi/2, pi}) and 300 taught (special values inside the limits).  For each set:

* how many targets the module's C (``NativeChain.exact``, every C arrangement in order) hands back to
  the Python ``General6``;
* of those, how many have their sampled joint vector at a singular configuration (smallest over
  largest singular value of the Jacobian, lengths over the size, below ``SINGULAR``: the pose's
  solution is a double root of det M, which the C's sign-based root isolation cannot certify), and how
  many have a pencil that is singular at the target in every C arrangement (M(th) rank-deficient at
  three unrelated angles: det M(th) vanishes identically, so D carries no information and its
  coefficient check fails);
* the single-pose ``solve`` median (wall, fastest of 3) of the settled and of the handed-back targets;
* for the first ``--profile`` handed-back special poses, a ``cProfile`` of ``solve``: the top functions
  by cumulative time, per pose;
* ``--compare``: the module's ``solve`` (limits on) against the reference runtime's (``NATIVE = False``:
  the path the handed-back targets took) on the same poses and on 4 random general 6R arms (150
  all-special and 150 random poses each, limits off): sampled vectors recovered (1e-6 rad), distinct
  solutions (1e-4 apart), reference solutions with no row of the module within 1e-4, rows not exact at
  1e-12, single-pose median and p99.

``python benchmarks/general6_special.py`` writes ``benchmarks/results/general6_special.md`` (``--out``
another file: ``general6_special_main.md`` holds the run on main before the eigenvalue path in C).  The
machine is shared: wall times carry its load (written with the results); the counts do not.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import os
import pstats
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
# the repository first (benchmarks/subproblems.py would shadow the package), the benchmarks last
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != ROOT / "benchmarks"]
sys.path.insert(0, str(ROOT))
sys.path.append(str(ROOT / "benchmarks"))

import special_poses as sp  # noqa: E402  (the benchmark's poses, same seeds)

from subproblems import general6 as g6  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "general6_special.md"
SINGULAR = 1e-10  # sigma_min / sigma_max of the Jacobian at the sampled vector: a singular configuration
PENCIL_SINGULAR = 1e-12  # sigma_min / sigma_max of M(th) at each probe angle: the pencil is singular there
PROBES = (0.3, 1.7, 4.1)  # angles unrelated to the special values


def _trig_pencil(C):
    """The C's 12 x 12 pencil M(th) = M0 + M1 cos th + M2 sin th (general6.h ikc_g6_candidates) from
    general6.py's equation coefficients C (6, 3 trig, 9 products), rows of equal weight."""
    half = np.kron(g6._HALF, g6._HALF)  # basis products -> monomials x_d^i x_e^j
    Mt = np.zeros((3, 12, 12))
    for t in range(3):
        E = C[:, t, :] @ half
        Mt[t, :6, :9] = E
        for md in range(3):
            Mt[t, 6:, 3 * md + 3:3 * md + 6] = E[:, 3 * md:3 * md + 3]
    norm = np.sqrt((Mt ** 2).sum(axis=(0, 2)))
    return Mt / np.where(norm > 0, norm, 1.0)[None, :, None]


def _pencil_singular(solver, arrangements, T) -> np.ndarray:
    """(N,) bool: M(th) rank-deficient at every probe angle in every given arrangement."""
    Gn = solver._norm(T) @ g6._inv(solver.Mn)
    out = np.ones(len(T), dtype=bool)
    for k in arrangements:
        C = solver._pencil(solver._arr[k], Gn)[2]
        for i in range(len(T)):
            if not out[i]:
                continue
            Mt = _trig_pencil(C[i])
            for th in PROBES:
                s = np.linalg.svd(Mt[0] + np.cos(th) * Mt[1] + np.sin(th) * Mt[2], compute_uv=False)
                if s[-1] > PENCIL_SINGULAR * s[0]:
                    out[i] = False
                    break
    return out


def _solve_time(module, t) -> float:
    best = np.inf
    for _ in range(3):
        s = time.perf_counter()
        module.solve(t)
        best = min(best, time.perf_counter() - s)
    return best


def _profile(module, targets) -> list[str]:
    prof = cProfile.Profile()
    prof.enable()
    for t in targets:
        module.solve(t)
    prof.disable()
    st = pstats.Stats(prof, stream=io.StringIO())
    n = len(targets)
    rows = []
    for (path, line, name), (_, nc, tt, ct, _callers) in st.stats.items():
        short = f"{Path(path).name}:{line}({name})" if path != "~" else name
        rows.append((ct, nc, tt, short))
    rows.sort(reverse=True)
    wanted = ("dispatch.py", "reference.py", "general6.py", "selfmotion.py", "plan_runtime.py", "robot.py")
    lines = ["| function | calls per pose | cumulative ms per pose | own ms per pose |",
             "|---|---:|---:|---:|"]
    for ct, nc, tt, short in rows:
        if short.split(":")[0] in wanted:
            lines.append(f"| `{short}` | {nc / n:.1f} | {ct / n * 1e3:.1f} | {tt / n * 1e3:.1f} |")
        if len(lines) >= 22:
            break
    return lines


def _gap(A, q):
    return np.abs(np.angle(np.exp(1j * (A - q)))).max(axis=1)


def _distinct(rows) -> int:
    kept = []
    for q in rows:
        if not kept or _gap(np.array(kept), q).min() > 1e-4:
            kept.append(q)
    return len(kept)


def _against_reference(module, Q, T, limits: bool) -> str:
    """One table row: the module (C) against its reference runtime on the targets T sampled at Q."""
    d = dict(c_rec=0, r_rec=0, c_dist=0, r_dist=0, r_only=0, wrong=0)
    times = []
    for i in range(len(T)):
        s = time.perf_counter()
        rows = module.solve(T[i], limits=limits)
        times.append(time.perf_counter() - s)
        module.NATIVE = False
        try:
            ref = module.solve(T[i], limits=limits)
        finally:
            module.NATIVE = True
        d["c_rec"] += int(bool(len(rows)) and _gap(rows, Q[i]).min() < 1e-6)
        d["r_rec"] += int(bool(len(ref)) and _gap(ref, Q[i]).min() < 1e-6)
        d["c_dist"] += _distinct(rows)
        d["r_dist"] += _distinct(ref)
        d["r_only"] += sum(1 for q in ref if not len(rows) or _gap(rows, q).min() > 1e-4)
        for q in rows:
            G = module.fk(q)
            err = max(np.linalg.norm(G[:3, 3] - T[i][:3, 3]) / module.SCALE,
                      np.linalg.norm(G[:3, :3] - T[i][:3, :3]))
            d["wrong"] += int(err > 1e-12)
    t = np.array(times) * 1e6
    return (f"{d['c_rec']} / {d['r_rec']} | {d['c_dist']} / {d['r_dist']} | {d['r_only']} | {d['wrong']} "
            f"| {np.median(t):.0f} | {np.percentile(t, 99):.0f} |")


def _compare(module, sets) -> list[str]:
    from ikcompiler import compile_robot
    from ikcompiler.configs import random_6r_chain

    lines = ["", "## The module against the reference runtime", "",
             "`solve` with the C against `solve` with `NATIVE = False` (the path of the targets the C handed "
             "back). Recovered: sampled vector among the rows (1e-6 rad); distinct: solutions 1e-4 apart; "
             "reference only: reference solutions with no module row within 1e-4; wrong: rows not exact at "
             "1e-12 of the size. Times: the module's `solve`, wall.", "",
             "| robot | poses | limits | recovered (module / reference) | distinct | reference only | wrong "
             "| median us | p99 us |", "|---|---|---|---|---|---:|---:|---:|---:|"]
    for label, Q, T in sets:
        lines.append(f"| jaco | {label} | on | " + _against_reference(module, Q, T, True))
        print(lines[-1], file=sys.stderr, flush=True)
    for seed in range(4):
        arm = compile_robot(random_6r_chain(seed))
        arm._native_chain()
        rng = np.random.default_rng(50 + seed)
        for label, Q in (("special", rng.choice(sp.SPECIAL, size=(150, 6))),
                         ("random", rng.uniform(-np.pi, np.pi, size=(150, 6)))):
            T = np.array([arm.fk(q) for q in Q])
            row = _against_reference(arm, Q, T, False)
            lines.append(f"| random_6r_chain({seed}) | {label} | off | " + row)
            print(lines[-1], file=sys.stderr, flush=True)
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", type=int, default=20, help="handed-back special poses profiled")
    ap.add_argument("--out", default=str(OUT))
    ap.add_argument("--compare", action="store_true", help="the module against its reference runtime too")
    args = ap.parse_args(argv)
    load = os.getloadavg()
    _, module, _ = sp._setup("jaco")
    nc = module._native_chain()
    solver = module._GENERAL6
    from ikcompiler.codegen import csource

    arrangements = csource.general6_native_arrangements(solver)
    special, random = sp._joint_sets(module, np.random.default_rng(7), sp.POSES)
    taught = sp._taught(module, np.random.default_rng(8), sp.POSES, random)
    command = "python benchmarks/general6_special.py" + (" --compare" if args.compare else "")
    lines = ["# General-6r: the Jaco's special poses, why they are handed back and where the time goes", "",
             f"Command: `{command} --profile {args.profile}`; poses of "
             f"`special_poses.py` (seeds 7, 8; {sp.POSES} a set); C arrangements {arrangements}.  Machine: "
             f"shared, 2 cores, load average at start {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f}.", "",
             "*Singular sample*: the sampled joint vector's Jacobian has sigma_min / sigma_max below "
             f"{SINGULAR:g} (a double root of det M).  *Singular pencil*: M(th) has sigma_min / sigma_max "
             f"below {PENCIL_SINGULAR:g} at th = {', '.join(map(str, PROBES))} in every C arrangement "
             "(det M vanishes identically at the target).", "",
             "| set | handed back by C | of them: singular sample | singular pencil | both | neither "
             "| settled: solve median us | handed back: solve median us |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    profiled, sets = None, []
    for label, Q in (("random", random), ("special", special), ("taught", taught)):
        T = sp._targets(module, Q)
        sets.append((label, Q, T))
        back = np.array([nc.exact(t, (), True) is None for t in T])
        _, J = solver._jacobian(Q)
        s = np.linalg.svd(J, compute_uv=False)
        singular = s[:, -1] < SINGULAR * s[:, 0]
        pencil = np.zeros(len(T), dtype=bool)
        pencil[back] = _pencil_singular(solver, arrangements, T[back])
        module.solve(T[0])
        t = np.array([_solve_time(module, x) for x in T]) * 1e6
        settled = f"{np.median(t[~back]):.0f}" if (~back).any() else "-"
        handed = f"{np.median(t[back]):.0f}" if back.any() else "-"
        lines.append(f"| {label} | {int(back.sum())} | {int((back & singular).sum())} "
                     f"| {int((back & pencil).sum())} | {int((back & singular & pencil).sum())} "
                     f"| {int((back & ~singular & ~pencil).sum())} | {settled} | {handed} |")
        print(lines[-1], file=sys.stderr, flush=True)
        if label == "special":
            profiled = T[np.nonzero(back)[0][:args.profile]]
    if args.compare:
        lines += _compare(module, sets)
    if len(profiled):
        lines += ["", f"## Profile: `solve` of the first {len(profiled)} handed-back special poses", "",
                  "`cProfile`, per pose (the profiler's overhead included); the runtime's and general6.py's "
                  "functions by cumulative time.", ""]
        module.solve(profiled[0])
        lines += _profile(module, profiled)
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
