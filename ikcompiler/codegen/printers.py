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
    "plane_r": 2, "plane_t": 1, "dist_r": 2, "dist_t": 2, "slide1": 1, "slide3": 1, "turn_slide2": 1,
    "slide2_turn": 2, "point_r": 1,
    "point_rr_meet": 2, "point_rr_parallel": 2, "rot_r": 1, "rot_rr": 1, "rot_rrr": 2, "point_rrr": 4,
}
# kernels with a ``NAME_cs`` form (fast.py, fast_kernels.h) that also returns the cosine and sine of
# each output angle, from the quantities the angle is the atan2 or acos of: a chain reads them where it
# would call ``cos(out)`` and ``sin(out)`` (docs/design.md section 11, "cos and sin of kernel outputs")
KERNEL_TRIG = frozenset({"plane_r", "dist_r", "point_r", "point_rr_meet", "point_rr_parallel", "rot_r",
                         "rot_rr", "rot_rrr"})
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


def _trig_name(e, trig):
    """The name holding ``cos(x)`` / ``sin(x)`` of a kernel output ``x`` in scope, or None."""
    if trig and isinstance(e, ir.Call) and e.fn in ("cos", "sin") and isinstance(e.args[0], ir.Name):
        pair = trig.get(e.args[0].id)
        if pair is not None:
            return pair[0] if e.fn == "cos" else pair[1]
    return None


def py_expr(e, trig=None) -> str:
    """``e`` in Python; ``trig`` maps a kernel output's name to the names of its cosine and sine."""
    if isinstance(e, ir.Const):
        return _py_number(e.value)
    if isinstance(e, ir.Name):
        return e.id
    if isinstance(e, ir.Free):
        return f"free[{e.index}]"
    if isinstance(e, ir.Call):
        return _trig_name(e, trig) or f"m.{e.fn}({', '.join(py_expr(a, trig) for a in e.args)})"
    if isinstance(e, ir.Neg):
        inner = py_expr(e.operand, trig)
        return "-" + (inner if _prec(e.operand) >= _ATOM else f"({inner})")
    p = _PREC[e.op]
    left = py_expr(e.left, trig)
    if _prec(e.left) < p:
        left = f"({left})"
    right = py_expr(e.right, trig)
    if _prec(e.right) <= p or _prec(e.right) == _UNARY:  # a - (b + c), a*(-b): the tree's grouping
        right = f"({right})"
    return f"{left} {e.op} {right}" if e.op in "+-" else f"{left}{e.op}{right}"


def _py_arg(a, trig=None) -> str:
    if isinstance(a, tuple):
        return "(" + ", ".join(_py_arg(x, trig) for x in a) + ("," if len(a) == 1 else "") + ")"
    return py_expr(a, trig)


def trig_names(s: ir.Loop) -> dict | None:
    """For a kernel loop whose body reads cos or sin of an output, and whose kernel has a ``_cs`` form:
    each output's (cosine, sine) names (``<flag>_c<j>``, ``<flag>_s<j>``); else None."""
    if s.kernel not in KERNEL_TRIG or not _trig_read(s.body, set(s.outs)):
        return None
    return {name: (f"{s.flag}_c{j}", f"{s.flag}_s{j}") for j, name in enumerate(s.outs)}


def _py_block(block, depth: int, lines: list, trig: dict) -> None:
    pad = "    " * depth
    for s in block:
        if isinstance(s, ir.Assign):
            lines.append(f"{pad}{s.name} = {py_expr(s.value, trig)}")
        elif isinstance(s, ir.Loop):
            args = ", ".join(["m"] + [_py_arg(a, trig) for a in s.args])
            pairs = trig_names(s)
            if pairs:
                names = s.outs + (s.flag,) + tuple(x for name in s.outs for x in pairs[name])
                lines.append(f"{pad}for {', '.join(names)} in _fk.{s.kernel}_cs({args}):")
            else:
                lines.append(f"{pad}for {', '.join(s.outs + (s.flag,))} in _fk.{s.kernel}({args}):")
            _py_block(s.body, depth + 1, lines, {**trig, **(pairs or {})})
        elif isinstance(s, ir.ReferenceLoop):
            screws = ", ".join(_py_arg(x, trig) for x in s.screws)
            fields = ", ".join(f"{k!r}: {_py_arg(v, trig)}" for k, v in s.inputs)
            call = f"_fk.reference(m, {s.code!r}, ({screws},), {{{fields}}})"
            lines.append(f"{pad}for {', '.join(s.outs + (s.flag,))} in {call}:")
            _py_block(s.body, depth + 1, lines, trig)
        else:
            err = py_expr(s.errors[0], trig) if len(s.errors) == 1 else (
                f"m.max2({', '.join(py_expr(x, trig) for x in s.errors)})")
            defer = " | ".join(s.flags) if s.flags else "False"
            qs = ", ".join(py_expr(x, trig) for x in s.q)
            lines.append(f"{pad}out.append(({qs}, {err}, {defer}))")


def python_source(program: ir.Program, name: str = "_fast_chain") -> str:
    """The program as ``def NAME(m, goal, free=(), rep=0.0)`` returning its list of leaves."""
    lines = [f"    {', '.join(program.goal)} = goal", "    out = []"]
    _py_block(program.body, 1, lines, {})
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


def c_expr(e, trig=None) -> str:
    """``e`` in C; ``trig`` maps a kernel output's name to the names of its cosine and sine."""
    if isinstance(e, ir.Const):
        return c_number(e.value)
    if isinstance(e, ir.Name):
        return e.id
    if isinstance(e, ir.Free):
        return f"fr[{e.index}]"
    if isinstance(e, ir.Call):
        name = _trig_name(e, trig)
        if name is not None:
            return name
        return f"{_C_CALLS[e.fn]}({', '.join(c_expr(a, trig) for a in e.args)})"
    if isinstance(e, ir.Neg):
        return f"(-{c_expr(e.operand, trig)})"
    return f"({c_expr(e.left, trig)} {e.op} {c_expr(e.right, trig)})"


def _c_arg(a, trig=None) -> str:
    if isinstance(a, tuple):
        return f"(const double[]){{{', '.join(c_expr(x, trig) for x in ir.arg_exprs(a))}}}"
    return c_expr(a, trig)


def _trig_read(block, names: set) -> bool:
    """Whether ``cos`` or ``sin`` of one of ``names`` is read anywhere in ``block`` (nested too)."""
    def reads(e) -> bool:
        if isinstance(e, ir.Call) and e.fn in ("cos", "sin") and isinstance(e.args[0], ir.Name):
            if e.args[0].id in names:
                return True
        return any(reads(c) for c in ir.children(e))

    for s in block:
        if any(reads(e) for e in ir.statement_exprs(s)):
            return True
        if ir.body_of(s) is not None and _trig_read(ir.body_of(s), names):
            return True
    return False


class _CPrinter:
    def __init__(self, dof: int):
        self.dof = dof
        self.lines: list[str] = []
        self.depth = 1
        self.leaves = 0
        self.slots = [1]  # product of the slots of the enclosing loops
        self.trig: dict = {}  # kernel output in scope -> the names of its cosine and sine

    def emit(self, text: str) -> None:
        self.lines.append("    " * self.depth + text)

    def block(self, block) -> None:
        for s in block:
            if isinstance(s, ir.Assign):
                self.emit(f"const double {s.name} = {c_expr(s.value, self.trig)};")
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
        args = [_c_arg(a, self.trig) for a in s.args]
        trig = trig_names(s)
        self.emit("{")
        self.depth += 1
        self.emit(f"double {flag}_q[{slots * outs}];")
        self.emit(f"int {flag}_f[{slots}];")
        if trig:  # the kernel also writes cos and sin of each output: the chain reads them
            self.emit(f"double {flag}_cs[{2 * slots * outs}];")
            self.emit(f"ikc_{s.kernel}_cs({', '.join(args + [f'{flag}_q', f'{flag}_f', f'{flag}_cs'])});")
        else:
            self.emit(f"ikc_{s.kernel}({', '.join(args + [f'{flag}_q', f'{flag}_f'])});")
        self.emit(f"for (int {flag}_k = 0; {flag}_k < {slots}; {flag}_k++) {{")
        self.depth += 1
        for j, name in enumerate(s.outs):
            self.emit(f"const double {name} = {flag}_q[{flag}_k * {outs} + {j}];")
            if trig:
                cos_name, sin_name = trig[name]
                self.emit(f"const double {cos_name} = {flag}_cs[{flag}_k * {2 * outs} + {2 * j}];")
                self.emit(f"const double {sin_name} = {flag}_cs[{flag}_k * {2 * outs} + {2 * j + 1}];")
                self.trig[name] = trig[name]
        self.emit(f"const int {flag} = {flag}_f[{flag}_k];")
        self.loop_body(s, slots)

    def loop_body(self, s: ir.Loop, slots: int) -> None:
        """A slot loop's body and its closing braces (the scalar and the lane printer alike)."""
        self.slots.append(self.slots[-1] * slots)
        self.block(s.body)
        for name in s.outs:
            self.trig.pop(name, None)
        self.slots.pop()
        self.depth -= 1
        self.emit("}")
        self.depth -= 1
        self.emit("}")

    def leaf(self, s: ir.Leaf) -> None:
        if len(s.q) != self.dof:
            raise Untranslatable(f"a leaf of {len(s.q)} joint values, the robot has {self.dof}")
        for j, e in enumerate(s.q):
            self.emit(f"Q[n * {self.dof} + {j}] = {c_expr(e, self.trig)};")
        err = c_expr(s.errors[0], self.trig) if len(s.errors) == 1 else (
            f"ikc_max2({', '.join(c_expr(x, self.trig) for x in s.errors)})")
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


# -- C, four poses a call (the block chain of a batch) ----------------------------------------------------
#
# The same tree printed a second time with every value a vector of 4 lanes, one pose a lane
# (``ikc_v4`` of subproblems/lane_kernels.h; docs/design.md section 14, "SIMD over poses"): every
# solution slot computed in every lane, each leaf's flags lane by lane.  The lane kernels compute only
# the regular branch (a lane where the scalar chain takes another is solved again by it), so they take
# no ``rep``: the arguments kept of each kernel, the leading ones.
LANE_KERNEL_ARGS = {"plane_r": 5, "point_rr_parallel": 6, "rot_rrr": 4}
_LANE_CALLS = {"cos": "ikc_v_cos", "sin": "ikc_v_sin", "sqrt": "ikc_v_sqrt", "atan2": "ikc_v_atan2",
               "max2": "ikc_v_max2"}


def _lane_varies(e) -> bool:
    """Whether ``e`` reads a name (a lane value); else it is one number for every lane."""
    if isinstance(e, ir.Name):
        return True
    if isinstance(e, ir.Free):
        raise Untranslatable("a free joint's value (the block chain takes poses alone)")
    return any(_lane_varies(c) for c in ir.children(e))


def lane_expr(e, trig=None) -> str:
    """``e`` as a 4-lane vector expression: a constant subtree is printed as the scalar C expression
    (a vector operation with a scalar operand applies it to every lane) and broadcast where it stands
    alone (``IKC_V``)."""
    if not _lane_varies(e):
        return f"IKC_V({c_expr(e)})"
    return _lane(e, trig)


def _lane(e, trig) -> str:
    if not _lane_varies(e):
        return c_expr(e)
    if isinstance(e, ir.Name):
        return e.id
    if isinstance(e, ir.Call):
        name = _trig_name(e, trig)
        if name is not None:
            return name
        return f"{_LANE_CALLS[e.fn]}({', '.join(lane_expr(a, trig) for a in e.args)})"
    if isinstance(e, ir.Neg):
        return f"(-{_lane(e.operand, trig)})"
    return f"({_lane(e.left, trig)} {e.op} {_lane(e.right, trig)})"


def _lane_arg(a, trig) -> str:
    if isinstance(a, tuple):
        return f"(const ikc_v4[]){{{', '.join(lane_expr(x, trig) for x in ir.arg_exprs(a))}}}"
    return lane_expr(a, trig)


class _LanePrinter(_CPrinter):
    """:class:`_CPrinter`'s walk with lane types, lane kernels and lane leaves."""

    def block(self, block) -> None:
        for s in block:
            if isinstance(s, ir.Assign):
                self.emit(f"const ikc_v4 {s.name} = {lane_expr(s.value, self.trig)};")
            elif isinstance(s, ir.Loop):
                self.loop(s)
            elif isinstance(s, ir.ReferenceLoop):
                raise Untranslatable(f"reference solver of {s.code}")
            else:
                self.leaf(s)

    def loop(self, s: ir.Loop) -> None:
        if s.kernel not in LANE_KERNEL_ARGS:
            raise Untranslatable(f"kernel {s.kernel} has no lane form")
        flag, outs, slots = s.flag, len(s.outs), KERNEL_SLOTS[s.kernel]
        args = [_lane_arg(a, self.trig) for a in s.args[:LANE_KERNEL_ARGS[s.kernel]]]
        self.emit("{")
        self.depth += 1
        self.emit(f"ikc_v4 {flag}_q[{slots * outs}], {flag}_cs[{2 * slots * outs}];")
        self.emit(f"ikc_m4 {flag}_f[{slots}];")
        self.emit(f"ikc_v_{s.kernel}_cs({', '.join(args + [f'{flag}_q', f'{flag}_f', f'{flag}_cs'])});")
        self.emit(f"for (int {flag}_k = 0; {flag}_k < {slots}; {flag}_k++) {{")
        self.depth += 1
        trig = {name: (f"{flag}_c{j}", f"{flag}_s{j}") for j, name in enumerate(s.outs)}
        for j, name in enumerate(s.outs):
            cos_name, sin_name = trig[name]
            self.emit(f"const ikc_v4 {name} = {flag}_q[{flag}_k * {outs} + {j}];")
            self.emit(f"const ikc_v4 {cos_name} = {flag}_cs[{flag}_k * {2 * outs} + {2 * j}];")
            self.emit(f"const ikc_v4 {sin_name} = {flag}_cs[{flag}_k * {2 * outs} + {2 * j + 1}];")
            self.emit(f"(void){cos_name};")
            self.emit(f"(void){sin_name};")
            self.trig[name] = trig[name]
        self.emit(f"const ikc_m4 {flag} = {flag}_f[{flag}_k];")
        self.loop_body(s, slots)

    def leaf(self, s: ir.Leaf) -> None:
        if len(s.q) != self.dof:
            raise Untranslatable(f"a leaf of {len(s.q)} joint values, the robot has {self.dof}")
        for j, e in enumerate(s.q):
            self.emit(f"ikc_v_store(Q + 4 * (n * {self.dof} + {j}), {lane_expr(e, self.trig)});")
        err = lane_expr(s.errors[0], self.trig) if len(s.errors) == 1 else (
            f"ikc_v_max2({', '.join(lane_expr(x, self.trig) for x in s.errors)})")
        self.emit(f"ikc_v_store(E + 4 * n, {err});")
        flags = s.flags[0] if s.flags else "((ikc_m4){0, 0, 0, 0})"
        for f in s.flags[1:]:
            flags = f"({flags} | {f})"
        self.emit(f"ikc_m_store(F + 4 * n, {flags});")
        self.emit("n++;")
        self.leaves += self.slots[-1]


def c_lane_function(program: ir.Program, name: str, dof: int) -> tuple[list[str], int]:
    """(C lines of ``static int NAME(G, Q, E, F)``, the most leaves it writes): the chain for 4 poses,
    goal entry ``i`` of lane ``l`` at ``G[4*i + l]``, leaf ``n``'s joint ``j`` at ``Q[4*(n*dof + j) + l]``,
    its error at ``E[4*n + l]`` and its flags at ``F[4*n + l]`` (``IKC_TANGENT_ROOT`` as the scalar
    chain's; ``IKC_IRREGULAR``: the lane is solved again by the scalar chain); raises
    :class:`Untranslatable`."""
    pr = _LanePrinter(dof)
    for i, g in enumerate(program.goal):
        pr.emit(f"const ikc_v4 {g} = ikc_v_load(G + 4 * {i});")
    pr.emit("const ikc_v4 rep = IKC_V(0.0);")
    pr.emit("(void)rep;")
    pr.block(program.body)
    head = [f"static int {name}(const double *G, double *Q, double *E, int64_t *F) {{", "    int n = 0;"]
    return head + [w for line in pr.lines for w in wrap(line)] + ["    return n;", "}", ""], pr.leaves
