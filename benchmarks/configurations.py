"""The configuration zoo: every joint string of 1..6 joints over {R, T}, modular and general geometry.

    nice python benchmarks/configurations.py [--instances 2] [--poses 50] [--timeout 20] [--max-len 6]

Each chain (:func:`ikcompiler.configs.modular_chain`, seeds 0..instances-1, geometry "modular" and
"general") is compiled with :func:`ikcompiler.configs.compile_chain` (a pose target) and verified with
:func:`ikcompiler.verify.verify` (a fifth of the poses at special angles).  A chain whose Jacobian has
rank below its joint count at random configurations (four or more prismatic joints, parallel prismatic
axes, ...) has a continuum of solutions at every pose: it is counted *redundant* and its recovery is not
scored (its rows are still checked for wrong solutions).  Writes ``benchmarks/results/configurations.md``
(after every joint string, so a cut-off run keeps its rows); progress on stderr.
"""

from __future__ import annotations

import argparse
import collections
import math
import platform
import signal
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ikcompiler import configs  # noqa: E402
from ikcompiler import verify as verify_mod  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "configurations.md"
MEMORY_MARK = "<!-- search_memory.py: begin -->"


class Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise Timeout()


@dataclass
class Result:
    kinds: str
    geometry: str
    seed: int
    method: str = ""
    compile_s: float = math.nan
    redundant: bool = False
    poses: int = 0
    recovered: int = 0
    self_motion: int = 0
    wrong: int = 0
    contract: int = 0  # imprecise, outside-limit, non-canonical and duplicate rows (verify's counts)
    status: str = "ok"


def run_one(kinds: str, geometry: str, seed: int, poses: int, timeout: float) -> Result:
    res = Result(kinds, geometry, seed)
    signal.setitimer(signal.ITIMER_PROF, timeout)  # CPU seconds: fair on a loaded machine
    try:
        chain = configs.modular_chain(kinds, seed=seed, geometry=geometry)
        res.redundant = configs.generic_rank(chain) < chain.dof
        compiled = configs.compile_chain(chain)
        res.method, res.compile_s = compiled.module.METHOD, compiled.seconds
        verify_mod.VERIFY_CHUNK = 500 if res.method == "closed-form" else 10
        special = max(1, poses // 5)
        for count, seed_v, sp in ((special, 1, 1.0), (poses - special, 2, 0.0)):
            rep = verify_mod.verify(
                chain, compiled.module, samples=count, seed=seed_v, special=sp, scalar_checks=2
            )
            res.poses += rep.poses
            res.recovered += rep.recovered
            res.self_motion += rep.self_motion
            res.wrong += rep.wrong + rep.batch_mismatch
            res.contract += rep.imprecise + rep.outside_limits + rep.non_canonical + rep.duplicates
    except Timeout:
        res.status = f"timeout after {res.poses} poses"
    except Exception as exc:  # a refusal or crash is a result
        res.status = f"{type(exc).__name__}: {str(exc).splitlines()[0][:120]}"
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        verify_mod.VERIFY_CHUNK = 500
    return res


def _commit() -> str:
    cmd = ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"]
    return subprocess.run(cmd, capture_output=True, text=True).stdout.strip() or "?"


def _cell(rs: list[Result]) -> dict:
    ok = [r for r in rs if r.method]
    cls = collections.Counter(configs.method_class(r.method) for r in ok)
    scored = [r for r in rs if not r.redundant and r.method]
    base = sum(r.poses - r.self_motion for r in scored)
    rec = sum(r.recovered for r in scored)
    comp = [r.compile_s for r in ok]
    return {
        "n": len(rs),
        "cf": cls["closed form"],
        "1d": cls["1-D search"],
        "gen": cls["general solver"],
        "failed": sum(1 for r in rs if r.status != "ok"),
        "redundant": sum(1 for r in rs if r.redundant),
        "wrong": sum(r.wrong for r in rs),
        "rec": f"{rec}/{base} ({100.0 * rec / base:.2f}%)" if base else "-",
        "full": sum(1 for r in scored if r.status == "ok" and r.recovered == r.poses - r.self_motion),
        "scored": len(scored),
        "compile": f"{statistics.median(comp):.2f}" if comp else "-",
    }


HEAD = (
    "| {key} | chains | closed form | 1-D search | general solver | failed/timeout | redundant | "
    "wrong rows | every pose recovered | recovered (non-redundant, self-motions excluded) | "
    "median compile s |"
)


def _row(key: str, c: dict) -> str:
    return (
        f"| {key} | {c['n']} | {c['cf']} | {c['1d']} | {c['gen']} | {c['failed']} | {c['redundant']} | "
        f"{c['wrong']} | {c['full']}/{c['scored']} | {c['rec']} | {c['compile']} |"
    )


def write(results: list[Result], args, started: float, done: bool) -> None:
    lines = [
        "# Configuration zoo: every joint string of 1..6 joints",
        "",
        "Command: `nice python benchmarks/configurations.py "
        f"--instances {args.instances} --poses {args.poses} --timeout {args.timeout:g} "
        f"--max-len {args.max_len}{f' --budget {args.budget:g}' if args.budget else ''}`; "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime(started))}, commit {_commit()}, "
        f"Python {platform.python_version()}, "
        "on a 2-core machine shared with other jobs (times are loaded-machine times).",
        ""
        if done
        else "**Run still in progress or cut off: the rows below are the joint strings done so far.**",
        "",
        "Modular: axes along or perpendicular to straight links of random length (a quarter of them zero), "
        "links turning by right angles; general: random axes and points.  Pose target, verified on "
        f"{args.poses} poses per chain (a fifth at special angles).  *redundant*: generic Jacobian rank "
        "below the joint count (a continuum of solutions everywhere; recovery not scored).  *wrong rows*: "
        "rows whose FK misses the target by more than 1e-9 of the size, plus single-pose/batch "
        "disagreements.",
        "",
        "## By number of joints and geometry",
        "",
        HEAD.format(key="joints / geometry"),
        "|" + "---|" * 11,
    ]
    by = collections.defaultdict(list)
    for r in results:
        by[(len(r.kinds), r.geometry)].append(r)
    for key in sorted(by):
        lines.append(_row(f"{key[0]} / {key[1]}", _cell(by[key])))
    lines.append(_row("**all**", _cell(results)))
    lines += ["", "## By joint string", "", HEAD.format(key="joint string / geometry"), "|" + "---|" * 11]
    by = collections.defaultdict(list)
    for r in results:
        by[(len(r.kinds), r.kinds, r.geometry)].append(r)
    for key in sorted(by):
        lines.append(_row(f"{key[1]} / {key[2]}", _cell(by[key])))
    bad = [r for r in results if r.wrong or r.contract or r.status != "ok"]
    lines += ["", "## Chains with wrong rows, contract violations or a failure", ""]
    lines += [
        f"- `modular_chain({r.kinds!r}, seed={r.seed}, geometry={r.geometry!r})`: {r.method or '-'}, "
        f"wrong {r.wrong}, imprecise/outside limits/non-canonical/duplicate rows {r.contract}, {r.status}"
        for r in bad
    ] or ["- none"]
    left = getattr(args, "left_out", [])
    if left:
        lines += ["", f"## Not run: cut by `--budget` ({len(left)} joint strings)", "", ", ".join(left)]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    # the memory section benchmarks/search_memory.py writes at the end is kept (it is measured apart)
    old = args.out.read_text() if args.out.exists() else ""
    if MEMORY_MARK in old:
        lines += ["", old[old.index(MEMORY_MARK):].rstrip()]
    args.out.write_text("\n".join(lines) + "\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--instances", type=int, default=2, help="seeds per joint string and geometry")
    ap.add_argument("--poses", type=int, default=50, help="poses verified per chain")
    ap.add_argument("--timeout", type=float, default=20.0, help="CPU seconds per chain")
    ap.add_argument("--max-len", type=int, default=6)
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--budget", type=float, default=0.0, help="wall minutes for the run (0: none)")
    args = ap.parse_args(argv)
    args.left_out = []
    signal.signal(signal.SIGPROF, _alarm)
    started = time.time()
    strings = configs.joint_strings(args.max_len)
    results: list[Result] = []
    for n, kinds in enumerate(strings, 1):
        if args.budget and time.time() - started > 60.0 * args.budget:
            args.left_out = strings[n - 1 :]
            print(f"budget of {args.budget:g} min: {len(args.left_out)} strings not run", file=sys.stderr)
            break
        for geometry in ("modular", "general"):
            for seed in range(args.instances):
                t0 = time.perf_counter()
                r = run_one(kinds, geometry, seed, args.poses, args.timeout)
                results.append(r)
                print(
                    f"[{n}/{len(strings)}] {kinds} {geometry} seed {seed}: {r.method or '-'} "
                    f"{'redundant ' if r.redundant else ''}rec {r.recovered}/{r.poses - r.self_motion} "
                    f"wrong {r.wrong} {r.status} ({time.perf_counter() - t0:.1f} s)",
                    file=sys.stderr,
                    flush=True,
                )
        write(results, args, started, done=False)
    write(results, args, started, done=True)
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
