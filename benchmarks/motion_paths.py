"""Straight tool lines on every zoo robot, checked from outside: ``python benchmarks/motion_paths.py``.

For each robot, ``--lines`` random lines (seeded): a random configuration inside the limits, a goal pose
``--move`` of the robot's size away in position and about 0.4 rad in orientation (arms with fewer joints
than a pose has: the pose of a random joint move of ~0.2 rad; the line between is mostly not in their
workspace), followed with
``ikcompiler.motion.follow``.  Checked on every path, from forward kinematics and not from the path's
own report: every row reproduces its waypoint (position to 1e-9 of the size, rotation to 1e-9); every
step that moves a joint by more than its jump limit carries an event; the waypoints lie on the line.
Counts of complete paths and of event kinds, and the time per path, go to
``benchmarks/results/motion_paths.md``.  About a minute on two cores.
"""

from __future__ import annotations

import argparse
import collections
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != ROOT / "benchmarks"]
sys.path.insert(0, str(ROOT))

from ikcompiler.compiler import compile_robot  # noqa: E402
from ikcompiler.inputs.zoo import zoo_names  # noqa: E402
from ikcompiler.motion import follow, straight_line  # noqa: E402
from ikcompiler.motion.path import _jump_limits, module_target, target_error  # noqa: E402
from ikcompiler.motion.poses import interpolate, rotation_exp  # noqa: E402

TARGETS = {"shadow_index": ("position", ()), "shadow_thumb": ("position+direction", ()),
           "panda": ("pose", ("panda_joint7",))}
SKIP = {"jaco"}  # the general 6R: a 1-D search per pose, ~5k poses/s: too slow for a sweep


def _random_line(m, rng, move):
    rev = np.array([k == "R" for k in m.JOINT_TYPES])
    bound = np.where(rev, math.pi, m.SCALE)  # revolute within one turn, prismatic within the size
    lo, hi = np.maximum(m.LOWER, -bound), np.minimum(m.UPPER, bound)
    for _ in range(100):
        q0 = lo + (hi - lo) * rng.uniform(0.1, 0.9, len(lo))
        T0 = m.fk(q0)
        if len(q0) < 6 and m.TARGET == "pose":  # a reduced arm: a goal it reaches (the line may not be)
            return q0, T0, m.fk(np.clip(q0 + rng.normal(size=len(q0)) * 0.2, lo, hi))
        T1 = T0.copy()
        d = rng.normal(size=3)
        T1[:3, 3] += move * m.SCALE * d / np.linalg.norm(d)
        if m.TARGET != "position":
            T1[:3, :3] = T0[:3, :3] @ rotation_exp(rng.normal(size=3) * 0.25)
        if len(m.solve(module_target(m, T1), *[q0[m.JOINT_NAMES.index(f)] for f in m.FREE_JOINTS])):
            return q0, T0, T1
    raise RuntimeError(f"no reachable goal found for {m.JOINT_NAMES}")


def check(m, path, T0, T1, n_poses) -> list[str]:
    """What is wrong with a followed path, from forward kinematics."""
    bad = []
    for k, q in enumerate(path.q):
        if target_error(m, m.fk(q), path.targets[k]) > 1e-9 * m.SCALE:
            bad.append(f"row {k} misses its waypoint")
    line = interpolate(T0, T1, path.s / (n_poses - 1))
    for k in range(len(path.q)):
        if target_error(m, line[k], path.targets[k]) > 1e-9 * m.SCALE:
            bad.append(f"waypoint {k} is off the line")
    jump = _jump_limits(m, None)
    flagged = {e.index for e in path.events} | {e.index + 1 for e in path.events}
    for k in range(1, len(path.q)):
        if np.any(np.abs(path.q[k] - path.q[k - 1]) > jump) and k not in flagged and k - 1 not in flagged:
            bad.append(f"unreported jump at row {k}")
    return bad


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=5)
    ap.add_argument("--move", type=float, default=0.15, help="line length, fraction of the size (0.15)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    out = ["# Straight lines on the zoo robots", "",
           f"`python benchmarks/motion_paths.py --lines {args.lines} --move {args.move} --seed {args.seed}`: "
           "random lines, checked from forward kinematics (loaded 2-core machine).", "",
           "| robot | target | lines | complete | events | rows per path | s per path | problems |",
           "|---|---|---|---|---|---|---|---|"]
    failures = 0
    for name in zoo_names():
        if name in SKIP:
            continue
        target, free = TARGETS.get(name, ("pose", ()))
        m = compile_robot(name, target=target, free=free)
        kinds, complete, rows, seconds, problems = collections.Counter(), 0, 0, 0.0, []
        for _ in range(args.lines):
            q0, T0, T1 = _random_line(m, rng, args.move)
            poses = straight_line(T0, T1, max_step=m.SCALE / 100, max_angle=0.02)
            start = time.perf_counter()
            path = follow(m, poses, q0)
            seconds += time.perf_counter() - start
            complete += path.complete
            rows += len(path.q)
            kinds.update(e.kind for e in path.events)
            problems += check(m, path, T0, T1, len(poses))
        failures += len(problems)
        ev = ", ".join(f"{k} {v}" for k, v in sorted(kinds.items())) or "-"
        out.append(f"| {name} | {target} | {args.lines} | {complete} | {ev} | {rows / args.lines:.0f} | "
                   f"{seconds / args.lines:.2f} | {len(problems)} {'; '.join(problems[:2])} |")
        print(out[-1], file=sys.stderr, flush=True)
    (ROOT / "benchmarks" / "results" / "motion_paths.md").write_text("\n".join(out) + "\n")
    print("\n".join(out))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
