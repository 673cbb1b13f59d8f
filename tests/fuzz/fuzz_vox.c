/* libFuzzer target for the .vox / .slab.vox parser (src/io/vox.c).
 *
 * Every input must either parse or fail with an error; a parsed file must
 * flatten (unless rotated or too large) and survive encode -> parse with the
 * same models. Seeds: tests/fuzz/corpus/vox/ (regenerate with
 * tests/fuzz/gen_vox_corpus.c, see its header).
 *   make fuzz && build-fuzz/fuzz_vox -max_total_time=60 tests/fuzz/corpus/vox
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_util.h"
#include "geosynth/mem.h"
#include "geosynth/vox.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    gs_vox v;
    if (gs_vox_parse(data, size, "fuzz.vox", &v) != GS_OK) {
        fuzz_check_error();
        return 0;
    }
    /* keep each run fast: the parser itself already handled the big ones */
    size_t cells = 0;
    for (int i = 0; i < v.nmodels; i++)
        cells += (size_t)v.models[i].nx * v.models[i].ny * v.models[i].nz;
    if (cells > ((size_t)1 << 22)) {
        gs_vox_destroy(&v);
        return 0;
    }
    int nx, ny, nz;
    uint8_t *flat = NULL;
    if (gs_vox_flatten(&v, &nx, &ny, &nz, &flat, NULL) == GS_OK)
        gs_free(flat);
    gs_error_clear();

    int rotated = 0, big = 0;
    for (int i = 0; i < v.ninstances; i++)
        rotated |= v.instances[i].rotated;
    for (int i = 0; i < v.nmodels; i++)
        big |= v.models[i].nx > GS_VOX_MAX_AXIS || v.models[i].ny > GS_VOX_MAX_AXIS ||
               v.models[i].nz > GS_VOX_MAX_AXIS; /* Slab6 input may exceed 256 */
    uint8_t *buf = NULL;
    size_t len = 0;
    if (!rotated && !big) {
        if (gs_vox_encode(&v, &buf, &len) != GS_OK)
            __builtin_trap();
        gs_vox r;
        if (gs_vox_parse(buf, len, "re-encoded.vox", &r) != GS_OK || r.nmodels != v.nmodels)
            __builtin_trap();
        for (int i = 0; i < v.nmodels; i++) {
            const gs_vox_model *a = &v.models[i], *b = &r.models[i];
            if (a->nx != b->nx || a->ny != b->ny || a->nz != b->nz ||
                memcmp(a->labels, b->labels, (size_t)a->nx * a->ny * a->nz) != 0)
                __builtin_trap();
        }
        gs_vox_destroy(&r);
        gs_free(buf);
    }
    gs_vox_destroy(&v);
    return 0;
}
