"""POE rewriting rules (DESIGN.md section 3) as moves that turn the equation into one subproblem."""

from ikcompiler.rules.moves import Context, propose

__all__ = ["Context", "propose"]
