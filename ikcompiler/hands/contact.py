"""One contact: contact types, selection matrices H (seed eq. 4), relative velocities (15)/(16), Montana (1).

Conventions (docs/hands.md):

* Twists are ``(v, w)`` 6-vectors.  A *contact twist* is the velocity of the body-fixed point at the
  contact, ``v_c = v_s + w x c``, with the body's angular velocity ``w``, both in world coordinates.
* The object's contact frame ``(t, o, n)`` is Montana's Gauss frame of the object surface at the contact
  (n the object's outward normal); the finger's frame ``(x_f, y_f, z_f)`` is that of the fingertip
  surface, with ``z_f = -n``.  ``psi`` is Montana's angle: ``[x_f y_f] = [t o] R_psi``,
  ``R_psi = [[cos psi, -sin psi], [-sin psi, -cos psi]]``.
* Montana's equations (1) take the motion of the finger relative to the object, ``(v, w)`` = finger
  contact twist minus object contact twist, **in the finger's contact frame** (his relative body
  velocity).  The seed paper writes (15) with the object frame's axes; in the plane the two agree
  (``psi = pi``, the in-plane components vanish), in space they differ by ``R_psi``, and only the
  finger-frame form keeps the contact points together (tests/test_hands.py checks it against the exact
  contact found by projection).

>>> selection_matrix(np.eye(3), "point").shape, selection_matrix(np.eye(3), "soft").shape
((3, 6), (4, 6))
"""

from __future__ import annotations

import math

import numpy as np

from ikcompiler.hands.surfaces import ContactError, PlacedGeometry, _inv2

CONTACT_TYPES = {"point": "point contact with friction", "soft": "soft-finger contact"}
CONTACT_ALIASES = {
    "point": "point",
    "point_with_friction": "point",
    "pcwf": "point",
    "soft": "soft",
    "soft_finger": "soft",
}


def selection_matrix(frame: np.ndarray, kind: str, planar: bool = False) -> np.ndarray:
    """H_i of eq. (4): the contact-twist components a contact transmits, rows in the contact frame.

    ``frame`` holds the object's contact axes t, o, n as columns.  Point contact with friction passes the
    three translational components; a soft finger also the spin about n.  In a planar problem (motion in
    the xy plane, o = +-z) the o row is identically zero and is left out: rows t, n.
    """
    t, o, n = frame[:, 0], frame[:, 1], frame[:, 2]
    z = np.zeros(3)
    rows = [np.r_[t, z], np.r_[n, z]] if planar else [np.r_[t, z], np.r_[o, z], np.r_[n, z]]
    if kind == "soft":
        if planar:
            raise ContactError(
                "a soft-finger contact has no meaning in a planar problem (spin is out of plane)"
            )
        rows.append(np.r_[z, n])
    return np.array(rows)


def relative_angular_velocity(frame: np.ndarray, rel_twist: np.ndarray, kind: str) -> np.ndarray:
    """Eq. (15)/(16): ``(w_o, w_t, w_n)`` (point) or ``(w_o, w_t)`` (soft) of ``J_i th' - G_i^T u``.

    ``frame``'s columns are the axes t, o, n it is projected on.
    """
    w = np.asarray(rel_twist, dtype=float)[3:]
    t, o, n = frame[:, 0], frame[:, 1], frame[:, 2]
    out = [o @ w, t @ w] + ([n @ w] if kind == "point" else [])
    return np.array(out)


def contact_angle(obj: PlacedGeometry, fin: PlacedGeometry) -> float:
    """Montana's psi from the two contact frames: ``x_f = cos psi t - sin psi o``."""
    xf = fin.frame[:, 0]
    return math.atan2(-(xf @ obj.frame[:, 1]), xf @ obj.frame[:, 0])


def R_psi(psi: float) -> np.ndarray:
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s], [-s, -c]])


def montana_matrix(fin: PlacedGeometry, obj: PlacedGeometry, planar: bool = False) -> np.ndarray:
    """(5, 6) linear map of eq. (1): relative contact twist (world) -> ``(u_f', u_o', psi')``.

    ``u_f' = M_f^-1 (K_f + K~_o)^-1 ([-w_y, w_x] - K~_o [v_x, v_y])``,
    ``u_o' = M_o^-1 R_psi (K_f + K~_o)^-1 ([-w_y, w_x] + K_f [v_x, v_y])``,
    ``psi' = w_z + T_f M_f u_f' + T_o M_o u_o'``, with ``K~_o = R_psi K_o R_psi`` and ``(v, w)`` the
    finger's motion relative to the object in the finger's contact frame.  Rolling contacts have
    ``v = 0``; the v terms are kept so the map is Montana's whole equation.  In a planar problem the
    out-of-plane direction has zero curvature on both curves, so ``K_f + K~_o`` is inverted on the plane
    only (its pseudo-inverse) and the extrusion coordinates stay fixed.
    """
    psi = contact_angle(obj, fin)
    Rp = R_psi(psi)
    Lf, Lo = fin.local, obj.local
    Kt = Rp @ Lo.K @ Rp
    S = Lf.K + Kt
    if planar:
        Sinv = np.linalg.pinv(S, rcond=1e-9)
    else:
        if abs(np.linalg.det(S)) < 1e-12 * max(1.0, float(np.abs(S).max())) ** 2:
            raise ContactError(
                "the relative curvature K_f + K~_o is singular (e.g. plane on plane, or parallel cylinders: "
                "a line contact); Montana's equations need a point contact between curved surfaces"
            )
        Sinv = np.linalg.inv(S)
    F = fin.frame  # world axes of the finger contact frame (columns x_f, y_f, z_f)
    Rv = np.zeros((3, 6))
    Rv[:, :3] = F.T  # v components in the finger frame
    Rw = np.zeros((3, 6))
    Rw[:, 3:] = F.T  # w components in the finger frame
    rot = np.array([-Rw[1], Rw[0]])  # [-w_y, w_x]
    vxy = Rv[:2]
    duf = _inv2(Lf.M) @ Sinv @ (rot - Kt @ vxy)
    duo = _inv2(Lo.M) @ Rp @ Sinv @ (rot + Lf.K @ vxy)
    dpsi = Rw[2] + Lf.T @ Lf.M @ duf + Lo.T @ Lo.M @ duo
    return np.vstack([duf, duo, dpsi[None, :]])


def contact_twist_map(point: np.ndarray) -> np.ndarray:
    """(6, 6) map from a body's spatial twist (v at the world origin, w) to its contact twist at ``point``."""
    X = np.eye(6)
    c = np.asarray(point, dtype=float)
    X[:3, 3:] = -np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
    return X
