/* Distributed search on a toy problem: nearest of N integer-valued vectors
 * (so exact distance ties are common) for Q queries, compared on every rank
 * with a serial brute-force loop; once with a count-balanced and once with
 * a weight-balanced partition, plus the gather variant (all hits within
 * (1 + eps) of the best).
 * np: 1 2 3 4
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/psearch.h"
#include "geosynth/rng.h"

enum { N = 24000, D = 8, Q = 200, LEVELS = 6 };
static const double EPS = 0.5;

typedef struct toy {
    const unsigned char *cand; /* N x D */
    const unsigned char *query; /* D */
    int64_t pruned;
} toy;

#define TOY_CHECK(cond, ...)                                                        \
    do {                                                                            \
        if (!(cond)) {                                                              \
            fprintf(stderr, "[rank %d] psearch_toy: check failed: %s: ", gs_par_rank(), #cond); \
            fprintf(stderr, __VA_ARGS__);                                           \
            fprintf(stderr, "\n");                                                  \
            MPI_Abort(MPI_COMM_WORLD, 1);                                           \
        }                                                                           \
    } while (0)

static double full_distance(const unsigned char *a, const unsigned char *b)
{
    int s = 0;
    for (int k = 0; k < D; k++) {
        int d = (int)a[k] - (int)b[k];
        s += d * d;
    }
    return (double)s;
}

/* Candidate search with early termination: the partial sum over the first
 * dimensions is a lower bound of the full distance, so a candidate is
 * dropped as soon as it exceeds the bound (strictly, per the contract). */
static gs_err search_share(void *user, gs_psearch_t ps, int64_t lo, int64_t hi)
{
    toy *t = user;
    for (int64_t i = lo; i < hi; i++) {
        double bound = gs_psearch_bound(ps);
        const unsigned char *c = t->cand + i * D;
        int s = 0, k = 0;
        for (; k < D; k++) {
            int d = (int)c[k] - (int)t->query[k];
            s += d * d;
            if ((double)s > bound)
                break;
        }
        if (k < D) {
            t->pruned++;
            continue;
        }
        gs_psearch_offer(ps, (double)s, i);
    }
    return GS_OK;
}

static gs_err run(void)
{
    int rank = gs_par_rank(), size = gs_par_size();
    unsigned char *cand = malloc((size_t)N * D);
    double *weights = malloc(N * sizeof *weights);
    gs_psearch_hit *brute_hits = malloc(N * sizeof *brute_hits);
    TOY_CHECK(cand && weights && brute_hits, "out of memory");
    gs_rng rng;
    gs_rng_init(&rng, 2024, gs_rng_stream_id(1, 0, 0, 0));
    for (int64_t i = 0; i < (int64_t)N * D; i++)
        cand[i] = (unsigned char)gs_rng_below(&rng, LEVELS);
    for (int64_t i = 0; i < N; i++) {
        double u = gs_rng_uniform(&rng);
        weights[i] = 1.0 + 50.0 * u * u * u; /* skewed, like subtree sizes */
    }

    gs_psearch_t by_count = NULL, by_weight = NULL;
    GS_CALL(gs_psearch_create(MPI_COMM_WORLD, N, NULL, &by_count));
    GS_CALL(gs_psearch_create(MPI_COMM_WORLD, N, weights, &by_weight));
    gs_psearch_set_poll_interval(by_weight, 7);

    gs_digest dbest, dwithin;
    TOY_CHECK(gs_digest_init(&dbest) && gs_digest_init(&dwithin), "digest init");
    int64_t within_total = 0, ties_total = 0;
    double t_search = 0, t_brute = 0;
    gs_rng qrng;
    gs_rng_init(&qrng, 2024, gs_rng_stream_id(2, 0, 0, 0));
    toy t = {cand, NULL, 0};
    for (int q = 0; q < Q; q++) {
        unsigned char query[D] = {0};
        if (rank == 0)
            for (int k = 0; k < D; k++)
                query[k] = (unsigned char)gs_rng_below(&qrng, LEVELS);
        gs_psearch_t ps = q % 2 ? by_weight : by_count;
        GS_CALL(gs_psearch_bcast(ps, query, D));
        t.query = query;

        double t0 = MPI_Wtime();
        gs_psearch_hit best;
        GS_CALL(gs_psearch_best(ps, search_share, &t, &best));
        gs_psearch_hit *hits = NULL;
        int64_t nhits = 0;
        GS_CALL(gs_psearch_within(ps, EPS, search_share, &t, &hits, &nhits));
        double t1 = MPI_Wtime();

        /* Serial reference, on every rank. */
        gs_psearch_hit ref = {INFINITY, -1};
        int64_t nties = 0;
        for (int64_t i = 0; i < N; i++) {
            double d = full_distance(cand + i * D, query);
            if (d < ref.dist) {
                ref = (gs_psearch_hit){d, i};
                nties = 1;
            } else if (d == ref.dist) {
                nties++;
            }
        }
        int64_t nref = 0;
        double thr = ref.dist * (1.0 + EPS);
        for (int64_t i = 0; i < N; i++) {
            double d = full_distance(cand + i * D, query);
            if (d <= thr)
                brute_hits[nref++] = (gs_psearch_hit){d, i};
        }
        /* Sort the reference by (dist, index): insertion into distance
         * buckets, since distances are small integers. */
        int64_t w = 0;
        for (int dist = 0; dist <= (int)thr; dist++)
            for (int64_t j = 0; j < nref; j++)
                if (brute_hits[j].dist == (double)dist)
                    brute_hits[nref + w++] = brute_hits[j];
        t_brute += MPI_Wtime() - t1;
        t_search += t1 - t0;
        ties_total += nties - 1;

        TOY_CHECK(best.index == ref.index && best.dist == ref.dist,
                  "query %d: distributed best (%lld, %g) != serial (%lld, %g)", q,
                  (long long)best.index, best.dist, (long long)ref.index, ref.dist);
        TOY_CHECK(nhits == nref, "query %d: %lld hits within, serial has %lld", q,
                  (long long)nhits, (long long)nref);
        for (int64_t j = 0; j < nhits; j++)
            TOY_CHECK(hits[j].index == brute_hits[nref + j].index &&
                          hits[j].dist == brute_hits[nref + j].dist,
                      "query %d hit %lld: (%lld, %g) != serial (%lld, %g)", q, (long long)j,
                      (long long)hits[j].index, hits[j].dist,
                      (long long)brute_hits[nref + j].index, brute_hits[nref + j].dist);
        TOY_CHECK(nhits == 0 || (hits[0].index == best.index), "query %d: first hit is not the best", q);
        gs_digest_update(&dbest, &best, sizeof best);
        gs_digest_update(&dwithin, &nhits, sizeof nhits);
        gs_digest_update(&dwithin, hits, (size_t)nhits * sizeof *hits);
        within_total += nhits;
        gs_free(hits);
    }

    /* Every bound message sent was received (the drain works), and with
     * more than one rank bounds were actually exchanged. */
    gs_psearch_stats s1 = gs_psearch_get_stats(by_count), s2 = gs_psearch_get_stats(by_weight);
    int64_t mine[4] = {(s1.bcasts + s2.bcasts) * (size - 1), s1.msgs_received + s2.msgs_received,
                       s1.offers + s2.offers, t.pruned};
    int64_t sum[4];
    GS_MPI(MPI_Allreduce(mine, sum, 4, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD));
    TOY_CHECK(sum[0] == sum[1], "%lld bound messages sent but %lld received",
              (long long)sum[0], (long long)sum[1]);
    TOY_CHECK(size == 1 || sum[0] > 0, "no bound was exchanged between %d ranks", size);
    TOY_CHECK(sum[3] > 0, "nothing was pruned");
    TOY_CHECK(ties_total > 0, "the toy has no exact ties: it does not test the tie rule");

    uint64_t hb = gs_digest_final(&dbest), hw = gs_digest_final(&dwithin);
    GS_CALL(gs_par_check_same_i64(MPI_COMM_WORLD, (int64_t)hb, "psearch best digest"));
    GS_CALL(gs_par_check_same_i64(MPI_COMM_WORLD, (int64_t)hw, "psearch within digest"));
    if (rank == 0) {
        char hex[17];
        fprintf(stderr, "psearch_toy np=%d: N=%d Q=%d, %lld tied candidates, %lld hits within "
                "%.2f, offers %lld pruned %lld, bound messages %lld; search %.3f s, brute %.3f s\n",
                size, N, Q, (long long)ties_total, (long long)within_total, EPS,
                (long long)sum[2], (long long)sum[3], (long long)sum[0], t_search, t_brute);
        gs_digest_hex(hb, hex);
        printf("digest: psearch_best %s\n", hex);
        gs_digest_hex(hw, hex);
        printf("digest: psearch_within %s\n", hex);
    }
    gs_psearch_destroy(&by_count);
    gs_psearch_destroy(&by_weight);
    TOY_CHECK(by_count == NULL, "destroy must NULL the handle");
    free(cand);
    free(weights);
    free(brute_hits);
    return GS_OK;
}

int main(int argc, char **argv)
{
    gs_err err = gs_par_init(&argc, &argv);
    if (err)
        gs_fatal(err, 0);
    err = run();
    if (err)
        gs_fatal(err, 0);
    gs_par_finalize();
    return 0;
}
