/* The plain-arithmetic kernels of subproblems/fast.py in C: the native backend of generated chains.
 *
 * A line-by-line port of fast.py's kernels with the SCALAR backend's semantics, in the same order of
 * operations, so that C and fast.SCALAR agree to rounding (compiled with -ffp-contract=off and
 * without -ffast-math; libm's sin, cos, atan2, acos are the functions Python's math module calls).
 * tests/subproblems/test_native_kernels.py checks the agreement kernel by kernel.
 *
 * Conventions (the code generator relies on them):
 *  - every function is static (inline) and prefixed ikc_; a generated chain includes this header and
 *    exports only its own entry points;
 *  - a kernel takes the Python kernel's arguments in order, without the backend m: 3-vectors and the
 *    row-major rotation R (9 entries) as const double *, scalars as double; then its outputs:
 *    double *q, slots x outs values slot-major (slot k, output j at q[k * outs + j]), and int *f,
 *    one flag per slot.  Slots x outs: plane_r 2x1, plane_t 1x1, dist_r 2x1, dist_t 2x1, slide1 1x1, slide3 1x3,
 *    turn_slide2 1x3, slide2_turn 2x3, point_r 1x1, point_rr_meet 2x2, point_rr_parallel 2x2, rot_r 1x1, rot_rr 1x2,
 *    rot_rrr 2x3, point_rrr 4x3;
 *  - the angle kernels (plane_r, dist_r, point_r, point_rr_meet, point_rr_parallel, rot_r, rot_rr,
 *    rot_rrr) have an ikc_NAME_cs form, fast.NAME_cs's port, that also writes double *cs: slots x outs
 *    pairs (cos, sin) of each output angle (slot k, output j at cs[2 * (k * outs + j)]), computed from
 *    the pair the angle is the atan2 of (fast.unit_pair) or by the sum formulas for phi +- acos(x); a
 *    chain reads them instead of calling cos and sin (~1 libm call saved per angle and leaf; the
 *    gimbal lock's values, rare, take libm's).  The plain forms drop cs;
 *  - SCALAR semantics: clip1 keeps NaN, pos(x) = x > 0 ? x : 0 (NaN -> 0), big(x) = x > TINY ? x : TINY;
 *    a comparison with NaN is false, as in Python.
 */
#ifndef IKC_FAST_KERNELS_H
#define IKC_FAST_KERNELS_H

#include <math.h>
#include <stddef.h>

#define IKC_TANGENT_ROOT 1
#define IKC_FAMILY 2
#define IKC_DEFER 4
#define IKC_EMPTY 8
#define IKC_LOCK 16  /* an S2-RR angle left free by its geometry: rep (fast.LOCK) */

#define IKC_NEAR 1e-7
#define IKC_TANGENT 1e-10
#define IKC_NEAR2 (IKC_NEAR * IKC_NEAR)
#define IKC_SPLIT_ROOT 1e-6
#define IKC_TINY 1e-300
#define IKC_PI 3.141592653589793115997963468544185161590576171875 /* math.pi, exactly */

/* ------------------------------------------------------------------------------------------------
 * SCALAR backend functions and 3-vector arithmetic */

static inline double ikc_clip1(double x) { return x < -1.0 ? -1.0 : (x > 1.0 ? 1.0 : x); }
static inline double ikc_pos(double x) { return x > 0.0 ? x : 0.0; }
static inline double ikc_big(double x) { return x > IKC_TINY ? x : IKC_TINY; }

static inline double ikc_dot(const double *a, const double *b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void ikc_cross(const double *a, const double *b, double *out) {
    double x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2], z = a[0] * b[1] - a[1] * b[0];
    out[0] = x;
    out[1] = y;
    out[2] = z;
}

static inline void ikc_sub(const double *a, const double *b, double *out) {
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

/* s a + b */
static inline void ikc_axpy(double s, const double *a, const double *b, double *out) {
    out[0] = s * a[0] + b[0];
    out[1] = s * a[1] + b[1];
    out[2] = s * a[2] + b[2];
}

static inline void ikc_mat_vec(const double *R, const double *x, double *out) {
    double a = R[0] * x[0] + R[1] * x[1] + R[2] * x[2];
    double b = R[3] * x[0] + R[4] * x[1] + R[5] * x[2];
    double c = R[6] * x[0] + R[7] * x[1] + R[8] * x[2];
    out[0] = a;
    out[1] = b;
    out[2] = c;
}

static inline void ikc_mat_t_vec(const double *R, const double *x, double *out) {
    double a = R[0] * x[0] + R[3] * x[1] + R[6] * x[2];
    double b = R[1] * x[0] + R[4] * x[1] + R[7] * x[2];
    double c = R[2] * x[0] + R[5] * x[1] + R[8] * x[2];
    out[0] = a;
    out[1] = b;
    out[2] = c;
}

/* fast._turn_cs: exp([w] th) x with cos th = c, sin th = s (Rodrigues) */
static inline void ikc_turn_cs(const double *w, double c, double s, const double *x, double *out) {
    double w0 = w[0], w1 = w[1], w2 = w[2];
    double x0 = x[0], x1 = x[1], x2 = x[2];
    double k = (w0 * x0 + w1 * x1 + w2 * x2) * (1.0 - c);
    out[0] = c * x0 + s * (w1 * x2 - w2 * x1) + k * w0;
    out[1] = c * x1 + s * (w2 * x0 - w0 * x2) + k * w1;
    out[2] = c * x2 + s * (w0 * x1 - w1 * x0) + k * w2;
}

/* exp([w] th) x */
static inline void ikc_rotate(const double *w, double th, const double *x, double *out) {
    ikc_turn_cs(w, cos(th), sin(th), x, out);
}

/* fast.unit_pair: (cos th, sin th) of th = atan2(s, c) from the pair, (1, 0) for a zero pair */
static inline void ikc_unit_pair(double c, double s, double *cs) {
    double r = sqrt(c * c + s * s);
    double inv = 1.0 / ikc_big(r);
    cs[0] = c * inv + (r == 0.0 ? 1.0 : 0.0);
    cs[1] = s * inv;
}

/* S1-R: the angle that turns u toward v about w; *flag = IKC_DEFER when either is (nearly) along w.
 * Also its cosine and sine, *cs = {cos, sin}, from the two components whose atan2 it is (the chain
 * takes them instead of cos and sin of the angle; a zero pair, always flagged, gives the angle 0's). */
static inline double ikc_angle_about_cs(const double *w, const double *u, const double *v, double size2,
                                        int *flag, double *cs) {
    double w0 = w[0], w1 = w[1], w2 = w[2];
    double u0 = u[0], u1 = u[1], u2 = u[2];
    double v0 = v[0], v1 = v[1], v2 = v[2];
    double uw = w0 * u0 + w1 * u1 + w2 * u2;
    double vw = w0 * v0 + w1 * v1 + w2 * v2;
    double a0 = u0 - uw * w0, a1 = u1 - uw * w1, a2 = u2 - uw * w2;
    double b0 = v0 - vw * w0, b1 = v1 - vw * w1, b2 = v2 - vw * w2;
    double sin_part = w0 * (a1 * b2 - a2 * b1) + w1 * (a2 * b0 - a0 * b2) + w2 * (a0 * b1 - a1 * b0);
    double cos_part = a0 * b0 + a1 * b1 + a2 * b2;
    double th = atan2(sin_part, cos_part);
    double lim = IKC_NEAR2 * (u0 * u0 + u1 * u1 + u2 * u2 + v0 * v0 + v1 * v1 + v2 * v2 + size2 + 1.0);
    *flag = ((a0 * a0 + a1 * a1 + a2 * a2 <= lim) | (b0 * b0 + b1 * b1 + b2 * b2 <= lim)) ? IKC_DEFER : 0;
    ikc_unit_pair(cos_part, sin_part, cs);
    return th;
}

static inline double ikc_angle_about(const double *w, const double *u, const double *v, double size2,
                                     int *flag) {
    double cs[2];
    return ikc_angle_about_cs(w, u, v, size2, flag, cs);
}

/* Both roots of a cos th + b sin th = c (clamped to the nearest when |c| > rho): th[0..1], f[0..1].
 * rho and c both negligible: every angle solves it, both slots th = rep, IKC_FAMILY; rho alone
 * negligible: IKC_DEFER. */
static inline void ikc_trig_roots_cs(double a, double b, double c, double size, double rep, double *th, int *f,
                                     double *cs) {
    double rho = sqrt(a * a + b * b);
    double phi = atan2(b, a);
    double x = c / ikc_big(rho);
    double cd = ikc_clip1(x);
    double delta = acos(cd);
    int flat = rho <= IKC_NEAR * size;
    int every = flat && fabs(c) <= IKC_NEAR * size;
    int tangent = (fabs(x * x - 1.0) <= IKC_TANGENT) && rho > IKC_NEAR * size;
    int flag = ((flat && !every) ? IKC_DEFER : 0) | (every ? IKC_FAMILY : 0) | (tangent ? IKC_TANGENT_ROOT : 0);
    double here = rep + 0.0 * phi;
    th[0] = every ? here : phi + delta;
    th[1] = every ? here : phi - delta;
    f[0] = flag;
    f[1] = flag;
    /* cos and sin of the roots phi +- delta by the sum formulas: cos phi = a / rho, sin phi = b / rho,
     * cos delta = the clipped x, sin delta = sqrt((1 - x)(1 + x)) >= 0 (delta = acos in [0, pi]) */
    if (every) {
        cs[0] = cos(here);
        cs[1] = sin(here);
        cs[2] = cs[0];
        cs[3] = cs[1];
        return;
    }
    double u[2];
    ikc_unit_pair(a, b, u);
    double cp = u[0], sp = u[1];
    double sd = sqrt(ikc_pos((1.0 - cd) * (1.0 + cd)));
    cs[0] = cp * cd - sp * sd;
    cs[1] = sp * cd + cp * sd;
    cs[2] = cp * cd + sp * sd;
    cs[3] = sp * cd - cp * sd;
}

/* ------------------------------------------------------------------------------------------------
 * the kernels */

/* H-R: h . exp(w th)(p) = d.  2 slots x 1 */
static inline void ikc_plane_r_cs(const double *w, const double *r, const double *p, const double *h, double d,
                                  double rep, double *q, int *f, double *cs) {
    double u[3], up[3], wu[3];
    ikc_sub(p, r, u);
    double uw = ikc_dot(w, u);
    ikc_axpy(-uw, w, u, up);
    double a = ikc_dot(h, up);
    ikc_cross(w, u, wu);
    double b = ikc_dot(h, wu);
    double c = d - ikc_dot(h, r) - uw * ikc_dot(h, w);
    double size = sqrt(ikc_dot(h, h) * (ikc_dot(u, u) + ikc_dot(r, r) + ikc_dot(p, p) + 1.0)) + IKC_TINY;
    ikc_trig_roots_cs(a, b, c, size, rep, q, f, cs);
}

/* H-T: h . (p + v th) = d.  1 slot x 1; h (nearly) across the slide: th = rep, IKC_FAMILY */
static inline void ikc_plane_t(const double *v, const double *p, const double *h, double d, double rep,
                               double *q, int *f) {
    double hv = ikc_dot(h, v);
    int across = (hv * hv) <= IKC_NEAR2 * ikc_dot(h, h);
    double th = (d - ikc_dot(h, p)) / (across ? 1.0 : hv);
    q[0] = across ? rep + 0.0 * th : th;
    f[0] = across ? IKC_FAMILY : 0;
}

/* S3-R: |exp(w th)(p) - q| = d.  2 slots x 1 (argument qq is the Python kernel's q) */
static inline void ikc_dist_r_cs(const double *w, const double *r, const double *p, const double *qq, double d,
                                 double rep, double *q, int *f, double *cs) {
    double u[3], z[3], up[3], wu[3];
    ikc_sub(p, r, u);
    ikc_sub(qq, r, z);
    double uw = ikc_dot(w, u);
    ikc_axpy(-uw, w, u, up);
    double a = ikc_dot(z, up);
    ikc_cross(w, u, wu);
    double b = ikc_dot(z, wu);
    double c = 0.5 * (ikc_dot(u, u) + ikc_dot(z, z) - d * d) - uw * ikc_dot(z, w);
    ikc_trig_roots_cs(a, b, c, ikc_dot(u, u) + ikc_dot(z, z) + ikc_dot(r, r) + d * d + 1.0, rep, q, f, cs);
}

/* S3-T: |p + v th - q| = d.  2 slots x 1 (argument qq is the Python kernel's q) */
static inline void ikc_dist_t(const double *v, const double *p, const double *qq, double d, double *q, int *f) {
    double e[3];
    ikc_sub(p, qq, e);
    double ve = ikc_dot(v, e);
    double disc = ve * ve - ikc_dot(e, e) + d * d;
    double root = sqrt(ikc_pos(disc));
    int tangent =
        (fabs(disc) <= IKC_TANGENT * (ve * ve + d * d + ikc_dot(p, p) + ikc_dot(qq, qq) + 1.0)) ? IKC_TANGENT_ROOT
                                                                                              : 0;
    q[0] = -ve + root;
    q[1] = -ve - root;
    f[0] = tangent;
    f[1] = tangent;
}

/* S2-T / S1-T: v t = b, the component of b along the slide (the chain's pose error measures the
 * rest); defer a (nearly) zero slide.  1 slot x 1 */
static inline void ikc_slide1(const double *v, const double *b, double *q, int *f) {
    double vv = ikc_dot(v, v);
    q[0] = ikc_dot(v, b) / (vv + IKC_TINY);
    f[0] = (vv <= IKC_NEAR2) ? IKC_DEFER : 0;
}

/* S2-TTT / S1-TTT: v1 t1 + v2 t2 + v3 t3 = b (Cramer).  1 slot x 3 */
static inline void ikc_slide3(const double *v1, const double *v2, const double *v3, const double *b, double *q,
                              int *f) {
    double c23[3], c31[3], c12[3];
    ikc_cross(v2, v3, c23);
    ikc_cross(v3, v1, c31);
    ikc_cross(v1, v2, c12);
    double det = ikc_dot(v1, c23);
    double scale = sqrt(ikc_dot(v1, v1) * ikc_dot(v2, v2) * ikc_dot(v3, v3)) + IKC_TINY;
    double inv = 1.0 / (det + (det >= 0.0 ? IKC_TINY : 0.0) - (det < 0.0 ? IKC_TINY : 0.0));
    q[0] = ikc_dot(b, c23) * inv;
    q[1] = ikc_dot(b, c31) * inv;
    q[2] = ikc_dot(b, c12) * inv;
    f[0] = (fabs(det) <= IKC_NEAR * scale) ? IKC_DEFER : 0;
}

static inline void ikc_plane_r(const double *w, const double *r, const double *p, const double *h, double d,
                               double rep, double *q, int *f);  /* below, with the other plain forms */

/* S2-TTR: v1 t1 + v2 t2 + exp(xi3 t3)(p) = q, xi3 about the axis (w, r): t3 from the plane across both
 * slides (plane_r with the normal v1 x v2), then the slides by normal equations.  2 slots x 3 */
static inline void ikc_slide2_turn(const double *v1, const double *v2, const double *w, const double *r,
                                   const double *p, const double *qq, double rep, double *q, int *f) {
    double n[3], u[3];
    ikc_cross(v1, v2, n);
    double a = ikc_dot(v1, v1), b = ikc_dot(v1, v2), e = ikc_dot(v2, v2);
    double det = a * e - b * b;
    double inv = 1.0 / ikc_big(det);
    int parallel = (det <= IKC_NEAR * a * e) ? IKC_DEFER : 0;
    ikc_sub(p, r, u);
    double t3[2];
    int f3[2];
    ikc_plane_r(w, r, p, n, ikc_dot(n, qq), rep, t3, f3);
    for (int k = 0; k < 2; k++) {
        double y[3], x[3];
        ikc_rotate(w, t3[k], u, y);
        x[0] = qq[0] - y[0] - r[0];
        x[1] = qq[1] - y[1] - r[1];
        x[2] = qq[2] - y[2] - r[2];
        double y1 = ikc_dot(v1, x), y2 = ikc_dot(v2, x);
        q[3 * k] = (e * y1 - b * y2) * inv;
        q[3 * k + 1] = (a * y2 - b * y1) * inv;
        q[3 * k + 2] = t3[k];
        f[k] = f3[k] | parallel;
    }
}

/* O-R: exp([w] th) = R.  1 slot x 1 */
static inline void ikc_rot_r_cs(const double *w, const double *R, double *q, int *f, double *cs) {
    double Rw[3];
    ikc_mat_vec(R, w, Rw);
    double c = 0.5 * (R[0] + R[4] + R[8] - ikc_dot(w, Rw));
    double s = 0.5 * (w[0] * (R[7] - R[5]) + w[1] * (R[2] - R[6]) + w[2] * (R[3] - R[1]));
    q[0] = atan2(s, c);
    f[0] = (c != c) ? IKC_DEFER : 0;
    ikc_unit_pair(c, s, cs);
}

static inline void ikc_rot_r(const double *w, const double *R, double *q, int *f) {
    double cs[2];
    ikc_rot_r_cs(w, R, q, f, cs);
}

/* S1-RTT: exp(xi1 t1) exp(v2 t2) exp(v3 t3) = (R, t), xi1 about the axis (w, r).  1 slot x 3 */
static inline void ikc_turn_slide2(const double *w, const double *r, const double *v2, const double *v3,
                                   const double *R, const double *t, double *q, int *f) {
    double t1;
    int f1;
    ikc_rot_r(w, R, &t1, &f1);
    double tr[3], x[3];
    ikc_sub(t, r, tr);
    ikc_rotate(w, -t1, tr, x);
    x[0] = x[0] + r[0];
    x[1] = x[1] + r[1];
    x[2] = x[2] + r[2];
    double a = ikc_dot(v2, v2), b = ikc_dot(v2, v3), e = ikc_dot(v3, v3);
    double det = a * e - b * b;
    double inv = 1.0 / ikc_big(det);
    double y2 = ikc_dot(v2, x), y3 = ikc_dot(v3, x);
    q[0] = t1;
    q[1] = (e * y2 - b * y3) * inv;
    q[2] = (a * y3 - b * y2) * inv;
    f[0] = f1 | ((det <= IKC_NEAR * a * e) ? IKC_DEFER : 0);
}

/* S2-R: exp(w th)(p) = q.  1 slot x 1 (argument qq is the Python kernel's q) */
static inline void ikc_point_r_cs(const double *w, const double *r, const double *p, const double *qq, double *q,
                                  int *f, double *cs) {
    double u[3], v[3];
    ikc_sub(p, r, u);
    ikc_sub(qq, r, v);
    q[0] = ikc_angle_about_cs(w, u, v, ikc_dot(p, p) + ikc_dot(qq, qq) + ikc_dot(r, r), &f[0], cs);
}

/* An S2-RR angle its geometry leaves free (ikc_angle_about_cs deferred: the point on the axis): the
 * representative rep, flagged IKC_LOCK, and its cosine and sine in cs[0], cs[1] (fast._locked_cs). */
static inline double ikc_locked_cs(double th, int *flag, double rep, double *cs) {
    if (*flag == 0) return th;
    const double here = rep + 0.0 * th;  /* as fast._locked_cs: -0.0 + 0.0 is +0.0, and a NaN stays */
    *flag = IKC_LOCK;
    cs[0] = cos(here);
    cs[1] = sin(here);
    return here;
}

/* S2-RR, axes meeting: exp(w1 t1) exp(w2 t2)(p) = q (Paden-Kahan 2).  2 slots x 2 (t1, t2) */
static inline void ikc_point_rr_meet_cs(const double *w1, const double *r1, const double *w2, const double *r2,
                                        const double *p, const double *qq, double rep, double *q, int *f,
                                        double *cs) {
    double n[3], d21[3], m[3], c[3], u[3], v[3];
    double k = ikc_dot(w1, w2);
    ikc_cross(w1, w2, n);
    double nn = ikc_dot(n, n);
    int parallel = nn <= IKC_NEAR;
    double den = parallel ? 1.0 : nn;
    ikc_sub(r2, r1, d21);
    ikc_cross(d21, w2, m);
    double s = ikc_dot(m, n) / den;
    ikc_axpy(s, w1, r1, c);
    ikc_sub(p, c, u);
    ikc_sub(qq, c, v);
    double size2 = ikc_dot(p, p) + ikc_dot(qq, qq) + ikc_dot(r1, r1) + ikc_dot(r2, r2);
    double a1 = ikc_dot(w1, v), a2 = ikc_dot(w2, u);
    double alpha = (a1 - k * a2) / den;
    double beta = (a2 - k * a1) / den;
    double uu = ikc_dot(u, u);
    double g2 = (uu - alpha * alpha - beta * beta - 2.0 * alpha * beta * k) / den;
    double gamma = sqrt(ikc_pos(g2));
    int degenerate = (parallel ? IKC_DEFER : 0) | ((fabs(g2) * nn <= IKC_TANGENT * uu) ? IKC_TANGENT_ROOT : 0);
    for (int i = 0; i < 2; i++) {
        double g = i == 0 ? gamma : -gamma;
        double z[3];
        z[0] = alpha * w1[0] + beta * w2[0] + g * n[0];
        z[1] = alpha * w1[1] + beta * w2[1] + g * n[1];
        z[2] = alpha * w1[2] + beta * w2[2] + g * n[2];
        int f1, f2;
        double t2 = ikc_angle_about_cs(w2, u, z, size2, &f2, cs + 4 * i + 2);
        t2 = ikc_locked_cs(t2, &f2, rep, cs + 4 * i + 2);
        double t1 = ikc_angle_about_cs(w1, z, v, size2, &f1, cs + 4 * i);
        t1 = ikc_locked_cs(t1, &f1, rep, cs + 4 * i);
        q[2 * i] = t1;
        q[2 * i + 1] = t2;
        f[i] = degenerate | f1 | f2;
    }
}

/* S2-RR, parallel axes (w2 = +-w1): a planar 2R arm.  2 slots x 2 (t1, t2) */
static inline void ikc_point_rr_parallel_cs(const double *w1, const double *r1, const double *w2,
                                            const double *r2, const double *p, const double *qq, double rep,
                                            double *q, int *f, double *cs) {
    double w0 = w1[0], w1_ = w1[1], w2_ = w1[2];
    double e0 = r1[0] - r2[0], e1 = r1[1] - r2[1], e2 = r1[2] - r2[2];
    double h = w0 * e0 + w1_ * e1 + w2_ * e2;
    e0 = e0 - h * w0;
    e1 = e1 - h * w1_;
    e2 = e2 - h * w2_;
    double u0 = p[0] - r2[0], u1 = p[1] - r2[1], u2 = p[2] - r2[2];
    double height = w0 * u0 + w1_ * u1 + w2_ * u2;
    double a[3] = {u0 - height * w0, u1 - height * w1_, u2 - height * w2_};
    double v0 = qq[0] - r1[0], v1 = qq[1] - r1[1], v2 = qq[2] - r1[2];
    h = w0 * v0 + w1_ * v1 + w2_ * v2;
    double b[3] = {v0 - h * w0, v1 - h * w1_, v2 - h * w2_};
    double ee = e0 * e0 + e1 * e1 + e2 * e2;
    double rho2 = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    double rho1 = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
    double x = (rho2 - rho1 + ee) / (2.0 * ikc_big(ee));
    double y2 = rho2 / ikc_big(ee) - x * x;
    double y = sqrt(ikc_pos(y2));
    double f0 = w1_ * e2 - w2_ * e1, f1 = w2_ * e0 - w0 * e2, f2 = w0 * e1 - w1_ * e0; /* w x e */
    double size2 = ikc_dot(p, p) + ikc_dot(qq, qq) + ikc_dot(r1, r1) + ikc_dot(r2, r2);
    int coincident = (ee <= IKC_NEAR2 * (rho1 + rho2 + size2 + 1.0)) ? IKC_DEFER : 0;
    int degenerate = coincident | ((fabs(y2) * ee <= IKC_TANGENT * rho2) ? IKC_TANGENT_ROOT : 0);
    for (int i = 0; i < 2; i++) {
        double s = i == 0 ? y : -y;
        double z[3] = {x * e0 + s * f0, x * e1 + s * f1, x * e2 + s * f2};
        double ze[3] = {z[0] - e0, z[1] - e1, z[2] - e2};
        int g1, g2;
        double t2 = ikc_angle_about_cs(w2, a, z, size2, &g2, cs + 4 * i + 2);
        t2 = ikc_locked_cs(t2, &g2, rep, cs + 4 * i + 2);
        double t1 = ikc_angle_about_cs(w1, ze, b, size2, &g1, cs + 4 * i);
        t1 = ikc_locked_cs(t1, &g1, rep, cs + 4 * i);
        q[2 * i] = t1;
        q[2 * i + 1] = t2;
        f[i] = degenerate | g1 | g2;
    }
}

/* O-RR: exp([w1] t1) exp([w2] t2) = R.  1 slot x 2 */
static inline void ikc_rot_rr_cs(const double *w1, const double *w2, const double *R, double *q, int *f,
                                  double *cs) {
    double Rw2[3], Rtw1[3];
    int f1, f2;
    ikc_mat_vec(R, w2, Rw2);
    q[0] = ikc_angle_about_cs(w1, w2, Rw2, 0.0, &f1, cs);
    ikc_mat_t_vec(R, w1, Rtw1);
    q[1] = ikc_angle_about_cs(w2, Rtw1, w1, 0.0, &f2, cs + 2);
    f[0] = f1 | f2;
}

/* O-RRR: exp([w1] t1) exp([w2] t2) exp([w3] t3) = R.  2 slots x 3; gimbal lock: t3 = rep, IKC_FAMILY */
static inline void ikc_rot_rrr_cs(const double *w1, const double *w2, const double *w3, const double *R,
                                   double rep, double *q, int *f, double *cs) {
    double Rw3[3], Rtw1[3], w23[3], w21[3], Rw2[3];
    ikc_mat_vec(R, w3, Rw3);
    ikc_mat_t_vec(R, w1, Rtw1);
    double k12 = ikc_dot(w1, w2), k23 = ikc_dot(w2, w3);
    ikc_cross(w2, w3, w23);
    ikc_cross(w2, w1, w21);
    double a = ikc_dot(w1, w3) - k12 * k23;
    double b = ikc_dot(w1, w23);
    double c = ikc_dot(w1, Rw3) - k12 * k23;
    double roots[2], rcs[4];
    int rf[2];
    ikc_trig_roots_cs(a, b, c, 1.0, rep, roots, rf, rcs);
    /* The lock's values (t2_lock, whether it is a lock at all, the representative t1_rep) are computed
     * only where a slot reads them: the values returned are those of fast.py, which computes them
     * always (4 libm calls of ~12 per call saved on a regular target). */
    double t2_lock = 0.0;
    int aligned = 0;
    if ((rf[0] | rf[1]) & IKC_TANGENT_ROOT) {
        /* whether t2_lock is a lock at all (exp([w2] t2_lock) w3 along w1): then a tangent t2 equation
         * is that lock, its roots split by upstream roundoff by ~sqrt(eps) */
        t2_lock = atan2(b, a) + (c < 0.0 ? IKC_PI : 0.0);
        double cl = cos(t2_lock), sl = sin(t2_lock);
        double kl = k23 * (1.0 - cl);
        double zl[3] = {cl * w3[0] + sl * w23[0] + kl * w2[0], cl * w3[1] + sl * w23[1] + kl * w2[1],
                        cl * w3[2] + sl * w23[2] + kl * w2[2]};
        double off[3];
        ikc_cross(w1, zl, off);
        aligned = ikc_dot(off, off) <= IKC_NEAR2;
    }
    double t[6], tcs[12];
    int lock[2];
    for (int i = 0; i < 2; i++) {
        double t2 = roots[i];
        double c2 = rcs[2 * i], s2 = rcs[2 * i + 1];  /* cos t2, sin t2 (fast.py: m.cos(t2), m.sin(t2)) */
        double k3 = k23 * (1.0 - c2), k1 = k12 * (1.0 - c2);
        double z[3] = {
            c2 * w3[0] + s2 * w23[0] + k3 * w2[0],
            c2 * w3[1] + s2 * w23[1] + k3 * w2[1],
            c2 * w3[2] + s2 * w23[2] + k3 * w2[2],
        };
        double y[3] = {
            c2 * w1[0] - s2 * w21[0] + k1 * w2[0],
            c2 * w1[1] - s2 * w21[1] + k1 * w2[1],
            c2 * w1[2] - s2 * w21[2] + k1 * w2[2],
        };
        int f1, f3;
        t[3 * i] = ikc_angle_about_cs(w1, z, Rw3, 0.0, &f1, tcs + 6 * i);
        t[3 * i + 1] = t2;
        tcs[6 * i + 2] = c2;
        tcs[6 * i + 3] = s2;
        t[3 * i + 2] = ikc_angle_about_cs(w3, Rtw1, y, 0.0, &f3, tcs + 6 * i + 4);
        lock[i] = ((f1 | f3) != 0) || ((rf[i] & IKC_TANGENT_ROOT) && aligned);
    }
    double t1_rep = 0.0;
    int f_rep = 0;
    if (lock[0] || lock[1]) {
        if (!((rf[0] | rf[1]) & IKC_TANGENT_ROOT)) t2_lock = atan2(b, a) + (c < 0.0 ? IKC_PI : 0.0);
        double w2_rep[3];
        ikc_rotate(w3, -rep, w2, w2_rep);  /* t1 turns w2 onto R exp(-[w3] rep) w2 */
        ikc_mat_vec(R, w2_rep, Rw2);
        t1_rep = ikc_angle_about(w1, w2, Rw2, 0.0, &f_rep);
    }
    for (int i = 0; i < 2; i++) {
        q[3 * i] = lock[i] ? t1_rep : t[3 * i];
        q[3 * i + 1] = lock[i] ? t2_lock : t[3 * i + 1];
        q[3 * i + 2] = lock[i] ? rep + 0.0 * t[3 * i + 2] : t[3 * i + 2];
        f[i] = rf[i] | (lock[i] ? (IKC_FAMILY | f_rep) : 0);
        for (int j = 0; j < 3; j++) {  /* a lock's values are rare: their cos and sin from libm */
            double v = q[3 * i + j];
            cs[6 * i + 2 * j] = lock[i] ? cos(v) : tcs[6 * i + 2 * j];
            cs[6 * i + 2 * j + 1] = lock[i] ? sin(v) : tcs[6 * i + 2 * j + 1];
        }
    }
}

/* ------------------------------------------------------------------------------------------------
 * S2-RRR, the regular case (fast.point_rrr and its helpers, same order of operations) */

#define IKC_RRR_REGULAR 1e-3  /* tolerances.FAST_RRR_REGULAR */
#define IKC_RRR_DOUBLE 1e-6   /* tolerances.FAST_RRR_DOUBLE */
#define IKC_RRR_NEWTON 3      /* fast.RRR_NEWTON */

/* fast._trig2: f0 + c1 cos + s1 sin + c2 cos 2 + s2 sin 2 at (cos, sin) = (c, s) */
static inline double ikc_rrr_trig2(const double *f, double c, double s) {
    return f[0] + f[1] * c + f[2] * s + f[3] * (c * c - s * s) + f[4] * (2.0 * s * c);
}

/* fast._cubic_largest: the largest real root of x^3 + p x^2 + q x + r */
static inline double ikc_rrr_cubic_largest(double p, double q, double r) {
    double a = q - p * p / 3.0;
    double b = 2.0 * p * p * p / 27.0 - p * q / 3.0 + r;
    double disc = 0.25 * b * b + a * a * a / 27.0;
    double sq = sqrt(ikc_pos(disc));
    double one = cbrt(-0.5 * b + sq) + cbrt(-0.5 * b - sq);
    double ra = sqrt(ikc_pos(-a / 3.0));
    double three = 2.0 * ra * cos(acos(ikc_clip1(-0.5 * b / ikc_big(ra * ra * ra))) / 3.0);
    double x = (disc > 0.0 ? one : three) - p / 3.0;
    for (int i = 0; i < 2; i++) {
        double g = ((x + p) * x + q) * x + r;
        double dg = (3.0 * x + 2.0 * p) * x + q;
        x = x - g * dg / (dg * dg + IKC_TINY);
    }
    return x;
}

/* fast._quartic_real: x[0..3] the roots of x^4 + b x^3 + c x^2 + d x + e as reals, disc[0..1] the two
 * quadratics' discriminants; *pp, *kk the depressed quartic's p and the resolvent's root */
static inline void ikc_rrr_quartic_real(double b, double c, double d, double e, double *x, double *disc,
                                        double *pp, double *kk) {
    double b4 = 0.25 * b;
    double p = c - 6.0 * b4 * b4;
    double q = d - 2.0 * c * b4 + 8.0 * b4 * b4 * b4;
    double r = e - d * b4 + c * b4 * b4 - 3.0 * b4 * b4 * b4 * b4;
    double k = ikc_pos(ikc_rrr_cubic_largest(p, 0.25 * p * p - r, -0.125 * q * q));
    double s = sqrt(2.0 * k);
    int tiny = s * s <= 1e-14 * (fabs(p) + sqrt(fabs(r)) + IKC_TINY);
    double h = tiny ? 0.0 : q / (2.0 * ikc_big(tiny ? 1.0 : s));
    double z = sqrt(ikc_pos(0.25 * p * p - r));
    for (int i = 0; i < 2; i++) {
        double sign = i == 0 ? 1.0 : -1.0;
        double disc_f = 0.25 * s * s - (0.5 * p + k + sign * h);
        double y2 = -0.5 * p - sign * z;
        double dd = tiny ? y2 : disc_f;
        double root = sqrt(ikc_pos(dd));
        double centre = tiny ? 0.0 : 0.5 * sign * s;
        x[2 * i] = centre + root - b4;
        x[2 * i + 1] = centre - root - b4;
        disc[i] = dd;
    }
    *pp = p;
    *kk = k;
}


/* fast._rrr_gauss_newton: one Newton step of the whole S2-RRR equation from t (cs: cos, sin of each) */
static inline void ikc_rrr_gauss_newton(const double *w1, const double *r1, const double *w2, const double *r2,
                                        const double *w3, const double *r3, const double *p, const double *qq,
                                        double *t, const double *cs) {
    double d[3], x3[3], x2[3], x1[3], a2[3], b2[3], a3[3], b3[3], u[3];
    ikc_sub(p, r3, d);
    ikc_turn_cs(w3, cs[4], cs[5], d, u);
    ikc_axpy(1.0, u, r3, x3);
    ikc_sub(x3, r2, d);
    ikc_turn_cs(w2, cs[2], cs[3], d, u);
    ikc_axpy(1.0, u, r2, x2);
    ikc_sub(x2, r1, d);
    ikc_turn_cs(w1, cs[0], cs[1], d, x1);
    ikc_turn_cs(w1, cs[0], cs[1], w2, a2);
    ikc_sub(r2, r1, d);
    ikc_turn_cs(w1, cs[0], cs[1], d, b2);
    ikc_turn_cs(w2, cs[2], cs[3], w3, u);
    ikc_turn_cs(w1, cs[0], cs[1], u, a3);
    ikc_sub(r3, r2, d);
    ikc_turn_cs(w2, cs[2], cs[3], d, u);
    ikc_axpy(1.0, u, r2, d);
    ikc_sub(d, r1, u);
    ikc_turn_cs(w1, cs[0], cs[1], u, b3);
    double j1[3], j2[3], j3[3], e[3], c23[3], c31[3], c12[3];
    ikc_cross(w1, x1, j1);
    ikc_sub(x1, b2, d);
    ikc_cross(a2, d, j2);
    ikc_sub(x1, b3, d);
    ikc_cross(a3, d, j3);
    ikc_sub(qq, r1, d);
    ikc_sub(d, x1, e);
    ikc_cross(j2, j3, c23);
    ikc_cross(j3, j1, c31);
    ikc_cross(j1, j2, c12);
    double det = ikc_dot(j1, c23);
    int ok = fabs(det) > IKC_NEAR * sqrt(ikc_dot(j1, j1) * ikc_dot(j2, j2) * ikc_dot(j3, j3));
    double inv = (ok ? 1.0 : 0.0) / (ok ? det : 1.0);
    t[0] = t[0] + ikc_dot(e, c23) * inv;
    t[1] = t[1] + ikc_dot(e, c31) * inv;
    t[2] = t[2] + ikc_dot(e, c12) * inv;
}

/* S2-RRR: exp(xi1 t1) exp(xi2 t2) exp(xi3 t3)(p) = q, axes 2 and 3 neither parallel nor meeting (the
 * quartic of subproblems/s2_rrr.py by Ferrari, Newton steps; fast.point_rrr).  4 slots x 3; a complex
 * pair's slots IKC_EMPTY where the other pair is real; degenerate or unreachable: IKC_DEFER */
static inline void ikc_point_rrr(const double *w1, const double *r1, const double *w2, const double *r2,
                                 const double *w3, const double *r3, const double *p, const double *qq,
                                 double *q, int *f) {
    double size2 = ikc_dot(p, p) + ikc_dot(qq, qq) + ikc_dot(r1, r1) + ikc_dot(r2, r2) + ikc_dot(r3, r3);
    double size = sqrt(size2) + IKC_TINY;
    double u[3], cc[3], cs[3], c0[3], v[3], ec[3], es[3], e0[3], k[3], h[3], d[3];
    ikc_sub(qq, r1, u);
    double uw = ikc_dot(w1, u);
    ikc_axpy(-uw, w1, u, cc);
    ikc_cross(w1, cc, cs);
    ikc_axpy(uw, w1, r1, c0);
    ikc_sub(p, r3, v);
    double vw = ikc_dot(w3, v);
    ikc_axpy(-vw, w3, v, ec);
    ikc_cross(w3, ec, es);
    ikc_axpy(vw, w3, r3, e0);
    ikc_sub(e0, r2, k);
    ikc_sub(c0, r2, h);
    double m00 = ikc_dot(w2, ec), m01 = ikc_dot(w2, es);
    double m10 = 2.0 * ikc_dot(k, ec) / size, m11 = 2.0 * ikc_dot(k, es) / size;
    ikc_sub(c0, e0, d);
    double g0[2] = {ikc_dot(w2, d), (ikc_dot(h, h) + ikc_dot(cc, cc) - ikc_dot(k, k) - ikc_dot(ec, ec)) / size};
    double gc[2] = {ikc_dot(w2, cc), 2.0 * ikc_dot(h, cc) / size};
    double gs[2] = {-ikc_dot(w2, cs), -2.0 * ikc_dot(h, cs) / size};
    double det = m00 * m11 - m01 * m10;
    double mm = m00 * m00 + m01 * m01 + m10 * m10 + m11 * m11;
    double a0[2] = {m11 * g0[0] - m01 * g0[1], m00 * g0[1] - m10 * g0[0]};
    double ac[2] = {m11 * gc[0] - m01 * gc[1], m00 * gc[1] - m10 * gc[0]};
    double as[2] = {m11 * gs[0] - m01 * gs[1], m00 * gs[1] - m10 * gs[0]};
    double qa = ac[0] * ac[0] + ac[1] * ac[1];
    double qb = 2.0 * (ac[0] * as[0] + ac[1] * as[1]);
    double qc = as[0] * as[0] + as[1] * as[1];
    double fs[5] = {a0[0] * a0[0] + a0[1] * a0[1] - det * det + 0.5 * (qa + qc),
                    2.0 * (a0[0] * ac[0] + a0[1] * ac[1]), 2.0 * (a0[0] * as[0] + a0[1] * as[1]),
                    0.5 * (qa - qc), 0.5 * qb};
    double ee = g0[0] * g0[0] + g0[1] * g0[1] + gc[0] * gc[0] + gc[1] * gc[1] + gs[0] * gs[0] + gs[1] * gs[1];
    double ref = mm * (mm + ee) + IKC_TINY;
    double fn = sqrt(fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2] + fs[3] * fs[3] + fs[4] * fs[4]);
    double lim = IKC_NEAR2 * size2;
    int flag = ((det * det <= IKC_RRR_REGULAR * IKC_RRR_REGULAR * mm * mm) || (ikc_dot(cc, cc) <= lim) ||
                (ikc_dot(ec, ec) <= lim) || (fn <= IKC_NEAR * ref)) ? IKC_DEFER : 0;
    /* the centre: the sample angle k pi / 4 where |F| is largest (fast._RRR_SAMPLES) */
    double big_f = ikc_rrr_trig2(fs, 1.0, 0.0), pc = -1.0, ps = 0.0;
    for (int j = 1; j < 8; j++) {
        double c = cos(j * IKC_PI / 4), s = sin(j * IKC_PI / 4);
        double fk = ikc_rrr_trig2(fs, c, s);
        if (fabs(fk) > fabs(big_f)) {
            big_f = fk;
            pc = -c;
            ps = -s;
        }
    }
    double c2p = pc * pc - ps * ps, s2p = 2.0 * ps * pc;
    double f0 = fs[0], c1 = fs[1], s1 = fs[2], c2 = fs[3], s2 = fs[4];
    double c1r = c1 * pc + s1 * ps, s1r = s1 * pc - c1 * ps;
    double c2r = c2 * c2p + s2 * s2p, s2r = s2 * c2p - c2 * s2p;
    double inv = 1.0 / (big_f == 0.0 ? 1.0 : big_f);
    double xs[4], discs[2], p_, k_;
    ikc_rrr_quartic_real((2.0 * s1r - 4.0 * s2r) * inv, (2.0 * f0 - 6.0 * c2r) * inv, (2.0 * s1r + 4.0 * s2r) * inv,
                         (f0 + c1r + c2r) * inv, xs, discs, &p_, &k_);
    double phi = atan2(ps, pc);
    double band = IKC_RRR_DOUBLE * IKC_RRR_DOUBLE * (1.0 + fabs(p_) + k_);
    int some_real = (discs[0] >= -band) || (discs[1] >= -band);
    for (int i = 0; i < 4; i++) {
        double dd = discs[i / 2];
        int real = dd >= -band;
        int kind = (fabs(dd) <= band ? IKC_DEFER : 0) | (dd < -band ? (some_real ? IKC_EMPTY : IKC_DEFER) : 0);
        double t1 = phi + 2.0 * atan2(xs[i], 1.0);
        for (int j = 0; j < IKC_RRR_NEWTON; j++) {
            double c = cos(t1), s = sin(t1);
            double c2_ = c * c - s * s, s2_ = 2.0 * s * c;
            double fv = f0 + c1 * c + s1 * s + c2 * c2_ + s2 * s2_;
            double dv = s1 * c - c1 * s + 2.0 * (s2 * c2_ - c2 * s2_);
            t1 = real ? t1 - fv * dv / (dv * dv + IKC_TINY) : t1;
        }
        double c = cos(t1), s = sin(t1);
        double c2_ = c * c - s * s, s2_ = 2.0 * s * c;
        double fv = f0 + c1 * c + s1 * s + c2 * c2_ + s2 * s2_;
        double dv = s1 * c - c1 * s + 2.0 * (s2 * c2_ - c2 * s2_);
        int dbl = (fabs(dv) <= IKC_RRR_DOUBLE * ref) && (fabs(fv) <= IKC_RRR_DOUBLE * ref);
        double t3 = atan2((a0[1] + ac[1] * c + as[1] * s) * det, (a0[0] + ac[0] * c + as[0] * s) * det);
        double y[3] = {c0[0] + cc[0] * c - cs[0] * s, c0[1] + cc[1] * c - cs[1] * s, c0[2] + cc[2] * c - cs[2] * s};
        double c3 = cos(t3), s3 = sin(t3);
        double z[3] = {e0[0] + ec[0] * c3 + es[0] * s3, e0[1] + ec[1] * c3 + es[1] * s3,
                       e0[2] + ec[2] * c3 + es[2] * s3};
        double zr[3], yr[3], tcs[6];
        int f2;
        ikc_sub(z, r2, zr);
        ikc_sub(y, r2, yr);
        double t2 = ikc_angle_about_cs(w2, zr, yr, size2, &f2, tcs + 2);
        double t[3] = {t1, t2, t3};
        if (real) {
            tcs[0] = c;
            tcs[1] = s;
            tcs[4] = c3;
            tcs[5] = s3;
            ikc_rrr_gauss_newton(w1, r1, w2, r2, w3, r3, p, qq, t, tcs);
        }
        q[3 * i] = t[0];
        q[3 * i + 1] = t[1];
        q[3 * i + 2] = t[2];
        f[i] = flag | f2 | (dbl ? IKC_DEFER : 0) | kind;
    }
}

/* ------------------------------------------------------------------------------------------------
 * The kernels without their angles' cosines and sines (the signatures of fast.py's kernels) */

static inline void ikc_plane_r(const double *w, const double *r, const double *p, const double *h, double d,
                               double rep, double *q, int *f) {
    double cs[4];
    ikc_plane_r_cs(w, r, p, h, d, rep, q, f, cs);
}

static inline void ikc_dist_r(const double *w, const double *r, const double *p, const double *qq, double d,
                              double rep, double *q, int *f) {
    double cs[4];
    ikc_dist_r_cs(w, r, p, qq, d, rep, q, f, cs);
}

static inline void ikc_point_r(const double *w, const double *r, const double *p, const double *qq, double *q,
                               int *f) {
    double cs[2];
    ikc_point_r_cs(w, r, p, qq, q, f, cs);
}

static inline void ikc_point_rr_meet(const double *w1, const double *r1, const double *w2, const double *r2,
                                     const double *p, const double *qq, double rep, double *q, int *f) {
    double cs[8];
    ikc_point_rr_meet_cs(w1, r1, w2, r2, p, qq, rep, q, f, cs);
}

static inline void ikc_point_rr_parallel(const double *w1, const double *r1, const double *w2, const double *r2,
                                         const double *p, const double *qq, double rep, double *q, int *f) {
    double cs[8];
    ikc_point_rr_parallel_cs(w1, r1, w2, r2, p, qq, rep, q, f, cs);
}

static inline void ikc_rot_rr(const double *w1, const double *w2, const double *R, double *q, int *f) {
    double cs[4];
    ikc_rot_rr_cs(w1, w2, R, q, f, cs);
}

static inline void ikc_rot_rrr(const double *w1, const double *w2, const double *w3, const double *R, double rep,
                               double *q, int *f) {
    double cs[12];
    ikc_rot_rrr_cs(w1, w2, w3, R, rep, q, f, cs);
}

#endif /* IKC_FAST_KERNELS_H */
