"""Plain-arithmetic kernels of the subproblems that generated fast paths call, one source for two backends.

Every kernel here is written with ``+ - * /`` on 3-tuples and the few functions of a *backend* ``m``:
``m.sin, m.cos, m.sqrt, m.atan2, m.acos, m.cbrt, m.clip1`` (clamp to [-1, 1]), ``m.pos`` (clamp below at 0),
``m.big`` (max with a tiny positive number) and ``m.small`` (``x <= y``).  With :data:`SCALAR` the
numbers are Python floats and one call costs a few microseconds; with :data:`ARRAY` they are numpy arrays
over N instances, vectorised with no Python loop over instances.  One source for both paths keeps
them in agreement by construction.

Each kernel returns a fixed number of *slots*, one per candidate, each a tuple of joint values followed
by an integer ``flag`` (bits, combined with ``|`` along a chain).  A candidate is not verified here: an
unreachable instance gives its clamped (nearest) candidate, and the caller measures every candidate by
forward kinematics.  The bits:

* :data:`TANGENT_ROOT` (1): two roots (nearly) coincide; roundoff locates them to about sqrt(eps), so
  the caller polishes near misses with Newton steps and merges the duplicates.
* :data:`FAMILY` (2): a gimbal lock in an orientation step; the slot holds the representative with the
  last angle 0 of a one-parameter family of solutions (a self-motion), flagged ``continuum`` when exact.
* :data:`DEFER` (4): any other geometry close to a degenerate case (a point on an axis, coincident
  axes, parallel slides): the caller sends the instance to the reference path
  (:mod:`subproblems.plan_runtime`), which classifies it properly.
* :data:`EMPTY` (8): no candidate in this slot (only from :func:`reference`, whose solvers fill a
  variable number of slots); the caller drops the leaf.
* :data:`LOCK` (16): a joint of an S2-RR step left free by its geometry (the point on the joint's
  axis): the slot holds the representative ``rep`` for it.  The rest of the chain may fix that joint
  or leave a self-motion; the Python paths defer such a leaf as :data:`DEFER`, the C finish settles it
  only where its representatives lie on a straight-line self-motion (docs/design.md section 6).

Equations (axis ``w`` unit, through point ``r``; ``exp`` the joint motion):

* :func:`plane_r`   H-R   ``h . exp(w th)(p) = d``            2 slots
* :func:`plane_t`   H-T   ``h . (p + v th) = d``               1 slot
* :func:`dist_r`    S3-R  ``|exp(w th)(p) - q| = d``           2 slots
* :func:`dist_t`    S3-T  ``|p + v th - q| = d``               2 slots
* :func:`point_r`   S2-R  ``exp(w th)(p) = q``                 1 slot
* :func:`turn_slide2` S1-RTT ``exp(xi1 t1) exp(v2 t2) exp(v3 t3) = T``  1 slot
* :func:`slide1`    S2-T, S1-T ``v t = b``                       1 slot
* :func:`slide3`    S2-TTT, S1-TTT ``v1 t1 + v2 t2 + v3 t3 = b`` 1 slot
* :func:`slide2_turn` S2-TTR ``v1 t1 + v2 t2 + exp(xi3 t3)(p) = q``  2 slots
* :func:`point_rr_meet`  S2-RR, axes meeting at ``c``          2 slots
* :func:`point_rr_parallel`  S2-RR, parallel axes              2 slots
* :func:`rot_r`, :func:`rot_rr`, :func:`rot_rrr`   O-R, O-RR, O-RRR on a rotation ``R`` (9-tuple,
  row-major): 1, 1 and 2 slots
* :func:`point_rrr` S2-RRR ``exp(xi1 t1) exp(xi2 t2) exp(xi3 t3)(p) = q``, the regular case (a quartic)
  4 slots
"""

from __future__ import annotations

import functools
import math
from types import SimpleNamespace

import numpy as np

from subproblems import tolerances
from subproblems.angles import wrap, wrap_array
from subproblems.screw import cross_tuple as cross  # on 3-tuples, as the helpers below

TANGENT_ROOT, FAMILY, DEFER, EMPTY, LOCK = 1, 2, 4, 8, 16
HAND_BACK = DEFER | LOCK  # leaves the Python paths send to the reference runtime
NEAR = tolerances.FAST_DEGENERATE  # tolerances in subproblems/tolerances.py (docs/design.md section 10)
# Relative (squared) distance from a double root below which two roots are one tangent root: there
# roundoff splits the root by up to sqrt(eps), so the reference path polishes and merges them.
TANGENT = tolerances.FAST_TANGENT
NEAR2 = NEAR * NEAR
SPLIT_ROOT = tolerances.FAST_SPLIT_ROOT
TINY = tolerances.TINY

SCALAR = SimpleNamespace(
    sin=math.sin,
    cos=math.cos,
    sqrt=math.sqrt,
    atan2=math.atan2,
    acos=math.acos,
    clip1=lambda x: -1.0 if x < -1.0 else (1.0 if x > 1.0 else x),
    pos=lambda x: x if x > 0.0 else 0.0,
    big=lambda x: x if x > TINY else TINY,
    cbrt=math.cbrt,
    maxabs=lambda *xs: max(map(abs, xs)),
    where=lambda c, a, b: a if c else b,
    max2=max,
    name="scalar",
)

ARRAY = SimpleNamespace(
    sin=np.sin,
    cos=np.cos,
    sqrt=np.sqrt,
    atan2=np.arctan2,
    acos=np.arccos,
    cbrt=np.cbrt,
    clip1=lambda x: np.clip(x, -1.0, 1.0),
    pos=lambda x: np.fmax(x, 0.0),  # fmax: NaN -> 0.0, as the scalar comparison gives
    big=lambda x: np.fmax(x, TINY),
    maxabs=lambda *xs: functools.reduce(np.maximum, map(np.abs, xs)),
    max2=np.maximum,
    where=np.where,
    name="array",
)


# ---------------------------------------------------------------------------------------------------
# 3-vector arithmetic on tuples (floats or arrays alike)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def axpy(s, a, b):
    """``s a + b``."""
    return (s * a[0] + b[0], s * a[1] + b[1], s * a[2] + b[2])


def mat_vec(R, x):
    return (
        R[0] * x[0] + R[1] * x[1] + R[2] * x[2],
        R[3] * x[0] + R[4] * x[1] + R[5] * x[2],
        R[6] * x[0] + R[7] * x[1] + R[8] * x[2],
    )


def mat_t_vec(R, x):
    return (
        R[0] * x[0] + R[3] * x[1] + R[6] * x[2],
        R[1] * x[0] + R[4] * x[1] + R[7] * x[2],
        R[2] * x[0] + R[5] * x[1] + R[8] * x[2],
    )


def rotate(m, w, th, x):
    """``exp([w] th) x`` (Rodrigues)."""
    return _turn_cs(w, m.cos(th), m.sin(th), x)


def unit_pair(m, c, s):
    """``(cos th, sin th)`` of ``th = atan2(s, c)`` from the pair itself: ``(c, s) / |(c, s)|``, and
    ``(1, 0)`` (the angle 0's) for a zero pair.  Branch-free, the same arithmetic on both backends
    and in C (``fast_kernels.h``), so the chain can take it instead of ``cos`` and ``sin`` of the angle
    (docs/design.md section 11, "cos and sin of kernel outputs")."""
    r = m.sqrt(c * c + s * s)
    inv = 1.0 / m.big(r)
    return c * inv + (r == 0.0), s * inv


def angle_about_cs(m, w, u, v, size2=0.0):
    """:func:`angle_about` and the cosine and sine of its angle: ``(th, flag, cos th, sin th)``."""
    w0, w1, w2 = w
    u0, u1, u2 = u
    v0, v1, v2 = v
    uw = w0 * u0 + w1 * u1 + w2 * u2
    vw = w0 * v0 + w1 * v1 + w2 * v2
    a0, a1, a2 = u0 - uw * w0, u1 - uw * w1, u2 - uw * w2
    b0, b1, b2 = v0 - vw * w0, v1 - vw * w1, v2 - vw * w2
    sin_part = w0 * (a1 * b2 - a2 * b1) + w1 * (a2 * b0 - a0 * b2) + w2 * (a0 * b1 - a1 * b0)
    cos_part = a0 * b0 + a1 * b1 + a2 * b2
    th = m.atan2(sin_part, cos_part)
    lim = NEAR2 * (u0 * u0 + u1 * u1 + u2 * u2 + v0 * v0 + v1 * v1 + v2 * v2 + size2 + 1.0)
    flag = ((a0 * a0 + a1 * a1 + a2 * a2 <= lim) | (b0 * b0 + b1 * b1 + b2 * b2 <= lim)) * DEFER
    c, s = unit_pair(m, cos_part, sin_part)
    return th, flag, c, s


def angle_about(m, w, u, v, size2=0.0):
    """The angle that turns ``u`` toward ``v`` about ``w`` (their components across ``w``): S1-R.

    Returns ``(th, flag)``; :data:`DEFER` when either vector is (nearly) along ``w``, where every angle
    is equally good; "nearly" is relative to the vectors, to ``size2``, the squared size of the
    geometry they come from (a point on an axis up to roundoff has rounding-sized vectors), and to
    one unit of length (so a geometry of rounding-sized vectors is degenerate too).  The arithmetic is
    :func:`angle_about_cs`'s (written out component by component there: the innermost call of every
    chain, where helper calls cost more than the arithmetic on floats).
    """
    th, flag, _, _ = angle_about_cs(m, w, u, v, size2)  # one arithmetic with the _cs form (and C)
    return th, flag


def trig_roots_cs(m, a, b, c, size, rep=0.0):
    """Both roots of ``a cos th + b sin th = c`` (clamped to the nearest when ``|c| > rho``), each with
    its cosine and sine: ``(th, flag, cos th, sin th)`` twice.

    When ``rho = |(a, b)|`` is negligible against ``size`` the equation hardly depends on ``th``: if
    ``c`` is negligible too, every angle solves it (a self-motion): both slots hold the
    representative ``th = rep``, flagged :data:`FAMILY`; otherwise no angle does, or the instance is
    too close to call: :data:`DEFER`.  The roots are ``phi +- delta``: cos phi = a / rho,
    sin phi = b / rho (:func:`unit_pair`), cos delta the clipped ``c / rho``,
    sin delta = sqrt((1 - cos)(1 + cos)) >= 0 (delta = acos in [0, pi])."""
    rho = m.sqrt(a * a + b * b)
    phi = m.atan2(b, a)
    x = c / m.big(rho)
    cd = m.clip1(x)
    delta = m.acos(cd)
    flat = rho <= NEAR * size
    every = flat & (abs(c) <= NEAR * size)
    tangent = (abs(x * x - 1.0) <= TANGENT) * (rho > NEAR * size)
    flag = (flat ^ every) * DEFER | every * FAMILY | tangent * TANGENT_ROOT
    here = rep + 0.0 * phi
    cp, sp = unit_pair(m, a, b)
    sd = m.sqrt(m.pos((1.0 - cd) * (1.0 + cd)))
    ch, sh = m.cos(here), m.sin(here)
    return ((m.where(every, here, phi + delta), flag, m.where(every, ch, cp * cd - sp * sd),
             m.where(every, sh, sp * cd + cp * sd)),
            (m.where(every, here, phi - delta), flag, m.where(every, ch, cp * cd + sp * sd),
             m.where(every, sh, sp * cd - cp * sd)))


def _without_trig(slots, outs: int):
    """A ``_cs`` kernel's slots without the cosines and sines (the kernel's plain form)."""
    return tuple(slot[: outs + 1] for slot in slots)


# ---------------------------------------------------------------------------------------------------
# the kernels


def plane_r_cs(m, w, r, p, h, d, rep=0.0):
    """H-R: ``h . exp(w th)(p) = d`` for a revolute axis (w, r); ``rep``: see :func:`trig_roots_cs`.
    Each slot also holds cos and sin of its angle (``_cs`` kernels; :func:`plane_r` without them)."""
    u = sub(p, r)
    uw = dot(w, u)
    up = axpy(-uw, w, u)
    a = dot(h, up)
    b = dot(h, cross(w, u))
    c = d - dot(h, r) - uw * dot(h, w)
    size = m.sqrt(dot(h, h) * (dot(u, u) + dot(r, r) + dot(p, p) + 1.0)) + TINY
    return trig_roots_cs(m, a, b, c, size, rep)


def plane_r(m, w, r, p, h, d, rep=0.0):
    """:func:`plane_r_cs` without the cosines and sines."""
    return _without_trig(plane_r_cs(m, w, r, p, h, d, rep), 1)


def plane_t(m, v, p, h, d, rep=0.0):
    """H-T: ``h . (p + v th) = d``.  With ``h`` (nearly) across the slide every ``th`` gives the same
    value: the representative ``th = rep``, flagged :data:`FAMILY`."""
    hv = dot(h, v)
    across = (hv * hv) <= NEAR2 * dot(h, h)
    th = (d - dot(h, p)) / m.where(across, 1.0, hv)
    return (m.where(across, rep + 0.0 * th, th), across * FAMILY),


def dist_r(m, w, r, p, q, d, rep=0.0):
    """:func:`dist_r_cs` without the cosines and sines."""
    return _without_trig(dist_r_cs(m, w, r, p, q, d, rep), 1)


def dist_r_cs(m, w, r, p, q, d, rep=0.0):
    """S3-R: ``|exp(w th)(p) - q| = d``: the plane equation with normal ``q - r``; ``rep``: see
    :func:`trig_roots`.  Slots with cos and sin (``_cs``)."""
    u = sub(p, r)
    z = sub(q, r)
    uw = dot(w, u)
    up = axpy(-uw, w, u)
    a = dot(z, up)
    b = dot(z, cross(w, u))
    c = 0.5 * (dot(u, u) + dot(z, z) - d * d) - uw * dot(z, w)
    return trig_roots_cs(m, a, b, c, dot(u, u) + dot(z, z) + dot(r, r) + d * d + 1.0, rep)


def dist_t(m, v, p, q, d):
    """S3-T: ``|p + v th - q| = d``: a quadratic (clamped to its vertex when it has no real root)."""
    e = sub(p, q)
    ve = dot(v, e)
    disc = ve * ve - dot(e, e) + d * d
    root = m.sqrt(m.pos(disc))
    tangent = (abs(disc) <= TANGENT * (ve * ve + d * d + dot(p, p) + dot(q, q) + 1.0)) * TANGENT_ROOT
    return (-ve + root, tangent), (-ve - root, tangent)


def slide1(m, v, b):
    """S2-T / S1-T: ``v t = b``: the component of ``b`` along the slide (what is left across it, and a
    rotation S1-T's target may hold, the chain's pose error measures); defer a (nearly) zero slide."""
    vv = dot(v, v)
    return (dot(v, b) / (vv + TINY), (vv <= NEAR2) * DEFER),


def slide3(m, v1, v2, v3, b):
    """S2-TTT / S1-TTT: ``v1 t1 + v2 t2 + v3 t3 = b`` (Cramer's rule); defer when the slides are
    (nearly) coplanar."""
    c23, c31, c12 = cross(v2, v3), cross(v3, v1), cross(v1, v2)
    det = dot(v1, c23)
    scale = m.sqrt(dot(v1, v1) * dot(v2, v2) * dot(v3, v3)) + TINY
    inv = 1.0 / (det + (det >= 0.0) * TINY - (det < 0.0) * TINY)
    return (dot(b, c23) * inv, dot(b, c31) * inv, dot(b, c12) * inv, (abs(det) <= NEAR * scale) * DEFER),


def turn_slide2(m, w, r, v2, v3, R, t):
    """S1-RTT: ``exp(xi1 t1) exp(v2 t2) exp(v3 t3) = (R, t)`` with xi1 about the axis (w, r).

    The rotation gives t1 (O-R); the slides then move ``x = R1^T (t - r) + r`` (the translation seen
    before the turn): ``v2 t2 + v3 t3 = x``, solved by normal equations; defer when the slides are
    (nearly) parallel."""
    ((t1, f1),) = rot_r(m, w, R)
    x = rotate(m, w, -t1, sub(t, r))
    x = (x[0] + r[0], x[1] + r[1], x[2] + r[2])
    a, b, e = dot(v2, v2), dot(v2, v3), dot(v3, v3)
    det = a * e - b * b
    inv = 1.0 / m.big(det)
    y2, y3 = dot(v2, x), dot(v3, x)
    return ((t1, (e * y2 - b * y3) * inv, (a * y3 - b * y2) * inv, f1 | (det <= NEAR * a * e) * DEFER),)


def slide2_turn(m, v1, v2, w, r, p, q, rep=0.0):
    """S2-TTR: ``v1 t1 + v2 t2 + exp(xi3 t3)(p) = q`` with xi3 about the axis (w, r).

    Across both slides (the normal ``n = v1 x v2``) they move nothing: ``n . exp(xi3 t3)(p) = n . q``
    gives t3 (H-R, 2 slots; ``rep``: see :func:`trig_roots_cs`); the slides then take
    ``x = q - exp(xi3 t3)(p)``: ``v1 t1 + v2 t2 = x`` by normal equations.  Defer when the slides are
    (nearly) parallel, where the normal is not defined."""
    n = cross(v1, v2)
    a, b, e = dot(v1, v1), dot(v1, v2), dot(v2, v2)
    det = a * e - b * b
    inv = 1.0 / m.big(det)
    parallel = (det <= NEAR * a * e) * DEFER
    u = sub(p, r)
    out = []
    for t3, f3 in plane_r(m, w, r, p, n, dot(n, q), rep):
        y = rotate(m, w, t3, u)
        x = (q[0] - y[0] - r[0], q[1] - y[1] - r[1], q[2] - y[2] - r[2])
        y1, y2 = dot(v1, x), dot(v2, x)
        out.append(((e * y1 - b * y2) * inv, (a * y2 - b * y1) * inv, t3, f3 | parallel))
    return tuple(out)


def point_r_cs(m, w, r, p, q):
    """S2-R: ``exp(w th)(p) = q``; the slot with cos and sin (``_cs``)."""
    return angle_about_cs(m, w, sub(p, r), sub(q, r), dot(p, p) + dot(q, q) + dot(r, r)),


def point_r(m, w, r, p, q):
    """:func:`point_r_cs` without the cosines and sines."""
    return _without_trig(point_r_cs(m, w, r, p, q), 1)


def point_rr_meet(m, w1, r1, w2, r2, p, q, rep=0.0):
    """:func:`point_rr_meet_cs` without the cosines and sines."""
    return _without_trig(point_rr_meet_cs(m, w1, r1, w2, r2, p, q, rep), 2)


def point_rr_meet_cs(m, w1, r1, w2, r2, p, q, rep=0.0):
    """S2-RR, axes meeting: ``exp(w1 t1) exp(w2 t2)(p) = q`` (Paden-Kahan 2).

    With ``c`` the meeting point, the middle point ``z = exp(w2 t2)(p) - c = exp(-w1 t1)(q) - c`` keeps
    its components along ``w2`` (from ``p``) and along ``w1`` (from ``q``); its length fixes the
    component across both.  Parallel axes defer; an angle left free (a point on its axis) is ``rep``,
    flagged :data:`LOCK`.
    """
    k = dot(w1, w2)
    n = cross(w1, w2)
    nn = dot(n, n)
    parallel = nn <= NEAR
    den = m.where(parallel, 1.0, nn)  # parallel axes defer; keep their arithmetic finite
    # the meeting point: r1 + s w1 with s = ((r2 - r1) x w2) . n / |n|^2
    s = dot(cross(sub(r2, r1), w2), n) / den
    c = axpy(s, w1, r1)
    u, v = sub(p, c), sub(q, c)
    size2 = dot(p, p) + dot(q, q) + dot(r1, r1) + dot(r2, r2)  # squared size of the geometry
    a1, a2 = dot(w1, v), dot(w2, u)
    alpha = (a1 - k * a2) / den
    beta = (a2 - k * a1) / den
    uu = dot(u, u)
    g2 = (uu - alpha * alpha - beta * beta - 2.0 * alpha * beta * k) / den
    gamma = m.sqrt(m.pos(g2))
    degenerate = parallel * DEFER | (abs(g2) * nn <= TANGENT * uu) * TANGENT_ROOT
    out = []
    for g in (gamma, -gamma):
        z = (
            alpha * w1[0] + beta * w2[0] + g * n[0],
            alpha * w1[1] + beta * w2[1] + g * n[1],
            alpha * w1[2] + beta * w2[2] + g * n[2],
        )
        t2, f2, c2, s2 = _locked_cs(m, *angle_about_cs(m, w2, u, z, size2), rep)
        t1, f1, c1, s1 = _locked_cs(m, *angle_about_cs(m, w1, z, v, size2), rep)
        out.append((t1, t2, degenerate | f1 | f2, c1, s1, c2, s2))
    return tuple(out)


def _locked_cs(m, th, flag, c, s, rep):
    """An S2-RR angle that its geometry leaves free (:func:`angle_about_cs` defers: the point on the
    axis) as the representative ``rep``, flagged :data:`LOCK`, with its cosine and sine."""
    lock = flag != 0
    here = rep + 0.0 * th
    return (m.where(lock, here, th), m.where(lock, LOCK, flag), m.where(lock, m.cos(here), c),
            m.where(lock, m.sin(here), s))


def point_rr_parallel(m, w1, r1, w2, r2, p, q, rep=0.0):
    """:func:`point_rr_parallel_cs` without the cosines and sines."""
    return _without_trig(point_rr_parallel_cs(m, w1, r1, w2, r2, p, q, rep), 2)


def point_rr_parallel_cs(m, w1, r1, w2, r2, p, q, rep=0.0):
    """S2-RR, parallel axes (``w2 = +-w1``): ``exp(w1 t1) exp(w2 t2)(p) = q`` (a planar 2R arm).

    The middle point ``z = exp(w2 t2)(p)`` keeps its height along the axes (from ``p``), its distance
    to axis 2 (from ``p``) and its distance to axis 1 (from ``q``): two circles in the plane across
    the axes meet in at most two points.  Coincident axes defer; an angle left free (a point on its
    axis) is ``rep``, flagged :data:`LOCK`.
    """
    w0, w1_, w2_ = w1
    # e: from axis 2 to axis 1, across the axes; u2: p from axis 2, across; v1: q from axis 1, across
    e0, e1, e2 = r1[0] - r2[0], r1[1] - r2[1], r1[2] - r2[2]
    h = w0 * e0 + w1_ * e1 + w2_ * e2
    e0, e1, e2 = e0 - h * w0, e1 - h * w1_, e2 - h * w2_
    u0, u1, u2 = p[0] - r2[0], p[1] - r2[1], p[2] - r2[2]
    height = w0 * u0 + w1_ * u1 + w2_ * u2
    a0, a1, a2 = u0 - height * w0, u1 - height * w1_, u2 - height * w2_
    v0, v1, v2 = q[0] - r1[0], q[1] - r1[1], q[2] - r1[2]
    h = w0 * v0 + w1_ * v1 + w2_ * v2
    b0, b1, b2 = v0 - h * w0, v1 - h * w1_, v2 - h * w2_
    ee = e0 * e0 + e1 * e1 + e2 * e2
    rho2 = a0 * a0 + a1 * a1 + a2 * a2
    rho1 = b0 * b0 + b1 * b1 + b2 * b2
    x = (rho2 - rho1 + ee) / (2.0 * m.big(ee))  # along e, in units of |e|
    y2 = rho2 / m.big(ee) - x * x
    y = m.sqrt(m.pos(y2))
    f0, f1, f2 = w1_ * e2 - w2_ * e1, w2_ * e0 - w0 * e2, w0 * e1 - w1_ * e0  # w x e
    size2 = dot(p, p) + dot(q, q) + dot(r1, r1) + dot(r2, r2)  # squared size of the geometry
    coincident = (ee <= NEAR2 * (rho1 + rho2 + size2 + 1.0)) * DEFER
    degenerate = coincident | (abs(y2) * ee <= TANGENT * rho2) * TANGENT_ROOT
    out = []
    for s in (y, -y):
        z = (x * e0 + s * f0, x * e1 + s * f1, x * e2 + s * f2)  # middle point from axis 2, across
        t2, g2, c2, s2 = _locked_cs(m, *angle_about_cs(m, w2, (a0, a1, a2), z, size2), rep)
        t1, g1, c1, s1 = _locked_cs(m, *angle_about_cs(m, w1, (z[0] - e0, z[1] - e1, z[2] - e2),
                                                        (b0, b1, b2), size2), rep)
        out.append((t1, t2, degenerate | g1 | g2, c1, s1, c2, s2))
    return tuple(out)


def rot_r_cs(m, w, R):
    """O-R: ``exp([w] th) = R``: ``cos th = (tr R - w.Rw) / 2``, ``sin th`` from the skew part along w.
    The slot with cos and sin (``_cs``)."""
    c = 0.5 * (R[0] + R[4] + R[8] - dot(w, mat_vec(R, w)))
    s = 0.5 * (w[0] * (R[7] - R[5]) + w[1] * (R[2] - R[6]) + w[2] * (R[3] - R[1]))
    return (m.atan2(s, c), (c != c) * DEFER, *unit_pair(m, c, s)),


def rot_r(m, w, R):
    """:func:`rot_r_cs` without the cosines and sines."""
    return _without_trig(rot_r_cs(m, w, R), 1)


def rot_rr_cs(m, w1, w2, R):
    """O-RR: ``exp([w1] t1) exp([w2] t2) = R``: t1 turns w2 onto R w2, t2 turns R^T w1 onto w1.
    The slot with cos and sin of both (``_cs``)."""
    t1, f1, c1, s1 = angle_about_cs(m, w1, w2, mat_vec(R, w2))
    t2, f2, c2, s2 = angle_about_cs(m, w2, mat_t_vec(R, w1), w1)
    return (t1, t2, f1 | f2, c1, s1, c2, s2),


def rot_rr(m, w1, w2, R):
    """:func:`rot_rr_cs` without the cosines and sines."""
    return _without_trig(rot_rr_cs(m, w1, w2, R), 2)


def rot_rrr(m, w1, w2, w3, R, rep=0.0):
    """:func:`rot_rrr_cs` without the cosines and sines."""
    return _without_trig(rot_rrr_cs(m, w1, w2, w3, R, rep), 3)


def rot_rrr_cs(m, w1, w2, w3, R, rep=0.0):
    """O-RRR: ``exp([w1] t1) exp([w2] t2) exp([w3] t3) = R``.

    ``w1 . R w3 = w1 . exp([w2] t2) w3`` gives t2 (two roots); then t1 turns ``exp([w2] t2) w3`` onto
    ``R w3`` and t3 turns ``R^T w1`` onto ``exp(-[w2] t2) w1``.  Gimbal lock (``exp([w2] t2) w3``
    along ``w1``) gives the representative t3 = ``rep``, flagged :data:`FAMILY` (the native backend
    tries other values when the rest of the chain cannot complete ``rep = 0``).
    """
    Rw3 = mat_vec(R, w3)
    Rtw1 = mat_t_vec(R, w1)
    k12, k23 = dot(w1, w2), dot(w2, w3)
    w23, w21 = cross(w2, w3), cross(w2, w1)
    # w1 . exp([w2] t2) w3 = a cos t2 + b sin t2 + k12 k23
    a = dot(w1, w3) - k12 * k23
    b = dot(w1, w23)
    c = dot(w1, Rw3) - k12 * k23
    # at a gimbal lock t2 is the tangent root phi (or phi + pi): use it exactly, not via acos(~1);
    # the representative t3 = rep then has t1 turning w2 onto R exp(-[w3] rep) exp(-[w2] t2) w2, which
    # is R exp(-[w3] rep) w2
    t2_lock = m.atan2(b, a) + (c < 0.0) * math.pi
    t1_rep, f_rep = angle_about(m, w1, w2, mat_vec(R, rotate(m, w3, -rep, w2)))
    # whether t2_lock is a lock at all (exp([w2] t2_lock) w3 along w1): then a tangent t2 equation is
    # that lock, its roots split by upstream roundoff (a stretched arm before the wrist) by ~sqrt(eps)
    cl, sl = m.cos(t2_lock), m.sin(t2_lock)
    kl = k23 * (1.0 - cl)
    zl = (cl * w3[0] + sl * w23[0] + kl * w2[0], cl * w3[1] + sl * w23[1] + kl * w2[1],
          cl * w3[2] + sl * w23[2] + kl * w2[2])
    off = cross(w1, zl)
    aligned = dot(off, off) <= NEAR2
    out = []
    for t2, f2, c2, s2 in trig_roots_cs(m, a, b, c, 1.0, rep):
        k3, k1 = k23 * (1.0 - c2), k12 * (1.0 - c2)
        z = (  # exp([w2] t2) w3
            c2 * w3[0] + s2 * w23[0] + k3 * w2[0],
            c2 * w3[1] + s2 * w23[1] + k3 * w2[1],
            c2 * w3[2] + s2 * w23[2] + k3 * w2[2],
        )
        y = (  # exp(-[w2] t2) w1
            c2 * w1[0] - s2 * w21[0] + k1 * w2[0],
            c2 * w1[1] - s2 * w21[1] + k1 * w2[1],
            c2 * w1[2] - s2 * w21[2] + k1 * w2[2],
        )
        t1, f1, c1, s1 = angle_about_cs(m, w1, z, Rw3)
        t3, f3, c3, s3 = angle_about_cs(m, w3, Rtw1, y)
        # Gimbal lock (exp([w2] t2) w3 along w1): only t1 +- t3 is fixed; the representative above.
        lock = ((f1 | f3) != 0) | (((f2 & TANGENT_ROOT) != 0) & aligned)
        t1 = m.where(lock, t1_rep, t1)
        t2 = m.where(lock, t2_lock, t2)
        t3 = m.where(lock, rep + 0.0 * t3, t3)
        f13 = lock * (FAMILY | f_rep)
        trig = [m.where(lock, m.cos(t), x) if k % 2 == 0 else m.where(lock, m.sin(t), x)  # a lock: libm's
                for k, (t, x) in enumerate(((t1, c1), (t1, s1), (t2, c2), (t2, s2), (t3, c3), (t3, s3)))]
        out.append((t1, t2, t3, f2 | f13, *trig))
    return tuple(out)


# ---------------------------------------------------------------------------------------------------
# S2-RRR: a point carried onto a point by three turns (subproblems/s2_rrr.py, the regular case)

#: |det M| below this times |M|^2 (axes 2 and 3 nearly parallel or meeting: M nearly rank 1, where
#: Cramer's rule loses the digits the quartic needs): the reference path (its rank-1 construction).
RRR_REGULAR = tolerances.FAST_RRR_REGULAR
#: A polished root whose derivative is below this (relative) is (nearly) double: a tangency, roots
#: split by roundoff, or a complex pair beside the circle: the reference path merges or projects it.
RRR_DOUBLE = tolerances.FAST_RRR_DOUBLE
RRR_NEWTON = 3  # Newton steps on the quartic's trigonometric form (Ferrari's roots have ~1e-8 errors)
# the half-angle substitution is centred on one of these angles (where |F| is largest: no root is
# near it, so the quartic's leading coefficient is the largest sample and its roots stay bounded)
_RRR_SAMPLES = tuple((math.cos(k * math.pi / 4), math.sin(k * math.pi / 4)) for k in range(8))


def _trig2(f, c, s):
    """``f0 + c1 cos + s1 sin + c2 cos 2 + s2 sin 2`` at the angle of (cos, sin) = (c, s)."""
    f0, c1, s1, c2, s2 = f
    return f0 + c1 * c + s1 * s + c2 * (c * c - s * s) + s2 * (2.0 * s * c)


def _cubic_largest(m, p, q, r):
    """The largest real root of ``x^3 + p x^2 + q x + r`` (Cardano's or Viete's form, then two
    Newton steps)."""
    a = q - p * p / 3.0
    b = 2.0 * p * p * p / 27.0 - p * q / 3.0 + r
    disc = 0.25 * b * b + a * a * a / 27.0
    sq = m.sqrt(m.pos(disc))
    one = m.cbrt(-0.5 * b + sq) + m.cbrt(-0.5 * b - sq)  # one real root
    ra = m.sqrt(m.pos(-a / 3.0))  # three real roots: 2 ra cos(acos(...) / 3)
    three = 2.0 * ra * m.cos(m.acos(m.clip1(-0.5 * b / m.big(ra * ra * ra))) / 3.0)
    x = m.where(disc > 0.0, one, three) - p / 3.0
    for _ in range(2):
        g = ((x + p) * x + q) * x + r
        dg = (3.0 * x + 2.0 * p) * x + q
        x = x - g * dg / (dg * dg + TINY)
    return x


def _quartic_real(m, b, c, d, e):
    """The four roots of ``x^4 + b x^3 + c x^2 + d x + e`` as real numbers (Ferrari): two quadratics,
    a complex pair's real part twice; each quadratic's discriminant (negative: a complex pair); the
    depressed quartic's ``p`` and the resolvent's root ``k`` (the discriminants' scale)."""
    b4 = 0.25 * b
    p = c - 6.0 * b4 * b4
    q = d - 2.0 * c * b4 + 8.0 * b4 * b4 * b4
    r = e - d * b4 + c * b4 * b4 - 3.0 * b4 * b4 * b4 * b4
    # y^4 + p y^2 + q y + r = (y^2 + p/2 + k)^2 - 2k (y - q / 4k)^2 with k the resolvent's root
    k = m.pos(_cubic_largest(m, p, 0.25 * p * p - r, -0.125 * q * q))
    s = m.sqrt(2.0 * k)
    tiny = s * s <= 1e-14 * (abs(p) + m.sqrt(abs(r)) + TINY)  # q ~ 0: y^4 + p y^2 + r, a quadratic in y^2
    h = m.where(tiny, 0.0, q / (2.0 * m.big(m.where(tiny, 1.0, s))))  # big: s = 0 where r is NaN
    z = m.sqrt(m.pos(0.25 * p * p - r))
    out, discs = [], []
    for sign in (1.0, -1.0):
        # ferrari: y^2 - sign s y + (p/2 + k + sign h) = 0; biquadratic: y^2 = -p/2 - sign z
        disc_f = 0.25 * s * s - (0.5 * p + k + sign * h)
        y2 = -0.5 * p - sign * z
        disc = m.where(tiny, y2, disc_f)
        root = m.sqrt(m.pos(disc))
        centre = m.where(tiny, 0.0, 0.5 * sign * s)
        out += [centre + root - b4, centre - root - b4]
        discs.append(disc)
    return out, discs, p, k


def point_rrr(m, w1, r1, w2, r2, w3, r3, p, q):
    """S2-RRR: ``exp(xi1 t1) exp(xi2 t2) exp(xi3 t3)(p) = q`` (axes (w_i, r_i)) where the middle axis
    is neither parallel to the third nor meets it: up to 4 slots (t1, t2, t3).

    The elimination of :mod:`subproblems.s2_rrr`: ``y(t1) = exp(-xi1 t1) q`` and ``z(t3) = exp(xi3 t3) p``
    have the same height along axis 2 and the same distance from it, ``M (cos t3, sin t3) = E(t1)``;
    Cramer's rule and ``|adj(M) E(t1)| = |det M|`` give a trigonometric quartic in t1, solved by the
    half-angle substitution (centred where the quartic is largest) and Ferrari, then Newton steps;
    t3 from Cramer's point, t2 turns ``z`` onto ``y`` (S2-R); one Newton step on the whole equation.
    A complex pair's slots are :data:`EMPTY` where the other pair is real.  Deferred: both pairs
    complex (unreachable: the reference path's least-squares row), M nearly rank 1
    (:data:`RRR_REGULAR`), ``p`` on axis 3 or ``q`` on axis 1, a quartic vanishing identically (t1
    free), a (nearly) double root (:data:`RRR_DOUBLE`), the middle point on axis 2 (t2 free).
    4 slots."""
    size2 = dot(p, p) + dot(q, q) + dot(r1, r1) + dot(r2, r2) + dot(r3, r3)
    size = m.sqrt(size2) + TINY
    # circle of q about axis 1: y = c0 + cc cos t1 - cs sin t1; of p about axis 3: z = e0 + ec cos + es sin
    u = sub(q, r1)
    uw = dot(w1, u)
    cc = axpy(-uw, w1, u)
    cs = cross(w1, cc)
    c0 = axpy(uw, w1, r1)
    v = sub(p, r3)
    vw = dot(w3, v)
    ec = axpy(-vw, w3, v)
    es = cross(w3, ec)
    e0 = axpy(vw, w3, r3)
    k, h = sub(e0, r2), sub(c0, r2)
    # rows: the height along axis 2, the squared distance from r2 (divided by the size: lengths)
    m00, m01 = dot(w2, ec), dot(w2, es)
    m10, m11 = 2.0 * dot(k, ec) / size, 2.0 * dot(k, es) / size
    g0 = (dot(w2, sub(c0, e0)), (dot(h, h) + dot(cc, cc) - dot(k, k) - dot(ec, ec)) / size)
    gc = (dot(w2, cc), 2.0 * dot(h, cc) / size)
    gs = (-dot(w2, cs), -2.0 * dot(h, cs) / size)
    det = m00 * m11 - m01 * m10
    mm = m00 * m00 + m01 * m01 + m10 * m10 + m11 * m11
    # adj(M) E(t1) = A0 + Ac cos t1 + As sin t1; |.|^2 - det^2 as a Fourier series in t1
    a0 = (m11 * g0[0] - m01 * g0[1], m00 * g0[1] - m10 * g0[0])
    ac = (m11 * gc[0] - m01 * gc[1], m00 * gc[1] - m10 * gc[0])
    as_ = (m11 * gs[0] - m01 * gs[1], m00 * gs[1] - m10 * gs[0])
    qa = ac[0] * ac[0] + ac[1] * ac[1]
    qb = 2.0 * (ac[0] * as_[0] + ac[1] * as_[1])
    qc = as_[0] * as_[0] + as_[1] * as_[1]
    f = (a0[0] * a0[0] + a0[1] * a0[1] - det * det + 0.5 * (qa + qc),
         2.0 * (a0[0] * ac[0] + a0[1] * ac[1]), 2.0 * (a0[0] * as_[0] + a0[1] * as_[1]),
         0.5 * (qa - qc), 0.5 * qb)
    ee = g0[0] * g0[0] + g0[1] * g0[1] + gc[0] * gc[0] + gc[1] * gc[1] + gs[0] * gs[0] + gs[1] * gs[1]
    ref = mm * (mm + ee) + TINY  # the coefficients' size
    fn = m.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2] + f[3] * f[3] + f[4] * f[4])
    lim = NEAR2 * size2
    flag = ((det * det <= RRR_REGULAR * RRR_REGULAR * mm * mm) | (dot(cc, cc) <= lim) | (dot(ec, ec) <= lim)
            | (fn <= NEAR * ref)) * DEFER
    # the centre: the sample angle where |F| is largest; theta = t1 - phi, phi = centre - pi
    big_f, pc, ps = _trig2(f, 1.0, 0.0), -1.0, 0.0
    for c, s in _RRR_SAMPLES[1:]:
        fk = _trig2(f, c, s)
        better = abs(fk) > abs(big_f)
        big_f, pc, ps = m.where(better, fk, big_f), m.where(better, -c, pc), m.where(better, -s, ps)
    c2p, s2p = pc * pc - ps * ps, 2.0 * ps * pc
    f0, c1, s1, c2, s2 = f
    c1r, s1r = c1 * pc + s1 * ps, s1 * pc - c1 * ps  # the series in theta
    c2r, s2r = c2 * c2p + s2 * s2p, s2 * c2p - c2 * s2p
    # times (1 + x^2)^2, x = tan(theta / 2): a quartic whose leading coefficient is F(centre) = big_f
    inv = 1.0 / m.where(big_f == 0.0, 1.0, big_f)
    xs, discs, p_, k_ = _quartic_real(m, (2.0 * s1r - 4.0 * s2r) * inv, (2.0 * f0 - 6.0 * c2r) * inv,
                              (2.0 * s1r + 4.0 * s2r) * inv, (f0 + c1r + c2r) * inv)
    phi = m.atan2(ps, pc)
    # a complex pair is no solution: its slots are empty where the other pair is real, and the
    # instance goes to the reference path (its least-squares row) where both are complex; a
    # discriminant within roundoff of 0 is a double root (a tangency): the reference path too
    band = RRR_DOUBLE * RRR_DOUBLE * (1.0 + abs(p_) + k_)
    some_real = (discs[0] >= -band) | (discs[1] >= -band)
    out = []
    for i, x in enumerate(xs):
        d = discs[i // 2]
        real = d >= -band
        kind = (abs(d) <= band) * DEFER | (d < -band) * m.where(some_real, EMPTY, DEFER)
        t1 = phi + 2.0 * m.atan2(x, 1.0)
        for _ in range(RRR_NEWTON):  # on F(t1) itself: the quartic's roots to full accuracy
            c, s = m.cos(t1), m.sin(t1)
            c2_, s2_ = c * c - s * s, 2.0 * s * c
            fv = f0 + c1 * c + s1 * s + c2 * c2_ + s2 * s2_
            dv = s1 * c - c1 * s + 2.0 * (s2 * c2_ - c2 * s2_)
            t1 = m.where(real, t1 - fv * dv / (dv * dv + TINY), t1)
        c, s = m.cos(t1), m.sin(t1)
        c2_, s2_ = c * c - s * s, 2.0 * s * c
        fv = f0 + c1 * c + s1 * s + c2 * c2_ + s2 * s2_
        dv = s1 * c - c1 * s + 2.0 * (s2 * c2_ - c2 * s2_)
        double = (abs(dv) <= RRR_DOUBLE * ref) & (abs(fv) <= RRR_DOUBLE * ref)
        # Cramer's point (cos t3, sin t3) = adj(M) E(t1) / det
        t3 = m.atan2((a0[1] + ac[1] * c + as_[1] * s) * det, (a0[0] + ac[0] * c + as_[0] * s) * det)
        y = (c0[0] + cc[0] * c - cs[0] * s, c0[1] + cc[1] * c - cs[1] * s, c0[2] + cc[2] * c - cs[2] * s)
        c3, s3 = m.cos(t3), m.sin(t3)
        z = (e0[0] + ec[0] * c3 + es[0] * s3, e0[1] + ec[1] * c3 + es[1] * s3,
             e0[2] + ec[2] * c3 + es[2] * s3)
        t2, f2, c2t, s2t = angle_about_cs(m, w2, sub(z, r2), sub(y, r2), size2)
        n1, n2, n3 = _rrr_gauss_newton(m, w1, r1, w2, r2, w3, r3, p, q, (t1, t2, t3),
                                       (c, s, c2t, s2t, c3, s3))
        t1, t2, t3 = m.where(real, n1, t1), m.where(real, n2, t2), m.where(real, n3, t3)
        out.append((t1, t2, t3, flag | f2 | double * DEFER | kind))
    return tuple(out)


def _turn_cs(w, c, s, x):
    """:func:`rotate` by the angle whose cosine and sine are ``c``, ``s``."""
    w0, w1, w2 = w
    x0, x1, x2 = x
    k = (w0 * x0 + w1 * x1 + w2 * x2) * (1.0 - c)
    return (
        c * x0 + s * (w1 * x2 - w2 * x1) + k * w0,
        c * x1 + s * (w2 * x0 - w0 * x2) + k * w1,
        c * x2 + s * (w0 * x1 - w1 * x0) + k * w2,
    )


def _rrr_gauss_newton(m, w1, r1, w2, r2, w3, r3, p, q, t, cs):
    """One Newton step of ``exp(xi1 t1) exp(xi2 t2) exp(xi3 t3)(p) = q`` from ``t`` = (t1, t2, t3)
    (``cs``: their cosines and sines): the quartic's root t1 is located to eps over the root
    separation, and Cramer's t3 inherits that error over the separation (two roots 0.005 apart: 1e-11
    of the size).  A singular Jacobian (a tangency, deferred anyway) leaves the values as they are."""
    c1, s1, c2, s2, c3, s3 = cs
    x3 = axpy(1.0, _turn_cs(w3, c3, s3, sub(p, r3)), r3)
    x2 = axpy(1.0, _turn_cs(w2, c2, s2, sub(x3, r2)), r2)
    x1 = _turn_cs(w1, c1, s1, sub(x2, r1))  # the point, less r1
    # the axes 2 and 3 where they are: axis 2 carried by t1, axis 3 by t2 then t1 (points less r1)
    a2 = _turn_cs(w1, c1, s1, w2)
    b2 = _turn_cs(w1, c1, s1, sub(r2, r1))
    a3 = _turn_cs(w1, c1, s1, _turn_cs(w2, c2, s2, w3))
    b3 = _turn_cs(w1, c1, s1, sub(axpy(1.0, _turn_cs(w2, c2, s2, sub(r3, r2)), r2), r1))
    j1 = cross(w1, x1)  # d point / d t_i: w_i x (point - a point of axis i)
    j2 = cross(a2, sub(x1, b2))
    j3 = cross(a3, sub(x1, b3))
    e = sub(sub(q, r1), x1)
    c23, c31, c12 = cross(j2, j3), cross(j3, j1), cross(j1, j2)
    det = dot(j1, c23)
    ok = abs(det) > NEAR * m.sqrt(dot(j1, j1) * dot(j2, j2) * dot(j3, j3))
    inv = m.where(ok, 1.0, 0.0) / m.where(ok, det, 1.0)
    return t[0] + dot(e, c23) * inv, t[1] + dot(e, c31) * inv, t[2] + dot(e, c12) * inv


def _screw_rows(twists, n=None):
    """6-tuples of floats or arrays as an (m, 6) array, or (n, m, 6) when ``n`` is given."""
    if n is None:
        return np.array([[float(x) for x in t] for t in twists])
    return np.stack([np.stack([np.broadcast_to(np.asarray(x, float), (n,)) for x in t], axis=-1)
                     for t in twists], axis=1)


def _input(name, value, n=None):
    if name == "T":  # 12 entries: rotation row-major, translation
        rows = [value[0:3] + (value[9],), value[3:6] + (value[10],), value[6:9] + (value[11],)]
        if n is None:
            return np.array([[float(x) for x in r] for r in rows] + [[0.0, 0.0, 0.0, 1.0]])
        out = np.zeros((n, 4, 4))
        out[:, 3, 3] = 1.0
        for i, r in enumerate(rows):
            for j, x in enumerate(r):
                out[:, i, j] = x
        return out
    if name == "d":
        return float(value) if n is None else np.broadcast_to(np.asarray(value, float), (n,))
    if n is None:
        return np.array([float(x) for x in value])
    return np.stack([np.broadcast_to(np.asarray(x, float), (n,)) for x in value], axis=-1)


def reference(m, code, twists, inputs):
    """Any registered subproblem through its reference solver, in the kernels' slot convention.

    For steps with no plain-arithmetic kernel (S2-RRR of a snapped plan, S2-RR with skew axes, the other
    class I and class III types): ``twists`` are 6-tuples ``(v, w)`` of floats or arrays, ``inputs`` maps the
    solver's keywords (``T`` as 12 entries, ``p``, ``q``, ``h`` as 3-tuples, ``d``) to values.  A
    continuum defers; unfilled slots are flagged :data:`EMPTY`; least-squares rows are returned like
    exact ones (the caller's pose check tells them apart).
    """
    from subproblems.core import solve, solve_batch

    if m.name == "scalar":
        r = solve(code, twists=_screw_rows(twists), **{k: _input(k, v) for k, v in inputs.items()})
        flag = DEFER if r.continuum else 0
        return tuple(tuple(float(x) for x in row) + (flag,) for row in r.q)
    values = [x for t in twists for x in t]
    values += [x for v in inputs.values() for x in (v if isinstance(v, (tuple, list)) else (v,))]
    n = max(np.size(x) for x in values)
    res = solve_batch(code, _screw_rows(twists, n), **{k: _input(k, v, n) for k, v in inputs.items()})
    cont = res.continuum * DEFER
    return tuple(
        tuple(res.q[:, k, j] for j in range(res.q.shape[2])) + (np.where(res.valid[:, k], 0, EMPTY) | cont,)
        for k in range(res.q.shape[1])
    )


# ---------------------------------------------------------------------------------------------------
# the end of a generated fast path: measure, wrap, limit, deduplicate, pack

NEAR_MISS = tolerances.NEAR_MISS  # candidates missing by less need Newton steps


# target checks as the runtime and the C make them (subproblems/tolerances.py)
_TARGET_RIGID = tolerances.TARGET_RIGID
_TARGET_EXACT_ROTATION = tolerances.TARGET_EXACT_ROTATION


def goal_entries(T, target: str):
    """The 12 entries (rotation row-major, translation) of one clean target as floats, else None.

    None for anything unusual (wrong shape, NaN, not a rotation): the caller then goes the reference
    way, which raises the documented error.
    """
    try:
        a = T.tolist() if isinstance(T, np.ndarray) else [list(r) if hasattr(r, "__len__") else r for r in T]
        if target == "position":
            if len(a) != 3:
                return None
            g = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, float(a[0]), float(a[1]), float(a[2]))
        else:
            if len(a) != (3 if target == "orientation" else 4) or any(len(r) != len(a) for r in a):
                return None
            r0, r1, r2 = a[0], a[1], a[2]
            t = (0.0, 0.0, 0.0) if target == "orientation" else (r0[3], r1[3], r2[3])
            if target != "orientation" and [float(x) for x in a[3]] != [0.0, 0.0, 0.0, 1.0]:
                return None  # not a rigid transform (or one off by roundoff): the checked way
            g = tuple(map(float, (r0[0], r0[1], r0[2], r1[0], r1[1], r1[2], r2[0], r2[1], r2[2], *t)))
    except (TypeError, ValueError):
        return None
    if not all(map(math.isfinite, g)):
        return None
    if target != "position":  # orthonormal columns, right-handed
        x0, y0, z0, x1, y1, z1, x2, y2, z2 = g[:9]  # columns x, y, z
        det = (x1 * y2 - x2 * y1) * z0 + (x2 * y0 - x0 * y2) * z1 + (x0 * y1 - x1 * y0) * z2
        if (
            abs(x0 * x0 + x1 * x1 + x2 * x2 - 1.0) > _TARGET_RIGID
            or abs(y0 * y0 + y1 * y1 + y2 * y2 - 1.0) > _TARGET_RIGID
            or abs(z0 * z0 + z1 * z1 + z2 * z2 - 1.0) > _TARGET_RIGID
            or abs(x0 * y0 + x1 * y1 + x2 * y2) > _TARGET_RIGID
            or abs(x0 * z0 + x1 * z1 + x2 * z2) > _TARGET_RIGID
            or abs(y0 * z0 + y1 * z1 + y2 * z2) > _TARGET_RIGID
            or abs(det - 1.0) > _TARGET_RIGID
        ):
            return None
        defect = (x0 * x0 + x1 * x1 + x2 * x2 - 1.0, y0 * y0 + y1 * y1 + y2 * y2 - 1.0,
                  z0 * z0 + z1 * z1 + z2 * z2 - 1.0, x0 * y0 + x1 * y1 + x2 * y2,
                  x0 * z0 + x1 * z1 + x2 * z2, y0 * z0 + y1 * z1 + y2 * z2)
        if max(map(abs, defect)) > _TARGET_EXACT_ROTATION:
            return None  # a rotation to 1e-6 only: the batch path projects it onto the nearest one
    return g


# The contract of a returned row (docs/finish.md): every value inside its joint's limits as returned; a
# revolute value as its representative in (-pi, pi] where that lies inside the limits, else the 2 pi alias
# inside them; a value within LIMIT_EPS outside a limit (a double root at a limit is only located to
# about sqrt(eps)) is clamped onto the limit, and one within PI_SNAP above -pi (roundoff of a root at pi)
# becomes pi; both change the row, so its error is measured again before it counts as exact.
LIMIT_EPS = tolerances.LIMIT_SLACK
PI_SNAP = tolerances.PI_SNAP
INSIDE, ADJUSTED, OUTSIDE, CLAMPED = 0, 1, 2, 3  # CLAMPED: only where the caller asks which were


def wrap_pi(x: float) -> float:
    """The representative of angle x in (-pi, pi]; within PI_SNAP above -pi it is pi.

    >>> wrap_pi(-math.pi), wrap_pi(3 * math.pi / 2) == -math.pi / 2, wrap_pi(-math.pi + 1e-15)
    (3.141592653589793, True, 3.141592653589793)
    """
    if not -math.pi < x <= math.pi:  # in range: wrap(x) is x (skipped for speed)
        x = wrap(x)
    return math.pi if x <= -math.pi + PI_SNAP else x


def represent_one(q, revolute, bounds, limits: bool, clamped=None):
    """Joint values q as returned, and their status: INSIDE, ADJUSTED (a value snapped or clamped:
    measure the row again) or OUTSIDE (no representative inside the limits).  Given a list
    ``clamped``, it marks the joints clamped onto a limit and a clamp is CLAMPED (the C finish's
    ``ikc_represent``, subproblems/settle.py: the other joints then need Newton steps).

    >>> represent_one([2.625], [True], [(-3.665, 1.152)], True)[0][0] == 2.625 - 2 * math.pi
    True
    """
    out, status = [], INSIDE
    two_pi = 2 * math.pi
    clamp_status = ADJUSTED if clamped is None else CLAMPED
    for j, (x, rev, (lo, hi)) in enumerate(zip(q, revolute, bounds)):
        if clamped is not None:
            clamped[j] = False
        if rev:
            if not -math.pi < x <= math.pi:
                x = wrap(x)
            if x <= -math.pi + PI_SNAP:
                if x != -math.pi and status == INSIDE:  # pi itself is an alias; a value beside it is moved
                    status = ADJUSTED
                x = math.pi
        if limits and not lo <= x <= hi:
            choices = (x, x - two_pi, x + two_pi) if rev else (x,)
            for c in choices:
                if lo <= c <= hi:
                    x = c
                    break
            else:
                for c in choices:
                    if lo - LIMIT_EPS <= c <= hi + LIMIT_EPS:
                        x, status = min(max(c, lo), hi), clamp_status
                        if clamped is not None:
                            clamped[j] = True
                        break
                else:
                    return out, OUTSIDE
        out.append(x)
    return out, status


def represent(Q, kinds, lower, upper, limits: bool, clamps: bool = False):
    """:func:`represent_one` vectorised over rows Q (..., dof): (values, adjusted, outside) arrays, and
    with ``clamps`` also the mask (..., dof) of the values clamped onto a limit.

    >>> Q, adj, out = represent(np.array([[-math.pi], [2.625], [1.5]]), "R", [-3.665], [1.152], True)
    >>> Q[:2, 0].round(3).tolist(), adj.tolist(), out.tolist()
    ([-3.142, -3.658], [False, False, False], [False, False, True])
    """
    Q = np.array(Q, dtype=float)
    adjusted = np.zeros(Q.shape[:-1], dtype=bool)
    outside = np.zeros(Q.shape[:-1], dtype=bool)
    clamped = np.zeros(Q.shape, dtype=bool)
    two_pi = 2 * math.pi
    for j, k in enumerate(kinds):
        x = Q[..., j]
        if k == "R":
            x = wrap_array(x)
            snap = x <= -math.pi + PI_SNAP
            adjusted |= snap & (x != -math.pi)
            x = np.where(snap, math.pi, x)
        if limits:
            lo, hi = float(lower[j]), float(upper[j])
            got = np.zeros(x.shape, dtype=bool)
            near = np.zeros(x.shape, dtype=bool)
            value, near_value = x.copy(), x.copy()
            choices = (x, x - two_pi, x + two_pi) if k == "R" else (x,)
            for c in choices[::-1]:  # the first that fits wins: assign in reverse order
                inside = (c >= lo) & (c <= hi)
                close = (c >= lo - LIMIT_EPS) & (c <= hi + LIMIT_EPS)
                value = np.where(inside, c, value)
                near_value = np.where(close, np.clip(c, lo, hi), near_value)
                got |= inside
                near |= close
            x = np.where(got, value, near_value)
            adjusted |= ~got & near
            outside |= ~got & ~near
            clamped[..., j] = ~got & near
        Q[..., j] = x
    return (Q, adjusted, outside, clamped) if clamps else (Q, adjusted, outside)


def angle_distance(d, revolute: bool):
    """|d| for a prismatic joint; modulo 2 pi (in [0, pi]) for a revolute one."""
    a = np.abs(d)
    return np.abs(np.remainder(a + math.pi, 2 * math.pi) - math.pi) if revolute else a


def finish_one(leaves, *, kinds, lower, upper, limits, scale, tol, slots):
    """Solutions of one target from the leaves of a fast chain, or None to take the reference path.

    Returns rows ``(inexact, error, q, continuum)`` sorted exact first, then by error; duplicates
    (equal modulo 2 pi) and, with ``limits``, rows outside the limits are left out; values as
    returned (:func:`represent_one`).  None when a leaf needs Newton steps (a tangent root, a near
    miss), a value was snapped or clamped (its error must be measured again), or the reference path
    (:data:`DEFER`).
    """
    exact_tol, near = tol * scale, NEAR_MISS * scale
    same = 1e-9 * (scale if scale > 1.0 else 1.0)  # exact duplicates
    two_pi = 2 * math.pi
    revolute = [k == "R" for k in kinds]
    bounds = list(zip(lower, upper))
    rows = []
    family_seen = False  # a self-motion leaf, inside the limits or not
    for leaf in leaves:
        err, flag = leaf[-2], leaf[-1]
        if flag & EMPTY:
            continue
        if flag & HAND_BACK or exact_tol < err < near or err != err:
            return None
        if flag & TANGENT_ROOT:
            same = SPLIT_ROOT  # two copies of one double root: merge them below
        family_seen = family_seen or bool(flag & FAMILY)
        q, status = represent_one(leaf[:-2], revolute, bounds, limits)
        if status == ADJUSTED:
            return None
        if status == INSIDE:
            rows.append((err > exact_tol, err, q, bool(flag & FAMILY)))
    if family_seen and not any(r[3] and not r[0] for r in rows):
        # a self-motion none of whose representatives is exact inside the limits: the reference path
        # completes them (its Newton steps move along the family)
        return None
    rows.sort(key=_row_order)
    kept = []
    for row in rows:
        q = row[2]
        for other in kept:
            for a, b, rev in zip(q, other[2], revolute):
                d = a - b if a > b else b - a
                if rev:
                    d = d % two_pi
                    d = two_pi - d if d > math.pi else d
                if d > same:
                    break  # differs in this joint
            else:
                break  # equal in every joint: a duplicate
        else:
            kept.append(row)
            if len(kept) == slots:
                break
    return kept


def _row_order(row):
    return row[0], row[1]


def goal_columns(goals, target: str):
    """The 12 goal entries of N targets (N, 4, 4) as arrays."""
    R = [goals[:, i, j] for i in range(3) for j in range(3)]
    t = [goals[:, i, 3] for i in range(3)]
    if target == "orientation":
        t = [np.zeros(len(goals))] * 3
    return tuple(R + t)


def leaf_arrays(leaves, N, dof):
    """The leaves of a fast chain run on arrays as ``Q (N, L, dof)``, ``error (N, L)``, ``flag (N, L)``."""
    L = len(leaves)
    Q = np.empty((N, L, dof))
    err = np.empty((N, L))
    flag = np.zeros((N, L), dtype=np.int64)
    for k, leaf in enumerate(leaves):
        for j in range(dof):
            Q[:, k, j] = leaf[j]
        err[:, k] = leaf[dof]
        flag[:, k] = leaf[dof + 1]
    return Q, err, flag


def usable(Q, flag):
    """Leaves that are candidates at all: finite joint values, a filled slot.  (N, L) mask."""
    return ~np.isnan(Q).any(axis=-1) & ((flag & EMPTY) == 0)


def _same_angle(d, revolute: bool, tol: float):
    """|d| within tol, modulo 2 pi for a revolute joint (values may be 2 pi aliases of each other)."""
    return angle_distance(d, revolute) <= tol


ROUTE_DONE, ROUTE_NEWTON, ROUTE_REFERENCE = 0, 1, 2


def finish_many(Q, err, flag, *, kinds, lower, upper, limits, scale, tol, slots):
    """Solutions of N targets from the leaf arrays of a fast chain (:func:`leaf_arrays`), vectorised.

    Returns ``(Q (N, slots, dof), valid, ls, residual, continuum)`` and ``route (N,)``: targets done
    here (:data:`ROUTE_DONE`), targets whose candidates need Newton steps before the final check (a
    near miss: :data:`ROUTE_NEWTON`) and targets for the reference path (:data:`ROUTE_REFERENCE`:
    degenerate geometry, or a self-motion whose representatives all miss, where the reference runtime
    tries its alternative chain and pulls a representative onto the family; measured cheaper than
    Newton steps on all the fast path's representatives, most of which belong to unreachable
    branches); the rows of the last two are left empty here.
    """
    N, L, dof = Q.shape
    Q = Q.copy()
    exact_tol = tol * scale
    inexact = err > exact_tol
    near = inexact & (err < NEAR_MISS * scale)
    empty = (flag & EMPTY) != 0
    near &= ~empty
    family = ((flag & FAMILY) != 0) & ~empty
    bad = (((flag & HAND_BACK) != 0) | np.isnan(err) | np.isnan(Q).any(axis=2) | (family & near)) & ~empty
    reference = bad.any(axis=1)
    route = np.where(reference, ROUTE_REFERENCE, ROUTE_DONE)
    route[(route == ROUTE_DONE) & near.any(axis=1)] = ROUTE_NEWTON
    split = ((flag & TANGENT_ROOT) != 0).any(axis=1)  # merge the two copies of a double root
    Q, adjusted, outside = represent(Q, kinds, lower, upper, limits)
    keep = ~empty & ~outside
    # a value snapped or clamped changes the row: the Newton route measures it again
    route[(route == ROUTE_DONE) & (adjusted & keep).any(axis=1)] = ROUTE_NEWTON
    # a self-motion none of whose representatives is exact inside the limits: the reference path
    route[family.any(axis=1) & ~(family & ~inexact & keep).any(axis=1)] = ROUTE_REFERENCE
    keep &= (route == ROUTE_DONE)[:, None]
    # order: exact first, then by error; rows not kept last
    key = np.where(keep, inexact * 1e300 + np.nan_to_num(err), np.inf)
    order = np.argsort(key, axis=1, kind="stable")
    Q = np.take_along_axis(Q, order[..., None], axis=1)
    err, keep, inexact, family = (np.take_along_axis(x, order, axis=1) for x in (err, keep, inexact, family))
    # duplicates: equal (modulo 2 pi) to an earlier kept row of the same target
    first, second = np.triu_indices(L, 1)
    same = keep[:, first].copy()
    dup_tol = np.where(split, SPLIT_ROOT, 1e-9 * max(1.0, scale))[:, None]
    for j, k in enumerate(kinds):
        same &= _same_angle(Q[:, first, j] - Q[:, second, j], k == "R", dup_tol)
    dup = np.zeros((N, L), dtype=bool)
    for k in range(len(second)):  # at most L (L - 1) / 2 pairs, L the chain's leaves
        dup[:, second[k]] |= same[:, k]
    keep &= ~dup
    rank = np.cumsum(keep, axis=1) - 1
    n_idx, c_idx = np.nonzero(keep & (rank < slots))
    r_idx = rank[n_idx, c_idx]
    Qo = np.zeros((N, slots, dof))
    valid = np.zeros((N, slots), dtype=bool)
    LS = np.zeros((N, slots), dtype=bool)
    RES = np.full((N, slots), np.inf)
    Qo[n_idx, r_idx] = Q[n_idx, c_idx]
    valid[n_idx, r_idx] = True
    LS[n_idx, r_idx] = inexact[n_idx, c_idx]
    RES[n_idx, r_idx] = err[n_idx, c_idx]
    CONT = np.zeros((N, slots), dtype=bool)
    CONT[n_idx, r_idx] = family[n_idx, c_idx]
    return (Qo, valid, LS, RES, CONT), route



def merge_split_roots(parts, kinds, tol: float = SPLIT_ROOT):
    """Merge solutions closer than ``tol`` (angles modulo 2 pi) within each target's packed slots.

    Roundoff splits a double root into two copies about sqrt(eps) apart that both pass the pose check;
    a few Newton steps converge only linearly there, so the copies stay apart by more than the exact
    duplicate tolerance.  The later copy (larger error: slots are sorted) is dropped, then the slots are
    packed again.
    """
    Q, valid, LS, RES, CONT = (np.array(x) for x in parts)
    N, S, dof = Q.shape
    for j in range(1, S):
        same = valid[:, :j] & valid[:, j:j + 1]
        for k, kind in enumerate(kinds):
            same &= _same_angle(Q[:, :j, k] - Q[:, j:j + 1, k], kind == "R", tol)
        valid[:, j] &= ~same.any(axis=1)
    order = np.argsort(~valid, axis=1, kind="stable")
    out = [np.take_along_axis(Q, order[..., None], axis=1)]
    out += [np.take_along_axis(x, order, axis=1) for x in (valid, LS, RES, CONT)]
    out[3] = np.where(out[1], out[3], np.inf)
    return tuple(out)
