"""Print a fast chain in C: the native backend of a generated module (docs/design.md section 11).

The fast chain is a code IR program (:mod:`ikcompiler.codegen.ir`, built by
:mod:`ikcompiler.codegen.fastpath`); :func:`ikcompiler.codegen.printers.c_function` prints it as a C
function ``ikc_chain``, expression for expression (every operation parenthesised as the tree groups,
so C rounds as Python does), calling the C port of the kernels (``subproblems/fast_kernels.h``).  The
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
solver, which has no C port): such modules keep their Python fast path alone.  The generated module
does not carry the C: :func:`native_source` prints it again from the module's own data on first
native use (cached by a hash of those data).
"""

from __future__ import annotations

import functools
import hashlib

import numpy as np

from ikcompiler.codegen import ir
from ikcompiler.codegen.printers import Untranslatable, c_function, c_lane_function, c_number, wrap
from subproblems import native

__all__ = [
    "TARGET_CODES", "chain_c_source", "module_c_source", "native_source", "translatable",
]

TARGET_CODES = {"pose": 0, "position": 1, "orientation": 2}


def _number(x: float) -> str:
    """A C literal for an initialiser (no parentheses needed there)."""
    text = c_number(x)
    return text[1:-1] if text.startswith("(") else text


def _array(values, fmt) -> str:
    return "{" + ", ".join(fmt(v) for v in values) + "}"


def chain_c_source(program: ir.Program, *, kinds: str, lower, upper, free, target: str, scale: float,
                   tol: float, slots: int, twists, home, A, b, search: int = 0, grid: int = 0,
                   polish: int = 0, alternative: ir.Program | None = None,
                   near_singular: float = 0.0) -> str | None:
    """C source of the chain ``program`` (the IR of ``_fast_chain``), or None if untranslatable.

    ``kinds``, ``lower``, ``upper`` are the returned joints' types and limits (JOINT_NAMES order),
    ``free`` the positions of the free joints among them; ``twists`` (all joints, mimic ones too),
    ``home`` (4x4) and ``A``, ``b`` (all joint values = A q + b) describe the true robot for the
    Newton steps of the finish.  ``alternative``: the IR of the plan's alternative chain (the C finish
    runs it where the chain cannot settle a target), or None.  ``search`` joints gridded over
    ``grid`` values each (a search plan: the chain takes their values after the free ones).
    ``polish``: Newton steps on the true robot for every leaf of a snapped plan (the chain itself runs
    on the snapped robot); ``near_singular``: the weakest singular value below which such a leaf's
    target goes to the Python continuation.
    """
    if target not in TARGET_CODES or program is None:
        return None
    dof = len(kinds)
    try:
        main = c_function(program, "ikc_chain", dof)
    except Untranslatable:
        return None
    try:
        # the alternative chain runs only where the chain cannot settle a target: compiled as cold
        # code (native.COLD: -O1, a fifth less of the compiler's work on it; docs/design.md section 14)
        alt = (c_function(alternative, "ikc_chain_alt", dof, storage=f"{native.COLD} static")
               if alternative is not None else None)
    except Untranslatable:
        alt = None
    head = [
        "/* The chain of this module in C (ikcompiler/codegen/csource.py): the same arithmetic as",
        " * _fast_chain, with the kernels and the finish of subproblems/fast_kernels.h, fast_finish.h. */",
    ]
    # ... and calls the shared finish library's kernels where it has them (native.cold_kernel_renames)
    cold = ([*native.COLD_DEFINITION.splitlines(), *native.cold_kernel_renames("\n".join(alt[0]))]
            if alt else [])
    body = main[0] + (cold + alt[0] if alt else [])
    return _with_entries(head + body, leaves=main[1], alt=alt[1] if alt else None, kinds=kinds, lower=lower,
                         upper=upper, free=free, target=target, scale=scale, tol=tol, slots=slots,
                         twists=twists, home=home, A=A, b=b, search=search, grid=grid, polish=polish,
                         near_singular=near_singular)


def _with_entries(lines, *, leaves: int, alt, kinds, lower, upper, free, target, scale, tol, slots, twists,
                  home, A, b, search=0, grid=0, polish=0, near_singular=0.0) -> str:
    """``lines`` (the C of ``ikc_chain`` and, when ``alt`` gives its leaf count, ``ikc_chain_alt``)
    followed by the module's ``ikc_robot`` and the exported entry points."""
    dof = len(kinds)
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
        f"static const ikc_robot ikc_this = {{{dof}, {len(free)}, {leaves}, {slots},",
        f"    {TARGET_CODES[target]},",
        f"    ikc_revolute_, ikc_lower_, ikc_upper_, {_number(scale)}, {_number(tol)}, ikc_chain,",
        f"    {nall}, ikc_twists_, ikc_home_, ikc_A_, ikc_b_, ikc_free_, {search}, {grid},",
        f"    {polish}, {'ikc_chain_alt' if alt is not None else 'NULL'}, {alt or 0},",
        f"    {_number(near_singular)}}};",
    ]
    tail = [
        *[w for line in robot for w in wrap(line)],
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
        "",
        "const void *ikc_robot_data(void) {  /* for the block chain's library (block_c_source) */",
        "    return &ikc_this;",
        "}",
    ]
    return "\n".join(list(lines) + tail) + "\n"


def general6_native_arrangements(solver) -> list[int]:
    """The arrangements of ``solver`` (a :class:`subproblems.general6.General6`) that the C elimination
    runs, in its usable order: those with the 12 x 12 pencil (general6.h's coverage: prismatic
    joints at a, b, d or e; not the deflated 9 x 9 pencil of a
    prismatic joint on each side of the split); none when the preferred one is not among them (its
    rows are the reference's first answer).  The one rule for a general-6r module's C (``NATIVE``)."""
    def covered(arr) -> bool:
        return not (arr.prism[2] or arr.prism[5] or arr.swap) and arr.deflate is None

    arrangements = [k for k in solver.usable if covered(solver._arr[k])]
    return arrangements if arrangements and arrangements[0] == solver.usable[0] else []


def general6_plain_pose(*, kinds: str, target: str, A, b) -> bool:
    """A plain 6-joint pose chain (no mimic or free joints): what a general-6r module's C solves."""
    A, b = np.asarray(A, float), np.asarray(b, float)
    return (target == "pose" and len(kinds) == 6 and A.shape == (6, 6) and np.array_equal(A, np.eye(6))
            and not np.any(b != 0))


def general6_c_source(solver, *, kinds: str, lower, upper, target: str, scale: float, tol: float,
                      slots: int, twists, home, A, b) -> str | None:
    """C source of a general-6r module (docs/general6.md, "Native path"): the data of the arrangements
    of ``solver`` (a :class:`subproblems.general6.General6`) that the C covers, in its usable order
    (:func:`general6_native_arrangements`), as ``ikc_g6`` structs and a chain ``ikc_chain`` that calls
    ``ikc_g6_leaves`` of ``subproblems/general6.h`` (a target doubtful under one arrangement is
    re-solved under the next); None when the module is not a plain 6-joint pose chain or the C does
    not cover its preferred arrangement."""
    arrangements = general6_native_arrangements(solver)
    if not general6_plain_pose(kinds=kinds, target=target, A=A, b=b) or not arrangements:
        return None
    A, b = np.asarray(A, float), np.asarray(b, float)
    Mi = np.linalg.inv(solver.Mn)
    flat = lambda x: _array(np.asarray(x, float).ravel().tolist(), _number)  # noqa: E731
    ints = lambda x: _array(list(x), str)  # noqa: E731
    data = [f"static const ikc_g6 ikc_g6_these[{len(arrangements)}] = {{"]
    for k in arrangements:
        arr = solver._arr[k]
        data += [
            f"    {{{int(arr.sign)}, {arr.conj}, {ints(arr.order)},",
            f"    {ints(int(p) for p in arr.prism)}, {len(arr.cols)},",
            f"    {ints(list(arr.cols) + [0] * (8 - len(arr.cols)))},",
            f"    {flat(arr.w)}, {flat(arr.r)},",
            f"    {flat(arr.A)},",
            f"    {flat(arr.inv9)}, {flat(arr.grid_ab)}, {flat(arr.u)},",
            f"    {flat(list(Mi[:3, :3].ravel()) + list(Mi[:3, 3]))},",
            f"    {flat(solver.center)}, {_number(solver._s)}}},",
        ]
    data += [
        "};",
        "static const ikc_robot ikc_this;",
        "",
        "static int ikc_chain(const double *goal, const double *fr, double rep, double *Q, double *E,",
        "                     int *F) {",
        "    (void)fr;",
        "    (void)rep;",
        f"    return ikc_g6_leaves(&ikc_this, ikc_g6_these, {len(arrangements)}, goal, Q, E, F);",
        "}",
        "",
    ]
    head = [
        "/* The general-6r chain of this module in C (ikcompiler/codegen/csource.py): the elimination of",
        " * subproblems/general6.h on the data of its arrangements (subproblems/general6.py), in order. */",
    ]
    lines = head + [w for line in data for w in wrap(line)]
    return _with_entries(lines, leaves=16, alt=None, kinds=kinds, lower=lower, upper=upper, free=[],
                         target=target, scale=scale, tol=tol, slots=slots, twists=twists, home=home,
                         A=A.tolist(), b=b.tolist())


def free_ends_c_source(solver, *, joint_types: str, lower, upper, scale: float, tol: float, slots: int,
                       twists, home, home_inv, A, b, solved, solved_pos, free_cols, free_pos) -> str | None:
    """C source of a general-6r module with free end joints (``runtime.freeends``): the elimination of
    its six solved joints (:func:`general6_c_source` on them) and ``ikc_free_solve_one`` /
    ``ikc_free_solve_many`` of ``subproblems/free_ends.h``, which move the target by the free values,
    solve the six and check every exact row on the whole robot.  ``twists`` (every chain joint), ``A``,
    ``b`` (all joint values = A q + b), ``joint_types``, ``lower``, ``upper``: the whole robot, in its
    returned joints' order; ``solved`` the six's chain columns, ``solved_pos`` their returned columns;
    ``free_cols``, ``free_pos``: each free value's chain column and returned column.  None where the
    six have no C."""
    twists = np.asarray(twists, float)
    six = general6_c_source(solver, kinds="".join(joint_types[p] for p in solved_pos),
                            lower=np.asarray(lower)[solved_pos], upper=np.asarray(upper)[solved_pos],
                            target="pose", scale=scale, tol=tol, slots=slots, twists=twists[solved],
                            home=home, A=np.eye(6), b=np.zeros(6))
    if six is None:
        return None
    n, nall = len(joint_types), len(twists)
    order = sorted(range(len(free_cols)), key=lambda i: free_cols[i])  # chain order
    before = [i for i in order if free_cols[i] < min(solved)]
    after = [i for i in order if free_cols[i] > max(solved)]
    if len(before) + len(after) != len(free_cols):
        return None  # a free joint between solved ones: the fold's (runtime.freefold), not this
    flat = lambda x: _array(np.asarray(x, float).ravel().tolist() or [0.0], _number)  # noqa: E731
    ints = lambda x: _array(list(x) or [0], str)  # noqa: E731
    hi = np.asarray(home_inv, float)
    data = [
        f"static const int ikc_fe_revolute_[{n}] = {ints(1 if k == 'R' else 0 for k in joint_types)};",
        f"static const double ikc_fe_lower_[{n}] = {flat(lower)};",
        f"static const double ikc_fe_upper_[{n}] = {flat(upper)};",
        f"static const int ikc_fe_is_free_[{n}] = {ints(1 if j in free_pos else 0 for j in range(n))};",
        f"static const double ikc_fe_twists_[{6 * nall}] = {flat(twists)};",
        f"static const double ikc_fe_A_[{nall * n}] = {flat(A)};",
        f"static const double ikc_fe_b_[{nall}] = {flat(b)};",
        f"static const ikc_robot ikc_whole = {{{n}, {len(free_pos)}, 0, {slots}, 0, ikc_fe_revolute_,",
        f"    ikc_fe_lower_, ikc_fe_upper_, {_number(scale)}, {_number(tol)}, NULL, {nall}, ikc_fe_twists_,",
        "    ikc_home_, ikc_fe_A_, ikc_fe_b_, ikc_fe_is_free_, 0, 0, 0, NULL, 0, 0.0};",
        f"static const int ikc_fe_free_pos_[{max(1, len(free_pos))}] = {ints(free_pos)};",
        f"static const int ikc_fe_solved_pos_[6] = {ints(solved_pos)};",
        f"static const int ikc_fe_before_[{max(1, len(before))}] = {ints(before)};",
        f"static const int ikc_fe_after_[{max(1, len(after))}] = {ints(after)};",
        f"static const double ikc_fe_tw_before_[{6 * max(1, len(before))}] = "
        f"{flat([twists[free_cols[i]] for i in before])};",
        f"static const double ikc_fe_tw_after_[{6 * max(1, len(after))}] = "
        f"{flat([twists[free_cols[i]] for i in after])};",
        f"static const double ikc_fe_home_inv_[12] = {flat(list(hi[:3, :3].ravel()) + list(hi[:3, 3]))};",
        f"static const ikc_free_ends ikc_fe_this = {{&ikc_this, &ikc_whole, {len(free_pos)},",
        f"    ikc_fe_free_pos_, ikc_fe_solved_pos_, {len(before)}, {len(after)}, ikc_fe_before_,",
        "    ikc_fe_after_,",
        "    ikc_fe_tw_before_, ikc_fe_tw_after_, ikc_fe_home_inv_};",
        "",
        "int ikc_free_solve_one(const double *T, const double *fr, int limits, double *q, double *res,",
        "                       int *ls, int *cont) {",
        "    return ikc_free_one(&ikc_fe_this, T, fr, limits, q, res, ls, cont);",
        "}",
        "",
        "void ikc_free_solve_many(int64_t n, const double *goals, const double *fr, int limits, double *q,",
        "                         double *res, int *ls, int *cont, int *count, int threads) {",
        "    ikc_free_many(&ikc_fe_this, n, goals, fr, limits, q, res, ls, cont, count, threads);",
        "}",
    ]
    head = ["", "/* the free end joints (subproblems/free_ends.h): the moved target and the whole robot */"]
    return six + "\n".join(head + [w for line in data for w in wrap(line)]) + "\n"


def translatable(program: ir.Program | None, *, target: str, dof: int) -> bool:
    """Whether :func:`chain_c_source` gives C for ``program`` (the module's ``NATIVE``)."""
    if program is None or target not in TARGET_CODES:
        return False
    try:
        c_function(program, "ikc_chain", dof)
    except Untranslatable:
        return False
    return True


# -- the C of a generated module, printed from the module's own data ---------------------------------

_MODULE_FIELDS = (  # what the C depends on, besides the code of this package (section 11)
    "METHOD", "TARGET", "_SOLVE_TARGET", "JOINT_TYPES", "LOWER", "UPPER", "SCALE", "TOLERANCE",
    "MAX_SOLUTIONS", "_TWISTS", "_PLAN_TWISTS", "_KINDS", "_HOME", "_COUPLINGS", "_A", "_B",
    "_INDEPENDENT", "_VARY", "_VARY_LOWER", "_VARY_UPPER", "_FREE", "_POLISH", "_SEARCH", "_GRID",
    "_STEPS", "_ALT_STEPS",
)
# a change to these changes the C: the code generator, the steps' lowerings (steps/kinds.py), and what
# it reads from subproblems (the pair classification runs plan_runtime; the snapped plan's threshold
# comes from continuation.near_singular)
_GENERATORS = ("ir.py", "printers.py", "fastpath.py", "csource.py", "../steps/kinds.py")
_READ_FROM_SUBPROBLEMS = ("plan_runtime.py", "continuation.py", "tolerances.py", "general6.py")
_SOURCES: dict[str, str | None] = {}  # data hash -> C text, for this process


def _plain(x):
    """``x`` as plain lists, numbers and strings (for a stable hash of a module's data)."""
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in sorted(x.items())}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if hasattr(x, "keys") and hasattr(x, "__getitem__"):  # a typed step read as a mapping
        return {str(k): _plain(x[k]) for k in sorted(x.keys())}
    return x


@functools.cache
def _generator_code() -> str:
    """The text of the code that prints the C (read once per process)."""
    from pathlib import Path

    import subproblems

    here, sub = Path(__file__).parent, Path(subproblems.__file__).parent
    files = [here / name for name in _GENERATORS] + [sub / name for name in _READ_FROM_SUBPROBLEMS]
    return "".join(f.read_text() for f in files)


def data_key(namespace) -> str:
    """A hash of the data a module's C is printed from and of the code that prints it."""
    code = _generator_code()
    snapped = namespace["_PLAN_TWISTS"] is not namespace["_TWISTS"]
    data = repr([_plain(namespace[k]) for k in _MODULE_FIELDS] + [_plain(namespace.get("_SPEED")), snapped])
    return hashlib.sha256((code + "\0" + data).encode()).hexdigest()[:24]


def native_source(namespace) -> str | None:
    """The C of a generated module (``ikc_chain`` and its entry points), or None when its chain has no
    C translation.  ``namespace``: the module's globals.

    The module holds its Python chain only; the C is printed from the same IR, rebuilt from the data
    the module holds (steps, twists, home, kinds, couplings, limits, free joints, scale), on the first
    native use, and kept per process and on disk (beside the C builds, ``subproblems.native``) under a
    hash of those data and of this package's code generators."""
    if namespace.get("_fast_chain") is None and namespace.get("_GENERAL6") is None:
        return None
    key = data_key(namespace)
    if key in _SOURCES:
        return _SOURCES[key]
    path = native.cache_dir() / f"ikc_src_{key}.c"
    try:
        text = path.read_text()
    except OSError:
        text = module_c_source(namespace)
        if text is not None and native.enabled() and native.compiler() is not None:
            _store(path, text)  # only where it will be built (a disabled backend writes nothing)
    _SOURCES[key] = text
    return text


def _store(path, text: str) -> None:
    """Write the cache file (another process may write it too: ``native.replace_atomically``)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        native.replace_atomically(path, lambda partial: partial.write_text(text))
    except OSError:
        pass  # an unwritable cache costs a reprint next time, nothing else


def module_c_source(ns, general6=None) -> str | None:
    """The C of the module with globals ``ns``, printed now (:func:`native_source` caches it).
    ``general6``: for a general-6r module, another :class:`subproblems.general6.General6` of its robot
    to print instead of the module's own (the tests and benchmarks print one arrangement alone)."""
    from ikcompiler.codegen.fastpath import ChainData, build_program

    if ns["METHOD"] == "general-6r":
        return general6_c_source(
            ns["_GENERAL6"] if general6 is None else general6, kinds=ns["JOINT_TYPES"],
            lower=ns.get("_LOWER", ns["LOWER"]), upper=ns.get("_UPPER", ns["UPPER"]), target=ns["TARGET"],
            scale=ns["SCALE"], tol=ns["TOLERANCE"], slots=ns["MAX_SOLUTIONS"], twists=ns["_TWISTS"],
            home=np.asarray(ns["_HOME"], float), A=ns["_A"], b=ns["_B"])
    program = build_program(ChainData.from_module(ns))
    alternative = None
    if ns["_ALT_STEPS"] and not ns["_SEARCH"]:
        alternative = build_program(ChainData.from_module(ns, "_ALT_STEPS"))
    near = 0.0
    if ns["_POLISH"] and ns["_PLAN_TWISTS"] is not ns["_TWISTS"]:  # a snapped plan (its own twists)
        from subproblems.continuation import near_singular

        near = near_singular(np.asarray(ns["_PLAN_TWISTS"], float), np.asarray(ns["_TWISTS"], float),
                             ns["SCALE"])
    return chain_c_source(
        program, alternative=alternative, kinds=ns["JOINT_TYPES"], lower=ns.get("_LOWER", ns["LOWER"]),
        upper=ns.get("_UPPER", ns["UPPER"]),
        free=list(ns["_FREE"]), target=ns["TARGET"], scale=ns["SCALE"], tol=ns["TOLERANCE"],
        slots=ns["MAX_SOLUTIONS"], twists=ns["_TWISTS"], home=np.asarray(ns["_HOME"], float), A=ns["_A"],
        b=ns["_B"], search=len(ns["_SEARCH"]), grid=ns["_GRID"], polish=ns["_POLISH"], near_singular=near)


# -- the block chain of a batch, printed and built on the first solve_batch ----------------------------


def block_c_source(ns) -> str | None:
    """The C of the module's block chain (docs/design.md section 14, "SIMD over poses"): its chain for
    4 poses at once (:func:`ikcompiler.codegen.printers.c_lane_function`, the kernels of
    ``subproblems/lane_kernels.h``) and ``ikc_solve_many_block(rb, ...)``, ``ikc_solve_many`` on it
    (``rb``: the ``ikc_robot`` of the module's own library, ``ikc_robot_data``).  None where the chain
    has no lane form: a general-6r module, free or searched joints, a snapped plan, a kernel without a
    lane form.  Printed when a batch first runs, so a module that never solves one never builds it."""
    from ikcompiler.codegen.fastpath import ChainData, build_program

    if ns["METHOD"] == "general-6r" or ns["_FREE"] or ns["_SEARCH"] or ns["_POLISH"]:
        return None
    if ns["TARGET"] not in TARGET_CODES or ns.get("_fast_chain") is None:
        return None
    try:
        lines, leaves = c_lane_function(build_program(ChainData.from_module(ns)), "ikc_block",
                                        len(ns["JOINT_TYPES"]))
    except Untranslatable:
        return None
    head = ["/* The block chain of this module (ikcompiler/codegen/csource.py block_c_source): ikc_chain's",
            " * arithmetic for 4 poses a call, on the lane kernels of subproblems/lane_kernels.h. */"]
    tail = [
        "#if IKC_LANE_VECTOR_ANGLES",
        "/* the block chain with libm's angles in every lane (lane_kernels.h IKC_LANE_AGAIN) */",
        "static int ikc_block_libm(const double *G, double *Q, double *E, int64_t *F) {",
        "    ikc_lane_libm = 1;",
        "    const int n = ikc_block(G, Q, E, F);",
        "    ikc_lane_libm = 0;",
        "    return n;",
        "}",
        "#else",
        "#define ikc_block_libm 0  /* libm's angles already */",
        "#endif",
        "",
        "void ikc_solve_many_block(const void *rb, int64_t n, const double *goals, const double *fr,",
        "                          int limits, double *q, double *res, int *ls, int *cont, int *count,",
        "                          int threads) {",
        "    __atomic_store_n(&ikc_lane_locks, ((const ikc_robot *)rb)->chain_alt == 0, __ATOMIC_RELAXED);",
        f"    ikc_many_block((const ikc_robot *)rb, ikc_block, ikc_block_libm, {leaves}, n, goals, fr, limits,",
        "                   q, res, ls, cont, count, threads);",
        "}",
        "",
        "/* the leaves of 4 goals, as ikc_many_block reads them (tests/test_block_chain.py) */",
        "int ikc_block_leaves(const double *G, double *Q, double *E, int64_t *F) {",
        "    return ikc_block(G, Q, E, F);",
        "}",
    ]
    return "\n".join(head + lines + tail) + "\n"
