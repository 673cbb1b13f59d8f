/* Analytic signed distance fields used as test and benchmark sources
 * (the paper's GRID, CHAINMAIL and BALLS examples, made procedurally). */
#include <math.h>

#include "geosynth/field.h"
#include "geosynth/mem.h"
#include "field/field_impl.h"

#define SHAPE_STREAM 0x5348u /* gs_rng domain tag "SH" */

const char *gs_field_shape_name(gs_field_shape kind)
{
    switch (kind) {
    case GS_FIELD_SPHERES: return "spheres";
    case GS_FIELD_GRID: return "grid";
    case GS_FIELD_CHAINMAIL: return "chainmail";
    case GS_FIELD_BALLS: return "balls";
    }
    return "unknown";
}

typedef struct ball { double c[3], r; } ball;

static double dist_balls(const ball *b, int nb, const double p[3])
{
    double d = 1e30;
    for (int i = 0; i < nb; i++) {
        double dx = p[0] - b[i].c[0], dy = p[1] - b[i].c[1], dz = p[2] - b[i].c[2];
        double e = sqrt(dx * dx + dy * dy + dz * dz) - b[i].r;
        if (e < d)
            d = e;
    }
    return d;
}

/* Balls bucketed in cells of BALL_CELL samples by centre. A sample looks at
 * the 27 cells around its own; any other ball has its centre more than
 * BALL_CELL away, so with radii <= 5 its surface is more than 3 away: the
 * field is exact where |d| <= BALL_CAP and clamped to BALL_CAP beyond
 * (quantize BALLS over a range within [-3, 3]). */
#define BALL_CELL 8
#define BALL_CAP 3.0

typedef struct ball_grid {
    int64_t g;          /* cells per axis */
    int64_t *start;     /* g^3 + 1 offsets into items */
    int *items;
} ball_grid;

static int64_t ball_cell_of(double v, int64_t g)
{
    int64_t c = (int64_t)floor(v / BALL_CELL);
    return c < 0 ? 0 : c >= g ? g - 1 : c;
}

static gs_err ball_grid_build(ball_grid *bg, const ball *b, int nb, int64_t n)
{
    bg->g = n / BALL_CELL + 1;
    int64_t cells = bg->g * bg->g * bg->g;
    bg->start = gs_calloc((size_t)cells + 1, sizeof *bg->start);
    bg->items = gs_calloc((size_t)nb + 1, sizeof *bg->items);
    GS_CHECK(bg->start && bg->items, GS_ERR_MEM, "out of memory for the ball grid");
    int64_t *cid = gs_calloc((size_t)nb + 1, sizeof *cid);
    GS_CHECK(cid, GS_ERR_MEM, "out of memory for the ball grid");
    for (int i = 0; i < nb; i++) {
        cid[i] = ball_cell_of(b[i].c[0], bg->g) +
                 bg->g * (ball_cell_of(b[i].c[1], bg->g) + bg->g * ball_cell_of(b[i].c[2], bg->g));
        bg->start[cid[i] + 1]++;
    }
    for (int64_t c = 0; c < cells; c++)
        bg->start[c + 1] += bg->start[c];
    int64_t *fill = gs_calloc((size_t)cells, sizeof *fill);
    GS_CHECK(fill, GS_ERR_MEM, "out of memory for the ball grid");
    for (int i = 0; i < nb; i++)
        bg->items[bg->start[cid[i]] + fill[cid[i]]++] = i;
    gs_free(fill);
    gs_free(cid);
    return GS_OK;
}

static double dist_balls_grid(const ball_grid *bg, const ball *b, const double p[3])
{
    double d = BALL_CAP;
    int64_t c[3];
    for (int a = 0; a < 3; a++)
        c[a] = ball_cell_of(p[a], bg->g);
    for (int64_t z = c[2] - 1; z <= c[2] + 1; z++)
        for (int64_t y = c[1] - 1; y <= c[1] + 1; y++)
            for (int64_t x = c[0] - 1; x <= c[0] + 1; x++) {
                if (x < 0 || y < 0 || z < 0 || x >= bg->g || y >= bg->g || z >= bg->g)
                    continue;
                int64_t cell = x + bg->g * (y + bg->g * z);
                for (int64_t k = bg->start[cell]; k < bg->start[cell + 1]; k++) {
                    const ball *o = &b[bg->items[k]];
                    double dx = p[0] - o->c[0], dy = p[1] - o->c[1], dz = p[2] - o->c[2];
                    double e = sqrt(dx * dx + dy * dy + dz * dz) - o->r;
                    if (e < d)
                        d = e;
                }
            }
    return d;
}

/* Distance to a torus with major radius R, minor r, centre c, axis a (0..2)
 * (src/field/field_impl.h). */
double gs_field_dist_torus(const double p[3], const double c[3], int axis, double R, double r)
{
    double q[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
    double h = q[axis];
    double u = q[(axis + 1) % 3], v = q[(axis + 2) % 3];
    double rho = sqrt(u * u + v * v) - R;
    return sqrt(rho * rho + h * h) - r;
}

gs_err gs_field_make_shape(gs_field_shape kind, int64_t n, uint64_t seed, gs_field **out)
{
    GS_CHECK(kind >= GS_FIELD_SPHERES && kind <= GS_FIELD_BALLS, GS_ERR_ARG,
             "shape kind %d: expected 0..3 (spheres, grid, chainmail, balls)", (int)kind);
    gs_field *f = NULL;
    GS_CALL(gs_field_create(n, n, n, &f));
    gs_rng rng;
    gs_rng_init(&rng, seed, gs_rng_stream_id(SHAPE_STREAM, (uint64_t)kind, (uint64_t)n, 0));
    double N = (double)n;

    ball *balls = NULL;
    int nb = 0;
    if (kind == GS_FIELD_SPHERES || kind == GS_FIELD_BALLS) {
        int want = kind == GS_FIELD_SPHERES ? 6 : (int)(N * N * N / 1500.0) + 4;
        balls = gs_calloc((size_t)want, sizeof *balls);
        if (!balls) {
            gs_field_destroy(&f);
            GS_RAISE(GS_ERR_MEM, "out of memory for %d balls", want);
        }
        while (nb < want) {
            ball b;
            b.r = kind == GS_FIELD_SPHERES ? N * (0.08 + 0.1 * gs_rng_uniform(&rng))
                                           : 3.0 + 2.0 * gs_rng_uniform(&rng);
            for (int a = 0; a < 3; a++)
                b.c[a] = N * gs_rng_uniform(&rng);
            balls[nb++] = b; /* overlaps allowed: the union is still a distance field */
        }
    }
    ball_grid grid = {0};
    if (kind == GS_FIELD_BALLS) {
        gs_err err = ball_grid_build(&grid, balls, nb, n);
        if (err != GS_OK) {
            gs_free(balls);
            gs_field_destroy(&f);
            GS_CALL(err);
        }
    }
    /* grid: period 16 with per-line jitter; chain mail: period 12 */
    double jit[3][64];
    for (int a = 0; a < 3; a++)
        for (int i = 0; i < 64; i++)
            jit[a][i] = 1.5 * (gs_rng_uniform(&rng) - 0.5);

    for (int64_t z = 0; z < n; z++)
        for (int64_t y = 0; y < n; y++)
            for (int64_t x = 0; x < n; x++) {
                double p[3] = {(double)x, (double)y, (double)z};
                double d = 1e30;
                if (kind == GS_FIELD_BALLS) {
                    d = dist_balls_grid(&grid, balls, p);
                } else if (balls) {
                    d = dist_balls(balls, nb, p);
                } else if (kind == GS_FIELD_GRID) {
                    const double P = 16.0, rc = 2.2, rb = 4.0;
                    int64_t cell[3];
                    double loc[3];
                    for (int a = 0; a < 3; a++) {
                        cell[a] = (int64_t)floor((p[a] + P / 2) / P);
                        loc[a] = p[a] - (double)cell[a] * P;
                    }
                    /* a cylinder along axis a passes through the line (j_b, j_c) of the lattice */
                    for (int a = 0; a < 3; a++) {
                        int b = (a + 1) % 3, c = (a + 2) % 3;
                        double ub = loc[b] - jit[a][(cell[b] * 7 + cell[c] * 3) & 63];
                        double uc = loc[c] - jit[a][(cell[b] * 5 + cell[c] * 11 + 1) & 63];
                        double e = sqrt(ub * ub + uc * uc) - rc;
                        if (e < d)
                            d = e;
                    }
                    double bx = loc[0], by = loc[1], bz = loc[2];
                    double e = sqrt(bx * bx + by * by + bz * bz) - rb;
                    if (e < d)
                        d = e;
                } else { /* chain mail: tori with axes alternating along x and y rows */
                    const double P = 12.0, R = 4.5, r = 1.3;
                    int64_t i0 = (int64_t)floor(p[0] / P), j0 = (int64_t)floor(p[1] / P),
                            k0 = (int64_t)floor(p[2] / P);
                    for (int64_t k = k0 - 1; k <= k0 + 1; k++)
                        for (int64_t j = j0 - 1; j <= j0 + 1; j++)
                            for (int64_t i = i0 - 1; i <= i0 + 1; i++) {
                                double c[3] = {i * P + P / 2, j * P + P / 2, k * P + P / 2};
                                int axis = (int)(((i + j + k) % 2 + 2) % 2); /* 0 or 1 */
                                double e = gs_field_dist_torus(p, c, axis, R, r);
                                /* linking tori between neighbours along x */
                                double c2[3] = {c[0] + P / 2, c[1], c[2]};
                                double e2 = gs_field_dist_torus(p, c2, 2, R * 0.8, r);
                                if (e2 < e)
                                    e = e2;
                                if (e < d)
                                    d = e;
                            }
                }
                f->v[x + n * (y + n * z)] = (float)d;
            }
    gs_free(balls);
    gs_free(grid.start);
    gs_free(grid.items);
    *out = f;
    return GS_OK;
}
