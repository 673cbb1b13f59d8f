/* Seam measure of a synthesized point set: how well the surface on one side
 * of a line continues on the other, at the patch seams against the same
 * inside the patches. Computed from the output points and the patch layout
 * only (no bookkeeping of the synthesis); see include/geosynth/points.h. */
#include <string.h>

#include "geosynth/mem.h"
#include "points/points_impl.h"

/* The MLS frame of the points on the other side of a line must weigh at
 * least this much (one point at 0.5 R weighs 0.32, at 0.6 R 0.17) for a band point to
 * count as matched. */
#define SEAM_MIN_WEIGHT 0.15

typedef struct seam_acc {
    double dist, normal;
    size_t n, unmatched;
} seam_acc;

/* One band point p against the points of nb on the other side of the line
 * coordinate[axis] = X. */
static void seam_point(const gs_opoint *p, gs_points *nb, gs_points *other, int axis, double X,
                       double R, seam_acc *acc)
{
    double side = p->p[axis] - X;
    other->n = 0;
    for (size_t j = 0; j < nb->n; j++) {
        double sj = nb->v[j].p[axis] - X;
        if ((side < 0) != (sj < 0))
            other->v[other->n++] = nb->v[j];
    }
    double a[3], n[3];
    acc->n++;
    if (gs_points_mls_frame(other, R, p->p, a, n) < SEAM_MIN_WEIGHT) {
        acc->unmatched++;
        return;
    }
    double d[3] = {p->p[0] - a[0], p->p[1] - a[1], p->p[2] - a[2]};
    acc->dist += fabs(v3_dot(d, n));
    acc->normal += 0.5 * (1.0 - v3_dot(p->n, n));
}

static gs_err seam_lines(const gs_points *pts, const gs_points_grid *g, double R, double band,
                         const double *lx, int nlx, const double *ly, int nly, gs_points *nb,
                         gs_points *other, seam_acc *acc)
{
    for (size_t i = 0; i < pts->n; i++) {
        const gs_opoint *p = &pts->v[i];
        for (int axis = 0; axis < 2; axis++) {
            const double *l = axis ? ly : lx;
            int nl = axis ? nly : nlx;
            for (int k = 0; k < nl; k++) {
                if (fabs(p->p[axis] - l[k]) >= band)
                    continue;
                nb->n = 0;
                GS_CALL(gs_points_grid_query(g, p->p, R, nb));
                GS_CALL(gs_points_reserve(other, nb->n));
                seam_point(p, nb, other, axis, l[k], R, acc);
            }
        }
    }
    return GS_OK;
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
    memset(acc, 0, sizeof acc);
    gs_err err = GS_OK;
    GS_TRY(err, gs_points_grid_create(lo, hi, 1.25 * R, &g), done);
    for (size_t i = 0; i < pts->n; i++)
        GS_TRY(err, gs_points_grid_add(g, &pts->v[i]), done);
    for (int w = 0; w < 2; w++) {
        const gs_points_lines *L = w ? inside : seams;
        GS_TRY(err, seam_lines(pts, g, R, band, L->x, L->nx, L->y, L->ny, &nb, &other, &acc[w]),
               done);
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
    gs_points_grid_destroy(&g);
    gs_points_free(&nb);
    gs_points_free(&other);
    return err;
}
