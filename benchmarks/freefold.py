"""What a general 6R solver costs per free value of a 7R chain folded at its free joint
(runtime/freefold.py; docs/design.md section 5, "General 6R"), and where the time goes.

    python benchmarks/freefold.py [--values 13] [--out benchmarks/results/freefold.md]

On general 7R arms (``configs.random_chain("RRRRRRR", seed)``, free joint 3): a ``General6`` build
choosing its arrangements on sample poses, against one at the arrangements chosen at compile time
(``freefold.choose_arrangements``), the first target solved at a new free value (the first
arrangement's matrices are built then), a target at a value already built, and the generated
module's ``solve_batch`` with every pose at its own free value.  Wall time, median over the values.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import math
import pstats
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
# Run as a script, this folder is first on sys.path: benchmarks/subproblems.py would shadow the package.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != ROOT / "benchmarks"]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ikcompiler.compiler import compile_robot  # noqa: E402
from ikcompiler.configs import random_chain  # noqa: E402
from ikcompiler.runtime import freefold  # noqa: E402
from subproblems import general6  # noqa: E402

OUT = Path(__file__).resolve().parent / "results" / "freefold.md"
SEEDS = (3, 5, 8)
FREE = 2  # chain index of the free joint (the elbow of a 7-joint arm)


def _ms(call) -> float:
    t = time.perf_counter()
    call()
    return 1e3 * (time.perf_counter() - t)


def _profile(call, top: int = 6) -> str:
    pr = cProfile.Profile()
    pr.enable()
    call()
    pr.disable()
    out = io.StringIO()
    pstats.Stats(pr, stream=out).sort_stats("cumtime").print_stats(top)
    keep = [line.replace(str(ROOT) + "/", "") for line in out.getvalue().splitlines()
            if "general6.py" in line or "ncalls" in line]
    return "\n".join(keep)


def measure(seed: int, count: int) -> tuple[dict, str]:
    chain = random_chain("RRRRRRR", seed=seed)
    tw, home, scale = chain.twists, np.asarray(chain.home), chain.scale
    arrangement = freefold.choose_arrangements(tw, home, scale, FREE, -math.pi, math.pi)
    values = np.linspace(-3.0, 3.0, count) + 0.01 * seed
    Q = np.random.default_rng(seed).uniform(-math.pi, math.pi, size=(count, 7))
    Q[:, FREE] = values
    T = chain.fk_batch(Q)
    choose = [_ms(lambda v=v: general6.General6(*freefold.folded(tw, home, FREE, v), scale)) for v in values]
    given, first, again = [], [], []
    for n, v in enumerate(values):
        six = freefold.folded(tw, home, FREE, v)
        t = time.perf_counter()
        g = general6.General6(*six, scale, arrangement=arrangement)
        given.append(1e3 * (time.perf_counter() - t))
        first.append(_ms(lambda g=g, n=n: g.rows(T[n:n + 1])))
        again.append(_ms(lambda g=g, n=n: g.rows(T[n:n + 1])))
    module = compile_robot(chain, free=(chain.joints[FREE].name,))
    module.solve_batch(T[:1], Q[:1, FREE])
    batch = _ms(lambda: module.solve_batch(T, Q[:, FREE])) / count
    prof = _profile(lambda: [general6.General6(*freefold.folded(tw, home, FREE, v), scale)
                             for v in values[:4]])
    row = {"seed": seed, "method": module.METHOD, "arrangements": len(arrangement),
           "choose": statistics.median(choose), "given": statistics.median(given),
           "first": statistics.median(first), "again": statistics.median(again), "batch": batch}
    return row, prof


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--values", type=int, default=13, help="free values (and poses) per arm")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    lines = ["# Folded general 6R: cost per free value (`python benchmarks/freefold.py`)", "",
             __doc__.split("\n\n", 2)[2].strip(), "",
             "| arm seed | method | arrangements | build, choosing (ms) | build, given (ms) | "
             "first target at a new value (ms) | target at a built value (ms) | solve_batch, own value "
             "each (ms/pose) |", "|---|---|---|---|---|---|---|---|"]
    profiles = []
    for seed in SEEDS:
        r, prof = measure(seed, args.values)
        lines.append(f"| {r['seed']} | {r['method']} | {r['arrangements']} | {r['choose']:.1f} | "
                     f"{r['given']:.2f} | {r['first']:.2f} | {r['again']:.2f} | {r['batch']:.2f} |")
        profiles.append(f"seed {seed}, four builds choosing their arrangements (cProfile, cumulative):\n"
                        + prof)
    lines += ["", "Where a choosing build's time goes:", "", "```", *profiles, "```", ""]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
