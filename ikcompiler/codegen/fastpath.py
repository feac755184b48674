"""Emit a plan as straight-line arithmetic: the fast path of a generated module.

The reference runtime (:mod:`subproblems.plan_runtime`) interprets a plan with 4x4 numpy matrices; it
is general but pays numpy's per-call overhead on every small product.  Here the same plan is written
out as one function of plain arithmetic with the robot's constants folded in (a joint about the z axis
costs a cosine, a sine and a handful of products, not a matrix product), calling the kernels of
:mod:`subproblems.fast` for the subproblems.  The function takes a *backend* ``m``: with
``subproblems.fast.SCALAR`` it runs on floats for one pose, with ``ARRAY`` on numpy arrays over many
poses; the solution slots of each step become nested loops over a fixed, small number of slots.

Each leaf of the loop nest is one candidate: the joint values, its pose error measured by forward
kinematics, and a ``defer`` flag for instances near a degenerate geometry (which the module hands to the
reference path).  :func:`fast_chain_program` returns ``None`` when a plan has a step this path does
not cover (searches, snapped robots, coupled-pair roots, subproblems without a kernel); such modules
use the reference path alone.

The chain is built as the code IR of :mod:`ikcompiler.codegen.ir` (constants folded, common
subexpressions named) and printed by :mod:`ikcompiler.codegen.printers`, in Python here and in C by
:mod:`ikcompiler.codegen.csource` (docs/design.md section 11).  It is built from :class:`ChainData`,
data a generated module holds as well, so the C can be printed again from a module (``native_source``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ikcompiler.codegen import ir
from ikcompiler.geometry import facts
from ikcompiler.steps import Step

ZERO = 1e-15  # constants below this (rounding noise of a URDF's rpy) fold to zero
FAST_TARGETS = ("pose", "position", "orientation")


class Unsupported(Exception):
    """The plan has a step the fast path does not cover."""


def _product(factors) -> ir.Expr:
    """``f0*f1*...`` grouped from the left, as Python reads it."""
    out = factors[0]
    for f in factors[1:]:
        out = ir.binop("*", out, f)
    return out


class _Code:
    """The IR being built: a stack of open blocks (each loop nests the rest of the chain), with
    constant folding of linear combinations.  A value is a float (a constant known now) or an IR
    expression; a term of :meth:`lin` multiplies a float by a value or by a pair of values."""

    def __init__(self):
        self.body: list = []
        self.blocks = [self.body]
        self.count = 0

    def emit(self, stmt) -> None:
        self.blocks[-1].append(stmt)

    def let(self, expr, hint: str = "t") -> ir.Name:
        name = f"{hint}{self.count}"
        self.count += 1
        self.emit(ir.Assign(name, ir.const(expr)))
        return ir.Name(name)

    def lin(self, terms, hint: str = "t"):
        """``sum coef * value``; folds to a float or an existing value when it can, else a new name.
        The sum is grouped from the left, first term first, the constant last."""
        const = 0.0
        coefs: dict = {}
        for coef, value in terms:
            if abs(coef) <= ZERO:
                continue
            if isinstance(value, tuple) or ir.is_expr(value):
                coefs[value] = coefs.get(value, 0.0) + coef
            else:
                const += coef * value
        coefs = {k: v for k, v in coefs.items() if abs(v) > ZERO}
        if not coefs:
            return const if abs(const) > ZERO else 0.0
        items = list(coefs.items())
        value, coef = items[0]
        if len(items) == 1 and coef == 1.0 and not isinstance(value, tuple) and abs(const) <= ZERO:
            return value
        expr = None
        for value, coef in items:
            factors = value if isinstance(value, tuple) else (value,)
            if expr is None:  # the first term carries its sign: -x, -x*y, -0.5*x
                if coef == 1.0:
                    expr = _product(factors)
                elif coef == -1.0:
                    expr = _product((ir.neg(factors[0]),) + factors[1:])
                else:
                    expr = _product((ir.Const(coef),) + factors)
            else:
                term = _product(factors if abs(coef) == 1.0 else (ir.Const(abs(coef)),) + factors)
                expr = ir.binop("+" if coef > 0 else "-", expr, term)
        if abs(const) > ZERO:
            expr = ir.binop("+" if const > 0 else "-", expr, abs(const))
        return self.let(expr, hint)

    @staticmethod
    def product(a, b):
        """A term (coef, value) for ``a * b``, or None when it is zero."""
        if ir.is_expr(a) and ir.is_expr(b):
            return (1.0, (a, b))
        if ir.is_expr(a):
            return None if abs(b) <= ZERO else (b, a)
        if ir.is_expr(b):
            return None if abs(a) <= ZERO else (a, b)
        return None if abs(a * b) <= ZERO else (a * b, 1.0)

    def dot(self, a, b, hint="t"):
        return self.lin([t for t in (self.product(x, y) for x, y in zip(a, b)) if t], hint)

    def mat_mul(self, A, B):
        """3x4 rigid transforms as 12 entries (rotation row-major, then translation)."""
        out = []
        for i in range(3):
            for j in range(3):
                out.append(self.dot([A[3 * i + k] for k in range(3)], [B[3 * k + j] for k in range(3)], "r"))
        for i in range(3):
            terms = [self.product(A[3 * i + k], B[9 + k]) for k in range(3)]
            out.append(self.lin([t for t in terms if t] + [(1.0, A[9 + i])], "p"))
        return out

    def mat_vec(self, A, x, translate: bool):
        out = []
        for i in range(3):
            terms = [self.product(A[3 * i + k], x[k]) for k in range(3)]
            if translate:
                terms.append((1.0, A[9 + i]))
            out.append(self.lin([t for t in terms if t], "v"))
        return out

    def inverse(self, A):
        R = [A[3 * j + i] for i in range(3) for j in range(3)]
        t = []
        for i in range(3):
            terms = [self.product(R[3 * i + k], A[9 + k]) for k in range(3)]
            t.append(self.lin([(-coef, v) for coef, v in (x for x in terms if x)], "p"))
        return R + t

    def scaled(self, sign: float, x):
        if sign > 0:
            return list(x)
        return [self.lin([(-1.0, v)]) if ir.is_expr(v) else -v for v in x]


def _arg(x):
    """A kernel argument: a vector (tuple) or a scalar, as IR."""
    if isinstance(x, (list, tuple)):
        return tuple(_arg(v) for v in x)
    return ir.const(x)


def _call(kernel: str, *args):
    return ("kernel", kernel, tuple(_arg(a) for a in args))


def _sumsq(xs):
    """``x0*x0 + x1*x1 + ...`` grouped from the left."""
    out = None
    for x in xs:
        sq = ir.binop("*", x, x)
        out = sq if out is None else ir.binop("+", out, sq)
    return ir.Const(0.0) if out is None else out


IDENTITY = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]


class _Emitter:
    """Walks the plan, building the loop nest as IR."""

    def __init__(self, twists, kinds, home, couplings, free_joints, scale, target, spans, snapped=False):
        self.c = _Code()
        self.snapped = snapped  # the plan's (ChainData.snapped)
        self.spans = spans  # per joint: the slide length a representative rep = pi stands for
        self.reps = 0  # steps given a representative so far
        self.twists = np.where(np.abs(twists) <= ZERO, 0.0, twists)
        self.kinds = kinds
        self.home = np.where(np.abs(home) <= ZERO, 0.0, home)
        self.couplings = couplings
        self.scale = scale
        self.target = target
        self.q: dict = {}  # joint -> its value: a float or an IR expression (a name, a free value)
        self.sig: dict = {}  # parallel group -> the name holding the sum of its angles
        self.exps: dict[int, list] = {}
        self.products: dict[tuple, list] = {(): IDENTITY}
        self.flags: list[str] = []
        for k, j in enumerate(free_joints):
            self.q[j] = ir.Free(k)
        self.couple()

    # -- joint values and their motions ------------------------------------------------------------
    def couple(self, solved=()):
        """Values of coupled joints from their masters.  A step that solved a coupled joint as if it
        were free (a subproblem over ``finger_joint`` and two joints that mimic it) gives it the
        master's value instead, so the leaf's forward-kinematics check sees the robot's own joint
        vector and rejects branches that break the coupling (the reference runtime does the same)."""
        solved = set(solved)
        for dep, master, a, b in self.couplings:
            if dep in solved and master in self.q:
                self.q[dep] = self.c.lin([(a, self.q[master]), (b, 1.0)], "q")
        changed = True
        while changed:
            changed = False
            for dep, master, a, b in self.couplings:
                if master in self.q and dep not in self.q:
                    self.q[dep] = self.c.lin([(a, self.q[master]), (b, 1.0)], "q")
                    changed = True
                elif dep in self.q and master not in self.q:
                    self.q[master] = self.c.lin([(1.0 / a, self.q[dep]), (-b / a, 1.0)], "q")
                    changed = True

    def axis(self, j):
        v, w = self.twists[j][:3], self.twists[j][3:]
        return w, np.cross(w, v)  # direction and the axis point nearest the origin

    def exp(self, j):
        if j in self.exps:
            return self.exps[j]
        c = self.c
        if self.kinds[j] == "T":
            v = self.twists[j][:3]
            E = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0] + [c.lin([(vi, self.q[j])], "p") for vi in v]
        else:
            w, r = self.axis(j)
            cj = c.let(ir.call("cos", self.q[j]), "c")
            sj = c.let(ir.call("sin", self.q[j]), "s")
            skew = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]
            E = []
            for i in range(3):
                for k in range(3):
                    E.append(c.lin([(w[i] * w[k], 1.0), ((i == k) - w[i] * w[k], cj), (skew[i][k], sj)], "e"))
            rp = r - (w @ r) * w
            wr = np.cross(w, r)
            E += [c.lin([(rp[i], 1.0), (-rp[i], cj), (-wr[i], sj)], "e") for i in range(3)]
        self.exps[j] = E
        return E

    def prefix(self, joints: tuple):
        """The product of the motions of ``joints`` (in index order), cached by its joint tuple."""
        if joints in self.products:
            return self.products[joints]
        P = self.c.mat_mul(self.prefix(joints[:-1]), self.exp(joints[-1]))
        self.products[joints] = P
        return P

    def equation(self, known):
        """``G_u`` for every unknown joint u and ``G_all`` (rule 7: solved factors moved right)."""
        sofar: tuple = ()
        G_u = {}
        for i in range(len(self.kinds)):
            if i in known:
                sofar = sofar + (i,)
            else:
                G_u[i] = sofar
        return G_u, sofar

    def lock_rep(self):
        """The representative of an S2-RR angle its geometry leaves free (``fast.LOCK``): ``rep``
        itself, outside the count of :meth:`rep`, so the other steps' families keep their factors.
        Where a lock and the first family meet in one target they move together, and the finish's
        line test (a null space of one direction) hands the target back (docs/design.md section 6)."""
        return ir.Name("rep")

    def rep(self, length: float = math.pi):
        """The representative for the next step that can meet a self-motion: ``rep`` times 1, -2, 3,
        -4, ... for the first, second, ... such step, so that one sweep of ``rep`` moves two families
        of one target independently (a shoulder and a wrist singularity at once); ``length`` is what
        ``rep = pi`` stands for (pi for an angle, the joint's travel for a slide)."""
        self.reps += 1
        factor = (self.reps if self.reps % 2 else -self.reps) * length / math.pi
        rep = ir.Name("rep")
        return rep if factor == 1.0 else self.c.lin([(factor, rep)])

    def twist(self, j, key, sign):
        """Joint j's axis carried by the motion ``key``: ``(w, r)`` (revolute) or ``(v,)`` (prismatic)."""
        G = self.prefix(key)
        if self.kinds[j] == "T":
            return (self.c.scaled(sign, self.c.mat_vec(G, self.twists[j][:3], False)),)
        w, r = self.axis(j)
        return self.c.scaled(sign, self.c.mat_vec(G, w, False)), self.c.mat_vec(G, r, True)

    def screw(self, tw, kind):
        """The 6 entries ``(v, w)`` of a carried axis: ``(v, 0)`` for a slide, ``(r x w, w)`` for a turn."""
        if kind == "T":
            return list(tw[0]) + [0.0, 0.0, 0.0]
        w, r = tw
        v = []
        for j, k in ((1, 2), (2, 0), (0, 1)):  # (r x w)_i = r_j w_k - r_k w_j
            plus, minus = self.c.product(r[j], w[k]), self.c.product(r[k], w[j])
            terms = ([plus] if plus else []) + ([(-minus[0], minus[1])] if minus else [])
            v.append(self.c.lin(terms, "v"))
        return v + list(w)

    def reference_call(self, code, tws, inputs):
        """A step with no plain-arithmetic kernel: its subproblem's reference solver (``_fk.reference``)."""
        kinds = code.split("-")[1]
        screws = tuple(_arg(self.screw(t, k)) for t, k in zip(tws, kinds))
        return ("reference", code, screws, tuple((k, _arg(v)) for k, v in inputs.items()))

    # -- what a step's lowering uses (the steps' ``lower`` methods, ikcompiler/steps/kinds.py) ---------
    Unsupported = Unsupported

    def rewrite(self, step, Td):
        """The step's equation with its known factors moved right (rule 7): ``(G_u, all_key, sign, Tp)``,
        ``G_u[u]`` the motion key carrying unknown u, ``Tp`` the target (inverted for rule 5)."""
        c = self.c
        known = set(step.known)
        missing = [j for j in known if j not in self.q]
        if missing:
            raise Unsupported(f"joints {missing} known to the plan but not to the emitter")
        G_u, all_key = self.equation(known)
        inverted = getattr(step, "inverted", None)
        sign = -1.0 if inverted else 1.0
        Tp = c.mat_mul(Td, c.inverse(self.prefix(all_key)))
        if inverted:
            Tp = c.inverse(Tp)
        return G_u, all_key, sign, Tp

    def point_image(self, step, G_u, all_key, Tp):
        """The step's point ``p0`` carried by its trailing axes, and its image under ``Tp``."""
        key = G_u[step.trail[0]] if step.trail else all_key
        point = self.c.mat_vec(self.prefix(key), step.p0, True)
        return point, self.c.mat_vec(Tp, point, True)

    @staticmethod
    def kernel(name: str, *args):
        """A call of the kernel ``name`` of subproblems/fast.py (its C port in fast_kernels.h)."""
        return _call(name, *args)

    def slot_names(self, count: int) -> list[str]:
        """The names of a loop's ``count`` outputs, numbered by the next name."""
        return [f"a{self.c.count}_{i}" for i in range(count)]

    def solved(self, joints, call) -> list:
        """Loop over the slots of ``call`` (the rest of the chain nests inside), its outputs the values
        of ``joints``; coupled joints follow."""
        outs = self.loop(self.slot_names(len(joints)), call)
        for j, name in zip(joints, outs):
            self.q[j] = name
        self.couple(joints)
        return outs

    def loop(self, outs, call) -> list:
        """Loop over the slots of ``call`` binding the names ``outs``: the rest of the chain nests inside."""
        flag = f"f{self.c.count}"
        self.c.count += 1
        if call[0] == "kernel":
            loop = ir.Loop(call[1], call[2], tuple(outs), flag, [])
        else:
            loop = ir.ReferenceLoop(call[1], call[2], call[3], tuple(outs), flag, [])
        self.c.emit(loop)
        self.c.blocks.append(loop.body)  # the rest of the chain runs once per slot
        self.flags.append(flag)
        return [ir.Name(name) for name in outs]

    def leaf(self, independent, goal):
        c = self.c
        n = len(self.kinds)
        missing = [j for j in range(n) if j not in self.q]
        if missing:
            raise Unsupported(f"joints {missing} not solved by the plan")
        F = c.mat_mul(self.prefix(tuple(range(n))), [float(x) for x in self.home[:3, :3].ravel()] +
                      [float(x) for x in self.home[:3, 3]])
        parts = []
        if self.target in ("pose", "position"):
            dp = [c.lin([(1.0, F[9 + i]), (-1.0, goal[9 + i])]) for i in range(3)]
            parts.append(c.let(ir.call("sqrt", _sumsq(dp)), "ep"))
        if self.target in ("pose", "orientation"):
            dR = [c.lin([(1.0, F[i]), (-1.0, goal[i])]) for i in range(9)]
            # Frobenius norm of the rotation error: the precision contract (docs/finish.md)
            parts.append(c.let(ir.binop("*", self.scale, ir.call("sqrt", _sumsq(dR))), "er"))
        c.emit(ir.Leaf(tuple(ir.const(self.q[j]) for j in independent), tuple(parts), tuple(self.flags)))


def classify_pairs(steps, twists, kinds, scale):
    """The steps with each S2-RR step's axis relation (``meet``, ``parallel``, ``skew``: which kernel
    solves it) as the compiler recorded it (``geometry/facts.py``, docs/design.md section 10).  A step
    without it (a module written before the relation was recorded in ``_STEPS``) is judged now, by the
    same function on the same configurations."""
    out = []
    for step in steps:
        if step.code == "S2-RR" and step.kind == "S2" and step.axes is None:
            th = facts.configurations(kinds, scale)
            axes = facts.step_axes(step, np.asarray(twists, float), kinds, scale, th)
            step = dataclasses.replace(step, axes=axes)
        out.append(step)
    return out


@dataclass(frozen=True)
class ChainData:
    """What the fast chain is built from; a generated module holds every field (``from_module``).

    ``twists`` are the plan's (the snapped robot's for a snapped plan), ``kinds`` / ``home`` /
    ``couplings`` (joint, master, a, b) the chain's with its mimic joints; ``known`` the joints the
    chain takes as inputs ``free[0], free[1], ...`` (the free joints, then a search plan's searched
    joints); ``independent`` the joints a leaf returns; ``vary`` / ``lower`` / ``upper`` the
    independent joints and their limits (the slide length a representative stands for)."""

    method: str
    target: str
    steps: tuple
    twists: np.ndarray
    kinds: str
    home: np.ndarray
    couplings: tuple
    known: tuple
    independent: tuple
    vary: tuple
    lower: tuple
    upper: tuple
    scale: float
    search: bool
    # a snapped plan (its twists the snapped robot's): S2-RRR keeps its reference solver, whose
    # near-miss rows seed the true robot's solutions at a fold (PointStep.lower)
    snapped: bool = False

    @classmethod
    def from_plan(cls, plan, chain, *, independent, free_joints, scale) -> ChainData:
        couplings = tuple((chain.index(cp.joint), chain.index(cp.master), cp.a, cp.b)
                          for cp in chain.couplings)
        return cls(
            method=plan.method, target="virtual" if plan.virtual else plan.target, steps=tuple(plan.steps),
            twists=np.asarray(plan.plan_twists if plan.plan_twists else chain.twists, dtype=float),
            kinds=chain.joint_types, home=np.asarray(chain.home, float), couplings=couplings,
            known=tuple(free_joints) + tuple(plan.search), independent=tuple(independent),
            vary=tuple(chain.independent), lower=tuple(map(float, chain.lower)),
            upper=tuple(map(float, chain.upper)), scale=float(scale), search=bool(plan.search),
            snapped=bool(plan.snapped))

    @classmethod
    def from_module(cls, ns, steps_name: str = "_STEPS") -> ChainData:
        """The data of a generated module's namespace (its globals), for its chain ``steps_name``."""
        search = tuple(ns["_SEARCH"])
        return cls(
            method=ns["METHOD"], target=ns["TARGET"] if ns["_SOLVE_TARGET"] == ns["TARGET"] else "virtual",
            steps=tuple(ns[steps_name]), twists=np.asarray(ns["_PLAN_TWISTS"], float), kinds=ns["_KINDS"],
            home=np.asarray(ns["_HOME"], float), couplings=tuple(tuple(c) for c in ns["_COUPLINGS"]),
            known=tuple(ns["_INDEPENDENT"][k] for k in ns["_FREE"]) + search,
            independent=tuple(ns["_INDEPENDENT"]), vary=tuple(ns["_VARY"]),
            lower=tuple(map(float, ns["_VARY_LOWER"])), upper=tuple(map(float, ns["_VARY_UPPER"])),
            scale=float(ns["SCALE"]), search=bool(search), snapped=bool(ns["_POLISH"]))

    def spans(self) -> list:
        """Per joint, the slide length a representative ``rep = pi`` stands for: the larger limit's
        size (the robot's size when a limit is infinite); a mimic joint's from its master's limits."""
        own = {}
        for j, lo, hi in zip(self.vary, self.lower, self.upper):
            own[j] = max(abs(lo), abs(hi)) if math.isfinite(lo) and math.isfinite(hi) else self.scale
        for dep, master, a, b in self.couplings:
            if master in own and dep not in own:
                k = self.vary.index(master)
                ends = (a * self.lower[k] + b, a * self.upper[k] + b)
                own[dep] = max(map(abs, ends)) if all(map(math.isfinite, ends)) else self.scale
        return [own.get(j, self.scale) for j in range(len(self.kinds))]


def build_program(data: ChainData, *, cse: bool = True) -> ir.Program | None:
    """The IR of ``_fast_chain`` for ``data``, or None when the plan is not covered.

    The chain takes the values of ``data.known`` (free joints, then a search plan's searched joints:
    it is then the closed form that treats them as known).  A snapped plan is built on the snapped
    robot's twists: its leaves are candidates that Newton steps then correct on the true robot.
    ``cse``: name common subexpressions (off only to measure what it saves)."""
    if data.method not in ("closed-form", "1d-search", "2d-search") or data.target not in FAST_TARGETS:
        return None
    steps = [s if isinstance(s, Step) else Step.from_module_entry(s) for s in data.steps]
    steps = classify_pairs(steps, data.twists, data.kinds, data.scale)
    em = _Emitter(data.twists, data.kinds, data.home, data.couplings, list(data.known), data.scale,
                  data.target, data.spans(), data.snapped)
    c = em.c
    goal = [ir.Name(f"g{i}") for i in range(12)]
    H = data.home
    Hinv = np.linalg.inv(H)
    if data.target == "position":
        Td = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0] + [c.lin([(1.0, goal[9 + i]), (-H[i, 3], 1.0)])
                                                             for i in range(3)]
    else:
        Td = c.mat_mul(goal if data.target == "pose" else goal[:9] + [0.0, 0.0, 0.0],
                       [float(x) for x in Hinv[:3, :3].ravel()] + [float(x) for x in Hinv[:3, 3]])
    try:
        for step in steps:
            step.lower(em, Td)
        em.leaf(data.independent, goal)
    except Unsupported:
        return None
    program = ir.without_dead_code(ir.Program(tuple(g.id for g in goal), c.body))
    if data.search and has_reference(program):
        # A search runs the chain on every grid value; a general solver inside it would run on every
        # parent slot, valid or not (measured up to 4x slower than the reference runtime, which runs
        # it on the valid rows only), so such a search keeps the reference runtime.
        return None
    return ir.eliminate_common(program) if cse else program


def has_reference(program: ir.Program) -> bool:
    """Whether a step of the program calls its subproblem's reference solver (no C port)."""
    def walk(block):
        return any(isinstance(s, ir.ReferenceLoop) or (ir.body_of(s) is not None and walk(ir.body_of(s)))
                   for s in block)
    return walk(program.body)


def fast_chain_program(plan, chain, *, independent, free_joints, scale, cse: bool = True):
    """The IR of ``plan``'s fast chain (:func:`build_program`), or None when the plan is not covered."""
    data = ChainData.from_plan(plan, chain, independent=independent, free_joints=free_joints, scale=scale)
    return build_program(data, cse=cse)
