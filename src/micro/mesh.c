/* micro meshes: allocation, built-in shapes (sphere, disk, bar), statistics,
 * normals. See include/geosynth/micro.h. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "micro/micro_impl.h"

/* ------------------------------------------------------------- map -- */

static uint64_t mix64(uint64_t x)
{
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

gs_err micro_map_init(micro_map *m, uint64_t expected)
{
    uint64_t cap = 16;
    while (cap < 2 * expected + 16)
        cap <<= 1;
    uint64_t *keys = NULL;
    uint32_t *vals = NULL;
    GS_CALL(gs_alloc_array((void **)&keys, cap, sizeof *keys, "micro hash keys"));
    gs_err err = gs_alloc_array((void **)&vals, cap, sizeof *vals, "micro hash values");
    if (err != GS_OK) {
        gs_free(keys);
        GS_CALL(err);
    }
    memset(keys, 0xff, cap * sizeof *keys);
    m->keys = keys;
    m->vals = vals;
    m->mask = cap - 1;
    m->size = 0;
    return GS_OK;
}

void micro_map_free(micro_map *m)
{
    GS_FREE(m->keys);
    GS_FREE(m->vals);
    m->size = 0;
}

uint32_t *micro_map_slot(micro_map *m, uint64_t key, int *found)
{
    uint64_t i = mix64(key) & m->mask;
    for (;;) {
        if (m->keys[i] == key) {
            *found = 1;
            return &m->vals[i];
        }
        if (m->keys[i] == UINT64_MAX) {
            m->keys[i] = key;
            m->vals[i] = UINT32_MAX;
            m->size++;
            *found = 0;
            return &m->vals[i];
        }
        i = (i + 1) & m->mask;
    }
}

uint32_t micro_map_get(const micro_map *m, uint64_t key)
{
    uint64_t i = mix64(key) & m->mask;
    for (;;) {
        if (m->keys[i] == key)
            return m->vals[i];
        if (m->keys[i] == UINT64_MAX)
            return UINT32_MAX;
        i = (i + 1) & m->mask;
    }
}

/* ------------------------------------------------------------ mesh -- */

gs_err gs_micro_mesh_alloc(gs_micro_mesh *m, uint32_t nverts, uint32_t ntris)
{
    float *pos = NULL;
    uint32_t *tris = NULL;
    GS_CALL(gs_alloc_array((void **)&pos, (size_t)nverts * 3, sizeof *pos, "mesh positions"));
    gs_err err = gs_alloc_array((void **)&tris, (size_t)ntris * 3, sizeof *tris, "mesh triangles");
    if (err != GS_OK) {
        gs_free(pos);
        GS_CALL(err);
    }
    m->nverts = nverts;
    m->ntris = ntris;
    m->pos = pos;
    m->tris = tris;
    m->normals = NULL;
    return GS_OK;
}

gs_err gs_micro_mesh_from_mesh(const gs_mesh *in, gs_micro_mesh *out)
{
    GS_CHECK(in->nverts < UINT32_MAX && in->ntris < UINT32_MAX, GS_ERR_ARG,
             "mesh of %zu vertices and %zu triangles: the micro engine supports < 2^32 of each",
             in->nverts, in->ntris);
    gs_micro_mesh m;
    GS_CALL(gs_micro_mesh_alloc(&m, (uint32_t)in->nverts, (uint32_t)in->ntris));
    memcpy(m.pos, in->pos, in->nverts * 3 * sizeof *m.pos);
    memcpy(m.tris, in->tris, in->ntris * 3 * sizeof *m.tris);
    if (in->normals) {
        gs_err err = gs_alloc_array((void **)&m.normals, in->nverts * 3, sizeof *m.normals,
                                    "vertex normals");
        if (err != GS_OK) {
            gs_micro_mesh_free(&m);
            GS_CALL(err);
        }
        memcpy(m.normals, in->normals, in->nverts * 3 * sizeof *m.normals);
    }
    *out = m;
    return GS_OK;
}

gs_err gs_micro_mesh_to_mesh(const gs_micro_mesh *in, gs_mesh *out)
{
    GS_CALL(gs_mesh_alloc(out, in->nverts, in->ntris, in->normals != NULL));
    memcpy(out->pos, in->pos, (size_t)in->nverts * 3 * sizeof *out->pos);
    memcpy(out->tris, in->tris, (size_t)in->ntris * 3 * sizeof *out->tris);
    if (in->normals)
        memcpy(out->normals, in->normals, (size_t)in->nverts * 3 * sizeof *out->normals);
    return GS_OK;
}

void gs_micro_mesh_free(gs_micro_mesh *m)
{
    if (!m)
        return;
    GS_FREE(m->pos);
    GS_FREE(m->tris);
    GS_FREE(m->normals);
    m->nverts = m->ntris = 0;
}

static void tri_normal(const float *a, const float *b, const float *c, double n[3])
{
    double u[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
    double v[3] = {(double)c[0] - a[0], (double)c[1] - a[1], (double)c[2] - a[2]};
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
}

/* Flips triangle t if its normal points against the outward direction dir. */
static void orient(gs_micro_mesh *m, uint32_t t, const double dir[3])
{
    uint32_t *tv = m->tris + 3 * (size_t)t;
    double n[3];
    tri_normal(m->pos + 3 * (size_t)tv[0], m->pos + 3 * (size_t)tv[1], m->pos + 3 * (size_t)tv[2], n);
    if (n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2] < 0) {
        uint32_t s = tv[1];
        tv[1] = tv[2];
        tv[2] = s;
    }
}

/* Vertex welding for lattice generators: key -> index, positions appended. */
typedef struct lattice {
    micro_map map;
    gs_micro_mesh *m;
} lattice;

static uint32_t lattice_vertex(lattice *l, uint64_t key, double x, double y, double z)
{
    int found;
    uint32_t *slot = micro_map_slot(&l->map, key, &found);
    if (!found) {
        uint32_t i = l->m->nverts++;
        l->m->pos[3 * (size_t)i] = (float)x;
        l->m->pos[3 * (size_t)i + 1] = (float)y;
        l->m->pos[3 * (size_t)i + 2] = (float)z;
        *slot = i;
    }
    return *slot;
}

static uint64_t lkey(int64_t i, int64_t j, int64_t k)
{
    const int64_t off = 1 << 20;
    return ((uint64_t)(i + off) << 42) | ((uint64_t)(j + off) << 21) | (uint64_t)(k + off);
}

gs_err gs_micro_mesh_sphere_segments(gs_micro_mesh *m, double radius, uint32_t s)
{
    GS_CHECK(radius > 0 && isfinite(radius), GS_ERR_ARG, "sphere radius %g: expected > 0", radius);
    GS_CHECK(s >= 1 && s <= 16000, GS_ERR_ARG,
             "sphere segments %u: expected [1, 16000] (8 s^2 triangles)", s);
    uint64_t nt = 8ull * s * s, nv = 4ull * s * s + 2;
    gs_micro_mesh out;
    GS_CALL(gs_micro_mesh_alloc(&out, (uint32_t)nv, (uint32_t)nt));
    out.nverts = 0;
    lattice l = {.m = &out};
    gs_err err = micro_map_init(&l.map, nv);
    if (err != GS_OK) {
        gs_micro_mesh_free(&out);
        GS_CALL(err);
    }
    uint32_t t = 0;
    for (int f = 0; f < 8; f++) {
        int sx = f & 1 ? -1 : 1, sy = f & 2 ? -1 : 1, sz = f & 4 ? -1 : 1;
        /* Lattice point (a, b, c), a + b + c = s, on the face of signs f. */
#define OCTV(a, b)                                                                      \
    lattice_vertex(&l, lkey(sx * (int64_t)(a), sy * (int64_t)(b), sz * ((int64_t)s - (a) - (b))), \
                   0, 0, 0)
        for (uint32_t a = 0; a < s; a++)
            for (uint32_t b = 0; a + b < s; b++) {
                uint32_t v0 = OCTV(a, b), v1 = OCTV(a + 1, b), v2 = OCTV(a, b + 1);
                uint32_t *tv = out.tris + 3 * (size_t)t;
                tv[0] = v0, tv[1] = v1, tv[2] = v2, t++;
                if (a + b + 1 < s) {
                    uint32_t v3 = OCTV(a + 1, b + 1);
                    tv = out.tris + 3 * (size_t)t;
                    tv[0] = v1, tv[1] = v3, tv[2] = v2, t++;
                }
            }
#undef OCTV
    }
    /* Positions from the keys: project the octahedron point to the sphere. */
    for (uint64_t i = 0; i <= l.map.mask; i++) {
        uint64_t k = l.map.keys[i];
        if (k == UINT64_MAX)
            continue;
        const int64_t off = 1 << 20, msk = (1 << 21) - 1;
        double x = (double)((int64_t)(k >> 42) - off), y = (double)((int64_t)((k >> 21) & msk) - off),
               z = (double)((int64_t)(k & msk) - off);
        double r = sqrt(x * x + y * y + z * z);
        float *p = out.pos + 3 * (size_t)l.map.vals[i];
        p[0] = (float)(radius * x / r), p[1] = (float)(radius * y / r), p[2] = (float)(radius * z / r);
    }
    micro_map_free(&l.map);
    for (uint32_t i = 0; i < out.ntris; i++) {
        const uint32_t *tv = out.tris + 3 * (size_t)i;
        double c[3] = {0, 0, 0};
        for (int j = 0; j < 3; j++)
            for (int d = 0; d < 3; d++)
                c[d] += out.pos[3 * (size_t)tv[j] + d];
        orient(&out, i, c);
    }
    GS_ASSERT(out.nverts == nv && t == nt);
    gs_micro_mesh_free(m);
    *m = out;
    return GS_OK;
}

gs_err gs_micro_mesh_sphere(gs_micro_mesh *m, double radius, double max_edge)
{
    GS_CHECK(max_edge > 0 && isfinite(max_edge), GS_ERR_ARG, "max_edge %g: expected > 0", max_edge);
    GS_CHECK(radius > 0 && isfinite(radius), GS_ERR_ARG, "sphere radius %g: expected > 0", radius);
    /* Start from an estimate of the longest edge (pi r / 2 per octant edge,
     * stretched up to ~1.25 by the projection), then measure and grow s until
     * the bound holds. */
    double guess = 1.25 * (MICRO_PI * radius / 2) / max_edge;
    GS_CHECK(guess < 16000, GS_ERR_ARG, "sphere radius %g with max_edge %g needs more than 2^31 triangles",
             radius, max_edge);
    uint32_t s = guess < 1 ? 1 : (uint32_t)guess;
    for (;;) {
        GS_CALL(gs_micro_mesh_sphere_segments(m, radius, s));
        double e, a;
        gs_micro_mesh_edge_stats(m, &e, &a);
        if (e <= max_edge)
            return GS_OK;
        s = (uint32_t)(s * e / max_edge) + 1;
    }
}

gs_err gs_micro_mesh_disk(gs_micro_mesh *m, double radius, double max_edge)
{
    GS_CHECK(radius > 0 && isfinite(radius), GS_ERR_ARG, "disk radius %g: expected > 0", radius);
    GS_CHECK(max_edge > 0 && isfinite(max_edge), GS_ERR_ARG, "max_edge %g: expected > 0", max_edge);
    double rings = ceil(radius / max_edge);
    for (;;) {
        GS_CHECK(rings < 18000, GS_ERR_ARG, "disk radius %g with max_edge %g needs more than 2^31 triangles",
                 radius, max_edge);
        int64_t R = (int64_t)rings;
        uint64_t nt = 6ull * R * R, nv = 3ull * R * (R + 1) + 1;
        gs_micro_mesh out;
        GS_CALL(gs_micro_mesh_alloc(&out, (uint32_t)nv, (uint32_t)nt));
        out.nverts = 0;
        lattice l = {.m = &out};
        gs_err err = micro_map_init(&l.map, nv);
        if (err != GS_OK) {
            gs_micro_mesh_free(&out);
            GS_CALL(err);
        }
        double h = radius / (double)R;
        /* Triangular lattice in axial coordinates (q, r): p = q e1 + r e2; a
         * point at hexagonal ring d is pushed radially onto the circle d h. */
#define HEXD(q, r) ((llabs(q) + llabs(r) + llabs((q) + (r))) / 2)
        uint32_t t = 0;
        for (int64_t q = -R; q <= R; q++)
            for (int64_t r = -R; r <= R; r++) {
                int64_t up[3][2] = {{q, r}, {q + 1, r}, {q, r + 1}};
                int64_t dn[3][2] = {{q + 1, r}, {q + 1, r + 1}, {q, r + 1}};
                for (int k = 0; k < 2; k++) {
                    int64_t(*c)[2] = k ? dn : up;
                    if (HEXD(c[0][0], c[0][1]) > R || HEXD(c[1][0], c[1][1]) > R ||
                        HEXD(c[2][0], c[2][1]) > R)
                        continue;
                    uint32_t *tv = out.tris + 3 * (size_t)t++;
                    for (int j = 0; j < 3; j++) {
                        int64_t qq = c[j][0], rr = c[j][1];
                        double px = (double)qq + 0.5 * (double)rr, py = 0.8660254037844386 * (double)rr;
                        double len = sqrt(px * px + py * py);
                        double sc = len > 0 ? (double)HEXD(qq, rr) * h / len : 0;
                        tv[j] = lattice_vertex(&l, lkey(qq, rr, 0), px * sc, py * sc, 0.0);
                    }
                }
            }
#undef HEXD
        micro_map_free(&l.map);
        GS_ASSERT(t == nt && out.nverts == nv);
        double e, a;
        gs_micro_mesh_edge_stats(&out, &e, &a);
        if (e <= max_edge) {
            gs_micro_mesh_free(m);
            *m = out;
            return GS_OK;
        }
        gs_micro_mesh_free(&out);
        rings = ceil(rings * e / max_edge);
    }
}

gs_err gs_micro_mesh_bar(gs_micro_mesh *m, double sx, double sy, double sz, double max_edge)
{
    GS_CHECK(sx > 0 && sy > 0 && sz > 0 && isfinite(sx + sy + sz), GS_ERR_ARG,
             "bar size %g x %g x %g: expected positive sizes", sx, sy, sz);
    GS_CHECK(max_edge > 0 && isfinite(max_edge), GS_ERR_ARG, "max_edge %g: expected > 0", max_edge);
    double cell = max_edge / sqrt(2.0); /* the cell diagonal is the longest edge */
    double n[3] = {ceil(sx / cell), ceil(sy / cell), ceil(sz / cell)};
    double size[3] = {sx, sy, sz};
    double ntd = 4 * (n[0] * n[1] + n[1] * n[2] + n[2] * n[0]);
    GS_CHECK(ntd < 2147483647.0 && n[0] < 1e6 && n[1] < 1e6 && n[2] < 1e6, GS_ERR_ARG,
             "bar %g x %g x %g with max_edge %g needs more than 2^31 triangles", sx, sy, sz, max_edge);
    int64_t N[3] = {(int64_t)n[0], (int64_t)n[1], (int64_t)n[2]};
    uint64_t nt = (uint64_t)ntd;
    uint64_t nv = (uint64_t)((N[0] + 1) * (N[1] + 1) * (N[2] + 1) - (N[0] - 1) * (N[1] - 1) * (N[2] - 1));
    gs_micro_mesh out;
    GS_CALL(gs_micro_mesh_alloc(&out, (uint32_t)nv, (uint32_t)nt));
    out.nverts = 0;
    lattice l = {.m = &out};
    gs_err err = micro_map_init(&l.map, nv);
    if (err != GS_OK) {
        gs_micro_mesh_free(&out);
        GS_CALL(err);
    }
    uint32_t t = 0;
    for (int axis = 0; axis < 3; axis++)
        for (int side = 0; side < 2; side++) {
            int ua = (axis + 1) % 3, va = (axis + 2) % 3;
            double dir[3] = {0, 0, 0};
            dir[axis] = side ? 1 : -1;
            for (int64_t u = 0; u < N[ua]; u++)
                for (int64_t v = 0; v < N[va]; v++) {
                    uint32_t q[4];
                    for (int c = 0; c < 4; c++) {
                        int64_t idx[3];
                        idx[axis] = side ? N[axis] : 0;
                        idx[ua] = u + (c == 1 || c == 2);
                        idx[va] = v + (c >= 2);
                        double p[3];
                        for (int d = 0; d < 3; d++)
                            p[d] = size[d] * ((double)idx[d] / (double)N[d] - 0.5);
                        q[c] = lattice_vertex(&l, lkey(idx[0], idx[1], idx[2]), p[0], p[1], p[2]);
                    }
                    /* corners 0 (u,v) 1 (u+1,v) 2 (u+1,v+1) 3 (u,v+1); the
                     * diagonal alternates so no direction is preferred. */
                    uint32_t a[2][3];
                    if ((u + v) & 1) {
                        uint32_t x0[3] = {q[0], q[1], q[2]}, x1[3] = {q[0], q[2], q[3]};
                        memcpy(a[0], x0, sizeof x0), memcpy(a[1], x1, sizeof x1);
                    } else {
                        uint32_t x0[3] = {q[0], q[1], q[3]}, x1[3] = {q[1], q[2], q[3]};
                        memcpy(a[0], x0, sizeof x0), memcpy(a[1], x1, sizeof x1);
                    }
                    for (int k = 0; k < 2; k++) {
                        memcpy(out.tris + 3 * (size_t)t, a[k], sizeof a[k]);
                        orient(&out, t++, dir);
                    }
                }
        }
    micro_map_free(&l.map);
    GS_ASSERT(t == nt && out.nverts == nv);
    gs_micro_mesh_free(m);
    *m = out;
    return GS_OK;
}

void gs_micro_mesh_edge_stats(const gs_micro_mesh *m, double *max_edge, double *min_angle_deg)
{
    double emax = 0, cmax = -1; /* largest cosine = smallest angle */
    for (uint32_t t = 0; t < m->ntris; t++) {
        const uint32_t *tv = m->tris + 3 * (size_t)t;
        const float *p[3] = {m->pos + 3 * (size_t)tv[0], m->pos + 3 * (size_t)tv[1],
                             m->pos + 3 * (size_t)tv[2]};
        double len[3];
        for (int i = 0; i < 3; i++)
            len[i] = micro_dist3f(p[i], p[(i + 1) % 3]);
        for (int i = 0; i < 3; i++) {
            if (len[i] > emax)
                emax = len[i];
            /* angle at vertex i + 2, between edges i+1 and i+2... opposite edge i */
            double a = len[(i + 1) % 3], b = len[(i + 2) % 3], c = len[i];
            double cosang = (a * a + b * b - c * c) / (2 * a * b + DBL_MIN);
            if (cosang > cmax)
                cmax = cosang;
        }
    }
    if (max_edge)
        *max_edge = emax;
    if (min_angle_deg)
        *min_angle_deg = m->ntris ? acos(cmax > 1 ? 1 : cmax) * 180.0 / MICRO_PI : 0;
}

double gs_micro_mesh_half_extent(const gs_micro_mesh *m)
{
    double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    for (uint32_t v = 0; v < m->nverts; v++)
        for (int d = 0; d < 3; d++) {
            double x = m->pos[3 * (size_t)v + d];
            lo[d] = x < lo[d] ? x : lo[d];
            hi[d] = x > hi[d] ? x : hi[d];
        }
    double e = 0;
    for (int d = 0; d < 3 && m->nverts; d++)
        e = hi[d] - lo[d] > e ? hi[d] - lo[d] : e;
    return e / 2;
}

gs_err gs_micro_mesh_normals(gs_micro_mesh *m)
{
    double *acc = NULL;
    GS_CALL(gs_alloc_array((void **)&acc, (size_t)m->nverts * 3, sizeof *acc, "vertex normals"));
    if (!m->normals) {
        gs_err err = gs_alloc_array((void **)&m->normals, (size_t)m->nverts * 3, sizeof *m->normals,
                                    "vertex normals");
        if (err != GS_OK) {
            gs_free(acc);
            GS_CALL(err);
        }
    }
    for (uint32_t t = 0; t < m->ntris; t++) {
        const uint32_t *tv = m->tris + 3 * (size_t)t;
        double n[3]; /* length = twice the area: area weighting */
        tri_normal(m->pos + 3 * (size_t)tv[0], m->pos + 3 * (size_t)tv[1], m->pos + 3 * (size_t)tv[2], n);
        for (int j = 0; j < 3; j++)
            for (int d = 0; d < 3; d++)
                acc[3 * (size_t)tv[j] + d] += n[d];
    }
    for (uint32_t v = 0; v < m->nverts; v++) {
        double *a = acc + 3 * (size_t)v;
        double len = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        for (int d = 0; d < 3; d++)
            m->normals[3 * (size_t)v + d] = len > 0 ? (float)(a[d] / len) : 0.0f;
    }
    gs_free(acc);
    return GS_OK;
}
