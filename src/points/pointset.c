/* Oriented point sets and the bucket grid; see include/geosynth/points.h. */
#include <math.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/mem.h"
#include "points/points_impl.h"

gs_err gs_points_reserve(gs_points *s, size_t cap)
{
    if (cap <= s->cap)
        return GS_OK;
    size_t want = s->cap ? s->cap : 16;
    while (want < cap) {
        GS_CHECK(want <= SIZE_MAX / 2, GS_ERR_MEM, "point set of %zu points overflows", cap);
        want *= 2;
    }
    size_t bytes;
    GS_CHECK(gs_mul_size(want, sizeof(gs_opoint), &bytes), GS_ERR_MEM,
             "point set of %zu points overflows", want);
    gs_opoint *v = gs_realloc(s->v, bytes);
    GS_CHECK(v != NULL, GS_ERR_MEM, "cannot grow a point set to %zu points (%.1f MiB)", want,
             (double)bytes / 1048576.0);
    s->v = v;
    s->cap = want;
    return GS_OK;
}

gs_err gs_points_push(gs_points *s, const double p[3], const double n[3])
{
    if (s->n == s->cap)
        GS_CALL(gs_points_reserve(s, s->n + 1));
    gs_opoint *o = &s->v[s->n++];
    memcpy(o->p, p, sizeof o->p);
    memcpy(o->n, n, sizeof o->n);
    return GS_OK;
}

gs_err gs_points_append(gs_points *s, const gs_opoint *v, size_t n)
{
    if (n == 0)
        return GS_OK;
    GS_CALL(gs_points_reserve(s, s->n + n));
    memcpy(s->v + s->n, v, n * sizeof *v);
    s->n += n;
    return GS_OK;
}

void gs_points_free(gs_points *s)
{
    gs_free(s->v);
    s->v = NULL;
    s->n = s->cap = 0;
}

uint64_t gs_points_digest(const gs_points *s)
{
    return gs_digest_bytes(s->v, s->n * sizeof(gs_opoint));
}

/* The cell counts of a grid of cell size cell over [lo, hi]; *total their
 * product. */
static gs_err grid_dims(const double lo[3], const double hi[3], double cell, int dim[3],
                        size_t *total)
{
    GS_CHECK(cell > 0 && isfinite(cell), GS_ERR_ARG, "bucket grid: cell size %g must be > 0", cell);
    *total = 1;
    for (int a = 0; a < 3; a++) {
        GS_CHECK(isfinite(lo[a]) && isfinite(hi[a]) && hi[a] > lo[a], GS_ERR_ARG,
                 "bucket grid: bounds [%g, %g] on axis %d: expected lo < hi", lo[a], hi[a], a);
        double d = ceil((hi[a] - lo[a]) / cell);
        GS_CHECK(d < 1e6, GS_ERR_ARG,
                 "bucket grid: %g cells on axis %d (extent %g / cell %g): expected < 1e6", d, a,
                 hi[a] - lo[a], cell);
        dim[a] = d < 1 ? 1 : (int)d;
        GS_CHECK(gs_mul_size(*total, (size_t)dim[a], total), GS_ERR_MEM, "bucket grid too large");
    }
    return GS_OK;
}

gs_err gs_points_grid_create(const double lo[3], const double hi[3], double cell,
                             gs_points_grid_t *out)
{
    size_t total;
    int dim[3];
    GS_CALL(grid_dims(lo, hi, cell, dim, &total));
    struct gs_points_grid *g = gs_calloc(1, sizeof *g);
    GS_CHECK(g != NULL, GS_ERR_MEM, "bucket grid: out of memory");
    gs_err err = gs_alloc_array((void **)&g->cells, total, sizeof(gs_points), "bucket grid cells");
    if (err != GS_OK) {
        gs_free(g);
        GS_CALL(err);
    }
    memcpy(g->lo, lo, sizeof g->lo);
    memcpy(g->dim, dim, sizeof g->dim);
    g->cell = cell;
    g->inv_cell = 1.0 / cell;
    *out = g;
    return GS_OK;
}

void gs_points_grid_destroy(gs_points_grid_t *gp)
{
    struct gs_points_grid *g = *gp;
    if (!g)
        return;
    size_t total = (size_t)g->dim[0] * g->dim[1] * g->dim[2];
    for (size_t i = 0; i < total; i++)
        gs_points_free(&g->cells[i]);
    gs_free(g->cells);
    if (g->lab)
        for (size_t i = 0; i < total; i++)
            gs_free(g->lab[i]);
    gs_free(g->lab);
    gs_free(g);
    *gp = NULL;
}

static size_t cell_index(const struct gs_points_grid *g, const double p[3])
{
    int i = grid_coord(g, 0, p[0]), j = grid_coord(g, 1, p[1]), k = grid_coord(g, 2, p[2]);
    return ((size_t)k * g->dim[1] + j) * g->dim[0] + i;
}

/* The index grid: the geometry of a bucket grid (its cells unused) and the
 * point indices of each cell, cell by cell (start[c] .. start[c + 1] in
 * idx), in increasing order within a cell. */
struct gs_points_index_grid {
    struct gs_points_grid geom;
    const gs_opoint *pts;
    size_t *start; /* cells + 1 */
    size_t *idx;   /* n */
};

gs_err gs_points_index_grid_create(const gs_opoint *pts, size_t n, const double lo[3],
                                   const double hi[3], double cell, gs_points_index_grid **out)
{
    size_t total;
    int dim[3];
    GS_CALL(grid_dims(lo, hi, cell, dim, &total));
    struct gs_points_index_grid *g = gs_calloc(1, sizeof *g);
    GS_CHECK(g != NULL, GS_ERR_MEM, "index grid: out of memory");
    memcpy(g->geom.lo, lo, sizeof g->geom.lo);
    memcpy(g->geom.dim, dim, sizeof g->geom.dim);
    g->geom.cell = cell;
    g->geom.inv_cell = 1.0 / cell;
    g->pts = pts;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&g->start, total + 1, sizeof *g->start, "index grid"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&g->idx, n ? n : 1, sizeof *g->idx, "index grid"), fail);
    for (size_t i = 0; i < n; i++)
        g->start[cell_index(&g->geom, pts[i].p) + 1]++;
    for (size_t c = 0; c < total; c++)
        g->start[c + 1] += g->start[c];
    for (size_t i = 0; i < n; i++) { /* start[c] runs ahead while filling, then is put back */
        size_t c = cell_index(&g->geom, pts[i].p);
        g->idx[g->start[c]++] = i;
    }
    for (size_t c = total; c > 0; c--)
        g->start[c] = g->start[c - 1];
    g->start[0] = 0;
    *out = g;
    return GS_OK;
fail:
    gs_points_index_grid_destroy(&g);
    return err;
}

void gs_points_index_grid_destroy(gs_points_index_grid **gp)
{
    struct gs_points_index_grid *g = *gp;
    if (!g)
        return;
    gs_free(g->start);
    gs_free(g->idx);
    gs_free(g);
    *gp = NULL;
}

gs_err gs_points_index_grid_query(const gs_points_index_grid *g, const double c[3], double r,
                                  gs_points_indices *out)
{
    const struct gs_points_grid *geo = &g->geom;
    int lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = grid_coord(geo, a, c[a] - r);
        hi[a] = grid_coord(geo, a, c[a] + r);
    }
    double r2 = r * r;
    for (int k = lo[2]; k <= hi[2]; k++)
        for (int j = lo[1]; j <= hi[1]; j++)
            for (int i = lo[0]; i <= hi[0]; i++) {
                size_t cell = ((size_t)k * geo->dim[1] + j) * geo->dim[0] + i;
                for (size_t q = g->start[cell]; q < g->start[cell + 1]; q++) {
                    size_t p = g->idx[q];
                    if (v3_dist2(g->pts[p].p, c) > r2)
                        continue;
                    if (out->n == out->cap) {
                        size_t cap = out->cap ? 2 * out->cap : 64;
                        size_t *v = gs_realloc(out->v, cap * sizeof *v);
                        GS_CHECK(v != NULL, GS_ERR_MEM, "index grid: out of memory (%zu answers)",
                                 cap);
                        out->v = v;
                        out->cap = cap;
                    }
                    out->v[out->n++] = p;
                }
            }
    return GS_OK;
}

gs_err gs_points_grid_add(gs_points_grid_t g, const gs_opoint *pt)
{
    return gs_points_grid_add_labeled(g, pt, GS_POINTS_NO_LABEL);
}

/* Label slots of cell c as many as its points' capacity (old slots kept;
 * new ones GS_POINTS_NO_LABEL). */
static gs_err lane_fit(struct gs_points_grid *g, size_t c, size_t had)
{
    size_t cap = g->cells[c].cap;
    if (cap == had)
        return GS_OK;
    uint32_t *v = gs_realloc(g->lab[c], cap * sizeof *v);
    GS_CHECK(v != NULL, GS_ERR_MEM, "bucket grid: out of memory (labels of %zu points)", cap);
    for (size_t i = had; i < cap; i++)
        v[i] = GS_POINTS_NO_LABEL;
    g->lab[c] = v;
    return GS_OK;
}

gs_err gs_points_grid_labels_on(gs_points_grid *g)
{
    if (g->lab)
        return GS_OK;
    size_t total = (size_t)g->dim[0] * g->dim[1] * g->dim[2];
    g->lab = gs_calloc(total, sizeof *g->lab);
    GS_CHECK(g->lab != NULL, GS_ERR_MEM, "bucket grid: out of memory (label lanes)");
    for (size_t c = 0; c < total; c++)
        GS_CALL(lane_fit(g, c, 0));
    return GS_OK;
}

gs_err gs_points_grid_add_labeled(gs_points_grid *g, const gs_opoint *pt, uint32_t label)
{
    size_t c = cell_index(g, pt->p), had = g->cells[c].cap;
    GS_CALL(gs_points_append(&g->cells[c], pt, 1));
    if (g->lab) {
        GS_CALL(lane_fit(g, c, had));
        g->lab[c][g->cells[c].n - 1] = label;
    }
    g->count++;
    return GS_OK;
}

gs_err gs_points_labels_push(gs_points_labels *l, uint32_t label)
{
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 256;
        uint32_t *v = gs_realloc(l->v, cap * sizeof *v);
        GS_CHECK(v != NULL, GS_ERR_MEM, "out of memory (%zu point labels)", cap);
        l->v = v;
        l->cap = cap;
    }
    l->v[l->n++] = label;
    return GS_OK;
}

size_t gs_points_grid_remove_points(gs_points_grid_t g, const gs_opoint *pts, size_t n)
{
    size_t removed = 0;
    for (size_t i = 0; i < n; i++) {
        size_t ci = cell_index(g, pts[i].p);
        gs_points *c = &g->cells[ci];
        for (size_t r = 0; r < c->n; r++)
            if (memcmp(&c->v[r], &pts[i], sizeof pts[i]) == 0) {
                memmove(&c->v[r], &c->v[r + 1], (c->n - r - 1) * sizeof c->v[0]);
                if (g->lab)
                    memmove(&g->lab[ci][r], &g->lab[ci][r + 1],
                            (c->n - r - 1) * sizeof g->lab[ci][0]);
                c->n--;
                removed++;
                break;
            }
    }
    g->count -= removed;
    return removed;
}

size_t gs_points_grid_remove_xy(gs_points_grid_t g, const double lo[2], const double hi[2])
{
    int i0 = grid_coord(g, 0, lo[0]), i1 = grid_coord(g, 0, hi[0]);
    int j0 = grid_coord(g, 1, lo[1]), j1 = grid_coord(g, 1, hi[1]);
    size_t removed = 0;
    for (int k = 0; k < g->dim[2]; k++)
        for (int j = j0; j <= j1; j++)
            for (int i = i0; i <= i1; i++) {
                size_t ci = ((size_t)k * g->dim[1] + j) * g->dim[0] + i;
                gs_points *c = &g->cells[ci];
                uint32_t *lab = g->lab ? g->lab[ci] : NULL;
                size_t w = 0;
                for (size_t r = 0; r < c->n; r++) {
                    const double *p = c->v[r].p;
                    if (p[0] >= lo[0] && p[0] < hi[0] && p[1] >= lo[1] && p[1] < hi[1])
                        continue;
                    if (lab)
                        lab[w] = lab[r];
                    c->v[w++] = c->v[r];
                }
                removed += c->n - w;
                c->n = w;
            }
    g->count -= removed;
    return removed;
}

/* Squared distance from x to the slab of cell index i along axis a, 0
 * inside; border cells extend to infinity (they hold everything beyond). */
static inline double slab_dist2(const struct gs_points_grid *g, int a, int i, double x)
{
    double lo = g->lo[a] + i * g->cell, hi = lo + g->cell;
    double d = 0;
    if (i > 0 && x < lo)
        d = lo - x;
    else if (i < g->dim[a] - 1 && x > hi)
        d = x - hi;
    return d * d;
}

int gs_points_grid_any_within(const gs_points_grid *g, const double c[3], double r)
{
    int lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = grid_coord(g, a, c[a] - r);
        hi[a] = grid_coord(g, a, c[a] + r);
    }
    double r2 = r * r;
    for (int k = lo[2]; k <= hi[2]; k++)
        for (int j = lo[1]; j <= hi[1]; j++)
            for (int i = lo[0]; i <= hi[0]; i++) {
                const gs_points *cl = &g->cells[((size_t)k * g->dim[1] + j) * g->dim[0] + i];
                for (size_t q = 0; q < cl->n; q++)
                    if (v3_dist2(cl->v[q].p, c) < r2)
                        return 1;
            }
    return 0;
}

gs_err gs_points_grid_query(const gs_points_grid *g, const double c[3], double r, gs_points *out)
{
    int lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = grid_coord(g, a, c[a] - r);
        hi[a] = grid_coord(g, a, c[a] + r);
    }
    double r2 = r * r, c0 = c[0], c1 = c[1], c2 = c[2];
    /* Cells whose box lies farther than r are skipped (they hold no answer;
     * the order of the answers is unchanged). The margin keeps rounding in
     * the box distance from ever skipping a cell that holds an answer. */
    double skip2 = r2 * (1 + 1e-9) + 1e-300;
    /* Most cells of a query are empty (the points lie on a surface): the
     * loops keep the per-cell work small (row pointers, the x slab
     * distances tabulated, the room checked before the call). */
    enum { TAB = 32 };
    double sx[TAB];
    const int nx = hi[0] - lo[0] + 1, tab = nx <= TAB;
    for (int i = 0; tab && i < nx; i++)
        sx[i] = slab_dist2(g, 0, lo[0] + i, c0);
    for (int k = lo[2]; k <= hi[2]; k++) {
        double dk = slab_dist2(g, 2, k, c2);
        if (dk > skip2)
            continue;
        for (int j = lo[1]; j <= hi[1]; j++) {
            double djk = dk + slab_dist2(g, 1, j, c1);
            if (djk > skip2)
                continue;
            const gs_points *row = g->cells + ((size_t)k * g->dim[1] + j) * g->dim[0] + lo[0];
            for (int i = 0; i < nx; i++) {
                const gs_points *cl = row + i;
                size_t n = cl->n;
                if (n == 0 || djk + (tab ? sx[i] : slab_dist2(g, 0, lo[0] + i, c0)) > skip2)
                    continue;
                if (out->cap - out->n < n)
                    GS_CALL(gs_points_reserve(out, out->n + n));
                /* Branch-free: copy every point, keep it only when within r
                 * (the room is reserved; the test is unpredictable). */
                gs_opoint *dst = out->v + out->n;
                const gs_opoint *src = cl->v, *end = cl->v + n;
                for (; src < end; src++) {
                    double dx = src->p[0] - c0, dy = src->p[1] - c1, dz = src->p[2] - c2;
                    *dst = *src;
                    dst += dx * dx + dy * dy + dz * dz <= r2;
                }
                out->n = (size_t)(dst - out->v);
            }
        }
    }
    return GS_OK;
}

gs_err gs_points_grid_query_xy(const gs_points_grid *g, const double lo[2], const double hi[2],
                               gs_points *out)
{
    return gs_points_grid_query_xy_labeled(g, lo, hi, out, NULL);
}

gs_err gs_points_grid_query_xy_labeled(const gs_points_grid *g, const double lo[2],
                                       const double hi[2], gs_points *out, gs_points_labels *lab)
{
    int i0 = grid_coord(g, 0, lo[0]), i1 = grid_coord(g, 0, hi[0]);
    int j0 = grid_coord(g, 1, lo[1]), j1 = grid_coord(g, 1, hi[1]);
    for (int k = 0; k < g->dim[2]; k++)
        for (int j = j0; j <= j1; j++)
            for (int i = i0; i <= i1; i++) {
                size_t ci = ((size_t)k * g->dim[1] + j) * g->dim[0] + i;
                const gs_points *c = &g->cells[ci];
                for (size_t r = 0; r < c->n; r++) {
                    const double *p = c->v[r].p;
                    if (!(p[0] >= lo[0] && p[0] < hi[0] && p[1] >= lo[1] && p[1] < hi[1]))
                        continue;
                    GS_CALL(gs_points_append(out, &c->v[r], 1));
                    if (lab)
                        GS_CALL(gs_points_labels_push(lab, g->lab ? g->lab[ci][r]
                                                                  : GS_POINTS_NO_LABEL));
                }
            }
    return GS_OK;
}

size_t gs_points_grid_count(const gs_points_grid *g)
{
    return g->count;
}

gs_err gs_points_grid_collect(const gs_points_grid *g, gs_points *out)
{
    size_t total = (size_t)g->dim[0] * g->dim[1] * g->dim[2];
    GS_CALL(gs_points_reserve(out, out->n + g->count));
    for (size_t i = 0; i < total; i++)
        GS_CALL(gs_points_append(out, g->cells[i].v, g->cells[i].n));
    return GS_OK;
}

gs_err gs_points_grid_collect_labeled(const gs_points_grid *g, gs_points *out,
                                      gs_points_labels *lab)
{
    size_t total = (size_t)g->dim[0] * g->dim[1] * g->dim[2];
    GS_CALL(gs_points_grid_collect(g, out));
    for (size_t i = 0; i < total; i++)
        for (size_t r = 0; r < g->cells[i].n; r++)
            GS_CALL(gs_points_labels_push(lab, g->lab ? g->lab[i][r] : GS_POINTS_NO_LABEL));
    return GS_OK;
}

/* First point of pts (n of them) nearest to x (the order breaks ties). */
static const gs_opoint *first_nearest(const gs_opoint *pts, size_t n, const double x[3])
{
    size_t best = 0;
    double bd = v3_dist2(pts[0].p, x);
    for (size_t i = 1; i < n; i++) {
        double d = v3_dist2(pts[i].p, x);
        if (d < bd) {
            bd = d;
            best = i;
        }
    }
    return &pts[best];
}

gs_err gs_points_grid_nearest_known(const gs_points_grid *g, const double x[3], double max_reach,
                                    double known_r, gs_points *scratch, gs_opoint *out,
                                    int *found)
{
    /* The radii are those of gs_points_grid_nearest. Its answers within r
     * are the points with the query's d2 <= r * r in the grid's cell order,
     * whatever r: for r <= known_r those of the known points, and for
     * r > known_r every known point and others, all farther than any known
     * one. So while r <= known_r the nearest known point is the answer if it
     * is within r, and beyond that it is the answer if any point is known
     * (ties: the first in the order either way). */
    const gs_opoint *near = scratch->n ? first_nearest(scratch->v, scratch->n, x) : NULL;
    double bd = near ? v3_dist2(near->p, x) : INFINITY;
    double r = g->cell;
    *found = 0;
    for (;;) {
        if (r > max_reach)
            r = max_reach;
        if (r <= known_r) {
            if (bd <= r * r) {
                *out = *near;
                *found = 1;
                return GS_OK;
            }
        } else if (near) {
            *out = *near;
            *found = 1;
            return GS_OK;
        } else {
            /* Nothing within known_r: the plain search from this radius on. */
            scratch->n = 0;
            GS_CALL(gs_points_grid_query(g, x, r, scratch));
            if (scratch->n > 0) {
                *out = *first_nearest(scratch->v, scratch->n, x);
                *found = 1;
                return GS_OK;
            }
        }
        if (r >= max_reach)
            return GS_OK;
        r *= 2;
    }
}

gs_err gs_points_grid_nearest(const gs_points_grid *g, const double x[3], double max_reach,
                              gs_points *scratch, gs_opoint *out, int *found)
{
    scratch->n = 0; /* nothing known: every radius is queried */
    GS_CALL(gs_points_grid_nearest_known(g, x, max_reach, -1, scratch, out, found));
    return GS_OK;
}

/* ----------------------------------------------------------------- columns */

static size_t column_of(const gs_points_columns *c, const double p[3])
{
    int x = (int)((p[0] - c->lo[0]) / c->cell), y = (int)((p[1] - c->lo[1]) / c->cell);
    x = x >= c->nx ? c->nx - 1 : x;
    y = y >= c->ny ? c->ny - 1 : y;
    return (size_t)y * (size_t)c->nx + (size_t)x;
}

gs_err gs_points_columns_build(gs_points_columns *c, const gs_opoint *v, size_t n, double cell)
{
    memset(c, 0, sizeof *c);
    GS_CHECK(cell > 0 && isfinite(cell) && n < UINT32_MAX, GS_ERR_ARG,
             "point columns: cell %g over %zu points, expected a positive cell and < 2^32 points",
             cell, n);
    double lo[2] = {0, 0}, hi[2] = {0, 0};
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 2; a++) {
            lo[a] = i ? fmin(lo[a], v[i].p[a]) : v[i].p[a];
            hi[a] = i ? fmax(hi[a], v[i].p[a]) : v[i].p[a];
        }
    for (;;) { /* wider columns when there would be far more than points */
        double nx = floor((hi[0] - lo[0]) / cell) + 1, ny = floor((hi[1] - lo[1]) / cell) + 1;
        if (nx * ny <= 4.0 * (double)n + 16) {
            c->nx = (int)nx;
            c->ny = (int)ny;
            break;
        }
        cell *= 2;
    }
    c->lo[0] = lo[0];
    c->lo[1] = lo[1];
    c->cell = cell;
    size_t nc = (size_t)c->nx * (size_t)c->ny;
    gs_err err = gs_alloc_array((void **)&c->start, nc + 1, sizeof *c->start, "point columns");
    if (err == GS_OK)
        err = gs_alloc_array((void **)&c->idx, n ? n : 1, sizeof *c->idx, "point columns");
    if (err != GS_OK) {
        gs_points_columns_free(c);
        GS_CALL(err);
    }
    memset(c->start, 0, (nc + 1) * sizeof *c->start);
    for (size_t i = 0; i < n; i++)
        c->start[column_of(c, v[i].p) + 1]++;
    for (size_t k = 0; k < nc; k++)
        c->start[k + 1] += c->start[k];
    /* start[k] runs through column k's slots, then is put back */
    for (size_t i = 0; i < n; i++)
        c->idx[c->start[column_of(c, v[i].p)]++] = (uint32_t)i;
    for (size_t k = nc; k > 0; k--)
        c->start[k] = c->start[k - 1];
    c->start[0] = 0;
    return GS_OK;
}

void gs_points_columns_free(gs_points_columns *c)
{
    GS_FREE(c->start);
    GS_FREE(c->idx);
}

int gs_points_columns_range(const gs_points_columns *c, const double lo[2], const double hi[2],
                            int r[4])
{
    if (!c->start)
        return 0;
    double f[4] = {floor((lo[0] - c->lo[0]) / c->cell), floor((hi[0] - c->lo[0]) / c->cell),
                   floor((lo[1] - c->lo[1]) / c->cell), floor((hi[1] - c->lo[1]) / c->cell)};
    if (!(f[1] >= 0 && f[3] >= 0 && f[0] < c->nx && f[2] < c->ny))
        return 0;
    r[0] = f[0] < 0 ? 0 : (int)f[0];
    r[1] = f[1] >= c->nx ? c->nx - 1 : (int)f[1];
    r[2] = f[2] < 0 ? 0 : (int)f[2];
    r[3] = f[3] >= c->ny ? c->ny - 1 : (int)f[3];
    return 1;
}
