/* Compiled core of the firmware model (firmware/simulate.py _Sim, planner.py, junction.py).
 *
 * The same model as the Python code, statement for statement: every double operation is
 * the one Python does, in the same order, so the results are the same bits (build with
 * -ffp-contract=off, no -ffast-math: see setup.py).  Python's float errors are kept:
 * a division by zero raises ZeroDivisionError, math.sqrt of a negative and math.cos/sin
 * of an infinity raise ValueError, float ** 2 that overflows raises OverflowError.
 * tests/test_fwcore_*.py compare this core with the Python one bit for bit.
 *
 * Moves, Arcs and Limits are read through their __slots__ offsets (taken once, in
 * setup()); any other object through getattr.  Blocks live in C arrays; a Python Block
 * is made only for on_block (none when on_block is a RowSink: the ringing's rows are
 * written straight into it), a LineRecord only for on_line (none when on_line is a
 * StrokeSums: the per-stroke sums are taken here).  Sim.play runs simulate._play's loop
 * over a chunk of lines, through the compiled reader's fused loop where it can (see
 * use_reader). */
#define PY_SSIZE_T_CLEAN
#if defined(__linux__) && !defined(_GNU_SOURCE)
#define _GNU_SOURCE               /* sincos (glibc): cos and sin of one argument at once */
#endif
#include <Python.h>
#include <structmember.h>
#include <math.h>
#include <float.h>
#include <string.h>
#include "../_npsum.h"      /* np_pairwise_sum: numpy's pairwise sum */
#include "../_linestr.h"    /* line_str: a line's str as read_lines gives it */
#include "../_strokefields.h"  /* StrokeFieldsAPI: the layout _STROKE_FIELDS exports */
#ifdef __SSE2__
#include <emmintrin.h>      /* src_next_buf's 16-byte scan */
#endif

/* ---------------------------------------------------------------- constants */
/* Move.kind values (setup); the model's constants come with each Sim (simulate.new_sim
 * reads them from the modules when the pass starts, as _Sim does) */
static long K_LINE = 0, K_ARC = 1, K_EONLY = 2;
static int configured = 0;

/* ---------------------------------------------------------------- slot access */
enum { MV_IDX, MV_KIND, MV_X0, MV_Y0, MV_Z0, MV_X1, MV_Y1, MV_Z1, MV_E, MV_V, MV_ACCEL, MV_LIM, MV_ARC,
       MV_FLOW_R, MV_FEATURE, MV_LAYER, MV_E_REL, MV_N };
static const char *MOVE_NAMES[MV_N] = {"idx", "kind", "x0", "y0", "z0", "x1", "y1", "z1", "e",
                                      "v", "accel", "lim", "arc", "flow_r", "feature", "layer", "e_rel"};
enum { A_CX, A_CY, A_R, A_THETA0, A_SWEEP, A_LENGTH, A_N };
static const char *ARC_NAMES[A_N] = {"cx", "cy", "r", "theta0", "sweep", "length_d"};
enum { L_VMAX, L_AXMAX, L_AYMAX, L_SCV, L_MCR, L_JD, L_JERKX, L_JERKY, L_N };
static const char *LIM_NAMES[L_N] = {"v_max", "ax_max", "ay_max", "scv", "mcr", "jd", "jerk_x",
                                     "jerk_y"};

typedef struct {
    PyTypeObject *type;       /* objects of exactly this type are read by offset */
    Py_ssize_t *off;          /* per attribute: slot offset, or -1 (getattr) */
    PyObject **name;          /* interned names */
    int n;
} SlotMap;

static Py_ssize_t move_off[MV_N], arc_off[A_N], lim_off[L_N], bar_off[1];
static PyObject *move_name[MV_N], *arc_name[A_N], *lim_name[L_N], *bar_name[1];
static SlotMap MOVE_MAP = {NULL, move_off, move_name, MV_N};
static SlotMap ARC_MAP = {NULL, arc_off, arc_name, A_N};
static SlotMap LIM_MAP = {NULL, lim_off, lim_name, L_N};
static SlotMap BAR_MAP = {NULL, bar_off, bar_name, 1};
static PyTypeObject *REC_TYPE = NULL, *RES_TYPE = NULL;

static int map_init(SlotMap *m, PyObject *type, const char **names)
{
    if (!PyType_Check(type)) {
        PyErr_SetString(PyExc_TypeError, "setup: expected a class");
        return -1;
    }
    Py_INCREF(type);
    Py_XSETREF(m->type, (PyTypeObject *)type);
    for (int i = 0; i < m->n; i++) {
        PyObject *nm = PyUnicode_InternFromString(names[i]);
        if (nm == NULL)
            return -1;
        Py_XSETREF(m->name[i], nm);
        m->off[i] = -1;
        PyObject *d = PyObject_GetAttr(type, nm);
        if (d == NULL) {
            PyErr_Clear();
            continue;
        }
        if (Py_TYPE(d) == &PyMemberDescr_Type) {
            PyMemberDef *md = ((PyMemberDescrObject *)d)->d_member;
            if (md->type == T_OBJECT_EX)
                m->off[i] = md->offset;
        }
        Py_DECREF(d);
    }
    return 0;
}

/* New reference to attribute i of o. */
static PyObject *get_obj(SlotMap *m, PyObject *o, int i)
{
    if (Py_TYPE(o) == m->type && m->off[i] >= 0) {
        PyObject *v = *(PyObject **)((char *)o + m->off[i]);
        if (v == NULL) {
            PyErr_Format(PyExc_AttributeError, "'%.50s' object has no attribute '%U'",
                         Py_TYPE(o)->tp_name, m->name[i]);
            return NULL;
        }
        Py_INCREF(v);
        return v;
    }
    return PyObject_GetAttr(o, m->name[i]);
}

static int get_d(SlotMap *m, PyObject *o, int i, double *out)
{
    if (Py_TYPE(o) == m->type && m->off[i] >= 0) {
        PyObject *v = *(PyObject **)((char *)o + m->off[i]);
        if (v != NULL && PyFloat_CheckExact(v)) {
            *out = PyFloat_AS_DOUBLE(v);
            return 0;
        }
    }
    PyObject *v = get_obj(m, o, i);
    if (v == NULL)
        return -1;
    double x = PyFloat_AsDouble(v);
    Py_DECREF(v);
    if (x == -1.0 && PyErr_Occurred())
        return -1;
    *out = x;
    return 0;
}

static int get_ll(SlotMap *m, PyObject *o, int i, long long *out)
{
    PyObject *v = get_obj(m, o, i);
    if (v == NULL)
        return -1;
    long long x = PyLong_AsLongLong(v);
    Py_DECREF(v);
    if (x == -1 && PyErr_Occurred())
        return -1;
    *out = x;
    return 0;
}

/* ---------------------------------------------------------------- Python's float errors */
static int zerodiv(void)
{
    PyErr_SetString(PyExc_ZeroDivisionError, "float division by zero");
    return -1;
}
static int domain(void)
{
    PyErr_SetString(PyExc_ValueError, "math domain error");
    return -1;
}
#define DIV(out, a, b) do { double b_ = (b); if (b_ == 0.0) return zerodiv(); (out) = (a) / b_; } while (0)
/* The correctly rounded square root (IEEE: the bits of libm's sqrt), without errno: gcc's
 * sqrt() is sqrtsd plus a test and a libm call kept for errno, and in a block it guesses
 * cold, the call alone (~25 instructions a block of the firmware model's).  Nothing here
 * reads errno. */
static inline double sqrt_rn(double x)
{
#if defined(__SSE2__) && defined(__GNUC__)
    /* the instruction alone, in place (the intrinsics' zeroed upper half cost ~4 more) */
    __asm__("sqrtsd %0, %0" : "+x"(x));
    return x;
#else
    return sqrt(x);
#endif
}
#define SQRT(out, x) do { double x_ = (x); if (x_ < 0.0) return domain(); (out) = sqrt_rn(x_); } while (0)
static inline double pymax(double a, double b) { return b > a ? b : a; }
static inline double pymin(double a, double b) { return b < a ? b : a; }

/* ---------------------------------------------------------------- Block (planner.Block) */
typedef struct {
    long long idx;
    int kind;
    char first, after_stop;
    double d, ux, uy, uz, er, accel, jd, nominal_v, v2max, delta_v2, mcr_delta_v2, max_start_v2,
        max_mcr_start_v2, safe_v, start_v, cruise_v, end_v, accel_t, cruise_t, decel_t;
} BlockData;

typedef struct {
    PyObject_HEAD
    BlockData b;
} BlockObject;

#define BOFF(f) (offsetof(BlockObject, b) + offsetof(BlockData, f))
static PyMemberDef Block_members[] = {
    {"idx", T_LONGLONG, BOFF(idx), 0, NULL},
    {"kind", T_INT, BOFF(kind), 0, NULL},
    {"first", T_BOOL, BOFF(first), 0, NULL},
    {"d", T_DOUBLE, BOFF(d), 0, NULL},
    {"ux", T_DOUBLE, BOFF(ux), 0, NULL},
    {"uy", T_DOUBLE, BOFF(uy), 0, NULL},
    {"uz", T_DOUBLE, BOFF(uz), 0, NULL},
    {"er", T_DOUBLE, BOFF(er), 0, NULL},
    {"accel", T_DOUBLE, BOFF(accel), 0, NULL},
    {"jd", T_DOUBLE, BOFF(jd), 0, NULL},
    {"nominal_v", T_DOUBLE, BOFF(nominal_v), 0, NULL},
    {"v2max", T_DOUBLE, BOFF(v2max), 0, NULL},
    {"delta_v2", T_DOUBLE, BOFF(delta_v2), 0, NULL},
    {"mcr_delta_v2", T_DOUBLE, BOFF(mcr_delta_v2), 0, NULL},
    {"max_start_v2", T_DOUBLE, BOFF(max_start_v2), 0, NULL},
    {"max_mcr_start_v2", T_DOUBLE, BOFF(max_mcr_start_v2), 0, NULL},
    {"safe_v", T_DOUBLE, BOFF(safe_v), 0, NULL},
    {"after_stop", T_BOOL, BOFF(after_stop), 0, NULL},
    {"start_v", T_DOUBLE, BOFF(start_v), 0, NULL},
    {"cruise_v", T_DOUBLE, BOFF(cruise_v), 0, NULL},
    {"end_v", T_DOUBLE, BOFF(end_v), 0, NULL},
    {"accel_t", T_DOUBLE, BOFF(accel_t), 0, NULL},
    {"cruise_t", T_DOUBLE, BOFF(cruise_t), 0, NULL},
    {"decel_t", T_DOUBLE, BOFF(decel_t), 0, NULL},
    {NULL}
};

static PyTypeObject BlockType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_fwcore.Block",
    .tp_doc = "A planned block (planner.Block's fields), as on_block sees it.",
    .tp_basicsize = sizeof(BlockObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_members = Block_members,
};

/* ---------------------------------------------------------------- RowSink (ringing.py) */
/* The ringing Collector's rows (ringing.ROW = 12 numbers a block or rest: _block_row,
 * _rest_row): a Sim whose on_block is a RowSink writes each planned block's row here
 * without making a Block object; called with a block (the Python model's path), it reads
 * the same attributes.  Once it holds `cap` rows or more it calls flush(), which must take
 * them (take()).  A compiled Sim that writes into it also writes its rests (an E-only
 * move's time, when its record is made; a barrier's dwell, once the barrier is taken: where
 * ringing.hooks' on_line and wrap_events put them); the sink's own line() and dwell() then
 * do nothing (sim_rests), so a pass gets each rest once whichever model plays it. */
#define SINK_ROW 12
/* The rows are written into a bytearray (store) that take() hands out as it is (a
 * chunk's rows, ~1.5 MB, not copied); the last one handed out (spare) is written again
 * once nothing but the sink holds it (the Collector's arrays over it are gone: an array
 * or view over it holds a reference).  A bytearray, not bytes: bytes are immutable to
 * everything else in the interpreter (their cached hash), a bytearray may be written. */
#define SINK_ROW_B ((Py_ssize_t)(SINK_ROW * sizeof(double)))
typedef struct {
    PyObject_HEAD
    double *buf;                      /* store's bytes, NULL without a store */
    Py_ssize_t n, alloc, cap;         /* rows held, rows allocated, rows that call flush */
    Py_ssize_t last_alloc;            /* rows allocated when take() took the store */
    PyObject *store, *spare;          /* bytearrays: the rows' room; the last one take() returned */
    PyObject *flush;
    int sim_rests;                    /* a compiled Sim writes the rests too */
} SinkObject;

static int sink_reserve(SinkObject *k, Py_ssize_t rows)
{
    if (k->n + rows <= k->alloc)
        return 0;
    if (k->store == NULL && k->spare != NULL && Py_REFCNT(k->spare) == 1) {
        /* no one else holds it (nor a view of it: a view holds a reference): its bytes
           can be written again */
        k->store = k->spare;
        k->spare = NULL;
        k->buf = (double *)PyByteArray_AS_STRING(k->store);
        k->alloc = PyByteArray_GET_SIZE(k->store) / SINK_ROW_B;
        if (k->n + rows <= k->alloc)
            return 0;
    }
    Py_ssize_t want;
    if (k->store == NULL && k->last_alloc >= k->n + rows)
        want = k->last_alloc;         /* (the room a chunk took before: taken at once) */
    else {
        want = k->alloc * 2 > k->n + rows ? k->alloc * 2 : k->n + rows + 16;
        if (want > k->cap + 1 && k->n + rows <= k->cap + 1)
            want = k->cap + 1;        /* (grown as rows come, to what a chunk holds) */
    }
    if (k->store == NULL)
        k->store = PyByteArray_FromStringAndSize(NULL, want * SINK_ROW_B);
    else if (PyByteArray_Resize(k->store, want * SINK_ROW_B) < 0)
        Py_CLEAR(k->store);           /* (its rows are lost) */
    if (k->store == NULL) {
        k->buf = NULL;
        k->n = k->alloc = 0;
        return -1;
    }
    k->buf = (double *)PyByteArray_AS_STRING(k->store);
    k->alloc = want;
    return 0;
}

/* the room of one more row (k->buf + k->n * SINK_ROW), NULL on error */
static inline double *sink_next(SinkObject *k)
{
    if (k->n >= k->alloc && sink_reserve(k, 1) < 0)
        return NULL;
    return k->buf + k->n * SINK_ROW;
}

/* the row written at sink_next() taken; flush() once cap rows are held */
static inline int sink_commit(SinkObject *k)
{
    k->n++;
    if (k->n >= k->cap) {
        PyObject *x = PyObject_CallNoArgs(k->flush);
        if (x == NULL)
            return -1;
        Py_DECREF(x);
        if (k->n >= k->cap) {
            PyErr_SetString(PyExc_RuntimeError, "RowSink: flush() did not take the rows");
            return -1;
        }
    }
    return 0;
}

/* one row in; flush() once cap rows are held */
static int sink_push(SinkObject *k, const double *row)
{
    double *o = sink_next(k);
    if (o == NULL)
        return -1;
    memcpy(o, row, SINK_ROW * sizeof(double));
    return sink_commit(k);
}

/* _block_row(b): (ux, uy, start_v, cruise_v, end_v, accel, accel_t, cruise_t, decel_t,
 * after_stop, idx, 1.0), written in place (a row a block: no copy of it) */
static inline int sink_block(SinkObject *k, const BlockData *b)
{
    double *o = sink_next(k);
    if (o == NULL)
        return -1;
    o[0] = b->ux;
    o[1] = b->uy;
    o[2] = b->start_v;
    o[3] = b->cruise_v;
    o[4] = b->end_v;
    o[5] = b->accel;
    o[6] = b->accel_t;
    o[7] = b->cruise_t;
    o[8] = b->decel_t;
    o[9] = b->after_stop ? 1.0 : 0.0;
    o[10] = (double)b->idx;
    o[11] = 1.0;
    return sink_commit(k);
}

static int Sink_init(SinkObject *k, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"cap", "flush", NULL};
    Py_ssize_t cap;
    PyObject *flush;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "nO:RowSink", kwlist, &cap, &flush))
        return -1;
    if (cap < 1) {
        PyErr_SetString(PyExc_ValueError, "RowSink: cap must be >= 1");
        return -1;
    }
    k->cap = cap;
    k->n = 0;
    Py_INCREF(flush);
    Py_XSETREF(k->flush, flush);
    /* a small file's rows, or a pass that never ends its chunk, take no more than they
     * need: the room grows (doubling) to cap + 1 rows as rows come */
    return sink_reserve(k, cap + 1 < 1024 ? cap + 1 : 1024);
}

static const char *SINK_FIELDS[SINK_ROW - 1] = {"ux", "uy", "start_v", "cruise_v", "end_v", "accel",
                                                "accel_t", "cruise_t", "decel_t", "after_stop", "idx"};

/* sink(block): the block's row, read by attribute (float() of each, as ringing._drain) */
static PyObject *Sink_call(SinkObject *k, PyObject *args, PyObject *kw)
{
    PyObject *b;
    if (!PyArg_ParseTuple(args, "O:RowSink", &b))
        return NULL;
    double row[SINK_ROW];
    for (int i = 0; i < SINK_ROW - 1; i++) {
        PyObject *v = PyObject_GetAttrString(b, SINK_FIELDS[i]);
        if (v == NULL)
            return NULL;
        row[i] = PyFloat_AsDouble(v);
        Py_DECREF(v);
        if (row[i] == -1.0 && PyErr_Occurred())
            return NULL;
    }
    row[SINK_ROW - 1] = 1.0;
    if (sink_push(k, row) < 0)
        return NULL;
    Py_RETURN_NONE;
}

/* rest(dt_t): a rest row (_rest_row) when dt_t > 0 */
static PyObject *Sink_rest(SinkObject *k, PyObject *arg)
{
    double dt = PyFloat_AsDouble(arg);
    if (dt == -1.0 && PyErr_Occurred())
        return NULL;
    if (dt > 0.0) {
        double row[SINK_ROW] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, dt, 0.0, 1.0, -1.0, 0.0};
        if (sink_push(k, row) < 0)
            return NULL;
    }
    Py_RETURN_NONE;
}

static int sink_rest(SinkObject *k, double dt)
{
    if (!(dt > 0.0))
        return 0;
    double row[SINK_ROW] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, dt, 0.0, 1.0, -1.0, 0.0};
    return sink_push(k, row);
}

/* dwell(dt_t): rest(dt_t) unless a compiled Sim writes the rests */
static PyObject *Sink_dwell(SinkObject *k, PyObject *arg)
{
    double dt = PyFloat_AsDouble(arg);
    if (dt == -1.0 && PyErr_Occurred())
        return NULL;
    if (!k->sim_rests && sink_rest(k, dt) < 0)
        return NULL;
    Py_RETURN_NONE;
}

/* line(rec): an E-only move's rest (rec.kind == EONLY: rest(rec.time_t)) unless a
 * compiled Sim writes the rests */
static PyObject *Sink_line(SinkObject *k, PyObject *rec)
{
    if (k->sim_rests)
        Py_RETURN_NONE;
    PyObject *v = PyObject_GetAttrString(rec, "kind");
    if (v == NULL)
        return NULL;
    long kind = PyLong_AsLong(v);
    Py_DECREF(v);
    if (kind == -1 && PyErr_Occurred())
        return NULL;
    if (kind != K_EONLY)
        Py_RETURN_NONE;
    v = PyObject_GetAttrString(rec, "time_t");
    if (v == NULL)
        return NULL;
    double dt = PyFloat_AsDouble(v);
    Py_DECREF(v);
    if (dt == -1.0 && PyErr_Occurred())
        return NULL;
    if (sink_rest(k, dt) < 0)
        return NULL;
    Py_RETURN_NONE;
}

/* put(data): whole rows (bytes of doubles) appended as they are, flush() not called */
static PyObject *Sink_put(SinkObject *k, PyObject *arg)
{
    Py_buffer v;
    if (PyObject_GetBuffer(arg, &v, PyBUF_SIMPLE) < 0)
        return NULL;
    Py_ssize_t rows = v.len / (Py_ssize_t)(SINK_ROW * sizeof(double));
    if (rows * (Py_ssize_t)(SINK_ROW * sizeof(double)) != v.len) {
        PyBuffer_Release(&v);
        PyErr_SetString(PyExc_ValueError, "RowSink.put: not whole rows of 12 doubles");
        return NULL;
    }
    if (sink_reserve(k, rows) < 0) {
        PyBuffer_Release(&v);
        return NULL;
    }
    memcpy(k->buf + k->n * SINK_ROW, v.buf, (size_t)v.len);
    k->n += rows;
    PyBuffer_Release(&v);
    Py_RETURN_NONE;
}

/* take(): the rows held (a bytearray: the store itself, cut to them), and the sink empty */
static PyObject *Sink_take(SinkObject *k, PyObject *noarg)
{
    if (k->store == NULL || k->n == 0) {
        k->n = 0;
        return PyByteArray_FromStringAndSize(NULL, 0);
    }
    PyObject *b = k->store;
    k->store = NULL;
    k->buf = NULL;
    k->last_alloc = k->alloc;
    Py_ssize_t len = k->n * SINK_ROW_B;
    k->n = k->alloc = 0;
    if (PyByteArray_Resize(b, len) < 0) {   /* (shrinking keeps its room: reused as it is) */
        Py_DECREF(b);
        return NULL;
    }
    Py_INCREF(b);
    Py_XSETREF(k->spare, b);
    return b;
}

static PyObject *Sink_len(SinkObject *k, void *c)
{
    return PyLong_FromSsize_t(k->n);
}

static int Sink_traverse(SinkObject *k, visitproc visit, void *arg)
{
    Py_VISIT(k->flush);
    return 0;
}

static int Sink_clear(SinkObject *k)
{
    Py_CLEAR(k->flush);
    return 0;
}

static void Sink_dealloc(SinkObject *k)
{
    PyObject_GC_UnTrack(k);
    Sink_clear(k);
    Py_XDECREF(k->store);
    Py_XDECREF(k->spare);
    Py_TYPE(k)->tp_free((PyObject *)k);
}

static PyMethodDef Sink_methods[] = {
    {"rest", (PyCFunction)Sink_rest, METH_O, "A rest of dt_t seconds (if > 0)."},
    {"put", (PyCFunction)Sink_put, METH_O, "Whole rows appended, flush() not called."},
    {"dwell", (PyCFunction)Sink_dwell, METH_O, "rest(dt_t) unless a compiled Sim writes the rests."},
    {"line", (PyCFunction)Sink_line, METH_O, "An E-only record's rest unless a compiled Sim writes the rests."},
    {"take", (PyCFunction)Sink_take, METH_NOARGS, "The rows held (bytes); the sink empties."},
    {NULL}
};

static PyObject *Sink_sim_rests(SinkObject *k, void *c)
{
    return PyBool_FromLong(k->sim_rests);
}

static PyGetSetDef Sink_getset[] = {
    {"rows", (getter)Sink_len, NULL, "rows held", NULL},
    {"sim_rests", (getter)Sink_sim_rests, NULL, "a compiled Sim writes the rests", NULL},
    {NULL}
};

static PyTypeObject SinkType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_fwcore.RowSink",
    .tp_doc = "RowSink(cap, flush): the ringing rows of a pass (see ringing.Collector).",
    .tp_basicsize = sizeof(SinkObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Sink_init,
    .tp_call = (ternaryfunc)Sink_call,
    .tp_traverse = (traverseproc)Sink_traverse,
    .tp_clear = (inquiry)Sink_clear,
    .tp_dealloc = (destructor)Sink_dealloc,
    .tp_methods = Sink_methods,
    .tp_getset = Sink_getset,
};

/* ---------------------------------------------------------------- LineRecord */
typedef struct {
    long long idx;
    int kind;
    double start_v, end_v, peak_v, time_t, int_a2, int_a2_j, int_v2, peak_a;
} RecData;

typedef struct {
    PyObject_HEAD
    RecData r;
} RecObject;

#define ROFF(f) (offsetof(RecObject, r) + offsetof(RecData, f))
static PyMemberDef Rec_members[] = {
    {"idx", T_LONGLONG, ROFF(idx), 0, NULL},
    {"kind", T_INT, ROFF(kind), 0, NULL},
    {"start_v", T_DOUBLE, ROFF(start_v), 0, NULL},
    {"end_v", T_DOUBLE, ROFF(end_v), 0, NULL},
    {"peak_v", T_DOUBLE, ROFF(peak_v), 0, NULL},
    {"time_t", T_DOUBLE, ROFF(time_t), 0, NULL},
    {"int_a2", T_DOUBLE, ROFF(int_a2), 0, NULL},
    {"int_a2_j", T_DOUBLE, ROFF(int_a2_j), 0, NULL},
    {"int_v2", T_DOUBLE, ROFF(int_v2), 0, NULL},
    {"peak_a", T_DOUBLE, ROFF(peak_a), 0, NULL},
    {NULL}
};

static PyTypeObject RecType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_fwcore.LineRecord",
    .tp_doc = "What one moving source line did (simulate.LineRecord's fields).",
    .tp_basicsize = sizeof(RecObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE,
    .tp_members = Rec_members,
    .tp_new = PyType_GenericNew,
};

/* ---------------------------------------------------------------- StrokeSums */
/* StrokeSums(lo, hi, t, a2, v2, also=None): pipeline._per_stroke in C, an on_line the
 * compiled Sim feeds without making a LineRecord.  lo, hi: the re-timed strokes' first and
 * last output lines (int64 buffers, in file order); t, a2, v2: float64 buffers written at
 * k when the records leave stroke k (flush() for the last one).  The records come in file
 * order and are summed as _per_stroke sums them (s_a2 += int_a2 + int_a2_j: the same
 * additions, in the same order, so the same bits).  also(rec), if not None, sees each
 * record after it was summed (a LineRecord is made for it then). */
#define SUMS_NOT_OPEN (1LL << 62)      /* strokes.NOT_OPEN: past the last stroke */
typedef struct {
    PyObject_HEAD
    long long *lo, *hi;
    Py_ssize_t n, k;
    long long cur_lo, cur_hi;
    int live, has_buf;
    double s_t, s_a2, s_v2;
    Py_buffer bt, ba, bv;
    PyObject *also;
} SumsObject;

static void sums_add(SumsObject *k, long long i, double time_t, double int_a2, double int_a2_j,
                     double int_v2)
{
    if (!k->has_buf)
        return;                        /* not initialised: nothing to sum into */
    double *t = (double *)k->bt.buf, *a2 = (double *)k->ba.buf, *v2 = (double *)k->bv.buf;
    if (i > k->cur_hi) {
        if (k->live) {
            t[k->k] = k->s_t;
            a2[k->k] = k->s_a2;
            v2[k->k] = k->s_v2;
            k->live = 0;
        }
        while (k->k < k->n && i > k->hi[k->k])
            k->k++;
        if (k->k >= k->n) {
            k->cur_lo = k->cur_hi = SUMS_NOT_OPEN;
            return;
        }
        k->cur_lo = k->lo[k->k];
        k->cur_hi = k->hi[k->k];
        k->s_t = k->s_a2 = k->s_v2 = 0.0;
    }
    if (k->cur_lo <= i) {
        k->live = 1;
        k->s_t += time_t;
        k->s_a2 += int_a2 + int_a2_j;
        k->s_v2 += int_v2;
    }
}

static int sums_buf(PyObject *o, Py_buffer *b, Py_ssize_t n, const char *what)
{
    if (PyObject_GetBuffer(o, b, PyBUF_WRITABLE | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return -1;
    if (b->itemsize != 8 || b->format == NULL || strcmp(b->format, "d") != 0
        || b->len < n * (Py_ssize_t)sizeof(double)) {
        PyBuffer_Release(b);
        PyErr_Format(PyExc_ValueError, "StrokeSums: %s must be a float64 buffer of len(lo)", what);
        return -1;
    }
    return 0;
}

static int sums_index(PyObject *o, long long **out, Py_ssize_t *n)
{
    Py_buffer b;
    if (PyObject_GetBuffer(o, &b, PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return -1;
    if (b.itemsize != 8 || b.format == NULL || (strcmp(b.format, "q") != 0 && strcmp(b.format, "l") != 0)) {
        PyBuffer_Release(&b);
        PyErr_SetString(PyExc_ValueError, "StrokeSums: lo and hi must be int64 buffers");
        return -1;
    }
    *n = b.len / 8;
    *out = PyMem_Malloc(b.len > 0 ? (size_t)b.len : 1);
    if (*out == NULL) {
        PyBuffer_Release(&b);
        PyErr_NoMemory();
        return -1;
    }
    memcpy(*out, b.buf, (size_t)b.len);
    PyBuffer_Release(&b);
    return 0;
}

static void sums_release(SumsObject *k)
{
    if (k->has_buf) {
        PyBuffer_Release(&k->bt);
        PyBuffer_Release(&k->ba);
        PyBuffer_Release(&k->bv);
        k->has_buf = 0;
    }
    PyMem_Free(k->lo);
    PyMem_Free(k->hi);
    k->lo = k->hi = NULL;
}

static int Sums_init(SumsObject *k, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"lo", "hi", "t", "a2", "v2", "also", NULL};
    PyObject *lo, *hi, *t, *a2, *v2, *also = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OOOOO|O:StrokeSums", kwlist, &lo, &hi, &t, &a2, &v2,
                                     &also))
        return -1;
    sums_release(k);
    Py_ssize_t n, n_hi;
    if (sums_index(lo, &k->lo, &n) < 0 || sums_index(hi, &k->hi, &n_hi) < 0)
        return -1;
    if (n_hi != n) {
        PyErr_SetString(PyExc_ValueError, "StrokeSums: lo and hi differ in length");
        return -1;
    }
    if (sums_buf(t, &k->bt, n, "t") < 0)
        return -1;
    if (sums_buf(a2, &k->ba, n, "a2") < 0) {
        PyBuffer_Release(&k->bt);
        return -1;
    }
    if (sums_buf(v2, &k->bv, n, "v2") < 0) {
        PyBuffer_Release(&k->bt);
        PyBuffer_Release(&k->ba);
        return -1;
    }
    k->has_buf = 1;
    k->n = n;
    k->k = 0;
    k->cur_lo = k->cur_hi = -1;
    k->live = 0;
    k->s_t = k->s_a2 = k->s_v2 = 0.0;
    Py_INCREF(also);
    Py_XSETREF(k->also, also);
    return 0;
}

/* sums(rec): one record by attribute (a record the Python model made, say) */
static PyObject *Sums_call(SumsObject *k, PyObject *args, PyObject *kw)
{
    static const char *names[5] = {"idx", "time_t", "int_a2", "int_a2_j", "int_v2"};
    PyObject *rec;
    if (!PyArg_ParseTuple(args, "O:StrokeSums", &rec))
        return NULL;
    if (!k->has_buf) {
        PyErr_SetString(PyExc_RuntimeError, "StrokeSums: not initialised");
        return NULL;
    }
    long long i = 0;
    double f[4];
    for (int j = 0; j < 5; j++) {
        PyObject *v = PyObject_GetAttrString(rec, names[j]);
        if (v == NULL)
            return NULL;
        if (j == 0)
            i = PyLong_AsLongLong(v);
        else
            f[j - 1] = PyFloat_AsDouble(v);
        Py_DECREF(v);
        if (PyErr_Occurred())
            return NULL;
    }
    sums_add(k, i, f[0], f[1], f[2], f[3]);
    if (k->also != Py_None) {
        PyObject *x = PyObject_CallOneArg(k->also, rec);
        if (x == NULL)
            return NULL;
        Py_DECREF(x);
    }
    Py_RETURN_NONE;
}

/* flush(): write out the stroke the records are at (after the pass) */
static PyObject *Sums_flush(SumsObject *k, PyObject *noarg)
{
    if (k->has_buf && k->live) {
        ((double *)k->bt.buf)[k->k] = k->s_t;
        ((double *)k->ba.buf)[k->k] = k->s_a2;
        ((double *)k->bv.buf)[k->k] = k->s_v2;
        k->live = 0;
    }
    Py_RETURN_NONE;
}

static int Sums_traverse(SumsObject *k, visitproc visit, void *arg)
{
    Py_VISIT(k->also);
    return 0;
}

static int Sums_clear(SumsObject *k)
{
    Py_CLEAR(k->also);
    return 0;
}

static void Sums_dealloc(SumsObject *k)
{
    PyObject_GC_UnTrack(k);
    Sums_clear(k);
    sums_release(k);
    Py_TYPE(k)->tp_free((PyObject *)k);
}

static PyMethodDef Sums_methods[] = {
    {"flush", (PyCFunction)Sums_flush, METH_NOARGS, "Write out the stroke the records are at."},
    {NULL}
};

static PyMemberDef Sums_members[] = {
    {"also", T_OBJECT, offsetof(SumsObject, also), READONLY, NULL},
    {NULL}
};

static PyTypeObject SumsType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_fwcore.StrokeSums",
    .tp_doc = "StrokeSums(lo, hi, t, a2, v2, also=None): pipeline._per_stroke in C.",
    .tp_basicsize = sizeof(SumsObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Sums_init,
    .tp_call = (ternaryfunc)Sums_call,
    .tp_traverse = (traverseproc)Sums_traverse,
    .tp_clear = (inquiry)Sums_clear,
    .tp_dealloc = (destructor)Sums_dealloc,
    .tp_methods = Sums_methods,
    .tp_members = Sums_members,
};

/* ---------------------------------------------------------------- RecordLog */
/* RecordLog(): an on_line the compiled Sim feeds without making a LineRecord, for the
 * analyse pass (pipeline.analyse).  It keeps each record's idx, start_v, end_v, time_t,
 * int_a2 + int_a2_j (the one addition pipeline.apply makes) and int_v2, in file order.
 * After the pass, stroke_sums() and feature_sums() take the sums pipeline.analyse's
 * on_line/apply take, over the same records in the same order (the same bits). */
#define LOG_COLS 5
typedef struct {
    PyObject_HEAD
    long long *idx;
    double *v;                         /* LOG_COLS a record: start_v end_v time_t a2 v2 */
    Py_ssize_t n, cap;
} LogObject;

/* log_add's room doubled (kept out of its inlined body) */
static int log_grow(LogObject *k)
{
    Py_ssize_t cap = k->cap ? 2 * k->cap : 4096;
    long long *idx = PyMem_Realloc(k->idx, (size_t)cap * sizeof(long long));
    if (idx == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    k->idx = idx;
    double *v = PyMem_Realloc(k->v, (size_t)cap * LOG_COLS * sizeof(double));
    if (v == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    k->v = v;
    k->cap = cap;
    return 0;
}

static inline int log_add(LogObject *k, const RecData *r)
{
    if (k->n == k->cap && log_grow(k) < 0)
        return -1;
    double *row = k->v + k->n * LOG_COLS;
    k->idx[k->n] = r->idx;
    row[0] = r->start_v;
    row[1] = r->end_v;
    row[2] = r->time_t;
    row[3] = r->int_a2 + r->int_a2_j;
    row[4] = r->int_v2;
    k->n++;
    return 0;
}

/* a C-contiguous buffer of n items of format fmt ("q" or "d"), writable if asked */
static int log_buf(PyObject *o, Py_buffer *b, Py_ssize_t n, const char *fmt, int writable, const char *what)
{
    if (PyObject_GetBuffer(o, b, (writable ? PyBUF_WRITABLE : 0) | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return -1;
    /* numpy's int64 is "l" on LP64 platforms, "q" elsewhere; a native-order prefix is fine */
    const char *f = b->format;
    if (f != NULL && (*f == '@' || *f == '=' || *f == '<'))
        f++;
    int ok_fmt = f != NULL && f[0] != 0 && f[1] == 0
                 && (fmt[0] == 'd' ? f[0] == 'd' : (f[0] == 'q' || f[0] == 'l'));
    if (b->itemsize != 8 || !ok_fmt || b->len != n * 8) {
        PyBuffer_Release(b);
        PyErr_Format(PyExc_ValueError, "RecordLog: %s must be a buffer of %zd '%s' items", what, n, fmt);
        return -1;
    }
    return 0;
}

/* stroke_sums(lo, hi, got, v0, v1, t, a2, v2): strokes lo[k]..hi[k] (int64 lines, in file
 * order, disjoint); for each, over the records of its lines in file order, what
 * pipeline.analyse's apply() does: v0 the record at lo's start_v (got bit 1), v1 the record
 * at hi's end_v (got bit 2), t, a2, v2 sums from 0.0.  All outputs are written. */
static PyObject *Log_stroke_sums(LogObject *k, PyObject *args)
{
    PyObject *o[8];
    if (!PyArg_ParseTuple(args, "OOOOOOOO:stroke_sums", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7]))
        return NULL;
    Py_ssize_t n = PyObject_Length(o[0]);
    if (n < 0)
        return NULL;
    static const char *names[8] = {"lo", "hi", "got", "v0", "v1", "t", "a2", "v2"};
    Py_buffer b[8];
    int nb = 0;
    for (; nb < 8; nb++)
        if (log_buf(o[nb], &b[nb], n, nb < 3 ? "q" : "d", nb >= 2, names[nb]) < 0)
            goto fail;
    const long long *lo = b[0].buf, *hi = b[1].buf;
    long long *got = b[2].buf;
    double *v0 = b[3].buf, *v1 = b[4].buf, *t = b[5].buf, *a2 = b[6].buf, *v2 = b[7].buf;
    Py_ssize_t j = 0;
    for (Py_ssize_t q = 0; q < n; q++) {
        while (j < k->n && k->idx[j] < lo[q])
            j++;
        double s_t = 0.0, s_a2 = 0.0, s_v2 = 0.0;
        long long g = 0;
        double w0 = 0.0, w1 = 0.0;
        for (; j < k->n && k->idx[j] <= hi[q]; j++) {
            const double *row = k->v + j * LOG_COLS;
            if (k->idx[j] == lo[q]) {
                w0 = row[0];
                g |= 1;
            }
            if (k->idx[j] == hi[q]) {
                w1 = row[1];
                g |= 2;
            }
            s_t += row[2];
            s_a2 += row[3];
            s_v2 += row[4];
        }
        got[q] = g;
        v0[q] = w0;
        v1[q] = w1;
        t[q] = s_t;
        a2[q] = s_a2;
        v2[q] = s_v2;
    }
    for (int q = 0; q < 8; q++)
        PyBuffer_Release(&b[q]);
    Py_RETURN_NONE;
fail:
    for (int q = 0; q < nb; q++)
        PyBuffer_Release(&b[q]);
    return NULL;
}

/* feature_sums(starts, ids, count, t, a2, first): the feature tally of pipeline.analyse's
 * on_line.  starts (int64, ascending): the lines where the moves' feature changes, ids
 * (int64) that feature's number there; a record belongs to the last start at or before its
 * line (none before the first: skipped).  Per feature number f (count, t, a2, first:
 * buffers of n_features items, zeroed by the caller, first at -1): records, their time_t
 * and a2 summed from 0.0 in file order, and the position of its first record.  stop, if
 * given, the number of records (the first ones) to take: the analyse pass takes a prefix,
 * drops it (drop) and goes on with the same sums later (the same additions in the same
 * order: the same bits). */
static PyObject *Log_feature_sums(LogObject *k, PyObject *args)
{
    PyObject *o[6];
    Py_ssize_t stop = -1;
    if (!PyArg_ParseTuple(args, "OOOOOO|n:feature_sums", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &stop))
        return NULL;
    if (stop < 0 || stop > k->n)
        stop = k->n;
    Py_ssize_t m = PyObject_Length(o[0]), nf = PyObject_Length(o[2]);
    if (m < 0 || nf < 0)
        return NULL;
    static const char *names[6] = {"starts", "ids", "count", "t", "a2", "first"};
    const char *fmts[6] = {"q", "q", "q", "d", "d", "q"};
    Py_ssize_t lens[6] = {m, m, nf, nf, nf, nf};
    Py_buffer b[6];
    int nb = 0;
    for (; nb < 6; nb++)
        if (log_buf(o[nb], &b[nb], lens[nb], fmts[nb], nb >= 2, names[nb]) < 0)
            goto fail;
    const long long *starts = b[0].buf, *ids = b[1].buf;
    long long *count = b[2].buf, *first = b[5].buf;
    double *t = b[3].buf, *a2 = b[4].buf;
    for (Py_ssize_t q = 0; q < m; q++)
        if (ids[q] < 0 || ids[q] >= nf) {
            PyErr_SetString(PyExc_ValueError, "RecordLog: a feature number out of range");
            goto fail;
        }
    Py_ssize_t p = -1;
    for (Py_ssize_t j = 0; j < stop; j++) {
        long long i = k->idx[j];
        while (p + 1 < m && starts[p + 1] <= i)
            p++;
        if (p < 0)
            continue;
        long long f = ids[p];
        const double *row = k->v + j * LOG_COLS;
        if (first[f] < 0)
            first[f] = j;
        count[f] += 1;
        t[f] += row[2];
        a2[f] += row[3];
    }
    for (int q = 0; q < 6; q++)
        PyBuffer_Release(&b[q]);
    Py_RETURN_NONE;
fail:
    for (int q = 0; q < nb; q++)
        PyBuffer_Release(&b[q]);
    return NULL;
}

static PyObject *Log_call(LogObject *k, PyObject *args, PyObject *kw)
{
    /* a Python caller handing a LineRecord (the Python model never does: analyse gives
     * a RecordLog only to the compiled Sim, which calls log_add itself) */
    PyObject *rec;
    if (!PyArg_ParseTuple(args, "O!:RecordLog", &RecType, &rec))
        return NULL;
    if (log_add(k, &((RecObject *)rec)->r) < 0)
        return NULL;
    Py_RETURN_NONE;
}

static void Log_dealloc(LogObject *k)
{
    PyMem_Free(k->idx);
    PyMem_Free(k->v);
    Py_TYPE(k)->tp_free((PyObject *)k);
}

static PyObject *Log_len(LogObject *k, void *c)
{
    return PyLong_FromSsize_t(k->n);
}

/* the idx of the last record, -1 if none */
static PyObject *Log_last(LogObject *k, void *c)
{
    return PyLong_FromLongLong(k->n ? k->idx[k->n - 1] : -1);
}

/* below(line): how many records (the first ones: file order) are of lines before line */
static PyObject *Log_below(LogObject *k, PyObject *arg)
{
    long long line = PyLong_AsLongLong(arg);
    if (line == -1 && PyErr_Occurred())
        return NULL;
    Py_ssize_t lo = 0, hi = k->n;
    while (lo < hi) {
        Py_ssize_t mid = lo + (hi - lo) / 2;
        if (k->idx[mid] < line)
            lo = mid + 1;
        else
            hi = mid;
    }
    return PyLong_FromSsize_t(lo);
}

/* drop(n): forget the first n records (the analyse pass has summed them): the log holds
 * the records not summed yet, not the whole file's (~48 bytes a record) */
static PyObject *Log_drop(LogObject *k, PyObject *arg)
{
    Py_ssize_t n = PyLong_AsSsize_t(arg);
    if (n == -1 && PyErr_Occurred())
        return NULL;
    if (n < 0 || n > k->n) {
        PyErr_SetString(PyExc_ValueError, "RecordLog.drop: n out of range");
        return NULL;
    }
    Py_ssize_t rest = k->n - n;
    memmove(k->idx, k->idx + n, (size_t)rest * sizeof(long long));
    memmove(k->v, k->v + n * LOG_COLS, (size_t)rest * LOG_COLS * sizeof(double));
    k->n = rest;
    Py_RETURN_NONE;
}

static PyMethodDef Log_methods[] = {
    {"stroke_sums", (PyCFunction)Log_stroke_sums, METH_VARARGS,
     "stroke_sums(lo, hi, got, v0, v1, t, a2, v2): pipeline.analyse's apply() per stroke."},
    {"feature_sums", (PyCFunction)Log_feature_sums, METH_VARARGS,
     "feature_sums(starts, ids, count, t, a2, first[, stop]): pipeline.analyse's feature tally."},
    {"below", (PyCFunction)Log_below, METH_O, "below(line): records of lines before line (the first ones)."},
    {"drop", (PyCFunction)Log_drop, METH_O, "drop(n): forget the first n records."},
    {NULL}
};

static PyGetSetDef Log_getset[] = {
    {"rows", (getter)Log_len, NULL, "records held", NULL},
    {"last", (getter)Log_last, NULL, "the last record's line, -1 if none", NULL},
    {NULL}
};

static PyTypeObject LogType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_fwcore.RecordLog",
    .tp_doc = "RecordLog(): the analyse pass's records, summed per stroke and feature after it.",
    .tp_basicsize = sizeof(LogObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_new = PyType_GenericNew,
    .tp_call = (ternaryfunc)Log_call,
    .tp_dealloc = (destructor)Log_dealloc,
    .tp_methods = Log_methods,
    .tp_getset = Log_getset,
};

/* ---------------------------------------------------------------- SimResult */
typedef struct {
    PyObject_HEAD
    double time_t, int_a2, int_a2_t, int_v2, peak_v, peak_a, barrier_dwell_t, corner_dv2;
    long long n_moves, n_blocks, full_stops, short_segments, corners;
    PyObject *stop_lines;
} ResObject;

static PyMemberDef Res_members[] = {
    {"time_t", T_DOUBLE, offsetof(ResObject, time_t), 0, NULL},
    {"int_a2", T_DOUBLE, offsetof(ResObject, int_a2), 0, NULL},
    {"int_a2_t", T_DOUBLE, offsetof(ResObject, int_a2_t), 0, NULL},
    {"int_v2", T_DOUBLE, offsetof(ResObject, int_v2), 0, NULL},
    {"peak_v", T_DOUBLE, offsetof(ResObject, peak_v), 0, NULL},
    {"peak_a", T_DOUBLE, offsetof(ResObject, peak_a), 0, NULL},
    {"n_moves", T_LONGLONG, offsetof(ResObject, n_moves), 0, NULL},
    {"n_blocks", T_LONGLONG, offsetof(ResObject, n_blocks), 0, NULL},
    {"full_stops", T_LONGLONG, offsetof(ResObject, full_stops), 0, NULL},
    {"stop_lines", T_OBJECT_EX, offsetof(ResObject, stop_lines), 0, NULL},
    {"short_segments", T_LONGLONG, offsetof(ResObject, short_segments), 0, NULL},
    {"barrier_dwell_t", T_DOUBLE, offsetof(ResObject, barrier_dwell_t), 0, NULL},
    {"corners", T_LONGLONG, offsetof(ResObject, corners), 0, NULL},
    {"corner_dv2", T_DOUBLE, offsetof(ResObject, corner_dv2), 0, NULL},
    {NULL}
};

static int Res_init(ResObject *self, PyObject *args, PyObject *kw)
{
    if ((args != NULL && PyTuple_GET_SIZE(args)) || (kw != NULL && PyDict_GET_SIZE(kw))) {
        PyErr_SetString(PyExc_TypeError, "SimResult() takes no arguments");
        return -1;
    }
    self->time_t = self->int_a2 = self->int_a2_t = self->int_v2 = 0.0;
    self->peak_v = self->peak_a = self->barrier_dwell_t = self->corner_dv2 = 0.0;
    self->n_moves = self->n_blocks = self->full_stops = self->short_segments = self->corners = 0;
    PyObject *l = PyList_New(0);
    if (l == NULL)
        return -1;
    Py_XSETREF(self->stop_lines, l);
    return 0;
}

static int Res_traverse(ResObject *self, visitproc visit, void *arg)
{
    Py_VISIT(self->stop_lines);
    return 0;
}

static int Res_clear(ResObject *self)
{
    Py_CLEAR(self->stop_lines);
    return 0;
}

static void Res_dealloc(ResObject *self)
{
    /* a Python subclass's subtype_dealloc drops the reference to its type */
    PyObject_GC_UnTrack(self);
    Res_clear(self);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* the eleven sums of r in _SUMS' order (take_stop's and quiet_record's row) */
#define RES_SUMS_N 11

static void res_sums_row(const ResObject *r, double row[RES_SUMS_N])
{
    const double v[RES_SUMS_N] = {r->time_t, r->int_a2, r->int_a2_t, r->int_v2, (double)r->n_moves,
                                  (double)r->n_blocks, (double)r->full_stops, (double)r->short_segments,
                                  r->barrier_dwell_t, (double)r->corners, r->corner_dv2};
    memcpy(row, v, sizeof v);
}

/* take_stop(): (peak_v, peak_a, sums), the peaks then set to 0.0: what the measure's ledger
 * (simulate._LedgerWriter.stopped) reads where the model stands empty, in one call (its
 * thirteen attribute reads and writes cost ~6 k instructions a stop, ~5 k stops a plate).
 * sums: simulate._sums_row(res)'s bytes, the eleven sums in _SUMS' order as the Ledger's
 * array("d") holds them (the counts as doubles: exact below 2^53, as array's conversion). */
static PyObject *Res_take_stop(ResObject *self, PyObject *Py_UNUSED(noarg))
{
    double row[RES_SUMS_N];
    res_sums_row(self, row);
    PyObject *r = Py_BuildValue("(ddy#)", self->peak_v, self->peak_a, (const char *)row, (Py_ssize_t)sizeof(row));
    if (r != NULL)
        self->peak_v = self->peak_a = 0.0;
    return r;
}

static PyMethodDef Res_methods[] = {
    {"take_stop", (PyCFunction)Res_take_stop, METH_NOARGS, "(peak_v, peak_a, sums); the peaks set to 0.0"},
    {NULL}
};

static PyTypeObject ResType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_fwcore.SimResult",
    .tp_doc = "The firmware model's figures of a pass (simulate.SimResult's fields).",
    .tp_basicsize = sizeof(ResObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC,
    .tp_members = Res_members,
    .tp_methods = Res_methods,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Res_init,
    .tp_traverse = (traverseproc)Res_traverse,
    .tp_clear = (inquiry)Res_clear,
    .tp_dealloc = (destructor)Res_dealloc,
};

/* ---------------------------------------------------------------- Sim */
enum { J_SCV, J_JD, J_JERK, J_OTHER };   /* J_OTHER: _Sim's else-branch (jerk junction, no safe speed) */

typedef struct {
    PyObject_HEAD
    PyObject *on_line, *on_block;
    ResObject *res;
    PyObject *max_stop_lines;         /* as set (100 or inf) */
    double max_stop_d;
    /* constants (simulate.py, junction.py, planner.py) */
    double corner_cos, sqrt2_m1, mps, arc_min_turn;
    /* profile */
    int klipper_limits, klipper_fw, model, marlin;
    int marlin_jerk;                  /* marlin, J_JERK, not klipper_fw: play_fused's CFG_MARLIN_JERK */
    double jerk_z, icv, min_seg_t, arc_segment_d, default_accel, max_z_accel, max_z_v, max_e_v;
    double caps[3], jerk[3];
    int caps_nonneg;                  /* no cap < 0: caps_axis() may be used (set with caps) */
    PyObject *lim;                    /* the Limits caps and jerk were last taken from */
    PyObject *vlim;                   /* the Limits vlim_* were last taken from (vlim_read) */
    double vlim_v_max, vlim_scv, vlim_mcr, vlim_jd;
    int vlim_nonneg;                  /* neither vlim_v_max nor max_z_v < 0 (vlim_read) */
    double stop_thr;
    /* planner: Klipper's queue q[0..n) / Marlin's buf q[0..n) with head */
    BlockData *q;
    Py_ssize_t n, cap, head;
    Py_ssize_t chunk, next_try, window;
    double prev_cruise;
    int has_last;                     /* Marlin: q[n - 1] is the last block added */
    int has_entry;
    double entry_v2;
    double *info;                     /* Klipper flush: start, cruise, next_start per move */
    char *info_c;                     /* cruise set (else None) */
    Py_ssize_t info_cap;
    /* accumulator */
    int has_prev;
    double prev_ux, prev_uy, prev_uz, prev_t;
    int has_rec;
    RecData rec;
    int busy;                         /* inside move/barrier/stop: a callback may not re-enter */
} SimObject;

/* the per-block path (sim_block -> planner -> sim_emit -> sink) inlined into one body:
 * ~40 instructions a block of calls, saved registers and reloads fewer */
#define BLOCK_PATH static inline __attribute__((always_inline))
BLOCK_PATH int sim_emit(SimObject *s, BlockData *b);

/* The per-block path's configuration, a constant argument of its inlined functions:
 * CFG_ANY reads the profile's choices from the Sim, CFG_MARLIN_JERK knows them (a Marlin
 * planner, the jerk junction, Marlin's limits: the plates' profiles), so play_fused's body
 * for it tests none of them per block (~20 instructions a block). */
enum { CFG_ANY, CFG_MARLIN_JERK, CFG_MARLIN_JERK_XY };
#define CFG_MARLIN(s, cfg) ((cfg) != CFG_ANY ? 1 : (s)->marlin)
#define CFG_MODEL(s, cfg) ((cfg) != CFG_ANY ? J_JERK : (s)->model)
#define CFG_KLIPPER_FW(s, cfg) ((cfg) != CFG_ANY ? 0 : (s)->klipper_fw)
#define CFG_KLIPPER_LIMITS(s, cfg) ((cfg) != CFG_ANY ? 0 : (s)->klipper_limits)
/* CFG_MARLIN_JERK_XY: CFG_MARLIN_JERK for a block with dz == 0 (+0 or -0) where the Z jerk
 * is not < 0 (s->jerk_z: 0, > 0 or NaN), so uz is +-0, or NaN where d is: every test of a
 * Z cap or a Z jerk on it is false (0 or NaN times a number is not above a cap that is not
 * < 0; NaN compares false), and dz * dz adds +0 to d's sum, which changes no bit.  Its
 * body leaves them out (~25 instructions a block of the plates'); b->uz is still dz * (1 / d). */
#define CFG_XY(cfg) ((cfg) == CFG_MARLIN_JERK_XY)

/* An axis's cap on a speed or acceleration x along unit-vector component au = |u| (0, > 0
 * or NaN), for a cap that is not < 0: x * au > cap says au > 0 too (au == 0 gives a
 * product of 0 or NaN, not above the cap), so _block's `au > 0.0 and x * au > cap` needs
 * only the product's test, and its division no zero check.  The same operations on the
 * same numbers: the same bits. */
static inline double caps_axis(double x, double au, double cap)
{
    return x * au > cap ? cap / au : x;
}

static int caps_nonneg(const double *caps)
{
    return !(caps[0] < 0.0) && !(caps[1] < 0.0) && !(caps[2] < 0.0);
}

static double getattr_d(PyObject *o, const char *name, double dflt, int use_dflt, int *err)
{
    PyObject *v = PyObject_GetAttrString(o, name);
    if (v == NULL) {
        if (use_dflt && PyErr_ExceptionMatches(PyExc_AttributeError)) {
            PyErr_Clear();
            return dflt;
        }
        *err = 1;
        return 0.0;
    }
    double x = PyFloat_AsDouble(v);
    Py_DECREF(v);
    if (x == -1.0 && PyErr_Occurred())
        *err = 1;
    return x;
}

static int Sim_init(SimObject *s, PyObject *args, PyObject *kw)
{
    static char *kwlist[] = {"profile", "on_line", "on_block", "consts", NULL};
    PyObject *prof, *on_line, *on_block = Py_None;
    double full_stop_v, klipper_icv;
    Py_ssize_t chunk, max_stop_lines;
    if (!configured) {
        PyErr_SetString(PyExc_RuntimeError, "_gcode_opt_fwcore: setup() was not called");
        return -1;
    }
    if (s->busy) {
        PyErr_SetString(PyExc_RuntimeError, "the firmware model was re-entered from its own callback");
        return -1;
    }
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OOO(ddddddnn):Sim", kwlist, &prof, &on_line,
                                     &on_block, &s->corner_cos, &full_stop_v, &s->sqrt2_m1,
                                     &s->mps, &klipper_icv, &s->arc_min_turn, &chunk,
                                     &max_stop_lines))
        return -1;
    Py_INCREF(on_line);
    Py_XSETREF(s->on_line, on_line);
    Py_INCREF(on_block);
    Py_XSETREF(s->on_block, on_block);
    if (Py_IS_TYPE(on_block, &SinkType))
        ((SinkObject *)on_block)->sim_rests = 1;
    PyObject *res = PyObject_CallNoArgs((PyObject *)RES_TYPE);
    if (res == NULL)
        return -1;
    if (!PyObject_TypeCheck(res, &ResType)) {
        Py_DECREF(res);
        PyErr_SetString(PyExc_TypeError, "setup: the result class must derive from _core.SimResult");
        return -1;
    }
    Py_XSETREF(s->res, (ResObject *)res);
    PyObject *msl = PyLong_FromSsize_t(max_stop_lines);
    if (msl == NULL)
        return -1;
    Py_XSETREF(s->max_stop_lines, msl);
    s->max_stop_d = (double)max_stop_lines;

    int err = 0;
    PyObject *o = PyObject_GetAttrString(prof, "block_buffer");
    if (o == NULL)
        return -1;
    long bb = PyLong_AsLong(o);
    Py_DECREF(o);
    if (bb == -1 && PyErr_Occurred())
        return -1;
    o = PyObject_GetAttrString(prof, "flavour");
    if (o == NULL)
        return -1;
    s->klipper_fw = PyUnicode_Check(o) && PyUnicode_CompareWithASCIIString(o, "klipper") == 0;
    Py_DECREF(o);
    o = PyObject_GetAttrString(prof, "junction");
    if (o == NULL)
        return -1;
    if (PyUnicode_Check(o) && PyUnicode_CompareWithASCIIString(o, "scv") == 0)
        s->model = J_SCV;
    else if (PyUnicode_Check(o) && PyUnicode_CompareWithASCIIString(o, "jd") == 0)
        s->model = J_JD;
    else if (PyUnicode_Check(o) && PyUnicode_CompareWithASCIIString(o, "jerk") == 0)
        s->model = J_JERK;
    else
        s->model = J_OTHER;
    Py_DECREF(o);
    s->klipper_limits = bb <= 0;
    s->marlin = bb > 0;
    s->marlin_jerk = s->marlin && s->model == J_JERK && !s->klipper_fw;
    s->jerk_z = getattr_d(prof, "jerk_z_v", 0.4, 1, &err);
    s->icv = getattr_d(prof, "instantaneous_corner_velocity_v", klipper_icv, 1, &err);
    double max_accel = getattr_d(prof, "max_accel_a", 0, 0, &err);
    s->max_z_accel = getattr_d(prof, "max_z_accel_a", 0, 0, &err);
    double jerk_xy = getattr_d(prof, "jerk_xy_v", 0, 0, &err);
    s->min_seg_t = getattr_d(prof, "min_segment_time_t", 0, 0, &err);
    s->arc_segment_d = getattr_d(prof, "arc_segment_d", 0, 0, &err);
    s->default_accel = getattr_d(prof, "default_accel_a", 0, 0, &err);
    s->max_z_v = getattr_d(prof, "max_z_velocity_v", 0, 0, &err);
    s->max_e_v = getattr_d(prof, "max_e_velocity_v", 0, 0, &err);
    if (err)
        return -1;
    s->caps[0] = s->caps[1] = max_accel;
    s->caps[2] = s->max_z_accel;
    s->caps_nonneg = caps_nonneg(s->caps);
    s->jerk[0] = s->jerk[1] = jerk_xy;
    s->jerk[2] = s->jerk_z;
    Py_CLEAR(s->lim);
    Py_CLEAR(s->vlim);                /* (vlim_nonneg reads max_z_v: read again) */
    s->n = s->head = 0;
    s->chunk = chunk;
    s->next_try = chunk;
    s->prev_cruise = 0.0;
    s->has_last = s->has_entry = 0;
    if (s->marlin) {
        /* a ring buffer of B slots holds B-1 blocks, the executing one included */
        long w = bb - 1;
        s->window = w < 1 ? 1 : w;
        s->stop_thr = pymax(s->mps * (1.0 + 1e-6), full_stop_v);
    } else {
        s->window = 0;
        s->stop_thr = pymax(1e-6, full_stop_v);
    }
    s->has_prev = 0;
    s->prev_t = 0.0;
    s->has_rec = 0;
    s->busy = 0;
    return 0;
}

static int Sim_traverse(SimObject *s, visitproc visit, void *arg)
{
    Py_VISIT(s->on_line);
    Py_VISIT(s->on_block);
    Py_VISIT(s->res);
    Py_VISIT(s->max_stop_lines);
    Py_VISIT(s->lim);
    Py_VISIT(s->vlim);
    return 0;
}

static int Sim_clear(SimObject *s)
{
    Py_CLEAR(s->on_line);
    Py_CLEAR(s->on_block);
    Py_CLEAR(s->res);
    Py_CLEAR(s->max_stop_lines);
    Py_CLEAR(s->lim);
    Py_CLEAR(s->vlim);
    return 0;
}

static void Sim_dealloc(SimObject *s)
{
    PyObject_GC_UnTrack(s);
    Sim_clear(s);
    PyMem_Free(s->q);
    PyMem_Free(s->info);
    PyMem_Free(s->info_c);
    Py_TYPE(s)->tp_free((PyObject *)s);
}

/* ---- junction laws (junction.py) ------------------------------------------------ */
static int klipper_corner_v2(double pux, double puy, double puz, double p_jd, double p_accel,
                             double p_delta_v2, double ux, double uy, double uz, double jd,
                             double accel, double delta_v2, double *out)
{
    double cos_theta = -(ux * pux + uy * puy + uz * puz);
    double s2 = 0.5 * (1.0 - cos_theta);
    double c2 = 0.5 * (1.0 + cos_theta);
    double sin_d2 = s2 > 0.0 ? sqrt_rn(s2) : 0.0;
    double cos_d2 = c2 > 0.0 ? sqrt_rn(c2) : 0.0;
    double one_m = 1.0 - sin_d2;
    if (one_m > 0.0 && cos_d2 > 0.0) {
        double r_jd, qt, c;
        DIV(r_jd, sin_d2, one_m);
        double v2 = r_jd * jd * accel;
        double pv2 = r_jd * p_jd * p_accel;
        if (pv2 < v2)
            v2 = pv2;
        DIV(qt, 0.25 * sin_d2, cos_d2);
        c = delta_v2 * qt;
        if (c < v2)
            v2 = c;
        c = p_delta_v2 * qt;
        if (c < v2)
            v2 = c;
        *out = v2;
        return 0;
    }
    *out = Py_HUGE_VAL;
    return 0;
}

static int klipper_extruder_v2(double p_er, double er, double icv, double *out)
{
    double diff = er - p_er;
    if (diff != 0.0) {
        double x;
        DIV(x, icv, fabs(diff));
        double r = pow(x, 2.0);
        if (isinf(r) && isfinite(x)) {           /* float.__pow__ overflow */
            PyErr_SetString(PyExc_OverflowError, "(34, 'Numerical result out of range')");
            return -1;
        }
        *out = r;
        return 0;
    }
    *out = Py_HUGE_VAL;
    return 0;
}

static int axis_limited(double value, double ux, double uy, double uz, double cx, double cy,
                        double cz, double *out)
{
    double a = fabs(ux);
    if (a > 0.0 && value * a > cx)
        DIV(value, cx, a);
    a = fabs(uy);
    if (a > 0.0 && value * a > cy)
        DIV(value, cy, a);
    a = fabs(uz);
    if (a > 0.0 && value * a > cz)
        DIV(value, cz, a);
    *out = value;
    return 0;
}

static double marlin_fast_acos_neg(double cos_theta)
{
    double neg = cos_theta < 0.0 ? -1.0 : 1.0;
    double t = neg * cos_theta;
    double asinx = (0.032843707 + t * (-1.451838349 + t * (29.66153956 + t * (-131.1123477
                    + t * (262.8130562 + t * (-242.7199627 + t * 84.31466202))))));
    return M_PI / 2.0 + neg * asinx;
}

static int marlin_jd_v2(double mps, double pux, double puy, double puz, double ux, double uy, double uz,
                        double d, double accel, double jd, double cx, double cy, double cz,
                        double *out)
{
    double cos_theta = -(pux * ux + puy * uy + puz * uz);
    if (cos_theta > 0.999999) {                  /* 0 deg acute junction: reversal */
        *out = mps * mps;
        return 0;
    }
    double jx = ux - pux, jy = uy - puy, jz = uz - puz;
    double jn = sqrt_rn(jx * jx + jy * jy + jz * jz);
    double ja;
    if (jn > 0.0) {
        double a1, a2, a3;
        DIV(a1, jx, jn);
        DIV(a2, jy, jn);
        DIV(a3, jz, jn);
        if (axis_limited(accel, a1, a2, a3, cx, cy, cz, &ja) < 0)
            return -1;
    }
    else
        ja = accel;
    double s = 0.5 * (1.0 - cos_theta);
    double sin_d2 = s > 0.0 ? sqrt_rn(s) : 0.0;
    double one_m = 1.0 - sin_d2;
    double v2;
    if (one_m > 0.0)
        DIV(v2, ja * jd * sin_d2, one_m);
    else
        v2 = Py_HUGE_VAL;
    if (d < 1.0 && cos_theta < -0.7071067812) {
        double theta = marlin_fast_acos_neg(cos_theta), lim;
        DIV(lim, d * ja, theta);
        if (lim < v2)
            v2 = lim;
    }
    *out = v2;
    return 0;
}

/* Python's max(v_exit, -v_entry) etc. in marlin_jerk_junction_v */
#define JERK_OF(jerk, v_exit, v_entry) do {                                               \
    if ((v_exit) > (v_entry))                                                             \
        (jerk) = ((v_entry) > 0.0 || (v_exit) < 0.0) ? ((v_exit) - (v_entry))               \
                                                   : pymax((v_exit), -(v_entry));         \
    else                                                                                  \
        (jerk) = ((v_entry) < 0.0 || (v_exit) > 0.0) ? ((v_entry) - (v_exit))               \
                                                   : pymax(-(v_exit), (v_entry));         \
} while (0)

/* one axis of marlin_jerk_junction_v's loop (written out per axis: no arrays, ~40 instructions
 * a junction fewer) */
BLOCK_PATH int jerk_axis(double pu, double p_nominal, double smaller, double u, double nominal,
                         double jmax, double *v_factor, int *limited)
{
    double v_exit = pu * p_nominal * smaller, v_entry = u * nominal, jerk, f;
    if (*limited) {
        v_exit *= *v_factor;
        v_entry *= *v_factor;
    }
    JERK_OF(jerk, v_exit, v_entry);
    if (jerk > jmax) {
        DIV(f, jmax, jerk);
        *v_factor *= f;
        *limited = 1;
    }
    return 0;
}

/* z_axis 0: the Z axis's term left out, where it cannot limit (CFG_XY: puz == 0, uz +-0 or
 * NaN, jz not < 0: the Z jerk is +-0 or NaN, not above jz) */
BLOCK_PATH int marlin_jerk_junction_v(double pux, double puy, double puz, double p_nominal,
                                      double p_safe, double ux, double uy, double uz, double nominal,
                                      double safe, double jx, double jy, double jz, int z_axis, double *out)
{
    double vmax = nominal < p_nominal ? nominal : p_nominal;
    double smaller;
    DIV(smaller, vmax, p_nominal);
    double v_factor = 1.0;
    int limited = 0;
    /* X, Y, Z in turn, as the Python law */
    if (jerk_axis(pux, p_nominal, smaller, ux, nominal, jx, &v_factor, &limited) < 0
        || jerk_axis(puy, p_nominal, smaller, uy, nominal, jy, &v_factor, &limited) < 0
        || (z_axis && jerk_axis(puz, p_nominal, smaller, uz, nominal, jz, &v_factor, &limited) < 0))
        return -1;
    if (limited)
        vmax *= v_factor;
    double thr = vmax * 0.99;
    if (p_safe > thr && safe > thr)             /* not coasting: Marlin restarts from safe speed */
        vmax = safe;
    *out = vmax;
    return 0;
}

BLOCK_PATH int junction(SimObject *s, BlockData *p, BlockData *b, double *out, const int cfg)
{
    const int model = CFG_MODEL(s, cfg);
    if (model == J_SCV) {
        double v2, e2;
        if (klipper_corner_v2(p->ux, p->uy, p->uz, p->jd, p->accel, p->delta_v2,
                              b->ux, b->uy, b->uz, b->jd, b->accel, b->delta_v2, &v2) < 0)
            return -1;
        if (b->er != p->er) {
            if (klipper_extruder_v2(p->er, b->er, s->icv, &e2) < 0)
                return -1;
            if (e2 < v2)
                v2 = e2;
        }
        *out = v2;
        return 0;
    }
    if (model == J_JD)
        return marlin_jd_v2(s->mps, p->ux, p->uy, p->uz, b->ux, b->uy, b->uz, b->d, b->accel, b->jd,
                            s->caps[0], s->caps[1], s->caps[2], out);
    double v;
    if (marlin_jerk_junction_v(p->ux, p->uy, p->uz, p->nominal_v, p->safe_v, b->ux, b->uy, b->uz,
                               b->nominal_v, b->safe_v, s->jerk[0], s->jerk[1], s->jerk[2],
                               !(CFG_XY(cfg) && p->uz == 0.0), &v) < 0)
        return -1;
    *out = v * v;
    return 0;
}

/* ---- planners (planner.py) -------------------------------------------------------- */
BLOCK_PATH int set_trapezoid(BlockData *b, double start_v2, double cruise_v2, double end_v2)
{
    double half_inv_a;
    DIV(half_inv_a, 0.5, b->accel);
    double accel_d = (cruise_v2 - start_v2) * half_inv_a;
    double decel_d = (cruise_v2 - end_v2) * half_inv_a;
    double cruise_d = b->d - accel_d - decel_d;
    if (cruise_d < 0.0)                          /* rounding only */
        cruise_d = 0.0;
    double sv = 0.0, cv, ev = 0.0;
    if (start_v2 > 0.0)
        SQRT(sv, start_v2);
    SQRT(cv, cruise_v2);
    if (end_v2 > 0.0)
        SQRT(ev, end_v2);
    b->start_v = sv;
    b->cruise_v = cv;
    b->end_v = ev;
    if (accel_d > 0.0)
        DIV(b->accel_t, accel_d, (sv + cv) * 0.5);
    else
        b->accel_t = 0.0;
    DIV(b->cruise_t, cruise_d, cv);
    if (decel_d > 0.0)
        DIV(b->decel_t, decel_d, (ev + cv) * 0.5);
    else
        b->decel_t = 0.0;
    return 0;
}

static int grow_queue(SimObject *s)
{
    if (s->n < s->cap)
        return 0;
    Py_ssize_t cap = s->cap ? 2 * s->cap : 1024;
    BlockData *q = PyMem_Realloc(s->q, (size_t)cap * sizeof(BlockData));
    if (q == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    s->q = q;
    s->cap = cap;
    return 0;
}

/* KlipperPlanner.flush: the number of moves committed, or -1 on error. */
static Py_ssize_t klipper_flush(SimObject *s, int lazy)
{
    BlockData *q = s->q;
    Py_ssize_t n = s->n, flush_count = n;
    int update = lazy;
    if (n > s->info_cap) {
        Py_ssize_t cap = n + n / 2 + 16;
        double *info = PyMem_Realloc(s->info, (size_t)cap * 3 * sizeof(double));
        if (info == NULL) {
            PyErr_NoMemory();
            return -1;
        }
        s->info = info;
        char *ic = PyMem_Realloc(s->info_c, (size_t)cap);
        if (ic == NULL) {
            PyErr_NoMemory();
            return -1;
        }
        s->info_c = ic;
        s->info_cap = cap;
    }
    double *info = s->info;
    char *info_c = s->info_c;
    double next_start = 0.0, next_mcr = 0.0, peak = 0.0;
    Py_ssize_t pending = 0;
    for (Py_ssize_t i = n - 1; i >= 0; i--) {
        BlockData *m = &q[i];
        double reach = next_start + m->delta_v2;
        double start = m->max_start_v2;
        if (reach < start)
            start = reach;
        int has_cruise = 0;
        double cruise = 0.0;
        pending += 1;
        double reach_mcr = next_mcr + m->mcr_delta_v2;
        double mcr = m->max_mcr_start_v2;
        if (reach_mcr < mcr)
            mcr = reach_mcr;
        if (mcr < reach_mcr) {
            /* this move can accelerate */
            if (mcr + m->mcr_delta_v2 > next_mcr || pending > 1) {
                if (update && peak != 0.0) {
                    flush_count = i + pending;
                    update = 0;
                }
                peak = (mcr + reach_mcr) * 0.5;
            }
            cruise = (start + reach) * 0.5;
            if (m->v2max < cruise)
                cruise = m->v2max;
            if (peak < cruise)
                cruise = peak;
            has_cruise = 1;
            pending = 0;
        }
        info[3 * i] = start;
        info[3 * i + 1] = cruise;
        info[3 * i + 2] = next_start;
        info_c[i] = (char)has_cruise;
        next_start = start;
        next_mcr = mcr;
    }
    if (update || !flush_count)
        return 0;
    double prev_cruise = s->prev_cruise;
    for (Py_ssize_t i = 0; i < flush_count; i++) {
        BlockData *m = &q[i];
        double start = info[3 * i];
        double cruise = info[3 * i + 1];
        if (!info_c[i])                 /* can't accelerate: carries the previous cruise */
            cruise = prev_cruise < start ? prev_cruise : start;
        double end = info[3 * i + 2];
        if (set_trapezoid(m, start < cruise ? start : cruise, cruise, end < cruise ? end : cruise) < 0)
            return -1;
        prev_cruise = cruise;
        if (sim_emit(s, m) < 0)
            return -1;
    }
    s->prev_cruise = prev_cruise;
    memmove(q, q + flush_count, (size_t)(n - flush_count) * sizeof(BlockData));
    s->n = n - flush_count;
    return flush_count;
}

/* b: the queue's slot q[n] (sim_block's), taken here */
BLOCK_PATH int klipper_add(SimObject *s, BlockData *b)
{
    if (s->n) {
        BlockData *p = &s->q[s->n - 1];
        double v2;
        if (junction(s, p, b, &v2, CFG_ANY) < 0)
            return -1;
        double lim = p->max_start_v2 + p->delta_v2;
        if (b->v2max < lim)
            lim = b->v2max;
        if (p->v2max < lim)
            lim = p->v2max;
        if (v2 < lim)
            lim = v2;
        b->max_start_v2 = lim;
        double m = p->max_mcr_start_v2 + p->mcr_delta_v2;
        b->max_mcr_start_v2 = m < lim ? m : lim;
        b->after_stop = 0;
    }
    s->n++;                           /* (b is q[n]: sim_block made it there) */
    if (s->n >= s->next_try) {
        Py_ssize_t k = klipper_flush(s, 1);
        if (k < 0)
            return -1;
        s->next_try = k ? s->n + s->chunk : 2 * s->n;
    }
    return 0;
}

static int klipper_stop(SimObject *s)
{
    if (s->n && klipper_flush(s, 0) < 0)
        return -1;
    s->next_try = s->chunk;
    s->prev_cruise = 0.0;
    return 0;
}

static double marlin_reverse(SimObject *s, Py_ssize_t j, double end_v2)
{
    double r = Py_HUGE_VAL, sum = 0.0, c;
    for (Py_ssize_t k = j; k < s->n; k++) {
        BlockData *bk = &s->q[k];
        c = bk->max_start_v2 + sum;
        if (c < r)
            r = c;
        sum += bk->delta_v2;
        if (sum >= r)
            return r;
    }
    c = end_v2 + sum;
    return c < r ? c : r;
}

BLOCK_PATH int marlin_execute(SimObject *s, double end_v2)
{
    Py_ssize_t i = s->head, n = s->n;
    BlockData *b = &s->q[i];
    double e = s->has_entry ? s->entry_v2 : marlin_reverse(s, i, end_v2);
    double x = i + 1 < n ? marlin_reverse(s, i + 1, end_v2) : end_v2;
    double dv2 = b->delta_v2;
    double f = e + dv2;
    if (f < x)
        x = f;
    if (x < e - dv2)                 /* cannot happen with a consistent plan; stay physical */
        x = e - dv2;
    double c = (e + x + dv2) * 0.5;
    if (b->v2max < c)
        c = b->v2max;
    if (c < e)
        c = e;
    if (c < x)
        c = x;
    if (set_trapezoid(b, e, c, x) < 0)
        return -1;
    s->entry_v2 = x;
    s->has_entry = 1;
    s->head = i + 1;
    return sim_emit(s, b);
}

/* b: the queue's slot q[n] (sim_block's), taken here; the last block added is q[n - 1]
 * while has_last (executing a block writes only its trapezoid, which junction() does not read) */
BLOCK_PATH int marlin_add(SimObject *s, BlockData *b, const int cfg)
{
    if (s->has_last) {
        BlockData *p = b - 1;
        double v2;
        if (junction(s, p, b, &v2, cfg) < 0)
            return -1;
        if (b->v2max < v2)
            v2 = b->v2max;
        if (p->v2max < v2)
            v2 = p->v2max;
        b->max_start_v2 = v2;
        b->after_stop = 0;
    }
    else
        b->max_start_v2 = CFG_MODEL(s, cfg) == J_JERK ? b->safe_v * b->safe_v : 0.0;
    s->has_last = 1;
    s->n++;
    if (s->n - s->head >= s->window) {
        if (marlin_execute(s, s->mps * s->mps) < 0)
            return -1;
        if (s->head > 4096) {
            /* the executed blocks dropped but the last one added: it is the next add's
               q[n - 1] (a window of one block executes it at once, leaving head == n) */
            Py_ssize_t from = s->head - 1;
            memmove(s->q, s->q + from, (size_t)(s->n - from) * sizeof(BlockData));
            s->n -= from;
            s->head = 1;
        }
    }
    return 0;
}

static int marlin_stop(SimObject *s)
{
    /* the buffer drains: the last block ends at MINIMUM_PLANNER_SPEED, as in Marlin */
    while (s->head < s->n)
        if (marlin_execute(s, s->mps * s->mps) < 0)
            return -1;
    s->n = s->head = 0;
    s->has_last = 0;
    s->has_entry = 0;
    return 0;
}

/* ---- blocks -> integrals (_Sim._emit, _close) --------------------------------------- */
/* call_on_line's less common part: fn(LineRecord) unless fn is None, then an E-only move's rest */
static int call_on_line_rest(SimObject *s, RecData *r, PyObject *fn)
{
    if (fn != Py_None) {
        RecObject *o = (RecObject *)REC_TYPE->tp_alloc(REC_TYPE, 0);
        if (o == NULL)
            return -1;
        o->r = *r;
        PyObject *x = PyObject_CallOneArg(fn, (PyObject *)o);
        Py_DECREF(o);
        if (x == NULL)
            return -1;
        Py_DECREF(x);
    }
    /* the ringing's rest for an E-only move, after the record's callback (ringing.hooks) */
    if (r->kind == K_EONLY && Py_IS_TYPE(s->on_block, &SinkType))
        return sink_rest((SinkObject *)s->on_block, r->time_t);
    return 0;
}

/* a record to on_line: a RecordLog's or StrokeSums' here (inlined in sim_emit), else
 * call_on_line_rest */
BLOCK_PATH int call_on_line(SimObject *s, RecData *r)
{
    PyObject *fn = s->on_line;
    if (Py_IS_TYPE(fn, &LogType)) {
        if (log_add((LogObject *)fn, r) < 0)
            return -1;
        fn = Py_None;
    } else if (Py_IS_TYPE(fn, &SumsType)) {
        /* per-stroke sums without a LineRecord; also(rec) only if asked */
        SumsObject *k = (SumsObject *)fn;
        sums_add(k, r->idx, r->time_t, r->int_a2, r->int_a2_j, r->int_v2);
        fn = k->also;
    }
    if (fn != Py_None || r->kind == K_EONLY)
        return call_on_line_rest(s, r, fn);
    return 0;
}

static int sim_close(SimObject *s)
{
    if (s->has_rec) {
        s->has_rec = 0;
        return call_on_line(s, &s->rec);
    }
    return 0;
}

static int append_stop_line(SimObject *s, long long line)
{
    PyObject *sl = s->res->stop_lines;
    if (sl == NULL) {
        PyErr_SetString(PyExc_AttributeError, "'SimResult' object has no attribute 'stop_lines'");
        return -1;
    }
    Py_ssize_t len = PyObject_Length(sl);
    if (len < 0)
        return -1;
    if (!((double)len < s->max_stop_d))
        return 0;
    PyObject *v = PyLong_FromLongLong(line);
    if (v == NULL)
        return -1;
    int rc;
    if (PyList_CheckExact(sl))
        rc = PyList_Append(sl, v);
    else {
        PyObject *x = PyObject_CallMethod(sl, "append", "O", v);
        rc = x == NULL ? -1 : 0;
        Py_XDECREF(x);
    }
    Py_DECREF(v);
    return rc;
}

BLOCK_PATH int sim_emit(SimObject *s, BlockData *b)
{
    ResObject *res = s->res;
    double a = b->accel, at = b->accel_t, ct = b->cruise_t, dt = b->decel_t;
    double t = at + ct + dt;
    double sv = b->start_v, cv = b->cruise_v, ev = b->end_v;
    double ta = at + dt;
    double a2 = a * a * ta;
    double cv2 = cv * cv;
    double v2 = (at * (sv * sv + sv * cv + cv2) + dt * (ev * ev + ev * cv + cv2)) / 3.0 + ct * cv * cv;
    double pa = ta > 0.0 ? a : 0.0;
    res->n_blocks += 1;
    res->time_t += t;
    res->int_a2_t += a2;
    res->int_a2 += a2;
    res->int_v2 += v2;
    if (cv > res->peak_v)
        res->peak_v = cv;
    double jterm = 0.0, na = 0.0;
    if (s->has_prev && !b->after_stop) {
        if (sv < s->stop_thr) {
            res->full_stops += 1;
            if (append_stop_line(s, b->idx + 1) < 0)
                return -1;
        }
        double cos_turn = s->prev_ux * b->ux + s->prev_uy * b->uy + s->prev_uz * b->uz;
        double dv2 = 2.0 * sv * sv * (1.0 - cos_turn);
        if (cos_turn < s->corner_cos) {
            res->corners += 1;
            res->corner_dv2 += dv2;
        }
        else if (dv2 > 0.0) {
            double tj = 0.5 * (s->prev_t + t);
            DIV(jterm, dv2, tj);
            DIV(na, sqrt_rn(dv2), tj);
            res->int_a2 += jterm;
            if (na > res->peak_a)
                res->peak_a = na;
        }
    }
    if (pa > res->peak_a)
        res->peak_a = pa;
    RecData *rec = &s->rec;
    if (s->has_rec && b->idx == rec->idx) {
        rec->int_a2 += jterm;
        if (na > rec->peak_a)
            rec->peak_a = na;
    }
    else {
        if (s->has_rec) {
            rec->int_a2_j += 0.5 * jterm;
            if (na > rec->peak_a)
                rec->peak_a = na;
            s->has_rec = 0;
            if (call_on_line(s, rec) < 0)
                return -1;
        }
        s->has_rec = 1;
        rec->idx = b->idx;
        rec->kind = b->kind;
        rec->end_v = rec->peak_v = 0.0;
        rec->time_t = rec->int_a2 = rec->int_v2 = 0.0;
        rec->start_v = sv;
        rec->int_a2_j = 0.5 * jterm;
        rec->peak_a = na;
    }
    rec->end_v = ev;
    if (cv > rec->peak_v)
        rec->peak_v = cv;
    if (pa > rec->peak_a)
        rec->peak_a = pa;
    rec->time_t += t;
    rec->int_a2 += a2;
    rec->int_v2 += v2;
    s->has_prev = 1;
    s->prev_ux = b->ux;
    s->prev_uy = b->uy;
    s->prev_uz = b->uz;
    s->prev_t = t;
    if (Py_IS_TYPE(s->on_block, &SinkType))
        return sink_block((SinkObject *)s->on_block, b);
    if (s->on_block != Py_None) {
        BlockObject *o = PyObject_New(BlockObject, &BlockType);
        if (o == NULL)
            return -1;
        o->b = *b;
        PyObject *x = PyObject_CallOneArg(s->on_block, (PyObject *)o);
        Py_DECREF(o);
        if (x == NULL)
            return -1;
        Py_DECREF(x);
    }
    return 0;
}

static int sim_stop(SimObject *s)
{
    if ((s->marlin ? marlin_stop(s) : klipper_stop(s)) < 0)
        return -1;
    if (sim_close(s) < 0)
        return -1;
    s->has_prev = 0;
    return 0;
}

/* ---- moves -> blocks (_Sim.move, _block, _eonly) ----------------------------------- */
typedef struct {
    PyObject *ev;                 /* borrowed */
    long long idx;
    int kind;
    double e, v, accel, flow_r;
    PyObject *lim;                /* new reference */
} MoveData;

/* What _block reads of a Limits per block besides the caps: v_max and the junction model's
 * (scv and mcr, or jd), in s->vlim_*, kept for one Limits object as the caps are (set_lim:
 * copy-on-write, so identity is enough; the reference held keeps its address from being
 * another's): ~3 attribute reads a block fewer.  Read all at once where _block reads
 * v_max: nothing between that and the model's reads can raise, so an error is the same. */
static int vlim_read(SimObject *s, PyObject *lim)
{
    double v_max, scv = 0.0, mcr = 0.0, jd = 0.0;
    if (get_d(&LIM_MAP, lim, L_VMAX, &v_max) < 0)
        return -1;
    if (s->model == J_SCV) {
        if (get_d(&LIM_MAP, lim, L_SCV, &scv) < 0 || get_d(&LIM_MAP, lim, L_MCR, &mcr) < 0)
            return -1;
    }
    else if (get_d(&LIM_MAP, lim, L_JD, &jd) < 0)
        return -1;
    Py_INCREF(lim);
    Py_XSETREF(s->vlim, lim);
    s->vlim_v_max = v_max;
    s->vlim_nonneg = !(v_max < 0.0) && !(s->max_z_v < 0.0);
    s->vlim_scv = scv;
    s->vlim_mcr = mcr;
    s->vlim_jd = jd;
    return 0;
}

static int set_lim(SimObject *s, PyObject *lim)
{
    double ax, ay, jx, jy;
    if (get_d(&LIM_MAP, lim, L_AXMAX, &ax) < 0 || get_d(&LIM_MAP, lim, L_AYMAX, &ay) < 0
        || get_d(&LIM_MAP, lim, L_JERKX, &jx) < 0 || get_d(&LIM_MAP, lim, L_JERKY, &jy) < 0)
        return -1;
    Py_INCREF(lim);
    Py_XSETREF(s->lim, lim);
    s->caps[0] = ax;
    s->caps[1] = ay;
    s->caps[2] = s->max_z_accel;
    s->caps_nonneg = caps_nonneg(s->caps);
    s->jerk[0] = jx;
    s->jerk[1] = jy;
    s->jerk[2] = s->jerk_z;
    return 0;
}

/* rest-to-rest trapezoid of the extruder alone (the toolhead stands still), after the stop */
static int eonly_rest(SimObject *s, long long idx, double e, double v, double a)
{
    double t;
    double d = fabs(e);
    v = pymin(v, s->max_e_v);
    if (d <= 0.0 || v <= 0.0 || a <= 0.0)
        t = 0.0;
    else if (v * v <= a * d) {
        double t1, t2;
        DIV(t1, d, v);
        DIV(t2, v, a);
        t = t1 + t2;
    }
    else {
        double q, r;
        DIV(q, d, a);
        SQRT(r, q);
        t = 2.0 * r;
    }
    s->res->time_t += t;
    RecData rec;
    memset(&rec, 0, sizeof(rec));
    rec.idx = idx;
    rec.kind = (int)K_EONLY;
    rec.time_t = t;
    return call_on_line(s, &rec);
}

static int sim_eonly_vals(SimObject *s, long long idx, double e, double v, double a)
{
    if (sim_stop(s) < 0)
        return -1;
    return eonly_rest(s, idx, e, v, a);
}

static int sim_eonly(SimObject *s, PyObject *mv)
{
    if (sim_stop(s) < 0)
        return -1;
    double e, v, a;
    long long idx;
    if (get_d(&MOVE_MAP, mv, MV_E, &e) < 0 || get_d(&MOVE_MAP, mv, MV_V, &v) < 0
        || get_d(&MOVE_MAP, mv, MV_ACCEL, &a) < 0 || get_ll(&MOVE_MAP, mv, MV_IDX, &idx) < 0)
        return -1;
    return eonly_rest(s, idx, e, v, a);
}

/* a move's block (_Sim._block): inlined into play_fused (the reader's lines: nearly every
 * block) and into sim_block (Move objects and arcs), one call a block, not two; cfg: the
 * configuration the caller knows (CFG_ANY: s's) */
BLOCK_PATH int sim_block_body(SimObject *s, const MoveData *m, int first, double dx, double dy,
                              double dz, double de, const int cfg)
{
    const int klipper_fw = CFG_KLIPPER_FW(s, cfg), model = CFG_MODEL(s, cfg);
    double d = sqrt_rn(CFG_XY(cfg) ? dx * dx + dy * dy : dx * dx + dy * dy + dz * dz);
    if (d < 1e-9) {
        if (de != 0.0 && first)         /* the move's own E, feed and accel (_eonly(mv)) */
            return sim_eonly_vals(s, m->idx, m->e, m->v, m->accel);
        return 0;
    }
    double inv = 1.0 / d;                 /* (d is not 0 here: no zero check) */
    double ux = dx * inv, uy = dy * inv, uz = dz * inv;
    PyObject *lim = m->lim;
    double a0 = m->accel;
    if (!(a0 > 0.0))                      /* M204 S0 or garbage: the profile's default */
        a0 = s->default_accel;
    double aux = fabs(ux), auy = fabs(uy), auz = fabs(uz);
    double a;
    if (klipper_fw) {
        a = a0;
        if (uz != 0.0) {
            double az;
            DIV(az, s->max_z_accel, auz);
            if (az < a)
                a = az;
        }
    }
    else {
        if (lim != s->lim && set_lim(s, lim) < 0)
            return -1;
        double cx = s->caps[0], cy = s->caps[1], cz = s->caps[2];
        a = a0;
        if (s->caps_nonneg) {
            a = caps_axis(a, aux, cx);
            a = caps_axis(a, auy, cy);
            if (!CFG_XY(cfg))
                a = caps_axis(a, auz, cz);
        }
        else {
            if (aux > 0.0 && a * aux > cx)
                DIV(a, cx, aux);
            if (auy > 0.0 && a * auy > cy)
                DIV(a, cy, auy);
            if (!CFG_XY(cfg) && auz > 0.0 && a * auz > cz)
                DIV(a, cz, auz);
        }
    }
    if (lim != s->vlim && vlim_read(s, lim) < 0)
        return -1;
    double v_max = s->vlim_v_max, v;
    if (CFG_KLIPPER_LIMITS(s, cfg)) {
        v = m->v < v_max ? m->v : v_max;
        if (uz != 0.0) {
            double vz;
            DIV(vz, s->max_z_v, auz);
            if (vz < v)
                v = vz;
        }
    }
    else {
        v = m->v;
        if (s->vlim_nonneg) {
            v = caps_axis(v, aux, v_max);
            v = caps_axis(v, auy, v_max);
            if (!CFG_XY(cfg))
                v = caps_axis(v, auz, s->max_z_v);
        }
        else {
            if (aux > 0.0 && v * aux > v_max)
                DIV(v, v_max, aux);
            if (auy > 0.0 && v * auy > v_max)
                DIV(v, v_max, auy);
            if (!CFG_XY(cfg) && auz > 0.0) {
                double cz = s->max_z_v;
                if (v * auz > cz)
                    DIV(v, cz, auz);
            }
        }
    }
    double jd, mcr_a;
    if (model == J_SCV) {
        double scv = s->vlim_scv;
        DIV(jd, scv * scv * s->sqrt2_m1, a0);
        mcr_a = a0 * (1.0 - s->vlim_mcr);
    }
    else {
        jd = s->vlim_jd;
        mcr_a = a;
    }
    double er = de != 0.0 ? de * inv * m->flow_r : 0.0;
    /* the block is made in the queue's next slot (q[n], not yet counted): no copy of it */
    if (grow_queue(s) < 0)
        return -1;
    BlockData *b = &s->q[s->n];
    b->idx = m->idx;
    b->kind = m->kind;
    b->first = (char)first;
    b->d = d;
    b->ux = ux;
    b->uy = uy;
    b->uz = uz;
    b->er = er;
    b->accel = a;
    b->jd = jd;
    b->nominal_v = v;
    b->v2max = v * v;
    double dv2 = 2.0 * d * a;
    b->delta_v2 = dv2;
    double mm = 2.0 * d * mcr_a;
    b->mcr_delta_v2 = mm < dv2 ? mm : dv2;
    b->max_start_v2 = b->max_mcr_start_v2 = b->safe_v = 0.0;
    b->after_stop = 1;
    /* (start_v .. decel_t not zeroed: set_trapezoid writes them all before anything reads
       them, sim_emit and on_block after it) */
    if (model == J_JERK) {
        /* (s->lim is lim already unless klipper_fw: set above, and vlim_read leaves it) */
        if (klipper_fw && lim != s->lim && set_lim(s, lim) < 0)
            return -1;
        double jx = s->jerk[0], jy = s->jerk[1], jz = s->jerk[2];
        double safe = v, comp, mjerk;
        int limited = 0;
        comp = aux * v;
        if (comp > jx) {
            limited = 1;
            safe = jx;
        }
        comp = auy * v;
        if (comp > jy) {
            if (limited) {
                mjerk = jy * v;
                if (comp * safe > mjerk)
                    DIV(safe, mjerk, comp);
            }
            else {
                limited = 1;
                safe = jy;
            }
        }
        comp = auz * v;
        if (!CFG_XY(cfg) && comp > jz) {
            if (limited) {
                mjerk = jz * v;
                if (comp * safe > mjerk)
                    DIV(safe, mjerk, comp);
            }
            else
                safe = jz;
        }
        b->safe_v = safe;
    }
    if (s->min_seg_t > 0.0 && d < s->min_seg_t * v)
        s->res->short_segments += 1;
    return CFG_MARLIN(s, cfg) ? marlin_add(s, b, cfg) : klipper_add(s, b);
}

static int sim_block(SimObject *s, const MoveData *m, int first, double dx, double dy, double dz,
                     double de)
{
    return sim_block_body(s, m, first, dx, dy, dz, de, CFG_ANY);
}

/* simulate.arc_chords */
static int arc_chords(double length_d, double sweep, double segment_d, double arc_min_turn,
                      Py_ssize_t *out)
{
    double turn = fabs(sweep) <= 2.0 * M_PI ? fabs(sweep) : 2.0 * M_PI;
    double n_max = ceil(turn / arc_min_turn);
    double n = segment_d > 0.0 ? length_d / segment_d : 1.0;
    if (!(n <= n_max))
        n = n_max;
    if (isinf(n)) {
        PyErr_SetString(PyExc_OverflowError, "cannot convert float infinity to integer");
        return -1;
    }
    double k = trunc(n);
    *out = k < 1.0 ? 1 : (Py_ssize_t)k;
    return 0;
}

static int enter(SimObject *s)
{
    if (s->busy) {
        PyErr_SetString(PyExc_RuntimeError, "the firmware model was re-entered from its own callback");
        return -1;
    }
    s->busy = 1;
    return 0;
}

static PyObject *Sim_move_body(SimObject *s, PyObject *mv);

static PyObject *Sim_move(SimObject *s, PyObject *mv)
{
    if (enter(s) < 0)
        return NULL;
    PyObject *r = Sim_move_body(s, mv);
    s->busy = 0;
    return r;
}

static PyObject *Sim_move_body(SimObject *s, PyObject *mv)
{
    MoveData m;
    m.ev = mv;
    m.lim = NULL;
    PyObject *arc = NULL;
    long long kind;
    s->res->n_moves += 1;
    if (get_ll(&MOVE_MAP, mv, MV_KIND, &kind) < 0)
        return NULL;
    if (kind == K_EONLY) {
        if (sim_eonly(s, mv) < 0)
            return NULL;
        Py_RETURN_NONE;
    }
    double x0, y0, z0, x1, y1, z1;
    if (get_ll(&MOVE_MAP, mv, MV_IDX, &m.idx) < 0
        || get_d(&MOVE_MAP, mv, MV_X0, &x0) < 0 || get_d(&MOVE_MAP, mv, MV_Y0, &y0) < 0
        || get_d(&MOVE_MAP, mv, MV_Z0, &z0) < 0 || get_d(&MOVE_MAP, mv, MV_X1, &x1) < 0
        || get_d(&MOVE_MAP, mv, MV_Y1, &y1) < 0 || get_d(&MOVE_MAP, mv, MV_Z1, &z1) < 0
        || get_d(&MOVE_MAP, mv, MV_E, &m.e) < 0 || get_d(&MOVE_MAP, mv, MV_V, &m.v) < 0
        || get_d(&MOVE_MAP, mv, MV_ACCEL, &m.accel) < 0
        || get_d(&MOVE_MAP, mv, MV_FLOW_R, &m.flow_r) < 0)
        return NULL;
    m.kind = (int)kind;
    m.lim = get_obj(&MOVE_MAP, mv, MV_LIM);
    if (m.lim == NULL)
        return NULL;
    int rc;
    if (kind == K_LINE)
        rc = sim_block(s, &m, 1, x1 - x0, y1 - y0, z1 - z0, m.e);
    else {
        double cx, cy, r, t0, sw, length_d;
        Py_ssize_t n;
        rc = -1;
        arc = get_obj(&MOVE_MAP, mv, MV_ARC);
        if (arc == NULL || get_d(&ARC_MAP, arc, A_LENGTH, &length_d) < 0
            || get_d(&ARC_MAP, arc, A_SWEEP, &sw) < 0
            || arc_chords(length_d, sw, s->arc_segment_d, s->arc_min_turn, &n) < 0
            || get_d(&ARC_MAP, arc, A_CX, &cx) < 0 || get_d(&ARC_MAP, arc, A_CY, &cy) < 0
            || get_d(&ARC_MAP, arc, A_R, &r) < 0 || get_d(&ARC_MAP, arc, A_THETA0, &t0) < 0)
            goto done;
        double dn = (double)n;
        double dz = (z1 - z0) / dn;
        double de = m.e / dn;
        double px = x0, py = y0, x, y;
        for (Py_ssize_t i = 1; i <= n; i++) {
            if (i == n) {
                x = x1;
                y = y1;
            }
            else {
                double th = t0 + sw * (double)i / dn;
                if (isinf(th)) {
                    domain();
                    goto done;
                }
                x = cx + r * cos(th);
                y = cy + r * sin(th);
            }
            if (sim_block(s, &m, i == 1, x - px, y - py, dz, de) < 0)
                goto done;
            px = x;
            py = y;
        }
        rc = 0;
    }
done:
    Py_XDECREF(arc);
    Py_XDECREF(m.lim);
    if (rc < 0)
        return NULL;
    Py_RETURN_NONE;
}

static PyObject *Sim_stop(SimObject *s, PyObject *noarg)
{
    if (enter(s) < 0)
        return NULL;
    int rc = sim_stop(s);
    s->busy = 0;
    if (rc < 0)
        return NULL;
    Py_RETURN_NONE;
}

static PyObject *Sim_barrier(SimObject *s, PyObject *ev)
{
    if (enter(s) < 0)
        return NULL;
    int rc = sim_stop(s);
    s->busy = 0;
    if (rc < 0)
        return NULL;
    double dw;
    if (get_d(&BAR_MAP, ev, 0, &dw) < 0)
        return NULL;
    s->res->time_t += dw;
    s->res->barrier_dwell_t += dw;
    /* the ringing's rest for the dwell, once the barrier is taken (ringing.wrap_events) */
    if (Py_IS_TYPE(s->on_block, &SinkType) && sink_rest((SinkObject *)s->on_block, dw) < 0)
        return NULL;
    Py_RETURN_NONE;
}

/* The reader's fused loop (_reader.c, capsule _gcode_opt_reader._C_API; use_reader()):
 * where `step` is the compiled reader's step bound to its MachineState, play() reads the
 * common lines through it and plays their moves from doubles, with no Move object and no
 * state dict traffic per line.  The layout string must be the reader's own. */
#define FUSED_LAYOUT "FusedMove 1: int kind; double x0 y0 z0 x1 y1 z1 e v accel flow_r; PyObject *lim" \
    " | RunMove 2: FusedMove fm; double e1 v1 speed; int has_f e_rel xyz_rel; PyObject *feature *accel;" \
    " double e0" \
    " | peek commit 4 | Lines line_ascii peek_ascii lf 6 | run_ascii 7 | lines_raw 8"
typedef struct {
    int kind;                         /* 0 a line, 1 E only */
    double x0, y0, z0, x1, y1, z1, e, v, accel, flow_r;
    PyObject *lim;                    /* borrowed */
} FusedMove;

typedef struct {                      /* _reader.c's: see fused_peek there */
    FusedMove fm;
    double e1, v1, speed;
    int has_f, e_rel, xyz_rel;
    PyObject *feature, *accel;        /* borrowed */
    double e0;
} RunMove;

typedef struct {
    const char *layout;
    size_t move_size;
    PyCFunction step;
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
                     void *ctx, const char **line, Py_ssize_t *n);   /* NULL: none */
    int (*lines_raw)(PyObject *o, const char **data, const Py_ssize_t **start);
} ReaderAPI;
enum { RUN_MORE = 0, RUN_STEP = 2, RUN_STOP = 3 };     /* run_ascii's answers (and -1: error) */

static const ReaderAPI *READER = NULL;
static PyObject *READER_CAPSULE = NULL;   /* keeps the reader module's capsule alive */

/* The session for `step`, NULL if play() must call step line by line: not the compiled
 * reader's step, or callbacks that are not the core's own (a Python on_line or on_block
 * could read the state while its x y z e v are held in C). *err on error. */
static void *fused_session(SimObject *s, PyObject *step, int *err)
{
    *err = 0;
    if (READER == NULL || !PyMethod_Check(step))
        return NULL;
    PyObject *fn = PyMethod_GET_FUNCTION(step);
    if (!PyCFunction_Check(fn) || PyCFunction_GET_FUNCTION(fn) != READER->step)
        return NULL;
    if (!(s->on_line == Py_None || Py_IS_TYPE(s->on_line, &LogType)
          || (Py_IS_TYPE(s->on_line, &SumsType) && ((SumsObject *)s->on_line)->also == Py_None))
        || !(s->on_block == Py_None || Py_IS_TYPE(s->on_block, &SinkType)))
        return NULL;
    void *ss = READER->open(PyMethod_GET_SELF(step));
    if (ss == NULL)
        *err = 1;
    return ss;
}

/* ---------------------------------------------------------------- SET_VELOCITY_LIMIT in play()
 * A Klipper output carries "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=.." (and ACCEL=..) around
 * every re-timed stroke; the reader hands such a line to Python (fused_line returns 2, the
 * state written back).  play() reads the plain ones here as MachineState._step_python reads
 * them (_other -> _set_velocity_limit, flavour klipper): ACCEL sets accel_print and
 * accel_travel to one float, VELOCITY / SQUARE_CORNER_VELOCITY / MINIMUM_CRUISE_RATIO make
 * a new Limits (Limits.replace: the other slots' objects shared), ACCEL_TO_DECEL is read
 * and ignored.  Only this shape is read here: spaces or tabs, then "SET_VELOCITY_LIMIT"
 * (upper case), then one or more " KEY=NUMBER" (KEY one of the five in upper case, each at
 * most once, NUMBER words.strict_number's grammar, at most 64 characters), spaces or tabs,
 * an optional ';' comment of printable ASCII and tabs, and the line's LF or CR LF; every
 * value within _set_velocity_limit's ranges; the state exactly a MachineState whose
 * flavour is the str "klipper" and whose lim is exactly a Limits with every slot set.
 * Anything else -- lower case, a key twice, an unknown key, a macro value, a bad or
 * out-of-range number, a stray CR, a control character -- goes to step() as before:
 * Python's errors and texts stay Python's.  The numbers are PyOS_string_to_double's, as
 * float() reads a strict number. */
static PyTypeObject *SVL_STATE = NULL;    /* state.MachineState (setup's consts["STATE"]) */
static double SVL_MAX_V = 0.0, SVL_MAX_A = 0.0;
static PyObject *SVL_NAMES[4] = {NULL, NULL, NULL, NULL};   /* flavour lim accel_print accel_travel */

enum { SVL_VEL, SVL_ACC, SVL_A2D, SVL_SCV, SVL_MCR, SVL_N };
static const char *SVL_KEYS[SVL_N] = {"VELOCITY", "ACCEL", "ACCEL_TO_DECEL", "SQUARE_CORNER_VELOCITY",
                                      "MINIMUM_CRUISE_RATIO"};

/* 1 with the values read (have[k] set for each key given), 0 not this shape or a value
 * _set_velocity_limit refuses (Python reads the line) */
static int svl_parse(const unsigned char *p, Py_ssize_t n, double *val, int *have)
{
    if (n > 0 && p[n - 1] == '\n') {
        n--;
        if (n > 0 && p[n - 1] == '\r')
            n--;
    }
    Py_ssize_t code_n = n;
    for (Py_ssize_t j = 0; j < n; j++) {
        unsigned char c = p[j];
        if (!(c == '\t' || (c >= 0x20 && c < 0x7f)))
            return 0;
        if (c == ';' && code_n == n)
            code_n = j;
    }
    Py_ssize_t j = 0;
    while (j < code_n && (p[j] == ' ' || p[j] == '\t'))
        j++;
    static const char CMD[] = "SET_VELOCITY_LIMIT";
    const Py_ssize_t cmd_n = (Py_ssize_t)sizeof(CMD) - 1;
    if (code_n - j < cmd_n || memcmp(p + j, CMD, (size_t)cmd_n) != 0)
        return 0;
    j += cmd_n;
    for (int k = 0; k < SVL_N; k++)
        have[k] = 0;
    int words = 0;
    for (;;) {
        Py_ssize_t ws = j;
        while (j < code_n && (p[j] == ' ' || p[j] == '\t'))
            j++;
        if (j == code_n)
            break;
        if (j == ws)                   /* "SET_VELOCITY_LIMITX" or "ACCEL=1X=2" */
            return 0;
        Py_ssize_t k0 = j;
        while (j < code_n && ((p[j] >= 'A' && p[j] <= 'Z') || p[j] == '_'))
            j++;
        if (j == code_n || p[j] != '=')
            return 0;
        int key = -1;
        for (int k = 0; k < SVL_N; k++)
            if ((Py_ssize_t)strlen(SVL_KEYS[k]) == j - k0 && memcmp(p + k0, SVL_KEYS[k], (size_t)(j - k0)) == 0)
                key = k;
        if (key < 0 || have[key])
            return 0;
        j++;
        Py_ssize_t v0 = j;
        if (j < code_n && (p[j] == '+' || p[j] == '-'))
            j++;
        Py_ssize_t d0 = j;
        while (j < code_n && p[j] >= '0' && p[j] <= '9')
            j++;
        Py_ssize_t int_n = j - d0, frac_n = 0;
        if (j < code_n && p[j] == '.') {
            j++;
            Py_ssize_t f0 = j;
            while (j < code_n && p[j] >= '0' && p[j] <= '9')
                j++;
            frac_n = j - f0;
        }
        if (int_n == 0 && frac_n == 0)          /* "", "+", ".", "-." */
            return 0;
        if (j < code_n && p[j] != ' ' && p[j] != '\t')
            return 0;                            /* "1e5", "1.2.3", "5,", "nan" */
        char buf[72];
        if (j - v0 > 64)
            return 0;
        memcpy(buf, p + v0, (size_t)(j - v0));
        buf[j - v0] = '\0';
        double x = PyOS_string_to_double(buf, NULL, NULL);
        if (x == -1.0 && PyErr_Occurred()) {
            PyErr_Clear();
            return 0;
        }
        val[key] = x;
        have[key] = 1;
        words++;
    }
    if (words == 0)
        return 0;
    if (have[SVL_VEL] && !(0.0 < val[SVL_VEL] && val[SVL_VEL] <= SVL_MAX_V))
        return 0;
    if (have[SVL_ACC] && !(0.0 < val[SVL_ACC] && val[SVL_ACC] <= SVL_MAX_A))
        return 0;
    if (have[SVL_SCV] && !(0.0 <= val[SVL_SCV] && val[SVL_SCV] <= SVL_MAX_V))
        return 0;
    if (have[SVL_MCR] && !(0.0 <= val[SVL_MCR] && val[SVL_MCR] < 1.0))
        return 0;
    return 1;
}

/* 1 the line read here (the state changed as Python's step changes it), 0 not read (call
 * step()), -1 error */
static int svl_line(PyObject *state, PyObject *raw)
{
    if (SVL_STATE == NULL || Py_TYPE(state) != SVL_STATE || !PyUnicode_CheckExact(raw)
        || !PyUnicode_IS_ASCII(raw))
        return 0;
    double val[SVL_N];
    int have[SVL_N];
    if (!svl_parse(PyUnicode_1BYTE_DATA(raw), PyUnicode_GET_LENGTH(raw), val, have))
        return 0;
    PyObject *fl = PyObject_GetAttr(state, SVL_NAMES[0]);
    if (fl == NULL) {
        PyErr_Clear();
        return 0;
    }
    int klipper = PyUnicode_CheckExact(fl) && PyUnicode_CompareWithASCIIString(fl, "klipper") == 0;
    Py_DECREF(fl);
    if (!klipper)
        return 0;
    PyObject *new_lim = NULL, *acc = NULL;
    int rc = -1;
    if (have[SVL_VEL] || have[SVL_SCV] || have[SVL_MCR]) {     /* Limits.replace(**kw) */
        PyObject *lim = PyObject_GetAttr(state, SVL_NAMES[1]);
        if (lim == NULL) {
            PyErr_Clear();
            return 0;
        }
        PyTypeObject *lt = LIM_MAP.type;
        int ok = lt != NULL && Py_TYPE(lim) == lt;
        for (int i = 0; ok && i < L_N; i++)
            ok = LIM_MAP.off[i] >= 0 && *(PyObject **)((char *)lim + LIM_MAP.off[i]) != NULL;
        if (!ok) {
            Py_DECREF(lim);
            return 0;
        }
        new_lim = lt->tp_alloc(lt, 0);
        if (new_lim == NULL) {
            Py_DECREF(lim);
            return -1;
        }
        for (int i = 0; i < L_N; i++) {
            PyObject *v;
            if (i == L_VMAX && have[SVL_VEL])
                v = PyFloat_FromDouble(val[SVL_VEL]);
            else if (i == L_SCV && have[SVL_SCV])
                v = PyFloat_FromDouble(val[SVL_SCV]);
            else if (i == L_MCR && have[SVL_MCR])
                v = PyFloat_FromDouble(val[SVL_MCR]);
            else {
                v = *(PyObject **)((char *)lim + LIM_MAP.off[i]);
                Py_INCREF(v);
            }
            if (v == NULL) {
                Py_DECREF(lim);
                goto done;
            }
            *(PyObject **)((char *)new_lim + LIM_MAP.off[i]) = v;
        }
        Py_DECREF(lim);
    }
    if (have[SVL_ACC]) {          /* self.accel_print = self.accel_travel = a, then the lim */
        acc = PyFloat_FromDouble(val[SVL_ACC]);
        if (acc == NULL || PyObject_SetAttr(state, SVL_NAMES[2], acc) < 0
            || PyObject_SetAttr(state, SVL_NAMES[3], acc) < 0)
            goto done;
    }
    if (new_lim != NULL && PyObject_SetAttr(state, SVL_NAMES[1], new_lim) < 0)
        goto done;
    rc = 1;
done:
    Py_XDECREF(new_lim);
    Py_XDECREF(acc);
    return rc;
}

/* setup's optional constants for svl_line: without them play() hands these lines to step() */
static int svl_setup(PyObject *c)
{
    static const char *names[4] = {"flavour", "lim", "accel_print", "accel_travel"};
    Py_CLEAR(SVL_STATE);
    PyObject *st = PyDict_GetItemString(c, "STATE");
    PyObject *mv = PyDict_GetItemString(c, "MAX_VELOCITY_V");
    PyObject *ma = PyDict_GetItemString(c, "MAX_ACCEL_A");
    if (st == NULL || mv == NULL || ma == NULL || !PyType_Check(st))
        return 0;
    double v = PyFloat_AsDouble(mv), a = PyFloat_AsDouble(ma);
    if (PyErr_Occurred())
        return -1;
    for (int i = 0; i < 4; i++) {
        PyObject *nm = PyUnicode_InternFromString(names[i]);
        if (nm == NULL)
            return -1;
        Py_XSETREF(SVL_NAMES[i], nm);
    }
    SVL_MAX_V = v;
    SVL_MAX_A = a;
    Py_INCREF(st);
    SVL_STATE = (PyTypeObject *)st;
    return 0;
}

/* a FusedMove played as Sim_move_body plays the Move the reader would have made; one
 * out-of-line body (sim_block_body inlined) for its four callers' loops */
static __attribute__((noinline)) int play_fused(SimObject *s, long long idx, const FusedMove *fm)
{
    if (enter(s) < 0)
        return -1;
    s->res->n_moves += 1;
    int rc;
    if (fm->kind == 1)
        rc = sim_eonly_vals(s, idx, fm->e, fm->v, fm->accel);
    else {
        MoveData m;
        m.ev = NULL;
        m.idx = idx;
        m.kind = (int)K_LINE;
        m.e = fm->e;
        m.v = fm->v;
        m.accel = fm->accel;
        m.flow_r = fm->flow_r;
        m.lim = fm->lim;
        double dx = fm->x1 - fm->x0, dy = fm->y1 - fm->y0, dz = fm->z1 - fm->z0;
        if (s->marlin_jerk && dz == 0.0 && !(s->jerk_z < 0.0))
            rc = sim_block_body(s, &m, 1, dx, dy, dz, m.e, CFG_MARLIN_JERK_XY);
        else if (s->marlin_jerk)
            rc = sim_block_body(s, &m, 1, dx, dy, dz, m.e, CFG_MARLIN_JERK);
        else
            rc = sim_block_body(s, &m, 1, dx, dy, dz, m.e, CFG_ANY);
    }
    s->busy = 0;
    return rc;
}

/* play_fused as the reader's run_ascii calls it back (a jump to play_fused) */
static int play_fused_cb(void *s, long long idx, const FusedMove *fm)
{
    return play_fused((SimObject *)s, idx, fm);
}

/* Where play_loop takes its lines: a list of str (lines[i] the file's line idx0 + i), or a
 * bytes buffer of whole lines (play_buf: the lines split and decoded here, as the text
 * file read_lines opens would give them, each str made only for the time its line is
 * played) */
typedef struct {
    PyObject *list;            /* the list, or NULL: buf */
    const char *buf;
    Py_ssize_t len;
    int cr;                    /* buf may hold a '\r' (else a line ends at its '\n' only) */
    Py_ssize_t i;              /* the next line: its index in the list, or its offset in buf */
    long long idx;             /* the next line's idx */
} LineSrc;

static int play_loop(SimObject *s, LineSrc *src, PyObject *step, long long until, int stops,
                     PyObject *on_barrier, const long long *firsts, Py_ssize_t nf, Py_ssize_t *wi_io,
                     PyObject *on_quiet);

/* play(lines, start, idx0, step, until, stops, on_barrier): simulate._play's loop over
 * lines[start:] (a list of str, lines[j] the file's line idx0 + j): ev = step(idx, raw),
 * a Move played (move), a Barrier taken (barrier, then on_barrier(ev.dwell_t) unless
 * None), anything else passed over.  Returns (j, stopped) where it stopped: before the
 * line whose idx == until (not read), after a line that left the model standing empty
 * (an E-only Move or a Barrier) when `stops` is true (stopped True), or at len(lines). */
/* play(lines, start, idx0, step, wi, stops, on_barrier, firsts): the same loop, but where
 * the 7-argument form stops before the line `until`, it passes over the watched ranges'
 * first lines: firsts (int64 buffer, sorted) from index wi; before each line whose idx
 * equals firsts[wi], wi moves on (as many times as firsts holds that idx).  Returns
 * (j, stopped, wi): the ranges started are those wi passed (simulate._play_chunks). */
static PyObject *Sim_play(SimObject *s, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 7 && nargs != 8)
        return PyErr_Format(PyExc_TypeError, "play() takes 7 or 8 arguments (%zd given)", nargs);
    PyObject *lines = args[0], *step = args[3], *on_barrier = args[6];
    if (!PyList_CheckExact(lines)) {
        PyErr_SetString(PyExc_TypeError, "play: lines must be a list of str");
        return NULL;
    }
    Py_ssize_t i = PyLong_AsSsize_t(args[1]);
    long long idx0 = PyLong_AsLongLong(args[2]);
    long long until = PyLong_AsLongLong(args[4]);
    int stops = PyObject_IsTrue(args[5]);
    if (PyErr_Occurred() || stops < 0)
        return NULL;
    if (i < 0)
        i = 0;
    Py_buffer fb;
    const long long *firsts = NULL;
    Py_ssize_t nf = 0, wi = 0;
    if (nargs == 8) {
        if (PyObject_GetBuffer(args[7], &fb, PyBUF_SIMPLE) < 0)
            return NULL;
        firsts = (const long long *)fb.buf;
        nf = fb.len / (Py_ssize_t)sizeof(long long);
        wi = (Py_ssize_t)until;
        if (wi < 0)
            wi = 0;
        until = -2;
    }
    LineSrc src = {lines, NULL, 0, 0, i, idx0 + (long long)i};
    int stopped = play_loop(s, &src, step, until, stops, on_barrier, firsts, nf, &wi, NULL);
    if (nargs == 8)
        PyBuffer_Release(&fb);
    if (stopped < 0)
        return NULL;
    if (nargs == 8)
        return Py_BuildValue("(nOn)", src.i, stopped ? Py_True : Py_False, wi);
    return Py_BuildValue("(nO)", src.i, stopped ? Py_True : Py_False);
}

/* play_buf(buf, pos, idx, cr, step, until, stops, on_barrier[, firsts]): play() over the
 * lines of buf (bytes-like) from offset pos, the first of them the file's line idx: buf
 * holds whole lines (split as a text file opened with newline="" splits them: after each
 * "\n", "\r\n" or lone "\r"; a last line without an ending is one), each decoded as
 * UTF-8 with surrogateescape, i.e. the str read_lines would give (cr false: buf holds no
 * "\r", lines end at "\n" only).  No list of str is made: each line's str lives only
 * while it is played.  Returns (pos, idx, stopped) where it stopped, the next line's
 * offset and idx; with firsts, (pos, idx, stopped, wi) as play()'s 8-argument form.
 * play_buf(..., firsts, on_quiet): on_quiet None, or a callable the loop calls as
 * on_quiet(line) at a stop (the model empty after that line) while no watched range has
 * started in this call, the state written back first, and plays on: the caller's stopped()
 * where nothing is pending (a stop of those returned only to be recorded, ~3.8 k on the
 * rectilinear plate's measure).  on_quiet a LedgerCore (ledger_new): every stop and every
 * watched range's start recorded in it, whatever is pending; returns at the buffer's end
 * only (stopped false). */
static PyObject *Sim_play_buf(SimObject *s, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs < 8 || nargs > 10)
        return PyErr_Format(PyExc_TypeError, "play_buf() takes 8 to 10 arguments (%zd given)", nargs);
    PyObject *step = args[4], *on_barrier = args[7];
    PyObject *on_quiet = nargs == 10 && args[9] != Py_None ? args[9] : NULL;
    Py_ssize_t pos = PyLong_AsSsize_t(args[1]);
    long long idx = PyLong_AsLongLong(args[2]);
    int cr = PyObject_IsTrue(args[3]);
    long long until = PyLong_AsLongLong(args[5]);
    int stops = PyObject_IsTrue(args[6]);
    if (PyErr_Occurred() || stops < 0 || cr < 0)
        return NULL;
    Py_buffer bb, fb;
    if (PyObject_GetBuffer(args[0], &bb, PyBUF_SIMPLE) < 0)
        return NULL;
    if (pos < 0 || pos > bb.len) {
        PyBuffer_Release(&bb);
        PyErr_SetString(PyExc_ValueError, "play_buf: pos out of the buffer");
        return NULL;
    }
    const long long *firsts = NULL;
    Py_ssize_t nf = 0, wi = 0;
    if (nargs >= 9) {
        if (PyObject_GetBuffer(args[8], &fb, PyBUF_SIMPLE) < 0) {
            PyBuffer_Release(&bb);
            return NULL;
        }
        firsts = (const long long *)fb.buf;
        nf = fb.len / (Py_ssize_t)sizeof(long long);
        wi = (Py_ssize_t)until;
        if (wi < 0)
            wi = 0;
        until = -2;
    }
    LineSrc src = {NULL, (const char *)bb.buf, bb.len, cr, pos, idx};
    int stopped = play_loop(s, &src, step, until, stops, on_barrier, firsts, nf, &wi, on_quiet);
    if (nargs >= 9)
        PyBuffer_Release(&fb);
    PyBuffer_Release(&bb);
    if (stopped < 0)
        return NULL;
    if (nargs >= 9)
        return Py_BuildValue("(nLOn)", src.i, src.idx, stopped ? Py_True : Py_False, wi);
    return Py_BuildValue("(nLO)", src.i, src.idx, stopped ? Py_True : Py_False);
}

/* The source's next line from a buffer: line[0..n) its bytes (the ending included), *ascii
 * whether all of them are ASCII; src moved past it.  0 at the buffer's end. */
static inline __attribute__((always_inline)) int src_next_buf(LineSrc *src, const char **line, Py_ssize_t *n_out,
                                                               int *ascii)
{
    if (src->i >= src->len)
        return 0;
    const char *a = src->buf + src->i, *end = src->buf + src->len, *e;
#ifdef __SSE2__
    if (!src->cr) {
        /* the line's '\n' and its bytes' high bits in one pass (line_end16): the same line
         * and ascii as the steps below, without memchr's call and a second pass over the
         * bytes; no '\n' in the whole 16-byte blocks (a line near the buffer's end, or a
         * long one): read by the steps below from its start */
        unsigned high;
        if ((e = line_end16(a, end, &high)) != NULL) {
            *line = a;
            *n_out = (Py_ssize_t)(e - a);
            *ascii = high == 0;
            src->i = (Py_ssize_t)(e - src->buf);
            src->idx++;
            return 1;
        }
    }
#endif
    if (!src->cr) {
        e = memchr(a, '\n', (size_t)(end - a));
        e = e != NULL ? e + 1 : end;
    } else {
        e = a;
        while (e < end && *e != '\n' && *e != '\r')
            e++;
        if (e < end)
            e += (*e == '\r' && e + 1 < end && e[1] == '\n') ? 2 : 1;
    }
    Py_ssize_t n = (Py_ssize_t)(e - a), k = 0;
    uint64_t high = 0, w8;
    if (n >= 8) {
        for (; k + 8 <= n; k += 8) {
            memcpy(&w8, a + k, sizeof w8);
            high |= w8;
        }
        if (k < n) {                   /* the last 8 bytes (some again): no byte loop */
            memcpy(&w8, a + n - 8, sizeof w8);
            high |= w8;
        }
    } else
        for (; k < n; k++)
            high |= (unsigned char)a[k];
    *line = a;
    *n_out = n;
    *ascii = (high & 0x8080808080808080ULL) == 0;
    src->i = (Py_ssize_t)(e - src->buf);
    src->idx++;
    return 1;
}

/* The source's next line as a new str, src moved past it; NULL at its end (no error set)
 * or on error (set). */
static PyObject *src_take(LineSrc *src)
{
    if (src->list != NULL) {
        if (src->i >= PyList_GET_SIZE(src->list))
            return NULL;
        PyObject *raw = PyList_GET_ITEM(src->list, src->i);
        Py_INCREF(raw);                /* (the callbacks could change the list) */
        src->i++;
        src->idx++;
        return raw;
    }
    const char *a;
    Py_ssize_t n;
    int ascii;
    if (!src_next_buf(src, &a, &n, &ascii))
        return NULL;
    return line_str(a, n, ascii);
}

static inline int src_more(const LineSrc *src)
{
    return src->list != NULL ? src->i < PyList_GET_SIZE(src->list) : src->i < src->len;
}

/* The measure's whole ledger writer in C (a LedgerCore as play_buf's on_quiet, defined with
 * QuietStops below): every stop and every watched range's start recorded where play_loop
 * meets them, no return to Python for them */
static PyTypeObject LedgerType;
static int ledger_stop(PyObject *lc, long long idx);
static int ledger_starts(PyObject *lc, Py_ssize_t k, Py_ssize_t wi);

/* play()'s loop over src's lines: returns 1 if it stopped after a line that left the model
 * empty, 0 before the line `until` or at the end of the lines, -1 on error; src is left at
 * the next line. */
/* A stop play_loop records without returning (on_quiet, see play_buf): the session closed
 * (the state written back, as on a return), on_quiet(line) called, a session opened again */
static int quiet_stop(SimObject *s, void **ss, PyObject *step, PyObject *on_quiet, long long line)
{
    int err;
    void *open_ss = *ss;
    *ss = NULL;
    if (open_ss != NULL && READER->close(open_ss) < 0)
        return -1;
    if (Py_IS_TYPE(on_quiet, &LedgerType)) {
        if (ledger_stop(on_quiet, line) < 0)
            return -1;
    } else {
        PyObject *li = PyLong_FromLongLong(line);
        if (li == NULL)
            return -1;
        PyObject *r = PyObject_CallOneArg(on_quiet, li);
        Py_DECREF(li);
        if (r == NULL)
            return -1;
        Py_DECREF(r);
    }
    *ss = fused_session(s, step, &err);
    return err ? -1 : 0;
}

static int play_loop(SimObject *s, LineSrc *src, PyObject *step, long long until, int stops,
                     PyObject *on_barrier, const long long *firsts, Py_ssize_t nf, Py_ssize_t *wi_io,
                     PyObject *on_quiet)
{
    Py_ssize_t wi = *wi_io;
    const Py_ssize_t wi0 = wi;         /* a stop is quiet (on_quiet) while wi is still wi0 */
    /* a LedgerCore takes every stop (quiet or not) and the ranges' starts as they come */
    const int all_quiet = on_quiet != NULL && Py_IS_TYPE(on_quiet, &LedgerType);
    int stopped = 0, err;
    PyObject *call[3];
    void *ss = fused_session(s, step, &err);
    if (err)
        return -1;
    /* runs of lines read by the reader's own loop (run_ascii: a call a run, not a line) */
    int runs = src->list == NULL && ss != NULL && !src->cr && READER->run_ascii != NULL;
    while (src_more(src)) {
        long long idx = src->idx;
        if (idx == until)
            break;
        if (wi < nf && firsts[wi] == idx) {
            Py_ssize_t w0 = wi;
            while (wi < nf && firsts[wi] == idx)
                wi++;
            if (all_quiet && ledger_starts(on_quiet, wi - w0, wi) < 0)
                goto fail_ss;
        }
        PyObject *raw;
        int got = -2;                  /* what the reader's fused line said; -2: not asked */
        FusedMove fm;
        if (runs) {
            /* up to the next line the tests above stop at: `until`, or the next watched
             * range's first line (none where firsts[wi] is behind: this loop never passes it) */
            long long limit = until > idx ? until : LLONG_MAX;
            if (wi < nf && firsts[wi] > idx && firsts[wi] < limit)
                limit = firsts[wi];
            const char *a;
            Py_ssize_t n;
            int r = READER->run_ascii(ss, src->buf, src->len, &src->i, &src->idx, limit, stops, play_fused_cb, s,
                                      &a, &n);
            if (r < 0)
                goto fail_ss;
            if (r == RUN_STOP) {
                if (on_quiet != NULL && (all_quiet || wi == wi0)) {
                    if (quiet_stop(s, &ss, step, on_quiet, src->idx - 1) < 0)
                        goto fail_ss;
                    runs = ss != NULL;
                    continue;
                }
                stopped = 1;
                break;
            }
            if (r == RUN_STEP) {       /* got 2 for line src->idx - 1: step() reads it */
                idx = src->idx - 1;
                if ((raw = line_str(a, n, 1)) == NULL)
                    goto fail_ss;
                goto python_line;
            }
            if (src->idx != idx)
                continue;              /* lines read: the tests above for the next one */
            /* (none read: this line is the steps' below) */
        }
        if (src->list == NULL && ss != NULL) {
            /* from bytes: a line of ASCII is read from its bytes, its str made only if
             * step() must read it (fused_line reads the same bytes from the str) */
            const char *a;
            Py_ssize_t n;
            int ascii;
            if (!src_next_buf(src, &a, &n, &ascii))
                break;                 /* (src_more said there is one: never taken) */
            if (ascii) {
                got = READER->line_ascii(ss, a, n, !src->cr, &fm);   /* (no CR in buf: none in the line) */
                if (got < 0)
                    goto fail_ss;
            }
            raw = NULL;
            if (got != 0 && got != 1 && (raw = line_str(a, n, ascii)) == NULL)
                goto fail_ss;          /* (line_str's NULL: an error) */
        } else {
            raw = src_take(src);
            if (raw == NULL)
                goto fail_ss;
        }
        if (ss != NULL) {
            if (got == -2)
                got = READER->line(ss, raw, &fm);
            if (got < 0)
                goto fail_raw;
            if (got == 0) {
                Py_XDECREF(raw);
                continue;
            }
            if (got == 1) {
                Py_XDECREF(raw);
                if (play_fused(s, idx, &fm) < 0)
                    goto fail_ss;
                if (stops && fm.kind == 1) {
                    if (on_quiet != NULL && (all_quiet || wi == wi0)) {
                        if (quiet_stop(s, &ss, step, on_quiet, idx) < 0)
                            goto fail_ss;
                        runs = runs && ss != NULL;
                        continue;
                    }
                    stopped = 1;
                    break;
                }
                continue;
            }
            /* got == 2: the state is written back; a plain SET_VELOCITY_LIMIT is read
             * here (svl_line), any other line by step() */
        python_line:;
            int h = svl_line(PyMethod_GET_SELF(step), raw);
            if (h < 0)
                goto fail_raw;
            if (h > 0) {
                Py_DECREF(raw);
                continue;
            }
        }
        PyObject *io = PyLong_FromLongLong(idx);
        if (io == NULL)
            goto fail_raw;
        call[0] = NULL;
        call[1] = io;
        call[2] = raw;
        PyObject *ev = PyObject_Vectorcall(step, call + 1, 2 | PY_VECTORCALL_ARGUMENTS_OFFSET, NULL);
        Py_DECREF(io);
        Py_DECREF(raw);
        if (ev == NULL)
            goto fail_ss;
        PyObject *r = NULL;
        if (Py_TYPE(ev) == MOVE_MAP.type) {
            if (enter(s) < 0)
                goto fail;
            r = Sim_move_body(s, ev);
            s->busy = 0;
            if (r == NULL)
                goto fail;
            Py_DECREF(r);
            if (stops) {
                long long kind;
                if (get_ll(&MOVE_MAP, ev, MV_KIND, &kind) < 0)
                    goto fail;
                stopped = kind == K_EONLY;
            }
        }
        else if (Py_TYPE(ev) == BAR_MAP.type) {
            r = Sim_barrier(s, ev);
            if (r == NULL)
                goto fail;
            Py_DECREF(r);
            if (on_barrier != Py_None) {
                PyObject *dw = get_obj(&BAR_MAP, ev, 0);
                if (dw == NULL)
                    goto fail;
                r = PyObject_CallOneArg(on_barrier, dw);
                Py_DECREF(dw);
                if (r == NULL)
                    goto fail;
                Py_DECREF(r);
            }
            stopped = stops;
        }
        Py_DECREF(ev);
        if (stopped && on_quiet != NULL && (all_quiet || wi == wi0)) {
            stopped = 0;
            if (quiet_stop(s, &ss, step, on_quiet, idx) < 0)
                goto fail_ss;
            runs = runs && ss != NULL;
            continue;
        }
        if (stopped)
            break;
        continue;
    fail:
        Py_DECREF(ev);
        goto fail_ss;
    fail_raw:
        Py_DECREF(raw);
        goto fail_ss;
    }
    *wi_io = wi;
    if (ss != NULL && READER->close(ss) < 0)
        return -1;
    return stopped;
fail_ss:
    if (ss != NULL)
        READER->close(ss);            /* writes the state back, keeps the error */
    return -1;
}

/* The chunk run_lines and gap_lines read (cur[0]): a list of str (read_chunks') or the
 * reader's Lines (state.line_chunks': the chunk's bytes, no str a line) */
typedef struct {
    PyObject *lines;                  /* borrowed */
    Py_ssize_t n_block;               /* a Lines' length; -1: a list */
    const char *data;                 /* a Lines' bytes and line starts (lines_raw), where all: */
    const Py_ssize_t *start;
    int all;                          /* lines_at's flags for every line (a block all ASCII), else 0 */
} Chunk;

/* 0; 1 without the reader (no line can be read here: the callers return None); -1 with a
 * TypeError (what: the caller's name) */
static int chunk_of(PyObject *lines, Chunk *c, const char *what)
{
    c->lines = lines;
    c->n_block = -1;
    c->all = 0;
    if (READER == NULL)
        return 1;
    if (PyList_CheckExact(lines))
        return 0;
    if ((c->n_block = READER->lines_len(lines)) >= 0) {
        c->all = READER->lines_raw(lines, &c->data, &c->start);
        return 0;
    }
    PyErr_Format(PyExc_TypeError, "%s: cur[0] must be a list of str or the reader's Lines", what);
    return -1;
}

static inline Py_ssize_t chunk_len(const Chunk *c)
{
    return c->n_block >= 0 ? c->n_block : PyList_GET_SIZE(c->lines);   /* (a list may change) */
}

enum { LINE_ASCII = 1, LINE_LF = 2 };     /* the reader's lines_at flags */

/* line i (< chunk_len) as bytes line[0..n): LINE_ASCII where they are ASCII (the str's
 * characters; else a str of other characters, or not a str: the peek's 0, Python reads
 * it), or'ed with LINE_LF where the line is known to hold no CR (a Lines' block holds none) */
static inline int chunk_line(const Chunk *c, Py_ssize_t i, const char **line, Py_ssize_t *n)
{
    if (c->all) {                     /* (lines_at's answer, without its call) */
        *line = c->data + c->start[i];
        *n = c->start[i + 1] - c->start[i];
        return c->all;
    }
    if (c->n_block >= 0)
        return READER->lines_at(c->lines, i, line, n);
    PyObject *raw = PyList_GET_ITEM(c->lines, i);
    if (!PyUnicode_CheckExact(raw) || !PyUnicode_IS_ASCII(raw))
        return 0;
    *line = (const char *)PyUnicode_1BYTE_DATA(raw);
    *n = PyUnicode_GET_LENGTH(raw);
    return LINE_ASCII;
}

/* READER->peek of line i (fused_peek's answers) */
static inline int chunk_peek(const Chunk *c, void *ss, Py_ssize_t i, RunMove *rm)
{
    const char *line;
    Py_ssize_t n;
    int got = chunk_line(c, i, &line, &n);
    return (got & LINE_ASCII) ? READER->peek_ascii(ss, line, n, (got & LINE_LF) != 0, rm) : 0;
}

/* run_lines(cur, step, run, run_ends, run_xy, v, accel, feature, z, e_rel, travel, lux, luy,
 *           ld, run_len, r_epm, turned, min_cos, coll, split, f_lim, f_lo, f_hi):
 * strokes.group_lines' common line in C, for pipeline.analyse.  cur = [lines, i, idx0]
 * (lines[i] the file's line idx0 + i, the next to read; lines a list of str or the reader's
 * Lines, read here as bytes: Chunk).  While the next line is a G0/G1
 * of the reader's fast shape whose move continues the open run and group_lines would take
 * it without asking Python (its fast test: the feed, acceleration, feature, Z and E mode
 * of the run (v accel feature z e_rel: the run's first move's), eligible() less what that
 * equality proves (travel: the run's feature is travel); collinear with the last move
 * (lux, luy) within coll, or turning with dot >= min_cos when split is false, or when the
 * move's limits are f_lim and both lengths (ld: the last move's) lie in [f_lo, f_hi]), it
 * reads the line (the reader's state held in C), plays its move in this model (as play()
 * does), appends the move's E (a float: the rest of the Move step() would have made is
 * the run's, strokes._read_move) to run, its end to run_xy and the run's length to
 * run_ends, as group_lines does.  It stops before any other line (Python
 * reads it) and at the chunk's end, sets cur[1] and returns (n lines taken, run_len,
 * r_epm, ld, lux, luy, turned), 0 when it took none, None when it cannot read lines here
 * (the reader's step is not the compiled one, or the callbacks are not the core's own).
 * Given two more arguments, kit and rs (see "run_lines' strokes" below), it also closes
 * runs and opens the next ones itself, and the tuple has an 8th item: the runs it opened
 * (rs then holds group_lines' locals for the last one, run[0] its first Move).
 * The lengths are math.hypot's (called: it is not libm's), the rest the same double
 * operations in the same order as group_lines. */
static PyObject *HYPOT = NULL;            /* math.hypot */

static inline int same_bits(double a, double b)
{
    return memcmp(&a, &b, sizeof(double)) == 0;
}

static int get_hypot(void)
{
    if (HYPOT == NULL) {
        PyObject *math = PyImport_ImportModule("math");
        if (math == NULL)
            return -1;
        HYPOT = PyObject_GetAttrString(math, "hypot");
        Py_DECREF(math);
        if (HYPOT == NULL)
            return -1;
    }
    return 0;
}

/* The length CPython's math.hypot gives two finite floats, computed here (no call: ~330
 * instructions a line of run_lines).  math.hypot is not libm's hypot: it scales both by the
 * power of two that puts the larger in [0.5, 1), sums 1 and the two squares with their exact
 * rounding errors kept aside (the products split exactly: Dekker), takes the root of that
 * sum less 1 and corrects it by one Newton step from the exact residual, then scales back.
 * Every step below is an exact operation or the same rounding in the same order, so the bits
 * are CPython 3.8+'s (checked: hypot_same() against the real math.hypot before use, and
 * tests/test_speed30_groupc_*.py on millions of pairs).  Needs -ffp-contract=off (setup.py). */
typedef struct {
    double hi, lo;
} TwoDouble;

static inline TwoDouble two_prod(double x, double y)      /* x * y = hi + lo exactly (Dekker) */
{
    const double split = 134217729.0;                     /* 2^27 + 1 */
    double cx = split * x, cy = split * y;
    double xh = cx - (cx - x), yh = cy - (cy - y);
    double xl = x - xh, yl = y - yh;
    double hi = x * y;
    double lo = (((xh * yh - hi) + xh * yl) + xl * yh) + xl * yl;
    TwoDouble r = {hi, lo};
    return r;
}

static inline TwoDouble fast_two_sum(double a, double b)  /* a + b = hi + lo exactly, |a| >= |b| */
{
    double hi = a + b;
    TwoDouble r = {hi, (a - hi) + b};
    return r;
}

/* c_hypot's body in two builds: the plain one, and one for FMA hardware (use_fma, where
 * the compiler gives __builtin_fma one instruction) */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define HYPOT_FMA 1
#define HYPOT_FMA_TARGET __attribute__((target("fma")))
#else
#define HYPOT_FMA 0
#endif

/* two_prod(x, y), where use_fma as lo = fma(x, y, -hi): the product's rounding error, exact
 * (one rounding of a representable number) -- Dekker's lo too, which is exact where no step
 * underflows, so the same bits; `exact`: the caller knows x y is far above the underflow
 * (else Dekker's, exact or not, is what CPython 3.11's dl_mul gives) */
static inline __attribute__((always_inline)) TwoDouble two_prod_k(double x, double y, const int use_fma,
                                                                   int exact)
{
#if HYPOT_FMA
    if (use_fma && exact) {
        double hi = x * y;
        TwoDouble r = {hi, __builtin_fma(x, y, -hi)};
        return r;
    }
#else
    (void)use_fma;
    (void)exact;
#endif
    return two_prod(x, y);
}

static double c_hypot(double dx, double dy);

static inline __attribute__((always_inline)) double c_hypot_body(double dx, double dy, const int use_fma)
{
    double ax = fabs(dx), ay = fabs(dy), mx = 0.0;
    if (ax > mx)                                       /* (a nan is never the max: an infinity wins) */
        mx = ax;
    if (ay > mx)
        mx = ay;
    if (isinf(mx))
        return mx;
    if (isnan(ax) || isnan(ay))
        return NAN;
    if (mx == 0.0)
        return mx;
    int e;
    double scale;
    unsigned long long bits;
    memcpy(&bits, &mx, sizeof(bits));
    int biased = (int)(bits >> 52);                    /* (mx > 0: no sign bit) */
    if (biased > 64 && biased < 2000) {
        /* frexp's exponent and ldexp(1.0, -e) read and made from the bits (a normal mx far
         * from both ends: the same numbers, without the two libm calls) */
        e = biased - 1022;
        bits = (unsigned long long)(1023 - e) << 52;
        memcpy(&scale, &bits, sizeof(scale));
    } else {
        frexp(mx, &e);
        if (e < -1023)                                 /* both subnormal: scaled up first */
            return DBL_MIN * c_hypot(ax / DBL_MIN, ay / DBL_MIN);
        scale = ldexp(1.0, -e);
    }
    double csum = 1.0, f1 = 0.0, f2 = 0.0;
    const double v[2] = {ax * scale, ay * scale};
    for (int k = 0; k < 2; k++) {
        /* v[k] in [2^-400, 1) or 0: Dekker's halves are multiples of v[k]'s ulp (2^-453 or
         * more), their products of 2^-906: none underflows, so his lo is the exact error */
        TwoDouble p = two_prod_k(v[k], v[k], use_fma, v[k] >= 0x1p-400 || v[k] == 0.0);
        TwoDouble q = fast_two_sum(csum, p.hi);
        csum = q.hi;
        f1 += p.lo;
        f2 += q.lo;
    }
    double h = sqrt(csum - 1.0 + (f1 + f2));
    TwoDouble p = two_prod_k(-h, h, use_fma, 1);      /* (h near 1: csum - 1 in [0.25, 2)) */
    TwoDouble q = fast_two_sum(csum, p.hi);
    csum = q.hi;
    f1 += p.lo;
    f2 += q.lo;
    double x = csum - 1.0 + (f1 + f2);
    h += x / (2.0 * h);
    return h / scale;
}

static double c_hypot_plain(double dx, double dy)
{
    return c_hypot_body(dx, dy, 0);
}

#if HYPOT_FMA
HYPOT_FMA_TARGET static double c_hypot_fma(double dx, double dy)
{
    return c_hypot_body(dx, dy, 1);
}
#endif

/* c_hypot's build for this machine (hypot_init: c_hypot_fma where the CPU has FMA) */
static double (*C_HYPOT)(double dx, double dy) = c_hypot_plain;

static void hypot_init(void)
{
#if HYPOT_FMA
    __builtin_cpu_init();
    if (__builtin_cpu_supports("fma"))
        C_HYPOT = c_hypot_fma;
#endif
}

static double c_hypot(double dx, double dy)
{
    return C_HYPOT(dx, dy);
}

/* *d = math.hypot(dx, dy), the Python call; -1 with an exception set if it fails */
static int call_hypot(double dx, double dy, double *d)
{
    PyObject *hx = PyFloat_FromDouble(dx), *hy = PyFloat_FromDouble(dy), *h = NULL;
    if (hx != NULL && hy != NULL) {
        PyObject *ha[2] = {hx, hy};
        h = PyObject_Vectorcall(HYPOT, ha, 2, NULL);
    }
    Py_XDECREF(hx);
    Py_XDECREF(hy);
    if (h == NULL)
        return -1;
    *d = PyFloat_AsDouble(h);
    Py_DECREF(h);
    return (*d == -1.0 && PyErr_Occurred()) ? -1 : 0;
}

/* c_hypot gives math.hypot's bits on a spread of pairs (zeros, subnormals, huge, equal,
 * the mm lengths of G-code): 1, else 0 (py_hypot then calls math.hypot); -1 an error */
static int HYPOT_SAME = -2;                            /* -2: not checked yet */

static int hypot_same(void)
{
    static const double xs[] = {0.0, -0.0, 1.0, -1.0, 3.0, 0.1, 0.2, 1e-3, 0.4142135623730951, 123.456,
                                1e-310, 5e-324, 2.2250738585072014e-308, 1e300, 1.7976931348623157e308,
                                7.0710678118654757, 249.99999999999997, 0.30000000000000004, 1.0000000000000002,
                                -87.123456789, 0.0123456789, 33.333333333333336, 6.103515625e-05};
    int n = (int)(sizeof(xs) / sizeof(xs[0]));
    for (int a = 0; a < n; a++)
        for (int b = 0; b < n; b++) {
            double want, got = c_hypot(xs[a], xs[b]);
            if (call_hypot(xs[a], xs[b], &want) < 0)
                return -1;
            if (!same_bits(want, got))
                return 0;
        }
    return 1;
}

/* *d = math.hypot(dx, dy): c_hypot where it is proven the same, else called; -1 with an
 * exception set if the call fails */
static int py_hypot(double dx, double dy, double *d)
{
    if (HYPOT_SAME == -2 && (HYPOT_SAME = hypot_same()) < 0) {
        HYPOT_SAME = -2;
        return -1;
    }
    if (HYPOT_SAME == 1) {
        *d = c_hypot(dx, dy);
        return 0;
    }
    return call_hypot(dx, dy, d);
}

/* hypot(dx, dy): c_hypot's length (tests: it is math.hypot's); hypot(dx, dy, build): the
 * plain build's (0) or the FMA build's (1; None where this machine or compiler has none);
 * hypot(): whether run_lines and gap_lines use it (hypot_same()) */
static PyObject *mod_hypot(PyObject *self, PyObject *args)
{
    double dx, dy;
    int build = -1;
    if (PyTuple_GET_SIZE(args) == 3) {
        if (!PyArg_ParseTuple(args, "ddi:hypot", &dx, &dy, &build))
            return NULL;
        if (build == 0)
            return PyFloat_FromDouble(c_hypot_plain(dx, dy));
#if HYPOT_FMA
        if (C_HYPOT == c_hypot_fma)
            return PyFloat_FromDouble(c_hypot_fma(dx, dy));
#endif
        Py_RETURN_NONE;
    }
    if (PyTuple_GET_SIZE(args) == 0) {
        if (get_hypot() < 0 || (HYPOT_SAME == -2 && (HYPOT_SAME = hypot_same()) < 0)) {
            HYPOT_SAME = -2;
            return NULL;
        }
        return PyBool_FromLong(HYPOT_SAME == 1);
    }
    if (!PyArg_ParseTuple(args, "dd:hypot", &dx, &dy))
        return NULL;
    return PyFloat_FromDouble(c_hypot(dx, dy));
}

/* ---------------------------------------------------------------- StrokeBase */
/* strokes.Stroke's compiled base (the class subclasses it, adding no slot, where this core
 * is used): every stroke lives for the whole run (gyroid plate: 35 k), and a float or int
 * of its own in an object slot cost 24-32 bytes beside the slot's 8.  The fields that are
 * always a float (and the None-able ones that are a float or None) are kept here as
 * doubles, first_idx / last_idx as 64-bit ints; reading one makes the float (int) of
 * those bits, so readers see the same values and types as from the object slots they
 * replace.  A value of another type (the tests' np.float64, an int for a float; never
 * the package's own writers) is kept as it is in the stroke's `extra` dict (its bit set
 * in `odd`) and read back as that object; a deleted field reads as unset (AttributeError),
 * as a slot.  The rest are object slots (T_OBJECT_EX, read by offset as before). */
enum { SD_X0, SD_Y0, SD_UX, SD_UY, SD_LEN, SD_EPM, SD_V0, SD_V1, SD_T, SD_A2, SD_V2,
       SD_PUX, SD_PUY, SD_NUX, SD_NUY, SD_SSE, SD_N };        /* from SD_PUX on: a float or None */
#define SD_NONE0 SD_PUX
enum { SI_FIRST, SI_LAST, SI_N };
enum { SO_Z, SO_ENDS, SO_VF, SO_ACC, SO_FEAT, SO_LAYER, SO_EREL, SO_LIM, SO_KIND, SO_ARC, SO_PTS, SO_CURV,
       SO_SSA, SO_SSC, SO_CHAIN, SO_V0FW, SO_V1FW, SO_CC0, SO_CC1, SO_N };
static const char *const SD_NAMES[SD_N] = {"x0", "y0", "ux", "uy", "length_d", "e_per_mm", "v0", "v1", "time_t",
    "int_a2", "int_v2", "_pux", "_puy", "_nux", "_nuy", "_ss_e"};
static const char *const SI_NAMES[SI_N] = {"first_idx", "last_idx"};

typedef struct {
    PyObject_HEAD
    PyObject *o[SO_N];
    PyObject *extra;           /* NULL, or {name: value} of the odd fields */
    double d[SD_N];
    long long i[SI_N];
    unsigned int has;          /* bit k - SD_NONE0: the None-able double k holds a float */
    unsigned int odd;          /* bit k (double k, int SD_N + k): the value is extra's (unset if not there) */
} StrokeObject;

#define ODD_INTS(s) (((s)->odd >> SD_N) & ((1u << SI_N) - 1))

static PyTypeObject StrokeType;

/* field f's value kept as an object (new reference; an unset field: AttributeError) */
static PyObject *odd_get(StrokeObject *s, const char *name)
{
    PyObject *v = s->extra ? PyDict_GetItemString(s->extra, name) : NULL;
    if (v == NULL) {
        PyErr_Format(PyExc_AttributeError, "'%.50s' object has no attribute '%s'", Py_TYPE(s)->tp_name, name);
        return NULL;
    }
    return Py_NewRef(v);
}

/* field f (bit f of odd) set to the object v, or unset (v NULL) */
static int odd_set(StrokeObject *s, int f, const char *name, PyObject *v)
{
    if (v == NULL) {
        if (s->extra && PyDict_GetItemString(s->extra, name) && PyDict_DelItemString(s->extra, name) < 0)
            return -1;
    } else {
        if (s->extra == NULL && (s->extra = PyDict_New()) == NULL)
            return -1;
        if (PyDict_SetItemString(s->extra, name, v) < 0)
            return -1;
    }
    s->odd |= 1u << f;
    return 0;
}

static PyObject *sd_get(StrokeObject *s, void *c)
{
    int k = (int)(intptr_t)c;
    if (s->odd & (1u << k))
        return odd_get(s, SD_NAMES[k]);
    if (k >= SD_NONE0 && !(s->has & (1u << (k - SD_NONE0))))
        Py_RETURN_NONE;
    return PyFloat_FromDouble(s->d[k]);
}

static int sd_set(StrokeObject *s, PyObject *v, void *c)
{
    int k = (int)(intptr_t)c;
    if (v != NULL && PyFloat_CheckExact(v)) {
        s->d[k] = PyFloat_AS_DOUBLE(v);
        if (k >= SD_NONE0)
            s->has |= 1u << (k - SD_NONE0);
        s->odd &= ~(1u << k);
        return 0;
    }
    if (v == Py_None && k >= SD_NONE0) {
        s->has &= ~(1u << (k - SD_NONE0));
        s->d[k] = 0.0;
        s->odd &= ~(1u << k);
        return 0;
    }
    return odd_set(s, k, SD_NAMES[k], v);
}

static PyObject *si_get(StrokeObject *s, void *c)
{
    int k = (int)(intptr_t)c;
    if (s->odd & (1u << (SD_N + k)))
        return odd_get(s, SI_NAMES[k]);
    return PyLong_FromLongLong(s->i[k]);
}

/* The fields' layout for _gcode_opt_emit (the module's "_STROKE_FIELDS" capsule): its
 * rewrite reads a stroke's doubles (x0, y0, time_t, _ss_e, length_d) and ints (first_idx,
 * last_idx) in place, not through sd_get / si_get's new float or int (~5 a stroke).  It
 * reads a field so only where the type's getter it found is this sd_get / si_get (the
 * same module: this layout), the field's bit in odd is clear, and (a None-able double)
 * its bit in has tells None; else through the getter, as before.  version: 1. */
static PyObject *si_get(StrokeObject *s, void *c);
static const StrokeFieldsAPI STROKE_FIELDS_API = {
    1, (getter)sd_get, (getter)si_get, offsetof(StrokeObject, d), offsetof(StrokeObject, i),
    offsetof(StrokeObject, has), offsetof(StrokeObject, odd), SD_N, SD_NONE0, SI_N};

static int si_set(StrokeObject *s, PyObject *v, void *c)
{
    int k = (int)(intptr_t)c;
    if (v != NULL && PyLong_CheckExact(v)) {
        int over = 0;
        long long x = PyLong_AsLongLongAndOverflow(v, &over);
        if (x == -1 && PyErr_Occurred())
            return -1;
        if (!over) {
            s->i[k] = x;
            s->odd &= ~(1u << (SD_N + k));
            return 0;
        }
    }
    return odd_set(s, SD_N + k, SI_NAMES[k], v);
}

static int Stroke_traverse(StrokeObject *s, visitproc visit, void *arg)
{
    for (int k = 0; k < SO_N; k++)
        Py_VISIT(s->o[k]);
    Py_VISIT(s->extra);
    return 0;
}

static int Stroke_clear(StrokeObject *s)
{
    for (int k = 0; k < SO_N; k++)
        Py_CLEAR(s->o[k]);
    Py_CLEAR(s->extra);
    return 0;
}

static void Stroke_dealloc(StrokeObject *s)
{
    PyObject_GC_UnTrack(s);
    Stroke_clear(s);
    Py_TYPE(s)->tp_free((PyObject *)s);
}

#define SOM(nm, k) {nm, T_OBJECT_EX, offsetof(StrokeObject, o) + (k) * sizeof(PyObject *), 0, NULL}
static PyMemberDef Stroke_members[] = {
    SOM("z", SO_Z), SOM("_ends", SO_ENDS), SOM("v_feed", SO_VF), SOM("accel", SO_ACC), SOM("feature", SO_FEAT),
    SOM("layer", SO_LAYER), SOM("e_rel", SO_EREL), SOM("lim", SO_LIM), SOM("kind", SO_KIND), SOM("arc", SO_ARC),
    SOM("pts", SO_PTS), SOM("curv", SO_CURV), SOM("_ss_a", SO_SSA), SOM("_ss_c", SO_SSC),
    SOM("chain_T", SO_CHAIN), SOM("v0_fw", SO_V0FW), SOM("v1_fw", SO_V1FW), SOM("corner_cmd0", SO_CC0),
    SOM("corner_cmd1", SO_CC1), {NULL}
};
#undef SOM

#define SDG(k) {(char *)0, (getter)sd_get, (setter)sd_set, NULL, (void *)(intptr_t)(k)}
#define SIG(k) {(char *)0, (getter)si_get, (setter)si_set, NULL, (void *)(intptr_t)(k)}
static PyGetSetDef Stroke_getset[SD_N + SI_N + 1] = {
    SDG(0), SDG(1), SDG(2), SDG(3), SDG(4), SDG(5), SDG(6), SDG(7), SDG(8), SDG(9), SDG(10), SDG(11), SDG(12),
    SDG(13), SDG(14), SDG(15), SIG(0), SIG(1), {NULL}
};
#undef SDG
#undef SIG

static PyTypeObject StrokeType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_fwcore.StrokeBase",
    .tp_doc = "strokes.Stroke's fields: the floats and line numbers kept as doubles and ints (see strokes.py)",
    .tp_basicsize = sizeof(StrokeObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC,
    .tp_new = PyType_GenericNew,
    .tp_dealloc = (destructor)Stroke_dealloc,
    .tp_traverse = (traverseproc)Stroke_traverse,
    .tp_clear = (inquiry)Stroke_clear,
    .tp_members = Stroke_members,
    .tp_getset = Stroke_getset,
};

/* a float64 (int64: q) buffer of at least n items, writable if asked; -1 with an error */
static int stroke_buf(PyObject *o, Py_buffer *b, Py_ssize_t n, int is_int, int writable, const char *what)
{
    if (PyObject_GetBuffer(o, b, (writable ? PyBUF_WRITABLE : 0) | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return -1;
    int ok = b->itemsize == 8 && b->format != NULL && b->len >= n * 8
             && (is_int ? (!strcmp(b->format, "q") || !strcmp(b->format, "l")) : !strcmp(b->format, "d"));
    if (!ok) {
        PyBuffer_Release(b);
        PyErr_Format(PyExc_ValueError, "%s: an %s buffer of len(strokes) expected", what,
                     is_int ? "int64" : "float64");
        return -1;
    }
    return 0;
}

/* every item of the list a StrokeBase (its fields read and written here directly) */
static int all_strokes(PyObject *list)
{
    Py_ssize_t n = PyList_GET_SIZE(list);
    for (Py_ssize_t k = 0; k < n; k++)
        if (!PyObject_TypeCheck(PyList_GET_ITEM(list, k), &StrokeType))
            return 0;
    return 1;
}

/* stroke_lines(strokes, lo, hi): lo[k], hi[k] = strokes[k].first_idx, .last_idx (int64
 * buffers of len(strokes)); 1, or 0 if an item is not a StrokeBase or keeps a line
 * number as an object (then the attribute reads) */
static PyObject *mod_stroke_lines(PyObject *self, PyObject *args)
{
    PyObject *list, *lo_o, *hi_o;
    if (!PyArg_ParseTuple(args, "O!OO:stroke_lines", &PyList_Type, &list, &lo_o, &hi_o))
        return NULL;
    if (!all_strokes(list))
        return PyLong_FromLong(0);
    Py_ssize_t n = PyList_GET_SIZE(list);
    Py_buffer bl, bh;
    if (stroke_buf(lo_o, &bl, n, 1, 1, "stroke_lines") < 0)
        return NULL;
    if (stroke_buf(hi_o, &bh, n, 1, 1, "stroke_lines") < 0) {
        PyBuffer_Release(&bl);
        return NULL;
    }
    long long *lo = bl.buf, *hi = bh.buf;
    int odd = 0;
    for (Py_ssize_t k = 0; k < n && !odd; k++) {
        StrokeObject *s = (StrokeObject *)PyList_GET_ITEM(list, k);
        lo[k] = s->i[SI_FIRST];
        hi[k] = s->i[SI_LAST];
        odd = ODD_INTS(s) != 0;        /* (a line number kept as an object: the attribute reads) */
    }
    PyBuffer_Release(&bl);
    PyBuffer_Release(&bh);
    return PyLong_FromLong(!odd);
}

/* stroke_put_sums(strokes, got, v0, v1, t, a2, v2): pipeline._LogSums' sums written into
 * the strokes: v0 where got & 1, v1 where got & 2, time_t int_a2 int_v2 always (got int64,
 * the rest float64 buffers of len(strokes)); 1, or 0 if an item is not a StrokeBase
 * (nothing written) */
static PyObject *mod_stroke_put_sums(PyObject *self, PyObject *args)
{
    PyObject *list, *o[6];
    if (!PyArg_ParseTuple(args, "O!OOOOOO:stroke_put_sums", &PyList_Type, &list, &o[0], &o[1], &o[2], &o[3],
                          &o[4], &o[5]))
        return NULL;
    if (!all_strokes(list))
        return PyLong_FromLong(0);
    Py_ssize_t n = PyList_GET_SIZE(list);
    Py_buffer b[6];
    int got_b = 0;
    for (; got_b < 6; got_b++)
        if (stroke_buf(o[got_b], &b[got_b], n, got_b == 0, 0, "stroke_put_sums") < 0)
            break;
    if (got_b == 6) {
        const long long *g = b[0].buf;
        const double *v0 = b[1].buf, *v1 = b[2].buf, *t = b[3].buf, *a2 = b[4].buf, *v2 = b[5].buf;
        for (Py_ssize_t k = 0; k < n; k++) {
            StrokeObject *s = (StrokeObject *)PyList_GET_ITEM(list, k);
            if (g[k] & 1) {
                s->d[SD_V0] = v0[k];
                s->odd &= ~(1u << SD_V0);
            }
            if (g[k] & 2) {
                s->d[SD_V1] = v1[k];
                s->odd &= ~(1u << SD_V1);
            }
            s->d[SD_T] = t[k];
            s->d[SD_A2] = a2[k];
            s->d[SD_V2] = v2[k];
            s->odd &= ~(1u << SD_T | 1u << SD_A2 | 1u << SD_V2);    /* (floats: as setattr) */
        }
    }
    for (int k = 0; k < got_b; k++)
        PyBuffer_Release(&b[k]);
    return got_b == 6 ? PyLong_FromLong(1) : NULL;
}

/* stroke_fields(strokes, names, vals, kinds): segments.line_classes' reading of the fields
 * `names` (a tuple of StrokeBase field names) of every stroke, without a Python object a
 * field: vals (float64, len(strokes) x len(names), C order) the value's double (a float's
 * own bits, a bool 1.0 / 0.0, None the NaN np.array(..., float) makes of it), kinds (int8,
 * the same shape) what it is: 0 a float, 1 None, 2 a bool, 3 another object or a double
 * field kept as an object (set or not), 4 an object field not set (the caller reads such
 * a field's attribute itself).  1, or 0 (nothing read) if an item is not a
 * StrokeBase or a name is not one of its double or object fields. */
static PyObject *mod_stroke_fields(PyObject *self, PyObject *args)
{
    PyObject *list, *names, *vals_o, *kinds_o;
    if (!PyArg_ParseTuple(args, "O!O!OO:stroke_fields", &PyList_Type, &list, &PyTuple_Type, &names, &vals_o,
                          &kinds_o))
        return NULL;
    Py_ssize_t w = PyTuple_GET_SIZE(names), n = PyList_GET_SIZE(list);
    int where[64];                     /* field j: double k (>= 0) or object slot ~k */
    if (w > 64 || !all_strokes(list))
        return PyLong_FromLong(0);
    for (Py_ssize_t j = 0; j < w; j++) {
        PyObject *nm = PyTuple_GET_ITEM(names, j);
        const char *c = PyUnicode_Check(nm) ? PyUnicode_AsUTF8(nm) : NULL;
        if (c == NULL) {
            PyErr_Clear();
            return PyLong_FromLong(0);
        }
        where[j] = INT_MIN;
        for (int k = 0; k < SD_N; k++)
            if (!strcmp(c, SD_NAMES[k]))
                where[j] = k;
        for (int k = 0; Stroke_members[k].name != NULL; k++)
            if (!strcmp(c, Stroke_members[k].name))
                where[j] = ~(int)((Stroke_members[k].offset - offsetof(StrokeObject, o)) / sizeof(PyObject *));
        if (where[j] == INT_MIN)
            return PyLong_FromLong(0);
    }
    Py_buffer bv, bk;
    if (PyObject_GetBuffer(vals_o, &bv, PyBUF_WRITABLE | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return NULL;
    if (PyObject_GetBuffer(kinds_o, &bk, PyBUF_WRITABLE | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0) {
        PyBuffer_Release(&bv);
        return NULL;
    }
    if (bv.itemsize != 8 || bv.format == NULL || strcmp(bv.format, "d") || bv.len < n * w * 8
        || bk.itemsize != 1 || bk.format == NULL || strcmp(bk.format, "b") || bk.len < n * w) {
        PyBuffer_Release(&bv);
        PyBuffer_Release(&bk);
        PyErr_SetString(PyExc_ValueError, "stroke_fields: float64 and int8 buffers of len(strokes) x len(names)");
        return NULL;
    }
    double *vals = bv.buf, nan_v;
    signed char *kinds = bk.buf;
    const unsigned long long nan_bits = 0x7ff8000000000000ull;      /* np.array([None], float) */
    memcpy(&nan_v, &nan_bits, sizeof nan_v);
    for (Py_ssize_t i = 0; i < n; i++) {
        StrokeObject *s = (StrokeObject *)PyList_GET_ITEM(list, i);
        for (Py_ssize_t j = 0; j < w; j++) {
            double v = 0.0;
            signed char kind = 3;
            int k = where[j];
            if (k >= 0) {
                if (s->odd & (1u << k))
                    ;                                  /* kept as an object (or unset): the caller's */
                else if (k >= SD_NONE0 && !(s->has & (1u << (k - SD_NONE0)))) {
                    v = nan_v;
                    kind = 1;
                } else {
                    v = s->d[k];
                    kind = 0;
                }
            } else {
                PyObject *o = s->o[~k];
                if (o == NULL)
                    kind = 4;
                else if (PyFloat_CheckExact(o)) {
                    v = PyFloat_AS_DOUBLE(o);
                    kind = 0;
                } else if (o == Py_None) {
                    v = nan_v;
                    kind = 1;
                } else if (o == Py_True || o == Py_False) {
                    v = o == Py_True ? 1.0 : 0.0;
                    kind = 2;
                }
            }
            vals[i * w + j] = v;
            kinds[i * w + j] = kind;
        }
    }
    PyBuffer_Release(&bv);
    PyBuffer_Release(&bk);
    return PyLong_FromLong(1);
}

static int stroke_type_ready(void)
{
    for (int k = 0; k < SD_N; k++)
        Stroke_getset[k].name = SD_NAMES[k];
    for (int k = 0; k < SI_N; k++)
        Stroke_getset[SD_N + k].name = SI_NAMES[k];
    return PyType_Ready(&StrokeType);
}

/* ---------------------------------------------------------------- run_lines' strokes
 * With its kit (strokes.group_lines' _RunKit: Stroke, Points, array, K_LINE, K_CURVE,
 * on_stroke, head_move, min_length_d, curves) run_lines also does group_lines' commonest
 * other line in C: a G1 that continues the run in everything but its direction (its test
 * passed, the turn too sharp for the run) closes the run and opens the next one at itself
 * (group_lines' `pre` path).  It does so only where close() makes at most one stroke
 * without asking Python: a run shorter than min_length_d (no stroke), a run of one move
 * (a K_LINE stroke), a curve (curves on, a turned vertex, 3 moves or more); a straight
 * run of several moves (_straight_parts) goes to Python, before the line.  The stroke is
 * the one _run_stroke makes, slot by slot (the same objects where Python passes objects
 * on, the same doubles where it computes), handed to on_stroke.  Every run of one call
 * has the run's feed, acceleration, feature, Z, E mode and limits (the test above), so
 * the first move of the run handed in (run[0]) gives those objects to every stroke;
 * layer, flow and speed factors only change on other lines. */
enum { ST_FIRST, ST_LAST, ST_X0, ST_Y0, ST_Z, ST_UX, ST_UY, ST_LEN, ST_ENDS, ST_VF, ST_ACC, ST_FEAT,
       ST_LAYER, ST_EREL, ST_V0, ST_V1, ST_T, ST_A2, ST_V2, ST_LIM, ST_EPM, ST_PUX, ST_PUY, ST_NUX,
       ST_NUY, ST_KIND, ST_ARC, ST_PTS, ST_CURV, ST_SSE, ST_SSA, ST_SSC, ST_CHAIN, ST_V0FW, ST_V1FW,
       ST_CC0, ST_CC1, ST_N };
static const char *STROKE_NAMES[ST_N] = {
    "first_idx", "last_idx", "x0", "y0", "z", "ux", "uy", "length_d", "_ends", "v_feed", "accel",
    "feature", "layer", "e_rel", "v0", "v1", "time_t", "int_a2", "int_v2", "lim", "e_per_mm", "_pux",
    "_puy", "_nux", "_nuy", "kind", "arc", "pts", "curv", "_ss_e", "_ss_a", "_ss_c", "chain_T", "v0_fw",
    "v1_fw", "corner_cmd0", "corner_cmd1"};
static Py_ssize_t stroke_off[ST_N], points_off[1];
static PyObject *stroke_name[ST_N], *points_name[1];
static SlotMap STROKE_MAP = {NULL, stroke_off, stroke_name, ST_N};
static SlotMap POINTS_MAP = {NULL, points_off, points_name, 1};

/* an object of exactly map's type, every slot val[k] (borrowed), or NULL with an error */
static PyObject *slots_new(SlotMap *m, PyObject *const *val)
{
    PyTypeObject *t = m->type;
    PyObject *o = t->tp_alloc(t, 0);
    if (o == NULL)
        return NULL;
    for (int k = 0; k < m->n; k++)
        *(PyObject **)((char *)o + m->off[k]) = Py_NewRef(val[k]);
    return o;
}

/* map set up for type (kept while it is the same type); 0 if a slot is not a plain one */
static int slots_ready(SlotMap *m, PyObject *type, const char **names)
{
    if ((PyObject *)m->type != type) {
        if (map_init(m, type, names) < 0)
            return -1;
    }
    for (int k = 0; k < m->n; k++)
        if (m->off[k] < 0)
            return 0;
    return 1;
}

/* a StrokeBase subclass (strokes.Stroke over this core): where each of STROKE_NAMES lives,
 * a double (stroke_dbl: SD_ index), an int (stroke_int: SI_ index) or an object slot (-1 in
 * both: STROKE_MAP.off's offset); stroke_inline: STROKE_MAP's type is one */
static signed char stroke_dbl[ST_N], stroke_int[ST_N];
static int stroke_inline = 0;

/* stroke_new's plan, by kind of field (one loop each, no test a field of which it is): the
 * object slots (STROKE_NAMES index, offset), the doubles and the ints (index, d / i index) */
static signed char plan_obj_k[ST_N], plan_dbl_k[ST_N], plan_dbl_j[ST_N], plan_int_k[ST_N], plan_int_j[ST_N];
static Py_ssize_t plan_obj_off[ST_N];
static int plan_n_obj, plan_n_dbl, plan_n_int;

/* the plan of STROKE_MAP's fields (a field in no slot, none of StrokeBase's: stroke_ready
 * finds it, no stroke is made) */
static void stroke_plan(void)
{
    plan_n_obj = plan_n_dbl = plan_n_int = 0;
    for (int k = 0; k < ST_N; k++) {
        if (stroke_dbl[k] >= 0) {
            plan_dbl_k[plan_n_dbl] = (signed char)k;
            plan_dbl_j[plan_n_dbl++] = stroke_dbl[k];
        } else if (stroke_int[k] >= 0) {
            plan_int_k[plan_n_int] = (signed char)k;
            plan_int_j[plan_n_int++] = stroke_int[k];
        } else if (STROKE_MAP.off[k] >= 0) {
            plan_obj_k[plan_n_obj] = (signed char)k;
            plan_obj_off[plan_n_obj++] = STROKE_MAP.off[k];
        }
    }
}

/* the descriptor of name on type, if it is StrokeBase's own (g: its getter) */
static int stroke_own(PyObject *type, const char *name, getter g)
{
    PyObject *d = PyObject_GetAttrString(type, name);
    if (d == NULL) {
        PyErr_Clear();
        return 0;
    }
    int own = Py_TYPE(d) == &PyGetSetDescr_Type && ((PyGetSetDescrObject *)d)->d_getset->get == g;
    Py_DECREF(d);
    return own;
}

/* STROKE_MAP set up for type (kept while it is the same type); 0 if a field is in no
 * plain slot and not StrokeBase's own */
static int stroke_ready(PyObject *type)
{
    if ((PyObject *)STROKE_MAP.type != type) {
        if (map_init(&STROKE_MAP, type, STROKE_NAMES) < 0)
            return -1;
        stroke_inline = PyType_IsSubtype((PyTypeObject *)type, &StrokeType);
        for (int k = 0; k < ST_N; k++) {
            stroke_dbl[k] = stroke_int[k] = -1;
            for (int j = 0; stroke_inline && j < SD_N; j++)
                if (!strcmp(STROKE_NAMES[k], SD_NAMES[j]) && stroke_own(type, SD_NAMES[j], (getter)sd_get))
                    stroke_dbl[k] = (signed char)j;
            for (int j = 0; stroke_inline && j < SI_N; j++)
                if (!strcmp(STROKE_NAMES[k], SI_NAMES[j]) && stroke_own(type, SI_NAMES[j], (getter)si_get))
                    stroke_int[k] = (signed char)j;
        }
        stroke_plan();
    }
    for (int k = 0; k < ST_N; k++)
        if (STROKE_MAP.off[k] < 0 && stroke_dbl[k] < 0 && stroke_int[k] < 0)
            return 0;
    return 1;
}

/* field k of the stroke o (of STROKE_MAP's type) set to v (borrowed) */
static int stroke_put(PyObject *o, int k, PyObject *v)
{
    if (stroke_dbl[k] >= 0)
        return sd_set((StrokeObject *)o, v, (void *)(intptr_t)stroke_dbl[k]);
    if (stroke_int[k] >= 0)
        return si_set((StrokeObject *)o, v, (void *)(intptr_t)stroke_int[k]);
    Py_XSETREF(*(PyObject **)((char *)o + STROKE_MAP.off[k]), Py_NewRef(v));
    return 0;
}

/* stroke_new's fields: field k is val[k] (borrowed), or, where bit k of dm (im) is set, the
 * double d[k] (the int i[k]) written straight into the StrokeBase's double (int) field: the
 * bits its float (int) object would leave there, without the object.  sv_d and sv_i defer a
 * value only into such a field (stroke_dbl, stroke_int), else the caller makes the object. */
typedef struct {
    PyObject *val[ST_N];
    double d[ST_N];
    long long i[ST_N];
    unsigned long long dm, im;
} StrokeVals;

/* every field None, copied into sv_init's StrokeVals as one block (filled at its first
 * use): a store a field in a loop was ~150 instructions a stroke made (~50 k a plate) */
static PyObject *SV_NONES[ST_N];

static inline void sv_init(StrokeVals *sv)
{
    if (SV_NONES[ST_N - 1] != Py_None)
        for (int k = 0; k < ST_N; k++)
            SV_NONES[k] = Py_None;
    memcpy(sv->val, SV_NONES, sizeof SV_NONES);
    sv->dm = sv->im = 0;
}

/* 1: field k will be x (deferred); 0: field k keeps no double, the caller sets val[k] */
static inline int sv_d(StrokeVals *sv, int k, double x)
{
    if (!stroke_inline || stroke_dbl[k] < 0)
        return 0;
    sv->d[k] = x;
    sv->dm |= 1ull << k;
    return 1;
}

static inline int sv_i(StrokeVals *sv, int k, long long x)
{
    if (!stroke_inline || stroke_int[k] < 0)
        return 0;
    sv->i[k] = x;
    sv->im |= 1ull << k;
    return 1;
}

/* a stroke of exactly STROKE_MAP's type with sv's fields, or NULL with an error */
static PyObject *stroke_new(const StrokeVals *sv)
{
    if (!stroke_inline)
        return slots_new(&STROKE_MAP, sv->val);     /* (nothing deferred: not a StrokeBase) */
    PyTypeObject *t = STROKE_MAP.type;
    PyObject *o = t->tp_alloc(t, 0);
    if (o == NULL)
        return NULL;
    StrokeObject *s = (StrokeObject *)o;            /* (zeroed: has and odd 0, as sd_set / si_set leave them) */
    for (int q = 0; q < plan_n_obj; q++)            /* (a slot of the new object: NULL, nothing to let go) */
        *(PyObject **)((char *)o + plan_obj_off[q]) = Py_NewRef(sv->val[plan_obj_k[q]]);
    for (int q = 0; q < plan_n_dbl; q++) {
        int k = plan_dbl_k[q], j = plan_dbl_j[q];
        PyObject *v = sv->val[k];
        if (((sv->dm >> k) & 1) || PyFloat_CheckExact(v)) {
            s->d[j] = ((sv->dm >> k) & 1) ? sv->d[k] : PyFloat_AS_DOUBLE(v);     /* sd_set's float */
            if (j >= SD_NONE0)
                s->has |= 1u << (j - SD_NONE0);
        } else if (sd_set(s, v, (void *)(intptr_t)j) < 0) {
            Py_DECREF(o);
            return NULL;
        }
    }
    for (int q = 0; q < plan_n_int; q++) {
        int k = plan_int_k[q], j = plan_int_j[q];
        if ((sv->im >> k) & 1)
            s->i[j] = sv->i[k];                                                 /* si_set's int */
        else if (si_set(s, sv->val[k], (void *)(intptr_t)j) < 0) {
            Py_DECREF(o);
            return NULL;
        }
    }
    return o;
}

typedef struct {
    PyObject *stroke_t, *points_t, *array_t, *k_line, *k_curve, *on_stroke, *head_move;
    double min_len;
    int curves;
} RunKit;

/* the open run's own figures (the rest is run_lines' locals): its first move is run[0]
 * handed in (c = 0: proto, with prev_u and start the objects group_lines holds) or a line
 * this call opened (c = 1: rm, prev_u (pux, puy), start E rm.e0).  The direction floats are
 * shared as group_lines shares them (a stroke's next_u is the next run's ux uy, a run's
 * prev_u its last move's direction: the stroke's ux uy after a run of one move): new
 * references, kept as long as the run is open */
typedef struct {
    int c;
    RunMove rm;
    long long first, last;
    PyObject *ux, *uy, *pux, *puy;
} RunHead;

static void head_clear(RunHead *h)
{
    Py_CLEAR(h->ux);
    Py_CLEAR(h->uy);
    Py_CLEAR(h->pux);
    Py_CLEAR(h->puy);
}

static PyObject *ZERO = NULL;          /* the 0.0 of _run_stroke's v0 v1 time_t int_a2 int_v2 (one object) */

/* the first move's objects every stroke of the call shares (new references) */
typedef struct {
    PyObject *idx, *x0, *y0, *z0, *v, *accel, *feature, *layer, *e_rel, *lim;
} Proto;

static void proto_clear(Proto *p)
{
    Py_CLEAR(p->idx);
    Py_CLEAR(p->x0);
    Py_CLEAR(p->y0);
    Py_CLEAR(p->z0);
    Py_CLEAR(p->v);
    Py_CLEAR(p->accel);
    Py_CLEAR(p->feature);
    Py_CLEAR(p->layer);
    Py_CLEAR(p->e_rel);
    Py_CLEAR(p->lim);
}

static int proto_read(Proto *p, PyObject *m)
{
    return (p->idx = get_obj(&MOVE_MAP, m, MV_IDX)) && (p->x0 = get_obj(&MOVE_MAP, m, MV_X0))
           && (p->y0 = get_obj(&MOVE_MAP, m, MV_Y0)) && (p->z0 = get_obj(&MOVE_MAP, m, MV_Z0))
           && (p->v = get_obj(&MOVE_MAP, m, MV_V)) && (p->accel = get_obj(&MOVE_MAP, m, MV_ACCEL))
           && (p->feature = get_obj(&MOVE_MAP, m, MV_FEATURE)) && (p->layer = get_obj(&MOVE_MAP, m, MV_LAYER))
           && (p->e_rel = get_obj(&MOVE_MAP, m, MV_E_REL)) && (p->lim = get_obj(&MOVE_MAP, m, MV_LIM))
           ? 0 : -1;
}

/* a new array("d") of n doubles, exactly their room (as array("d", list) has: the strokes
 * keep their arrays for the whole run, ~1.3 MB of the gyroid plate's curves), *buf its
 * items to fill: array("d", [0.0]) repeated n times (array_repeat makes the array of that
 * size, ~10x fewer instructions than array("d", bytes) and its copy a[:], which gave the
 * same array before) */
static PyObject *ARRAY_ONE = NULL;     /* array("d", [0.0]) of the kit's array class */
/* The new array's items read at its item pointer (after its PyVarObject head, as
 * arraymodule.c lays an array out) where a probe of ARRAY_ONE found its buffer there:
 * not through a buffer taken and released (~75 instructions an array: the gyroid plate
 * windowed makes ~165 k).  Else (another layout) through the buffer.  (A slice of an array
 * of zeros, one copy where the repeat doubles its copies, cost as much again in the
 * slice's objects.) */
static Py_ssize_t array_item_off = 0;  /* 0: not found there */

/* array_item_off for ARRAY_ONE's class: 0, or -1 (an exception) */
static int array_probe(void)
{
    Py_buffer view;
    array_item_off = 0;
    if (PyObject_GetBuffer(ARRAY_ONE, &view, PyBUF_WRITABLE) < 0)
        return -1;
    Py_ssize_t off = (Py_ssize_t)sizeof(PyVarObject);
    if (Py_SIZE(ARRAY_ONE) == 1 && view.len == (Py_ssize_t)sizeof(double) && view.itemsize == (Py_ssize_t)sizeof(double)
        && (size_t)Py_TYPE(ARRAY_ONE)->tp_basicsize >= off + sizeof(void *)
        && *(void **)((char *)ARRAY_ONE + off) == view.buf)
        array_item_off = off;
    PyBuffer_Release(&view);
    return 0;
}

static PyObject *array_room(PyObject *array_t, Py_ssize_t n, double **buf)
{
    if (ARRAY_ONE == NULL || (PyObject *)Py_TYPE(ARRAY_ONE) != array_t) {
        PyObject *one = PyObject_CallFunction(array_t, "s[d]", "d", 0.0);
        if (one == NULL)
            return NULL;
        Py_XSETREF(ARRAY_ONE, one);
        if (array_probe() < 0)
            return NULL;
    }
    PyObject *a = PySequence_Repeat(ARRAY_ONE, n);
    if (a == NULL)
        return NULL;
    if (array_item_off > 0 && Py_IS_TYPE(a, Py_TYPE(ARRAY_ONE)) && Py_SIZE(a) == n) {
        *buf = *(double **)((char *)a + array_item_off);     /* (stays put: nothing else holds the array) */
        return a;
    }
    Py_buffer view;
    if (PyObject_GetBuffer(a, &view, PyBUF_WRITABLE) < 0) {
        Py_DECREF(a);
        return NULL;
    }
    *buf = (double *)view.buf;         /* (stays put: nothing else holds the array) */
    int ok = view.len == n * (Py_ssize_t)sizeof(double) && view.itemsize == (Py_ssize_t)sizeof(double);
    PyBuffer_Release(&view);
    if (!ok) {
        Py_DECREF(a);
        PyErr_SetString(PyExc_TypeError, "array_room: not an array of doubles");
        return NULL;
    }
    return a;
}

/* array("d", floats): the list's doubles copied into array_room's array where every item
 * is a float (array("d", list) converts item by item, through the argument parser: ~200
 * instructions a vertex), else array("d", list) itself */
static PyObject *double_array(PyObject *array_t, PyObject *list)
{
    Py_ssize_t n = PyList_GET_SIZE(list);
    for (Py_ssize_t k = 0; k < n; k++)
        if (!PyFloat_CheckExact(PyList_GET_ITEM(list, k)))
            return PyObject_CallFunction(array_t, "sO", "d", list);
    double *d;
    PyObject *a = array_room(array_t, n, &d);
    if (a == NULL)
        return NULL;
    for (Py_ssize_t k = 0; k < n; k++)
        d[k] = PyFloat_AS_DOUBLE(PyList_GET_ITEM(list, k));
    return a;
}

/* array("d") of the n doubles (array_room) */
static PyObject *doubles_array(PyObject *array_t, const double *v, Py_ssize_t n)
{
    double *d;
    PyObject *a = array_room(array_t, n, &d);
    if (a != NULL && n > 0)
        memcpy(d, v, (size_t)n * sizeof(double));
    return a;
}

/* the moves of a run run_lines opened itself, as doubles (no float objects, no list
 * appends a line): e[k] the k-th move's E, xy the run's start and every move's end (x y x y
 * ..., run_xy's), ends[k] the run's length after move k (run_ends').  group_lines' lists
 * are made from them only when the call returns with that run still open (rb_to_lists) */
typedef struct {
    double *e, *xy, *ends;
    Py_ssize_t n, cap;                 /* moves, room (in moves) */
} RunBuf;

static void rb_free(RunBuf *b)
{
    PyMem_Free(b->e);
    PyMem_Free(b->xy);
    PyMem_Free(b->ends);
    b->e = b->xy = b->ends = NULL;
    b->n = b->cap = 0;
}

/* room for one more move; -1 (MemoryError) if none */
static int rb_room(RunBuf *b)
{
    if (b->n < b->cap)
        return 0;
    Py_ssize_t cap = b->cap ? 2 * b->cap : 64;
    double *e = PyMem_Realloc(b->e, (size_t)cap * sizeof(double));
    if (e)
        b->e = e;
    double *xy = PyMem_Realloc(b->xy, (size_t)(2 * cap + 2) * sizeof(double));
    if (xy)
        b->xy = xy;
    double *ends = PyMem_Realloc(b->ends, (size_t)cap * sizeof(double));
    if (ends)
        b->ends = ends;
    if (!e || !xy || !ends) {
        PyErr_NoMemory();
        return -1;
    }
    b->cap = cap;
    return 0;
}

/* the run is one move (e, from (x0, y0) to (x1, y1), length d) */
static int rb_reset(RunBuf *b, double e, double x0, double y0, double x1, double y1, double d)
{
    b->n = 0;
    if (rb_room(b) < 0)
        return -1;
    b->e[0] = e;
    b->xy[0] = x0;
    b->xy[1] = y0;
    b->xy[2] = x1;
    b->xy[3] = y1;
    b->ends[0] = d;
    b->n = 1;
    return 0;
}

/* a move appended (its E, its end, the run's length after it) */
static int rb_push(RunBuf *b, double e, double x1, double y1, double len)
{
    if (rb_room(b) < 0)
        return -1;
    Py_ssize_t n = b->n;
    b->e[n] = e;
    b->xy[2 * n + 2] = x1;
    b->xy[2 * n + 3] = y1;
    b->ends[n] = len;
    b->n = n + 1;
    return 0;
}

/* list[:] = the n doubles as new floats */
static int list_set_doubles(PyObject *list, const double *v, Py_ssize_t n)
{
    PyObject *l = PyList_New(n);
    if (l == NULL)
        return -1;
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *f = PyFloat_FromDouble(v[k]);
        if (f == NULL) {
            Py_DECREF(l);
            return -1;
        }
        PyList_SET_ITEM(l, k, f);
    }
    int rc = PyList_SetSlice(list, 0, PyList_GET_SIZE(list), l);
    Py_DECREF(l);
    return rc;
}

/* group_lines' run, run_ends and run_xy made from the buffer (the open run, handed back) */
static int rb_to_lists(const RunBuf *b, PyObject *run, PyObject *run_ends, PyObject *run_xy)
{
    return list_set_doubles(run, b->e, b->n) < 0 || list_set_doubles(run_ends, b->ends, b->n) < 0
           || list_set_doubles(run_xy, b->xy, 2 * b->n + 2) < 0 ? -1 : 0;
}

/* close()'s stroke of the open run (_run_stroke: curve, or one move when !curve), its
 * next_u (nux, nuy), handed to on_stroke.  prev_u / start: the run handed in's objects
 * (None or a tuple) when h->c is 0; z: the run's Z (the run handed in's z1, the bits of
 * every z0 in it). */
static int run_stroke(const RunKit *kit, const Proto *p, const RunHead *h, PyObject *prev_u, PyObject *start,
                      int travel, int curve, const RunBuf *rb, PyObject *run_ends, PyObject *run_xy, double run_len,
                      double r_epm, PyObject *nux, PyObject *nuy, PyObject *z)
{
    PyObject *own[12];                 /* new references made here (at most 9) */
    int n_own = 0, rc = -1;
#define OWN(x) (own[n_own++] = (x))
    /* field k the double (int) x: deferred into the stroke, else its object */
#define SV_D(k, x) do { if (!sv_d(&sv, (k), (x)) && !(val[k] = OWN(PyFloat_FromDouble(x)))) goto done; } while (0)
#define SV_I(k, x) do { if (!sv_i(&sv, (k), (x)) && !(val[k] = OWN(PyLong_FromLongLong(x)))) goto done; } while (0)
    StrokeVals sv;
    PyObject **val = sv.val;
    sv_init(&sv);
    SV_D(ST_EPM, r_epm);
    if (h->c) {
        SV_I(ST_FIRST, h->first);
        SV_D(ST_X0, h->rm.fm.x0);
        SV_D(ST_Y0, h->rm.fm.y0);
        val[ST_Z] = z;
        val[ST_PUX] = h->pux;
        val[ST_PUY] = h->puy;
        if (start != Py_None)
            SV_D(ST_SSE, h->rm.e0);
    } else {
        val[ST_FIRST] = p->idx;
        val[ST_X0] = p->x0;
        val[ST_Y0] = p->y0;
        val[ST_Z] = p->z0;
        if (prev_u != Py_None) {
            val[ST_PUX] = PyTuple_GET_ITEM(prev_u, 0);
            val[ST_PUY] = PyTuple_GET_ITEM(prev_u, 1);
        }
        if (start != Py_None)
            val[ST_SSE] = PyTuple_GET_ITEM(start, 0);
    }
    if (start != Py_None) {
        val[ST_SSA] = PyTuple_GET_ITEM(start, travel ? 2 : 1);
        val[ST_SSC] = PyTuple_GET_ITEM(start, 3);
    }
    if (h->last == h->first && !((sv.im >> ST_FIRST) & 1))
        val[ST_LAST] = val[ST_FIRST];  /* (one line: group_lines' r_last is that line's idx) */
    else
        SV_I(ST_LAST, h->last);
    val[ST_UX] = h->ux;
    val[ST_UY] = h->uy;
    val[ST_VF] = p->v;
    val[ST_ACC] = p->accel;
    val[ST_FEAT] = p->feature;
    val[ST_LAYER] = p->layer;
    val[ST_EREL] = p->e_rel;
    val[ST_LIM] = p->lim;
    val[ST_V0] = val[ST_V1] = val[ST_T] = val[ST_A2] = val[ST_V2] = ZERO;
    val[ST_NUX] = nux;
    val[ST_NUY] = nuy;
    val[ST_CC0] = val[ST_CC1] = Py_False;
    if (curve) {
        /* Points(run_xy), array("d", run_ends), length_d run_ends[-1] (rb: the run's buffer) */
        PyObject *xy = OWN(rb ? doubles_array(kit->array_t, rb->xy, 2 * rb->n + 2) : double_array(kit->array_t, run_xy));
        if (!xy)
            goto done;
        PyObject *pts = OWN(slots_new(&POINTS_MAP, &xy));
        PyObject *ends = OWN(rb ? doubles_array(kit->array_t, rb->ends, rb->n) : double_array(kit->array_t, run_ends));
        if (!pts || !ends)
            goto done;
        val[ST_KIND] = kit->k_curve;
        val[ST_PTS] = pts;
        val[ST_ENDS] = ends;
        if (rb)
            SV_D(ST_LEN, rb->ends[rb->n - 1]);
        else
            val[ST_LEN] = PyList_GET_ITEM(run_ends, PyList_GET_SIZE(run_ends) - 1);
    } else {
        val[ST_KIND] = kit->k_line;
        SV_D(ST_LEN, run_len);
    }
#undef SV_D
#undef SV_I
    PyObject *st = OWN(stroke_new(&sv));
    if (!st)
        goto done;
    PyObject *r = PyObject_CallOneArg(kit->on_stroke, st);
    if (r == NULL)
        goto done;
    Py_DECREF(r);
    rc = 0;
done:
    for (int k = 0; k < n_own; k++)
        Py_XDECREF(own[k]);
#undef OWN
    return rc;
}

/* close()'s strokes of a straight run of several moves (_straight_parts, then close_parts,
 * or close()'s one-stroke case, which is close_parts' first part): a new Stroke(move)
 * wherever Stroke.try_extend refuses the move (|cross| > coll d or dot <= 0 against the
 * part's first direction: the run's other tests hold for every move of a run), each part's
 * prev_u the run's (the first) or the direction of the move before it, next_u the next
 * part's first direction, start_state E the run's start E plus the moves' E before it (in
 * order); the parts shorter than min_length_d dropped, the last one kept given (nux, nuy),
 * each handed to on_stroke.  The moves are run's (its E: a float, or a Move's e) and
 * run_xy's (their ends); their lengths math.hypot's again (the bits group_lines had). */
static int run_parts(const RunKit *kit, const Proto *p, const RunHead *h, PyObject *prev_u, PyObject *start,
                     int travel, const RunBuf *rb, PyObject *run, PyObject *run_xy, double coll, PyObject *nux,
                     PyObject *nuy, PyObject *z)
{
    Py_ssize_t n = rb ? rb->n : PyList_GET_SIZE(run);
    if (!rb && PyList_GET_SIZE(run_xy) != 2 * n + 2)
        return 1;                      /* (not the run's shape: Python) */
    /* 1 (nothing done: Python closes the run) is decided before any stroke is made */
    double *buf = PyMem_Malloc(6 * (size_t)n * sizeof(double));
    Py_ssize_t *k0s = PyMem_Malloc(((size_t)n + 1) * sizeof(Py_ssize_t));
    PyObject **made = PyMem_Calloc((size_t)n, sizeof(PyObject *));
    if (buf == NULL || k0s == NULL || made == NULL) {
        PyMem_Free(buf);
        PyMem_Free(k0s);
        PyMem_Free(made);
        PyErr_NoMemory();
        return -1;
    }
    double *d = buf, *ux = buf + n, *uy = buf + 2 * n, *e = buf + 3 * n, *ends = buf + 4 * n;
    int rc = -1;
    Py_ssize_t np = 0, kept = 0;       /* parts, strokes made */
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *m, *o;
        double q[4];
        if (rb) {                      /* (a run opened here: its moves' E and ends) */
            memcpy(q, rb->xy + 2 * k, sizeof(q));
            e[k] = rb->e[k];
            goto got_move;
        }
        m = PyList_GET_ITEM(run, k);
        for (int j = 0; j < 4; j++) {
            o = PyList_GET_ITEM(run_xy, 2 * k + j);
            if (!PyFloat_CheckExact(o)) {
                rc = 1;
                goto done;
            }
            q[j] = PyFloat_AS_DOUBLE(o);
        }
        /* the moves after the first are floats (run_lines' or group_lines' lazy moves: the
         * run's feed, acceleration, Z ... to the bit); a Move group_lines took there: Python */
        if (PyFloat_CheckExact(m))
            e[k] = PyFloat_AS_DOUBLE(m);
        else if (k > 0) {
            rc = 1;
            goto done;
        } else if (get_d(&MOVE_MAP, m, MV_E, &e[k]) < 0)
            goto done;
    got_move:;
        double dx = q[2] - q[0], dy = q[3] - q[1];
        if (py_hypot(dx, dy, &d[k]) < 0)
            goto done;
        if (d[k] == 0.0) {
            rc = 1;
            goto done;
        }
        ux[k] = dx / d[k];
        uy[k] = dy / d[k];
        if (k > 0) {                   /* try_extend against the part's first move */
            Py_ssize_t f = k0s[np - 1];
            if (!(fabs(dx * uy[f] - dy * ux[f]) > coll * d[k] || dx * ux[f] + dy * uy[f] <= 0.0))
                continue;
        }
        k0s[np++] = k;
    }
    k0s[np] = n;
    double e_k = 0.0;
    if (start != Py_None) {
        if (h->c)
            e_k = h->rm.e0;
        else if ((e_k = PyFloat_AsDouble(PyTuple_GET_ITEM(start, 0))) == -1.0 && PyErr_Occurred())
            goto done;
    }
    Py_ssize_t k_done = 0;
    for (Py_ssize_t j = 0; j < np; j++) {
        Py_ssize_t a = k0s[j], b = k0s[j + 1];      /* the part's moves a .. b-1 */
        double len = d[a], epm = e[a] / d[a];
        ends[0] = len;
        for (Py_ssize_t k = a + 1; k < b; k++) {
            len += d[k];
            ends[k - a] = len;
            double q = e[k] / d[k];
            if (q > epm)               /* max(e_per_mm, q) */
                epm = q;
        }
        for (; k_done < a; k_done++)  /* the reader's own sum, in its order */
            e_k += e[k_done];
        if (len < kit->min_len)
            continue;                  /* dropped (its neighbours keep what they were given) */
        PyObject *own[16];
        int n_own = 0, bad = 0;
#define OWN(x) (bad |= (own[n_own++] = (x)) == NULL, own[n_own - 1])
        /* field k the double (int) x: deferred into the stroke, else its object */
#define SV_D(k, x) do { if (!sv_d(&sv, (k), (x))) val[k] = OWN(PyFloat_FromDouble(x)); } while (0)
#define SV_I(k, x) do { if (!sv_i(&sv, (k), (x))) val[k] = OWN(PyLong_FromLongLong(x)); } while (0)
        StrokeVals sv;
        PyObject **val = sv.val;
        sv_init(&sv);
        if (a == 0 && !h->c) {
            val[ST_FIRST] = p->idx;
            val[ST_X0] = p->x0;
            val[ST_Y0] = p->y0;
            val[ST_Z] = p->z0;
        } else {
            SV_I(ST_FIRST, h->first + a);
            SV_D(ST_X0, rb ? rb->xy[2 * a] : PyFloat_AS_DOUBLE(PyList_GET_ITEM(run_xy, 2 * a)));
            SV_D(ST_Y0, rb ? rb->xy[2 * a + 1] : PyFloat_AS_DOUBLE(PyList_GET_ITEM(run_xy, 2 * a + 1)));
            val[ST_Z] = z;
        }
        if (b - 1 == a && !((sv.im >> ST_FIRST) & 1))
            val[ST_LAST] = val[ST_FIRST];
        else
            SV_I(ST_LAST, h->first + b - 1);
        if (a == 0) {
            val[ST_UX] = h->ux;        /* (the run's first direction: the same bits) */
            val[ST_UY] = h->uy;
            if (h->c) {
                val[ST_PUX] = h->pux;
                val[ST_PUY] = h->puy;
            } else if (prev_u != Py_None) {
                val[ST_PUX] = PyTuple_GET_ITEM(prev_u, 0);
                val[ST_PUY] = PyTuple_GET_ITEM(prev_u, 1);
            }
        } else {
            SV_D(ST_UX, ux[a]);
            SV_D(ST_UY, uy[a]);
            SV_D(ST_PUX, ux[a - 1]);
            SV_D(ST_PUY, uy[a - 1]);
        }
        if (j + 1 < np) {              /* the next part's first direction (the last kept: below) */
            SV_D(ST_NUX, ux[b]);
            SV_D(ST_NUY, uy[b]);
        }
        SV_D(ST_LEN, len);
        if (b - a > 1)
            val[ST_ENDS] = OWN(doubles_array(kit->array_t, ends, b - a));
        SV_D(ST_EPM, epm);
        if (start != Py_None) {
            if (a == 0 && !h->c)
                val[ST_SSE] = PyTuple_GET_ITEM(start, 0);
            else
                SV_D(ST_SSE, e_k);
            val[ST_SSA] = PyTuple_GET_ITEM(start, travel ? 2 : 1);
            val[ST_SSC] = PyTuple_GET_ITEM(start, 3);
        }
#undef OWN
#undef SV_D
#undef SV_I
        val[ST_VF] = p->v;
        val[ST_ACC] = p->accel;
        val[ST_FEAT] = p->feature;
        val[ST_LAYER] = p->layer;
        val[ST_EREL] = p->e_rel;
        val[ST_LIM] = p->lim;
        val[ST_V0] = val[ST_V1] = val[ST_T] = val[ST_A2] = val[ST_V2] = ZERO;
        val[ST_CC0] = val[ST_CC1] = Py_False;
        val[ST_KIND] = kit->k_line;
        PyObject *st = bad ? NULL : stroke_new(&sv);
        for (int k = 0; k < n_own; k++)
            Py_XDECREF(own[k]);
        if (st == NULL)
            goto done;
        made[kept++] = st;
    }
    if (kept) {                        /* the last one kept: the run's next_u */
        PyObject *st = made[kept - 1];
        if (stroke_put(st, ST_NUX, nux) < 0 || stroke_put(st, ST_NUY, nuy) < 0)
            goto done;
    }
    for (Py_ssize_t k = 0; k < kept; k++) {
        PyObject *r = PyObject_CallOneArg(kit->on_stroke, made[k]);
        if (r == NULL)
            goto done;
        Py_DECREF(r);
    }
    rc = 0;
done:
    for (Py_ssize_t k = 0; k < kept; k++)
        Py_XDECREF(made[k]);
    PyMem_Free(buf);
    PyMem_Free(k0s);
    PyMem_Free(made);
    return rc;
}

/* the kit's parts; 0: no kit (None, or a Stroke / Points whose slots are not all plain) */
static int kit_read(PyObject *o, RunKit *kit)
{
    if (o == Py_None)
        return 0;
    if (!PyTuple_CheckExact(o) || PyTuple_GET_SIZE(o) != 9) {
        PyErr_SetString(PyExc_TypeError, "run_lines: the kit must be a 9-tuple or None");
        return -1;
    }
    kit->stroke_t = PyTuple_GET_ITEM(o, 0);
    kit->points_t = PyTuple_GET_ITEM(o, 1);
    kit->array_t = PyTuple_GET_ITEM(o, 2);
    kit->k_line = PyTuple_GET_ITEM(o, 3);
    kit->k_curve = PyTuple_GET_ITEM(o, 4);
    kit->on_stroke = PyTuple_GET_ITEM(o, 5);
    kit->head_move = PyTuple_GET_ITEM(o, 6);
    kit->min_len = PyFloat_AsDouble(PyTuple_GET_ITEM(o, 7));
    kit->curves = PyObject_IsTrue(PyTuple_GET_ITEM(o, 8));
    if ((kit->min_len == -1.0 && PyErr_Occurred()) || kit->curves < 0)
        return -1;
    if (!PyType_Check(kit->stroke_t) || !PyType_Check(kit->points_t)) {
        PyErr_SetString(PyExc_TypeError, "run_lines: the kit's Stroke and Points must be classes");
        return -1;
    }
    static const char *points_names[1] = {"xy"};
    int a = stroke_ready(kit->stroke_t);
    int b = a < 0 ? -1 : slots_ready(&POINTS_MAP, kit->points_t, points_names);
    return a < 0 || b < 0 ? -1 : (a && b);
}

/* every slot of a Move (state.Move.__slots__), for head_move_new */
enum { HM_IDX, HM_KIND, HM_X0, HM_Y0, HM_Z0, HM_X1, HM_Y1, HM_Z1, HM_E, HM_V, HM_ACCEL, HM_FEATURE, HM_LAYER,
       HM_LIM, HM_ARC, HM_HAS_F, HM_E_REL, HM_XYZ_REL, HM_CHECKSUM, HM_INCH, HM_FLOW_R, HM_SPEED_R, HM_N };
static const char *HEAD_NAMES[HM_N] = {"idx", "kind", "x0", "y0", "z0", "x1", "y1", "z1", "e", "v", "accel",
    "feature", "layer", "lim", "arc", "has_f", "e_rel", "xyz_rel", "checksum", "inch", "flow_r", "speed_r"};
static Py_ssize_t head_off[HM_N];
static PyObject *head_name[HM_N];
static SlotMap HEAD_MAP = {NULL, head_off, head_name, HM_N};

/* the Move strokes._head_move(proto, idx, x0, y0, z0, x1, y1, z1, e, v, has_f) makes, slot by
 * slot (no Python call, no argument tuple: ~7 k instructions a run opened), where proto's
 * class keeps every Move slot plainly and proto has the ones copied; NULL with no error:
 * not so (hand_back calls head_move) */
static PyObject *head_move_new(PyObject *proto, long long idx, const FusedMove *fm, int has_f)
{
    int ready = slots_ready(&HEAD_MAP, (PyObject *)Py_TYPE(proto), HEAD_NAMES);
    if (ready <= 0) {
        PyErr_Clear();                 /* (an error: head_move's call meets it again) */
        return NULL;
    }
    static const int copied[] = {HM_KIND, HM_ACCEL, HM_FEATURE, HM_LAYER, HM_LIM, HM_E_REL, HM_FLOW_R, HM_SPEED_R};
    PyObject *val[HM_N];
    for (size_t q = 0; q < sizeof(copied) / sizeof(copied[0]); q++)
        if ((val[copied[q]] = *(PyObject **)((char *)proto + head_off[copied[q]])) == NULL)
            return NULL;
    PyObject *own[9] = {PyLong_FromLongLong(idx), PyFloat_FromDouble(fm->x0), PyFloat_FromDouble(fm->y0),
                        PyFloat_FromDouble(fm->z0), PyFloat_FromDouble(fm->x1), PyFloat_FromDouble(fm->y1),
                        PyFloat_FromDouble(fm->z1), PyFloat_FromDouble(fm->e), PyFloat_FromDouble(fm->v)};
    static const int owned[9] = {HM_IDX, HM_X0, HM_Y0, HM_Z0, HM_X1, HM_Y1, HM_Z1, HM_E, HM_V};
    int bad = 0;
    for (int k = 0; k < 9; k++) {
        val[owned[k]] = own[k];
        bad |= own[k] == NULL;
    }
    val[HM_ARC] = Py_None;
    val[HM_HAS_F] = has_f ? Py_True : Py_False;
    val[HM_XYZ_REL] = val[HM_CHECKSUM] = val[HM_INCH] = Py_False;
    PyObject *mv = bad ? NULL : slots_new(&HEAD_MAP, val);
    for (int k = 0; k < 9; k++)
        Py_XDECREF(own[k]);
    if (mv == NULL)
        PyErr_Clear();                 /* (head_move's call meets the same failure, and raises) */
    return mv;
}

/* the open run is one run_lines opened: run[0] its first Move (head_move(the run handed
 * in's first Move, ...): the Move step() made of the line) and rs group_lines' locals for
 * it.  start: the run handed in's start_state (its accelerations and cruise ratio hold:
 * no other line came between) */
static int hand_back(const RunKit *kit, const RunHead *h, PyObject *proto_mv, PyObject *run, PyObject *rs,
                     PyObject *start)
{
    const FusedMove *fm = &h->rm.fm;
    PyObject *mv = head_move_new(proto_mv, h->first, fm, h->rm.has_f);
    if (mv == NULL)
        mv = PyObject_CallFunction(kit->head_move, "OLddddddddO", proto_mv, h->first, fm->x0, fm->y0,
                                   fm->z0, fm->x1, fm->y1, fm->z1, fm->e, fm->v,
                                   h->rm.has_f ? Py_True : Py_False);
    if (mv == NULL)
        return -1;
    PyList_SetItem(run, 0, mv);        /* steals mv */
    PyObject *nst = Py_None;
    if (start != Py_None)
        nst = Py_BuildValue("(dOOO)", h->rm.e0, PyTuple_GET_ITEM(start, 1), PyTuple_GET_ITEM(start, 2),
                            PyTuple_GET_ITEM(start, 3));
    else
        Py_INCREF(nst);
    PyObject *val[6] = {PyLong_FromLongLong(h->last), Py_NewRef(h->ux), Py_NewRef(h->uy),
                        PyTuple_Pack(2, h->pux, h->puy), nst, PyLong_FromLongLong(h->first)};
    int bad = 0;
    for (int k = 0; k < 6; k++)
        bad |= val[k] == NULL;
    if (bad) {
        for (int k = 0; k < 6; k++)
            Py_XDECREF(val[k]);
        return -1;
    }
    for (int k = 0; k < 6; k++)
        PyList_SetItem(rs, k, val[k]);     /* steals */
    return 0;
}

#define RL_CLEANUP() (proto_clear(&p), head_clear(&h), Py_XDECREF(proto_mv), Py_XDECREF(o_lux), \
                      Py_XDECREF(o_luy), rb_free(&rb))
static PyObject *Sim_run_lines(SimObject *s, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 23 && nargs != 25)
        return PyErr_Format(PyExc_TypeError, "run_lines() takes 23 or 25 arguments (%zd given)", nargs);
    PyObject *cur = args[0], *step = args[1], *run = args[2], *run_ends = args[3], *run_xy = args[4];
    PyObject *o_v = args[5], *o_accel = args[6], *feature = args[7], *o_z = args[8];
    PyObject *f_lim = args[20];
    if (!PyList_CheckExact(cur) || PyList_GET_SIZE(cur) != 3 || !PyList_CheckExact(run)
        || !PyList_CheckExact(run_ends) || !PyList_CheckExact(run_xy)) {
        PyErr_SetString(PyExc_TypeError, "run_lines: cur, run, run_ends and run_xy must be lists");
        return NULL;
    }
    PyObject *lines = PyList_GET_ITEM(cur, 0);
    Chunk chunk;
    int no_chunk = chunk_of(lines, &chunk, "run_lines");
    if (no_chunk < 0)
        return NULL;
    if (no_chunk)
        Py_RETURN_NONE;
    Py_ssize_t i0 = PyLong_AsSsize_t(PyList_GET_ITEM(cur, 1));
    long long idx0 = PyLong_AsLongLong(PyList_GET_ITEM(cur, 2));
    int e_rel = PyObject_IsTrue(args[9]), travel = PyObject_IsTrue(args[10]);
    double lux = PyFloat_AsDouble(args[11]), luy = PyFloat_AsDouble(args[12]);
    double ld = PyFloat_AsDouble(args[13]), run_len = PyFloat_AsDouble(args[14]);
    double r_epm = PyFloat_AsDouble(args[15]);
    int turned = PyObject_IsTrue(args[16]);
    double min_cos = PyFloat_AsDouble(args[17]), coll = PyFloat_AsDouble(args[18]);
    int split = PyObject_IsTrue(args[19]);
    double f_lo = PyFloat_AsDouble(args[21]), f_hi = PyFloat_AsDouble(args[22]);
    if (PyErr_Occurred() || e_rel < 0 || travel < 0 || turned < 0 || split < 0)
        return NULL;
    if (get_hypot() < 0)
        return NULL;
    /* the strokes' kit and the open run's head, rs = [r_last, r_ux, r_uy, run_prev_u,
     * run_start, first line] (group_lines' locals; rewritten when this call opened a run) */
    RunKit kit;
    memset(&kit, 0, sizeof(kit));
    int have_kit = 0;
    PyObject *rs = NULL, *prev_u = Py_None, *start = Py_None, *proto_mv = NULL;
    /* the last move's direction as objects (the run's ux uy after a run of one move), NULL:
     * not made yet (a line taken here) */
    PyObject *o_lux = NULL, *o_luy = NULL;
    RunHead h;
    memset(&h, 0, sizeof(h));
    Proto p;
    memset(&p, 0, sizeof(p));
    RunBuf rb;                         /* the moves of the run open while h.c (opened here) */
    memset(&rb, 0, sizeof(rb));
    if (nargs == 25) {
        have_kit = kit_read(args[23], &kit);
        if (have_kit < 0)
            return NULL;
        rs = args[24];
        if (have_kit) {
            if (!PyList_CheckExact(rs) || PyList_GET_SIZE(rs) != 6) {
                PyErr_SetString(PyExc_TypeError, "run_lines: rs must be a list of 6");
                return NULL;
            }
            prev_u = PyList_GET_ITEM(rs, 3);
            start = PyList_GET_ITEM(rs, 4);
            h.last = PyLong_AsLongLong(PyList_GET_ITEM(rs, 0));
            if ((h.last == -1 && PyErr_Occurred()) || (ZERO == NULL && (ZERO = PyFloat_FromDouble(0.0)) == NULL))
                return NULL;
            h.ux = Py_NewRef(PyList_GET_ITEM(rs, 1));
            h.uy = Py_NewRef(PyList_GET_ITEM(rs, 2));
            /* (anything unusual: no strokes here, Python closes the run) */
            if (PyList_GET_SIZE(run) < 1 || Py_TYPE(PyList_GET_ITEM(run, 0)) != MOVE_MAP.type
                || !(prev_u == Py_None || (PyTuple_CheckExact(prev_u) && PyTuple_GET_SIZE(prev_u) == 2))
                || !(start == Py_None || (PyTuple_CheckExact(start) && PyTuple_GET_SIZE(start) == 4))
                || PyList_GET_SIZE(run_ends) < 1)
                have_kit = 0;
            else if (proto_read(&p, PyList_GET_ITEM(run, 0)) < 0) {
                RL_CLEANUP();
                return NULL;
            }
            if (have_kit) {
                proto_mv = Py_NewRef(PyList_GET_ITEM(run, 0));
                h.first = PyLong_AsLongLong(p.idx);
                if (h.first == -1 && PyErr_Occurred()) {
                    RL_CLEANUP();
                    return NULL;
                }
            }
        }
    }
    int opened = 0;                    /* runs this call opened */
    o_lux = Py_NewRef(args[11]);
    o_luy = Py_NewRef(args[12]);
    int err;
    void *ss = fused_session(s, step, &err);
    if (err || ss == NULL) {
        RL_CLEANUP();
        if (err)
            return NULL;
        Py_RETURN_NONE;
    }
    Py_INCREF(lines);                  /* the model's callbacks run Python: keep the chunk */
    /* the run's feed, acceleration and Z compared as Python compares floats (an object of
     * another type: no line is taken) */
    int ok = PyFloat_CheckExact(o_v) && PyFloat_CheckExact(o_accel) && PyFloat_CheckExact(o_z);
    double v = ok ? PyFloat_AS_DOUBLE(o_v) : 0.0, accel = ok ? PyFloat_AS_DOUBLE(o_accel) : 0.0;
    double z = ok ? PyFloat_AS_DOUBLE(o_z) : 0.0;
    Py_ssize_t i = i0 < 0 ? 0 : i0;
    for (; ok && i < chunk_len(&chunk); i++) {
        RunMove rm;
        const FusedMove *fm = &rm.fm;
        int got = chunk_peek(&chunk, ss, i, &rm);
        if (got < 0)
            goto fail;
        if (got != 1 || fm->kind != 0)
            break;                     /* not a line move: Python reads it */
        /* the run's feed, acceleration, feature, Z and E mode; eligible().  The feed,
         * acceleration and Z to the bit: the move is kept as its E alone, the rest is the
         * run's (strokes._read_move) */
        double acc = PyFloat_CheckExact(rm.accel) ? PyFloat_AS_DOUBLE(rm.accel) : NAN;
        if (!(same_bits(fm->v, v) && same_bits(acc, accel) && same_bits(fm->z0, z) && same_bits(fm->z1, z)))
            break;
        if (rm.feature != feature) {
            int eq = PyObject_RichCompareBool(rm.feature, feature, Py_EQ);
            if (eq < 0)
                goto fail;
            if (!eq)
                break;
        }
        if (!(rm.e_rel == e_rel && !rm.xyz_rel && rm.speed == 1.0
              && (fm->x1 != fm->x0 || fm->y1 != fm->y0) && (fm->e > 0.0 || (fm->e == 0.0 && travel))))
            break;
        double dx = fm->x1 - fm->x0, dy = fm->y1 - fm->y0;
        double d;
        if (py_hypot(dx, dy, &d) < 0)
            goto fail;
        if (d == 0.0)
            break;                     /* Python's division raises */
        double ux = dx / d, uy = dy / d;
        double dot = lux * ux + luy * uy;
        double cross = lux * uy - luy * ux;
        int turn = 0;
        long long idx = idx0 + (long long)i;
        if (-coll <= cross && cross <= coll && dot > 0.0)
            ;
        else if (dot >= min_cos) {
            if (split && !(fm->lim == f_lim && f_lo <= d && d <= f_hi && f_lo <= ld && ld <= f_hi))
                break;                 /* Python finds the bounds or asks split_vertex */
            turn = 1;
        }
        else {
            /* group_lines' pre path: close the run, open the next one at this line */
            if (!have_kit || fm->lim != p.lim)
                break;
            const RunBuf *rbc = h.c ? &rb : NULL;      /* (the run's moves: in rb, else the lists) */
            Py_ssize_t n_run = h.c ? rb.n : PyList_GET_SIZE(run);
            int drop = run_len < kit.min_len;
            int curve = !drop && kit.curves && turned && n_run >= 3;
            int parts = !drop && !curve && n_run >= 2;
            /* this line's direction: the stroke's next_u, the new run's ux uy and last direction */
            PyObject *nux = PyFloat_FromDouble(ux), *nuy = PyFloat_FromDouble(uy);
            if (nux == NULL || nuy == NULL) {
                Py_XDECREF(nux);
                Py_XDECREF(nuy);
                goto fail;
            }
            if (parts) {               /* straight parts (or Python, before anything changed) */
                int r = run_parts(&kit, &p, &h, prev_u, start, travel, rbc, run, run_xy, coll, nux, nuy, o_z);
                if (r != 0) {
                    Py_DECREF(nux);
                    Py_DECREF(nuy);
                    if (r < 0)
                        goto fail;
                    break;
                }
            }
            READER->commit(ss, &rm);   /* (read() plays the line before group_lines sees it) */
            if (o_lux == NULL)
                o_lux = PyFloat_FromDouble(lux);
            if (o_luy == NULL)
                o_luy = PyFloat_FromDouble(luy);
            if (play_fused(s, idx, fm) < 0 || o_lux == NULL || o_luy == NULL
                || (!drop && !parts && run_stroke(&kit, &p, &h, prev_u, start, travel, curve, rbc, run_ends,
                                                  run_xy, run_len, r_epm, nux, nuy, o_z) < 0)) {
                Py_DECREF(nux);
                Py_DECREF(nuy);
                goto fail;
            }
            head_clear(&h);
            h.pux = o_lux;             /* run_prev_u: the last move's direction (the references move) */
            h.puy = o_luy;
            h.ux = Py_NewRef(nux);
            h.uy = Py_NewRef(nuy);
            o_lux = nux;
            o_luy = nuy;
            if (rb_reset(&rb, fm->e, fm->x0, fm->y0, fm->x1, fm->y1, d) < 0)
                goto fail;
            h.c = 1;
            h.rm = rm;
            h.first = h.last = idx;
            run_len = ld = d;
            r_epm = fm->e / d;
            lux = ux;
            luy = uy;
            turned = 0;
            opened++;
            continue;
        }
        /* taken: the reader's state, the model, the run */
        READER->commit(ss, &rm);
        if (play_fused(s, idx, fm) < 0)
            goto fail;
        run_len += d;
        if (h.c) {
            if (rb_push(&rb, fm->e, fm->x1, fm->y1, run_len) < 0)
                goto fail;
        } else {
            PyObject *t[4] = {PyFloat_FromDouble(fm->e), PyFloat_FromDouble(fm->x1), PyFloat_FromDouble(fm->y1),
                              PyFloat_FromDouble(run_len)};
            int bad = t[0] == NULL || t[1] == NULL || t[2] == NULL || t[3] == NULL;
            if (!bad)
                bad = PyList_Append(run, t[0]) < 0 || PyList_Append(run_xy, t[1]) < 0
                      || PyList_Append(run_xy, t[2]) < 0 || PyList_Append(run_ends, t[3]) < 0;
            for (int k = 0; k < 4; k++)
                Py_XDECREF(t[k]);
            if (bad)
                goto fail;
        }
        double q = fm->e / d;
        if (q > r_epm)
            r_epm = q;
        lux = ux;
        luy = uy;
        ld = d;
        turned |= turn;
        h.last = idx;
        Py_CLEAR(o_lux);
        Py_CLEAR(o_luy);
    }
    Py_DECREF(lines);
    if (READER->close(ss) < 0) {
        RL_CLEANUP();
        return NULL;
    }
    PyObject *io = PyLong_FromSsize_t(i);
    if (io == NULL) {
        RL_CLEANUP();
        return NULL;
    }
    PyList_SetItem(cur, 1, io);        /* steals io */
    if (opened && (rb_to_lists(&rb, run, run_ends, run_xy) < 0 || hand_back(&kit, &h, proto_mv, run, rs, start) < 0)) {
        RL_CLEANUP();
        return NULL;
    }
    RL_CLEANUP();
    if (i == i0)
        return PyLong_FromLong(0);
    if (nargs == 23)                   /* (the round-24 form: no runs opened, 7 items) */
        return Py_BuildValue("(ndddddN)", i - i0, run_len, r_epm, ld, lux, luy, PyBool_FromLong(turned));
    return Py_BuildValue("(ndddddNi)", i - i0, run_len, r_epm, ld, lux, luy, PyBool_FromLong(turned), opened);
fail:
    Py_DECREF(lines);
    RL_CLEANUP();
    READER->close(ss);                 /* writes the state back, keeps the error */
    return NULL;
}

/* gap_lines(cur, step, last_f, selected, travel, min_feed_v, feat_at, last_u, waiting):
 * what pipeline.analyse and strokes.group_lines do with a line while no run or arc stroke
 * is open, for the lines that change nothing there but the reader's state, the model,
 * analyse's feature notes and last_u, in C.  cur as run_lines'; last_f a one-item list,
 * the feature of the last move read; feat_at analyse's (a move of another feature:
 * last_f[0] = its feature and feat_at.append((line, feature)), as analyse's read() does;
 * its tally, which only its Python records' on_line reads, is not kept); selected the features
 * selected (a frozenset); travel the travel feature's name; min_feed_v strokes.MIN_FEED_V;
 * last_u group_lines' (the last move's direction where it leaves, None: a stop); waiting
 * true while a closed stroke waits for the next move's direction (group_lines' waiting).
 * While the next line is a blank or unmarked comment line (nothing to do), an M204 the
 * reader's fused loop reads, a G0/G1 of the reader's fast shape that moves nothing (its
 * state change) or, unless waiting, makes a line or E-only move that eligible() refuses,
 * it reads the line (the reader's state held in C) and plays its move in this model; it
 * stops before any other line (Python reads it) and at the chunk's end, sets cur[1] and
 * returns (n lines read, last_u after them), 0 when it read none, None when it cannot
 * read lines here (as run_lines).  last_u: the last move's direction (_direction(ev,
 * True): math.hypot, then the divisions; None for a zero length, an E-only move), or the
 * one given when no move was read. */
/* feat_at.append((idx, f)): the method's name interned once (PyObject_CallMethod with a
 * format made the name and an argument tuple each call: ~1.9 k instructions a note, ~12 k
 * notes a plate); 0, or -1 with the error set */
static int feat_note(PyObject *feat_at, long long idx, PyObject *f)
{
    static PyObject *append = NULL;
    if (append == NULL && (append = PyUnicode_InternFromString("append")) == NULL)
        return -1;
    PyObject *io = PyLong_FromLongLong(idx);
    if (io == NULL)
        return -1;
    PyObject *note = PyTuple_Pack(2, io, f);
    Py_DECREF(io);
    if (note == NULL)
        return -1;
    PyObject *r = PyObject_CallMethodOneArg(feat_at, append, note);
    Py_DECREF(note);
    Py_XDECREF(r);
    return r == NULL ? -1 : 0;
}

static PyObject *Sim_gap_lines(SimObject *s, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 9)
        return PyErr_Format(PyExc_TypeError, "gap_lines() takes 9 arguments (%zd given)", nargs);
    PyObject *cur = args[0], *step = args[1], *last_f = args[2], *selected = args[3];
    PyObject *travel = args[4], *feat_at = args[6], *last_u = args[7];
    double min_feed_v = PyFloat_AsDouble(args[5]);
    int waiting = PyObject_IsTrue(args[8]);
    if ((min_feed_v == -1.0 && PyErr_Occurred()) || waiting < 0)
        return NULL;
    if (!PyList_CheckExact(cur) || PyList_GET_SIZE(cur) != 3 || !PyList_CheckExact(last_f)
        || PyList_GET_SIZE(last_f) != 1 || !PyFrozenSet_CheckExact(selected)) {
        PyErr_SetString(PyExc_TypeError, "gap_lines: cur and last_f must be lists, selected a frozenset");
        return NULL;
    }
    PyObject *lines = PyList_GET_ITEM(cur, 0);
    Chunk chunk;
    int no_chunk = chunk_of(lines, &chunk, "gap_lines");
    if (no_chunk < 0)
        return NULL;
    if (no_chunk)
        Py_RETURN_NONE;
    Py_ssize_t i0 = PyLong_AsSsize_t(PyList_GET_ITEM(cur, 1));
    long long idx0 = PyLong_AsLongLong(PyList_GET_ITEM(cur, 2));
    if (PyErr_Occurred() || get_hypot() < 0)
        return NULL;
    PyObject *feature = PyList_GET_ITEM(last_f, 0);
    Py_INCREF(feature);
    /* eligible()'s feature tests, for a move of the feature last_f[0]: the same answers
     * for any feature equal to it */
    int sel = PySet_Contains(selected, feature);
    int is_travel = sel < 0 ? -1 : PyObject_RichCompareBool(feature, travel, Py_EQ);
    if (sel < 0 || is_travel < 0) {
        Py_DECREF(feature);
        return NULL;
    }
    int err;
    void *ss = fused_session(s, step, &err);
    if (err || ss == NULL) {
        Py_DECREF(feature);
        if (err)
            return NULL;
        Py_RETURN_NONE;
    }
    Py_INCREF(lines);                  /* the model's callbacks run Python: keep the chunk */
    int moved = 0, last_kind = 0;       /* a move was read; the last one's kind */
    double ldx = 0.0, ldy = 0.0;        /* the last line move's dx dy */
    Py_ssize_t i = i0 < 0 ? 0 : i0;
    for (; i < chunk_len(&chunk); i++) {
        long long idx = idx0 + (long long)i;
        RunMove rm;
        const FusedMove *fm = &rm.fm;
        int got = chunk_peek(&chunk, ss, i, &rm);
        if (got < 0)
            goto fail;
        if (got == 0)
            break;
        if (got == 2)
            continue;                  /* None: nothing to do */
        if (got == 3) {                /* an M204: the fused loop reads it (None), or Python */
            FusedMove m204;
            const char *line;
            Py_ssize_t n;
            int lf = (chunk_line(&chunk, i, &line, &n) & LINE_LF) != 0;     /* (ASCII: the peek read it) */
            /* (a list's str held while it is read, as the list could let go of it) */
            PyObject *held = chunk.n_block < 0 ? Py_NewRef(PyList_GET_ITEM(lines, i)) : NULL;
            int r = READER->line_ascii(ss, line, n, lf, &m204);
            Py_XDECREF(held);
            if (r < 0)
                goto fail;
            if (r != 0)
                break;
            continue;
        }
        if (fm->kind != 2) {
            if (waiting)
                break;                 /* the move whose direction the stroke waits for */
            /* a move eligible() refuses (of its own feature: the feature before, or a new one) */
            PyObject *f = rm.feature;
            int changed = 0, f_sel = sel, f_travel = is_travel;
            if (f != feature) {
                int eq = PyObject_RichCompareBool(f, feature, Py_EQ);
                if (eq < 0)
                    goto fail;
                if (!eq) {
                    changed = 1;
                    f_sel = PySet_Contains(selected, f);
                    f_travel = f_sel < 0 ? -1 : PyObject_RichCompareBool(f, travel, Py_EQ);
                    if (f_sel < 0 || f_travel < 0)
                        goto fail;
                }
            }
            if (fm->kind == 0 && f_sel && !rm.xyz_rel && rm.speed == 1.0 && fm->v >= min_feed_v
                && fm->z0 == fm->z1 && (fm->x1 != fm->x0 || fm->y1 != fm->y0)
                && (fm->e > 0.0 || (fm->e == 0.0 && f_travel)))
                break;                 /* eligible: a run starts (Python) */
            if (changed) {             /* analyse's note of the new feature */
                if (feat_note(feat_at, idx, f) < 0)
                    goto fail;
                Py_INCREF(f);
                PyList_SetItem(last_f, 0, f);           /* steals */
                Py_INCREF(f);
                Py_SETREF(feature, f);
                sel = f_sel;
                is_travel = f_travel;
            }
        }
        READER->commit(ss, &rm);
        if (fm->kind == 2)
            continue;
        if (play_fused(s, idx, fm) < 0)
            goto fail;
        moved = 1;
        last_kind = fm->kind;
        ldx = fm->x1 - fm->x0;
        ldy = fm->y1 - fm->y0;
    }
    Py_DECREF(feature);
    Py_DECREF(lines);
    if (READER->close(ss) < 0)
        return NULL;
    PyObject *io = PyLong_FromSsize_t(i);
    if (io == NULL)
        return NULL;
    PyList_SetItem(cur, 1, io);        /* steals io */
    if (i == i0)
        return PyLong_FromLong(0);
    PyObject *u;
    if (!moved) {
        u = last_u;
        Py_INCREF(u);
    } else if (last_kind == 1)
        u = Py_NewRef(Py_None);
    else {
        double d;
        if (py_hypot(ldx, ldy, &d) < 0)
            return NULL;
        u = d > 0 ? Py_BuildValue("(dd)", ldx / d, ldy / d) : Py_NewRef(Py_None);
        if (u == NULL)
            return NULL;
    }
    return Py_BuildValue("(nN)", i - i0, u);
fail:
    Py_DECREF(feature);
    Py_DECREF(lines);
    READER->close(ss);                 /* writes the state back, keeps the error */
    return NULL;
}

static PyObject *Sim_empty(SimObject *s, PyObject *noarg)
{
    /* nothing planned is waiting: what comes next cannot change what came before */
    return PyBool_FromLong(s->n == 0 && !s->has_rec && !s->has_prev);
}

static PyObject *Sim_get_msl(SimObject *s, void *c)
{
    Py_INCREF(s->max_stop_lines);
    return s->max_stop_lines;
}

static int Sim_set_msl(SimObject *s, PyObject *v, void *c)
{
    if (v == NULL) {
        PyErr_SetString(PyExc_AttributeError, "max_stop_lines cannot be deleted");
        return -1;
    }
    double d = PyFloat_AsDouble(v);
    if (d == -1.0 && PyErr_Occurred())
        return -1;
    Py_INCREF(v);
    Py_XSETREF(s->max_stop_lines, v);
    s->max_stop_d = d;
    return 0;
}

static PyObject *Sim_get_res(SimObject *s, void *c)
{
    Py_INCREF(s->res);
    return (PyObject *)s->res;
}

static PyGetSetDef Sim_getset[] = {
    {"max_stop_lines", (getter)Sim_get_msl, (setter)Sim_set_msl, "full stops listed at most", NULL},
    {"res", (getter)Sim_get_res, NULL, "the SimResult this pass fills", NULL},
    {NULL}
};

static PyMemberDef Sim_members[] = {
    {"on_line", T_OBJECT, offsetof(SimObject, on_line), READONLY, NULL},
    {"on_block", T_OBJECT, offsetof(SimObject, on_block), READONLY, NULL},
    {NULL}
};

static PyMethodDef Sim_methods[] = {
    {"move", (PyCFunction)Sim_move, METH_O, "Play one state.Move."},
    {"barrier", (PyCFunction)Sim_barrier, METH_O, "Bring the machine to rest, then dwell."},
    {"stop", (PyCFunction)Sim_stop, METH_NOARGS, "Bring the machine to rest."},
    {"empty", (PyCFunction)Sim_empty, METH_NOARGS, "Nothing planned is waiting."},
    {"run_lines", (PyCFunction)(void (*)(void))Sim_run_lines, METH_FASTCALL,
     "run_lines(cur, step, run, run_ends, run_xy, v, accel, feature, z, e_rel, travel, lux, luy, ld, run_len, "
     "r_epm, turned, min_cos, coll, split, f_lim, f_lo, f_hi[, kit, rs]): group_lines' common lines "
     "(pipeline.analyse); with a kit, also the runs they close and open"},
    {"gap_lines", (PyCFunction)(void (*)(void))Sim_gap_lines, METH_FASTCALL,
     "gap_lines(cur, step, last_f, selected, travel, min_feed_v, feat_at, last_u, waiting): "
     "analyse's lines between runs"},
    {"play", (PyCFunction)(void (*)(void))Sim_play, METH_FASTCALL,
     "play(lines, start, idx0, step, until, stops, on_barrier) -> (j, stopped): read and play lines."},
    {"play_buf", (PyCFunction)(void (*)(void))Sim_play_buf, METH_FASTCALL,
     "play_buf(buf, pos, idx, cr, step, until, stops, on_barrier[, firsts]) -> (pos, idx, stopped[, wi]): "
     "play() over the lines of a bytes buffer."},
    {NULL}
};

static PyTypeObject SimType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_fwcore.Sim",
    .tp_doc = "Sim(profile, on_line, on_block=None): simulate._Sim in C.",
    .tp_basicsize = sizeof(SimObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Sim_init,
    .tp_traverse = (traverseproc)Sim_traverse,
    .tp_clear = (inquiry)Sim_clear,
    .tp_dealloc = (destructor)Sim_dealloc,
    .tp_methods = Sim_methods,
    .tp_members = Sim_members,
    .tp_getset = Sim_getset,
};

/* ---------------------------------------------------------------- module */
static int const_l(PyObject *c, const char *k, long *out)
{
    PyObject *v = PyDict_GetItemString(c, k);
    if (v == NULL) {
        PyErr_Format(PyExc_KeyError, "setup: constant %s missing", k);
        return -1;
    }
    *out = PyLong_AsLong(v);
    return (*out == -1 && PyErr_Occurred()) ? -1 : 0;
}

static PyObject *mod_setup(PyObject *self, PyObject *args)
{
    PyObject *move_t, *arc_t, *lim_t, *bar_t, *rec_t, *res_t, *c;
    if (!PyArg_ParseTuple(args, "OOOOOOO!:setup", &move_t, &arc_t, &lim_t, &bar_t, &rec_t, &res_t,
                          &PyDict_Type, &c))
        return NULL;
    if (!PyType_Check(rec_t) || !PyType_IsSubtype((PyTypeObject *)rec_t, &RecType)
        || !PyType_Check(res_t) || !PyType_IsSubtype((PyTypeObject *)res_t, &ResType)) {
        PyErr_SetString(PyExc_TypeError, "setup: record and result classes must derive from "
                                         "_core.LineRecord and _core.SimResult");
        return NULL;
    }
    if (map_init(&MOVE_MAP, move_t, MOVE_NAMES) < 0 || map_init(&ARC_MAP, arc_t, ARC_NAMES) < 0
        || map_init(&LIM_MAP, lim_t, LIM_NAMES) < 0)
        return NULL;
    static const char *bar_names[1] = {"dwell_t"};
    if (map_init(&BAR_MAP, bar_t, bar_names) < 0)
        return NULL;
    if (const_l(c, "LINE", &K_LINE) < 0 || const_l(c, "ARC", &K_ARC) < 0
        || const_l(c, "EONLY", &K_EONLY) < 0 || svl_setup(c) < 0)
        return NULL;
    Py_INCREF(rec_t);
    Py_XSETREF(REC_TYPE, (PyTypeObject *)rec_t);
    Py_INCREF(res_t);
    Py_XSETREF(RES_TYPE, (PyTypeObject *)res_t);
    configured = 1;
    Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- ringing (resonance.py) */
/* ring_exps(tt, s, wd, e1, e2): for each tt[i] >= 0, e1[i] = np.exp(-lam tt[i]) and
 * e2[i] = np.exp(lam tt[i]) with lam = -s + i wd, as numpy makes them: the argument is the
 * complex product (s - i wd)(tt + 0i), whose parts are s tt + 0 and 0 - wd tt (exact: the
 * other products are zeros), and numpy's complex exp is libm's, exp(x) (cos y, sin y).  The
 * two share cos and sin of wd tt (cos is even, sin odd).  e1 and e2 are complex128 buffers
 * of len(tt).  Returns False, leaving the rest, at a tt that is not finite (numpy's
 * special cases are not copied).  resonance.py uses it only after it gave numpy's bits on a
 * probe for the oscillator at hand. */
#if defined(__GLIBC__)
#define RING_SINCOS 1
#endif
/* libm's exp without its errno wrapper: glibc's exp is a wrapper (~16 instructions a call,
 * errno on overflow) around __ieee754_exp, which it exports as __exp_finite (a compat
 * symbol since 2.31: found with dlvsym, not linked); the same function, the same numbers
 * (the kernels' probes check them against numpy's anyway).  Elsewhere, or without it,
 * exp.  ring_exp_init() sets it once (each ring_* entry calls it). */
#if defined(__GLIBC__) && defined(__x86_64__)
#include <dlfcn.h>
#define RING_EXP_FINITE 1
#endif
static double (*ring_exp_fn)(double) = NULL;
static void ring_exp_init(void)
{
    if (ring_exp_fn != NULL)
        return;
    ring_exp_fn = exp;
#ifdef RING_EXP_FINITE
    void *f = dlvsym(RTLD_DEFAULT, "__exp_finite", "GLIBC_2.15");
    if (f != NULL)
        ring_exp_fn = (double (*)(double))f;
#endif
}
#define ring_libm_exp(x) (ring_exp_fn(x))

/* cos and sin of y: glibc's sincos where there is one (the same two values, one call) */
static inline void ring_sincos(double y, double *sn, double *cs)
{
#ifdef RING_SINCOS
    sincos(y, sn, cs);
#else
    *cs = cos(y);
    *sn = sin(y);
#endif
}
static PyObject *mod_ring_exps(PyObject *self, PyObject *args)
{
    Py_buffer tb, b1, b2;
    double s, wd;
    ring_exp_init();
    if (!PyArg_ParseTuple(args, "y*ddw*w*:ring_exps", &tb, &s, &wd, &b1, &b2))
        return NULL;
    Py_ssize_t n = tb.len / (Py_ssize_t)sizeof(double);
    PyObject *ret = NULL;
    if (b1.len != 2 * n * (Py_ssize_t)sizeof(double) || b2.len != b1.len) {
        PyErr_SetString(PyExc_ValueError, "ring_exps: e1 and e2 must hold len(tt) complex numbers");
        goto done;
    }
    const double *tt = (const double *)tb.buf;
    double *o1 = (double *)b1.buf, *o2 = (double *)b2.buf;
    int ok = 1;
    for (Py_ssize_t i = 0; i < n; i++) {
        double t = tt[i];
        if (!isfinite(t)) {
            ok = 0;
            break;
        }
        double x1 = s * t + 0.0, x2 = -s * t;
        double y2 = wd * t, y1 = 0.0 - y2;
        double ex1 = ring_libm_exp(x1), ex2 = ring_libm_exp(x2);
        double cs, sn;
        ring_sincos(y2, &sn, &cs);
        double sn1 = y2 != 0.0 ? -sn : y1;
        o1[2 * i] = ex1 * cs;
        o1[2 * i + 1] = ex1 * sn1;
        o2[2 * i] = ex2 * cs;
        o2[2 * i + 1] = ex2 * sn;
    }
    ret = PyBool_FromLong(ok);
done:
    PyBuffer_Release(&tb);
    PyBuffer_Release(&b1);
    PyBuffer_Release(&b2);
    return ret;
}

/* ring_exp(t, a, b, out): out[i] = np.exp(complex(a, b) * t[i]) for real t[i], as numpy
 * makes it: the product with t + 0i is (a t - b 0, a 0 + b t) (numpy's complex product; its
 * zero terms are exact, so a fused multiply-add gives the same), then libm's exp, cos, sin.
 * False, leaving the rest, at a t that is not finite. */
static PyObject *mod_ring_exp(PyObject *self, PyObject *args)
{
    Py_buffer tb, ob;
    double a, b;
    ring_exp_init();
    if (!PyArg_ParseTuple(args, "y*ddw*:ring_exp", &tb, &a, &b, &ob))
        return NULL;
    Py_ssize_t n = tb.len / (Py_ssize_t)sizeof(double);
    PyObject *ret = NULL;
    if (ob.len != 2 * n * (Py_ssize_t)sizeof(double)) {
        PyErr_SetString(PyExc_ValueError, "ring_exp: out must hold len(t) complex numbers");
        goto done;
    }
    const double *tt = (const double *)tb.buf;
    double *o = (double *)ob.buf;
    int ok = 1;
    for (Py_ssize_t i = 0; i < n; i++) {
        double t = tt[i];
        if (!isfinite(t)) {
            ok = 0;
            break;
        }
        double x = a * t - b * 0.0, y = a * 0.0 + b * t;
        double ex = ring_libm_exp(x), cs, sn;
        ring_sincos(y, &sn, &cs);
        o[2 * i] = ex * cs;
        o[2 * i + 1] = ex * sn;
    }
    ret = PyBool_FromLong(ok);
done:
    PyBuffer_Release(&tb);
    PyBuffer_Release(&ob);
    return ret;
}

/* ring_amps(t_ev, dc, s, wd, span, short_n, start, carry, t_carry, c, fused): resonance.py's
 * Oscillator.amplitudes restart loop from event `start`, done here while each restart is
 * shorter than short_n events and its times finite; returns the event it stopped at (the
 * caller does that restart with numpy, then calls again; so too for a dc that is not finite).  Each restart: stop by numpy's
 * searchsorted(t_ev, t0 + span, 'right') (its binary search, NaN last), tt = t_ev - t0,
 * e_dn / e_up as ring_exps, c0 = carry * exp(lam (t0 - t_carry)) (CPython's complex times
 * float, libm's exp as numpy's complex exp takes it, numpy's scalar complex product), the
 * products dc e_dn and (c0 + g) e_up as numpy's contiguous complex-multiply loop makes them
 * (fused = 1: its SIMD loop, re = fma(ar, br, -(ai bi)), im = fma(ar, bi, ai br); 0: the
 * plain formula), g the running sum (the cumsum's first term copied).  resonance.py uses it
 * only after it gave the numpy loop's bits on a probe. */
/* The loops below call fma() per product: a clone of each built for FMA hardware does it
 * in one instruction (the same exact result; glibc's ifunc picks the clone at load time,
 * so only with glibc: musl has no ifunc). */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__GLIBC__)
#define RING_CLONES __attribute__((target_clones("fma", "default")))
#else
#define RING_CLONES
#endif

/* x hidden from the compiler's algebra: where it knows ta = -a, it makes ta * u as -(a * u)
 * (and takes a * u of the piece before), which is another NaN than numpy's (-a) * u when
 * a * u is not a number (0 * inf: x86's default NaN, negative, then negated) */
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#define RING_OPAQUE(x) __asm__("" : "+x"(x))
#elif defined(__GNUC__)
#define RING_OPAQUE(x) __asm__("" : "+m"(x))
#else
#define RING_OPAQUE(x) ((void)0)
#endif

static inline void ring_cmul(int fused, double ar, double ai, double br, double bi,
                             double *re, double *im)
{
    if (fused) {
        *re = fma(ar, br, -(ai * bi));
        *im = fma(ar, bi, ai * br);
    } else {
        /* (the products hidden: gcc's vectorizer takes such a complex product, once its
         * operands are held from event to event, for one fused vfmaddsub -- another
         * rounding, despite -ffp-contract=off) */
        double rr = ar * br, ii = ai * bi, ri = ar * bi, ir = ai * br;
        RING_OPAQUE(rr);
        RING_OPAQUE(ii);
        RING_OPAQUE(ri);
        RING_OPAQUE(ir);
        *re = rr - ii;
        *im = ri + ir;
    }
}

/* The amplitude cr + i ci carried dt to a restart's first time: times exp((-s + i wd) dt),
 * as numpy's complex exp of (-s + i wd) dt (its parts -s dt - wd 0 and -s 0 + wd dt), then
 * the plain complex product (ring_solve's and ring_amps_run's restarts) */
static inline void ring_carry(double cr, double ci, double s, double wd, double dt, double *c0r, double *c0i)
{
    double x = -s * dt - wd * 0.0, y = -s * 0.0 + wd * dt;
    double ex = ring_libm_exp(x), cs, sn;
    ring_sincos(y, &sn, &cs);
    double er = ex * cs, ei = ex * sn;
    *c0r = cr * er - ci * ei;
    *c0i = cr * ei + ci * er;
}

static inline int ring_less(double a, double b)     /* numpy's sort order: NaN last */
{
    return a < b || (b != b && a == a);
}

/* The memo (optional, ring_amps' last five arguments): the exponentials another call made,
 * for its events mt (sorted) in restarts starting at mt0 (NaN: not made there), mv = (exp(s tt),
 * exp(-s tt), cos(wd tt), sin(wd tt)) per event; an event here at the same time in a restart
 * that starts at the same time has the same tt = t - t0, bit for bit, so the same
 * exponentials: they are taken from the memo instead of libm (the ringing's parts and axes
 * share most events).  This call's own go to ot0 / ov (len(t_ev) each, 4 numbers an event
 * in ov; ot0 left as the caller set it where numpy makes the restart). */
typedef struct {
    Py_buffer mt, mt0, mv, ot0, ov;
    int have_m, have_o;
} RingMemo;

static void ring_memo_release(RingMemo *m)
{
    if (m->have_m) {
        PyBuffer_Release(&m->mt);
        PyBuffer_Release(&m->mt0);
        PyBuffer_Release(&m->mv);
    }
    if (m->have_o) {
        PyBuffer_Release(&m->ot0);
        PyBuffer_Release(&m->ov);
    }
    m->have_m = m->have_o = 0;
}

/* m: the memo from memo_t, memo_t0, memo_v (all None: no memo) and out_t0, out_v (None: not
 * kept) with per values an event; -1 with an exception on a wrong length */
static int ring_memo_get(RingMemo *m, PyObject *mt, PyObject *mt0, PyObject *mv, PyObject *ot0,
                         PyObject *ov, Py_ssize_t n, Py_ssize_t per)
{
    m->have_m = m->have_o = 0;
    if (mt != Py_None) {
        if (PyObject_GetBuffer(mt, &m->mt, PyBUF_SIMPLE) < 0)
            return -1;
        if (PyObject_GetBuffer(mt0, &m->mt0, PyBUF_SIMPLE) < 0) {
            PyBuffer_Release(&m->mt);
            return -1;
        }
        if (PyObject_GetBuffer(mv, &m->mv, PyBUF_SIMPLE) < 0) {
            PyBuffer_Release(&m->mt);
            PyBuffer_Release(&m->mt0);
            return -1;
        }
        m->have_m = 1;
        if (m->mt0.len != m->mt.len || m->mv.len != per * m->mt.len) {
            PyErr_SetString(PyExc_ValueError, "ring memo: lengths differ");
            ring_memo_release(m);
            return -1;
        }
    }
    if (ot0 != Py_None) {
        if (PyObject_GetBuffer(ot0, &m->ot0, PyBUF_WRITABLE) < 0) {
            ring_memo_release(m);
            return -1;
        }
        if (PyObject_GetBuffer(ov, &m->ov, PyBUF_WRITABLE) < 0) {
            PyBuffer_Release(&m->ot0);
            ring_memo_release(m);
            return -1;
        }
        m->have_o = 1;
        if (m->ot0.len != n * (Py_ssize_t)sizeof(double) || m->ov.len != per * m->ot0.len) {
            PyErr_SetString(PyExc_ValueError, "ring memo: out_t0 / out_v lengths");
            ring_memo_release(m);
            return -1;
        }
    }
    return 0;
}

static inline int ring_same(double a, double b)      /* the same bits */
{
    uint64_t x, y;
    memcpy(&x, &a, sizeof x);
    memcpy(&y, &b, sizeof y);
    return x == y;
}

/* Whether the memo (m_t sorted, m_t0 each event's restart's start) has a restart from t0:
 * only then can an event of a restart from t0 find its exponentials there (the same tt,
 * t - t0, is the same event time in a restart from the same time), and that restart starts
 * at an event at t0 (its m_t0 is its own time).  *m_j: there (the first event at t0), to
 * look the restart's events up from. */
static inline int ring_memo_restart(const double *m_t, const double *m_t0, Py_ssize_t m_n, double t0,
                                    Py_ssize_t *m_j)
{
    Py_ssize_t lo = 0, hi = m_n;
    while (lo < hi) {               /* the first event not before t0 */
        Py_ssize_t mid = lo + ((hi - lo) >> 1);
        if (m_t[mid] < t0)
            lo = mid + 1;
        else
            hi = mid;
    }
    for (Py_ssize_t k = lo; k < m_n && m_t[k] == t0; k++)
        if (ring_same(m_t[k], t0) && ring_same(m_t0[k], t0)) {
            *m_j = lo;
            return 1;
        }
    return 0;
}

/* a restart at event start (time t[start]) runs to the first event past key = t[start] + span
 * (numpy's searchsorted(t, key, 'right'), NaN last), and at least over its own event */
static inline Py_ssize_t ring_restart_stop(const double *t, Py_ssize_t n, Py_ssize_t start, double key)
{
    Py_ssize_t lo = 0, hi = n;
    while (lo < hi) {
        Py_ssize_t mid = lo + ((hi - lo) >> 1);
        if (!ring_less(key, t[mid]))
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo <= start ? start + 1 : lo;
}

/* ring_amps_run's state from event to event of a restart: the last time's bits and its
 * exponentials, e_dn, e_up, the running sum g, the memo's place */
typedef struct {
    uint64_t tt_prev;
    double ex1, ex2, c2, s2, edr, edi, eur, eui, gr, gi;
    Py_ssize_t m_j;
} RingEvState;

/* one event i of a restart from t0 with jump (dcr, dci): the restart loop's body (use_m:
 * the memo's entry for an event is searched by its time; 0: no memo for this restart) (e_dn =
 * (ex1 c2, ex1 s1) and e_up = (ex2 c2, ex2 s2) made once a time: the same products) */
static inline __attribute__((always_inline)) void
ring_solve_event(RingEvState *st, Py_ssize_t i, double dcr, double dci, const double *t, double t0, double s,
                 double wd, double c0r, double c0i, double *c, int fused, int use_m, const double *m_t,
                 const double *m_t0, const double *m_v, Py_ssize_t m_n, double *o_t0, double *o_v, int out)
{
    double tt = t[i] - t0;
    uint64_t tt_bits;
    memcpy(&tt_bits, &tt, sizeof tt_bits);
    if (tt_bits != st->tt_prev) {
        double y2 = wd * tt, y1 = 0.0 - y2;
        int got = 0;
        if (use_m) {
            double ti = t[i];
            Py_ssize_t m_j = st->m_j;
            while (m_j < m_n && m_t[m_j] < ti)
                m_j++;
            st->m_j = m_j;
            for (Py_ssize_t k = m_j; k < m_n && ring_same(m_t[k], ti); k++)
                if (ring_same(m_t0[k], t0)) {
                    st->ex1 = m_v[4 * k];
                    st->ex2 = m_v[4 * k + 1];
                    st->c2 = m_v[4 * k + 2];
                    st->s2 = m_v[4 * k + 3];
                    got = 1;
                    break;
                }
        }
        if (!got) {
            double x1 = s * tt + 0.0, x2 = -s * tt;
            st->ex1 = ring_libm_exp(x1);
            st->ex2 = ring_libm_exp(x2);
            double sn2, cs2;
            ring_sincos(y2, &sn2, &cs2);
            st->s2 = sn2;
            st->c2 = cs2;
        }
        double s1 = y2 != 0.0 ? -st->s2 : y1;
        st->edr = st->ex1 * st->c2;
        st->edi = st->ex1 * s1;
        st->eur = st->ex2 * st->c2;
        st->eui = st->ex2 * st->s2;
        st->tt_prev = tt_bits;
    }
    if (out) {
        o_t0[i] = t0;
        o_v[4 * i] = st->ex1;
        o_v[4 * i + 1] = st->ex2;
        o_v[4 * i + 2] = st->c2;
        o_v[4 * i + 3] = st->s2;
    }
    double pr, pi;
    ring_cmul(fused, dcr, dci, st->edr, st->edi, &pr, &pi);
    st->gr = st->gr + pr;
    st->gi = st->gi + pi;
    ring_cmul(fused, c0r + st->gr, c0i + st->gi, st->eur, st->eui, &c[2 * i], &c[2 * i + 1]);
}

/* Oscillator.amplitudes' restart loop (ring_amps'): from event start with
 * the carried amplitude (cr, ci) at t_carry; returns the event it stopped at.  m_*: the memo
 * (m_n 0: none), o_*: this call's exponentials (NULL: not kept).  checks: stop before a
 * restart holding a time or a dc that is not finite (numpy does that restart). */
static inline __attribute__((always_inline)) Py_ssize_t
ring_amps_run(const double *t, const double *dc, Py_ssize_t n, double s, double wd, double span,
              Py_ssize_t short_n, Py_ssize_t start, double cr, double ci, double t_carry, double *c,
              int fused, const double *m_t, const double *m_t0, const double *m_v, Py_ssize_t m_n,
              double *o_t0, double *o_v, int checks)
{
    Py_ssize_t m_j = 0;
    while (start < n) {
        double t0 = t[start];
        if (!isfinite(t0))
            break;
        Py_ssize_t stop = ring_restart_stop(t, n, start, t0 + span);
        if (stop - start >= short_n)
            break;
        int fin = 1;        /* NaN's bits are not copied: such a restart is numpy's */
        for (Py_ssize_t i = start; checks && i < stop; i++)
            if (!isfinite(t[i] - t0) || !isfinite(dc[2 * i]) || !isfinite(dc[2 * i + 1])) {
                fin = 0;
                break;
            }
        double dt = t0 - t_carry;
        if (!fin || !isfinite(dt))
            break;
        double c0r, c0i;
        ring_carry(cr, ci, s, wd, dt, &c0r, &c0i);
        /* the memo serves this restart only if it has one from t0 too; the running sum g from
         * -0.0 (-0.0 + p is p, bit for bit: the cumsum's first term copied); events at one
         * time (a block without cruise) share the previous event's exponentials (same bits
         * in, same out; the first event's tt is +0, never tt_prev's first bits, a NaN's) */
        int use_m = m_n && ring_memo_restart(m_t, m_t0, m_n, t0, &m_j);
        RingEvState st = {UINT64_MAX, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.0, -0.0, m_j};
        for (Py_ssize_t i = start; i < stop; i++)
            ring_solve_event(&st, i, dc[2 * i], dc[2 * i + 1], t, t0, s, wd, c0r, c0i, c, fused, use_m, m_t,
                             m_t0, m_v, m_n, o_t0, o_v, o_t0 != NULL);
        m_j = st.m_j;
        cr = c[2 * (stop - 1)];
        ci = c[2 * (stop - 1) + 1];
        t_carry = t[stop - 1];
        start = stop;
    }
    return start;
}

RING_CLONES static PyObject *mod_ring_amps(PyObject *self, PyObject *args)
{
    Py_buffer tb, db, cb;
    double s, wd, span, t_carry;
    Py_complex carry;
    Py_ssize_t short_n, start;
    int fused;
    PyObject *mt = Py_None, *mt0 = Py_None, *mv = Py_None, *ot0 = Py_None, *ov = Py_None;
    RingMemo memo;
    ring_exp_init();
    if (!PyArg_ParseTuple(args, "y*y*dddnnDdw*p|OOOOO:ring_amps", &tb, &db, &s, &wd, &span, &short_n,
                          &start, &carry, &t_carry, &cb, &fused, &mt, &mt0, &mv, &ot0, &ov))
        return NULL;
    Py_ssize_t n = tb.len / (Py_ssize_t)sizeof(double);
    PyObject *ret = NULL;
    if (ring_memo_get(&memo, mt, mt0, mv, ot0, ov, n, 4) < 0) {
        PyBuffer_Release(&tb);
        PyBuffer_Release(&db);
        PyBuffer_Release(&cb);
        return NULL;
    }
    const double *m_t = memo.have_m ? (const double *)memo.mt.buf : NULL;
    const double *m_t0 = memo.have_m ? (const double *)memo.mt0.buf : NULL;
    const double *m_v = memo.have_m ? (const double *)memo.mv.buf : NULL;
    Py_ssize_t m_n = memo.have_m ? memo.mt.len / (Py_ssize_t)sizeof(double) : 0;
    double *o_t0 = memo.have_o ? (double *)memo.ot0.buf : NULL;
    double *o_v = memo.have_o ? (double *)memo.ov.buf : NULL;
    if (db.len != 2 * n * (Py_ssize_t)sizeof(double) || cb.len != db.len || start < 0 || start > n) {
        PyErr_SetString(PyExc_ValueError, "ring_amps: dc and c must hold len(t_ev) complex numbers");
        goto done;
    }
    const double *t = (const double *)tb.buf, *dc = (const double *)db.buf;
    double *c = (double *)cb.buf;
    start = ring_amps_run(t, dc, n, s, wd, span, short_n, start, carry.real, carry.imag, t_carry, c,
                          fused, m_t, m_t0, m_v, m_n, o_t0, o_v, 1);
    ret = PyLong_FromSsize_t(start);
done:
    ring_memo_release(&memo);
    PyBuffer_Release(&tb);
    PyBuffer_Release(&db);
    PyBuffer_Release(&cb);
    return ret;
}

/* ring_jumps(dr, drp, s, wd, out) -> False (out partly written) at a jump that is not
 * finite, else True: resonance.py's Oscillator.jump_amplitude,
 * dr - 1j (drp + s dr) / wd, as numpy makes it: x = drp + s dr, 1j x by its fused complex
 * product ((0 + 1i)(x + 0i)), the quotient by wd + 0i by its Smith division (ratio 0, scale
 * 1 / wd), then dr + 0i minus it.  out: len(dr) complex numbers.  resonance.py uses it only
 * after it gave numpy's bits on a probe. */
/* jump_amplitude into o (n complex numbers), as ring_jumps; checks: stop (returning 0) at a
 * jump that is not finite (ring_jumps); 0: none (ring_solve: such a jump's dc is not finite,
 * see there).  (The product and quotient by their steps, zeros and all: worked through to
 * fewer operations they were the same bits on hardware, but not under valgrind, whose fma
 * gives fma(0, x, -0) another zero's sign -- as it gives numpy's, which then differed from
 * the core's, and the probe left every chunk to the steps.) */
/* one jump_amplitude (dr, drp) into (*re, *im); rat, scl: the Smith division's scalars, as
 * ring_jumps_run makes them of wd (ring_solve's amplitudes make each event's as they go) */
static inline __attribute__((always_inline)) void
ring_jump_one(double dr, double drp, double s, double rat, double scl, double *re, double *im)
{
    double x = drp + s * dr;
    double zr, zi;
    ring_cmul(1, 0.0, 1.0, x, 0.0, &zr, &zi);
    double wr = (zr + zi * rat) * scl, wi = (zi - zr * rat) * scl;
    *re = dr - wr;
    *im = 0.0 - wi;
}

static inline __attribute__((always_inline)) int
ring_jumps_run(const double *dr, const double *drp, Py_ssize_t n, double s, double wd, double *o, int checks)
{
    double rat = 0.0 / wd, scl = 1.0 / (wd + 0.0 * rat);
    for (Py_ssize_t i = 0; i < n; i++) {
        if (checks && (!isfinite(dr[i]) || !isfinite(drp[i])))    /* NaN's bits are not copied */
            return 0;
        ring_jump_one(dr[i], drp[i], s, rat, scl, &o[2 * i], &o[2 * i + 1]);
    }
    return 1;
}

RING_CLONES static PyObject *mod_ring_jumps(PyObject *self, PyObject *args)
{
    Py_buffer rb, pb, ob;
    double s, wd;
    if (!PyArg_ParseTuple(args, "y*y*ddw*:ring_jumps", &rb, &pb, &s, &wd, &ob))
        return NULL;
    Py_ssize_t n = rb.len / (Py_ssize_t)sizeof(double);
    PyObject *ret = NULL;
    if (pb.len != rb.len || ob.len != 2 * rb.len) {
        PyErr_SetString(PyExc_ValueError, "ring_jumps: drp and out must match dr");
        goto done;
    }
    ret = PyBool_FromLong(ring_jumps_run((const double *)rb.buf, (const double *)pb.buf, n, s, wd,
                                         (double *)ob.buf, 1));
done:
    PyBuffer_Release(&rb);
    PyBuffer_Release(&pb);
    PyBuffer_Release(&ob);
    return ret;
}

/* ring_int_r2(c, dur, decay2, qr, qi, four_s, rat, scl, real_major, work): resonance.py's
 * float(Oscillator.integral_r2_fin(c, dur).sum()) with decay2 = np.exp(-2 s dur) made by
 * numpy: osc2 = exp((qr + i qi) dur) as ring_exp, y = (c c)(osc2 - 1) by numpy's complex
 * product (its fused loop, as ring_amps), |c| by numpy's complex absolute (its SIMD loop:
 * larger * sqrt(fma(r, r, 1)), r = smaller / larger), then |c|^2 (1 - decay2) / four_s plus
 * the real part of y / (4 lam) by _real_quotient's steps (rat, scl: its scalars;
 * real_major: its first branch), summed as numpy sums (work: n doubles of room).  None,
 * leaving the sum to numpy, where a number is not finite.  resonance.py uses it only after
 * it gave numpy's bits on a probe. */
/* ring_int_r2's memo (optional, its last five arguments): ts, the pieces' start times
 * (sorted); memo_ts, memo_dur, memo_v: another call's pieces, their lengths and (exp(qr dur),
 * cos(qi dur), sin(qi dur)) each; a piece here with the start and the length (bits) of one
 * there takes its numbers (the same argument: the same exponentials).  out_v (3 numbers a
 * piece, or None) receives this call's. */
/* The pieces' exponentials by their length: (exp(qr dur), cos(qi dur), sin(qi dur)) for
 * the last pieces of each length seen (a direct-mapped table on dur's bits, kept from call
 * to call for one (qr, qi)).  The plates' pieces are of few lengths (a move's ramps last
 * (v - v0) / a, the same for many moves): on the gyroid plate 83 % of the pieces whose
 * exponentials a chunk computed had a length an earlier piece of the chunk had.  The same
 * arguments give the same numbers, so a hit is what libm would give.  16 k slots, not 4 k:
 * with 4 k, lengths seen before lost their slot to others (plate_rectilinear's two ringing
 * passes: 202 k pieces took libm's exp and sincos, 0.27 G instructions of the table's
 * misses; 16 k: ~25 M fewer instructions in all; 32 k: no fewer).  512 kB a table.
 * Two ways a set (8 k sets of 2 slots, the one used last first), not one slot a length:
 * fewer lengths lose their slot to another that hashes alike (the plates' lookups replayed:
 * plate_gyroid 364 k -> 287 k misses, plate_rectilinear 162 k -> 102 k, the same memory;
 * measured with the amplitudes' first-event test gone: -1.2 M / -4.6 M instructions --
 * the memo served most of those misses already). */
typedef struct {
    uint64_t key;             /* dur's bits; RING_DUR_NONE: empty */
    double ex, cs, sn;
} RingDur;
#define RING_DUR_BITS 14
#define RING_DUR_SET_BITS (RING_DUR_BITS - 1)     /* two slots a set */
#define RING_DUR_NONE UINT64_MAX      /* a NaN's bits: never a (finite) length's */
/* The tables of the last two (qr, qi) asked for, the latest first: X's and Y's oscillators
 * where they differ (their streams alternate call by call), neither cleared by the other's
 * calls; a third pair takes the older one's room, cleared. */
typedef struct {
    void *slots;              /* NULL: none yet */
    uint64_t qr, qi;          /* the pair's bits */
} RingDurTable;
static RingDurTable ring_dur[2] = {{NULL, 0, 0}, {NULL, 0, 0}};

/* the table of tabs for (qr, qi) (made or cleared as needed: `entry` bytes a slot, a
 * uint64_t key then doubles), or NULL without memory; taken once a call, not once a piece */
static void *ring_table(RingDurTable tabs[2], double qr, double qi, size_t entry)
{
    uint64_t br, bi;
    memcpy(&br, &qr, sizeof br);
    memcpy(&bi, &qi, sizeof bi);
    for (int j = 0; j < 2; j++)
        if (tabs[j].slots != NULL && tabs[j].qr == br && tabs[j].qi == bi) {
            if (j == 1) {               /* (the latest first) */
                RingDurTable t = tabs[1];
                tabs[1] = tabs[0];
                tabs[0] = t;
            }
            return tabs[0].slots;
        }
    RingDurTable t = tabs[1];           /* the older one's room, or a new one */
    tabs[1] = tabs[0];
    if (t.slots == NULL)
        t.slots = PyMem_Malloc(entry << RING_DUR_BITS);
    tabs[0] = t;
    if (t.slots == NULL)
        return NULL;
    /* (an empty slot's numbers are NaN: a length whose bits are RING_DUR_NONE's -- a NaN
     * ring_solve does not test for before the table -- takes NaN from it, as from libm) */
    size_t words = entry / sizeof(uint64_t);
    uint64_t nan_bits, *w = t.slots;
    double nan_ = NAN;
    memcpy(&nan_bits, &nan_, sizeof nan_bits);
    for (size_t k = 0; k < ((size_t)1 << RING_DUR_BITS); k++, w += words) {
        w[0] = RING_DUR_NONE;
        for (size_t j = 1; j < words; j++)
            w[j] = nan_bits;
    }
    tabs[0].qr = br;
    tabs[0].qi = bi;
    return t.slots;
}

/* ring_int_r2_run's table for (qr, qi) */
static RingDur *ring_dur_table(double qr, double qi)
{
    return ring_table(ring_dur, qr, qi, sizeof(RingDur));
}

/* dur's set (its two slots) in a table of ring_dur_table */
static inline RingDur *ring_dur_set(RingDur *table, uint64_t d_bits)
{
    return table + 2 * ((d_bits * 0x9E3779B97F4A7C15ULL) >> (64 - RING_DUR_SET_BITS));
}

/* |c| as numpy's complex absolute (numpy's SIMD loop: larger * sqrt(fma(r, r, 1)), r = smaller / larger) */
static inline __attribute__((always_inline)) double ring_cabs(double cr, double ci)
{
    double ar = fabs(cr), ai = fabs(ci);
    double big = ar > ai ? ar : ai, small = ai < ar ? ai : ar;
    double ratio = big == 0.0 ? 0.0 : small / big;
    return sqrt(fma(ratio, ratio, 1.0)) * big;
}

/* integral_r2_fin's pieces (ring_int_r2's) into v: c, dur, decay2 (np.exp(-2 s dur)) of n
 * pieces starting at t_s (for the memo: m_*, m_n 0 none; o_v NULL: not kept); 0 where a
 * number is not finite. */
#define RING_ZERO_BIG 1e150       /* |Re c|, |Im c| below it: c^2 and |c|^2 are finite */

static inline __attribute__((always_inline)) int
ring_int_r2_run(const double *c, const double *dur, const double *decay2, Py_ssize_t n, double qr, double qi,
                double four_s, double rat, double scl, int real_major, const double *t_s, const double *m_t,
                const double *m_d, const double *m_v, Py_ssize_t m_n, double *o_v, double *v)
{
    int ok = 1;
    Py_ssize_t m_j = 0;
    RingDur *table = n > 0 ? ring_dur_table(qr, qi) : NULL;
    /* pieces of one length (0: events at one time) share exp and sincos: the previous
     * piece's and the last zero-length piece's are kept (same bits in, same out) */
    uint64_t d_prev = 0, zero_bits;
    double zero = 0.0;
    memcpy(&zero_bits, &zero, sizeof zero_bits);
    int have_prev = 0, have_zero = 0;
    double ex = 0.0, cs = 0.0, sn = 0.0, ex0 = 0.0, cs0 = 0.0, sn0 = 0.0;
    /* A piece of length +0 (events at one time: about half the pieces) whose exp(q 0) is
     * 1 + 0i and whose decay2 is 1 has v = +0 exactly for |c| below RING_ZERO_BIG: y = c^2
     * (osc2 - 1) is a complex zero (c^2 finite), q a zero (rat, scl finite), |c|^2 (1 -
     * 1) / four_s is +0 (four_s > 0), and +0 + (+-0) is +0.  zero_v: those scalars hold
     * (the exponentials are checked once made). */
    int zero_call = isfinite(rat) && isfinite(scl) && four_s > 0.0 && isfinite(four_s), zero_v = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        double t = dur[i], cr = c[2 * i], ci = c[2 * i + 1];
        if (!isfinite(t) || !isfinite(cr) || !isfinite(ci) || !isfinite(decay2[i])) {
            ok = 0;
            break;
        }
        uint64_t d_bits;
        memcpy(&d_bits, &t, sizeof d_bits);
        if (d_bits == zero_bits && zero_v) {       /* (zero_v: have_zero too) */
            /* (|Re c| + |Im c| below RING_ZERO_BIG: both are -- the rounded sum is not below
             * either; a piece it leaves out takes the general steps, the same +0) */
            if (fabs(cr) + fabs(ci) < RING_ZERO_BIG && decay2[i] == 1.0) {
                /* (d_prev, ex, cs, sn are left as they are, still a length and its exponentials:
                 * one instruction less here, about half the pieces; the next piece of another
                 * length goes to its lookup, of length zero here again) */
                if (o_v) {
                    o_v[3 * i] = ex0;
                    o_v[3 * i + 1] = cs0;
                    o_v[3 * i + 2] = sn0;
                }
                v[i] = 0.0;
                continue;
            }
            ex = ex0;
            cs = cs0;
            sn = sn0;
        } else if (have_zero && d_bits == zero_bits) {
            ex = ex0;
            cs = cs0;
            sn = sn0;
        } else if (!have_prev || d_bits != d_prev) {
            /* the table first (a lookup; it holds most lengths the memo would give: the memo's
             * stream filled it too), then the memo, then libm */
            RingDur *set = table != NULL ? ring_dur_set(table, d_bits) : NULL;
            if (set != NULL && set[0].key == d_bits) {
                ex = set[0].ex;
                cs = set[0].cs;
                sn = set[0].sn;
            } else if (set != NULL && set[1].key == d_bits) {
                ex = set[1].ex;
                cs = set[1].cs;
                sn = set[1].sn;
                set[1] = set[0];            /* (the one used last first) */
                set[0].key = d_bits;
                set[0].ex = ex;
                set[0].cs = cs;
                set[0].sn = sn;
            } else {
                int got = 0;
                if (m_n) {      /* the memo's piece from this start, of this length */
                    double ti = t_s[i];
                    while (m_j < m_n && m_t[m_j] < ti)
                        m_j++;
                    for (Py_ssize_t k = m_j; k < m_n && ring_same(m_t[k], ti); k++)
                        if (ring_same(m_d[k], t)) {
                            ex = m_v[3 * k];
                            cs = m_v[3 * k + 1];
                            sn = m_v[3 * k + 2];
                            got = 1;
                            break;
                        }
                }
                if (!got) {
                    double x = qr * t - qi * 0.0, y = qr * 0.0 + qi * t;
                    ex = ring_libm_exp(x);
                    ring_sincos(y, &sn, &cs);
                }
                if (set != NULL) {          /* (the set's older slot gives way) */
                    set[1] = set[0];
                    set[0].key = d_bits;
                    set[0].ex = ex;
                    set[0].cs = cs;
                    set[0].sn = sn;
                }
            }
            if (d_bits == zero_bits) {
                ex0 = ex;
                cs0 = cs;
                sn0 = sn;
                have_zero = 1;
                zero_v = zero_call && ex * cs - 1.0 == 0.0 && ex * sn - 0.0 == 0.0;
            }
        }
        d_prev = d_bits;
        have_prev = 1;
        if (o_v) {
            o_v[3 * i] = ex;
            o_v[3 * i + 1] = cs;
            o_v[3 * i + 2] = sn;
        }
        double c2r, c2i, yr, yi;
        ring_cmul(1, cr, ci, cr, ci, &c2r, &c2i);
        ring_cmul(1, c2r, c2i, ex * cs - 1.0, ex * sn - 0.0, &yr, &yi);
        double a = ring_cabs(cr, ci);
        double q = real_major ? (yr + yi * rat) * scl : (yr * rat + yi) * scl;
        v[i] = a * a * (1.0 - decay2[i]) / four_s + q;
    }
    return ok;
}

RING_CLONES static PyObject *mod_ring_int_r2(PyObject *self, PyObject *args)
{
    Py_buffer cb, db, eb, wb, sb;
    double qr, qi, four_s, rat, scl;
    int real_major;
    PyObject *ts = Py_None, *mt = Py_None, *md = Py_None, *mv = Py_None, *ov = Py_None;
    RingMemo memo;
    ring_exp_init();
    if (!PyArg_ParseTuple(args, "y*y*y*dddddpw*|OOOOO:ring_int_r2", &cb, &db, &eb, &qr, &qi, &four_s,
                          &rat, &scl, &real_major, &wb, &ts, &mt, &md, &mv, &ov))
        return NULL;
    Py_ssize_t n = db.len / (Py_ssize_t)sizeof(double);
    PyObject *ret = NULL;
    int have_ts = 0;
    memo.have_m = memo.have_o = 0;
    if (ts != Py_None) {
        if (PyObject_GetBuffer(ts, &sb, PyBUF_SIMPLE) < 0)
            goto fail;
        have_ts = 1;
        /* (the memo's out part: out_v, with ts as its times) */
        if (ring_memo_get(&memo, mt, md, mv, Py_None, Py_None, n, 3) < 0)
            goto fail;
        if (ov != Py_None) {
            if (PyObject_GetBuffer(ov, &memo.ov, PyBUF_WRITABLE) < 0)
                goto fail;
            memo.have_o = 2;        /* ov only (ring_memo_release: see below) */
        }
        if (sb.len != db.len || (memo.have_o && memo.ov.len != 3 * db.len)) {
            PyErr_SetString(PyExc_ValueError, "ring_int_r2: ts, out_v lengths");
            goto fail;
        }
    }
    const double *m_t = memo.have_m ? (const double *)memo.mt.buf : NULL;
    const double *m_d = memo.have_m ? (const double *)memo.mt0.buf : NULL;
    const double *m_v = memo.have_m ? (const double *)memo.mv.buf : NULL;
    Py_ssize_t m_n = memo.have_m ? memo.mt.len / (Py_ssize_t)sizeof(double) : 0;
    const double *t_s = have_ts ? (const double *)sb.buf : NULL;
    double *o_v = memo.have_o ? (double *)memo.ov.buf : NULL;
    if (cb.len != 2 * db.len || eb.len != db.len || wb.len != db.len) {
        PyErr_SetString(PyExc_ValueError, "ring_int_r2: c, dur, decay2, work of one length");
        goto done;
    }
    const double *c = (const double *)cb.buf, *dur = (const double *)db.buf;
    const double *decay2 = (const double *)eb.buf;
    double *v = (double *)wb.buf;
    int ok = ring_int_r2_run(c, dur, decay2, n, qr, qi, four_s, rat, scl, real_major, t_s, m_t, m_d, m_v, m_n,
                             o_v, v);
    if (ok)
        ret = PyFloat_FromDouble(-0.0 + np_pairwise_sum(v, n));
    else {
        ret = Py_None;
        Py_INCREF(ret);
    }
done:
    if (memo.have_o == 2) {
        PyBuffer_Release(&memo.ov);
        memo.have_o = 0;
    }
    ring_memo_release(&memo);
    if (have_ts)
        PyBuffer_Release(&sb);
    PyBuffer_Release(&cb);
    PyBuffer_Release(&db);
    PyBuffer_Release(&eb);
    PyBuffer_Release(&wb);
    return ret;
fail:
    ret = NULL;
    goto done;
}

/* |np.real(c * np.exp(lam * t))| (lam = lr + i li, t real): libm's exp, cos, sin */
static inline __attribute__((always_inline)) double
ring_re_abs(double cr, double ci, double lr, double li, double t)
{
    double ex = ring_libm_exp(lr * t), cs, sn;
    ring_sincos(li * t, &sn, &cs);
    return fabs(cr * (ex * cs) - ci * (ex * sn));
}

static inline double ring_npmax(double a, double b)     /* np.maximum(a, b) */
{
    return (a >= b || a != a) ? a : b;
}

/* np.mod(a, b) for b > 0 (numpy's npy_remainder: fmod, then the sign of b) */
static inline double ring_npmod(double a, double b)
{
    double mod = fmod(a, b);
    if (mod != 0.0) {
        if ((b < 0) != (mod < 0))
            mod += b;
    } else
        mod = copysign(0.0, b);
    return mod;
}

/* Oscillator.peak_abs_r of one piece (c, finite d): the largest of |Re c|, the end's |r|
 * and, if it is inside, the first extremum's (phi = np.angle(lam c), tau = np.mod(pi / 2 -
 * phi, pi) / wd) */
static inline __attribute__((always_inline)) double
ring_peak_one(double cr, double ci, double d, double lr, double li, double wd)
{
    double best = fabs(cr);
    double end = ring_re_abs(cr, ci, lr, li, d);
    best = ring_npmax(best, end);
    double phi = atan2(lr * ci + li * cr, lr * cr - li * ci);
    double tau = ring_npmod(0.5 * M_PI - phi, M_PI) / wd;
    double ext = tau < d ? ring_re_abs(cr, ci, lr, li, tau) : 0.0;
    return ring_npmax(best, ext);
}

/* ring_solve's steps: the tables of its pieces' numbers by their length d (bits), kept from
 * call to call for one oscillator (-s, wd): E = exp(lam d) (the amplitude's step across the
 * piece, by libm's exp and sincos as numpy's complex exp takes them), and the piece's r^2
 * integral as a quadratic form in its amplitude c: int_0^d |Re(c e^(lam u))|^2 du =
 * |c|^2 a + Re(c^2 w), a = (1 - exp(-2 s d)) / (4 s), w = (exp(2 lam d) - 1) / (4 lam)
 * (integral_r2_fin's formula, its scalars made once a length, not once a piece).  The
 * plates' pieces are of few lengths (a move's ramps last (v - v0) / a, the same for many
 * moves): most pieces find theirs in the table, filled by the streams before (X's and
 * Y's, the parts: one oscillator). */
typedef struct {
    uint64_t key;             /* d's bits; RING_DUR_NONE: empty */
    double er, ei, a, wr, wi;
} RingStep;
static RingDurTable ring_step[2] = {{NULL, 0, 0}, {NULL, 0, 0}};

/* the oscillator's constants for its steps: lam = lr + i li, q = 2 lam (qr, qi), four_s;
 * the division by 4 lam by Smith's method (rat, scl; real_major: its first branch) */
typedef struct {
    double lr, li, qr, qi, four_s, rat, scl;
    int real_major;
} RingStepK;

/* e's numbers for length d (libm's exp, sincos) */
static __attribute__((noinline)) void ring_step_make(RingStep *e, double d, const RingStepK *k)
{
    double ex = ring_libm_exp(k->lr * d), cs, sn;
    ring_sincos(k->li * d, &sn, &cs);
    e->er = ex * cs;
    e->ei = ex * sn;
    double ex2 = ring_libm_exp(k->qr * d), cs2, sn2;
    ring_sincos(k->qi * d, &sn2, &cs2);
    double yr = ex2 * cs2 - 1.0, yi = ex2 * sn2;
    e->a = (1.0 - ex2) / k->four_s;
    if (k->real_major) {
        e->wr = (yr + yi * k->rat) * k->scl;
        e->wi = (yi - yr * k->rat) * k->scl;
    } else {
        e->wr = (yr * k->rat + yi) * k->scl;
        e->wi = (yi * k->rat - yr) * k->scl;
    }
}

/* the numbers of length d (bits d_bits): its set's slot, made on a miss (two slots a set,
 * the one used last first) */
static inline __attribute__((always_inline)) const RingStep *
ring_step_get(RingStep *table, double d, uint64_t d_bits, const RingStepK *k)
{
    RingStep *set = table + 2 * ((d_bits * 0x9E3779B97F4A7C15ULL) >> (64 - RING_DUR_SET_BITS));
    if (set[0].key == d_bits)
        return set;
    RingStep old = set[0];
    if (set[1].key == d_bits)
        set[0] = set[1];
    else {
        set[0].key = d_bits;
        ring_step_make(set, d, k);
    }
    set[1] = old;
    return set;
}

/* max_abs_r's pieces, found while ring_solve_run has each piece's |c| at hand: floor, the
 * caller's peak so far; lo, np.abs(c.real).max() over the pieces; idx[0..n), the pieces
 * whose |c| (1 + 1e-9) may not be below max(floor, lo) so far, in order, as their amplitude
 * and length (not every event's: few are candidates) -- the pieces max_abs_r keeps (not
 * below max(floor, lo)) are among them: lo only grows; the last event's amplitude. */
typedef struct {
    double floor, lo;
    double *pc;               /* each candidate's c (re, im) and length: 3 doubles */
    Py_ssize_t n;
    double last_r, last_i;    /* the last event's amplitude */
} RingCand;

/* _Stream._solve's amplitudes and pieces in one pass: c_0 the carried amplitude (fr, fi;
 * off 1) or event 0's jump, then c_i = c_(i-1) exp(lam d) + dc_i over each piece of length
 * d = t[i] - t[i-1], dc_i = jump_amplitude(dr[i - off], drp[i - off]) = dr - i (drp + s dr)
 * / wd: the recursion of Oscillator.amplitudes' sum (each step decays, so its rounding
 * stays relative to what still rings, without restarts); each piece's r^2 integral into v
 * (none for pieces of length +0, events at one time -- 42 % of the plates': 0), its length
 * into dur, max_abs_r's candidates into cand.  Plain double arithmetic (no fused
 * multiply-add: the same numbers on any x86-64).  Returns the number of integrals in v. */
static __attribute__((noinline)) Py_ssize_t
ring_solve_run(const double *t, const double *dr, const double *drp, int off, double fr, double fi, Py_ssize_t n,
               double s, double wd, RingStep *table, const RingStepK *k, double *v, RingCand *cand)
{
    double inv_wd = 1.0 / wd, cr = fr, ci = fi, lo = 0.0, c_floor = cand->floor;
    Py_ssize_t nv = 0;
    double *pc = cand->pc;
    if (!off) {
        cr = dr[0];
        ci = -((drp[0] + s * dr[0]) * inv_wd);
    }
    for (Py_ssize_t i = 1; i < n; i++) {
        double d = t[i] - t[i - 1];
        uint64_t d_bits;
        memcpy(&d_bits, &d, sizeof d_bits);
        double ar = fabs(cr);
        lo = ar > lo ? ar : lo;
        if (d_bits != 0) {
            /* (a piece of length +0 has no integral, and its peak, |Re c|, is in lo: no
             * candidate; exp(lam 0) is 1) */
            const RingStep *e = ring_step_get(table, d, d_bits, k);
            double n2 = cr * cr + ci * ci, c2r = cr * cr - ci * ci, c2i = 2.0 * cr * ci;
            v[nv++] = n2 * e->a + (c2r * e->wr - c2i * e->wi);
            /* a candidate while |c| (1 + 1e-9) may not be below max(floor, lo) -- |c|^2 with
             * a margin over its rounding (mod_ring_solve tests |c| itself); NaN kept */
            double thr = c_floor > lo ? c_floor : lo;
            if (!(n2 * (1.0 + 4e-9) < thr * thr)) {
                pc[0] = cr;
                pc[1] = ci;
                pc[2] = d;
                pc += 3;
            }
            double pr = cr * e->er - ci * e->ei, pi = cr * e->ei + ci * e->er;
            cr = pr;
            ci = pi;
        }
        double x = drp[i - off] + s * dr[i - off];
        cr = cr + dr[i - off];
        ci = ci - x * inv_wd;
    }
    cand->lo = lo;
    cand->n = (pc - cand->pc) / 3;
    cand->last_r = cr;
    cand->last_i = ci;
    return nv;
}

/* ring_solve(t, dr, drp, first, s, wd, qr, qi, four_s, rat, scl, real_major[, floor]):
 * ringing.py's _Stream._solve in one pass: the events' amplitudes (Oscillator.
 * jump_amplitude of dr, drp; after the carried amplitude `first` at t[0], a complex, when
 * it is not None) by the recursion of ring_solve_run, the sum of the pieces' r^2 integrals
 * (integral_r2_fin's; qr, qi: 2 lam; four_s, rat, scl, real_major: resonance._int_r2_args')
 * and max_abs_r (the peak of the pieces where |c| (1 + 1e-9) is not below the largest
 * |Re c|).  The figures of numpy's steps (Oscillator.amplitudes' restarts of a cumulative
 * sum) to rounding, not their bits.  Returns None where a number is not finite (the
 * caller's steps), else (sum or None, peak or None (one event: no piece), the last
 * amplitude).  floor (0.0 if not given): a peak the caller already has (of earlier
 * chunks); pieces whose |c| (1 + 1e-9) is below it are ruled out too (|r| <= |c| on a
 * piece: they cannot raise the caller's max; the peak returned may then be below floor). */
static double *ring_scratch = NULL;          /* ring_solve's room */
static size_t ring_scratch_n = 0;

/* ring_solve's work on n events t (C doubles), the jumps dr, drp (n - off of them, off 1
 * where first is not None: the carried amplitude at t[0]): its return value, or NULL with
 * an exception set */
static PyObject *ring_solve_events(const double *t, const double *dr, const double *drp, Py_ssize_t n,
                                   PyObject *first, double s, double wd, double qr, double qi, double four_s,
                                   double rat, double scl, int real_major, double floor_)
{
    PyObject *ret = NULL;
    int off = first != Py_None;
    double fr = 0.0, fi = 0.0;
    if (off) {
        Py_complex z = PyComplex_AsCComplex(first);
        if (z.real == -1.0 && PyErr_Occurred())
            return NULL;
        fr = z.real;
        fi = z.imag;
    }
    if (n == 0)
        Py_RETURN_NONE;
    Py_ssize_t np_ = n - 1;                      /* pieces */
    /* room kept from call to call (fresh memory costs a page fault a page; the GIL is held) */
    /* (the room a past layout took -- 4 n + 3 pieces, where 4 pieces are written at most:
     * with a smaller room plate_rectilinear's peak RSS rose by 1 MB, the heap's layout; the
     * room past what is written is never touched) */
    size_t need = 4 * (size_t)n + 3 * (size_t)np_ + 1;
    if (need > ring_scratch_n) {
        size_t want = need + need / 8;     /* (the next chunk's few more events) */
        double *p = PyMem_Realloc(ring_scratch, sizeof(double) * want);
        if (p == NULL)
            return PyErr_NoMemory();
        ring_scratch = p;
        ring_scratch_n = want;
    }
    RingStep *table = ring_table(ring_step, -s, wd, sizeof(RingStep));
    if (table == NULL)
        return PyErr_NoMemory();
    /* (the pieces' integrals, then max_abs_r's candidates: 3 doubles each) */
    double *v = ring_scratch;
    RingCand cand = {floor_, 0.0, v + np_, 0, 0.0, 0.0};
    /* No number is tested for being finite on the way: one that is not (in t, dr, drp,
     * first, or made from them) gives an amplitude that is not finite from its event on
     * (the recursion carries it: a NaN stays one, and inf times a step of 0 is NaN), so
     * the last amplitude is not finite.  It is tested once at the end, and the sum: None
     * (the caller's steps) then.  (A finite sum can overflow too: the caller's steps then
     * give that same sum.) */
    const RingStepK k = {-s, wd, qr, qi, four_s, rat, scl, real_major};
    Py_ssize_t nv = ring_solve_run(t, dr, drp, off, fr, fi, n, s, wd, table, &k, v, &cand);
    double c_last_r = cand.last_r, c_last_i = cand.last_i;
    if (!isfinite(c_last_r) || !isfinite(c_last_i))
        Py_RETURN_NONE;
    PyObject *sum = NULL, *peak = NULL;
    if (np_ > 0) {
        double total = -0.0 + np_pairwise_sum(v, nv);
        if (!isfinite(total))
            Py_RETURN_NONE;
        /* max_abs_r: lo = np.abs(c.real).max(); the pieces it solves, |c| (1 + 1e-9) not below
         * lo, nor below `floor` (a peak the caller already has: a piece below it cannot
         * raise its max), are those of the candidates; np.maximum */
        double lo = cand.lo;
        double thr = floor_ > lo ? floor_ : lo;
        Py_ssize_t kk = 0;
        double *pc = cand.pc;
        for (Py_ssize_t j = 0; j < cand.n; j++) {
            const double *q = pc + 3 * j;
            if (!(ring_cabs(q[0], q[1]) * (1.0 + 1e-9) < thr)) {
                memmove(pc + 3 * kk, q, 3 * sizeof(double));
                kk++;
            }
        }
        sum = PyFloat_FromDouble(total);
        if (sum == NULL)
            return NULL;
        double pk = 0.0;
        for (Py_ssize_t j = 0; j < kk; j++) {
            const double *q = pc + 3 * j;
            double p = ring_peak_one(q[0], q[1], q[2], -s, wd, wd);
            pk = j == 0 || p > pk ? p : pk;
        }
        peak = PyFloat_FromDouble(kk > 0 ? ring_npmax(lo, pk) : lo);
    } else {
        sum = Py_None;
        Py_INCREF(sum);
        peak = Py_None;
        Py_INCREF(peak);
    }
    if (sum == NULL || peak == NULL) {
        Py_XDECREF(sum);
        Py_XDECREF(peak);
        return NULL;
    }
    ret = Py_BuildValue("NND", sum, peak, &(Py_complex){c_last_r, c_last_i});
    return ret;
}

static PyObject *mod_ring_solve(PyObject *self, PyObject *args)
{
    Py_buffer tb, rb, pb;
    PyObject *first;
    double s, wd, qr, qi, four_s, rat, scl;
    int real_major;
    double floor_ = 0.0;
    ring_exp_init();
    if (!PyArg_ParseTuple(args, "y*y*y*Odddddddp|d:ring_solve", &tb, &rb, &pb, &first, &s, &wd, &qr, &qi,
                          &four_s, &rat, &scl, &real_major, &floor_))
        return NULL;
    PyObject *ret = NULL;
    Py_ssize_t n = tb.len / (Py_ssize_t)sizeof(double);
    int off = first != Py_None;
    if (rb.len != pb.len || rb.len != (n - off) * (Py_ssize_t)sizeof(double) || n - off < 0)
        PyErr_SetString(PyExc_ValueError, "ring_solve: dr, drp must hold len(t) (less the carried one) numbers");
    else
        ret = ring_solve_events((const double *)tb.buf, (const double *)rb.buf, (const double *)pb.buf, n, first,
                                s, wd, qr, qi, four_s, rat, scl, real_major, floor_);
    PyBuffer_Release(&tb);
    PyBuffer_Release(&rb);
    PyBuffer_Release(&pb);
    return ret;
}

/* Elementwise loops in vector clones where gcc makes them (glibc's ifunc picks the clone at
 * load time): each lane does its element's operation, the same bits as one at a time; no
 * early exit, so a loop of tests is vectorized too (the numbers are in cache: reading all of
 * them costs less than a branch each) */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__GLIBC__)
#define RING_VEC __attribute__((target_clones("avx2", "default"), \
                                optimize("O3", "no-trapping-math", "fp-contract=off"), noinline))
#else
#define RING_VEC
#endif

/* t[0..n) += 0.0 (-0.0 made 0.0: add's t + 0.0, in place) */
RING_VEC static void ring_add_zero(double *t, Py_ssize_t n)
{
    for (Py_ssize_t i = 0; i < n; i++)
        t[i] += 0.0;
}

/* (t[:-1] <= t[1:]).all() of t[0..n): in order, no NaN (n < 2: true) */
RING_VEC static int ring_in_order(const double *t, Py_ssize_t n)
{
    int ok = 1;
    for (Py_ssize_t i = 0; i + 1 < n; i++)
        ok &= t[i] <= t[i + 1];
    return ok;
}

/* numpy's less-than of doubles in its sorts and searches: NaN after every number */
static inline int ring_np_lt(double a, double b)
{
    return a < b || (b != b && a == a);
}

/* ring_join(t1, dr1, drp1, has_last, nw, horizon, first, floor, s, wd, qr, qi, four_s, rat,
 * scl, real_major): ringing._Stream.add_joined's steps where the stream's events need no
 * shaping, in one call.  t1 (doubles, written): the carried time (has_last) and the nw
 * waiting events, then the new ones; dr1, drp1: the waiting and the new events' jumps.
 * Adds 0.0 to the new times (add's t + 0.0, in place); if the times after the carried one
 * are not in order (<=, as numpy compares them) returns None, the rest undone (the caller's
 * own steps: they sort).  Else k, the events before horizon (np.searchsorted(..., "left")),
 * and, where k > 0, ring_solve's result for t1[:has_last + k], dr1[:k], drp1[:k] (None:
 * the caller's steps then, as for ring_solve); (k, result or None if k == 0).  None too,
 * nothing done, where an array is not a contiguous one of doubles (t1 writable): the
 * caller's steps take any. */
static int ring_doubles(PyObject *o, Py_buffer *b, int writable)
{
    if (PyObject_GetBuffer(o, b, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0)) < 0) {
        PyErr_Clear();
        return 0;
    }
    if (b->itemsize != (Py_ssize_t)sizeof(double) || b->format == NULL || strcmp(b->format, "d") != 0) {
        PyBuffer_Release(b);
        return 0;
    }
    return 1;
}

static PyObject *mod_ring_join(PyObject *self, PyObject *args)
{
    PyObject *to, *ro, *po, *first;
    Py_ssize_t has_last, nw;
    double horizon, floor_, s, wd, qr, qi, four_s, rat, scl;
    int real_major;
    ring_exp_init();
    if (!PyArg_ParseTuple(args, "OOOnndOddddddddp:ring_join", &to, &ro, &po, &has_last, &nw, &horizon, &first,
                          &floor_, &s, &wd, &qr, &qi, &four_s, &rat, &scl, &real_major))
        return NULL;
    Py_buffer tb, rb, pb;
    int got_t = ring_doubles(to, &tb, 1), got_r = got_t && ring_doubles(ro, &rb, 0),
        got_p = got_r && ring_doubles(po, &pb, 0);
    PyObject *ret = NULL;
    if (!got_p) {                                 /* (not arrays of doubles: the caller's steps) */
        ret = Py_None;
        Py_INCREF(ret);
        goto done;
    }
    Py_ssize_t n1 = tb.len / (Py_ssize_t)sizeof(double), m = rb.len / (Py_ssize_t)sizeof(double);
    if (rb.len != pb.len || (has_last != 0 && has_last != 1) || (has_last == 1) != (first != Py_None) || nw < 0
        || n1 != has_last + m || nw > m) {
        PyErr_SetString(PyExc_ValueError, "ring_join: t1 must hold the carried time and dr1's events");
        goto done;
    }
    double *t1 = (double *)tb.buf, *t_all = t1 + has_last;
    ring_add_zero(t1 + has_last + nw, n1 - has_last - nw);
    if (!ring_in_order(t_all, m)) {               /* (not in order, or a NaN) */
        ret = Py_None;
        Py_INCREF(ret);
        goto done;
    }
    Py_ssize_t lo = 0, hi = m;                    /* the first event not before horizon */
    while (lo < hi) {
        Py_ssize_t mid = lo + (hi - lo) / 2;
        if (ring_np_lt(t_all[mid], horizon))
            lo = mid + 1;
        else
            hi = mid;
    }
    PyObject *got = Py_None;
    Py_INCREF(got);
    if (lo > 0) {
        Py_DECREF(got);
        got = ring_solve_events(t1, (const double *)rb.buf, (const double *)pb.buf, has_last + lo, first, s, wd, qr,
                                qi, four_s, rat, scl, real_major, floor_);
        if (got == NULL)
            goto done;
    }
    ret = Py_BuildValue("nN", lo, got);
done:
    if (got_t)
        PyBuffer_Release(&tb);
    if (got_r)
        PyBuffer_Release(&rb);
    if (got_p)
        PyBuffer_Release(&pb);
    return ret;
}

/* ring_events' state from piece to piece: the carry (t, the cumulative sum of the pieces'
 * lengths, vel_end, acc), each axis' and part's count and outputs, w^2 of each axis */
typedef struct {
    double c_t, cs, pvx, pvy, pax, pay;
    Py_ssize_t cnt[2][4];
    double *T[2][4], *DR[2][2], *DP[2][3];
    double w2[2];
} RingEv;

/* a != 0.0 || b != 0.0 (zeros of both signs: false; NaN: true), by their bits: an OR and a
 * shift of two words, not two compares and their parity flags (ring_events_axis' "all" test
 * where no part needs ramp and jump apart) */
static inline int ring_either_nonzero(double a, double b)
{
    uint64_t x, y;
    memcpy(&x, &a, sizeof x);
    memcpy(&y, &b, sizeof y);
    return ((x | y) << 1) != 0;
}

/* one axis' events of a piece starting at t0: dr = da / w^2 (da = acc - the piece before's),
 * drp = -dv; cls (the piece's junction: 1 corner, 2 turn, 0 none -- not a block's first piece) */
static inline __attribute__((always_inline)) void
ring_events_axis(RingEv *e, int x, double t0, double acc, double pa, double dv, int cls, int all_only)
{
    double dr = (acc - pa) / e->w2[x], drp = -dv;
    int ramp = dr != 0.0, jump = drp != 0.0;
    if (all_only ? ring_either_nonzero(dr, drp) : ramp || jump) {
        Py_ssize_t j = e->cnt[x][0]++;
        e->T[x][0][j] = t0;
        e->DR[x][0][j] = dr;
        e->DP[x][0][j] = drp;
    }
    if (all_only)
        return;
    if (ramp) {
        Py_ssize_t j = e->cnt[x][1]++;
        e->T[x][1][j] = t0;
        e->DR[x][1][j] = dr;
    }
    if (jump && (cls == 1 || cls == 2)) {
        int part = cls == 1 ? 2 : 3;
        Py_ssize_t j = e->cnt[x][part]++;
        e->T[x][part][j] = t0;
        e->DP[x][part - 1][j] = drp;
    }
}

/* one piece of a row (jumping: its block's first, the velocity jumps there; first: the
 * chunk's first piece) of length dur, speed and tangential acceleration ta at its start,
 * along (ux, uy): _pieces' t0 (c.t + the pieces before's cumulative sum), vel, acc, dv, da,
 * end speed, each by numpy's operations */
static inline __attribute__((always_inline)) void
ring_events_piece(RingEv *e, int jumping, int first, double dur, double speed, double ta, double ux,
                  double uy, int cls, int all_only)
{
    /* t0 = c.t + concatenate([[0.0], cs[:-1]]) */
    double t0 = e->c_t + (first ? 0.0 : e->cs);
    e->cs = first ? dur : e->cs + dur;
    RING_OPAQUE(ta);
    double es = speed + ta * dur;          /* end_speed = speed + tan_a * dur */
    double ax = ta * ux, ay = ta * uy;
    /* (dv: vel - the piece before's vel_end where a block or a rest begins, else 0) */
    ring_events_axis(e, 0, t0, ax, e->pax, jumping ? speed * ux - e->pvx : 0.0, cls, all_only);
    ring_events_axis(e, 1, t0, ay, e->pay, jumping ? speed * uy - e->pvy : 0.0, cls, all_only);
    e->pvx = es * ux;                      /* vel_end = end_speed * u */
    e->pvy = es * uy;
    e->pax = ax;
    e->pay = ay;
}

/* the rows' pieces (accelerate, cruise, decelerate) and their events; (pux, puy, pisb): the
 * row before's direction and is_block, moved to the last row's */
static inline __attribute__((always_inline)) void
ring_events_rows(RingEv *e, const double *m, Py_ssize_t rows, double corner_cos, double *pux_, double *puy_,
                 double *pisb_, int all_only)
{
    double pux = *pux_, puy = *puy_, pisb = *pisb_;
    for (Py_ssize_t r = 0; r < rows; r++) {
        const double *q = m + 12 * r;
        double ux = q[0], uy = q[1], sv = q[2], cv = q[3], a = q[5];
        double after = q[9], isb = q[11];
        /* a junction is a gentle turn when both blocks move and it turns < 30 degrees */
        double cos_turn = ux * pux + uy * puy;
        int moving = isb > 0 && pisb > 0 && after == 0;
        int cls = moving && cos_turn >= corner_cos ? 2 : 1;      /* TURN : CORNER */
        ring_events_piece(e, 1, r == 0, q[6], sv, a, ux, uy, cls, all_only);
        ring_events_piece(e, 0, 0, q[7], cv, 0.0 * a, ux, uy, 0, all_only);
        ring_events_piece(e, 0, 0, q[8], cv, -a, ux, uy, 0, all_only);
        pux = ux;
        puy = uy;
        pisb = isb;
    }
    *pux_ = pux;
    *puy_ = puy;
    *pisb_ = pisb;
}

/* ring_events(m, c_t, c_vx, c_vy, c_ax, c_ay, c_ux, c_uy, c_isb, w2x, w2y, corner_cos,
 * t_out, dr_out, drp_out): ringing.py's _pieces (without positions) of the rows m (12
 * doubles a row) following on from the carry (its t, vel_end, acc, ux, uy, isb), and
 * Collector._flush's events of each axis and part from them, in one pass: every number by
 * the same operations as the numpy code, in its order (plain double arithmetic, no fused
 * multiply-add: setup.py's flags; this function has no FMA clone).  Per axis (x: 0, y: 1)
 * the events of "all" (dr = da / w2 != 0 or drp = -dv != 0), "ramp" (dr != 0), "corner"
 * and "turn" (drp != 0 at a junction of that class): times into t_out (8 n doubles an axis:
 * all at 0, ramp at 3n, corner at 6n, turn at 7n; n rows), dr of all and ramp into dr_out
 * (6 n an axis: 0, 3n), drp of all, corner and turn into drp_out (5 n an axis: 0, 3n, 4n).
 * Returns (counts: 8 ints, x's four parts then y's, the new carry: t, vel_end x, y, acc x,
 * y, ux, uy, isb).  all_only (optional, false if not given): "all"'s events only (the
 * other parts' counts 0, their outputs not written: a Collector without the parts).
 * front (optional, 0 if not given): doubles left unwritten before each output (t_out
 * 16 n + 8 front: axis a's all, ramp, corner, turn at a (8 n + 4 front) + front, + 3 n +
 * front, + 6 n + 2 front, + 7 n + 3 front; dr_out 12 n + 4 front: all, ramp at a (6 n + 2
 * front) + front, + 3 n + front; drp_out 10 n + 6 front: all, corner, turn at a (5 n + 3
 * front) + front, + 3 n + front, + 4 n + 2 front): the caller puts each stream's events
 * that wait from the chunk before (and its carried time) in front of its new ones, which
 * then need no concatenation (Collector._flush). */
static PyObject *mod_ring_events(PyObject *self, PyObject *args)
{
    Py_buffer mb, tb, rb, pb;
    double c_t, pvx, pvy, pax, pay, pux, puy, pisb, w2[2], corner_cos;
    int all_only = 0;
    Py_ssize_t front = 0;
    if (!PyArg_ParseTuple(args, "y*dddddddddddw*w*w*|pn:ring_events", &mb, &c_t, &pvx, &pvy, &pax, &pay,
                          &pux, &puy, &pisb, &w2[0], &w2[1], &corner_cos, &tb, &rb, &pb, &all_only, &front))
        return NULL;
    PyObject *ret = NULL;
    Py_ssize_t rows = mb.len / (Py_ssize_t)(12 * sizeof(double));
    const Py_ssize_t d = (Py_ssize_t)sizeof(double);
    if (front < 0 || mb.len != rows * 12 * d || tb.len != (16 * rows + 8 * front) * d
        || rb.len != (12 * rows + 4 * front) * d || pb.len != (10 * rows + 6 * front) * d) {
        PyErr_SetString(PyExc_ValueError, "ring_events: m is not whole rows, or the outputs' lengths");
        goto done;
    }
    const double *m = (const double *)mb.buf;
    double *t_out = (double *)tb.buf, *dr_out = (double *)rb.buf, *drp_out = (double *)pb.buf;
    Py_ssize_t n = rows;
    RingEv e = {.c_t = c_t, .cs = 0.0, .pvx = pvx, .pvy = pvy, .pax = pax, .pay = pay,
                .w2 = {w2[0], w2[1]}};
    for (int a = 0; a < 2; a++) {
        for (int k = 0; k < 4; k++)
            e.cnt[a][k] = 0;
        e.T[a][0] = t_out + a * (8 * n + 4 * front) + front;
        e.T[a][1] = e.T[a][0] + 3 * n + front;
        e.T[a][2] = e.T[a][0] + 6 * n + 2 * front;
        e.T[a][3] = e.T[a][0] + 7 * n + 3 * front;
        e.DR[a][0] = dr_out + a * (6 * n + 2 * front) + front;
        e.DR[a][1] = e.DR[a][0] + 3 * n + front;
        e.DP[a][0] = drp_out + a * (5 * n + 3 * front) + front;
        e.DP[a][1] = e.DP[a][0] + 3 * n + front;
        e.DP[a][2] = e.DP[a][0] + 4 * n + 2 * front;
    }
    /* (each a loop of its own: the parts' tests drop out of "all"'s) */
    if (all_only)
        ring_events_rows(&e, m, rows, corner_cos, &pux, &puy, &pisb, 1);
    else
        ring_events_rows(&e, m, rows, corner_cos, &pux, &puy, &pisb, 0);
    double t_end = rows ? c_t + e.cs : c_t;
    Py_ssize_t (*cnt)[4] = e.cnt;
    pvx = e.pvx;
    pvy = e.pvy;
    pax = e.pax;
    pay = e.pay;
    ret = Py_BuildValue("(nnnnnnnn)dddddddd", cnt[0][0], cnt[0][1], cnt[0][2], cnt[0][3], cnt[1][0], cnt[1][1],
                        cnt[1][2], cnt[1][3], t_end, pvx, pvy, pax, pay, pux, puy, pisb);
done:
    PyBuffer_Release(&mb);
    PyBuffer_Release(&tb);
    PyBuffer_Release(&rb);
    PyBuffer_Release(&pb);
    return ret;
}

/* ring_rows_time(m, r0, r1): float(m[r0:r1, 6:9].sum()) for rows m of 12 doubles
 * (Collector._flush's time of the rows' pieces), summed as numpy sums that strided view:
 * its buffered reduction copies the values a row at a time (~60 instructions a row) into
 * a buffer of 8190 (its 8192 cut to whole rows of 3) and adds each buffer's pairwise sum,
 * in order, to 0.0.  ringing._rows_time checks it against numpy once a process. */
#define RING_ROWS_BUF 8190
_Static_assert(RING_ROWS_BUF % 3 == 0, "ring_rows_time fills its buffer 3 values at a time");
static double ring_rows_buf[RING_ROWS_BUF];

static PyObject *mod_ring_rows_time(PyObject *self, PyObject *args)
{
    Py_buffer mb;
    Py_ssize_t r0, r1;
    if (!PyArg_ParseTuple(args, "y*nn:ring_rows_time", &mb, &r0, &r1))
        return NULL;
    Py_ssize_t rows = mb.len / (Py_ssize_t)(12 * sizeof(double));
    if (mb.len != rows * 12 * (Py_ssize_t)sizeof(double) || r0 < 0 || r1 > rows) {
        PyBuffer_Release(&mb);
        PyErr_SetString(PyExc_ValueError, "ring_rows_time: m is not whole rows, or r0, r1 out of them");
        return NULL;
    }
    const double *m = (const double *)mb.buf;
    double total = 0.0;
    Py_ssize_t k = 0;
    for (Py_ssize_t r = r0; r < r1; r++) {
        const double *q = m + 12 * r + 6;
        ring_rows_buf[k] = q[0];
        ring_rows_buf[k + 1] = q[1];
        ring_rows_buf[k + 2] = q[2];
        k += 3;
        if (k == RING_ROWS_BUF) {
            total += np_pairwise_sum(ring_rows_buf, k);
            k = 0;
        }
    }
    if (k)
        total += np_pairwise_sum(ring_rows_buf, k);
    PyBuffer_Release(&mb);
    return PyFloat_FromDouble(total);
}

/* use_reader(capsule or None): the reader's fused loop for play(); False (not used) if
 * its layout is not this core's */
static PyObject *mod_use_reader(PyObject *self, PyObject *cap)
{
    if (cap == Py_None) {
        READER = NULL;
        Py_CLEAR(READER_CAPSULE);
        Py_RETURN_FALSE;
    }
    const ReaderAPI *api = PyCapsule_GetPointer(cap, "_gcode_opt_reader._C_API");
    if (api == NULL)
        return NULL;
    if (strcmp(api->layout, FUSED_LAYOUT) != 0 || api->move_size != sizeof(FusedMove)
        || api->run_move_size != sizeof(RunMove)) {
        READER = NULL;
        Py_CLEAR(READER_CAPSULE);
        Py_RETURN_FALSE;
    }
    Py_INCREF(cap);
    Py_XSETREF(READER_CAPSULE, cap);
    READER = api;
    Py_RETURN_TRUE;
}

/* ---------------------------------------------------------------- plan._allocate's choices
 * least_pair: one row's choice at lam among its w costs I[c] + lam * T[c] (one product, then one sum:
 * numpy's two ufuncs) and then the last, i_last + lam * t_last, in that order: j = the first least
 * (a later one replaces it only where strictly less), *least = c1 its cost, *second = c2 the least of
 * the others (the least again on a tie; never NaN: a NaN cost is passed over, but at c = 0, where it
 * stays c1).  Returns j (w: the last).
 * least_two: least_pair, and *margin = inf where c2 is inf else c2 - c1, *tol = margin_r (|c1| + |c2|). */
static inline Py_ssize_t least_pair(const double *T, const double *I, Py_ssize_t w, double t_last, double i_last,
                                    double lam, double *least, double *second)
{
    double c1 = w > 0 ? I[0] + lam * T[0] : i_last + lam * t_last, c2 = INFINITY;
    Py_ssize_t j = 0;
    for (Py_ssize_t c = 1; c <= w; c++) {
        double x = c < w ? I[c] + lam * T[c] : i_last + lam * t_last;
        if (x < c1) {
            c2 = c1;
            c1 = x;
            j = c;
        } else if (x < c2) {
            c2 = x;
        }
    }
    *least = c1;
    *second = c2;
    return j;
}

/* least_pair's choice j with least_two's margin (*mo, *to) and what a later lambda's test
   reads kept in rq: the second least cost, the choice's T and its I (the row's own
   last T, I where j = w) */
static inline Py_ssize_t least_kept(const double *tr, const double *ir, Py_ssize_t w, double t_last,
                                    double i_last, double lam, double margin_r, double *mo, double *to,
                                    double *rq)
{
    double c1;
    Py_ssize_t j = least_pair(tr, ir, w, t_last, i_last, lam, &c1, rq);
    *mo = isinf(rq[0]) ? INFINITY : rq[0] - c1;
    *to = margin_r * (fabs(c1) + fabs(rq[0]));
    rq[1] = j < w ? tr[j] : t_last;
    rq[2] = j < w ? ir[j] : i_last;
    return j;
}

/* row r's candidates lie inside the table (else IndexError "<name>: row out of range") */
static inline int alloc_row_ok(Py_ssize_t r, Py_ssize_t n, const Py_ssize_t *first, const Py_ssize_t *cnt,
                               Py_ssize_t nnz, const char *name)
{
    if (r < 0 || r >= n || first[r] < 0 || cnt[r] < 0 || first[r] > nnz - cnt[r]) {
        PyErr_Format(PyExc_IndexError, "%s: row out of range", name);
        return 0;
    }
    return 1;
}

static inline Py_ssize_t least_two(const double *T, const double *I, Py_ssize_t w, double t_last, double i_last,
                                   double lam, double margin_r, double *margin, double *tol)
{
    double c1, c2;
    Py_ssize_t j = least_pair(T, I, w, t_last, i_last, lam, &c1, &c2);
    *margin = isinf(c2) ? INFINITY : c2 - c1;
    *tol = margin_r * (fabs(c1) + fabs(c2));
    return j;
}

/* alloc_choices(Tx, Ix, k, rows, lam, margin_r, T_orig, dT, j, margin, tol): plan._allocate's choices() of the
 * rows `rows` (intp) of the row-major (n, k) tables Tx, Ix (float64; plain: every T finite
 * and >= 0, Ix inf where not finite) at lam, k >= 2: per row least_two over its k columns
 * (j = argmin's column, margin, tol = MARGIN_R (|c1| + |c2|)); and its take(): dT[r] =
 * Tx[r, j] - T_orig[r].  The costs hold no NaN (finite lam), so these are the numpy path's values
 * (the sign of a zero c2 aside, which only comparisons and fabs read). */
static PyObject *mod_alloc_choices(PyObject *self, PyObject *args)
{
    Py_buffer tb, ib, rb, gb, db, jb, mb, ob;
    Py_ssize_t k;
    double lam, margin_r;
    if (!PyArg_ParseTuple(args, "y*y*ny*ddy*w*w*w*w*:alloc_choices", &tb, &ib, &k, &rb, &lam, &margin_r,
                          &gb, &db, &jb, &mb, &ob))
        return NULL;
    PyObject *ret = NULL;
    Py_ssize_t m = rb.len / (Py_ssize_t)sizeof(Py_ssize_t);
    Py_ssize_t n = k > 0 ? tb.len / (Py_ssize_t)sizeof(double) / k : 0;
    if (k < 2 || ib.len != tb.len || tb.len != (Py_ssize_t)sizeof(double) * n * k
        || jb.len != rb.len || mb.len != m * (Py_ssize_t)sizeof(double) || ob.len != mb.len
        || gb.len != n * (Py_ssize_t)sizeof(double) || db.len != gb.len) {
        PyErr_SetString(PyExc_ValueError, "alloc_choices: bad sizes");
        goto done;
    }
    const double *T = (const double *)tb.buf, *I = (const double *)ib.buf;
    const Py_ssize_t *rows = (const Py_ssize_t *)rb.buf;
    Py_ssize_t *jo = (Py_ssize_t *)jb.buf;
    double *mo = (double *)mb.buf, *to = (double *)ob.buf, *dT = (double *)db.buf;
    const double *T_orig = (const double *)gb.buf;
    for (Py_ssize_t q = 0; q < m; q++) {
        Py_ssize_t r = rows[q];
        if (r < 0 || r >= n) {
            PyErr_SetString(PyExc_IndexError, "alloc_choices: row out of range");
            goto done;
        }
        const double *tr = T + r * k, *ir = I + r * k;
        Py_ssize_t j = least_two(tr, ir, k - 1, tr[k - 1], ir[k - 1], lam, margin_r, mo + q, to + q);
        jo[q] = j;
        dT[r] = tr[j] - T_orig[r];
    }
    ret = Py_None;
    Py_INCREF(ret);
done:
    PyBuffer_Release(&tb);
    PyBuffer_Release(&ib);
    PyBuffer_Release(&rb);
    PyBuffer_Release(&gb);
    PyBuffer_Release(&db);
    PyBuffer_Release(&jb);
    PyBuffer_Release(&mb);
    PyBuffer_Release(&ob);
    return ret;
}

/* alloc_rows(vT, vI, first, cnt, T_orig, I_orig, rows, lam, margin_r, dT, j, margin, tol[, ref]): alloc_choices on
 * the candidates as plan.Candidates holds them, not on a table copied out of them: local row r's
 * feasible candidates are vT, vI[first[r] .. first[r] + cnt[r]) (float64: T, I in column order),
 * then its original T_orig[r], I_orig[r], in the order of a row of the packed table (its filler,
 * I = inf, moved neither the least nor the second least), so per row the same costs in the same
 * order: the same j (0 .. cnt[r], cnt[r] = the original), margin and tol, and dT[r] = its T -
 * T_orig[r].  rows, first, cnt intp; j, margin, tol of rows' length; dT, T_orig, I_orig of
 * first's length (plan._allocate_rows checks the tables are plain, as packed() did).  ref (optional,
 * float64, 3 a row): each row's second least cost, its choice's T and I, for alloc_rise. */
static PyObject *mod_alloc_rows(PyObject *self, PyObject *args)
{
    Py_buffer tb, ib, fb, cb, gb, hb, rb, db, jb, mb, ob, sb = {0};
    double lam, margin_r;
    if (!PyArg_ParseTuple(args, "y*y*y*y*y*y*y*ddw*w*w*w*|w*:alloc_rows", &tb, &ib, &fb, &cb, &gb, &hb, &rb,
                          &lam, &margin_r, &db, &jb, &mb, &ob, &sb))
        return NULL;
    PyObject *ret = NULL;
    Py_ssize_t nnz = tb.len / (Py_ssize_t)sizeof(double);
    Py_ssize_t n = fb.len / (Py_ssize_t)sizeof(Py_ssize_t);
    Py_ssize_t m = rb.len / (Py_ssize_t)sizeof(Py_ssize_t);
    if (ib.len != tb.len || cb.len != fb.len || gb.len != n * (Py_ssize_t)sizeof(double) || hb.len != gb.len
        || db.len != gb.len || jb.len != rb.len || mb.len != m * (Py_ssize_t)sizeof(double) || ob.len != mb.len
        || (sb.obj != NULL && sb.len != 3 * mb.len)) {
        PyErr_SetString(PyExc_ValueError, "alloc_rows: bad sizes");
        goto done;
    }
    double *so = sb.obj != NULL ? (double *)sb.buf : NULL;
    const double *T = (const double *)tb.buf, *I = (const double *)ib.buf;
    const Py_ssize_t *first = (const Py_ssize_t *)fb.buf, *cnt = (const Py_ssize_t *)cb.buf;
    const double *T_orig = (const double *)gb.buf, *I_orig = (const double *)hb.buf;
    const Py_ssize_t *rows = (const Py_ssize_t *)rb.buf;
    Py_ssize_t *jo = (Py_ssize_t *)jb.buf;
    double *mo = (double *)mb.buf, *to = (double *)ob.buf, *dT = (double *)db.buf;
    for (Py_ssize_t q = 0; q < m; q++) {
        Py_ssize_t r = rows[q];
        if (!alloc_row_ok(r, n, first, cnt, nnz, "alloc_rows"))
            goto done;
        const double *tr = T + first[r], *ir = I + first[r];
        Py_ssize_t w = cnt[r];
        Py_ssize_t j;
        if (so == NULL) {
            j = least_two(tr, ir, w, T_orig[r], I_orig[r], lam, margin_r, mo + q, to + q);
        } else {              /* least_two's values, and the second least and the choice's T, I kept */
            j = least_kept(tr, ir, w, T_orig[r], I_orig[r], lam, margin_r, mo + q, to + q, so + 3 * q);
        }
        jo[q] = j;
        dT[r] = (j < w ? tr[j] : T_orig[r]) - T_orig[r];
    }
    ret = Py_None;
    Py_INCREF(ret);
done:
    PyBuffer_Release(&tb);
    PyBuffer_Release(&ib);
    PyBuffer_Release(&fb);
    PyBuffer_Release(&cb);
    PyBuffer_Release(&gb);
    PyBuffer_Release(&hb);
    PyBuffer_Release(&rb);
    PyBuffer_Release(&db);
    PyBuffer_Release(&jb);
    PyBuffer_Release(&mb);
    PyBuffer_Release(&ob);
    if (sb.obj != NULL)
        PyBuffer_Release(&sb);
    return ret;
}

/* alloc_rise(vT, vI, first, cnt, T_orig, I_orig, rows, lam, j, ref, dT, margin_r, margin, tol, kept):
 * alloc_rows' choices of the rows at lam, given each one's choice j[q] and ref[q] = (second least
 * cost, the choice's T and I) (alloc_rows' ref output, or this one's) at a lambda lam0 <= lam: a row
 * whose choice's cost at lam, I + lam * T by least_pair's operations, is below its second least
 * keeps it (j, ref, margin, tol and dT[r] untouched; q appended to kept); the others are costed
 * again (least_pair at lam: j[q], ref[q], margin[q], tol[q] and dT[r] as alloc_rows writes them).
 * Returns how many were (kept holds the others' q, ascending, first).
 * Why a kept row's choice is least_pair's at lam, bit for bit: every T is finite and >= 0 and lam
 * >= lam0 (the caller's), so each product lam * T is at least lam0 * T, and rounding to nearest is
 * monotone, so each candidate's cost at lam is at least its cost at lam0 (inf and NaN stay so; a
 * NaN cost, passed over by least_pair at every lambda, is not among the others, and a NaN at the
 * choice fails the test); every other candidate's cost at lam0 is at least the kept second least
 * (their least), so the choice's cost at lam is strictly below every other's at lam: it is the first
 * least, and the second least at lam is some other's, at least the kept one (which stays a valid
 * bound for a later lam).  Rows out of range raise (those costed again: a kept row reads only ref). */
static PyObject *mod_alloc_rise(PyObject *self, PyObject *args)
{
    Py_buffer tb, ib, fb, cb, gb, hb, rb, jb, sb, db, mb, ob, kb;
    double lam, margin_r;
    if (!PyArg_ParseTuple(args, "y*y*y*y*y*y*y*dw*w*w*dw*w*w*:alloc_rise", &tb, &ib, &fb, &cb, &gb, &hb, &rb, &lam,
                          &jb, &sb, &db, &margin_r, &mb, &ob, &kb))
        return NULL;
    PyObject *ret = NULL;
    Py_ssize_t nnz = tb.len / (Py_ssize_t)sizeof(double);
    Py_ssize_t n = fb.len / (Py_ssize_t)sizeof(Py_ssize_t);
    Py_ssize_t m = rb.len / (Py_ssize_t)sizeof(Py_ssize_t);
    if (ib.len != tb.len || cb.len != fb.len || gb.len != n * (Py_ssize_t)sizeof(double) || hb.len != gb.len
        || db.len != gb.len || jb.len != rb.len || sb.len != 3 * m * (Py_ssize_t)sizeof(double)
        || mb.len != m * (Py_ssize_t)sizeof(double) || ob.len != mb.len || kb.len != rb.len) {
        PyErr_SetString(PyExc_ValueError, "alloc_rise: bad sizes");
        goto done;
    }
    const double *T = (const double *)tb.buf, *I = (const double *)ib.buf;
    const Py_ssize_t *first = (const Py_ssize_t *)fb.buf, *cnt = (const Py_ssize_t *)cb.buf;
    const double *T_orig = (const double *)gb.buf, *I_orig = (const double *)hb.buf;
    const Py_ssize_t *rows = (const Py_ssize_t *)rb.buf;
    Py_ssize_t *jo = (Py_ssize_t *)jb.buf;
    double *so = (double *)sb.buf, *dT = (double *)db.buf, *mo = (double *)mb.buf, *to = (double *)ob.buf;
    Py_ssize_t *kept = (Py_ssize_t *)kb.buf;
    Py_ssize_t costed = 0, nk = 0;
    for (Py_ssize_t q = 0; q < m; q++) {
        double *rq = so + 3 * q;             /* second least, the choice's T, its I */
        double x = rq[2] + lam * rq[1];
        if (x < rq[0]) {
            kept[nk++] = q;
            continue;
        }
        Py_ssize_t r = rows[q];
        if (!alloc_row_ok(r, n, first, cnt, nnz, "alloc_rise"))
            goto done;
        const double *tr = T + first[r], *ir = I + first[r];
        Py_ssize_t w = cnt[r];
        Py_ssize_t j = least_kept(tr, ir, w, T_orig[r], I_orig[r], lam, margin_r, mo + q, to + q, rq);
        jo[q] = j;
        dT[r] = rq[1] - T_orig[r];
        costed++;
    }
    ret = PyLong_FromSsize_t(costed);
done:
    PyBuffer_Release(&tb);
    PyBuffer_Release(&ib);
    PyBuffer_Release(&fb);
    PyBuffer_Release(&cb);
    PyBuffer_Release(&gb);
    PyBuffer_Release(&hb);
    PyBuffer_Release(&rb);
    PyBuffer_Release(&jb);
    PyBuffer_Release(&sb);
    PyBuffer_Release(&db);
    PyBuffer_Release(&mb);
    PyBuffer_Release(&ob);
    PyBuffer_Release(&kb);
    return ret;
}

/* ring_release(): ring_solve's room given back (a Collector's pass is over: the room,
 * ~7 doubles an event of a chunk, would stay for the rest of the run); the next ring_solve
 * takes it again.  Returns the bytes it held. */
static PyObject *mod_ring_release(PyObject *self, PyObject *noargs)
{
    size_t held = ring_scratch_n * sizeof(double);
    PyMem_Free(ring_scratch);
    ring_scratch = NULL;
    ring_scratch_n = 0;
    for (int j = 0; j < 2; j++) {            /* (the pieces' tables: made again when next asked) */
        if (ring_dur[j].slots != NULL) {
            held += sizeof(RingDur) << RING_DUR_BITS;
            PyMem_Free(ring_dur[j].slots);
            ring_dur[j].slots = NULL;
        }
        if (ring_step[j].slots != NULL) {
            held += sizeof(RingStep) << RING_DUR_BITS;
            PyMem_Free(ring_step[j].slots);
            ring_step[j].slots = NULL;
        }
    }
    return PyLong_FromSize_t(held);
}

/* ---------------------------------------------------------------- segments._jerk_rows' tail
 * Elementwise helpers with numpy's semantics: np.maximum propagates a NaN (the first
 * operand's if both are), np.max of a row likewise. */
static inline double np_maximum(double a, double b)
{
    return (a >= b || isnan(a)) ? a : b;
}

/* jerk_tail(S, V, acc, a_own, step, v_feed, K, A, F, t, a2, fine): segments._jerk_rows
 * after its rows are taken, for m rows of K knots (row-major float64; K >= 3):
 *   A     = hold_cruise_accels_rows(acc, a_own)               (m, K - 1)
 *   F     = tent_feeds_rows(max(max(V[:-1], V[1:]), MIN_FEED_V), v_feed, step)
 *   t, a2 = _predict_rows(S, V, A)  (segment_times, each row's pairwise sum)
 *   fine  = fine_rows(S, V, A, F, t, a2)                      (m bytes, 0 / 1)
 * the same operations on the same doubles as the numpy path (no contraction: the build's
 * -ffp-contract=off), in the same order where it matters (the sums), so the same bits;
 * MIN_FEED_V and CRUISE_A and the floors 1e-12, 1e-9 are passed as segments.py has them. */
static PyObject *mod_jerk_tail(PyObject *self, PyObject *args)
{
    Py_buffer sb, vb, cb, ob, pb, fb, Ab, Fb, tb, ab, kb;
    Py_ssize_t K;
    double min_feed_v, cruise_a;
    if (!PyArg_ParseTuple(args, "y*y*y*y*y*y*nddw*w*w*w*w*:jerk_tail", &sb, &vb, &cb, &ob, &pb, &fb, &K,
                          &min_feed_v, &cruise_a, &Ab, &Fb, &tb, &ab, &kb))
        return NULL;
    PyObject *ret = NULL;
    Py_ssize_t m = ob.len / (Py_ssize_t)sizeof(double);
    Py_ssize_t ks = K - 1;
    double *work = NULL;
    if (K < 3 || sb.len != (Py_ssize_t)sizeof(double) * m * K || vb.len != sb.len
        || cb.len != (Py_ssize_t)sizeof(double) * m * ks || Ab.len != cb.len || Fb.len != cb.len
        || pb.len != ob.len || fb.len != ob.len || tb.len != ob.len || ab.len != ob.len || kb.len != m) {
        PyErr_SetString(PyExc_ValueError, "jerk_tail: bad sizes");
        goto done;
    }
    work = PyMem_Malloc(sizeof(double) * (size_t)(3 * ks + 2));
    if (work == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    const double *S = (const double *)sb.buf, *V = (const double *)vb.buf, *C = (const double *)cb.buf;
    const double *a_own = (const double *)ob.buf, *step = (const double *)pb.buf, *vf = (const double *)fb.buf;
    double *A = (double *)Ab.buf, *F = (double *)Fb.buf, *t_out = (double *)tb.buf, *a2_out = (double *)ab.buf;
    unsigned char *fine = (unsigned char *)kb.buf;
    double *tt = work, *aa = work + ks, *pad = work + 2 * ks;    /* ks, ks and ks + 2 doubles */
    for (Py_ssize_t r = 0; r < m; r++) {
        const double *s = S + r * K, *v = V + r * K, *c = C + r * ks;
        double *Ar = A + r * ks, *Fr = F + r * ks;
        /* hold_cruise_accels_rows: a cruise (acc <= CRUISE_A, not NaN) keeps the last
         * non-cruise before it, the first non-cruise before that, a_own when all cruise */
        Py_ssize_t first = -1;
        for (Py_ssize_t k = 0; k < ks; k++)
            if (!(c[k] <= cruise_a)) {
                first = k;
                break;
            }
        if (first < 0) {
            for (Py_ssize_t k = 0; k < ks; k++)
                Ar[k] = a_own[r];
        } else {
            Py_ssize_t last = first;
            for (Py_ssize_t k = 0; k < ks; k++) {
                if (!(c[k] <= cruise_a)) {
                    last = k;
                    Ar[k] = c[k];
                } else {
                    Ar[k] = k < first ? c[first] : c[last];
                }
            }
        }
        /* tent_feeds_rows: need_k = max(max(v_k, v_k+1), MIN_FEED_V); a row of finite
         * step: max_j (pad_j - step |k - j|), j = -1..ks, pad's ends v_feed + step */
        double st = step[r];
        for (Py_ssize_t k = 0; k < ks; k++)
            Fr[k] = np_maximum(np_maximum(v[k], v[k + 1]), min_feed_v);
        if (isfinite(st)) {
            double side = vf[r] + st;
            pad[0] = side;
            for (Py_ssize_t k = 0; k < ks; k++)
                pad[k + 1] = Fr[k];
            pad[ks + 1] = side;
            for (Py_ssize_t k = 0; k < ks; k++) {
                double best = 0.0;
                for (Py_ssize_t j = 0; j < ks + 2; j++) {       /* pad index j is position j - 1 */
                    Py_ssize_t dist = k - (j - 1);
                    double x = pad[j] - st * (double)(dist < 0 ? -dist : dist);
                    if (j == 0 || isnan(x) || x > best) {
                        best = x;
                        if (isnan(x))
                            break;
                    }
                }
                Fr[k] = best;
            }
        }
        /* segment_times and the rows' sums */
        for (Py_ssize_t k = 0; k < ks; k++) {
            double d = s[k + 1] - s[k];
            double va = v[k], vb2 = v[k + 1];
            double dv = fabs(vb2 - va);
            double vmax = np_maximum(va, vb2);
            double a = np_maximum(Ar[k], 1e-12);
            double ramp_d = fabs(vb2 * vb2 - va * va) / (2.0 * a);
            tt[k] = dv / a + np_maximum(d - ramp_d, 0.0) / np_maximum(vmax, 1e-9);
            aa[k] = a * dv;
        }
        /* (0.0 +: the numpy path's row sums start from +0.0, so an all -0.0 row sums to +0.0) */
        double t_sum = 0.0 + np_pairwise_sum(tt, ks), a2_sum = 0.0 + np_pairwise_sum(aa, ks);
        t_out[r] = t_sum;
        a2_out[r] = a2_sum;
        /* fine_rows */
        int ok = isfinite(t_sum) && isfinite(a2_sum);
        for (Py_ssize_t k = 0; ok && k < K; k++)
            ok = isfinite(s[k]) && isfinite(v[k]) && v[k] >= 0.0 && (k == 0 || s[k] > s[k - 1]);
        for (Py_ssize_t k = 0; ok && k < ks; k++)
            ok = isfinite(Ar[k]) && Ar[k] > 0.0 && isfinite(Fr[k]) && Fr[k] > 0.0;
        fine[r] = (unsigned char)ok;
    }
    ret = Py_None;
    Py_INCREF(ret);
done:
    PyMem_Free(work);
    PyBuffer_Release(&sb);
    PyBuffer_Release(&vb);
    PyBuffer_Release(&cb);
    PyBuffer_Release(&ob);
    PyBuffer_Release(&pb);
    PyBuffer_Release(&fb);
    PyBuffer_Release(&Ab);
    PyBuffer_Release(&Fb);
    PyBuffer_Release(&tb);
    PyBuffer_Release(&ab);
    PyBuffer_Release(&kb);
    return ret;
}

/* ---------------------------------------------------------------- stroke store records
 * stroke_store.StrokeStore's encoding of a stroke (a StrokeBase of exactly the kit's Stroke
 * class, which adds no slot) into bytes and back, read and filled here directly (the
 * Python twin in stroke_store.py writes and reads the same bytes).  A record: the doubles
 * d[SD_N], the ints i[SI_N], `has` (uint32), one tag a object slot (SO_N bytes), then each
 * slot's payload in slot order: a float or int 8 bytes, an interned object its uint32 index
 * in the store's table (restored as that same object), an array("d") / Points a uint32
 * count and the doubles, an Arc its 7 doubles and a byte of its two bools.  curv (a cache)
 * is stored as None; chain_T as None or a ChainMemo (restored empty).  A field kept as an
 * object in `extra` (odd), or a value of another type, is refused with a TypeError (never
 * lost).  Native byte order: the records live in a temporary file of this process. */
enum { SR_UNSET, SR_NONE, SR_FALSE, SR_TRUE, SR_FLOAT, SR_INT, SR_INTERN, SR_DARRAY, SR_POINTS, SR_ARC, SR_MEMO };
#define SR_HEAD ((Py_ssize_t)(SD_N * 8 + SI_N * 8 + 4 + SO_N))
#define SR_TAGS (SD_N * 8 + SI_N * 8 + 4)
static const char *const SO_NAMES[SO_N] = {"z", "_ends", "v_feed", "accel", "feature", "layer", "e_rel", "lim",
    "kind", "arc", "pts", "curv", "_ss_a", "_ss_c", "chain_T", "v0_fw", "v1_fw", "corner_cmd0", "corner_cmd1"};

/* state.Arc's slots, in record order: 7 doubles, then the bools cw and off_circle */
enum { SA_N = 9, SA_NDBL = 7 };
static const char *SR_ARC_NAMES[SA_N] = {"cx", "cy", "r", "theta0", "sweep", "length_d", "end_off_d", "cw",
                                         "off_circle"};
static Py_ssize_t sr_arc_off[SA_N];
static PyObject *sr_arc_name[SA_N];
static SlotMap SR_ARC_MAP = {NULL, sr_arc_off, sr_arc_name, SA_N};

/* the store's kit: (Stroke, Points, array, Arc, Limits, ChainMemo) */
typedef struct {
    PyTypeObject *stroke_t;
    PyObject *points_t, *array_t, *arc_t, *lim_t, *memo_t;
} StoreKit;

static int store_kit(PyObject *o, StoreKit *k)
{
    if (!PyTuple_CheckExact(o) || PyTuple_GET_SIZE(o) != 6) {
        PyErr_SetString(PyExc_TypeError, "stroke store: the kit must be a 6-tuple");
        return -1;
    }
    PyObject *st = PyTuple_GET_ITEM(o, 0);
    k->points_t = PyTuple_GET_ITEM(o, 1);
    k->array_t = PyTuple_GET_ITEM(o, 2);
    k->arc_t = PyTuple_GET_ITEM(o, 3);
    k->lim_t = PyTuple_GET_ITEM(o, 4);
    k->memo_t = PyTuple_GET_ITEM(o, 5);
    if (!PyType_Check(st) || !PyType_IsSubtype((PyTypeObject *)st, &StrokeType)
        || ((PyTypeObject *)st)->tp_basicsize != (Py_ssize_t)sizeof(StrokeObject)
        || ((PyTypeObject *)st)->tp_dictoffset != 0) {
        PyErr_SetString(PyExc_TypeError, "stroke store: the kit's Stroke must be a StrokeBase adding no slot");
        return -1;
    }
    k->stroke_t = (PyTypeObject *)st;
    static const char *points_names[1] = {"xy"};
    int a = slots_ready(&POINTS_MAP, k->points_t, points_names);
    int b = a < 0 ? -1 : slots_ready(&SR_ARC_MAP, k->arc_t, SR_ARC_NAMES);
    if (a < 0 || b < 0)
        return -1;
    if (!a || !b) {
        PyErr_SetString(PyExc_TypeError, "stroke store: the kit's Points and Arc must keep plain slots");
        return -1;
    }
    return 0;
}

/* a growing bytearray (the caller's, kept between calls); cap and base: its size and bytes
 * as last seen (only sr_grow resizes it) */
typedef struct {
    PyObject *ba;
    Py_ssize_t n, cap;
    char *base;
} SrBuf;

static void sr_buf_init(SrBuf *w, PyObject *ba)
{
    w->ba = ba;
    w->n = 0;
    w->cap = PyByteArray_GET_SIZE(ba);
    w->base = PyByteArray_AS_STRING(ba);
}

/* sr_room's bytearray grown (doubled, or to what is needed and 64 kB more) */
static __attribute__((noinline)) char *sr_grow(SrBuf *w, Py_ssize_t need)
{
    Py_ssize_t cap = w->cap;
    Py_ssize_t to = cap * 2 > w->n + need ? cap * 2 : w->n + need + 65536;
    if (PyByteArray_Resize(w->ba, to) < 0)
        return NULL;
    w->cap = PyByteArray_GET_SIZE(w->ba);
    w->base = PyByteArray_AS_STRING(w->ba);
    char *p = w->base + w->n;
    w->n += need;
    return p;
}

/* need bytes at the end of w's bytes (inline: a record's ~10 payloads each reserve theirs,
 * ~0.5 M calls on the rectilinear plate) */
static inline __attribute__((always_inline)) char *sr_room(SrBuf *w, Py_ssize_t need)
{
    if (w->n + need > w->cap)
        return sr_grow(w, need);
    char *p = w->base + w->n;
    w->n += need;
    return p;
}

static int sr_refuse(Py_ssize_t row, const char *name, PyObject *v)
{
    PyErr_Format(PyExc_TypeError, "StrokeStore: stroke %zd: field %s holds %s%.80s (not storable; refused)", row,
                 name, v == NULL ? "no value" : "a ", v == NULL ? "" : Py_TYPE(v)->tp_name);
    return -1;
}

/* the doubles of an array("d") of the kit's class (n, *v borrowed while a is alive); -1 if not one */
static int sr_darray(const StoreKit *k, PyObject *a, Py_ssize_t *n, const double **v)
{
    if ((PyObject *)Py_TYPE(a) != k->array_t)
        return -1;
    Py_buffer b;
    if (PyObject_GetBuffer(a, &b, PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0) {
        PyErr_Clear();
        return -1;
    }
    int ok = b.format != NULL && !strcmp(b.format, "d") && b.itemsize == 8 && b.len / 8 <= 0xffffffffLL;
    *n = b.len / 8;
    *v = b.buf;                        /* (the array's storage: stays put while nobody resizes it) */
    PyBuffer_Release(&b);
    return ok ? 0 : -1;
}

static int sr_put_doubles(SrBuf *w, const double *v, Py_ssize_t n)
{
    char *p = sr_room(w, 4 + 8 * n);
    if (p == NULL)
        return -1;
    uint32_t c = (uint32_t)n;
    memcpy(p, &c, 4);
    if (n)
        memcpy(p + 4, v, (size_t)n * 8);
    return 0;
}

/* the last object interned for each slot by one store_encode call and its index (the
 * table keeps it): the strokes of a run share their feature, kind and limits */
typedef struct {
    PyObject *obj[SO_N];
    uint32_t q[SO_N];
} SrSeen;

/* slot value v (NULL: unset) of stroke row written: its tag (*tag) and payload */
static inline __attribute__((always_inline)) int sr_put_obj(SrBuf *w, const StoreKit *k, int slot, PyObject *v,
                                                            PyObject *index, PyObject *table, Py_ssize_t row,
                                                            unsigned char *tag, SrSeen *seen)
{
    char *p;
    if (v == NULL) {
        *tag = SR_UNSET;
        return 0;
    }
    if (slot == SO_CURV || v == Py_None) {         /* (curv: a cache, made again when read) */
        *tag = SR_NONE;
        return 0;
    }
    if (slot == SO_CHAIN) {
        if ((PyObject *)Py_TYPE(v) != k->memo_t)
            return sr_refuse(row, SO_NAMES[slot], v);
        *tag = SR_MEMO;
        return 0;
    }
    if (v == Py_False || v == Py_True) {
        *tag = v == Py_True ? SR_TRUE : SR_FALSE;
        return 0;
    }
    if (PyFloat_CheckExact(v)) {
        double x = PyFloat_AS_DOUBLE(v);
        if ((p = sr_room(w, 8)) == NULL)
            return -1;
        memcpy(p, &x, 8);
        *tag = SR_FLOAT;
        return 0;
    }
    if (PyLong_CheckExact(v)) {
        int over = 0;
        long long x = PyLong_AsLongLongAndOverflow(v, &over);
        if (x == -1 && PyErr_Occurred())
            return -1;
        if (over)
            return sr_refuse(row, SO_NAMES[slot], v);
        if ((p = sr_room(w, 8)) == NULL)
            return -1;
        memcpy(p, &x, 8);
        *tag = SR_INT;
        return 0;
    }
    if (seen->obj[slot] == v) {
        if ((p = sr_room(w, 4)) == NULL)
            return -1;
        memcpy(p, &seen->q[slot], 4);
        *tag = SR_INTERN;
        return 0;
    }
    if (PyUnicode_CheckExact(v) || (PyObject *)Py_TYPE(v) == k->lim_t) {
        PyObject *key = PyLong_FromVoidPtr(v);
        if (key == NULL)
            return -1;
        PyObject *got = PyDict_GetItemWithError(index, key);
        Py_ssize_t q;
        if (got != NULL) {
            q = PyLong_AsSsize_t(got);
        } else if (PyErr_Occurred()) {
            q = -1;
        } else {                                   /* a new object: the table keeps it (its id stays its) */
            q = PyList_GET_SIZE(table);
            PyObject *qo = PyLong_FromSsize_t(q);
            if (qo == NULL || PyList_Append(table, v) < 0 || PyDict_SetItem(index, key, qo) < 0)
                q = -1;
            Py_XDECREF(qo);
        }
        Py_DECREF(key);
        if (q < 0 || (p = sr_room(w, 4)) == NULL)
            return -1;
        uint32_t c = (uint32_t)q;
        memcpy(p, &c, 4);
        seen->obj[slot] = v;
        seen->q[slot] = c;
        *tag = SR_INTERN;
        return 0;
    }
    Py_ssize_t n;
    const double *d;
    if (sr_darray(k, v, &n, &d) == 0) {
        *tag = SR_DARRAY;
        return sr_put_doubles(w, d, n);
    }
    if ((PyObject *)Py_TYPE(v) == k->points_t) {
        PyObject *xy = *(PyObject **)((char *)v + POINTS_MAP.off[0]);
        if (xy == NULL || sr_darray(k, xy, &n, &d) < 0)
            return sr_refuse(row, "pts.xy", xy);
        *tag = SR_POINTS;
        return sr_put_doubles(w, d, n);
    }
    if ((PyObject *)Py_TYPE(v) == k->arc_t) {
        double a[SA_NDBL];
        unsigned char bits = 0;
        for (int j = 0; j < SA_N; j++) {
            PyObject *x = *(PyObject **)((char *)v + sr_arc_off[j]);
            if (j < SA_NDBL && x != NULL && PyFloat_CheckExact(x))
                a[j] = PyFloat_AS_DOUBLE(x);
            else if (j >= SA_NDBL && (x == Py_True || x == Py_False))
                bits |= (x == Py_True) << (j - SA_NDBL);
            else
                return sr_refuse(row, SR_ARC_NAMES[j], x);
        }
        if ((p = sr_room(w, 8 * SA_NDBL + 1)) == NULL)
            return -1;
        memcpy(p, a, sizeof a);
        p[8 * SA_NDBL] = (char)bits;
        *tag = SR_ARC;
        return 0;
    }
    return sr_refuse(row, SO_NAMES[slot], v);
}

/* one stroke's record appended to w (row: its number, for errors) */
static int sr_encode(SrBuf *w, const StoreKit *k, PyObject *o, PyObject *index, PyObject *table, Py_ssize_t row,
                     SrSeen *seen, Py_ssize_t *off)
{
    if (Py_TYPE(o) != k->stroke_t) {
        PyErr_Format(PyExc_TypeError, "StrokeStore: stroke %zd is a %.80s, not the store's Stroke", row,
                     Py_TYPE(o)->tp_name);
        return -1;
    }
    StrokeObject *s = (StrokeObject *)o;
    if (s->odd) {                                  /* a field kept as an object (or unset): not stored */
        for (int f = 0; f < SD_N + SI_N; f++)
            if (s->odd & (1u << f)) {
                const char *nm = f < SD_N ? SD_NAMES[f] : SI_NAMES[f - SD_N];
                PyObject *v = s->extra ? PyDict_GetItemString(s->extra, nm) : NULL;
                return sr_refuse(row, nm, v);
            }
    }
    Py_ssize_t at = w->n;
    char *p = sr_room(w, SR_HEAD);
    if (p == NULL)
        return -1;
    double d[SD_N];
    memcpy(d, s->d, sizeof d);
    for (int f = SD_NONE0; f < SD_N; f++)          /* (None: 0.0, as sd_set leaves it) */
        if (!(s->has & (1u << (f - SD_NONE0))))
            d[f] = 0.0;
    uint32_t has = s->has;
    memcpy(p, d, sizeof d);
    memcpy(p + SD_N * 8, s->i, SI_N * 8);
    memcpy(p + SD_N * 8 + SI_N * 8, &has, 4);
    unsigned char tags[SO_N];
    for (int j = 0; j < SO_N; j++) {
        off[j] = w->n - at;                        /* (slot j's payload: where store_fields' walk finds it) */
        if (sr_put_obj(w, k, j, s->o[j], index, table, row, &tags[j], seen) < 0)
            return -1;
    }
    memcpy(w->base + at + SR_TAGS, tags, SO_N);      /* (the buffer may have moved) */
    return 0;
}

/* store_fields' and store_encode's field numbers: the tuple codes_o's ints into codes (64 at
 * most), *w their count, *last_slot the last object slot among them (-1: none); -1 with an error */
static int sr_codes(PyObject *codes_o, int *codes, Py_ssize_t *w, int *last_slot, const char *what)
{
    *w = PyTuple_GET_SIZE(codes_o);
    *last_slot = -1;
    if (*w > 64) {
        PyErr_Format(PyExc_ValueError, "%s: at most 64 fields", what);
        return -1;
    }
    for (Py_ssize_t j = 0; j < *w; j++) {
        long c = PyLong_AsLong(PyTuple_GET_ITEM(codes_o, j));
        if (c == -1 && PyErr_Occurred())
            return -1;
        if (c < 0 || c >= SD_N + SI_N + SO_N) {
            PyErr_Format(PyExc_ValueError, "%s: no such field", what);
            return -1;
        }
        codes[j] = (int)c;
        if (c >= SD_N + SI_N && c - SD_N - SI_N > *last_slot)
            *last_slot = (int)(c - SD_N - SI_N);
    }
    return 0;
}

/* a call's codes sorted by how a record holds them, once a call (sr_fields_row's loops: no
 * test of a code's range a field a record, ~20 instructions a field before): plain (a double
 * that is never None, or an int field: its 8 bytes at 8 * code), maybe (a None-able double:
 * its has bit), slot (an object slot: its tag); each with its column j */
typedef struct {
    int n_plain, n_maybe, n_slot;
    int plain_j[64], plain_c[64], maybe_j[64], maybe_c[64], slot_j[64], slot_s[64];
} SrPlan;

static void sr_plan(const int *codes, Py_ssize_t w, SrPlan *pl)
{
    pl->n_plain = pl->n_maybe = pl->n_slot = 0;
    for (Py_ssize_t j = 0; j < w; j++) {
        int c = codes[j];
        if (c >= SD_N + SI_N) {
            pl->slot_j[pl->n_slot] = (int)j;
            pl->slot_s[pl->n_slot++] = c - SD_N - SI_N;
        } else if (c >= SD_NONE0 && c < SD_N) {
            pl->maybe_j[pl->n_maybe] = (int)j;
            pl->maybe_c[pl->n_maybe++] = c;
        } else {
            pl->plain_j[pl->n_plain] = (int)j;
            pl->plain_c[pl->n_plain++] = c;
        }
    }
}

/* the fields of pl (sr_plan's of codes[0..w)) of the record at p (its payloads: slot s's at
 * p + off[s], for the slots codes name) into vals[0..w) and kinds[0..w), as store_fields
 * reads them */
static inline __attribute__((always_inline)) void sr_fields_row(const char *p, const Py_ssize_t *off,
                                                                const SrPlan *pl, int ints,
                                                                double *vals, signed char *kinds)
{
    const unsigned char *tags = (const unsigned char *)p + SR_TAGS;
    uint32_t has;
    memcpy(&has, p + SD_N * 8 + SI_N * 8, 4);
    const unsigned long long nan_bits = 0x7ff8000000000000ull;      /* stroke_fields' None */
    double nan_v;
    memcpy(&nan_v, &nan_bits, sizeof nan_v);
    for (int i = 0; i < pl->n_plain; i++) {          /* (an int field: its int64's bits) */
        int j = pl->plain_j[i];
        memcpy(vals + j, p + 8 * pl->plain_c[i], 8);
        kinds[j] = 0;
    }
    for (int i = 0; i < pl->n_maybe; i++) {
        int j = pl->maybe_j[i], c = pl->maybe_c[i];
        if (has & (1u << (c - SD_NONE0))) {
            memcpy(vals + j, p + 8 * c, 8);
            kinds[j] = 0;
        } else {
            vals[j] = nan_v;
            kinds[j] = 1;
        }
    }
    for (int i = 0; i < pl->n_slot; i++) {
        int j = pl->slot_j[i], s = pl->slot_s[i];
        double v = 0.0;
        signed char kind;
        switch (tags[s]) {
        case SR_FLOAT:
            memcpy(&v, p + off[s], 8);
            kind = 0;
            break;
        case SR_NONE:
            v = nan_v;
            kind = 1;
            break;
        case SR_FALSE: case SR_TRUE:
            v = tags[s] == SR_TRUE ? 1.0 : 0.0;
            kind = 2;
            break;
        case SR_UNSET:
            kind = 4;
            break;
        case SR_INTERN: {
            uint32_t k;
            memcpy(&k, p + off[s], 4);
            v = (double)k;
            kind = 5;
            break;
        }
        case SR_INT:
            if (ints)
                memcpy(&v, p + off[s], 8);     /* (the int64's bits) */
            kind = ints ? 6 : 3;
            break;
        default:
            kind = 3;
        }
        vals[j] = v;
        kinds[j] = kind;
    }
}

/* store_fields' and store_encode's vals (float64) and kinds (int8) buffers of n x w items,
 * writable; got: how many of the two are held (to release) */
static int sr_fields_out(PyObject *vals_o, PyObject *kinds_o, Py_ssize_t n, Py_ssize_t w, Py_buffer *vb,
                         Py_buffer *kb, int *got, const char *what)
{
    *got = 0;
    if (PyObject_GetBuffer(vals_o, vb, PyBUF_WRITABLE | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return -1;
    *got = 1;
    if (PyObject_GetBuffer(kinds_o, kb, PyBUF_WRITABLE | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return -1;
    *got = 2;
    if (vb->itemsize != 8 || vb->format == NULL || strcmp(vb->format, "d") || vb->len < n * w * 8
        || kb->itemsize != 1 || kb->format == NULL || strcmp(kb->format, "b") || kb->len < n * w) {
        PyErr_Format(PyExc_ValueError, "%s: float64 and int8 buffers of len(offs) x len(codes)", what);
        return -1;
    }
    return 0;
}

/* store_encode(strokes, i0, i1, kit, index, table, buf, lens[, codes, vals, kinds]): the records
 * of strokes[i0:i1] written one after the other at the start of the bytearray buf (grown as
 * needed), their lengths into lens (int64, >= i1 - i0 items); the bytes written.  index {id:
 * table index} and table (a list) intern the shared objects (str, Limits).  codes, vals,
 * kinds: the records' fields codes as store_fields(..., ints=True) reads them of buf after
 * (vals, kinds: (i1 - i0) x len(codes)), taken as each record is written (no walk of its
 * slots: stroke_store's side columns of every record appended or rewritten) */
static PyObject *mod_store_encode(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *list, *kit_o, *index, *table, *ba, *lens_o, *codes_o = NULL, *vals_o = NULL, *kinds_o = NULL;
    Py_ssize_t i0, i1;
    if (!PyArg_ParseTuple(args, "O!nnOO!O!O!O|O!OO:store_encode", &PyList_Type, &list, &i0, &i1, &kit_o, &PyDict_Type,
                          &index, &PyList_Type, &table, &PyByteArray_Type, &ba, &lens_o, &PyTuple_Type, &codes_o,
                          &vals_o, &kinds_o))
        return NULL;
    StoreKit k;
    if (store_kit(kit_o, &k) < 0)
        return NULL;
    if (i0 < 0 || i1 > PyList_GET_SIZE(list) || i0 > i1) {
        PyErr_SetString(PyExc_IndexError, "store_encode: rows out of range");
        return NULL;
    }
    if (codes_o != NULL && kinds_o == NULL) {
        PyErr_SetString(PyExc_TypeError, "store_encode: codes, vals and kinds go together");
        return NULL;
    }
    Py_ssize_t nw = 0;
    int codes[64], last_slot, out_got = 0;
    if (codes_o != NULL && sr_codes(codes_o, codes, &nw, &last_slot, "store_encode") < 0)
        return NULL;
    SrPlan plan;
    sr_plan(codes, nw, &plan);
    Py_buffer lb, vb, kb;
    if (stroke_buf(lens_o, &lb, i1 - i0, 1, 1, "store_encode") < 0)
        return NULL;
    if (codes_o != NULL && sr_fields_out(vals_o, kinds_o, i1 - i0, nw, &vb, &kb, &out_got, "store_encode") < 0) {
        PyBuffer_Release(&lb);
        if (out_got >= 1)
            PyBuffer_Release(&vb);
        if (out_got >= 2)
            PyBuffer_Release(&kb);
        return NULL;
    }
    long long *lens = lb.buf;
    SrBuf w;
    sr_buf_init(&w, ba);
    SrSeen seen = {{NULL}, {0}};
    Py_ssize_t off[SO_N];
    int rc = 0;
    for (Py_ssize_t r = i0; r < i1 && rc == 0; r++) {
        Py_ssize_t at = w.n;
        rc = sr_encode(&w, &k, PyList_GET_ITEM(list, r), index, table, r, &seen, off);
        lens[r - i0] = w.n - at;
        if (rc == 0 && codes_o != NULL)
            sr_fields_row(w.base + at, off, &plan, 1, (double *)vb.buf + (r - i0) * nw,
                          (signed char *)kb.buf + (r - i0) * nw);
    }
    PyBuffer_Release(&lb);
    if (codes_o != NULL) {
        PyBuffer_Release(&vb);
        PyBuffer_Release(&kb);
    }
    return rc < 0 ? NULL : PyLong_FromSsize_t(w.n);
}

/* a reader of one record's bytes */
typedef struct {
    const char *p, *end;
} SrRead;

static const char *sr_take(SrRead *r, Py_ssize_t n)
{
    if (r->end - r->p < n) {
        PyErr_SetString(PyExc_ValueError, "StrokeStore: a record runs past its end (corrupt store)");
        return NULL;
    }
    const char *p = r->p;
    r->p += n;
    return p;
}

/* the doubles of an array / Points payload: count and where they are */
static const char *sr_doubles(SrRead *r, Py_ssize_t *n)
{
    const char *p = sr_take(r, 4);
    if (p == NULL)
        return NULL;
    uint32_t c;
    memcpy(&c, p, 4);
    *n = c;
    return sr_take(r, 8 * (Py_ssize_t)c);
}

static PyObject *sr_array(const StoreKit *k, const char *p, Py_ssize_t n)
{
    double *d;
    PyObject *a = array_room(k->array_t, n, &d);
    if (a != NULL && n > 0)
        memcpy(d, p, (size_t)n * 8);
    return a;
}

/* the last float / int made for each slot by one store_decode call: the next record's
 * value of the same bits is that object again (the strokes of a run share their Z, feed,
 * acceleration, start state and layer objects as analyse made them: a float each a stroke
 * would hold more than the strokes spilled) */
typedef struct {
    PyObject *obj[SO_N];
    long long bits[SO_N];
} SrLast;

static PyObject *sr_number(SrLast *c, int slot, const char *p, int is_float)
{
    long long b;
    memcpy(&b, p, 8);
    PyObject *o = c->obj[slot];
    if (o != NULL && c->bits[slot] == b && (is_float ? PyFloat_CheckExact(o) : PyLong_CheckExact(o)))
        return Py_NewRef(o);
    double x;
    memcpy(&x, p, 8);
    o = is_float ? PyFloat_FromDouble(x) : PyLong_FromLongLong(b);
    if (o != NULL) {
        Py_XSETREF(c->obj[slot], Py_NewRef(o));
        c->bits[slot] = b;
    }
    return o;
}

/* SR_MEMO's empty memo: the kit's memo type called once (MEMO_PROTO), then each new memo
 * tp_alloc'd with that one's slot values (memo_copy: ~1.6 k instructions a call of
 * ChainMemo's __init__ saved; gyroid plate windowed: 49 k memos decoded).  Only where that is
 * what a call makes: a class of object's (its new object's, no __dict__) whose slots the call
 * left unset or set to None, a bool, an int or a float (shared: immutable); else called
 * each time.  (Its __init__ is taken to set constants: chains.ChainMemo's does.) */
static PyObject *MEMO_TYPE = NULL, *MEMO_PROTO = NULL;
static int memo_copy = 0;

static int memo_copyable(PyObject *p)
{
    PyTypeObject *t = Py_TYPE(p);
    if (t->tp_base != &PyBaseObject_Type || t->tp_new != PyBaseObject_Type.tp_new || t->tp_dictoffset != 0
        || t->tp_members == NULL)
        return 0;
    for (PyMemberDef *md = t->tp_members; md->name != NULL; md++) {
        if (md->type != T_OBJECT_EX)
            return 0;
        PyObject *v = *(PyObject **)((char *)p + md->offset);
        if (v != NULL && v != Py_None && !PyBool_Check(v) && !PyLong_CheckExact(v) && !PyFloat_CheckExact(v))
            return 0;
    }
    return 1;
}

static PyObject *sr_memo(const StoreKit *k)
{
    if (MEMO_TYPE != k->memo_t) {
        PyObject *p = PyObject_CallNoArgs(k->memo_t);
        if (p == NULL)
            return NULL;
        Py_XSETREF(MEMO_PROTO, p);
        Py_XSETREF(MEMO_TYPE, Py_NewRef(k->memo_t));
        memo_copy = (PyObject *)Py_TYPE(p) == k->memo_t && memo_copyable(p);
    }
    if (!memo_copy)
        return PyObject_CallNoArgs(k->memo_t);
    PyTypeObject *t = Py_TYPE(MEMO_PROTO);
    PyObject *o = t->tp_alloc(t, 0);
    if (o == NULL)
        return NULL;
    for (PyMemberDef *md = t->tp_members; md->name != NULL; md++)
        *(PyObject **)((char *)o + md->offset) = Py_XNewRef(*(PyObject **)((char *)MEMO_PROTO + md->offset));
    return o;
}

/* the object of a slot's tag and payload (new reference; *unset 1 and NULL for SR_UNSET) */
static PyObject *sr_get_obj(SrRead *r, const StoreKit *k, unsigned char tag, PyObject *table, int *unset,
                            SrLast *last, int slot)
{
    const char *p;
    Py_ssize_t n;
    *unset = 0;
    switch (tag) {
    case SR_UNSET:
        *unset = 1;
        return NULL;
    case SR_NONE:
        Py_RETURN_NONE;
    case SR_FALSE:
        Py_RETURN_FALSE;
    case SR_TRUE:
        Py_RETURN_TRUE;
    case SR_FLOAT:
    case SR_INT:
        if ((p = sr_take(r, 8)) == NULL)
            return NULL;
        return sr_number(last, slot, p, tag == SR_FLOAT);
    case SR_INTERN: {
        uint32_t q;
        if ((p = sr_take(r, 4)) == NULL)
            return NULL;
        memcpy(&q, p, 4);
        if ((Py_ssize_t)q >= PyList_GET_SIZE(table)) {
            PyErr_SetString(PyExc_ValueError, "StrokeStore: an interned object's index out of its table");
            return NULL;
        }
        return Py_NewRef(PyList_GET_ITEM(table, q));
    }
    case SR_DARRAY:
        if ((p = sr_doubles(r, &n)) == NULL)
            return NULL;
        return sr_array(k, p, n);
    case SR_POINTS: {
        if ((p = sr_doubles(r, &n)) == NULL)
            return NULL;
        PyObject *xy = sr_array(k, p, n);
        if (xy == NULL)
            return NULL;
        PyObject *pts = slots_new(&POINTS_MAP, &xy);
        Py_DECREF(xy);
        return pts;
    }
    case SR_ARC: {
        if ((p = sr_take(r, 8 * SA_NDBL + 1)) == NULL)
            return NULL;
        PyTypeObject *t = (PyTypeObject *)k->arc_t;
        PyObject *a = t->tp_alloc(t, 0);
        if (a == NULL)
            return NULL;
        for (int j = 0; j < SA_N; j++) {
            PyObject *x;
            if (j < SA_NDBL) {
                double v;
                memcpy(&v, p + 8 * j, 8);
                if ((x = PyFloat_FromDouble(v)) == NULL) {
                    Py_DECREF(a);
                    return NULL;
                }
            } else {
                x = Py_NewRef((p[8 * SA_NDBL] >> (j - SA_NDBL)) & 1 ? Py_True : Py_False);
            }
            *(PyObject **)((char *)a + sr_arc_off[j]) = x;
        }
        return a;
    }
    case SR_MEMO:
        return sr_memo(k);
    }
    PyErr_Format(PyExc_ValueError, "StrokeStore: unknown tag %d (corrupt store)", (int)tag);
    return NULL;
}

static inline __attribute__((always_inline)) int sr_skip(SrRead *r, unsigned char tag);

/* a new stroke of the record r (its bytes exactly), record q of its call: a slot j with a
 * list over[j] (its bit in over_bits; else NULL) takes over[j][q] where that is not None,
 * its payload skipped (StoredStrokes' side tables: the kept objects given back in the
 * decode, not made and then replaced a setattr at a time) */
static PyObject *sr_decode(SrRead *r, const StoreKit *k, PyObject *table, SrLast *last, PyObject *const *over,
                           uint32_t over_bits, Py_ssize_t q)
{
    const char *p = sr_take(r, SR_HEAD);
    if (p == NULL)
        return NULL;
    PyObject *o = k->stroke_t->tp_alloc(k->stroke_t, 0);
    if (o == NULL)
        return NULL;
    StrokeObject *s = (StrokeObject *)o;           /* (zeroed: odd 0, extra NULL, slots NULL) */
    uint32_t has;
    memcpy(s->d, p, SD_N * 8);
    memcpy(s->i, p + SD_N * 8, SI_N * 8);
    memcpy(&has, p + SD_N * 8 + SI_N * 8, 4);
    s->has = has;
    const unsigned char *tags = (const unsigned char *)p + SR_TAGS;
    for (int j = 0; j < SO_N; j++) {
        int unset = 0;
        PyObject *v;
        PyObject *x = (over_bits >> j) & 1 ? PyList_GET_ITEM(over[j], q) : Py_None;
        if (x != Py_None)
            v = sr_skip(r, tags[j]) < 0 ? NULL : Py_NewRef(x);
        else
            v = sr_get_obj(r, k, tags[j], table, &unset, last, j);
        if (v == NULL && !unset) {
            Py_DECREF(o);
            return NULL;
        }
        s->o[j] = v;
    }
    if (r->p != r->end) {
        Py_DECREF(o);
        PyErr_SetString(PyExc_ValueError, "StrokeStore: a record longer than its fields (corrupt store)");
        return NULL;
    }
    return o;
}

/* store_decode's over (None, or a dict {object slot: a list of one value a record, n at
 * least}) as a list a slot, NULL where none (borrowed) */
static int sr_over(PyObject *over_o, Py_ssize_t n, PyObject **over, uint32_t *bits)
{
    *bits = 0;
    for (int j = 0; j < SO_N; j++)
        over[j] = NULL;
    if (over_o == Py_None)
        return 0;
    if (!PyDict_Check(over_o)) {
        PyErr_SetString(PyExc_TypeError, "store_decode: over must be None or a dict {slot: list}");
        return -1;
    }
    PyObject *key, *val;
    Py_ssize_t pos = 0;
    while (PyDict_Next(over_o, &pos, &key, &val)) {
        long j = PyLong_AsLong(key);
        if (j == -1 && PyErr_Occurred())
            return -1;
        if (j < 0 || j >= SO_N || !PyList_CheckExact(val) || PyList_GET_SIZE(val) < n) {
            PyErr_SetString(PyExc_ValueError, "store_decode: over's slot out of range or its list too short");
            return -1;
        }
        over[j] = val;
        *bits |= (uint32_t)1 << j;
    }
    return 0;
}

/* store_decode(buf, offs, lens, kit, table, out[, over]): a new stroke of each record
 * buf[offs[q]:offs[q] + lens[q]] appended to the list out; over: sr_over's, sr_decode's */
static PyObject *mod_store_decode(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *buf_o, *offs_o, *lens_o, *kit_o, *table, *out, *over_o = Py_None;
    if (!PyArg_ParseTuple(args, "OOOOO!O!|O:store_decode", &buf_o, &offs_o, &lens_o, &kit_o, &PyList_Type, &table,
                          &PyList_Type, &out, &over_o))
        return NULL;
    StoreKit k;
    if (store_kit(kit_o, &k) < 0)
        return NULL;
    Py_buffer bb, ob, lb;
    if (PyObject_GetBuffer(buf_o, &bb, PyBUF_SIMPLE) < 0)
        return NULL;
    Py_ssize_t n = PyObject_Length(offs_o);
    if (n < 0 || stroke_buf(offs_o, &ob, n, 1, 0, "store_decode") < 0) {
        PyBuffer_Release(&bb);
        return NULL;
    }
    if (stroke_buf(lens_o, &lb, n, 1, 0, "store_decode") < 0) {
        PyBuffer_Release(&bb);
        PyBuffer_Release(&ob);
        return NULL;
    }
    const long long *offs = ob.buf, *lens = lb.buf;
    PyObject *over[SO_N];
    uint32_t over_bits;
    int rc = sr_over(over_o, n, over, &over_bits);
    SrLast last = {{NULL}, {0}};
    for (Py_ssize_t q = 0; q < n && rc == 0; q++) {
        if (offs[q] < 0 || lens[q] < 0 || offs[q] + lens[q] > bb.len) {
            PyErr_SetString(PyExc_ValueError, "store_decode: a record out of the buffer");
            rc = -1;
            break;
        }
        SrRead r = {(const char *)bb.buf + offs[q], (const char *)bb.buf + offs[q] + lens[q]};
        PyObject *st = sr_decode(&r, &k, table, &last, over, over_bits, q);
        rc = st == NULL || PyList_Append(out, st) < 0 ? -1 : 0;
        Py_XDECREF(st);
    }
    for (int j = 0; j < SO_N; j++)
        Py_XDECREF(last.obj[j]);
    PyBuffer_Release(&bb);
    PyBuffer_Release(&ob);
    PyBuffer_Release(&lb);
    if (rc < 0)
        return NULL;
    Py_RETURN_NONE;
}

/* a slot's payload skipped (r past it); -1 with an error */
/* a payload's bytes by its tag byte: fixed, SR_LEN_COUNT (an array's and Points': by their
 * count) or SR_LEN_BAD (no such tag) */
enum { SR_LEN_COUNT = -1, SR_LEN_BAD = -2 };
#define SR_BAD4 SR_LEN_BAD, SR_LEN_BAD, SR_LEN_BAD, SR_LEN_BAD
#define SR_BAD16 SR_BAD4, SR_BAD4, SR_BAD4, SR_BAD4
static const Py_ssize_t SR_PAYLOAD_LEN[256] = {
    [SR_UNSET] = 0, [SR_NONE] = 0, [SR_FALSE] = 0, [SR_TRUE] = 0, [SR_FLOAT] = 8, [SR_INT] = 8, [SR_INTERN] = 4,
    [SR_DARRAY] = SR_LEN_COUNT, [SR_POINTS] = SR_LEN_COUNT, [SR_ARC] = 8 * SA_NDBL + 1, [SR_MEMO] = 0,
    SR_LEN_BAD, SR_LEN_BAD, SR_LEN_BAD, SR_LEN_BAD, SR_LEN_BAD,       /* 11 .. 15 */
    SR_BAD16, SR_BAD16, SR_BAD16, SR_BAD16, SR_BAD16, SR_BAD16, SR_BAD16, SR_BAD16,
    SR_BAD16, SR_BAD16, SR_BAD16, SR_BAD16, SR_BAD16, SR_BAD16, SR_BAD16};
#undef SR_BAD16
#undef SR_BAD4

static inline __attribute__((always_inline)) int sr_skip(SrRead *r, unsigned char tag)
{
    Py_ssize_t n;
    switch (tag) {
    case SR_UNSET: case SR_NONE: case SR_FALSE: case SR_TRUE: case SR_MEMO:
        return 0;
    case SR_FLOAT: case SR_INT:
        return sr_take(r, 8) ? 0 : -1;
    case SR_INTERN:
        return sr_take(r, 4) ? 0 : -1;
    case SR_DARRAY: case SR_POINTS:
        return sr_doubles(r, &n) ? 0 : -1;
    case SR_ARC:
        return sr_take(r, 8 * SA_NDBL + 1) ? 0 : -1;
    }
    PyErr_Format(PyExc_ValueError, "StrokeStore: unknown tag %d (corrupt store)", (int)tag);
    return -1;
}

/* store_column(buf, offs, lens, field, out, none): field `field` (a record field number:
 * double k < SD_N, int SD_N + k, object slot SD_N + SI_N + k) of each record into out
 * (float64 or int64 by its format): a float its bits (into int64: refused), an int its value
 * (into float64 as float(x)), a bool 0 / 1; None (an unset slot, a None-able double's None)
 * as NaN into float64 (refused into int64) with none[q] = 1 (none: a uint8 buffer or None) */
static PyObject *mod_store_column(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *buf_o, *offs_o, *lens_o, *out_o, *none_o;
    int field;
    if (!PyArg_ParseTuple(args, "OOOiOO:store_column", &buf_o, &offs_o, &lens_o, &field, &out_o, &none_o))
        return NULL;
    if (field < 0 || field >= SD_N + SI_N + SO_N) {
        PyErr_SetString(PyExc_ValueError, "store_column: no such field");
        return NULL;
    }
    Py_buffer bb, ob, lb, vb, nb = {0};
    if (PyObject_GetBuffer(buf_o, &bb, PyBUF_SIMPLE) < 0)
        return NULL;
    Py_ssize_t n = PyObject_Length(offs_o);
    int got = 1;
    if (n < 0 || stroke_buf(offs_o, &ob, n, 1, 0, "store_column") < 0)
        goto fail;
    got = 2;
    if (stroke_buf(lens_o, &lb, n, 1, 0, "store_column") < 0)
        goto fail;
    got = 3;
    if (PyObject_GetBuffer(out_o, &vb, PyBUF_WRITABLE | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        goto fail;
    got = 4;
    int is_int = vb.format && (!strcmp(vb.format, "q") || !strcmp(vb.format, "l"));
    if (vb.itemsize != 8 || vb.len < 8 * n || !(is_int || (vb.format && !strcmp(vb.format, "d")))) {
        PyErr_SetString(PyExc_ValueError, "store_column: out must be a float64 or int64 buffer of len(offs)");
        goto fail;
    }
    if (none_o != Py_None) {
        if (PyObject_GetBuffer(none_o, &nb, PyBUF_WRITABLE) < 0)
            goto fail;
        got = 5;
        if (nb.len < n) {
            PyErr_SetString(PyExc_ValueError, "store_column: none must be a uint8 buffer of len(offs)");
            goto fail;
        }
    }
    const long long *offs = ob.buf, *lens = lb.buf;
    double *fo = vb.buf;
    long long *io = vb.buf;
    unsigned char *no = nb.buf;
    for (Py_ssize_t q = 0; q < n; q++) {
        if (offs[q] < 0 || lens[q] < SR_HEAD || offs[q] + lens[q] > bb.len) {
            PyErr_SetString(PyExc_ValueError, "store_column: a record out of the buffer");
            goto fail;
        }
        SrRead r = {(const char *)bb.buf + offs[q], (const char *)bb.buf + offs[q] + lens[q]};
        const char *p = r.p;
        int none = 0, kind;                /* kind: 0 double x, 1 int i */
        double x = 0.0;
        long long i = 0;
        if (field < SD_N) {
            uint32_t has;
            memcpy(&has, p + SD_N * 8 + SI_N * 8, 4);
            memcpy(&x, p + 8 * field, 8);
            kind = 0;
            none = field >= SD_NONE0 && !(has & (1u << (field - SD_NONE0)));
        } else if (field < SD_N + SI_N) {
            memcpy(&i, p + 8 * field, 8);
            kind = 1;
        } else {
            int slot = field - SD_N - SI_N;
            const unsigned char *tags = (const unsigned char *)p + SR_TAGS;
            r.p += SR_HEAD;
            for (int j = 0; j < slot; j++)
                if (sr_skip(&r, tags[j]) < 0)
                    goto fail;
            unsigned char t = tags[slot];
            const char *v = t == SR_FLOAT || t == SR_INT ? sr_take(&r, 8) : r.p;
            if (v == NULL)
                goto fail;
            if (t == SR_FLOAT) {
                memcpy(&x, v, 8);
                kind = 0;
            } else if (t == SR_INT) {
                memcpy(&i, v, 8);
                kind = 1;
            } else if (t == SR_FALSE || t == SR_TRUE) {
                i = t == SR_TRUE;
                kind = 1;
            } else if (t == SR_NONE || t == SR_UNSET) {
                none = 1;
                kind = 0;
            } else {
                PyErr_Format(PyExc_TypeError, "store_column: record %zd's field is not a number", q);
                goto fail;
            }
        }
        if (none) {
            if (is_int) {
                PyErr_Format(PyExc_TypeError, "store_column: record %zd's field is None (an int64 column)", q);
                goto fail;
            }
            x = NAN;
            kind = 0;
        }
        if (is_int) {
            if (kind == 0) {
                PyErr_Format(PyExc_TypeError, "store_column: record %zd's field is a float (an int64 column)", q);
                goto fail;
            }
            io[q] = i;
        } else {
            fo[q] = kind == 0 ? x : (double)i;
        }
        if (no)
            no[q] = (unsigned char)none;
    }
    PyBuffer_Release(&bb);
    PyBuffer_Release(&ob);
    PyBuffer_Release(&lb);
    PyBuffer_Release(&vb);
    if (got >= 5)
        PyBuffer_Release(&nb);
    Py_RETURN_NONE;
fail:
    PyBuffer_Release(&bb);
    if (got >= 2)
        PyBuffer_Release(&ob);
    if (got >= 3)
        PyBuffer_Release(&lb);
    if (got >= 4)
        PyBuffer_Release(&vb);
    if (got >= 5)
        PyBuffer_Release(&nb);
    return NULL;
}

/* store_fields(buf, offs, lens, codes, vals, kinds[, ints]): the fields `codes` (a tuple of record
 * field numbers, as store_column's) of each record, as stroke_fields reads a stroke's:
 * vals (float64, len(offs) x len(codes), C order) and kinds (int8, the same shape) -- 0 a
 * float (a double field's value), 1 None (vals the NaN stroke_fields gives it), 2 a bool
 * (1.0 / 0.0), 3 another object (an int, an array, points, an arc, a memo; vals 0.0),
 * 4 an unset slot (0.0), 5 a shared object (vals its index in the store's table); an int
 * field (first_idx, last_idx): kind 0, vals holding its int64's bits.  ints true: an object
 * slot holding an int is kind 6, vals its int64's bits (stroke_store's side columns; else
 * kind 3, as stroke_fields reads it).  No stroke made (segments.line_classes of stored
 * strokes: no window loaded). */
static PyObject *mod_store_fields(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *buf_o, *offs_o, *lens_o, *codes_o, *vals_o, *kinds_o;
    int ints = 0;
    if (!PyArg_ParseTuple(args, "OOOO!OO|p:store_fields", &buf_o, &offs_o, &lens_o, &PyTuple_Type, &codes_o, &vals_o,
                          &kinds_o, &ints))
        return NULL;
    Py_ssize_t w;
    int codes[64], last_slot;
    if (sr_codes(codes_o, codes, &w, &last_slot, "store_fields") < 0)
        return NULL;
    SrPlan plan;
    sr_plan(codes, w, &plan);
    Py_buffer bb, ob, lb, vb, kb;
    if (PyObject_GetBuffer(buf_o, &bb, PyBUF_SIMPLE) < 0)
        return NULL;
    Py_ssize_t n = PyObject_Length(offs_o);
    int got = 1, out_got = 0;
    if (n < 0 || stroke_buf(offs_o, &ob, n, 1, 0, "store_fields") < 0)
        goto fail;
    got = 2;
    if (stroke_buf(lens_o, &lb, n, 1, 0, "store_fields") < 0)
        goto fail;
    got = 3;
    if (sr_fields_out(vals_o, kinds_o, n, w, &vb, &kb, &out_got, "store_fields") < 0)
        goto fail;
    const long long *offs = ob.buf, *lens = lb.buf;
    double *vals = vb.buf;
    signed char *kinds = kb.buf;
    for (Py_ssize_t q = 0; q < n; q++) {
        if (offs[q] < 0 || lens[q] < SR_HEAD || offs[q] + lens[q] > bb.len) {
            PyErr_SetString(PyExc_ValueError, "store_fields: a record out of the buffer");
            goto fail;
        }
        const char *p = (const char *)bb.buf + offs[q];
        const unsigned char *tags = (const unsigned char *)p + SR_TAGS;
        Py_ssize_t at[SO_N];
        /* each object slot's payload: its place by a table of the fixed lengths (sr_skip's
         * steps, ~25 instructions a slot, were most of the time of a side's or the summary's read) */
        Py_ssize_t o = SR_HEAD, len = lens[q];
        for (int s = 0; s <= last_slot; s++) {
            unsigned char t = tags[s];
            Py_ssize_t step = SR_PAYLOAD_LEN[t];
            at[s] = o;
            if (step < 0) {
                uint32_t c;
                if (step == SR_LEN_BAD) {
                    PyErr_Format(PyExc_ValueError, "StrokeStore: unknown tag %d (corrupt store)", (int)t);
                    goto fail;
                }
                if (len - o < 4)
                    goto past_end;
                memcpy(&c, p + o, 4);
                step = 4 + 8 * (Py_ssize_t)c;
            }
            o += step;
            if (o > len)
                goto past_end;
        }
        sr_fields_row(p, at, &plan, ints, vals + q * w, kinds + q * w);
    }
    PyBuffer_Release(&bb);
    PyBuffer_Release(&ob);
    PyBuffer_Release(&lb);
    PyBuffer_Release(&vb);
    PyBuffer_Release(&kb);
    Py_RETURN_NONE;
past_end:
    PyErr_SetString(PyExc_ValueError, "StrokeStore: a record runs past its end (corrupt store)");
fail:
    PyBuffer_Release(&bb);
    if (got >= 2)
        PyBuffer_Release(&ob);
    if (got >= 3)
        PyBuffer_Release(&lb);
    if (out_got >= 1)
        PyBuffer_Release(&vb);
    if (out_got >= 2)
        PyBuffer_Release(&kb);
    return NULL;
}

/* The measure's quiet stops (play_buf's on_quiet: a stop with no watched range pending,
 * ~3.8 k of the rectilinear plate's) recorded without a Python object each: what
 * simulate._LedgerWriter.stopped does there (the peaks and sums taken as take_stop takes
 * them, the carried peaks raised, the stop and its snapshot kept as `last`) costs ~4.1 k
 * instructions a stop, nearly all of it objects made and dropped (take_stop's tuple, the
 * sums' bytes, `last`'s tuple, the attributes' traffic).  A QuietStops keeps the last
 * stop's line, snapshot and sums row, and the peaks' running maximum (as stopped's strict
 * `>`: the first of equal values kept); the writer folds them in (quiet_take) when play_buf
 * returns, before anything reads them. */
typedef struct {
    PyObject_HEAD
    ResObject *res;                   /* the pass's SimResult (new reference) */
    PyObject *snap_fn, *snap_arg;     /* a stop's snapshot: snap_fn(snap_arg) (new references) */
    PyObject *snap;                   /* the last stop's snapshot (new reference), NULL: no stop kept */
    long long idx;                    /* the last stop's line */
    double row[RES_SUMS_N];           /* its sums, as take_stop's */
    double peak_v, peak_a;            /* the stops' peaks since the last quiet_take, -inf: none */
} QuietObject;

static void Quiet_dealloc(QuietObject *q)
{
    Py_XDECREF(q->res);
    Py_XDECREF(q->snap_fn);
    Py_XDECREF(q->snap_arg);
    Py_XDECREF(q->snap);
    PyObject_Free(q);
}

static PyTypeObject QuietType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_fwcore.QuietStops",
    .tp_doc = "The measure's quiet stops since the writer last took them (quiet_new, quiet_record, quiet_take).",
    .tp_basicsize = sizeof(QuietObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_dealloc = (destructor)Quiet_dealloc,
};

/* quiet_new(res, snap_fn, snap_arg): a QuietStops of the compiled SimResult res, each stop's
 * snapshot snap_fn(snap_arg) */
static PyObject *mod_quiet_new(PyObject *module, PyObject *args)
{
    PyObject *res, *fn, *arg;
    (void)module;
    if (!PyArg_ParseTuple(args, "O!OO", &ResType, &res, &fn, &arg))
        return NULL;
    if (!(QuietType.tp_flags & Py_TPFLAGS_READY) && PyType_Ready(&QuietType) < 0)
        return NULL;
    QuietObject *q = PyObject_New(QuietObject, &QuietType);
    if (q == NULL)
        return NULL;
    q->res = (ResObject *)Py_NewRef(res);
    q->snap_fn = Py_NewRef(fn);
    q->snap_arg = Py_NewRef(arg);
    q->snap = NULL;
    q->idx = -1;
    memset(q->row, 0, sizeof q->row);
    q->peak_v = q->peak_a = -INFINITY;
    return (PyObject *)q;
}

/* x raised to v where v > x (stopped's test: a NaN never raises it, the first of equal
 * values is kept) */
static inline void quiet_raise(double *x, double v)
{
    if (v > *x)
        *x = v;
}

/* quiet_record(q, idx): the model stands empty after line idx (play_buf's on_quiet, bound
 * to q): the peaks since the last stop taken (the SimResult's then 0.0, as take_stop), the
 * sums row and the state's snapshot kept as the last stop */
static PyObject *mod_quiet_record(PyObject *module, PyObject *const *args, Py_ssize_t nargs)
{
    (void)module;
    if (nargs != 2 || Py_TYPE(args[0]) != &QuietType) {
        PyErr_SetString(PyExc_TypeError, "quiet_record(QuietStops, idx)");
        return NULL;
    }
    QuietObject *q = (QuietObject *)args[0];
    long long idx = PyLong_AsLongLong(args[1]);
    if (idx == -1 && PyErr_Occurred())
        return NULL;
    PyObject *snap = PyObject_CallOneArg(q->snap_fn, q->snap_arg);
    if (snap == NULL)
        return NULL;
    ResObject *r = q->res;
    res_sums_row(r, q->row);
    quiet_raise(&q->peak_v, r->peak_v);
    quiet_raise(&q->peak_a, r->peak_a);
    r->peak_v = r->peak_a = 0.0;
    Py_XSETREF(q->snap, snap);
    q->idx = idx;
    Py_RETURN_NONE;
}

/* quiet_take(q): None if no stop was recorded since the last take, else (idx, snapshot, sums,
 * peak_v, peak_a) of them: the last stop's line, snapshot and sums (take_stop's bytes), the
 * peaks' maximum; q then holds none */
static PyObject *mod_quiet_take(PyObject *module, PyObject *arg)
{
    (void)module;
    if (Py_TYPE(arg) != &QuietType) {
        PyErr_SetString(PyExc_TypeError, "quiet_take(QuietStops)");
        return NULL;
    }
    QuietObject *q = (QuietObject *)arg;
    if (q->snap == NULL)
        Py_RETURN_NONE;
    PyObject *t = Py_BuildValue("(LOy#dd)", q->idx, q->snap, (const char *)q->row, (Py_ssize_t)sizeof q->row,
                                q->peak_v, q->peak_a);
    if (t == NULL)
        return NULL;
    Py_CLEAR(q->snap);
    q->peak_v = q->peak_a = -INFINITY;
    return t;
}

/* The measure's ledger writer (simulate._LedgerWriter's range_starts, ranges_start and stopped)
 * in C, for play_buf's whole pass: with a LedgerCore as on_quiet, play_loop records every
 * stop and every watched range's start where it meets them and returns only at a block's end
 * (each stop with a range pending returned to Python: ~1.2 k returns of ~15 k instructions on
 * the rectilinear plate's measure).  The writer's state (the last stop, its entry, the carried
 * peaks, the pending ranges) lives here for the pass; the ledger's entries wait in small C
 * buffers appended to the Ledger's arrays as each fills (LED_FLUSH_BYTES: with 4 kB, the
 * windowed rectilinear plate's peak RSS rose ~0.3 MB, heap layout) and at ledger_flush
 * (each snapshot goes into its state list at once); ledger_done hands the state back to the
 * _LedgerWriter for finish(). */
typedef struct {
    char *p;
    Py_ssize_t n, cap;                /* bytes held, room */
    PyObject *put;                    /* the Ledger's array's frombytes (new reference) */
} LedBuf;

enum { LB_LINE, LB_SUMS, LB_PV, LB_PA, LB_LO, LB_HI, LB_N };
#define LED_FLUSH_BYTES 512
static const char *const LB_NAMES[LB_N] = {"line", "sums", "peak_v", "peak_a", "lo", "hi"};

typedef struct {
    PyObject_HEAD
    ResObject *res;                   /* the pass's SimResult (new reference) */
    PyObject *snap_fn, *snap_arg;     /* a stop's snapshot: snap_fn(snap_arg) (new references) */
    PyObject *states;                 /* its state list (new reference) */
    Py_buffer w_last;                 /* each watched range's last line (int64) */
    PyObject *last_snap;              /* the last stop's snapshot (new reference) */
    long long last_idx, last_j;       /* its line; its ledger entry, -1: not committed */
    double last_row[RES_SUMS_N];      /* its sums */
    double carry_v, carry_a;          /* the peaks since the last committed stop */
    long long n_commits;              /* the Ledger's entries (len(line)), flushed or not */
    Py_ssize_t n_pend, pend_last;     /* the ranges started, not yet closed by a stop; the last one */
    int ok;                           /* 0: a stop fell inside a watched range */
    LedBuf buf[LB_N];
} LedgerObject;

static void Ledger_dealloc(LedgerObject *lc)
{
    Py_XDECREF(lc->res);
    Py_XDECREF(lc->snap_fn);
    Py_XDECREF(lc->snap_arg);
    Py_XDECREF(lc->states);
    Py_XDECREF(lc->last_snap);
    if (lc->w_last.obj != NULL)
        PyBuffer_Release(&lc->w_last);
    for (int b = 0; b < LB_N; b++) {
        PyMem_Free(lc->buf[b].p);
        Py_XDECREF(lc->buf[b].put);
    }
    PyObject_Free(lc);
}

static PyTypeObject LedgerType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_gcode_opt_fwcore.LedgerCore",
    .tp_doc = "The measure's ledger writer for play_buf (ledger_new, ledger_flush, ledger_done).",
    .tp_basicsize = sizeof(LedgerObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_dealloc = (destructor)Ledger_dealloc,
};

/* n bytes at v appended to b */
static int ledbuf_put(LedBuf *b, const void *v, Py_ssize_t n)
{
    if (b->n + n > b->cap) {
        Py_ssize_t cap = b->cap ? 2 * b->cap : 2 * LED_FLUSH_BYTES;
        while (cap < b->n + n)
            cap *= 2;
        char *p = PyMem_Realloc(b->p, (size_t)cap);
        if (p == NULL) {
            PyErr_NoMemory();
            return -1;
        }
        b->p = p;
        b->cap = cap;
    }
    memcpy(b->p + b->n, v, (size_t)n);
    b->n += n;
    return 0;
}

/* k copies of the entry j appended to b (lo's or hi's: _repeat(j, k)) */
static int ledbuf_repeat(LedBuf *b, long long j, Py_ssize_t k)
{
    for (Py_ssize_t q = 0; q < k; q++)
        if (ledbuf_put(b, &j, sizeof j) < 0)
            return -1;
    return 0;
}

/* the entries lb holds appended to its array (a view of the buffer to frombytes: no bytes
 * copy made and dropped between the array's growths) */
static int ledbuf_flush(LedBuf *lb)
{
    if (lb->n == 0)
        return 0;
    PyObject *view = PyMemoryView_FromMemory(lb->p, lb->n, PyBUF_READ);
    PyObject *r = view != NULL ? PyObject_CallOneArg(lb->put, view) : NULL;
    Py_XDECREF(view);
    if (r == NULL)
        return -1;
    Py_DECREF(r);
    lb->n = 0;
    return 0;
}

/* every buffer's entries appended to its array (each array's stay in order) */
static int ledger_flush_all(LedgerObject *lc)
{
    for (int b = 0; b < LB_N; b++)
        if (ledbuf_flush(&lc->buf[b]) < 0)
            return -1;
    return 0;
}

/* lb flushed once it holds LED_FLUSH_BYTES */
static inline int ledbuf_full(LedBuf *lb)
{
    return lb->n >= LED_FLUSH_BYTES ? ledbuf_flush(lb) : 0;
}

/* Ledger._commit(line, snap, row, peak_v, peak_a): the new entry's index, or -1 on error */
static long long ledger_commit(LedgerObject *lc, long long line, PyObject *snap, const double *row,
                               double peak_v, double peak_a)
{
    if (ledbuf_put(&lc->buf[LB_LINE], &line, sizeof line) < 0 || PyList_Append(lc->states, snap) < 0
        || ledbuf_put(&lc->buf[LB_SUMS], row, RES_SUMS_N * sizeof(double)) < 0
        || ledbuf_put(&lc->buf[LB_PV], &peak_v, sizeof peak_v) < 0
        || ledbuf_put(&lc->buf[LB_PA], &peak_a, sizeof peak_a) < 0 || ledbuf_full(&lc->buf[LB_LINE]) < 0
        || ledbuf_full(&lc->buf[LB_SUMS]) < 0 || ledbuf_full(&lc->buf[LB_PV]) < 0 || ledbuf_full(&lc->buf[LB_PA]) < 0)
        return -1;
    return lc->n_commits++;
}

/* range_starts k times over (_LedgerWriter.ranges_start(k)); wi: the next range after them */
static int ledger_starts(PyObject *o, Py_ssize_t k, Py_ssize_t wi)
{
    LedgerObject *lc = (LedgerObject *)o;
    if (lc->last_j < 0) {
        lc->last_j = ledger_commit(lc, lc->last_idx, lc->last_snap, lc->last_row, lc->carry_v, lc->carry_a);
        if (lc->last_j < 0)
            return -1;
        lc->carry_v = lc->carry_a = 0.0;
    }
    if (ledbuf_repeat(&lc->buf[LB_LO], lc->last_j, k) < 0 || ledbuf_full(&lc->buf[LB_LO]) < 0)
        return -1;
    lc->n_pend += k;
    lc->pend_last = wi - 1;
    return 0;
}

/* _LedgerWriter.stopped(idx): the model stands empty after line idx */
static int ledger_stop(PyObject *o, long long idx)
{
    LedgerObject *lc = (LedgerObject *)o;
    PyObject *snap = PyObject_CallOneArg(lc->snap_fn, lc->snap_arg);
    if (snap == NULL)
        return -1;
    ResObject *r = lc->res;
    double peak_v = r->peak_v, peak_a = r->peak_a;     /* (take_stop's: read, then 0.0) */
    r->peak_v = r->peak_a = 0.0;
    res_sums_row(r, lc->last_row);
    if (peak_v > lc->carry_v)
        lc->carry_v = peak_v;
    if (peak_a > lc->carry_a)
        lc->carry_a = peak_a;
    Py_XSETREF(lc->last_snap, snap);
    lc->last_idx = idx;
    lc->last_j = -1;
    if (lc->n_pend) {
        const long long *w_last = (const long long *)lc->w_last.buf;
        if (lc->pend_last < 0 || lc->pend_last >= lc->w_last.len / (Py_ssize_t)sizeof(long long)) {
            PyErr_SetString(PyExc_IndexError, "LedgerCore: a pending range past w_last");
            return -1;
        }
        if (w_last[lc->pend_last] >= idx)           /* a stop inside a watched range */
            lc->ok = 0;
        lc->last_j = ledger_commit(lc, idx, snap, lc->last_row, lc->carry_v, lc->carry_a);
        if (lc->last_j < 0)
            return -1;
        lc->carry_v = lc->carry_a = 0.0;
        if (ledbuf_repeat(&lc->buf[LB_HI], lc->last_j, lc->n_pend) < 0 || ledbuf_full(&lc->buf[LB_HI]) < 0)
            return -1;
        lc->n_pend = 0;
    }
    return 0;
}

/* ledger_new(res, snap_fn, snap_arg, w_last, led, last_snap, last_sums): a LedgerCore of a
 * writer just made (_LedgerWriter.__init__: the last stop before the file, line -1, with
 * last_snap and last_sums (its bytes), not committed; nothing carried or pending) writing
 * into the Ledger led (empty; its state a list) */
static PyObject *mod_ledger_new(PyObject *module, PyObject *args)
{
    PyObject *res, *fn, *arg, *w_last, *led, *snap;
    Py_buffer sums;
    (void)module;
    if (!PyArg_ParseTuple(args, "O!OOOOOy*", &ResType, &res, &fn, &arg, &w_last, &led, &snap, &sums))
        return NULL;
    if (sums.len != (Py_ssize_t)(RES_SUMS_N * sizeof(double))) {
        PyBuffer_Release(&sums);
        PyErr_SetString(PyExc_ValueError, "ledger_new: last_sums is not eleven doubles");
        return NULL;
    }
    PyObject *states = PyObject_GetAttrString(led, "state");
    if (states == NULL || !PyList_CheckExact(states)) {
        Py_XDECREF(states);
        PyBuffer_Release(&sums);
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_TypeError, "ledger_new: the Ledger's state is not a list");
        return NULL;
    }
    LedgerObject *lc = NULL;
    if ((LedgerType.tp_flags & Py_TPFLAGS_READY) || PyType_Ready(&LedgerType) == 0)
        lc = PyObject_New(LedgerObject, &LedgerType);
    if (lc == NULL) {
        Py_DECREF(states);
        PyBuffer_Release(&sums);
        return NULL;
    }
    memset((char *)lc + offsetof(LedgerObject, res), 0, sizeof(LedgerObject) - offsetof(LedgerObject, res));
    memcpy(lc->last_row, sums.buf, sizeof lc->last_row);
    PyBuffer_Release(&sums);
    lc->res = (ResObject *)Py_NewRef(res);
    lc->snap_fn = Py_NewRef(fn);
    lc->snap_arg = Py_NewRef(arg);
    lc->states = states;
    lc->last_snap = Py_NewRef(snap);
    lc->last_idx = lc->last_j = -1;
    lc->pend_last = -1;
    lc->ok = 1;
    if (PyObject_GetBuffer(w_last, &lc->w_last, PyBUF_SIMPLE) < 0) {
        lc->w_last.obj = NULL;
        Py_DECREF(lc);
        return NULL;
    }
    for (int b = 0; b < LB_N; b++) {
        PyObject *arr = PyObject_GetAttrString(led, LB_NAMES[b]);
        lc->buf[b].put = arr != NULL ? PyObject_GetAttrString(arr, "frombytes") : NULL;
        Py_XDECREF(arr);
        if (lc->buf[b].put == NULL) {
            Py_DECREF(lc);
            return NULL;
        }
    }
    return (PyObject *)lc;
}

/* ledger_flush(lc): the entries lc holds appended to its Ledger's arrays; lc then holds none */
static PyObject *mod_ledger_flush(PyObject *module, PyObject *o)
{
    (void)module;
    if (Py_TYPE(o) != &LedgerType) {
        PyErr_SetString(PyExc_TypeError, "ledger_flush(LedgerCore)");
        return NULL;
    }
    if (ledger_flush_all((LedgerObject *)o) < 0)
        return NULL;
    Py_RETURN_NONE;
}

/* ledger_done(lc): (last_idx, last_snap, last_sums, last_j, carry_v, carry_a, n_pending, ok):
 * the writer's state for _LedgerWriter.finish (flush first) */
static PyObject *mod_ledger_done(PyObject *module, PyObject *o)
{
    (void)module;
    if (Py_TYPE(o) != &LedgerType) {
        PyErr_SetString(PyExc_TypeError, "ledger_done(LedgerCore)");
        return NULL;
    }
    LedgerObject *lc = (LedgerObject *)o;
    return Py_BuildValue("(LOy#LddnO)", lc->last_idx, lc->last_snap, (const char *)lc->last_row,
                         (Py_ssize_t)sizeof lc->last_row, lc->last_j, lc->carry_v, lc->carry_a, lc->n_pend,
                         lc->ok ? Py_True : Py_False);
}

static PyMethodDef mod_methods[] = {
    {"alloc_choices", mod_alloc_choices, METH_VARARGS,
     "alloc_choices(Tx, Ix, k, rows, lam, margin_r, T_orig, dT, j, margin, tol): plan._allocate's choices() and take() of rows"},
    {"alloc_rows", mod_alloc_rows, METH_VARARGS,
     "alloc_rows(vT, vI, first, cnt, T_orig, I_orig, rows, lam, margin_r, dT, j, margin, tol[, ref]): alloc_choices on plan.Candidates' rows"},
    {"alloc_rise", mod_alloc_rise, METH_VARARGS,
     "alloc_rise(vT, vI, first, cnt, T_orig, I_orig, rows, lam, j, ref, dT, margin_r, margin, tol, kept): alloc_rows' "
     "choices at a higher lambda, "
     "costing again only rows whose choice may have moved; returns how many"},
    {"use_reader", mod_use_reader, METH_O,
     "use_reader(the reader's _C_API capsule, or None): Sim.play reads common lines through it"},
    {"setup", mod_setup, METH_VARARGS,
     "setup(Move, Arc, Limits, Barrier, LineRecord subclass, SimResult subclass, constants)"},
    {"ring_exp", mod_ring_exp, METH_VARARGS,
     "ring_exp(t, a, b, out): np.exp(complex(a, b) * t) for a real array t"},
    {"ring_amps", mod_ring_amps, METH_VARARGS,
     "ring_amps(t_ev, dc, s, wd, span, short_n, start, carry, t_carry, c, fused): amplitudes' restarts"},
    {"ring_int_r2", mod_ring_int_r2, METH_VARARGS,
     "ring_int_r2(c, dur, decay2, qr, qi, four_s, rat, scl, real_major, work): integral_r2_fin's sum"},
    {"ring_events", mod_ring_events, METH_VARARGS,
     "ring_events(m, carry (8 numbers), w2x, w2y, corner_cos, t_out, dr_out, drp_out[, all_only]): the ringing's events"},
    {"ring_rows_time", mod_ring_rows_time, METH_VARARGS,
     "ring_rows_time(m, r0, r1): float(m[r0:r1, 6:9].sum()), numpy's bits"},
    {"ring_jumps", mod_ring_jumps, METH_VARARGS,
     "ring_jumps(dr, drp, s, wd, out): Oscillator.jump_amplitude"},
    {"ring_solve", mod_ring_solve, METH_VARARGS,
     "ring_solve(t, dr, drp, first, s, wd, qr, qi, four_s, rat, scl, real_major[, floor]): "
     "_Stream._solve"},
    {"ring_join", mod_ring_join, METH_VARARGS,
     "ring_join(t1, dr1, drp1, has_last, nw, horizon, first, floor, s, wd, qr, qi, four_s, rat, scl, real_major): "
     "_Stream.add_joined without a shaper"},
    {"ring_release", mod_ring_release, METH_NOARGS,
     "ring_release(): ring_solve's room given back; returns the bytes it held"},
    {"jerk_tail", mod_jerk_tail, METH_VARARGS,
     "jerk_tail(S, V, acc, a_own, step, v_feed, K, min_feed_v, cruise_a, A, F, t, a2, fine): segments._jerk_rows' "
     "held accelerations, feeds, figures and verdicts"},
    {"hypot", mod_hypot, METH_VARARGS,
     "hypot(dx, dy): math.hypot's length computed in C; hypot(): whether run_lines and gap_lines use it"},
    {"stroke_lines", mod_stroke_lines, METH_VARARGS,
     "stroke_lines(strokes, lo, hi): their first_idx and last_idx into two int64 buffers; 0: declined"},
    {"stroke_put_sums", mod_stroke_put_sums, METH_VARARGS,
     "stroke_put_sums(strokes, got, v0, v1, t, a2, v2): pipeline._LogSums' sums written in; 0: declined"},
    {"stroke_fields", mod_stroke_fields, METH_VARARGS,
     "stroke_fields(strokes, names, vals, kinds): line_classes' fields as doubles and kinds; 0: declined"},
    {"ring_exps", mod_ring_exps, METH_VARARGS,
     "ring_exps(tt, s, wd, e1, e2): np.exp(-lam tt) and np.exp(lam tt), lam = -s + i wd"},
    {"store_encode", mod_store_encode, METH_VARARGS,
     "store_encode(strokes, i0, i1, kit, index, table, buf, lens[, codes, vals, kinds]): stroke_store's records "
     "of strokes[i0:i1] (codes: their fields as store_fields(..., ints=True) reads them, into vals and kinds)"},
    {"store_decode", mod_store_decode, METH_VARARGS,
     "store_decode(buf, offs, lens, kit, table, out[, over]): new strokes of stroke_store's records, appended "
     "to out; over: None or {object slot: a list of one value a record}, the value put where not None"},
    {"store_column", mod_store_column, METH_VARARGS,
     "store_column(buf, offs, lens, field, out, none): one numeric field of stroke_store's records"},
    {"store_fields", mod_store_fields, METH_VARARGS,
     "store_fields(buf, offs, lens, codes, vals, kinds[, ints]): fields of stroke_store's records as stroke_fields "
     "reads them (ints: an int slot's value, kind 6)"},
    {"quiet_new", mod_quiet_new, METH_VARARGS,
     "quiet_new(res, snap_fn, snap_arg): a QuietStops for play_buf's on_quiet (quiet_record bound to it)"},
    {"quiet_record", (PyCFunction)(void (*)(void))mod_quiet_record, METH_FASTCALL,
     "quiet_record(q, idx): a quiet stop after line idx kept in q (simulate._LedgerWriter.stopped's work)"},
    {"quiet_take", mod_quiet_take, METH_O,
     "quiet_take(q): None, or (idx, snapshot, sums, peak_v, peak_a) of q's stops since the last take"},
    {"ledger_new", mod_ledger_new, METH_VARARGS,
     "ledger_new(res, snap_fn, snap_arg, w_last, led, last_snap, last_sums): a LedgerCore for play_buf's on_quiet"},
    {"ledger_flush", mod_ledger_flush, METH_O,
     "ledger_flush(lc): lc's ledger entries appended to its Ledger"},
    {"ledger_done", mod_ledger_done, METH_O,
     "ledger_done(lc): (last_idx, last_snap, last_sums, last_j, carry_v, carry_a, n_pending, ok)"},
    {NULL}
};

static struct PyModuleDef core_module = {
    PyModuleDef_HEAD_INIT, "_gcode_opt_fwcore",
    "Compiled core of the firmware model (gcode_opt/firmware/_core.c; see simulate.py).", -1,
    mod_methods,
};

#ifndef FWCORE_SOURCE_SHA256
#define FWCORE_SOURCE_SHA256 ""
#endif
#ifndef GCODE_OPT_SOURCE_STAT   /* setup.py: the digest and the stat of each file it covers, when taken (native.stat_record) */
#define GCODE_OPT_SOURCE_STAT ""
#endif

/* STROKE_FIELDS_API's capsule added to m: 0, or -1 (an exception) */
static int add_stroke_fields(PyObject *m)
{
    PyObject *cap = PyCapsule_New((void *)&STROKE_FIELDS_API, "_gcode_opt_fwcore._STROKE_FIELDS", NULL);
    if (cap == NULL)
        return -1;
    int r = PyModule_AddObjectRef(m, "_STROKE_FIELDS", cap);
    Py_DECREF(cap);
    return r;
}

PyMODINIT_FUNC PyInit__gcode_opt_fwcore(void)
{
    if (PyType_Ready(&BlockType) < 0 || PyType_Ready(&RecType) < 0 || PyType_Ready(&ResType) < 0
        || PyType_Ready(&SimType) < 0 || PyType_Ready(&SinkType) < 0 || PyType_Ready(&SumsType) < 0
        || PyType_Ready(&LogType) < 0 || stroke_type_ready() < 0)
        return NULL;
    PyObject *m = PyModule_Create(&core_module);
    if (m == NULL)
        return NULL;
    hypot_init();
    Py_INCREF(&BlockType);
    Py_INCREF(&RecType);
    Py_INCREF(&ResType);
    Py_INCREF(&SimType);
    Py_INCREF(&SinkType);
    Py_INCREF(&SumsType);
    Py_INCREF(&LogType);
    if (PyModule_AddObject(m, "Block", (PyObject *)&BlockType) < 0
        || PyModule_AddObject(m, "LineRecord", (PyObject *)&RecType) < 0
        || PyModule_AddObject(m, "SimResult", (PyObject *)&ResType) < 0
        || PyModule_AddObject(m, "Sim", (PyObject *)&SimType) < 0
        || PyModule_AddObject(m, "RowSink", (PyObject *)&SinkType) < 0
        || PyModule_AddObject(m, "StrokeSums", (PyObject *)&SumsType) < 0
        || PyModule_AddObject(m, "RecordLog", (PyObject *)&LogType) < 0
        || PyModule_AddObject(m, "StrokeBase", Py_NewRef((PyObject *)&StrokeType)) < 0
        || add_stroke_fields(m) < 0
        || PyModule_AddStringConstant(m, "SOURCE_SHA256", FWCORE_SOURCE_SHA256) < 0
        || PyModule_AddStringConstant(m, "SOURCE_STAT", GCODE_OPT_SOURCE_STAT) < 0
        || PyModule_AddIntConstant(m, "PLAY_FIRSTS", 1) < 0
        || PyModule_AddIntConstant(m, "STORE_FIELDS_INTS", 1) < 0
        || PyModule_AddIntConstant(m, "STORE_ENCODE_FIELDS", 1) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
