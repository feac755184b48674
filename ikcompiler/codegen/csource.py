"""Translate a fast chain into C: the native backend of a generated module.

The fast chain (:mod:`ikcompiler.codegen.fastpath`) is a small, regular subset of Python: assignments
of arithmetic on floats, loops over the slots of a kernel of :mod:`subproblems.fast`, and one leaf per
candidate.  This module walks its syntax tree and writes the same computation as a C function
``ikc_chain``, expression for expression (every operation parenthesised as Python grouped it, so C
rounds the same way), calling the C port of the kernels (``subproblems/fast_kernels.h``).  The
module's settings (joint kinds, limits, tolerances) become an ``ikc_robot`` and three exported entry
points wrap the shared finish and driver (``subproblems/fast_finish.h``):

* ``ikc_solve_one(T, free, limits, q, res, ls, cont)``: one raw target; the solution count, -1 for
  the Python path, -2 for an invalid target; ``ikc_solve_exact(T, free, limits, q)`` the same with
  the exact solutions alone (``solve``);
* ``ikc_solve_many(n, goals, free, limits, q, res, ls, cont, count, threads)``: n checked 4x4 targets;
* ``ikc_leaves(goal12, free, Q, E, F)``: the raw leaves of one goal (tests compare them with Python).

Both chains take ``rep``, the representative of a self-motion the kernels return (the Python path
always uses 0); the C finish reruns the chain with other values when the representatives of 0 cannot
be completed inside the limits.

:func:`chain_c_source` returns None for a chain it cannot translate (a step that calls a reference
solver, which has no C port): such modules keep their Python fast path alone.
"""

from __future__ import annotations

import ast
import math

# slots of each kernel of subproblems.fast (its outputs per slot come from the loop's targets)
KERNEL_SLOTS = {
    "plane_r": 2, "plane_t": 1, "dist_r": 2, "dist_t": 2, "slide3": 1, "turn_slide2": 1, "point_r": 1,
    "point_rr_meet": 2, "point_rr_parallel": 2, "rot_r": 1, "rot_rr": 1, "rot_rrr": 2,
}
_MATH = {"cos": "cos", "sin": "sin", "sqrt": "sqrt", "atan2": "atan2"}
_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.BitOr: "|"}
TARGET_CODES = {"pose": 0, "position": 1, "orientation": 2}
WIDTH = 100  # the C is embedded in the Python module, whose lines ruff keeps under 110


class Untranslatable(Exception):
    """The chain has a construct with no C counterpart."""


def _number(x: float) -> str:
    x = float(x)
    if math.isinf(x):
        return "HUGE_VAL" if x > 0 else "(-HUGE_VAL)"
    if not math.isfinite(x):
        raise Untranslatable(f"constant {x}")
    text = repr(x)
    return text if any(ch in text for ch in ".en") else text + ".0"


class _Translator:
    def __init__(self, dof: int):
        self.dof = dof
        self.lines: list[str] = []
        self.depth = 1
        self.leaves = 0
        self.slots = [1]  # product of the slots of the enclosing loops

    def emit(self, text: str) -> None:
        self.lines.append("    " * self.depth + text)

    # -- expressions -------------------------------------------------------------------------------
    def expr(self, node) -> str:
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool):
                return "1" if node.value else "0"
            if isinstance(node.value, (int, float)):
                return _number(node.value)
        elif isinstance(node, ast.Name):
            return node.id
        elif isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) and node.value.id == "free":
            if isinstance(node.slice, ast.Constant) and isinstance(node.slice.value, int):
                return f"fr[{node.slice.value}]"
        elif isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
            return f"({self.expr(node.left)} {_BINOPS[type(node.op)]} {self.expr(node.right)})"
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            return f"(-{self.expr(node.operand)})"
        elif isinstance(node, ast.Call) and _backend_call(node):
            name = node.func.attr
            args = [self.expr(a) for a in node.args]
            if name in _MATH:
                return f"{_MATH[name]}({', '.join(args)})"
            if name == "max2":
                return f"ikc_max2({', '.join(args)})"
            if name == "maxabs":
                return f"ikc_maxabs({len(args)}, (const double[]){{{', '.join(args)}}})"
        raise Untranslatable(ast.dump(node)[:200])

    def argument(self, node) -> str:
        if isinstance(node, ast.Tuple):
            return f"(const double[]){{{', '.join(self.expr(e) for e in node.elts)}}}"
        return self.expr(node)

    # -- statements --------------------------------------------------------------------------------
    def statements(self, body) -> None:
        for node in body:
            self.statement(node)

    def statement(self, node) -> None:
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):
            return  # the docstring
        if isinstance(node, ast.Return):
            return
        if isinstance(node, ast.Assign) and len(node.targets) == 1:
            target, value = node.targets[0], node.value
            if isinstance(target, ast.Name) and target.id == "out":
                return
            if isinstance(target, ast.Tuple) and isinstance(value, ast.Name) and value.id == "goal":
                for i, name in enumerate(target.elts):
                    self.emit(f"const double {name.id} = goal[{i}];")
                return
            if isinstance(target, ast.Name):
                self.emit(f"const double {target.id} = {self.expr(value)};")
                return
        if isinstance(node, ast.For) and isinstance(node.target, ast.Tuple) and _kernel_call(node.iter):
            self.loop(node)
            return
        if (isinstance(node, ast.Expr) and isinstance(node.value, ast.Call)
                and isinstance(node.value.func, ast.Attribute) and node.value.func.attr == "append"):
            self.leaf(node.value.args[0])
            return
        raise Untranslatable(ast.dump(node)[:200])

    def loop(self, node) -> None:
        kernel = node.iter.func.attr
        if kernel not in KERNEL_SLOTS:
            raise Untranslatable(f"kernel {kernel}")
        names = [e.id for e in node.target.elts]
        outs, flag, slots = len(names) - 1, names[-1], KERNEL_SLOTS[kernel]
        args = [self.argument(a) for a in node.iter.args[1:]]
        self.emit("{")
        self.depth += 1
        self.emit(f"double {flag}_q[{slots * outs}];")
        self.emit(f"int {flag}_f[{slots}];")
        self.emit(f"ikc_{kernel}({', '.join(args + [f'{flag}_q', f'{flag}_f'])});")
        self.emit(f"for (int {flag}_k = 0; {flag}_k < {slots}; {flag}_k++) {{")
        self.depth += 1
        for j, name in enumerate(names[:-1]):
            self.emit(f"const double {name} = {flag}_q[{flag}_k * {outs} + {j}];")
        self.emit(f"const int {flag} = {flag}_f[{flag}_k];")
        self.slots.append(self.slots[-1] * slots)
        self.statements(node.body)
        self.slots.pop()
        self.depth -= 1
        self.emit("}")
        self.depth -= 1
        self.emit("}")

    def leaf(self, node) -> None:
        if not isinstance(node, ast.Tuple) or len(node.elts) != self.dof + 2:
            raise Untranslatable("leaf")
        for j, e in enumerate(node.elts[: self.dof]):
            self.emit(f"Q[n * {self.dof} + {j}] = {self.expr(e)};")
        self.emit(f"E[n] = {self.expr(node.elts[self.dof])};")
        self.emit(f"F[n] = {self.expr(node.elts[self.dof + 1])};")
        self.emit("n++;")
        self.leaves += self.slots[-1]


def _backend_call(node) -> bool:
    f = node.func
    return isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == "m"


def _kernel_call(node) -> bool:
    return (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
            and isinstance(node.func.value, ast.Name) and node.func.value.id == "_fk")


def _wrap(line: str) -> list[str]:
    """Break a long line at spaces (C does not care where), continuation lines indented deeper."""
    if len(line) <= WIDTH:
        return [line]
    indent = len(line) - len(line.lstrip()) + 8
    out, current = [], line
    while len(current) > WIDTH:
        cut = current.rfind(" ", indent + 1, WIDTH)
        if cut <= indent:
            break
        out.append(current[:cut])
        current = " " * indent + current[cut + 1:]
    return out + [current]


def _array(values, fmt) -> str:
    return "{" + ", ".join(fmt(v) for v in values) + "}"


def _translate(python_source: str, name: str, c_name: str, dof: int):
    """(C lines of function ``name`` of ``python_source`` as ``c_name``, its leaf count), or None."""
    tree = ast.parse(python_source)
    fn = next((n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name), None)
    if fn is None:
        return None
    tr = _Translator(dof)
    try:
        tr.statements(fn.body)
    except Untranslatable:
        return None
    head = [
        f"static int {c_name}(const double *goal, const double *fr, double rep, double *Q, double *E,",
        "                     int *F) {",
        "    int n = 0;",
        "    (void)fr;",
        "    (void)rep;",
    ]
    lines = head + [w for line in tr.lines for w in _wrap(line)] + ["    return n;", "}", ""]
    return lines, tr.leaves


def chain_c_source(python_source: str, *, kinds: str, lower, upper, free, target: str, scale: float,
                   tol: float, slots: int, twists, home, A, b, search: int = 0, grid: int = 0,
                   polish: int = 0, alternative: str | None = None, near_singular: float = 0.0) -> str | None:
    """C source of the chain ``python_source`` (the text of ``_fast_chain``), or None if untranslatable.

    ``kinds``, ``lower``, ``upper`` are the returned joints' types and limits (JOINT_NAMES order),
    ``free`` the positions of the free joints among them; ``twists`` (all joints, mimic ones too),
    ``home`` (4x4) and ``A``, ``b`` (all joint values = A q + b) describe the true robot for the
    Newton steps of the finish.  ``alternative``: the source of ``_fast_chain`` for the plan's
    alternative chain (the C finish runs it where the chain cannot settle a target), or None.
    ``search`` joints gridded over ``grid`` values each (a search plan:
    the chain takes their values after the free ones).  ``polish``: Newton steps on the true robot for
    every leaf of a snapped plan (the chain itself runs on the snapped robot); ``near_singular``: the
    weakest singular value below which such a leaf's target goes to the Python continuation.
    """
    if target not in TARGET_CODES:
        return None
    dof = len(kinds)
    main = _translate(python_source, "_fast_chain", "ikc_chain", dof)
    if main is None:
        return None
    alt = _translate(alternative, "_fast_chain", "ikc_chain_alt", dof) if alternative else None
    nall = len(twists)
    flat_home = [home[i][j] for i in range(3) for j in range(3)] + [home[i][3] for i in range(3)]
    robot = [
        f"static const int ikc_revolute_[{dof}] = {_array(kinds, lambda k: '1' if k == 'R' else '0')};",
        f"static const int ikc_free_[{dof}] = {_array(range(dof), lambda j: '1' if j in free else '0')};",
        f"static const double ikc_lower_[{dof}] = {_array(lower, _number)};",
        f"static const double ikc_upper_[{dof}] = {_array(upper, _number)};",
        f"static const double ikc_twists_[{6 * nall}] = {_array([x for t in twists for x in t], _number)};",
        f"static const double ikc_home_[12] = {_array(flat_home, _number)};",
        f"static const double ikc_A_[{nall * dof}] = {_array([x for row in A for x in row], _number)};",
        f"static const double ikc_b_[{nall}] = {_array(b, _number)};",
        f"static const ikc_robot ikc_this = {{{dof}, {len(free)}, {main[1]}, {slots},",
        f"    {TARGET_CODES[target]},",
        f"    ikc_revolute_, ikc_lower_, ikc_upper_, {_number(scale)}, {_number(tol)}, ikc_chain,",
        f"    {nall}, ikc_twists_, ikc_home_, ikc_A_, ikc_b_, ikc_free_, {search}, {grid},",
        f"    {polish}, {'ikc_chain_alt' if alt else 'NULL'}, {alt[1] if alt else 0},",
        f"    {_number(near_singular)}}};",
    ]
    head = [
        "/* The chain of this module in C (ikcompiler/codegen/csource.py): the same arithmetic as",
        " * _fast_chain, with the kernels and the finish of subproblems/fast_kernels.h, fast_finish.h. */",
    ]
    body = main[0] + (alt[0] if alt else [])
    tail = [
        *[w for line in robot for w in _wrap(line)],
        "",
        "int ikc_solve_one(const double *T, const double *fr, int limits, double *q, double *res, int *ls,",
        "                  int *cont) {",
        "    return ikc_one(&ikc_this, T, fr, limits, q, res, ls, cont);",
        "}",
        "",
        "int ikc_solve_exact(const double *T, const double *fr, int limits, double *q) {",
        "    return ikc_one_exact(&ikc_this, T, fr, limits, q);",
        "}",
        "",
        "void ikc_solve_many(int64_t n, const double *goals, const double *fr, int limits, double *q,",
        "                    double *res, int *ls, int *cont, int *count, int threads) {",
        "    ikc_many(&ikc_this, n, goals, fr, limits, q, res, ls, cont, count, threads);",
        "}",
        "",
        "int ikc_leaves(const double *goal, const double *fr, double *Q, double *E, int *F) {",
        "    return ikc_chain(goal, fr, 0.0, Q, E, F);",
        "}",
    ]
    return "\n".join(head + body + tail) + "\n"
