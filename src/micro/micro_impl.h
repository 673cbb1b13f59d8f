/* Internal helpers of the micro engine (not part of the public API). */
#ifndef GEOSYNTH_MICRO_IMPL_H
#define GEOSYNTH_MICRO_IMPL_H

#include <math.h>
#include <stdint.h>

#include "geosynth/micro.h"

#define MICRO_PI 3.14159265358979323846

/* Open-addressing map uint64 key -> uint32 value (key UINT64_MAX reserved).
 * Used to weld generator vertices and to number edges. Capacity is a power
 * of two, at least twice the number of keys it is created for. */
typedef struct micro_map {
    uint64_t *keys;
    uint32_t *vals;
    uint64_t mask;
    uint64_t size;
} micro_map;

gs_err micro_map_init(micro_map *m, uint64_t expected);
void micro_map_free(micro_map *m);
/* Returns a pointer to the value slot of key; *found says whether the key
 * was present (if not it is inserted with value UINT32_MAX). Never fails:
 * the caller sized the map. */
uint32_t *micro_map_slot(micro_map *m, uint64_t key, int *found);
/* Value of key or UINT32_MAX. */
uint32_t micro_map_get(const micro_map *m, uint64_t key);

static inline uint64_t micro_edge_key(uint32_t a, uint32_t b)
{
    return a < b ? ((uint64_t)a << 32) | b : ((uint64_t)b << 32) | a;
}

static inline double micro_dist3f(const float *p, const float *q)
{
    double dx = (double)p[0] - q[0], dy = (double)p[1] - q[1], dz = (double)p[2] - q[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

/* Binary min-heap of (distance, triangle) for the Dijkstra searches of the
 * reconstruction (implemented in geo.c). Lazy deletion: stale entries are skipped. */
typedef struct micro_heap {
    double *key;
    uint32_t *item;
    size_t size, cap;
} micro_heap;
gs_err micro_heap_push(micro_heap *h, double key, uint32_t item);
/* Pops the minimum into key and item; returns 0 when empty. */
int micro_heap_pop(micro_heap *h, double *key, uint32_t *item);
void micro_heap_free(micro_heap *h);

/* Reusable Dijkstra workspace (layout of gs_micro_geo). dist[] is +inf for
 * every triangle not touched by the current query. */
struct gs_micro_geo {
    const gs_micro_dual *dual;
    double *dist;
    uint32_t *touched;
    size_t ntouched;
    micro_heap heap;
    uint32_t *out_tris;
    double *out_dist;
    size_t nout, cap_out;
};
/* Forgets the previous query (resets only what it touched). */
void micro_geo_reset(struct gs_micro_geo *g);
/* Starts a query at triangle src (after micro_geo_reset). */
gs_err micro_geo_seed(struct gs_micro_geo *g, uint32_t src);
/* Settles u (popped at distance du): offers each ring neighbour its distance
 * through u, up to radius. The one step of every search of the
 * reconstruction (geo.c). */
gs_err micro_geo_relax(struct gs_micro_geo *g, uint32_t u, double du, double radius);

#endif
