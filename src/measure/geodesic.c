/* Geodesic distances on triangle meshes by fast marching, and the realized
 * contact distribution of a two-region labelling (include/geosynth/measure.h).
 *
 * Fast marching (Kimmel & Sethian, "Computing geodesic paths on manifolds",
 * PNAS 1998): vertices are accepted in increasing distance; a vertex w of a
 * triangle (a, b, w) whose a and b are accepted gets the value of the planar
 * wavefront through a and b (|grad| = 1) when the front's characteristic into
 * w crosses the edge ab, else the better of the two edge paths. The result is
 * an isotropic distance (first-order accurate in the edge length), not the
 * polygonal metric of a graph (a graph of the triangles' centroids measures
 * up to ~15% long off its edge directions and grows hexagons). Obtuse
 * triangles are not unfolded: their updates fall back to the edge paths,
 * which only errs long, by at most the triangle's own size. */
#include <math.h>
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"

struct gs_measure_geo {
    size_t nv, nt;
    const uint32_t *tris;
    double *p;           /* 3 nv positions, times scale */
    uint32_t *vt_off;    /* vertex -> incident triangles, CSR */
    uint32_t *vt;
    double *dist;        /* nv; +inf unless reached by the current march */
    uint8_t *state;      /* 0 far, 1 trial, 2 accepted */
    uint32_t *origin;    /* nv: index of the source a vertex's value came from */
    uint32_t *eadj;      /* 3 nt: the triangle across edge (tv[i], tv[i+1]), EADJ_NONE, EADJ_MULTI */
    uint8_t *near;       /* nv: workspace of gs_measure_interface_dist */
    uint32_t *stamp;     /* nv: vertices seen by the current near_interface */
    uint32_t tick;
    uint32_t *touched;
    size_t ntouched;
    double *hk;          /* heap keys */
    uint32_t *hv;        /* heap vertices */
    size_t hn, hcap;
};

static gs_err heap_push(struct gs_measure_geo *g, double k, uint32_t v)
{
    if (g->hn == g->hcap) {
        size_t cap = g->hcap ? 2 * g->hcap : 1024;
        double *nk = gs_realloc(g->hk, cap * sizeof *nk);
        GS_CHECK(nk, GS_ERR_MEM, "fast-marching heap of %zu entries", cap);
        g->hk = nk;
        uint32_t *nvv = gs_realloc(g->hv, cap * sizeof *nvv);
        GS_CHECK(nvv, GS_ERR_MEM, "fast-marching heap of %zu entries", cap);
        g->hv = nvv;
        g->hcap = cap;
    }
    size_t i = g->hn++;
    while (i > 0) {
        size_t q = (i - 1) / 2;
        if (g->hk[q] < k || (g->hk[q] == k && g->hv[q] <= v))
            break;
        g->hk[i] = g->hk[q];
        g->hv[i] = g->hv[q];
        i = q;
    }
    g->hk[i] = k;
    g->hv[i] = v;
    return GS_OK;
}

static int heap_pop(struct gs_measure_geo *g, double *k, uint32_t *v)
{
    if (g->hn == 0)
        return 0;
    *k = g->hk[0];
    *v = g->hv[0];
    double lk = g->hk[--g->hn];
    uint32_t lv = g->hv[g->hn];
    size_t i = 0, n = g->hn;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= n)
            break;
        if (c + 1 < n && (g->hk[c + 1] < g->hk[c] || (g->hk[c + 1] == g->hk[c] && g->hv[c + 1] < g->hv[c])))
            c++;
        if (lk < g->hk[c] || (lk == g->hk[c] && lv <= g->hv[c]))
            break;
        g->hk[i] = g->hk[c];
        g->hv[i] = g->hv[c];
        i = c;
    }
    if (n) {
        g->hk[i] = lk;
        g->hv[i] = lv;
    }
    return 1;
}

#define EADJ_NONE UINT32_MAX        /* border edge */
#define EADJ_MULTI (UINT32_MAX - 1) /* non-manifold edge: look at every triangle on it */

/* Triangles other than t on the edge (a, b), found from a's incidence: the
 * one there is, EADJ_NONE or EADJ_MULTI. */
static uint32_t edge_neighbour(const struct gs_measure_geo *g, size_t t, uint32_t a, uint32_t b)
{
    uint32_t found = EADJ_NONE;
    for (uint32_t k = g->vt_off[a]; k < g->vt_off[a + 1]; k++) {
        uint32_t u = g->vt[k];
        const uint32_t *uv = g->tris + 3 * (size_t)u;
        if (u != t && (uv[0] == b || uv[1] == b || uv[2] == b)) {
            if (found != EADJ_NONE)
                return EADJ_MULTI;
            found = u;
        }
    }
    return found;
}

gs_err gs_measure_geo_create(const float *pos, size_t nverts, const uint32_t *tris, size_t ntris, double scale,
                             gs_measure_geo_t *out)
{
    GS_CHECK(scale > 0 && isfinite(scale), GS_ERR_ARG, "geodesic scale %g: expected > 0", scale);
    GS_CHECK(nverts < UINT32_MAX && ntris < UINT32_MAX / 3, GS_ERR_ARG,
             "geodesic mesh of %zu vertices, %zu triangles: too large", nverts, ntris);
    for (size_t i = 0; i < 3 * ntris; i++)
        GS_CHECK(tris[i] < nverts, GS_ERR_ARG, "triangle %zu refers to vertex %u of %zu", i / 3, tris[i], nverts);
    struct gs_measure_geo *g = gs_calloc(1, sizeof *g);
    GS_CHECK(g, GS_ERR_MEM, "geodesic workspace");
    g->nv = nverts;
    g->nt = ntris;
    g->tris = tris;
    gs_err err = GS_OK;
    size_t nv1 = nverts ? nverts : 1;
    GS_TRY(err, gs_alloc_array((void **)&g->p, 3 * nv1, sizeof *g->p, "geodesic positions"), fail);
    GS_TRY(err, gs_alloc_array((void **)&g->vt_off, nverts + 1, sizeof *g->vt_off, "vertex incidence"), fail);
    GS_TRY(err, gs_alloc_array((void **)&g->vt, 3 * ntris + 1, sizeof *g->vt, "vertex incidence"), fail);
    GS_TRY(err, gs_alloc_array((void **)&g->dist, nv1, sizeof *g->dist, "geodesic distances"), fail);
    GS_TRY(err, gs_alloc_array((void **)&g->state, nv1, 1, "geodesic states"), fail);
    GS_TRY(err, gs_alloc_array((void **)&g->touched, nv1, sizeof *g->touched, "geodesic states"), fail);
    GS_TRY(err, gs_alloc_array((void **)&g->origin, nv1, sizeof *g->origin, "geodesic origins"), fail);
    GS_TRY(err, gs_alloc_array((void **)&g->eadj, 3 * ntris + 1, sizeof *g->eadj, "edge neighbours"), fail);
    GS_TRY(err, gs_alloc_array((void **)&g->near, nv1, 1, "interface neighbourhood"), fail);
    GS_TRY(err, gs_alloc_array((void **)&g->stamp, nv1, sizeof *g->stamp, "interface neighbourhood"), fail);
    for (size_t i = 0; i < 3 * nverts; i++)
        g->p[i] = (double)pos[i] * scale;
    for (size_t v = 0; v < nverts; v++)
        g->dist[v] = INFINITY;
    for (size_t i = 0; i < 3 * ntris; i++)
        g->vt_off[tris[i] + 1]++;
    for (size_t v = 0; v < nverts; v++)
        g->vt_off[v + 1] += g->vt_off[v];
    for (size_t t = 0; t < ntris; t++)
        for (int i = 0; i < 3; i++)
            g->vt[g->vt_off[tris[3 * t + i]]++] = (uint32_t)t;
    for (size_t v = nverts; v > 0; v--)
        g->vt_off[v] = g->vt_off[v - 1];
    g->vt_off[0] = 0;
    for (size_t t = 0; t < ntris; t++)
        for (int i = 0; i < 3; i++)
            g->eadj[3 * t + i] = edge_neighbour(g, t, tris[3 * t + i], tris[3 * t + (i + 1) % 3]);
    *out = g;
    return GS_OK;
fail:
    gs_measure_geo_destroy(&g);
    return err;
}

void gs_measure_geo_destroy(gs_measure_geo_t *gp)
{
    struct gs_measure_geo *g = *gp;
    if (!g)
        return;
    gs_free(g->p);
    gs_free(g->vt_off);
    gs_free(g->vt);
    gs_free(g->dist);
    gs_free(g->state);
    gs_free(g->touched);
    gs_free(g->origin);
    gs_free(g->eadj);
    gs_free(g->near);
    gs_free(g->stamp);
    gs_free(g->hk);
    gs_free(g->hv);
    gs_free(g);
    *gp = NULL;
}

static inline double dist3(const double *a, const double *b)
{
    double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return sqrt(x * x + y * y + z * z);
}

/* Value at c from a and b with values da <= ... (any order): planar front
 * through a and b when its characteristic into c crosses the edge ab,
 * otherwise the shorter edge path. */
static double update(const double *a, double da, const double *b, double db, const double *c)
{
    double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ac[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double L2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    double edge = fmin(da + dist3(a, c), db + dist3(b, c));
    if (!(L2 > 0) || !isfinite(da) || !isfinite(db))
        return edge;
    double L = sqrt(L2);
    /* c in the triangle's plane: x along ab, y > 0 across it. */
    double cx = (ac[0] * ab[0] + ac[1] * ab[1] + ac[2] * ab[2]) / L;
    double ac2 = ac[0] * ac[0] + ac[1] * ac[1] + ac[2] * ac[2];
    double cy2 = ac2 - cx * cx;
    if (!(cy2 > 0))
        return edge;
    double cy = sqrt(cy2);
    double gx = (db - da) / L;
    if (gx >= 1 || gx <= -1)
        return edge;
    double gy = sqrt(1 - gx * gx);
    double foot = cx - gx * cy / gy; /* where the characteristic into c meets ab */
    if (foot < 0 || foot > L)
        return edge;
    double v = da + gx * cx + gy * cy;
    return v < edge ? v : edge;
}

gs_err gs_measure_geo_march(gs_measure_geo_t g, const uint32_t *src, const double *src_dist, size_t nsrc,
                            double radius)
{
    for (size_t i = 0; i < g->ntouched; i++) {
        g->dist[g->touched[i]] = INFINITY;
        g->state[g->touched[i]] = 0;
    }
    g->ntouched = 0;
    g->hn = 0;
    for (size_t i = 0; i < nsrc; i++) {
        uint32_t v = src[i];
        GS_CHECK(v < g->nv, GS_ERR_ARG, "geodesic source %u of %zu vertices", v, g->nv);
        double d = src_dist ? src_dist[i] : 0;
        if (!(d < g->dist[v]))
            continue;
        if (g->state[v] == 0)
            g->touched[g->ntouched++] = v;
        g->state[v] = 1;
        g->dist[v] = d;
        g->origin[v] = (uint32_t)i;
        GS_CALL(heap_push(g, d, v));
    }
    double du;
    uint32_t u;
    while (heap_pop(g, &du, &u)) {
        if (g->state[u] == 2 || du > g->dist[u])
            continue;
        g->state[u] = 2;
        for (uint32_t k = g->vt_off[u]; k < g->vt_off[u + 1]; k++) {
            const uint32_t *t = g->tris + 3 * (size_t)g->vt[k];
            for (int i = 0; i < 3; i++) {
                uint32_t w = t[i];
                if (w == u || g->state[w] == 2)
                    continue;
                uint32_t o = t[0] != u && t[0] != w ? t[0] : t[1] != u && t[1] != w ? t[1] : t[2];
                const double *pu = g->p + 3 * (size_t)u, *pw = g->p + 3 * (size_t)w, *po = g->p + 3 * (size_t)o;
                double nd = g->state[o] == 2 && o != u ? update(pu, du, po, g->dist[o], pw) : du + dist3(pu, pw);
                if (nd > radius || !(nd < g->dist[w]))
                    continue;
                if (g->state[w] == 0)
                    g->touched[g->ntouched++] = w;
                g->state[w] = 1;
                g->dist[w] = nd;
                g->origin[w] = g->state[o] == 2 && o != u && g->dist[o] < du ? g->origin[o] : g->origin[u];
                GS_CALL(heap_push(g, nd, w));
            }
        }
    }
    return GS_OK;
}

const double *gs_measure_geo_vertex_dist(gs_measure_geo_t g)
{
    return g->dist;
}

const uint32_t *gs_measure_geo_origin(gs_measure_geo_t g)
{
    return g->origin;
}

double gs_measure_geo_tri_dist(gs_measure_geo_t g, size_t t)
{
    const uint32_t *v = g->tris + 3 * t;
    return (g->dist[v[0]] + g->dist[v[1]] + g->dist[v[2]]) / 3.0;
}

/* ------------------------------------------------ contact distribution -- */

/* Distance of point p to segment ab. */
static double seg_dist(const double *p, const double *a, const double *b)
{
    double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ap[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
    double L2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    double s = L2 > 0 ? (ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / L2 : 0;
    s = s < 0 ? 0 : s > 1 ? 1 : s;
    double q[3] = {a[0] + s * ab[0] - p[0], a[1] + s * ab[1] - p[1], a[2] + s * ab[2] - p[2]};
    return sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
}

/* Nearest interface edge incident to a vertex of a triangle around one of
 * the nv vertices v[], from point p (+inf when there is none). ie_off/ie:
 * vertex -> interface edges (the other end). Each vertex's edges are looked
 * at once (g->stamp), in the order of first visit, so ties go to the first
 * edge met as if every visit were made. */
static double near_interface(struct gs_measure_geo *g, const uint32_t *ie_off, const uint32_t *ie,
                             const uint32_t *v, int nv, const double *p, uint32_t *foot)
{
    double best = INFINITY;
    uint32_t tick = ++g->tick;
    if (tick == 0) { /* wrapped: forget every stamp */
        memset(g->stamp, 0, g->nv * sizeof *g->stamp);
        tick = g->tick = 1;
    }
    for (int c = 0; c < nv; c++)
        for (uint32_t k = g->vt_off[v[c]]; k < g->vt_off[v[c] + 1]; k++) {
            const uint32_t *t = g->tris + 3 * (size_t)g->vt[k];
            for (int i = 0; i < 3; i++) {
                uint32_t a = t[i];
                if (g->stamp[a] == tick)
                    continue;
                g->stamp[a] = tick;
                for (uint32_t j = ie_off[a]; j < ie_off[a + 1]; j++) {
                    const double *pa = g->p + 3 * (size_t)a, *pb = g->p + 3 * (size_t)ie[j];
                    double d = seg_dist(p, pa, pb);
                    if (d < best) {
                        best = d;
                        *foot = dist3(p, pa) <= dist3(p, pb) ? a : ie[j];
                    }
                }
            }
        }
    return best;
}

gs_err gs_measure_interface_dist(gs_measure_geo_t g, const uint8_t *side, double *tri_dist, size_t *nsrc_out,
                                 uint32_t *foot)
{
    size_t nt = g->nt, nv = g->nv;
    uint32_t *src = NULL, *ie_off = NULL, *ie = NULL, *src_foot = NULL;
    double *sd = NULL;
    size_t ns = 0, nif = 0;
    gs_err err = GS_OK;
    /* Interface edges: an edge (a, b) of a triangle with a triangle of the
     * other side across it. Stored at both ends (CSR). */
    GS_TRY(err, gs_alloc_array((void **)&ie_off, nv + 1, sizeof *ie_off, "interface edges"), done);
    for (int pass = 0; pass < 2; pass++) {
        for (size_t t = 0; t < nt; t++) {
            const uint32_t *tv = g->tris + 3 * t;
            for (int i = 0; i < 3; i++) {
                uint32_t a = tv[i], b = tv[(i + 1) % 3], u = g->eadj[3 * t + i];
                int other = u != EADJ_NONE && u != EADJ_MULTI && !side[u] != !side[t];
                for (uint32_t k = g->vt_off[a]; u == EADJ_MULTI && k < g->vt_off[a + 1] && !other; k++) {
                    uint32_t w = g->vt[k];
                    const uint32_t *wv = g->tris + 3 * (size_t)w;
                    if (w != t && (wv[0] == b || wv[1] == b || wv[2] == b) && !side[w] != !side[t])
                        other = 1;
                }
                /* Each such edge is seen from both of its triangles: keep
                 * the positive triangle's view, once per end. */
                if (!other || !side[t])
                    continue;
                if (pass) {
                    ie[ie_off[a]++] = b;
                    ie[ie_off[b]++] = a;
                } else {
                    ie_off[a + 1]++;
                    ie_off[b + 1]++;
                }
            }
        }
        if (!pass) {
            for (size_t v = 0; v < nv; v++)
                ie_off[v + 1] += ie_off[v];
            GS_TRY(err, gs_alloc_array((void **)&ie, (size_t)ie_off[nv] + 1, sizeof *ie, "interface edges"),
                   done);
        } else {
            for (size_t v = nv; v > 0; v--)
                ie_off[v] = ie_off[v - 1];
            ie_off[0] = 0;
        }
    }
    /* Sources: the interface vertices (0) and their neighbours, which start
     * at their straight distance to the nearest interface edge (a line
     * source: the front next to the interface is planar, not a fan of
     * circles around its vertices). */
    GS_TRY(err, gs_alloc_array((void **)&src, nv ? nv : 1, sizeof *src, "interface sources"), done);
    GS_TRY(err, gs_alloc_array((void **)&sd, nv ? nv : 1, sizeof *sd, "interface sources"), done);
    GS_TRY(err, gs_alloc_array((void **)&src_foot, nv ? nv : 1, sizeof *src_foot, "interface sources"), done);
    /* near[v]: v shares a triangle with an interface vertex (elsewhere
     * near_interface finds nothing, so it is not asked). */
    memset(g->near, 0, nv);
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *tv = g->tris + 3 * t;
        if (ie_off[tv[0] + 1] > ie_off[tv[0]] || ie_off[tv[1] + 1] > ie_off[tv[1]] ||
            ie_off[tv[2] + 1] > ie_off[tv[2]])
            g->near[tv[0]] = g->near[tv[1]] = g->near[tv[2]] = 1;
    }
    for (size_t v = 0; v < nv; v++) {
        int on = ie_off[v + 1] > ie_off[v];
        nif += on;
        uint32_t f = (uint32_t)v;
        uint32_t vv = (uint32_t)v;
        double d = on ? 0 : g->near[v] ? near_interface(g, ie_off, ie, &vv, 1, g->p + 3 * v, &f) : INFINITY;
        if (isfinite(d)) {
            src[ns] = (uint32_t)v;
            src_foot[ns] = f;
            sd[ns++] = d;
        }
    }
    GS_TRY(err, gs_measure_geo_march(g, src, sd, ns, INFINITY), done);
    /* Triangles next to the interface: the straight distance of the
     * centroid to the nearest interface edge around it; the others: the
     * mean of their vertices. */
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *tv = g->tris + 3 * t;
        double c[3];
        for (int k = 0; k < 3; k++)
            c[k] = (g->p[3 * (size_t)tv[0] + k] + g->p[3 * (size_t)tv[1] + k] + g->p[3 * (size_t)tv[2] + k]) / 3;
        double d = INFINITY;
        uint32_t f = UINT32_MAX;
        for (int i = 0; i < 3; i++)
            if (ie_off[tv[i] + 1] > ie_off[tv[i]]) {
                d = near_interface(g, ie_off, ie, tv, 3, c, &f);
                break;
            }
        if (!isfinite(d)) {
            d = gs_measure_geo_tri_dist(g, t);
            if (isfinite(d)) {
                uint32_t m = tv[0];
                for (int i = 1; i < 3; i++)
                    m = g->dist[tv[i]] < g->dist[m] ? tv[i] : m;
                f = src_foot[g->origin[m]];
            }
        }
        tri_dist[t] = d;
        if (foot)
            foot[t] = f;
    }
    if (nsrc_out)
        *nsrc_out = nif;
done:
    gs_free(src);
    gs_free(sd);
    gs_free(src_foot);
    gs_free(ie_off);
    gs_free(ie);
    return err;
}

void gs_measure_contact_hist(const double *tri_dist, const uint8_t *side, size_t ntris, uint32_t nbins,
                             int64_t *pos, int64_t *neg, uint64_t *beyond)
{
    memset(pos, 0, nbins * sizeof *pos);
    memset(neg, 0, nbins * sizeof *neg);
    uint64_t far = 0;
    if (nbins == 0)
        return;
    for (size_t t = 0; t < ntris; t++) {
        double d = tri_dist[t];
        uint32_t k;
        if (!(d < (double)nbins)) {
            far++;
            k = nbins - 1;
        } else {
            k = d > 0 ? (uint32_t)d : 0;
        }
        (side[t] ? pos : neg)[k]++;
    }
    if (beyond)
        *beyond = far;
}
