"""One exception hierarchy for everything a user can get wrong.

Every message names where the fault is (file, line, joint, row or field) and what was expected, so the
CLI can print it as one line and exit non-zero.
"""

from __future__ import annotations


class IkcError(Exception):
    """Base class of every error ikcompiler raises on purpose."""


class RobotInputError(IkcError, ValueError):
    """A robot description (URDF, DH table, spec file) is malformed or asks for something unsupported."""

    def __init__(self, message: str, *, source: str | None = None, where: str | None = None):
        self.source = source
        self.where = where
        prefix = ": ".join(x for x in (source, where) if x)
        super().__init__(f"{prefix}: {message}" if prefix else message)


class UnknownRobotError(RobotInputError):
    """The name is neither a file nor a robot of the zoo."""


class UnsupportedJointError(RobotInputError):
    """A planar, floating or otherwise unsupported joint lies inside the chain."""


class ChainSelectionError(RobotInputError):
    """Base or tip link missing, not connected, or ambiguous (a tree needs a tip)."""


class TargetError(IkcError, ValueError):
    """A target pose is not finite or not a rigid transform, or has the wrong shape."""


class FreeJointError(IkcError, ValueError):
    """Free joints named wrongly, or the wrong number of free values passed at solve time."""


class RedundantChainError(FreeJointError):
    """A chain whose solved joints are dependent (generic Jacobian rank below their number: a continuum of
    solutions at every pose) and that no closed form or general 6R elimination covers: a search on it
    would not end.  ``dependent`` names the joints to declare free (docs/design.md section 5,
    "Rank-deficient chains")."""

    def __init__(self, message: str, dependent: tuple[str, ...] = ()):
        super().__init__(message)
        self.dependent = tuple(dependent)


class CompileError(IkcError):
    """No plan could be built; the message says what was tried and why it failed."""


class PlanFormatError(IkcError, ValueError):
    """A serialised plan or step (``Plan.from_json``, ``Step.from_dict``) that does not follow the schema
    of docs/design.md section 12: the message names the step kind and the field."""


class MotionError(IkcError, ValueError):
    """A path or trajectory request that cannot be met as asked (start not on the path, limits too
    tight for the duration, wrong number of joint values)."""
