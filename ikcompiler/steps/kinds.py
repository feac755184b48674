"""One frozen dataclass per step kind (docs/design.md section 12).  The equations each kind solves are
written in the module docstring of :mod:`subproblems.plan_runtime`, which runs them.

Fields shared by the kinds that rewrite the POE equation:

* ``known``: joints solved before this step (the equation moves their factors to the right);
* ``solve``: the joints this step fixes;
* ``inverted``: the step works on the inverted equation (rule 5);
* ``snapped``: a relation the step relies on holds only to the snap tolerance (its validation in the
  search then uses the looser trial tolerance, and the module polishes on the true robot).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

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


@_frozen
class DistanceStep(PointStep):
    """Rules 1 and 3: also a point ``c0`` fixed by the leading axes ``lead``: the distance
    ``|| prod_mid exp(xi' th) p - c || = || T' p - c ||``."""

    kind: ClassVar[str] = "S3"
    lead: tuple[int, ...]
    c0: tuple[float, float, float]


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


@_frozen
class LeadingAxialStep(PointStep):
    """Rules 1 and 6: the leading axes ``lead`` are parallel to ``h``:
    ``h^T prod_mid exp(xi' th) p = h^T T' p``."""

    kind: ClassVar[str] = "HL"
    lead: tuple[int, ...]


@_frozen
class TrailingAxialStep(PointStep):
    """Rules 1 and 6 on the other side: the parallel run ``lead`` after the single unknown ``a`` keeps
    the component along its direction: ``h^T exp(-xi'_a th_a) T' p = h^T p``."""

    kind: ClassVar[str] = "HT"
    lead: tuple[int, ...]


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
    ``arrangements`` in order."""

    kind: ClassVar[str] = "G6R"
    solve: tuple[int, ...]
    arrangements: tuple[int, ...]

    @property
    def slots(self) -> int:
        return WHOLE_CHAIN_SLOTS
