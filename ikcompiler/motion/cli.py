"""``ikc path`` and ``ikc trajectory``: the command-line face of :mod:`ikcompiler.motion`."""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from ikcompiler.errors import MotionError


def parse_values(text: str, count: int, what: str, names=()) -> np.ndarray:
    """Comma-separated numbers; a value ending in ``deg`` is in degrees (e.g. ``30deg``).

    >>> parse_values("0.5, 30deg", 2, "--start").round(6).tolist()
    [0.5, 0.523599]
    """
    parts = [p.strip() for p in text.split(",") if p.strip()]
    if len(parts) != count:
        expect = f" ({', '.join(names)})" if names else ""
        raise MotionError(f"{what} needs {count} comma-separated values{expect}; got {len(parts)}: {text!r}")
    out = []
    for p in parts:
        try:
            out.append(math.radians(float(p[:-3])) if p.endswith("deg") else float(p))
        except ValueError:
            raise MotionError(f"{what}: {p!r} is not a number (radians, or degrees with a 'deg' suffix)"
                              ) from None
    v = np.array(out)
    if not np.all(np.isfinite(v)):
        raise MotionError(f"{what} contains NaN or infinity: {text!r}")
    return v


def _robot_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("robot", help="a .urdf file, a robot spec/DH .toml file, or the name of a zoo robot")
    p.add_argument("--base", help="base link (URDF); default: the root link")
    p.add_argument("--tip", help="tip link (URDF); default: the single leaf link")


def _check_limits(q, chain, what: str) -> None:
    kinds = "".join(chain.joints[i].kind for i in chain.independent)
    from subproblems.select import excluding_joints

    out = excluding_joints(q[None], kinds, chain.lower, chain.upper)[0]
    if out.any():
        j = int(np.nonzero(out)[0][0])
        raise MotionError(f"{what}: {chain.independent_names[j]} = {q[j]:.6g} lies outside its limits "
                          f"[{chain.lower[j]:.6g}, {chain.upper[j]:.6g}]")


def _cmd_path(args) -> int:
    from ikcompiler import load_robot
    from ikcompiler.compiler import compile_robot
    from ikcompiler.motion import follow, pose_from_xyzrpy, straight_line

    chain = load_robot(args.robot, base=args.base, tip=args.tip)
    module = compile_robot(chain, target=args.target, free=args.free)
    names = tuple(module.JOINT_NAMES)
    q0 = parse_values(args.start, len(names), "--start", names)
    _check_limits(q0, chain, "--start")
    goal = pose_from_xyzrpy(*parse_values(args.to, 6, "--to", ("x", "y", "z", "roll", "pitch", "yaw")))
    step = args.step if args.step is not None else module.SCALE / 100
    angle = parse_values(args.max_angle, 1, "--max-angle")[0]
    T0 = module.fk(q0)
    if module.TARGET == "position":  # only the tool origin counts: keep the start orientation
        goal[:3, :3] = T0[:3, :3]
    poses = straight_line(T0, goal, max_step=step, max_angle=angle)
    print(f"following {len(poses)} poses of {chain.name} ...", file=sys.stderr)

    def progress(done, total):
        if done == total or done % max(1, total // 10) == 0:
            print(f"  solved {done}/{total} waypoints", file=sys.stderr, flush=True)

    path = follow(module, poses, q0, progress=progress)
    if args.csv:
        _write_path_csv(path, args.csv)
    if args.png:
        from ikcompiler.motion.plot import plot_path

        plot_path(path, args.png, title=f"{chain.name}: straight line")
    if args.json:
        print(json.dumps(path.to_json()))
    else:
        steps = np.abs(path.steps()).max(axis=0) if len(path.q) > 1 else np.zeros(len(names))
        state = "complete" if path.complete else "NOT complete"
        print(f"{len(path.q)} rows, {state}; largest step per joint: "
              + ", ".join(f"{n} {s:.4g}" for n, s in zip(names, steps)))
        for e in path.events:
            print(f"  event at row {e.index} (waypoint {path.s[e.index]:.4g}): {e.kind} "
                  f"[{', '.join(e.joints)}] {e.detail}")
    return 0 if path.complete else 1


def _write_path_csv(path, file) -> None:
    from ikcompiler.motion.poses import matrix_to_rpy

    with open(file, "w") as f:
        f.write(",".join(["row", "s", *path.joints, "x", "y", "z", "roll", "pitch", "yaw"]) + "\n")
        for k, (q, T) in enumerate(zip(path.q, path.poses)):
            vals = [*q, *T[:3, 3], *matrix_to_rpy(T[:3, :3])]
            f.write(",".join([str(k), repr(float(path.s[k]))] + [repr(float(v)) for v in vals]) + "\n")


DEFAULT_V, DEFAULT_A = 1.0, 2.0  # rad/s, rad/s^2 for revolute joints without --duration or limits
DEFAULT_V_T, DEFAULT_A_T = 0.25, 0.5  # prismatic: fractions of the robot's size per s, per s^2


def _cmd_trajectory(args) -> int:
    from ikcompiler import load_robot
    from ikcompiler.motion import quintic, trapezoid

    chain = load_robot(args.robot, base=args.base, tip=args.tip)
    names = tuple(chain.independent_names)
    q0 = parse_values(args.start, len(names), "--start", names)
    q1 = parse_values(args.goal, len(names), "--goal", names)
    _check_limits(q0, chain, "--start")
    _check_limits(q1, chain, "--goal")
    vmax, amax = args.vmax, args.amax
    if args.duration is None:  # the shortest within the limits; defaults by joint type
        kinds = "".join(chain.joints[i].kind for i in chain.independent)
        if vmax is None:
            vmax = np.array([DEFAULT_V if k == "R" else DEFAULT_V_T * chain.scale for k in kinds])
        if amax is None:
            amax = np.array([DEFAULT_A if k == "R" else DEFAULT_A_T * chain.scale for k in kinds])
    make = quintic if args.profile == "quintic" else trapezoid
    traj = make(q0, q1, args.duration, vmax=vmax, amax=amax)
    if args.csv:
        t, q, _, _ = traj.sample(args.dt)
        q[0], q[-1] = q0, q1  # the evaluation returns the knots there; say so explicitly
        with open(args.csv, "w") as f:
            f.write(",".join(["t", *names]) + "\n")
            for ti, row in zip(t, q):
                f.write(",".join([repr(float(ti))] + [repr(float(v)) for v in row]) + "\n")
    if args.png:
        from ikcompiler.motion.plot import plot_trajectory

        plot_trajectory(traj, chain.fk, names, args.png, dt=args.dt,
                        title=f"{chain.name}: {args.profile}, {traj.duration:.3g} s")
    vpk, apk = traj.peaks()
    print(f"{args.profile} trajectory of {chain.name}: {traj.duration:.6g} s")
    for n, v, a in zip(names, vpk, apk):
        print(f"  {n}: peak velocity {v:.6g}, peak acceleration {a:.6g}")
    return 0


def add_parser(sub) -> None:
    """Register ``path`` and ``trajectory`` on the ``ikc`` subcommand parser."""
    p = sub.add_parser("path", help="follow a straight tool line from a joint configuration (one IK branch)")
    _robot_args(p)
    p.add_argument("--target", default="pose", choices=["pose", "position", "position+direction"],
                   help="what is solved for (default pose)")
    p.add_argument("--free", nargs="*", default=[], metavar="JOINT",
                   help="free joints (redundant robots), held at their --start values")
    p.add_argument("--start", required=True, metavar="Q",
                   help="joint values, comma-separated, JOINT_NAMES order")
    p.add_argument("--to", required=True, metavar="POSE",
                   help="goal x,y,z,roll,pitch,yaw of the tool, base frame (robot units; radians, fixed XYZ)")
    p.add_argument("--step", type=float, metavar="LENGTH", help="largest step in length (default SCALE/100)")
    p.add_argument("--max-angle", default="2deg", metavar="ANGLE",
                   help="largest step in orientation (radians, or e.g. 2deg; default 2deg)")
    p.add_argument("--json", action="store_true", help="print the path as one JSON object")
    p.add_argument("--csv", metavar="FILE", help="write the rows: row, s, joints, x, y, z, roll, pitch, yaw")
    p.add_argument("--png", metavar="FILE", help="write a figure: joints along the path and the tool path")
    p.set_defaults(func=_cmd_path)

    p = sub.add_parser("trajectory", help="a synchronised joint trajectory (quintic or trapezoidal velocity)")
    _robot_args(p)
    p.add_argument("--start", required=True, metavar="Q",
                   help="joint values, comma-separated (or e.g. 30deg)")
    p.add_argument("--goal", required=True, metavar="Q",
                   help="joint values, comma-separated (or e.g. 30deg)")
    p.add_argument("--duration", type=float, metavar="S",
                   help="seconds (default: shortest within the limits)")
    p.add_argument("--profile", default="quintic", choices=["quintic", "trapezoid"])
    p.add_argument("--vmax", type=float, help="joint velocity limit (rad/s or units/s), all joints; without "
                   "--duration default 1 rad/s (prismatic: 0.25 of the robot's size per s)")
    p.add_argument("--amax", type=float, help="joint acceleration limit, all joints; without --duration "
                   "default 2 rad/s^2 (prismatic: 0.5 of the size per s^2)")
    p.add_argument("--dt", type=float, default=0.01,
                   help="sample period of the CSV and PNG (default 0.01 s)")
    p.add_argument("--csv", metavar="FILE", help="write t and one column per joint")
    p.add_argument("--png", metavar="FILE",
                   help="write angle/velocity/acceleration vs time and the tool path")
    p.set_defaults(func=_cmd_trajectory)
