"""The C kernels of ``subproblems/fast_kernels.h`` against ``fast.<kernel>(fast.SCALAR, ...)``.

The header is a port of :mod:`subproblems.fast` in the same order of operations, compiled by
:func:`subproblems.native.build` with the generated chains' flags; a shim exports one wrapper per kernel
(the kernels themselves are ``static``) and ctypes calls them.  Every kernel is checked on:

* the instances of ``test_fast_kernels`` (general position first, then its degenerate families:
  points on or near axes, normals along or across an axis or zero, meeting / parallel / antiparallel /
  nearly parallel / coincident axes, gimbal locks, special angles 0, +-pi/2, pi, reachable and
  unreachable right-hand sides), for the ten kernels it specifies;
* raw instances from this file for all fifteen (``slide1``, ``slide3``, ``turn_slide2``, ``slide2_turn``,
  ``point_rrr`` included): each vector argument drawn as a fresh one, a copy, a multiple or a near copy of an
  earlier one, zero, or on an earlier axis, so that coincidences of every pair of arguments come up;
* hand-built corner cases, and a bulk run of numpy-random instances.

Expected: identical flags; values equal to ``AGREE`` (angles modulo 2 pi, slides relative to
max(1, |value|)), zeros with the same sign, NaN exactly where Python gives NaN (NaN inputs included).
(Measured: every value bit-identical on ~26000 instances per kernel.)  Without a C compiler the file is
skipped.
"""

from __future__ import annotations

import ctypes
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from subproblems import fast, native
from subproblems.screw import rotation_exp
from tests.strategies import SPECIAL_ANGLES, angle_distance, joint_values, unit_vectors
from tests.subproblems.test_fast_kernels import SPECS, RngSource, _across, _corners, _unit, instances

EXAMPLES = settings().max_examples
AGREE = 1e-12

# name: (argument kinds, slots, value kinds).  Argument kinds: "u" a unit axis, "v" any 3-vector,
# "p" a point, "R" a rotation (9 entries, row-major), "s" a scalar (the last one of plane_r, plane_t,
# dist_r, point_rr_meet, point_rr_parallel and rot_rrr is ``rep``, the representative of a self-motion
# or lock; 0.0 where an instance leaves it out).  Value kinds: "R" an angle, "T" a slide.
KERNELS = {
    "plane_r": ("uppvss", 2, "R"),
    "plane_t": ("vpvss", 1, "T"),
    "dist_r": ("uppps" + "s", 2, "R"),
    "dist_t": ("upps", 2, "T"),
    "slide1": ("vp", 1, "T"),
    "slide3": ("vvvp", 1, "TTT"),
    "turn_slide2": ("upvvRp", 1, "RTT"),
    "slide2_turn": ("vvuppps", 2, "TTR"),
    "point_r": ("uppp", 1, "R"),
    "point_rr_meet": ("upuppps", 2, "RR"),
    "point_rr_parallel": ("upuppps", 2, "RR"),
    "rot_r": ("uR", 1, "R"),
    "rot_rr": ("uuR", 1, "RR"),
    "rot_rrr": ("uuuRs", 2, "RRR"),
    "point_rrr": ("upupuppp", 4, "RRR"),
}
# the Python argument names of the ten kernels test_fast_kernels specifies, for its instances
SPEC_BY_NAME = {s.name: s for s in SPECS}


def _shim_source() -> str:
    """One exported wrapper ``shim_<kernel>`` per kernel, with the kernel's own C signature."""
    out = []
    for name, (args, _, _) in KERNELS.items():
        params = [f"double a{i}" if k == "s" else f"const double *a{i}" for i, k in enumerate(args)]
        names = [f"a{i}" for i in range(len(args))]
        out.append(
            f"void shim_{name}({', '.join(params + ['double *q', 'int *f'])}) "
            f"{{ ikc_{name}({', '.join(names + ['q', 'f'])}); }}"
        )
    return "\n".join(out) + "\n"


_LIB: list = []


def _lib():
    if not _LIB:
        if native.compiler() is None:
            pytest.skip("no C compiler found (set CC, or install gcc)")
        path = native.build(_shim_source())
        assert path is not None, native.last_error
        lib = ctypes.CDLL(str(path))
        for name, (args, _, _) in KERNELS.items():
            fn = getattr(lib, f"shim_{name}")
            fn.restype = None
            fn.argtypes = [ctypes.c_double if k == "s" else ctypes.POINTER(ctypes.c_double) for k in args] + [
                ctypes.POINTER(ctypes.c_double),
                ctypes.POINTER(ctypes.c_int),
            ]
        _LIB.append(lib)
    return _LIB[0]


def call_c(name, args):
    """Slots of the C kernel: list of (values, flag)."""
    kinds, slots, outs = KERNELS[name]
    cargs = [ctypes.c_double(a) if k == "s" else (ctypes.c_double * len(a))(*a) for k, a in zip(kinds, args)]
    q = (ctypes.c_double * (slots * len(outs)))()
    f = (ctypes.c_int * slots)()
    getattr(_lib(), f"shim_{name}")(*cargs, q, f)
    n = len(outs)
    return [(tuple(q[k * n:(k + 1) * n]), f[k]) for k in range(slots)]


def call_py(name, args):
    """Slots of ``fast.<name>`` on the SCALAR backend, in the same form."""
    out = getattr(fast, name)(fast.SCALAR, *args)
    return [(tuple(float(x) for x in s[:-1]), int(s[-1])) for s in out]


def _plain(name, args):
    kinds = KERNELS[name][0]
    args = list(args) + [0.0] * (len(kinds) - len(args))  # rep left out: the chains' default
    return [float(a) if k == "s" else tuple(float(x) for x in np.asarray(a, dtype=float).ravel())
            for k, a in zip(kinds, args)]


def differences(name, args):
    """Compare both sides on one instance: the worst value difference (asserting flags and NaNs)."""
    args = _plain(name, args)
    py, c = call_py(name, args), call_c(name, args)
    worst = 0.0
    for k, ((pv, pf), (cv, cf)) in enumerate(zip(py, c)):
        assert pf == cf, (name, args, k, "flags", pf, cf, pv, cv)
        for kind, a, b in zip(KERNELS[name][2], pv, cv):
            if math.isnan(a) or math.isnan(b):
                assert math.isnan(a) and math.isnan(b), (name, args, k, a, b)
                continue
            if a == b:  # zeros with their sign (rot_rrr's 0.0 * t3, plane_t's 0.0 * th)
                assert math.copysign(1.0, a) == math.copysign(1.0, b), (name, args, k, a, b)
                continue
            diff = angle_distance(a, b) if kind == "R" else abs(a - b) / max(1.0, abs(a))
            assert diff <= AGREE, (name, args, k, a, b)
            worst = max(worst, diff)
    return worst


# ---------------------------------------------------------------------------------------------------
# raw instances: every argument fresh or tied to an earlier one


_coord = st.one_of(st.just(0.0), st.floats(-2.0, 2.0, allow_nan=False, allow_infinity=False))
_vec = st.tuples(_coord, _coord, _coord).map(np.array)
_tilt = st.sampled_from((1e-3, 1e-6, 1.5e-7, 1e-7, 5e-8, 1e-9, 1e-12, 1e-16))  # around NEAR too


@st.composite
def raw_instances(draw, name):
    kinds = KERNELS[name][0]
    units, vecs, args = [], [], []
    for k in kinds:
        if k == "u":
            ties = ("fresh", "same", "opposite", "across", "tilted")
            how = draw(st.sampled_from(ties) if units else st.just("fresh"))
            u = draw(unit_vectors())
            if how == "fresh":
                w = u
            else:
                w0 = draw(st.sampled_from(units))
                w = {
                    "same": w0,
                    "opposite": -w0,
                    "across": _across(w0, u),
                    "tilted": _unit(w0 + draw(_tilt) * _across(w0, u)),
                }.get(how, w0)
            units.append(w)
            args.append(w)
        elif k in "vp":
            how = draw(st.sampled_from(("fresh", "zero", "copy", "scaled", "on-axis", "near-axis", "sum")))
            if how == "fresh" or not vecs and how in ("copy", "scaled", "on-axis", "near-axis", "sum"):
                x = draw(_vec)
            elif how == "zero":
                x = np.zeros(3)
            elif how == "copy":
                x = draw(st.sampled_from(vecs)).copy()
            elif how == "scaled":
                x = draw(st.sampled_from(vecs)) * draw(st.sampled_from((-1.0, 2.0, 0.5, 1e-9)))
            elif how == "sum":  # coplanar with two earlier vectors (slide3)
                a, b = draw(st.sampled_from(vecs)), draw(st.sampled_from(vecs))
                x = draw(st.floats(-2.0, 2.0)) * a + draw(st.floats(-2.0, 2.0)) * b
            else:
                base = draw(st.sampled_from(vecs))
                w = draw(st.sampled_from(units)) if units else draw(unit_vectors())
                x = base + draw(st.floats(-2.0, 2.0)) * w
                if how == "near-axis":
                    x = x + draw(_tilt) * _across(w, draw(unit_vectors()))
            vecs.append(x)
            args.append(x)
        elif k == "R":
            how = draw(st.sampled_from(("product", "identity", "half-turn", "random")))
            if how == "identity":
                R = np.eye(3)
            elif how == "half-turn":
                R = rotation_exp(draw(st.sampled_from(units + [draw(unit_vectors())])), math.pi)
            elif how == "random":
                R = rotation_exp(draw(unit_vectors()), draw(st.floats(-math.pi, math.pi)))
            else:  # reachable from the axes drawn (special angles: gimbal locks in rot_rrr)
                th = draw(joint_values("R" * len(units)))
                R = np.eye(3)
                for w, t in zip(units, th):
                    R = R @ rotation_exp(w, t)
            args.append(R.ravel())
        else:
            args.append(draw(st.one_of(st.just(0.0), st.just(1.0), st.floats(-3.0, 3.0))))
    return args


# ---------------------------------------------------------------------------------------------------
# the tests


@pytest.fixture(scope="module", autouse=True)
def _built():
    _lib()


@pytest.mark.parametrize("name", sorted(SPEC_BY_NAME))
@given(data=st.data())
@settings(max_examples=max(5, EXAMPLES))
def test_spec_instances(name, data):
    spec = SPEC_BY_NAME[name]
    inst, _ = data.draw(instances(spec, reachable=None))
    differences(name, [inst[a] for a in spec.args])


@pytest.mark.parametrize("name", sorted(KERNELS))
@given(data=st.data())
@settings(max_examples=max(5, EXAMPLES))
def test_raw_instances(name, data):
    differences(name, data.draw(raw_instances(name)))


def _more_corners(name):
    z, (ex, ey, ez) = np.zeros(3), np.eye(3)
    R90 = rotation_exp(ez, math.pi / 2).ravel()
    if name == "slide1":
        return [
            [ex, np.array([1.0, 2.0, 3.0])],
            [-2.0 * ey, np.array([1.0, 2.0, 3.0])],  # not unit, antiparallel
            [ex, ey],  # across the slide: 0 (the chain's pose error measures the rest)
            [z, ex],  # a zero slide: defer
            [1e-8 * ez, ez],  # below NEAR: defer
            [1e-6 * ez, ez],  # above it
            [z, z],
        ]
    if name == "slide3":
        return [
            [ex, ey, ez, np.array([1.0, 2.0, 3.0])],
            [ex, ey, ex + ey, ex],  # coplanar
            [ex, ex, ez, ez],  # parallel
            [z, ey, ez, ey],  # a zero slide
            [z, z, z, z],
            [ex, -ey, 1e-9 * ez, ex],
            [-1e-101 * ex, 1e-100 * ey, 1e-100 * ez, ex],  # det -1e-301: the sign of the TINY guard
        ]
    if name == "turn_slide2":
        return [
            [ez, z, ex, ey, R90, np.array([1.0, 2.0, 3.0])],
            [ez, ex, ex, ex, np.eye(3).ravel(), ey],  # parallel slides
            [ez, ex, ex, -ex, R90, ey],  # antiparallel
            [ez, z, z, ey, R90, ex],  # a zero slide
            [ez, z, ex, ey, rotation_exp(ex, math.pi).ravel(), ex],  # not a turn about w
            [ex, ey, ey, ez, rotation_exp(ex, math.pi).ravel(), z],
        ]
    if name == "slide2_turn":
        return [
            [ex, ey, ez, z, ex, np.array([1.0, 2.0, 3.0]), 0.0],
            [ex, ex, ez, z, ex, ey, 0.0],  # parallel slides
            [ex, -ex, ez, z, ex, ey, 0.0],  # antiparallel
            [z, ey, ez, z, ex, ey, 0.0],  # a zero slide
            [ex, ey, ez, z, ez, ez, 0.5],  # the point on the axis: every t3 (a family)
            [ex, ey, ex, ey, ex, ey, 0.0],  # the axis in the slides' plane
            [ex, ey, ez, ex, ex, ez, 1.0],  # the point on the axis, off the plane: none
        ]
    if name == "point_rrr":  # (w1, r1, w2, r2, w3, r3, p, q)
        from tests.subproblems.test_fast_kernels import rrr_corners

        return [list(c) for c in rrr_corners()]
    spec = SPEC_BY_NAME[name]
    cases = [[inst[a] for a in spec.args] for inst in _corners(name)]
    if name == "rot_rrr":  # w2 1.2e-7 from w1 (t1_rep defers, t2 does not), R w3 along w1: a lock
        cases.append([ez, _unit(ez + 1.2e-7 * ex), ex, rotation_exp(-ey, math.pi / 2).ravel()])
    return cases


@pytest.mark.parametrize("name", sorted(KERNELS))
def test_corner_cases(name):
    for args in _more_corners(name):
        differences(name, args)


def _rng_args(name, rng):
    src = RngSource(rng)
    if name in SPEC_BY_NAME:
        spec = SPEC_BY_NAME[name]
        g = spec.geometry(src)
        th = src.joints(spec.kinds)
        inst = {**g, **(spec.rhs(g, th) if rng.random() < 0.5 else spec.arbitrary(src, g))}
        return [inst[a] for a in spec.args]
    if name == "slide1":
        return [rng.uniform(-2, 2, 3) for _ in range(2)]
    if name == "slide3":
        return [rng.uniform(-2, 2, 3) for _ in range(4)]
    if name == "slide2_turn":
        return [src.unit(), src.unit(), src.unit(), src.vec(), src.vec(), src.vec(), rng.uniform(-3, 3)]
    if name == "point_rrr":  # reachable (special angles among the joint values) or arbitrary
        from tests.subproblems.test_fast_kernels import rrr_instance

        return list(rrr_instance(rng, reachable=rng.random() < 0.7))
    w, r, v2, v3, t = src.unit(), src.vec(), src.vec(), src.vec(), src.vec()
    th = rng.choice([rng.uniform(-math.pi, math.pi), *SPECIAL_ANGLES])
    return [w, r, v2, v3, rotation_exp(w, th).ravel(), t]


@pytest.mark.parametrize("name", sorted(KERNELS))
def test_bulk(name):
    rng = np.random.default_rng(sum(map(ord, name)))
    worst = max(differences(name, _rng_args(name, rng)) for _ in range(300))
    assert worst <= AGREE


@pytest.mark.parametrize("name", sorted(KERNELS))
def test_nan_inputs(name):
    """A NaN in any argument entry: NaN semantics (clip1 keeps it, pos and comparisons drop it) match."""
    rng = np.random.default_rng(7)
    for _ in range(3):
        args = _plain(name, _rng_args(name, rng))
        for i, a in enumerate(args):
            for j in range(1 if isinstance(a, float) else len(a)):
                bad = list(args)
                bad[i] = math.nan if isinstance(a, float) else a[:j] + (math.nan,) + a[j + 1:]
                differences(name, bad)
