/* The rewrite's per-line work compiled: the emitter's reading of a stroke's plain lines
(emit._plain_moves), its segment lines (emit.emit_stroke's loop) and the validator's
column pass over a block it wrote (validate._fast_ok).

Optional extension _gcode_opt_emit (setup.py builds it; emit.py and validate.py run their
Python code when it is missing, stale or GCODE_OPT_PURE_PYTHON is set).  Every function
here declines -- returns NotImplemented (plain_moves) or None (emit_body, fast_body) --
on anything its Python counterpart would treat otherwise than the common case (a text
that is not ASCII, a number past the exact integer range, a value Python refuses with an
exception, a point near its tolerance): the Python code then runs as before, with its
own result or exception.  What it does return is the Python code's result:
  * texts: integers formatted as the Python code formats them (no float formatting:
    the emitter's feeds and accelerations are rounded up to integer tenths first);
  * numbers read: PyOS_string_to_double, which is float(), on texts of the plain
    decimal grammar -?(digits[.digits] | .digits);
  * floats: the same IEEE operations in the same order (built with -ffp-contract=off,
    no fast math), round() as float.__round__ does it;
  * the validator passes a block only when its verdict is certain: a distance within
    1e-12 (relative) of its tolerance, or a filament sum within its rounding bound of the
    limit, goes to the Python check (math.hypot and math.fsum are not libm's).
The validator reads the block's own text: it does not use the emitter's numbers. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#define EXACT_MAX 9007199254740992.0     /* 2^53: integers exact as doubles */
#define TENTHS_MAX (1LL << 50)            /* emit._TENTHS_MAX */
#define MAX_DECIMALS 8                    /* validate.MAX_DECIMALS */
#define E_TOL 1e-7                        /* validate.E_TOL */
#define MARGIN_R 1e-12                    /* a verdict this close to its limit: Python's */
#define MCR "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO="
#define MCR_N ((Py_ssize_t)sizeof(MCR) - 1)

/* ---------------------------------------------------------------- small helpers */

/* an ASCII str's bytes, else NULL (no exception) */
static inline const char *ascii(PyObject *o, Py_ssize_t *n)
{
    if (!PyUnicode_CheckExact(o) || !PyUnicode_IS_COMPACT_ASCII(o))
        return NULL;
    *n = PyUnicode_GET_LENGTH(o);
    return (const char *)PyUnicode_DATA(o);
}

/* length of the plain decimal -?(\d+(\.\d*)?|\.\d+) at p[0..n), or -1; *dec: its decimals */
static Py_ssize_t plain_decimal(const char *p, Py_ssize_t n, int *dec)
{
    Py_ssize_t i = 0, nd = 0, nf = 0;
    if (i < n && p[i] == '-')
        i++;
    while (i < n && p[i] >= '0' && p[i] <= '9') i++, nd++;
    *dec = 0;
    if (i < n && p[i] == '.') {
        i++;
        while (i < n && p[i] >= '0' && p[i] <= '9') i++, nf++;
        *dec = (int)nf;
    }
    return (nd + nf > 0) ? i : -1;
}

/* a run of [-.0-9] (the Python patterns' number) from p[0..n): its length */
static inline Py_ssize_t num_run(const char *p, Py_ssize_t n)
{
    Py_ssize_t i = 0;
    while (i < n && ((p[i] >= '0' && p[i] <= '9') || p[i] == '-' || p[i] == '.')) i++;
    return i;
}

/* exact powers of ten as doubles */
static const double POW10[16] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14,
                                 1e15};

/* float() of a plain decimal text of length n (no exception: the grammar is checked).
   At most 15 digits: the digits m and 10^d (d decimals) are exact doubles, so m / 10^d,
   one correctly rounded division, is the correctly rounded value float() gives (Clinger's
   fast path); other texts go to PyOS_string_to_double, which is float(). */
static double to_double(const char *p, Py_ssize_t n)
{
    char tmp[64];
    char *end;
    double v;
    {
        Py_ssize_t i = 0;
        int neg = 0, nd = 0, dec = 0, dot = 0;
        uint64_t m = 0;
        if (n > 0 && p[0] == '-') {
            neg = 1;
            i = 1;
        }
        for (; i < n; i++) {
            char c = p[i];
            if (c == '.') {
                if (dot) goto slow;
                dot = 1;
            } else if (c >= '0' && c <= '9' && nd < 15) {
                m = m * 10 + (uint64_t)(c - '0');
                nd++;
                dec += dot;
            } else
                goto slow;
        }
        if (nd == 0) goto slow;
        v = (double)m;
        if (dec) v = v / POW10[dec];
        return neg ? -v : v;
    }
slow:
    if (n < (Py_ssize_t)sizeof(tmp)) {
        memcpy(tmp, p, n);
        tmp[n] = 0;
        v = PyOS_string_to_double(tmp, &end, NULL);
    } else {
        char *big = PyMem_Malloc(n + 1);
        if (big == NULL) { PyErr_Clear(); return NAN; }
        memcpy(big, p, n);
        big[n] = 0;
        v = PyOS_string_to_double(big, &end, NULL);
        PyMem_Free(big);
    }
    if (v == -1.0 && PyErr_Occurred()) { PyErr_Clear(); return NAN; }
    return v;
}

/* growable byte buffer */
typedef struct { char *p; Py_ssize_t n, cap; } Buf;

static int buf_grow(Buf *b, Py_ssize_t more)
{
    if (b->n + more <= b->cap)
        return 0;
    Py_ssize_t cap = b->cap ? b->cap : 4096;
    while (cap < b->n + more) cap *= 2;
    char *p = PyMem_Realloc(b->p, cap);
    if (p == NULL)
        return -1;
    b->p = p;
    b->cap = cap;
    return 0;
}

static Buf EMIT_BUF = {NULL, 0, 0};            /* emit_text's buffer, reused (the GIL is held) */

/* give emit_text's buffer back for the next block (a huge one is freed) */
static void keep_buf(Buf *b)
{
    if (b->cap > (1 << 22)) {
        PyMem_Free(b->p);
        b->p = NULL;
        b->cap = 0;
    }
    b->n = 0;
    EMIT_BUF = *b;
}

static inline int put(Buf *b, const char *s, Py_ssize_t n)
{
    if (buf_grow(b, n) < 0)
        return -1;
    memcpy(b->p + b->n, s, n);
    b->n += n;
    return 0;
}

/* a str of n ASCII bytes (PyUnicode_FromStringAndSize without its UTF-8 decoding) */
static inline PyObject *ascii_str(const char *p, Py_ssize_t n)
{
    PyObject *o = PyUnicode_New(n, 127);
    if (o != NULL)
        memcpy(PyUnicode_DATA(o), p, n);
    return o;
}

/* ---------------------------------------------------------------- plain_moves */

/* emit._start_decimals(text) for an ASCII text: the decimals, trailing zeros cut, at most 6 */
static int start_decimals(const char *p, Py_ssize_t n)
{
    const char *dot = memchr(p, '.', n);
    if (dot == NULL)
        return 0;
    Py_ssize_t f = n - (dot - p) - 1;
    while (f > 0 && dot[f] == '0') f--;
    return f < 6 ? (int)f : 6;
}

/* plain_moves(raws, x_start_text, y_start_text): emit._plain_moves(raws) -- the tuple, or
   None where it gives None -- with two more items: StrokeText's dec_xy and dec_e for these
   lines and start texts; or NotImplemented (a line or start text not an ASCII str, raws
   not a list: the Python reading decides). */
static PyObject *plain_moves(PyObject *self, PyObject *args)
{
    PyObject *raws, *xs0, *ys0;
    Py_ssize_t n0x, n0y;
    if (!PyArg_ParseTuple(args, "OOO", &raws, &xs0, &ys0))
        return NULL;
    const char *p0x = ascii(xs0, &n0x), *p0y = ascii(ys0, &n0y);
    if (!PyList_CheckExact(raws) || p0x == NULL || p0y == NULL)
        Py_RETURN_NOTIMPLEMENTED;
    int dec_xy = 3, dec_e = 5, d0;                    /* at least 3 and 5: _decimals_at_least */
    if ((d0 = start_decimals(p0x, n0x)) > dec_xy) dec_xy = d0;
    if ((d0 = start_decimals(p0y, n0y)) > dec_xy) dec_xy = d0;
    Py_ssize_t n = PyList_GET_SIZE(raws);
    if (n == 0)
        Py_RETURN_NONE;
    /* the shape of every line first (a None costs no objects) */
    for (Py_ssize_t k = 0; k < n; k++) {
        Py_ssize_t m;
        PyObject *o = PyList_GET_ITEM(raws, k);
        const char *p = ascii(o, &m);
        if (p == NULL)
            Py_RETURN_NOTIMPLEMENTED;
        if (m == 0 || p[m - 1] != '\n' || memchr(p, '\n', m - 1) != NULL)
            Py_RETURN_NONE;
    }
    PyObject *xs = PyList_New(n), *ys = PyList_New(n), *es = PyList_New(n), *given = PyList_New(n),
             *comments = PyList_New(n), *xv = PyList_New(n), *yv = PyList_New(n), *ev = PyList_New(0);
    PyObject *empty = PyUnicode_New(0, 0), *zero = PyUnicode_FromString("0");
    PyObject *res = NULL;
    int shape_ok = 1;
    if (!xs || !ys || !es || !given || !comments || !xv || !yv || !ev || !empty || !zero)
        goto done;
    for (Py_ssize_t k = 0; k < n && shape_ok; k++) {
        Py_ssize_t m = 0, i, r = 0;
        const char *p = ascii(PyList_GET_ITEM(raws, k), &m);
        m -= 1;                                      /* the line without its "\n" */
        Py_ssize_t xa, xn, ya, yn, ea = 0, en = 0, ca = 0, cn = 0;
        int dec;
        if (m < 4 || memcmp(p, "G1 X", 4) != 0) { shape_ok = 0; break; }
        i = 4;
        xa = i; xn = num_run(p + i, m - i); i += xn;
        if (xn == 0 || i + 2 > m || p[i] != ' ' || p[i + 1] != 'Y') { shape_ok = 0; break; }
        i += 2;
        ya = i; yn = num_run(p + i, m - i); i += yn;
        if (yn == 0) { shape_ok = 0; break; }
        if (i + 1 < m && p[i] == ' ' && p[i + 1] == 'E') {
            i += 2;
            ea = i; en = num_run(p + i, m - i); i += en;
            if (en == 0) { shape_ok = 0; break; }
        }
        while (i < m && (p[i] == ' ' || p[i] == '\t')) i++;
        if (i < m && p[i] == ';') {
            ca = i;
            while (i < m && p[i] != '\r') i++;
            cn = i - ca;
        }
        if (i < m && p[i] == '\r') i++;
        if (i != m) { shape_ok = 0; break; }
        /* the numbers: float()'s grammar over [-.0-9] (else the Python reading's None) */
        int dec_y, dec_e1 = 0;
        if (plain_decimal(p + xa, xn, &dec) != xn || plain_decimal(p + ya, yn, &dec_y) != yn
            || (en && plain_decimal(p + ea, en, &dec_e1) != en)) {
            res = Py_None;
            Py_INCREF(res);
            goto done;
        }
        /* the texts' decimals (a plain decimal has one '.': decimals() is its fraction's length) */
        if (dec > dec_xy) dec_xy = dec;
        if (dec_y > dec_xy) dec_xy = dec_y;
        if (dec_e1 > dec_e) dec_e = dec_e1;
        PyObject *t;
        if (!(t = ascii_str(p + xa, xn))) goto done;
        PyList_SET_ITEM(xs, k, t);
        if (!(t = ascii_str(p + ya, yn))) goto done;
        PyList_SET_ITEM(ys, k, t);
        if (en) {
            if (!(t = ascii_str(p + ea, en))) goto done;
        } else {
            t = zero;
            Py_INCREF(t);
        }
        PyList_SET_ITEM(es, k, t);
        t = en ? Py_True : Py_False;
        Py_INCREF(t);
        PyList_SET_ITEM(given, k, t);
        if (cn) {
            if (!(t = ascii_str(p + ca, cn))) goto done;
        } else {
            t = empty;
            Py_INCREF(t);
        }
        PyList_SET_ITEM(comments, k, t);
        if (!(t = PyFloat_FromDouble(to_double(p + xa, xn)))) goto done;
        PyList_SET_ITEM(xv, k, t);
        if (!(t = PyFloat_FromDouble(to_double(p + ya, yn)))) goto done;
        PyList_SET_ITEM(yv, k, t);
        if (en) {
            if (!(t = PyFloat_FromDouble(to_double(p + ea, en)))) goto done;
            r = PyList_Append(ev, t);
            Py_DECREF(t);
            if (r < 0) goto done;
        }
        (void)r;
    }
    if (!shape_ok) {
        res = Py_None;
        Py_INCREF(res);
        goto done;
    }
    PyObject *values = PyTuple_Pack(3, xv, yv, ev);
    if (values == NULL)
        goto done;
    PyObject *dx = PyLong_FromLong(dec_xy), *de = PyLong_FromLong(dec_e);
    if (dx != NULL && de != NULL)
        res = PyTuple_Pack(8, xs, ys, es, given, comments, values, dx, de);
    Py_DECREF(values);
    Py_XDECREF(dx);
    Py_XDECREF(de);
done:
    Py_XDECREF(xs); Py_XDECREF(ys); Py_XDECREF(es); Py_XDECREF(given); Py_XDECREF(comments);
    Py_XDECREF(xv); Py_XDECREF(yv); Py_XDECREF(ev); Py_XDECREF(empty); Py_XDECREF(zero);
    return res;
}

/* ---------------------------------------------------------------- emit_body */

/* emit._units(text, dec) when it takes its fast form and fits: 0, else -1 (decline) */
static int units(PyObject *o, int dec, int64_t *out)
{
    Py_ssize_t m;
    const char *p = ascii(o, &m);
    if (p == NULL)
        return -1;
    const char *dot = memchr(p, '.', m);
    Py_ssize_t wn = dot ? dot - p : m;
    Py_ssize_t fn = dot ? m - wn - 1 : 0;
    const char *f = dot ? dot + 1 : p + m;
    Py_ssize_t fk = fn <= dec ? fn : dec;          /* fraction digits kept */
    /* digits = whole + frac[:dec]: all ASCII digits, or a sign and at least one digit */
    Py_ssize_t i = 0;
    int neg = 0;
    if (wn > 0 && (p[0] == '+' || p[0] == '-')) {
        neg = p[0] == '-';
        i = 1;
    }
    if (wn - i + fk <= 0 || wn - i + fk > 15)       /* no digits (Python's slow path), or too many */
        return -1;
    int64_t v = 0;
    for (; i < wn; i++) {
        if (p[i] < '0' || p[i] > '9') return -1;
        v = v * 10 + (p[i] - '0');
    }
    for (Py_ssize_t j = 0; j < fk; j++) {
        if (f[j] < '0' || f[j] > '9') return -1;
        v = v * 10 + (f[j] - '0');
    }
    for (Py_ssize_t j = fk; j < dec; j++) {       /* v * 10 ** (dec - n) */
        if (v > (int64_t)EXACT_MAX) return -1;
        v *= 10;
    }
    if (v > (int64_t)EXACT_MAX) return -1;
    *out = neg ? -v : v;
    return 0;
}

/* emit._fmt_units(u, dec) appended */
static int put_units(Buf *b, int64_t u, int dec)
{
    char digits[40], tmp[48];
    uint64_t a = u < 0 ? (uint64_t)0 - (uint64_t)u : (uint64_t)u;
    int nd = 0;
    do { digits[nd++] = (char)('0' + a % 10); a /= 10; } while (a);   /* reversed */
    if (dec <= 0) {
        int t = 0;
        if (u < 0) tmp[t++] = '-';
        while (nd) tmp[t++] = digits[--nd];
        return put(b, tmp, t);
    }
    if (dec > 30) return -2;
    while (nd < dec + 1) digits[nd++] = '0';      /* zero-padded to dec + 1 digits */
    int fz = 0;                                    /* trailing zeros of the fraction */
    while (fz < dec && digits[fz] == '0') fz++;
    int t = 0;
    if (u < 0) tmp[t++] = '-';                     /* u != 0: whole != "0" or a fraction digit */
    for (int j = nd - 1; j >= dec; j--) tmp[t++] = digits[j];
    if (fz < dec) {
        tmp[t++] = '.';
        for (int j = dec - 1; j >= fz; j--) tmp[t++] = digits[j];
    }
    return put(b, tmp, t);
}

/* emit._tenths_up(k) appended (k < TENTHS_MAX) */
static int put_tenths_up(Buf *b, int64_t k)
{
    char tmp[32];
    int t = (int)sizeof tmp;
    if (k <= 1)
        return put(b, "0.1", 3);
    int r = (int)(k % 10);
    if (r) {
        tmp[--t] = (char)('0' + r);
        tmp[--t] = '.';
    }
    k /= 10;                                       /* k >= 1 here */
    do { tmp[--t] = (char)('0' + k % 10); k /= 10; } while (k);
    return put(b, tmp + t, (Py_ssize_t)sizeof tmp - t);
}

/* Python's round(x) of a float (float.__round__: half to even), as an int64: 0, or -1 */
static int py_round(double x, int64_t *out)
{
    if (!isfinite(x))
        return -1;
    double r = round(x);
    if (fabs(x - r) == 0.5)
        r = 2.0 * round(x / 2.0);
    if (!(fabs(r) < 4.0e18))
        return -1;
    *out = (int64_t)r;
    return 0;
}

/* emit.emit_stroke's inline E text of a whole move, relative E: "0" + t for ".ddd" not
   ending in 0, else _canon(t) */
static int put_canon(Buf *b, const char *t, Py_ssize_t m)
{
    if (m > 0 && t[0] == '.' && t[m - 1] != '0') {
        if (put(b, "0", 1) < 0) return -1;
        return put(b, t, m);
    }
    int neg = m > 0 && t[0] == '-';
    Py_ssize_t i = 0;
    while (i < m && (t[i] == '+' || t[i] == '-')) i++;         /* lstrip("+-") */
    const char *rest = t + i;
    Py_ssize_t rn = m - i;
    const char *dot = memchr(rest, '.', rn);
    Py_ssize_t wn = dot ? dot - rest : rn;
    const char *frac = dot ? dot + 1 : rest + rn;
    Py_ssize_t fn = dot ? rn - wn - 1 : 0;
    Py_ssize_t w0 = 0;
    while (w0 < wn && rest[w0] == '0') w0++;                   /* lstrip("0") */
    while (fn > 0 && frac[fn - 1] == '0') fn--;                /* rstrip("0") */
    int whole_zero = (w0 == wn);                                /* whole is "0" */
    if (!fn && whole_zero)
        return put(b, "0", 1);
    if (neg && put(b, "-", 1) < 0) return -1;
    if (whole_zero) {
        if (put(b, "0", 1) < 0) return -1;
    } else if (put(b, rest + w0, wn - w0) < 0) return -1;
    if (fn) {
        if (put(b, ".", 1) < 0) return -1;
        if (put(b, frac, fn) < 0) return -1;
    }
    return 0;
}

/* a sequence of doubles: a list of floats (copied), or the bytes of native doubles
   (emit._doubles: a float64 array's tobytes(); its items are the floats its tolist()
   gives).  Not the buffer protocol: numpy keeps a buffer's format and shape with the
   array until it dies, and the plan's arrays live to the end of the run (~7 MB of RSS on
   the rectilinear plate). */
typedef struct {
    double *own;
    const double *d;
    Py_ssize_t n;
} FSeq;

static void fseq_release(FSeq *f)
{
    PyMem_Free(f->own);
    f->own = NULL;
}

/* 0, or -1 (no exception): not such a sequence */
static int fseq_get(PyObject *o, FSeq *f)
{
    memset(f, 0, sizeof *f);
    if (PyList_CheckExact(o)) {
        Py_ssize_t n = PyList_GET_SIZE(o);
        f->own = PyMem_Malloc((n ? n : 1) * sizeof(double));
        if (f->own == NULL) return -1;
        for (Py_ssize_t k = 0; k < n; k++) {
            PyObject *v = PyList_GET_ITEM(o, k);
            if (!PyFloat_CheckExact(v)) return -1;
            f->own[k] = PyFloat_AS_DOUBLE(v);
        }
        f->d = f->own;
        f->n = n;
        return 0;
    }
    if (PyBytes_CheckExact(o) && PyBytes_GET_SIZE(o) % sizeof(double) == 0) {
        f->n = PyBytes_GET_SIZE(o) / (Py_ssize_t)sizeof(double);
        f->own = PyMem_Malloc((f->n ? f->n : 1) * sizeof(double));
        if (f->own == NULL) return -1;
        memcpy(f->own, PyBytes_AS_STRING(o), f->n * sizeof(double));
        f->d = f->own;
        return 0;
    }
    return -1;
}

typedef struct { int64_t x_a, x_b, y_a, y_b, e_move, e_before; } MoveUnits;

/* emit._move_units */
static int move_units(PyObject *xt, PyObject *yt, PyObject *et, Py_ssize_t move, const int64_t *start_u,
                      int dxy, int de, int e_rel, int64_t e_start_u, MoveUnits *mu)
{
    int64_t e_u, e_b;
    if (move == 0) {
        mu->x_a = start_u[0];
        mu->y_a = start_u[1];
    } else if (units(PyList_GET_ITEM(xt, move - 1), dxy, &mu->x_a) < 0
               || units(PyList_GET_ITEM(yt, move - 1), dxy, &mu->y_a) < 0)
        return -1;
    if (units(PyList_GET_ITEM(xt, move), dxy, &mu->x_b) < 0 || units(PyList_GET_ITEM(yt, move), dxy, &mu->y_b) < 0
        || units(PyList_GET_ITEM(et, move), de, &e_u) < 0)
        return -1;
    if (e_rel) {
        mu->e_move = e_u;
        mu->e_before = 0;
        return 0;
    }
    if (move == 0)
        e_b = e_start_u;
    else if (units(PyList_GET_ITEM(et, move - 1), de, &e_b) < 0)
        return -1;
    mu->e_move = e_u - e_b;
    mu->e_before = e_b;
    return 0;
}

/* emit_body(head, x_texts, y_texts, e_texts, comments, s, accels, feeds, ends_d, dxy, de,
             e_rel, extruding, e_start_units, x0_text, y0_text, accel_word, nl, before,
             after, closing)
   emit.emit_stroke's text: head + segment lines (before/after around the first move when
   not None) + closing; None where the Python loop would take another path or raise. */
static PyObject *emit_text(PyObject *head, PyObject *xt, PyObject *yt, PyObject *et, PyObject *cm, const FSeq *s,
                           const FSeq *acc, const FSeq *fd, const FSeq *ends, int dxy, int de, int e_rel,
                           int extruding, PyObject *e_start_o, PyObject *x0t, PyObject *y0t, PyObject *word,
                           PyObject *nlo, PyObject *before, PyObject *after, PyObject *closing);

static PyObject *emit_body(PyObject *self, PyObject *args)
{
    PyObject *head, *xt, *yt, *et, *cm, *s_o, *acc_o, *fd_o, *ends_o, *e_start_o, *x0t, *y0t, *word, *nlo, *before,
             *after, *closing;
    int dxy, de, e_rel, extruding;
    if (!PyArg_ParseTuple(args, "UO!O!O!O!OOOOiippOUUUUOOU", &head, &PyList_Type, &xt, &PyList_Type, &yt,
                          &PyList_Type, &et, &PyList_Type, &cm, &s_o, &acc_o, &fd_o, &ends_o, &dxy, &de, &e_rel, &extruding, &e_start_o,
                          &x0t, &y0t, &word, &nlo, &before, &after, &closing))
        return NULL;
    FSeq fs[4];
    for (int i = 0; i < 4; i++)
        memset(&fs[i], 0, sizeof fs[i]);
    PyObject *res = NULL;
    if (fseq_get(s_o, &fs[0]) == 0 && fseq_get(acc_o, &fs[1]) == 0 && fseq_get(fd_o, &fs[2]) == 0
        && fseq_get(ends_o, &fs[3]) == 0)
        res = emit_text(head, xt, yt, et, cm, &fs[0], &fs[1], &fs[2], &fs[3], dxy, de, e_rel, extruding, e_start_o,
                        x0t, y0t, word, nlo, before, after, closing);
    else
        res = Py_NewRef(Py_None);
    for (int i = 0; i < 4; i++)
        fseq_release(&fs[i]);
    return res;
}

static PyObject *emit_text(PyObject *head, PyObject *xt, PyObject *yt, PyObject *et, PyObject *cm, const FSeq *s,
                           const FSeq *acc, const FSeq *fd, const FSeq *ends, int dxy, int de, int e_rel,
                           int extruding, PyObject *e_start_o, PyObject *x0t, PyObject *y0t, PyObject *word,
                           PyObject *nlo, PyObject *before, PyObject *after, PyObject *closing)
{
    Py_ssize_t n_moves = ends->n, k_total = s->n - 1;
    Py_ssize_t hn = 0, wn = 0, nln = 0, cln = 0, bn = 0, an = 0;
    const char *hp = ascii(head, &hn), *wp = ascii(word, &wn), *nlp = ascii(nlo, &nln),
               *clp = ascii(closing, &cln), *bp = NULL, *ap = NULL;
    if (!hp || !wp || !nlp || !clp || n_moves == 0 || k_total < 0 || dxy < 0 || dxy > 15 || de < 0 || de > 15)
        Py_RETURN_NONE;
    if (before != Py_None && ((bp = ascii(before, &bn)) == NULL || (ap = ascii(after, &an)) == NULL))
        Py_RETURN_NONE;
    if (PyList_GET_SIZE(xt) < n_moves || PyList_GET_SIZE(yt) < n_moves || PyList_GET_SIZE(et) < n_moves
        || PyList_GET_SIZE(cm) < n_moves || acc->n < k_total || fd->n < k_total)
        Py_RETURN_NONE;
    int overflow = 0;
    long long e_start_u = PyLong_Check(e_start_o) ? PyLong_AsLongLongAndOverflow(e_start_o, &overflow) : 0;
    if (!PyLong_Check(e_start_o) || overflow || (e_start_u == -1 && PyErr_Occurred())
        || fabs((double)e_start_u) > EXACT_MAX) {
        PyErr_Clear();
        Py_RETURN_NONE;
    }
    int64_t start_u[2];
    if (units(x0t, dxy, &start_u[0]) < 0 || units(y0t, dxy, &start_u[1]) < 0)
        Py_RETURN_NONE;
    double end_last = ends->d[n_moves - 1];
    double tol_d = 1e-9 * (end_last > 1.0 ? end_last : 1.0);
    double end_d = ends->d[0], start_d = 0.0;
    /* one buffer for every block, kept between calls (a block's text is built there and
       copied once into its str): no growing allocations per block to fragment the heap */
    Buf b = EMIT_BUF;
    b.n = 0;
    Py_ssize_t move = 0;
    int have_mu = 0;
    MoveUnits mu;
    int64_t e_done_u = 0, e_again_u = 0;
    int have_a = 0, have_cmd = 0;
    double last_a = 0.0;
    int64_t last_ka = 0;
    if (put(&b, hp, hn) < 0)
        goto fail;
    for (Py_ssize_t k = 1; k <= k_total; k++) {
        double sk = s->d[k], a = acc->d[k - 1], f = fd->d[k - 1];
        if (!(sk <= end_d + tol_d))
            goto decline;                            /* "a knot skipped an original vertex" */
        int at_vertex = fabs(sk - end_d) <= tol_d;
        PyObject *xo = NULL, *yo = NULL, *co = NULL;
        int64_t xu = 0, yu = 0, eu = 0;
        int e_kind;                                  /* 0: e text as is, 1: canon, 2: units */
        if (at_vertex) {
            xo = PyList_GET_ITEM(xt, move);
            yo = PyList_GET_ITEM(yt, move);
            co = PyList_GET_ITEM(cm, move);
            if (!e_rel)
                e_kind = 0;
            else if (e_done_u == 0)
                e_kind = 1;
            else {
                if (units(PyList_GET_ITEM(et, move), de, &eu) < 0)
                    goto decline;
                eu -= e_done_u;
                e_kind = 2;
            }
        } else {
            double d_move = end_d - start_d, frac;
            if (d_move <= 0)
                frac = 1.0;
            else {
                double q = (sk - start_d) / d_move;
                q = q > 0.0 ? q : 0.0;               /* max(0.0, q) */
                frac = q < 1.0 ? q : 1.0;            /* min(1.0, q) */
            }
            if (!have_mu) {
                if (move_units(xt, yt, et, move, start_u, dxy, de, e_rel, e_start_u, &mu) < 0)
                    goto decline;
                have_mu = 1;
            }
            int64_t e_target_u;
            if (py_round((double)mu.x_a + (double)(mu.x_b - mu.x_a) * frac, &xu) < 0
                || py_round((double)mu.y_a + (double)(mu.y_b - mu.y_a) * frac, &yu) < 0
                || py_round((double)mu.e_move * frac, &e_target_u) < 0)
                goto decline;
            if (fabs((double)e_target_u) > EXACT_MAX || fabs((double)e_again_u) > EXACT_MAX)
                goto decline;
            eu = e_rel ? e_target_u - e_done_u : mu.e_before + e_again_u + e_target_u;
            e_done_u = e_target_u;
            e_kind = 2;
        }
        if (!have_a || a != last_a) {
            if (!(isfinite(a) && a > 0.0))
                goto decline;                        /* accel_command raises */
            double c = ceil(a * 10.0 - 1e-9);
            if (!(c < (double)TENTHS_MAX))
                goto decline;                        /* the float formatting (or ceil's OverflowError) */
            int64_t ka = (int64_t)c;
            if (ka <= 1) ka = 1;                     /* _tenths_up: every k <= 1 is "0.1" */
            have_a = 1;
            last_a = a;
            if (!have_cmd || ka != last_ka) {
                if (put(&b, wp, wp ? wn : 0) < 0 || put_tenths_up(&b, ka) < 0 || put(&b, nlp, nln) < 0)
                    goto fail;
                last_ka = ka;
                if (!have_cmd && bp != NULL && put(&b, bp, bn) < 0)   /* first_cmds[0], after the first M204 */
                    goto fail;
                have_cmd = 1;
            }
        }
        if (!(isfinite(f) && f > 0.0))
            goto decline;
        double cf = ceil(f * 600.0 - 1e-6);
        if (!(cf < (double)TENTHS_MAX))
            goto decline;
        /* the line */
        Py_ssize_t n1;
        const char *p1;
        if (put(&b, "G1 X", 4) < 0) goto fail;
        if (at_vertex) {
            if (!(p1 = ascii(xo, &n1))) goto decline;
            if (put(&b, p1, n1) < 0) goto fail;
        } else if (put_units(&b, xu, dxy) < 0) goto fail;
        if (put(&b, " Y", 2) < 0) goto fail;
        if (at_vertex) {
            if (!(p1 = ascii(yo, &n1))) goto decline;
            if (put(&b, p1, n1) < 0) goto fail;
        } else if (put_units(&b, yu, dxy) < 0) goto fail;
        if (extruding) {
            if (put(&b, " E", 2) < 0) goto fail;
            if (e_kind == 2) {
                if (put_units(&b, eu, de) < 0) goto fail;
            } else {
                if (!(p1 = ascii(PyList_GET_ITEM(et, move), &n1))) goto decline;
                if ((e_kind == 0 ? put(&b, p1, n1) : put_canon(&b, p1, n1)) < 0) goto fail;
            }
        }
        if (put(&b, " F", 2) < 0 || put_tenths_up(&b, (int64_t)cf) < 0) goto fail;
        if (co != NULL) {
            if (!(p1 = ascii(co, &n1))) goto decline;
            if (n1 && (put(&b, " ", 1) < 0 || put(&b, p1, n1) < 0)) goto fail;
        }
        if (put(&b, nlp, nln) < 0) goto fail;
        if (k == 1 && ap != NULL && put(&b, ap, an) < 0)   /* first_cmds[1], after the first move */
            goto fail;
        if (at_vertex) {
            e_done_u = 0;
            if (move < n_moves - 1) {
                move += 1;
                start_d = end_d;
                end_d = ends->d[move];
            } else if (!e_rel) {                     /* knots past the end: the last move again */
                if (!have_mu && move_units(xt, yt, et, move, start_u, dxy, de, e_rel, e_start_u, &mu) < 0)
                    goto decline;
                e_again_u += mu.e_move;
            }
            have_mu = 0;
        }
    }
    if (put(&b, clp, cln) < 0)
        goto fail;
    PyObject *res = PyUnicode_New(b.n, 127);
    if (res != NULL)
        memcpy(PyUnicode_DATA(res), b.p, b.n);
    keep_buf(&b);
    return res;
decline:
    keep_buf(&b);
    Py_RETURN_NONE;
fail:
    keep_buf(&b);
    return PyErr_NoMemory();
}

/* ---------------------------------------------------------------- fast_body */

/* fast_body(text, start, stop, want, klipper, limit, accel_max_a, px, py, tol_d, e_mode,
             e_value, min_move_d)
   validate._fast_ok's reading of text[start:stop] (the body: "\n" line "\n" ... line "\n")
   and its checks; True when they certainly pass, None otherwise (the Python reading then
   decides).  want: the M204 letter; limit: the command buffer (0: none); px, py: the
   polyline's vertices (None: no path check); e_mode: 0 none, 1 relative (the E words'
   sum), 2 absolute (the last E word). */
static PyObject *fast_body(PyObject *self, PyObject *args)
{
    PyObject *text, *pxo, *pyo;
    Py_ssize_t start, stop, limit;
    int want, klipper, e_mode;
    double accel_max_a, tol_d, e_value, min_move_d;
    if (!PyArg_ParseTuple(args, "UnnCpndOOdidd", &text, &start, &stop, &want, &klipper, &limit, &accel_max_a,
                          &pxo, &pyo, &tol_d, &e_mode, &e_value, &min_move_d))
        return NULL;
    Py_ssize_t tn;
    const char *t = ascii(text, &tn);
    if (t == NULL || start < 0 || stop > tn || stop - start < 1 || t[start] != '\n' || t[stop - 1] != '\n')
        Py_RETURN_NONE;
    int path = pxo != Py_None;
    Py_ssize_t nv = 0;
    if (path) {
        if (!PyList_CheckExact(pxo) || !PyList_CheckExact(pyo) || PyList_GET_SIZE(pxo) != PyList_GET_SIZE(pyo)
            || (nv = PyList_GET_SIZE(pxo)) < 2)
            Py_RETURN_NONE;
        for (Py_ssize_t j = 0; j < nv; j++) {      /* floats below validate._polyline_walk's bound */
            PyObject *a = PyList_GET_ITEM(pxo, j), *c = PyList_GET_ITEM(pyo, j);
            if (!PyFloat_CheckExact(a) || !PyFloat_CheckExact(c) || !(fabs(PyFloat_AS_DOUBLE(a)) < 1e150)
                || !(fabs(PyFloat_AS_DOUBLE(c)) < 1e150))
                Py_RETURN_NONE;
        }
    }
#define PX(j) PyFloat_AS_DOUBLE(PyList_GET_ITEM(pxo, (j)))
#define PY(j) PyFloat_AS_DOUBLE(PyList_GET_ITEM(pyo, (j)))
    const double accel_hi = accel_max_a + 0.1 + 1e-9;
    Py_ssize_t j = 1;                               /* the next original vertex */
    double x_prev = 0.0, y_prev = 0.0, gap_least = INFINITY;
    int n_points = 0;
    double e_sum = 0.0, e_abs = 0.0, e_last = 0.0;
    Py_ssize_t n_e = 0;
    if (path) {
        x_prev = PX(0);
        y_prev = PY(0);
    }
    const char *p = t + start + 1, *end = t + stop;
    while (p < end) {
        const char *q = memchr(p, '\n', end - p);   /* the line is p[0..m) */
        Py_ssize_t m = q - p, i, r;
        int dec;
        if (limit > 0 && m > limit)
            Py_RETURN_NONE;
        if (m > 4 && memcmp(p, "G1 X", 4) == 0) {
            /* "G1 X<n> Y<n>[ E<n>] F<n>" */
            Py_ssize_t xa = 4, xn, ya, yn, ea = 0, en = 0, fa, fn;
            int dx_, dy_;
            i = 4;
            xn = plain_decimal(p + i, m - i, &dx_);
            if (xn < 0 || dx_ > MAX_DECIMALS) Py_RETURN_NONE;
            i += xn;
            if (i + 2 > m || p[i] != ' ' || p[i + 1] != 'Y') Py_RETURN_NONE;
            i += 2;
            ya = i;
            yn = plain_decimal(p + i, m - i, &dy_);
            if (yn < 0 || dy_ > MAX_DECIMALS) Py_RETURN_NONE;
            i += yn;
            if (i + 2 <= m && p[i] == ' ' && p[i + 1] == 'E') {
                i += 2;
                ea = i;
                en = plain_decimal(p + i, m - i, &dec);
                if (en < 0 || dec > MAX_DECIMALS) Py_RETURN_NONE;
                i += en;
            }
            if (i + 2 > m || p[i] != ' ' || p[i + 1] != 'F') Py_RETURN_NONE;
            i += 2;
            fa = i;
            fn = plain_decimal(p + i, m - i, &dec);
            if (fn < 0 || dec > MAX_DECIMALS || i + fn != m) Py_RETURN_NONE;
            double x = to_double(p + xa, xn), y = to_double(p + ya, yn), f = to_double(p + fa, fn);
            if (!(isfinite(x) && isfinite(y) && f > 0.0 && f < INFINITY)) Py_RETURN_NONE;
            if (en) {
                double e = to_double(p + ea, en);
                if (!isfinite(e)) Py_RETURN_NONE;
                e_sum += e;
                e_abs += fabs(e);
                e_last = e;
                n_e++;
            }
            if (path) {
                if (j < nv && x == PX(j) && y == PY(j))
                    j++;
                else {
                    Py_ssize_t k = j < nv ? j - 1 : nv - 2;
                    double ax = PX(k), ay = PY(k);
                    double ddx = PX(k + 1) - ax, ddy = PY(k + 1) - ay;
                    double dd = ddx * ddx + ddy * ddy, tt;
                    if (dd <= 0)
                        tt = 0.0;
                    else {
                        double u = ((x - ax) * ddx + (y - ay) * ddy) / dd;
                        u = u > 0.0 ? u : 0.0;
                        tt = u < 1.0 ? u : 1.0;
                    }
                    double d = hypot(x - ax - tt * ddx, y - ay - tt * ddy);
                    int dmax = dx_ > dy_ ? dx_ : dy_;   /* validate._tol */
                    double tv = 0.75 * pow(10.0, (double)-dmax);
                    double tol = (tv < tol_d ? tv : tol_d) + 1e-7;
                    if (!(d <= tol * (1.0 - MARGIN_R)))
                        Py_RETURN_NONE;              /* off this segment, or near: Python's search */
                }
                double gx = fabs(x - x_prev), gy = fabs(y - y_prev);
                double g = gy > gx ? gy : gx;
                if (g < gap_least) gap_least = g;
                x_prev = x;
                y_prev = y;
            }
            n_points++;
        } else if (m > 4 && memcmp(p, "G1 F", 4) == 0) {
            i = 4;
            r = plain_decimal(p + i, m - i, &dec);
            if (r < 0 || dec > MAX_DECIMALS || i + r != m) Py_RETURN_NONE;
            double f = to_double(p + i, r);
            if (!(f > 0.0 && f < INFINITY)) Py_RETURN_NONE;
        } else if (m > 6 && memcmp(p, "M204 ", 5) == 0 && p[5] == want) {
            i = 6;
            r = plain_decimal(p + i, m - i, &dec);
            if (r < 0 || dec > MAX_DECIMALS || i + r != m) Py_RETURN_NONE;
            double a = to_double(p + i, r);
            if (!(a > 0.0 && a <= accel_hi && a < INFINITY)) Py_RETURN_NONE;
        } else if (klipper && m > MCR_N && memcmp(p, MCR, MCR_N) == 0) {
            i = MCR_N;
            r = plain_decimal(p + i, m - i, &dec);
            if (r < 0 || dec > MAX_DECIMALS || i + r != m) Py_RETURN_NONE;
            double v = to_double(p + i, r);
            if (!(v >= 0.0 && v < 1.0)) Py_RETURN_NONE;
        } else
            Py_RETURN_NONE;
        p = q + 1;
    }
    if (path && min_move_d > 0.0 && n_points && gap_least < min_move_d) {
        /* _ShortMoves' floor: the original's own shortest move passes too */
        double floor_d = min_move_d;
        if (nv > 2) {
            double own = INFINITY;
            for (Py_ssize_t k = 0; k + 1 < nv; k++) {
                double gx = fabs(PX(k + 1) - PX(k)), gy = fabs(PY(k + 1) - PY(k));
                double g = gy > gx ? gy : gx;
                if (g < own) own = g;
            }
            double o = own * (1.0 - 1e-9);
            if (o < floor_d) floor_d = o;
        }
        if (gap_least < floor_d)
            Py_RETURN_NONE;
    }
    if (e_mode) {
        if (n_e == 0)
            Py_RETURN_NONE;
        double lim = E_TOL * (1.0 + fabs(e_value));
        if (e_mode == 2) {
            if (fabs(e_last - e_value) > lim) Py_RETURN_NONE;
        } else {
            /* fsum is within half an ulp of the exact sum, the running sum within
               (n - 1) u sum|e| of it: a pass this far inside the limit is fsum's too */
            double err = 2.0 * (double)n_e * 1.1102230246251565e-16 * e_abs + 1e-300;
            if (!(fabs(e_sum - e_value) + 2.0 * err <= lim * (1.0 - MARGIN_R))) Py_RETURN_NONE;
        }
    }
#undef PX
#undef PY
    Py_RETURN_TRUE;
}

/* decimal_value(text): to_double on a plain decimal (for the tests), else None */
static PyObject *decimal_value(PyObject *self, PyObject *o)
{
    Py_ssize_t n;
    int dec;
    const char *p = ascii(o, &n);
    if (p == NULL || plain_decimal(p, n, &dec) != n)
        Py_RETURN_NONE;
    return PyFloat_FromDouble(to_double(p, n));
}

static PyMethodDef mod_methods[] = {
    {"decimal_value", decimal_value, METH_O, "float(text) of a plain decimal text, else None (tests)"},
    {"plain_moves", plain_moves, METH_VARARGS,
     "emit._plain_moves(raws) + (dec_xy, dec_e), or NotImplemented"},
    {"emit_body", emit_body, METH_VARARGS, "emit.emit_stroke's text, or None"},
    {"fast_body", fast_body, METH_VARARGS, "True when validate._fast_ok's checks certainly pass, else None"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef emit_module = {
    PyModuleDef_HEAD_INIT, "_gcode_opt_emit",
    "The rewrite's per-line work compiled (gcode_opt/_emit.c; see emit.py, validate.py).", -1, mod_methods,
};

#ifndef EMIT_SOURCE_SHA256
#define EMIT_SOURCE_SHA256 ""
#endif

PyMODINIT_FUNC PyInit__gcode_opt_emit(void)
{
    PyObject *m = PyModule_Create(&emit_module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddStringConstant(m, "SOURCE_SHA256", EMIT_SOURCE_SHA256) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
