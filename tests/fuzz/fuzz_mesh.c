/* libFuzzer target for the mesh readers (src/io/meshread.c): PLY, OFF, STL
 * and OBJ. The first byte picks the format (its value mod 4: ply, off, stl,
 * obj), the rest is the file. Every input must either give a valid mesh
 * (gs_mesh_validate, at least one triangle) or an error that says what is
 * wrong; nothing may crash, leak, read out of bounds or take long (the
 * readers are linear in the file size). Seeds: tests/fuzz/corpus/mesh/
 * (small cubes in every format and encoding, made by hand).
 *   make fuzz && build-fuzz/fuzz_mesh -max_total_time=60 tests/fuzz/corpus/mesh
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_util.h"
#include "geosynth/mem.h"
#include "geosynth/mesh.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *names[4] = {"fuzz.ply", "fuzz.off", "fuzz.stl", "fuzz.obj"};
    uint8_t opt;
    size_t len;
    char *buf = fuzz_split(data, size, &opt, &len);
    if (!buf)
        return 0;
    const char *name = names[opt % 4];
    gs_mesh m;
    if (gs_mesh_parse(buf, len, name, &m) != GS_OK) {
        fuzz_check_error();
    } else {
        if (m.ntris == 0 || gs_mesh_validate(&m, name) != GS_OK)
            __builtin_trap();
        gs_mesh_destroy(&m);
    }
    gs_free(buf);
    return 0;
}
