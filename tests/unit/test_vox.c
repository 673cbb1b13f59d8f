/* Unit tests for src/io/vox.c: every example .vox loads, round trips,
 * tiling of large lattices, damaged files give located errors. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "../util/testutil.h"
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "geosynth/mem.h"
#include "geosynth/vox.h"


static const char *tmp_path(const char *name, char *buf, size_t n)
{
    snprintf(buf, n, "%s/%s", gs_test_tmpdir, name);
    return buf;
}

static size_t filled(const gs_vox_model *m)
{
    size_t n = 0;
    for (size_t i = 0; i < (size_t)m->nx * m->ny * m->nz; i++)
        n += m->labels[i] != 0;
    return n;
}

/* Reads, re-encodes, re-parses: same models, same palette. */
static void check_roundtrip(const gs_vox *v, const char *name)
{
    uint8_t *buf = NULL;
    size_t len = 0;
    assert_int_equal(gs_vox_encode(v, &buf, &len), GS_OK);
    gs_vox r;
    assert_int_equal(gs_vox_parse(buf, len, name, &r), GS_OK);
    assert_int_equal(r.nmodels, v->nmodels);
    for (int i = 0; i < v->nmodels; i++) {
        assert_int_equal(r.models[i].nx, v->models[i].nx);
        assert_int_equal(r.models[i].ny, v->models[i].ny);
        assert_int_equal(r.models[i].nz, v->models[i].nz);
        assert_memory_equal(r.models[i].labels, v->models[i].labels,
                            (size_t)v->models[i].nx * v->models[i].ny * v->models[i].nz);
    }
    assert_memory_equal(&r.palette[1], &v->palette[1], 255 * 4);
    if (v->ninstances > 0) {
        assert_int_equal(r.ninstances, v->ninstances);
        for (int i = 0; i < v->ninstances; i++) {
            assert_int_equal(r.instances[i].model, v->instances[i].model);
            assert_int_equal(r.instances[i].x0, v->instances[i].x0);
            assert_int_equal(r.instances[i].y0, v->instances[i].y0);
            assert_int_equal(r.instances[i].z0, v->instances[i].z0);
        }
    }
    gs_vox_destroy(&r);
    gs_free(buf);
}

static int walk(const char *dir, int *count)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    struct dirent *e;
    int bad = 0;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        struct stat st;
        if (stat(path, &st) != 0)
            continue;
        if (S_ISDIR(st.st_mode)) {
            bad += walk(path, count) < 0;
            continue;
        }
        size_t l = strlen(path);
        if (l < 4 || strcmp(path + l - 4, ".vox") != 0)
            continue;
        gs_vox v;
        gs_err e2 = gs_vox_read(path, &v);
        if (e2 != GS_OK) {
            gs_error_report("");
            bad++;
            continue;
        }
        (*count)++;
        int nx, ny, nz;
        uint8_t *lab = NULL;
        assert_int_equal(gs_vox_flatten(&v, &nx, &ny, &nz, &lab, NULL), GS_OK);
        gs_free(lab);
        check_roundtrip(&v, path);
        gs_vox_destroy(&v);
    }
    closedir(d);
    return bad ? -1 : 0;
}

/* Every .vox under ${data}/vox: the repository's 42 (VoxModSynth, DeBroglie's
 * castle, MarkovJunior's tile sets), plus ephtracy's 7 once fetched. */
static void test_every_example_file_loads(void **state)
{
    (void)state;
    char dir[4096];
    int count = 0;
    assert_int_equal(walk(gs_test_data("vox", dir, sizeof dir), &count), 0);
    printf("%d .vox files loaded and round-tripped\n", count);
    assert_true(count >= 42);
}

/* ephtracy's models (`make data`): the procedural ones and the teapot scan. */
static void test_fetched_files(void **state)
{
    (void)state;
    GS_TEST_NEED_DATA("vox/ephtracy-voxel-model/vox/scan/teapot.vox",
                      "vox/ephtracy-voxel-model/vox/procedure/maze.vox");
    char dir[4096], path[4096];
    int count = 0;
    assert_int_equal(walk(gs_test_data("vox/ephtracy-voxel-model", dir, sizeof dir), &count), 0);
    printf("%d ephtracy .vox files loaded and round-tripped\n", count);
    assert_int_equal(count, 7);
    gs_vox v;
    /* teapot: one 126x80x61 model with an RGBA palette */
    assert_int_equal(
        gs_vox_read(gs_test_data("vox/ephtracy-voxel-model/vox/scan/teapot.vox", path, sizeof path),
                    &v),
        GS_OK);
    assert_int_equal(v.nmodels, 1);
    assert_true(v.models[0].nx == 126 && v.models[0].ny == 80 && v.models[0].nz == 61);
    assert_int_equal(filled(&v.models[0]), 28411);
    gs_vox_destroy(&v);
}

static void test_known_contents(void **state)
{
    (void)state;
    char path[4096];
    gs_vox v;
    /* castle tile with scene graph, layers, materials: one placed 5^3 model */
    assert_int_equal(gs_vox_read(gs_test_data("vox/DeBroglie-castle/solid.vox", path, sizeof path),
                                 &v),
                     GS_OK);
    assert_int_equal(v.nmodels, 1);
    assert_int_equal(v.ninstances, 1);
    assert_int_equal(filled(&v.models[0]), 125);
    gs_vox_destroy(&v);
    /* Slab6 exemplar: z flipped so ground (slab 254 -> label 255) is at z = 0 */
    assert_int_equal(gs_vox_read(gs_test_data("vox/sylefeb-VoxModSynth/exemplars/blog2.slab.vox",
                                              path, sizeof path),
                                 &v),
                     GS_OK);
    const gs_vox_model *m = &v.models[0];
    assert_true(m->nx == 5 && m->ny == 5 && m->nz == 5);
    size_t ground = 0;
    for (int y = 0; y < 5; y++)
        for (int x = 0; x < 5; x++)
            ground += m->labels[x + 5 * y] == 255;
    assert_int_equal(ground, 25);
    assert_int_equal(v.palette[0][3], 0);
    gs_vox_destroy(&v);
}

static void test_large_lattice_tiles(void **state)
{
    (void)state;
    int nx = 300, ny = 20, nz = 270;
    uint8_t *lab = gs_malloc((size_t)nx * ny * nz);
    for (int z = 0; z < nz; z++)
        for (int y = 0; y < ny; y++)
            for (int x = 0; x < nx; x++)
                lab[x + (size_t)nx * (y + (size_t)ny * z)] =
                    ((x * 7 + y * 3 + z) % 11 == 0) ? (uint8_t)(1 + (x + z) % 255) : 0;
    lab[(size_t)nx * ny * nz - 1] = 9; /* far corner filled */
    char path[256];
    tmp_path("big.vox", path, sizeof path);
    assert_int_equal(gs_vox_write_lattice(path, nx, ny, nz, lab, NULL), GS_OK);
    gs_vox v;
    assert_int_equal(gs_vox_read(path, &v), GS_OK);
    assert_int_equal(v.nmodels, 4); /* 2 x 1 x 2 tiles */
    for (int i = 0; i < v.nmodels; i++)
        assert_true(v.models[i].nx <= 256 && v.models[i].nz <= 256);
    int fx, fy, fz, o[3];
    uint8_t *flat = NULL;
    assert_int_equal(gs_vox_flatten(&v, &fx, &fy, &fz, &flat, o), GS_OK);
    assert_true(fx == nx && fy == ny && fz == nz);
    assert_true(o[0] == 0 && o[1] == 0 && o[2] == 0);
    assert_memory_equal(flat, lab, (size_t)nx * ny * nz);
    /* a model over 256 cannot be written as such */
    gs_vox bad = v;
    gs_vox_model big = {300, 2, 2, lab};
    bad.models = &big;
    bad.nmodels = 1;
    bad.ninstances = 0;
    assert_int_equal(gs_vox_write(path, &bad), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "300x2x2"));
    gs_error_clear();
    gs_free(flat);
    gs_free(lab);
    gs_vox_destroy(&v);
}

/* Small valid file: SIZE 2x2x2 with 2 voxels + RGBA. */
static uint8_t *small_file(size_t *len)
{
    uint8_t lab[8] = {0, 3, 0, 0, 0, 0, 0, 200};
    gs_vox v;
    assert_int_equal(gs_vox_from_lattice(2, 2, 2, lab, NULL, &v), GS_OK);
    uint8_t *buf = NULL;
    assert_int_equal(gs_vox_encode(&v, &buf, len), GS_OK);
    gs_vox_destroy(&v);
    return buf;
}

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void expect_error(const uint8_t *buf, size_t len, gs_err code, const char *needle)
{
    gs_vox v;
    gs_err e = gs_vox_parse(buf, len, "damaged.vox", &v);
    printf("  -> %s\n", gs_error_message());
    assert_int_equal(e, code);
    assert_non_null(strstr(gs_error_message(), "damaged.vox"));
    if (needle)
        assert_non_null(strstr(gs_error_message(), needle));
    assert_null(v.models);
    gs_error_clear();
}

static void test_damaged(void **state)
{
    (void)state;
    size_t len;
    uint8_t *good = small_file(&len);
    uint8_t *b = gs_malloc(len);
    /* SIZE is the first child chunk at byte 20 */
    assert_memory_equal(good + 20, "SIZE", 4);
    memcpy(b, good, len);
    put32(b + 32, 0); /* size x = 0 */
    expect_error(b, len, GS_ERR_FORMAT, "0x2x2 voxels: expected sizes in [1, 256]");
    memcpy(b, good, len);
    put32(b + 32, 300);
    expect_error(b, len, GS_ERR_FORMAT, "byte 20");
    memcpy(b, good, len);
    put32(b + 24, 0x7fffffff); /* SIZE content larger than the file */
    expect_error(b, len, GS_ERR_FORMAT, "chunk SIZE at byte 20");
    memcpy(b, good, len);
    put32(b + 16, (uint32_t)len); /* MAIN children larger than the file */
    expect_error(b, len, GS_ERR_FORMAT, "MAIN");
    /* XYZI: voxel count too large, voxel outside SIZE, colour 0 */
    size_t xyzi = 20 + 12 + 12;
    assert_memory_equal(good + xyzi, "XYZI", 4);
    memcpy(b, good, len);
    put32(b + xyzi + 12, 1000);
    expect_error(b, len, GS_ERR_FORMAT, "declares 1000 voxels");
    memcpy(b, good, len);
    b[xyzi + 16] = 2; /* x = 2 in a 2-wide model */
    expect_error(b, len, GS_ERR_FORMAT, "outside the model size 2x2x2");
    memcpy(b, good, len);
    b[xyzi + 19] = 0;
    expect_error(b, len, GS_ERR_FORMAT, "colour index 0");
    /* truncations at every length give an error, never a crash */
    for (size_t cut = 0; cut < len; cut++) {
        gs_vox v;
        assert_int_not_equal(gs_vox_parse(good, cut, "cut.vox", &v), GS_OK);
        gs_error_clear();
    }
    /* scene graph pointing at a missing model */
    memcpy(b, good, len);
    uint8_t *shp = NULL;
    for (size_t i = 20; i + 4 <= len; i++)
        if (!memcmp(b + i, "nSHP", 4)) {
            shp = b + i;
            break;
        }
    assert_non_null(shp);
    put32(shp + 12 + 12, 5); /* node id, empty dict, count, then model id */
    expect_error(b, len, GS_ERR_FORMAT, "refers to model 5");
    /* unknown chunks are skipped */
    size_t len2 = len + 16;
    uint8_t *c = gs_malloc(len2);
    memcpy(c, good, 20);
    memcpy(c + 20, "ZZZZ", 4);
    put32(c + 24, 4);
    put32(c + 28, 0);
    put32(c + 32, 0xdeadbeef);
    memcpy(c + 36, good + 20, len - 20);
    put32(c + 16, (uint32_t)(len2 - 20));
    gs_vox v;
    assert_int_equal(gs_vox_parse(c, len2, "extra.vox", &v), GS_OK);
    assert_int_equal(v.models[0].labels[1], 3);
    assert_int_equal(v.models[0].labels[7], 200);
    gs_vox_destroy(&v);
    /* neither .vox nor slab */
    expect_error((const uint8_t *)"hello world, not voxels", 23, GS_ERR_FORMAT, "Slab6");
    assert_int_equal(gs_vox_read("/nonexistent/x.vox", &v), GS_ERR_IO);
    gs_error_clear();
    gs_free(c);
    gs_free(b);
    gs_free(good);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_example_file_loads),
        cmocka_unit_test(test_fetched_files),
        cmocka_unit_test(test_known_contents),
        cmocka_unit_test(test_large_lattice_tiles),
        cmocka_unit_test(test_damaged),
    };
    return cmocka_run_group_tests(tests, gs_test_tmpdir_setup, gs_test_tmpdir_teardown);
}
