"""Shared pytest configuration: hypothesis profiles.

``HYPOTHESIS_PROFILE`` selects one: ``ci`` (the default; small budgets so the whole suite stays fast on
two cores) or ``thorough`` (many examples, for a nightly or pre-release run).  Tests that want a
per-test budget scale ``settings().max_examples`` of the active profile rather than hard-coding a count.

Reproducibility of ``ci``: ``derandomize=True`` seeds each test from a hash of its own function and
already implies ``database=None`` (the ``.hypothesis/`` example database is neither read nor written),
so the database cannot make dev and CI runs differ.  What does: Hypothesis mixes literal constants of
every *local* module loaded in ``sys.modules`` into its draws (``1e-9``, ``1e-7`` from the solvers turn
up as coordinates).  The pool grows as tests import more modules, so the examples a test draws depend on
which tests ran before it, on the selection (``-k``, one file), on uncommitted local files, and on any
edit that adds a literal anywhere in the project.  No setting switches the pool off (Hypothesis 6.170);
to reproduce a CI failure, run the same selection on the same committed tree.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci",
    max_examples=40,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
settings.register_profile(
    "thorough",
    max_examples=2000,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
