/* The rank-0 work queue every micro pass runs through (gs_regions, one
 * colour, one region per item): the reconstruction rounds and the output
 * pass of engine.c, the gallery's candidates of engine_explore.c. */
#include "geosynth/mem.h"
#include "geosynth/regions.h"
#include "micro/engine_impl.h"

gs_err micro_queue_create(MPI_Comm comm, int64_t n, uint64_t seed, uint32_t rng_domain,
                          gs_regions_t *queue)
{
    gs_region *regs = gs_calloc((size_t)n, sizeof *regs);
    GS_CHECK(regs != NULL, GS_ERR_MEM, "region list of %lld items", (long long)n);
    for (int64_t i = 0; i < n; i++)
        regs[i] = (gs_region){i, 0};
    gs_err err = gs_regions_create(comm, regs, n, seed, rng_domain, queue);
    gs_free(regs);
    GS_CALL(err);
    return GS_OK;
}

gs_err micro_queue_pass(MPI_Comm comm, int64_t n, uint64_t seed, uint32_t rng_domain,
                        gs_region_run_fn run, gs_region_apply_fn apply, void *ctx)
{
    gs_regions_t queue = NULL;
    GS_CALL(micro_queue_create(comm, n, seed, rng_domain, &queue));
    gs_err err = gs_regions_run_pass(queue, 0, run, apply, ctx);
    gs_regions_destroy(&queue);
    GS_CALL(err);
    return GS_OK;
}
