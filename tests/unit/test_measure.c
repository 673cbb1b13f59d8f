/* Unit tests for the shared quality measures (src/measure/stats.c, src/io/preview.c):
 * L1 of distributions, two-sample KS against hand-computed values,
 * connected components against a brute-force flood fill, the preview's
 * panel layout, and fast-marching geodesics / interface distances against
 * closed forms (src/measure/geodesic.c). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/error.h"
#include "geosynth/image.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/preview.h"
#include "geosynth/rng.h"

static void test_l1(void **state)
{
    (void)state;
    const double a[] = {1, 1, 0}, b[] = {2, 2, 0}, c[] = {0, 0, 5}, z[] = {0, 0, 0};
    assert_true(fabs(gs_measure_l1(a, b, 3)) < 1e-12);
    assert_true(fabs(gs_measure_l1(a, c, 3) - 2) < 1e-12);
    assert_true(fabs(gs_measure_l1(z, z, 3)) < 1e-12);
    assert_true(fabs(gs_measure_l1(a, z, 3) - 2) < 1e-12);
    const double d[] = {3, 1, 0}; /* 0.75 0.25 vs 0.5 0.5 */
    assert_true(fabs(gs_measure_l1(d, a, 3) - 0.5) < 1e-12);
}

static void test_ks(void **state)
{
    (void)state;
    double d;
    const double x[] = {1, 2, 3, 4}, y[] = {1, 2, 3, 4};
    assert_int_equal(gs_measure_ks(x, 4, y, 4, &d), GS_OK);
    assert_true(d < 1e-12);
    const double lo[] = {0, 1}, hi[] = {5, 6, 7};
    assert_int_equal(gs_measure_ks(lo, 2, hi, 3, &d), GS_OK);
    assert_true(fabs(d - 1) < 1e-12);
    /* x = {1,2,3,4}, w = {3,4,5,6}: F_x(2) = 0.5, F_w(2) = 0, the sup is 0.5. */
    const double w[] = {3, 4, 5, 6};
    assert_int_equal(gs_measure_ks(x, 4, w, 4, &d), GS_OK);
    assert_true(fabs(d - 0.5) < 1e-12);
    const double withnan[] = {1, NAN, 2, 3, 4};
    assert_int_equal(gs_measure_ks(withnan, 5, y, 4, &d), GS_OK);
    assert_true(d < 1e-12);
    assert_int_equal(gs_measure_ks(x, 0, y, 0, &d), GS_OK);
    assert_true(d == 0);
    assert_int_equal(gs_measure_ks(x, 4, y, 0, &d), GS_OK);
    assert_true(d == 1);
}

/* Recursive-free reference: repeated relaxation of labels to the minimum
 * over face neighbours until nothing changes. */
static void reference_components(const uint8_t *m, int nx, int ny, int nz, const int per[3],
                                 uint32_t *lab)
{
    size_t n = (size_t)nx * ny * nz;
    for (size_t i = 0; i < n; i++)
        lab[i] = m[i] ? (uint32_t)i + 1 : 0;
    int changed = 1;
    const int dims[3] = {nx, ny, nz};
    while (changed) {
        changed = 0;
        for (size_t i = 0; i < n; i++) {
            if (!m[i])
                continue;
            int p[3] = {(int)(i % nx), (int)((i / nx) % ny), (int)(i / ((size_t)nx * ny))};
            for (int k = 0; k < 3; k++)
                for (int d = -1; d <= 1; d += 2) {
                    int q[3] = {p[0], p[1], p[2]};
                    q[k] += d;
                    if (q[k] < 0 || q[k] >= dims[k]) {
                        if (!per[k])
                            continue;
                        q[k] = (q[k] + dims[k]) % dims[k];
                    }
                    size_t j = q[0] + (size_t)nx * (q[1] + (size_t)ny * q[2]);
                    if (m[j] && lab[j] < lab[i]) {
                        lab[i] = lab[j];
                        changed = 1;
                    }
                }
        }
    }
}

static void test_components(void **state)
{
    (void)state;
    gs_rng rng;
    gs_rng_init(&rng, 7, 1);
    for (int trial = 0; trial < 40; trial++) {
        int nx = 1 + (int)gs_rng_below(&rng, 9), ny = 1 + (int)gs_rng_below(&rng, 9),
            nz = 1 + (int)gs_rng_below(&rng, 9);
        int per[3] = {trial & 1, (trial >> 1) & 1, (trial >> 2) & 1};
        size_t n = (size_t)nx * ny * nz;
        uint8_t *m = malloc(n);
        uint32_t *lab = malloc(n * 4), *ref = malloc(n * 4);
        for (size_t i = 0; i < n; i++)
            m[i] = gs_rng_uniform(&rng) < 0.45;
        uint32_t nc;
        uint64_t *sizes;
        assert_int_equal(gs_measure_components3(m, nx, ny, nz, per, lab, &nc, &sizes), GS_OK);
        reference_components(m, nx, ny, nz, per, ref);
        /* Same partition: cells share a label iff they share a reference label. */
        uint64_t total = 0;
        for (uint32_t c = 1; c <= nc; c++)
            total += sizes[c];
        size_t set = 0;
        for (size_t i = 0; i < n; i++) {
            set += m[i] != 0;
            assert_true((lab[i] == 0) == (m[i] == 0));
            for (size_t j = i + 1; j < n && j < i + 40; j++)
                if (m[i] && m[j])
                    assert_true((lab[i] == lab[j]) == (ref[i] == ref[j]));
        }
        assert_int_equal(total, set);
        gs_free(sizes);
        free(m), free(lab), free(ref);
    }
    uint8_t m1[4] = {1, 0, 0, 1};
    uint32_t l1[4], nc;
    int per[3] = {1, 0, 0}, none[3] = {0, 0, 0};
    assert_int_equal(gs_measure_components3(m1, 4, 1, 1, none, l1, &nc, NULL), GS_OK);
    assert_int_equal(nc, 2);
    assert_int_equal(gs_measure_components3(m1, 4, 1, 1, per, l1, &nc, NULL), GS_OK);
    assert_int_equal(nc, 1);
}

/* Euler characteristics of 6-connected components: a solid block 1, a
 * square ring 0 (one handle), a block with a tunnel through 0, a ring cut
 * open (an arc) 1, two rings sharing a side -1, a hollow box (a cavity) 2,
 * two cells touching only at an edge are two components of 1. */
static void test_component_euler(void **state)
{
    (void)state;
    enum { N = 24 };
    uint8_t *m = calloc(N * N * N, 1);
    uint32_t *lab = malloc(N * N * N * sizeof *lab), nc;
#define SET(x, y, z) (m[(x) + N * ((y) + N * (z))] = 1)
    for (int z = 1; z < 4; z++) /* a 3x3x3 block */
        for (int y = 1; y < 4; y++)
            for (int x = 1; x < 4; x++)
                SET(x, y, z);
    for (int y = 6; y < 11; y++) /* a square ring in z = 2, 5x5, hole 3x3 */
        for (int x = 1; x < 6; x++)
            if (x == 1 || x == 5 || y == 6 || y == 10)
                SET(x, y, 2);
    for (int y = 13; y < 18; y++) /* an arc: the same ring with one cell left out */
        for (int x = 1; x < 6; x++)
            if ((x == 1 || x == 5 || y == 13 || y == 17) && !(x == 3 && y == 17))
                SET(x, y, 2);
    for (int y = 1; y < 6; y++) /* two rings sharing the side x = 12 (a theta: 2 handles) */
        for (int x = 8; x < 17; x++)
            if (x == 8 || x == 12 || x == 16 || y == 1 || y == 5)
                SET(x, y, 8);
    for (int z = 12; z < 17; z++) /* a hollow 5^3 box (a cavity) */
        for (int y = 12; y < 17; y++)
            for (int x = 12; x < 17; x++)
                if (x == 12 || x == 16 || y == 12 || y == 16 || z == 12 || z == 16)
                    SET(x, y, z);
    for (int z = 1; z < 4; z++) /* a 3x3 slab pierced by a tunnel along z */
        for (int y = 19; y < 22; y++)
            for (int x = 1; x < 4; x++)
                if (!(x == 2 && y == 20))
                    SET(x, y, z);
    SET(20, 2, 2), SET(21, 3, 2); /* edge contact only: two components */
#undef SET
    assert_int_equal(gs_measure_components3(m, N, N, N, NULL, lab, &nc, NULL), GS_OK);
    assert_int_equal(nc, 8);
    int64_t e[9];
    gs_measure_component_euler3(lab, N, N, N, nc, e);
    const int at[8][3] = {{1, 1, 1}, {1, 6, 2}, {1, 13, 2}, {8, 1, 8}, {12, 12, 12}, {1, 19, 1},
                          {20, 2, 2}, {21, 3, 2}};
    const int64_t want[8] = {1, 0, 1, -1, 2, 0, 1, 1};
    for (int k = 0; k < 8; k++)
        assert_int_equal(e[lab[at[k][0] + N * (at[k][1] + N * at[k][2])]], want[k]);
    free(m), free(lab);
}

/* Pieces inside a box: a sheet the box cuts on every side, a speck in the
 * middle, a speck touching the left side, a blob of 40 points inside and
 * points outside the box (not counted, and not linking anything). */
static void test_point_pieces(void **state)
{
    (void)state;
    enum { MAXP = 2000 };
    double *p = malloc(MAXP * 3 * sizeof *p);
    size_t n = 0;
    const double h = 0.1, r = 0.15, lo[2] = {0, 0}, hi[2] = {4, 4};
#define PUT(x, y, z) (p[3 * n] = (x), p[3 * n + 1] = (y), p[3 * n + 2] = (z), n++)
    for (int j = 0; j < 40; j++) /* the sheet z = 0 over y < 1, cut by the box */
        for (int i = -2; i < 42; i++)
            if (j * h < 1.0)
                PUT(i * h, j * h, 0);
    PUT(2.0, 2.0, 0);  /* a speck in the middle */
    PUT(0.05, 2.0, 0); /* a speck the left side cuts */
    for (int k = 0; k < 40; k++) /* a blob of 40 points: one piece, not small */
        PUT(3.0 + (k % 8) * h, 3.0 + (k / 8) * h, 0.5);
    PUT(-1.0, 3.0, 0); /* outside the box */
    PUT(5.0, 2.0, 0);
#undef PUT
    gs_measure_pieces pc;
    assert_int_equal(gs_measure_point_pieces(p, 3, n, r, lo, hi, 30, &pc), GS_OK);
    assert_int_equal(pc.border, 2);   /* the sheet and the speck at x = 0.05 */
    assert_int_equal(pc.pieces, 2);   /* the middle speck and the blob */
    assert_int_equal(pc.small, 1);    /* the middle speck */
    assert_int_equal(pc.small_points, 1);
    /* Minus-sampling: the speck (extent 0) over (4 - 0.3)^2, the blob
     * (0.7 x 0.4) over (4 - 0.7 - 0.3)(4 - 0.4 - 0.3). */
    double ws = 1.0 / (3.7 * 3.7), wb = 1.0 / (3.0 * 3.3);
    assert_true(fabs(pc.small_density - ws) < 1e-9);
    assert_true(fabs(pc.density - ws - wb) < 1e-9);
    double bad_hi[2] = {0, 4};
    assert_int_equal(gs_measure_point_pieces(p, 3, n, r, lo, bad_hi, 30, &pc), GS_ERR_ARG);
    free(p);
}

/* Nearest other point against brute force: random points (stride 6, as the
 * points engine stores xyz + normal) in a box a few radii wide, so some
 * points have no neighbour within the radius (INFINITY), a duplicated point
 * (0), one point alone (INFINITY), and a bad radius refused. */
static void test_point_nearest(void **state)
{
    (void)state;
    enum { N = 700, S = 6 };
    double *p = malloc(N * S * sizeof *p), *d = malloc(N * sizeof *d);
    uint64_t x = 88172645463325252ull;
    for (size_t i = 0; i < N * S; i++) {
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        p[i] = (double)(x >> 11) / 9007199254740992.0 * 2.0 - 0.5;
    }
    memcpy(p + 5 * S, p + 9 * S, 3 * sizeof *p); /* point 5 on point 9 */
    const double radii[] = {0.05, 0.12, 0.3};
    for (size_t t = 0; t < sizeof radii / sizeof radii[0]; t++) {
        double r = radii[t];
        assert_int_equal(gs_measure_point_nearest(p, S, N, r, d), GS_OK);
        size_t none = 0;
        for (size_t i = 0; i < N; i++) {
            double best = INFINITY;
            for (size_t j = 0; j < N; j++) {
                if (j == i)
                    continue;
                double a = p[i * S] - p[j * S], b = p[i * S + 1] - p[j * S + 1],
                       c = p[i * S + 2] - p[j * S + 2], e = sqrt(a * a + b * b + c * c);
                best = e < best ? e : best;
            }
            if (best > r) {
                assert_true(isinf(d[i]));
                none++;
            } else {
                assert_true(fabs(d[i] - best) < 1e-12);
            }
        }
        assert_true(d[5] == 0.0 && d[9] == 0.0);
        if (t == 0)
            assert_true(none > 0); /* the small radius leaves points alone */
    }
    assert_int_equal(gs_measure_point_nearest(p, S, 1, 0.3, d), GS_OK);
    assert_true(isinf(d[0]));
    assert_int_equal(gs_measure_point_nearest(p, S, N, 0.0, d), GS_ERR_ARG);
    assert_int_equal(gs_measure_point_nearest(p, 2, N, 0.1, d), GS_ERR_ARG);
    free(p);
    free(d);
}

/* Seams from patch ids: a plane z = 0 sampled on a grid, split at x = 1 into
 * patches 0 and 1. Patch 1 raised by dz: the seam points see the other
 * patch's surface dz away and the inside sees a plane (0); not raised, the
 * seam is like the inside. Tilting patch 1's normals by 10 degrees gives a
 * 10 degree seam angle. Patch 1 lifted far above (more than the radius):
 * patch 0's surface ends at the seam with none across, every seam point is
 * open (the seam is found in the plane, at any height). */
static void test_point_seams(void **state)
{
    (void)state;
    enum { NX = 40, NY = 20 };
    const double h = 0.05, R = 3 * h, band = 1.5 * h, dz = 0.02;
    double *v = malloc(NX * NY * 6 * sizeof *v);
    int32_t *id = malloc(NX * NY * sizeof *id);
    for (int raise = 0; raise < 4; raise++) {
        size_t n = 0;
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                double *q = v + 6 * n;
                id[n] = i * h < 1.0 ? 0 : 1;
                double a = raise == 2 && id[n] ? 10 * 3.14159265358979323846 / 180 : 0;
                q[0] = i * h;
                q[1] = j * h;
                q[2] = raise == 1 && id[n] ? dz : raise == 3 && id[n] ? 1.0 : 0;
                q[3] = sin(a);
                q[4] = 0;
                q[5] = cos(a);
                n++;
            }
        gs_measure_seams ms;
        assert_int_equal(gs_measure_point_seams(v, n, id, R, band, 0.15, &ms), GS_OK);
        /* One column each side lies within 1.5 h of the other patch. */
        assert_int_equal(ms.seam_points, 2 * NY);
        /* (tilted normals on a flat sampling are no plane: no inside check) */
        assert_true(raise == 2 || (ms.inside_dist < 1e-12 && ms.inside_angle < 1e-5));
        assert_true(ms.inside_fits > 0);
        assert_true(raise == 3 ? ms.seam_open == 1 : ms.seam_open == 0);
        if (raise == 1) {
            assert_true(fabs(ms.seam_dist - dz) < 1e-9);
            assert_true(ms.seam_angle < 1e-5);
        } else if (raise == 2) {
            assert_true(fabs(ms.seam_angle - 10) < 1e-5);
        } else {
            assert_true(ms.seam_dist < 1e-12 && ms.seam_angle < 1e-5);
        }
        /* Broken against a far distance of dz / 2: the raised seam's points
         * all (dz away), the open ones all, a seam like the inside none;
         * against 2 dz the raised seam is whole again, the open one not. */
        gs_measure_seams mf;
        assert_int_equal(gs_measure_point_seams_far(v, n, id, R, band, 0.15, dz / 2, &mf), GS_OK);
        assert_true(mf.far_dist == dz / 2 && mf.seam_points == ms.seam_points);
        assert_true(mf.seam_dist == ms.seam_dist && mf.seam_open == ms.seam_open);
        assert_true(mf.seam_broken == (raise == 1 || raise == 3 ? 1 : 0));
        assert_true(raise == 2 || mf.inside_broken == 0);
        assert_int_equal(gs_measure_point_seams_far(v, n, id, R, band, 0.15, 2 * dz, &mf), GS_OK);
        assert_true(mf.seam_broken == (raise == 3 ? 1 : 0));
    }
    gs_measure_seams ms;
    assert_int_equal(gs_measure_point_seams(v, 10, id, R, 2 * R, 0.15, &ms), GS_ERR_ARG);
    assert_int_equal(gs_measure_point_seams_far(v, 10, id, R, band, 0.15, -1, &ms), GS_ERR_ARG);
    free(v);
    free(id);
}

/* A curved surface (a sphere of radius 2.5 seen from above, jittered
 * samples, one in each grid cell so evenly dense, exact normals: the same
 * curvature everywhere and in every direction) split at x = 1 into two patch ids with nothing changed: the
 * seam scores as the inside (ratios within 10% of 1: the inside reference
 * has the seam's one-sided geometry at its distances); patch 1 raised by a
 * third of the spacing scores clearly above. */
static void test_point_seams_curved(void **state)
{
    (void)state;
    enum { NX = 80, NY = 60 };
    const double h = 0.025, R = 3 * h, band = 1.5 * h, S = 2.5;
    double *v = malloc(NX * NY * 6 * sizeof *v);
    int32_t *id = malloc(NX * NY * sizeof *id);
    for (int raise = 0; raise < 2; raise++) {
        uint64_t r = 12345;
        size_t n = 0;
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                double jit[2];
                for (int a = 0; a < 2; a++) {
                    r = r * 6364136223846793005ULL + 1442695040888963407ULL;
                    jit[a] = ((double)(r >> 11) / 9007199254740992.0 - 0.5) * h;
                }
                double x = i * h + jit[0], y = j * h + jit[1], *q = v + 6 * n;
                double dx = x - 1.0, dy = y - 0.75, z = sqrt(S * S - dx * dx - dy * dy);
                id[n] = x < 1.0 ? 0 : 1;
                q[0] = x;
                q[1] = y;
                q[2] = z + (raise && id[n] ? h / 3 : 0);
                q[3] = dx / S;
                q[4] = dy / S;
                q[5] = z / S;
                n++;
            }
        gs_measure_seams ms;
        assert_int_equal(gs_measure_point_seams(v, n, id, R, band, 0.15, &ms), GS_OK);
        double dr = ms.seam_dist / ms.inside_dist, ar = ms.seam_angle / ms.inside_angle;
        print_message("curved seam, raise %d: dist %g / %g = %.3f, angle %g / %g = %.3f\n", raise,
                      ms.seam_dist, ms.inside_dist, dr, ms.seam_angle, ms.inside_angle, ar);
        assert_true(ms.seam_points > 0 && ms.inside_fits > 0);
        if (raise) {
            assert_true(dr > 2);
        } else {
            assert_true(fabs(dr - 1) < 0.1);
            assert_true(fabs(ar - 1) < 0.1);
        }
    }
    free(v);
    free(id);
}

static void test_preview(void **state)
{
    (void)state;
    /* One triangle panel next to an empty one: the left panel has lit pixels,
     * the right is all background, the gutter is grey. */
    float pos[9] = {0, 0, 0, 1, 0, 0, 0, 0, 1};
    uint32_t tris[3] = {0, 1, 2};
    gs_mesh m = {.nverts = 3, .ntris = 1, .pos = pos, .tris = tris};
    gs_preview_panel p[2] = {{&m, NULL, NULL}, {NULL, NULL, NULL}};
    char dir[] = "/tmp/gs-test-preview-XXXXXX", path[64];
    assert_non_null(mkdtemp(dir));
    snprintf(path, sizeof path, "%s/p.png", dir);
    assert_int_equal(gs_preview_write(path, p, 2, 64), GS_OK);
    gs_image img;
    assert_int_equal(gs_image_read(path, &img), GS_OK);
    assert_int_equal(img.width, 2 * 64 + 4);
    assert_int_equal(img.height, 64);
    size_t lit_left = 0, lit_right = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < img.width; x++) {
            const uint8_t *px = img.data8 + 3 * ((size_t)y * img.width + x);
            int lit = px[0] > 90;
            if (x < 64)
                lit_left += lit;
            else if (x >= 68)
                lit_right += lit;
            else
                assert_int_equal(px[0], 150);
        }
    assert_true(lit_left > 50);
    assert_int_equal(lit_right, 0);
    gs_image_destroy(&img);
    unlink(path);
    rmdir(dir);
    assert_int_equal(gs_preview_write(path, p, 0, 64), GS_ERR_ARG);
    assert_int_equal(gs_preview_write(path, p, 2, 8), GS_ERR_ARG);
    gs_error_clear();
}

static unsigned char *read_all(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    *n = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc(*n);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, *n, f), *n);
    fclose(f);
    return b;
}

/* A panel given as `turn` (the field's contour: turned y-up in place, no
 * copy) draws the same bytes as one drawn from a y-up copy, and its mesh
 * is left exactly as it was, normals included. The mesh is lopsided (a
 * pyramid leaning towards +y and +z, -0 coordinates included), so a wrong
 * turn shows. */
static void test_preview_turn(void **state)
{
    (void)state;
    float pos[15] = {0, 0, 0, 2, -0.0f, 0, 2, 1, 0, 0, 1, -0.0f, 1.4f, 1.6f, 2.5f};
    uint32_t tris[18] = {0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4, 0, 2, 1, 0, 3, 2};
    float keep[15], normals[15], nkeep[15];
    for (int i = 0; i < 15; i++)
        normals[i] = (float)i, nkeep[i] = (float)i;
    memcpy(keep, pos, sizeof pos);
    gs_mesh m = {.nverts = 5, .ntris = 6, .pos = pos, .tris = tris, .normals = normals};
    gs_mesh plain = m; /* the same positions, drawn from a copy */
    plain.normals = NULL;
    char dir[] = "/tmp/gs-test-preview-XXXXXX", a[64], b[64];
    assert_non_null(mkdtemp(dir));
    snprintf(a, sizeof a, "%s/copy.png", dir);
    snprintf(b, sizeof b, "%s/turn.png", dir);
    gs_preview_panel pc[2] = {{&plain, NULL, NULL}, {&plain, NULL, NULL}};
    gs_preview_panel pt[2] = {{&plain, NULL, NULL}, {&m, NULL, &m}};
    assert_int_equal(gs_preview_write(a, pc, 2, 96), GS_OK);
    assert_int_equal(gs_preview_write(b, pt, 2, 96), GS_OK);
    assert_memory_equal(pos, keep, sizeof pos); /* bits: -0 stays -0 */
    assert_memory_equal(normals, nkeep, sizeof normals);
    size_t na, nb;
    unsigned char *da = read_all(a, &na), *db = read_all(b, &nb);
    assert_int_equal(na, nb);
    assert_memory_equal(da, db, na);
    free(da);
    free(db);
    /* a turn that is not the panel's mesh is refused */
    gs_preview_panel bad[1] = {{&plain, NULL, &m}};
    assert_int_equal(gs_preview_write(b, bad, 1, 96), GS_ERR_ARG);
    gs_error_clear();
    unlink(a);
    unlink(b);
    rmdir(dir);
}

/* A flat (2n x n) grid of unit squares in [-n, n] x [0, n], each split into
 * two triangles along alternating diagonals (not a graph with a preferred
 * direction). */
static void grid(int n, float **pos, uint32_t **tris, size_t *nv, size_t *nt)
{
    int cols = 2 * n, rows = n;
    *nv = (size_t)(cols + 1) * (rows + 1);
    *nt = (size_t)2 * cols * rows;
    *pos = malloc(*nv * 3 * sizeof **pos);
    *tris = malloc(*nt * 3 * sizeof **tris);
    for (int y = 0; y <= rows; y++)
        for (int x = 0; x <= cols; x++) {
            float *p = *pos + 3 * ((size_t)y * (cols + 1) + x);
            p[0] = (float)(x - n), p[1] = (float)y, p[2] = 0;
        }
    size_t t = 0;
    for (int y = 0; y < rows; y++)
        for (int x = 0; x < cols; x++) {
            uint32_t a = (uint32_t)(y * (cols + 1) + x), b = a + 1, c = a + (uint32_t)cols + 1, d = c + 1;
            uint32_t *q = *tris + 3 * t;
            if ((x + y) % 2) {
                q[0] = a, q[1] = b, q[2] = d, q[3] = a, q[4] = d, q[5] = c;
            } else {
                q[0] = a, q[1] = b, q[2] = c, q[3] = b, q[4] = d, q[5] = c;
            }
            t += 2;
        }
}

static void centroid(const float *pos, const uint32_t *tri, double c[3])
{
    for (int k = 0; k < 3; k++)
        c[k] = (pos[3 * tri[0] + k] + pos[3 * tri[1] + k] + pos[3 * tri[2] + k]) / 3.0;
}

/* Fast marching and the interface distance against closed forms: a point
 * source (distance = Euclidean in the plane, any direction: no hexagons or
 * diamonds as a graph metric would give), a straight interface (distance =
 * |x|) and a disc (| r - R |), and the contact histogram of the disc. The
 * tolerances are the method's: first order in the edge length (1 here). */
static void test_geodesic(void **state)
{
    (void)state;
    float *pos;
    uint32_t *tris;
    size_t nv, nt;
    const int n = 24;
    grid(n, &pos, &tris, &nv, &nt);
    gs_measure_geo_t g = NULL;
    const double scale = 0.5; /* lengths in half units: exercises the scale */
    assert_int_equal(gs_measure_geo_create(pos, nv, tris, nt, scale, &g), GS_OK);
    /* Point source at (0, 0): vertex distances vs the Euclidean ones, in
     * every direction; the worst relative error off the grid's axes stays
     * under 8% (a triangle graph's metric is ~15% long on its diagonals). */
    uint32_t src = (uint32_t)n; /* x = 0, y = 0 */
    assert_int_equal(gs_measure_geo_march(g, &src, NULL, 1, INFINITY), GS_OK);
    const double *vd = gs_measure_geo_vertex_dist(g);
    double worst = 0;
    for (size_t v = 0; v < nv; v++) {
        double r = scale * hypot(pos[3 * v], pos[3 * v + 1]);
        if (r < 4 * scale)
            continue;
        worst = fmax(worst, fabs(vd[v] - r) / r);
    }
    assert_true(worst < 0.08); /* 6.9% here: planar updates err long next to a point source */
    /* Bounded march: nothing beyond the radius. */
    assert_int_equal(gs_measure_geo_march(g, &src, NULL, 1, 3.0), GS_OK);
    for (size_t v = 0; v < nv; v++)
        assert_true(isinf(vd[v]) || vd[v] <= 3.0);
    assert_true(isinf(vd[nv - 1]));

    /* Straight interface x = 0 (left half positive): exact |x| of the
     * centroid (the interface is a line of grid edges). */
    uint8_t *side = malloc(nt);
    double *dist = malloc(nt * sizeof *dist);
    for (size_t t = 0; t < nt; t++) {
        double c[3];
        centroid(pos, tris + 3 * t, c);
        side[t] = c[0] < 0;
    }
    size_t ns = 0;
    assert_int_equal(gs_measure_interface_dist(g, side, dist, &ns, NULL), GS_OK);
    assert_int_equal(ns, (size_t)n + 1);
    for (size_t t = 0; t < nt; t++) {
        double c[3];
        centroid(pos, tris + 3 * t, c);
        assert_true(fabs(dist[t] - scale * fabs(c[0])) < 0.02 * scale * fabs(c[0]) + 1e-9);
    }
    /* A disc of radius R around (0, 0) (half of it: the grid is y >= 0):
     * the interface follows the triangles, so it lies within one edge of
     * the circle; the distances follow | r - R | to that and to first
     * order. */
    const double R = 12;
    for (size_t t = 0; t < nt; t++) {
        double c[3];
        centroid(pos, tris + 3 * t, c);
        side[t] = hypot(c[0], c[1]) < R;
    }
    assert_int_equal(gs_measure_interface_dist(g, side, dist, NULL, NULL), GS_OK);
    for (size_t t = 0; t < nt; t++) {
        double c[3];
        centroid(pos, tris + 3 * t, c);
        double want = scale * fabs(hypot(c[0], c[1]) - R);
        assert_true(fabs(dist[t] - want) < scale * (0.75 + 0.05 * want / scale));
    }
    /* Histogram: every triangle counted once, on its side; the positive
     * half disc of radius R scale = 6 units has nothing at distance >= 6.5. */
    const uint32_t K = 8;
    int64_t hp[8], hn[8];
    uint64_t beyond = 0;
    gs_measure_contact_hist(dist, side, nt, K, hp, hn, &beyond);
    int64_t sum = 0, npos = 0;
    for (uint32_t k = 0; k < K; k++)
        sum += hp[k] + hn[k], npos += hp[k];
    assert_int_equal(sum, (int64_t)nt);
    int64_t want_pos = 0;
    for (size_t t = 0; t < nt; t++)
        want_pos += side[t];
    assert_int_equal(npos, want_pos);
    assert_int_equal(hp[7], 0);
    assert_true(hp[0] > hp[3] && hp[3] > hp[5]);  /* annuli shrink inwards */
    assert_true(beyond > 0 && hn[7] >= (int64_t)beyond); /* the far corners */
    /* One region only: no interface, every distance infinite. */
    memset(side, 1, nt);
    assert_int_equal(gs_measure_interface_dist(g, side, dist, &ns, NULL), GS_OK);
    assert_int_equal(ns, 0);
    assert_true(isinf(dist[0]) && isinf(dist[nt - 1]));
    assert_int_equal(gs_measure_geo_create(pos, nv, tris, nt, 0, &(gs_measure_geo_t){NULL}), GS_ERR_ARG);
    gs_error_clear();
    gs_measure_geo_destroy(&g);
    assert_null(g);
    free(side);
    free(dist);
    free(pos);
    free(tris);
}

/* Lattice measures on hand-made lattices: an all-empty output has no
 * non-empty window (share 0, not the 1.0 the empty windows give), the
 * example itself scores 1 and completeness 1, a floating cell is
 * unsupported, the profile pads the example with empty above its top. */
static void test_lattice_measures(void **state)
{
    (void)state;
    enum { N = 4, Z = 3 };
    uint16_t ex[N * N * Z], out[N * N * 5];
    memset(ex, 0, sizeof ex);
    for (int i = 0; i < N * N; i++)
        ex[i] = 1; /* ground */
    ex[N * N + 5] = 2; /* a post on the ground */
    ex[2 * N * N + 5] = 3;
    const int ed[3] = {N, N, Z}, od[3] = {N, N, 5};
    gs_measure_windows w;
    assert_int_equal(gs_measure_lattice_windows(ex, ed, ex, ed, 3, &w), GS_OK);
    assert_true(fabs(w.found_share - 1) < 1e-12 && fabs(w.completeness - 1) < 1e-12);
    assert_int_equal((int)w.output_nonempty, 4); /* every 3x3x3 window holds ground */
    memset(out, 0, sizeof out);
    assert_int_equal(gs_measure_lattice_windows(ex, ed, out, od, 2, &w), GS_OK);
    assert_int_equal((int)w.output_nonempty, 0);
    assert_true(w.found_share == 0 && w.completeness == 0);
    assert_true(w.found_share_all > 0.5); /* the empty windows alone */
    /* ground plus one floating cell at z = 3 */
    for (int i = 0; i < N * N; i++)
        out[i] = 1;
    out[3 * N * N + 6] = 3;
    uint64_t u, n;
    assert_int_equal(gs_measure_unsupported(out, od, &u, &n), GS_OK);
    assert_int_equal((int)u, 1);
    assert_int_equal((int)n, N * N + 1);
    assert_int_equal(gs_measure_unsupported(ex, ed, &u, &n), GS_OK);
    assert_int_equal((int)u, 0);
    gs_measure_profile p;
    assert_int_equal(gs_measure_height_profile(ex, ed, out, od, &p), GS_OK);
    assert_int_equal(p.nz, 5);
    assert_true(fabs(p.fill_output[0] - 1) < 1e-12 && fabs(p.fill_example[1] - 1.0 / 16) < 1e-12);
    assert_true(p.fill_example[3] == 0 && fabs(p.fill_output[3] - 1.0 / 16) < 1e-12);
    assert_int_equal(p.top_output, 3);
    assert_int_equal(p.top_example, 2);
    assert_true(fabs(p.fill_mean_abs - (2.0 / 16 + 1.0 / 16) / 5) < 1e-12);
    gs_measure_profile_free(&p);
}

/* Land interior (gs_measure_land_interior, lattice_measures.py land()): a
 * one-column post (the example above) is all edge; a 2x2 hill two layers
 * high on a 4x4 ground has no column with 4 raised neighbours; a layer
 * raised everywhere is all interior (past the sides counts as high); a 3x3
 * plateau in a 5x5 layer has its centre inside: 1 of 9. */
static void test_land_interior(void **state)
{
    (void)state;
    enum { N = 5, Z = 3 };
    uint16_t a[N * N * Z];
    const int d[3] = {N, N, Z}, d4[3] = {4, 4, Z};
    double in = -1;
    memset(a, 0, sizeof a);
    for (int i = 0; i < N * N; i++)
        a[i] = 1;
    assert_int_equal(gs_measure_land_interior(a, d, &in), GS_OK);
    assert_true(in == 0); /* nothing above the lowest column */
    for (int y = 1; y < 4; y++)
        for (int x = 1; x < 4; x++)
            a[N * N + y * N + x] = 2;
    assert_int_equal(gs_measure_land_interior(a, d, &in), GS_OK);
    assert_true(fabs(in - 1.0 / 9) < 1e-12);
    uint16_t b[4 * 4 * Z];
    memset(b, 0, sizeof b);
    for (int i = 0; i < 16; i++)
        b[i] = 1;
    for (int z = 1; z < 3; z++)
        for (int y = 1; y < 3; y++)
            for (int x = 1; x < 3; x++)
                b[z * 16 + y * 4 + x] = 2;
    assert_int_equal(gs_measure_land_interior(b, d4, &in), GS_OK);
    assert_true(in == 0);
    for (int i = 16; i < 32; i++)
        b[i] = 2; /* layer 1 everywhere: the lowest column rises, the 2x2 stands on it */
    assert_int_equal(gs_measure_land_interior(b, d4, &in), GS_OK);
    assert_true(in == 0); /* only the 2x2 above the (now higher) lowest column */
    for (int i = 32; i < 48; i++)
        b[i] = 2;
    assert_int_equal(gs_measure_land_interior(b, d4, &in), GS_OK);
    assert_true(in == 0); /* every column equal: nothing rises */
    b[32] = 0; /* one column lower: the other 15 are land at layer 2 */
    assert_int_equal(gs_measure_land_interior(b, d4, &in), GS_OK);
    assert_true(fabs(in - 13.0 / 15) < 1e-12);
}

/* Enclosure: a closed 6x6 wall ring on a 12x12 layer (z = 1 over a ground
 * layer) encloses its 4x4 yard; the same ring with one wall cell gone
 * encloses nothing; a second, 1-cell ring is a small yard (not large). */
static void test_enclosure(void **state)
{
    (void)state;
    enum { N = 12 };
    uint16_t a[N * N * 3];
    const int d[3] = {N, N, 3};
    memset(a, 0, sizeof a);
    for (int i = 0; i < N * N; i++)
        a[i] = 1; /* ground */
    for (int y = 2; y <= 7; y++)
        for (int x = 2; x <= 7; x++)
            if (x == 2 || x == 7 || y == 2 || y == 7)
                a[N * N + N * y + x] = 9; /* the ring at z = 1 */
    assert_int_equal(gs_measure_ground_layer(a, d), 1);
    gs_measure_enclosure e;
    assert_int_equal(gs_measure_enclosure_layer(a, d, 1, 8, &e), GS_OK);
    assert_int_equal((int)e.cells, N * N);
    assert_int_equal((int)e.enclosed, 16);
    assert_int_equal((int)e.yards, 1);
    assert_int_equal((int)e.yard_max, 16);
    assert_int_equal((int)e.large, 16);
    assert_int_equal(gs_measure_enclosure_layer(a, d, 2, 1, &e), GS_OK); /* no walls up there */
    assert_int_equal((int)e.enclosed, 0);
    /* a 1-cell yard in the corner ring (9..11 x 9..11): small */
    for (int y = 9; y <= 11; y++)
        for (int x = 9; x <= 11; x++)
            if (x != 10 || y != 10)
                a[N * N + N * y + x] = 9;
    assert_int_equal(gs_measure_enclosure_layer(a, d, 1, 8, &e), GS_OK);
    assert_int_equal((int)e.enclosed, 17);
    assert_int_equal((int)e.yards, 2);
    assert_int_equal((int)e.large, 16);
    /* a gap in the big ring: its yard joins the outside */
    a[N * N + N * 2 + 4] = 0;
    assert_int_equal(gs_measure_enclosure_layer(a, d, 1, 8, &e), GS_OK);
    assert_int_equal((int)e.enclosed, 1);
    assert_int_equal((int)e.yards, 1);
    assert_int_equal((int)e.large, 0);
    /* an empty cell on the layer's border is outside even when walled in */
    a[N * N + N * 10 + 10] = 9;
    a[N * N + N * 10 + 11] = 0;
    assert_int_equal(gs_measure_enclosure_layer(a, d, 1, 1, &e), GS_OK);
    assert_int_equal((int)e.enclosed, 0);
    assert_int_equal(gs_measure_enclosure_layer(a, d, 3, 1, &e), GS_ERR_ARG);
    memset(a, 1, sizeof a);
    assert_int_equal(gs_measure_ground_layer(a, d), -1);
}

/* n pseudo-random bytes (a 64-bit LCG's top byte), *r the state carried on. */
static void lcg_bytes(uint8_t *a, size_t n, uint64_t *r)
{
    for (size_t i = 0; i < n; i++) {
        *r = *r * 6364136223846793005ULL + 1442695040888963407ULL;
        a[i] = (uint8_t)(*r >> 56);
    }
}

/* gs_measure_components_nested3 (one labelling of an outer set and the
 * inner set within it) against labelling each set alone
 * (gs_measure_components3, gs_measure_component_euler3, the faces and
 * coordinate sums read off the labels), and
 * gs_measure_object_layout_components on its inner components against
 * gs_measure_object_layout on the inner mask, bit for bit: blurred noise
 * (blobs, most touching others), raw noise (the most provisional labels),
 * grids with an axis of one or two samples, classes from random thresholds
 * (an empty inner set, an empty outer set). */
static void nested_reference(const uint8_t *v, const int64_t n[3], const uint8_t cls[256],
                             int want, gs_measure_component **ref, uint32_t *nref, uint8_t **mask)
{
    int64_t cells = n[0] * n[1] * n[2];
    uint8_t *m = malloc((size_t)cells);
    uint32_t *lab = malloc((size_t)cells * sizeof *lab), nc = 0;
    uint64_t *sz = NULL;
    assert_non_null(m);
    assert_non_null(lab);
    for (int64_t i = 0; i < cells; i++)
        m[i] = cls[v[i]] >= want;
    assert_int_equal(gs_measure_components3(m, (int)n[0], (int)n[1], (int)n[2], NULL, lab, &nc, &sz),
                     GS_OK);
    gs_measure_component *c = calloc((size_t)nc + 1, sizeof *c);
    int64_t *eu = calloc((size_t)nc + 1, sizeof *eu);
    assert_non_null(c);
    assert_non_null(eu);
    gs_measure_component_euler3(lab, (int)n[0], (int)n[1], (int)n[2], nc, eu);
    for (int64_t z = 0, i = 0; z < n[2]; z++)
        for (int64_t y = 0; y < n[1]; y++)
            for (int64_t x = 0; x < n[0]; x++, i++) {
                if (!lab[i])
                    continue;
                gs_measure_component *k = &c[lab[i]];
                int64_t p[3] = {x, y, z};
                for (int a = 0; a < 3; a++)
                    k->faces |= (uint8_t)((p[a] == 0) << (2 * a) | (p[a] == n[a] - 1) << (2 * a + 1));
                if (want == 2)
                    k->sum[0] += (double)x, k->sum[1] += (double)y, k->sum[2] += (double)z;
            }
    for (uint32_t l = 1; l <= nc; l++) {
        c[l].size = sz[l];
        c[l].euler = want == 1 ? eu[l] : 0;
    }
    free(lab);
    gs_free(sz);
    free(eu);
    *ref = c, *nref = nc, *mask = m;
}

static void nested_compare(const gs_measure_component *a, uint32_t na,
                           const gs_measure_component *b, uint32_t nb)
{
    assert_int_equal(na, nb);
    for (uint32_t l = 1; l <= na; l++) {
        assert_int_equal(a[l].size, b[l].size);
        assert_int_equal(a[l].faces, b[l].faces);
        assert_int_equal(a[l].euler, b[l].euler);
        for (int k = 0; k < 3; k++)
            assert_true(a[l].sum[k] == b[l].sum[k]);
    }
}

static void test_components_nested(void **state)
{
    (void)state;
    const int64_t dims[][3] = {{23, 19, 17}, {31, 29, 1}, {40, 1, 9}, {1, 1, 30}, {2, 26, 21},
                               {24, 24, 24}};
    uint64_t r = 1919;
    int cases = 0, inner_objects = 0;
    for (size_t d = 0; d < sizeof dims / sizeof dims[0]; d++)
        for (int kind = 0; kind < 2; kind++) {
            const int64_t *n = dims[d];
            int64_t cells = n[0] * n[1] * n[2];
            uint8_t *v = malloc((size_t)cells), *w = malloc((size_t)cells);
            assert_non_null(v);
            assert_non_null(w);
            lcg_bytes(v, (size_t)cells, &r);
            for (int pass = 0; kind == 0 && pass < 3; pass++) { /* blur: blobs */
                for (int64_t z = 0, i = 0; z < n[2]; z++)
                    for (int64_t y = 0; y < n[1]; y++)
                        for (int64_t x = 0; x < n[0]; x++, i++) {
                            int s = 0, c = 0;
                            for (int dz = -1; dz <= 1; dz++)
                                for (int dy = -1; dy <= 1; dy++)
                                    for (int dx = -1; dx <= 1; dx++) {
                                        int64_t p[3] = {x + dx, y + dy, z + dz};
                                        if (p[0] < 0 || p[1] < 0 || p[2] < 0 || p[0] >= n[0] ||
                                            p[1] >= n[1] || p[2] >= n[2])
                                            continue;
                                        s += v[p[0] + n[0] * (p[1] + n[1] * p[2])], c++;
                                    }
                            w[i] = (uint8_t)(s / c);
                        }
                memcpy(v, w, (size_t)cells);
            }
            uint8_t lo = 255, hi = 0;
            for (int64_t i = 0; i < cells; i++)
                lo = v[i] < lo ? v[i] : lo, hi = v[i] > hi ? v[i] : hi;
            for (int t = 0; t < 4; t++) {
                /* thresholds within the values' range (t = 3: no inner set) */
                uint8_t b[2];
                lcg_bytes(b, 2, &r);
                int t2 = lo + b[0] % (hi - lo + 1), t1 = lo + b[1] % (t2 - lo + 1);
                if (t == 3)
                    t1 = -1;
                uint8_t cls[256];
                for (int i = 0; i < 256; i++)
                    cls[i] = i <= t1 ? 2 : i <= t2 ? 1 : 0;
                gs_measure_nested k;
                assert_int_equal(gs_measure_components_nested3(v, n, cls, 1, &k), GS_OK);
                gs_measure_component *ro, *ri;
                uint32_t nro, nri;
                uint8_t *mo, *mi;
                nested_reference(v, n, cls, 1, &ro, &nro, &mo);
                nested_reference(v, n, cls, 2, &ri, &nri, &mi);
                nested_compare(k.outer, k.nouter, ro, nro);
                nested_compare(k.inner, k.ninner, ri, nri);
                /* the layout of these inner components against the previous
                 * case's (or their own) */
                gs_measure_objlayout la, lb;
                assert_int_equal(gs_measure_object_layout_components(k.inner, k.ninner, n, k.inner,
                                                                     k.ninner, n, 1.5, &la), GS_OK);
                assert_int_equal(gs_measure_object_layout(mi, n, mi, n, 1.5, &lb), GS_OK);
                assert_memory_equal(&la, &lb, sizeof la);
                inner_objects += (int)la.out.objects;
                /* without the Euler terms: the same but euler 0 */
                gs_measure_nested k0;
                assert_int_equal(gs_measure_components_nested3(v, n, cls, 0, &k0), GS_OK);
                for (uint32_t l = 1; l <= nro; l++)
                    ro[l].euler = 0;
                nested_compare(k0.outer, k0.nouter, ro, nro);
                gs_measure_nested_free(&k0);
                gs_measure_nested_free(&k);
                free(ro);
                free(ri);
                free(mo);
                free(mi);
                cases++;
            }
            free(v);
            free(w);
        }
    printf("nested components: %d cases, %d inner objects measured\n", cases, inner_objects);
    assert_true(inner_objects > 20);
}

/* The layout of an output's cores against its example's from one
 * labelling (gs_measure_object_layout_components) equals the layout of the
 * two masks (gs_measure_object_layout), for two different grids. */
static void test_layout_components(void **state)
{
    (void)state;
    const int64_t on[3] = {30, 26, 22}, sn[3] = {20, 18, 16};
    uint64_t r = 77;
    uint8_t *g[2], *m[2];
    gs_measure_nested k[2];
    const int64_t *n[2] = {on, sn};
    uint8_t cls[256];
    for (int i = 0; i < 256; i++)
        cls[i] = i < 90 ? 2 : i < 130;
    for (int s = 0; s < 2; s++) {
        int64_t cells = n[s][0] * n[s][1] * n[s][2];
        g[s] = malloc((size_t)cells), m[s] = malloc((size_t)cells);
        uint8_t *w = malloc((size_t)cells);
        assert_non_null(g[s]);
        assert_non_null(m[s]);
        assert_non_null(w);
        lcg_bytes(g[s], (size_t)cells, &r);
        for (int pass = 0; pass < 2; pass++) {
            for (int64_t i = 0; i < cells; i++) {
                int64_t x = i % n[s][0], sum = g[s][i], c = 1;
                if (x > 0)
                    sum += g[s][i - 1], c++;
                if (x + 1 < n[s][0])
                    sum += g[s][i + 1], c++;
                if (i >= n[s][0])
                    sum += g[s][i - n[s][0]], c++;
                if (i + n[s][0] * n[s][1] < cells)
                    sum += g[s][i + n[s][0] * n[s][1]], c++;
                w[i] = (uint8_t)(sum / c);
            }
            memcpy(g[s], w, (size_t)cells);
        }
        free(w);
        for (int64_t i = 0; i < cells; i++)
            m[s][i] = cls[g[s][i]] == 2;
        assert_int_equal(gs_measure_components_nested3(g[s], n[s], cls, 1, &k[s]), GS_OK);
    }
    gs_measure_objlayout a, b;
    assert_int_equal(gs_measure_object_layout_components(k[0].inner, k[0].ninner, on, k[1].inner,
                                                         k[1].ninner, sn, 1.5, &a), GS_OK);
    assert_int_equal(gs_measure_object_layout(m[0], on, m[1], sn, 1.5, &b), GS_OK);
    printf("layout from components: %lld/%lld objects, nn KS %.4f\n", (long long)a.out.objects,
           (long long)a.src.objects, a.nn_ks);
    assert_true(a.out.objects > 3 && a.src.objects > 3);
    assert_memory_equal(&a, &b, sizeof a);
    for (int s = 0; s < 2; s++) {
        gs_measure_nested_free(&k[s]);
        free(g[s]);
        free(m[s]);
    }
}

/* Copy measure on a periodic source: a face-centred pattern (periods
 * (8,8,0), (8,0,8), (0,8,8): every window repeats, none is unique in the
 * plain sense) tiled into the output is one copied region larger than the
 * source, while a random source has no period and a shuffled output copies
 * only pieces. */
/* Layout above the ground (gs_measure_layout_lattice), 5x5x4, ground z = 0
 * full, measured from z = 1: a wall column 2 high at (1, 1) with a 1-cell
 * spur at (2, 1) z = 1 (one structure of 3 cells), a bush (1 high) at (3, 3):
 * no structure. Open: 25 - 3 columns; clear: the columns at Chebyshev
 * distance >= 2 from (1, 1), (2, 1) and (3, 3): x = 4 with y <= 1 (2) and
 * y = 3..4 with x <= 1 (4): 6. A second wall of 5 cells at (0, 4)
 * z = 1..3 plus (1, 4) z = 1, (2, 4) z = 1: then 2 structures, cell-weighted
 * median 5, large (more than 4 cells) 5 of 8. */
static void test_layout(void **state)
{
    (void)state;
    enum { NX = 5, NY = 5, NZ = 4 };
    uint16_t lab[NX * NY * NZ] = {0};
    for (int i = 0; i < NX * NY; i++)
        lab[i] = 1;
#define AT(x, y, z) lab[(x) + NX * ((y) + NY * (z))]
    AT(1, 1, 1) = AT(1, 1, 2) = 2;
    AT(2, 1, 1) = 2;
    AT(3, 3, 1) = 3;
    const int dims[3] = {NX, NY, NZ};
    gs_measure_layout L;
    assert_int_equal(gs_measure_layout_lattice(lab, dims, 1, 0, &L), GS_OK);
    assert_int_equal(L.columns, 25);
    assert_int_equal(L.open, 22);
    assert_int_equal(L.clear, 6);
    assert_int_equal(L.structures, 1);
    assert_int_equal(L.structure_cells, 3);
    assert_int_equal(L.largest, 3);
    assert_int_equal(L.size_median, 3);
    assert_int_equal(L.large_cells, 0);
    AT(0, 4, 1) = AT(0, 4, 2) = AT(0, 4, 3) = 2;
    AT(1, 4, 1) = AT(2, 4, 1) = 2;
    assert_int_equal(gs_measure_layout_lattice(lab, dims, 1, 4, &L), GS_OK);
    assert_int_equal(L.open, 19);
    assert_int_equal(L.structures, 2);
    assert_int_equal(L.structure_cells, 8);
    assert_int_equal(L.largest, 5);
    assert_int_equal(L.size_median, 5);
    assert_int_equal(L.large_cells, 5);
#undef AT
    assert_int_equal(gs_measure_layout_lattice(lab, dims, 4, 0, &L), GS_ERR_ARG);
    assert_int_equal(L.nested_cells, 0); /* both structures reach the outside */
    /* nested: 7x7x3, a ring wall 2 high round the columns x, y = 2..4 (16
     * columns, 32 cells) and a keep 2 high at (3, 3) inside it: the keep (2
     * cells) is nested, the ring is not; with a gap in the ring at (3, 1) the
     * yard joins the outside and nothing is nested. */
    enum { RN = 7 };
    uint16_t ring[RN * RN * 3] = {0};
    for (int i = 0; i < RN * RN; i++)
        ring[i] = 1;
#define RAT(x, y, z) ring[(x) + RN * ((y) + RN * (z))]
    for (int z = 1; z < 3; z++) {
        for (int k = 1; k <= 5; k++)
            RAT(k, 1, z) = RAT(k, 5, z) = RAT(1, k, z) = RAT(5, k, z) = 2;
        RAT(3, 3, z) = 3;
    }
    const int rdims[3] = {RN, RN, 3};
    assert_int_equal(gs_measure_layout_lattice(ring, rdims, 1, 0, &L), GS_OK);
    assert_int_equal(L.structures, 2);
    assert_int_equal(L.structure_cells, 34);
    assert_int_equal(L.nested_cells, 2);
    RAT(3, 1, 1) = RAT(3, 1, 2) = 0;
    assert_int_equal(gs_measure_layout_lattice(ring, rdims, 1, 0, &L), GS_OK);
    assert_int_equal(L.structures, 2);
    assert_int_equal(L.nested_cells, 0);
#undef RAT
}

/* Fragments and merged objects (gs_measure_object_layout): a 2-D source
 * (n z = 1) with two 4x4 squares (16 samples); an output with three whole
 * squares, a 2x4 sliver (8 < 3/4 of 16) and a 2x2 piece cut by the face
 * (not measured): 4 measured objects, 1 a fragment; the source none. */
static void test_object_fragments(void **state)
{
    (void)state;
    enum { SN = 20, ON = 30 };
    uint8_t src[SN * SN] = {0}, out[ON * ON] = {0};
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++) {
            src[(3 + x) + SN * (3 + y)] = src[(12 + x) + SN * (12 + y)] = 1;
            out[(3 + x) + ON * (3 + y)] = out[(15 + x) + ON * (3 + y)] = 1;
            out[(3 + x) + ON * (15 + y)] = 1;
            if (x < 2)
                out[(15 + x) + ON * (15 + y)] = 1;
            if (x < 2 && y < 2)
                out[x + ON * (25 + y)] = 1;
        }
    const int64_t sn[3] = {SN, SN, 1}, on[3] = {ON, ON, 1};
    gs_measure_objlayout r;
    assert_int_equal(gs_measure_object_layout(out, on, src, sn, 1.5, &r), GS_OK);
    assert_int_equal((int)r.out.objects, 4);
    assert_true(fabs(r.out.fragment_share - 0.25) < 1e-12);
    assert_true(r.src.fragment_share == 0);
    out[(17 + 0) + ON * 15] = out[17 + ON * 16] = out[18 + ON * 15] = out[18 + ON * 16] = 1;
    assert_int_equal(gs_measure_object_layout(out, on, src, sn, 1.5, &r), GS_OK);
    assert_true(r.out.fragment_share == 0); /* 12 samples: 3/4 of the smallest, not below */
    assert_true(r.out.merged_share == 0 && r.src.merged_share == 0);
    /* that object made a 5x4 rectangle (2.50 from its centre: within the
     * source's 2.12 plus half a sample), then 6x4 (two glued pieces, 24
     * samples: not over 1.5x the largest; 2.92: merged) */
    for (int y = 0; y < 4; y++)
        for (int x = 15; x < 20; x++)
            out[x + ON * (15 + y)] = 1;
    assert_int_equal(gs_measure_object_layout(out, on, src, sn, 1.5, &r), GS_OK);
    assert_true(r.out.merged_share == 0 && r.out.fused_share == 0);
    for (int y = 0; y < 4; y++)
        out[20 + ON * (15 + y)] = 1;
    assert_int_equal(gs_measure_object_layout(out, on, src, sn, 1.5, &r), GS_OK);
    assert_true(fabs(r.out.merged_share - 0.25) < 1e-12 && r.out.fused_share == 0);
}

static void test_copy_periodic(void **state)
{
    (void)state;
    enum { S = 40, O = 64 };
    uint8_t *cell = malloc(16 * 16 * 16), *src = malloc(S * S * S), *out = malloc(O * O * O);
    assert_non_null(cell);
    assert_non_null(src);
    assert_non_null(out);
    uint64_t r = 7;
    lcg_bytes(cell, 16 * 16 * 16, &r);
    /* make the cell itself face-centred: value at p = value at p reduced */
    for (int64_t z = 0; z < 16; z++)
        for (int64_t y = 0; y < 16; y++)
            for (int64_t x = 0; x < 16; x++) {
                int64_t c[3] = {x, y, z};
                /* the representative: the lowest of p, p - (8,8,0), p - (8,0,8), p - (0,8,8) mod 16 */
                int64_t best = x + 16 * (y + 16 * z);
                const int64_t v[3][3] = {{8, 8, 0}, {8, 0, 8}, {0, 8, 8}};
                for (int i = 0; i < 3; i++) {
                    int64_t t[3];
                    for (int a = 0; a < 3; a++)
                        t[a] = (c[a] + v[i][a]) % 16;
                    int64_t l = t[0] + 16 * (t[1] + 16 * t[2]);
                    best = l < best ? l : best;
                }
                cell[x + 16 * (y + 16 * z)] = cell[best];
            }
    for (int64_t z = 0; z < S; z++)
        for (int64_t y = 0; y < S; y++)
            for (int64_t x = 0; x < S; x++)
                src[x + S * (y + S * z)] = cell[x % 16 + 16 * (y % 16 + 16 * (z % 16))];
    /* the output: the same infinite pattern, shifted (a tiling of the source) */
    for (int64_t z = 0; z < O; z++)
        for (int64_t y = 0; y < O; y++)
            for (int64_t x = 0; x < O; x++)
                out[x + O * (y + O * z)] = cell[(x + 3) % 16 + 16 * ((y + 5) % 16 + 16 * ((z + 11) % 16))];
    const int64_t sn[3] = {S, S, S}, on[3] = {O, O, O};
    gs_measure_copy m;
    assert_int_equal(gs_measure_copy3(out, on, src, sn, 4, 64, 4, &m), GS_OK);
    assert_true(m.periods >= 3);
    assert_true(fabs(m.shortest_period - sqrt(128.0)) < 1e-9);
    assert_true(m.matched_share > 0.99);
    assert_int_equal(m.regions, 1);
    assert_true(m.largest_region_of_source > 1);
    assert_true(m.completeness > 0.99);
    /* a source without periods: none found, the same output copies nothing */
    lcg_bytes(src, S * S * S, &r);
    assert_int_equal(gs_measure_copy3(out, on, src, sn, 4, 64, 4, &m), GS_OK);
    assert_int_equal(m.periods, 0);
    assert_true(m.matched_share < 0.01);
    free(cell);
    free(src);
    free(out);
}

/* A copied window right above an unmatched one whose source position is
 * the last of the source's first plane (its offset one plane down would be
 * -1, the value of an unmatched neighbour): it must not join that neighbour
 * (main before field30 read the union-find outside its array there). */
static void test_copy_below_unmatched(void **state)
{
    (void)state;
    enum { S = 12, O = 6, K = 3 };
    uint8_t *src = malloc(S * S * S), out[O * O * O];
    assert_non_null(src);
    uint64_t r = 5;
    lcg_bytes(src, S * S * S, &r);
    for (int i = 0; i < S * S * S; i++)
        src[i] %= 200;
    memset(out, 255, sizeof out); /* never in src: no window holding one matches */
    for (int z = 0; z < K; z++)
        for (int y = 0; y < K; y++)
            for (int x = 0; x < K; x++)
                out[x + O * (y + O * (z + 1))] = src[S - K + x + S * (S - K + y + S * z)];
    const int64_t sn[3] = {S, S, S}, on[3] = {O, O, O};
    for (int ref = 0; ref < 2; ref++) {
        gs_measure_copy m;
        assert_int_equal((ref ? gs_measure_copy3_reference : gs_measure_copy3)(out, on, src, sn, K,
                                                                              8, 2, &m), GS_OK);
        assert_int_equal(m.regions, 1);
        assert_int_equal(m.largest_region, 1);
        assert_true(m.matched_share == 1.0 / 64);
    }
    free(src);
}

/* Copy measure on a repetitive source that is not periodic (grid.ini's
 * kind): a random 8^3 cell repeated, with a few samples changed, so most
 * windows occur several times and only those around the changes are unique.
 * A verbatim tiling of a 24^3 piece of it is one copied region per tile
 * (windows joined through consistent offsets, not only unique ones: #19);
 * an output of 8^3 blocks copied from offsets that differ modulo the cell
 * copies only pieces of one block. */
static void test_copy_repetitive(void **state)
{
    (void)state;
    enum { S = 32, O = 48, T = 24 };
    uint8_t cell[8 * 8 * 8], *src = malloc(S * S * S), *out = malloc(O * O * O);
    assert_non_null(src);
    assert_non_null(out);
    uint64_t r = 11;
    lcg_bytes(cell, 8 * 8 * 8, &r);
    for (int64_t z = 0; z < S; z++)
        for (int64_t y = 0; y < S; y++)
            for (int64_t x = 0; x < S; x++)
                src[x + S * (y + S * z)] = cell[x % 8 + 8 * (y % 8 + 8 * (z % 8))];
    const int64_t defects[6][3] = {{5, 9, 3}, {20, 4, 17}, {12, 25, 8}, {27, 14, 26}, {3, 28, 21}, {17, 17, 12}};
    for (int i = 0; i < 6; i++) {
        uint8_t *d = &src[defects[i][0] + S * (defects[i][1] + S * defects[i][2])];
        *d = (uint8_t)(*d + 101);
    }
    for (int64_t z = 0; z < O; z++)
        for (int64_t y = 0; y < O; y++)
            for (int64_t x = 0; x < O; x++)
                out[x + O * (y + O * z)] = src[2 + x % T + S * (3 + y % T + S * (4 + z % T))];
    const int64_t sn[3] = {S, S, S}, on[3] = {O, O, O};
    gs_measure_copy m;
    assert_int_equal(gs_measure_copy3(out, on, src, sn, 4, 64, 4, &m), GS_OK);
    assert_int_equal(m.periods, 0);
    assert_true(m.source_unique_share < 0.1);
    printf("tiling: largest %lld (%.3f of the source), regions %lld\n", (long long)m.largest_region,
           m.largest_region_of_source, (long long)m.regions);
    /* a tile's windows: (T - 3)^3 */
    assert_true(m.largest_region >= (T - 3) * (T - 3) * (T - 3));
    /* 8^3 blocks from offsets differing modulo the cell: at most one block's windows */
    for (int64_t z = 0; z < O; z++)
        for (int64_t y = 0; y < O; y++)
            for (int64_t x = 0; x < O; x++) {
                int64_t b = x / 8 + 6 * (y / 8 + 6 * (z / 8)), o = b % 7 + 1;
                out[x + O * (y + O * z)] = src[o + x % 8 + S * (2 * o % 8 + y % 8 + S * (3 * o % 8 + z % 8))];
            }
    assert_int_equal(gs_measure_copy3(out, on, src, sn, 4, 64, 4, &m), GS_OK);
    printf("blocks: largest %lld, regions %lld\n", (long long)m.largest_region, (long long)m.regions);
    assert_true(m.largest_region <= 5 * 5 * 5);
    free(src);
    free(out);
}

/* gs_measure_copy3 (an output window continuing a neighbour's source
 * position takes that position's entry; a filter skips absent windows)
 * gives the figures of gs_measure_copy3_reference (every window looked up),
 * bit for bit: sources of blocky low-entropy values with flat zones, a
 * repeated cell with defects, a periodic (face-centred) pattern; outputs of
 * blocks copied from random offsets of random sizes, with flat blocks and
 * sprinkled changed samples, and shifted tilings; windows 3 and 4. */
static void test_copy_reference(void **state)
{
    (void)state;
    enum { S = 28, O = 44 };
    uint8_t *src = malloc(S * S * S), *out = malloc(O * O * O), cell[8 * 8 * 8], rnd[4];
    assert_non_null(src);
    assert_non_null(out);
    uint64_t r = 2026;
    const int64_t sn[3] = {S, S, S}, on[3] = {O, O, O};
    int compared = 0;
    for (int kind = 0; kind < 3; kind++) {
        lcg_bytes(cell, sizeof cell, &r);
        for (int64_t z = 0; z < S; z++)
            for (int64_t y = 0; y < S; y++)
                for (int64_t x = 0; x < S; x++) {
                    uint8_t *v = &src[x + S * (y + S * z)];
                    if (kind == 0) { /* 2^3 cells of 3 levels, a flat slab */
                        *v = z >= 20 ? 7 : (uint8_t)(cell[x / 2 % 8 + 8 * (y / 2 % 8 + 8 * (z / 2 % 8))] % 3);
                        if (x / 2 >= 8 || y / 2 >= 8) {
                            lcg_bytes(rnd, 1, &r);
                            *v = z >= 20 ? 7 : (uint8_t)(rnd[0] % 3);
                        }
                    } else if (kind == 1) { /* repeated cell */
                        *v = cell[x % 8 + 8 * (y % 8 + 8 * (z % 8))];
                    } else { /* periodic: face-centred with period 8 */
                        int64_t a = (x + y) % 8, b = (x - y + 8 * S) % 8;
                        *v = cell[a / 2 + 4 * (b / 2) + 16 * (z % 4)];
                    }
                }
        if (kind == 1)
            for (int i = 0; i < 5; i++) { /* defects */
                lcg_bytes(rnd, 3, &r);
                src[rnd[0] % S + S * (rnd[1] % S + S * (rnd[2] % S))] += 101;
            }
        for (int shape = 0; shape < 2; shape++) {
            if (shape == 0) { /* random blocks from random offsets, flat ones, noise */
                for (int64_t z0 = 0; z0 < O;) {
                    lcg_bytes(rnd, 1, &r);
                    int64_t dz = 3 + rnd[0] % 10;
                    for (int64_t y0 = 0; y0 < O;) {
                        lcg_bytes(rnd, 1, &r);
                        int64_t dy = 3 + rnd[0] % 10;
                        for (int64_t x0 = 0; x0 < O;) {
                            lcg_bytes(rnd, 4, &r);
                            int64_t dx = 3 + rnd[0] % 10, ox = rnd[1] % (S - 12), oy = rnd[2] % (S - 12),
                                    oz = rnd[3] % (S - 12);
                            int flat = rnd[0] % 7 == 0;
                            for (int64_t z = z0; z < z0 + dz && z < O; z++)
                                for (int64_t y = y0; y < y0 + dy && y < O; y++)
                                    for (int64_t x = x0; x < x0 + dx && x < O; x++)
                                        out[x + O * (y + O * z)] =
                                            flat ? 7
                                                 : src[ox + x - x0 + S * (oy + y - y0 + S * (oz + z - z0))];
                            x0 += dx;
                        }
                        y0 += dy;
                    }
                    z0 += dz;
                }
                for (int i = 0; i < O * O * O / 100; i++) {
                    lcg_bytes(rnd, 4, &r);
                    out[rnd[0] % O + O * (rnd[1] % O + O * (rnd[2] % O))] = rnd[3] % 4;
                }
            } else { /* shifted tilings of a 20^3 piece */
                lcg_bytes(rnd, 3, &r);
                for (int64_t z = 0; z < O; z++)
                    for (int64_t y = 0; y < O; y++)
                        for (int64_t x = 0; x < O; x++)
                            out[x + O * (y + O * z)] =
                                src[rnd[0] % 8 + x % 20 + S * (rnd[1] % 8 + y % 20 + S * (rnd[2] % 8 + z % 20))];
            }
            for (int k = 3; k <= 4; k++) {
                gs_measure_copy a, b;
                assert_int_equal(gs_measure_copy3(out, on, src, sn, k, 27, 4, &a), GS_OK);
                assert_int_equal(gs_measure_copy3_reference(out, on, src, sn, k, 27, 4, &b), GS_OK);
                printf("copy kind %d shape %d k %d: matched %.4f regions %lld largest %lld "
                       "periods %d\n", kind, shape, k, a.matched_share, (long long)a.regions,
                       (long long)a.largest_region, a.periods);
                assert_int_equal(a.window, b.window);
                assert_int_equal(a.positions, b.positions);
                assert_true(a.matched_share == b.matched_share);
                assert_int_equal(a.regions, b.regions);
                assert_int_equal(a.largest_region, b.largest_region);
                assert_true(a.largest_region_of_source == b.largest_region_of_source);
                assert_true(a.large_share == b.large_share);
                assert_true(a.completeness == b.completeness);
                assert_true(a.source_unique_share == b.source_unique_share);
                assert_int_equal(a.periods, b.periods);
                assert_true(a.shortest_period == b.shortest_period);
                compared++;
            }
        }
    }
    assert_int_equal(compared, 12);
    free(src);
    free(out);
}

/* A flat grid mesh of n x n quads (edge h, two triangles each) in the xy
 * plane, and a labelling by whether the vertex lies inside radius r(theta)
 * about the centre. */
static void outline_grid(int n, double h, float **pos, uint32_t **tris, size_t *nv, size_t *nt)
{
    *nv = (size_t)(n + 1) * (n + 1);
    *nt = 2 * (size_t)n * n;
    *pos = malloc(3 * *nv * sizeof **pos);
    *tris = malloc(3 * *nt * sizeof **tris);
    assert_non_null(*pos);
    assert_non_null(*tris);
    for (int y = 0; y <= n; y++)
        for (int x = 0; x <= n; x++) {
            float *p = *pos + 3 * ((size_t)y * (n + 1) + x);
            p[0] = (float)(x * h), p[1] = (float)(y * h), p[2] = 0;
        }
    size_t t = 0;
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            uint32_t a = (uint32_t)(y * (n + 1) + x), b = a + 1, c = a + (uint32_t)(n + 1), d = c + 1;
            uint32_t *f = *tris + 3 * t;
            f[0] = a, f[1] = b, f[2] = d, f[3] = a, f[4] = d, f[5] = c;
            t += 2;
        }
}

static double outline_of(int n, double h, double r0, double amp, int teeth)
{
    float *pos;
    uint32_t *tris;
    size_t nv, nt;
    outline_grid(n, h, &pos, &tris, &nv, &nt);
    uint8_t *side = malloc(nv);
    assert_non_null(side);
    double c = 0.5 * n * h;
    for (size_t v = 0; v < nv; v++) {
        double dx = pos[3 * v] - c, dy = pos[3 * v + 1] - c;
        double th = atan2(dy, dx);
        double r = r0 + (teeth && sin(teeth * th) > 0 ? amp : 0);
        side[v] = sqrt(dx * dx + dy * dy) <= r;
    }
    gs_measure_outline_t o;
    assert_int_equal(gs_measure_outline(pos, nv, tris, nt, 1.0, side, 1.5, &o), GS_OK);
    assert_false(o.on_sphere);
    assert_true(o.length > 0 && o.smoothed_length > 0);
    free(pos);
    free(tris);
    free(side);
    return o.roughness;
}

/* Outline roughness (gs_measure_outline): a disc of radius 10 units on a
 * grid of 0.25 units is as round as its smoothing (an opening at 1.5 units
 * leaves it): within 3% of 1; a cog of the same disc with 48 teeth
 * 1 unit high and ~1.3 units wide (narrower than 2 x 1.5) is cut back to the
 * disc, and its coast is the circle's 63 units plus 48 x 2 tooth flanks of 1
 * unit: about 2.5x; required > 1.3x. No boundary gives NaN; bad radius
 * GS_ERR_ARG. */
static void test_outline(void **state)
{
    (void)state;
    double disc = outline_of(100, 0.25, 10, 0, 0);
    double cog = outline_of(100, 0.25, 10, 1, 48);
    print_message("outline roughness: disc %.4f, cog %.4f\n", disc, cog);
    assert_true(disc > 0.98 && disc < 1.03);
    assert_true(cog > 1.3);
    float *pos;
    uint32_t *tris;
    size_t nv, nt;
    outline_grid(4, 1.0, &pos, &tris, &nv, &nt);
    uint8_t *side = calloc(nv, 1);
    assert_non_null(side);
    gs_measure_outline_t o;
    assert_int_equal(gs_measure_outline(pos, nv, tris, nt, 1.0, side, 1.5, &o), GS_OK);
    assert_true(isnan(o.roughness));
    assert_int_equal(gs_measure_outline(pos, nv, tris, nt, 1.0, side, 0, &o), GS_ERR_ARG);
    free(pos);
    free(tris);
    free(side);
}

/* gs_measure_repeats2: a 2x2 tiling of a height map (a relief of random
 * bumps) repeats it: two places alike to NCC 1 (the example's own most alike
 * two less), one feature recurring at least 4 times; within example-sized
 * crops (the equal-area figure) no repeat; the example as output: crops and
 * whole give the example's own figure. */
static void smooth_relief(uint64_t seed, int n, double *h)
{
    gs_rng r;
    gs_rng_init(&r, seed, 3);
    double bump[24][3];
    for (int k = 0; k < 24; k++)
        for (int a = 0; a < 3; a++)
            bump[k][a] = (double)gs_rng_below(&r, 1000) / 1000.0;
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            double v = 0;
            for (int k = 0; k < 24; k++) {
                double dx = x - bump[k][0] * n, dy = y - bump[k][1] * n, s = 2 + 4 * bump[k][2];
                v += exp(-(dx * dx + dy * dy) / (2 * s * s));
            }
            h[x + n * y] = v;
        }
}

/* out (2n x 2n, x fastest) = src (n x n) tiled twice along x and y */
static void tile_2x2(const double *src, int n, double *out)
{
    for (int y = 0; y < 2 * n; y++)
        for (int x = 0; x < 2 * n; x++)
            out[x + 2 * n * y] = src[x % n + n * (y % n)];
}

static void test_repeats(void **state)
{
    (void)state;
    enum { N = 48 };
    double *src = malloc(sizeof(double) * N * N), *tile = malloc(sizeof(double) * 4 * N * N);
    assert_non_null(src);
    assert_non_null(tile);
    smooth_relief(1, N, src);
    tile_2x2(src, N, tile);
    gs_measure_repeats m;
    assert_int_equal(gs_measure_repeats2(tile, 2 * N, 2 * N, src, N, N, &m), GS_OK);
    assert_true(m.window >= 3 && m.window <= N / 2);
    assert_true(m.ncc_src < 0.999);
    assert_true(m.ncc_out > 0.999);
    assert_true(m.recur_out >= 4);
    /* the equal-area figure: 3 x 3 example-sized crops (every N/2); each
     * holds the example cyclically shifted, none a repeat of its own */
    assert_int_equal(m.crops, 9);
    assert_true(m.ncc_out_area > -1 && m.ncc_out_area < 0.999);
    assert_true(m.ncc_out_area <= m.ncc_out_area_max && m.ncc_out_area_max <= m.ncc_out);
    /* an output that is the example: one crop, the example's own figure */
    assert_int_equal(gs_measure_repeats2(src, N, N, src, N, N, &m), GS_OK);
    assert_int_equal(m.crops, 1);
    assert_true(m.ncc_out_area == m.ncc_src && m.ncc_out == m.ncc_src);
    free(src);
    free(tile);
}

/* gs_measure_heights: a 2x2 tiling of a height map holds its distribution
 * (the example's own shares, KS 0); the same map with its top flattened to
 * the 90th percentile and its bottom raised to the 10th (the output's tails
 * compressed) holds nothing strictly between the levels' sides: 0 at or
 * above the 95th, all of the old tail at the 90th/10th; the shares of
 * 1..100 are exact. */
static void test_heights(void **state)
{
    (void)state;
    enum { N = 40 };
    double *src = malloc(sizeof(double) * N * N), *out = malloc(sizeof(double) * 4 * N * N);
    assert_non_null(src);
    assert_non_null(out);
    smooth_relief(2, N, src);
    tile_2x2(src, N, out);
    gs_measure_heights_t m;
    assert_int_equal(gs_measure_heights(out, 4 * N * N, src, N * N, &m), GS_OK);
    assert_true(m.ks == 0 && m.low_out == m.low_src);
    for (int k = 0; k < GS_MEASURE_HEIGHT_LEVELS - 1; k++)
        assert_true(m.high_out[k] == m.high_src[k]);
    assert_true(fabs(m.high_src[0] - 0.10) < 0.01 && fabs(m.low_src - 0.10) < 0.01);
    double lo = m.level[0], hi = m.level[1];
    for (int i = 0; i < 4 * N * N; i++)
        out[i] = out[i] > hi ? hi : out[i] < lo ? lo : out[i];
    assert_int_equal(gs_measure_heights(out, 4 * N * N, src, N * N, &m), GS_OK);
    assert_true(m.high_out[1] == 0 && m.high_out[2] == 0);
    assert_true(fabs(m.high_out[0] - m.high_src[0]) < 1e-12 && fabs(m.low_out - m.low_src) < 1e-12);
    assert_true(m.ks > 0.04 && m.ks < 0.11);
    /* 1..100: the 10th percentile 10.9, the 90th 90.1, the 99th 99.01 */
    double v[100];
    for (int i = 0; i < 100; i++)
        v[i] = i + 1;
    assert_int_equal(gs_measure_heights(v, 100, v, 100, &m), GS_OK);
    assert_true(fabs(m.level[0] - 10.9) < 1e-9 && fabs(m.level[1] - 90.1) < 1e-9);
    assert_true(fabs(m.low_src - 0.10) < 1e-12 && fabs(m.high_src[0] - 0.10) < 1e-12 &&
                fabs(m.high_src[1] - 0.05) < 1e-12 && fabs(m.high_src[2] - 0.01) < 1e-12);
    assert_int_equal(gs_measure_heights(v, 0, v, 100, &m), GS_ERR_ARG);
    free(src);
    free(out);
}

/* gs_measure_window_share_range: a plane every 4 samples along x, windows 6
 * long along x: 2/6 or 1/6 of a window set; and a random mask against brute
 * force over every periodic window (one window larger than the mask, one
 * smaller). */
static void test_window_share(void **state)
{
    (void)state;
    uint8_t m[64];
    for (int i = 0; i < 64; i++)
        m[i] = i % 4 == 0;
    double lo, hi;
    assert_int_equal(gs_measure_window_share_range(m, (const int64_t[3]){4, 4, 4},
                                                   (const int64_t[3]){6, 4, 4}, &lo, &hi), GS_OK);
    assert_true(fabs(lo - 1.0 / 6) < 1e-12 && fabs(hi - 2.0 / 6) < 1e-12);
    enum { NX = 5, NY = 4, NZ = 3 };
    uint8_t r[NX * NY * NZ];
    gs_rng g;
    gs_rng_init(&g, 7, 1);
    for (int i = 0; i < NX * NY * NZ; i++)
        r[i] = gs_rng_below(&g, 3) == 0;
    const int64_t ws[2][3] = {{7, 3, 5}, {2, 4, 1}};
    for (int t = 0; t < 2; t++) {
        const int64_t *w = ws[t];
        double blo = 1, bhi = 0;
        for (int oz = 0; oz < NZ; oz++)
            for (int oy = 0; oy < NY; oy++)
                for (int ox = 0; ox < NX; ox++) {
                    int64_t c = 0;
                    for (int64_t z = 0; z < w[2]; z++)
                        for (int64_t y = 0; y < w[1]; y++)
                            for (int64_t x = 0; x < w[0]; x++)
                                c += r[(ox + x) % NX + NX * ((oy + y) % NY + NY * ((oz + z) % NZ))];
                    double f = (double)c / (double)(w[0] * w[1] * w[2]);
                    blo = f < blo ? f : blo, bhi = f > bhi ? f : bhi;
                }
        assert_int_equal(gs_measure_window_share_range(r, (const int64_t[3]){NX, NY, NZ}, w, &lo,
                                                       &hi), GS_OK);
        assert_true(fabs(lo - blo) < 1e-12 && fabs(hi - bhi) < 1e-12);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_l1),
        cmocka_unit_test(test_ks),
        cmocka_unit_test(test_components),
        cmocka_unit_test(test_component_euler),
        cmocka_unit_test(test_point_pieces),
        cmocka_unit_test(test_point_nearest),
        cmocka_unit_test(test_point_seams),
        cmocka_unit_test(test_point_seams_curved),
        cmocka_unit_test(test_preview),
        cmocka_unit_test(test_preview_turn),
        cmocka_unit_test(test_geodesic),
        cmocka_unit_test(test_lattice_measures),
        cmocka_unit_test(test_land_interior),
        cmocka_unit_test(test_enclosure),
        cmocka_unit_test(test_layout),
        cmocka_unit_test(test_object_fragments),
        cmocka_unit_test(test_copy_periodic),
        cmocka_unit_test(test_copy_repetitive),
        cmocka_unit_test(test_copy_reference),
        cmocka_unit_test(test_copy_below_unmatched),
        cmocka_unit_test(test_components_nested),
        cmocka_unit_test(test_layout_components),
        cmocka_unit_test(test_outline),
        cmocka_unit_test(test_repeats),
        cmocka_unit_test(test_heights),
        cmocka_unit_test(test_window_share),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
