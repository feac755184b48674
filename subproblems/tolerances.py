"""Every tolerance of the solvers, the runtime and the compiler, in one place (docs/design.md section 10).

The policy
----------

Two kinds of number decide things here, and each constant below says which it is.

* **Relative** ones are lengths divided by a size: the robot's size (``Chain.scale``, the module's
  ``SCALE``) for the compiler and the generated module, the instance's own size (``problem_scale``:
  ``max(1, the largest point or offset)``) inside a subproblem solver.  A relative tolerance is
  multiplied by its size where it is used, so a robot drawn in millimetres or in metres gets the same
  answers.  Joint distances are radians for revolute joints and lengths over the size for prismatic
  ones.
* **Absolute** ones are angles (radians, rotation residuals), ratios without units (singular values
  over the largest one, cosines, cross products of unit vectors) or floating-point guards.

Three of them are contracts, read by the tests and the documentation:

* :data:`PRECISION` (1e-12): every exact row a generated module returns meets its target to this times
  the robot's size (position; rotation by the Frobenius norm times the size): the finish's Newton steps
  bring it there (docs/finish.md).
* :data:`EXACT` (1e-9): the structural tolerance.  An axis relation (parallel, intersecting, ...) that
  holds to it is a fact of the robot; a subproblem solution whose residual is within it (times the
  instance's size) is exact; a module row whose error exceeds it is wrong (docs/design.md section 9).
* :data:`SNAP` (1e-3): a relation that holds only to this is snapped: the plan is built as if it held
  and every solution is corrected on the true robot (docs/design.md section 5).

Everything else is an internal threshold of one algorithm or a numerical guard, named by what it
decides; the comment above each says why it has its value.  A solver's thresholds are relative to the
instance's size unless the comment says radians or a ratio.  Iteration counts and step sizes are not
tolerances: they stay beside their algorithm.  The values are the ones each module carried before it
imported them from here; this module only gathers them (no value changed).

This module needs nothing but the standard library: ``subproblems`` stays usable without
``ikcompiler``, and ``ikcompiler`` imports its numbers from here.
"""

from __future__ import annotations

import sys

# ------------------------------------------------------------------------------------------- contract

#: The precision contract: exact rows meet the target to this times the robot's size.
PRECISION = 1e-12
#: The structural tolerance: exact relations, exact solutions (times the size), wrong rows beyond it.
EXACT = 1e-9
#: A relation that holds to this (times the size, or radians) but not to EXACT is snapped and corrected.
SNAP = 1e-3
#: A 6-joint pose chain whose snap moved its geometry by more than this (an axis direction in radians, an
#: axis point over the size: ``geometry.snap.snap_move``) is solved as the general robot it is, by the
#: elimination, not by the snapped closed form and continuation.  Measured (docs/calibrated.md,
#: "Policy", session 14): from 1e-5 up the snapped path hands 10-60% of the poses to the Python
#: continuation (p90 80-190 ms a pose on ur5 and panda) where the elimination takes 0.05-0.8 ms (p90
#: 0.06-0.9 ms), both recovering every sampled pose; below it the snapped closed form's tail is the
#: smaller one on puma560 (p90 0.05-0.13 ms against 11-16 ms), the elimination's pencil nearly singular.
SNAP_GENERAL = 1e-5

# ------------------------------------------------------------------------------------ numerical guards

#: Floor of a divisor or a scale (an all-zero instance must not get a zero tolerance).
TINY = 1e-300
#: One unit of roundoff of a double.
EPS = sys.float_info.epsilon

# ---------------------------------------------------------------------------------------- twists, input

#: A twist whose axis part is shorter than this has no rotation: a prismatic joint (absolute).
ZERO_AXIS = 1e-12
#: A twist's axis (revolute) or direction (prismatic) must be a unit vector to this, and ``v . w`` of a
#: revolute twist zero to this: inputs that are not twists are refused (absolute).
TWIST_UNIT = 1e-9

#: Robot files: a 4x4 matrix must be rigid to this (``rigid_residual``; write rpy for rounded data).
INPUT_RIGID = 1e-9
#: Robot files: an rpy angle within this (relative) of a multiple of 90 degrees is one (exact cos/sin).
INPUT_RIGHT_ANGLE = 1e-15
#: URDF: an axis whose length differs from 1 by more than this is normalised with a note.
INPUT_UNIT_NOTE = 1e-12
#: URDF mimic joints: a multiplier within this of +-1 can stand for its master; a follower's limits
#: contain the master's when they do to this.
INPUT_MIMIC = 1e-12
#: Folded slides (``ikcompiler/model/fold.py``): a run of slides driven by one master whose summed
#: direction ``sum a_i v_i`` (multipliers times unit vectors, absolute) is shorter than this cancels out
#: and is not folded (the master would move nothing there).
FOLD_SPEED = 1e-9

# -------------------------------------------------------------------------- class I (S1-*), _class1.py

#: Candidates with a residual below this (relative) are polished before the exactness check.
S1_POLISH = 1e-6
#: Two exact solutions closer than this (angles modulo 2 pi; prismatic values relative) are one.
S1_SAME_SOLUTION = 1e-6
#: Relative singular value under which prismatic directions count as dependent.
S1_DEPENDENT_SLIDES = 1e-9
#: Revolute axes parallel within this (``|w_i x w_j|``) also get candidates from the parallel geometry;
#: the batch path leaves them, and prismatic directions this close to dependent, to the scalar one.
S1_NEAR_PARALLEL = 1e-6
#: Those candidates are polished when their residual is below this (relative).
S1_NEAR_POLISH = 1e-3
#: Roots of a family's trigonometric polynomial at most this far apart (radians) may be one double root,
S1_DOUBLE_ROOT_SPAN = 1e-5
#: merged when the polynomial at their midpoint is within this many ulps of its coefficients' size.
S1_DOUBLE_ROOT_ULPS = 64.0

# ------------------------------------------------------------------------- class II (S2-*), _class2.py

#: Two exact solutions closer than this (angles modulo 2 pi; prismatic values relative) are one.
S2_SAME_SOLUTION = 1e-6
#: A point closer than this (relative) to a revolute axis does not determine the joint angle.
S2_POINT_ON_AXIS = 1e-10
#: After polishing, a solution whose point on a revolute joint is this close (relative) to the joint's
#: axis leaves that angle undetermined at the EXACT level (near a double root the polished point may
#: stay ~sqrt(eps) off the axis): the instance is flagged continuum.
S2_POLISHED_POINT_ON_AXIS = 10 * EXACT
#: Two exact rows closer than this are the same root found twice (not averaged into a cluster).
S2_SAME_ROOT = 1e-12
#: Relative size under which an eliminant coefficient counts as zero.
S2_ZERO_COEFFICIENT = 1e-12
#: Candidates whose residual is at most this times the problem scale are not polished: the closed
#: forms and eigenvalue roots normally land there, and Gauss-Newton would not change them.
S2_NO_POLISH = 1e-14
#: Two exact rows closer than S2_TANGENT are one (multiple) root when their polished midpoint
#: satisfies the equation to this times the problem scale, and to S2_TANGENT_SPREAD times the larger
#: of the two rows' own residuals (at least one eps of the scale): see ``_class2.merge_tangent``.
S2_TANGENT_MERGE = 1e-12
#: ... Between two distinct roots d apart the residual is ~curvature x (d/2)^2: at a fold with roots
#: 4.3e-6 rad apart (shadow_thumb position+direction, q5 = +-2.1e-6, limits [0, pi/2]) that is 3.5e-13
#: of the scale, below S2_TANGENT_MERGE, and the merged row at q5 = 0 lost the in-limit root.  A split
#: multiple root's midpoint is as exact as its members (the spread is eps^(1/k) by construction).
S2_TANGENT_SPREAD = 100.0
#: Candidates whose residual exceeds this times the problem scale are polished only when no candidate
#: of the instance is exact (to find the best least-squares answer): from that far, a few
#: Gauss-Newton steps do not reach a solution the construction missed.
S2_FAR = 1e-2
#: Two exact rows closer than this (joint distance) whose midpoint is exact to S2_TANGENT_MERGE are one
#: (tangent) solution: see ``_class2.merge_tangent``.
S2_TANGENT = 1e-3
#: An exact row whose point on a revolute joint is this close (relative) to the joint's axis, but not
#: within S2_POLISHED_POINT_ON_AXIS, is tested for a nearby exact row with the point on the axis: at a
#: singular configuration the roots are located only to ~sqrt(eps), and a free joint can hide there.
S2_NEAR_POINT_ON_AXIS = 1e-4
#: An exact row whose Jacobian, columns scaled to unit length, has a singular value below this is
#: probed for a curve of solutions through it: see ``_class2.on_continuum_rows``.
S2_SINGULAR = 1e-8
#: Least-squares refinement: Newton steps on the squared residual until a step is below this (radians;
#: prismatic values relative).
S2_LS_STEP = 1e-13
#: Two least-squares rows whose residuals differ by at most this times the scale are equally good: the
#: lexicographically smaller one is returned (symmetric minima), so the answer does not depend on
#: which path found which minimiser first.
S2_LS_TIE = 1e-12
#: An exact row is uncertain when its residual exceeds this times the scale (well-posed roots polish
#: to ~1e-15: a larger residual means a valley of near-solutions, nearly degenerate geometry) ...
S2_UNCERTAIN_RESIDUAL = 1e-12
#: ... or when its Jacobian, columns scaled to unit length, has a singular value below this (a
#: multiple root or a continuum, located only to ~sqrt(eps)).  The two paths' constructions then
#: return different rows (each within EXACT), so both paths answer with the union of both.
S2_UNCERTAIN_SINGULAR = 1e-6
#: S2-RR: axes whose direction cross product is below this are parallel (the planar construction).
S2_RR_PARALLEL = 1e-12
#: S2-RR: axes whose direction cross product is below this also get the parallel (planar) candidates.
S2_RR_NEAR_PARALLEL = 1e-6
#: S2-RRR / S2-RTR: relative singular value under which the linear system is rank deficient.
S2_RRR_RANK = 1e-9
#: S2-RRT / S2-TRR: below this ``|w_2 . v|`` the roots of the axial condition join the eliminant's.
S2_RRT_AXIAL = 1e-8
#: S2-TT: relative singular value under which the two directions are dependent.
S2_TT_RANK = 1e-10

# ------------------------------------------------------------------------ class III (S3-*), _class3.py

#: Relative size of ``r - |C|`` under which the two roots of ``A cos + B sin = C`` are one.
S3_TANGENT = 1e-13
#: Relative size of ``r = hypot(A, B)`` under which the angle does not matter (continuum).
S3_FREE_ANGLE = 1e-12

# ----------------------------------------------------- coupled distance pairs (S3 pairs), _class3_pairs.py

#: Two rows closer than this (joint distance) are one solution.
S3P_SAME_SOLUTION = 1e-7
#: ``|F| / reference`` below which the eliminant is identically zero.
S3P_ZERO_ELIMINANT = 1e-10
#: Tensor entries below this times the problem's size are roundoff.
S3P_TENSOR_FLOOR = 1e-13
#: Coefficient size (relative) under which a value is unconstrained.
S3P_FREE_VALUE = 1e-10
#: A distance below this times the scale is a point coincidence (a class II problem).
S3P_ZERO_DISTANCE = 1e-12
#: Engine rows this close to a point-coincidence (d = 0) solution are that solution.
S3P_APEX = 1e-6
#: Stalled candidates missing by less than this, a value acting less (relative), are reseeded.
S3P_RESEED = 1e-4
#: Rows of one multiple root are at most this far apart (angles, relative prismatic values).
S3P_MULTIPLE_ROOT = 1e-3
#: The equations' evaluation roundoff, relative to the problem scale (~eps / 2).
S3P_ROUNDOFF = 1e-16
#: ``|det J| / |J|^2`` under which an exact row may be a tangency split by roundoff.
S3P_FOLD_SINGULAR = 1e-6
#: ``|J| / scale`` under which the Jacobian vanishes at a tangency (both equations stationary).
S3P_FOLD_FLAT = 1e-5
#: Roots of the eliminant closer than this are a cluster: its centre is a root too.
S3P_CLUSTER = 1e-2
#: H-TT: singular values below this times the largest are roundoff (a singular system).
S3P_RANK = 1e-12

# ------------------------------------------------------------------ orientation (O-*), rotation.py

#: Two axes are parallel when ``|w1 x w2|`` is at most this (absolute).
O_PARALLEL = 1e-9
#: Below this ``|w1 x w2|`` the general formulas cannot be evaluated: the parallel branch is forced.
O_DEGENERATE = 1e-15
#: Gimbal lock is tried when ``|w1 x R w3|`` is at most this; it is declared when its representative
#: (``t1 = 0``) is exact.  Closer to gimbal lock than this the isolated solutions are not resolvable.
O_GIMBAL = 1e-6
#: A vector closer than this (relative) to an axis does not determine the angle about it.
O_VECTOR_ON_AXIS = 1e-10
#: Exact solutions closer than this (radians, modulo 2 pi) are one.
O_SAME_SOLUTION = 1e-6
#: Candidates with a residual below this (radians) are polished before the exactness check.
O_POLISH = 1e-5
#: Below this ``|w1 x w2|`` or ``|w2 x w3|`` the general ``O-RRR`` candidates get Gauss-Newton restarts.
O_NEAR_PARALLEL = 1e-6
#: ``O-RRR``: two exact, distinct first candidates with a Jacobian determinant at least this are final.
O_WELL_CONDITIONED = 1e-3
#: ``rho cos(t - psi) = rhs`` with ``|rhs| / rho`` this many ulps from 1 is a double root (a tangency).
O_TANGENT_ULPS = 8.0
#: Residual (radians) under which a tangent point is preferred to other candidates (roundoff floor).
O_TANGENT_FLOOR = 1e-14

# ------------------------------------------------------------- fast kernels and finish, fast.py (and C)

#: Relative size below which a fast kernel's instance is degenerate (point on an axis, coincident
#: axes): it is deferred to the reference runtime.  fast_kernels.h ``IKC_NEAR``.
FAST_DEGENERATE = 1e-7
#: Relative (squared) distance from a double root below which two roots are one tangent root: there
#: roundoff splits the root by up to sqrt(eps), so the reference path polishes and merges them.
#: fast_kernels.h ``IKC_TANGENT``.
FAST_TANGENT = 1e-10
#: Joint distance within which two copies of a tangent root are one solution (``IKC_SPLIT_ROOT``).
FAST_SPLIT_ROOT = 1e-6
#: S2-RRR kernel (fast.point_rrr): |det M| at most this times |M|^2 (M nearly rank 1: axes 2 and 3
#: nearly parallel or meeting) defers to the reference path (``IKC_RRR_REGULAR``).
FAST_RRR_REGULAR = 1e-3
#: S2-RRR kernel: a polished root where the quartic and its derivative are both below this (relative
#: to the coefficients) is (nearly) double: deferred (``IKC_RRR_DOUBLE``).
FAST_RRR_DOUBLE = 1e-6
#: Candidates missing by less than this (relative) need Newton steps (``IKC_NEAR_MISS``).
NEAR_MISS = 1e-4
#: A value within this outside a joint limit is clamped onto it: a double root at a limit is only
#: located to about sqrt(eps) (``IKC_LIMIT_EPS``; also ``select``).
LIMIT_SLACK = 1e-7
#: A revolute value within this above -pi is pi (roundoff of a root at pi) (``IKC_PI_SNAP``).
PI_SNAP = 1e-13

# ------------------------------------------------------------ reference runtime finish, plan_runtime.py

#: Two returned rows closer than this times max(1, the robot's size) are one (``finish``'s default).
DUPLICATE_ROWS = 1e-9
#: Levenberg-Marquardt damping of the finish's Newton steps (on ``J^T J`` with unit columns; absolute).
NEWTON_DAMPING = 1e-12
#: Undamped Newton steps at a singular configuration (the pseudo-inverse of the unit-column Jacobian)
#: leave out the singular values below this times the largest: the damping above halves every step
#: along a direction whose singular value is below its square root (1e-6), so those rows stall just
#: above the precision (docs/design.md section 10, "Newton at a singular configuration").
SINGULAR_CUTOFF = 1e-13

# --------------------------------------------------------------------- continuation (continuation.py)

#: Joint distance (radians / relative length) below which two continued rows are the same solution.
CONTINUATION_SAME_SOLUTION = 1e-6
#: Rescue rows missing by less than this are kept for the caller's check (it polishes them further).
CONTINUATION_NEAR_MISS = 1e-4

# ------------------------------------------------------ generated module runtime (ikcompiler/runtime/)

#: A target rotation orthonormal to this (absolute, ``|R^T R - I|`` and ``|det R - 1|``) is projected
#: onto the nearest rotation; a worse one is an invalid target (as ``fast.goal_entries`` and the C).
TARGET_RIGID = 1e-6
#: Below this defect a target rotation is used as given (no projection).
TARGET_EXACT_ROTATION = 1e-14
#: A pose target's bottom row must be [0, 0, 0, 1] to this (absolute).
TARGET_BOTTOM_ROW = 1e-12
#: Seeds of the search fallback missing the target by more than this times the size are dropped.
SEARCH_SEED_ERROR = 1.0
#: Newton steps stop at this fraction of the exactness threshold (as the C finish): on to well inside
#: the precision contract.
FINISH_MARGIN = 1e-3
#: A self-motion's representative already within this fraction of the exactness threshold takes no
#: more Newton steps toward its family (``Robot.newton_until_exact``).
CONTINUUM_MARGIN = 1e-2


# ------------------------------------------------------------------------- compiler (ikcompiler/)

#: verify: a sampled revolute value (radians) / prismatic value (of the size) counts as recovered.
VERIFY_SAME_ANGLE = 1e-6
VERIFY_SAME_LENGTH = 1e-6
#: verify: a sampled vector whose normalised Jacobian has a singular value below this is singular.
VERIFY_SINGULAR = 1e-7
#: A chain whose size-free Jacobian (tool origin velocity over the size, angular velocity) has fewer
#: singular values above this than it has unknowns, at every sampled configuration, is *near-redundant*:
#: within the snap tolerance of a redundant chain (docs/design.md section 5, "Near-redundant chains").
#: Its rows whose own smallest singular value is below it are flagged representatives of the snapped
#: chain's self-motion.  The snap tolerance itself: the same closeness, judged on the Jacobian.
NEAR_REDUNDANT = SNAP
#: A solved joint whose size-free Jacobian column adds no singular value above this to the columns
#: before it, at every sampled configuration, is *dependent* on them: the chain is redundant exactly (a
#: continuum of solutions at every pose; configs.generic_rank's tolerance).  A chain with dependent
#: joints that no closed form or general 6R elimination covers is refused with the joints to declare
#: free (errors.RedundantChainError; docs/design.md section 5, "Rank-deficient chains").  Far below
#: NEAR_REDUNDANT: a near-redundant chain keeps its plan, its rows flagged.
DEPENDENT_JOINT = 1e-8
#: verify: an exact row whose relative error exceeds this is wrong (the structural tolerance).
VERIFY_WRONG = EXACT
#: The S2-RR step's two axes are parallel when ``|w1 x w2|`` is at most this in every sampled
#: configuration (absolute; ``geometry.facts.step_axes``, the fast kernel's choice) ...
RR_AXES_PARALLEL = EXACT
#: ... they meet when their common normal is at most EXACT times the size and they are farther than
#: this from parallel (absolute) in every configuration (the meeting-axes kernel divides by
#: ``|w1 x w2|``); otherwise they are skew and the reference solver takes them.
RR_AXES_MEET_ANGLE = 1e-6
#: Lines whose normal-equation matrix has a condition number above this are (nearly) all parallel:
#: they have no unique common point (``geometry.relations.lines_meet``; a ratio).
LINES_MEET_CONDITION = 1e8

# ------------------------------------- general 6-joint elimination, general6.py and general6.h (G6_*)

#: A twist whose axis part is shorter than this is a prismatic joint's (general6's own test; absolute).
G6_PRISMATIC_AXIS = 1e-9
#: Eigenvalue candidates whose angle has an imaginary part below this (radians) are kept for Newton
#: (near-real roots; a double root split by rounding).
G6_IMAG_TOL = 2e-3
#: ... and a kept candidate with an imaginary part above this makes its target doubtful (radians).
G6_NEAR_REAL = 1e-9
#: The leading matrix of the pencil is used as is when |det L| / prod(row norms) exceeds this (a ratio).
G6_LEADING_OK = 1e-9
#: B' (the right side's non-constant columns) loses rank below this smallest / largest singular value
#: (a ratio): the target is doubtful.  general6.h ``G6_RANK`` (|R_last / R_first| of its pivoted QR).
G6_RANK = 1e-9
#: A candidate still missing by less than this (of the size) after Newton stalled near a solution (a
#: double root): its target is doubtful (general6.py; general6.h treats every clean candidate that
#: Newton cannot finish as doubtful).
G6_STALLED = 1e-3
#: A column of B' whose largest entry over sample targets is below this times B's largest is
#: structurally absent (a prismatic joint's missing products; a ratio).
G6_ABSENT_COLUMN = 1e-10
#: Singular values of B' below this times the largest are left out of its pseudo-inverse (a ratio).
G6_PINV_CUTOFF = 1e-13
#: Inverse iteration at a root moves it by this (relative): an exact root would make the factorisation
#: singular.
G6_ROOT_SHIFT = 1e-11
#: A pencil whose sampled smallest / largest singular value has a median below this is singular on
#: every target (a ratio): that joint order is refused.
G6_SINGULAR_PENCIL = 1e-10
#: Newton near a double root: singular values of the Jacobian below this times the largest are left
#: out of the truncated least-squares step (a ratio).
G6_PINV_RCOND = 1e-7
#: Candidates left between the precision and G6_STALLED by Newton get up to G6_UNDAMPED_STEPS plain
#: (undamped) Gauss-Newton steps, singular values of the Jacobian below G6_UNDAMPED_RCOND times the
#: largest left out (general6.py ``_undamped``; a near-double root; a ratio and a count).
G6_UNDAMPED_RCOND = 1e-13
G6_UNDAMPED_STEPS = 30
# The native path (general6.h) adds: G6_COEF_CHECK (1e-7: |coefficients 9, 10| of det M(th) over its
# largest, which must vanish), G6_NEAR_DOUBLE (1e-3 rad: estimated imaginary part of a near-real root
# pair), G6_TOUCH (1e-10: |det| at a minimum over the largest coefficient), G6_NOISE (32: det's error
# bound over the largest of its coefficients 9, 10, which must vanish; |det| within it at an isolation
# cell's middle), G6_CLOSE (1e-7 rad: two real roots), G6_COLLIDE (1e-4: two candidates after Newton,
# joint distance), G6_CLEAN (1e-6 of the size: a candidate this close before Newton is a clean root),
# G6_HMIN (1e-9 rad: the narrowest isolation cell): each makes a target doubtful (handed to general6.py).
# G6_CLOSE was 1e-5 until session 18: a nearly structured arm (xarm7.urdf, axes 4e-6..1e-5 rad off
# intersecting) has pairs of solutions that nearly share the eliminated joint (4e-7..1e-5 rad apart),
# each certified by its own sign change and read from its own null vector; at 1e-5 nearly every target
# was doubtful under every arrangement and took the eigenvalue path (C call median 4.7 ms -> 0.11 ms).
# Two roots that are one solution still meet after Newton (G6_COLLIDE) and make the target doubtful.
G6_COEF_CHECK = 1e-7
G6_NEAR_DOUBLE = 1e-3
G6_TOUCH = 1e-10
G6_NOISE = 32.0
G6_CLOSE = 1e-7
G6_COLLIDE = 1e-4
G6_CLEAN = 1e-6
G6_HMIN = 1e-9
