"""Joint trajectories (issue 13 item 3): point-to-point quintic and trapezoidal-velocity profiles, paths
through via points, and timing along a followed Cartesian path.  All joints are synchronised: they
start and stop together.

A trajectory is a piecewise polynomial in time (:class:`Trajectory`), so its peak velocity and
acceleration are found exactly (roots of the derivative polynomials), not by sampling; limits are
respected to within a relative 1e-9 margin that the timing adds on purpose.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ikcompiler.errors import MotionError

__all__ = ["Trajectory", "quintic", "trapezoid", "via_points", "time_path"]

MARGIN = 1.0 + 1e-9  # timings computed to meet a limit exactly are stretched by this much (roundoff)


@dataclasses.dataclass
class Trajectory:
    """q(t) = sum_p coeffs[i, p] (t - breaks[i])^p on segment i; ``knots[i]`` is q at ``breaks[i]``
    exactly (the evaluation returns it there, so the first and last samples are the start and goal)."""

    breaks: np.ndarray  # (S+1,) seconds, increasing, breaks[0] = 0
    coeffs: np.ndarray  # (S, 6, n)
    knots: np.ndarray  # (S+1, n)

    @property
    def duration(self) -> float:
        return float(self.breaks[-1])

    def _eval(self, t, order: int) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        i = np.clip(np.searchsorted(self.breaks, t, side="right") - 1, 0, len(self.coeffs) - 1)
        tau = (np.clip(t, 0.0, self.duration) - self.breaks[i])[:, None]
        c = self.coeffs[i]  # (M, 6, n)
        out = np.zeros((len(t), c.shape[2]))
        for p in range(5, order - 1, -1):  # Horner on the order-th derivative
            f = math.factorial(p) / math.factorial(p - order)
            out = out * tau + f * c[:, p, :]
        if order == 0:
            at = np.nonzero(np.isin(t, self.breaks))[0]
            out[at] = self.knots[np.searchsorted(self.breaks, t[at])]
        return out

    def position(self, t) -> np.ndarray:
        return self._eval(t, 0)

    def velocity(self, t) -> np.ndarray:
        return self._eval(t, 1)

    def acceleration(self, t) -> np.ndarray:
        return self._eval(t, 2)

    def sample(self, dt: float = 0.01):
        """(t, q, qd, qdd) every ``dt`` seconds; the last sample at the end exactly."""
        steps = max(1, math.ceil(self.duration / dt - 1e-9))
        t = np.linspace(0.0, self.duration, steps + 1)
        return t, self.position(t), self.velocity(t), self.acceleration(t)

    def peaks(self) -> tuple[np.ndarray, np.ndarray]:
        """Exact peak |velocity| and |acceleration| of each joint: (n,), (n,)."""
        n = self.coeffs.shape[2]
        vmax, amax = np.zeros(n), np.zeros(n)
        for i, c in enumerate(self.coeffs):
            T = self.breaks[i + 1] - self.breaks[i]
            for j in range(n):
                p = np.polynomial.Polynomial(c[:, j])
                for deriv, store in ((1, vmax), (2, amax)):
                    d = p.deriv(deriv)
                    inner = [r.real for r in d.deriv().roots() if abs(r.imag) < 1e-12 and 0 < r.real < T]
                    ts = [0.0, T] + inner
                    store[j] = max(store[j], float(np.max(np.abs(d(np.array(ts))))))
        return vmax, amax


def _limits(value, n: int, what: str):
    if value is None:
        return None
    v = np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()
    if np.any(~(v > 0)):
        raise MotionError(f"{what} must be > 0 (one value, or one per joint); got {value!r}")
    return v


def _ends(q0, q1):
    q0, q1 = np.asarray(q0, dtype=float).reshape(-1), np.asarray(q1, dtype=float).reshape(-1)
    if q0.shape != q1.shape or not (np.all(np.isfinite(q0)) and np.all(np.isfinite(q1))):
        raise MotionError(f"start and goal need the same number of finite joint values; got {q0}, {q1}")
    return q0, q1


def _quintic_coeffs(q0, q1, v0, v1, a0, a1, T):
    h = q1 - q0
    c = np.zeros((6, len(q0)))
    c[0], c[1], c[2] = q0, v0, a0 / 2
    c[3] = (20 * h - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T**2) / (2 * T**3)
    c[4] = (-30 * h + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T**2) / (2 * T**4)
    c[5] = (12 * h - 6 * (v1 + v0) * T + (a1 - a0) * T**2) / (2 * T**5)
    return c


QUINTIC_PEAK_V = 15 / 8  # peak of s' for s = 10 t^3 - 15 t^4 + 6 t^5 on [0, 1]
QUINTIC_PEAK_A = 10 / math.sqrt(3)  # peak of |s''|


def quintic(q0, q1, duration: float | None = None, *, vmax=None, amax=None) -> Trajectory:
    """Point-to-point quintic: rest to rest (zero velocity and acceleration at both ends).

    Without ``duration`` the shortest one that keeps every joint within ``vmax`` / ``amax`` (scalars
    or per joint); with both, a :class:`MotionError` if the duration is too short for the limits.

    >>> tr = quintic([0.0, 0.0], [1.0, -2.0], 2.0)
    >>> tr.position([0.0, 1.0, 2.0]).tolist()
    [[0.0, 0.0], [0.5, -1.0], [1.0, -2.0]]
    >>> [round(float(x), 6) for x in tr.peaks()[0]]
    [0.9375, 1.875]
    """
    q0, q1 = _ends(q0, q1)
    n, h = len(q0), np.abs(q1 - q0)
    vm, am = _limits(vmax, n, "vmax"), _limits(amax, n, "amax")
    need = 0.0
    if vm is not None:
        need = max(need, float(np.max(QUINTIC_PEAK_V * h / vm)))
    if am is not None:
        need = max(need, float(np.max(np.sqrt(QUINTIC_PEAK_A * h / am))))
    need *= MARGIN
    if duration is None:
        if vm is None and am is None:
            raise MotionError("quintic needs a duration or velocity/acceleration limits")
        duration = need if need > 0 else 1.0
    elif duration < need:
        raise MotionError(f"a {duration} s quintic exceeds the velocity/acceleration limits; it needs at "
                          f"least {need:.6g} s")
    if not duration > 0:
        raise MotionError(f"duration must be > 0; got {duration}")
    z = np.zeros(n)
    c = _quintic_coeffs(q0, q1, z, z, z, z, float(duration))
    return Trajectory(np.array([0.0, float(duration)]), c[None], np.array([q0, q1]))


def _trapezoid_blend(h, T, vm, am):
    """The largest shared blend time ta in (0, T/2] meeting the limits, or None."""
    ta = T / 2
    if vm is not None:
        ta = min(ta, float(np.min(T - h / vm)))
    if ta <= 0:
        return None
    if am is not None and np.any(h / am > ta * (T - ta) * (1 + 1e-12)):
        return None
    return ta


def trapezoid(q0, q1, duration: float | None = None, *, vmax=None, amax=None, blend=None) -> Trajectory:
    """Point-to-point trapezoidal velocity (linear segment with parabolic blends), rest to rest, all
    joints sharing the blend time so that they accelerate, cruise and stop together.

    Without ``duration`` the shortest synchronised one within ``vmax`` and ``amax`` (both needed);
    with a duration and no limits the blend is a third of it (cruise at 1.5 times the mean speed), or
    ``blend`` seconds.

    >>> tr = trapezoid([0.0], [3.0], 3.0)
    >>> [round(float(x), 9) for x in tr.position([0.0, 1.0, 1.5, 3.0])[:, 0]]
    [0.0, 0.75, 1.5, 3.0]
    >>> [float(x[0]) for x in tr.peaks()]
    [1.5, 1.5]
    """
    q0, q1 = _ends(q0, q1)
    n, d = len(q0), q1 - q0
    h = np.abs(d)
    vm, am = _limits(vmax, n, "vmax"), _limits(amax, n, "amax")
    if duration is None:
        if vm is None or am is None:
            raise MotionError("a trapezoid without a duration needs both vmax and amax")
        # each joint's own shortest time is a lower bound; feasibility grows with T: bisect
        own = np.where(h >= vm**2 / am, h / vm + vm / am, 2 * np.sqrt(h / am))
        lo = float(np.max(own))
        if lo == 0:
            lo = 1e-9
        hi = lo
        while _trapezoid_blend(h, hi, vm, am) is None:
            hi *= 2
        for _ in range(80):
            mid = (lo + hi) / 2
            lo, hi = (lo, mid) if _trapezoid_blend(h, mid, vm, am) is not None else (mid, hi)
        duration = hi * MARGIN
    T = float(duration)
    if not T > 0:
        raise MotionError(f"duration must be > 0; got {duration}")
    if blend is not None:
        ta = float(blend)
        if not 0 < ta <= T / 2:
            raise MotionError(f"blend must be in (0, duration / 2]; got {blend}")
    else:
        ta = T / 3
        if vm is not None or am is not None:
            ok = _trapezoid_blend(h, T, vm, am)
            if ok is None:
                raise MotionError(f"a {T} s trapezoid cannot meet the velocity/acceleration limits; "
                                  "leave the duration out for the shortest one")
            if (vm is not None and np.any(h / (T - ta) > vm)) or (am is not None and np.any(
                    h / ((T - ta) * ta) > am)):
                ta = ok
    v = d / (T - ta)
    a = v / ta
    c = np.zeros((3, 6, n))
    c[0, 0], c[0, 2] = q0, a / 2
    qa = q0 + a * ta**2 / 2
    c[1, 0], c[1, 1] = qa, v
    qb = qa + v * (T - 2 * ta)
    c[2, 0], c[2, 1], c[2, 2] = qb, v, -a / 2
    breaks = np.array([0.0, ta, T - ta, T])
    if T - 2 * ta <= 0:  # a triangle: drop the empty cruise
        c, breaks = c[[0, 2]], np.array([0.0, ta, T])
        return Trajectory(breaks, c, np.array([q0, qa, q1]))
    return Trajectory(breaks, c, np.array([q0, qa, qb, q1]))


def _concat(parts) -> Trajectory:
    breaks, coeffs, knots, t0 = [0.0], [], [parts[0].knots[0]], 0.0
    for p in parts:
        breaks.extend(t0 + p.breaks[1:])
        coeffs.append(p.coeffs)
        knots.extend(p.knots[1:])
        t0 += p.duration
    return Trajectory(np.array(breaks), np.concatenate(coeffs), np.array(knots))


def _via_velocities(Q, dts):
    """Velocities at the knots: 0 at the ends and where a joint turns back, else the mean slope."""
    slope = np.diff(Q, axis=0) / dts[:, None]
    V = np.zeros_like(Q)
    inner = (slope[:-1] + slope[1:]) / 2
    V[1:-1] = np.where(slope[:-1] * slope[1:] > 0, inner, 0.0)
    return V


def _quintic_through(Q, dts) -> Trajectory:
    V = _via_velocities(Q, dts)
    z = np.zeros(Q.shape[1])
    coeffs = np.array([_quintic_coeffs(Q[i], Q[i + 1], V[i], V[i + 1], z, z, dts[i])
                       for i in range(len(dts))])
    return Trajectory(np.concatenate([[0.0], np.cumsum(dts)]), coeffs, Q.copy())


def _rescale(tr: Trajectory, vm, am) -> Trajectory:
    """The same motion slowed or sped up uniformly so that the binding limit is just met."""
    pv, pa = tr.peaks()
    c = 0.0
    if vm is not None:
        c = max(c, float(np.max(pv / vm)))
    if am is not None:
        c = max(c, math.sqrt(float(np.max(pa / am))))
    if c == 0:
        return tr
    c *= MARGIN
    scale = c ** -np.arange(6)  # q(t / c): the p-th coefficient over c^p
    return Trajectory(tr.breaks * c, tr.coeffs * scale[None, :, None], tr.knots)


def via_points(Q, times=None, *, profile: str = "quintic", vmax=None, amax=None) -> Trajectory:
    """Through the rows of ``Q`` (m, n), at rest at the first and last.

    ``quintic``: one quintic per segment, velocities at the via points the mean of the neighbouring
    slopes (0 where a joint turns back), acceleration 0 there: continuous velocity and acceleration.
    ``times`` (m,) fixes when each row is reached; without it the segments are timed by their largest
    joint motion and the whole is scaled so that the binding limit of ``vmax`` / ``amax`` is just met.
    ``trapezoid``: a synchronised trapezoid per segment, stopping at each via point.
    """
    Q = np.asarray(Q, dtype=float)
    if Q.ndim != 2 or len(Q) < 2 or not np.all(np.isfinite(Q)):
        raise MotionError(f"via points must be (m, n) finite values with m >= 2; got shape {Q.shape}")
    n = Q.shape[1]
    vm, am = _limits(vmax, n, "vmax"), _limits(amax, n, "amax")
    if profile == "trapezoid":
        if times is not None:
            dts = np.diff(np.asarray(times, dtype=float))
            return _concat([trapezoid(Q[i], Q[i + 1], dts[i], vmax=vm, amax=am) for i in range(len(dts))])
        return _concat([trapezoid(Q[i], Q[i + 1], vmax=vm, amax=am) for i in range(len(Q) - 1)])
    if profile != "quintic":
        raise MotionError(f"profile must be quintic or trapezoid; got {profile!r}")
    if times is not None:
        times = np.asarray(times, dtype=float).reshape(-1)
        if times.shape != (len(Q),) or np.any(np.diff(times) <= 0):
            raise MotionError(f"times must be {len(Q)} increasing values; got {times}")
        tr = _quintic_through(Q, np.diff(times))
        pv, pa = tr.peaks()
        if (vm is not None and np.any(pv > vm)) or (am is not None and np.any(pa > am)):
            raise MotionError("the given times exceed the velocity/acceleration limits; leave them out to "
                              "have the path timed to the limits")
        return Trajectory(tr.breaks + times[0], tr.coeffs, tr.knots) if times[0] else tr
    if vm is None and am is None:
        raise MotionError("via points need times or velocity/acceleration limits")
    step = np.abs(np.diff(Q, axis=0))
    base = vm if vm is not None else np.sqrt(am)
    dts = np.max(step / base, axis=1)
    dts = np.maximum(dts, 1e-9 * max(float(dts.max()), 1e-9))  # a repeated row still takes a moment
    return _rescale(_quintic_through(Q, dts), vm, am)


def time_path(Q, *, vmax, amax) -> Trajectory:
    """Time a joint path (the rows of a followed Cartesian path, ``Path.q``) within the limits.

    The rows are spaced along a trapezoidal speed profile of the path parameter (each segment's length
    the time its slowest joint needs at full speed; the parameter accelerates at most at
    min(amax / vmax)), joined by the C2 cubic spline through every row at those times (at rest at both
    ends), then scaled uniformly so the binding limit is just met: continuous velocity and acceleration,
    every row passed exactly.
    """
    Q = np.asarray(getattr(Q, "q", Q), dtype=float)
    n = Q.shape[1]
    vm, am = _limits(vmax, n, "vmax"), _limits(amax, n, "amax")
    if vm is None or am is None:
        raise MotionError("time_path needs both vmax and amax")
    ell = np.max(np.abs(np.diff(Q, axis=0)) / vm, axis=1)
    lam = np.concatenate([[0.0], np.cumsum(ell)])
    total = float(lam[-1])
    if total == 0:
        raise MotionError("the path does not move")
    alpha = float(np.min(am / vm))
    if total >= 1 / alpha:  # accelerate to speed 1, cruise, stop
        ta, T = 1 / alpha, total + 1 / alpha

        def when(x):
            if x <= 0.5 / alpha:
                return math.sqrt(2 * x / alpha)
            if x <= total - 0.5 / alpha:
                return ta + (x - 0.5 / alpha)
            return T - math.sqrt(max(0.0, 2 * (total - x) / alpha))
    else:  # a triangle
        T = 2 * math.sqrt(total / alpha)

        def when(x):
            if x <= total / 2:
                return math.sqrt(2 * x / alpha)
            return T - math.sqrt(max(0.0, 2 * (total - x) / alpha))
    t = np.array([when(x) for x in lam])
    dts = np.maximum(np.diff(t), 1e-9 * T)
    return _rescale(_clamped_spline(Q, dts), vm, am)


def _clamped_spline(Q, dts) -> Trajectory:
    """The C2 cubic spline through the rows of Q at the knot spacing dts, at rest at both ends.

    Unknowns: the knot accelerations M (m, n); continuity of velocity at the inner knots and zero
    velocity at the ends give a tridiagonal system, solved by the Thomas algorithm (all joints at once).
    """
    m = len(Q)
    h = dts
    slope = np.diff(Q, axis=0) / h[:, None]
    sub, diag, sup = np.zeros(m), np.zeros(m), np.zeros(m)
    rhs = np.zeros_like(Q)
    diag[0], sup[0], rhs[0] = 2 * h[0], h[0], 6 * slope[0]
    diag[-1], sub[-1], rhs[-1] = 2 * h[-1], h[-1], -6 * slope[-1]
    sub[1:-1], diag[1:-1], sup[1:-1] = h[:-1], 2 * (h[:-1] + h[1:]), h[1:]
    rhs[1:-1] = 6 * (slope[1:] - slope[:-1])
    for i in range(1, m):  # forward elimination
        w = sub[i] / diag[i - 1]
        diag[i] -= w * sup[i - 1]
        rhs[i] -= w * rhs[i - 1]
    M = np.zeros_like(Q)
    M[-1] = rhs[-1] / diag[-1]
    for i in range(m - 2, -1, -1):
        M[i] = (rhs[i] - sup[i] * M[i + 1]) / diag[i]
    c = np.zeros((m - 1, 6, Q.shape[1]))
    c[:, 0] = Q[:-1]
    c[:, 1] = slope - h[:, None] * (2 * M[:-1] + M[1:]) / 6
    c[:, 2] = M[:-1] / 2
    c[:, 3] = (M[1:] - M[:-1]) / (6 * h[:, None])
    return Trajectory(np.concatenate([[0.0], np.cumsum(dts)]), c, Q.copy())
