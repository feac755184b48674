"""Round trip and completeness of every zoo robot's generated solver, written to results/completeness.md.

For each robot: N random poses inside the limits with no special angles (generic poses) and N with a
quarter of the joint values snapped to 0, +-pi/2, pi (special poses, where wrists line up and
self-motions appear).  Reported: recovered (the sampled joint vector is among the solutions), wrong
(a returned solution whose FK misses by more than 1e-9 of the robot's size), self-motion poses and
misses.  Not a test: ``python benchmarks/completeness.py [--poses N]``.
"""

from __future__ import annotations

import argparse
import datetime
import platform
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ikcompiler import load_robot  # noqa: E402
from ikcompiler.compiler import compile_robot  # noqa: E402
from ikcompiler.inputs.zoo import zoo_names  # noqa: E402
from ikcompiler.verify import verify  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=2000)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "completeness.md"))
    args = ap.parse_args(argv)
    rows = []
    for name in zoo_names():
        chain = load_robot(name)
        free = (chain.independent_names[-1],) if chain.dof > 6 else ()
        module = compile_robot(chain, free=free)
        for label, special in (("generic", 0.0), ("special", 0.25)):
            r = verify(chain, module, samples=args.poses, seed=11, scalar_checks=5, special=special)
            rows.append((name, module.METHOD, label, r))
            print(
                f"{name:14s} {label:8s} recovered {r.recovered}/{r.poses} wrong {r.wrong} "
                f"self-motion {r.self_motion} missed {r.missed}",
                flush=True,
            )
    lines = [
        "# Completeness of the generated solvers",
        "",
        f"{datetime.date.today()}, Python {platform.python_version()}, {platform.machine()}; "
        f"{args.poses} poses per row; free joint for 7-joint arms: the last one.",
        "",
        "| robot | method | poses | recovered | wrong | self-motion (no exact rep.) | missed | max error |",
        "|---|---|---|---:|---:|---:|---:|---:|",
    ]
    for name, method, label, r in rows:
        lines.append(
            f"| {name} | {method} | {label} | {r.recovered / r.poses:.2%} | {r.wrong} | "
            f"{r.self_motion} ({r.self_motion_unsolved}) | {r.missed} | {r.max_error:.1e} |"
        )
    lines += [
        "",
        "Generic poses: every joint uniform inside its limits.  Special poses: each revolute value is",
        "0, +-pi/2 or pi with probability 1/4; many such poses sit on a self-motion (a wrist with axes 4",
        "and 6 aligned, a prismatic joint in the plane of parallel axes), where the sampled vector is one",
        "of infinitely many solutions and a flagged representative is returned instead.",
    ]
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
