/* The circle law's preconditioned collocation iteration (laws/circle.py: _precond_cheb),
the derivative and integral series of its laws (CircleBatch._eval_cheb) and the curvature
kernel's arguments (curves.py: _parts_block), their elementwise work compiled.

Optional extension _gcode_opt_curvecore (setup.py builds it; laws/circle.py and curves.py
fall back to the numpy code when it is missing, stale or GCODE_OPT_PURE_PYTHON is set).
It must give the numpy code's bits: every double operation below is the one numpy does,
in the same order (built with -ffp-contract=off, no fast math).  The series' matrix
products stay numpy's (BLAS, _rows_matmul's fixed-shape calls on the same zero-padded
arrays), those of the preconditioned iteration are sums in a fixed order (circle._mm_ordered:
pc_solve does them itself), and np.exp stays numpy's (numpy's is not libm's on every
machine).  Row sums are numpy's pairwise sum (np.add.reduce of a contiguous row);
row maxima and minima propagate NaN as numpy's do.  One exception: screen_rows' speeds and
|a| are a filter's numbers (curves.screen_a_only), accurate sums, not eval_tau's bits. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include "../_npsum.h"      /* np_pairwise_sum: numpy's pairwise sum */

typedef struct {
    Py_buffer v[16];
    int n;
} Bufs;

static void release(Bufs *b) {
    for (int i = 0; i < b->n; i++) PyBuffer_Release(&b->v[i]);
    b->n = 0;
}

/* a C-contiguous buffer of items of `size` bytes and at least `need` items; NULL
   (exception set) otherwise */
static void *get(Bufs *b, PyObject *o, Py_ssize_t size, int writable, Py_ssize_t need) {
    Py_buffer *v = &b->v[b->n];
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(o, v, flags) < 0) return NULL;
    b->n++;
    if (v->itemsize != size) {
        PyErr_SetString(PyExc_TypeError, "curve core: wrong item size");
        return NULL;
    }
    if (v->len / size < need) {
        PyErr_SetString(PyExc_ValueError, "curve core: buffer too small");
        return NULL;
    }
    return v->buf;
}

/* numpy's maximum / minimum: NaN if either is NaN */
static inline double np_max(double a, double b) { return (a >= b || isnan(a)) ? a : b; }
static inline double np_min(double a, double b) { return (a <= b || isnan(a)) ? a : b; }

#define MAX_COLS 1024

/* The elementwise loops below have a 4-wide AVX form (x86-64 with gcc or clang, chosen at
   run time where the CPU has AVX): IEEE add, subtract, multiply, divide and square root
   are correctly rounded whatever the vector width, and the AVX forms do those same
   operations on the same operands in the same order (no fused multiply-add: AVX alone
   has none, and -ffp-contract=off), so each element gets the scalar loop's bits.  Row
   maxima and minima are exact whatever the order; a row holding a NaN (numpy's maxima
   propagate the first NaN, whose payload the scalar loop keeps) is redone by the scalar
   loop.  simd(flag) turns the AVX forms off (0) or back on (1) and returns whether they
   are used: the tests compare the two. */
#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define CURVE_AVX 1
#define AVX_FN __attribute__((target("avx")))
static int avx_ok = -1;       /* the CPU has AVX (-1: not asked yet) */
static int avx_wanted = 1;    /* simd(0) turns the AVX forms off */
static int use_avx(void) {
    if (avx_ok < 0) {
        __builtin_cpu_init();
        avx_ok = __builtin_cpu_supports("avx") ? 1 : 0;
    }
    return avx_ok && avx_wanted;
}
#else
#define CURVE_AVX 0
static int use_avx(void) { return 0; }
#endif

static PyObject *simd(PyObject *self, PyObject *a) {
    int flag = -1;
    if (!PyArg_ParseTuple(a, "|i", &flag)) return NULL;
#if CURVE_AVX
    if (flag >= 0) avx_wanted = flag != 0;
#endif
    return PyBool_FromLong(use_avx());
}

/* dst[0 .. n) = src[0 .. n): 4 doubles a step where the CPU has AVX (a row of a series'
   values is a few KB: memcpy's "rep movsb" copies it no faster natively, and valgrind
   counts it byte by byte) */
#if CURVE_AVX
AVX_FN static void copy_avx(double *dst, const double *src, Py_ssize_t n) {
    Py_ssize_t j = 0;
    for (; j + 4 <= n; j += 4) _mm256_storeu_pd(dst + j, _mm256_loadu_pd(src + j));
    for (; j < n; j++) dst[j] = src[j];
}
#endif
static void copy_row(double *dst, const double *src, Py_ssize_t n, int avx) {
#if CURVE_AVX
    if (avx) {
        copy_avx(dst, src, n);
        return;
    }
#endif
    (void)avx;
    memcpy(dst, src, (size_t)n * sizeof(double));
}

/* rows_take(src, rows, n, k, dst, top): dst[i, j] = src[rows[i], j] for i < n, j < k, rows
   n .. top of dst zero (dst C-contiguous (top, k); src any 2-D float64 array, strided: a
   table, its column slice, or a transpose): circle._series_values' rows of one length in
   _rows_matmul's zero-padded blocks */
static PyObject *rows_take(PyObject *self, PyObject *a) {
    PyObject *osrc, *orows, *odst;
    Py_ssize_t n, k, top;
    if (!PyArg_ParseTuple(a, "OOnnOn", &osrc, &orows, &n, &k, &odst, &top)) return NULL;
    Py_buffer sv;
    if (PyObject_GetBuffer(osrc, &sv, PyBUF_STRIDES | PyBUF_FORMAT) < 0) return NULL;
    if (sv.ndim != 2 || sv.itemsize != 8 || !sv.format || strcmp(sv.format, "d") != 0 ||
        n < 0 || k < 1 || k > sv.shape[1] || top < n) {
        PyBuffer_Release(&sv);
        PyErr_SetString(PyExc_ValueError, "rows_take: a 2-D float64 table, 0 < k <= its width, n <= top");
        return NULL;
    }
    Bufs b = {.n = 0};
    const int64_t *rows = get(&b, orows, 8, 0, n);
    double *dst = rows ? get(&b, odst, 8, 1, top * k) : NULL;
    if (!dst) { release(&b); PyBuffer_Release(&sv); return NULL; }
    const char *src = sv.buf;
    Py_ssize_t rs = sv.strides[0], cs = sv.strides[1];
    int avx = cs == 8 && use_avx();
    for (Py_ssize_t i = 0; i < n; i++) {
        Py_ssize_t r = (Py_ssize_t)rows[i];
        if (r < 0 || r >= sv.shape[0]) {
            release(&b);
            PyBuffer_Release(&sv);
            PyErr_SetString(PyExc_IndexError, "rows_take: row out of range");
            return NULL;
        }
        const char *sr = src + r * rs;
        double *dr = dst + i * k;
        if (cs == 8) {
            copy_row(dr, (const double *)sr, k, avx);
        } else {
            for (Py_ssize_t j = 0; j < k; j++) memcpy(dr + j, sr + j * cs, sizeof(double));
        }
    }
    memset(dst + n * k, 0, (size_t)((top - n) * k) * sizeof(double));
    release(&b);
    PyBuffer_Release(&sv);
    Py_RETURN_NONE;
}

/* rows_put(src, n, m, rows, dst): dst[rows[i]] = src[i] for i < n, rows of m doubles (both
   C-contiguous): the products' rows back in their places */
static PyObject *rows_put(PyObject *self, PyObject *a) {
    PyObject *osrc, *orows, *odst;
    Py_ssize_t n, m;
    if (!PyArg_ParseTuple(a, "OnnOO", &osrc, &n, &m, &orows, &odst)) return NULL;
    if (n < 0 || m < 0) {
        PyErr_SetString(PyExc_ValueError, "rows_put: bad sizes");
        return NULL;
    }
    Bufs b = {.n = 0};
    const double *src = get(&b, osrc, 8, 0, n * m);
    const int64_t *rows = src ? get(&b, orows, 8, 0, n) : NULL;
    double *dst = rows ? get(&b, odst, 8, 1, 0) : NULL;
    if (!dst) { release(&b); return NULL; }
    Py_ssize_t len = b.v[2].len / 8;
    int avx = use_avx();
    for (Py_ssize_t i = 0; i < n; i++) {
        Py_ssize_t r = (Py_ssize_t)rows[i];
        if (r < 0 || (r + 1) * m > len) {
            release(&b);
            PyErr_SetString(PyExc_IndexError, "rows_put: row out of range");
            return NULL;
        }
        copy_row(dst + r * m, src + i * m, m, avx);
    }
    release(&b);
    Py_RETURN_NONE;
}

/* The preconditioned iteration of _precond_cheb, one arc at a time (each arc's iteration is
   its own: the batch form's active set only says which arcs still step).  Its three matrix
   products are the ordered sums of circle._mm_ordered: out[j] = x[0] M[0][j] + x[1] M[1][j]
   + ..., each product rounded, then added in the order of k (the numpy fallback does the same
   operations, so the same bits; no BLAS call of 32-row blocks, ~20 k instructions each).
   The matrices are held with rows of jp >= J doubles (jp a multiple of 4, zero beyond J). */
typedef struct {
    Py_ssize_t n, nc, ni, jp;       /* N, N + 1 nodes, N - 1 interior ones, padded row length */
    const double *d2, *vinv, *v;    /* (nc, jp), (ni, jp), (ni, jp): d2_t, vinv_t, v_t padded */
    const double *q, *lam_e, *qv, *e, *qe;
    Py_ssize_t iters;
    double slow_r, tol, floor_r;
} PcConst;

/* out[j] = sum over k < K of x[k] M[k][j] in the order of k (j < J), M rows of jp doubles */
static void mv_ordered(const double *x, Py_ssize_t K, const double *M, Py_ssize_t J, Py_ssize_t jp, double *out) {
    for (Py_ssize_t j = 0; j < J; j++) {
        double acc = x[0] * M[j];
        for (Py_ssize_t k = 1; k < K; k++) acc = acc + x[k] * M[k * jp + j];
        out[j] = acc;
    }
}

/* the end of a step of the iteration: 1 converged (at the rounding floor of the residual,
   steps no longer shrinking, or below it, or the steps left, a geometric series at the last
   step ratio, within it), 0 stopped unconverged (slow or not finite), -1 on; *last the step
   before */
static inline int pc_next(Py_ssize_t it, double step, double *last, double scale, const PcConst *P) {
    const int slow = it >= 4 && !(step < P->slow_r * *last);
    if (step <= P->tol * scale || (slow && step <= P->floor_r * scale)) return 1;
    const double rho = step / *last;
    if (it >= 1 && rho < 1.0 && step * rho <= P->tol * scale * (1.0 - rho)) return 1;
    if (slow || !isfinite(step)) return 0;
    *last = step;
    return -1;
}

/* One arc's iteration (circle._precond_cheb_np's steps for one row; w its N + 1 node values,
   the ends set, updated in place with *cc); returns ok (converged) */
static int pc_row(double *w, double *cc, double g2, double ph, double scale, const PcConst *P) {
    const Py_ssize_t nc = P->nc, ni = P->ni, jp = P->jp;
    double m1[MAX_COLS], r1[MAX_COLS], den[MAX_COLS], t1[MAX_COLS], t2[MAX_COLS], x[MAX_COLS], dw[MAX_COLS];
    double last = INFINITY;
    for (Py_ssize_t it = 0; it < P->iters; it++) {
        const double ca = *cc;
        double *wi = w + 1;
        /* r1 = w @ d2_t - g2 wi - 2 wi w2 - ca,  r2 = (w q).sum() - phi,  den */
        mv_ordered(w, nc, P->d2, ni, jp, m1);
        double mx = 0.0, mn = 0.0;
        for (Py_ssize_t j = 0; j < ni; j++) {
            const double wj = wi[j], w2 = wj * wj;
            r1[j] = ((m1[j] - g2 * wj) - (2.0 * wj) * w2) - ca;
            mx = j == 0 ? w2 : np_max(mx, w2);
            mn = j == 0 ? w2 : np_min(mn, w2);
        }
        for (Py_ssize_t j = 0; j < nc; j++) t1[j] = w[j] * P->q[j];
        const double r2 = np_pairwise_sum(t1, nc) - ph;
        const double dd = g2 + 3.0 * (mx + mn);
        for (Py_ssize_t j = 0; j < ni; j++) den[j] = P->lam_e[j] - dd;
        /* b = -(r1 @ vinv_t), dc, x = (b + dc e) / den, dw = x @ v_t */
        mv_ordered(r1, ni, P->vinv, ni, jp, m1);
        for (Py_ssize_t j = 0; j < ni; j++) {
            t1[j] = (-m1[j] / den[j]) * P->qv[j];
            t2[j] = P->qe[j] / den[j];
        }
        const double dc = (-r2 - np_pairwise_sum(t1, ni)) / np_pairwise_sum(t2, ni);
        for (Py_ssize_t j = 0; j < ni; j++) x[j] = (-m1[j] + dc * P->e[j]) / den[j];
        mv_ordered(x, ni, P->v, ni, jp, dw);
        double step = 0.0;
        for (Py_ssize_t j = 0; j < ni; j++) {
            wi[j] = wi[j] + dw[j];
            const double ad = fabs(dw[j]);
            step = j == 0 ? ad : np_max(step, ad);
        }
        *cc = ca + dc;
        const int end = pc_next(it, step, &last, scale, P);
        if (end >= 0) return end;
    }
    return 0;
}

#if CURVE_AVX
/* mv_ordered on nv * 4 columns (nv <= 8 accumulators held in registers) */
static inline __attribute__((always_inline, target("avx"))) void mv_blk(const double *x, Py_ssize_t K,
                                                                          const double *m, Py_ssize_t jp,
                                                                          double *out, const int nv) {
    __m256d acc[8];
    __m256d xk = _mm256_set1_pd(x[0]);
#pragma GCC unroll 8
    for (int v = 0; v < nv; v++) acc[v] = _mm256_mul_pd(xk, _mm256_loadu_pd(m + 4 * v));
    for (Py_ssize_t k = 1; k < K; k++) {
        m += jp;
        xk = _mm256_set1_pd(x[k]);
#pragma GCC unroll 8
        for (int v = 0; v < nv; v++) acc[v] = _mm256_add_pd(acc[v], _mm256_mul_pd(xk, _mm256_loadu_pd(m + 4 * v)));
    }
#pragma GCC unroll 8
    for (int v = 0; v < nv; v++) _mm256_storeu_pd(out + 4 * v, acc[v]);
}

/* mv_ordered on all jp columns, 32 at a time (the padding columns give zeros, unread) */
AVX_FN static void mv_ordered_avx(const double *x, Py_ssize_t K, const double *M, Py_ssize_t jp, double *out) {
    for (Py_ssize_t j = 0; j < jp; j += 32) {
        const Py_ssize_t nv = jp - j >= 32 ? 8 : (jp - j) / 4;
        switch (nv) {
        case 8: mv_blk(x, K, M + j, jp, out + j, 8); break;
        case 7: mv_blk(x, K, M + j, jp, out + j, 7); break;
        case 6: mv_blk(x, K, M + j, jp, out + j, 6); break;
        case 5: mv_blk(x, K, M + j, jp, out + j, 5); break;
        case 4: mv_blk(x, K, M + j, jp, out + j, 4); break;
        case 3: mv_blk(x, K, M + j, jp, out + j, 3); break;
        case 2: mv_blk(x, K, M + j, jp, out + j, 2); break;
        default: mv_blk(x, K, M + j, jp, out + j, 1); break;
        }
    }
}

/* max over a row of numpy's maximum (NaN first seen) from a vector of running maxima and a
   flag of unordered lanes: the lanes' maximum, or the scalar fold when a NaN was met */
AVX_FN static double lanes_max(__m256d v) {
    double l[4];
    _mm256_storeu_pd(l, v);
    double m = l[0];
    for (int c = 1; c < 4; c++) m = l[c] > m ? l[c] : m;
    return m;
}

AVX_FN static double lanes_min(__m256d v) {
    double l[4];
    _mm256_storeu_pd(l, v);
    double m = l[0];
    for (int c = 1; c < 4; c++) m = l[c] < m ? l[c] : m;
    return m;
}

/* pc_row with its elementwise loops 4 columns at a time (the same operations on the same
   operands in the same order: the same bits; a row maximum or minimum over a NaN is the
   scalar fold's, numpy's).  np_pairwise_sum is compiled for any x86-64 (SSE, not VEX, code):
   reached with the upper halves of the YMM registers dirty, its SSE instructions pay for them
   (an AVX-SSE transition or a merge with the upper state, by CPU: this function took ~90 ms
   of CPU on the rectilinear plate's arcs, the same code built with -mavx throughout ~29 ms,
   for the same instructions), so they are cleared (vzeroupper) before each call. */
AVX_FN static int pc_row_avx(double *w, double *cc, double g2, double ph, double scale, const PcConst *P) {
    const Py_ssize_t nc = P->nc, ni = P->ni, jp = P->jp, nv = ni / 4 * 4;
    double m1[MAX_COLS], r1[MAX_COLS], den[MAX_COLS], t1[MAX_COLS], t2[MAX_COLS], x[MAX_COLS], dw[MAX_COLS];
    double last = INFINITY;
    const __m256d sign = _mm256_set1_pd(-0.0), vg = _mm256_set1_pd(g2), two = _mm256_set1_pd(2.0);
    for (Py_ssize_t it = 0; it < P->iters; it++) {
        const double ca = *cc;
        double *wi = w + 1;
        mv_ordered_avx(w, nc, P->d2, jp, m1);
        const __m256d vc = _mm256_set1_pd(ca);
        __m256d vmx = _mm256_set1_pd(-INFINITY), vmn = _mm256_set1_pd(INFINITY), bad = _mm256_setzero_pd();
        Py_ssize_t j = 0;
        for (; j < nv; j += 4) {
            const __m256d wj = _mm256_loadu_pd(wi + j), w2 = _mm256_mul_pd(wj, wj);
            __m256d t = _mm256_sub_pd(_mm256_loadu_pd(m1 + j), _mm256_mul_pd(vg, wj));
            t = _mm256_sub_pd(t, _mm256_mul_pd(_mm256_mul_pd(two, wj), w2));
            _mm256_storeu_pd(r1 + j, _mm256_sub_pd(t, vc));
            vmx = _mm256_max_pd(vmx, w2);
            vmn = _mm256_min_pd(vmn, w2);
            bad = _mm256_or_pd(bad, _mm256_cmp_pd(w2, w2, _CMP_UNORD_Q));
        }
        double mx = lanes_max(vmx), mn = lanes_min(vmn);
        int nan = _mm256_movemask_pd(bad);
        for (; j < ni; j++) {
            const double wj = wi[j], w2 = wj * wj;
            r1[j] = ((m1[j] - g2 * wj) - (2.0 * wj) * w2) - ca;
            nan |= isnan(w2);
            mx = w2 > mx ? w2 : mx;
            mn = w2 < mn ? w2 : mn;
        }
        if (nan)
            for (j = 0; j < ni; j++) {
                const double w2 = wi[j] * wi[j];
                mx = j == 0 ? w2 : np_max(mx, w2);
                mn = j == 0 ? w2 : np_min(mn, w2);
            }
        for (j = 0; j + 4 <= nc; j += 4)
            _mm256_storeu_pd(t1 + j, _mm256_mul_pd(_mm256_loadu_pd(w + j), _mm256_loadu_pd(P->q + j)));
        for (; j < nc; j++) t1[j] = w[j] * P->q[j];
        _mm256_zeroupper();        /* (np_pairwise_sum: SSE code, see above) */
        const double r2 = np_pairwise_sum(t1, nc) - ph;
        const __m256d vd = _mm256_set1_pd(g2 + 3.0 * (mx + mn));
        mv_ordered_avx(r1, ni, P->vinv, jp, m1);
        for (j = 0; j < jp; j += 4) {      /* (padding: lam_e, qv, qe zero there; unread) */
            const __m256d dv = _mm256_sub_pd(_mm256_loadu_pd(P->lam_e + j), vd);
            _mm256_storeu_pd(den + j, dv);
            const __m256d bj = _mm256_xor_pd(_mm256_loadu_pd(m1 + j), sign);
            _mm256_storeu_pd(t1 + j, _mm256_mul_pd(_mm256_div_pd(bj, dv), _mm256_loadu_pd(P->qv + j)));
            _mm256_storeu_pd(t2 + j, _mm256_div_pd(_mm256_loadu_pd(P->qe + j), dv));
        }
        _mm256_zeroupper();
        const double dc = (-r2 - np_pairwise_sum(t1, ni)) / np_pairwise_sum(t2, ni);
        const __m256d vdc = _mm256_set1_pd(dc);
        for (j = 0; j < jp; j += 4) {
            const __m256d bj = _mm256_xor_pd(_mm256_loadu_pd(m1 + j), sign);
            const __m256d t = _mm256_add_pd(bj, _mm256_mul_pd(vdc, _mm256_loadu_pd(P->e + j)));
            _mm256_storeu_pd(x + j, _mm256_div_pd(t, _mm256_loadu_pd(den + j)));
        }
        mv_ordered_avx(x, ni, P->v, jp, dw);
        __m256d vst = _mm256_setzero_pd();
        bad = _mm256_setzero_pd();
        for (j = 0; j < nv; j += 4) {
            const __m256d d = _mm256_loadu_pd(dw + j), ad = _mm256_andnot_pd(sign, d);
            _mm256_storeu_pd(wi + j, _mm256_add_pd(_mm256_loadu_pd(wi + j), d));
            vst = _mm256_max_pd(vst, ad);
            bad = _mm256_or_pd(bad, _mm256_cmp_pd(ad, ad, _CMP_UNORD_Q));
        }
        double step = lanes_max(vst);
        nan = _mm256_movemask_pd(bad);
        for (; j < ni; j++) {
            wi[j] = wi[j] + dw[j];
            const double ad = fabs(dw[j]);
            nan |= isnan(ad);
            step = ad > step ? ad : step;
        }
        if (nan) step = NAN;       /* (numpy's maximum: NaN; a NaN step only stops the row) */
        *cc = ca + dc;
        const int end = pc_next(it, step, &last, scale, P);
        if (end >= 0) return end;
    }
    return 0;
}
#endif

/* a (rows, cols) C-contiguous matrix into rows of jp doubles, zero beyond cols */
static double *padded(const double *m, Py_ssize_t rows, Py_ssize_t cols, Py_ssize_t jp) {
    double *p = calloc((size_t)(rows * jp), sizeof(double));
    if (p)
        for (Py_ssize_t r = 0; r < rows; r++) memcpy(p + r * jp, m + r * cols, (size_t)cols * sizeof(double));
    return p;
}

/* pc_solve(w, cc, ok, nb, n, gam2, phi, scale, d2_t, q, lam_e, vinv_t, v_t, qv, e, iters, slow_r, tol,
   floor): circle._precond_cheb_np's iteration for each of the nb arcs, w (nb, N + 1) the start
   nodes with their ends set, cc (nb) zeros: both updated in place, ok[i] set (1) or cleared */
static PyObject *pc_solve(PyObject *self, PyObject *a) {
    PyObject *o[13];
    Py_ssize_t nb, n, iters;
    double slow_r, tol, floor_r;
    if (!PyArg_ParseTuple(a, "OOOnnOOOOOOOOOOnddd", &o[0], &o[1], &o[2], &nb, &n, &o[3], &o[4], &o[5], &o[6],
                          &o[7], &o[8], &o[9], &o[10], &o[11], &o[12], &iters, &slow_r, &tol, &floor_r))
        return NULL;
    if (n < 2 || n + 1 > MAX_COLS || nb < 0) {
        PyErr_SetString(PyExc_ValueError, "pc_solve: bad n");
        return NULL;
    }
    const Py_ssize_t nc = n + 1, ni = n - 1, jp = (ni + 3) / 4 * 4;
    Bufs b = {.n = 0};
    double *w = get(&b, o[0], 8, 1, nb * nc);
    double *cc = w ? get(&b, o[1], 8, 1, nb) : NULL;
    char *ok = cc ? get(&b, o[2], 1, 1, nb) : NULL;
    const double *gam2 = ok ? get(&b, o[3], 8, 0, nb) : NULL;
    const double *phi = gam2 ? get(&b, o[4], 8, 0, nb) : NULL;
    const double *scale = phi ? get(&b, o[5], 8, 0, nb) : NULL;
    const double *d2_t = scale ? get(&b, o[6], 8, 0, nc * ni) : NULL;
    const double *q = d2_t ? get(&b, o[7], 8, 0, nc) : NULL;
    const double *lam_e = q ? get(&b, o[8], 8, 0, ni) : NULL;
    const double *vinv_t = lam_e ? get(&b, o[9], 8, 0, ni * ni) : NULL;
    const double *v_t = vinv_t ? get(&b, o[10], 8, 0, ni * ni) : NULL;
    const double *qv = v_t ? get(&b, o[11], 8, 0, ni) : NULL;
    const double *e = qv ? get(&b, o[12], 8, 0, ni) : NULL;
    if (!e) { release(&b); return NULL; }
    /* the vectors of ni, zero up to jp (the AVX loops run over whole vectors) */
    double lam_p[MAX_COLS] = {0}, qv_p[MAX_COLS] = {0}, e_p[MAX_COLS] = {0}, qe[MAX_COLS] = {0};
    for (Py_ssize_t j = 0; j < ni; j++) {
        lam_p[j] = lam_e[j], qv_p[j] = qv[j], e_p[j] = e[j];
        qe[j] = qv[j] * e[j];
    }
    double *md2 = padded(d2_t, nc, ni, jp), *mvi = padded(vinv_t, ni, ni, jp), *mvv = padded(v_t, ni, ni, jp);
    if (!md2 || !mvi || !mvv) {
        free(md2), free(mvi), free(mvv);
        release(&b);
        return PyErr_NoMemory();
    }
    const PcConst P = {n, nc, ni, jp, md2, mvi, mvv, q, lam_p, qv_p, e_p, qe, iters, slow_r, tol, floor_r};
#if CURVE_AVX
    if (use_avx() && ni >= 4) {
        for (Py_ssize_t i = 0; i < nb; i++)
            ok[i] = (char)pc_row_avx(w + i * nc, cc + i, gam2[i], phi[i], scale[i], &P);
    } else
#endif
    for (Py_ssize_t i = 0; i < nb; i++) ok[i] = (char)pc_row(w + i * nc, cc + i, gam2[i], phi[i], scale[i], &P);
    free(md2), free(mvi), free(mvv);
    release(&b);
    Py_RETURN_NONE;
}

/* jerk_caps(u, jx, jy, jerk_r, m, n, out): curves._jerk_caps (marlin_jerk_junction_v with
   nominal speeds 1e6, no safe speeds, z = 0) at the n - 1 interior vertices of m strokes of
   n unit directions u (m, n, 2), the axis jerks jerk_r * jx[r], jerk_r * jy[r] (r the
   stroke), into out (m, n - 1): _jerk_caps' np.where choices and products in its order */
static inline double jk_pmax(double a, double b) { return b > a ? b : a; }

static inline double axis_jerk(double ex, double en) {
    if (ex > en) return (en > 0.0 || ex < 0.0) ? ex - en : jk_pmax(ex, -en);
    return (en < 0.0 || ex > 0.0) ? en - ex : jk_pmax(-ex, en);
}

static PyObject *jerk_caps(PyObject *self, PyObject *a) {
    PyObject *ou, *ox, *oy, *oo;
    double jerk_r;
    Py_ssize_t m, n;
    if (!PyArg_ParseTuple(a, "OOOdnnO", &ou, &ox, &oy, &jerk_r, &m, &n, &oo)) return NULL;
    if (n < 1 || m < 0) {
        PyErr_SetString(PyExc_ValueError, "jerk_caps: bad size");
        return NULL;
    }
    Bufs b = {.n = 0};
    const double *u = get(&b, ou, 8, 0, m * n * 2);
    const double *jxs = u ? get(&b, ox, 8, 0, m) : NULL;
    const double *jys = jxs ? get(&b, oy, 8, 0, m) : NULL;
    double *out = jys ? get(&b, oo, 8, 1, m * (n - 1)) : NULL;
    if (!out) { release(&b); return NULL; }
    const double big = 1e6;
    for (Py_ssize_t r = 0; r < m; r++) {
        const double jx = jerk_r * jxs[r], jy = jerk_r * jys[r];
        const double *ur = u + r * n * 2;
        double *o = out + r * (n - 1);
        for (Py_ssize_t k = 0; k + 1 < n; k++) {
            const double pux = ur[2 * k], puy = ur[2 * k + 1], ux = ur[2 * k + 2], uy = ur[2 * k + 3];
            double jerk = axis_jerk((pux * big) * 1.0, ux * big);
            const int lim_x = jerk > jx;
            double vf = lim_x ? 1.0 * (jx / jerk) : 1.0;
            double ex = (puy * big) * 1.0, en = uy * big;
            if (lim_x) {
                ex = ex * vf;
                en = en * vf;
            }
            jerk = axis_jerk(ex, en);
            const int lim_y = jerk > jy;
            if (lim_y) vf = vf * (jy / jerk);
            o[k] = (lim_x || lim_y) ? big * vf : big;
        }
    }
    release(&b);
    Py_RETURN_NONE;
}

/* kern_args(s_v, sd, m, n1, kern): _parts_block's kernel before np.exp, for m strokes of
   n1 = n + 1 vertices (s_v (m, n1), sd (m,), kern (m, n1, n1 - 2)):
     z = ((s_v[:, :, None] - s_v[:, None, 1:-1]) / sd) ** 2,  kern = (z - z.min(axis=2)) * -0.5 */
static void kern_row(const double *si, Py_ssize_t ni, double sj, double d, double *kr) {
    double mn = 0.0;
    for (Py_ssize_t i = 0; i < ni; i++) {
        double t = (sj - si[i]) / d;
        t = t * t;
        kr[i] = t;
        mn = i == 0 ? t : np_min(mn, t);
    }
    for (Py_ssize_t i = 0; i < ni; i++) kr[i] = (kr[i] - mn) * -0.5;
}

#if CURVE_AVX
/* kern_row's numbers; 0 (the row to be redone by kern_row) if one of its squares is NaN */
AVX_FN static int kern_row_avx(const double *si, Py_ssize_t ni, double sj, double d, double *kr) {
    const __m256d vs = _mm256_set1_pd(sj), vd = _mm256_set1_pd(d);
    __m256d vmn = _mm256_set1_pd(INFINITY), bad = _mm256_setzero_pd();
    Py_ssize_t i = 0;
    for (; i + 4 <= ni; i += 4) {
        __m256d t = _mm256_div_pd(_mm256_sub_pd(vs, _mm256_loadu_pd(si + i)), vd);
        t = _mm256_mul_pd(t, t);
        _mm256_storeu_pd(kr + i, t);
        vmn = _mm256_min_pd(vmn, t);
        bad = _mm256_or_pd(bad, _mm256_cmp_pd(t, t, _CMP_UNORD_Q));
    }
    if (_mm256_movemask_pd(bad)) return 0;
    double m4[4];
    _mm256_storeu_pd(m4, vmn);
    double mn = m4[0];
    for (int j = 1; j < 4; j++) mn = m4[j] < mn ? m4[j] : mn;
    for (; i < ni; i++) {
        double t = (sj - si[i]) / d;
        t = t * t;
        kr[i] = t;
        if (isnan(t)) return 0;
        mn = t < mn ? t : mn;
    }
    const __m256d vm = _mm256_set1_pd(mn), h = _mm256_set1_pd(-0.5);
    for (i = 0; i + 4 <= ni; i += 4)
        _mm256_storeu_pd(kr + i, _mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(kr + i), vm), h));
    for (; i < ni; i++) kr[i] = (kr[i] - mn) * -0.5;
    return 1;
}
#endif

static PyObject *kern_args(PyObject *self, PyObject *a) {
    PyObject *os, *osd, *ok;
    Py_ssize_t m, n1;
    if (!PyArg_ParseTuple(a, "OOnnO", &os, &osd, &m, &n1, &ok)) return NULL;
    if (n1 < 3 || m < 0) {
        PyErr_SetString(PyExc_ValueError, "kern_args: bad size");
        return NULL;
    }
    Py_ssize_t ni = n1 - 2;
    Bufs b = {.n = 0};
    const double *s = get(&b, os, 8, 0, m * n1);
    const double *sd = s ? get(&b, osd, 8, 0, m) : NULL;
    double *k = sd ? get(&b, ok, 8, 1, m * n1 * ni) : NULL;
    if (!k) { release(&b); return NULL; }
#if CURVE_AVX
    const int avx = use_avx() && ni >= 4;      /* shorter rows: no whole vector */
#endif
    for (Py_ssize_t r = 0; r < m; r++) {
        const double *sr = s + r * n1;
        const double d = sd[r];
        for (Py_ssize_t j = 0; j < n1; j++) {
            double *kr = k + (r * n1 + j) * ni;
#if CURVE_AVX
            if (avx && kern_row_avx(sr + 1, ni, sr[j], d, kr)) continue;
#endif
            kern_row(sr + 1, ni, sr[j], d, kr);
        }
    }
    release(&b);
    Py_RETURN_NONE;
}

/* kern_pack(s_v, sd, m, n1, lo, mirror, buf, rng, sym) -> count: kern_args' arguments, row by row
   (the same operations), but only those not below lo (NaN included) kept, packed in buf in
   order, as exp_split would pack them (np.exp then takes buf[:count]); rng (m n1 2 int64)
   the first and end index of each row's packed run.  A row's arguments are unimodal in the
   index (s_v sorted: rounding is monotone), so its kept ones are one run; -1 if a row's
   are not (unsorted or NaN arguments: the caller takes kern_args and exp_split then).
   Where that is known beforehand (one_run_rows) and mirror is 1, the interior rows pack
   only their run from the diagonal on (sym_row: the kernel's interior block is
   symmetric, bit for bit), about half of them: sym[r] = 1 for such a stroke, else 0.
   kern_unpack(kern, m, n1, rng, buf, count, sym): exp_merge's kern from them, +0.0 outside
   each row's run, the interior rows of a sym stroke left of their diagonal copied from
   the rows above (kern[j][i] = kern[i + 1][j - 1]).  The full kernel is written once, not
   three times (kern_args, exp_merge) and read twice (exp_split, exp_merge), and np.exp
   takes each argument of a symmetric pair once. */
static Py_ssize_t kept_run(const double *kr, Py_ssize_t ni, double lo, Py_ssize_t *a, Py_ssize_t *e) {
    Py_ssize_t i = 0;
    while (i < ni && kr[i] < lo) i++;
    *a = i;
    while (i < ni && !(kr[i] < lo)) i++;
    *e = i;
    while (i < ni && kr[i] < lo) i++;
    return i == ni;           /* 0: a kept argument after the run */
}

/* kept_run of a row whose arguments are known to be one run (kern_pack's sorted rows):
   only the dropped arguments at its two ends are read */
static void run_ends(const double *kr, Py_ssize_t ni, double lo, Py_ssize_t *a, Py_ssize_t *e) {
    Py_ssize_t i = 0, j = ni;
    while (i < ni && kr[i] < lo) i++;
    while (j > i && kr[j - 1] < lo) j--;
    *a = i;
    *e = j;
}

/* whether kern_row's arguments of the stroke (vertices s (n1), width d) are one run in
   every row: s finite, its interior vertices in order and d > 0 finite.  Then each row's
   z_i = ((s_j - s_i) / d)^2 falls then rises with i (each rounded step is monotone, the
   overflows included), (z_i - min z) * -0.5 rises then falls, and those not below lo are
   one run (or, the minimum infinite, every argument NaN: one run too). */
static int one_run_rows(const double *s, Py_ssize_t n1, double d) {
    if (!(d > 0.0) || !isfinite(d)) return 0;
    for (Py_ssize_t i = 0; i < n1; i++)
        if (!isfinite(s[i])) return 0;
    for (Py_ssize_t i = 1; i + 2 < n1; i++)
        if (!(s[i + 1] >= s[i])) return 0;
    return 1;
}

/* sym_row(si, ni, i0, sj, d, lo, out) -> count: the kept arguments of the interior row j
   (i0 = j - 1, its diagonal column) of a stroke one_run_rows takes, from the diagonal to the
   run's end, into out.  There every z_i = ((s_j - s_i) / d)^2 is +0.0 or more (no NaN) and
   the diagonal's is +0.0, so the row's minimum is +0.0 and kern_row's argument
   (z_i - min) * -0.5 is z_i * -0.5, the same double; and z_ji = z_ij bit for bit
   (fl(s_i - s_j) = -fl(s_j - s_i), and division and squaring round symmetrically): the
   row's arguments left of its diagonal are those above the diagonal in its column, which
   kern_unpack copies.  The arguments fall from the diagonal on (the row is one run), so
   the first one below lo ends the run. */
static Py_ssize_t sym_row(const double *si, Py_ssize_t ni, Py_ssize_t i0, double sj, double d, double lo,
                          double *out) {
    Py_ssize_t i = i0;
    for (; i < ni; i++) {
        double t = (sj - si[i]) / d;
        double x = (t * t) * -0.5;
        if (x < lo) break;
        out[i - i0] = x;
    }
    return i - i0;
}

#if CURVE_AVX
/* sym_row, 4 columns at a time (the same operations per element) */
AVX_FN static Py_ssize_t sym_row_avx(const double *si, Py_ssize_t ni, Py_ssize_t i0, double sj, double d,
                                     double lo, double *out) {
    const __m256d vs = _mm256_set1_pd(sj), vd = _mm256_set1_pd(d), h = _mm256_set1_pd(-0.5),
                  vlo = _mm256_set1_pd(lo);
    Py_ssize_t i = i0;
    for (; i + 4 <= ni; i += 4) {
        __m256d t = _mm256_div_pd(_mm256_sub_pd(vs, _mm256_loadu_pd(si + i)), vd);
        __m256d x = _mm256_mul_pd(_mm256_mul_pd(t, t), h);
        int below = _mm256_movemask_pd(_mm256_cmp_pd(x, vlo, _CMP_LT_OQ));
        if (below) {                     /* the run ends in these four: its first below lo */
            double x4[4];
            _mm256_storeu_pd(x4, x);
            int k = 0;
            while (!(below & (1 << k))) out[i - i0 + k] = x4[k], k++;
            return i - i0 + k;
        }
        _mm256_storeu_pd(out + (i - i0), x);
    }
    return i - i0 + sym_row(si, ni, i, sj, d, lo, out + (i - i0));
}
#endif

static PyObject *kern_pack(PyObject *self, PyObject *a) {
    PyObject *os, *osd, *ob, *orng, *osym;
    Py_ssize_t m, n1;
    double lo;
    int mirror;
    if (!PyArg_ParseTuple(a, "OOnndpOOO", &os, &osd, &m, &n1, &lo, &mirror, &ob, &orng, &osym)) return NULL;
    if (n1 < 3 || m < 0) {
        PyErr_SetString(PyExc_ValueError, "kern_pack: bad size");
        return NULL;
    }
    Py_ssize_t ni = n1 - 2;
    Bufs b = {.n = 0};
    const double *s = get(&b, os, 8, 0, m * n1);
    const double *sd = s ? get(&b, osd, 8, 0, m) : NULL;
    double *buf = sd ? get(&b, ob, 8, 1, m * n1 * ni) : NULL;
    int64_t *rng = buf ? get(&b, orng, 8, 1, m * n1 * 2) : NULL;
    int64_t *sym = rng ? get(&b, osym, 8, 1, m) : NULL;
    if (!sym) { release(&b); return NULL; }
#if CURVE_AVX
    const int avx = use_avx() && ni >= 4;
#endif
    Py_ssize_t c = 0;
    for (Py_ssize_t r = 0; r < m; r++) {
        const double *sr = s + r * n1;
        const double d = sd[r];
        const int known = one_run_rows(sr, n1, d);
        sym[r] = known && mirror;
        for (Py_ssize_t j = 0; j < n1; j++) {
            double *kr = buf + c;           /* the row made in place, its run moved down to c */
            if (sym[r] && j >= 1 && j + 1 < n1) {
                Py_ssize_t cnt;
#if CURVE_AVX
                if (avx)
                    cnt = sym_row_avx(sr + 1, ni, j - 1, sr[j], d, lo, kr);
                else
#endif
                    cnt = sym_row(sr + 1, ni, j - 1, sr[j], d, lo, kr);
                rng[2 * (r * n1 + j)] = j - 1;
                rng[2 * (r * n1 + j) + 1] = j - 1 + cnt;
                c += cnt;
                continue;
            }
#if CURVE_AVX
            if (!(avx && kern_row_avx(sr + 1, ni, sr[j], d, kr)))
#endif
                kern_row(sr + 1, ni, sr[j], d, kr);
            Py_ssize_t ra, re;
            if (known) {
                run_ends(kr, ni, lo, &ra, &re);
            } else if (!kept_run(kr, ni, lo, &ra, &re)) {
                release(&b);
                return PyLong_FromSsize_t(-1);
            }
            if (ra > 0 && re > ra) memmove(kr, kr + ra, (size_t)(re - ra) * sizeof(double));
            rng[2 * (r * n1 + j)] = ra;
            rng[2 * (r * n1 + j) + 1] = re;
            c += re - ra;
        }
    }
    release(&b);
    return PyLong_FromSsize_t(c);
}

static PyObject *kern_unpack(PyObject *self, PyObject *a) {
    PyObject *ok, *orng, *ob, *osym;
    Py_ssize_t m, n1, count;
    if (!PyArg_ParseTuple(a, "OnnOOnO", &ok, &m, &n1, &orng, &ob, &count, &osym)) return NULL;
    if (n1 < 3 || m < 0 || count < 0) {
        PyErr_SetString(PyExc_ValueError, "kern_unpack: bad size");
        return NULL;
    }
    Py_ssize_t ni = n1 - 2;
    Bufs b = {.n = 0};
    double *k = get(&b, ok, 8, 1, m * n1 * ni);
    const int64_t *rng = k ? get(&b, orng, 8, 0, m * n1 * 2) : NULL;
    const double *buf = rng ? get(&b, ob, 8, 0, count) : NULL;
    const int64_t *sym = buf ? get(&b, osym, 8, 0, m) : NULL;
    if (!sym) { release(&b); return NULL; }
    Py_ssize_t c = 0;
    for (Py_ssize_t q = 0; q < m * n1; q++) {
        double *kr = k + q * ni;
        const Py_ssize_t j = q % n1;
        const int mirror = sym[q / n1] && j >= 1 && j + 1 < n1;    /* an interior row of a sym stroke */
        Py_ssize_t ra = (Py_ssize_t)rng[2 * q], re = (Py_ssize_t)rng[2 * q + 1];
        if (ra < 0 || re < ra || re > ni || c + (re - ra) > count || (mirror && ra != j - 1)) {
            release(&b);
            PyErr_SetString(PyExc_ValueError, "kern_unpack: runs do not match the buffer");
            return NULL;
        }
        if (mirror) {                   /* left of the diagonal: the column above it (sym_row) */
            const double *col = kr - (j - 1) * ni + (j - 1);        /* kern[q - j + 1][j - 1] */
            for (Py_ssize_t i = 0; i < ra; i++) kr[i] = col[i * ni];
        } else
            for (Py_ssize_t i = 0; i < ra; i++) kr[i] = 0.0;
        memcpy(kr + ra, buf + c, (size_t)(re - ra) * sizeof(double));
        for (Py_ssize_t i = re; i < ni; i++) kr[i] = 0.0;
        c += re - ra;
    }
    release(&b);
    Py_RETURN_NONE;
}

/* exp_split(kern, total, lo, buf) -> count: the arguments kern[i] not below lo (NaN
   included) copied to buf in order, for one np.exp on them; exp_merge(kern, total, lo,
   buf): kern[i] = +0.0 where kern[i] < lo, else the next of buf.  curves.py uses them only
   where np.exp gave +0.0 on a probe of arguments below lo (_EXP_ZERO_OK): with them, the
   ~26 % of the curvature kernel's arguments that underflow (libm's slow path) skip np.exp. */
static PyObject *exp_split(PyObject *self, PyObject *a) {
    PyObject *ok, *ob;
    Py_ssize_t total;
    double lo;
    if (!PyArg_ParseTuple(a, "OndO", &ok, &total, &lo, &ob)) return NULL;
    Bufs b = {.n = 0};
    const double *k = get(&b, ok, 8, 0, total);
    double *buf = k ? get(&b, ob, 8, 1, total) : NULL;
    if (!buf) { release(&b); return NULL; }
    Py_ssize_t c = 0;
    for (Py_ssize_t i = 0; i < total; i++) {
        double x = k[i];
        if (!(x < lo)) buf[c++] = x;
    }
    release(&b);
    return PyLong_FromSsize_t(c);
}

static PyObject *exp_merge(PyObject *self, PyObject *a) {
    PyObject *ok, *ob;
    Py_ssize_t total, count;
    double lo;
    if (!PyArg_ParseTuple(a, "OndOn", &ok, &total, &lo, &ob, &count)) return NULL;
    Bufs b = {.n = 0};
    double *k = get(&b, ok, 8, 1, total);
    const double *buf = k ? get(&b, ob, 8, 0, count) : NULL;
    if (!buf) { release(&b); return NULL; }
    Py_ssize_t c = 0;
    for (Py_ssize_t i = 0; i < total; i++) {
        if (k[i] < lo) {
            k[i] = 0.0;
        } else {
            if (c >= count) {
                release(&b);
                PyErr_SetString(PyExc_ValueError, "exp_merge: buffer too short");
                return NULL;
            }
            k[i] = buf[c++];
        }
    }
    release(&b);
    Py_RETURN_NONE;
}

/* cheb_der_int(coef, B, K, der_t, int_t): numpy.polynomial.chebyshev's
     chebder(coef, axis=1, scl=2.0)                -> der_t.T  (der_t (K - 1, B))
     chebint(coef, axis=1, lbnd=-1.0, scl=0.5)     -> int_t.T  (int_t (K + 1, B))
   of coef (B, K), K >= 2, row by row: the same operations in the same order as numpy's
   loops over the coefficients (integers times doubles as doubles; chebval at -1 by its
   recurrence); its arrays are (coefficients, rows), so the transposes are laid out as
   numpy's results are.  der_t or int_t None: that one not made (each is made apart). */
#if CURVE_AVX
/* cheb_der_int's rows 4 at a time (K <= DER_INT_AVX_COLS): the scalar loop's operations, each
   on the 4 rows' coefficients at once (IEEE multiply, divide, add, subtract: each element the
   scalar loop's bits), their results stored as 4 adjacent doubles of der and itg (one row of
   each (coefficients, rows) array; either NULL: not made); returns the rows done (a multiple
   of 4), the rest left to the scalar loop */
#define DER_INT_AVX_COLS 256
AVX_FN static Py_ssize_t cheb_der_int_avx(const double *coef, Py_ssize_t nb, Py_ssize_t K, double *der,
                                          double *itg) {
    __m256d cr[DER_INT_AVX_COLS], c[DER_INT_AVX_COLS], t[DER_INT_AVX_COLS + 1];
    const __m256d two = _mm256_set1_pd(2.0), half = _mm256_set1_pd(0.5), zero = _mm256_set1_pd(0.0);
    Py_ssize_t r = 0;
    for (; r + 4 <= nb; r += 4) {
        const double *c0r = coef + r * K, *c1r = c0r + K, *c2r = c1r + K, *c3r = c2r + K;
        for (Py_ssize_t j = 0; j < K; j++) cr[j] = _mm256_set_pd(c3r[j], c2r[j], c1r[j], c0r[j]);
        Py_ssize_t n;
        if (der) {
            /* chebder: c *= scl, then from the top */
            n = K - 1;
            for (Py_ssize_t j = 0; j < K; j++) c[j] = _mm256_mul_pd(cr[j], two);
            for (Py_ssize_t j = n; j > 2; j--) {
                _mm256_storeu_pd(der + (j - 1) * nb + r, _mm256_mul_pd(_mm256_set1_pd((double)(2 * j)), c[j]));
                c[j - 2] = _mm256_add_pd(c[j - 2], _mm256_div_pd(_mm256_mul_pd(_mm256_set1_pd((double)j), c[j]),
                                                                 _mm256_set1_pd((double)(j - 2))));
            }
            if (n > 1) _mm256_storeu_pd(der + 1 * nb + r, _mm256_mul_pd(_mm256_set1_pd(4.0), c[2]));
            _mm256_storeu_pd(der + r, c[1]);
        }
        if (!itg) continue;
        /* chebint: c *= scl, tmp, then tmp[0] += k - chebval(lbnd, tmp) */
        n = K;
        for (Py_ssize_t j = 0; j < K; j++) c[j] = _mm256_mul_pd(cr[j], half);
        t[0] = _mm256_mul_pd(c[0], zero);
        t[1] = c[0];
        t[2] = _mm256_div_pd(c[1], _mm256_set1_pd(4.0));
        for (Py_ssize_t j = 2; j < n; j++) {
            t[j + 1] = _mm256_div_pd(c[j], _mm256_set1_pd((double)(2 * (j + 1))));
            t[j - 1] = _mm256_sub_pd(t[j - 1], _mm256_div_pd(c[j], _mm256_set1_pd((double)(2 * (j - 1)))));
        }
        Py_ssize_t L = n + 1;
        const __m256d x = _mm256_set1_pd(-1.0), x2 = _mm256_set1_pd(2.0 * -1.0);
        __m256d c0 = t[L - 2], c1 = t[L - 1];
        for (Py_ssize_t i = 3; i < L + 1; i++) {
            __m256d tmp = c0;
            c0 = _mm256_sub_pd(t[L - i], c1);
            c1 = _mm256_add_pd(tmp, _mm256_mul_pd(c1, x2));
        }
        __m256d v = _mm256_add_pd(c0, _mm256_mul_pd(c1, x));
        t[0] = _mm256_add_pd(t[0], _mm256_sub_pd(zero, v));
        for (Py_ssize_t j = 0; j < L; j++) _mm256_storeu_pd(itg + j * nb + r, t[j]);
    }
    return r;
}
#endif

static PyObject *cheb_der_int(PyObject *self, PyObject *a) {
    PyObject *oc, *od, *oi;
    Py_ssize_t nb, K;
    if (!PyArg_ParseTuple(a, "OnnOO", &oc, &nb, &K, &od, &oi)) return NULL;
    if (K < 2 || K > MAX_COLS) {
        PyErr_SetString(PyExc_ValueError, "cheb_der_int: bad size");
        return NULL;
    }
    Bufs b = {.n = 0};
    const double *coef = get(&b, oc, 8, 0, nb * K);
    double *der = (coef && od != Py_None) ? get(&b, od, 8, 1, (K - 1) * nb) : NULL;
    double *itg = (coef && oi != Py_None) ? get(&b, oi, 8, 1, (K + 1) * nb) : NULL;
    if (!coef || (od != Py_None && !der) || (oi != Py_None && !itg)) { release(&b); return NULL; }
    double c[MAX_COLS], t[MAX_COLS + 1];
    Py_ssize_t r0 = 0;
#if CURVE_AVX
    if (K <= DER_INT_AVX_COLS && use_avx()) r0 = cheb_der_int_avx(coef, nb, K, der, itg);
#endif
    for (Py_ssize_t r = r0; r < nb; r++) {
        const double *cr = coef + r * K;
        Py_ssize_t n;
        if (der) {
            /* chebder: c *= scl, then from the top */
            n = K - 1;
            for (Py_ssize_t j = 0; j < K; j++) c[j] = cr[j] * 2.0;
            for (Py_ssize_t j = n; j > 2; j--) {
                der[(j - 1) * nb + r] = (double)(2 * j) * c[j];
                c[j - 2] += ((double)j * c[j]) / (double)(j - 2);
            }
            if (n > 1) der[1 * nb + r] = 4.0 * c[2];
            der[r] = c[1];
        }
        if (!itg) continue;
        /* chebint: c *= scl, tmp, then tmp[0] += k - chebval(lbnd, tmp) */
        n = K;
        for (Py_ssize_t j = 0; j < K; j++) c[j] = cr[j] * 0.5;
        t[0] = c[0] * 0.0;
        t[1] = c[0];
        t[2] = c[1] / 4.0;
        for (Py_ssize_t j = 2; j < n; j++) {
            t[j + 1] = c[j] / (double)(2 * (j + 1));
            t[j - 1] -= c[j] / (double)(2 * (j - 1));
        }
        Py_ssize_t L = n + 1;
        const double x = -1.0, x2 = 2.0 * -1.0;
        double c0 = t[L - 2], c1 = t[L - 1];
        for (Py_ssize_t i = 3; i < L + 1; i++) {
            double tmp = c0;
            c0 = t[L - i] - c1;
            c1 = tmp + c1 * x2;
        }
        double v = c0 + c1 * x;
        t[0] += 0.0 - v;
        for (Py_ssize_t j = 0; j < L; j++) itg[j * nb + r] = t[j];
    }
    release(&b);
    Py_RETURN_NONE;
}

/* The boundary-layer regime's residual (laws/circle.py: _layers_total) of m cruise values
   per arc, wc (m, n), for n arcs (phi, gam2, u0, u1 (n,)), in three compiled steps around
   numpy's np.exp and np.arcsinh (which stay numpy's: they need not be libm's):
     lay_pre:  ebuf = -sqrt(gam2 + 6 wc wc) * 1.0                     -> np.exp(ebuf)
     lay_mid:  abuf (m, 2, n) = _asinh_diff's argument of the left and right layer
                                                                       -> np.arcsinh(abuf)
     lay_post: out = ((wc + asinh_l) + asinh_r) - phi
   the same operations in the same order as _layers_total's numpy expressions; np.maximum
   and np.where as numpy takes them (NaN propagates, both branches' conditions as written). */
static PyObject *lay_pre(PyObject *self, PyObject *a) {
    PyObject *ow, *og, *oe;
    Py_ssize_t n, m;
    if (!PyArg_ParseTuple(a, "OOnnO", &ow, &og, &n, &m, &oe)) return NULL;
    Bufs b = {.n = 0};
    const double *wc = get(&b, ow, 8, 0, m * n);
    const double *g2 = wc ? get(&b, og, 8, 0, n) : NULL;
    double *e = g2 ? get(&b, oe, 8, 1, m * n) : NULL;
    if (!e) { release(&b); return NULL; }
    for (Py_ssize_t r = 0; r < m; r++)
        for (Py_ssize_t i = 0; i < n; i++) {
            double w = wc[r * n + i];
            double c = g2[i] + (6.0 * w) * w;
            e[r * n + i] = -sqrt(c) * 1.0;
        }
    release(&b);
    Py_RETURN_NONE;
}

/* _layer_coeffs, _layer_d(1.0, ...) and _asinh_diff's argument of one layer (offset d0),
   the terms both layers share (c, lam, c_sq, g2w, w2, w4, k, e) given */
static inline double lay_arg(double d0, double c, double lam, double c_sq, double g2w, double w2,
                             double w4, double k, double e) {
    double rho = (w2 * d0) / c;
    double qa = ((d0 * d0) + (w4 * d0)) + c;
    double q = sqrt(np_max(qa, 0.0)) / lam;
    double s1 = 1.0 + rho;
    double num = ((d0 * d0) * g2w) / c_sq;
    double a_inf = s1 >= 0 ? (s1 + q) / 2.0 : num / (2.0 * (q - s1));
    double b_inf = s1 <= 0 ? (s1 - q) / 2.0 : (-num) / (2.0 * (q + s1));
    double d1 = (d0 * e) / (((-rho) * e + a_inf) + ((b_inf * e) * e));
    /* _asinh_diff((d0 + w2) / k, (d1 + w2) / k) before its np.arcsinh */
    double x = (d0 + w2) / k, y = (d1 + w2) / k;
    double sa = sqrt(1.0 + x * x), sb = sqrt(1.0 + y * y);
    if (x * y > 0) return ((x - y) * (x + y)) / (x * sb + y * sa);
    return x * sb - y * sa;
}

#if CURVE_AVX
/* lay_arg on 4 arcs: both branches of each choice computed and the scalar one's condition
   picks (an ordered compare: false on NaN, as the scalar test); np_max(qa, 0.0) is qa where
   qa >= 0 or qa is NaN, else 0.0 */
AVX_FN static inline __m256d lay_arg_avx(__m256d d0, __m256d c, __m256d lam, __m256d c_sq, __m256d g2w,
                                        __m256d w2, __m256d w4, __m256d k, __m256d e) {
    const __m256d sign = _mm256_set1_pd(-0.0), zero = _mm256_setzero_pd();
    const __m256d one = _mm256_set1_pd(1.0), two = _mm256_set1_pd(2.0);
    __m256d rho = _mm256_div_pd(_mm256_mul_pd(w2, d0), c);
    __m256d qa = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(d0, d0), _mm256_mul_pd(w4, d0)), c);
    __m256d keep = _mm256_or_pd(_mm256_cmp_pd(qa, zero, _CMP_GE_OQ), _mm256_cmp_pd(qa, qa, _CMP_UNORD_Q));
    __m256d q = _mm256_div_pd(_mm256_sqrt_pd(_mm256_blendv_pd(zero, qa, keep)), lam);
    __m256d s1 = _mm256_add_pd(one, rho);
    __m256d num = _mm256_div_pd(_mm256_mul_pd(_mm256_mul_pd(d0, d0), g2w), c_sq);
    __m256d a_inf = _mm256_blendv_pd(_mm256_div_pd(num, _mm256_mul_pd(two, _mm256_sub_pd(q, s1))),
                                     _mm256_div_pd(_mm256_add_pd(s1, q), two),
                                     _mm256_cmp_pd(s1, zero, _CMP_GE_OQ));
    __m256d b_inf = _mm256_blendv_pd(_mm256_div_pd(_mm256_xor_pd(num, sign), _mm256_mul_pd(two, _mm256_add_pd(q, s1))),
                                     _mm256_div_pd(_mm256_sub_pd(s1, q), two),
                                     _mm256_cmp_pd(s1, zero, _CMP_LE_OQ));
    __m256d den = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_xor_pd(rho, sign), e), a_inf),
                                _mm256_mul_pd(_mm256_mul_pd(b_inf, e), e));
    __m256d d1 = _mm256_div_pd(_mm256_mul_pd(d0, e), den);
    __m256d x = _mm256_div_pd(_mm256_add_pd(d0, w2), k), y = _mm256_div_pd(_mm256_add_pd(d1, w2), k);
    __m256d sa = _mm256_sqrt_pd(_mm256_add_pd(one, _mm256_mul_pd(x, x)));
    __m256d sb = _mm256_sqrt_pd(_mm256_add_pd(one, _mm256_mul_pd(y, y)));
    __m256d same = _mm256_div_pd(_mm256_mul_pd(_mm256_sub_pd(x, y), _mm256_add_pd(x, y)),
                                 _mm256_add_pd(_mm256_mul_pd(x, sb), _mm256_mul_pd(y, sa)));
    __m256d diff = _mm256_sub_pd(_mm256_mul_pd(x, sb), _mm256_mul_pd(y, sa));
    return _mm256_blendv_pd(diff, same, _mm256_cmp_pd(_mm256_mul_pd(x, y), zero, _CMP_GT_OQ));
}

/* lay_mid's loop over arcs i0 <= i < i0 + 4k of row r */
AVX_FN static Py_ssize_t lay_mid_avx(const double *wc, const double *g2, const double *u0, const double *u1,
                                     const double *e, Py_ssize_t n, Py_ssize_t r, double *out) {
    const __m256d six = _mm256_set1_pd(6.0), two = _mm256_set1_pd(2.0), four = _mm256_set1_pd(4.0);
    Py_ssize_t i = 0;
    for (; i + 4 <= n; i += 4) {
        __m256d w = _mm256_loadu_pd(wc + r * n + i), ee = _mm256_loadu_pd(e + r * n + i);
        __m256d gam2 = _mm256_loadu_pd(g2 + i);
        __m256d c = _mm256_add_pd(gam2, _mm256_mul_pd(_mm256_mul_pd(six, w), w));
        __m256d lam = _mm256_sqrt_pd(c);
        __m256d c_sq = _mm256_mul_pd(c, c);
        __m256d g2w = _mm256_add_pd(gam2, _mm256_mul_pd(_mm256_mul_pd(two, w), w));
        __m256d w2 = _mm256_mul_pd(two, w), w4 = _mm256_mul_pd(four, w);
        __m256d k = _mm256_sqrt_pd(g2w);
        _mm256_storeu_pd(out + (2 * r) * n + i,
                         lay_arg_avx(_mm256_sub_pd(_mm256_loadu_pd(u0 + i), w), c, lam, c_sq, g2w, w2, w4, k, ee));
        _mm256_storeu_pd(out + (2 * r + 1) * n + i,
                         lay_arg_avx(_mm256_sub_pd(_mm256_loadu_pd(u1 + i), w), c, lam, c_sq, g2w, w2, w4, k, ee));
    }
    return i;
}
#endif

static PyObject *lay_mid(PyObject *self, PyObject *a) {
    PyObject *ow, *og, *o0, *o1, *oe, *oa;
    Py_ssize_t n, m;
    if (!PyArg_ParseTuple(a, "OOOOOnnO", &ow, &og, &o0, &o1, &oe, &n, &m, &oa)) return NULL;
    Bufs b = {.n = 0};
    const double *wc = get(&b, ow, 8, 0, m * n);
    const double *g2 = wc ? get(&b, og, 8, 0, n) : NULL;
    const double *u0 = g2 ? get(&b, o0, 8, 0, n) : NULL;
    const double *u1 = u0 ? get(&b, o1, 8, 0, n) : NULL;
    const double *e = u1 ? get(&b, oe, 8, 0, m * n) : NULL;
    double *out = e ? get(&b, oa, 8, 1, 2 * m * n) : NULL;
    if (!out) { release(&b); return NULL; }
    const int avx = use_avx();
    (void)avx;
    for (Py_ssize_t r = 0; r < m; r++)
        for (Py_ssize_t i =
#if CURVE_AVX
                 avx ? lay_mid_avx(wc, g2, u0, u1, e, n, r, out) :
#endif
                 0;
             i < n; i++) {
            double w = wc[r * n + i], ee = e[r * n + i], gam2 = g2[i];
            double c = gam2 + (6.0 * w) * w;
            double lam = sqrt(c);
            double c_sq = c * c;
            double g2w = gam2 + (2.0 * w) * w;
            double w2 = 2.0 * w, w4 = 4.0 * w;
            double k = sqrt(g2w);
            out[(2 * r) * n + i] = lay_arg(u0[i] - w, c, lam, c_sq, g2w, w2, w4, k, ee);
            out[(2 * r + 1) * n + i] = lay_arg(u1[i] - w, c, lam, c_sq, g2w, w2, w4, k, ee);
        }
    release(&b);
    Py_RETURN_NONE;
}

static PyObject *lay_post(PyObject *self, PyObject *a) {
    PyObject *ow, *op, *oa, *oo;
    Py_ssize_t n, m;
    if (!PyArg_ParseTuple(a, "OOOnnO", &ow, &op, &oa, &n, &m, &oo)) return NULL;
    Bufs b = {.n = 0};
    const double *wc = get(&b, ow, 8, 0, m * n);
    const double *phi = wc ? get(&b, op, 8, 0, n) : NULL;
    const double *as = phi ? get(&b, oa, 8, 0, 2 * m * n) : NULL;
    double *out = as ? get(&b, oo, 8, 1, m * n) : NULL;
    if (!out) { release(&b); return NULL; }
    for (Py_ssize_t r = 0; r < m; r++)
        for (Py_ssize_t i = 0; i < n; i++) {
            double t = wc[r * n + i] + as[(2 * r) * n + i];
            t = t + as[(2 * r + 1) * n + i];
            out[r * n + i] = t - phi[i];
        }
    release(&b);
    Py_RETURN_NONE;
}

/* lay_step(m, wcs, as, phi, h, act, x, xp, gp, g2, u0, u1, sp, lo, hi, n, wc): one step of
   circle._solve_layers_batch's iteration over its n live arcs (the state arrays, packed), after
   lay_pre / np.exp / lay_mid / np.arcsinh of the step's m cruise values (wcs (m, n): x, or x and
   x + h; as (m, 2, n)): lay_post's residuals g (and gh of x + h), then the slope (m = 2: the
   forward difference (gh - g) / h; m = 1: the secant (g - gp) / (x - xp)), the bracket (lo where
   g < 0, hi where g > 0), the step x - g / slope (slope > 0, else inf) and bisection where it
   leaves the bracket or is not finite, and the test |new - x| <= 1e-15 sp: the numpy loop's
   operations in its order.  An arc whose test holds has its new value put at wc[act[i]] and
   leaves; the others are packed to the front of every state array in order (xp the old x, gp
   g, x the new), as the numpy loop's masks take them.  Returns the number left. */
static PyObject *lay_step(PyObject *self, PyObject *a) {
    PyObject *ow, *oa, *op, *oh, *oact, *ox, *oxp, *ogp, *og2, *o0, *o1, *osp, *olo, *ohi, *owc;
    Py_ssize_t m, n, nwc;
    if (!PyArg_ParseTuple(a, "nOOOOOOOOOOOOOOnOn", &m, &ow, &oa, &op, &oh, &oact, &ox, &oxp, &ogp, &og2,
                          &o0, &o1, &osp, &olo, &ohi, &n, &owc, &nwc))
        return NULL;
    if ((m != 1 && m != 2) || n < 0) {
        PyErr_SetString(PyExc_ValueError, "lay_step: bad size");
        return NULL;
    }
    Bufs b = {.n = 0};
    const double *wcs = get(&b, ow, 8, 0, m * n);
    const double *as = wcs ? get(&b, oa, 8, 0, 2 * m * n) : NULL;
    double *phi = as ? get(&b, op, 8, 1, n) : NULL;
    const double *h = (phi && m == 2) ? get(&b, oh, 8, 0, n) : NULL;
    int64_t *act = (phi && (h || m == 1)) ? get(&b, oact, 8, 1, n) : NULL;
    double *x = act ? get(&b, ox, 8, 1, n) : NULL;
    double *xp = x ? get(&b, oxp, 8, 1, n) : NULL;
    double *gp = xp ? get(&b, ogp, 8, 1, n) : NULL;
    double *g2 = gp ? get(&b, og2, 8, 1, n) : NULL;
    double *u0 = g2 ? get(&b, o0, 8, 1, n) : NULL;
    double *u1 = u0 ? get(&b, o1, 8, 1, n) : NULL;
    double *sp = u1 ? get(&b, osp, 8, 1, n) : NULL;
    double *lo = sp ? get(&b, olo, 8, 1, n) : NULL;
    double *hi = lo ? get(&b, ohi, 8, 1, n) : NULL;
    double *wc = hi ? get(&b, owc, 8, 1, nwc) : NULL;
    if (!wc) { release(&b); return NULL; }
    Py_ssize_t k = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        const double xi = x[i];
        /* lay_post of row 0 (x), then of row 1 (x + h) */
        double g = wcs[i] + as[i];
        g = g + as[n + i];
        g = g - phi[i];
        double dg;
        if (m == 2) {
            double gh = wcs[n + i] + as[2 * n + i];
            gh = gh + as[3 * n + i];
            gh = gh - phi[i];
            dg = (gh - g) / h[i];
        } else {
            dg = (g - gp[i]) / (xi - xp[i]);
        }
        const double l = g < 0 ? xi : lo[i];
        const double u = g > 0 ? xi : hi[i];
        double nw = xi - g / (dg > 0 ? dg : INFINITY);
        if (!((nw > l) && (nw < u)) || !isfinite(nw)) nw = 0.5 * (l + u);
        if (fabs(nw - xi) <= 1e-15 * sp[i]) {
            const int64_t at = act[i];
            if (at < 0 || at >= nwc) {
                PyErr_SetString(PyExc_IndexError, "lay_step: an arc out of wc");
                release(&b);
                return NULL;
            }
            wc[at] = nw;
            continue;
        }
        /* (k <= i: each state value is read before its place is written) */
        act[k] = act[i];
        xp[k] = xi;
        gp[k] = g;
        x[k] = nw;
        phi[k] = phi[i];
        g2[k] = g2[i];
        u0[k] = u0[i];
        u1[k] = u1[i];
        sp[k] = sp[i];
        lo[k] = l;
        hi[k] = u;
        k++;
    }
    release(&b);
    return PyLong_FromSsize_t(k);
}

/* A row's decisions from its m speeds v and tangential accelerations at (probe_rows' and
   screen_rows' scalar step): over_v, the largest v above vt; by_at, the largest |at| above
   ac (a NaN decides neither); v_ok, every |v| <= 1e150. */
static void screen_decide(const double *vr, const double *ar, Py_ssize_t m, double vt, double ac,
                          uint8_t *over_v, uint8_t *by_at, uint8_t *v_ok) {
    double vmax = vr[0], a2max = ar[0] * ar[0];
    int v_nan = isnan(vr[0]), a_nan = isnan(a2max), tame = fabs(vr[0]) <= 1e150;
    for (Py_ssize_t j = 1; j < m; j++) {
        const double x = vr[j], y = ar[j] * ar[j];
        v_nan |= isnan(x);
        a_nan |= isnan(y);
        tame &= fabs(x) <= 1e150;
        vmax = x > vmax ? x : vmax;
        a2max = y > a2max ? y : a2max;
    }
    *over_v = !v_nan && vmax > vt;
    *by_at = !a_nan && sqrt(a2max) > ac;
    *v_ok = (uint8_t)tame;
}

/* probe_rows(v, at, nb, m, v_thr, a_cap, over_v, by_at, v_ok): per row r of v and at (nb, m),
   curves.surely_over's decisions before κ: over_v[r] = np.max(v[r]) > v_thr[r], by_at[r] =
   np.sqrt(np.max(at[r] * at[r])) > a_cap[r] (numpy's maxima: NaN where a NaN is met, and a NaN
   compares false), v_ok[r] = every |v[r]| <= 1e150 (none NaN); bool (uint8) outputs. */
#if CURVE_AVX
/* probe_rows' row r (m >= 4) 4 points at a time: the maxima of v and at * at (exact whatever
   the order where no NaN is met; a NaN met is flagged, and the decision is then false as
   numpy's NaN maximum compares), and |v| <= 1e150 at every point */
AVX_FN static void probe_row_avx(const double *vr, const double *ar, Py_ssize_t m, double vt, double ac,
                                 uint8_t *over_v, uint8_t *by_at, uint8_t *v_ok) {
    const __m256d sign = _mm256_set1_pd(-0.0), big = _mm256_set1_pd(1e150);
    __m256d vmax = _mm256_loadu_pd(vr), a0 = _mm256_loadu_pd(ar);
    __m256d a2max = _mm256_mul_pd(a0, a0);
    __m256d nan_v = _mm256_cmp_pd(vmax, vmax, _CMP_UNORD_Q), nan_a = _mm256_cmp_pd(a2max, a2max, _CMP_UNORD_Q);
    __m256d tame = _mm256_cmp_pd(_mm256_andnot_pd(sign, vmax), big, _CMP_LE_OQ);
    Py_ssize_t j = 4;
    for (; j + 4 <= m; j += 4) {
        const __m256d x = _mm256_loadu_pd(vr + j), y0 = _mm256_loadu_pd(ar + j);
        const __m256d y = _mm256_mul_pd(y0, y0);
        nan_v = _mm256_or_pd(nan_v, _mm256_cmp_pd(x, x, _CMP_UNORD_Q));
        nan_a = _mm256_or_pd(nan_a, _mm256_cmp_pd(y, y, _CMP_UNORD_Q));
        tame = _mm256_and_pd(tame, _mm256_cmp_pd(_mm256_andnot_pd(sign, x), big, _CMP_LE_OQ));
        vmax = _mm256_max_pd(vmax, x);
        a2max = _mm256_max_pd(a2max, y);
    }
    double l[4], k[4];
    _mm256_storeu_pd(l, vmax);
    _mm256_storeu_pd(k, a2max);
    double vm = l[0], am = k[0];
    for (int c = 1; c < 4; c++) {
        vm = l[c] > vm ? l[c] : vm;
        am = k[c] > am ? k[c] : am;
    }
    int v_nan = _mm256_movemask_pd(nan_v) != 0, a_nan = _mm256_movemask_pd(nan_a) != 0;
    int ok = _mm256_movemask_pd(tame) == 0xF;
    for (; j < m; j++) {
        const double x = vr[j], y = ar[j] * ar[j];
        v_nan |= isnan(x);
        a_nan |= isnan(y);
        ok &= fabs(x) <= 1e150;
        vm = x > vm ? x : vm;
        am = y > am ? y : am;
    }
    *over_v = !v_nan && vm > vt;
    *by_at = !a_nan && sqrt(am) > ac;
    *v_ok = (uint8_t)ok;
}
#endif

static PyObject *probe_rows(PyObject *self, PyObject *a) {
    PyObject *ov, *oa, *ovt, *oac, *oo, *ob, *ok_;
    Py_ssize_t nb, m;
    if (!PyArg_ParseTuple(a, "OOnnOOOOO", &ov, &oa, &nb, &m, &ovt, &oac, &oo, &ob, &ok_)) return NULL;
    if (nb < 0 || m < 1) {
        PyErr_SetString(PyExc_ValueError, "probe_rows: bad size");
        return NULL;
    }
    Bufs b = {.n = 0};
    const double *v = get(&b, ov, 8, 0, nb * m);
    const double *at = v ? get(&b, oa, 8, 0, nb * m) : NULL;
    const double *vt = at ? get(&b, ovt, 8, 0, nb) : NULL;
    const double *ac = vt ? get(&b, oac, 8, 0, nb) : NULL;
    uint8_t *over_v = ac ? get(&b, oo, 1, 1, nb) : NULL;
    uint8_t *by_at = over_v ? get(&b, ob, 1, 1, nb) : NULL;
    uint8_t *v_ok = by_at ? get(&b, ok_, 1, 1, nb) : NULL;
    if (!v_ok) { release(&b); return NULL; }
    const int avx = use_avx();
    (void)avx;
    for (Py_ssize_t r = 0; r < nb; r++) {
        const double *vr = v + r * m, *ar = at + r * m;
#if CURVE_AVX
        if (avx && m >= 4) {
            probe_row_avx(vr, ar, m, vt[r], ac[r], over_v + r, by_at + r, v_ok + r);
            continue;
        }
#endif
        screen_decide(vr, ar, m, vt[r], ac[r], over_v + r, by_at + r, v_ok + r);
    }
    release(&b);
    Py_RETURN_NONE;
}

/* screen_rows(coef, nb, K, vand, dvand, jp, m, R, T, v_thr, a_thr, kv2ok, v, at, rest, over_v, over_a,
   store, nstore) -> the number of rows left (store 0):
   curves.screen_a_only's probe of rough Chebyshev laws, whole in one pass a row.  Row r of coef
   (nb, K; trailing zeros ignored) holds the coefficients c_k of w(τ).  At the m points x_j
   whose T_k(x_j) are vand (K, jp) and whose d/dτ T_k(x(τ)) = 2 T_k'(x_j) are dvand (K, jp),
   jp >= m a multiple of 4 (the columns past m: any finite numbers): w_j = Σ_k c_k T_k(x_j)
   and w'_j = Σ_k c_k 2 T_k'(x_j), sums in the order of k, then v = (R w) / T and
   at = (R w') / (T T), and probe_rows' decisions of them: over_v, and over_a = by_at and
   v_ok and kv2ok (curves._kv2_not_nan's rows).  The rows neither decides (left to κ(s))
   are put in rest, in order (v, at not written).  store 1: no decisions; the rows
   rest[0 .. nstore) made again, their v and at into rows 0 .. nstore of v and at (nstore, m)
   (the κ part's numbers, ~12 % of the rows, not (nb, m) arrays of every row's).  NOT the bits of CircleBatch.eval_tau's BLAS products (~1e-16 of the row's
   scale from them): only the screen's filter reads these (a candidate it lets through is
   decided on its full law; one it rejects is far over the cap: curves.SCREEN_BAND_R), so
   any accurate sums serve.  The AVX form does the scalar loop's operations (its bits). */
#define SCREEN_COLS 64
static Py_ssize_t own_len(const double *c, Py_ssize_t K) {
    Py_ssize_t n = K;
    while (n > 1 && c[n - 1] == 0.0) n--;
    return n;
}


#if CURVE_AVX
/* screen_rows' row with jp == 20 (the probe's 17 points): both sums in 5 + 5 registers of 4,
   then v and at (the scalar loop's operations, so its bits) */
#define SCREEN_STEP(q)                                                                        \
    w##q = _mm256_add_pd(w##q, _mm256_mul_pd(ck, _mm256_loadu_pd(vk + 4 * q)));               \
    g##q = _mm256_add_pd(g##q, _mm256_mul_pd(ck, _mm256_loadu_pd(dk + 4 * q)))
#define SCREEN_OUT(q)                                                                         \
    _mm256_storeu_pd(v + 4 * q, _mm256_div_pd(_mm256_mul_pd(r, w##q), t));                    \
    _mm256_storeu_pd(a + 4 * q, _mm256_div_pd(_mm256_mul_pd(r, g##q), t2))
AVX_FN static void screen_row20_avx(const double *cr, Py_ssize_t n, const double *vand, const double *dvand,
                                    double ri, double ti, Py_ssize_t m, double *vr, double *ar) {
    __m256d w0, w1, w2, w3, w4, g0, g1, g2, g3, g4;
    w0 = w1 = w2 = w3 = w4 = g0 = g1 = g2 = g3 = g4 = _mm256_setzero_pd();
    for (Py_ssize_t k = 0; k < n; k++) {
        const __m256d ck = _mm256_set1_pd(cr[k]);
        const double *vk = vand + k * 20, *dk = dvand + k * 20;
        SCREEN_STEP(0);
        SCREEN_STEP(1);
        SCREEN_STEP(2);
        SCREEN_STEP(3);
        SCREEN_STEP(4);
    }
    const __m256d r = _mm256_set1_pd(ri), t = _mm256_set1_pd(ti), t2 = _mm256_set1_pd(ti * ti);
    double v[20], a[20];
    SCREEN_OUT(0);
    SCREEN_OUT(1);
    SCREEN_OUT(2);
    SCREEN_OUT(3);
    SCREEN_OUT(4);
    for (Py_ssize_t j = 0; j < m; j++) {
        vr[j] = v[j];
        ar[j] = a[j];
    }
}
#endif

static PyObject *screen_rows(PyObject *self, PyObject *a) {
    PyObject *oc, *ovd, *odv, *orr, *ot, *ovt, *oac, *okv, *ov, *oa, *ors, *oo, *ob;
    Py_ssize_t nb, K, jp, m, nstore;
    int store;
    if (!PyArg_ParseTuple(a, "OnnOOnnOOOOOOOOOOin", &oc, &nb, &K, &ovd, &odv, &jp, &m, &orr, &ot, &ovt, &oac, &okv,
                          &ov, &oa, &ors, &oo, &ob, &store, &nstore))
        return NULL;
    if (nb < 0 || K < 1 || m < 1 || jp < m || jp % 4 || jp > SCREEN_COLS || nstore < 0 || (store && nstore > nb)) {
        PyErr_SetString(PyExc_ValueError, "screen_rows: bad size");
        return NULL;
    }
    Bufs b = {.n = 0};
    const double *coef = get(&b, oc, 8, 0, nb * K);
    const double *vand = coef ? get(&b, ovd, 8, 0, K * jp) : NULL;
    const double *dvand = vand ? get(&b, odv, 8, 0, K * jp) : NULL;
    const double *R = dvand ? get(&b, orr, 8, 0, nb) : NULL;
    const double *T = R ? get(&b, ot, 8, 0, nb) : NULL;
    const double *vt = T ? get(&b, ovt, 8, 0, nb) : NULL;
    const double *ac = vt ? get(&b, oac, 8, 0, nb) : NULL;
    const uint8_t *kv2ok = ac ? get(&b, okv, 1, 0, nb) : NULL;
    double *v = kv2ok ? get(&b, ov, 8, 1, (store ? nstore : 0) * m) : NULL;
    double *at = v ? get(&b, oa, 8, 1, (store ? nstore : 0) * m) : NULL;
    int64_t *rest = at ? get(&b, ors, 8, 1, store ? nstore : nb) : NULL;
    uint8_t *over_v = rest ? get(&b, oo, 1, 1, nb) : NULL;
    uint8_t *over_a = over_v ? get(&b, ob, 1, 1, nb) : NULL;
    if (!over_a) { release(&b); return NULL; }
    const int avx = use_avx();
    (void)avx;
    double w[SCREEN_COLS], dw[SCREEN_COLS], vr[SCREEN_COLS], ar[SCREEN_COLS];
    Py_ssize_t nr = 0;
    const Py_ssize_t nq = store ? nstore : nb;
    for (Py_ssize_t q = 0; q < nq; q++) {
        const Py_ssize_t r = store ? (Py_ssize_t)rest[q] : q;
        if (r < 0 || r >= nb) {
            release(&b);
            PyErr_SetString(PyExc_IndexError, "screen_rows: row out of range");
            return NULL;
        }
        const double *cr = coef + r * K;
        const Py_ssize_t n = own_len(cr, K);
        uint8_t by_at, v_ok, ov_scratch;
        uint8_t *ov_r = store ? &ov_scratch : over_v + r;
#if CURVE_AVX
        if (avx && jp == 20 && m >= 4) {
            screen_row20_avx(cr, n, vand, dvand, R[r], T[r], m, vr, ar);
            probe_row_avx(vr, ar, m, vt[r], ac[r], ov_r, &by_at, &v_ok);
        } else
#endif
        {
            for (Py_ssize_t j = 0; j < jp; j++) w[j] = dw[j] = 0.0;
            for (Py_ssize_t k = 0; k < n; k++) {
                const double ck = cr[k], *vk = vand + k * jp, *dk = dvand + k * jp;
                for (Py_ssize_t j = 0; j < jp; j++) {
                    w[j] += ck * vk[j];
                    dw[j] += ck * dk[j];
                }
            }
            const double ri = R[r], ti = T[r], t2 = T[r] * T[r];
            for (Py_ssize_t j = 0; j < m; j++) {
                vr[j] = (ri * w[j]) / ti;
                ar[j] = (ri * dw[j]) / t2;
            }
            screen_decide(vr, ar, m, vt[r], ac[r], ov_r, &by_at, &v_ok);
        }
        if (store) {                            /* the rows asked: their numbers, packed */
            memcpy(v + q * m, vr, m * sizeof(double));
            memcpy(at + q * m, ar, m * sizeof(double));
            continue;
        }
        over_a[r] = by_at && v_ok && kv2ok[r];
        if (!over_a[r] && !over_v[r]) rest[nr++] = r;   /* left to κ(s) */
    }
    release(&b);
    return PyLong_FromSsize_t(nr);
}

/* interp_rows' knot: the last j with xp[j] <= x, for xp[0] <= x <= xp[n - 1] (n >= 2), by
   the hint h (0 <= h < n): h, h + 1 or h + 2 where x lies there, else a binary search of
   the knots after h + 2 or before h (xp[lo] <= x, and xp[hi] > x or hi = n - 1, as the
   search of every knot keeps them) */
static inline Py_ssize_t knot_at(const double *xp, Py_ssize_t n, double x, Py_ssize_t h) {
    Py_ssize_t lo = 0, hi = n - 1;
    if (xp[h] <= x) {
        if (h + 1 >= n || x < xp[h + 1]) return h;
        if (h + 2 >= n || x < xp[h + 2]) return h + 1;
        lo = h + 2;
    } else {
        hi = h;
    }
    while (hi - lo > 1) {
        Py_ssize_t mid = lo + (hi - lo) / 2;
        if (xp[mid] <= x) lo = mid; else hi = mid;
    }
    return (xp[hi] <= x) ? hi : lo;
}

/* curves.py: _kappa_rows with its knots laid out (_Knots): per row r, np.interp(s[r],
   xs[off[r]:off[r]+cnt[r]], ys[...]) with numpy's defaults (left, right: the end values),
   numpy's arr_interp operations in its order: NaN x gives x; above the last knot the last
   value, below the first the first; at the last knot, or exactly at a knot, that knot's
   value; else slope (fp[j+1] - fp[j]) / (xp[j+1] - xp[j]), slope (x - xp[j]) + fp[j], and
   numpy's two NaN fallbacks.  j is the last knot with xp[j] <= x, which numpy's guessed
   binary search also finds when the knots are strictly increasing and finite (the caller
   gives only such rows, cnt >= 2; rows of cnt < 2 are skipped and left to the caller).
   That j is one knot whatever finds it: knot_at looks first at the last point's knot and
   the next two (a row's points mostly go forward along the curve); the slope of a knot is
   made once for a run of points at it (the same operations on the same knots). */
static PyObject *interp_rows(PyObject *self, PyObject *a) {
    PyObject *os_, *oo, *oc, *ox, *oy, *out_;
    Py_ssize_t nr, m, nk;
    if (!PyArg_ParseTuple(a, "OOOOOnnnO", &os_, &oo, &oc, &ox, &oy, &nr, &m, &nk, &out_)) return NULL;
    Bufs b = {.n = 0};
    const double *s = get(&b, os_, 8, 0, nr * m);
    const int64_t *off = s ? get(&b, oo, 8, 0, nr) : NULL;
    const int64_t *cnt = off ? get(&b, oc, 8, 0, nr) : NULL;
    const double *xs = cnt ? get(&b, ox, 8, 0, nk) : NULL;
    const double *ys = xs ? get(&b, oy, 8, 0, nk) : NULL;
    double *out = ys ? get(&b, out_, 8, 1, nr * m) : NULL;
    if (!out) { release(&b); return NULL; }
    for (Py_ssize_t r = 0; r < nr; r++) {
        Py_ssize_t n = (Py_ssize_t)cnt[r], o = (Py_ssize_t)off[r];
        if (n < 2 || o < 0 || o + n > nk) continue;
        const double *xp = xs + o, *fp = ys + o;
        const double *x_r = s + r * m;
        double *res = out + r * m;
        Py_ssize_t j = 0;               /* the last point's knot (xp[0] at the row's start) */
        Py_ssize_t js = -1;             /* the knot whose slope is held (a function of j alone) */
        double slope = 0.0;
        for (Py_ssize_t i = 0; i < m; i++) {
            const double x = x_r[i];
            if (isnan(x)) { res[i] = x; continue; }
            if (x > xp[n - 1]) { res[i] = fp[n - 1]; continue; }
            if (x < xp[0]) { res[i] = fp[0]; continue; }
            j = knot_at(xp, n, x, j);
            if (j == n - 1 || xp[j] == x) { res[i] = fp[j]; continue; }
            if (j != js) {
                slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]);
                js = j;
            }
            double v = slope * (x - xp[j]) + fp[j];
            if (isnan(v)) {
                v = slope * (x - xp[j + 1]) + fp[j + 1];
                if (isnan(v) && fp[j] == fp[j + 1]) v = fp[j];
            }
            res[i] = v;
        }
    }
    release(&b);
    Py_RETURN_NONE;
}

/* row_lengths(coef, B, K, out): circle._row_lengths, each row's own number of
   coefficients of coef (B, K): one past its last c != 0 (NaN is != 0, -0.0 is not), at
   least 1; out (B,) int64. */
static PyObject *row_lengths(PyObject *self, PyObject *a) {
    PyObject *oc, *oo;
    Py_ssize_t nb, K;
    if (!PyArg_ParseTuple(a, "OnnO", &oc, &nb, &K, &oo)) return NULL;
    if (nb < 0 || K < 1) {
        PyErr_SetString(PyExc_ValueError, "row_lengths: bad size");
        return NULL;
    }
    /* strided: _cheb_der_int's tables are transposes (each row's trailing entries read,
       not the whole table copied into rows first) */
    Py_buffer cv;
    if (PyObject_GetBuffer(oc, &cv, PyBUF_STRIDES | PyBUF_FORMAT) < 0) return NULL;
    if (cv.ndim != 2 || cv.itemsize != 8 || !cv.format || strcmp(cv.format, "d") != 0 ||
        cv.shape[0] != nb || cv.shape[1] != K) {
        PyBuffer_Release(&cv);
        PyErr_SetString(PyExc_ValueError, "row_lengths: a (B, K) float64 table");
        return NULL;
    }
    Bufs b = {.n = 0};
    int64_t *out = get(&b, oo, 8, 1, nb);
    if (!out) { release(&b); PyBuffer_Release(&cv); return NULL; }
    Py_ssize_t rs = cv.strides[0], cs = cv.strides[1];
    for (Py_ssize_t r = 0; r < nb; r++) {
        const char *row = (const char *)cv.buf + r * rs;
        Py_ssize_t k = K;
        while (k > 0) {
            double v;
            memcpy(&v, row + (k - 1) * cs, sizeof v);
            if (v != 0.0) break;
            k--;
        }
        out[r] = k > 0 ? k : 1;
    }
    release(&b);
    PyBuffer_Release(&cv);
    Py_RETURN_NONE;
}

/* circle._graded_grid's nodes xs and weights ws (nb x (2 L q + mq)) of layer widths h (nb):
   the edges e = h * E (E: L + 1 values), per panel p < L with a = e[p], b = e[p + 1] the
   nodes a + (b - a) gx[q] and weights (b - a) gw[q] (q < nq); the middle panel's nodes
   h + (1 - 2 h) mx[q] and weights (1 - 2 h) mw[q] (q < mq); then the end panels mirrored,
   1 - x and the weights, in reverse: numpy's operations, each on the same doubles, where
   numpy copies every broadcast operand through its buffers. */
static PyObject *graded_grid(PyObject *self, PyObject *a) {
    PyObject *oh, *oe, *ogx, *ogw, *omx, *omw, *oxs, *ows;
    Py_ssize_t nb, L, nq, mq;
    if (!PyArg_ParseTuple(a, "OOOOOOnnnnOO", &oh, &oe, &ogx, &ogw, &omx, &omw, &nb, &L, &nq, &mq, &oxs, &ows))
        return NULL;
    if (nb < 0 || L < 1 || nq < 1 || mq < 1 || L + 1 > MAX_COLS) {
        PyErr_SetString(PyExc_ValueError, "graded_grid: bad size");
        return NULL;
    }
    const Py_ssize_t nl = L * nq, cols = 2 * nl + mq;
    Bufs b = {.n = 0};
    const double *h = get(&b, oh, 8, 0, nb);
    const double *E = h ? get(&b, oe, 8, 0, L + 1) : NULL;
    const double *gx = E ? get(&b, ogx, 8, 0, nq) : NULL;
    const double *gw = gx ? get(&b, ogw, 8, 0, nq) : NULL;
    const double *mx = gw ? get(&b, omx, 8, 0, mq) : NULL;
    const double *mw = mx ? get(&b, omw, 8, 0, mq) : NULL;
    double *xs = mw ? get(&b, oxs, 8, 1, nb * cols) : NULL;
    double *ws = xs ? get(&b, ows, 8, 1, nb * cols) : NULL;
    if (!ws) { release(&b); return NULL; }
    double e[MAX_COLS];
    for (Py_ssize_t i = 0; i < nb; i++) {
        const double hi = h[i];
        double *xr = xs + i * cols, *wr = ws + i * cols;
        for (Py_ssize_t p = 0; p <= L; p++) e[p] = hi * E[p];
        for (Py_ssize_t p = 0; p < L; p++) {
            const double lo = e[p], wd = e[p + 1] - e[p];
            for (Py_ssize_t q = 0; q < nq; q++) {
                xr[p * nq + q] = lo + wd * gx[q];
                wr[p * nq + q] = wd * gw[q];
            }
        }
        const double mid = 1.0 - 2.0 * hi;
        for (Py_ssize_t q = 0; q < mq; q++) {
            xr[nl + q] = hi + mid * mx[q];
            wr[nl + q] = mid * mw[q];
        }
        for (Py_ssize_t k = 0; k < nl; k++) {
            xr[nl + mq + k] = 1.0 - xr[nl - 1 - k];
            wr[nl + mq + k] = wr[nl - 1 - k];
        }
    }
    release(&b);
    Py_RETURN_NONE;
}

/* curves._true_figures_rows' quadrature sums np.sum(wq * x[:, :m], axis=1) of rows x
   (nb x ld, the first m of each row) and weights wq (nb x m): each row's products, numpy's
   multiply, then numpy's pairwise sum of them (the product array is C-contiguous: a row
   is one reduction of m values), where numpy copied x's strided rows through its buffers
   and made the nb x m products. */
static PyObject *wsum_rows(PyObject *self, PyObject *a) {
    PyObject *ow, *ox, *oo;
    Py_ssize_t nb, m, ld;
    if (!PyArg_ParseTuple(a, "OOnnnO", &ow, &ox, &nb, &m, &ld, &oo)) return NULL;
    if (nb < 0 || m < 0 || ld < m) {
        PyErr_SetString(PyExc_ValueError, "wsum_rows: bad size");
        return NULL;
    }
    Bufs b = {.n = 0};
    const double *w = get(&b, ow, 8, 0, nb * m);
    const double *x = w ? get(&b, ox, 8, 0, nb * ld) : NULL;
    double *out = x ? get(&b, oo, 8, 1, nb) : NULL;
    if (!out) { release(&b); return NULL; }
    double *tmp = PyMem_Malloc((m ? m : 1) * sizeof(double));
    if (!tmp) { release(&b); return PyErr_NoMemory(); }
    for (Py_ssize_t i = 0; i < nb; i++) {
        const double *wr = w + i * m, *xr = x + i * ld;
        for (Py_ssize_t j = 0; j < m; j++) tmp[j] = wr[j] * xr[j];
        out[i] = m ? np_pairwise_sum(tmp, m) : 0.0;     /* (numpy: an empty sum is +0.0) */
    }
    PyMem_Free(tmp);
    release(&b);
    Py_RETURN_NONE;
}

/* curves._lag_rows: out[i, j] = x[i, j + lag] - x[i, j] (x[:, lag:] - x[:, :-lag], np.diff's
   subtract at lag 1), or with add x[i, j] + x[i, j + lag] (x[:, :-lag] + x[:, lag:]), of rows
   x (nb x cols) into out (nb x (cols - lag)): one IEEE operation an element, where numpy
   copies both strided operands through its buffers. */
static PyObject *lag_rows(PyObject *self, PyObject *a) {
    PyObject *ox, *oo;
    Py_ssize_t nb, cols, lag;
    int add;
    if (!PyArg_ParseTuple(a, "OnnniO", &ox, &nb, &cols, &lag, &add, &oo)) return NULL;
    if (nb < 0 || lag < 1 || cols < lag) {
        PyErr_SetString(PyExc_ValueError, "lag_rows: bad size");
        return NULL;
    }
    const Py_ssize_t oc = cols - lag;
    Bufs b = {.n = 0};
    const double *x = get(&b, ox, 8, 0, nb * cols);
    double *out = x ? get(&b, oo, 8, 1, nb * oc) : NULL;
    if (!out) { release(&b); return NULL; }
    for (Py_ssize_t i = 0; i < nb; i++) {
        const double *xr = x + i * cols;
        double *o = out + i * oc;
        if (add)
            for (Py_ssize_t j = 0; j < oc; j++) o[j] = xr[j] + xr[j + lag];
        else
            for (Py_ssize_t j = 0; j < oc; j++) o[j] = xr[j + lag] - xr[j];
    }
    release(&b);
    Py_RETURN_NONE;
}

/* curves._parts_block's u = seg / d[..., None]: each (x, y) pair over its length, where
   numpy copies the broadcast d through its buffers.  seg: n pairs, d: n, out: n pairs. */
static PyObject *div_pairs(PyObject *self, PyObject *a) {
    PyObject *os, *od, *oo;
    Py_ssize_t n;
    if (!PyArg_ParseTuple(a, "OOnO", &os, &od, &n, &oo)) return NULL;
    if (n < 0) {
        PyErr_SetString(PyExc_ValueError, "div_pairs: bad size");
        return NULL;
    }
    Bufs b = {.n = 0};
    const double *sg = get(&b, os, 8, 0, 2 * n);
    const double *d = sg ? get(&b, od, 8, 0, n) : NULL;
    double *out = d ? get(&b, oo, 8, 1, 2 * n) : NULL;
    if (!out) { release(&b); return NULL; }
    for (Py_ssize_t k = 0; k < n; k++) {
        out[2 * k] = sg[2 * k] / d[k];
        out[2 * k + 1] = sg[2 * k + 1] / d[k];
    }
    release(&b);
    Py_RETURN_NONE;
}

/* curves._row_scale: out = R[:, None] * x, R[:, None] * x / T[:, None] (p = 1) or
   R[:, None] * x / T[:, None] ** 2 (p = 2) of rows x (nb x M), numpy's operations on the same
   doubles (T ** 2 is np.square, T * T; a multiply then a divide, each correctly rounded, no
   contraction): numpy 2 runs a (B, 1) operand broadcast along (B, M) through its iterator's
   buffers, a copy of the column into a buffer for every row of every such operation.
   p = 3: p = 1's, then np.maximum(., 0.0) (numpy's: a NaN itself, else y > 0.0 ? y : 0.0,
   so -0.0 gives +0.0: the second operand where they compare equal). */
static inline double np_max0(double y) { return isnan(y) ? y : (y > 0.0 ? y : 0.0); }
#if CURVE_AVX
AVX_FN static void row_scale_avx(const double *x, Py_ssize_t M, double r, double t, int p, double *o) {
    Py_ssize_t j = 0;
    const __m256d vr = _mm256_set1_pd(r), vt = _mm256_set1_pd(t);
    if (p == 3) {
        const __m256d zero = _mm256_setzero_pd();
        for (; j + 4 <= M; j += 4) {
            const __m256d y = _mm256_div_pd(_mm256_mul_pd(vr, _mm256_loadu_pd(x + j)), vt);
            /* max_pd(y, 0): y where y > 0, else 0 (a NaN y gives 0: put back) */
            _mm256_storeu_pd(o + j, _mm256_blendv_pd(_mm256_max_pd(y, zero), y, _mm256_cmp_pd(y, y, _CMP_UNORD_Q)));
        }
        for (; j < M; j++) o[j] = np_max0((r * x[j]) / t);
    } else if (p) {
        for (; j + 4 <= M; j += 4)
            _mm256_storeu_pd(o + j, _mm256_div_pd(_mm256_mul_pd(vr, _mm256_loadu_pd(x + j)), vt));
        for (; j < M; j++) o[j] = (r * x[j]) / t;
    } else {
        for (; j + 4 <= M; j += 4) _mm256_storeu_pd(o + j, _mm256_mul_pd(vr, _mm256_loadu_pd(x + j)));
        for (; j < M; j++) o[j] = r * x[j];
    }
}
#endif

static PyObject *row_scale(PyObject *self, PyObject *a) {
    PyObject *ox, *orr, *ot, *oo;
    Py_ssize_t nb, M;
    int p;
    if (!PyArg_ParseTuple(a, "OOOinnO", &ox, &orr, &ot, &p, &nb, &M, &oo)) return NULL;
    if (nb < 0 || M < 0 || p < 0 || p > 3) {
        PyErr_SetString(PyExc_ValueError, "row_scale: bad size or power");
        return NULL;
    }
    Bufs b = {.n = 0};
    const double *x = get(&b, ox, 8, 0, nb * M);
    const double *r = x ? get(&b, orr, 8, 0, nb) : NULL;
    const double *t = (r && p) ? get(&b, ot, 8, 0, nb) : NULL;
    double *out = (r && (t || !p)) ? get(&b, oo, 8, 1, nb * M) : NULL;
    if (!out) { release(&b); return NULL; }
    const int avx = use_avx();
    for (Py_ssize_t i = 0; i < nb; i++) {
        const double *xr = x + i * M;
        double *o = out + i * M;
        const double ri = r[i];
        const double ti = p == 2 ? t[i] * t[i] : (p ? t[i] : 1.0);
#if CURVE_AVX
        if (avx) { row_scale_avx(xr, M, ri, ti, p, o); continue; }
#endif
        (void)avx;
        if (p == 3)
            for (Py_ssize_t j = 0; j < M; j++) o[j] = np_max0((ri * xr[j]) / ti);
        else if (p)
            for (Py_ssize_t j = 0; j < M; j++) o[j] = (ri * xr[j]) / ti;
        else
            for (Py_ssize_t j = 0; j < M; j++) o[j] = ri * xr[j];
    }
    release(&b);
    Py_RETURN_NONE;
}

/* curves._Blk.u_rows: the unit directions of rows of a geometry block made again from
   the strokes' own vertices, (x[j + 1] - x[j]) / d[j] per axis: numpy's subtract then
   divide of the same doubles (two correctly rounded operations, no contraction between
   them).  pts: the block's list of strokes.Points (each an `xy` array of doubles, n + 1
   vertices); ks: an int64 buffer of m row indices, or None for the rows k0 .. k0 + m - 1;
   d: the block's lengths (rows x n, C-contiguous); out: m x n x 2 doubles.  A row whose
   vertices are not such a buffer raises (the caller takes numpy's path). */
static PyObject *u_rows(PyObject *self, PyObject *a) {
    PyObject *pts, *oks, *od, *out_;
    Py_ssize_t k0, m, n;
    if (!PyArg_ParseTuple(a, "O!OnOnnO", &PyList_Type, &pts, &oks, &k0, &od, &m, &n, &out_)) return NULL;
    const Py_ssize_t rows = PyList_GET_SIZE(pts);
    Bufs b = {.n = 0};
    const int64_t *ks = NULL;
    if (oks != Py_None && !(ks = get(&b, oks, 8, 0, m))) { release(&b); return NULL; }
    const double *d = get(&b, od, 8, 0, rows * n);
    double *out = d ? get(&b, out_, 8, 1, m * n * 2) : NULL;
    if (!out) { release(&b); return NULL; }
    static PyObject *name_xy = NULL;
    if (!name_xy && !(name_xy = PyUnicode_InternFromString("xy"))) { release(&b); return NULL; }
    for (Py_ssize_t q = 0; q < m; q++) {
        const Py_ssize_t k = ks ? (Py_ssize_t)ks[q] : k0 + q;
        if (k < 0 || k >= rows) {
            PyErr_SetString(PyExc_IndexError, "curve core: row out of range");
            release(&b);
            return NULL;
        }
        PyObject *xy = PyObject_GetAttr(PyList_GET_ITEM(pts, k), name_xy);
        if (!xy) { release(&b); return NULL; }
        Py_buffer v;
        int bad = PyObject_GetBuffer(xy, &v, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT);
        Py_DECREF(xy);      /* (the buffer holds the array while it is read) */
        if (bad < 0) { release(&b); return NULL; }
        if (v.itemsize != 8 || !v.format || strcmp(v.format, "d") != 0 || v.len != (n + 1) * 2 * 8) {
            PyBuffer_Release(&v);
            PyErr_SetString(PyExc_ValueError, "curve core: vertices not n + 1 pairs of doubles");
            release(&b);
            return NULL;
        }
        const double *x = v.buf, *dk = d + k * n;
        double *o = out + q * n * 2;
        for (Py_ssize_t j = 0; j < n; j++) {
            o[2 * j] = (x[2 * j + 2] - x[2 * j]) / dk[j];
            o[2 * j + 1] = (x[2 * j + 3] - x[2 * j + 1]) / dk[j];
        }
        PyBuffer_Release(&v);
    }
    release(&b);
    Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- gathers of object fields */
/* The Python side's per-object reads (np.fromiter(map(attrgetter(name), objs), ...): ~500
 * instructions an element through map, attrgetter and PyArray_Pack) made in one C pass:
 * the attribute read as Python's generic getattr reads it (a data descriptor of the
 * object's type first: looked up once a run of objects of one type; an object slot read at
 * its offset), the value taken only where it is of the one exact type the caller's
 * conversion gives the same bits of, else 0 (nothing kept: the caller reads them itself,
 * with every error of its own; an error here is cleared). */

#include <structmember.h>

typedef struct {
    PyTypeObject *tp;          /* the type the rest is for (a strong reference), or NULL */
    PyObject *descr;           /* its data descriptor of the name (strong), or NULL: PyObject_GetAttr */
    Py_ssize_t off;            /* >= 0: the descriptor is an object slot at this offset */
} AttrCache;

static void attr_cache_clear(AttrCache *c)
{
    Py_CLEAR(c->tp);
    Py_CLEAR(c->descr);
    c->off = -1;
}

/* o's attribute name (a new reference; NULL with an exception) */
static PyObject *attr_of(PyObject *o, PyObject *name, AttrCache *c)
{
    PyTypeObject *tp = Py_TYPE(o);
    if (tp != c->tp) {
        attr_cache_clear(c);
        c->tp = (PyTypeObject *)Py_NewRef(tp);
        PyObject *d = tp->tp_getattro == PyObject_GenericGetAttr ? _PyType_Lookup(tp, name) : NULL;
        if (d != NULL && Py_TYPE(d)->tp_descr_get != NULL && Py_TYPE(d)->tp_descr_set != NULL) {
            c->descr = Py_NewRef(d);
            if (Py_TYPE(d) == &PyMemberDescr_Type) {
                PyMemberDef *m = ((PyMemberDescrObject *)d)->d_member;
                if (m->type == T_OBJECT_EX && (m->flags & ~READONLY) == 0)
                    c->off = m->offset;
            }
        }
    }
    if (c->off >= 0) {
        PyObject *v = *(PyObject **)((char *)o + c->off);
        if (v != NULL)
            return Py_NewRef(v);
    }
    if (c->descr != NULL)
        return Py_TYPE(c->descr)->tp_descr_get(c->descr, o, (PyObject *)tp);
    return PyObject_GetAttr(o, name);
}

/* a writable C-contiguous buffer of format fmt and at least n items */
static int out_buffer(PyObject *o, Py_buffer *b, const char *fmt, Py_ssize_t itemsize, Py_ssize_t n)
{
    if (PyObject_GetBuffer(o, b, PyBUF_WRITABLE | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return -1;
    if (b->itemsize != itemsize || b->format == NULL || strcmp(b->format, fmt) || b->len < n * itemsize) {
        PyBuffer_Release(b);
        PyErr_Format(PyExc_ValueError, "a C-contiguous '%s' buffer of %zd items", fmt, n);
        return -1;
    }
    return 0;
}

#define OBJ_MAX_NAMES 16

/* obj_floats(objs, names, out, also): out (float64, len(objs) x len(names), C order) the
 * attributes `names` of every object of the list, where each is a float or of the float
 * subclass `also` (None: none; np.float64, whose double is a float's) (its double) or a
 * bool (1.0 / 0.0: what np.fromiter(..., float) and np.array(..., float) make of them);
 * 1, or 0 where one is not (or its read raises). */
static PyObject *obj_floats(PyObject *self, PyObject *a)
{
    PyObject *list, *names, *out_o, *also = Py_None;
    if (!PyArg_ParseTuple(a, "O!O!O|O:obj_floats", &PyList_Type, &list, &PyTuple_Type, &names, &out_o, &also))
        return NULL;
    if (also != Py_None && !(PyType_Check(also) && PyType_IsSubtype((PyTypeObject *)also, &PyFloat_Type))) {
        PyErr_SetString(PyExc_TypeError, "obj_floats: also a subclass of float or None");
        return NULL;
    }
    Py_ssize_t n = PyList_GET_SIZE(list), w = PyTuple_GET_SIZE(names);
    if (w > OBJ_MAX_NAMES)
        return PyLong_FromLong(0);
    Py_buffer b;
    if (out_buffer(out_o, &b, "d", 8, n * w) < 0)
        return NULL;
    double *out = b.buf;
    AttrCache c[OBJ_MAX_NAMES];
    for (Py_ssize_t j = 0; j < w; j++)
        c[j] = (AttrCache){NULL, NULL, -1};
    int ok = 1;
    for (Py_ssize_t i = 0; ok && i < n && i < PyList_GET_SIZE(list); i++) {
        PyObject *o = Py_NewRef(PyList_GET_ITEM(list, i));
        for (Py_ssize_t j = 0; ok && j < w; j++) {
            PyObject *v = attr_of(o, PyTuple_GET_ITEM(names, j), &c[j]);
            if (v == NULL) {
                PyErr_Clear();
                ok = 0;
            } else {
                if (PyFloat_CheckExact(v) || (PyObject *)Py_TYPE(v) == also)
                    out[i * w + j] = PyFloat_AS_DOUBLE(v);
                else if (v == Py_True || v == Py_False)
                    out[i * w + j] = v == Py_True ? 1.0 : 0.0;
                else
                    ok = 0;
                Py_DECREF(v);
            }
        }
        Py_DECREF(o);
    }
    ok = ok && n == PyList_GET_SIZE(list);
    for (Py_ssize_t j = 0; j < w; j++)
        attr_cache_clear(&c[j]);
    PyBuffer_Release(&b);
    return PyLong_FromLong(ok);
}

/* obj_codes(objs, name, code_of, add, out): out (int64, len(objs)) the code of each
 * object's attribute `name` (name None: of the object itself): code_of[value] (an int),
 * a value not in code_of added with the next code len(code_of) when add, or
 * code_of None: the value itself (an int).  1, or 0 where a value is not a key (add
 * false), a code or value not an int of 64 bits, a read or a look-up raises. */
static PyObject *obj_codes(PyObject *self, PyObject *a)
{
    PyObject *list, *name, *code_of, *out_o;
    int add;
    if (!PyArg_ParseTuple(a, "O!OOpO:obj_codes", &PyList_Type, &list, &name, &code_of, &add, &out_o))
        return NULL;
    if ((name != Py_None && !PyUnicode_Check(name)) || (code_of != Py_None && !PyDict_CheckExact(code_of))) {
        PyErr_SetString(PyExc_TypeError, "obj_codes: name a str or None, code_of a dict or None");
        return NULL;
    }
    Py_ssize_t n = PyList_GET_SIZE(list);
    Py_buffer b;
    if (out_buffer(out_o, &b, "l", 8, n) < 0)
        return NULL;
    long *out = b.buf;
    AttrCache c = {NULL, NULL, -1};
    int ok = 1;
    for (Py_ssize_t i = 0; ok && i < n && i < PyList_GET_SIZE(list); i++) {
        PyObject *o = Py_NewRef(PyList_GET_ITEM(list, i));
        PyObject *v = name == Py_None ? Py_NewRef(o) : attr_of(o, name, &c);
        Py_DECREF(o);
        if (v == NULL) {
            ok = 0;
            break;
        }
        PyObject *k = v;                           /* the code (borrowed from code_of, or v) */
        if (code_of != Py_None) {
            k = PyDict_GetItemWithError(code_of, v);
            if (k == NULL && !PyErr_Occurred() && add) {
                PyObject *next = PyLong_FromSsize_t(PyDict_GET_SIZE(code_of));
                if (next != NULL && PyDict_SetItem(code_of, v, next) == 0)
                    k = next;
                Py_XDECREF(next);                  /* (code_of holds it) */
            }
        }
        if (k != NULL && PyLong_CheckExact(k)) {
            int over;
            long long x = PyLong_AsLongLongAndOverflow(k, &over);
            if (over || (x == -1 && PyErr_Occurred()))
                ok = 0;
            else
                out[i] = (long)x;
        } else
            ok = 0;
        Py_DECREF(v);
    }
    if (!ok)
        PyErr_Clear();
    ok = ok && n == PyList_GET_SIZE(list);
    attr_cache_clear(&c);
    PyBuffer_Release(&b);
    return PyLong_FromLong(ok);
}

/* obj_ids(objs, name, out): the distinct objects (by identity) that are the attribute
 * `name` of the objects of the list, in the order first met, as a list; out (int64,
 * len(objs)) each one's place in it.  None where a read raises. */
static PyObject *obj_ids(PyObject *self, PyObject *a)
{
    PyObject *list, *name, *out_o;
    if (!PyArg_ParseTuple(a, "O!UO:obj_ids", &PyList_Type, &list, &name, &out_o))
        return NULL;
    Py_ssize_t n = PyList_GET_SIZE(list);
    Py_buffer b;
    if (out_buffer(out_o, &b, "l", 8, n) < 0)
        return NULL;
    long *out = b.buf;
    PyObject *firsts = PyList_New(0), *at = PyDict_New();   /* at: {id: place} */
    AttrCache c = {NULL, NULL, -1};
    PyObject *last = NULL;                                   /* the last value (borrowed from firsts) */
    long last_k = 0;
    int ok = firsts != NULL && at != NULL;
    for (Py_ssize_t i = 0; ok && i < n && i < PyList_GET_SIZE(list); i++) {
        PyObject *o = Py_NewRef(PyList_GET_ITEM(list, i));
        PyObject *v = attr_of(o, name, &c);
        Py_DECREF(o);
        if (v == NULL) {
            ok = 0;
            break;
        }
        if (v != last) {                   /* (most objects share their neighbour's) */
            PyObject *id = PyLong_FromVoidPtr(v), *k = NULL;
            if (id == NULL || (k = PyDict_GetItemWithError(at, id)) == NULL) {
                PyObject *next = PyErr_Occurred() || id == NULL ? NULL : PyLong_FromSsize_t(PyList_GET_SIZE(firsts));
                if (next == NULL || PyDict_SetItem(at, id, next) < 0 || PyList_Append(firsts, v) < 0)
                    ok = 0;
                k = next;
                Py_XDECREF(next);
            }
            if (ok) {
                last = v;
                last_k = PyLong_AsLong(k);
            }
            Py_XDECREF(id);
        }
        out[i] = last_k;
        Py_DECREF(v);                      /* (firsts holds every value last may be) */
    }
    ok = ok && n == PyList_GET_SIZE(list);
    attr_cache_clear(&c);
    PyBuffer_Release(&b);
    Py_XDECREF(at);
    if (!ok) {
        PyErr_Clear();
        Py_XDECREF(firsts);
        Py_RETURN_NONE;
    }
    return firsts;
}

/* the list index i of Python's list[i] (a negative i counts from the end), or -1 with
 * Python's IndexError (msg) where it is out of range */
static Py_ssize_t list_index(PyObject *list, int64_t i, const char *msg)
{
    Py_ssize_t n = PyList_GET_SIZE(list), k = i < 0 ? (Py_ssize_t)i + n : (Py_ssize_t)i;
    if (k < 0 || k >= n) {
        PyErr_SetString(PyExc_IndexError, msg);
        return -1;
    }
    return k;
}

/* dst[k] = v (a new reference taken), as list.__setitem__ does: the old item released after */
static int list_set(PyObject *dst, int64_t i, PyObject *v)
{
    Py_ssize_t k = list_index(dst, i, "list assignment index out of range");
    if (k < 0) {
        Py_DECREF(v);
        return -1;
    }
    PyObject *old = PyList_GET_ITEM(dst, k);
    PyList_SET_ITEM(dst, k, v);
    Py_DECREF(old);
    return 0;
}

/* a C-contiguous read-only buffer of int64 row numbers ('l' where long is 64-bit, 'q'
 * where it is not: numpy's intp either way), or -1 with an error */
static int rows_buffer(PyObject *o, Py_buffer *b)
{
    if (PyObject_GetBuffer(o, b, PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return -1;
    if (b->itemsize != 8 || b->format == NULL || (strcmp(b->format, "l") && strcmp(b->format, "q"))) {
        PyBuffer_Release(b);
        PyErr_SetString(PyExc_ValueError, "a C-contiguous buffer of int64 rows");
        return -1;
    }
    return 0;
}

/* list_put(dst, rows, src, at): for k in order, dst[rows[k]] = src[at[k]] (at: int64 rows
 * as rows), or src[k] (at None), or src itself (at Ellipsis: every row the one value);
 * dst, src lists, rows int64.  The loop `for i, j in zip(rows, at): dst[i] = src[j]`
 * over lists of ints (~190 instructions a row) in one pass: the same items, the same
 * IndexError at the same row (the rows before it written). */
static PyObject *list_put(PyObject *self, PyObject *a)
{
    PyObject *dst, *rows_o, *src, *at_o;
    if (!PyArg_ParseTuple(a, "O!OOO:list_put", &PyList_Type, &dst, &rows_o, &src, &at_o))
        return NULL;
    (void)self;
    int fill = at_o == Py_Ellipsis, by_at = !fill && at_o != Py_None;
    if (!fill && !PyList_Check(src)) {
        PyErr_SetString(PyExc_TypeError, "list_put: src a list");
        return NULL;
    }
    Py_buffer rb, ab;
    if (rows_buffer(rows_o, &rb) < 0)
        return NULL;
    Py_ssize_t n = rb.len / 8;
    if (by_at && rows_buffer(at_o, &ab) < 0) {
        PyBuffer_Release(&rb);
        return NULL;
    }
    if ((by_at && ab.len / 8 != n) || (!fill && !by_at && PyList_GET_SIZE(src) != n)) {
        PyErr_SetString(PyExc_ValueError, "list_put: rows and their values of one length");
        n = -1;
    }
    const int64_t *rows = rb.buf, *at = by_at ? ab.buf : NULL;
    int ok = n >= 0;
    for (Py_ssize_t k = 0; ok && k < n; k++) {
        PyObject *v;
        if (fill)
            v = src;
        else {
            Py_ssize_t j = by_at ? list_index(src, at[k], "list index out of range") : k;
            if (j < 0 || j >= PyList_GET_SIZE(src)) {        /* (src may have shrunk: an item's release) */
                if (j >= 0)
                    PyErr_SetString(PyExc_IndexError, "list index out of range");
                ok = 0;
                break;
            }
            v = PyList_GET_ITEM(src, j);
        }
        ok = list_set(dst, rows[k], Py_NewRef(v)) == 0;
    }
    PyBuffer_Release(&rb);
    if (by_at)
        PyBuffer_Release(&ab);
    if (!ok)
        return NULL;
    Py_RETURN_NONE;
}

/* list_take(src, rows): [src[i] for i in rows] (src a list, rows int64) in one pass, the
 * same IndexError where a row is out of range. */
static PyObject *list_take(PyObject *self, PyObject *a)
{
    PyObject *src, *rows_o;
    if (!PyArg_ParseTuple(a, "O!O:list_take", &PyList_Type, &src, &rows_o))
        return NULL;
    (void)self;
    Py_buffer rb;
    if (rows_buffer(rows_o, &rb) < 0)
        return NULL;
    Py_ssize_t n = rb.len / 8;
    const int64_t *rows = rb.buf;
    PyObject *out = PyList_New(n);
    for (Py_ssize_t k = 0; out != NULL && k < n; k++) {
        Py_ssize_t j = list_index(src, rows[k], "list index out of range");
        if (j < 0)
            Py_CLEAR(out);                 /* (its items not yet set are NULL: released as such) */
        else
            PyList_SET_ITEM(out, k, Py_NewRef(PyList_GET_ITEM(src, j)));
    }
    PyBuffer_Release(&rb);
    return out;
}

/* ---------------------------------------------------------------- stacked geometry rows */
/* curves.stack_du / stack_d in one pass: for each geometry g of gs (a list; curves.CurveGeom,
   row g._k of its block g._b, a curves._Blk), D[i] = the block's d[k] (n doubles, copied)
   and, where U is not None, U[i] = the block's u[k]: its kept u's row where it keeps u, else
   made from the stroke's vertices (b._pts[k].xy) and that d row as _Blk.u_rows makes it
   ((x[j + 1] - x[j]) / d[j] per axis).  1, or 0 (nothing raised; D and U partly written)
   where a geometry, its block, its row or its arrays are not of that make (a read raising,
   _k not an int, d not C-contiguous doubles of n columns, a row out of range, u or the
   vertices not such doubles): the caller then stacks them its own way. */
typedef struct {
    PyObject *blk;             /* the block whose buffers are held (strong), or NULL */
    Py_buffer d, u;            /* its d; its u where kept (u.obj NULL: not) */
    PyObject *pts;             /* its _pts (strong; a list), or NULL where u is kept */
    Py_ssize_t rows;           /* its d's rows */
} StackBlk;

static void stack_blk_clear(StackBlk *s)
{
    if (s->d.obj) PyBuffer_Release(&s->d);
    if (s->u.obj) PyBuffer_Release(&s->u);
    s->d.obj = s->u.obj = NULL;
    Py_CLEAR(s->pts);
    Py_CLEAR(s->blk);
}

/* s made to hold block b's buffers (rows of n lengths; its u or vertices where want_u);
   0 where b is not of that make */
static int stack_blk_set(StackBlk *s, PyObject *b, Py_ssize_t n, int want_u, PyObject *const names[3],
                         AttrCache c[3])
{
    stack_blk_clear(s);
    s->blk = Py_NewRef(b);
    PyObject *d = attr_of(b, names[0], &c[0]);
    if (!d) return 0;
    int bad = PyObject_GetBuffer(d, &s->d, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT);
    Py_DECREF(d);           /* (the buffer holds the array while it is read) */
    if (bad < 0) { s->d.obj = NULL; return 0; }
    if (s->d.itemsize != 8 || !s->d.format || strcmp(s->d.format, "d") || s->d.ndim != 2 || s->d.shape[1] != n)
        return 0;
    s->rows = s->d.shape[0];
    if (!want_u) return 1;
    PyObject *u = attr_of(b, names[1], &c[1]);
    if (!u) return 0;
    if (u != Py_None) {
        bad = PyObject_GetBuffer(u, &s->u, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT);
        Py_DECREF(u);
        if (bad < 0) { s->u.obj = NULL; return 0; }
        return s->u.itemsize == 8 && s->u.format && !strcmp(s->u.format, "d") && s->u.ndim == 3
               && s->u.shape[0] == s->rows && s->u.shape[1] == n && s->u.shape[2] == 2;
    }
    Py_DECREF(u);
    PyObject *pts = attr_of(b, names[2], &c[2]);
    if (!pts) return 0;
    s->pts = pts;
    return PyList_CheckExact(pts) && PyList_GET_SIZE(pts) >= s->rows;
}

/* row k's directions of the block s (its kept u, or made from its vertices) into o (n x 2) */
static int stack_u_row(StackBlk *s, Py_ssize_t k, Py_ssize_t n, PyObject *name_xy, double *o)
{
    const double *dk = (const double *)s->d.buf + k * n;
    if (s->u.obj) {
        memcpy(o, (const double *)s->u.buf + k * n * 2, (size_t)n * 2 * sizeof(double));
        return 1;
    }
    if (k >= PyList_GET_SIZE(s->pts)) return 0;
    PyObject *p = Py_NewRef(PyList_GET_ITEM(s->pts, k));
    PyObject *xy = PyObject_GetAttr(p, name_xy);
    Py_DECREF(p);
    if (!xy) return 0;
    Py_buffer v;
    int bad = PyObject_GetBuffer(xy, &v, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT);
    Py_DECREF(xy);
    if (bad < 0) return 0;
    int ok = v.itemsize == 8 && v.format && !strcmp(v.format, "d") && v.len == (n + 1) * 2 * 8;
    if (ok) {
        const double *x = v.buf;
        for (Py_ssize_t j = 0; j < n; j++) {
            o[2 * j] = (x[2 * j + 2] - x[2 * j]) / dk[j];
            o[2 * j + 1] = (x[2 * j + 3] - x[2 * j + 1]) / dk[j];
        }
    }
    PyBuffer_Release(&v);
    return ok;
}

static PyObject *stack_rows(PyObject *self, PyObject *a)
{
    PyObject *gs, *od, *ou;
    Py_ssize_t n;
    if (!PyArg_ParseTuple(a, "O!nOO:stack_rows", &PyList_Type, &gs, &n, &od, &ou)) return NULL;
    static PyObject *names[6] = {NULL};     /* _b, _k; d, _u, _pts; xy */
    static const char *const strs[6] = {"_b", "_k", "d", "_u", "_pts", "xy"};
    for (int i = 0; i < 6; i++)
        if (!names[i] && !(names[i] = PyUnicode_InternFromString(strs[i]))) return NULL;
    const Py_ssize_t m = PyList_GET_SIZE(gs);
    const int want_u = ou != Py_None;
    Bufs b = {.n = 0};
    double *D = get(&b, od, 8, 1, m * n);
    double *U = D && want_u ? get(&b, ou, 8, 1, m * n * 2) : NULL;
    if (!D || (want_u && !U)) { release(&b); return NULL; }
    AttrCache cg[2] = {{NULL, NULL, -1}, {NULL, NULL, -1}}, cb[3] = {{NULL, NULL, -1}, {NULL, NULL, -1}, {NULL, NULL, -1}};
    StackBlk s = {.blk = NULL};
    int ok = 1;
    for (Py_ssize_t i = 0; ok && i < m && i < PyList_GET_SIZE(gs); i++) {
        PyObject *g = Py_NewRef(PyList_GET_ITEM(gs, i));
        PyObject *blk = attr_of(g, names[0], &cg[0]);
        PyObject *ko = blk ? attr_of(g, names[1], &cg[1]) : NULL;
        Py_DECREF(g);
        Py_ssize_t k = -1;
        if (ko && PyLong_CheckExact(ko)) k = PyLong_AsSsize_t(ko);
        Py_XDECREF(ko);
        if (blk && blk != s.blk && !stack_blk_set(&s, blk, n, want_u, names + 2, cb)) k = -1;
        Py_XDECREF(blk);    /* (s holds its block) */
        if (k < 0 || k >= s.rows) {
            ok = 0;
            break;
        }
        memcpy(D + i * n, (const double *)s.d.buf + k * n, (size_t)n * sizeof(double));
        if (want_u && !stack_u_row(&s, k, n, names[5], U + i * n * 2)) ok = 0;
    }
    ok = ok && m == PyList_GET_SIZE(gs);
    if (PyErr_Occurred()) PyErr_Clear();
    stack_blk_clear(&s);
    for (int i = 0; i < 2; i++) attr_cache_clear(&cg[i]);
    for (int i = 0; i < 3; i++) attr_cache_clear(&cb[i]);
    release(&b);
    return PyLong_FromLong(ok);
}

/* curves.row_geom put on strokes in one pass: for k, st in enumerate(sts) (a list): where
   st.curv is None (every k where not only_none), st.curv = a new geometry of type tp (tp's
   own allocation, no __init__: CurveGeom.__new__) with _b = blk, _k = k, chain_caps =
   chain[k] (chain a list of at least len(sts), or None: None each) and _j1 = j1.  The
   geometry's four fields are stored at their slots' offsets where tp's descriptors of
   them are plain object slots (else set as attributes), st.curv through the descriptor
   found once a run of strokes of one type.  The number of geometries put; raises where a
   read or a write raises (the strokes before keep theirs, as the Python loop leaves them). */
static Py_ssize_t slot_offset(PyTypeObject *tp, PyObject *name)
{
    PyObject *d = _PyType_Lookup(tp, name);
    if (d == NULL || Py_TYPE(d) != &PyMemberDescr_Type) return -1;
    PyMemberDef *m = ((PyMemberDescrObject *)d)->d_member;
    return m->type == T_OBJECT_EX && m->flags == 0 ? m->offset : -1;
}

static PyObject *put_geoms(PyObject *self, PyObject *a)
{
    PyObject *blk, *sts, *chain, *tpo, *j1;
    int only_none;
    if (!PyArg_ParseTuple(a, "OO!OO!Op:put_geoms", &blk, &PyList_Type, &sts, &chain, &PyType_Type, &tpo, &j1,
                          &only_none))
        return NULL;
    PyTypeObject *tp = (PyTypeObject *)tpo;
    if (chain != Py_None && (!PyList_CheckExact(chain) || PyList_GET_SIZE(chain) < PyList_GET_SIZE(sts))) {
        PyErr_SetString(PyExc_ValueError, "put_geoms: chain a list as long as sts, or None");
        return NULL;
    }
    static PyObject *names[5] = {NULL};     /* curv; _b, _k, chain_caps, _j1 */
    static const char *const strs[5] = {"curv", "_b", "_k", "chain_caps", "_j1"};
    for (int i = 0; i < 5; i++)
        if (!names[i] && !(names[i] = PyUnicode_InternFromString(strs[i]))) return NULL;
    Py_ssize_t off[4];
    int direct = tp->tp_setattro == PyObject_GenericSetAttr;
    for (int i = 0; i < 4; i++)
        direct = direct && (off[i] = slot_offset(tp, names[i + 1])) >= 0;
    AttrCache c = {NULL, NULL, -1};
    PyTypeObject *st_tp = NULL;     /* the strokes' type (strong) whose curv descriptor is set_d (borrowed from it) */
    PyObject *set_d = NULL;
    Py_ssize_t given = 0;
    int ok = 1;
    for (Py_ssize_t k = 0; ok && k < PyList_GET_SIZE(sts); k++) {
        PyObject *st = Py_NewRef(PyList_GET_ITEM(sts, k));
        if (only_none) {
            PyObject *cur = attr_of(st, names[0], &c);
            if (!cur) { Py_DECREF(st); ok = 0; break; }
            Py_DECREF(cur);
            if (cur != Py_None) { Py_DECREF(st); continue; }
        }
        if (Py_TYPE(st) != st_tp) {
            Py_XSETREF(st_tp, (PyTypeObject *)Py_NewRef(Py_TYPE(st)));
            set_d = st_tp->tp_setattro == PyObject_GenericSetAttr ? _PyType_Lookup(st_tp, names[0]) : NULL;
            if (set_d != NULL && Py_TYPE(set_d)->tp_descr_set == NULL) set_d = NULL;
        }
        if (chain != Py_None && k >= PyList_GET_SIZE(chain)) {
            Py_DECREF(st);
            PyErr_SetString(PyExc_ValueError, "put_geoms: chain shorter than sts");
            ok = 0;
            break;
        }
        PyObject *g = tp->tp_alloc(tp, 0);
        PyObject *ko = g ? PyLong_FromSsize_t(k) : NULL;
        PyObject *cc = Py_NewRef(chain == Py_None ? Py_None : PyList_GET_ITEM(chain, k));
        if (!ko) {
            ok = 0;
        } else if (direct) {        /* (a new object's slots are NULL: nothing to let go) */
            PyObject *v[4] = {blk, ko, cc, j1};
            for (int i = 0; i < 4; i++)
                *(PyObject **)((char *)g + off[i]) = Py_NewRef(v[i]);
        } else {
            ok = PyObject_SetAttr(g, names[1], blk) == 0 && PyObject_SetAttr(g, names[2], ko) == 0
                 && PyObject_SetAttr(g, names[3], cc) == 0 && PyObject_SetAttr(g, names[4], j1) == 0;
        }
        if (ok)
            ok = (set_d ? Py_TYPE(set_d)->tp_descr_set(set_d, st, g) : PyObject_SetAttr(st, names[0], g)) == 0;
        Py_DECREF(cc);
        Py_XDECREF(ko);
        Py_XDECREF(g);
        Py_DECREF(st);
        given += ok;
    }
    attr_cache_clear(&c);
    Py_XDECREF(st_tp);
    return ok ? PyLong_FromSsize_t(given) : NULL;
}

/* geom_keep's chain caps given back: [buf[a[i]:z[i]] if has[i] else None for i in range(m)]
   (bytes of buf, any C-contiguous buffer; a, z int64, has one byte a row, m of each), the
   same bytes as Python's slices of buf's bytes. */
static PyObject *byte_runs(PyObject *self, PyObject *args)
{
    PyObject *ob, *oa, *oz, *oh;
    Py_ssize_t m;
    if (!PyArg_ParseTuple(args, "OOOOn:byte_runs", &ob, &oa, &oz, &oh, &m)) return NULL;
    Py_buffer v;
    if (PyObject_GetBuffer(ob, &v, PyBUF_C_CONTIGUOUS) < 0) return NULL;
    Bufs b = {.n = 0};
    const int64_t *a = get(&b, oa, 8, 0, m), *z = a ? get(&b, oz, 8, 0, m) : NULL;
    const char *has = z ? get(&b, oh, 1, 0, m) : NULL;
    PyObject *out = has ? PyList_New(m) : NULL;
    for (Py_ssize_t i = 0; out && i < m; i++) {
        PyObject *x;
        if (!has[i]) {
            x = Py_NewRef(Py_None);
        } else if (a[i] < 0 || z[i] < a[i] || z[i] > v.len) {
            PyErr_SetString(PyExc_IndexError, "byte_runs: a run out of the buffer");
            x = NULL;
        } else {
            x = PyBytes_FromStringAndSize((const char *)v.buf + a[i], (Py_ssize_t)(z[i] - a[i]));
        }
        if (!x) Py_CLEAR(out);
        else PyList_SET_ITEM(out, i, x);
    }
    release(&b);
    PyBuffer_Release(&v);
    return out;
}

static PyMethodDef methods[] = {
    {"pc_solve", pc_solve, METH_VARARGS, "_precond_cheb: the preconditioned iteration of each arc, whole"},
    {"rows_take", rows_take, METH_VARARGS, "rows of a table (or its transpose's columns) into zero-padded blocks"},
    {"rows_put", rows_put, METH_VARARGS, "rows back into their places in a table"},
    {"kern_args", kern_args, METH_VARARGS, "_parts_block's curvature kernel before np.exp"},
    {"jerk_caps", jerk_caps, METH_VARARGS, "curves._jerk_caps of a block of strokes' interior vertices"},
    {"simd", simd, METH_VARARGS, "simd([flag]): whether the AVX loops are used (flag 0 turns them off, 1 on)"},
    {"lay_pre", lay_pre, METH_VARARGS, "_layers_total's argument of np.exp"},
    {"lay_mid", lay_mid, METH_VARARGS, "_layers_total's arguments of np.arcsinh"},
    {"lay_post", lay_post, METH_VARARGS, "_layers_total's sum"},
    {"lay_step", lay_step, METH_VARARGS, "_solve_layers_batch's step: residuals, slope, bracket, step, test, packing"},
    {"kern_pack", kern_pack, METH_VARARGS, "_parts_block's kernel arguments np.exp does not take to +0.0, packed, and each row's run"},
    {"kern_unpack", kern_unpack, METH_VARARGS, "the kernel from np.exp of kern_pack's arguments, +0.0 outside the runs"},
    {"exp_split", exp_split, METH_VARARGS, "the arguments np.exp does not take to +0.0, packed"},
    {"exp_merge", exp_merge, METH_VARARGS, "np.exp of the packed arguments back in place, +0.0 elsewhere"},
    {"cheb_der_int", cheb_der_int, METH_VARARGS, "chebder and chebint of Chebyshev series rows"},
    {"probe_rows", probe_rows, METH_VARARGS, "curves.surely_over's speed and tangential-|a| decisions of each row"},
    {"screen_rows", screen_rows, METH_VARARGS, "curves._screen_a_only's speed and tangential-|a| probe of rough laws, whole"},
    {"interp_rows", interp_rows, METH_VARARGS, "np.interp of each row at its own knots (_kappa_rows)"},
    {"row_lengths", row_lengths, METH_VARARGS, "circle._row_lengths: each row's own number of coefficients"},
    {"graded_grid", graded_grid, METH_VARARGS, "circle._graded_grid's nodes and weights"},
    {"wsum_rows", wsum_rows, METH_VARARGS, "curves._true_figures_rows' sums of weighted rows"},
    {"lag_rows", lag_rows, METH_VARARGS, "curves._lag_rows: x[:, lag:] - x[:, :-lag] (or x[:, :-lag] + x[:, lag:])"},
    {"div_pairs", div_pairs, METH_VARARGS, "curves._parts_block's seg / d[..., None]"},
    {"row_scale", row_scale, METH_VARARGS, "curves._row_scale: R[:, None] * x, over T or T ** 2 (p = 1, 2)"},
    {"u_rows", u_rows, METH_VARARGS, "the unit directions of geometry block rows from their vertices (curves._Blk)"},
    {"obj_floats", obj_floats, METH_VARARGS, "the float (or bool) attributes of a list of objects, in one pass"},
    {"obj_codes", obj_codes, METH_VARARGS, "a code (from a dict, or the int itself) of each object's attribute"},
    {"list_put", list_put, METH_VARARGS, "dst[rows[k]] = src[at[k]] (or src[k], or src) of lists, in one pass"},
    {"list_take", list_take, METH_VARARGS, "[src[i] for i in rows] of a list, in one pass"},
    {"byte_runs", byte_runs, METH_VARARGS, "runs of a buffer's bytes as bytes objects, None where not asked"},
    {"put_geoms", put_geoms, METH_VARARGS, "curves.row_geom of a block's rows put on their strokes, in one pass"},
    {"stack_rows", stack_rows, METH_VARARGS, "curves.stack_du / stack_d: geometry rows' lengths and directions stacked"},
    {"obj_ids", obj_ids, METH_VARARGS, "the distinct attribute objects (by identity) of a list's objects and each one's place"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef curvecore_module = {
    PyModuleDef_HEAD_INIT, "_gcode_opt_curvecore",
    "Compiled elementwise steps of the circle law's iteration and the curves' kernel", -1, methods};

#ifndef CURVECORE_SOURCE_SHA256
#define CURVECORE_SOURCE_SHA256 ""
#endif
#ifndef GCODE_OPT_SOURCE_STAT   /* setup.py: the digest and the stat of each file it covers, when taken (native.stat_record) */
#define GCODE_OPT_SOURCE_STAT ""
#endif

PyMODINIT_FUNC PyInit__gcode_opt_curvecore(void) {
    PyObject *mod = PyModule_Create(&curvecore_module);
    if (mod && (PyModule_AddStringConstant(mod, "SOURCE_SHA256", CURVECORE_SOURCE_SHA256) < 0
                || PyModule_AddStringConstant(mod, "SOURCE_STAT", GCODE_OPT_SOURCE_STAT) < 0)) {
        Py_DECREF(mod);
        return NULL;
    }
    return mod;
}
