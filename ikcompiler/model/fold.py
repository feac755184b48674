"""Fold each run of consecutive slides driven by one master into one slide (docs/design.md section 2,
"Folded slides").

Consecutive prismatic factors are translations, so they commute and add up.  When every joint of a run
follows the same independent joint ``q`` (the master itself with ``a = 1, b = 0``, mimics with
``th_i = a_i q + b_i``)::

    prod_i exp(v_i th_i) = Trans(d q + c0),   d = sum_i a_i v_i,   c0 = sum_i b_i v_i

which is ONE slide of unit direction ``u = d / |d|`` and value ``s = |d| q`` followed by the constant
translation ``E = Trans(c0)``.  E is carried past the later joints (``E exp(xi th) = exp(Ad_E xi th) E``)
into the home pose, as the loader does for an external master (``inputs/urdf.py``).  The folded chain
has the same forward kinematics and fewer unknowns: stretch's four telescoping slides (three mimicking
the first) become one, and the chain TTRRR has a closed form (S2-TTR at the wrist point, then O-RR).

The value solved for is ``s``, not ``q``: the slide keeps a unit direction, so every subproblem, the plan
runtime, the fast chain and its C see an ordinary prismatic joint, and the generated module converts at
its boundary (``_SPEED``: solved value = speed * returned value; ``ikcompiler/runtime/dispatch.py``).  A
non-unit twist would have touched every solver that assumes ``|v| = 1``.

Limits: each member's own limits give an interval of ``q`` (``(lo_i - b_i) / a_i`` ...); the master's
limits are the intersection of them all (an empty one raises, naming the joints).  A run whose master
lies elsewhere in the chain becomes one coupled slide (``th = |d| q``) and its members' limits narrow
the master's.

Not folded: revolute runs (coincident mimicking axes would add up the same way, but the folded angle
``k q`` is known modulo 2 pi only, so one folded solution stands for ``|k|`` master values, which the
finish would have to enumerate; no robot seen needs it), runs of one joint (a single mimic is already
no unknown), and runs whose summed direction cancels (:data:`~subproblems.tolerances.FOLD_SPEED`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ikcompiler.errors import RobotInputError
from ikcompiler.model.chain import Chain, Coupling, Joint
from subproblems.screw import transform_twist
from subproblems.tolerances import FOLD_SPEED


@dataclass(frozen=True)
class SlideFold:
    """One folded run: ``members`` (chain order) became the slide ``joint`` along ``direction``, whose
    value is ``speed`` times the value of ``master``."""

    joint: str
    members: tuple[str, ...]
    master: str
    speed: float
    direction: tuple[float, float, float]

    def note(self) -> str:
        u = ", ".join(f"{x:.6g}" for x in self.direction)
        return (f"folded slides: {', '.join(self.members)} follow {self.master!r} and commute: one slide "
                f"{self.joint!r} along ({u}) moving {self.speed:.6g} x {self.master} "
                "(docs/design.md section 2)")


@dataclass(frozen=True)
class FoldedChain:
    """The chain with its runs folded, and how its independent values relate to the original ones."""

    chain: Chain
    folds: tuple[SlideFold, ...]
    speed: tuple[float, ...]  # per independent joint (chain order): value solved = speed * master value

    @property
    def folded(self) -> bool:
        return bool(self.folds)

    @property
    def notes(self) -> tuple[str, ...]:
        return tuple(f.note() for f in self.folds)


def _runs(chain: Chain, master_of: dict[int, tuple[int, float, float]]) -> list[list[int]]:
    """Maximal runs of consecutive prismatic joints with one master, as lists of joint indices."""
    runs: list[list[int]] = []
    for i, j in enumerate(chain.joints):
        same = (runs and j.kind == "T" and chain.joints[runs[-1][-1]].kind == "T"
                and runs[-1][-1] == i - 1 and master_of[runs[-1][-1]][0] == master_of[i][0])
        if same:
            runs[-1].append(i)
        else:
            runs.append([i])
    return runs


def _master_interval(chain: Chain, members: list[int], master_of) -> tuple[float, float]:
    """The master values that keep every member of ``members`` inside its own limits."""
    lo, hi = -math.inf, math.inf
    for i in members:
        _, a, b = master_of[i]
        j = chain.joints[i]
        if a == 0.0:
            continue  # a member the master does not move: its limits say nothing about the master
        ends = sorted(((j.lower - b) / a, (j.upper - b) / a))
        lo, hi = max(lo, ends[0]), min(hi, ends[1])
    return lo, hi


def fold_slides(chain: Chain) -> FoldedChain:
    """The chain with every foldable run folded (see the module docstring); the chain itself when
    there is none."""
    master_of = {i: (i, 1.0, 0.0) for i in chain.independent}
    master_of.update(chain._resolve_couplings())
    runs = []
    for run in _runs(chain, master_of):
        if len(run) < 2:
            continue
        d = sum(master_of[i][1] * chain.joints[i].twist[:3] for i in run)
        if np.linalg.norm(d) > FOLD_SPEED:
            runs.append(run)
    if not runs:
        return FoldedChain(chain, (), tuple(1.0 for _ in chain.independent))

    # the master values every run's members allow: intersected into the master's own limits
    limits = {k: (chain.joints[k].lower, chain.joints[k].upper) for k in chain.independent}
    for run in runs:
        k = master_of[run[0]][0]
        lo, hi = _master_interval(chain, run, master_of)
        new = (max(limits[k][0], lo), min(limits[k][1], hi))
        if not new[0] <= new[1]:
            names = ", ".join(chain.joints[i].name for i in run)
            raise RobotInputError(
                f"the limits of the slides {names} (all driven by {chain.joints[k].name!r}) leave it "
                "no value in common", source=chain.source or chain.name,
                where=f"joint {chain.joints[k].name!r}")
        limits[k] = new

    first = {run[0]: run for run in runs}
    inside = {i for run in runs for i in run}
    speed = {k: 1.0 for k in chain.independent}
    folds, plan = [], []  # plan: ([joints], unit direction of the fold or None, speed) in chain order
    for i in range(chain.n):
        if i in first:
            run = first[i]
            k = master_of[i][0]
            d = sum(master_of[m][1] * chain.joints[m].twist[:3] for m in run)
            sp = float(np.linalg.norm(d))
            name = chain.joints[k].name if k in run else chain.joints[i].name
            if k in run:
                speed[k] = sp
            plan.append((run, d / sp, sp))
            folds.append(SlideFold(name, tuple(chain.joints[m].name for m in run), chain.joints[k].name, sp,
                                   tuple(float(x) for x in d / sp)))
        elif i not in inside:
            plan.append(([i], None, 1.0))

    E = np.eye(4)  # the constant translations of the runs so far, carried to the right
    joints, couplings = [], []
    for run, u, sp in plan:
        k, _, _ = master_of[run[0]]
        if u is None:  # a joint that is not folded: moved past E
            j = chain.joints[run[0]]
            lo, hi = limits.get(run[0], (j.lower, j.upper))
            joints.append(Joint(j.name, j.kind, transform_twist(E, j.twist), lo, hi))
            if run[0] not in chain.independent:
                _, a, b = master_of[run[0]]
                couplings.append(Coupling(j.name, chain.joints[k].name, a / speed[k], b))
            continue
        name = chain.joints[k].name if k in run else chain.joints[run[0]].name
        lo, hi = limits[k]  # a coupled slide's limits are not imposed (those of its master are)
        joints.append(Joint(name, "T", np.concatenate([u, np.zeros(3)]), sp * lo, sp * hi))
        if k not in run:  # driven by a master elsewhere: a coupled slide of value sp * q
            couplings.append(Coupling(name, chain.joints[k].name, sp / speed[k], 0.0))
        c0 = sum(master_of[m][2] * chain.joints[m].twist[:3] for m in run)
        E[:3, 3] += c0
    folded = Chain(name=chain.name, joints=tuple(joints), home=E @ chain.home, couplings=tuple(couplings),
                   base=chain.base, tip=chain.tip, units=chain.units, source=chain.source,
                   notes=chain.notes)
    return FoldedChain(folded, tuple(folds), tuple(speed[k] for k in chain.independent))
