"""A hand holding an object: fingers, object surface, contact types; geometry, matrices and projection.

The configuration is ``(theta, g_o, U)``: all joint angles (fingers in order), the object's pose (4x4,
its reference point is the frame origin) and per contact the chart coordinates
``U[i] = (alpha_f, beta_f, alpha_o, beta_o)``; Montana's fifth coordinate ``psi`` is a function of these
(:func:`ikcompiler.hands.contact.contact_angle`).  The object twist ``u`` is taken in the world frame
as the seed paper does: ``u = (v, w)`` with ``v`` the velocity of the object's reference point and ``w``
its angular velocity, both in world coordinates (in the plane ``(v_x, v_y, w_z)``).

:meth:`HandSystem.project` puts a configuration back on the contact constraints (contact points coincide,
normals opposed) by Gauss-Newton with minimum-norm steps in ``(theta, U)`` at a fixed object pose.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ikcompiler.hands.contact import (
    contact_angle,
    contact_twist_map,
    montana_matrix,
    selection_matrix,
)
from ikcompiler.hands.fingers import Finger
from ikcompiler.hands.grasp import JointObject, analyse
from ikcompiler.hands.surfaces import ContactError, PlacedGeometry, Surface, placed_geometry
from subproblems.screw import hat

PLANAR_BASIS = np.eye(6)[:, [0, 1, 5]]  # (v_x, v_y, w_z)
PROJECTION_TOL = 1e-13  # relative to the object's size: the constraint residual aimed at


@dataclass(frozen=True)
class Contacts:
    """Geometry of every contact at one configuration: finger and object side, psi."""

    finger: tuple[PlacedGeometry, ...]
    object: tuple[PlacedGeometry, ...]
    psi: np.ndarray


@dataclass(frozen=True)
class Matrices:
    """``G^T`` (rows x m), ``J`` (rows x joints) of eq. (7) and the per-contact 6-row maps."""

    Gt: np.ndarray
    J: np.ndarray
    G6: tuple[np.ndarray, ...]  # contact twist of the object per object twist u (6 x m)
    J6: tuple[np.ndarray, ...]  # contact twist of fingertip i per joint rate (6 x joints)
    row_scale: np.ndarray
    rows: tuple[slice, ...]


@dataclass(frozen=True)
class HandSystem:
    """Fingers (one contact each) holding an object surface.

    ``object_frame`` is the pose of the object's surface chart in the object's body frame (rotate it to
    keep the chart's poles away from the contacts); ``contact`` the type of each contact, "point"
    (point contact with friction) or "soft" (soft finger).
    """

    fingers: tuple[Finger, ...]
    object_surface: Surface
    contact: tuple[str, ...]
    planar: bool
    object_frame: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "hand"
    units: str = ""

    def __post_init__(self):
        object.__setattr__(self, "fingers", tuple(self.fingers))
        object.__setattr__(self, "contact", tuple(self.contact))
        if len(self.contact) != len(self.fingers):
            raise ContactError(f"{len(self.fingers)} fingers but {len(self.contact)} contact types")
        if self.planar:
            bad = [f.name for f in self.fingers if not f.surface.planar]
            if bad or not self.object_surface.planar:
                raise ContactError(
                    "a planar problem needs planar curves (circle, line) for the object and every fingertip"
                    + (
                        f"; fingers {bad} have {', '.join(f.surface.name for f in self.fingers)}"
                        if bad
                        else ""
                    )
                )
            for f in self.fingers:
                _check_planar(f)
        for f, kind in zip(self.fingers, self.contact):
            if kind not in ("point", "soft"):
                raise ContactError(f"finger {f.name}: contact type must be 'point' or 'soft', got {kind!r}")

    # ---- sizes -----------------------------------------------------------------------------------

    @property
    def length_scale(self) -> float:
        return float(self.object_surface.size)

    @property
    def object_dof(self) -> int:
        return 3 if self.planar else 6

    @property
    def basis(self) -> np.ndarray:
        """(6, m): object twist components -> full (v, w)."""
        return PLANAR_BASIS if self.planar else np.eye(6)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(n for f in self.fingers for n in f.joint_names)

    @property
    def n_joints(self) -> int:
        return sum(f.dof for f in self.fingers)

    def joint_slices(self) -> tuple[slice, ...]:
        out, k = [], 0
        for f in self.fingers:
            out.append(slice(k, k + f.dof))
            k += f.dof
        return tuple(out)

    def twist_scale(self) -> np.ndarray:
        L = self.length_scale
        return np.array([L, L, 1.0]) if self.planar else np.array([L, L, L, 1, 1, 1], dtype=float)

    # ---- geometry --------------------------------------------------------------------------------

    def contacts(self, theta, g_o, U) -> Contacts:
        """Contact geometry on both sides at configuration ``(theta, g_o, U)``."""
        fin, obj, psi = [], [], []
        g_surf = np.asarray(g_o) @ self.object_frame
        for f, sl, u in zip(self.fingers, self.joint_slices(), np.asarray(U, dtype=float)):
            gf = placed_geometry(f.surface, u[:2], f.tip_pose(np.asarray(theta)[sl]))
            go = placed_geometry(self.object_surface, u[2:], g_surf)
            fin.append(gf)
            obj.append(go)
            psi.append(contact_angle(go, gf))
        return Contacts(tuple(fin), tuple(obj), np.array(psi))

    def residual(self, c: Contacts) -> float:
        """Largest constraint violation: point gap / object size, and |n_f + n_o| (an angle)."""
        L = self.length_scale
        r = 0.0
        for gf, go in zip(c.finger, c.object):
            r = max(
                r,
                float(np.linalg.norm(gf.point - go.point)) / L,
                float(np.linalg.norm(gf.normal + go.normal)),
            )
        return r

    def matrices(self, theta, g_o, c: Contacts) -> Matrices:
        """``G^T`` and ``J`` of eq. (5)-(7) at the object-side contact points."""
        theta = np.asarray(theta, dtype=float)
        p_o = np.asarray(g_o)[:3, 3]
        P = self.basis
        G6, J6, Gt, Jr, scale, rows = [], [], [], [], [], []
        k = 0
        for f, sl, kind, gf, go in zip(self.fingers, self.joint_slices(), self.contact, c.finger, c.object):
            H = selection_matrix(go.frame, kind, self.planar)
            g6 = contact_twist_map(go.point - p_o) @ P
            j6 = np.zeros((6, self.n_joints))
            j6[:, sl] = contact_twist_map(gf.point) @ f.spatial_jacobian(theta[sl])
            G6.append(g6)
            J6.append(j6)
            Gt.append(H @ g6)
            Jr.append(H @ j6)
            ntrans = 2 if self.planar else 3
            scale.extend([1.0 / self.length_scale] * ntrans + [1.0] * (H.shape[0] - ntrans))
            rows.append(slice(k, k + H.shape[0]))
            k += H.shape[0]
        return Matrices(np.vstack(Gt), np.vstack(Jr), tuple(G6), tuple(J6), np.array(scale), tuple(rows))

    def analyse(self, m: Matrices) -> JointObject:
        """The joint-object equation (14) and the classification."""
        return analyse(m.Gt, m.J, dof=self.object_dof, row_scale=m.row_scale, twist_scale=self.twist_scale())

    def rate_map(self, c: Contacts) -> list[np.ndarray]:
        """Per contact the (5, 6) Montana map of eq. (1): relative contact twist -> eta' (without alpha)."""
        return [montana_matrix(gf, go, self.planar) for gf, go in zip(c.finger, c.object)]

    def contact_rates(self, m: Matrices, maps, dtheta, u) -> np.ndarray:
        """(n, 5): ``(alpha_f', beta_f', alpha_o', beta_o', psi')`` per contact; ``u`` in basis components."""
        return np.array([W @ (j6 @ dtheta - g6 @ u) for W, j6, g6 in zip(maps, m.J6, m.G6)])

    # ---- projection onto the contact constraints ---------------------------------------------------

    def project(
        self,
        theta,
        g_o,
        U,
        *,
        max_iter: int = 30,
        tol: float = PROJECTION_TOL,
        where: str = "",
        fix_joints: bool = False,
    ) -> tuple[np.ndarray, np.ndarray, Contacts, float]:
        """Minimum-norm Gauss-Newton: contact points coincide, normals opposed, at the fixed object pose.

        Unknowns are the joints and chart coordinates (the extrusion coordinates stay fixed in a planar
        problem); each column is scaled to unit size (joints in radians, chart coordinates in object
        lengths) and the least-norm step is taken, so the configuration moves as little as possible.
        Returns ``(theta, U, contacts, residual)``; :class:`ContactError` when it does not converge.
        ``fix_joints`` moves the chart coordinates only and returns the best it found without raising
        (the initial contact search: find where the fingertips touch before moving any joint).
        """
        theta = np.array(theta, dtype=float)
        U = np.array(U, dtype=float)
        L = self.length_scale
        ucols = [0, 2] if self.planar else [0, 1, 2, 3]
        n_th, n_c = self.n_joints, len(self.fingers)
        res = np.inf
        for _ in range(max_iter):
            c = self.contacts(theta, g_o, U)
            res = self.residual(c)
            if res <= tol:
                return theta, U, c, res
            r = np.zeros(6 * n_c)
            A = np.zeros((6 * n_c, n_th + len(ucols) * n_c))
            for i, (f, sl, gf, go) in enumerate(zip(self.fingers, self.joint_slices(), c.finger, c.object)):
                rr = slice(6 * i, 6 * i + 6)
                r[rr] = np.r_[(gf.point - go.point) / L, gf.normal + go.normal]
                Js = contact_twist_map(gf.point) @ f.spatial_jacobian(theta[sl])
                A[6 * i : 6 * i + 3, sl] = Js[:3] / L
                A[6 * i + 3 : 6 * i + 6, sl] = -hat(gf.normal) @ Js[3:]
                for k, col in enumerate(ucols):
                    j = n_th + len(ucols) * i + k
                    side, s = (gf, 1.0) if col < 2 else (go, -1.0)
                    a = col % 2
                    A[6 * i : 6 * i + 3, j] = s * side.tangents[:, a] / L
                    A[6 * i + 3 : 6 * i + 6, j] = side.dnormal[:, a]
            if fix_joints:
                A[:, :n_th] = 0.0
            w = np.linalg.norm(A, axis=0)
            w[w == 0] = 1.0
            dz, *_ = np.linalg.lstsq(A / w, -r, rcond=1e-10)
            dz /= w
            theta += dz[:n_th]
            U[:, ucols] += dz[n_th:].reshape(n_c, len(ucols))
        if fix_joints:
            c = self.contacts(theta, g_o, U)
            return theta, U, c, self.residual(c)
        raise ContactError(
            f"{where}could not put the fingertips back on the object (constraint residual {res:.2e} of its "
            f"size after {max_iter} steps): a contact was lost or the hand is at a singular configuration; "
            "try a smaller --dt or check the initial grasp"
        )

    def find_contacts(self, theta, g_o, samples: int = 24) -> np.ndarray:
        """Initial chart coordinates: the closest pair of points with opposed normals, per contact.

        A coarse grid (``samples`` per chart coordinate); :meth:`project` with ``fix_joints`` refines it.
        """
        U = np.zeros((len(self.fingers), 4))
        g_surf = np.asarray(g_o) @ self.object_frame
        obj_pts, obj_n, obj_u = _sample(self.object_surface, g_surf, samples)
        L = self.length_scale
        for i, (f, sl) in enumerate(zip(self.fingers, self.joint_slices())):
            fp, fn, fu = _sample(f.surface, f.tip_pose(np.asarray(theta, dtype=float)[sl]), samples)
            d = ((fp[:, None, :] - obj_pts[None]) ** 2).sum(-1) / L**2 + (
                (fn[:, None, :] + obj_n[None]) ** 2
            ).sum(-1)
            a, b = np.unravel_index(int(np.argmin(d)), d.shape)
            U[i, :2], U[i, 2:] = fu[a], obj_u[b]
        return U


def _check_planar(f: Finger) -> None:
    """Planar fingers move in the xy plane: joints about z or along xy, the tip frame's z axis up."""
    q = np.zeros(f.dof)
    J = f.spatial_jacobian(q)
    g = f.tip_pose(q)
    bad = [
        name
        for name, col in zip(f.joint_names, J.T)
        if abs(col[2]) > 1e-9 * max(1.0, float(np.abs(col[:3]).max())) or np.abs(col[3:5]).max() > 1e-9
    ]
    if (
        bad
        or np.abs(g[:3, 2] - [0, 0, 1]).max() > 1e-9
        or abs(g[2, 3]) > 1e-9 * max(1.0, abs(g[:3, 3]).max())
    ):
        raise ContactError(
            f"finger {f.name}: a planar problem needs every joint to turn about z or slide in the xy plane "
            "and the fingertip in the plane z = 0 with its z axis up"
            + (f"; joints {', '.join(bad)} do not" if bad else "; the fingertip frame does not")
            + " (set planar = false for a 3-D hand)"
        )


def _sample(surface: Surface, g: np.ndarray, n: int):
    """World points, outward normals and chart coordinates on an n x n grid of the chart's domain."""
    (u0, u1), (v0, v1) = surface.domain()
    us = np.linspace(u0, u1, n, endpoint=False)
    vs = np.linspace(v0, v1, n) if v1 > v0 else np.array([v0])
    pts, nrm, uv = [], [], []
    for u in us:
        for v in vs:
            f, fu, fv, *_ = surface._derivs(float(u), float(v))
            c = np.array(
                [fu[1] * fv[2] - fu[2] * fv[1], fu[2] * fv[0] - fu[0] * fv[2], fu[0] * fv[1] - fu[1] * fv[0]]
            )
            nc = np.linalg.norm(c)
            if nc < 1e-9 * surface.size**2:
                continue
            pts.append(f)
            nrm.append(c / nc)
            uv.append((u, v))
    R, p = g[:3, :3], g[:3, 3]
    return np.array(pts) @ R.T + p, np.array(nrm) @ R.T, np.array(uv)
