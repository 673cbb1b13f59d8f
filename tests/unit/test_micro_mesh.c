/* Unit tests for the micro engine's meshes: generators and subdivision. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/micro.h"

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Counts edges used once (boundary), twice (interior) and more (bad). */
static void edge_use(const gs_micro_mesh *m, uint64_t *once, uint64_t *twice, uint64_t *more)
{
    size_t n = (size_t)m->ntris * 3;
    uint64_t *k = malloc(n * sizeof *k);
    for (uint32_t t = 0; t < m->ntris; t++)
        for (int i = 0; i < 3; i++) {
            uint64_t a = m->tris[3 * t + i], b = m->tris[3 * t + (i + 1) % 3];
            k[3 * t + i] = a < b ? a << 32 | b : b << 32 | a;
        }
    qsort(k, n, sizeof *k, cmp_u64);
    *once = *twice = *more = 0;
    for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && k[j] == k[i])
            j++;
        if (j - i == 1)
            (*once)++;
        else if (j - i == 2)
            (*twice)++;
        else
            (*more)++;
        i = j;
    }
    free(k);
}

/* Sum of signed volumes (closed meshes, outward orientation => positive). */
static double volume(const gs_micro_mesh *m)
{
    double v = 0;
    for (uint32_t t = 0; t < m->ntris; t++) {
        const float *a = m->pos + 3 * m->tris[3 * t], *b = m->pos + 3 * m->tris[3 * t + 1],
                    *c = m->pos + 3 * m->tris[3 * t + 2];
        v += (a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) -
              a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
              a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0])) / 6.0;
    }
    return v;
}

static void test_sphere(void **state)
{
    (void)state;
    gs_micro_mesh m = {0};
    assert_int_equal(gs_micro_mesh_sphere_segments(&m, 2.0, 10), GS_OK);
    assert_int_equal(m.ntris, 800);
    assert_int_equal(m.nverts, 402);
    uint64_t once, twice, more;
    edge_use(&m, &once, &twice, &more);
    assert_true(once == 0 && more == 0 && twice == 1200); /* closed, V - E + F = 2 */
    for (uint32_t v = 0; v < m.nverts; v++) {
        const float *p = m.pos + 3 * v;
        assert_true(fabs(sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 2.0) < 1e-5);
    }
    double vol = volume(&m);
    assert_true(vol > 0.95 * 4.0 / 3.0 * 3.14159265358979 * 8 && vol < 4.0 / 3.0 * 3.14159265358979 * 8);
    double e, a;
    gs_micro_mesh_edge_stats(&m, &e, &a);
    assert_true(a > 30.0);
    gs_micro_mesh_free(&m);

    assert_int_equal(gs_micro_mesh_sphere(&m, 1.0, 0.05), GS_OK);
    gs_micro_mesh_edge_stats(&m, &e, &a);
    assert_true(e <= 0.05 && e > 0.035);
    assert_true(a > 30.0);
    gs_micro_mesh_free(&m);
    assert_int_equal(gs_micro_mesh_sphere(&m, -1.0, 0.05), GS_ERR_ARG);
}

static void test_disk_and_bar(void **state)
{
    (void)state;
    gs_micro_mesh m = {0};
    assert_int_equal(gs_micro_mesh_disk(&m, 3.0, 0.2), GS_OK);
    double e, a;
    gs_micro_mesh_edge_stats(&m, &e, &a);
    assert_true(e <= 0.2);
    assert_true(a > 30.0);
    uint64_t once, twice, more;
    edge_use(&m, &once, &twice, &more);
    assert_true(more == 0 && once > 0);
    assert_int_equal(m.nverts - (once + twice) + m.ntris, 1); /* a disk */
    double rmax = 0;
    for (uint32_t v = 0; v < m.nverts; v++) {
        const float *p = m.pos + 3 * v;
        rmax = fmax(rmax, hypot(p[0], p[1]));
        assert_true(p[2] == 0.0f);
    }
    assert_true(fabs(rmax - 3.0) < 1e-5);
    gs_micro_mesh_free(&m);

    assert_int_equal(gs_micro_mesh_bar(&m, 4.0, 2.0, 0.5, 0.3), GS_OK);
    gs_micro_mesh_edge_stats(&m, &e, &a);
    assert_true(e <= 0.3 + 1e-6);
    assert_true(a > 30.0);
    edge_use(&m, &once, &twice, &more);
    assert_true(once == 0 && more == 0);
    assert_int_equal(m.nverts - twice + m.ntris, 2);
    assert_true(fabs(volume(&m) - 4.0) < 1e-4);
    gs_micro_mesh_free(&m);
}

static void test_subdivide(void **state)
{
    (void)state;
    /* A coarse bar (cells of 1) refined to edges <= 0.3: uniform splits then
     * bisection; closed and outward oriented afterwards. */
    gs_micro_mesh m = {0};
    assert_int_equal(gs_micro_mesh_bar(&m, 2.0, 1.0, 1.0, 1.5), GS_OK);
    double e0, a0;
    gs_micro_mesh_edge_stats(&m, &e0, &a0);
    gs_micro_subdiv_stats st;
    assert_int_equal(gs_micro_mesh_subdivide(&m, 0.3, &st), GS_OK);
    assert_true(st.max_edge <= 0.3);
    assert_true(st.uniform_passes >= 1 && st.bisect_passes >= 1);
    assert_true(st.min_angle_deg >= a0 / 2 - 1e-9);
    uint64_t once, twice, more;
    edge_use(&m, &once, &twice, &more);
    assert_true(once == 0 && more == 0); /* conforming: no hanging vertices */
    assert_true(fabs(volume(&m) - 2.0) < 1e-4);

    /* A skinny input: one 10 x 1 right triangle pair (min angle ~5.7 deg). */
    gs_micro_mesh q = {0};
    assert_int_equal(gs_micro_mesh_alloc(&q, 4, 2), GS_OK);
    float p[12] = {0, 0, 0, 10, 0, 0, 10, 1, 0, 0, 1, 0};
    uint32_t t[6] = {0, 1, 2, 0, 2, 3};
    memcpy(q.pos, p, sizeof p);
    memcpy(q.tris, t, sizeof t);
    gs_micro_mesh_edge_stats(&q, &e0, &a0);
    assert_int_equal(gs_micro_mesh_subdivide(&q, 0.25, &st), GS_OK);
    assert_true(st.max_edge <= 0.25);
    assert_true(st.min_angle_deg >= a0 / 2);
    edge_use(&q, &once, &twice, &more);
    assert_true(more == 0);
    double area = 0;
    for (uint32_t i = 0; i < q.ntris; i++) {
        const float *x = q.pos + 3 * q.tris[3 * i], *y = q.pos + 3 * q.tris[3 * i + 1],
                    *z = q.pos + 3 * q.tris[3 * i + 2];
        double cr = ((double)y[0] - x[0]) * ((double)z[1] - x[1]) - ((double)y[1] - x[1]) * ((double)z[0] - x[0]);
        assert_true(cr > 0); /* orientation kept */
        area += cr / 2;
    }
    assert_true(fabs(area - 10.0) < 1e-3);
    gs_micro_mesh_free(&q);
    gs_micro_mesh_free(&m);
    assert_int_equal(gs_micro_mesh_subdivide(&m, 0.0, NULL), GS_ERR_ARG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere),
        cmocka_unit_test(test_disk_and_bar),
        cmocka_unit_test(test_subdivide),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
