/* libFuzzer target for the oriented point-set PLY reader (src/io/pointply.c,
 * over the bounded PLY layer src/io/ply.c), the points engine's example
 * input. The first byte's bit 0 says whether normals are required; the rest
 * is the file. Every input must either give points (finite coordinates;
 * with normals, unit normals) or an error that says what is wrong, in
 * printable text. Seeds: tests/fuzz/corpus/pointply/ (ASCII and both binary
 * encodings, float and double, with and without normals, extra elements).
 *   make fuzz && build-fuzz/fuzz_pointply -max_total_time=60 tests/fuzz/corpus/pointply
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_util.h"
#include "geosynth/mem.h"
#include "geosynth/pointply.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t opt;
    size_t len;
    char *buf = fuzz_split(data, size, &opt, &len);
    if (!buf)
        return 0;
    int require = opt & 1;
    gs_pointply p;
    if (gs_pointply_parse(buf, len, "fuzz.ply", require, &p) != GS_OK) {
        fuzz_check_error();
    } else {
        if (require && !p.has_normals)
            __builtin_trap();
        for (size_t i = 0; i < p.n; i++) {
            const double *v = p.v + 6 * i;
            if (!isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2]))
                __builtin_trap();
            if (p.has_normals && require &&
                fabs(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] - 1.0) > 1e-9)
                __builtin_trap();
        }
        gs_pointply_destroy(&p);
    }
    gs_free(buf);
    return 0;
}
