/* Height distribution of a synthesized height map against its example (see
 * include/geosynth/measure.h, gs_measure_heights). analysis/field_heights.py
 * computes the same figures from field.h5. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/sort.h"

/* numpy.percentile's default (linear between the closest ranks) of sorted a */
static double percentile(const double *a, size_t n, double p)
{
    double pos = p / 100.0 * (double)(n - 1);
    size_t lo = (size_t)floor(pos);
    if (lo + 1 >= n)
        return a[n - 1];
    return a[lo] + (pos - (double)lo) * (a[lo + 1] - a[lo]);
}

static void shares(const double *h, size_t n, const double t[GS_MEASURE_HEIGHT_LEVELS], double *low,
                   double *high)
{
    size_t c[GS_MEASURE_HEIGHT_LEVELS] = {0};
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < GS_MEASURE_HEIGHT_LEVELS; k++)
            c[k] += k == 0 ? h[i] <= t[0] : h[i] >= t[k];
    *low = (double)c[0] / (double)n;
    for (int k = 1; k < GS_MEASURE_HEIGHT_LEVELS; k++)
        high[k - 1] = (double)c[k] / (double)n;
}

const double gs_measure_height_percentiles[GS_MEASURE_HEIGHT_LEVELS] = {10, 90, 95, 99};

gs_err gs_measure_heights(const double *out, size_t nout, const double *src, size_t nsrc,
                          gs_measure_heights_t *m)
{
    memset(m, 0, sizeof *m);
    GS_CHECK(nout > 0 && nsrc > 0, GS_ERR_ARG, "height distribution: empty height map (%zu, %zu samples)",
             nout, nsrc);
    double *a = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&a, nsrc, sizeof *a, "sorted example heights"), done);
    memcpy(a, src, nsrc * sizeof *a);
    gs_sort_f64(a, nsrc);
    for (int k = 0; k < GS_MEASURE_HEIGHT_LEVELS; k++)
        m->level[k] = percentile(a, nsrc, gs_measure_height_percentiles[k]);
    shares(out, nout, m->level, &m->low_out, m->high_out);
    shares(src, nsrc, m->level, &m->low_src, m->high_src);
    GS_TRY(err, gs_measure_ks(out, nout, src, nsrc, &m->ks), done);
done:
    gs_free(a);
    return err;
}
