"""A plan: the chosen chain of rules and subproblems, plain data between the search and the code
generator.  ``Plan.explain()`` renders it for ``ikc explain`` in the style of the paper's worked example.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Plan:
    robot: str
    joint_names: tuple[str, ...]
    kinds: str
    target: str
    method: str  # "closed-form", "numerical", ...
    steps: tuple[dict, ...]
    free: tuple[str, ...] = ()
    snapped: bool = False
    n_groups: int = 0
    geometry: tuple[str, ...] = ()
    notes: tuple[str, ...] = field(default=())
    cost: float = 0.0
    search: tuple[int, ...] = ()  # joints gridded by the 1-D / 2-D search fallback
    grid: int = 0
    all_names: tuple[str, ...] = ()  # every joint, coupled ones included (steps index these)
    alternative: tuple[dict, ...] = ()  # run for targets where ``steps`` meets a continuum
    plan_twists: tuple = ()  # twists of the snapped robot the steps were derived on (empty: the true ones)
    virtual: bool = False  # the last joint is a virtual tool roll (position + direction targets)

    @property
    def joint_names_all(self) -> tuple[str, ...]:
        return self.all_names or self.joint_names

    def step_lines(self, steps=None) -> list[str]:
        names = self.joint_names_all
        out = []
        for k, s in enumerate(self.steps if steps is None else steps, start=1):
            if s["kind"] == "SUM":
                out.append(f"step {k}: {s['rule']}")
                continue
            if s["kind"] == "NUM":
                out.append(f"step {k}: {s['rule']}")
                continue
            if s["kind"] == "O":
                gives = [
                    names[g[0][0]]
                    if len(g) == 1
                    else "(" + " + ".join(("" if sg > 0 else "-") + names[j] for j, sg in g) + ")"
                    for g in s["groups"]
                ]
                what = ", ".join(gives)
            else:
                what = ", ".join(names[j] for j in s["solve"])
            out.append(f"step {k}: {s['code']} in ({what})  <-  {s['rule']}")
        return out

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
