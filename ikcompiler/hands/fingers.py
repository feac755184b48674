"""Fingers: a robot chain (:class:`ikcompiler.model.Chain`) on a base pose, ending in a fingertip surface.

The fingertip pose is ``base @ g_st(theta) @ tip``: ``g_st`` the chain's forward kinematics
(``ikcompiler/model/kinematics.py``), ``tip`` the pose of the fingertip surface's frame in the chain's tool
frame.  Any robot file the project reads can be a finger; :func:`planar_finger` builds the planar fingers
of the seed paper from link lengths (joints about z, joint angles relative, 0 = link along the base
frame's +x).

>>> f = planar_finger("f", [20, 20, 10], base=(0, 0))
>>> f.tip_pose(np.radians([90, -90, 0]))[:3, 3].round(9).tolist()
[30.0, 20.0, 0.0]
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ikcompiler.hands.surfaces import Surface
from ikcompiler.model import Chain, Joint
from ikcompiler.model.kinematics import forward, space_jacobian
from subproblems.screw import adjoint, revolute_twist, twist_exp


@dataclass(frozen=True)
class Finger:
    """One finger: ``chain`` placed at ``base`` (4x4, world), fingertip ``surface`` at ``tip`` (4x4)."""

    name: str
    chain: Chain
    base: np.ndarray
    tip: np.ndarray
    surface: Surface

    @property
    def dof(self) -> int:
        return self.chain.dof

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(f"{self.name}.{n}" for n in self.chain.independent_names)

    def __post_init__(self):
        object.__setattr__(self, "_memo", {})

    def _kinematics(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """Pose and spatial Jacobian together (one pass of :mod:`ikcompiler.model.kinematics`), memoised
        on the last joint vector: a run asks for both at the same angles several times a step."""
        q = np.asarray(theta, dtype=float)
        key = q.tobytes()
        hit = self._memo.get(key)
        if hit is None:
            hit = self._pose_and_jacobian(q)
            A = self._memo.get("A")
            self._memo.clear()
            self._memo["A"] = A
            self._memo[key] = hit
        return hit

    def _pose_and_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # The product of exponentials of kinematics.forward and the columns of kinematics.space_jacobian in
        # one loop (each alone repeats the other's exponentials); tests hold it to both.
        A = self._memo.get("A")
        if A is None:
            A = self._memo["A"] = self.chain.coupling_matrix()[0]
        th = self.chain.expand(q)
        cols = np.zeros((6, self.chain.n))
        g = np.eye(4)
        for i, (joint, t) in enumerate(zip(self.chain.joints, th)):
            cols[:, i] = adjoint(g) @ joint.twist
            g = g @ twist_exp(joint.twist, t)
        return self.base @ g @ self.chain.home @ self.tip, adjoint(self.base) @ (cols @ A)

    def tip_pose_reference(self, theta) -> np.ndarray:
        """:func:`tip_pose` through ``kinematics.forward`` itself (for tests)."""
        return self.base @ forward(self.chain, theta) @ self.tip

    def spatial_jacobian_reference(self, theta) -> np.ndarray:
        """:func:`spatial_jacobian` through ``kinematics.space_jacobian`` itself (for tests)."""
        return adjoint(self.base) @ space_jacobian(self.chain, theta)

    def tip_pose(self, theta) -> np.ndarray:
        """World pose of the fingertip surface's frame."""
        return self._kinematics(theta)[0]

    def spatial_jacobian(self, theta) -> np.ndarray:
        """(6, dof): world spatial twist ``(v at the world origin, w)`` of the fingertip per joint rate."""
        return self._kinematics(theta)[1]


def planar_finger(
    name: str, lengths, *, base=(0.0, 0.0), base_angle: float = 0.0, surface=None, units: str = ""
) -> Finger:
    """A planar finger with revolute joints about z, links of ``lengths``, base at ``base`` (x, y).

    The fingertip surface frame sits at the end of the last link with its x axis along that link.
    """
    lengths = [float(x) for x in lengths]
    joints, x = [], 0.0
    for k, length in enumerate(lengths):
        joints.append(
            Joint(f"q{k + 1}", "R", revolute_twist([0, 0, 1], [x, 0, 0]), -4 * math.pi, 4 * math.pi)
        )
        x += length
    home = np.eye(4)
    home[0, 3] = x
    chain = Chain(name, tuple(joints), home, units=units, source=f"planar finger {name}")
    c, s = math.cos(base_angle), math.sin(base_angle)
    g = np.eye(4)
    g[:2, :2] = [[c, -s], [s, c]]
    g[0, 3], g[1, 3] = float(base[0]), float(base[1])
    return Finger(name, chain, g, np.eye(4), surface)
