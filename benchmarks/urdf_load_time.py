"""CPU time of reading a URDF robot in a fresh process: importing the reader and ``load_urdf``.

Usage::

    python benchmarks/urdf_load_time.py [--urdf robots/ur5.urdf] [--repeat 7] [--root CHECKOUT]

``--root`` runs another checkout's code (an exported older commit, for a before/after comparison).

Each run is a fresh process (bytecode cache on, as for an installed package) that imports
``ikcompiler.inputs`` first (numpy and the model, which every input needs), then measures the CPU of
importing ``ikcompiler.inputs.urdf`` and of ``load_urdf``.  Prints each run and the medians; the numbers
are quoted in ``benchmarks/results/compile_time.md`` (docs/design.md section 14).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import resource, sys
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
import ikcompiler.inputs
c0 = cpu()
from ikcompiler.inputs.urdf import load_urdf
c1 = cpu()
load_urdf(sys.argv[1])
c2 = cpu()
print((c1 - c0) * 1e3, (c2 - c1) * 1e3)
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--urdf", default="robots/ur5.urdf")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--root", type=Path, default=ROOT, help="the checkout whose ikcompiler is imported")
    opts = ap.parse_args(argv)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(opts.root.resolve())
    runs = []
    for _ in range(opts.repeat):
        out = subprocess.run([sys.executable, "-c", CHILD, opts.urdf], env=env, cwd=opts.root, check=True,
                             capture_output=True, text=True).stdout.split()
        runs.append((float(out[0]), float(out[1])))
        print(f"import {runs[-1][0]:.0f} ms, load {runs[-1][1]:.0f} ms (CPU)")
    print(f"median: import {statistics.median(r[0] for r in runs):.0f} ms, "
          f"load {statistics.median(r[1] for r in runs):.0f} ms (CPU), {opts.repeat} fresh processes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
