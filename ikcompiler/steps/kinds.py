"""One frozen dataclass per step kind (docs/design.md section 12).  The equations each kind solves are
written in the module docstring of :mod:`subproblems.plan_runtime`, which runs them.

Fields shared by the kinds that rewrite the POE equation:

* ``known``: joints solved before this step (the equation moves their factors to the right);
* ``solve``: the joints this step fixes;
* ``inverted``: the step works on the inverted equation (rule 5);
* ``snapped``: a relation the step relies on holds only to the snap tolerance (its validation in the
  search then uses the looser trial tolerance, and the module polishes on the true robot).

Each kind owns its lowering, ``lower(em, Td)``: the code IR of its step in the fast chain, built with
the emitter ``em`` of :mod:`ikcompiler.codegen.fastpath` (docs/design.md section 11, "Code IR"): a
call of its kernel of ``subproblems/fast.py``, ``em.reference_call`` for a subproblem without a
kernel, or the base class's ``em.Unsupported``.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

from ikcompiler.codegen import ir
from ikcompiler.steps.base import Step

_frozen = dataclasses.dataclass(frozen=True, kw_only=True)

# The most IK solutions of a 6-DOF chain: the MAX_SOLUTIONS of the whole-chain methods.
WHOLE_CHAIN_SLOTS = 16


@_frozen
class S1Step(Step):
    """Class I on every unsolved joint: the rigid motion of the last unknowns (rules 5, 7)."""

    kind: ClassVar[str] = "S1"
    known: tuple[int, ...]
    inverted: bool
    solve: tuple[int, ...]

    def lower(self, em, Td) -> None:
        G_u, _, sign, Tp = em.rewrite(self, Td)
        tws = [em.twist(j, G_u[j], sign) for j in self.solve]
        if self.code == "S1-T":
            call = em.kernel("slide1", tws[0][0], Tp[9:])
        elif self.code == "S1-TTT":
            call = em.kernel("slide3", tws[0][0], tws[1][0], tws[2][0], Tp[9:])
        elif self.code == "S1-RTT":
            call = em.kernel("turn_slide2", tws[0][0], tws[0][1], tws[1][0], tws[2][0], Tp[:9], Tp[9:])
        else:
            call = em.reference_call(self.code, tws, {"T": Tp})
        em.solved(self.solve, call)


@_frozen
class OrientationStep(Step):
    """Orientation separation (rule 2): the revolute unknowns in runs of parallel axes; ``groups`` holds
    each run as ((joint, sign), ...), and the rotation gives each run's sum ``sum s_i th_i``.  A run of one
    joint gives that joint (``solve``); ``group_ids`` numbers the longer runs' sums (-1 for a single
    joint), set once the plan is final (search moves carry None)."""

    kind: ClassVar[str] = "O"
    known: tuple[int, ...]
    groups: tuple[tuple[tuple[int, float], ...], ...]
    solve: tuple[int, ...]
    snapped: bool
    group_ids: tuple[int, ...] | None = None

    @property
    def gives_sums(self):
        return tuple(g for g in self.groups if len(g) > 1)

    def lower(self, em, Td) -> None:
        G_u, _, sign, Tp = em.rewrite(self, Td)
        ws = [em.twist(g[0][0], G_u[g[0][0]], sign)[0] for g in self.groups]
        names = em.slot_names(len(ws))  # named before the representative's own name
        fn = {1: "rot_r", 2: "rot_rr", 3: "rot_rrr"}[len(ws)]
        outs = em.loop(names, em.kernel(fn, *ws, Tp[:9], *([em.rep()] if len(ws) == 3 else [])))
        for col, g in enumerate(self.group_ids):
            group = self.groups[col]
            if len(group) == 1:  # a joint of its own
                j, s = group[0]
                em.q[j] = em.c.lin([(s, outs[col])], "q")
            else:  # a parallel run's sum, for its SUM steps
                em.sig[g] = outs[col]
        em.couple(self.solve)

    def describe(self, names) -> str:
        gives = [
            names[g[0][0]]
            if len(g) == 1
            else "(" + " + ".join(("" if sg > 0 else "-") + names[j] for j, sg in g) + ")"
            for g in self.groups
        ]
        return f"{self.code} in ({', '.join(gives)})  <-  {self.rule}"


@_frozen
class OrientationAxialStep(Step):
    """Orientation plus axial projection (rules 2, 6): ``h^T R_mid x = h^T R' x``, ``h`` the axis of the
    leading parallel run ``lead``, ``x`` that of the trailing run ``trail``, one joint between."""

    kind: ClassVar[str] = "OH"
    known: tuple[int, ...]
    inverted: bool
    lead: tuple[int, ...]
    trail: tuple[int, ...]
    solve: tuple[int, ...]
    snapped: bool


@_frozen
class PointStep(Step):
    """Rule 1, point to point: the point ``p0`` (home frame, carried by the joint ``trail[0]``) is fixed
    by the trailing axes ``trail``; ``prod_rest exp(xi' th) p = T' p`` in the ``solve`` joints.  With no
    trailing axes ``p0`` is the tool point (position targets)."""

    kind: ClassVar[str] = "S2"
    known: tuple[int, ...]
    inverted: bool
    trail: tuple[int, ...]
    p0: tuple[float, float, float]
    snapped: bool
    solve: tuple[int, ...]
    # S2-RR: the relation of the two unknown axes in every sampled configuration ("parallel", "meet",
    # "skew"), recorded by the compiler (ikcompiler/geometry/facts.py, docs/design.md section 10)
    axes: str | None = None

    def lower(self, em, Td) -> None:
        G_u, all_key, sign, Tp = em.rewrite(self, Td)
        point, Tpp = em.point_image(self, G_u, all_key, Tp)
        args = [em.twist(j, G_u[j], sign) for j in self.solve]
        if self.code == "S2-R":
            call = em.kernel("point_r", args[0][0], args[0][1], point, Tpp)
        elif self.code == "S2-RR" and self.axes in ("parallel", "meet"):
            (w1, r1), (w2, r2) = args
            fn = "point_rr_parallel" if self.axes == "parallel" else "point_rr_meet"
            call = em.kernel(fn, w1, r1, w2, r2, point, Tpp, em.lock_rep())
        elif self.code == "S2-RRR" and not em.snapped:  # the regular case; the kernel defers the others
            # (a snapped plan keeps the reference solver: its near-miss rows at a complex pair seed
            # the true robot's solutions born at a fold, tests/test_near_miss_rows.py)
            (w1, r1), (w2, r2), (w3, r3) = args
            call = em.kernel("point_rrr", w1, r1, w2, r2, w3, r3, point, Tpp)
        elif self.code in ("S2-T", "S2-TTT"):
            b = [em.c.lin([(1.0, a), (-1.0, x)]) for a, x in zip(Tpp, point)]
            slides = [a[0] for a in args]
            call = em.kernel("slide1" if len(slides) == 1 else "slide3", *slides, b)
        elif self.code == "S2-TTR":
            (v1,), (v2,), (w, r) = args
            call = em.kernel("slide2_turn", v1, v2, w, r, point, Tpp, em.rep())
        else:  # skew S2-RR and the types without a kernel: the general solver
            call = em.reference_call(self.code, args, {"p": point, "q": Tpp})
        em.solved(self.solve, call)


@_frozen
class DistanceStep(PointStep):
    """Rules 1 and 3: also a point ``c0`` fixed by the leading axes ``lead``: the distance
    ``|| prod_mid exp(xi' th) p - c || = || T' p - c ||``."""

    kind: ClassVar[str] = "S3"
    lead: tuple[int, ...]
    c0: tuple[float, float, float]

    def lower(self, em, Td) -> None:
        c = em.c
        G_u, all_key, sign, Tp = em.rewrite(self, Td)
        point, Tpp = em.point_image(self, G_u, all_key, Tp)
        args = [em.twist(j, G_u[j], sign) for j in self.solve]
        centre = c.mat_vec(em.prefix(G_u[self.lead[0]]), self.c0, True)
        diff = [c.lin([(1.0, a), (-1.0, b)]) for a, b in zip(Tpp, centre)]
        d = c.let(ir.call("sqrt", c.dot(diff, diff)), "d")
        if self.code == "S3-R":
            call = em.kernel("dist_r", args[0][0], args[0][1], point, centre, d, em.rep())
        elif self.code == "S3-T":
            call = em.kernel("dist_t", args[0][0], point, centre, d)
        else:
            call = em.reference_call(self.code, args, {"p": point, "q": centre, "d": d})
        em.solved(self.solve, call)


@_frozen
class CoupledDistanceStep(DistanceStep):
    """Rule 3 with a coupled pair in the middle (``th_k = a th_j + b``, the Shadow finger): one angle
    ``var`` through the two exponentials of ``solve_pair``, all roots of the distance equation on the
    circle (``coupling`` = [a, b])."""

    kind: ClassVar[str] = "S3C"
    solve_pair: tuple[int, int]
    var: int
    coupling: tuple[float, float]

    @property
    def slots(self) -> int:
        from subproblems.plan_runtime import COUPLED_ROOT_SLOTS

        return COUPLED_ROOT_SLOTS

    def lower(self, em, Td) -> None:  # its root search runs in the reference runtime only
        raise em.Unsupported(f"step kind {self.kind}")


@_frozen
class LeadingAxialStep(PointStep):
    """Rules 1 and 6: the leading axes ``lead`` are parallel to ``h``:
    ``h^T prod_mid exp(xi' th) p = h^T T' p``."""

    kind: ClassVar[str] = "HL"
    lead: tuple[int, ...]

    def lower(self, em, Td) -> None:
        _lower_axial(self, em, Td, trailing=False)


@_frozen
class TrailingAxialStep(PointStep):
    """Rules 1 and 6 on the other side: the parallel run ``lead`` after the single unknown ``a`` keeps
    the component along its direction: ``h^T exp(-xi'_a th_a) T' p = h^T p``."""

    kind: ClassVar[str] = "HT"
    lead: tuple[int, ...]

    def lower(self, em, Td) -> None:
        _lower_axial(self, em, Td, trailing=True)


def _lower_axial(step, em, Td, trailing: bool) -> None:
    """Rule 6 with the axis ``h`` of the parallel run ``lead``: HL projects the carried point
    (``h . exp(xi th) p = h . T'p``), HT the target (``h . exp(-xi th) T'p = h . p``)."""
    c = em.c
    G_u, all_key, sign, Tp = em.rewrite(step, Td)
    point, Tpp = em.point_image(step, G_u, all_key, Tp)
    args = [em.twist(j, G_u[j], sign) for j in step.solve]
    lead = step.lead[0]
    if em.kinds[lead] != "R":
        raise em.Unsupported("rule 6 along a prismatic group")
    h = em.twist(lead, G_u[lead], 1.0)[0]
    if trailing:  # the inverse motion of the unknown: its axis reversed
        p_in, d = Tpp, c.dot(h, point, "d")
        tw = tuple([c.scaled(-1.0, args[0][0])] + list(args[0][1:]))
    else:
        p_in, d = point, c.dot(h, Tpp, "d")
        tw = args[0]
    letters = step.code.split("-")[1]
    if letters == "R":
        call = em.kernel("plane_r", tw[0], tw[1], p_in, h, d, em.rep())
    elif letters == "T":
        call = em.kernel("plane_t", tw[0], p_in, h, d, em.rep(em.spans[step.solve[0]]))
    else:
        if trailing:
            args = [tuple([c.scaled(-1.0, t[0])] + list(t[1:])) for t in args]
        call = em.reference_call(step.code, args, {"p": p_in, "h": h, "d": d})
    em.solved(step.solve, call)


@_frozen
class SumStep(Step):
    """A joint from a known parallel-group sum (rule 2): ``th_j = (sigma - sum_{m != j} s_m th_m) / s_j``
    over the group ``members`` ((joint, sign), ...); ``group`` is the sum's id, set once the plan is final
    (search moves carry None)."""

    kind: ClassVar[str] = "SUM"
    known: tuple[int, ...]
    solve: tuple[int, ...]
    members: tuple[tuple[int, float], ...]
    group: int | None = None

    @property
    def needs(self) -> tuple[int, ...]:
        return tuple(m for m, _ in self.members if m not in self.solve)

    @property
    def slots(self) -> int:
        return 1

    def describe(self, names) -> str:
        return self.rule

    def lower(self, em, Td) -> None:
        j = self.solve[0]
        s_j = dict(self.members)[j]
        terms = [(1.0 / s_j, em.sig[self.group])] + [(-s / s_j, em.q[m]) for m, s in self.members if m != j]
        em.q[j] = em.c.lin(terms, "q")
        em.couple()


@_frozen
class NumericalStep(Step):
    """The numerical fallback: Gauss-Newton on the whole chain from ``starts`` fixed starts, ``iters``
    iterations each; it solves every joint at once (no joint list: ``solves`` is empty)."""

    kind: ClassVar[str] = "NUM"
    starts: int
    iters: int

    @property
    def slots(self) -> int:
        return WHOLE_CHAIN_SLOTS

    def describe(self, names) -> str:
        return self.rule


@_frozen
class General6Step(Step):
    """The general 6R elimination (subproblems.general6) on the whole chain, trying the elimination
    ``arrangements`` in order; ``native``: those the C elimination runs, in the same order
    (``codegen.csource.general6_native_arrangements``; empty: the module has no C chain); ``fold``: the
    chain index of a free joint between solved joints, whose value folds the twists after it
    (runtime/freefold.py), or None (free joints, if any, at the chain's ends)."""

    kind: ClassVar[str] = "G6R"
    solve: tuple[int, ...]
    arrangements: tuple[int, ...]
    native: tuple[int, ...] = ()
    fold: int | None = None

    @property
    def slots(self) -> int:
        return WHOLE_CHAIN_SLOTS
