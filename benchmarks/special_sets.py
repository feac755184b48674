"""Solution sets of every zoo robot on the special and taught poses of ``special_poses.py``, written
to a JSON file, and the comparison of two such files (docs/design.md section 6: a change to the
finish must not lose or add solutions).

``python benchmarks/special_sets.py --write FILE`` solves the 300 special and 300 taught poses of each
zoo robot (the same poses, seeds 7 and 8) and stores each pose's rows; ``--compare A B`` says, robot by
robot, how many poses have the same set in both (rows matched to 1e-6: revolute values modulo 2 pi,
prismatic ones over the size) and lists the others.  Run ``--write`` before and after a change, from
the two trees (``PYTHONPATH``), then ``--compare``.
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
        out[label] = [np.asarray(module.solve(T[i], *tuple(Q[i, free_cols]))).tolist() for i in range(len(T))]
    return out


def _distance(a, b, kinds, scale) -> float:
    d = np.abs(np.asarray(a) - np.asarray(b))
    rev = np.array([k == "R" for k in kinds])
    d[rev] = np.abs((d[rev] + np.pi) % (2 * np.pi) - np.pi)
    d[~rev] /= scale
    return float(d.max()) if d.size else 0.0


def same_set(A, B, kinds, scale) -> bool:
    if len(A) != len(B):
        return False
    return all(any(_distance(a, b, kinds, scale) <= MATCH for b in B) for a in A) and \
        all(any(_distance(a, b, kinds, scale) <= MATCH for a in A) for b in B)


def compare(fa: str, fb: str) -> int:
    A, B = json.loads(Path(fa).read_text()), json.loads(Path(fb).read_text())
    differ = 0
    for name in sorted(A):
        if name not in B:
            print(f"{name}: only in {fa}")
            continue
        a, b = A[name], B[name]
        for label in ("special", "taught"):
            bad = [i for i, (x, y) in enumerate(zip(a[label], b[label]))
                   if not same_set(x, y, a["kinds"], a["scale"])]
            differ += len(bad)
            print(f"{name:14s} {label:8s} same {len(a[label]) - len(bad)}/{len(a[label])}"
                  + (f"  differ at {bad[:10]}: rows {[len(a[label][i]) for i in bad[:10]]} -> "
                     f"{[len(b[label][i]) for i in bad[:10]]}" if bad else ""))
    return 1 if differ else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write")
    ap.add_argument("--robots", nargs="*")
    ap.add_argument("--compare", nargs=2)
    args = ap.parse_args(argv)
    if args.compare:
        return compare(*args.compare)
    from ikcompiler.inputs.zoo import zoo_names

    names = args.robots or zoo_names()
    Path(args.write).write_text(json.dumps({n: robot_sets(n) for n in names}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
