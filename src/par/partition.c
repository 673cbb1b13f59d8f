/* Contiguous count- and weight-balanced partitions; see partition.h. */
#include "geosynth/partition.h"

#include <math.h>

gs_err gs_partition(int64_t n, int nranks, int rank, int64_t *lo, int64_t *hi)
{
    GS_CHECK(n >= 0, GS_ERR_ARG, "partition: candidate count %lld must be >= 0", (long long)n);
    GS_CHECK(nranks >= 1, GS_ERR_ARG, "partition: rank count %d must be >= 1", nranks);
    GS_CHECK(rank >= 0 && rank < nranks, GS_ERR_ARG,
             "partition: rank %d outside [0, %d)", rank, nranks);
    int64_t base = n / nranks, extra = n % nranks;
    int64_t r = rank;
    *lo = r * base + (r < extra ? r : extra);
    *hi = *lo + base + (r < extra ? 1 : 0);
    return GS_OK;
}

static gs_err check_weights(int64_t n, const double *weights, int nranks, double *total)
{
    GS_CHECK(n >= 0, GS_ERR_ARG, "partition: candidate count %lld must be >= 0", (long long)n);
    GS_CHECK(nranks >= 1, GS_ERR_ARG, "partition: rank count %d must be >= 1", nranks);
    GS_CHECK(weights != NULL || n == 0, GS_ERR_ARG,
             "partition: weights missing for %lld candidates", (long long)n);
    double sum = 0.0;
    for (int64_t i = 0; i < n; i++) {
        GS_CHECK(isfinite(weights[i]) && weights[i] >= 0.0, GS_ERR_ARG,
                 "partition: weight of candidate %lld is %g: expected a finite value >= 0",
                 (long long)i, weights[i]);
        sum += weights[i];
    }
    GS_CHECK(isfinite(sum), GS_ERR_ARG, "partition: total weight overflows (%g)", sum);
    *total = sum;
    return GS_OK;
}

/* Advances (*i, *prefix) to bound k: the index whose prefix weight is
 * closest to k * total / nranks, ties to the lower index. Targets increase
 * with k and prefixes never decrease, so calling this for k = 1, 2, ... walks
 * the weights once. A run of zero weights before the target is taken (it
 * does not change the distance); one after the target is left to the next
 * rank. */
static void advance_to_bound(int64_t n, const double *w, double total, int nranks, int k,
                             int64_t *i, double *prefix)
{
    if (k >= nranks) {
        *i = n;
        return;
    }
    double target = total * ((double)k / (double)nranks);
    while (*i < n) {
        double next = *prefix + w[*i];
        int closer = fabs(next - target) < fabs(*prefix - target);
        int zero_run_before_target = next == *prefix && *prefix < target;
        if (!closer && !zero_run_before_target)
            break;
        *prefix = next;
        (*i)++;
    }
}

gs_err gs_partition_weighted_bounds(int64_t n, const double *weights, int nranks,
                                    int64_t *bounds)
{
    double total = 0.0;
    GS_CALL(check_weights(n, weights, nranks, &total));
    bounds[0] = 0;
    if (total == 0.0) {
        for (int r = 1; r < nranks; r++) {
            int64_t lo, hi;
            GS_CALL(gs_partition(n, nranks, r, &lo, &hi));
            bounds[r] = lo;
        }
    } else {
        int64_t i = 0;
        double prefix = 0.0;
        for (int k = 1; k < nranks; k++) {
            advance_to_bound(n, weights, total, nranks, k, &i, &prefix);
            bounds[k] = i;
        }
    }
    bounds[nranks] = n;
    return GS_OK;
}

gs_err gs_partition_weighted(int64_t n, const double *weights, int nranks, int rank,
                             int64_t *lo, int64_t *hi)
{
    GS_CHECK(nranks >= 1, GS_ERR_ARG, "partition: rank count %d must be >= 1", nranks);
    GS_CHECK(rank >= 0 && rank < nranks, GS_ERR_ARG,
             "partition: rank %d outside [0, %d)", rank, nranks);
    double total = 0.0;
    GS_CALL(check_weights(n, weights, nranks, &total));
    if (total == 0.0)
        return gs_partition(n, nranks, rank, lo, hi);
    int64_t i = 0, start = 0;
    double prefix = 0.0;
    for (int k = 1; k <= rank + 1; k++) {
        advance_to_bound(n, weights, total, nranks, k, &i, &prefix);
        if (k == rank)
            start = i;
    }
    *lo = start;
    *hi = i;
    return GS_OK;
}
