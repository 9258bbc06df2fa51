/* Compiled fast path of the G-code reader (state.MachineState.step); see state.py.
 *
 * It reads the two line shapes the Python step() already fast-paths -- the slicer's own
 * "G0/G1 X.. Y.. Z.. E.. F.." and "M204 S.. P.. T.. R.." -- blank lines, comment lines
 * (a feature or layer marker's too), and the commands step() does not read ("M73 P5":
 * None, nothing changed), and gives exactly what Python gives: the same Move (fields read
 * and written by __slots__ offset, the same objects where Python passes objects through,
 * the same doubles where it computes), the same
 * MachineState changes (written to the instance dict, as Python's setattr does).  Every
 * other line, and every case where Python leaves its fast path or raises (a lone CR, a
 * BOM, a word float() refuses, a word given twice, F out of range, G20, a target out of
 * range, a state attribute of an unusual type), goes to the Python step unchanged
 * (MachineState._step_python), before this code has changed anything: errors and their
 * texts stay Python's.
 *
 * Numbers are Python's float(): PyOS_string_to_double on the whole token (the grammar
 * leaves only "+-.0123456789", where float() and PyOS_string_to_double agree), or the
 * same bits by an exact fast path (fast_decimal).  The firmware core's Sim.play reads
 * through fused_line (the capsule _C_API) the same lines the same way, without Move
 * objects. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <float.h>
#include <string.h>
#include "_linestr.h"     /* line_str: a line's str as read_lines gives it */
#ifdef __SSE2__
#include <emmintrin.h>      /* split_scan's 16-byte scan */
#endif

/* ---------------------------------------------------------------- set up from state.py */
enum { MV_IDX, MV_KIND, MV_X0, MV_Y0, MV_Z0, MV_X1, MV_Y1, MV_Z1, MV_E, MV_V, MV_ACCEL, MV_FEATURE,
       MV_LAYER, MV_LIM, MV_ARC, MV_HAS_F, MV_E_REL, MV_XYZ_REL, MV_CHECKSUM, MV_INCH, MV_FLOW_R,
       MV_SPEED_R, MV_N };
static const char *MOVE_NAMES[MV_N] = {
    "idx", "kind", "x0", "y0", "z0", "x1", "y1", "z1", "e", "v", "accel", "feature", "layer", "lim",
    "arc", "has_f", "e_rel", "xyz_rel", "checksum", "inch", "flow_r", "speed_r"};
static Py_ssize_t move_off[MV_N];

/* MachineState attributes read or written here */
enum { S_X, S_Y, S_Z, S_E, S_ABS, S_EREL, S_INCH, S_V, S_FEATURE, S_LAYER, S_FLOW, S_SPEED,
       S_ACC_PRINT, S_ACC_TRAVEL, S_ACC_RETRACT, S_LIM, S_ONE, S_SEEN, S_N };
static const char *STATE_NAMES[S_N] = {
    "x", "y", "z", "e", "abs_xyz", "e_rel_flag", "inch", "v", "feature", "layer", "flow_r",
    "speed_r", "accel_print", "accel_travel", "accel_retract", "lim", "_one_accel", "feature_seen"};
static PyObject *state_name[S_N];

static PyTypeObject *MOVE_TYPE = NULL, *STATE_TYPE = NULL;
static PyObject *TRAVEL = NULL;                 /* features.TRAVEL */
static PyObject *LINE_K = NULL, *EONLY_K = NULL; /* state.LINE, state.EONLY */
static PyObject *NAME_SLOW = NULL, *NAME_M204 = NULL, *NAME_FLAVOUR = NULL;
static double MAX_POS_D = 0.0, MAX_E_D = 0.0, MAX_F = 0.0, MAX_ACCEL_A = 0.0;
static int READY = 0;

/* The comment prefixes _step_python acts on (features._PREFIXES and _LAYER_MARKERS, read at
 * setup): a comment-only line starting with none of them (lowercased) changes nothing, as
 * feature_from_comment and is_layer_change test startswith on comment.strip().lower() (the
 * strip takes only trailing whitespace off a comment that starts with ';').  A comment
 * one of them starts is read here too (marked_comment: the feature features._NAMES gives
 * its name, or the layer count) where features._NAMES and OTHER are a dict and a str;
 * else it goes to Python. */
#define MAX_MARKS 32
static char *MARKS[MAX_MARKS];
static int N_MARKS = -1;          /* -1: not read (every comment line goes to Python) */
static int N_PREFIX = 0;          /* MARKS[:N_PREFIX] are _PREFIXES, the rest _LAYER_MARKERS */
static PyObject *FEATURE_NAMES = NULL, *FEATURE_OTHER = NULL;   /* features._NAMES, OTHER (or NULL) */
/* a mark's first 4 bytes (fewer: its length's), each | 0x20, as one word (b0 | b1 << 8 ...),
 * and the mask of those bytes: a line s[0:4] whose bytes | 0x20 differ from them is not
 * that mark lowercased (c | 0x20 is lowercase(c) | 0x20 for every byte), no byte compare */
static unsigned MARK_KEY[MAX_MARKS], MARK_MASK[MAX_MARKS];
/* bit pair_key(s) set for each mark's bytes 1 and 2 (| 0x20, as key4's): a line whose pair's
 * bit is clear is none of them (one test, not one a mark: ~100 instructions a comment line);
 * MARK_SHORT: a mark has fewer than 3 bytes (then every line is tested mark by mark) */
static unsigned char MARK_PAIR[1 << 13];
static int MARK_SHORT = 1;

static inline unsigned pair_key(const unsigned char *s)
{
    return ((unsigned)s[1] | (unsigned)s[2] << 8) | 0x2020u;
}

static inline unsigned key4(const unsigned char *s)
{
    return ((unsigned)s[0] | (unsigned)s[1] << 8 | (unsigned)s[2] << 16 | (unsigned)s[3] << 24) | 0x20202020u;
}

static int read_marks(void)
{
    for (int i = 0; i < N_MARKS; i++)
        PyMem_Free(MARKS[i]);
    N_MARKS = -1;
    memset(MARK_PAIR, 0, sizeof(MARK_PAIR));
    MARK_SHORT = 0;
    Py_CLEAR(FEATURE_NAMES);
    Py_CLEAR(FEATURE_OTHER);
    PyObject *mod = PyImport_ImportModule("gcode_opt.features");
    if (mod == NULL)
        return -1;
    PyObject *names_d = PyObject_GetAttrString(mod, "_NAMES"), *other = PyObject_GetAttrString(mod, "OTHER");
    if (names_d != NULL && other != NULL && PyDict_CheckExact(names_d) && PyUnicode_CheckExact(other)) {
        FEATURE_NAMES = names_d;
        FEATURE_OTHER = other;
    } else {                      /* not the shape this code knows: marked comments stay Python's */
        PyErr_Clear();
        Py_XDECREF(names_d);
        Py_XDECREF(other);
    }
    int n = 0, ok = 1;
    static const char *names[2] = {"_PREFIXES", "_LAYER_MARKERS"};
    for (int j = 0; j < 2 && ok; j++) {
        if (j == 1)
            N_PREFIX = n;
        PyObject *t = PyObject_GetAttrString(mod, names[j]);
        if (t == NULL || !PyTuple_Check(t)) {
            PyErr_Clear();
            Py_XDECREF(t);
            ok = 0;
            break;
        }
        for (Py_ssize_t k = 0; k < PyTuple_GET_SIZE(t) && ok; k++) {
            PyObject *m = PyTuple_GET_ITEM(t, k);
            const char *c = PyUnicode_Check(m) && PyUnicode_IS_ASCII(m) ? PyUnicode_AsUTF8(m) : NULL;
            if (c == NULL || n == MAX_MARKS || (MARKS[n] = PyMem_Malloc(strlen(c) + 1)) == NULL) {
                PyErr_Clear();
                ok = 0;
                break;
            }
            strcpy(MARKS[n], c);
            unsigned char head[4] = {0, 0, 0, 0};
            size_t len = strlen(c);
            memcpy(head, c, len < 4 ? len : 4);
            MARK_MASK[n] = len >= 4 ? 0xffffffffu : (1u << (8 * len)) - 1u;
            MARK_KEY[n] = key4(head) & MARK_MASK[n];
            if (len >= 3) {
                unsigned k = pair_key((const unsigned char *)c);
                MARK_PAIR[k >> 3] |= (unsigned char)(1u << (k & 7));
            } else
                MARK_SHORT = 1;
            n++;
        }
        Py_DECREF(t);
    }
    Py_DECREF(mod);
    if (!ok) {                    /* not the shape this code knows: comments stay Python's */
        for (int i = 0; i < n; i++)
            PyMem_Free(MARKS[i]);
        return 0;
    }
    N_MARKS = n;
    return 0;
}

/* s[0:n] lowercased starts with one of MARKS (or they are unknown) */
static int marked(const unsigned char *s, Py_ssize_t n)
{
    if (N_MARKS < 0)
        return 1;
    if (n >= 3 && !MARK_SHORT) {
        unsigned k = pair_key(s);
        if (!(MARK_PAIR[k >> 3] & (1u << (k & 7))))
            return 0;
    }
    unsigned key = n >= 4 ? key4(s) : 0;
    for (int i = 0; i < N_MARKS; i++) {
        if (n >= 4 && (key & MARK_MASK[i]) != MARK_KEY[i])
            continue;                  /* (its first bytes differ: not this mark) */
        const char *m = MARKS[i];
        Py_ssize_t j = 0;
        while (m[j] != '\0' && j < n) {
            unsigned char c = s[j];
            if (c >= 'A' && c <= 'Z')
                c = (unsigned char)(c - 'A' + 'a');
            if (c != (unsigned char)m[j])
                break;
            j++;
        }
        if (m[j] == '\0')
            return 1;
    }
    return 0;
}

/* str.split()'s whitespace among ASCII characters */
static inline int is_split_space(unsigned char c)
{
    return c == ' ' || (c >= '\t' && c <= '\r') || (c >= 0x1c && c <= 0x1f);
}

static int read_cmds(PyObject *cmds);

static PyObject *setup(PyObject *self, PyObject *args)
{
    PyObject *move, *state, *travel, *line_k, *eonly_k, *cmds = NULL;
    double pos, e, f, acc;
    if (!PyArg_ParseTuple(args, "O!O!OOOdddd|O", &PyType_Type, &move, &PyType_Type, &state, &travel,
                          &line_k, &eonly_k, &pos, &e, &f, &acc, &cmds))
        return NULL;
    for (int i = 0; i < MV_N; i++) {
        PyObject *d = PyObject_GetAttrString(move, MOVE_NAMES[i]);
        if (d == NULL)
            return NULL;
        int ok = Py_TYPE(d) == &PyMemberDescr_Type
                 && ((PyMemberDescrObject *)d)->d_member->type == T_OBJECT_EX;
        if (ok)
            move_off[i] = ((PyMemberDescrObject *)d)->d_member->offset;
        Py_DECREF(d);
        if (!ok) {
            PyErr_Format(PyExc_TypeError, "Move.%s is not a slot", MOVE_NAMES[i]);
            return NULL;
        }
    }
    for (int i = 0; i < S_N; i++) {
        PyObject *nm = PyUnicode_InternFromString(STATE_NAMES[i]);
        if (nm == NULL)
            return NULL;
        Py_XSETREF(state_name[i], nm);
    }
    Py_XSETREF(NAME_SLOW, PyUnicode_InternFromString("_step_python"));
    Py_XSETREF(NAME_M204, PyUnicode_InternFromString("_m204"));
    Py_XSETREF(NAME_FLAVOUR, PyUnicode_InternFromString("flavour"));
    if (NAME_SLOW == NULL || NAME_M204 == NULL || NAME_FLAVOUR == NULL)
        return NULL;
    Py_INCREF(move);
    Py_XSETREF(MOVE_TYPE, (PyTypeObject *)move);
    Py_INCREF(state);
    Py_XSETREF(STATE_TYPE, (PyTypeObject *)state);
    Py_INCREF(travel);
    Py_XSETREF(TRAVEL, travel);
    Py_INCREF(line_k);
    Py_XSETREF(LINE_K, line_k);
    Py_INCREF(eonly_k);
    Py_XSETREF(EONLY_K, eonly_k);
    MAX_POS_D = pos;
    MAX_E_D = e;
    MAX_F = f;
    MAX_ACCEL_A = acc;
    if (read_marks() < 0 || read_cmds(cmds) < 0)
        return NULL;
    READY = 1;
    Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- the line */
/* Clinger's fast path: s[0:n] = [+-]digits[.digits] (a digit at least) with at most 19
 * digits making m < 2^53 and at most 22 after the point is m / 10^k, both exact doubles,
 * and one IEEE division rounds it correctly: the bits of Python's float() (correctly
 * rounded too), without PyOS_string_to_double's cost (it sets the x87 control word on
 * every call).  1 and *out, or 0 (not that shape: to_double's general path decides). */
#if defined(FLT_EVAL_METHOD) && FLT_EVAL_METHOD == 0
#define FAST_DECIMAL 1
static const double POW10[23] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12,
                                 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

static int fast_decimal(const char *s, Py_ssize_t n, double *out)
{
    Py_ssize_t i = 0;
    int neg = 0;
    if (i < n && (s[i] == '+' || s[i] == '-'))
        neg = s[i++] == '-';
    unsigned long long m = 0;
    int digits = 0, frac = -1;          /* frac: digits after the point, -1 before it */
    for (; i < n; i++) {
        char c = s[i];
        if (c >= '0' && c <= '9') {
            if (++digits > 19)
                return 0;
            m = m * 10u + (unsigned)(c - '0');
            if (frac >= 0)
                frac++;
        }
        else if (c == '.' && frac < 0)
            frac = 0;
        else
            return 0;
    }
    if (digits == 0 || m > (1ull << 53) || frac > 22)
        return 0;
    double v = (double)m;
    if (frac > 0)
        v = v / POW10[frac];
    *out = neg ? -v : v;
    return 1;
}
#endif

/* Python's float() of s[0:n] (only "+-.0-9" characters): 0 and *out, or -1 (no error left). */
static int to_double(const char *s, Py_ssize_t n, double *out)
{
#ifdef FAST_DECIMAL
    if (fast_decimal(s, n, out))
        return 0;
#endif
    char buf[64];
    char *b = buf;
    if (n >= (Py_ssize_t)sizeof(buf)) {
        b = PyMem_Malloc(n + 1);
        if (b == NULL) {
            PyErr_Clear();
            return -1;
        }
    }
    memcpy(b, s, n);
    b[n] = '\0';
    double v = PyOS_string_to_double(b, NULL, NULL);  /* whole string; overflow gives +-inf */
    if (b != buf)
        PyMem_Free(b);
    if (v == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        return -1;
    }
    *out = v;
    return 0;
}

/* room for every letter: a letter comes at most once (read_words' seen test), so a line
 * never has more words than this (no count of them tested) */
#define MAXW 26
typedef struct {
    int n;
    char letter[MAXW];                /* the words' letters, in the line's order */
    unsigned seen;                    /* bit c - 'A': letter c given */
    double by[26];                    /* letter c's value at by[c - 'A'] (if seen) */
} Words;

/* read_words' classes of a byte: a scan's test of a byte is one table load (a blank is
 * ' ' or '\t', as the fast regexes' [ \t]) */
enum { WC_BLANK = 1, WC_SIGN = 2, WC_POINT = 4 };
static const unsigned char WORD_CLASS[256] = {[' '] = WC_BLANK, ['\t'] = WC_BLANK, ['+'] = WC_SIGN,
                                              ['-'] = WC_SIGN, ['.'] = WC_POINT};

/* a letter's bit c - 'A' (0 for any other byte): a word's letter tested by one load */
#define LB(c) [c] = 1u << (c - 'A')
static const unsigned LETTER_BIT[256] = {LB('A'), LB('B'), LB('C'), LB('D'), LB('E'), LB('F'), LB('G'), LB('H'),
    LB('I'), LB('J'), LB('K'), LB('L'), LB('M'), LB('N'), LB('O'), LB('P'), LB('Q'), LB('R'), LB('S'), LB('T'),
    LB('U'), LB('V'), LB('W'), LB('X'), LB('Y'), LB('Z')};
#undef LB

/* the letters a command takes, as a mask of bits c - 'A' */
#define LETTER(c) (1u << ((c) - 'A'))
#define G_LETTERS (LETTER('X') | LETTER('Y') | LETTER('Z') | LETTER('E') | LETTER('F'))
#define M204_LETTERS (LETTER('S') | LETTER('P') | LETTER('T') | LETTER('R'))

/* The words after a 4- or 2-character command, as the fast regexes of state.py accept them:
 *   CMD(?:[ \t]+[letters][-+.0-9]+)*[ \t\r\n]*  (fullmatch over the code: s[0:n] up to its
 * first ';', where the line's comment starts -- the callers may pass the whole line, a
 * line line_shape has not read)
 * and each value through float(); -1 if the line is not of that shape, a value is not a
 * number or a letter comes twice (Python's len(p) check).
 * A value is read as it is scanned: fast_decimal's rule (the same m, digits and point, so
 * the same double), or, where that rule does not hold, to_double over the token.
 *
 * ended: s[n - 1] is a line ending ('\n' or '\r': the common line) and k < n.  Then no scan
 * of blanks, a letter, a sign, digits or a point passes n - 1 (that character is none of
 * those and stops each; so does a ';'), so those loops need no bound (~20% of this
 * function's instructions); only the trailing blanks and line endings are read up to n.  A
 * constant in read_words' two calls of it: two copies, the same steps and results. */
static inline __attribute__((always_inline)) int read_words_in(const unsigned char *s, Py_ssize_t n, Py_ssize_t k,
                                                               unsigned letters, Words *w, const int ended)
{
#define BELOW(j) (ended || (j) < n)          /* s[j] is in the code (always, when ended) */
    /* w's count and letters set kept here until the end: w->letter's char stores may alias
     * them, which would have them read and written back around every word */
    unsigned seen = 0;
    int nw = 0;
    for (;;) {
        Py_ssize_t j = k;
        while (BELOW(j) && (WORD_CLASS[s[j]] & WC_BLANK))
            j++;
        unsigned bit = 0;
        if (j > k && BELOW(j))
            bit = LETTER_BIT[s[j]] & letters;
        if (bit) {
            int c = s[j] - 'A';
            Py_ssize_t a = ++j;
            /* fast_decimal's scan: [+-]digits[.digits]; ok = 0 where its shape fails */
            int neg = 0, ok = 1;
            Py_ssize_t digits = 0, frac = -1;      /* frac: digits after the point, -1 before it */
            unsigned long long m = 0;
            if (BELOW(j) && (WORD_CLASS[s[j]] & WC_SIGN))
                neg = s[j++] == '-';
            /* the usual shape, digits[.digits], in two tight loops (the same m, digits, frac
             * and end as the loop below, which goes on from where they stop) */
            unsigned dd = 0;           /* (the point's is '.' - '0': no other copy of the byte kept a digit) */
            Py_ssize_t j0 = j;
            for (; BELOW(j) && (dd = (unsigned)s[j] - '0') <= 9; j++)
                m = m * 10u + dd;
            if (BELOW(j) && dd == (unsigned)('.' - '0')) {
                /* (counted from the point: indexed from the line's start, gcc kept the index
                 * before each step in a register of its own, an instruction a digit) */
                const unsigned char *f = s + ++j;
                Py_ssize_t t = 0;
                for (; BELOW(j + t) && (dd = (unsigned)f[t] - '0') <= 9; t++)
                    m = m * 10u + dd;
                frac = t;
                j += t;
                digits = j - j0 - 1;
            } else
                digits = j - j0;
            /* the loop below takes only digits, points and signs: the tight loops stopped
             * at none of those but a point or a sign (the usual value ends here) */
            int usual = 0;             /* 1 to 15 digits (m < 10^15 < 2^53): fast_decimal's test holds */
            if (BELOW(j) && (WORD_CLASS[s[j]] & (WC_POINT | WC_SIGN))) {
                for (; j < n; j++) {
                    unsigned d = (unsigned)s[j] - '0';
                    if (d <= 9) {
                        m = m * 10u + d;        /* wraps past 19 digits: then not used */
                        digits++;
                        if (frac >= 0)
                            frac++;
                    }
                    else if (s[j] == '.') {
                        if (frac >= 0)
                            ok = 0;
                        frac = 0;
                    }
                    else if (s[j] == '+' || s[j] == '-')
                        ok = 0;
                    else
                        break;
                }
            } else
                usual = (size_t)(digits - 1) < 15;
            if (j == a)
                return -1;
            if (seen & bit)
                return -1;
#ifdef FAST_DECIMAL
            /* fast_decimal's test: 1 to 19 digits (then frac <= 22: frac counts some of them) */
            if (usual || (ok && (size_t)(digits - 1) < 19 && m <= (1ull << 53))) {
                /* m <= 2^53: converted as signed (one instruction; unsigned's takes a test
                 * of the top bit and a second path), the same double */
                double v = (double)(long long)m;
                if (frac > 0)
                    v = v / POW10[frac];
                w->by[c] = neg ? -v : v;
            }
            else
#endif
            if (to_double((const char *)s + a, j - a, &w->by[c]) < 0)
                return -1;
            seen |= bit;
            w->letter[nw++] = (char)('A' + c);
            k = j;
            continue;
        }
        while (j < n && (s[j] == ' ' || s[j] == '\t' || s[j] == '\r' || s[j] == '\n'))
            j++;
        if (!(j == n || s[j] == ';'))   /* the code's end: the line's, or its comment's start */
            return -1;
        w->n = nw;
        w->seen = seen;
        return 0;
    }
#undef BELOW
}

#ifdef FAST_DECIMAL
/* RUN[b0 | b1 << 8], the bytes p[0] p[1] as digit_run reads them: the number two digits make
 * (0 to 99: "07" is 7), RUN_ONE + d where b0 is a digit d and b1 is not (the run ends after
 * it), RUN_END where b0 is not a digit; one load and one test a pair, and the run's end read
 * from the same load.  Built at the module's load (run_table_init). */
enum { RUN_ONE = 100, RUN_END = 110 };
static unsigned char RUN[1 << 16];

static void run_table_init(void)
{
    memset(RUN, RUN_END, sizeof(RUN));
    for (int b1 = 0; b1 < 256; b1++)
        for (int d0 = 0; d0 < 10; d0++) {
            unsigned d1 = (unsigned)b1 - '0';
            RUN[('0' + d0) | (b1 << 8)] = (unsigned char)(d1 <= 9 ? (unsigned)d0 * 10 + d1 : (unsigned)(RUN_ONE + d0));
        }
}

/* the digits from p on (none: 0) appended to *m (m * 10 + d a digit, wrapping as that
 * does); end, at or after p, is a byte that is not a digit (the line's ending).  A pair's
 * read may take the byte past end (end[1], never a digit's place) where past_ok (a constant:
 * that byte is readable), else it reads p[1] only where p < end.  past_ok RUN_BOUNDED: end
 * is a bound, not a digit's end (the first pair read whatever p is, the next ones only while
 * p < end: a run that reaches end stops at end or end + 1 with its digits not all read --
 * the caller refuses the value). */
enum { RUN_BOUNDED = 2 };
static inline __attribute__((always_inline)) const unsigned char *
digit_run(const unsigned char *p, const unsigned char *end, unsigned long long *m, const int past_ok)
{
    unsigned long long v = *m;
    unsigned long long t;
    for (;;) {
        if (!past_ok && p >= end) {
            t = RUN_END;               /* (p is end: not a digit) */
            break;
        }
        t = RUN[p[0] | (p[1] << 8)];
        if (t >= RUN_ONE)
            break;
        v = v * 100u + t;
        p += 2;
        if (past_ok == RUN_BOUNDED && p >= end) {
            t = RUN_END;
            break;
        }
    }
    if (t < RUN_END) {                 /* a last digit */
        v = v * 10u + t - RUN_ONE;
        p++;
    }
    *m = v;
    return p;
}

/* digits[.digits] from *pp (none is 0 digits), as read_words_in's steps scan a value: m the
 * digits as one integer (it wraps past 20 digits: the callers take 1 to 15), *frac the
 * digits after the point; *pp moves past them; end (the line's ending, not a digit nor a
 * point) stops the scan, past_ok as digit_run's.  The number of digits. */
static inline __attribute__((always_inline)) Py_ssize_t
scan_plain_decimal(const unsigned char **pp, const unsigned char *end, unsigned long long *m_out, Py_ssize_t *frac,
                   const int past_ok)
{
    const unsigned char *p0 = *pp;
    unsigned long long m = 0;
    const unsigned char *p = digit_run(p0, end, &m, past_ok);
    Py_ssize_t digits = p - p0;
    *frac = 0;
    if (*p == '.') {
        const unsigned char *f = p + 1;
        p = digit_run(f, end, &m, past_ok);
        *frac = p - f;
        digits += *frac;
    }
    *pp = p;
    *m_out = m;
    return digits;
}

/* the byte after the line's last one, s[n], is readable: it is in the page of s[n - 1] (a
 * page is 4 KiB or a multiple of it) */
static inline int past_readable(const unsigned char *s, Py_ssize_t n)
{
    return ((uintptr_t)(s + n) & 4095u) != 0;
}
#endif

#ifdef FAST_DECIMAL
/* read_words of an ended line (as read_words_in's) whose words are all usual: each one
 * blank, a letter not seen yet, an optional '-' and digits[.digits] (1 to 15 digits: m <
 * 10^15), then the next word's blank or the line's ending (s[n - 1]) -- the same m, frac,
 * sign and end read_words_in's steps find for such a word, so the same double.  0 with w
 * filled, or 1: a line of any other shape (two blanks, a tab, a '+', a long or odd value,
 * a ';'), read_words_in's to read from the start (w's fields are all written again).  Its
 * loop holds few values (no spills) and tests no general case.  past_ok: digit_run's (a
 * constant in usual_words' two calls). */
static inline __attribute__((always_inline)) const unsigned char *
usual_words_to(const unsigned char *p, const unsigned char *end, unsigned letters, Words *w, const int past_ok,
               const int in_order, const int to_lf);

static inline __attribute__((always_inline)) int usual_words_in(const unsigned char *s, Py_ssize_t n, Py_ssize_t k,
                                                                unsigned letters, Words *w, const int past_ok,
                                                                const int in_order)
{
    return usual_words_to(s + k, s + n - 1, letters, w, past_ok, in_order, 0) == NULL;
}

/* usual_words_in's steps from p: the line's ending at end (to_lf 0), or (to_lf 1) a line
 * whose LF is not known yet: the first LF a word's value (or the command) ends at, end a
 * bound (p before it; a word starts only before it and its value's digit runs are
 * RUN_BOUNDED: every byte read is before end + 7, and a word or value that reaches end is
 * not read).  Such a LF has only the words' bytes before it: a line of ASCII
 * bytes, no other LF in it, read as usual_words_in reads it.  The LF (end, for to_lf 0),
 * or NULL (usual_words_in's 1). */
static inline __attribute__((always_inline)) const unsigned char *
usual_words_to(const unsigned char *p, const unsigned char *end, unsigned letters, Words *w, const int past_ok,
               const int in_order, const int to_lf)
{
    unsigned seen = 0;
    int nw = 0;
    for (;;) {
        if (to_lf) {
            if (p >= end)
                return NULL;
            if (*p == '\n')
                break;
        } else if (p == end)
            break;
        unsigned bit = LETTER_BIT[p[1]] & letters;
        if (p[0] != ' ' || !bit || (seen & bit))
            return NULL;
        size_t c = (size_t)p[1] - 'A';
        p += 2;
        double sign = 1.0;              /* (v * -1.0 is -v, bit for bit: no test of a flag after) */
        if (__builtin_expect(*p == '-', 0)) {
            sign = -1.0;
            p++;
        }
        unsigned long long m;
        Py_ssize_t frac, digits = scan_plain_decimal(&p, end, &m, &frac, to_lf ? RUN_BOUNDED : past_ok);
        if ((size_t)(digits - 1) >= 15)
            return NULL;                /* (a value ended by a point or sign: the next step's NULL) */
        /* (exact: m < 10^15; frac 0 divides by 1.0, exact: no test of frac, an unpredictable
         * branch where integer and decimal values mix) */
        double v = (double)(long long)m / POW10[frac];
        w->by[c] = v * sign;
        seen |= bit;
        if (in_order)
            w->letter[nw++] = (char)('A' + c);
    }
    if (in_order)
        w->n = nw;
    w->seen = seen;
    return p;
}

static __attribute__((noinline)) int usual_words(const unsigned char *s, Py_ssize_t n, Py_ssize_t k, unsigned letters,
                                                 Words *w)
{
    if (past_readable(s, n))
        return usual_words_in(s, n, k, letters, w, 1, 1);
    return usual_words_in(s, n, k, letters, w, 0, 1);
}
#endif

/* read_words: usual_words where it reads the line, else read_words_in's general steps.  Two
 * functions the callers call (none inlined): usual_words' call saves no more registers than
 * its loop needs, where a function holding both paths saved all the general steps' on every
 * line (~25 instructions a line) */
static __attribute__((noinline)) int read_words_gen(const unsigned char *s, Py_ssize_t n, Py_ssize_t k,
                                                    unsigned letters, Words *w)
{
    if (k < n && (s[n - 1] == '\n' || s[n - 1] == '\r'))
        return read_words_in(s, n, k, letters, w, 1);
    return read_words_in(s, n, k, letters, w, 0);
}

static inline int read_words(const unsigned char *s, Py_ssize_t n, Py_ssize_t k, unsigned letters, Words *w)
{
#ifdef FAST_DECIMAL
    if (k < n && (s[n - 1] == '\n' || s[n - 1] == '\r') && usual_words(s, n, k, letters, w) == 0)
        return 0;
#endif
    return read_words_gen(s, n, k, letters, w);
}

/* read_words of a G0/G1 (s[0:2], words from s[2]), usual_words' loop inlined (the fused
 * readers' callers save every register already: the call's own saves and moves were the
 * cost), the words' order and count not kept where it reads the line (w->letter and w->n:
 * only an M204's words are read in order) */
static inline __attribute__((always_inline)) int read_g_words(const unsigned char *s, Py_ssize_t n, Words *w)
{
#ifdef FAST_DECIMAL
    if (2 < n && s[n - 1] == '\n' && past_readable(s, n) && usual_words_in(s, n, 2, G_LETTERS, w, 1, 0) == 0)
        return 0;
#endif
    return read_words(s, n, 2, G_LETTERS, w);
}

static inline int word(const Words *w, char c, double *out)
{
    if (!(w->seen & LETTER(c)))
        return 0;
    *out = w->by[c - 'A'];
    return 1;
}

/* the i-th word's value (in the line's order) */
static inline double word_val(const Words *w, int i)
{
    return w->by[w->letter[i] - 'A'];
}

/* Borrowed attribute of the state (its instance dict), NULL if absent. */
#define GET(i) PyDict_GetItemWithError(dict, state_name[i])

static PyObject *slow(PyObject *self, PyObject *idx, PyObject *raw)
{
    PyObject *args[3] = {self, idx, raw};
    return PyObject_VectorcallMethod(NAME_SLOW, args, 3 | PY_VECTORCALL_ARGUMENTS_OFFSET, NULL);
}

static inline int exact_float(PyObject *o, double *out)
{
    if (o == NULL || !PyFloat_CheckExact(o))
        return 0;
    *out = PyFloat_AS_DOUBLE(o);
    return 1;
}

static PyObject *new_move(PyObject **val)
{
    PyObject *m = MOVE_TYPE->tp_alloc(MOVE_TYPE, 0);
    if (m == NULL)
        return NULL;
    for (int i = 0; i < MV_N; i++) {
        Py_INCREF(val[i]);
        *(PyObject **)((char *)m + move_off[i]) = val[i];
    }
    return m;
}

/* The doubles state._linear(idx, raw, p, False) computes for a G0/G1 of the fast shape,
 * from the state's x y z e v speed_r and modes: shared by linear() (which makes the Move
 * and writes the state) and the firmware core's fused loop (fused_line), so both give the
 * same bits.  o->fallback: Python decides (F out of range: _feed; a target out of range:
 * _check_target raises). */
typedef struct {
    double x0, y0, z0, e, v, speed;
    int abs_xyz, e_rel_flag, one;
} LinIn;

typedef struct {
    int fallback, has_f, has_x, has_y, has_z, e_rel;
    double x, y, z, de, v;            /* the target, E moved, the feed (mm/s) now in force */
} LinOut;

static inline __attribute__((always_inline)) void linear_calc(const LinIn *in, const Words *w, LinOut *o)
{
    o->fallback = 1;
    double f = 0.0, px = 0.0, py = 0.0, pz = 0.0, ev = 0.0;
    double v = in->v;
    o->has_f = word(w, 'F', &f);
    if (o->has_f) {
        if (!(0.0 < f && f <= MAX_F))
            return;                        /* _feed decides (or raises) */
        v = f / 60.0;
    }
    int has_x = word(w, 'X', &px), has_y = word(w, 'Y', &py), has_z = word(w, 'Z', &pz);
    int has_e = word(w, 'E', &ev);
    double x, y, z;
    if (in->abs_xyz) {
        x = has_x ? px : in->x0;
        y = has_y ? py : in->y0;
        z = has_z ? pz : in->z0;
    } else {
        x = in->x0 + (has_x ? px : 0.0);
        y = in->y0 + (has_y ? py : 0.0);
        z = in->z0 + (has_z ? pz : 0.0);
    }
    int e_rel = in->e_rel_flag || !in->abs_xyz;
    double de = !has_e ? 0.0 : (e_rel ? ev : ev - in->e);
    const double b = MAX_POS_D;
    /* (-b <= x <= b is |x| <= b for every b and x, NaN and -0.0 too: three tests, one
       branch, where the pairs of compares took six branches a line) */
    int in_range = (fabs(x) <= b) & (fabs(y) <= b) & (fabs(z) <= b);
    if (!in_range || (has_e && !(fabs(ev) <= MAX_E_D)))
        return;                            /* _check_target raises */
    o->fallback = 0;
    o->has_x = has_x;
    o->has_y = has_y;
    o->has_z = has_z;
    o->e_rel = e_rel;
    o->x = x;
    o->y = y;
    o->z = z;
    o->de = de;
    o->v = v;
}

/* G0/G1 of the fast shape: state._linear(idx, raw, p, False) as Python runs it.
 * Returns a new reference, or NULL with *fallback set (nothing changed) or an error. */
static void kept_moved(PyObject *dict, uint64_t tag0, PyObject *x, PyObject *y, PyObject *z, PyObject *e,
                       PyObject *v);
static uint64_t kept_tag(PyObject *dict);

static PyObject *linear(PyObject *dict, PyObject *idx, const Words *w, int *fallback)
{
    *fallback = 1;
    uint64_t tag0 = kept_tag(dict);     /* (before any write: kept_moved) */
    PyObject *o_x = GET(S_X), *o_y = GET(S_Y), *o_z = GET(S_Z), *o_e = GET(S_E);
    PyObject *o_abs = GET(S_ABS), *o_erel = GET(S_EREL), *o_inch = GET(S_INCH);
    PyObject *o_v = GET(S_V), *o_speed = GET(S_SPEED), *o_one = GET(S_ONE);
    PyObject *o_feature = GET(S_FEATURE), *o_layer = GET(S_LAYER), *o_flow = GET(S_FLOW);
    PyObject *o_ap = GET(S_ACC_PRINT), *o_at = GET(S_ACC_TRAVEL), *o_ar = GET(S_ACC_RETRACT);
    PyObject *o_lim = GET(S_LIM);
    if (PyErr_Occurred()) {
        PyErr_Clear();
        return NULL;
    }
    LinIn in;
    if (!exact_float(o_x, &in.x0) || !exact_float(o_y, &in.y0) || !exact_float(o_z, &in.z0)
        || !exact_float(o_e, &in.e) || !exact_float(o_v, &in.v) || !exact_float(o_speed, &in.speed))
        return NULL;
    if (o_inch != Py_False || (o_abs != Py_True && o_abs != Py_False)
        || (o_erel != Py_True && o_erel != Py_False) || (o_one != Py_True && o_one != Py_False)
        || !o_feature || !o_layer || !o_flow || !o_ap || !o_at || !o_ar || !o_lim)
        return NULL;
    in.abs_xyz = o_abs == Py_True;
    in.e_rel_flag = o_erel == Py_True;
    in.one = o_one == Py_True;
    LinOut lo;
    linear_calc(&in, w, &lo);
    if (lo.fallback)
        return NULL;
    double x0 = in.x0, y0 = in.y0, z0 = in.z0, e = in.e, speed = in.speed;
    double x = lo.x, y = lo.y, z = lo.z, de = lo.de, v = lo.v;
    int has_f = lo.has_f, has_x = lo.has_x, has_y = lo.has_y, has_z = lo.has_z;
    int abs_xyz = in.abs_xyz, e_rel = lo.e_rel;
    *fallback = 0;

    /* the objects Python would hold: a value taken from p is a new float, a value kept is
     * the state's own object, a sum is a new float */
    PyObject *nx = NULL, *ny = NULL, *nz = NULL, *ne = NULL, *nv = NULL, *nde = NULL, *vs = NULL;
    PyObject *res = NULL;
    nx = (abs_xyz && !has_x) ? (Py_INCREF(o_x), o_x) : PyFloat_FromDouble(x);
    ny = (abs_xyz && !has_y) ? (Py_INCREF(o_y), o_y) : PyFloat_FromDouble(y);
    nz = (abs_xyz && !has_z) ? (Py_INCREF(o_z), o_z) : PyFloat_FromDouble(z);
    ne = PyFloat_FromDouble(e + de);
    nv = has_f ? PyFloat_FromDouble(v) : (Py_INCREF(o_v), o_v);
    if (!nx || !ny || !nz || !ne || !nv)
        goto done;
    /* keep the old objects alive while the dict lets go of them */
    Py_INCREF(o_x);
    Py_INCREF(o_y);
    Py_INCREF(o_z);
    Py_INCREF(o_v);
    PyObject *ox = o_x, *oy = o_y, *oz = o_z, *ov = o_v;
    Py_INCREF(o_feature);
    Py_INCREF(o_layer);
    Py_INCREF(o_flow);
    Py_INCREF(o_ap);
    Py_INCREF(o_at);
    Py_INCREF(o_ar);
    Py_INCREF(o_lim);
    Py_INCREF(o_speed);
    int err = 0;
    if (has_f)
        err |= PyDict_SetItem(dict, state_name[S_V], nv) < 0;
    err |= PyDict_SetItem(dict, state_name[S_X], nx) < 0;
    err |= PyDict_SetItem(dict, state_name[S_Y], ny) < 0;
    err |= PyDict_SetItem(dict, state_name[S_Z], nz) < 0;
    err |= PyDict_SetItem(dict, state_name[S_E], ne) < 0;
    if (!err) {
        kept_moved(dict, tag0, nx, ny, nz, ne, has_f ? nv : NULL);
        if (x == x0 && y == y0 && z == z0 && de == 0.0) {
            res = Py_None;
            Py_INCREF(res);
        } else {
            nde = PyFloat_FromDouble(de);
            vs = PyFloat_FromDouble(v * speed);
            if (nde && vs) {
                PyObject *val[MV_N];
                int eonly = x == x0 && y == y0 && z == z0;
                val[MV_IDX] = idx;
                val[MV_X0] = ox;
                val[MV_Y0] = oy;
                val[MV_Z0] = oz;
                val[MV_X1] = nx;
                val[MV_Y1] = ny;
                val[MV_Z1] = nz;
                val[MV_E] = nde;
                val[MV_V] = vs;
                val[MV_LAYER] = o_layer;
                val[MV_LIM] = o_lim;
                val[MV_ARC] = Py_None;
                val[MV_HAS_F] = has_f ? Py_True : Py_False;
                val[MV_E_REL] = e_rel ? Py_True : Py_False;
                val[MV_XYZ_REL] = abs_xyz ? Py_False : Py_True;
                val[MV_CHECKSUM] = Py_False;
                val[MV_INCH] = o_inch;
                val[MV_FLOW_R] = o_flow;
                val[MV_SPEED_R] = o_speed;
                if (eonly) {
                    val[MV_KIND] = EONLY_K;
                    val[MV_ACCEL] = o_ar;
                    val[MV_FEATURE] = o_feature;
                } else if (de > 0.0) {
                    val[MV_KIND] = LINE_K;
                    val[MV_ACCEL] = o_ap;
                    val[MV_FEATURE] = o_feature;
                } else {
                    val[MV_KIND] = LINE_K;
                    val[MV_ACCEL] = o_one == Py_True ? o_ap : o_at;
                    val[MV_FEATURE] = TRAVEL;
                }
                res = new_move(val);
            }
        }
    }
    Py_DECREF(ox);
    Py_DECREF(oy);
    Py_DECREF(oz);
    Py_DECREF(ov);
    Py_DECREF(o_feature);
    Py_DECREF(o_layer);
    Py_DECREF(o_flow);
    Py_DECREF(o_ap);
    Py_DECREF(o_at);
    Py_DECREF(o_ar);
    Py_DECREF(o_lim);
    Py_DECREF(o_speed);
done:
    Py_XDECREF(nx);
    Py_XDECREF(ny);
    Py_XDECREF(nz);
    Py_XDECREF(ne);
    Py_XDECREF(nv);
    Py_XDECREF(nde);
    Py_XDECREF(vs);
    return res;
}

/* state._m204(idx, raw, p) with p the words as Python's fast path builds it. */
static int m204_python(PyObject *self, PyObject *idx, PyObject *raw, const Words *w)
{
    PyObject *p = PyDict_New();
    if (p == NULL)
        return -1;
    for (int i = 0; i < w->n; i++) {
        char key[2] = {w->letter[i], '\0'};
        PyObject *v = PyFloat_FromDouble(word_val(w, i));
        if (v == NULL || PyDict_SetItemString(p, key, v) < 0) {
            Py_XDECREF(v);
            Py_DECREF(p);
            return -1;
        }
        Py_DECREF(v);
    }
    PyObject *margs[4] = {self, idx, raw, p};
    PyObject *r = PyObject_VectorcallMethod(NAME_M204, margs, 4 | PY_VECTORCALL_ARGUMENTS_OFFSET, NULL);
    Py_DECREF(p);
    if (r == NULL)
        return -1;
    Py_DECREF(r);
    return 0;
}

/* The flavours state._m204 reads in its own way (m204() and sess_m204() here); ACC_OTHER:
 * Python reads the M204 (another flavour, or a flavour attribute not a str) */
enum { ACC_UNKNOWN = -1, ACC_OTHER, ACC_KLIPPER, ACC_LEGACY, ACC_MARLIN };

/* The flavour object last compared as text, and its kind: a file's M204s read under one
 * flavour str compare it once.  The reference held keeps its address from being another's. */
static PyObject *KIND_OF = NULL;
static int KIND = ACC_OTHER;

/* the ACC_* kind of the state's flavour attribute (dict: its instance dict) */
static int acc_kind(PyObject *dict)
{
    PyObject *fl = PyDict_GetItemWithError(dict, NAME_FLAVOUR);
    if (fl == NULL) {
        PyErr_Clear();
        return ACC_OTHER;
    }
    if (fl == KIND_OF)
        return KIND;
    if (!PyUnicode_CheckExact(fl))
        return ACC_OTHER;
    int kind = ACC_OTHER;
    if (PyUnicode_CompareWithASCIIString(fl, "klipper") == 0)
        kind = ACC_KLIPPER;
    else if (PyUnicode_CompareWithASCIIString(fl, "marlin-legacy") == 0)
        kind = ACC_LEGACY;
    else if (PyUnicode_CompareWithASCIIString(fl, "marlin2") == 0 || PyUnicode_CompareWithASCIIString(fl, "rrf") == 0)
        kind = ACC_MARLIN;
    Py_INCREF(fl);
    Py_XSETREF(KIND_OF, fl);
    KIND = kind;
    return kind;
}

/* 1 if every value of an M204's words is in (0, MAX_ACCEL_A], else 0 (state._positive
 * raises: Python reads the line) */
static int m204_in_range(const Words *w)
{
    for (int i = 0; i < w->n; i++) {
        double val = word_val(w, i);
        if (!(0.0 < val && val <= MAX_ACCEL_A))
            return 0;                  /* _positive raises (Klipper: only for S, or P/T without S) */
    }
    return 1;
}

/* An M204's words, in m204_pick's order */
enum { W_S, W_P, W_T, W_R, W_CUR, W_NONE = -1 };
static const char M204_KEYS[4] = {'S', 'P', 'T', 'R'};

/* An M204's S P T R as new floats (NULL where not given): 1, or 0 where a value given is
 * not in (0, MAX_ACCEL_A] (m204_in_range; nothing made), -1 on error. */
static int m204_words(const Words *w, PyObject *o[4])
{
    double val;
    if (!m204_in_range(w))
        return 0;
    for (int k = 0; k < 4; k++) {
        o[k] = NULL;
        if (word(w, M204_KEYS[k], &val) && (o[k] = PyFloat_FromDouble(val)) == NULL) {
            for (int j = 0; j < k; j++)
                Py_XDECREF(o[j]);
            return -1;
        }
    }
    return 1;
}

/* state._m204's rule for the flavour kind (not ACC_OTHER): the word (W_S W_P W_T W_R) whose
 * value (one object: Python's p[k]) the print, travel and retract accelerations take;
 * W_NONE: that one unchanged.  Klipper's travel is the print acceleration in force (W_CUR)
 * where neither S nor both P and T are given: then the print is W_CUR too (unchanged). */
static void m204_pick(int kind, const Words *w, int *print, int *travel, int *retract)
{
    int S = (w->seen & LETTER('S')) != 0, P = (w->seen & LETTER('P')) != 0;
    int T = (w->seen & LETTER('T')) != 0, R = (w->seen & LETTER('R')) != 0;
    *print = *travel = *retract = W_NONE;
    switch (kind) {
    case ACC_KLIPPER:
        if (S)
            *print = W_S;
        else if (P && T)
            *print = w->by['T' - 'A'] < w->by['P' - 'A'] ? W_T : W_P;   /* min(P, T) */
        else
            *print = W_CUR;
        *travel = *print;
        break;
    case ACC_LEGACY:
        if (S) {
            *print = *travel = W_S;
            *retract = T ? W_T : W_NONE;
        } else {
            *print = *travel = P ? W_P : W_NONE;
            *retract = R ? W_R : W_NONE;
        }
        break;
    default:                           /* ACC_MARLIN */
        *print = *travel = S ? W_S : W_NONE;
        if (P)
            *print = W_P;
        if (T)
            *travel = W_T;
        *retract = R ? W_R : W_NONE;
    }
}

/* state._m204 where every value given is in (0, MAX_ACCEL_A] and the flavour is one it
 * knows: 1 when done, 0 to let Python do it (it raises or reads another flavour), -1 on
 * error.  The values stored are the p values Python would store (one object where Python
 * stores the same p[k] twice). */
static int m204(PyObject *dict, const Words *w)
{
    int kind = acc_kind(dict);
    if (kind == ACC_OTHER)
        return 0;
    PyObject *o[4];
    int got = m204_words(w, o);
    if (got <= 0)
        return got;
    int rc = -1;
    PyObject *cur = NULL;
    int pw, tw, rw;
    m204_pick(kind, w, &pw, &tw, &rw);
    if (pw == W_CUR) {                 /* travel = the print in force */
        cur = PyDict_GetItemWithError(dict, state_name[S_ACC_PRINT]);
        if (cur == NULL) {
            if (!PyErr_Occurred())
                rc = 0;                /* no attribute: Python's AttributeError */
            goto out;
        }
    }
    PyObject *print = pw == W_CUR ? cur : pw >= 0 ? o[pw] : NULL;
    PyObject *travel = tw == W_CUR ? cur : tw >= 0 ? o[tw] : NULL;
    PyObject *retract = rw >= 0 ? o[rw] : NULL;
    Py_XINCREF(print);             /* print may be the dict's own object */
    if ((print && PyDict_SetItem(dict, state_name[S_ACC_PRINT], print) < 0)
        || (travel && PyDict_SetItem(dict, state_name[S_ACC_TRAVEL], travel) < 0)
        || (retract && PyDict_SetItem(dict, state_name[S_ACC_RETRACT], retract) < 0)) {
        Py_XDECREF(print);
        goto out;
    }
    Py_XDECREF(print);
    rc = 1;
out:
    for (int k = 0; k < 4; k++)
        Py_XDECREF(o[k]);
    return rc;
}

/* ---------------------------------------------------------------- lines that change little
 * The commands _step_python reads (state.COMMANDS_READ, given to setup): any other classic
 * command ("M73 P5", "M107", "T0", "M862.3 P", ...) returns None there and changes nothing
 * (no word of it is parsed), so it needs no Python. */
#define MAX_CMDS 64
static char CMDS[MAX_CMDS][16];
static int N_CMDS = -1;           /* -1: not given (every command goes to Python) */

static int read_cmds(PyObject *cmds)
{
    N_CMDS = -1;
    if (cmds == NULL || cmds == Py_None)
        return 0;
    PyObject *it = PyObject_GetIter(cmds);
    if (it == NULL)
        return -1;
    int n = 0, ok = 1;
    PyObject *c;
    while ((c = PyIter_Next(it)) != NULL) {
        const char *t = PyUnicode_Check(c) && PyUnicode_IS_ASCII(c) ? PyUnicode_AsUTF8(c) : NULL;
        if (t == NULL || n == MAX_CMDS || strlen(t) >= sizeof(CMDS[0]))
            ok = 0;
        else
            strcpy(CMDS[n++], t);
        Py_DECREF(c);
    }
    Py_DECREF(it);
    if (PyErr_Occurred())
        return -1;
    if (ok)
        N_CMDS = n;
    return 0;
}

/* s[0:code_n] a command _step_python returns None for without reading it: a classic
 * command word at the line's start (letter, digits, none of N or a '*' in the code: no
 * line number, no checksum) whose name as words.command_of gives it ("G01" is "G1",
 * "M862.3" keeps its fraction) is not one it reads. */
static int noop_command(const unsigned char *s, Py_ssize_t code_n)
{
    if (N_CMDS < 0 || code_n < 2 || memchr(s, '*', code_n) != NULL)
        return 0;
    unsigned char c0 = s[0];
    if (c0 >= 'a' && c0 <= 'z')
        c0 = (unsigned char)(c0 - 'a' + 'A');
    if (c0 < 'A' || c0 > 'Z' || c0 == 'N' || !(s[1] >= '0' && s[1] <= '9'))
        return 0;
    Py_ssize_t j = 1;
    while (j < code_n && s[j] == '0')      /* int(whole): no leading zeros */
        j++;
    Py_ssize_t w0 = j;
    while (j < code_n && s[j] >= '0' && s[j] <= '9')
        j++;
    if (j - w0 > 9)
        return 0;
    if (j + 1 < code_n && s[j] == '.' && s[j + 1] >= '0' && s[j + 1] <= '9')
        return 1;                          /* a fraction: none of the commands read has one */
    char name[16];
    name[0] = (char)c0;
    Py_ssize_t k = 1;
    if (j == w0)
        name[k++] = '0';
    for (Py_ssize_t i = w0; i < j; i++)
        name[k++] = (char)s[i];
    name[k] = '\0';
    for (int i = 0; i < N_CMDS; i++)
        if (strcmp(name, CMDS[i]) == 0)
            return 0;
    return 1;
}

/* A comment-only line a marker starts (c[0:n], from its ';' to the line's end): what
 * _step_python does with it -- features.feature_from_comment's feature (comment
 * .strip().lower() starting with a prefix: the rest, stripped, looked up in _NAMES, else
 * OTHER) into state.feature, else (a layer marker) state.layer += 1 -- done in the state's
 * dict.  A feature also sets feature_seen (analyse's `seen` of the lines read in C).  1
 * done (*feature: the feature set, borrowed, or NULL; a comment marked only before its
 * strip changes nothing), 0 Python decides (nothing changed: no _NAMES, a layer that is
 * not an int), -1 error. */
static void kept_marked(PyObject *dict, uint64_t tag0, int k, PyObject *o);

static int marked_comment(PyObject *dict, const unsigned char *c, Py_ssize_t n, PyObject **feature)
{
    *feature = NULL;
    uint64_t tag0 = kept_tag(dict);     /* (before any write: kept_marked) */
    if (FEATURE_NAMES == NULL || N_MARKS < 0)
        return 0;
    while (n > 0 && is_split_space(c[n - 1]))      /* strip(): the comment starts with ';' */
        n--;
    for (int i = 0; i < N_MARKS; i++) {
        const char *m = MARKS[i];
        Py_ssize_t j = 0;
        for (; m[j] != '\0' && j < n; j++) {
            unsigned char ch = c[j];
            if (ch >= 'A' && ch <= 'Z')
                ch = (unsigned char)(ch - 'A' + 'a');
            if (ch != (unsigned char)m[j])
                break;
        }
        if (m[j] != '\0')
            continue;
        if (i >= N_PREFIX) {                       /* a layer marker (no prefix starts it) */
            PyObject *layer = GET(S_LAYER);
            if (layer == NULL || !PyLong_CheckExact(layer)) {
                PyErr_Clear();
                return 0;
            }
            PyObject *one = PyLong_FromLong(1);
            PyObject *next = one ? PyNumber_Add(layer, one) : NULL;
            Py_XDECREF(one);
            int rc = next == NULL ? -1 : PyDict_SetItem(dict, state_name[S_LAYER], next);
            if (rc == 0)
                kept_marked(dict, tag0, S_LAYER, next);
            Py_XDECREF(next);
            return rc < 0 ? -1 : 1;
        }
        Py_ssize_t a = j, b = n;                   /* the name: the rest, stripped, lowercased */
        while (a < b && is_split_space(c[a]))
            a++;
        PyObject *key = PyUnicode_New(b - a, 127);
        if (key == NULL)
            return -1;
        Py_UCS1 *k = PyUnicode_1BYTE_DATA(key);
        for (Py_ssize_t t = a; t < b; t++)
            k[t - a] = (c[t] >= 'A' && c[t] <= 'Z') ? (Py_UCS1)(c[t] - 'A' + 'a') : c[t];
        PyObject *f = PyDict_GetItemWithError(FEATURE_NAMES, key);
        Py_DECREF(key);
        if (f == NULL && PyErr_Occurred())
            return -1;
        if (f == NULL)
            f = FEATURE_OTHER;
        Py_INCREF(f);                              /* (held while the dict lets go of the old one) */
        int rc = PyDict_SetItem(dict, state_name[S_FEATURE], f) < 0
                 || PyDict_SetItem(dict, state_name[S_SEEN], Py_True) < 0 ? -1 : 1;
        if (rc == 1)
            kept_marked(dict, tag0, S_FEATURE, f);
        Py_DECREF(f);
        *feature = f;                              /* (the dict holds it) */
        return rc;
    }
    return 1;                 /* marked only before the strip ("; feature " + spaces): nothing to do */
}

/* What kind of line s[0..n) is, for step() and fused_line(): SHAPE_PYTHON (the Python
 * reader must read it: a stray CR, which Python rejects; lf: the caller knows the line holds
 * no CR, as play_buf and a Lines know their blocks' -- no look for one), SHAPE_NOTHING (a blank line, a
 * comment no marker starts: it changes nothing), SHAPE_MARKED (a comment a marker starts:
 * marked_comment; *code_n: where its ';' is), or
 * SHAPE_CODE (a command; *code_n: the length before any ';': the callers read a G0/G1 or
 * M204 of the fast shape, answer a command noop_command finds, and hand the rest to Python). */
enum { SHAPE_PYTHON, SHAPE_NOTHING, SHAPE_CODE, SHAPE_MARKED };

/* the length of the line's code: before its first ';' */
static inline Py_ssize_t code_len(const unsigned char *s, Py_ssize_t n)
{
    const unsigned char *semi = memchr(s, ';', (size_t)n);
    return semi ? semi - s : n;
}

/* A line line_shape finds SHAPE_CODE without reading more than its first character: no CR
 * in it (lf), two characters at least, and a command first (neither a blank nor a ';').
 * The fused readers take such a line (nearly every line the measure pass plays) without
 * line_shape's look for a ';': read_words stops at one itself, and code_len finds it only
 * for a line that goes on to noop_command. */
static inline int command_line(const unsigned char *s, Py_ssize_t n, int lf)
{
    return lf && n >= 2 && s[0] != ';' && !is_split_space(s[0]);
}

static int line_shape(const unsigned char *s, Py_ssize_t n, int lf, Py_ssize_t *code_n)
{
    if (n < 1)
        return SHAPE_PYTHON;
    /* a CR anywhere but in the trailing run of CR/LF, or a CR last: Python raises */
    if (!lf) {
        Py_ssize_t t = n;
        while (t > 0 && (s[t - 1] == '\r' || s[t - 1] == '\n'))
            t--;
        if (s[n - 1] == '\r' || memchr(s, '\r', t) != NULL)
            return SHAPE_PYTHON;
    }
    *code_n = code_len(s, n);
    Py_ssize_t k = 0;
    while (k < *code_n && is_split_space(s[k]))
        k++;
    if (k == *code_n)      /* no command: a blank line changes nothing; a comment only if it is marked */
        return (*code_n < n && marked(s + *code_n, n - *code_n)) ? SHAPE_MARKED : SHAPE_NOTHING;
    return n < 2 ? SHAPE_PYTHON : SHAPE_CODE;
}

/* line_shape for the fused readers: a line whose first byte is ';' and that holds no CR (lf)
 * is a comment only (its code empty: code_len 0, no look for its ';'), marked or not --
 * line_shape's answer without its call and memchr's (a written file's fences: ~80 k
 * lines in the measure pass of a plate) */
static inline int fused_shape(const unsigned char *s, Py_ssize_t n, int lf, Py_ssize_t *code_n)
{
    if (lf && n >= 1 && s[0] == ';') {
        *code_n = 0;
        return marked(s, n) ? SHAPE_MARKED : SHAPE_NOTHING;
    }
    return line_shape(s, n, lf, code_n);
}

/* step(self, idx, raw): the Move, None, or what MachineState._step_python returns. */
static PyObject *step(PyObject *module, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3)
        return PyErr_Format(PyExc_TypeError, "step() takes 3 arguments (%zd given)", nargs);
    PyObject *self = args[0], *idx = args[1], *raw = args[2];
    if (!READY || Py_TYPE(self) != STATE_TYPE || !PyUnicode_CheckExact(raw) || !PyUnicode_IS_ASCII(raw))
        return slow(self, idx, raw);       /* not ASCII: the BOM, or anything unusual */
    const unsigned char *s = PyUnicode_1BYTE_DATA(raw);
    Py_ssize_t code_n = 0;
    switch (line_shape(s, PyUnicode_GET_LENGTH(raw), 0, &code_n)) {
    case SHAPE_PYTHON:
        return slow(self, idx, raw);
    case SHAPE_NOTHING:
        Py_RETURN_NONE;
    case SHAPE_MARKED: {
        PyObject *dict = PyObject_GenericGetDict(self, NULL), *f;
        if (dict == NULL) {
            PyErr_Clear();
            return slow(self, idx, raw);
        }
        int done = marked_comment(dict, s + code_n, PyUnicode_GET_LENGTH(raw) - code_n, &f);
        Py_DECREF(dict);
        if (done < 0)
            return NULL;
        if (!done)
            return slow(self, idx, raw);
        Py_RETURN_NONE;
    }
    }
    Words w;
    if (code_n >= 2 && s[0] == 'G' && (s[1] == '0' || s[1] == '1')) {
        if (read_words(s, code_n, 2, G_LETTERS, &w) < 0)
            goto other;
        PyObject *dict = PyObject_GenericGetDict(self, NULL);
        if (dict == NULL) {
            PyErr_Clear();
            return slow(self, idx, raw);
        }
        int fallback;
        PyObject *res = linear(dict, idx, &w, &fallback);
        Py_DECREF(dict);
        if (res == NULL && fallback)
            return slow(self, idx, raw);
        return res;
    }
    if (code_n >= 4 && memcmp(s, "M204", 4) == 0) {
        if (read_words(s, code_n, 4, M204_LETTERS, &w) < 0)
            goto other;
        PyObject *dict = PyObject_GenericGetDict(self, NULL);
        if (dict == NULL)
            return NULL;
        int done = m204(dict, &w);
        Py_DECREF(dict);
        if (done < 0)
            return NULL;
        if (!done && m204_python(self, idx, raw, &w) < 0)
            return NULL;
        Py_RETURN_NONE;
    }
other:
    if (noop_command(s, code_n))
        Py_RETURN_NONE;
    return slow(self, idx, raw);
}

/* ---------------------------------------------------------------- the firmware core's fused loop
 * The compiled firmware core's Sim.play reads a chunk of lines through these functions
 * (a capsule, _C_API) instead of calling step() line by line: a G0/G1 or M204 of the fast
 * shape, a blank or unmarked comment line, is read here as step() reads it, but the Move
 * is handed over as doubles (FusedMove) and the state's x y z e v live in C (Session)
 * until a line step() would hand to Python, or the chunk's end: then they are written
 * back (the values step() would have left).  The doubles are linear_calc's, the ones
 * linear() puts into the Move, so the model gets the same bits. */
#define FUSED_LAYOUT "FusedMove 1: int kind; double x0 y0 z0 x1 y1 z1 e v accel flow_r; PyObject *lim" \
    " | RunMove 2: FusedMove fm; double e1 v1 speed; int has_f e_rel xyz_rel; PyObject *feature *accel;" \
    " double e0" \
    " | peek commit 4 | Lines line_ascii peek_ascii lf 6 | run_ascii 7 | lines_raw 8"
typedef struct {
    int kind;                         /* 0 a line, 1 E only */
    double x0, y0, z0, x1, y1, z1, e, v, accel, flow_r;
    PyObject *lim;                    /* borrowed: the state's Limits */
} FusedMove;

/* A line move as the analyse pass's run loop reads it (fused_peek): the FusedMove, the
 * state's e and v after the line, and what the Move would hold besides */
typedef struct {
    FusedMove fm;
    double e1, v1, speed;             /* the state's e and v after the line; Move.speed_r */
    int has_f, e_rel, xyz_rel;
    PyObject *feature, *accel;        /* borrowed: the Move's feature and accel objects */
    double e0;                        /* the state's e before the line (analyse's start_state) */
} RunMove;

/* The three accelerations (accel_print, accel_travel, accel_retract) as a session holds them */
enum { A_P, A_T, A_R, A_N };
static const int ACC_NAME[A_N] = {S_ACC_PRINT, S_ACC_TRAVEL, S_ACC_RETRACT};

typedef struct {
    PyObject *state, *dict;           /* new references */
    int off;                          /* not a MachineState step() reads: every line goes to step() */
    int live;                         /* in holds the state (read at load, kept since) */
    int dirty, dirty_v;               /* x y z e (and v) changed since load */
    LinIn in;
    double loaded[5];                 /* x y z e v as the dict held them at load (sess_flush) */
    double acc[A_N], flow;            /* the Move's accel objects and flow_r, as the model reads them */
    PyObject *lim;                    /* borrowed from dict */
    PyObject *o_feature;              /* borrowed from dict: fused_peek's Move feature */
    /* The accel objects a Move would hold (fused_peek's): borrowed from dict, but a slot
     * whose bit is set in acc_own is an M204's (sess_m204) not yet written: a new reference
     * the session holds until sess_flush writes it to the dict, or NULL: the object not
     * made yet (sess_acc_obj makes it where a Move or the dict needs it; the measure pass
     * reads ~360 k M204s a plate and needs none).  Two slots may hold one object, as
     * Python's `self.accel_print = self.accel_travel = p["S"]` stores one: slots not made
     * yet that took the same word have the same acc_word. */
    PyObject *o_acc[A_N];
    int acc_own;
    long long acc_word[A_N];          /* an M204 slot not made yet: m204_n * 4 + the word */
    long long m204_n;                 /* the session's M204s read */
    int acc_kind;                     /* ACC_*: the flavour's, read at the first M204 since load */
} Session;

/* the values sess_flush writes back, as the dict holds them now (the session's load) */
static inline void sess_mark_loaded(Session *ss)
{
    const double vals[5] = {ss->in.x0, ss->in.y0, ss->in.z0, ss->in.e, ss->in.v};
    memcpy(ss->loaded, vals, sizeof ss->loaded);
}

/* a number the model reads with PyFloat_AsDouble: an exact float or int; 0 otherwise */
static int num_double(PyObject *o, double *out)
{
    if (o != NULL && PyFloat_CheckExact(o)) {
        *out = PyFloat_AS_DOUBLE(o);
        return 1;
    }
    if (o != NULL && PyLong_CheckExact(o)) {
        double d = PyLong_AsDouble(o);
        if (d == -1.0 && PyErr_Occurred()) {
            PyErr_Clear();
            return 0;
        }
        *out = d;
        return 1;
    }
    return 0;
}

/* the accel objects from the dict (borrowed), and their numbers; 0 if one is not a number */
static int sess_accels(Session *ss)
{
    PyObject *dict = ss->dict;
    int ok = 1;
    for (int k = 0; k < A_N; k++) {
        ss->o_acc[k] = GET(ACC_NAME[k]);
        ok = ok && num_double(ss->o_acc[k], &ss->acc[k]);
    }
    return ok;
}

/* What a session read from a state's dict, kept past its write-back (sess_flush) with the
 * dict's version tag then: a later session on that dict, not changed since (the tag is
 * globally unique and moves at every change), takes it as sess_load would read it again,
 * without ~17 dict look-ups (~2.2 k instructions: each return of the firmware core's play
 * to Python at a stop of the measure pass, and of the analyse pass's loops, closes the
 * session and the next one loads it).  The objects are borrowed from the dict, alive
 * while it holds them, i.e. while the tag is unchanged.  Python 3.11 only (3.12 marks the
 * tag deprecated): elsewhere every load reads the dict. */
static PyObject *MODAL_NAMES = NULL;   /* snapshot's names (set_modal): a tuple of str */
static PyObject *MODAL_GET = NULL;     /* operator.attrgetter(*MODAL_NAMES) */

#if PY_VERSION_HEX >= 0x030B0000 && PY_VERSION_HEX < 0x030C0000
#define LOAD_CACHE 1
enum { MOD_MAX = 32 };
static struct {
    PyObject *dict;                   /* not a reference: compared only */
    uint64_t tag;                     /* 0: nothing kept */
    LinIn in;
    double acc[A_N], flow;
    PyObject *lim, *o_feature, *o_acc[A_N];
    /* snapshot()'s objects, MachineState.MODAL's values (mod_ok: all of them), kept on
     * through the writes made here (flush, linear, marked comments) */
    int mod_ok;
    PyObject *mod[MOD_MAX];
} LOADED;
static Py_ssize_t MOD_N = 0;          /* MODAL's names (set_modal), 0: none kept */
static int MOD_AT[S_N];               /* each state_name's index in MODAL + 1; 0: not there */

static inline uint64_t dict_tag(PyObject *dict)
{
    return ((PyDictObject *)dict)->ma_version_tag;
}

/* what was kept is the dict as it is (its tag unchanged since) */
static inline int kept_now(PyObject *dict)
{
    return LOADED.tag != 0 && LOADED.dict == dict && dict_tag(dict) == LOADED.tag;
}

/* the kept modal object of state_name[k] is now o (the dict's) */
static inline void mod_put(int k, PyObject *o)
{
    if (MOD_AT[k])
        LOADED.mod[MOD_AT[k] - 1] = o;
}

/* the modal objects read from the dict (sess_load's full read) */
static void mod_read(PyObject *dict)
{
    LOADED.mod_ok = 0;
    if (MOD_N == 0 || MODAL_NAMES == NULL)
        return;
    for (Py_ssize_t i = 0; i < MOD_N; i++)
        if ((LOADED.mod[i] = PyDict_GetItemWithError(dict, PyTuple_GET_ITEM(MODAL_NAMES, i))) == NULL) {
            PyErr_Clear();
            return;
        }
    LOADED.mod_ok = 1;
}

/* keep what a live session holds, the dict now holding the same (sess_load's values) */
static void sess_keep(const Session *ss)
{
    LOADED.dict = ss->dict;
    LOADED.tag = dict_tag(ss->dict);
    LOADED.in = ss->in;
    memcpy(LOADED.acc, ss->acc, sizeof LOADED.acc);
    memcpy(LOADED.o_acc, ss->o_acc, sizeof LOADED.o_acc);
    LOADED.flow = ss->flow;
    LOADED.lim = ss->lim;
    LOADED.o_feature = ss->o_feature;
}

/* step()'s G0/G1 (linear) moved x y z e (v: NULL if not) in a dict whose tag was tag0
 * before: what was kept for the dict then is kept on, with the new values (the analyse
 * pass's loops hand a line that ends a run to step(), then read on in a new session) */
static void kept_moved(PyObject *dict, uint64_t tag0, PyObject *x, PyObject *y, PyObject *z, PyObject *e,
                       PyObject *v)
{
    if (LOADED.tag == 0 || LOADED.dict != dict || LOADED.tag != tag0)
        return;
    LOADED.in.x0 = PyFloat_AS_DOUBLE(x);    /* (linear's objects: exact floats) */
    LOADED.in.y0 = PyFloat_AS_DOUBLE(y);
    LOADED.in.z0 = PyFloat_AS_DOUBLE(z);
    LOADED.in.e = PyFloat_AS_DOUBLE(e);
    mod_put(S_X, x);
    mod_put(S_Y, y);
    mod_put(S_Z, z);
    mod_put(S_E, e);
    if (v != NULL) {
        LOADED.in.v = PyFloat_AS_DOUBLE(v);
        mod_put(S_V, v);
    }
    LOADED.tag = dict_tag(dict);
}

/* marked_comment set state_name[k] to o (the feature, or the layer) in a dict whose tag
 * was tag0 before: kept on as kept_moved keeps on */
static void kept_marked(PyObject *dict, uint64_t tag0, int k, PyObject *o)
{
    if (LOADED.tag == 0 || LOADED.dict != dict || LOADED.tag != tag0)
        return;
    if (k == S_FEATURE)
        LOADED.o_feature = o;
    mod_put(k, o);
    LOADED.tag = dict_tag(dict);
}

static uint64_t kept_tag(PyObject *dict)
{
    return dict_tag(dict);
}

/* sess_load from what was kept, if the dict did not change since: 1 done (live) */
static int sess_load_kept(Session *ss)
{
    if (LOADED.tag == 0 || LOADED.dict != ss->dict || dict_tag(ss->dict) != LOADED.tag)
        return 0;
    ss->in = LOADED.in;
    memcpy(ss->acc, LOADED.acc, sizeof ss->acc);
    memcpy(ss->o_acc, LOADED.o_acc, sizeof ss->o_acc);
    ss->flow = LOADED.flow;
    ss->lim = LOADED.lim;
    ss->o_feature = LOADED.o_feature;
    ss->dirty = ss->dirty_v = 0;
    ss->acc_kind = ACC_UNKNOWN;
    ss->acc_own = 0;
    sess_mark_loaded(ss);
    ss->live = 1;
    return 1;
}
#endif

#ifndef LOAD_CACHE
static void kept_moved(PyObject *dict, uint64_t tag0, PyObject *x, PyObject *y, PyObject *z, PyObject *e,
                       PyObject *v)
{
    (void)dict, (void)tag0, (void)x, (void)y, (void)z, (void)e, (void)v;
}

static uint64_t kept_tag(PyObject *dict)
{
    (void)dict;
    return 0;
}

static void kept_marked(PyObject *dict, uint64_t tag0, int k, PyObject *o)
{
    (void)dict, (void)tag0, (void)k, (void)o;
}
#endif

/* A session not live yet goes live where that costs no look-up (sess_load_kept): an M204
 * or a marked comment before the session's first G0/G1 (after each stop of the measure
 * pass: "M204 S..", ";TYPE:..") is then read live, the dict left as it was kept; read
 * into the dict instead, it changed the tag, and the G0/G1 after it read the dict again.
 * The same state either way (a live session's M204s and features are written back). */
static inline void sess_wake(Session *ss)
{
#ifdef LOAD_CACHE
    if (!ss->live)
        sess_load_kept(ss);
#else
    (void)ss;
#endif
}

/* read the state as linear() would (live only where linear() would not fall back for it) */
static void sess_load(Session *ss)
{
    PyObject *dict = ss->dict;
#ifdef LOAD_CACHE
    if (sess_load_kept(ss))
        return;
#endif
    ss->live = ss->dirty = ss->dirty_v = 0;
    PyObject *o_abs = GET(S_ABS), *o_erel = GET(S_EREL), *o_inch = GET(S_INCH), *o_one = GET(S_ONE);
    ss->lim = GET(S_LIM);
    int ok = exact_float(GET(S_X), &ss->in.x0) && exact_float(GET(S_Y), &ss->in.y0)
             && exact_float(GET(S_Z), &ss->in.z0) && exact_float(GET(S_E), &ss->in.e)
             && exact_float(GET(S_V), &ss->in.v) && exact_float(GET(S_SPEED), &ss->in.speed)
             && o_inch == Py_False && (o_abs == Py_True || o_abs == Py_False)
             && (o_erel == Py_True || o_erel == Py_False) && (o_one == Py_True || o_one == Py_False)
             && (ss->o_feature = GET(S_FEATURE)) != NULL && GET(S_LAYER) != NULL && ss->lim != NULL
             && num_double(GET(S_FLOW), &ss->flow) && sess_accels(ss);
    if (PyErr_Occurred()) {
        PyErr_Clear();
        ok = 0;
    }
    if (!ok)
        return;
    ss->in.abs_xyz = o_abs == Py_True;
    ss->in.e_rel_flag = o_erel == Py_True;
    ss->in.one = o_one == Py_True;
    ss->acc_kind = ACC_UNKNOWN;       /* read at the session's first M204 */
    ss->acc_own = 0;
    sess_mark_loaded(ss);
    ss->live = 1;
#ifdef LOAD_CACHE
    mod_read(dict);
    sess_keep(ss);
#endif
}

/* slot k now holds slot `from`'s value and object (made or not), as Python's
 * `self.accel_travel = self.accel_print` stores it: the session's own until sess_flush */
static void sess_share_acc(Session *ss, int k, int from)
{
    PyObject *o = ss->o_acc[from];
    Py_XINCREF(o);                    /* first: o may be the object the slot lets go of */
    if (ss->acc_own & (1 << k))
        Py_XDECREF(ss->o_acc[k]);
    ss->o_acc[k] = o;
    ss->acc[k] = ss->acc[from];
    ss->acc_word[k] = ss->acc_word[from];
    ss->acc_own |= 1 << k;
}

/* slot k now holds val, the value of word `word` of the session's m204_n-th M204 (its
 * object not made yet): the session's own until sess_flush */
static inline __attribute__((always_inline)) void sess_set_value(Session *ss, int k, double val, int word)
{
    if (ss->acc_own & (1 << k))
        Py_XDECREF(ss->o_acc[k]);
    ss->o_acc[k] = NULL;
    ss->acc[k] = val;
    ss->acc_word[k] = ss->m204_n * 4 + word;
    ss->acc_own |= 1 << k;
}

static void sess_set_word(Session *ss, int k, const Words *w, int word)
{
    sess_set_value(ss, k, w->by[M204_KEYS[word] - 'A'], word);
}

/* slot k's object (borrowed from the session, or the dict where not the session's), made
 * now if an M204's not made yet: one float for every slot that took the same word; NULL on
 * error (set) */
static PyObject *sess_acc_obj(Session *ss, int k)
{
    if (ss->o_acc[k] != NULL)
        return ss->o_acc[k];
    PyObject *f = PyFloat_FromDouble(ss->acc[k]);
    if (f == NULL)
        return NULL;
    for (int j = 0; j < A_N; j++)
        if ((ss->acc_own & (1 << j)) && ss->o_acc[j] == NULL && ss->acc_word[j] == ss->acc_word[k]) {
            Py_INCREF(f);
            ss->o_acc[j] = f;
        }
    Py_DECREF(f);
    return ss->o_acc[k];
}

/* An M204 of the fast shape in a live session: m204()'s rules (state._m204's), the dict
 * left alone (sess_flush writes the slots; the floats made only where needed).  1 done, 0
 * Python decides (nothing changed: a value out of (0, MAX_ACCEL_A], another flavour). */
static int sess_m204(Session *ss, const Words *w)
{
    if (ss->acc_kind == ACC_UNKNOWN)
        ss->acc_kind = acc_kind(ss->dict);
    if (ss->acc_kind == ACC_OTHER || !m204_in_range(w))
        return 0;
    int pw, tw, rw;
    m204_pick(ss->acc_kind, w, &pw, &tw, &rw);
    ss->m204_n++;
    if (pw >= 0 && pw != W_CUR)                                /* (Klipper's print in force: kept) */
        sess_set_word(ss, A_P, w, pw);
    if (tw == W_CUR)
        sess_share_acc(ss, A_T, A_P);
    else if (tw >= 0)
        sess_set_word(ss, A_T, w, tw);     /* (print's word too: one object, made for both) */
    if (rw >= 0)
        sess_set_word(ss, A_R, w, rw);
    return 1;
}

#ifdef FAST_DECIMAL
/* sess_m204_s's value, digits[.digits] from p: *val, and the LF after it, or NULL (not that
 * shape).  end: the line's LF (to_lf 0; past_ok digit_run's), or (to_lf 1) a bound where the
 * LF is not known yet, as usual_words_to's: the first byte after the value must be a LF
 * before end. */
static inline __attribute__((always_inline)) const unsigned char *
m204_s_value(const unsigned char *p, const unsigned char *end, double *val, const int past_ok, const int to_lf)
{
    unsigned long long m;
    Py_ssize_t frac, digits = scan_plain_decimal(&p, end, &m, &frac, to_lf ? RUN_BOUNDED : past_ok);  /* (frac 0: no point, or none after it) */
    if ((to_lf ? p >= end || *p != '\n' : p != end) || (size_t)(digits - 1) >= 15)
        return NULL;
    *val = (double)(long long)m / POW10[frac];     /* (m < 10^15: exact; as usual_words_to's) */
    return p;
}

/* sess_m204_s's step once its value is read: 1 done, 0 not a case it covers (nothing changed) */
static inline __attribute__((always_inline)) int sess_m204_set_s(Session *ss, double val)
{
    if (!(0.0 < val && val <= MAX_ACCEL_A))
        return 0;
    if (ss->acc_kind == ACC_UNKNOWN)
        ss->acc_kind = acc_kind(ss->dict);
    if (ss->acc_kind == ACC_OTHER)
        return 0;
    ss->m204_n++;
    sess_set_value(ss, A_P, val, W_S);
    sess_set_value(ss, A_T, val, W_S);         /* (the same word: one object, made for both) */
    return 1;
}

/* "M204 S<digits>[.<digits>]" and the line's LF, nothing else (the rewrite writes one before
 * every re-timed segment: ~360 k lines in a plate's measure pass), in a live session, read
 * as read_words and sess_m204 read it without their general steps: the value read_words'
 * (1 to 15 digits: m / 10^frac, exact), and S alone, in (0, MAX_ACCEL_A], sets print and
 * travel to its value (one object) and leaves retract in every flavour m204_pick knows.
 * 1 done, 0 not this line or not a case this covers (nothing changed: the general path
 * reads the line). */
static inline __attribute__((always_inline)) int sess_m204_s(Session *ss, const unsigned char *s, Py_ssize_t n)
{
    /* s[0:4] is "M204"; the line's last byte, its LF, stops each digit loop */
    if (n < 8 || s[4] != ' ' || s[5] != 'S' || s[n - 1] != '\n')
        return 0;
    double val;
    const unsigned char *lf = past_readable(s, n) ? m204_s_value(s + 6, s + n - 1, &val, 1, 0)
                                                  : m204_s_value(s + 6, s + n - 1, &val, 0, 0);
    return lf != NULL && sess_m204_set_s(ss, val);
}
#endif

/* write x y z e (v) back where fused lines moved them; the session is no longer live */
static int sess_flush(Session *ss)
{
    int rc = 0;
#ifdef LOAD_CACHE
    int chain = ss->live && LOADED.mod_ok && kept_now(ss->dict);     /* the modal objects kept on */
#endif
    for (int k = 0; ss->acc_own && k < A_N; k++)     /* the M204s' objects (none unless live) */
        if (ss->acc_own & (1 << k)) {
            PyObject *o = rc == 0 ? sess_acc_obj(ss, k) : ss->o_acc[k];
            if (rc == 0 && (o == NULL || PyDict_SetItem(ss->dict, state_name[ACC_NAME[k]], o) < 0))
                rc = -1;
#ifdef LOAD_CACHE
            if (rc == 0)
                mod_put(ACC_NAME[k], o);
#endif
            Py_XDECREF(ss->o_acc[k]);     /* (the dict holds it now: o_acc[k] borrowed from it) */
        }
    ss->acc_own = 0;
    if (ss->live && ss->dirty && rc == 0) {
        const int keys[5] = {S_X, S_Y, S_Z, S_E, S_V};
        const double vals[5] = {ss->in.x0, ss->in.y0, ss->in.z0, ss->in.e, ss->in.v};
        for (int i = 0; i < (ss->dirty_v ? 5 : 4) && rc == 0; i++) {
            /* a value the dict holds already (the same bits: -0.0 is not 0.0) is left as it
             * is: z and v most sessions of the measure pass, ~1 k instructions a flush */
            if (memcmp(&vals[i], &ss->loaded[i], sizeof vals[i]) == 0)
                continue;
            PyObject *f = PyFloat_FromDouble(vals[i]);
            if (f == NULL || PyDict_SetItem(ss->dict, state_name[keys[i]], f) < 0)
                rc = -1;
#ifdef LOAD_CACHE
            if (rc == 0)
                mod_put(keys[i], f);
#endif
            Py_XDECREF(f);
        }
    }
#ifdef LOAD_CACHE
    /* the dict holds what the session held (the values sess_load would read): kept (what
     * was kept before stays good while the dict's tag is its own); the modal objects too
     * where they were kept up to the flush's writes */
    if (ss->live && rc == 0) {
        if (!chain)
            LOADED.mod_ok = 0;
        sess_keep(ss);
    }
#endif
    ss->live = ss->dirty = ss->dirty_v = 0;
    return rc;
}

/* a session on `state`, or NULL (error); one that reads no line itself (off) unless the
 * state is a MachineState step() reads (not a subclass: step() hands those to Python) */
static void *fused_open(PyObject *state)
{
    Session *ss = PyMem_Calloc(1, sizeof(Session));
    if (ss == NULL) {
        PyErr_NoMemory();
        return NULL;
    }
    if (!READY || Py_TYPE(state) != STATE_TYPE) {
        ss->off = 1;
        return ss;
    }
    PyObject *dict = PyObject_GenericGetDict(state, NULL);
    if (dict == NULL) {
        PyMem_Free(ss);
        return NULL;
    }
    Py_INCREF(state);
    ss->state = state;
    ss->dict = dict;
    return ss;
}

/* write back and free; -1 if the write-back failed (an error is set) */
static int fused_close(void *p)
{
    Session *ss = p;
    PyObject *et, *ev, *tb;
    PyErr_Fetch(&et, &ev, &tb);           /* closing after an error keeps that error */
    int rc = sess_flush(ss);
    if (et != NULL) {
        if (rc < 0)
            PyErr_Clear();
        PyErr_Restore(et, ev, tb);
        rc = -1;
    }
    Py_XDECREF(ss->dict);
    Py_XDECREF(ss->state);
    PyMem_Free(ss);
    return rc;
}

/* The FusedMove of a G0/G1 that linear_calc read (lo) from the session's state as it is
 * before the line: kind 0 a line, 1 E only (the callers tell an E of 0 apart), and
 * linear()'s choice of acceleration.  fused_line and fused_peek fill it so. */
static inline __attribute__((always_inline)) void fill_fused(const Session *ss, const LinOut *lo, FusedMove *out)
{
    const LinIn *in = &ss->in;
    int eonly = lo->x == in->x0 && lo->y == in->y0 && lo->z == in->z0;
    out->kind = eonly ? 1 : 0;
    out->x0 = in->x0;
    out->y0 = in->y0;
    out->z0 = in->z0;
    out->x1 = lo->x;
    out->y1 = lo->y;
    out->z1 = lo->z;
    out->e = lo->de;
    out->v = lo->v * in->speed;
    out->flow_r = ss->flow;
    out->lim = ss->lim;
    out->accel = ss->acc[eonly ? A_R : (lo->de > 0.0 || in->one ? A_P : A_T)];
}

/* One line: 0 read (no move), 1 read with a move in *out, 2 not read here (the state is
 * written back: call step()), -1 error. */
static int fused_line_ascii(void *p, const char *line, Py_ssize_t n, int lf, FusedMove *out);

static int fused_line(void *p, PyObject *raw, FusedMove *out)
{
    Session *ss = p;
    if (ss->off)
        return 2;
    if (!PyUnicode_CheckExact(raw) || !PyUnicode_IS_ASCII(raw))
        return sess_flush(ss) < 0 ? -1 : 2;
    return fused_line_ascii(p, (const char *)PyUnicode_1BYTE_DATA(raw), PyUnicode_GET_LENGTH(raw), 0, out);
}

/* fused_line of the line line[0..n), all of it ASCII (the str a line of ASCII bytes
 * decodes to has these bytes): the firmware core's play_buf reads its lines from bytes
 * without a str each (one is made only where this returns 2: step() reads the line).
 * lf: the line holds no CR (line_shape's). */
static inline __attribute__((always_inline)) int fused_line_body(Session *ss, const unsigned char *s, Py_ssize_t n,
                                                                 int lf, FusedMove *out);

static int fused_line_ascii(void *p, const char *line, Py_ssize_t n, int lf, FusedMove *out)
{
    Session *ss = p;
    if (ss->off)
        return 2;
    return fused_line_body(ss, (const unsigned char *)line, n, lf, out);
}

#ifdef __SSE2__
/* fused_run: fused_line_ascii over the lines of buf[*pos..len) (whole lines, none holding a
 * CR: play_buf's buffer), for the firmware core's play loop, each move handed to
 * on_move(ctx, idx, fm) from here: one call a run of lines, not one a line.  It reads line
 * *idx, *idx + 1 ... (*pos and *idx moved past each line it reads) and stops before line
 * `limit`, or before a line it leaves to the loop's own steps (not ASCII, or no '\n' in the
 * 16-byte blocks left: the lines and the ASCII test are src_next_buf's); after a line
 * fused_line_ascii returns 2 for (RUN_STEP: *line, *n that line, for step()), or an E-only
 * move where stop_eonly (RUN_STOP).  RUN_MORE where it stopped before a line; -1 on error. */
enum { RUN_MORE = 0, RUN_STEP = 2, RUN_STOP = 3 };

enum { LINE_SLOW = 3 };
static inline __attribute__((always_inline)) int run_line_fast(Session *ss, const unsigned char *a,
                                                               const unsigned char *end, const unsigned char **e,
                                                               FusedMove *out);

static int fused_run_ascii(void *p, const char *buf, Py_ssize_t len, Py_ssize_t *pos, long long *idx,
                           long long limit, int stop_eonly,
                           int (*on_move)(void *ctx, long long idx, const FusedMove *fm), void *ctx,
                           const char **line, Py_ssize_t *n_out)
{
    Session *ss = p;
    if (ss->off)
        return RUN_MORE;
    const char *a = buf + *pos, *end = buf + len;
    long long i = *idx;
    int rc = RUN_MORE;
    while (i < limit) {
        FusedMove fm;
        const unsigned char *ue;
        const char *e;
        int got = run_line_fast(ss, (const unsigned char *)a, (const unsigned char *)end, &ue, &fm);
        if (got != LINE_SLOW)
            e = (const char *)ue;
        else {
            unsigned high;
            e = line_end16(a, end, &high);
            if (e == NULL || high != 0)
                break;                         /* the loop's own steps read it */
            got = fused_line_body(ss, (const unsigned char *)a, e - a, 1, &fm);
        }
        if (got < 0) {
            rc = -1;
            break;
        }
        const char *l = a;
        a = e;
        i++;
        if (got == 1) {
            if (on_move(ctx, i - 1, &fm) < 0) {
                rc = -1;
                break;
            }
            if (stop_eonly && fm.kind == 1) {
                rc = RUN_STOP;
                break;
            }
        } else if (got == 2) {
            *line = l;
            *n_out = e - l;
            rc = RUN_STEP;
            break;
        }
    }
    *pos = a - buf;
    *idx = i;
    return rc;
}
#endif

/* fused_line_body's step for a G0/G1 once its words are read (w) */
static inline __attribute__((always_inline)) int fused_g_move(Session *ss, const Words *w, FusedMove *out)
{
    if (!ss->live) {
        sess_load(ss);
        if (!ss->live)
            return sess_flush(ss) < 0 ? -1 : 2;
    }
    LinOut lo;
    linear_calc(&ss->in, w, &lo);
    if (lo.fallback)
        return sess_flush(ss) < 0 ? -1 : 2;
    LinIn *in = &ss->in;
    int moved = !(lo.x == in->x0 && lo.y == in->y0 && lo.z == in->z0 && lo.de == 0.0);
    if (moved)
        fill_fused(ss, &lo, out);
    in->x0 = lo.x;
    in->y0 = lo.y;
    in->z0 = lo.z;
    in->e = in->e + lo.de;
    if (lo.has_f) {
        in->v = lo.v;
        ss->dirty_v = 1;
    }
    ss->dirty = 1;
    return moved;
}

static inline __attribute__((always_inline)) int fused_line_body(Session *ss, const unsigned char *s, Py_ssize_t n,
                                                                 int lf, FusedMove *out)
{
    Py_ssize_t code_n = -1;            /* the code's length: line_shape's, or code_len's where needed */
    if (!command_line(s, n, lf))
        switch (fused_shape(s, n, lf, &code_n)) {
        case SHAPE_PYTHON:
            goto other;
        case SHAPE_NOTHING:
            return 0;
        case SHAPE_MARKED: {
            PyObject *f;
            sess_wake(ss);
            int done = marked_comment(ss->dict, s + code_n, n - code_n, &f);
            if (done < 0)
                return -1;
            if (!done)
                goto other;
            if (f != NULL && ss->live)
                ss->o_feature = f;     /* (borrowed from the dict, as sess_load's) */
            return 0;
        }
        }
    /* a command (SHAPE_CODE: n >= 2); read_words reads its code, up to any ';' */
    Words w;
    if (s[0] == 'G' && (s[1] == '0' || s[1] == '1')) {
        if (read_g_words(s, n, &w) < 0)
            goto command;
        return fused_g_move(ss, &w, out);
    }
    if (n >= 4 && memcmp(s, "M204", 4) == 0) {
        sess_wake(ss);
#ifdef FAST_DECIMAL
        if (ss->live && sess_m204_s(ss, s, n))
            return 0;
#endif
        if (read_words(s, n, 4, M204_LETTERS, &w) < 0)
            goto other;
        /* live: the session's accel slots (written back with x y z e); else the dict, as
         * step() writes it */
        int done = ss->live ? sess_m204(ss, &w) : m204(ss->dict, &w);
        if (done < 0)
            return -1;
        if (!done)
            goto other;
        return 0;
    }
command:
    if (noop_command(s, code_n >= 0 ? code_n : code_len(s, n)))
        return 0;
other:
    return sess_flush(ss) < 0 ? -1 : 2;
}

#ifdef __SSE2__
/* fused_line_body of the line at a, for fused_run_ascii (buf's end: end), without
 * line_end16's look for its end where it is a G0/G1 usual_words reads or an "M204 S.." line
 * sess_m204_s takes: the words' own scan finds its LF (usual_words_to, m204_s_value), the
 * line line_end16 finds (every byte before that LF is one the words take: ASCII, no other
 * LF; and 16 bytes follow it: its 16-byte block is whole).  *e: the line's end (past its
 * LF); LINE_SLOW: not such a line, nothing changed (fused_line_body reads it). */
static inline __attribute__((always_inline)) int run_line_fast(Session *ss, const unsigned char *a,
                                                               const unsigned char *end, const unsigned char **e,
                                                               FusedMove *out)
{
#ifdef FAST_DECIMAL
    if (end - a < 32)
        return LINE_SLOW;
    const unsigned char *bound = end - 16;    /* every byte read is before bound + 7 */
    if (a[0] == 'G' && (a[1] == '0' || a[1] == '1')) {
        Words w;
        const unsigned char *lf = usual_words_to(a + 2, bound, G_LETTERS, &w, 0, 0, 1);
        if (lf == NULL)
            return LINE_SLOW;
        *e = lf + 1;
        return fused_g_move(ss, &w, out);
    }
    double val;
    const unsigned char *lf;
    if (ss->live && memcmp(a, "M204 S", 6) == 0 && (lf = m204_s_value(a + 6, bound, &val, 0, 1)) != NULL
        && sess_m204_set_s(ss, val)) {
        *e = lf + 1;
        return 0;
    }
#endif
    return LINE_SLOW;
}
#endif

/* The analyse pass's loops (the firmware core's Sim.run_lines and gap_lines) read a line in
 * two steps: fused_peek reads a G0/G1 of the fast shape as fused_line reads it, changing
 * nothing: 1 with *rm filled (rm->fm.kind 0 a line, 1 E only, 2 no move: a line step()
 * returns None for, its state change only), 2 a blank or unmarked comment line or a command
 * noop_command finds (step() returns None, nothing changes), 3 an M204 or a marked comment
 * line (nothing read: fused_line reads it), 0 any other line, -1 error; fused_commit then makes the state step() would leave, if the loop
 * takes the line. */
static int fused_peek_ascii(void *p, const char *line, Py_ssize_t n, int lf, RunMove *rm);

static int fused_peek(void *p, PyObject *raw, RunMove *rm)
{
    if (!PyUnicode_CheckExact(raw) || !PyUnicode_IS_ASCII(raw))
        return 0;
    return fused_peek_ascii(p, (const char *)PyUnicode_1BYTE_DATA(raw), PyUnicode_GET_LENGTH(raw), 0, rm);
}

/* fused_peek of the line line[0..n), all of it ASCII, lf as fused_line_ascii's: run_lines
 * and gap_lines read the reader's Lines chunks without a str a line */
static int fused_peek_ascii(void *p, const char *line, Py_ssize_t n, int lf, RunMove *rm)
{
    Session *ss = p;
    if (ss->off)
        return 0;
    const unsigned char *s = (const unsigned char *)line;
    Py_ssize_t code_n = -1;            /* as fused_line_ascii's */
    if (!command_line(s, n, lf))
        switch (fused_shape(s, n, lf, &code_n)) {
        case SHAPE_PYTHON:
            return 0;
        case SHAPE_NOTHING:
            return 2;
        case SHAPE_MARKED:
            return 3;
        }
    Words w;
    if (n >= 4 && memcmp(s, "M204", 4) == 0)
        return 3;
    if (!(s[0] == 'G' && (s[1] == '0' || s[1] == '1')) || read_g_words(s, n, &w) < 0)
        return noop_command(s, code_n >= 0 ? code_n : code_len(s, n)) ? 2 : 0;
    if (!ss->live) {
        sess_load(ss);
        if (!ss->live)
            return 0;
    }
    LinIn *in = &ss->in;
    LinOut lo;
    linear_calc(in, &w, &lo);
    if (lo.fallback)
        return 0;                      /* Python decides */
    FusedMove *out = &rm->fm;
    fill_fused(ss, &lo, out);
    int eonly = out->kind == 1;
    if (eonly && lo.de == 0.0)
        out->kind = 2;
    rm->e0 = in->e;
    rm->e1 = in->e + lo.de;
    rm->v1 = lo.v;
    rm->speed = in->speed;
    rm->has_f = lo.has_f;
    rm->e_rel = lo.e_rel;
    rm->xyz_rel = !in->abs_xyz;
    if (eonly) {                       /* linear()'s choice of accel object and feature */
        rm->accel = sess_acc_obj(ss, A_R);
        rm->feature = ss->o_feature;
    } else if (lo.de > 0.0) {
        rm->accel = sess_acc_obj(ss, A_P);
        rm->feature = ss->o_feature;
    } else {
        rm->accel = sess_acc_obj(ss, in->one ? A_P : A_T);
        rm->feature = TRAVEL;
    }
    return rm->accel != NULL ? 1 : -1;
}

static void fused_commit(void *p, const RunMove *rm)
{
    Session *ss = p;
    LinIn *in = &ss->in;
    in->x0 = rm->fm.x1;
    in->y0 = rm->fm.y1;
    in->z0 = rm->fm.z1;
    in->e = rm->e1;
    if (rm->has_f) {
        in->v = rm->v1;
        ss->dirty_v = 1;
    }
    ss->dirty = 1;
}

typedef struct {
    const char *layout;               /* FUSED_LAYOUT: the core checks it is its own */
    size_t move_size;
    PyCFunction step;                 /* the C step: a state whose step is it can be read here */
    void *(*open)(PyObject *state);
    int (*line)(void *session, PyObject *raw, FusedMove *out);
    int (*close)(void *session);
    size_t run_move_size;
    int (*peek)(void *session, PyObject *raw, RunMove *rm);
    void (*commit)(void *session, const RunMove *rm);
    int (*line_ascii)(void *session, const char *line, Py_ssize_t n, int lf, FusedMove *out);
    Py_ssize_t (*lines_len)(PyObject *o);
    int (*lines_at)(PyObject *o, Py_ssize_t i, const char **line, Py_ssize_t *n);
    int (*peek_ascii)(void *session, const char *line, Py_ssize_t n, int lf, RunMove *rm);
    int (*run_ascii)(void *session, const char *buf, Py_ssize_t len, Py_ssize_t *pos, long long *idx,
                     long long limit, int stop_eonly, int (*on_move)(void *ctx, long long idx, const FusedMove *fm),
                     void *ctx, const char **line, Py_ssize_t *n);   /* NULL: none (no SSE2) */
    int (*lines_raw)(PyObject *o, const char **data, const Py_ssize_t **start);
} ReaderAPI;

/* ---------------------------------------------------------------- a chunk of lines as bytes
 * line_chunks' chunk with the compiled reader: the chunk's bytes and where each line starts,
 * read as a sequence of str (lines[i] makes the str read_lines gives: split_lines' own).
 * The analyse pass reads most lines in C (run_lines, gap_lines: lines_at, no str), so a
 * str is made only for the few lines Python reads (~5 k of the gyroid plate's 461 k). */
typedef struct {
    PyObject_HEAD
    PyObject *data;                   /* bytes: the lines from offset 0 */
    Py_ssize_t n;                     /* lines */
    Py_ssize_t *start;                /* n + 1 offsets: line i is data[start[i]:start[i + 1]] */
    int ascii;                        /* every byte of data is ASCII */
    int cr;                           /* data holds a CR */
} LinesObject;

static PyTypeObject LinesType;

static Py_ssize_t Lines_len(LinesObject *o)
{
    return o->n;
}

static PyObject *Lines_item(LinesObject *o, Py_ssize_t i)
{
    if (i < 0 || i >= o->n) {
        PyErr_SetString(PyExc_IndexError, "Lines index out of range");
        return NULL;
    }
    const char *s = PyBytes_AS_STRING(o->data) + o->start[i];
    return line_str(s, o->start[i + 1] - o->start[i], o->ascii);
}

static void Lines_dealloc(LinesObject *o)
{
    Py_XDECREF(o->data);
    PyMem_Free(o->start);
    Py_TYPE(o)->tp_free((PyObject *)o);
}

static PySequenceMethods Lines_as_seq = {
    .sq_length = (lenfunc)Lines_len,
    .sq_item = (ssizeargfunc)Lines_item,
};

static PyTypeObject LinesType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_reader.Lines",
    .tp_basicsize = sizeof(LinesObject),
    .tp_dealloc = (destructor)Lines_dealloc,
    .tp_as_sequence = &Lines_as_seq,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "A chunk of lines as bytes (split_block): lines[i] is the i-th line's str",
};

/* the capsule's: o's length, -1 if o is not a Lines */
static Py_ssize_t lines_len(PyObject *o)
{
    return Py_IS_TYPE(o, &LinesType) ? ((LinesObject *)o)->n : -1;
}

/* the capsule's: line i (0 <= i < len) of the Lines o as bytes; LINE_ASCII if all of it is
 * ASCII (then it is the str's own characters; else the str is the decoder's), or'ed with
 * LINE_LF where it holds no CR (line_shape's lf) */
enum { LINE_ASCII = 1, LINE_LF = 2 };

static int lines_at(PyObject *o, Py_ssize_t i, const char **line, Py_ssize_t *n)
{
    LinesObject *b = (LinesObject *)o;
    const char *s = PyBytes_AS_STRING(b->data) + b->start[i];
    Py_ssize_t k = 0, m = b->start[i + 1] - b->start[i];
    *line = s;
    *n = m;
    int lf = b->cr ? 0 : LINE_LF;
    if (b->ascii)
        return LINE_ASCII | lf;
    for (; k < m; k++)
        if ((unsigned char)s[k] & 0x80)
            return lf;
    return LINE_ASCII | lf;
}

/* the capsule's: the Lines o's bytes and line starts (line i is data[start[i]..start[i + 1]),
 * held by o, unchanged while it lives), and lines_at's flags where they are every line's
 * (LINE_ASCII | LINE_LF where the block has no CR), else 0 (lines_at tests each line) */
static int lines_raw(PyObject *o, const char **data, const Py_ssize_t **start)
{
    LinesObject *b = (LinesObject *)o;
    *data = PyBytes_AS_STRING(b->data);
    *start = b->start;
    return b->ascii ? LINE_ASCII | (b->cr ? 0 : LINE_LF) : 0;
}

static PyObject *step(PyObject *module, PyObject *const *args, Py_ssize_t nargs);
static const ReaderAPI READER_API = {FUSED_LAYOUT, sizeof(FusedMove), (PyCFunction)(void (*)(void))step,
                                     fused_open, fused_line, fused_close,
                                     sizeof(RunMove), fused_peek, fused_commit, fused_line_ascii,
                                     lines_len, lines_at, fused_peek_ascii,
#ifdef __SSE2__
                                     fused_run_ascii,
#else
                                     NULL,
#endif
                                     lines_raw};

/* An instance method (binds like a Python function) calling step. */
static PyMethodDef step_def = {"step", (PyCFunction)(void (*)(void))step, METH_FASTCALL,
                               "step(self, idx, raw): read one line (compiled fast path)."};

static PyObject *make_method(PyObject *module, PyObject *unused)
{
    PyObject *f = PyCFunction_New(&step_def, NULL);
    if (f == NULL)
        return NULL;
    PyObject *m = PyInstanceMethod_New(f);
    Py_DECREF(f);
    return m;
}

/* split_scan's starts with twice the room (*cap doubled), or NULL (start freed, error set) */
static Py_ssize_t *grow_starts(Py_ssize_t *start, Py_ssize_t *cap)
{
    *cap *= 2;
    Py_ssize_t *more = PyMem_Realloc(start, (size_t)*cap * sizeof(Py_ssize_t));
    if (more == NULL) {
        PyMem_Free(start);
        PyErr_NoMemory();
    }
    return more;
}

/* The whole lines at the start of p[0..len) as read_lines reads them (open_text: newline=""):
 * a line ends after "\n", "\r\n" or a lone "\r".  The rest (a line without its ending, or a
 * "\r" at the very end, which may be the start of a "\r\n") waits for more bytes, unless
 * final (the file's end: the rest is the last line).  Returns the lines n, their starts and
 * the end of the last in *start_out (n + 1 offsets, PyMem; the caller frees them), *ascii
 * whether every byte of p[0..len) is ASCII, *cr_out whether one is a CR; -1 on error (set). */
static Py_ssize_t split_scan(const char *p, Py_ssize_t len, int final, Py_ssize_t **start_out, int *ascii,
                             int *cr_out)
{
    const char *end = p + len, *s = p;
    int cr = *cr_out = memchr(p, '\r', (size_t)len) != NULL;
    unsigned long long any = 0;        /* the bytes or'ed, 8 at a time: all ASCII (the usual)? */
    Py_ssize_t k = 0;
    for (; k + 8 <= len; k += 8) {
        unsigned long long w;
        memcpy(&w, p + k, 8);
        any |= w;
    }
    for (; k < len; k++)
        any |= (unsigned char)p[k];
    *ascii = (any & 0x8080808080808080ULL) == 0;
    Py_ssize_t n = 0, cap = len / 24 + 16;
    Py_ssize_t *start = PyMem_Malloc((size_t)cap * sizeof(Py_ssize_t));
    if (start == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    start[0] = 0;
#ifdef __SSE2__
    if (!cr) {
        /* the '\n's 16 bytes at a time (one compare and mask), each line's end from the
         * mask's bits: the same ends as the memchr steps below, without a call a line */
        const __m128i nl16 = _mm_set1_epi8('\n');
        Py_ssize_t j = 0;
        for (; j + 16 <= len; j += 16) {
            unsigned nl = (unsigned)_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_loadu_si128((const __m128i *)(p + j)), nl16));
            for (; nl != 0; nl &= nl - 1) {
                if (n + 2 > cap && (start = grow_starts(start, &cap)) == NULL)
                    return -1;
                start[++n] = j + __builtin_ctz(nl) + 1;
            }
        }
        s = p + start[n];              /* the rest, fewer than 16 bytes on from j: the steps below */
    }
#endif
    while (s < end) {
        const char *e;
        if (!cr) {
            e = memchr(s, '\n', (size_t)(end - s));
            if (e == NULL)
                e = end;
        } else
            for (e = s; e < end && *e != '\n' && *e != '\r'; e++)
                ;
        if (e == end) {
            if (!final)
                break;                 /* a line without its ending: more bytes may come */
        } else if (*e == '\r') {
            if (e + 1 == end && !final)
                break;                 /* maybe "\r\n" */
            e += (e + 1 < end && e[1] == '\n') ? 2 : 1;
        } else
            e++;
        if (n + 2 > cap && (start = grow_starts(start, &cap)) == NULL)
            return -1;
        start[++n] = e - p;
        s = e;
    }
    *start_out = start;
    return n;
}

/* split_lines(buf, final) -> (lines, used): the whole lines at the start of the bytes-like
 * buf (split_scan's), a list of str, endings kept; used: the bytes they take.  (The
 * reference of split_block: read_chunks' lists.) */
static PyObject *split_lines(PyObject *module, PyObject *args)
{
    Py_buffer b;
    int final, ascii, cr;
    Py_ssize_t *start = NULL;
    if (!PyArg_ParseTuple(args, "y*p:split_lines", &b, &final))
        return NULL;
    const char *p = (const char *)b.buf;
    Py_ssize_t n = split_scan(p, b.len, final, &start, &ascii, &cr);
    PyObject *lines = n < 0 ? NULL : PyList_New(n);
    for (Py_ssize_t i = 0; lines != NULL && i < n; i++) {
        PyObject *line = line_str(p + start[i], start[i + 1] - start[i], ascii);
        if (line == NULL)
            Py_CLEAR(lines);
        else
            PyList_SET_ITEM(lines, i, line);
    }
    Py_ssize_t used = n < 0 ? 0 : start[n];
    PyMem_Free(start);
    PyBuffer_Release(&b);
    return lines == NULL ? NULL : Py_BuildValue("(Nn)", lines, used);
}

/* split_block(data, final) -> (lines, used): split_lines' lines as a Lines over the bytes
 * data (held, not copied): no str is made until one is read.  (state.line_chunks: analyse's
 * reading.) */
static PyObject *split_block(PyObject *module, PyObject *args)
{
    PyObject *data;
    int final, ascii, cr;
    if (!PyArg_ParseTuple(args, "O!p:split_block", &PyBytes_Type, &data, &final))
        return NULL;
    Py_ssize_t *start = NULL;
    Py_ssize_t n = split_scan(PyBytes_AS_STRING(data), PyBytes_GET_SIZE(data), final, &start, &ascii, &cr);
    if (n < 0)
        return NULL;
    LinesObject *o = PyObject_New(LinesObject, &LinesType);
    if (o == NULL) {
        PyMem_Free(start);
        return NULL;
    }
    Py_INCREF(data);
    o->data = data;
    o->n = n;
    o->start = start;
    o->ascii = ascii;
    o->cr = cr;
    return Py_BuildValue("(Nn)", (PyObject *)o, start[n]);
}

/* ---------------------------------------------------------------- the state's snapshot
 * MachineState.snapshot(): the modal attributes (MachineState.MODAL) as a tuple.  Python's
 * attrgetter takes each through the generic attribute look-up (the type's MRO first,
 * ~210 instructions a name); a MachineState (not a subclass) whose class defines none of
 * them holds each in its dict, read here (~110 a name).  The measure pass takes one at
 * every stop of its ledger.  Any other object, or a name missing from the dict, goes to
 * the attrgetter (set_modal's), as does every call before set_modal. */
static PyObject *set_modal(PyObject *module, PyObject *args)
{
    PyObject *names, *getter;
    (void)module;
    if (!PyArg_ParseTuple(args, "O!O", &PyTuple_Type, &names, &getter))
        return NULL;
    Py_ssize_t n = PyTuple_GET_SIZE(names);
    PyObject *own = PyTuple_New(n);
    if (own == NULL)
        return NULL;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *nm = PyTuple_GET_ITEM(names, i);
        if (!PyUnicode_CheckExact(nm)) {
            Py_DECREF(own);
            PyErr_SetString(PyExc_TypeError, "set_modal: the names must be str");
            return NULL;
        }
        Py_INCREF(nm);
        PyUnicode_InternInPlace(&nm);  /* (the dict's keys are interned: compared by pointer) */
        PyTuple_SET_ITEM(own, i, nm);
    }
    Py_XSETREF(MODAL_NAMES, own);
    Py_INCREF(getter);
    Py_XSETREF(MODAL_GET, getter);
#ifdef LOAD_CACHE
    /* where each name the session writes sits in MODAL (the names are interned) */
    LOADED.mod_ok = 0;
    MOD_N = n <= MOD_MAX ? n : 0;
    for (int k = 0; k < S_N; k++) {
        MOD_AT[k] = 0;
        for (Py_ssize_t i = 0; i < MOD_N; i++)
            if (state_name[k] != NULL && PyTuple_GET_ITEM(own, i) == state_name[k])
                MOD_AT[k] = (int)i + 1;
    }
#endif
    Py_RETURN_NONE;
}

static PyObject *snapshot(PyObject *module, PyObject *state)
{
    (void)module;
    if (MODAL_GET == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "snapshot: set_modal not called");
        return NULL;
    }
    if (STATE_TYPE == NULL || Py_TYPE(state) != STATE_TYPE)
        return PyObject_CallOneArg(MODAL_GET, state);
    PyObject *dict = PyObject_GenericGetDict(state, NULL);
    if (dict == NULL)
        return NULL;
    Py_ssize_t n = PyTuple_GET_SIZE(MODAL_NAMES);
    PyObject *snap = PyTuple_New(n);
    if (snap == NULL) {
        Py_DECREF(dict);
        return NULL;
    }
#ifdef LOAD_CACHE
    /* the objects kept with the session's load (at a stop of the measure pass: the dict as
     * the session's write-back left it), without a look-up */
    int kept = kept_now(dict);
    if (kept && LOADED.mod_ok && MOD_N == n) {
        for (Py_ssize_t i = 0; i < n; i++) {
            Py_INCREF(LOADED.mod[i]);
            PyTuple_SET_ITEM(snap, i, LOADED.mod[i]);
        }
        Py_DECREF(dict);
        return snap;
    }
#endif
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *v = PyDict_GetItemWithError(dict, PyTuple_GET_ITEM(MODAL_NAMES, i));
        if (v == NULL) {
            Py_DECREF(snap);
            Py_DECREF(dict);
            return PyErr_Occurred() ? NULL : PyObject_CallOneArg(MODAL_GET, state);
        }
        Py_INCREF(v);
        PyTuple_SET_ITEM(snap, i, v);
    }
#ifdef LOAD_CACHE
    if (kept && MOD_N == n) {          /* read: kept on from here */
        for (Py_ssize_t i = 0; i < n; i++)
            LOADED.mod[i] = PyTuple_GET_ITEM(snap, i);
        LOADED.mod_ok = 1;
    }
#endif
    Py_DECREF(dict);
    return snap;
}

static PyMethodDef mod_methods[] = {
    {"setup", setup, METH_VARARGS,
     "setup(Move, MachineState, TRAVEL, LINE, EONLY, MAX_POS_D, MAX_E_D, MAX_F, MAX_ACCEL_A)"},
    {"step", (PyCFunction)(void (*)(void))step, METH_FASTCALL, "step(state, idx, raw)"},
    {"set_modal", set_modal, METH_VARARGS,
     "set_modal(names, getter): snapshot's attributes, and the attrgetter for other objects"},
    {"snapshot", snapshot, METH_O, "snapshot(state): the modal attributes (MachineState.MODAL), a tuple"},
    {"make_method", make_method, METH_NOARGS, "step as a method for MachineState"},
    {"split_lines", split_lines, METH_VARARGS,
     "split_lines(buf, final) -> (lines, used): buf's whole lines decoded as read_lines reads them"},
    {"split_block", split_block, METH_VARARGS,
     "split_block(data, final) -> (lines, used): split_lines' lines as a Lines over the bytes data"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef reader_module = {
    PyModuleDef_HEAD_INIT, "_gcode_opt_reader",
    "Compiled fast path of the G-code reader (gcode_opt/_reader.c; see state.py).", -1, mod_methods,
};

#ifndef READER_SOURCE_SHA256
#define READER_SOURCE_SHA256 ""
#endif
#ifndef GCODE_OPT_SOURCE_STAT   /* setup.py: the digest and the stat of each file it covers, when taken (native.stat_record) */
#define GCODE_OPT_SOURCE_STAT ""
#endif

PyMODINIT_FUNC PyInit__gcode_opt_reader(void)
{
    if (PyType_Ready(&LinesType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&reader_module);
    if (m == NULL)
        return NULL;
#ifdef FAST_DECIMAL
    run_table_init();
#endif
    Py_INCREF(&LinesType);
    if (PyModule_AddObject(m, "Lines", (PyObject *)&LinesType) < 0) {
        Py_DECREF(&LinesType);
        Py_DECREF(m);
        return NULL;
    }
    PyObject *cap = PyCapsule_New((void *)&READER_API, "_gcode_opt_reader._C_API", NULL);
    if (cap == NULL || PyModule_AddObject(m, "_C_API", cap) < 0) {
        Py_XDECREF(cap);
        Py_DECREF(m);
        return NULL;
    }
    if (PyModule_AddStringConstant(m, "SOURCE_SHA256", READER_SOURCE_SHA256) < 0
        || PyModule_AddStringConstant(m, "SOURCE_STAT", GCODE_OPT_SOURCE_STAT) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
