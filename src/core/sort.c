/* Ascending sorts of plain number arrays; see include/geosynth/sort.h. */
#include <stdlib.h>

#include "geosynth/sort.h"

static int cmp_f64(const void *pa, const void *pb)
{
    double a = *(const double *)pa, b = *(const double *)pb;
    return (a > b) - (a < b);
}

static int cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return (a > b) - (a < b);
}

void gs_sort_f64(double *v, size_t n)
{
    if (n > 1)
        qsort(v, n, sizeof *v, cmp_f64);
}

void gs_sort_u64(uint64_t *v, size_t n)
{
    if (n > 1)
        qsort(v, n, sizeof *v, cmp_u64);
}
