/* The parallel map: n items of `bytes` bytes each, item i computed by one
 * rank and then known to every rank (points uses it to generate examples and
 * to extract neighbourhoods, include/geosynth/points.h gs_points_map_fn).
 *
 * Each rank computes a contiguous share of the items. Shares start equal and
 * follow each rank's measured speed (items per second of its last maps): on
 * a shared machine a rank whose core also runs another job is slower, and an
 * equal split would make every map wait for it. Who computes an item never
 * changes its value, and every rank updates the shares from the same gathered
 * numbers with the same arithmetic, so the split is the same everywhere and
 * the result does not depend on it. Above GS_PMAP_MAX_RANKS_ADAPTIVE ranks
 * the split stays equal (gs_partition).
 *
 * Up to GS_PMAP_ONE_EXCHANGE_BYTES of items travel in one collective that
 * also carries each rank's status and compute time (each exchange waits for
 * the slowest rank, and points maps twice per patch); larger maps agree on
 * the status first and then gather the items in place.
 */
#ifndef GEOSYNTH_PMAP_H
#define GEOSYNTH_PMAP_H

#include <stddef.h>

#include "geosynth/par.h"

#define GS_PMAP_ONE_EXCHANGE_BYTES ((size_t)16 << 20)
#define GS_PMAP_MAX_RANKS_ADAPTIVE 4096

/* Computes items [lo, hi) into out_lo (item lo's bytes). Local. */
typedef gs_err (*gs_pmap_range_fn)(void *ctx, size_t lo, size_t hi, void *out_lo);

/* Optional hooks of the caller (test fault injection, its own agreement);
 * a NULL hook does nothing (agree: gs_par_agree). */
typedef struct gs_pmap_hooks {
    void *user;
    /* This rank's status after computing its share; returns the status to
     * go on with. */
    gs_err (*computed)(void *user, gs_err local);
    /* Before the one-collective exchange allocates its buffers; a failure
     * there is local to this rank (the caller aborts every rank). */
    gs_err (*exchanging)(void *user);
    /* Agreement of a status over the ranks, whenever a map fails. */
    gs_err (*agree)(void *user, MPI_Comm comm, gs_err local);
} gs_pmap_hooks;

typedef struct gs_pmap {
    MPI_Comm comm;
    int rank, size;
    gs_pmap_hooks hooks;
    double share[GS_PMAP_MAX_RANKS_ADAPTIVE]; /* sums to 1; used when size <= the max */
} gs_pmap;

/* Local: equal shares over comm. hooks may be NULL. */
gs_err gs_pmap_init(gs_pmap *m, MPI_Comm comm, const gs_pmap_hooks *hooks);

/* Collective: every rank's out (n * bytes) ends up holding all n items; a
 * failure of fn on any rank is returned on every rank (through the agree
 * hook), except a failure of the exchange's allocations, which is local. */
gs_err gs_pmap_run(gs_pmap *m, size_t n, size_t bytes, gs_pmap_range_fn fn, void *ctx,
                   void *out);

#endif
