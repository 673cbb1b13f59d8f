/* Internal helpers shared by the points engine files (not public API). */
#ifndef GEOSYNTH_POINTS_IMPL_H
#define GEOSYNTH_POINTS_IMPL_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "geosynth/points.h"

#define GS_PI 3.14159265358979323846

struct gs_points_grid {
    double lo[3];
    double inv_cell;
    double cell;
    int dim[3];
    gs_points *cells; /* dim[0]*dim[1]*dim[2], x fastest */
    size_t count;
    uint32_t **lab;   /* NULL, or per cell a label per point (gs_points_grid_labels_on),
                         as many slots as the cell's capacity, kept in step with it */
};

/* Cell coordinate of x along axis a, clamped to the grid. */
static inline int grid_coord(const struct gs_points_grid *g, int a, double x)
{
    double f = (x - g->lo[a]) * g->inv_cell;
    if (!(f >= 0))
        return 0;
    if (f >= g->dim[a] - 1)
        return g->dim[a] - 1;
    return (int)f;
}

static inline double v3_dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline double v3_dist2(const double a[3], const double b[3])
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}
static inline void v3_cross(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}
static inline double v3_normalize(double a[3])
{
    double l = sqrt(v3_dot(a, a));
    if (l > 0) {
        a[0] /= l;
        a[1] /= l;
        a[2] /= l;
    }
    return l;
}

/* MLS evaluation over a gathered neighbour set: weighted average a and
 * normalized weighted normal n at y. Returns the weight sum (0: none). */
double gs_points_mls_frame(const gs_points *nb, double R, const double y[3], double a[3],
                           double n[3]);

/* Degree-2 MLS (Levin's, over the frame of gs_points_mls_frame at y): the
 * weighted least-squares height of nb over that frame's plane as a
 * quadratic in the plane's coordinates, evaluated at x's: out is x moved
 * along the frame's normal onto it, nout its normal. The plane alone lies
 * inside a curved sheet (on the chain mail's tubes ~0.2 spacings); the
 * quadratic does not. Falls back to the plane when the points do not fix
 * a quadratic. Returns the frame's weight sum (0: no surface). */
double gs_points_mls_quadric(const gs_points *nb, double R, const double y[3], const double x[3],
                             double out[3], double nout[3]);

/* Nearest point of g to x within max_reach; *found = 0 when none. */
gs_err gs_points_grid_nearest(const gs_points_grid *g, const double x[3], double max_reach,
                              gs_points *scratch, gs_opoint *out, int *found);

/* gs_points_grid_nearest when scratch already holds the answers of
 * gs_points_grid_query(g, x, known_r) (in its order): the same result, with
 * the queries it makes answered from them where they can be. Overwrites
 * scratch. */
gs_err gs_points_grid_nearest_known(const gs_points_grid *g, const double x[3], double max_reach,
                                    double known_r, gs_points *scratch, gs_opoint *out,
                                    int *found);

/* One node of a distance field (see gs_points_field). */
gs_err gs_points_field_node(const gs_points_grid *g, double R, double trunc, double max_reach,
                            const double x[3], gs_points *scratch, float o[4]);

/* Nodes [first, first + count) of gs_points_field (x fastest) into out
 * (4 floats each). */
gs_err gs_points_field_range(const gs_points_grid *g, double R, double trunc, double max_reach,
                             const double lo[3], const double step[3], int nx, int ny,
                             size_t first, size_t count, gs_points *scratch, float *out);

/* The blend of one point q of F' onto N_k (synth.c): see there. */
gs_err gs_points_blend_target(const gs_points_grid *out, double R, int ray, gs_points *scratch,
                              gs_points *scratch2, const gs_opoint *q, double y[3], double n[3],
                              int *found);
gs_err gs_points_blend_onto(const gs_points_grid *out, double R, int ray, int blend, double t,
                            gs_points *scratch, gs_points *scratch2, gs_opoint *q,
                            double *resid, int *found, int *keep);

/* A strip point of F' for gs_points_blend_sheet: q, its own target y on N_k
 * with normal yn (gs_points_blend_target; found = 0: none) and blend weight
 * t > 0. */
typedef struct gs_points_sheet_point {
    gs_opoint q;
    double y[3], yn[3], t;
    int found;
} gs_points_sheet_point;

/* The blend of a patch's strip points onto N_k together (synth.c,
 * blend_smooth): each q moves by t times the mean of the displacements
 * y - q of the points within R that found N_k (MLS weights, normals within
 * 60 degrees: the same sheet), its normal toward their normals; a point
 * with no such neighbour stays. A blended normal that vanishes becomes 0
 * (the caller drops the point). */
gs_err gs_points_blend_sheet(gs_points_sheet_point *v, size_t n, double R);

/* The blend as the zero set of (1 - t) f_F + t f_N (blend.c,
 * points.blend_implicit): f_F, f_N continuous signed distances to F' (the
 * points of F) and N_k (N), each v[k] with found != 0 moved from q by Newton
 * steps along (1 - t) n_F + t n_N onto it, its normal that blend of normals;
 * found = 2 marks those that got there (*done_n of them), the others are
 * left as they were (for gs_points_blend_sheet). reach: how far f_F, f_N
 * look for a point. The per-point solves go through the map hook map
 * (NULL: here; collective if it is): each point's answer depends on its
 * own inputs only, so v ends the same for any split. */
gs_err gs_points_blend_implicit(gs_points_sheet_point *v, size_t n, const gs_points_grid *F,
                                const gs_points_grid *N, double R, double reach,
                                gs_points_map_fn map, void *map_user, size_t *done_n);

/* The links the blend tore (synth.c, blend_smooth): pre[k] is sheet point
 * k before gs_points_blend_sheet, v[k].q after it (normal 0: dropped). Two
 * points within `link` of each other before (normals not opposed: the same
 * side of a thin ring or thread) that end farther apart get points along
 * the segment between them, at most `link` apart, each moved onto the MLS
 * surface (radius R) of the blended points and kept unless a blended or
 * added point lies within link / 2 (the synthesis: the sampling spacing,
 * as dart throwing sampled the example). They are appended to *out. */
gs_err gs_points_blend_bridge(const gs_opoint *pre, const gs_points_sheet_point *v, size_t n,
                              double link, double R, gs_points *out);

/* An index sorted by a double key, ties by index (a total order, so a sort
 * gives one result whatever the input order). */
typedef struct keyed {
    double key;
    size_t idx;
} keyed;
int gs_points_keyed_cmp(const void *a, const void *b); /* qsort comparator */

/* Points bucketed by xy columns of side `cell`, with their indices (a
 * counting sort: a column lists its points in array order). Used for the
 * input points of a patch (synth.c) and the pairing candidates (warp.c). */
typedef struct gs_points_columns {
    double lo[2], cell;
    int nx, ny;
    size_t *start; /* nx*ny + 1 */
    uint32_t *idx;
} gs_points_columns;

/* Columns of side cell over v[0, n) (n < 2^32), or wider (doubled) when
 * that would make more than 4n + 16 columns. */
gs_err gs_points_columns_build(gs_points_columns *c, const gs_opoint *v, size_t n, double cell);
void gs_points_columns_free(gs_points_columns *c);
/* The columns meeting the xy box [lo, hi] as r = {x0, x1, y0, y1}; 0 when
 * none (the box misses the columns' range). */
int gs_points_columns_range(const gs_points_columns *c, const double lo[2], const double hi[2],
                            int r[4]);

/* Pairing of the warp (eq. 1-3): see warp.c. */
typedef struct gs_points_pairing_in {
    const gs_opoint *S; const double *Sv; size_t ns;   /* source points + variation */
    const gs_opoint *Q; const double *Qv; size_t nq;   /* target points + variation */
    const gs_points_params *p;
    double spacing;
} gs_points_pairing_in;

/* pair[i] = index in S paired with Q[i], or -1 when none. */
gs_err gs_points_pairing(const gs_points_pairing_in *in, long *pair);

/* Per-point labels carried beside a bucket grid's points (pointset.c): the
 * synthesis' output grid keeps the patch that pasted each point this way.
 * Every change of the grid keeps them in step: gs_points_grid_add gives a
 * point GS_POINTS_NO_LABEL, the removals drop a point's label with it, the
 * labelled query and collect hand them out in the points' order. */
#define GS_POINTS_NO_LABEL UINT32_MAX
/* Gives g a label lane (every point it holds: GS_POINTS_NO_LABEL). */
gs_err gs_points_grid_labels_on(gs_points_grid *g);
gs_err gs_points_grid_add_labeled(gs_points_grid *g, const gs_opoint *pt, uint32_t label);
/* A growable array of labels (zero-initialize; free with gs_free(v)). */
typedef struct gs_points_labels {
    uint32_t *v;
    size_t n, cap;
} gs_points_labels;
gs_err gs_points_labels_push(gs_points_labels *l, uint32_t label);
/* gs_points_grid_query_xy that appends each point's label to lab as well
 * (GS_POINTS_NO_LABEL when g has no lane). */
gs_err gs_points_grid_query_xy_labeled(const gs_points_grid *g, const double lo[2],
                                       const double hi[2], gs_points *out, gs_points_labels *lab);
/* gs_points_grid_collect that appends each point's label to lab as well. */
gs_err gs_points_grid_collect_labeled(const gs_points_grid *g, gs_points *out,
                                      gs_points_labels *lab);

#endif
