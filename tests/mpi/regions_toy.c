/* Colored regions on a toy problem: a 3D grid where each region relaxes its
 * cells towards the mean of their neighbours (reading across the halo into
 * neighbouring regions) plus noise from its random stream, several passes
 * over all colors. The scheduled result must equal a serial in-place sweep
 * (which also proves same-colored regions do not interact) and be identical
 * for every rank count, with the colour-by-colour schedule and with the
 * dataflow one (gs_regions_set_conflicts). np=1 vs np=2 wall times are
 * logged, not asserted.
 * np: 1 2 3 4
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "geosynth/digest.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/regions.h"
#include "geosynth/rng.h"

enum { NX = 40, NY = 36, NZ = 32, RSIZE = 8, HALO = 1, PASSES = 3, ITERS = 600 };
static const uint64_t SEED = 77;
static const uint32_t DOMAIN = 0x7e61;

#define TOY_CHECK(cond, ...)                                                        \
    do {                                                                            \
        if (!(cond)) {                                                              \
            fprintf(stderr, "[rank %d] regions_toy: check failed: %s: ", gs_par_rank(), #cond); \
            fprintf(stderr, __VA_ARGS__);                                           \
            fprintf(stderr, "\n");                                                  \
            MPI_Abort(MPI_COMM_WORLD, 1);                                           \
        }                                                                           \
    } while (0)

typedef struct toy {
    double *grid; /* NX x NY x NZ, x fastest */
    const gs_region_box *boxes;
} toy;

static int64_t cell(int64_t x, int64_t y, int64_t z) { return x + NX * (y + NY * z); }

/* The region computation: a copy of the read box, ITERS Gauss-Seidel sweeps
 * over the core with noise, the core written to dst (x fastest). */
static gs_err compute(const toy *t, int64_t id, gs_rng *rng, double *dst)
{
    const gs_region_box *b = &t->boxes[id];
    int64_t n[3];
    for (int a = 0; a < 3; a++)
        n[a] = b->rhi[a] - b->rlo[a];
    double *l = NULL;
    GS_CALL(gs_alloc_array((void **)&l, (size_t)(n[0] * n[1] * n[2]), sizeof *l, "region copy"));
#define L(x, y, z) l[((x) - b->rlo[0]) + n[0] * (((y) - b->rlo[1]) + n[1] * ((z) - b->rlo[2]))]
    for (int64_t z = b->rlo[2]; z < b->rhi[2]; z++)
        for (int64_t y = b->rlo[1]; y < b->rhi[1]; y++)
            for (int64_t x = b->rlo[0]; x < b->rhi[0]; x++)
                L(x, y, z) = t->grid[cell(x, y, z)];
    for (int it = 0; it < ITERS; it++)
        for (int64_t z = b->lo[2]; z < b->hi[2]; z++)
            for (int64_t y = b->lo[1]; y < b->hi[1]; y++)
                for (int64_t x = b->lo[0]; x < b->hi[0]; x++) {
                    double c = L(x, y, z), s = 0;
                    s += x > b->rlo[0] ? L(x - 1, y, z) : c;
                    s += x + 1 < b->rhi[0] ? L(x + 1, y, z) : c;
                    s += y > b->rlo[1] ? L(x, y - 1, z) : c;
                    s += y + 1 < b->rhi[1] ? L(x, y + 1, z) : c;
                    s += z > b->rlo[2] ? L(x, y, z - 1) : c;
                    s += z + 1 < b->rhi[2] ? L(x, y, z + 1) : c;
                    L(x, y, z) = 0.9 * (s / 6.0) + 0.1 * (gs_rng_uniform(rng) - 0.5);
                }
    int64_t k = 0;
    for (int64_t z = b->lo[2]; z < b->hi[2]; z++)
        for (int64_t y = b->lo[1]; y < b->hi[1]; y++)
            for (int64_t x = b->lo[0]; x < b->hi[0]; x++)
                dst[k++] = L(x, y, z);
#undef L
    gs_free(l);
    return GS_OK;
}

static int64_t core_cells(const gs_region_box *b)
{
    return (b->hi[0] - b->lo[0]) * (b->hi[1] - b->lo[1]) * (b->hi[2] - b->lo[2]);
}

static void write_core(toy *t, int64_t id, const double *src)
{
    const gs_region_box *b = &t->boxes[id];
    int64_t k = 0;
    for (int64_t z = b->lo[2]; z < b->hi[2]; z++)
        for (int64_t y = b->lo[1]; y < b->hi[1]; y++)
            for (int64_t x = b->lo[0]; x < b->hi[0]; x++)
                t->grid[cell(x, y, z)] = src[k++];
}

static gs_err toy_run(void *ctx, int64_t id, int color, int pass, gs_rng *rng, gs_region_out *out)
{
    toy *t = ctx;
    void *dst;
    GS_CALL(gs_region_out_reserve(out, (size_t)core_cells(&t->boxes[id]) * sizeof(double), &dst));
    GS_CALL(compute(t, id, rng, dst));
    return GS_OK;
}

static gs_err toy_apply(void *ctx, int64_t id, const void *buf, size_t len)
{
    toy *t = ctx;
    GS_CHECK(len == (size_t)core_cells(&t->boxes[id]) * sizeof(double), GS_ERR_INTERNAL,
             "region %lld: %zu result bytes", (long long)id, len);
    write_core(t, id, buf);
    return GS_OK;
}

/* Fails on one region: the error must reach every rank. */
static gs_err toy_run_failing(void *ctx, int64_t id, int color, int pass, gs_rng *rng,
                              gs_region_out *out)
{
    GS_CHECK(id != 37, GS_ERR_ARG, "region %lld refuses to run", (long long)id);
    return toy_run(ctx, id, color, pass, rng, out);
}

static void init_grid(double *g)
{
    gs_rng rng;
    gs_rng_init(&rng, SEED, gs_rng_stream_id(DOMAIN + 1, 0, 0, 0));
    for (int64_t i = 0; i < (int64_t)NX * NY * NZ; i++)
        g[i] = gs_rng_uniform(&rng);
}

static gs_err check_grid_helpers(void)
{
    /* Too small for the interaction range: refused, naming the axis. */
    gs_region_box *b = NULL;
    int64_t n = 0;
    const int64_t dims[3] = {NX, NY, NZ}, small[3] = {8, 3, 8};
    TOY_CHECK(gs_regions_grid(dims, small, 1, 2, &b, &n) == GS_ERR_ARG && b == NULL,
              "a grid with size 3 < 2*1+2 along y must be refused");
    TOY_CHECK(strstr(gs_error_message(), "along y") != NULL, "message: %s", gs_error_message());
    gs_error_clear();
    /* With overlap: separated, and breaking one read box is detected. */
    const int64_t size[3] = {6, 6, 6};
    GS_CALL(gs_regions_grid(dims, size, 2, 2, &b, &n));
    GS_CALL(gs_regions_check_separated(b, n));
    b[0].rhi[0] += 3; /* region 0 now reads into region 2's write box */
    TOY_CHECK(gs_regions_check_separated(b, n) == GS_ERR_ARG, "overlap not detected");
    gs_error_clear();
    gs_free(b);
    /* 2D: 2x2 colouring. */
    const int64_t d2[3] = {50, 30, 1}, s2[3] = {10, 10, 1};
    GS_CALL(gs_regions_grid(d2, s2, 0, 3, &b, &n));
    TOY_CHECK(n == 15, "2D grid has %lld regions", (long long)n);
    for (int64_t i = 0; i < n; i++)
        TOY_CHECK(b[i].color >= 0 && b[i].color < 4, "2D color %d", b[i].color);
    GS_CALL(gs_regions_check_separated(b, n));
    gs_free(b);
    return GS_OK;
}

/* PASSES passes of the toy on every rank; wall seconds in *elapsed. With
 * g_stall_ms > 0 the last rank sleeps that long in its first apply of
 * every pass, between regions, when the others see it idle (its last
 * header was a record, not a claim), like a process another job keeps off
 * its core: the others take the regions of its share that it leaves
 * unclaimed. */
static int g_stall_ms;
static int64_t g_stall_every; /* applies per pass */

static gs_err stalling_apply(void *ctx, int64_t id, const void *buf, size_t len)
{
    static int64_t applies;
    if (g_stall_ms > 0 && applies++ % g_stall_every == 0 && gs_par_size() > 1 &&
        gs_par_rank() == gs_par_size() - 1) {
        struct timespec ts = {0, (long)g_stall_ms * 1000000L};
        nanosleep(&ts, NULL);
    }
    return toy_apply(ctx, id, buf, len);
}

static gs_err timed_passes(gs_regions_t sched, toy *t, double *elapsed)
{
    GS_MPI(MPI_Barrier(MPI_COMM_WORLD));
    double t0 = MPI_Wtime();
    for (int pass = 0; pass < PASSES; pass++)
        GS_CALL(gs_regions_run_pass(sched, pass, toy_run, stalling_apply, t));
    GS_MPI(MPI_Barrier(MPI_COMM_WORLD));
    *elapsed = MPI_Wtime() - t0;
    return GS_OK;
}

static gs_err run(void)
{
    int rank = gs_par_rank(), size = gs_par_size();
    GS_CALL(check_grid_helpers());
    const int64_t dims[3] = {NX, NY, NZ}, rsize[3] = {RSIZE, RSIZE, RSIZE};
    gs_region_box *boxes = NULL;
    int64_t nreg = 0;
    GS_CALL(gs_regions_grid(dims, rsize, 0, HALO, &boxes, &nreg));
    GS_CALL(gs_regions_check_separated(boxes, nreg));
    gs_region *list = malloc((size_t)nreg * sizeof *list);
    double *grid = malloc((size_t)NX * NY * NZ * sizeof *grid);
    double *ref = malloc((size_t)NX * NY * NZ * sizeof *ref);
    double *tmp = malloc((size_t)RSIZE * RSIZE * RSIZE * sizeof *tmp);
    TOY_CHECK(list && grid && ref && tmp, "out of memory");
    /* Queue order is the list order; reverse it to show it does not matter. */
    for (int64_t i = 0; i < nreg; i++)
        list[i] = (gs_region){boxes[nreg - 1 - i].id, boxes[nreg - 1 - i].color};

    toy t = {grid, boxes};
    init_grid(grid);
    gs_regions_t sched = NULL;
    GS_CALL(gs_regions_create(MPI_COMM_WORLD, list, nreg, SEED, DOMAIN, &sched));
    double elapsed = 0;
    GS_CALL(timed_passes(sched, &t, &elapsed));
    gs_regions_stats st = gs_regions_get_stats(sched);
    gs_regions_destroy(&sched);

    /* The same passes as one dataflow (gs_regions_set_conflicts): each
     * region lists the lower-coloured regions whose write box meets its read
     * box or the other way round; the result must not change. */
    double *flow_grid = malloc((size_t)NX * NY * NZ * sizeof *flow_grid);
    int64_t *off = malloc((size_t)(nreg + 1) * sizeof *off);
    int64_t *ids = malloc((size_t)nreg * 64 * sizeof *ids);
    TOY_CHECK(flow_grid && off && ids, "out of memory");
    int64_t m = 0;
    for (int64_t i = 0; i < nreg; i++) {
        off[i] = m;
        const gs_region_box *a = &boxes[list[i].id];
        for (int64_t j = 0; j < nreg; j++) {
            const gs_region_box *b = &boxes[j];
            if (b->color >= a->color)
                continue;
            int ab = 1, ba = 1;
            for (int d = 0; d < 3; d++) {
                ab &= a->wlo[d] < b->rhi[d] && b->rlo[d] < a->whi[d];
                ba &= b->wlo[d] < a->rhi[d] && a->rlo[d] < b->whi[d];
            }
            if (ab || ba) {
                TOY_CHECK(m < nreg * 64, "too many conflicts");
                ids[m++] = b->id;
            }
        }
    }
    off[nreg] = m;
    toy tf = {flow_grid, boxes};
    init_grid(flow_grid);
    GS_CALL(gs_regions_create(MPI_COMM_WORLD, list, nreg, SEED, DOMAIN, &sched));
    GS_CALL(gs_regions_set_conflicts(sched, off, ids));
    double flow_elapsed = 0;
    GS_CALL(timed_passes(sched, &tf, &flow_elapsed));
    gs_regions_stats fst = gs_regions_get_stats(sched);
    /* Again with the last rank stalled in every pass (its ready regions are
     * taken by the others after FLOW_STEAL_AFTER, or it runs them late):
     * the same grid. */
    double *stall_grid = malloc((size_t)NX * NY * NZ * sizeof *stall_grid);
    TOY_CHECK(stall_grid != NULL, "out of memory");
    toy ts = {stall_grid, boxes};
    init_grid(stall_grid);
    gs_regions_t stalled = NULL;
    GS_CALL(gs_regions_create(MPI_COMM_WORLD, list, nreg, SEED, DOMAIN, &stalled));
    GS_CALL(gs_regions_set_conflicts(stalled, off, ids));
    double stall_elapsed = 0;
    g_stall_ms = 100;
    g_stall_every = nreg;
    GS_CALL(timed_passes(stalled, &ts, &stall_elapsed));
    g_stall_ms = 0;
    gs_regions_stats sst = gs_regions_get_stats(stalled);
    gs_regions_destroy(&stalled);
    /* a failing region stops the dataflow pass with the same code everywhere */
    toy tfail = {ref, boxes}; /* scratch: ref is rebuilt below */
    TOY_CHECK(gs_regions_run_pass(sched, 0, toy_run_failing, toy_apply, &tfail) == GS_ERR_ARG,
              "a failing region must fail the dataflow pass on every rank");
    TOY_CHECK(strstr(gs_error_message(), "refuses") != NULL, "message: %s", gs_error_message());
    gs_error_clear();
    /* a conflict of the same colour is refused on every rank */
    int64_t bad_ids[1];
    gs_regions_t one = NULL;
    gs_region two[2] = {{0, 1}, {1, 1}};
    GS_CALL(gs_regions_create(MPI_COMM_WORLD, two, 2, SEED, DOMAIN, &one));
    int64_t bad_off2[3] = {0, 1, 1};
    bad_ids[0] = 1;
    TOY_CHECK(gs_regions_set_conflicts(one, bad_off2, bad_ids) == GS_ERR_ARG,
              "a same-coloured conflict must be refused");
    gs_error_clear();
    gs_regions_destroy(&one);
    gs_regions_destroy(&sched);
    free(off);
    free(ids);

    /* Serial reference: colors in order, regions in id order, each result
     * written at once (in place). Equal only if same-colored regions are
     * independent and the scheduler keyed the streams as documented. */
    toy tr = {ref, boxes};
    init_grid(ref);
    for (int pass = 0; pass < PASSES; pass++)
        for (int color = 0; color < 8; color++)
            for (int64_t id = 0; id < nreg; id++) {
                if (boxes[id].color != color)
                    continue;
                gs_rng rng;
                gs_rng_init(&rng, SEED, gs_rng_stream_id(DOMAIN, (uint64_t)id, (uint64_t)pass, 0));
                GS_CALL(compute(&tr, id, &rng, tmp));
                write_core(&tr, id, tmp);
            }
    uint64_t h = gs_digest_bytes(grid, (size_t)NX * NY * NZ * sizeof *grid);
    uint64_t href = gs_digest_bytes(ref, (size_t)NX * NY * NZ * sizeof *ref);
    TOY_CHECK(h == href, "scheduled grid differs from the serial sweep");
    TOY_CHECK(gs_digest_bytes(flow_grid, (size_t)NX * NY * NZ * sizeof *flow_grid) == href,
              "dataflow grid differs from the serial sweep");
    TOY_CHECK(gs_digest_bytes(stall_grid, (size_t)NX * NY * NZ * sizeof *stall_grid) == href,
              "dataflow grid with a stalled rank differs from the serial sweep");
    free(flow_grid);
    free(stall_grid);
    GS_CALL(gs_par_check_same_i64(MPI_COMM_WORLD, (int64_t)h, "regions grid digest"));

    int64_t computed_all[64] = {0};
    double wait_all[64] = {0};
    GS_MPI(MPI_Gather(&st.computed, 1, MPI_INT64_T, computed_all, 1, MPI_INT64_T, 0, MPI_COMM_WORLD));
    GS_MPI(MPI_Gather(&st.t_wait, 1, MPI_DOUBLE, wait_all, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD));
    if (rank == 0) {
        int64_t total = 0;
        char per[256] = "";
        for (int r = 0; r < size && r < 64; r++) {
            total += computed_all[r];
            size_t len = strlen(per);
            snprintf(per + len, sizeof per - len, "%s%lld (wait %.2f s)", r ? ", " : "",
                     (long long)computed_all[r], wait_all[r]);
        }
        TOY_CHECK(total == nreg * PASSES, "%lld regions computed, expected %lld",
                  (long long)total, (long long)(nreg * PASSES));
        fprintf(stderr, "regions_toy np=%d dataflow: %.3f s wall (rank 0: %lld regions, wait "
                "%.3f s)\n", size, flow_elapsed, (long long)fst.computed, fst.t_wait);
        fprintf(stderr, "regions_toy np=%d dataflow, last rank stalled %d x 100 ms: %.3f s wall "
                "(rank 0: %lld regions, %lld duplicates received)\n", size, PASSES,
                stall_elapsed, (long long)sst.computed, (long long)sst.duplicates);
        fprintf(stderr, "regions_toy np=%d: %lld regions x %d passes in 8 colors: %.3f s wall "
                "(regions per rank: %s; rank 0 compute %.3f s, exchange %.3f s)\n",
                size, (long long)nreg, PASSES, elapsed, per, st.t_compute, st.t_exchange);
        char hex[17];
        gs_digest_hex(h, hex);
        printf("digest: regions_grid %s\n", hex);
    }
    free(list);
    free(grid);
    free(ref);
    free(tmp);
    gs_free(boxes);
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
