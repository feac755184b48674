"""Typed plan steps (ikcompiler.steps) and the plan as JSON (docs/design.md section 12).

On every zoo robot, the README's target variants, the three fallbacks (1-D search, 2-D search,
numerical) and a calibrated arm (a snapped plan): the plan survives ``to_json`` / ``from_json``
unchanged and the module generated from the read-back plan is the same text; every step's dict view
agrees with its ``to_dict()``; the steps are in an order where each one's run-time inputs are solved
before it; and malformed plans raise typed errors naming the field.
"""

from __future__ import annotations

import dataclasses
import json

import pytest

from ikcompiler import compiler
from ikcompiler.cli import main
from ikcompiler.compiler import compile_plan, plan_source
from ikcompiler.configs import perturbed, random_chain
from ikcompiler.errors import PlanFormatError
from ikcompiler.geometry.facts import dependent_joints
from ikcompiler.inputs import load_robot
from ikcompiler.inputs.zoo import zoo_names
from ikcompiler.plan import Plan
from ikcompiler.steps import STEP_KINDS, Step, SumStep, step_class, step_from_dict

VARIANTS = {  # the README's variants beside the default pose target
    "panda": ("pose", ("panda_joint7",)),
    "shadow_index": ("position", ()),
    "shadow_thumb": ("position+direction", ()),
    "puma560": ("orientation", ("j1", "j2", "j3")),
}


CASES = [n for n in zoo_names() if n != "panda"] + [f"{n}:{t}" for n, (t, _) in VARIANTS.items()]
CASES += ["jaco:search", "general:TRRRRR", "general:TTTTR", "puma560:perturbed"]


@pytest.fixture(scope="module", params=CASES)
def compiled(request, monkeypatch_module):
    name, _, variant = request.param.partition(":")
    target, free = "pose", ()
    if name == "general":
        chain = random_chain(variant)
        if variant == "TRRRRR":  # general-6r solves it now (prismatic joint 1): the 2-D search kept covered
            monkeypatch_module.setattr(compiler, "USE_GENERAL6", False)
        if variant == "TTTTR":  # rank 4 of 5, refused by the compiler now (design.md section 5,
            # "Rank-deficient chains"): the refusal off here keeps the numerical plan covered
            monkeypatch_module.setattr(compiler, "dependent_joints", lambda *a, **k: ())
    else:
        chain = load_robot(name)
        if variant == "search":
            monkeypatch_module.setattr(compiler, "USE_GENERAL6", False)
        elif variant == "perturbed":  # a calibrated arm: a snapped plan carries the snapped twists
            chain = perturbed(chain, 1e-6)
        elif variant:
            target, free = VARIANTS[name]
    plan = compile_plan(chain, target=target, free=free)
    monkeypatch_module.setattr(compiler, "USE_GENERAL6", True)
    monkeypatch_module.setattr(compiler, "dependent_joints", dependent_joints)
    return request.param, chain, plan


@pytest.fixture(scope="module")
def monkeypatch_module():
    with pytest.MonkeyPatch.context() as mp:
        yield mp


def test_the_cases_reach_every_method(compiled):
    """The cases above exercise the fallbacks they are named for (else the round trips below would not
    cover the NUM and search plans)."""
    case, _, plan = compiled
    expected = {
        "jaco": "general-6r",
        "jaco:search": "1d-search",
        "general:TRRRRR": "2d-search",
        "general:TTTTR": "numerical",
    }.get(case, "closed-form")
    assert plan.method == expected, (case, plan.method)
    assert bool(plan.plan_twists) == (case == "puma560:perturbed"), case


def test_plan_json_round_trip(compiled):
    case, chain, plan = compiled
    text = plan.to_json()
    json.loads(text, parse_constant=lambda c: pytest.fail(f"{case}: non-standard JSON constant {c}"))
    back = Plan.from_json(text)
    assert back == plan, case
    assert back.explain() == plan.explain(), case
    pairs = zip(back.steps + back.alternative, plan.steps + plan.alternative)
    assert all(type(a) is type(b) for a, b in pairs), case
    # the serialised plan carries everything the code generator reads
    assert plan_source(back, chain) == plan_source(plan, chain), case


def test_step_dict_view_agrees_with_to_dict(compiled):
    case, _, plan = compiled
    for step in plan.steps + plan.alternative:
        assert isinstance(step, STEP_KINDS[step.kind]), (case, step)
        data = step.to_dict()
        assert data["kind"] == step.kind and dict(step) == data and len(step) == len(data)
        for key, value in data.items():
            assert key in step and step[key] == value and step.get(key) == value, (case, key)
        assert "no_such_field" not in step and step.get("no_such_field") is None
        with pytest.raises(KeyError):
            step["no_such_field"]
        assert step_from_dict(data) == step and step_from_dict(json.loads(json.dumps(data))) == step
        assert hash(step) == hash(step_from_dict(data))


def test_steps_are_immutable(compiled):
    _, _, plan = compiled
    step = plan.steps[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        step.code = "S9"
    view = step.get("solve")
    if view is not None:
        view.append(99)  # the view hands out copies
        assert 99 not in step["solve"]


def test_each_step_needs_only_what_is_solved_before_it(compiled):
    """Closed-form chains: a step's run-time inputs (``needs``; a sum step also its group's sum) are
    free, solved by an earlier step, or coupled to such a joint; at the end every joint is solved."""
    case, chain, plan = compiled
    if plan.method not in ("closed-form", "1d-search", "2d-search"):
        return
    names = plan.joint_names_all
    couplings = [(names.index(c.joint), names.index(c.master)) for c in chain.couplings]
    for steps in (plan.steps, plan.alternative):
        if not steps:
            continue
        solved = {names.index(f) for f in plan.free} | set(plan.search)
        sums = set()

        def close(joints):
            joints = set(joints)
            for _ in couplings:
                for dep, master in couplings:
                    if dep in joints or master in joints:
                        joints |= {dep, master}
            return joints

        solved = close(solved)
        for k, step in enumerate(steps, start=1):
            assert set(step.needs) <= solved, (case, k, step.needs, solved)
            if isinstance(step, SumStep):
                assert step.members in sums, (case, k)
            assert not set(step.solves) & solved, (case, k, "solves a joint already solved")
            solved = close(solved | set(step.solves))
            sums |= set(step.gives_sums)
        assert solved == set(range(len(names))), (case, solved)


def test_every_kind_is_registered_once_under_its_own_name():
    assert len(STEP_KINDS) == len(set(STEP_KINDS.values())) == 11
    for kind, cls in STEP_KINDS.items():
        assert cls.kind == kind and issubclass(cls, Step) and step_class(kind) is cls
        assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen


def test_explain_json_prints_the_plan(capsys):
    assert main(["explain", "rhino", "--json"]) == 0
    printed = Plan.from_json(capsys.readouterr().out)
    assert printed == compile_plan(load_robot("rhino"))


def _rhino_dict() -> dict:
    return json.loads(compile_plan(load_robot("rhino")).to_json())


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda d: d["steps"][0].update(kind="S9"), ["unknown step kind 'S9'"]),
        (lambda d: d["steps"][0].update(colour="red"), ["'O'", "colour"]),
        (lambda d: d["steps"][1].pop("p0"), ["'HT'", "missing", "p0"]),
        (lambda d: d["steps"][1].update(solve="q1"), ["'HT'", "'solve'", "tuple"]),
        (lambda d: d["steps"][1].update(inverted=0), ["'HT'", "'inverted'", "bool"]),
        (lambda d: d["steps"][3].update(group=None), ["'SUM'", "'group'", "null"]),
        (lambda d: d.update(version=99), ["version 99"]),
        (lambda d: d.update(extra=1), ["plan", "extra"]),
        (lambda d: d.pop("robot"), ["missing", "robot"]),
        (lambda d: d.update(robot=5), ["'robot'", "str"]),
        (lambda d: d.update(cost="cheap"), ["'cost'", "number"]),
        (lambda d: d.update(plan_twists=[[0.0] * 5]), ["'plan_twists'", "6-lists"]),
        (lambda d: d.update(steps={"kind": "O"}), ["'steps'", "list"]),
    ],
)
def test_malformed_plans_raise_typed_errors_naming_the_field(edit, words):
    data = _rhino_dict()
    edit(data)
    with pytest.raises(PlanFormatError) as err:
        Plan.from_json(json.dumps(data))
    for w in words:
        assert w in str(err.value), (w, str(err.value))


def test_text_that_is_not_json_raises_a_typed_error():
    with pytest.raises(PlanFormatError, match="does not parse"):
        Plan.from_json("{not json")
    with pytest.raises(PlanFormatError, match="must be an object"):
        step_from_dict(["O"])
