"""Axis-geometry analysis: which joint axes intersect, are parallel, coincide; tolerance policy."""

from ikcompiler.geometry.relations import Tolerance, analyse, lines_meet, pair_relation

__all__ = ["Tolerance", "analyse", "lines_meet", "pair_relation"]
