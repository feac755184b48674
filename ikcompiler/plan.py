"""A plan: the chosen chain of rules and subproblems, typed data between the search and the code
generator.  ``Plan.explain()`` renders it for ``ikc explain`` in the style of the paper's worked example;
``Plan.to_json()`` / ``Plan.from_json()`` serialise it (``ikc explain --json``; the schema is in
docs/design.md section 12).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field

from ikcompiler.errors import PlanFormatError
from ikcompiler.steps import Step, step_from_dict
from ikcompiler.steps.base import check_fields

PLAN_FORMAT = "ikcompiler-plan"
PLAN_VERSION = 1


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


@dataclass(frozen=True)
class Plan:
    robot: str
    joint_names: tuple[str, ...]
    kinds: str
    target: str
    method: str  # "closed-form", "numerical", ...
    steps: tuple[Step, ...]
    free: tuple[str, ...] = ()
    snapped: bool = False
    n_groups: int = 0
    geometry: tuple[str, ...] = ()
    notes: tuple[str, ...] = field(default=())
    cost: float = 0.0
    search: tuple[int, ...] = ()  # joints gridded by the 1-D / 2-D search fallback
    grid: int = 0
    all_names: tuple[str, ...] = ()  # every joint, coupled ones included (steps index these)
    alternative: tuple[Step, ...] = ()  # run for targets where ``steps`` meets a continuum
    plan_twists: tuple = ()  # twists of the snapped robot the steps were derived on (empty: the true ones)
    virtual: bool = False  # the last joint is a virtual tool roll (position + direction targets)

    @property
    def joint_names_all(self) -> tuple[str, ...]:
        return self.all_names or self.joint_names

    def step_lines(self, steps=None) -> list[str]:
        names = self.joint_names_all
        chain = self.steps if steps is None else steps
        return [f"step {k}: {s.describe(names)}" for k, s in enumerate(chain, start=1)]

    def explain(self) -> str:
        lines = [
            f"robot    {self.robot}",
            f"joints   {self.kinds}  ({', '.join(self.joint_names)})",
            f"target   {self.target}",
            f"method   {self.method}" + ("  (near-relations snapped, Newton-corrected)" * self.snapped),
        ]
        if self.free:
            lines.append(f"free     {', '.join(self.free)} (values passed at solve time)")
        if self.geometry:
            lines.append("")
            lines.append("geometry")
            lines += [f"  {g}" for g in self.geometry]
        lines.append("")
        lines.append("chain")
        if self.search:
            which = ", ".join(self.joint_names_all[j] for j in self.search)
            lines.append(
                f"  search over {which} on a grid of {self.grid} values per joint; for each value the "
                "closed form below gives candidates; local minima of the pose error along the grid are "
                "polished by Newton steps on every joint"
            )
        lines += [f"  {s}" for s in self.step_lines()]
        if self.alternative:
            lines.append("alternative chain (for targets where a step above meets a continuum)")
            lines += [f"  {s}" for s in self.step_lines(self.alternative)]
        for note in self.notes:
            lines.append(f"note: {note}")
        return "\n".join(lines)

    # -- serialisation (docs/design.md section 12, "The plan as JSON") ---------------------------------
    def to_dict(self) -> dict:
        """Plain JSON-ready data: tuples as lists, steps as their dicts, an infinite cost as None."""
        out = {"format": PLAN_FORMAT, "version": PLAN_VERSION}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name in ("steps", "alternative"):
                value = [s.to_dict() for s in value]
            elif f.name == "cost":
                value = float(value) if math.isfinite(value) else None
            elif f.name == "plan_twists":
                value = [[float(x) for x in row] for row in value]
            elif isinstance(value, tuple):
                value = list(value)
            out[f.name] = value
        return out

    def to_json(self, indent: int | None = None) -> str:
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    @classmethod
    def from_dict(cls, data) -> Plan:
        if not isinstance(data, dict):
            raise PlanFormatError(f"a plan must be a JSON object, got {type(data).__name__}")
        if data.get("format") != PLAN_FORMAT or data.get("version") != PLAN_VERSION:
            raise PlanFormatError(
                f"not a plan of format {PLAN_FORMAT!r} version {PLAN_VERSION}: "
                f"format {data.get('format')!r}, version {data.get('version')!r}"
            )
        fields = check_fields(cls, data, "plan", header=("format", "version"),
                              by_caller=("steps", "alternative", "cost"))
        kw = {}
        for name in fields:
            if name not in data:
                continue
            value = data[name]
            if name in ("steps", "alternative"):
                if not isinstance(value, list):
                    raise PlanFormatError(f"plan: field {name!r} must be a list of steps")
                value = tuple(step_from_dict(s) for s in value)
            elif name == "cost":
                if value is not None and not _is_number(value):
                    raise PlanFormatError(f"plan: field 'cost' must be a number or null, got {value!r}")
                value = math.inf if value is None else float(value)
            elif name == "plan_twists":
                if not all(
                    isinstance(row, (list, tuple)) and len(row) == 6 and all(map(_is_number, row))
                    for row in value
                ):
                    raise PlanFormatError("plan: field 'plan_twists' must hold 6-lists (v, w), one per joint")
                value = tuple(tuple(float(x) for x in row) for row in value)
            elif isinstance(value, list):
                value = tuple(value)
            kw[name] = value
        return cls(**kw)

    @classmethod
    def from_json(cls, text: str) -> Plan:
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise PlanFormatError(f"plan JSON does not parse: {exc}") from None
        return cls.from_dict(data)
