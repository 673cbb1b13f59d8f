/* The `model` engine: Merrell's model synthesis (src/model core) behind the
 * geosynth CLI, run over MPI ranks with colored regions.
 *
 *   mpirun -np N geosynth model -c configs/model/castle.ini
 *
 * This file holds the engine's operations for the run driver
 * (include/geosynth/engine.h, src/run/driver.c, which owns the phases,
 * checkpoint cadence, signals and the summary): set-up, restore, the advance
 * by a window of colours, save, the synthesis report, destroy. The rest of
 * the driver: engine_config.c (keys, `geosynth model --help`, validation),
 * engine_setup.c (inputs, rules, symmetries, start model), engine_regions.c
 * (the sweep: plans, regions, windows), engine_sched.c (schedule figures
 * in region CPU seconds), engine_state.c (checkpoints),
 * engine_output.c (files, measures, metrics); shared declarations in
 * engine_impl.h.
 *
 * Phases: setup (rank 0 reads the example and the optional start lattice and
 * broadcasts them; every rank learns the same rules and builds the same
 * start model), synthesis (pass after pass; the regions of a pass run on all
 * ranks through gs_regions as one dataflow over the colours of
 * gs_model_plan: a region starts once the regions of lower colours it
 * touches (gs_model_regions_interact) are applied, and every rank applies
 * each result after those; the outcome is exactly the core's serial driver
 * gs_model_synthesize, colours in order, regions in id order),
 * output (rank 0: lattice.h5 + lattice.xmf, lattice.vox, the merged-face
 * mesh, lattice.png when nz == 1, optionally Merrell's .txt; quality
 * metrics).
 *
 * 2D inputs as WaveFunctionCollapse users know them (model_tiles.h):
 * model.tileset (mxgmn tile set XML, optional model.subset / start_tile)
 * and model.sample (overlapping model: N x N patterns of a PNG, keys
 * overlap_n, symmetry, periodic_input) replace model.example; their rules
 * come from explicit pairs, the start model is a uniform layer of a tile
 * that may sit next to itself, and the output adds tiles.png (assembled
 * from the tile images) or image.png (pattern pixels); the violations metric
 * then comes from the tile-set / pattern checker. Periodic output and the
 * overlapping model's ground are not supported. Voxel (3D) tile sets
 * (MarkovJunior XML, DeBroglie JSON) run at any z: their ground, border and
 * fixed tiles (and model.border_tile) become pins, and the outputs add
 * tiles.vox; mesh.ply and preview.png show the assembled voxels.
 * model.overlap3d = N (3D overlapping model, overlap3d.c) turns the example's
 * N^3 windows into labels: the solver, regions and checkpoints see pattern
 * labels, the outputs the decoded lattice (each pattern's origin cell).
 *
 * Work units (checkpoint cadence, GS_STOP_AFTER_UNITS) are regions
 * finished; checkpoints are taken between colours, since regions of
 * neighbouring colours run concurrently: a window of colours (at most
 * MODEL_WINDOW_REGIONS regions) ends where a unit-based checkpoint or stop
 * would fall, so those land on the same colour as with one colour at a
 * time; time-based checkpoints and signals are seen at the window's end. The checkpoint (group /model) holds the lattice,
 * the per-cell count of accepted regions (coverage, which decides when the
 * sweep may stop), the position (pass, next colour), the per-region status
 * and attempt counters of the pass in progress and the statistics; a resumed
 * run continues with any rank count and ends with the same digest.
 *
 * Determinism: gs_model_region_run depends only on (lattice before the
 * colour, box, params, region id, pass); the gs_regions random stream is not
 * used. So the final lattice is identical for every rank count.
 */
#include <stddef.h>

#include "geosynth/engine.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "model/engine_impl.h"

static gs_err model_setup_op(gs_run *run, const void *cfgp, int resume, void **state,
                             gs_json *phase)
{
    model_drive *d = gs_calloc(1, sizeof *d);
    GS_CHECK(d != NULL, GS_ERR_MEM, "model: out of memory for the run state");
    *state = d;
    model_engine *e = &d->e;
    e->cfg = cfgp;
    GS_CALL(model_setup(run, e, resume));
    gs_json_begin_array(phase, "example");
    gs_json_i64(phase, NULL, e->example.nx);
    gs_json_i64(phase, NULL, e->example.ny);
    gs_json_i64(phase, NULL, e->example.nz);
    gs_json_end_array(phase);
    gs_json_i64(phase, "labels", gs_model_rules_nlabels(e->rules));
    gs_json_begin_array(phase, "output");
    gs_json_i64(phase, NULL, e->lat.nx);
    gs_json_i64(phase, NULL, e->lat.ny);
    gs_json_i64(phase, NULL, e->lat.nz);
    gs_json_end_array(phase);
    return GS_OK;
}

static gs_err model_restore(void *state, gs_run *run)
{
    model_engine *e = &((model_drive *)state)->e;
    GS_CALL(model_read_checkpoint(run, e));
    gs_log(GS_LOG_INFO, "resumed at pass %d, colour %d after %lld regions", e->pass + 1, e->color,
           (long long)e->units);
    return GS_OK;
}

/* Regions run, including before a resume; the passes needed are not known
 * in advance (each pass has its own progress line). */
static void model_units(const void *state, int64_t *done, int64_t *total)
{
    *done = ((const model_drive *)state)->e.units;
    *total = 0;
}

static gs_err model_advance(void *state, gs_run *run, int *finished)
{
    model_drive *d = state;
    model_engine *e = &d->e;
    if (!d->started) {
        d->started = 1;
        d->cpu0 = gs_cpu_now();
        d->t0 = gs_time_now();
        d->base = e->synth_seconds;
    }
    GS_CALL(model_advance_window(run, e, finished));
    e->synth_seconds = d->base + (gs_time_now() - d->t0);
    return GS_OK;
}

static gs_err model_save(void *state, gs_run *run)
{
    model_engine *e = &((model_drive *)state)->e;
    GS_CALL(GS_PAR_BCAST_VALUE(run->comm, &e->synth_seconds, 0));
    return model_write_checkpoint(run, e);
}

static gs_err model_synthesis_report(void *state, gs_run *run, gs_json *j)
{
    model_drive *d = state;
    const model_engine *e = &d->e;
    const double cells = (double)lattice_cells(&e->lat);
    gs_json_i64(j, "passes", e->stats.passes);
    gs_json_u64(j, "regions", e->stats.regions);
    gs_json_u64(j, "accepted", e->stats.accepted);
    gs_json_u64(j, "failed", e->stats.failed);
    gs_json_u64(j, "retries", e->stats.attempts - e->stats.regions);
    gs_json_u64(j, "rejected_attempts", e->stats.attempts - e->stats.accepted);
    gs_json_u64(j, "backtracks", e->stats.backtracks);
    gs_json_u64(j, "min_coverage", e->stats.min_coverage);
    gs_json_f64(j, "cells_per_second", e->synth_seconds > 0 ? cells / e->synth_seconds : 0.0);
    GS_CALL(model_queue_report(run, e, d->started ? gs_cpu_now() - d->cpu0 : 0, &d->qr, j));
    GS_CHECK(!j->failed, GS_ERR_MEM, "out of memory for the synthesis phase report");
    return GS_OK;
}

static void model_destroy(void *state)
{
    model_drive *d = state;
    if (!d)
        return;
    gs_measure_profile_free(&d->q.fig.profile);
    model_engine_free(&d->e);
    gs_free(d);
}

static const gs_engine_ops model_ops = {
    .setup = model_setup_op,
    .restore = model_restore,
    .units = model_units,
    .advance = model_advance,
    .save = model_save,
    .synthesis_report = model_synthesis_report,
    .output = model_output_op,
    .destroy = model_destroy,
};

const gs_engine gs_engine_model = {
    "model",
    "model synthesis (Merrell 2007): label lattice from an example lattice",
    &model_cfg_table,
    sizeof(model_config),
    offsetof(model_config, run),
    &model_ops,
};
