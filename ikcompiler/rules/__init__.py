"""POE rewriting rules (docs/design.md section 3) as moves that turn the equation into one subproblem."""

from ikcompiler.rules.moves import Context, propose

__all__ = ["Context", "propose"]
