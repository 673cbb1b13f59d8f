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

#include "geosynth/mem.h"
#include "geosynth/mesh.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    static const char *names[4] = {"fuzz.ply", "fuzz.off", "fuzz.stl", "fuzz.obj"};
    const char *name = names[data[0] % 4];
    /* an exact-size copy, so ASan sees any read past the end */
    char *buf = gs_malloc(size - 1 ? size - 1 : 1);
    if (!buf)
        return 0;
    memcpy(buf, data + 1, size - 1);
    gs_mesh m;
    if (gs_mesh_parse(buf, size - 1, name, &m) != GS_OK) {
        if (gs_error_message()[0] == '\0')
            __builtin_trap(); /* an error must say what is wrong */
        gs_error_clear();
    } else {
        if (m.ntris == 0 || gs_mesh_validate(&m, name) != GS_OK)
            __builtin_trap();
        gs_mesh_destroy(&m);
    }
    gs_free(buf);
    return 0;
}
