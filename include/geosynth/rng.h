/* Counter-based random streams (Random123 Philox4x32-10).
 *
 * A stream is keyed by (seed, stream id): the same pair gives the same
 * numbers on any rank, in any order of evaluation, so results never depend
 * on the rank count. Engines derive stream ids from what the randomness is
 * for (gs_rng_stream_id(domain, a, b, c)), never from the rank.
 *
 * The whole state is (seed, stream, counter, index): four integers that a
 * checkpoint stores to resume a stream exactly (gs_rng_state_*).
 */
#ifndef GEOSYNTH_RNG_H
#define GEOSYNTH_RNG_H

#include <stdint.h>

typedef struct gs_rng {
    uint64_t seed;
    uint64_t stream;
    uint64_t counter;    /* next Philox block to generate */
    uint32_t buf[4];     /* current block */
    unsigned index;      /* next word of buf to hand out, 4 = empty */
} gs_rng;

void gs_rng_init(gs_rng *r, uint64_t seed, uint64_t stream);

/* Combines a domain tag and up to three integers into a 64-bit stream id
 * (a mixing hash, collisions negligible). */
uint64_t gs_rng_stream_id(uint32_t domain, uint64_t a, uint64_t b, uint64_t c);

uint32_t gs_rng_u32(gs_rng *r);
uint64_t gs_rng_u64(gs_rng *r);
/* Uniform double in [0, 1) with 53 random bits. */
double gs_rng_uniform(gs_rng *r);
/* Uniform integer in [0, n) without modulo bias; n > 0. */
uint64_t gs_rng_below(gs_rng *r, uint64_t n);
/* Standard normal (Box-Muller on two uniforms). */
double gs_rng_normal(gs_rng *r);

/* Serializable position of a stream: blocks consumed and word index. */
typedef struct gs_rng_state {
    uint64_t seed, stream, counter, index;
} gs_rng_state;
gs_rng_state gs_rng_save(const gs_rng *r);
void gs_rng_restore(gs_rng *r, gs_rng_state s);

#endif
