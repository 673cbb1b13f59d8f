/* Philox4x32-10 streams; see include/geosynth/rng.h. */
#include "geosynth/digest.h"
#include "geosynth/rng.h"

#include <math.h>
#include <Random123/philox.h>

static void refill(gs_rng *r)
{
    philox4x32_ctr_t ctr = {{(uint32_t)r->counter, (uint32_t)(r->counter >> 32),
                             (uint32_t)r->stream, (uint32_t)(r->stream >> 32)}};
    philox4x32_key_t key = {{(uint32_t)r->seed, (uint32_t)(r->seed >> 32)}};
    philox4x32_ctr_t out = philox4x32(ctr, key);
    for (int i = 0; i < 4; i++)
        r->buf[i] = out.v[i];
    r->counter++;
    r->index = 0;
}

void gs_rng_init(gs_rng *r, uint64_t seed, uint64_t stream)
{
    r->seed = seed;
    r->stream = stream;
    r->counter = 0;
    r->index = 4;
}

uint64_t gs_rng_stream_id(uint32_t domain, uint64_t a, uint64_t b, uint64_t c)
{
    uint64_t h = gs_hash_mix64(0x9e3779b97f4a7c15ULL ^ domain);
    h = gs_hash_mix64(h ^ a);
    h = gs_hash_mix64(h ^ (b + 0x632be59bd9b4e019ULL));
    h = gs_hash_mix64(h ^ (c + 0x85157af5ULL));
    return h;
}

uint32_t gs_rng_u32(gs_rng *r)
{
    if (r->index >= 4)
        refill(r);
    return r->buf[r->index++];
}

uint64_t gs_rng_u64(gs_rng *r)
{
    uint64_t hi = gs_rng_u32(r);
    return (hi << 32) | gs_rng_u32(r);
}

double gs_rng_uniform(gs_rng *r)
{
    return (double)(gs_rng_u64(r) >> 11) * (1.0 / 9007199254740992.0);
}

uint64_t gs_rng_below(gs_rng *r, uint64_t n)
{
    if (n <= 1)
        return 0;
    /* Rejection sampling: values below 2^64 mod n would be over-represented. */
    uint64_t threshold = (0 - n) % n;
    for (;;) {
        uint64_t x = gs_rng_u64(r);
        if (x >= threshold)
            return x % n;
    }
}

double gs_rng_normal(gs_rng *r)
{
    double u1 = gs_rng_uniform(r), u2 = gs_rng_uniform(r);
    if (u1 < 1e-300)
        u1 = 1e-300;
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

gs_rng_state gs_rng_save(const gs_rng *r)
{
    /* counter counts generated blocks; a partly used block is regenerated on
     * restore, so store the block it came from. */
    gs_rng_state s = {r->seed, r->stream, r->counter, r->index};
    if (r->index < 4 && r->counter > 0)
        s.counter = r->counter - 1;
    return s;
}

void gs_rng_restore(gs_rng *r, gs_rng_state s)
{
    gs_rng_init(r, s.seed, s.stream);
    r->counter = s.counter;
    if (s.index < 4) {
        refill(r);
        r->index = (unsigned)s.index;
    }
}
