"""Contact surfaces with local charts and their Montana geometry: metric M, curvature K, torsion T.

A surface is a chart ``f(u, v)`` in its own frame (a fingertip's or the object's), with the outward normal
``n = f_u x f_v / |f_u x f_v|``.  The *contact frame* at a point is Montana's Gauss frame
``x = f_u / |f_u|``, ``y = n x x``, ``z = n``.  For a chart that is not orthogonal (the ellipsoid's
latitude-longitude chart) Montana's diagonal metric generalises to the upper-triangular ``M`` with
``[f_u f_v] = [x y] M``; then, for a chart velocity ``du``:

* the point moves by ``[x y] M du`` (metric),
* the normal turns by ``[x y] K M du`` (curvature ``K = [x y]^T [n_u n_v] M^-1``, symmetric),
* the frame's x axis turns about n by ``T M du`` (torsion ``T = y^T [x_u x_v] M^-1``),

which are Montana's ``M``, ``K`` and ``T`` for an orthogonal chart.  Second derivatives of the charts are
written out analytically (no finite differences), so K and T are exact to rounding.

Planar problems use :class:`Circle` and :class:`Line`: curves in the plane z = 0 extruded along z, charted
by arc length ``s`` (so ``alpha`` is the length travelled along the curve, as in the seed paper's Fig. 3)
and the extrusion coordinate, which a planar run keeps at 0.

>>> g = local_geometry(Sphere(2.0), (0.0, 0.0))
>>> g.point.tolist(), g.normal.tolist(), g.K.round(12).tolist()
([2.0, 0.0, 0.0], [1.0, 0.0, 0.0], [[0.5, 0.0], [0.0, 0.5]])
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ikcompiler.errors import IkcError
from subproblems.screw import cross_tuple


class ContactError(IkcError, ValueError):
    """A contact left its surface's chart, lost touch, or became degenerate (curvatures cancel)."""


@dataclass(frozen=True)
class LocalGeometry:
    """Montana's local geometry of a surface at chart point ``u``, in the surface's own frame."""

    u: np.ndarray  # chart coordinates (alpha, beta)
    point: np.ndarray  # f(u)
    x: np.ndarray  # contact frame axis x = f_u / |f_u|
    y: np.ndarray  # y = n x x
    normal: np.ndarray  # outward unit normal, z of the contact frame
    tangents: np.ndarray  # (3, 2): [f_u f_v]
    dnormal: np.ndarray  # (3, 2): [n_u n_v]
    M: np.ndarray  # (2, 2) metric, upper triangular
    K: np.ndarray  # (2, 2) curvature form
    T: np.ndarray  # (2,) torsion form

    @property
    def frame(self) -> np.ndarray:
        """(3, 3) rotation whose columns are the contact frame axes x, y, n."""
        return np.column_stack([self.x, self.y, self.normal])


class Surface:
    """Base class: a chart with analytic first and second derivatives.

    Subclasses define ``_derivs(u, v) -> (f, fu, fv, fuu, fuv, fvv)``, ``implicit(p)`` (zero on the surface,
    in length units to first order: used by tests as a check independent of the chart) and ``size``.
    ``planar`` marks the curves usable in planar problems.
    """

    planar = False
    name = "surface"

    @property
    def size(self) -> float:  # pragma: no cover - overridden
        raise NotImplementedError

    def _derivs(self, u: float, v: float):  # pragma: no cover - overridden
        raise NotImplementedError

    def implicit(self, p) -> float:  # pragma: no cover - overridden
        raise NotImplementedError

    def domain(self) -> tuple[tuple[float, float], tuple[float, float]]:  # pragma: no cover
        """Chart ranges sampled by the initial contact search."""
        raise NotImplementedError

    def chart(self, u) -> np.ndarray:
        """The point ``f(u)``."""
        return self._derivs(float(u[0]), float(u[1]))[0]

    def describe(self) -> str:
        return self.name


def _vec(*c) -> np.ndarray:
    return np.array(c, dtype=float)


@dataclass(frozen=True)
class Ellipsoid(Surface):
    """``f = (a cos u cos v, b sin u cos v, c sin v)``: longitude u, latitude v; poles at +-z."""

    a: float
    b: float
    c: float
    name = "ellipsoid"

    @property
    def size(self) -> float:
        return max(self.a, self.b, self.c)

    def _derivs(self, u, v):
        s = _vec(self.a, self.b, self.c)
        cu, su, cv, sv = math.cos(u), math.sin(u), math.cos(v), math.sin(v)
        f = s * _vec(cu * cv, su * cv, sv)
        fu = s * _vec(-su * cv, cu * cv, 0)
        fv = s * _vec(-cu * sv, -su * sv, cv)
        fuu = s * _vec(-cu * cv, -su * cv, 0)
        fuv = s * _vec(su * sv, -cu * sv, 0)
        fvv = s * _vec(-cu * cv, -su * cv, -sv)
        return f, fu, fv, fuu, fuv, fvv

    def domain(self):
        return (-math.pi, math.pi), (-0.45 * math.pi, 0.45 * math.pi)

    def implicit(self, p) -> float:
        q = np.asarray(p, dtype=float) / _vec(self.a, self.b, self.c)
        return float((np.linalg.norm(q) - 1.0) * min(self.a, self.b, self.c))


class Sphere(Ellipsoid):
    """Sphere of radius ``r`` (an ellipsoid with a = b = c); chart longitude u, latitude v."""

    name = "sphere"

    def __init__(self, radius: float):
        super().__init__(radius, radius, radius)

    @property
    def radius(self) -> float:
        return self.a

    def implicit(self, p) -> float:
        return float(np.linalg.norm(p) - self.a)


@dataclass(frozen=True)
class Cylinder(Surface):
    """``f = (r cos u, r sin u, v)``: angle u about the z axis, height v."""

    radius: float
    name = "cylinder"

    @property
    def size(self) -> float:
        return self.radius

    def _derivs(self, u, v):
        r, cu, su = self.radius, math.cos(u), math.sin(u)
        z = _vec(0, 0, 0)
        return (
            _vec(r * cu, r * su, v),
            _vec(-r * su, r * cu, 0),
            _vec(0, 0, 1),
            _vec(-r * cu, -r * su, 0),
            z,
            z,
        )

    def domain(self):
        return (-math.pi, math.pi), (-2 * self.radius, 2 * self.radius)

    def implicit(self, p) -> float:
        return float(math.hypot(p[0], p[1]) - self.radius)


@dataclass(frozen=True)
class Plane(Surface):
    """``f = (u, v, 0)``, normal +z.  ``extent`` is only the length scale used for tolerances."""

    extent: float = 1.0
    name = "plane"

    @property
    def size(self) -> float:
        return self.extent

    def _derivs(self, u, v):
        z = _vec(0, 0, 0)
        return _vec(u, v, 0), _vec(1, 0, 0), _vec(0, 1, 0), z, z, z

    def domain(self):
        return (-self.extent, self.extent), (-self.extent, self.extent)

    def implicit(self, p) -> float:
        return float(p[2])


@dataclass(frozen=True)
class Circle(Surface):
    """Planar circle of radius r about the origin, charted by arc length s (counter-clockwise from +x)."""

    radius: float
    name = "circle"
    planar = True

    @property
    def size(self) -> float:
        return self.radius

    def _derivs(self, s, v):
        r = self.radius
        c, si = math.cos(s / r), math.sin(s / r)
        z = _vec(0, 0, 0)
        return _vec(r * c, r * si, v), _vec(-si, c, 0), _vec(0, 0, 1), _vec(-c / r, -si / r, 0), z, z

    def domain(self):
        return (0.0, 2 * math.pi * self.radius), (0.0, 0.0)

    def implicit(self, p) -> float:
        return float(math.hypot(p[0], p[1]) - self.radius)


@dataclass(frozen=True)
class Line(Surface):
    """Planar straight line along +x through the origin, normal +y, charted by arc length s."""

    extent: float = 1.0
    name = "line"
    planar = True

    @property
    def size(self) -> float:
        return self.extent

    def _derivs(self, s, v):
        z = _vec(0, 0, 0)
        return _vec(s, 0, -v), _vec(1, 0, 0), _vec(0, 0, -1), z, z, z

    def domain(self):
        return (-self.extent, self.extent), (0.0, 0.0)

    def implicit(self, p) -> float:
        return float(p[1])


def _cross(a, b) -> np.ndarray:
    """3-vector cross product (np.cross costs ~30 us a call: it dominated a run)."""
    return np.array(cross_tuple(a, b))


def _inv2(M: np.ndarray) -> np.ndarray:
    a, b, c, d = M[0, 0], M[0, 1], M[1, 0], M[1, 1]
    det = a * d - b * c
    return np.array([[d, -b], [-c, a]]) / det


def local_geometry(surface: Surface, u) -> LocalGeometry:
    """Montana's contact frame, metric, curvature and torsion of ``surface`` at chart point ``u``.

    >>> g = local_geometry(Circle(10.0), (0.0, 0.0))
    >>> g.M.tolist(), g.K.round(12).tolist(), g.T.tolist()
    ([[1.0, 0.0], [0.0, 1.0]], [[0.1, 0.0], [0.0, 0.0]], [0.0, 0.0])
    """
    u = np.asarray(u, dtype=float)
    f, fu, fv, fuu, fuv, fvv = surface._derivs(float(u[0]), float(u[1]))
    c = _cross(fu, fv)
    nc = float(np.linalg.norm(c))
    if nc < 1e-12 * surface.size**2:
        raise ContactError(f"chart of the {surface.name} is singular at {u.tolist()} (a pole)")
    n = c / nc
    a = float(np.linalg.norm(fu))
    x = fu / a
    y = _cross(n, x)
    M = np.array([[a, x @ fv], [0.0, y @ fv]])
    Minv = _inv2(M)
    Pn = np.eye(3) - np.outer(n, n)
    nu = Pn @ (_cross(fuu, fv) + _cross(fu, fuv)) / nc
    nv = Pn @ (_cross(fuv, fv) + _cross(fu, fvv)) / nc
    Px = np.eye(3) - np.outer(x, x)
    xu, xv = Px @ fuu / a, Px @ fuv / a
    XY = np.column_stack([x, y])
    dn = np.column_stack([nu, nv])
    K = XY.T @ dn @ Minv
    T = y @ np.column_stack([xu, xv]) @ Minv
    return LocalGeometry(u, f, x, y, n, np.column_stack([fu, fv]), dn, M, 0.5 * (K + K.T), T)


@dataclass(frozen=True)
class PlacedGeometry:
    """A :class:`LocalGeometry` carried into the world by the surface frame's pose ``g`` (4x4)."""

    local: LocalGeometry
    point: np.ndarray
    frame: np.ndarray  # (3, 3) world axes x, y, n
    tangents: np.ndarray  # (3, 2) world [f_u f_v]
    dnormal: np.ndarray  # (3, 2) world [n_u n_v]

    @property
    def normal(self) -> np.ndarray:
        return self.frame[:, 2]


def placed_geometry(surface: Surface, u, g: np.ndarray) -> PlacedGeometry:
    """:func:`local_geometry` of ``surface`` at ``u``, expressed in the world through pose ``g``."""
    loc = local_geometry(surface, u)
    R, p = g[:3, :3], g[:3, 3]
    return PlacedGeometry(loc, R @ loc.point + p, R @ loc.frame, R @ loc.tangents, R @ loc.dnormal)


SURFACES = {"sphere", "cylinder", "plane", "ellipsoid", "circle", "line"}
