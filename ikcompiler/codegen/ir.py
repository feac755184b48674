"""A small typed code IR for the fast chain (docs/design.md section 11, "Code IR").

The fast chain of a plan is straight-line arithmetic inside nested loops over the solution slots of
the subproblem kernels.  :mod:`ikcompiler.codegen.fastpath` builds it as this IR;
:mod:`ikcompiler.codegen.printers` prints it as Python (``_fast_chain``) and as C (``ikc_chain``).

Expressions are immutable trees (hashable, compared by structure): :class:`Const`, :class:`Name`,
:class:`Free` (a free joint's value), :class:`BinOp` (``+ - * /``), :class:`Neg` and :class:`Call`
(``cos sin sqrt atan2`` and ``max2``).  Statements: :class:`Assign`, :class:`Loop` (a kernel call whose
solution slots bind the loop's outputs and a flag), :class:`ReferenceLoop` (a subproblem without a
kernel: its reference solver, Python only) and :class:`Leaf` (one candidate).

A tree is evaluated exactly as it is built: the printers parenthesise as the tree groups, so Python
and C round the same way.  The rewrites here keep every value bit for bit: :func:`fold` folds
constant operations and exact identities only (``x*1``, ``--x``, ``x - 0``), :func:`eliminate_common`
reuses the name of an expression computed before and gives a repeated subexpression one name,
:func:`without_dead_code` drops assignments nobody reads.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

BINARY = ("+", "-", "*", "/")
FUNCTIONS = {"cos": 1, "sin": 1, "sqrt": 1, "atan2": 2, "max2": 2}  # name -> number of arguments


@dataclass(frozen=True)
class Const:
    value: float

    def __post_init__(self):
        if not math.isfinite(self.value):
            raise ValueError(f"IR constant {self.value!r} is not finite")
        # one zero: -0.0 and 0.0 compare equal and would otherwise share a CSE entry
        object.__setattr__(self, "value", float(self.value) + 0.0)


@dataclass(frozen=True)
class Name:
    id: str


@dataclass(frozen=True)
class Free:
    """The value of free (or searched) joint number ``index`` among the chain's inputs."""

    index: int


class _Hashed:
    """Compound nodes keep their hash: CSE hashes every subtree, and a tree's hash needs its children's."""

    def __hash__(self):
        return self._hash

    def _keep_hash(self, *fields):
        object.__setattr__(self, "_hash", hash((type(self).__name__,) + fields))


@dataclass(frozen=True)
class BinOp(_Hashed):
    op: str
    left: Expr
    right: Expr

    def __post_init__(self):
        if self.op not in BINARY:
            raise ValueError(f"IR operator {self.op!r} is not one of {BINARY}")
        self._keep_hash(self.op, self.left, self.right)


@dataclass(frozen=True)
class Neg(_Hashed):
    operand: Expr

    def __post_init__(self):
        self._keep_hash(self.operand)


@dataclass(frozen=True)
class Call(_Hashed):
    fn: str
    args: tuple

    def __post_init__(self):
        if FUNCTIONS.get(self.fn) != len(self.args):
            raise ValueError(f"IR call {self.fn} with {len(self.args)} arguments")
        self._keep_hash(self.fn, self.args)


Expr = Const | Name | Free | BinOp | Neg | Call


def is_expr(v) -> bool:
    """``v`` is an IR expression (not a plain number)."""
    return isinstance(v, Expr)
Arg = Expr | tuple  # a kernel argument: a scalar or a tuple of scalars (a vector, a matrix)


@dataclass
class Assign:
    name: str
    value: Expr


@dataclass
class Loop:
    """``for outs..., flag in kernel(args)``: one pass per solution slot of ``kernel``."""

    kernel: str
    args: tuple  # of Arg
    outs: tuple  # of str
    flag: str
    body: list


@dataclass
class ReferenceLoop:
    """A step without a kernel: the reference solver of subproblem ``code`` (Python only)."""

    code: str
    screws: tuple  # of tuples of Expr, one screw (v, w) per unknown
    inputs: tuple  # of (key, Arg)
    outs: tuple
    flag: str
    body: list


@dataclass
class Leaf:
    """One candidate: joint values, its pose error (the largest of ``errors``), the OR of ``flags``."""

    q: tuple  # of Expr
    errors: tuple  # of Expr
    flags: tuple  # of str


Stmt = Assign | Loop | ReferenceLoop | Leaf


@dataclass
class Program:
    """The chain: unpack the 12 goal entries into ``goal``, then ``body``."""

    goal: tuple  # of str
    body: list


# -- building, with folding ---------------------------------------------------------------------------


def const(x) -> Expr:
    return x if is_expr(x) else Const(float(x))


def binop(op: str, a, b) -> Expr:
    return fold(BinOp(op, const(a), const(b)))


def neg(a) -> Expr:
    return fold(Neg(const(a)))


def call(fn: str, *args) -> Expr:
    return fold(Call(fn, tuple(const(a) for a in args)))


_APPLY = {"+": lambda a, b: a + b, "-": lambda a, b: a - b, "*": lambda a, b: a * b,
          "/": lambda a, b: a / b if b != 0.0 else math.nan}


def fold(e: Expr) -> Expr:
    """One node folded: constant operands computed now (the same IEEE operation the chain would do:
    + - * / and sqrt), and the identities that hold bit for bit (``x*1 = 1*x = x``, ``x/1 = x``,
    ``x - 0 = x``, ``--x = x``).  ``x + 0`` is not folded (-0 + 0 is +0), nor ``x*0`` (NaN, infinity)."""
    if isinstance(e, BinOp):
        a, b = e.left, e.right
        if isinstance(a, Const) and isinstance(b, Const):
            value = _APPLY[e.op](a.value, b.value)
            return Const(value) if math.isfinite(value) else e
        if e.op in ("*", "/") and isinstance(b, Const) and b.value == 1.0:
            return a
        if e.op == "*" and isinstance(a, Const) and a.value == 1.0:
            return b
        if e.op == "-" and isinstance(b, Const) and b.value == 0.0:
            return a
        return e
    if isinstance(e, Neg):
        if isinstance(e.operand, Const):
            return Const(-e.operand.value)
        if isinstance(e.operand, Neg):
            return e.operand.operand
        return e
    if isinstance(e, Call) and e.fn in ("sqrt", "max2") and all(isinstance(a, Const) for a in e.args):
        # correctly rounded everywhere; cos, sin, atan2 are not folded: libm and numpy may differ by
        # an ulp, and the chain must compute what each backend computes
        values = [a.value for a in e.args]
        if e.fn == "sqrt":
            return Const(math.sqrt(values[0])) if values[0] >= 0.0 else e
        return Const(max(values))
    return e


def _rebuild(e: Expr, leaf) -> Expr:
    """``e`` with ``leaf`` applied to every Name and each node refolded."""
    if isinstance(e, Name):
        return leaf(e)
    if isinstance(e, BinOp):
        return fold(BinOp(e.op, _rebuild(e.left, leaf), _rebuild(e.right, leaf)))
    if isinstance(e, Neg):
        return fold(Neg(_rebuild(e.operand, leaf)))
    if isinstance(e, Call):
        return fold(Call(e.fn, tuple(_rebuild(a, leaf) for a in e.args)))
    return e


# -- walking ------------------------------------------------------------------------------------------


def children(e: Expr) -> tuple:
    if isinstance(e, BinOp):
        return (e.left, e.right)
    if isinstance(e, Neg):
        return (e.operand,)
    if isinstance(e, Call):
        return e.args
    return ()


def compound(e) -> bool:
    return isinstance(e, (BinOp, Neg, Call))


def arg_exprs(arg: Arg):
    """The scalar expressions of a kernel argument."""
    if isinstance(arg, tuple):
        for x in arg:
            yield from arg_exprs(x)
    else:
        yield arg


def map_arg(arg: Arg, fn) -> Arg:
    return tuple(map_arg(x, fn) for x in arg) if isinstance(arg, tuple) else fn(arg)


def statement_exprs(s: Stmt):
    """Every top-level expression a statement reads (not its body's)."""
    if isinstance(s, Assign):
        yield s.value
    elif isinstance(s, Loop):
        for a in s.args:
            yield from arg_exprs(a)
    elif isinstance(s, ReferenceLoop):
        for a in s.screws:
            yield from arg_exprs(a)
        for _, a in s.inputs:
            yield from arg_exprs(a)
    elif isinstance(s, Leaf):
        yield from s.q
        yield from s.errors
        yield from (Name(f) for f in s.flags)


def map_statement(s: Stmt, fn) -> Stmt:
    """A copy of ``s`` (body shared) with ``fn`` applied to each top-level expression."""
    if isinstance(s, Assign):
        return Assign(s.name, fn(s.value))
    if isinstance(s, Loop):
        return Loop(s.kernel, tuple(map_arg(a, fn) for a in s.args), s.outs, s.flag, s.body)
    if isinstance(s, ReferenceLoop):
        return ReferenceLoop(s.code, tuple(map_arg(a, fn) for a in s.screws),
                             tuple((k, map_arg(a, fn)) for k, a in s.inputs), s.outs, s.flag, s.body)
    return Leaf(tuple(fn(x) for x in s.q), tuple(fn(x) for x in s.errors), s.flags)


def body_of(s: Stmt):
    return s.body if isinstance(s, (Loop, ReferenceLoop)) else None


def names_read(e: Expr, into: dict) -> None:
    stack = [e]
    while stack:
        x = stack.pop()
        if isinstance(x, Name):
            into[x.id] = into.get(x.id, 0) + 1
        else:
            stack.extend(children(x))


# -- rewrites -----------------------------------------------------------------------------------------


def without_dead_code(program: Program) -> Program:
    """Drop assignments whose name is never read (the builder computes some axis points eagerly)."""
    body = program.body
    while True:
        reads: dict = {}
        _count_reads(body, reads)
        new = _prune(body, reads)
        if _size(new) == _size(body):
            return Program(program.goal, new)
        body = new


def _count_reads(block, reads: dict) -> None:
    for s in block:
        for e in statement_exprs(s):
            names_read(e, reads)
        if body_of(s) is not None:
            _count_reads(body_of(s), reads)


def _prune(block, reads: dict) -> list:
    kept = []
    for s in block:
        if isinstance(s, Assign) and s.name not in reads:
            continue
        if body_of(s) is not None:
            s = _with_body(s, _prune(body_of(s), reads))
        kept.append(s)
    return kept


def _size(block) -> int:
    return sum(1 + (_size(body_of(s)) if body_of(s) is not None else 0) for s in block)


def _with_body(s, body):
    if isinstance(s, Loop):
        return Loop(s.kernel, s.args, s.outs, s.flag, body)
    return ReferenceLoop(s.code, s.screws, s.inputs, s.outs, s.flag, body)


def eliminate_common(program: Program, prefix: str = "x") -> Program:
    """Common-subexpression elimination that keeps every value bit for bit.

    1. Value numbering along the loop nest: an assignment whose (rewritten) value was computed before
       in an enclosing or the same block reuses that name; a copy (``a = b``, ``a = 0.5``) is
       propagated.  2. Every compound subexpression still written twice or more (counted on the
       expression DAG: a tree inside one repeated tree counts once) gets a name of its own (``prefix``
       and a number), assigned in the innermost block that holds every use, before the first statement
       that uses it; then pass 1 again drops the copies this leaves.  Trees are only replaced by names
       of equal trees, so the arithmetic, and its rounding, is unchanged."""
    body = _number_values(program.body, {}, {})
    body = _name_repeats(body, prefix)
    return Program(program.goal, _number_values(body, {}, {}))


def _number_values(block, available: dict, alias: dict, negated: dict | None = None) -> list:
    """Pass 1 of :func:`eliminate_common` on ``block``; ``available`` maps trees to names in scope,
    ``alias`` names to the value they copy, ``negated`` names ``n = -y`` to ``y``."""
    negated = {} if negated is None else negated
    available, out = dict(available), []

    def rename(name: Name) -> Expr:
        return alias.get(name.id, name)

    def rewrite(e: Expr) -> Expr:
        e = _rebuild(e, rename)
        if isinstance(e, Neg) and isinstance(e.operand, Name) and e.operand.id in negated:
            return negated[e.operand.id]  # -(n) where n = -y: y itself, bit for bit
        return _replace_known(e, available)

    for s in block:
        s = map_statement(s, rewrite)
        if isinstance(s, Assign):
            if not compound(s.value):
                alias[s.name] = s.value  # a copy or a constant: propagate it
                continue
            available[s.value] = Name(s.name)
            if isinstance(s.value, Neg):
                negated[s.name] = s.value.operand
        if body_of(s) is not None:
            s = _with_body(s, _number_values(body_of(s), available, alias, negated))
        out.append(s)
    return out


def _replace_known(e: Expr, available: dict) -> Expr:
    """``e`` with every subtree that some name in scope holds replaced by that name (largest first)."""
    if not compound(e):
        return e
    if e in available:
        return available[e]
    if isinstance(e, BinOp):
        return BinOp(e.op, _replace_known(e.left, available), _replace_known(e.right, available))
    if isinstance(e, Neg):
        return Neg(_replace_known(e.operand, available))
    return Call(e.fn, tuple(_replace_known(a, available) for a in e.args))


def _name_repeats(body, prefix):
    """Pass 2 of :func:`eliminate_common`."""
    paths: dict = {}  # tree -> statement paths (indices through the loop nest) of every occurrence
    refs: dict = {}  # tree -> references on the DAG (distinct parents, plus each top-level use)
    size: dict = {}

    def occurrences(e, path):
        if compound(e):
            paths.setdefault(e, []).append(path)
            for c in children(e):
                occurrences(c, path)

    def dag(e):
        if not compound(e):
            return
        refs[e] = refs.get(e, 0) + 1
        if refs[e] == 1:  # a tree's children are counted once, however often the tree occurs
            for c in children(e):
                dag(c)
            size[e] = 1 + sum(size.get(c, 0) for c in children(e))

    def walk(block, path):
        for i, s in enumerate(block):
            here = path + (i,)
            for e in statement_exprs(s):
                occurrences(e, here)
                dag(e)
            if body_of(s) is not None:
                walk(body_of(s), here)

    walk(body, ())
    repeated = sorted((e for e, n in refs.items() if n >= 2), key=lambda e: (size[e], min(paths[e])))
    if not repeated:
        return body
    names = {e: Name(f"{prefix}{k}") for k, e in enumerate(repeated)}

    def named(e, top=False):
        if not compound(e):
            return e
        if not top and e in names:
            return names[e]
        if isinstance(e, BinOp):
            return BinOp(e.op, named(e.left), named(e.right))
        if isinstance(e, Neg):
            return Neg(named(e.operand))
        return Call(e.fn, tuple(named(a) for a in e.args))

    inserts: dict = {}  # block path -> [(position, Assign)] in the order of ``repeated``
    for e in repeated:
        block, at = _placement(paths[e])
        inserts.setdefault(block, []).append((at, Assign(names[e].id, named(e, top=True))))

    def rebuild(block, path):
        pending = sorted(inserts.get(path, ()), key=lambda x: x[0])  # stable: inner trees first
        out, k = [], 0
        for i, s in enumerate(block):
            while k < len(pending) and pending[k][0] == i:
                out.append(pending[k][1])
                k += 1
            s = map_statement(s, named)
            if body_of(s) is not None:
                s = _with_body(s, rebuild(body_of(s), path + (i,)))
            out.append(s)
        return out

    return rebuild(body, ())


def _placement(paths) -> tuple:
    """(path of the block holding every use, index there of the statement with the first use)."""
    common = []
    for parts in zip(*paths):
        if any(p != parts[0] for p in parts):
            break
        common.append(parts[0])
    if len(common) == min(len(p) for p in paths):
        common = common[:-1]  # a statement that uses the tree itself, not only its body
    return tuple(common), min(paths)[len(common)]


# -- measuring ----------------------------------------------------------------------------------------


def operation_count(program: Program) -> dict:
    """Operations written in the program (each statement once, not per loop pass): ``arith`` (+ - * /
    and negation), ``calls`` (cos, sin, sqrt, atan2, max2), ``kernels`` and ``statements``."""
    counts = {"arith": 0, "calls": 0, "kernels": 0, "statements": 0}

    def expr(e):
        if isinstance(e, (BinOp, Neg)):
            counts["arith"] += 1
        elif isinstance(e, Call):
            counts["calls"] += 1
        for c in children(e):
            expr(c)

    def walk(block):
        for s in block:
            counts["statements"] += 1
            if isinstance(s, (Loop, ReferenceLoop)):
                counts["kernels"] += 1
            for e in statement_exprs(s):
                expr(e)
            if body_of(s) is not None:
                walk(body_of(s))

    walk(program.body)
    return counts
