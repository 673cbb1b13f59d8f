/* Sorted sets of 64-bit keys; see include/geosynth/measure.h. */
#include <stdlib.h>

#include "geosynth/measure.h"
#include "geosynth/sort.h"

void gs_measure_keys_sort(uint64_t *keys, size_t n)
{
    if (n > 1)
        gs_sort_u64(keys, n);
}

size_t gs_measure_keys_sort_unique(uint64_t *keys, size_t n)
{
    gs_measure_keys_sort(keys, n);
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (m == 0 || keys[i] != keys[m - 1])
            keys[m++] = keys[i];
    return m;
}

int gs_measure_keys_has(const uint64_t *keys, size_t n, uint64_t key)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (keys[mid] < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && keys[lo] == key;
}
