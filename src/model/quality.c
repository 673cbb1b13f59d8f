/* Resemblance: share of output windows that occur in the example. See
 * include/geosynth/model_io.h. Windows are compared by a 64-bit digest of
 * their labels (XXH3; a collision would only overstate resemblance by one
 * window in about 2^-64 per pair). */
#include <stdlib.h>

#include "geosynth/digest.h"
#include "geosynth/mem.h"
#include "geosynth/model_io.h"

static int cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return (a > b) - (a < b);
}

static uint64_t window_key(const gs_model_lattice *l, int x, int y, int z, const int w[3],
                           uint16_t *buf)
{
    size_t k = 0;
    for (int dz = 0; dz < w[2]; dz++)
        for (int dy = 0; dy < w[1]; dy++)
            for (int dx = 0; dx < w[0]; dx++)
                buf[k++] = l->labels[gs_model_lattice_index(l, x + dx, y + dy, z + dz)];
    return gs_digest_bytes(buf, k * sizeof *buf);
}

gs_err gs_model_resemblance(const gs_model_lattice *example, const gs_model_lattice *output,
                            int w, double *share)
{
    GS_CHECK(w >= 1 && w <= 8, GS_ERR_ARG, "resemblance window %d: expected 1..8", w);
    const int en[3] = {example->nx, example->ny, example->nz};
    const int on[3] = {output->nx, output->ny, output->nz};
    int ww[3];
    for (int a = 0; a < 3; a++) {
        ww[a] = w;
        if (ww[a] > en[a])
            ww[a] = en[a];
        if (ww[a] > on[a])
            ww[a] = on[a];
    }
    size_t ne = 1, no = 1;
    for (int a = 0; a < 3; a++) {
        ne *= (size_t)(en[a] - ww[a] + 1);
        no *= (size_t)(on[a] - ww[a] + 1);
    }
    uint64_t *keys = NULL;
    uint16_t buf[512];
    GS_CALL(gs_alloc_array((void **)&keys, ne, sizeof *keys, "example windows"));
    size_t k = 0;
    for (int z = 0; z + ww[2] <= en[2]; z++)
        for (int y = 0; y + ww[1] <= en[1]; y++)
            for (int x = 0; x + ww[0] <= en[0]; x++)
                keys[k++] = window_key(example, x, y, z, ww, buf);
    qsort(keys, k, sizeof *keys, cmp_u64);
    size_t hits = 0;
    for (int z = 0; z + ww[2] <= on[2]; z++)
        for (int y = 0; y + ww[1] <= on[1]; y++)
            for (int x = 0; x + ww[0] <= on[0]; x++) {
                uint64_t key = window_key(output, x, y, z, ww, buf);
                size_t lo = 0, hi = k;
                while (lo < hi) {
                    size_t mid = lo + (hi - lo) / 2;
                    if (keys[mid] < key)
                        lo = mid + 1;
                    else
                        hi = mid;
                }
                hits += lo < k && keys[lo] == key;
            }
    gs_free(keys);
    *share = no ? (double)hits / (double)no : 0.0;
    return GS_OK;
}
