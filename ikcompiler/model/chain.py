"""The immutable kinematic chain every later stage reads: joints with twists, limits, home pose, couplings.

The chain is the product-of-exponentials (POE) model of docs/design.md section 2::

    g_st(th) = exp(xi_1^ th_1) ... exp(xi_n^ th_n) g_st(0)

``joints`` lists every moving joint in chain order, mimic joints included.  A coupling
``th_j = a * th_k + b`` makes joint j follow joint k; the *independent* joints (those no coupling
drives) are the variables of forward and inverse kinematics, in chain order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ikcompiler.errors import RobotInputError
from subproblems.screw import axis_point, is_prismatic
from subproblems.tolerances import TWIST_UNIT

JOINT_KINDS = ("R", "T")


def _frozen(a, shape) -> np.ndarray:
    arr = np.array(a, dtype=float).reshape(shape)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class Joint:
    """One 1-DOF joint: ``kind`` "R" (revolute) or "T" (prismatic), its space-frame twist at home."""

    name: str
    kind: str
    twist: np.ndarray
    lower: float = -math.pi
    upper: float = math.pi

    def __post_init__(self):
        if self.kind not in JOINT_KINDS:
            raise RobotInputError(f"joint kind must be 'R' or 'T', got {self.kind!r}", where=self.name)
        tw = _frozen(self.twist, (6,))
        if not np.all(np.isfinite(tw)):
            raise RobotInputError("twist is not finite", where=f"joint {self.name!r}")
        if self.kind == "R" and abs(np.linalg.norm(tw[3:]) - 1.0) > TWIST_UNIT:
            raise RobotInputError("revolute twist needs a unit axis w", where=f"joint {self.name!r}")
        if self.kind == "T" and not (is_prismatic(tw) and abs(np.linalg.norm(tw[:3]) - 1) < TWIST_UNIT):
            raise RobotInputError(
                "prismatic twist needs w = 0 and a unit direction v", where=f"joint {self.name!r}"
            )
        if not self.lower <= self.upper:
            raise RobotInputError(
                f"lower limit {self.lower} is above upper limit {self.upper}",
                where=f"joint {self.name!r}",
            )
        object.__setattr__(self, "twist", tw)

    @property
    def axis(self) -> np.ndarray:
        """Unit direction: the rotation axis (R) or the direction of travel (T)."""
        return self.twist[3:] if self.kind == "R" else self.twist[:3]

    @property
    def point(self) -> np.ndarray | None:
        """The axis point closest to the origin for a revolute joint; None for a prismatic one."""
        return axis_point(self.twist) if self.kind == "R" else None


@dataclass(frozen=True)
class Coupling:
    """``th[joint] = a * th[master] + b`` (URDF ``<mimic>``; the Shadow finger's ``th_4 = th_3``)."""

    joint: str
    master: str
    a: float = 1.0
    b: float = 0.0


@dataclass(frozen=True)
class Chain:
    """A serial chain in POE form.  Immutable: stages derive new chains, never edit one.

    ``units`` names the length unit of twists and home pose ("m", "mm", ...); ``source`` the file it came
    from; ``base`` and ``tip`` the frames S and T.
    """

    name: str
    joints: tuple[Joint, ...]
    home: np.ndarray
    couplings: tuple[Coupling, ...] = ()
    base: str = "base"
    tip: str = "tool"
    units: str = ""
    source: str = ""
    notes: tuple[str, ...] = field(default=())

    def __post_init__(self):
        object.__setattr__(self, "joints", tuple(self.joints))
        object.__setattr__(self, "couplings", tuple(self.couplings))
        object.__setattr__(self, "home", _frozen(self.home, (4, 4)))
        names = [j.name for j in self.joints]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise RobotInputError(f"duplicate joint names {dupes}", source=self.source or self.name)
        known = set(names)
        for c in self.couplings:
            for role, jn in (("coupled joint", c.joint), ("master joint", c.master)):
                if jn not in known:
                    raise RobotInputError(
                        f"{role} {jn!r} of a coupling is not a joint of the chain ({', '.join(names)})",
                        source=self.source or self.name,
                    )
        self._resolve_couplings()  # raises on cycles

    # ---- joint bookkeeping -------------------------------------------------------------------------

    @property
    def n(self) -> int:
        """Number of moving joints, coupled ones included."""
        return len(self.joints)

    @property
    def joint_types(self) -> str:
        """The joint string, e.g. ``"TRRRRR"`` (coupled joints included)."""
        return "".join(j.kind for j in self.joints)

    @property
    def independent(self) -> tuple[int, ...]:
        """Indices (into ``joints``) of the joints no coupling drives: the IK/FK variables."""
        coupled = {c.joint for c in self.couplings}
        return tuple(i for i, j in enumerate(self.joints) if j.name not in coupled)

    @property
    def independent_names(self) -> tuple[str, ...]:
        return tuple(self.joints[i].name for i in self.independent)

    @property
    def dof(self) -> int:
        return len(self.independent)

    def index(self, name: str) -> int:
        for i, j in enumerate(self.joints):
            if j.name == name:
                return i
        raise RobotInputError(
            f"no joint named {name!r}; joints are {', '.join(j.name for j in self.joints)}",
            source=self.source or self.name,
        )

    def _resolve_couplings(self) -> dict[int, tuple[int, float, float]]:
        """Map each coupled joint to (independent master index, a, b), following chains of mimics."""
        by_joint = {c.joint: c for c in self.couplings}
        out: dict[int, tuple[int, float, float]] = {}
        for c in self.couplings:
            a, b, seen, cur = 1.0, 0.0, {c.joint}, c
            while True:
                a, b = a * cur.a, a * cur.b + b
                if cur.master not in by_joint:
                    break
                if cur.master in seen:
                    raise RobotInputError(
                        f"coupling cycle through joint {cur.master!r}", source=self.source or self.name
                    )
                seen.add(cur.master)
                cur = by_joint[cur.master]
            names = [j.name for j in self.joints]
            out[names.index(c.joint)] = (names.index(cur.master), a, b)
        return out

    def expand(self, q) -> np.ndarray:
        """Joint values of every joint (coupled ones computed) from independent values ``q`` (..., dof)."""
        q = np.asarray(q, dtype=float)
        if q.shape[-1] != self.dof:
            raise RobotInputError(
                f"expected {self.dof} joint values ({', '.join(self.independent_names)}), got {q.shape[-1]}",
                source=self.source or self.name,
            )
        full = np.zeros(q.shape[:-1] + (self.n,))
        full[..., list(self.independent)] = q
        for j, (k, a, b) in self._resolve_couplings().items():
            full[..., j] = a * full[..., k] + b
        return full

    def coupling_matrix(self) -> tuple[np.ndarray, np.ndarray]:
        """``(A, b)`` with ``th_full = A @ q + b``: the linear map from independent to all joints."""
        A = np.zeros((self.n, self.dof))
        b = np.zeros(self.n)
        col = {idx: c for c, idx in enumerate(self.independent)}
        for idx in self.independent:
            A[idx, col[idx]] = 1.0
        for j, (k, a, off) in self._resolve_couplings().items():
            A[j, col[k]] = a
            b[j] = off
        return A, b

    @property
    def lower(self) -> np.ndarray:
        return np.array([self.joints[i].lower for i in self.independent])

    @property
    def upper(self) -> np.ndarray:
        return np.array([self.joints[i].upper for i in self.independent])

    # ---- geometry ----------------------------------------------------------------------------------

    @property
    def twists(self) -> np.ndarray:
        """(n, 6) home twists of all joints in chain order."""
        return np.array([j.twist for j in self.joints])

    @property
    def scale(self) -> float:
        """Characteristic length of the robot: tolerances are relative to it.

        The largest of: the home tool distance from the base, the axis points' distances, and the finite
        prismatic strokes.  1.0 when all of these are zero.
        """
        sizes = [float(np.linalg.norm(self.home[:3, 3]))]
        for j in self.joints:
            if j.kind == "R":
                sizes.append(float(np.linalg.norm(j.point)))
            elif math.isfinite(j.lower) and math.isfinite(j.upper):
                sizes.append(max(abs(j.lower), abs(j.upper)))
        s = max(sizes)
        return s if s > 0 else 1.0

    def inverted(self) -> Chain:
        """The reversed chain that maps the same joint values to ``g_st(th)^-1``.

        ``g^-1 = g0^-1 exp(-xi_n th_n) ... exp(-xi_1 th_1) = prod_i exp((-Ad_{g0^-1} xi_i)^ th_i) g0^-1``
        with the product in reversed order; joint names, kinds and limits travel with their joints.
        """
        from subproblems.screw import adjoint, inverse_transform

        g0i = inverse_transform(self.home)
        Ad = adjoint(g0i)
        joints = tuple(
            Joint(j.name, j.kind, -(Ad @ j.twist), j.lower, j.upper) for j in reversed(self.joints)
        )
        return Chain(
            name=f"{self.name} (inverted)",
            joints=joints,
            home=g0i,
            couplings=self.couplings,
            base=self.tip,
            tip=self.base,
            units=self.units,
            source=self.source,
        )

    # ---- kinematics (delegated so that the model file stays about data) ------------------------------

    def fk(self, q) -> np.ndarray:
        """Tool pose ``g_st(q)`` (4x4) for independent joint values ``q``."""
        from ikcompiler.model.kinematics import forward

        return forward(self, q)

    def fk_batch(self, Q) -> np.ndarray:
        """Tool poses (N, 4, 4) for independent joint values (N, dof), vectorised."""
        from ikcompiler.model.kinematics import forward_batch

        return forward_batch(self, Q)

    def space_jacobian(self, q) -> np.ndarray:
        from ikcompiler.model.kinematics import space_jacobian

        return space_jacobian(self, q)

    def body_jacobian(self, q) -> np.ndarray:
        from ikcompiler.model.kinematics import body_jacobian

        return body_jacobian(self, q)

    def describe(self) -> str:
        from ikcompiler.model.describe import describe

        return describe(self)
