/* libFuzzer target for HDF5 example inputs: the field engine's HDF5 field
 * (gs_field_from_h5, /field/distance float32 {nz, ny, nx}) and the model
 * engine's HDF5 lattice (gs_model_load format h5, /model/labels uint16),
 * both through the checkpoint reader's file checks (src/io/h5_file.c). The
 * input is the file. Every input must give a field / lattice or an error
 * naming the file, in printable text; no allocation beyond what the file can
 * hold. (fuzz_ckpt covers the same reader from an in-memory image with the
 * checkpoint's datasets.) Seeds: tests/fuzz/corpus/h5example/ (a small
 * field.h5 and lattice.h5 as runs write them, and damaged copies).
 *   make fuzz && build-fuzz/fuzz_h5example -max_total_time=60 tests/fuzz/corpus/h5example
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_util.h"
#include "geosynth/field.h"
#include "geosynth/field_examples.h"
#include "geosynth/model.h"
#include "geosynth/model_io.h"

/* libhdf5 1.10 leaks cache buffers on some error paths (see fuzz_ckpt.c);
 * LeakSanitizer still checks every allocation of our own code. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libhdf5\n"; }

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("example.h5", data, size);
    gs_field *f = NULL;
    if (gs_field_from_h5(path, "/field/distance", &f) == GS_OK) {
        if (!f || f->nx < 1 || f->ny < 1 || f->nz < 1)
            __builtin_trap();
        gs_field_destroy(&f);
    } else {
        fuzz_check_error();
    }
    gs_model_lattice lat;
    memset(&lat, 0, sizeof lat);
    if (gs_model_load(path, "h5", NULL, &lat, NULL) == GS_OK) {
        if (lat.nx < 1 || lat.ny < 1 || lat.nz < 1 || !lat.labels || lat.frames < 1 ||
            lat.nz % lat.frames != 0)
            __builtin_trap(); /* a 4D dataset: frames stacked along z */
        gs_model_lattice_destroy(&lat);
    } else {
        fuzz_check_error();
    }
    return 0;
}
