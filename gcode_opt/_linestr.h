/* A line's str as read_lines gives it: a line of ASCII bytes (nearly all) is copied into a
 * new str; any other is UTF-8's decoder's with surrogateescape (a line alone decodes as it
 * would in the stream: no byte of "\r" or "\n" is inside a UTF-8 sequence; the decoder's
 * ASCII path costs about as much again as the copy).  Shared by the reader (_reader.c) and
 * the firmware model (firmware/_core.c); setup.py and native.py hash it with each source
 * that includes it (a stale build is not used). */
#ifndef GCODE_OPT_LINESTR_H
#define GCODE_OPT_LINESTR_H

#include <Python.h>
#include <string.h>

static PyObject *line_str(const char *s, Py_ssize_t n, int ascii)
{
    if (!ascii)
        return PyUnicode_DecodeUTF8(s, n, "surrogateescape");
    PyObject *line = PyUnicode_New(n, 127);
    if (line != NULL)
        memcpy(PyUnicode_1BYTE_DATA(line), s, (size_t)n);
    return line;
}

#endif
