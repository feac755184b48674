"""ikcompiler: compile a robot's inverse kinematics into a chain of canonical subproblems.

Pipeline (one sub-package each): ``inputs`` (URDF, DH, spec files, zoo) -> ``model`` (POE chain) ->
``geometry`` (axis relations) -> ``rules`` (POE rewriting) -> ``search`` (cheapest subproblem chain, a
plan) -> ``codegen`` (a Python solver module).  The CLI (``ikc``) is a thin layer over this API.
"""

from __future__ import annotations

from ikcompiler.errors import IkcError
from ikcompiler.model import Chain, Coupling, Joint

__all__ = ["Chain", "Coupling", "Joint", "IkcError", "compile_robot", "load_robot"]
__version__ = "0.1.0"


def load_robot(robot, *, base: str | None = None, tip: str | None = None) -> Chain:
    """Load a robot from a URDF path, a spec/DH file, or the name of a robot in ``robots/``."""
    from ikcompiler.inputs import load_robot as _load

    return _load(robot, base=base, tip=tip)


def compile_robot(robot, **options):
    """Compile a robot (a Chain, path or zoo name) into a solver module; see
    :func:`ikcompiler.compiler.compile_robot` for the options (base, tip, target, free, tol, out)."""
    from ikcompiler.compiler import compile_robot as _compile

    return _compile(robot, **options)
