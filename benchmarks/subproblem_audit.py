"""Audit every subproblem code the way an outside caller would: random geometry, general and degenerate.

Not a test and not run by CI (the property tests in ``tests/subproblems`` are).  This is a black-box
check over many more instances than CI affords, with geometry built here on its own (numpy's random
generator, not the tests' hypothesis strategies), so that it finds what the tests' families miss::

    .venv/bin/python benchmarks/subproblem_audit.py [--n 2000] [--codes S2-RRT,S3-RR] [--seed 1]

For each code and each geometry family (below), ``n`` instances are drawn; the right-hand side is the
left side evaluated at drawn joint values (a few are made unreachable on purpose).  Each instance is
checked against the contract of issue 3 / docs/design.md section 4:

* ``raise``: ``solve`` raised on valid input;  ``nan``: a non-finite value came back;
* ``bad``: a row flagged exact (neither ``ls`` nor ``continuum``) misses the equation by more than
  ``1e-9`` times the instance's size (its largest length, floored at 1; radians for ``O-*``);
* ``lost``: not a continuum and the drawn joint values are not among the rows to ``1e-9`` (angles
  wrapped, translations relative to the size); ``lost6`` / ``lost3``: not even to ``1e-6`` / ``1e-3``;
* ``false-ls``: a reachable instance answered only by rows flagged ``ls``;
* ``batch``: ``solve_batch`` over the family's ``n`` instances disagrees with ``solve`` on this one (a row of
  either path without a row of the other within ``1e-6``, or different ``ls`` / ``continuum`` flags; the
  representatives of a continuum are not compared), or returned a non-finite value.

Families: ``general`` (random axes and points), ``lattice`` (axis directions along the coordinate
axes and their 45-degree diagonals, points on a half-unit lattice: exact intersections, parallels,
perpendiculars, coincident axes and points on axes arise by themselves), ``related`` (each joint
made exactly intersecting / parallel / coincident / perpendicular to an earlier one), ``near``
(``related`` perturbed by 1e-6 .. 1e-12).  Joint values: random, or 0, +-pi/2, pi (revolute) and 0
(prismatic).  Length scale 1, 1e-3 or 1e3.

Writes ``benchmarks/results/subproblem_audit.md`` (the table) and, with ``--dump F``, every failing
instance as JSON lines (code, family, twists, inputs, drawn values, what failed) to reproduce it.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from subproblems import codes, solve, solve_batch  # noqa: E402

FAMILIES = ("general", "lattice", "related", "near")
SPECIAL = (0.0, math.pi / 2, -math.pi / 2, math.pi)
COLUMNS = ("raise", "nan", "bad", "lost", "lost6", "lost3", "false-ls", "batch")
_DIAG = [np.array(v, float) / np.linalg.norm(v) for v in ([1, 1, 0], [1, 0, 1], [0, 1, 1], [1, -1, 0])]
_LATTICE_DIRS = [s * e for e in np.eye(3) for s in (1.0, -1.0)] + _DIAG


# ---------------------------------------------------------------- kinematics (written here, independent)


def _hat(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _rot(w, th):
    K = _hat(w)
    return np.eye(3) + math.sin(th) * K + (1.0 - math.cos(th)) * (K @ K)


def _exp(xi, th):
    v, w = xi[:3], xi[3:]
    g = np.eye(4)
    if not w.any():
        g[:3, 3] = v * th
        return g
    R = _rot(w, th)
    g[:3, :3] = R
    g[:3, 3] = (np.eye(3) - R) @ np.cross(w, v)  # axis point r = w x v for v = -w x r
    return g


def _fk(tw, th):
    g = np.eye(4)
    for xi, a in zip(tw, th):
        g = g @ _exp(xi, a)
    return g


def _apply(g, p):
    return g[:3, :3] @ p + g[:3, 3]


# --------------------------------------------------------------------------------- instance drawing


def _unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _perp_to(rng, w):
    u = np.cross(w, _unit(rng))
    return u / np.linalg.norm(u)


def _axes(rng, kinds, family, s):
    """Directions and points of the joint axes for one family."""
    W, R = [], []
    for i in range(len(kinds)):
        if family == "lattice":
            w = _LATTICE_DIRS[rng.integers(len(_LATTICE_DIRS))].copy()
            r = s * rng.integers(-2, 3, size=3) / 2.0
        else:
            w, r = _unit(rng), s * rng.uniform(-1, 1, size=3)
            if family in ("related", "near") and i:
                j = int(rng.integers(i))
                how = rng.choice(
                    ["intersect", "parallel", "coincident", "perpendicular", "perp-meet", "free"]
                )
                if how in ("parallel", "coincident"):
                    w = W[j] * rng.choice([1.0, -1.0])
                if how in ("perpendicular", "perp-meet"):
                    w = _perp_to(rng, W[j])
                if how in ("intersect", "coincident", "perp-meet"):
                    r = R[j] + s * rng.choice([0.0, 0.7]) * W[j]
                if family == "near" and how != "free":
                    eps = 10.0 ** -rng.integers(6, 13)
                    if rng.integers(2):
                        w = w + eps * _perp_to(rng, w)
                        w /= np.linalg.norm(w)
                    else:
                        r = r + s * eps * _perp_to(rng, w)
        W.append(w)
        R.append(r)
    tw = []
    for k, w, r in zip(kinds, W, R):
        tw.append(np.r_[-np.cross(w, r), w] if k == "R" else np.r_[w, 0.0, 0.0, 0.0])
    return np.array(tw), W, R


def _joint_values(rng, kinds, s):
    th = []
    for k in kinds:
        if k == "R":
            th.append(SPECIAL[rng.integers(4)] if rng.random() < 0.35 else rng.uniform(-math.pi, math.pi))
        else:
            th.append(0.0 if rng.random() < 0.2 else s * rng.uniform(-2, 2))
    return np.array(th)


def _point(rng, W, R, kinds, s, family):
    """A general point, the origin, a lattice point, or a point on a revolute axis."""
    pick = rng.integers(5)
    revs = [i for i, k in enumerate(kinds) if k == "R"]
    if pick == 0:
        return np.zeros(3)
    if pick == 1 and revs:
        i = revs[rng.integers(len(revs))]
        return R[i] + s * rng.choice([0.0, 1.0, -0.5]) * W[i]
    if family == "lattice":
        return s * rng.integers(-2, 3, size=3) / 2.0
    return s * rng.uniform(-1.5, 1.5, size=3)


def draw_instance(rng, code, family):
    """(twists, inputs, drawn joint values, reachable) for one instance of ``code``."""
    kinds = code.split("-", 1)[1]
    cls = code[:2]
    s = float(rng.choice([1.0, 1.0, 1.0, 1e-3, 1e3]))
    if cls == "O-":
        s = 1.0
    tw, W, R = _axes(rng, kinds, family, s)
    if cls == "O-":
        tw[:, :3] = 0.0  # orientation problems: axes through the origin
    th = _joint_values(rng, kinds, s)
    g = _fk(tw, th)
    reachable = rng.random() > 0.1
    if cls in ("S1", "O-"):
        T = g.copy()
        if not reachable:
            T = T @ _exp(np.r_[-np.cross(_unit(rng), s * rng.uniform(-1, 1, 3)), _unit(rng)], 0.3)
        return tw, {"T": T}, th, reachable
    m = 2 if len(kinds) == 2 and cls in ("S3", "H-") else 1
    P = [_point(rng, W, R, kinds, s, family) for _ in range(m)]
    if m == 2 and rng.random() < 0.2:
        P[1] = P[0].copy()
    if cls == "S2":
        q = _apply(g, P[0])
        if not reachable:
            q = q + s * 0.3 * _unit(rng)
        return tw, {"p": P[0], "q": q}, th, reachable
    if cls == "S3":
        Q = [
            _point(rng, W, R, kinds, s, family) if rng.random() < 0.85 else _apply(g, P[k]) for k in range(m)
        ]
        D = [float(np.linalg.norm(_apply(g, P[k]) - Q[k])) for k in range(m)]
        if not reachable:
            D = [d + s * rng.uniform(0.5, 3.0) for d in D]
        if m == 1:
            return tw, {"p": P[0], "q": Q[0], "d": D[0]}, th, reachable
        return tw, {"p": np.array(P), "q": np.array(Q), "d": np.array(D)}, th, reachable
    # H-*: plane normals along an axis, perpendicular to one, or general
    H = []
    for _ in range(m):
        ax = W[rng.integers(len(W))]
        H.append([ax, _perp_to(rng, ax), _unit(rng)][rng.integers(3)] * rng.choice([1.0, -2.0]))
    D = [float(H[k] @ _apply(g, P[k])) for k in range(m)]
    if not reachable:
        D = [d + s * rng.uniform(5.0, 8.0) for d in D]
    if m == 1:
        return tw, {"p": P[0], "h": H[0], "d": D[0]}, th, reachable
    return tw, {"p": np.array(P), "h": np.array(H), "d": np.array(D)}, th, reachable


# ----------------------------------------------------------------------------------------- checking


def size_of(tw, inputs):
    vals = [1.0]
    for name, v in inputs.items():
        v = np.asarray(v, float)
        if name == "T":
            vals.append(float(np.linalg.norm(v[:3, 3])))
        elif name != "h":
            vals.append(float(np.abs(v).max()) * math.sqrt(3))
    vals += [float(np.linalg.norm(np.cross(xi[3:], xi[:3]))) for xi in tw]
    return max(vals)


def miss(code, tw, row, inputs):
    """How far ``row`` misses the equation (length units; radians for O-*)."""
    g = _fk(tw, row)
    cls = code[:2]
    if cls == "O-":
        return float(np.abs(g[:3, :3] - inputs["T"][:3, :3]).max())
    if cls == "S1":
        T = inputs["T"]
        sT = max(1.0, float(np.linalg.norm(T[:3, 3])))
        return float(max(np.linalg.norm(g[:3, 3] - T[:3, 3]), sT * np.abs(g[:3, :3] - T[:3, :3]).max()))
    if cls == "S2":
        return float(np.linalg.norm(_apply(g, inputs["p"]) - inputs["q"]))
    P, D = np.atleast_2d(inputs["p"]), np.atleast_1d(inputs["d"])
    out = []
    for k in range(len(D)):
        x = _apply(g, P[k])
        if cls == "S3":
            out.append(abs(float(np.linalg.norm(x - np.atleast_2d(inputs["q"])[k])) - D[k]))
        else:
            h = np.atleast_2d(inputs["h"])[k]
            out.append(abs(float(h @ x) - D[k]) / float(np.linalg.norm(h)))
    return max(out)


def distance_to_drawn(kinds, rows, th, size):
    if not len(rows):
        return math.inf
    d = rows - th
    for j, k in enumerate(kinds):
        if k == "R":
            d[:, j] = (d[:, j] + math.pi) % (2 * math.pi) - math.pi
        else:
            d[:, j] /= size
    return float(np.abs(d).max(axis=1).min())


def check(code, tw, inputs, th, reachable):
    """The failure labels of one instance (empty when it passes) and the scalar result (None if it raised)."""
    kinds = code.split("-", 1)[1]
    try:
        r = solve(code, tw, **inputs)
    except Exception as exc:  # noqa: BLE001 - an audit records every failure kind
        return [f"raise:{type(exc).__name__}: {exc}"], None
    fails = []
    if not (np.all(np.isfinite(r.q)) and np.all(np.isfinite(r.residual))):
        return ["nan"], r
    size = size_of(tw, inputs)
    exact = ~r.ls
    for row, ex in zip(r.q, exact):
        if ex and not r.continuum and miss(code, tw, row, inputs) > 1e-9 * size:
            fails.append("bad")
            break
    if reachable:
        if len(r.q) and not exact.any():
            fails.append("false-ls")
        if not r.continuum:
            dist = distance_to_drawn(kinds, r.q.copy(), th, size)
            fails += [lab for lab, tol in (("lost", 1e-9), ("lost6", 1e-6), ("lost3", 1e-3)) if dist > tol]
    return fails, r


def _rows_match(kinds, A, B, size):
    """Every row of A has a row of B within 1e-6 (joint distance), with the same ls flag."""
    (qa, la), (qb, lb) = A, B
    for row, flag in zip(qa, la):
        near = [distance_to_drawn(kinds, qb[j : j + 1].copy(), row, size) <= 1e-6 for j in range(len(qb))]
        if not any(n and lb[j] == flag for j, n in enumerate(near)):
            return False
    return True


def batch_disagreements(code, insts, results):
    """Indices of instances where ``solve_batch`` over all of ``insts`` disagrees with the scalar results."""
    kinds = code.split("-", 1)[1]
    tws = np.array([t for t, *_ in insts])
    arrays = {k: np.array([inp[k] for _, inp, *_ in insts]) for k in insts[0][1]}
    try:
        b = solve_batch(code, tws, **arrays)
    except Exception:  # noqa: BLE001
        return set(range(len(insts)))
    out = set()
    for i, ((tw, inputs, *_), r) in enumerate(zip(insts, results)):
        if r is None:
            continue
        v = b.valid[i]
        qb, lb = b.q[i][v], b.ls[i][v]
        if not np.all(np.isfinite(b.q[i])) or bool(b.continuum[i]) != r.continuum:
            out.add(i)
            continue
        if r.continuum:
            continue  # representatives of a continuum: only the flags are compared
        size = size_of(tw, inputs)
        if not (
            _rows_match(kinds, (r.q, r.ls), (qb, lb), size)
            and _rows_match(kinds, (qb, lb), (r.q, r.ls), size)
        ):
            out.add(i)
    return out


def _jsonable(x):
    return np.asarray(x).tolist()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=500, help="instances per code and family")
    ap.add_argument("--codes", default="", help="comma-separated codes (default: every registered code)")
    ap.add_argument("--families", default=",".join(FAMILIES))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--dump", default="", help="write failing instances to this JSON-lines file")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "subproblem_audit.md"))
    args = ap.parse_args(argv)
    todo = [c for c in args.codes.split(",") if c] or codes()
    fams = [f for f in args.families.split(",") if f]
    dump = open(args.dump, "w") if args.dump else None
    lines = [
        f"# Subproblem audit (`benchmarks/subproblem_audit.py --n {args.n} --seed {args.seed}`)",
        "",
        "Failures per code and geometry family out of `n` instances each (columns: the script's docstring).",
        "",
        "| code | family | n | continuum | " + " | ".join(COLUMNS) + " |",
        "|---|---|---:|---:|" + "---:|" * len(COLUMNS),
    ]
    total = Counter()
    t0 = time.time()
    for ci, code in enumerate(todo):
        for fam in fams:
            rng = np.random.default_rng([args.seed, ci, FAMILIES.index(fam)])
            count, cont = Counter(), 0
            insts = [draw_instance(rng, code, fam) for _ in range(args.n)]
            checked = [check(code, *inst) for inst in insts]
            differ = batch_disagreements(code, insts, [r for _, r in checked])
            for i, ((tw, inputs, th, reachable), (fails, r)) in enumerate(zip(insts, checked)):
                fails = fails + (["batch"] if i in differ else [])
                cont += bool(r is not None and r.continuum)
                labels = {f.split(":")[0] for f in fails}
                count.update(labels)
                if fails and dump:
                    rec = {
                        "code": code,
                        "family": fam,
                        "i": i,
                        "fails": fails,
                        "twists": _jsonable(tw),
                        "inputs": {k: _jsonable(v) for k, v in inputs.items()},
                        "th": _jsonable(th),
                        "reachable": reachable,
                    }
                    dump.write(json.dumps(rec) + "\n")
            total.update(count)
            lines.append(
                f"| {code} | {fam} | {args.n} | {cont} | " + " | ".join(str(count[c]) for c in COLUMNS) + " |"
            )
            bad = ", ".join(f"{c} {count[c]}" for c in COLUMNS if count[c])
            print(
                f"[{ci + 1}/{len(todo)}] {code:7s} {fam:8s} {bad or 'ok'}  ({time.time() - t0:.0f} s)",
                flush=True,
            )
    lines += ["", "Totals: " + ", ".join(f"{c} {total[c]}" for c in COLUMNS), ""]
    Path(args.out).write_text("\n".join(lines))
    print("\n".join(lines[-2:]))
    print(f"table written to {args.out}")
    if dump:
        dump.close()


if __name__ == "__main__":
    main()
