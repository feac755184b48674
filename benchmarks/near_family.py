"""Special-angle poses on the two robots of the last strict xfails: written to results/near_family.md.

* rhino perturbed by 1e-4 (``perturb_chain`` seed 3, as tests/test_calibrated.py), N poses with a
  quarter of the joint values at 0, +-pi/2, pi (sample seed 7), limits off: recovered (the sampled
  vector among the exact rows, revolute values to 1e-6 rad, prismatic to 1e-6 of the size), wrong
  (exact rows whose forward kinematics, recomputed on the perturbed robot, miss by more than 1e-9 of
  the size), poses with no exact row, and the time per pose, C backend and Python path;
* shadow_thumb ``--target position+direction``: ``verify`` on N poses (seed 5, as
  tests/test_compiler.py): recovered, at a self-motion, missed, wrong.

Not a test (about a minute a robot): ``python benchmarks/near_family.py [--poses N] [--label L]``.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ikcompiler import load_robot  # noqa: E402
from ikcompiler.compiler import compile_robot  # noqa: E402
from ikcompiler.geometry.perturb import perturb_chain  # noqa: E402
from ikcompiler.verify import joint_distance, sample_configurations, verify  # noqa: E402


def rhino(poses: int) -> str:
    chain = perturb_chain(load_robot("rhino"), 1e-4, seed=3)
    module = compile_robot(chain)
    Q = sample_configurations(chain, poses, seed=7, special=0.25)
    G = chain.fk_batch(Q)
    kinds = [chain.joints[i].kind for i in chain.independent]
    cells = []
    for native in (True, False):
        module.NATIVE = native
        module.solve_batch_info(G[:2], limits=False)  # the C build outside the timing
        t0 = time.perf_counter()
        S, valid, ls, _, _ = module.solve_batch_info(G, limits=False)
        us = 1e6 * (time.perf_counter() - t0) / poses
        recovered = wrong = empty = 0
        for i in range(poses):
            sols = S[i][valid[i] & ~ls[i]]
            if not len(sols):
                empty += 1
                continue
            E = chain.fk_batch(sols)
            err = np.maximum(np.linalg.norm(E[:, :3, 3] - G[i, :3, 3], axis=1),
                             chain.scale * np.abs(E[:, :3, :3] - G[i, :3, :3]).max(axis=(1, 2)))
            wrong += int((err > 1e-9 * chain.scale).sum())
            recovered += bool(joint_distance(sols, Q[i], kinds, chain.scale).min() <= 1e-6)
        cells.append((recovered, wrong, empty, us))
    (rc, wc, ec, uc), (rp, wp, ep, up) = cells
    return (f"| rhino 1e-4 (seed 3), special 0.25 (seed 7) | {poses} | {rc} / {rp} | {poses - rc} / {poses - rp} "
            f"| - | {wc} / {wp} | {ec} / {ep} | {uc:.0f} / {up:.0f} |")


def thumb(poses: int) -> str:
    chain = load_robot("shadow_thumb")
    module = compile_robot(chain, target="position+direction")
    t0 = time.perf_counter()
    r = verify(chain, module, samples=poses, seed=5, scalar_checks=0)
    us = 1e6 * (time.perf_counter() - t0) / poses
    return (f"| shadow_thumb position+direction (verify, seed 5) | {poses} | {r.recovered} | {r.missed} | "
            f"{r.self_motion} | {r.wrong} | - | {us:.0f} (verify) |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=2000)
    ap.add_argument("--label", default="current")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "near_family.md"))
    args = ap.parse_args(argv)
    lines = [
        f"## {args.label}",
        "",
        f"{datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC, Python {platform.python_version()}, "
        f"{platform.machine()}, {os.cpu_count()} cores shared with other jobs (timings on a loaded machine).",
        "",
        "| robot, poses | N | recovered (C / Py) | missed (C / Py) | at a self-motion | wrong | no exact row "
        "(C / Py) | us/pose (C / Py) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
        rhino(args.poses),
        thumb(args.poses),
        "",
    ]
    out = Path(args.out)
    title = ("# Near-self-motions of a snapped robot, and the thumb's position+direction target\n\n"
             "Command: `python benchmarks/near_family.py --label LABEL` (appends a section).  Columns: see the\n"
             "script's docstring.\n\n")
    old = out.read_text() if out.exists() else title
    out.write_text(old + "\n".join(lines) + "\n")
    print("\n".join(lines), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
