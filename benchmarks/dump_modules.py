"""Write the generated module and the `ikc explain` text of every zoo robot (and a few variants) to a
folder, so two checkouts can be compared byte for byte: a refactoring that must not change the
compiler's behaviour (docs/design.md section 12) shows up as an empty `diff -r`.

    python benchmarks/dump_modules.py OUT_DIR [--configurations]   # then: diff -r OUT_A OUT_B

Cases: every zoo robot with its default target; the README's variants (panda with a free joint,
shadow_index position, shadow_thumb position + direction, puma560 orientation); jaco with the general
6R solver turned off (the 1-D search fallback); and two drawn general chains, TRRRRR (the 2-D search
fallback) and TTTTR (rank 4 of 5: refused with RedundantChainError, its text written as the case's
``.error.txt``; tests/test_steps.py turns the refusal off to keep the numerical fallback covered);
four zoo arms perturbed by 1e-6 of their size (snapped plans); with ``--configurations`` also the
configuration zoo's 126 joint strings in both geometries, seed 0 (``ikcompiler.configs``; a few
minutes).  Run it with the checkout to compare installed or on PYTHONPATH: it imports the
`ikcompiler` found first (and prints where).
"""

from __future__ import annotations

import sys
from pathlib import Path

# benchmarks/subproblems.py would shadow the package of that name when this folder is on the path
HERE = Path(__file__).resolve().parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != HERE]

VARIANTS = [
    ("panda", "pose", ("panda_joint7",)),
    ("shadow_index", "position", ()),
    ("shadow_thumb", "position+direction", ()),
    ("puma560", "orientation", ("j1", "j2", "j3")),
]


def cases(configurations: bool = False):
    from ikcompiler.configs import joint_strings, modular_chain, perturbed, random_chain
    from ikcompiler.inputs import load_robot
    from ikcompiler.inputs.zoo import zoo_names

    for name in zoo_names():
        yield name, (lambda n=name: load_robot(n)), "pose", (), True
    for name, target, free in VARIANTS:
        yield f"{name}_{target.replace('+', '_')}", (lambda n=name: load_robot(n)), target, free, True
    yield "jaco_search", (lambda: load_robot("jaco")), "pose", (), False
    for kinds in ("TRRRRR", "TTTTR"):  # the 2-D search fallback; a rank-deficient chain refused
        yield f"general_{kinds.lower()}", (lambda k=kinds: random_chain(k)), "pose", (), True
    for name in ("puma560", "ur5", "kr6_r700", "stanford"):  # calibrated: snapped plans (_PLAN_TWISTS)
        yield f"{name}_perturbed", (lambda n=name: perturbed(load_robot(n), 1e-6)), "pose", (), True
    if configurations:
        for geometry in ("modular", "general"):
            for kinds in joint_strings():
                load = lambda k=kinds, g=geometry: modular_chain(k, seed=0, geometry=g)  # noqa: E731
                yield f"config_{geometry}_{kinds}", load, "pose", (), True


def main(argv=None) -> int:
    import ikcompiler
    from ikcompiler import compiler
    from ikcompiler.errors import IkcError

    print(f"ikcompiler from {Path(ikcompiler.__file__).parent}")

    args = list(sys.argv[1:] if argv is None else argv)
    configurations = "--configurations" in args
    folders = [a for a in args if not a.startswith("--")]
    if len(folders) != 1 or "--help" in args or "-h" in args:
        print("usage: python benchmarks/dump_modules.py OUT_FOLDER [--configurations]  (diff -r two of them)")
        return 0 if "--help" in args or "-h" in args else 2
    out = Path(folders[0])
    out.mkdir(parents=True, exist_ok=True)
    for case, load, target, free, general6 in cases(configurations):
        compiler.USE_GENERAL6 = general6
        try:
            chain = load()
            plan = compiler.compile_plan(chain, target=target, free=free)
            (out / f"{case}.explain.txt").write_text(plan.explain() + "\n")
            (out / f"{case}.py").write_text(compiler.compile_source(chain, target=target, free=free))
            print(f"{case}: {plan.method}, {len(plan.steps)} steps")
        except IkcError as exc:
            (out / f"{case}.error.txt").write_text(f"{type(exc).__name__}: {exc}\n")
            print(f"{case}: {type(exc).__name__}")
        finally:
            compiler.USE_GENERAL6 = True
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
