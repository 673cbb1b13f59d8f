/* Failure injection for tests/e2e/mpi_errors.sh: one rank fails in the
 * middle of a region or a search while the others already sit in the
 * collective that ends it. Usage: abort_on_error [MODE]
 *   none               no failure (what tests/run.sh runs; must exit 0)
 *   search-abort       rank F calls gs_fatal(err, 0) inside the search callback
 *   region-abort       rank F calls gs_fatal(err, 0) inside a region callback
 *   search-collective  rank F's search callback returns GS_ERR_FORMAT
 *   region-collective  rank F's region callback returns GS_ERR_FORMAT
 *   agree              rank F reports GS_ERR_ARG to gs_par_agree
 * F = 2 with 3 or more ranks, else the last rank. The failing rank first
 * sleeps a little so the others are inside the collective when it fails.
 * Expected: the abort modes end every rank with a "[rank F]" message; the
 * collective modes exit with the error code and rank 0 prints the message
 * once.
 * np: 2 4
 */
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "geosynth/par.h"
#include "geosynth/psearch.h"
#include "geosynth/regions.h"

typedef struct injector {
    const char *mode;
    int fail_rank;
    int64_t seen;
    double sink;
} injector;

static int is(const injector *in, const char *mode) { return strcmp(in->mode, mode) == 0; }

static void nap(void)
{
    struct timespec ts = {0, 300 * 1000 * 1000};
    nanosleep(&ts, NULL);
}

/* Called on the failing rank in the middle of its work. */
static gs_err inject(injector *in, const char *where, int64_t item)
{
    nap();
    gs_err err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                                "abort_on_error: injected failure in %s %lld on rank %d",
                                where, (long long)item, gs_par_rank());
    if (strstr(in->mode, "-abort"))
        gs_fatal(err, 0);
    return err;
}

static gs_err search_fn(void *user, gs_psearch_t ps, int64_t lo, int64_t hi)
{
    injector *in = user;
    for (int64_t i = lo; i < hi; i++) {
        if (gs_par_rank() == in->fail_rank && i == (lo + hi) / 2 && strstr(in->mode, "search"))
            GS_CALL(inject(in, "search candidate", i));
        double d = (double)((i * 7919) % 1000);
        if (d > gs_psearch_bound(ps))
            continue;
        gs_psearch_offer(ps, d, i);
    }
    return GS_OK;
}

static gs_err region_run(void *ctx, int64_t id, int color, int pass, gs_rng *rng, gs_region_out *out)
{
    injector *in = ctx;
    if (gs_par_rank() == in->fail_rank && in->seen++ == 1 && strstr(in->mode, "region"))
        GS_CALL(inject(in, "region", id));
    double v = gs_rng_uniform(rng);
    GS_CALL(gs_region_out_append(out, &v, sizeof v));
    return GS_OK;
}

static gs_err region_apply(void *ctx, int64_t id, const void *buf, size_t len)
{
    injector *in = ctx;
    double v;
    GS_CHECK(len == sizeof v, GS_ERR_INTERNAL, "region %lld: %zu bytes", (long long)id, len);
    memcpy(&v, buf, sizeof v);
    in->sink += v;
    return GS_OK;
}

/* Returns the failure (collective modes) to main. */
static gs_err run(injector *in)
{
    int size = gs_par_size();
    in->fail_rank = size >= 3 ? 2 : size - 1;
    if (is(in, "agree")) {
        gs_err local = GS_OK;
        if (gs_par_rank() == in->fail_rank) {
            nap();
            local = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                   "abort_on_error: injected failure in agree on rank %d",
                                   gs_par_rank());
        }
        GS_CALL(gs_par_agree(MPI_COMM_WORLD, local));
        return GS_OK;
    }
    gs_psearch_t ps = NULL;
    GS_CALL(gs_psearch_create(MPI_COMM_WORLD, 100000, NULL, &ps));
    gs_psearch_hit best;
    gs_err err = gs_psearch_best(ps, search_fn, in, &best);
    gs_psearch_destroy(&ps);
    GS_CALL(err);
    /* One color of 40 regions: every worker gets prefetched work. */
    gs_region list[40];
    for (int i = 0; i < 40; i++)
        list[i] = (gs_region){i, 0};
    gs_regions_t rs = NULL;
    GS_CALL(gs_regions_create(MPI_COMM_WORLD, list, 40, 5, 1, &rs));
    err = gs_regions_run_pass(rs, 0, region_run, region_apply, in);
    gs_regions_destroy(&rs);
    GS_CALL(err);
    if (gs_par_rank() == 0)
        printf("abort_on_error %s: best %lld at %g, region sum %.6f\n", in->mode,
               (long long)best.index, best.dist, in->sink);
    return GS_OK;
}

int main(int argc, char **argv)
{
    gs_err err = gs_par_init(&argc, &argv);
    if (err)
        gs_fatal(err, 0);
    injector in = {argc > 1 ? argv[1] : "none", 0, 0, 0.0};
    const char *modes[] = {"none", "search-abort", "region-abort", "search-collective",
                           "region-collective", "agree"};
    int known = 0;
    for (size_t i = 0; i < sizeof modes / sizeof modes[0]; i++)
        known |= is(&in, modes[i]);
    if (!known) {
        gs_error_raise(GS_ERR_USAGE, __FILE__, __LINE__, __func__,
                       "abort_on_error: unknown mode '%s'", in.mode);
        gs_fatal(GS_ERR_USAGE, 1);
    }
    err = run(&in);
    if (err)
        gs_fatal(err, 1); /* every rank got the same code from the collective */
    gs_par_finalize();
    return 0;
}
