"""Solution sets of every zoo robot on the special and taught poses of ``special_poses.py``, written
to a JSON file, and the comparison of two such files (docs/design.md section 6: a change to the
finish must not lose or add solutions).

``python benchmarks/special_sets.py --write FILE`` solves the 300 special and 300 taught poses of each
zoo robot (the same poses, seeds 7 and 8) and stores each pose's rows; ``--compare A B`` says, robot by
robot, how many poses have the same set in both (rows matched to 1e-6: revolute values modulo 2 pi,
prismatic ones over the size), how many differ only in the representatives of a self-motion line
(flagged continuum: each old representative on a new one's line, found from the Jacobian's null
direction, and the other way round) and lists the others.  Run ``--write`` before and after a change, from
the two trees (``PYTHONPATH``), then ``--compare``.  ``--tol 1e-9 --strict``: rows matched to 1e-9 and no
other representatives allowed (the same rows, as sets).  The exit status is 1 when any pose differs.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT))

import special_poses as sp  # noqa: E402  (the benchmark's poses, same seeds)

MATCH = 1e-6


def robot_sets(name: str) -> dict:
    _, module, free_cols = sp._setup(name)
    special, random = sp._joint_sets(module, np.random.default_rng(7), sp.POSES)
    taught = sp._taught(module, np.random.default_rng(8), sp.POSES, random)
    out = {"kinds": module.JOINT_TYPES, "scale": float(module.SCALE)}
    for label, Q in (("special", special), ("taught", taught)):
        T = sp._targets(module, Q)
        rows, cont, info_rows = [], [], []  # solve's rows; their continuum flags; solve_info's rows + ls
        for i in range(len(T)):
            free = tuple(Q[i, free_cols])
            R = np.asarray(module.solve(T[i], *free)).reshape(-1, len(module.JOINT_TYPES))
            info = module.solve_info(T[i], *free)
            flags = [bool(any(c and _distance(r, q, module.JOINT_TYPES, module.SCALE) <= MATCH
                              for q, c in zip(info.q, info.continuum))) for r in R]
            rows.append(R.tolist())
            cont.append(flags)
            info_rows.append([[*r, bool(ls)] for r, ls in zip(np.asarray(info.q).tolist(), info.ls)])
        out[label], out[label + "_continuum"], out[label + "_info"] = rows, cont, info_rows
    return out


def _distance(a, b, kinds, scale) -> float:
    d = np.abs(np.asarray(a) - np.asarray(b))
    rev = np.array([k == "R" for k in kinds])
    d[rev] = np.abs((d[rev] + np.pi) % (2 * np.pi) - np.pi)
    d[~rev] /= scale
    return float(d.max()) if d.size else 0.0


def same_set(A, B, kinds, scale, tol=None) -> bool:
    tol = MATCH if tol is None else tol
    if len(A) != len(B):
        return False
    return all(any(_distance(a, b, kinds, scale) <= tol for b in B) for a in A) and \
        all(any(_distance(a, b, kinds, scale) <= tol for a in A) for b in B)


def _null_slopes(module, q):
    """Integer joint slopes of the self-motion line through q (the Jacobian's null direction, the
    largest component 1), or None where it is not a line of integer slopes."""
    q = np.asarray(q, dtype=float)
    T0 = np.asarray(module.fk(q))
    h, J = 1e-6, []
    for j in range(len(q)):
        d = np.zeros(len(q))
        d[j] = h
        T1 = np.asarray(module.fk(q + d))
        dT = T1 - T0
        J.append(np.concatenate([dT[:3, 3] / module.SCALE, dT[:3, :3].ravel()]) / h)
    n = np.linalg.svd(np.array(J).T)[2][-1]
    s = n / n[np.argmax(np.abs(n))]
    return np.round(s) if np.abs(s - np.round(s)).max() <= 1e-4 else None


def _on_line(a, b, s) -> bool:
    """Whether row a lies on the line b + s t (revolute values modulo 2 pi)."""
    j = int(np.argmax(np.abs(s)))
    for k in range(-int(abs(s[j])) - 1, int(abs(s[j])) + 2):
        t = (np.remainder(a[j] - b[j] + np.pi, 2 * np.pi) - np.pi + 2 * np.pi * k) / s[j]
        d = np.remainder(np.asarray(b) + s * t - np.asarray(a) + np.pi, 2 * np.pi) - np.pi
        if np.abs(d).max() <= MATCH:
            return True
    return False


def compare(fa: str, fb: str, tol: float = MATCH, strict: bool = False) -> int:
    """Isolated rows must be the same (to ``tol``); rows on a self-motion may be other representatives
    of the same line (each old one on a new one's line and the other way round), unless ``strict``."""
    A, B = json.loads(Path(fa).read_text()), json.loads(Path(fb).read_text())
    differ = 0
    for name in sorted(A):
        if name not in B:
            print(f"{name}: only in {fa}")
            continue
        a, b = A[name], B[name]
        module = None
        for label in ("special", "taught"):
            bad, moved = [], []
            for i, (x, y) in enumerate(zip(a[label], b[label])):
                if same_set(x, y, a["kinds"], a["scale"], tol):
                    continue
                cx, cy = a[label + "_continuum"][i], b[label + "_continuum"][i]
                iso_x = [r for r, c in zip(x, cx) if not c]
                iso_y = [r for r, c in zip(y, cy) if not c]
                fam_x = [r for r, c in zip(x, cx) if c]
                fam_y = [r for r, c in zip(y, cy) if c]
                ok = not strict and same_set(iso_x, iso_y, a["kinds"], a["scale"], tol) \
                    and bool(fam_x) == bool(fam_y)
                if ok and fam_x:
                    if module is None:
                        module = sp._setup(name)[1]
                    lines = [(r, _null_slopes(module, r)) for r in fam_x + fam_y]
                    ok = all(s is not None for _, s in lines) and all(
                        any(_on_line(r, q, s) for q, s in lines if q is not r) or len(lines) == 1
                        for r in fam_x + fam_y)
                    ok = ok and all(any(_on_line(r, q, s) for q, s in lines[len(fam_x):]) for r in fam_x) \
                        and all(any(_on_line(r, q, s) for q, s in lines[:len(fam_x)]) for r in fam_y)
                (moved if ok else bad).append(i)
            if strict and label + "_info" in a and label + "_info" in b:
                # solve_info's rows too (least-squares ones included), each with its ls flag
                for i, (x, y) in enumerate(zip(a[label + "_info"], b[label + "_info"])):
                    same = len(x) == len(y) and all(
                        same_set([r[:-1] for r in x if r[-1] == ls], [r[:-1] for r in y if r[-1] == ls],
                                 a["kinds"], a["scale"], tol) for ls in (True, False))
                    if not same and i not in bad:
                        bad.append(i)
            differ += len(bad)
            n = len(a[label])
            print(f"{name:14s} {label:8s} same {n - len(bad) - len(moved)}/{n}, other representatives of "
                  f"the same self-motion lines {len(moved)}, differ {len(bad)}"
                  + (f" at {bad[:10]}: rows {[len(a[label][i]) for i in bad[:10]]} -> "
                     f"{[len(b[label][i]) for i in bad[:10]]}" if bad else ""))
    return 1 if differ else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write")
    ap.add_argument("--robots", nargs="*")
    ap.add_argument("--compare", nargs=2)
    ap.add_argument("--tol", type=float, default=MATCH, help="rows match to this (default %(default)g)")
    ap.add_argument("--strict", action="store_true", help="no other representatives of a self-motion")
    args = ap.parse_args(argv)
    if args.compare:
        return compare(*args.compare, tol=args.tol, strict=args.strict)
    from ikcompiler.inputs.zoo import zoo_names

    names = args.robots or zoo_names()
    Path(args.write).write_text(json.dumps({n: robot_sets(n) for n in names}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
