"""The code IR of the fast chain (``ikcompiler/codegen/ir.py``) and its two printers (``printers.py``).

Folding and CSE keep every value bit for bit; the Python printer groups as the tree does (checked by
evaluating random trees both ways); the C printer computes what the Python printer does (a hand-built
program compiled and run); on every zoo robot with a fast chain the chain with CSE gives the same
leaves, bit for bit, as without, and the chain rebuilt from a generated module's data is the chain
the module holds (the C the runtime prints is that chain's).
"""

from __future__ import annotations

import ctypes
import math

import numpy as np
import pytest

from ikcompiler import compile_robot, load_robot
from ikcompiler.codegen import csource, fastpath, ir, printers
from ikcompiler.inputs.zoo import zoo_names
from ikcompiler.verify import sample_configurations
from subproblems import fast, native
from tests.test_fastpath import COVERED, FREE

a, b, c = ir.Name("a"), ir.Name("b"), ir.Name("c")


# --- folding -------------------------------------------------------------------------------------------


def test_constants_fold_with_the_operation_the_chain_would_do():
    assert ir.binop("+", 1.5, 2.25) == ir.Const(3.75)
    assert ir.binop("*", 0.1, 3.0) == ir.Const(0.1 * 3.0)  # rounded as at run time, not 0.3
    assert ir.binop("/", 1.0, 3.0) == ir.Const(1.0 / 3.0)
    assert ir.neg(2.0) == ir.Const(-2.0)
    assert ir.call("sqrt", 2.0) == ir.Const(math.sqrt(2.0))  # correctly rounded everywhere
    assert ir.call("max2", 1.0, 3.0) == ir.Const(3.0)


def test_only_exact_identities_fold():
    assert ir.binop("*", a, 1.0) is a and ir.binop("*", 1.0, a) is a and ir.binop("/", a, 1.0) is a
    assert ir.binop("-", a, 0.0) is a
    assert ir.neg(ir.neg(a)) is a
    # -0 + 0 is +0 and x*0 is NaN for an infinite x: these stay as written
    assert isinstance(ir.binop("+", a, 0.0), ir.BinOp) and isinstance(ir.binop("*", a, 0.0), ir.BinOp)
    # libm and numpy may differ in the last bit of cos, sin, atan2: computed by each backend
    assert isinstance(ir.call("cos", 0.5), ir.Call) and isinstance(ir.call("atan2", 1.0, 2.0), ir.Call)
    assert isinstance(ir.call("sqrt", -1.0), ir.Call)  # no value to fold to
    assert math.copysign(1.0, ir.Const(-0.0).value) == 1.0  # one zero, so CSE cannot confuse two


def test_bad_nodes_are_refused():
    with pytest.raises(ValueError, match="operator"):
        ir.BinOp("**", a, b)
    with pytest.raises(ValueError, match="arguments"):
        ir.Call("atan2", (a,))
    with pytest.raises(ValueError, match="finite"):
        ir.Const(math.inf)


# --- the Python printer groups as the tree --------------------------------------------------------------


def test_python_printer_parenthesises_as_the_tree_groups():
    sub, add, mul = (lambda x, y: ir.BinOp("-", x, y)), (lambda x, y: ir.BinOp("+", x, y)), (
        lambda x, y: ir.BinOp("*", x, y))
    cases = {
        sub(mul(a, b), add(b, c)): "a*b - (b + c)",
        sub(sub(a, b), c): "a - b - c",
        sub(a, sub(b, c)): "a - (b - c)",
        mul(add(a, b), c): "(a + b)*c",
        ir.Neg(mul(a, b)): "-(a*b)",
        mul(ir.Neg(a), b): "-a*b",
        sub(a, ir.Neg(b)): "a - (-b)",
        mul(a, ir.Const(-0.5)): "a*(-0.5)",
        mul(ir.Const(-0.5), a): "-0.5*a",
        ir.BinOp("/", a, mul(b, c)): "a/(b*c)",
        ir.Call("sqrt", (add(a, ir.Free(1)),)): "m.sqrt(a + free[1])",
    }
    for tree, text in cases.items():
        assert printers.py_expr(tree) == text
    assert printers.c_expr(sub(mul(ir.Const(-0.5), a), ir.Free(0))) == "(((-0.5) * a) - fr[0])"


def _evaluate(e, env):
    """The tree's value, operation by operation (independent of both printers)."""
    if isinstance(e, ir.Const):
        return e.value
    if isinstance(e, ir.Name):
        return env[e.id]
    if isinstance(e, ir.Neg):
        return -_evaluate(e.operand, env)
    if isinstance(e, ir.Call):
        return getattr(math, e.fn)(*(_evaluate(x, env) for x in e.args))
    x, y = _evaluate(e.left, env), _evaluate(e.right, env)
    return {"+": x + y, "-": x - y, "*": x * y, "/": x / y}[e.op]


def _random_tree(rng, depth):
    if depth == 0 or rng.random() < 0.2:
        return ir.Name("abc"[rng.integers(3)]) if rng.random() < 0.7 else ir.Const(float(rng.normal()))
    kind = rng.integers(5)
    if kind == 4:
        return ir.Neg(_random_tree(rng, depth - 1))
    return ir.BinOp("+-*/"[kind], _random_tree(rng, depth - 1), _random_tree(rng, depth - 1))


def test_printed_python_evaluates_as_the_tree():
    rng = np.random.default_rng(1)
    env = {"a": 0.1, "b": -3.7, "c": 1.0 / 3.0}
    for _ in range(400):
        tree = _random_tree(rng, 5)
        try:
            want = _evaluate(tree, env)
        except ZeroDivisionError:
            continue
        got = eval(printers.py_expr(tree), {}, env)  # noqa: S307 - our own printed arithmetic
        assert got == want or (math.isnan(got) and math.isnan(want)), printers.py_expr(tree)


# --- CSE ------------------------------------------------------------------------------------------------


def _goal():
    return tuple(f"g{i}" for i in range(12))


def _hand_program():
    """A small chain: two assignments, one kernel loop (O-R about z), a repeated subexpression and a
    repeated whole assignment inside the loop, one leaf."""
    g = [ir.Name(n) for n in _goal()]
    shared = ir.BinOp("-", ir.BinOp("*", g[0], g[1]), ir.BinOp("+", g[2], g[3]))
    body = [
        ir.Assign("t0", shared),
        ir.Assign("t1", ir.Neg(ir.BinOp("*", g[4], g[5]))),
    ]
    loop = ir.Loop("rot_r", ((ir.Const(0.0), ir.Const(0.0), ir.Const(1.0)), tuple(g[:9])), ("a0",), "f0", [])
    body.append(loop)
    angle = ir.Name("a0")
    loop.body += [
        ir.Assign("c0", ir.Call("cos", (angle,))),
        ir.Assign("t2", shared),  # computed already: t0
        ir.Assign("t3", ir.BinOp("+", ir.BinOp("*", ir.Name("c0"), ir.BinOp("*", g[6], g[7])), ir.Free(0))),
        ir.Assign("t4", ir.BinOp("-", ir.BinOp("*", g[6], g[7]), ir.Name("t2"))),  # g6*g7 again
        ir.Leaf((angle, ir.Name("t3"), ir.Name("t1")),
                (ir.Call("sqrt", (ir.BinOp("*", ir.Name("t3"), ir.Name("t3")),)), ir.Name("t4")), ("f0",)),
    ]
    return ir.Program(_goal(), body)


def _python_leaves(program, goal, free=(0.25,)):
    ns = {"_fk": fast}
    exec(printers.python_source(program), ns)  # noqa: S102 - our own printed chain
    return ns["_fast_chain"](fast.SCALAR, goal, free)


def _goal_values(seed=0):
    rng = np.random.default_rng(seed)
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    return tuple(R.ravel().tolist()) + tuple(rng.normal(size=3).tolist())


def test_cse_reuses_names_and_names_repeats_without_changing_a_bit():
    before = _hand_program()
    after = ir.eliminate_common(before)
    text = printers.python_source(after)
    assert text.count("g6*g7") == 1  # named once, inside the loop (its first use)
    loop = next(s for s in after.body if isinstance(s, ir.Loop))
    assigned = {s.name: s.value for s in loop.body if isinstance(s, ir.Assign)}
    assert "t2" not in assigned and assigned["t4"].right == ir.Name("t0")  # t2 was t0
    g67 = ir.BinOp("*", ir.Name("g6"), ir.Name("g7"))
    named = [s for s in loop.body if isinstance(s, ir.Assign) and s.value == g67]
    assert len(named) == 1 and named[0].name.startswith("x")
    ops_before, ops_after = ir.operation_count(before), ir.operation_count(after)
    assert ops_after["arith"] == ops_before["arith"] - 4  # t2's three operations and one g6*g7
    for seed in range(5):
        goal = _goal_values(seed)
        assert _python_leaves(before, goal) == _python_leaves(after, goal)


def test_a_repeat_used_by_a_loop_and_its_body_is_named_before_the_loop():
    g = [ir.Name(n) for n in _goal()]
    twice = ir.BinOp("*", g[0], g[1])
    loop = ir.Loop("rot_r", ((twice, ir.Const(0.0), ir.Const(1.0)), tuple(g[:9])), ("a0",), "f0", [
        ir.Leaf((ir.BinOp("+", twice, ir.Name("a0")),), (ir.Const(0.0),), ("f0",))])
    out = ir.eliminate_common(ir.Program(_goal(), [loop]))
    assert isinstance(out.body[0], ir.Assign) and out.body[0].value == twice
    assert printers.python_source(out).count("g0*g1") == 1


def test_dead_assignments_are_dropped():
    g = ir.Name("g0")
    program = ir.Program(_goal(), [ir.Assign("u", ir.BinOp("*", g, g)), ir.Assign("v", ir.Neg(ir.Name("u"))),
                                   ir.Leaf((g,), (ir.Const(0.0),), ())])
    assert [type(s) for s in ir.without_dead_code(program).body] == [ir.Leaf]


# --- the C printer computes what the Python printer does -------------------------------------------------


def _c_leaves(program, goal, free=(0.25,), dof=3):
    lines, most = printers.c_function(program, "hand_chain", dof)
    source = "\n".join(lines) + (
        "\nint hand_leaves(const double *goal, const double *fr, double *Q, double *E, int *F) {\n"
        "    return hand_chain(goal, fr, 0.0, Q, E, F);\n}\n")
    path = native.build(source)
    assert path is not None, native.last_error
    fn = ctypes.CDLL(str(path)).hand_leaves
    fn.restype = ctypes.c_int
    Q, E, F = np.zeros((most, dof)), np.zeros(most), np.zeros(most, dtype=np.intc)
    g, fr = np.array(goal, dtype=float), np.array(free, dtype=float)
    n = fn(*(ctypes.c_void_p(x.ctypes.data) for x in (g, fr, Q, E, F)))
    return [tuple(Q[k].tolist()) + (float(E[k]), int(F[k])) for k in range(n)]


@pytest.mark.skipif(native.compiler() is None, reason="no C compiler")
@pytest.mark.parametrize("cse", [False, True])
def test_c_and_python_leaves_of_a_hand_built_program_agree(cse):
    program = _hand_program()
    program = ir.eliminate_common(program) if cse else program
    for seed in range(5):
        goal = _goal_values(seed)
        py = [tuple(float(x) for x in leaf[:-1]) + (int(leaf[-1]),) for leaf in _python_leaves(program, goal)]
        assert _c_leaves(program, goal) == py


def test_a_reference_solver_has_no_c():
    loop = ir.ReferenceLoop("S2-RRR", ((ir.Const(1.0),) * 6,) * 3, (("p", (ir.Name("g9"),) * 3),),
                            ("a0", "a1", "a2"), "f0", [ir.Leaf((ir.Name("a0"),), (ir.Const(0.0),), ("f0",))])
    program = ir.Program(_goal(), [loop])
    assert "_fk.reference(m, 'S2-RRR', (" in printers.python_source(program)
    with pytest.raises(printers.Untranslatable):
        printers.c_function(program, "x", 1)
    assert not csource.translatable(program, target="pose", dof=1)


# --- on the zoo ----------------------------------------------------------------------------------------

_MODULES: dict = {}


def _module(name):
    if name not in _MODULES:
        _MODULES[name] = compile_robot(name, free=FREE.get(name, ()))
    return _MODULES[name]


def _leaf_array(leaves):
    return np.array([[float(x) for x in leaf] for leaf in leaves])


@pytest.mark.parametrize("name", sorted(COVERED & set(zoo_names())))
def test_cse_keeps_every_zoo_leaf_bit_for_bit(name):
    module = _module(name)
    data = fastpath.ChainData.from_module(vars(module))
    plain, named = fastpath.build_program(data, cse=False), fastpath.build_program(data, cse=True)
    ops = ir.operation_count(plain), ir.operation_count(named)
    assert ops[1]["arith"] <= ops[0]["arith"] and ops[1]["calls"] <= ops[0]["calls"], ops
    Q = sample_configurations(load_robot(name), 30, seed=4, special=0.3)
    grid = np.linspace(-np.pi, np.pi, max(module._GRID, 1), endpoint=False)
    for k, q in enumerate(Q):
        goal = fast.goal_entries(module.fk(q), module.TARGET)
        free = tuple(float(q[module.JOINT_NAMES.index(f)]) for f in module.FREE_JOINTS)
        free += tuple(float(grid[k % len(grid)]) for _ in module._SEARCH)
        x, y = _leaf_array(_python_leaves(plain, goal, free)), _leaf_array(_python_leaves(named, goal, free))
        assert x.shape == y.shape and np.array_equal(x, y, equal_nan=True), (name, k)


@pytest.mark.parametrize("name", sorted(COVERED & set(zoo_names())))
def test_the_chain_rebuilt_from_a_module_is_the_modules_chain(name):
    module = _module(name)
    rebuilt = fastpath.build_program(fastpath.ChainData.from_module(vars(module)))
    assert printers.python_source(rebuilt) in module.__source__
    assert module.NATIVE == (csource.native_source(vars(module)) is not None)
