/* XXH3-64 digests; see include/geosynth/digest.h. */
#include "geosynth/digest.h"

#include <stdio.h>
#include <xxhash.h>

uint64_t gs_digest_bytes(const void *data, size_t n)
{
    return (uint64_t)XXH3_64bits(data, n);
}

int gs_digest_init(gs_digest *d)
{
    XXH3_state_t *s = XXH3_createState();
    if (!s)
        return 0;
    XXH3_64bits_reset(s);
    d->state = s;
    return 1;
}

void gs_digest_update(gs_digest *d, const void *data, size_t n)
{
    XXH3_64bits_update((XXH3_state_t *)d->state, data, n);
}

uint64_t gs_digest_final(gs_digest *d)
{
    uint64_t h = (uint64_t)XXH3_64bits_digest((XXH3_state_t *)d->state);
    XXH3_freeState((XXH3_state_t *)d->state);
    d->state = NULL;
    return h;
}

void gs_digest_hex(uint64_t h, char out[17])
{
    snprintf(out, 17, "%016llx", (unsigned long long)h);
}
