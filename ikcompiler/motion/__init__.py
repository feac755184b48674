"""Using the solutions (issue 13): Cartesian paths that keep one IK branch, and joint trajectories.

``follow(module, poses, q_start)`` tracks a sequence of tool poses with one continuous joint path and
reports where it cannot (docs/motion.md); ``straight_line`` builds the poses of a straight segment;
``quintic``, ``trapezoid``, ``via_points`` and ``time_path`` make timed joint trajectories.  Selection
among the solutions of one pose (aliases, nearest to a seed) lives in the generated modules' ``solve``
and ``nearest`` (runtime: ``subproblems/select.py``).
"""

from ikcompiler.motion.path import Event, Path, follow
from ikcompiler.motion.poses import interpolate, pose_from_xyzrpy, straight_line
from ikcompiler.motion.trajectory import Trajectory, quintic, time_path, trapezoid, via_points

__all__ = ["Event", "Path", "follow", "interpolate", "pose_from_xyzrpy", "straight_line", "Trajectory",
           "quintic", "trapezoid", "via_points", "time_path"]
