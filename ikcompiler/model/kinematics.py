"""Forward kinematics and Jacobians of a POE chain.

Jacobian columns are twists ``(v, w)``, one per independent joint; a coupled joint adds ``a`` times its
column to its master's.  Space Jacobian: ``V_s = J_s(q) dq`` with ``V_s^ = g' g^-1``; body Jacobian:
``J_b = Ad_{g^-1} J_s``.
"""

from __future__ import annotations

import numpy as np

from subproblems.screw import adjoint, fk, fk_batch, inverse_transform


def forward(chain, q) -> np.ndarray:
    """``g_st(q) = exp(xi_1 th_1) ... exp(xi_n th_n) g_st(0)`` (:func:`subproblems.screw.fk`)."""
    th = chain.expand(np.asarray(q, dtype=float))
    return fk(chain.twists, th, chain.home)


def forward_batch(chain, Q) -> np.ndarray:
    """Vectorised :func:`forward` over Q of shape (N, dof); returns (N, 4, 4)."""
    th = chain.expand(np.atleast_2d(np.asarray(Q, dtype=float)))
    return fk_batch(chain.twists, th, chain.home)


def space_jacobian(chain, q) -> np.ndarray:
    """(6, dof) space Jacobian at independent joint values ``q`` (one implementation, vectorised:
    :func:`subproblems.conditioning.space_jacobian`)."""
    from subproblems.conditioning import space_jacobian as batch

    A, b = chain.coupling_matrix()
    return batch(chain.twists, A, b, np.asarray(q, dtype=float)[None, :])[0]


def body_jacobian(chain, q) -> np.ndarray:
    """(6, dof) body Jacobian: tool-frame twists per unit joint velocity."""
    return adjoint(inverse_transform(forward(chain, q))) @ space_jacobian(chain, q)
