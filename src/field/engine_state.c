/* field driver, checkpoints: units done, and RUN_DIR/checkpoint.h5's field
 * group written (collective) and read back (target, mask, provenance,
 * iteration, cursor, match statistics; docs/FORMATS.md). */
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/partition.h"
#include "field/engine_impl.h"

int64_t field_units_done(const gs_field_synth_state *st)
{
    int64_t u = 0;
    for (int i = 0; i < GS_FIELD_MAX_ITER; i++)
        u += st->stat_count[i];
    return u;
}

gs_err field_write_slabs(gs_ckpt_t h, gs_run *run, const char *path, const int64_t n[3],
                         gs_h5_type type, const void *data)
{
    gs_h5_shape sh = {type, 3, {(uint64_t)n[2], (uint64_t)n[1], (uint64_t)n[0]}};
    int64_t start, end;
    GS_CALL(gs_partition(n[2], run->size, run->rank, &start, &end));
    uint64_t count = (uint64_t)(end - start);
    size_t row = (size_t)(n[0] * n[1]) * gs_h5_type_size(type);
    gs_h5_write_opts opts = {4, 0}; /* chunked + deflate, like every output array (#23) */
    GS_CALL(gs_ckpt_write_slab(h, path, &sh, (uint64_t)start, count, (const char *)data + start * row, &opts));
    return GS_OK;
}

gs_err field_write_checkpoint(gs_run *run, match_ctx *ctx, uint64_t src_digest)
{
    const gs_field_synth_state *st = gs_field_synth_get_state(ctx->synth);
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_begin(run, &h));
    gs_err err = GS_OK;
    GS_TRY(err, gs_ckpt_set_i64(h, "/field", "iteration", st->iteration), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, "/field", "cursor", st->cursor), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, "/field", "blocks_in_iteration", st->blocks_in_iteration), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, "/field", "source_digest", src_digest), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, "/field", "units_done", (uint64_t)field_units_done(st)), fail);
    gs_h5_shape s3 = {GS_H5_I64, 1, {3}};
    GS_TRY(err, gs_ckpt_write_whole(h, "/field/tn", &s3, st->tn, NULL), fail);
    gs_h5_shape si = {GS_H5_I64, 1, {GS_FIELD_MAX_ITER}};
    gs_h5_shape sf = {GS_H5_F64, 1, {GS_FIELD_MAX_ITER}};
    gs_h5_shape su = {GS_H5_U64, 1, {GS_FIELD_MAX_ITER}};
    GS_TRY(err, gs_ckpt_write_whole(h, "/field/stat_count", &si, st->stat_count, NULL), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/field/stat_sum", &sf, st->stat_sum, NULL), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/field/stat_min", &sf, st->stat_min, NULL), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/field/stat_max", &sf, st->stat_max, NULL), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/field/stat_pops", &su, st->stat_pops, NULL), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/field/stat_pushes", &su, st->stat_pushes, NULL), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/field/stat_coarse_flips", &su, st->stat_coarse_flips, NULL), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/field/stat_coarse_n", &su, st->stat_coarse_n, NULL), fail);
    GS_TRY(err, field_write_slabs(h, run, "/field/target", st->tn, GS_H5_U8, st->target), fail);
    GS_TRY(err, field_write_slabs(h, run, "/field/mask", st->tn, GS_H5_U8, st->mask), fail);
    GS_TRY(err, field_write_slabs(h, run, "/field/provenance", ctx->target, GS_H5_I32, ctx->prov), fail);
    if (st->matches && st->blocks_in_iteration > 0) {
        gs_h5_shape sm = {GS_H5_I64, 1, {(uint64_t)st->blocks_in_iteration}};
        GS_TRY(err, gs_ckpt_write_whole(h, "/field/matches", &sm, st->matches, NULL), fail);
    }
    GS_CALL(gs_run_checkpoint_commit(run, &h, field_units_done(st)));
    return GS_OK;
fail:
    gs_ckpt_discard(&h);
    return err;
}

gs_err field_read_checkpoint(gs_run *run, const gs_qfield *src, const gs_field_synth_config *sc,
                             match_ctx *ctx, uint64_t src_digest, gs_field_synth_t *out)
{
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_open(run, &h));
    gs_field_synth_state st;
    memset(&st, 0, sizeof st);
    gs_err err = GS_OK;
    int64_t v;
    uint64_t dig;
    GS_TRY(err, gs_ckpt_get_u64(h, "/field", "source_digest", &dig), done);
    GS_TRY_CHECK(err, dig == src_digest, GS_ERR_ARG, done,
                 "%s: the example differs from the one this checkpoint was made from (source "
                 "digest %016llx, now %016llx): was the example file changed?",
                 gs_ckpt_path(h), (unsigned long long)dig, (unsigned long long)src_digest);
    GS_TRY(err, gs_ckpt_get_i64(h, "/field", "iteration", &v), done);
    st.iteration = (int)v;
    GS_TRY(err, gs_ckpt_get_i64(h, "/field", "cursor", &st.cursor), done);
    GS_TRY(err, gs_ckpt_get_i64(h, "/field", "blocks_in_iteration", &st.blocks_in_iteration), done);
    gs_h5_shape s3 = {GS_H5_I64, 1, {3}};
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/tn", &s3, st.tn), done);
    GS_TRY_CHECK(err, st.tn[0] > 0 && st.tn[1] > 0 && st.tn[2] > 0 && st.tn[0] <= 4096 &&
                          st.tn[1] <= 4096 && st.tn[2] <= 4096,
                 GS_ERR_FORMAT, done, "%s: /field/tn holds an impossible target size",
                 gs_ckpt_path(h));
    gs_h5_shape si = {GS_H5_I64, 1, {GS_FIELD_MAX_ITER}};
    gs_h5_shape sf = {GS_H5_F64, 1, {GS_FIELD_MAX_ITER}};
    gs_h5_shape su = {GS_H5_U64, 1, {GS_FIELD_MAX_ITER}};
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/stat_count", &si, st.stat_count), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/stat_sum", &sf, st.stat_sum), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/stat_min", &sf, st.stat_min), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/stat_max", &sf, st.stat_max), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/stat_pops", &su, st.stat_pops), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/stat_pushes", &su, st.stat_pushes), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/stat_coarse_flips", &su, st.stat_coarse_flips), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/stat_coarse_n", &su, st.stat_coarse_n), done);
    size_t n = (size_t)(st.tn[0] * st.tn[1] * st.tn[2]);
    GS_TRY(err, gs_alloc_array((void **)&st.target, n, 1, "checkpoint target"), done);
    GS_TRY(err, gs_alloc_array((void **)&st.mask, n, 1, "checkpoint mask"), done);
    gs_h5_shape sh = {GS_H5_U8, 3, {(uint64_t)st.tn[2], (uint64_t)st.tn[1], (uint64_t)st.tn[0]}};
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/target", &sh, st.target), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/mask", &sh, st.mask), done);
    gs_h5_shape sp = {GS_H5_I32, 3,
                      {(uint64_t)ctx->target[2], (uint64_t)ctx->target[1], (uint64_t)ctx->target[0]}};
    GS_TRY(err, gs_ckpt_read_whole(h, "/field/provenance", &sp, ctx->prov), done);
    if (st.iteration < sc->iterations) {
        GS_TRY_CHECK(err, st.blocks_in_iteration > 0 && st.blocks_in_iteration <= ((int64_t)1 << 32),
                     GS_ERR_FORMAT, done, "%s: /field blocks_in_iteration = %lld is impossible",
                     gs_ckpt_path(h), (long long)st.blocks_in_iteration);
        GS_TRY(err, gs_alloc_array((void **)&st.matches, (size_t)st.blocks_in_iteration,
                                   sizeof *st.matches, "checkpoint matches"), done);
        gs_h5_shape sm = {GS_H5_I64, 1, {(uint64_t)st.blocks_in_iteration}};
        GS_TRY(err, gs_ckpt_read_whole(h, "/field/matches", &sm, st.matches), done);
    }
    GS_TRY(err, gs_field_synth_resume(src, sc, &st, out), done);
done:
    gs_free(st.target);
    gs_free(st.mask);
    gs_free(st.matches);
    gs_ckpt_close(&h);
    return err;
}
