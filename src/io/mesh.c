/* Triangle mesh I/O and topology helpers; see include/geosynth/mesh.h. */
#include "geosynth/digest.h"
#include "geosynth/mesh.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/file.h"
#include "geosynth/glb.h"

void gs_mesh_destroy(gs_mesh *m)
{
    if (!m)
        return;
    gs_free(m->pos);
    gs_free(m->normals);
    gs_free(m->tris);
    gs_free(m->scalar);
    gs_free(m->label);
    memset(m, 0, sizeof *m);
}

gs_err gs_mesh_alloc(gs_mesh *m, size_t nverts, size_t ntris, int with_normals)
{
    memset(m, 0, sizeof *m);
    GS_CHECK(nverts <= GS_MESH_MAX_ELEMS && ntris <= GS_MESH_MAX_ELEMS, GS_ERR_ARG,
             "mesh of %zu vertices and %zu triangles exceeds the %zu supported", nverts, ntris,
             GS_MESH_MAX_ELEMS);
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&m->pos, nverts * 3, sizeof(float), "mesh vertices"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&m->tris, ntris * 3, sizeof(uint32_t), "mesh triangles"),
           fail);
    if (with_normals)
        GS_TRY(err,
               gs_alloc_array((void **)&m->normals, nverts * 3, sizeof(float), "mesh normals"),
               fail);
    m->nverts = nverts;
    m->ntris = ntris;
    return GS_OK;
fail:
    gs_mesh_destroy(m);
    return err;
}

gs_err gs_mesh_validate(const gs_mesh *m, const char *what)
{
    const char *w = what ? what : "mesh";
    GS_CHECK(m->nverts <= GS_MESH_MAX_ELEMS && m->ntris <= GS_MESH_MAX_ELEMS, GS_ERR_FORMAT,
             "%s: %zu vertices and %zu triangles: at most %zu of each are supported", w,
             m->nverts, m->ntris, GS_MESH_MAX_ELEMS);
    GS_CHECK((m->pos || !m->nverts) && (m->tris || !m->ntris), GS_ERR_ARG,
             "%s: vertex or triangle array missing", w);
    for (size_t i = 0; i < 3 * m->nverts; i++)
        GS_CHECK(isfinite(m->pos[i]), GS_ERR_FORMAT,
                 "%s: vertex %zu has a non-finite coordinate (%g): expected finite numbers", w,
                 i / 3, (double)m->pos[i]);
    for (size_t i = 0; i < 3 * m->ntris; i++)
        GS_CHECK(m->tris[i] < m->nverts, GS_ERR_FORMAT,
                 "%s: triangle %zu uses vertex %u but the mesh has %zu vertices", w, i / 3,
                 m->tris[i], m->nverts);
    return GS_OK;
}

/* Reading: src/io/meshread.c. */

/* ---------------------------------------------------------------- writing */

static gs_err write_obj(const char *path, const gs_mesh *m, const gs_mesh_meta *meta)
{
    GS_CALL(gs_mesh_validate(m, path));
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    FILE *f = af.f;
    fprintf(f, "# geosynth mesh: %zu vertices, %zu triangles\n", m->nverts, m->ntris);
    if (meta && meta->units)
        fprintf(f, "# up_axis z; units: %s\n", meta->units);
    if (meta && meta->about)
        fprintf(f, "# %s\n", meta->about);
    for (size_t i = 0; i < m->nverts; i++)
        fprintf(f, "v %.9g %.9g %.9g\n", (double)m->pos[3 * i], (double)m->pos[3 * i + 1],
                (double)m->pos[3 * i + 2]);
    if (m->normals)
        for (size_t i = 0; i < m->nverts; i++)
            fprintf(f, "vn %.9g %.9g %.9g\n", (double)m->normals[3 * i],
                    (double)m->normals[3 * i + 1], (double)m->normals[3 * i + 2]);
    for (size_t t = 0; t < m->ntris; t++) {
        unsigned long a = m->tris[3 * t] + 1UL, b = m->tris[3 * t + 1] + 1UL,
                      c = m->tris[3 * t + 2] + 1UL;
        if (m->normals)
            fprintf(f, "f %lu//%lu %lu//%lu %lu//%lu\n", a, a, b, b, c, c);
        else
            fprintf(f, "f %lu %lu %lu\n", a, b, c);
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
}

static void le32(uint8_t *p, uint32_t u)
{
    p[0] = (uint8_t)u;
    p[1] = (uint8_t)(u >> 8);
    p[2] = (uint8_t)(u >> 16);
    p[3] = (uint8_t)(u >> 24);
}

static void lef32(uint8_t *p, float v)
{
    uint32_t u;
    memcpy(&u, &v, sizeof u);
    le32(p, u);
}

static int ply_name_ok(const char *s)
{
    if (!s[0])
        return 0;
    for (const char *p = s; *p; p++)
        if (!((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') ||
              *p == '_'))
            return 0;
    return 1;
}

gs_err gs_mesh_write_obj(const char *path, const gs_mesh *m)
{
    return write_obj(path, m, NULL);
}

static gs_err write_ply(const char *path, const gs_mesh *m, const char *prop_name, const uint8_t *rgb,
                        const gs_mesh_meta *meta);

gs_err gs_mesh_write_ply(const char *path, const gs_mesh *m, const char *prop_name)
{
    return write_ply(path, m, prop_name, NULL, NULL);
}

gs_err gs_mesh_write_ply_rgb(const char *path, const gs_mesh *m, const char *prop_name, const uint8_t *rgb)
{
    return write_ply(path, m, prop_name, rgb, NULL);
}

/* A meta text goes into a header line: no line breaks. */
static int one_line(const char *s)
{
    return !s || !strpbrk(s, "\r\n");
}

static gs_err write_ply(const char *path, const gs_mesh *m, const char *prop_name, const uint8_t *rgb,
                        const gs_mesh_meta *meta)
{
    GS_CALL(gs_mesh_validate(m, path));
    int prop = 0; /* 0 none, 1 float scalar, 2 uchar label */
    if (prop_name && m->scalar)
        prop = 1;
    else if (prop_name && m->label)
        prop = 2;
    GS_CHECK(!prop || ply_name_ok(prop_name), GS_ERR_ARG,
             "%s: PLY property name '%s' must be letters, digits and '_'", path, prop_name);
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    FILE *f = af.f;
    fprintf(f, "ply\nformat binary_little_endian 1.0\ncomment geosynth\n");
    if (meta && meta->units)
        fprintf(f, "comment up_axis z; units: %s\n", meta->units);
    if (meta && meta->about)
        fprintf(f, "comment %s\n", meta->about);
    fprintf(f, "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n",
            m->nverts);
    if (m->normals)
        fprintf(f, "property float nx\nproperty float ny\nproperty float nz\n");
    if (prop)
        fprintf(f, "property %s %s\n", prop == 1 ? "float" : "uchar", prop_name);
    if (rgb)
        fprintf(f, "property uchar red\nproperty uchar green\nproperty uchar blue\n");
    fprintf(f, "element face %zu\nproperty list uchar int vertex_indices\nend_header\n",
            m->ntris);
    uint8_t rec[32];
    for (size_t i = 0; i < m->nverts; i++) {
        size_t n = 0;
        for (int c = 0; c < 3; c++, n += 4)
            lef32(rec + n, m->pos[3 * i + c]);
        if (m->normals)
            for (int c = 0; c < 3; c++, n += 4)
                lef32(rec + n, m->normals[3 * i + c]);
        if (prop == 1) {
            lef32(rec + n, m->scalar[i]);
            n += 4;
        } else if (prop == 2) {
            rec[n++] = m->label[i];
        }
        if (rgb)
            for (int c = 0; c < 3; c++)
                rec[n++] = rgb[3 * i + c];
        fwrite(rec, 1, n, f);
    }
    for (size_t t = 0; t < m->ntris; t++) {
        rec[0] = 3;
        for (int c = 0; c < 3; c++)
            le32(rec + 1 + 4 * c, m->tris[3 * t + c]);
        fwrite(rec, 1, 13, f);
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
}

gs_err gs_mesh_write(const char *path, const gs_mesh *m, const char *prop_name)
{
    return gs_mesh_write_meta(path, m, prop_name, NULL, NULL);
}

gs_err gs_mesh_write_meta(const char *path, const gs_mesh *m, const char *prop_name, const uint8_t *rgb,
                          const gs_mesh_meta *meta)
{
    char ext[8];
    gs_path_ext(path, ext, sizeof ext);
    GS_CHECK(!meta || (one_line(meta->units) && one_line(meta->about)), GS_ERR_ARG,
             "%s: mesh description with a line break", path);
    if (!strcmp(ext, "obj"))
        GS_CALL(write_obj(path, m, meta));
    else if (!strcmp(ext, "ply"))
        GS_CALL(write_ply(path, m, prop_name, rgb, meta));
    else if (!strcmp(ext, "glb"))
        GS_CALL(gs_mesh_write_glb(path, m, rgb, meta));
    else
        GS_RAISE(GS_ERR_ARG, "%s: unknown mesh extension '.%s': expected .obj, .ply or .glb", path, ext);
    return GS_OK;
}

gs_err gs_mesh_write_glb(const char *path, const gs_mesh *m, const uint8_t *rgb, const gs_mesh_meta *meta)
{
    GS_CALL(gs_mesh_validate(m, path));
    const gs_glb_part part = {m->tris, m->ntris, "surface", NULL};
    const gs_glb_desc d = {m->pos,  m->nverts, m->normals, rgb, &part, m->ntris ? 1 : 0,
                           meta ? meta->name : NULL, meta ? meta->units : NULL, meta ? meta->about : NULL};
    return gs_glb_write(path, &d);
}

/* ---------------------------------------------------------------- geometry */

void gs_mesh_bbox(const gs_mesh *m, float lo[3], float hi[3])
{
    for (int c = 0; c < 3; c++)
        lo[c] = hi[c] = m->nverts ? m->pos[c] : 0.0f;
    for (size_t i = 1; i < m->nverts; i++)
        for (int c = 0; c < 3; c++) {
            float v = m->pos[3 * i + c];
            lo[c] = v < lo[c] ? v : lo[c];
            hi[c] = v > hi[c] ? v : hi[c];
        }
}

static void tri_cross(const gs_mesh *m, size_t t, double n[3])
{
    const float *a = m->pos + 3 * (size_t)m->tris[3 * t], *b = m->pos + 3 * (size_t)m->tris[3 * t + 1],
                *c = m->pos + 3 * (size_t)m->tris[3 * t + 2];
    double u[3], v[3];
    for (int k = 0; k < 3; k++) {
        u[k] = (double)b[k] - a[k];
        v[k] = (double)c[k] - a[k];
    }
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
}

double gs_mesh_area(const gs_mesh *m)
{
    double s = 0;
    for (size_t t = 0; t < m->ntris; t++) {
        double n[3];
        tri_cross(m, t, n);
        s += 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    }
    return s;
}

double gs_mesh_volume(const gs_mesh *m)
{
    double s = 0;
    for (size_t t = 0; t < m->ntris; t++) {
        const float *a = m->pos + 3 * (size_t)m->tris[3 * t];
        double n[3];
        tri_cross(m, t, n);
        s += (a[0] * n[0] + a[1] * n[1] + a[2] * n[2]) / 6.0;
    }
    return s;
}

/* Vertices whose double sums gs_mesh_compute_normals holds at once (24
 * bytes each): larger meshes are done in ranges of this many vertices, one
 * pass over the triangles per range. */
#define NORMAL_RANGE_VERTS ((size_t)1 << 22)

/* The normals of vertices [v0, v1) into m->normals: each vertex's double sum
 * of its triangles' cross products, in triangle order and corner order (the
 * same additions, so the same bits, whatever the range). acc: 3 * (v1 - v0). */
static void normals_range(gs_mesh *m, size_t v0, size_t v1, double *acc)
{
    memset(acc, 0, 3 * (v1 - v0) * sizeof *acc);
    const int whole = v0 == 0 && v1 == m->nverts;
    for (size_t t = 0; t < m->ntris; t++) {
        const uint32_t *c3 = m->tris + 3 * t;
        if (!whole && !((c3[0] >= v0 && c3[0] < v1) || (c3[1] >= v0 && c3[1] < v1) ||
                        (c3[2] >= v0 && c3[2] < v1)))
            continue;
        double n[3]; /* |cross| = 2 * area: area weighting for free */
        tri_cross(m, t, n);
        for (int c = 0; c < 3; c++)
            if (c3[c] >= v0 && c3[c] < v1)
                for (int k = 0; k < 3; k++)
                    acc[3 * (size_t)(c3[c] - v0) + k] += n[k];
    }
    for (size_t i = v0; i < v1; i++) {
        const double *a = acc + 3 * (i - v0);
        double l = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        for (int k = 0; k < 3; k++)
            m->normals[3 * i + k] = l > 0 ? (float)(a[k] / l) : 0.0f;
    }
}

/* Memory: the float normals plus the double sums of at most
 * NORMAL_RANGE_VERTS vertices (96 MiB), not of every vertex (24 bytes a
 * vertex: ~560 MB for a 512^3 contour); time: one pass over the triangles
 * per range. */
gs_err gs_mesh_compute_normals(gs_mesh *m)
{
    return gs_mesh_compute_normals_ranged(m, NORMAL_RANGE_VERTS);
}

gs_err gs_mesh_compute_normals_ranged(gs_mesh *m, size_t range)
{
    GS_CHECK(range >= 1, GS_ERR_ARG, "normals: a range of %zu vertices, expected at least 1", range);
    if (m->nverts < range)
        range = m->nverts;
    double *acc = NULL;
    GS_CALL(gs_alloc_array((void **)&acc, range * 3, sizeof(double), "normal accumulator"));
    if (!m->normals) {
        gs_err err = gs_alloc_array((void **)&m->normals, m->nverts * 3, sizeof(float),
                                    "mesh normals");
        if (err) {
            gs_free(acc);
            GS_CALL(err);
        }
    }
    for (size_t v0 = 0; v0 < m->nverts; v0 += range)
        normals_range(m, v0, m->nverts - v0 < range ? m->nverts : v0 + range, acc);
    gs_free(acc);
    return GS_OK;
}

/* ---------------------------------------------------------------- topology */

typedef struct half_edge {
    uint64_t key; /* min << 32 | max */
    uint32_t forward; /* 1 when stored as min -> max */
} half_edge;

static int half_edge_cmp(const void *a, const void *b)
{
    const half_edge *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return (x->forward > y->forward) - (x->forward < y->forward);
}

gs_err gs_mesh_topology_check(const gs_mesh *m, gs_mesh_topology *topo)
{
    memset(topo, 0, sizeof *topo);
    half_edge *he = NULL;
    GS_CALL(gs_alloc_array((void **)&he, m->ntris * 3, sizeof *he, "edge list"));
    size_t n = 0;
    for (size_t t = 0; t < m->ntris; t++) {
        const uint32_t *v = m->tris + 3 * t;
        if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) {
            topo->degenerate_tris++;
            continue;
        }
        for (int c = 0; c < 3; c++) {
            uint32_t a = v[c], b = v[(c + 1) % 3];
            uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
            he[n++] = (half_edge){(uint64_t)lo << 32 | hi, a < b};
        }
    }
    qsort(he, n, sizeof *he, half_edge_cmp);
    for (size_t i = 0; i < n;) {
        size_t j = i, fwd = 0;
        while (j < n && he[j].key == he[i].key)
            fwd += he[j++].forward;
        size_t cnt = j - i;
        topo->edges++;
        if (cnt == 1)
            topo->boundary_edges++;
        else if (cnt > 2)
            topo->nonmanifold_edges++;
        else if (fwd != 1)
            topo->misoriented_edges++;
        i = j;
    }
    gs_free(he);
    topo->closed = m->ntris > 0 && !topo->boundary_edges && !topo->nonmanifold_edges &&
                   !topo->misoriented_edges && !topo->degenerate_tris;
    return GS_OK;
}

gs_err gs_mesh_require_closed(const gs_mesh *m, const char *what, const char *purpose)
{
    gs_mesh_topology t;
    GS_CALL(gs_mesh_topology_check(m, &t));
    GS_CHECK(t.closed, GS_ERR_ARG,
             "%s: a %s needs a closed, consistently oriented triangle mesh, but this one has "
             "%zu boundary edges, %zu non-manifold edges, %zu inconsistently oriented edges "
             "and %zu degenerate triangles (of %zu triangles)%s",
             what ? what : "mesh", purpose ? purpose : "signed distance field",
             t.boundary_edges, t.nonmanifold_edges, t.misoriented_edges, t.degenerate_tris,
             m->ntris, t.boundary_edges ? ": fill the holes or ask for an unsigned distance" : "");
    return GS_OK;
}

/* ---------------------------------------------------------------- welding */

typedef struct weld_grid {
    uint32_t *slot; /* representative vertex or UINT32_MAX */
    int64_t *cell;  /* 3 per slot */
    size_t mask;
} weld_grid;

static uint64_t cell_hash(const int64_t c[3])
{
    return gs_hash_mix64((uint64_t)c[0] * 0x9E3779B97F4A7C15ULL ^ gs_hash_mix64((uint64_t)c[1] + 0x632BE59BD9B4E019ULL) ^
                 gs_hash_mix64((uint64_t)c[2] * 0x85EBCA77C2B2AE63ULL + 1));
}

/* Weld cell of p: cubes of side 2*tol (tol > 0), so every vertex within
 * tol of p lies in one of the 2 cells nearest p along each axis (3 when p
 * sits within rounding of a cell's middle): lo[k] .. hi[k]. tol = 0: the
 * exact coordinate bits, one cell. */
static gs_err weld_cell_of(const float *p, float tol, int64_t c[3], int64_t lo[3], int64_t hi[3])
{
    for (int k = 0; k < 3; k++) {
        float v = p[k] + 0.0f; /* -0 == +0 */
        if (tol > 0) {
            double x = (double)v / (2.0 * tol), q = floor(x), f = x - q;
            GS_CHECK(fabs(q) < 4.0e18, GS_ERR_ARG,
                     "weld tolerance %g is too small for coordinate %g", (double)tol, (double)v);
            c[k] = (int64_t)q;
            lo[k] = c[k] - (f < 0.5 + 1e-6);
            hi[k] = c[k] + (f > 0.5 - 1e-6);
        } else {
            uint32_t u;
            memcpy(&u, &v, sizeof u);
            c[k] = lo[k] = hi[k] = u;
        }
    }
    return GS_OK;
}

gs_err gs_mesh_weld(gs_mesh *m, float tol)
{
    GS_CHECK(tol >= 0 && isfinite(tol), GS_ERR_ARG, "weld tolerance %g must be >= 0",
             (double)tol);
    size_t nv = m->nverts;
    if (nv == 0)
        return GS_OK;
    gs_err err = GS_OK;
    weld_grid g = {NULL, NULL, 0};
    uint32_t *rep = NULL, *newidx = NULL, *tris = NULL;
    float *pos = NULL, *scalar = NULL;
    uint8_t *label = NULL;
    size_t cap = 16;
    while (cap < 2 * nv)
        cap *= 2;
    g.mask = cap - 1;
    GS_TRY(err, gs_alloc_array((void **)&g.slot, cap, sizeof(uint32_t), "weld table"), done);
    GS_TRY(err, gs_alloc_array((void **)&g.cell, cap * 3, sizeof(int64_t), "weld table"), done);
    GS_TRY(err, gs_alloc_array((void **)&rep, nv, sizeof(uint32_t), "weld map"), done);
    memset(g.slot, 0xff, cap * sizeof(uint32_t));
    double tol2 = (double)tol * tol;
    for (size_t i = 0; i < nv; i++) {
        const float *p = m->pos + 3 * i;
        int64_t c[3], lo[3], hi[3];
        GS_TRY(err, weld_cell_of(p, tol, c, lo, hi), done);
        /* the lowest kept vertex within tol (kept vertices precede i) */
        uint32_t found = UINT32_MAX;
        int64_t q[3];
        for (q[2] = lo[2]; q[2] <= hi[2]; q[2]++)
            for (q[1] = lo[1]; q[1] <= hi[1]; q[1]++)
                for (q[0] = lo[0]; q[0] <= hi[0]; q[0]++) {
                    for (size_t s = cell_hash(q) & g.mask; g.slot[s] != UINT32_MAX;
                         s = (s + 1) & g.mask) {
                        const int64_t *sc = g.cell + 3 * s;
                        if (sc[0] != q[0] || sc[1] != q[1] || sc[2] != q[2] || g.slot[s] >= found)
                            continue;
                        const float *o = m->pos + 3 * (size_t)g.slot[s];
                        double d2 = 0;
                        for (int k = 0; k < 3; k++)
                            d2 += ((double)o[k] - p[k]) * ((double)o[k] - p[k]);
                        if (d2 <= tol2)
                            found = g.slot[s];
                    }
                }
        if (found == UINT32_MAX) {
            size_t s = cell_hash(c) & g.mask;
            while (g.slot[s] != UINT32_MAX)
                s = (s + 1) & g.mask;
            g.slot[s] = (uint32_t)i;
            memcpy(g.cell + 3 * s, c, sizeof c);
            found = (uint32_t)i;
        }
        rep[i] = found;
    }
    /* remap triangles, drop degenerate ones, keep used representatives */
    GS_TRY(err, gs_alloc_array((void **)&tris, m->ntris * 3, sizeof(uint32_t), "weld triangles"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&newidx, nv, sizeof(uint32_t), "weld map"), done);
    size_t nt = 0;
    for (size_t t = 0; t < m->ntris; t++) {
        uint32_t a = rep[m->tris[3 * t]], b = rep[m->tris[3 * t + 1]], c = rep[m->tris[3 * t + 2]];
        if (a == b || b == c || a == c)
            continue;
        tris[3 * nt] = a;
        tris[3 * nt + 1] = b;
        tris[3 * nt + 2] = c;
        nt++;
    }
    for (size_t i = 0; i < nv; i++)
        newidx[i] = m->ntris == 0 && rep[i] == i; /* point sets keep every representative */
    for (size_t k = 0; k < 3 * nt; k++)
        newidx[tris[k]] = 1;
    size_t nn = 0;
    for (size_t i = 0; i < nv; i++)
        newidx[i] = newidx[i] ? (uint32_t)nn++ : UINT32_MAX;
    GS_TRY(err, gs_alloc_array((void **)&pos, nn * 3, sizeof(float), "weld vertices"), done);
    if (m->scalar)
        GS_TRY(err, gs_alloc_array((void **)&scalar, nn, sizeof(float), "weld scalars"), done);
    if (m->label)
        GS_TRY(err, gs_alloc_array((void **)&label, nn, 1, "weld labels"), done);
    for (size_t i = 0; i < nv; i++) {
        if (newidx[i] == UINT32_MAX)
            continue;
        memcpy(pos + 3 * (size_t)newidx[i], m->pos + 3 * i, 3 * sizeof(float));
        if (scalar)
            scalar[newidx[i]] = m->scalar[i];
        if (label)
            label[newidx[i]] = m->label[i];
    }
    for (size_t k = 0; k < 3 * nt; k++)
        tris[k] = newidx[tris[k]];
    int had_normals = m->normals != NULL;
    gs_free(m->pos);
    gs_free(m->tris);
    gs_free(m->scalar);
    gs_free(m->label);
    GS_FREE(m->normals);
    m->pos = pos;
    m->tris = tris;
    m->scalar = scalar;
    m->label = label;
    m->nverts = nn;
    m->ntris = nt;
    pos = NULL;
    tris = NULL;
    scalar = NULL;
    label = NULL;
    if (had_normals)
        GS_TRY(err, gs_mesh_compute_normals(m), done);
done:
    gs_free(g.slot);
    gs_free(g.cell);
    gs_free(rep);
    gs_free(newidx);
    gs_free(tris);
    gs_free(pos);
    gs_free(scalar);
    gs_free(label);
    return err;
}
