/* Point-set measures (see include/geosynth/measure.h): connected components
 * of a point cloud under a linking radius. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"

static uint32_t uf_find(uint32_t *par, uint32_t i)
{
    while (par[i] != i) {
        par[i] = par[par[i]];
        i = par[i];
    }
    return i;
}

typedef struct cell_key {
    uint64_t cell;
    uint32_t idx;
} cell_key;

static int cell_key_cmp(const void *a, const void *b)
{
    const cell_key *x = a, *y = b;
    if (x->cell != y->cell)
        return x->cell < y->cell ? -1 : 1;
    return x->idx < y->idx ? -1 : x->idx > y->idx;
}

/* The cell code of integer cell coordinates (21 bits each, offset). */
static uint64_t cell_code(long cx, long cy, long cz)
{
    const long off = 1L << 20;
    return ((uint64_t)(cx + off) << 42) | ((uint64_t)(cy + off) << 21) | (uint64_t)(cz + off);
}

gs_err gs_measure_point_components(const double *xyz, size_t stride, size_t n, double radius,
                                   uint32_t *label, uint32_t *ncomp, uint64_t **sizes)
{
    GS_CHECK(radius > 0 && isfinite(radius), GS_ERR_ARG,
             "point components: radius %g, expected > 0", radius);
    GS_CHECK(n < UINT32_MAX && stride >= 3, GS_ERR_ARG,
             "point components: %zu points with stride %zu, expected < 2^32 and stride >= 3", n,
             stride);
    *ncomp = 0;
    if (sizes)
        *sizes = NULL;
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            lo[a] = fmin(lo[a], xyz[i * stride + a]);
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            GS_CHECK(isfinite(xyz[i * stride + a]) &&
                         (xyz[i * stride + a] - lo[a]) / radius < (double)(1L << 19),
                     GS_ERR_ARG, "point components: point %zu is not finite or too far out", i);
    cell_key *k = NULL;
    uint32_t *par = NULL, *first = NULL;
    uint64_t *sz = NULL;
    long (*cc)[3] = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&k, n ? n : 1, sizeof *k, "point cells"), done);
    GS_TRY(err, gs_alloc_array((void **)&par, n ? n : 1, sizeof *par, "point components"), done);
    GS_TRY(err, gs_alloc_array((void **)&cc, n ? n : 1, sizeof *cc, "point cells"), done);
    for (size_t i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++)
            cc[i][a] = (long)floor((xyz[i * stride + a] - lo[a]) / radius);
        k[i].cell = cell_code(cc[i][0], cc[i][1], cc[i][2]);
        k[i].idx = (uint32_t)i;
        par[i] = (uint32_t)i;
    }
    qsort(k, n, sizeof *k, cell_key_cmp);
    double r2 = radius * radius;
    /* Each point against the points of the 27 cells around it (binary
     * search for each cell's run in the sorted keys). */
    for (size_t i = 0; i < n; i++) {
        const double *p = xyz + i * stride;
        for (int dz = -1; dz <= 1; dz++)
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    uint64_t code = cell_code(cc[i][0] + dx, cc[i][1] + dy, cc[i][2] + dz);
                    size_t a = 0, b = n;
                    while (a < b) {
                        size_t m = a + (b - a) / 2;
                        if (k[m].cell < code)
                            a = m + 1;
                        else
                            b = m;
                    }
                    for (size_t j = a; j < n && k[j].cell == code; j++) {
                        uint32_t q = k[j].idx;
                        if (q <= i)
                            continue;
                        const double *o = xyz + (size_t)q * stride;
                        double d0 = p[0] - o[0], d1 = p[1] - o[1], d2 = p[2] - o[2];
                        if (d0 * d0 + d1 * d1 + d2 * d2 > r2)
                            continue;
                        uint32_t ra = uf_find(par, (uint32_t)i), rb = uf_find(par, q);
                        if (ra != rb)
                            par[ra > rb ? ra : rb] = ra < rb ? ra : rb;
                    }
                }
    }
    /* Number components in order of their lowest point index. */
    GS_TRY(err, gs_alloc_array((void **)&first, n ? n : 1, sizeof *first, "point components"),
           done);
    uint32_t nc = 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t r = uf_find(par, (uint32_t)i);
        if (r == i)
            first[i] = ++nc;
        label[i] = first[r];
    }
    if (sizes) {
        GS_TRY(err, gs_alloc_array((void **)&sz, (size_t)nc + 1, sizeof *sz, "component sizes"),
               done);
        memset(sz, 0, ((size_t)nc + 1) * sizeof *sz);
        for (size_t i = 0; i < n; i++)
            sz[label[i]]++;
        *sizes = sz;
        sz = NULL;
    }
    *ncomp = nc;
done:
    gs_free(cc);
    gs_free(k);
    gs_free(par);
    gs_free(first);
    gs_free(sz);
    return err;
}

gs_err gs_measure_point_pieces(const double *xyz, size_t stride, size_t n, double radius,
                               const double lo[2], const double hi[2], uint64_t small,
                               gs_measure_pieces *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(lo[0] < hi[0] && lo[1] < hi[1], GS_ERR_ARG,
             "point pieces: box (%g, %g) - (%g, %g) is empty", lo[0], lo[1], hi[0], hi[1]);
    double *in = NULL;
    uint32_t *label = NULL, nc = 0;
    uint64_t *sizes = NULL;
    uint8_t *cut = NULL;
    double *box = NULL;
    size_t m = 0;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&in, n ? n : 1, 3 * sizeof *in, "point pieces"), done);
    for (size_t i = 0; i < n; i++) {
        const double *p = xyz + i * stride;
        if (p[0] >= lo[0] && p[0] < hi[0] && p[1] >= lo[1] && p[1] < hi[1]) {
            memcpy(in + 3 * m, p, 3 * sizeof *in);
            m++;
        }
    }
    GS_TRY(err, gs_alloc_array((void **)&label, m ? m : 1, sizeof *label, "point pieces"), done);
    GS_TRY(err, gs_measure_point_components(in, 3, m, radius, label, &nc, &sizes), done);
    GS_TRY(err, gs_alloc_array((void **)&cut, (size_t)nc + 1, 1, "point pieces"), done);
    GS_TRY(err, gs_alloc_array((void **)&box, (size_t)nc + 1, 4 * sizeof *box, "point pieces"),
           done);
    memset(cut, 0, (size_t)nc + 1);
    for (uint32_t c = 0; c <= nc; c++) {
        box[4 * c] = box[4 * c + 1] = INFINITY;
        box[4 * c + 2] = box[4 * c + 3] = -INFINITY;
    }
    for (size_t i = 0; i < m; i++) {
        const double *p = in + 3 * i;
        double *b = box + 4 * label[i];
        for (int a = 0; a < 2; a++) {
            b[a] = fmin(b[a], p[a]);
            b[2 + a] = fmax(b[2 + a], p[a]);
        }
        if (p[0] - lo[0] <= radius || hi[0] - p[0] <= radius || p[1] - lo[1] <= radius ||
            hi[1] - p[1] <= radius)
            cut[label[i]] = 1;
    }
    for (uint32_t c = 1; c <= nc; c++) {
        if (cut[c]) {
            out->border++;
            continue;
        }
        out->pieces++;
        const double *b = box + 4 * c;
        double ax = hi[0] - lo[0] - (b[2] - b[0]) - 2 * radius;
        double ay = hi[1] - lo[1] - (b[3] - b[1]) - 2 * radius;
        double w = ax > 0 && ay > 0 ? 1.0 / (ax * ay) : 0; /* ax, ay > 0 for an inner piece */
        out->density += w;
        if (sizes[c] < small) {
            out->small++;
            out->small_points += sizes[c];
            out->small_density += w;
        }
    }
done:
    gs_free(in);
    gs_free(label);
    gs_free(sizes);
    gs_free(cut);
    gs_free(box);
    return err;
}
