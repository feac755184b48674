"""Shared pytest configuration: hypothesis profiles.

``HYPOTHESIS_PROFILE`` selects one: ``ci`` (the default; small budgets so the whole suite stays fast on
two cores) or ``thorough`` (many examples, for a nightly or pre-release run).  Tests that want a
per-test budget scale ``settings().max_examples`` of the active profile rather than hard-coding a count.

Reproducibility of ``ci``: ``derandomize=True`` seeds each test from a hash of its own function and
already implies ``database=None`` (the ``.hypothesis/`` example database is neither read nor written),
so the database cannot make dev and CI runs differ.  What else did: Hypothesis mixes the literal
constants of every *local* module loaded in ``sys.modules`` into its draws, so any edit that added a
literal anywhere in the project (a new package, a docstring's number) changed what every property test
drew, and a run could fail on a solver nobody had touched.  No setting switches that pool off
(Hypothesis 6.170), so it is replaced here by a fixed pool of the edge values our solvers care about
(tolerance-sized offsets, special angles): the draws of a test now depend only on the test itself and
the Hypothesis version, which ``pyproject.toml`` pins for the same reason.
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


def _fixed_constant_pool() -> None:
    """Replace Hypothesis's pool of project literals by a fixed one (see the module docstring)."""
    import math

    from hypothesis.internal.conjecture import providers

    floats = [0.0, 0.5, 1.0, 2.0, 1e3, 1e-3, math.pi, math.pi / 2, math.pi / 4]
    floats += [10.0 ** -k for k in range(1, 17)]
    floats += [-x for x in floats]
    pool = providers.Constants(
        integers=providers.SortedSet([0, 1, 2, 3, -1]),
        floats=providers.SortedSet(floats, key=providers.float_to_int),
        bytes=providers.SortedSet(),
        strings=providers.SortedSet(),
    )
    providers._get_local_constants = lambda: pool
    providers.CONSTANTS_CACHE.cache.clear()


_fixed_constant_pool()

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
