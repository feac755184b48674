"""Shared pytest configuration: hypothesis profiles.

``HYPOTHESIS_PROFILE`` selects one: ``ci`` (the default; small budgets so the whole suite stays fast on
two cores) or ``thorough`` (many examples, for a nightly or pre-release run).  Tests that want a
per-test budget scale ``settings().max_examples`` of the active profile rather than hard-coding a count.
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
