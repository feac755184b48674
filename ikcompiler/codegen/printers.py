"""The two printers of the code IR (docs/design.md section 11, "Code IR"): Python and C.

Both print a :class:`~ikcompiler.codegen.ir.Program` tree for tree, so they compute the same thing in
the same order: Python with the fewest parentheses that keep the tree's grouping (``a - (b + c)``,
``-(a*b)``), C with every operation parenthesised.  Conventions of the printed code:

* Python: ``_fast_chain(m, goal, free=(), rep=0.0)`` on a backend ``m`` of :mod:`subproblems.fast`
  (``m.cos`` ...), kernels ``_fk.NAME(m, ...)``, a list of leaves ``(q..., error, defer)``;
* C: ``static int NAME(goal, fr, rep, Q, E, F)`` writing leaf ``n`` to ``Q[n*dof + j]``, ``E[n]``,
  ``F[n]`` and returning the leaf count, kernels ``ikc_NAME(args..., out_q, out_flags)`` of
  ``subproblems/fast_kernels.h``.
"""

from __future__ import annotations

import math

from ikcompiler.codegen import ir

# solution slots of each kernel of subproblems.fast (its outputs per slot come from the loop's targets)
KERNEL_SLOTS = {
    "plane_r": 2, "plane_t": 1, "dist_r": 2, "dist_t": 2, "slide3": 1, "turn_slide2": 1, "slide2_turn": 2,
    "point_r": 1,
    "point_rr_meet": 2, "point_rr_parallel": 2, "rot_r": 1, "rot_rr": 1, "rot_rrr": 2,
}
C_WIDTH = 100  # C lines are broken at spaces beyond this (the C must fit a Python module's 110 columns)

PYTHON_DOC = (
    '    """Every candidate of the chain above as straight-line arithmetic on backend ``m``: a list of\n'
    '    (joint values..., pose error, defer) over the solution slots of each step.  ``rep`` picks the\n'
    '    representative a step returns where its joint is free (a self-motion)."""\n'
)


class Untranslatable(Exception):
    """The program has a construct with no C counterpart (a reference solver)."""


# -- Python ---------------------------------------------------------------------------------------------

_PREC = {"+": 1, "-": 1, "*": 2, "/": 2}
_UNARY, _ATOM = 3, 4


def _py_number(x: float) -> str:
    return repr(float(x)) if x != 0.0 else "0.0"


def _prec(e) -> int:
    if isinstance(e, ir.BinOp):
        return _PREC[e.op]
    if isinstance(e, ir.Neg) or (isinstance(e, ir.Const) and e.value < 0):
        return _UNARY
    return _ATOM


def py_expr(e) -> str:
    if isinstance(e, ir.Const):
        return _py_number(e.value)
    if isinstance(e, ir.Name):
        return e.id
    if isinstance(e, ir.Free):
        return f"free[{e.index}]"
    if isinstance(e, ir.Call):
        return f"m.{e.fn}({', '.join(py_expr(a) for a in e.args)})"
    if isinstance(e, ir.Neg):
        inner = py_expr(e.operand)
        return "-" + (inner if _prec(e.operand) >= _ATOM else f"({inner})")
    p = _PREC[e.op]
    left = py_expr(e.left)
    if _prec(e.left) < p:
        left = f"({left})"
    right = py_expr(e.right)
    if _prec(e.right) <= p or _prec(e.right) == _UNARY:  # a - (b + c), a*(-b): the tree's grouping
        right = f"({right})"
    return f"{left} {e.op} {right}" if e.op in "+-" else f"{left}{e.op}{right}"


def _py_arg(a) -> str:
    if isinstance(a, tuple):
        return "(" + ", ".join(_py_arg(x) for x in a) + ("," if len(a) == 1 else "") + ")"
    return py_expr(a)


def _py_block(block, depth: int, lines: list) -> None:
    pad = "    " * depth
    for s in block:
        if isinstance(s, ir.Assign):
            lines.append(f"{pad}{s.name} = {py_expr(s.value)}")
        elif isinstance(s, ir.Loop):
            args = ", ".join(["m"] + [_py_arg(a) for a in s.args])
            lines.append(f"{pad}for {', '.join(s.outs + (s.flag,))} in _fk.{s.kernel}({args}):")
            _py_block(s.body, depth + 1, lines)
        elif isinstance(s, ir.ReferenceLoop):
            screws = ", ".join(_py_arg(x) for x in s.screws)
            fields = ", ".join(f"{k!r}: {_py_arg(v)}" for k, v in s.inputs)
            call = f"_fk.reference(m, {s.code!r}, ({screws},), {{{fields}}})"
            lines.append(f"{pad}for {', '.join(s.outs + (s.flag,))} in {call}:")
            _py_block(s.body, depth + 1, lines)
        else:
            err = py_expr(s.errors[0]) if len(s.errors) == 1 else (
                f"m.max2({', '.join(py_expr(x) for x in s.errors)})")
            defer = " | ".join(s.flags) if s.flags else "False"
            qs = ", ".join(py_expr(x) for x in s.q)
            lines.append(f"{pad}out.append(({qs}, {err}, {defer}))")


def python_source(program: ir.Program, name: str = "_fast_chain") -> str:
    """The program as ``def NAME(m, goal, free=(), rep=0.0)`` returning its list of leaves."""
    lines = [f"    {', '.join(program.goal)} = goal", "    out = []"]
    _py_block(program.body, 1, lines)
    head = f"\n\ndef {name}(m, goal, free=(), rep=0.0):\n" + PYTHON_DOC
    return head + "\n".join(lines) + "\n    return out\n"


# -- C --------------------------------------------------------------------------------------------------


def c_number(x: float) -> str:
    x = float(x)
    if math.isinf(x):
        return "HUGE_VAL" if x > 0 else "(-HUGE_VAL)"
    if not math.isfinite(x):
        raise Untranslatable(f"constant {x}")
    text = repr(x)
    text = text if any(ch in text for ch in ".en") else text + ".0"
    return f"({text})" if x < 0 else text


_C_CALLS = {"cos": "cos", "sin": "sin", "sqrt": "sqrt", "atan2": "atan2", "max2": "ikc_max2"}


def c_expr(e) -> str:
    if isinstance(e, ir.Const):
        return c_number(e.value)
    if isinstance(e, ir.Name):
        return e.id
    if isinstance(e, ir.Free):
        return f"fr[{e.index}]"
    if isinstance(e, ir.Call):
        return f"{_C_CALLS[e.fn]}({', '.join(c_expr(a) for a in e.args)})"
    if isinstance(e, ir.Neg):
        return f"(-{c_expr(e.operand)})"
    return f"({c_expr(e.left)} {e.op} {c_expr(e.right)})"


def _c_arg(a) -> str:
    if isinstance(a, tuple):
        return f"(const double[]){{{', '.join(c_expr(x) for x in ir.arg_exprs(a))}}}"
    return c_expr(a)


class _CPrinter:
    def __init__(self, dof: int):
        self.dof = dof
        self.lines: list[str] = []
        self.depth = 1
        self.leaves = 0
        self.slots = [1]  # product of the slots of the enclosing loops

    def emit(self, text: str) -> None:
        self.lines.append("    " * self.depth + text)

    def block(self, block) -> None:
        for s in block:
            if isinstance(s, ir.Assign):
                self.emit(f"const double {s.name} = {c_expr(s.value)};")
            elif isinstance(s, ir.Loop):
                self.loop(s)
            elif isinstance(s, ir.ReferenceLoop):
                raise Untranslatable(f"reference solver of {s.code}")
            else:
                self.leaf(s)

    def loop(self, s: ir.Loop) -> None:
        if s.kernel not in KERNEL_SLOTS:
            raise Untranslatable(f"kernel {s.kernel}")
        flag, outs, slots = s.flag, len(s.outs), KERNEL_SLOTS[s.kernel]
        args = [_c_arg(a) for a in s.args]
        self.emit("{")
        self.depth += 1
        self.emit(f"double {flag}_q[{slots * outs}];")
        self.emit(f"int {flag}_f[{slots}];")
        self.emit(f"ikc_{s.kernel}({', '.join(args + [f'{flag}_q', f'{flag}_f'])});")
        self.emit(f"for (int {flag}_k = 0; {flag}_k < {slots}; {flag}_k++) {{")
        self.depth += 1
        for j, name in enumerate(s.outs):
            self.emit(f"const double {name} = {flag}_q[{flag}_k * {outs} + {j}];")
        self.emit(f"const int {flag} = {flag}_f[{flag}_k];")
        self.slots.append(self.slots[-1] * slots)
        self.block(s.body)
        self.slots.pop()
        self.depth -= 1
        self.emit("}")
        self.depth -= 1
        self.emit("}")

    def leaf(self, s: ir.Leaf) -> None:
        if len(s.q) != self.dof:
            raise Untranslatable(f"a leaf of {len(s.q)} joint values, the robot has {self.dof}")
        for j, e in enumerate(s.q):
            self.emit(f"Q[n * {self.dof} + {j}] = {c_expr(e)};")
        err = c_expr(s.errors[0]) if len(s.errors) == 1 else (
            f"ikc_max2({', '.join(c_expr(x) for x in s.errors)})")
        self.emit(f"E[n] = {err};")
        flags = s.flags[0] if s.flags else "0"
        for f in s.flags[1:]:  # as Python groups ``f1 | f2 | f3``
            flags = f"({flags} | {f})"
        self.emit(f"F[n] = {flags};")
        self.emit("n++;")
        self.leaves += self.slots[-1]


def wrap(line: str, width: int = C_WIDTH) -> list[str]:
    """Break a long C line at spaces (C does not care where), continuation lines indented deeper."""
    if len(line) <= width:
        return [line]
    indent = len(line) - len(line.lstrip()) + 8
    out, current = [], line
    while len(current) > width:
        cut = current.rfind(" ", indent + 1, width)
        if cut <= indent:
            break
        out.append(current[:cut])
        current = " " * indent + current[cut + 1:]
    return out + [current]


def c_function(program: ir.Program, name: str, dof: int, *,
               storage: str = "static") -> tuple[list[str], int]:
    """(C lines of ``STORAGE int NAME(...)``, the most leaves it writes); raises :class:`Untranslatable`.
    ``storage``: ``static``, or with an attribute macro in front (``native.COLD``)."""
    pr = _CPrinter(dof)
    for i, g in enumerate(program.goal):
        pr.emit(f"const double {g} = goal[{i}];")
    pr.block(program.body)
    head = [
        f"{storage} int {name}(const double *goal, const double *fr, double rep, double *Q, double *E,",
        "                     int *F) {",
        "    int n = 0;",
        "    (void)fr;",
        "    (void)rep;",
    ]
    return head + [w for line in pr.lines for w in wrap(line)] + ["    return n;", "}", ""], pr.leaves
