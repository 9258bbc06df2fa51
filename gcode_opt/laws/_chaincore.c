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

/* share_args(T, sqb, poff, conv, Tall, args, zmax) -> (m, k)
   The active pieces (those of chains not conv, in order): Tall = [T - h, T, T + h] (3 m,
   h = FD_H_R T), args = [γ/2, γ] (6 m, γ = Tall / sqb) for np.sinh; k = the Horner terms
   the batch needs (_nms_terms over γ²).  m = -1: a duration not finite and > 0 or a γ
   not below GAMMA_SWITCH (the numpy code then runs: its error or its other branch). */
static PyObject *share_args(PyObject *self, PyObject *a) {
    PyObject *oT, *osqb, *opoff, *oconv, *oTall, *oargs, *ozmax;
    if (!PyArg_ParseTuple(a, "OOOOOOO", &oT, &osqb, &opoff, &oconv, &oTall, &oargs, &ozmax)) return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t P, nc1, nz;
    double *T = get(&b, oT, 8, 0, &P);
    double *sqb = T ? get(&b, osqb, 8, 0, NULL) : NULL;
    int64_t *poff = sqb ? get(&b, opoff, 8, 0, &nc1) : NULL;
    uint8_t *conv = poff ? get(&b, oconv, 1, 0, NULL) : NULL;
    double *Tall = conv ? get(&b, oTall, 8, 1, NULL) : NULL;
    double *args = Tall ? get(&b, oargs, 8, 1, NULL) : NULL;
    double *zmax = args ? get(&b, ozmax, 8, 0, &nz) : NULL;
    if (!zmax) { release(&b); return NULL; }
    Py_ssize_t n_c = nc1 - 1, m = 0;
    for (Py_ssize_t c = 0; c < n_c; c++)
        if (!conv[c]) m += poff[c + 1] - poff[c];
    Py_ssize_t j = 0;
    int bad = 0;
    double zm = -1.0;
    for (Py_ssize_t c = 0; c < n_c && !bad; c++) {
        if (conv[c]) continue;
        for (int64_t p = poff[c]; p < poff[c + 1]; p++, j++) {
            double Ti = T[p], h = FD_H_R * Ti;
            double t3[3] = {Ti - h, Ti, Ti + h};
            for (int q = 0; q < 3; q++) {
                double t = t3[q];
                if (!(t > 0) || !isfinite(t)) { bad = 1; break; }
                double g = t / sqb[p];
                if (!(g < GAMMA_SWITCH)) { bad = 1; break; }
                Tall[q * m + j] = t;
                args[q * m + j] = g / 2;
                args[3 * m + q * m + j] = g;
                double z2 = g * g;
                if (z2 > zm) zm = z2;
            }
            if (bad) break;
        }
    }
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

/* J = ∫ṡ² + β∫s̈² of one piece at duration t (_J3's arithmetic, element by element) */
static inline double piece_J(double L, double beta, double vs, double vd, double t, double t3,
                             double z_half, double sh_half, double z_full, double sh_full,
                             const double *coef, int k) {
    double z2 = z_full * z_full;
    double n = coef[3 * (k - 1)], mm = coef[3 * (k - 1) + 1], s1 = coef[3 * (k - 1) + 2];
    for (int i = k - 2; i >= 0; i--) {
        n = n * z2; n = n + coef[3 * i];
        mm = mm * z2; mm = mm + coef[3 * i + 1];
        s1 = s1 * z2; s1 = s1 + coef[3 * i + 2];
    }
    double sh2 = z_half == 0.0 ? 1.0 : sh_half / z_half;
    double shg = z_full == 0.0 ? 1.0 : sh_full / z_full;
    double n2 = (2 * n) * n, sq = sh2 * sh2;
    double Ig1 = mm / n2, Igp = s1 / n2, Ih = (2 * s1) / sq, Ihp = (2 * (shg + 1)) / sq;
    double A = L - (t * vs) / 2, d = (t * vd) / 2;
    double AA = A * A, dd = d * d;
    double iv = ((L * L + AA * Ig1) + dd * Ih) / t;
    double ia = (AA * Igp + dd * Ihp) / t3;
    return iv + beta * ia;
}

/* share_step(L, beta, vs, vd, T, T_total, poff, conv, lam, first, m, k, Tall, T3, args, sh,
   coef, n_p, d1, inv) -> chains still moving.  One Newton step of _share_time on the
   active pieces (share_args' m, k, Tall; T3 = Tall ** 3 and sh = np.sinh(args) by numpy;
   vs = va + vb, vd = va - vb): T, lam, conv updated in place. */
static PyObject *share_step(PyObject *self, PyObject *a) {
    PyObject *o[20];
    int first, k;
    Py_ssize_t m;
    if (!PyArg_ParseTuple(a, "OOOOOOOOOpniOOOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &first, &m, &k, &o[9], &o[10], &o[11], &o[12], &o[13], &o[14], &o[15], &o[16]))
        return NULL;
    Bufs b = {.n = 0};
    Py_ssize_t nc1;
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
    if (!invb) { release(&b); return NULL; }
    Py_ssize_t n_c = nc1 - 1, j = 0, moving = 0;
    for (Py_ssize_t c = 0; c < n_c; c++) {
        if (conv[c]) continue;
        int64_t p0 = poff[c], p1 = poff[c + 1];
        Py_ssize_t j0 = j;
        double s_inv = 0.0, s_d1inv = 0.0, s_T = 0.0, s_ad1 = 0.0;
        for (int64_t p = p0; p < p1; p++, j++) {
            double J[3];
            for (int q = 0; q < 3; q++) {
                Py_ssize_t i = q * m + j;
                J[q] = piece_J(L[p], beta[p], vs[p], vd[p], Tall[i], T3[i], args[i], sh[i],
                               args[3 * m + i], sh[3 * m + i], coef, k);
            }
            double Ti = T[p], h = FD_H_R * Ti;
            double d1 = (J[2] - J[0]) / (2.0 * h);
            double d2 = ((J[2] - 2.0 * J[1]) + J[0]) / (h * h);
            d2 = np_max(d2, ((1e-12 * fabs(J[1])) / (Ti * Ti)) + 1e-300);
            double inv = 1.0 / d2;
            d1b[j] = d1;
            invb[j] = inv;
            s_inv += inv;
            s_d1inv += d1 * inv;
            s_T += Ti;
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

static PyMethodDef methods[] = {
    {"share_args", share_args, METH_VARARGS, "the active pieces' durations and np.sinh arguments"},
    {"share_step", share_step, METH_VARARGS, "one Newton step of _share_time"},
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
