/* ---- general-6r modules with free end joints (ikcompiler/runtime/freeends.py) --------------------
 * With P the motion of the free joints before the six solved ones and S of those after, the pose
 * equation P X(q) S M = T is the 6R problem X(q) M = P^-1 T M^-1 S^-1 M: the free values move the
 * target.  Here the moved target, the elimination of the six on it (the module's ikc_robot, its finish
 * included) and the check of every exact row on the whole robot, in one call: done in Python around
 * the C call they cost ~10x the call itself (docs/design.md section 14, "Single pose with free end
 * joints").  Rows come back in the returned joints' order, the free values in their columns as given. */

#define IKC_WHY_WHOLE 10  /* an exact row of the six misses the precision on the whole robot */

typedef struct {
    const ikc_robot *six;    /* the six solved joints (their moved-target problem and its finish) */
    const ikc_robot *whole;  /* the whole robot (dof: the returned joints), for the exact rows' check */
    int nfree;
    const int *free_pos;     /* each free value's column among the returned joints */
    const int *solved_pos;   /* each solved joint's column among the returned joints */
    int nbefore, nafter;     /* free joints before / after the six, in chain order: */
    const int *before, *after;        /* their free-value indices */
    const double *tw_before, *tw_after;  /* their twists (v, w) */
    const double *home_inv;  /* M^-1 (rotation row-major, translation); M is six->home */
} ikc_free_ends;

/* (R, p) <- (R, p) exp(xi th) for the twist tw = (v, w): the arithmetic of ikc_fk_jacobian's joint */
static void ikc_fe_times_exp(double *R, double *p, const double *tw, double th) {
    const double *v = tw, *w = tw + 3;
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
        for (int k = 0; k < 3; k++)
            t[k] = wv[k] - (E[3 * k] * wv[0] + E[3 * k + 1] * wv[1] + E[3 * k + 2] * wv[2]) + w[k] * wdv * th;
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

/* c = a b of rigid motions (12 entries: rotation row-major, translation) */
static void ikc_fe_compose(const double *a, const double *b, double *c) {
    for (int r = 0; r < 3; r++) {
        for (int k = 0; k < 3; k++)
            c[3 * r + k] = a[3 * r] * b[k] + a[3 * r + 1] * b[3 + k] + a[3 * r + 2] * b[6 + k];
        c[9 + r] = a[3 * r] * b[9] + a[3 * r + 1] * b[10] + a[3 * r + 2] * b[11] + a[9 + r];
    }
}

/* the inverse of the motion of n joints (twists tw, values fr[idx[i]]) */
static void ikc_fe_inverse_motion(int n, const int *idx, const double *tw, const double *fr, double *out) {
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, p[3] = {0, 0, 0};
    for (int i = 0; i < n; i++) ikc_fe_times_exp(R, p, tw + 6 * i, fr[idx[i]]);
    for (int r = 0; r < 3; r++) {
        for (int k = 0; k < 3; k++) out[3 * r + k] = R[3 * k + r];
        out[9 + r] = -(R[r] * p[0] + R[3 + r] * p[1] + R[6 + r] * p[2]);
    }
}

/* The moved target P^-1 g M^-1 S^-1 M of goal g (12 entries) at free values fr. */
static void ikc_fe_moved(const ikc_free_ends *fe, const double *g, const double *fr, double *out) {
    double left[12], right[12], a[12];
    if (fe->nbefore) {
        ikc_fe_inverse_motion(fe->nbefore, fe->before, fe->tw_before, fr, a);
        ikc_fe_compose(a, g, left);
    } else {
        for (int k = 0; k < 12; k++) left[k] = g[k];
    }
    if (!fe->nafter) {
        for (int k = 0; k < 12; k++) out[k] = left[k];
        return;
    }
    ikc_fe_inverse_motion(fe->nafter, fe->after, fe->tw_after, fr, a);
    double b[12];
    ikc_fe_compose(fe->home_inv, a, b);
    ikc_fe_compose(b, fe->six->home, right);
    ikc_fe_compose(left, right, out);
}

/* One checked goal g: the rows of the six on the moved target as rows of the returned joints, each exact
 * row's residual measured on the whole robot; the count, or IKC_PYTHON (the six's finish hands back, or
 * an exact row misses on the whole robot: the Python path decides). */
static int ikc_fe_solve_goal(const ikc_free_ends *fe, const double *g, const double *fr, int limits, double *q,
                             double *res, int *ls, int *cont) {
    const ikc_robot *six = fe->six;
    const int n = fe->whole->dof;
    double moved[12], q6[six->slots * 6];
    ikc_fe_moved(fe, g, fr, moved);
    const int k = ikc_solve_goal(six, moved, fr, limits, q6, res, ls, cont);
    if (k < 0) return k;
    const double exact = fe->whole->tol * fe->whole->scale;
    for (int r = 0; r < k; r++) {
        double *row = q + r * n;
        for (int i = 0; i < 6; i++) row[fe->solved_pos[i]] = q6[6 * r + i];
        for (int j = 0; j < fe->nfree; j++) row[fe->free_pos[j]] = fr[j];
        if (ls[r]) continue;  /* a least-squares row keeps the moved target's error */
        const double e = ikc_measure(fe->whole, g, row);
        if (!(e <= exact)) return ikc_hand_back(IKC_WHY_WHOLE);
        res[r] = e;
    }
    return k;
}

/* One raw 4x4 target: the count, IKC_PYTHON or IKC_INVALID (as ikc_one). */
static int ikc_free_one(const ikc_free_ends *fe, const double *T, const double *fr, int limits, double *q,
                        double *res, int *ls, int *cont) {
    double g[12];
    ikc_why = 0;
    const int checked = ikc_goal_checked(fe->whole, T, g);
    if (checked != 1) return checked == 0 ? IKC_INVALID : ikc_hand_back(IKC_WHY_ROTATION);
    return ikc_fe_solve_goal(fe, g, fr, limits, q, res, ls, cont);
}

typedef struct {
    const ikc_free_ends *fe;
    int64_t start, stop;
    const double *goals, *fr;
    int limits;
    double *q, *res;
    int *ls, *cont, *count;
} ikc_fe_job;

static void *ikc_fe_run(void *arg) {
    const ikc_fe_job *job = (const ikc_fe_job *)arg;
    const ikc_free_ends *fe = job->fe;
    const int slots = fe->six->slots, n = fe->whole->dof;
    for (int64_t i = job->start; i < job->stop; i++)
        job->count[i] = ikc_free_one(fe, job->goals + 16 * i, job->fr + fe->nfree * i, job->limits,
                                     job->q + i * slots * n, job->res + i * slots, job->ls + i * slots,
                                     job->cont + i * slots);
    return NULL;
}

/* N 4x4 targets and their free values (N x nfree) in `threads` threads, as ikc_many. */
static void ikc_free_many(const ikc_free_ends *fe, int64_t n, const double *goals, const double *fr, int limits,
                          double *q, double *res, int *ls, int *cont, int *count, int threads) {
    threads = ikc_threads_for(n, threads);
    ikc_fe_job jobs[64];
    for (int t = 0; t < threads; t++)
        jobs[t] = (ikc_fe_job){fe, n * t / threads, n * (t + 1) / threads, goals, fr, limits, q, res, ls, cont,
                               count};
    ikc_run_shares(threads, ikc_fe_run, jobs, sizeof jobs[0]);
}
