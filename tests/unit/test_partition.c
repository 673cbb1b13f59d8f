/* Unit tests for src/par/partition.c: count- and weight-balanced contiguous
 * partitions, edge cases (n < nranks, n == 0, zero weights), bad input. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/error.h"
#include "geosynth/partition.h"
#include "geosynth/rng.h"

/* Ranges of all ranks must tile [0, n) in rank order. */
static void check_tiling(int64_t n, int nranks, const int64_t *lo, const int64_t *hi)
{
    assert_int_equal(lo[0], 0);
    for (int r = 0; r < nranks; r++) {
        assert_true(lo[r] <= hi[r]);
        if (r > 0)
            assert_int_equal(lo[r], hi[r - 1]);
    }
    assert_int_equal(hi[nranks - 1], n);
}

static void test_balanced(void **state)
{
    (void)state;
    const int64_t ns[] = {0, 1, 2, 3, 7, 10, 100, 1001, 20000};
    for (size_t a = 0; a < sizeof ns / sizeof ns[0]; a++) {
        for (int nranks = 1; nranks <= 9; nranks++) {
            int64_t lo[9], hi[9];
            for (int r = 0; r < nranks; r++)
                assert_int_equal(gs_partition(ns[a], nranks, r, &lo[r], &hi[r]), GS_OK);
            check_tiling(ns[a], nranks, lo, hi);
            int64_t smin = INT64_MAX, smax = 0;
            for (int r = 0; r < nranks; r++) {
                int64_t s = hi[r] - lo[r];
                smin = s < smin ? s : smin;
                smax = s > smax ? s : smax;
                /* Larger shares come first. */
                if (r > 0)
                    assert_true(hi[r] - lo[r] <= hi[r - 1] - lo[r - 1]);
            }
            assert_true(smax - smin <= 1);
        }
    }
    /* n < nranks: the first n ranks get one each, the rest are empty. */
    int64_t lo, hi;
    assert_int_equal(gs_partition(2, 4, 1, &lo, &hi), GS_OK);
    assert_int_equal(lo, 1);
    assert_int_equal(hi, 2);
    assert_int_equal(gs_partition(2, 4, 3, &lo, &hi), GS_OK);
    assert_int_equal(lo, 2);
    assert_int_equal(hi, 2);
    assert_int_equal(gs_partition(0, 3, 2, &lo, &hi), GS_OK);
    assert_int_equal(lo, 0);
    assert_int_equal(hi, 0);
}

static void weighted_all(int64_t n, const double *w, int nranks, int64_t *lo, int64_t *hi)
{
    int64_t bounds[17];
    assert_int_equal(gs_partition_weighted_bounds(n, w, nranks, bounds), GS_OK);
    for (int r = 0; r < nranks; r++) {
        assert_int_equal(gs_partition_weighted(n, w, nranks, r, &lo[r], &hi[r]), GS_OK);
        /* The per-rank and the all-bounds functions agree. */
        assert_int_equal(lo[r], bounds[r]);
        assert_int_equal(hi[r], bounds[r + 1]);
    }
}

static void test_weighted_random(void **state)
{
    (void)state;
    enum { N = 5000 };
    static double w[N];
    for (int trial = 0; trial < 20; trial++) {
        gs_rng rng;
        gs_rng_init(&rng, 7, (uint64_t)trial);
        double wmax = 0, total = 0;
        for (int i = 0; i < N; i++) {
            /* Skewed weights, like subtree sizes: mostly small, some large. */
            double u = gs_rng_uniform(&rng);
            w[i] = trial % 3 == 0 ? 1.0 : floor(1.0 + 100.0 * u * u * u);
            wmax = w[i] > wmax ? w[i] : wmax;
            total += w[i];
        }
        int nranks = 1 + trial % 16;
        int64_t lo[16], hi[16];
        weighted_all(N, w, nranks, lo, hi);
        check_tiling(N, nranks, lo, hi);
        for (int r = 0; r < nranks; r++) {
            double s = 0;
            for (int64_t i = lo[r]; i < hi[r]; i++)
                s += w[i];
            /* Each bound is within half a weight of its target, so a share
             * is within one maximum weight of the ideal. */
            assert_true(fabs(s - total / nranks) <= wmax + 1e-9 * total);
        }
        if (trial % 3 == 0) {
            /* Unit weights: the same balance as by count (sizes within 1). */
            for (int r = 0; r < nranks; r++)
                assert_true(llabs((long long)(hi[r] - lo[r]) - N / nranks) <= 1);
        }
    }
}

static void test_weighted_edges(void **state)
{
    (void)state;
    int64_t lo[8], hi[8];
    /* n == 0: every range empty. */
    weighted_all(0, NULL, 4, lo, hi);
    for (int r = 0; r < 4; r++) {
        assert_int_equal(lo[r], 0);
        assert_int_equal(hi[r], 0);
    }
    /* n < nranks. */
    const double three[] = {1, 1, 1};
    weighted_all(3, three, 5, lo, hi);
    check_tiling(3, 5, lo, hi);
    for (int r = 0; r < 5; r++)
        assert_true(hi[r] - lo[r] <= 1);
    /* One dominant candidate: it gets a rank to itself, others share the rest. */
    const double heavy[] = {1, 1, 100, 1, 1, 1};
    weighted_all(6, heavy, 2, lo, hi);
    check_tiling(6, 2, lo, hi);
    assert_true(lo[1] == 2 || lo[1] == 3); /* the split is next to the heavy one */
    /* All zero weights fall back to the count partition. */
    const double zeros[] = {0, 0, 0, 0, 0, 0, 0};
    weighted_all(7, zeros, 3, lo, hi);
    for (int r = 0; r < 3; r++) {
        int64_t blo, bhi;
        assert_int_equal(gs_partition(7, 3, r, &blo, &bhi), GS_OK);
        assert_int_equal(lo[r], blo);
        assert_int_equal(hi[r], bhi);
    }
    /* Zero-weight runs are assigned, never lost. */
    const double gaps[] = {0, 0, 5, 0, 0, 5, 0, 0};
    weighted_all(8, gaps, 2, lo, hi);
    check_tiling(8, 2, lo, hi);
    double s0 = 0;
    for (int64_t i = lo[0]; i < hi[0]; i++)
        s0 += gaps[i];
    assert_true(s0 == 5.0);
}

static void test_bad_input(void **state)
{
    (void)state;
    int64_t lo = -7, hi = -7;
    assert_int_equal(gs_partition(-1, 2, 0, &lo, &hi), GS_ERR_ARG);
    assert_int_equal(gs_partition(5, 0, 0, &lo, &hi), GS_ERR_ARG);
    assert_int_equal(gs_partition(5, 2, 2, &lo, &hi), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "rank 2 outside [0, 2)"));
    assert_int_equal(lo, -7); /* outputs unchanged on error */
    const double neg[] = {1, -2, 3};
    assert_int_equal(gs_partition_weighted(3, neg, 2, 0, &lo, &hi), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "candidate 1"));
    const double bad[] = {1, NAN, 3};
    assert_int_equal(gs_partition_weighted(3, bad, 2, 0, &lo, &hi), GS_ERR_ARG);
    const double inf[] = {1, INFINITY};
    assert_int_equal(gs_partition_weighted(2, inf, 2, 1, &lo, &hi), GS_ERR_ARG);
    const double big[] = {1e308, 1e308};
    assert_int_equal(gs_partition_weighted(2, big, 2, 1, &lo, &hi), GS_ERR_ARG);
    assert_int_equal(gs_partition_weighted(2, NULL, 2, 1, &lo, &hi), GS_ERR_ARG);
    assert_int_equal(lo, -7);
    int64_t bounds[3] = {-7, -7, -7};
    assert_int_equal(gs_partition_weighted_bounds(3, neg, 2, bounds), GS_ERR_ARG);
    assert_int_equal(bounds[0], -7);
    gs_error_clear();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_balanced),
        cmocka_unit_test(test_weighted_random),
        cmocka_unit_test(test_weighted_edges),
        cmocka_unit_test(test_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
