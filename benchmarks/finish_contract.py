"""The row contract on every zoo robot (docs/finish.md), written to results/finish_contract.md.

For each robot (its reduced target where it has one): N random poses, a quarter of the joint values
at 0, +-pi/2, pi; every count of :func:`ikcompiler.verify.verify`, recomputed from forward kinematics
and the limits.  Not a test: ``python benchmarks/finish_contract.py [--poses N]`` (progress on stderr).
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

from ikcompiler import load_robot  # noqa: E402
from ikcompiler.compiler import compile_robot  # noqa: E402
from ikcompiler.inputs.zoo import zoo_names  # noqa: E402
from ikcompiler.verify import verify  # noqa: E402

TARGETS = {"shadow_index": "position", "shadow_thumb": "position+direction"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "finish_contract.md"))
    args = ap.parse_args(argv)
    lines = [
        "# The row contract on the zoo (benchmarks/finish_contract.py)",
        "",
        f"{args.poses} poses per robot, seed {args.seed}, a quarter of the joint values at 0, +-pi/2, pi; "
        f"{datetime.date.today()}, Python {platform.python_version()}, a shared loaded machine.",
        "",
        "| robot | target | method | recovered | missed | self-motion | wrong | imprecise | outside limits "
        "| non-canonical | duplicate | max error | ok | time s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name in zoo_names():
        chain = load_robot(name)
        free = (chain.independent_names[-1],) if chain.dof > 6 else ()
        target = TARGETS.get(name, "pose")
        module = compile_robot(chain, free=free, target=target)
        start = time.perf_counter()
        r = verify(chain, module, samples=args.poses, seed=args.seed, scalar_checks=20)
        took = time.perf_counter() - start
        print(f"{name}: {'ok' if r.ok else 'FAILED'} ({took:.1f} s)", file=sys.stderr, flush=True)
        lines.append(
            f"| {name} | {target} | {r.method} | {r.recovered} | {r.missed} | {r.self_motion} | {r.wrong} "
            f"| {r.imprecise} | {r.outside_limits} | {r.non_canonical} | {r.duplicates} | {r.max_error:.1e} "
            f"| {'yes' if r.ok else 'no'} | {took:.1f} |"
        )
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
