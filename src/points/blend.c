/* The blend as a blend of implicit surfaces (points.blend_implicit): see
 * points_impl.h. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/sort.h"
#include "points/points_impl.h"

/* The points of a grid within rc of c (a query's answer, in the grid's
 * order), kept while a point's Newton steps stay near c: the evaluations
 * below read their neighbours from it instead of querying the grid (the
 * queries were 42% of a heightfield run with the implicit blend). Valid
 * for x when every point that the two queries of implicit_at would answer
 * lies within rc of c; then the answers, and so f and n, are bit-identical
 * (the cache's extra points get MLS weight +0, which leaves every sum
 * exactly as skipping them; the common points come in the same order). */
typedef struct nb_cache {
    gs_points pts;
    double c[3], rc;
    int valid;
} nb_cache;

/* Margin of a cache's radius beyond the MLS radius h of the point it was
 * made for (times R): a Newton step moves at most R / 2. */
#define CACHE_MARGIN 0.75

/* The signed distance of x to the points of g as a continuous function: the
 * MLS plane (weighted mean a, weighted normal n) of the points within
 * h = d + R of x, d the distance to the nearest point (at most reach): on
 * the surface the MLS surface of radius R, farther away a wider average
 * about the nearest part of it. A nearest-point projection jumps where x
 * crosses the surface's medial axis (a valley under a crest: its points
 * went to either flank and the sheet tore between); this does not. (h = 2 d
 * takes in a crest's flanks down to x's own height beside it, so f was 0
 * under the crest: ridged field 1.08-1.21 specks per unit area with d + R,
 * 1.24-1.45 with 2 d, before the continuation below.) *ok = 0 when no point
 * lies within reach. The neighbours come from the cache when it covers x,
 * else from the grid (and the cache is made anew about x). */
static gs_err implicit_at(const gs_points_grid *g, nb_cache *ca, double R, double reach,
                          const double x[3], gs_points *scratch, double *f, double n[3], int *ok)
{
    *ok = 0;
    double d2 = INFINITY;
    int hit = 0;
    if (ca->valid) {
        double dc = sqrt(v3_dist2(x, ca->c));
        for (size_t i = 0; i < ca->pts.n; i++) {
            double e = v3_dist2(ca->pts.v[i].p, x);
            d2 = e < d2 ? e : d2; /* fmin was a library call: 8% of a run */
        }
        /* The nearest point is in the cache when the ball about x through
         * it lies inside the cache's ball; none within reach when that
         * ball of radius reach does and holds none. */
        double d = sqrt(d2);
        if (d2 <= reach * reach ? dc + d + R <= ca->rc : dc + reach <= ca->rc)
            hit = 1;
        if (hit && !(d2 <= reach * reach))
            return GS_OK; /* no point within reach */
    }
    if (!hit) {
        scratch->n = 0;
        GS_CALL(gs_points_grid_query(g, x, R, scratch));
        d2 = INFINITY;
        for (size_t i = 0; i < scratch->n; i++)
            d2 = fmin(d2, v3_dist2(scratch->v[i].p, x));
        if (scratch->n == 0) {
            gs_opoint near;
            int found;
            GS_CALL(gs_points_grid_nearest(g, x, reach, scratch, &near, &found));
            if (!found)
                return GS_OK;
            d2 = v3_dist2(near.p, x);
        }
        /* The cache about x: the points within h + margin. */
        double h = sqrt(d2) + R;
        memcpy(ca->c, x, sizeof ca->c);
        ca->rc = h + CACHE_MARGIN * R;
        ca->pts.n = 0;
        GS_CALL(gs_points_grid_query(g, x, ca->rc, &ca->pts));
        ca->valid = 1;
    }
    double h = d2 > 0 ? sqrt(d2) + R : R;
    double a[3];
    if (gs_points_mls_frame(&ca->pts, h, x, a, n) <= 0)
        return GS_OK;
    *f = n[0] * (x[0] - a[0]) + n[1] * (x[1] - a[1]) + n[2] * (x[2] - a[2]);
    *ok = 1;
    return GS_OK;
}

/* Newton steps of the blend (each at most R / 2) and the tolerance on
 * |f| (times R) at which a point is on the blended surface. */
#define IMPLICIT_STEPS 30
#define IMPLICIT_TOL 1e-3
/* Stages of the continuation in t (each 6 Newton steps but the last): the
 * root is followed from q (t = 0) as t grows, so a point stays on the branch
 * of the zero set its neighbours stay on (from q straight at t some found a
 * root by q while their neighbours went 0.2-0.3 up: ridged field 1.08-1.21
 * -> 0.77-0.93 specks per unit area). */
#define IMPLICIT_STAGES 8
/* A point whose displacement differs from its neighbours' median by more
 * than this (times R), or that got nowhere, starts again from q plus that
 * median (a smooth displacement field where the roots still fold; points
 * left to the sheet blend were 0.3% of the strips' and 30% of the ridged
 * field's speck points): ridged field 0.77-0.93 -> 0.42-0.69; 0.5 R:
 * 0.60-0.92. */
#define IMPLICIT_FIX 0.25

/* Newton steps at blend weight t from x (in place) onto the zero set;
 * *on = 1 when |f| got below the tolerance, g the blended normal there. */
static gs_err implicit_solve(const gs_points_grid *F, const gs_points_grid *N, double R,
                             double reach, double t, int steps, double x[3], double g[3],
                             gs_points *sc, nb_cache *cF, nb_cache *cN, int *on)
{
    *on = 0;
    for (int i = 0; i < steps && !*on; i++) {
        double fF = 0, fN = 0, nF[3], nN[3];
        int okF, okN;
        GS_CALL(implicit_at(F, cF, R, reach, x, sc, &fF, nF, &okF));
        GS_CALL(implicit_at(N, cN, R, reach, x, sc, &fN, nN, &okN));
        if (!okF || !okN || v3_dot(nF, nN) < -0.9) /* facing each other: no blend */
            return GS_OK;
        double f = (1 - t) * fF + t * fN;
        for (int a = 0; a < 3; a++)
            g[a] = (1 - t) * nF[a] + t * nN[a];
        double g2 = v3_dot(g, g);
        if (!(g2 > 0.01))
            return GS_OK;
        double step = f / g2, len = fabs(step) * sqrt(g2);
        if (len > 0.5 * R)
            step *= 0.5 * R / len;
        for (int a = 0; a < 3; a++)
            x[a] -= step * g[a];
        *on = fabs(f) < IMPLICIT_TOL * R;
    }
    return GS_OK;
}

/* One point's answer (a map item: every byte set, so the items gathered
 * from the ranks are the same bytes whoever computed them). */
typedef struct implicit_res {
    double p[3], n[3];
    int32_t on, pad;
} implicit_res;

typedef struct implicit_ctx {
    const gs_points_sheet_point *v;
    const size_t *ix;     /* the items: indices into v */
    const double *start;  /* restart: 3 per item, the start of its solve; NULL: continuation from q */
    const gs_points_grid *F, *N;
    double R, reach;
    gs_points sc;         /* scratch of this process */
    nb_cache cF, cN;
} implicit_ctx;

/* gs_points_range_fn: items [lo, hi) of c->ix onto the zero set. Each item
 * starts with empty caches, so its answer depends on nothing but its own
 * inputs (the same on any process). */
static gs_err implicit_range(void *vctx, size_t lo, size_t hi, void *vout)
{
    implicit_ctx *c = vctx;
    implicit_res *out = vout;
    const int K = IMPLICIT_STAGES;
    for (size_t i = lo; i < hi; i++) {
        implicit_res *r = &out[i - lo];
        memset(r, 0, sizeof *r);
        const gs_points_sheet_point *it = &c->v[c->ix[i]];
        double x[3], g[3] = {0, 0, 0};
        int on = 0;
        c->cF.valid = c->cN.valid = 0;
        if (c->start) {
            memcpy(x, c->start + 3 * i, sizeof x);
            GS_CALL(implicit_solve(c->F, c->N, c->R, c->reach, it->t, IMPLICIT_STEPS, x, g, &c->sc,
                                   &c->cF, &c->cN, &on));
        } else {
            /* Continuation: the root followed from q (t = 0) as t grows, so
             * each point stays on its own branch of the zero set as its
             * neighbours do. */
            memcpy(x, it->q.p, sizeof x);
            for (int k = 1; k <= K; k++)
                GS_CALL(implicit_solve(c->F, c->N, c->R, c->reach, it->t * k / K,
                                       k < K ? 6 : IMPLICIT_STEPS, x, g, &c->sc, &c->cF, &c->cN,
                                       &on));
        }
        if (!on)
            continue;
        memcpy(r->p, x, sizeof r->p);
        memcpy(r->n, g, sizeof r->n);
        if (v3_normalize(r->n) <= 0)
            r->n[0] = r->n[1] = r->n[2] = 0;
        r->on = 1;
    }
    return GS_OK;
}

/* The items c->ix[0, m) through the map hook (or here), their answers
 * written back into v (found = 2; *done_n counts the new ones). */
static gs_err implicit_map(implicit_ctx *c, size_t m, gs_points_map_fn map, void *map_user,
                           gs_points_sheet_point *v, size_t *done_n)
{
    if (m == 0)
        return GS_OK; /* m is the same on every process: all skip the map */
    implicit_res *res = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&res, m, sizeof *res, "blend"), done);
    if (map)
        GS_TRY(err, map(map_user, m, sizeof *res, implicit_range, c, res), done);
    else
        GS_TRY(err, implicit_range(c, 0, m, res), done);
    for (size_t i = 0; i < m; i++) {
        if (!res[i].on)
            continue;
        gs_points_sheet_point *it = &v[c->ix[i]];
        memcpy(it->q.p, res[i].p, sizeof res[i].p);
        memcpy(it->q.n, res[i].n, sizeof res[i].n);
        *done_n += it->found != 2;
        it->found = 2;
    }
done:
    gs_free(res);
    return err;
}

gs_err gs_points_blend_implicit(gs_points_sheet_point *v, size_t n, const gs_points_grid *F,
                                const gs_points_grid *N, double R, double reach,
                                gs_points_map_fn map, void *map_user, size_t *done_n)
{
    gs_opoint *q0 = NULL;
    double *med = NULL, *tmp = NULL, *start = NULL;
    size_t *ix = NULL;
    int *has = NULL;
    gs_points_index_grid *ig = NULL;
    gs_points_indices nb = {0};
    implicit_ctx c = {.v = v, .F = F, .N = N, .R = R, .reach = reach};
    gs_err err = GS_OK;
    const double fix = IMPLICIT_FIX;
    *done_n = 0;
    GS_TRY(err, gs_alloc_array((void **)&q0, n ? n : 1, sizeof *q0, "blend"), done);
    GS_TRY(err, gs_alloc_array((void **)&ix, n ? n : 1, sizeof *ix, "blend"), done);
    size_t m = 0;
    for (size_t k = 0; k < n; k++) {
        q0[k] = v[k].q;
        if (v[k].found) /* no N_k near: left to the sheet blend (it stays) */
            ix[m++] = k;
    }
    c.ix = ix;
    GS_TRY(err, implicit_map(&c, m, map, map_user, v, done_n), done);
    if (fix >= 0 && n) {
        /* Each point's displacement against its neighbours' median (pre-blend
         * positions within R, same sheet): a point that did not get there, or
         * went more than fix R from that median, starts again from q + median. */
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (size_t k = 0; k < n; k++)
            for (int a = 0; a < 3; a++) {
                lo[a] = fmin(lo[a], q0[k].p[a] - R);
                hi[a] = fmax(hi[a], q0[k].p[a] + R);
            }
        GS_TRY(err, gs_points_index_grid_create(q0, n, lo, hi, R, &ig), done);
        GS_TRY(err, gs_alloc_array((void **)&med, 3 * n, sizeof *med, "blend"), done);
        GS_TRY(err, gs_alloc_array((void **)&has, n, sizeof *has, "blend"), done);
        size_t cap = 0;
        for (size_t k = 0; k < n; k++) {
            has[k] = 0;
            if (!v[k].found)
                continue;
            nb.n = 0;
            GS_TRY(err, gs_points_index_grid_query(ig, q0[k].p, R, &nb), done);
            if (nb.n > cap) {
                gs_free(tmp);
                tmp = NULL;
                cap = 2 * nb.n;
                GS_TRY(err, gs_alloc_array((void **)&tmp, cap, sizeof *tmp, "blend"), done);
            }
            for (int a = 0; a < 3; a++) {
                size_t mm = 0;
                for (size_t j = 0; j < nb.n; j++) {
                    size_t e = nb.v[j];
                    if (v[e].found == 2 && v3_dot(q0[e].n, q0[k].n) > 0.5)
                        tmp[mm++] = v[e].q.p[a] - q0[e].p[a];
                }
                if (mm < 3)
                    break;
                gs_sort_f64(tmp, mm);
                med[3 * k + a] = mm % 2 ? tmp[mm / 2] : 0.5 * (tmp[mm / 2 - 1] + tmp[mm / 2]);
                has[k] = a == 2;
            }
        }
        GS_TRY(err, gs_alloc_array((void **)&start, 3 * n, sizeof *start, "blend"), done);
        m = 0;
        for (size_t k = 0; k < n; k++) {
            if (!has[k])
                continue;
            double d[3];
            for (int a = 0; a < 3; a++)
                d[a] = (v[k].found == 2 ? v[k].q.p[a] - q0[k].p[a] : INFINITY) - med[3 * k + a];
            if (v[k].found == 2 && v3_dot(d, d) <= fix * fix * R * R)
                continue;
            for (int a = 0; a < 3; a++)
                start[3 * m + a] = q0[k].p[a] + med[3 * k + a];
            ix[m++] = k;
        }
        c.start = start;
        GS_TRY(err, implicit_map(&c, m, map, map_user, v, done_n), done);
    }
done:
    gs_points_index_grid_destroy(&ig);
    gs_free(nb.v);
    gs_free(q0);
    gs_free(ix);
    gs_free(has);
    gs_free(med);
    gs_free(tmp);
    gs_free(start);
    gs_points_free(&c.sc);
    gs_points_free(&c.cF.pts);
    gs_points_free(&c.cN.pts);
    return err;
}
