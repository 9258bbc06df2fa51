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
static int units_txt(const char *p, Py_ssize_t m, int dec, int64_t *out)
{
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

/* a text of a stroke's line: an ASCII str's bytes, or a piece of a line stroke_block read */
typedef struct { const char *p; Py_ssize_t n; } Txt;

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

/* set_types(ndarray, float64 dtype, array.array): what fseq_get reads besides lists and bytes */
static PyObject *ND_TYPE = NULL, *F64_DTYPE = NULL, *ARRAY_TYPE = NULL;

static PyObject *set_types(PyObject *self, PyObject *args)
{
    PyObject *nd, *f64, *arr;
    if (!PyArg_ParseTuple(args, "O!OO!", &PyType_Type, &nd, &f64, &PyType_Type, &arr))
        return NULL;
    Py_XSETREF(ND_TYPE, Py_NewRef(nd));
    Py_XSETREF(F64_DTYPE, Py_NewRef(f64));
    Py_XSETREF(ARRAY_TYPE, Py_NewRef(arr));
    Py_RETURN_NONE;
}

/* the doubles of a 1-D float64 ndarray (its tobytes(), as emit._doubles takes them) or an
   array.array('d') (its buffer: array.array keeps nothing of a buffer after its release),
   into f: 0; -1 (no exception): not one */
static int fseq_object(PyObject *o, FSeq *f)
{
    PyObject *bytes = NULL;
    if (ND_TYPE != NULL && Py_IS_TYPE(o, (PyTypeObject *)ND_TYPE)) {
        PyObject *dt = PyObject_GetAttrString(o, "dtype");
        int ok = dt == F64_DTYPE;
        Py_XDECREF(dt);
        if (ok) {
            PyObject *nd = PyObject_GetAttrString(o, "ndim");
            ok = nd != NULL && PyLong_CheckExact(nd) && PyLong_AsLong(nd) == 1;
            Py_XDECREF(nd);
        }
        if (ok)
            bytes = PyObject_CallMethod(o, "tobytes", NULL);
        if (bytes == NULL || !PyBytes_CheckExact(bytes) || PyBytes_GET_SIZE(bytes) % sizeof(double)) {
            Py_XDECREF(bytes);
            PyErr_Clear();
            return -1;
        }
        f->n = PyBytes_GET_SIZE(bytes) / (Py_ssize_t)sizeof(double);
        f->own = PyMem_Malloc((f->n ? f->n : 1) * sizeof(double));
        if (f->own != NULL)
            memcpy(f->own, PyBytes_AS_STRING(bytes), f->n * sizeof(double));
        Py_DECREF(bytes);
        f->d = f->own;
        return f->own != NULL ? 0 : -1;
    }
    if (ARRAY_TYPE != NULL && Py_IS_TYPE(o, (PyTypeObject *)ARRAY_TYPE)) {
        Py_buffer v;
        if (PyObject_GetBuffer(o, &v, PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0) {
            PyErr_Clear();
            return -1;
        }
        int ok = v.format != NULL && strcmp(v.format, "d") == 0 && v.itemsize == sizeof(double) && v.ndim == 1;
        if (ok) {
            f->n = v.len / (Py_ssize_t)sizeof(double);
            f->own = PyMem_Malloc((f->n ? f->n : 1) * sizeof(double));
            if (f->own != NULL)
                memcpy(f->own, v.buf, f->n * sizeof(double));
            f->d = f->own;
            ok = f->own != NULL;
        }
        PyBuffer_Release(&v);
        return ok ? 0 : -1;
    }
    return -1;
}

/* 0, or -1 (no exception): not such a sequence.  objects: an ndarray or array.array too
   (stroke_block; emit_body takes emit._doubles' lists and bytes only) */
static int fseq_get(PyObject *o, FSeq *f, int objects)
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
    return objects ? fseq_object(o, f) : -1;
}

typedef struct { int64_t x_a, x_b, y_a, y_b, e_move, e_before; } MoveUnits;

/* emit._move_units */
static int move_units(const Txt *xt, const Txt *yt, const Txt *et, Py_ssize_t move, const int64_t *start_u,
                      int dxy, int de, int e_rel, int64_t e_start_u, MoveUnits *mu)
{
    int64_t e_u, e_b;
    if (move == 0) {
        mu->x_a = start_u[0];
        mu->y_a = start_u[1];
    } else if (units_txt(xt[move - 1].p, xt[move - 1].n, dxy, &mu->x_a) < 0
               || units_txt(yt[move - 1].p, yt[move - 1].n, dxy, &mu->y_a) < 0)
        return -1;
    if (units_txt(xt[move].p, xt[move].n, dxy, &mu->x_b) < 0 || units_txt(yt[move].p, yt[move].n, dxy, &mu->y_b) < 0
        || units_txt(et[move].p, et[move].n, de, &e_u) < 0)
        return -1;
    if (e_rel) {
        mu->e_move = e_u;
        mu->e_before = 0;
        return 0;
    }
    if (move == 0)
        e_b = e_start_u;
    else if (units_txt(et[move - 1].p, et[move - 1].n, de, &e_b) < 0)
        return -1;
    mu->e_move = e_u - e_b;
    mu->e_before = e_b;
    return 0;
}

/* the pieces emit_cols puts around the segment lines (ASCII) */
typedef struct {
    const char *hp, *wp, *nlp, *clp, *bp, *ap;
    Py_ssize_t hn, wn, nln, cln, bn, an;
} Pieces;

/* emit.emit_stroke's loop: head + segment lines (before/after around the first move when
   bp is not NULL) + closing appended to b.  The moves' texts are the columns xt, yt, et, cm
   (n_cols of them).  0: written; 1: decline (the Python loop would take another path or
   raise); -1: no memory. */
static int emit_cols(Buf *b, const Pieces *pc, const Txt *xt, const Txt *yt, const Txt *et, const Txt *cm,
                     Py_ssize_t n_cols, const FSeq *s, const FSeq *acc, const FSeq *fd, const FSeq *ends, int dxy,
                     int de, int e_rel, int extruding, int64_t e_start_u, const Txt *x0t, const Txt *y0t)
{
    Py_ssize_t n_moves = ends->n, k_total = s->n - 1;
    const char *hp = pc->hp, *wp = pc->wp, *nlp = pc->nlp, *clp = pc->clp, *bp = pc->bp, *ap = pc->ap;
    Py_ssize_t hn = pc->hn, wn = pc->wn, nln = pc->nln, cln = pc->cln, bn = pc->bn, an = pc->an;
    if (!hp || !wp || !nlp || !clp || n_moves == 0 || k_total < 0 || dxy < 0 || dxy > 15 || de < 0 || de > 15)
        return 1;
    if (n_cols < n_moves || acc->n < k_total || fd->n < k_total || fabs((double)e_start_u) > EXACT_MAX)
        return 1;
    int64_t start_u[2];
    if (units_txt(x0t->p, x0t->n, dxy, &start_u[0]) < 0 || units_txt(y0t->p, y0t->n, dxy, &start_u[1]) < 0)
        return 1;
    double end_last = ends->d[n_moves - 1];
    double tol_d = 1e-9 * (end_last > 1.0 ? end_last : 1.0);
    double end_d = ends->d[0], start_d = 0.0;
    Py_ssize_t move = 0;
    int have_mu = 0;
    MoveUnits mu;
    int64_t e_done_u = 0, e_again_u = 0;
    int have_a = 0, have_cmd = 0;
    double last_a = 0.0;
    int64_t last_ka = 0;
    if (put(b, hp, hn) < 0)
        return -1;
    for (Py_ssize_t k = 1; k <= k_total; k++) {
        double sk = s->d[k], a = acc->d[k - 1], f = fd->d[k - 1];
        if (!(sk <= end_d + tol_d))
            return 1;                            /* "a knot skipped an original vertex" */
        int at_vertex = fabs(sk - end_d) <= tol_d;
        const Txt *xo = NULL, *yo = NULL, *co = NULL;
        int64_t xu = 0, yu = 0, eu = 0;
        int e_kind;                                  /* 0: e text as is, 1: canon, 2: units */
        if (at_vertex) {
            xo = &xt[move];
            yo = &yt[move];
            co = &cm[move];
            if (!e_rel)
                e_kind = 0;
            else if (e_done_u == 0)
                e_kind = 1;
            else {
                if (units_txt(et[move].p, et[move].n, de, &eu) < 0)
                    return 1;
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
                    return 1;
                have_mu = 1;
            }
            int64_t e_target_u;
            if (py_round((double)mu.x_a + (double)(mu.x_b - mu.x_a) * frac, &xu) < 0
                || py_round((double)mu.y_a + (double)(mu.y_b - mu.y_a) * frac, &yu) < 0
                || py_round((double)mu.e_move * frac, &e_target_u) < 0)
                return 1;
            if (fabs((double)e_target_u) > EXACT_MAX || fabs((double)e_again_u) > EXACT_MAX)
                return 1;
            eu = e_rel ? e_target_u - e_done_u : mu.e_before + e_again_u + e_target_u;
            e_done_u = e_target_u;
            e_kind = 2;
        }
        if (!have_a || a != last_a) {
            if (!(isfinite(a) && a > 0.0))
                return 1;                        /* accel_command raises */
            double c = ceil(a * 10.0 - 1e-9);
            if (!(c < (double)TENTHS_MAX))
                return 1;                        /* the float formatting (or ceil's OverflowError) */
            int64_t ka = (int64_t)c;
            if (ka <= 1) ka = 1;                     /* _tenths_up: every k <= 1 is "0.1" */
            have_a = 1;
            last_a = a;
            if (!have_cmd || ka != last_ka) {
                if (put(b, wp, wp ? wn : 0) < 0 || put_tenths_up(b, ka) < 0 || put(b, nlp, nln) < 0)
                    return -1;
                last_ka = ka;
                if (!have_cmd && bp != NULL && put(b, bp, bn) < 0)   /* first_cmds[0], after the first M204 */
                    return -1;
                have_cmd = 1;
            }
        }
        if (!(isfinite(f) && f > 0.0))
            return 1;
        double cf = ceil(f * 600.0 - 1e-6);
        if (!(cf < (double)TENTHS_MAX))
            return 1;
        /* the line */
        if (put(b, "G1 X", 4) < 0) return -1;
        if (at_vertex) {
            if (put(b, xo->p, xo->n) < 0) return -1;
        } else if (put_units(b, xu, dxy) < 0) return -1;
        if (put(b, " Y", 2) < 0) return -1;
        if (at_vertex) {
            if (put(b, yo->p, yo->n) < 0) return -1;
        } else if (put_units(b, yu, dxy) < 0) return -1;
        if (extruding) {
            if (put(b, " E", 2) < 0) return -1;
            if (e_kind == 2) {
                if (put_units(b, eu, de) < 0) return -1;
            } else {
                if ((e_kind == 0 ? put(b, et[move].p, et[move].n) : put_canon(b, et[move].p, et[move].n)) < 0)
                    return -1;
            }
        }
        if (put(b, " F", 2) < 0 || put_tenths_up(b, (int64_t)cf) < 0) return -1;
        if (co != NULL && co->n && (put(b, " ", 1) < 0 || put(b, co->p, co->n) < 0)) return -1;
        if (put(b, nlp, nln) < 0) return -1;
        if (k == 1 && ap != NULL && put(b, ap, an) < 0)   /* first_cmds[1], after the first move */
            return -1;
        if (at_vertex) {
            e_done_u = 0;
            if (move < n_moves - 1) {
                move += 1;
                start_d = end_d;
                end_d = ends->d[move];
            } else if (!e_rel) {                     /* knots past the end: the last move again */
                if (!have_mu && move_units(xt, yt, et, move, start_u, dxy, de, e_rel, e_start_u, &mu) < 0)
                    return 1;
                e_again_u += mu.e_move;
            }
            have_mu = 0;
        }
    }
    if (put(b, clp, cln) < 0)
        return -1;
    return 0;
}

/* emit_body(head, x_texts, y_texts, e_texts, comments, s, accels, feeds, ends_d, dxy, de,
             e_rel, extruding, e_start_units, x0_text, y0_text, accel_word, nl, before,
             after, closing)
   emit.emit_stroke's text: head + segment lines (before/after around the first move when
   not None) + closing; None where the Python loop would take another path or raise. */
static PyObject *emit_body(PyObject *self, PyObject *args)
{
    PyObject *head, *xt, *yt, *et, *cm, *s_o, *acc_o, *fd_o, *ends_o, *e_start_o, *x0t, *y0t, *word, *nlo, *before,
             *after, *closing;
    int dxy, de, e_rel, extruding;
    if (!PyArg_ParseTuple(args, "UO!O!O!O!OOOOiippOUUUUOOU", &head, &PyList_Type, &xt, &PyList_Type, &yt,
                          &PyList_Type, &et, &PyList_Type, &cm, &s_o, &acc_o, &fd_o, &ends_o, &dxy, &de, &e_rel, &extruding, &e_start_o,
                          &x0t, &y0t, &word, &nlo, &before, &after, &closing))
        return NULL;
    Pieces pc;
    memset(&pc, 0, sizeof pc);
    pc.hp = ascii(head, &pc.hn);
    pc.wp = ascii(word, &pc.wn);
    pc.nlp = ascii(nlo, &pc.nln);
    pc.clp = ascii(closing, &pc.cln);
    if (before != Py_None && ((pc.bp = ascii(before, &pc.bn)) == NULL || (pc.ap = ascii(after, &pc.an)) == NULL))
        Py_RETURN_NONE;
    Txt x0 = {NULL, 0}, y0 = {NULL, 0};
    x0.p = ascii(x0t, &x0.n);
    y0.p = ascii(y0t, &y0.n);
    if (x0.p == NULL || y0.p == NULL)
        Py_RETURN_NONE;
    int overflow = 0;
    long long e_start_u = PyLong_Check(e_start_o) ? PyLong_AsLongLongAndOverflow(e_start_o, &overflow) : 0;
    if (!PyLong_Check(e_start_o) || overflow || (e_start_u == -1 && PyErr_Occurred())) {
        PyErr_Clear();
        Py_RETURN_NONE;
    }
    /* the columns: the moves' texts (an item not an ASCII str: the Python loop) */
    Py_ssize_t n_cols = PyList_GET_SIZE(xt);
    if (PyList_GET_SIZE(yt) < n_cols) n_cols = PyList_GET_SIZE(yt);
    if (PyList_GET_SIZE(et) < n_cols) n_cols = PyList_GET_SIZE(et);
    if (PyList_GET_SIZE(cm) < n_cols) n_cols = PyList_GET_SIZE(cm);
    Txt *cols = PyMem_Malloc((4 * n_cols + 1) * sizeof(Txt));
    if (cols == NULL)
        return PyErr_NoMemory();
    Txt *cx = cols, *cy = cols + n_cols, *ce = cols + 2 * n_cols, *cc = cols + 3 * n_cols;
    for (Py_ssize_t k = 0; k < n_cols; k++) {
        if ((cx[k].p = ascii(PyList_GET_ITEM(xt, k), &cx[k].n)) == NULL
            || (cy[k].p = ascii(PyList_GET_ITEM(yt, k), &cy[k].n)) == NULL
            || (ce[k].p = ascii(PyList_GET_ITEM(et, k), &ce[k].n)) == NULL
            || (cc[k].p = ascii(PyList_GET_ITEM(cm, k), &cc[k].n)) == NULL) {
            PyMem_Free(cols);
            Py_RETURN_NONE;
        }
    }
    FSeq fs[4];
    for (int i = 0; i < 4; i++)
        memset(&fs[i], 0, sizeof fs[i]);
    PyObject *res = NULL;
    if (fseq_get(s_o, &fs[0], 0) == 0 && fseq_get(acc_o, &fs[1], 0) == 0 && fseq_get(fd_o, &fs[2], 0) == 0
        && fseq_get(ends_o, &fs[3], 0) == 0) {
        /* one buffer for every block, kept between calls (a block's text is built there and
           copied once into its str): no growing allocations per block to fragment the heap */
        Buf b = EMIT_BUF;
        b.n = 0;
        int r = emit_cols(&b, &pc, cx, cy, ce, cc, n_cols, &fs[0], &fs[1], &fs[2], &fs[3], dxy, de, e_rel, extruding,
                          (int64_t)e_start_u, &x0, &y0);
        if (r == 0)
            res = ascii_str(b.p, b.n);
        else if (r > 0)
            res = Py_NewRef(Py_None);
        else
            res = PyErr_NoMemory();
        keep_buf(&b);
    } else
        res = Py_NewRef(Py_None);
    for (int i = 0; i < 4; i++)
        fseq_release(&fs[i]);
    PyMem_Free(cols);
    return res;
}

/* ---------------------------------------------------------------- fast_body */

/* fast_body(text, start, stop, want, klipper, limit, accel_max_a, px, py, tol_d, e_mode,
             e_value, min_move_d)
   validate._fast_ok's reading of text[start:stop] (the body: "\n" line "\n" ... line "\n")
   and its checks; True when they certainly pass, None otherwise (the Python reading then
   decides).  want: the M204 letter; limit: the command buffer (0: none); px, py: the
   polyline's vertices (None: no path check); e_mode: 0 none, 1 relative (the E words'
   sum), 2 absolute (the last E word). */
/* fast_body's checks of the body t[start:stop] ("\n" line "\n" ... line "\n"): 1 when they
   certainly pass, 0 otherwise.  px, py: the polyline's nv vertices (path 0: no path check),
   each below validate._polyline_walk's bound. */
static int fast_check(const char *t, Py_ssize_t start, Py_ssize_t stop, int want, int klipper, Py_ssize_t limit,
                      double accel_max_a, int path, const double *px, const double *py, Py_ssize_t nv,
                      double tol_d, int e_mode, double e_value, double e_err, double min_move_d)
{
    const double accel_hi = accel_max_a + 0.1 + 1e-9;
    Py_ssize_t j = 1;                               /* the next original vertex */
    double x_prev = 0.0, y_prev = 0.0, gap_least = INFINITY;
    int n_points = 0;
    double e_sum = 0.0, e_abs = 0.0, e_last = 0.0;
    Py_ssize_t n_e = 0;
    if (path) {
        x_prev = px[0];
        y_prev = py[0];
    }
    const char *p = t + start + 1, *end = t + stop;
    while (p < end) {
        const char *q = memchr(p, '\n', end - p);   /* the line is p[0..m) */
        Py_ssize_t m = q - p, i, r;
        int dec;
        if (limit > 0 && m > limit)
            return 0;
        if (m > 4 && memcmp(p, "G1 X", 4) == 0) {
            /* "G1 X<n> Y<n>[ E<n>] F<n>" */
            Py_ssize_t xa = 4, xn, ya, yn, ea = 0, en = 0, fa, fn;
            int dx_, dy_;
            i = 4;
            xn = plain_decimal(p + i, m - i, &dx_);
            if (xn < 0 || dx_ > MAX_DECIMALS) return 0;
            i += xn;
            if (i + 2 > m || p[i] != ' ' || p[i + 1] != 'Y') return 0;
            i += 2;
            ya = i;
            yn = plain_decimal(p + i, m - i, &dy_);
            if (yn < 0 || dy_ > MAX_DECIMALS) return 0;
            i += yn;
            if (i + 2 <= m && p[i] == ' ' && p[i + 1] == 'E') {
                i += 2;
                ea = i;
                en = plain_decimal(p + i, m - i, &dec);
                if (en < 0 || dec > MAX_DECIMALS) return 0;
                i += en;
            }
            if (i + 2 > m || p[i] != ' ' || p[i + 1] != 'F') return 0;
            i += 2;
            fa = i;
            fn = plain_decimal(p + i, m - i, &dec);
            if (fn < 0 || dec > MAX_DECIMALS || i + fn != m) return 0;
            double x = to_double(p + xa, xn), y = to_double(p + ya, yn), f = to_double(p + fa, fn);
            if (!(isfinite(x) && isfinite(y) && f > 0.0 && f < INFINITY)) return 0;
            if (en) {
                double e = to_double(p + ea, en);
                if (!isfinite(e)) return 0;
                e_sum += e;
                e_abs += fabs(e);
                e_last = e;
                n_e++;
            }
            if (path) {
                if (j < nv && x == px[j] && y == py[j])
                    j++;
                else {
                    Py_ssize_t k = j < nv ? j - 1 : nv - 2;
                    double ax = px[k], ay = py[k];
                    double ddx = px[k + 1] - ax, ddy = py[k + 1] - ay;
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
                        return 0;              /* off this segment, or near: Python's search */
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
            if (r < 0 || dec > MAX_DECIMALS || i + r != m) return 0;
            double f = to_double(p + i, r);
            if (!(f > 0.0 && f < INFINITY)) return 0;
        } else if (m > 6 && memcmp(p, "M204 ", 5) == 0 && p[5] == want) {
            i = 6;
            r = plain_decimal(p + i, m - i, &dec);
            if (r < 0 || dec > MAX_DECIMALS || i + r != m) return 0;
            double a = to_double(p + i, r);
            if (!(a > 0.0 && a <= accel_hi && a < INFINITY)) return 0;
        } else if (klipper && m > MCR_N && memcmp(p, MCR, MCR_N) == 0) {
            i = MCR_N;
            r = plain_decimal(p + i, m - i, &dec);
            if (r < 0 || dec > MAX_DECIMALS || i + r != m) return 0;
            double v = to_double(p + i, r);
            if (!(v >= 0.0 && v < 1.0)) return 0;
        } else
            return 0;
        p = q + 1;
    }
    if (path && min_move_d > 0.0 && n_points && gap_least < min_move_d) {
        /* _ShortMoves' floor: the original's own shortest move passes too */
        double floor_d = min_move_d;
        if (nv > 2) {
            double own = INFINITY;
            for (Py_ssize_t k = 0; k + 1 < nv; k++) {
                double gx = fabs(px[k + 1] - px[k]), gy = fabs(py[k + 1] - py[k]);
                double g = gy > gx ? gy : gx;
                if (g < own) own = g;
            }
            double o = own * (1.0 - 1e-9);
            if (o < floor_d) floor_d = o;
        }
        if (gap_least < floor_d)
            return 0;
    }
    if (e_mode) {
        if (n_e == 0)
            return 0;
        double lim = E_TOL * (1.0 + fabs(e_value));
        if (e_mode == 2) {
            if (fabs(e_last - e_value) > lim) return 0;
        } else {
            /* fsum is within half an ulp of the exact sum, the running sum within
               (n - 1) u sum|e| of it: a pass this far inside the limit is fsum's too */
            double err = 2.0 * (double)n_e * 1.1102230246251565e-16 * e_abs + 1e-300;
            /* e_err: how far e_value may be from the value the Python check compares with
               (stroke_block's running sum of the original's E words; 0 for fast_body's fsum) */
            if (e_err > 0.0)
                lim = E_TOL * (1.0 + fabs(e_value) - e_err);
            if (!(fabs(e_sum - e_value) + 2.0 * err + 2.0 * e_err <= lim * (1.0 - MARGIN_R))) return 0;
        }
    }
    return 1;
}

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
    double *pv = NULL;
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
        pv = PyMem_Malloc(2 * nv * sizeof(double));
        if (pv == NULL)
            return PyErr_NoMemory();
        for (Py_ssize_t j = 0; j < nv; j++) {
            pv[j] = PyFloat_AS_DOUBLE(PyList_GET_ITEM(pxo, j));
            pv[nv + j] = PyFloat_AS_DOUBLE(PyList_GET_ITEM(pyo, j));
        }
    }
    int ok = fast_check(t, start, stop, want, klipper, limit, accel_max_a, path, pv, pv ? pv + nv : NULL, nv, tol_d,
                        e_mode, e_value, 0.0, min_move_d);
    PyMem_Free(pv);
    if (ok)
        Py_RETURN_TRUE;
    Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- skip_lines, stroke_block */

/* skip_lines(data, pos, n, final): (end, got) -- the offset in the bytes data after the
   next n lines from pos, as a file opened with newline="" reads lines ("\n", "\r\n" or a
   lone "\r" ends one; a "\r" as data's last byte ends one: the caller's data never splits
   a "\r\n"), and how many lines that is (fewer than n at the end of data).  Bytes after
   the last line end: taken (end is len(data)) and counted as a line only when final (the
   end of the file: the text reading's last line without a line end). */
static PyObject *skip_lines(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 4 || !PyBytes_CheckExact(args[0])) {
        PyErr_SetString(PyExc_TypeError, "skip_lines(bytes, pos, n, final)");
        return NULL;
    }
    Py_ssize_t pos = PyLong_AsSsize_t(args[1]), n = PyLong_AsSsize_t(args[2]);
    if ((pos == -1 || n == -1) && PyErr_Occurred())
        return NULL;
    int final = PyObject_IsTrue(args[3]);
    if (final < 0)
        return NULL;
    const char *d = PyBytes_AS_STRING(args[0]);
    Py_ssize_t len = PyBytes_GET_SIZE(args[0]), got = 0;
    if (pos < 0 || pos > len) {
        PyErr_SetString(PyExc_ValueError, "skip_lines: pos out of range");
        return NULL;
    }
    while (got < n && pos < len) {
        /* the next "\n" or "\r" */
        const char *p = d + pos, *e = d + len, *q = p;
        while (q < e && *q != '\n' && *q != '\r') q++;
        if (q == e) {
            pos = len;
            got += final;                         /* the file's last line, without a line end */
            break;
        }
        pos = q - d + 1;
        if (*q == '\r' && pos < len && d[pos] == '\n')
            pos++;
        got++;
    }
    return Py_BuildValue("(nn)", pos, got);
}

/* one plain line of a stroke, as plain_moves reads it ("G1 X<n> Y<n>[ E<n>][ \t]*[;c][\r]"):
   1 and its pieces, or 0 (not that shape, or a number not a plain decimal: the Python
   reading) */
static int plain_line(const char *p, Py_ssize_t m, Txt *x, Txt *y, Txt *e, Txt *c, int *dx, int *dy, int *de)
{
    Py_ssize_t i, xn, yn, en = 0;
    if (m < 4 || memcmp(p, "G1 X", 4) != 0)
        return 0;
    i = 4;
    x->p = p + i; xn = num_run(p + i, m - i); i += xn;
    if (xn == 0 || i + 2 > m || p[i] != ' ' || p[i + 1] != 'Y')
        return 0;
    i += 2;
    y->p = p + i; yn = num_run(p + i, m - i); i += yn;
    if (yn == 0)
        return 0;
    e->p = NULL;
    if (i + 1 < m && p[i] == ' ' && p[i + 1] == 'E') {
        i += 2;
        e->p = p + i; en = num_run(p + i, m - i); i += en;
        if (en == 0)
            return 0;
    }
    while (i < m && (p[i] == ' ' || p[i] == '\t')) i++;
    c->p = p + i;
    c->n = 0;
    if (i < m && p[i] == ';') {
        Py_ssize_t ca = i;
        while (i < m && p[i] != '\r') i++;
        c->n = i - ca;
    }
    if (i < m && p[i] == '\r') i++;
    if (i != m)
        return 0;
    *de = 0;
    if (plain_decimal(x->p, xn, dx) != xn || plain_decimal(y->p, yn, dy) != yn
        || (en && plain_decimal(e->p, en, de) != en))
        return 0;
    x->n = xn;
    y->n = yn;
    e->n = en;
    return 1;
}

static double arg_double(PyObject *o, int *bad)
{
    double v = PyFloat_AsDouble(o);
    if (v == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        *bad = 1;
    }
    return v;
}

/* The head of a line stroke's block as pipeline._rewrite_bytes' f-string writes it,
     f"{BEGIN}: replaces {n_lines} lines, kind={kind}, {n_segments} segments, "
     f"T={t:.4f}s (was {t_was:.4f}s), beta={f'{beta:.4g}' if isfinite(beta) else 'inf'}s^2\n{svl}"
   from spec = (kind, n_segments, t, t_was, beta, svl): the floats through
   PyOS_double_to_string, which float.__format__ calls for 'f' and 'g' with a precision.
   A PyMem buffer (the caller frees it) and its length; NULL (no exception) for a spec of
   other types. */
static char *head_text(PyObject *spec, Py_ssize_t n_lines, Py_ssize_t *len)
{
    if (!PyTuple_CheckExact(spec) || PyTuple_GET_SIZE(spec) != 6)
        return NULL;
    PyObject *o_seg = PyTuple_GET_ITEM(spec, 1), *o_t = PyTuple_GET_ITEM(spec, 2),
             *o_tw = PyTuple_GET_ITEM(spec, 3), *o_b = PyTuple_GET_ITEM(spec, 4);
    Py_ssize_t kn, sn;
    const char *kp = ascii(PyTuple_GET_ITEM(spec, 0), &kn), *sp = ascii(PyTuple_GET_ITEM(spec, 5), &sn);
    if (!kp || !sp || !PyLong_CheckExact(o_seg) || !PyFloat_Check(o_t) || !PyFloat_Check(o_tw) || !PyFloat_Check(o_b))
        return NULL;
    long long n_seg = PyLong_AsLongLong(o_seg);
    if (n_seg == -1 && PyErr_Occurred()) {
        PyErr_Clear();
        return NULL;
    }
    double beta = PyFloat_AS_DOUBLE(o_b);
    char *ft = PyOS_double_to_string(PyFloat_AS_DOUBLE(o_t), 'f', 4, 0, NULL),
         *fw = PyOS_double_to_string(PyFloat_AS_DOUBLE(o_tw), 'f', 4, 0, NULL),
         *fb = isfinite(beta) ? PyOS_double_to_string(beta, 'g', 4, 0, NULL) : NULL;
    char *out = NULL;
    if (ft && fw && (fb || !isfinite(beta))) {
        size_t cap = strlen(ft) + strlen(fw) + (fb ? strlen(fb) : 3) + (size_t)kn + (size_t)sn + 160;
        out = PyMem_Malloc(cap);
        if (out != NULL) {
            int m = snprintf(out, cap, "; gcode-opt begin: replaces %zd lines, kind=%.*s, %lld segments, "
                             "T=%ss (was %ss), beta=%ss^2\n", n_lines, (int)kn, kp, n_seg, ft, fw, fb ? fb : "inf");
            if (m < 0 || (size_t)m + (size_t)sn >= cap) {
                PyMem_Free(out);
                out = NULL;
            } else {
                memcpy(out + m, sp, (size_t)sn);
                *len = m + sn;
            }
        }
    }
    PyMem_Free(ft);
    PyMem_Free(fw);
    PyMem_Free(fb);
    PyErr_Clear();             /* (a failed PyOS_double_to_string: declined, no exception) */
    return out;
}

/* stroke_block(data, start, stop, n_lines, head, closing, before, after, x0_text, y0_text, x0, y0, e0,
                s, accels, feeds, ends_d, e_rel, extruding, ctx, accel_max_a)
   ctx = (accel_word, want, klipper, limit, min_move_d)
   A line stroke's block in one call: data[start:stop] is the stroke's n_lines original lines
   (bytes); the lines read as emit.StrokeText reads plain lines, the block written as
   emit_stroke writes it (head: "; gcode-opt begin: ..." and its line end, plus Klipper's
   cruise-ratio line; closing: emit._closing_text; before/after: the first_cmds lines with
   their line end, or None) and checked as pipeline._validate's validate_block checks it
   (validate._fast_ok's passes).  The block's bytes, or None: anything else (a line not
   plain, not ASCII, a "\r", a block the column pass does not certainly pass, ...) is
   pipeline's Python path's to decide.
   head may be head_text's spec tuple instead of the text; x0_text and y0_text None for
   f"{x0:.8f}" and f"{y0:.8f}" made here (PyOS_double_to_string, as format() makes them). */
static PyObject *stroke_block(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 21) {
        PyErr_SetString(PyExc_TypeError, "stroke_block takes 21 arguments");
        return NULL;
    }
    PyObject *data = args[0], *ctx = args[19];
    if (!PyBytes_CheckExact(data) || !PyTuple_CheckExact(ctx) || PyTuple_GET_SIZE(ctx) != 5)
        Py_RETURN_NONE;
    Py_ssize_t start = PyLong_AsSsize_t(args[1]), stop = PyLong_AsSsize_t(args[2]),
               n = PyLong_AsSsize_t(args[3]);
    if (PyErr_Occurred()) {
        PyErr_Clear();
        Py_RETURN_NONE;
    }
    const char *d = PyBytes_AS_STRING(data);
    if (start < 0 || stop > PyBytes_GET_SIZE(data) || n < 1 || stop - start < 2 || d[stop - 1] != '\n')
        Py_RETURN_NONE;
    Pieces pc;
    memset(&pc, 0, sizeof pc);
    Txt x0 = {NULL, 0}, y0 = {NULL, 0};
    char *own_head = NULL, *own_x0 = NULL, *own_y0 = NULL;     /* texts made here (freed at the end) */
    if (PyTuple_CheckExact(args[4])) {
        if ((own_head = head_text(args[4], n, &pc.hn)) == NULL)
            Py_RETURN_NONE;
        pc.hp = own_head;
    } else
        pc.hp = ascii(args[4], &pc.hn);
    if (args[8] == Py_None && args[9] == Py_None) {
        double xv = PyFloat_AsDouble(args[10]), yv = PyFloat_AsDouble(args[11]);
        if (!PyErr_Occurred()) {
            own_x0 = PyOS_double_to_string(xv, 'f', 8, 0, NULL);
            own_y0 = PyOS_double_to_string(yv, 'f', 8, 0, NULL);
        }
        PyErr_Clear();
    }
    PyObject *res = NULL;
    char *mem = NULL;
    FSeq fs[4];
    for (int i = 0; i < 4; i++)
        memset(&fs[i], 0, sizeof fs[i]);
    pc.clp = ascii(args[5], &pc.cln);
    pc.wp = ascii(PyTuple_GET_ITEM(ctx, 0), &pc.wn);
    pc.nlp = "\n";
    pc.nln = 1;
    if (args[6] != Py_None && ((pc.bp = ascii(args[6], &pc.bn)) == NULL || (pc.ap = ascii(args[7], &pc.an)) == NULL))
        goto decline;
    if (own_x0 != NULL && own_y0 != NULL) {
        x0.p = own_x0;
        x0.n = (Py_ssize_t)strlen(own_x0);
        y0.p = own_y0;
        y0.n = (Py_ssize_t)strlen(own_y0);
    } else {
        x0.p = ascii(args[8], &x0.n);
        y0.p = ascii(args[9], &y0.n);
    }
    PyObject *want_o = PyTuple_GET_ITEM(ctx, 1);
    Py_ssize_t wl;
    const char *wantp = ascii(want_o, &wl);
    if (!pc.hp || !pc.clp || !pc.wp || !x0.p || !y0.p || !wantp || wl != 1 || !PyFloat_CheckExact(args[12]))
        goto decline;
    /* the head line as validate._fast_ok wants it (the caller writes it: its kind is there) */
    static const char BEGIN_R[] = "; gcode-opt begin: replaces ";
    Py_ssize_t hl = 0;
    while (hl < pc.hn && pc.hp[hl] != '\n') hl++;
    if (hl == pc.hn || hl < (Py_ssize_t)sizeof(BEGIN_R) - 1 || memcmp(pc.hp, BEGIN_R, sizeof(BEGIN_R) - 1) != 0)
        goto decline;
    for (Py_ssize_t k = 0; k < hl; k++) {
        char c = pc.hp[k];
        if (c == '\r' || c == '\x0b' || c == '\x0c' || c == '\x1c' || c == '\x1d' || c == '\x1e')
            goto decline;
    }
    int bad = 0;
    double x0v = arg_double(args[10], &bad), y0v = arg_double(args[11], &bad), e0 = PyFloat_AS_DOUBLE(args[12]);
    double accel_max_a = arg_double(args[20], &bad), min_move_d = arg_double(PyTuple_GET_ITEM(ctx, 4), &bad);
    int e_rel = PyObject_IsTrue(args[17]), extruding = PyObject_IsTrue(args[18]),
        klipper = PyObject_IsTrue(PyTuple_GET_ITEM(ctx, 2));
    Py_ssize_t limit = PyLong_AsSsize_t(PyTuple_GET_ITEM(ctx, 3));
    if (bad || e_rel < 0 || extruding < 0 || klipper < 0 || (limit == -1 && PyErr_Occurred())) {
        PyErr_Clear();
        goto decline;
    }

    /* the lines: one allocation for their texts and the path's vertices */
    mem = PyMem_Malloc(n * 4 * sizeof(Txt) + (n + 1) * 2 * sizeof(double) + 16);
    if (mem == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Txt *cx = (Txt *)mem, *cy = cx + n, *ce = cx + 2 * n, *cc = cx + 3 * n;
    double *px = (double *)(cx + 4 * n), *py = px + n + 1;
    int dec_xy = 3, dec_e = 5, d0;
    if ((d0 = start_decimals(x0.p, x0.n)) > dec_xy) dec_xy = d0;
    if ((d0 = start_decimals(y0.p, y0.n)) > dec_xy) dec_xy = d0;
    px[0] = x0v;
    py[0] = y0v;
    int path_ok = fabs(x0v) < 1e150 && fabs(y0v) < 1e150;
    double e_sum = 0.0, e_abs = 0.0, e_last = 0.0;
    Py_ssize_t n_e = 0;
    const char *p = d + start, *end = d + stop;
    for (Py_ssize_t k = 0; k < n; k++) {
        if (p >= end)
            goto decline;
        const char *q = memchr(p, '\n', end - p);
        if (q == NULL)
            goto decline;
        Py_ssize_t m = q - p;
        for (Py_ssize_t j = 0; j < m; j++)        /* ASCII, no line break but the "\r" of "\r\n" */
            if ((unsigned char)p[j] >= 0x80 || (p[j] == '\r' && j != m - 1))
                goto decline;
        if (k == 0 && m > 0 && p[m - 1] == '\r')  /* the block's line end is the first line's */
            goto decline;
        int dx, dy, de;
        if (!plain_line(p, m, &cx[k], &cy[k], &ce[k], &cc[k], &dx, &dy, &de))
            goto decline;
        if (dx > dec_xy) dec_xy = dx;
        if (dy > dec_xy) dec_xy = dy;
        if (de > dec_e) dec_e = de;
        double xv = to_double(cx[k].p, cx[k].n), yv = to_double(cy[k].p, cy[k].n);
        px[k + 1] = xv;
        py[k + 1] = yv;
        if (!(fabs(xv) < 1e150 && fabs(yv) < 1e150))
            path_ok = 0;
        if (ce[k].p != NULL) {
            double ev = to_double(ce[k].p, ce[k].n);
            if (!isfinite(ev))
                goto decline;
            e_sum += ev;
            e_abs += fabs(ev);
            e_last = ev;
            n_e++;
        } else {
            ce[k].p = "0";                        /* StrokeText's e text of a line without E */
            ce[k].n = 1;
        }
        p = q + 1;
    }
    if (p != end || !path_ok || dec_e > 15)
        goto decline;
    /* st_text.e_start_units = int(round(e0 * 10 ** dec_e)) */
    int64_t e_start_u;
    if (py_round(e0 * POW10[dec_e], &e_start_u) < 0)
        goto decline;
    if (fseq_get(args[13], &fs[0], 1) < 0 || fseq_get(args[14], &fs[1], 1) < 0 || fseq_get(args[15], &fs[2], 1) < 0
        || fseq_get(args[16], &fs[3], 1) < 0)
        goto decline;
    Buf b = EMIT_BUF;
    b.n = 0;
    int r = emit_cols(&b, &pc, cx, cy, ce, cc, n, &fs[0], &fs[1], &fs[2], &fs[3], dec_xy, dec_e, e_rel, extruding,
                      e_start_u, &x0, &y0);
    if (r < 0) {
        keep_buf(&b);
        res = PyErr_NoMemory();
        goto done;
    }
    if (r == 0) {
        /* validate._fast_ok: the end line, then the column pass over the body */
        static const char END_L[] = "\n; gcode-opt end\n";
        Py_ssize_t el = (Py_ssize_t)sizeof(END_L) - 1;
        int e_mode = 0;
        double e_value = 0.0, e_err = 0.0;
        if (extruding && n_e > 0) {
            e_mode = e_rel ? 1 : 2;
            if (e_rel) {              /* fsum's value within e_err of the running sum */
                e_value = e_sum;
                e_err = 2.0 * (double)n_e * 1.1102230246251565e-16 * e_abs + 1e-300;
            } else
                e_value = e_last;
        }
        if (b.n > hl + el && memcmp(b.p + b.n - el, END_L, el) == 0
            && fast_check(b.p, hl, b.n - el + 1, wantp[0], klipper, limit, accel_max_a, 1, px, py, n + 1, 2e-3,
                          e_mode, e_value, e_err, min_move_d))
            res = PyBytes_FromStringAndSize(b.p, b.n);
    }
    keep_buf(&b);
    if (res != NULL || PyErr_Occurred())
        goto done;
decline:
    res = Py_NewRef(Py_None);
done:
    for (int i = 0; i < 4; i++)
        fseq_release(&fs[i]);
    PyMem_Free(mem);
    PyMem_Free(own_head);
    PyMem_Free(own_x0);
    PyMem_Free(own_y0);
    return res;
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
    {"set_types", set_types, METH_VARARGS, "set_types(ndarray, float64 dtype, array.array): fseq_get's types"},
    {"skip_lines", (PyCFunction)(void (*)(void))skip_lines, METH_FASTCALL,
     "(end, got): the offset after the next n lines of bytes data from pos, and how many"},
    {"stroke_block", (PyCFunction)(void (*)(void))stroke_block, METH_FASTCALL,
     "a line stroke's block (bytes) written and checked in one call, or None"},
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
