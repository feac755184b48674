"""Manipulation spec files (``kind = "manipulation"``): a hand, an object and a commanded object motion.

Format (``robots/two_finger_disk.toml`` and ``robots/three_finger_sphere.toml`` are full examples)::

    kind = "manipulation"     # required: marks the file as a hand task, not a zoo robot
    name = "two_finger_disk"
    units = "cm"              # length unit of everything, the twist's v included (per second)
    angles = "deg"            # unit of initial angles, base_angle, angle and rpy (not of the twist: rad/s)
    planar = true             # motion in the xy plane: circle/line surfaces, twist (vx, vy, wz)
    contact = "point"         # "point" (with friction) or "soft" (soft finger); per finger: contact = ...
    objective = "equal_object_speeds"   # self-motion objective, or "none" / "fixed_object_contacts"
    duration = 3.0            # s (default for --duration)
    dt = 0.01                 # s (default for --dt)

    [object]
    surface = "circle"        # circle, line (planar); sphere, cylinder, plane, ellipsoid (3-D)
    radius = 10               # circle, sphere, cylinder; a, b, c for an ellipsoid; extent for plane/line
    position = [0, 0]         # initial position ([x, y, z] in 3-D)
    angle = 0                 # planar initial orientation; 3-D: rpy = [r, p, y]
    # chart = {rpy = [..]}    # 3-D: orientation of the surface chart in the object frame (poles away)

    [twist]                   # commanded object twist in the world frame, expressions in t
    vx = "1 - 1.5*t"          # velocity of the object's reference point (its frame origin)
    vy = "2 - t"
    wz = "0.1*t"              # angular velocity (3-D: vx vy vz wx wy wz; missing ones are 0)

    [[finger]]
    name = "f1"
    links = [20, 20, 10]      # planar finger from link lengths; or robot = "file" (any robot file)
    base = [-22, -20]         # planar: [x, y] (+ base_angle); 3-D: {xyz = [...], rpy = [...]}
    initial = [150, 240, 330] # initial joint angles
    tip = {surface = "circle", radius = 2}   # fingertip surface; xyz/rpy: its frame in the tool frame

Expressions may use ``t``, numbers, ``+ - * / **``, ``pi``, ``e`` and ``sin cos tan exp log sqrt abs``.

>>> spec = load_manipulation("two_finger_disk")
>>> spec.system.planar, spec.system.joint_names[:2], round(float(spec.theta0[1]), 6)
(True, ('f1.q1', 'f1.q2'), 4.18879)
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ikcompiler.errors import RobotInputError
from ikcompiler.hands.fingers import Finger, planar_finger
from ikcompiler.hands.surfaces import Circle, Cylinder, Ellipsoid, Line, Plane, Sphere, Surface
from ikcompiler.hands.system import HandSystem
from ikcompiler.hands.trajectory import OBJECTIVES, GraspObjective, Trajectory, manipulate
from ikcompiler.inputs._common import angle_scale, check_keys, frame, number, read_toml, string, vector


class ManipulationSpecError(RobotInputError):
    """A manipulation spec file is malformed (the message names the file and the field)."""


TOP_KEYS = {
    "kind",
    "name",
    "description",
    "units",
    "angles",
    "planar",
    "contact",
    "objective",
    "duration",
    "dt",
    "object",
    "twist",
    "finger",
    "assumptions",
}
FINGER_KEYS = {
    "name",
    "links",
    "robot",
    "base",
    "base_angle",
    "initial",
    "tip",
    "contact",
    "tip_link",
    "base_link",
    "contact_guess",
}
SURFACE_KEYS = {"surface", "radius", "a", "b", "c", "extent", "xyz", "rpy"}
OBJECT_KEYS = SURFACE_KEYS | {"position", "angle", "chart"}
PLANAR_TWIST = ("vx", "vy", "wz")
SPATIAL_TWIST = ("vx", "vy", "vz", "wx", "wy", "wz")

_FUNCS = {k: getattr(math, k) for k in ("sin", "cos", "tan", "exp", "log", "sqrt")} | {"abs": abs}
_CONSTS = {"pi": math.pi, "e": math.e}


def expression(text: str, source: str, where: str) -> Callable[[float], float]:
    """A safe function of ``t`` from an expression string (no names but t, pi, e and math functions).

    >>> expression("1 - 1.5*t", "f", "vx")(2.0)
    -2.0
    """
    if isinstance(text, int | float) and not isinstance(text, bool):
        value = float(text)
        return lambda t: value
    if not isinstance(text, str):
        raise ManipulationSpecError(
            f"must be an expression string in t, got {text!r}", source=source, where=where
        )
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise ManipulationSpecError(
            f"not an expression: {text!r} ({exc.msg})", source=source, where=where
        ) from exc
    ok = (
        ast.Expression,
        ast.BinOp,
        ast.UnaryOp,
        ast.Constant,
        ast.Name,
        ast.Call,
        ast.Load,
        ast.Add,
        ast.Sub,
        ast.Mult,
        ast.Div,
        ast.Pow,
        ast.USub,
        ast.UAdd,
    )
    for node in ast.walk(tree):
        bad = not isinstance(node, ok)
        bad |= (
            isinstance(node, ast.Name) and node.id not in _FUNCS and node.id not in _CONSTS and node.id != "t"
        )
        bad |= isinstance(node, ast.Call) and not (isinstance(node.func, ast.Name) and node.func.id in _FUNCS)
        bad |= isinstance(node, ast.Constant) and not isinstance(node.value, int | float)
        if bad:
            raise ManipulationSpecError(
                f"{text!r}: only t, numbers, + - * / **, pi, e and {', '.join(sorted(_FUNCS))} are allowed",
                source=source,
                where=where,
            )
    code = compile(tree, f"<{where}>", "eval")
    env = {"__builtins__": {}} | _FUNCS | _CONSTS
    try:
        float(eval(code, env, {"t": 0.0}))
    except (ArithmeticError, ValueError, TypeError) as exc:
        raise ManipulationSpecError(
            f"{text!r} cannot be evaluated at t = 0: {exc}", source=source, where=where
        ) from exc
    return lambda t: float(eval(code, env, {"t": float(t)}))


def surface(table, source: str, where: str, scale: float) -> tuple[Surface, np.ndarray]:
    """A surface and the pose of its frame (xyz, rpy) from a table."""
    if not isinstance(table, dict):
        raise ManipulationSpecError("must be a table with surface = ...", source=source, where=where)
    check_keys(table, SURFACE_KEYS, source, where)
    kind = string(table, "surface", source, where)
    if kind in ("circle", "sphere", "cylinder"):
        r = number(table, "radius", source, where)
        if not r > 0:
            raise ManipulationSpecError(f"radius must be positive, got {r}", source=source, where=where)
        s = {"circle": Circle, "sphere": Sphere, "cylinder": Cylinder}[kind](r)
    elif kind == "ellipsoid":
        a, b, c = (number(table, k, source, where) for k in "abc")
        if min(a, b, c) <= 0:
            raise ManipulationSpecError("ellipsoid a, b, c must be positive", source=source, where=where)
        s = Ellipsoid(a, b, c)
    elif kind in ("plane", "line"):
        s = (Plane if kind == "plane" else Line)(number(table, "extent", source, where, default=1.0))
    else:
        raise ManipulationSpecError(
            f"unknown surface {kind!r}; use circle or line (planar), sphere, cylinder, plane or ellipsoid",
            source=source,
            where=where,
        )
    pose = frame({k: table[k] for k in ("xyz", "rpy") if k in table}, source, where, scale)
    return s, pose


@dataclass
class ManipulationSpec:
    """A loaded spec: the system, its initial configuration, the commanded twist and run defaults."""

    system: HandSystem
    theta0: np.ndarray
    object_pose: np.ndarray
    twist: Callable[[float], np.ndarray]
    twist_text: dict[str, str]
    duration: float
    dt: float
    objective: str
    source: str
    contact_guess: np.ndarray | None = None
    assumptions: list[str] = field(default_factory=list)

    def make_objective(self) -> GraspObjective | None:
        return None if self.objective == "none" else OBJECTIVES[self.objective]()

    def run(
        self,
        *,
        duration: float | None = None,
        dt: float | None = None,
        self_motion: bool = True,
        method: str = "rk4",
        progress: bool = False,
    ) -> Trajectory:
        """The trajectory algorithm on this spec (``self_motion=False``: no joint self-motion)."""
        return manipulate(
            self.system,
            self.theta0,
            self.object_pose,
            self.twist,
            duration=self.duration if duration is None else duration,
            dt=self.dt if dt is None else dt,
            objective=self.make_objective() if self_motion else None,
            method=method,
            U0=self.contact_guess,
            progress=progress,
        )


def _locate(spec) -> Path:
    from ikcompiler.inputs.zoo import zoo_dir

    p = Path(spec)
    if not p.exists() and "/" not in str(spec) and not str(spec).endswith(".toml"):
        p = zoo_dir() / f"{spec}.toml"
    if not p.is_file():
        raise ManipulationSpecError(
            'no such manipulation spec file (a .toml with kind = "manipulation")', source=str(spec)
        )
    return p


def load_manipulation(spec) -> ManipulationSpec:
    """Read a manipulation spec from a path or the name of one in ``robots/``."""
    path = _locate(spec)
    src = str(path)
    data = read_toml(path)
    if data.get("kind") != "manipulation":
        raise ManipulationSpecError(
            'not a manipulation spec: it needs kind = "manipulation" at the top (a robot file goes to '
            "ikc describe / compile)",
            source=src,
            where="kind",
        )
    check_keys(data, TOP_KEYS, src, "top level")
    scale = angle_scale(data, src)
    planar = bool(data.get("planar", False))
    units = string(data, "units", src, "units", default="")
    default_contact = _contact(data.get("contact", "point"), src, "contact")
    if planar and default_contact == "soft":
        raise ManipulationSpecError("a planar problem has point contacts only", source=src, where="contact")
    objective = string(data, "objective", src, "objective", default="equal_object_speeds")
    if objective != "none" and objective not in OBJECTIVES:
        raise ManipulationSpecError(
            f"unknown objective {objective!r}; use none, {', '.join(sorted(OBJECTIVES))}",
            source=src,
            where="objective",
        )
    obj_t = data.get("object")
    if not isinstance(obj_t, dict):
        raise ManipulationSpecError("an [object] table is required", source=src, where="object")
    check_keys(obj_t, OBJECT_KEYS, src, "object")
    osurf, _ = surface(
        {k: v for k, v in obj_t.items() if k not in ("position", "angle", "chart", "rpy")},
        src,
        "object",
        scale,
    )
    g_o = np.eye(4)
    if planar:
        xy = vector(obj_t, "position", 2, src, "object", default=[0, 0])
        a = number(obj_t, "angle", src, "object", default=0.0) * scale
        g_o[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
        g_o[:2, 3] = xy
        chart = np.eye(4)
    else:
        g_o = frame(
            {"xyz": obj_t.get("position", [0, 0, 0]), "rpy": obj_t.get("rpy", [0, 0, 0])},
            src,
            "object",
            scale,
        )
        chart = frame(obj_t.get("chart", {}), src, "object.chart", scale)
    names = PLANAR_TWIST if planar else SPATIAL_TWIST
    tw_t = data.get("twist", {})
    if not isinstance(tw_t, dict):
        raise ManipulationSpecError("[twist] must be a table of expressions in t", source=src, where="twist")
    check_keys(tw_t, set(names), src, "twist")
    funcs = [expression(tw_t.get(k, "0"), src, f"twist.{k}") for k in names]

    def twist(t: float) -> np.ndarray:
        return np.array([f(t) for f in funcs])

    fingers_t = data.get("finger")
    if not isinstance(fingers_t, list) or not fingers_t:
        raise ManipulationSpecError("at least one [[finger]] table is required", source=src, where="finger")
    fingers, contacts, theta0, guesses = [], [], [], []
    for i, ft in enumerate(fingers_t):
        where = f"finger {i + 1}"
        check_keys(ft, FINGER_KEYS, src, where)
        name = string(ft, "name", src, where, default=f"f{i + 1}")
        where = f"finger {name!r}"
        tip_s, tip_g = surface(ft.get("tip"), src, f"{where}.tip", scale)
        if "links" in ft:
            if not planar:
                raise ManipulationSpecError(
                    "links = [...] makes a planar finger; a 3-D finger needs robot = ...",
                    source=src,
                    where=where,
                )
            links = ft["links"]
            if not (
                isinstance(links, list) and links and all(isinstance(x, int | float) and x > 0 for x in links)
            ):
                raise ManipulationSpecError(
                    "links must be a list of positive lengths", source=src, where=where
                )
            base = vector(ft, "base", 2, src, where, default=[0, 0])
            f = planar_finger(
                name,
                links,
                base=base,
                base_angle=number(ft, "base_angle", src, where, 0.0) * scale,
                surface=tip_s,
                units=units,
            )
            f = Finger(f.name, f.chain, f.base, f.tip @ tip_g, tip_s)
        elif "robot" in ft:
            from ikcompiler.inputs import load_robot

            rob = string(ft, "robot", src, where)
            rp = (path.parent / rob) if (path.parent / rob).exists() else rob
            chain = load_robot(rp, base=ft.get("base_link"), tip=ft.get("tip_link"))
            base = frame(ft.get("base", {}), src, f"{where}.base", scale)
            f = Finger(name, chain, base, tip_g, tip_s)
        else:
            raise ManipulationSpecError(
                'give links = [...] (planar) or robot = "file"', source=src, where=where
            )
        init = vector(ft, "initial", f.dof, src, where) * scale
        kind = _contact(ft.get("contact", default_contact), src, f"{where}.contact")
        if planar and kind == "soft":
            raise ManipulationSpecError("a planar problem has point contacts only", source=src, where=where)
        fingers.append(f)
        contacts.append(kind)
        theta0.extend(init)
        guesses.append(vector(ft, "contact_guess", 4, src, where) if "contact_guess" in ft else None)
    try:
        system = HandSystem(
            tuple(fingers),
            osurf,
            tuple(contacts),
            planar,
            chart,
            name=string(data, "name", src, "name", default=path.name.split(".")[0]),
            units=units,
        )
    except ValueError as exc:
        raise ManipulationSpecError(str(exc), source=src) from exc
    guess = None
    if all(g is not None for g in guesses):
        guess = np.array(guesses)
    dur = number(data, "duration", src, "duration", default=1.0)
    dt = number(data, "dt", src, "dt", default=0.01)
    assumptions = data.get("assumptions", [])
    return ManipulationSpec(
        system,
        np.array(theta0),
        g_o,
        twist,
        {k: str(tw_t.get(k, "0")) for k in names},
        dur,
        dt,
        objective,
        src,
        guess,
        list(assumptions) if isinstance(assumptions, list) else [],
    )


def _contact(value, src: str, where: str) -> str:
    from ikcompiler.hands.contact import CONTACT_ALIASES

    if value not in CONTACT_ALIASES:
        raise ManipulationSpecError(
            f'unknown contact type {value!r}; use "point" (point contact with friction) '
            'or "soft" (soft finger)',
            source=src,
            where=where,
        )
    return CONTACT_ALIASES[value]
