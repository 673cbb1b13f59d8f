/* libFuzzer target for the micro engine's distribution tables
 * (gs_micro_dist_read_csv, src/micro/table.c: "bin, positive, negative" rows,
 * header, comments). The input is the file. Every input must give a table
 * (1..16384 bins, every probability finite in [0, 1]) or an error naming
 * the line and what was expected, in printable text; a table then goes
 * through the sum check a run makes (gs_micro_dist_check_sum), which may
 * refuse it but must say why. Seeds: tests/fuzz/corpus/table/.
 *   make fuzz && build-fuzz/fuzz_table -max_total_time=60 tests/fuzz/corpus/table
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_util.h"
#include "geosynth/micro.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("table.csv", data, size);
    gs_micro_dist d;
    memset(&d, 0, sizeof d);
    if (gs_micro_dist_read_csv(path, &d) != GS_OK) {
        if (d.pos || d.neg)
            __builtin_trap(); /* on error *d is unchanged */
        fuzz_check_error();
        return 0;
    }
    if (d.nbins < 1 || d.nbins > 16384 || !d.pos || !d.neg)
        __builtin_trap();
    for (uint32_t i = 0; i < d.nbins; i++)
        if (!(d.pos[i] >= 0 && d.pos[i] <= 1 && d.neg[i] >= 0 && d.neg[i] <= 1))
            __builtin_trap();
    if (gs_micro_dist_check_sum(d.pos, d.nbins, d.neg, d.nbins, 1e-3, path) != GS_OK)
        fuzz_check_error();
    gs_micro_dist_free(&d);
    return 0;
}
