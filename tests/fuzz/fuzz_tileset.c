/* libFuzzer target for the model engine's tile sets: mxgmn's 2D <set> XML
 * (src/model/tileset.c), MarkovJunior's 3D <tileset> XML (tileset3d.c) over
 * the small XML reader (tileset_xml.c), and DeBroglie's voxSet JSON over the
 * JSON reader (tileset_json.c), loaded as a run loads them
 * (gs_model_tileset_load_any) and turned into rules. The first byte picks:
 * bit 0 the format (0: .xml, 1: .json), bit 1 whether tile images are
 * loaded, bit 2 a subset named "s"; the rest is the file. The scratch
 * directory holds tiles A, B and C as 2x2 RGBA PNGs (t/NAME.png) and as
 * 2x2x2 .vox models (t/NAME.vox and NAME.vox, for the JSON's relative
 * "src"), so the seeds reach symmetry expansion, images and voxel faces.
 * Every input must give a tile set with rules or an error naming the file
 * (and line), in printable text. Seeds: tests/fuzz/corpus/tileset/.
 *   make fuzz && build-fuzz/fuzz_tileset -max_total_time=60 tests/fuzz/corpus/tileset
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "fuzz_util.h"
#include "geosynth/image.h"
#include "geosynth/model.h"
#include "geosynth/model_io.h"
#include "geosynth/model_tiles.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void make_tiles(void)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/t", fuzz_dir());
    if (mkdir(path, 0700) != 0)
        __builtin_trap();
    static const char *names[3] = {"A", "B", "C"};
    for (int t = 0; t < 3; t++) {
        gs_image img;
        if (gs_image_alloc(&img, 2, 2, 4, 8) != GS_OK)
            __builtin_trap();
        for (int i = 0; i < 16; i++)
            img.data8[i] = (uint8_t)(i % 4 == 3 ? 255 : 40 * t + 30 * (i / 4) + 10 * (i % 4));
        snprintf(path, sizeof path, "%s/t/%s.png", fuzz_dir(), names[t]);
        if (gs_image_write_png(path, &img) != GS_OK)
            __builtin_trap();
        gs_image_destroy(&img);
        gs_model_lattice lat;
        memset(&lat, 0, sizeof lat);
        if (gs_model_lattice_create(&lat, 2, 2, 2) != GS_OK)
            __builtin_trap();
        for (int i = 0; i < 8; i++)
            lat.labels[i] = (uint16_t)((i + t) % 3 == 0 ? 0 : 1 + (i + t) % 3);
        for (int k = 0; k < 2; k++) {
            snprintf(path, sizeof path, "%s/%s%s.vox", fuzz_dir(), k ? "t/" : "", names[t]);
            if (gs_model_write_vox(path, &lat, NULL, NULL) != GS_OK)
                __builtin_trap();
        }
        gs_model_lattice_destroy(&lat);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int ready;
    if (!ready) {
        make_tiles();
        ready = 1;
    }
    if (size < 1)
        return 0;
    int json = data[0] & 1, images = (data[0] >> 1) & 1;
    const char *subset = (data[0] >> 2) & 1 ? "s" : NULL;
    const char *path = fuzz_file(json ? "t.json" : "t.xml", data + 1, size - 1);
    gs_model_tileset ts;
    memset(&ts, 0, sizeof ts);
    if (gs_model_tileset_load_any(path, subset, NULL, images, &ts) != GS_OK) {
        fuzz_check_error();
        return 0;
    }
    if (ts.ntiles < 1 || ts.npairs < 1)
        __builtin_trap();
    gs_model_rules_t r = NULL;
    if (gs_model_tileset_rules(&ts, &r) == GS_OK)
        gs_model_rules_destroy(&r);
    else
        fuzz_check_error();
    gs_model_tileset_destroy(&ts);
    return 0;
}
