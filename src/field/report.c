/* Geometry measures of an output against its source (see
 * include/geosynth/field.h, gs_field_geometry_measure): computed from the
 * two quantized fields alone, never from the synthesis' bookkeeping. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/field.h"
#include "geosynth/log.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"

double gs_field_step_violations(const float *v, const int64_t n[3], double spacing, double limit)
{
    int64_t nx = n[0], nxy = n[0] * n[1], pairs = 0, bad = 0;
    double lim = limit * spacing;
    for (int64_t z = 0; z < n[2]; z++)
        for (int64_t y = 0; y < n[1]; y++)
            for (int64_t x = 0; x < nx; x++) {
                int64_t i = x + nx * y + nxy * z;
                if (x + 1 < nx)
                    pairs++, bad += fabs((double)v[i + 1] - v[i]) > lim;
                if (y + 1 < n[1])
                    pairs++, bad += fabs((double)v[i + nx] - v[i]) > lim;
                if (z + 1 < n[2])
                    pairs++, bad += fabs((double)v[i + nxy] - v[i]) > lim;
            }
    return pairs ? (double)bad / (double)pairs : 0;
}

/* The same on quantized levels (a level is (hi-lo)/255 of distance). */
static double level_step_violations(const gs_qfield *q, double limit)
{
    double per = (q->hi - q->lo) / 255.0 / q->spacing; /* samples per level */
    int lim = (int)floor(limit / per); /* |dl| > lim  <=>  |dl| * per > limit */
    int64_t nx = q->nx, nxy = q->nx * q->ny, pairs = 0, bad = 0;
    const uint8_t *v = q->q;
    for (int64_t z = 0; z < q->nz; z++)
        for (int64_t y = 0; y < q->ny; y++)
            for (int64_t x = 0; x < nx; x++) {
                int64_t i = x + nx * y + nxy * z;
                if (x + 1 < nx)
                    pairs++, bad += abs(v[i + 1] - v[i]) > lim;
                if (y + 1 < q->ny)
                    pairs++, bad += abs(v[i + nx] - v[i]) > lim;
                if (z + 1 < q->nz)
                    pairs++, bad += abs(v[i + nxy] - v[i]) > lim;
            }
    return pairs ? (double)bad / (double)pairs : 0;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Inside components of q that touch none of its faces (one that does may be
 * cut by the box: the output's at its faces are, and the source's would be):
 * count and sizes (sorted ascending, *sizes owned by the caller, *n
 * entries). */
static gs_err inside_components(const gs_qfield *q, uint64_t **sizes, int64_t *n)
{
    int64_t cells = q->nx * q->ny * q->nz;
    uint8_t inside[256];
    for (int i = 0; i < 256; i++)
        inside[i] = gs_qfield_value(q, (uint8_t)i) < 0;
    uint8_t *mask = NULL;
    uint32_t *label = NULL, nc = 0;
    uint64_t *sz = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&mask, (size_t)cells, 1, "inside mask"), done);
    GS_TRY(err, gs_alloc_array((void **)&label, (size_t)cells, sizeof *label, "component labels"), done);
    for (int64_t i = 0; i < cells; i++)
        mask[i] = inside[q->q[i]];
    GS_TRY(err, gs_measure_components3(mask, (int)q->nx, (int)q->ny, (int)q->nz, NULL, label, &nc,
                                       &sz), done);
    /* components touching a face: size 0, dropped */
    for (int64_t z = 0; z < q->nz; z++)
        for (int64_t y = 0; y < q->ny; y++) {
            int face = z == 0 || z == q->nz - 1 || y == 0 || y == q->ny - 1;
            for (int64_t x = 0; x < q->nx; x += face || x == q->nx - 1 ? 1 : q->nx - 1)
                sz[label[x + q->nx * (y + q->ny * z)]] = 0;
        }
    uint32_t keep = 0;
    for (uint32_t c = 1; c <= nc; c++)
        if (sz[c])
            sz[keep++] = sz[c];
    qsort(sz, keep, sizeof *sz, cmp_u64);
    *sizes = sz;
    *n = keep;
    sz = NULL;
done:
    gs_free(mask);
    gs_free(label);
    gs_free(sz);
    return err;
}

static double median_u64(const uint64_t *s, int64_t n)
{
    if (n == 0)
        return 0;
    return n % 2 ? (double)s[n / 2] : 0.5 * ((double)s[n / 2 - 1] + (double)s[n / 2]);
}

static double share_below(const uint64_t *s, int64_t n, double t)
{
    int64_t c = 0;
    while (c < n && (double)s[c] < t)
        c++;
    return n ? (double)c / (double)n : 0;
}

gs_err gs_field_geometry_measure(const gs_qfield *out, const gs_qfield *src, int B,
                                 gs_field_geometry_report *r)
{
    memset(r, 0, sizeof *r);
    double t0 = gs_time_now();
    const int64_t on[3] = {out->nx, out->ny, out->nz}, sn[3] = {src->nx, src->ny, src->nz};
    GS_CALL(gs_measure_copy3(out->q, on, src->q, sn, GS_FIELD_COPY_WINDOW, (int64_t)B * B * B, B,
                             &r->copy));
    uint64_t *so = NULL, *ss = NULL;
    double *xo = NULL, *xs = NULL;
    int64_t no = 0, ns = 0;
    gs_err err = GS_OK;
    GS_TRY(err, inside_components(out, &so, &no), done);
    GS_TRY(err, inside_components(src, &ss, &ns), done);
    r->components_out = no, r->components_src = ns;
    r->components_per_msample_out = 1e6 * (double)no / (double)(on[0] * on[1] * on[2]);
    r->components_per_msample_src = 1e6 * (double)ns / (double)(sn[0] * sn[1] * sn[2]);
    r->component_median_out = median_u64(so, no);
    r->component_median_src = median_u64(ss, ns);
    r->fragment_share_out = share_below(so, no, r->component_median_src / 4);
    r->fragment_share_src = share_below(ss, ns, r->component_median_src / 4);
    GS_TRY(err, gs_alloc_array((void **)&xo, (size_t)(no ? no : 1), sizeof *xo, "sizes"), done);
    GS_TRY(err, gs_alloc_array((void **)&xs, (size_t)(ns ? ns : 1), sizeof *xs, "sizes"), done);
    for (int64_t i = 0; i < no; i++)
        xo[i] = (double)so[i];
    for (int64_t i = 0; i < ns; i++)
        xs[i] = (double)ss[i];
    GS_TRY(err, gs_measure_ks(xo, (size_t)no, xs, (size_t)ns, &r->component_size_ks), done);
    r->step_violations_out = level_step_violations(out, 1.5);
    r->step_violations_src = level_step_violations(src, 1.5);
    r->seconds = gs_time_now() - t0;
done:
    gs_free(so);
    gs_free(ss);
    gs_free(xo);
    gs_free(xs);
    return err;
}
