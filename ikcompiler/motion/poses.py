"""Poses for Cartesian motion: roll-pitch-yaw, rotation log/exp, and straight segments between two poses.

Rotations are interpolated along the geodesic (slerp: constant angular velocity about one fixed axis),
positions linearly; both reach the end pose exactly at the last sample.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["rpy_to_matrix", "matrix_to_rpy", "pose_from_xyzrpy", "rotation_log", "rotation_exp",
           "interpolate", "straight_line", "pose_distance"]


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Fixed-axis XYZ angles (roll about x, then pitch about y, then yaw about z, all fixed axes):
    R = Rz(yaw) Ry(pitch) Rx(roll).

    >>> np.round(rpy_to_matrix(0, 0, math.pi / 2), 6).tolist()
    [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def matrix_to_rpy(R) -> tuple[float, float, float]:
    """Inverse of :func:`rpy_to_matrix` (pitch in [-pi/2, pi/2]; at pitch = +-pi/2 the roll is 0).

    >>> [round(x, 9) for x in matrix_to_rpy(rpy_to_matrix(0.1, -0.2, 0.3))]
    [0.1, -0.2, 0.3]
    """
    R = np.asarray(R, dtype=float)
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[2, 1], R[2, 2]) < 1e-12:  # gimbal lock: only roll - yaw (or roll + yaw) is defined
        return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def pose_from_xyzrpy(x: float, y: float, z: float, roll: float, pitch: float, yaw: float) -> np.ndarray:
    """4x4 pose from a position and fixed-axis XYZ angles (radians)."""
    T = np.eye(4)
    T[:3, :3] = rpy_to_matrix(roll, pitch, yaw)
    T[:3, 3] = (x, y, z)
    return T


def rotation_log(R) -> np.ndarray:
    """Rotation vector (axis times angle, angle in [0, pi]) of a rotation matrix.

    >>> np.round(rotation_log(rpy_to_matrix(0, 0, 0.5)), 12).tolist()
    [0.0, 0.0, 0.5]
    """
    R = np.asarray(R, dtype=float)
    c = max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2.0
    s = float(np.linalg.norm(w))
    angle = math.atan2(s, c)
    if angle < 1e-8:
        return w  # sin(angle) ~ angle
    if math.pi - angle > 1e-6:
        return w * (angle / s)
    # near pi: the axis from the symmetric part, its sign from w
    B = (R + R.T) / 2.0 - c * np.eye(3)
    k = int(np.argmax(np.diag(B)))
    axis = B[:, k] / math.sqrt(max(B[k, k], 1e-300))
    if axis @ w < 0:
        axis = -axis
    return axis / np.linalg.norm(axis) * angle


def rotation_exp(r) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues)."""
    r = np.asarray(r, dtype=float)
    angle = float(np.linalg.norm(r))
    if angle < 1e-300:
        return np.eye(3)
    k = r / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


def pose_distance(T0, T1) -> tuple[float, float]:
    """(translation length, rotation angle) between two poses."""
    T0, T1 = np.asarray(T0, dtype=float), np.asarray(T1, dtype=float)
    return (float(np.linalg.norm(T1[:3, 3] - T0[:3, 3])),
            float(np.linalg.norm(rotation_log(T0[:3, :3].T @ T1[:3, :3]))))


def interpolate(T0, T1, s) -> np.ndarray:
    """Poses at fractions ``s`` (M,) of the straight segment T0 -> T1: (M, 4, 4); s = 1 gives T1 exactly."""
    T0, T1 = np.asarray(T0, dtype=float), np.asarray(T1, dtype=float)
    s = np.atleast_1d(np.asarray(s, dtype=float))
    r = rotation_log(T0[:3, :3].T @ T1[:3, :3])
    out = np.broadcast_to(np.eye(4), (len(s), 4, 4)).copy()
    for i, f in enumerate(s):
        if f == 1.0:
            out[i] = T1
            continue
        out[i, :3, :3] = T0[:3, :3] @ rotation_exp(f * r)
        out[i, :3, 3] = (1 - f) * T0[:3, 3] + f * T1[:3, 3]
    return out


def straight_line(T0, T1, *, max_step: float, max_angle: float = math.radians(2.0)) -> np.ndarray:
    """Poses of the straight segment from T0 to T1, both included: linear position, geodesic (slerp)
    orientation, evenly spaced so that no step is longer than ``max_step`` (length) or turns more than
    ``max_angle`` (radians).  (M, 4, 4) with M >= 2; the first is T0 and the last T1, exactly.

    >>> T1 = pose_from_xyzrpy(1.0, 0, 0, 0, 0, 0.4)
    >>> P = straight_line(np.eye(4), T1, max_step=0.3, max_angle=0.1)
    >>> len(P), bool(np.allclose(P[-1], T1)), round(float(P[1][0, 3]), 6)
    (5, True, 0.25)
    """
    if not (max_step > 0 and max_angle > 0):
        raise ValueError(f"max_step and max_angle must be > 0; got {max_step}, {max_angle}")
    length, angle = pose_distance(T0, T1)
    steps = max(1, math.ceil(max(length / max_step, angle / max_angle) - 1e-12))
    P = interpolate(T0, T1, np.arange(steps + 1) / steps)
    P[0] = np.asarray(T0, dtype=float)
    return P
