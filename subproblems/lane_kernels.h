/* Lane forms of the kernels of fast_kernels.h: the block chain of a batch, four poses at once
 * (docs/design.md section 14, "SIMD over poses").
 *
 * A block chain (ikcompiler/codegen/printers.py c_lane_function) is the chain ikc_chain with every
 * value a vector of 4 lanes, one pose a lane, and every solution slot computed in every lane.  The
 * kernels here compute only the regular branch of their fast_kernels.h form -- the arithmetic a kernel
 * does where it takes no other branch -- in the same order of operations, and return per slot its flag
 * bits: IKC_TANGENT_ROOT where the scalar kernel sets that flag and nothing else changes (the roots are
 * the same formulas; with libmvec's angles IKC_LANE_AGAIN instead, below), IKC_IRREGULAR wherever it
 * would set another flag (DEFER, FAMILY, LOCK) or take another branch (a locked S2-RR angle, every angle
 * a root).  The exception is O-RRR: a lane whose roots or angles are flagged takes the scalar kernel's
 * values and flags (ikc_v_rot_rrr_lane), so a gimbal lock reaches the leaves as IKC_FAMILY, as in
 * ikc_chain.  A lane whose leaves carry no IKC_IRREGULAR is, value for value and flag for flag, what
 * ikc_chain computes for that pose (every +, -, *, /, sqrt of a lane is the scalar IEEE operation: no
 * -ffast-math, -ffp-contract=off); any other lane is handed to the scalar chain
 * whole (fast_finish.h ikc_many_block).  The one difference allowed: with IKC_LIBMVEC the
 * angles (atan2, acos: the joint values themselves, never the cosines and sines of a kernel's outputs,
 * which come from its pairs) come from glibc's libmvec, within a few ulps of libm's
 * (benchmarks/results/batch_simd.md), and so do cos and sin of a value the chain computes from those
 * angles (ur5's q4, ikc_v_cos / ikc_v_sin), which is a few ulps from ikc_chain's already.
 */
#ifndef IKC_LANE_KERNELS_H
#define IKC_LANE_KERNELS_H

#include <math.h>
#include <stdint.h>

typedef double ikc_v4 __attribute__((vector_size(32), aligned(32)));
typedef int64_t ikc_m4 __attribute__((vector_size(32), aligned(32)));  /* a lane mask: 0 or -1 (any bits) */
/* (no immintrin.h: parsing it was three quarters of a block chain's compile time; GCC's builtins and
 * libmvec's ABI take these vector types as they are) */
#define IKC_LANES 4
#define IKC_IRREGULAR 256  /* a lane the scalar chain must solve (fast_finish.h IKC_LANE_IRREGULAR) */
/* A tangent root's flag.  With libmvec's angles a tangent root needs the lane again with libm's
 * (IKC_LANE_AGAIN): its two copies (phi +- acos(x), x within ulps of +-1) split by about the square root
 * of an angle's ulps, so a few ulps of atan2 moved the copy the finish keeps by 1.4e-7 rad (ur5; both
 * exact rows of a double root).  ikc_block_libm runs the block chain with libm's angles in every lane
 * (ikc_lane_libm set, this thread only): its lanes are ikc_chain's leaves bit for bit, tangent roots and
 * all (fast_finish.h ikc_run_block gathers such lanes 4 at a time). */
#define IKC_LANE_AGAIN 512  /* fast_finish.h IKC_LANE_AGAIN */
static __thread int ikc_lane_libm __attribute__((tls_model("initial-exec")));
#if defined(IKC_LIBMVEC) && defined(__AVX2__)
#define IKC_LANE_VECTOR_ANGLES 1
#define IKC_LANE_TANGENT (ikc_lane_libm ? IKC_TANGENT_ROOT : IKC_LANE_AGAIN)
#else
#define IKC_LANE_VECTOR_ANGLES 0
#define IKC_LANE_TANGENT IKC_TANGENT_ROOT
#endif
#define IKC_V(x) ((ikc_v4){(x), (x), (x), (x)})

/* the block chain's arrays hold 4 lanes an entry; loads and stores need no alignment */
static inline ikc_v4 ikc_v_load(const double *p) {
    ikc_v4 v;
    __builtin_memcpy(&v, p, sizeof v);
    return v;
}
static inline void ikc_v_store(double *p, ikc_v4 v) { __builtin_memcpy(p, &v, sizeof v); }
static inline void ikc_m_store(int64_t *p, ikc_m4 m) { __builtin_memcpy(p, &m, sizeof m); }

static inline ikc_v4 ikc_v_sel(ikc_m4 m, ikc_v4 a, ikc_v4 b) {  /* m ? a : b, lane by lane */
    return (ikc_v4)((m & (ikc_m4)a) | (~m & (ikc_m4)b));
}

static inline ikc_v4 ikc_v_abs(ikc_v4 x) {  /* fabs: the sign bit cleared */
    return (ikc_v4)((ikc_m4)x & (ikc_m4){INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX});
}

static inline ikc_v4 ikc_v_sqrt(ikc_v4 x) {  /* correctly rounded either way */
#if defined(__AVX__) && defined(__GNUC__) && !defined(__clang__)
    return __builtin_ia32_sqrtpd256(x);
#else
    ikc_v4 r;
    for (int i = 0; i < IKC_LANES; i++) r[i] = sqrt(x[i]);
    return r;
#endif
}

/* the scalar backend's clip1, pos, big (fast_kernels.h), lane by lane: the same NaN rules */
static inline ikc_v4 ikc_v_clip1(ikc_v4 x) {
    return ikc_v_sel(x < -1.0, IKC_V(-1.0), ikc_v_sel(x > 1.0, IKC_V(1.0), x));
}
static inline ikc_v4 ikc_v_pos(ikc_v4 x) { return ikc_v_sel(x > 0.0, x, IKC_V(0.0)); }
static inline ikc_v4 ikc_v_big(ikc_v4 x) { return ikc_v_sel(x > IKC_TINY, x, IKC_V(IKC_TINY)); }

/* ikc_max2: NaN wins */
static inline ikc_v4 ikc_v_max2(ikc_v4 a, ikc_v4 b) {
    return ikc_v_sel((a != a) | (b != b), IKC_V(NAN), ikc_v_sel(a > b, a, b));
}

/* libm's angles, lane by lane */
static inline ikc_v4 ikc_v_atan2_libm(ikc_v4 y, ikc_v4 x) {
    ikc_v4 r;
    for (int i = 0; i < IKC_LANES; i++) r[i] = atan2(y[i], x[i]);
    return r;
}
static inline ikc_v4 ikc_v_acos_libm(ikc_v4 x) {
    ikc_v4 r;
    for (int i = 0; i < IKC_LANES; i++) r[i] = acos(x[i]);
    return r;
}
#if IKC_LANE_VECTOR_ANGLES
/* glibc's AVX2 vector variants (libmvec.so.1), libm's where ikc_block_libm asks for them (out of line:
 * inlined, the four libm calls made the callers' hot path slower: +2% of ur5's instructions) */
extern ikc_v4 _ZGVdN4vv_atan2(ikc_v4 y, ikc_v4 x);
extern ikc_v4 _ZGVdN4v_acos(ikc_v4 x);
__attribute__((cold, noinline)) static ikc_v4 ikc_v_atan2_again(ikc_v4 y, ikc_v4 x) { return ikc_v_atan2_libm(y, x); }
__attribute__((cold, noinline)) static ikc_v4 ikc_v_acos_again(ikc_v4 x) { return ikc_v_acos_libm(x); }
static inline ikc_v4 ikc_v_atan2(ikc_v4 y, ikc_v4 x) {
    return __builtin_expect(ikc_lane_libm, 0) ? ikc_v_atan2_again(y, x) : _ZGVdN4vv_atan2(y, x);
}
static inline ikc_v4 ikc_v_acos(ikc_v4 x) {
    return __builtin_expect(ikc_lane_libm, 0) ? ikc_v_acos_again(x) : _ZGVdN4v_acos(x);
}
#else
static inline ikc_v4 ikc_v_atan2(ikc_v4 y, ikc_v4 x) { return ikc_v_atan2_libm(y, x); }
static inline ikc_v4 ikc_v_acos(ikc_v4 x) { return ikc_v_acos_libm(x); }
#endif

/* cos and sin that a chain reads of a value other than a kernel's output (ur5's q4, a difference of
 * angles).  libm's, lane by lane, so they round as ikc_chain's: written lane by lane, not as a loop, so
 * that GCC pairs cos and sin of one lane into one sincos call, as it does in ikc_chain (the same
 * values: glibc's sincos is its sin and cos; 8 libm calls a leaf became 4 on ur5). */
static inline ikc_v4 ikc_v_cos_libm(ikc_v4 x) {
    return (ikc_v4){cos(x[0]), cos(x[1]), cos(x[2]), cos(x[3])};
}
static inline ikc_v4 ikc_v_sin_libm(ikc_v4 x) {
    return (ikc_v4){sin(x[0]), sin(x[1]), sin(x[2]), sin(x[3])};
}
#if IKC_LANE_VECTOR_ANGLES
/* With libmvec's angles such a value is already a few ulps from ikc_chain's (its angles come from
 * libmvec), so its cos and sin come from libmvec too (docs/design.md section 14, session 18); libm's
 * where ikc_block_libm asks for them, whose lanes must be ikc_chain's bit for bit. */
extern ikc_v4 _ZGVdN4v_cos(ikc_v4 x);
extern ikc_v4 _ZGVdN4v_sin(ikc_v4 x);
__attribute__((cold, noinline)) static ikc_v4 ikc_v_cos_again(ikc_v4 x) { return ikc_v_cos_libm(x); }
__attribute__((cold, noinline)) static ikc_v4 ikc_v_sin_again(ikc_v4 x) { return ikc_v_sin_libm(x); }
static inline ikc_v4 ikc_v_cos(ikc_v4 x) {
    return __builtin_expect(ikc_lane_libm, 0) ? ikc_v_cos_again(x) : _ZGVdN4v_cos(x);
}
static inline ikc_v4 ikc_v_sin(ikc_v4 x) {
    return __builtin_expect(ikc_lane_libm, 0) ? ikc_v_sin_again(x) : _ZGVdN4v_sin(x);
}
#else
static inline ikc_v4 ikc_v_cos(ikc_v4 x) { return ikc_v_cos_libm(x); }
static inline ikc_v4 ikc_v_sin(ikc_v4 x) { return ikc_v_sin_libm(x); }
#endif

static inline ikc_v4 ikc_v_dot(const ikc_v4 *a, const ikc_v4 *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static inline void ikc_v_cross(const ikc_v4 *a, const ikc_v4 *b, ikc_v4 *out) {
    ikc_v4 x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2], z = a[0] * b[1] - a[1] * b[0];
    out[0] = x;
    out[1] = y;
    out[2] = z;
}

static inline void ikc_v_sub(const ikc_v4 *a, const ikc_v4 *b, ikc_v4 *out) {
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

static inline void ikc_v_mat_vec(const ikc_v4 *R, const ikc_v4 *x, ikc_v4 *out) {
    ikc_v4 a = R[0] * x[0] + R[1] * x[1] + R[2] * x[2];
    ikc_v4 b = R[3] * x[0] + R[4] * x[1] + R[5] * x[2];
    ikc_v4 c = R[6] * x[0] + R[7] * x[1] + R[8] * x[2];
    out[0] = a;
    out[1] = b;
    out[2] = c;
}

static inline void ikc_v_mat_t_vec(const ikc_v4 *R, const ikc_v4 *x, ikc_v4 *out) {
    ikc_v4 a = R[0] * x[0] + R[3] * x[1] + R[6] * x[2];
    ikc_v4 b = R[1] * x[0] + R[4] * x[1] + R[7] * x[2];
    ikc_v4 c = R[2] * x[0] + R[5] * x[1] + R[8] * x[2];
    out[0] = a;
    out[1] = b;
    out[2] = c;
}

static inline void ikc_v_unit_pair(ikc_v4 c, ikc_v4 s, ikc_v4 *cs) {
    ikc_v4 r = ikc_v_sqrt(c * c + s * s);
    ikc_v4 inv = 1.0 / ikc_v_big(r);
    cs[0] = c * inv + ikc_v_sel(r == 0.0, IKC_V(1.0), IKC_V(0.0));
    cs[1] = s * inv;
}

/* ikc_angle_about_cs; the mask: its DEFER */
static inline ikc_v4 ikc_v_angle_about_cs(const ikc_v4 *w, const ikc_v4 *u, const ikc_v4 *v, ikc_v4 size2,
                                          ikc_m4 *flag, ikc_v4 *cs) {
    ikc_v4 w0 = w[0], w1 = w[1], w2 = w[2];
    ikc_v4 u0 = u[0], u1 = u[1], u2 = u[2];
    ikc_v4 v0 = v[0], v1 = v[1], v2 = v[2];
    ikc_v4 uw = w0 * u0 + w1 * u1 + w2 * u2;
    ikc_v4 vw = w0 * v0 + w1 * v1 + w2 * v2;
    ikc_v4 a0 = u0 - uw * w0, a1 = u1 - uw * w1, a2 = u2 - uw * w2;
    ikc_v4 b0 = v0 - vw * w0, b1 = v1 - vw * w1, b2 = v2 - vw * w2;
    ikc_v4 sin_part = w0 * (a1 * b2 - a2 * b1) + w1 * (a2 * b0 - a0 * b2) + w2 * (a0 * b1 - a1 * b0);
    ikc_v4 cos_part = a0 * b0 + a1 * b1 + a2 * b2;
    ikc_v4 th = ikc_v_atan2(sin_part, cos_part);
    ikc_v4 lim = IKC_NEAR2 * (u0 * u0 + u1 * u1 + u2 * u2 + v0 * v0 + v1 * v1 + v2 * v2 + size2 + 1.0);
    *flag = (a0 * a0 + a1 * a1 + a2 * a2 <= lim) | (b0 * b0 + b1 * b1 + b2 * b2 <= lim);
    ikc_v_unit_pair(cos_part, sin_part, cs);
    return th;
}

/* ikc_trig_roots_cs where no root is every angle; flags: IKC_IRREGULAR where flat (DEFER or FAMILY),
 * IKC_TANGENT_ROOT as the scalar kernel's */
static inline ikc_m4 ikc_v_trig_roots_cs(ikc_v4 a, ikc_v4 b, ikc_v4 c, ikc_v4 size, ikc_v4 *th, ikc_v4 *cs) {
    ikc_v4 rho = ikc_v_sqrt(a * a + b * b);
    ikc_v4 phi = ikc_v_atan2(b, a);
    ikc_v4 x = c / ikc_v_big(rho);
    ikc_v4 cd = ikc_v_clip1(x);
    ikc_v4 delta = ikc_v_acos(cd);
    ikc_m4 flat = rho <= IKC_NEAR * size;
    ikc_m4 tangent = (ikc_v_abs(x * x - 1.0) <= IKC_TANGENT) & (rho > IKC_NEAR * size);
    th[0] = phi + delta;
    th[1] = phi - delta;
    ikc_v4 u[2];
    ikc_v_unit_pair(a, b, u);
    ikc_v4 cp = u[0], sp = u[1];
    ikc_v4 sd = ikc_v_sqrt(ikc_v_pos((1.0 - cd) * (1.0 + cd)));
    cs[0] = cp * cd - sp * sd;
    cs[1] = sp * cd + cp * sd;
    cs[2] = cp * cd + sp * sd;
    cs[3] = sp * cd - cp * sd;
    return (flat & IKC_IRREGULAR) | (tangent & IKC_LANE_TANGENT);
}

/* H-R (ikc_plane_r_cs).  2 slots x 1 */
static inline void ikc_v_plane_r_cs(const ikc_v4 *w, const ikc_v4 *r, const ikc_v4 *p, const ikc_v4 *h, ikc_v4 d,
                                    ikc_v4 *q, ikc_m4 *f, ikc_v4 *cs) {
    ikc_v4 u[3], up[3], wu[3];
    ikc_v_sub(p, r, u);
    ikc_v4 uw = ikc_v_dot(w, u);
    for (int i = 0; i < 3; i++) up[i] = -uw * w[i] + u[i];
    ikc_v4 a = ikc_v_dot(h, up);
    ikc_v_cross(w, u, wu);
    ikc_v4 b = ikc_v_dot(h, wu);
    ikc_v4 c = d - ikc_v_dot(h, r) - uw * ikc_v_dot(h, w);
    ikc_v4 size = ikc_v_sqrt(ikc_v_dot(h, h) * (ikc_v_dot(u, u) + ikc_v_dot(r, r) + ikc_v_dot(p, p) + 1.0)) + IKC_TINY;
    f[0] = f[1] = ikc_v_trig_roots_cs(a, b, c, size, q, cs);
}

/* S2-RR, parallel axes (ikc_point_rr_parallel_cs).  2 slots x 2; IKC_IRREGULAR: coincident axes or a
 * locked angle */
static inline void ikc_v_point_rr_parallel_cs(const ikc_v4 *w1, const ikc_v4 *r1, const ikc_v4 *w2,
                                              const ikc_v4 *r2, const ikc_v4 *p, const ikc_v4 *qq, ikc_v4 *q,
                                              ikc_m4 *f, ikc_v4 *cs) {
    ikc_v4 w0 = w1[0], w1_ = w1[1], w2_ = w1[2];
    ikc_v4 e0 = r1[0] - r2[0], e1 = r1[1] - r2[1], e2 = r1[2] - r2[2];
    ikc_v4 h = w0 * e0 + w1_ * e1 + w2_ * e2;
    e0 = e0 - h * w0;
    e1 = e1 - h * w1_;
    e2 = e2 - h * w2_;
    ikc_v4 u0 = p[0] - r2[0], u1 = p[1] - r2[1], u2 = p[2] - r2[2];
    ikc_v4 height = w0 * u0 + w1_ * u1 + w2_ * u2;
    ikc_v4 a[3] = {u0 - height * w0, u1 - height * w1_, u2 - height * w2_};
    ikc_v4 v0 = qq[0] - r1[0], v1 = qq[1] - r1[1], v2 = qq[2] - r1[2];
    h = w0 * v0 + w1_ * v1 + w2_ * v2;
    ikc_v4 b[3] = {v0 - h * w0, v1 - h * w1_, v2 - h * w2_};
    ikc_v4 ee = e0 * e0 + e1 * e1 + e2 * e2;
    ikc_v4 rho2 = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    ikc_v4 rho1 = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
    ikc_v4 x = (rho2 - rho1 + ee) / (2.0 * ikc_v_big(ee));
    ikc_v4 y2 = rho2 / ikc_v_big(ee) - x * x;
    ikc_v4 y = ikc_v_sqrt(ikc_v_pos(y2));
    ikc_v4 f0 = w1_ * e2 - w2_ * e1, f1 = w2_ * e0 - w0 * e2, f2 = w0 * e1 - w1_ * e0;
    ikc_v4 size2 = ikc_v_dot(p, p) + ikc_v_dot(qq, qq) + ikc_v_dot(r1, r1) + ikc_v_dot(r2, r2);
    ikc_m4 degenerate = ((ee <= IKC_NEAR2 * (rho1 + rho2 + size2 + 1.0)) & IKC_IRREGULAR) |
                        ((ikc_v_abs(y2) * ee <= IKC_TANGENT * rho2) & IKC_LANE_TANGENT);
    for (int i = 0; i < 2; i++) {
        ikc_v4 s = i == 0 ? y : -y;
        ikc_v4 z[3] = {x * e0 + s * f0, x * e1 + s * f1, x * e2 + s * f2};
        ikc_v4 ze[3] = {z[0] - e0, z[1] - e1, z[2] - e2};
        ikc_m4 g1, g2;
        q[2 * i + 1] = ikc_v_angle_about_cs(w2, a, z, size2, &g2, cs + 4 * i + 2);
        q[2 * i] = ikc_v_angle_about_cs(w1, ze, b, size2, &g1, cs + 4 * i);
        f[i] = degenerate | ((g1 | g2) & IKC_IRREGULAR);
    }
}

/* The scalar O-RRR kernel for lane l (ikc_rot_rrr_cs at the block chain's rep = 0, the finish library's
 * copy: the same C, so the same values and flags as ikc_chain's) in place of the lane's regular
 * branch: a gimbal lock (the wrist of a UR arm at q5 = 0) keeps its lock values, flagged IKC_FAMILY, and
 * the lane goes on in the block chain; any other flag but IKC_TANGENT_ROOT (DEFER, the representative's
 * angle deferred) makes it irregular.  Cold: 12% of ur5's batch poses, 1-2% of puma560's. */
__attribute__((cold, noinline)) static void ikc_v_rot_rrr_lane(const ikc_v4 *w1, const ikc_v4 *w2,
                                                              const ikc_v4 *w3, const ikc_v4 *R, int l,
                                                              ikc_v4 *q, ikc_m4 *f, ikc_v4 *cs) {
    double a[3], b[3], c[3], M[9], sq[6], scs[12];
    int sf[2];
    for (int i = 0; i < 3; i++) a[i] = w1[i][l], b[i] = w2[i][l], c[i] = w3[i][l];
    for (int i = 0; i < 9; i++) M[i] = R[i][l];
    ikc_shared_k_rot_rrr_cs(a, b, c, M, 0.0, sq, sf, scs);
    for (int i = 0; i < 6; i++) q[i][l] = sq[i];
    for (int i = 0; i < 12; i++) cs[i][l] = scs[i];
    for (int i = 0; i < 2; i++) {
        /* a lock's values are not the split copies of a tangent root: its flag stays as it is */
        const int64_t tangent = (sf[i] & IKC_FAMILY) ? IKC_TANGENT_ROOT : IKC_LANE_TANGENT;
        f[i][l] = (sf[i] & IKC_FAMILY) | ((sf[i] & IKC_TANGENT_ROOT) ? tangent : 0) |
                  ((sf[i] & ~(IKC_FAMILY | IKC_TANGENT_ROOT)) ? IKC_IRREGULAR : 0);
    }
}

/* Whether a flagged O-RRR lane takes the scalar kernel (1) or is irregular (0): 0 where the module has an
 * alternative chain, whose scalar path tries that chain first at a gimbal lock, so the lane's lock values
 * would be spent for nothing (puma560: +2.5% of its instructions).  Set by ikc_solve_many_block from the
 * module's ikc_robot (the same value from every thread: relaxed atomics). */
static int ikc_lane_locks = 1;

/* O-RRR (ikc_rot_rrr_cs): the regular branch in every lane, then the scalar kernel in each lane where
 * either root is flagged (a tangent root may be a lock) or an angle about w1 or w3 is deferred (a lock):
 * ikc_v_rot_rrr_lane.  2 slots x 3 */
static inline void ikc_v_rot_rrr_cs(const ikc_v4 *w1, const ikc_v4 *w2, const ikc_v4 *w3, const ikc_v4 *R,
                                    ikc_v4 *q, ikc_m4 *f, ikc_v4 *cs) {
    ikc_v4 Rw3[3], Rtw1[3], w23[3], w21[3];
    ikc_v_mat_vec(R, w3, Rw3);
    ikc_v_mat_t_vec(R, w1, Rtw1);
    ikc_v4 k12 = ikc_v_dot(w1, w2), k23 = ikc_v_dot(w2, w3);
    ikc_v_cross(w2, w3, w23);
    ikc_v_cross(w2, w1, w21);
    ikc_v4 a = ikc_v_dot(w1, w3) - k12 * k23;
    ikc_v4 b = ikc_v_dot(w1, w23);
    ikc_v4 c = ikc_v_dot(w1, Rw3) - k12 * k23;
    ikc_v4 roots[2], rcs[4];
    ikc_m4 rf = ikc_v_trig_roots_cs(a, b, c, IKC_V(1.0), roots, rcs);
    for (int i = 0; i < 2; i++) {
        ikc_v4 t2 = roots[i];
        ikc_v4 c2 = rcs[2 * i], s2 = rcs[2 * i + 1];
        ikc_v4 k3 = k23 * (1.0 - c2), k1 = k12 * (1.0 - c2);
        ikc_v4 z[3] = {
            c2 * w3[0] + s2 * w23[0] + k3 * w2[0],
            c2 * w3[1] + s2 * w23[1] + k3 * w2[1],
            c2 * w3[2] + s2 * w23[2] + k3 * w2[2],
        };
        ikc_v4 y[3] = {
            c2 * w1[0] - s2 * w21[0] + k1 * w2[0],
            c2 * w1[1] - s2 * w21[1] + k1 * w2[1],
            c2 * w1[2] - s2 * w21[2] + k1 * w2[2],
        };
        ikc_m4 f1, f3;
        q[3 * i] = ikc_v_angle_about_cs(w1, z, Rw3, IKC_V(0.0), &f1, cs + 6 * i);
        q[3 * i + 1] = t2;
        cs[6 * i + 2] = c2;
        cs[6 * i + 3] = s2;
        q[3 * i + 2] = ikc_v_angle_about_cs(w3, Rtw1, y, IKC_V(0.0), &f3, cs + 6 * i + 4);
        f[i] = (rf != 0) | f1 | f3;
    }
    if (!__atomic_load_n(&ikc_lane_locks, __ATOMIC_RELAXED)) {
        f[0] &= IKC_IRREGULAR;
        f[1] &= IKC_IRREGULAR;
        return;
    }
    const ikc_m4 odd = f[0] | f[1];
    for (int l = 0; l < IKC_LANES; l++)
        if (odd[l]) ikc_v_rot_rrr_lane(w1, w2, w3, R, l, q, f, cs);
}

#endif /* IKC_LANE_KERNELS_H */
