/* PNG/JPEG images in through stb_image, PNG out through libpng; see
 * include/geosynth/image.h.
 *
 * The stb implementations are compiled here (not linked from libstb) with
 * their allocations routed through gs_malloc, so decoded pixels are adopted
 * without a copy and count in the memory report.
 */
#include "geosynth/image.h"

#include <errno.h>
#include <math.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/file.h"

#define STBI_MALLOC(sz) gs_malloc(sz)
#define STBI_REALLOC(p, sz) gs_realloc(p, sz)
#define STBI_FREE(p) gs_free(p)
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STB_IMAGE_IMPLEMENTATION
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#endif
#include <stb/stb_image.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

void gs_image_destroy(gs_image *img)
{
    if (!img)
        return;
    gs_free(img->data8);
    gs_free(img->data16);
    memset(img, 0, sizeof *img);
}

static gs_err check_shape(const char *what, int w, int h, int c, int bits)
{
    GS_CHECK(w >= 1 && h >= 1 && w <= GS_IMAGE_MAX_SIDE && h <= GS_IMAGE_MAX_SIDE, GS_ERR_FORMAT,
             "%s: image of %dx%d pixels: expected sides in [1, %d]", what, w, h,
             GS_IMAGE_MAX_SIDE);
    GS_CHECK(c >= 1 && c <= 4, GS_ERR_FORMAT, "%s: %d channels: expected 1 to 4", what, c);
    GS_CHECK(bits == 8 || bits == 16, GS_ERR_ARG, "%s: %d bits per sample: expected 8 or 16",
             what, bits);
    return GS_OK;
}

gs_err gs_image_alloc(gs_image *img, int width, int height, int channels, int bits)
{
    memset(img, 0, sizeof *img);
    GS_CALL(check_shape("image", width, height, channels, bits));
    size_t n = (size_t)width * (size_t)height * (size_t)channels;
    if (bits == 8)
        GS_CALL(gs_alloc_array((void **)&img->data8, n, 1, "image pixels"));
    else
        GS_CALL(gs_alloc_array((void **)&img->data16, n, 2, "image pixels"));
    img->width = width;
    img->height = height;
    img->channels = channels;
    img->bits = bits;
    return GS_OK;
}

/* stb_image trusts what it reads (found by tests/fuzz/fuzz_image.c, #25):
 * - a JPEG Huffman table (DHT) whose 16 code counts add up to more than 256
 *   makes stbi__build_huffman write past its 257-entry table (Debian 12's
 *   stb of 2022-09; newer stb refuses it as "bad DHT header"). jpeg_check
 *   walks the markers (skipping entropy-coded data, where 0xFF is always
 *   followed by 0x00 or a restart marker) and refuses such a table first,
 *   table by table as stb reads them.
 * - the header's sides are believed: a 45-byte PNG claiming 16384 x 16384
 *   RGBA gets 1 GiB allocated before decoding finds no data (stb itself
 *   refuses only claims above 2^30 bytes, "too large"). A file cannot
 *   encode more pixels than its compression allows: deflate expands at most
 *   1032:1 and a PNG pixel takes at least one bit of inflated data, so
 *   pixels <= 8 * 1032 * bytes; a baseline or progressive JPEG spends at
 *   least one bit per 8x8 block on its DC coefficients, so pixels <= 512 *
 *   bytes. Larger claims are refused before any allocation.
 * - a PNG chunk's length is believed: an IDAT claiming 2 GB in an 83-byte
 *   file gets its buffer allocated (and zeroed by the allocator) before the
 *   read fails, 0.5 s of CPU each. png_check walks the chunks first and
 *   refuses a length that runs past the end of the file. */
#define IMAGE_MAX_FILE_BYTES ((size_t)INT32_MAX) /* stb reads lengths as int */

static gs_err jpeg_check(const unsigned char *d, size_t len, const char *path)
{
    size_t p = 2; /* after SOI */
    while (p < len) {
        if (d[p] != 0xFF) { /* entropy-coded data (or junk stb refuses itself) */
            p++;
            continue;
        }
        while (p < len && d[p] == 0xFF) /* fill bytes */
            p++;
        if (p >= len)
            break;
        unsigned m = d[p++];
        if (m == 0x00 || m == 0x01 || (m >= 0xD0 && m <= 0xD8)) /* stuffed, TEM, RSTn, SOI */
            continue;
        if (m == 0xD9 || p + 2 > len) /* EOI, or a length cut off (stb says so) */
            break;
        size_t seg = (size_t)d[p] << 8 | d[p + 1];
        if (m == 0xC4) {
            size_t q = p + 2, end = p + seg;
            while (q < end && q < len) {
                unsigned n = 0;
                for (size_t i = 0; i < 16 && q + 1 + i < len; i++)
                    n += d[q + 1 + i];
                GS_CHECK(n <= 256, GS_ERR_FORMAT,
                         "%s: damaged JPEG: the Huffman table at byte %zu declares %u codes "
                         "(at most 256)",
                         path, q, n);
                q += 17 + n;
            }
        }
        if (seg < 2)
            break;
        p += seg;
    }
    return GS_OK;
}

static gs_err png_check(const unsigned char *d, size_t len, const char *path)
{
    size_t p = 8; /* after the signature */
    while (p + 8 <= len) {
        size_t n = (size_t)d[p] << 24 | (size_t)d[p + 1] << 16 | (size_t)d[p + 2] << 8 | d[p + 3];
        char type[5];
        for (int i = 0; i < 4; i++) {
            unsigned char c = d[p + 4 + i];
            type[i] = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') ? (char)c : '?';
        }
        type[4] = '\0';
        GS_CHECK(n <= len - p - 8, GS_ERR_FORMAT,
                 "%s: damaged or truncated PNG: chunk '%s' at byte %zu declares %zu bytes but "
                 "only %zu remain",
                 path, type, p, n, len - p - 8);
        if (!memcmp(d + p + 4, "IEND", 4))
            break;
        p += 12 + n; /* length, type, data, CRC */
    }
    return GS_OK;
}

gs_err gs_image_read(const char *path, gs_image *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(path && path[0], GS_ERR_ARG, "image path is empty");
    char *file = NULL;
    size_t len = 0;
    {
        FILE *f = fopen(path, "rb");
        GS_CHECK(f, GS_ERR_IO, "%s: cannot open image file: %s", path, strerror(errno));
        fclose(f);
    }
    GS_CALL(gs_file_read_all(path, IMAGE_MAX_FILE_BYTES, &file, &len));
    const unsigned char *d = (const unsigned char *)file;
    gs_err err = GS_OK;
    static const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    int is_png = len >= 8 && !memcmp(d, png_sig, 8);
    int is_jpeg = len >= 3 && d[0] == 0xFF && d[1] == 0xD8 && d[2] == 0xFF;
    GS_TRY_CHECK(err, len <= (size_t)INT32_MAX, GS_ERR_FORMAT, done,
                 "%s: %zu bytes: image files of at most 2 GiB are read", path, len);
    GS_TRY_CHECK(err, is_png || is_jpeg, GS_ERR_FORMAT, done,
                 "%s: not a PNG or JPEG image (%s)", path,
                 len == 0 ? "the file is empty" : "no PNG or JPEG signature at byte 0");
    if (is_jpeg)
        GS_TRY(err, jpeg_check(d, len, path), done);
    else
        GS_TRY(err, png_check(d, len, path), done);
    int w = 0, h = 0, c = 0;
    GS_TRY_CHECK(err, stbi_info_from_memory(d, (int)len, &w, &h, &c), GS_ERR_FORMAT, done,
                 "%s: not a readable PNG or JPEG image (%s)", path, stbi_failure_reason());
    GS_TRY(err, check_shape(path, w, h, c, 8), done);
    double per_byte = is_png ? 8.0 * 1032.0 : 512.0;
    GS_TRY_CHECK(err, (double)w * (double)h <= per_byte * (double)len + 4096.0, GS_ERR_FORMAT, done,
                 "%s: the header says %dx%d pixels, more than a %s file of %zu bytes can hold "
                 "(at most %.0f per byte): the file is damaged or truncated",
                 path, w, h, is_png ? "PNG" : "JPEG", len, per_byte);
    int is16 = stbi_is_16_bit_from_memory(d, (int)len);
    void *pix;
    int w2, h2, c2;
    if (is16)
        pix = stbi_load_16_from_memory(d, (int)len, &w2, &h2, &c2, 0);
    else
        pix = stbi_load_from_memory(d, (int)len, &w2, &h2, &c2, 0);
    GS_TRY_CHECK(err, pix, GS_ERR_FORMAT, done, "%s: damaged image (%s)", path,
                 stbi_failure_reason());
    if (w2 != w || h2 != h || c2 != c) {
        gs_free(pix);
        GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, done, "%s: image header and data disagree", path);
    }
    out->width = w;
    out->height = h;
    out->channels = c;
    out->bits = is16 ? 16 : 8;
    if (is16)
        out->data16 = pix;
    else
        out->data8 = pix;
done:
    gs_free(file);
    return err;
}

typedef struct png_err_ctx {
    char msg[256];
} png_err_ctx;

static void png_error_cb(png_structp png, png_const_charp msg)
{
    png_err_ctx *ctx = png_get_error_ptr(png);
    snprintf(ctx->msg, sizeof ctx->msg, "%s", msg);
    png_longjmp(png, 1);
}

static void png_warning_cb(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

/* PNG through libpng, 8 or 16 bits (stb_image_write, used before for 8
 * bits, tries every filter on every row at zlib level 8). Pictures of at
 * least PNG_FAST_PIXELS pixels are written fast: no filter, zlib level 1.
 * Measured on wfc-summer at 256x256 cells (tiles.png, 12288^2 RGB): whole
 * run 16-17 s with stb, 10 s with libpng's defaults (level 6, adaptive
 * filters), 3.8 s fast (55 MB instead of 46 MB). Smaller pictures keep
 * libpng's defaults. */
#define PNG_FAST_PIXELS (16LL << 20)

static int write_png_lib(FILE *f, const gs_image *img, png_err_ctx *ctx)
{
    static const int color_type[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA,
                                      PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGBA};
    png_structp png =
        png_create_write_struct(PNG_LIBPNG_VER_STRING, ctx, png_error_cb, png_warning_cb);
    if (!png) {
        snprintf(ctx->msg, sizeof ctx->msg, "cannot create the libpng writer");
        return 0;
    }
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        snprintf(ctx->msg, sizeof ctx->msg, "cannot create the libpng info struct");
        return 0;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return 0;
    }
    png_init_io(png, f);
    if ((long long)img->width * img->height >= PNG_FAST_PIXELS) {
        png_set_compression_level(png, 1);
        png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
    }
    png_set_IHDR(png, info, (png_uint_32)img->width, (png_uint_32)img->height, img->bits,
                 color_type[img->channels], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    size_t row = (size_t)img->width * (size_t)img->channels;
    if (img->bits == 16) {
        uint16_t probe = 1;
        uint8_t first;
        memcpy(&first, &probe, 1);
        if (first == 1)
            png_set_swap(png); /* PNG stores big-endian samples */
        for (int y = 0; y < img->height; y++)
            png_write_row(png, (png_const_bytep)(img->data16 + (size_t)y * row));
    } else {
        for (int y = 0; y < img->height; y++)
            png_write_row(png, (png_const_bytep)(img->data8 + (size_t)y * row));
    }
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return 1;
}

gs_err gs_image_write_png(const char *path, const gs_image *img)
{
    GS_CALL(check_shape(path, img->width, img->height, img->channels, img->bits));
    GS_CHECK(img->bits == 8 ? img->data8 != NULL : img->data16 != NULL, GS_ERR_ARG,
             "%s: image has no %d-bit pixel array", path, img->bits);
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    int ok;
    png_err_ctx ctx = {{0}};
    ok = write_png_lib(af.f, img, &ctx);
    if (!ok) {
        gs_atomic_abort(&af);
        GS_RAISE(GS_ERR_LIB, "%s: PNG encoding failed: %s", path, ctx.msg);
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
}

float gs_image_sample(const gs_image *img, int x, int y, int c)
{
    size_t i = ((size_t)y * (size_t)img->width + (size_t)x) * (size_t)img->channels + (size_t)c;
    return img->bits == 8 ? img->data8[i] / 255.0f : img->data16[i] / 65535.0f;
}

gs_err gs_image_to_gray(const gs_image *img, float **out)
{
    GS_CALL(check_shape("image", img->width, img->height, img->channels, img->bits));
    float *g = NULL;
    size_t n = (size_t)img->width * (size_t)img->height;
    GS_CALL(gs_alloc_array((void **)&g, n, sizeof(float), "grey image"));
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) {
            float v;
            if (img->channels <= 2) {
                v = gs_image_sample(img, x, y, 0);
            } else {
                float r = gs_image_sample(img, x, y, 0), gr = gs_image_sample(img, x, y, 1),
                      b = gs_image_sample(img, x, y, 2);
                v = (r == gr && gr == b) ? r : 0.2126f * r + 0.7152f * gr + 0.0722f * b;
            }
            g[(size_t)y * img->width + x] = v;
        }
    *out = g;
    return GS_OK;
}

gs_err gs_image_from_gray(int width, int height, const float *v, float lo, float hi, int bits,
                          gs_image *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(isfinite(lo) && isfinite(hi) && hi > lo, GS_ERR_ARG,
             "grey range [%g, %g]: expected finite lo < hi", (double)lo, (double)hi);
    GS_CALL(gs_image_alloc(out, width, height, 1, bits));
    double maxv = bits == 8 ? 255.0 : 65535.0, scale = maxv / ((double)hi - lo);
    size_t n = (size_t)width * (size_t)height;
    for (size_t i = 0; i < n; i++) {
        double q = isnan(v[i]) ? 0.0 : floor(((double)v[i] - lo) * scale + 0.5);
        q = q < 0 ? 0 : q > maxv ? maxv : q;
        if (bits == 8)
            out->data8[i] = (uint8_t)q;
        else
            out->data16[i] = (uint16_t)q;
    }
    return GS_OK;
}
