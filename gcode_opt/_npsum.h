/* numpy's pairwise sum of a contiguous run of doubles: what np.add.reduce (np.sum of a
 * contiguous row) computes, so a compiled core gives numpy's bits.  Below 8 values a plain
 * loop from -0.0 (numpy's reduction identity for float add); up to 128, eight partial sums
 * over blocks of 8 combined as ((0+1)+(2+3))+((4+5)+(6+7)), then the rest in order; above,
 * the two halves (the first a multiple of 8 long) summed each and added.  Shared by the
 * cores that need it (firmware/_core.c, laws/_chaincore.c, laws/_curvecore.c); setup.py
 * and native.py hash it with each source that includes it (a stale build is not used).
 * Where the compiler has vector extensions (gcc, clang), the eight partial sums are four
 * pairs of lanes: gcc kept the array r[8] on the stack (a load, an add and a store a number);
 * each lane adds its numbers in the same order, and the eight are combined as numpy combines
 * them: the same bits. */
#ifndef GCODE_OPT_NPSUM_H
#define GCODE_OPT_NPSUM_H

#include <Python.h>

#if defined(__GNUC__) || defined(__clang__)
#include <string.h>
typedef double NpSumV2 __attribute__((vector_size(16)));   /* two doubles: r[j], r[j + 1] */

static inline NpSumV2 npsum_v2_at(const double *a)
{
    NpSumV2 x;
    memcpy(&x, a, sizeof x);        /* (unaligned: a run may start anywhere) */
    return x;
}
#endif

static double np_pairwise_sum(const double *a, Py_ssize_t n)
{
    if (n < 8) {
        double res = -0.0;
        for (Py_ssize_t i = 0; i < n; i++)
            res += a[i];
        return res;
    }
    if (n <= 128) {
        Py_ssize_t i;
#if defined(__GNUC__) || defined(__clang__)
        NpSumV2 r01 = npsum_v2_at(a), r23 = npsum_v2_at(a + 2), r45 = npsum_v2_at(a + 4), r67 = npsum_v2_at(a + 6);
        for (i = 8; i < n - (n % 8); i += 8) {
            r01 += npsum_v2_at(a + i);
            r23 += npsum_v2_at(a + i + 2);
            r45 += npsum_v2_at(a + i + 4);
            r67 += npsum_v2_at(a + i + 6);
        }
        double res = ((r01[0] + r01[1]) + (r23[0] + r23[1])) + ((r45[0] + r45[1]) + (r67[0] + r67[1]));
#else
        double r[8];
        for (int j = 0; j < 8; j++)
            r[j] = a[j];
        for (i = 8; i < n - (n % 8); i += 8)
            for (int j = 0; j < 8; j++)
                r[j] += a[i + j];
        double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
#endif
        for (; i < n; i++)
            res += a[i];
        return res;
    }
    Py_ssize_t n2 = n / 2;
    n2 -= n2 % 8;
    return np_pairwise_sum(a, n2) + np_pairwise_sum(a + n2, n - n2);
}

#endif
