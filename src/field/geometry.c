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

/* Closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision
 * Detection 5.1.5); returns the squared distance. */
static double closest_on_triangle(const double p[3], const double a[3], const double b[3],
                                  const double c[3], double q[3])
{
    double ab[3], ac[3], ap[3], bp[3], cp[3];
    for (int k = 0; k < 3; k++)
        ab[k] = b[k] - a[k], ac[k] = c[k] - a[k], ap[k] = p[k] - a[k], bp[k] = p[k] - b[k],
        cp[k] = p[k] - c[k];
#define DOT(u, v) ((u)[0] * (v)[0] + (u)[1] * (v)[1] + (u)[2] * (v)[2])
    double d1 = DOT(ab, ap), d2 = DOT(ac, ap), d3 = DOT(ab, bp), d4 = DOT(ac, bp);
    double d5 = DOT(ab, cp), d6 = DOT(ac, cp);
#undef DOT
    double u = 0, v = 0; /* q = a + u ab + v ac */
    double va = d3 * d6 - d5 * d4, vb = d5 * d2 - d1 * d6, vc = d1 * d4 - d3 * d2;
    if (d1 <= 0 && d2 <= 0)
        u = 0, v = 0;
    else if (d3 >= 0 && d4 <= d3)
        u = 1, v = 0;
    else if (vc <= 0 && d1 >= 0 && d3 <= 0)
        u = d1 / (d1 - d3), v = 0;
    else if (d6 >= 0 && d5 <= d6)
        u = 0, v = 1;
    else if (vb <= 0 && d2 >= 0 && d6 <= 0)
        u = 0, v = d2 / (d2 - d6);
    else if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        u = 1 - w, v = w;
    } else {
        double den = 1 / (va + vb + vc);
        u = vb * den, v = vc * den;
    }
    double d = 0;
    for (int k = 0; k < 3; k++) {
        q[k] = a[k] + u * ab[k] + v * ac[k];
        d += (p[k] - q[k]) * (p[k] - q[k]);
    }
    return d;
}

gs_err gs_field_prov_pack(const int32_t *prov, const int64_t n[3], gs_field_prov *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(n[0] >= 1 && n[1] >= 1 && n[2] >= 1 && n[0] <= INT32_MAX, GS_ERR_ARG,
             "provenance of %lldx%lldx%lld samples: expected 1..2^31 along x", (long long)n[0],
             (long long)n[1], (long long)n[2]);
    const int64_t nx = n[0], rows = n[1] * n[2];
    /* a run goes on at x while prov[x] is its value there */
#define PROV_GOES_ON(r, x) ((r)[x] == ((r)[(x) - 1] < 0 ? (int64_t)(r)[(x) - 1] : (int64_t)(r)[(x) - 1] + 1))
    int64_t runs = 0;
    for (int64_t y = 0; y < rows; y++) {
        const int32_t *r = prov + nx * y;
        runs++;
        for (int64_t x = 1; x < nx; x++)
            runs += !PROV_GOES_ON(r, x);
    }
    gs_field_prov p;
    memset(&p, 0, sizeof p);
    memcpy(p.n, n, sizeof p.n);
    p.runs = runs;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&p.row, (size_t)rows + 1, sizeof *p.row, "packed provenance"), fail);
    GS_TRY(err, gs_alloc_array((void **)&p.run, 2 * (size_t)runs, sizeof *p.run, "packed provenance"), fail);
    int64_t k = 0;
    for (int64_t y = 0; y < rows; y++) {
        const int32_t *r = prov + nx * y;
        p.row[y] = k;
        for (int64_t x = 0; x < nx; x++)
            if (x == 0 || !PROV_GOES_ON(r, x))
                p.run[2 * k] = (int32_t)x, p.run[2 * k + 1] = r[x], k++;
    }
#undef PROV_GOES_ON
    p.row[rows] = k;
    *out = p;
    return GS_OK;
fail:
    gs_field_prov_destroy(&p);
    return err;
}

int32_t gs_field_prov_at(const gs_field_prov *p, int64_t t)
{
    const int64_t y = t / p->n[0], x = t - y * p->n[0];
    /* the last run of row y starting at or before x */
    int64_t lo = p->row[y], hi = p->row[y + 1] - 1;
    while (lo < hi) {
        int64_t mid = (lo + hi + 1) / 2;
        if (p->run[2 * mid] <= x)
            lo = mid;
        else
            hi = mid - 1;
    }
    const int32_t v = p->run[2 * lo + 1];
    return v < 0 ? v : (int32_t)(v + (x - p->run[2 * lo]));
}

size_t gs_field_prov_bytes(const gs_field_prov *p)
{
    return p->row ? (size_t)(p->n[1] * p->n[2] + 1) * sizeof *p->row +
                        2 * (size_t)p->runs * sizeof *p->run
                  : 0;
}

void gs_field_prov_destroy(gs_field_prov *p)
{
    gs_free(p->row);
    gs_free(p->run);
    memset(p, 0, sizeof *p);
}

/* The copy's provenance: dense (one int32 a sample) or packed (owned:
 * destroyed by copy_geometry once read) */
typedef struct copy_prov {
    const int32_t *dense;
    gs_field_prov *packed;
} copy_prov;

static inline int32_t copy_prov_at(const copy_prov *cp, int64_t t)
{
    return cp->dense ? cp->dense[t] : gs_field_prov_at(cp->packed, t);
}

typedef struct copy_src {
    const gs_mesh *m;
    int64_t sn[3];
    const int64_t *start, *tri_of; /* triangles bucketed by the sample nearest their centroid */
} copy_src;

/* Closest point of the source surface to q (source sample units) among the
 * triangles of the samples within 1 of round(q); 0 when none lies within
 * snap. */
static int snap_to_source(const copy_src *cs, const double q[3], double snap, double out[3])
{
    int64_t c[3];
    for (int a = 0; a < 3; a++)
        c[a] = (int64_t)llround(q[a]);
    double best = snap * snap;
    int found = 0;
    for (int64_t z = c[2] - 1; z <= c[2] + 1; z++)
        for (int64_t y = c[1] - 1; y <= c[1] + 1; y++)
            for (int64_t x = c[0] - 1; x <= c[0] + 1; x++) {
                if (x < 0 || y < 0 || z < 0 || x >= cs->sn[0] || y >= cs->sn[1] || z >= cs->sn[2])
                    continue;
                int64_t s = x + cs->sn[0] * (y + cs->sn[1] * z);
                for (int64_t b = cs->start[s]; b < cs->start[s + 1]; b++) {
                    const uint32_t *tr = cs->m->tris + 3 * cs->tri_of[b];
                    double v[3][3], r[3];
                    for (int k = 0; k < 3; k++)
                        for (int a = 0; a < 3; a++)
                            v[k][a] = cs->m->pos[3 * (size_t)tr[k] + a];
                    double d = closest_on_triangle(q, v[0], v[1], v[2], r);
                    if (d <= best) {
                        best = d, found = 1;
                        memcpy(out, r, sizeof r);
                    }
                }
            }
    return found;
}

/* Trilinear value of f (sample units) at p, clamped to the box. (The
 * corners' weights and indices per axis once, then the same products and
 * sums in the same order as corner by corner: the same value.) */
static double field_at(const gs_field *f, const double p[3])
{
    const int64_t n[3] = {f->nx, f->ny, f->nz};
    int64_t lo[3], hi[3];
    double wl[3], wh[3];
    for (int a = 0; a < 3; a++) {
        double x = fmin(fmax(p[a], 0), (double)(n[a] - 1));
        double fl = fmin(floor(x), (double)(n[a] - 2 < 0 ? 0 : n[a] - 2));
        lo[a] = (int64_t)fl;
        hi[a] = lo[a] + 1 < n[a] ? lo[a] + 1 : n[a] - 1;
        wh[a] = n[a] > 1 ? x - fl : 0;
        wl[a] = 1 - wh[a];
    }
    const int64_t sy = n[0], sz = n[0] * n[1];
    const float *fv = f->v;
    double v = 0;
    for (int c = 0; c < 8; c++) {
        int bx = c & 1, by = (c >> 1) & 1, bz = c >> 2;
        double wt = bx ? wh[0] : wl[0];
        wt *= by ? wh[1] : wl[1];
        wt *= bz ? wh[2] : wl[2];
        if (wt > 0)
            v += wt * fv[(bx ? hi[0] : lo[0]) + sy * (by ? hi[1] : lo[1]) + sz * (bz ? hi[2] : lo[2])];
    }
    return v;
}

/* The steps of room_at's walk: t = 0.05, 0.10, ... up to 2, summed as the
 * walk always summed them (the same doubles). */
#define ROOM_STEPS 40
static int room_steps(double t[ROOM_STEPS + 1])
{
    int n = 0;
    for (double s = 0.05; s <= 2 && n < ROOM_STEPS + 1; s += 0.05)
        t[n++] = s;
    return n;
}

/* A bound on how fast f's trilinear value changes along any unit direction
 * (sample units): within a cell the derivative along x interpolates the
 * cell's x differences, so |grad| <= the norm of the largest difference per
 * axis (with a margin over rounding). room_at skips the steps this bound
 * says cannot reach the other sign: the same answer with fewer samples. */
static double field_slope_bound(const gs_field *f)
{
    const int64_t n[3] = {f->nx, f->ny, f->nz}, st[3] = {1, f->nx, f->nx * f->ny};
    double dmax[3] = {0, 0, 0};
    for (int64_t z = 0; z < n[2]; z++)
        for (int64_t y = 0; y < n[1]; y++) {
            const float *row = f->v + st[1] * y + st[2] * z;
            float mx = 0, my = 0, mz = 0;
            for (int64_t x = 0; x + 1 < n[0]; x++)
                mx = fmaxf(mx, fabsf(row[x + 1] - row[x]));
            if (y + 1 < n[1])
                for (int64_t x = 0; x < n[0]; x++)
                    my = fmaxf(my, fabsf(row[x + st[1]] - row[x]));
            if (z + 1 < n[2])
                for (int64_t x = 0; x < n[0]; x++)
                    mz = fmaxf(mz, fabsf(row[x + st[2]] - row[x]));
            dmax[0] = fmax(dmax[0], mx), dmax[1] = fmax(dmax[1], my), dmax[2] = fmax(dmax[2], mz);
        }
    return sqrt(dmax[0] * dmax[0] + dmax[1] * dmax[1] + dmax[2] * dmax[2]) * 1.001 + 1e-12;
}

/* Distance from p (on the zero level of f) to the next surface of f along
 * its gradient, either way, up to 2 samples: the room a vertex at p has
 * before it would pass through another sheet. The walk looks at steps of
 * 0.05 (ts, nt: room_steps) and stops at the first on the other sign; a
 * step whose value |v| is more than slope (field_slope_bound) times the
 * distance to a later step cannot change sign before it, so those are
 * skipped. */
static double room_at(const gs_field *f, const double p[3], const double *ts, int nt, double slope)
{
    double g[3], gl = 0;
    for (int a = 0; a < 3; a++) {
        double q[3] = {p[0], p[1], p[2]}, r[3] = {p[0], p[1], p[2]};
        q[a] += 0.5, r[a] -= 0.5;
        g[a] = field_at(f, q) - field_at(f, r);
        gl += g[a] * g[a];
    }
    if (gl <= 0)
        return 0;
    gl = sqrt(gl);
    double room = 2;
    for (int side = -1; side <= 1; side += 2)
        for (int k = 0; k < nt;) {
            double t = ts[k], q[3];
            for (int a = 0; a < 3; a++)
                q[a] = p[a] + side * t * g[a] / gl;
            double v = field_at(f, q);
            if ((side > 0 && v < 0) || (side < 0 && v > 0)) {
                room = fmin(room, t);
                break;
            }
            /* v is on the walk's own sign (or 0): no step within |v| / slope of t changes it */
            int j = k + 1;
            while (j < nt && slope * (ts[j] - t) < fabs(v))
                j++;
            k = j;
        }
    return room;
}

double gs_field_copy_room(const gs_field *f, const double p[3], int walk_every_step)
{
    double ts[ROOM_STEPS + 1];
    const int nt = room_steps(ts);
    return room_at(f, p, ts, nt, walk_every_step ? INFINITY : field_slope_bound(f));
}

/* Twice the area vector of triangle t of positions pos. */
static void tri_normal(const float *pos, const uint32_t *tr, double n[3])
{
    double e1[3], e2[3];
    for (int a = 0; a < 3; a++) {
        e1[a] = (double)pos[3 * (size_t)tr[1] + a] - pos[3 * (size_t)tr[0] + a];
        e2[a] = (double)pos[3 * (size_t)tr[2] + a] - pos[3 * (size_t)tr[0] + a];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

static int same_point(const float *a, const float *b)
{
    return a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
}

/* Vertex indices ordered by their positions (x, y, z; -0 == +0), then by
 * index: a total order, so the sorted indices are the very order of the
 * (position, index) pairs it replaced (4 bytes a vertex instead of 16; and
 * qsort's own buffer as large). The positions: those of the sort running
 * on this thread (qsort has no context argument in C11). */
static _Thread_local const float *vorder_pos;

static int cmp_vorder(const void *x, const void *y)
{
    const uint32_t a = *(const uint32_t *)x, b = *(const uint32_t *)y;
    const float *pa = vorder_pos + 3 * (size_t)a, *pb = vorder_pos + 3 * (size_t)b;
    for (int k = 0; k < 3; k++)
        if (pa[k] != pb[k])
            return pa[k] < pb[k] ? -1 : 1;
    return a < b ? -1 : a > b;
}

/* Vertices a and b of pos at the very same point (-0 == +0, as bits) */
static int same_bits(const float *pos, uint32_t a, uint32_t b)
{
    float p[3], q[3];
    for (int k = 0; k < 3; k++)
        p[k] = pos[3 * (size_t)a + k] + 0.0f, q[k] = pos[3 * (size_t)b + k] + 0.0f;
    return !memcmp(p, q, sizeof p);
}

/* Moved vertices must not fold the base: a triangle whose normal turned by
 * more than 60 degrees or whose area fell below a hundredth of the base's, and
 * vertices moved onto one another, pull their vertices halfway back, up to
 * 8 times, then all the way; the base itself is valid, so this ends.
 * Returns the number of vertices pulled back in *pulled and flags those
 * pulled all the way in reverted. */
static gs_err unfold(gs_mesh *m, const gs_mesh *base, uint8_t *reverted, int64_t *pulled)
{
    gs_err err = GS_OK;
    uint8_t *bad = NULL, *ever = NULL;
    uint32_t *order = NULL;
    GS_TRY(err, gs_alloc_array((void **)&bad, m->nverts + 1, 1, "unfold flags"), done);
    GS_TRY(err, gs_alloc_array((void **)&ever, m->nverts + 1, 1, "unfold flags"), done);
    GS_TRY(err, gs_alloc_array((void **)&order, m->nverts + 1, sizeof *order, "unfold order"), done);
    for (int round = 0;; round++) {
        memset(bad, 0, m->nverts + 1);
        int64_t nbad = 0;
        for (size_t t = 0; t < m->ntris; t++) {
            const uint32_t *tr = m->tris + 3 * t;
            double nb[3], nn[3];
            tri_normal(base->pos, tr, nb);
            tri_normal(m->pos, tr, nn);
            double dot = nb[0] * nn[0] + nb[1] * nn[1] + nb[2] * nn[2];
            double ab = nb[0] * nb[0] + nb[1] * nb[1] + nb[2] * nb[2];
            double an = nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2];
            /* a triangle degenerate in the base itself (collinear contour
             * points) has no normal to keep: skipped, or it would stay bad
             * after its vertices went all the way back and this never end */
            if (ab > 0 && (dot <= 0.5 * sqrt(ab * an) || an < 0.01 * ab))
                for (int c = 0; c < 3; c++)
                    nbad += !bad[tr[c]], bad[tr[c]] = 1;
        }
        /* vertices at the very same position (once no triangle folds) */
        int64_t folds = nbad;
        for (size_t v = 0; v < m->nverts && folds == 0; v++)
            order[v] = (uint32_t)v;
        if (folds == 0) {
            vorder_pos = m->pos;
            qsort(order, m->nverts, sizeof *order, cmp_vorder);
            vorder_pos = NULL;
        }
        for (size_t i = 1; i < m->nverts && folds == 0; i++)
            if (same_bits(m->pos, order[i - 1], order[i]) &&
                !same_point(base->pos + 3 * (size_t)order[i - 1],
                            base->pos + 3 * (size_t)order[i])) /* (one point in the base: left) */
                for (int q = 0; q < 2; q++)
                    nbad += !bad[order[i - q]], bad[order[i - q]] = 1;
        double keep = round < 8 ? 0.5 : 0.0;
        if (keep == 0) /* only vertices still off the base can be pulled back */
            for (size_t v = 0; v < m->nverts; v++)
                if (bad[v] && same_point(m->pos + 3 * v, base->pos + 3 * v))
                    bad[v] = 0, nbad--; /* (==, not memcmp: a -0 put back reads +0) */
        if (nbad == 0)
            break;
        for (size_t v = 0; v < m->nverts; v++)
            if (bad[v]) {
                ever[v] = 1;
                reverted[v] |= keep == 0;
                for (int a = 0; a < 3; a++)
                    m->pos[3 * v + a] = (float)(base->pos[3 * v + a] +
                                                keep * ((double)m->pos[3 * v + a] - base->pos[3 * v + a]));
            }
    }
    *pulled = 0;
    for (size_t v = 0; v < m->nverts; v++)
        *pulled += ever[v];
done:
    gs_free(bad);
    gs_free(ever);
    gs_free(order);
    return err;
}

/* gs_field_copy_geometry; take: the copy's triangles are base's own
 * (borrowed during the work, base->tris moved into *out on success). */
static gs_err copy_geometry(const gs_mesh *src_mesh, const int64_t sn[3], copy_prov prov,
                            const gs_field *target, const gs_mesh *base, int take, double snap,
                            int relax, gs_mesh *out, gs_field_copy_stats *st)
{
    const int64_t tn[3] = {target->nx, target->ny, target->nz};
    int64_t ns = sn[0] * sn[1] * sn[2];
    size_t T = src_mesh->ntris;
    gs_err err = GS_OK;
    int64_t *start = NULL, *tri_of = NULL, *cell = NULL, *fill = NULL, *cnt = NULL;
    uint32_t *slot = NULL;
    double *acc = NULL;
    uint8_t *seam = NULL, *copied_flag = NULL;
    gs_mesh m;
    memset(&m, 0, sizeof m);
    gs_field_copy_stats stats;
    memset(&stats, 0, sizeof stats);
    /* bucket source triangles by the source sample nearest their centroid */
    GS_TRY(err, gs_alloc_array((void **)&start, (size_t)ns + 1, sizeof *start, "triangle buckets"), done);
    GS_TRY(err, gs_alloc_array((void **)&fill, (size_t)ns + 1, sizeof *fill, "triangle buckets"), done);
    GS_TRY(err, gs_alloc_array((void **)&tri_of, T + 1, sizeof *tri_of, "triangle buckets"), done);
    GS_TRY(err, gs_alloc_array((void **)&cell, T + 1, sizeof *cell, "triangle cells"), done);
    for (size_t t = 0; t < T; t++) {
        int64_t c[3];
        int outside = 0;
        for (int a = 0; a < 3; a++) {
            double s = 0;
            for (int k = 0; k < 3; k++) {
                double x = src_mesh->pos[3 * src_mesh->tris[3 * t + k] + a];
                outside |= x < -1e-3 || x > (double)(sn[a] - 1) + 1e-3;
                s += x;
            }
            c[a] = (int64_t)llround(s / 3);
        }
        /* triangles reaching out of the source box close a contour there:
         * not part of the example's surface inside a target */
        cell[t] = -1;
        if (outside)
            continue;
        cell[t] = c[0] + sn[0] * (c[1] + sn[1] * c[2]);
        start[cell[t] + 1]++;
    }
    for (int64_t i = 0; i < ns; i++)
        start[i + 1] += start[i];
    for (size_t t = 0; t < T; t++)
        if (cell[t] >= 0)
            tri_of[start[cell[t]] + fill[cell[t]]++] = (int64_t)t;
    copy_src cs = {src_mesh, {sn[0], sn[1], sn[2]}, start, tri_of};
    /* the base's connectivity (one welded, manifold sheet); each vertex
     * takes, for each of the 8 samples around it, the point of the source
     * surface that sample's copy puts nearest, blended trilinearly */
    if (take) {
        m.nverts = base->nverts, m.ntris = base->ntris;
        GS_TRY(err, gs_alloc_array((void **)&m.pos, 3 * m.nverts + 3, sizeof *m.pos, "copied mesh"),
               done);
        m.tris = base->tris;
    } else {
        GS_TRY(err, gs_mesh_alloc(&m, base->nverts, base->ntris, 0), done);
        memcpy(m.tris, base->tris, 3 * base->ntris * sizeof *m.tris);
    }
    GS_TRY(err, gs_alloc_array((void **)&seam, m.nverts + 1, 1, "seam flags"), done);
    GS_TRY(err, gs_alloc_array((void **)&copied_flag, m.nverts + 1, 1, "copy flags"), done);
    for (size_t v = 0; v < m.nverts; v++) {
        double p[3], acc3[3] = {0, 0, 0}, wsum = 0;
        int64_t c0[3];
        double fr[3];
        for (int a = 0; a < 3; a++) {
            p[a] = base->pos[3 * v + a];
            double fl = floor(p[a]);
            fl = fl < 0 ? 0 : fl > (double)(tn[a] - 2) ? (double)(tn[a] - 2) : fl;
            c0[a] = (int64_t)fl;
            fr[a] = fmin(fmax(p[a] - fl, 0), 1);
        }
        /* candidates of the distinct offsets so far (mostly one) */
        int64_t seen_off[8][3];
        double seen_cand[8][3];
        int nseen = 0;
        int64_t off0[3] = {0, 0, 0};
        int first = 1, mixed = 0, copied = 0, in_box = 1;
        for (int a = 0; a < 3; a++)
            in_box &= p[a] >= 1 && p[a] <= (double)(tn[a] - 2);
        for (int corner = 0; corner < 8 && in_box; corner++) {
            int64_t t[3];
            double w = 1;
            for (int a = 0; a < 3; a++) {
                int hi = (corner >> a) & 1;
                t[a] = c0[a] + hi;
                if (t[a] >= tn[a])
                    t[a] = tn[a] - 1;
                w *= hi ? fr[a] : 1 - fr[a];
            }
            int64_t ti = t[0] + tn[0] * (t[1] + tn[1] * t[2]);
            double cand[3] = {p[0], p[1], p[2]};
            const int64_t s = copy_prov_at(&prov, ti);
            if (s >= 0 && s < ns) {
                int64_t o[3] = {t[0] - s % sn[0], t[1] - s / sn[0] % sn[1], t[2] - s / (sn[0] * sn[1])};
                if (first)
                    memcpy(off0, o, sizeof o), first = 0;
                else if (o[0] != off0[0] || o[1] != off0[1] || o[2] != off0[2])
                    mixed = 1;
                int k = 0;
                while (k < nseen && memcmp(seen_off[k], o, sizeof o))
                    k++;
                if (k == nseen) {
                    double q[3] = {p[0] - (double)o[0], p[1] - (double)o[1], p[2] - (double)o[2]}, r[3];
                    if (snap_to_source(&cs, q, snap, r)) {
                        for (int a = 0; a < 3; a++)
                            cand[a] = r[a] + (double)o[a];
                        copied = 1;
                    }
                    memcpy(seen_off[k], o, sizeof o);
                    memcpy(seen_cand[k], cand, sizeof cand);
                    nseen++;
                }
                memcpy(cand, seen_cand[k], sizeof cand);
            } else {
                mixed = 1;
            }
            for (int a = 0; a < 3; a++)
                acc3[a] += w * cand[a];
            wsum += w;
        }
        for (int a = 0; a < 3; a++)
            m.pos[3 * v + a] = (float)(wsum > 0 ? acc3[a] / wsum : p[a]);
        seam[v] = (uint8_t)mixed;
        copied_flag[v] = (uint8_t)copied;
        stats.seam_vertices += mixed;
    }
    /* the provenance is read: a packed one (consumed) freed before the
     * relaxation's, the room's and the unfolding's arrays */
    if (prov.packed)
        gs_field_prov_destroy(prov.packed);
    /* the paper's mesh relaxation: Laplacian (weight 0.5) of the seam
     * vertices; sums kept for the seam vertices only (slot: their index
     * among them), added in the same order as over every vertex */
    if (relax > 0 && stats.seam_vertices > 0) {
        size_t ns_v = (size_t)stats.seam_vertices, k = 0;
        GS_TRY(err, gs_alloc_array((void **)&slot, m.nverts + 1, sizeof *slot, "relaxation"), done);
        for (size_t v = 0; v < m.nverts; v++)
            slot[v] = seam[v] ? (uint32_t)k++ : UINT32_MAX;
        GS_TRY(err, gs_alloc_array((void **)&cnt, ns_v, sizeof *cnt, "relaxation"), done);
        GS_TRY(err, gs_alloc_array((void **)&acc, 3 * ns_v, sizeof *acc, "relaxation"), done);
    }
    for (int it = 0; it < relax && slot; it++) {
        memset(acc, 0, 3 * (size_t)stats.seam_vertices * sizeof *acc);
        memset(cnt, 0, (size_t)stats.seam_vertices * sizeof *cnt);
        for (size_t t = 0; t < m.ntris; t++)
            for (int c = 0; c < 3; c++) {
                uint32_t a = m.tris[3 * t + c], b = m.tris[3 * t + (c + 1) % 3];
                uint32_t sa = slot[a], sb = slot[b];
                if (sa == UINT32_MAX && sb == UINT32_MAX)
                    continue;
                for (int q = 0; q < 3; q++) {
                    if (sa != UINT32_MAX)
                        acc[3 * (size_t)sa + q] += m.pos[3 * b + q];
                    if (sb != UINT32_MAX)
                        acc[3 * (size_t)sb + q] += m.pos[3 * a + q];
                }
                if (sa != UINT32_MAX)
                    cnt[sa]++;
                if (sb != UINT32_MAX)
                    cnt[sb]++;
            }
        for (size_t v = 0; v < m.nverts; v++) {
            uint32_t sv = slot[v];
            if (sv != UINT32_MAX && cnt[sv] > 0)
                for (int q = 0; q < 3; q++)
                    m.pos[3 * v + q] = (float)(0.5 * m.pos[3 * v + q] +
                                               0.5 * acc[3 * (size_t)sv + q] / (double)cnt[sv]);
        }
    }
    /* the buckets and sums are done with: freed before unfold's own arrays */
    gs_free(slot), gs_free(cnt), gs_free(acc), gs_free(start), gs_free(fill), gs_free(tri_of),
        gs_free(cell);
    slot = NULL, cnt = NULL, acc = NULL, start = fill = tri_of = cell = NULL;
    /* no vertex moves more than 0.45 of the room to the next sheet of the
     * synthesized field: two facing sheets cannot pass through each other */
    double ts[ROOM_STEPS + 1];
    const int nt = room_steps(ts);
    const double slope = field_slope_bound(target);
    for (size_t v = 0; v < m.nverts; v++) {
        double p[3], d = 0;
        for (int a = 0; a < 3; a++) {
            p[a] = base->pos[3 * v + a];
            d += ((double)m.pos[3 * v + a] - p[a]) * ((double)m.pos[3 * v + a] - p[a]);
        }
        if (d == 0)
            continue;
        double lim = 0.45 * room_at(target, p, ts, nt, slope);
        d = sqrt(d);
        if (d > lim)
            for (int a = 0; a < 3; a++)
                m.pos[3 * v + a] = (float)(p[a] + (lim / d) * ((double)m.pos[3 * v + a] - p[a]));
    }
    uint8_t *reverted = seam; /* no longer needed as seam flags */
    memset(reverted, 0, m.nverts + 1);
    GS_TRY(err, unfold(&m, base, reverted, &stats.pulled_back), done);
    stats.copied_vertices = 0;
    stats.mean_shift = 0;
    for (size_t v = 0; v < m.nverts; v++) {
        double d = 0;
        for (int a = 0; a < 3; a++)
            d += ((double)m.pos[3 * v + a] - base->pos[3 * v + a]) *
                 ((double)m.pos[3 * v + a] - base->pos[3 * v + a]);
        stats.copied_vertices += copied_flag[v] && !reverted[v];
        stats.mean_shift += sqrt(d);
    }
    if (m.nverts)
        stats.mean_shift /= (double)m.nverts;
    if (st)
        *st = stats;
    *out = m;
    memset(&m, 0, sizeof m);
done:
    if (take)
        m.tris = NULL; /* base's, still */
    gs_mesh_destroy(&m);
    gs_free(slot);
    gs_free(start);
    gs_free(fill);
    gs_free(tri_of);
    gs_free(cell);
    gs_free(cnt);
    gs_free(acc);
    gs_free(seam);
    gs_free(copied_flag);
    return err;
}

gs_err gs_field_copy_geometry(const gs_mesh *src_mesh, const int64_t sn[3], const int32_t *prov,
                              const gs_field *target, const gs_mesh *base, double snap, int relax,
                              gs_mesh *out, gs_field_copy_stats *st)
{
    return copy_geometry(src_mesh, sn, (copy_prov){prov, NULL}, target, base, 0, snap, relax, out,
                         st);
}

gs_err gs_field_copy_geometry_consume(const gs_mesh *src_mesh, const int64_t sn[3],
                                      gs_field_prov *prov, const gs_field *target, gs_mesh *base,
                                      double snap, int relax, gs_mesh *out,
                                      gs_field_copy_stats *st)
{
    gs_err err = copy_geometry(src_mesh, sn, (copy_prov){NULL, prov}, target, base, 1, snap, relax,
                               out, st);
    gs_field_prov_destroy(prov);
    GS_CALL(err);
    base->tris = NULL; /* now out's */
    gs_mesh_destroy(base);
    return GS_OK;
}

/* ------------------------------------------------------ height map out */

void gs_field_surface_heights(const gs_field *f, double *h)
{
    int64_t nx = f->nx, ny = f->ny, nz = f->nz;
    size_t st = (size_t)(nx * ny);
    for (int64_t y = 0; y < ny; y++)
        for (int64_t x = 0; x < nx; x++) {
            /* the highest sign change from inside (< 0) below to outside above */
            const float *col = f->v + x + nx * y;
            double z = col[(size_t)(nz - 1) * st] < 0 ? (double)(nz - 1) : 0;
            for (int64_t k = nz - 2; k >= 0; k--) {
                double lo = col[(size_t)k * st], hi = col[(size_t)(k + 1) * st];
                if (lo < 0 && hi >= 0) {
                    z = (double)k + lo / (lo - hi);
                    break;
                }
            }
            h[x + nx * y] = z;
        }
}

gs_err gs_field_write_heightmap(const gs_field *f, double base, double height, const char *path)
{
    GS_CHECK(height > 0 && f->nx <= 65535 && f->ny <= 65535, GS_ERR_ARG,
             "%s: height map of %lldx%lld columns, relief %g: expected relief > 0", path,
             (long long)f->nx, (long long)f->ny, height);
    int64_t nx = f->nx, ny = f->ny;
    float *grey = NULL;
    double *h = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&grey, (size_t)(nx * ny), sizeof *grey, "height map"), done);
    GS_TRY(err, gs_alloc_array((void **)&h, (size_t)(nx * ny), sizeof *h, "height map"), done);
    gs_field_surface_heights(f, h);
    /* image row 0 is the top: largest y (as gs_field_from_heightmap reads it) */
    for (int64_t y = 0; y < ny; y++)
        for (int64_t x = 0; x < nx; x++)
            grey[x + nx * (ny - 1 - y)] = (float)((h[x + nx * y] - base) / height);
    gs_image img;
    GS_TRY(err, gs_image_from_gray((int)nx, (int)ny, grey, 0.0f, 1.0f, 16, &img), done);
    err = gs_image_write_png(path, &img);
    gs_image_destroy(&img);
done:
    gs_free(grey);
    gs_free(h);
    return err;
}
