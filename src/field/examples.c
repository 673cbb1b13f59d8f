/* Built-in example generators of the field engine; see
 * include/geosynth/field_examples.h. grid, chainmail and spheres come from
 * the core's analytic shapes (src/field/shapes.c); balls and fibers are
 * built here because the paper's versions differ from the core's test
 * shapes (dropped balls never overlap; fibers are long perturbed tubes);
 * chainmail_jittered is chainmail with every ring its own (not periodic). */
#include <math.h>
#include <string.h>

#include "geosynth/field_examples.h"
#include "geosynth/mem.h"
#include "geosynth/rng.h"
#include "geosynth/vdb.h"
#include "field/field_impl.h"

#define EXAMPLE_STREAM 0x455841u /* gs_rng domain "EXA" */

typedef struct drop_ball {
    double c[3], r;
} drop_ball;

/* Takes the minimum of f and the sphere distance over the ball's band box. */
static void splat_ball(gs_field *f, const drop_ball *b)
{
    int64_t n = f->nx, lo[3], hi[3];
    double ext = b->r + GS_EXAMPLE_BAND;
    for (int a = 0; a < 3; a++) {
        lo[a] = (int64_t)floor(b->c[a] - ext);
        hi[a] = (int64_t)ceil(b->c[a] + ext);
        lo[a] = lo[a] < 0 ? 0 : lo[a];
        hi[a] = hi[a] > n - 1 ? n - 1 : hi[a];
    }
    for (int64_t z = lo[2]; z <= hi[2]; z++)
        for (int64_t y = lo[1]; y <= hi[1]; y++)
            for (int64_t x = lo[0]; x <= hi[0]; x++) {
                double dx = (double)x - b->c[0], dy = (double)y - b->c[1], dz = (double)z - b->c[2];
                float d = (float)(sqrt(dx * dx + dy * dy + dz * dz) - b->r);
                float *v = &f->v[x + n * (y + n * z)];
                if (d < *v)
                    *v = d;
            }
}

/* Ballistic deposition: each ball falls straight down at a random (x, y)
 * and stops at the highest contact (floor or another ball), so balls never
 * overlap; stops after 400 consecutive drops that would stick out of the
 * top. O(balls^2) contact tests (about 600 balls at n = 64). */
static gs_err make_balls(gs_field *f, gs_rng *r)
{
    double N = (double)f->nx;
    size_t cap = (size_t)(N * N * N / 40.0) + 16, nb = 0;
    drop_ball *b = NULL;
    GS_CALL(gs_alloc_array((void **)&b, cap, sizeof *b, "dropped balls"));
    int misses = 0;
    while (misses < 400 && nb < cap) {
        drop_ball d;
        d.r = 3.0 + 2.0 * gs_rng_uniform(r);
        d.c[0] = d.r + (N - 1 - 2 * d.r) * gs_rng_uniform(r);
        d.c[1] = d.r + (N - 1 - 2 * d.r) * gs_rng_uniform(r);
        d.c[2] = d.r; /* the floor */
        for (size_t i = 0; i < nb; i++) {
            double dx = d.c[0] - b[i].c[0], dy = d.c[1] - b[i].c[1], rr = d.r + b[i].r;
            double h2 = dx * dx + dy * dy;
            if (h2 < rr * rr) {
                double z = b[i].c[2] + sqrt(rr * rr - h2);
                if (z > d.c[2])
                    d.c[2] = z;
            }
        }
        if (d.c[2] + d.r > N - 1) {
            misses++;
            continue;
        }
        misses = 0;
        b[nb++] = d;
    }
    for (size_t i = 0; i < nb; i++)
        splat_ball(f, &b[i]);
    gs_free(b);
    return GS_OK;
}

/* Fibers along x through a jittered (y, z) lattice of period 9: centre
 * (y0 + a sin(2 pi x / w + p), z0 + a' cos(2 pi x / w' + p')), radius
 * r (1 + 0.15 sin(2 pi x / w'' + p'')). The distance is measured in the
 * x = const plane (exact up to the fibers' small slope). */
static gs_err make_fibers(gs_field *f, gs_rng *r)
{
    int64_t n = f->nx;
    const double P = 9.0;
    int64_t cells = n / 9 + 2;
    for (int64_t cz = -1; cz < cells; cz++)
        for (int64_t cy = -1; cy < cells; cy++) {
            double y0 = (double)cy * P + P / 2 + 2.0 * (gs_rng_uniform(r) - 0.5);
            double z0 = (double)cz * P + P / 2 + 2.0 * (gs_rng_uniform(r) - 0.5);
            double rad = 1.4 + 1.0 * gs_rng_uniform(r);
            double ay = 0.5 + 1.5 * gs_rng_uniform(r), az = 0.5 + 1.5 * gs_rng_uniform(r);
            double wy = (double)n * (0.4 + 0.8 * gs_rng_uniform(r)),
                   wz = (double)n * (0.4 + 0.8 * gs_rng_uniform(r)),
                   wr = (double)n * (0.2 + 0.4 * gs_rng_uniform(r));
            double py = 6.283185307179586 * gs_rng_uniform(r), pz = 6.283185307179586 * gs_rng_uniform(r),
                   pr = 6.283185307179586 * gs_rng_uniform(r);
            for (int64_t x = 0; x < n; x++) {
                double t = (double)x * 6.283185307179586;
                double cyx = y0 + ay * sin(t / wy + py), czx = z0 + az * cos(t / wz + pz);
                double rx = rad * (1.0 + 0.15 * sin(t / wr + pr));
                double ext = rx + GS_EXAMPLE_BAND;
                int64_t ylo = (int64_t)floor(cyx - ext), yhi = (int64_t)ceil(cyx + ext);
                int64_t zlo = (int64_t)floor(czx - ext), zhi = (int64_t)ceil(czx + ext);
                ylo = ylo < 0 ? 0 : ylo, zlo = zlo < 0 ? 0 : zlo;
                yhi = yhi > n - 1 ? n - 1 : yhi, zhi = zhi > n - 1 ? n - 1 : zhi;
                for (int64_t z = zlo; z <= zhi; z++)
                    for (int64_t y = ylo; y <= yhi; y++) {
                        double dy = (double)y - cyx, dz = (double)z - czx;
                        float d = (float)(sqrt(dy * dy + dz * dz) - rx);
                        float *v = &f->v[x + n * (y + n * z)];
                        if (d < *v)
                            *v = d;
                    }
            }
        }
    return GS_OK;
}

/* chainmail (src/field/shapes.c: period 12, rings R 4.5 r 1.3 with axes
 * alternating between x and y, linking rings R 3.6 about z half a period on
 * along x) with every ring jittered: centre +-0.6 along each axis, major
 * radius x 0.88..1.12, minor radius 1.15..1.45, drawn per ring. */
static gs_err make_chainmail_jittered(gs_field *f, gs_rng *r)
{
    const double P = 12.0, R = 4.5, R2 = 3.6;
    int64_t n = f->nx, m = n / 12 + 3; /* ring cells -1 .. n / 12 + 1 per axis */
    size_t rings = (size_t)(m * m * m) * 2;
    double(*jit)[5] = NULL; /* per ring: centre shift x y z, major scale, minor radius */
    GS_CALL(gs_alloc_array((void **)&jit, rings, sizeof *jit, "ring jitter"));
    for (size_t i = 0; i < rings; i++) {
        for (int a = 0; a < 3; a++)
            jit[i][a] = 1.2 * (gs_rng_uniform(r) - 0.5);
        jit[i][3] = 0.88 + 0.24 * gs_rng_uniform(r);
        jit[i][4] = 1.15 + 0.30 * gs_rng_uniform(r);
    }
    for (int64_t z = 0; z < n; z++)
        for (int64_t y = 0; y < n; y++)
            for (int64_t x = 0; x < n; x++) {
                double p[3] = {(double)x, (double)y, (double)z}, d = GS_EXAMPLE_BAND;
                int64_t i0 = (int64_t)floor(p[0] / P), j0 = (int64_t)floor(p[1] / P),
                        k0 = (int64_t)floor(p[2] / P);
                for (int64_t k = k0 - 1; k <= k0 + 1; k++)
                    for (int64_t j = j0 - 1; j <= j0 + 1; j++)
                        for (int64_t i = i0 - 1; i <= i0 + 1; i++) {
                            if (i < -1 || j < -1 || k < -1 || i > m - 2 || j > m - 2 || k > m - 2)
                                continue;
                            size_t id = (size_t)((i + 1) + m * ((j + 1) + m * (k + 1))) * 2;
                            int axis = (int)(((i + j + k) % 2 + 2) % 2);
                            const double *a = jit[id], *b = jit[id + 1];
                            double c[3] = {(double)i * P + P / 2 + a[0], (double)j * P + P / 2 + a[1],
                                           (double)k * P + P / 2 + a[2]};
                            double c2[3] = {(double)i * P + P + b[0], (double)j * P + P / 2 + b[1],
                                            (double)k * P + P / 2 + b[2]};
                            double e = gs_field_dist_torus(p, c, axis, R * a[3], a[4]);
                            double e2 = gs_field_dist_torus(p, c2, 2, R2 * b[3], b[4]);
                            e = e2 < e ? e2 : e;
                            d = e < d ? e : d;
                        }
                f->v[x + n * (y + n * z)] = (float)d;
            }
    gs_free(jit);
    return GS_OK;
}

gs_err gs_field_example_make(const char *kind, int64_t n, uint64_t seed, gs_field **out)
{
    GS_CHECK(n >= 8 && n <= 1024, GS_ERR_ARG, "example size %lld: expected 8..1024 samples",
             (long long)n);
    gs_field_shape shape;
    if (!strcmp(kind, "grid"))
        shape = GS_FIELD_GRID;
    else if (!strcmp(kind, "chainmail"))
        shape = GS_FIELD_CHAINMAIL;
    else if (!strcmp(kind, "spheres"))
        shape = GS_FIELD_SPHERES;
    else if (!strcmp(kind, "balls") || !strcmp(kind, "fibers") ||
             !strcmp(kind, "chainmail_jittered"))
        shape = (gs_field_shape)-1;
    else
        GS_RAISE(GS_ERR_ARG, "example kind '%s': expected one of %s", kind, GS_EXAMPLE_KINDS);
    gs_field *f = NULL;
    if (shape != (gs_field_shape)-1) {
        GS_CALL(gs_field_make_shape(shape, n, seed, &f));
        /* same band convention as the generators below */
        for (int64_t i = 0; i < n * n * n; i++)
            if (f->v[i] > GS_EXAMPLE_BAND)
                f->v[i] = (float)GS_EXAMPLE_BAND;
        *out = f;
        return GS_OK;
    }
    GS_CALL(gs_field_create(n, n, n, &f));
    for (int64_t i = 0; i < n * n * n; i++)
        f->v[i] = (float)GS_EXAMPLE_BAND;
    gs_rng r;
    uint64_t which = kind[0] == 'b' ? 1 : kind[0] == 'f' ? 2 : 3;
    gs_rng_init(&r, seed, gs_rng_stream_id(EXAMPLE_STREAM, which, (uint64_t)n, 0));
    gs_err err = which == 1 ? make_balls(f, &r) : which == 2 ? make_fibers(f, &r)
                                                             : make_chainmail_jittered(f, &r);
    if (err) {
        gs_field_destroy(&f);
        GS_CALL(err);
    }
    *out = f;
    return GS_OK;
}

gs_err gs_field_example_mesh(const char *kind, int64_t n, uint64_t seed, gs_mesh *out)
{
    gs_field *f = NULL;
    GS_CALL(gs_field_example_make(kind, n, seed, &f));
    /* pad with one outside sample so shapes cut by the box get caps */
    gs_field *p = NULL;
    gs_err err = gs_field_create(n + 2, n + 2, n + 2, &p);
    if (err) {
        gs_field_destroy(&f);
        GS_CALL(err);
    }
    int64_t m = n + 2;
    for (int64_t i = 0; i < m * m * m; i++)
        p->v[i] = 1.0f;
    for (int64_t z = 0; z < n; z++)
        for (int64_t y = 0; y < n; y++)
            memcpy(p->v + 1 + m * (y + 1 + m * (z + 1)), f->v + n * (y + n * z), (size_t)n * sizeof(float));
    gs_field_destroy(&f);
    p->origin[0] = p->origin[1] = p->origin[2] = -1.0;
    err = gs_field_contour(p, 0.0, 0.0, out);
    gs_field_destroy(&p);
    GS_CALL(err);
    return GS_OK;
}
