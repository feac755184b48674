"""Size of the generated chains: module lines, Python and C chain lines, operations before/after CSE.

    python benchmarks/ir_size.py [ROBOT ...]        (default: puma560 ur5 kr6_r700)

Per robot: the generated module's lines; the Python chain's lines (``_fast_chain``) and the C's
(``ikc_chain`` and the alternative chain ``ikc_chain_alt``, as ``native_source`` prints them); the
operations written in the main chain (``ir.operation_count``: + - * / and negations, calls of
cos/sin/sqrt/atan2/max2, each statement once, not per loop pass) without and with common-subexpression
elimination (docs/design.md section 11).  A markdown table on stdout.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# Run as a script, this folder is first on sys.path: its subproblems.py would shadow the package
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != ROOT / "benchmarks"]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def measure(name: str) -> dict:
    from ikcompiler.codegen import csource, fastpath, ir, printers
    from ikcompiler.compiler import compile_robot

    module = compile_robot(name)
    row = {"robot": name, "module lines": module.__source__.count("\n")}
    if module._fast_chain is None:
        return row
    data = fastpath.ChainData.from_module(vars(module))
    plain, named = fastpath.build_program(data, cse=False), fastpath.build_program(data, cse=True)
    row["Python chain lines"] = printers.python_source(named).strip().count("\n") + 1
    source = csource.module_c_source(vars(module)) or ""
    start, end = source.find("static int ikc_chain("), source.find("static const int ikc_revolute_")
    row["C chain lines"] = source[start:end].count("\n") if start >= 0 else 0
    for label, program in (("before CSE", plain), ("after CSE", named)):
        ops = ir.operation_count(program)
        row[f"arith {label}"], row[f"calls {label}"] = ops["arith"], ops["calls"]
    return row


def main(argv: list[str]) -> int:
    robots = argv or ["puma560", "ur5", "kr6_r700"]
    rows = [measure(r) for r in robots]
    keys = list(dict.fromkeys(k for r in rows for k in r))
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for r in rows:
        print("| " + " | ".join(str(r.get(k, "-")) for k in keys) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
