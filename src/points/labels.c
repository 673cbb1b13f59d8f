/* Patch ids of the output points (see points_impl.h, gs_points_labels): a
 * map from a point's exact position (the bits of its three coordinates) to
 * the patch that pasted it. Open addressing, linear probing; grows at half
 * full. */
#include <string.h>

#include "geosynth/mem.h"
#include "points/points_impl.h"

static uint64_t label_hash(const double p[3])
{
    uint64_t h = 0x9e3779b97f4a7c15ULL;
    for (int a = 0; a < 3; a++) {
        uint64_t u;
        memcpy(&u, &p[a], sizeof u);
        h ^= u + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
        h *= 0xff51afd7ed558ccdULL;
        h ^= h >> 33;
    }
    return h;
}

static gs_points_label_slot *label_find(const gs_points_labels *m, const double p[3])
{
    size_t mask = m->cap - 1;
    for (size_t i = (size_t)label_hash(p) & mask;; i = (i + 1) & mask) {
        gs_points_label_slot *e = &m->slot[i];
        if (!e->used || memcmp(e->p, p, sizeof e->p) == 0)
            return e;
    }
}

gs_err gs_points_labels_set(gs_points_labels *m, const double p[3], uint32_t label)
{
    if (2 * (m->n + 1) > m->cap) {
        size_t cap = m->cap ? 2 * m->cap : 4096;
        gs_points_label_slot *old = m->slot;
        size_t oldcap = m->cap;
        GS_CALL(gs_alloc_array((void **)&m->slot, cap, sizeof *m->slot, "patch ids"));
        memset(m->slot, 0, cap * sizeof *m->slot);
        m->cap = cap;
        for (size_t i = 0; i < oldcap; i++)
            if (old[i].used)
                *label_find(m, old[i].p) = old[i];
        gs_free(old);
    }
    gs_points_label_slot *e = label_find(m, p);
    if (!e->used) {
        memcpy(e->p, p, sizeof e->p);
        e->used = 1;
        m->n++;
    }
    e->label = label;
    return GS_OK;
}

uint32_t gs_points_labels_get(const gs_points_labels *m, const double p[3])
{
    if (!m->cap)
        return GS_POINTS_NO_LABEL;
    const gs_points_label_slot *e = label_find(m, p);
    return e->used ? e->label : GS_POINTS_NO_LABEL;
}

void gs_points_labels_free(gs_points_labels *m)
{
    gs_free(m->slot);
    memset(m, 0, sizeof *m);
}
