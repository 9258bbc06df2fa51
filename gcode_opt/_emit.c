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
The validator reads the block's own text, but for the lines emit_cols writes from numbers
(segment and accel lines): those emit_cols checks as it writes them, with the doubles and
decimals the reading would give (Known, known_units; set_text_check(True): read too). */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include "_strokefields.h"  /* StrokeFieldsAPI: the firmware core's stroke fields' layout */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>      /* line_break_at's 16-byte scan */
#endif

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

/* a == b for two ASCII str (PyObject_RichCompareBool's Py_EQ: the same object, or the same
   length and bytes): 1 or 0, without the rich comparison's calls; -1 for other objects
   (the caller compares them) */
static inline int str_eq(PyObject *a, PyObject *b)
{
    if (a == b)
        return 1;
    Py_ssize_t na, nb;
    const char *pa = ascii(a, &na), *pb = ascii(b, &nb);
    if (pa == NULL || pb == NULL)
        return -1;
    return na == nb && memcmp(pa, pb, (size_t)na) == 0;
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

/* The start of a plain line, "G1 X" or "G1 F<n> X" (Cura's first move of a run names its
   feed first): the index after its 'X', or 0 (another start, an F number not of float()'s
   grammar over [-.0-9]: the general reading, words.param_texts, would refuse it).  The F
   is read by nothing the rewrite writes (a block's feeds are its own), as the general
   reading reads it only to check it. */
static inline Py_ssize_t plain_start(const char *p, Py_ssize_t m)
{
    if (m < 4 || memcmp(p, "G1 ", 3) != 0)
        return 0;
    Py_ssize_t i = 3;
    if (p[i] == 'F') {
        int dec;
        Py_ssize_t fn = num_run(p + 4, m - 4);
        if (fn == 0 || plain_decimal(p + 4, fn, &dec) != fn)
            return 0;
        i = 4 + fn;
        if (i + 2 > m || p[i] != ' ')
            return 0;
        i++;
    }
    return p[i] == 'X' ? i + 1 : 0;
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

/* plain_decimal and to_double in one pass: the length of the plain decimal at p[0..n)
   (or -1), its decimals in *dec and, when it is one, to_double of its text in *v and
   its digits' integer in *mo (wrapped mod 2^64 past 19 digits).
   ended: a '\n' ends the text (at p[n - 1], or past it: fast_check's lines, whose "\n"
   it finds as they are read), where each scan stops: no bound to look at a digit (~1/3 of
   the instructions a digit); dec_value and dec_value_nl are its two copies. */
static inline __attribute__((always_inline)) Py_ssize_t dec_value_in(const char *p, Py_ssize_t n, int *dec,
                                                                     double *v, const int ended, uint64_t *mo)
{
#define BELOW(i) (ended || (i) < n)               /* p[i] is in the text (always, when ended) */
    Py_ssize_t i = 0, nd = 0, nf = 0;
    int neg = 0;
    uint64_t m = 0;                               /* (wraps past 19 digits: then unused) */
    if (BELOW(i) && p[i] == '-') {
        neg = 1;
        i++;
    }
    /* the digits' loops count no digits (their ends do: two instructions a digit less) */
    unsigned d = 0;                               /* (the point's is '.' - '0': no copy of the byte kept a digit) */
    Py_ssize_t i0 = i;
    for (; BELOW(i) && (d = (unsigned)(unsigned char)p[i] - '0') <= 9; i++)
        m = m * 10 + d;
    nd = i - i0;
    *dec = 0;
    if (BELOW(i) && d == (unsigned)('.' - '0')) {
        /* (counted from the point: indexed from p, gcc kept the index before each step in
           a register of its own, an instruction a digit) */
        const char *f = p + ++i;
        for (; BELOW(i + nf) && (d = (unsigned)(unsigned char)f[nf] - '0') <= 9; nf++)
            m = m * 10 + d;
        i += nf;
        *dec = (int)nf;
    }
    if (nd + nf == 0)
        return -1;
    *mo = m;
    if (nd + nf <= 15) {                          /* to_double's fast path: the same division */
        double x = (double)(int64_t)m;            /* (m < 10^15: the same value, one instruction) */
        if (nf) x = x / POW10[nf];
        *v = neg ? -x : x;
    } else
        *v = to_double(p, i);
    return i;
#undef BELOW
}

static inline Py_ssize_t dec_value(const char *p, Py_ssize_t n, int *dec, double *v)
{
    uint64_t m;
    return dec_value_in(p, n, dec, v, 0, &m);
}

/* dec_value of a text a '\n' ends (no bound: the scans stop at it) */
static inline Py_ssize_t dec_value_nl(const char *p, int *dec, double *v)
{
    uint64_t m;
    return dec_value_in(p, 0, dec, v, 1, &m);
}

/* PAIR[b0 | b1 << 8], the bytes p[0] p[1] as digit_pairs reads them (_reader.c's RUN, a
   copy: the two modules are separate .so files): the number two digits make (0 to 99: "07"
   is 7), PAIR_ONE + d where b0 is a digit d and b1 is not (the run ends after it), PAIR_END
   where b0 is not a digit.  One load and one test a pair of digits, the run's end read from
   the same load.  Built at the module's load (pair_table_init). */
enum { PAIR_ONE = 100, PAIR_END = 110 };
static unsigned char PAIR[1 << 16];

static void pair_table_init(void)
{
    memset(PAIR, PAIR_END, sizeof PAIR);
    for (int b1 = 0; b1 < 256; b1++)
        for (int d0 = 0; d0 < 10; d0++) {
            unsigned d1 = (unsigned)b1 - '0';
            PAIR[('0' + d0) | (b1 << 8)] = (unsigned char)(d1 <= 9 ? (unsigned)d0 * 10 + d1 : (unsigned)(PAIR_ONE + d0));
        }
}

/* p[0] | p[1] << 8: PAIR's index, one 16-bit load where the bytes are little-endian (gcc
   made two byte loads, a shift and an or of the two reads) */
static inline __attribute__((always_inline)) unsigned pair_index(const char *p)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    uint16_t w;
    memcpy(&w, p, sizeof w);
    return w;
#else
    return (unsigned char)p[0] | (unsigned)(unsigned char)p[1] << 8;
#endif
}

/* the run of digits at p[i]: the index past it, the digits appended to *m (m * 10 + d a
   digit, wrapping as that does: m * 100 + the pair's number is the same).  Reads the byte
   after the run's end: past a '\n' that ends it, the caller makes sure that is readable. */
static inline __attribute__((always_inline)) Py_ssize_t digit_pairs(const char *p, Py_ssize_t i, uint64_t *m)
{
    uint64_t v = *m;
    unsigned t;
    for (;;) {
        t = PAIR[pair_index(p + i)];
        if (t >= PAIR_ONE)
            break;
        v = v * 100u + t;
        i += 2;
    }
    if (t < PAIR_END) {                           /* a last digit */
        v = v * 10u + (t - PAIR_ONE);
        i++;
    }
    *m = v;
    return i;
}

/* dec_value_nl's reading (the same length, decimals, double and integer) with the digits read two
   at a time: the byte after the text's '\n' must be readable (digit_pairs) */
static inline __attribute__((always_inline)) Py_ssize_t dec_value_pairs(const char *p, int *dec, double *v,
                                                                        uint64_t *mo)
{
    int neg = p[0] == '-';
    Py_ssize_t i0 = neg, nf = 0;
    uint64_t m = 0;                               /* (wraps past 19 digits: then unused) */
    Py_ssize_t i = digit_pairs(p, i0, &m);
    Py_ssize_t nd = i - i0;
    *dec = 0;
    if (p[i] == '.') {
        Py_ssize_t f0 = i + 1;
        i = digit_pairs(p, f0, &m);
        nf = i - f0;
        *dec = (int)nf;
    }
    if (nd + nf == 0)
        return -1;
    *mo = m;
    if (nd + nf <= 15) {                          /* to_double's fast path: the same division */
        double x = (double)(int64_t)m;
        if (nf) x = x / POW10[nf];
        *v = neg ? -x : x;
    } else
        *v = to_double(p, i);
    return i;
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
        if ((i = plain_start(p, m)) == 0) { shape_ok = 0; break; }
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

/* units_txt(t, dec) of a plain decimal text t plain_line read (m: its digits' integer, nf
   its decimals), without reading it again.  Where nf <= dec (every text of a block: dec is
   its texts' most decimals) the digits kept are all of them, m (exact: at most 15 digits
   here), times 10 a decimal short of dec; else the text is read. */
static inline int units_read(const Txt *t, uint64_t m, int nf, int dec, int64_t *out)
{
    if (nf > dec)
        return units_txt(t->p, t->n, dec, out);
    int neg = t->p[0] == '-', dot = nf > 0 || t->p[t->n - 1] == '.';
    Py_ssize_t nd = t->n - neg - dot - nf;         /* the whole's digits */
    if (nd + nf <= 0 || nd + nf > 15)
        return -1;
    int64_t v = (int64_t)m;
    for (int j = nf; j < dec; j++) {
        if (v > (int64_t)EXACT_MAX) return -1;
        v *= 10;
    }
    if (v > (int64_t)EXACT_MAX) return -1;
    *out = neg ? -v : v;
    return 0;
}

/* the moves' texts' digits' integers and decimals as stroke_block read them (x, y, e):
   their units taken when asked, only for the moves that need them (most moves of a dense
   path need none) */
typedef struct { const uint64_t *m[3]; const int *nf[3]; } ColUnits;

/* units_txt(t[k], dec) of column c (0 x, 1 y, 2 e): from cu's integers (cu not NULL) or
   read from the text */
static inline int col_units(const Txt *t, const ColUnits *cu, int c, Py_ssize_t k, int dec, int64_t *out)
{
    if (cu == NULL)
        return units_txt(t[k].p, t[k].n, dec, out);
    return units_read(&t[k], cu->m[c][k], cu->nf[c][k], dec, out);
}

/* "00".."99": two decimal digits a division */
static const char DIGITS2[201] = "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
                                 "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
                                 "8081828384858687888990919293949596979899";

/* the decimal digits of a, written backwards ending at end: their first.  Two digits a
   step; 64-bit steps only while a needs them, then 32-bit ones (cheaper multiplications;
   nearly every number of a segment line fits 32 bits from the start) */
static inline char *digits_back(char *end, uint64_t a)
{
    while (a > UINT32_MAX) {
        uint64_t r = a % 100;
        a /= 100;
        end -= 2;
        memcpy(end, DIGITS2 + 2 * r, 2);
    }
    uint32_t b = (uint32_t)a;
    while (b >= 100) {
        uint32_t r = b % 100;
        b /= 100;
        end -= 2;
        memcpy(end, DIGITS2 + 2 * r, 2);
    }
    if (b >= 10) {
        end -= 2;
        memcpy(end, DIGITS2 + 2 * b, 2);
    } else
        *--end = (char)('0' + b);
    return end;
}

/* s[0..n) copied to q: the end.  The short texts of a segment line (numbers, words) by two
   overlapping loads, without a call to memcpy */
static inline char *copy_short(char *q, const char *s, Py_ssize_t n)
{
    if (n >= 8 && n <= 16) {
        uint64_t a, z;
        memcpy(&a, s, 8);
        memcpy(&z, s + n - 8, 8);
        memcpy(q, &a, 8);
        memcpy(q + n - 8, &z, 8);
    } else if (n >= 4 && n < 8) {
        uint32_t a, z;
        memcpy(&a, s, 4);
        memcpy(&z, s + n - 4, 4);
        memcpy(q, &a, 4);
        memcpy(q + n - 4, &z, 4);
    } else if (n > 16)
        memcpy(q, s, (size_t)n);
    else if (n >= 2) {
        uint16_t a, z;
        memcpy(&a, s, 2);
        memcpy(&z, s + n - 2, 2);
        memcpy(q, &a, 2);
        memcpy(q + n - 2, &z, 2);
    } else if (n == 1)
        *q = *s;
    return q + n;
}

/* s[0..n) copied to q, where 16 bytes may be read at s and written at q (units_at's
   digits and room): one 16-byte copy for n <= 16 (the bytes past n are written over or
   past the text's end), copy_short past that; the end */
static inline char *copy_upto16(char *q, const char *s, Py_ssize_t n)
{
    if (n > 16)
        return copy_short(q, s, n);
    memcpy(q, s, 16);
    return q + n;
}

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ && defined(__GNUC__)
#define SWAR_DIGITS 1
/* the 8 decimal digits of v < 10^8, zero-padded, one a byte (0..9), the first in the lowest
   byte (the first in memory): the division by 10^4, then by 100 in two 32-bit lanes, then
   by 10 in four 16-bit lanes, each lane's quotient a multiplication and a shift, exact for
   its range (n * 10486 >> 20 is n / 100 for n < 10^4; n * 103 >> 10 is n / 10 for n < 100);
   no lane's product reaches the next lane.  ~15 instructions where digits_back's loop
   takes ~45 */
static inline uint64_t digits8(uint32_t v)
{
    uint64_t x = (uint64_t)(v / 10000) | (uint64_t)(v % 10000) << 32;
    uint64_t h = ((x * 10486) >> 20) & 0x0000007F0000007FULL;
    x = h | (x - h * 100) << 16;
    h = ((x * 103) >> 10) & 0x000F000F000F000FULL;
    return h | (x - h * 10) << 8;
}

/* units_at_nf's text of |u| = a < 10^8 with dec <= 7 decimals (neg: a "-" first): the
   whole is the digits before the last dec, its leading zeros cut (ctz) but its last
   digit kept; the fraction the last dec, its trailing zeros cut (clz); each written as
   one 8-byte store (units_at_nf's room).  The end; *nf: the fraction's digits */
static inline __attribute__((always_inline)) char *small_units_at(char *q, uint32_t a, int neg, int dec, int *nf)
{
    uint64_t d = digits8(a), t = d + 0x3030303030303030ULL;
    /* (the bits or-ed in change a count only past the digits min() keeps: lead <= 7 - dec,
       trail >= dec for d == 0) */
    int lead = __builtin_ctzll(d | 1ULL << 56) >> 3, trail = __builtin_clzll(d | 1) >> 3;
    int first = lead < 7 - dec ? lead : 7 - dec;       /* the whole: digits first .. 8 - dec */
    int n_frac = trail < dec ? dec - trail : 0;
    uint64_t w = t >> (8 * first);
    if (neg) *q++ = '-';                           /* a != 0: whole != "0" or a fraction digit */
    memcpy(q, &w, 8);
    q += 8 - dec - first;
    *nf = n_frac;
    if (n_frac) {
        *q++ = '.';
        w = t >> (8 * (8 - dec));                   /* (dec >= 1 here) */
        memcpy(q, &w, 8);
        q += n_frac;
    }
    return q;
}
#else
#define SWAR_DIGITS 0
static inline __attribute__((always_inline)) char *small_units_at(char *q, uint32_t a, int neg, int dec, int *nf)
{
    (void)q; (void)a; (void)neg; (void)dec; (void)nf;
    return NULL;
}
#endif

/* emit._fmt_units(u, dec) written at q (room for 48 bytes; 0 <= dec <= 30): the end; *nf:
   its decimals (the fraction's digits, trailing zeros cut).  |u| < 10^8 and dec <= 7
   (nearly every number a segment line writes): small_units_at.  Else its
   digits are made in tmp after 32 zeros (the padding to dec + 1 digits, without a loop),
   and the whole and the fraction copied 16 bytes at a time: at most 1 + 20 + 1 + 16 bytes
   written, inside the room */
static __attribute__((noinline)) char *big_units_at(char *q, int64_t u, int dec, int *nf)
{
    uint64_t a = u < 0 ? (uint64_t)0 - (uint64_t)u : (uint64_t)u;
    char tmp[64];
    char *end = tmp + 48;                          /* the digits end here; 16 bytes after them to read */
    memset(end - 32, '0', 32);
    char *first = digits_back(end, a);
    if (end - first < dec + 1)
        first = end - (dec + 1);                   /* zero-padded to dec + 1 digits */
    char *point = end - dec, *last = end;          /* the whole: first..point; the fraction: point..last */
    while (last > point && last[-1] == '0') last--;   /* the fraction's trailing zeros cut */
    if (u < 0) *q++ = '-';                         /* u != 0: whole != "0" or a fraction digit */
    q = copy_upto16(q, first, point - first);
    *nf = (int)(last - point);
    if (last > point) {
        *q++ = '.';
        q = copy_upto16(q, point, last - point);
    }
    return q;
}

/* (inlined: emit_cols writes ~3 numbers a segment line, nearly all small_units_at's; the
   call and big_units_at's frame cost ~20 instructions a number) */
static inline __attribute__((always_inline)) char *units_at_nf(char *q, int64_t u, int dec, int *nf)
{
    uint64_t a = u < 0 ? (uint64_t)0 - (uint64_t)u : (uint64_t)u;
    if (SWAR_DIGITS && a < 100000000 && dec <= 7)
        return small_units_at(q, (uint32_t)a, u < 0, dec, nf);
    return big_units_at(q, u, dec, nf);
}

static inline char *units_at(char *q, int64_t u, int dec)
{
    int nf;
    return units_at_nf(q, u, dec, &nf);
}

/* emit._fmt_units(u, dec) appended */
static int put_units(Buf *b, int64_t u, int dec)
{
    if (dec > 30) return -2;
    if (buf_grow(b, 48) < 0)
        return -1;
    b->n = units_at(b->p + b->n, u, dec < 0 ? 0 : dec) - b->p;   /* (dec <= 0: str(u)) */
    return 0;
}

/* emit._tenths_up(k) written at q (room for 24 bytes; k < TENTHS_MAX): the end.  (Inlined
   at emit_cols' two calls, its feed's and its accel line's: gcc made it a call a line) */
static inline __attribute__((always_inline)) char *tenths_at(char *q, int64_t k)
{
    char tmp[24];
    if (k <= 1) {
        memcpy(q, "0.1", 3);
        return q + 3;
    }
    if (SWAR_DIGITS && k < 100000000) {         /* _tenths(k): _fmt_units(k, 1)'s text for k >= 1 */
        int nf;
        return small_units_at(q, (uint32_t)k, 0, 1, &nf);
    }
    int r = (int)(k % 10);
    char *end = tmp + sizeof tmp, *first = digits_back(end, (uint64_t)(k / 10));   /* k / 10 >= 1 */
    q = copy_short(q, first, end - first);
    if (r) {
        *q++ = '.';
        *q++ = (char)('0' + r);
    }
    return q;
}

/* emit._tenths_up(k) appended (k < TENTHS_MAX) */
static int put_tenths_up(Buf *b, int64_t k)
{
    if (buf_grow(b, 24) < 0)
        return -1;
    b->n = tenths_at(b->p + b->n, k) - b->p;
    return 0;
}

/* Python's round(x) of a float (float.__round__: half to even), as an int64: 0, or -1.
   Below 2^52, |x| + 2^52 is rounded to an integer by the addition itself, a half to even
   (IEEE's rounding to nearest, which Python never changes): the subtraction is exact, so
   r is float.__round__'s value without libm's round and the halfway test (~50 instructions
   a call of emit_cols' three a point); from 2^52 on every double is an integer. */
#if defined(FLT_EVAL_METHOD) && FLT_EVAL_METHOD == 0
static inline int py_round(double x, int64_t *out)
{
    const double two52 = 4503599627370496.0;
    double t = fabs(x);
    if (!(t < 4.0e18))                            /* (NaN and the infinities too) */
        return -1;
    double r = t < two52 ? (t + two52) - two52 : t;
    *out = (int64_t)copysign(r, x);
    return 0;
}
#else
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
#endif

/* ceil(x) as an int64 where it is below TENTHS_MAX (c < TENTHS_MAX, an integer: x <=
   TENTHS_MAX - 1): 0, else -1 (NaN too).  For x > -1 (a feed's and an accel's tenths: x >
   -1e-6) the truncation t, plus 1 where x is past it (t and x exact below 2^50), without
   ceil (gcc's SSE2 expansion of it: ~16 instructions; emit_cols takes two a line) */
static inline int ceil_tenths(double x, int64_t *k)
{
    if (!(x <= (double)(TENTHS_MAX - 1)))
        return -1;
    if (x > -1.0) {
        int64_t t = (int64_t)x;
        *k = t + ((double)t < x);
    } else
        *k = (int64_t)ceil(x);
    return 0;
}

/* emit.emit_stroke's inline E text of a whole move, relative E: "0" + t for ".ddd" not
   ending in 0, else _canon(t), written at q (at most m + 1 bytes): the end; *nf: its decimals */
static inline __attribute__((always_inline)) char *canon_at(char *q, const char *t, Py_ssize_t m, int *nf)
{
    if (m > 0 && t[0] == '.' && t[m - 1] != '0') {
        *nf = (int)(m - 1);
        *q++ = '0';
        return copy_short(q, t, m);
    }
    int neg = m > 0 && t[0] == '-';
    Py_ssize_t i = 0;
    while (i < m && (t[i] == '+' || t[i] == '-')) i++;         /* lstrip("+-") */
    const char *rest = t + i;
    Py_ssize_t rn = m > i ? m - i : 0;                          /* (i <= m; written so gcc sees rn >= 0) */
    const char *dot = memchr(rest, '.', (size_t)rn);
    Py_ssize_t wn = dot ? dot - rest : rn;
    const char *frac = dot ? dot + 1 : rest + rn;
    Py_ssize_t fn = dot ? rn - wn - 1 : 0;
    Py_ssize_t w0 = 0;
    while (w0 < wn && rest[w0] == '0') w0++;                   /* lstrip("0") */
    while (fn > 0 && frac[fn - 1] == '0') fn--;                /* rstrip("0") */
    int whole_zero = (w0 == wn);                                /* whole is "0" */
    *nf = (int)fn;
    if (!fn && whole_zero) {
        *q++ = '0';
        return q;
    }
    if (neg)
        *q++ = '-';
    if (whole_zero)
        *q++ = '0';
    else
        q = copy_short(q, rest + w0, wn - w0);
    if (fn) {
        *q++ = '.';
        q = copy_short(q, frac, fn);
    }
    return q;
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

/* set_types(ndarray, float64 dtype, array.array[, probe, probe_address]): what fseq_get
   reads besides lists and bytes.  probe: a float64 ndarray [0.5, 1.5, 2.5] and the address
   of its data (probe.ctypes.data): when the array's leading fields (NdHead) read as they
   should on it, fseq_object reads a contiguous 1-D float64 ndarray's doubles where they are
   (no tobytes() and copy a sequence) */
static PyObject *ND_TYPE = NULL, *F64_DTYPE = NULL, *ARRAY_TYPE = NULL;

/* numpy's array object's leading fields (PyArrayObject_fields in numpy/ndarraytypes.h:
   the same in numpy 1.x and 2.x); used only when set_types' probe reads right */
typedef struct {
    PyObject_HEAD
    char *data;
    int nd;
    Py_ssize_t *dimensions, *strides;
    PyObject *base, *descr;
} NdHead;
static int ND_DIRECT = 0;

static PyObject *set_types(PyObject *self, PyObject *args)
{
    PyObject *nd, *f64, *arr, *probe = NULL, *addr = NULL;
    if (!PyArg_ParseTuple(args, "O!OO!|OO", &PyType_Type, &nd, &f64, &PyType_Type, &arr, &probe, &addr))
        return NULL;
    Py_XSETREF(ND_TYPE, Py_NewRef(nd));
    Py_XSETREF(F64_DTYPE, Py_NewRef(f64));
    Py_XSETREF(ARRAY_TYPE, Py_NewRef(arr));
    ND_DIRECT = 0;
    if (probe != NULL && addr != NULL && Py_IS_TYPE(probe, (PyTypeObject *)nd) && PyLong_Check(addr)) {
        void *at = PyLong_AsVoidPtr(addr);
        const NdHead *h = (const NdHead *)probe;
        if (at != NULL && h->data == at && h->nd == 1 && h->dimensions[0] == 3 && h->strides[0] == sizeof(double)
            && h->descr == f64) {
            const double *v = (const double *)h->data;
            ND_DIRECT = v[0] == 0.5 && v[1] == 1.5 && v[2] == 2.5;
        }
        PyErr_Clear();
    }
    return PyBool_FromLong(ND_DIRECT);
}

/* the doubles of an array.array('d') o (its buffer: array.array keeps nothing of a buffer
   after its release) into f, after zero_first 0.0s (1: a RowPlan's knots made of its
   stroke's ends_d, 0 then those: segments.knots_of_ends): 0; -1 (no exception): not one */
static int fseq_array(PyObject *o, FSeq *f, int zero_first)
{
    if (ARRAY_TYPE == NULL || !Py_IS_TYPE(o, (PyTypeObject *)ARRAY_TYPE))
        return -1;
    Py_buffer v;
    if (PyObject_GetBuffer(o, &v, PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0) {
        PyErr_Clear();
        return -1;
    }
    int ok = v.format != NULL && strcmp(v.format, "d") == 0 && v.itemsize == sizeof(double) && v.ndim == 1;
    if (ok) {
        f->n = v.len / (Py_ssize_t)sizeof(double) + zero_first;
        f->own = PyMem_Malloc((f->n ? f->n : 1) * sizeof(double));
        if (f->own != NULL) {
            for (int k = 0; k < zero_first; k++)
                f->own[k] = 0.0;
            memcpy(f->own + zero_first, v.buf, (f->n - zero_first) * sizeof(double));
        }
        f->d = f->own;
        ok = f->own != NULL;
    }
    PyBuffer_Release(&v);
    return ok ? 0 : -1;
}

/* the doubles of a 1-D float64 ndarray (its tobytes(), as emit._doubles takes them) or an
   array.array('d') (its buffer: array.array keeps nothing of a buffer after its release),
   into f: 0; -1 (no exception): not one */
static int fseq_object(PyObject *o, FSeq *f)
{
    PyObject *bytes = NULL;
    if (ND_DIRECT && Py_IS_TYPE(o, (PyTypeObject *)ND_TYPE)) {
        /* the doubles where they are (the caller holds the array): tobytes() would give
           these same bytes */
        const NdHead *h = (const NdHead *)o;
        if (h->descr == F64_DTYPE && h->nd == 1 && h->strides[0] == (Py_ssize_t)sizeof(double)
            && ((uintptr_t)h->data % sizeof(double)) == 0) {
            f->own = NULL;
            f->d = (const double *)h->data;
            f->n = h->dimensions[0];
            return 0;
        }
    }
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
    return fseq_array(o, f, 0);
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

/* row r of a 2-D float64 ndarray whose rows are contiguous, read where it is (a RowPlan's
   block: block[r] is the 1-D view fseq_object would read in place, the same doubles): 0;
   -1 (f untouched): not such an array or row, fseq_get on block[r] decides */
static int fseq_row(PyObject *o, Py_ssize_t r, FSeq *f)
{
    if (!ND_DIRECT || !Py_IS_TYPE(o, (PyTypeObject *)ND_TYPE))
        return -1;
    const NdHead *h = (const NdHead *)o;
    if (h->descr != F64_DTYPE || h->nd != 2 || h->strides[1] != (Py_ssize_t)sizeof(double) || r < 0
        || r >= h->dimensions[0])
        return -1;
    const char *at = h->data + r * h->strides[0];
    if ((uintptr_t)at % sizeof(double) != 0)
        return -1;
    f->own = NULL;
    f->d = (const double *)at;
    f->n = h->dimensions[1];
    return 0;
}

typedef struct { int64_t x_a, x_b, y_a, y_b, e_move, e_before; } MoveUnits;

/* emit._move_units */
static int move_units(const Txt *xt, const Txt *yt, const Txt *et, const ColUnits *cu, Py_ssize_t move,
                      const int64_t *start_u, int dxy, int de, int e_rel, int64_t e_start_u, MoveUnits *mu)
{
    int64_t e_u, e_b;
    if (move == 0) {
        mu->x_a = start_u[0];
        mu->y_a = start_u[1];
    } else if (col_units(xt, cu, 0, move - 1, dxy, &mu->x_a) < 0 || col_units(yt, cu, 1, move - 1, dxy, &mu->y_a) < 0)
        return -1;
    if (col_units(xt, cu, 0, move, dxy, &mu->x_b) < 0 || col_units(yt, cu, 1, move, dxy, &mu->y_b) < 0
        || col_units(et, cu, 2, move, de, &e_u) < 0)
        return -1;
    if (e_rel) {
        mu->e_move = e_u;
        mu->e_before = 0;
        return 0;
    }
    if (move == 0)
        e_b = e_start_u;
    else if (col_units(et, cu, 2, move - 1, de, &e_b) < 0)
        return -1;
    mu->e_move = e_u - e_b;
    mu->e_before = e_b;
    return 0;
}

/* the "\n"s in p[0..n) */
static Py_ssize_t count_nl(const char *p, Py_ssize_t n)
{
    Py_ssize_t c = 0;
    for (const char *e = p + n; p < e && (p = memchr(p, '\n', (size_t)(e - p))) != NULL; p++)
        c++;
    return c;
}

/* the pieces emit_cols puts around the segment lines (ASCII) */
typedef struct {
    const char *hp, *wp, *nlp, *clp, *bp, *ap;
    Py_ssize_t hn, wn, nln, cln, bn, an;
} Pieces;

/* their "\n"s, in this order: head, closing, before, after, line end, accel word */
#define PIECES 6

static double POW10_NEG[32];
static int POW10_NEG_READY = 0;

static inline double pow10_neg(int k)
{
    if (k < 0 || k >= 32)
        return pow(10.0, (double)-k);
    if (!POW10_NEG_READY) {
        for (int j = 0; j < 32; j++)
            POW10_NEG[j] = pow(10.0, (double)-j);
        POW10_NEG_READY = 1;
    }
    return POW10_NEG[k];
}

/* fast_check's running state of a body's segment lines */
typedef struct {
    int path;                       /* px, py: the polyline (0: no path check) */
    const double *px, *py;
    Py_ssize_t nv, j;               /* its vertices; the next original vertex */
    double tol_d, x_prev, y_prev, gap_least;
    int n_points;
    double e_sum, e_abs, e_last;
    Py_ssize_t n_e;
} Walk;

/* a segment line's point (x, y; dxy: the larger of their decimals) and E word (has_e)
   taken into w: 1, or 0 (the check does not certainly pass) */
static inline __attribute__((always_inline)) int walk_point(Walk *w, double x, double y, int dxy, int has_e, double e)
{
    if (has_e) {
        if (!isfinite(e)) return 0;
        w->e_sum += e;
        w->e_abs += fabs(e);
        w->e_last = e;
        w->n_e++;
    }
    if (w->path) {
        const double *px = w->px, *py = w->py;
        Py_ssize_t j = w->j, nv = w->nv;
        if (j < nv && x == px[j] && y == py[j])
            w->j = j + 1;
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
            double ex = x - ax - tt * ddx, ey = y - ay - tt * ddy;
            double tv = 0.75 * pow10_neg(dxy);         /* validate._tol */
            double tol = (tv < w->tol_d ? tv : w->tol_d) + 1e-7;
            double lim = tol * (1.0 - MARGIN_R), d2 = ex * ex + ey * ey;
            /* hypot(ex, ey) <= lim: certain where d2 is below lim^2 by far (the squares'
               and the sum's rounding, and hypot's own, are ~1e-16 relative; an underflow
               is far below lim^2 when lim > 1e-100), else hypot's own verdict */
            if (!(lim > 1e-100 && d2 <= lim * lim * (1.0 - 1e-9)) && !(hypot(ex, ey) <= lim))
                return 0;              /* off this segment, or near: Python's search */
        }
        double gx = fabs(x - w->x_prev), gy = fabs(y - w->y_prev);
        double g = gy > gx ? gy : gx;
        if (g < w->gap_least) w->gap_least = g;
        w->x_prev = x;
        w->y_prev = y;
    }
    w->n_points++;
    return 1;
}

/* a segment line "G1 X<n> Y<n>[ E<n>] F<n>" read at p (its "\n" ends the scans): its
   length (no "\n"), or -1 (not certainly such a line with values fast_check passes):
   x, y, dxy (the larger of their decimals), has_e and e */
static inline __attribute__((always_inline)) Py_ssize_t read_point(const char *p, double *x, double *y, int *dxy,
                                                                    int *has_e, double *e)
{
    Py_ssize_t xn, yn, en = 0, fn, i = 4, m;
    int dx_, dy_, dec;
    double f;
    *e = 0.0;
    xn = dec_value_nl(p + i, &dx_, x);
    if (xn < 0 || dx_ > MAX_DECIMALS) return -1;
    i += xn;
    if (p[i] != ' ' || p[i + 1] != 'Y') return -1;
    i += 2;
    yn = dec_value_nl(p + i, &dy_, y);
    if (yn < 0 || dy_ > MAX_DECIMALS) return -1;
    i += yn;
    if (p[i] == ' ' && p[i + 1] == 'E') {
        i += 2;
        en = dec_value_nl(p + i, &dec, e);
        if (en < 0 || dec > MAX_DECIMALS) return -1;
        i += en;
    }
    if (p[i] != ' ' || p[i + 1] != 'F') return -1;
    i += 2;
    fn = dec_value_nl(p + i, &dec, &f);
    m = i + fn;
    if (fn < 0 || dec > MAX_DECIMALS || p[m] != '\n') return -1;
    if (!(isfinite(*x) && isfinite(*y) && f > 0.0 && f < INFINITY)) return -1;
    *dxy = dx_ > dy_ ? dx_ : dy_;
    *has_e = en != 0;
    return m;
}

/* block_into's check of the lines emit_cols writes from numbers (segment and accel lines),
   done as it writes them: the doubles and decimals fast_check's reading would give each
   (known_units; plain_line's values for a text copied; ka / 10 for tenths_at's text) taken
   through fast_check's own tests, in the lines' order, w the state they leave for its
   reading of the other lines.  The lines so checked are the ranges skip[0..n_skip) (at
   most 3: first_cmds' lines, read, part them).  A segment line's F is positive and
   finite, 1 decimal at most, by construction: nothing of it to check. */
typedef struct {
    Walk w;
    double accel_hi;                /* fast_check's bound of an accel line's value */
    Py_ssize_t limit;               /* its command length limit (0: none) */
    const double *x, *y, *e;        /* move k's end as plain_line read it (e: 0.0 without E) */
    const int *dx, *dy, *de;        /* and its decimals */
    Py_ssize_t skip[3][2], n_skip, open;   /* ranges [a, z) checked (offsets in emit_cols' buffer) */
} Known;

/* the range of checked lines open at kn->open closed at z (an empty one dropped) */
static inline void skip_close(Known *kn, Py_ssize_t z)
{
    if (z > kn->open && kn->n_skip < 3) {
        kn->skip[kn->n_skip][0] = kn->open;
        kn->skip[kn->n_skip][1] = z;
        kn->n_skip++;
    }
}

/* the value and decimals fast_check's reading gives a number units_at(u, dec) wrote
   (nf: its decimals): 1, or 0 (not certain: the line is read).  The text is u / 10^dec
   with trailing zeros cut; dec_value reads digits m' and nf decimals, m' / 10^nf, the
   same real: each a correctly rounded division of exact doubles (|u| <= 2^53, dec <= 15),
   or PyOS_string_to_double's correctly rounded value past 15 digits: the same double. */
static inline int known_units(int64_t u, int dec, double *v)
{
    if (!(u >= -(int64_t)EXACT_MAX && u <= (int64_t)EXACT_MAX) || dec < 0 || dec > 15)
        return 0;
    *v = (double)u / POW10[dec];
    return 1;
}

/* a start text that is fmt_f(x, 8)'s, as its integer: |x| 10^8 rounded (n) and the sign
   fmt_f writes (neg: signbit(x)), for x0 and y0 (known: both are) -- units_txt's and
   start_decimals' values of the texts without reading them again */
typedef struct {
    int known;
    uint64_t n[2];
    int neg[2];
} Start8;

#define E8 100000000ULL

/* start_decimals of fmt_f(x, 8)'s text: the fraction's 8 digits, trailing zeros cut, at most 6
   (SWAR_DIGITS: the trailing zeros counted on digits8's bytes, the last digit the highest
   byte, not a division by 10 a zero: a plate's start texts have ~5) */
static inline int start8_decimals(uint64_t n)
{
    uint64_t f = n % E8;
    if (f == 0)
        return 0;
#if SWAR_DIGITS
    int k = 8 - (__builtin_clzll(digits8((uint32_t)f)) >> 3);
#else
    int k = 8;
    while (f % 10 == 0) {
        f /= 10;
        k--;
    }
#endif
    return k < 6 ? k : 6;
}

/* 10^k as an integer, k 0..19 */
static const uint64_t U10[20] = {1ULL, 10ULL, 100ULL, 1000ULL, 10000ULL, 100000ULL, 1000000ULL, 10000000ULL,
                                 100000000ULL, 1000000000ULL, 10000000000ULL, 100000000000ULL,
                                 1000000000000ULL, 10000000000000ULL, 100000000000000ULL,
                                 1000000000000000ULL, 10000000000000000ULL, 100000000000000000ULL,
                                 1000000000000000000ULL, 10000000000000000000ULL};

/* units_txt(fmt_f(x, 8)'s text, dec, out) from its integer: the whole's digits and the
   fraction's first min(8, dec) (at most 15 digits), times 10 for each decimal past 8 while
   at most 2^53: 0, or -1 where units_txt declines */
static int start8_units(uint64_t n, int neg, int dec, int64_t *out)
{
    int fk = dec < 8 ? dec : 8;
    /* the whole's digits (wn, 1 for 0) and fk at most 15: whole < 10^(15 - fk) (15 - fk >= 7) */
    if (dec < 0 || n / E8 >= U10[15 - fk])
        return -1;
    int64_t v = (int64_t)(n / U10[8 - fk]);       /* < 10^15 */
    for (int j = fk; j < dec; j++) {
        if (v > (int64_t)EXACT_MAX) return -1;
        v *= 10;
    }
    if (v > (int64_t)EXACT_MAX) return -1;
    *out = neg ? -v : v;
    return 0;
}

#define ROOM_KNOTS 32             /* emit_cols_body's knots a room is made for at once (more: its reallocs copied more) */

/* emit.emit_stroke's loop: head + segment lines (before/after around the first move when
   bp is not NULL) + closing appended to b.  The moves' texts are the columns xt, yt, et, cm
   (n_cols of them).  0: written; 1: decline (the Python loop would take another path or
   raise); -1: no memory.  n_lines (not NULL): the "\n"s written (the pieces' counted once
   a block, or taken from piece_nl where not NULL: PIECES counts, piece_lines'; the moves'
   texts have none: plain_line's, or units and tenths).  kn (not
   NULL, nlp "\n", wp fast_check's accel word): the lines checked as they are written, 1
   (decline) where fast_check would not pass them. */
static inline __attribute__((always_inline)) int
emit_cols_body(Buf *b, const Pieces *pc, const Txt *xt, const Txt *yt, const Txt *et, const Txt *cm,
               Py_ssize_t n_cols, const FSeq *s, const FSeq *acc, const FSeq *fd, const FSeq *ends, int dxy,
               int de, int e_rel, int extruding, int64_t e_start_u, const Txt *x0t, const Txt *y0t,
               const Start8 *s8, const ColUnits *cu, const Py_ssize_t *piece_nl, Py_ssize_t *n_lines, Known *kn)
{
    Py_ssize_t n_moves = ends->n, k_total = s->n - 1;
    const char *hp = pc->hp, *wp = pc->wp, *nlp = pc->nlp, *clp = pc->clp, *bp = pc->bp, *ap = pc->ap;
    Py_ssize_t hn = pc->hn, wn = pc->wn, nln = pc->nln, cln = pc->cln, bn = pc->bn, an = pc->an;
    if (!hp || !wp || !nlp || !clp || n_moves == 0 || k_total < 0 || dxy < 0 || dxy > 15 || de < 0 || de > 15)
        return 1;
    if (n_cols < n_moves || acc->n < k_total || fd->n < k_total || fabs((double)e_start_u) > EXACT_MAX)
        return 1;
    int64_t start_u[2];
    if (s8 != NULL && s8->known) {                 /* (the texts' integers: the same units) */
        if (start8_units(s8->n[0], s8->neg[0], dxy, &start_u[0]) < 0
            || start8_units(s8->n[1], s8->neg[1], dxy, &start_u[1]) < 0)
            return 1;
    } else if (units_txt(x0t->p, x0t->n, dxy, &start_u[0]) < 0 || units_txt(y0t->p, y0t->n, dxy, &start_u[1]) < 0)
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
    if (kn != NULL)
        kn->open = b->n;
    Py_ssize_t lines = 0, nl_nl = 0, nl_acc = 0;   /* "\n"s: written; a line end's; an accel line's */
    if (n_lines != NULL) {
        Py_ssize_t c[PIECES];
        if (piece_nl != NULL)
            memcpy(c, piece_nl, sizeof c);
        else {
            c[0] = count_nl(hp, hn);
            c[1] = count_nl(clp, cln);
            c[2] = bp != NULL ? count_nl(bp, bn) : 0;
            c[3] = ap != NULL ? count_nl(ap, an) : 0;
            c[4] = count_nl(nlp, nln);
            c[5] = count_nl(wp, wn);
        }
        lines = c[0] + c[1] + (k_total >= 1 ? c[2] + c[3] : 0);
        nl_nl = c[4];
        nl_acc = c[5] + nl_nl;
    }
    /* The room of a knot's lines made ROOM_KNOTS knots at a time, not a line at a time: at
       most an accel line (wn + 24 + nln: tenths_at's text in 24) and a segment line (11 +
       3 * 48 + 24 + nln: its words, numbers and feed, the move's texts where it takes them
       as they are -- the longest of the moves' -- and E's); the first call's also the
       before and after pieces.  (Each line's own sum and test were ~25 instructions a knot.) */
    Py_ssize_t max_txt = 0, max_e = 0;
    for (Py_ssize_t j = 0; j < n_moves; j++) {
        Py_ssize_t t = xt[j].n + yt[j].n + cm[j].n;
        max_txt = t > max_txt ? t : max_txt;
        max_e = et[j].n > max_e ? et[j].n : max_e;
    }
    const Py_ssize_t knot_room = wn + 24 + nln + 11 + 3 * 48 + 24 + nln + max_txt + (extruding ? max_e + 1 : 0);
    Py_ssize_t k_room = 1;                     /* the knots before k_room have their room made */
    for (Py_ssize_t k = 1; k <= k_total; k++) {
        if (k >= k_room) {
            Py_ssize_t nk = k_total - k + 1 < ROOM_KNOTS ? k_total - k + 1 : ROOM_KNOTS;
            if (buf_grow(b, nk * knot_room + (k == 1 ? (bp != NULL ? bn : 0) + (ap != NULL ? an : 0) : 0)) < 0)
                return -1;
            k_room = k + nk;
        }
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
                if (col_units(et, cu, 2, move, de, &eu) < 0)
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
                if (move_units(xt, yt, et, cu, move, start_u, dxy, de, e_rel, e_start_u, &mu) < 0)
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
            int64_t ka;
            if (ceil_tenths(a * 10.0 - 1e-9, &ka) < 0)
                return 1;                        /* the float formatting (or ceil's OverflowError) */
            if (ka <= 1) ka = 1;                     /* _tenths_up: every k <= 1 is "0.1" */
            have_a = 1;
            last_a = a;
            if (!have_cmd || ka != last_ka) {
                /* the accel line in the knot's room (tenths_at: at most 24 bytes) */
                char *q = copy_short(b->p + b->n, wp, wn);
                q = tenths_at(q, ka);
                if (kn != NULL) {
                    /* tenths_at's text of ka: ka / 10 (ka < 2^50: exact; "0.1" for 1) */
                    double av = (double)ka / 10.0;
                    if (!(av > 0.0 && av <= kn->accel_hi && av < INFINITY)
                        || (kn->limit > 0 && (q - b->p) - b->n > kn->limit))
                        return 1;
                }
                b->n = copy_short(q, nlp, nln) - b->p;
                lines += nl_acc;
                last_ka = ka;
                if (!have_cmd && bp != NULL) {           /* first_cmds[0], after the first M204 */
                    if (kn != NULL)
                        skip_close(kn, b->n);
                    if (put(b, bp, bn) < 0)          /* (in the first knots' room: no growth) */
                        return -1;
                    if (kn != NULL)
                        kn->open = b->n;
                }
                have_cmd = 1;
            }
        }
        if (!(isfinite(f) && f > 0.0))
            return 1;
        int64_t kf;
        if (ceil_tenths(f * 600.0 - 1e-6, &kf) < 0)
            return 1;
        /* the line, in the knot's room (a number's text: at most 48 bytes) */
        char *q = b->p + b->n;
        Py_ssize_t line_at = b->n;
        /* the line's values as fast_check would read them (known: all of them certain) */
        double xv = 0.0, yv = 0.0, ev = 0.0;
        int known = kn != NULL, nx = 0, ny = 0, ne = -1;
#define CPY(s_, n_) do { q = copy_short(q, (s_), (n_)); } while (0)
        CPY("G1 X", 4);
        if (at_vertex) {
            CPY(xo->p, xo->n);
            if (known) {                             /* the text plain_line read */
                xv = kn->x[move];
                nx = kn->dx[move];
            }
        } else {
            q = units_at_nf(q, xu, dxy, &nx);
            known = known && known_units(xu, dxy, &xv);
        }
        CPY(" Y", 2);
        if (at_vertex) {
            CPY(yo->p, yo->n);
            if (known) {
                yv = kn->y[move];
                ny = kn->dy[move];
            }
        } else {
            q = units_at_nf(q, yu, dxy, &ny);
            known = known && known_units(yu, dxy, &yv);
        }
        if (extruding) {
            CPY(" E", 2);
            if (e_kind == 2) {
                q = units_at_nf(q, eu, de, &ne);
                known = known && known_units(eu, de, &ev);
            } else if (e_kind == 0) {
                CPY(et[move].p, et[move].n);
                if (known) {                         /* (a line without E: "0", 0.0) */
                    ev = kn->e[move];
                    ne = kn->de[move];
                }
            } else {
                q = canon_at(q, et[move].p, et[move].n, &ne);   /* (in the room: m + 1 bytes) */
                if (known)                           /* the same digits; a zero is "0" */
                    ev = kn->e[move] == 0.0 ? 0.0 : kn->e[move];
            }
        }
        CPY(" F", 2);
        q = tenths_at(q, kf);
        if (co != NULL && co->n) {
            *q++ = ' ';
            CPY(co->p, co->n);
        }
        Py_ssize_t m_line = (q - b->p) - line_at;
        CPY(nlp, nln);
        if (kn != NULL) {
            /* the line's values (a number past the exact range: the line read back) */
            int dxy_l = nx > ny ? nx : ny, has_e = ne >= 0;
            if (co != NULL && co->n)
                return 1;                            /* (fast_check refuses a comment) */
            if (!known && (m_line = read_point(b->p + line_at, &xv, &yv, &dxy_l, &has_e, &ev)) < 0)
                return 1;
            if (dxy_l > MAX_DECIMALS || ne > MAX_DECIMALS || (kn->limit > 0 && m_line > kn->limit)
                || !walk_point(&kn->w, xv, yv, dxy_l, has_e, ev))
                return 1;
        }
        if (k == 1 && ap != NULL) {                  /* first_cmds[1], after the first move */
            if (kn != NULL) {
                skip_close(kn, q - b->p);
                kn->open = q - b->p + an;
            }
            CPY(ap, an);
        }
#undef CPY
        b->n = q - b->p;
        lines += nl_nl;
        if (at_vertex) {
            e_done_u = 0;
            if (move < n_moves - 1) {
                move += 1;
                start_d = end_d;
                end_d = ends->d[move];
            } else if (!e_rel) {                     /* knots past the end: the last move again */
                if (!have_mu && move_units(xt, yt, et, cu, move, start_u, dxy, de, e_rel, e_start_u, &mu) < 0)
                    return 1;
                e_again_u += mu.e_move;
            }
            have_mu = 0;
        }
    }
    if (kn != NULL)
        skip_close(kn, b->n);
    if (put(b, clp, cln) < 0)
        return -1;
    if (n_lines != NULL)
        *n_lines = lines;
    return 0;
}

/* emit_cols' body with the decimals of the slicers' usual columns as constants (X and Y 3,
   E 5: PrusaSlicer's and Cura's text; nearly every stroke): small_units_at's shifts and
   bounds fold, and dxy, de hold no register in the loop (the same operations on the same
   numbers as the general body's: the same bytes) */
static __attribute__((noinline)) int emit_cols_3_5(Buf *b, const Pieces *pc, const Txt *xt, const Txt *yt,
                                                   const Txt *et, const Txt *cm, Py_ssize_t n_cols, const FSeq *s,
                                                   const FSeq *acc, const FSeq *fd, const FSeq *ends, int e_rel,
                                                   int extruding, int64_t e_start_u, const Txt *x0t, const Txt *y0t,
                                                   const Start8 *s8, const ColUnits *cu, const Py_ssize_t *piece_nl,
                                                   Py_ssize_t *n_lines, Known *kn)
{
    return emit_cols_body(b, pc, xt, yt, et, cm, n_cols, s, acc, fd, ends, 3, 5, e_rel, extruding, e_start_u, x0t,
                          y0t, s8, cu, piece_nl, n_lines, kn);
}

static int emit_cols(Buf *b, const Pieces *pc, const Txt *xt, const Txt *yt, const Txt *et, const Txt *cm,
                     Py_ssize_t n_cols, const FSeq *s, const FSeq *acc, const FSeq *fd, const FSeq *ends, int dxy,
                     int de, int e_rel, int extruding, int64_t e_start_u, const Txt *x0t, const Txt *y0t,
                     const Start8 *s8, const ColUnits *cu, const Py_ssize_t *piece_nl, Py_ssize_t *n_lines, Known *kn)
{
    if (dxy == 3 && de == 5)
        return emit_cols_3_5(b, pc, xt, yt, et, cm, n_cols, s, acc, fd, ends, e_rel, extruding, e_start_u, x0t, y0t,
                             s8, cu, piece_nl, n_lines, kn);
    return emit_cols_body(b, pc, xt, yt, et, cm, n_cols, s, acc, fd, ends, dxy, de, e_rel, extruding, e_start_u, x0t,
                          y0t, s8, cu, piece_nl, n_lines, kn);
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
                          (int64_t)e_start_u, &x0, &y0, NULL, NULL, NULL, NULL, NULL);
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

/* pow(10.0, -k) (Python's 10.0 ** -k calls libm's pow): the same values, made once */
/* fast_body(text, start, stop, want, klipper, limit, accel_max_a, px, py, tol_d, e_mode,
             e_value, min_move_d)
   validate._fast_ok's reading of text[start:stop] (the body: "\n" line "\n" ... line "\n")
   and its checks; True when they certainly pass, None otherwise (the Python reading then
   decides).  want: the M204 letter; limit: the command buffer (0: none); px, py: the
   polyline's vertices (None: no path check); e_mode: 0 none, 1 relative (the E words'
   sum), 2 absolute (the last E word). */
/* fast_body's checks of the body t[start:stop] ("\n" line "\n" ... line "\n"): 1 when they
   certainly pass, 0 otherwise.  px, py: the polyline's nv vertices (path 0: no path check),
   each below validate._polyline_walk's bound.  kn (NULL: none): emit_cols' check of the
   lines it wrote, t at offset t_at of its buffer: those lines are passed over, the state
   they left taken on (no other line read here is a segment line: block_into). */
static int fast_check(const char *t, Py_ssize_t start, Py_ssize_t stop, int want, int klipper, Py_ssize_t limit,
                      double accel_max_a, int path, const double *px, const double *py, Py_ssize_t nv,
                      double tol_d, int e_mode, double e_value, double e_err, double min_move_d,
                      const Known *kn, Py_ssize_t t_at)
{
    const double accel_hi = accel_max_a + 0.1 + 1e-9;
    Walk w = {path, px, py, nv, 1, tol_d, 0.0, 0.0, INFINITY, 0, 0.0, 0.0, 0.0, 0};
    if (path) {
        w.x_prev = px[0];
        w.y_prev = py[0];
    }
    const char *skip_a = NULL;                       /* the next range checked, [skip_a, skip_z) */
    Py_ssize_t n_skip = 0, next = 0;
    if (kn != NULL) {
        w = kn->w;
        n_skip = kn->n_skip;
    }
    if (next < n_skip)
        skip_a = t + (kn->skip[0][0] - t_at);
    const char *p = t + start + 1, *end = t + stop;
    while (p < end) {
        /* The line is p[0..m), its "\n" at p[m], found as the line is read (no memchr a
           line): the region ends with a "\n", and each scan stops at one (a number's, a
           word's compare), so no read passes the region's end */
        const Py_ssize_t left = end - p;
        Py_ssize_t m, i, r;
        int dec;
        if (p == skip_a) {
            /* lines emit_cols checked: passed over (a range ends after a "\n", in the body) */
            p = t + (kn->skip[next][1] - t_at);
            skip_a = ++next < n_skip ? t + (kn->skip[next][0] - t_at) : NULL;
            continue;
        }
        if (left > 4 && memcmp(p, "G1 X", 4) == 0) {
            double x, y, e;
            int dxy, has_e;
            if (kn != NULL || (m = read_point(p, &x, &y, &dxy, &has_e, &e)) < 0 || !walk_point(&w, x, y, dxy, has_e, e))
                return 0;
        } else if (left > 4 && memcmp(p, "G1 F", 4) == 0) {
            i = 4;
            double f;
            r = dec_value_nl(p + i, &dec, &f);
            m = i + r;
            if (r < 0 || dec > MAX_DECIMALS || p[m] != '\n') return 0;
            if (!(f > 0.0 && f < INFINITY)) return 0;
        } else if (left > 6 && memcmp(p, "M204 ", 5) == 0 && p[5] == want) {
            i = 6;
            double a;
            r = dec_value_nl(p + i, &dec, &a);
            m = i + r;
            if (r < 0 || dec > MAX_DECIMALS || p[m] != '\n') return 0;
            if (!(a > 0.0 && a <= accel_hi && a < INFINITY)) return 0;
        } else if (klipper && left > MCR_N && memcmp(p, MCR, MCR_N) == 0) {
            i = MCR_N;
            double v;
            r = dec_value_nl(p + i, &dec, &v);
            m = i + r;
            if (r < 0 || dec > MAX_DECIMALS || p[m] != '\n') return 0;
            if (!(v >= 0.0 && v < 1.0)) return 0;
        } else
            return 0;
        if (limit > 0 && m > limit)
            return 0;
        p += m + 1;
    }
    if (path && min_move_d > 0.0 && w.n_points && w.gap_least < min_move_d) {
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
        if (w.gap_least < floor_d)
            return 0;
    }
    if (e_mode) {
        if (w.n_e == 0)
            return 0;
        double lim = E_TOL * (1.0 + fabs(e_value));
        if (e_mode == 2) {
            if (fabs(w.e_last - e_value) > lim) return 0;
        } else {
            /* fsum is within half an ulp of the exact sum, the running sum within
               (n - 1) u sum|e| of it: a pass this far inside the limit is fsum's too */
            double err = 2.0 * (double)w.n_e * 1.1102230246251565e-16 * w.e_abs + 1e-300;
            /* e_err: how far e_value may be from the value the Python check compares with
               (stroke_block's running sum of the original's E words; 0 for fast_body's fsum) */
            if (e_err > 0.0)
                lim = E_TOL * (1.0 + fabs(e_value) - e_err);
            if (!(fabs(w.e_sum - e_value) + 2.0 * err + 2.0 * e_err <= lim * (1.0 - MARGIN_R))) return 0;
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
                        e_mode, e_value, 0.0, min_move_d, NULL, 0);
    PyMem_Free(pv);
    if (ok)
        Py_RETURN_TRUE;
    Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- skip_lines, stroke_block */

/* the first "\n" or "\r" in p[0..e-p), else e: 16 bytes a step (SSE2), the rest (fewer
   than 16 before e) byte by byte.  (memchr for "\n", then for a "\r" before it, cost two
   calls a line: ~80 instructions a line of ~30 bytes) */
static inline const char *line_break_at(const char *p, const char *e)
{
#ifdef __SSE2__
    const __m128i nl = _mm_set1_epi8('\n'), cr = _mm_set1_epi8('\r');
    for (; e - p >= 16; p += 16) {
        __m128i v = _mm_loadu_si128((const __m128i *)p);
        unsigned m = (unsigned)_mm_movemask_epi8(_mm_or_si128(_mm_cmpeq_epi8(v, nl), _mm_cmpeq_epi8(v, cr)));
        if (m != 0)
            return p + __builtin_ctz(m);
    }
#endif
    while (p < e && *p != '\n' && *p != '\r')
        p++;
    return p;
}

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
        const char *e = d + len, *q = line_break_at(d + pos, e);
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

/* the number at p[0..n) as num_run finds it and plain_decimal reads it: its length when
   the run of [-.0-9] there is a plain decimal (read whole: dec_value's length, and no
   [-.0-9] after it), else -1; *dec, *v: its decimals and to_double's value.  p[n] is a
   plain_line's line end (its '\n', or a '\r' before it): the number is read up to it. */
static inline __attribute__((always_inline)) Py_ssize_t num_word(const char *p, Py_ssize_t n, int *dec, double *v,
                                                                 uint64_t *m, const int pairs)
{
    /* (plain_line's lines: a '\n' at p[n] or before; pairs: the byte after it readable) */
    Py_ssize_t k = pairs ? dec_value_pairs(p, dec, v, m) : dec_value_in(p, 0, dec, v, 1, m);
    if (k < 0)
        return -1;
    /* (digit_pairs' run ends at a byte that is not a digit: dec_value_pairs' p[k] is none) */
    if (k < n && ((!pairs && p[k] >= '0' && p[k] <= '9') || p[k] == '-' || p[k] == '.'))
        return -1;
    return k;
}

/* p[0..n) all ASCII (8 bytes a step) */
static inline int ascii_bytes(const char *p, Py_ssize_t n)
{
    uint64_t high = 0, w8;
    Py_ssize_t k = 0;
    if (n >= 8) {
        for (; k + 8 <= n; k += 8) {
            memcpy(&w8, p + k, sizeof w8);
            high |= w8;
        }
        if (k < n) {                              /* the last 8 bytes (some again) */
            memcpy(&w8, p + n - 8, sizeof w8);
            high |= w8;
        }
    } else
        for (; k < n; k++)
            high |= (unsigned char)p[k];
    return (high & 0x8080808080808080ULL) == 0;
}

/* one plain line of a stroke, as plain_moves reads it ("G1 [F<n> ]X<n> Y<n>[ E<n>][ \t]*[;c][\r]"):
   1 and its pieces, its numbers' decimals, values and digits' integers (v, u: x, y and e;
   e->p NULL without E), or 0 (not that shape, a number not a plain decimal, a byte not ASCII, a "\r" but
   the line's last: the Python reading).  The line is p[0..m) and p[m] its '\n' (num_word
   reads a number up to it, without a bound). */
static inline __attribute__((always_inline)) int plain_line_in(const char *p, Py_ssize_t m, Txt *x, Txt *y, Txt *e,
                                                              Txt *c, int *dx, int *dy, int *de, double *v,
                                                              uint64_t *u, const int pairs)
{
    Py_ssize_t i, xn, yn, en = 0;
    if ((i = plain_start(p, m)) == 0)
        return 0;
    x->p = p + i;
    if ((xn = num_word(p + i, m - i, dx, &v[0], &u[0], pairs)) < 0)
        return 0;
    i += xn;
    if (i + 2 > m || p[i] != ' ' || p[i + 1] != 'Y')
        return 0;
    i += 2;
    y->p = p + i;
    if ((yn = num_word(p + i, m - i, dy, &v[1], &u[1], pairs)) < 0)
        return 0;
    i += yn;
    e->p = NULL;
    *de = 0;
    if (i + 1 < m && p[i] == ' ' && p[i + 1] == 'E') {
        i += 2;
        e->p = p + i;
        if ((en = num_word(p + i, m - i, de, &v[2], &u[2], pairs)) < 0)
            return 0;
        i += en;
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
    /* the line read to its end, so a byte not ASCII or a "\r" before the last is only in
       a comment, where the first "\r" stops the loop above short of m */
    if (i != m || !ascii_bytes(c->p, c->n))
        return 0;
    x->n = xn;
    y->n = yn;
    e->n = en;
    return 1;
}

/* plain_line_in reading digits two at a time where that may read the byte after the line's
   '\n' (p[m + 1]): it is in the page of p[m] (a page is 4 KiB or a multiple of it), else a
   digit at a time */
static int plain_line(const char *p, Py_ssize_t m, Txt *x, Txt *y, Txt *e, Txt *c, int *dx, int *dy, int *de,
                      double *v, uint64_t *u)
{
    if (((uintptr_t)(p + m + 1) & 4095u) != 0)
        return plain_line_in(p, m, x, y, e, c, dx, dy, de, v, u, 1);
    return plain_line_in(p, m, x, y, e, c, dx, dy, de, v, u, 0);
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

/* ---------------------------------------------------------------- float texts
   float.__format__'s 'f' (precision <= 20) and '.4g' texts of the finite doubles of the
   common range made by exact integer arithmetic: x = m 2^e exactly, so x 10^k = m 5^k 2^(e+k)
   is an exact 128-bit integer shifted, and its rounding to an integer is decided on the
   shifted-out bits, half to even -- the correctly rounded digits PyOS_double_to_string
   (dtoa) gives.  Other values (not finite, too large, a '.4g' text in exponent form, no
   128-bit integers) take PyOS_double_to_string itself. */
#if defined(__SIZEOF_INT128__)
typedef unsigned __int128 u128;

/* round(|x| 10^k) half to even (*n) and floor(|x| 10^k) (*fl), k <= 27: 0; -1 when
   either is 2^64 or more */
/* 5^k, k <= 27 (scaled_int's factor) */
static const uint64_t POW5[28] = {
    1ULL, 5ULL, 25ULL, 125ULL, 625ULL, 3125ULL, 15625ULL, 78125ULL, 390625ULL, 1953125ULL, 9765625ULL,
    48828125ULL, 244140625ULL, 1220703125ULL, 6103515625ULL, 30517578125ULL, 152587890625ULL, 762939453125ULL,
    3814697265625ULL, 19073486328125ULL, 95367431640625ULL, 476837158203125ULL, 2384185791015625ULL,
    11920928955078125ULL, 59604644775390625ULL, 298023223876953125ULL, 1490116119384765625ULL,
    7450580596923828125ULL};

static int scaled_int(double x, int k, uint64_t *n, uint64_t *fl)
{
    uint64_t bits, p5;
    memcpy(&bits, &x, sizeof bits);
    int ex = (int)((bits >> 52) & 0x7ff);
    uint64_t m = bits & ((1ULL << 52) - 1);
    if (ex == 0)
        ex = 1;                                   /* subnormal: m 2^-1074 */
    else
        m |= 1ULL << 52;
    int s = ex - 1075 + k;                        /* |x| 10^k = m 5^k 2^s */
    p5 = POW5[k];                                 /* (5^27 < 2^63) */
    u128 P = (u128)m * p5;                        /* < 2^116 */
    if (s >= 0) {
        if (s >= 64 || (P >> (64 - s)) != 0)
            return -1;
        *n = *fl = (uint64_t)(P << s);
        return 0;
    }
    int sh = -s;
    if (sh >= 120) {                              /* |x| 10^k < 2^-4 */
        *n = *fl = 0;
        return 0;
    }
    if (sh < 64 && (P >> 64) == 0) {
        /* P in 64 bits (fmt_f(x, 4)'s: m 5^4 < 2^63): the same quotient, remainder and
           half in 64-bit words, without the 128-bit shifts' branches */
        uint64_t lo = (uint64_t)P, r = lo >> sh, rem = lo & ((1ULL << sh) - 1), half = 1ULL << (sh - 1);
        *fl = r;
        *n = r + (rem > half || (rem == half && (r & 1)));
        return 0;                                 /* (r < 2^63: no carry) */
    }
    u128 q = P >> sh, rem = P - (q << sh), half = (u128)1 << (sh - 1);
    if ((q >> 64) != 0)
        return -1;
    uint64_t r = (uint64_t)q;
    *fl = r;
    *n = r + (rem > half || (rem == half && (r & 1)));
    return *n < r ? -1 : 0;                       /* (a carry past 2^64) */
}

/* digits_back(end, n) (room for 28 bytes before end): n >= 10^8 (a start text's |x| 10^8
   for |x| >= 1: fmt_f_n(x, 8)'s) its last 8 digits one digits8 store, the digits before
   them digits_back's (~2 steps for a plate's coordinates, not ~5) */
static inline char *f_digits(char *end, uint64_t n)
{
#if SWAR_DIGITS
    if (n >= E8) {
        uint64_t hi = n / E8, t = digits8((uint32_t)(n - hi * E8)) + 0x3030303030303030ULL;
        memcpy(end - 8, &t, 8);
        return digits_back(end - 8, hi);
    }
#endif
    return digits_back(end, n);
}

/* format(x, f".{prec}f") into buf (at least 64 bytes): its length, or -1 (declined);
   *n_out: its digits' integer, |x| 10^prec rounded */
static int fmt_f_n(double x, int prec, char *buf, uint64_t *n_out)
{
    uint64_t n, fl;
    if (!isfinite(x) || prec < 0 || prec > 20 || scaled_int(x, prec, &n, &fl) < 0)
        return -1;
    *n_out = n;
#if SWAR_DIGITS
    if (n < 100000000 && prec <= 7) {
        /* the 8 digits of n at once (digits8: the heads' T, a start's x0 where its text is
           made): the whole's leading zeros cut but its last digit kept, then the prec
           decimals, each an 8-byte store into buf (~40 instructions, not digits_back's
           loop, the padding's and two copies) */
        uint64_t d = digits8((uint32_t)n), t = d + 0x3030303030303030ULL;
        int lead = __builtin_ctzll(d | 1ULL << 56) >> 3, first = lead < 7 - prec ? lead : 7 - prec;
        char *q = buf;
        if (signbit(x)) *q++ = '-';
        uint64_t w = t >> (8 * first);
        memcpy(q, &w, 8);
        q += 8 - prec - first;
        if (prec) {
            *q++ = '.';
            w = t >> (8 * (8 - prec));
            memcpy(q, &w, 8);
            q += prec;
        }
        *q = 0;
        return (int)(q - buf);
    }
#endif
    char tmp[48], *end = tmp + sizeof tmp, *first = f_digits(end, n);
    while (end - first < prec + 1) *--first = '0';     /* at least "0" before the point */
    char *q = buf;
    if (signbit(x)) *q++ = '-';                       /* "-0.0000" too, as Python writes it */
    q = copy_short(q, first, end - first - prec);
    if (prec) {
        *q++ = '.';
        q = copy_short(q, end - prec, prec);
    }
    *q = 0;
    return (int)(q - buf);
}

static int fmt_f(double x, int prec, char *buf)
{
    uint64_t n;
    return fmt_f_n(x, prec, buf, &n);
}

/* fmt_f_n(x, 8)'s integer (*n) without its text: 0 where fmt_f_n(x, 8) makes one, else -1
   (the same tests).  A start whose both integers are known needs no text (run_block) */
static int start8_of(double x, uint64_t *n)
{
    uint64_t fl;
    return isfinite(x) && scaled_int(x, 8, n, &fl) == 0 ? 0 : -1;
}

/* The first k of 0..7 where floor(|x| 10^k) (scaled_int's fl) is 1000 or more, and its n and
   fl: k; 8 where none is; -1 where scaled_int declines before that k (x finite, not 0).
   The loop k = 0, 1, ... (up to 8 scaled_int calls: the heads' beta ~1e-3 took 7) started
   at log10(|x|)'s estimate from the exponent instead, then moved to that same first k:
   "scaled_int declines or fl >= 1000" holds from some k on (fl grows with k; a decline is
   fl >= 2^64), so the first k is found from either side with a call or two. */
static int g4_scale(double x, uint64_t *n, uint64_t *fl)
{
    int e2 = ilogb(x);                             /* 2^e2 <= |x| < 2^(e2 + 1) */
    int k = 3 - (int)floor(e2 * 0.30102999566398120);
    k = k < 0 ? 0 : k > 7 ? 7 : k;
    int ok = scaled_int(x, k, n, fl) == 0;
    if (!ok || *fl >= 1000) {                      /* the first k is this one or before it */
        while (k > 0) {
            /* (set: where scaled_int declines they are copied out, unread; -O3 warned) */
            uint64_t n1 = 0, fl1 = 0;
            int ok1 = scaled_int(x, k - 1, &n1, &fl1) == 0;
            if (ok1 && fl1 < 1000)
                break;
            k--;
            ok = ok1;
            *n = n1;
            *fl = fl1;
        }
        return ok ? k : -1;
    }
    while (k < 7) {                                /* after it */
        k++;
        if (scaled_int(x, k, n, fl) < 0)
            return -1;
        if (*fl >= 1000)
            return k;
    }
    return 8;
}

/* format(x, ".4g") into buf (at least 64 bytes) where it is written without an exponent
   (1e-4 <= |x| rounded < 1e4): its length, or -1 (declined: zero, not finite, exponent form) */
static int fmt_g4(double x, char *buf)
{
    uint64_t n = 0, fl = 0;
    if (!isfinite(x) || x == 0.0)
        return -1;
    int k = g4_scale(x, &n, &fl);                  /* the k with |x| 10^k in [1000, 10000) */
    if (k < 0 || k > 7 || fl >= 10000)
        return -1;
    int decpt = 4 - k;                             /* x ~ 0.dddd 10^decpt */
    if (n >= 10000) {                              /* 9999.5.. rounded up: "1000", one place on */
        n = 1000;
        decpt++;
    }
    if (decpt <= -4 || decpt > 4)
        return -1;
    char d[4];
    memcpy(d, DIGITS2 + 2 * (n / 100), 2);
    memcpy(d + 2, DIGITS2 + 2 * (n % 100), 2);
    int nd = 4;
    while (nd > 1 && d[nd - 1] == '0') nd--;       /* dtoa's digits: no trailing zeros */
    char *q = buf;
    if (x < 0) *q++ = '-';
    if (decpt <= 0) {
        *q++ = '0';
        *q++ = '.';
        for (int j = 0; j < -decpt; j++) *q++ = '0';
        memcpy(q, d, (size_t)nd);
        q += nd;
    } else if (decpt < nd) {
        memcpy(q, d, (size_t)decpt);
        q += decpt;
        *q++ = '.';
        memcpy(q, d + decpt, (size_t)(nd - decpt));
        q += nd - decpt;
    } else {
        memcpy(q, d, (size_t)nd);
        q += nd;
        for (int j = nd; j < decpt; j++) *q++ = '0';
    }
    *q = 0;
    return (int)(q - buf);
}
#else
static int fmt_f_n(double x, int prec, char *buf, uint64_t *n_out)
{
    (void)x; (void)prec; (void)buf; (void)n_out;
    return -1;
}
static int fmt_f(double x, int prec, char *buf) { (void)x; (void)prec; (void)buf; return -1; }
static int start8_of(double x, uint64_t *n) { (void)x; (void)n; return -1; }
static int fmt_g4(double x, char *buf) { (void)x; (void)buf; return -1; }
#endif

/* PyOS_double_to_string(x, code, prec, 0, NULL)'s text ('f', or 'g' with prec 4) and its
   length (*len): in buf (64 bytes) when fmt_f / fmt_g4 make it, else PyOS_double_to_string's
   own (*own, the caller's to free); NULL on its failure (an exception set) */
static const char *fmt_double(double x, char code, int prec, char *buf, char **own, size_t *len)
{
    *own = NULL;
    int n = code == 'f' ? fmt_f(x, prec, buf) : prec == 4 ? fmt_g4(x, buf) : -1;
    if (n >= 0) {
        *len = (size_t)n;
        return buf;
    }
    if ((*own = PyOS_double_to_string(x, code, prec, 0, NULL)) != NULL)
        *len = strlen(*own);
    return *own;
}

/* The head of a line stroke's block as pipeline._rewrite_bytes' f-string writes it,
     f"{BEGIN}: replaces {n_lines} lines, kind={kind}, {n_segments} segments, "
     f"T={t:.4f}s (was {t_was:.4f}s), beta={f'{beta:.4g}' if isfinite(beta) else 'inf'}s^2\n{svl}"
   from the kind's and svl's texts and the numbers: the floats through
   PyOS_double_to_string, which float.__format__ calls for 'f' and 'g' with a precision.
   In room (room_n bytes) where it fits (no allocation a block), else a PyMem buffer (the
   caller frees a text that is not room), and its length; NULL (no exception): declined. */
/* the decimal text of v (what %lld writes) at p: its length (at most 20) */
static int put_ll(char *p, long long v)
{
    char tmp[24], *end = tmp + sizeof tmp;
    unsigned long long u = v < 0 ? 0ULL - (unsigned long long)v : (unsigned long long)v;
    char *first = digits_back(end, u);            /* (two digits a step) */
    if (v < 0) *--first = '-';
    copy_short(p, first, end - first);
    return (int)(end - first);
}

static char *head_text_of(const char *kp, Py_ssize_t kn, long long n_seg, double t, double t_was, double beta,
                          const char *sp, Py_ssize_t sn, Py_ssize_t n_lines, char *room, size_t room_n,
                          Py_ssize_t *len)
{
    char bt_[64], bw_[64], bb_[64], *ft_own = NULL, *fw_own = NULL, *fb_own = NULL;
    size_t nt = 0, nw = 0, nb = 3;
    const char *ft = fmt_double(t, 'f', 4, bt_, &ft_own, &nt),
               *fw = ft ? fmt_double(t_was, 'f', 4, bw_, &fw_own, &nw) : NULL,
               *fb = fw && isfinite(beta) ? fmt_double(beta, 'g', 4, bb_, &fb_own, &nb) : NULL;
    char *out = NULL;
    if (ft && fw && (fb || !isfinite(beta))) {
        /* the pieces put one after the other (snprintf's "%zd", "%.*s", "%lld", "%s" of
           them: the same bytes, without the format's parsing a block) */
        static const char P0[] = "; gcode-opt begin: replaces ", P1[] = " lines, kind=", P2[] = ", ",
                          P3[] = " segments, T=", P4[] = "s (was ", P5[] = "s), beta=", P6[] = "s^2\n";
        const char *bt = fb ? fb : "inf";       /* (nb: 3 for "inf") */
        size_t cap = nt + nw + nb + (size_t)kn + (size_t)sn + 160;
        out = cap <= room_n ? room : PyMem_Malloc(cap);
        if (out != NULL) {
            char *q = out;
#define PUT(s_, n_) do { memcpy(q, (s_), (n_)); q += (n_); } while (0)
#define PUT_V(s_, n_) do { q = copy_short(q, (s_), (Py_ssize_t)(n_)); } while (0)   /* (short: no call) */
            PUT(P0, sizeof P0 - 1);
            q += put_ll(q, (long long)n_lines);
            PUT(P1, sizeof P1 - 1);
            PUT_V(kp, (size_t)kn);
            PUT(P2, sizeof P2 - 1);
            q += put_ll(q, n_seg);
            PUT(P3, sizeof P3 - 1);
            PUT_V(ft, nt);
            PUT(P4, sizeof P4 - 1);
            PUT_V(fw, nw);
            PUT(P5, sizeof P5 - 1);
            PUT_V(bt, nb);
            PUT(P6, sizeof P6 - 1);
            PUT_V(sp, (size_t)sn);
#undef PUT
#undef PUT_V
            *len = q - out;
        }
    }
    PyMem_Free(ft_own);
    PyMem_Free(fw_own);
    PyMem_Free(fb_own);
    if (PyErr_Occurred())
        PyErr_Clear();         /* (a failed PyOS_double_to_string: declined, no exception) */
    return out;
}

/* head_text_of from spec = (kind, n_segments, t, t_was, beta, svl); NULL (no exception)
   for a spec of other types */
static char *head_text(PyObject *spec, Py_ssize_t n_lines, Py_ssize_t *len)
{
    if (!PyTuple_CheckExact(spec) || PyTuple_GET_SIZE(spec) != 6)
        return NULL;
    PyObject *o_seg = PyTuple_GET_ITEM(spec, 1), *o_t = PyTuple_GET_ITEM(spec, 2),
             *o_tw = PyTuple_GET_ITEM(spec, 3), *o_b = PyTuple_GET_ITEM(spec, 4);
    Py_ssize_t kn = 0, sn = 0;
    const char *kp = ascii(PyTuple_GET_ITEM(spec, 0), &kn), *sp = ascii(PyTuple_GET_ITEM(spec, 5), &sn);
    if (!kp || !sp || !PyLong_CheckExact(o_seg) || !PyFloat_Check(o_t) || !PyFloat_Check(o_tw) || !PyFloat_Check(o_b)
        || memchr(kp, 0, (size_t)kn) != NULL)
        return NULL;
    long long n_seg = PyLong_AsLongLong(o_seg);
    if (n_seg == -1 && PyErr_Occurred()) {
        PyErr_Clear();
        return NULL;
    }
    return head_text_of(kp, kn, n_seg, PyFloat_AS_DOUBLE(o_t), PyFloat_AS_DOUBLE(o_tw), PyFloat_AS_DOUBLE(o_b), sp,
                        sn, n_lines, NULL, 0, len);
}

/* p[0..n) holds a line break of str.splitlines below 0x20 (\r \x0b \x0c \x1c \x1d \x1e):
   8 bytes a step, a byte below 0x20 found by the word's test (exact: no false "none"),
   those 8 bytes then looked at one by one */
static int has_break(const char *p, Py_ssize_t n)
{
    const uint32_t breaks = (1u << 0x0d) | (1u << 0x0b) | (1u << 0x0c) | (1u << 0x1c) | (1u << 0x1d) | (1u << 0x1e);
    const uint64_t ones = 0x0101010101010101ULL, highs = 0x8080808080808080ULL;
    Py_ssize_t k = 0;
    for (; k + 8 <= n; k += 8) {
        uint64_t w;
        memcpy(&w, p + k, sizeof w);
        if (((w - 0x20 * ones) & ~w & highs) == 0)
            continue;                              /* no byte below 0x20 */
        for (int j = 0; j < 8; j++) {
            unsigned char c = (unsigned char)p[k + j];
            if (c < 0x20 && ((breaks >> c) & 1))
                return 1;
        }
    }
    for (; k < n; k++) {
        unsigned char c = (unsigned char)p[k];
        if (c < 0x20 && ((breaks >> c) & 1))
            return 1;
    }
    return 0;
}

/* has_break of a head's first line hp[0..hl): a line break of str.splitlines below 0x20
   (\r \x0b \x0c \x1c \x1d \x1e) in it.  In a head head_text_of wrote from a kind with
   no "\n" (kind->p not NULL), the line's bytes but the kind's are head_text_of's own (words,
   digits, "-", ".", "inf", "nan", "e+"): only the kind's are looked at */
static int head_line_breaks(const Txt *kind, const char *hp, Py_ssize_t hl)
{
    if (kind->p != NULL && memchr(kind->p, '\n', (size_t)kind->n) == NULL)
        return has_break(kind->p, kind->n);
    return has_break(hp, hl);
}

/* 1: block_into's check reads every line of the block (set_text_check, for the tests:
   emit_cols then checks nothing as it writes) */
static int TEXT_CHECK = 0;

/* p[0..n): whole lines (empty, or ending in "\n"), none of them a segment line ("G1 X"):
   their number, else -1 */
static Py_ssize_t other_lines(const char *p, Py_ssize_t n)
{
    Py_ssize_t c = 0;
    if (n == 0)
        return 0;
    if (n < 0 || p[n - 1] != '\n')
        return -1;
    for (const char *e = p + n; p < e; c++) {
        if (e - p >= 4 && memcmp(p, "G1 X", 4) == 0)
            return -1;
        p = (const char *)memchr(p, '\n', (size_t)(e - p)) + 1;
    }
    return c;
}

/* block_into's pieces as fast_check reads them: the head's lines after its first (hl
   bytes), the closing, before and after whole lines with no segment line (other_lines),
   the line end "\n" and the accel word "M204 <letter>": 1, their "\n"s in nl (PieceLines:
   emit_cols takes them, no count of its own), else 0 */
static int piece_lines(const Pieces *pc, Py_ssize_t hl, char letter, Py_ssize_t *nl)
{
    if (pc->nln != 1 || pc->nlp[0] != '\n' || pc->wn != 6 || memcmp(pc->wp, "M204 ", 5) != 0 || pc->wp[5] != letter)
        return 0;
    if ((nl[0] = other_lines(pc->hp + hl + 1, pc->hn - hl - 1)) < 0 || (nl[1] = other_lines(pc->clp, pc->cln)) < 0
        || (nl[2] = pc->bp != NULL ? other_lines(pc->bp, pc->bn) : 0) < 0
        || (nl[3] = pc->ap != NULL ? other_lines(pc->ap, pc->an) : 0) < 0)
        return 0;
    nl[0] += 1;                                   /* (the head's first line) */
    nl[4] = 1;
    nl[5] = 0;
    return 1;
}

/* what block_into reads besides the four sequences (stroke_block's arguments, unpacked) */
typedef struct {
    const char *d;                  /* d[start:stop]: the stroke's n original lines */
    Py_ssize_t start, stop, n;
    Py_ssize_t *stop_at;            /* not NULL: stop is d's end, the n lines' end (found as they
                                       are read) written here when the block is appended */
    Pieces pc;                      /* head, closing, M204 word, before/after (nlp: "\n") */
    Txt x0, y0;                     /* the start's texts */
    Txt kind;                       /* the kind head_text_of wrote in the head (p NULL: a head given) */
    Start8 s8;                      /* and their integers, where they are fmt_f(x, 8)'s */
    const char *wantp;              /* the M204 letter (one character) */
    double x0v, y0v, e0, accel_max_a, min_move_d;
    int e_rel, extruding, klipper;
    Py_ssize_t limit;
} BlockArgs;

/* A line stroke's block appended to out (at out->n): the lines read as emit.StrokeText
   reads plain lines, the block written as emit_stroke writes it and checked as
   validate._fast_ok checks it.  1: appended; 0: declined (out->n as it was, no
   exception); -1: no memory (exception set).  fs: s, accels, feeds, ends_d.  n_lines (not
   NULL): the block's lines ("\n"s) when appended. */
static int block_into(Buf *out, const BlockArgs *ba, const FSeq *fs, Py_ssize_t *n_lines)
{
    const Pieces *pc = &ba->pc;
    const char *d = ba->d;
    Py_ssize_t n = ba->n, start = ba->start, stop = ba->stop, base = out->n;
    if (n < 1 || (ba->stop_at == NULL && (stop - start < 2 || d[stop - 1] != '\n')))
        return 0;
    if (!pc->hp || !pc->clp || !pc->wp || !ba->x0.p || !ba->y0.p || !ba->wantp)
        return 0;
    /* the head line as validate._fast_ok wants it (the caller writes it: its kind is there) */
    static const char BEGIN_R[] = "; gcode-opt begin: replaces ";
    const char *hnl = memchr(pc->hp, '\n', (size_t)pc->hn);
    Py_ssize_t hl = hnl != NULL ? hnl - pc->hp : pc->hn;
    if (hl == pc->hn || hl < (Py_ssize_t)sizeof(BEGIN_R) - 1 || memcmp(pc->hp, BEGIN_R, sizeof(BEGIN_R) - 1) != 0)
        return 0;
    /* no other line break of str.splitlines in it */
    if (head_line_breaks(&ba->kind, pc->hp, hl))
        return 0;
    /* the lines: one allocation for their texts, the path's vertices, their E values,
       their numbers' units and their numbers' decimals */
    char *mem = PyMem_Malloc(n * 4 * sizeof(Txt) + (n + 1) * 2 * sizeof(double) + n * sizeof(double)
                             + n * 3 * sizeof(int64_t) + n * 3 * sizeof(int) + 16);
    if (mem == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    int got = 0;
    Txt *cx = (Txt *)mem, *cy = cx + n, *ce = cx + 2 * n, *cc = cx + 3 * n;
    double *px = (double *)(cx + 4 * n), *py = px + n + 1, *ev_k = py + n + 1;
    uint64_t *ux = (uint64_t *)(ev_k + n), *uy = ux + n, *ue = uy + n;   /* the digits' integers */
    int *dx_k = (int *)(ue + n), *dy_k = dx_k + n, *de_k = dy_k + n;
    int dec_xy = 3, dec_e = 5, d0;
    if ((d0 = ba->s8.known ? start8_decimals(ba->s8.n[0]) : start_decimals(ba->x0.p, ba->x0.n)) > dec_xy) dec_xy = d0;
    if ((d0 = ba->s8.known ? start8_decimals(ba->s8.n[1]) : start_decimals(ba->y0.p, ba->y0.n)) > dec_xy) dec_xy = d0;
    px[0] = ba->x0v;
    py[0] = ba->y0v;
    int path_ok = fabs(ba->x0v) < 1e150 && fabs(ba->y0v) < 1e150;
    double e_sum = 0.0, e_abs = 0.0, e_last = 0.0;
    Py_ssize_t n_e = 0;
    const char *p = d + start, *end = d + stop;
    double v[3] = {0.0, 0.0, 0.0};                /* a line's x, y and e (e: with an E word) */
    uint64_t u[3] = {0, 0, 0};                    /* and their digits' integers */
    for (Py_ssize_t k = 0; k < n; k++) {
        if (p >= end)
            goto decline;
        const char *q = memchr(p, '\n', end - p);
        if (q == NULL)
            goto decline;
        Py_ssize_t m = q - p;
        /* (plain_line takes only ASCII lines with no line break but the "\r" of "\r\n") */
        if (k == 0 && m > 0 && p[m - 1] == '\r')  /* the block's line end is the first line's */
            goto decline;
        int dx, dy, de;
        if (!plain_line(p, m, &cx[k], &cy[k], &ce[k], &cc[k], &dx, &dy, &de, v, u))
            goto decline;
        if (dx > dec_xy) dec_xy = dx;
        if (dy > dec_xy) dec_xy = dy;
        if (de > dec_e) dec_e = de;
        dx_k[k] = dx;
        dy_k[k] = dy;
        ux[k] = u[0];
        uy[k] = u[1];
        double xv = v[0], yv = v[1];
        px[k + 1] = xv;
        py[k + 1] = yv;
        if (!(fabs(xv) < 1e150 && fabs(yv) < 1e150))
            path_ok = 0;
        if (ce[k].p != NULL) {
            double ev = v[2];
            if (!isfinite(ev))
                goto decline;
            e_sum += ev;
            e_abs += fabs(ev);
            e_last = ev;
            n_e++;
            ev_k[k] = ev;
            de_k[k] = de;
            ue[k] = u[2];
        } else {
            ce[k].p = "0";                        /* StrokeText's e text of a line without E */
            ce[k].n = 1;
            ev_k[k] = 0.0;
            de_k[k] = 0;
            ue[k] = 0;
        }
        p = q + 1;
    }
    /* (stop_at: the n lines read end at p, each at a "\n" -- a lone "\r" in one is not a
       plain line's: skip_lines' n lines from start, the same end) */
    if ((ba->stop_at != NULL ? p - (d + start) < 2 : p != end) || !path_ok || dec_e > 15)
        goto decline;
    Py_ssize_t z = p - d;
    ColUnits cu = {{ux, uy, ue}, {dx_k, dy_k, de_k}};
    /* st_text.e_start_units = int(round(e0 * 10 ** dec_e)) */
    int64_t e_start_u;
    if (py_round(ba->e0 * POW10[dec_e], &e_start_u) < 0)
        goto decline;
    /* emit_cols checks the lines it writes when fast_check would read its accel lines as
       accel lines and no other line is a segment line (they are read, the state emit_cols
       leaves taken on: the same checks in the same order), each piece whole lines */
    Known kn = {{1, px, py, n + 1, 1, 2e-3, px[0], py[0], INFINITY, 0, 0.0, 0.0, 0.0, 0},
                ba->accel_max_a + 0.1 + 1e-9, ba->limit, px + 1, py + 1, ev_k, dx_k, dy_k, de_k, {{0}}, 0, 0};
    Py_ssize_t nl[PIECES];
    int by_text = TEXT_CHECK || !piece_lines(pc, hl, ba->wantp[0], nl);
    int r = emit_cols(out, pc, cx, cy, ce, cc, n, &fs[0], &fs[1], &fs[2], &fs[3], dec_xy, dec_e, ba->e_rel,
                      ba->extruding, e_start_u, &ba->x0, &ba->y0, &ba->s8, &cu, by_text ? NULL : nl, n_lines,
                      by_text ? NULL : &kn);
    if (r < 0) {
        PyErr_NoMemory();
        got = -1;
        goto done;
    }
    if (r == 0) {
        /* validate._fast_ok: the end line, then the column pass over the body */
        static const char END_L[] = "\n; gcode-opt end\n";
        Py_ssize_t el = (Py_ssize_t)sizeof(END_L) - 1, bn = out->n - base;
        const char *bp = out->p + base;
        int e_mode = 0;
        double e_value = 0.0, e_err = 0.0;
        if (ba->extruding && n_e > 0) {
            e_mode = ba->e_rel ? 1 : 2;
            if (ba->e_rel) {          /* fsum's value within e_err of the running sum */
                e_value = e_sum;
                e_err = 2.0 * (double)n_e * 1.1102230246251565e-16 * e_abs + 1e-300;
            } else
                e_value = e_last;
        }
        if (bn > hl + el && memcmp(bp + bn - el, END_L, el) == 0
            && fast_check(bp, hl, bn - el + 1, ba->wantp[0], ba->klipper, ba->limit, ba->accel_max_a, 1, px, py, n + 1,
                          2e-3, e_mode, e_value, e_err, ba->min_move_d, by_text ? NULL : &kn, base)) {
            if (ba->stop_at != NULL)
                *ba->stop_at = z;
            got = 1;
            goto done;
        }
    }
decline:
    out->n = base;
done:
    PyMem_Free(mem);
    return got;
}

/* the ctx tuple (accel_word, want, klipper, limit, min_move_d) into ba: 0, or -1 (no
   exception): not such a tuple */
static int ctx_into(PyObject *ctx, BlockArgs *ba)
{
    if (!PyTuple_CheckExact(ctx) || PyTuple_GET_SIZE(ctx) != 5)
        return -1;
    Py_ssize_t wl = 0;
    int bad = 0;
    ba->pc.wp = ascii(PyTuple_GET_ITEM(ctx, 0), &ba->pc.wn);
    ba->wantp = ascii(PyTuple_GET_ITEM(ctx, 1), &wl);
    ba->klipper = PyObject_IsTrue(PyTuple_GET_ITEM(ctx, 2));
    ba->limit = PyLong_AsSsize_t(PyTuple_GET_ITEM(ctx, 3));
    ba->min_move_d = arg_double(PyTuple_GET_ITEM(ctx, 4), &bad);
    if (bad || !ba->pc.wp || !ba->wantp || wl != 1 || ba->klipper < 0 || (ba->limit == -1 && PyErr_Occurred())) {
        PyErr_Clear();
        return -1;
    }
    return 0;
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
    PyObject *data = args[0];
    if (!PyBytes_CheckExact(data))
        Py_RETURN_NONE;
    BlockArgs ba;
    memset(&ba, 0, sizeof ba);
    ba.start = PyLong_AsSsize_t(args[1]);
    ba.stop = PyLong_AsSsize_t(args[2]);
    ba.n = PyLong_AsSsize_t(args[3]);
    if (PyErr_Occurred()) {
        PyErr_Clear();
        Py_RETURN_NONE;
    }
    ba.d = PyBytes_AS_STRING(data);
    if (ba.start < 0 || ba.stop > PyBytes_GET_SIZE(data) || ba.n < 1 || ba.stop - ba.start < 2
        || ba.d[ba.stop - 1] != '\n' || ctx_into(args[19], &ba) < 0)
        Py_RETURN_NONE;
    char *own_head = NULL, *own_x0 = NULL, *own_y0 = NULL;     /* texts made here (freed at the end) */
    if (PyTuple_CheckExact(args[4])) {
        if ((own_head = head_text(args[4], ba.n, &ba.pc.hn)) == NULL)
            Py_RETURN_NONE;
        ba.pc.hp = own_head;
    } else
        ba.pc.hp = ascii(args[4], &ba.pc.hn);
    char x0b[64], y0b[64];
    const char *x0s = NULL, *y0s = NULL;
    size_t x0n = 0, y0n = 0;
    if (args[8] == Py_None && args[9] == Py_None) {
        double xv = PyFloat_AsDouble(args[10]), yv = PyFloat_AsDouble(args[11]);
        if (!PyErr_Occurred()) {
            x0s = fmt_double(xv, 'f', 8, x0b, &own_x0, &x0n);
            y0s = fmt_double(yv, 'f', 8, y0b, &own_y0, &y0n);
        }
        PyErr_Clear();
    }
    PyObject *res = NULL;
    FSeq fs[4];
    for (int i = 0; i < 4; i++)
        memset(&fs[i], 0, sizeof fs[i]);
    ba.pc.clp = ascii(args[5], &ba.pc.cln);
    ba.pc.nlp = "\n";
    ba.pc.nln = 1;
    if (args[6] != Py_None
        && ((ba.pc.bp = ascii(args[6], &ba.pc.bn)) == NULL || (ba.pc.ap = ascii(args[7], &ba.pc.an)) == NULL))
        goto decline;
    if (x0s != NULL && y0s != NULL) {
        ba.x0.p = x0s;
        ba.x0.n = (Py_ssize_t)x0n;
        ba.y0.p = y0s;
        ba.y0.n = (Py_ssize_t)y0n;
    } else {
        ba.x0.p = ascii(args[8], &ba.x0.n);
        ba.y0.p = ascii(args[9], &ba.y0.n);
    }
    if (!PyFloat_CheckExact(args[12]))
        goto decline;
    int bad = 0;
    ba.x0v = arg_double(args[10], &bad);
    ba.y0v = arg_double(args[11], &bad);
    ba.e0 = PyFloat_AS_DOUBLE(args[12]);
    ba.accel_max_a = arg_double(args[20], &bad);
    ba.e_rel = PyObject_IsTrue(args[17]);
    ba.extruding = PyObject_IsTrue(args[18]);
    if (bad || ba.e_rel < 0 || ba.extruding < 0) {
        PyErr_Clear();
        goto decline;
    }
    if (fseq_get(args[13], &fs[0], 1) < 0 || fseq_get(args[14], &fs[1], 1) < 0 || fseq_get(args[15], &fs[2], 1) < 0
        || fseq_get(args[16], &fs[3], 1) < 0)
        goto decline;
    /* one buffer for every block, kept between calls */
    Buf b = EMIT_BUF;
    b.n = 0;
    int r = block_into(&b, &ba, fs, NULL);
    if (r > 0)
        res = PyBytes_FromStringAndSize(b.p, b.n);
    keep_buf(&b);
    if (res != NULL || r < 0)
        goto done;
decline:
    res = Py_NewRef(Py_None);
done:
    for (int i = 0; i < 4; i++)
        fseq_release(&fs[i]);
    PyMem_Free(own_head);
    PyMem_Free(own_x0);
    PyMem_Free(own_y0);
    return res;
}

/* ---------------------------------------------------------------- stroke_run */

/* the attribute names stroke_run reads (interned once) */
enum { A_FIRST, A_LAST, A_KIND, A_X0, A_Y0, A_SS_E, A_SS_A, A_SS_C, A_ENDS, A_LENGTH, A_E_REL, A_FEATURE,
       A_V_FEED, A_TIME, A_S, A_ACCEL, A_FEED, A_FIRST_CMDS, A_COPY, A_UPDATE, A_DIGEST, A_ROW, A_FROMBYTES, N_NAMES };
static const char *const NAME_TEXT[N_NAMES] = {"first_idx", "last_idx", "kind", "x0", "y0", "_ss_e", "_ss_a",
    "_ss_c", "_ends", "length_d", "e_rel", "feature", "v_feed", "time_t", "_s", "_accel", "_feed", "first_cmds",
    "copy", "update", "digest", "_row", "frombytes"};
static PyObject *NAMES[N_NAMES];

static int names_ready(void)
{
    for (int k = 0; k < N_NAMES; k++)
        if (NAMES[k] == NULL && (NAMES[k] = PyUnicode_InternFromString(NAME_TEXT[k])) == NULL)
            return -1;
    return 0;
}

/* Attribute reads by the type's own data descriptor: PyObject_GetAttr's result where the
   type reads attributes generically (PyObject_GenericGetAttr), for that takes a data
   descriptor found on the type (a __slots__ member, a C getter, a property) before anything
   else and returns its __get__(o, type).  The descriptor found is kept with the type's
   version tag, which Python changes whenever the type or a base is modified: a stale entry
   is never used.  Other types and names: PyObject_GetAttr.
   Two descriptors are read without their __get__ (~17 reads a stroke): an object member
   (a __slots__ slot, T_OBJECT_EX) by its offset, as member_get reads it when set (unset:
   __get__, for its AttributeError); a C getter (StrokeBase's doubles) called as getset_get
   calls it.  Both only where __get__'s own type check passed for the type when the slot was
   filled (the type's MRO is part of what its tag stands for). */
#if PY_VERSION_HEX >= 0x030A0000 && PY_VERSION_HEX < 0x030E0000 && !defined(Py_GIL_DISABLED)
#define ATTR_CACHE 1
#include <structmember.h>           /* T_OBJECT_EX, READONLY */
typedef struct {
    PyTypeObject *type;             /* (not a reference: compared, and used only while tag holds) */
    unsigned int tag;
    PyObject *descr;                /* borrowed from the type's dict, valid while tag holds */
    descrgetfunc get;
    Py_ssize_t slot_off;            /* > 0: an object member at this offset in the object, else 0 */
    getter gs_get;                  /* a C getter (with gs_closure), else NULL */
    void *gs_closure;
} AttrSlot;
#define ATTR_WAYS 4
static AttrSlot ATTR_SLOTS[N_NAMES][ATTR_WAYS];   /* a name read on a few types (Stroke, SegmentPlan, RowPlan) */
static unsigned int ATTR_NEXT[N_NAMES];           /* the slot a miss takes when none is free */

static inline int tag_valid(PyTypeObject *tp, unsigned int tag)
{
    return tag != 0 && tp->tp_version_tag == tag && PyType_HasFeature(tp, Py_TPFLAGS_VALID_VERSION_TAG);
}

/* d.__get__(o, type(o)), d held for the call (as the generic getattr holds it) */
static inline PyObject *descr_get(PyObject *d, descrgetfunc get, PyObject *o)
{
    Py_INCREF(d);
    PyObject *r = get(d, o, (PyObject *)Py_TYPE(o));
    Py_DECREF(d);
    return r;
}

/* at's direct read of d (its member's offset, or its C getter) where d.__get__(o, type(o))
   is exactly that read for o's type; else neither */
static void fill_direct(AttrSlot *at, PyObject *d, PyObject *o)
{
    at->slot_off = 0;
    at->gs_get = NULL;
    at->gs_closure = NULL;
    if (!PyObject_TypeCheck(o, PyDescr_TYPE(d)))
        return;
    if (Py_IS_TYPE(d, &PyMemberDescr_Type)) {
        PyMemberDef *mb = ((PyMemberDescrObject *)d)->d_member;
        if (mb->type == T_OBJECT_EX && (mb->flags & ~READONLY) == 0 && mb->offset > 0)
            at->slot_off = mb->offset;
    } else if (Py_IS_TYPE(d, &PyGetSetDescr_Type)) {
        PyGetSetDef *gs = ((PyGetSetDescrObject *)d)->d_getset;
        if (gs->get != NULL) {
            at->gs_get = gs->get;
            at->gs_closure = gs->closure;
        }
    }
}

static __attribute__((noinline)) PyObject *get_attr_ways(PyObject *o, int name)
{
    PyTypeObject *tp = Py_TYPE(o);
    AttrSlot *sl = ATTR_SLOTS[name];
    for (int k = 0; k < ATTR_WAYS; k++)
        if (sl[k].type == tp && tag_valid(tp, sl[k].tag)) {
            if (sl[k].slot_off > 0) {
                PyObject *v = *(PyObject **)((char *)o + sl[k].slot_off);
                if (v != NULL)
                    return Py_NewRef(v);
            } else if (sl[k].gs_get != NULL)
                return sl[k].gs_get(o, sl[k].gs_closure);
            return descr_get(sl[k].descr, sl[k].get, o);
        }
    if (tp->tp_getattro == PyObject_GenericGetAttr) {
        PyObject *d = _PyType_Lookup(tp, NAMES[name]);      /* (borrowed; gives the type a tag) */
        if (d != NULL && Py_TYPE(d)->tp_descr_get != NULL && Py_TYPE(d)->tp_descr_set != NULL
            && tag_valid(tp, tp->tp_version_tag)) {
            AttrSlot *at = NULL;
            for (int k = 0; k < ATTR_WAYS && at == NULL; k++)     /* this type's stale slot, or a free one */
                if (sl[k].type == tp || sl[k].type == NULL)
                    at = &sl[k];
            if (at == NULL)
                at = &sl[ATTR_NEXT[name]++ % ATTR_WAYS];
            at->type = tp;
            at->tag = tp->tp_version_tag;
            at->descr = d;
            at->get = Py_TYPE(d)->tp_descr_get;
            fill_direct(at, d, o);
            return descr_get(d, at->get, o);
        }
    }
    return PyObject_GetAttr(o, NAMES[name]);
}

/* get_attr_ways' read where name's first way holds o's type and a member slot that is set
   (most of a run's ~17 reads a stroke: the call's entry and exit cost more than the read),
   inline; the rest by the call */
static inline __attribute__((always_inline)) PyObject *get_attr(PyObject *o, int name)
{
    PyTypeObject *tp = Py_TYPE(o);
    const AttrSlot *sl = &ATTR_SLOTS[name][0];
    if (sl->type == tp && sl->slot_off > 0 && tag_valid(tp, sl->tag)) {
        PyObject *v = *(PyObject **)((char *)o + sl->slot_off);
        if (v != NULL)
            return Py_NewRef(v);
    }
    return get_attr_ways(o, name);
}

/* The compiled firmware core's StrokeBase fields read in place (its "_STROKE_FIELDS"
   capsule: the layout, and the getters that read them as objects): a double or int field
   of a stroke whose attribute slot holds that module's getter is read from the stroke
   itself, not as the new float or int the getter makes (~5 a stroke in a run: each a
   call, an allocation and its release).  The same value: the getter's own tests (the
   field's bit in odd: an object kept aside, read as an object; has: None) made here. */
static const StrokeFieldsAPI *STROKE_FIELDS = NULL;      /* (its layout: _strokefields.h) */

/* STROKE_FIELDS from the firmware core, if it is imported (not imported here) and its
   capsule is of this version; NULL else, no exception */
static void stroke_fields_ready(void)
{
    if (STROKE_FIELDS != NULL)
        return;
    PyObject *name = PyUnicode_FromString("_gcode_opt_fwcore"), *m = NULL, *cap = NULL;
    if (name != NULL && (m = PyImport_GetModule(name)) != NULL
        && (cap = PyObject_GetAttrString(m, "_STROKE_FIELDS")) != NULL) {
        const StrokeFieldsAPI *api = PyCapsule_GetPointer(cap, "_gcode_opt_fwcore._STROKE_FIELDS");
        if (api != NULL && api->version == 1)
            STROKE_FIELDS = api;
    }
    Py_XDECREF(cap);
    Py_XDECREF(m);
    Py_XDECREF(name);
    PyErr_Clear();
}

/* the way of name's slots that holds o's type with a valid tag and getter get (NULL: none) */
static inline const AttrSlot *getter_way(PyObject *o, int name, getter get)
{
    PyTypeObject *tp = Py_TYPE(o);
    for (int k = 0; k < ATTR_WAYS; k++) {
        const AttrSlot *sl = &ATTR_SLOTS[name][k];
        if (sl->type == tp)
            return sl->gs_get == get && tag_valid(tp, sl->tag) ? sl : NULL;
    }
    return NULL;
}

/* o's double field name read in place: 1 (*x its value, 0.0 and *none 1 for None), or 0
   (not a StrokeBase double read so: get_attr reads it, filling its slot the first time) */
static inline int stroke_double(PyObject *o, int name, double *x, int *none)
{
    const StrokeFieldsAPI *f = STROKE_FIELDS;
    const AttrSlot *sl = f != NULL ? getter_way(o, name, f->sd_get) : NULL;
    if (sl == NULL)
        return 0;
    int k = (int)(intptr_t)sl->gs_closure;
    const char *b = (const char *)o;
    unsigned int odd = *(const unsigned int *)(b + f->off_odd), has = *(const unsigned int *)(b + f->off_has);
    if (k < 0 || k >= f->sd_n || (odd >> k) & 1)
        return 0;
    *none = k >= f->sd_none0 && !((has >> (k - f->sd_none0)) & 1);
    *x = *none ? 0.0 : ((const double *)(b + f->off_d))[k];
    return 1;
}

/* o's int field name read in place: 1 (*x), or 0 (as stroke_double's) */
static inline int stroke_int(PyObject *o, int name, long long *x)
{
    const StrokeFieldsAPI *f = STROKE_FIELDS;
    const AttrSlot *sl = f != NULL ? getter_way(o, name, f->si_get) : NULL;
    if (sl == NULL)
        return 0;
    int k = (int)(intptr_t)sl->gs_closure;
    const char *b = (const char *)o;
    unsigned int odd = *(const unsigned int *)(b + f->off_odd);
    if (k < 0 || k >= f->si_n || (odd >> (f->sd_n + k)) & 1)
        return 0;
    *x = ((const long long *)(b + f->off_i))[k];
    return 1;
}
#else
static PyObject *get_attr(PyObject *o, int name)
{
    return PyObject_GetAttr(o, NAMES[name]);
}
static void stroke_fields_ready(void) {}
static inline int stroke_double(PyObject *o, int name, double *x, int *none)
{
    (void)o; (void)name; (void)x; (void)none;
    return 0;
}
static inline int stroke_int(PyObject *o, int name, long long *x)
{
    (void)o; (void)name; (void)x;
    return 0;
}
#endif

/* the lines after pos in d[0:len): skip_lines(d, pos, n, False)'s (end, got) */
static Py_ssize_t skip_n(const char *d, Py_ssize_t len, Py_ssize_t pos, Py_ssize_t n, Py_ssize_t *got)
{
    const char *e = d + len;
    *got = 0;
    while (*got < n && pos < len) {
        const char *q = line_break_at(d + pos, e);
        if (q == e)
            return len;
        pos = q - d + 1;
        if (*q == '\r' && pos < len && d[pos] == '\n')
            pos++;
        (*got)++;
    }
    return pos;
}

/* closing_text's last call in a run: its arguments and text (references).  closing_text
   is emit._closing_text, lru-cached: called again with the same arguments (the same
   objects, or floats of the same bits: the same key) and nothing called in between, it
   returns that same text object, which is returned here without the call. */
typedef struct {
    PyObject *arg[6];
    PyObject *res;                  /* NULL: no call kept */
} ClosingMemo;

static inline int same_arg(PyObject *a, PyObject *b)
{
    if (a == b)
        return 1;
    if (!PyFloat_CheckExact(a) || !PyFloat_CheckExact(b))
        return 0;
    double x = PyFloat_AS_DOUBLE(a), y = PyFloat_AS_DOUBLE(b);
    return memcmp(&x, &y, sizeof x) == 0;
}

static void memo_clear(ClosingMemo *m)
{
    if (m->res == NULL)
        return;
    for (int k = 0; k < 6; k++)
        Py_CLEAR(m->arg[k]);
    Py_CLEAR(m->res);
}

/* closing_text(*args) (6 of them): a new reference, or NULL (an exception) */
static PyObject *closing_call(ClosingMemo *m, PyObject *fn, PyObject *const *args)
{
    if (m->res != NULL) {
        int k = 0;
        while (k < 6 && same_arg(m->arg[k], args[k])) k++;
        if (k == 6)
            return Py_NewRef(m->res);
    }
    PyObject *r = PyObject_Vectorcall(fn, args, 6, NULL);
    memo_clear(m);
    if (r != NULL) {
        for (int k = 0; k < 6; k++)
            m->arg[k] = Py_NewRef(args[k]);
        m->res = Py_NewRef(r);
    }
    return r;
}

/* the run's fixed arguments */
typedef struct {
    PyObject *strokes, *segs, *betas, *stroke_type, *seg_type, *row_type, *k_arc, *travel, *closing_text, *flavour, *nl,
             *svl, *digests, *blake2b;
    PyObject *ctx_o[2];             /* ctx[False], ctx[True] */
    BlockArgs ctx[2];               /* their unpacked fields */
    double max_accel_a;
    ClosingMemo memo;
} RunArgs;

/* an attribute that must be a float: its value; bad set (no exception) otherwise */
static double float_attr(PyObject *o, int name, int *bad)
{
    double x = 0.0;
    int none;
    if (stroke_double(o, name, &x, &none)) {      /* (None is not a float) */
        *bad |= none;
        return x;
    }
    PyObject *v = get_attr(o, name);
    if (v != NULL && PyFloat_CheckExact(v))
        x = PyFloat_AS_DOUBLE(v);
    else {
        PyErr_Clear();
        *bad = 1;
    }
    Py_XDECREF(v);
    return x;
}

/* one stroke of the run, its n lines from d[a] (d[0:len): the data), appended to out as
   pipeline._rewrite_bytes' one-call path writes it: 1; 0: not this stroke (out as it
   was: pipeline's loop takes it); -1: an exception.  *n_lines: the block's lines; *z:
   the end of its n lines in d (block_into finds it as it reads them) */
static int run_block(Buf *out, RunArgs *ra, PyObject *s, PyObject *seg, PyObject *beta_o, PyObject *kind,
                     const char *d, Py_ssize_t a, Py_ssize_t len, Py_ssize_t n, Py_ssize_t *n_lines, Py_ssize_t *z)
{
    PyObject *obj[24];              /* references held (at most 22): obj[0..no), freed at the end */
    int no = 0, got = 0, bad = 0, rows_read = 0;
    FSeq fs[4];
    char *head = NULL, *x0t = NULL, *y0t = NULL, head_room[512];   /* (the head in head_room where it fits) */
    for (int k = 0; k < 4; k++)
        memset(&fs[k], 0, sizeof fs[k]);
#define GET(var, o, name) do { if ((var = obj[no++] = get_attr(o, name)) == NULL) goto decline; } while (0)
    PyObject *e0_o = NULL, *a0_o, *c0_o, *ends, *e_rel_o, *feature, *v_feed, *knots, *acc, *fd, *fc, *t_was_o = NULL,
             *t_o;
    /* the start's e and the stroke's time: read in place where they are StrokeBase's doubles
       (stroke_double: no float made), else as objects */
    double e0 = 0.0, t_was = 0.0;
    int e0_none = 0, t_none = 0;
    int e0_in = stroke_double(s, A_SS_E, &e0, &e0_none), t_in = stroke_double(s, A_TIME, &t_was, &t_none);
    if (!e0_in)
        GET(e0_o, s, A_SS_E);
    GET(a0_o, s, A_SS_A);
    GET(c0_o, s, A_SS_C);
    GET(ends, s, A_ENDS);
    GET(e_rel_o, s, A_E_REL);
    GET(feature, s, A_FEATURE);
    GET(v_feed, s, A_V_FEED);
    if (!t_in)
        GET(t_was_o, s, A_TIME);
    GET(knots, seg, A_S);
    GET(acc, seg, A_ACCEL);
    GET(fd, seg, A_FEED);
    GET(fc, seg, A_FIRST_CMDS);
    GET(t_o, seg, A_TIME);
    if (ra->row_type != NULL && Py_IS_TYPE(seg, (PyTypeObject *)ra->row_type)) {
        PyObject *row;             /* a RowPlan: its arrays are that row of its blocks (its s, accel, feed) */
        GET(row, seg, A_ROW);
        if (row != Py_None) {
            if (!PyLong_CheckExact(row))
                goto decline;
            Py_ssize_t r = PyLong_AsSsize_t(row);
            if (r == -1 && PyErr_Occurred())
                PyErr_Clear();
            /* the rows read where they are; else the row views (numpy's indexing).  Knots
               that are an array.array are not a block: its stroke's ends_d, the knots 0
               then those (segments.RowPlan) */
            int from_ends = ARRAY_TYPE != NULL && Py_IS_TYPE(knots, (PyTypeObject *)ARRAY_TYPE);
            if ((from_ends ? fseq_array(knots, &fs[0], 1) : fseq_row(knots, r, &fs[0])) == 0
                && fseq_row(acc, r, &fs[1]) == 0 && fseq_row(fd, r, &fs[2]) == 0)
                rows_read = 1;
            else if (from_ends)
                goto decline;
            else if ((knots = obj[no++] = PyObject_GetItem(knots, row)) == NULL
                     || (acc = obj[no++] = PyObject_GetItem(acc, row)) == NULL
                     || (fd = obj[no++] = PyObject_GetItem(fd, row)) == NULL)
                goto decline;
        }
    }
#undef GET
    if ((e0_in ? e0_none : e0_o == Py_None || !PyFloat_CheckExact(e0_o)) || !PyFloat_CheckExact(a0_o)
        || !PyFloat_Check(t_o) || (t_in ? t_none : !PyFloat_Check(t_was_o)) || !PyFloat_Check(beta_o))
        goto decline;
    if (!e0_in)
        e0 = PyFloat_AS_DOUBLE(e0_o);
    if (!t_in)
        t_was = PyFloat_AS_DOUBLE(t_was_o);
    if (ends == Py_None) {        /* one move: ends_d's (length_d,) */
        double len_d = float_attr(s, A_LENGTH, &bad);
        if (bad)
            goto decline;
        fs[3].own = PyMem_Malloc(sizeof(double));
        if (fs[3].own == NULL)
            goto decline;
        fs[3].own[0] = len_d;
        fs[3].d = fs[3].own;
        fs[3].n = 1;
    } else if (PyBytes_Check(ends) || fseq_get(ends, &fs[3], 1) < 0)
        goto decline;
    /* (bytes are not a plan's arrays: len() of them is not the doubles' count) */
    if (!rows_read && (PyBytes_Check(knots) || PyBytes_Check(acc) || PyBytes_Check(fd) || fseq_get(knots, &fs[0], 1) < 0
                       || fseq_get(acc, &fs[1], 1) < 0 || fseq_get(fd, &fs[2], 1) < 0))
        goto decline;
    int travel = str_eq(feature, ra->travel);
    int extruding = travel >= 0 ? !travel : PyObject_RichCompareBool(feature, ra->travel, Py_NE),
        e_rel = PyObject_IsTrue(e_rel_o);
    if (extruding < 0 || e_rel < 0) {
        PyErr_Clear();
        goto decline;
    }
    BlockArgs ba = ra->ctx[extruding];
    ba.d = d;
    ba.start = a;
    ba.stop = len;
    ba.stop_at = z;
    ba.n = n;
    ba.e0 = e0;
    ba.e_rel = e_rel;
    ba.extruding = extruding;
    double accel0 = PyFloat_AS_DOUBLE(a0_o);
    /* max(max_accel_a, accel0) if isfinite(accel0) else max_accel_a */
    ba.accel_max_a = isfinite(accel0) && accel0 > ra->max_accel_a ? accel0 : ra->max_accel_a;
    ba.x0v = float_attr(s, A_X0, &bad);
    ba.y0v = float_attr(s, A_Y0, &bad);
    if (bad)
        goto decline;
    /* the start's texts, f"{x0:.8f}", stand in block_into and emit_cols by their integers
       (ba.s8) where fmt_f makes both: then no text is made (block_into and emit_cols read
       the texts only without s8.known; ~250 instructions a stroke).  Else the texts:
       fmt_f's, else PyOS_double_to_string's */
    char x0b[64], y0b[64];
    ba.s8.known = start8_of(ba.x0v, &ba.s8.n[0]) == 0 && start8_of(ba.y0v, &ba.s8.n[1]) == 0;
    ba.s8.neg[0] = signbit(ba.x0v) != 0;
    ba.s8.neg[1] = signbit(ba.y0v) != 0;
    if (ba.s8.known) {
        ba.x0.p = ba.y0.p = "";          /* (not read: s8's integers are their numbers) */
        ba.x0.n = ba.y0.n = 0;
    } else {
        int nx0 = fmt_f_n(ba.x0v, 8, x0b, &ba.s8.n[0]), ny0 = fmt_f_n(ba.y0v, 8, y0b, &ba.s8.n[1]);
        if ((ba.x0.p = nx0 >= 0 ? x0b : (x0t = PyOS_double_to_string(ba.x0v, 'f', 8, 0, NULL))) == NULL
            || (ba.y0.p = ny0 >= 0 ? y0b : (y0t = PyOS_double_to_string(ba.y0v, 'f', 8, 0, NULL))) == NULL) {
            PyErr_Clear();
            goto decline;
        }
        ba.x0.n = nx0 >= 0 ? nx0 : (Py_ssize_t)strlen(ba.x0.p);
        ba.y0.n = ny0 >= 0 ? ny0 : (Py_ssize_t)strlen(ba.y0.p);
    }
    Py_ssize_t kn = 0, sn = 0;
    const char *kp = ascii(kind, &kn), *sp = ascii(ra->svl, &sn);
    if (kp == NULL || sp == NULL || memchr(kp, 0, (size_t)kn) != NULL   /* (snprintf's "%.*s" stopped there) */
        || (head = head_text_of(kp, kn, (long long)fs[0].n - 1, PyFloat_AS_DOUBLE(t_o), t_was,
                                PyFloat_AS_DOUBLE(beta_o), sp, sn, n, head_room, sizeof head_room, &ba.pc.hn)) == NULL)
        goto decline;
    ba.pc.hp = head;
    ba.kind.p = kp;
    ba.kind.n = kn;
    /* closing_text(flavour, accel0, extruding, mcr0, v_feed, "\n") (lru-cached in emit.py) */
    PyObject *cargs[6] = {ra->flavour, a0_o, extruding ? Py_True : Py_False, c0_o, v_feed, ra->nl};
    PyObject *closing = obj[no++] = closing_call(&ra->memo, ra->closing_text, cargs);
    if (closing == NULL || (ba.pc.clp = ascii(closing, &ba.pc.cln)) == NULL) {
        PyErr_Clear();
        goto decline;
    }
    /* first_cmds' lines around the first move: fc[0] + "\n", fc[1] + "\n" when fc and two knots */
    if (fc != Py_None) {
        int t = PyObject_IsTrue(fc);
        if (t < 0) {
            PyErr_Clear();
            goto decline;
        }
        if (t && fs[0].n >= 2) {
            PyObject *f0, *f1, *bf, *af;
            if ((f0 = obj[no++] = PySequence_GetItem(fc, 0)) == NULL || (f1 = obj[no++] = PySequence_GetItem(fc, 1)) == NULL
                || (bf = obj[no++] = PyNumber_Add(f0, ra->nl)) == NULL || (af = obj[no++] = PyNumber_Add(f1, ra->nl)) == NULL
                || (ba.pc.bp = ascii(bf, &ba.pc.bn)) == NULL || (ba.pc.ap = ascii(af, &ba.pc.an)) == NULL) {
                PyErr_Clear();
                goto decline;
            }
        }
    }
    got = block_into(out, &ba, fs, n_lines);
    goto done;
decline:
    PyErr_Clear();
    got = 0;
done:
    for (int k = 0; k < 4; k++)
        fseq_release(&fs[k]);
    for (int k = 0; k < no; k++)
        Py_XDECREF(obj[k]);
    if (head != head_room)
        PyMem_Free(head);
    PyMem_Free(x0t);
    PyMem_Free(y0t);
    return got;
}

/* stroke_run(data, pos, line, order, k, out_line, out_ranges, strokes, segs, betas, stroke_type, seg_type,
              k_arc, travel, closing_text, flavour, svl, ctx_false, ctx_true, max_accel_a, digests, blake2b,
              write)
   pipeline._rewrite_bytes' loop over order[k:] in one call, for as long as each stroke is
   a line stroke of the exact Stroke and SegmentPlan types whose untouched lines before it
   and own lines are whole in data (from byte pos; line: the input line at pos) and whose
   block block_into writes.  For each: the untouched lines and the block appended to one
   buffer, (out_first, out_last, order[k]) appended to out_ranges -- a list: that tuple; a
   tuple of three array('q') (outranges.OutRanges' columns): each number to its column, by
   one frombytes a column at the end of the call (no tuple, int or gc-tracked object a
   row: their allocations ran the young generation's collections) -- and, digests not None,
   digests[order[k]] = blake2b(block, digest_size=16).digest() (blake2b: the hash of
   nothing, blake2b(digest_size=16), copied for each block).  Stops at the first stroke
   it does not take (pipeline's loop takes that one, from its first untouched line on).
   The buffer goes to write (a memoryview of it, released after the call) a MB at a time
   and at the end: no bytes object of the run's output, and a bounded buffer.
   Returns (k, pos, line, out_line). */
#define RUN_FLUSH (1 << 20)

/* v appended to a column of int64s (out_ranges' rows as stroke_run takes them as
   columns): 0, or -1 (no memory).  The store inline, buf_grow only when full */
static inline int col_put(Buf *b, Py_ssize_t v)
{
    int64_t x = (int64_t)v;
    if (b->n + (Py_ssize_t)sizeof x > b->cap && buf_grow(b, (Py_ssize_t)sizeof x) < 0)
        return -1;
    memcpy(b->p + b->n, &x, sizeof x);
    b->n += (Py_ssize_t)sizeof x;
    return 0;
}

/* cols[c].frombytes(the int64s of col[c]) for each column with any, the exception in
   force (if any) kept: 0, or -1 (frombytes' exception, which then is the one in force) */
static int cols_flush(PyObject *const *cols, Buf *col)
{
    PyObject *et, *ev, *tb;
    int bad = 0;
    PyErr_Fetch(&et, &ev, &tb);
    for (int c = 0; c < 3 && !bad; c++) {
        if (col[c].n == 0)
            continue;
        PyObject *mv = PyMemoryView_FromMemory(col[c].p, col[c].n, PyBUF_READ), *r = NULL;
        if (mv != NULL)
            r = PyObject_CallMethodOneArg(cols[c], NAMES[A_FROMBYTES], mv);
        bad = r == NULL;
        Py_XDECREF(r);
        Py_XDECREF(mv);
    }
    if (bad) {                     /* frombytes' exception replaces any in force */
        Py_XDECREF(et);
        Py_XDECREF(ev);
        Py_XDECREF(tb);
        return -1;
    }
    PyErr_Restore(et, ev, tb);
    return 0;
}

/* (a, z, i): Py_BuildValue("(nnO)", a, z, i) */
static PyObject *range_row(Py_ssize_t a, Py_ssize_t z, PyObject *i)
{
    PyObject *t = PyTuple_New(3), *ao = PyLong_FromSsize_t(a), *zo = PyLong_FromSsize_t(z);
    if (t == NULL || ao == NULL || zo == NULL) {
        Py_XDECREF(t);
        Py_XDECREF(ao);
        Py_XDECREF(zo);
        return NULL;
    }
    PyTuple_SET_ITEM(t, 0, ao);
    PyTuple_SET_ITEM(t, 1, zo);
    PyTuple_SET_ITEM(t, 2, Py_NewRef(i));
    return t;
}

/* write(memoryview of b's bytes), then b emptied: 0, or -1 (an exception) */
static int run_flush(Buf *b, PyObject *write)
{
    if (b->n == 0)
        return 0;
    PyObject *mv = PyMemoryView_FromMemory(b->p, b->n, PyBUF_READ);
    if (mv == NULL)
        return -1;
    PyObject *r = PyObject_CallOneArg(write, mv);
    /* (a writer that kept the view finds it released, not the buffer's next bytes; the
       write's own exception, a full disk say, is the one raised) */
    PyObject *et, *ev, *tb;
    PyErr_Fetch(&et, &ev, &tb);
    PyObject *rel = PyObject_CallMethod(mv, "release", NULL);
    Py_DECREF(mv);
    if (r == NULL) {
        Py_XDECREF(rel);
        PyErr_Restore(et, ev, tb);        /* (release's own exception, if any, replaced) */
        return -1;
    }
    Py_DECREF(r);
    if (rel == NULL)
        return -1;
    Py_DECREF(rel);
    b->n = 0;
    return 0;
}
static PyObject *stroke_run(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 23) {
        PyErr_SetString(PyExc_TypeError, "stroke_run takes 23 arguments");
        return NULL;
    }
    if (names_ready() < 0)
        return NULL;
    stroke_fields_ready();
    PyObject *data = args[0], *order = args[3], *out_ranges = args[6];
    RunArgs ra;
    memset(&ra, 0, sizeof ra);
    ra.strokes = args[7];
    ra.segs = args[8];
    ra.betas = args[9];
    ra.stroke_type = args[10];
    /* seg_type: the SegmentPlan type, or (SegmentPlan, RowPlan): a RowPlan's arrays are
       row _row of the blocks it holds (segments.RowPlan) */
    if (PyTuple_Check(args[11]) && PyTuple_GET_SIZE(args[11]) == 2) {
        ra.seg_type = PyTuple_GET_ITEM(args[11], 0);
        ra.row_type = PyTuple_GET_ITEM(args[11], 1);
    } else
        ra.seg_type = args[11];
    ra.k_arc = args[12];
    ra.travel = args[13];
    ra.closing_text = args[14];
    ra.flavour = args[15];
    ra.svl = args[16];
    ra.ctx_o[0] = args[17];
    ra.ctx_o[1] = args[18];
    ra.digests = args[20];
    ra.blake2b = args[21];
    Py_ssize_t pos = PyLong_AsSsize_t(args[1]), line = PyLong_AsSsize_t(args[2]), k = PyLong_AsSsize_t(args[4]),
               out_line = PyLong_AsSsize_t(args[5]);
    if (PyErr_Occurred())
        return NULL;
    PyObject *const *cols = NULL;           /* out_ranges as three array('q') columns */
    if (PyTuple_CheckExact(out_ranges) && PyTuple_GET_SIZE(out_ranges) == 3)
        cols = &PyTuple_GET_ITEM(out_ranges, 0);
    if (!PyBytes_CheckExact(data) || !(cols != NULL || PyList_CheckExact(out_ranges)) || !PyList_CheckExact(ra.strokes)
        || !PyList_CheckExact(ra.segs) || !PyList_CheckExact(ra.betas) || !PyFloat_CheckExact(args[19])
        || !PyUnicode_CheckExact(ra.k_arc) || (ra.digests != Py_None && !PyDict_CheckExact(ra.digests))
        || pos < 0 || pos > PyBytes_GET_SIZE(data) || k < 0) {
        PyErr_SetString(PyExc_TypeError, "stroke_run: arguments of other types");
        return NULL;
    }
    ra.max_accel_a = PyFloat_AS_DOUBLE(args[19]);
    ra.nl = PyUnicode_InternFromString("\n");
    if (ra.nl == NULL)
        return NULL;
    int ctx_ok = ctx_into(ra.ctx_o[0], &ra.ctx[0]) == 0 && ctx_into(ra.ctx_o[1], &ra.ctx[1]) == 0;
    for (int x = 0; x < 2; x++) {
        ra.ctx[x].pc.nlp = "\n";
        ra.ctx[x].pc.nln = 1;
    }
    const char *d = PyBytes_AS_STRING(data);
    Py_ssize_t len = PyBytes_GET_SIZE(data), n_order = PySequence_Length(order);
    if (n_order < 0) {
        Py_DECREF(ra.nl);
        return NULL;
    }
    /* order's int64s read in place where it is a contiguous int64 array (pipeline's numpy
       order): no numpy scalar made and read back a stroke; order[k] itself only where
       something keeps it (a list's row tuple, a digest's key) */
    Py_buffer ov;
    const int64_t *order_d = NULL;
    if (PyObject_CheckBuffer(order) && PyObject_GetBuffer(order, &ov, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) == 0) {
        const char *f = ov.format ? ov.format : "B";
        if (*f == '<' || *f == '=' || *f == '@')
            f++;
        if (ov.ndim == 1 && ov.itemsize == 8 && ov.len == 8 * n_order && (strcmp(f, "q") == 0 || strcmp(f, "l") == 0))
            order_d = (const int64_t *)ov.buf;
        else
            PyBuffer_Release(&ov);
    } else
        PyErr_Clear();
    int keep_i = cols == NULL || ra.digests != Py_None;
    Buf col[3] = {{NULL, 0, 0}, {NULL, 0, 0}, {NULL, 0, 0}};
    /* room for a flush's worth and the block that passes RUN_FLUSH, taken at once: grown
       from nothing by doubling, each call copied ~2 MB in realloc (~25 M instructions of
       memcpy on the gyroid plate).  (Not had: put grows it as it goes.) */
    Buf out = {NULL, 0, 0};
    (void)buf_grow(&out, 2 * RUN_FLUSH);
    int err = 0;
    while (ctx_ok && k < n_order) {
        PyObject *i_o = NULL, *kind = NULL;
        Py_ssize_t i;
        if (order_d == NULL || keep_i) {
            if ((i_o = PySequence_GetItem(order, k)) == NULL) { err = 1; break; }
            i = order_d != NULL ? (Py_ssize_t)order_d[k] : PyNumber_AsSsize_t(i_o, NULL);
        } else
            i = (Py_ssize_t)order_d[k];
        int took = 0;
        if (i < 0 || i >= PyList_GET_SIZE(ra.strokes) || i >= PyList_GET_SIZE(ra.segs)
            || i >= PyList_GET_SIZE(ra.betas)) {
            PyErr_Clear();
            goto next;
        }
        PyObject *s = PyList_GET_ITEM(ra.strokes, i), *seg = PyList_GET_ITEM(ra.segs, i);
        if (!Py_IS_TYPE(s, (PyTypeObject *)ra.stroke_type)
            || !(Py_IS_TYPE(seg, (PyTypeObject *)ra.seg_type)
                 || (ra.row_type != NULL && Py_IS_TYPE(seg, (PyTypeObject *)ra.row_type))))
            goto next;
        Py_ssize_t first, last;
        long long fi, li;
        if (stroke_int(s, A_FIRST, &fi) && stroke_int(s, A_LAST, &li)) {    /* (in place: no int made) */
            first = (Py_ssize_t)fi;
            last = (Py_ssize_t)li;
        } else {
            PyObject *fi_o = get_attr(s, A_FIRST), *li_o = get_attr(s, A_LAST);
            first = fi_o && PyLong_CheckExact(fi_o) ? PyLong_AsSsize_t(fi_o) : -1;
            last = li_o && PyLong_CheckExact(li_o) ? PyLong_AsSsize_t(li_o) : -1;
            Py_XDECREF(fi_o);
            Py_XDECREF(li_o);
            PyErr_Clear();
        }
        Py_ssize_t n_copy = first - line, n_take = last - first + 1;
        if (first < 0 || last < 0 || n_copy < 0 || n_take < 1)
            goto next;
        kind = get_attr(s, A_KIND);
        int arc = kind == NULL ? -1 : str_eq(kind, ra.k_arc);
        if (arc < 0 && kind != NULL)
            arc = PyObject_RichCompareBool(kind, ra.k_arc, Py_EQ);
        if (arc != 0) {
            PyErr_Clear();
            goto next;
        }
        /* the untouched lines whole in data (the stroke's: block_into reads them to their end z) */
        Py_ssize_t got_c, end = skip_n(d, len, pos, n_copy, &got_c), z = end;
        if (got_c != n_copy)
            goto next;
        Py_ssize_t base = out.n;
        if (put(&out, d + pos, end - pos) < 0) {
            PyErr_NoMemory();
            err = 1;
            goto next;
        }
        Py_ssize_t head_at = out.n;
        Py_ssize_t n_out = 0;                     /* the block's lines */
        int r = run_block(&out, &ra, s, seg, PyList_GET_ITEM(ra.betas, i), kind, d, end, len, n_take, &n_out, &z);
        if (r <= 0) {             /* (no memory: the loop's stroke_block call, as before) */
            out.n = base;
            PyErr_Clear();
            goto next;
        }
        if (cols != NULL) {
            Py_ssize_t n_col = col[0].n;
            if (col_put(&col[0], out_line + n_copy) < 0 || col_put(&col[1], out_line + n_copy + n_out - 1) < 0
                || col_put(&col[2], i) < 0) {
                col[0].n = col[1].n = col[2].n = n_col;
                PyErr_NoMemory();
                out.n = base;
                err = 1;
                goto next;
            }
        } else {
            PyObject *row = range_row(out_line + n_copy, out_line + n_copy + n_out - 1, i_o);
            if (row == NULL || PyList_Append(out_ranges, row) < 0) {
                Py_XDECREF(row);
                out.n = base;
                err = 1;
                goto next;
            }
            Py_DECREF(row);
        }
        if (ra.digests != Py_None) {
            /* blake2b(block, digest_size=16).digest(), as the loop makes it: the empty
               hash's copy (blake2 is the same from its start state) updated with the block
               (no keyword dict a call) */
            PyObject *mv = PyMemoryView_FromMemory(out.p + head_at, out.n - head_at, PyBUF_READ), *h = NULL, *dg = NULL;
            if (mv != NULL && (h = PyObject_CallMethodNoArgs(ra.blake2b, NAMES[A_COPY])) != NULL) {
                PyObject *u = PyObject_CallMethodOneArg(h, NAMES[A_UPDATE], mv);
                if (u != NULL)
                    dg = PyObject_CallMethodNoArgs(h, NAMES[A_DIGEST]);
                Py_XDECREF(u);
            }
            Py_XDECREF(mv);
            Py_XDECREF(h);
            if (dg == NULL || PyDict_SetItem(ra.digests, i_o, dg) < 0) {
                /* (the row is in out_ranges: an exception here ends the rewrite) */
                Py_XDECREF(dg);
                err = 1;
                goto next;
            }
            Py_DECREF(dg);
        }
        pos = z;
        line = first + n_take;
        out_line += n_copy + n_out;
        took = 1;
        if (out.n >= RUN_FLUSH && run_flush(&out, args[22]) < 0)
            err = 1;
next:
        Py_XDECREF(kind);
        Py_XDECREF(i_o);
        if (!took || err)
            break;
        k++;
    }
    memo_clear(&ra.memo);
    Py_DECREF(ra.nl);
    if (order_d != NULL)
        PyBuffer_Release(&ov);
    /* the rows taken, into out_ranges' columns whatever ends the call (as a list's rows are) */
    if (cols != NULL && cols_flush(cols, col) < 0)
        err = 1;
    for (int c = 0; c < 3; c++)
        PyMem_Free(col[c].p);
    PyObject *res = NULL;
    if (!err && run_flush(&out, args[22]) == 0)
        res = Py_BuildValue("(nnnn)", k, pos, line, out_line);
    PyMem_Free(out.p);
    return res;
}

/* ---------------------------------------------------------------- for the tests */

/* format_text(x, code, prec): fmt_f's ('f') or fmt_g4's ('g', prec 4) text of x, None
   where it declines */
/* row_plans(cls, blocks, H, shape, fine) -> a list of new cls objects, or None (declined)
   spill_file.block_plans' RowPlans made without a Python call each (~1 us a plan through
   RowPlan.__init__; ~16 k chain plans in a windowed gyroid rewrite): for each block
   (S, V, A, F, k) of blocks (a list), k objects, the i-th of a block holding its S, V, A, F
   and row i, in order; object q's time_t, int_a2 the floats H[q, 0], H[q, 1] (H: a
   C-contiguous float64 array of sum(k) rows and at least 3 columns), shape `shape`,
   first_cmds None, fault `fine` where H[q, 2] != 0.0 else None: what RowPlan(S, V, A, F,
   i, time_t, int_a2) then p.fault = fine sets.  cls: a type without a __dict__, a __new__
   or items of its own whose fields are these ten object slots (__slots__) and no other;
   anything else, None. */
#ifdef ATTR_CACHE
enum { RP_S, RP_V, RP_ACCEL, RP_FEED, RP_ROW, RP_TIME, RP_A2, RP_SHAPE, RP_FAULT, RP_FC, RP_N };
static const char *const RP_NAMES[RP_N] = {"_s", "_v", "_accel", "_feed", "_row", "time_t", "int_a2", "shape",
                                           "fault", "first_cmds"};

/* the offsets of cls' ten object slots: 0, or -1 (declined; no exception left) */
static int row_plan_slots(PyTypeObject *tp, Py_ssize_t *off)
{
    /* (the size: these ten slots and nothing else, so that none is left unset) */
    if (tp->tp_new != PyBaseObject_Type.tp_new || tp->tp_dictoffset != 0 || tp->tp_itemsize != 0
        || tp->tp_alloc == NULL || tp->tp_basicsize != (Py_ssize_t)(sizeof(PyObject) + RP_N * sizeof(PyObject *)))
        return -1;
    for (int k = 0; k < RP_N; k++) {
        PyObject *name = PyUnicode_InternFromString(RP_NAMES[k]);
        if (name == NULL) {
            PyErr_Clear();
            return -1;
        }
        PyObject *d = _PyType_Lookup(tp, name);        /* (borrowed) */
        Py_DECREF(name);
        if (d == NULL || !Py_IS_TYPE(d, &PyMemberDescr_Type))
            return -1;
        PyMemberDef *mb = ((PyMemberDescrObject *)d)->d_member;
        if (mb->type != T_OBJECT_EX || (mb->flags & READONLY) || mb->offset <= 0
            || !PyType_IsSubtype(tp, PyDescr_TYPE(d)))
            return -1;
        off[k] = mb->offset;
    }
    return 0;
}

static inline void slot_put(PyObject *o, Py_ssize_t off, PyObject *v)
{
    *(PyObject **)((char *)o + off) = v;            /* (a new object's slot: NULL before) */
}

static PyObject *row_plans(PyObject *self, PyObject *args)
{
    PyObject *cls, *blocks, *H, *shape, *fine;
    if (!PyArg_ParseTuple(args, "O!O!OOO", &PyType_Type, &cls, &PyList_Type, &blocks, &H, &shape, &fine))
        return NULL;
    PyTypeObject *tp = (PyTypeObject *)cls;
    Py_ssize_t off[RP_N];
    if (row_plan_slots(tp, off) < 0)
        Py_RETURN_NONE;
    Py_buffer hv;
    if (PyObject_GetBuffer(H, &hv, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) {
        PyErr_Clear();
        Py_RETURN_NONE;
    }
    PyObject *out = NULL;
    Py_ssize_t nb = PyList_GET_SIZE(blocks), m = 0;
    if (hv.ndim != 2 || hv.format == NULL || strcmp(hv.format, "d") != 0 || hv.shape[1] < 3)
        goto decline;
    for (Py_ssize_t b = 0; b < nb; b++) {
        PyObject *blk = PyList_GET_ITEM(blocks, b);
        if (!PyTuple_CheckExact(blk) || PyTuple_GET_SIZE(blk) != 5 || !PyLong_CheckExact(PyTuple_GET_ITEM(blk, 4)))
            goto decline;
        Py_ssize_t k = PyLong_AsSsize_t(PyTuple_GET_ITEM(blk, 4));
        if (k < 0 || k > PY_SSIZE_T_MAX - m) {
            PyErr_Clear();
            goto decline;
        }
        m += k;
    }
    if (m != hv.shape[0])
        goto decline;
    if ((out = PyList_New(m)) == NULL)
        goto fail;
    const double *h = (const double *)hv.buf;
    Py_ssize_t w = hv.shape[1], q = 0;
    for (Py_ssize_t b = 0; b < nb; b++) {
        PyObject *blk = PyList_GET_ITEM(blocks, b);
        Py_ssize_t k = PyLong_AsSsize_t(PyTuple_GET_ITEM(blk, 4));
        for (Py_ssize_t i = 0; i < k; i++, q++) {
            const double *r = h + q * w;
            PyObject *row = PyLong_FromSsize_t(i), *t = PyFloat_FromDouble(r[0]), *a2 = PyFloat_FromDouble(r[1]);
            PyObject *o = row && t && a2 ? tp->tp_alloc(tp, 0) : NULL;
            if (o == NULL) {
                Py_XDECREF(row);
                Py_XDECREF(t);
                Py_XDECREF(a2);
                goto fail;
            }
            slot_put(o, off[RP_S], Py_NewRef(PyTuple_GET_ITEM(blk, 0)));
            slot_put(o, off[RP_V], Py_NewRef(PyTuple_GET_ITEM(blk, 1)));
            slot_put(o, off[RP_ACCEL], Py_NewRef(PyTuple_GET_ITEM(blk, 2)));
            slot_put(o, off[RP_FEED], Py_NewRef(PyTuple_GET_ITEM(blk, 3)));
            slot_put(o, off[RP_ROW], row);
            slot_put(o, off[RP_TIME], t);
            slot_put(o, off[RP_A2], a2);
            slot_put(o, off[RP_SHAPE], Py_NewRef(shape));
            slot_put(o, off[RP_FAULT], Py_NewRef(r[2] != 0.0 ? fine : Py_None));
            slot_put(o, off[RP_FC], Py_NewRef(Py_None));
            PyList_SET_ITEM(out, q, o);
        }
    }
    PyBuffer_Release(&hv);
    return out;
decline:
    PyBuffer_Release(&hv);
    Py_RETURN_NONE;
fail:
    PyBuffer_Release(&hv);
    Py_XDECREF(out);
    return NULL;
}
#else
static PyObject *row_plans(PyObject *self, PyObject *args)
{
    Py_RETURN_NONE;
}
#endif

static PyObject *format_text(PyObject *self, PyObject *args)
{
    double x;
    int code, prec;
    char buf[64];
    if (!PyArg_ParseTuple(args, "dCi", &x, &code, &prec))
        return NULL;
    int n = code == 'f' ? fmt_f(x, prec, buf) : code == 'g' && prec == 4 ? fmt_g4(x, buf) : -1;
    if (n < 0)
        Py_RETURN_NONE;
    return ascii_str(buf, n);
}

/* format_check(doubles, code, prec): the native doubles (bytes) formatted by fmt_f / fmt_g4
   and by PyOS_double_to_string: (taken, index of the first text that differs or -1) */
static PyObject *format_check(PyObject *self, PyObject *args)
{
    Py_buffer v;
    int code, prec;
    if (!PyArg_ParseTuple(args, "y*Ci", &v, &code, &prec))
        return NULL;
    const double *d = (const double *)v.buf;
    Py_ssize_t n = v.len / (Py_ssize_t)sizeof(double), taken = 0, bad = -1;
    char buf[64];
    for (Py_ssize_t k = 0; k < n && bad < 0; k++) {
        double x;
        memcpy(&x, d + k, sizeof x);
        int m = code == 'f' ? fmt_f(x, prec, buf) : code == 'g' && prec == 4 ? fmt_g4(x, buf) : -1;
        if (m < 0)
            continue;
        taken++;
        char *ref = PyOS_double_to_string(x, (char)code, prec, 0, NULL);
        if (ref == NULL) {
            PyBuffer_Release(&v);
            return NULL;
        }
        if ((size_t)m != strlen(buf) || strcmp(ref, buf) != 0)
            bad = k;
        PyMem_Free(ref);
    }
    PyBuffer_Release(&v);
    return Py_BuildValue("(nn)", taken, bad);
}

/* dec_read(text): the fused reading of the plain decimal leading text and the two-pass one
   it replaced: ((length, decimals, value) by dec_value, (length, decimals, value) by
   plain_decimal and to_double); a length -1 where no plain decimal leads (value None) */
static PyObject *dec_read(PyObject *self, PyObject *o)
{
    Py_ssize_t n;
    const char *p = ascii(o, &n);
    if (p == NULL) {
        PyErr_SetString(PyExc_TypeError, "dec_read: an ASCII str");
        return NULL;
    }
    int d1 = 0, d2 = 0;
    double v1 = 0.0;
    Py_ssize_t n1 = dec_value(p, n, &d1, &v1), n2 = plain_decimal(p, n, &d2);
    PyObject *a = n1 < 0 ? Py_BuildValue("(niO)", n1, d1, Py_None) : Py_BuildValue("(nid)", n1, d1, v1);
    PyObject *b = n2 < 0 ? Py_BuildValue("(niO)", n2, d2, Py_None) : Py_BuildValue("(nid)", n2, d2, to_double(p, n2));
    PyObject *r = a && b ? PyTuple_Pack(2, a, b) : NULL;
    Py_XDECREF(a);
    Py_XDECREF(b);
    return r;
}

/* attr_read(o, name): get_attr's read of one of NAME_TEXT's names (tests) */
static PyObject *attr_read(PyObject *self, PyObject *args)
{
    PyObject *o;
    const char *nm;
    if (!PyArg_ParseTuple(args, "Os", &o, &nm) || names_ready() < 0)
        return NULL;
    for (int k = 0; k < N_NAMES; k++)
        if (strcmp(nm, NAME_TEXT[k]) == 0)
            return get_attr(o, k);
    PyErr_Format(PyExc_ValueError, "attr_read: %s is not one of get_attr's names", nm);
    return NULL;
}

/* field_read(o, name): stroke_double's / stroke_int's in-place read of o's field name
   (stroke_run's: x0, y0, time_t, _ss_e, length_d; first_idx, last_idx) as
   (True, its value: a float, None or an int), or (False, None) where it is not read so
   (tests: against getattr) */
static PyObject *field_read(PyObject *self, PyObject *args)
{
    PyObject *o;
    const char *nm;
    if (!PyArg_ParseTuple(args, "Os", &o, &nm) || names_ready() < 0)
        return NULL;
    stroke_fields_ready();
    for (int k = 0; k < N_NAMES; k++)
        if (strcmp(nm, NAME_TEXT[k]) == 0) {
            double x;
            long long i;
            int none;
            if (k == A_FIRST || k == A_LAST) {
                if (stroke_int(o, k, &i))
                    return Py_BuildValue("(OL)", Py_True, i);
            } else if (stroke_double(o, k, &x, &none)) {
                if (none)
                    return Py_BuildValue("(OO)", Py_True, Py_None);
                return Py_BuildValue("(Od)", Py_True, x);
            }
            return Py_BuildValue("(OO)", Py_False, Py_None);
        }
    PyErr_Format(PyExc_ValueError, "field_read: %s is not one of get_attr's names", nm);
    return NULL;
}

/* line_read(text): plain_line on an ASCII line without its "\n": None (not plain), or
   (x_text, y_text, e_text or None, comment, dx, dy, de, x, y, e or None) */
static PyObject *line_read(PyObject *self, PyObject *o)
{
    Py_ssize_t m;
    const char *p = ascii(o, &m);
    if (p == NULL) {
        PyErr_SetString(PyExc_TypeError, "line_read: an ASCII str");
        return NULL;
    }
    char *line = PyMem_Malloc(m + 2);            /* the line and its '\n', as block_into gives it, */
    if (line == NULL)                            /* and the byte after it */
        return PyErr_NoMemory();
    memcpy(line, p, m);
    line[m] = '\n';
    line[m + 1] = '7';
    Txt x = {0}, y = {0}, e = {0}, c = {0}, x1 = {0}, y1 = {0}, e1 = {0}, c1 = {0};
    int dx, dy, de, dx1 = 0, dy1 = 0, de1 = 0;
    double v[3] = {0.0, 0.0, 0.0}, v1[3] = {0.0, 0.0, 0.0};
    uint64_t u[3] = {0, 0, 0}, u1[3] = {0, 0, 0};
    PyObject *r = NULL;
    int ok = plain_line_in(line, m, &x, &y, &e, &c, &dx, &dy, &de, v, u, 1);
    int ok1 = plain_line_in(line, m, &x1, &y1, &e1, &c1, &dx1, &dy1, &de1, v1, u1, 0);
    if (ok != ok1 || (ok && (x.n != x1.n || y.n != y1.n || e.p != e1.p || e.n != e1.n || c.p != c1.p || c.n != c1.n
                             || dx != dx1 || dy != dy1 || de != de1 || memcmp(v, v1, sizeof v) != 0
                             || memcmp(u, u1, sizeof u) != 0))) {
        PyMem_Free(line);
        PyErr_SetString(PyExc_AssertionError, "line_read: the pair reading and the digit reading differ");
        return NULL;
    }
    if (!ok)
        r = Py_NewRef(Py_None);
    else {
        PyObject *et = e.p ? ascii_str(e.p, e.n) : Py_NewRef(Py_None);
        PyObject *ev = e.p ? PyFloat_FromDouble(v[2]) : Py_NewRef(Py_None);
        if (et && ev)
            r = Py_BuildValue("(s#s#Os#iiiddO)", x.p, x.n, y.p, y.n, et, c.p, c.n, dx, dy, de, v[0], v[1], ev);
        Py_XDECREF(et);
        Py_XDECREF(ev);
    }
    PyMem_Free(line);
    return r;
}

/* line_units(line, dec_xy, dec_e): a plain line's x, y and e (None without E) numbers'
   units as block_into takes them (units_read of plain_line's integers) and as units_txt
   reads the texts, each (units_read's, units_txt's) with None where one declines; None:
   not a plain line (tests) */
static PyObject *line_units(PyObject *self, PyObject *args)
{
    const char *p;
    Py_ssize_t m;
    int dxy, de_w;
    if (!PyArg_ParseTuple(args, "s#ii", &p, &m, &dxy, &de_w))
        return NULL;
    char *line = PyMem_Malloc(m + 2);
    if (line == NULL)
        return PyErr_NoMemory();
    memcpy(line, p, m);
    line[m] = '\n';
    line[m + 1] = '7';
    Txt t[3], c;
    int d[3];
    double v[3];
    uint64_t u[3] = {0, 0, 0};
    PyObject *r = NULL;
    if (!plain_line_in(line, m, &t[0], &t[1], &t[2], &c, &d[0], &d[1], &d[2], v, u, 1))
        r = Py_NewRef(Py_None);
    else {
        PyObject *items[3] = {NULL, NULL, NULL};
        for (int i = 0; i < 3; i++) {
            int dec = i < 2 ? dxy : de_w;
            int64_t a = 0, b = 0;
            if (t[i].p == NULL) {
                items[i] = Py_NewRef(Py_None);
                continue;
            }
            int ra = units_read(&t[i], u[i], d[i], dec, &a), rb = units_txt(t[i].p, t[i].n, dec, &b);
            PyObject *pa = ra < 0 ? Py_NewRef(Py_None) : PyLong_FromLongLong(a);
            PyObject *pb = rb < 0 ? Py_NewRef(Py_None) : PyLong_FromLongLong(b);
            items[i] = pa && pb ? PyTuple_Pack(2, pa, pb) : NULL;
            Py_XDECREF(pa);
            Py_XDECREF(pb);
        }
        if (items[0] && items[1] && items[2])
            r = PyTuple_Pack(3, items[0], items[1], items[2]);
        for (int i = 0; i < 3; i++)
            Py_XDECREF(items[i]);
    }
    PyMem_Free(line);
    return r;
}

/* head_of(spec, n_lines): head_text's head, None where it declines, with head_line_breaks
   of its first line from its kind and from the line's text: (head, by kind, by text) (tests) */
static PyObject *head_of(PyObject *self, PyObject *args)
{
    PyObject *spec;
    Py_ssize_t n_lines, len = 0;
    if (!PyArg_ParseTuple(args, "On", &spec, &n_lines))
        return NULL;
    char *h = head_text(spec, n_lines, &len);
    if (h == NULL)
        Py_RETURN_NONE;
    Txt kind = {NULL, 0};
    kind.p = ascii(PyTuple_GET_ITEM(spec, 0), &kind.n);
    const char *nl = memchr(h, '\n', (size_t)len);
    Py_ssize_t hl = nl != NULL ? nl - h : len;
    Txt given = {NULL, 0};
    PyObject *r = Py_BuildValue("(Nii)", PyUnicode_DecodeASCII(h, len, NULL), head_line_breaks(&kind, h, hl),
                                head_line_breaks(&given, h, hl));
    PyMem_Free(h);
    return r;
}

/* units_text(u, dec), tenths_text(k): put_units' and put_tenths_up's texts */
static PyObject *units_text(PyObject *self, PyObject *args)
{
    long long u;
    int dec;
    if (!PyArg_ParseTuple(args, "Li", &u, &dec))
        return NULL;
    Buf b = {NULL, 0, 0};
    int r = put_units(&b, (int64_t)u, dec);
    PyObject *res = r == 0 ? ascii_str(b.p, b.n) : r == -2 ? Py_NewRef(Py_None) : PyErr_NoMemory();
    PyMem_Free(b.p);
    return res;
}

/* start8(x, dec): run_block's start text of x, f"{x:.8f}", read two ways: (text, units by
   start8_units or None, start8_decimals) from fmt_f's integer and (units by units_txt or
   None, start_decimals) from the text; None where fmt_f declines (tests) */
static PyObject *start8(PyObject *self, PyObject *args)
{
    double x;
    int dec;
    char buf[64];
    uint64_t n;
    if (!PyArg_ParseTuple(args, "di", &x, &dec))
        return NULL;
    int len = fmt_f_n(x, 8, buf, &n);
    if (len < 0 || dec < 0 || dec > 15)
        Py_RETURN_NONE;
    int64_t u_n = 0, u_t = 0;
    int ok_n = start8_units(n, signbit(x) != 0, dec, &u_n) == 0, ok_t = units_txt(buf, len, dec, &u_t) == 0;
    PyObject *a = ok_n ? PyLong_FromLongLong(u_n) : Py_NewRef(Py_None);
    PyObject *b = ok_t ? PyLong_FromLongLong(u_t) : Py_NewRef(Py_None);
    if (a == NULL || b == NULL) {
        Py_XDECREF(a);
        Py_XDECREF(b);
        return NULL;
    }
    return Py_BuildValue("(s#NiNi)", buf, (Py_ssize_t)len, a, start8_decimals(n), b, start_decimals(buf, len));
}

/* units_nf(u, dec): units_at_nf's text and decimals, (str, int) (dec 0..30; tests) */
static PyObject *units_nf(PyObject *self, PyObject *args)
{
    long long u;
    int dec, nf = -1;
    char room[96];
    if (!PyArg_ParseTuple(args, "Li", &u, &dec))
        return NULL;
    if (dec < 0 || dec > 30)
        Py_RETURN_NONE;
    char *q = units_at_nf(room, (int64_t)u, dec, &nf);
    return Py_BuildValue("(s#i)", room, (Py_ssize_t)(q - room), nf);
}

static PyObject *tenths_text(PyObject *self, PyObject *args)
{
    long long k;
    if (!PyArg_ParseTuple(args, "L", &k))
        return NULL;
    if (k >= TENTHS_MAX)
        Py_RETURN_NONE;
    Buf b = {NULL, 0, 0};
    int r = put_tenths_up(&b, (int64_t)k);
    PyObject *res = r == 0 ? ascii_str(b.p, b.n) : PyErr_NoMemory();
    PyMem_Free(b.p);
    return res;
}

/* tenths_ceil(x): ceil_tenths' integer of a float, None where it declines (tests: math.ceil) */
static PyObject *tenths_ceil(PyObject *self, PyObject *o)
{
    (void)self;
    double x = PyFloat_AsDouble(o);
    int64_t k;
    if (x == -1.0 && PyErr_Occurred())
        return NULL;
    if (ceil_tenths(x, &k) < 0)
        Py_RETURN_NONE;
    return PyLong_FromLongLong(k);
}

/* pieces_nl(head, closing, before, after, nl, word, letter): piece_lines' counts (a tuple of
   PIECES ints) of ASCII str pieces (before, after: None for none), None where it declines
   (tests: str.count("\n") of each) */
static PyObject *pieces_nl(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *o[6];
    const char *letter;
    Py_ssize_t n_letter;
    if (!PyArg_ParseTuple(args, "UUOOUUs#", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &letter, &n_letter))
        return NULL;
    Pieces pc = {0};
    if ((pc.hp = ascii(o[0], &pc.hn)) == NULL || (pc.clp = ascii(o[1], &pc.cln)) == NULL
        || (o[2] != Py_None && (pc.bp = ascii(o[2], &pc.bn)) == NULL)
        || (o[3] != Py_None && (pc.ap = ascii(o[3], &pc.an)) == NULL) || (pc.nlp = ascii(o[4], &pc.nln)) == NULL
        || (pc.wp = ascii(o[5], &pc.wn)) == NULL || n_letter != 1)
        Py_RETURN_NONE;
    const char *hnl = memchr(pc.hp, '\n', (size_t)pc.hn);
    Py_ssize_t nl[PIECES];
    if (hnl == NULL || !piece_lines(&pc, hnl - pc.hp, letter[0], nl))
        Py_RETURN_NONE;
    return Py_BuildValue("(nnnnnn)", nl[0], nl[1], nl[2], nl[3], nl[4], nl[5]);
}

/* rounds(doubles): py_round of each native double (bytes): its int, or None where it
   declines (for the tests: Python's round() of each) */
static PyObject *rounds(PyObject *self, PyObject *o)
{
    Py_buffer v;
    if (PyObject_GetBuffer(o, &v, PyBUF_SIMPLE) < 0)
        return NULL;
    Py_ssize_t n = v.len / (Py_ssize_t)sizeof(double);
    PyObject *res = PyList_New(n);
    for (Py_ssize_t k = 0; res != NULL && k < n; k++) {
        double x;
        int64_t r;
        memcpy(&x, (const char *)v.buf + k * sizeof(double), sizeof x);
        PyObject *item = py_round(x, &r) < 0 ? Py_NewRef(Py_None) : PyLong_FromLongLong((long long)r);
        if (item == NULL)
            Py_CLEAR(res);
        else
            PyList_SET_ITEM(res, k, item);
    }
    PyBuffer_Release(&v);
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

/* head_breaks(bytes): has_break of the bytes (block_into's test of a head line, for the tests) */
static PyObject *head_breaks(PyObject *self, PyObject *o)
{
    if (!PyBytes_Check(o)) {
        PyErr_SetString(PyExc_TypeError, "head_breaks: bytes");
        return NULL;
    }
    return PyBool_FromLong(has_break(PyBytes_AS_STRING(o), PyBytes_GET_SIZE(o)));
}

/* set_text_check(flag): block_into's check reads every line (flag true) or lets emit_cols
   check the lines it writes (false, the default); the previous setting (tests) */
static PyObject *set_text_check(PyObject *self, PyObject *o)
{
    int t = PyObject_IsTrue(o);
    if (t < 0)
        return NULL;
    int was = TEXT_CHECK;
    TEXT_CHECK = t;
    return PyBool_FromLong(was);
}

static PyMethodDef mod_methods[] = {
    {"set_text_check", set_text_check, METH_O, "block_into's check reads every line (True) or not; the old setting (tests)"},
    {"head_breaks", head_breaks, METH_O, "block_into's test for a line break in a head line (tests)"},
    {"decimal_value", decimal_value, METH_O, "float(text) of a plain decimal text, else None (tests)"},
    {"rounds", rounds, METH_O, "py_round of each native double (bytes): int, or None where declined (tests)"},
    {"format_text", format_text, METH_VARARGS, "the hand-made 'f' / '.4g' text of a float, else None (tests)"},
    {"format_check", format_check, METH_VARARGS, "(taken, first index differing or -1): the hand-made texts "
     "of native doubles against PyOS_double_to_string's (tests)"},
    {"head_of", head_of, METH_VARARGS, "(head_text's head of a spec, or None) (tests)"},
    {"line_units", line_units, METH_VARARGS, "(block_into's units of a plain line's numbers, units_txt's) (tests)"},
    {"dec_read", dec_read, METH_O, "(dec_value's (n, dec, value), plain_decimal + to_double's) (tests)"},
    {"attr_read", attr_read, METH_VARARGS, "get_attr's read of o's attribute name (tests)"},
    {"field_read", field_read, METH_VARARGS, "stroke_double's / stroke_int's in-place read of a field (tests)"},
    {"line_read", line_read, METH_O, "plain_line's reading of a line without its line end, or None (tests)"},
    {"units_text", units_text, METH_VARARGS, "put_units' text (emit._fmt_units), None for dec > 30 (tests)"},
    {"start8", start8, METH_VARARGS, "a start text's units and decimals from fmt_f's integer and from the text (tests)"},
    {"units_nf", units_nf, METH_VARARGS, "units_at_nf's (text, decimals) (tests)"},
    {"tenths_text", tenths_text, METH_VARARGS, "put_tenths_up's text (emit._tenths_up), None past TENTHS_MAX (tests)"},
    {"tenths_ceil", tenths_ceil, METH_O, "ceil_tenths' integer of a float, None where it declines (tests)"},
    {"pieces_nl", pieces_nl, METH_VARARGS, "piece_lines' \"\\n\" counts of the pieces, None where it declines (tests)"},
    {"plain_moves", plain_moves, METH_VARARGS,
     "emit._plain_moves(raws) + (dec_xy, dec_e), or NotImplemented"},
    {"emit_body", emit_body, METH_VARARGS, "emit.emit_stroke's text, or None"},
    {"fast_body", fast_body, METH_VARARGS, "True when validate._fast_ok's checks certainly pass, else None"},
    {"set_types", set_types, METH_VARARGS, "set_types(ndarray, float64 dtype, array.array): fseq_get's types"},
    {"skip_lines", (PyCFunction)(void (*)(void))skip_lines, METH_FASTCALL,
     "(end, got): the offset after the next n lines of bytes data from pos, and how many"},
    {"stroke_block", (PyCFunction)(void (*)(void))stroke_block, METH_FASTCALL,
     "a line stroke's block (bytes) written and checked in one call, or None"},
    {"stroke_run", (PyCFunction)(void (*)(void))stroke_run, METH_FASTCALL,
     "pipeline._rewrite_bytes' loop over a run of line strokes in one call"},
    {"row_plans", row_plans, METH_VARARGS, "spill_file.block_plans' RowPlans made in one call, or None"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef emit_module = {
    PyModuleDef_HEAD_INIT, "_gcode_opt_emit",
    "The rewrite's per-line work compiled (gcode_opt/_emit.c; see emit.py, validate.py).", -1, mod_methods,
};

#ifndef EMIT_SOURCE_SHA256
#define EMIT_SOURCE_SHA256 ""
#endif
#ifndef GCODE_OPT_SOURCE_STAT   /* setup.py: the digest and the stat of each file it covers, when taken (native.stat_record) */
#define GCODE_OPT_SOURCE_STAT ""
#endif

PyMODINIT_FUNC PyInit__gcode_opt_emit(void)
{
    PyObject *m = PyModule_Create(&emit_module);
    if (m == NULL)
        return NULL;
    pair_table_init();
    if (PyModule_AddStringConstant(m, "SOURCE_SHA256", EMIT_SOURCE_SHA256) < 0
        || PyModule_AddStringConstant(m, "SOURCE_STAT", GCODE_OPT_SOURCE_STAT) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
