/* Independent verifier of a micro reconstruction. Deliberately shares no code
 * with geo.c / recon.c: its own adjacency (sorted edge list instead of vertex
 * incidence), its own centroids, its own heap and Dijkstra, so a bug in the
 * reconstruction's distances cannot hide itself. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "micro/micro_impl.h"

typedef struct vedge {
    uint64_t key;
    uint32_t tri;
} vedge;

static int cmp_vedge(const void *a, const void *b)
{
    const vedge *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->tri < y->tri ? -1 : x->tri > y->tri;
}

typedef struct vgraph {
    uint32_t n;
    uint32_t *start, *nbr;
    double *len;
} vgraph;

static void vgraph_free(vgraph *g)
{
    gs_free(g->start);
    gs_free(g->nbr);
    gs_free(g->len);
}

static gs_err vgraph_build(const gs_micro_mesh *m, double scale, vgraph *g)
{
    uint32_t n = m->ntris;
    size_t ne = (size_t)n * 3;
    vedge *e = NULL;
    double *cen = NULL;
    gs_err err = GS_OK;
    memset(g, 0, sizeof *g);
    g->n = n;
    GS_TRY(err, gs_alloc_array((void **)&e, ne, sizeof *e, "verifier edges"), fail);
    GS_TRY(err, gs_alloc_array((void **)&cen, ne, sizeof *cen, "verifier centroids"), fail);
    for (uint32_t t = 0; t < n; t++) {
        const uint32_t *v = m->tris + 3 * (size_t)t;
        for (int c = 0; c < 3; c++)
            cen[3 * (size_t)t + c] = ((double)m->pos[3 * (size_t)v[0] + c] + m->pos[3 * (size_t)v[1] + c] +
                                      m->pos[3 * (size_t)v[2] + c]) / 3.0;
        for (int i = 0; i < 3; i++) {
            uint64_t a = v[i], b = v[(i + 1) % 3];
            e[3 * (size_t)t + i] = (vedge){a < b ? a << 32 | b : b << 32 | a, t};
        }
    }
    qsort(e, ne, sizeof *e, cmp_vedge);
    GS_TRY(err, gs_alloc_array((void **)&g->start, (size_t)n + 1, sizeof *g->start, "verifier graph"), fail);
    /* Every pair of triangles in a run of equal keys is adjacent. */
    for (int pass = 0; pass < 2; pass++) {
        if (pass) {
            for (uint32_t t = 0; t < n; t++)
                g->start[t + 1] += g->start[t];
            size_t total = g->start[n];
            GS_TRY(err, gs_alloc_array((void **)&g->nbr, total + 1, sizeof *g->nbr, "verifier graph"), fail);
            GS_TRY(err, gs_alloc_array((void **)&g->len, total + 1, sizeof *g->len, "verifier graph"), fail);
        }
        uint32_t *fill = pass ? g->start : NULL;
        for (size_t i = 0; i < ne;) {
            size_t j = i;
            while (j < ne && e[j].key == e[i].key)
                j++;
            for (size_t x = i; x < j; x++)
                for (size_t y = i; y < j; y++) {
                    if (x == y || e[x].tri == e[y].tri)
                        continue;
                    if (!pass)
                        g->start[e[x].tri + 1]++;
                    else {
                        uint32_t t = e[x].tri, u = e[y].tri;
                        const double *p = cen + 3 * (size_t)t, *q = cen + 3 * (size_t)u;
                        g->nbr[fill[t]] = u;
                        g->len[fill[t]++] = scale * sqrt((p[0] - q[0]) * (p[0] - q[0]) +
                                                          (p[1] - q[1]) * (p[1] - q[1]) +
                                                          (p[2] - q[2]) * (p[2] - q[2]));
                    }
                }
            i = j;
        }
        if (pass) { /* fill[] advanced start[t] to start[t+1]: shift back */
            for (uint32_t t = n; t > 0; t--)
                g->start[t] = g->start[t - 1];
            g->start[0] = 0;
        }
    }
    gs_free(e);
    gs_free(cen);
    return GS_OK;
fail:
    gs_free(e);
    gs_free(cen);
    vgraph_free(g);
    return err;
}

/* Plain binary heap of (distance, triangle). */
typedef struct vheap {
    double *d;
    uint32_t *t;
    size_t n, cap;
} vheap;

static gs_err vheap_push(vheap *h, double d, uint32_t t)
{
    if (h->n == h->cap) {
        size_t cap = h->cap ? h->cap * 2 : 256;
        double *nd = gs_realloc(h->d, cap * sizeof *nd);
        GS_CHECK(nd, GS_ERR_MEM, "verifier heap");
        h->d = nd;
        uint32_t *nt = gs_realloc(h->t, cap * sizeof *nt);
        GS_CHECK(nt, GS_ERR_MEM, "verifier heap");
        h->t = nt;
        h->cap = cap;
    }
    size_t i = h->n++;
    for (; i && h->d[(i - 1) / 2] > d; i = (i - 1) / 2) {
        h->d[i] = h->d[(i - 1) / 2];
        h->t[i] = h->t[(i - 1) / 2];
    }
    h->d[i] = d;
    h->t[i] = t;
    return GS_OK;
}

static void vheap_pop(vheap *h, double *d, uint32_t *t)
{
    *d = h->d[0];
    *t = h->t[0];
    double ld = h->d[--h->n];
    uint32_t lt = h->t[h->n];
    size_t i = 0;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= h->n)
            break;
        if (c + 1 < h->n && h->d[c + 1] < h->d[c])
            c++;
        if (ld <= h->d[c])
            break;
        h->d[i] = h->d[c];
        h->t[i] = h->t[c];
        i = c;
    }
    if (h->n) {
        h->d[i] = ld;
        h->t[i] = lt;
    }
}

gs_err gs_micro_verify(const gs_micro_mesh *m, double units_per_model, const gs_micro_hist *h,
                       const double *value, const uint16_t *label, uint32_t nsample, gs_rng *rng,
                       gs_micro_report *r)
{
    GS_CHECK(units_per_model > 0, GS_ERR_ARG, "units_per_model %g: expected > 0", units_per_model);
    uint32_t n = m->ntris, K = h->nbins;
    memset(r, 0, sizeof *r);
    r->nbins = K;
    gs_err err = GS_OK;
    vgraph g = {0};
    vheap hp = {0};
    double *dist = NULL;
    uint32_t *visited = NULL;
    GS_TRY(err, gs_alloc_array((void **)&r->achieved, 2 * (size_t)K, sizeof *r->achieved, "report"), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->error, 2 * (size_t)K, sizeof *r->error, "report"), fail);
    for (uint32_t t = 0; t < n; t++) {
        if (label[t] < 2 * K)
            r->achieved[label[t]]++;
        else
            r->unassigned++;
    }
    r->unassigned_share = n ? (double)r->unassigned / n : 0;
    for (uint32_t i = 0; i < 2 * K; i++) {
        r->error[i] = r->achieved[i] - h->count[i];
        r->abs_error_sum += llabs(r->error[i]);
    }
    double vmax = 0;
    for (uint32_t t = 0; t < n; t++)
        vmax = fmax(vmax, fabs(value[t]));
    GS_TRY(err, vgraph_build(m, units_per_model, &g), fail);
    GS_TRY(err, gs_alloc_array((void **)&dist, n, sizeof *dist, "verifier distances"), fail);
    GS_TRY(err, gs_alloc_array((void **)&visited, n, sizeof *visited, "verifier distances"), fail);
    for (uint32_t t = 0; t < n; t++)
        dist[t] = INFINITY;
    uint32_t samples = nsample >= n ? n : nsample;
    for (uint32_t s = 0; s < samples; s++) {
        uint32_t src = samples == n ? s : (uint32_t)gs_rng_below(rng, n);
        /* A pair can only violate within |x_i - x_j| <= |x_i| + vmax. */
        double radius = fabs(value[src]) + vmax;
        size_t nvis = 0;
        dist[src] = 0;
        visited[nvis++] = src;
        hp.n = 0;
        GS_TRY(err, vheap_push(&hp, 0, src), fail);
        while (hp.n) {
            double du;
            uint32_t u;
            vheap_pop(&hp, &du, &u);
            if (du != dist[u])
                continue;
            if (u != src) {
                r->pairs_checked++;
                double excess = fabs(value[src] - value[u]) - du;
                if (excess > r->max_excess)
                    r->max_excess = excess;
                if (excess > 1e-9 * (1 + du))
                    r->violations++;
            }
            for (uint32_t k = g.start[u]; k < g.start[u + 1]; k++) {
                uint32_t v = g.nbr[k];
                double dv = du + g.len[k];
                if (dv <= radius && dv < dist[v]) {
                    if (dist[v] == INFINITY)
                        visited[nvis++] = v;
                    dist[v] = dv;
                    GS_TRY(err, vheap_push(&hp, dv, v), fail);
                }
            }
        }
        for (size_t i = 0; i < nvis; i++)
            dist[visited[i]] = INFINITY;
    }
    vgraph_free(&g);
    gs_free(hp.d);
    gs_free(hp.t);
    gs_free(dist);
    gs_free(visited);
    return GS_OK;
fail:
    vgraph_free(&g);
    gs_free(hp.d);
    gs_free(hp.t);
    gs_free(dist);
    gs_free(visited);
    gs_micro_report_free(r);
    return err;
}

void gs_micro_report_free(gs_micro_report *r)
{
    if (!r)
        return;
    GS_FREE(r->achieved);
    GS_FREE(r->error);
}
