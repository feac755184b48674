"""``ikc``: the command-line face of ikcompiler.  A thin layer: parse arguments, call the API, print.

Every expected failure is an :class:`~ikcompiler.errors.IkcError`; it is printed as one line with what
to do next, and the exit code is 2.  Anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import sys

from ikcompiler.errors import IkcError


def _add_robot_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("robot", help="a .urdf file, a robot spec/DH .toml file, or the name of a zoo robot")
    p.add_argument("--base", help="base link (URDF); default: the root link")
    p.add_argument("--tip", help="tip link (URDF); default: the single leaf link")


def _cmd_describe(args) -> int:
    from ikcompiler import load_robot

    print(load_robot(args.robot, base=args.base, tip=args.tip).describe())
    return 0


def _compile_args(p: argparse.ArgumentParser) -> None:
    _add_robot_args(p)
    p.add_argument("--free", nargs="*", default=[], metavar="JOINT", help="free joints (redundant robots)")
    p.add_argument(
        "--target",
        default="pose",
        choices=["pose", "position", "orientation", "position+direction"],
        help="what is solved for",
    )


def _cmd_compile(args) -> int:
    from ikcompiler.compiler import compile_robot

    out = args.output or f"{_stem(args.robot)}_ik.py"
    module = compile_robot(
        args.robot, base=args.base, tip=args.tip, target=args.target, free=args.free, out=out
    )
    print(
        f"wrote {out}: {module.JOINT_TYPES} solver, method {module.METHOD}, "
        f"up to {module.MAX_SOLUTIONS} solutions, "
        + ("fast path" if module.FAST_PATH else "reference runtime only (a step has no fast kernel)")
    )
    if getattr(module, "NATIVE", False):
        print(_native_status(module))
    if module.METHOD != "closed-form":
        print(
            f"note: no closed-form chain; see `ikc explain {args.robot}` for what was tried", file=sys.stderr
        )
    return 0


def _native_status(module) -> str:
    """Build the module's C chain now (so the first solve does not pay for it) and say how it went."""
    import time

    from subproblems import native

    start = time.perf_counter()
    if module._native_chain() is None:
        return (f"native backend unavailable: {native.last_error}; the module runs its Python fast path "
                "(same answers, slower)")
    seconds = time.perf_counter() - start
    return f"native backend: C chain ready in {seconds:.2f} s (cache {native.cache_dir()})"


def _cmd_explain(args) -> int:
    from ikcompiler import load_robot
    from ikcompiler.compiler import compile_plan

    chain = load_robot(args.robot, base=args.base, tip=args.tip)
    plan = compile_plan(chain, target=args.target, free=args.free)
    print(plan.to_json(indent=2) if args.json else plan.explain())
    return 0


def _cmd_verify(args) -> int:
    from ikcompiler import load_robot
    from ikcompiler.compiler import compile_robot
    from ikcompiler.verify import verify

    chain = load_robot(args.robot, base=args.base, tip=args.tip)
    module = compile_robot(chain, target=args.target, free=args.free)
    print(f"verifying {chain.name} on {args.samples} random poses ...", file=sys.stderr)

    def progress(done, total):
        print(f"  solved {done}/{total} poses", file=sys.stderr, flush=True)

    report = verify(
        chain, module, samples=args.samples, seed=args.seed, progress=progress, special=args.special,
        allow_missed=args.allow_missed,
    )
    print(report.text())
    return 0 if report.ok else 1


def _stem(robot: str) -> str:
    from pathlib import Path

    name = Path(robot).name
    return name.split(".")[0] or "robot"


def _cmd_zoo(args) -> int:
    from ikcompiler.inputs.zoo import zoo_names

    for name in zoo_names():
        print(name)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ikc", description="Compile a robot's inverse kinematics into a Python solver module."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("describe", help="load a robot and print its POE model")
    _add_robot_args(p)
    p.set_defaults(func=_cmd_describe)
    p = sub.add_parser("compile", help="write the IK solver module of a robot")
    _compile_args(p)
    p.add_argument("-o", "--output", help="output .py file (default: ROBOT_ik.py)")
    p.set_defaults(func=_cmd_compile)
    p = sub.add_parser("explain", help="print the geometry found and the subproblem chain")
    _compile_args(p)
    p.add_argument(
        "--json", action="store_true", help="print the plan as JSON (Plan.to_json; docs/design.md section 12)"
    )
    p.set_defaults(func=_cmd_explain)
    p = sub.add_parser("verify", help="compile, then check solutions on random poses")
    _compile_args(p)
    p.add_argument("--samples", type=int, default=200, help="number of random poses (default 200)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--special", type=float, default=0.25, help="chance of a special angle 0, +-pi/2, pi per joint (0.25)"
    )
    p.add_argument(
        "--allow-missed", type=int, default=0, metavar="N",
        help="missed poses tolerated before the exit code is non-zero (default 0)",
    )
    p.set_defaults(func=_cmd_verify)
    p = sub.add_parser("zoo", help="list the robots of the zoo")
    p.set_defaults(func=_cmd_zoo)
    __import__("ikcompiler.analysis.cli", fromlist=["add_parser"]).add_parser(sub)  # ikc singularities
    __import__("ikcompiler.motion.cli", fromlist=["add_parser"]).add_parser(sub)  # ikc path, ikc trajectory
    __import__("ikcompiler.hands.cli", fromlist=["add_parser"]).add_parser(sub)  # ikc manipulate
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except IkcError as exc:
        print(f"ikc {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
