"""Calibrated (perturbed) zoo arms: are all solutions kept?  Written to results/calibrated.md.

For each arm and perturbation size (axes tilted by ~eps rad, axis points moved by ~eps of the size,
``ikcompiler.geometry.perturb.perturb_chain``, fixed seeds) the perturbed robot is compiled and N
sampled joint vectors are solved from their poses (forward kinematics of the perturbed robot).
Reported per row:

* method (closed-form with snapped near-relations, or the search fallback when nothing snapped);
* recovered: the sampled vector is among the exact solutions (revolute values to 1e-6 rad absolute,
  prismatic ones to 1e-6 of the size), joint limits off;
* wrong: returned exact rows whose forward kinematics (recomputed on the perturbed robot) miss the
  target by more than 1e-9 of the size;
* lost: how many fewer exact solutions came back than the snapped robot has at the same pose (its own
  exact plan), summed over poses (``ref`` is the snapped robot's total); a pose counts as losing when
  any is; poses where the snapped robot has a self-motion (a continuum: no count) are counted apart;
* time: median solve_batch_info time per pose, native (C) backend and Python fast path.

Not a test (a few minutes): ``python benchmarks/calibrated.py [--poses N] [--label before]``.
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
from ikcompiler.geometry.relations import Tolerance  # noqa: E402
from ikcompiler.geometry.snap import snap_chain  # noqa: E402
from ikcompiler.verify import joint_distance, sample_configurations  # noqa: E402

ARMS = ("puma560", "ur5", "kr6_r700", "prob", "rhino")
SIZES = (1e-8, 1e-6, 1e-4, 1e-3, 2e-3)


def _exact_rows(module, G, limits=False, native=True):
    module.NATIVE = native
    t0 = time.perf_counter()
    Q, valid, ls, _, cont = module.solve_batch_info(G, limits=limits)
    dt = time.perf_counter() - t0
    return Q, valid & ~ls, cont & valid, dt


def _plain_newton(module):
    """The module as before the continuation: plain Newton steps from the snapped answers."""
    solver = module._SOLVER
    solver.correct = lambda TH, owner, goals: (solver.robot.newton(TH, goals[owner], module._POLISH), owner)


def measure(chain, poses: int, seed: int, special: float = 0.25, plain: bool = False, snap=None) -> dict:
    """One row of the table for the (perturbed) chain; ``snap``: the snap tolerance (default 1e-3)."""
    tol = Tolerance(snap=snap) if snap else None
    module = compile_robot(chain, tol=tol)
    if plain:
        _plain_newton(module)
    snapped, notes = snap_chain(chain, tol)
    kinds = [chain.joints[i].kind for i in chain.independent]
    Q = sample_configurations(chain, poses, seed=seed, special=special)
    G = chain.fk_batch(Q)
    _exact_rows(module, G[:2])  # build the native backend outside the timing
    S, ok, _, t_native = _exact_rows(module, G)
    S_py, ok_py, _, t_py = _exact_rows(module, G, native=False)
    ref_module = compile_robot(snapped) if notes else None
    if ref_module is not None:
        _, ok_ref, cont_ref, _ = _exact_rows(ref_module, G, native=False)
    out = {"method": module.METHOD + (" (snapped)" if notes else ""), "poses": poses}
    for tag, rows, good in (("", S, ok), ("_py", S_py, ok_py)):
        recovered = wrong = lost = ref = losing = continuum = 0
        for i in range(poses):
            sols = rows[i][good[i]]
            if len(sols):
                E = chain.fk_batch(sols)
                err = np.maximum(
                    np.linalg.norm(E[:, :3, 3] - G[i, :3, 3], axis=1),
                    chain.scale * np.abs(E[:, :3, :3] - G[i, :3, :3]).max(axis=(1, 2)),
                )
                wrong += int((err > 1e-9 * chain.scale).sum())
                if joint_distance(sols, Q[i], kinds, chain.scale).min() <= 1e-6:
                    recovered += 1
            if ref_module is not None:
                if cont_ref[i].any():  # a self-motion of the snapped robot: no count to compare with
                    continuum += 1
                    continue
                n_ref = int(ok_ref[i].sum())
                ref += n_ref
                lost += max(0, n_ref - len(sols))
                losing += n_ref > len(sols)
        out.update({f"recovered{tag}": recovered, f"wrong{tag}": wrong, f"lost{tag}": lost,
                    f"ref{tag}": ref, f"losing{tag}": losing, "continuum": continuum})
    out["us_native"] = 1e6 * t_native / poses
    out["us_py"] = 1e6 * t_py / poses
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=500)
    ap.add_argument("--seeds", type=int, default=2, help="perturbation seeds per arm and size")
    ap.add_argument("--arms", default=",".join(ARMS))
    ap.add_argument("--sizes", default=",".join(f"{s:g}" for s in SIZES))
    ap.add_argument("--label", default="current")
    ap.add_argument("--special", type=float, default=0.25,
                    help="probability of a special joint value (0, +-pi/2, pi)")
    ap.add_argument("--plain", action="store_true",
                    help="Python path as before the continuation (plain Newton from the snapped answers)")
    ap.add_argument("--snap", type=float, default=None, help="snap tolerance (default: Tolerance().snap)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "calibrated.md"))
    args = ap.parse_args(argv)
    lines = [
        f"## {args.label}",
        "",
        f"{datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC, Python {platform.python_version()}, "
        f"{platform.machine()}, {os.cpu_count()} cores shared with other jobs (timings on a loaded machine); "
        f"{args.poses} poses per row, limits off, special angles (0, +-pi/2, pi) with probability "
        f"{args.special} per value{'; plain Newton (as before)' if args.plain else ''}"
        f"{f'; snap tolerance {args.snap:g}' if args.snap else ''}.",
        "",
        "| arm | eps | seed | method | recovered (C / Py) | wrong (C / Py) | lost of ref (C / Py) | "
        "poses losing (C / Py) | snapped self-motion poses | us/pose C | us/pose Py |",
        "|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name in args.arms.split(","):
        base = load_robot(name)
        for eps in (float(s) for s in args.sizes.split(",")):
            for seed in range(args.seeds):
                t0 = time.perf_counter()
                r = measure(perturb_chain(base, eps, seed=seed), args.poses, seed=seed + 100,
                            special=args.special, plain=args.plain, snap=args.snap)
                line = (
                    f"| {name} | {eps:g} | {seed} | {r['method']} | {r['recovered']} / {r['recovered_py']} | "
                    f"{r['wrong']} / {r['wrong_py']} | {r['lost']} / {r['lost_py']} of {r['ref']} | "
                    f"{r['losing']} / {r['losing_py']} | {r['continuum']} | {r['us_native']:.0f} | "
                    f"{r['us_py']:.0f} |"
                )
                lines.append(line)
                print(line, f"({time.perf_counter() - t0:.1f} s)", file=sys.stderr, flush=True)
    lines.append("")
    out = Path(args.out)
    title = "# Calibrated (perturbed) arms: recovery and lost solutions\n\n" + (
        "Command: `python benchmarks/calibrated.py --label LABEL` (appends a section).  Columns: see the\n"
        "script's docstring.\n\n"
    )
    old = out.read_text() if out.exists() else title
    out.write_text(old + "\n".join(lines) + "\n")
    print(f"wrote {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
