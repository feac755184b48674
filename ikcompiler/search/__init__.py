"""Graph search over solved-joint sets for the cheapest validated subproblem chain."""

from ikcompiler.search.planner import SearchReport, finalize_steps, search

__all__ = ["SearchReport", "finalize_steps", "search"]
