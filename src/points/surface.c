/* Implicit function of an oriented point set on a dense grid, for meshing
 * the output through OpenVDB (gs_vdb_dense_to_mesh); see points.h. */
#include <string.h>

#include "geosynth/mem.h"
#include "points/points_impl.h"

gs_err gs_points_implicit_grid(const gs_points *pts, double R, const double origin[3],
                               double voxel, size_t nx, size_t ny, size_t nz, float *out)
{
    GS_CHECK(R > 0 && voxel > 0 && nx > 0 && ny > 0 && nz > 0, GS_ERR_ARG,
             "implicit grid: radius %g, voxel %g, %zu x %zu x %zu samples: expected positive values",
             R, voxel, nx, ny, nz);
    size_t total = nx * ny * nz;
    double *num = NULL, *den = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&num, total, sizeof *num, "implicit grid"), done);
    GS_TRY(err, gs_alloc_array((void **)&den, total, sizeof *den, "implicit grid weights"), done);
    double inv_r2 = 1.0 / (R * R);
    int reach = (int)ceil(R / voxel);
    /* Splat: f(x) = sum w_i n_i.(x - p_i) / sum w_i, w = (1 - r^2/R^2)^4,
     * the same weights as the MLS surface. Points in array order, so the
     * sums (and the mesh) are deterministic. */
    for (size_t i = 0; i < pts->n; i++) {
        const gs_opoint *q = &pts->v[i];
        long c[3], lo[3], hi[3];
        long dim[3] = {(long)nx, (long)ny, (long)nz};
        for (int a = 0; a < 3; a++) {
            c[a] = lround((q->p[a] - origin[a]) / voxel);
            lo[a] = c[a] - reach < 0 ? 0 : c[a] - reach;
            hi[a] = c[a] + reach >= dim[a] ? dim[a] - 1 : c[a] + reach;
        }
        for (long k = lo[2]; k <= hi[2]; k++)
            for (long j = lo[1]; j <= hi[1]; j++)
                for (long ii = lo[0]; ii <= hi[0]; ii++) {
                    double x[3] = {origin[0] + ii * voxel, origin[1] + j * voxel,
                                   origin[2] + k * voxel};
                    double t = 1.0 - v3_dist2(x, q->p) * inv_r2;
                    if (t <= 0)
                        continue;
                    t *= t;
                    double w = t * t;
                    size_t at = ((size_t)k * ny + (size_t)j) * nx + (size_t)ii;
                    num[at] += w * ((x[0] - q->p[0]) * q->n[0] + (x[1] - q->p[1]) * q->n[1] +
                                    (x[2] - q->p[2]) * q->n[2]);
                    den[at] += w;
                }
    }
    /* Samples no point reaches: beyond the band, with the sign of the last
     * known sample above them in their z column (outside at the top), so
     * the solid below a height field and inside thick tubes stays inside. */
    float band = (float)R;
    for (size_t j = 0; j < ny; j++)
        for (size_t ii = 0; ii < nx; ii++) {
            float sign = 1;
            for (size_t k = nz; k-- > 0;) {
                size_t at = (k * ny + j) * nx + ii;
                if (den[at] > 0) {
                    double f = num[at] / den[at];
                    out[at] = (float)(f > R ? R : f < -R ? -R : f);
                    sign = out[at] < 0 ? -1.0f : 1.0f;
                } else {
                    out[at] = sign * band;
                }
            }
        }
done:
    gs_free(num);
    gs_free(den);
    return err;
}
