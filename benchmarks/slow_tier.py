"""The slow tier: 20,000 poses per zoo robot through ``verify``, held to the whole contract.

    python benchmarks/slow_tier.py                          # every zoo robot (about an hour, loaded)
    python benchmarks/slow_tier.py --robots ur5 puma560 rhino --poses 20000

Each zoo robot is compiled as ``ikc compile`` does (a 7-joint arm: its last joint free) and checked by
:func:`ikcompiler.verify.verify` on ``--poses`` joint vectors drawn inside the limits, a quarter of
the revolute values at 0, +-pi/2 or pi (where wrists line up: the poses that hide misses), in chunks so
that progress shows.  Every count of the report is recomputed by ``verify`` from forward kinematics
and the limits: wrong, imprecise (above the module's 1e-12), outside the limits, non-canonical,
duplicate rows, single-pose/batch disagreement, missed poses (self-motions apart).  Writes
``benchmarks/results/slow_tier.md`` (date, commit, one row per robot) and exits 1 when any robot's
report is not ``ok`` with no missed pose allowed.  The CI tests run 200-2,000 poses per robot; this is
the tier that takes the hours (docs/design.md, section 9).
"""

from __future__ import annotations

import argparse
import platform
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ikcompiler import load_robot  # noqa: E402
from ikcompiler.compiler import compile_robot  # noqa: E402
from ikcompiler.inputs.zoo import zoo_names  # noqa: E402
from ikcompiler.verify import verify  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "slow_tier.md"
SEED = 20000  # fixed: a rerun draws the same poses


def _commit() -> str:
    cmd = ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"]
    out = subprocess.run(cmd, capture_output=True, text=True)
    return out.stdout.strip() or "?"


def _flags(args) -> str:
    flags = f" --robots {' '.join(args.robots)}" if args.robots else ""
    return flags + (f" --poses {args.poses}" if args.poses != 20000 else "")


def run(name: str, poses: int) -> tuple[str, object, float]:
    chain = load_robot(name)
    free = (chain.independent_names[-1],) if chain.dof > 6 else ()
    module = compile_robot(chain, free=free)
    t0 = time.perf_counter()

    def progress(done, total):
        print(
            f"  {name}: {done}/{total} poses ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True
        )

    rep = verify(chain, module, samples=poses, seed=SEED, scalar_checks=20, special=0.25, progress=progress)
    return module.METHOD, rep, time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="*", default=None, help="zoo robot names (default: every one)")
    ap.add_argument("--poses", type=int, default=20000, help="poses per robot (default 20000)")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    names = args.robots or zoo_names()
    started = time.time()
    lines = [
        "# Slow tier: the whole contract on 20,000 poses per zoo robot",
        "",
        f"Command: `python benchmarks/slow_tier.py{_flags(args)}`; "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime(started))}, commit {_commit()}, Python "
        f"{platform.python_version()}, a 2-core machine shared with other jobs (seconds are loaded-machine "
        "seconds).  Poses drawn inside the limits with a quarter of the revolute values at 0, +-pi/2, pi "
        f"(seed {SEED}); every count recomputed by `verify` from forward kinematics and the limits; "
        "*ok*: nothing wrong, imprecise, outside the limits, non-canonical or duplicate, batch and single "
        "pose agree, no missed pose.",
        "",
        "| robot | method | poses | recovered | self-motion (no exact rep.) | missed | wrong | imprecise | "
        "outside limits | non-canonical | duplicates | batch mismatch | max error | seconds | ok |",
        "|" + "---|" * 15,
    ]
    failed = []
    for name in names:
        method, r, secs = run(name, args.poses)
        if not r.ok:
            failed.append(name)
        lines.append(
            f"| {name} | {method} | {r.poses} | {r.recovered} | {r.self_motion} ({r.self_motion_unsolved}) | "
            f"{r.missed} | {r.wrong} | {r.imprecise} | {r.outside_limits} | {r.non_canonical} | "
            f"{r.duplicates} | {r.batch_mismatch} | {r.max_error:.1e} | {secs:.0f} | "
            f"{'yes' if r.ok else 'NO'} |"
        )
        print(f"{name}: {'ok' if r.ok else 'FAILED'}\n{r.text()}", file=sys.stderr, flush=True)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")
    verdict = f"{len(names) - len(failed)} of {len(names)} robots ok"
    lines += ["", verdict + (f"; not ok: {', '.join(failed)}" if failed else ""), ""]
    args.out.write_text("\n".join(lines))
    print(f"wrote {args.out}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
