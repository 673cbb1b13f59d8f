/* Field engine geometry: example loaders (mesh, OpenVDB, HDF5, height map)
 * and outputs (contour, the paper's copied source triangles); see
 * include/geosynth/field_examples.h. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/field_examples.h"
#include "geosynth/h5.h"
#include "geosynth/image.h"
#include "geosynth/mem.h"
#include "geosynth/vdb.h"

static gs_err field_from_dense(const gs_vdb_dense *d, const char *what, gs_field **out)
{
    GS_CHECK(d->nx >= 1 && d->ny >= 1 && d->nz >= 1 && d->nx <= 4096 && d->ny <= 4096 &&
                 d->nz <= 4096,
             GS_ERR_ARG, "%s: %zux%zux%zu samples: expected 1..4096 per axis", what, d->nx, d->ny,
             d->nz);
    gs_field *f = NULL;
    GS_CALL(gs_field_create((int64_t)d->nx, (int64_t)d->ny, (int64_t)d->nz, &f));
    memcpy(f->v, d->v, d->nx * d->ny * d->nz * sizeof(float));
    memcpy(f->origin, d->origin, sizeof f->origin);
    f->spacing = d->voxel;
    *out = f;
    return GS_OK;
}

gs_err gs_field_from_mesh(const gs_mesh *m, const char *what, int64_t samples, double margin,
                          int is_signed, double shell, gs_field **out)
{
    GS_CHECK(samples >= 8 && samples <= 4096, GS_ERR_ARG,
             "%s: resolution %lld: expected 8..4096 samples along the longest axis", what,
             (long long)samples);
    GS_CHECK(margin >= 0 && 2 * margin < (double)samples - 5, GS_ERR_ARG,
             "%s: margin %g samples: expected in [0, %g) for %lld samples", what, margin,
             ((double)samples - 5) / 2, (long long)samples);
    float lo[3], hi[3];
    gs_mesh_bbox(m, lo, hi);
    double longest = 0;
    for (int a = 0; a < 3; a++)
        longest = fmax(longest, (double)hi[a] - lo[a]);
    GS_CHECK(longest > 0, GS_ERR_ARG, "%s: the mesh has an empty bounding box", what);
    gs_vdb_distance_opts o = {(int)samples, margin * longest / ((double)samples - 1 - 2 * margin),
                              is_signed};
    gs_vdb_dense d;
    memset(&d, 0, sizeof d);
    GS_CALL(gs_vdb_mesh_to_distance(m, what, &o, &d));
    gs_err err = field_from_dense(&d, what, out);
    gs_vdb_dense_destroy(&d);
    GS_CALL(err);
    if (!is_signed) {
        gs_field *f = *out;
        float s = (float)(shell * f->spacing);
        for (int64_t i = 0; i < f->nx * f->ny * f->nz; i++)
            f->v[i] -= s;
    }
    return GS_OK;
}

gs_err gs_field_from_vdb(const char *path, const char *grid, gs_field **out)
{
    gs_vdb_dense d;
    memset(&d, 0, sizeof d);
    GS_CALL(gs_vdb_read_dense(path, grid && grid[0] ? grid : NULL, &d));
    gs_err err = field_from_dense(&d, path, out);
    gs_vdb_dense_destroy(&d);
    GS_CALL(err);
    return GS_OK;
}

gs_err gs_field_from_h5(const char *path, const char *dataset, gs_field **out)
{
    gs_ckpt_t h = NULL;
    GS_CALL(gs_ckpt_open(MPI_COMM_NULL, path, NULL, &h));
    gs_err err = GS_OK;
    gs_field *f = NULL;
    gs_h5_shape sh;
    GS_TRY(err, gs_ckpt_shape(h, dataset, &sh), done);
    char buf[96];
    gs_h5_shape_format(&sh, buf, sizeof buf);
    GS_TRY_CHECK(err, sh.type == GS_H5_F32 && sh.rank == 3, GS_ERR_FORMAT, done,
                 "%s: dataset %s is %s: expected a float32 field of 3 dimensions {nz, ny, nx}",
                 path, dataset, buf);
    GS_TRY_CHECK(err, sh.dims[0] <= 4096 && sh.dims[1] <= 4096 && sh.dims[2] <= 4096, GS_ERR_ARG,
                 done, "%s: dataset %s is %s: expected at most 4096 samples per axis", path,
                 dataset, buf);
    GS_TRY(err, gs_ckpt_check_stored(h, dataset, &sh), done);
    GS_TRY(err, gs_field_create((int64_t)sh.dims[2], (int64_t)sh.dims[1], (int64_t)sh.dims[0], &f),
           done);
    GS_TRY(err, gs_ckpt_read_whole(h, dataset, &sh, f->v), done);
    for (int64_t i = 0; i < f->nx * f->ny * f->nz; i++)
        GS_TRY_CHECK(err, isfinite(f->v[i]), GS_ERR_FORMAT, done,
                     "%s: dataset %s: sample %lld is not finite", path, dataset, (long long)i);
    /* optional geometry attributes */
    double v;
    if (gs_ckpt_get_f64(h, dataset, "spacing", &v) == GS_OK && v > 0 && isfinite(v))
        f->spacing = v;
    const char *on[3] = {"origin_x", "origin_y", "origin_z"};
    for (int a = 0; a < 3; a++)
        if (gs_ckpt_get_f64(h, dataset, on[a], &v) == GS_OK && isfinite(v))
            f->origin[a] = v;
    gs_error_clear();
    *out = f;
    f = NULL;
done:
    gs_field_destroy(&f);
    gs_ckpt_close(&h);
    return err;
}

gs_err gs_field_from_heightmap(const char *path, int64_t size, int64_t depth, double height,
                               gs_field **out)
{
    GS_CHECK(size >= 8 && size <= 4096 && depth >= 4 && depth <= 4096, GS_ERR_ARG,
             "%s: height map field %lld (longer side) x %lld (depth): expected 8..4096 and 4..4096",
             path, (long long)size, (long long)depth);
    GS_CHECK(height > 0 && height <= (double)depth, GS_ERR_ARG,
             "%s: relief %g samples: expected in (0, depth = %lld]", path, height, (long long)depth);
    gs_image img;
    GS_CALL(gs_image_read(path, &img));
    float *grey = NULL;
    gs_err err = gs_image_to_gray(&img, &grey);
    int W = img.width, H = img.height;
    gs_image_destroy(&img);
    GS_CALL(err);
    int64_t longer = W > H ? W : H;
    int64_t nx = W >= H ? size : (int64_t)llround((double)size * W / H);
    int64_t ny = H >= W ? size : (int64_t)llround((double)size * H / W);
    nx = nx < 1 ? 1 : nx, ny = ny < 1 ? 1 : ny;
    double scale = (double)longer / (double)size; /* image pixels per sample */
    float *h = gs_malloc((size_t)(nx * ny) * sizeof *h);
    gs_field *f = NULL;
    if (!h || (err = gs_field_create(nx, ny, depth, &f)) != GS_OK) {
        gs_free(grey);
        gs_free(h);
        GS_CHECK(h, GS_ERR_MEM, "out of memory for a %lldx%lld height map", (long long)nx,
                 (long long)ny);
        GS_CALL(err);
    }
    /* box filter: sample (x, y) averages the pixels whose centres fall in its footprint */
    double base = ((double)depth - height) / 2;
    for (int64_t y = 0; y < ny; y++)
        for (int64_t x = 0; x < nx; x++) {
            int64_t x0 = (int64_t)floor((double)x * scale), x1 = (int64_t)floor((double)(x + 1) * scale);
            int64_t y0 = (int64_t)floor((double)y * scale), y1 = (int64_t)floor((double)(y + 1) * scale);
            x1 = x1 <= x0 ? x0 + 1 : x1, y1 = y1 <= y0 ? y0 + 1 : y1;
            x1 = x1 > W ? W : x1, y1 = y1 > H ? H : y1;
            double s = 0;
            int64_t c = 0;
            for (int64_t py = y0; py < y1; py++)
                for (int64_t px = x0; px < x1; px++, c++)
                    s += grey[py * W + px];
            /* image row 0 is the top: largest y */
            h[x + nx * (ny - 1 - y)] = (float)(base + height * (c ? s / (double)c : 0));
        }
    gs_free(grey);
    const int R = (int)GS_EXAMPLE_BAND;
    for (int64_t z = 0; z < depth; z++)
        for (int64_t y = 0; y < ny; y++)
            for (int64_t x = 0; x < nx; x++) {
                double hz = h[x + nx * y], zz = (double)z;
                double d = fabs(zz - hz);
                for (int dy = -R; dy <= R; dy++)
                    for (int dx = -R; dx <= R; dx++) {
                        int64_t xx = x + dx, yy = y + dy;
                        if ((dx == 0 && dy == 0) || xx < 0 || yy < 0 || xx >= nx || yy >= ny)
                            continue;
                        double e2 = (double)(dx * dx + dy * dy);
                        if (e2 >= d * d)
                            continue;
                        double dz = zz - h[xx + nx * yy];
                        double e = sqrt(e2 + dz * dz);
                        if (e < d)
                            d = e;
                    }
                if (d > GS_EXAMPLE_BAND)
                    d = GS_EXAMPLE_BAND;
                f->v[x + nx * (y + ny * z)] = (float)(zz < hz ? -d : d);
            }
    gs_free(h);
    *out = f;
    return GS_OK;
}

gs_err gs_field_contour(const gs_field *f, double iso, double adaptivity, gs_mesh *out)
{
    gs_vdb_dense d;
    memset(&d, 0, sizeof d);
    d.nx = (size_t)f->nx, d.ny = (size_t)f->ny, d.nz = (size_t)f->nz;
    memcpy(d.origin, f->origin, sizeof d.origin);
    d.voxel = f->spacing;
    d.v = f->v; /* borrowed: not destroyed below */
    float mx = 0;
    for (int64_t i = 0; i < f->nx * f->ny * f->nz; i++)
        mx = f->v[i] > mx ? f->v[i] : mx;
    d.background = mx;
    GS_CALL(gs_vdb_dense_to_mesh(&d, iso, adaptivity, out));
    return GS_OK;
}

/* ------------------------------------------------------ copied geometry */

static int cmp_i64(const void *x, const void *y)
{
    int64_t a = *(const int64_t *)x, b = *(const int64_t *)y;
    return a < b ? -1 : a > b;
}

/* Marks (flag[v] = 1) the vertices of edges used by exactly one triangle:
 * after welding, those are the open seams between copies that do not meet.
 * Returns their number. */
static gs_err mark_seams(const gs_mesh *m, uint8_t *flag, int64_t *count)
{
    size_t E = 3 * m->ntris;
    int64_t *key = NULL, n = 0;
    GS_CALL(gs_alloc_array((void **)&key, E + 1, sizeof *key, "seam edges"));
    int64_t V = (int64_t)m->nverts;
    for (size_t t = 0; t < m->ntris; t++)
        for (int c = 0; c < 3; c++) {
            int64_t a = m->tris[3 * t + c], b = m->tris[3 * t + (c + 1) % 3];
            key[3 * t + c] = a < b ? a * V + b : b * V + a;
        }
    qsort(key, E, sizeof *key, cmp_i64);
    for (size_t i = 0; i < E;) {
        size_t j = i;
        while (j < E && key[j] == key[i])
            j++;
        if (j - i == 1) {
            int64_t v[2] = {key[i] / V, key[i] % V};
            for (int q = 0; q < 2; q++)
                if (!flag[v[q]])
                    flag[v[q]] = 1, n++;
        }
        i = j;
    }
    gs_free(key);
    *count = n;
    return GS_OK;
}

gs_err gs_field_copy_geometry(const gs_mesh *src_mesh, const int64_t sn[3], const int32_t *prov,
                              const int64_t tn[3], float weld_tol, int relax, gs_mesh *out,
                              int64_t *seam_vertices)
{
    int64_t ns = sn[0] * sn[1] * sn[2], nt = tn[0] * tn[1] * tn[2];
    size_t T = src_mesh->ntris;
    gs_err err = GS_OK;
    int64_t *start = NULL, *tri_of = NULL, *cell = NULL, *fill = NULL, *cnt = NULL;
    double *acc = NULL;
    uint8_t *seam = NULL;
    gs_mesh m;
    memset(&m, 0, sizeof m);
    /* bucket source triangles by the source sample nearest their centroid */
    GS_TRY(err, gs_alloc_array((void **)&start, (size_t)ns + 1, sizeof *start, "triangle buckets"), done);
    GS_TRY(err, gs_alloc_array((void **)&fill, (size_t)ns + 1, sizeof *fill, "triangle buckets"), done);
    GS_TRY(err, gs_alloc_array((void **)&tri_of, T + 1, sizeof *tri_of, "triangle buckets"), done);
    GS_TRY(err, gs_alloc_array((void **)&cell, T + 1, sizeof *cell, "triangle cells"), done);
    for (size_t t = 0; t < T; t++) {
        int64_t c[3];
        for (int a = 0; a < 3; a++) {
            double s = 0;
            for (int k = 0; k < 3; k++)
                s += src_mesh->pos[3 * src_mesh->tris[3 * t + k] + a];
            c[a] = (int64_t)llround(s / 3);
        }
        cell[t] = -1;
        if (c[0] < 0 || c[1] < 0 || c[2] < 0 || c[0] >= sn[0] || c[1] >= sn[1] || c[2] >= sn[2])
            continue;
        cell[t] = c[0] + sn[0] * (c[1] + sn[1] * c[2]);
        start[cell[t] + 1]++;
    }
    for (int64_t i = 0; i < ns; i++)
        start[i + 1] += start[i];
    for (size_t t = 0; t < T; t++)
        if (cell[t] >= 0)
            tri_of[start[cell[t]] + fill[cell[t]]++] = (int64_t)t;
    size_t ntri = 0;
    for (int64_t t = 0; t < nt; t++)
        if (prov[t] >= 0 && prov[t] < ns)
            ntri += (size_t)(start[prov[t] + 1] - start[prov[t]]);
    GS_TRY_CHECK(err, ntri * 3 < GS_MESH_MAX_ELEMS, GS_ERR_ARG, done,
                 "copied geometry would have %zu triangles: more than a mesh may hold", ntri);
    GS_TRY(err, gs_mesh_alloc(&m, ntri * 3, ntri, 0), done);
    size_t k = 0;
    for (int64_t t = 0; t < nt; t++) {
        if (prov[t] < 0 || prov[t] >= ns)
            continue;
        int64_t s = prov[t];
        double off[3] = {(double)(t % tn[0] - s % sn[0]),
                         (double)(t / tn[0] % tn[1] - s / sn[0] % sn[1]),
                         (double)(t / (tn[0] * tn[1]) - s / (sn[0] * sn[1]))};
        for (int64_t b = start[s]; b < start[s + 1]; b++, k++) {
            const uint32_t *tr = src_mesh->tris + 3 * tri_of[b];
            for (int c = 0; c < 3; c++) {
                for (int a = 0; a < 3; a++)
                    m.pos[3 * (3 * k + c) + a] = (float)(src_mesh->pos[3 * tr[c] + a] + off[a]);
                m.tris[3 * k + c] = (uint32_t)(3 * k + c);
            }
        }
    }
    /* copies of neighbouring samples from the same copied block share exact
     * vertices; across seams vertices within weld_tol are joined */
    GS_TRY(err, gs_mesh_weld(&m, weld_tol), done);
    GS_TRY(err, gs_alloc_array((void **)&seam, m.nverts + 1, 1, "seam flags"), done);
    int64_t seams = 0;
    GS_TRY(err, mark_seams(&m, seam, &seams), done);
    GS_TRY(err, gs_alloc_array((void **)&cnt, m.nverts + 1, sizeof *cnt, "relaxation"), done);
    GS_TRY(err, gs_alloc_array((void **)&acc, 3 * m.nverts + 3, sizeof *acc, "relaxation"), done);
    /* Laplacian relaxation (weight 0.5) of the seam vertices */
    for (int it = 0; it < relax; it++) {
        memset(acc, 0, (3 * m.nverts + 3) * sizeof *acc);
        memset(cnt, 0, (m.nverts + 1) * sizeof *cnt);
        for (size_t t = 0; t < m.ntris; t++)
            for (int c = 0; c < 3; c++) {
                uint32_t a = m.tris[3 * t + c], b = m.tris[3 * t + (c + 1) % 3];
                if (!seam[a] && !seam[b])
                    continue;
                for (int q = 0; q < 3; q++) {
                    acc[3 * a + q] += m.pos[3 * b + q];
                    acc[3 * b + q] += m.pos[3 * a + q];
                }
                cnt[a]++, cnt[b]++;
            }
        for (size_t v = 0; v < m.nverts; v++)
            if (seam[v] && cnt[v] > 0)
                for (int q = 0; q < 3; q++)
                    m.pos[3 * v + q] =
                        (float)(0.5 * m.pos[3 * v + q] + 0.5 * acc[3 * v + q] / (double)cnt[v]);
    }
    if (seam_vertices)
        *seam_vertices = seams;
    *out = m;
    memset(&m, 0, sizeof m);
done:
    gs_mesh_destroy(&m);
    gs_free(start);
    gs_free(fill);
    gs_free(tri_of);
    gs_free(cell);
    gs_free(cnt);
    gs_free(acc);
    gs_free(seam);
    return err;
}
