"""Rank-deficient chains of the configuration zoo (docs/design.md section 5, "Rank-deficient chains").

The eight modular chains of seed 0 that took a 1-D / 2-D search and ran until the zoo's 20 s CPU timeout
(benchmarks/results/configurations.md, 2026-12-02) are redundant: generic Jacobian rank below their
joint count.  ``compile_plan`` now refuses them at compile time with the dependent joints named
(errors.RedundantChainError), and ``configs.compile_chain`` declares those free as the refusal says: a
full-rank chain, solved closed form, whose rows are exact by FK and whose sampled joint vectors (the
free joints at their sampled values) come back."""

from __future__ import annotations

import numpy as np
import pytest

from ikcompiler import configs
from ikcompiler.compiler import compile_plan
from ikcompiler.errors import FreeJointError, RedundantChainError
from ikcompiler.geometry.facts import dependent_joints
from ikcompiler.verify import sample_configurations, verify

# joint string (modular, seed 0) -> the dependent joints the refusal names (rank = dof - len)
TIMED_OUT = {
    "RTRR": ("q4",),
    "TRRRR": ("q4", "q5"),
    "RRRRRR": ("q3", "q5"),
    "RRRTTR": ("q2", "q3"),
    "RRRRRT": ("q2", "q3"),
    "TRRRTR": ("q3", "q5"),
    "RRTRRR": ("q6",),
    "TRRRRR": ("q4",),
}


@pytest.mark.parametrize("kinds", sorted(TIMED_OUT))
def test_a_redundant_chain_is_refused_naming_its_dependent_joints(kinds):
    chain = configs.modular_chain(kinds, seed=0)
    dependent = TIMED_OUT[kinds]
    assert configs.generic_rank(chain) == chain.dof - len(dependent)
    with pytest.raises(RedundantChainError) as refused:
        compile_plan(chain, target="pose")
    assert refused.value.dependent == dependent
    assert isinstance(refused.value, FreeJointError)  # the CLI prints it as one line, like --free errors
    assert f"--free {' '.join(dependent)}" in str(refused.value)
    # declared free, the rest is of full rank: nothing more is dependent
    assert dependent_joints(chain, "pose", free=dependent) == ()


@pytest.mark.parametrize("kinds", sorted(TIMED_OUT))
def test_declared_free_a_redundant_chain_is_solved_closed_form_and_complete(kinds):
    chain = configs.modular_chain(kinds, seed=0)
    module = configs.compile_chain(chain).module
    assert module.METHOD == "closed-form" and module.FREE_JOINTS == TIMED_OUT[kinds]
    for seed, special in ((1, 1.0), (2, 0.0)):
        rep = verify(chain, module, samples=20, seed=seed, special=special, scalar_checks=2)
        assert rep.wrong == 0 and rep.batch_mismatch == 0, rep.text()
        assert rep.imprecise + rep.outside_limits + rep.non_canonical + rep.duplicates == 0, rep.text()
        assert rep.recovered + rep.self_motion == rep.poses, rep.text()


def test_rows_of_a_declared_free_chain_are_exact_and_keep_the_free_values():
    chain = configs.modular_chain("RRRRRR", seed=0)
    module = configs.compile_chain(chain).module
    free = [chain.independent_names.index(f) for f in module.FREE_JOINTS]
    for q in sample_configurations(chain, 5, seed=4, special=0.0):
        T = chain.fk(q)
        rows = module.solve(T, *q[free])
        assert len(rows)
        for row in rows:
            assert np.array_equal(row[free], q[free])  # a free value is a command, returned as given
            assert np.abs(chain.fk(row) - T).max() < 1e-12 * chain.scale


@pytest.mark.parametrize("kinds, seed", [("RRR", 2), ("RRRRRR", 2), ("TRRRRR", 1)])
def test_a_full_rank_chain_has_no_dependent_joint(kinds, seed):
    chain = configs.modular_chain(kinds, seed=seed)
    assert configs.generic_rank(chain) == chain.dof
    assert dependent_joints(chain, "pose") == ()


def test_joints_past_the_targets_rows_are_dependent():
    """A position target has three rows: of a full-rank 6R arm the last three joints add no rank."""
    chain = configs.random_6r_chain(4)
    assert dependent_joints(chain, "pose") == ()
    assert dependent_joints(chain, "position") == ("j4", "j5", "j6")


def test_joints_kept_first_are_not_named_dependent():
    """The compiler keeps position+direction's virtual roll first (the user cannot name it free): of
    two dependent joints the other one is named."""
    chain = configs.modular_chain("RRRRRR", seed=0)
    assert dependent_joints(chain, "pose") == ("q3", "q5")
    assert dependent_joints(chain, "pose", keep_first=("q5",)) == ("q3", "q4")
