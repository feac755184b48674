"""ikcompiler beside every IK tool that applies, on the same robots and the same poses (issue 11 item 7).

One command::

    python benchmarks/compare.py [--robots LABEL ...] [--poses N] [--batch N] [--threads T]

Robots: the zoo's 6R arms, the Robotics Toolbox's DH models of Pieper and UR-type arms (loaded into
ikcompiler from the same DH numbers, so both sides have one frame by construction) and a URDF arm of
rtb-data (via ``ikcompiler.robotdb``).  Tools, each in its own subprocess (a crash or an abort is
reported, not fatal; a tool that is not installed is reported "not installed"):

* ikcompiler: ``compile_robot`` + the C build (cold: a fresh chain cache, the shared finish library
  built once beforehand, docs/design.md section 14; warm: the chain found in the cache), ``solve``
  per pose, ``solve_batch`` over the batch poses in ``--threads`` C threads;
* EAIK (``eaik``): built from the chain's axes and offsets (H, P, tool rotation: the construction of
  ``benchmarks/compiler.py``), ``calculate_IK`` per pose and ``calculate_IK_batched`` in the same
  number of threads;
* IK-Geo (``ik_geo``): the user picks the family; here each family of its Python package is tried on
  known poses (joint vectors of the robot's own FK) and the first whose exact rows reproduce them is
  used; none passing is reported;
* ikpy: a chain of URDF-style links built from the same axes and offsets, ``inverse_kinematics_frame``
  from the zero vector (few poses: it takes milliseconds);
* the Robotics Toolbox (``roboticstoolbox``): ``ik_LM`` (C++) on an ETS built from the same axes and
  offsets, or on its own DH model for its robots, and its analytic ``ikine_a`` where its model has one
  (Puma560).

Every returned row is checked by OUR forward kinematics of the true robot (never the tool's own
report), with ``benchmarks/compiler.py``'s accounting: *wrong* above 1e-9 of the robot's size
(docs/design.md section 9), *recovered* the sampled joint vector among the rows (1e-6), over the poses
whose sampled vector is regular.  Rows a tool flags least-squares are left out.  Each tool's frame is
checked on a known pose (the first single pose) before its figures count.

Results: ``benchmarks/results/compare.md`` (table and notes) and ``benchmarks/results/compare.png``.
Progress goes to stderr.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import importlib.metadata as _md
import importlib.util
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# benchmarks/ first on sys.path would shadow the project's packages (benchmarks/subproblems.py)
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != ROOT / "benchmarks"]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
RESULTS = ROOT / "benchmarks" / "results"
WORKER_TIMEOUT = 600
SEED_SINGLE, SEED_BATCH = 11, 12
TOOLS = ("ikcompiler", "eaik", "ik_geo", "ikpy", "rtb_ik_LM", "rtb_ikine_a")
TOOL_PACKAGE = {"ikcompiler": "ikcompiler", "eaik": "EAIK", "ik_geo": "ik-geo", "ikpy": "ikpy",
                "rtb_ik_LM": "roboticstoolbox-python", "rtb_ikine_a": "roboticstoolbox-python"}
TOOL_MODULE = {"eaik": "eaik", "ik_geo": "ik_geo", "ikpy": "ikpy", "rtb_ik_LM": "roboticstoolbox",
               "rtb_ikine_a": "roboticstoolbox"}
SLOW_SINGLE = {"ikpy": 30, "ik_geo": 60}  # poses for tools that take milliseconds a pose
IK_GEO_FAMILIES = ("spherical_two_parallel", "spherical_two_intersecting", "spherical",
                   "three_parallel_two_intersecting", "three_parallel", "two_parallel", "two_intersecting",
                   "gen_six_dof")


def _bench_compiler():
    """benchmarks/compiler.py as a module: its accounting (_accuracy) and EAIK geometry are reused."""
    spec = importlib.util.spec_from_file_location("ikc_bench_compiler", ROOT / "benchmarks" / "compiler.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def log(msg: str) -> None:
    print(f"[compare {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


# ---- robots ------------------------------------------------------------------------------------------

ZOO = ("puma560", "ur5", "kr6_r700", "prob", "jaco")
RTB_DH = ("Puma560", "UR10", "KR5", "IRB140")  # roboticstoolbox.models.DH: standard DH, no base/tool
URDF = (("rtb-data", "kr16_2.urdf"), ("example-robot-data", "kinova.urdf"))


def rtb_dh_dict(model: str) -> dict:
    """The toolbox's DH model as an ikcompiler DH table (same numbers: one frame on both sides)."""
    import roboticstoolbox as rtb

    robot = getattr(rtb.models.DH, model)()
    if robot.mdh or not np.allclose(robot.base.A, np.eye(4)) or not np.allclose(robot.tool.A, np.eye(4)):
        raise ValueError(f"{model}: modified DH or a base/tool transform (not read here)")
    rows = []
    for i, link in enumerate(robot.links):
        if link.isflip or not link.isrevolute:
            raise ValueError(f"{model}: joint {i} is flipped or prismatic (not read here)")
        lo, hi = (robot.qlim[:, i] if robot.qlim is not None else (-np.pi, np.pi))
        rows.append({"name": f"j{i + 1}", "type": "R", "d": float(link.d), "a": float(link.a),
                     "alpha": float(link.alpha), "theta": float(link.offset),
                     "lower": float(lo), "upper": float(hi)})
    return {"name": f"{model.lower()}_rtb", "convention": "standard", "units": "m", "angles": "rad",
            "row": rows}


def robot_specs(only=None) -> list[dict]:
    """Every robot of the comparison: label, how to load it (spec), where it comes from."""
    specs = [{"label": n, "spec": {"kind": "zoo", "name": n}, "source": "zoo"} for n in ZOO]
    try:
        for m in RTB_DH:
            specs.append({"label": f"{m.lower()} (rtb DH)", "spec": {"kind": "dh", "table": rtb_dh_dict(m)},
                          "source": "roboticstoolbox-python DH model", "rtb_model": m})
    except ImportError:
        log("roboticstoolbox not installed: its DH models are left out")
    try:
        from ikcompiler import robotdb

        for package, name in URDF:
            for path, rel in robotdb.description_files(package):
                if Path(rel).name == name:
                    entries, _ = robotdb.chains_in_urdf(path, package, rel)
                    for e, _sig in entries[:1]:
                        specs.append({"label": f"{e.robot} ({package})",
                                      "spec": {"kind": "urdf", "path": str(e.urdf), "base": e.base,
                                               "tip": e.tip}, "source": f"{package}: {rel}"})
    except Exception as exc:  # the robots extra is optional
        log(f"robot-description packages unavailable ({exc}): URDF arms left out")
    if only:
        specs = [s for s in specs if s["label"] in only or s["label"].split()[0] in only]
    return specs


def load_chain(spec: dict):
    from ikcompiler import load_robot

    if spec["kind"] == "zoo":
        return load_robot(spec["name"])
    if spec["kind"] == "urdf":
        return load_robot(spec["path"], base=spec["base"], tip=spec["tip"])
    from ikcompiler.inputs.dh import dh_from_dict

    return dh_from_dict(spec["table"], "<rtb DH>")


def compile_spec(spec: dict):
    from ikcompiler import compile_robot

    return compile_robot(load_chain(spec))


# ---- workers (each in its own process) -------------------------------------------------------------


def _median_us(times) -> float:
    return float(np.median(times)) * 1e6 if len(times) else float("nan")


def _pack(rows: list[np.ndarray], n: int):
    """Per-pose rows (k_i, n) padded to (N, K, n) with NaN."""
    k = max([len(r) for r in rows] + [1])
    Q = np.full((len(rows), k, n), np.nan)
    for i, r in enumerate(rows):
        Q[i, : len(r)] = r
    return Q


def _time_each(fn, Ts) -> tuple[list, list]:
    out, times = [], []
    for T in Ts:
        t0 = time.perf_counter()
        rows = fn(T)
        times.append(time.perf_counter() - t0)
        out.append(rows)
    return out, times


def worker_ikcompiler(job: dict, z) -> dict:
    import resource

    from subproblems import native

    meta = {}
    spec = job["spec"]
    t0 = time.perf_counter()
    module = compile_spec(spec)
    meta["compile_ms"] = (time.perf_counter() - t0) * 1e3
    t0, cpu0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
    chain = module._native_chain()
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    meta["cbuild_cold_ms"] = (time.perf_counter() - t0) * 1e3
    # the compiler's own CPU time: what the build costs on an idle machine (the wall time waits for cores)
    meta["cbuild_cpu_ms"] = (cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime) * 1e3
    meta["native"] = chain is not None
    meta["native_error"] = native.last_error
    # warm: a second compile, the chain found in the on-disk cache (the in-process table emptied)
    native._loaded.clear()
    t0 = time.perf_counter()
    warm = compile_spec(spec)
    warm._native_chain()
    meta["compile_warm_ms"] = (time.perf_counter() - t0) * 1e3
    meta["method"] = module.METHOD
    Ts, Tb = z["Ts"], z["Tb"]
    for T in Ts[:20]:  # warm-up
        module.solve(T)
    rows, times = _time_each(module.solve, Ts)
    meta["single_us"] = _median_us(times)
    module.solve_batch(Tb[:200])
    runs = []
    for _ in range(3):
        t0 = time.perf_counter()
        module.solve_batch(Tb)
        runs.append(time.perf_counter() - t0)
    meta["batch_pps"] = len(Tb) / min(runs)
    return meta, {"Q": _pack(rows, len(module.JOINT_NAMES))}


def worker_eaik(job: dict, z) -> dict:
    bc = _bench_compiler()  # EAIK's robot, single call and batch timing as benchmarks/compiler.py's
    H = z["H"]
    t0 = time.perf_counter()
    robot = bc.eaik_robot(H, z["P"], z["R6T"])
    meta = {"build_ms": (time.perf_counter() - t0) * 1e3, "family": str(robot.get_kinematic_family())}
    if not robot.has_known_decomposition():
        meta["error"] = f"no known decomposition ({meta['family']})"
        return meta, {}
    n = H.shape[0]

    def one(T):
        q, ls = bc.eaik_solve(robot, T, n)
        return q[~ls]

    Ts, Tb = z["Ts"], z["Tb"]
    for T in Ts[:20]:
        one(T)
    rows, times = _time_each(one, Ts)
    meta["single_us"] = _median_us(times)
    best, _ = bc.eaik_batch(robot, Tb, int(job["threads"]))
    meta["batch_pps"] = len(Tb) / best
    return meta, {"Q": _pack(rows, n)}


def worker_ik_geo(job: dict, z) -> dict:
    import ik_geo

    H, P, R6T = z["H"].tolist(), z["P"].tolist(), z["R6T"]
    known_q, known_T = z["known_q"], z["known_T"]

    def solver(robot):
        def one(T):
            # its tool frame is the last joint's (no tool rotation): the target rotation times R6T^T
            out = robot.get_ik((T[:3, :3] @ R6T.T).tolist(), T[:3, 3].tolist())
            return np.array([s for s, ls in out if not ls], dtype=float).reshape(-1, len(H))
        return one

    tried = []
    for family in IK_GEO_FAMILIES:
        t0 = time.perf_counter()
        robot = getattr(ik_geo.Robot, family)(H, P)
        build_ms = (time.perf_counter() - t0) * 1e3
        one, hits = solver(robot), 0
        for q, T in zip(known_q, known_T):
            try:
                rows = one(T)
            except BaseException:  # its Rust panics surface as pyo3 PanicException (a BaseException)
                rows = np.zeros((0, len(H)))
            d = np.abs(np.remainder(rows - q + np.pi, 2 * np.pi) - np.pi).max(axis=1) if len(rows) else [1]
            hits += bool(np.min(d) < 1e-6)
        tried.append(f"{family} {hits}/{len(known_q)}")
        if hits == len(known_q):
            break
    else:
        return {"error": "no family recovers the known poses (" + ", ".join(tried) + ")"}, {}
    meta = {"family": family, "build_ms": build_ms, "tried": tried}
    Ts = z["Ts"][: SLOW_SINGLE["ik_geo"]]

    def safe(T):
        try:
            return one(T)
        except BaseException:
            return np.zeros((0, len(H)))

    rows, times = _time_each(safe, Ts)
    meta["single_us"] = _median_us(times)
    return meta, {"Q": _pack(rows, len(H))}


def _ikpy_chain(H, P, R6T):
    from ikpy.chain import Chain
    from ikpy.link import OriginLink, URDFLink
    from scipy.spatial.transform import Rotation

    links = [OriginLink()]
    for i in range(len(H)):  # each joint frame at its axis point, aligned with the base at home
        links.append(URDFLink(name=f"j{i}", origin_translation=P[i], origin_orientation=[0, 0, 0],
                              rotation=H[i]))
    links.append(URDFLink(name="tool", origin_translation=P[-1],
                          origin_orientation=Rotation.from_matrix(R6T).as_euler("xyz"), joint_type="fixed"))
    return Chain(links, active_links_mask=[False] + [True] * len(H) + [False])


def worker_ikpy(job: dict, z) -> dict:
    import warnings

    warnings.filterwarnings("ignore")
    import ikpy.chain  # noqa: F401  (imported before the timed build)

    H, P, R6T = z["H"], z["P"], z["R6T"]
    n = len(H)
    t0 = time.perf_counter()
    chain = _ikpy_chain(H, P, R6T)
    meta = {"build_ms": (time.perf_counter() - t0) * 1e3}
    start = [0.0] * (n + 2)

    def one(T):
        return np.asarray(chain.inverse_kinematics_frame(T, initial_position=start, orientation_mode="all"))[
            None, 1:n + 1]

    rows, times = _time_each(one, z["Ts"][: SLOW_SINGLE["ikpy"]])
    meta["single_us"] = _median_us(times)
    return meta, {"Q": _pack(rows, n)}


def _rtb_robot(job, z):
    import roboticstoolbox as rtb
    from scipy.spatial.transform import Rotation
    from spatialmath import SE3

    if job.get("rtb_model"):
        return getattr(rtb.models.DH, job["rtb_model"])()
    H, P, R6T = z["H"], z["P"], z["R6T"]
    ets = rtb.ETS()
    z_axis = np.array([0.0, 0.0, 1.0])
    for i in range(len(H)):  # a fixed frame at the axis point whose z is the axis, Rz, and back
        v, c = np.cross(z_axis, H[i]), float(z_axis @ H[i])
        if np.linalg.norm(v) < 1e-12:
            A = np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
        else:
            A = Rotation.from_rotvec(v / np.linalg.norm(v) * np.arccos(np.clip(c, -1, 1))).as_matrix()
        M, B = np.eye(4), np.eye(4)
        M[:3, :3], M[:3, 3], B[:3, :3] = A, P[i], A.T
        ets = ets * rtb.ET.SE3(SE3(M, check=False)) * rtb.ET.Rz() * rtb.ET.SE3(SE3(B, check=False))
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R6T, P[-1]
    return rtb.Robot(ets * rtb.ET.SE3(SE3(M, check=False)))


def worker_rtb_ik_LM(job: dict, z) -> dict:
    import roboticstoolbox  # noqa: F401  (imported before the timed build)

    t0 = time.perf_counter()
    robot = _rtb_robot(job, z)
    meta = {"build_ms": (time.perf_counter() - t0) * 1e3, "model": job.get("rtb_model") or "ETS from H, P"}
    n = robot.n

    def one(T):
        sol = robot.ik_LM(T)  # C++; default tolerance, one solution from a random restart
        return np.asarray(sol.q, dtype=float)[None] if sol.success else np.zeros((0, n))

    Ts = z["Ts"]
    for T in Ts[:10]:
        one(T)
    rows, times = _time_each(one, Ts)
    meta["single_us"] = _median_us(times)
    return meta, {"Q": _pack(rows, n)}


def worker_rtb_ikine_a(job: dict, z) -> dict:
    if not job.get("rtb_model"):
        return {"error": "no toolbox model of this robot"}, {}
    import roboticstoolbox as rtb
    from spatialmath import SE3

    robot = getattr(rtb.models.DH, job["rtb_model"])()
    if "ikine_a" not in type(robot).__dict__:
        return {"error": f"its {job['rtb_model']} model has no analytic IK"}, {}
    # every branch, one call each: left/right arm, elbow up/down, wrist flipped or not
    configs = ("luf", "lun", "ldf", "ldn", "ruf", "run", "rdf", "rdn")

    def one(T):
        out = []
        for c in configs:
            sol = robot.ikine_a(SE3(T, check=False), config=c)
            if sol.success:
                out.append(np.asarray(sol.q, dtype=float))
        return np.array(out).reshape(-1, robot.n)

    Ts = z["Ts"]
    for T in Ts[:5]:
        one(T)
    rows, times = _time_each(one, Ts)
    meta = {"single_us": _median_us(times), "branches": "8 calls (one per configuration string)"}
    return meta, {"Q": _pack(rows, robot.n)}


WORKERS = {"ikcompiler": worker_ikcompiler, "eaik": worker_eaik, "ik_geo": worker_ik_geo, "ikpy": worker_ikpy,
           "rtb_ik_LM": worker_rtb_ik_LM, "rtb_ikine_a": worker_rtb_ikine_a}


def _worker_main(tool: str, inp: str, out: str) -> None:
    with np.load(inp, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    job = json.loads(str(arrays.pop("job")))
    meta, outputs = WORKERS[tool](job, arrays)
    np.savez(out, meta=np.array(json.dumps(meta)), **outputs)


def run_worker(tool: str, job: dict, arrays: dict, tmp: Path, env: dict, bc) -> tuple[dict, dict]:
    """Run one tool in a subprocess: (meta, arrays); meta["error"] says why there is nothing."""
    module = TOOL_MODULE.get(tool)
    if module and importlib.util.find_spec(module) is None:
        return {"error": "not installed"}, {}
    meta, out, err = bc.run_npz_worker([Path(__file__).resolve(), "--worker", tool],
                                       {"job": np.array(json.dumps(job)), **arrays}, tmp / f"{tool}_in.npz",
                                       tmp / f"{tool}_out.npz", what="the worker", timeout=WORKER_TIMEOUT,
                                       env=env)
    return ({"error": err}, {}) if err else (meta, out)


# ---- the comparison ----------------------------------------------------------------------------------


def unpack(Q: np.ndarray) -> list[np.ndarray]:
    return [q[~np.isnan(q).any(axis=1)] for q in Q]


def frame_check(chain, T: np.ndarray, rows: np.ndarray, scale: float) -> bool:
    """Whether a tool's rows for a known pose reproduce it through our FK to 1e-2 of the size: loose
    enough for a numerical tool's default tolerance (RTB's ik_LM misses by up to ~1e-3), tight enough
    to catch a wrong frame or joint convention (those miss by a good part of the size)."""
    if len(rows) == 0:
        return False
    G = chain.fk_batch(rows)
    err = np.maximum(np.linalg.norm(G[:, :3, 3] - T[:3, 3], axis=1) / scale,
                     np.abs(G[:, :3, :3] - T[:3, :3]).max(axis=(1, 2)))
    return bool(err.min() < 1e-2)


def compare_robot(entry: dict, opts, bc, env: dict) -> dict:
    chain = load_chain(entry["spec"])
    Q1, T1 = bc._poses(chain, opts.poses, SEED_SINGLE, [], [])
    _, Tb = bc._poses(chain, opts.batch, SEED_BATCH, [], [])
    H, P, R6T, _ = bc.eaik_geometry(chain, [], [])
    arrays = {"Ts": T1, "Tb": Tb, "H": H, "P": P, "R6T": R6T, "known_q": Q1[:3], "known_T": T1[:3]}
    job = {"spec": entry["spec"], "threads": opts.threads, "rtb_model": entry.get("rtb_model")}
    row = {"label": entry["label"], "source": entry["source"], "joints": chain.joint_types,
           "scale": float(chain.scale), "tools": {}}
    revolute = all(k == "R" for k in chain.joint_types) and not chain.couplings and chain.dof == 6
    with tempfile.TemporaryDirectory(prefix="ikc_compare_") as tmpdir:
        for tool in TOOLS:
            if tool != "ikcompiler" and not revolute:
                row["tools"][tool] = {"error": "not a 6R chain"}
                continue
            log(f"{entry['label']}: {tool}")
            meta, out = run_worker(tool, job, arrays, Path(tmpdir), env, bc)
            if "Q" in out:
                rows = unpack(out["Q"])
                n = len(rows)
                meta["frame_ok"] = frame_check(chain, T1[0], rows[0], chain.scale) or frame_check(
                    chain, T1[1], rows[1], chain.scale)
                meta["accuracy"] = bc._accuracy(chain, T1[:n], Q1[:n], rows, chain.joint_types)
                meta["poses"] = n
            row["tools"][tool] = meta
    return row


# ---- output ------------------------------------------------------------------------------------------


def _f(x, spec=".3g", none="-"):
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return none
    return format(x, spec)


def _ratio(a, b) -> str:
    if not a or not b or not np.isfinite(a) or not np.isfinite(b):
        return "-"
    r = a / b
    return f"{r:,.0f}x" if r >= 100 else f"{r:.2g}x"


TOOL_LABEL = {"ikcompiler": "ikcompiler", "eaik": "EAIK", "ik_geo": "IK-Geo", "ikpy": "ikpy",
              "rtb_ik_LM": "RTB ik_LM", "rtb_ikine_a": "RTB ikine_a"}


def render(rows, meta, opts) -> str:
    out = ["# ikcompiler beside the other IK tools: same robots, same poses", "",
           f"Generated by `python benchmarks/compare.py` on {meta['date']}. Machine: {meta['machine']}; "
           f"Python {meta['python']}, numpy {meta['numpy']}; versions: {meta['versions']}. "
           f"Load average (1 min) at the start {meta['load_start']}, at the end {meta['load_end']} on "
           f"{meta['cores']} cores: the machine was shared, so times are loaded-machine times (ratios taken "
           "within one robot's run are the fairer figures).", "",
           f"Poses: {opts.poses} single poses per robot (ikpy the first {SLOW_SINGLE['ikpy']}, IK-Geo the "
           f"first {SLOW_SINGLE['ik_geo']}) and {opts.batch} batch poses, from "
           "`verify.sample_configurations` (a quarter of the joint values at 0, +-pi/2, pi) and our FK; "
           "the same poses for every tool. "
           f"Batch: ikcompiler `solve_batch` in {opts.threads} C threads (`IKC_THREADS`), EAIK "
           f"`calculate_IK_batched` in {opts.threads} threads; the other tools have no batch call.", "",
           "Columns. *build ms*: ikcompiler `compile_robot` (derivation + code) + its C build cold "
           "(fresh chain cache; the shared finish library built once beforehand; in square brackets the "
           "compiler's own CPU time, what the build costs on an idle machine), and warm (a second "
           "`compile_robot` + loading the cached chain); the others construct their solver object. "
           "*single us*: median wall time of one call per pose (RTB ikine_a: its 8 branch calls). "
           "*ratio*: tool / ikcompiler in time per pose (single: medians; batch: throughputs inverted; "
           "above 1x the tool is slower). *found*: poses with at least one returned row; *recovered*: the "
           "sampled joint vector among the rows (1e-6), over the regular sampled vectors; *wrong*: rows "
           "whose residual through OUR FK of the true robot exceeds 1e-9 of the size (the project's "
           "contract; a numerical tool's default tolerance is looser, so its rows count as wrong there: "
           "see max error); *max error*: the largest such residual, relative to the size; *solutions*: "
           "median rows per pose.", "",
           "| robot | tool | method / family | build ms | single us | ratio | batch poses/s | ratio | found "
           "| recovered | wrong | max error | solutions | notes |",
           "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for row in rows:
        ours = row["tools"].get("ikcompiler", {})
        for tool in TOOLS:
            t = row["tools"].get(tool)
            if t is None:
                continue
            acc = t.get("accuracy") or {}
            notes = []
            if t.get("error"):
                notes.append(t["error"])
            if "frame_ok" in t and not t["frame_ok"]:
                notes.append("known-pose frame check failed: figures not comparable")
            if tool == "ikcompiler":
                method = t.get("method", "-")
                build = (f"{_f(t.get('compile_ms'), '.0f')} + {_f(t.get('cbuild_cold_ms'), '.0f')} "
                         f"[cc CPU {_f(t.get('cbuild_cpu_ms'), '.0f')}] "
                         f"(warm {_f(t.get('compile_warm_ms'), '.0f')})") if "compile_ms" in t else "-"
                if t.get("native") is False:
                    why = t.get("native_error")
                    notes.append(f"no C build: {why}" if why else "no C chain for this method (numpy)")
            else:
                method = t.get("family") or t.get("model") or "-"
                build = _f(t.get("build_ms"), ".3g")
                if tool == "rtb_ik_LM":
                    method = f"LM, {t.get('model', '-')}"
            if tool == "ik_geo" and t.get("tried"):
                notes.append("families tried on known poses: " + "; ".join(t["tried"]))
            single, batch = t.get("single_us"), t.get("batch_pps")
            r_single = "-" if tool == "ikcompiler" else _ratio(single, ours.get("single_us"))
            r_batch = "-" if tool == "ikcompiler" or not batch else _ratio(ours.get("batch_pps"), batch)
            found = f"{acc['found_fraction']:.1%}" if acc else "-"
            rec = f"{acc['recovered_regular_fraction']:.1%}" if acc else "-"
            out.append(f"| {row['label']} | {TOOL_LABEL[tool]} | {method} | {build} | {_f(single, '.3g')} | "
                       f"{r_single} | {_f(batch, ',.0f')} | {r_batch} | {found} | {rec} | "
                       f"{acc.get('wrong', '-')} | {_f(acc.get('max_error'), '.1e')} | "
                       f"{_f(acc.get('solutions_median'), '.0f')} | {'; '.join(notes)} |")
    out += ["", "## Short table (the README's)", ""] + render_short(rows)
    out += ["", "## Robots", ""]
    for row in rows:
        out.append(f"- {row['label']}: {row['joints']}, size {row['scale']:.3g} m, from {row['source']}")
    out += ["", "## Notes", "",
            "- EAIK, IK-Geo, ikpy and the ETS of RTB's `ik_LM` are built from our chain's axes H, axis "
            "points turned into offsets P, and the home rotation as the tool rotation "
            "(`benchmarks/compiler.py` `eaik_geometry`); IK-Geo has no tool rotation, "
            "so its target rotation is ours times R6T^T. "
            "The toolbox's own DH models (rtb DH rows) are the same numbers ikcompiler reads.",
            "- Every tool's rows are checked by our FK; its own success flags and residuals are not used "
            "(least-squares rows it flags are dropped).",
            "- The ratio columns compare the same poses in the same run; the machine's load moves both.",
            "- IK-Geo (`ik-geo` 1.0.3, its Python package): with H and P as documented (6x3, 7x3) its "
            "`forward_kinematics` agrees with ours, but no family's `get_ik` returns the sampled joint "
            "vector of the known poses, and its rows flagged exact miss the target through its own "
            "`forward_kinematics` too (puma560, q = 0.1..0.6: by 0.25-1.1 m), with the rotation given "
            "either way round; the package's hard-coded bots have no FK to check a frame against.  So "
            "it is reported, not timed.",
            "- Where ikcompiler's time goes (callgrind, `benchmarks/results/batch_instructions.md`, "
            "session 8): on the RTB DH puma560 25.5k instructions a pose, `ikc_angle_about` 21% and libm `atan2` 20% "
            "(the one libm call a leaf still needs: cosines and sines are passed on from the pairs the "
            "angles are the atan2 of), the chain's own arithmetic 20%, `ikc_rot_rrr` 13%, the finish "
            "(`ikc_finish`, `ikc_represent`) 14%.  The kinova arm is the exception (187k a pose): its "
            "URDF writes pi/2 as 1.57079632679, so every candidate misses the 1e-12 precision by "
            "1-4e-12 and gets a Newton step on the true robot in the finish (`ikc_fk_jacobian` 45%, "
            "steps and linear solves 27%; docs/design.md section 14).",
            ""]
    return "\n".join(out)


def render_short(rows) -> list[str]:
    """Time per pose of each tool and the batch ratio to EAIK, one line per robot (README, "Speed")."""
    def us(t):
        ok = t.get("single_us") and t.get("frame_ok", True)
        return _f(t["single_us"], ",.3g" if t["single_us"] < 1000 else ",.0f") if ok else (
            "refuses" if "decomposition" in str(t.get("error", "")) else "-")

    def pps(t):
        return _f(t.get("batch_pps"), ",.0f") if t.get("batch_pps") else (
            "refuses" if "decomposition" in str(t.get("error", "")) else "-")

    lines = ["| robot | ikcompiler `solve` us | EAIK us | RTB `ik_LM` us | ikpy us "
             "| ikcompiler batch poses/s | EAIK `IK_batched` | batch ratio |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for row in rows:
        t = row["tools"]
        ours, eaik = t.get("ikcompiler", {}), t.get("eaik", {})
        ratio = _ratio(ours.get("batch_pps"), eaik.get("batch_pps")) if eaik.get("batch_pps") else "-"
        lines.append(f"| {row['label']} | {us(ours)} | {us(eaik)} | {us(t.get('rtb_ik_LM', {}))} | "
                     f"{us(t.get('ikpy', {}))} | {pps(ours)} | {pps(eaik)} | {ratio} |")
    return lines


def plot(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [r["label"] for r in rows]
    series = [(tool, "single") for tool in TOOLS] + [("ikcompiler", "batch"), ("eaik", "batch")]
    fig, ax = plt.subplots(figsize=(max(10, 1.5 * len(rows)), 5))
    width = 0.8 / len(series)
    colors = plt.get_cmap("tab10")
    for j, (tool, kind) in enumerate(series):
        ys = []
        for r in rows:
            t = r["tools"].get(tool, {})
            if kind == "single":
                ok = t.get("frame_ok", True) and t.get("single_us")
                ys.append(t["single_us"] if ok else np.nan)
            else:
                ys.append(1e6 / t["batch_pps"] if t.get("batch_pps") else np.nan)
        x = np.arange(len(rows)) + (j - len(series) / 2 + 0.5) * width
        name = TOOL_LABEL[tool] + (" batch (per pose)" if kind == "batch" else "")
        batch = kind == "batch"
        ax.bar(x, ys, width, label=name, color=colors(TOOLS.index(tool)), hatch="//" if batch else None,
               edgecolor="white" if batch else None)
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(rows)))
    ax.set_xticklabels(labels, rotation=30, ha="right")
    ax.set_ylabel("time per pose (us, log scale)")
    ax.set_title("IK time per pose, same robots and poses (lower is better)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 1.0))  # outside: the bars stay visible
    ax.grid(axis="y", which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _machine(opts) -> dict:
    versions = []
    for tool in TOOLS:
        pkg = TOOL_PACKAGE[tool]
        if any(pkg in v for v in versions):
            continue
        try:
            versions.append(f"{pkg} {_md.version(pkg)}")
        except _md.PackageNotFoundError:
            versions.append(f"{pkg} not installed")
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    return {"date": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
            "machine": f"{cpu}, {platform.platform()}", "cores": os.cpu_count(),
            "python": platform.python_version(), "numpy": np.__version__,
            "versions": ", ".join(versions) + f" (ikcompiler at {commit})",
            "load_start": f"{os.getloadavg()[0]:.2f}"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robots", nargs="*", help="labels (or their first word) to run")
    ap.add_argument("--poses", type=int, default=200, help="single poses per robot")
    ap.add_argument("--batch", type=int, default=10000, help="batch poses per robot")
    ap.add_argument("--threads", type=int, default=2, help="threads of both batch calls")
    ap.add_argument("--out", default=str(RESULTS / "compare.md"))
    ap.add_argument("--worker", nargs=3, metavar=("TOOL", "IN", "OUT"), help=argparse.SUPPRESS)
    opts = ap.parse_args(argv)
    if opts.worker:
        _worker_main(*opts.worker)
        return 0
    bc = _bench_compiler()
    meta = _machine(opts)
    cache = Path(tempfile.mkdtemp(prefix="ikc_compare_cache_"))
    env = {**os.environ, "IKC_CACHE": str(cache), "IKC_THREADS": str(opts.threads)}
    # the shared finish library, built once (per machine, in real use) before the cold chain builds
    subprocess.run([sys.executable, "-c", "from ikcompiler import compile_robot; "
                    "compile_robot('rhino')._native_chain()"], env=env, check=False, capture_output=True)
    rows = []
    for entry in robot_specs(opts.robots):
        try:
            rows.append(compare_robot(entry, opts, bc, env))
        except Exception as exc:  # a robot that does not load: reported, the run goes on
            log(f"{entry['label']}: {type(exc).__name__}: {exc}")
            rows.append({"label": entry["label"], "source": entry["source"], "joints": "-",
                         "scale": float("nan"),
                         "tools": {"ikcompiler": {"error": f"{type(exc).__name__}: {str(exc)[:160]}"}}})
    meta["load_end"] = f"{os.getloadavg()[0]:.2f}"
    out = Path(opts.out)
    out.write_text(render(rows, meta, opts))
    out.with_suffix(".json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1, default=float))
    try:
        plot(rows, out.with_suffix(".png"))
    except ImportError:
        log("matplotlib not installed: no figure")
    log(f"wrote {out} and {out.with_suffix('.png')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
