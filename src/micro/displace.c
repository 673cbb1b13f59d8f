/* Displacement mapping from triangle labels (paper 4.5, Table 1). */
#include <math.h>
#include <string.h>

#include "geosynth/mem.h"
#include "micro/micro_impl.h"

double gs_micro_func_eval(gs_micro_func f, double x)
{
    switch (f) {
    case GS_MICRO_LINEAR: return x;
    case GS_MICRO_SQRT: return sqrt(x);
    case GS_MICRO_SQUARE: return x * x;
    case GS_MICRO_CBRT: return cbrt(x);
    case GS_MICRO_STEP: return x > 0 ? 1.0 : 0.0;
    }
    return x;
}

gs_err gs_micro_displace(gs_micro_mesh *m, const double *tri_value, const gs_micro_displace_params *p,
                         double *vertex_value, float *out_pos)
{
    for (int s = 0; s < 2; s++) {
        GS_CHECK(p->direction[s] >= -1 && p->direction[s] <= 1, GS_ERR_ARG,
                 "%s region direction %d: expected -1 (in), 0 (none) or 1 (out)", s ? "negative" : "positive",
                 p->direction[s]);
        GS_CHECK(isfinite(p->scale[s]) && p->scale[s] >= 0, GS_ERR_ARG, "%s region scale %g: expected >= 0",
                 s ? "negative" : "positive", p->scale[s]);
        GS_CHECK((int)p->func[s] >= GS_MICRO_LINEAR && p->func[s] <= GS_MICRO_STEP, GS_ERR_ARG,
                 "%s region function %d: expected linear, sqrt, square, cbrt or step",
                 s ? "negative" : "positive", (int)p->func[s]);
    }
    if (!m->normals)
        GS_CALL(gs_micro_mesh_normals(m));
    double *sum = NULL;
    uint32_t *cnt = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&sum, m->nverts, sizeof *sum, "vertex values"), done);
    GS_TRY(err, gs_alloc_array((void **)&cnt, m->nverts, sizeof *cnt, "vertex values"), done);
    for (uint32_t t = 0; t < m->ntris; t++)
        for (int i = 0; i < 3; i++) {
            uint32_t v = m->tris[3 * (size_t)t + i];
            sum[v] += tri_value[t];
            cnt[v]++;
        }
    double h = gs_micro_mesh_half_extent(m);
    for (uint32_t v = 0; v < m->nverts; v++) {
        double x = cnt[v] ? sum[v] / cnt[v] : 0;
        if (vertex_value)
            vertex_value[v] = x;
        int s = x < 0; /* region by the sign of the vertex value */
        double off = x == 0 ? 0 : p->direction[s] * p->scale[s] * gs_micro_func_eval(p->func[s], fabs(x)) * h;
        for (int c = 0; c < 3; c++)
            out_pos[3 * (size_t)v + c] =
                (float)((double)m->pos[3 * (size_t)v + c] + off * m->normals[3 * (size_t)v + c]);
    }
done:
    gs_free(sum);
    gs_free(cnt);
    return err;
}
