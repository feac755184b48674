/* The general 6-joint elimination in C (docs/general6.md, "Native path"; docs/design.md section 5).
 *
 * The method is subproblems/general6.py's (Raghavan-Roth / Manocha-Canny in POE form, read its
 * docstring for the derivation); only the root finding differs.  Per target:
 *
 *   1. the right side B (14 x 9) of the fourteen quantities on the (a, b) grid, interpolated;
 *   2. its left null space (6 vectors) by a Householder QR with column pivoting of B' (no SVD);
 *   3. the 12 x 12 pencil in *trigonometric* form, M(phi) = M0 + M1 cos(phi) + M2 sin(phi), phi the
 *      joint value th_c itself (no half-angle, so no root at infinity and no shift: th_c = pi is an
 *      ordinary point);
 *   4. D(phi) = det M(phi) is a trigonometric polynomial of degree 8 (the 24 - 8 spurious half-angle
 *      roots at +-i of general6.py are the factor (1 + x^2)^4 that the trigonometric form never has:
 *      det M(x) / (1 + x^2)^12 = p16(x) / (1 + x^2)^8); its 17 coefficients come from D at G6_K
 *      equispaced angles (LU determinants) by a discrete Fourier transform, well conditioned because
 *      the points are on the circle.  The coefficients above 8 must vanish: their size is a check;
 *   5. the real roots of D on the circle: sign changes on a fine grid, refined by safeguarded Newton
 *      (bisection fallback); between grid points where D' changes sign and D does not, the extremum
 *      is located and a hidden pair of roots split there, or, when the extremum nearly touches zero,
 *      the target is *doubtful* (a near-double root);
 *   6. null vector of M(root) by inverse iteration (LU), back-substitution as general6.py.
 *
 * A doubtful target (B' near rank loss, the coefficient check failing, a near-double root, two roots
 * closer than G6_CLOSE, a clean candidate that Newton cannot bring to exact, two candidates that meet
 * after Newton) is handed to the Python
 * general6 (IKC_DEFER): the reference and fallback.  No LAPACK: every factorisation is written here.
 * The G6_* thresholds below mirror subproblems/tolerances.py (same names, same values: a test reads
 * both); iteration counts and grid sizes stay here. */

#define G6_K 20            /* samples of D on the circle: degree 8 needs 17; 9 and 10 are the check */
#define G6_GRID 48         /* first isolation cells on [0, 2 pi) */
#define G6_COEF_CHECK 1e-7 /* |coefficient 9 or 10| / max |coefficient| above this: doubtful */
#define G6_NEAR_DOUBLE 1e-3 /* estimated |imaginary part| of a near-real root pair below this: doubtful
                             * (a double root split by rounding can reach ~1e-5 on a flat tangency) */
#define G6_TOUCH 1e-10     /* |D| at a minimum of |D| below this times max |coefficient|: doubtful */
#define G6_NOISE 32.0      /* D's error bound: this times max |coefficient 9, 10| (which must vanish) */
#define G6_CLOSE 1e-7      /* two real roots (rad) closer than this: doubtful (a near-double root; tolerances.py) */
#define G6_COLLIDE 1e-4    /* two candidates closer than this after Newton (rad; prismatic / size): doubtful */
#define G6_HMIN 1e-9       /* isolation cells narrower than this that settle nothing: doubtful */
#define G6_STACK 256       /* isolation cells pending at once */
#define G6_RANK 1e-9       /* |R_last / R_first| of B' below this: doubtful (general6 brank) */
#define G6_NEWTON 8        /* Newton steps on the true robot per candidate */
#define G6_CLEAN 1e-6      /* prismatic pencils: a candidate missing by less (of the size) before Newton
                            * is a clean root, a farther one may be spurious */
#define G6_IMAG_TOL 2e-3   /* the eigenvalue path: |imaginary part| of a candidate angle kept for Newton */
#define G6_LEADING_OK 1e-9 /* the eigenvalue path: |det| / prod(row norms) of the leading matrix to use it */
#define G6_TWIN 1e-6       /* the eigenvalue path: two roots this close (rad) are read as two solutions */
#define G6_PINV_RCOND 1e-7 /* the eigenvalue path's Newton: singular values below this (relative) left out */
#define G6_UNDAMPED_RCOND 1e-13 /* ... for candidates it left between exact and G6_STALLED */
#define G6_STALLED 1e-3    /* ... (of the size) */
#define G6_COPY_ANGLE 1e-4 /* the eigenvalue path: two copies of the target rotated by this much (rad) */
#define G6_POOL 512        /* the eigenvalue path: exact rows pooled per target (xarm7 special poses filled
                            * 192 once the shallow rows were deepened) */
#define G6_SAME 1e-6       /* ... rows closer than this are one (the finish's VERIFY_SAME_ANGLE) */
#define G6_PLAIN_MARGIN 4.0  /* the eigenvalue path's Newton: an LU step where sigma_min / sigma_max is
                              * provably above this times its rcond ... */
#define G6_PLAIN_COND 1e-9    /* ... and above this (the undamped pass's rcond 1e-13 is too near rounding) */
#define G6_DEEP 1e-3           /* the eigenvalue path's Newton stops at this times the precision; an exact
                                * row above it is deepened (g6_eigen_source) */
#define G6_TRUNCATED_STEPS 18  /* the eigenvalue path's truncated Newton steps (general6.py 3 NEWTON_ITERS) */
#define G6_UNDAMPED_STEPS 30   /* ... then for the stalled ones (general6.py G6_UNDAMPED_STEPS) */

typedef struct {
    int sign;         /* +1 the chain, -1 its inverse */
    int conj;         /* the first conj joints have their axes mapped by the target */
    int order[6];     /* original joint index at positions a..f */
    int prism[6];     /* prismatic, in arrangement order (a, b, d, e can be; c and f are revolute) */
    int ncols;        /* columns of B' present */
    int cols[8];
    double w[18], r[18];  /* axes in arrangement order, normalised coordinates */
    double A[14 * 3 * 9]; /* left side: quantity, (1, c_c, s_c), (1,c_d,s_d) x (1,c_e,s_e) */
    double inv9[81];      /* interpolation on the (a, b) grid */
    double grid_ab[18];   /* (a, b) grid values */
    double u[3];          /* unit vector normal to w_f */
    double Mn_inv[12];    /* inverse normalised home pose (rotation row-major, translation) */
    double center[3], s;  /* normalisation: x_n = (x - center) / s */
} ikc_g6;

/* ---- small rigid-motion helpers (rotation row-major R[9], translation t[3]) -------------------- */

static void g6_rot(const double *w, double th, double *R) {
    double c = cos(th), s = sin(th), v = 1.0 - c;
    double x = w[0], y = w[1], z = w[2];
    R[0] = c + v * x * x;     R[1] = v * x * y - s * z; R[2] = v * x * z + s * y;
    R[3] = v * x * y + s * z; R[4] = c + v * y * y;     R[5] = v * y * z - s * x;
    R[6] = v * x * z - s * y; R[7] = v * y * z + s * x; R[8] = c + v * z * z;
}

/* the joint's motion: rotation by th about the line (r, w), or translation th w */
static void g6_joint(const double *w, const double *r, int prism, double th, double *R, double *t) {
    if (prism) {
        for (int k = 0; k < 9; k++) R[k] = (k % 4 == 0) ? 1.0 : 0.0;
        for (int k = 0; k < 3; k++) t[k] = th * w[k];
        return;
    }
    g6_rot(w, th, R);
    for (int i = 0; i < 3; i++) t[i] = r[i] - (R[3 * i] * r[0] + R[3 * i + 1] * r[1] + R[3 * i + 2] * r[2]);
}

/* (R, t) <- (R, t) (R2, t2) */
static void g6_compose(double *R, double *t, const double *R2, const double *t2) {
    double Rn[9], tn[3];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            Rn[3 * i + j] = R[3 * i] * R2[j] + R[3 * i + 1] * R2[3 + j] + R[3 * i + 2] * R2[6 + j];
        tn[i] = R[3 * i] * t2[0] + R[3 * i + 1] * t2[1] + R[3 * i + 2] * t2[2] + t[i];
    }
    for (int k = 0; k < 9; k++) R[k] = Rn[k];
    for (int k = 0; k < 3; k++) t[k] = tn[k];
}

/* y = R x + t (t NULL: R x); fast_kernels.h's ikc_mat_vec */
static void g6_apply(const double *R, const double *t, const double *x, double *y) {
    ikc_mat_vec(R, x, y);
    if (t)
        for (int i = 0; i < 3; i++) y[i] += t[i];
}

/* the fourteen quantities p, l, p.p, p.l, p x l, (p.p) l - 2 (p.l) p (general6.py _fourteen) */
static void g6_fourteen(const double *p, const double *l, double *q) {
    const double pp = ikc_dot(p, p), pl = ikc_dot(p, l);
    for (int k = 0; k < 3; k++) q[k] = p[k], q[3 + k] = l[k];
    q[6] = pp;
    q[7] = pl;
    ikc_cross(p, l, q + 8);
    for (int k = 0; k < 3; k++) q[11 + k] = pp * l[k] - 2.0 * pl * p[k];
}

/* ---- dense linear algebra ---------------------------------------------------------------------- */

/* LU with partial pivoting of the n x n matrix a (row-major, in place); piv the row order; returns the
 * determinant.  A zero pivot is replaced by a tiny one (inverse iteration at an exact root). */
static double g6_lu(int n, double *a, int *piv) {
    double det = 1.0;
    for (int k = 0; k < n; k++) {
        int p = k;
        double best = fabs(a[k * n + k]);
        for (int i = k + 1; i < n; i++)
            if (fabs(a[i * n + k]) > best) best = fabs(a[i * n + k]), p = i;
        piv[k] = p;
        if (p != k) {
            for (int j = 0; j < n; j++) {
                double tmp = a[k * n + j];
                a[k * n + j] = a[p * n + j];
                a[p * n + j] = tmp;
            }
            det = -det;
        }
        double d = a[k * n + k];
        det *= d;
        if (d == 0.0) a[k * n + k] = d = 1e-300;
        for (int i = k + 1; i < n; i++) {
            double f = a[i * n + k] / d;
            a[i * n + k] = f;
            if (f != 0.0)
                for (int j = k + 1; j < n; j++) a[i * n + j] -= f * a[k * n + j];
        }
    }
    return det;
}

/* x <- a^-1 x for the factors of g6_lu: every row interchange first (g6_lu swaps whole rows, so its
 * multipliers are in the final row order), then the two triangular solves.  (An earlier version
 * interleaved the interchanges with the elimination: not a^-1 x, residuals of 1-5 on random systems,
 * though inverse iteration at a root still found U's null direction.) */
static void g6_lu_solve(int n, const double *a, const int *piv, double *x) {
    for (int k = 0; k < n; k++)
        if (piv[k] != k) {
            double tmp = x[k];
            x[k] = x[piv[k]];
            x[piv[k]] = tmp;
        }
    for (int k = 0; k < n; k++)
        for (int i = k + 1; i < n; i++) x[i] -= a[i * n + k] * x[k];
    for (int k = n - 1; k >= 0; k--) {
        double s = x[k];
        for (int j = k + 1; j < n; j++) s -= a[k * n + j] * x[j];
        x[k] = s / a[k * n + k];
    }
}

/* Householder QR with column pivoting of the 14 x nc matrix B (column-major b[c][14], in place):
 * the reflectors stay below the diagonal, beta[k] their factors, rdiag the diagonal of R, perm the
 * column order.  Returns |R_last| / |R_first| (general6's rank ratio of B'). */
static double g6_qr(int nc, double b[][14], double *beta, double *rdiag, int *perm) {
    double norms[8];
    for (int c = 0; c < nc; c++) {
        perm[c] = c;
        double s = 0.0;
        for (int i = 0; i < 14; i++) s += b[c][i] * b[c][i];
        norms[c] = s;
    }
    for (int k = 0; k < nc; k++) {
        int p = k;  /* pivot: the remaining column of largest norm below row k (recomputed: 14 rows) */
        double best = -1.0;
        for (int c = k; c < nc; c++) {
            double s = 0.0;
            for (int i = k; i < 14; i++) s += b[c][i] * b[c][i];
            norms[c] = s;
            if (s > best) best = s, p = c;
        }
        if (p != k) {
            for (int i = 0; i < 14; i++) {
                double tmp = b[k][i];
                b[k][i] = b[p][i];
                b[p][i] = tmp;
            }
            int tp = perm[k];
            perm[k] = perm[p];
            perm[p] = tp;
        }
        double alpha = sqrt(norms[p] > 0.0 ? best : 0.0);
        double x0 = b[k][k];
        if (alpha == 0.0) {
            beta[k] = 0.0;
            rdiag[k] = 0.0;
            continue;
        }
        double v0 = x0 >= 0.0 ? x0 + alpha : x0 - alpha;
        rdiag[k] = x0 >= 0.0 ? -alpha : alpha;
        /* v = (v0, b[k][k+1..]) ; H = I - beta v v^T */
        double vv = v0 * v0;
        for (int i = k + 1; i < 14; i++) vv += b[k][i] * b[k][i];
        beta[k] = 2.0 / vv;
        b[k][k] = v0;
        for (int c = k + 1; c < nc; c++) {
            double s = 0.0;
            for (int i = k; i < 14; i++) s += b[k][i] * b[c][i];
            s *= beta[k];
            for (int i = k; i < 14; i++) b[c][i] -= s * b[k][i];
        }
    }
    double first = fabs(rdiag[0]), last = fabs(rdiag[nc - 1]);
    return first > 0.0 ? last / first : 0.0;
}

/* x <- Q^T x (transpose = false) or Q x (true) for the reflectors of g6_qr */
static void g6_qr_apply(int nc, double b[][14], const double *beta, double *x, int forward) {
    for (int s = 0; s < nc; s++) {
        int k = forward ? nc - 1 - s : s;
        if (beta[k] == 0.0) continue;
        double d = 0.0;
        for (int i = k; i < 14; i++) d += b[k][i] * x[i];
        d *= beta[k];
        for (int i = k; i < 14; i++) x[i] -= d * b[k][i];
    }
}

/* ---- the trigonometric polynomial D(phi) ------------------------------------------------------- */

/* D = a[0] + sum_k a_k cos k phi + b_k sin k phi (k = 1..8) and its first three derivatives at the
 * angle of cosine c1 and sine s1 */
static void g6_trig3(const double *a, const double *b, double c1, double s1, double *d) {
    double ck = 1.0, sk = 0.0;
    d[0] = a[0], d[1] = d[2] = d[3] = 0.0;
    for (int k = 1; k <= 8; k++) {
        double cn = ck * c1 - sk * s1, sn = sk * c1 + ck * s1;
        ck = cn, sk = sn;
        double even = a[k] * ck + b[k] * sk, odd = b[k] * ck - a[k] * sk;
        d[0] += even;
        d[1] += k * odd;
        d[2] -= (double)(k * k) * even;
        d[3] -= (double)(k * k * k) * odd;
    }
}

/* A zero of D (order 0) or of D' (order 1) in [lo, hi], where that derivative changes sign (its
 * value at lo is flo) and is monotone: Newton on it inside the bracket, bisection where a step leaves. */
static double g6_bracket(const double *a, const double *b, double lo, double hi, double flo, int order) {
    double x = 0.5 * (lo + hi);
    for (int it = 0; it < 80; it++) {
        double d[4];
        g6_trig3(a, b, cos(x), sin(x), d);
        const double f = d[order], df = d[order + 1];
        if (f == 0.0) return x;
        if ((f < 0.0) == (flo < 0.0)) lo = x, flo = f;
        else hi = x;
        double next = df != 0.0 ? x - f / df : 0.5 * (lo + hi);
        if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
        if (fabs(next - x) <= 4e-16 * (1.0 + fabs(x)) || hi - lo <= 4e-16 * (1.0 + fabs(x))) return next;
        x = next;
    }
    return x;
}

/* D, D' and D'' at phi (g6_trig3 at its cosine and sine) */
static void g6_trig(const double *a, const double *b, double phi, double *f, double *df, double *ddf) {
    double d[4];
    g6_trig3(a, b, cos(phi), sin(phi), d);
    *f = d[0];
    if (df) *df = d[1];
    if (ddf) *ddf = d[2];
}

/* a root of D in [lo, hi] where D(lo) = flo and D(hi) differ in sign */
static double g6_refine(const double *a, const double *b, double lo, double hi, double flo) {
    return g6_bracket(a, b, lo, hi, flo, 0);
}

/* a zero of D' in [lo, hi] where D' changes sign and is monotone */
static double g6_extremum(const double *a, const double *b, double lo, double hi) {
    double f, dlo;
    g6_trig(a, b, lo, &f, &dlo, NULL);
    return g6_bracket(a, b, lo, hi, dlo, 1);
}

/* cos and sin of the first isolation grid, 2 pi i / G6_GRID (printed by Python's math) */
static const double g6_grid_cos[G6_GRID] = {
    1.0, 0.9914448613738104, 0.9659258262890683, 0.9238795325112867, 0.8660254037844387, 0.7933533402912352,
    0.7071067811865476, 0.6087614290087207, 0.5000000000000001, 0.38268343236508984, 0.25881904510252074,
    0.1305261922200517, 6.123233995736766e-17, -0.1305261922200516, -0.25881904510252063,
    -0.3826834323650895, -0.4999999999999998, -0.6087614290087207, -0.7071067811865475, -0.793353340291235,
    -0.8660254037844387, -0.9238795325112867, -0.9659258262890682, -0.9914448613738104, -1.0,
    -0.9914448613738104, -0.9659258262890683, -0.9238795325112868, -0.8660254037844388, -0.7933533402912352,
    -0.7071067811865479, -0.6087614290087209, -0.5000000000000004, -0.3826834323650895, -0.25881904510252063,
    -0.13052619222005163, -1.8369701987210297e-16, 0.13052619222005127, 0.2588190451025203,
    0.38268343236508917, 0.5000000000000001, 0.6087614290087199, 0.7071067811865474, 0.7933533402912349,
    0.8660254037844384, 0.9238795325112868, 0.9659258262890681, 0.9914448613738104};
static const double g6_grid_sin[G6_GRID] = {
    0.0, 0.13052619222005157, 0.25881904510252074, 0.3826834323650898, 0.49999999999999994,
    0.6087614290087207, 0.7071067811865475, 0.7933533402912352, 0.8660254037844386, 0.9238795325112867,
    0.9659258262890683, 0.9914448613738104, 1.0, 0.9914448613738104, 0.9659258262890683, 0.9238795325112868,
    0.8660254037844387, 0.7933533402912352, 0.7071067811865476, 0.6087614290087209, 0.49999999999999994,
    0.3826834323650899, 0.258819045102521, 0.130526192220052, 1.2246467991473532e-16, -0.13052619222005177,
    -0.2588190451025208, -0.38268343236508967, -0.4999999999999997, -0.6087614290087207, -0.7071067811865471,
    -0.7933533402912349, -0.8660254037844384, -0.9238795325112868, -0.9659258262890683, -0.9914448613738104,
    -1.0, -0.9914448613738105, -0.9659258262890684, -0.923879532511287, -0.8660254037844386,
    -0.7933533402912357, -0.7071067811865477, -0.6087614290087209, -0.5000000000000004, -0.38268343236508956,
    -0.25881904510252157, -0.13052619222005168};


/* Real roots of D on [0, 2 pi) into roots (at most 16); -1 when doubtful.
 *
 * Certified isolation by subdivision.  On a cell of half-width r about its middle, Taylor's theorem
 * with the derivatives there and the bound L4 >= |D''''| (sum of k^4 |c_k|) bounds how far D, D'
 * and D'' can move from their middle values: the cell is root-free when D cannot reach zero, D is
 * monotone there when D' cannot (one root at a sign change), and D' is monotone when D'' cannot (at
 * most two roots, split at the extremum of D).  A cell narrower than G6_HMIN that none of these
 * settles, two roots closer than G6_CLOSE, an extremum that nearly touches zero (a complex pair
 * within G6_NEAR_DOUBLE of the real axis, or |D| below G6_TOUCH there) or D within its error bound
 * `noise` at a cell's middle make the target doubtful.  The bounds carry that error too (8^j noise
 * for the j-th derivative: the error is itself a trigonometric polynomial of degree 8). */
static int g6_roots(const double *a, const double *b, double noise, double *roots) {
    double L4 = 0.0, big = fabs(a[0]);
    for (int k = 1; k <= 8; k++) {
        double c = hypot(a[k], b[k]);
        L4 += (double)(k * k) * (k * k) * c;
        big = fmax(big, c);
    }
    if (!(big > 0.0)) return -1;
    int n = 0, top = 0;
    double lo[G6_STACK], hi[G6_STACK], flo[G6_STACK], fhi[G6_STACK];
    const double h0 = IKC_TWO_PI / G6_GRID;
    double fg[G6_GRID + 1], d[4];
    for (int i = 0; i < G6_GRID; i++) {
        g6_trig3(a, b, g6_grid_cos[i], g6_grid_sin[i], d);
        fg[i] = d[0];
    }
    fg[G6_GRID] = fg[0];
    for (int i = G6_GRID - 1; i >= 0; i--) {  /* pushed in reverse: taken in order */
        lo[top] = i * h0, hi[top] = (i + 1) * h0, flo[top] = fg[i], fhi[top] = fg[i + 1];
        top++;
    }
    while (top > 0) {
        top--;
        const double x0 = lo[top], x1 = hi[top], y0 = flo[top], y1 = fhi[top], h = x1 - x0;
        const double xm = 0.5 * (x0 + x1), r = 0.5 * h;
        g6_trig3(a, b, cos(xm), sin(xm), d);
        const double m2 = fabs(d[2]), m3 = fabs(d[3]);
        const double move0 = r * (fabs(d[1]) + r * (m2 / 2.0 + r * (m3 / 6.0 + r * L4 / 24.0)));
        const double move1 = r * (m2 + r * (m3 / 2.0 + r * L4 / 6.0));
        const double move2 = r * (m3 + r * L4 / 2.0);
        const double fm = d[0];
        /* D within its interpolation error (noise, from the coefficients that must vanish) at a
         * cell's middle: the sign means nothing there (a cluster of roots, a degenerate pose); a
         * simple root that close to a middle is a chance of order noise / |D'| */
        if (fabs(fm) < noise) return -1;
        if (fabs(fm) > move0 + noise) continue;  /* root-free, the error included */
        const int change = y0 == 0.0 || (y1 != 0.0 && (y0 < 0.0) != (y1 < 0.0));
        if (fabs(d[1]) > move1 + 8.0 * noise) {  /* monotone: one root where the sign changes */
            if (change) {
                if (n >= 16) return -1;
                roots[n++] = y0 == 0.0 ? x0 : g6_refine(a, b, x0, x1, y0);
            }
            continue;
        }
        if (fabs(d[2]) > move2 + 64.0 * noise) {  /* D' monotone: one extremum of D at most */
            double f, d0, d1;
            g6_trig(a, b, x0, &f, &d0, NULL);
            g6_trig(a, b, x1, &f, &d1, NULL);
            if ((d0 < 0.0) == (d1 < 0.0)) {  /* monotone after all */
                if (change) {
                    if (n >= 16) return -1;
                    roots[n++] = y0 == 0.0 ? x0 : g6_refine(a, b, x0, x1, y0);
                }
                continue;
            }
            const double xe = g6_extremum(a, b, x0, x1);
            double fe, de, dde;
            g6_trig(a, b, xe, &fe, &de, &dde);
            const int left = y0 == 0.0 || fe == 0.0 || (y0 < 0.0) != (fe < 0.0);
            const int right = y1 != 0.0 && fe != 0.0 && (fe < 0.0) != (y1 < 0.0);
            if (!left && !right) {  /* no root; at a minimum of |D|, a complex pair xe +- i y with
                                      * D ~ fe + dde (x - xe)^2 / 2, y = sqrt(2 fe / dde) */
                if (dde == 0.0 || (fe / dde > 0.0 && (2.0 * fe / dde < G6_NEAR_DOUBLE * G6_NEAR_DOUBLE ||
                                                      fabs(fe) < G6_TOUCH * big || fabs(fe) < 4.0 * noise)))
                    return -1;
                continue;
            }
            if (n + left + right > 16) return -1;
            if (left) roots[n++] = y0 == 0.0 ? x0 : (fe == 0.0 ? xe : g6_refine(a, b, x0, xe, y0));
            if (right) roots[n++] = g6_refine(a, b, xe, x1, fe);
            continue;
        }
        if (h < G6_HMIN || top + 2 > G6_STACK) return -1;
        lo[top] = xm, hi[top] = x1, flo[top] = fm, fhi[top] = y1;  /* the right half after the left */
        top++;
        lo[top] = x0, hi[top] = xm, flo[top] = y0, fhi[top] = fm;
        top++;
    }
    /* a root on a cell boundary may be found from both sides: merged; then close roots are doubtful */
    for (int i = 0; i < n; i++)
        for (int j = i + 1; j < n; j++) {
            double d = fabs(roots[i] - roots[j]);
            if (d > IKC_PI_F) d = IKC_TWO_PI - d;
            if (d < 1e-12) {
                roots[j--] = roots[--n];
                continue;
            }
            if (d < G6_CLOSE) return -1;
        }
    return n;
}


/* ---- eigenvalues of a real matrix (the doubtful targets' path, below) ------------------------------ */

/* Balance the n x n matrix a (row-major, in place) by powers of 2 (Parlett-Reinsch): the eigenvalues
 * are unchanged, their rounding errors scale with the balanced norm. */
static void g6_balance(int n, double *a) {
    for (int done = 0; !done;) {
        done = 1;
        for (int i = 0; i < n; i++) {
            double c = 0.0, r = 0.0;
            for (int j = 0; j < n; j++)
                if (j != i) c += fabs(a[n * j + i]), r += fabs(a[n * i + j]);
            if (!(c > 0.0 && r > 0.0)) continue;
            double g = r / 2.0, f = 1.0;
            const double s = c + r;
            while (c < g) f *= 2.0, c *= 4.0;
            g = r * 2.0;
            while (c > g) f /= 2.0, c /= 4.0;
            if ((c + r) / f < 0.95 * s) {
                done = 0;
                for (int j = 0; j < n; j++) a[n * i + j] /= f;
                for (int j = 0; j < n; j++) a[n * j + i] *= f;
            }
        }
    }
}

/* Reduce a to upper Hessenberg form by stabilised elementary similarity transforms (the multipliers
 * are left below the subdiagonal; g6_hqr ignores them). */
static void g6_hessenberg(int n, double *a) {
    for (int m = 1; m < n - 1; m++) {
        double x = 0.0;
        int i = m;
        for (int j = m; j < n; j++)
            if (fabs(a[n * j + m - 1]) > fabs(x)) x = a[n * j + m - 1], i = j;
        if (i != m) {
            for (int j = m - 1; j < n; j++) {
                double t = a[n * i + j];
                a[n * i + j] = a[n * m + j], a[n * m + j] = t;
            }
            for (int j = 0; j < n; j++) {
                double t = a[n * j + i];
                a[n * j + i] = a[n * j + m], a[n * j + m] = t;
            }
        }
        if (x == 0.0) continue;
        for (i = m + 1; i < n; i++) {
            double y = a[n * i + m - 1];
            if (y == 0.0) continue;
            y /= x;
            a[n * i + m - 1] = y;
            for (int j = m; j < n; j++) a[n * i + j] -= y * a[n * m + j];
            for (int j = 0; j < n; j++) a[n * j + m] += y * a[n * j + i];
        }
    }
}

/* Eigenvalues (wr + i wi) of the upper Hessenberg matrix a (destroyed) by the Francis double-shift QR
 * algorithm; 0, or -1 when an eigenvalue takes more than 60 iterations. */
static int g6_hqr(int n, double *a, double *wr, double *wi) {
#define H(i, j) a[n * (i) + (j)]
    double anorm = 0.0, t = 0.0, p = 0.0, q = 0.0, r = 0.0, x, y, z, w, s, u, v;
    for (int i = 0; i < n; i++)
        for (int j = i > 0 ? i - 1 : 0; j < n; j++) anorm += fabs(H(i, j));
    int nn = n - 1, l;
    while (nn >= 0) {
        int its = 0;
        do {
            for (l = nn; l >= 1; l--) {
                s = fabs(H(l - 1, l - 1)) + fabs(H(l, l));
                if (s == 0.0) s = anorm;
                if (fabs(H(l, l - 1)) + s == s) {
                    H(l, l - 1) = 0.0;
                    break;
                }
            }
            x = H(nn, nn);
            if (l == nn) {
                wr[nn] = x + t, wi[nn] = 0.0;
                nn--;
            } else {
                y = H(nn - 1, nn - 1);
                w = H(nn, nn - 1) * H(nn - 1, nn);
                if (l == nn - 1) {
                    p = 0.5 * (y - x);
                    q = p * p + w;
                    z = sqrt(fabs(q));
                    x += t;
                    if (q >= 0.0) {
                        z = p + (p >= 0.0 ? z : -z);
                        wr[nn - 1] = wr[nn] = x + z;
                        if (z != 0.0) wr[nn] = x - w / z;
                        wi[nn - 1] = wi[nn] = 0.0;
                    } else {
                        wr[nn - 1] = wr[nn] = x + p;
                        wi[nn - 1] = -z, wi[nn] = z;
                    }
                    nn -= 2;
                } else {
                    if (its == 60) return -1;
                    if (its == 10 || its == 20) {  /* exceptional shift */
                        t += x;
                        for (int i = 0; i <= nn; i++) H(i, i) -= x;
                        s = fabs(H(nn, nn - 1)) + fabs(H(nn - 1, nn - 2));
                        y = x = 0.75 * s;
                        w = -0.4375 * s * s;
                    }
                    ++its;
                    int m;
                    for (m = nn - 2; m >= l; m--) {
                        z = H(m, m);
                        r = x - z;
                        s = y - z;
                        p = (r * s - w) / H(m + 1, m) + H(m, m + 1);
                        q = H(m + 1, m + 1) - z - r - s;
                        r = H(m + 2, m + 1);
                        s = fabs(p) + fabs(q) + fabs(r);
                        p /= s, q /= s, r /= s;
                        if (m == l) break;
                        u = fabs(H(m, m - 1)) * (fabs(q) + fabs(r));
                        v = fabs(p) * (fabs(H(m - 1, m - 1)) + fabs(z) + fabs(H(m + 1, m + 1)));
                        if (u + v == v) break;
                    }
                    for (int i = m + 2; i <= nn; i++) {
                        H(i, i - 2) = 0.0;
                        if (i != m + 2) H(i, i - 3) = 0.0;
                    }
                    for (int k = m; k <= nn - 1; k++) {
                        if (k != m) {
                            p = H(k, k - 1);
                            q = H(k + 1, k - 1);
                            r = k != nn - 1 ? H(k + 2, k - 1) : 0.0;
                            if ((x = fabs(p) + fabs(q) + fabs(r)) != 0.0) p /= x, q /= x, r /= x;
                        }
                        s = sqrt(p * p + q * q + r * r);
                        if (p < 0.0) s = -s;
                        if (s == 0.0) continue;
                        if (k == m) {
                            if (l != m) H(k, k - 1) = -H(k, k - 1);
                        } else {
                            H(k, k - 1) = -s * x;
                        }
                        p += s;
                        x = p / s, y = q / s, z = r / s;
                        q /= p, r /= p;
                        for (int j = k; j <= nn; j++) {
                            p = H(k, j) + q * H(k + 1, j);
                            if (k != nn - 1) {
                                p += r * H(k + 2, j);
                                H(k + 2, j) -= p * z;
                            }
                            H(k + 1, j) -= p * y;
                            H(k, j) -= p * x;
                        }
                        const int mmin = nn < k + 3 ? nn : k + 3;
                        for (int i = l; i <= mmin; i++) {
                            p = x * H(i, k) + y * H(i, k + 1);
                            if (k != nn - 1) {
                                p += z * H(i, k + 2);
                                H(i, k + 2) -= p * r;
                            }
                            H(i, k + 1) -= p * q;
                            H(i, k) -= p;
                        }
                    }
                }
            }
        } while (l < nn - 1);
    }
    return 0;
#undef H
}

/* One-sided Jacobi SVD of the n x n matrix a (row-major, in place: its columns become U Sigma): the
 * singular values sv (unsorted) and the right singular vectors, V's columns (row-major v).  The
 * doubtful targets' path only (twin roots' 2-D null spaces, the truncated Newton below). */
static void g6_svd(int n, double *a, double *sv, double *v) {
    for (int i = 0; i < n * n; i++) v[i] = (i % (n + 1) == 0) ? 1.0 : 0.0;
    for (int sweep = 0; sweep < 40; sweep++) {
        int rotated = 0;
        for (int p = 0; p < n - 1; p++)
            for (int q = p + 1; q < n; q++) {
                double al = 0.0, be = 0.0, ga = 0.0;
                for (int i = 0; i < n; i++) {
                    al += a[n * i + p] * a[n * i + p];
                    be += a[n * i + q] * a[n * i + q];
                    ga += a[n * i + p] * a[n * i + q];
                }
                if (!(fabs(ga) > 1e-15 * sqrt(al * be)) || ga == 0.0) continue;
                rotated = 1;
                const double zeta = (be - al) / (2.0 * ga);
                const double t = (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
                const double c = 1.0 / sqrt(1.0 + t * t), sn = c * t;
                for (int i = 0; i < n; i++) {
                    const double x = a[n * i + p], y = a[n * i + q];
                    a[n * i + p] = c * x - sn * y, a[n * i + q] = sn * x + c * y;
                    const double vx = v[n * i + p], vy = v[n * i + q];
                    v[n * i + p] = c * vx - sn * vy, v[n * i + q] = sn * vx + c * vy;
                }
            }
        if (!rotated) break;
    }
    for (int j = 0; j < n; j++) {
        double s = 0.0;
        for (int i = 0; i < n; i++) s += a[n * i + j] * a[n * i + j];
        sv[j] = sqrt(s);
    }
}

/* The truncated step of g6_truncated_newton where it truncates nothing: dq = Js^-1 e by LU, when
 * 1 / (|Js|_F |Js^-1|_F), a lower bound of sigma_min / sigma_max, shows that every singular value is
 * above G6_PLAIN_MARGIN times rcond (and above G6_PLAIN_COND): then the pseudo-inverse step keeps every
 * singular value and is this step.  0 (dq untouched) otherwise: the SVD decides.  A 6 x 6 LU and its
 * inverse take about a third of the Jacobi SVD's instructions (callgrind: ~5 k against ~15 k), and the
 * SVD steps were half of the eigenvalue path's instructions. */
static int g6_plain_step(const double *Js, const double *e, double rcond, double *dq) {
    double L[36], inv[36];
    int piv[6];
    double na = 0.0, ni = 0.0;
    for (int i = 0; i < 36; i++) L[i] = Js[i], na += Js[i] * Js[i];
    if (g6_lu(6, L, piv) == 0.0) return 0;
    for (int j = 0; j < 6; j++) {
        double x[6] = {0, 0, 0, 0, 0, 0};
        x[j] = 1.0;
        g6_lu_solve(6, L, piv, x);
        for (int i = 0; i < 6; i++) inv[6 * i + j] = x[i], ni += x[i] * x[i];
    }
    const double bound = 1.0 / sqrt(na * ni);
    if (!(bound > G6_PLAIN_MARGIN * rcond && bound > G6_PLAIN_COND)) return 0;
    for (int i = 0; i < 6; i++) {
        double s = 0.0;
        for (int j = 0; j < 6; j++) s += inv[6 * i + j] * e[j];
        dq[i] = s;
    }
    return 1;
}

/* Truncated Gauss-Newton on the true robot toward goal g (general6.py _newton): columns scaled to unit
 * norm, singular values of the Jacobian below rcond times the largest left out, so that at a double
 * root the step never moves along the weak direction, which the eigenvalue read gave accurately (the
 * damped ikc_newton runs along it); steps bounded to 0.5 rad; the best iterate kept.  Returns its
 * error.  (A 6-joint robot: rb->dof == 6.) */
static double g6_truncated_newton(const ikc_robot *rb, const double *g, double *q, int iters, double rcond) {
    double G[12], J[36], best[6], x[6];
    for (int i = 0; i < 6; i++) x[i] = best[i] = q[i];
    double best_err = INFINITY;
    const double done = G6_DEEP * rb->tol * rb->scale;  /* deeper than general6.py: double roots */
    for (int it = 0; it <= iters; it++) {
        ikc_fk_jacobian(rb, x, G, J);
        const double err = ikc_pose_error(rb, G, g);
        if (!(err == err)) break;
        if (err < best_err) {
            best_err = err;
            for (int i = 0; i < 6; i++) best[i] = x[i];
        }
        if (err <= done || it == iters) break;
        /* far after general6.py's first 6 steps: a near-real complex root, not a solution */
        if (it == 6 && best_err > G6_STALLED * rb->scale) break;
        double e[6];
        for (int k = 0; k < 3; k++) e[k] = g[9 + k] - G[9 + k], e[3 + k] = 0.0;
        for (int c = 0; c < 3; c++) {
            const double a0 = G[c], a1 = G[3 + c], a2 = G[6 + c], b0 = g[c], b1 = g[3 + c], b2 = g[6 + c];
            e[3] += 0.5 * (a1 * b2 - a2 * b1);
            e[4] += 0.5 * (a2 * b0 - a0 * b2);
            e[5] += 0.5 * (a0 * b1 - a1 * b0);
        }
        double col[6], Js[36], sv[6], V[36];
        for (int j = 0; j < 6; j++) {
            double s = 0.0;
            for (int r = 0; r < 6; r++) s += J[r * 6 + j] * J[r * 6 + j];
            col[j] = sqrt(s) > 1e-300 ? sqrt(s) : 1e-300;
            for (int r = 0; r < 6; r++) Js[r * 6 + j] = J[r * 6 + j] / col[j];
        }
        double dq[6] = {0, 0, 0, 0, 0, 0};
        if (!g6_plain_step(Js, e, rcond, dq)) {
            g6_svd(6, Js, sv, V);  /* Js V = U S: the columns of Js are now U S */
            double top = 0.0;
            for (int j = 0; j < 6; j++) top = fmax(top, sv[j]);
            for (int j = 0; j < 6; j++) {
                if (!(sv[j] > rcond * top)) continue;
                double proj = 0.0;  /* (U S)_j . e / s_j^2 = u_j . e / s_j */
                for (int r = 0; r < 6; r++) proj += Js[r * 6 + j] * e[r];
                proj /= sv[j] * sv[j];
                for (int i = 0; i < 6; i++) dq[i] += V[6 * i + j] * proj;
            }
        }
        double step = 0.0;
        for (int i = 0; i < 6; i++) dq[i] /= col[i], step = fmax(step, fabs(dq[i]));
        const double f = step > 0.5 ? 0.5 / step : 1.0;
        for (int i = 0; i < 6; i++) x[i] += f * dq[i];
    }
    for (int i = 0; i < 6; i++) q[i] = best[i];
    return best_err;
}

/* The two monomial vectors in the 2-D null space (V1, V2) of M at a root shared by two solutions
 * (general6.py _two_monomial_vectors): u = b V1 + a V2 is one exactly when every identity
 * u_p u_q = u_r u_s of the layout x_d^i x_e^j (i <= 3, j <= 2) holds; each is a quadratic form in
 * (b, a), all multiples of the one whose two roots are the two solutions: the top eigenvector of the
 * Gram matrix of their coefficients (power iteration on 3 x 3). */
static void g6_two_vectors(const double *V1, const double *V2, double *u1, double *u2) {
    double Gm[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    for (int p = 0; p < 12; p++)
        for (int q = p; q < 12; q++)
            for (int r = 0; r < 12; r++)
                for (int t = r; t < 12; t++) {
                    if (r * 12 + t <= p * 12 + q) continue;  /* each pair of pairs once */
                    if (p / 3 + q / 3 != r / 3 + t / 3 || p % 3 + q % 3 != r % 3 + t % 3) continue;
                    const double h[3] = {V1[p] * V1[q] - V1[r] * V1[t],
                                         V1[p] * V2[q] + V2[p] * V1[q] - V1[r] * V2[t] - V2[r] * V1[t],
                                         V2[p] * V2[q] - V2[r] * V2[t]};
                    for (int i = 0; i < 3; i++)
                        for (int j = 0; j < 3; j++) Gm[i][j] += h[i] * h[j];
                }
    double h[3] = {0.57, 0.61, 0.55};
    for (int it = 0; it < 100; it++) {
        double y[3], nrm = 0.0;
        for (int i = 0; i < 3; i++) y[i] = Gm[i][0] * h[0] + Gm[i][1] * h[1] + Gm[i][2] * h[2], nrm += y[i] * y[i];
        nrm = sqrt(nrm);
        if (!(nrm > 0.0)) break;
        for (int i = 0; i < 3; i++) h[i] = y[i] / nrm;
    }
    /* h0 b^2 + h1 a b + h2 a^2 = 0: the ratio of the larger coefficient's variable */
    const double disc = sqrt(fmax(h[1] * h[1] - 4.0 * h[0] * h[2], 0.0));
    for (int sgn = 0; sgn < 2; sgn++) {
        const double num = -h[1] + (sgn ? -disc : disc);
        double b = 1.0, a = 1.0;
        if (fabs(h[2]) >= fabs(h[0])) a = h[2] != 0.0 ? num / (2.0 * h[2]) : 0.0;
        else b = h[0] != 0.0 ? num / (2.0 * h[0]) : 0.0;
        double *u = sgn ? u2 : u1;
        for (int i = 0; i < 12; i++) u[i] = b * V1[i] + a * V2[i];
    }
}


/* ---- the elimination ---------------------------------------------------------------------------- */

static const double g6_probe[12] = {0.31, -0.77, 0.52, 0.13, -0.48, 0.91, -0.26, 0.67, -0.84, 0.39, 0.58, -0.19};

/* A joint from consecutive monomials (num = its variable times den): th = 2 atan2(num, den) from the
 * pair of largest magnitude (the half-angle tangent, valid at th = pi), or for a prismatic joint (its
 * monomials are powers of the displacement itself) num / den from the pair of largest den
 * (general6.py _read_ratio) */
static double g6_ratio(int n, const double *den, const double *num, int prism) {
    int best = 0;
    double m = -1.0;
    for (int k = 0; k < n; k++) {
        double s = prism ? fabs(den[k]) : den[k] * den[k] + num[k] * num[k];
        if (s > m) m = s, best = k;
    }
    return prism ? num[best] / den[best] : 2.0 * atan2(num[best], den[best]);
}

/* (1, cos th, sin th) of a revolute joint, (1, d, d^2) of a prismatic one (general6.py _basis) */
static void g6_basis(double th, int prism, double *u) {
    u[0] = 1.0;
    u[1] = prism ? th : cos(th);
    u[2] = prism ? th * th : sin(th);
}

/* Candidates of goal g (12 entries, robot units) in the original joint order, prismatic values in
 * robot units: their count (at most 16), or -1 when the target is doubtful. */
static int g6_candidates(const ikc_g6 *G, const double *g, double *Qout, int *eig);

static int ikc_g6_candidates(const ikc_g6 *G, const double *g, double *Qout) {
    return g6_candidates(G, g, Qout, NULL);
}

/* Why the eigenvalue path's candidates of one source may be incomplete (g6_candidates' *eig): B' near
 * rank loss (its null space is not the equations'), no shift with a regular leading matrix (M(th)
 * nearly singular at the four angles tried: a pencil singular at the target) */
#define G6_WEAK_RIGHT 1
#define G6_WEAK_LEADING 2

/* general6.py's SHIFTS: th_c = delta + 2 atan(y), delta chosen so that the leading matrix is regular */
static const double g6_shifts[4] = {0.6180339887498949, 2.0943951023931953, -1.3089969389957472, 2.6179938779914944};

/* The uncertified candidates of the doubtful targets' path (g6_candidates with eig set; general6.py
 * _candidates in C): the pencil in y = tan((th - delta) / 2), (1 + y^2) M(th) = P0 + P1 y + P2 y^2,
 * its 24 x 24 companion's eigenvalues (balanced, Hessenberg, Francis QR), every th = delta + 2 atan(y)
 * whose imaginary part is below G6_IMAG_TOL (near-real pairs: a double root split by rounding), the
 * null vector of M(th) by inverse iteration; roots closer than G6_TWIN also read as the two monomial
 * vectors of a 2-D null space.  Thetas into rth, vectors into rv (at most 32); their count or -1. */
static int g6_eigen_roots(double Mt[3][12][12], double *rth, double rv[][12], int *weak) {

    double P[3][144], best = -1.0, delta = g6_shifts[0];
    for (int k = 0; k < 4; k++) {  /* the shift whose leading matrix is best conditioned (Hadamard) */
        const double cd = cos(g6_shifts[k]), sd = sin(g6_shifts[k]);
        double L[144], logrows = 0.0;
        int piv[12];
        for (int i = 0; i < 12; i++) {
            double rn = 0.0;
            for (int j = 0; j < 12; j++) {
                const double A = Mt[1][i][j] * cd + Mt[2][i][j] * sd;
                L[12 * i + j] = Mt[0][i][j] - A;
                rn += L[12 * i + j] * L[12 * i + j];
            }
            logrows += 0.5 * log(rn > 1e-300 ? rn : 1e-300);
        }
        const double ratio = log(fabs(g6_lu(12, L, piv)) + 1e-300) - logrows;
        if (ratio > best || k == 0) {
            best = ratio, delta = g6_shifts[k];
            if (ratio > log(G6_LEADING_OK)) break;
        }
    }
    if (!(best > log(G6_LEADING_OK))) *weak |= G6_WEAK_LEADING;
    const double cd = cos(delta), sd = sin(delta);
    for (int i = 0; i < 12; i++)
        for (int j = 0; j < 12; j++) {
            const double A = Mt[1][i][j] * cd + Mt[2][i][j] * sd, B = Mt[2][i][j] * cd - Mt[1][i][j] * sd;
            P[0][12 * i + j] = Mt[0][i][j] + A;
            P[1][12 * i + j] = 2.0 * B;
            P[2][12 * i + j] = Mt[0][i][j] - A;
        }
    int piv[12];
    g6_lu(12, P[2], piv);
    double Kl[576];
    for (int i = 0; i < 576; i++) Kl[i] = 0.0;
    for (int i = 0; i < 12; i++) Kl[24 * i + 12 + i] = 1.0;
    for (int half = 0; half < 2; half++)
        for (int j = 0; j < 12; j++) {
            double x[12];
            for (int i = 0; i < 12; i++) x[i] = P[half][12 * i + j];
            g6_lu_solve(12, P[2], piv, x);
            for (int i = 0; i < 12; i++) Kl[24 * (12 + i) + 12 * half + j] = -x[i];
        }
    for (int i = 0; i < 576; i++)
        if (!isfinite(Kl[i])) return -1;
    double wr[24], wi[24];
    g6_balance(24, Kl);
    g6_hessenberg(24, Kl);
    if (g6_hqr(24, Kl, wr, wi) < 0) return -1;
    int n = 0;
    for (int k = 0; k < 24; k++) {
        const double u = wr[k], v = wi[k];
        const double re = 0.5 * atan2(2.0 * u, 1.0 - u * u - v * v);
        const double im = 0.25 * log((u * u + (v + 1.0) * (v + 1.0)) / (u * u + (v - 1.0) * (v - 1.0)));
        if (!isfinite(re) || !isfinite(im) || !(fabs(2.0 * im) < G6_IMAG_TOL)) continue;
        if (v < 0.0) {  /* a conjugate pair gives one candidate (its real part): the v > 0 member */
            int twin = 0;
            for (int j = 0; j < 24; j++)
                if (j != k && wr[j] == u && wi[j] == -v) twin = 1;
            if (twin) continue;
        }
        rth[n++] = ikc_wrap(delta + 2.0 * re);
    }
    /* null vectors; twins also from the 2-D null space */
    const int roots = n;
    for (int k = 0; k < roots; k++) {
        const double c = cos(rth[k]), s = sin(rth[k]);
        double L[144];
        for (int i = 0; i < 12; i++)
            for (int j = 0; j < 12; j++) L[12 * i + j] = Mt[0][i][j] + c * Mt[1][i][j] + s * Mt[2][i][j];
        int twin = 0;
        for (int j = 0; j < roots; j++) {
            double d = fabs(rth[j] - rth[k]);
            if (d > IKC_PI_F) d = IKC_TWO_PI - d;
            if (j != k && d < G6_TWIN) twin = 1;
        }
        if (twin && n + 2 <= 32) {
            double Ls[144], sv[12], V[144], V1[12], V2[12];
            for (int i = 0; i < 144; i++) Ls[i] = L[i];
            g6_svd(12, Ls, sv, V);
            int a = 0, b2 = 1;
            if (sv[b2] < sv[a]) a = 1, b2 = 0;
            for (int j = 2; j < 12; j++) {
                if (sv[j] < sv[a]) b2 = a, a = j;
                else if (sv[j] < sv[b2]) b2 = j;
            }
            for (int i = 0; i < 12; i++) V1[i] = V[12 * i + a], V2[i] = V[12 * i + b2];
            g6_two_vectors(V1, V2, rv[n], rv[n + 1]);
            rth[n] = rth[n + 1] = rth[k];
            for (int r = n; r < n + 2; r++) {
                double mx = 0.0;
                for (int i = 0; i < 12; i++) mx = fmax(mx, fabs(rv[r][i]));
                for (int i = 0; i < 12; i++) rv[r][i] = mx > 0.0 ? rv[r][i] / mx : 0.0;
            }
            n += 2;
        }
        g6_lu(12, L, piv);
        double *v = rv[k];
        for (int i = 0; i < 12; i++) v[i] = g6_probe[i];
        for (int it = 0; it < 2; it++) {
            g6_lu_solve(12, L, piv, v);
            double mx = 0.0;
            for (int i = 0; i < 12; i++) mx = fmax(mx, fabs(v[i]));
            if (!(mx > 0.0) || !isfinite(mx)) break;
            for (int i = 0; i < 12; i++) v[i] /= mx;
        }
    }
    return n;
}

/* Candidates of goal g: the certified path (eig NULL, ikc_g6_candidates) or the doubtful targets'
 * uncertified eigenvalue path (eig set, g6_eigen_roots; at most 32 candidates, non-finite ones left NaN
 * for Newton to drop; *eig receives the source's G6_WEAK_* flags). */
static int g6_candidates(const ikc_g6 *G, const double *g, double *Qout, int *eig) {
    /* normalised target Tn and Gn = Tn Mn^-1, inverted for the inverse chain */
    double R[9], t[3];
    for (int k = 0; k < 9; k++) R[k] = g[k];
    for (int k = 0; k < 3; k++) t[k] = (g[9 + k] - G->center[k]) / G->s;
    g6_compose(R, t, G->Mn_inv, G->Mn_inv + 9);
    if (G->sign < 0) {
        double Ri[9], ti[3];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) Ri[3 * i + j] = R[3 * j + i];
        for (int i = 0; i < 3; i++) ti[i] = -(Ri[3 * i] * t[0] + Ri[3 * i + 1] * t[1] + Ri[3 * i + 2] * t[2]);
        for (int k = 0; k < 9; k++) R[k] = Ri[k];
        for (int k = 0; k < 3; k++) t[k] = ti[k];
    }
    /* per-target axes: the first conj joints mapped by the target */
    double W[18], P[18];
    for (int k = 0; k < 6; k++) {
        if (k < G->conj) {
            g6_apply(R, NULL, G->w + 3 * k, W + 3 * k);
            g6_apply(R, t, G->r + 3 * k, P + 3 * k);
        } else {
            for (int i = 0; i < 3; i++) W[3 * k + i] = G->w[3 * k + i], P[3 * k + i] = G->r[3 * k + i];
        }
    }
    double y[3], m[3];
    g6_apply(R, t, G->r + 15, y);
    g6_apply(R, NULL, G->w + 15, m);
    /* the fourteen quantities of X_b^-1 X_a^-1 (y, m) on the (a, b) grid, then interpolated */
    double F[9][14], B[9][14];
    for (int k = 0; k < 9; k++) {
        double Ra[9], ta[3], Rb[9], tb[3], p1[3], l1[3], p2[3], l2[3];
        g6_joint(W, P, G->prism[0], -G->grid_ab[2 * k], Ra, ta);
        g6_joint(W + 3, P + 3, G->prism[1], -G->grid_ab[2 * k + 1], Rb, tb);
        g6_apply(Ra, ta, y, p1);
        g6_apply(Ra, NULL, m, l1);
        g6_apply(Rb, tb, p1, p2);
        g6_apply(Rb, NULL, l1, l2);
        g6_fourteen(p2, l2, F[k]);
    }
    for (int q = 0; q < 9; q++)
        for (int j = 0; j < 14; j++) {
            double s = 0.0;
            for (int k = 0; k < 9; k++) s += G->inv9[9 * q + k] * F[k][j];
            B[q][j] = s;
        }
    /* left null space of B' (its present columns) */
    const int nc = G->ncols;
    double Bp[8][14], beta[8], rdiag[8];
    int perm[8];
    for (int c = 0; c < nc; c++)
        for (int i = 0; i < 14; i++) Bp[c][i] = B[1 + G->cols[c]][i];
    if (eig) *eig = 0;
    if (g6_qr(nc, Bp, beta, rdiag, perm) < G6_RANK) {
        if (!eig) return -1;
        *eig |= G6_WEAK_RIGHT;
    }
    double Nl[6][14];
    for (int e = 0; e < 6; e++) {
        for (int i = 0; i < 14; i++) Nl[e][i] = (i == 8 + e) ? 1.0 : 0.0;
        g6_qr_apply(nc, Bp, beta, Nl[e], 1);
    }
    /* C[e][t][j] = N^T A, the right side's constant column moved over; then to x_d, x_e monomials */
    double Cm[6][3][9];
    for (int e = 0; e < 6; e++) {
        for (int tt = 0; tt < 3; tt++)
            for (int j = 0; j < 9; j++) {
                double s = 0.0;
                for (int q = 0; q < 14; q++) s += Nl[e][q] * G->A[(q * 3 + tt) * 9 + j];
                Cm[e][tt][j] = s;
            }
        double s = 0.0;
        for (int q = 0; q < 14; q++) s += Nl[e][q] * B[0][q];
        Cm[e][0][0] -= s;
    }
    /* (1, c, s) times (1 + x^2) in powers of x: 1 -> (1, 0, 1), c -> (1, 0, -1), s -> (0, 2, 0); a
     * prismatic d or e has its basis (1, d, d^2) already in monomials: the identity */
    static const double half[3][3] = {{1.0, 0.0, 1.0}, {1.0, 0.0, -1.0}, {0.0, 2.0, 0.0}};
    static const double same[3][3] = {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}};
    const double (*hd)[3] = G->prism[3] ? same : half, (*he)[3] = G->prism[4] ? same : half;
    double Mt[3][12][12];
    for (int tt = 0; tt < 3; tt++)
        for (int i = 0; i < 12; i++)
            for (int j = 0; j < 12; j++) Mt[tt][i][j] = 0.0;
    for (int e = 0; e < 6; e++)
        for (int tt = 0; tt < 3; tt++)
            for (int md = 0; md < 3; md++)
                for (int me = 0; me < 3; me++) {
                    double s = 0.0;
                    for (int td = 0; td < 3; td++)
                        for (int te = 0; te < 3; te++)
                            s += Cm[e][tt][3 * td + te] * hd[td][md] * he[te][me];
                    Mt[tt][e][3 * md + me] = s;
                    Mt[tt][6 + e][3 * md + 3 + me] = s;
                }
    for (int i = 0; i < 12; i++) {  /* rows of equal weight */
        double s = 0.0;
        for (int tt = 0; tt < 3; tt++)
            for (int j = 0; j < 12; j++) s += Mt[tt][i][j] * Mt[tt][i][j];
        s = s > 0.0 ? 1.0 / sqrt(s) : 1.0;
        for (int tt = 0; tt < 3; tt++)
            for (int j = 0; j < 12; j++) Mt[tt][i][j] *= s;
    }
    double rth[32], rv[32][12];
    int nr = 0;
    if (eig) {
        nr = g6_eigen_roots(Mt, rth, rv, eig);
        if (nr < 0) return -1;
    } else {
    /* D on the circle, its Fourier coefficients */
    double D[G6_K], a[11], b[11], ck[G6_K], sk[G6_K];
    for (int k = 0; k < G6_K; k++) ck[k] = cos(IKC_TWO_PI * k / G6_K), sk[k] = sin(IKC_TWO_PI * k / G6_K);
    for (int k = 0; k < G6_K; k++) {
        double c = ck[k], s = sk[k], L[144];
        int piv[12];
        for (int i = 0; i < 12; i++)
            for (int j = 0; j < 12; j++) L[12 * i + j] = Mt[0][i][j] + c * Mt[1][i][j] + s * Mt[2][i][j];
        D[k] = g6_lu(12, L, piv);
    }
    for (int f = 0; f <= 10; f++) {
        double sa = 0.0, sb = 0.0;
        for (int k = 0; k < G6_K; k++) {
            const int idx = (f * k) % G6_K;
            sa += D[k] * ck[idx];
            sb += D[k] * sk[idx];
        }
        double w = (f == 0 || 2 * f == G6_K) ? 1.0 / G6_K : 2.0 / G6_K;
        a[f] = w * sa;
        b[f] = w * sb;
    }
    double big = 0.0, tail = 0.0;
    for (int f = 0; f <= 8; f++) big = fmax(big, fmax(fabs(a[f]), fabs(b[f])));
    for (int f = 9; f <= 10; f++) tail = fmax(tail, fmax(fabs(a[f]), fabs(b[f])));
    if (!(tail <= G6_COEF_CHECK * big)) return -1;
    double roots[16];
    /* D's interpolation error: the vanishing coefficients measure it (each of the 17 is as noisy) */
    const int n = g6_roots(a, b, G6_NOISE * (tail > 1e-16 * big ? tail : 1e-16 * big), roots);
    if (n < 0) return -1;
    /* each root: null vector, then the other joints */
    for (int k = 0; k < n; k++) {
        const double thc = roots[k] > IKC_PI_F ? roots[k] - IKC_TWO_PI : roots[k];
        double c = cos(thc), s = sin(thc), L[144], *v = rv[nr];
        int piv[12];
        rth[nr++] = thc;
        for (int i = 0; i < 12; i++)
            for (int j = 0; j < 12; j++) L[12 * i + j] = Mt[0][i][j] + c * Mt[1][i][j] + s * Mt[2][i][j];
        g6_lu(12, L, piv);
        for (int i = 0; i < 12; i++) v[i] = g6_probe[i];
        for (int it = 0; it < 2; it++) {
            g6_lu_solve(12, L, piv, v);
            double mx = 0.0;
            for (int i = 0; i < 12; i++) mx = fmax(mx, fabs(v[i]));
            if (!(mx > 0.0) || !isfinite(mx)) return -1;
            for (int i = 0; i < 12; i++) v[i] /= mx;
        }
    }
    }
    for (int k = 0; k < nr; k++) {
        const double thc = rth[k], c = cos(thc), s = sin(thc), *v = rv[k];
        /* v[3 i + j] = x_d^i x_e^j, i <= 3, j <= 2 */
        double den[9], num[9];
        for (int i = 0; i < 9; i++) den[i] = v[i], num[i] = v[i + 3];
        const double thd = g6_ratio(9, den, num, G->prism[3]);
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 2; j++) den[2 * i + j] = v[3 * i + j], num[2 * i + j] = v[3 * i + j + 1];
        const double the = g6_ratio(8, den, num, G->prism[4]);
        const double tc[3] = {1.0, c, s};
        double ud[3], ue[3];
        g6_basis(thd, G->prism[3], ud);
        g6_basis(the, G->prism[4], ue);
        double rhs[14];
        for (int q = 0; q < 14; q++) {
            double acc = 0.0;
            for (int tt = 0; tt < 3; tt++)
                for (int j = 0; j < 9; j++) acc += G->A[(q * 3 + tt) * 9 + j] * tc[tt] * ud[j / 3] * ue[j % 3];
            rhs[q] = acc - B[0][q];
        }
        /* least squares B' m = rhs through the QR: m = P R^-1 (Q^T rhs)[:nc] */
        g6_qr_apply(nc, Bp, beta, rhs, 0);
        double z[8], mab[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        for (int r = nc - 1; r >= 0; r--) {
            double acc = rhs[r];
            for (int c2 = r + 1; c2 < nc; c2++) acc -= Bp[c2][r] * z[c2];
            z[r] = acc / rdiag[r];
        }
        for (int r = 0; r < nc; r++) mab[G->cols[perm[r]]] = z[r];
        /* Kab = a b^T (rank one): a = (1, c_a, s_a) or (1, d_a, d_a^2) up to scale, likewise b */
        double K[9] = {1.0, mab[0], mab[1], mab[2], mab[3], mab[4], mab[5], mab[6], mab[7]};
        double tha, thb;
        if (G->prism[0] || G->prism[1]) {
            tha = G->prism[0] ? K[3] : atan2(K[6], K[3]);
            thb = G->prism[1] ? K[1] : atan2(K[2], K[1]);
        } else {
            double av[3], bv[3];
            for (int r = 0; r < 3; r++) {
                av[r] = K[3 * r] * K[0] + K[3 * r + 1] * K[1] + K[3 * r + 2] * K[2];
                bv[r] = K[r] * K[0] + K[3 + r] * K[3] + K[6 + r] * K[6];
            }
            tha = atan2(av[2], av[1]);
            thb = atan2(bv[2], bv[1]);
        }
        double th[6] = {tha, thb, thc, thd, the, 0.0};
        /* th_f from the rotation left over: X_a ... X_e R_f = Gn */
        double XR[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, Xt[3] = {0, 0, 0};
        for (int j = 0; j < 5; j++) {
            double Rj[9], tj[3];
            g6_joint(W + 3 * j, P + 3 * j, G->prism[j], th[j], Rj, tj);
            g6_compose(XR, Xt, Rj, tj);
        }
        double Rf[9];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                Rf[3 * i + j] = XR[i] * R[j] + XR[3 + i] * R[3 + j] + XR[6 + i] * R[6 + j];
        double Ru[3], cr[3];
        g6_apply(Rf, NULL, G->u, Ru);
        const double *u = G->u, *wf = G->w + 15;
        ikc_cross(u, Ru, cr);
        th[5] = atan2(ikc_dot(cr, wf), ikc_dot(Ru, u));
        for (int j = 0; j < 6; j++) {
            double x = th[j];
            if (G->prism[j]) x *= G->s;
            if (!isfinite(x) && !eig) return -1;
            Qout[6 * k + G->order[j]] = x;
        }
    }
    return nr;
}

/* One arrangement's leaves for goal g: every candidate after G6_NEWTON Newton steps on the true robot,
 * exact ones as plain leaves, far ones empty; their count, or -1 when the target is doubtful under this
 * arrangement (a candidate stalled short of exact, two candidates that met). */
static int g6_arrangement_leaves(const ikc_robot *rb, const ikc_g6 *G, const double *g, double *Q, double *E,
                                 int *F) {
    int n = ikc_g6_candidates(G, g, Q);
    if (n < 0) return -1;
    const double exact = rb->tol * rb->scale;
    int clean[16];
    for (int k = 0; k < n; k++) {
        /* with all 8 columns of B' the pencil's real roots are all solutions (its 8 spurious roots
         * are at +-i); with fewer (a prismatic joint's absent products) its null space is larger than
         * the 6 vectors taken and real spurious roots appear: a far candidate may be one of them */
        clean[k] = G->ncols == 8 || ikc_measure(rb, g, Q + 6 * k) <= G6_CLEAN * rb->scale;
        double e = ikc_newton(rb, g, Q + 6 * k, G6_NEWTON);
        E[k] = e;
        F[k] = 0;
        /* exact, but the steps stopped short of their margin (1e-3 of the precision) at a near-singular
         * configuration: the row is located only to e / sigma, doubtful when that exceeds G6_SAME
         * (tiago_pro.urdf at 1e-6, seed 8, q = (0, 0, 0, 0, pi/2, pi/2, 0): sigma 2.7e-7, the row
         * exact to 7.6e-13 lay 2e-6 from the sampled vector) */
        if (e <= exact && e > 1e-3 * exact && e > G6_SAME * rb->scale * ikc_weakest(rb, Q + 6 * k)) return -1;
        if (e <= exact) continue;
        /* a clean root that Newton cannot finish, near or far: a double root in disguise or a null
         * vector misread beside a close root (dropping the far ones lost 2 of 8 solutions on Jaco
         * poses with every joint at 0, +-pi/2 or pi) */
        if (e != e || clean[k]) return -1;
        F[k] = IKC_EMPTY;  /* a spurious root of a prismatic pencil (started far, went nowhere) */
    }
    /* two clean roots whose candidates met: a near-double root (Newton took both to one solution, or
     * the pencil's rounding split one double root) */
    for (int i = 0; i < n; i++)
        for (int j = i + 1; j < n; j++)
            if (clean[i] && clean[j] && !(F[i] & IKC_EMPTY) && !(F[j] & IKC_EMPTY) &&
                ikc_row_distance(rb, Q + 6 * i, Q + 6 * j) < G6_COLLIDE)
                return -1;
    return n;
}

/* The target g rotated by th about the unit axis w through the normalisation centre (general6.py
 * rotates the normalised goal about its origin, the same point) */
static void g6_rotated_target(const ikc_g6 *G, const double *w, double th, const double *g, double *out) {
    double Rr[9];
    g6_rot(w, th, Rr);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            out[3 * i + j] = Rr[3 * i] * g[j] + Rr[3 * i + 1] * g[3 + j] + Rr[3 * i + 2] * g[6 + j];
    double d[3] = {g[9] - G->center[0], g[10] - G->center[1], g[11] - G->center[2]}, y[3];
    ikc_mat_vec(Rr, d, y);
    for (int i = 0; i < 3; i++) out[9 + i] = y[i] + G->center[i];
}

/* general6.py's _PERTURB: the axes of its rotated copies */
static const double g6_copy_axes[2][3] = {{0.49297937126024555, -0.8307369262465643, 0.2585488326840085},
                                          {0.05063565066984169, 0.9585454499271961, 0.28040444237763246}};

/* One eigenvalue source of g6_eigen_leaves: the candidates of arrangement G for the target gr (g or a
 * rotated copy), each polished toward the true target g by truncated Newton steps (g6_truncated_newton:
 * they keep the weak direction the eigenvector read gave), the stalled ones by plain steps; the exact
 * rows appended to the pool P (error PE, *np of them).  Its G6_WEAK_* flags (0: none), or -1 when the
 * source gave no candidates (the companion's QR did not converge, a non-finite companion). */
static int g6_eigen_source(const ikc_robot *rb, const ikc_g6 *G, const double *gr, const double *g, double *P,
                           double *PE, int *np) {
    const double exact = rb->tol * rb->scale;
    double Qc[6 * 32];
    int weak = 0;
    const int n = g6_candidates(G, gr, Qc, &weak);
    if (n < 0) return -1;
    for (int j = 0; j < n && *np < G6_POOL; j++) {
        double *q = Qc + 6 * j;
        double e = g6_truncated_newton(rb, g, q, G6_TRUNCATED_STEPS, G6_PINV_RCOND);
        if (e > exact && e < G6_STALLED * rb->scale)  /* stalled: a near-double root (_undamped) */
            e = g6_truncated_newton(rb, g, q, G6_UNDAMPED_STEPS, G6_UNDAMPED_RCOND);
        if (!(e <= exact)) continue;
        for (int i = 0; i < 6; i++) P[6 * *np + i] = q[i];
        PE[*np] = e;
        (*np)++;
        /* exact but shallow: the truncated steps stopped along a double root's weak direction, up to
         * ~1e-6 rad from the root.  Plain steps (linear there, the distance halved a step) bring a copy
         * nearer the root; the copy joins the pool beside the row (a close pair of roots keeps both) */
        if (e > G6_DEEP * exact && *np < G6_POOL) {
            double r[6];
            for (int i = 0; i < 6; i++) r[i] = q[i];
            const double e2 = g6_truncated_newton(rb, g, r, G6_UNDAMPED_STEPS, G6_UNDAMPED_RCOND);
            if (e2 < e) {
                for (int i = 0; i < 6; i++) P[6 * *np + i] = r[i];
                PE[*np] = e2;
                (*np)++;
            }
        }
    }
    return weak;
}

/* The rows P (np, best error first by selection) merged at distance `apart` into Q (at most 16 leaves):
 * their count, or -1 when more than 16 remain. */
static int g6_merge(const ikc_robot *rb, const double *P, const double *PE, int np, double apart, double *Q, double *E,
                    int *F) {
    int used[G6_POOL] = {0}, m = 0;
    for (;;) {
        int best = -1;
        for (int j = 0; j < np; j++)
            if (!used[j] && (best < 0 || PE[j] < PE[best])) best = j;
        if (best < 0) break;
        used[best] = 1;
        int near = 0;
        for (int r = 0; r < m && !near; r++) near = ikc_row_distance(rb, Q + 6 * r, P + 6 * best) < apart;
        if (near) continue;
        if (m == 16) return -1;
        for (int i = 0; i < 6; i++) Q[6 * m + i] = P[6 * best + i];
        E[m] = PE[best], F[m] = 0;
        m++;
    }
    return m;
}

/* Whether the exact rows of the arrangements (pool slices from[k]..from[k + 1]) tell one story: each
 * merged at G6_SAME gives the same number of rows, at least one, and every row of one has a row of
 * every other within G6_COLLIDE (a double root's rows end 1e-6..4e-5 apart).  Then the target's own
 * eigenproblems have found what the rotated copies would add (measured, docs/general6.md "Native path"
 * item 6); otherwise the copies are solved too. */
static int g6_sources_agree(const ikc_robot *rb, const double *P, const double *PE, const int *from, int count) {
    if (count < 2) return 0;
    double Q0[6 * 16], Qk[6 * 16], E[16];
    int F[16];
    const int m0 = g6_merge(rb, P + 6 * from[0], PE + from[0], from[1] - from[0], G6_SAME, Q0, E, F);
    if (m0 <= 0) return 0;
    for (int k = 1; k < count; k++) {
        const int mk = g6_merge(rb, P + 6 * from[k], PE + from[k], from[k + 1] - from[k], G6_SAME, Qk, E, F);
        if (mk != m0) return 0;
        for (int side = 0; side < 2; side++)
            for (int i = 0; i < m0; i++) {
                const double *a = (side ? Qk : Q0) + 6 * i, *B = side ? Q0 : Qk;
                int near = 0;
                for (int j = 0; j < m0 && !near; j++) near = ikc_row_distance(rb, a, B + 6 * j) < G6_COLLIDE;
                if (!near) return 0;
            }
    }
    return 1;
}

/* A target doubtful under every arrangement (a double root at a singular configuration, a pencil
 * singular at the target: 189 of 300 Jaco poses with every joint at 0, +-pi/2, pi; docs/general6.md
 * "Special poses"): general6.py's doubtful-target path in C, uncertified as it is.  First the target's
 * own eigenvalue candidates under every arrangement (g6_eigen_source); where the arrangements disagree
 * (g6_sources_agree), one gave no candidates or one was weak (G6_WEAK_*), also four copies rotated by
 * +-G6_COPY_ANGLE about two fixed axes under each (a double root splits; a singular pencil becomes
 * regular), as general6.py does.
 * Every source's exact rows are pooled, then merged: one arrangement's rows are not chosen over
 * another's (xarm7, a root pair 1.3e-5 rad apart: each arrangement found one of the two).  -1 when no
 * source gave candidates (the Python general6 takes the target). */
static int g6_eigen_leaves(const ikc_robot *rb, const ikc_g6 *G, int count, const double *g, double *Q, double *E,
                           int *F) {
    if (rb->dof != 6 || rb->nfree) return -1;  /* the six solved joints alone (g6_truncated_newton) */
    for (int j = 0; j < 6; j++)  /* revolute chains only: a prismatic pencil's real spurious roots and
                                  * absent columns are not treated here (a modular RRRRTT lost 2 of 10
                                  * verify poses): its doubtful targets stay Python's */
        if (G->prism[j]) return -1;
    double P[6 * G6_POOL], PE[G6_POOL];
    int np = 0, answered = 0, weak = 0, from[count + 1];
    for (int k = 0; k < count; k++) {
        from[k] = np;
        const int w = g6_eigen_source(rb, G + k, g, g, P, PE, &np);
        answered += w >= 0;
        weak |= w;  /* -1: every bit */
    }
    from[count] = np;
    if (answered < count || weak || !g6_sources_agree(rb, P, PE, from, count))
        for (int c = 1; c < 5; c++)
            for (int k = 0; k < count; k++) {
                double gr[12];
                g6_rotated_target(G, g6_copy_axes[(c - 1) % 2], c > 2 ? -G6_COPY_ANGLE : G6_COPY_ANGLE, g, gr);
                answered += g6_eigen_source(rb, G + k, gr, g, P, PE, &np) >= 0;
            }
    if (!answered) return -1;
    /* the exact rows, best first; one closer than G6_SAME to a kept row is that row (general6.py _pack;
     * at a double root the candidates end 1e-6..4e-5 apart, each exact, and the one nearest the root is
     * not the one of least error); more than 16 left: merged at G6_COLLIDE instead (general6.py
     * _apart) */
    int m = -1;
    for (int pass = 0; pass < 2 && m < 0; pass++) m = g6_merge(rb, P, PE, np, pass ? G6_COLLIDE : G6_SAME, Q, E, F);
    return m;
}

/* The leaves of the general-6r chain (ikc_chain_fn's outputs) for goal g, trying the module's
 * arrangements G[0..count-1] in order (general6.py's usable order): a target doubtful under one is
 * re-solved under the next, and the first that answers it cleanly gives its leaves, the same trust as a
 * clean first arrangement (general6.py's doubtful-target path, docs/general6.md "Native path").  A
 * target doubtful under every one takes the eigenvalue path (g6_eigen_leaves); where that fails, one
 * DEFER leaf, for the Python general6. */
static int ikc_g6_leaves(const ikc_robot *rb, const ikc_g6 *G, int count, const double *g, double *Q, double *E,
                         int *F) {
    for (int k = 0; k < count; k++) {
        int n = g6_arrangement_leaves(rb, G + k, g, Q, E, F);
        int rows = 0;
        for (int i = 0; i < n; i++) rows += !(F[i] & IKC_EMPTY);
        /* A later arrangement's clean "no solution" is not trusted: an earlier one found the target
         * doubtful (a near-double root, close roots: a configuration near a singular one), and there
         * a noisy pencil can turn a real pair into a complex one that the certificate cannot see
         * (xarm7.urdf perturbed by 1e-6, seed 7, q = (-pi/2, -0.04498, 0, pi/2, -pi/2, -pi/2, pi): the
         * third arrangement's D stayed 8 of its noise estimates above zero at the pair, 0 rows for a
         * target with 3).  The next arrangements, then the eigenvalue path, answer it. */
        if (n >= 0 && (k == 0 || rows > 0)) return n;
    }
    const int n = g6_eigen_leaves(rb, G, count, g, Q, E, F);
    if (n >= 0) return n;
    for (int j = 0; j < 6; j++) Q[j] = 0.0;
    E[0] = 0.0;
    F[0] = IKC_DEFER;
    return 1;
}
