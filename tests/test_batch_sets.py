"""benchmarks/batch_sets.py, the before/after check of the batch path (docs/design.md section 14): its
comparison must fail on a moved row, a lost row, a changed mark and an inexact row."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from ikcompiler import compile_robot

_PATH = Path(__file__).parents[1] / "benchmarks" / "batch_sets.py"
_SPEC = importlib.util.spec_from_file_location("batch_sets", _PATH)
batch_sets = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(batch_sets)


def _run(module, Ts):
    Q, valid, ls, _, _ = module.solve_batch_info(Ts)
    revolute = np.array([t == "R" for t in module.JOINT_TYPES])
    return {"T": Ts, "Q": Q, "valid": valid, "ls": ls, "revolute": revolute, "scale": float(module.SCALE)}


def test_the_batch_set_check_fails_where_it_must():
    module = compile_robot("puma560")
    rng = np.random.default_rng(5)
    Ts = np.array([module.fk(rng.uniform(-1.0, 1.0, 6)) for _ in range(6)])
    now = _run(module, Ts)
    same = batch_sets.compare(now, {k: np.copy(v) for k, v in now.items()}, module.fk)
    counts = (same["set_differs"], same["marks_differ"], same["inexact_rows"], same["bit_equal"])
    assert counts == (0, 0, 0, 6)
    assert same["rows"] == same["rows_before"] == int((now["valid"] & ~now["ls"]).sum()) > 0

    moved = {k: np.copy(v) for k, v in now.items()}
    k = int(np.argmax(moved["valid"][0]))
    moved["Q"][0, k, 2] += 1e-8  # a row moved by more than 1e-9: the sets differ
    assert batch_sets.compare(now, moved, module.fk)["set_differs"] == 1
    assert batch_sets.compare(moved, now, module.fk)["inexact_rows"] == 1  # and it misses its target

    aliased = {k: np.copy(v) for k, v in now.items()}
    aliased["Q"][1, int(np.argmax(aliased["valid"][1])), 0] += 2 * np.pi  # a 2 pi alias: the same set
    assert batch_sets.compare(now, aliased, module.fk)["set_differs"] == 0

    lost = {k: np.copy(v) for k, v in now.items()}
    lost["valid"][2, int(np.argmax(lost["valid"][2]))] = False  # a row lost: sets and marks differ
    out = batch_sets.compare(now, lost, module.fk)
    assert out["set_differs"] == 1 and out["marks_differ"] == 1
