/* Unit tests for the points engine's input side: uniform mesh sampling,
 * spacing estimate, non-periodic generated examples, reference-plane
 * permutations, implicit grid. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/error.h"
#include "geosynth/mem.h"
#include "geosynth/points.h"

/* A bumpy square sheet [0, L]^2, n x n quads, z = a sin(x) cos(y). */
static void sheet(int n, double L, double a, float **pos, uint32_t **tris, size_t *nv, size_t *nt)
{
    *nv = (size_t)(n + 1) * (n + 1);
    *nt = (size_t)2 * n * n;
    *pos = gs_malloc(*nv * 3 * sizeof **pos);
    *tris = gs_malloc(*nt * 3 * sizeof **tris);
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            float *p = *pos + 3 * ((size_t)j * (n + 1) + i);
            p[0] = (float)(L * i / n);
            p[1] = (float)(L * j / n);
            p[2] = (float)(a * sin(3 * p[0]) * cos(2 * p[1]));
        }
    size_t t = 0;
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            uint32_t v0 = (uint32_t)(j * (n + 1) + i), v1 = v0 + 1, v2 = v0 + (uint32_t)n + 1,
                     v3 = v2 + 1;
            uint32_t q[6] = {v0, v1, v3, v0, v3, v2}; /* counter-clockwise from +z */
            memcpy(*tris + 3 * t, q, sizeof q);
            t += 2;
        }
}

static void test_mesh_sampling(void **state)
{
    (void)state;
    float *pos;
    uint32_t *tris;
    size_t nv, nt;
    sheet(40, 2.0, 0.0, &pos, &tris, &nv, &nt);
    double s = 0.03;
    gs_points a = {0}, b = {0};
    assert_int_equal(gs_points_sample_mesh(pos, nv, tris, nt, s, 5, "sheet", &a), GS_OK);
    assert_int_equal(gs_points_sample_mesh(pos, nv, tris, nt, s, 5, "sheet", &b), GS_OK);
    assert_int_equal(a.n, b.n);
    assert_memory_equal(a.v, b.v, a.n * sizeof *a.v); /* same seed, same samples */
    /* Poisson disk: no two closer than s; normals up; dense enough. A
     * maximal disk packing of radius s has about 0.6-0.7 / s^2 points per
     * unit area; dart throwing with 9 tries per point gets most of it. */
    double dens = a.n / 4.0;
    printf("flat sheet: %zu samples, %.3f / s^2 per unit area\n", a.n, dens * s * s);
    assert_true(dens * s * s > 0.45 && dens * s * s < 0.8);
    for (size_t i = 0; i < a.n; i++) {
        assert_true(fabs(a.v[i].n[2] - 1) < 1e-9);
        assert_true(a.v[i].p[0] >= 0 && a.v[i].p[0] <= 2 && fabs(a.v[i].p[2]) < 1e-6);
        for (size_t j = i + 1; j < a.n; j++) {
            double dx = a.v[i].p[0] - a.v[j].p[0], dy = a.v[i].p[1] - a.v[j].p[1];
            if (fabs(dx) < s && fabs(dy) < s)
                assert_true(dx * dx + dy * dy >= s * s);
        }
    }
    /* Uniform by area: each quarter of the sheet holds about a quarter. */
    size_t q[4] = {0};
    for (size_t i = 0; i < a.n; i++)
        q[(a.v[i].p[0] >= 1) + 2 * (a.v[i].p[1] >= 1)]++;
    for (int k = 0; k < 4; k++)
        assert_true(fabs(q[k] / (double)a.n - 0.25) < 0.02);
    /* The spacing estimate recovers s within 12%. */
    double est;
    assert_int_equal(gs_points_estimate_spacing(&a, &est), GS_OK);
    printf("spacing estimate %.4f for %.4f\n", est, s);
    assert_true(fabs(est / s - 1) < 0.12);
    gs_points_free(&a);
    gs_points_free(&b);
    gs_free(pos);
    gs_free(tris);
    /* Bumpy sheet: normals follow the surface (up-facing, tilted). */
    sheet(80, 2.0, 0.2, &pos, &tris, &nv, &nt);
    assert_int_equal(gs_points_sample_mesh(pos, nv, tris, nt, s, 1, "bumps", &a), GS_OK);
    double maxtilt = 0;
    for (size_t i = 0; i < a.n; i++) {
        const double *p = a.v[i].p, *n = a.v[i].n;
        double gx = 0.2 * 3 * cos(3 * p[0]) * cos(2 * p[1]), gy = -0.2 * 2 * sin(3 * p[0]) * sin(2 * p[1]);
        double l = sqrt(gx * gx + gy * gy + 1);
        double dot = (-gx * n[0] - gy * n[1] + n[2]) / l;
        assert_true(dot > 0.98);
        maxtilt = fmax(maxtilt, 1 - n[2]);
    }
    assert_true(maxtilt > 0.1);
    gs_points_free(&a);
    /* Errors name the mesh. */
    assert_int_equal(gs_points_sample_mesh(pos, nv, tris, 0, s, 1, "empty.obj", &a), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "empty.obj"));
    gs_error_clear();
    assert_int_equal(gs_points_sample_mesh(pos, nv, tris, nt, 1e-6, 1, "huge.obj", &a), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "use a larger spacing"));
    gs_error_clear();
    gs_free(pos);
    gs_free(tris);
}

static void test_spacing_estimate_generators(void **state)
{
    (void)state;
    double s = 0.04;
    gs_points_gen_params gp = {{2, 2}, 0.5, s, 7, 0, NULL, NULL, NULL};
    gs_points_texture t;
    for (int kind = 0; kind < 3; kind++) {
        gs_err e = kind == 0 ? gs_points_gen_chainmail(&gp, 2, &t)
                   : kind == 1 ? gs_points_gen_weave(&gp, 2, &t)
                               : gs_points_gen_flowers(&gp, 2, &t);
        assert_int_equal(e, GS_OK);
        double est;
        assert_int_equal(gs_points_estimate_spacing(&t.pts, &est), GS_OK);
        printf("generator %d: spacing estimate %.4f for %.4f\n", kind, est, s);
        assert_true(fabs(est / s - 1) < 0.15);
        gs_points_texture_free(&t);
    }
    gs_points few = {0};
    double p[3] = {0, 0, 0}, n[3] = {0, 0, 1};
    assert_int_equal(gs_points_push(&few, p, n), GS_OK);
    double est;
    assert_int_equal(gs_points_estimate_spacing(&few, &est), GS_ERR_ARG);
    gs_error_clear();
    gs_points_free(&few);
}

/* Share of the points in [0.25, 0.75] x [0.25, 1.75] that, moved by the
 * pattern's period (2 lattice cells: rings lean, threads go over and under,
 * alternately) along x (and dy along y: threads along x move onto others),
 * lie farther than far from every point of t:
 * a tileable example lies on itself (two samplings of one surface), a
 * jittered one does not. */
static double shifted_nn(const gs_points_texture *t, double dy, double far)
{
    double sum = 0;
    size_t n = 0;
    for (size_t i = 0; i < t->pts.n; i++) {
        const double *p = t->pts.v[i].p;
        if (p[0] < 0.25 || p[0] > 0.75 || p[1] < 0.25 || p[1] > 1.75)
            continue;
        double q[3] = {p[0] + 2, p[1] + dy, p[2]}, best = INFINITY;
        for (size_t j = 0; j < t->pts.n; j++) {
            const double *r = t->pts.v[j].p;
            double d = (r[0] - q[0]) * (r[0] - q[0]) + (r[1] - q[1]) * (r[1] - q[1]) +
                       (r[2] - q[2]) * (r[2] - q[2]);
            best = d < best ? d : best;
        }
        sum += sqrt(best) > far;
        n++;
    }
    assert_true(n > 100);
    return sum / (double)n;
}

/* #21: chain mail and weave are not tileable by default (the paper's
 * examples are not), and exactly periodic with periodic = 1. */
static void test_generators_periodic(void **state)
{
    (void)state;
    double s = 0.04;
    for (int kind = 0; kind < 2; kind++) {
        double d[2];
        for (int per = 0; per < 2; per++) {
            gs_points_gen_params gp = {{4, 4}, 0.5, s, 7, per, NULL, NULL, NULL};
            gs_points_texture t;
            assert_int_equal(kind ? gs_points_gen_weave(&gp, 4, &t) : gs_points_gen_chainmail(&gp, 4, &t),
                             GS_OK);
            d[per] = shifted_nn(&t, kind ? 2 : 0, s);
            gs_points_texture_free(&t);
        }
        printf("%s: shifted by one period, %.4f of the points farther than a spacing from "
               "the example (periodic: %.4f)\n", kind ? "weave" : "chain mail", d[0], d[1]);
        assert_true(d[1] < 0.05);         /* periodic: on itself but for sampling gaps */
        assert_true(d[0] > 4 * d[1] + 0.05); /* jittered: off itself */
    }
}

static void test_permutations(void **state)
{
    (void)state;
    for (int up = 0; up < 3; up++) {
        gs_points s = {0};
        double p[3] = {1, 2, 3}, n[3] = {0, 0, 0};
        n[up] = 1; /* a normal along the up axis */
        assert_int_equal(gs_points_push(&s, p, n), GS_OK);
        gs_points_permute_to_z(&s, up);
        assert_true(s.v[0].n[2] == 1);          /* up goes to z */
        assert_true(s.v[0].p[2] == p[up]);      /* and so does its coordinate */
        double v[3] = {1, 2, 3};
        gs_points_permute_vec_to_z(v, up);
        assert_memory_equal(v, s.v[0].p, sizeof v);
        /* handedness kept: the images of x and y still cross to z */
        gs_points e = {0};
        double ex[3] = {0, 0, 0}, ey[3] = {0, 0, 0};
        ex[(up + 1) % 3] = 1;
        ey[(up + 2) % 3] = 1;
        assert_int_equal(gs_points_push(&e, ex, ey), GS_OK);
        gs_points_permute_to_z(&e, up);
        assert_true(e.v[0].p[0] == 1 && e.v[0].n[1] == 1);
        gs_points_permute_from_z(&s, up);
        assert_memory_equal(s.v[0].p, p, sizeof p);
        assert_memory_equal(s.v[0].n, n, sizeof n);
        gs_points_free(&s);
        gs_points_free(&e);
    }
}

static void test_implicit_grid(void **state)
{
    (void)state;
    /* Points on the plane z = 0.5 with normal +z: f = z - 0.5 near it,
     * positive above, negative below (also far below, by the column rule). */
    gs_points s = {0};
    for (int j = 0; j < 30; j++)
        for (int i = 0; i < 30; i++) {
            double p[3] = {i * 0.05, j * 0.05, 0.5}, n[3] = {0, 0, 1};
            assert_int_equal(gs_points_push(&s, p, n), GS_OK);
        }
    enum { NX = 20, NY = 20, NZ = 21 };
    static float f[NX * NY * NZ];
    double o[3] = {0.2, 0.2, 0};
    assert_int_equal(gs_points_implicit_grid(&s, 0.15, o, 0.05, NX, NY, NZ, f), GS_OK);
    for (int k = 0; k < NZ; k++) {
        float v = f[((size_t)k * NY + 5) * NX + 7];
        double z = k * 0.05;
        if (fabs(z - 0.5) < 0.1)
            assert_true(fabs(v - (z - 0.5)) < 1e-6);
        else
            assert_true(z > 0.5 ? v > 0 : v < 0);
    }
    gs_points_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mesh_sampling),
        cmocka_unit_test(test_spacing_estimate_generators),
        cmocka_unit_test(test_generators_periodic),
        cmocka_unit_test(test_permutations),
        cmocka_unit_test(test_implicit_grid),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
