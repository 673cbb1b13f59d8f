/* Unit tests for src/io/render.c (OSMesa thumbnails): a rendered cube and
 * sphere are lit inside their projected bounding box and exactly background
 * outside it; vertex colours show; PNG output; bad options. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "../util/testutil.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/image.h"
#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/micro.h"
#include "geosynth/render.h"

/* Closed unit cube [lo, hi]^3, outward counter-clockwise faces. */
static void make_cube(gs_mesh *m, float lo, float hi)
{
    static const uint32_t f[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7},
                                      {0, 1, 5}, {0, 5, 4}, {2, 3, 7}, {2, 7, 6},
                                      {1, 2, 6}, {1, 6, 5}, {0, 4, 7}, {0, 7, 3}};
    assert_int_equal(gs_mesh_alloc(m, 8, 12, 0), GS_OK);
    for (int v = 0; v < 8; v++) {
        m->pos[3 * v + 0] = (v == 1 || v == 2 || v == 5 || v == 6) ? hi : lo;
        m->pos[3 * v + 1] = (v == 2 || v == 3 || v == 6 || v == 7) ? hi : lo;
        m->pos[3 * v + 2] = v >= 4 ? hi : lo;
    }
    memcpy(m->tris, f, sizeof f);
    assert_true(gs_mesh_volume(m) > 0);
}

static int is_bg(const gs_image *img, const gs_render_opts *o, int x, int y)
{
    const uint8_t *p = img->data8 + ((size_t)y * img->width + x) * 3;
    return p[0] == o->background[0] && p[1] == o->background[1] && p[2] == o->background[2];
}

/* Checks the picture against the projected bounding box of the mesh:
 * background outside (1 pixel margin for the filter), mostly lit inside,
 * several grey levels (shading, not a flat silhouette). min_fill: the share of
 * the box the silhouette must cover (a sphere covers less of its box's
 * projection than a cube). */
static void check_picture(const gs_mesh *m, const gs_render_opts *o, double min_fill)
{
    gs_image img;
    gs_render_camera cam;
    assert_int_equal(gs_render_mesh(m, o, &img, &cam), GS_OK);
    assert_int_equal(img.width, o->width);
    assert_int_equal(img.height, o->height);
    assert_int_equal(img.channels, 3);
    float lo[3], hi[3];
    gs_mesh_bbox(m, lo, hi);
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
    for (int c = 0; c < 8; c++) {
        double p[3] = {c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]}, x, y;
        assert_true(gs_render_project(&cam, p, &x, &y));
        x0 = fmin(x0, x), x1 = fmax(x1, x), y0 = fmin(y0, y), y1 = fmax(y1, y);
    }
    /* the vertices fill the frame: the box reaches at least 80% of it */
    assert_true(x1 - x0 >= 0.8 * o->width || y1 - y0 >= 0.8 * o->height);
    size_t inside = 0, lit_inside = 0, lit_outside = 0;
    int levels[256] = {0}, nlevels = 0;
    for (int y = 0; y < img.height; y++) {
        for (int x = 0; x < img.width; x++) {
            int in = x + 1 >= x0 && x <= x1 + 1 && y + 1 >= y0 && y <= y1 + 1;
            int lit = !is_bg(&img, o, x, y);
            inside += in;
            lit_inside += in && lit;
            lit_outside += !in && lit;
            if (lit) {
                int g = img.data8[((size_t)y * img.width + x) * 3 + 1];
                nlevels += !levels[g]++;
            }
        }
    }
    double cx, cy, centre[3] = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
    assert_true(gs_render_project(&cam, centre, &cx, &cy));
    print_message("render %dx%d: box [%.1f, %.1f] x [%.1f, %.1f], %zu of %zu pixels inside lit, "
                  "%zu lit outside, %d grey levels\n",
                  o->width, o->height, x0, x1, y0, y1, lit_inside, inside, lit_outside, nlevels);
    assert_int_equal(lit_outside, 0);
    assert_false(is_bg(&img, o, (int)cx, (int)cy));
    assert_true((double)lit_inside > min_fill * (double)inside);
    assert_true(nlevels >= 8);
    assert_true(is_bg(&img, o, 0, 0) && is_bg(&img, o, o->width - 1, o->height - 1));
    gs_image_destroy(&img);
}

static void test_cube(void **state)
{
    (void)state;
    gs_mesh m;
    make_cube(&m, -0.5f, 1.5f);
    gs_render_opts o;
    gs_render_defaults(&o, 160, 120);
    o.supersample = 1;
    check_picture(&m, &o, 0.4);
    o.supersample = 3;
    o.width = 90, o.height = 140; /* portrait: the narrow side limits the fit */
    o.azimuth_deg = -60, o.elevation_deg = -30;
    check_picture(&m, &o, 0.4);
    gs_mesh_destroy(&m);
}

static void test_sphere_colors(void **state)
{
    (void)state;
    gs_micro_mesh mm = {0};
    assert_int_equal(gs_micro_mesh_sphere(&mm, 2.0, 0.2), GS_OK);
    gs_mesh m;
    assert_int_equal(gs_micro_mesh_to_mesh(&mm, &m), GS_OK);
    gs_micro_mesh_free(&mm);
    for (size_t v = 0; v < m.nverts; v++)
        m.pos[3 * v] += 10.0f; /* off the origin: the camera follows the box */
    gs_render_opts o;
    gs_render_defaults(&o, 128, 128);
    check_picture(&m, &o, 0.25);
    uint8_t *rgb = NULL;
    assert_int_equal(gs_alloc_array((void **)&rgb, m.nverts, 3, "colours"), GS_OK);
    for (size_t v = 0; v < m.nverts; v++)
        rgb[3 * v] = 255, rgb[3 * v + 1] = 0, rgb[3 * v + 2] = 0;
    o.colors = rgb;
    gs_image img;
    assert_int_equal(gs_render_mesh(&m, &o, &img, NULL), GS_OK);
    const uint8_t *c = img.data8 + ((size_t)64 * 128 + 64) * 3;
    assert_true(c[0] > 100 && c[0] > 2 * c[2]); /* lit red, not grey */
    char path[128];
    snprintf(path, sizeof path, "%s/sphere.png", gs_test_tmpdir);
    assert_int_equal(gs_image_write_png(path, &img), GS_OK);
    if (getenv("GS_RENDER_KEEP")) /* for looking at it: GS_RENDER_KEEP=/tmp/sphere.png */
        assert_int_equal(gs_image_write_png(getenv("GS_RENDER_KEEP"), &img), GS_OK);
    gs_image_destroy(&img);
    gs_free(rgb);
    gs_mesh_destroy(&m);
}

static void test_png_and_errors(void **state)
{
    (void)state;
    gs_mesh m;
    make_cube(&m, 0, 1);
    gs_render_opts o;
    gs_render_defaults(&o, 64, 48);
    char path[128];
    snprintf(path, sizeof path, "%s/cube.png", gs_test_tmpdir);
    assert_int_equal(gs_render_mesh_png(&m, &o, path), GS_OK);
    gs_image img;
    assert_int_equal(gs_image_read(path, &img), GS_OK);
    assert_int_equal(img.width, 64);
    assert_int_equal(img.height, 48);
    gs_image_destroy(&img);
    o.width = 0;
    assert_int_equal(gs_render_mesh(&m, &o, &img, NULL), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "render size"));
    o.width = 64, o.supersample = 9;
    assert_int_equal(gs_render_mesh(&m, &o, &img, NULL), GS_ERR_ARG);
    o.supersample = 1;
    assert_int_equal(gs_render_mesh_png(&m, &o, "/nonexistent/dir/x.png"), GS_ERR_IO);
    assert_non_null(strstr(gs_error_message(), "thumbnail"));
    gs_mesh_destroy(&m);
    gs_mesh empty = {0};
    assert_int_equal(gs_render_mesh(&empty, &o, &img, NULL), GS_ERR_ARG);
    assert_null(img.data8);
    gs_error_clear();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cube),
        cmocka_unit_test(test_sphere_colors),
        cmocka_unit_test(test_png_and_errors),
    };
    return cmocka_run_group_tests(tests, gs_test_tmpdir_setup, gs_test_tmpdir_teardown);
}
