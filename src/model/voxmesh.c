/* Voxel-cube surface with merged faces (greedy meshing per slice) and its
 * PLY / OBJ writers. See include/geosynth/model_io.h. */
#include <stdio.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/file.h"
#include "geosynth/glb.h"
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
                        mask[(size_t)j * (size_t)nu + (size_t)i] = (l != 0 && m == 0) ? l : 0;
                        res.unit_faces += (l != 0 && m == 0);
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
                        while (i + w < nu && w < GS_MODEL_QUAD_MAX && mask[(size_t)j * (size_t)nu + (size_t)(i + w)] == l)
                            w++;
                        int h = 1;
                        for (; j + h < nv && h < GS_MODEL_QUAD_MAX; h++) {
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
                        q.lo[a] = q.hi[a] = k + (side ? 0 : 1);
                        q.lo[u] = i;
                        q.hi[u] = i + w;
                        q.lo[v] = j;
                        q.hi[v] = j + h;
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

/* ---- welding ------------------------------------------------------------ */

/* The 12 unit squares around a lattice point P: square (a, bu, bv) is
 * perpendicular to axis a and lies between the two of the 8 cells around P
 * whose bits on axes (a+1)%3, (a+2)%3 are bu, bv (cell bit k set: the cell
 * on the + side of P along axis k). */
static int slot_between(int c1, int c2)
{
    const int d = c1 ^ c2, a = d == 1 ? 0 : d == 2 ? 1 : 2;
    return 4 * a + ((c1 >> ((a + 1) % 3)) & 1) + 2 * ((c1 >> ((a + 2) % 3)) & 1);
}

static int uf_find(int *p, int i)
{
    while (p[i] != i)
        i = p[i] = p[p[i]];
    return i;
}

/* The sheet of surface through lattice point P that surface square `slot`
 * belongs to, as the smallest slot of that sheet. Around each of the 6 unit
 * edges at P the filled cells form arcs; the two squares bounding an arc are
 * one sheet there (so two cubes touching along the edge keep apart). */
static int sheet_of(const gs_model_lattice *lat, const int P[3], int slot)
{
    int solid[8], parent[12];
    for (int b = 0; b < 8; b++) {
        const int c[3] = {P[0] - 1 + (b & 1), P[1] - 1 + ((b >> 1) & 1), P[2] - 1 + ((b >> 2) & 1)};
        solid[b] = cell(lat, c) != 0;
    }
    for (int i = 0; i < 12; i++)
        parent[i] = i;
    for (int e = 0; e < 3; e++)
        for (int s = 0; s < 2; s++) {
            const int u = (e + 1) % 3, v = (e + 2) % 3;
            const int cyc[4] = {s << e, s << e | 1 << u, s << e | 1 << u | 1 << v, s << e | 1 << v};
            for (int i = 0; i < 4; i++) {
                if (!solid[cyc[i]] || solid[cyc[(i + 3) % 4]])
                    continue; /* not the start of an arc */
                int j = i;
                while (solid[cyc[(j + 1) % 4]])
                    j = (j + 1) % 4;
                int r1 = uf_find(parent, slot_between(cyc[(i + 3) % 4], cyc[i]));
                int r2 = uf_find(parent, slot_between(cyc[j], cyc[(j + 1) % 4]));
                if (r1 < r2)
                    parent[r2] = r1;
                else
                    parent[r1] = r2;
            }
        }
    return uf_find(parent, slot);
}

/* The square of rectangle q at its boundary lattice point P. */
static int quad_slot(const gs_model_quad *q, const int P[3])
{
    const int a = q->dir / 2, u = (a + 1) % 3, v = (a + 2) % 3;
    const int cu = P[u] - 1 >= q->lo[u] ? P[u] - 1 : P[u];
    const int cv = P[v] - 1 >= q->lo[v] ? P[v] - 1 : P[v];
    return 4 * a + (cu - (P[u] - 1)) + 2 * (cv - (P[v] - 1));
}

/* Corner c of q as a lattice point, in the order of q->p. */
static void quad_corner(const gs_model_quad *q, int c, int P[3])
{
    const int a = q->dir / 2, side = q->dir % 2, u = (a + 1) % 3, v = (a + 2) % 3;
    static const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    const int cc = side ? 3 - c : c;
    P[a] = q->lo[a];
    P[u] = uv[cc][0] ? q->hi[u] : q->lo[u];
    P[v] = uv[cc][1] ? q->hi[v] : q->lo[v];
}

typedef struct vmap {
    uint64_t *key; /* key + 1; 0 = free */
    uint32_t *id;
    size_t mask;
} vmap;

static size_t vmap_slot(const vmap *m, uint64_t key)
{
    size_t s = (size_t)gs_hash_mix64(key) & m->mask;
    while (m->key[s] && m->key[s] != key + 1)
        s = (s + 1) & m->mask;
    return s;
}

/* Vertex keys on the doubled lattice (edge midpoints have one odd
 * coordinate), times 16 for the sheet. */
static uint64_t vkey2(const gs_model_lattice *lat, const int P2[3], int sheet)
{
    return (((uint64_t)P2[2] * (uint64_t)(2 * lat->ny + 1) + (uint64_t)P2[1]) *
                (uint64_t)(2 * lat->nx + 1) + (uint64_t)P2[0]) * 16u + (uint64_t)sheet;
}

static uint64_t vkey(const gs_model_lattice *lat, const int P[3], int sheet)
{
    const int P2[3] = {2 * P[0], 2 * P[1], 2 * P[2]};
    return vkey2(lat, P2, sheet);
}

/* The unit edge from lattice point X one step along axis ax (step +-1):
 * when exactly two cells around it are filled and they face each other
 * across it (two cubes touching along the edge only), the surface passes
 * it twice, once per cube. Returns 1 and, for rectangle q's face there, the
 * cube's place around the edge (0..3) in *sheet. */
static int diagonal_edge(const gs_model_lattice *lat, const gs_model_quad *q, const int X[3], int ax,
                         int step, int *sheet)
{
    const int s = ax == 0 ? 1 : 0, t = ax == 2 ? 1 : 2; /* the other two axes, ascending */
    int solid[4], n = 0;
    for (int b = 0; b < 4; b++) {
        int c[3];
        c[ax] = step > 0 ? X[ax] : X[ax] - 1;
        c[s] = X[s] - 1 + (b & 1);
        c[t] = X[t] - 1 + (b >> 1);
        solid[b] = cell(lat, c) != 0;
        n += solid[b];
    }
    if (n != 2 || solid[0] != solid[3])
        return 0;
    /* q's cell at this edge: behind its face along its axis, and its unit
     * square next to the edge along the third axis */
    const int a = q->dir / 2, w = 3 - a - ax;
    int c[3];
    c[a] = q->dir % 2 ? q->lo[a] : q->lo[a] - 1;
    c[w] = X[w] - 1 >= q->lo[w] ? X[w] - 1 : X[w];
    *sheet = (c[s] - (X[s] - 1)) + 2 * (c[t] - (X[t] - 1));
    return 1;
}

gs_err gs_model_mesh_weld(const gs_model_lattice *lat, const gs_model_quads *q, double voxel,
                          gs_model_polymesh *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(q->n <= ((size_t)1 << 28), GS_ERR_ARG, "mesh: %zu rectangles: too many to weld", q->n);
    gs_err err = GS_OK;
    vmap m = {NULL, NULL, 0};
    gs_model_polymesh r;
    memset(&r, 0, sizeof r);
    size_t cap = 16, ccap = 0, nc = 0, pos_cap = 0;
    while (cap < 16 * q->n)
        cap *= 2;
    m.mask = cap - 1;
    GS_TRY(err, gs_alloc_array((void **)&m.key, cap, sizeof *m.key, "mesh weld table"), done);
    GS_TRY(err, gs_alloc_array((void **)&m.id, cap, sizeof *m.id, "mesh weld table"), done);
    memset(m.key, 0, cap * sizeof *m.key);
    /* at most 4 corners and 4 edge midpoints per rectangle */
    pos_cap = 8 * q->n;
    GS_TRY(err, gs_alloc_array((void **)&r.pos, q->n ? 3 * pos_cap : 1, sizeof *r.pos, "mesh vertices"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&r.start, q->n + 1, sizeof *r.start, "mesh faces"), done);
    GS_TRY(err, gs_alloc_array((void **)&r.label, q->n ? q->n : 1, sizeof *r.label, "mesh faces"),
           done);
    /* every rectangle's corners are vertices */
    for (size_t i = 0; i < q->n; i++)
        for (int c = 0; c < 4; c++) {
            int P[3];
            quad_corner(&q->q[i], c, P);
            const uint64_t k = vkey(lat, P, sheet_of(lat, P, quad_slot(&q->q[i], P)));
            const size_t s = vmap_slot(&m, k);
            if (m.key[s])
                continue;
            m.key[s] = k + 1;
            m.id[s] = (uint32_t)r.nv;
            for (int t = 0; t < 3; t++)
                r.pos[3 * r.nv + (size_t)t] = (float)(P[t] * voxel);
            r.nv++;
        }
    /* each polygon: its corners and, in order, the vertices on its edges */
    ccap = 4 * q->n + 16;
    GS_TRY(err, gs_alloc_array((void **)&r.corner, ccap, sizeof *r.corner, "mesh corners"), done);
    for (size_t i = 0; i < q->n; i++) {
        const gs_model_quad *qq = &q->q[i];
        r.start[i] = (uint32_t)nc;
        r.label[i] = qq->label;
        for (int c = 0; c < 4; c++) {
            int P[3], Q[3];
            quad_corner(qq, c, P);
            quad_corner(qq, (c + 1) % 4, Q);
            int ax = 0;
            while (P[ax] == Q[ax])
                ax++;
            const int step = Q[ax] > P[ax] ? 1 : -1;
            for (; P[ax] != Q[ax]; P[ax] += step) {
                for (int mid = 0; mid < 2; mid++) {
                    uint64_t k;
                    int sheet;
                    if (!mid) {
                        k = vkey(lat, P, sheet_of(lat, P, quad_slot(qq, P)));
                    } else if (diagonal_edge(lat, qq, P, ax, step, &sheet)) {
                        /* two cubes touching along this edge: a vertex in the
                         * middle for each, so the two sheets have distinct edges */
                        int P2[3] = {2 * P[0], 2 * P[1], 2 * P[2]};
                        P2[ax] += step;
                        k = vkey2(lat, P2, sheet);
                        const size_t s = vmap_slot(&m, k);
                        if (!m.key[s]) {
                            GS_TRY_CHECK(err, r.nv < pos_cap, GS_ERR_INTERNAL, done,
                                         "mesh: more vertices than %zu", pos_cap);
                            m.key[s] = k + 1;
                            m.id[s] = (uint32_t)r.nv;
                            for (int t = 0; t < 3; t++)
                                r.pos[3 * r.nv + (size_t)t] = (float)(P2[t] * 0.5 * voxel);
                            r.nv++;
                        }
                    } else {
                        continue;
                    }
                    const size_t s = vmap_slot(&m, k);
                    if (!m.key[s])
                        continue; /* no vertex of this sheet here */
                    if (nc == ccap) {
                        size_t ncap = 2 * ccap;
                        void *p = gs_realloc(r.corner, ncap * sizeof *r.corner);
                        GS_TRY_CHECK(err, p != NULL, GS_ERR_MEM, done,
                                     "mesh: cannot grow the corner list to %zu", ncap);
                        r.corner = p;
                        ccap = ncap;
                    }
                    r.corner[nc++] = m.id[s];
                }
            }
        }
        GS_TRY_CHECK(err, nc - r.start[i] <= 8 * GS_MODEL_QUAD_MAX && nc <= UINT32_MAX, GS_ERR_INTERNAL,
                     done, "mesh: polygon %zu has %zu corners", i, nc - (size_t)r.start[i]);
    }
    r.start[q->n] = (uint32_t)nc;
    r.nf = q->n;
    *out = r;
    memset(&r, 0, sizeof r);
done:
    gs_free(m.key);
    gs_free(m.id);
    gs_model_polymesh_free(&r);
    return err;
}

/* ---- triangulation ------------------------------------------------------ */

/* Twice the signed area of (a, b, c) in the plane's axes (u, v), times the
 * polygon's orientation sign: > 0 a strictly convex corner, 0 collinear. The
 * coordinates of points on one side of a rectangle are bit-equal along it,
 * so collinear corners give exactly 0. */
static double corner_turn(const float *pos, uint32_t a, uint32_t b, uint32_t c, int u, int v, double sign)
{
    const float *A = pos + 3 * (size_t)a, *B = pos + 3 * (size_t)b, *C = pos + 3 * (size_t)c;
    return sign * (((double)B[u] - A[u]) * ((double)C[v] - A[v]) - ((double)B[v] - A[v]) * ((double)C[u] - A[u]));
}

static int strict_corners(const float *pos, const uint32_t *p, int n, int skip, int u, int v, double sign)
{
    int cnt = 0;
    for (int i = 0; i < n; i++) {
        if (i == skip)
            continue;
        int a = (i + n - 1) % n, b = (i + 1) % n;
        if (a == skip)
            a = (a + n - 1) % n;
        if (b == skip)
            b = (b + 1) % n;
        cnt += corner_turn(pos, p[a], p[i], p[b], u, v, sign) > 0;
    }
    return cnt;
}

gs_err gs_model_polymesh_triangulate(const gs_model_polymesh *in, gs_model_polymesh *out)
{
    memset(out, 0, sizeof *out);
    size_t nf = 0, nc = 0;
    for (size_t f = 0; f < in->nf; f++) {
        const size_t k = in->start[f + 1] - in->start[f];
        nf += k == 4 ? 1 : k - 2;
        nc += k == 4 ? 4 : 3 * (k - 2);
    }
    gs_model_polymesh r;
    memset(&r, 0, sizeof r);
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&r.pos, in->nv ? 3 * in->nv : 1, sizeof *r.pos, "mesh vertices"), done);
    GS_TRY(err, gs_alloc_array((void **)&r.start, nf + 1, sizeof *r.start, "mesh faces"), done);
    GS_TRY(err, gs_alloc_array((void **)&r.corner, nc ? nc : 1, sizeof *r.corner, "mesh corners"), done);
    GS_TRY(err, gs_alloc_array((void **)&r.label, nf ? nf : 1, sizeof *r.label, "mesh faces"), done);
    memcpy(r.pos, in->pos, 3 * in->nv * sizeof *r.pos);
    r.nv = in->nv;
    r.start[0] = 0;
    uint32_t p[8 * GS_MODEL_QUAD_MAX];
    for (size_t f = 0; f < in->nf; f++) {
        const uint32_t *c = in->corner + in->start[f];
        int n = (int)(in->start[f + 1] - in->start[f]);
        if (n == 4) {
            r.label[r.nf] = in->label[f];
            memcpy(r.corner + r.start[r.nf], c, 4 * sizeof *c);
            r.start[r.nf + 1] = r.start[r.nf] + 4;
            r.nf++;
            continue;
        }
        GS_TRY_CHECK(err, n >= 3 && n <= 8 * GS_MODEL_QUAD_MAX, GS_ERR_INTERNAL, done,
                     "mesh: polygon %zu has %d corners", f, n);
        memcpy(p, c, (size_t)n * sizeof *p);
        /* the plane's axis: the one along which every corner has one value */
        int a = 0;
        for (int t = 0; t < 3; t++) {
            int flat = 1;
            for (int i = 1; i < n && flat; i++)
                flat = r.pos[3 * (size_t)p[i] + (size_t)t] == r.pos[3 * (size_t)p[0] + (size_t)t];
            if (flat)
                a = t;
        }
        const int u = (a + 1) % 3, v = (a + 2) % 3;
        double area = 0;
        for (int i = 1; i + 1 < n; i++)
            area += corner_turn(r.pos, p[0], p[i], p[i + 1], u, v, 1.0);
        const double sign = area >= 0 ? 1.0 : -1.0;
        /* ear clipping of a convex polygon whose sides carry collinear
         * corners: cut a strictly convex corner whose cut leaves at least 3
         * strictly convex corners (or a proper triangle), so no triangle has
         * zero area (a fan from one corner would: its sides' corners) */
        while (n > 3) {
            int ear = -1;
            for (int i = 0; i < n && ear < 0; i++) {
                if (corner_turn(r.pos, p[(i + n - 1) % n], p[i], p[(i + 1) % n], u, v, sign) <= 0)
                    continue;
                if (strict_corners(r.pos, p, n, i, u, v, sign) >= 3)
                    ear = i;
            }
            GS_TRY_CHECK(err, ear >= 0, GS_ERR_INTERNAL, done, "mesh: polygon %zu: no ear to cut", f);
            uint32_t *o = r.corner + r.start[r.nf];
            o[0] = p[(ear + n - 1) % n];
            o[1] = p[ear];
            o[2] = p[(ear + 1) % n];
            r.label[r.nf] = in->label[f];
            r.start[r.nf + 1] = r.start[r.nf] + 3;
            r.nf++;
            memmove(p + ear, p + ear + 1, (size_t)(n - ear - 1) * sizeof *p);
            n--;
        }
        GS_TRY_CHECK(err, corner_turn(r.pos, p[0], p[1], p[2], u, v, sign) > 0, GS_ERR_INTERNAL, done,
                     "mesh: polygon %zu: last triangle has no area", f);
        memcpy(r.corner + r.start[r.nf], p, 3 * sizeof *p);
        r.label[r.nf] = in->label[f];
        r.start[r.nf + 1] = r.start[r.nf] + 3;
        r.nf++;
    }
    *out = r;
    memset(&r, 0, sizeof r);
done:
    gs_model_polymesh_free(&r);
    return err;
}

void gs_model_polymesh_free(gs_model_polymesh *m)
{
    if (!m)
        return;
    GS_FREE(m->pos);
    GS_FREE(m->start);
    GS_FREE(m->corner);
    GS_FREE(m->label);
    m->nv = m->nf = 0;
}

static int put_bytes(FILE *f, const void *p, size_t n) { return fwrite(p, 1, n, f) == n; }

static gs_err write_ply(const char *path, const gs_model_polymesh *m, const gs_model_palette *pal)
{
    GS_CHECK(m->nv <= ((size_t)1 << 31) && m->nf <= ((size_t)1 << 31), GS_ERR_ARG,
             "%s: %zu vertices, %zu faces: too many for a PLY mesh", path, m->nv, m->nf);
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    int ok = fprintf(af.f,
                     "ply\nformat binary_little_endian 1.0\n"
                     "comment geosynth model: surface of the filled voxel cells, welded closed "
                     "2-manifold; faces are merged rectangles (quads), or the triangles of one "
                     "that has its neighbours' vertices on its edges (no T-junctions, no zero-area "
                     "triangles), colour and label of their cell\n"
                     "comment up_axis z; units: model.voxel_size per cell\n"
                     "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n"
                     "element face %zu\nproperty list uchar int vertex_indices\n"
                     "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                     "property ushort label\nend_header\n",
                     m->nv, m->nf) > 0;
    /* little-endian host assumed by the PLY writer of src/io too (x86/ARM) */
    ok = ok && put_bytes(af.f, m->pos, 3 * m->nv * sizeof *m->pos);
    for (size_t i = 0; ok && i < m->nf; i++) {
        const uint8_t k = (uint8_t)(m->start[i + 1] - m->start[i]);
        uint8_t rgb[3];
        gs_model_label_rgb(pal, m->label[i], rgb);
        ok = put_bytes(af.f, &k, 1) && put_bytes(af.f, m->corner + m->start[i], 4 * (size_t)k) &&
             put_bytes(af.f, rgb, 3) && put_bytes(af.f, &m->label[i], 2);
    }
    if (!ok) {
        gs_atomic_abort(&af);
        GS_RAISE(GS_ERR_IO, "%s: write failed", path);
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
}

static gs_err write_obj(const char *path, const gs_model_polymesh *m, const gs_model_palette *pal)
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
    for (size_t i = 0; i < m->nf; i++) {
        uint16_t l = m->label[i];
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
    ok = fprintf(af.f,
                 "# geosynth model: surface of the filled voxel cells, welded closed 2-manifold "
                 "(%zu vertices, %zu faces: merged rectangles as quads, or triangles where a "
                 "rectangle has its neighbours' vertices on its edges); z up, units: "
                 "model.voxel_size per cell\nmtllib %s\n",
                 m->nv, m->nf, mtl_base) > 0;
    for (size_t i = 0; ok && i < m->nv; i++)
        ok = fprintf(af.f, "v %.9g %.9g %.9g\n", m->pos[3 * i], m->pos[3 * i + 1],
                     m->pos[3 * i + 2]) > 0;
    /* faces grouped by label, in label order */
    memset(seen, 0, 65536);
    for (size_t i = 0; i < m->nf; i++)
        seen[m->label[i]] = 1;
    for (int l = 1; ok && l < 65536; l++) {
        if (!seen[l])
            continue;
        ok = fprintf(af.f, "usemtl label_%d\n", l) > 0;
        for (size_t i = 0; ok && i < m->nf; i++) {
            if (m->label[i] != l)
                continue;
            ok = fputc('f', af.f) != EOF;
            for (uint32_t c = m->start[i]; ok && c < m->start[i + 1]; c++)
                ok = fprintf(af.f, " %u", m->corner[c] + 1u) > 0;
            ok = ok && fputc('\n', af.f) != EOF;
        }
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

/* glTF: one primitive (material label_N, the label's colour) per label, in
 * label order, over the shared vertices; quads as two triangles. */
static gs_err write_glb(const char *path, const gs_model_polymesh *m, const gs_model_palette *pal)
{
    size_t ntri = 0;
    for (size_t f = 0; f < m->nf; f++)
        ntri += m->start[f + 1] - m->start[f] - 2;
    uint32_t *tris = NULL;
    size_t *first = NULL;
    gs_glb_part *parts = NULL;
    uint8_t *rgb = NULL;
    char (*names)[16] = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&tris, 3 * ntri + 1, sizeof *tris, "glTF triangles"), done);
    GS_TRY(err, gs_alloc_array((void **)&first, 65537, sizeof *first, "glTF parts"), done);
    memset(first, 0, 65537 * sizeof *first);
    for (size_t f = 0; f < m->nf; f++)
        first[m->label[f] + 1] += m->start[f + 1] - m->start[f] - 2;
    size_t nparts = 0;
    for (int l = 0; l < 65536; l++) {
        nparts += first[l + 1] > 0;
        first[l + 1] += first[l];
    }
    GS_TRY(err, gs_alloc_array((void **)&parts, nparts + 1, sizeof *parts, "glTF parts"), done);
    GS_TRY(err, gs_alloc_array((void **)&rgb, 3 * nparts + 1, 1, "glTF parts"), done);
    GS_TRY(err, gs_alloc_array((void **)&names, nparts + 1, sizeof *names, "glTF parts"), done);
    for (int l = 0, k = 0; l < 65536; l++) {
        if (first[l + 1] == first[l])
            continue;
        gs_model_label_rgb(pal, (uint16_t)l, rgb + 3 * k);
        snprintf(names[k], sizeof names[k], "label_%d", l);
        parts[k] = (gs_glb_part){tris + 3 * first[l], first[l + 1] - first[l], names[k], rgb + 3 * k};
        k++;
    }
    for (size_t f = 0; f < m->nf; f++) {
        const uint32_t *c = m->corner + m->start[f];
        const uint32_t k = m->start[f + 1] - m->start[f];
        uint32_t *o = tris + 3 * first[m->label[f]];
        for (uint32_t t = 1; t + 1 < k; t++, o += 3) { /* a triangle, or a quad's two */
            o[0] = c[0];
            o[1] = c[t];
            o[2] = c[t + 1];
        }
        first[m->label[f]] += k - 2;
    }
    const gs_glb_desc d = {m->pos, m->nv, NULL, NULL, parts, nparts, "geosynth model",
                           "model.voxel_size per cell",
                           "surface of the filled voxel cells, one material label_N per label "
                           "(its lattice.vox colour); welded: primitives share the vertices"};
    err = gs_glb_write(path, &d);
done:
    gs_free(tris);
    gs_free(first);
    gs_free(parts);
    gs_free(rgb);
    gs_free(names);
    return err;
}

gs_err gs_model_write_mesh(const char *path, const gs_model_polymesh *m, const gs_model_palette *pal)
{
    char ext[16];
    gs_path_ext(path, ext, sizeof ext);
    GS_CHECK(!strcmp(ext, "ply") || !strcmp(ext, "obj") || !strcmp(ext, "glb"), GS_ERR_ARG,
             "%s: mesh output must end in .ply, .obj or .glb", path);
    gs_model_polymesh t;
    GS_CALL(gs_model_polymesh_triangulate(m, &t));
    gs_err err = !strcmp(ext, "ply") ? write_ply(path, &t, pal)
                 : !strcmp(ext, "obj") ? write_obj(path, &t, pal)
                                       : write_glb(path, &t, pal);
    gs_model_polymesh_free(&t);
    return err;
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
        gs_preview_panel panels[2] = {{&m[0], rgb[0], NULL}, {&m[1], rgb[1], NULL}};
        err = gs_preview_write(path, panels, 2, side);
    }
    for (int i = 0; i < 2; i++) {
        gs_mesh_destroy(&m[i]);
        gs_free(rgb[i]);
    }
    return err;
}
