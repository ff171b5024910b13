/* SPDX-License-Identifier: MIT
 * select.c -- the value of a given rank in an array of doubles (Hoare
 * quickselect, O(n) expected): medians and quantiles without a full sort.
 * The value is that of the sorted array's entry, so a sort it replaces
 * gives the same result.
 */
#include "pkss_internal.h"

double pkss__select_value(double *v, size_t n, size_t r)
{
    size_t lo = 0, hi = n - 1;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        double a = v[lo], b = v[mid], c = v[hi];
        double pivot = (a < b) ? ((b < c) ? b : (a < c ? c : a))
                               : ((a < c) ? a : (b < c ? c : b));
        size_t i = lo, j = hi;
        for (;;) {
            while (v[i] < pivot)
                ++i;
            while (v[j] > pivot)
                --j;
            if (i >= j)
                break;
            double t = v[i];
            v[i] = v[j];
            v[j] = t;
            ++i;
            --j;
        }
        if (i == j) { /* v[i] == pivot, in its final place */
            if (r == i)
                return v[i];
            if (r < i)
                hi = i - 1;
            else
                lo = i + 1;
        } else if (r <= j) {
            hi = j;
        } else {
            lo = j + 1;
        }
    }
    return v[r];
}
