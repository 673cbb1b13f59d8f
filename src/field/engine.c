/* The `field` engine: distance-field geometry synthesis after Lagae, Dumont,
 * Dutré, "Geometry Synthesis" (2004), wired into geosynth.
 *
 *   mpirun -np N geosynth field -c configs/field/grid.ini
 *
 * This file holds the engine's operations for the run driver
 * (include/geosynth/engine.h, src/run/driver.c, which owns the phases,
 * checkpoint cadence, signals and the summary): restore, units, the advance
 * by one colour's regions or a batch of blocks, save, the synthesis report,
 * destroy. The rest of the driver: engine_config.c (keys, `geosynth field
 * --help`, validation), engine_setup.c (the source built on rank 0 and
 * broadcast, the synthesis created), engine_match.c (the distributed exact
 * match, a colour's regions on the work queue), engine_state.c (checkpoints),
 * engine_output.c (the output phase); shared declarations in engine_impl.h.
 *
 * Phases:
 *  setup      rank 0 builds the example (generator, mesh, .vdb, height map or
 *             HDF5 field; see include/geosynth/field_examples.h), crops it to a
 *             multiple of 2^(iterations-1) per axis and quantizes it over
 *             [-range, range] samples; the quantized source is broadcast, so
 *             every rank holds the identical bytes (OpenVDB is never run on
 *             two ranks). Then the synthesis is created, or restored from
 *             RUN_DIR/checkpoint.h5.
 *  synthesis  the core's multi-resolution synthesis (src/field/synth.c). Every
 *             rank holds the whole (small) target. Each iteration's block
 *             positions are cut into target regions (field.region_blocks)
 *             visited in wavefront colors; the core's visit order (colors,
 *             regions by id, raster inside) gives exactly the paper's raster
 *             order's result (see gs_field_region), so the region size never
 *             changes the output. A color with at least one region per rank
 *             runs on the gs_regions work queue: each rank synthesizes whole
 *             regions on private copies with its local tree, the results
 *             (source block per target block) are exchanged and applied in id
 *             order on every rank. Other colors (the first and last of the
 *             wavefront, coarse iterations with few regions, a color resumed
 *             in its middle) run block by block on every rank, and each
 *             query is first searched whole on every rank
 *             with a pop budget (FIELD_LOCAL_POPS; the same answer, or the
 *             same give-up, everywhere, no messages); only queries over the
 *             budget are distributed: the search
 *             tree's top-level subtrees are split over the ranks (gs_psearch,
 *             balanced by blocks per subtree), each rank searches its share
 *             with the bound shared between ranks (the tree search polls
 *             gs_psearch_bound), and the result is made exact: psearch gives
 *             the smallest distance, one MPI_Allreduce(MIN) gives the lowest
 *             tie rank (gs_field_tie_rank of the query's tie key: a seeded
 *             hash above the block index, so exact ties do not all go to
 *             the source's start) among the ranks whose best has that
 *             distance. So
 *             each block gets exactly the serial answer of
 *             gs_field_tree_best_match and the output is bit-identical for any
 *             rank count (and to the core's serial synthesis).
 *             field.tree = sharded: each rank builds only the tree of one
 *             z-slab of every iteration's block positions (gs_field_tree_build_shard,
 *             split by count), so tree + pyramid memory per rank falls with
 *             the rank count; every query is then spread (one psearch
 *             candidate per rank: its slab, bound shared), regions run in
 *             order (a region needs the whole tree), and the quality measure
 *             searches the slabs together too. Same output.
 *             Checkpoint tests (a collective) run after every region color
 *             and every FIELD_UNIT_BATCH blocks in order. Checkpoints hold target, mask, iteration,
 *             cursor, match statistics and the provenance map; the only
 *             randomness (the seeds of iteration 0) is drawn from gs_rng keyed
 *             by run.seed when the synthesis is created, so it is part of the
 *             stored target, not a running RNG; the random first blocks and
 *             the matcher's tie order are streams and hashes keyed by
 *             (run.seed, block), stateless.
 *  output     field.h5 (+ field.xmf) with the float distance and the quantized
 *             levels, field.vdb, the contoured mesh (OpenVDB) and, with
 *             output.geometry = copy|both, the paper's copied geometry: the
 *             source surface copied along the provenance onto the contour's
 *             connectivity (a valid mesh, seams relaxed). Quality metrics go to
 *             summary.json. The digest is that of the final quantized target.
 *
 * Memory per rank: source 1 byte/sample + pyramid 8L bytes/sample + tree
 * (~20 bytes/node), the last two for the rank's slab only when sharded
 * (1/np + (B-1)/nz of the source, plus 1 byte/sample for the slab's copy);
 * target 2 bytes/sample + provenance 4 bytes/sample of the final target;
 * rank 0 also the float source (4 bytes/sample) and meshes. The largest
 * rank's tree + pyramid bytes are reported (tree_bytes_rank_max).
 */
#include <stddef.h>

#include "geosynth/engine.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "field/engine_impl.h"

static gs_err max_over_ranks(gs_run *run, unsigned long long v, unsigned long long *out)
{
    uint64_t m;
    GS_CALL(gs_par_max_u64(run->comm, (uint64_t)v, &m));
    *out = (unsigned long long)m;
    return GS_OK;
}

static int synth_finished(const gs_field_synth_state *st, int iterations)
{
    return st->iteration >= iterations ||
           (st->iteration == iterations - 1 && st->cursor >= st->blocks_in_iteration);
}

static gs_err field_restore(void *state, gs_run *run)
{
    field_drive *d = state;
    gs_err err = field_read_checkpoint(run, d->src.q, &d->sc, &d->ctx, d->src_digest, &d->synth);
    GS_CALL(gs_par_agree(run->comm, err));
    d->ctx.synth = d->synth;
    return GS_OK;
}

static void field_units(const void *state, int64_t *done, int64_t *total)
{
    const field_drive *d = state;
    const gs_field_synth_state *st = gs_field_synth_get_state(d->synth);
    *done = field_units_done(st);
    *total = *done > d->total ? *done : d->total;
}

/* One colour's regions in parallel, or up to FIELD_UNIT_BATCH blocks of a
 * colour in order (each query spread over the ranks). */
static gs_err field_advance(void *state, gs_run *run, int *finished)
{
    field_drive *d = state;
    const gs_field_synth_state *st = gs_field_synth_get_state(d->synth);
    if (!d->started) {
        d->started = 1;
        d->t0 = gs_time_now();
        d->start_units = field_units_done(st);
    }
    *finished = st->iteration >= d->sc.iterations;
    if (*finished)
        return GS_OK;
    int64_t begin, end, r0, nr;
    const gs_field_region *regs;
    double ta = gs_time_now();
    GS_CALL(gs_field_synth_color(d->synth, &begin, &end, &regs, &r0, &nr, finished));
    double tb = gs_time_now();
    d->t_setup += tb - ta; /* a new iteration: level source, tree */
    if (*finished)
        return GS_OK;
    st = gs_field_synth_get_state(d->synth);
    gs_field_tree_t tr = gs_field_synth_tree(d->synth);
    if (tr) {
        gs_field_tree_info ti;
        gs_field_tree_get_info(tr, &ti);
        if (ti.tree_bytes + ti.pyramid_bytes > d->tree_peak)
            d->tree_peak = ti.tree_bytes + ti.pyramid_bytes;
    }
    if (run->size > 1 && nr >= run->size && st->cursor == begin && !d->ctx.sharded) {
        /* a color with a region for every rank: regions in parallel */
        GS_CALL(field_run_color_regions(run, d->synth, r0, nr, &d->rt));
        d->region_colors++;
    } else {
        /* one region (or fewer than ranks, or a color resumed in its
         * middle): the color's blocks in order, each query spread over
         * the ranks. Batches: the checkpoint test is a collective, and
         * most blocks take microseconds (identical batches on every rank) */
        int64_t left = end - st->cursor, n = left < FIELD_UNIT_BATCH ? left : FIELD_UNIT_BATCH;
        GS_CALL(gs_field_synth_run(d->synth, n, finished));
        d->serial_colors += n == left;
        d->t_order += gs_time_now() - tb;
    }
    st = gs_field_synth_get_state(d->synth);
    *finished = *finished || synth_finished(st, d->sc.iterations);
    return GS_OK;
}

static gs_err field_save(void *state, gs_run *run)
{
    field_drive *d = state;
    return field_write_checkpoint(run, &d->ctx, d->src_digest);
}

static gs_err field_synthesis_report(void *state, gs_run *run, gs_json *phase)
{
    field_drive *d = state;
    const gs_field_synth_state *st = gs_field_synth_get_state(d->synth);
    double syn_s = d->started ? gs_time_now() - d->t0 : 0;
    unsigned long long tree_peak_max = 0, pops_max = 0;
    GS_CALL(max_over_ranks(run, d->tree_peak, &tree_peak_max));
    GS_CALL(max_over_ranks(run, d->ctx.pops, &pops_max));
    if (run->rank == 0) {
        gs_log(GS_LOG_INFO, "search tree + pyramid per rank: %.1f MiB (largest rank), %s",
               (double)tree_peak_max / 1048576.0, d->ctx.sharded ? "sharded" : "whole");
        gs_run_metric_i64(run, "tree_bytes_rank_max", (int64_t)tree_peak_max);
    }
    const int64_t u = field_units_done(st), here = u - (d->started ? d->start_units : u);
    gs_json_str(phase, "tree", d->ctx.sharded ? "sharded" : "whole");
    gs_json_u64(phase, "tree_bytes_rank_max", tree_peak_max);
    gs_json_i64(phase, "blocks", u);
    gs_json_i64(phase, "blocks_this_run", here);
    gs_json_f64(phase, "blocks_per_second", syn_s > 0 ? (double)here / syn_s : 0.0);
    gs_json_i64(phase, "colors_in_regions", d->region_colors);
    gs_json_i64(phase, "colors_in_order", d->serial_colors);
    gs_json_begin_object(phase, "rank0_seconds");
    gs_json_f64(phase, "iteration_setup", d->t_setup);
    gs_json_f64(phase, "in_order", d->t_order);
    gs_json_f64(phase, "regions_compute", d->rt.compute);
    gs_json_f64(phase, "regions_wait", d->rt.wait);
    gs_json_f64(phase, "regions_exchange", d->rt.exchange);
    gs_json_f64(phase, "regions_apply", d->rt.apply);
    gs_json_end_object(phase);
    gs_json_i64(phase, "rank0_regions", d->rt.regions);
    gs_json_i64(phase, "queries_local", d->ctx.local_queries);
    gs_json_i64(phase, "queries_spread", run->size > 1 ? d->ctx.queries - d->ctx.local_queries : 0);
    gs_json_u64(phase, "search_pops_rank_max", pops_max);
    return GS_OK;
}

static void field_destroy(void *state)
{
    field_drive *d = state;
    if (!d)
        return;
    gs_field_searcher_destroy(&d->ctx.qsearcher);
    gs_field_tree_destroy(&d->ctx.qtree);
    gs_psearch_destroy(&d->ctx.ps);
    gs_field_synth_destroy(&d->synth);
    gs_free(d->ctx.prov);
    gs_qfield_destroy(&d->res);
    gs_field_destroy(&d->resf);
    field_source_free(&d->src);
    gs_free(d);
}

static const gs_engine_ops field_ops = {
    .setup = field_setup_op,
    .restore = field_restore,
    .units = field_units,
    .advance = field_advance,
    .save = field_save,
    .synthesis_report = field_synthesis_report,
    .output = field_output_op,
    .destroy = field_destroy,
};

const gs_engine gs_engine_field = {
    "field",
    "distance-field geometry synthesis from a mesh, level set, height map or built-in example "
    "(Lagae et al.)",
    &field_cfg_table,
    sizeof(field_config),
    offsetof(field_config, run),
    &field_ops,
};
