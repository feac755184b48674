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
edit that adds a literal anywhere in the project.  No setting switches the pool off (Hypothesis 6.170).
The pool is worth keeping (our own thresholds make good edge values), so it is made stable instead:
every module of ``ikcompiler`` and ``subproblems`` is imported here, before the first draw, so tests
no longer see a pool that grows as the run goes.  What still changes draws: the set of test files
collected (run the whole suite to reproduce CI) and any edit of a literal in the project.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

import ikcompiler
import subproblems


def _import_all(package) -> None:
    """Import every module of ``package`` (the draws' constant pool is then complete from the start)."""
    import importlib
    import pkgutil

    for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
        importlib.import_module(info.name)


_import_all(ikcompiler)
_import_all(subproblems)

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
