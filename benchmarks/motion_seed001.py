"""Seed 001's example on the P-Rob (zoo ``prob``): the paper's joint trajectory and a Cartesian line.

    python benchmarks/motion_seed001.py

1. The paper's move [0 0 0 0 0 0] -> [30 60 90 45 -90] deg in 2 s (its Fig. 6-9), as a quintic (what the
   Robotics Toolbox's jtraj plots) and as a trapezoid: docs/images/prob_trajectory_quintic.png,
   docs/images/prob_trajectory_trapezoid.png.
2. A straight tool line (10 cm and 0.38 rad of turn) from a well-conditioned configuration, followed on
   one IK branch and timed within 1 rad/s and 2 rad/s^2: docs/images/prob_line.png,
   docs/images/prob_line_trajectory.png.
Numbers go to benchmarks/results/motion_seed001.md.  Takes a few seconds.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# run as a script this folder is first on sys.path, and its subproblems.py would shadow the package
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != ROOT / "benchmarks"]
sys.path.insert(0, str(ROOT))

from ikcompiler.compiler import compile_robot  # noqa: E402
from ikcompiler.motion import follow, quintic, straight_line, time_path, trapezoid  # noqa: E402
from ikcompiler.motion.plot import plot_path, plot_trajectory  # noqa: E402
from ikcompiler.motion.poses import rotation_exp  # noqa: E402

IMAGES, RESULTS = ROOT / "docs" / "images", ROOT / "benchmarks" / "results"


def main() -> int:
    IMAGES.mkdir(parents=True, exist_ok=True)
    print("compiling prob ...", file=sys.stderr)
    m = compile_robot("prob")
    lines = ["# Seed 001 on the P-Rob: trajectory and Cartesian line", "",
             "`python benchmarks/motion_seed001.py` (numbers below are from that run).", ""]

    q0, q1 = np.zeros(6), np.radians([30, 60, 90, 45, -90, 0])
    info = m.solve_info(m.fk(q1), q_seed=q1)
    lines += ["## 1. The paper's move, 2 s", "",
              f"Goal [30 60 90 45 -90 0] deg: {len(info.q)} solutions inside the limits "
              f"({len(info.q) + len(info.excluded)} without); sigma_min of the paper's configuration "
              f"{info.sigma_min[0]:.2g}: j3 = 90 deg is the P-Rob's stretched elbow (singular, "
              "where the paper's 8 solutions pair up into 4).", "",
              "| profile | peak velocity per joint [rad/s] | peak acceleration per joint [rad/s^2] |",
              "|---|---|---|"]
    for name, make in (("quintic", quintic), ("trapezoid", trapezoid)):
        tr = make(q0, q1, 2.0)
        v, a = tr.peaks()
        lines.append(f"| {name} | {' '.join(f'{x:.3f}' for x in v)} | {' '.join(f'{x:.3f}' for x in a)} |")
        plot_trajectory(tr, m.fk, m.JOINT_NAMES, IMAGES / f"prob_trajectory_{name}.png",
                        title=f"P-Rob, [0 0 0 0 0 0] -> [30 60 90 45 -90 0] deg, {name}, 2 s")
    lines += ["", "![quintic](../../docs/images/prob_trajectory_quintic.png)", ""]

    qa = np.radians([10, 30, 40, 20, 50, 10])
    Ta = m.fk(qa)
    Tb = Ta.copy()
    Tb[:3, 3] += [-0.08, 0.1, -0.05]
    Tb[:3, :3] = Ta[:3, :3] @ rotation_exp([0.2, 0.1, -0.3])
    lines += ["## 2. A straight tool line on one branch", "",
              "| step [m] | waypoints | rows | complete | largest joint step [rad] | pose error [m] | "
              "follow time [s] |", "|---|---|---|---|---|---|---|"]
    for step in (0.02, 0.01, 0.005, 0.0025):
        poses = straight_line(Ta, Tb, max_step=step, max_angle=2 * step)
        start = time.perf_counter()
        path = follow(m, poses, qa)
        took = time.perf_counter() - start
        G = np.array([m.fk(q) for q in path.q])
        err = max(np.linalg.norm(G[:, :3, 3] - path.targets[:, :3, 3], axis=1).max(),
                  np.linalg.norm(G[:, :3, :3] - path.targets[:, :3, :3], axis=(1, 2)).max())
        lines.append(f"| {step} | {len(poses)} | {len(path.q)} | {path.complete} | "
                     f"{np.abs(path.steps()).max():.4f} | {err:.1e} | {took:.3f} |")
    plot_path(path, IMAGES / "prob_line.png", title="P-Rob: straight tool line, one IK branch")
    tr = time_path(path, vmax=1.0, amax=2.0)
    v, a = tr.peaks()
    plot_trajectory(tr, m.fk, m.JOINT_NAMES, IMAGES / "prob_line_trajectory.png",
                    title=f"P-Rob: the line timed within 1 rad/s, 2 rad/s^2 ({tr.duration:.2f} s)")
    lines += ["", f"Timed within 1 rad/s and 2 rad/s^2: {tr.duration:.3f} s, peak velocity {v.max():.4f}, "
              f"peak acceleration {a.max():.4f}.  (Follow times on a loaded 2-core machine.)", "",
              "![line](../../docs/images/prob_line.png)", ""]
    (RESULTS / "motion_seed001.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
