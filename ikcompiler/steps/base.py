"""The common base of the typed plan steps (docs/design.md section 12, "A new step kind").

A step is a frozen dataclass: its fields are the step's data, tuples all the way down so that a step is
immutable and hashable.  ``to_dict()`` gives the plain-dict form that generated modules hold in
``_STEPS`` and that the plan's JSON carries (lists instead of tuples; a field whose value is None is
absent); ``from_dict()`` reads it back.

Transition: a step also reads like that dict (``step["solve"]``, ``step.get("inverted")``,
``"lead" in step``), a read-only Mapping view over the fields present, so that code written against the
old dicts (codegen, the reference runtime) keeps working while it moves to the attributes.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Iterator, Mapping
from typing import Any, ClassVar

import numpy as np

from ikcompiler.errors import PlanFormatError


def freeze(value: Any) -> Any:
    """Lists (nested) as tuples, numpy scalars as Python numbers: the immutable, JSON-ready form a step
    stores (the module prints a numpy and a Python number the same way)."""
    if isinstance(value, (list, tuple)):
        return tuple(freeze(v) for v in value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    return value


def thaw(value: Any) -> Any:
    """Tuples (nested) as lists: the dict form of generated modules and JSON."""
    if isinstance(value, (list, tuple)):
        return [thaw(v) for v in value]
    return value


def fits_annotation(annotation: str, value: Any) -> bool:
    """Whether a value read from JSON has the shape a field's annotation asks for (outer type only)."""
    outer = annotation.split(" | ")[0]
    if outer.startswith("tuple"):
        return isinstance(value, (list, tuple))
    if outer == "bool":
        return isinstance(value, bool)
    if outer == "int":
        return isinstance(value, int) and not isinstance(value, bool)
    if outer == "str":
        return isinstance(value, str)
    return True


def check_fields(cls: type, data: Mapping, what: str, *, header=(), by_caller=(), null_unset=False) -> dict:
    """Check the plain-dict form ``data`` of the dataclass ``cls`` (a step or a plan) field by field and
    return ``cls``'s fields by name.  No field beyond those and the ``header`` keys, none missing that
    has no default, each value of the outer shape its annotation asks for (the fields ``by_caller`` are
    checked by the caller); with ``null_unset`` a null value is refused as such (the dict form leaves an
    unset field out).  ``what`` names the object in the typed errors ("plan", "step 'O'")."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - set(fields) - set(header))
    if unknown:
        raise PlanFormatError(f"{what}: unknown field(s) {', '.join(unknown)}")
    missing = [
        n
        for n, f in fields.items()
        if n not in data and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise PlanFormatError(f"{what}: missing field(s) {', '.join(missing)}")
    for name, value in data.items():
        if name not in fields or name in by_caller:
            continue
        if null_unset and value is None:
            raise PlanFormatError(f"{what}: field {name!r} is null (an unset field is left out)")
        if not fits_annotation(str(fields[name].type), value):
            raise PlanFormatError(f"{what}: field {name!r} must be {fields[name].type}, got {value!r}")
    return fields


@dataclasses.dataclass(frozen=True, kw_only=True)
class Step(Mapping):
    """One step of a plan: a canonical subproblem (``code``) and the derivation in words (``rule``).

    Subclasses set ``kind`` (the registry key, the dict's ``"kind"``) and add their fields; optional
    fields default to None and are then absent from the dict form.
    """

    kind: ClassVar[str] = ""
    code: str
    rule: str

    def __post_init__(self):
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, freeze(getattr(self, f.name)))

    # -- what the step does ----------------------------------------------------------------------------
    @property
    def solves(self) -> tuple[int, ...]:
        """Joints (chain indices) whose values this step fixes."""
        return tuple(getattr(self, "solve", ()) or ())

    @property
    def needs(self) -> tuple[int, ...]:
        """Joints whose values the step reads at run time (solved by earlier steps or given free)."""
        return tuple(getattr(self, "known", ()) or ())

    @property
    def gives_sums(self) -> tuple[tuple[tuple[int, float], ...], ...]:
        """Parallel-group sums ``sum s_i th_i`` this step fixes (as ((joint, sign), ...) groups)."""
        return ()

    @property
    def slots(self) -> int:
        """Solution slots: the most branches this step can open per incoming branch."""
        from subproblems import max_solutions

        return max_solutions(self.code)

    def describe(self, names) -> str:
        """The explain line (without its "step k:" number); ``names`` index the chain's joints."""
        return f"{self.code} in ({', '.join(names[j] for j in self.solves)})  <-  {self.rule}"

    # -- plain-dict form -------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        out = {"kind": self.kind}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if value is not None:
                out[f.name] = thaw(value)
        return out

    @classmethod
    def from_dict(cls, data: Mapping) -> Step:
        """The step of ``data`` (its class chosen by ``data["kind"]`` when called on :class:`Step`)."""
        from ikcompiler.steps import step_class

        if not isinstance(data, Mapping):
            raise PlanFormatError(f"a step must be an object, got {type(data).__name__}")
        kind = data.get("kind")
        target = step_class(kind) if cls is Step else cls
        if kind != target.kind:
            raise PlanFormatError(f"step kind {kind!r} given to the {target.kind!r} step class")
        check_fields(target, data, f"step {kind!r}", header=("kind",), null_unset=True)
        return target(**{k: v for k, v in data.items() if k != "kind"})

    @classmethod
    def from_module_entry(cls, data: Mapping) -> Step:
        """The step of a generated module's ``_STEPS`` entry, which holds the fields the runtime and the
        code generator read (``STEP_FIELDS`` of codegen/module.py): the others (the rule, the snap
        flag) are absent there and get neutral values."""
        from ikcompiler.steps import step_class

        if not isinstance(data, Mapping):
            raise PlanFormatError(f"a step must be an object, got {type(data).__name__}")
        target = step_class(data.get("kind"))
        names = _field_names(target)
        filled = dict(data)
        for name, neutral in (("rule", ""), ("snapped", False)):
            if name in names and name not in filled:
                filled[name] = neutral
        return target.from_dict(filled)

    # -- lowering to the code IR -----------------------------------------------------------------------
    def lower(self, em, Td) -> None:
        """Append this step's code IR to the fast chain being built by ``em`` (the emitter of
        codegen/fastpath.py, docs/design.md section 11), ``Td`` the target as 12 IR entries.  A kind
        without a lowering raises ``em.Unsupported``: a plan holding it runs the reference runtime."""
        raise em.Unsupported(f"step kind {self.kind}")

    # -- read-only Mapping view (transition; see the module docstring) ---------------------------------
    def _present(self) -> list[str]:
        return ["kind"] + [n for n in _field_names(type(self)) if getattr(self, n) is not None]

    def __getitem__(self, key: str) -> Any:
        if key == "kind":
            return self.kind
        if key in _field_names(type(self)) and getattr(self, key) is not None:
            return thaw(getattr(self, key))
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        return iter(self._present())

    def __len__(self) -> int:
        return len(self._present())


@functools.cache
def _field_names(cls: type) -> tuple[str, ...]:
    """The dataclass fields of a step class, in order (looked up on every dict-view access)."""
    return tuple(f.name for f in dataclasses.fields(cls))
