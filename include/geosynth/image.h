/* Raster images: PNG in (8 and 16 bit; grey, grey+alpha, RGB, RGBA; JPEG
 * 8-bit too) through stb_image, PNG out (8 and 16 bit) through libpng, so
 * 16-bit height maps round-trip exactly.
 *
 * Layout: row-major, row 0 = top row of the file, channels interleaved:
 * sample (x, y, c) is data[(y * width + x) * channels + c]. Exactly one of
 * data8 (bits == 8) and data16 (bits == 16) is set. Arrays come from
 * gs_malloc; gs_image_destroy frees them and zeroes the struct.
 *
 * Writes are atomic (path.tmp + rename). Errors name the file: missing or
 * unreadable (GS_ERR_IO), not a PNG/JPEG or damaged (GS_ERR_FORMAT), larger
 * than GS_IMAGE_MAX_SIDE per side (GS_ERR_FORMAT), encoder failure (GS_ERR_LIB).
 */
#ifndef GEOSYNTH_IMAGE_H
#define GEOSYNTH_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"

#define GS_IMAGE_MAX_SIDE 65536

typedef struct gs_image {
    int width, height;
    int channels; /* 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA */
    int bits;     /* 8 or 16 */
    uint8_t *data8;
    uint16_t *data16;
} gs_image;

/* Zeroed image. On error *img is zeroed. */
gs_err gs_image_alloc(gs_image *img, int width, int height, int channels, int bits);
void gs_image_destroy(gs_image *img);

/* Reads a PNG (or JPEG) keeping its bit depth (16-bit PNGs stay 16-bit) and
 * its channel count. On error *out is zeroed. */
gs_err gs_image_read(const char *path, gs_image *out);

/* Writes img as PNG with its bit depth and channels. */
gs_err gs_image_write_png(const char *path, const gs_image *img);

/* Sample (x, y, c) scaled to [0, 1] (value / 255 or / 65535). No bounds check. */
float gs_image_sample(const gs_image *img, int x, int y, int c);

/* Grey levels in [0, 1], width*height floats, row-major (row 0 = top):
 * grey channel as is, RGB pixels with R == G == B as R, other colours as
 * Rec. 709 luma; alpha is ignored. *out is gs_malloc'ed (caller frees). */
gs_err gs_image_to_gray(const gs_image *img, float **out);

/* Quantizes a grey field into a 1-channel image of bits 8 or 16:
 * level = round((v - lo) / (hi - lo) * max), clamped to [0, max].
 * hi must exceed lo. On error *out is zeroed. */
gs_err gs_image_from_gray(int width, int height, const float *v, float lo, float hi, int bits,
                          gs_image *out);

#endif
