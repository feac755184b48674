"""Multi-finger manipulation with rolling contacts (seed 002): contact kinematics, hand-object equations,
the trajectory algorithm.  See docs/hands.md; ``ikc manipulate SPEC.toml`` is the command."""

from ikcompiler.hands.fingers import Finger, planar_finger
from ikcompiler.hands.grasp import JointObject, analyse
from ikcompiler.hands.spec import ManipulationSpec, load_manipulation
from ikcompiler.hands.surfaces import (
    Circle,
    ContactError,
    Cylinder,
    Ellipsoid,
    Line,
    Plane,
    Sphere,
    local_geometry,
)
from ikcompiler.hands.system import HandSystem
from ikcompiler.hands.trajectory import EqualObjectSpeeds, FixedObjectContacts, Trajectory, manipulate

__all__ = [
    "Circle",
    "ContactError",
    "Cylinder",
    "Ellipsoid",
    "EqualObjectSpeeds",
    "Finger",
    "FixedObjectContacts",
    "HandSystem",
    "JointObject",
    "Line",
    "ManipulationSpec",
    "Plane",
    "Sphere",
    "Trajectory",
    "analyse",
    "load_manipulation",
    "local_geometry",
    "manipulate",
    "planar_finger",
]
