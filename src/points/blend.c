/* The blend as a blend of implicit surfaces (points.blend_implicit): see
 * points_impl.h. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "points/points_impl.h"

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
 * lies within reach. */
static gs_err implicit_at(const gs_points_grid *g, double R, double reach, const double x[3],
                          gs_points *scratch, double *f, double n[3], int *ok)
{
    *ok = 0;
    scratch->n = 0;
    GS_CALL(gs_points_grid_query(g, x, R, scratch));
    double d2 = INFINITY;
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
    double h = R;
    if (d2 > 0) {
        h = sqrt(d2) + R;
        scratch->n = 0;
        GS_CALL(gs_points_grid_query(g, x, h, scratch));
    }
    double a[3];
    if (gs_points_mls_frame(scratch, h, x, a, n) <= 0)
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
                             gs_points *sc, int *on)
{
    *on = 0;
    for (int i = 0; i < steps && !*on; i++) {
        double fF = 0, fN = 0, nF[3], nN[3];
        int okF, okN;
        GS_CALL(implicit_at(F, R, reach, x, sc, &fF, nF, &okF));
        GS_CALL(implicit_at(N, R, reach, x, sc, &fN, nN, &okN));
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

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

gs_err gs_points_blend_implicit(gs_points_sheet_point *v, size_t n, const gs_points_grid *F,
                                const gs_points_grid *N, double R, double reach, size_t *done_n)
{
    gs_points sc = {0};
    gs_opoint *q0 = NULL;
    double *med = NULL, *tmp = NULL;
    gs_points_index_grid *ig = NULL;
    gs_points_indices nb = {0};
    gs_err err = GS_OK;
    const int K = IMPLICIT_STAGES;
    const double fix = IMPLICIT_FIX;
    *done_n = 0;
    GS_TRY(err, gs_alloc_array((void **)&q0, n ? n : 1, sizeof *q0, "blend"), done);
    for (size_t k = 0; k < n; k++)
        q0[k] = v[k].q;
    for (size_t k = 0; k < n; k++) {
        gs_points_sheet_point *it = &v[k];
        if (!it->found)
            continue; /* no N_k near: left to the sheet blend (it stays) */
        double x[3], g[3] = {0, 0, 0};
        memcpy(x, it->q.p, sizeof x);
        int on = 0;
        /* Continuation: the root followed from q (t = 0) as t grows, so each
         * point stays on its own branch of the zero set as its neighbours do. */
        for (int c = 1; c <= K; c++)
            GS_TRY(err, implicit_solve(F, N, R, reach, it->t * c / K, c < K ? 6 : IMPLICIT_STEPS,
                                       x, g, &sc, &on), done);
        if (!on)
            continue; /* left to the sheet blend */
        memcpy(it->q.p, x, sizeof x);
        memcpy(it->q.n, g, sizeof g);
        if (v3_normalize(it->q.n) <= 0)
            it->q.n[0] = it->q.n[1] = it->q.n[2] = 0;
        it->found = 2;
        ++*done_n;
    }
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
        size_t cap = 0;
        int *has = NULL;
        GS_TRY(err, gs_alloc_array((void **)&has, n, sizeof *has, "blend"), done);
        for (size_t k = 0; k < n; k++) {
            has[k] = 0;
            if (!v[k].found)
                continue;
            nb.n = 0;
            GS_TRY(err, gs_points_index_grid_query(ig, q0[k].p, R, &nb), fixdone);
            if (nb.n > cap) {
                gs_free(tmp);
                tmp = NULL;
                cap = 2 * nb.n;
                GS_TRY(err, gs_alloc_array((void **)&tmp, cap, sizeof *tmp, "blend"), fixdone);
            }
            for (int a = 0; a < 3; a++) {
                size_t m = 0;
                for (size_t j = 0; j < nb.n; j++) {
                    size_t c = nb.v[j];
                    if (v[c].found == 2 && v3_dot(q0[c].n, q0[k].n) > 0.5)
                        tmp[m++] = v[c].q.p[a] - q0[c].p[a];
                }
                if (m < 3)
                    break;
                qsort(tmp, m, sizeof *tmp, cmp_double);
                med[3 * k + a] = m % 2 ? tmp[m / 2] : 0.5 * (tmp[m / 2 - 1] + tmp[m / 2]);
                has[k] = a == 2;
            }
        }
        for (size_t k = 0; k < n; k++) {
            if (!has[k])
                continue;
            double d[3], x[3], g[3];
            for (int a = 0; a < 3; a++)
                d[a] = (v[k].found == 2 ? v[k].q.p[a] - q0[k].p[a] : INFINITY) - med[3 * k + a];
            if (v[k].found == 2 && v3_dot(d, d) <= fix * fix * R * R)
                continue;
            for (int a = 0; a < 3; a++)
                x[a] = q0[k].p[a] + med[3 * k + a];
            int on;
            GS_TRY(err, implicit_solve(F, N, R, reach, v[k].t, IMPLICIT_STEPS, x, g, &sc, &on),
                   fixdone);
            if (!on)
                continue;
            if (v[k].found != 2)
                ++*done_n;
            memcpy(v[k].q.p, x, sizeof x);
            memcpy(v[k].q.n, g, sizeof g);
            if (v3_normalize(v[k].q.n) <= 0)
                v[k].q.n[0] = v[k].q.n[1] = v[k].q.n[2] = 0;
            v[k].found = 2;
        }
    fixdone:
        gs_free(has);
    }
done:
    gs_points_index_grid_destroy(&ig);
    gs_free(nb.v);
    gs_free(q0);
    gs_free(med);
    gs_free(tmp);
    gs_points_free(&sc);
    return err;
}
