/* Unit tests for the points engine building blocks: bucket grid, MLS
 * surface, thin-plate spline, generators and their padding check, search. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/error.h"
#include "geosynth/mem.h"
#include "geosynth/points.h"
#include "geosynth/rng.h"
#include "points/points_impl.h"

static void random_points(gs_points *s, size_t n, uint64_t seed)
{
    gs_rng r;
    gs_rng_init(&r, seed, 7);
    for (size_t i = 0; i < n; i++) {
        double p[3] = {gs_rng_uniform(&r) * 10 - 1, gs_rng_uniform(&r) * 8, gs_rng_uniform(&r) * 3};
        double nn[3] = {0, 0, 1};
        assert_int_equal(gs_points_push(s, p, nn), GS_OK);
    }
}

static int cmp_opoint(const void *a, const void *b)
{
    return memcmp(a, b, sizeof(gs_opoint));
}

static void test_grid_vs_brute_force(void **state)
{
    (void)state;
    gs_points pts = {0}, got = {0};
    random_points(&pts, 3000, 1);
    double lo[3] = {0, 0, 0}, hi[3] = {8, 8, 3}; /* some points lie outside: border buckets */
    gs_points_grid_t g = NULL;
    assert_int_equal(gs_points_grid_create(lo, hi, 0.7, &g), GS_OK);
    for (size_t i = 0; i < pts.n; i++)
        assert_int_equal(gs_points_grid_add(g, &pts.v[i]), GS_OK);
    assert_int_equal(gs_points_grid_count(g), 3000);
    gs_rng r;
    gs_rng_init(&r, 3, 3);
    for (int t = 0; t < 200; t++) {
        double c[3] = {gs_rng_uniform(&r) * 12 - 2, gs_rng_uniform(&r) * 10 - 1,
                       gs_rng_uniform(&r) * 5 - 1};
        double rad = 0.1 + 1.5 * gs_rng_uniform(&r);
        got.n = 0;
        assert_int_equal(gs_points_grid_query(g, c, rad, &got), GS_OK);
        size_t expect = 0;
        for (size_t i = 0; i < pts.n; i++) {
            double dx = pts.v[i].p[0] - c[0], dy = pts.v[i].p[1] - c[1], dz = pts.v[i].p[2] - c[2];
            expect += dx * dx + dy * dy + dz * dz <= rad * rad;
        }
        assert_int_equal(got.n, expect);
    }
    /* Remove an xy box, compare with brute force; the rest survives intact. */
    double blo[2] = {2, 1.5}, bhi[2] = {5.5, 4};
    size_t inbox = 0;
    for (size_t i = 0; i < pts.n; i++)
        inbox += pts.v[i].p[0] >= 2 && pts.v[i].p[0] < 5.5 && pts.v[i].p[1] >= 1.5 &&
                 pts.v[i].p[1] < 4;
    assert_true(inbox > 100);
    assert_int_equal(gs_points_grid_remove_xy(g, blo, bhi), inbox);
    got.n = 0;
    assert_int_equal(gs_points_grid_collect(g, &got), GS_OK);
    assert_int_equal(got.n, 3000 - inbox);
    gs_points keep = {0};
    for (size_t i = 0; i < pts.n; i++)
        if (!(pts.v[i].p[0] >= 2 && pts.v[i].p[0] < 5.5 && pts.v[i].p[1] >= 1.5 &&
              pts.v[i].p[1] < 4))
            assert_int_equal(gs_points_append(&keep, &pts.v[i], 1), GS_OK);
    qsort(keep.v, keep.n, sizeof *keep.v, cmp_opoint);
    qsort(got.v, got.n, sizeof *got.v, cmp_opoint);
    assert_memory_equal(keep.v, got.v, keep.n * sizeof *keep.v);
    got.n = 0;
    assert_int_equal(gs_points_grid_query_xy(g, blo, bhi, &got), GS_OK);
    assert_int_equal(got.n, 0);
    gs_points_grid_destroy(&g);
    assert_null(g);
    gs_points_free(&pts);
    gs_points_free(&got);
    gs_points_free(&keep);
}

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

/* The index grid answers exactly the brute-force set of indices within r
 * (also for points outside its bounds), each once; gs_points_grid_any_within
 * says whether
 * a point lies strictly closer than r. */
static void test_index_grid_vs_brute_force(void **state)
{
    (void)state;
    gs_points pts = {0};
    random_points(&pts, 3000, 5);
    double lo[3] = {0, 0, 0}, hi[3] = {8, 8, 3}; /* some points lie outside: border buckets */
    gs_points_index_grid *ig = NULL;
    assert_int_equal(gs_points_index_grid_create(pts.v, pts.n, lo, hi, 0.6, &ig), GS_OK);
    gs_points_grid_t g = NULL;
    assert_int_equal(gs_points_grid_create(lo, hi, 0.6, &g), GS_OK);
    for (size_t i = 0; i < pts.n; i++)
        assert_int_equal(gs_points_grid_add(g, &pts.v[i]), GS_OK);
    gs_points_indices got = {0};
    size_t *expect = malloc(pts.n * sizeof *expect);
    assert_non_null(expect);
    gs_rng r;
    gs_rng_init(&r, 9, 3);
    for (int t = 0; t < 200; t++) {
        double c[3] = {gs_rng_uniform(&r) * 12 - 2, gs_rng_uniform(&r) * 10 - 1,
                       gs_rng_uniform(&r) * 5 - 1};
        double rad = 0.05 + 1.2 * gs_rng_uniform(&r);
        got.n = 0;
        assert_int_equal(gs_points_index_grid_query(ig, c, rad, &got), GS_OK);
        size_t ne = 0, closer = 0;
        for (size_t i = 0; i < pts.n; i++) {
            double dx = pts.v[i].p[0] - c[0], dy = pts.v[i].p[1] - c[1], dz = pts.v[i].p[2] - c[2];
            double d2 = dx * dx + dy * dy + dz * dz;
            if (d2 <= rad * rad)
                expect[ne++] = i;
            closer += d2 < rad * rad;
        }
        assert_int_equal(got.n, ne);
        qsort(got.v, got.n, sizeof *got.v, cmp_size);
        if (ne)
            assert_memory_equal(got.v, expect, ne * sizeof *expect);
        assert_int_equal(gs_points_grid_any_within(g, c, rad), closer > 0);
    }
    free(expect);
    gs_free(got.v);
    gs_points_index_grid_destroy(&ig);
    assert_null(ig);
    gs_points_grid_destroy(&g);
    gs_points_free(&pts);
}

/* Points on a sphere of radius rad (Fibonacci lattice), outward normals. */
static void sphere_points(gs_points *s, int n, double rad)
{
    for (int i = 0; i < n; i++) {
        double z = 1 - (2.0 * i + 1) / n, r = sqrt(1 - z * z), phi = i * 2.399963229728653;
        double nn[3] = {r * cos(phi), r * sin(phi), z};
        double p[3] = {rad * nn[0], rad * nn[1], rad * nn[2]};
        assert_int_equal(gs_points_push(s, p, nn), GS_OK);
    }
}

/* The ring search of gs_points_grid_nearest equals brute force: smallest
 * distance within the reach, ties to the first point in query order. */
static void test_grid_nearest_vs_brute_force(void **state)
{
    (void)state;
    gs_points pts = {0}, scratch = {0};
    random_points(&pts, 2000, 11);
    for (size_t i = 0; i < 200; i++) { /* exact duplicates: ties */
        gs_opoint dup = pts.v[i * 7]; /* a copy: appending may move pts.v */
        assert_int_equal(gs_points_append(&pts, &dup, 1), GS_OK);
    }
    double lo[3] = {0, 0, 0}, hi[3] = {8, 8, 3};
    gs_points_grid_t g = NULL;
    assert_int_equal(gs_points_grid_create(lo, hi, 0.45, &g), GS_OK);
    for (size_t i = 0; i < pts.n; i++)
        assert_int_equal(gs_points_grid_add(g, &pts.v[i]), GS_OK);
    gs_rng r;
    gs_rng_init(&r, 4, 4);
    for (int t = 0; t < 400; t++) {
        double c[3] = {gs_rng_uniform(&r) * 14 - 3, gs_rng_uniform(&r) * 12 - 2,
                       gs_rng_uniform(&r) * 9 - 3};
        if (t % 5 == 0) /* right on a sample: distance 0 and its duplicate */
            memcpy(c, pts.v[(t * 7) % 1400].p, sizeof c);
        double reach = 0.05 + 4 * gs_rng_uniform(&r);
        gs_opoint got;
        int found;
        assert_int_equal(gs_points_grid_nearest(g, c, reach, &scratch, &got, &found), GS_OK);
        /* reference: the first minimum of a full query in query order */
        scratch.n = 0;
        assert_int_equal(gs_points_grid_query(g, c, reach, &scratch), GS_OK);
        size_t best = 0;
        for (size_t i = 1; i < scratch.n; i++)
            if (v3_dist2(scratch.v[i].p, c) < v3_dist2(scratch.v[best].p, c))
                best = i;
        assert_int_equal(found, scratch.n > 0);
        if (found)
            assert_memory_equal(&got, &scratch.v[best], sizeof got);
    }
    gs_points_grid_destroy(&g);
    gs_points_free(&pts);
    gs_points_free(&scratch);
}

/* The degree-2 MLS (gs_points_mls_quadric) keeps a tube as thin as the
 * chain mail's (radius 0.075, spacing 0.033, R = 0.099: the strip
 * resampling's darts) at its radius, where the frame's plane lies inside
 * it (the darts sat 0.0045 inside the copied points). */
static void test_mls_quadric_tube(void **state)
{
    (void)state;
    const double rt = 0.075, R = 0.099;
    gs_points pts = {0};
    gs_rng r;
    gs_rng_init(&r, 9, 9);
    for (int k = 0; k < 31; k++)
        for (int i = 0; i < 14; i++) {
            double th = 2 * GS_PI * (i + 0.5 * (k & 1) + 0.2 * gs_rng_uniform(&r)) / 14;
            double p[3] = {rt * cos(th), rt * sin(th), 0.033 * k + 0.005 * gs_rng_uniform(&r)};
            double nn[3] = {cos(th), sin(th), 0};
            assert_int_equal(gs_points_push(&pts, p, nn), GS_OK);
        }
    double worst_q = 0, mean_plane = 0;
    for (int t = 0; t < 40; t++) {
        double th = 2 * GS_PI * gs_rng_uniform(&r), rr = rt + 0.02 * (gs_rng_uniform(&r) - 0.5);
        double x[3] = {rr * cos(th), rr * sin(th), 0.4 + 0.2 * gs_rng_uniform(&r)};
        double y[3], yq[3], n[3], a[3], np[3];
        memcpy(y, x, sizeof y);
        memcpy(yq, x, sizeof yq);
        for (int it = 0; it < 3; it++) {
            double z[3];
            assert_true(gs_points_mls_quadric(&pts, R, yq, x, z, n) > 0);
            memcpy(yq, z, sizeof z);
            assert_true(gs_points_mls_frame(&pts, R, y, a, np) > 0);
            double d = (x[0] - a[0]) * np[0] + (x[1] - a[1]) * np[1] + (x[2] - a[2]) * np[2];
            for (int b = 0; b < 3; b++)
                y[b] = x[b] - d * np[b];
        }
        worst_q = fmax(worst_q, fabs(hypot(yq[0], yq[1]) - rt));
        mean_plane += (rt - hypot(y[0], y[1])) / 40;
        assert_true(n[0] * cos(th) + n[1] * sin(th) > 0.99);
    }
    assert_true(mean_plane > 0.003); /* the plane: well inside */
    assert_true(worst_q < 0.0015);   /* the quadratic: on the tube */
    gs_points_free(&pts);
}

static void test_mls_projection_plane_sphere(void **state)
{
    (void)state;
    /* Plane z = 0.3 sampled on a jittered grid. */
    gs_points pts = {0}, scratch = {0};
    gs_rng r;
    gs_rng_init(&r, 5, 5);
    for (int j = 0; j < 40; j++)
        for (int i = 0; i < 40; i++) {
            double p[3] = {i * 0.1 + 0.03 * gs_rng_uniform(&r), j * 0.1 + 0.03 * gs_rng_uniform(&r),
                           0.3};
            double nn[3] = {0, 0, 1};
            assert_int_equal(gs_points_push(&pts, p, nn), GS_OK);
        }
    double lo[3] = {-1, -1, -1}, hi[3] = {5, 5, 2};
    gs_points_grid_t g = NULL;
    assert_int_equal(gs_points_grid_create(lo, hi, 0.35, &g), GS_OK);
    for (size_t i = 0; i < pts.n; i++)
        assert_int_equal(gs_points_grid_add(g, &pts.v[i]), GS_OK);
    for (int t = 0; t < 20; t++) {
        double x[3] = {1 + 2 * gs_rng_uniform(&r), 1 + 2 * gs_rng_uniform(&r),
                       0.3 + 0.6 * (gs_rng_uniform(&r) - 0.5)};
        gs_points_mls_result res;
        assert_int_equal(gs_points_mls_project(g, 0.3, 2.0, x, &scratch, &res), GS_OK);
        assert_true(res.ok);
        assert_true(fabs(res.y[2] - 0.3) < 1e-9);
        assert_true(fabs(res.y[0] - x[0]) < 1e-9 && fabs(res.y[1] - x[1]) < 1e-9);
        assert_true(fabs(res.dist - (x[2] - 0.3)) < 1e-9);
        assert_true(res.n[2] > 0.999999);
    }
    /* Far above the plane: sign and gradient from the nearest sample. */
    double far[3] = {2, 2, 1.9};
    gs_points_mls_result fr;
    assert_int_equal(gs_points_mls_project(g, 0.3, 3.0, far, &scratch, &fr), GS_OK);
    assert_true(fr.dist > 1.0);
    gs_points_grid_destroy(&g);
    gs_points_free(&pts);

    /* Sphere of radius 1: projections converge close to the sphere. */
    sphere_points(&pts, 4000, 1.0);
    double slo[3] = {-2, -2, -2}, shi[3] = {2, 2, 2};
    assert_int_equal(gs_points_grid_create(slo, shi, 0.2, &g), GS_OK);
    for (size_t i = 0; i < pts.n; i++)
        assert_int_equal(gs_points_grid_add(g, &pts.v[i]), GS_OK);
    double worst = 0, worst_sd = 0;
    for (int t = 0; t < 50; t++) {
        double d[3] = {gs_rng_normal(&r), gs_rng_normal(&r), gs_rng_normal(&r)};
        double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        double rr = 0.85 + 0.3 * gs_rng_uniform(&r);
        double x[3] = {rr * d[0] / l, rr * d[1] / l, rr * d[2] / l};
        gs_points_mls_result res;
        assert_int_equal(gs_points_mls_project(g, 0.2, 2.0, x, &scratch, &res), GS_OK);
        assert_true(res.ok);
        double ry = sqrt(res.y[0] * res.y[0] + res.y[1] * res.y[1] + res.y[2] * res.y[2]);
        worst = fmax(worst, fabs(ry - 1));
        worst_sd = fmax(worst_sd, fabs(res.dist - (rr - 1)));
        double ndot = (res.n[0] * res.y[0] + res.n[1] * res.y[1] + res.n[2] * res.y[2]) / ry;
        assert_true(ndot > 0.999);
    }
    assert_true(worst < 0.01);     /* MLS shrinks a sphere slightly */
    assert_true(worst_sd < 0.015);
    /* Distance field inside/outside signs. */
    float f[4 * 3];
    double flo[3] = {0, 0, 0.5}, step[3] = {1, 1, 0.5};
    assert_int_equal(gs_points_field(g, 0.2, 0.25, 2.0, flo, step, 1, 1, 3, f), GS_OK);
    assert_true(f[0] < -0.99f);                     /* z = 0.5: inside, clamped */
    assert_true(fabs(f[4]) < 0.05f && f[7] > 0.99f); /* z = 1: on the surface, normal +z */
    assert_true(f[8] > 0.99f);                      /* z = 1.5: outside */
    gs_points_grid_destroy(&g);
    gs_points_free(&pts);
    gs_points_free(&scratch);
}

static void test_tps_interpolates_and_affine(void **state)
{
    (void)state;
    gs_rng r;
    gs_rng_init(&r, 11, 1);
    enum { N = 30 };
    double src[3 * N], dst[3 * N];
    for (int i = 0; i < 3 * N; i++)
        src[i] = gs_rng_uniform(&r) * 4;
    for (int i = 0; i < 3 * N; i++)
        dst[i] = src[i] + 0.3 * gs_rng_normal(&r);
    gs_points_tps t;
    assert_int_equal(gs_points_tps_fit(src, dst, N, 0.0, &t), GS_OK);
    for (int i = 0; i < N; i++) {
        double y[3];
        gs_points_tps_eval(&t, src + 3 * i, y, NULL);
        for (int d = 0; d < 3; d++)
            assert_true(fabs(y[d] - dst[3 * i + d]) < 1e-8);
    }
    gs_points_tps_free(&t);
    /* An affine map is reproduced everywhere, Jacobian = its matrix. */
    const double M[9] = {1.1, 0.2, -0.1, 0.05, 0.9, 0.3, -0.2, 0.1, 1.3}, b[3] = {0.5, -1, 2};
    for (int i = 0; i < N; i++)
        for (int d = 0; d < 3; d++)
            dst[3 * i + d] = b[d] + M[3 * d] * src[3 * i] + M[3 * d + 1] * src[3 * i + 1] +
                             M[3 * d + 2] * src[3 * i + 2];
    assert_int_equal(gs_points_tps_fit(src, dst, N, 0.0, &t), GS_OK);
    for (int k = 0; k < 20; k++) {
        double x[3] = {gs_rng_uniform(&r) * 6 - 1, gs_rng_uniform(&r) * 6 - 1,
                       gs_rng_uniform(&r) * 6 - 1};
        double y[3], J[9];
        gs_points_tps_eval(&t, x, y, J);
        for (int d = 0; d < 3; d++) {
            double e = b[d] + M[3 * d] * x[0] + M[3 * d + 1] * x[1] + M[3 * d + 2] * x[2];
            assert_true(fabs(y[d] - e) < 1e-7);
        }
        for (int i = 0; i < 9; i++)
            assert_true(fabs(J[i] - M[i]) < 1e-7);
    }
    /* Normals transform like the inverse transpose. */
    double n[3] = {0, 0.6, 0.8}, nt[3], J[9], y[3];
    double x0[3] = {1, 1, 1};
    gs_points_tps_eval(&t, x0, y, J);
    gs_points_tps_normal(J, n, nt);
    /* tangent u = (1,0,0) maps to J u; must stay orthogonal to the new normal */
    double ju[3] = {J[0], J[3], J[6]};
    assert_true(fabs(ju[0] * nt[0] + ju[1] * nt[1] + ju[2] * nt[2]) < 1e-9);
    assert_true(nt[0] * n[0] + nt[1] * n[1] + nt[2] * n[2] > 0.5);
    gs_points_tps_free(&t);
    /* Coplanar controls: clear error, output untouched. */
    for (int i = 0; i < N; i++)
        src[3 * i + 2] = 0;
    gs_points_tps t2 = {0};
    assert_int_equal(gs_points_tps_fit(src, src, N, 0.0, &t2), GS_ERR_ARG);
    assert_null(t2.c);
    gs_error_clear();
}

static void test_generators_and_padding_check(void **state)
{
    (void)state;
    enum { W = 32 };
    uint8_t img[W * W];
    for (int j = 0; j < W; j++)
        for (int i = 0; i < W; i++)
            img[j * W + i] = (uint8_t)(127.5 + 127 * sin(i * 0.6) * cos(j * 0.45));
    gs_points_gen_params gp = {{4, 4}, 1.0, 0.1, 42, 0, NULL, NULL, NULL};
    gs_points_texture t;
    assert_int_equal(gs_points_gen_heightfield(&gp, W, W, img, NULL, 0.5, &t), GS_OK);
    assert_true(t.pts.n > 1500);
    /* Poisson-disk: no two points closer than the spacing; unit normals pointing up. */
    double lo[3] = {-1.5, -1.5, -1}, hi[3] = {5.5, 5.5, 2};
    gs_points_grid_t g = NULL;
    gs_points nb = {0};
    assert_int_equal(gs_points_grid_create(lo, hi, 0.1, &g), GS_OK);
    for (size_t i = 0; i < t.pts.n; i++)
        assert_int_equal(gs_points_grid_add(g, &t.pts.v[i]), GS_OK);
    for (size_t i = 0; i < t.pts.n; i += 7) {
        nb.n = 0;
        assert_int_equal(gs_points_grid_query(g, t.pts.v[i].p, 0.0999, &nb), GS_OK);
        assert_int_equal(nb.n, 1);
        const double *n = t.pts.v[i].n;
        assert_true(fabs(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1) < 1e-9);
        assert_true(n[2] > 0);
    }
    gs_points_grid_destroy(&g);
    gs_points_free(&nb);
    assert_int_equal(gs_points_texture_check(&t, 0.8), GS_OK);
    /* Needing more than the padding is reported with the side and the numbers. */
    assert_int_equal(gs_points_texture_check(&t, 1.6), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "past the bounding box"));
    gs_error_clear();
    gs_points_texture_free(&t);
    gp.pad = 0;
    assert_int_equal(gs_points_gen_heightfield(&gp, W, W, img, NULL, 0.5, &t), GS_OK);
    assert_int_equal(gs_points_texture_check(&t, 0.5), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "side -x"));
    gs_error_clear();
    gs_points_texture_free(&t);
    /* Bad image arguments. */
    assert_int_equal(gs_points_gen_heightfield(&gp, W, W, NULL, NULL, 0.5, &t), GS_ERR_ARG);
    gs_error_clear();

    /* The other kinds: non-empty, padded, with the expected outward normals. */
    gs_points_gen_params gq = {{3, 3}, 0.8, 0.06, 9, 0, NULL, NULL, NULL};
    gs_err (*gens[3])(const gs_points_gen_params *, int, gs_points_texture *) = {
        gs_points_gen_chainmail, gs_points_gen_weave, gs_points_gen_flowers};
    for (int k = 0; k < 3; k++) {
        assert_int_equal(gens[k](&gq, 3, &t), GS_OK);
        printf("generator %d: %zu points, z [%g, %g]\n", k, t.pts.n, t.box_lo[2], t.box_hi[2]);
        assert_true(t.pts.n > 1000);
        assert_true(t.box_hi[2] > t.box_lo[2]);
        assert_int_equal(gs_points_texture_check(&t, 0.6), GS_OK);
        /* normals point away from the mean surface: the top-most point faces up */
        size_t top = 0;
        for (size_t i = 1; i < t.pts.n; i++)
            if (t.pts.v[i].p[2] > t.pts.v[top].p[2])
                top = i;
        assert_true(t.pts.v[top].n[2] > 0.8);
        gs_points_texture_free(&t);
    }
}

/* A running (1 + eps) * best threshold, as gs_psearch_within keeps it. */
typedef struct scan_acc {
    gs_points_cands c;
    double best, eps;
} scan_acc;

static double scan_bound(void *user)
{
    scan_acc *a = user;
    return (1.0 + a->eps) * a->best;
}

static void scan_offer(void *user, double d, uint64_t index)
{
    scan_acc *a = user;
    assert_true(d <= scan_bound(user));
    if (a->c.n == a->c.cap) {
        a->c.cap = a->c.cap ? 2 * a->c.cap : 64;
        a->c.v = gs_realloc(a->c.v, a->c.cap * sizeof *a->c.v);
        assert_non_null(a->c.v);
    }
    a->c.v[a->c.n].dist = d;
    a->c.v[a->c.n++].index = index;
    if (d < a->best)
        a->best = d;
}

static void test_search_partition_matches_serial(void **state)
{
    (void)state;
    int nx = 20, ny = 18, nz = 3;
    gs_points_layout l;
    gs_points_layout_init(&l, 6, 2, nz);
    float *field = gs_malloc(sizeof(float) * 4 * nx * ny * nz);
    gs_rng r;
    gs_rng_init(&r, 2, 2);
    for (int i = 0; i < 4 * nx * ny * nz; i++)
        field[i] = (float)gs_rng_uniform(&r);
    size_t total = gs_points_bank_total(nx, ny, &l);
    assert_int_equal(total, 14 * 12);
    /* Query = the field of patch 37 plus a little noise. */
    gs_points_bank_t all = NULL;
    assert_int_equal(gs_points_bank_create(field, nx, ny, &l, 0, total, &all), GS_OK);
    size_t nf = gs_points_layout_floats(&l);
    float *q = gs_malloc(nf * sizeof *q);
    for (size_t i = 0; i < nf; i++) {
        int a, b, k;
        gs_points_layout_node(&l, i / 4, &a, &b, &k);
        int pi = 37 % 14, pj = 37 / 14;
        q[i] = field[4 * ((k * ny + pj + b) * nx + pi + a) + i % 4] + 0.2f * (float)gs_rng_normal(&r);
    }
    for (int mode = 1; mode <= 3; mode++) {
        gs_points_cands serial = {0}, merged = {0}, parts[3] = {{0}};
        assert_int_equal(gs_points_search_local(all, q, mode, 6.0, INFINITY, &serial), GS_OK);
        gs_points_cands ser_sorted = {0};
        assert_int_equal(gs_points_search_merge(&serial, 1, 6.0, &ser_sorted), GS_OK);
        assert_int_equal(ser_sorted.v[0].index, 37);
        assert_true(ser_sorted.n > 1);
        /* Three uneven shares with a shared bound, merged: same list. */
        size_t cut[4] = {0, 50, 51, total};
        double bound = INFINITY;
        for (int s = 0; s < 3; s++) {
            gs_points_bank_t b = NULL;
            assert_int_equal(gs_points_bank_create(field, nx, ny, &l, cut[s], cut[s + 1] - cut[s], &b),
                             GS_OK);
            assert_int_equal(gs_points_search_local(b, q, mode, 6.0, bound, &parts[s]), GS_OK);
            bound = fmin(bound, parts[s].best);
            gs_points_bank_destroy(&b);
        }
        assert_int_equal(gs_points_search_merge(parts, 3, 6.0, &merged), GS_OK);
        assert_int_equal(merged.n, ser_sorted.n);
        for (size_t i = 0; i < merged.n; i++) {
            assert_true(merged.v[i].index == ser_sorted.v[i].index);
            assert_true(merged.v[i].dist == ser_sorted.v[i].dist);
            assert_true(merged.v[i].dist <= 7.0 * merged.v[0].dist);
        }
        /* Bounded scans (the gs_psearch callback path) with one running
         * threshold (1 + eps) * best over the shares: same list again. */
        scan_acc acc = {{0}, INFINITY, 6.0};
        for (int s = 0; s < 3; s++) {
            gs_points_bank_t b = NULL;
            assert_int_equal(gs_points_bank_create(field, nx, ny, &l, cut[s], cut[s + 1] - cut[s], &b),
                             GS_OK);
            size_t f0, fc;
            gs_points_bank_share(b, &f0, &fc);
            assert_int_equal(f0, cut[s]);
            assert_int_equal(fc, cut[s + 1] - cut[s]);
            assert_int_equal(gs_points_search_scan(b, q, mode, f0, f0 + fc, scan_bound, scan_offer, &acc),
                             GS_OK);
            /* A range outside the share is refused. */
            assert_int_equal(gs_points_search_scan(b, q, mode, f0, f0 + fc + 1, scan_bound, scan_offer,
                                                   &acc), GS_ERR_ARG);
            gs_error_clear();
            gs_points_bank_destroy(&b);
        }
        gs_points_cands scanned = {0};
        assert_int_equal(gs_points_search_merge(&acc.c, 1, 6.0, &scanned), GS_OK);
        assert_true(acc.c.n >= scanned.n);
        assert_int_equal(scanned.n, ser_sorted.n);
        for (size_t i = 0; i < scanned.n; i++) {
            assert_true(scanned.v[i].index == ser_sorted.v[i].index);
            assert_true(scanned.v[i].dist == ser_sorted.v[i].dist);
        }
        gs_points_cands_free(&scanned);
        gs_free(acc.c.v);
        gs_rng pick;
        gs_rng_init(&pick, 1, 1);
        uint64_t c = gs_points_search_pick(&merged, &pick);
        assert_true(c < total);
        gs_points_cands_free(&serial);
        gs_points_cands_free(&ser_sorted);
        gs_points_cands_free(&merged);
        for (int s = 0; s < 3; s++)
            gs_points_cands_free(&parts[s]);
    }
    gs_points_bank_destroy(&all);
    gs_free(field);
    gs_free(q);
}

/* The paper's pairing (eqs. 1-3, the iterated greedy) written plainly: every
 * S point tested for every target in S order, weights formed where used. */
static void pairing_reference(const gs_points_pairing_in *in, long *pair)
{
    const gs_points_params *p = in->p;
    size_t nq = in->nq, ns = in->ns;
    double inv_sp = 1.0 / in->spacing, md2 = p->max_pair_dist * p->max_pair_dist;
    double *c = malloc(nq * ns * sizeof *c), *fl = malloc(nq * sizeof *fl);
    double *fd = malloc(3 * nq * sizeof *fd);
    long *prev = malloc(nq * sizeof *prev);
    unsigned char *used = calloc(ns, 1);
    assert_non_null(c);
    for (size_t q = 0; q < nq; q++)
        for (size_t k = 0; k < ns; k++) {
            const gs_opoint *a = &in->S[k], *b = &in->Q[q];
            double d2 = v3_dist2(a->p, b->p), nt = 0.5 * (1.0 - v3_dot(a->n, b->n));
            double dv = in->Sv[k] - in->Qv[q];
            c[q * ns + k] = d2 > md2 || nt > p->max_normal || fabs(dv) > p->max_variation
                                ? INFINITY
                                : p->w_p * sqrt(d2) * inv_sp + p->w_n * nt + p->w_v * dv * dv;
        }
    for (size_t q = 0; q < nq; q++) {
        long best = -1;
        double bc = INFINITY;
        for (size_t k = 0; k < ns; k++)
            if (!used[k] && c[q * ns + k] < bc) {
                bc = c[q * ns + k];
                best = (long)k;
            }
        pair[q] = best;
        if (best >= 0)
            used[best] = 1;
    }
    double two_sig2 = 2.0 * p->coherence_sigma * p->coherence_sigma;
    for (int it = 0; it < p->greedy_iterations; it++) {
        memcpy(prev, pair, nq * sizeof *prev);
        for (size_t q = 0; q < nq; q++) {
            double sw = 0, sl = 0, sd[3] = {0, 0, 0};
            for (size_t r = 0; r < nq; r++) {
                if (r == q || prev[r] < 0)
                    continue;
                double th = exp(-v3_dist2(in->Q[q].p, in->Q[r].p) / two_sig2);
                const double *pt = in->S[prev[r]].p, *pr = in->Q[r].p;
                double e[3] = {pt[0] - pr[0], pt[1] - pr[1], pt[2] - pr[2]};
                sw += th;
                sl += th * sqrt(v3_dot(e, e));
                for (int k = 0; k < 3; k++)
                    sd[k] += th * e[k];
            }
            fl[q] = sw > 0 ? sl / sw : -1;
            v3_normalize(sd);
            memcpy(fd + 3 * q, sd, sizeof sd);
        }
        memset(used, 0, ns);
        for (size_t q = 0; q < nq; q++) {
            pair[q] = -1;
            if (prev[q] < 0)
                continue;
            double bc = INFINITY;
            for (size_t k = 0; k < ns; k++) {
                if (used[k] || !isfinite(c[q * ns + k]))
                    continue;
                double cost = c[q * ns + k];
                if (fl[q] >= 0) {
                    const double *ps = in->S[k].p, *pq = in->Q[q].p;
                    double e[3] = {ps[0] - pq[0], ps[1] - pq[1], ps[2] - pq[2]};
                    double len = sqrt(v3_dot(e, e));
                    cost += p->w_l * fabs(len - fl[q]) * inv_sp;
                    if (len > 0)
                        cost += 0.5 * p->w_d * (1.0 - v3_dot(fd + 3 * q, e) / len);
                }
                if (cost < bc) {
                    bc = cost;
                    pair[q] = (long)k;
                }
            }
            if (pair[q] >= 0)
                used[pair[q]] = 1;
        }
    }
    free(c);
    free(fl);
    free(fd);
    free(prev);
    free(used);
}

/* gs_points_pairing (xy buckets, tabulated weights) pairs exactly as the
 * plain full scan: strips like the synthesis's, wide and narrow pairing
 * distances, and S with exact duplicates (equal costs: lowest index). */
static void test_pairing_matches_full_scan(void **state)
{
    (void)state;
    gs_rng r;
    gs_rng_init(&r, 11, 3);
    int checked = 0;
    for (int trial = 0; trial < 24; trial++) {
        size_t ns = 200 + gs_rng_below(&r, 1200), nq = 8 + gs_rng_below(&r, 90);
        gs_opoint *S = malloc(ns * sizeof *S), *Q = malloc(nq * sizeof *Q);
        double *Sv = malloc(ns * sizeof *Sv), *Qv = malloc(nq * sizeof *Qv);
        long *got = malloc(nq * sizeof *got), *want = malloc(nq * sizeof *want);
        assert_non_null(S);
        assert_non_null(Q);
        /* an L-shaped strip of width 0.4 around a 1.6 patch, z a bumpy layer */
        for (size_t i = 0; i < ns + nq; i++) {
            gs_opoint *o = i < ns ? &S[i] : &Q[i - ns];
            double u = gs_rng_uniform(&r) * 2.0, v = gs_rng_uniform(&r) * 0.4;
            int left = gs_rng_below(&r, 2);
            o->p[0] = left ? v : u;
            o->p[1] = left ? u : v;
            o->p[2] = 0.05 * sin(9 * o->p[0]) * cos(7 * o->p[1]) + 0.02 * gs_rng_uniform(&r);
            double nn[3] = {0.3 * (gs_rng_uniform(&r) - 0.5), 0.3 * (gs_rng_uniform(&r) - 0.5), 1};
            v3_normalize(nn);
            memcpy(o->n, nn, sizeof nn);
            *(i < ns ? &Sv[i] : &Qv[i - ns]) = 0.05 * gs_rng_uniform(&r);
        }
        if (trial % 3 == 2) /* duplicates: every tenth S point repeats an earlier one */
            for (size_t i = 10; i < ns; i += 10) {
                size_t j = gs_rng_below(&r, i);
                S[i] = S[j];
                Sv[i] = Sv[j];
            }
        gs_points_params p;
        gs_points_params_default(4, 4, 0.033, &p);
        p.max_pair_dist = trial % 2 ? 0.05 + 0.3 * gs_rng_uniform(&r) : 5.0;
        p.greedy_iterations = (int)(trial % 4);
        gs_points_pairing_in in = {S, Sv, ns, Q, Qv, nq, &p, 0.033};
        assert_int_equal(gs_points_pairing(&in, got), GS_OK);
        pairing_reference(&in, want);
        for (size_t q = 0; q < nq; q++) {
            if (got[q] != want[q])
                fail_msg("trial %d: target %zu paired with %ld, full scan %ld", trial, q, got[q],
                         want[q]);
            checked += want[q] >= 0;
        }
        free(S);
        free(Q);
        free(Sv);
        free(Qv);
        free(got);
        free(want);
    }
    assert_true(checked > 500); /* the cases pair most targets */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_grid_vs_brute_force),
        cmocka_unit_test(test_index_grid_vs_brute_force),
        cmocka_unit_test(test_grid_nearest_vs_brute_force),
        cmocka_unit_test(test_mls_projection_plane_sphere),
        cmocka_unit_test(test_mls_quadric_tube),
        cmocka_unit_test(test_tps_interpolates_and_affine),
        cmocka_unit_test(test_generators_and_padding_check),
        cmocka_unit_test(test_search_partition_matches_serial),
        cmocka_unit_test(test_pairing_matches_full_scan),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
