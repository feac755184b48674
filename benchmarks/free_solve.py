"""Single-pose ``solve`` of chains with a free joint: its time against the C call under it, and, with
``--against DIR``, the same poses on another checkout: the time before/after and the rows compared.

One command::

    python benchmarks/free_solve.py [--against DIR] [--atol TOL] [--cases NAME ...] [--poses N]

Why: a free joint's value comes back as given (dispatch ``_free_as_given``); done on the batch arrays
for one pose, that bookkeeping cost five times panda's C solve (docs/design.md section 14 item 6).
``special_poses.py`` times whole solves, where a regression of the Python layer hides in the load of a
shared machine; here each solve is timed beside the C call it wraps (``NativeChain.exact``), in CPU
time, fastest of 3 a pose, so the ratio of the two stays readable under load.

Cases ``ROBOT[_eps]_jK``: a zoo robot with its K-th joint free, ``_eps`` perturbed by 1e-6 of its size
(``configs.perturbed``, seed 7): panda with its last joint free (as special_poses.py compiles it), the
same perturbed, and two 6R arms with one joint free (kr6_r700's last, ur5's first).  (panda with its
third or first joint free is a general 6R on the Python path: 1-7 ms a solve, the same rows.)  Cases
of :data:`ARMS`: 7-joint arms of the robot-description packages (the robots extra) compiled by
``configs.compile_chain``, which gives them a free end joint and the general 6R elimination (baxter's
left arm, rtb-data's iiwa14, tiago perturbed by 1e-3, xarm7); their *C call* is the elimination of the
six solved joints on the moved target (``NativeFreeEnds.native.exact``).  Poses: ``--poses`` random
joint vectors inside the limits (seed 7, as special_poses.py), as many at special angles ({0, +-pi/2,
pi}), and a tenth as many with the free value outside its limits.  Compared: ``solve`` with and
without limits, and ``solve_info``'s rows, residuals and flags, bit for bit (``np.array_equal``), or
with ``--atol`` as solution sets (a change of the moved target by an ulp may reorder rows of equal
residual or turn pi into -pi).  A pose that differs is *sound on both sides* when each side's rows
without limits are all exact by our FK and, where the free value is the sampled one, hold the sampled
vector by ``verify``'s rule (within its SAME_ANGLE, or 100 times that at a singular sampled vector: a
double root); exits 1 when a differing pose is not.  Writes ``benchmarks/results/free_solve.md``;
progress to stderr.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
CASES = ("panda_j7", "kr6_r700_j6", "ur5_j1", "baxter_left", "iiwa14_rtb", "tiago_1e-3")
# also panda_eps_j7: ~20 min a checkout (its solve_info)
# 7-joint arms of the robot-description packages (the robots extra) that configs.compile_chain gives a
# free end joint and the general 6R elimination: (package, file, tip, perturbation, seed)
ARMS = {
    "baxter_left": ("example-robot-data", "baxter.urdf", "left_gripper_base_link", 0.0, 0),
    "iiwa14_rtb": ("rtb-data", "lbr_iiwa_14_r820.urdf", "tool0", 0.0, 0),
    "tiago_1e-3": ("example-robot-data", "tiago.urdf", "hand_palm_link", 1e-3, 9),
    "xarm7": ("example-robot-data", "xarm7.urdf", "link_eef", 0.0, 0),
}
REPEATS = 3

# runs in a subprocess per checkout: the case's poses solved and timed, saved for the parent
SOLVE = r"""
import sys, time
import numpy as np
root, case, poses, out, reps = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], int(sys.argv[5])
sys.path.insert(0, root)
from ikcompiler import configs, load_robot
from ikcompiler.compiler import compile_robot

ARMS = __ARMS__  # free_solve.ARMS, printed in by run()
if case in ARMS:  # a robot-description arm, its free joint as configs.compile_chain picks it
    from ikcompiler import robotdb
    package, file, tip, eps, seed = ARMS[case]
    entry = next(e for e in robotdb.discover(packages=robotdb.EXTRA).chains
                 if e.package == package and e.rel.rsplit("/", 1)[-1] == file and e.tip == tip)
    chain = entry.load()
    if eps:
        chain = configs.perturbed(chain, eps, seed=seed)
    compiled = configs.compile_chain(chain)
    module, free = compiled.module, compiled.free
else:
    name, joint = case.rsplit("_j", 1)  # robot[_eps]_jK: the zoo robot, its K-th joint free
    chain = load_robot(name.removesuffix("_eps"))
    if name.endswith("_eps"):
        chain = configs.perturbed(chain, 1e-6, seed=7)
    free = (chain.independent_names[int(joint) - 1],)
    module = compile_robot(chain, free=free)
native = module._native_chain()
ends = module._SOLVER.free_ends_native()  # free end joints: the C elimination on moved targets
col = module.JOINT_NAMES.index(free[0])
rng = np.random.default_rng(7)
lo, hi = np.maximum(module.LOWER, -np.pi), np.minimum(module.UPPER, np.pi)
Q = np.concatenate([rng.uniform(lo, hi, (poses, len(lo))),
                    rng.choice((0.0, np.pi / 2, -np.pi / 2, np.pi), (poses, len(lo)))])
T = np.array([module.fk(q) for q in Q])
F = Q[:, col].copy()
outside = rng.choice(len(F), max(1, poses // 10), replace=False)
F[outside] = np.where(outside % 2, module.UPPER[col] + 0.25, module.LOWER[col] - 0.25)

def many(fn, *args):  # process_time ticks are coarse: a block of calls, per call
    t0 = time.process_time()
    for _ in range(reps):
        fn(*args)
    return (time.process_time() - t0) / reps

from ikcompiler import verify as V
from subproblems.plan_runtime import target_error

kinds = [chain.joints[j].kind for j in chain.independent]
tol = module.TOLERANCE * chain.scale

def sound(rows, i):
    # every row exact (our FK) and, where the free value is the sampled one, the sampled vector among
    # the rows by verify's rule (within SAME_ANGLE, or 100 times that at a singular sampled vector)
    if not len(rows):
        return F[i] != Q[i, col]
    G = np.array([module.fk(q) for q in rows])
    if not (target_error(G, T[i][None], "pose", chain.scale) <= tol).all():
        return False
    if F[i] != Q[i, col]:
        return True
    near = V._recovery_distance(rows, Q[i], kinds, chain.scale).min()
    return bool(near <= 1.0 or (near <= V.SINGULAR_FACTOR and V._singular(chain, Q[i], [col])))

rows = {}
t_solve, t_c, sound_rows = [], [], []
for i in range(len(T)):
    f = float(F[i])
    rows[f"solve_{i}"] = module.solve(T[i], f)
    rows[f"unlimited_{i}"] = module.solve(T[i], f, limits=False)
    sound_rows.append(sound(rows[f"unlimited_{i}"], i))
    info = module.solve_info(T[i], f)
    for k in ("q", "residual", "ls", "continuum"):
        rows[f"info_{k}_{i}"] = getattr(info, k)
    t_solve.append(min(many(module.solve, T[i], f) for _ in range(3)))
    if native is not None:
        t_c.append(min(many(native.exact, T[i], (f,), True) for _ in range(3)))
    elif ends is not None:
        init = np.full((1, len(module.JOINT_NAMES)), np.nan)
        init[0, col] = f
        moved = ends.split.targets(T[i][None], init)[0]
        t_c.append(min(many(ends.native.exact, moved, (), True) for _ in range(3)))
np.savez(out, T=T, F=F, t_solve=np.array(t_solve), t_c=np.array(t_c), method=module.METHOD,
         sound=np.array(sound_rows),
         path="native" if native is not None else "free-ends C" if ends is not None else "python",
         free=" ".join(free), revolute=np.array([k == "R" for k in module.JOINT_TYPES]), **rows)
"""


def log(msg: str) -> None:
    print(f"[free_solve {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def run(root: Path, case: str, poses: int, out: Path, reps: int = 20) -> dict:
    env = {**os.environ, "PYTHONPATH": str(root)}
    source = SOLVE.replace("__ARMS__", repr(ARMS))
    subprocess.run(["nice", sys.executable, "-c", source, str(root), case, str(poses), str(out), str(reps)],
                   env=env,
                   check=True, capture_output=True, text=True)
    with np.load(out) as data:
        return {k: data[k] for k in data.files}


def differing(now: dict, before: dict, atol: float = 0.0) -> tuple[set, float]:
    """Poses whose solve, unlimited solve or solve_info differ (shape and dtype included): without
    ``atol`` in any bit; with it as solution sets: each row of one within atol (radians, revolute values
    modulo 2 pi; lengths) of a row of the other with the same ls and continuum flags and residual to
    atol (rows of equal residual may come in another order, a value at pi as -pi).  Also returns the
    largest distance of a row to its match (0.0 bit for bit).  The poses as a set."""
    bad, worst = set(), 0.0
    for i in range(len(now["F"])):
        if atol:
            gap = max(_set_gap(now, before, i, key) for key in ("solve", "unlimited", "info_q"))
            worst = max(worst, gap)
            same = gap <= atol
        else:
            keys = [k for k in now if k[:5] in ("solve", "unlim", "info_") and k.endswith(f"_{i}")]
            same = all(k in before and now[k].dtype == before[k].dtype and np.array_equal(now[k], before[k])
                       for k in keys)
        if not same:
            bad.add(i)
    return bad, worst


def _set_gap(now: dict, before: dict, i: int, key: str) -> float:
    """How far the rows of ``key`` of pose i are from one another's as sets (inf: other counts or
    flags); solve_info's rows carry their ls and continuum flags and residual along."""
    a, b = now[f"{key}_{i}"], before[f"{key}_{i}"]
    if a.shape != b.shape:
        return np.inf
    if not len(a):
        return 0.0
    d = np.abs(a[:, None, :] - b[None, :, :])
    rev = now["revolute"]
    d[..., rev] = np.abs(np.remainder(d[..., rev] + np.pi, 2 * np.pi) - np.pi)
    if key == "info_q":
        for k in ("ls", "continuum"):
            x, y = now[f"info_{k}_{i}"], before[f"info_{k}_{i}"]
            d[x[:, None] != y[None, :]] = np.inf
        x, y = now[f"info_residual_{i}"], before[f"info_residual_{i}"]
        d = np.maximum(d, np.abs(x[:, None] - y[None, :])[..., None])
    D = d.max(axis=2)
    return float(max(D.min(axis=1).max(), D.min(axis=0).max()))


def medians(t, poses: int) -> np.ndarray:
    """Medians (us) of times t over all the poses, the random ones (the first ``poses``) and the rest."""
    if not len(t):
        return np.full(3, np.nan)
    return 1e6 * np.array([np.median(t), np.median(t[:poses]), np.median(t[poses:])])


def _cell(x, fmt: str) -> str:
    return " / ".join(fmt.format(v) for v in x)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", help="another checkout: its times and rows beside this one's")
    ap.add_argument("--cases", nargs="*", default=list(CASES))
    ap.add_argument("--poses", type=int, default=150, help="random poses (as many special ones)")
    ap.add_argument("--reps", type=int, default=20,
                    help="calls a timed block (fewer: faster on arms whose special poses take ms)")
    ap.add_argument("--atol", type=float, default=0.0,
                    help="compare solution sets to this (radians, lengths), not bit for bit (0)")
    ap.add_argument("--out", default=str(RESULTS / "free_solve.md"))
    opts = ap.parse_args(argv)
    head = ["case", "method", "path", "solve median (us CPU): all / random / special", "C call median",
            "ratio"]
    if opts.against:
        head += [f"before ({Path(opts.against).name})", "before ratio", "poses differing",
                 "of them sound on both sides", "largest difference"]
    lines = ["# Single-pose solve with a free joint", "",
             f"Written by `python benchmarks/free_solve.py --poses {opts.poses}"
             + (f" --against {opts.against}" if opts.against else "")
             + (f" --atol {opts.atol:g}" if opts.atol else "")
             + (f" --reps {opts.reps}" if opts.reps != 20 else "") + "`: "
             f"{2 * opts.poses} poses a case ({opts.poses} random, {opts.poses} special, "
             f"{max(1, opts.poses // 10)} of them with the free value outside its limits); CPU time a "
             f"call, fastest of 3 blocks of {opts.reps} calls, medians over all the poses, the random "
             "ones and the special ones (a median over both lands between the two where they differ "
             "much); *C call*: `NativeChain.exact` alone; *ratio*: solve over the C call (all, random, "
             "special).", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * 3 + "---:|" * (len(head) - 3)]
    failed = False
    load = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory(prefix="ikc_free_") as tmp:
        for case in opts.cases:
            log(f"{case}: this checkout")
            now = run(ROOT, case, opts.poses, Path(tmp) / "now.npz", opts.reps)
            s, c = medians(now["t_solve"], opts.poses), medians(now["t_c"], opts.poses)
            cells = [case + (f" ({now['free']} free)" if case in ARMS else ""), str(now["method"]),
                     str(now["path"]), _cell(s, "{:.1f}"), _cell(c, "{:.1f}"), _cell(s / c, "{:.2f}")]
            if opts.against:
                log(f"{case}: {opts.against}")
                before = run(Path(opts.against).resolve(), case, opts.poses, Path(tmp) / "before.npz",
                             opts.reps)
                if not np.array_equal(now["T"], before["T"]) or not np.array_equal(now["F"], before["F"]):
                    raise SystemExit(f"{case}: the two checkouts sampled different poses")
                bs, bc = medians(before["t_solve"], opts.poses), medians(before["t_c"], opts.poses)
                bad, worst = differing(now, before, opts.atol)
                sound = sum(bool(now["sound"][i] and before["sound"][i]) for i in bad)
                failed |= sound < len(bad)  # a difference is acceptable where both sides are sound
                cells += [_cell(bs, "{:.1f}"), _cell(bs / bc, "{:.2f}"), str(len(bad)), str(sound),
                          f"{worst:.1e}"]
            lines.append("| " + " | ".join(cells) + " |")
            log(lines[-1])
    load.append(os.getloadavg()[0])
    lines += ["", f"Load average (1 min) at the start and end of the run: {load[0]:.1f}, {load[1]:.1f}.", ""]
    Path(opts.out).write_text("\n".join(lines))
    print(f"wrote {opts.out}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
