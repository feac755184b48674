"""``ikc manipulate SPEC.toml``: run the rolling-manipulation algorithm of seed 002 on a spec file."""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np


def add_parser(sub) -> None:
    """Register ``manipulate`` on the ``ikc`` subparsers."""
    p = sub.add_parser(
        "manipulate",
        help="joint trajectories of a multi-finger hand rolling an object along a commanded motion",
        description="Multi-finger manipulation with rolling contacts (seed 002); see docs/hands.md.",
    )
    p.add_argument(
        "spec", help='a manipulation .toml (kind = "manipulation"), e.g. robots/two_finger_disk.toml'
    )
    p.add_argument("--duration", type=float, help="seconds to run (default: the spec's duration)")
    p.add_argument("--dt", type=float, help="step in seconds (default: the spec's dt)")
    p.add_argument("--no-self-motion", action="store_true", help="no joint self-motion (no grasp objective)")
    p.add_argument("--euler", action="store_true", help="the paper's explicit Euler steps instead of RK4")
    p.add_argument("--describe", action="store_true", help="print the system and its classification; no run")
    p.add_argument("--json", action="store_true", help="print the trajectory as JSON on stdout")
    p.add_argument("--csv", metavar="FILE", help="write the trajectory as a CSV table")
    p.add_argument("--png", metavar="FILE", help="plot Fig. 3 (with and without self-motion)")
    p.set_defaults(func=run_command)


def describe(spec) -> str:
    """The system, its initial contacts and the classification of eq. (14)."""
    from ikcompiler.hands.grasp import report

    s = spec.system
    U = s.find_contacts(spec.theta0, spec.object_pose) if spec.contact_guess is None else spec.contact_guess
    _, U, _, _ = s.project(spec.theta0, spec.object_pose, U, fix_joints=True, max_iter=50)
    theta, U, c, res = s.project(spec.theta0, spec.object_pose, U, where="initial grasp: ")
    m = s.matrices(theta, spec.object_pose, c)
    jo = s.analyse(m)
    lines = [
        f"{s.name} ({spec.source}): {'planar' if s.planar else 'spatial'}, units {s.units or '-'}",
        f"object: {s.object_surface.name} of size {s.length_scale:g}",
    ]
    for f, kind, sl, u, psi in zip(s.fingers, s.contact, s.joint_slices(), U, c.psi):
        lines.append(
            f"finger {f.name}: {f.chain.joint_types} ({', '.join(f.chain.independent_names)}), "
            f"tip {f.surface.name} of size {f.surface.size:g}, {kind} contact; initial angles "
            f"{(np.round(np.degrees(theta[sl]), 6) + 0.0).tolist()} deg, "
            f"contact (alpha_f, beta_f, alpha_o, beta_o) = "
            f"{(np.round(u, 6) + 0.0).tolist()}, psi = {psi:.6f}"
        )
    lines.append(f"commanded twist (world): {', '.join(f'{k} = {v}' for k, v in spec.twist_text.items())}")
    lines.append(f"grasp objective for the self-motion: {spec.objective}")
    lines.append(f"initial constraint residual after projection: {res:.1e}")
    lines.append(report(jo, contacts=len(s.fingers), joints=s.n_joints, rows=m.J.shape[0]))
    if jo.kind == "degenerate" and jo.rank_D:
        names = "(vx, vy, wz)" if s.planar else "(vx, vy, vz, wx, wy, wz)"
        Uo, sv, _ = np.linalg.svd(jo.D, full_matrices=False)
        lines.append(f"object twists the hand can produce now, a basis of R(D) in {names}:")
        lines += [f"  {np.round(Uo[:, k], 6).tolist()}" for k in range(jo.rank_D)]
    if spec.assumptions:
        lines.append("assumptions of the spec:")
        lines += [f"  - {a}" for a in spec.assumptions]
    return "\n".join(lines)


def run_command(args: argparse.Namespace) -> int:
    from ikcompiler.hands import output
    from ikcompiler.hands.spec import load_manipulation

    spec = load_manipulation(args.spec)
    if args.describe:
        print(describe(spec))
        return 0
    method = "euler" if args.euler else "rk4"
    kw = dict(duration=args.duration, dt=args.dt, method=method, progress=True)
    print(f"running {spec.system.name} ...", file=sys.stderr)
    start = time.perf_counter()
    run = spec.run(self_motion=not args.no_self_motion, **kw)
    seconds = time.perf_counter() - start
    if args.json:
        print(json.dumps(output.to_json(run)))
    else:
        print(output.summary(run, seconds))
    if args.csv:
        output.write_csv(run, args.csv)
        print(f"wrote {args.csv}", file=sys.stderr)
    if args.png:
        runs = [run]
        if spec.objective != "none":
            print("running the other case for the plot ...", file=sys.stderr)
            runs.append(spec.run(self_motion=args.no_self_motion, **kw))
        runs.sort(key=lambda r: not r.self_motion)
        output.plot(runs, args.png)
        print(f"wrote {args.png}", file=sys.stderr)
    return 0
