/* The `points` engine: patch-based synthesis of geometry textures on
 * point-set surfaces (Duranleau and Poulin) behind `geosynth points -c X.ini`.
 *
 * This file holds the engine's operations for the run driver
 * (include/geosynth/engine.h, src/run/driver.c, which owns the phases,
 * checkpoint cadence, signals and the summary): set-up, restore, one patch
 * per advance, save, the finish phase (relaxation, trimming), the synthesis
 * report, destroy, and each operation's status (collective or local). The
 * rest of the driver: engine_config.c (keys, `geosynth points --help`,
 * validation), engine_setup.c (the example, broadcast, the synthesis
 * created), engine_parallel.c (distributed search, map hook, agreement,
 * test faults), engine_state.c (checkpoints), engine_output.c (files and
 * measures); shared declarations in engine_impl.h.
 *
 * Input (section [input]): an oriented point set (PLY with normals), a
 * triangle mesh sampled uniformly (Poisson disk), or one of the paper's
 * generated examples (height field from an image, chain mail, weave,
 * flowers). User geometry comes with its box B_Tin (input.box_lo/box_hi) and
 * the axis normal to its reference plane (input.up); the core works with z
 * up, so points are permuted cyclically to z-up and back for the output.
 *
 * Parallel model: every rank holds the whole synthesis state (output point
 * grid, RNG, metrics) and does the same deterministic steps; the search over
 * the input patches is distributed: each rank's patch bank holds only its
 * share [lo, hi) of gs_partition's split, each rank scans it and one
 * all-gather brings every candidate under (1 + eps) * global best, sorted by
 * (distance, index), to every rank (points_distributed_search). Each patch's distance is summed in a fixed order
 * independent of the partition, so Psi_k, the random pick and therefore the
 * output are bit-identical for any rank count.
 *
 * Rank 0 reads/generates the example and broadcasts it. Work units for
 * checkpoints are placed patches; checkpoint.h5 holds /points: cursor, RNG
 * state, the output points (bucket order), the per-patch metrics, and the
 * digest of the example (a resume refuses a changed example).
 *
 * Outputs in RUN_DIR: points.ply (x y z nx ny nz, doubles), optionally
 * mesh.ply (implicit function of the points on a dense grid, contoured by
 * OpenVDB), patches.csv (per-patch metrics); summary.json metrics: search
 * distances, warp residual, densities, search/warp/blend/other/relax times.
 *
 * Errors (STYLE.md: MPI code never hangs on error). A failure that every
 * rank learns in the same exchange (a status word travels in the search
 * all-gather and in the map all-gather; rank 0's set-up and output go
 * through gs_par_agree) is collective: every rank returns the same gs_err
 * (the failing one with its message, the others with "rank N failed: ...")
 * and the run ends cleanly with one report (gs_run.failed_together). Any
 * other failure is local to one rank (an allocation, a merge, the warp's
 * solve, the paste, between two exchanges): the operation sets
 * gs_run.failed_alone and the driver (gs_engine_drive) ends the job at once,
 * before any clean-up collective, so MPI_Abort stops every rank wherever it
 * waits. No extra collective per patch.
 */
#include <stddef.h>

#include "geosynth/engine.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "points/engine_impl.h"

/* One patch placed (the search is spread over the ranks). */
static gs_err synth_step(run_state *rs, int *finished)
{
    gs_points_synth_t s = rs->synth;
    *finished = gs_points_synth_cursor(s) >= gs_points_synth_total(s);
    if (*finished)
        return GS_OK;
    fault_inject *f = &rs->fault;
    f->armed = f->site != FAULT_NONE && gs_points_synth_cursor(s) == f->patch;
    GS_CALL(gs_points_synth_step(s));
    if (points_fault_fires(f, FAULT_STEP))
        GS_CALL(points_fault_raise(f, FAULT_STEP, GS_ERR_LIB));
    f->armed = 0;
    *finished = gs_points_synth_cursor(s) >= gs_points_synth_total(s);
    return GS_OK;
}

static gs_err points_synthesis_report(void *state, gs_run *run, gs_json *j)
{
    const run_state *rs = state;
    gs_points_synth_t s = rs->synth;
    gs_points_times tm = gs_points_synth_times(s);
    gs_json_u64(j, "patches_done", gs_points_synth_cursor(s));
    gs_json_f64(j, "search_seconds", tm.search);
    gs_json_f64(j, "warp_seconds", tm.warp);
    gs_json_f64(j, "blend_seconds", tm.blend);
    gs_json_f64(j, "other_seconds", tm.other);
    gs_json_i64(j, "candidates_offered_rank0", rs->sctx.offers);
    gs_json_i64(j, "search_regathers", rs->sctx.regathers);
    return GS_OK;
}

/* ---- the run driver's operations (include/geosynth/engine.h) -------------- */

/* An operation's status. A failure every rank returned from the same
 * collective (rs->together, see points_agree) is agreed by the driver; one that
 * may be this rank's alone (the others may be waiting in an exchange) ends
 * every rank at once (gs_run.failed_alone). */
static gs_err op_status(gs_run *run, const run_state *rs, gs_err err)
{
    if (err != GS_OK && err != GS_ERR_INTERRUPTED && !rs->together)
        run->failed_alone = 1;
    return err;
}

static gs_err points_setup_op(gs_run *run, const void *vcfg, int resume, void **state,
                              gs_json *phase)
{
    run_state *rs = gs_calloc(1, sizeof *rs);
    GS_CHECK(rs != NULL, GS_ERR_MEM, "points: out of memory for the run state");
    *state = rs;
    rs->c = vcfg;
    gs_err err = points_fault_init(&rs->fault, run->rank);
    if (err != GS_OK) { /* the same environment, so the same error, on every rank */
        rs->together = 1;
        return err;
    }
    return op_status(run, rs, points_phase_setup(run, rs->c, rs, resume, phase));
}

static gs_err points_restore(void *state, gs_run *run)
{
    run_state *rs = state;
    gs_points_synth_state st;
    gs_err err = points_read_checkpoint(run, rs->tex_digest, &st);
    if (err == GS_OK) {
        err = gs_points_synth_resume_share(&rs->tex, &rs->params, &rs->share, &st, &rs->synth);
        gs_points_synth_state_free(&st);
        if (err == GS_OK)
            err = points_apply_choices(rs);
    }
    GS_CALL(op_status(run, rs, err));
    run->ckpt_last_units = (int64_t)gs_points_synth_cursor(rs->synth);
    gs_log(GS_LOG_INFO, "resumed at patch %llu of %llu",
           (unsigned long long)gs_points_synth_cursor(rs->synth),
           (unsigned long long)gs_points_synth_total(rs->synth));
    return GS_OK;
}

static void points_units(const void *state, int64_t *done, int64_t *total)
{
    const run_state *rs = state;
    *done = (int64_t)gs_points_synth_cursor(rs->synth);
    *total = (int64_t)gs_points_synth_total(rs->synth);
}

static gs_err points_advance(void *state, gs_run *run, int *finished)
{
    run_state *rs = state;
    return op_status(run, rs, synth_step(rs, finished));
}

static gs_err points_save(void *state, gs_run *run)
{
    run_state *rs = state;
    gs_err err = points_write_checkpoint(run, rs->synth, rs->tex_digest);
    GS_DEBUG("checkpoint at patch %llu", (unsigned long long)gs_points_synth_cursor(rs->synth));
    return op_status(run, rs, err);
}


/* Relaxation, trimming, back to the example's axes. */
static gs_err points_finish(void *state, gs_run *run, gs_json *phase)
{
    run_state *rs = state;
    GS_CALL(op_status(run, rs, gs_points_synth_finish_labeled(rs->synth, &rs->out,
                                                                       &rs->out_patch)));
    gs_points_permute_from_z(&rs->out, kind_is_user(rs->c) ? up_axis(rs->c) : 2);
    double area = rs->params.out_size[0] * rs->params.out_size[1];
    rs->dens_out = rs->out.n / area;
    gs_json_u64(phase, "output_points", rs->out.n);
    gs_json_f64(phase, "relax_seconds", gs_points_synth_times(rs->synth).relax);
    return GS_OK;
}

static void points_destroy(void *state)
{
    run_state *rs = state;
    if (!rs)
        return;
    points_run_state_free(rs);
    gs_free(rs);
}

static const gs_engine_ops points_ops = {
    .setup = points_setup_op,
    .restore = points_restore,
    .units = points_units,
    .advance = points_advance,
    .save = points_save,
    .synthesis_report = points_synthesis_report,
    .finish = points_finish,
    .output = points_output_op,
    .destroy = points_destroy,
};

const gs_engine gs_engine_points = {
    "points",
    "patch-based geometry texture synthesis on point-set surfaces (Duranleau & Poulin)",
    &points_cfg_table,
    sizeof(points_config),
    offsetof(points_config, run),
    &points_ops,
};
