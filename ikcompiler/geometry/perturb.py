"""Calibrated robots for tests and benchmarks: a chain whose axes are tilted and shifted a little.

A real, calibrated robot misses its design relations (parallel axes, wrist axes meeting in a point) by
a small fraction of its size.  :func:`perturb_chain` makes such a robot from an ideal one with a fixed
seed, so that completeness on calibrated robots can be measured and tested (docs/calibrated.md).
"""

from __future__ import annotations

import numpy as np

from ikcompiler.model import Chain, Joint
from subproblems.screw import prismatic_twist, revolute_twist


def perturb_chain(chain: Chain, eps: float, seed: int = 0) -> Chain:
    """The chain with every axis direction tilted by about ``eps`` rad and every revolute axis point
    moved by about ``eps`` of the robot's size (independent normal draws per component, fixed seed).

    Joint names, limits, home pose and couplings are kept.

    >>> from ikcompiler import load_robot
    >>> arm = load_robot("ur5")
    >>> bent = perturb_chain(arm, 1e-4, seed=1)
    >>> 1e-5 < float(np.abs(bent.twists - arm.twists).max()) < 1e-2
    True
    """
    rng = np.random.default_rng(seed)
    joints = []
    for j in chain.joints:
        w = j.axis + eps * rng.normal(size=3)
        shift = eps * chain.scale * rng.normal(size=3)
        if j.kind == "R":
            tw = revolute_twist(w, j.point + shift)
        else:
            tw = prismatic_twist(w)
        joints.append(Joint(j.name, j.kind, tw, j.lower, j.upper))
    return Chain(f"{chain.name} (perturbed {eps:g}, seed {seed})", tuple(joints), chain.home, chain.couplings)


__all__ = ["perturb_chain"]
