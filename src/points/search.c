/* Patch search over precomputed overlap fields (paper section 5.1); see
 * include/geosynth/points.h for the layout and the partitioning contract. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "points/points_impl.h"

struct gs_points_bank {
    gs_points_layout l;
    size_t first, count, stride; /* stride = floats per patch */
    float *data;
};

void gs_points_layout_init(gs_points_layout *l, int pc, int oc, int nz)
{
    l->pc = pc;
    l->oc = oc;
    l->nz = nz;
    size_t w = (size_t)(pc + 1 - oc);
    l->n_corner = 4 * (size_t)oc * oc * nz;
    l->n_left = 4 * (size_t)oc * w * nz;
    l->n_bottom = 4 * w * (size_t)oc * nz;
}

size_t gs_points_layout_floats(const gs_points_layout *l)
{
    return l->n_corner + l->n_left + l->n_bottom;
}

void gs_points_layout_node(const gs_points_layout *l, size_t node, int *a, int *b, int *k)
{
    size_t nc = l->n_corner / 4, nl = l->n_left / 4;
    int oc = l->oc, w = l->pc + 1 - oc, nz = l->nz;
    *k = (int)(node % nz);
    size_t col = node / nz; /* index over (a, b) within the block, a fastest */
    if (node < nc) {
        *a = (int)(col % oc);
        *b = (int)(col / oc);
    } else if (node < nc + nl) {
        col = (node - nc) / nz;
        *a = (int)(col % oc);
        *b = oc + (int)(col / oc);
    } else {
        col = (node - nc - nl) / nz;
        *a = oc + (int)(col % w);
        *b = (int)(col / w);
    }
}

size_t gs_points_bank_total(int nx, int ny, const gs_points_layout *l)
{
    if (nx <= l->pc || ny <= l->pc)
        return 0;
    return (size_t)(nx - l->pc) * (size_t)(ny - l->pc);
}

gs_err gs_points_bank_create(const float *field, int nx, int ny, const gs_points_layout *l,
                             size_t first, size_t count, gs_points_bank_t *out)
{
    size_t total = gs_points_bank_total(nx, ny, l);
    GS_CHECK(total > 0, GS_ERR_ARG,
             "patch bank: field of %d x %d nodes has no room for a patch of %d cells", nx, ny,
             l->pc);
    GS_CHECK(first <= total && count <= total - first, GS_ERR_ARG,
             "patch bank: share [%zu, %zu) outside the %zu patches", first, first + count, total);
    struct gs_points_bank *b = gs_calloc(1, sizeof *b);
    GS_CHECK(b != NULL, GS_ERR_MEM, "patch bank: out of memory");
    b->l = *l;
    b->first = first;
    b->count = count;
    b->stride = gs_points_layout_floats(l);
    gs_err err = gs_alloc_array((void **)&b->data, count ? count : 1, b->stride * sizeof(float),
                                "patch bank fields");
    if (err != GS_OK) {
        gs_free(b);
        GS_CALL(err);
    }
    int npx = nx - l->pc;
    size_t nodes = b->stride / 4;
    for (size_t p = 0; p < count; p++) {
        size_t idx = first + p;
        int pi = (int)(idx % (size_t)npx), pj = (int)(idx / (size_t)npx);
        float *dst = b->data + p * b->stride;
        for (size_t node = 0; node < nodes; node++) {
            int a, bb, k;
            gs_points_layout_node(l, node, &a, &bb, &k);
            const float *src = field + 4 * (((size_t)k * ny + pj + bb) * nx + pi + a);
            memcpy(dst + 4 * node, src, 4 * sizeof(float));
        }
    }
    *out = b;
    return GS_OK;
}

void gs_points_bank_destroy(gs_points_bank_t *bp)
{
    if (!*bp)
        return;
    gs_free((*bp)->data);
    gs_free(*bp);
    *bp = NULL;
}

void gs_points_cands_free(gs_points_cands *c)
{
    gs_free(c->v);
    c->v = NULL;
    c->n = c->cap = 0;
}

static gs_err cands_push(gs_points_cands *c, double d, uint64_t idx)
{
    if (c->n == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 64;
        gs_points_cand *v = gs_realloc(c->v, cap * sizeof *v);
        GS_CHECK(v != NULL, GS_ERR_MEM, "candidate list: out of memory (%zu entries)", cap);
        c->v = v;
        c->cap = cap;
    }
    c->v[c->n].dist = d;
    c->v[c->n].index = idx;
    c->n++;
    return GS_OK;
}

/* Sum of squared differences over [0, n), in chunks of 64 floats summed in
 * 8 float lanes then added to a double in a fixed order. Stops early (and
 * returns a value > cutoff) once the running sum exceeds cutoff. */
static double ssd_range(const float *a, const float *b, size_t n, double acc, double cutoff)
{
    size_t i = 0;
    for (; i + 64 <= n; i += 64) {
        float lane[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        for (size_t j = 0; j < 64; j += 8)
            for (int l = 0; l < 8; l++) {
                float d = a[i + j + l] - b[i + j + l];
                lane[l] += d * d;
            }
        acc += (double)(((lane[0] + lane[1]) + (lane[2] + lane[3])) +
                        ((lane[4] + lane[5]) + (lane[6] + lane[7])));
        if (acc > cutoff)
            return acc;
    }
    for (; i < n; i++) {
        double d = (double)a[i] - (double)b[i];
        acc += d * d;
    }
    return acc;
}

/* The float ranges of a patch's overlap field that mode compares: up to
 * two, [r[0], r[1]) and [r[2], r[3]). */
static void mode_ranges(const gs_points_layout *l, int mode, size_t r[4])
{
    r[0] = r[2] = r[3] = 0;
    if (mode == GS_POINTS_OVERLAP_LEFT) {
        r[1] = l->n_corner + l->n_left;
    } else if (mode == GS_POINTS_OVERLAP_BOTTOM) {
        r[1] = l->n_corner;
        r[2] = l->n_corner + l->n_left;
        r[3] = r[2] + l->n_bottom;
    } else {
        r[1] = l->n_corner + l->n_left + l->n_bottom;
    }
}

void gs_points_bank_share(const gs_points_bank *b, size_t *first, size_t *count)
{
    *first = b->first;
    *count = b->count;
}

gs_err gs_points_search_scan(const gs_points_bank *b, const float *query, int mode, uint64_t lo,
                             uint64_t hi, gs_points_bound_fn bound, gs_points_offer_fn offer,
                             void *user)
{
    GS_CHECK(mode >= 1 && mode <= 3, GS_ERR_ARG, "search: overlap mode %d, expected 1..3", mode);
    GS_CHECK(lo <= hi && lo >= b->first && hi <= b->first + b->count, GS_ERR_ARG,
             "search: patches [%llu, %llu) are outside this bank's share [%zu, %zu)",
             (unsigned long long)lo, (unsigned long long)hi, b->first, b->first + b->count);
    size_t r[4];
    mode_ranges(&b->l, mode, r);
    for (uint64_t idx = lo; idx < hi; idx++) {
        const float *f = b->data + (idx - b->first) * b->stride;
        double cutoff = bound(user);
        double d = ssd_range(f + r[0], query + r[0], r[1] - r[0], 0.0, cutoff);
        if (d <= cutoff && r[3] > r[2])
            d = ssd_range(f + r[2], query + r[2], r[3] - r[2], d, cutoff);
        if (d > cutoff)
            continue;
        offer(user, d, idx);
    }
    return GS_OK;
}

gs_err gs_points_search_local(const gs_points_bank *b, const float *query, int mode, double eps,
                              double bound, gs_points_cands *out)
{
    GS_CHECK(mode >= 1 && mode <= 3, GS_ERR_ARG, "search: overlap mode %d, expected 1..3", mode);
    GS_CHECK(eps >= 0, GS_ERR_ARG, "search: eps %g must be >= 0", eps);
    out->n = 0;
    out->best = INFINITY;
    size_t rr[4];
    mode_ranges(&b->l, mode, rr);
    size_t r0b = rr[0], r0e = rr[1], r1b = rr[2], r1e = rr[3];
    double best = bound;
    for (size_t p = 0; p < b->count; p++) {
        const float *f = b->data + p * b->stride;
        double cutoff = (1.0 + eps) * best;
        double d = ssd_range(f + r0b, query + r0b, r0e - r0b, 0.0, cutoff);
        if (d <= cutoff && r1e > r1b)
            d = ssd_range(f + r1b, query + r1b, r1e - r1b, d, cutoff);
        if (d > cutoff)
            continue;
        GS_CALL(cands_push(out, d, b->first + p));
        if (d < best)
            best = d;
        if (d < out->best)
            out->best = d;
    }
    /* Drop what the final local best rules out (pure shrinking). */
    size_t w = 0;
    double keep = (1.0 + eps) * out->best;
    for (size_t i = 0; i < out->n; i++)
        if (out->v[i].dist <= keep)
            out->v[w++] = out->v[i];
    out->n = w;
    return GS_OK;
}

static int cand_cmp(const void *pa, const void *pb)
{
    const gs_points_cand *a = pa, *b = pb;
    if (a->dist != b->dist)
        return a->dist < b->dist ? -1 : 1;
    return a->index < b->index ? -1 : a->index > b->index;
}

gs_err gs_points_search_merge(const gs_points_cands *parts, int nparts, double eps,
                              gs_points_cands *out)
{
    out->n = 0;
    out->best = INFINITY;
    for (int i = 0; i < nparts; i++)
        for (size_t j = 0; j < parts[i].n; j++)
            if (parts[i].v[j].dist < out->best)
                out->best = parts[i].v[j].dist;
    double keep = (1.0 + eps) * out->best;
    for (int i = 0; i < nparts; i++)
        for (size_t j = 0; j < parts[i].n; j++)
            if (parts[i].v[j].dist <= keep)
                GS_CALL(cands_push(out, parts[i].v[j].dist, parts[i].v[j].index));
    if (out->n > 1)
        qsort(out->v, out->n, sizeof *out->v, cand_cmp);
    return GS_OK;
}

uint64_t gs_points_search_pick(const gs_points_cands *c, gs_rng *r)
{
    return c->v[gs_rng_below(r, c->n)].index;
}
