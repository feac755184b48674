"""The native general-6r path's hand-back to the Python general6, measured
(issue 10 / 11; docs/general6.md, "Native path" and "When it is used").

* The zoo's Jaco at POSES poses inside its limits (seed 21) with a share of the joint values at 0,
  +-pi/2, pi (0, 0.3, 0.5, 1): targets the C hands back to the Python general6 with the module's C
  (every arrangement the C covers, in order: a target doubtful under one is re-solved under the next)
  and with its first arrangement alone (what the C did before); single-pose ``solve`` median, p90 and
  p99 (wall, warm); recovered sampled vectors and rows of ``solve_batch``.
* Compile: ``compile_robot`` wall time (warm process, the C build cached) for the Jaco.

The route (1-D search or general-6r, ikcompiler/general6_route.py) is measured by
``benchmarks/general6.py`` ("The 1-D search or general-6r: the compile-time decision").

``python benchmarks/general6_fallback.py [--poses 400]`` writes ``benchmarks/results/general6_fallback.md``.
The machine is shared (2 cores): the load average is written with the results; wall times are
inflated by it, the hand-back counts are not.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != ROOT / "benchmarks"]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ikcompiler import compile_robot, load_robot  # noqa: E402
from ikcompiler.codegen import csource  # noqa: E402
from ikcompiler.verify import sample_configurations  # noqa: E402
from subproblems import general6 as g6  # noqa: E402
from subproblems import native  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "general6_fallback.md"
SHARES = (0.0, 0.3, 0.5, 1.0)


def _first_only(module, chain):
    """A NativeChain of the module's C with its first arrangement alone (to count its hand-backs)."""
    ns = vars(module)
    solver = g6.General6(chain.twists, chain.home, chain.scale, arrangement=[module._GENERAL6.usable[0]])
    src = csource.module_c_source(ns, general6=solver)
    return native.bind(src, dof=6, slots=ns["MAX_SOLUTIONS"], nfree=0, target="pose")


def jaco_section(poses: int, log) -> list[str]:
    chain = load_robot("jaco")
    compile_robot(chain)
    times = []
    for _ in range(3):
        t = time.perf_counter()
        module = compile_robot(chain)
        times.append(time.perf_counter() - t)
    nc = module._SOLVER.native_chain()
    first = _first_only(module, chain)
    lines = ["## Jaco: targets handed back to the Python general6", "",
             f"{poses} poses inside the limits (seed 21) per share of special values. C arrangements: "
             f"{csource.general6_native_arrangements(module._GENERAL6)} "
             f"(general6.py's usable order {module._GENERAL6.usable}). `compile_robot` (warm, C cached): "
             f"median {np.median(times) * 1e3:.0f} ms of {len(times)}.", "",
             "| special share | handed back (all C arrangements) | handed back (first alone) "
             "| solve median us | p90 us | p99 us | recovered | rows |",
             "|---|---|---|---|---|---|---|---|"]
    for share in SHARES:
        Q = sample_configurations(chain, poses, seed=21, special=share)
        T = chain.fk_batch(Q)
        back = sum(nc.exact(t, (), True) is None for t in T)
        back_first = sum(first.exact(t, (), True) is None for t in T)
        module.solve(T[0])
        wall = []
        for t in T:
            s = time.perf_counter()
            module.solve(t)
            wall.append(time.perf_counter() - s)
        wall = np.array(wall) * 1e6
        S, V = module.solve_batch(T)
        d = np.abs(np.angle(np.exp(1j * (S - Q[:, None, :])))).max(axis=2)
        hit = int((np.where(V, d, np.inf).min(axis=1) < 1e-6).sum())
        log(f"jaco share {share}: back {back} (first alone {back_first})")
        lines.append(f"| {share:g} | {back}/{poses} | {back_first}/{poses} | {np.median(wall):.0f} "
                     f"| {np.percentile(wall, 90):.0f} | {np.percentile(wall, 99):.0f} | {hit}/{poses} "
                     f"| {int(V.sum())} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=400)
    args = ap.parse_args(argv)

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    load = os.getloadavg()
    lines = ["# General-6r native path: hand-back", "",
             f"Command: `python benchmarks/general6_fallback.py --poses {args.poses}`. "
             "Machine: shared, 2 cores, "
             f"load average at start {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f}.", ""]
    lines += jaco_section(args.poses, log)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n")
    log(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
