/* PLY point sets (vertices with normals); see include/geosynth/pointply.h. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "geosynth/pointply.h"
#include "io/ply_internal.h"

#define MAX_FILE_BYTES ((size_t)1 << 36)

gs_err gs_pointply_parse(const char *data, size_t len, const char *name, int require_normals,
                         gs_pointply *out)
{
    memset(out, 0, sizeof *out);
    gs_ply r;
    GS_CALL(gs_ply_begin(&r, data, len, name));
    double *v = NULL;
    gs_err err = GS_OK;
    int vi = gs_ply_find_elem(&r, "vertex");
    GS_TRY_CHECK(err, vi >= 0, GS_ERR_FORMAT, done,
                 "%s: the header declares no 'vertex' element: expected points with x y z", name);
    gs_ply_elem *ve = &r.elems[vi];
    static const char *rn[6] = {"x", "y", "z", "nx", "ny", "nz"};
    static const char *alt[6] = {"x", "y", "z", "normal_x", "normal_y", "normal_z"};
    int has[6] = {0};
    for (int role = 0; role < 6; role++) {
        const char *names[2] = {rn[role], alt[role]};
        int k = gs_ply_find_prop(ve, names, 2);
        if (k < 0)
            continue;
        GS_TRY_CHECK(err, !ve->props[k].list, GS_ERR_FORMAT, done,
                     "%s: line %d: vertex property %s is a list: expected a scalar", name,
                     ve->line, ve->props[k].name);
        ve->props[k].role = role;
        has[role] = 1;
    }
    for (int k = 0; k < 3; k++)
        GS_TRY_CHECK(err, has[k], GS_ERR_FORMAT, done,
                     "%s: line %d: element vertex has no property %s: expected x y z", name,
                     ve->line, rn[k]);
    int normals = has[3] + has[4] + has[5];
    GS_TRY_CHECK(err, normals == 0 || normals == 3, GS_ERR_FORMAT, done,
                 "%s: line %d: element vertex has only some of nx ny nz", name, ve->line);
    GS_TRY_CHECK(err, normals == 3 || !require_normals, GS_ERR_FORMAT, done,
                 "%s: line %d: element vertex has no normals (nx ny nz): oriented points are "
                 "needed (estimate and orient normals first, or give a mesh)", name, ve->line);
    GS_TRY_CHECK(err, ve->count > 0, GS_ERR_FORMAT, done, "%s: element vertex has 0 points", name);
    for (int i = 0; i < vi; i++)
        GS_TRY(err, gs_ply_skip_elem(&r, &r.elems[i]), done);
    /* A cheap bound before allocating: every vertex needs its bytes. */
    GS_TRY(err, gs_ply_check_fits(&r, ve), done);
    GS_TRY(err, gs_alloc_array((void **)&v, ve->count, 6 * sizeof *v, "PLY points"), done);
    for (size_t item = 0; item < ve->count; item++) {
        double vals[6] = {0, 0, 0, 0, 0, 0};
        gs_ply_skip_blanks(&r);
        size_t at = r.pos;
        int at_line = r.line;
        GS_TRY(err, gs_ply_item(&r, ve, item, vals, NULL, 0, NULL), done);
        char where[64];
        if (r.ascii)
            snprintf(where, sizeof where, "line %d", at_line);
        else
            snprintf(where, sizeof where, "byte %zu", at);
        double *o = v + 6 * item;
        memcpy(o, vals, sizeof vals);
        for (int k = 0; k < 3; k++)
            GS_TRY_CHECK(err, isfinite(o[k]), GS_ERR_FORMAT, done,
                         "%s: %s: vertex %zu has a non-finite coordinate", name, where, item);
        if (normals) {
            /* Scaled by the largest component first: a tiny or huge normal
             * (1e-160, 1e200) would underflow or overflow its squares. */
            double m = fmax(fabs(o[3]), fmax(fabs(o[4]), fabs(o[5])));
            GS_TRY_CHECK(err, m > 0 && isfinite(m), GS_ERR_FORMAT, done,
                         "%s: %s: vertex %zu has a zero or non-finite normal (%g, %g, %g)", name,
                         where, item, o[3], o[4], o[5]);
            for (int k = 3; k < 6; k++)
                o[k] /= m;
            double l = sqrt(o[3] * o[3] + o[4] * o[4] + o[5] * o[5]);
            if (l != 1.0)
                for (int k = 3; k < 6; k++)
                    o[k] /= l;
        }
    }
    out->n = ve->count;
    out->v = v;
    out->has_normals = normals == 3;
    v = NULL;
done:
    gs_free(v);
    gs_ply_end(&r);
    return err;
}

gs_err gs_pointply_read(const char *path, int require_normals, gs_pointply *out)
{
    memset(out, 0, sizeof *out);
    char *data = NULL;
    size_t len = 0;
    GS_CALL(gs_file_read_all(path, MAX_FILE_BYTES, &data, &len));
    gs_err err = gs_pointply_parse(data, len, path, require_normals, out);
    gs_free(data);
    GS_CALL(err);
    return GS_OK;
}

void gs_pointply_destroy(gs_pointply *p)
{
    gs_free(p->v);
    memset(p, 0, sizeof *p);
}

gs_err gs_pointply_write(const char *path, const double *v, size_t n, int with_normals,
                         gs_pointply_format format)
{
    return gs_pointply_write_ids(path, v, n, with_normals, NULL, NULL, format);
}

gs_err gs_pointply_write_ids(const char *path, const double *v, size_t n, int with_normals,
                             const char *id_name, const int32_t *id, gs_pointply_format format)
{
    GS_CHECK(n <= GS_POINTPLY_MAX_POINTS, GS_ERR_ARG, "%s: %zu points, at most %zu can be written",
             path, n, GS_POINTPLY_MAX_POINTS);
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    FILE *f = af.f;
    /* float32 (24 bytes an oriented point, as PLY point clouds usually are):
     * the synthesis' doubles rounded to nearest */
    int ok = fprintf(f, "ply\nformat %s 1.0\ncomment geosynth oriented point set\n"
                        "comment up_axis z (input.up = y: the example's y); units: the example's\n"
                        "comment ParaView: open, then Filters > Convert To Point Cloud (vertex cells)\n"
                        "element vertex %zu\nproperty float x\nproperty float y\n"
                        "property float z\n%s",
                     format == GS_POINTPLY_ASCII ? "ascii" : "binary_little_endian", n,
                     with_normals ? "property float nx\nproperty float ny\nproperty float nz\n"
                                  : "") > 0;
    if (ok && id)
        ok = fprintf(f, "property int %s\n", id_name) > 0;
    ok = ok && fputs("end_header\n", f) >= 0;
    int nv = with_normals ? 6 : 3;
    for (size_t i = 0; i < n && ok; i++) {
        const double *o = v + 6 * i;
        if (format == GS_POINTPLY_ASCII) {
            for (int k = 0; k < nv && ok; k++)
                ok = fprintf(f, k + 1 < nv || id ? "%.9g " : "%.9g\n", (double)(float)o[k]) > 0;
            if (ok && id)
                ok = fprintf(f, "%ld\n", (long)id[i]) > 0;
        } else {
            unsigned char b[28];
            for (int k = 0; k < nv; k++) {
                float x = (float)o[k];
                uint32_t u;
                memcpy(&u, &x, sizeof u);
                for (int j = 0; j < 4; j++)
                    b[4 * k + j] = (unsigned char)(u >> (8 * j));
            }
            int nw = nv;
            if (id) {
                uint32_t u = (uint32_t)id[i];
                for (int j = 0; j < 4; j++)
                    b[4 * nv + j] = (unsigned char)(u >> (8 * j));
                nw++;
            }
            ok = fwrite(b, 4, (size_t)nw, f) == (size_t)nw;
        }
    }
    if (!ok) {
        gs_atomic_abort(&af);
        GS_RAISE(GS_ERR_IO, "%s: write failed (disk full?)", path);
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
}
