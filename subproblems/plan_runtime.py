"""Executes a subproblem chain (a *plan*) over many target poses at once.

This is the small runtime that generated solver modules and the compiler's own checks share.  A plan is
a list of steps (plain dicts, written out literally in each generated module).  Each step reads the
joints solved so far, rewrites the POE equation with the rules of docs/design.md section 3, calls one
canonical subproblem through :func:`subproblems.solve_batch`, and branches on its solutions.

Equation bookkeeping (rules 5 and 7): with the solved joints known, every factor of
``exp(xi_1 th_1) ... exp(xi_n th_n) = Td`` that belongs to a solved joint is moved to the right with the
adjoint, ``K exp(xi th) = exp((Ad_K xi) th) K``, which leaves

    prod_{u unsolved} exp(xi'_u th_u) = T' = Td K_all^-1,   xi'_u = Ad_{K_u} xi_u

where ``K_u`` is the product of the solved factors before joint u.  An inverted step uses the same
equation inverted (rule 5): ``prod_reversed exp(-xi'_u th_u) = T'^-1``.

Step kinds (``step["kind"]``):

* ``"S1"``: class I on all unsolved joints.
* ``"O"``: orientation separation (rule 2): revolute unknowns grouped in runs of parallel axes; the
  group sums ``sum_i s_i th_i`` are solved with an ``O-*`` rotation subproblem.
* ``"OH"``: orientation plus axial projection (rules 2 and 6): ``h^T R_mid x = h^T R' x`` where ``h`` is
  the axis of a leading parallel group and ``x`` the axis of a trailing parallel group.
* ``"S2"``: rule 1: the point ``p`` common to the trailing ``trail`` axes is fixed by them, leaving
  ``prod_rest exp(xi' th) p = T' p``.
* ``"S3"``: rules 1 and 3: also a point ``c`` common to the leading ``lead`` axes: distance
  ``|| prod_mid exp(xi' th) p - c || = || T' p - c ||``.
* ``"HL"``: rules 1 and 6: the leading ``lead`` axes are parallel to ``h``:
  ``h^T prod_mid exp(xi' th) p = h^T T' p``.
* ``"HT"``: rules 1 and 6 on the other side: the trailing group ``lead`` before ``trail`` is parallel
  to ``h``: ``h^T exp(-xi'_a th_a) T' p = h^T p`` for the single leading unknown ``a``.
* ``"SUM"``: a joint from a known group sum.
"""

from __future__ import annotations

import math

import numpy as np

from subproblems import newton as _newton
from subproblems._class2 import independent_paths
from subproblems.angles import wrap_joints
from subproblems.core import solve_batch
from subproblems.fast import angle_distance, represent
from subproblems.screw import cross as _cross
from subproblems.screw import fk_batch, inverse_transform, twist_exp_batch
from subproblems.tolerances import DUPLICATE_ROWS

__all__ = ["run_plan", "finish", "fk_batch", "target_error", "InvalidTargetError", "InvalidFreeValueError"]


class InvalidTargetError(ValueError):
    """A target a generated module cannot take: not finite, not a rigid transform, or the wrong shape.

    The generated modules import only numpy and ``subproblems``, so their errors derive from these
    (``module.InvalidTargetError`` is a subclass); catch ``ValueError`` to catch both kinds.
    """


class InvalidFreeValueError(ValueError):
    """Free joint values that are NaN or infinite, or not one per free joint."""


def _adjoint_apply(G, xi) -> np.ndarray:
    """``Ad_G xi`` for G (M, 4, 4) and one twist xi (6,); returns (M, 6)."""
    R, p = G[:, :3, :3], G[:, :3, 3]
    w = R @ xi[3:]
    v = R @ xi[:3] + _cross(p, w)
    return np.concatenate([v, w], axis=1)


def _line_point(G, p0) -> np.ndarray:
    return np.einsum("mij,j->mi", G[:, :3, :3], np.asarray(p0, dtype=float)) + G[:, :3, 3]


def _apply(T, p) -> np.ndarray:
    return np.einsum("mij,mj->mi", T[:, :3, :3], p) + T[:, :3, 3]


def _equation(step, twists, kinds, Td, TH):
    """Transformed unsolved twists {u: (M, 6)}, the K_u transforms and T' for the step's solved set."""
    M = TH.shape[0]
    solved = set(step["known"])
    G = np.broadcast_to(np.eye(4), (M, 4, 4)).copy()
    xi_t, K = {}, {}
    for i in range(len(kinds)):
        if i in solved:
            G = G @ twist_exp_batch(twists[i], TH[:, i])
        else:
            xi_t[i] = _adjoint_apply(G, twists[i])
            K[i] = G.copy()
    Tp = Td @ inverse_transform(G)
    return xi_t, K, Tp, G


def _step_inputs(step, twists, kinds, Td, TH, SIG):
    """Subproblem inputs (twists, keyword inputs) of one step, for every instance."""
    kind = step["kind"]
    xi_t, K, Tp, G_all = _equation(step, twists, kinds, Td, TH)
    sign = -1.0 if step.get("inverted") else 1.0
    if step.get("inverted"):
        Tp = inverse_transform(Tp)

    def tw(j):
        return sign * xi_t[j]

    if kind == "S1":
        return np.stack([tw(j) for j in step["solve"]], axis=1), {"T": Tp}
    if kind == "O":
        cols = []
        for group in step["groups"]:
            first = group[0][0]
            w = xi_t[first][:, 3:] * sign
            cols.append(np.concatenate([np.zeros_like(w), w], axis=1))
        T = Tp.copy()
        T[:, :3, 3] = 0.0
        return np.stack(cols, axis=1), {"T": T}
    if kind == "OH":
        h = xi_t[step["lead"][0]][:, 3:]
        x = xi_t[step["trail"][0]][:, 3:]
        w = xi_t[step["solve"][0]][:, 3:]
        if step.get("inverted"):
            h, x = x, h
        twist = np.concatenate([np.zeros_like(w), sign * w], axis=1)[:, None, :]
        Rx = np.einsum("mij,mj->mi", Tp[:, :3, :3], x)
        return twist, {"p": x, "h": h, "d": np.sum(h * Rx, axis=1)}
    # Point-based kinds: p is fixed by the trailing axes (K_u carries the home point p0 with them);
    # with no trailing axes p is the tool point carried by every solved joint (position targets).
    p = _line_point(K[step["trail"][0]] if step["trail"] else G_all, step["p0"])
    Tp_p = _apply(Tp, p)
    solve_tw = np.stack([tw(j) for j in step["solve"]], axis=1)
    if kind == "S2":
        return solve_tw, {"p": p, "q": Tp_p}
    if kind == "S3":
        c = _line_point(K[step["lead"][0]], step["c0"])
        d = np.linalg.norm(Tp_p - c, axis=1)
        return solve_tw, {"p": p, "q": c, "d": d}
    if kind == "HL":
        h = xi_t[step["lead"][0]][:, 3:]
        return solve_tw, {"p": p, "h": h, "d": np.sum(h * Tp_p, axis=1)}
    if kind == "HT":
        h = xi_t[step["lead"][0]][:, 3:]
        # h^T exp(xi'_a th)^-1 T'p = h^T p: rotate T'p by the inverse joint motion onto the plane.
        return -solve_tw, {"p": Tp_p, "h": h, "d": np.sum(h * p, axis=1)}
    raise ValueError(f"unknown step kind {kind!r}")


COUPLED_ROOT_SLOTS = 8  # a coupled pair (th_k = a th_j + b, |a| <= 3) gives at most 8 roots here


def _solve_coupled_distance(step, twists, kinds, Td, TH):
    """Rule 3 with a coupled pair in the middle: ``|| E_j(th) E_k(a th + b) p - c || = d``.

    One unknown angle through two exponentials (the Shadow finger's th_4 = th_3): the squared distance
    is a trigonometric polynomial in th, whose roots are found on the circle by
    :func:`subproblems.roots.find_roots_batch` (sign changes refined to machine precision, double roots
    polished).  Returns a BatchResult whose single column is the variable joint's angle.
    """
    from subproblems.core import BatchResult
    from subproblems.roots import find_roots_batch

    xi_t, K, Tp, G_all = _equation(step, twists, kinds, Td, TH)
    sign = -1.0 if step.get("inverted") else 1.0
    if step.get("inverted"):
        Tp = inverse_transform(Tp)
    p = _line_point(K[step["trail"][0]] if step["trail"] else G_all, step["p0"])
    c = _line_point(K[step["lead"][0]], step["c0"])
    d2 = np.sum((_apply(Tp, p) - c) ** 2, axis=1)
    first, second = step["solve_pair"]
    var, (a, b) = step["var"], step["coupling"]
    x1, x2 = sign * xi_t[first], sign * xi_t[second]
    M = p.shape[0]

    def f(X):
        G = X.shape[1]
        th = X.ravel()
        th1 = th if first == var else a * th + b
        th2 = th if second == var else a * th + b
        E = twist_exp_batch(np.repeat(x1, G, axis=0), th1) @ twist_exp_batch(np.repeat(x2, G, axis=0), th2)
        x = np.einsum("mij,mj->mi", E[:, :3, :3], np.repeat(p, G, axis=0)) + E[:, :3, 3]
        return (np.sum((x - np.repeat(c, G, axis=0)) ** 2, axis=1) - np.repeat(d2, G)).reshape(M, G)

    X, valid = find_roots_batch(f, -math.pi, math.pi, M, grid=96, periodic=True)
    K_ = COUPLED_ROOT_SLOTS
    Q = np.zeros((M, K_, 1))
    V = np.zeros((M, K_), dtype=bool)
    k = min(K_, X.shape[1])
    Q[:, :k, 0], V[:, :k] = X[:, :k], valid[:, :k]
    return BatchResult(step["code"], Q, V, np.zeros((M, K_), dtype=bool), np.zeros(M, dtype=bool))


def solve_step(step, twists, kinds, Td, TH, SIG=None):
    """The subproblem of one step for every instance, as a BatchResult."""
    if step["kind"] == "S3C":
        return _solve_coupled_distance(step, twists, kinds, Td, TH)
    tw, inputs = _step_inputs(step, twists, kinds, Td, TH, SIG)
    # the runtime polishes and checks every candidate on the whole robot itself: the class II
    # solvers' agreement of scalar and batch least-squares points is not needed here, and costs ~30x
    with independent_paths():
        return solve_batch(step["code"], tw, **inputs)


def _apply_couplings(TH, couplings) -> None:
    for dep, master, a, b in couplings:
        known_m, known_d = ~np.isnan(TH[:, master]), ~np.isnan(TH[:, dep])
        fill = known_m & ~known_d
        TH[fill, dep] = a * TH[fill, master] + b
        back = known_d & ~known_m
        TH[back, master] = (TH[back, dep] - b) / a


def run_plan(steps, twists, kinds, Td, couplings=(), n_groups=0, init=None):
    """Run every step over N targets ``Td`` (N, 4, 4) (already right-multiplied by ``g_st(0)^-1``).

    ``init`` (N, n) holds the values of free joints (NaN for the others).

    Returns ``(TH, owner, ls, branch, cont)``: candidate joint vectors (M, n) of all joints, the target
    each belongs to (M,), whether any step along the branch used a least-squares answer (M,), the branch
    id (the solution slots taken at each step, mixed radix) that the search fallbacks follow, and whether
    a step met a continuum of solutions (a self-motion: the branch holds one representative) (M,).
    """
    twists = np.asarray(twists, dtype=float)
    N, n = Td.shape[0], len(kinds)
    TH = np.full((N, n), np.nan)
    if init is not None:  # free joints: values given per target, NaN elsewhere
        TH = np.where(np.isnan(init), TH, init)
        _apply_couplings(TH, couplings)
    SIG = np.full((N, max(n_groups, 1)), np.nan)
    owner = np.arange(N)
    ls = np.zeros(N, dtype=bool)
    branch = np.zeros(N, dtype=np.int64)
    cont = np.zeros(N, dtype=bool)
    for step in steps:
        if TH.shape[0] == 0:
            break
        if step["kind"] == "SUM":
            j, g, members = step["solve"][0], step["group"], step["members"]
            s_j = dict(members)[j]
            acc = SIG[:, g].copy()
            for m, s in members:
                if m != j:
                    acc -= s * TH[:, m]
            TH[:, j] = acc / s_j
            _apply_couplings(TH, couplings)
            continue
        res = solve_step(step, twists, kinds, Td[owner], TH, SIG)
        rows, slots = np.nonzero(res.valid)
        TH, SIG, owner = TH[rows], SIG[rows], owner[rows]
        branch = branch[rows] * res.valid.shape[1] + slots
        ls = ls[rows] | res.ls[rows, slots]
        cont = cont[rows] | res.continuum[rows]
        vals = res.q[rows, slots]
        if step["kind"] == "O":
            for col, g in enumerate(step["group_ids"]):
                group = step["groups"][col]
                if len(group) == 1:
                    TH[:, group[0][0]] = vals[:, col] * group[0][1]
                else:
                    SIG[:, g] = vals[:, col]
        else:
            for col, j in enumerate(step["solve"]):
                TH[:, j] = vals[:, col]
        _apply_couplings(TH, couplings)
    return TH, owner, ls, branch, cont


def run_search(step, twists, kinds, Td, couplings=(), n_groups=0, init=None):
    """Search fallback: grid over the ``step["search"]`` joints, closed form for the rest.

    For every grid value the sub-plan ``step["steps"]`` (which treats the searched joints as known)
    gives candidate branches; each branch's pose error is followed along the grid and its local minima
    become seeds that the caller polishes with Newton steps on every joint.  Returns ``(TH, owner)``
    seeds.  Roots closer together than one grid cell can merge: ``step["grid"]`` sets the resolution.
    """
    N, n = Td.shape[0], len(kinds)
    joints, G = step["search"], step["grid"]
    axes = [np.linspace(-math.pi, math.pi, G, endpoint=False) for _ in joints]
    mesh = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(joints))
    P = len(mesh)
    base = np.full((N, n), np.nan) if init is None else init
    seed_init = np.repeat(base, P, axis=0)
    seed_init[:, joints] = np.tile(mesh, (N, 1))
    TH, flat_owner, _, branch, _ = run_plan(
        step["steps"], twists, kinds, np.repeat(Td, P, axis=0), couplings, n_groups, seed_init
    )
    if TH.shape[0] == 0:
        return TH, flat_owner
    owner, cell = flat_owner // P, flat_owner % P
    poses = fk_batch(twists, TH, step["home"])
    if step.get("target") == "position":
        # Td is a translation taking the home tool point to the goal point
        goal = Td[owner, :3, 3] + np.asarray(step["home"])[:3, 3]
        err = np.linalg.norm(poses[:, :3, 3] - goal, axis=1)
    elif step.get("target") == "orientation":
        goal = Td[owner] @ step["home"]
        err = step["scale"] * np.abs(poses[:, :3, :3] - goal[:, :3, :3]).max(axis=(1, 2))
    else:
        err = pose_error(poses, Td[owner] @ step["home"], step["scale"])
    _, b_idx = np.unique(branch, return_inverse=True)
    B = int(b_idx.max()) + 1
    E = np.full((N, B) + (G,) * len(joints), np.inf)
    shape_cells = (G,) * len(joints)
    idx = np.unravel_index(cell, shape_cells)
    E[(owner, b_idx) + idx] = err
    is_min = np.isfinite(E)
    for ax in range(2, 2 + len(joints)):
        for shift in (1, -1):
            is_min &= E <= np.roll(E, shift, axis=ax)
    picked = is_min[(owner, b_idx) + idx]
    return TH[picked], owner[picked]


def pose_error(G, T, scale: float) -> np.ndarray:
    """Per-row pose error: max of the position error and ``scale`` times the rotation error (Frobenius
    norm), so that ``error <= tol * scale`` holds a row to ``tol`` of the robot's size in position and
    ``tol`` in rotation (the precision contract, docs/finish.md)."""
    dp = np.linalg.norm(G[:, :3, 3] - T[:, :3, 3], axis=1)
    dR = np.linalg.norm(G[:, :3, :3] - T[:, :3, :3], axis=(1, 2))
    return np.maximum(dp, scale * dR)


def target_error(G, T, target: str, scale: float) -> np.ndarray:
    """Per-row error of tool poses G (M, 4, 4) against targets T (M or 1, 4, 4) in what the ``target``
    kind constrains, in lengths (rotations scaled by the robot's size): the position error, the
    rotation error (Frobenius norm), for ``position+direction`` the tool origin and its z axis (the roll
    is free), else :func:`pose_error`.  The one error measure of the targets: the runtime's check,
    ``verify`` (over the size) and the motion paths use it; ``error <= tol * scale`` is the contract.

    >>> G = np.eye(4)[None]; T = np.eye(4)[None].copy(); T[0, 0, 3] = 1e-3
    >>> target_error(G, T, "orientation", 2.0).tolist(), target_error(G, T, "pose", 2.0).tolist()
    ([0.0], [0.001])
    """
    if target == "position":
        return np.linalg.norm(G[:, :3, 3] - T[:, :3, 3], axis=1)
    if target == "orientation":
        return scale * np.linalg.norm(G[:, :3, :3] - T[:, :3, :3], axis=(1, 2))
    if target == "position+direction":
        dp = np.linalg.norm(G[:, :3, 3] - T[:, :3, 3], axis=1)
        return np.maximum(dp, scale * np.linalg.norm(G[:, :3, 2] - T[:, :3, 2], axis=1))
    return pose_error(G, T, scale)


def within_limits(Q, kinds, lower, upper, eps=None) -> np.ndarray:
    """Rows of Q (M, dof) that have a representative inside the limits (:func:`subproblems.fast.represent`:
    a revolute value or its 2 pi alias, or a value within ``fast.LIMIT_EPS`` of a limit, which the finish
    clamps onto it: a double root at a limit is only located to about sqrt(machine epsilon))."""
    return ~represent(Q, kinds, lower, upper, True)[2]


def finish(
    TH,
    owner,
    ls,
    N,
    *,
    twists,
    kinds,
    home,
    independent,
    targets,
    scale,
    tol,
    slots,
    error,
    cont=None,
    limits=None,
    A=None,
    b=None,
    vary=None,
    dedupe=None,
    family_dedupe=None,
):
    """Check every candidate against its target, represent, remove duplicates, pack into slots.

    ``error(G, T)`` measures the target error of poses G against targets (full pose, position, ...).
    Returns ``Q (N, slots, dof)``, ``valid (N, slots)``, ``ls (N, slots)``, ``residual (N, slots)``,
    ``continuum (N, slots)``.
    Candidates with NaN (an unresolved joint) are dropped, and so are candidates outside ``limits``
    (lower, upper of the independent joints) when given.  The returned values are those of
    :func:`subproblems.fast.represent` (inside the limits as returned), and the error of each row is
    measured on exactly those values: with ``A, b, vary`` (all joints = A q_vary + b) the other joints
    are rebuilt from them first.  A row is exact when its error is at most ``tol * scale``; exact rows
    come first in each slot row.  ``dedupe``: the joint distance within which two rows of a target are
    one (default 1e-9 of max(1, scale); the search fallbacks pass ``fast.SPLIT_ROOT``: Newton from two
    seeds of one double root stops on a flat valley up to ~1e-7 apart).  ``family_dedupe``: the same for
    a pair of which one row or both are on a self-motion (``cont``; default ``dedupe``): Newton moves a
    representative onto its family at a point that depends on where it starts, and two of one family
    may land ~1e-8 apart (docs/design.md section 10, "Duplicate rows").
    """
    dof = len(independent)
    Q = np.zeros((N, slots, dof))
    valid = np.zeros((N, slots), dtype=bool)
    LS = np.zeros((N, slots), dtype=bool)
    RES = np.full((N, slots), np.inf)
    CONT = np.zeros((N, slots), dtype=bool)
    cont = np.zeros(len(owner), dtype=bool) if cont is None else cont
    ok = ~np.isnan(TH).any(axis=1)
    TH, owner, ls, cont = TH[ok], owner[ok], ls[ok], cont[ok]
    ind_kinds = "".join(kinds[i] for i in independent)
    lower, upper = limits if limits is not None else (np.zeros(dof), np.zeros(dof))
    Qi, _, outside = represent(TH[:, list(independent)], ind_kinds, lower, upper, limits is not None)
    TH, owner, ls, cont, Qi = TH[~outside], owner[~outside], ls[~outside], cont[~outside], Qi[~outside]
    if TH.shape[0] == 0:
        return Q, valid, LS, RES, CONT
    TH = wrap_joints(TH, kinds)
    TH[:, list(independent)] = Qi
    if A is not None:
        TH = TH[:, list(vary)] @ np.asarray(A).T + np.asarray(b)
    err = error(fk_batch(twists, TH, home), targets[owner])
    inexact = ~(err <= tol * scale)
    # order: by target, exact first, then by error
    order = np.lexsort((err, inexact, owner))
    TH, owner, err, inexact, cont = TH[order], owner[order], err[order], inexact[order], cont[order]
    Qi = TH[:, list(independent)]
    # pack candidates per target: rank within its target (rows are sorted by owner)
    first = np.searchsorted(owner, owner, side="left")
    rank = np.arange(len(owner)) - first
    C = int(rank.max()) + 1
    cand = np.zeros((N, C, dof))
    cval = np.zeros((N, C), dtype=bool)
    cerr = np.full((N, C), np.inf)
    cls = np.zeros((N, C), dtype=bool)
    ccont = np.zeros((N, C), dtype=bool)
    cand[owner, rank], cval[owner, rank], cerr[owner, rank], cls[owner, rank] = Qi, True, err, inexact
    ccont[owner, rank] = cont
    # duplicates: a candidate equal (angles modulo 2 pi) to an earlier valid one of the same target
    diff = cand[:, :, None, :] - cand[:, None, :, :]
    for c, k in enumerate(ind_kinds):
        diff[..., c] = angle_distance(diff[..., c], k == "R")
    tol = DUPLICATE_ROWS * max(1.0, scale) if dedupe is None else dedupe
    if family_dedupe is not None:
        tol = np.where(ccont[:, :, None] | ccont[:, None, :], family_dedupe, tol)
    same = np.abs(diff).max(axis=3) <= tol
    earlier = np.tril(np.ones((C, C), dtype=bool), k=-1)
    dup = np.any(same & earlier & cval[:, None, :], axis=2)
    keep = cval & ~dup
    new_rank = np.cumsum(keep, axis=1) - 1
    n_idx, c_idx = np.nonzero(keep & (new_rank < slots))
    r_idx = new_rank[n_idx, c_idx]
    Q[n_idx, r_idx] = cand[n_idx, c_idx]
    valid[n_idx, r_idx] = True
    LS[n_idx, r_idx] = cls[n_idx, c_idx]
    RES[n_idx, r_idx] = cerr[n_idx, c_idx]
    CONT[n_idx, r_idx] = ccont[n_idx, c_idx]
    return Q, valid, LS, RES, CONT


def polish(TH, targets, *, twists, home, A, b, independent, target="pose", iters=4, hold=(), cutoff=None):
    """Damped Gauss-Newton on the independent joints of every row toward its target (M, 4, 4).

    Corrects solutions of snapped near-relations and seeds of the numerical fallback.  Rows that do
    not converge stay where they end; the final check flags them.  ``hold``: positions in
    ``independent`` of joints that keep their values (free joints: the caller chose them).
    ``cutoff``: undamped pseudo-inverse steps instead (``newton.gauss_newton_step``), for rows at a
    rank-deficient Jacobian that the damped steps leave above the precision (docs/design.md section 10,
    "Newton at a singular configuration").
    """
    Q = TH[:, list(independent)].copy()
    twists = np.asarray(twists, dtype=float)
    for _ in range(iters):  # the step: subproblems/newton.py
        G, J = _newton.tool_jacobian(twists, Q @ A.T + b, home, A)
        e, rows = _newton.residual(G, targets, target)
        Q = Q + _newton.gauss_newton_step(J[:, rows, :], e, hold, cutoff=cutoff)
    return Q @ A.T + b


def numerical_seeds(N, starts, lower, upper, seed=11):
    """Fixed, deterministic starting points for the numerical fallback: (N * S, dof) and owners."""
    rng = np.random.default_rng(seed)
    S = rng.uniform(lower, upper, size=(starts, len(lower)))
    return np.tile(S, (N, 1)), np.repeat(np.arange(N), starts)
