"""`ikc singularities` on every zoo robot with the default 10000 samples, written to results/singularities.md.

For each robot: time, symbolic status, the conditions (name, equations, inside the limits), and the
sampling counts (near-singular below the threshold, explained by a condition, unexplained ones that lead
down to a nonzero local minimum of sigma_min).  Not a test: ``python benchmarks/singularities.py
[--samples N] [--budget S]``.
"""

from __future__ import annotations

import argparse
import datetime
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import sympy as sp  # noqa: E402

from ikcompiler import load_robot  # noqa: E402
from ikcompiler.analysis.singularities import analyse  # noqa: E402
from ikcompiler.inputs.zoo import zoo_names  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=10000)
    ap.add_argument("--budget", type=float, default=8.0)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "singularities.md"))
    args = ap.parse_args(argv)
    rows, details = [], []
    for name in zoo_names():
        print(f"{name} ...", file=sys.stderr, flush=True)
        chain = load_robot(name)
        t = time.perf_counter()
        rep = analyse(chain, samples=args.samples, budget=args.budget)
        dt = time.perf_counter() - t
        s = rep.sampling
        rows.append(
            f"| {name} | {chain.joint_types} | {dt:.2f} | {rep.status} | {len(rep.conditions)} | "
            f"{'yes' if rep.singular_everywhere else 'no'} | {s.near_singular} | {s.explained} | "
            f"{s.nonsingular_minima} | {s.lowest[0][0]:.1e} |"
        )
        details.append(f"### {name}\n")
        for c in rep.conditions:
            eqs = ", ".join(f"`{sp.sstr(e)} = 0`" for e in c.equations)
            details.append(f"- {c.name}: {eqs} ({'inside' if c.inside_limits else 'outside'} the limits)")
        if not rep.conditions:
            details.append("- no conditions")
        details.append("")
    text = [
        "# ikc singularities on the zoo",
        "",
        f"`python benchmarks/singularities.py --samples {args.samples} --budget {args.budget:g}`, "
        f"{datetime.date.today()}, {platform.processor() or platform.machine()}, Python "
        f"{platform.python_version()}.  Times are wall-clock on a machine shared with other jobs (2 cores):",
        "read them as upper bounds.  near: samples with sigma_min below 1e-3; explained: of those, within",
        "0.2 rad of a condition or leading down to a singular point on one; nonzero minima: unexplained",
        "samples whose local minimum of sigma_min is not 0.",
        "",
        "| robot | joints | seconds | symbolic | conditions | singular everywhere | near | explained | "
        "nonzero minima | smallest sigma_min |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        "## Conditions",
        "",
        *details,
    ]
    Path(args.out).write_text("\n".join(text) + "\n")
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
