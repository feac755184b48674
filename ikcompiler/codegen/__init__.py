"""Code generation: a plan and its chain become the source text of a solver module."""

from ikcompiler.codegen.module import generate

__all__ = ["generate"]
