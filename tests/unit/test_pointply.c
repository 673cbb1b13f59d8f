/* Unit tests for the PLY point reader/writer: exact round trips (binary and
 * ASCII), foreign files with extra properties and elements, and every error
 * naming the file and the line or byte. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/error.h"
#include "geosynth/pointply.h"

static void test_roundtrip_float32(void **state)
{
    (void)state;
    enum { N = 257 };
    static double v[6 * N];
    for (int i = 0; i < N; i++) {
        double a = 0.37 * i, b = 1.0 / (i + 3);
        double n[3] = {cos(a) * sin(b), sin(a) * sin(b), cos(b)};
        double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        double row[6] = {a / 7, -b * 1e-7, 1e5 + a, n[0] / l, n[1] / l, n[2] / l};
        memcpy(v + 6 * i, row, sizeof row);
    }
    const char *paths[2] = {"pointply_bin.ply", "pointply_ascii.ply"};
    for (int f = 0; f < 2; f++) {
        assert_int_equal(gs_pointply_write(paths[f], v, N, 1, f ? GS_POINTPLY_ASCII : GS_POINTPLY_BINARY),
                         GS_OK);
        gs_pointply p;
        assert_int_equal(gs_pointply_read(paths[f], 1, &p), GS_OK);
        assert_int_equal(p.n, N);
        assert_true(p.has_normals);
        /* float32 in the file (#23): positions come back as the doubles
         * rounded to the nearest float, normals within float rounding */
        for (int i = 0; i < N; i++)
            for (int k = 0; k < 6; k++) {
                double w = v[6 * i + k], r = p.v[6 * i + k];
                if (k < 3) /* binary: the float exactly; ASCII: its 9 digits */
                    assert_true(f ? fabs(r - (double)(float)w) <= 1e-8 * fabs(w) : r == (double)(float)w);
                else
                    assert_true(fabs(r - w) < 2e-7);
            }
        gs_pointply_destroy(&p);
        assert_null(p.v);
        unlink(paths[f]);
    }
    /* Without normals: readable when normals are optional, refused otherwise. */
    assert_int_equal(gs_pointply_write("pointply_nonormal.ply", v, N, 0, GS_POINTPLY_BINARY), GS_OK);
    gs_pointply p;
    assert_int_equal(gs_pointply_read("pointply_nonormal.ply", 0, &p), GS_OK);
    assert_int_equal(p.n, N);
    assert_false(p.has_normals);
    assert_true(p.v[6 * 5 + 2] == (double)(float)v[6 * 5 + 2] && p.v[6 * 5 + 3] == 0);
    gs_pointply_destroy(&p);
    assert_int_equal(gs_pointply_read("pointply_nonormal.ply", 1, &p), GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "pointply_nonormal.ply"));
    assert_non_null(strstr(gs_error_message(), "no normals"));
    assert_null(p.v);
    gs_error_clear();
    unlink("pointply_nonormal.ply");
    assert_int_equal(gs_pointply_read("/nonexistent/p.ply", 1, &p), GS_ERR_IO);
    assert_non_null(strstr(gs_error_message(), "/nonexistent/p.ply"));
    gs_error_clear();
}

/* Binary float file with an extra property, a face element before the
 * vertices (skipped item by item) and unnormalized normals. */
static void test_foreign_binary(void **state)
{
    (void)state;
    const char *hdr = "ply\r\nformat binary_little_endian 1.0\r\ncomment made by hand\r\n"
                      "element face 2\r\nproperty list uchar int vertex_indices\r\n"
                      "element vertex 3\r\nproperty float x\r\nproperty float y\r\n"
                      "property float z\r\nproperty uchar red\r\nproperty float normal_x\r\n"
                      "property float normal_y\r\nproperty float normal_z\r\nend_header\r\n";
    unsigned char buf[512];
    size_t n = strlen(hdr);
    memcpy(buf, hdr, n);
    for (int f = 0; f < 2; f++) { /* faces: 3 ints */
        buf[n++] = 3;
        for (int k = 0; k < 3; k++) {
            int32_t idx = k;
            memcpy(buf + n, &idx, 4);
            n += 4;
        }
    }
    for (int i = 0; i < 3; i++) {
        float xyz[3] = {(float)i, 0.5f, -2.0f};
        memcpy(buf + n, xyz, 12);
        n += 12;
        buf[n++] = 200;
        float nn[3] = {0, 0, 2.0f};
        memcpy(buf + n, nn, 12);
        n += 12;
    }
    gs_pointply p;
    assert_int_equal(gs_pointply_parse((const char *)buf, n, "hand.ply", 1, &p), GS_OK);
    assert_int_equal(p.n, 3);
    assert_true(p.v[6 * 2 + 0] == 2.0 && p.v[6 * 2 + 1] == 0.5 && p.v[6 * 2 + 2] == -2.0);
    assert_true(p.v[6 * 2 + 5] == 1.0 && p.v[6 * 2 + 3] == 0.0);
    gs_pointply_destroy(&p);
    /* Truncated inside vertex 2: caught before reading the vertices, with the
     * byte offset and the element named. */
    assert_int_equal(gs_pointply_parse((const char *)buf, n - 5, "hand.ply", 1, &p), GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "hand.ply: byte"));
    assert_non_null(strstr(gs_error_message(), "3 items of element vertex"));
    gs_error_clear();
}

static gs_err parse_text(const char *text, int require_normals, gs_pointply *p)
{
    return gs_pointply_parse(text, strlen(text), "t.ply", require_normals, p);
}

static void expect_error(const char *text, const char *needle)
{
    gs_pointply p;
    gs_err e = parse_text(text, 1, &p);
    if (e != GS_ERR_FORMAT || !strstr(gs_error_message(), needle) ||
        !strstr(gs_error_message(), "t.ply"))
        fail_msg("expected an error with '%s', got %d: %s", needle, e, gs_error_message());
    assert_null(p.v);
    gs_error_clear();
}

static void test_ascii_and_errors(void **state)
{
    (void)state;
    const char *good = "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\n"
                       "property double y\nproperty double z\nproperty double nx\n"
                       "property double ny\nproperty double nz\nelement face 1\n"
                       "property list uchar int vertex_indices\nend_header\n"
                       "0 0 0 0 0 1\n1 2 3 0 1 0\n3 0 1 1\n";
    gs_pointply p;
    assert_int_equal(parse_text(good, 1, &p), GS_OK);
    assert_int_equal(p.n, 2);
    assert_true(p.v[6 + 1] == 2 && p.v[6 + 4] == 1);
    gs_pointply_destroy(&p);
    expect_error("ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
                 "property double z\nproperty double nx\nproperty double ny\nproperty double nz\n"
                 "end_header\n0 0 0 0 0 1\n1 2 3x 0 1 0\n",
                 "line 12: vertex 1");
    expect_error("ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
                 "property double z\nproperty double nx\nproperty double ny\nproperty double nz\n"
                 "end_header\n0 0 0 0 0 1\n1 2 3 0 0 0\n",
                 "line 12: vertex 1 has a zero or non-finite normal");
    expect_error("ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
                 "property double z\nproperty double nx\nproperty double ny\nproperty double nz\n"
                 "end_header\n0 0 0 0 0 1\n1 2\n",
                 "2 items of element vertex of at least 12 bytes each need more data");
    expect_error("ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
                 "property double z\nproperty double nx\nproperty double ny\nproperty double nz\n"
                 "end_header\n0 0 0 0 0 1\n100000 2000 300\n",
                 "file ends inside vertex 1 of 2");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\n"
                 "property double z\nend_header\n0 0 0\n",
                 "line 3: element vertex has no normals");
    expect_error("ply\nformat binary_big_endian 1.0\nelement vertex 1\nend_header\n",
                 "line 3: element vertex has no property x");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n",
                 "line 4: unknown property type 'float128'");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nproperty float z\n"
                 "end_header\n1 2\n",
                 "line 3: element vertex has no property x");
    expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "no end_header");
    expect_error("OFF\n3 1 0\n", "line 1: not a PLY file");
    expect_error("ply\nformat ascii 1.0\nelement vertex -3\nend_header\n", "line 3: element vertex count");
    expect_error("ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
                 "end_header\n3 0 1 2\n",
                 "no 'vertex' element");
    /* Binary: a declared count far beyond the data is caught before allocating. */
    expect_error("ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\n"
                 "property double x\nproperty double y\nproperty double z\nproperty double nx\n"
                 "property double ny\nproperty double nz\nend_header\n",
                 "need more data than the 0 bytes left");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roundtrip_float32),
        cmocka_unit_test(test_foreign_binary),
        cmocka_unit_test(test_ascii_and_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
