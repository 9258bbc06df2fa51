/* The chains' time sharing and time of distance (laws/chain.py: _share_time_numpy,
_time_of_distance), their whole Newton loops compiled.

Optional extension _gcode_opt_chaincore (setup.py builds it; laws/chain.py falls back to
the numpy code when it is missing, stale or GCODE_OPT_PURE_PYTHON is set).  It must give
the numpy code's bits: every double operation below is the one numpy does, in the same
order (built with -ffp-contract=off, no fast math).  No libm function is called on a
value: sinh and x³ are the deterministic primitives of laws/prims.py (+ - * / only, the
same operations as there: p_sinh, p_cube), so the bits are the same on every machine.
Sums per chain are bincount's: from 0.0, in the order of the pieces. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <float.h>
#include <stdint.h>
#include <string.h>
#include "../_npsum.h"      /* np_pairwise_sum: numpy's pairwise sum */

#if defined(_MSC_VER) && !defined(restrict)
#define restrict __restrict
#endif

#define FD_H_R 1e-4
#define NEWTON_TOL_R 1e-8
#define GAMMA_SWITCH 4.0
#define NTERMS 24
#define SINH_MAX 32        /* prims.SINH_TERMS (17) at most */

typedef struct {
    Py_buffer v[32];
    int n;
} Bufs;

static void release(Bufs *b) {
    for (int i = 0; i < b->n; i++) PyBuffer_Release(&b->v[i]);
    b->n = 0;
}

/* a C-contiguous buffer of items of `size` bytes; NULL (exception set) otherwise */
static void *get(Bufs *b, PyObject *o, Py_ssize_t size, int writable, Py_ssize_t *len) {
    Py_buffer *v = &b->v[b->n];
    /* (no PyBUF_FORMAT: only the item size is checked; numpy makes its format string, and
       compares it with its cached one, a buffer, when asked for it) */
    int flags = PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(o, v, flags) < 0) return NULL;
    b->n++;
    if (v->itemsize != size) {
        PyErr_SetString(PyExc_TypeError, "chain core: wrong item size");
        return NULL;
    }
    if (len) *len = v->len / size;
    return v->buf;
}

/* numpy's maximum: the first operand if it is nan or not below the second */
static inline double np_max(double a, double b) {
    int k = (a >= b) | (a != a);          /* (both tests, no short cut: a select, not branches) */
    return k ? a : b;
}

/* numpy's nan_to_num */
static inline double nan_to_num(double x) {
    if (isnan(x)) return 0.0;
    if (isinf(x)) return x > 0 ? DBL_MAX : -DBL_MAX;
    return x;
}

/* Vector clones where gcc can make them (x86-64 Linux): the loops below are elementwise,
   so SIMD lanes do each element's operations in its order: the same bits as one element at
   a time.  No contraction into fused multiply-adds (-ffp-contract=off, and again in the
   clones' own options: the AVX-512 target has FMA), no reassociation.  (gcc 11 and later
   know x86-64-v4; before, the AVX2 and default clones only.) */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && __GNUC__ >= 11
#define VEC_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default"), \
                                  optimize("O3", "no-trapping-math", "fp-contract=off")))
#elif defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define VEC_CLONES __attribute__((target_clones("avx2", "default"), \
                                  optimize("O3", "no-trapping-math", "fp-contract=off")))
#else
#define VEC_CLONES
#endif

/* 4 doubles, for the Horner loops that keep a block's series in registers (gcc's vector
   extension: elementwise IEEE operations, each lane's in its order; no contraction) */
typedef double v4d __attribute__((vector_size(32)));

/* The input checks' loops without an early exit (so the clones vectorize them; a bad input
   is rare, its check's cost no matter): every x[i] in [0, hi) / finite / finite and > 0. */
VEC_CLONES static int all_in_range(Py_ssize_t n, const int64_t *restrict x, int64_t hi) {
    int bad = 0;
    for (Py_ssize_t i = 0; i < n; i++) bad |= (uint64_t)x[i] >= (uint64_t)hi;
    return !bad;
}

VEC_CLONES static int all_finite(Py_ssize_t n, const double *restrict x) {
    int bad = 0;
    for (Py_ssize_t i = 0; i < n; i++) bad |= !(fabs(x[i]) <= DBL_MAX);       /* isfinite: nan, ±inf not */
    return !bad;
}

VEC_CLONES static int all_finite_pos(Py_ssize_t n, const double *restrict x) {
    int bad = 0;
    for (Py_ssize_t i = 0; i < n; i++) bad |= !(x[i] > 0.0) | !(x[i] <= DBL_MAX);
    return !bad;
}

/* the nonzero bytes among x[0..n) (a vector loop: fixed_knots' count of binding vertices) */
VEC_CLONES static Py_ssize_t count_nonzero_u8(Py_ssize_t n, const uint8_t *restrict x) {
    Py_ssize_t c = 0;
    for (Py_ssize_t i = 0; i < n; i++) c += x[i] != 0;
    return c;
}

/* prims.cube and prims.sinh (its Horner on the fixed coefficients c[0..nc-1], from the
   last): the same operations in the same order */
static inline double p_cube(double x) { return (x * x) * x; }
/* the same, as a macro for the vector clones (a call from them to a function built for
   another target is not inlined: a call per element and AVX/SSE transitions) */
#define P_CUBE(x) (((x) * (x)) * (x))

static inline double p_sinh(double z, const double *restrict c, int nc) {
    double z2 = z * z, s = c[nc - 1];
    for (int q = nc - 2; q >= 0; q--) { s = s * z2; s = s + c[q]; }
    return z + p_cube(z) * s;
}

/* prims.shc: sinh(z)/z, 1 at z = 0 */
static inline double p_shc(double z, const double *restrict c, int nc) {
    double v = p_sinh(z, c, nc) / z;
    return z == 0.0 ? 1.0 : v;
}

/* _nms_terms: the least k with zmax <= table[k] (searchsorted left), plus one, <= NTERMS;
   NTERMS for an empty batch or a nan */
static int nms_terms(double zm, const double *zmax, Py_ssize_t nz, int empty) {
    if (empty || isnan(zm)) return NTERMS;
    Py_ssize_t i = 0;
    while (i < nz && zmax[i] < zm) i++;
    return (int)(i + 1 < NTERMS ? i + 1 : NTERMS);
}

/* The m active pieces' durations Tm and √β sq: Tlo = Tm - h, Thi = Tm + h (h = FD_H_R Tm).
   Returns 1 where a duration is not finite and > 0 or a γ = T / √β not below GAMMA_SWITCH,
   else 0 and *gmax the bits of the largest γ (all then > 0 or +0: their bits order as
   their values, as their squares do). */
VEC_CLONES static int args_vec(Py_ssize_t m, const double *restrict Tm, const double *restrict sq,
                               double *restrict Tlo, double *restrict Thi, int64_t *gmax) {
    int bad = 0;
    int64_t gb = 0;
    for (Py_ssize_t j = 0; j < m; j++) {
        double Ti = Tm[j], h = FD_H_R * Ti, s = sq[j];
        double t0 = Ti - h, t2 = Ti + h;
        double g0 = t0 / s, g1 = Ti / s, g2 = t2 / s;
        Tlo[j] = t0;
        Thi[j] = t2;
        bad |= !(t0 > 0.0) | !(t0 < HUGE_VAL) | !(Ti > 0.0) | !(Ti < HUGE_VAL) | !(t2 > 0.0) | !(t2 < HUGE_VAL)
               | !(g0 < GAMMA_SWITCH) | !(g1 < GAMMA_SWITCH) | !(g2 < GAMMA_SWITCH);
        int64_t b0, b1, b2;
        memcpy(&b0, &g0, 8); memcpy(&b1, &g1, 8); memcpy(&b2, &g2, 8);
        gb = b0 > gb ? b0 : gb;
        gb = b1 > gb ? b1 : gb;
        gb = b2 > gb ? b2 : gb;
    }
    *gmax = gb;
    return bad;
}

#define CHUNK 256          /* pieces a pass of j_chunk: its series stay in L1 */
#define INF_BITS 0x7ff0000000000000LL   /* +inf's bits: a square's (sign dropped) above them is nan */

/* J = ∫ṡ² + β∫s̈² (_J3's arithmetic, element by element) of n pieces at one of their
   three durations t (γ = t / √β: sq), the pieces' L, β, v0 + v1, v0 - v1: the n, m, S1
   series (_horner_nms with its k terms) at γ², prims.shc at γ/2 and γ (the sinh series'
   nc coefficients sc), cube(t); each series in the chunk's own scratch (n <= CHUNK). */
VEC_CLONES static void j_chunk(Py_ssize_t n, int k, const double *restrict t, const double *restrict sqc,
                               const double *restrict coef, const double *restrict sc, int nc,
                               const double *restrict Lc, const double *restrict bc, const double *restrict vsc,
                               const double *restrict vdc, double *restrict J) {
    double nb[CHUNK], mb[CHUNK], sb[CHUNK], zf[CHUNK], hb[CHUNK], fb[CHUNK], f2b[CHUNK], h2b[CHUNK];
    double c0 = coef[3 * (k - 1)], c1 = coef[3 * (k - 1) + 1], c2 = coef[3 * (k - 1) + 2];
    for (Py_ssize_t i = 0; i < n; i++) {
        double z = t[i] / sqc[i], zh = z / 2;
        zf[i] = z;
        f2b[i] = z * z;                       /* γ² (the n, m, S1 series and sinh at γ) */
        h2b[i] = zh * zh;                     /* (γ/2)² */
        nb[i] = c0; mb[i] = c1; sb[i] = c2;
    }
    for (int q = k - 2; q >= 0; q--) {
        double a0 = coef[3 * q], a1 = coef[3 * q + 1], a2 = coef[3 * q + 2];
        for (Py_ssize_t i = 0; i < n; i++) {
            double z2 = f2b[i];
            double x = nb[i] * z2, y = mb[i] * z2, w = sb[i] * z2;
            nb[i] = x + a0; mb[i] = y + a1; sb[i] = w + a2;
        }
    }
    /* the sinh series (prims.sinh's Horner) at γ/2 and γ */
    double cl = sc[nc - 1];
    for (Py_ssize_t i = 0; i < n; i++) { hb[i] = cl; fb[i] = cl; }
    for (int q = nc - 2; q >= 0; q--) {
        double a = sc[q];
        for (Py_ssize_t i = 0; i < n; i++) {
            double x = hb[i] * h2b[i], y = fb[i] * f2b[i];
            hb[i] = x + a; fb[i] = y + a;
        }
    }
    for (Py_ssize_t j = 0; j < n; j++) {
        double zfj = zf[j], zhj = zfj / 2;
        double sh2 = (zhj + P_CUBE(zhj) * hb[j]) / zhj, shg = (zfj + P_CUBE(zfj) * fb[j]) / zfj;
        sh2 = zhj == 0.0 ? 1.0 : sh2;                    /* prims.shc: 1 at z = 0 */
        shg = zfj == 0.0 ? 1.0 : shg;
        double nn = nb[j], n2 = (2 * nn) * nn, sq = sh2 * sh2;
        double Ig1 = mb[j] / n2, Igp = sb[j] / n2, Ih = (2 * sb[j]) / sq, Ihp = (2 * (shg + 1)) / sq;
        double tj = t[j], L = Lc[j];
        double A = L - (tj * vsc[j]) / 2, d = (tj * vdc[j]) / 2;
        double AA = A * A, dd = d * d;
        double iv = ((L * L + AA * Ig1) + dd * Ih) / tj;
        double ia = (AA * Igp + dd * Ihp) / P_CUBE(tj);
        J[j] = iv + bc[j] * ia;
    }
}

/* _share_time's slopes of the m active pieces from their J at T - h, T, T + h (J: 3 m,
   Tc = the durations T): d1 = J', inv = 1 / J'' (its floor as numpy's maximum). */
VEC_CLONES static void slopes(Py_ssize_t m, const double *restrict J, const double *restrict Tc,
                              double *restrict d1b, double *restrict invb) {
    for (Py_ssize_t j = 0; j < m; j++) {
        double J0 = J[j], J1 = J[m + j], J2 = J[2 * m + j];
        double Ti = Tc[j], h = FD_H_R * Ti;
        double d1 = (J2 - J0) / (2.0 * h);
        double d2 = ((J2 - 2.0 * J1) + J0) / (h * h);
        double fl = ((1e-12 * fabs(J1)) / (Ti * Ti)) + 1e-300;
        d2 = (d2 >= fl || isnan(d2)) ? d2 : fl;          /* np.maximum(d2, fl) */
        d1b[j] = d1;
        invb[j] = 1.0 / d2;
    }
}

/* share_time(L, beta, vs, vd, sqb, poff, npc, T_total, T, lam, conv, coef, zmax, sinh_coef,
   max_newton) -> 0, or -1 (T, lam, conv then meaningless: the numpy code runs from the
   start) where a duration is not finite and > 0 or a γ not below GAMMA_SWITCH.
   _share_time_numpy's whole iteration: pieces of chain c at poff[c]:poff[c + 1] (npc:
   their count as doubles), vs = va + vb, vd = va - vb, sqb = √β; T (the first guess,
   updated), lam, conv (uint8) written in place.  Each step: the active pieces (those of
   chains not converged, compact), γ at T - h, T, T + h and the terms k of the n, m, S1
   series the step's batch needs (_nms_terms over the largest γ²), J at the three (j_chunk),
   the slopes, then per chain the Newton update of (T, λ). */
/* One chain's KKT step of the time sharing (share_time's and exact_share's): over its n
 * pieces (T, d1 = J' per piece, inv = 1 / J''), the multiplier l (first: -Σ d1 inv / Σ inv,
 * else lam_prev), the residuals r = d1 + l written over d1, and the multiplier's Newton step
 * *dlam.  Returns 1 where the chain has converged (residuals and total time within
 * tolerance).  Every sum is taken in piece order (the fused and split forms: the same sums). */
static inline int kkt_chain(const double *T, double *d1, const double *inv, Py_ssize_t n, int first,
                            double lam_prev, double Ttot, double npc, double *l_out, double *dlam) {
    double s_inv = 0.0, s_d1inv = 0.0, s_T = 0.0, s_ad1 = 0.0, s_rinv = 0.0, rr = 0.0, l;
    if (!first) {            /* λ known: the residuals' sums in the same pass (the same sums) */
        l = lam_prev;
        for (Py_ssize_t p = 0; p < n; p++) {
            double d = d1[p], iv = inv[p];
            s_inv += iv;
            s_d1inv += d * iv;
            s_T += T[p];
            s_ad1 += fabs(d);
            double r = d + l;
            d1[p] = r;                    /* r from here on */
            s_rinv += r * iv;
            rr += fabs(r);
        }
    } else {
        for (Py_ssize_t p = 0; p < n; p++) {
            double d = d1[p], iv = inv[p];
            s_inv += iv;
            s_d1inv += d * iv;
            s_T += T[p];
            s_ad1 += fabs(d);
        }
        l = -s_d1inv / s_inv;
        for (Py_ssize_t p = 0; p < n; p++) {
            double r = d1[p] + l;
            d1[p] = r;                    /* r from here on */
            s_rinv += r * inv[p];
            rr += fabs(r);
        }
    }
    double e = Ttot - s_T;
    *l_out = l;
    *dlam = -(e + s_rinv) / s_inv;
    double scale = np_max(fabs(l), s_ad1 / npc);
    return (rr <= (NEWTON_TOL_R * scale) * npc) && (fabs(e) <= 1e-12 * Ttot);
}

/* A piece's new duration after kkt_chain's step: T + the step -(r + dlam) inv clipped to
 * [-T/2, T] (np.clip: a NaN step stays NaN) */
static inline double kkt_new_T(double Ti, double r, double dlam, double inv) {
    double dT = -(r + dlam) * inv;
    double lo = -0.5 * Ti, st;
    if (isnan(dT)) st = dT;
    else {
        st = dT > lo ? dT : lo;
        st = st < Ti ? st : Ti;
    }
    return Ti + st;
}

static PyObject *share_time(PyObject *self, PyObject *a) {
    PyObject *o[14];
    int max_newton;
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOOOOOi", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &o[9], &o[10], &o[11], &o[12], &o[13], &max_newton))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t P, nc1, nz, nsc, nT, nlam, nconv, ntot, nnpc, nb2, nvs, nvd, nsq;
    double *L = get(&b, o[0], 8, 0, &P);
    double *beta = L ? get(&b, o[1], 8, 0, &nb2) : NULL;
    double *vs = beta ? get(&b, o[2], 8, 0, &nvs) : NULL;
    double *vd = vs ? get(&b, o[3], 8, 0, &nvd) : NULL;
    double *sqb = vd ? get(&b, o[4], 8, 0, &nsq) : NULL;
    int64_t *poff = sqb ? get(&b, o[5], 8, 0, &nc1) : NULL;
    double *npc = poff ? get(&b, o[6], 8, 0, &nnpc) : NULL;
    double *Ttot = npc ? get(&b, o[7], 8, 0, &ntot) : NULL;
    double *T = Ttot ? get(&b, o[8], 8, 1, &nT) : NULL;
    double *lam = T ? get(&b, o[9], 8, 1, &nlam) : NULL;
    uint8_t *conv = lam ? get(&b, o[10], 1, 1, &nconv) : NULL;
    double *coef = conv ? get(&b, o[11], 8, 0, NULL) : NULL;
    double *zmax = coef ? get(&b, o[12], 8, 0, &nz) : NULL;
    double *sc = zmax ? get(&b, o[13], 8, 0, &nsc) : NULL;
    if (!sc) { release(&b); return NULL; }
    Py_ssize_t n_c = nc1 - 1;
    int ok = n_c >= 0 && nb2 == P && nvs == P && nvd == P && nsq == P && nT == P && nnpc == n_c
             && ntot == n_c && nlam == n_c && nconv == n_c && nsc >= 1 && nsc <= SINH_MAX && poff[0] == 0
             && poff[n_c] == P;
    for (Py_ssize_t c = 0; ok && c < n_c; c++) ok = poff[c + 1] >= poff[c];
    int mono = 1;                                      /* zmax nondecreasing: ex_terms may start mid-way */
    for (Py_ssize_t i = 1; ok && i < nz; i++) mono &= zmax[i] >= zmax[i - 1];
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "share_time: shapes");
        return NULL;
    }
    int nc = (int)nsc;
    Py_ssize_t PP = P ? P : 1;
    double *work = PyMem_Malloc(14 * PP * sizeof(double));
    if (!work) { release(&b); return PyErr_NoMemory(); }
    double *Tall = work, *Jb = work + 3 * PP, *d1b = work + 6 * PP, *invb = work + 7 * PP;
    double *Lc = work + 8 * PP, *bc = work + 9 * PP, *vsc = work + 10 * PP, *vdc = work + 11 * PP;
    double *sqc = work + 12 * PP, *scr = work + 13 * PP;
    int status = 0;
    (void)scr;
    for (int it = 0; it < max_newton; it++) {
        Py_ssize_t m = 0;
        for (Py_ssize_t c = 0; c < n_c; c++)
            if (!conv[c]) m += poff[c + 1] - poff[c];
        if (m == 0) break;
        Py_ssize_t j = 0;
        for (Py_ssize_t c = 0; c < n_c; c++) {          /* the active pieces, compact */
            if (conv[c]) continue;
            for (int64_t p = poff[c]; p < poff[c + 1]; p++, j++) {
                Tall[m + j] = T[p];
                sqc[j] = sqb[p];
                Lc[j] = L[p]; bc[j] = beta[p]; vsc[j] = vs[p]; vdc[j] = vd[p];
            }
        }
        int64_t gb;
        if (args_vec(m, Tall + m, sqc, Tall, Tall + 2 * m, &gb)) { status = -1; break; }
        double gm;
        memcpy(&gm, &gb, 8);
        int k = nms_terms(gm * gm, zmax, nz, 0);     /* the largest γ²: rounding keeps the order */
        for (int q = 0; q < 3; q++) {
            Py_ssize_t o3 = q * m;
            for (Py_ssize_t j0 = 0; j0 < m; j0 += CHUNK) {
                Py_ssize_t n = m - j0 < CHUNK ? m - j0 : CHUNK, x = o3 + j0;
                j_chunk(n, k, Tall + x, sqc + j0, coef, sc, nc, Lc + j0, bc + j0, vsc + j0, vdc + j0, Jb + x);
            }
        }
        slopes(m, Jb, Tall + m, d1b, invb);             /* Tall[m + j]: the duration T itself */
        j = 0;
        for (Py_ssize_t c = 0; c < n_c; c++) {
            if (conv[c]) continue;
            int64_t p0 = poff[c], p1 = poff[c + 1];
            Py_ssize_t j0 = j;
            j += p1 - p0;
            double l, dlam;
            if (kkt_chain(T + p0, d1b + j0, invb + j0, p1 - p0, it == 0, lam[c], Ttot[c], npc[c], &l, &dlam)) {
                conv[c] = 1;
                lam[c] = l;
                continue;
            }
            Py_ssize_t q = j0;
            for (int64_t p = p0; p < p1; p++, q++)
                T[p] = kkt_new_T(T[p], d1b[q], dlam, invb[q]);
            lam[c] = l + nan_to_num(dlam);
        }
    }
    PyMem_Free(work);
    release(&b);
    return PyLong_FromLong(status);
}


/* ---- Horner from a lower term, the same bits (tod_chunk's and shc_quarter's sinh series).
   The series S(x) = c[0] + x (c[1] + x (... + x c[nt-1])) by Horner from its last term,
   s[nt-1] = c[nt-1], s[q] = fl(fl(s[q+1] x) + c[q]), at x = a square (x >= +0, or nan).
   For x >= 0 each step is nondecreasing in s[q+1] (fl(s x) is, for a fixed x >= 0; so is
   fl(p + c); rounding to nearest is monotone), so from bounds lo <= s[Q] <= hi the same
   steps on lo and on hi (with the lane's own x) keep lo[q] <= s[q] <= hi[q] at every q < Q;
   where they meet (lo[q] == hi[q], not nan) that is s[q] itself, and the steps after it,
   the same operations on the same double, give the full Horner's bits.  Bounds of s[Q] for
   every x in [0, xb]: an interval Horner from the last term (s[nt-1] = c[nt-1] exactly),
   at a step fl(s x) over s in [lo, hi], x in [0, xb] lies in [fl(lo (lo >= 0 ? 0 : xb)),
   fl(hi (hi >= 0 ? xb : 0))] (fl(s x) is monotone in s for x >= 0 and in x for each sign
   of s), then + c[q] rounded (monotone).  So the bounds hold whatever the coefficients'
   signs; for positive ones (the sinh series) lo[Q] = c[Q] and hi[Q] = s[Q](xb).
   Exact absorption (fl(s[q+1] x) below half an ulp of c[q], so s[q] = c[q]) needs x below
   ~2^-43 here: the chains' squares (~2^-20 .. 2^-8) are far above, so the bounds' steps.
   A block of lanes whose largest x has biased exponent E (x < 2^(E - 1022)) starts at the
   table's row for E: term Q, bounds [lo, hi]; the lanes run the bounds' steps down to the
   row's term M (where they should meet), then on until every lane's have met, then the
   plain steps; a block not met by term 0 (rare: a lane's value within the bounds' width of
   a rounding boundary) runs the whole Horner again.  A nan or inf lane (E = 2047), or a
   row past HS_EHI, starts at the last term: the full Horner.  (The x are squares: never
   below +0, the bounds' monotonicity holds.) */
#define HS_ELO (1023 - 90)   /* rows: E in [HS_ELO, HS_EHI]; below HS_ELO, HS_ELO's row (its xb is larger) */
#define HS_EHI (1023 + 4)    /* x < 32; above: the full Horner */
#define HS_NE (HS_EHI - HS_ELO + 1)
#define HS_TOL (-60)         /* a row's start: the bounds' width within 2^HS_TOL |c[q]| by a term q >= 1 */
#define HS_MAXT SINH_MAX    /* the callers' check */

typedef struct {
    int nt;                  /* the series' terms (0: not made) */
    double c[HS_MAXT];       /* its coefficients */
    int q[HS_NE];            /* row E - HS_ELO: the term to start at */
    int m[HS_NE];            /* and the term whose step the bounds are expected to meet at (checked from there) */
    double lo[HS_NE], hi[HS_NE];
} HornerSkip;

/* The table of the nt <= HS_MAXT coefficients c.  A row's start Q: the cheapest (a bounds'
   step counted as HS_ISTEP plain ones) where the bounds' width w = hi - lo at x = xb, times
   xb a step, is within 2^tol_exp |c[q]| by a term q >= 1 (the bounds then nearly always meet
   by there: their roundings differ only where a value lies within the width of a rounding
   boundary, a chance of about 2^(tol_exp + 52); one more step shrinks the width by another
   factor x); w = 0 (the tail absorbed): met at Q; else the last term (the full Horner; every
   row's with tol_exp 0).  (Q's choice is speed only: any Q gives the same bits; the tests
   make many blocks take several steps or miss with a coarse tol_exp.) */
#define HS_ISTEP 2
static void hs_make(HornerSkip *hs, const double *c, int nt, int tol_exp) {
    hs->nt = nt;
    memcpy(hs->c, c, nt * sizeof(double));
    double lo[HS_MAXT], hi[HS_MAXT];
    for (int r = 0; r < HS_NE; r++) {
        double xb = ldexp(1.0, HS_ELO + r - 1022);
        lo[nt - 1] = hi[nt - 1] = c[nt - 1];
        for (int q = nt - 2; q >= 0; q--) {
            double pl = lo[q + 1] * (lo[q + 1] >= 0 ? 0.0 : xb), ph = hi[q + 1] * (hi[q + 1] >= 0 ? xb : 0.0);
            lo[q] = pl + c[q];
            hi[q] = ph + c[q];
        }
        int Q = nt - 1, M = nt - 1, cost = nt - 1;
        for (int s = 1; tol_exp && s < nt - 1; s++) {
            if (!(lo[s] <= hi[s])) continue;               /* (a nan or inf coefficient) */
            double w = hi[s] - lo[s];
            int met = w == 0.0 ? s : -1;
            for (int q = s - 1; met < 0 && q >= 1; q--) {
                w = w * xb;
                if (w <= ldexp(fabs(c[q]), tol_exp)) met = q;
            }
            if (met < 0) continue;
            int cs = HS_ISTEP * (s - met) + met;
            if (cs < cost) { cost = cs; Q = s; M = met; }
        }
        hs->q[r] = Q;
        hs->m[r] = M;
        hs->lo[r] = Q == nt - 1 ? c[nt - 1] : lo[Q];
        hs->hi[r] = Q == nt - 1 ? c[nt - 1] : hi[Q];
    }
}

/* The table of the series c (nt terms), made once for coefficients seen before (the module's
   callers pass prims.SINH_COEF every time; the GIL held) */
static HornerSkip hs_sinh;
static const HornerSkip *hs_get(const double *c, int nt) {
    if (nt < 1 || nt > HS_MAXT) return NULL;
    if (!(hs_sinh.nt == nt && memcmp(hs_sinh.c, c, nt * sizeof(double)) == 0)) hs_make(&hs_sinh, c, nt, HS_TOL);
    return &hs_sinh;
}

/* A block's row: the start term Q, the term M whose step starts the checks, bounds L, H from the bits xbits of its largest x
   (sign masked: a nan's bits above every number's).  A macro: the vector clones call it (a
   function built for another target is not inlined into them). */
#define HS_ROW(hs, xbits, Q, M, L, H) do {                                                   \
    int64_t E_ = (xbits) >> 52;                                                                \
    if (E_ > HS_EHI) { (Q) = (M) = (hs)->nt - 1; (L) = (H) = (hs)->c[(hs)->nt - 1]; break; }  \
    int r_ = E_ < HS_ELO ? 0 : (int)(E_ - HS_ELO);                                             \
    (Q) = (hs)->q[r_]; (M) = (hs)->m[r_]; (L) = (hs)->lo[r_]; (H) = (hs)->hi[r_];             \
} while (0)
#define HS_ABS_BITS(x) ((x) & INT64_MAX)        /* a square's bits, a nan's sign dropped */

typedef long long v4l __attribute__((vector_size(32)));       /* a v4d comparison's lanes */
#define V4_ALL(e) (((e)[0] & (e)[1] & (e)[2] & (e)[3]) != 0)      /* every lane's comparison true */

/* out[i] = prims.shc(g[i] / 4) for n <= CHUNK laws (p_shc's operations; its series by blocks
   of 8 lanes from the term hs's row gives, the same bits: see HornerSkip) */
VEC_CLONES static void shc_quarter(Py_ssize_t n, const double *restrict g, const HornerSkip *restrict hs,
                                   double *restrict out) {
    double zb[CHUNK], z2b[CHUNK], hb[CHUNK];
    int64_t mb[CHUNK];
    const double *sc = hs->c;
    int nc = hs->nt;
    double cl = sc[nc - 1];
    for (Py_ssize_t j = 0; j < n; j++) {
        double z = g[j] / 4, x = z * z;
        int64_t xb;
        memcpy(&xb, &x, 8);
        zb[j] = z; z2b[j] = x; mb[j] = HS_ABS_BITS(xb);
    }
    Py_ssize_t n8 = (n + 7) & ~(Py_ssize_t)7;            /* blocks of 8, the tail's padding zeros */
    for (Py_ssize_t j = n; j < n8; j++) { z2b[j] = 0.0; mb[j] = 0; }
    for (Py_ssize_t j0 = 0; j0 < n8; j0 += 8) {
        int64_t bm = mb[j0];
        for (int u = 1; u < 8; u++) bm = mb[j0 + u] > bm ? mb[j0 + u] : bm;
        int Q, M;
        double l, h;
        HS_ROW(hs, bm, Q, M, l, h);
        v4d xl, xh;
        memcpy(&xl, z2b + j0, sizeof xl); memcpy(&xh, z2b + j0 + 4, sizeof xh);
        v4d ul = {l, l, l, l}, uh = ul, Ul = {h, h, h, h}, Uh = Ul;
        int q = Q - 1, met = 1;
        for (; q >= M; q--) {                             /* the bounds' steps to where they should meet */
            double c = sc[q];
            v4d a = {c, c, c, c};
            v4d pl = ul * xl, ph = uh * xh, Pl = Ul * xl, Ph = Uh * xh;
            ul = pl + a; uh = ph + a; Ul = Pl + a; Uh = Ph + a;
        }
        if (l != h) {                                     /* then until they have met */
            v4l e = (ul == Ul) & (uh == Uh);
            met = V4_ALL(e);
            while (!met && q >= 0) {
                double c = sc[q--];
                v4d a = {c, c, c, c};
                v4d pl = ul * xl, ph = uh * xh, Pl = Ul * xl, Ph = Uh * xh;
                ul = pl + a; uh = ph + a; Ul = Pl + a; Uh = Ph + a;
                e = (ul == Ul) & (uh == Uh);
                met = V4_ALL(e);
            }
        }
        if (!met) {                                       /* not met by term 0: the whole series */
            ul = (v4d){cl, cl, cl, cl}; uh = ul;
            q = nc - 2;
        }
        for (; q >= 0; q--) {
            double c = sc[q];
            v4d a = {c, c, c, c};
            v4d pl = ul * xl, ph = uh * xh;
            ul = pl + a; uh = ph + a;
        }
        memcpy(hb + j0, &ul, sizeof ul); memcpy(hb + j0 + 4, &uh, sizeof uh);
    }
    for (Py_ssize_t j = 0; j < n; j++) {
        double z = zb[j];
        double v = (z + P_CUBE(z) * hb[j]) / z;
        out[j] = z == 0.0 ? 1.0 : v;
    }
}

/* One tod_solve step's s and ṡ of n active laws (n <= CHUNK), compact: τ, γ (g), the S1
   series' k terms (coef), the per-law constants s4 = prims.shc(γ/4), n, sh2, wbar, A, δ, T;
   the operations of _eval(t, "sv") element by element (prims.shc at γτ/2, γ(1 - τ)/2 and
   z = γ(τ - 1/2), each sinh series by Horner from its last coefficient; the S1 series of G
   at z²), loops over the terms outside and the elements inside: SIMD lanes, each element's
   operations in its own order, the same bits as one element at a time. */
VEC_CLONES static void tod_chunk(Py_ssize_t n, int k, const double *restrict taub, const double *restrict gb,
                                 const double *restrict coef, const HornerSkip *restrict hs,
                                 const double *restrict s4b, const double *restrict nb, const double *restrict sh2b,
                                 const double *restrict wb, const double *restrict Ab, const double *restrict db,
                                 const double *restrict Tb, double *restrict sout, double *restrict vout) {
    double za[CHUNK], zb_[CHUNK], zx[CHUNK], ha[CHUNK], hb[CHUNK], hx[CHUNK], s1[CHUNK];
    double a2b[CHUNK], b2b[CHUNK], x2b[CHUNK];             /* the squares, made once */
    int64_t mb[CHUNK];                                     /* the bits of each law's largest square */
    const double *sc = hs->c;
    int nc = hs->nt;
    double cl = sc[nc - 1], ck = coef[k - 1];
    for (Py_ssize_t j = 0; j < n; j++) {
        double tau = taub[j], g = gb[j];
        double zaj = (g * tau) / 2, zbj = (g * (1 - tau)) / 2, zxj = g * (tau - 0.5);
        double a2 = zaj * zaj, b2 = zbj * zbj, x2 = zxj * zxj;
        za[j] = zaj; zb_[j] = zbj; zx[j] = zxj;
        a2b[j] = a2; b2b[j] = b2; x2b[j] = x2;
        int64_t ba, bb, bx;
        memcpy(&ba, &a2, 8); memcpy(&bb, &b2, 8); memcpy(&bx, &x2, 8);
        ba = HS_ABS_BITS(ba); bb = HS_ABS_BITS(bb); bx = HS_ABS_BITS(bx);
        ba = bb > ba ? bb : ba;
        mb[j] = bx > ba ? bx : ba;
    }
    Py_ssize_t n8 = (n + 7) & ~(Py_ssize_t)7;            /* blocks of 8, the tail's padding zeros */
    for (Py_ssize_t j = n; j < n8; j++) { a2b[j] = 0.0; b2b[j] = 0.0; x2b[j] = 0.0; mb[j] = 0; }
    /* each block's Horner steps in registers (gcc's vectors, two a series: gcc's own
       vectorising of a block kept a third of it in scalars), the elements' operations in
       their order */
    for (Py_ssize_t j0 = 0; j0 < n8; j0 += 8) {
        v4d a2l, a2h, b2l, b2h, x2l, x2h;
        memcpy(&a2l, a2b + j0, sizeof a2l); memcpy(&a2h, a2b + j0 + 4, sizeof a2h);
        memcpy(&b2l, b2b + j0, sizeof b2l); memcpy(&b2h, b2b + j0 + 4, sizeof b2h);
        memcpy(&x2l, x2b + j0, sizeof x2l); memcpy(&x2h, x2b + j0 + 4, sizeof x2h);
        /* the three sinh series from the term the block's largest square allows (HornerSkip:
           the bounds' steps until every lane's have met, then the plain steps; the whole
           series where they have not met by term 0) */
        int64_t bm = mb[j0];
        for (int u = 1; u < 8; u++) bm = mb[j0 + u] > bm ? mb[j0 + u] : bm;
        int Q, M;
        double l, h;
        HS_ROW(hs, bm, Q, M, l, h);
        v4d ul = {l, l, l, l}, uh = ul, wl = ul, wh = ul, yl = ul, yh = ul;
        v4d Ul = {h, h, h, h}, Uh = Ul, Wl = Ul, Wh = Ul, Yl = Ul, Yh = Ul;
        int q = Q - 1, met = 1;
#define TC_BOUNDS_STEP(c) do {                                                                             \
            v4d a = {(c), (c), (c), (c)};                                                                  \
            v4d pul = ul * a2l, puh = uh * a2h, pwl = wl * b2l, pwh = wh * b2h, pyl = yl * x2l, pyh = yh * x2h; \
            v4d Pul = Ul * a2l, Puh = Uh * a2h, Pwl = Wl * b2l, Pwh = Wh * b2h, Pyl = Yl * x2l, Pyh = Yh * x2h; \
            ul = pul + a; uh = puh + a; wl = pwl + a; wh = pwh + a; yl = pyl + a; yh = pyh + a;             \
            Ul = Pul + a; Uh = Puh + a; Wl = Pwl + a; Wh = Pwh + a; Yl = Pyl + a; Yh = Pyh + a;             \
        } while (0)
#define TC_MET() ({ v4l e = (ul == Ul) & (uh == Uh) & (wl == Wl) & (wh == Wh) & (yl == Yl) & (yh == Yh); V4_ALL(e); })
        for (; q >= M; q--) TC_BOUNDS_STEP(sc[q]);
        if (l != h) {
            met = TC_MET();
            while (!met && q >= 0) {
                TC_BOUNDS_STEP(sc[q]);
                q--;
                met = TC_MET();
            }
        }
#undef TC_BOUNDS_STEP
#undef TC_MET
        if (!met) {
            ul = (v4d){cl, cl, cl, cl}; uh = ul; wl = ul; wh = ul; yl = ul; yh = ul;
            q = nc - 2;
        }
#pragma GCC unroll 2
        for (; q >= 0; q--) {
            double c = sc[q];
            v4d a = {c, c, c, c};
            v4d pul = ul * a2l, puh = uh * a2h, pwl = wl * b2l, pwh = wh * b2h, pyl = yl * x2l, pyh = yh * x2h;
            ul = pul + a; uh = puh + a; wl = pwl + a; wh = pwh + a; yl = pyl + a; yh = pyh + a;
        }
        v4d el = {ck, ck, ck, ck}, eh = el;
#pragma GCC unroll 2
        for (int q = k - 2; q >= 0; q--) {
            double c = coef[q];
            v4d a = {c, c, c, c};
            v4d pel = el * x2l, peh = eh * x2h;
            el = pel + a; eh = peh + a;
        }
        memcpy(ha + j0, &ul, sizeof ul); memcpy(ha + j0 + 4, &uh, sizeof uh);
        memcpy(hb + j0, &wl, sizeof wl); memcpy(hb + j0 + 4, &wh, sizeof wh);
        memcpy(hx + j0, &yl, sizeof yl); memcpy(hx + j0 + 4, &yh, sizeof yh);
        memcpy(s1 + j0, &el, sizeof el); memcpy(s1 + j0 + 4, &eh, sizeof eh);
    }
    for (Py_ssize_t j = 0; j < n; j++) {
        double tau = taub[j], x = tau - 0.5;
        double zaj = za[j], zbj = zb_[j], z = zx[j];
        double pa = (zaj + P_CUBE(zaj) * ha[j]) / zaj, pb = (zbj + P_CUBE(zbj) * hb[j]) / zbj;
        double shx = (z + P_CUBE(z) * hx[j]) / z;
        pa = zaj == 0.0 ? 1.0 : pa;                      /* prims.shc: 1 at z = 0 */
        pb = zbj == 0.0 ? 1.0 : pb;
        shx = z == 0.0 ? 1.0 : shx;
        double bub = ((tau * (1 - tau)) * pa) * pb;
        double gg = bub / (2 * nb[j]);
        double Hs = (-bub) / sh2b[j];
        double h = ((2 * x) * shx) / sh2b[j];
        double s4 = s4b[j];
        double G = 0.5 + (((x * (s4 * s4)) / 8) - P_CUBE(x) * s1[j]) / nb[j];
        sout[j] = ((wb[j] * tau) + (Ab[j] * G)) - (db[j] * Hs);
        vout[j] = ((wb[j] + Ab[j] * gg) - db[j] * h) / Tb[j];
    }
}

/* Law i's inputs of the time-of-distance iteration (tod_prep's and tod_at's), as _tod_core
   makes them: its duration Ti, length Li, the distance x asked for: target = x clipped into
   [min(0, L), max(0, L)], sgn, the bracket [0, T], t = 0 + (T - 0) (target / L, or 0.5 at
   L = 0) and out = t, scale = max(|L|, 1e-300). */
static inline void tod_start(double Ti, double Li, double x, Py_ssize_t i, double *target, double *sgn, double *lo,
                             double *hi, double *t, double *out, double *scale) {
    double los = (0.0 <= Li || isnan(0.0)) ? 0.0 : Li;       /* np.minimum(0.0, L) */
    double his = (0.0 >= Li || isnan(0.0)) ? 0.0 : Li;       /* np.maximum(0.0, L) */
    double mx = isnan(x) ? x : (x > los ? x : los);          /* np.clip */
    double tg = isnan(mx) ? mx : (mx < his ? mx : his);
    target[i] = tg;
    sgn[i] = Li < 0 ? -1.0 : 1.0;
    double l0 = 0.0, h0 = Ti;
    lo[i] = l0;
    hi[i] = h0;
    double r = Li != 0 ? tg / Li : 0.5;
    double ti = l0 + (h0 - l0) * r;
    t[i] = ti;
    out[i] = ti;
    double aL = fabs(Li);
    scale[i] = (aL >= 1e-300 || isnan(aL)) ? aL : 1e-300;
}

/* The laws a time-of-distance iteration reads (tod_iterate): law i's T, γ, n, sh2, wbar, A, δ
   at place ix[i] of these arrays (tod_iterate_at), or at i (tod_iterate_own; ix NULL).
   tod_solve hands it laws gathered by tod_prep (at i); tod_at the step's own laws and the
   free vertices' pieces (ix = pj), so the laws' numbers are read where they are, not
   copied out first. */
typedef struct {
    const double *T, *gs, *n, *sh2, *wbar, *A, *dl;
    const int64_t *ix;
} TodLaws;

/* The elementwise part of a time-of-distance step on m active laws (a chunk, compact): from
   s and ṡ at t (tod_chunk's) and the laws' sgn, target, scale, T, γ: the bracket [lo, hi]
   (updated in place), done, the next t (Newton inside the bracket, else its middle), its
   τ = clip(t / T, 0, 1) and (γ (τ - 1/2))², the S1 terms' measure.  Only the laws going on
   (act[j] >= 0: not done at an earlier step) count: done[j] is 0 for the others; the laws
   going on and not done now take their next t and τ in place (t[j], taus[j]; a done law
   keeps the t it ended on, a law done before its t and τ: not read any more).  Returns the
   bits of the largest (γx)² of the laws going on and not done (its sign dropped: a square
   or nan; -1 if none; above +inf's bits: one is nan), the S1 terms of the next step's batch
   (squares' bits order as their values do: the same largest as the values' max).
   Each element's operations in their order (SIMD lanes: the same bits as one at a time). */
VEC_CLONES static int64_t tod_step(Py_ssize_t m, const double *restrict s, const double *restrict v,
                                   const double *restrict sgn, const double *restrict target,
                                   const double *restrict scale, const double *restrict Tb,
                                   const double *restrict gb, const int64_t *restrict act, double *restrict t,
                                   double *restrict lo, double *restrict hi, int64_t *restrict done,
                                   double *restrict taus) {
    const double eps4 = 4 * DBL_EPSILON;
    int64_t zbits[CHUNK];            /* (the largest taken after the loop: gcc vectorises neither
                                        loop with the reduction and the selections in one) */
    for (Py_ssize_t j = 0; j < m; j++) {
        double ti = t[j];
        double f = sgn[j] * (s[j] - target[j]);
        double loi = (f <= 0) ? ti : lo[j], hii = (f >= 0) ? ti : hi[j];    /* (selections: f's sign is a coin toss) */
        lo[j] = loi;
        hi[j] = hii;
        int64_t going = act[j] >= 0;
        int64_t dn = going & ((fabs(f) <= eps4 * scale[j]) | (hii - loi <= eps4 * Tb[j]));
        done[j] = dn;
        double sv = sgn[j] * v[j];
        double tnew = ti - f / sv;
        int okn = (sv > 0) & (tnew > loi) & (tnew < hii);
        double nt = okn ? tnew : 0.5 * (loi + hii);
        double tau = nt / Tb[j];
        double c = tau > 0.0 ? tau : 0.0;
        c = c < 1.0 ? c : 1.0;
        tau = isnan(tau) ? tau : c;                       /* np.clip: nan stays */
        double z = gb[j] * (tau - 0.5);
        double z2 = z * z;
        int64_t on = going & !dn, b;
        memcpy(&b, &z2, 8);
        zbits[j] = on ? HS_ABS_BITS(b) : -1;
        t[j] = on ? nt : ti;
        double tu = taus[j];
        taus[j] = on ? tau : tu;
    }
    int64_t zb = -1;
    for (Py_ssize_t j = 0; j < m; j++) zb = zbits[j] > zb ? zbits[j] : zb;
    return zb;
}

/* What tod_at_into makes of its laws before the iteration (tod_begin_at, chunk by chunk),
   for tod_iterate to start from instead of its own first lines: blk, the per-law block it
   would allocate (prims.shc(γ/4), τ, the law's T, γ, n, sh2, wbar, A, δ: 9 N doubles, made;
   tod_iterate neither allocates nor frees it), zm and nan (the largest (γx)² and whether one
   is nan, as its first lines take them).  act is 0..N-1 and target .. hi the laws' own. */
typedef struct {
    double *blk;
    double zm;
    int nan;
} TodBegun;

/* tod_at_into's first lines on m <= CHUNK laws: law i (law pj[i] of the arrays T .. dl, asked
   for the distance x[i]) gets tod_start's target, sgn, scale, t, lo, hi (its operations,
   element by element), its law's numbers gathered (Tq .. dq: tod_iterate's gather), τ =
   clip(t / T, 0, 1) (taus) and act[i] = i0 + i.  Returns the bits of the largest (γx)² (sign
   dropped; above +inf's: one is nan; -1 for m = 0), as tod_step does.  The gather first, in
   a loop of its own (gcc makes no vector gathers for x86-64: the loop with them stays
   scalar), then the rest in vector loops on the gathered numbers. */
VEC_CLONES static int64_t tod_begin_at(Py_ssize_t m, Py_ssize_t i0, const int64_t *restrict pj,
                                       const double *restrict T, const double *restrict L,
                                       const double *restrict gs, const double *restrict n,
                                       const double *restrict sh2, const double *restrict wbar,
                                       const double *restrict A, const double *restrict dl,
                                       const double *restrict x, double *restrict target, double *restrict sgn,
                                       double *restrict scale, double *restrict t, double *restrict lo,
                                       double *restrict hi, double *restrict Tq, double *restrict gq,
                                       double *restrict nq, double *restrict shq, double *restrict wq,
                                       double *restrict Aq, double *restrict dq, double *restrict taus,
                                       int64_t *restrict act) {
    double Lq[CHUNK];
    int64_t zbits[CHUNK];            /* (the largest taken after the loop, as in tod_step) */
    for (Py_ssize_t i = 0; i < m; i++) {
        int64_t j = pj[i];
        Tq[i] = T[j]; Lq[i] = L[j]; gq[i] = gs[j]; nq[i] = n[j]; shq[i] = sh2[j]; wq[i] = wbar[j]; Aq[i] = A[j];
        dq[i] = dl[j];
    }
    for (Py_ssize_t i = 0; i < m; i++) {
        double Ti = Tq[i], Li = Lq[i], xi = x[i];
        double los = (0.0 <= Li) ? 0.0 : Li;                     /* np.minimum(0.0, L) */
        double his = (0.0 >= Li) ? 0.0 : Li;                     /* np.maximum(0.0, L) */
        double c0 = xi > los ? xi : los, mx = isnan(xi) ? xi : c0;      /* np.clip: nan stays */
        double c1 = mx < his ? mx : his, tg = isnan(mx) ? mx : c1;
        target[i] = tg;
        sgn[i] = Li < 0 ? -1.0 : 1.0;
        double l0 = 0.0, h0 = Ti;
        lo[i] = l0;
        hi[i] = h0;
        double q = tg / Li;
        double r = Li != 0 ? q : 0.5;
        double ti = l0 + (h0 - l0) * r;
        t[i] = ti;
        double aL = fabs(Li);
        scale[i] = (aL >= 1e-300 || isnan(aL)) ? aL : 1e-300;
        double tau = ti / Ti;
        double c = tau > 0.0 ? tau : 0.0;
        c = c < 1.0 ? c : 1.0;
        tau = isnan(tau) ? tau : c;                               /* np.clip: nan stays */
        taus[i] = tau;
        double z = gq[i] * (tau - 0.5);
        double z2 = z * z;
        int64_t b;
        memcpy(&b, &z2, 8);
        zbits[i] = HS_ABS_BITS(b);
        act[i] = i0 + i;
    }
    int64_t zb = -1;
    for (Py_ssize_t i = 0; i < m; i++) zb = zbits[i] > zb ? zbits[i] : zb;
    return zb;
}

/* _time_of_distance's whole iteration on the N laws lw (tod_solve's; see there): target,
   sgn, scale per law; t, lo, hi, act the scratch, changed (act: 0..N-1 on entry); out = t's
   copy on entry; vout.  Returns the laws still going after max_iter steps (act[:that]), -1
   out of memory (exception set).  Each law's numbers that change or that are its own (t, lo,
   hi, τ, prims.shc(γ/4), sgn, target, scale, and its law's T, γ, n, sh2, wbar, A, δ) are
   kept in act's order and compacted with it, so a step reads them in a row (target, sgn,
   scale, t, lo, hi: the caller's arrays, changed, when act is 0..N-1 on entry, as its
   callers give it; else copies); the law arrays' numbers are gathered once, not at every
   step (the laws going are moved up about once: see below).  Inlined into its two
   callers, indexed a constant there (tod_iterate_at: 1, the laws at lw->ix; tod_iterate_own:
   0, lw->ix not read): no test of ix a law read.
   dst (tod_iterate_into; NULL in the others: a constant there): each law's answers go to
   where its caller keeps them instead of out and vout: ṡ to vdst[dst[i]], and its t added to
   tdst[dst[i]] (tdst[dst[i]] + t: the caller's `tdst[dst] += out` of a dst without repeats);
   the laws still going are not written there, their last t put in out[0..going) in act's
   order (out may be target: not read any more then). */
static inline __attribute__((always_inline)) Py_ssize_t
tod_iterate(const TodLaws *lw, const int indexed, Py_ssize_t N, double *target, double *sgn, double *scale,
            double *t, double *lo, double *hi, int64_t *act, double *out, double *vout,
            const double *coef, const double *zmax, Py_ssize_t nz, const double *sc, int nc, int max_iter,
            const int64_t *dst, double *vdst, double *tdst, const TodBegun *begun) {
    const double *T = lw->T, *gs = lw->gs, *n = lw->n, *sh2 = lw->sh2, *wbar = lw->wbar, *A = lw->A, *dl = lw->dl;
    const int64_t *ix = lw->ix;
    const HornerSkip *hs = hs_get(sc, nc);       /* the sinh series' start terms (nc <= SINH_MAX: the callers') */
    Py_ssize_t NN = N ? N : 1;
    int ident = 1;
    if (!begun)
        for (Py_ssize_t j = 0; j < N; j++) ident &= act[j] == j;
    /* per active law: prims.shc(γ/4), τ, its law's T, γ, n, sh2, wbar, A, δ; the copies of
       target .. hi in act's order where act is not 0..N-1 */
    double *s4 = begun ? begun->blk : PyMem_Malloc((ident ? 9 : 15) * NN * sizeof(double));
    if (!s4) { PyErr_NoMemory(); return -1; }
    double *taus = s4 + NN;
    double *Tq = s4 + 2 * NN, *gq = s4 + 3 * NN, *nq = s4 + 4 * NN, *shq = s4 + 5 * NN, *wq = s4 + 6 * NN,
           *Aq = s4 + 7 * NN, *dq = s4 + 8 * NN;
    double zm = -1.0;
    int nan = 0;
    if (begun) {
        zm = begun->zm;
        nan = begun->nan;
        goto steps;
    }
    if (!ident) {
        double *cp = s4 + 9 * NN, *src[6] = {target, sgn, scale, t, lo, hi};
        for (int u = 0; u < 6; u++)
            for (Py_ssize_t j = 0; j < N; j++) cp[u * NN + j] = src[u][act[j]];
        target = cp; sgn = cp + NN; scale = cp + 2 * NN; t = cp + 3 * NN; lo = cp + 4 * NN; hi = cp + 5 * NN;
    }
    /* a chunk of the active laws: s, ṡ (tod_chunk); done, the next t and τ (tod_step) */
    double sb[CHUNK], vv[CHUNK];
    int64_t dn[CHUNK];
    for (Py_ssize_t j = 0; j < N; j++) {
        int64_t q = indexed ? ix[act[j]] : act[j];
        Tq[j] = T[q]; gq[j] = gs[q]; nq[j] = n[q]; shq[j] = sh2[q]; wq[j] = wbar[q]; Aq[j] = A[q]; dq[j] = dl[q];
    }
    for (Py_ssize_t j0 = 0; j0 < N; j0 += CHUNK) {
        Py_ssize_t m = N - j0 < CHUNK ? N - j0 : CHUNK;
        shc_quarter(m, gq + j0, hs, s4 + j0);
    }
    /* τ = clip(t / T, 0, 1) of the active laws (taus[j]: act[j]'s), made where t is: once
       here, then by the step that moves t (each law's τ once a step, not once for the
       batch's S1 terms and again for its chunk); zm, nan: the largest (γx)² of the active
       laws (nan: one is nan), the S1 terms the next step's batch needs */
    for (Py_ssize_t j = 0; j < N; j++) {
        double tau = t[j] / Tq[j];
        if (!isnan(tau)) {                /* np.clip: nan stays */
            tau = tau > 0.0 ? tau : 0.0;
            tau = tau < 1.0 ? tau : 1.0;
        }
        taus[j] = tau;
        double z = gq[j] * (tau - 0.5);
        double z2 = z * z;
        if (isnan(z2)) nan = 1;
        else if (z2 > zm) zm = z2;
    }
    /* the laws done stay in place, marked (act[j] = -1 - i: evaluated with the rest, their
       answers not read), until they are more than an eighth of the entries na: then the
       laws going are moved up in order before a step (most laws take 4 or 5 steps: the
       laws going are moved about once, not at every step) */
steps:;
    Py_ssize_t na = N, ndone = 0;
    for (int it = 0; it < max_iter && na > ndone; it++) {
        if (ndone > na / 8) {
            Py_ssize_t keep = 0;
            for (Py_ssize_t j = 0; j < na; j++) {
                if (act[j] < 0) continue;
                t[keep] = t[j]; lo[keep] = lo[j]; hi[keep] = hi[j]; taus[keep] = taus[j];
                s4[keep] = s4[j]; sgn[keep] = sgn[j]; target[keep] = target[j]; scale[keep] = scale[j];
                Tq[keep] = Tq[j]; gq[keep] = gq[j]; nq[keep] = nq[j]; shq[keep] = shq[j]; wq[keep] = wq[j];
                Aq[keep] = Aq[j]; dq[keep] = dq[j];
                act[keep++] = act[j];
            }
            na = keep;
            ndone = 0;
        }
        /* γx of the active laws: the S1 terms their batch needs */
        int k = nms_terms(zm, zmax, nz, nan);
        zm = -1.0;
        nan = 0;
        /* chunk by chunk: s and ṡ (tod_chunk), the bracket, done, the next t and its τ
           (tod_step); the laws done now give their answers and are marked */
        for (Py_ssize_t j0 = 0; j0 < na; j0 += CHUNK) {
            Py_ssize_t m = na - j0 < CHUNK ? na - j0 : CHUNK;
            tod_chunk(m, k, taus + j0, gq + j0, coef, hs, s4 + j0, nq + j0, shq + j0, wq + j0, Aq + j0, dq + j0,
                      Tq + j0, sb, vv);
            int64_t zb = tod_step(m, sb, vv, sgn + j0, target + j0, scale + j0, Tq + j0, gq + j0, act + j0, t + j0,
                                  lo + j0, hi + j0, dn, taus + j0);
            if (zb > INF_BITS) nan = 1;         /* the largest (γx)² of the laws going on */
            else if (zb >= 0) {
                double z2;
                memcpy(&z2, &zb, 8);
                if (z2 > zm) zm = z2;
            }
            for (Py_ssize_t jj = 0; jj < m; jj++) {
                if (!dn[jj]) continue;
                Py_ssize_t j = j0 + jj;
                int64_t i = act[j];    /* t stays */
                if (dst) {
                    int64_t d = dst[i];
                    vdst[d] = vv[jj];
                    tdst[d] = tdst[d] + t[j];
                } else {
                    out[i] = t[j];
                    vout[i] = vv[jj];
                }
                act[j] = -1 - i;
                ndone++;
            }
        }
    }
    Py_ssize_t going = 0;          /* the laws still going, in order, and their last t */
    for (Py_ssize_t j = 0; j < na; j++) {
        if (act[j] < 0) continue;
        if (dst) out[going] = t[j];
        else out[act[j]] = t[j];
        act[going++] = act[j];
    }
    if (!begun) PyMem_Free(s4);
    return going;
}

#define TOD_ITERATE_ARGS const TodLaws *lw, Py_ssize_t N, double *target, double *sgn, double *scale, \
    double *t, double *lo, double *hi, int64_t *act, double *out, double *vout, \
    const double *coef, const double *zmax, Py_ssize_t nz, const double *sc, int nc, int max_iter
static Py_ssize_t tod_iterate_at(TOD_ITERATE_ARGS) {
    return tod_iterate(lw, 1, N, target, sgn, scale, t, lo, hi, act, out, vout, coef, zmax, nz, sc, nc,
                       max_iter, NULL, NULL, NULL, NULL);
}
static Py_ssize_t tod_iterate_own(TOD_ITERATE_ARGS) {
    return tod_iterate(lw, 0, N, target, sgn, scale, t, lo, hi, act, out, vout, coef, zmax, nz, sc, nc,
                       max_iter, NULL, NULL, NULL, NULL);
}
static Py_ssize_t tod_iterate_into(TOD_ITERATE_ARGS, const int64_t *dst, double *vdst, double *tdst,
                                   const TodBegun *begun) {
    return tod_iterate(lw, 1, N, target, sgn, scale, t, lo, hi, act, out, vout, coef, zmax, nz, sc, nc,
                       max_iter, dst, vdst, tdst, begun);
}

/* tod_solve(t, T, gs, n, sh2, wbar, A, delta, target, sgn, lo, hi, scale, act, out, vout,
   s1coef, s1zmax, sinh_coef, max_iter) -> laws still going after max_iter steps (act[:that]:
   which; their vout not written), 0 when every law is done.  _time_of_distance's whole
   iteration (_tod_rows: each step on the laws not done): s and ṡ at t as _eval(t, "sv")
   (series branch, prims.shc and prims.cube; the S1 series of G with the terms its step's
   batch needs: _s1's _nms_terms over the largest (γx)²), the bracket [lo, hi], done, Newton
   or bisection; out[i] = each law's last t; vout[i] = ṡ at the t a law ended on (_eval(t,
   "v") there).  target, sgn, scale, t, lo, hi, act: the caller's scratch, changed; out: a
   copy of t on entry.  prims.shc(γ/4), the same at every step, is made once per law; each
   step gathers its active laws' numbers compact chunk by chunk (CHUNK laws in L1) and
   makes their s and ṡ there (tod_chunk), then each law's bracket and next t (tod_step),
   and keeps the laws going (tod_iterate). */
static PyObject *tod_solve(PyObject *self, PyObject *a) {
    PyObject *o[19];
    int max_iter;
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOOOOOOOOOOi", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &o[9], &o[10], &o[11], &o[12], &o[13], &o[14], &o[15], &o[16], &o[17], &o[18],
                          &max_iter))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t N, nz, nsc, ncoef, nn[15];
    double *t = get(&b, o[0], 8, 1, &N);
    double *T = t ? get(&b, o[1], 8, 0, &nn[0]) : NULL;
    double *gs = T ? get(&b, o[2], 8, 0, &nn[1]) : NULL;
    double *n = gs ? get(&b, o[3], 8, 0, &nn[2]) : NULL;
    double *sh2 = n ? get(&b, o[4], 8, 0, &nn[3]) : NULL;
    double *wbar = sh2 ? get(&b, o[5], 8, 0, &nn[4]) : NULL;
    double *A = wbar ? get(&b, o[6], 8, 0, &nn[5]) : NULL;
    double *dl = A ? get(&b, o[7], 8, 0, &nn[6]) : NULL;
    double *target = dl ? get(&b, o[8], 8, 1, &nn[7]) : NULL;
    double *sgn = target ? get(&b, o[9], 8, 1, &nn[8]) : NULL;
    double *lo = sgn ? get(&b, o[10], 8, 1, &nn[9]) : NULL;
    double *hi = lo ? get(&b, o[11], 8, 1, &nn[10]) : NULL;
    double *scale = hi ? get(&b, o[12], 8, 1, &nn[11]) : NULL;
    int64_t *act = scale ? get(&b, o[13], 8, 1, &nn[12]) : NULL;
    double *out = act ? get(&b, o[14], 8, 1, &nn[13]) : NULL;
    double *vout = out ? get(&b, o[15], 8, 1, &nn[14]) : NULL;
    double *coef = vout ? get(&b, o[16], 8, 0, &ncoef) : NULL;
    double *zmax = coef ? get(&b, o[17], 8, 0, &nz) : NULL;
    double *sc = zmax ? get(&b, o[18], 8, 0, &nsc) : NULL;
    if (!sc) { release(&b); return NULL; }
    int ok = nsc >= 1 && nsc <= SINH_MAX && ncoef >= NTERMS;
    for (int q = 0; q < 15; q++) ok = ok && nn[q] == N;
    for (Py_ssize_t j = 0; ok && j < N; j++) ok = act[j] >= 0 && act[j] < N;
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "tod_solve: shapes");
        return NULL;
    }
    TodLaws lw = {T, gs, n, sh2, wbar, A, dl, NULL};
    Py_ssize_t na = tod_iterate_own(&lw, N, target, sgn, scale, t, lo, hi, act, out, vout, coef, zmax, nz, sc,
                                    (int)nsc, max_iter);
    release(&b);
    return na < 0 ? NULL : PyLong_FromSsize_t(na);
}

/* tod_at(T, L, gs, n, sh2, wbar, A, delta, pj, s, out, vout, act, s1coef, s1zmax, sinh_coef,
   max_iter) -> laws still going after max_iter steps (act[:that]), 0 when every law is done.
   tod_prep then tod_solve in one call, without the laws gathered first: law i is the step's
   law pj[i] (its P pieces' arrays T .. delta), asked for the distance s[i]; its inputs as
   tod_prep makes them (tod_start) and the iteration as tod_solve runs it on them
   (tod_iterate, reading each law's numbers at pj[i]): the same operations on the same numbers.
   Writes out (each law's last t), vout (ṡ there; not for the laws still going) and act. */
static PyObject *tod_at(PyObject *self, PyObject *a) {
    PyObject *o[16];
    int max_iter;
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOOOOOOOi", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &o[9], &o[10], &o[11], &o[12], &o[13], &o[14], &o[15], &max_iter))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t nn[16];
    void *p[16];
    for (int q = 0; q < 16; q++) {
        p[q] = get(&b, o[q], 8, q >= 10 && q <= 12, &nn[q]);
        if (!p[q]) { release(&b); return NULL; }
    }
    Py_ssize_t P = nn[0], N = nn[8], nz = nn[14], nsc = nn[15];
    int ok = nsc >= 1 && nsc <= SINH_MAX && nn[13] >= NTERMS;
    for (int q = 1; q < 8; q++) ok = ok && nn[q] == P;
    for (int q = 9; q < 13; q++) ok = ok && nn[q] == N;
    const int64_t *pj = p[8];
    ok = ok && all_in_range(N, pj, P);
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "tod_at: shapes");
        return NULL;
    }
    const double *T = p[0], *L = p[1], *s = p[9];
    double *out = p[10], *vout = p[11];
    int64_t *act = p[12];
    Py_ssize_t NN = N ? N : 1;
    /* per law: target, sgn, scale, t, lo, hi */
    double *work = PyMem_Malloc(6 * NN * sizeof(double));
    if (!work) { release(&b); return PyErr_NoMemory(); }
    double *target = work, *sgn = work + NN, *scale = work + 2 * NN, *t = work + 3 * NN, *lo = work + 4 * NN,
           *hi = work + 5 * NN;
    for (Py_ssize_t i = 0; i < N; i++) {          /* tod_prep's inputs of law i */
        int64_t j = pj[i];
        double Ti = T[j], Li = L[j];
        tod_start(Ti, Li, s[i], i, target, sgn, lo, hi, t, out, scale);
        act[i] = (int64_t)i;
    }
    TodLaws lw = {T, p[2], p[3], p[4], p[5], p[6], p[7], pj};
    Py_ssize_t na = tod_iterate_at(&lw, N, target, sgn, scale, t, lo, hi, act, out, vout, p[13], p[14], nz, p[15],
                                   (int)nsc, max_iter);
    PyMem_Free(work);
    release(&b);
    return na < 0 ? NULL : PyLong_FromSsize_t(na);
}

/* tod_at_into(T, L, gs, n, sh2, wbar, A, delta, pj, s, free, v, t, act, s1coef, s1zmax, sinh_coef,
   max_iter) -> () when every law is done, else the last t of the laws still going after
   max_iter steps (a tuple of floats; act[:that many] which).  tod_at with its answers put
   where solve_fixed keeps them (_Flat._at_times: `tl, v[free] = tod_at's out, vout;
   t[free] += tl`): law i's ṡ to v[free[i]], its t added to t[free[i]] (free without
   repeats: vert_prep's free vertices), as each law ends -- the same operations, without
   the out and vout arrays and numpy's scatters of them.  The laws still going are not
   written to v and t. */
static PyObject *tod_at_into(PyObject *self, PyObject *a) {
    PyObject *o[17];
    int max_iter;
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOOOOOOOOi", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &o[9], &o[10], &o[11], &o[12], &o[13], &o[14], &o[15], &o[16], &max_iter))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t nn[17];
    void *p[17];
    for (int q = 0; q < 17; q++) {
        p[q] = get(&b, o[q], 8, q >= 11 && q <= 13, &nn[q]);
        if (!p[q]) { release(&b); return NULL; }
    }
    Py_ssize_t P = nn[0], N = nn[8], nv = nn[11], nz = nn[15], nsc = nn[16];
    int ok = nsc >= 1 && nsc <= SINH_MAX && nn[14] >= NTERMS && nn[9] == N && nn[10] == N && nn[12] == nv
             && nn[13] == N;
    for (int q = 1; q < 8; q++) ok = ok && nn[q] == P;
    const int64_t *pj = p[8], *dst = p[10];
    ok = ok && all_in_range(N, pj, P) && all_in_range(N, dst, nv);
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "tod_at_into: shapes");
        return NULL;
    }
    const double *T = p[0], *L = p[1], *s = p[9];
    int64_t *act = p[13];
    Py_ssize_t NN = N ? N : 1;
    /* per law: target, sgn, scale, t, lo, hi (tod_at's), then tod_iterate's block */
    double *work = PyMem_Malloc(15 * NN * sizeof(double));
    if (!work) { release(&b); return PyErr_NoMemory(); }
    double *target = work, *sgn = work + NN, *scale = work + 2 * NN, *t = work + 3 * NN, *lo = work + 4 * NN,
           *hi = work + 5 * NN;
    /* tod_prep's inputs of each law (its out: t again), its law's numbers, τ, prims.shc(γ/4):
       tod_iterate's first lines, chunk by chunk in one pass */
    TodBegun bg = {work + 6 * NN, -1.0, 0};
    double *s4 = bg.blk, *taus = s4 + NN, *Tq = s4 + 2 * NN;
    const HornerSkip *hs = hs_get(p[16], (int)nsc);
    int64_t zb = -1;
    for (Py_ssize_t j0 = 0; j0 < N; j0 += CHUNK) {
        Py_ssize_t m = N - j0 < CHUNK ? N - j0 : CHUNK;
        int64_t z = tod_begin_at(m, j0, pj + j0, T, L, p[2], p[3], p[4], p[5], p[6], p[7], s + j0, target + j0,
                                 sgn + j0, scale + j0, t + j0, lo + j0, hi + j0, Tq + j0, Tq + NN + j0,
                                 Tq + 2 * NN + j0, Tq + 3 * NN + j0, Tq + 4 * NN + j0, Tq + 5 * NN + j0,
                                 Tq + 6 * NN + j0, taus + j0, act + j0);
        zb = z > zb ? z : zb;
        shc_quarter(m, Tq + NN + j0, hs, s4 + j0);
    }
    if (zb > INF_BITS) bg.nan = 1;
    else if (zb >= 0) memcpy(&bg.zm, &zb, 8);
    TodLaws lw = {T, p[2], p[3], p[4], p[5], p[6], p[7], pj};
    Py_ssize_t na = tod_iterate_into(&lw, N, target, sgn, scale, t, lo, hi, act, target, NULL, p[14], p[15], nz,
                                     p[16], (int)nsc, max_iter, dst, p[11], p[12], &bg);
    PyObject *res = NULL;
    if (na >= 0) {                 /* the last t of the laws still going (target[:na]) */
        res = PyTuple_New(na);
        for (Py_ssize_t g = 0; res && g < na; g++) {
            PyObject *x = PyFloat_FromDouble(target[g]);
            if (!x) Py_CLEAR(res);
            else PyTuple_SET_ITEM(res, g, x);
        }
    }
    PyMem_Free(work);
    release(&b);
    return res;
}

/* fixed_knots(sv, cv, vt, vi, bv, bvoff, S, T, v0, v1, warm, ks, kv, kt0, koff, L, va, vb, T0, owner,
   kj): _Flat.solve_fixed's knots and pieces (its numpy code, _knots_numpy), in one pass.
   The na active chains' vertices vi (chain r's at bvoff[r]:bvoff[r + 1]), bv (uint8) their
   binding marks; S, T, v0, v1, warm (uint8) the active chains'.  Writes each chain's knots
   [0, binding vertices, S] (ks; speeds kv [v0, caps, v1]; warm-start times kt0 [0, vt, T]) at
   koff[r]:koff[r + 1], its pieces at koff[r] - r: L (the knots' difference), va, vb, owner = r,
   T0 = (T L) / S, or the differences of kt0 where warm[r] and every one of them is
   > 1e-6 T (a nan is not); kj: the knot of each vertex's piece start (koff[r] + the binding
   vertices of its chain up to it: solve_fixed's monotone count).  The sizes (knots:
   2 na + the binding vertices) are checked. */
static PyObject *fixed_knots(PyObject *self, PyObject *a) {
    PyObject *o[21];
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOOOOOOOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &o[9], &o[10], &o[11], &o[12], &o[13], &o[14], &o[15], &o[16], &o[17], &o[18],
                          &o[19], &o[20]))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t nsv, ncv, nvt, n, nbv, nb1, nS, nT, n0, n1, nw, K, nkv, nkt, nko, P, nva, nvb, nT0, now, nkj;
    double *sv = get(&b, o[0], 8, 0, &nsv);
    double *cv = sv ? get(&b, o[1], 8, 0, &ncv) : NULL;
    double *vt = cv ? get(&b, o[2], 8, 0, &nvt) : NULL;
    int64_t *vi = vt ? get(&b, o[3], 8, 0, &n) : NULL;
    uint8_t *bv = vi ? get(&b, o[4], 1, 0, &nbv) : NULL;
    int64_t *bvoff = bv ? get(&b, o[5], 8, 0, &nb1) : NULL;
    double *S = bvoff ? get(&b, o[6], 8, 0, &nS) : NULL;
    double *T = S ? get(&b, o[7], 8, 0, &nT) : NULL;
    double *v0 = T ? get(&b, o[8], 8, 0, &n0) : NULL;
    double *v1 = v0 ? get(&b, o[9], 8, 0, &n1) : NULL;
    uint8_t *warm = v1 ? get(&b, o[10], 1, 0, &nw) : NULL;
    double *ks = warm ? get(&b, o[11], 8, 1, &K) : NULL;
    double *kv = ks ? get(&b, o[12], 8, 1, &nkv) : NULL;
    double *kt0 = kv ? get(&b, o[13], 8, 1, &nkt) : NULL;
    int64_t *koff = kt0 ? get(&b, o[14], 8, 1, &nko) : NULL;
    double *L = koff ? get(&b, o[15], 8, 1, &P) : NULL;
    double *va = L ? get(&b, o[16], 8, 1, &nva) : NULL;
    double *vb = va ? get(&b, o[17], 8, 1, &nvb) : NULL;
    double *T0 = vb ? get(&b, o[18], 8, 1, &nT0) : NULL;
    int64_t *owner = T0 ? get(&b, o[19], 8, 1, &now) : NULL;
    int64_t *kj = owner ? get(&b, o[20], 8, 1, &nkj) : NULL;
    if (!kj) { release(&b); return NULL; }
    Py_ssize_t na = nb1 - 1;
    int ok = na >= 0 && ncv == nsv && nvt == nsv && nbv == n && nS == na && nT == na && n0 == na && n1 == na
             && nw == na && nkv == K && nkt == K && nko == na + 1 && nva == P && nvb == P && nT0 == P && now == P
             && nkj == n && bvoff[0] == 0 && bvoff[na] == n;
    for (Py_ssize_t r = 0; ok && r < na; r++) ok = bvoff[r + 1] >= bvoff[r];
    Py_ssize_t nbind = 0;
    ok = ok && all_in_range(n, vi, nsv);
    if (ok) nbind = count_nonzero_u8(n, bv);
    if (!(ok && K == 2 * na + nbind && P == K - na)) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "fixed_knots: shapes");
        return NULL;
    }
    Py_ssize_t k = 0;
    koff[0] = 0;
    for (Py_ssize_t r = 0; r < na; r++) {
        Py_ssize_t k0 = k;
        ks[k] = 0.0; kv[k] = v0[r]; kt0[k] = 0.0; k++;
        for (int64_t u = bvoff[r]; u < bvoff[r + 1]; u++) {
            if (bv[u]) {
                int64_t i = vi[u];
                ks[k] = sv[i]; kv[k] = cv[i]; kt0[k] = vt[i]; k++;
            }
            kj[u] = k - 1;              /* the last knot at or before the vertex */
        }
        ks[k] = S[r]; kv[k] = v1[r]; kt0[k] = T[r]; k++;
        koff[r + 1] = k;
        double Tr = T[r], Sr = S[r], lim = 1e-6 * Tr;
        int good = warm[r] != 0;
        for (Py_ssize_t q = k0; q + 1 < k; q++) {
            Py_ssize_t p = q - r;
            double l = ks[q + 1] - ks[q];
            L[p] = l; va[p] = kv[q]; vb[p] = kv[q + 1]; owner[p] = r;
            T0[p] = (Tr * l) / Sr;
            if (good) good = (kt0[q + 1] - kt0[q]) > lim;
        }
        if (good)
            for (Py_ssize_t q = k0; q + 1 < k; q++) T0[q - r] = kt0[q + 1] - kt0[q];
    }
    release(&b);
    Py_RETURN_NONE;
}

/* tent_rows(need, vf, step, out) -> True, or False (nothing meaningful written) where a
   value is not finite and > 0.  segments.tent_feeds_rows' envelope of every row of need
   (R, n): out[r, k] = max over j = -1..n of pad[r, j] - step[r] * |k - j|, pad = need[r]
   with vf[r] + step[r] at both ends (j = -1, n).  Each difference is numpy's (one product
   of the step and the integer distance, one subtraction); with every input finite and
   > 0 no difference is a nan or a -0, so their maximum is one value whatever the order
   numpy's reduction takes them in: the same bits.  The differences that cannot reach
   the maximum (bounded through the row's largest need) are not made: see the loop. */
static PyObject *tent_rows(PyObject *self, PyObject *a) {
    PyObject *oneed, *ovf, *ostep, *oout;
    if (!PyArg_ParseTuple(a, "OOOO", &oneed, &ovf, &ostep, &oout)) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t N, R, Rs, No;
    double *need = get(&b, oneed, 8, 0, &N);
    double *vf = need ? get(&b, ovf, 8, 0, &R) : NULL;
    double *step = vf ? get(&b, ostep, 8, 0, &Rs) : NULL;
    double *out = step ? get(&b, oout, 8, 1, &No) : NULL;
    if (!out) { release(&b); return NULL; }
    if (Rs != R || No != N || R <= 0 || N % R) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "tent_rows: shapes");
        return NULL;
    }
    Py_ssize_t n = N / R;
    int ok = 1;
    for (Py_ssize_t r = 0; r < R && ok; r++) {
        double side = vf[r] + step[r];
        ok = isfinite(vf[r]) && vf[r] > 0 && isfinite(step[r]) && step[r] > 0 && isfinite(side);
    }
    for (Py_ssize_t i = 0; i < N && ok; i++) ok = isfinite(need[i]) && need[i] > 0;
    if (ok) {
        for (Py_ssize_t r = 0; r < R; r++) {
            const double *p = need + r * n;
            double st = step[r], side = vf[r] + st, pmax = p[0];
            for (Py_ssize_t j = 1; j < n; j++) pmax = p[j] > pmax ? p[j] : pmax;
            for (Py_ssize_t k = 0; k < n; k++) {
                double m = side - st * (double)(k + 1);          /* j = -1 */
                double e = side - st * (double)(n - k);          /* j = n */
                if (e > m) m = e;
                /* the j at distance d = |k - j| = 0, 1, ... from k, until pmax - st d < m:
                   then every difference at d or farther is below m (st d grows with d, each
                   rounding is monotone, p[j] <= pmax), so it cannot be the maximum */
                for (Py_ssize_t d = 0; d < n; d++) {
                    double sd = st * (double)d;
                    if (pmax - sd < m) break;
                    if (k - d >= 0) {
                        double c = p[k - d] - sd;
                        if (c > m) m = c;
                    }
                    if (d > 0 && k + d < n) {
                        double c = p[k + d] - sd;
                        if (c > m) m = c;
                    }
                }
                out[r * n + k] = m;
            }
        }
    }
    release(&b);
    return PyBool_FromLong(ok);
}

/* piece_cumsum(x, off, out): out[p] = x[off[c]] + ... + x[p] for the pieces p of each
   chain c (off[c]:off[c + 1]), summed from the chain's first piece in order: what
   np.cumsum along the rows of solve_fixed's (chains, pieces) grid gives (accumulate:
   out[0] = x[0], out[i] = out[i - 1] + x[i]; the zeros after a chain's pieces come
   later and are not read). */
static PyObject *piece_cumsum(PyObject *self, PyObject *a) {
    PyObject *ox, *ooff, *oout;
    if (!PyArg_ParseTuple(a, "OOO", &ox, &ooff, &oout)) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t P, nc1, Po;
    double *x = get(&b, ox, 8, 0, &P);
    int64_t *off = x ? get(&b, ooff, 8, 0, &nc1) : NULL;
    double *out = off ? get(&b, oout, 8, 1, &Po) : NULL;
    if (!out) { release(&b); return NULL; }
    if (Po != P || nc1 < 1 || off[0] != 0 || off[nc1 - 1] != P) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "piece_cumsum: offsets");
        return NULL;
    }
    for (Py_ssize_t c = 0; c + 1 < nc1; c++) {
        int64_t p0 = off[c], p1 = off[c + 1];
        if (p1 < p0 || p1 > P) {
            release(&b);
            PyErr_SetString(PyExc_ValueError, "piece_cumsum: offsets");
            return NULL;
        }
        if (p1 == p0) continue;
        double s = x[p0];
        out[p0] = s;
        for (int64_t p = p0 + 1; p < p1; p++) {
            s = s + x[p];
            out[p] = s;
        }
    }
    release(&b);
    Py_RETURN_NONE;
}

/* knots_flat(nA, V0, V1, TL, VV, TT, BB, vmap, voff, jA, rcA, VK, DT, IDX, BND): chains._knots_flat's
   rows (chain jA[i], column rcA[i], nA[i] >= 1 segments), nA[i] + 1 cells a row end to end: VK the
   knot speeds (V0[i], VV[f] at each inner vertex's flat place f, V1[i]), DT the steps of the knot
   times (0, TT[f]..., TL[i]: each the same subtraction numpy's difference makes; the row's last
   cell 0, not a step), IDX the flat places f = rcA[i] * W + (vmap ? vmap[v] : v) at the inner
   cells (v = voff[jA[i]] + p - 1; the end cells 0), BND (None: not made) the binding stack BB
   (uint8) at them (the ends 0).  VV, TT, BB: (k, W) C-contiguous, W = len(VV) / k given by the
   places' bound; ValueError on a row whose places fall outside them (nothing is then trusted). */
static PyObject *knots_flat(PyObject *self, PyObject *a) {
    PyObject *o[15];
    Py_ssize_t W;
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOOOOOOn", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8],
                          &o[9], &o[10], &o[11], &o[12], &o[13], &o[14], &W))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t R, r1, r2, r3, NV, NT, NB = 0, NM = 0, NO, rj, rc, C, c1, c2, c3 = 0;
    int64_t *nA = get(&b, o[0], 8, 0, &R);
    double *V0 = nA ? get(&b, o[1], 8, 0, &r1) : NULL;
    double *V1 = V0 ? get(&b, o[2], 8, 0, &r2) : NULL;
    double *TL = V1 ? get(&b, o[3], 8, 0, &r3) : NULL;
    double *VV = TL ? get(&b, o[4], 8, 0, &NV) : NULL;
    double *TT = VV ? get(&b, o[5], 8, 0, &NT) : NULL;
    uint8_t *BB = NULL;
    if (TT && o[6] != Py_None && !(BB = get(&b, o[6], 1, 0, &NB))) TT = NULL;
    int64_t *vmap = NULL;
    if (TT && o[7] != Py_None && !(vmap = get(&b, o[7], 8, 0, &NM))) TT = NULL;
    int64_t *voff = TT ? get(&b, o[8], 8, 0, &NO) : NULL;
    int64_t *jA = voff ? get(&b, o[9], 8, 0, &rj) : NULL;
    int64_t *rcA = jA ? get(&b, o[10], 8, 0, &rc) : NULL;
    double *VK = rcA ? get(&b, o[11], 8, 1, &C) : NULL;
    double *DT = VK ? get(&b, o[12], 8, 1, &c1) : NULL;
    int64_t *IDX = DT ? get(&b, o[13], 8, 1, &c2) : NULL;
    uint8_t *BND = NULL;
    if (IDX && BB && !(BND = get(&b, o[14], 1, 1, &c3))) IDX = NULL;
    if (!IDX) { release(&b); return NULL; }
    int bad = r1 != R || r2 != R || r3 != R || rj != R || rc != R || NT != NV || (BB && NB != NV) || W < 1
              || c1 != C || c2 != C || (BB && c3 != C) || NO < 1;
    for (Py_ssize_t v = 0; v < NM && !bad; v++)         /* (the map's places checked once, not a cell) */
        bad = vmap[v] < 0 || vmap[v] >= W;
    int64_t at = 0;
    for (Py_ssize_t i = 0; i < R && !bad; i++) {
        int64_t n = nA[i], j = jA[i], base = rcA[i] * (int64_t)W;
        if (n < 1 || at + n + 1 > C || j < 0 || j + 1 >= NO || rcA[i] < 0 || voff[j] < 0
                || voff[j + 1] - voff[j] != n - 1
                || (vmap ? voff[j + 1] > NM || base + W > NV : base + voff[j + 1] > NV)) {
            bad = 1;
            break;
        }
        /* the row's inner cells at + 1 .. at + n - 1: vertex voff[j] + p - 1 of cell at + p */
        double prev = 0.0;
        int64_t *ix = IDX + at;
        double *vk = VK + at, *dt = DT + at;
        if (vmap) {
            const int64_t *vm = vmap + voff[j] - 1;
            for (int64_t p = 1; p < n; p++) {
                int64_t f = base + vm[p];
                ix[p] = f;
                vk[p] = VV[f];
                double t = TT[f];
                dt[p - 1] = t - prev;
                prev = t;
            }
        } else {
            int64_t f0 = base + voff[j] - 1;
            for (int64_t p = 1; p < n; p++) {
                int64_t f = f0 + p;
                ix[p] = f;
                vk[p] = VV[f];
                double t = TT[f];
                dt[p - 1] = t - prev;
                prev = t;
            }
        }
        if (BND) {
            uint8_t *bd = BND + at;
            for (int64_t p = 1; p < n; p++) bd[p] = BB[ix[p]];
            bd[0] = bd[n] = 0;
        }
        vk[0] = V0[i];
        vk[n] = V1[i];
        dt[n - 1] = TL[i] - prev;
        dt[n] = 0.0;
        ix[0] = ix[n] = 0;
        at += n + 1;
    }
    release(&b);
    if (bad || at != C) {
        PyErr_SetString(PyExc_ValueError, "knots_flat: rows or places");
        return NULL;
    }
    Py_RETURN_NONE;
}

/* horner_skip_c(tau, g, s1coef, k, sinh_coef, n, sh2, wbar, A, delta, T, s4, s, v, tol_exp) (tests):
   s4 = prims.shc(g / 4) (shc_quarter), then s, v = tod_chunk's s and ṡ of the laws (tau, g,
   n .. T, with the s4 made here) with the S1 series' k terms, CHUNK laws a call, both with a
   HornerSkip table of sinh_coef made with tol_exp (HS_TOL the module's; 0 the full Horner;
   coarser ones make many blocks' bounds take several steps or miss) */
static PyObject *horner_skip_c(PyObject *self, PyObject *a) {
    PyObject *o[13];
    int k, tol_exp;
    if (!PyArg_ParseTuple(a, "OOOiOOOOOOOOOOi", &o[0], &o[1], &o[2], &k, &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &o[9], &o[10], &o[11], &o[12], &tol_exp))
        return NULL;
    Bufs b = {.n = 0};
    double *p[13];
    Py_ssize_t nn[13];
    for (int u = 0; u < 13; u++) {
        p[u] = get(&b, o[u], 8, u >= 10, &nn[u]);
        if (!p[u]) { release(&b); return NULL; }
    }
    Py_ssize_t N = nn[0];
    int ok = nn[3] >= 1 && nn[3] <= SINH_MAX && k >= 1 && k <= nn[2] && tol_exp <= 0;
    for (int u = 0; u < 13; u++) ok = ok && (u == 2 || u == 3 || nn[u] == N);
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "horner_skip_c: shapes");
        return NULL;
    }
    HornerSkip *hs = PyMem_Malloc(sizeof *hs);
    if (!hs) { release(&b); return PyErr_NoMemory(); }
    hs_make(hs, p[3], (int)nn[3], tol_exp);
    for (Py_ssize_t j0 = 0; j0 < N; j0 += CHUNK) {
        Py_ssize_t m = N - j0 < CHUNK ? N - j0 : CHUNK;
        shc_quarter(m, p[1] + j0, hs, p[10] + j0);
        tod_chunk(m, k, p[0] + j0, p[1] + j0, p[2], hs, p[10] + j0, p[4] + j0, p[5] + j0, p[6] + j0, p[7] + j0,
                  p[8] + j0, p[9] + j0, p[11] + j0, p[12] + j0);
    }
    PyMem_Free(hs);
    release(&b);
    Py_RETURN_NONE;
}

/* prims_c(z, sinh_coef, sh, cu, sc): sh = p_sinh(z), cu = p_cube(z), sc = p_shc(z), element by
   element (for the tests: the C primitives against prims.py's) */
static PyObject *prims_c(PyObject *self, PyObject *a) {
    PyObject *oz, *oc, *osh, *ocu, *osc;
    if (!PyArg_ParseTuple(a, "OOOOO", &oz, &oc, &osh, &ocu, &osc)) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t n, nc, n1, n2, n3;
    double *z = get(&b, oz, 8, 0, &n);
    double *c = z ? get(&b, oc, 8, 0, &nc) : NULL;
    double *sh = c ? get(&b, osh, 8, 1, &n1) : NULL;
    double *cu = sh ? get(&b, ocu, 8, 1, &n2) : NULL;
    double *sc = cu ? get(&b, osc, 8, 1, &n3) : NULL;
    if (!sc) { release(&b); return NULL; }
    if (n1 != n || n2 != n || n3 != n || nc < 1 || nc > SINH_MAX) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "prims_c: shapes");
        return NULL;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        sh[i] = p_sinh(z[i], c, (int)nc);
        cu[i] = p_cube(z[i]);
        sc[i] = p_shc(z[i], c, (int)nc);
    }
    release(&b);
    Py_RETURN_NONE;
}

/* ------------------------------------------------------------------ chain finishing
   chain_finish: chains.py's _finish_stacked_dt (numpy) for a batch of R rows of chains
   with n segments under the junction laws "jerk" (classic jerk, junction 0), "scv" (Klipper, 1)
   and "jd" (Marlin's junction deviation, 2):
   shape_segments, the fits test, the acceleration floor / junction accelerations,
   hold_cruise_accels_rows, the classic-jerk tent (tent_rows' envelope) and, when
   predict, _predict_group.  Every double operation is numpy's, in numpy's order; numpy's
   maximum/minimum (nan first), argmin (first minimum, first nan), pairwise row sums.
   Returns False (nothing usable written) on an input it does not take: a non-finite knot
   speed, duration or limit, or a classic-jerk tent input that is not finite and > 0. */

/* numpy's minimum: the first operand if it is nan or not above the second */
static inline double np_min(double a, double b) {
    int k = (a <= b) | (a != a);
    return k ? a : b;
}
/* Python's max(a, b) / min(a, b) of two floats: a unless b is above / below it */
static inline double py_max(double a, double b) { return (b > a) ? b : a; }
static inline double py_min(double a, double b) { return (b < a) ? b : a; }

#define CF_TRAP_G 32      /* chains.TRAP_GRID: the trapezoid cruise speeds tried */

/* per chain parameters (columns of P) */
enum { CP_ATOP, CP_VFEED, CP_STEP, CP_JX, CP_JY, CP_SCV, CP_AXM, CP_AYM, CP_V0, CP_V1, CP_C0, CP_C1,
       CP_PUX, CP_PUY, CP_HASP, CP_NUX, CP_NUY, CP_HASN, CP_N };
/* under jd (junction 2) the scv column holds the limits' jd (cf_rows' jd: 1), so that P and Q
   keep their columns (a caller of an earlier layout runs unchanged) */
#define CP_JD CP_SCV
/* constants (K) */
enum { CK_TOL, CK_DEFA, CK_CRUISE, CK_CORNER, CK_SQ2M1, CK_MARGIN, CK_STOPV, CK_MINFEED, CK_N };

/* junction.accel_to_pass_junction("scv", v, pu, u, d) */
static inline double cf_atp_scv(double v, int has_pu, double pux, double puy, int has_u, double ux, double uy,
                                double d) {
    if (v <= 0.0 || !has_pu || !has_u) return 0.0;
    double cos_theta = -(ux * pux + uy * puy);
    if (cos_theta <= -0.999999) return 0.0;
    double sin_d2 = sqrt(py_max(0.5 * (1.0 - cos_theta), 0.0));
    double cos_d2 = sqrt(py_max(0.5 * (1.0 + cos_theta), 0.0));
    double v2 = v * v;
    if (cos_d2 <= 0.0) return 0.0;
    if (sin_d2 <= 0.0) return INFINITY;
    return v2 / (2.0 * d * 0.25 * sin_d2 / cos_d2);
}

/* junction._marlin_fast_acos_neg: Marlin's polynomial for acos(-cos_theta), in its order */
static inline double cf_fast_acos_neg(double cos_theta) {
    double neg = cos_theta < 0.0 ? -1.0 : 1.0;
    double t = neg * cos_theta;
    double asinx = (0.032843707 + t * (-1.451838349 + t * (29.66153956 + t * (-131.1123477
                    + t * (262.8130562 + t * (-242.7199627 + t * 84.31466202))))));
    return M_PI / 2.0 + neg * asinx;
}

/* junction.accel_to_pass_junction("jd", v, pu, u, d, jd); *bad = 1 where it would divide
   by zero (Python raises: the caller declines) */
static inline double cf_atp_jd(double v, int has_pu, double pux, double puy, double ux, double uy, double d,
                               double jd, int *bad) {
    if (v <= 0.0 || !has_pu) return 0.0;
    double cos_theta = -(ux * pux + uy * puy);
    if (cos_theta <= -0.999999) {
        if (d < 1.0) {
            if (d == 0.0) { *bad = 1; return 0.0; }
            return v * v * cf_fast_acos_neg(-0.999999) / d;
        }
        return 0.0;
    }
    double sin_d2 = sqrt(py_max(0.5 * (1.0 - cos_theta), 0.0));
    double v2 = v * v;
    double per_a = sin_d2 < 1.0 ? jd * sin_d2 / (1.0 - sin_d2) : INFINITY;
    if (d < 1.0 && cos_theta < -0.7071067812) {
        double th = cf_fast_acos_neg(cos_theta);
        if (th == 0.0) { *bad = 1; return 0.0; }
        per_a = py_min(per_a, d / th);
    }
    return per_a > 0 ? v2 / per_a : INFINITY;
}

/* junction.marlin_jd_v2 of an XY junction (pu, u; the move's length d and acceleration in
   force a, the axes' caps cx, cy; Z: nothing), in its order; *bad = 1 where Python would
   raise (d * ja / theta with theta 0) */
static inline double cf_jd_v2(double pux, double puy, double ux, double uy, double d, double a, double jd,
                              double cx, double cy, int *bad) {
    double cos_theta = -(pux * ux + puy * uy + 0.0);
    if (cos_theta > 0.999999) return 0.05 * 0.05;          /* MINIMUM_PLANNER_SPEED squared */
    double jx = ux - pux, jy = uy - puy;
    double jn = sqrt(jx * jx + jy * jy + 0.0);
    double ja = a;
    if (jn > 0.0) {                                        /* axis_limited, X then Y (Z: 0) */
        double ax = fabs(jx / jn), ay = fabs(jy / jn);
        if (ax > 0.0 && ja * ax > cx) ja = cx / ax;
        if (ay > 0.0 && ja * ay > cy) ja = cy / ay;
    }
    double s2 = 0.5 * (1.0 - cos_theta);
    double sin_d2 = s2 > 0.0 ? sqrt(s2) : 0.0;
    double one_m = 1.0 - sin_d2;
    double v2 = one_m > 0.0 ? ja * jd * sin_d2 / one_m : INFINITY;
    if (d < 1.0 && cos_theta < -0.7071067812) {
        double th = cf_fast_acos_neg(cos_theta);
        if (th == 0.0) { *bad = 1; return 0.0; }
        double lim = d * ja / th;
        if (lim < v2) v2 = lim;
    }
    return v2;
}

/* numpy's maximum and minimum (np_max, np_min) as macros for the vector clones (a call to
   a function built for another target is not inlined there) */
#define NP_MAX(a, b) ((((a) >= (b)) | ((a) != (a))) ? (a) : (b))
#define NP_MIN(a, b) ((((a) <= (b)) | ((a) != (a))) ? (a) : (b))

/* chains._axis_jerk of a junction's speeds x (exit) and e (entry), plain variables, into j:
   the numpy code's selections (np.maximum's nan rule), each candidate made, then selected.
   A macro: the vector clones inline no function built for another target. */
#define CF_AXIS_JERK(j, x, e) do {                                                          \
        double up1_ = (x) - (e), up2_ = NP_MAX((x), -(e)), dn1_ = (e) - (x), dn2_ = NP_MAX(-(x), (e)); \
        double up_ = (((e) > 0.0) | ((x) < 0.0)) ? up1_ : up2_;                            \
        double dn_ = (((e) < 0.0) | ((x) > 0.0)) ? dn1_ : dn2_;                            \
        (j) = ((x) > (e)) ? up_ : dn_;                                                     \
    } while (0)

/* _predict_group's jerk junction (junction 0) on one row's n moves (unit vectors u, feeds
   fr): each move's safe speed (chains._safe_speed) and the junction speed caps v[1..n-1]
   (chains._jerk_junction_v, then at most both feeds), elementwise with selections for the
   numpy code's masks (SIMD lanes: each element's operations in its order) */
VEC_CLONES static void cf_jerk_caps(Py_ssize_t n, const double *restrict u, const double *restrict fr, double jx,
                                    double jy, double *restrict safe, double *restrict v) {
    for (Py_ssize_t k = 0; k < n; k++) {
        double nominal = fr[k];
        double cx = fabs(u[2 * k]) * nominal;
        int lx = cx > jx;
        double sk = lx ? jx : nominal;
        double cy = fabs(u[2 * k + 1]) * nominal;
        int ly = cy > jy;
        double both = (cy * sk > jy * nominal) ? jy * nominal / cy : sk;
        safe[k] = ly ? (lx ? both : jy) : sk;
    }
    for (Py_ssize_t k = 1; k < n; k++) {
        double pux = u[2 * (k - 1)], puy = u[2 * (k - 1) + 1], ux = u[2 * k], uy = u[2 * k + 1];
        double p_nom = fr[k - 1], nom = fr[k];
        double vmax = NP_MIN(nom, p_nom);
        double smaller = vmax / p_nom;
        double x0 = pux * p_nom * smaller, e0 = ux * nom;
        double jerk;
        CF_AXIS_JERK(jerk, x0, e0);
        int limited = jerk > jx;
        double vfx = jx / jerk;
        double vf = limited ? vfx : 1.0;
        double v_exit = puy * p_nom * smaller, v_entry = uy * nom;
        double vxs = v_exit * vf, ves = v_entry * vf;
        v_exit = limited ? vxs : v_exit;
        v_entry = limited ? ves : v_entry;
        double jerk2;
        CF_AXIS_JERK(jerk2, v_exit, v_entry);
        int ly = jerk2 > jy;
        double vfy = vf * (jy / jerk2);
        vf = ly ? vfy : vf;
        limited = limited | ly;
        double vms = vmax * vf;
        vmax = limited ? vms : vmax;
        double thr = vmax * 0.99;
        double q = ((safe[k - 1] > thr) & (safe[k] > thr)) ? safe[k] : vmax;
        double fm = NP_MIN(p_nom, nom);
        v[k] = NP_MIN(q, fm);
    }
}

/* shape_segments' per-segment numbers of one row's n segments (lengths d, durations tr,
   knot speeds vr[0..n]), elementwise (SIMD lanes: each segment's operations in its order):
   whether it bumps (a triangle above the ramp), its duration ttk (1 where it does not), the
   triangle's peak and acceleration, and its acceleration ak and feed fk before the trapezoid
   search (scv) and the floor of the feeds.  (A loop with sqrt is not vectorised: its errno;
   the clones' code still takes ~6 % fewer instructions of chain_finish than the loop inline.) */
VEC_CLONES static void cf_shape(Py_ssize_t n, const double *restrict d, const double *restrict tr,
                                const double *restrict vr, uint8_t *restrict bump, double *restrict ttk,
                                double *restrict peak, double *restrict tri, double *restrict ak,
                                double *restrict fk) {
    for (Py_ssize_t k = 0; k < n; k++) {
        double dk = d[k], t = NP_MAX(tr[k], 1e-12), a0 = vr[k], b0 = vr[k + 1];
        double t_ramp = 2.0 * dk / NP_MAX(a0 + b0, 1e-12);
        double ramp_a = fabs(b0 * b0 - a0 * a0) / (2.0 * dk);
        int bu = t < t_ramp * (1.0 - 1e-9);
        double tt = bu ? t : 1.0;
        double disc = NP_MAX(16.0 * dk * dk - 8.0 * tt * (2.0 * dk * (a0 + b0) - tt * (a0 * a0 + b0 * b0)), 0.0);
        double pk = (4.0 * dk + sqrt(disc)) / (4.0 * tt);
        pk = NP_MAX(pk, NP_MAX(a0, b0));
        double tri_a = (2.0 * pk * pk - a0 * a0 - b0 * b0) / (2.0 * dk);
        bump[k] = (uint8_t)bu;
        ttk[k] = tt;
        peak[k] = pk;
        tri[k] = tri_a;
        ak[k] = bu ? tri_a : ramp_a;
        fk[k] = bu ? pk : NP_MAX(a0, b0);
    }
}

/* _trapezoid_rows' times and ∫a² terms of one row's n segments from the lookahead's squared
   speeds v2[0..n], feeds fr, reaches, accelerations ar, lengths d: tt, tmp (a (Δv up + Δv
   down)), the end speeds va, vb; elementwise (each segment's operations in its order). */
VEC_CLONES static void cf_trap_times(Py_ssize_t n, const double *restrict v2, const double *restrict fr,
                                     const double *restrict reach, const double *restrict ar,
                                     const double *restrict d, double *restrict tt, double *restrict tmp,
                                     double *restrict va, double *restrict vb) {
    for (Py_ssize_t k = 0; k < n; k++) {
        double va2 = v2[k], vb2 = v2[k + 1];
        double peak2 = NP_MIN(fr[k] * fr[k], 0.5 * (reach[k] + va2 + vb2));
        peak2 = NP_MAX(peak2, NP_MAX(va2, vb2));
        double pkk = sqrt(peak2), vak = sqrt(va2), vbk = sqrt(vb2);
        double a = NP_MAX(ar[k], 1e-12);
        double up_d = (peak2 - va2) / (2.0 * a);
        double dn_d = (peak2 - vb2) / (2.0 * a);
        double cruise_d = NP_MAX(d[k] - up_d - dn_d, 0.0);
        tt[k] = (pkk - vak) / a + (pkk - vbk) / a + cruise_d / NP_MAX(pkk, 1e-9);
        tmp[k] = a * ((pkk - vak) + (pkk - vbk));
        va[k] = vak;
        vb[k] = vbk;
    }
}

/* chain_finish's elementwise lines (SIMD lanes: each element's operations in its order,
   numpy's maximum / minimum as selections): the lookahead floor of the accelerations ar
   on the windows w (a_top the cap) */
VEC_CLONES static void cf_floor(Py_ssize_t n, double *restrict ar, const double *restrict fr,
                                const double *restrict w, double a_top) {
    for (Py_ssize_t k = 0; k < n; k++) {
        double f = 1.1 * (fr[k] * fr[k]) / (2.0 * w[k]);
        ar[k] = NP_MAX(ar[k], NP_MIN(f, a_top));
    }
}

/* _lookahead_v2's reach (2 a d) of the n segments and the squared speeds of the n + 1 knots */
VEC_CLONES static void cf_reach_v2(Py_ssize_t n, const double *restrict ar, const double *restrict d,
                                   const double *restrict v, double *restrict reach, double *restrict v2) {
    for (Py_ssize_t k = 0; k < n; k++) reach[k] = 2.0 * ar[k] * d[k];
    for (Py_ssize_t k = 0; k <= n; k++) v2[k] = v[k] * v[k];
}

/* the nj inner corners' ∫a² terms: at junction k (between segments k and k + 1) with
   cos_turn ct[k] at least corner, 2 v² (1 - ct) / max(the mean of the two durations, 1e-12),
   v = va[k + 1]; else 0 */
VEC_CLONES static void cf_corners(Py_ssize_t nj, const double *restrict va, const double *restrict tt,
                                  const double *restrict ct, double corner, double *restrict out) {
    for (Py_ssize_t k = 0; k < nj; k++) {
        double vi = va[k + 1];
        double tj = 0.5 * (tt[k] + tt[k + 1]);
        double dv2 = 2.0 * vi * vi * (1.0 - ct[k]);
        double q = dv2 / NP_MAX(tj, 1e-12);
        out[k] = (ct[k] >= corner) ? q : 0.0;
    }
}

/* The largest of n > 0 feeds f, every one finite and > 0 (all_finite_pos checked them
   first): with no nan, inf or signed zero among them their maximum is the same number
   whatever the order its comparisons take, so the vector clones may take the lanes'
   maxima and then the largest of those (finite-math-only, no-signed-zeros here, and only
   here: a function that tests for them must not have them) */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
__attribute__((target_clones("avx2", "default"),
               optimize("O3", "no-trapping-math", "fp-contract=off", "finite-math-only", "no-signed-zeros")))
#endif
static double cf_pos_max(Py_ssize_t n, const double *restrict f) {
    double m = f[0];
    for (Py_ssize_t j = 1; j < n; j++) m = f[j] > m ? f[j] : m;
    return m;
}

/* shape_segments' last lines on one row's n segments: the feeds floored at min_feed, the
   accelerations capped at a_top; 1 where every acceleration is <= lim (a_top tol: the row
   fits), else 0.  Elementwise (SIMD lanes), numpy's maximum / minimum as selections. */
VEC_CLONES static int cf_clamp(Py_ssize_t n, double *restrict ar, double *restrict fr, double a_top, double lim,
                               double min_feed) {
    int bad = 0;
    for (Py_ssize_t k = 0; k < n; k++) {
        double ak = ar[k], fk = fr[k];
        fr[k] = NP_MAX(fk, min_feed);
        bad |= !(ak <= lim);
        ar[k] = NP_MIN(ak, a_top);
    }
    return !bad;
}

/* tent_rows' envelope of one row's n feeds f (finite, > 0) before its search: at k the larger
   of the two sides' ramps side - st (k + 1), side - st (n - k), then the search's first
   step (dd = 0: f[k] - st 0 = f[k] against it; its test pmax - 0 < mm only ends the search
   where dd = 1's would: pmax >= f[k]), elementwise (SIMD lanes: k an int, whose conversion
   to double has a vector instruction, which int64's lacks before AVX-512; n <= INT_MAX,
   checked by the caller); the search goes on from dd = 1 */
VEC_CLONES static void cf_tent_base(int n, const double *restrict f, double side, double st,
                                    double *restrict mm) {
    for (int k = 0; k < n; k++) {
        double m = side - st * (double)(k + 1);
        double e = side - st * (double)(n - k);
        m = e > m ? e : m;
        double q = f[k] - st * 0.0;
        mm[k] = q > m ? q : m;
    }
}

/* Does chain_finish take a chain's parameters p: every one finite but the end turns' cosines
   (nan: no neighbour) and, under scv and jd, the step (inf)? */
static int cf_p_ok(const double *p, int junction) {
    for (int j = 0; j < CP_N; j++)
        if (j != CP_C0 && j != CP_C1 && !(j == CP_STEP && junction >= 1) && !isfinite(p[j])) return 0;
    return 1;
}

/* One row of chain_finish / chain_finish_ragged: n segments of a chain (p: its CP_N
   parameters, d its lengths, u its directions (n, 2), ct its n - 1 turn cosines, w its
   lookahead windows or NULL: no floor), the row's knot speeds vr (n + 1) and segment
   durations tr (n); out: its accelerations ar and feeds fr (n), *fit, and when predict its
   predicted time *tout and *a2out; wk: 20 (n + 2) doubles of work space.  0 where the
   classic-jerk tent declines the row's feeds (nothing usable written), else 1. */
static int cf_row(int junction, int predict, Py_ssize_t n, const double *restrict p, const double *restrict d,
                  const double *restrict u, const double *restrict ct, const double *restrict w,
                  const double *restrict vr, const double *restrict tr, const double *restrict grid,
                  const double *restrict K, double *restrict ar, double *restrict fr, double *restrict tout,
                  double *restrict a2out, uint8_t *restrict fit, double *restrict wk) {
    const double tol = K[CK_TOL], defa = K[CK_DEFA], cruise_a = K[CK_CRUISE], corner = K[CK_CORNER],
                 sq2m1 = K[CK_SQ2M1], margin = K[CK_MARGIN], stop_v = K[CK_STOPV], min_feed = K[CK_MINFEED];
    const double a_top = p[CP_ATOP];
    double *v = wk, *cs = wk + (n + 2), *rs = wk + 2 * (n + 2), *reach = wk + 3 * (n + 2),
           *va = wk + 5 * (n + 2), *vb = wk + 6 * (n + 2), *tt = wk + 7 * (n + 2),
           *aa = wk + 8 * (n + 2), *tmp = wk + 9 * (n + 2), *safe = wk + 10 * (n + 2), *vj = wk + 11 * (n + 2),
           *fsh = wk + 12 * (n + 2), *x = wk + 13 * (n + 2), *v2 = wk + 14 * (n + 2),
           *ttk_ = wk + 15 * (n + 2), *pk_ = wk + 16 * (n + 2), *tri_ = wk + 17 * (n + 2);
    uint8_t *bmp = (uint8_t *)(wk + 18 * (n + 2));       /* (two rows of doubles: n bytes) */
    /* shape_segments: elementwise (cf_shape), then the trapezoids tried on the bumps (scv),
       then the feeds' floor and the accelerations' cap (cf_clamp) */
    cf_shape(n, d, tr, vr, bmp, ttk_, pk_, tri_, ar, fr);
    for (Py_ssize_t k = 0; junction >= 1 && k < n; k++) {
        if (bmp[k]) {
            double dk = d[k], a0 = vr[k], b0 = vr[k + 1], ttk = ttk_[k], peak = pk_[k], tri_a = tri_[k];
            double lo = np_max(dk / ttk, np_max(a0, b0));
            double Fv[CF_TRAP_G], av[CF_TRAP_G], cv[CF_TRAP_G];
            for (int j = 0; j < CF_TRAP_G; j++) {      /* elementwise: vectorizable */
                double F = lo + (peak - lo) * grid[j];
                double a = ((F - a0) * (F - a0) + (F - b0) * (F - b0)) / (2.0 * (F * ttk - dk));
                Fv[j] = F;
                av[j] = a;
                cv[j] = a * (2.0 * F - a0 - b0);
            }
            for (int j = 0; j < CF_TRAP_G; j++)
                if (!((av[j] > 0) && (av[j] <= a_top))) cv[j] = INFINITY;
            int jb = 0;                                 /* np.argmin: the first minimum, a nan first */
            for (int j = 1; j < CF_TRAP_G && !isnan(cv[jb]); j++)
                if (cv[j] < cv[jb] || isnan(cv[j])) jb = j;
            double best = cv[jb], best_a = av[jb], best_F = Fv[jb];
            double tri_cost = tri_a * (2.0 * peak - a0 - b0);
            int take = isfinite(best) && best < tri_cost;
            ar[k] = take ? best_a : tri_a;
            fr[k] = take ? best_F : peak;
        }
    }
    *fit = (uint8_t)cf_clamp(n, ar, fr, a_top, a_top * tol, min_feed);
    if (junction == 1) {       /* curves.junction_accels (scv), vmax = the feeds as shaped */
        for (Py_ssize_t k = 0; k <= n; k++) x[k] = vr[k];
        x[0] = p[CP_V0] >= stop_v ? p[CP_V0] : 0.0;
        x[n] = p[CP_V1] >= stop_v ? p[CP_V1] : 0.0;
        for (Py_ssize_t k = 0; k < n; k++) {
            int hp = k > 0 || p[CP_HASP] != 0.0, hn = k < n - 1 || p[CP_HASN] != 0.0;
            double pux = k > 0 ? u[2 * (k - 1)] : p[CP_PUX], puy = k > 0 ? u[2 * (k - 1) + 1] : p[CP_PUY];
            double nux = k < n - 1 ? u[2 * (k + 1)] : p[CP_NUX], nuy = k < n - 1 ? u[2 * (k + 1) + 1] : p[CP_NUY];
            double need = cf_atp_scv(x[k], hp, pux, puy, 1, u[2 * k], u[2 * k + 1], d[k]);
            need = py_max(need, cf_atp_scv(x[k + 1], 1, u[2 * k], u[2 * k + 1], hn, nux, nuy, d[k]));
            ar[k] = py_max(ar[k], py_min(margin * need, a_top));
        }
    } else if (junction == 2) {     /* curves.junction_accels (jd: each segment's start junction) */
        int bad = 0;
        for (Py_ssize_t k = 0; k <= n; k++) x[k] = vr[k];
        x[0] = p[CP_V0] >= stop_v ? p[CP_V0] : 0.0;
        x[n] = p[CP_V1] >= stop_v ? p[CP_V1] : 0.0;
        for (Py_ssize_t k = 0; k < n; k++) {
            int hp = k > 0 || p[CP_HASP] != 0.0;
            double pux = k > 0 ? u[2 * (k - 1)] : p[CP_PUX], puy = k > 0 ? u[2 * (k - 1) + 1] : p[CP_PUY];
            double need = cf_atp_jd(x[k], hp, pux, puy, u[2 * k], u[2 * k + 1], d[k], p[CP_JD], &bad);
            ar[k] = py_max(ar[k], py_min(margin * need, a_top));
        }
        if (bad) return 0;
    }
    if (w) cf_floor(n, ar, fr, w, a_top);
    /* hold_cruise_accels_rows */
    {
        Py_ssize_t first = -1;
        for (Py_ssize_t k = 0; k < n; k++)
            if (!(ar[k] <= cruise_a)) { first = k; break; }
        if (first < 0) {
            for (Py_ssize_t k = 0; k < n; k++) ar[k] = a_top;
        } else {
            double held = ar[first];
            for (Py_ssize_t k = first; k < n; k++) {
                if (ar[k] <= cruise_a) ar[k] = held;
                else held = ar[k];
            }
            for (Py_ssize_t k = 0; k < first; k++) ar[k] = ar[first];
        }
    }
    /* the classic jerk tent (tent_rows) */
    if (junction == 0) {
        double vf = p[CP_VFEED], st = p[CP_STEP], side = vf + st;
        int ok = isfinite(vf) && vf > 0 && isfinite(st) && st > 0 && isfinite(side);
        ok = ok && n <= INT_MAX && all_finite_pos(n, fr);     /* (INT_MAX: cf_tent_base's int) */
        if (!ok) return 0;
        double pmax = cf_pos_max(n, fr);
        memcpy(fsh, fr, (size_t)n * sizeof(double));
        cf_tent_base((int)n, fr, side, st, tmp);
        for (Py_ssize_t k = 0; k < n; k++) {
            double mm = tmp[k];
            for (Py_ssize_t dd = 1; dd < n; dd++) {
                double sd = st * (double)dd;
                if (pmax - sd < mm) break;
                if (k - dd >= 0) {
                    double q = fsh[k - dd] - sd;
                    if (q > mm) mm = q;
                }
                if (k + dd < n) {
                    double q = fsh[k + dd] - sd;
                    if (q > mm) mm = q;
                }
            }
            fr[k] = mm;
        }
    }
    if (!predict) return 1;
    /* _predict_group: the junction speed caps v (n + 1) */
    v[0] = p[CP_V0];
    v[n] = p[CP_V1];
    if (junction == 0) {
        cf_jerk_caps(n, u, fr, p[CP_JX], p[CP_JY], safe, v);
    } else if (junction == 2) {     /* chains._jd_vertex_v: the law at the next move's accel in force */
        double jd = p[CP_JD], axm = p[CP_AXM], aym = p[CP_AYM];
        int bad = 0;
        for (Py_ssize_t k = 1; k < n; k++) {
            double a0 = ar[k] > 0 ? ar[k] : defa;
            double ux = fabs(u[2 * k]), uy = fabs(u[2 * k + 1]);
            double a = ((ux > 0) && (a0 * ux > axm)) ? axm / ux : a0;
            a = ((uy > 0) && (a * uy > aym)) ? aym / uy : a;
            double w2 = cf_jd_v2(u[2 * (k - 1)], u[2 * (k - 1) + 1], u[2 * k], u[2 * k + 1], d[k], a, jd, axm, aym,
                                 &bad);
            if (w2 < 0.0) bad = 1;                 /* (math.sqrt raises) */
            double m = isfinite(w2) ? sqrt(w2) : INFINITY;
            if (fr[k - 1] < m) m = fr[k - 1];      /* Python's min(v, fp, fn) */
            if (fr[k] < m) m = fr[k];
            v[k] = m;
        }
        if (bad) return 0;
    } else {
        double scv = p[CP_SCV], axm = p[CP_AXM], aym = p[CP_AYM];
        for (Py_ssize_t k = 0; k < n; k++) {      /* a (aa), jd (vj), dv2 (x) per move */
            double a0 = ar[k] > 0 ? ar[k] : defa;
            double ux = fabs(u[2 * k]), uy = fabs(u[2 * k + 1]);
            double a = ((ux > 0) && (a0 * ux > axm)) ? axm / ux : a0;
            a = ((uy > 0) && (a * uy > aym)) ? aym / uy : a;
            aa[k] = a;
            vj[k] = scv * scv * sq2m1 / a0;
            x[k] = 2.0 * d[k] * a;
        }
        for (Py_ssize_t k = 1; k < n; k++) {
            double cos_t = -(u[2 * k] * u[2 * (k - 1)] + u[2 * k + 1] * u[2 * (k - 1) + 1] + 0.0);
            double s2 = 0.5 * (1.0 - cos_t), c2 = 0.5 * (1.0 + cos_t);
            double sin_d2 = sqrt(np_max(s2, 0.0)), cos_d2 = sqrt(np_max(c2, 0.0));
            double one_m = 1.0 - sin_d2;
            int okj = (one_m > 0.0) && (cos_d2 > 0.0);
            double r_jd = sin_d2 / (okj ? one_m : 1.0);
            double qt = 0.25 * sin_d2 / (okj ? cos_d2 : 1.0);
            double q = np_min(r_jd * vj[k] * aa[k], r_jd * vj[k - 1] * aa[k - 1]);
            q = np_min(np_min(q, x[k] * qt), x[k - 1] * qt);
            q = okj ? sqrt(np_max(q, 0.0)) : INFINITY;
            v[k] = np_min(q, np_min(fr[k - 1], fr[k]));
        }
    }
    /* _trapezoid_rows: _lookahead_v2 */
    cf_reach_v2(n, ar, d, v, reach, v2);
    cs[0] = 0.0;
    cs[1] = reach[0];
    for (Py_ssize_t k = 1; k < n; k++) cs[k + 1] = cs[k] + reach[k];
    {
        double mn = v2[0] - cs[0];
        tmp[0] = np_min(v2[0], mn + cs[0]);
        for (Py_ssize_t k = 1; k <= n; k++) {
            mn = np_min(mn, v2[k] - cs[k]);
            tmp[k] = np_min(v2[k], mn + cs[k]);
        }
    }
    rs[n] = 0.0;
    rs[n - 1] = reach[n - 1];
    for (Py_ssize_t k = n - 2; k >= 0; k--) rs[k] = rs[k + 1] + reach[k];
    {
        double mn = tmp[n] - rs[n];
        v2[n] = np_min(tmp[n], mn + rs[n]);
        for (Py_ssize_t k = n - 1; k >= 0; k--) {
            mn = np_min(mn, tmp[k] - rs[k]);
            v2[k] = np_min(tmp[k], mn + rs[k]);
        }
    }
    cf_trap_times(n, v2, fr, reach, ar, d, tt, tmp, va, vb);
    double a2 = -0.0 + np_pairwise_sum(tmp, n);
    cf_corners(n - 1, va, tt, ct, corner, tmp);
    a2 = a2 + (n > 1 ? -0.0 + np_pairwise_sum(tmp, n - 1) : 0.0);      /* numpy's empty sum: 0.0 */
    /* the end corners */
    if (p[CP_C0] >= corner) a2 = a2 + 1.0 * va[0] * va[0] * (1.0 - p[CP_C0]) / np_max(tt[0], 1e-12);
    if (p[CP_C1] >= corner) a2 = a2 + 1.0 * vb[n - 1] * vb[n - 1] * (1.0 - p[CP_C1]) / np_max(tt[n - 1], 1e-12);
    *tout = -0.0 + np_pairwise_sum(tt, n);
    *a2out = a2;
    return 1;
}

/* chain_finish(junction, predict, own, vk, tk, D, U, COS, W, ws, P, grid, K,
                acc, feed, t, a2, fits) -> bool
   junction 0 = jerk (triangles, the lookahead floor on W if W has R... rows, the tent),
   1 = scv (trapezoids, junction accelerations, the floor).  own (R,) int64 chain of each
   row; vk (R, n+1); tk (R, n) segment durations; per chain: D (m, n) lengths, U (m, n, 2)
   directions, COS (m, n-1) cos_turn, W lookahead windows, chain c's at W[c ws:c ws + n] (size 0: no floor),
   P (m, CP_N); grid: TRAP_GRID; K: constants.  Out: acc, feed (R, n); t, a2 (R,)
   (predict); fits (R,) uint8. */
static PyObject *chain_finish(PyObject *self, PyObject *args) {
    int junction, predict;
    Py_ssize_t ws;
    PyObject *oown, *ovk, *otk, *oD, *oU, *oC, *oW, *oP, *og, *oK, *oacc, *ofeed, *ot, *oa2, *ofits;
    if (!PyArg_ParseTuple(args, "iiOOOOOOOnOOOOOOOO", &junction, &predict, &oown, &ovk, &otk, &oD, &oU, &oC,
                          &oW, &ws, &oP, &og, &oK, &oacc, &ofeed, &ot, &oa2, &ofits))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t R, Nvk, Ntk, ND, NU, NC, NW, NP, G, NK, Nacc, Nfeed, Nt, Na2, Nf;
    int64_t *own = get(&b, oown, 8, 0, &R);
    double *vk = own ? get(&b, ovk, 8, 0, &Nvk) : NULL;
    double *tk = vk ? get(&b, otk, 8, 0, &Ntk) : NULL;
    double *D = tk ? get(&b, oD, 8, 0, &ND) : NULL;
    double *U = D ? get(&b, oU, 8, 0, &NU) : NULL;
    double *COS = U ? get(&b, oC, 8, 0, &NC) : NULL;
    double *W = COS ? get(&b, oW, 8, 0, &NW) : NULL;
    double *P = W ? get(&b, oP, 8, 0, &NP) : NULL;
    double *grid = P ? get(&b, og, 8, 0, &G) : NULL;
    double *K = grid ? get(&b, oK, 8, 0, &NK) : NULL;
    double *acc = K ? get(&b, oacc, 8, 1, &Nacc) : NULL;
    double *feed = acc ? get(&b, ofeed, 8, 1, &Nfeed) : NULL;
    double *tout = feed ? get(&b, ot, 8, 1, &Nt) : NULL;
    double *a2out = tout ? get(&b, oa2, 8, 1, &Na2) : NULL;
    uint8_t *fits = a2out ? get(&b, ofits, 1, 1, &Nf) : NULL;
    if (!fits) { release(&b); return NULL; }
    Py_ssize_t n = R > 0 ? Ntk / R : 0, m = NP / CP_N;
    if (R <= 0 || n < 1 || Ntk != R * n || Nvk != R * (n + 1) || NP != m * CP_N || m < 1 || ND != m * n ||
        NU != 2 * m * n || NC != m * (n - 1) || (NW != 0 && (ws < n || (m - 1) * ws + n > NW)) || NK != CK_N || G < 1 ||
        Nacc != R * n || Nfeed != R * n || Nt != R || Na2 != R || Nf != R || junction < 0 || junction > 2) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "chain_finish: shapes");
        return NULL;
    }
    for (Py_ssize_t r = 0; r < R; r++)
        if (own[r] < 0 || own[r] >= m) {
            release(&b);
            PyErr_SetString(PyExc_ValueError, "chain_finish: own");
            return NULL;
        }
    int ok = 1;
    ok = all_finite(Nvk, vk) && all_finite(Ntk, tk);
    for (Py_ssize_t c = 0; c < m && ok; c++) ok = cf_p_ok(P + c * CP_N, junction);
    if (G != CF_TRAP_G) ok = 0;        /* chains.TRAP_GRID's size */
    if (!ok) { release(&b); Py_RETURN_FALSE; }
    double *wk = malloc(sizeof(double) * (size_t)(20 * (n + 2)));
    if (!wk) { release(&b); return PyErr_NoMemory(); }
    for (Py_ssize_t r = 0; r < R && ok; r++) {
        const Py_ssize_t c = (Py_ssize_t)own[r];
        ok = cf_row(junction, predict, n, P + c * CP_N, D + c * n, U + c * 2 * n, COS + c * (n - 1),
                    NW ? W + c * ws : NULL, vk + r * (n + 1), tk + r * n, grid, K, acc + r * n, feed + r * n,
                    tout + r, a2out + r, fits + r, wk);
    }
    free(wk);
    release(&b);
    return PyBool_FromLong(ok);
}

/* chain_finish_ragged(junction, predict, nb, step_r, own, coff, vk, tk, D, U, Q, grid, K,
                       acc, feed, t, a2, fits) -> bool
   chain_finish over rows of chains of several segment counts, in one call (chains.
   _finish_ragged: the windowed candidates finish ~30 segment counts a window, each a
   chain_finish call and its numpy set-up before).  Chain c has n_c = coff[c + 1] - coff[c]
   >= 1 segments: its lengths D[coff[c]:coff[c + 1]], its directions U[2 coff[c]:2 coff[c + 1]];
   Q (m, CF_Q) its chains._cf_rows row.  Row r is chain own[r]'s, its n + 1 knot speeds and n
   durations next in vk and tk after the rows before it (acc, feed: its n values likewise).
   What chains._finish_core makes of each group with numpy is made here chain by chain with
   the same operations: P's columns from Q (the step JERK_F_STEP_R (step_r) x min(jerk_x,
   jerk_y), the end turns' cosines), the turn cosines (turn_cosines' sums), the lookahead
   windows of nb lengths (window_sums' sums over the lengths and nb copies of the last; nb 0:
   no floor; the caller takes nb > 0 only where _window_sums uses window_sums).  Each row then
   as chain_finish's (cf_row): the same bits.  False (nothing usable written) where
   chain_finish would decline a group. */
#define CF_Q 15       /* chains._CF_ROW */
enum { CQ_ATOP, CQ_VFEED, CQ_V0, CQ_V1, CQ_JX, CQ_JY, CQ_SCV, CQ_AXM, CQ_AYM, CQ_PUX, CQ_PUY, CQ_NUX, CQ_NUY,
       CQ_HASP, CQ_HASN };

/* chains._finish_core's P row of a chain of n segments (directions u) from its Q row q */
static void cf_p_of(int junction, double step_r, const double *restrict q, const double *restrict u,
                    Py_ssize_t n, double *restrict p) {
    for (int j = 0; j < CP_N; j++) p[j] = 0.0;
    p[CP_ATOP] = q[CQ_ATOP];
    p[CP_V0] = q[CQ_V0];
    p[CP_V1] = q[CQ_V1];
    if (junction == 0) {
        p[CP_VFEED] = q[CQ_VFEED];
        p[CP_JX] = q[CQ_JX];
        p[CP_JY] = q[CQ_JY];
    } else {
        p[CP_SCV] = q[CQ_SCV];
        p[CP_AXM] = q[CQ_AXM];
        p[CP_AYM] = q[CQ_AYM];
    }
    p[CP_C0] = q[CQ_PUX] * u[0] + q[CQ_PUY] * u[1];
    p[CP_C1] = u[2 * (n - 1)] * q[CQ_NUX] + u[2 * (n - 1) + 1] * q[CQ_NUY];
    if (junction == 0) {
        p[CP_STEP] = step_r * NP_MIN(p[CP_JX], p[CP_JY]);
    } else {
        p[CP_STEP] = INFINITY;
        if (q[CQ_HASP] != 0.0) {
            p[CP_PUX] = q[CQ_PUX];
            p[CP_PUY] = q[CQ_PUY];
            p[CP_HASP] = 1.0;
        }
        if (q[CQ_HASN] != 0.0) {
            p[CP_NUX] = q[CQ_NUX];
            p[CP_NUY] = q[CQ_NUY];
            p[CP_HASN] = 1.0;
        }
    }
}

static void win_sums(Py_ssize_t no, Py_ssize_t nb, const double *restrict x, double *restrict out);

/* a chain's n - 1 turn cosines ct and (nb > 0) its n lookahead windows w of nb lengths (the
   lengths d, then nb copies of the last: ext, n + nb doubles), as turn_cosines and
   window_sums (win_sums itself) make them */
static void cf_turns_windows(Py_ssize_t n, const double *restrict d, const double *restrict u, Py_ssize_t nb,
                             double *restrict ct, double *restrict ext, double *restrict w) {
    for (Py_ssize_t i = 0; i + 1 < n; i++) {
        const double *x = u + 2 * i;
        ct[i] = (0.0 + x[0] * x[2]) + x[1] * x[3];
    }
    if (nb > 0) {
        memcpy(ext, d, (size_t)n * sizeof(double));
        for (Py_ssize_t j = 0; j < nb; j++) ext[n + j] = d[n - 1];
        win_sums(n, nb, ext, w);
    }
}

static PyObject *chain_finish_ragged(PyObject *self, PyObject *args) {
    (void)self;
    int junction, predict;
    Py_ssize_t nb;
    double step_r;
    PyObject *oown, *ocoff, *ovk, *otk, *oD, *oU, *oQ, *og, *oK, *oacc, *ofeed, *ot, *oa2, *ofits;
    if (!PyArg_ParseTuple(args, "iindOOOOOOOOOOOOOO", &junction, &predict, &nb, &step_r, &oown, &ocoff, &ovk,
                          &otk, &oD, &oU, &oQ, &og, &oK, &oacc, &ofeed, &ot, &oa2, &ofits))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t R, M1, Nvk, Ntk, ND, NU, NQ, G, NK, Nacc, Nfeed, Nt, Na2, Nf;
    int64_t *own = get(&b, oown, 8, 0, &R);
    int64_t *coff = own ? get(&b, ocoff, 8, 0, &M1) : NULL;
    double *vk = coff ? get(&b, ovk, 8, 0, &Nvk) : NULL;
    double *tk = vk ? get(&b, otk, 8, 0, &Ntk) : NULL;
    double *D = tk ? get(&b, oD, 8, 0, &ND) : NULL;
    double *U = D ? get(&b, oU, 8, 0, &NU) : NULL;
    double *Q = U ? get(&b, oQ, 8, 0, &NQ) : NULL;
    double *grid = Q ? get(&b, og, 8, 0, &G) : NULL;
    double *K = grid ? get(&b, oK, 8, 0, &NK) : NULL;
    double *acc = K ? get(&b, oacc, 8, 1, &Nacc) : NULL;
    double *feed = acc ? get(&b, ofeed, 8, 1, &Nfeed) : NULL;
    double *tout = feed ? get(&b, ot, 8, 1, &Nt) : NULL;
    double *a2out = tout ? get(&b, oa2, 8, 1, &Na2) : NULL;
    uint8_t *fits = a2out ? get(&b, ofits, 1, 1, &Nf) : NULL;
    if (!fits) { release(&b); return NULL; }
    const Py_ssize_t m = M1 - 1;
    int shapes = m >= 1 && R >= 1 && coff[0] == 0 && coff[m] == ND && NU == 2 * ND && NQ == m * CF_Q &&
                 NK == CK_N && G >= 1 && Nt == R && Na2 == R && Nf == R && nb >= 0 && nb <= (1 << 20) &&
                 junction >= 0 && junction <= 2;
    Py_ssize_t nmax = 0, sn = 0, sn1 = 0;
    for (Py_ssize_t c = 0; c < m && shapes; c++) {
        Py_ssize_t n = coff[c + 1] - coff[c];
        shapes = n >= 1 && n <= ND;
        nmax = n > nmax ? n : nmax;
    }
    for (Py_ssize_t r = 0; r < R && shapes; r++) {
        shapes = own[r] >= 0 && own[r] < m;
        if (shapes) {
            Py_ssize_t n = coff[own[r] + 1] - coff[own[r]];
            sn += n;
            sn1 += n + 1;
        }
    }
    if (!shapes || Ntk != sn || Nvk != sn1 || Nacc != sn || Nfeed != sn) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "chain_finish_ragged: shapes");
        return NULL;
    }
    int ok = all_finite(Nvk, vk) && all_finite(Ntk, tk) && G == CF_TRAP_G;
    double p[CP_N];
    for (Py_ssize_t c = 0; c < m && ok; c++) {       /* (every chain's, as chain_finish checks its groups') */
        cf_p_of(junction, step_r, Q + c * CF_Q, U + 2 * coff[c], coff[c + 1] - coff[c], p);
        ok = cf_p_ok(p, junction);
    }
    if (!ok) { release(&b); Py_RETURN_FALSE; }
    /* work space of cf_row, and the chain's own turn cosines, lengths extended and windows */
    double *wk = malloc(sizeof(double) * (size_t)(23 * (nmax + 2) + nb));
    if (!wk) { release(&b); return PyErr_NoMemory(); }
    double *ct = wk + 20 * (nmax + 2), *w = ct + (nmax + 2), *ext = w + (nmax + 2);
    Py_ssize_t at = 0, last = -1;           /* the row's first segment in tk; the chain of p, ct, w */
    for (Py_ssize_t r = 0; r < R && ok; r++) {
        const Py_ssize_t c = (Py_ssize_t)own[r], n = coff[c + 1] - coff[c];
        const double *d = D + coff[c], *u = U + 2 * coff[c];
        if (c != last) {
            cf_p_of(junction, step_r, Q + c * CF_Q, u, n, p);
            cf_turns_windows(n, d, u, nb, ct, ext, w);
            last = c;
        }
        ok = cf_row(junction, predict, n, p, d, u, ct, nb > 0 ? w : NULL, vk + at + r, tk + at, grid, K,
                          acc + at, feed + at, tout + r, a2out + r, fits + r, wk);
        at += n;
    }
    free(wk);
    release(&b);
    return PyBool_FromLong(ok);
}

/* ---------------------------------------------------------------- session 22 (chainlaw)
   row_sums(x, off, out): out[c] = np.sum(x[off[c]:off[c + 1]]) (numpy's pairwise sum of
   each contiguous run, np_pairwise_sum; 0.0 for an empty run, as numpy's empty sum): the row
   sums _flat_figures made per piece count with np.sum(x[ix], axis=1). */
static PyObject *row_sums(PyObject *self, PyObject *a) {
    PyObject *ox, *ooff, *oout;
    if (!PyArg_ParseTuple(a, "OOO", &ox, &ooff, &oout)) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t P, nc1, no;
    double *x = get(&b, ox, 8, 0, &P);
    int64_t *off = x ? get(&b, ooff, 8, 0, &nc1) : NULL;
    double *out = off ? get(&b, oout, 8, 1, &no) : NULL;
    if (!out) { release(&b); return NULL; }
    int ok = nc1 >= 1 && no == nc1 - 1;
    for (Py_ssize_t c = 0; ok && c + 1 < nc1; c++) ok = off[c] >= 0 && off[c + 1] >= off[c] && off[c + 1] <= P;
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "row_sums: offsets");
        return NULL;
    }
    for (Py_ssize_t c = 0; c + 1 < nc1; c++) {
        Py_ssize_t n = (Py_ssize_t)(off[c + 1] - off[c]);
        out[c] = n ? np_pairwise_sum(x + off[c], n) : 0.0;
    }
    release(&b);
    Py_RETURN_NONE;
}

/* step_accels(T, n, sh2, ch, A, d, a0, a1): LineLaw.end_accels of series-branch laws,
   element by element, its operations in its order: gp0 = 0.5 sh2 / n, hp = 2 cosh(γ/2) / sh2
   (ch = np.cosh(0.5 γ), made by numpy), T2 = T T, a0 = (A gp0 - d hp) / T2,
   a1 = (-A gp0 - d hp) / T2. */
VEC_CLONES static void accels_vec(Py_ssize_t N, const double *restrict T, const double *restrict n,
                                  const double *restrict sh2, const double *restrict ch, const double *restrict A,
                                  const double *restrict d, double *restrict a0, double *restrict a1) {
    for (Py_ssize_t i = 0; i < N; i++) {
        double gp0 = (0.5 * sh2[i]) / n[i];
        double hp = (2.0 * ch[i]) / sh2[i];
        double T2 = T[i] * T[i];
        double x = A[i] * gp0, y = d[i] * hp;
        a0[i] = (x - y) / T2;
        a1[i] = ((-A[i]) * gp0 - y) / T2;
    }
}

static PyObject *step_accels(PyObject *self, PyObject *a) {
    PyObject *o[8];
    if (!PyArg_ParseTuple(a, "OOOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7])) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t nn[8];
    double *p[8];
    for (int q = 0; q < 8; q++) {
        p[q] = get(&b, o[q], 8, q >= 6, &nn[q]);
        if (!p[q]) { release(&b); return NULL; }
    }
    for (int q = 1; q < 8; q++)
        if (nn[q] != nn[0]) {
            release(&b);
            PyErr_SetString(PyExc_ValueError, "step_accels: shapes");
            return NULL;
        }
    accels_vec(nn[0], p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]);
    release(&b);
    Py_RETURN_NONE;
}

/* step_law(L, T, beta, va, vb, coef, zmax, gamma, gs, n, wbar, delta, A) -> 0, or 1 (nothing
   usable written: laws/chain._step_law's numpy code runs) on an input LineLaw refuses
   (T not finite and > 0, β not > 0, L, v0, v1 not finite) or a γ not below GAMMA_SWITCH.
   _step_law's numbers, element by element, its operations in its order: γ = T / √β,
   gs = γ (np.minimum(γ, GAMMA_SWITCH) of a γ below it), n by Horner on the first column of
   coef (the _NMS_COEF rows) with the terms _nms_terms gives the batch's largest γ², wbar =
   T (v0 + v1) / 2, δ = T (v0 - v1) / 2, A = L - wbar.  (shc(γ/2) is numpy's: np.sinh.) */
VEC_CLONES static int steplaw_args(Py_ssize_t N, const double *restrict L, const double *restrict T,
                                   const double *restrict beta, const double *restrict va,
                                   const double *restrict vb, double *restrict g, int64_t *gmax) {
    int bad = 0;
    int64_t gb = 0;
    for (Py_ssize_t i = 0; i < N; i++) {
        double t = T[i], bt = beta[i];
        double gi = t / sqrt(bt);
        g[i] = gi;
        bad |= !(t > 0.0) | !(t < HUGE_VAL) | !(bt > 0.0) | !(fabs(L[i]) < HUGE_VAL) | !(fabs(va[i]) < HUGE_VAL)
               | !(fabs(vb[i]) < HUGE_VAL) | !(gi < GAMMA_SWITCH);
        int64_t b0;
        memcpy(&b0, &gi, 8);
        gb = b0 > gb ? b0 : gb;
    }
    *gmax = gb;
    return bad;
}

/* The first nser series of the _NMS_COEF rows (coef, 3 a term; out[s]: series s) at γ² of
   the N laws g, k terms by Horner from the last: blocks of 8 laws with the terms outside
   and the laws inside, held in registers (SIMD lanes: each law's operations in its order,
   x = x γ² then x = x + c; the last block padded with zeros, not written).  A macro, not
   a function: a call from a vector clone is not inlined (see P_CUBE). */
#define NMS_HORNER8(N, k, coef, g, nser, out)                                                      \
    for (Py_ssize_t i0_ = 0; i0_ < (N); i0_ += 8) {                                                \
        Py_ssize_t nb_ = (N) - i0_ < 8 ? (N) - i0_ : 8;                                            \
        double gt_[8], z2_[8], x_[3][8];                                                           \
        const double *gb_ = (g) + i0_;                                                             \
        if (nb_ < 8) {                                                                             \
            for (int jj = 0; jj < 8; jj++) gt_[jj] = jj < nb_ ? gb_[jj] : 0.0;                    \
            gb_ = gt_;                                                                             \
        }                                                                                          \
        for (int jj = 0; jj < 8; jj++) z2_[jj] = gb_[jj] * gb_[jj];                               \
        for (int s_ = 0; s_ < (nser); s_++)                                                        \
            for (int jj = 0; jj < 8; jj++) x_[s_][jj] = (coef)[3 * ((k) - 1) + s_];               \
        for (int q_ = (k) - 2; q_ >= 0; q_--)                                                      \
            for (int s_ = 0; s_ < (nser); s_++) {                                                  \
                double a_ = (coef)[3 * q_ + s_];                                                   \
                for (int jj = 0; jj < 8; jj++) {                                                   \
                    double p_ = x_[s_][jj] * z2_[jj];                                              \
                    x_[s_][jj] = p_ + a_;                                                          \
                }                                                                                  \
            }                                                                                      \
        for (int s_ = 0; s_ < (nser); s_++)                                                        \
            for (int jj = 0; jj < nb_; jj++) (out)[s_][i0_ + jj] = x_[s_][jj];                     \
    }

VEC_CLONES static void steplaw_rest(Py_ssize_t N, int k, const double *restrict coef, const double *restrict L,
                                    const double *restrict T, const double *restrict va, const double *restrict vb,
                                    const double *restrict g, double *restrict gs, double *restrict n,
                                    double *restrict wbar, double *restrict dl, double *restrict A) {
    double *out[1] = {n};
    NMS_HORNER8(N, k, coef, g, 1, out);
    for (Py_ssize_t i = 0; i < N; i++) {
        double z = g[i];
        gs[i] = z;
        double w = (T[i] * (va[i] + vb[i])) / 2;
        wbar[i] = w;
        dl[i] = (T[i] * (va[i] - vb[i])) / 2;
        A[i] = L[i] - w;
    }
}

/* step_law and fig_a's arguments: nargs buffers of doubles (the outputs from index 7 on),
   all of one length but the series table (5, at least 3 NTERMS long) and its term limits
   (6).  Returns 0 with an exception set (the buffers released) or 1. */
static int law_args(PyObject *a, int nargs, const char *name, Bufs *b, double **p, Py_ssize_t *nn) {
    if (!PyTuple_Check(a) || PyTuple_GET_SIZE(a) != nargs) {
        PyErr_Format(PyExc_TypeError, "%s takes %d arguments", name, nargs);
        return 0;
    }
    for (int q = 0; q < nargs; q++) {
        p[q] = get(b, PyTuple_GET_ITEM(a, q), 8, q >= 7, &nn[q]);
        if (!p[q]) { release(b); return 0; }
    }
    int ok = nn[5] >= 3 * NTERMS;
    for (int q = 0; q < nargs; q++) ok = ok && (q == 5 || q == 6 || nn[q] == nn[0]);
    if (!ok) {
        release(b);
        PyErr_Format(PyExc_ValueError, "%s: shapes", name);
        return 0;
    }
    return 1;
}

/* the series terms the laws (L, T, sq, va, vb: p[0..4], Tlo/Thi... into p[7]) need: -1 when
   steplaw_args finds a law it does not take, or there is none */
static int law_terms(const Py_ssize_t *nn, double **p) {
    Py_ssize_t N = nn[0];
    int64_t gb;
    if (steplaw_args(N, p[0], p[1], p[2], p[3], p[4], p[7], &gb) || !N)
        return -1;
    double gm;
    memcpy(&gm, &gb, 8);
    return nms_terms(gm * gm, p[6], nn[6], 0);     /* the largest γ²: all γ > 0 here */
}

static PyObject *step_law(PyObject *self, PyObject *a) {
    Bufs b = {.n = 0};
    Py_ssize_t nn[13];
    double *p[13];
    if (!law_args(a, 13, "step_law", &b, p, nn))
        return NULL;
    int k = law_terms(nn, p);
    if (k >= 0)
        steplaw_rest(nn[0], k, p[5], p[0], p[1], p[3], p[4], p[7], p[8], p[9], p[10], p[11], p[12]);
    release(&b);
    return PyLong_FromLong(k < 0);
}

/* tod_prep(T, L, gs, n, sh2, wbar, A, dl, pj, s, <outs: T, gs, n, sh2, wbar, A, dl, target, sgn,
   lo, hi, t, scale, out, act>): laws/chain._tod_core's inputs of the laws pj (law.take(pj)'s
   numbers) in one pass: target = np.clip(s, min(0, L), max(0, L)), sgn, lo = 0, hi = T,
   t = lo + (hi - lo) (L != 0 ? target / L : 0.5), scale = max(|L|, 1e-300), out = t,
   act = 0, 1, ... (numpy's minimum, maximum, clip on their nan and signed-zero rules). */
static PyObject *tod_prep(PyObject *self, PyObject *a) {
    PyObject *o[25];
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOOOOOOOOOOOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6],
                          &o[7], &o[8], &o[9], &o[10], &o[11], &o[12], &o[13], &o[14], &o[15], &o[16], &o[17],
                          &o[18], &o[19], &o[20], &o[21], &o[22], &o[23], &o[24]))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t nn[25];
    void *p[25];
    for (int q = 0; q < 25; q++) {
        p[q] = get(&b, o[q], 8, q >= 10, &nn[q]);
        if (!p[q]) { release(&b); return NULL; }
    }
    Py_ssize_t P = nn[0], N = nn[8];
    int ok = 1;
    for (int q = 1; q < 8; q++) ok = ok && nn[q] == P;
    for (int q = 9; q < 25; q++) ok = ok && nn[q] == N;
    const int64_t *pj = p[8];
    ok = ok && all_in_range(N, pj, P);
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "tod_prep: shapes");
        return NULL;
    }
    const double *T = p[0], *L = p[1], *s = p[9];
    double *const *src = (double *const *)&p[2];          /* gs, n, sh2, wbar, A, dl */
    double *oT = p[10], *target = p[17], *sgn = p[18], *lo = p[19], *hi = p[20], *t = p[21], *scale = p[22];
    double *out = p[23];
    int64_t *act = p[24];
    for (Py_ssize_t i = 0; i < N; i++) {
        int64_t j = pj[i];
        double Ti = T[j], Li = L[j];
        oT[i] = Ti;
        for (int q = 0; q < 6; q++) ((double *)p[11 + q])[i] = src[q][j];
        tod_start(Ti, Li, s[i], i, target, sgn, lo, hi, t, out, scale);
        act[i] = (int64_t)i;
    }
    release(&b);
    Py_RETURN_NONE;
}

/* active_step's multiplier of the binding vertex before piece p + 1 (chain r of the step):
   mug's (binding vertex p - r of the step, in order), else the jump of s̈ over scale, 0
   unless below -mu_tol */
static inline double as_multiplier(const double *mug, const double *a0, const double *a1, int64_t p, Py_ssize_t r,
                                   double scale, double mu_tol) {
    if (mug) return mug[p - r];
    double m = (a0[p + 1] - a1[p]) / scale;
    return m < -mu_tol ? m : 0.0;
}

/* active_step(vi, rank_off, bv, vert_v, cv, a0, a1, koff, mu, hist, cap_f, mu_tol, last, new, done, cyc,
               bound, vt, vert_t, warm, active) -> 0
   One step of laws/chain.solve_flat's active-set bookkeeping, chain by chain (each chain's
   answer is its own: the numpy code's, whole batch at once, gives the same): the step's
   chains r (vertices q at rank_off[r]:rank_off[r + 1] of vi, pieces at koff[r] - r ..
   koff[r + 1] - r - 1), bv (uint8) their binding masks, vert_v their speeds, cv the caps
   (all vertices), a0, a1 the pieces' end accelerations (_Step.multipliers' numbers: the
   scale as numpy's maximum from 0 over |a0| then |a1|, floored at 1e-9; mu = jump / scale,
   0 unless below -mu_tol; mu not None: the multipliers given, per binding vertex in order,
   as _Step.multipliers returns them), hist the binding masks (uint8, all vertices) of the steps so far
   (this one's last; bv None: this step's masks read there, hist[-1][vi], no gather by the caller).
   Writes new (uint8), done, cyc (uint8 per chain) and, for the chains not done, bound[vi] = new,
   vt[vi] = vert_t, warm[active[r]] = 1.  last: out of steps.  res_v, res_t (optional, all
   vertices): for the chains done, res_v[vi] = vert_v, res_t[vi] = vert_t (FlatLaws.take's
   vertices, written here: take then gathers no vertex). */
static PyObject *active_step(PyObject *self, PyObject *a) {
    PyObject *o[20], *omu, *orv = Py_None, *ort = Py_None;
    double cap_f, mu_tol;
    int last;
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOddiOOOOOOOO|OO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &omu, &o[8], &cap_f, &mu_tol, &last, &o[9], &o[10], &o[11], &o[12], &o[13], &o[14],
                          &o[15], &o[16], &orv, &ort))
        return NULL;
    if (!PyList_Check(o[8])) {
        PyErr_SetString(PyExc_TypeError, "active_step: hist must be a list");
        return NULL;
    }
    Py_ssize_t H = PyList_GET_SIZE(o[8]);
    if (H < 1 || H > 64) {
        PyErr_SetString(PyExc_ValueError, "active_step: hist size");
        return NULL;
    }
    Bufs b = {.n = 0};
    Py_ssize_t n, nr1, nbv = -1, nvv, NV, np0, np1, nk1, nnew, ndone, ncyc, nbound, nvt, nvert_t, nwarm, nact;
    Py_ssize_t nrv = -1, nrt = -1;
    const int bv_given = o[2] != Py_None, res_given = orv != Py_None || ort != Py_None;
    int64_t *vi = get(&b, o[0], 8, 0, &n);
    int64_t *roff = vi ? get(&b, o[1], 8, 0, &nr1) : NULL;
    uint8_t *bv = (roff && bv_given) ? get(&b, o[2], 1, 0, &nbv) : NULL;
    double *vv = (bv || (roff && !bv_given)) ? get(&b, o[3], 8, 0, &nvv) : NULL;
    double *cv = vv ? get(&b, o[4], 8, 0, &NV) : NULL;
    double *a0 = cv ? get(&b, o[5], 8, 0, &np0) : NULL;
    double *a1 = a0 ? get(&b, o[6], 8, 0, &np1) : NULL;
    int64_t *koff = a1 ? get(&b, o[7], 8, 0, &nk1) : NULL;
    uint8_t *nw = koff ? get(&b, o[9], 1, 1, &nnew) : NULL;
    uint8_t *done = nw ? get(&b, o[10], 1, 1, &ndone) : NULL;
    uint8_t *cyc = done ? get(&b, o[11], 1, 1, &ncyc) : NULL;
    uint8_t *bound = cyc ? get(&b, o[12], 1, 1, &nbound) : NULL;
    double *vt = bound ? get(&b, o[13], 8, 1, &nvt) : NULL;
    double *vert_t = vt ? get(&b, o[14], 8, 0, &nvert_t) : NULL;
    uint8_t *warm = vert_t ? get(&b, o[15], 1, 1, &nwarm) : NULL;
    int64_t *act = warm ? get(&b, o[16], 8, 0, &nact) : NULL;
    Py_ssize_t nmu = -1;
    double *mug = NULL, *res_v = NULL, *res_t = NULL;
    if (act && omu != Py_None) {
        mug = get(&b, omu, 8, 0, &nmu);
        if (!mug) act = NULL;
    }
    if (act && res_given) {
        res_v = get(&b, orv, 8, 1, &nrv);
        res_t = res_v ? get(&b, ort, 8, 1, &nrt) : NULL;
        if (!res_t) act = NULL;
    }
    if (!act) { release(&b); return NULL; }
    if (!bv_given) nbv = n;
    Py_ssize_t na = nr1 - 1;
    int ok = na >= 0 && nbv == n && nvv == n && nnew == n && nvert_t == n && np1 == np0 && nk1 == nr1
             && ndone == na && ncyc == na && nact == na && nbound == NV && nvt == NV && roff[0] == 0
             && roff[na] == n && koff[0] == 0 && koff[na] - na == np0 && (!res_given || (nrv == NV && nrt == NV));
    for (Py_ssize_t r = 0; ok && r < na; r++)
        ok = roff[r + 1] >= roff[r] && koff[r + 1] - koff[r] >= 1 && act[r] >= 0 && act[r] < nwarm;
    ok = ok && all_in_range(n, vi, NV);
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "active_step: shapes");
        return NULL;
    }
    const uint8_t *hist[64];
    Py_buffer hb[64];
    int nh = 0;
    for (Py_ssize_t h = 0; h < H; h++) {
        if (PyObject_GetBuffer(PyList_GET_ITEM(o[8], h), &hb[h], PyBUF_C_CONTIGUOUS) < 0) break;
        nh++;
        if (hb[h].len != NV) {
            PyErr_SetString(PyExc_ValueError, "active_step: hist shapes");
            break;
        }
        hist[h] = hb[h].buf;
    }
    uint8_t *bvbuf = NULL;
    const uint8_t *cur = NULL;                          /* bv not given: this step's masks, hist[-1] at vi */
    if (nh == H && !PyErr_Occurred() && !bv_given) {
        bvbuf = PyMem_Malloc(n ? n : 1);
        if (!bvbuf) PyErr_NoMemory();
        else {
            cur = hist[H - 1];
            bv = bvbuf;
        }
    }
    PyObject *ret = NULL;                               /* (NULL: an exception set) */
    if (nh < H || PyErr_Occurred()) goto out;
    /* binding vertices per chain = pieces - 1 (bvbuf made in the same pass) */
    Py_ssize_t nbt = 0;
    for (Py_ssize_t r = 0; ok && r < na; r++) {
        Py_ssize_t nb = 0;
        if (cur)
            for (int64_t q = roff[r]; q < roff[r + 1]; q++) {
                uint8_t x = cur[vi[q]] != 0;
                bvbuf[q] = x;
                nb += x;
            }
        else
            for (int64_t q = roff[r]; q < roff[r + 1]; q++) nb += bv[q] != 0;
        ok = nb == koff[r + 1] - koff[r] - 2;
        nbt += nb;
    }
    ok = ok && (mug == NULL || nmu == nbt);
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "active_step: shapes");
        goto out;
    }
    for (Py_ssize_t r = 0; r < na; r++) {
        int64_t q0 = roff[r], q1 = roff[r + 1];
        int64_t p0 = koff[r] - r, p1 = koff[r + 1] - r - 1;        /* pieces p0 .. p1 - 1 */
        /* the largest |a0| and |a1| in one pass: np_max's running maximum of values >= +0 is
           the largest whatever the order; with a nan, the first nan of a0's run, else of a1's,
           as the two runs one after the other give */
        double sc0 = 0.0, sc1 = 0.0;
        for (int64_t p = p0; p < p1; p++) {
            sc0 = np_max(sc0, fabs(a0[p]));
            sc1 = np_max(sc1, fabs(a1[p]));
        }
        double scale = np_max(np_max(sc0, sc1), 1e-9);
        int any_viol = 0, any_neg = 0;
        double mu_min = 0.0;
        int64_t worst = -1;
        int64_t p = p0;                                  /* the piece after the next binding vertex: p + 1 */
        for (int64_t q = q0; q < q1; q++) {
            if (bv[q]) {
                double m = as_multiplier(mug, a0, a1, p, r, scale, mu_tol);
                p++;
                if (m < 0) any_neg = 1;
                if (worst < 0 || m < mu_min) { mu_min = m; worst = q; }
                nw[q] = 1;                               /* binding (released below where rel) */
            } else {
                int viol = vv[q] > cv[vi[q]] * cap_f + 1e-12;
                any_viol |= viol;
                nw[q] = viol;
            }
        }
        int rel = !any_viol && any_neg;
        if (rel) {                                       /* new = bv | viol, less the released: */
            p = p0;                                      /* the negative multipliers' (again, the same m) */
            for (int64_t q = q0; q < q1; q++)
                if (bv[q]) {
                    nw[q] = !(as_multiplier(mug, a0, a1, p, r, scale, mu_tol) < 0);
                    p++;
                }
        }
        int moving = any_viol || any_neg;
        int seen = 0;
        if (rel || moving) {
            for (Py_ssize_t h = 0; h < H && !seen; h++) {
                int same = 1;
                for (int64_t q = q0; q < q1 && same; q++) same = (hist[h][vi[q]] != 0) == (nw[q] != 0);
                seen = same;
            }
        }
        if (rel && seen) {                                /* cycling: release only the worst */
            for (int64_t q = q0; q < q1; q++) nw[q] = bv[q] != 0;
            nw[worst] = 0;
            seen = 0;
            for (Py_ssize_t h = 0; h < H && !seen; h++) {
                int same = 1;
                for (int64_t q = q0; q < q1 && same; q++) same = (hist[h][vi[q]] != 0) == (nw[q] != 0);
                seen = same;
            }
        }
        int cy = moving && seen;
        int dn = !moving || cy;
        if (last) {
            cy = cy || moving;
            dn = 1;
        }
        cyc[r] = (uint8_t)cy;
        done[r] = (uint8_t)dn;
        if (!dn) {
            for (int64_t q = q0; q < q1; q++) {
                bound[vi[q]] = nw[q];
                vt[vi[q]] = vert_t[q];
            }
            warm[act[r]] = 1;
        } else if (res_v) {
            for (int64_t q = q0; q < q1; q++) {
                res_v[vi[q]] = vv[q];
                res_t[vi[q]] = vert_t[q];
            }
        }
    }
    ret = PyLong_FromLong(0);
out:
    for (int h = 0; h < nh; h++) PyBuffer_Release(&hb[h]);
    PyMem_Free(bvbuf);
    release(&b);
    return ret;
}

/* take_blocks(off, done, srcs, outs): FlatLaws.take's gathers of a step's chains done
   (uint8, na) without a mask: block r of every array in srcs (float64, its items
   off[r]:off[r + 1]) copied, the blocks of the chains done end to end in their order, to the
   same place of outs (float64, each the size of those blocks together).  x[np.repeat(done,
   np.diff(off)).astype(bool)] of each x: the same numbers. */
static PyObject *take_blocks(PyObject *self, PyObject *a) {
    PyObject *ooff, *odone, *osrc, *oout;
    if (!PyArg_ParseTuple(a, "OOOO", &ooff, &odone, &osrc, &oout)) return NULL;
    if (!PyTuple_Check(osrc) || !PyTuple_Check(oout) || PyTuple_GET_SIZE(osrc) != PyTuple_GET_SIZE(oout)
        || PyTuple_GET_SIZE(osrc) > 12) {
        PyErr_SetString(PyExc_TypeError, "take_blocks: srcs, outs: tuples of one size (12 at most)");
        return NULL;
    }
    Py_ssize_t k = PyTuple_GET_SIZE(osrc), nr1, na, ns[12], no[12];
    Bufs b = {.n = 0};
    const int64_t *off = get(&b, ooff, 8, 0, &nr1);
    const uint8_t *done = off ? get(&b, odone, 1, 0, &na) : NULL;
    const double *src[12];
    double *out[12];
    int got = done != NULL;
    for (Py_ssize_t j = 0; got && j < k; j++) {
        src[j] = get(&b, PyTuple_GET_ITEM(osrc, j), 8, 0, &ns[j]);
        out[j] = src[j] ? get(&b, PyTuple_GET_ITEM(oout, j), 8, 1, &no[j]) : NULL;
        got = out[j] != NULL;
    }
    if (!got) { release(&b); return NULL; }
    int ok = nr1 == na + 1 && off[0] == 0;
    Py_ssize_t total = 0;
    for (Py_ssize_t r = 0; ok && r < na; r++) {
        ok = off[r + 1] >= off[r];
        if (done[r]) total += off[r + 1] - off[r];
    }
    for (Py_ssize_t j = 0; ok && j < k; j++) ok = ns[j] == off[na] && no[j] == total;
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "take_blocks: shapes");
        return NULL;
    }
    Py_ssize_t w = 0;
    for (Py_ssize_t r = 0; r < na;) {
        if (!done[r]) { r++; continue; }
        Py_ssize_t r1 = r;                  /* a run of chains done: one copy */
        while (r1 < na && done[r1]) r1++;
        Py_ssize_t len = off[r1] - off[r];
        for (Py_ssize_t j = 0; j < k; j++) memcpy(out[j] + w, src[j] + off[r], (size_t)len * sizeof(double));
        w += len;
        r = r1;
    }
    release(&b);
    Py_RETURN_NONE;
}

/* The figures of _flat_figures(full=False) (laws/chain._figure_law, end_speeds, _critical_t,
   eval(t, "v"), peak_speed, min_speed, the per-chain maxima and minima), their arithmetic
   in three C passes, element by element in numpy's operations and order; numpy's sinh and
   arctanh (line._shc, line._atanhc) in between, made by numpy.
   fig_a(L, T, beta, v0, v1, coef, zmax, <outs: gamma, gs, n, m, s1, wbar, delta, A>) -> 0, or 1
   (nothing usable: the numpy code runs) on an input LineLaw refuses or a γ not below
   GAMMA_SWITCH: _figure_law's γ, n, m, S1 (_horner_nms: the batch's terms), wbar, δ, A. */
VEC_CLONES static void fig_a_rest(Py_ssize_t N, int k, const double *restrict coef, const double *restrict L,
                                  const double *restrict T, const double *restrict va, const double *restrict vb,
                                  const double *restrict g, double *restrict gs, double *restrict n,
                                  double *restrict m, double *restrict s1, double *restrict wbar,
                                  double *restrict dl, double *restrict A) {
    double *out[3] = {n, m, s1};
    NMS_HORNER8(N, k, coef, g, 3, out);
    for (Py_ssize_t i = 0; i < N; i++) {
        gs[i] = g[i];
        double wb = (T[i] * (va[i] + vb[i])) / 2;
        wbar[i] = wb;
        dl[i] = (T[i] * (va[i] - vb[i])) / 2;
        A[i] = L[i] - wb;
    }
}

static PyObject *fig_a(PyObject *self, PyObject *a) {
    Bufs b = {.n = 0};
    Py_ssize_t nn[15];
    double *p[15];
    if (!law_args(a, 15, "fig_a", &b, p, nn))
        return NULL;
    int k = law_terms(nn, p);
    if (k >= 0)
        fig_a_rest(nn[0], k, p[5], p[0], p[1], p[3], p[4], p[7], p[8], p[9], p[10], p[11], p[12], p[13], p[14]);
    release(&b);
    return PyLong_FromLong(k < 0);
}

/* fig_b(L, T, gamma, n, m, s1, sh2, wbar, delta, A, <outs: iv, kog, vs, ve, rho, r>): ∫ṡ²
   (integrals()' with _small_coeffs' Ig1, Ih), κ/γ = 2 n / sh2, end_speeds, and _critical_t's
   ρ = -δ / A, r = ρ κ/γ γ. */
VEC_CLONES static void fig_b_vec(Py_ssize_t N, const double *restrict L, const double *restrict T,
                                 const double *restrict g, const double *restrict n, const double *restrict m,
                                 const double *restrict s1, const double *restrict sh2, const double *restrict wbar,
                                 const double *restrict dl, const double *restrict A, double *restrict iv,
                                 double *restrict kog, double *restrict vs, double *restrict ve,
                                 double *restrict rho, double *restrict r) {
    for (Py_ssize_t i = 0; i < N; i++) {
        double ni = n[i], sh = sh2[i], Ai = A[i], di = dl[i], Ti = T[i], Li = L[i], wb = wbar[i];
        double Ig1 = m[i] / ((2 * ni) * ni), Ih = (2 * s1[i]) / (sh * sh);
        iv[i] = ((Li * Li + (Ai * Ai) * Ig1) + (di * di) * Ih) / Ti;
        double kg = (2 * ni) / sh;
        kog[i] = kg;
        double z = Ai * 0.0;
        vs[i] = ((wb + z) - di * -1.0) / Ti;
        ve[i] = ((wb + z) - di * 1.0) / Ti;
        double rh = -di / Ai;
        rho[i] = rh;
        r[i] = (rh * kg) * g[i];
    }
}

/* fig_c's arithmetic of one element (a macro: the vector clones use it): x = ρ κ/γ atc, ±1/2
   where |r| >= 1, nan_to_num, clip; τ, and the arguments of shc */
#define FIG_C_ELEM(Ti_, g_, rho_, kog_, r_, atc_, tau_, za_, zb_, zx_) do {                       \
        double ri = (r_);                                                                          \
        double x = ((rho_) * (kog_)) * (atc_);                                                     \
        double sg = ri > 0 ? 1.0 : (ri < 0 ? -1.0 : ri);          /* np.sign (0 and nan kept) */  \
        x = fabs(ri) >= 1 ? sg * 0.5 : x;                                                          \
        x = isnan(x) ? 0.0 : (isinf(x) ? (x > 0 ? DBL_MAX : -DBL_MAX) : x);     /* nan_to_num */  \
        x = x > -0.5 ? x : -0.5;                                  /* np.clip (no nan left) */     \
        x = x < 0.5 ? x : 0.5;                                                                     \
        double Ti = (Ti_);                                                                         \
        double t = (x + 0.5) * Ti;                                                                 \
        double u = t / Ti;                                                                         \
        u = isnan(u) ? u : (u > 0.0 ? u : 0.0);                                                    \
        u = isnan(u) ? u : (u < 1.0 ? u : 1.0);                                                    \
        (tau_) = u;                                                                                \
        double g = (g_);                                                                           \
        (za_) = (g * u) / 2;                                                                       \
        (zb_) = (g * (1 - u)) / 2;                                                                 \
        (zx_) = g * (u - 0.5);                                                                     \
    } while (0)

/* fig_d's speed at the critical t of one element: eval(t, "v") (g = bub / 2n, h = 2x shx / sh2) */
#define FIG_D_VC(u_, pa_, pb_, shx_, n_, sh2_, wbar_, A_, dl_, T_) ({                               \
        double u = (u_);                                                                           \
        double bub = ((u * (1 - u)) * (pa_)) * (pb_);                                              \
        double g = bub / (2 * (n_));                                                               \
        double h = ((2 * (u - 0.5)) * (shx_)) / (sh2_);                                            \
        (((wbar_) + (A_) * g) - (dl_) * h) / (T_);                                                 \
    })

/* fig_c(T, gs, rho, kog, r, atc, <outs: tau, za, zb, zx>): _critical_t's x (atc = _atanhc(r)),
   nan_to_num, clip, t; eval's τ = clip(t / T, 0, 1) and the arguments of shc: γτ/2,
   γ(1 - τ)/2, γ(τ - 1/2). */
VEC_CLONES static void fig_c_vec(Py_ssize_t N, const double *restrict T, const double *restrict gs,
                                 const double *restrict rho, const double *restrict kog, const double *restrict r,
                                 const double *restrict atc, double *restrict tau, double *restrict za,
                                 double *restrict zb, double *restrict zx) {
    for (Py_ssize_t i = 0; i < N; i++)
        FIG_C_ELEM(T[i], gs[i], rho[i], kog[i], r[i], atc[i], tau[i], za[i], zb[i], zx[i]);
}

/* a tuple of nargs buffers of 8-byte items, the ones from first_out on writable: p, nn */
static int at_args(PyObject *a, int nargs, int first_out, const char *name, Bufs *b, void **p, Py_ssize_t *nn) {
    if (!PyTuple_Check(a) || PyTuple_GET_SIZE(a) != nargs) {
        PyErr_Format(PyExc_TypeError, "%s: arguments", name);
        return 0;
    }
    for (int q = 0; q < nargs; q++) {
        p[q] = get(b, PyTuple_GET_ITEM(a, q), 8, q >= first_out, &nn[q]);
        if (!p[q]) return 0;
    }
    return 1;
}

/* chains' first pieces: poff[0] = 0, poff[nc] = N, each chain at least one piece */
static int chain_offsets_ok(const int64_t *poff, Py_ssize_t nc, Py_ssize_t N) {
    if (nc >= 0 && (poff[0] != 0 || poff[nc] != N))
        return 0;
    for (Py_ssize_t c = 0; c < nc; c++)
        if (poff[c + 1] <= poff[c]) return 0;
    return 1;
}

/* fig_d(tau, pa, pb, shx, n, sh2, wbar, A, delta, T, vs, ve, poff, <outs: peak_v, min_v per
   chain>): eval(t, "v") at the critical t (g = bub / 2n, h = 2x shx / sh2), the candidates'
   max and min (np.maximum.reduce / np.minimum.reduce of (vs, ve, vc)), each chain's
   (np.maximum.reduceat / np.minimum.reduceat over poff: from its first piece, in order). */
static PyObject *fig_d(PyObject *self, PyObject *a) {
    Bufs b = {.n = 0};
    Py_ssize_t nn[15];
    void *pv[15];
    if (!at_args(a, 15, 13, "fig_d", &b, pv, nn)) { release(&b); return NULL; }
    double *p[15];                            /* (typed: the code below steps through them) */
    for (int q = 0; q < 15; q++) p[q] = pv[q];
    Py_ssize_t N = nn[0], nc = nn[12] - 1;
    int ok = nc >= 0 && nn[13] == nc && nn[14] == nc;
    for (int q = 1; q < 12; q++) ok = ok && nn[q] == N;
    const int64_t *poff = (const int64_t *)p[12];
    ok = ok && chain_offsets_ok(poff, nc, N);
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "fig_d: shapes");
        return NULL;
    }
    const double *tau = p[0], *pa = p[1], *pb = p[2], *shx = p[3], *n = p[4], *sh2 = p[5], *wbar = p[6];
    const double *A = p[7], *dl = p[8], *T = p[9], *vs = p[10], *ve = p[11];
    double *pk = p[13], *mn = p[14];
    for (Py_ssize_t c = 0; c < nc; c++) {
        double hi = 0.0, lo = 0.0;
        for (int64_t i = poff[c]; i < poff[c + 1]; i++) {
            double u = tau[i];
            double bub = ((u * (1 - u)) * pa[i]) * pb[i];
            double g = bub / (2 * n[i]);
            double h = ((2 * (u - 0.5)) * shx[i]) / sh2[i];
            double vc = ((wbar[i] + A[i] * g) - dl[i] * h) / T[i];
            double mx = np_max(np_max(vs[i], ve[i]), vc), mi = np_min(np_min(vs[i], ve[i]), vc);
            if (i == poff[c]) { hi = mx; lo = mi; }
            else { hi = np_max(hi, mx); lo = np_min(lo, mi); }
        }
        pk[c] = hi;
        mn[c] = lo;
    }
    release(&b);
    Py_RETURN_NONE;
}

/* ------------------------------------------------------------------ session 43 (chain43)
   The pieces whose speed at the critical t can be a chain's peak or least speed.  fig_d takes
   each chain's maximum and minimum of (vs, ve, vc) over its pieces; a vc strictly below the
   chain's maximum and strictly above its minimum changes neither (the reductions' result is
   the first element of the extreme value, the same whatever smaller elements came before:
   no nan, checked).  fig_need bounds every vc without numpy's arctanh and sinh: their series
   (atanh(r)/r for |r| <= 1/8; sinh(z)/z for |z| <= 1/8: γ <= 1/4) through
   fig_c's and fig_d's arithmetic, then a margin FN_MARGIN (|wbar| + 8|A| + 4|δ|) / T, many
   orders above what the approximations (within ~1e-16 relative of the true functions, as
   numpy's are) can move vc: through τ (|dvc/dτ| <= ~(8|A| + 3|δ|) / T) and through shc (|g|
   <= 1.7, |h| <= 1.1 there).  A piece is needed unless its bound's top is below the largest
   of the chain's end speeds and its pieces' bound bottoms, and its bottom above the least
   of theirs; a piece with γ > 1/4, 1/8 < |r| < 1 (rare) or a value not finite is needed, as every piece of a chain
   whose end speeds are not all finite.  Only the needed pieces' arctanh and sinh are made
   (fig_c_at, fig_d_at): the same peak and least speed bits. */
#define FN_AT_TERMS 10        /* atanh(r)/r = Σ w^j / (2j + 1), w = r² <= 1/64: the rest below 1e-19 */
#define FN_SH_TERMS 6         /* sinh(z)/z = Σ w^j / (2j + 1)!, w = z² <= 1/64: the rest below 1e-20 */
#define FN_R_MAX 0.125        /* |r| above (and below 1: clipped there): the piece needed */
#define FN_G_MAX 0.25         /* γ above: the piece needed (then |z| <= γ / 2 <= 1/8) */
#define FN_MARGIN 1e-9
#define FN_BUF 1024          /* pieces a run of fig_need (its chains whole) */

#define FN_SERIES(w_, c_, nt_) ({                                                                  \
        double w__ = (w_), s_ = (c_)[(nt_) - 1];                                                   \
        for (int q_ = (nt_) - 2; q_ >= 0; q_--) s_ = s_ * w__ + (c_)[q_];                          \
        s_;                                                                                        \
    })

/* each piece's bounds [vlo, vhi] of vc (-inf, inf: none), and tp, bt: the largest and least
   of vs, ve and the bound's bottom, top (nan: an end speed not finite) */
VEC_CLONES static void need_bounds(Py_ssize_t N, const double *restrict T, const double *restrict gs,
                                   const double *restrict rho, const double *restrict kog, const double *restrict r,
                                   const double *restrict n, const double *restrict sh2,
                                   const double *restrict wbar, const double *restrict A, const double *restrict dl,
                                   const double *restrict vs, const double *restrict ve,
                                   const double *restrict cat, const double *restrict csh, double *restrict vlo,
                                   double *restrict vhi, double *restrict tp, double *restrict bt) {
    for (Py_ssize_t i = 0; i < N; i++) {
        double ri = r[i], w = ri * ri;
        double atc = FN_SERIES(w < 0.015625 ? w : 0.015625, cat, FN_AT_TERMS);
        double tau, za, zb, zx;
        FIG_C_ELEM(T[i], gs[i], rho[i], kog[i], ri, atc, tau, za, zb, zx);
        double pa = FN_SERIES(za * za, csh, FN_SH_TERMS), pb = FN_SERIES(zb * zb, csh, FN_SH_TERMS);
        double shx = FN_SERIES(zx * zx, csh, FN_SH_TERMS);
        double vc = FIG_D_VC(tau, pa, pb, shx, n[i], sh2[i], wbar[i], A[i], dl[i], T[i]);
        double mg = (FN_MARGIN * ((fabs(wbar[i]) + 8 * fabs(A[i])) + 4 * fabs(dl[i]))) / T[i];
        double lo = vc - mg, hi = vc + mg, ar = fabs(ri);
        int ok = (gs[i] <= FN_G_MAX) & ((ar <= FN_R_MAX) | (ar >= 1.0)) & (fabs(lo) <= DBL_MAX)
                 & (fabs(hi) <= DBL_MAX);
        lo = ok ? lo : -HUGE_VAL;
        hi = ok ? hi : HUGE_VAL;
        vlo[i] = lo;
        vhi[i] = hi;
        double s = vs[i], e = ve[i];
        int fin = (fabs(s) <= DBL_MAX) & (fabs(e) <= DBL_MAX);
        double mx = s > e ? s : e, mi = s < e ? s : e;
        mx = lo > mx ? lo : mx;
        mi = hi < mi ? hi : mi;
        tp[i] = fin ? mx : NAN;
        bt[i] = mi;
    }
}

/* fig_need(T, gs, rho, kog, r, n, sh2, wbar, delta, A, vs, ve, poff, <outs: idx (int64), rsub>)
   -> k: the needed pieces (ascending) in idx[:k], their r in rsub[:k] (see above) */
static PyObject *fig_need(PyObject *self, PyObject *a) {
    Bufs b = {.n = 0};
    Py_ssize_t nn[15];
    void *pv[15];
    if (!at_args(a, 15, 13, "fig_need", &b, pv, nn)) { release(&b); return NULL; }
    double *p[15];                            /* (typed: the code below steps through them) */
    for (int q = 0; q < 15; q++) p[q] = pv[q];
    Py_ssize_t N = nn[0], nc = nn[12] - 1;
    int ok = nc >= 0 && nn[13] == N && nn[14] == N;
    for (int q = 1; q < 12; q++) ok = ok && nn[q] == N;
    const int64_t *poff = (const int64_t *)p[12];
    ok = ok && chain_offsets_ok(poff, nc, N);
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "fig_need: shapes");
        return NULL;
    }
    const double *r = p[4];
    int64_t *idx = (int64_t *)p[13];
    double *rsub = p[14];
    double cat[FN_AT_TERMS], csh[FN_SH_TERMS], f = 1.0;
    for (int q = 0; q < FN_AT_TERMS; q++) cat[q] = 1.0 / (2 * q + 1);
    for (int q = 0; q < FN_SH_TERMS; q++) {
        csh[q] = 1.0 / f;                             /* 1 / (2q + 1)! */
        f *= (2 * q + 2) * (2 * q + 3);
    }
    /* runs of whole chains of at most FN_BUF pieces at a time, their bounds in the stack's
       buffers (no heap block: a large one freed raises glibc's mmap threshold, and the next
       ones then stay resident); a chain of more pieces: all needed */
    double vlo[FN_BUF], vhi[FN_BUF], tp[FN_BUF], bt[FN_BUF];
    Py_ssize_t k = 0;
    for (Py_ssize_t c0 = 0; c0 < nc;) {
        int64_t q0 = poff[c0];
        Py_ssize_t c1 = c0;
        while (c1 < nc && poff[c1 + 1] - q0 <= FN_BUF) c1++;
        if (c1 == c0) {                               /* one chain longer than the buffers */
            for (int64_t i = q0; i < poff[c0 + 1]; i++) {
                idx[k] = i;
                rsub[k++] = r[i];
            }
            c0++;
            continue;
        }
        need_bounds(poff[c1] - q0, p[0] + q0, p[1] + q0, p[2] + q0, p[3] + q0, r + q0, p[5] + q0, p[6] + q0,
                    p[7] + q0, p[9] + q0, p[8] + q0, p[10] + q0, p[11] + q0, cat, csh, vlo, vhi, tp, bt);
        for (Py_ssize_t c = c0; c < c1; c++) {
            int64_t p0 = poff[c] - q0, p1 = poff[c + 1] - q0;
            double top = tp[p0], bot = bt[p0];         /* the largest lower bound, the least upper one */
            int fin = top == top;
            for (int64_t i = p0 + 1; i < p1; i++) {
                double t = tp[i], u = bt[i];
                fin &= t == t;
                top = t > top ? t : top;
                bot = u < bot ? u : bot;
            }
            for (int64_t i = p0; i < p1; i++) {
                if (fin && vhi[i] < top && vlo[i] > bot) continue;
                idx[k] = q0 + i;
                rsub[k++] = r[q0 + i];
            }
        }
        c0 = c1;
    }
    release(&b);
    return PyLong_FromSsize_t(k);
}

/* the k needed pieces idx (int64, ascending) of fig_need and their atc: fig_c of those
   (fig_c_at(idx, T, gs, rho, kog, r, atc_k, <outs: tau, za, zb, zx of k>); the full arrays
   read at idx) and fig_d with only their vc (fig_d_at(idx, tau, pa, pb, shx of k, n, sh2,
   wbar, A, delta, T, vs, ve, poff, <outs: peak_v, min_v>): the others' vc left out) */

static PyObject *fig_c_at(PyObject *self, PyObject *a) {
    Bufs b = {.n = 0};
    Py_ssize_t nn[11];
    void *p[11];
    if (!at_args(a, 11, 0, "fig_c_at", &b, p, nn)) { release(&b); return NULL; }
    Py_ssize_t k = nn[0], N = nn[1];
    int ok = 1;
    for (int q = 2; q < 6; q++) ok = ok && nn[q] == N;
    for (int q = 6; q < 11; q++) ok = ok && nn[q] == k;
    const int64_t *idx = p[0];
    for (Py_ssize_t j = 0; ok && j < k; j++) ok = idx[j] >= 0 && idx[j] < N;
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "fig_c_at: shapes");
        return NULL;
    }
    const double *T = p[1], *gs = p[2], *rho = p[3], *kog = p[4], *r = p[5], *atc = p[6];
    double *tau = p[7], *za = p[8], *zb = p[9], *zx = p[10];
    for (Py_ssize_t j = 0; j < k; j++) {
        int64_t i = idx[j];
        FIG_C_ELEM(T[i], gs[i], rho[i], kog[i], r[i], atc[j], tau[j], za[j], zb[j], zx[j]);
    }
    release(&b);
    Py_RETURN_NONE;
}

static PyObject *fig_d_at(PyObject *self, PyObject *a) {
    Bufs b = {.n = 0};
    Py_ssize_t nn[16];
    void *p[16];
    if (!at_args(a, 16, 0, "fig_d_at", &b, p, nn)) { release(&b); return NULL; }
    Py_ssize_t k = nn[0], N = nn[5], nc = nn[13] - 1;
    int ok = nc >= 0 && nn[14] == nc && nn[15] == nc;
    for (int q = 1; q < 5; q++) ok = ok && nn[q] == k;
    for (int q = 5; q < 13; q++) ok = ok && nn[q] == N;
    const int64_t *idx = p[0], *poff = p[13];
    ok = ok && chain_offsets_ok(poff, nc, N);
    for (Py_ssize_t j = 0; ok && j < k; j++) ok = idx[j] >= 0 && idx[j] < N && (j == 0 || idx[j] > idx[j - 1]);
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "fig_d_at: shapes");
        return NULL;
    }
    const double *tau = p[1], *pa = p[2], *pb = p[3], *shx = p[4], *n = p[5], *sh2 = p[6], *wbar = p[7];
    const double *A = p[8], *dl = p[9], *T = p[10], *vs = p[11], *ve = p[12];
    double *pk = p[14], *mn = p[15];
    Py_ssize_t j = 0;
    for (Py_ssize_t c = 0; c < nc; c++) {
        double hi = 0.0, lo = 0.0;
        for (int64_t i = poff[c]; i < poff[c + 1]; i++) {
            double mx = np_max(vs[i], ve[i]), mi = np_min(vs[i], ve[i]);
            if (j < k && idx[j] == i) {
                double vc = FIG_D_VC(tau[j], pa[j], pb[j], shx[j], n[i], sh2[i], wbar[i], A[i], dl[i], T[i]);
                mx = np_max(mx, vc);
                mi = np_min(mi, vc);
                j++;
            }
            if (i == poff[c]) { hi = mx; lo = mi; }
            else { hi = np_max(hi, mx); lo = np_min(lo, mi); }
        }
        pk[c] = hi;
        mn[c] = lo;
    }
    release(&b);
    Py_RETURN_NONE;
}

/* fig_b and fig_c's argument parsing: n inputs then n_out outputs, all the same length */
static PyObject *fig_call(PyObject *a, int nin, int nout, int which) {
    PyObject *o[16];
    Py_ssize_t nargs = PyTuple_GET_SIZE(a);
    if (nargs != nin + nout) {
        PyErr_SetString(PyExc_TypeError, "fig: arguments");
        return NULL;
    }
    Bufs b = {.n = 0};
    Py_ssize_t nn[16];
    double *p[16];
    for (int q = 0; q < nin + nout; q++) {
        o[q] = PyTuple_GET_ITEM(a, q);
        p[q] = get(&b, o[q], 8, q >= nin, &nn[q]);
        if (!p[q]) { release(&b); return NULL; }
        if (nn[q] != nn[0]) {
            release(&b);
            PyErr_SetString(PyExc_ValueError, "fig: shapes");
            return NULL;
        }
    }
    if (which == 0)
        fig_b_vec(nn[0], p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], p[12], p[13],
                  p[14], p[15]);
    else
        fig_c_vec(nn[0], p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9]);
    release(&b);
    Py_RETURN_NONE;
}

/* cf_rows(sts, stroke_type, out) -> 1, or 0 (out then meaningless: chains._cf_row runs
   instead): chains._cf_row of every stroke of the list sts, row q of out (m, 15 doubles):
   _a_top = min(accel, lim.ax_max, lim.ay_max) (Python's min: the first of the least, a
   later one only when below), v_feed, v0, v1, lim's jerk_x, jerk_y, scv, ax_max, ay_max,
   prev_u and next_u (the stroke's _pux, _puy, _nux, _nuy: nan, nan where _pux / _nux is
   None: no neighbour) and whether each is there (1.0 / 0.0); with jd true (cf_rows(sts,
   stroke_type, out, True): chains under Marlin's junction deviation) lim.jd in scv's place.
   Declines (0) a stroke whose
   type is not exactly stroke_type (whose prev_u, next_u are those four slots) or a value
   that is not a Python float (or a subclass): _cf_row's float() of it is then not
   certainly its double.  Each name's attribute is read by its type's data descriptor,
   looked up once a call (a stroke type's, and a limits type's for each new type of lim)
   where the type's getattr is the generic one: what PyObject_GetAttr does first for a
   data descriptor, the same object, without its type-cache lookup a read (~14 reads a
   chain); else by PyObject_GetAttr. */

/* the data descriptors of names[0..n) on type t, all or none (0): where t's getattr is
   PyObject_GenericGetAttr and each name's attribute is a data descriptor (a getset or a
   slot's member: tp_descr_get and tp_descr_set), which the generic getattr returns the
   __get__ of before any instance dict (new references, cf_drop; none taken where 0) */
static int cf_descrs(PyTypeObject *t, PyObject **names, int n, PyObject **out) {
    for (int i = 0; i < n; i++) out[i] = NULL;
    if (t->tp_getattro != PyObject_GenericGetAttr) return 0;
    for (int i = 0; i < n; i++) {
        PyObject *d = _PyType_Lookup(t, names[i]);
        if (!d || !Py_TYPE(d)->tp_descr_get || !Py_TYPE(d)->tp_descr_set) {
            for (int j = 0; j < i; j++) Py_CLEAR(out[j]);
            return 0;
        }
        Py_INCREF(d);
        out[i] = d;
    }
    return 1;
}

static void cf_drop(PyObject **d, int n) {
    for (int i = 0; i < n; i++) Py_CLEAR(d[i]);
}

/* obj.name by its descriptor d (cf_descrs) when there is one, else PyObject_GetAttr */
static inline PyObject *cf_get(PyObject *obj, PyObject *d, PyObject *name) {
    return d ? Py_TYPE(d)->tp_descr_get(d, obj, (PyObject *)Py_TYPE(obj)) : PyObject_GetAttr(obj, name);
}

static PyObject *cf_rows(PyObject *self, PyObject *a) {
    PyObject *sts, *stype, *outo;
    int jd = 0;
    if (!PyArg_ParseTuple(a, "O!OO|p", &PyList_Type, &sts, &stype, &outo, &jd)) return NULL;
    static PyObject *nm[15];
    static const char *names[15] = {"accel", "v_feed", "v0", "v1", "lim", "_pux", "_puy", "_nux", "_nuy",
                                    "jerk_x", "jerk_y", "scv", "ax_max", "ay_max", "jd"};
    for (int i = 0; i < 15; i++)          /* (made once; again where a first try failed) */
        if (!nm[i] && !(nm[i] = PyUnicode_InternFromString(names[i]))) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t len;
    double *out = get(&b, outo, 8, 1, &len);
    if (!out) { release(&b); return NULL; }
    Py_ssize_t m = PyList_GET_SIZE(sts);
    if (len != 15 * m) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "cf_rows: shapes");
        return NULL;
    }
    int ok = 1;
    PyObject *sd[9] = {NULL}, *ld[5] = {NULL};          /* the names' descriptors (NULL: getattr) */
    PyObject *lname[5] = {nm[9], nm[10], jd ? nm[14] : nm[11], nm[12], nm[13]};   /* (jd: in scv's place) */
    PyTypeObject *ltype = NULL;                        /* the type ld is of (held) */
    if (PyType_Check(stype))
        cf_descrs((PyTypeObject *)stype, nm, 9, sd);
    for (Py_ssize_t q = 0; ok && q < m; q++) {
        PyObject *st = PyList_GET_ITEM(sts, q);
        if ((PyObject *)Py_TYPE(st) != stype) { ok = 0; break; }
        double v[15];
        PyObject *lim = NULL;
        /* accel, v_feed, v0, v1 -> v[0..3] (accel to a_top below); lim; the neighbours'
           slots _pux, _puy, _nux, _nuy -> pu[0..3] (None: isnone) */
        double pu[4];
        int isnone[4];
        for (int i = 0; ok && i < 9; i++) {
            PyObject *x = cf_get(st, sd[i], nm[i]);
            if (!x) { PyErr_Clear(); ok = 0; break; }
            if (i == 4) { lim = x; continue; }             /* (a reference kept until its fields are read) */
            if (i >= 5) {
                isnone[i - 5] = x == Py_None;
                if (isnone[i - 5]) { Py_DECREF(x); pu[i - 5] = NAN; continue; }
            }
            if (!PyFloat_Check(x)) { Py_DECREF(x); ok = 0; break; }
            double d = PyFloat_AS_DOUBLE(x);
            Py_DECREF(x);
            if (i < 4) v[i] = d;
            else pu[i - 5] = d;
        }
        double lv[5];                                       /* jerk_x, jerk_y, scv (jd), ax_max, ay_max */
        if (ok && Py_TYPE(lim) != ltype) {
            cf_drop(ld, 5);
            Py_XSETREF(ltype, (PyTypeObject *)Py_NewRef(Py_TYPE(lim)));
            cf_descrs(ltype, lname, 5, ld);
        }
        for (int i = 0; ok && i < 5; i++) {
            PyObject *x = cf_get(lim, ld[i], lname[i]);
            if (!x) { PyErr_Clear(); ok = 0; break; }
            if (!PyFloat_Check(x)) { Py_DECREF(x); ok = 0; break; }
            lv[i] = PyFloat_AS_DOUBLE(x);
            Py_DECREF(x);
        }
        Py_XDECREF(lim);
        if (!ok) break;
        /* prev_u is (_pux, _puy) where _pux is not None, else None: nan, nan (likewise
           next_u); a _puy None beside a _pux is no number (_cf_row raises): declined */
        int has[2];
        for (int e = 0; e < 2; e++) {
            has[e] = !isnone[2 * e];
            if (!has[e]) { pu[2 * e] = NAN; pu[2 * e + 1] = NAN; }
            else if (isnone[2 * e + 1]) ok = 0;
        }
        if (!ok) break;
        double at = v[0];                                   /* min(accel, ax_max, ay_max) */
        if (lv[3] < at) at = lv[3];
        if (lv[4] < at) at = lv[4];
        double *r = out + 15 * q;
        r[0] = at; r[1] = v[1]; r[2] = v[2]; r[3] = v[3];
        r[4] = lv[0]; r[5] = lv[1]; r[6] = lv[2]; r[7] = lv[3]; r[8] = lv[4];
        r[9] = pu[0]; r[10] = pu[1]; r[11] = pu[2]; r[12] = pu[3];
        r[13] = has[0] ? 1.0 : 0.0;
        r[14] = has[1] ? 1.0 : 0.0;
    }
    cf_drop(sd, 9);
    cf_drop(ld, 5);
    Py_XDECREF(ltype);
    release(&b);
    return PyLong_FromLong(ok);
}

/* ---------------------------------------------------------------- session 32 (chainplan)
   window_sums(x, nb, out): out[i] = the sum of x[i], ..., x[i + nb - 1] added left to right
   from 0.0, each term times 1.0: a dot product with ones whose terms are added one after
   the other, which is what np.convolve(x, np.ones(nb), "valid") gives where its dot adds
   them so (numpy's own loop; OpenBLAS's ddot below its vector kernel's block).  chains.
   _window_sums probes that it does, for each nb, before taking these (else np.convolve). */
#define WIN_BLOCK 512       /* windows at a time: their sums stay in L1 while their terms are added */
VEC_CLONES static void win_sums(Py_ssize_t no, Py_ssize_t nb, const double *restrict x, double *restrict out) {
    /* the windows side by side (SIMD lanes), each one's terms added in its order */
    for (Py_ssize_t i0 = 0; i0 < no; i0 += WIN_BLOCK) {
        Py_ssize_t i1 = no - i0 < WIN_BLOCK ? no : i0 + WIN_BLOCK;
        for (Py_ssize_t i = i0; i < i1; i++) out[i] = 0.0;
        for (Py_ssize_t j = 0; j < nb; j++)
            for (Py_ssize_t i = i0; i < i1; i++) out[i] = out[i] + x[i + j] * 1.0;
    }
}

static PyObject *window_sums(PyObject *self, PyObject *a) {
    PyObject *ox, *oo;
    Py_ssize_t nb;
    if (!PyArg_ParseTuple(a, "OnO", &ox, &nb, &oo)) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t n, no;
    const double *x = get(&b, ox, 8, 0, &n);
    double *out = x ? get(&b, oo, 8, 1, &no) : NULL;
    if (!out) { release(&b); return NULL; }
    if (nb < 1 || n < nb || no != n - nb + 1 || (out < x + n && x < out + no)) {     /* (out apart from x) */
        release(&b);
        PyErr_SetString(PyExc_ValueError, "window_sums: shapes");
        return NULL;
    }
    win_sums(no, nb, x, out);
    release(&b);
    Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- session 29 (chainnewton)
   laws/chain._share_time_exact's iteration: Newton on the exact slopes J', J'' of the line
   law's J (laws/chain._exact_slopes: series of G, R, Q and their z-derivatives in z = γ²),
   numpy's operations in its order. */
#define EX_NS 6            /* series: G, R, Q, dG/dz, dR/dz, dQ/dz (a row of coef per term) */
#define EX_BLOCK 8          /* pieces a block of ex_chunk's Horner steps (two vectors; a divisor of CHUNK) */

/* J' (d1) and 1 / J'' (invb; J'' floored as np.maximum(d2, 1e-12 |d1| / T + 1e-300)) of
   n <= CHUNK pieces with k terms of the series (cb: coef's EX_NS a term, each one a vector wide) */
VEC_CLONES static void ex_chunk(Py_ssize_t n, int k, const v4d *restrict cb, const double *restrict T,
                                const double *restrict Lc, const double *restrict bc, const double *restrict vsc,
                                const double *restrict vdc, double *restrict d1b, double *restrict invb) {
    double zb[CHUNK], s0[CHUNK], s1[CHUNK], s2[CHUNK], s3[CHUNK], s4[CHUNK], s5[CHUNK];
    for (Py_ssize_t i = 0; i < n; i++) {
        double t = T[i];
        zb[i] = (t * t) / bc[i];
    }
    Py_ssize_t nb = (n + EX_BLOCK - 1) & ~(Py_ssize_t)(EX_BLOCK - 1);    /* whole blocks, the tail's z 0 */
    for (Py_ssize_t i = n; i < nb; i++) zb[i] = 0.0;
    /* each block's Horner steps in registers (gcc's vectors: two a series), its coefficients
       read as they are added (cb: already a vector wide), not the six series stored and
       loaded a term.  Each element's operations in their order: the same bits. */
    const v4d *cl = cb + EX_NS * (k - 1);
    for (Py_ssize_t i0 = 0; i0 < nb; i0 += EX_BLOCK) {
        v4d z, y, x0 = cl[0], x1 = cl[1], x2 = cl[2], x3 = cl[3], x4 = cl[4], x5 = cl[5];
        v4d y0 = x0, y1 = x1, y2 = x2, y3 = x3, y4 = x4, y5 = x5;
        memcpy(&z, zb + i0, sizeof z);
        memcpy(&y, zb + i0 + 4, sizeof y);
        for (const v4d *c = cl; c != cb;) {         /* the terms k - 2, ..., 0 */
            c -= EX_NS;
            v4d p0 = x0 * z, p1 = x1 * z, p2 = x2 * z, p3 = x3 * z, p4 = x4 * z, p5 = x5 * z;
            v4d q0 = y0 * y, q1 = y1 * y, q2 = y2 * y, q3 = y3 * y, q4 = y4 * y, q5 = y5 * y;
            x0 = p0 + c[0]; x1 = p1 + c[1]; x2 = p2 + c[2]; x3 = p3 + c[3]; x4 = p4 + c[4]; x5 = p5 + c[5];
            y0 = q0 + c[0]; y1 = q1 + c[1]; y2 = q2 + c[2]; y3 = q3 + c[3]; y4 = q4 + c[4]; y5 = q5 + c[5];
        }
        memcpy(s0 + i0, &x0, sizeof z); memcpy(s1 + i0, &x1, sizeof z); memcpy(s2 + i0, &x2, sizeof z);
        memcpy(s3 + i0, &x3, sizeof z); memcpy(s4 + i0, &x4, sizeof z); memcpy(s5 + i0, &x5, sizeof z);
        Py_ssize_t i1 = i0 + 4;
        memcpy(s0 + i1, &y0, sizeof z); memcpy(s1 + i1, &y1, sizeof z); memcpy(s2 + i1, &y2, sizeof z);
        memcpy(s3 + i1, &y3, sizeof z); memcpy(s4 + i1, &y4, sizeof z); memcpy(s5 + i1, &y5, sizeof z);
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        double t = T[i], b = bc[i], vs = vsc[i], vd = vdc[i], z = zb[i];
        double g = s0[i], r = s1[i], q = s2[i], gz = s3[i], rz = s4[i], qz = s5[i];
        double rt = 1.0 / t;
        double rt2 = rt * rt;
        double hv = vs / 2;
        double wb = (t * vs) / 2;
        double A = Lc[i] - wb;
        double bt = b * rt2;
        double zp = (2 * z) * rt;
        double u = wb + A * g;
        double Au = A * u;
        double w = b * (vd * vd);
        double F = (u * u + w * q) + (2 * bt) * (Au * r);
        double up = (hv - hv * g) + A * (gz * zp);
        double Fp = ((2 * u) * up + w * (qz * zp)) + (2 * bt) * (((A * up - hv * u) * r + Au * (rz * zp))
                                                                  - ((2 * Au) * r) * rt);
        double d1 = -F * rt2;
        double d2 = ((2 * F) * rt - Fp) * rt2;
        double fl = (1e-12 * fabs(d1)) * rt + 1e-300;
        d2 = (d2 >= fl || isnan(d2)) ? d2 : fl;          /* np.maximum(d2, fl) */
        d1b[i] = d1;
        invb[i] = 1.0 / d2;
    }
}

/* The largest z = T²/β of pieces [p0, p1) folded into *zm (the bits of z: where no duration
   is bad, every z is >= +0 and not nan -- β is finite and > 0, checked by the caller -- so
   their bits order as their values, as a maximum of the doubles has them), and 1 where a
   duration is not finite and > 0 (*zm then not read) */
VEC_CLONES static int ex_zmax(int64_t p0, int64_t p1, const double *restrict T, const double *restrict beta,
                              int64_t *zm) {
    int bad = 0;
    int64_t m = *zm;
    for (int64_t p = p0; p < p1; p++) {
        double t = T[p], z = (t * t) / beta[p];
        bad |= !(t > 0.0) | !(t < HUGE_VAL);
        int64_t zb;
        memcpy(&zb, &z, 8);
        m = zb > m ? zb : m;
    }
    *zm = m;
    return bad;
}

/* The series terms of a largest z whose bits are zb (>= +0, not nan: ex_zmax's): _exact_terms'
   k = i + 1, i the least with z <= zmax[i] (searchsorted left; nz + 1 where none is).  The
   search starts at k0 - 1 (a chain's terms of its last step, or its neighbour's: a step or
   two from its own), which needs zmax nondecreasing (mono; else k0 = 1: from the start). */
static inline int ex_terms(int64_t zb, const double *zmax, Py_ssize_t nz, int mono, int k0) {
    double z;
    memcpy(&z, &zb, 8);
    Py_ssize_t i = mono && k0 - 1 <= nz ? k0 - 1 : 0;
    while (i > 0 && zmax[i - 1] >= z) i--;
    while (i < nz && zmax[i] < z) i++;
    return (int)(i + 1);
}

/* A chain's n pieces after its step (exact_share's): each one's new duration as kkt_new_T
   makes it (elementwise, in its order: SIMD lanes), from its residual r and 1 / J'' inv and
   the chain's dlam; with ex_zmax's largest z and bad test of the new durations. */
VEC_CLONES static int ex_move(Py_ssize_t n, double *restrict T, const double *restrict r,
                              const double *restrict inv, const double *restrict beta, double dlam, int64_t *zm) {
    int bad = 0;
    int64_t m = *zm;
    for (Py_ssize_t p = 0; p < n; p++) {
        double Ti = T[p], dT = -(r[p] + dlam) * inv[p], lo = -0.5 * Ti;
        double st = dT > lo ? dT : lo;               /* np.clip(dT, -T/2, T): a nan step stays nan */
        st = st < Ti ? st : Ti;
        st = isnan(dT) ? dT : st;
        double tn = Ti + st, z = (tn * tn) / beta[p];
        T[p] = tn;
        bad |= !(tn > 0.0) | !(tn < HUGE_VAL);
        int64_t zb;
        memcpy(&zb, &z, 8);
        m = zb > m ? zb : m;
    }
    *zm = m;
    return bad;
}

/* exact_share(L, beta, vs, vd, poff, npc, T_total, T, lam, conv, coef, zmax, zlim, max_newton)
   -> 0, or -1 (T, lam, conv then meaningless: the caller runs the central differences) where
   a step's duration is not finite and > 0 or its largest z = T²/β is not <= zlim or needs
   more terms than coef has (_exact_terms).  Pieces of chain c at poff[c]:poff[c + 1].  The
   pieces of the chains not converged are not gathered: each run of consecutive such chains
   with the same number of terms is a contiguous range of pieces, and their slopes are made
   there (ex_chunk), in place.  A step's terms: the whole batch's largest z decides whether
   it declines; each chain's own largest z its terms (ex_terms), so a chain's numbers are
   its own whatever chains a call holds (the batch's largest z set every chain's terms
   before: on the gyroid plate's windowed calls, ~500 chains each, 7.9 terms a piece where
   the chains' own need 6.1). */
static PyObject *exact_share(PyObject *self, PyObject *a) {
    PyObject *o[13];
    double zlim;
    int max_newton;
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOOOdi", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &o[9], &o[10], &o[11], &zlim, &max_newton))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t P, nc1, nz, ncoef, nT, nlam, nconv, ntot, nnpc, nb2, nvs, nvd;
    double *L = get(&b, o[0], 8, 0, &P);
    double *beta = L ? get(&b, o[1], 8, 0, &nb2) : NULL;
    double *vs = beta ? get(&b, o[2], 8, 0, &nvs) : NULL;
    double *vd = vs ? get(&b, o[3], 8, 0, &nvd) : NULL;
    int64_t *poff = vd ? get(&b, o[4], 8, 0, &nc1) : NULL;
    double *npc = poff ? get(&b, o[5], 8, 0, &nnpc) : NULL;
    double *Ttot = npc ? get(&b, o[6], 8, 0, &ntot) : NULL;
    double *T = Ttot ? get(&b, o[7], 8, 1, &nT) : NULL;
    double *lam = T ? get(&b, o[8], 8, 1, &nlam) : NULL;
    uint8_t *conv = lam ? get(&b, o[9], 1, 1, &nconv) : NULL;
    double *coef = conv ? get(&b, o[10], 8, 0, &ncoef) : NULL;
    double *zmax = coef ? get(&b, o[11], 8, 0, &nz) : NULL;
    if (!zmax) { release(&b); return NULL; }
    Py_ssize_t n_c = nc1 - 1, nterms = ncoef / EX_NS;
    int ok = n_c >= 0 && nb2 == P && nvs == P && nvd == P && nT == P && nnpc == n_c && ntot == n_c
             && nlam == n_c && nconv == n_c && ncoef % EX_NS == 0 && nz == nterms + 1 && nterms >= 2
             && poff[0] == 0 && poff[n_c] == P;
    for (Py_ssize_t c = 0; ok && c < n_c; c++) ok = poff[c + 1] >= poff[c];
    int mono = 1;                                      /* zmax nondecreasing: ex_terms may start mid-way */
    for (Py_ssize_t i = 1; ok && i < nz; i++) mono &= zmax[i] >= zmax[i - 1];
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "exact_share: shapes");
        return NULL;
    }
    Py_ssize_t PP = P ? P : 1;
    /* per piece: J', then r; 1 / J''; and each coefficient a vector wide, aligned (ex_chunk's
       cb: its additions read them as they are, not broadcast a block) */
    double *work = PyMem_Malloc((2 * PP + 4 * (nterms * EX_NS + 1)) * sizeof(double));
    int *kc = PyMem_Malloc((n_c ? n_c : 1) * sizeof(int));      /* each chain's terms this step */
    if (!work || !kc) { PyMem_Free(work); PyMem_Free(kc); release(&b); return PyErr_NoMemory(); }
    double *d1b = work, *invb = work + PP;
    v4d *cb = (v4d *)(((uintptr_t)(invb + PP) + sizeof(v4d) - 1) & ~(uintptr_t)(sizeof(v4d) - 1));
    for (Py_ssize_t j = 0; j < nterms * EX_NS; j++) {
        double c = coef[j];
        cb[j] = (v4d){c, c, c, c};
    }
    int status = 0;
    /* the active pieces' count m, largest z and bad durations: of every chain not converged
       at the start, then made by the step that moves T (of the chains going on) */
    Py_ssize_t m = 0;
    int bad = 0;
    int64_t zb = 0;                                    /* the bits of the largest z (ex_zmax) */
    int kn = 1;                                        /* the last chain's terms (ex_terms' start) */
    for (Py_ssize_t c = 0; c < n_c; c++) {             /* each chain not converged: its largest z */
        if (conv[c]) continue;
        int64_t zc = 0;
        bad |= ex_zmax(poff[c], poff[c + 1], T, beta, &zc);
        kn = kc[c] = ex_terms(zc, zmax, nz, mono, kn);
        zb = zc > zb ? zc : zb;
        m += poff[c + 1] - poff[c];
    }
    for (int it = 0; it < max_newton; it++) {
        if (m == 0) break;
        if (bad) { status = -1; break; }
        /* the batch's largest z: _exact_terms' decline (above zlim, or more terms than coef has) */
        double zm;
        memcpy(&zm, &zb, 8);
        if (!(zm <= zlim) || ex_terms(zb, zmax, nz, 0, 1) > nterms) { status = -1; break; }
        for (Py_ssize_t c = 0; c < n_c;) {             /* runs of chains not converged, of one k */
            if (conv[c]) { c++; continue; }
            int k = kc[c];
            Py_ssize_t c1 = c + 1;
            while (c1 < n_c && !conv[c1] && kc[c1] == k) c1++;
            for (int64_t j0 = poff[c]; j0 < poff[c1]; j0 += CHUNK) {
                Py_ssize_t n = poff[c1] - j0 < CHUNK ? poff[c1] - j0 : CHUNK;
                ex_chunk(n, k, cb, T + j0, L + j0, beta + j0, vs + j0, vd + j0, d1b + j0, invb + j0);
            }
            c = c1;
        }
        m = 0;
        bad = 0;
        zb = 0;
        for (Py_ssize_t c = 0; c < n_c; c++) {           /* as share_time */
            if (conv[c]) continue;
            int64_t p0 = poff[c], p1 = poff[c + 1];
            double l, dlam;
            if (kkt_chain(T + p0, d1b + p0, invb + p0, p1 - p0, it == 0, lam[c], Ttot[c], npc[c], &l, &dlam)) {
                conv[c] = 1;
                lam[c] = l;
                continue;
            }
            int64_t zc = 0;
            bad |= ex_move(p1 - p0, T + p0, d1b + p0, invb + p0, beta + p0, dlam, &zc);
            kc[c] = ex_terms(zc, zmax, nz, mono, kc[c]);
            zb = zc > zb ? zc : zb;
            m += p1 - p0;
            lam[c] = l + nan_to_num(dlam);
        }
    }
    PyMem_Free(kc);
    PyMem_Free(work);
    release(&b);
    return PyLong_FromLong(status);
}

/* exact_prep's checks and sums over the P pieces, elementwise (SIMD lanes, no early exit):
   vs = va + vb, vd = va - vb; 1 where a β is not finite and > 0 or an L, va, vb not finite */
VEC_CLONES static int prep_vec(Py_ssize_t P, const double *restrict L, const double *restrict beta,
                               const double *restrict va, const double *restrict vb, double *restrict vs,
                               double *restrict vd) {
    int bad = 0;
    for (Py_ssize_t p = 0; p < P; p++) {
        double x = beta[p], a = va[p], c = vb[p];
        bad |= !(x > 0.0) | !(x < HUGE_VAL) | !(fabs(L[p]) < HUGE_VAL) | !(fabs(a) < HUGE_VAL)
               | !(fabs(c) < HUGE_VAL);
        vs[p] = a + c;
        vd[p] = a - c;
    }
    return bad;
}

/* every owner in [0, n_c) and not below the one before it (the first: not below 0) */
VEC_CLONES static int owners_ok(Py_ssize_t P, const int64_t *restrict owner, int64_t n_c) {
    int bad = P > 0 && owner[0] < 0;
    for (Py_ssize_t p = 0; p < P; p++) bad |= owner[p] >= n_c;
    for (Py_ssize_t p = 1; p < P; p++) bad |= owner[p] < owner[p - 1];
    return !bad;
}

/* exact_prep(L, beta, va, vb, owner, vs, vd, poff, npc) -> -1, 0 or 1: _share_time_exact's
   checks and exact_share's inputs in one pass over the P pieces (not ~15 numpy calls a
   solve step).  -1: a β not finite and > 0, or an L, va, vb not finite (the caller
   declines: None); 0: owner not nondecreasing in [0, n_c) (the caller's numpy loop runs;
   nothing usable written); 1: vs = va + vb, vd = va - vb, npc[c] = the pieces of chain c
   (np.bincount's counts, as doubles), poff their offsets (np.cumsum of them after a 0). */
static PyObject *exact_prep(PyObject *self, PyObject *a) {
    PyObject *o[9];
    if (!PyArg_ParseTuple(a, "OOOOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8]))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t P, nb2, nva, nvb, now, nvs, nvd, nc1, nnpc;
    const double *L = get(&b, o[0], 8, 0, &P);
    const double *beta = L ? get(&b, o[1], 8, 0, &nb2) : NULL;
    const double *va = beta ? get(&b, o[2], 8, 0, &nva) : NULL;
    const double *vb = va ? get(&b, o[3], 8, 0, &nvb) : NULL;
    const int64_t *owner = vb ? get(&b, o[4], 8, 0, &now) : NULL;
    double *vs = owner ? get(&b, o[5], 8, 1, &nvs) : NULL;
    double *vd = vs ? get(&b, o[6], 8, 1, &nvd) : NULL;
    int64_t *poff = vd ? get(&b, o[7], 8, 1, &nc1) : NULL;
    double *npc = poff ? get(&b, o[8], 8, 1, &nnpc) : NULL;
    if (!npc) { release(&b); return NULL; }
    Py_ssize_t n_c = nc1 - 1;
    if (nb2 != P || nva != P || nvb != P || now != P || nvs != P || nvd != P || n_c < 0 || nnpc != n_c) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "exact_prep: shapes");
        return NULL;
    }
    if (prep_vec(P, L, beta, va, vb, vs, vd)) { release(&b); return PyLong_FromLong(-1); }
    if (!owners_ok(P, owner, n_c)) { release(&b); return PyLong_FromLong(0); }
    for (Py_ssize_t c = 0; c < n_c; c++) npc[c] = 0.0;
    for (Py_ssize_t p = 0; p < P; p++) npc[owner[p]] += 1.0;
    poff[0] = 0;
    for (Py_ssize_t c = 0; c < n_c; c++) poff[c + 1] = poff[c] + (int64_t)npc[c];
    release(&b);
    return PyLong_FromLong(1);
}

/* step_vertices(active, voff, bound, vi, rank, bvoff, bv) -> n, or -1 where active is not
   strictly ascending in [0, chains): solve_fixed's vertices of the chains active, one pass:
   vi[:n] the active chains' vertices in order (chain c's at voff[c]:voff[c + 1]), rank[:n]
   the place in active of each one's chain, bvoff[r] the first of chain active[r]'s in vi
   (bvoff[na] = n), bv[:n] = bound[vi] (uint8).  vi, rank, bv hold at least the vertices of
   every chain. */
static PyObject *step_vertices(PyObject *self, PyObject *a) {
    PyObject *o[7];
    if (!PyArg_ParseTuple(a, "OOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6])) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t na, nc1, nb, nvi, nrk, nbo, nbv;
    const int64_t *active = get(&b, o[0], 8, 0, &na);
    const int64_t *voff = active ? get(&b, o[1], 8, 0, &nc1) : NULL;
    const uint8_t *bound = voff ? get(&b, o[2], 1, 0, &nb) : NULL;
    int64_t *vi = bound ? get(&b, o[3], 8, 1, &nvi) : NULL;
    int64_t *rank = vi ? get(&b, o[4], 8, 1, &nrk) : NULL;
    int64_t *bvoff = rank ? get(&b, o[5], 8, 1, &nbo) : NULL;
    uint8_t *bv = bvoff ? get(&b, o[6], 1, 1, &nbv) : NULL;
    if (!bv) { release(&b); return NULL; }
    Py_ssize_t m = nc1 - 1;
    int ok = m >= 0 && voff[0] == 0 && voff[m] == nb && nvi >= nb && nrk >= nb && nbv >= nb && nbo == na + 1;
    for (Py_ssize_t c = 0; ok && c < m; c++) ok = voff[c + 1] >= voff[c];
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "step_vertices: shapes");
        return NULL;
    }
    for (Py_ssize_t r = 0; r < na; r++)
        if (active[r] < 0 || active[r] >= m || (r && active[r] <= active[r - 1])) {
            release(&b);
            return PyLong_FromLong(-1);
        }
    Py_ssize_t n = 0;
    for (Py_ssize_t r = 0; r < na; r++) {
        bvoff[r] = n;
        for (int64_t q = voff[active[r]]; q < voff[active[r] + 1]; q++) {
            vi[n] = q;
            rank[n] = r;
            bv[n] = bound[q];
            n++;
        }
    }
    bvoff[na] = n;
    release(&b);
    return PyLong_FromSsize_t(n);
}

/* knot_times(Tj, koff, kt): solve_fixed's knot times, each chain's [0, running sums of its
   pieces' durations] (its piece_cumsum and the scatter to the knots after each chain's
   first: out[0] = x[0], out[i] = out[i - 1] + x[i]), written to kt at koff[r]:koff[r + 1]
   (chain r's pieces at koff[r] - r: a chain has one piece less than knots). */
static PyObject *knot_times(PyObject *self, PyObject *a) {
    PyObject *ot, *ok, *oo;
    if (!PyArg_ParseTuple(a, "OOO", &ot, &ok, &oo)) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t P, nc1, K;
    const double *Tj = get(&b, ot, 8, 0, &P);
    const int64_t *koff = Tj ? get(&b, ok, 8, 0, &nc1) : NULL;
    double *kt = koff ? get(&b, oo, 8, 1, &K) : NULL;
    if (!kt) { release(&b); return NULL; }
    int ok_ = nc1 >= 1 && koff[0] == 0 && koff[nc1 - 1] == K && K - (nc1 - 1) == P;
    for (Py_ssize_t r = 0; ok_ && r + 1 < nc1; r++) ok_ = koff[r + 1] > koff[r];
    if (!ok_) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "knot_times: offsets");
        return NULL;
    }
    for (Py_ssize_t r = 0; r + 1 < nc1; r++) {
        int64_t k0 = koff[r], k1 = koff[r + 1];
        const double *x = Tj + (k0 - r);
        kt[k0] = 0.0;
        if (k1 - k0 < 2) continue;
        double s = x[0];
        kt[k0 + 1] = s;
        for (int64_t k = k0 + 2; k < k1; k++) {
            s = s + x[k - k0 - 1];
            kt[k] = s;
        }
    }
    release(&b);
    Py_RETURN_NONE;
}

/* vert_prep(vi, bv, kj, rank, cv, sv, ks, kt, v, t, free, pj, x) -> nf: solve_fixed's
   vertices before their time of distance, one pass over the step's n vertices q: v[q] =
   cv[vi[q]] (the cap: exact at a binding vertex), t[q] = kt[kj[q]] (its piece's start
   knot's time); the free ones (bv[q] == 0, in order) listed in free[:nf], with pj their
   piece (kj[q] - rank[q]) and x their distance into it (sv[vi[q]] - ks[kj[q]]). */
static PyObject *vert_prep(PyObject *self, PyObject *a) {
    PyObject *o[13];
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8],
                          &o[9], &o[10], &o[11], &o[12]))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t n, nbv, nkj, nrk, ncv, nsv, nks, nkt, nv, nt, nfr, npj, nx;
    const int64_t *vi = get(&b, o[0], 8, 0, &n);
    const uint8_t *bv = vi ? get(&b, o[1], 1, 0, &nbv) : NULL;
    const int64_t *kj = bv ? get(&b, o[2], 8, 0, &nkj) : NULL;
    const int64_t *rank = kj ? get(&b, o[3], 8, 0, &nrk) : NULL;
    const double *cv = rank ? get(&b, o[4], 8, 0, &ncv) : NULL;
    const double *sv = cv ? get(&b, o[5], 8, 0, &nsv) : NULL;
    const double *ks = sv ? get(&b, o[6], 8, 0, &nks) : NULL;
    const double *kt = ks ? get(&b, o[7], 8, 0, &nkt) : NULL;
    double *v = kt ? get(&b, o[8], 8, 1, &nv) : NULL;
    double *t = v ? get(&b, o[9], 8, 1, &nt) : NULL;
    int64_t *fr = t ? get(&b, o[10], 8, 1, &nfr) : NULL;
    int64_t *pj = fr ? get(&b, o[11], 8, 1, &npj) : NULL;
    double *x = pj ? get(&b, o[12], 8, 1, &nx) : NULL;
    if (!x) { release(&b); return NULL; }
    int ok = nbv == n && nkj == n && nrk == n && nv == n && nt == n && nfr == n && npj == n && nx == n
             && ncv == nsv && nks == nkt;
    ok = ok && all_in_range(n, vi, ncv) && all_in_range(n, kj, nks);
    if (!ok) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "vert_prep: shapes");
        return NULL;
    }
    Py_ssize_t nf = 0;
    for (Py_ssize_t q = 0; q < n; q++) {
        int64_t i = vi[q], k = kj[q];
        v[q] = cv[i];
        t[q] = kt[k];
        if (bv[q]) continue;
        fr[nf] = q;
        pj[nf] = k - rank[q];
        x[nf] = sv[i] - ks[k];
        nf++;
    }
    release(&b);
    return PyLong_FromSsize_t(nf);
}

static PyObject *fig_b(PyObject *self, PyObject *a) { return fig_call(a, 10, 6, 0); }
static PyObject *fig_c(PyObject *self, PyObject *a) { return fig_call(a, 6, 4, 1); }

static PyObject *turn_cosines(PyObject *self, PyObject *a);      /* (session 38, replay: at the end) */
static PyObject *ask_memos(PyObject *self, PyObject *a);         /* (session 39, replay: at the end) */
static PyObject *remember_plans(PyObject *self, PyObject *a);    /* (session 39, replay: at the end) */
static PyObject *sort_asks(PyObject *self, PyObject *a);         /* (session 39, replay: at the end) */
static PyObject *drop_items(PyObject *self, PyObject *a);        /* (session 39, replay: at the end) */

static PyMethodDef methods[] = {
    {"turn_cosines", turn_cosines, METH_VARARGS, "chains._finish_core's turn cosines (einsum's bits)"},
    {"ask_memos", ask_memos, METH_VARARGS, "chains.ask_all: ChainMemo.ask of every memo, one pass"},
    {"remember_plans", remember_plans, METH_VARARGS, "plan_chain_segments' memos of their plans, one pass"},
    {"sort_asks", sort_asks, METH_VARARGS, "plan_chain_segments' sorting of ask_all's answers, one pass"},
    {"drop_items", drop_items, METH_VARARGS, "_replay's drop of the chosen chains' rows, one pass"},
    {"piece_cumsum", piece_cumsum, METH_VARARGS, "running sums of each chain's pieces"},
    {"knots_flat", knots_flat, METH_VARARGS, "chains._knots_flat's rows: knots, steps, flat places, binding bits"},
    {"tent_rows", tent_rows, METH_VARARGS, "segments.tent_feeds_rows' envelopes (finite positive inputs)"},
    {"share_time", share_time, METH_VARARGS, "_share_time's whole Newton iteration"},
    {"exact_share", exact_share, METH_VARARGS, "_share_time_exact's whole Newton iteration"},
    {"step_vertices", step_vertices, METH_VARARGS, "solve_fixed's vertices of its active chains"},
    {"knot_times", knot_times, METH_VARARGS, "solve_fixed's knot times: each chain's running sums after a 0"},
    {"vert_prep", vert_prep, METH_VARARGS, "solve_fixed's vertices before their time of distance"},
    {"exact_prep", exact_prep, METH_VARARGS, "_share_time_exact's checks and exact_share's inputs"},
    {"tod_solve", tod_solve, METH_VARARGS, "the chains' time of distance, its whole iteration"},
    {"tod_at", tod_at, METH_VARARGS, "tod_prep and tod_solve in one call, the laws read where they are"},
    {"tod_at_into", tod_at_into, METH_VARARGS, "tod_at with its answers put where solve_fixed keeps them"},
    {"fixed_knots", fixed_knots, METH_VARARGS, "solve_fixed's knots and pieces, one pass"},
    {"prims_c", prims_c, METH_VARARGS, "the C primitives sinh, cube, sinh(z)/z (tests)"},
    {"horner_skip_c", horner_skip_c, METH_VARARGS, "shc_quarter and tod_chunk with a HornerSkip table (tests)"},
    {"chain_finish", chain_finish, METH_VARARGS, "chains._finish_stacked_dt's numbers for a batch of rows"},
    {"chain_finish_ragged", chain_finish_ragged, METH_VARARGS, "chain_finish over rows of several segment counts"},
    {"row_sums", row_sums, METH_VARARGS, "np.sum of each contiguous run (pairwise)"},
    {"step_accels", step_accels, METH_VARARGS, "LineLaw.end_accels of series-branch laws"},
    {"step_law", step_law, METH_VARARGS, "_step_law's numbers but shc(gamma/2)"},
    {"tod_prep", tod_prep, METH_VARARGS, "_tod_core's inputs of the taken laws, one pass"},
    {"active_step", active_step, METH_VARARGS, "solve_flat's active-set bookkeeping of one step"},
    {"take_blocks", take_blocks, METH_VARARGS, "the blocks of the chains done of a step's arrays, end to end"},
    {"fig_a", fig_a, METH_VARARGS, "_figure_law's numbers but shc(gamma/2)"},
    {"fig_b", fig_b, METH_VARARGS, "the flat figures: integral of v^2, end speeds, critical-point ratio"},
    {"fig_c", fig_c, METH_VARARGS, "the flat figures: critical t, tau and the shc arguments"},
    {"cf_rows", cf_rows, METH_VARARGS, "chains._cf_row of a list of strokes, one row each"},
    {"window_sums", window_sums, METH_VARARGS, "sums of nb consecutive values, left to right"},
    {"fig_d", fig_d, METH_VARARGS, "the flat figures: speed at the critical t, per-chain peak and least speed"},
    {"fig_need", fig_need, METH_VARARGS, "the flat figures: the pieces whose critical speed can be a chain's extreme"},
    {"fig_c_at", fig_c_at, METH_VARARGS, "fig_c of the pieces fig_need gave"},
    {"fig_d_at", fig_d_at, METH_VARARGS, "fig_d with the critical speeds of the pieces fig_need gave only"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef chaincore_module = {
    PyModuleDef_HEAD_INIT, "_gcode_opt_chaincore",
    "Compiled Newton loops of the chains' time sharing and time of distance (laws/chain.py)", -1, methods};

#ifndef CHAINCORE_SOURCE_SHA256
#define CHAINCORE_SOURCE_SHA256 ""
#endif
#ifndef GCODE_OPT_SOURCE_STAT   /* setup.py: the digest and the stat of each file it covers, when taken (native.stat_record) */
#define GCODE_OPT_SOURCE_STAT ""
#endif

PyMODINIT_FUNC PyInit__gcode_opt_chaincore(void) {
    PyObject *mod = PyModule_Create(&chaincore_module);
    if (mod && (PyModule_AddStringConstant(mod, "SOURCE_SHA256", CHAINCORE_SOURCE_SHA256) < 0
                || PyModule_AddStringConstant(mod, "SOURCE_STAT", GCODE_OPT_SOURCE_STAT) < 0)) {
        Py_DECREF(mod);
        return NULL;
    }
    return mod;
}

/* ---------------------------------------------------------------- session 38 (replay)
   chains._finish_core's turn cosines, np.einsum("mij,mij->mi", U[:, :-1], U[:, 1:]) of the
   unit directions U (m, n, 2) of m chains of n segments: each turn's two products added to
   einsum's zero start in its order, (0 + x0 y0) + x1 y1 (the same bits: a -0.0 sum is +0.0,
   as einsum's), without einsum's set-up and generic loop a batch (einsum 57.5 -> 20.0 M
   instructions on the gyroid plate, this 7.3 M). */
static PyObject *turn_cosines(PyObject *self, PyObject *a) {
    PyObject *ou, *oc;
    Py_ssize_t m, n;
    if (!PyArg_ParseTuple(a, "OnnO", &ou, &m, &n, &oc)) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t nu, nc;
    const double *u = get(&b, ou, 8, 0, &nu);
    double *c = u ? get(&b, oc, 8, 1, &nc) : NULL;
    if (!c) { release(&b); return NULL; }
    if (m < 0 || n < 1 || nu != m * n * 2 || nc != m * (n - 1) || (c < u + nu && u < c + nc)) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "turn_cosines: shapes");
        return NULL;
    }
    for (Py_ssize_t q = 0; q < m; q++) {
        const double *r = u + q * n * 2;
        double *o = c + q * (n - 1);
        for (Py_ssize_t i = 0; i + 1 < n; i++) {
            const double *x = r + 2 * i;
            o[i] = (0.0 + x[0] * x[2]) + x[1] * x[3];
        }
    }
    release(&b);
    Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- session 39 (replay)
   chains.ask_all in one pass: ChainMemo.ask(t_in[k], b_in[k], key) of every memo k, the law
   durations written into T, the rest into the lists segs, kept and rows (None where none).
   A memo with no last plan (seg None) whose rows are an array of doubles (array_type, 4 a
   row: predicted time, law T, beta, row) is answered here as ask answers it: law_of's
   newest row (smallest q) whose predicted time == t (C's ==: NaN matches nothing, -0.0
   matches 0.0, as the floats' == that array.index makes), its law T, else t; then plan_of's
   newest row of that (T, beta): its kept (kept[q] of a list) and int(row).  Any other memo
   (a last plan, rows of another type or out of their array) is asked by its own ask method:
   the same answers, ask's own exceptions.  (ask_all's numpy groups and look-ups: this pass
   -136 M instructions on the gyroid plate.) */
static PyObject *ask_memos(PyObject *self, PyObject *a) {
    PyObject *memos, *ot, *ob, *key, *oT, *array_type, *segs, *kept, *rows;
    if (!PyArg_ParseTuple(a, "O!OOOOOO!O!O!", &PyList_Type, &memos, &ot, &ob, &key, &oT, &array_type,
                          &PyList_Type, &segs, &PyList_Type, &kept, &PyList_Type, &rows))
        return NULL;
    static PyObject *s_seg, *s_figs, *s_at, *s_n, *s_kept, *s_ask;
    if (!s_ask) {
        s_seg = PyUnicode_InternFromString("seg");
        s_figs = PyUnicode_InternFromString("figs");
        s_at = PyUnicode_InternFromString("at");
        s_n = PyUnicode_InternFromString("n");
        s_kept = PyUnicode_InternFromString("kept");
        s_ask = PyUnicode_InternFromString("ask");
        if (!s_seg || !s_figs || !s_at || !s_n || !s_kept || !s_ask) return NULL;
    }
    Py_ssize_t m = PyList_GET_SIZE(memos), nt, nb, nT;
    Bufs b = {.n = 0};
    const double *t_in = get(&b, ot, 8, 0, &nt);
    const double *b_in = t_in ? get(&b, ob, 8, 0, &nb) : NULL;
    double *T = b_in ? get(&b, oT, 8, 1, &nT) : NULL;
    if (!T) { release(&b); return NULL; }
    if (nt != m || nb != m || nT != m || PyList_GET_SIZE(segs) != m || PyList_GET_SIZE(kept) != m
        || PyList_GET_SIZE(rows) != m) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "ask_memos: sizes");
        return NULL;
    }
    for (Py_ssize_t k = 0; k < m; k++) {
        PyObject *memo = PyList_GET_ITEM(memos, k);
        double t = t_in[k], beta = b_in[k];
        PyObject *seg = PyObject_GetAttr(memo, s_seg);
        if (!seg) goto fail;
        int mine = seg == Py_None;
        Py_DECREF(seg);
        PyObject *figs = NULL;
        Py_buffer fv = {.obj = NULL};
        Py_ssize_t at = 0, n = 0;
        if (mine) {
            figs = PyObject_GetAttr(memo, s_figs);
            if (!figs) goto fail;
            if (figs != Py_None) {
                PyObject *oa = PyObject_GetAttr(memo, s_at), *on = oa ? PyObject_GetAttr(memo, s_n) : NULL;
                if (!on) {
                    Py_XDECREF(oa);
                    Py_DECREF(figs);
                    goto fail;
                }
                mine = PyLong_CheckExact(oa) && PyLong_CheckExact(on) && Py_IS_TYPE(figs, (PyTypeObject *)array_type);
                if (mine) {
                    at = PyLong_AsSsize_t(oa);
                    n = PyLong_AsSsize_t(on);
                    if ((at == -1 || n == -1) && PyErr_Occurred()) PyErr_Clear();
                }
                Py_XDECREF(oa);
                Py_XDECREF(on);
                if (mine && PyObject_GetBuffer(figs, &fv, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) {
                    Py_DECREF(figs);
                    goto fail;
                }
                /* (rows of doubles inside the array, else ask: its IndexError) */
                mine = mine && fv.itemsize == 8 && fv.format && strcmp(fv.format, "d") == 0
                       && at >= 0 && n >= 0 && 4 * (at + n) <= fv.len / 8;
            }
        }
        if (!mine) {        /* ChainMemo.ask itself */
            if (fv.obj) PyBuffer_Release(&fv);
            Py_XDECREF(figs);
            PyObject *ft = PyFloat_FromDouble(t), *fb = ft ? PyFloat_FromDouble(beta) : NULL;
            PyObject *r = fb ? PyObject_CallMethodObjArgs(memo, s_ask, ft, fb, key, NULL) : NULL;
            Py_XDECREF(ft);
            Py_XDECREF(fb);
            if (!r) goto fail;
            PyObject *lt, *sg, *hit;
            if (!PyArg_ParseTuple(r, "OOO", &lt, &sg, &hit)) { Py_DECREF(r); goto fail; }
            double v = PyFloat_AsDouble(lt);
            if (v == -1.0 && PyErr_Occurred()) { Py_DECREF(r); goto fail; }
            T[k] = v;
            Py_INCREF(sg);
            PyList_SetItem(segs, k, sg);
            if (hit != Py_None) {
                PyObject *kp, *rw;
                if (!PyArg_ParseTuple(hit, "OO", &kp, &rw)) { Py_DECREF(r); goto fail; }
                Py_INCREF(kp);
                Py_INCREF(rw);
                PyList_SetItem(kept, k, kp);
                PyList_SetItem(rows, k, rw);
            }
            Py_DECREF(r);
            continue;
        }
        double lt = t;
        if (figs == Py_None) {                  /* no rows: law_of(t) is t, plan_of None */
            Py_DECREF(figs);
            T[k] = lt;
            continue;
        }
        const double *F = (const double *)fv.buf + 4 * at;
        for (Py_ssize_t q = 0; q < n; q++)
            if (F[4 * q] == t) { lt = F[4 * q + 1]; break; }
        T[k] = lt;
        Py_ssize_t hq = -1;
        for (Py_ssize_t q = 0; q < n; q++)
            if (F[4 * q + 1] == lt && F[4 * q + 2] == beta) { hq = q; break; }
        double row = hq >= 0 ? F[4 * hq + 3] : 0.0;
        PyBuffer_Release(&fv);
        Py_DECREF(figs);
        if (hq < 0) continue;
        PyObject *kp = PyObject_GetAttr(memo, s_kept);
        if (!kp) goto fail;
        if (PyList_Check(kp)) {
            if (hq >= PyList_GET_SIZE(kp)) {
                Py_DECREF(kp);
                PyErr_SetString(PyExc_IndexError, "list index out of range");
                goto fail;
            }
            PyObject *e = PyList_GET_ITEM(kp, hq);
            Py_INCREF(e);
            Py_DECREF(kp);
            kp = e;
        }
        PyObject *rw = PyLong_FromDouble(row);
        if (!rw) { Py_DECREF(kp); goto fail; }
        PyList_SetItem(kept, k, kp);
        PyList_SetItem(rows, k, rw);
    }
    release(&b);
    Py_RETURN_NONE;
fail:
    release(&b);
    return NULL;
}

/* plan_chain_segments' last loop in one pass: for each k of todo, the chain strokes[k]'s memo
   (its chain_T) remembers its plan out[k] and what it was made for: seg_T = T[k], seg_beta =
   b_in[k], seg_key = key, seg = out[k] (set in that order), seg_tin = the plan's time_t
   where it == t_in[k] (getattr(plan, "time_t", None): no time_t, None), else t_in[k]; then
   drop(strokes[k]) where k is not in the set dropped.  (~16 k chains on the gyroid plate:
   the loop's attribute reads and writes: -9 M instructions on the gyroid plate.) */
static PyObject *remember_plans(PyObject *self, PyObject *a) {
    PyObject *strokes, *todo, *out, *oT, *ob, *ot, *key, *dropped, *drop;
    if (!PyArg_ParseTuple(a, "O!O!O!OOOOO!O", &PyList_Type, &strokes, &PyList_Type, &todo, &PyList_Type, &out,
                          &oT, &ob, &ot, &key, &PySet_Type, &dropped, &drop))
        return NULL;
    static PyObject *s_chain_T, *s_seg_T, *s_seg_beta, *s_seg_key, *s_seg, *s_time_t, *s_seg_tin;
    if (!s_seg_tin) {
        s_chain_T = PyUnicode_InternFromString("chain_T");
        s_seg_T = PyUnicode_InternFromString("seg_T");
        s_seg_beta = PyUnicode_InternFromString("seg_beta");
        s_seg_key = PyUnicode_InternFromString("seg_key");
        s_seg = PyUnicode_InternFromString("seg");
        s_time_t = PyUnicode_InternFromString("time_t");
        s_seg_tin = PyUnicode_InternFromString("seg_tin");
        if (!s_chain_T || !s_seg_T || !s_seg_beta || !s_seg_key || !s_seg || !s_time_t || !s_seg_tin) return NULL;
    }
    Py_ssize_t m = PyList_GET_SIZE(strokes), nT, nb, nt;
    Bufs b = {.n = 0};
    const double *T = get(&b, oT, 8, 0, &nT);
    const double *b_in = T ? get(&b, ob, 8, 0, &nb) : NULL;
    const double *t_in = b_in ? get(&b, ot, 8, 0, &nt) : NULL;
    if (!t_in) { release(&b); return NULL; }
    if (nT != m || nb != m || nt != m || PyList_GET_SIZE(out) != m) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "remember_plans: sizes");
        return NULL;
    }
    for (Py_ssize_t i = 0; i < PyList_GET_SIZE(todo); i++) {
        PyObject *ok = PyList_GET_ITEM(todo, i);
        Py_ssize_t k = PyLong_AsSsize_t(ok);
        if (k == -1 && PyErr_Occurred()) goto fail;
        if (k < 0 || k >= m) {
            PyErr_SetString(PyExc_IndexError, "remember_plans: todo out of range");
            goto fail;
        }
        PyObject *st = PyList_GET_ITEM(strokes, k), *plan = PyList_GET_ITEM(out, k);
        PyObject *memo = PyObject_GetAttr(st, s_chain_T);
        if (!memo) goto fail;
        PyObject *fT = PyFloat_FromDouble(T[k]), *fb = fT ? PyFloat_FromDouble(b_in[k]) : NULL;
        int bad = !fb || PyObject_SetAttr(memo, s_seg_T, fT) < 0 || PyObject_SetAttr(memo, s_seg_beta, fb) < 0
                  || PyObject_SetAttr(memo, s_seg_key, key) < 0 || PyObject_SetAttr(memo, s_seg, plan) < 0;
        Py_XDECREF(fT);
        Py_XDECREF(fb);
        if (bad) { Py_DECREF(memo); goto fail; }
        PyObject *tt = PyObject_GetAttr(plan, s_time_t);
        if (!tt) {
            if (!PyErr_ExceptionMatches(PyExc_AttributeError)) { Py_DECREF(memo); goto fail; }
            PyErr_Clear();
            Py_INCREF(Py_None);
            tt = Py_None;
        }
        PyObject *t = PyFloat_FromDouble(t_in[k]);
        int eq = -1;
        if (t) {
            if (PyFloat_CheckExact(tt)) {
                eq = PyFloat_AS_DOUBLE(tt) == t_in[k];
            } else {
                PyObject *r = PyObject_RichCompare(tt, t, Py_EQ);
                if (r) {
                    eq = PyObject_IsTrue(r);
                    Py_DECREF(r);
                }
            }
        }
        bad = eq < 0 || PyObject_SetAttr(memo, s_seg_tin, eq ? tt : t) < 0;
        Py_DECREF(tt);
        Py_XDECREF(t);
        Py_DECREF(memo);
        if (bad) goto fail;
        int in = PySet_Contains(dropped, ok);
        if (in < 0) goto fail;
        if (!in) {
            PyObject *r = PyObject_CallOneArg(drop, st);
            if (!r) goto fail;
            Py_DECREF(r);
        }
    }
    release(&b);
    Py_RETURN_NONE;
fail:
    release(&b);
    return NULL;
}

/* plan_chain_segments' sorting of ask_all's answers in one pass: for each chain k, its last
   plan segs[k] where there is one (into out[k]), else k joins todo and, where it has a
   candidate row (rows[k] not None) of the rules key (kept[k].key == key): a row dropped
   (an instance of again_type) -> again [(k, kept)], a kept law (laws_type) -> items
   [(strokes[k], kept, row)] and lazy [k], else out[k] = kept.plan(row); no row -> cold [k].
   Returns (todo, items, lazy, again, cold). */
static PyObject *sort_asks(PyObject *self, PyObject *a) {
    PyObject *strokes, *segs, *kept, *rows, *key, *again_type, *laws_type, *out;
    if (!PyArg_ParseTuple(a, "O!O!O!O!OOOO!", &PyList_Type, &strokes, &PyList_Type, &segs, &PyList_Type, &kept,
                          &PyList_Type, &rows, &key, &again_type, &laws_type, &PyList_Type, &out))
        return NULL;
    static PyObject *s_key, *s_plan;
    if (!s_plan) {
        s_key = PyUnicode_InternFromString("key");
        s_plan = PyUnicode_InternFromString("plan");
        if (!s_key || !s_plan) return NULL;
    }
    Py_ssize_t m = PyList_GET_SIZE(strokes);
    if (PyList_GET_SIZE(segs) != m || PyList_GET_SIZE(kept) != m || PyList_GET_SIZE(rows) != m
        || PyList_GET_SIZE(out) != m) {
        PyErr_SetString(PyExc_ValueError, "sort_asks: sizes");
        return NULL;
    }
    PyObject *todo = PyList_New(0), *items = PyList_New(0), *lazy = PyList_New(0), *again = PyList_New(0),
             *cold = PyList_New(0), *ok = NULL;
    if (!todo || !items || !lazy || !again || !cold) goto done;
    for (Py_ssize_t k = 0; k < m; k++) {
        PyObject *seg = PyList_GET_ITEM(segs, k);
        if (seg != Py_None) {
            Py_INCREF(seg);
            PyList_SetItem(out, k, seg);
            continue;
        }
        PyObject *ik = PyLong_FromSsize_t(k);
        if (!ik || PyList_Append(todo, ik) < 0) { Py_XDECREF(ik); goto done; }
        PyObject *r = PyList_GET_ITEM(rows, k), *kp = PyList_GET_ITEM(kept, k);
        int mine = 0;
        if (r != Py_None) {
            PyObject *kk = PyObject_GetAttr(kp, s_key);
            PyObject *eq = kk ? PyObject_RichCompare(kk, key, Py_EQ) : NULL;
            Py_XDECREF(kk);
            mine = eq ? PyObject_IsTrue(eq) : -1;
            Py_XDECREF(eq);
        }
        int bad = mine < 0;
        if (!bad && mine) {
            int is_again = PyObject_IsInstance(kp, again_type);
            int is_laws = is_again == 0 ? PyObject_IsInstance(kp, laws_type) : 0;
            if (is_again < 0 || is_laws < 0) {
                bad = 1;
            } else if (is_again) {
                PyObject *t = PyTuple_Pack(2, ik, kp);
                bad = !t || PyList_Append(again, t) < 0;
                Py_XDECREF(t);
            } else if (is_laws) {
                PyObject *t = PyTuple_Pack(3, PyList_GET_ITEM(strokes, k), kp, r);
                bad = !t || PyList_Append(items, t) < 0 || PyList_Append(lazy, ik) < 0;
                Py_XDECREF(t);
            } else {
                PyObject *p = PyObject_CallMethodOneArg(kp, s_plan, r);
                bad = !p;
                if (p) PyList_SetItem(out, k, p);
            }
        } else if (!bad) {
            bad = PyList_Append(cold, ik) < 0;
        }
        Py_DECREF(ik);
        if (bad) goto done;
    }
    ok = PyTuple_Pack(5, todo, items, lazy, again, cold);
done:
    Py_XDECREF(todo);
    Py_XDECREF(items);
    Py_XDECREF(lazy);
    Py_XDECREF(again);
    Py_XDECREF(cold);
    return ok;
}

/* _replay's drop of the chosen chains' rows in one pass: for each item (stroke, kept, row) of
   items, the stroke's memo (chain_T) drops its rows as ChainMemo.drop_rows does (its kept of
   type laws_type exactly, a src not None and kept.key == src.key: kept = src.again), gs[q]'s
   chain_caps = None, and items[q] = (stroke, None, row). */
static PyObject *drop_items(PyObject *self, PyObject *a) {
    PyObject *items, *gs, *laws_type;
    if (!PyArg_ParseTuple(a, "O!O!O", &PyList_Type, &items, &PyList_Type, &gs, &laws_type)) return NULL;
    static PyObject *s_chain_T, *s_kept, *s_src, *s_key, *s_again, *s_chain_caps;
    if (!s_chain_caps) {
        s_chain_T = PyUnicode_InternFromString("chain_T");
        s_kept = PyUnicode_InternFromString("kept");
        s_src = PyUnicode_InternFromString("src");
        s_key = PyUnicode_InternFromString("key");
        s_again = PyUnicode_InternFromString("again");
        s_chain_caps = PyUnicode_InternFromString("chain_caps");
        if (!s_chain_T || !s_kept || !s_src || !s_key || !s_again || !s_chain_caps) return NULL;
    }
    Py_ssize_t m = PyList_GET_SIZE(items);
    if (PyList_GET_SIZE(gs) != m) {
        PyErr_SetString(PyExc_ValueError, "drop_items: sizes");
        return NULL;
    }
    for (Py_ssize_t q = 0; q < m; q++) {
        PyObject *it = PyList_GET_ITEM(items, q);
        if (!PyTuple_Check(it) || PyTuple_GET_SIZE(it) != 3) {
            PyErr_SetString(PyExc_TypeError, "drop_items: items of (stroke, kept, row)");
            return NULL;
        }
        PyObject *st = PyTuple_GET_ITEM(it, 0);
        PyObject *memo = PyObject_GetAttr(st, s_chain_T);
        if (!memo) return NULL;
        PyObject *kept = PyObject_GetAttr(memo, s_kept);
        int bad = !kept;
        if (kept && (PyObject *)Py_TYPE(kept) == laws_type) {
            PyObject *src = PyObject_GetAttr(memo, s_src);
            bad = !src;
            if (src && src != Py_None) {
                PyObject *k1 = PyObject_GetAttr(kept, s_key), *k2 = k1 ? PyObject_GetAttr(src, s_key) : NULL;
                PyObject *eq = k2 ? PyObject_RichCompare(k1, k2, Py_EQ) : NULL;
                int is = eq ? PyObject_IsTrue(eq) : -1;
                Py_XDECREF(k1);
                Py_XDECREF(k2);
                Py_XDECREF(eq);
                if (is > 0) {
                    PyObject *ag = PyObject_GetAttr(src, s_again);
                    is = ag && PyObject_SetAttr(memo, s_kept, ag) == 0 ? 0 : -1;
                    Py_XDECREF(ag);
                }
                bad = is < 0;
            }
            Py_XDECREF(src);
        }
        Py_XDECREF(kept);
        Py_DECREF(memo);
        if (bad || PyObject_SetAttr(PyList_GET_ITEM(gs, q), s_chain_caps, Py_None) < 0) return NULL;
        PyObject *t = PyTuple_Pack(3, st, Py_None, PyTuple_GET_ITEM(it, 2));
        if (!t) return NULL;
        PyList_SetItem(items, q, t);
    }
    Py_RETURN_NONE;
}
