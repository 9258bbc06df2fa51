/* The firmware core's StrokeBase fields read in place: the layout the firmware core
 * (firmware/_core.c) exports in its "_gcode_opt_fwcore._STROKE_FIELDS" capsule and the
 * rewrite core (_emit.c) reads.  One definition for both modules, so the two cannot drift:
 * version, the getters that read a field as an object (sd_get for the doubles, si_get for
 * the ints: a reader uses the layout only where a type's attribute slot holds these),
 * the offsets of the doubles (double[sd_n]), the ints (long long[si_n]), the has
 * (unsigned int: bit k - sd_none0, the None-able double k holds a float) and odd (unsigned
 * int: bit k, double k or int sd_n + k, an object kept aside) bit sets, and the counts. */
#ifndef GCODE_OPT_STROKEFIELDS_H
#define GCODE_OPT_STROKEFIELDS_H
#include <Python.h>

typedef struct {
    int version;
    getter sd_get, si_get;
    Py_ssize_t off_d, off_i, off_has, off_odd;
    int sd_n, sd_none0, si_n;
} StrokeFieldsAPI;

#endif
