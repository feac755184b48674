"""Numeric Jacobians and manipulability measures of a chain, vectorised over configurations Q (N, dof).

One implementation: :mod:`subproblems.conditioning` (plain numpy, so generated modules can use it too);
this module binds it to a :class:`~ikcompiler.model.chain.Chain`.  Size-free measures use the Jacobian
referred to the tool origin with linear rows divided by ``chain.scale`` and prismatic columns multiplied
by it (see :mod:`subproblems.conditioning`): they do not change when the robot is given in mm instead of
m, or when the base frame is moved.

>>> import numpy as np
>>> from ikcompiler import load_robot
>>> puma = load_robot("puma560")
>>> m = measures(puma, np.array([[0, 0.3, 0.2, 0, 0.0, 0], [0, 0.3, 0.2, 0, 0.5, 0]]))
>>> bool(m.sigma_min[0] < 1e-12), bool(m.sigma_min[1] > 1e-3)   # sin(j5) = 0 is the wrist singularity
(True, True)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from subproblems import conditioning
from subproblems.screw import adjoint, inverse_transform


def _parts(chain):
    A, b = chain.coupling_matrix()
    return chain.twists, A, b


def space_jacobians(chain, Q) -> np.ndarray:
    """(N, 6, dof) space Jacobians (rows v, w) at the configurations Q (N, dof)."""
    tw, A, b = _parts(chain)
    return conditioning.space_jacobian(tw, A, b, np.atleast_2d(Q))


def body_jacobians(chain, Q) -> np.ndarray:
    """(N, 6, dof) body Jacobians: ``Ad_{g_st(q)^-1} J_s``."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    Js = space_jacobians(chain, Q)
    G = chain.fk_batch(Q)
    return np.stack([adjoint(inverse_transform(g)) @ J for g, J in zip(G, Js)])


def scaled_jacobians(chain, Q) -> np.ndarray:
    """(N, 6, dof) size-free Jacobians (tool origin, linear rows / scale, prismatic columns * scale)."""
    tw, A, b = _parts(chain)
    return conditioning.tool_jacobian(tw, A, b, chain.home, np.atleast_2d(Q), chain.scale)


@dataclass(frozen=True)
class Measures:
    """Per configuration: smallest singular value, Yoshikawa manipulability, condition number."""

    sigma_min: np.ndarray
    manipulability: np.ndarray
    condition: np.ndarray


def measures(chain, Q) -> Measures:
    """Size-free measures at Q (N, dof).

    ``sigma_min``: the min(6, dof)-th singular value of the size-free Jacobian (0 at a singularity);
    ``manipulability``: Yoshikawa's ``sqrt(det(J J^T))`` (dof >= 6) or ``sqrt(det(J^T J))`` (dof < 6),
    i.e. the product of those singular values; ``condition``: largest over smallest (inf when singular).
    """
    s = np.linalg.svd(scaled_jacobians(chain, Q), compute_uv=False)
    smin = s[:, -1]
    with np.errstate(divide="ignore"):
        cond = np.where(smin > 0, s[:, 0] / np.where(smin > 0, smin, 1.0), np.inf)
    return Measures(smin, np.prod(s, axis=1), cond)
