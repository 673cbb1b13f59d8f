/* model driver, checkpoints: RUN_DIR/checkpoint.h5's /model group (lattice,
 * coverage, pass, colour, per-region status and attempts, statistics; see
 * docs/FORMATS.md) written (collective) and read back. */
#include "geosynth/log.h"
#include "model/engine_impl.h"

gs_h5_shape model_lattice_shape(const gs_model_lattice *l)
{
    gs_h5_shape s = {GS_H5_U16, 3, {(uint64_t)l->nz, (uint64_t)l->ny, (uint64_t)l->nx}};
    if (l->frames > 1) { /* 4D: [t][z][y][x], the same bytes */
        gs_h5_shape s4 = {GS_H5_U16, 4, {(uint64_t)l->frames, (uint64_t)gs_model_frame_nz(l),
                                         (uint64_t)l->ny, (uint64_t)l->nx}};
        return s4;
    }
    return s;
}

gs_err model_write_checkpoint(gs_run *run, model_engine *e)
{
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_begin(run, &h));
    gs_err err = GS_OK;
    gs_h5_shape ls = model_lattice_shape(&e->lat);
    const char *g = "/model";
    GS_TRY(err, gs_ckpt_write_whole(h, "/model/lattice", &ls, e->lat.labels, NULL), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/model/coverage", &ls, e->coverage, NULL), fail);
    if (e->nplan) {
        gs_h5_shape rs = {GS_H5_I32, 1, {e->nplan}};
        GS_TRY(err, gs_ckpt_write_whole(h, "/model/region_status", &rs, e->region_status, NULL),
               fail);
        GS_TRY(err,
               gs_ckpt_write_whole(h, "/model/region_attempts", &rs, e->region_attempts, NULL),
               fail);
    }
    GS_TRY(err, gs_ckpt_set_i64(h, g, "pass", e->pass), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, g, "color", e->color), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, g, "units", e->units), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, g, "nplan", (int64_t)e->nplan), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "example_digest", e->example_digest), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_regions", e->stats.regions), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_accepted", e->stats.accepted), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_failed", e->stats.failed), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_attempts", e->stats.attempts), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_choices", e->stats.choices), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_backtracks", e->stats.backtracks), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_region_cells", e->region_cells), fail);
    if (e->params.shape || e->keep_tests) /* rejected rebuilds too */
        GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_mh_rejected", e->stats.mh_rejected), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, g, "synthesis_seconds", e->synth_seconds), fail);
    GS_CALL(gs_run_checkpoint_commit(run, &h, e->units));
    return GS_OK;
fail:
    gs_ckpt_discard(&h);
    return err;
}

gs_err model_read_checkpoint(gs_run *run, model_engine *e)
{
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_open(run, &h));
    gs_err err = GS_OK;
    const char *g = "/model";
    int64_t pass = 0, color = 0, nplan = 0;
    uint64_t exd = 0;
    GS_TRY(err, gs_ckpt_get_u64(h, g, "example_digest", &exd), done);
    GS_TRY_CHECK(err, exd == e->example_digest, GS_ERR_ARG, done,
                 "%s: the example %s changed since the checkpoint was written (digest "
                 "%016llx, now %016llx): resume needs the same example",
                 gs_ckpt_path(h),
                 e->cfg->tileset[0] ? e->cfg->tileset
                 : e->cfg->sample[0] ? e->cfg->sample : e->cfg->example,
                 (unsigned long long)exd,
                 (unsigned long long)e->example_digest);
    GS_TRY(err, gs_ckpt_get_i64(h, g, "pass", &pass), done);
    GS_TRY(err, gs_ckpt_get_i64(h, g, "color", &color), done);
    GS_TRY(err, gs_ckpt_get_i64(h, g, "units", &e->units), done);
    GS_TRY(err, gs_ckpt_get_i64(h, g, "nplan", &nplan), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_regions", &e->stats.regions), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_accepted", &e->stats.accepted), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_failed", &e->stats.failed), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_attempts", &e->stats.attempts), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_choices", &e->stats.choices), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_backtracks", &e->stats.backtracks), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_region_cells", &e->region_cells), done);
    if (e->params.shape || e->keep_tests)
        GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_mh_rejected", &e->stats.mh_rejected), done);
    GS_TRY(err, gs_ckpt_get_f64(h, g, "synthesis_seconds", &e->synth_seconds), done);
    gs_h5_shape ls = model_lattice_shape(&e->lat);
    GS_TRY(err, gs_ckpt_read_whole(h, "/model/lattice", &ls, e->lat.labels), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/model/coverage", &ls, e->coverage), done);
    GS_TRY_CHECK(err, pass >= 0 && pass < e->params.max_passes && color >= 0, GS_ERR_FORMAT, done,
                 "%s: /model pass %lld colour %lld out of range", gs_ckpt_path(h),
                 (long long)pass, (long long)color);
    e->pass = (int)pass;
    e->color = (int)color;
    GS_TRY(err, model_make_plan(e), done);
    GS_TRY_CHECK(err, (int64_t)e->nplan == nplan && e->color < e->ncolors, GS_ERR_FORMAT, done,
                 "%s: pass %d has %zu regions in %d colours here, the checkpoint says %lld "
                 "regions, next colour %d",
                 gs_ckpt_path(h), e->pass, e->nplan, e->ncolors, (long long)nplan, e->color);
    if (e->nplan) {
        gs_h5_shape rs = {GS_H5_I32, 1, {e->nplan}};
        GS_TRY(err, gs_ckpt_read_whole(h, "/model/region_status", &rs, e->region_status), done);
        GS_TRY(err, gs_ckpt_read_whole(h, "/model/region_attempts", &rs, e->region_attempts),
               done);
    }
done:
    gs_ckpt_close(&h);
    return err;
}
