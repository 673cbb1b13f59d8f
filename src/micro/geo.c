/* Dual graph of triangles, ring graph and bounded Dijkstra.
 *
 * The paper (4.2) takes the geodesic distance between triangles as the
 * shortest path between centroids along the dual graph (edge neighbours).
 * On a regular mesh that metric is polygonal: dual paths zigzag, 15-36%
 * longer than the straight line off the few directions they follow, so its
 * balls, and every region the reconstruction grows from them, are hexagons
 * (issue 20). The reconstruction's searches use the ring graph instead: each
 * triangle linked to every triangle sharing a vertex with it (12 on a
 * regular mesh), weight = the straight centroid distance. Its paths have
 * twice as many directions to choose from and deviate from the straight
 * line by at most 3.5% on a regular mesh (a 40x40 equilateral lattice at
 * radius 8-12: dual 1.154-1.357, ring 1.000-1.035), so regions come out
 * round. It stays a graph metric on purpose: the reconstruction's pruned
 * propagation and its forced values rely on the triangle inequality, which
 * a wavefront distance (fast marching, or straight lines from virtual
 * sources) only nearly keeps: tried, such labels broke constraints of the
 * verifier's metric by up to 0.16 units and left the fill contradictory
 * bounds. Each ring weight is a chord no longer than the dual path between
 * the two triangles, so ring distances never exceed dual ones and the
 * constraints the reconstruction keeps imply the verifier's (dual graph).
 * The verifier's side is right for a non-graph metric too: a dual path is a
 * path on the surface, so the dual distance is at least the true geodesic,
 * and values 1-Lipschitz in the true geodesic always pass it; the fast
 * marched labels that failed it by 0.16 units broke the paper's constraint
 * in the true metric as well (fast marching is only first-order accurate).
 * Measured on planet.ini's undisplaced sphere against the exact great-circle
 * distance between centroids, 3-12 units, 12 sources (29k pairs): ring
 * 1.000-1.071, median 1.022; dual 1.062-1.649, median 1.265; the reach of an
 * 8-unit ball over 24 sectors varies by cv 0.015 (ring) and 0.071 (dual). */
#include <math.h>
#include <string.h>

#include "geosynth/mem.h"
#include "micro/micro_impl.h"

/* ------------------------------------------------------------ heap -- */

gs_err micro_heap_push(micro_heap *h, double key, uint32_t item)
{
    if (h->size == h->cap) {
        size_t cap = h->cap ? 2 * h->cap : 1024;
        double *k = gs_realloc(h->key, cap * sizeof *k);
        GS_CHECK(k, GS_ERR_MEM, "Dijkstra heap of %zu entries", cap);
        h->key = k;
        uint32_t *it = gs_realloc(h->item, cap * sizeof *it);
        GS_CHECK(it, GS_ERR_MEM, "Dijkstra heap of %zu entries", cap);
        h->item = it;
        h->cap = cap;
    }
    size_t i = h->size++;
    while (i > 0) {
        size_t p = (i - 1) / 2;
        if (h->key[p] < key || (h->key[p] == key && h->item[p] <= item))
            break;
        h->key[i] = h->key[p];
        h->item[i] = h->item[p];
        i = p;
    }
    h->key[i] = key;
    h->item[i] = item;
    return GS_OK;
}

int micro_heap_pop(micro_heap *h, double *key, uint32_t *item)
{
    if (h->size == 0)
        return 0;
    *key = h->key[0];
    *item = h->item[0];
    double k = h->key[--h->size];
    uint32_t it = h->item[h->size];
    size_t i = 0, n = h->size;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= n)
            break;
        if (c + 1 < n && (h->key[c + 1] < h->key[c] || (h->key[c + 1] == h->key[c] && h->item[c + 1] < h->item[c])))
            c++;
        if (k < h->key[c] || (k == h->key[c] && it <= h->item[c]))
            break;
        h->key[i] = h->key[c];
        h->item[i] = h->item[c];
        i = c;
    }
    if (n) {
        h->key[i] = k;
        h->item[i] = it;
    }
    return 1;
}

void micro_heap_free(micro_heap *h)
{
    GS_FREE(h->key);
    GS_FREE(h->item);
    h->size = h->cap = 0;
}

/* ------------------------------------------------------- dual graph -- */

/* Centroid distance (distribution units) of every CSR neighbour pair. */
static void csr_weights(const gs_micro_mesh *m, uint32_t n, const uint32_t *off, const uint32_t *adj,
                        double units_per_model, double *w)
{
    for (uint32_t t = 0; t < n; t++) {
        double ct[3] = {0, 0, 0};
        for (int i = 0; i < 3; i++)
            for (int c = 0; c < 3; c++)
                ct[c] += m->pos[3 * (size_t)m->tris[3 * (size_t)t + i] + c];
        for (uint32_t k = off[t]; k < off[t + 1]; k++) {
            uint32_t u = adj[k];
            double cu[3] = {0, 0, 0};
            for (int i = 0; i < 3; i++)
                for (int c = 0; c < 3; c++)
                    cu[c] += m->pos[3 * (size_t)m->tris[3 * (size_t)u + i] + c];
            double dx = (ct[0] - cu[0]) / 3, dy = (ct[1] - cu[1]) / 3, dz = (ct[2] - cu[2]) / 3;
            w[k] = sqrt(dx * dx + dy * dy + dz * dz) * units_per_model;
        }
    }
}

gs_err gs_micro_dual_build(const gs_micro_mesh *m, double units_per_model, gs_micro_dual *d)
{
    GS_CHECK(units_per_model > 0 && isfinite(units_per_model), GS_ERR_ARG,
             "units_per_model %g: expected > 0", units_per_model);
    GS_CHECK(m->ntris > 0 && m->ntris < UINT32_MAX / 3, GS_ERR_ARG,
             "mesh has %u triangles: expected [1, 2^32/3)", m->ntris);
    for (size_t i = 0; i < (size_t)m->ntris * 3; i++)
        GS_CHECK(m->tris[i] < m->nverts, GS_ERR_ARG, "triangle %zu refers to vertex %u of %u", i / 3,
                 m->tris[i], m->nverts);
    gs_err err = GS_OK;
    uint32_t *voff = NULL, *vtri = NULL, *off = NULL, *adj = NULL, *roff = NULL, *radj = NULL;
    double *w = NULL, *rw = NULL;
    uint32_t n = m->ntris;
    /* Vertex -> incident triangles (CSR, triangles ascending). */
    GS_TRY(err, gs_alloc_array((void **)&voff, (size_t)m->nverts + 1, sizeof *voff, "vertex incidence"), fail);
    GS_TRY(err, gs_alloc_array((void **)&vtri, (size_t)n * 3, sizeof *vtri, "vertex incidence"), fail);
    for (size_t i = 0; i < (size_t)n * 3; i++)
        voff[m->tris[i] + 1]++;
    for (uint32_t v = 0; v < m->nverts; v++)
        voff[v + 1] += voff[v];
    for (uint32_t t = 0; t < n; t++)
        for (int i = 0; i < 3; i++)
            vtri[voff[m->tris[3 * (size_t)t + i]]++] = t;
    for (uint32_t v = m->nverts; v > 0; v--)
        voff[v] = voff[v - 1];
    voff[0] = 0;
    /* Two passes over the edges: count, then fill. A neighbour across edge
     * (a, b) is any other triangle incident to a that also uses b. */
    GS_TRY(err, gs_alloc_array((void **)&off, (size_t)n + 1, sizeof *off, "dual graph"), fail);
    for (int pass = 0; pass < 2; pass++) {
        for (uint32_t t = 0; t < n; t++) {
            uint32_t k = pass ? off[t] : 0;
            for (int i = 0; i < 3; i++) {
                uint32_t a = m->tris[3 * (size_t)t + i], b = m->tris[3 * (size_t)t + (i + 1) % 3];
                for (uint32_t j = voff[a]; j < voff[a + 1]; j++) {
                    uint32_t u = vtri[j];
                    if (u == t)
                        continue;
                    const uint32_t *uv = m->tris + 3 * (size_t)u;
                    if (uv[0] != b && uv[1] != b && uv[2] != b)
                        continue;
                    if (pass)
                        adj[k] = u;
                    k++;
                }
            }
            if (!pass)
                off[t + 1] = k;
        }
        if (!pass) {
            for (uint32_t t = 0; t < n; t++)
                off[t + 1] += off[t];
            GS_TRY(err, gs_alloc_array((void **)&adj, (size_t)off[n] + 1, sizeof *adj, "dual graph"), fail);
            GS_TRY(err, gs_alloc_array((void **)&w, (size_t)off[n] + 1, sizeof *w, "dual graph"), fail);
        }
    }
    /* Ring graph: every other triangle around t's three vertices, ascending,
     * without repeats (two passes: count, fill). */
    GS_TRY(err, gs_alloc_array((void **)&roff, (size_t)n + 1, sizeof *roff, "ring graph"), fail);
    for (int pass = 0; pass < 2; pass++) {
        for (uint32_t t = 0; t < n; t++) {
            uint32_t k = pass ? roff[t] : 0, k0 = k;
            for (int i = 0; i < 3; i++) {
                uint32_t a = m->tris[3 * (size_t)t + i];
                for (uint32_t j = voff[a]; j < voff[a + 1]; j++) {
                    uint32_t u = vtri[j], dup = u == t;
                    if (pass)
                        for (uint32_t q = k0; q < k && !dup; q++)
                            dup = radj[q] == u;
                    else
                        for (int i2 = 0; i2 < i && !dup; i2++) {
                            uint32_t b = m->tris[3 * (size_t)t + i2];
                            const uint32_t *uv = m->tris + 3 * (size_t)u;
                            dup = uv[0] == b || uv[1] == b || uv[2] == b;
                        }
                    if (dup)
                        continue;
                    if (pass) {
                        /* insertion keeps the row ascending */
                        uint32_t q = k;
                        while (q > k0 && radj[q - 1] > u) {
                            radj[q] = radj[q - 1];
                            q--;
                        }
                        radj[q] = u;
                    }
                    k++;
                }
            }
            if (!pass)
                roff[t + 1] = k;
        }
        if (!pass) {
            for (uint32_t t = 0; t < n; t++)
                roff[t + 1] += roff[t];
            GS_TRY(err, gs_alloc_array((void **)&radj, (size_t)roff[n] + 1, sizeof *radj, "ring graph"), fail);
            GS_TRY(err, gs_alloc_array((void **)&rw, (size_t)roff[n] + 1, sizeof *rw, "ring graph"), fail);
        }
    }
    csr_weights(m, n, roff, radj, units_per_model, rw);
    double sum = 0;
    csr_weights(m, n, off, adj, units_per_model, w);
    for (uint32_t k = 0; k < off[n]; k++)
        sum += w[k];
    gs_free(voff);
    gs_free(vtri);
    d->ntris = n;
    d->off = off;
    d->adj = adj;
    d->w = w;
    d->mean_w = off[n] ? sum / off[n] : 0;
    d->roff = roff;
    d->radj = radj;
    d->rw = rw;
    return GS_OK;
fail:
    gs_free(voff);
    gs_free(vtri);
    gs_free(off);
    gs_free(adj);
    gs_free(w);
    gs_free(roff);
    gs_free(radj);
    gs_free(rw);
    return err;
}

void gs_micro_dual_free(gs_micro_dual *d)
{
    if (!d)
        return;
    GS_FREE(d->off);
    GS_FREE(d->adj);
    GS_FREE(d->w);
    GS_FREE(d->roff);
    GS_FREE(d->radj);
    GS_FREE(d->rw);
    d->ntris = 0;
}

/* ------------------------------------------------------- Dijkstra -- */

gs_err gs_micro_geo_create(const gs_micro_dual *d, gs_micro_geo_t *out)
{
    struct gs_micro_geo *g = gs_calloc(1, sizeof *g);
    GS_CHECK(g, GS_ERR_MEM, "geodesic workspace");
    g->dual = d;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&g->dist, d->ntris, sizeof *g->dist, "geodesic distances"), fail);
    GS_TRY(err, gs_alloc_array((void **)&g->touched, d->ntris, sizeof *g->touched, "geodesic distances"), fail);
    for (uint32_t t = 0; t < d->ntris; t++)
        g->dist[t] = INFINITY;
    *out = g;
    return GS_OK;
fail:
    gs_micro_geo_destroy(&g);
    return err;
}

void gs_micro_geo_destroy(gs_micro_geo_t *gp)
{
    struct gs_micro_geo *g = *gp;
    if (!g)
        return;
    gs_free(g->dist);
    gs_free(g->touched);
    micro_heap_free(&g->heap);
    gs_free(g->out_tris);
    gs_free(g->out_dist);
    gs_free(g);
    *gp = NULL;
}

void micro_geo_reset(struct gs_micro_geo *g)
{
    for (size_t i = 0; i < g->ntouched; i++)
        g->dist[g->touched[i]] = INFINITY;
    g->ntouched = 0;
    g->heap.size = 0;
    g->nout = 0;
}

gs_err micro_geo_seed(struct gs_micro_geo *g, uint32_t src)
{
    g->dist[src] = 0;
    g->touched[g->ntouched++] = src;
    GS_CALL(micro_heap_push(&g->heap, 0, src));
    return GS_OK;
}

gs_err micro_geo_relax(struct gs_micro_geo *g, uint32_t u, double du, double radius)
{
    const gs_micro_dual *d = g->dual;
    for (uint32_t k = d->roff[u]; k < d->roff[u + 1]; k++) {
        uint32_t v = d->radj[k];
        double dv = du + d->rw[k];
        if (dv > radius || dv >= g->dist[v])
            continue;
        if (g->dist[v] == INFINITY)
            g->touched[g->ntouched++] = v;
        g->dist[v] = dv;
        GS_CALL(micro_heap_push(&g->heap, dv, v));
    }
    return GS_OK;
}

gs_err gs_micro_geo_ball(gs_micro_geo_t g, uint32_t src, double radius, const uint32_t **tris,
                         const double **dist, size_t *count)
{
    const gs_micro_dual *d = g->dual;
    GS_CHECK(src < d->ntris, GS_ERR_ARG, "triangle %u of %u", src, d->ntris);
    micro_geo_reset(g);
    GS_CALL(micro_geo_seed(g, src));
    double du;
    uint32_t u;
    while (micro_heap_pop(&g->heap, &du, &u)) {
        if (du > g->dist[u])
            continue; /* stale entry */
        if (g->nout == g->cap_out) {
            size_t cap = g->cap_out ? 2 * g->cap_out : 1024;
            uint32_t *t = gs_realloc(g->out_tris, cap * sizeof *t);
            GS_CHECK(t, GS_ERR_MEM, "geodesic ball of %zu triangles", cap);
            g->out_tris = t;
            double *x = gs_realloc(g->out_dist, cap * sizeof *x);
            GS_CHECK(x, GS_ERR_MEM, "geodesic ball of %zu triangles", cap);
            g->out_dist = x;
            g->cap_out = cap;
        }
        g->out_tris[g->nout] = u;
        g->out_dist[g->nout++] = du;
        GS_CALL(micro_geo_relax(g, u, du, radius));
    }
    *tris = g->out_tris;
    *dist = g->out_dist;
    *count = g->nout;
    return GS_OK;
}
