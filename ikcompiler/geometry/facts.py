"""The geometry facts the steps rely on, found once (docs/design.md section 10).

A relation between joint axes that the plan relies on must hold in every configuration of the joints
between them, so it is judged on sampled configurations.  One seed policy for all of them:
:func:`configurations` draws the joint values (revolute uniform in (-pi, pi), prismatic uniform in
(-size, size), from ``numpy.random.default_rng(SEED)``), and every judgement of the compiler uses it:
the rules' ``Context.samples``, the persistence of the relations ``analyse`` reports, and the axes of
each S2-RR step recorded on the step (:func:`record_step_facts`, the key ``axes``), which the code
generator reads instead of measuring them again.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from subproblems import tolerances as tol

#: The one seed of the compiler's sampled configurations.
SEED = 3
#: How many configurations a relation is judged on (the rules' samples; enough: a relation that does
#: not persist fails on a random configuration with probability one).
COUNT = 4


def configurations(kinds: str, scale: float, count: int = COUNT, seed: int = SEED) -> np.ndarray:
    """Joint values (count, n) of every joint: revolute ones uniform in (-pi, pi), prismatic ones in
    (-scale, scale), drawn in that order from ``default_rng(seed)``.

    >>> configurations("RT", 2.0, 3).shape
    (3, 2)
    """
    rng = np.random.default_rng(seed)
    th = rng.uniform(-math.pi, math.pi, size=(count, len(kinds)))
    for i, k in enumerate(kinds):
        if k == "T":
            th[:, i] = rng.uniform(-scale, scale, size=count)
    return th


def step_axes(step, twists, kinds, scale: float, th) -> str | None:
    """The relation of the two unknown axes of an S2-RR step (``parallel``, ``meet``, ``skew``) in the
    configurations ``th`` (M, n), or None for any other step."""
    from subproblems import plan_runtime as rt

    if step.get("code") != "S2-RR" or step.get("kind") != "S2":
        return None
    Td = rt.fk_batch(twists, th, np.eye(4))
    tw, _ = rt._step_inputs(step, twists, kinds, Td, th, None)
    w1, w2 = tw[:, 0, 3:], tw[:, 1, 3:]
    r1, r2 = np.cross(w1, tw[:, 0, :3]), np.cross(w2, tw[:, 1, :3])
    n12 = np.cross(w1, w2)
    nn = np.linalg.norm(n12, axis=1)
    if np.all(nn <= tol.RR_AXES_PARALLEL):
        return "parallel"
    gap = np.abs(np.sum((r2 - r1) * n12, axis=1)) / np.maximum(nn, tol.TINY)
    return "meet" if np.all((gap <= tol.EXACT * scale) & (nn > tol.RR_AXES_MEET_ANGLE)) else "skew"


def record_step_facts(steps, twists, kinds, scale: float) -> list:
    """The steps with the facts they rely on recorded: ``axes`` on each S2-RR step (a new step)."""
    th = configurations(kinds, scale)
    twists = np.asarray(twists, dtype=float)
    out = []
    for step in steps:
        axes = step_axes(step, twists, kinds, scale, th)
        out.append(step if axes is None else dataclasses.replace(step, axes=axes))
    return out


def _sampled_jacobians(chain, target: str) -> np.ndarray:
    """The size-free Jacobians (rows the ``target`` constrains, every independent joint) at the sampled
    :func:`configurations` of the chain."""
    from subproblems import select

    A, b = chain.coupling_matrix()
    kinds = "".join(chain.joints[i].kind for i in chain.independent)
    Q = configurations(kinds, chain.scale)
    return select.jacobian(Q, twists=chain.twists, A=A, b=b, home=chain.home, scale=chain.scale,
                           target="pose" if target == "position+direction" else target)


def conditioned_rank(chain, target: str, free=(), tol: float = tol.NEAR_REDUNDANT) -> int:
    """The largest number of singular values above ``tol`` of the size-free Jacobian of the chain's
    solved joints (its independent joints but ``free``; rows the ``target`` constrains) over the
    sampled :func:`configurations`.  Below the number of solved joints the chain is *near-redundant*
    (``tol`` the snap tolerance; docs/design.md section 5): 0 where it is redundant exactly.

    >>> from ikcompiler import configs
    >>> conditioned_rank(configs.modular_chain("RRR", seed=2), "position")
    3
    """
    J = _sampled_jacobians(chain, target)
    keep = [k for k, name in enumerate(chain.independent_names) if name not in set(free)]
    s = np.linalg.svd(J[:, :, keep], compute_uv=False)
    return int((s > tol).sum(axis=1).max()) if len(keep) else 0


def dependent_joints(chain, target: str, free=(), tol: float = tol.DEPENDENT_JOINT,
                     keep_first=()) -> tuple[str, ...]:
    """The solved joints (independent joints but ``free``) whose size-free Jacobian column (rows the
    ``target`` constrains) adds no singular value above ``tol`` to the columns kept before it, in chain
    order (the joints ``keep_first`` first: a virtual joint the user cannot name free), at the sampled
    :func:`configurations` that keeps the most: () for a chain of full generic rank.  Declared free,
    they leave a full-rank chain (docs/design.md section 5, "Rank-deficient chains"): two coaxial
    revolute joints give the later one, four parallel revolute axes the fourth.

    >>> from ikcompiler import configs
    >>> dependent_joints(configs.modular_chain("RTRR", seed=0), "pose")
    ('q4',)
    >>> dependent_joints(configs.modular_chain("RRR", seed=2), "pose")
    ()
    """
    J = _sampled_jacobians(chain, target)
    solved = [k for k, name in enumerate(chain.independent_names) if name not in set(free)]
    solved.sort(key=lambda k: chain.independent_names[k] not in set(keep_first))  # stable: chain order
    best: list[int] = []
    for Jq in J:
        kept: list[int] = []
        for k in solved:
            s = np.linalg.svd(Jq[:, kept + [k]], compute_uv=False)
            if (s > tol * max(s[0], 1.0)).sum() > len(kept):  # a rank more (none past the rows)
                kept.append(k)
        if len(kept) > len(best):
            best = kept
    return tuple(chain.independent_names[k] for k in solved if k not in best)
