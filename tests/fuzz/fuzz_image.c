/* libFuzzer target for image inputs: the PNG/JPEG reader (gs_image_read,
 * src/io/image.c over stb_image) and what each engine builds from an image
 * as a run does: the field engine's height map (gs_field_from_heightmap),
 * the model engine's overlapping-model sample (gs_model_patterns_learn, N =
 * 2 and 3 with all 8 symmetries), the micro engine's image acquisition
 * (grey levels -> gs_micro_dist_from_image). The input is the file.
 * Every input must decode to a consistent image (sides in [1, 65536],
 * channels 1..4, 8 or 16 bits, pixels readable to the last byte) or give an
 * error naming the file, in printable text; nothing may allocate more than
 * the image's pixels can justify from the file's size. Seeds:
 * tests/fuzz/corpus/image/ (grey, grey+alpha, RGB, RGBA and 16-bit PNGs,
 * a palette PNG, grey and colour baseline/progressive JPEGs, 6x6 pixels).
 *   make fuzz && build-fuzz/fuzz_image -max_total_time=60 tests/fuzz/corpus/image
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_util.h"
#include "geosynth/field.h"
#include "geosynth/field_examples.h"
#include "geosynth/image.h"
#include "geosynth/mem.h"
#include "geosynth/micro.h"
#include "geosynth/model.h"
#include "geosynth/model_tiles.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("image.png", data, size);
    gs_image img;
    if (gs_image_read(path, &img) != GS_OK) {
        if (img.data8 || img.data16)
            __builtin_trap(); /* on error *out is zeroed */
        fuzz_check_error();
        return 0;
    }
    if (img.width < 1 || img.height < 1 || img.width > GS_IMAGE_MAX_SIDE ||
        img.height > GS_IMAGE_MAX_SIDE || img.channels < 1 || img.channels > 4 ||
        (img.bits == 8) != (img.data8 != NULL) || (img.bits == 16) != (img.data16 != NULL))
        __builtin_trap();
    const uint32_t W = (uint32_t)img.width, H = (uint32_t)img.height;
    size_t npix = (size_t)W * H;
    volatile float sink = gs_image_sample(&img, img.width - 1, img.height - 1, img.channels - 1);
    (void)sink;
    float *grey = NULL;
    if (gs_image_to_gray(&img, &grey) != GS_OK)
        __builtin_trap();
    gs_image_destroy(&img);
    if (npix <= ((size_t)1 << 16)) {
        /* micro: image acquisition at threshold 128 */
        uint8_t *pix = gs_malloc(npix);
        if (pix) {
            for (size_t i = 0; i < npix; i++)
                pix[i] = (uint8_t)(grey[i] * 255.0f + 0.5f);
            gs_micro_dist d;
            memset(&d, 0, sizeof d);
            if (gs_micro_dist_from_image(&d, W, H, pix, 128, 1.0, 64) == GS_OK)
                gs_micro_dist_free(&d);
            else
                fuzz_check_error();
            gs_free(pix);
        }
        /* field: a small height map */
        gs_field *f = NULL;
        if (gs_field_from_heightmap(path, 8, 4, 2.0, &f) == GS_OK)
            gs_field_destroy(&f);
        else
            fuzz_check_error();
    }
    gs_free(grey);
    if (npix <= 1024) {
        /* model: overlapping patterns (O(patterns^2) adjacency: small only) */
        for (int n = 2; n <= 3; n++) {
            gs_model_patterns p;
            if (gs_model_patterns_learn(path, n, 8, n == 3, &p) == GS_OK)
                gs_model_patterns_destroy(&p);
            else
                fuzz_check_error();
        }
    }
    return 0;
}
