/* Voxel-cube surface with merged faces (greedy meshing per slice) and its
 * PLY / OBJ writers. See include/geosynth/model_io.h. */
#include <stdio.h>
#include <string.h>

#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/model_io.h"
#include "geosynth/preview.h"

static gs_err push_quad(gs_model_quads *out, size_t *cap, const gs_model_quad *q)
{
    if (out->n == *cap) {
        size_t nc = *cap ? 2 * *cap : 1024;
        void *p = gs_realloc(out->q, nc * sizeof *out->q);
        GS_CHECK(p != NULL, GS_ERR_MEM, "mesh: cannot grow the quad list to %zu quads", nc);
        out->q = p;
        *cap = nc;
    }
    out->q[out->n++] = *q;
    return GS_OK;
}

static uint16_t cell(const gs_model_lattice *l, const int c[3])
{
    if (c[0] < 0 || c[1] < 0 || c[2] < 0 || c[0] >= l->nx || c[1] >= l->ny || c[2] >= l->nz)
        return 0;
    return l->labels[gs_model_lattice_index(l, c[0], c[1], c[2])];
}

gs_err gs_model_mesh_quads(const gs_model_lattice *lat, double voxel, gs_model_quads *out)
{
    const int n[3] = {lat->nx, lat->ny, lat->nz};
    size_t maxslice = 0;
    for (int a = 0; a < 3; a++) {
        size_t s = (size_t)n[(a + 1) % 3] * (size_t)n[(a + 2) % 3];
        if (s > maxslice)
            maxslice = s;
    }
    uint16_t *mask = NULL;
    gs_model_quads res = {NULL, 0, 0};
    size_t cap = 0;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&mask, maxslice, sizeof *mask, "mesh slice mask"), done);
    for (int a = 0; a < 3; a++) {
        const int u = (a + 1) % 3, v = (a + 2) % 3; /* u x v = +a */
        const int nu = n[u], nv = n[v];
        for (int side = 0; side < 2; side++) { /* 0: +a faces, 1: -a faces */
            for (int k = 0; k < n[a]; k++) {
                /* mask of faces of layer k on this side */
                for (int j = 0; j < nv; j++)
                    for (int i = 0; i < nu; i++) {
                        int c[3], d[3];
                        c[a] = k;
                        c[u] = i;
                        c[v] = j;
                        memcpy(d, c, sizeof d);
                        d[a] += side ? -1 : 1;
                        uint16_t l = cell(lat, c), m = cell(lat, d);
                        mask[(size_t)j * (size_t)nu + (size_t)i] = (l != 0 && l != m) ? l : 0;
                        res.unit_faces += (l != 0 && l != m);
                    }
                /* greedy rectangles: grow along u, then along v */
                for (int j = 0; j < nv; j++)
                    for (int i = 0; i < nu;) {
                        uint16_t l = mask[(size_t)j * (size_t)nu + (size_t)i];
                        if (!l) {
                            i++;
                            continue;
                        }
                        int w = 1;
                        while (i + w < nu && mask[(size_t)j * (size_t)nu + (size_t)(i + w)] == l)
                            w++;
                        int h = 1;
                        for (; j + h < nv; h++) {
                            int row_ok = 1;
                            for (int t = 0; t < w && row_ok; t++)
                                row_ok = mask[(size_t)(j + h) * (size_t)nu + (size_t)(i + t)] == l;
                            if (!row_ok)
                                break;
                        }
                        for (int hh = 0; hh < h; hh++)
                            memset(&mask[(size_t)(j + hh) * (size_t)nu + (size_t)i], 0,
                                   (size_t)w * sizeof *mask);
                        gs_model_quad q;
                        q.label = l;
                        q.dir = (uint8_t)(2 * a + side);
                        const float plane = (float)((k + (side ? 0 : 1)) * voxel);
                        const float u0 = (float)(i * voxel), u1 = (float)((i + w) * voxel);
                        const float v0 = (float)(j * voxel), v1 = (float)((j + h) * voxel);
                        const float uv[4][2] = {{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}};
                        for (int corner = 0; corner < 4; corner++) {
                            /* +a: counter-clockwise in (u, v); -a: reversed */
                            int cc = side ? 3 - corner : corner;
                            q.p[corner][a] = plane;
                            q.p[corner][u] = uv[cc][0];
                            q.p[corner][v] = uv[cc][1];
                        }
                        GS_TRY(err, push_quad(&res, &cap, &q), done);
                        i += w;
                    }
            }
        }
    }
    *out = res;
    res.q = NULL;
done:
    gs_free(mask);
    gs_free(res.q);
    return err;
}

void gs_model_quads_free(gs_model_quads *q)
{
    if (!q)
        return;
    GS_FREE(q->q);
    q->n = q->unit_faces = 0;
}

static int put_bytes(FILE *f, const void *p, size_t n) { return fwrite(p, 1, n, f) == n; }

static gs_err write_ply(const char *path, const gs_model_quads *q, const gs_model_palette *pal)
{
    GS_CHECK(q->n <= ((size_t)1 << 29), GS_ERR_ARG, "%s: %zu quads: too many for a PLY mesh",
             path, q->n);
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    int ok = fprintf(af.f,
                     "ply\nformat binary_little_endian 1.0\ncomment geosynth model: coloured "
                     "voxel cubes, merged faces\nelement vertex %zu\nproperty float x\n"
                     "property float y\nproperty float z\nproperty uchar red\n"
                     "property uchar green\nproperty uchar blue\nelement face %zu\n"
                     "property list uchar int vertex_indices\nproperty ushort label\n"
                     "end_header\n",
                     4 * q->n, q->n) > 0;
    /* little-endian host assumed by the PLY writer of src/io too (x86/ARM) */
    for (size_t i = 0; ok && i < q->n; i++) {
        uint8_t rgb[3];
        gs_model_label_rgb(pal, q->q[i].label, rgb);
        for (int c = 0; ok && c < 4; c++)
            ok = put_bytes(af.f, q->q[i].p[c], 12) && put_bytes(af.f, rgb, 3);
    }
    for (size_t i = 0; ok && i < q->n; i++) {
        uint8_t four = 4;
        int32_t idx[4];
        for (int c = 0; c < 4; c++)
            idx[c] = (int32_t)(4 * i + (size_t)c);
        ok = put_bytes(af.f, &four, 1) && put_bytes(af.f, idx, sizeof idx) &&
             put_bytes(af.f, &q->q[i].label, 2);
    }
    if (!ok) {
        gs_atomic_abort(&af);
        GS_RAISE(GS_ERR_IO, "%s: write failed", path);
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
}

static gs_err write_obj(const char *path, const gs_model_quads *q, const gs_model_palette *pal)
{
    /* MTL next to the OBJ: same name with .mtl */
    size_t len = strlen(path);
    char *mtl = gs_malloc(len + 5);
    GS_CHECK(mtl != NULL, GS_ERR_MEM, "%s: out of memory", path);
    memcpy(mtl, path, len + 1);
    if (len >= 4 && mtl[len - 4] == '.')
        mtl[len - 4] = '\0';
    strcat(mtl, ".mtl");
    const char *mtl_base = strrchr(mtl, '/') ? strrchr(mtl, '/') + 1 : mtl;
    uint8_t *seen = gs_calloc(65536, 1);
    gs_atomic_file af = {0}, am = {0};
    gs_err err = GS_OK;
    GS_TRY_CHECK(err, seen != NULL, GS_ERR_MEM, done, "%s: out of memory", path);
    GS_TRY(err, gs_atomic_begin(mtl, &am), done);
    int ok = fprintf(am.f, "# geosynth model: one material per label\n") > 0;
    for (size_t i = 0; i < q->n; i++) {
        uint16_t l = q->q[i].label;
        if (seen[l])
            continue;
        seen[l] = 1;
        uint8_t rgb[3];
        gs_model_label_rgb(pal, l, rgb);
        ok = ok && fprintf(am.f, "newmtl label_%u\nKd %.4f %.4f %.4f\n", (unsigned)l, rgb[0] / 255.0,
                           rgb[1] / 255.0, rgb[2] / 255.0) > 0;
    }
    if (!ok) {
        gs_atomic_abort(&am);
        GS_TRY_CHECK(err, 0, GS_ERR_IO, done, "%s: write failed", mtl);
    }
    GS_TRY(err, gs_atomic_commit(&am), done);
    GS_TRY(err, gs_atomic_begin(path, &af), done);
    ok = fprintf(af.f, "# geosynth model: coloured voxel cubes, merged faces (%zu quads)\nmtllib %s\n",
                 q->n, mtl_base) > 0;
    for (size_t i = 0; ok && i < q->n; i++)
        for (int c = 0; ok && c < 4; c++)
            ok = fprintf(af.f, "v %.9g %.9g %.9g\n", q->q[i].p[c][0], q->q[i].p[c][1],
                         q->q[i].p[c][2]) > 0;
    /* faces grouped by label, in label order */
    memset(seen, 0, 65536);
    for (size_t i = 0; i < q->n; i++)
        seen[q->q[i].label] = 1;
    for (int l = 1; ok && l < 65536; l++) {
        if (!seen[l])
            continue;
        ok = fprintf(af.f, "usemtl label_%d\n", l) > 0;
        for (size_t i = 0; ok && i < q->n; i++)
            if (q->q[i].label == l)
                ok = fprintf(af.f, "f %zu %zu %zu %zu\n", 4 * i + 1, 4 * i + 2, 4 * i + 3,
                             4 * i + 4) > 0;
    }
    if (!ok) {
        gs_atomic_abort(&af);
        GS_TRY_CHECK(err, 0, GS_ERR_IO, done, "%s: write failed", path);
    }
    GS_TRY(err, gs_atomic_commit(&af), done);
done:
    gs_free(seen);
    gs_free(mtl);
    return err;
}

gs_err gs_model_write_mesh(const char *path, const gs_model_quads *q, const gs_model_palette *pal)
{
    char ext[16];
    gs_path_ext(path, ext, sizeof ext);
    if (!strcmp(ext, "ply"))
        return write_ply(path, q, pal);
    if (!strcmp(ext, "obj"))
        return write_obj(path, q, pal);
    GS_RAISE(GS_ERR_ARG, "%s: mesh output must end in .ply or .obj", path);
}

/* ---- preview picture ------------------------------------------------------ */

/* The coloured cubes of lat as a triangle mesh with one RGB per vertex (four
 * vertices per quad, so faces are shaded flat). */
static gs_err lattice_mesh(const gs_model_lattice *lat, const gs_model_palette *pal, gs_mesh *m,
                           uint8_t **rgb)
{
    gs_model_quads q;
    GS_CALL(gs_model_mesh_quads(lat, 1.0, &q));
    gs_err err = gs_mesh_alloc(m, 4 * q.n, 2 * q.n, 0);
    if (err == GS_OK)
        err = gs_alloc_array((void **)rgb, q.n ? 4 * q.n : 1, 3, "preview colours");
    if (err) {
        gs_mesh_destroy(m);
        gs_model_quads_free(&q);
        return err;
    }
    for (size_t i = 0; i < q.n; i++) {
        uint8_t c[3];
        gs_model_label_rgb(pal, q.q[i].label, c);
        for (int k = 0; k < 4; k++) {
            memcpy(m->pos + 3 * (4 * i + (size_t)k), q.q[i].p[k], 3 * sizeof(float));
            memcpy(*rgb + 3 * (4 * i + (size_t)k), c, 3);
        }
        static const int tri[6] = {0, 1, 2, 0, 2, 3};
        for (int k = 0; k < 6; k++)
            m->tris[6 * i + (size_t)k] = (uint32_t)(4 * i + (size_t)tri[k]);
    }
    gs_model_quads_free(&q);
    return GS_OK;
}

gs_err gs_model_write_preview(const char *path, const gs_model_lattice *example,
                              const gs_model_lattice *output, const gs_model_palette *pal,
                              int side)
{
    gs_mesh m[2];
    uint8_t *rgb[2] = {NULL, NULL};
    memset(m, 0, sizeof m);
    gs_err err = lattice_mesh(example, pal, &m[0], &rgb[0]);
    if (err == GS_OK)
        err = lattice_mesh(output, pal, &m[1], &rgb[1]);
    if (err == GS_OK) {
        gs_preview_panel panels[2] = {{&m[0], rgb[0]}, {&m[1], rgb[1]}};
        err = gs_preview_write(path, panels, 2, side);
    }
    for (int i = 0; i < 2; i++) {
        gs_mesh_destroy(&m[i]);
        gs_free(rgb[i]);
    }
    return err;
}
