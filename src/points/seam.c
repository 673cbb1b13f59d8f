/* Seam measure of a synthesized point set: how well the surface on one side
 * of a line continues on the other, at the patch seams against the same
 * inside the patches. Computed from the output points and the patch layout
 * only (no bookkeeping of the synthesis); see include/geosynth/points.h. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/sort.h"
#include "points/points_impl.h"


/* A segment counts with at least this many band points. */
#define SEGMENT_MIN_POINTS 10

/* Band points and unmatched ones per segment: [2 * (line * nseg + k)]. */
typedef struct seam_acc {
    double dist, normal;
    size_t n, unmatched;
    size_t *seg; /* per axis: (lines x nseg) pairs */
    size_t nseg[2], off[2];
} seam_acc;

/* One band point p against the points of nb on the other side of the line
 * coordinate[axis] = X. */
static void seam_point(const gs_opoint *p, gs_points *nb, gs_points *other, int axis, double X,
                       double R, seam_acc *acc, size_t *cell)
{
    if (cell)
        cell[0]++;
    double side = p->p[axis] - X;
    other->n = 0;
    for (size_t j = 0; j < nb->n; j++) {
        double sj = nb->v[j].p[axis] - X;
        if ((side < 0) != (sj < 0))
            other->v[other->n++] = nb->v[j];
    }
    double a[3], n[3];
    acc->n++;
    if (gs_points_mls_frame(other, R, p->p, a, n) < GS_POINTS_SEAM_MIN_WEIGHT) {
        acc->unmatched++;
        if (cell)
            cell[1]++;
        return;
    }
    double d[3] = {p->p[0] - a[0], p->p[1] - a[1], p->p[2] - a[2]};
    acc->dist += fabs(v3_dot(d, n));
    acc->normal += 0.5 * (1.0 - v3_dot(p->n, n));
}

static gs_err seam_lines(const gs_points *pts, const gs_points_grid *g, double R, double band,
                         const gs_points_lines *L, const double *lo, gs_points *nb,
                         gs_points *other, seam_acc *acc)
{
    for (size_t i = 0; i < pts->n; i++) {
        const gs_opoint *p = &pts->v[i];
        for (int axis = 0; axis < 2; axis++) {
            const double *l = axis ? L->y : L->x;
            int nl = axis ? L->ny : L->nx;
            for (int k = 0; k < nl; k++) {
                if (fabs(p->p[axis] - l[k]) >= band)
                    continue;
                size_t *cell = NULL;
                if (acc->seg) { /* the segment along the line (the other axis) */
                    double u = (p->p[1 - axis] - lo[1 - axis]) / L->seg;
                    size_t j = u < 0 ? 0 : (size_t)u;
                    if (j >= acc->nseg[axis])
                        j = acc->nseg[axis] - 1;
                    cell = acc->seg + 2 * (acc->off[axis] + (size_t)k * acc->nseg[axis] + j);
                }
                nb->n = 0;
                GS_CALL(gs_points_grid_query(g, p->p, R, nb));
                GS_CALL(gs_points_reserve(other, nb->n));
                seam_point(p, nb, other, axis, l[k], R, acc, cell);
            }
        }
    }
    return GS_OK;
}

/* acc->seg for lines L over points spanning [lo, hi] (none without L->seg). */
static gs_err segments_alloc(const gs_points_lines *L, const double *lo, const double *hi,
                             seam_acc *acc)
{
    if (!(L->seg > 0))
        return GS_OK;
    size_t total = 0;
    for (int a = 0; a < 2; a++) {
        acc->nseg[a] = (size_t)((hi[1 - a] - lo[1 - a]) / L->seg) + 1;
        acc->off[a] = total;
        total += (size_t)(a ? L->ny : L->nx) * acc->nseg[a];
    }
    GS_CALL(gs_alloc_array((void **)&acc->seg, total ? 2 * total : 1, sizeof *acc->seg,
                           "seam segments"));
    memset(acc->seg, 0, (total ? 2 * total : 1) * sizeof *acc->seg);
    return GS_OK;
}

/* The unmatched share of each segment of >= SEGMENT_MIN_POINTS band
 * points into v (sized for every segment); returns how many. */
static size_t segment_shares(const seam_acc *acc, const gs_points_lines *L, double *v)
{
    size_t m = 0, total = (size_t)L->nx * acc->nseg[0] + (size_t)L->ny * acc->nseg[1];
    for (size_t c = 0; acc->seg && c < total; c++)
        if (acc->seg[2 * c] >= SEGMENT_MIN_POINTS)
            v[m++] = (double)acc->seg[2 * c + 1] / (double)acc->seg[2 * c];
    return m;
}

gs_err gs_points_seam_measure(const gs_points *pts, double R, double band,
                              const gs_points_lines *seams, const gs_points_lines *inside,
                              gs_points_seam_stats *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(R > 0 && band > 0, GS_ERR_ARG, "seam measure: radius %g, band %g: expected > 0", R,
             band);
    if (pts->n == 0)
        return GS_OK;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < pts->n; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], pts->v[i].p[a]);
            hi[a] = fmax(hi[a], pts->v[i].p[a]);
        }
    for (int a = 0; a < 3; a++) {
        lo[a] -= R;
        hi[a] += R;
    }
    gs_points_grid_t g = NULL;
    gs_points nb = {0}, other = {0};
    seam_acc acc[2];
    double *sh[2] = {NULL, NULL};
    memset(acc, 0, sizeof acc);
    gs_err err = GS_OK;
    GS_TRY(err, gs_points_grid_create(lo, hi, 1.25 * R, &g), done);
    for (size_t i = 0; i < pts->n; i++)
        GS_TRY(err, gs_points_grid_add(g, &pts->v[i]), done);
    for (int w = 0; w < 2; w++) {
        const gs_points_lines *L = w ? inside : seams;
        GS_TRY(err, segments_alloc(L, lo, hi, &acc[w]), done);
        GS_TRY(err, seam_lines(pts, g, R, band, L, lo, &nb, &other, &acc[w]), done);
    }
    {
        size_t ns[2];
        for (int w = 0; w < 2; w++) {
            const gs_points_lines *L = w ? inside : seams;
            size_t cap = (size_t)L->nx * acc[w].nseg[0] + (size_t)L->ny * acc[w].nseg[1];
            GS_TRY(err, gs_alloc_array((void **)&sh[w], cap ? cap : 1, sizeof *sh[w],
                                       "seam segments"), done);
            ns[w] = segment_shares(&acc[w], L, sh[w]);
        }
        out->seam_segments = ns[0];
        out->inside_segments = ns[1];
        if (ns[0] > 0 && ns[1] > 0) {
            gs_sort_f64(sh[1], ns[1]);
            double p90 = sh[1][(size_t)floor(0.9 * (double)(ns[1] - 1))];
            size_t above = 0;
            for (size_t j = 0; j < ns[0]; j++)
                above += sh[0][j] > p90;
            out->inside_open_p90 = p90;
            out->seam_open_segments = (double)above / (double)ns[0];
        }
    }
    out->seam_points = acc[0].n;
    out->inside_points = acc[1].n;
    for (int w = 0; w < 2; w++) {
        size_t m = acc[w].n - acc[w].unmatched;
        double d = m ? acc[w].dist / (double)m : 0, nr = m ? acc[w].normal / (double)m : 0;
        double u = acc[w].n ? (double)acc[w].unmatched / (double)acc[w].n : 0;
        if (w) {
            out->inside_dist = d;
            out->inside_normal = nr;
            out->inside_unmatched = u;
        } else {
            out->seam_dist = d;
            out->seam_normal = nr;
            out->seam_unmatched = u;
        }
    }
done:
    gs_free(acc[0].seg);
    gs_free(acc[1].seg);
    gs_free(sh[0]);
    gs_free(sh[1]);
    gs_points_grid_destroy(&g);
    gs_points_free(&nb);
    gs_points_free(&other);
    return err;
}
