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
    p = sub.add_parser("zoo", help="list the robots of the zoo")
    p.set_defaults(func=_cmd_zoo)
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
