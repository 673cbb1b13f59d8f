/* Colored independent regions, run with a dynamic rank-0 work queue.
 *
 * Model. The target (field blocks, model B-regions, ...) is cut into
 * regions, each with an id (unique, >= 0) and a color (>= 0). Regions of one
 * color never interact: none reads what another writes. A pass runs the
 * colors in ascending order; inside a color:
 *  1. run: rank 0 hands region ids to ranks on request (work queue) and
 *     computes regions itself between answering requests; workers keep two
 *     requests outstanding (gs_regions_set_prefetch) while they compute, so
 *     the next id is usually waiting when they finish (rank 0 answers only
 *     between its own regions). When fewer regions than ranks are left, a
 *     worker that still holds an unstarted region gets no more, so the last
 *     regions go to whoever is free first.
 *     run(ctx, id, color, pass, rng, out) READS the shared state and writes
 *     its result bytes into out; it must not modify the shared state.
 *  2. exchange: every rank's results go to every rank (one MPI_Allgatherv).
 *  3. apply: every rank calls apply(ctx, id, buf, len) for each region of
 *     the color in ascending id order, so the next color sees the same state
 *     on every rank.
 * Determinism: a region's result may depend only on (seed, region id, pass)
 * and the state before its color. The rng handed to run is keyed by
 * (seed, gs_rng_stream_id(domain, id, pass, 0)); use it and nothing else for
 * randomness. Then the final state is identical for any rank count, and
 * equal to a serial loop over colors and ids that applies each result at
 * once (which tests/mpi/regions_toy.c checks).
 *
 * Errors are collective per color: a run (or apply) that fails on any rank
 * stops the queue (a failing worker reports it with its next request; rank 0
 * then answers "done" to everyone), every rank finishes the color's protocol
 * and all ranks return the same error code from gs_regions_run_pass(): the
 * failing rank with its own record, the others with "rank N failed: ...".
 * Callers then end with gs_fatal(err, 1). A callback that cannot return
 * calls gs_fatal(err, 0), which aborts all ranks. An MPI failure is returned
 * on the rank that saw it only: treat it as local (gs_fatal(err, 0)).
 *
 * Cost per color on P ranks: 2 messages of 8 bytes per region computed off
 * rank 0 (request, reply), 1 MPI_Allgather of 16 bytes per rank (result
 * sizes and statuses), 1 MPI_Allgatherv of the results (each region: 16
 * bytes of header + its bytes rounded up to 8), 2 MPI_Allreduce of 2 ints
 * (agreement that every rank could allocate the results, and after apply). The
 * results of one color must total < 2 GiB. Memory: this rank's results plus
 * all results of one color.
 */
#ifndef GEOSYNTH_REGIONS_H
#define GEOSYNTH_REGIONS_H

#include <mpi.h>
#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"
#include "geosynth/rng.h"

typedef struct gs_region {
    int64_t id;
    int color;
} gs_region;

/* Result buffer of one region (owned by the scheduler). */
typedef struct gs_region_out gs_region_out;

/* Appends n bytes to the region's result. */
gs_err gs_region_out_append(gs_region_out *out, const void *data, size_t n);
/* Appends n uninitialized bytes and returns where to write them in *dst
 * (valid until the next append). */
gs_err gs_region_out_reserve(gs_region_out *out, size_t n, void **dst);

typedef gs_err (*gs_region_run_fn)(void *ctx, int64_t region_id, int color, int pass,
                                   gs_rng *rng, gs_region_out *out);
/* buf is 8-byte aligned and valid during the call only; len may be 0. */
typedef gs_err (*gs_region_apply_fn)(void *ctx, int64_t region_id, const void *buf, size_t len);

typedef struct gs_regions *gs_regions_t;

/* Collective on comm: every rank passes the same list (checked by count and
 * digest). Copies the list; dups comm. rng_domain separates this use of the
 * regions' random streams from others with the same seed. Errors: duplicate
 * or negative ids, negative colors. On error *out is unchanged. */
gs_err gs_regions_create(MPI_Comm comm, const gs_region *regions, int64_t count, uint64_t seed,
                         uint32_t rng_domain, gs_regions_t *out);
/* Collective. Sets *s to NULL; NULL is ok. */
void gs_regions_destroy(gs_regions_t *s);

/* Collective: runs every color of the list once, in ascending color order. */
gs_err gs_regions_run_pass(gs_regions_t s, int pass, gs_region_run_fn run,
                           gs_region_apply_fn apply, void *ctx);

/* Collective (same lists on every rank, checked by digest). Declares which
 * regions of different colors interact: for the region at list index i
 * (the list given to gs_regions_create), ids[offsets[i] .. offsets[i+1])
 * are the regions of LOWER colors whose write box meets its read box or
 * whose read box meets its write box (model: gs_model_regions_interact).
 * A pair that interacts but is left out makes the result depend on timing.
 * Test hook GS_FLOW_PICK=random:SEED: each rank runs a random ready region
 * of its share instead of the rule's, so such a pair shows at one rank. Regions not listed must not interact. Then
 * gs_regions_run_pass no longer waits at the end of each color and has no
 * rank-0 queue: every rank runs a region once the results it depends on
 * are applied there, picking among the ready ones (claims sent to all keep
 * ranks from picking the same one; when two still do, both compute the
 * same bytes and one copy is kept), and applies every result once its
 * predecessors are applied there (dataflow). The final state is the same
 * as with the color-by-color
 * schedule, hence the same as the serial loop, for any rank count; the
 * apply callback then sees the regions of one color in no fixed order, so
 * it must not depend on the order of non-interacting results (counters,
 * disjoint writes). Cost: each result goes from the rank that computed it
 * to every other rank as soon as it exists (point to point, in chunks that
 * fit the eager protocol so delivery does not wait for the sender's next
 * MPI call), instead of one Allgatherv per color. Memory: every result of
 * the pass is kept until the pass ends. Errors: ids not in the list, or of
 * the same or a higher color (GS_ERR_ARG, on every rank). */
gs_err gs_regions_set_conflicts(gs_regions_t s, const int64_t *offsets, const int64_t *ids);

/* The dataflow's priority (gs_regions_set_conflicts): dep[k] = how many of
 * the n regions wait for region k, directly or through others, where
 * succ[succ_off[k] .. succ_off[k+1]) are the regions that wait for k
 * directly, each later than k (positions in colour order). A free rank runs
 * the ready region with the most dependents first (then the lowest
 * position): a region that others wait for starts early, so a region that
 * turns out long (many tries) does not leave the other ranks idle at the
 * end. Local, no MPI; GS_ERR_MEM when out of memory. Also used by the model
 * engine's simulation of the rule (src/model/engine_sched.c). */
gs_err gs_regions_dependents(int64_t n, const int64_t *succ_off, const int64_t *succ, int64_t *dep);

typedef struct gs_regions_stats {
    int64_t computed;   /* regions this rank ran */
    int64_t bytes;      /* result bytes received in exchanges */
    double t_compute;   /* seconds in run */
    double t_wait;      /* seconds waiting for the queue (workers) or requests (rank 0);
                           dataflow: with nothing ready to run here */
    double t_exchange;  /* seconds in the result exchange */
    double t_apply;     /* seconds in apply */
    /* dataflow passes (gs_regions_set_conflicts) only: */
    double t_pass;      /* seconds in gs_regions_run_pass (all of it, this rank) */
    double t_tail;      /* part of t_wait after every region was claimed as far as this
                           rank knew: the end of a pass, nothing left to start here */
    int64_t duplicates; /* records received of regions this rank had already: work that
                           two ranks did at once */
} gs_regions_stats;
gs_regions_stats gs_regions_get_stats(const gs_regions_t s);

/* Requests a worker keeps outstanding (default 2, clamped to [1, 8]): more
 * hides rank 0's own regions better, fewer balances the end of a color
 * better. Same value on every rank. Does not change results. */
#define GS_REGIONS_PREFETCH_MAX 8
void gs_regions_set_prefetch(gs_regions_t s, int depth);

/* ---- Region grids over a box -------------------------------------------
 * gs_regions_grid cuts a box of dims[0] x dims[1] x dims[2] cells (2D: dims[2]
 * = 1 and size[2] = 1) into a grid of regions of size[] cells (the last one
 * along an axis may be smaller). Region (ix, iy, iz) has id
 * ix + nx * (iy + ny * iz) (x fastest) and color
 * (ix & 1) | (iy & 1) << 1 | (iz & 1) << 2 (2x2x2; 2x2 in 2D). Boxes are
 * half-open [lo, hi) in cells, all clipped to the domain:
 *   core  [lo, hi):   the cells the region owns (cores tile the box);
 *   write [wlo, whi): core grown by `overlap` (what run may change);
 *   read  [rlo, rhi): write box grown by `halo` (what run may read).
 * Same-colored regions are at least one full region apart along some axis,
 * so none reads what another writes when size >= 2 * overlap + halo on every
 * axis with 3 or more regions; that is checked (GS_ERR_ARG naming the axis).
 * *boxes is gs_malloc'ed (free with gs_free), *count = nx * ny * nz. On error
 * the outputs are unchanged. */
typedef struct gs_region_box {
    int64_t id;
    int color;
    int64_t lo[3], hi[3];
    int64_t wlo[3], whi[3];
    int64_t rlo[3], rhi[3];
} gs_region_box;

gs_err gs_regions_grid(const int64_t dims[3], const int64_t size[3], int64_t overlap,
                       int64_t halo, gs_region_box **boxes, int64_t *count);

/* Checks that no two regions of one color conflict (write box of one meets
 * read box of the other); GS_ERR_ARG naming the first pair otherwise.
 * O(count^2): meant for tests and debug runs. */
gs_err gs_regions_check_separated(const gs_region_box *boxes, int64_t count);

#endif
