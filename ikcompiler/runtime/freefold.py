"""The true robot's general 6R solver for a chain of seven revolute joints with one free joint: the free
joint's value folded into the chain (docs/design.md section 5, "Snapping").

A snapped plan asks the true robot's general 6R solver about its doubtful targets (the continuation's
rescued ones, ``reference.correct``).  With a free joint the six solved joints form a 6R chain only once
the free value is known: with ``E = exp(xi_f q_f)``, ``E exp(xi_k t) = exp((Ad_E xi_k) t) E``, so the
twists after the free joint become ``Ad_E xi_k`` and the home pose ``E g_st(0)``.  Without it a 7-joint
arm perturbed by 1e-6 (Panda, Kinova Gen3, TIAGo: 5 of 30 special poses each) or CAD-rounded in its
file (roboplan's kinova_robotiq) lost the branches the snapped robot lacks near a singular
configuration (``benchmarks/results/real_robots_unseen.md``).  One solver per free value, built when
first asked (it chooses its arrangements on sample poses: ~0.1 s on an idle core), the last few kept.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from subproblems.screw import transform_twist, twist_exp

KEEP = 8  # solvers kept, by free value (a batch at one free value, or a few, builds each once)


def eligible(robot) -> bool:
    """Seven revolute joints, one of them free, no couplings, a pose target."""
    return (
        robot.kinds == "R" * 7
        and len(robot.free_joints) == 1
        and robot.solve_target == "pose"
        and not robot.couplings
    )


class FoldedGeneral6:
    """``rows(Ts, values)``: the exact solutions of targets ``Ts`` at free values ``values`` as flat
    rows of every joint (the free one included), with their target index: ``(Q (M, 7), owner (M,))``."""

    def __init__(self, robot):
        self.robot = robot
        self.column = robot.independent[robot.free[0]]
        self._solvers: OrderedDict[float, object] = OrderedDict()

    def solver(self, value: float):
        """The General6 of the chain folded at ``value``, or None where its geometry degenerates."""
        from subproblems import general6

        if value in self._solvers:
            self._solvers.move_to_end(value)
            return self._solvers[value]
        r, f = self.robot, self.column
        E = twist_exp(r.twists[f], value)
        twists = np.array([transform_twist(E, t) if k > f else t for k, t in enumerate(r.twists) if k != f])
        try:
            made = general6.General6(twists, E @ r.home, r.scale)
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
