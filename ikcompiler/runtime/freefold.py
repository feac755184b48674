"""The general 6R elimination of a chain of seven revolute joints with one free joint anywhere: the
free joint's value folded into the chain (docs/design.md section 5, "General 6R" and "Snapping").

With ``E = exp(xi_f q_f)``, ``E exp(xi_k t) = exp((Ad_E xi_k) t) E``, so the twists after the free
joint become ``Ad_E xi_k`` and the home pose ``E g_st(0)``: one 6R chain per free value.

Two users:

* a general-6r plan whose free joint lies between solved joints (``compiler._general6_plan``): the
  arrangements are chosen at compile time on the chain folded at :data:`CHOICE_VALUES`
  (:func:`choose_arrangements`) and written into the module, so a new free value costs only the
  folded twists and the first arrangement's matrices (~2-4 ms, against ~0.15 s when the arrangements
  are chosen again on sample poses);
* a snapped plan's doubtful targets (``reference.correct``; without it a 7-joint arm perturbed by
  1e-6 lost the branches the snapped robot lacks near a singular configuration,
  ``benchmarks/results/real_robots_unseen.md``): built from the robot, the arrangements chosen as the
  compiler would, once, on the first doubtful target (:meth:`FoldedGeneral6.from_robot`).  Chosen
  per value instead, they cost ~70 ms a doubtful target: panda.urdf perturbed by 1e-3 spent 92 ms a
  pose (median of 40) with 12 of 20 random poses doubtful (session 14).

The last few solvers are kept, by free value (a batch at one free value, or a few, builds each once).
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from subproblems.screw import transform_twist, twist_exp

KEEP = 8  # solvers kept, by free value
# Free values (rad) the compiler folds the chain at to choose the arrangements: away from 0 and the
# special angles, where a folded chain may have relations the general one lacks.
CHOICE_VALUES = (-2.3, -0.7, 0.9, 2.6)


def eligible(robot) -> bool:
    """Seven revolute joints, one of them free, no couplings, a pose target."""
    return (
        robot.kinds == "R" * 7
        and len(robot.free_joints) == 1
        and robot.solve_target == "pose"
        and not robot.couplings
    )


def folded(twists, home, column: int, value: float):
    """The six twists (6, 6) and home (4, 4) of the 7R chain ``twists`` with joint ``column`` at
    ``value``."""
    E = twist_exp(twists[column], value)
    six = np.array([transform_twist(E, t) if k > column else t for k, t in enumerate(twists) if k != column])
    return six, E @ np.asarray(home, dtype=float)


def choose_arrangements(twists, home, scale: float, column: int, lower: float, upper: float) -> list[int]:
    """The arrangements of the folded chain, in order: those usable at every choice value (inside the
    limits), ordered by their mean place in each value's order.  Raises General6Error when the
    elimination degenerates at a value or no arrangement is usable at all of them."""
    from subproblems import general6

    values = [v for v in CHOICE_VALUES if lower <= v <= upper] or [0.5 * (lower + upper)]
    orders = [general6.General6(*folded(twists, home, column, v), scale).usable for v in values]
    common = set(orders[0]).intersection(*orders[1:])
    if not common:
        raise general6.General6Error(
            f"general6: no arrangement of the chain folded at joint {column + 1} is usable at every free "
            f"value of {values}")
    return sorted(common, key=lambda k: (sum(o.index(k) for o in orders), k))


class FoldedGeneral6:
    """``rows(Ts, values)``: the exact solutions of targets ``Ts`` at free values ``values`` as flat
    rows of every joint (the free one included), with their target index: ``(Q (M, 7), owner (M,))``.
    ``arrangement``: the elimination's arrangements in order (a general-6r module's, chosen at compile
    time), or None (chosen for each free value on sample poses)."""

    def __init__(self, twists, home, scale: float, column: int, arrangement=None, choose_within=None):
        """``choose_within``: the free joint's (lower, upper): the arrangements are chosen on the
        first call of :meth:`solver` (:func:`choose_arrangements`), for every value after it; where
        that choice fails, each value chooses its own."""
        self._choose_within = choose_within if arrangement is None else None
        self.twists = np.asarray(twists, dtype=float)
        self.home = np.asarray(home, dtype=float)
        self.scale = float(scale)
        self.column = int(column)
        self.arrangement = None if arrangement is None else [int(k) for k in arrangement]
        self._solvers: OrderedDict[float, object] = OrderedDict()

    @classmethod
    def from_robot(cls, robot) -> FoldedGeneral6:
        """The fold of an eligible runtime robot, its arrangements chosen on first use."""
        free = robot.free[0]
        return cls(robot.twists, robot.home, robot.scale, robot.independent[free],
                   choose_within=(float(robot.lower[free]), float(robot.upper[free])))

    def solver(self, value: float):
        """The General6 of the chain folded at ``value``, or None where its geometry degenerates."""
        from subproblems import general6

        if value in self._solvers:
            self._solvers.move_to_end(value)
            return self._solvers[value]
        if self._choose_within is not None:
            within, self._choose_within = self._choose_within, None
            try:
                self.arrangement = choose_arrangements(self.twists, self.home, self.scale, self.column,
                                                       *within)
            except general6.General6Error:
                self.arrangement = None  # no order usable at every choice value: each value chooses
        try:
            made = general6.General6(*folded(self.twists, self.home, self.column, value), self.scale,
                                     arrangement=self.arrangement)
        except general6.General6Error:
            made = None
        self._solvers[value] = made
        if len(self._solvers) > KEEP:
            self._solvers.popitem(last=False)
        return made

    def rows(self, Ts, values):
        Ts, values = np.asarray(Ts, dtype=float), np.asarray(values, dtype=float)
        out, owner = [np.zeros((0, 7))], [np.zeros(0, dtype=int)]
        for value in np.unique(values):
            at = np.nonzero(values == value)[0]
            solver = self.solver(float(value))
            if solver is None:
                continue
            Q, own = solver.rows(Ts[at])
            out.append(np.insert(Q, self.column, value, axis=1))
            owner.append(at[own])
        return np.concatenate(out), np.concatenate(owner)
