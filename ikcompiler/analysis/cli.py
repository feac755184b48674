"""``ikc singularities ROBOT``: the singular set (symbolic conditions, confirmed by sampling), JSON, PNG."""

from __future__ import annotations

import json
import sys

from ikcompiler.errors import IkcError


def add_parser(sub) -> None:
    p = sub.add_parser(
        "singularities", help="the singular configurations: exact conditions, sampling, plots",
        description="Derive the singular set from the Jacobian's minors (sympy), confirm it by sampling "
        "the smallest singular value of the size-free Jacobian, optionally plot.  See docs/singularities.md.",
    )
    p.add_argument("robot", help="a .urdf file, a robot spec/DH .toml file, or the name of a zoo robot")
    p.add_argument("--base", help="base link (URDF); default: the root link")
    p.add_argument("--tip", help="tip link (URDF); default: the single leaf link")
    p.add_argument("--samples", type=int, default=10000, help="random configurations (default 10000)")
    p.add_argument("--threshold", type=float, default=None,
                   help="near-singular below this sigma_min (size-free; default 1e-3)")
    p.add_argument("--budget", type=float, default=8.0, help="seconds for sympy (default 8)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--png", metavar="FILE", help="write sigma_min plots to FILE")
    p.set_defaults(func=run)


def run(args) -> int:
    from ikcompiler import load_robot
    from ikcompiler.analysis.singularities import THRESHOLD, analyse

    if args.samples < 1:
        raise IkcError(f"--samples must be at least 1, got {args.samples}")
    chain = load_robot(args.robot, base=args.base, tip=args.tip)
    print(f"analysing {chain.name} ({chain.dof} joints) ...", file=sys.stderr)
    rep = analyse(chain, samples=args.samples, threshold=args.threshold or THRESHOLD,
                  budget=args.budget, seed=args.seed)
    if rep.status != "factored":
        print(f"symbolic: {rep.status}: {rep.message}; reporting the sampled minima", file=sys.stderr)
    if args.png:
        from dataclasses import replace

        from ikcompiler.analysis.plot import write_png

        rep = replace(rep, png=write_png(rep, chain, args.png))
    if args.json:
        print(json.dumps(rep.to_json(), indent=2))
    else:
        print(rep.text())
    return 0

