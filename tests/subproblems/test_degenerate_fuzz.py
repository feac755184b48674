"""Fuzz every registered subproblem code with degenerate geometry (GitHub issue 3).

For every code of ``subproblems.codes()`` hypothesis draws small batches of instances whose geometry
comes from the degenerate families -- axes intersecting, parallel, anti-parallel, coincident,
perpendicular, nearly parallel or nearly intersecting (1e-6 .. 1e-10), relations to *any* earlier joint
(gimbal-lock shapes such as axis 3 lined up with axis 1), points at the origin or on an axis, equal
points, zero distances, zero plane normals, unreachable targets -- and joint values with the special
angles 0, +-pi/2, pi, plus general position, at three length scales (1e-3, 1, 1e3).

Each instance must satisfy the solver contract of docs/design.md section 4:

* ``solve`` and ``solve_batch`` never raise and never return NaN or infinity (``q``, ``residual``);
* there is at least one row (exact, least squares or a continuum representative) and at most
  ``max_solutions(code)``;
* every row flagged neither ``ls`` nor ``continuum`` satisfies the equation: its round-trip error is at
  most ``TOL`` times the size of the geometry (the largest point, offset, distance, translation or axis
  distance, floored at 1).

Budget: the active hypothesis profile's ``max_examples`` per code, ``BATCH`` instances per example
(``ci``: 40 x 5 = 200 instances per code; about half that for the
two-equation types, which cost ~10x more).  Class II solvers that fail are marked ``xfail`` here (their
owner fixes them); see ``KNOWN_FAILURES``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st

from subproblems import codes, max_solutions, solve, solve_batch
from subproblems.screw import prismatic_twist, revolute_twist, rotation_exp, twist_exp

#: Round-trip tolerance of an exact row, relative to the geometry's size (solvers promise 1e-9 of
#: their own problem scale, which is never larger than the size used here).
TOL = 1e-8
#: Instances per hypothesis example (one ``solve_batch`` call over all of them).
BATCH = 5
EXAMPLES = settings().max_examples
SPECIAL_ANGLES = (0.0, math.pi / 2, -math.pi / 2, math.pi)

#: Codes whose solver fails this fuzz test, with the reason (non-strict xfail; the class II solvers
#: are owned by another change and reported rather than fixed here).
KNOWN_FAILURES: dict[str, str] = {}


def kinds_of(code: str) -> str:
    return code.split("-", 1)[1]


# ---------------------------------------------------------------------------------------- strategies

_coord = st.floats(-2.0, 2.0, allow_nan=False, allow_infinity=False)
_simple = st.sampled_from([0.0, 1.0, -1.0, 0.5, 2.0])
_axes = [np.eye(3)[i] * s for i in range(3) for s in (1.0, -1.0)]


@st.composite
def vectors(draw) -> np.ndarray:
    if draw(st.integers(0, 3)) == 0:
        return np.array([draw(_simple) for _ in range(3)])
    return np.array([draw(_coord) for _ in range(3)])


@st.composite
def units(draw) -> np.ndarray:
    if draw(st.booleans()):
        return draw(st.sampled_from(_axes)).copy()
    v = draw(vectors())
    n = np.linalg.norm(v)
    return v / n if n > 0.2 else np.array([0.6, 0.0, 0.8])


def _perp(w, v) -> np.ndarray:
    u = v - (v @ w) * w
    if np.linalg.norm(u) < 1e-3:
        u = np.cross(w, [1.0, 0, 0]) if abs(w[0]) < 0.9 else np.cross(w, [0, 1.0, 0])
    return u / np.linalg.norm(u)


RELATIONS = (
    "general",
    "intersecting",
    "parallel",
    "coincident",
    "perpendicular",
    "perp-intersecting",
    "near-parallel",
    "near-intersecting",
)


@st.composite
def geometry(draw, kinds: str, s: float):
    """Twists (m, 6) at length scale ``s``; joint i relates to a drawn earlier joint j."""
    ws, rs, tw, rel = [], [], [], []
    for i, kind in enumerate(kinds):
        w = draw(units())
        r = s * draw(vectors()) if draw(st.integers(0, 3)) else np.zeros(3)
        if i:
            j = draw(st.integers(0, i - 1))
            how = draw(st.sampled_from(RELATIONS))
            rel.append(f"{j + 1}{how}{i + 1}")
            if how in ("parallel", "coincident", "near-parallel"):
                w = ws[j] * draw(st.sampled_from([1.0, -1.0]))
            if how in ("perpendicular", "perp-intersecting"):
                w = _perp(ws[j], w)
            if how in ("intersecting", "coincident", "perp-intersecting", "near-intersecting"):
                r = rs[j].copy()
            if how == "near-parallel":
                eps = 10.0 ** -draw(st.integers(6, 10))
                w = w + eps * _perp(w, draw(units()))
                w = w / np.linalg.norm(w)
            if how == "near-intersecting":
                r = r + s * 10.0 ** -draw(st.integers(6, 10)) * _perp(w, draw(units()))
        ws.append(w)
        rs.append(r)
        tw.append(revolute_twist(w, r) if kind == "R" else prismatic_twist(w))
    return np.array(tw), tuple(rel)


@st.composite
def joint_values(draw, kinds: str, s: float) -> np.ndarray:
    out = []
    for kind in kinds:
        if kind == "R":
            if draw(st.integers(0, 2)) == 0:
                out.append(draw(st.sampled_from(SPECIAL_ANGLES)))
            else:
                out.append(draw(st.floats(-math.pi, math.pi)))
        else:
            out.append(0.0 if draw(st.integers(0, 4)) == 0 else s * draw(st.floats(-2.0, 2.0)))
    return np.array(out)


@st.composite
def points(draw, tw, s: float) -> np.ndarray:
    """The origin, a point on a revolute axis (or its foot), or a general point."""
    kind = draw(st.integers(0, 5))
    revs = [xi for xi in tw if xi[3:].any()]
    if kind == 0:
        return np.zeros(3)
    if kind == 1 and revs:
        xi = draw(st.sampled_from(revs))
        return np.cross(xi[3:], xi[:3]) + s * draw(st.sampled_from([0.0, 1.0, -0.7])) * xi[3:]
    return s * draw(vectors())


@st.composite
def normals(draw, tw) -> np.ndarray:
    """A plane normal along a joint axis/direction, perpendicular to one, general, or zero."""
    kind = draw(st.integers(0, 5))
    xi = tw[draw(st.integers(0, len(tw) - 1))]
    ax = xi[3:] if xi[3:].any() else xi[:3]
    if kind == 0:
        h = ax.copy()
    elif kind == 1:
        h = _perp(ax, draw(units()))
    elif kind == 2 and draw(st.integers(0, 3)) == 0:
        h = np.zeros(3)
    else:
        h = draw(units())
    return h * draw(st.sampled_from([1.0, -1.0, 2.5]))


def fk(tw, th) -> np.ndarray:
    g = np.eye(4)
    for xi, a in zip(tw, th):
        g = g @ twist_exp(xi, a)
    return g


def _apply(g, p) -> np.ndarray:
    return g[:3, :3] @ p + g[:3, 3]


@st.composite
def rigid(draw, s: float) -> np.ndarray:
    g = np.eye(4)
    g[:3, :3] = rotation_exp(draw(units()), draw(st.floats(-math.pi, math.pi)))
    g[:3, 3] = s * draw(vectors())
    return g


@st.composite
def instance(draw, code: str):
    """(twists, inputs dict, note) for one instance of ``code``."""
    kinds = kinds_of(code)
    fam = code[:2]
    s = draw(st.sampled_from([1.0, 1.0, 1.0, 1e-3, 1e3]))
    tw, rel = draw(geometry(kinds, s))
    th = draw(joint_values(kinds, s))
    g = fk(tw, th)
    mode = draw(st.sampled_from(["reachable", "reachable", "reachable", "perturbed", "random", "zero"]))
    if fam in ("S1", "O-"):
        if mode == "perturbed":
            d = twist_exp(revolute_twist(draw(units()), s * draw(vectors())), draw(st.floats(1e-4, 0.3)))
            T = g @ d
        elif mode == "random":
            T = draw(rigid(s))
        elif mode == "zero":
            T = np.eye(4)
        else:
            T = g
        return tw, {"T": T}, (rel, th, mode)
    m = 2 if fam in ("S3", "H-") and len(kinds) == 2 else 1
    P = [draw(points(tw, s)) for _ in range(m)]
    if m == 2 and draw(st.integers(0, 3)) == 0:
        P[1] = P[0].copy()
    if fam == "S2":
        p = P[0]
        q = {"reachable": _apply(g, p), "perturbed": _apply(g, p) + s * 1e-3 * draw(units())}.get(mode)
        if q is None:
            q = p.copy() if mode == "zero" else draw(points(tw, s))
        return tw, {"p": p, "q": q}, (rel, th, mode)
    if fam == "S3":
        Q = [draw(points(tw, s)) for _ in range(m)]
        D = [float(np.linalg.norm(_apply(g, P[k]) - Q[k])) for k in range(m)]
        for k in range(m):
            if mode == "perturbed":
                D[k] += s * 1e-3
            elif mode == "random":
                D[k] = s * draw(st.floats(0.0, 5.0))
            elif mode == "zero":
                Q[k] = _apply(g, P[k]) if draw(st.booleans()) else Q[k]
                D[k] = 0.0 if draw(st.booleans()) else D[k]
        if m == 1:
            return tw, {"p": P[0], "q": Q[0], "d": D[0]}, (rel, th, mode)
        return tw, {"p": np.array(P), "q": np.array(Q), "d": np.array(D)}, (rel, th, mode)
    H = [draw(normals(tw)) for _ in range(m)]
    D = [float(H[k] @ _apply(g, P[k])) for k in range(m)]
    for k in range(m):
        if mode == "perturbed":
            D[k] += s * 1e-3
        elif mode == "random":
            D[k] = s * draw(st.floats(-5.0, 5.0))
        elif mode == "zero":
            D[k] = 0.0
    if m == 1:
        return tw, {"p": P[0], "h": H[0], "d": D[0]}, (rel, th, mode)
    return tw, {"p": np.array(P), "h": np.array(H), "d": np.array(D)}, (rel, th, mode)


# ------------------------------------------------------------------------------------------- checks


def size_of(tw, inputs) -> float:
    """Largest length in the instance, floored at 1."""
    vals = [1.0]
    for name, v in inputs.items():
        v = np.asarray(v, dtype=float)
        if name == "T":
            vals.append(float(np.linalg.norm(v[:3, 3])))
        elif name != "h":
            vals.append(float(np.abs(v).max()) * math.sqrt(3.0))
    for xi in tw:
        vals.append(float(np.linalg.norm(np.cross(xi[3:], xi[:3]))))
    return max(vals)


def roundtrip_error(code, tw, qrow, inputs) -> float:
    """How far ``qrow`` misses the equation of ``code``, in units of length (radians for O-*)."""
    g = fk(tw, qrow)
    fam = code[:2]
    if fam == "O-":
        R = np.eye(3)
        for xi, a in zip(tw, qrow):
            R = R @ rotation_exp(xi[3:], a)
        return float(np.abs(R - inputs["T"][:3, :3]).max())
    if fam == "S1":
        T = inputs["T"]
        sT = max(1.0, float(np.linalg.norm(T[:3, 3])))
        return float(max(np.linalg.norm(g[:3, 3] - T[:3, 3]), sT * np.abs(g[:3, :3] - T[:3, :3]).max()))
    if fam == "S2":
        return float(np.linalg.norm(_apply(g, inputs["p"]) - inputs["q"]))
    P = np.atleast_2d(inputs["p"])
    D = np.atleast_1d(inputs["d"])
    errs = []
    for k in range(len(D)):
        x = _apply(g, P[k])
        if fam == "S3":
            errs.append(abs(float(np.linalg.norm(x - np.atleast_2d(inputs["q"])[k])) - D[k]))
        else:
            h = np.atleast_2d(inputs["h"])[k]
            hn = float(np.linalg.norm(h))
            errs.append(abs(D[k]) if hn == 0 else abs(float(h @ x) - D[k]) / hn)
    return max(errs)


def check_rows(code, tw, inputs, Q, ls, continuum, where) -> None:
    size = size_of(tw, inputs)
    assert len(Q) >= 1, f"{code} {where}: no row at all"
    assert len(Q) <= max_solutions(code), f"{code} {where}: {len(Q)} rows"
    assert np.all(np.isfinite(Q)), f"{code} {where}: non-finite q {Q}"
    if continuum:
        return
    for row, flag in zip(Q, ls):
        if not flag:
            err = roundtrip_error(code, tw, row, inputs)
            assert err <= TOL * size, f"{code} {where}: exact row {row} misses by {err:.3g} (size {size:.3g})"


def _params():
    out = []
    for code in codes():
        reason = KNOWN_FAILURES.get(code)
        marks = [pytest.mark.xfail(strict=False, reason=reason)] if reason else []
        out.append(pytest.param(code, marks=marks, id=code))
    return out


def _examples(code: str) -> int:
    # the two-equation types (S3-XY, H-XY) cost ~10x the others: half the examples
    return max(5, EXAMPLES // 2) if code[:2] in ("S3", "H-") and len(kinds_of(code)) == 2 else EXAMPLES


@pytest.mark.parametrize("code", _params())
@settings(max_examples=EXAMPLES, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_never_raises_never_nan_exact_rows_hold(code, data):
    if data.draw(st.integers(0, EXAMPLES - 1), label="budget") >= _examples(code):
        return  # this code's share of the profile's examples is used up
    insts = [data.draw(instance(code), label=f"instance {i}") for i in range(BATCH)]
    for i, (tw, inputs, info) in enumerate(insts):
        note(f"instance {i}: relations/th/mode={info}")
        r = solve(code, tw, **inputs)
        assert np.all(np.isfinite(r.residual)), f"{code} scalar {i}: non-finite residual {r.residual}"
        check_rows(code, tw, inputs, r.q, r.ls, r.continuum, f"scalar {i}")
    tws = np.array([t for t, _, _ in insts])
    arrays = {k: np.array([inp[k] for _, inp, _ in insts]) for k in insts[0][1]}
    b = solve_batch(code, tws, **arrays)
    K = max_solutions(code)
    assert b.q.shape == (BATCH, K, len(kinds_of(code))) and b.valid.shape == (BATCH, K)
    assert np.all(np.isfinite(b.q)), f"{code} batch: non-finite q"
    for i, (tw, inputs, _) in enumerate(insts):
        v = b.valid[i]
        check_rows(code, tw, inputs, b.q[i][v], b.ls[i][v], bool(b.continuum[i]), f"batch {i}")


def test_s2_ttr_huge_rows_from_nearly_parallel_directions_are_not_exact():
    """Regression (thorough profile): prismatic directions 1e-9 apart put the second root of the plane
    condition at translations ~1e9; such a row cannot be evaluated to the tolerance (its roundoff is
    ~1e9 eps), yet it was flagged exact and missed by ~1e-8.  Every exact row must hold."""
    v1 = np.array([1.0, 1.0, 2.0]) / math.sqrt(6.0)
    v2 = v1 + np.array([0.0, 1e-9, 0.0])
    tw = np.array(
        [prismatic_twist(v1), prismatic_twist(v2 / np.linalg.norm(v2)), revolute_twist([1, 0, 0], [0, 0, 0])]
    )
    inputs = {"p": np.array([0.0, 0.0, 0.5]), "q": np.zeros(3)}
    r = solve("S2-TTR", tw, **inputs)
    check_rows("S2-TTR", tw, inputs, r.q, r.ls, r.continuum, "scalar")
    b = solve_batch("S2-TTR", tw[None], p=inputs["p"][None], q=inputs["q"][None])
    v = b.valid[0]
    check_rows("S2-TTR", tw, inputs, b.q[0][v], b.ls[0][v], bool(b.continuum[0]), "batch")
