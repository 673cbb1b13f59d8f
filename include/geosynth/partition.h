/* Contiguous partitions of candidates 0..n-1 over ranks.
 *
 * Rank r owns the half-open range [lo, hi); ranges are contiguous, in rank
 * order, cover 0..n-1 exactly once and may be empty (n < nranks, n == 0).
 * Both functions are pure (no MPI): every rank computes every range itself,
 * so they agree without communication as long as the inputs agree.
 *
 * gs_partition: balanced by count. The first n % nranks ranks get one extra
 * candidate, so sizes differ by at most 1. O(1).
 *
 * gs_partition_weighted: balanced by per-candidate weights (subtree sizes,
 * patch point counts, cost estimates), keeping each range contiguous. Bound
 * k (1 <= k < nranks) is the index i whose prefix weight W(i) = w[0] + ... +
 * w[i-1] is closest to k * W(n) / nranks (ties to the lower i); bounds are
 * non-decreasing, so a range is empty when one candidate outweighs a whole
 * share. Prefix sums are accumulated in index order in double precision, the
 * same on every rank. A total weight of 0 falls back to gs_partition.
 * O(n) time, no allocation. gs_partition_weighted_bounds writes all
 * nranks + 1 bounds at once (bounds[0] = 0, bounds[nranks] = n).
 *
 * Errors (GS_ERR_ARG): n < 0, nranks < 1, rank outside [0, nranks), weights
 * NULL with n > 0, a weight negative or not finite, a non-finite total. On
 * error the outputs are unchanged.
 */
#ifndef GEOSYNTH_PARTITION_H
#define GEOSYNTH_PARTITION_H

#include <stdint.h>

#include "geosynth/error.h"

gs_err gs_partition(int64_t n, int nranks, int rank, int64_t *lo, int64_t *hi);

gs_err gs_partition_weighted(int64_t n, const double *weights, int nranks, int rank,
                             int64_t *lo, int64_t *hi);

/* bounds has nranks + 1 entries; rank r owns [bounds[r], bounds[r+1]). */
gs_err gs_partition_weighted_bounds(int64_t n, const double *weights, int nranks,
                                    int64_t *bounds);

#endif
