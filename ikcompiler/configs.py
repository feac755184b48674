"""The configuration zoo: seeded modular and general robots of every joint string up to 6 joints.

Modular robots are assembled from joint modules and links: each module's axis lies along the incoming
link or perpendicular to it, each link is straight, of a random length (sometimes zero, so that axes
meet), and runs along the current direction or turns by a right angle.  The *general* variant draws
every axis direction and point at random: no relation between axes holds.  Every chain is compiled with
the target its joint count allows (:func:`compile_chain`) and verified; ``benchmarks/configurations.py``
runs the whole zoo (126 joint strings x instances x both geometries) and writes
``benchmarks/results/configurations.md``; ``tests/test_configurations.py`` runs a fixed sample.
See ``docs/realrobots.md``.

>>> len(joint_strings())
126
>>> chain = modular_chain("RTR", seed=1)
>>> chain.joint_types, chain.dof
('RTR', 3)
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass

import numpy as np

from ikcompiler.model import Chain, Joint
from subproblems.screw import prismatic_twist, revolute_twist

PRISMATIC_RANGE = (-0.3, 0.3)  # metres; the links are 0..0.4 m


def joint_strings(max_len: int = 6) -> list[str]:
    """Every string over {R, T} of length 1..max_len, shortest first (2 + 4 + ... + 64 = 126 for 6)."""
    return ["".join(p) for n in range(1, max_len + 1) for p in itertools.product("RT", repeat=n)]


def _turn(R: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Rotate the frame by +-90 degrees about its x or y axis (the link direction z turns a right angle)."""
    c = int(rng.integers(0, 2))
    s = 1.0 if rng.random() < 0.5 else -1.0
    Q = np.eye(3)
    i, k = (1, 2) if c == 0 else (2, 0)  # about x: y,z mix; about y: z,x mix
    Q[i, i] = Q[k, k] = 0.0
    Q[i, k], Q[k, i] = -s, s
    return R @ Q


def modular_chain(kinds: str, seed: int = 0, geometry: str = "modular") -> Chain:
    """A seeded chain of joint string ``kinds``; ``geometry`` "modular" or "general" (module docstring)."""
    rng = np.random.default_rng([seed, len(kinds), int(kinds.replace("R", "0").replace("T", "1"), 2)])
    joints = []
    if geometry == "general":
        for i, k in enumerate(kinds):
            w = rng.normal(size=3)
            w /= np.linalg.norm(w)
            tw = revolute_twist(w, rng.uniform(-0.4, 0.4, size=3)) if k == "R" else prismatic_twist(w)
            joints.append(_joint(i, k, tw))
        A = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        home = np.eye(4)
        home[:3, :3] = A * np.sign(np.linalg.det(A))
        home[:3, 3] = rng.uniform(-0.5, 0.5, size=3)
        return Chain(f"general-{kinds}-{seed}", tuple(joints), home, units="m", source="ikcompiler.configs")
    if geometry != "modular":
        raise ValueError(f"geometry must be 'modular' or 'general', got {geometry!r}")
    R, p = np.eye(3), np.zeros(3)
    for i, k in enumerate(kinds):
        axis = R[:, int(rng.integers(0, 3))]  # x or y: perpendicular to the link, z: along it
        tw = revolute_twist(axis, p) if k == "R" else prismatic_twist(axis)
        joints.append(_joint(i, k, tw))
        if rng.random() < 0.5:
            R = _turn(R, rng)
        length = 0.0 if rng.random() < 0.25 else float(rng.uniform(0.05, 0.4))
        p = p + length * R[:, 2]
    home = np.eye(4)
    home[:3, :3], home[:3, 3] = R, p
    return Chain(f"modular-{kinds}-{seed}", tuple(joints), home, units="m", source="ikcompiler.configs")


def _joint(i: int, kind: str, twist) -> Joint:
    lo, hi = (-math.pi, math.pi) if kind == "R" else PRISMATIC_RANGE
    return Joint(f"q{i + 1}", kind, twist, lo, hi)


@dataclass
class Compiled:
    module: object
    target: str
    free: tuple[str, ...]
    seconds: float  # compile time (all attempts)


def random_6r_geometry(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A general 6R arm: axis directions uniform on the sphere, axis points in a 1 m cube, a random
    tool offset.  Returns ``(twists (6, 6), home (4, 4))``; the same seed gives the same arm bit for bit
    (the general 6R tests and benchmark name their arms by seed)."""
    rng = np.random.default_rng(seed)
    w = rng.normal(size=(6, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    r = rng.uniform(-0.5, 0.5, size=(6, 3))
    home = np.eye(4)
    home[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    return np.concatenate([-np.cross(w, r), w], axis=1), home


def random_6r_chain(seed: int) -> Chain:
    """:func:`random_6r_geometry` as a chain (joints j1..j6, limits (-pi, pi])."""
    twists, home = random_6r_geometry(seed)
    joints = tuple(Joint(f"j{i + 1}", "R", twists[i], -math.pi, math.pi) for i in range(6))
    return Chain(f"random-6r-{seed}", joints, home)


def random_chain(kinds: str, seed: int = 11) -> Chain:
    """A chain of joint string ``kinds`` with random unit axes and points (fixed seed), prismatic
    joints limited to [-1, 1]: no relation between the axes holds (TRRRRR takes general-6r, TTTTR the
    numerical fallback).  The typed-steps tests and ``benchmarks/dump_modules.py`` share it."""
    rng = np.random.default_rng(seed)
    joints = []
    for k, kind in enumerate(kinds):
        w = rng.normal(size=3)
        w /= np.linalg.norm(w)
        if kind == "T":
            joints.append(Joint(f"j{k}", "T", np.r_[w, 0.0, 0.0, 0.0], -1.0, 1.0))
        else:
            joints.append(Joint(f"j{k}", "R", revolute_twist(w, rng.normal(size=3))))
    home = np.eye(4)
    home[:3, 3] = rng.normal(size=3)
    return Chain(f"general_{kinds.lower()}", tuple(joints), home)


def free_candidates(chain: Chain) -> list[tuple[str, ...]]:
    """Free-joint choices tried for a chain with more than 6 independent joints: the 3rd joint (the
    elbow of a 7-joint arm), then the last, then the first; ``[()]`` for 6 joints or fewer."""
    names = chain.independent_names
    extra = len(names) - 6
    if extra <= 0:
        return [()]
    picks = []
    for start in (2, len(names) - extra, 0):
        cand = tuple(names[start : start + extra])
        if len(cand) == extra and cand not in picks:
            picks.append(cand)
    return picks


def compile_chain(chain: Chain, first_only: bool = False, **options) -> Compiled:
    """Compile ``chain`` for the target its joint count allows: a full pose (up to 6 independent joints;
    fewer are solved from a sufficient subset of the equations and checked against the whole pose),
    with free joints beyond 6: the first choice of :func:`free_candidates` that compiles closed form
    (for a chain its snap moves beyond tolerances.SNAP_GENERAL: the first with free end joints that
    takes the elimination, else the first snapped closed form), else the first that takes the
    complete general 6R elimination with its free joints at the chain's ends (fixed twists: the C
    elimination), else the first with a free joint folded into it (Python only: runtime/freefold.py;
    baxter's arms: 0.7 ms median a pose with the last joint free, 5-10 ms with the elbow), else the
    first.  ``first_only``: the first choice alone (the third joint, as a user
    naming it free; ``benchmarks/real_robots.py --first-free``).  A rank-deficient chain the compiler
    refuses (errors.RedundantChainError) is compiled with the dependent joints it names free as well,
    as the refusal tells a user to (docs/design.md section 5, "Rank-deficient chains"); ``free`` of the
    result is the module's FREE_JOINTS."""
    from ikcompiler.compiler import (
        GENERAL6,
        _module_name,
        compile_plan,
        free_end_split,
        load_module,
        plan_source,
    )
    from ikcompiler.errors import RedundantChainError

    t0 = time.perf_counter()

    def compiled(free, fold: bool):
        try:
            plan = compile_plan(chain, target="pose", free=free, fold=fold, **options)
        except RedundantChainError as exc:  # as the refusal says: its dependent joints declared free
            plan = compile_plan(chain, target="pose", free=tuple(free) + exc.dependent, fold=fold, **options)
        return load_module(plan_source(plan, chain, **options), _module_name(chain.name))

    first = general = folded = snapped_far = None
    far = _snapped_far(chain)
    searched = []
    for free in free_candidates(chain)[:1] if first_only else free_candidates(chain):
        module = compiled(free, fold=False)  # the fold measured only where nothing else is complete
        if first is None:
            first = (module, free)
        if module.METHOD == "closed-form" and not far:
            return Compiled(module, "pose", tuple(module.FREE_JOINTS), time.perf_counter() - t0)
        if module.METHOD == "closed-form" and snapped_far is None:
            # beyond tolerances.SNAP_GENERAL the policy wants the elimination, which this free joint
            # (between solved ones, not folded here) keeps from it: another choice may allow it
            snapped_far = (module, free)
        if module.METHOD == GENERAL6 and general is None:
            general = (module, free)
        if free_end_split(chain, free) is None:  # a free joint between solved ones: the fold may apply
            searched.append(free)
    for free in searched if general is None and snapped_far is None else ():
        module = compiled(free, fold=True)
        if module.METHOD == GENERAL6:
            folded = (module, free)
            break
    module, free = general or snapped_far or folded or first
    return Compiled(module, "pose", tuple(module.FREE_JOINTS), time.perf_counter() - t0)


def _snapped_far(chain: Chain) -> bool:
    """Whether the compiler's policy wants the elimination for ``chain`` (compiler.beyond_snap_general)."""
    from ikcompiler.compiler import beyond_snap_general
    from ikcompiler.geometry.snap import snap_chain

    return bool(beyond_snap_general(chain, *snap_chain(chain)))


def generic_rank(chain: Chain, samples: int = 5, seed: int = 0) -> int:
    """The largest rank of the size-free space Jacobian at random configurations inside the limits.

    Below the number of independent joints (four parallel revolute axes, four or more prismatic
    joints, two coincident axes) the chain has a continuum of solutions at every pose: *redundant*.

    >>> generic_rank(modular_chain("RRR", seed=2))
    3
    """
    from ikcompiler.verify import sample_configurations  # verify imports nothing of this module

    best = 0
    for q in sample_configurations(chain, samples, seed=seed, special=0.0):
        J = chain.space_jacobian(q).copy()
        J[:3] /= chain.scale
        best = max(best, int(np.linalg.matrix_rank(J, tol=1e-8)))
    return best


def method_class(method: str) -> str:
    """The coverage column of a module's METHOD: closed form, 1-D search, or general solver."""
    if method == "closed-form":
        return "closed form"
    if method == "1d-search":
        return "1-D search"
    return "general solver"


def perturbed(chain: Chain, eps: float, seed: int = 0) -> Chain:
    """The chain with every axis direction tilted by about ``eps`` rad and every axis point moved by
    about ``eps`` of the robot's size (fixed seed): a calibrated robot.  Couplings and limits kept.

    >>> c = perturbed(modular_chain("RRR", seed=2), 1e-6)
    >>> c.name.endswith("(perturbed 1e-06)")
    True
    """
    rng = np.random.default_rng(seed)
    joints = []
    for j in chain.joints:
        w = j.axis + eps * rng.normal(size=3)
        if j.kind == "R":
            tw = revolute_twist(w / np.linalg.norm(w), j.point + eps * chain.scale * rng.normal(size=3))
        else:
            tw = prismatic_twist(w / np.linalg.norm(w))
        joints.append(Joint(j.name, j.kind, tw, j.lower, j.upper))
    return Chain(
        f"{chain.name} (perturbed {eps:g})",
        tuple(joints),
        chain.home,
        chain.couplings,
        base=chain.base,
        tip=chain.tip,
        units=chain.units,
        source=chain.source,
    )
