"""The data of one generated module as a typed record (docs/design.md section 6).

:meth:`Robot.from_namespace` reads the constants a module defines (``JOINT_NAMES``, ``_TWISTS``,
``_STEPS``, ...); everything the runtime needs about the robot comes from here.  The switches
``FAST_PATH`` and ``NATIVE`` are not part of it: users and tests change them on the module at any
time, so the dispatch reads them from the module each call.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from subproblems import plan_runtime as _rt
from subproblems import tolerances as _tol


@dataclass(frozen=True, eq=False)
class Robot:
    joint_names: tuple
    joint_types: str  # returned joints, JOINT_NAMES order
    method: str
    target: str
    free_joints: tuple
    lower: np.ndarray
    upper: np.ndarray
    scale: float
    tol: float  # exact when the error <= tol * scale
    slots: int
    twists: np.ndarray  # true robot, every joint (mimic ones too)
    plan_twists: np.ndarray  # the robot the chain was derived on (snapped) or twists
    kinds: str  # every joint of the chain
    home: np.ndarray
    home_inv: np.ndarray
    couplings: list
    A: np.ndarray  # all joint values = A @ q + B
    B: np.ndarray
    independent: tuple  # returned joints among the chain's
    vary: tuple  # joints Newton steps move
    vary_lower: np.ndarray
    vary_upper: np.ndarray
    vary_kinds: str
    solve_target: str  # what the chain solves for (a virtual roll makes position+direction a pose)
    free: tuple  # positions of the free joints in joint_names
    n_groups: int
    polish: int  # Newton steps on the true robot of a snapped plan (0: not snapped)
    search: tuple  # joints gridded by the search fallback
    grid: int
    steps: list
    alt_steps: list
    general6: Any  # subproblems.general6.General6 for the general-6r method, else None
    fast_chain: Any  # the module's _fast_chain or None
    target_error: type
    free_error: type
    near_redundant: bool = False  # within the snap tolerance of a redundant chain (selfmotion.near_redundant)
    speed: Any = None  # None or (n,): solved value = speed * q (folded slides, docs/design.md section 2)

    @classmethod
    def from_namespace(cls, ns: dict) -> Robot:
        return cls(
            joint_names=tuple(ns["JOINT_NAMES"]), joint_types=ns["JOINT_TYPES"], method=ns["METHOD"],
            target=ns["TARGET"], free_joints=tuple(ns["FREE_JOINTS"]), lower=ns.get("_LOWER", ns["LOWER"]),
            upper=ns.get("_UPPER", ns["UPPER"]),
            scale=float(ns["SCALE"]), tol=float(ns["TOLERANCE"]), slots=int(ns["MAX_SOLUTIONS"]),
            twists=ns["_TWISTS"], plan_twists=ns["_PLAN_TWISTS"], kinds=ns["_KINDS"], home=ns["_HOME"],
            home_inv=_rt.inverse_transform(ns["_HOME"]), couplings=ns["_COUPLINGS"], A=ns["_A"], B=ns["_B"],
            independent=tuple(ns["_INDEPENDENT"]), vary=tuple(ns["_VARY"]), vary_lower=ns["_VARY_LOWER"],
            vary_upper=ns["_VARY_UPPER"], vary_kinds="".join(ns["_KINDS"][j] for j in ns["_VARY"]),
            solve_target=ns["_SOLVE_TARGET"], free=tuple(ns["_FREE"]), n_groups=int(ns["_N_GROUPS"]),
            polish=int(ns["_POLISH"]), search=tuple(ns["_SEARCH"]), grid=int(ns["_GRID"]),
            steps=ns["_STEPS"], alt_steps=ns["_ALT_STEPS"], general6=ns.get("_GENERAL6"),
            fast_chain=ns.get("_fast_chain"),
            target_error=ns["InvalidTargetError"], free_error=ns["InvalidFreeValueError"],
            near_redundant=bool(ns.get("_NEAR_REDUNDANT", False)),
            speed=None if ns.get("_SPEED") is None else np.asarray(ns["_SPEED"], dtype=float),
        )

    def finish_kwargs(self, limits) -> dict:
        """The fast finish's arguments (subproblems.fast.finish_one / finish_many)."""
        return self._finish_arguments[bool(limits)]

    @functools.cached_property
    def _finish_arguments(self) -> dict:
        # built once: a single-pose solve asks for them on every call
        return {limits: {"kinds": self.joint_types, "lower": tuple(self.lower.tolist()),
                         "upper": tuple(self.upper.tolist()), "limits": limits, "scale": self.scale,
                         "tol": self.tol, "slots": self.slots} for limits in (False, True)}

    @functools.cached_property
    def free_ends(self):
        """The split of a general-6r robot with free end joints (runtime.freeends.FreeEnds), made once."""
        from ikcompiler.runtime.freeends import FreeEnds

        return FreeEnds(self)

    def error(self, G, goals) -> np.ndarray:
        """How far tool poses G miss their goals, in lengths (rotation scaled by the robot's size)."""
        return _rt.target_error(G, goals, self.target, self.scale)

    def fk(self, q) -> np.ndarray:
        """Tool pose (4x4) for joint values q in joint_names order (exactly that many)."""
        q = np.asarray(q, dtype=float)
        n = len(self.joint_names)
        if q.shape != (n,):
            raise ValueError(f"fk expects {n} joint values {self.joint_names}, got shape {q.shape}")
        q = np.concatenate([q, np.zeros(len(self.vary) - n)]).reshape(1, -1)  # virtual joints at 0
        return _rt.fk_batch(self.twists, q @ self.A.T + self.B, self.home)[0]

    def newton_until_exact(self, TH, goals, iters: int, margin: float = _tol.CONTINUUM_MARGIN, *,
                           rows=None, per_round: int = 4) -> np.ndarray:
        """Newton steps as :meth:`newton`, up to ``iters``, in rounds of ``per_round`` on the rows still
        missing by more than ``margin`` of the precision: a row already exact takes none (a self-motion's
        representative usually is: then 60 steps on it only cost time, about 5 ms a pose).  ``rows``
        (a mask): the rows to work on, instead of all those missing by more than the margin."""
        TH = np.array(TH, dtype=float)
        stop = margin * self.tol * self.scale
        if rows is None:
            rows = self.error(_rt.fk_batch(self.twists, np.nan_to_num(TH), self.home), goals) > stop
        active = np.array(rows, dtype=bool)
        done = 0
        while active.any() and done < iters:
            k = min(per_round, iters - done)
            TH[active] = self.newton(TH[active], goals[active], k)
            done += k
            err = self.error(_rt.fk_batch(self.twists, TH[active], self.home), goals[active])
            active[np.nonzero(active)[0][~(err > stop)]] = False  # on, or given up (NaN)
        return TH

    def newton(self, TH, goals, iters: int, hold=None) -> np.ndarray:
        """Newton steps on the true robot for candidate rows TH toward their goals (free joints held)."""
        return _rt.polish(TH, goals, twists=self.twists, home=self.home, A=self.A, b=self.B,
                          independent=self.vary, target=self.solve_target, iters=iters,
                          hold=self.free if hold is None else hold)
