/* Union-find over uint32 indices with path halving, shared by the measures
 * of src/measure/: the root of a set is its lowest index, so a parent is
 * never above its child (a pass in ascending order can number the sets in
 * order of their lowest index). */
#ifndef GEOSYNTH_MEASURE_UNIONFIND_H
#define GEOSYNTH_MEASURE_UNIONFIND_H

#include <stdint.h>

static inline uint32_t uf_find(uint32_t *p, uint32_t x)
{
    while (p[x] != x) {
        p[x] = p[p[x]];
        x = p[x];
    }
    return x;
}

static inline void uf_union(uint32_t *p, uint32_t a, uint32_t b)
{
    a = uf_find(p, a), b = uf_find(p, b);
    if (a < b)
        p[b] = a;
    else if (b < a)
        p[a] = b;
}

#endif
