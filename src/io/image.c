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

gs_err gs_image_read(const char *path, gs_image *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(path && path[0], GS_ERR_ARG, "image path is empty");
    FILE *f = fopen(path, "rb");
    GS_CHECK(f, GS_ERR_IO, "%s: cannot open image file: %s", path, strerror(errno));
    int w = 0, h = 0, c = 0;
    gs_err err = GS_OK;
    if (!stbi_info_from_file(f, &w, &h, &c)) {
        fclose(f);
        GS_RAISE(GS_ERR_FORMAT, "%s: not a readable PNG or JPEG image (%s)", path,
                 stbi_failure_reason());
    }
    GS_TRY(err, check_shape(path, w, h, c, 8), done);
    int is16 = stbi_is_16_bit_from_file(f);
    void *pix;
    int w2, h2, c2;
    if (is16)
        pix = stbi_load_from_file_16(f, &w2, &h2, &c2, 0);
    else
        pix = stbi_load_from_file(f, &w2, &h2, &c2, 0);
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
    fclose(f);
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
