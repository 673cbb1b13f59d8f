/* Distributed exact search: the smallest distance over candidates 0..n-1
 * partitioned across ranks, with the bound shared while searching so pruning
 * works globally, and an answer bit-identical to a serial search.
 *
 * Model. gs_psearch_create() splits the candidates into one contiguous share
 * per rank (by count, or by per-candidate weights such as subtree sizes; see
 * partition.h) and dups the communicator, so search traffic never mixes with
 * the caller's messages. For each query every rank calls gs_psearch_best()
 * (or gs_psearch_within()), which calls the search callback once with the
 * rank's share [lo, hi). The query itself is either known on every rank or
 * broadcast from rank 0 first with gs_psearch_bcast().
 *
 * Callback contract (what makes the answer exact):
 *  - For every candidate i it does not prune, compute the exact distance d
 *    (finite, >= 0, computed the same way as the serial search) and call
 *    gs_psearch_offer(ps, d, i). Offer each candidate at most once.
 *  - It may prune a candidate (or a subtree of them) only when a true lower
 *    bound lb of their distances satisfies   lb > gs_psearch_bound(ps)
 *    STRICTLY. Equality must not prune: an equal distance with a lower index
 *    wins the tie. gs_psearch_bound() never falls below the final answer's
 *    pruning threshold, so no candidate of the answer is ever pruned.
 *  - gs_psearch_bound() is cheap (a load and a counter); every poll_every-th
 *    call it also polls the network: one MPI_Iprobe for improved bounds
 *    from other ranks, and sends this rank's own improvement (if any) to all
 *    others with MPI_Isend. No collective happens inside the callback, so
 *    ranks may search at any speed. Call it once per candidate or subtree.
 *  - It must not call other collective operations on ps's communicator.
 * The result is reduced with a total order: smallest distance, ties broken
 * by the lowest candidate index. Whatever the timing of bound messages (and
 * whatever the rank count or weights), the answer equals the serial loop
 *     best = (inf, -1); for i: if (d(i) < best.dist) best = (d(i), i);
 *
 * Errors. A callback that returns an error (or offers an index outside its
 * share, or a NaN/negative distance) does not hang the others: the failure
 * is made collective at the end of the query (gs_par_agree), so every rank
 * returns the same error code, the failing rank with its own record and the
 * others with "rank N failed: ...". The caller can then gs_fatal(err, 1).
 * A callback that cannot return (it must stop this rank now) calls
 * gs_fatal(err, 0), which aborts every rank. An MPI failure inside the
 * library is returned on the rank that saw it only; treat it as local
 * (gs_fatal(err, 0)).
 *
 * Cost of one query on P ranks:
 *  - gs_psearch_best: 1 MPI_Allgather of 32 bytes per rank (best hit, number
 *    of bound messages sent, status), which also tells each rank how many
 *    bound messages to drain, so nothing is left pending on the
 *    communicator. Point to point: each time a rank's local best improves
 *    the global bound it sends P-1 messages of 8 bytes, at most once per
 *    poll interval; a running minimum improves O(log share) times, so a
 *    query typically costs a few times P*(P-1) tiny messages.
 *  - gs_psearch_within: the same plus 1 MPI_Allgather of 8 bytes per rank
 *    (hit counts), 1 MPI_Allreduce of 2 ints (agreement that every rank
 *    could allocate the result) and 1 MPI_Allgatherv of 16 bytes per hit.
 *  - gs_psearch_bcast: 1 MPI_Bcast of the query.
 * With P == 1 no messages are sent and the collectives are trivial.
 *
 * Memory: O(P) per handle, plus the hits within the threshold for
 * gs_psearch_within (pruned by the running threshold while searching).
 */
#ifndef GEOSYNTH_PSEARCH_H
#define GEOSYNTH_PSEARCH_H

#include <mpi.h>
#include <stdint.h>

#include "geosynth/error.h"

typedef struct gs_psearch *gs_psearch_t;

/* One search result; index == -1 (dist == +inf) when there was none. */
typedef struct gs_psearch_hit {
    double dist;
    int64_t index;
} gs_psearch_hit;

/* Searches candidates [lo, hi) following the contract above. user is the
 * pointer given to gs_psearch_best/within. */
typedef gs_err (*gs_psearch_fn)(void *user, gs_psearch_t ps, int64_t lo, int64_t hi);

/* Collective on comm: every rank passes the same ncand and weights (NULL =
 * balance by count). Dups comm. Destroy with gs_psearch_destroy(). On error
 * *out is unchanged. */
gs_err gs_psearch_create(MPI_Comm comm, int64_t ncand, const double *weights,
                         gs_psearch_t *out);
/* Collective (frees the dup'ed communicator). Sets *ps to NULL; NULL is ok. */
void gs_psearch_destroy(gs_psearch_t *ps);

/* This rank's share [lo, hi) of the candidates. */
void gs_psearch_share(const gs_psearch_t ps, int64_t *lo, int64_t *hi);

/* Collective: broadcasts bytes of buf from rank 0 (the query). */
gs_err gs_psearch_bcast(gs_psearch_t ps, void *buf, int64_t bytes);

/* Collective: runs fn on every rank's share and returns the best hit in the
 * total order (distance, index) on every rank. */
gs_err gs_psearch_best(gs_psearch_t ps, gs_psearch_fn fn, void *user, gs_psearch_hit *best);

/* Collective: every candidate whose distance is <= (1 + eps) * (the global
 * best distance), sorted by (distance, index), on every rank. eps >= 0. In
 * this mode gs_psearch_bound() returns (1 + eps) * best so far, so the same
 * strict pruning rule applies. *hits is gs_malloc'ed (free with gs_free),
 * *count its length (0 and NULL when nothing was found). On error the
 * outputs are unchanged. */
gs_err gs_psearch_within(gs_psearch_t ps, double eps, gs_psearch_fn fn, void *user,
                         gs_psearch_hit **hits, int64_t *count);

/* Inside the callback: the current pruning threshold (+inf at the start).
 * Prune only when lower bound > this value. */
double gs_psearch_bound(gs_psearch_t ps);

/* Inside the callback: reports the exact distance of candidate index. */
void gs_psearch_offer(gs_psearch_t ps, double dist, int64_t index);

/* Network poll every `every` calls of gs_psearch_bound (default 64, >= 1).
 * Must be the same on every rank only for reproducible message counts; the
 * answer does not depend on it. */
void gs_psearch_set_poll_interval(gs_psearch_t ps, int every);

/* Counters of this rank since create (for metrics and tests). */
typedef struct gs_psearch_stats {
    int64_t queries;
    int64_t offers;        /* candidates offered (not pruned) */
    int64_t polls;         /* MPI_Iprobe rounds */
    int64_t bcasts;        /* bound improvements sent (each to P-1 ranks) */
    int64_t msgs_received; /* bound messages received */
} gs_psearch_stats;
gs_psearch_stats gs_psearch_get_stats(const gs_psearch_t ps);

#endif
