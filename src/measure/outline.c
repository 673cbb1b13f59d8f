/* Outline roughness of a two-sided vertex labelling on a triangle mesh (see
 * include/geosynth/measure.h, gs_measure_outline). The same measure as
 * analysis/micro_outline.py's roughness(): both are checked against each
 * other by tests/e2e/micro.sh. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/sort.h"

/* Length of the colour boundary of side[] (one flag per vertex): in a
 * triangle whose corners differ it runs between the midpoints of the two
 * edges at the lone corner, half as long as the edge opposite it. */
static double boundary_length(const double *P, const uint32_t *tris, size_t nt, const uint8_t *side)
{
    double len = 0;
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *f = tris + 3 * t;
        int n = !!side[f[0]] + !!side[f[1]] + !!side[f[2]];
        if (n == 0 || n == 3)
            continue;
        int lone = 0; /* the corner on the side the other two are not */
        for (int k = 0; k < 3; k++)
            if ((!!side[f[k]]) == (n == 1))
                lone = k;
        const double *a = P + 3 * (size_t)f[(lone + 1) % 3], *b = P + 3 * (size_t)f[(lone + 2) % 3];
        len += 0.5 * sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                          (a[2] - b[2]) * (a[2] - b[2]));
    }
    return len;
}

/* A bucket grid over the vertices: cell edge h >= r, so the points within r
 * of a vertex lie in its cell and the 26 around it. */
typedef struct grid {
    double lo[3], h;
    int64_t dim[3];
    uint32_t *start; /* [ncells + 1] */
    uint32_t *item;  /* vertices by cell */
} grid;

static int64_t cell_of(const grid *g, const double *p, int k)
{
    int64_t c = (int64_t)floor((p[k] - g->lo[k]) / g->h);
    return c < 0 ? 0 : c >= g->dim[k] ? g->dim[k] - 1 : c;
}

static gs_err grid_build(grid *g, const double *P, size_t nv, double r)
{
    memset(g, 0, sizeof *g);
    double hi[3];
    for (int k = 0; k < 3; k++)
        g->lo[k] = INFINITY, hi[k] = -INFINITY;
    for (size_t v = 0; v < nv; v++)
        for (int k = 0; k < 3; k++)
            g->lo[k] = fmin(g->lo[k], P[3 * v + k]), hi[k] = fmax(hi[k], P[3 * v + k]);
    /* Cells no smaller than r and not many more than the vertices. */
    g->h = r;
    for (;;) {
        double cells = 1;
        for (int k = 0; k < 3; k++)
            cells *= floor((hi[k] - g->lo[k]) / g->h) + 1;
        if (cells <= 4.0 * (double)nv + 64)
            break;
        g->h *= 2;
    }
    size_t nc = 1;
    for (int k = 0; k < 3; k++) {
        g->dim[k] = (int64_t)floor((hi[k] - g->lo[k]) / g->h) + 1;
        nc *= (size_t)g->dim[k];
    }
    GS_CALL(gs_alloc_array((void **)&g->start, nc + 1, sizeof *g->start, "outline grid"));
    gs_err err = gs_alloc_array((void **)&g->item, nv ? nv : 1, sizeof *g->item, "outline grid items");
    if (err != GS_OK) {
        gs_free(g->start);
        g->start = NULL;
        return err;
    }
    memset(g->start, 0, (nc + 1) * sizeof *g->start);
    for (size_t v = 0; v < nv; v++) {
        const double *p = P + 3 * v;
        g->start[1 + (size_t)(cell_of(g, p, 0) + g->dim[0] * (cell_of(g, p, 1) + g->dim[1] * cell_of(g, p, 2)))]++;
    }
    for (size_t c = 0; c < nc; c++)
        g->start[c + 1] += g->start[c];
    for (size_t v = 0; v < nv; v++) {
        const double *p = P + 3 * v;
        size_t c = (size_t)(cell_of(g, p, 0) + g->dim[0] * (cell_of(g, p, 1) + g->dim[1] * cell_of(g, p, 2)));
        g->item[g->start[c]++] = (uint32_t)v;
    }
    for (size_t c = nc; c > 0; c--)
        g->start[c] = g->start[c - 1];
    g->start[0] = 0;
    return GS_OK;
}

static void grid_free(grid *g)
{
    gs_free(g->start);
    gs_free(g->item);
}

/* out[v] = 1 when a vertex u with in[u] lies closer than r to v (v itself
 * counts), else 0: the dilation of in by an open ball of radius r. */
static void grow(const grid *g, const double *P, size_t nv, const uint8_t *in, double r, uint8_t *out)
{
    double r2 = r * r;
    for (size_t v = 0; v < nv; v++) {
        const double *p = P + 3 * v;
        uint8_t hit = in[v];
        int64_t c[3];
        for (int k = 0; k < 3; k++)
            c[k] = cell_of(g, p, k);
        for (int64_t z = c[2] - 1; z <= c[2] + 1 && !hit; z++) {
            if (z < 0 || z >= g->dim[2])
                continue;
            for (int64_t y = c[1] - 1; y <= c[1] + 1 && !hit; y++) {
                if (y < 0 || y >= g->dim[1])
                    continue;
                for (int64_t x = c[0] - 1; x <= c[0] + 1 && !hit; x++) {
                    if (x < 0 || x >= g->dim[0])
                        continue;
                    size_t cell = (size_t)(x + g->dim[0] * (y + g->dim[1] * z));
                    for (uint32_t i = g->start[cell]; i < g->start[cell + 1]; i++) {
                        uint32_t u = g->item[i];
                        if (!in[u])
                            continue;
                        const double *q = P + 3 * (size_t)u;
                        double d2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                                    (p[2] - q[2]) * (p[2] - q[2]);
                        if (d2 < r2) {
                            hit = 1;
                            break;
                        }
                    }
                }
            }
        }
        out[v] = hit;
    }
}

static void invert(uint8_t *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        s[i] = !s[i];
}

gs_err gs_measure_outline(const float *pos, size_t nv, const uint32_t *tris, size_t nt, double scale,
                          const uint8_t *side, double rho, gs_measure_outline_t *out)
{
    memset(out, 0, sizeof *out);
    out->roughness = NAN;
    GS_CHECK(rho > 0 && scale > 0, GS_ERR_ARG, "outline: radius %g and scale %g must be > 0", rho, scale);
    if (nv == 0 || nt == 0)
        return GS_OK;
    GS_CHECK(nv <= UINT32_MAX, GS_ERR_ARG, "outline: %zu vertices (at most 2^32 - 1)", nv);
    double *P = NULL, *rad = NULL;
    uint8_t *a = NULL, *b = NULL;
    grid g;
    memset(&g, 0, sizeof g);
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&P, 3 * nv, sizeof *P, "outline vertices"), done);
    GS_TRY(err, gs_alloc_array((void **)&rad, nv, sizeof *rad, "outline radii"), done);
    GS_TRY(err, gs_alloc_array((void **)&a, nv, 1, "outline sides"), done);
    GS_TRY(err, gs_alloc_array((void **)&b, nv, 1, "outline sides"), done);
    double c[3] = {0, 0, 0};
    for (size_t v = 0; v < nv; v++)
        for (int k = 0; k < 3; k++)
            c[k] += (P[3 * v + k] = (double)pos[3 * v + k] * scale);
    for (int k = 0; k < 3; k++)
        c[k] /= (double)nv;
    /* A sphere displaced along its normals (radial spread under 10%) is
     * measured on the sphere under the relief: the displacement is radial. */
    double mean = 0, var = 0;
    for (size_t v = 0; v < nv; v++) {
        const double *p = P + 3 * v;
        rad[v] = sqrt((p[0] - c[0]) * (p[0] - c[0]) + (p[1] - c[1]) * (p[1] - c[1]) + (p[2] - c[2]) * (p[2] - c[2]));
        mean += rad[v];
    }
    mean /= (double)nv;
    for (size_t v = 0; v < nv; v++)
        var += (rad[v] - mean) * (rad[v] - mean);
    if (mean > 0 && sqrt(var / (double)nv) / mean < 0.1) {
        double *copy = NULL;
        GS_TRY(err, gs_alloc_array((void **)&copy, nv, sizeof *copy, "outline radii"), done);
        memcpy(copy, rad, nv * sizeof *copy);
        gs_sort_f64(copy, nv);
        double R = nv % 2 ? copy[nv / 2] : 0.5 * (copy[nv / 2 - 1] + copy[nv / 2]);
        gs_free(copy);
        for (size_t v = 0; v < nv; v++)
            if (rad[v] > 0)
                for (int k = 0; k < 3; k++)
                    P[3 * v + k] = c[k] + (P[3 * v + k] - c[k]) * R / rad[v];
        out->on_sphere = 1;
    }
    GS_TRY(err, grid_build(&g, P, nv, rho), done);
    /* Opening: erode the side by rho, grow it back by rho. */
    for (size_t v = 0; v < nv; v++)
        a[v] = !side[v];
    grow(&g, P, nv, a, rho, b); /* b: near the other side */
    invert(b, nv);              /* b: eroded */
    grow(&g, P, nv, b, rho, a); /* a: opened */
    out->length = boundary_length(P, tris, nt, side);
    out->smoothed_length = boundary_length(P, tris, nt, a);
    out->roughness = out->smoothed_length > 0 ? out->length / out->smoothed_length : NAN;
done:
    grid_free(&g);
    gs_free(P);
    gs_free(rad);
    gs_free(a);
    gs_free(b);
    return err;
}
