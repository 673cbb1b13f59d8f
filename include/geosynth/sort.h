/* Ascending sorts of plain number arrays, one comparator each for every
 * engine and measure (NaN compares equal to everything, as before). */
#ifndef GEOSYNTH_SORT_H
#define GEOSYNTH_SORT_H

#include <stddef.h>
#include <stdint.h>

/* Sorts v[0, n) ascending in place (qsort: equal values keep no order). */
void gs_sort_f64(double *v, size_t n);
void gs_sort_u64(uint64_t *v, size_t n);

#endif
