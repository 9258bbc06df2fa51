/* A line's str as read_lines gives it: a line of ASCII bytes (nearly all) is copied into a
 * new str; any other is UTF-8's decoder's with surrogateescape (a line alone decodes as it
 * would in the stream: no byte of "\r" or "\n" is inside a UTF-8 sequence; the decoder's
 * ASCII path costs about as much again as the copy); and line_end16, a line's end found 16
 * bytes at a time.  Shared by the reader (_reader.c) and the firmware model
 * (firmware/_core.c); setup.py and native.py hash it with each source that includes it (a
 * stale build is not used). */
#ifndef GCODE_OPT_LINESTR_H
#define GCODE_OPT_LINESTR_H

#include <Python.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

static PyObject *line_str(const char *s, Py_ssize_t n, int ascii)
{
    if (!ascii)
        return PyUnicode_DecodeUTF8(s, n, "surrogateescape");
    PyObject *line = PyUnicode_New(n, 127);
    if (line != NULL)
        memcpy(PyUnicode_1BYTE_DATA(line), s, (size_t)n);
    return line;
}

#ifdef __SSE2__
/* The end (one past its '\n') of the line at a, its '\n' and its bytes' high bits found in
 * one pass, 16 bytes at a time while 16 remain before end (the bytes after its '\n'
 * masked off); *high: 0 where every byte of it is ASCII.  NULL where no whole 16-byte
 * block holds a '\n' (a line near end, or a long one: the caller reads it another way). */
static inline __attribute__((always_inline)) const char *line_end16(const char *a, const char *end,
                                                                    unsigned *high)
{
    const __m128i nl16 = _mm_set1_epi8('\n');
    unsigned hi = 0;
    for (const char *q = a; end - q >= 16; q += 16) {
        __m128i v = _mm_loadu_si128((const __m128i *)q);
        unsigned nl = (unsigned)_mm_movemask_epi8(_mm_cmpeq_epi8(v, nl16));
        unsigned hb = (unsigned)_mm_movemask_epi8(v);          /* bit j: q[j] >= 0x80 */
        if (nl != 0) {
            *high = hi | (hb & (nl ^ (nl - 1)));              /* the bytes up to the '\n' */
            return q + __builtin_ctz(nl) + 1;
        }
        hi |= hb;
    }
    *high = hi;
    return NULL;
}
#endif

#endif
