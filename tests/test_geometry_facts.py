"""The geometry facts found once (``ikcompiler.geometry.facts``; docs/design.md section 10).

The compiler records on each S2-RR step the relation of its two axes (``axes``), judged on the one set
of sampled configurations, and the code generator reads it (``codegen.fastpath.classify_pairs``).  The
relation must persist: judged on another draw of configurations (another seed, more of them) it is the
same on every plan; and a step without it (a module written before ``_STEPS`` carried it) is judged
by the code generator to the same relation."""

from __future__ import annotations

import dataclasses

import numpy as np

from ikcompiler import configs
from ikcompiler.codegen.fastpath import classify_pairs
from ikcompiler.compiler import compile_plan
from ikcompiler.geometry.facts import configurations, dependent_joints, step_axes
from ikcompiler.inputs import load_robot
from ikcompiler.inputs.zoo import zoo_names


def _compare(chain, plan):
    twists = np.asarray(plan.plan_twists if plan.plan_twists else chain.twists, dtype=float)
    other_draw = configurations(chain.joint_types, chain.scale, count=6, seed=5)
    seen = []
    for steps in (plan.steps, plan.alternative):
        for step in steps:
            again = step_axes(step, twists, chain.joint_types, chain.scale, other_draw)
            assert step.get("axes") == again, (chain.name, step.get("rule"))
            if "axes" in step:
                seen.append(step["axes"])
        bare = [dataclasses.replace(s, axes=None) if s.kind == "S2" else s for s in steps]
        judged = classify_pairs(bare, twists, chain.joint_types, chain.scale)
        assert [s.get("axes") for s in judged] == [s.get("axes") for s in steps], chain.name
    return seen


def test_recorded_axes_are_the_relation_the_code_generator_measures():
    seen = []
    for name in zoo_names():
        chain = load_robot(name)
        free = configs.free_candidates(chain)[0]
        seen += _compare(chain, compile_plan(chain, free=free))
    for kinds in ("RRR", "RRRRRR", "TRRR", "RRRT"):
        chain = configs.modular_chain(kinds)  # RRRRRR (rank 4) compiles with its dependent joints free
        seen += _compare(chain, compile_plan(chain, free=dependent_joints(chain, "pose")))
    for name in ("puma560", "ur5"):  # snapped plans: judged on the snapped robot's twists
        chain = configs.perturbed(load_robot(name), 1e-4)
        seen += _compare(chain, compile_plan(chain))
    assert {"meet", "parallel"} <= set(seen), seen  # both relations occur: the comparison is not empty


def test_configurations_follow_the_seed_policy():
    a, b = configurations("RTR", 2.5, 5), configurations("RTR", 2.5, 5)
    np.testing.assert_array_equal(a, b)
    assert a.shape == (5, 3)
    assert np.all(np.abs(a[:, [0, 2]]) <= np.pi) and np.all(np.abs(a[:, 1]) <= 2.5)
    assert np.abs(a[:, 1]).max() > np.pi / 2.5  # prismatic values are drawn over the size, not as angles
    assert not np.array_equal(a, configurations("RTR", 2.5, 5, seed=4))
