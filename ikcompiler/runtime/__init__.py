"""The runtime that every generated solver module calls (docs/design.md section 6).

A generated module holds its robot's data, its derivation and its chain (the fast chain in Python,
its C translation where built, the reference steps); it builds one :class:`Solver` from its namespace
and binds the public API (``solve``, ``solve_info``, ``solve_batch``, ...) to it.  Dispatch, target
checks, the finish glue and the batch driver live here, so a fix to them needs no recompile.

Modules, one job each: ``robot`` (the module's data, typed), ``targets`` (validation of targets and
free values), ``reference`` (the reference runtime's candidates and their check on the true robot),
``fastchain`` (the fast chain on arrays and the search on it, within a memory budget), ``dispatch``
(which path a pose takes, each at most once; the batch driver), ``selection`` (aliases, seed order,
``solve_info``'s extras).
"""

from __future__ import annotations

from ikcompiler.runtime.dispatch import Solver
from ikcompiler.runtime.robot import Robot

__all__ = ["Robot", "Solver"]

