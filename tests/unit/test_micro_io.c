/* Unit tests for the micro engine's input helpers: CSV distribution tables,
 * the table-sum check, and the gs_micro_mesh <-> gs_mesh copy pair. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/micro.h"

static const char *write_tmp(const char *name, const char *text)
{
    static char path[256];
    snprintf(path, sizeof path, "/tmp/gs_test_micro_io_%d_%s", (int)getpid(), name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    return path;
}

static void expect_csv_error(const char *text, const char *needle)
{
    const char *p = write_tmp("bad.csv", text);
    gs_micro_dist d = {0};
    assert_int_equal(gs_micro_dist_read_csv(p, &d), GS_ERR_ARG);
    if (!strstr(gs_error_message(), needle))
        fail_msg("message '%s' lacks '%s'", gs_error_message(), needle);
    assert_null(d.pos);
    gs_error_clear();
    unlink(p);
}

static void test_csv_table(void **state)
{
    (void)state;
    const char *p = write_tmp("ok.csv", "# comment\nbin, positive, negative\n\n0, 0.25, 0.3\r\n"
                                        "1,0.15,0.2\n 2 , 0.1 , 0\n");
    gs_micro_dist d;
    assert_int_equal(gs_micro_dist_read_csv(p, &d), GS_OK);
    assert_int_equal(d.nbins, 3);
    const double pos[3] = {0.25, 0.15, 0.1}, neg[3] = {0.3, 0.2, 0};
    for (int k = 0; k < 3; k++) {
        assert_true(d.pos[k] == pos[k]);
        assert_true(d.neg[k] == neg[k]);
    }
    assert_int_equal(gs_micro_dist_check_sum(d.pos, 3, d.neg, 3, 0.01, "t"), GS_OK);
    gs_micro_dist_free(&d);
    unlink(p);
    /* No header is fine too. */
    p = write_tmp("nohead.csv", "0,0.5,0.5\n");
    assert_int_equal(gs_micro_dist_read_csv(p, &d), GS_OK);
    assert_int_equal(d.nbins, 1);
    gs_micro_dist_free(&d);
    unlink(p);

    expect_csv_error("bin,pos,neg\n0,0.5,0.3\n1,-0.2,0.4\n", ":3: positive probability '-0.2'");
    expect_csv_error("0,0.5,0.3\n2,0.1,0.1\n", ":2: bin 2: expected bin 1");
    expect_csv_error("0,0.5\n", ":1: expected 3 comma-separated fields");
    expect_csv_error("0,0.5,0.1,7\n", "got more than 3");
    expect_csv_error("0,0.5,1.5\n", "negative probability '1.5'");
    expect_csv_error("0,abc,0.1\n", "positive probability 'abc'");
    expect_csv_error("# only a comment\nbin,pos,neg\n", "no table rows");
    expect_csv_error("0,0,0\n1,0,0\n", "no mass");
    gs_micro_dist d2 = {0};
    assert_int_equal(gs_micro_dist_read_csv("/nonexistent/t.csv", &d2), GS_ERR_IO);
    gs_error_clear();
}

static void test_table_sum(void **state)
{
    (void)state;
    const double a[3] = {0.14, 0.085, 0.045}, b[2] = {0.5, 0.23};
    assert_int_equal(gs_micro_dist_check_sum(a, 3, b, 2, 0.01, "t"), GS_OK); /* 1.0 together */
    const double c[2] = {0.5, 0.5}, e[3] = {0.6, 0.3, 0.1};
    assert_int_equal(gs_micro_dist_check_sum(c, 2, e, 3, 0.01, "t"), GS_OK); /* 1 per side */
    const double f[2] = {0.27, 0}, g[1] = {0.72};
    assert_int_equal(gs_micro_dist_check_sum(f, 2, g, 1, 0.01, "t"), GS_OK); /* 0.99, at the margin */
    const double h[2] = {0.5, 0.1}, i[1] = {0.1};
    assert_int_equal(gs_micro_dist_check_sum(h, 2, i, 1, 0.01, "my table"), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "my table: probabilities sum to 0.7"));
    gs_error_clear();
    const double j[2] = {0.9, -0.1}, k[1] = {0.2};
    assert_int_equal(gs_micro_dist_check_sum(j, 2, k, 1, 0.01, "t"), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "positive bin 1 has probability -0.1"));
    gs_error_clear();
}

static void test_mesh_conversion(void **state)
{
    (void)state;
    gs_micro_mesh m = {0};
    assert_int_equal(gs_micro_mesh_bar(&m, 2, 1, 0.5, 0.3), GS_OK);
    assert_int_equal(gs_micro_mesh_normals(&m), GS_OK);
    gs_mesh g;
    assert_int_equal(gs_micro_mesh_to_mesh(&m, &g), GS_OK);
    assert_int_equal(g.nverts, m.nverts);
    assert_int_equal(g.ntris, m.ntris);
    assert_memory_equal(g.pos, m.pos, sizeof(float) * 3 * m.nverts);
    assert_memory_equal(g.tris, m.tris, sizeof(uint32_t) * 3 * m.ntris);
    assert_memory_equal(g.normals, m.normals, sizeof(float) * 3 * m.nverts);
    assert_null(g.label);
    gs_mesh_topology topo;
    assert_int_equal(gs_mesh_topology_check(&g, &topo), GS_OK);
    assert_true(topo.closed); /* the bar is watertight and oriented */
    assert_true(gs_mesh_volume(&g) > 0.99 && gs_mesh_volume(&g) < 1.01);
    gs_micro_mesh back = {0};
    assert_int_equal(gs_micro_mesh_from_mesh(&g, &back), GS_OK);
    assert_int_equal(back.nverts, m.nverts);
    assert_memory_equal(back.pos, m.pos, sizeof(float) * 3 * m.nverts);
    assert_memory_equal(back.tris, m.tris, sizeof(uint32_t) * 3 * m.ntris);
    assert_non_null(back.normals);
    gs_micro_mesh_free(&back);
    gs_free(g.normals);
    g.normals = NULL;
    assert_int_equal(gs_micro_mesh_from_mesh(&g, &back), GS_OK);
    assert_null(back.normals);
    gs_micro_mesh_free(&back);
    gs_mesh_destroy(&g);
    gs_micro_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_csv_table),
        cmocka_unit_test(test_table_sum),
        cmocka_unit_test(test_mesh_conversion),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
