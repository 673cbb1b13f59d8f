/* libFuzzer target: arbitrary bytes as an in-memory HDF5 file image fed to
 * the checkpoint reader/validator (gs_ckpt_open_image: raw-byte precheck,
 * /geosynth identity, engine and version checks), then to the dataset and
 * attribute readers with the shapes the file claims (bounded sizes), and to
 * the inspector (gs_inspect_image), which walks any structure.
 * Seeds: tests/fuzz/corpus/ckpt/ (small valid checkpoints and damaged ones). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/error.h"
#include "geosynth/h5.h"
#include "geosynth/mem.h"

/* libhdf5 1.10 leaks cache buffers on some error paths (e.g. an object
 * header beyond the end of the file: H5O_protect -> H5FL_blk_malloc, found
 * by this target). Those leaks are inside the library, not in geosynth;
 * LeakSanitizer still checks every allocation made by our own code. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libhdf5\n"; }

static void read_datasets(gs_ckpt_t h)
{
    static const char *names[] = {"/field/a", "/field/packed", "/field/labels", "/state/b"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        gs_h5_shape s;
        if (gs_ckpt_shape(h, names[i], &s) != GS_OK)
            continue;
        uint64_t n = gs_h5_type_size(s.type);
        for (int d = 0; d < s.rank && n <= (1u << 20); d++)
            n = s.dims[d] ? n * s.dims[d] : 0;
        if (n > (1u << 20))
            continue; /* the file may claim anything: stay bounded */
        void *buf = gs_malloc((size_t)n + 1);
        if (!buf)
            continue;
        gs_ckpt_read_whole(h, names[i], &s, buf);
        if (s.dims[0] > 0)
            gs_ckpt_read_slab(h, names[i], &s, s.dims[0] - 1, 1, buf);
        gs_free(buf);
        gs_error_clear();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static FILE *sink;
    if (!sink)
        sink = fopen("/dev/null", "w");
    gs_ckpt_t h = NULL;
    if (gs_ckpt_open_image(data, size, "fuzz.h5", NULL, &h) == GS_OK) {
        int64_t i;
        uint64_t u;
        double f;
        char *s = NULL;
        gs_ckpt_get_i64(h, "/state", "k", &i);
        gs_ckpt_get_u64(h, "/state", "counter", &u);
        gs_ckpt_get_f64(h, "/state", "t", &f);
        if (gs_ckpt_get_str(h, "/state", "phase", &s) == GS_OK)
            gs_free(s);
        read_datasets(h);
        gs_ckpt_close(&h);
    }
    gs_error_clear();
    /* The inspector accepts any HDF5 file, and libhdf5 1.10 itself crashes
     * on some hostile files in the older formats (unchecksummed metadata;
     * see src/io/h5_internal.h). Fuzz it on superblock version >= 3 images,
     * the format geosynth writes, where libhdf5 verifies all checksums. */
    static const uint8_t sig[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
    if (size > 8 && memcmp(data, sig, 8) == 0 && data[8] >= 3) {
        gs_inspect_opts opts = {5, 4096};
        gs_inspect_image(data, size, "fuzz.h5", sink, &opts);
        gs_error_clear();
    }
    return 0;
}
