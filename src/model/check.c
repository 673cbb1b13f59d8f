/* Independent consistency checker. Deliberately shares nothing with the
 * synthesizer's bitsets or propagation: it lists the example's adjacent
 * pairs as sorted 64-bit keys (axis, first label, second label) and looks
 * every output pair up by binary search. See include/geosynth/model.h. */
#include <stdlib.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/model.h"

static uint64_t pair_key(int axis, unsigned a, unsigned b)
{
    return ((uint64_t)axis << 32) | ((uint64_t)a << 16) | (uint64_t)b;
}

static uint16_t at(const gs_model_lattice *l, int x, int y, int z)
{
    return l->labels[(size_t)x + (size_t)l->nx * ((size_t)y + (size_t)l->ny * (size_t)z)];
}

/* Height of one frame of a 4D lattice (its own arithmetic, not the
 * synthesizer's helpers): frames stacked along z. */
static int frame_height(const gs_model_lattice *l) { return l->frames > 1 ? l->nz / l->frames : l->nz; }

gs_err gs_model_check(const gs_model_lattice *example, const gs_model_lattice *output,
                      gs_model_violation *out, size_t cap, size_t *count)
{
    size_t ncell = (size_t)example->nx * (size_t)example->ny * (size_t)example->nz;
    uint64_t *keys = NULL;
    /* up to four pairs (x, y, z, t) plus one "label occurs" key per cell */
    GS_CALL(gs_alloc_array((void **)&keys, 5 * ncell, sizeof *keys, "checker pairs"));
    size_t n = 0;
    const int efz = frame_height(example), ofz = frame_height(output);
    for (int z = 0; z < example->nz; z++)
        for (int y = 0; y < example->ny; y++)
            for (int x = 0; x < example->nx; x++) {
                uint16_t a = at(example, x, y, z);
                if (x + 1 < example->nx)
                    keys[n++] = pair_key(0, a, at(example, x + 1, y, z));
                if (y + 1 < example->ny)
                    keys[n++] = pair_key(1, a, at(example, x, y + 1, z));
                if ((z + 1) % efz != 0)
                    keys[n++] = pair_key(2, a, at(example, x, y, z + 1));
                if (z + efz < example->nz)
                    keys[n++] = pair_key(3, a, at(example, x, y, z + efz)); /* next frame */
                keys[n++] = pair_key(4, a, a); /* "label occurs" */
            }
    gs_measure_keys_sort(keys, n);
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (m == 0 || keys[i] != keys[m - 1])
            keys[m++] = keys[i];

    size_t found = 0;
    for (int z = 0; z < output->nz; z++)
        for (int y = 0; y < output->ny; y++)
            for (int x = 0; x < output->nx; x++) {
                uint16_t a = at(output, x, y, z);
                gs_model_violation v = {x, y, z, -1, a, a};
                if (!gs_measure_keys_has(keys, m, pair_key(4, a, a))) {
                    if (found < cap)
                        out[found] = v;
                    found++;
                }
                for (int axis = 0; axis < 4; axis++) {
                    int qx = x + (axis == 0), qy = y + (axis == 1),
                        qz = z + (axis == 2) + (axis == 3) * ofz;
                    if (qx >= output->nx || qy >= output->ny || qz >= output->nz ||
                        (axis == 2 && qz % ofz == 0) || (axis == 3 && output->frames <= 1))
                        continue;
                    uint16_t b = at(output, qx, qy, qz);
                    if (gs_measure_keys_has(keys, m, pair_key(axis, a, b)))
                        continue;
                    v.dir = 2 * axis;
                    v.b = b;
                    if (found < cap)
                        out[found] = v;
                    found++;
                }
            }
    gs_free(keys);
    *count = found;
    return GS_OK;
}
