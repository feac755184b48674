/* The end of a generated chain in C: the port of subproblems.fast.finish_one and goal_entries, Newton
 * steps on the true robot (plan_runtime.polish), the search fallback over a grid, and the driver that
 * runs a chain over N poses in a few threads.
 *
 * A generated chain (ikcompiler/codegen/csource.py) defines `ikc_chain`, which writes every leaf of
 * its loop nest (joint values, pose error, flag bits), and an `ikc_robot` with the module's settings;
 * the entry points it exports call the functions below.  A target this code cannot settle alone (a
 * leaf flagged DEFER, NaN, a self-motion none of whose representatives can be completed inside the
 * limits and that is no straight line alone in joint space) returns IKC_PYTHON: the Python module then
 * runs its own path for that target.  The specification of this finish is subproblems/settle.py (the
 * same statements in Python; tests/test_finish_spec.py holds the two to the same rows bit for bit):
 * a change here is made there too (docs/design.md section 6). */
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>

/* The Newton kernels (FK + Jacobian, the linear solve, the steps) are written once for any dof and
 * inlined into a copy for 6 joints without mimic joints, the common arm: with the sizes constant the
 * compiler unrolls the loops (kinova, whose every leaf takes Newton steps: 139k -> 112k instructions a
 * batch pose), and with -ffp-contract=off and no reassociation the copy rounds as the generic code
 * does (benchmarks/batch_sets.py: bit for bit). */
#if defined(__GNUC__)
#define IKC_INLINE static inline __attribute__((always_inline))
#else
#define IKC_INLINE static inline
#endif

#define IKC_NEAR_MISS 1e-4  /* relative miss below which a candidate gets Newton steps */
#define IKC_SPLIT_ROOT 1e-6 /* copies of a tangent root closer than this are one solution */
#define IKC_TWO_PI 6.283185307179586
#define IKC_PI_F 3.141592653589793

/* max of two errors and the largest |x| of n: NaN wins (it sends the target to the Python path) */
static double ikc_max2(double a, double b) {
    if (a != a || b != b) return NAN;
    return a > b ? a : b;
}

static double ikc_maxabs(int n, const double *x) {
    double m = 0.0;
    for (int i = 0; i < n; i++) {
        if (x[i] != x[i]) return NAN;
        if (fabs(x[i]) > m) m = fabs(x[i]);
    }
    return m;
}

typedef int (*ikc_chain_fn)(const double *goal, const double *fr, double rep, double *Q, double *E, int *F);

#define IKC_PYTHON (-1)       /* the Python path takes this target */
#define IKC_INVALID (-2)      /* not a finite rigid transform: the Python path raises the error */
#define IKC_FAMILY_MISS (-3)  /* a self-motion whose representatives all miss: try others */
#define IKC_REPS 16           /* representatives tried: rep = k pi / 8, k = 1 .. 8 and -1 .. -7 */

/* Why the last target this thread handed back (IKC_PYTHON) was handed back: one of IKC_WHY_*, of the
 * main chain and (times IKC_WHY_ALT) of the alternative chain; 0 when it was settled.  Read by
 * benchmarks/special_poses.py through ikc_last_reason (docs/design.md section 6). */
#define IKC_WHY_DEFER 1       /* a leaf near a degenerate geometry (DEFER) */
#define IKC_WHY_NAN 2         /* a leaf's values or error NaN, or NaN after Newton steps */
#define IKC_WHY_CLAMPED 3     /* a value clamped onto a limit */
#define IKC_WHY_REPS 4        /* the chain's leaf count changed with the representative */
#define IKC_WHY_FAMILY 5      /* a self-motion with no exact representative inside the limits */
#define IKC_WHY_ROTATION 6    /* a target rotation orthonormal only to 1e-6 */
#define IKC_WHY_SEARCH 7      /* the search fallback could not run or finish */
#define IKC_WHY_SNAPPED 8     /* a snapped plan's correction is not certain */
#define IKC_WHY_LOCK 9        /* an S2-RR lock (IKC_LOCK) whose representatives are not shown a line */
#define IKC_WHY_ALT 16
static __thread int ikc_why;

static int ikc_last_reason(void) { return ikc_why; }

static int ikc_hand_back(int why) {
    ikc_why = why;
    return IKC_PYTHON;
}

typedef struct {
    int dof, nfree, leaves, slots;
    int target;  /* 0 pose, 1 position, 2 orientation */
    const int *revolute;
    const double *lower, *upper;
    double scale, tol;
    ikc_chain_fn chain;
    /* the true robot, for Newton steps: all joints = A q + b (mimic joints), their twists (v, w), the
     * home pose (rotation row-major, translation), and which of the dof returned joints are free */
    int nall;
    const double *twists, *home, *A, *b;
    const int *is_free;
    /* search plans: the chain takes the searched joints' values after the free ones (fr), gridded
     * over `grid` values per searched joint in [-pi, pi); 0 searched joints for a closed form */
    int nsearch, grid;
    /* snapped plans (a calibrated robot): the chain runs on the snapped robot and every leaf gets
     * this many Newton steps on the true robot before the finish; 0 otherwise */
    int polish;
    /* the plan's alternative chain (NULL if none), for targets where the chain above meets a
     * degenerate geometry it cannot settle: it solves the joints in another order */
    ikc_chain_fn chain_alt;
    int leaves_alt;
    /* snapped plans: a corrected leaf whose weakest singular value (subproblems.continuation
     * near_singular) is below this, or a least-squares leaf missing by less than this times the
     * scale, hands the target to the Python continuation */
    double near_singular;
} ikc_robot;

/* Tool pose G (12 entries) and space Jacobian J (6 x dof, row-major: tool-point velocity, then
 * angular) of the true robot at returned joint values q: the C port of subproblems/newton.py tool_jacobian.
 * J NULL: the pose alone (the same arithmetic for G, the Jacobian's columns skipped: a measure). */
IKC_INLINE void ikc_fk_jacobian_n(const ikc_robot *rb, const double *q, double *G, double *J, const int dof,
                                  const int nall, const int plain) {
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, p[3] = {0, 0, 0};
    double cols[nall > 0 ? nall : 1][6];
    for (int i = 0; i < nall; i++) {
        double th = rb->b[i];
        if (plain)  /* A the identity: the same sum for finite q, its zero products left out */
            th += q[i];
        else
            for (int j = 0; j < dof; j++) th += rb->A[i * dof + j] * q[j];
        const double *v = rb->twists + 6 * i, *w = v + 3;
        if (J) {  /* this joint's space twist at q: its Jacobian column before the tool-point shift */
            double Rw[3], Rv[3];
            for (int r = 0; r < 3; r++) {
                Rw[r] = R[3 * r] * w[0] + R[3 * r + 1] * w[1] + R[3 * r + 2] * w[2];
                Rv[r] = R[3 * r] * v[0] + R[3 * r + 1] * v[1] + R[3 * r + 2] * v[2];
            }
            double pxw[3] = {p[1] * Rw[2] - p[2] * Rw[1], p[2] * Rw[0] - p[0] * Rw[2],
                             p[0] * Rw[1] - p[1] * Rw[0]};
            for (int r = 0; r < 3; r++) {
                cols[i][r] = Rv[r] + pxw[r];
                cols[i][3 + r] = Rw[r];
            }
        }
        /* this joint's motion exp(xi th) as (E, t) */
        double E[9], t[3];
        if (w[0] == 0.0 && w[1] == 0.0 && w[2] == 0.0) {
            for (int k = 0; k < 9; k++) E[k] = (k % 4 == 0) ? 1.0 : 0.0;
            for (int k = 0; k < 3; k++) t[k] = v[k] * th;
        } else {
            double c = cos(th), s = sin(th), C = 1.0 - c;
            E[0] = c + w[0] * w[0] * C;        E[1] = w[0] * w[1] * C - w[2] * s; E[2] = w[0] * w[2] * C + w[1] * s;
            E[3] = w[1] * w[0] * C + w[2] * s; E[4] = c + w[1] * w[1] * C;        E[5] = w[1] * w[2] * C - w[0] * s;
            E[6] = w[2] * w[0] * C - w[1] * s; E[7] = w[2] * w[1] * C + w[0] * s; E[8] = c + w[2] * w[2] * C;
            double wv[3] = {w[1] * v[2] - w[2] * v[1], w[2] * v[0] - w[0] * v[2], w[0] * v[1] - w[1] * v[0]};
            double wdv = w[0] * v[0] + w[1] * v[1] + w[2] * v[2];
            for (int k = 0; k < 3; k++) {
                double Ewv = E[3 * k] * wv[0] + E[3 * k + 1] * wv[1] + E[3 * k + 2] * wv[2];
                t[k] = wv[k] - Ewv + w[k] * wdv * th;
            }
        }
        double R2[9], p2[3];
        for (int r = 0; r < 3; r++) {
            for (int k = 0; k < 3; k++)
                R2[3 * r + k] = R[3 * r] * E[k] + R[3 * r + 1] * E[3 + k] + R[3 * r + 2] * E[6 + k];
            p2[r] = R[3 * r] * t[0] + R[3 * r + 1] * t[1] + R[3 * r + 2] * t[2] + p[r];
        }
        for (int k = 0; k < 9; k++) R[k] = R2[k];
        for (int k = 0; k < 3; k++) p[k] = p2[k];
    }
    const double *H = rb->home;
    for (int r = 0; r < 3; r++) {
        for (int k = 0; k < 3; k++) G[3 * r + k] = R[3 * r] * H[k] + R[3 * r + 1] * H[3 + k] + R[3 * r + 2] * H[6 + k];
        G[9 + r] = R[3 * r] * H[9] + R[3 * r + 1] * H[10] + R[3 * r + 2] * H[11] + p[r];
    }
    if (!J) return;
    const double *tp = G + 9;
    for (int j = 0; j < dof; j++) {
        double col[6] = {0, 0, 0, 0, 0, 0};
        for (int i = 0; i < nall; i++) {
            double a = plain ? (i == j ? 1.0 : 0.0) : rb->A[i * dof + j];
            if (a == 0.0) continue;
            const double *c = cols[i];
            double wxp[3] = {c[4] * tp[2] - c[5] * tp[1], c[5] * tp[0] - c[3] * tp[2], c[3] * tp[1] - c[4] * tp[0]};
            for (int r = 0; r < 3; r++) {
                col[r] += a * (c[r] + wxp[r]);
                col[3 + r] += a * c[3 + r];
            }
        }
        for (int r = 0; r < 6; r++) J[r * dof + j] = col[r];
    }
}

/* Whether the true robot's joints are the returned ones (A the identity, b any): no mimic joint. */
static int ikc_plain_joints(const ikc_robot *rb) {
    if (rb->nall != rb->dof) return 0;
    for (int i = 0; i < rb->nall; i++)
        for (int j = 0; j < rb->dof; j++)
            if (rb->A[i * rb->dof + j] != (i == j ? 1.0 : 0.0)) return 0;
    return 1;
}

#define IKC_PLAIN6(rb) ((rb)->dof == 6 && ikc_plain_joints(rb))

static void ikc_fk_jacobian(const ikc_robot *rb, const double *q, double *G, double *J) {
    if (IKC_PLAIN6(rb))
        ikc_fk_jacobian_n(rb, q, G, J, 6, 6, 1);
    else
        ikc_fk_jacobian_n(rb, q, G, J, rb->dof, rb->nall, 0);
}

/* The chain's pose error of tool pose G against goal g: max(|dp|, scale |dR|_F) for a pose (the
 * precision contract: Frobenius norm of the rotation error, as plan_runtime.pose_error). */
static double ikc_pose_error(const ikc_robot *rb, const double *G, const double *g) {
    double dp = 0.0, dr = 0.0;
    for (int k = 0; k < 3; k++) dp += (G[9 + k] - g[9 + k]) * (G[9 + k] - g[9 + k]);
    dp = sqrt(dp);
    for (int k = 0; k < 9; k++) {
        double d = G[k] - g[k];
        if (d != d) return NAN;
        dr += d * d;
    }
    dr = rb->scale * sqrt(dr);
    if (rb->target == 1) return dp;
    if (rb->target == 2) return dr;
    return ikc_max2(dp, dr);
}

/* Solve the n x n system M x = M[:, n] by Gaussian elimination with partial pivoting; 0 if singular. */
IKC_INLINE int ikc_solve_linear_n(const int n, double M[n][n + 1], double *x) {
    for (int k = 0; k < n; k++) {
        int piv = k;
        for (int r = k + 1; r < n; r++)
            if (fabs(M[r][k]) > fabs(M[piv][k])) piv = r;
        if (piv != k)
            for (int c = k; c <= n; c++) {
                double tmp = M[k][c];
                M[k][c] = M[piv][c];
                M[piv][c] = tmp;
            }
        if (M[k][k] == 0.0) return 0;
        for (int r = k + 1; r < n; r++) {
            double f = M[r][k] / M[k][k];
            for (int c = k; c <= n; c++) M[r][c] -= f * M[k][c];
        }
    }
    for (int k = n - 1; k >= 0; k--) {
        double s = M[k][n];
        for (int c = k + 1; c < n; c++) s -= M[k][c] * x[c];
        x[k] = s / M[k][k];
    }
    return 1;
}

static int ikc_solve_linear(int n, double M[n][n + 1], double *x) { return ikc_solve_linear_n(n, M, x); }

/* Damped Gauss-Newton steps on the returned joints (free joints held) toward goal g, as
 * plan_runtime.polish (columns scaled to unit norm, 1e-12 damping), except that a step which does
 * not lower the error is retried with 100x the damping (Levenberg-Marquardt; up to 8 tries) when
 * `guarded`: at a doubly singular configuration the plain step runs off along the null directions.
 * Unguarded, every step is taken (far seeds of the search may need to climb before they descend).  At most `iters`
 * steps, fewer once the error is far inside the exact tolerance, or once a guarded step ends inside
 * IKC_SETTLED of it without halving the error (Newton's linear regime at a singular configuration: a
 * stretched arm's double root, kinova's q3 = pi leaves, took all 15 steps at ~0.92 each).  Returns the new
 * pose error.  A trial is measured by its pose alone; the Jacobian is computed where a next step needs it. */
#define IKC_SETTLED 0.5
IKC_INLINE double ikc_newton_steps_n(const ikc_robot *rb, const double *g, double *q, int iters, int guarded,
                                    const int *held, const int dof, const int nall, const int plain) {
    const double done = 1e-3 * rb->tol * rb->scale;  /* converged to well inside the exact tolerance */
    const double exact = rb->tol * rb->scale;
    int slow = 0;  /* the last step, inside IKC_SETTLED of the tolerance, did not halve the error */
    double G[12], J[6 * dof], trial[dof], G2[12];
    double lambda = 1e-12;  /* damping: raised when a step makes things worse (Levenberg-Marquardt) */
    ikc_fk_jacobian_n(rb, q, G, J, dof, nall, plain);
    double now = ikc_pose_error(rb, G, g);
    int stale = 0;  /* J is of an earlier point: a trial is measured by its pose alone (most end the loop) */
    for (int it = 0; it < iters; it++) {
        if (now != now) return NAN;
        if (now <= done) return now;
        if (stale) ikc_fk_jacobian_n(rb, q, G, J, dof, nall, plain);  /* the same G, and J at the accepted point */
        stale = 0;
        double e[6];
        for (int k = 0; k < 3; k++) e[k] = g[9 + k] - G[9 + k];
        for (int k = 0; k < 3; k++) e[3 + k] = 0.0;
        for (int c = 0; c < 3; c++) {  /* 0.5 sum over columns of R_c x Rd_c */
            double a0 = G[c], a1 = G[3 + c], a2 = G[6 + c], b0 = g[c], b1 = g[3 + c], b2 = g[6 + c];
            e[3] += 0.5 * (a1 * b2 - a2 * b1);
            e[4] += 0.5 * (a2 * b0 - a0 * b2);
            e[5] += 0.5 * (a0 * b1 - a1 * b0);
        }
        int r0 = rb->target == 2 ? 3 : 0, r1 = rb->target == 1 ? 3 : 6;
        double col[dof], Js[6 * dof], JtJ[dof][dof], Jte[dof];
        for (int j = 0; j < dof; j++) {  /* scale the columns to unit norm; free joints' columns to 0 */
            double s = 0.0;
            for (int r = r0; r < r1; r++) s += J[r * dof + j] * J[r * dof + j];
            col[j] = sqrt(s) > 1e-300 ? sqrt(s) : 1e-300;
            const int hold = rb->is_free[j] || (held && held[j]);
            for (int r = r0; r < r1; r++) Js[r * dof + j] = hold ? 0.0 : J[r * dof + j] / col[j];
        }
        for (int a = 0; a < dof; a++) {
            for (int c = 0; c <= a; c++) {  /* symmetric: the same products, summed in the same order */
                double s = 0.0;
                for (int r = r0; r < r1; r++) s += Js[r * dof + a] * Js[r * dof + c];
                JtJ[a][c] = JtJ[c][a] = s;
            }
            double s = 0.0;
            for (int r = r0; r < r1; r++) s += Js[r * dof + a] * e[r];
            Jte[a] = s;
        }
        int accepted = 0;
        for (int attempt = 0; attempt < 8 && !accepted; attempt++) {
            double M[dof][dof + 1], dq[dof];
            for (int a = 0; a < dof; a++) {
                for (int c = 0; c < dof; c++) M[a][c] = JtJ[a][c] + (a == c ? lambda : 0.0);
                M[a][dof] = Jte[a];
            }
            if (!ikc_solve_linear_n(dof, M, dq)) return now;
            for (int j = 0; j < dof; j++)
                trial[j] = q[j] + ((rb->is_free[j] || (held && held[j])) ? 0.0 : dq[j] / col[j]);
            ikc_fk_jacobian_n(rb, trial, G2, NULL, dof, nall, plain);
            double next = ikc_pose_error(rb, G2, g);
            if (next < now || !guarded) {  /* accept; trust the linear model more next time */
                for (int j = 0; j < dof; j++) q[j] = trial[j];
                for (int k = 0; k < 12; k++) G[k] = G2[k];
                stale = 1;
                slow = guarded && next <= IKC_SETTLED * exact && next > 0.5 * now;
                now = next;
                lambda = lambda > 1e-11 ? lambda * 0.1 : 1e-12;
                accepted = 1;
            } else {  /* reject: a shorter, more gradient-like step */
                lambda *= 100.0;
            }
        }
        if (!accepted || slow) break;
    }
    return now;
}

static double ikc_newton_steps(const ikc_robot *rb, const double *g, double *q, int iters, int guarded,
                               const int *held) {
    if (IKC_PLAIN6(rb)) return ikc_newton_steps_n(rb, g, q, iters, guarded, held, 6, 6, 1);
    return ikc_newton_steps_n(rb, g, q, iters, guarded, held, rb->dof, rb->nall, 0);
}

/* Newton steps that never raise the error (near misses, self-motion representatives). */
static double ikc_newton(const ikc_robot *rb, const double *g, double *q, int iters) {
    return ikc_newton_steps(rb, g, q, iters, 1, NULL);
}

/* ikc_newton once per start: the steps are a function of the start row alone (and of the goal and
 * iters, the same for one memo), so a row starting bit for bit where an earlier row of the memo started
 * takes that row's end and error.  The copies of a self-motion leaf (a lock's two slots, split copies
 * of a root) are equal rows: ur5's wrist-locked targets paid 60 steps for each copy.  Storage for `cap`
 * rows is the caller's (start, end: cap x dof; err: cap). */
typedef struct {
    int n, cap;
    double *start, *end, *err;
} ikc_newton_memo;

static int ikc_same_row(int dof, const double *a, const double *b) {  /* bit for bit (-0.0 is not 0.0) */
    for (int c = 0; c < dof; c++) {
        uint64_t x, y;
        __builtin_memcpy(&x, a + c, sizeof x);
        __builtin_memcpy(&y, b + c, sizeof y);
        if (x != y) return 0;
    }
    return 1;
}

static double ikc_newton_once(const ikc_robot *rb, const double *g, double *q, int iters, ikc_newton_memo *m) {
    const int dof = rb->dof;
    for (int k = 0; k < m->n; k++)
        if (ikc_same_row(dof, m->start + k * dof, q)) {
            for (int c = 0; c < dof; c++) q[c] = m->end[k * dof + c];
            return m->err[k];
        }
    const int k = m->n < m->cap ? m->n++ : -1;
    if (k >= 0)
        for (int c = 0; c < dof; c++) m->start[k * dof + c] = q[c];
    const double e = ikc_newton(rb, g, q, iters);
    if (k >= 0) {
        for (int c = 0; c < dof; c++) m->end[k * dof + c] = q[c];
        m->err[k] = e;
    }
    return e;
}

/* fmod(x, 2 pi), bit for bit, the libm call made only where it is needed: x itself below 2 pi in
 * magnitude (fmod returns it), x -+ 2 pi strictly between 2 pi and 4 pi (fmod's x - 2 pi trunc(x / 2 pi)
 * with a quotient of 1, and the subtraction is exact by Sterbenz's lemma; at -2 pi itself fmod gives
 * -0.0, so the ends take the call).  ur5's q4, a difference of angles, lies in (-3 pi, 3 pi). */
static inline double ikc_fmod_two_pi(double x) {
    const double a = fabs(x);
    if (a < IKC_TWO_PI) return x;
    if (IKC_TWO_PI < a && a < 2.0 * IKC_TWO_PI) return x > 0.0 ? x - IKC_TWO_PI : x + IKC_TWO_PI;
    return fmod(x, IKC_TWO_PI);
}

/* fmod(d, 2 pi) of a distance d >= 0 (or NaN), bit for bit (the finish's duplicate test). */
static inline double ikc_mod_two_pi(double d) { return ikc_fmod_two_pi(d); }

/* subproblems.angles.wrap, bit for bit: x - 2 pi k in (-pi, pi], exact (fmod is exact, and the one
 * subtraction is exact by Sterbenz's lemma). */
static double ikc_wrap(double x) {
    if (-IKC_PI_F < x && x <= IKC_PI_F) return x;
    double r = ikc_fmod_two_pi(x);
    if (r > IKC_PI_F) r -= IKC_TWO_PI;
    else if (r <= -IKC_PI_F) r += IKC_TWO_PI;
    return r;
}

#define IKC_LIMIT_EPS 1e-7  /* fast.LIMIT_EPS: a value this close outside a limit is clamped onto it */
#define IKC_PI_SNAP 1e-13   /* fast.PI_SNAP: a value this close above -pi is pi */
#define IKC_INSIDE 0
#define IKC_ADJUSTED 1      /* a value snapped or clamped: the row's error must be measured again */
#define IKC_OUTSIDE 2
#define IKC_CLAMPED 3       /* a value clamped onto a limit: the other joints need Newton steps */
#define IKC_CLAMPED_NEWTON 3  /* Newton steps with a clamped joint held (reference.clamped_onto_limits) */

/* fast.represent_one: joint values q (in place) as returned -- a revolute value as its representative in
 * (-pi, pi] where that lies inside the limits, else its 2 pi alias inside them -- and the status.
 * Inlined with `dof` a constant where the finish is specialised to 6 joints (ikc_finish), and the robot's
 * arrays read through locals: the stores to q could alias them, so GCC reloaded rb's fields at every
 * joint (docs/design.md section 14, session 18). */
IKC_INLINE int ikc_represent_n(const ikc_robot *rb, double *q, int limits,
                               int *clamped, const int dof) {
    const int *revolute = rb->revolute;
    const double *lower = rb->lower, *upper = rb->upper;
    int status = IKC_INSIDE;
    if (clamped)
        for (int j = 0; j < dof; j++) clamped[j] = 0;
    for (int j = 0; j < dof; j++) {
        double x = q[j];
        const int rev = revolute[j];
        if (rev) {
            x = ikc_wrap(x);
            if (x <= -IKC_PI_F + IKC_PI_SNAP) {
                if (x != -IKC_PI_F && status == IKC_INSIDE) status = IKC_ADJUSTED;
                x = IKC_PI_F;
            }
        }
        const double lo = lower[j], hi = upper[j];
        if (limits && !(lo <= x && x <= hi)) {
            double c[3] = {x, x - IKC_TWO_PI, x + IKC_TWO_PI};
            const int nc = rev ? 3 : 1;
            int found = 0;
            for (int k = 0; k < nc && !found; k++)
                if (lo <= c[k] && c[k] <= hi) x = c[k], found = 1;
            for (int k = 0; k < nc && !found; k++)
                if (lo - IKC_LIMIT_EPS <= c[k] && c[k] <= hi + IKC_LIMIT_EPS) {
                    x = c[k] < lo ? lo : (c[k] > hi ? hi : c[k]);
                    found = 1;
                    status = IKC_CLAMPED;
                    if (clamped) clamped[j] = 1;
                }
            if (!found) return IKC_OUTSIDE;
        }
        q[j] = x;
    }
    return status;
}

static int ikc_represent(const ikc_robot *rb, double *q, int limits, int *clamped) {
    return ikc_represent_n(rb, q, limits, clamped, rb->dof);
}

/* Whether joint values q have a representative inside the limits (q itself unchanged). */
static int ikc_row_inside(const ikc_robot *rb, const double *q) {
    double w[rb->dof];
    for (int j = 0; j < rb->dof; j++) w[j] = q[j];
    return ikc_represent(rb, w, 1, NULL) != IKC_OUTSIDE;
}

/* The pose error of returned joint values q against goal g, measured on the true robot. */
static double ikc_measure(const ikc_robot *rb, const double *g, const double *q) {
    double G[12];
    ikc_fk_jacobian(rb, q, G, NULL);
    return ikc_pose_error(rb, G, g);
}

/* ---- ikc_finish's test of a row ikc_represent keeps as it is, on 6 joints, 4 lanes at a time (joints
 * 0-3, then 4, 5 and two zeros) ----
 * Each lane makes the scalar code's comparisons, so the verdict is the scalar loops' (docs/design.md
 * section 14, session 18); a row it does not pass takes the scalar NaN test and ikc_represent.  (Tried:
 * 8-lane vectors, whose comparisons GCC made scalar branches on AVX2; the duplicate test in lanes,
 * slower than the scalar loop, which mostly stops at the first or second joint.) */
typedef double ikc_f4 __attribute__((vector_size(32)));
typedef int64_t ikc_b4 __attribute__((vector_size(32)));
typedef struct {
    ikc_f4 a, b;  /* joints 0-3; joints 4, 5 and two zeros */
} ikc_row6;
#define IKC_F4(x) ((ikc_f4){(x), (x), (x), (x)})

static inline ikc_row6 ikc_row6_load(const double *w) {
    ikc_row6 r;
    __builtin_memcpy(&r.a, w, sizeof r.a);
    r.b = (ikc_f4){w[4], w[5], 0.0, 0.0};
    return r;
}

static inline int ikc_b4_any(ikc_b4 m) {  /* any lane set (the masks are 0 or -1) */
#if defined(__AVX__) && defined(__GNUC__) && !defined(__clang__)
    return __builtin_ia32_movmskpd256((ikc_f4)m) != 0;
#else
    return ((m[0] | m[1]) | (m[2] | m[3])) != 0;
#endif
}

/* ikc_row6_kept's test on 4 lanes: a NaN, a revolute value outside (-pi + IKC_PI_SNAP, pi], a value
 * outside its limits where they apply */
static inline ikc_b4 ikc_f4_moved(ikc_f4 x, ikc_b4 rev, ikc_f4 lo, ikc_f4 hi, int limits) {
    ikc_b4 bad = (x != x) | (rev & ~((x > IKC_F4(-IKC_PI_F + IKC_PI_SNAP)) & (x <= IKC_F4(IKC_PI_F))));
    if (limits) bad |= ~((lo <= x) & (x <= hi));
    return bad;
}

/* Whether ikc_represent would leave row x as it is with IKC_INSIDE, and x holds no NaN: every revolute
 * value above -pi + IKC_PI_SNAP and at most pi (ikc_wrap keeps it, the snap does not move it), every
 * value inside its limits where they apply.  rev: -1 on the revolute joints (0 on the padding). */
static inline int ikc_row6_kept(ikc_row6 x, const ikc_b4 *rev, const ikc_row6 *lo, const ikc_row6 *hi,
                                int limits) {
    return !ikc_b4_any(ikc_f4_moved(x.a, rev[0], lo->a, hi->a, limits) |
                       ikc_f4_moved(x.b, rev[1], lo->b, hi->b, limits));
}

/* finish_one: solutions of one target (goal g, 12 entries) from its leaves, sorted exact first then
 * by error, duplicates (equal modulo 2 pi) and rows outside the limits left out.  Near misses (a
 * tangent root located to sqrt(eps)) get Newton steps on the true robot first, as the Python batch
 * path gives them.  Returns the count, IKC_PYTHON, or IKC_FAMILY_MISS.  Outputs: q (slots x dof), res,
 * ls (inexact), cont (a representative of a self-motion). */
IKC_INLINE int ikc_finish_n(const ikc_robot *rb, const double *g, int n,
                            const double *Q, const double *E, const int *F,
                            int limits, double *q, double *res, int *ls,
                            int *cont, const int dof) {
    const int *revolute = rb->revolute;
    const double exact_tol = rb->tol * rb->scale, near = IKC_NEAR_MISS * rb->scale;
    double same = 1e-9 * (rb->scale > 1.0 ? rb->scale : 1.0);
    ikc_b4 rev6[2] = {{0, 0, 0, 0}, {0, 0, 0, 0}};  /* the 6-joint row tests' robot: revolute mask, limits */
    ikc_row6 lo6 = {IKC_F4(0.0), IKC_F4(0.0)}, hi6 = lo6;
    if (dof == 6) {
        const int *r = revolute;
        rev6[0] = (ikc_b4){-(int64_t)(r[0] != 0), -(int64_t)(r[1] != 0), -(int64_t)(r[2] != 0), -(int64_t)(r[3] != 0)};
        rev6[1] = (ikc_b4){-(int64_t)(r[4] != 0), -(int64_t)(r[5] != 0), 0, 0};
        lo6 = ikc_row6_load(rb->lower);
        hi6 = ikc_row6_load(rb->upper);
    }
    const int m = n > 0 ? n : 1;
    int rows[m], inexact[m], polished[m];
    double W[m * dof], err[m], P[m * dof], PE[m];
    int count = 0, family_any = 0, family_exact = 0;
    for (int k = 0; k < n; k++) polished[k] = 0;
    for (int k = 0; k < n; k++) {
        int flag = F[k];
        if (flag & IKC_EMPTY) continue;
        err[k] = E[k];
        if (flag & IKC_DEFER) return ikc_hand_back(IKC_WHY_DEFER);
        if (err[k] != err[k]) return ikc_hand_back(IKC_WHY_NAN);
        /* an S2-RR lock: ikc_settle_chain's line test settles it (its leaves read FAMILY there) */
        if (flag & IKC_LOCK) return (flag & IKC_FAMILY) ? IKC_FAMILY_MISS : ikc_hand_back(IKC_WHY_DEFER);
        double *w = W + k * dof;
        for (int j = 0; j < dof; j++) w[j] = Q[k * dof + j];
        if (exact_tol < err[k] && err[k] < near) {
            /* up to 15 steps (they stop once converged): at a double root Newton is only linear; a copy
             * of a leaf polished already (equal values and error: a tangent root's) takes its polish */
            int before = -1;
            for (int b = 0; b < k && before < 0; b++) {
                int equal = polished[b] && E[b] == E[k];
                for (int j = 0; j < dof && equal; j++) equal = Q[b * dof + j] == Q[k * dof + j];
                if (equal) before = b;
            }
            if (before >= 0) {
                for (int j = 0; j < dof; j++) w[j] = P[before * dof + j];
                err[k] = PE[before];
            } else {
                err[k] = ikc_newton(rb, g, w, 15);
            }
            if (err[k] != err[k]) return ikc_hand_back(IKC_WHY_NAN);
            polished[k] = 1;
            for (int j = 0; j < dof; j++) P[k * dof + j] = w[j];
            PE[k] = err[k];
            same = IKC_SPLIT_ROOT;  /* Newton converges only linearly at a double root */
        }
        if (flag & IKC_TANGENT_ROOT) same = IKC_SPLIT_ROOT;
        int held[dof], status = IKC_INSIDE;
        if (!(dof == 6 && ikc_row6_kept(ikc_row6_load(w), rev6, &lo6, &hi6, limits))) {
            for (int j = 0; j < dof; j++)
                if (w[j] != w[j]) return ikc_hand_back(IKC_WHY_NAN);
            status = ikc_represent_n(rb, w, limits, held, dof);
        }
        const int was_exact = err[k] <= exact_tol, clamped = status == IKC_CLAMPED;
        if (clamped) {
            /* a value clamped onto its limit (a root at a limit, located to roundoff): Newton steps on
             * the other joints with it held, as reference.clamped_onto_limits; then the row as returned */
            ikc_newton_steps(rb, g, w, IKC_CLAMPED_NEWTON, 1, held);
            same = IKC_SPLIT_ROOT;  /* Newton placed this row: a copy of it may stop 1e-7 away */
            for (int j = 0; j < dof; j++)
                if (w[j] != w[j]) return ikc_hand_back(IKC_WHY_NAN);
            status = ikc_represent_n(rb, w, limits, held, dof);
            if (status == IKC_CLAMPED) return ikc_hand_back(IKC_WHY_CLAMPED);  /* again: Python */
            if (status != IKC_OUTSIDE) status = IKC_ADJUSTED;
        }
        const int ok = status != IKC_OUTSIDE;
        if (status == IKC_ADJUSTED) err[k] = ikc_measure(rb, g, w);  /* the values as returned */
        inexact[k] = !(err[k] <= exact_tol);
        /* an exact row that the clamp left above the precision: at a singular configuration the damped
         * steps stall there, Python's Robot.singular_newton takes undamped ones (docs/design.md
         * section 10, "Newton at a singular configuration"; pybullet's xarm6 at q5 = pi) */
        if (clamped && ok && was_exact && inexact[k]) return ikc_hand_back(IKC_WHY_CLAMPED);
        if (flag & IKC_FAMILY) {  /* a self-motion needs one exact representative inside the limits */
            family_any = 1;
            if (ok && !inexact[k]) family_exact = 1;
        }
        if (!ok) continue;
        rows[count++] = k;
    }
    if (family_any && !family_exact) return IKC_FAMILY_MISS;
    /* stable insertion sort by (inexact, error) */
    for (int a = 1; a < count; a++) {
        int r = rows[a], b = a - 1;
        while (b >= 0 && (inexact[rows[b]] > inexact[r] ||
                          (inexact[rows[b]] == inexact[r] && err[rows[b]] > err[r]))) {
            rows[b + 1] = rows[b];
            b--;
        }
        rows[b + 1] = r;
    }
    int kept = 0;
    for (int a = 0; a < count && kept < rb->slots; a++) {
        const double *w = W + rows[a] * dof;
        int duplicate = 0;
        for (int b = 0; b < kept && !duplicate; b++) {
            const double *o = q + b * dof;
            int differs = 0;
            for (int j = 0; j < dof; j++) {
                double d = w[j] > o[j] ? w[j] - o[j] : o[j] - w[j];
                if (revolute[j]) {  /* modulo 2 pi: the rows may hold 2 pi aliases */
                    d = ikc_mod_two_pi(d);
                    if (d > IKC_PI_F) d = IKC_TWO_PI - d;
                }
                if (d > same) {
                    differs = 1;
                    break;
                }
            }
            duplicate = !differs;
        }
        if (duplicate) continue;
        for (int j = 0; j < dof; j++) q[kept * dof + j] = w[j];
        res[kept] = err[rows[a]];
        ls[kept] = inexact[rows[a]];
        cont[kept] = (F[rows[a]] & IKC_FAMILY) != 0;
        kept++;
    }
    return kept;
}

/* ikc_finish_n with the joint count a constant for 6-joint arms (the closed-form chains of a batch): the
 * row copies, the NaN test, ikc_represent and the duplicate test unrolled, no memcpy calls; the same
 * operations in the same order, so the same bits. */
static int ikc_finish(const ikc_robot *rb, const double *g, int n, const double *Q, const double *E,
                      const int *F, int limits, double *q, double *res, int *ls, int *cont) {
    if (rb->dof == 6) return ikc_finish_n(rb, g, n, Q, E, F, limits, q, res, ls, cont, 6);
    return ikc_finish_n(rb, g, n, Q, E, F, limits, q, res, ls, cont, rb->dof);
}

/* goal_entries: the 12 entries (rotation row-major, translation) of one raw target (16 entries for a
 * pose, 9 for an orientation, 3 for a position), or 0 when they are not finite or not a rotation (the
 * Python path raises then). */
static int ikc_goal_checked(const ikc_robot *rb, const double *T, double *g) {
    if (rb->target == 1) {
        for (int i = 0; i < 12; i++) g[i] = (i == 0 || i == 4 || i == 8) ? 1.0 : 0.0;
        for (int i = 0; i < 3; i++) g[9 + i] = T[i];
    } else if (rb->target == 2) {
        for (int i = 0; i < 9; i++) g[i] = T[i];
        g[9] = g[10] = g[11] = 0.0;
    } else {
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) g[3 * i + j] = T[4 * i + j];
        for (int i = 0; i < 3; i++) g[9 + i] = T[4 * i + 3];
        for (int i = 12; i < 16; i++)
            if (!isfinite(T[i])) return 0;
        for (int i = 12; i < 16; i++)  /* the bottom row of a rigid transform */
            if (fabs(T[i] - (i == 15 ? 1.0 : 0.0)) > 1e-12) return 0;
    }
    for (int i = 0; i < 12; i++)
        if (!isfinite(g[i])) return 0;
    if (rb->target == 1) return 1;
    double x0 = g[0], y0 = g[1], z0 = g[2], x1 = g[3], y1 = g[4], z1 = g[5], x2 = g[6], y2 = g[7], z2 = g[8];
    double det = (x1 * y2 - x2 * y1) * z0 + (x2 * y0 - x0 * y2) * z1 + (x0 * y1 - x1 * y0) * z2;
    if (fabs(x0 * x0 + x1 * x1 + x2 * x2 - 1.0) > 1e-6 || fabs(y0 * y0 + y1 * y1 + y2 * y2 - 1.0) > 1e-6 ||
        fabs(z0 * z0 + z1 * z1 + z2 * z2 - 1.0) > 1e-6 || fabs(x0 * y0 + x1 * y1 + x2 * y2) > 1e-6 ||
        fabs(x0 * z0 + x1 * z1 + x2 * z2) > 1e-6 || fabs(y0 * z0 + y1 * z1 + y2 * z2) > 1e-6 ||
        fabs(det - 1.0) > 1e-6)
        return 0;
    /* orthonormal to 1e-6 but not to 1e-14: the Python path projects it onto the nearest rotation */
    double defect[6] = {x0 * x0 + x1 * x1 + x2 * x2 - 1.0, y0 * y0 + y1 * y1 + y2 * y2 - 1.0,
                        z0 * z0 + z1 * z1 + z2 * z2 - 1.0, x0 * y0 + x1 * y1 + x2 * y2,
                        x0 * z0 + x1 * z1 + x2 * z2, y0 * z0 + y1 * z1 + y2 * z2};
    for (int i = 0; i < 6; i++)
        if (fabs(defect[i]) > 1e-14) return 2;
    return 1;
}


/* ---- self-motions that are straight lines (docs/design.md section 6, "Self-motions in C") ----
 * A family leaf whose joint values, over the chain's representatives rep, are q(rep) = q(0) + s rep
 * (modulo 2 pi) with integer slopes s on the revolute joints and none on the prismatic ones is a closed
 * line in joint space covered once by rep in (-pi, pi].  Where the Jacobian's null space is exactly one
 * direction along it (the second smallest singular value clear of 0), the solution set near each of
 * its points is that line alone, so the line is the whole component: where it misses the limit box,
 * no in-limit representative of this self-motion exists (the leaf is dropped); where it meets the
 * box, the middle of the widest in-limit stretch of rep is a representative inside the limits. */
#define IKC_LINE_FIT 1e-9       /* a representative's values off the line by more: not a line */
#define IKC_LINE_RANK 1e-5      /* second smallest singular value (size-free) below this: not alone */
#define IKC_LINE_POINTS 3       /* points of the line where the rank is checked: t = 0, +-2 pi / 3 */

/* The size-free J^T J at q (rows of the target, lengths over the size, prismatic columns times the
 * size) over the m joints that are not free (their positions in col), row-major in S (m x m; room for
 * dof x dof).  Returns m; *rows is the target's row count. */
static int ikc_scaled_jtj(const ikc_robot *rb, const double *q, int *col, double *S, int *rows) {
    const int dof = rb->dof;
    double G[12], J[6 * dof];
    ikc_fk_jacobian(rb, q, G, J);
    int r0 = rb->target == 2 ? 3 : 0, r1 = rb->target == 1 ? 3 : 6, m = 0;
    for (int j = 0; j < dof; j++)
        if (!rb->is_free[j]) col[m++] = j;
    for (int a = 0; a < m; a++)
        for (int c = 0; c < m; c++) {
            double t = 0.0;
            for (int r = r0; r < r1; r++) {
                double f = r < 3 ? 1.0 / (rb->scale * rb->scale) : 1.0;
                t += f * J[r * dof + col[a]] * J[r * dof + col[c]];
            }
            double ua = rb->revolute[col[a]] ? 1.0 : rb->scale, uc = rb->revolute[col[c]] ? 1.0 : rb->scale;
            S[a * m + c] = t * ua * uc;
        }
    *rows = r1 - r0;
    return m;
}

/* The size-free J^T J at q (rows of the target, lengths over the size, prismatic columns times the size)
 * over the m returned joints that are not free (their positions in col), diagonalised by cyclic
 * Jacobi rotations: its eigenvalues ascending in lam[0..m), and with V (m x m, row-major) their unit
 * eigenvectors as columns.  Returns m, or 0 when there are fewer than 2 such joints or they outnumber
 * the target's rows (no isolated direction to show). */
static int ikc_jtj_eigen(const ikc_robot *rb, const double *q, int *col, double *lam, double *V) {
    double Sf[rb->dof * rb->dof];
    int rows, m = ikc_scaled_jtj(rb, q, col, Sf, &rows);
    if (m < 2 || m > rows) return 0;
    double S[m][m], U[m][m];
    for (int a = 0; a < m; a++)
        for (int c = 0; c < m; c++) {
            S[a][c] = Sf[a * m + c];
            U[a][c] = a == c ? 1.0 : 0.0;
        }
    for (int sweep = 0; sweep < 30; sweep++) {  /* cyclic Jacobi: S -> diagonal, U -> eigenvectors */
        double off = 0.0, diag = 0.0;
        for (int a = 0; a < m; a++) {
            diag += S[a][a] * S[a][a];
            for (int c = a + 1; c < m; c++) off += S[a][c] * S[a][c];
        }
        if (off <= 1e-34 * diag) break;
        for (int a = 0; a < m; a++)
            for (int c = a + 1; c < m; c++) {
                if (S[a][c] == 0.0) continue;
                double theta = (S[c][c] - S[a][a]) / (2.0 * S[a][c]);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                double cs = 1.0 / sqrt(t * t + 1.0), sn = t * cs;
                for (int k = 0; k < m; k++) {  /* S <- S R, U <- U R (columns a, c) */
                    double x = S[k][a], y = S[k][c];
                    S[k][a] = cs * x - sn * y;
                    S[k][c] = sn * x + cs * y;
                    x = U[k][a], y = U[k][c];
                    U[k][a] = cs * x - sn * y;
                    U[k][c] = sn * x + cs * y;
                }
                for (int k = 0; k < m; k++) {  /* S <- R^T S (rows a, c) */
                    double x = S[a][k], y = S[c][k];
                    S[a][k] = cs * x - sn * y;
                    S[c][k] = sn * x + cs * y;
                }
            }
    }
    int order[m];
    for (int a = 0; a < m; a++) order[a] = a;
    for (int a = 1; a < m; a++)  /* ascending eigenvalues (insertion sort, stable) */
        for (int b = a; b > 0 && S[order[b - 1]][order[b - 1]] > S[order[b]][order[b]]; b--) {
            int tmp = order[b];
            order[b] = order[b - 1];
            order[b - 1] = tmp;
        }
    for (int a = 0; a < m; a++) {
        lam[a] = S[order[a]][order[a]];
        if (V)
            for (int k = 0; k < m; k++) V[k * m + a] = U[k][order[a]];
    }
    return m;
}

/* The two smallest singular values of the size-free Jacobian at q (free joints left out); both 0 where
 * ikc_jtj_eigen shows nothing. */
static void ikc_two_weakest(const ikc_robot *rb, const double *q, double sig[2]) {
    int col[rb->dof];
    double lam[rb->dof];
    sig[0] = sig[1] = 0.0;
    if (!ikc_jtj_eigen(rb, q, col, lam, NULL)) return;
    sig[0] = sqrt(lam[0] > 0.0 ? lam[0] : 0.0);
    sig[1] = sqrt(lam[1] > 0.0 ? lam[1] : 0.0);
}

/* The difference a - b of two joint values: modulo 2 pi into (-pi, pi] for a revolute joint. */
static double ikc_joint_step(const ikc_robot *rb, int j, double a, double b) {
    return rb->revolute[j] ? ikc_wrap(a - b) : a - b;
}

static int ikc_tangent_line_alone(const ikc_robot *rb, const double *g, const double *p0, const double *s);

/* A sufficient test that the second smallest eigenvalue of the size-free J^T J at q is at least
 * IKC_LINE_RANK^2, cheaper than ikc_jtj_eigen's sweeps: J^T J compressed onto the complement of the
 * line's unit direction f (an orthonormal basis by Gram-Schmidt), less twice that floor, has a Cholesky
 * factor.  By Courant-Fischer the second eigenvalue is at least the compression's smallest, so where
 * this holds the eigenvalue test holds too (the factor 2 keeps roundoff off the floor); where it fails
 * the caller asks the eigenvalues (settle.rank_clear). */
static int ikc_rank_clear(const ikc_robot *rb, const double *q, const double *s) {
    const int dof = rb->dof;
    int col[dof], rows;
    double Sf[dof * dof];
    const int m = ikc_scaled_jtj(rb, q, col, Sf, &rows);
    if (m < 2 || m > rows) return 0;
    double f[m], fn = 0.0;
    for (int a = 0; a < m; a++) fn += s[col[a]] * s[col[a]];
    if (!(fn > 0.0)) return 0;
    for (int a = 0; a < m; a++) f[a] = s[col[a]] / sqrt(fn);
    int top = 0;
    for (int a = 1; a < m; a++)
        if (fabs(f[a]) > fabs(f[top])) top = a;
    const int k = m - 1;
    double U[k > 0 ? k : 1][m];  /* orthonormal basis of the complement of f */
    int nu = 0;
    for (int a = 0; a < m; a++) {
        if (a == top) continue;
        double *u = U[nu];
        for (int c = 0; c < m; c++) u[c] = (c == a ? 1.0 : 0.0) - f[a] * f[c];
        for (int b = 0; b < nu; b++) {
            double d = 0.0;
            for (int c = 0; c < m; c++) d += U[b][c] * u[c];
            for (int c = 0; c < m; c++) u[c] -= d * U[b][c];
        }
        double norm = 0.0;
        for (int c = 0; c < m; c++) norm += u[c] * u[c];
        norm = sqrt(norm);
        if (!(norm > 0.0)) return 0;
        for (int c = 0; c < m; c++) u[c] = u[c] / norm;
        nu++;
    }
    double C[k > 0 ? k : 1][k > 0 ? k : 1], L[k > 0 ? k : 1][k > 0 ? k : 1];
    for (int a = 0; a < k; a++) {
        double Su[m];
        for (int r = 0; r < m; r++) {
            double t = 0.0;
            for (int c = 0; c < m; c++) t += Sf[r * m + c] * U[a][c];
            Su[r] = t;
        }
        for (int b = 0; b <= a; b++) {
            double t = 0.0;
            for (int r = 0; r < m; r++) t += U[b][r] * Su[r];
            C[a][b] = t;
        }
    }
    const double floor = 2.0 * IKC_LINE_RANK * IKC_LINE_RANK;
    for (int a = 0; a < k; a++)
        for (int b = 0; b <= a; b++) {
            double t = C[a][b] - (a == b ? floor : 0.0);
            for (int c = 0; c < b; c++) t -= L[a][c] * L[b][c];
            if (a == b) {
                if (!(t > 0.0)) return 0;
                L[a][a] = sqrt(t);
            } else {
                L[a][b] = t / L[b][b];
            }
        }
    return 1;
}

/* Whether the line q0 + s t is a self-motion alone at its points t = 0, +-2 pi / 3 (see above).  With
 * g (the goal; not NULL for a line whose leaves are flagged a tangent root, exact there), a point with a
 * second null direction counts where that direction is a double root's (ikc_tangent_line_alone at the
 * point: Newton steps off it come back to the line). */
static int ikc_line_alone(const ikc_robot *rb, const double *q0, const double *s, const double *g) {
    const int dof = rb->dof;
    int moves = 0;
    for (int j = 0; j < dof; j++) moves |= s[j] != 0.0;
    if (!moves) return 0;  /* rep moves no joint: the family is not this line */
    for (int p = 0; p < IKC_LINE_POINTS; p++) {
        double t = (p == 0 ? 0.0 : (p == 1 ? 1.0 : -1.0)) * IKC_TWO_PI / 3.0, q[dof], sig[2];
        for (int j = 0; j < dof; j++) q[j] = q0[j] + s[j] * t;
        if (ikc_rank_clear(rb, q, s)) continue;  /* the eigenvalues would say the same */
        ikc_two_weakest(rb, q, sig);
        if (!(sig[1] >= IKC_LINE_RANK) && !(g != NULL && ikc_tangent_line_alone(rb, g, q, s))) return 0;
    }
    return 1;
}

/* The unit null vector n (of the two weakest, V's first columns) least along the unit f, made orthogonal
 * to it; returns its squared length before that (0 when none). */
static double ikc_null_across(int m, const double *V, const double *f, double *n) {
    double best = 0.0;
    for (int v = 0; v < 2; v++) {
        double d = 0.0, w[m], len = 0.0;
        for (int a = 0; a < m; a++) d += V[a * m + v] * f[a];
        for (int a = 0; a < m; a++) w[a] = V[a * m + v] - d * f[a], len += w[a] * w[a];
        if (len > best) {
            best = len;
            for (int a = 0; a < m; a++) n[a] = w[a] / sqrt(len);
        }
    }
    return best;
}

/* Whether value x of joint j (or an alias) lies inside its limits widened by the slack. */
static int ikc_joint_inside(const ikc_robot *rb, int j, double x, double slack, double slide_slack) {
    const double sl = rb->revolute[j] ? slack : slide_slack;
    double lo = rb->lower[j] - sl, hi = rb->upper[j] + sl;
    if (rb->revolute[j]) {
        if (hi - lo >= IKC_TWO_PI) return 1;
        x = lo + fmod(fmod(x - lo, IKC_TWO_PI) + IKC_TWO_PI, IKC_TWO_PI);  /* the alias at or above lo */
    }
    return lo <= x && x <= hi;
}

/* Whether t lies inside the limits of every joint on the line q0 + s t (bounds widened by `slack`,
 * `slide_slack` for a prismatic joint). */
static int ikc_line_inside(const ikc_robot *rb, const double *q0, const double *s, double t, double slack,
                           double slide_slack) {
    for (int j = 0; j < rb->dof; j++)
        if (!ikc_joint_inside(rb, j, q0[j] + s[j] * t, slack, slide_slack)) return 0;
    return 1;
}

/* The in-limit stretch of the line q0 + s t, t in [-pi, pi]: 0 when none (even with the limits
 * widened by `slack`, `slide_slack` for a prismatic joint: IKC_LIMIT_EPS, as ikc_represent clamps, or
 * IKC_TANGENT_MARGIN radians and times the size, for a line known only to that), else 1 and *t_mid the middle of the
 * widest stretch inside the limits; -1 when undecided.  The stretches end where some joint's value
 * (or an alias) crosses a limit. */
static int ikc_line_in_limits(const ikc_robot *rb, const double *q0, const double *s, double slack,
                              double slide_slack, double *t_mid) {
    enum { MAXCUTS = 256 };
    double cut[MAXCUTS];
    int nc = 0;
    cut[nc++] = -IKC_PI_F;
    cut[nc++] = IKC_PI_F;
    for (int j = 0; j < rb->dof; j++) {
        if (s[j] == 0.0) continue;
        const double bound[2] = {rb->lower[j], rb->upper[j]};
        if (rb->revolute[j] && bound[1] - bound[0] >= IKC_TWO_PI) continue;
        const int wraps = rb->revolute[j] ? (int)ceil(fabs(s[j])) + 1 : 0;
        for (int b = 0; b < 2; b++)
            for (int k = -wraps; k <= wraps; k++) {
                double t = (bound[b] + IKC_TWO_PI * k - q0[j]) / s[j];
                if (-IKC_PI_F < t && t < IKC_PI_F) {
                    if (nc == MAXCUTS) return -1;
                    cut[nc++] = t;
                }
            }
    }
    for (int a = 1; a < nc; a++)  /* insertion sort */
        for (int b = a; b > 0 && cut[b - 1] > cut[b]; b--) {
            double tmp = cut[b];
            cut[b] = cut[b - 1];
            cut[b - 1] = tmp;
        }
    double widest = -1.0;
    int any = 0;
    for (int a = 0; a + 1 < nc; a++) {
        double mid = 0.5 * (cut[a] + cut[a + 1]), width = cut[a + 1] - cut[a];
        if (ikc_line_inside(rb, q0, s, mid, slack, slide_slack)) any = 1;
        if (width > widest && ikc_line_inside(rb, q0, s, mid, 0.0, 0.0)) widest = width, *t_mid = mid;
    }
    for (int a = 0; a < nc && !any; a++) any = ikc_line_inside(rb, q0, s, cut[a], slack, slide_slack);
    return !any ? 0 : (widest > 0.0 ? 1 : -1);
}

static double ikc_row_distance(const ikc_robot *rb, const double *x, const double *y);  /* below */

#define IKC_TANGENT_MARGIN 1e-3  /* a tangent line's leaves lie this close to the line (radians) */
#define IKC_TANGENT_PROBE 1e-3   /* the step off the line along the second null direction */
/* Newton steps from a probe: a double root's halve the distance each, and 4 halvings bring it inside
 * the tenth of the probe that the test asks (8: a margin of 16) */
#define IKC_TANGENT_PROBE_STEPS 8

/* Newton steps (ikc_newton, `iters`) from p0 moved by step * v (v over the columns col, radians or
 * sizes): the end point x, its step from p0 per column d in the same units; returns the error (the
 * probes of the line and plane tests; settle.py _probe) */
static double ikc_probe(const ikc_robot *rb, const double *g, const double *p0, int m, const int *col, double step,
                        const double *v, int iters, double *x, double *d) {
    for (int j = 0; j < rb->dof; j++) x[j] = p0[j];
    for (int a = 0; a < m; a++) {
        const double u = rb->revolute[col[a]] ? 1.0 : rb->scale;
        x[col[a]] += step * v[a] * u;
    }
    const double err = ikc_newton(rb, g, x, iters);
    for (int a = 0; a < m; a++) {
        const double u = rb->revolute[col[a]] ? 1.0 : rb->scale;
        d[a] = ikc_joint_step(rb, col[a], x[col[a]], p0[col[a]]) / u;
    }
    return err;
}

/* sum d[a] f[a] in order (settle.py _dot) */
static double ikc_dot_m(int m, const double *d, const double *f) {
    double total = 0.0;
    for (int a = 0; a < m; a++) total += d[a] * f[a];
    return total;
}

/* A self-motion line whose leaves are a tangent root (two roots of one step coincide: located to about
 * sqrt(eps)) has, at its exact point p0 (Newton-polished), a Jacobian null space of two directions: the
 * line's own, f, and one more, n.  Along a double root, n leads to no solution: Newton steps from
 * p0 + IKC_TANGENT_PROBE n come back to the line (they halve the distance each step); on a sheet of
 * solutions (a second self-motion, as the Rhino's planar arm) they stop where they start.  So the line
 * is alone where the null space has exactly two directions and Newton from both sides returns to
 * within a tenth of the step; or where it has only one (ikc_line_alone's case). */
static int ikc_tangent_line_alone(const ikc_robot *rb, const double *g, const double *p0, const double *s) {
    const int dof = rb->dof;
    int col[dof];
    double lam[dof], V[dof * dof];
    const int m = ikc_jtj_eigen(rb, p0, col, lam, V);
    const double floor = IKC_LINE_RANK * IKC_LINE_RANK;
    if (m < 3 || !(lam[2] >= floor)) return 0;
    if (lam[1] >= floor) return 1;  /* one null direction: the line alone */
    double f[m], fn = 0.0;
    for (int a = 0; a < m; a++) fn += s[col[a]] * s[col[a]];
    if (!(fn > 0.0)) return 0;
    for (int a = 0; a < m; a++) f[a] = s[col[a]] / sqrt(fn);  /* revolute: scaled and joint units agree */
    double n[m];
    if (!(ikc_null_across(m, V, f, n) > 0.25)) return 0;
    for (int side = -1; side <= 1; side += 2) {
        double x[dof], d[m], off = 0.0;
        ikc_probe(rb, g, p0, m, col, side * IKC_TANGENT_PROBE, n, IKC_TANGENT_PROBE_STEPS, x, d);
        const double along = ikc_dot_m(m, d, f);
        for (int a = 0; a < m; a++) off += (d[a] - along * f[a]) * (d[a] - along * f[a]);
        if (!(sqrt(off) <= 0.1 * IKC_TANGENT_PROBE)) return 0;  /* not back on the line: a sheet */
    }
    return 1;
}

#define IKC_PLANE_PROBE 0.5  /* the step along a plane's second direction (radians, or over the size) */
#define IKC_PLANE_FIXED 1e-6 /* a joint neither (unit) direction of the plane moves */

/* Whether the self-motion through the exact point p0 of a family line (slopes s) is a plane alone of
 * which a joint that neither of its directions moves lies outside its limits: the Jacobian's null space
 * at p0 has exactly two directions, the line's f and n; the points p0 +- IKC_PLANE_PROBE n are exact (a
 * sheet of solutions: Newton keeps them off the line, where a double root's would come back), keep
 * that joint's value and have two null directions again.  Near each of those points the solutions
 * are that sheet, so the self-motion keeps the joint where it misses its limits: no solution
 * (docs/design.md section 6; panda's stretched elbow at q4 = 0 with joints 1, 3 and 5 coaxial). */
static int ikc_plane_misses(const ikc_robot *rb, const double *g, const double *p0, const double *s,
                            double slack, double slide_slack) {
    const int dof = rb->dof;
    int col[dof];
    double lam[dof], V[dof * dof];
    const int m = ikc_jtj_eigen(rb, p0, col, lam, V);
    const double floor = IKC_LINE_RANK * IKC_LINE_RANK;
    if (m < 3 || !(lam[1] < floor && lam[2] >= floor)) return 0;
    double f[m], fn = 0.0, n[m];
    for (int a = 0; a < m; a++) fn += s[col[a]] * s[col[a]];
    if (!(fn > 0.0)) return 0;
    for (int a = 0; a < m; a++) f[a] = s[col[a]] / sqrt(fn);
    if (!(ikc_null_across(m, V, f, n) > 0.25)) return 0;
    int out[m], nout = 0;
    for (int a = 0; a < m; a++)
        if (fabs(f[a]) <= IKC_PLANE_FIXED && fabs(n[a]) <= IKC_PLANE_FIXED &&
            !ikc_joint_inside(rb, col[a], p0[col[a]], slack, slide_slack))
            out[nout++] = a;
    if (!nout) return 0;
    const double exact = rb->tol * rb->scale;
    for (int side = -1; side <= 1; side += 2) {
        double x[dof], d[m], off = 0.0;
        if (!(ikc_probe(rb, g, p0, m, col, side * IKC_PLANE_PROBE, n, 15, x, d) <= exact)) return 0;
        const double along = ikc_dot_m(m, d, f);
        for (int a = 0; a < m; a++) off += (d[a] - along * f[a]) * (d[a] - along * f[a]);
        if (!(sqrt(off) >= 0.5 * IKC_PLANE_PROBE)) return 0;  /* back towards the line: no sheet */
        for (int k = 0; k < nout; k++)
            if (!(fabs(d[out[k]]) <= IKC_LINE_FIT)) return 0;
        int colx[dof];
        double lamx[dof];
        ikc_jtj_eigen(rb, x, colx, lamx, NULL);
        if (!(lamx[1] < floor && lamx[2] >= floor)) return 0;
    }
    return 1;
}

/* A joint the sheet's direction n leaves, where a double root's direction shares the null space at p0:
 * there p0 is exact only to the double root's flat error (joint values to ~1e-8, the error their
 * square), the null vectors of the triple eigenvalue mix by ~1e-6 and Newton's end points on the sheet
 * keep the joint to ~1e-8; the joint is also asked to stay outside its limits at those points. */
#define IKC_ROOT_FIXED 1e-4

/* ikc_plane_root_misses for one choice of the sheet's second direction n and the double root's r
 * (unit, across f and each other; m entries over col): a joint that neither f nor n moves lies outside
 * its limits; Newton steps from p0 +- IKC_TANGENT_PROBE r come back to the sheet's tangent plane (a
 * double root: no solutions along r); the points p0 +- IKC_PLANE_PROBE n are exact, off the line, keep
 * that joint (within IKC_ROOT_FIXED, outside its limits) and have two null directions (the sheet alone
 * there).  (settle._sheet_and_root) */
static int ikc_sheet_and_root(const ikc_robot *rb, const double *g, const double *p0, int m, const int *col,
                              const double *f, const double *n, const double *r, double slack,
                              double slide_slack) {
    const int dof = rb->dof;
    int out[m], nout = 0;
    for (int a = 0; a < m; a++)
        if (fabs(f[a]) <= IKC_PLANE_FIXED && fabs(n[a]) <= IKC_ROOT_FIXED &&
            !ikc_joint_inside(rb, col[a], p0[col[a]], slack, slide_slack))
            out[nout++] = a;
    if (!nout) return 0;
    for (int side = -1; side <= 1; side += 2) {
        double x[dof], d[m], off = 0.0;
        ikc_probe(rb, g, p0, m, col, side * IKC_TANGENT_PROBE, r, IKC_TANGENT_PROBE_STEPS, x, d);
        const double along = ikc_dot_m(m, d, f), across = ikc_dot_m(m, d, n);
        for (int a = 0; a < m; a++)
            off += (d[a] - along * f[a] - across * n[a]) * (d[a] - along * f[a] - across * n[a]);
        if (!(sqrt(off) <= 0.1 * IKC_TANGENT_PROBE)) return 0;  /* not back on the sheet: no double root */
    }
    const double exact = rb->tol * rb->scale, floor = IKC_LINE_RANK * IKC_LINE_RANK;
    for (int side = -1; side <= 1; side += 2) {
        double x[dof], d[m], off = 0.0;
        if (!(ikc_probe(rb, g, p0, m, col, side * IKC_PLANE_PROBE, n, 15, x, d) <= exact)) return 0;
        const double along = ikc_dot_m(m, d, f);
        for (int a = 0; a < m; a++) off += (d[a] - along * f[a]) * (d[a] - along * f[a]);
        if (!(sqrt(off) >= 0.5 * IKC_PLANE_PROBE)) return 0;  /* back towards the line: no sheet */
        for (int k = 0; k < nout; k++)
            if (!(fabs(d[out[k]]) <= IKC_ROOT_FIXED &&
                  !ikc_joint_inside(rb, col[out[k]], x[col[out[k]]], slack, slide_slack)))
                return 0;
        int colx[dof];
        double lamx[dof];
        ikc_jtj_eigen(rb, x, colx, lamx, NULL);
        if (!(lamx[1] < floor && lamx[2] >= floor)) return 0;
    }
    return 1;
}

/* Whether the self-motion through the exact point p0 of a family line (slopes s) is a plane alone of
 * which a joint lies outside its limits, where a double root adds a third null direction at p0 (prob at
 * q5 = pi: joints 1, 4 and 6 coaxial and the S2-RR of joints 2 and 3 at a double root): the null space
 * at p0 has exactly three directions, the line's f and, across it, a sheet's n and a double root's r
 * (tried in each order of the null vectors across f: at a triple null eigenvalue the sweeps' vectors
 * are any basis of it, so a mixed basis finds no order and refuses), each as ikc_sheet_and_root asks
 * (settle.plane_root_misses). */
static int ikc_plane_root_misses(const ikc_robot *rb, const double *g, const double *p0, const double *s,
                                 double slack, double slide_slack) {
    const int dof = rb->dof;
    int col[dof];
    double lam[dof], V[dof * dof];
    const int m = ikc_jtj_eigen(rb, p0, col, lam, V);
    const double floor = IKC_LINE_RANK * IKC_LINE_RANK;
    if (m < 4 || !(lam[2] < floor && lam[3] >= floor)) return 0;
    double f[m], fn = 0.0, W[3][m];
    for (int a = 0; a < m; a++) fn += s[col[a]] * s[col[a]];
    if (!(fn > 0.0)) return 0;
    for (int a = 0; a < m; a++) f[a] = s[col[a]] / sqrt(fn);
    for (int v = 0; v < 3; v++) {  /* the three null vectors made orthogonal to f */
        double d = 0.0;
        for (int a = 0; a < m; a++) d += V[a * m + v] * f[a];
        for (int a = 0; a < m; a++) W[v][a] = V[a * m + v] - d * f[a];
    }
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            if (i == k) continue;
            double ni = 0.0, n[m], r[m], d = 0.0, nr = 0.0;
            for (int a = 0; a < m; a++) ni += W[i][a] * W[i][a];
            if (!(ni > 0.25)) continue;
            for (int a = 0; a < m; a++) n[a] = W[i][a] / sqrt(ni);
            for (int a = 0; a < m; a++) d += W[k][a] * n[a];
            for (int a = 0; a < m; a++) r[a] = W[k][a] - d * n[a];
            for (int a = 0; a < m; a++) nr += r[a] * r[a];
            if (!(nr > 0.25)) continue;
            for (int a = 0; a < m; a++) r[a] = r[a] / sqrt(nr);
            if (ikc_sheet_and_root(rb, g, p0, m, col, f, n, r, slack, slide_slack)) return 1;
        }
    return 0;
}

/* Leaves, finish, and for a self-motion none of whose representatives (rep = 0) is exact inside the
 * joint limits, the chain again with rep = +-pi/8, +-pi/4, ... pi: each family leaf takes the first
 * representative that is exact and inside the limits (the family's interval of reachable values may
 * not contain 0, or 0 may lie outside a limit).  Family leaves that no
 * representative completes are settled, where the family is a straight line alone (above), by the
 * line: dropped where it misses the limits, else taken at the middle of its widest in-limit stretch;
 * the others (an interval narrower than the grid: a stretched arm at a wrist lock) get Newton steps
 * from their best representative, as the reference runtime pulls its representatives onto the
 * family.  Count or IKC_PYTHON. */
static int ikc_any_flag(int n, const int *F, int bit) {
    for (int k = 0; k < n; k++)
        if (!(F[k] & IKC_EMPTY) && (F[k] & bit)) return 1;
    return 0;
}

static int ikc_settle_alternative(const ikc_robot *rb, const double *g, const double *fr, int limits,
                                  double *q, double *res, int *ls, int *cont);

/* The leaves of a chain at rep for the settling below: an S2-RR lock (IKC_LOCK, the angle = rep) is a
 * candidate self-motion (IKC_FAMILY too), kept only where its representatives are a line. */
static int ikc_lock_leaves(ikc_chain_fn chain, const double *g, const double *fr, double rep, double *Q,
                           double *E, int *F) {
    const int n = chain(g, fr, rep, Q, E, F);
    for (int k = 0; k < n; k++)
        if (F[k] & IKC_LOCK) F[k] |= IKC_FAMILY;
    return n;
}

/* The straight-line verdict of family leaf q0 (its leaf at rep = 0) with slopes s: -2 where it is not
 * shown a line alone (a tangent line: its exact point near q0 is found first; `root`: an exact line whose
 * leaves are flagged a tangent root, see ikc_line_alone); else ikc_line_in_limits's 0 (the line misses
 * the limits), 1 (*t: the middle of its widest in-limit stretch) or -1. */
static int ikc_line_verdict(const ikc_robot *rb, const double *g, const double *q0, const double *s,
                            int tangent, int root, double *t) {
    const int dof = rb->dof;
    double p0[dof];
    for (int c = 0; c < dof; c++) p0[c] = q0[c];
    if (tangent && !(ikc_newton(rb, g, p0, 15) <= rb->tol * rb->scale &&
                     ikc_row_distance(rb, p0, q0) <= IKC_TANGENT_MARGIN))
        return -2;
    const double slack = tangent ? IKC_TANGENT_MARGIN : IKC_LIMIT_EPS;
    const double slide = tangent ? slack * rb->scale : slack;
    /* not a line alone: a plane alone that misses the limits has no solution either (also where a double
     * root adds a third null direction at p0) */
    if (!(tangent ? ikc_tangent_line_alone(rb, g, p0, s) : ikc_line_alone(rb, q0, s, root ? g : NULL)))
        return ikc_plane_misses(rb, g, p0, s, slack, slide) || ikc_plane_root_misses(rb, g, p0, s, slack, slide)
                   ? 0 : -2;
    *t = 0.0;
    return ikc_line_in_limits(rb, q0, s, slack, slide, t);
}

/* The earlier leaf k < j whose line verdict j can take (-1 when none): asked already, the same test
 * (tangent, root) and slopes, and leaf values equal (a tangent line's: within IKC_SPLIT_ROOT, where the
 * finish takes two copies of a tangent root for one solution) -- ikc_line_verdict depends on those
 * alone, and a double root's split copies would each pay for its Newton steps and probes again. */
static int ikc_given_verdict(const ikc_robot *rb, int j, const int *verdict, const int *line,
                             const double *Q0, const double *S, const int *tangent, const int *root) {
    const int dof = rb->dof;
    for (int k = 0; k < j; k++) {
        if (verdict[k] == -3 || !line[k] || tangent[k] != tangent[j] || root[k] != root[j]) continue;
        int same = 1;
        for (int c = 0; c < dof && same; c++) same = S[k * dof + c] == S[j * dof + c];
        if (!same) continue;
        if (tangent[j])
            same = ikc_row_distance(rb, Q0 + k * dof, Q0 + j * dof) <= IKC_SPLIT_ROOT;
        else
            for (int c = 0; c < dof && same; c++) same = Q0[k * dof + c] == Q0[j * dof + c];
        if (same) return k;
    }
    return -1;
}

/* Whether each candidate line's leaf at representative rep (the r-th: Q2, E2, F2) still lies on it,
 * exactly; the first (r = 1) sets its slopes S (settle._fit_lines). */
static void ikc_fit_lines(const ikc_robot *rb, int n, int r, double rep, const double *Q2, const double *E2,
                          const int *F2, const double *Q0, int *line, double *S) {
    const int dof = rb->dof;
    const double exact_tol = rb->tol * rb->scale, near = IKC_NEAR_MISS * rb->scale;
    for (int j = 0; j < n; j++) {
        if (line[j]) {  /* still on the line q0 + s rep, exactly? (the first rep sets the slopes) */
            const double *row = Q2 + j * dof, *q0 = Q0 + j * dof;
            int fits = (F2[j] & IKC_FAMILY) && !(F2[j] & (IKC_DEFER | IKC_EMPTY)) &&
                       (E2[j] <= exact_tol || ((F2[j] & IKC_TANGENT_ROOT) && E2[j] < near));
            for (int c = 0; c < dof && fits; c++) {
                double d = ikc_joint_step(rb, c, row[c], q0[c]), unit = rb->revolute[c] ? 1.0 : rb->scale;
                if (r == 1) {
                    double sl = d / rep, whole = nearbyint(sl);
                    fits = rb->revolute[c] ? fabs(sl - whole) <= IKC_LINE_FIT / rep : fabs(d) <= IKC_LINE_FIT * unit;
                    S[j * dof + c] = rb->revolute[c] ? whole : 0.0;
                } else {
                    fits = fabs(ikc_joint_step(rb, c, d, S[j * dof + c] * rep)) <= IKC_LINE_FIT * unit;
                }
            }
            line[j] = fits;
        }
    }
}

/* Whether the line q0 + s rep misses the goal by at most `bound` (forward kinematics) at the
 * representatives k pi / 4 (k = +-1, +-2, +-3, 4): with the chain's leaves at 0 and pi / 8, nine points
 * around the closed line, the chain's grid at half its resolution (each point costs a quarter of a chain
 * run; settle._line_points_exact). */
static int ikc_line_points_exact(const ikc_robot *rb, const double *g, const double *q0, const double *s,
                                 double bound) {
    const int dof = rb->dof;
    for (int r = 1; r < IKC_REPS; r++) {
        int step = (r + 1) / 2;
        double rep = (r % 2 ? 1.0 : -1.0) * step * (IKC_TWO_PI / IKC_REPS), x[dof];
        if (step % 2 || rep <= -IKC_PI_F) continue;
        for (int c = 0; c < dof; c++) x[c] = q0[c] + s[c] * rep;
        if (!(ikc_measure(rb, g, x) <= bound)) return 0;
    }
    return 1;
}

/* Whether the line point q0 + s rep has a representative inside the limits. */
static int ikc_line_point_inside(const ikc_robot *rb, const double *q0, const double *s, double rep) {
    double x[rb->dof];
    for (int c = 0; c < rb->dof; c++) x[c] = q0[c] + s[c] * rep;
    return ikc_row_inside(rb, x);
}

/* The settling of a target whose self-motion leaves are all straight-line candidates after the first
 * other representative (Q1, E1, F1: its leaves), without running the chain at the other 14
 * (docs/design.md section 6, "Lines checked by forward kinematics"): each line's points at every other
 * of those representatives are checked by forward kinematics instead (exact, or for a tangent line
 * within IKC_NEAR_MISS, as its leaves were: ikc_line_points_exact); a tangent line is judged first, as in the full loop, and must be
 * dropped; an exact line's leaf takes the first representative whose line point lies inside the limits
 * (the chain run there, its leaf on the line, exact and inside: what the full loop would take), or,
 * with none, the line's verdict drops it (the line misses the limits) or takes the chain at its
 * in-limit middle.  The finish's count (or IKC_PYTHON), or -4 where any step leaves the quick case
 * (the full loop then runs from the start; Q, E, F untouched: settle.quick_lines). */
#define IKC_NOT_QUICK (-4)
static int ikc_quick_lines(const ikc_robot *rb, ikc_chain_fn chain, int L, int n, const double *g,
                           const double *fr, const double *Q, const double *E, const int *F,
                           const double *Q0, const int *line, const double *S, const int *tangent,
                           const int *root, const double *Q1, const double *E1, const int *F1, double *q,
                           double *res, int *ls, int *cont) {
    const int dof = rb->dof;
    const double exact_tol = rb->tol * rb->scale, near = IKC_NEAR_MISS * rb->scale;
    int pending[L], np = 0;
    for (int j = 0; j < n; j++) {
        if (!(F[j] & IKC_FAMILY) || (F[j] & (IKC_DEFER | IKC_EMPTY))) continue;
        const int lock = F[j] & IKC_LOCK;
        if (!lock && E[j] <= exact_tol && ikc_row_inside(rb, Q + j * dof)) continue;
        if (!line[j] || !(tangent[j] || E1[j] <= exact_tol)) return IKC_NOT_QUICK;
        pending[np++] = j;
    }
    if (!np) return IKC_NOT_QUICK;
    for (int a = 0; a < np; a++) {  /* each line once (split copies share their values and slopes) */
        const int j = pending[a];
        int seen = 0;
        for (int b = 0; b < a && !seen; b++) {
            const int k = pending[b];
            seen = 1;
            for (int c = 0; c < dof && seen; c++)
                seen = Q0[k * dof + c] == Q0[j * dof + c] && S[k * dof + c] == S[j * dof + c];
        }
        if (!seen && !ikc_line_points_exact(rb, g, Q0 + j * dof, S + j * dof, tangent[j] ? near : exact_tol))
            return IKC_NOT_QUICK;
    }
    /* the chain at a representative, run once (rep r at r - 1; the first is Q1) */
    double RQ[(IKC_REPS - 1) * L * dof], RE[(IKC_REPS - 1) * L];
    int RF[(IKC_REPS - 1) * L], ran[IKC_REPS];
    for (int r = 0; r < IKC_REPS; r++) ran[r] = r == 1;
    double Qc[L * dof], Ec[L], VT[L], Q3[L * dof], E3[L];
    int Fc[L], verdict[L], F3[L];
    for (int j = 0; j < n; j++) {  /* the full loop starts afresh where this fails */
        for (int c = 0; c < dof; c++) Qc[j * dof + c] = Q[j * dof + c];
        Ec[j] = E[j];
        Fc[j] = F[j];
        verdict[j] = -3;
        VT[j] = 0.0;
    }
    for (int a = 0; a < np; a++) {  /* tangent lines first, as the full loop judges them before its polish */
        const int j = pending[a];
        if (!tangent[j]) continue;
        const int k = ikc_given_verdict(rb, j, verdict, line, Q0, S, tangent, root);
        if (k >= 0)
            verdict[j] = verdict[k], VT[j] = VT[k];
        else
            verdict[j] = ikc_line_verdict(rb, g, Q0 + j * dof, S + j * dof, 1, 0, VT + j);
        if (verdict[j] != 0) return IKC_NOT_QUICK;
        Fc[j] |= IKC_EMPTY;
    }
    for (int a = 0; a < np; a++) {
        const int j = pending[a];
        if (tangent[j]) continue;
        int taken = 0;
        for (int r = 1; r < IKC_REPS && !taken && !(Fc[j] & IKC_LOCK); r++) {
            int step = (r + 1) / 2;
            double rep = (r % 2 ? 1.0 : -1.0) * step * (IKC_TWO_PI / IKC_REPS);
            if (rep <= -IKC_PI_F) continue;
            if (!ikc_line_point_inside(rb, Q0 + j * dof, S + j * dof, rep)) continue;
            const double *Q2 = r == 1 ? Q1 : RQ + (r - 1) * L * dof, *E2 = r == 1 ? E1 : RE + (r - 1) * L;
            const int *F2 = r == 1 ? F1 : RF + (r - 1) * L;
            if (!ran[r]) {
                if (ikc_lock_leaves(chain, g, fr, rep, RQ + (r - 1) * L * dof, RE + (r - 1) * L,
                                    RF + (r - 1) * L) != n)
                    return IKC_NOT_QUICK;
                ran[r] = 1;
            }
            const double *row = Q2 + j * dof;
            if (!(F2[j] & IKC_FAMILY) || (F2[j] & (IKC_DEFER | IKC_EMPTY)) || !(E2[j] <= exact_tol) ||
                !ikc_row_inside(rb, row))
                return IKC_NOT_QUICK;
            for (int c = 0; c < dof; c++) {
                const double unit = rb->revolute[c] ? 1.0 : rb->scale;
                const double d = ikc_joint_step(rb, c, row[c], Q0[j * dof + c]);
                if (!(fabs(ikc_joint_step(rb, c, d, S[j * dof + c] * rep)) <= IKC_LINE_FIT * unit))
                    return IKC_NOT_QUICK;
            }
            for (int c = 0; c < dof; c++) Qc[j * dof + c] = row[c];
            Ec[j] = E2[j];
            Fc[j] = F2[j];
            taken = 1;
        }
        if (taken) continue;
        double t = 0.0;
        const int k = ikc_given_verdict(rb, j, verdict, line, Q0, S, tangent, root);
        int found;
        if (k >= 0)
            found = verdict[k], t = VT[k];
        else
            found = ikc_line_verdict(rb, g, Q0 + j * dof, S + j * dof, 0, root[j], &t);
        verdict[j] = found, VT[j] = t;
        if (found == 0) {
            Fc[j] |= IKC_EMPTY;
            continue;
        }
        if (found != 1) return IKC_NOT_QUICK;
        if (ikc_lock_leaves(chain, g, fr, t, Q3, E3, F3) != n || !(F3[j] & IKC_FAMILY) ||
            (F3[j] & (IKC_DEFER | IKC_EMPTY)))
            return IKC_NOT_QUICK;
        double e3 = E3[j];
        if (exact_tol < e3 && e3 < near) e3 = ikc_newton(rb, g, Q3 + j * dof, 15);
        if (!(e3 <= exact_tol && ikc_row_inside(rb, Q3 + j * dof))) return IKC_NOT_QUICK;
        for (int c = 0; c < dof; c++) Qc[j * dof + c] = Q3[j * dof + c];
        Ec[j] = e3;
        Fc[j] = F3[j] & ~IKC_LOCK;
    }
    const int kept = ikc_finish(rb, g, n, Qc, Ec, Fc, 1, q, res, ls, cont);
    return kept == IKC_FAMILY_MISS ? ikc_hand_back(IKC_WHY_FAMILY) : kept;
}

/* Whether any of the n flags is set. */
static int ikc_any_set(int n, const int *x) {
    for (int j = 0; j < n; j++)
        if (x[j]) return 1;
    return 0;
}

/* Whether family leaf j still looks for an exact representative inside the limits in ikc_settle_chain's
 * polish (settle._polish_pending): a later representative can change only those. */
static int ikc_polish_pending(const ikc_robot *rb, const double *Q, const double *E, const int *F, int j,
                              int limits) {
    if (!(F[j] & IKC_FAMILY) || (F[j] & (IKC_EMPTY | IKC_LOCK))) return 0;
    return !(E[j] <= rb->tol * rb->scale && (!limits || ikc_row_inside(rb, Q + j * rb->dof)));
}

static int ikc_settle_chain(const ikc_robot *rb, ikc_chain_fn chain, int L, const double *g,
                            const double *fr, int limits, double *q, double *res, int *ls, int *cont,
                            int try_alt) {
    const int dof = rb->dof;
    double Q[L * dof], E[L];
    int F[L];
    int n = ikc_lock_leaves(chain, g, fr, 0.0, Q, E, F);
    if (try_alt && ikc_any_flag(n, F, IKC_FAMILY)) {  /* a gimbal lock: the alternative chain first */
        int ka = ikc_settle_alternative(rb, g, fr, limits, q, res, ls, cont);
        if (ka != IKC_FAMILY_MISS) return ka;
    }
    int k = ikc_finish(rb, g, n, Q, E, F, limits, q, res, ls, cont);
    if (k != IKC_FAMILY_MISS) return k;
    const double exact_tol = rb->tol * rb->scale, near = IKC_NEAR_MISS * rb->scale;
    /* the leaves of every other representative (RQ, RE, RF: rep r at r - 1), kept for the polish */
    double RQ[(IKC_REPS - 1) * L * dof], RE[(IKC_REPS - 1) * L], B[L * dof], EB[L], Q0[L * dof], E0[L],
        S[L * dof];
    int RF[(IKC_REPS - 1) * L], line[L], F0[L];
    for (int j = 0; j < n; j++) {  /* best variant so far, inside the limits (none yet: EB = inf) */
        for (int c = 0; c < dof; c++) B[j * dof + c] = Q0[j * dof + c] = Q[j * dof + c];
        E0[j] = E[j];
        F0[j] = F[j];
        EB[j] = (!limits || ikc_row_inside(rb, Q + j * dof)) ? E[j] : INFINITY;
        /* a candidate straight line: exact at rep = 0, or a tangent root there (its slopes come from the
         * first other rep) */
        line[j] = limits && (F[j] & IKC_FAMILY) && !(F[j] & (IKC_DEFER | IKC_EMPTY)) &&
                  (E[j] <= exact_tol || ((F[j] & IKC_TANGENT_ROOT) && E[j] < near));
    }
    int verdict[L];  /* ikc_line_verdict of a line (its t in VT), or -3 where not yet asked */
    int tangent[L], root[L];
    double VT[L];
    for (int j = 0; j < n; j++) {
        verdict[j] = -3;
        VT[j] = 0.0;
        tangent[j] = !(E0[j] <= exact_tol);
        root[j] = (F0[j] & IKC_TANGENT_ROOT) != 0;
    }
    int ran[IKC_REPS];  /* whether the chain ran at representative r (its leaves in RQ, RE, RF) */
    for (int r = 0; r < IKC_REPS; r++) ran[r] = 0;
    for (int r = 1; r < IKC_REPS; r++) {  /* the representatives' leaves, and which lie on a line */
        int step = (r + 1) / 2;  /* 1, 1, 2, 2, ...: pi/8, -pi/8, pi/4, -pi/4, ... */
        double rep = (r % 2 ? 1.0 : -1.0) * step * (IKC_TWO_PI / IKC_REPS);
        if (rep <= -IKC_PI_F) continue;
        if (r > 1 && !ikc_any_set(n, line)) break;  /* no line to fit: the polish runs the chain on demand */
        ran[r] = 1;
        double *Q2 = RQ + (r - 1) * L * dof;
        int *F2 = RF + (r - 1) * L;
        int n2 = ikc_lock_leaves(chain, g, fr, rep, Q2, RE + (r - 1) * L, F2);
        if (n2 != n) return ikc_hand_back(IKC_WHY_REPS);
        const double *E2 = RE + (r - 1) * L;
        ikc_fit_lines(rb, n, r, rep, Q2, E2, F2, Q0, line, S);
        if (r == 1) {  /* the slopes are known: the quick case, where it applies, needs no more reps */
            const int quick = ikc_quick_lines(rb, chain, L, n, g, fr, Q, E, F, Q0, line, S, tangent, root,
                                              Q2, E2, F2, q, res, ls, cont);
            if (quick != IKC_NOT_QUICK) return quick;
        }
    }
    /* A tangent line shown to miss the limits has no solution: decided before its representatives are
     * polished (docs/design.md section 6: each polish is 8 Newton steps, moot there). */
    for (int j = 0; j < n; j++) {
        if (line[j] && tangent[j]) {
            const int k = ikc_given_verdict(rb, j, verdict, line, Q0, S, tangent, root);
            if (k >= 0)
                verdict[j] = verdict[k], VT[j] = VT[k];
            else
                verdict[j] = ikc_line_verdict(rb, g, Q0 + j * dof, S + j * dof, 1, 0, VT + j);
            if (verdict[j] == 0) F[j] |= IKC_EMPTY;
        }
    }
    for (int r = 1; r < IKC_REPS; r++) {  /* each family leaf: the first representative exact inside */
        int step = (r + 1) / 2;
        double rep = (r % 2 ? 1.0 : -1.0) * step * (IKC_TWO_PI / IKC_REPS);
        if (rep <= -IKC_PI_F) continue;
        int pending = 0;
        for (int j = 0; j < n && !pending; j++) pending = ikc_polish_pending(rb, Q, E, F, j, limits);
        if (!pending) break;  /* every family leaf settled: the later representatives change nothing */
        double *Q2 = RQ + (r - 1) * L * dof, *E2 = RE + (r - 1) * L;
        int *F2 = RF + (r - 1) * L;
        if (!ran[r]) {
            if (ikc_lock_leaves(chain, g, fr, rep, Q2, E2, F2) != n) return ikc_hand_back(IKC_WHY_REPS);
            ran[r] = 1;
        }
        double PS[L * dof], PQ[L * dof], PE[L];  /* this representative's polishes, once per start */
        ikc_newton_memo polish = {0, L, PS, PQ, PE};
        for (int j = 0; j < n; j++) {
            if (!(F[j] & IKC_FAMILY) || (F[j] & (IKC_EMPTY | IKC_LOCK)) || !(F2[j] & IKC_FAMILY) ||
                (F2[j] & (IKC_DEFER | IKC_EMPTY)))
                continue;  /* a lock is settled by its line alone (below) */
            if (E[j] <= exact_tol && (!limits || ikc_row_inside(rb, Q + j * dof))) continue;  /* settled */
            double *row = Q2 + j * dof, e = E2[j];
            if (exact_tol < e && e < near) e = ikc_newton_once(rb, g, row, 8, &polish);  /* a tangent root */
            int inside = !limits || ikc_row_inside(rb, row);
            if (e <= exact_tol && inside) {
                for (int c = 0; c < dof; c++) Q[j * dof + c] = row[c];
                E[j] = e;
                F[j] = F2[j];
            } else if (inside && e < EB[j]) {
                for (int c = 0; c < dof; c++) B[j * dof + c] = row[c];
                EB[j] = e;
            }
        }
    }
    double Q3[L * dof], E3[L], NS[L * dof], NQ[L * dof], NE[L];
    int F3[L];
    ikc_newton_memo best = {0, L, NS, NQ, NE};  /* the 60 steps from each best variant, once per start */
    for (int j = 0; j < n; j++) {
        if (!(F[j] & IKC_FAMILY) || (F[j] & (IKC_DEFER | IKC_EMPTY))) continue;
        const int lock = F[j] & IKC_LOCK;  /* exact or not, a lock needs its line */
        if (!lock && E[j] <= exact_tol && (!limits || ikc_row_inside(rb, Q + j * dof))) continue;
        double t = VT[j];
        int found = -2;
        if (verdict[j] != -3) {
            found = verdict[j];
        } else if (line[j]) {
            const int k = ikc_given_verdict(rb, j, verdict, line, Q0, S, tangent, root);
            if (k >= 0)
                found = verdict[k], t = VT[k];
            else
                found = ikc_line_verdict(rb, g, Q0 + j * dof, S + j * dof, 0, root[j], &t);
            verdict[j] = found, VT[j] = t;
        }
        if (found != -2) {
            if (found == 0) {  /* the whole self-motion lies outside the limits: no solution here */
                F[j] |= IKC_EMPTY;
                continue;
            }
            double e3 = INFINITY;
            if (found == 1 && ikc_lock_leaves(chain, g, fr, t, Q3, E3, F3) == n && (F3[j] & IKC_FAMILY) &&
                !(F3[j] & (IKC_DEFER | IKC_EMPTY))) {
                e3 = E3[j];
                if (exact_tol < e3 && e3 < near) e3 = ikc_newton(rb, g, Q3 + j * dof, 15);
            }
            if (e3 <= exact_tol && ikc_row_inside(rb, Q3 + j * dof)) {
                for (int c = 0; c < dof; c++) Q[j * dof + c] = Q3[j * dof + c];
                E[j] = e3;
                F[j] = F3[j] & ~IKC_LOCK;  /* a representative of the line */
                continue;
            }
        }
        if (lock) return ikc_hand_back(IKC_WHY_LOCK);  /* no line: the rest of the chain may fix it */
        double e = ikc_newton_once(rb, g, B + j * dof, 60, &best);
        if (e <= exact_tol && (!limits || ikc_row_inside(rb, B + j * dof))) {
            for (int c = 0; c < dof; c++) Q[j * dof + c] = B[j * dof + c];
            E[j] = e;
        }
    }
    k = ikc_finish(rb, g, n, Q, E, F, limits, q, res, ls, cont);
    return k == IKC_FAMILY_MISS ? ikc_hand_back(IKC_WHY_FAMILY) : k;
}

/* Whether any filled leaf of n carries flag bit `bit`. */
/* A gimbal lock in the chain (a FAMILY leaf) where the plan has an alternative chain: the alternative
 * chain's leaves.  Where they meet no lock (and no degenerate geometry) they are every solution -- a
 * closed-form chain is complete where no step degenerates -- and the lock was no self-motion of the
 * target (a 5-joint arm's O-RRR gimbal, whose waist value the position fixes): their finish, as the
 * reference runtime's with_alternative.  Else IKC_FAMILY_MISS: the caller goes on as before.  Called by
 * ikc_settle_chain on the main chain's rep-0 leaves (the chain runs once). */
static int ikc_settle_alternative(const ikc_robot *rb, const double *g, const double *fr, int limits,
                                  double *q, double *res, int *ls, int *cont) {
    const int La = rb->leaves_alt, dof = rb->dof;
    double Qa[La * dof], Ea[La];
    int Fa[La];
    int na = rb->chain_alt(g, fr, 0.0, Qa, Ea, Fa);
    int filled = 0;
    for (int k = 0; k < na; k++) filled |= !(Fa[k] & IKC_EMPTY);
    if (!filled || ikc_any_flag(na, Fa, IKC_FAMILY | IKC_DEFER | IKC_LOCK)) return IKC_FAMILY_MISS;
    int k = ikc_finish(rb, g, na, Qa, Ea, Fa, limits, q, res, ls, cont);
    return k < 0 ? IKC_PYTHON : k;
}

/* The chain, then (where it cannot settle the target) the alternative chain. */
static int ikc_settle(const ikc_robot *rb, const double *g, const double *fr, int limits, double *q,
                      double *res, int *ls, int *cont) {
    int k = ikc_settle_chain(rb, rb->chain, rb->leaves, g, fr, limits, q, res, ls, cont, rb->chain_alt != 0);
    if (k == IKC_PYTHON && rb->chain_alt) {
        const int why = ikc_why;
        k = ikc_settle_chain(rb, rb->chain_alt, rb->leaves_alt, g, fr, limits, q, res, ls, cont, 0);
        ikc_why = k == IKC_PYTHON ? why + IKC_WHY_ALT * ikc_why : 0;
    }
    return k;
}

#define IKC_SEED_ERROR 1.0  /* grid minima missing by more than this (relative) are not seeds */

/* Twin seeds of a polished search row x (error ex) near a singular configuration: two roots of one
 * branch closer than a grid cell or two give one local minimum along the grid, and there they lie
 * along the Jacobian's null direction.  An exact row whose weakest singular value is below
 * IKC_TWIN_SINGULAR writes IKC_TWINS rows (with their errors and flags) offset along the weakest
 * direction (largest entry 1 in joint units) and Newton-polished; returns how many (0 or IKC_TWINS).
 * The C form of ikcompiler/runtime/reference.py twin_seeds (TWIN_OFFSETS, TWIN_SINGULAR). */
#define IKC_TWINS 6
#define IKC_TWIN_SINGULAR 0.05
static int ikc_twin_seeds(const ikc_robot *rb, const double *g, const double *x, double ex, double *out,
                          double *E, int *F) {
    static const double offsets[IKC_TWINS] = {-0.6, -0.2, -0.05, 0.05, 0.2, 0.6};
    const int dof = rb->dof;
    if (!(ex <= rb->tol * rb->scale)) return 0;
    int col[dof];
    double lam[dof], V[dof * dof];
    const int m = ikc_jtj_eigen(rb, x, col, lam, V);
    if (m == 0 || !(sqrt(lam[0] > 0.0 ? lam[0] : 0.0) < IKC_TWIN_SINGULAR)) return 0;
    double big = 0.0;
    for (int k = 0; k < m; k++)
        if (fabs(V[k * m]) > big) big = fabs(V[k * m]);
    if (!(big > 0.0)) return 0;
    for (int t = 0; t < IKC_TWINS; t++) {
        double *y = out + t * dof;
        for (int j = 0; j < dof; j++) y[j] = x[j];
        for (int k = 0; k < m; k++)
            y[col[k]] += offsets[t] * V[k * m] / big * (rb->revolute[col[k]] ? 1.0 : rb->scale);
        E[t] = ikc_newton_steps(rb, g, y, 8, 0, NULL);
        F[t] = IKC_TANGENT_ROOT;
    }
    return IKC_TWINS;
}

/* The search fallback (the module's _fast_search_candidates): the chain on every grid value of the
 * searched joint(s); the local minima of each leaf's error along the grid (circular; on a plateau its
 * first cell) within IKC_SEED_ERROR of the target get 8 Newton steps on the true robot, those near a
 * singular configuration their twin seeds (ikc_twin_seeds); then the finish.  1-D and 2-D grids.
 * Count or IKC_PYTHON. */
static int ikc_search(const ikc_robot *rb, const double *g, const double *fr, int limits, double *q,
                      double *res, int *ls, int *cont) {
    const int L = rb->leaves, dof = rb->dof, G = rb->grid, S = rb->nsearch;
    const int cells = S == 1 ? G : G * G;
    if (S < 1 || S > 2 || G < 3) return ikc_hand_back(IKC_WHY_SEARCH);
    double *E = malloc(sizeof(double) * (size_t)cells * L);
    double *Q = malloc(sizeof(double) * (size_t)cells * L * dof);
    int *F = malloc(sizeof(int) * (size_t)L);
    int *seed = malloc(sizeof(int) * (size_t)cells * L);
    int status = 0;
    if (!E || !Q || !F || !seed) status = IKC_PYTHON;
    double f2[rb->nfree + 2];
    for (int j = 0; j < rb->nfree; j++) f2[j] = fr[j];
    for (int cell = 0; !status && cell < cells; cell++) {
        int i0 = S == 1 ? cell : cell / G, i1 = cell % G;
        f2[rb->nfree] = -IKC_PI_F + IKC_TWO_PI * i0 / G;
        if (S == 2) f2[rb->nfree + 1] = -IKC_PI_F + IKC_TWO_PI * i1 / G;
        int n = rb->chain(g, f2, 0.0, Q + (size_t)cell * L * dof, E + (size_t)cell * L, F);
        if (n != L) status = IKC_PYTHON;
        for (int k = 0; k < n; k++) {
            double *e = E + (size_t)cell * L + k;
            if (*e != *e || (F[k] & IKC_EMPTY)) *e = INFINITY;
        }
    }
    int count = 0;
    const double bound = IKC_SEED_ERROR * rb->scale;
    for (int cell = 0; !status && cell < cells; cell++) {
        int i0 = S == 1 ? cell : cell / G, i1 = cell % G;
        for (int k = 0; k < L; k++) {
            double e = E[(size_t)cell * L + k];
            if (!(e <= bound)) continue;
            /* neighbours along each searched axis (circular) */
            int prev0 = S == 1 ? (i0 + G - 1) % G : ((i0 + G - 1) % G) * G + i1;
            int next0 = S == 1 ? (i0 + 1) % G : ((i0 + 1) % G) * G + i1;
            int minimum = e < E[(size_t)prev0 * L + k] && e <= E[(size_t)next0 * L + k];
            if (S == 2) {
                int prev1 = i0 * G + (i1 + G - 1) % G, next1 = i0 * G + (i1 + 1) % G;
                minimum = minimum && e < E[(size_t)prev1 * L + k] && e <= E[(size_t)next1 * L + k];
            }
            if (minimum) seed[count++] = cell * L + k;
        }
    }
    if (!status) {
        const int cap = count > 0 ? count * (1 + IKC_TWINS) : 1;
        double C[cap * dof], CE[cap];
        int CF[cap];
        for (int a = 0; a < count; a++) {
            for (int j = 0; j < dof; j++) C[a * dof + j] = Q[(size_t)seed[a] * dof + j];
            CE[a] = ikc_newton_steps(rb, g, C + a * dof, 8, 0, NULL);  /* plain steps, as the Python search */
            /* merged within IKC_SPLIT_ROOT, as the Python search: two seeds of one double root stop on
             * its flat valley up to ~1e-7 apart */
            CF[a] = IKC_TANGENT_ROOT;
        }
        int total = count;
        for (int a = 0; a < count; a++) total += ikc_twin_seeds(rb, g, C + a * dof, CE[a], C + total * dof,
                                                                CE + total, CF + total);
        status = ikc_finish(rb, g, total, C, CE, CF, limits, q, res, ls, cont);
        if (status < 0) status = IKC_PYTHON;
    }
    if (status == IKC_PYTHON) ikc_why = IKC_WHY_SEARCH;
    free(E);
    free(Q);
    free(F);
    free(seed);
    return status;
}

/* Smallest singular value of the true robot's Jacobian at q (rows of the target, lengths relative to
 * the size, prismatic columns times the size, free joints left out) by inverse iteration on J^T J:
 * the C form of subproblems.continuation._weakest, for its threshold test only. */
static double ikc_weakest(const ikc_robot *rb, const double *q) {
    int col[rb->dof], rows;
    double Sf[rb->dof * rb->dof];
    const int m = ikc_scaled_jtj(rb, q, col, Sf, &rows);
    if (m == 0) return INFINITY;
    double JtJ[m][m], x[m];
    for (int a = 0; a < m; a++) {
        for (int c = 0; c < m; c++) JtJ[a][c] = Sf[a * m + c];
        x[a] = 1.0 / sqrt((double)m) * (1.0 + 0.1 * a);
    }
    double lambda = INFINITY;
    for (int it = 0; it < 30; it++) {
        double M[m][m + 1], y[m], norm = 0.0;
        for (int a = 0; a < m; a++) {
            for (int c = 0; c < m; c++) M[a][c] = JtJ[a][c];
            M[a][m] = x[a];
        }
        if (!ikc_solve_linear(m, M, y)) return 0.0;
        for (int a = 0; a < m; a++) norm += y[a] * y[a];
        norm = sqrt(norm);
        if (!(norm > 0.0) || norm != norm) return 0.0;
        double next = 1.0 / norm;  /* |x| = 1: an upper bound of lambda_min that converges to it */
        for (int a = 0; a < m; a++) x[a] = y[a] / norm;
        if (fabs(next - lambda) <= 1e-3 * next) {
            lambda = next;
            break;
        }
        lambda = next;
    }
    return sqrt(lambda > 0.0 ? lambda : 0.0);
}

/* Joint distance of two rows: revolute values modulo 2 pi, prismatic ones relative to the size. */
static double ikc_row_distance(const ikc_robot *rb, const double *x, const double *y) {
    double m = 0.0;
    for (int j = 0; j < rb->dof; j++) {
        double d = fabs(x[j] - y[j]);
        if (rb->revolute[j]) {
            d = ikc_mod_two_pi(d);
            if (d > IKC_PI_F) d = IKC_TWO_PI - d;
        } else {
            d /= rb->scale;
        }
        if (!(d <= m)) m = d;  /* NaN wins */
    }
    return m;
}

#define IKC_MAX_MOVE 0.25      /* subproblems.continuation.MAX_MOVE */
#define IKC_SEPARATE 1e-6      /* subproblems.continuation.SEPARATE */
#define IKC_SNAPPED_LEAF 1e-9  /* subproblems.continuation.SNAPPED_LEAF: an exact leaf of the snapped robot */

/* A snapped plan (the module's _POLISH branch): leaves of the snapped robot's chain, each corrected by
 * Newton steps on the true robot, then the finish.  The correction is kept only where it is
 * certainly the leaf's own solution (subproblems.continuation, docs/calibrated.md): every exact leaf
 * converged, moved less than IKC_MAX_MOVE, no two distinct leaves ended on one solution, no corrected
 * leaf near a singular configuration, no least-squares leaf that nearly reaches the target (a pair of
 * solutions may be born there), no self-motion leaf.  Otherwise IKC_PYTHON: the Python continuation
 * takes the target.  Count or IKC_PYTHON (also for a leaf near a degenerate geometry of the snapped robot).
 *
 * A reduced chain (fewer joints than its target has DOF: a 5-joint arm for a pose) is solved from a
 * subset of the equations, and the snapped robot reaches almost no target of the true one: every leaf
 * misses by about the change in geometry, which says nothing of a fold.  There a near-miss leaf is
 * judged after its Newton steps on the true robot: one that ends exact is a corrected leaf like an
 * exact one (moved less than IKC_MAX_MOVE, not near a singular configuration); one that ends
 * least-squares is a minimum of the residual that no solution lies near while its Jacobian is well
 * conditioned (a 6 x 5 Jacobian has full rank at such a minimum, unlike a square one, whose
 * least-squares minima are singular); two near-miss leaves that start at one point (a pair clamped
 * onto a fold of the snapped chain: the true robot may have two solutions there) hand the target back.
 * (hextilt_flying_arm_5 of example-robot-data: every target went to Python, 48 ms a pose; docs/calibrated.md) */
static int ikc_polished(const ikc_robot *rb, const double *g, const double *fr, int limits, double *q,
                        double *res, int *ls, int *cont) {
    const int L = rb->leaves, dof = rb->dof;
    const double exact = rb->tol * rb->scale, leaf_exact = IKC_SNAPPED_LEAF * rb->scale;
    double Q[L * dof], E[L], Q0[L * dof];
    int F[L], good[L], near[L], any_exact = 0, fold = 0, tangent = 0;
    const int reduced = dof - rb->nfree < (rb->target == 0 ? 6 : 3);
    int n = rb->chain(g, fr, 0.0, Q, E, F);
    for (int k = 0; k < n; k++) {
        good[k] = near[k] = 0;
        if (F[k] & (IKC_DEFER | IKC_LOCK)) return ikc_hand_back(IKC_WHY_DEFER);
        if (F[k] & IKC_EMPTY) continue;
        if (F[k] & IKC_TANGENT_ROOT) tangent = 1;
        /* a self-motion of the snapped robot (also a gimbal lock where the plan has an alternative
         * chain: reference.with_alternative): whether the corrected row stays a representative (the
         * true robot leaves it unresolved) is the Python continuation's call (its `family` rows) */
        if (F[k] & IKC_FAMILY) return ikc_hand_back(IKC_WHY_SNAPPED);
        if (!(E[k] <= leaf_exact)) {  /* a least-squares leaf: a near miss may hide a pair of solutions */
            if (E[k] <= rb->near_singular * rb->scale) {
                if (!reduced) return ikc_hand_back(IKC_WHY_SNAPPED);
                near[k] = 1;  /* a reduced chain's leaf: judged after its Newton steps (below) */
            }
        } else {
            good[k] = 1;
        }
        for (int j = 0; j < dof; j++) Q0[k * dof + j] = Q[k * dof + j];
        E[k] = ikc_newton_steps(rb, g, Q + k * dof, rb->polish, 0, NULL);  /* plain steps, as the Python path */
        F[k] = 0;  /* as the Python path: a corrected leaf is a plain candidate */
        if (near[k]) {
            if (ikc_weakest(rb, Q + k * dof) < rb->near_singular) return ikc_hand_back(IKC_WHY_SNAPPED);
            good[k] = E[k] <= exact;
            if (good[k] && !(ikc_row_distance(rb, Q + k * dof, Q0 + k * dof) <= IKC_MAX_MOVE))
                return ikc_hand_back(IKC_WHY_SNAPPED);
        } else if (good[k]) {
            if (!(E[k] <= exact)) return ikc_hand_back(IKC_WHY_SNAPPED);
            if (!(ikc_row_distance(rb, Q + k * dof, Q0 + k * dof) <= IKC_MAX_MOVE)) return ikc_hand_back(IKC_WHY_SNAPPED);
            if (ikc_weakest(rb, Q + k * dof) < rb->near_singular) return ikc_hand_back(IKC_WHY_SNAPPED);
        } else if (E[k] <= exact) {
            /* a least-squares leaf ending exact: a pair born at a fold of the snapped robot, of which
             * Newton from the one leaf finds one (continuation.correct's `born` rows; panda.urdf at
             * 1e-6, seed 8: the sampled vector 0.015 rad from the leaf was lost) */
            return ikc_hand_back(IKC_WHY_SNAPPED);
        } else if ((E[k] < IKC_NEAR_MISS * rb->scale || !fold) && ikc_weakest(rb, Q + k * dof) < rb->near_singular) {
            /* ending just above the precision near a singular configuration: a double root the damped
             * steps stall at (continuation._double_root's rows; kuka_iiwa model.urdf at 1e-6, seed 8, q4 = 0:
             * the sample came back least-squares at 6e-12) */
            if (E[k] < IKC_NEAR_MISS * rb->scale) return ikc_hand_back(IKC_WHY_SNAPPED);
            fold = 1;  /* a least-squares leaf ending near a singular configuration */
        }
        if (E[k] <= exact) any_exact = 1;
    }
    /* No leaf ends exact and one ends near a singular configuration (a fold: the true robot may have a
     * pair of solutions there, which the snapped robot lacks -- every leaf of a chain with fewer joints
     * than the target misses it): the continuation seeds it, as it seeds every such row.  A target
     * with exact rows keeps the C answer: an unreachable branch's least-squares end is often singular
     * (a stretched elbow), and handing all those over cost 100x on kr16_2 at 1e-3. */
    if (!any_exact && fold) return ikc_hand_back(IKC_WHY_SNAPPED);
    /* No leaf ends exact and one met a tangent root on a reduced chain with an alternative chain: the
     * snapped O-RRR near its gimbal lock, its outer angles read off nearly parallel vectors; the
     * reference runtime takes the alternative chain (dispatch.Solver.tangent_misses; trossen px150 of
     * rtb-data at 1e-6, seed 8, q = (pi/2, -pi/2, pi/2, pi/2, pi/2): the sample's waist branch lost) */
    if (!any_exact && tangent && reduced && rb->chain_alt) return ikc_hand_back(IKC_WHY_SNAPPED);
    for (int a = 0; a < n; a++)
        for (int c = a + 1; c < n; c++)
            if (near[a] && near[c] && ikc_row_distance(rb, Q0 + a * dof, Q0 + c * dof) <= IKC_SEPARATE)
                return ikc_hand_back(IKC_WHY_SNAPPED);  /* a clamped pair of a reduced chain */
            else if (good[a] && good[c] && ikc_row_distance(rb, Q + a * dof, Q + c * dof) <= IKC_SEPARATE &&
                ikc_row_distance(rb, Q0 + a * dof, Q0 + c * dof) > IKC_SEPARATE)
                return ikc_hand_back(IKC_WHY_SNAPPED);  /* a collision: one branch went to the other's */
    int k = ikc_finish(rb, g, n, Q, E, F, limits, q, res, ls, cont);
    return k == IKC_FAMILY_MISS ? ikc_hand_back(IKC_WHY_FAMILY) : k;
}

static int ikc_solve_goal(const ikc_robot *rb, const double *g, const double *fr, int limits, double *q,
                          double *res, int *ls, int *cont) {
    ikc_why = 0;
    if (rb->nsearch) return ikc_search(rb, g, fr, limits, q, res, ls, cont);
    if (rb->polish) return ikc_polished(rb, g, fr, limits, q, res, ls, cont);
    return ikc_settle(rb, g, fr, limits, q, res, ls, cont);
}

/* One raw target: the solution count, IKC_PYTHON, or IKC_INVALID. */
static int ikc_one(const ikc_robot *rb, const double *T, const double *fr, int limits, double *q,
                   double *res, int *ls, int *cont) {
    double g[12];
    const int checked = ikc_goal_checked(rb, T, g);
    if (checked != 1) return checked == 0 ? IKC_INVALID : ikc_hand_back(IKC_WHY_ROTATION);
    return ikc_solve_goal(rb, g, fr, limits, q, res, ls, cont);
}

/* One raw target, exact solutions only (they come first): their count, IKC_PYTHON or IKC_INVALID. */
static int ikc_one_exact(const ikc_robot *rb, const double *T, const double *fr, int limits, double *q) {
    double res[rb->slots];
    int ls[rb->slots], cont[rb->slots];
    int k = ikc_one(rb, T, fr, limits, q, res, ls, cont);
    int e = 0;
    while (e < k && !ls[e]) e++;
    return k < 0 ? k : e;
}

typedef struct {
    const ikc_robot *rb;
    int64_t start, stop;
    const double *goals, *fr;
    int limits;
    double *q, *res;
    int *ls, *cont, *count;
} ikc_job;

static void *ikc_run(void *arg) {
    const ikc_job *job = (const ikc_job *)arg;
    const ikc_robot *rb = job->rb;
    const int dof = rb->dof, slots = rb->slots, stride = rb->target == 1 ? 3 : (rb->target == 2 ? 9 : 16);
    double g[12];
    for (int64_t i = job->start; i < job->stop; i++) {
        const int checked = ikc_goal_checked(rb, job->goals + stride * i, g);
        if (checked != 1) {
            job->count[i] = checked == 0 ? IKC_INVALID : IKC_PYTHON;
            continue;
        }
        job->count[i] = ikc_solve_goal(rb, g, job->fr + rb->nfree * i, job->limits, job->q + i * slots * dof,
                                   job->res + i * slots, job->ls + i * slots, job->cont + i * slots);
    }
    return NULL;
}

/* N raw targets (N x 16, 9 or 3 entries, as ikc_one takes them) and their free values (N x nfree) in
 * `threads` threads; count[i] is the solution count, IKC_PYTHON or IKC_INVALID. */
/* How many threads a batch of n poses takes: 1..64, and 1 below a few hundred poses a thread (a thread
 * costs more than that). */
static int ikc_threads_for(int64_t n, int threads) {
    if (threads < 1) threads = 1;
    if (threads > 64) threads = 64;
    return n < 256 * threads ? 1 : threads;
}

/* run(jobs[t]) for t < threads (`size` bytes a job): job 0 here, the others in threads of their own,
 * each share done here where no thread is to be had; returns when every share is done.  The drivers
 * below (ikc_many, the block path's, free_ends.h's) fill their jobs and call this. */
static void ikc_run_shares(int threads, void *(*run)(void *), void *jobs, size_t size) {
    pthread_t ids[64];
    int started[64] = {0};
    for (int t = 1; t < threads; t++) started[t] = pthread_create(&ids[t], NULL, run, (char *)jobs + t * size) == 0;
    run(jobs);
    for (int t = 1; t < threads; t++) {
        if (started[t])
            pthread_join(ids[t], NULL);
        else
            run((char *)jobs + t * size);
    }
}

static void ikc_many(const ikc_robot *rb, int64_t n, const double *goals, const double *fr, int limits,
                     double *q, double *res, int *ls, int *cont, int *count, int threads) {
    threads = ikc_threads_for(n, threads);
    ikc_job jobs[64];
    for (int t = 0; t < threads; t++) {
        jobs[t] = (ikc_job){rb, n * t / threads, n * (t + 1) / threads, goals, fr, limits, q, res, ls, cont,
                            count};
    }
    ikc_run_shares(threads, ikc_run, jobs, sizeof jobs[0]);
}

/* ---- the block path of a batch (docs/design.md section 14, "SIMD over poses") ----
 * A block chain (ikcompiler/codegen/printers.py c_lane_function, subproblems/lane_kernels.h) writes
 * the leaves of 4 poses at once: goal entry i of lane l at G[4 i + l], leaf k's joint j at
 * Q[4 (k dof + j) + l], its error at E[4 k + l], its flags at F[4 k + l] (IKC_TANGENT_ROOT and
 * IKC_FAMILY as the scalar chain's, IKC_LANE_AGAIN for a tangent root with libmvec's angles,
 * IKC_LANE_IRREGULAR where the scalar chain's leaf has another flag or its kernels took a rare branch).
 * A lane without an irregular leaf holds ikc_chain's leaves of its pose, flags and all, none LOCK:
 * their finish is what ikc_settle returns for it (such leaves go straight to ikc_finish there, a gimbal
 * lock's FAMILY leaves too where the plan has no alternative chain) whenever it returns a count.  A
 * lane with a tangent root or a near miss runs the block chain again with libm's angles (4 such lanes a
 * call, ikc_block_libm: its leaves are ikc_chain's bit for bit) before its finish.  Every other lane --
 * an irregular leaf, a finish that hands back or misses a family -- is solved by ikc_solve_goal from the
 * start, so the block path returns what ikc_many returns, target for target (bit for bit with libm's
 * angles in the lanes; to a few ulps of the angles with libmvec's). */
typedef int (*ikc_block_fn)(const double *G, double *Q, double *E, int64_t *F);
#define IKC_LANE_IRREGULAR 256  /* lane_kernels.h IKC_IRREGULAR */
#define IKC_LANE_AGAIN 512      /* lane_kernels.h IKC_LANE_AGAIN: a tangent root with libmvec's angles */

typedef struct {
    ikc_job job;
    ikc_block_fn block, block_libm;  /* block_libm: the block chain with libm's angles, or 0 */
    int leaves;
} ikc_block_job;

/* What becomes of lane l of a block call (n leaves; `libm`: the call had libm's angles, so its leaves are
 * ikc_chain's bit for bit): IKC_LANE_FINISH, its leaves go to ikc_finish; IKC_LANE_LIBM, the lane again
 * with libm's angles (a tangent root, or a near miss: its Newton steps in the finish amplify the lanes'
 * few-ulp angles along an ill-conditioned least-squares valley, 1e-10 .. 4e-9 rad measured), where the
 * block chain has that form; IKC_LANE_SCALAR, the scalar path from the start (every other flag). */
#define IKC_LANE_FINISH 0
#define IKC_LANE_LIBM 1
#define IKC_LANE_SCALAR 2
static int ikc_lane_kind(const ikc_robot *rb, const ikc_block_job *bj, int n, int l, const double *E,
                         const int64_t *F, int libm) {
    const double exact_tol = rb->tol * rb->scale, near = IKC_NEAR_MISS * rb->scale;
    /* a gimbal lock's leaves (IKC_FAMILY, the scalar kernel's values) go to the finish as ikc_settle_chain
     * gives them, unless an alternative chain is to be tried first */
    const int64_t allowed = IKC_TANGENT_ROOT | (rb->chain_alt ? 0 : IKC_FAMILY);
    int again = 0;
    for (int k = 0; k < n; k++) {
        const int64_t f = F[4 * k + l] & ~allowed;
        if (f & ~(int64_t)IKC_LANE_AGAIN) return IKC_LANE_SCALAR;
        again |= f != 0 || (!libm && exact_tol < E[4 * k + l] && E[4 * k + l] < near);
    }
    if (!again) return IKC_LANE_FINISH;
    return !libm && bj->block_libm ? IKC_LANE_LIBM : IKC_LANE_SCALAR;
}

/* Pose i from lane l of a block call: its leaves' finish (`finish`: what ikc_settle returns for it
 * whenever it returns a count), else -- or where that finish hands back or misses a family -- the
 * scalar path from the start. */
static void ikc_block_pose(const ikc_robot *rb, const ikc_job *job, int64_t i, int l, int n, const double *g,
                           const double *Q, const double *E, const int64_t *F, int finish) {
    const int dof = rb->dof, slots = rb->slots, m = n > 0 ? n : 1;
    double *q = job->q + i * slots * dof, *res = job->res + i * slots;
    int *ls = job->ls + i * slots, *cont = job->cont + i * slots;
    int count = IKC_PYTHON;
    if (finish) {
        double Ql[m * dof], El[m];
        int Fl[m];
        for (int t = 0; t < n * dof; t++) Ql[t] = Q[4 * t + l];  /* value t = k dof + j of leaf k */
        for (int k = 0; k < n; k++) {
            El[k] = E[4 * k + l];
            Fl[k] = (int)F[4 * k + l];
        }
        ikc_why = 0;
        count = ikc_finish(rb, g, n, Ql, El, Fl, job->limits, q, res, ls, cont);
    }
    if (count < 0) count = ikc_solve_goal(rb, g, job->fr + rb->nfree * i, job->limits, q, res, ls, cont);
    job->count[i] = count;
}

/* Up to 4 goals (poses idx[0..lanes-1]) through the block chain; each lane settled as ikc_lane_kind
 * says, except that the lanes to run again with libm's angles are gathered in `again` (idx, goals) and
 * their count returned; with `libm` the call is that run. */
static int ikc_block_lanes(const ikc_block_job *bj, int lanes, const int64_t *idx, double (*g)[12], int libm,
                           int64_t *again_idx, double (*again)[12], int na) {
    const ikc_job *job = &bj->job;
    const ikc_robot *rb = job->rb;
    const int dof = rb->dof, L = bj->leaves;
    double G[48], Q[4 * L * dof], E[4 * L];
    int64_t F[4 * L];
    for (int l = 0; l < 4; l++)  /* a lane without a pose of its own computes the first one's */
        for (int e = 0; e < 12; e++) G[4 * e + l] = g[l < lanes ? l : 0][e];
    const int n = (libm ? bj->block_libm : bj->block)(G, Q, E, F);
    for (int l = 0; l < lanes; l++) {
        const int kind = ikc_lane_kind(rb, bj, n, l, E, F, libm);
        if (kind == IKC_LANE_LIBM) {
            again_idx[na] = idx[l];
            for (int e = 0; e < 12; e++) again[na][e] = g[l][e];
            na++;
        } else {
            ikc_block_pose(rb, job, idx[l], l, n, g[l], Q, E, F, kind == IKC_LANE_FINISH);
        }
    }
    return na;
}

static void *ikc_run_block(void *arg) {
    const ikc_block_job *bj = (const ikc_block_job *)arg;
    const ikc_job *job = &bj->job;
    const ikc_robot *rb = job->rb;
    const int stride = rb->target == 1 ? 3 : (rb->target == 2 ? 9 : 16);
    double g[4][12], again[8][12];  /* lanes to run again with libm's angles: at most 4 + 3 pending */
    int64_t idx[4], again_idx[8];
    int na = 0;
    for (int64_t i = job->start; i < job->stop; i += 4) {
        const int lanes = job->stop - i < 4 ? (int)(job->stop - i) : 4;
        int ok = 0;
        for (int l = 0; l < lanes; l++) {
            const int checked = ikc_goal_checked(rb, job->goals + stride * (i + l), g[ok]);
            if (checked != 1) job->count[i + l] = checked == 0 ? IKC_INVALID : IKC_PYTHON;
            else idx[ok++] = i + l;
        }
        if (!ok) continue;
        na = ikc_block_lanes(bj, ok, idx, g, 0, again_idx, again, na);
        if (na >= 4) {
            ikc_block_lanes(bj, 4, again_idx, again, 1, NULL, NULL, 0);
            na -= 4;
            for (int a = 0; a < na; a++) {
                again_idx[a] = again_idx[4 + a];
                for (int e = 0; e < 12; e++) again[a][e] = again[4 + a][e];
            }
        }
    }
    if (na) ikc_block_lanes(bj, na, again_idx, again, 1, NULL, NULL, 0);
    return NULL;
}

/* ikc_many with a block chain of `leaves` leaves (closed-form chains without free joints; anything
 * else runs ikc_many). */
static void ikc_many_block(const ikc_robot *rb, ikc_block_fn block, ikc_block_fn block_libm, int leaves, int64_t n,
                           const double *goals,
                           const double *fr, int limits, double *q, double *res, int *ls, int *cont, int *count,
                           int threads) {
    if (rb->nsearch || rb->polish || rb->nfree || leaves != rb->leaves) {
        ikc_many(rb, n, goals, fr, limits, q, res, ls, cont, count, threads);
        return;
    }
    threads = ikc_threads_for(n, threads);
    ikc_block_job jobs[64];
    for (int t = 0; t < threads; t++) {
        /* each thread's share starts on a multiple of 4 poses */
        int64_t start = (n * t / threads) & ~(int64_t)3, stop = t + 1 == threads ? n : (n * (t + 1) / threads) & ~(int64_t)3;
        jobs[t] = (ikc_block_job){{rb, start, stop, goals, fr, limits, q, res, ls, cont, count}, block, block_libm,
                                  leaves};
    }
    ikc_run_shares(threads, ikc_run_block, jobs, sizeof jobs[0]);
}
