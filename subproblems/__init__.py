"""Canonical inverse-kinematics subproblems of the product-of-exponentials equation.

Three classes (seed 003, Table 1; docs/design.md section 4), written with R (revolute) and T (prismatic,
"translational") joints in chain order:

* class I   ``prod exp(xi_i th_i) = T``                      S1-R ... S1-TTT
* class II  ``prod exp(xi_i th_i) p = q``                    S2-R ... S2-TTT
* class III ``|| prod exp(xi_i th_i) p - q || = d``          S3-R ... S3-TT

plus the extras the decomposition needs.  Every solver returns **all** solutions.  Use
:func:`solve` for one instance and :func:`solve_batch` for N instances::

    from subproblems import solve
    r = solve("S2-TRR", twists=[xi1, xi2, xi3], p=p, q=q)
    r.q, r.ls, r.continuum

The package is usable on its own: it needs numpy only.
"""

from __future__ import annotations

import importlib
import pkgutil

from subproblems.core import (
    BatchResult,
    Result,
    Solution,
    SubproblemError,
    SubproblemInputError,
    codes,
    max_solutions,
    register,
    solve,
    solve_batch,
)

__all__ = [
    "BatchResult",
    "Result",
    "Solution",
    "SubproblemError",
    "SubproblemInputError",
    "codes",
    "max_solutions",
    "register",
    "solve",
    "solve_batch",
]

# Every public module other than the infrastructure holds solvers that register themselves on import.
_INFRASTRUCTURE = {"angles", "core", "screw", "tolerances"}
for _mod in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    if not _mod.name.startswith("_") and _mod.name not in _INFRASTRUCTURE:
        importlib.import_module(f"{__name__}.{_mod.name}")
