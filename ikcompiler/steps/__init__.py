"""Typed plan steps: one frozen dataclass per step kind, and the registry from kind to class
(docs/design.md section 12, "A new step kind").

``Plan.steps`` holds these objects; a generated module holds their ``to_dict()`` form in ``_STEPS``.
"""

from __future__ import annotations

from ikcompiler.errors import PlanFormatError
from ikcompiler.steps.base import Step
from ikcompiler.steps.kinds import (
    CoupledDistanceStep,
    DistanceStep,
    General6Step,
    LeadingAxialStep,
    NumericalStep,
    OrientationAxialStep,
    OrientationStep,
    PointStep,
    S1Step,
    SumStep,
    TrailingAxialStep,
)

STEP_KINDS: dict[str, type[Step]] = {
    cls.kind: cls
    for cls in (
        S1Step,
        OrientationStep,
        OrientationAxialStep,
        PointStep,
        DistanceStep,
        CoupledDistanceStep,
        LeadingAxialStep,
        TrailingAxialStep,
        SumStep,
        NumericalStep,
        General6Step,
    )
}


def step_class(kind) -> type[Step]:
    """The class of a step kind; a typed error naming the kind and the known ones otherwise."""
    try:
        return STEP_KINDS[kind]
    except (KeyError, TypeError):
        raise PlanFormatError(f"unknown step kind {kind!r}; known kinds: {', '.join(STEP_KINDS)}") from None


def step_from_dict(data) -> Step:
    """The typed step of a plain step dict (the ``to_dict()`` form)."""
    return Step.from_dict(data)


__all__ = ["STEP_KINDS", "Step", "step_class", "step_from_dict"] + [c.__name__ for c in STEP_KINDS.values()]
