/* libFuzzer target for the model engine's example lattices: Paul Merrell's
 * samples/NAME.txt (gs_model_parse_merrell_txt) and DeBroglie's CSV layers
 * (gs_model_parse_debroglie_csv), src/model/lattice.c and csv.c. The first
 * byte picks the format (even: txt, odd: csv), the rest is the file. Every
 * input must give a lattice within the documented limits (dims in
 * [1, 2^20], fewer than 2^31 cells) or an error naming what is wrong, in
 * printable text; a small lattice's rules are then learned as a run would
 * (gs_model_rules_learn), which must succeed when it holds a label.
 * Seeds: tests/fuzz/corpus/lattice/.
 *   make fuzz && build-fuzz/fuzz_lattice -max_total_time=60 tests/fuzz/corpus/lattice
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_util.h"
#include "geosynth/mem.h"
#include "geosynth/model.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t opt;
    size_t len;
    char *buf = fuzz_split(data, size, &opt, &len);
    if (!buf)
        return 0;
    int csv = opt & 1;
    gs_model_lattice lat;
    memset(&lat, 0, sizeof lat);
    gs_err err = csv ? gs_model_parse_debroglie_csv(buf, len, "fuzz.csv", &lat)
                     : gs_model_parse_merrell_txt(buf, len, "fuzz.txt", &lat);
    gs_free(buf);
    if (err != GS_OK) {
        if (lat.labels)
            __builtin_trap(); /* on error the output is left unchanged */
        fuzz_check_error();
        return 0;
    }
    if (lat.nx < 1 || lat.ny < 1 || lat.nz < 1 || lat.nx > (1 << 20) || lat.ny > (1 << 20) ||
        lat.nz > (1 << 20) || !lat.labels)
        __builtin_trap();
    size_t cells = (size_t)lat.nx * (size_t)lat.ny * (size_t)lat.nz;
    if (cells >= ((size_t)1 << 31))
        __builtin_trap();
    int any = 0, top = 0;
    for (size_t i = 0; i < cells; i++) {
        any |= lat.labels[i] != 0;
        top = lat.labels[i] > top ? lat.labels[i] : top;
    }
    /* The rules hold a bitset of every label per label and direction: keep
     * each run small (a label id of 65534 costs gigabytes by design there,
     * a pre-synthesis memory check's business, not the parser's). */
    if (any && cells <= 4096 && top <= 256) {
        gs_model_rules_t r = NULL;
        if (gs_model_rules_learn(&lat, &r) != GS_OK)
            __builtin_trap();
        gs_model_rules_destroy(&r);
    }
    gs_model_lattice_destroy(&lat);
    return 0;
}
