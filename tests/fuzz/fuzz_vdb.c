/* libFuzzer target for the .vdb example check (gs_vdb_check, src/io/vdb.c):
 * the bounded walk over a VDB file's header, file metadata, grid
 * descriptors, grid metadata and transform that stands in front of OpenVDB
 * (which then reads in a forked child with memory and time limits; OpenVDB
 * itself lives in the plugin, which the fuzz build does not load). The input
 * is the file. Every input must pass or give an error naming the file and
 * the byte, in printable text. Seeds: tests/fuzz/corpus/vdb/ (small grids
 * written by geosynth's plugin, one and two grids, and damaged copies).
 *   make fuzz && build-fuzz/fuzz_vdb -max_total_time=60 tests/fuzz/corpus/vdb
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_util.h"
#include "geosynth/mem.h"
#include "geosynth/vdb.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *buf = fuzz_copy(data, size);
    if (!buf)
        return 0;
    if (gs_vdb_check(buf, size, "fuzz.vdb") != GS_OK)
        fuzz_check_error();
    gs_free(buf);
    return 0;
}
