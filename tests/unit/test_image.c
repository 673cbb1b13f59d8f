/* Unit tests for src/io/image.c: real PNGs, 8/16-bit round trips, errors. */
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
#include <unistd.h>

#include <zlib.h>

#include "geosynth/image.h"
#include "geosynth/mem.h"


static const char *tmp_path(const char *name, char *buf, size_t n)
{
    snprintf(buf, n, "%s/%s", gs_test_tmpdir, name);
    return buf;
}

typedef struct image_case {
    const char *file;
    int w, h, c;
} image_case;

static void check_real_images(const image_case *cases, size_t ncases)
{
    for (size_t i = 0; i < ncases; i++) {
        char path[4096];
        gs_image im;
        assert_int_equal(gs_image_read(gs_test_data(cases[i].file, path, sizeof path), &im), GS_OK);
        assert_int_equal(im.width, cases[i].w);
        assert_int_equal(im.height, cases[i].h);
        assert_int_equal(im.channels, cases[i].c);
        assert_int_equal(im.bits, 8); /* every example PNG is 8-bit */
        assert_non_null(im.data8);
        assert_null(im.data16);
        float *g = NULL;
        assert_int_equal(gs_image_to_gray(&im, &g), GS_OK);
        if (strstr(cases[i].file, "raylib")) { /* R = G = B height map: grey equals R exactly */
            for (int y = 0; y < im.height; y += 7)
                for (int x = 0; x < im.width; x += 5)
                    assert_true(g[y * im.width + x] == im.data8[(y * im.width + x) * 3] / 255.0f);
        }
        gs_free(g);
        gs_image_destroy(&im);
        assert_null(im.data8);
    }
}

/* The height maps in the repository's data/. */
static void test_real_images(void **state)
{
    (void)state;
    static const image_case cases[] = {
        {"heightmaps/raylib-heightmap.png", 128, 128, 3},
        {"heightmaps/srtm30plus-e020n40-crop.png", 1000, 200, 4},
    };
    check_real_images(cases, sizeof cases / sizeof cases[0]);
}

/* The Embark textures (PNG with alpha, JPEG) from `make data`. */
static void test_real_images_fetched(void **state)
{
    (void)state;
    static const image_case cases[] = {
        {"textures/embark-4.png", 354, 352, 4},
        {"textures/embark-5.png", 208, 168, 4},
        {"textures/embark-1.jpg", 300, 300, 3},
    };
    GS_TEST_NEED_DATA(cases[0].file, cases[1].file, cases[2].file);
    check_real_images(cases, sizeof cases / sizeof cases[0]);
}

static void test_roundtrip_8_and_16(void **state)
{
    (void)state;
    char path[256];
    for (int bits = 8; bits <= 16; bits += 8)
        for (int c = 1; c <= 4; c++) {
            gs_image im, r;
            assert_int_equal(gs_image_alloc(&im, 37, 23, c, bits), GS_OK);
            size_t n = (size_t)37 * 23 * c;
            for (size_t i = 0; i < n; i++) {
                uint32_t v = (uint32_t)(i * 2654435761u >> 7);
                if (bits == 8)
                    im.data8[i] = (uint8_t)v;
                else
                    im.data16[i] = (uint16_t)v;
            }
            char name[32];
            snprintf(name, sizeof name, "rt%d_%d.png", bits, c);
            assert_int_equal(gs_image_write_png(tmp_path(name, path, sizeof path), &im), GS_OK);
            assert_int_equal(gs_image_read(path, &r), GS_OK);
            assert_int_equal(r.bits, bits);
            assert_int_equal(r.channels, c);
            assert_int_equal(r.width, 37);
            assert_int_equal(r.height, 23);
            if (bits == 8)
                assert_memory_equal(r.data8, im.data8, n);
            else
                assert_memory_equal(r.data16, im.data16, n * 2);
            gs_image_destroy(&r);
            gs_image_destroy(&im);
        }
}

/* A float height map quantized to 16 bit survives with 1/65535 resolution. */
static void test_heightmap16(void **state)
{
    (void)state;
    char path[256];
    int w = 64, h = 48;
    float *v = malloc(sizeof(float) * w * h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            v[y * w + x] = -120.0f + 2500.0f * (0.5f + 0.5f * sinf(0.1f * x) * cosf(0.13f * y));
    gs_image im, r;
    assert_int_equal(gs_image_from_gray(w, h, v, -120.0f, 2380.0f, 16, &im), GS_OK);
    assert_int_equal(gs_image_write_png(tmp_path("h16.png", path, sizeof path), &im), GS_OK);
    assert_int_equal(gs_image_read(path, &r), GS_OK);
    assert_int_equal(r.bits, 16);
    float *g = NULL;
    assert_int_equal(gs_image_to_gray(&r, &g), GS_OK);
    double worst = 0;
    for (int i = 0; i < w * h; i++) {
        double back = -120.0 + 2500.0 * g[i];
        worst = fmax(worst, fabs(back - v[i]));
    }
    assert_true(worst <= 0.5 * 2500.0 / 65535.0 + 1e-3);
    /* the same at 8 bit loses resolution (the reason 16-bit exists) */
    gs_image im8;
    assert_int_equal(gs_image_from_gray(w, h, v, -120.0f, 2380.0f, 8, &im8), GS_OK);
    int distinct8 = 0, distinct16 = 0;
    for (int i = 1; i < w * h; i++) {
        distinct8 += im8.data8[i] != im8.data8[i - 1];
        distinct16 += im.data16[i] != im.data16[i - 1];
    }
    assert_true(distinct16 > distinct8);
    gs_image_destroy(&im8);
    assert_int_equal(gs_image_from_gray(w, h, v, 1.0f, 1.0f, 16, &im8), GS_ERR_ARG);
    assert_null(im8.data16);
    gs_error_clear();
    free(v);
    gs_free(g);
    gs_image_destroy(&im);
    gs_image_destroy(&r);
}

static void test_errors(void **state)
{
    (void)state;
    char path[256];
    gs_image im;
    assert_int_equal(gs_image_read("/nonexistent/a.png", &im), GS_ERR_IO);
    assert_non_null(strstr(gs_error_message(), "/nonexistent/a.png"));
    tmp_path("text.png", path, sizeof path);
    FILE *f = fopen(path, "w");
    fputs("not an image", f);
    fclose(f);
    assert_int_equal(gs_image_read(path, &im), GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "text.png"));
    assert_null(im.data8);
    /* a truncated PNG */
    gs_image ok;
    assert_int_equal(gs_image_alloc(&ok, 64, 64, 3, 8), GS_OK);
    for (int i = 0; i < 64 * 64 * 3; i++)
        ok.data8[i] = (uint8_t)(i * 31);
    tmp_path("full.png", path, sizeof path);
    assert_int_equal(gs_image_write_png(path, &ok), GS_OK);
    f = fopen(path, "rb");
    unsigned char buf[8192];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    tmp_path("cut.png", path, sizeof path);
    f = fopen(path, "wb");
    fwrite(buf, 1, n / 2, f);
    fclose(f);
    assert_int_equal(gs_image_read(path, &im), GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "cut.png"));
    assert_int_equal(gs_image_write_png("/nonexistent/dir/x.png", &ok), GS_ERR_IO);
    assert_int_equal(gs_image_alloc(&im, 0, 5, 1, 8), GS_ERR_FORMAT);
    assert_int_equal(gs_image_alloc(&im, 5, 5, 1, 12), GS_ERR_ARG);
    gs_error_clear();
    gs_image_destroy(&ok);
}

static void write_bytes(const char *path, const unsigned char *d, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(d, 1, n, f), n);
    fclose(f);
}

/* Inputs stb_image trusts (#25 item 5, found by tests/fuzz/fuzz_image.c). */
static void test_hostile_headers(void **state)
{
    (void)state;
    char path[256];
    gs_image im;
    /* A JPEG Huffman table declaring 300 codes: stb wrote past its 257-entry
     * size table (UBSan: index 257 out of bounds in stbi__build_huffman). */
    unsigned char jpg[64] = {0xFF, 0xD8, 0xFF, 0xC4, 0x00, 0x13, 0x00, 0xFF, 0x2D};
    size_t n = 2 + 2 + 0x13;
    jpg[n++] = 0xFF;
    jpg[n++] = 0xD9;
    tmp_path("dht.jpg", path, sizeof path);
    write_bytes(path, jpg, n);
    assert_int_equal(gs_image_read(path, &im), GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "dht.jpg"));
    assert_non_null(strstr(gs_error_message(), "Huffman table at byte 6 declares 300 codes"));
    assert_null(im.data8);
    /* A 45-byte PNG whose header claims 16384 x 16384 RGBA: 1 GiB was
     * allocated before the missing data was noticed. */
    unsigned char png[64] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13,
                             'I', 'H', 'D', 'R', 0, 0, 0x40, 0, 0, 0, 0x40, 0, 8, 6, 0, 0, 0};
    uLong crc = crc32(0L, png + 12, 17);
    for (int i = 0; i < 4; i++)
        png[29 + i] = (unsigned char)(crc >> (24 - 8 * i));
    n = 33;
    static const unsigned char iend[12] = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xAE, 0x42, 0x60, 0x82};
    memcpy(png + n, iend, sizeof iend);
    n += sizeof iend;
    tmp_path("huge.png", path, sizeof path);
    write_bytes(path, png, n);
    assert_int_equal(gs_image_read(path, &im), GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "huge.png"));
    assert_non_null(strstr(gs_error_message(), "16384x16384 pixels, more than a PNG file of 45 bytes"));
    assert_null(im.data8);
    /* An IDAT chunk claiming 0x7fff0000 bytes in a 57-byte file: its buffer
     * was allocated before the read failed. */
    static const unsigned char idat[12] = {0x7f, 0xff, 0, 0, 'I', 'D', 'A', 'T', 0, 0, 0, 0};
    png[16] = png[20] = 0; /* 64 x 64 now */
    png[18] = png[22] = 0;
    png[19] = png[23] = 64;
    crc = crc32(0L, png + 12, 17);
    for (int i = 0; i < 4; i++)
        png[29 + i] = (unsigned char)(crc >> (24 - 8 * i));
    memcpy(png + 33, idat, sizeof idat);
    memcpy(png + 45, iend, sizeof iend);
    tmp_path("idat.png", path, sizeof path);
    write_bytes(path, png, 57);
    assert_int_equal(gs_image_read(path, &im), GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "idat.png: damaged or truncated PNG: chunk 'IDAT' at byte 33 declares 2147418112 bytes but only 16 remain"));
    gs_error_clear();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_real_images),
        cmocka_unit_test(test_real_images_fetched),
        cmocka_unit_test(test_roundtrip_8_and_16),
        cmocka_unit_test(test_heightmap16),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_hostile_headers),
    };
    return cmocka_run_group_tests(tests, gs_test_tmpdir_setup, gs_test_tmpdir_teardown);
}
