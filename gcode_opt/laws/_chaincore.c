/* The chains' time sharing (laws/chain.py: _share_time), its Newton steps compiled.

Optional extension _gcode_opt_chaincore (setup.py builds it; laws/chain.py falls back to
the numpy code when it is missing, stale or GCODE_OPT_PURE_PYTHON is set).  It must give
the numpy code's bits: every double operation below is the one numpy does, in the same
order (built with -ffp-contract=off, no fast math).  numpy's sinh and power are not
libm's on every machine (SIMD versions), so they stay numpy's: share_args writes their
arguments, the Python loop calls np.sinh and ** 3 on them, and share_step does the rest
of the step.  Sums per chain are bincount's: from 0.0, in the order of the pieces. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <float.h>
#include <stdint.h>
#include <string.h>

#if defined(_MSC_VER) && !defined(restrict)
#define restrict __restrict
#endif

#define FD_H_R 1e-4
#define NEWTON_TOL_R 1e-8
#define GAMMA_SWITCH 4.0
#define NTERMS 24

typedef struct {
    Py_buffer v[24];
    int n;
} Bufs;

static void release(Bufs *b) {
    for (int i = 0; i < b->n; i++) PyBuffer_Release(&b->v[i]);
    b->n = 0;
}

/* a C-contiguous buffer of items of `size` bytes; NULL (exception set) otherwise */
static void *get(Bufs *b, PyObject *o, Py_ssize_t size, int writable, Py_ssize_t *len) {
    Py_buffer *v = &b->v[b->n];
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
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
static inline double np_max(double a, double b) { return (a >= b || isnan(a)) ? a : b; }

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

/* share_args' arithmetic on the m active pieces, compact: durations Tm, √β sq; writes
   Tlo = Tm - h, Thi = Tm + h (h = FD_H_R Tm) and args = [γ/2, γ] at the three (6 m).
   Returns 1 where a duration is not finite and > 0 or a γ not below GAMMA_SWITCH, else 0
   and *gmax the bits of the largest γ (all then > 0 or +0: their bits order as their
   values, as their squares do). */
VEC_CLONES static int args_vec(Py_ssize_t m, const double *restrict Tm, const double *restrict sq,
                               double *restrict Tlo, double *restrict Thi, double *restrict args,
                               int64_t *gmax) {
    int bad = 0;
    int64_t gb = 0;
    for (Py_ssize_t j = 0; j < m; j++) {
        double Ti = Tm[j], h = FD_H_R * Ti, s = sq[j];
        double t0 = Ti - h, t2 = Ti + h;
        double g0 = t0 / s, g1 = Ti / s, g2 = t2 / s;
        Tlo[j] = t0;
        Thi[j] = t2;
        args[j] = g0 / 2;
        args[m + j] = g1 / 2;
        args[2 * m + j] = g2 / 2;
        args[3 * m + j] = g0;
        args[4 * m + j] = g1;
        args[5 * m + j] = g2;
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

/* share_args(T, sqb, poff, conv, Tall, args, zmax, scratch) -> (m, k)
   The active pieces (those of chains not conv, in order): Tall = [T - h, T, T + h] (3 m,
   h = FD_H_R T), args = [γ/2, γ] (6 m, γ = Tall / sqb) for np.sinh; k = the Horner terms
   the batch needs (_nms_terms over γ²).  m = -1: a duration not finite and > 0 or a γ
   not below GAMMA_SWITCH (the numpy code then runs: its error or its other branch).
   scratch: m doubles or more (√β of the active pieces). */
static PyObject *share_args(PyObject *self, PyObject *a) {
    PyObject *oT, *osqb, *opoff, *oconv, *oTall, *oargs, *ozmax, *oscr;
    if (!PyArg_ParseTuple(a, "OOOOOOOO", &oT, &osqb, &opoff, &oconv, &oTall, &oargs, &ozmax, &oscr)) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t P, nc1, nz, nTall, nargs, nscr;
    double *T = get(&b, oT, 8, 0, &P);
    double *sqb = T ? get(&b, osqb, 8, 0, NULL) : NULL;
    int64_t *poff = sqb ? get(&b, opoff, 8, 0, &nc1) : NULL;
    uint8_t *conv = poff ? get(&b, oconv, 1, 0, NULL) : NULL;
    double *Tall = conv ? get(&b, oTall, 8, 1, &nTall) : NULL;
    double *args = Tall ? get(&b, oargs, 8, 1, &nargs) : NULL;
    double *zmax = args ? get(&b, ozmax, 8, 0, &nz) : NULL;
    double *scr = zmax ? get(&b, oscr, 8, 1, &nscr) : NULL;
    if (!scr) { release(&b); return NULL; }
    Py_ssize_t n_c = nc1 - 1, m = 0;
    for (Py_ssize_t c = 0; c < n_c; c++)
        if (!conv[c]) m += poff[c + 1] - poff[c];
    if (nTall < 3 * m || nargs < 6 * m || nscr < m) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "share_args: buffers");
        return NULL;
    }
    Py_ssize_t j = 0;
    for (Py_ssize_t c = 0; c < n_c; c++) {              /* the active pieces, compact */
        if (conv[c]) continue;
        for (int64_t p = poff[c]; p < poff[c + 1]; p++, j++) {
            Tall[m + j] = T[p];
            scr[j] = sqb[p];
        }
    }
    int64_t gb;
    int bad = args_vec(m, Tall + m, scr, Tall, Tall + 2 * m, args, &gb);
    double gm;
    memcpy(&gm, &gb, 8);
    double zm = gm * gm;                 /* the largest γ²: rounding keeps the order of γ > 0 */
    release(&b);
    if (bad) return Py_BuildValue("(ni)", (Py_ssize_t)-1, 0);
    /* _nms_terms: the least k with zmax <= table[k] (searchsorted left), plus one, <= NTERMS */
    int k = NTERMS;
    if (m > 0) {
        Py_ssize_t i = 0;
        while (i < nz && zmax[i] < zm) i++;
        k = (int)(i + 1 < NTERMS ? i + 1 : NTERMS);
    }
    return Py_BuildValue("(ni)", m, k);
}

#define CHUNK 256          /* pieces a pass of j_chunk: its series stay in L1 */

/* J = ∫ṡ² + β∫s̈² (_J3's arithmetic, element by element) of n pieces at one of their
   three durations: t, t3 = t ** 3, the np.sinh arguments γ/2 (zh) and γ (zf) and values
   (shh, shf), the pieces' L, β, v0 + v1, v0 - v1; the n, m, S1 series (_horner_nms with
   its k terms) at γ² first, into the chunk's own scratch (n <= CHUNK). */
VEC_CLONES static void j_chunk(Py_ssize_t n, int k, const double *restrict t, const double *restrict t3,
                               const double *restrict zh, const double *restrict shh, const double *restrict zf,
                               const double *restrict shf, const double *restrict coef,
                               const double *restrict Lc, const double *restrict bc, const double *restrict vsc,
                               const double *restrict vdc, double *restrict J) {
    double nb[CHUNK], mb[CHUNK], sb[CHUNK];
    double c0 = coef[3 * (k - 1)], c1 = coef[3 * (k - 1) + 1], c2 = coef[3 * (k - 1) + 2];
    for (Py_ssize_t i = 0; i < n; i++) { nb[i] = c0; mb[i] = c1; sb[i] = c2; }
    for (int q = k - 2; q >= 0; q--) {
        double a0 = coef[3 * q], a1 = coef[3 * q + 1], a2 = coef[3 * q + 2];
        for (Py_ssize_t i = 0; i < n; i++) {
            double z2 = zf[i] * zf[i];
            double x = nb[i] * z2, y = mb[i] * z2, w = sb[i] * z2;
            nb[i] = x + a0; mb[i] = y + a1; sb[i] = w + a2;
        }
    }
    for (Py_ssize_t j = 0; j < n; j++) {
        double sh2 = shh[j] / zh[j], shg = shf[j] / zf[j];
        sh2 = zh[j] == 0.0 ? 1.0 : sh2;                  /* _shc: 1 at z = 0 */
        shg = zf[j] == 0.0 ? 1.0 : shg;
        double nn = nb[j], n2 = (2 * nn) * nn, sq = sh2 * sh2;
        double Ig1 = mb[j] / n2, Igp = sb[j] / n2, Ih = (2 * sb[j]) / sq, Ihp = (2 * (shg + 1)) / sq;
        double tj = t[j], L = Lc[j];
        double A = L - (tj * vsc[j]) / 2, d = (tj * vdc[j]) / 2;
        double AA = A * A, dd = d * d;
        double iv = ((L * L + AA * Ig1) + dd * Ih) / tj;
        double ia = (AA * Igp + dd * Ihp) / t3[j];
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

/* share_step(L, beta, vs, vd, T, T_total, poff, conv, lam, first, m, k, Tall, T3, args, sh,
   coef, n_p, d1, inv, work) -> chains still moving.  One Newton step of _share_time on the
   active pieces (share_args' m, k, Tall; T3 = Tall ** 3 and sh = np.sinh(args) by numpy;
   vs = va + vb, vd = va - vb): T, lam, conv updated in place.  work: scratch of 7 m
   doubles or more (the caller's, kept over the steps). */
static PyObject *share_step(PyObject *self, PyObject *a) {
    PyObject *o[20];
    int first, k;
    Py_ssize_t m;
    if (!PyArg_ParseTuple(a, "OOOOOOOOOpniOOOOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &first, &m, &k, &o[9], &o[10], &o[11], &o[12], &o[13], &o[14], &o[15], &o[16],
                          &o[17]))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t nc1, nwork;
    double *L = get(&b, o[0], 8, 0, NULL);
    double *beta = L ? get(&b, o[1], 8, 0, NULL) : NULL;
    double *vs = beta ? get(&b, o[2], 8, 0, NULL) : NULL;
    double *vd = vs ? get(&b, o[3], 8, 0, NULL) : NULL;
    double *T = vd ? get(&b, o[4], 8, 1, NULL) : NULL;
    double *Ttot = T ? get(&b, o[5], 8, 0, NULL) : NULL;
    int64_t *poff = Ttot ? get(&b, o[6], 8, 0, &nc1) : NULL;
    uint8_t *conv = poff ? get(&b, o[7], 1, 1, NULL) : NULL;
    double *lam = conv ? get(&b, o[8], 8, 1, NULL) : NULL;
    double *Tall = lam ? get(&b, o[9], 8, 0, NULL) : NULL;
    double *T3 = Tall ? get(&b, o[10], 8, 0, NULL) : NULL;
    double *args = T3 ? get(&b, o[11], 8, 0, NULL) : NULL;
    double *sh = args ? get(&b, o[12], 8, 0, NULL) : NULL;
    double *coef = sh ? get(&b, o[13], 8, 0, NULL) : NULL;
    double *npc = coef ? get(&b, o[14], 8, 0, NULL) : NULL;
    double *d1b = npc ? get(&b, o[15], 8, 1, NULL) : NULL;
    double *invb = d1b ? get(&b, o[16], 8, 1, NULL) : NULL;
    double *work = invb ? get(&b, o[17], 8, 1, &nwork) : NULL;
    if (!work) { release(&b); return NULL; }
    if (nwork < 7 * m || k < 1 || k > NTERMS) {
        release(&b);
        PyErr_SetString(PyExc_ValueError, "share_step: work or terms");
        return NULL;
    }
    Py_ssize_t n_c = nc1 - 1, j = 0, moving = 0;
    double *Lc = work, *bc = work + m, *vsc = work + 2 * m, *vdc = work + 3 * m, *Jb = work + 4 * m;
    for (Py_ssize_t c = 0; c < n_c; c++) {              /* the active pieces, compact */
        if (conv[c]) continue;
        for (int64_t p = poff[c]; p < poff[c + 1]; p++, j++) {
            Lc[j] = L[p]; bc[j] = beta[p]; vsc[j] = vs[p]; vdc[j] = vd[p];
        }
    }
    Py_ssize_t M = 3 * m;
    for (int q = 0; q < 3; q++) {
        Py_ssize_t o3 = q * m;
        for (Py_ssize_t j0 = 0; j0 < m; j0 += CHUNK) {
            Py_ssize_t n = m - j0 < CHUNK ? m - j0 : CHUNK, x = o3 + j0;
            j_chunk(n, k, Tall + x, T3 + x, args + x, sh + x, args + M + x, sh + M + x, coef,
                    Lc + j0, bc + j0, vsc + j0, vdc + j0, Jb + x);
        }
    }
    slopes(m, Jb, Tall + m, d1b, invb);                 /* Tall[m + j]: the duration T itself */
    j = 0;
    for (Py_ssize_t c = 0; c < n_c; c++) {
        if (conv[c]) continue;
        int64_t p0 = poff[c], p1 = poff[c + 1];
        Py_ssize_t j0 = j;
        double s_inv = 0.0, s_d1inv = 0.0, s_T = 0.0, s_ad1 = 0.0;
        for (int64_t p = p0; p < p1; p++, j++) {
            double d1 = d1b[j], inv = invb[j];
            s_inv += inv;
            s_d1inv += d1 * inv;
            s_T += T[p];
            s_ad1 += fabs(d1);
        }
        double l = first ? -s_d1inv / s_inv : lam[c];
        double s_rinv = 0.0, rr = 0.0;
        for (Py_ssize_t q = j0; q < j; q++) {
            double r = d1b[q] + l;
            d1b[q] = r;                       /* r from here on */
            s_rinv += r * invb[q];
            rr += fabs(r);
        }
        double e = Ttot[c] - s_T;
        double dlam = -(e + s_rinv) / s_inv;
        double scale = np_max(fabs(l), s_ad1 / npc[c]);
        int now = (rr <= (NEWTON_TOL_R * scale) * npc[c]) && (fabs(e) <= 1e-12 * Ttot[c]);
        if (now) {
            conv[c] = 1;
            lam[c] = l;
            continue;
        }
        moving++;
        Py_ssize_t q = j0;
        for (int64_t p = p0; p < p1; p++, q++) {
            double Ti = T[p];
            double dT = -(d1b[q] + dlam) * invb[q];
            double lo = -0.5 * Ti, st;
            if (isnan(dT)) st = dT;           /* np.clip: nan stays */
            else {
                st = dT > lo ? dT : lo;
                st = st < Ti ? st : Ti;
            }
            T[p] = Ti + st;
        }
        lam[c] = l + nan_to_num(dlam);
    }
    release(&b);
    return PyLong_FromSsize_t(moving);
}


/* tod_args(t, T, gs, act, na, args, xb, zmax) -> k
   time_of_distance's step on the active laws act[:na]: τ = clip(t / T, 0, 1), x = τ - 1/2;
   args = [γτ/2, γ(1 - τ)/2, γx] (3 na) for np.sinh, xb = x (for ** 3); k = the S1
   series' terms the batch needs (_s1: _nms_terms over (γx)² with the S1 table). */
static PyObject *tod_args(PyObject *self, PyObject *a) {
    PyObject *ot, *oT, *ogs, *oact, *oargs, *oxb, *ozmax;
    Py_ssize_t na;
    if (!PyArg_ParseTuple(a, "OOOOnOOO", &ot, &oT, &ogs, &oact, &na, &oargs, &oxb, &ozmax)) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t nz;
    double *t = get(&b, ot, 8, 0, NULL);
    double *T = t ? get(&b, oT, 8, 0, NULL) : NULL;
    double *gs = T ? get(&b, ogs, 8, 0, NULL) : NULL;
    int64_t *act = gs ? get(&b, oact, 8, 0, NULL) : NULL;
    double *args = act ? get(&b, oargs, 8, 1, NULL) : NULL;
    double *xb = args ? get(&b, oxb, 8, 1, NULL) : NULL;
    double *zmax = xb ? get(&b, ozmax, 8, 0, &nz) : NULL;
    if (!zmax) { release(&b); return NULL; }
    double zm = -1.0;
    int nan = 0;
    for (Py_ssize_t j = 0; j < na; j++) {
        int64_t i = act[j];
        double tau = t[i] / T[i];
        if (!isnan(tau)) {                /* np.clip: nan stays */
            tau = tau > 0.0 ? tau : 0.0;
            tau = tau < 1.0 ? tau : 1.0;
        }
        double x = tau - 0.5, g = gs[i];
        args[j] = (g * tau) / 2;
        args[na + j] = (g * (1 - tau)) / 2;
        double z = g * x;
        args[2 * na + j] = z;
        xb[j] = x;
        double z2 = z * z;
        if (isnan(z2)) nan = 1;
        else if (z2 > zm) zm = z2;
    }
    release(&b);
    int k = NTERMS;
    if (na > 0 && !nan) {
        Py_ssize_t i = 0;
        while (i < nz && zmax[i] < zm) i++;
        k = (int)(i + 1 < NTERMS ? i + 1 : NTERMS);
    }
    return PyLong_FromLong(k);
}

static inline double shc(double z, double s) { return z == 0.0 ? 1.0 : s / z; }

/* tod_step(t, T, n, sh2, wbar, A, delta, target, sgn, lo, hi, scale, act, na, args, sh, x3,
   k, s1coef, out, vout, q4, sh4) -> laws still active (q4 = γ/4 and sh4 = np.sinh(q4) of
   every law: the same at every step) (act compacted in place), 0 when all are done
   (then nothing is written, as _tod_rows breaks).  One step of _tod_step / _tod_rows: s and
   ṡ at t as LineLaw.eval(t, "sv") (series branch), the bracket, done, Newton or bisection;
   out[i] = the new t; vout[i] = ṡ at the t a law ended on (eval(t, "v") there). */
static PyObject *tod_step(PyObject *self, PyObject *a) {
    PyObject *o[21];
    Py_ssize_t na;
    int k;
    if (!PyArg_ParseTuple(a, "OOOOOOOOOOOOOnOOOiOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &o[9], &o[10], &o[11], &o[12], &na, &o[13], &o[14], &o[15], &k, &o[16],
                          &o[17], &o[18], &o[19], &o[20]))
        return NULL;
    Bufs b = {.n = 0};
    double *t = get(&b, o[0], 8, 1, NULL);
    double *T = t ? get(&b, o[1], 8, 0, NULL) : NULL;
    double *n = T ? get(&b, o[2], 8, 0, NULL) : NULL;
    double *sh2 = n ? get(&b, o[3], 8, 0, NULL) : NULL;
    double *wbar = sh2 ? get(&b, o[4], 8, 0, NULL) : NULL;
    double *A = wbar ? get(&b, o[5], 8, 0, NULL) : NULL;
    double *dl = A ? get(&b, o[6], 8, 0, NULL) : NULL;
    double *target = dl ? get(&b, o[7], 8, 0, NULL) : NULL;
    double *sgn = target ? get(&b, o[8], 8, 0, NULL) : NULL;
    double *lo = sgn ? get(&b, o[9], 8, 1, NULL) : NULL;
    double *hi = lo ? get(&b, o[10], 8, 1, NULL) : NULL;
    double *scale = hi ? get(&b, o[11], 8, 0, NULL) : NULL;
    int64_t *act = scale ? get(&b, o[12], 8, 1, NULL) : NULL;
    double *args = act ? get(&b, o[13], 8, 0, NULL) : NULL;
    double *sh = args ? get(&b, o[14], 8, 0, NULL) : NULL;
    double *x3 = sh ? get(&b, o[15], 8, 0, NULL) : NULL;
    double *coef = x3 ? get(&b, o[16], 8, 0, NULL) : NULL;
    double *out = coef ? get(&b, o[17], 8, 1, NULL) : NULL;
    double *vout = out ? get(&b, o[18], 8, 1, NULL) : NULL;
    double *q4 = vout ? get(&b, o[19], 8, 0, NULL) : NULL;
    double *sh4 = q4 ? get(&b, o[20], 8, 0, NULL) : NULL;
    if (!sh4) { release(&b); return NULL; }
    const double eps4 = 4 * DBL_EPSILON;
    /* first pass: done of every law (all done: nothing written) */
    double *newt = PyMem_Malloc((na ? na : 1) * sizeof(double));
    unsigned char *dn = PyMem_Malloc(na ? na : 1);
    double *vv = PyMem_Malloc((na ? na : 1) * sizeof(double));
    if (!newt || !dn || !vv) {
        PyMem_Free(newt); PyMem_Free(dn); PyMem_Free(vv); release(&b);
        return PyErr_NoMemory();
    }
    Py_ssize_t ndone = 0;
    for (Py_ssize_t j = 0; j < na; j++) {
        int64_t i = act[j];
        double ti = t[i], x = 0.0;
        double tau = ti / T[i];
        if (!isnan(tau)) {
            tau = tau > 0.0 ? tau : 0.0;
            tau = tau < 1.0 ? tau : 1.0;
        }
        x = tau - 0.5;
        double pa = shc(args[j], sh[j]), pb = shc(args[na + j], sh[na + j]);
        double bub = ((tau * (1 - tau)) * pa) * pb;
        double g = bub / (2 * n[i]);
        double Hs = (-bub) / sh2[i];
        double shx = shc(args[2 * na + j], sh[2 * na + j]);
        double h = ((2 * x) * shx) / sh2[i];
        double z = args[2 * na + j], z2 = z * z;
        double s1 = coef[k - 1];
        for (int q = k - 2; q >= 0; q--) { s1 = s1 * z2; s1 = s1 + coef[q]; }
        double s4 = shc(q4[i], sh4[i]);
        double G = 0.5 + (((x * (s4 * s4)) / 8) - x3[j] * s1) / n[i];
        double s = ((wbar[i] * tau) + (A[i] * G)) - (dl[i] * Hs);
        double v = ((wbar[i] + A[i] * g) - dl[i] * h) / T[i];
        double f = sgn[i] * (s - target[i]);
        if (f <= 0) lo[i] = ti;
        if (f >= 0) hi[i] = ti;
        int done = (fabs(f) <= eps4 * scale[i]) || (hi[i] - lo[i] <= eps4 * T[i]);
        dn[j] = (unsigned char)done;
        vv[j] = v;
        if (done) { ndone++; newt[j] = ti; continue; }
        double sv = sgn[i] * v;
        double tn = ti - f / sv;
        int ok = (sv > 0) && (tn > lo[i]) && (tn < hi[i]);
        newt[j] = ok ? tn : 0.5 * (lo[i] + hi[i]);
    }
    Py_ssize_t keep = 0;
    if (ndone < na) {
        for (Py_ssize_t j = 0; j < na; j++) {
            int64_t i = act[j];
            t[i] = newt[j];
            out[i] = newt[j];
            if (dn[j]) vout[i] = vv[j];
            else act[keep++] = i;
        }
    } else {
        for (Py_ssize_t j = 0; j < na; j++) vout[act[j]] = vv[j];
    }
    PyMem_Free(newt); PyMem_Free(dn); PyMem_Free(vv);
    release(&b);
    return PyLong_FromSsize_t(keep);
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

static PyMethodDef methods[] = {
    {"piece_cumsum", piece_cumsum, METH_VARARGS, "running sums of each chain's pieces"},
    {"tent_rows", tent_rows, METH_VARARGS, "segments.tent_feeds_rows' envelopes (finite positive inputs)"},
    {"share_args", share_args, METH_VARARGS, "the active pieces' durations and np.sinh arguments"},
    {"share_step", share_step, METH_VARARGS, "one Newton step of _share_time"},
    {"tod_args", tod_args, METH_VARARGS, "time_of_distance's np.sinh and ** 3 arguments"},
    {"tod_step", tod_step, METH_VARARGS, "one step of time_of_distance"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef chaincore_module = {
    PyModuleDef_HEAD_INIT, "_gcode_opt_chaincore",
    "Compiled Newton steps of the chains' time sharing (laws/chain.py)", -1, methods};

#ifndef CHAINCORE_SOURCE_SHA256
#define CHAINCORE_SOURCE_SHA256 ""
#endif

PyMODINIT_FUNC PyInit__gcode_opt_chaincore(void) {
    PyObject *mod = PyModule_Create(&chaincore_module);
    if (mod && PyModule_AddStringConstant(mod, "SOURCE_SHA256", CHAINCORE_SOURCE_SHA256) < 0) {
        Py_DECREF(mod);
        return NULL;
    }
    return mod;
}
