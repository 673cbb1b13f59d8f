/* Unit tests for the model engine's I/O and measures (src/model/io.c,
 * voxmesh.c, quality.c): merged-face mesh geometry (areas, orientation via
 * the enclosed volume, re-reading the PLY and OBJ), .vox / .h5 / .txt round
 * trips through gs_model_load, label renumbering for .vox, PNG colours,
 * resemblance, and the file-level checker. Runs from tests/. */
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

#include "geosynth/h5.h"
#include "geosynth/image.h"
#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/model_io.h"
#include "geosynth/rng.h"

static char tmpdir[] = "/tmp/gs-model-io-XXXXXX";

static const char *tmp(const char *name)
{
    static char path[4][256];
    static int k;
    k = (k + 1) % 4;
    snprintf(path[k], sizeof path[k], "%s/%s", tmpdir, name);
    return path[k];
}

static void random_lattice(gs_model_lattice *l, int nx, int ny, int nz, int nlabels, int fill_pct,
                           uint64_t seed)
{
    assert_int_equal(gs_model_lattice_create(l, nx, ny, nz), GS_OK);
    gs_rng r;
    gs_rng_init(&r, seed, 3);
    for (size_t i = 0; i < (size_t)nx * ny * nz; i++)
        l->labels[i] = gs_rng_below(&r, 100) < (uint64_t)fill_pct
                           ? (uint16_t)(1 + gs_rng_below(&r, (uint64_t)nlabels))
                           : 0;
}

static double quad_area(const gs_model_quad *q)
{
    double e1[3], e2[3];
    for (int a = 0; a < 3; a++) {
        e1[a] = q->p[1][a] - q->p[0][a];
        e2[a] = q->p[3][a] - q->p[0][a];
    }
    double c[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                   e1[0] * e2[1] - e1[1] * e2[0]};
    return sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
}

/* Outward normal of the quad (cross product of its edges) matches dir. */
static int quad_normal_ok(const gs_model_quad *q)
{
    double e1[3], e2[3];
    for (int a = 0; a < 3; a++) {
        e1[a] = q->p[1][a] - q->p[0][a];
        e2[a] = q->p[2][a] - q->p[1][a];
    }
    double c[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                   e1[0] * e2[1] - e1[1] * e2[0]};
    int axis = q->dir / 2, sign = (q->dir & 1) ? -1 : 1;
    for (int a = 0; a < 3; a++)
        if (a != axis && fabs(c[a]) > 1e-6)
            return 0;
    return c[axis] * sign > 0;
}

/* Every directed edge of pm used once and its reverse once (closed,
 * oriented, no T-junction), and every vertex's polygons one cycle around
 * it (no pinched vertex). */
static void check_polymesh_manifold(const gs_model_polymesh *pm)
{
    const size_t nc = pm->start[pm->nf];
    uint64_t *he = malloc(nc * sizeof *he);
    assert_non_null(he);
    for (size_t f = 0; f < pm->nf; f++)
        for (uint32_t c = pm->start[f]; c < pm->start[f + 1]; c++) {
            uint32_t a = pm->corner[c], b = pm->corner[c + 1 < pm->start[f + 1] ? c + 1 : pm->start[f]];
            assert_true(a != b);
            he[c] = (uint64_t)a << 32 | b;
        }
    for (size_t i = 0; i < nc; i++) {
        size_t same = 0, rev = 0;
        for (size_t j = 0; j < nc; j++) {
            same += he[j] == he[i];
            rev += he[j] == (he[i] >> 32 | he[i] << 32);
        }
        assert_int_equal(same, 1);
        assert_int_equal(rev, 1);
    }
    /* fans: at vertex v, follow incoming edge -> next outgoing around v; the
     * cycle must visit every corner at v */
    for (uint32_t v = 0; v < pm->nv; v++) {
        size_t at = 0, first = SIZE_MAX;
        for (size_t c = 0; c < nc; c++)
            if ((uint32_t)(he[c] >> 32) == v) {
                at++;
                if (first == SIZE_MAX)
                    first = c;
            }
        assert_true(at >= 2); /* 2: the middle of an edge where two cubes touch */
        size_t c = first, steps = 0;
        do { /* he[c] = v -> w; the corner after the reverse w -> v leaves v */
            uint64_t r = he[c] >> 32 | he[c] << 32;
            size_t k = 0;
            while (he[k] != r)
                k++;
            size_t f = 0;
            while (pm->start[f + 1] <= k)
                f++;
            c = k + 1 < pm->start[f + 1] ? k + 1 : pm->start[f];
            steps++;
        } while (c != first && steps <= at);
        assert_int_equal(steps, at);
    }
    free(he);
}

static void test_mesh_box_and_pair(void **state)
{
    (void)state;
    gs_model_lattice l = {0};
    assert_int_equal(gs_model_lattice_create(&l, 5, 4, 6), GS_OK);
    for (int z = 1; z < 5; z++) /* a 3x2x4 solid box of label 7 */
        for (int y = 1; y < 3; y++)
            for (int x = 1; x < 4; x++)
                l.labels[gs_model_lattice_index(&l, x, y, z)] = 7;
    gs_model_quads q;
    assert_int_equal(gs_model_mesh_quads(&l, 0.5, &q), GS_OK);
    assert_int_equal(q.n, 6); /* every side merged into one rectangle */
    assert_int_equal(q.unit_faces, 2 * (3 * 2 + 2 * 4 + 3 * 4));
    double area = 0;
    for (size_t i = 0; i < q.n; i++) {
        area += quad_area(&q.q[i]);
        assert_true(quad_normal_ok(&q.q[i]));
        assert_int_equal(q.q[i].label, 7);
    }
    assert_true(fabs(area - 52 * 0.25) < 1e-9);
    gs_model_quads_free(&q);

    /* two touching cubes of different labels: the face between them is inside
     * the solid and left out (it used to appear twice, once per label) */
    memset(l.labels, 0, 5 * 4 * 6 * sizeof *l.labels);
    l.labels[gs_model_lattice_index(&l, 2, 2, 2)] = 1;
    l.labels[gs_model_lattice_index(&l, 3, 2, 2)] = 2;
    assert_int_equal(gs_model_mesh_quads(&l, 1.0, &q), GS_OK);
    assert_int_equal(q.n, 10);
    assert_int_equal(q.unit_faces, 10);
    gs_model_quads_free(&q);
    /* same label: one 2x1x1 box */
    l.labels[gs_model_lattice_index(&l, 3, 2, 2)] = 1;
    assert_int_equal(gs_model_mesh_quads(&l, 1.0, &q), GS_OK);
    assert_int_equal(q.n, 6);
    assert_int_equal(q.unit_faces, 10);
    gs_model_quads_free(&q);
    /* cubes touching along an edge, then at a corner only: two closed cubes,
     * the touching lattice points have one vertex per cube (8 + 8), and the
     * touching edge a vertex in its middle per cube */
    for (int k = 0; k < 2; k++) {
        memset(l.labels, 0, 5 * 4 * 6 * sizeof *l.labels);
        l.labels[gs_model_lattice_index(&l, 2, 2, 2)] = 1;
        l.labels[gs_model_lattice_index(&l, 3, 1, k ? 1 : 2)] = 2;
        gs_model_polymesh pm;
        assert_int_equal(gs_model_mesh_quads(&l, 1.0, &q), GS_OK);
        assert_int_equal(gs_model_mesh_weld(&l, &q, 1.0, &pm), GS_OK);
        assert_int_equal(pm.nf, 12);
        assert_int_equal(pm.nv, k ? 16 : 18);
        check_polymesh_manifold(&pm);
        gs_model_polymesh_free(&pm);
        gs_model_quads_free(&q);
    }
    /* an L of two labels: the wall of the taller part gets the vertex of the
     * lower part's top on its edge (no T-junction) */
    memset(l.labels, 0, 5 * 4 * 6 * sizeof *l.labels);
    l.labels[gs_model_lattice_index(&l, 1, 1, 1)] = 1;
    l.labels[gs_model_lattice_index(&l, 1, 1, 2)] = 1;
    l.labels[gs_model_lattice_index(&l, 2, 1, 1)] = 2;
    {
        gs_model_polymesh pm;
        assert_int_equal(gs_model_mesh_quads(&l, 1.0, &q), GS_OK);
        assert_int_equal(gs_model_mesh_weld(&l, &q, 1.0, &pm), GS_OK);
        check_polymesh_manifold(&pm);
        assert_true(pm.start[pm.nf] > 4 * pm.nf);
        gs_model_polymesh_free(&pm);
        gs_model_quads_free(&q);
    }
    gs_model_lattice_destroy(&l);
}

/* Random lattices: areas add up to the unit faces, normals point out, and
 * the written meshes re-read with the enclosed volume = filled cells (only
 * true when every face is oriented outward). The welded mesh is a closed
 * 2-manifold by its own indices: every edge used twice in opposite
 * directions, each vertex one fan (see also analysis/mesh_validity.py,
 * which e2e/model runs on the written file). */
static void test_mesh_random_volume_and_reread(void **state)
{
    (void)state;
    gs_model_lattice l = {0};
    random_lattice(&l, 13, 9, 7, 3, 55, 5);
    size_t filled = 0;
    for (size_t i = 0; i < (size_t)13 * 9 * 7; i++)
        filled += l.labels[i] != 0;
    gs_model_quads q;
    assert_int_equal(gs_model_mesh_quads(&l, 1.0, &q), GS_OK);
    double area = 0;
    for (size_t i = 0; i < q.n; i++) {
        area += quad_area(&q.q[i]);
        assert_true(quad_normal_ok(&q.q[i]));
    }
    assert_true(fabs(area - (double)q.unit_faces) < 1e-6);
    assert_true(q.n < q.unit_faces); /* some merging happened */
    gs_model_palette pal;
    memset(&pal, 0, sizeof pal);
    gs_model_polymesh pm;
    assert_int_equal(gs_model_mesh_weld(&l, &q, 1.0, &pm), GS_OK);
    assert_int_equal(pm.nf, q.n);
    check_polymesh_manifold(&pm);
    const char *names[2] = {"m.ply", "m.obj"};
    for (int k = 0; k < 2; k++) {
        assert_int_equal(gs_model_write_mesh(tmp(names[k]), &pm, &pal), GS_OK);
        gs_mesh m;
        gs_err e = gs_mesh_read(tmp(names[k]), &m);
        if (e)
            gs_error_report("test_model_io: ");
        assert_int_equal(e, GS_OK);
        assert_int_equal(m.ntris, pm.start[pm.nf] - 2 * pm.nf); /* fanned polygons */
        float lo[3], hi[3];
        gs_mesh_bbox(&m, lo, hi);
        assert_true(lo[0] >= 0 && hi[0] <= 13 && hi[2] <= 7);
        assert_true(fabs(gs_mesh_volume(&m) - (double)filled) < 1e-3);
        gs_mesh_destroy(&m);
    }
    assert_true(access(tmp("m.mtl"), R_OK) == 0);
    assert_int_equal(gs_model_write_mesh(tmp("m.stl"), &pm, &pal), GS_ERR_ARG);
    gs_error_clear();
    gs_model_polymesh_free(&pm);
    gs_model_quads_free(&q);
    gs_model_lattice_destroy(&l);
}

static void test_formats_roundtrip(void **state)
{
    (void)state;
    gs_model_lattice l = {0}, back = {0};
    random_lattice(&l, 30, 7, 5, 200, 60, 9);
    gs_model_palette pal;
    memset(&pal, 0, sizeof pal);
    /* .vox keeps labels <= 255 as they are */
    int renum = -1;
    assert_int_equal(gs_model_write_vox(tmp("a.vox"), &l, &pal, &renum), GS_OK);
    assert_int_equal(renum, 0);
    gs_model_palette rpal;
    assert_int_equal(gs_model_load(tmp("a.vox"), "auto", NULL, &back, &rpal), GS_OK);
    assert_int_equal(back.nx, 30);
    assert_int_equal(back.nz, 5);
    assert_memory_equal(back.labels, l.labels, 30 * 7 * 5 * sizeof *l.labels);
    assert_int_equal(rpal.from_file, 1);
    uint8_t rgb[3];
    gs_model_label_rgb(&pal, l.labels[0] ? l.labels[0] : 1, rgb);
    gs_model_lattice_destroy(&back);
    /* Merrell .txt */
    assert_int_equal(gs_model_write_merrell_txt(tmp("a.txt"), &l), GS_OK);
    assert_int_equal(gs_model_load(tmp("a.txt"), "auto", NULL, &back, NULL), GS_OK);
    assert_memory_equal(back.labels, l.labels, 30 * 7 * 5 * sizeof *l.labels);
    gs_model_lattice_destroy(&back);
    /* geosynth .h5 with a uint16 [nz][ny][nx] dataset */
    gs_ckpt_meta meta = {"model", 1, ""};
    gs_ckpt_t h = NULL;
    assert_int_equal(gs_ckpt_create(MPI_COMM_NULL, tmp("a.h5"), &meta, &h), GS_OK);
    gs_h5_shape sh = {GS_H5_U16, 3, {5, 7, 30}};
    assert_int_equal(gs_ckpt_write_whole(h, "/model/labels", &sh, l.labels, NULL), GS_OK);
    gs_h5_shape bad = {GS_H5_F32, 1, {3}};
    float f3[3] = {1, 2, 3};
    assert_int_equal(gs_ckpt_write_whole(h, "/other", &bad, f3, NULL), GS_OK);
    assert_int_equal(gs_ckpt_commit(&h), GS_OK);
    assert_int_equal(gs_model_load(tmp("a.h5"), "auto", NULL, &back, NULL), GS_OK);
    assert_memory_equal(back.labels, l.labels, 30 * 7 * 5 * sizeof *l.labels);
    gs_model_lattice_destroy(&back);
    assert_int_equal(gs_model_load(tmp("a.h5"), "h5", "/other", &back, NULL), GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "/other"));
    assert_non_null(strstr(gs_error_message(), "uint16"));
    assert_int_equal(gs_model_load(tmp("a.png"), "auto", NULL, &back, NULL), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "a.png"));
    assert_int_equal(gs_model_load(tmp("missing.vox"), "auto", NULL, &back, NULL), GS_ERR_IO);
    gs_error_clear();
    assert_null(back.labels);
    /* labels above 255: renumbered in order for .vox */
    l.labels[3] = 1000;
    l.labels[4] = 40000;
    assert_int_equal(gs_model_write_vox(tmp("b.vox"), &l, &pal, &renum), GS_OK);
    assert_int_equal(renum, 1);
    assert_int_equal(gs_model_load(tmp("b.vox"), "vox", NULL, &back, NULL), GS_OK);
    uint16_t maxl = 0;
    for (size_t i = 0; i < 30 * 7 * 5; i++) {
        assert_int_equal(back.labels[i] == 0, l.labels[i] == 0);
        if (back.labels[i] > maxl)
            maxl = back.labels[i];
    }
    assert_int_equal(back.labels[4], maxl); /* 40000 is the largest, so last */
    assert_true(back.labels[3] == maxl - 1);
    gs_model_lattice_destroy(&back);
    gs_model_lattice_destroy(&l);
}

static void test_png_2d(void **state)
{
    (void)state;
    gs_model_lattice l = {0};
    assert_int_equal(gs_model_lattice_create(&l, 4, 3, 1), GS_OK);
    l.labels[gs_model_lattice_index(&l, 1, 0, 0)] = 5; /* y = 0 is the bottom row */
    assert_int_equal(gs_model_write_png(tmp("a.png"), &l, NULL), GS_OK);
    gs_image img;
    assert_int_equal(gs_image_read(tmp("a.png"), &img), GS_OK);
    assert_int_equal(img.width, 4);
    assert_int_equal(img.height, 3);
    uint8_t rgb[3];
    gs_model_label_rgb(NULL, 5, rgb);
    const uint8_t *px = img.data8 + ((size_t)2 * 4 + 1) * (size_t)img.channels;
    assert_memory_equal(px, rgb, 3);
    assert_int_equal(img.data8[0], 255); /* empty = white */
    gs_image_destroy(&img);
    gs_model_lattice_destroy(&l);
}

static void test_resemblance_and_checker(void **state)
{
    (void)state;
    gs_model_lattice ex = {0}, out = {0};
    random_lattice(&ex, 12, 12, 6, 4, 50, 21);
    double share = 0;
    assert_int_equal(gs_model_resemblance(&ex, &ex, 3, &share), GS_OK);
    assert_true(share == 1.0);
    random_lattice(&out, 20, 20, 6, 4, 50, 22);
    assert_int_equal(gs_model_resemblance(&ex, &out, 3, &share), GS_OK);
    assert_true(share < 0.01); /* random 3x3x3 windows almost never repeat */
    assert_int_equal(gs_model_resemblance(&ex, &out, 1, &share), GS_OK);
    assert_true(share == 1.0); /* every label occurs */
    /* a copy of the example inside a larger output: its windows all match */
    gs_model_lattice_destroy(&out);
    assert_int_equal(gs_model_lattice_create(&out, 12, 12, 1), GS_OK);
    memcpy(out.labels, ex.labels + 144 * 2, 144 * sizeof *out.labels);
    assert_int_equal(gs_model_resemblance(&ex, &out, 3, &share), GS_OK);
    assert_true(share == 1.0); /* 2D: 3x3x1 windows of layer 2 */
    gs_model_lattice_destroy(&out);

    /* file checker: the example against itself is clean; a broken copy is not */
    assert_int_equal(gs_model_write_vox(tmp("ex.vox"), &ex, NULL, NULL), GS_OK);
    FILE *f = fopen(tmp("report.txt"), "w");
    assert_non_null(f);
    size_t nv = 99;
    assert_int_equal(gs_model_check_files(tmp("ex.vox"), tmp("ex.vox"), f, 5, &nv), GS_OK);
    assert_int_equal(nv, 0);
    ex.labels[gs_model_lattice_index(&ex, 5, 5, 3)] = 200; /* unknown label */
    assert_int_equal(gs_model_write_merrell_txt(tmp("broken.txt"), &ex), GS_OK);
    assert_int_equal(gs_model_check_files(tmp("ex.vox"), tmp("broken.txt"), f, 10, &nv), GS_OK);
    assert_true(nv >= 2 && nv <= 7); /* the label itself and its pairs */
    size_t nv1 = 0;
    assert_int_equal(gs_model_check_files(tmp("ex.vox"), tmp("broken.txt"), f, 1, &nv1), GS_OK);
    assert_int_equal(nv1, nv); /* the cap limits the listing, not the count */
    fclose(f);
    char *text = NULL;
    size_t len = 0;
    FILE *g = fopen(tmp("report.txt"), "r");
    assert_non_null(g);
    text = calloc(1, 65536);
    len = fread(text, 1, 65535, g);
    fclose(g);
    assert_true(len > 0);
    assert_non_null(strstr(text, "label 200 never occurs"));
    assert_non_null(strstr(text, "more"));
    assert_non_null(strstr(text, "violations: 0"));
    free(text);
    gs_model_lattice_destroy(&ex);
}

static int setup_dir(void **state)
{
    (void)state;
    return mkdtemp(tmpdir) ? 0 : -1;
}

static int remove_dir(void **state)
{
    (void)state;
    const char *names[] = {"m.ply", "m.obj", "m.mtl", "a.vox", "a.txt", "a.h5", "b.vox",
                           "a.png", "ex.vox", "broken.txt", "report.txt"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        remove(tmp(names[i]));
    return rmdir(tmpdir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mesh_box_and_pair),
        cmocka_unit_test(test_mesh_random_volume_and_reread),
        cmocka_unit_test(test_formats_roundtrip),
        cmocka_unit_test(test_png_2d),
        cmocka_unit_test(test_resemblance_and_checker),
    };
    return cmocka_run_group_tests(tests, setup_dir, remove_dir);
}
