/* points driver, checkpoints: RUN_DIR/checkpoint.h5's /points group (cursor,
 * RNG state, output points, per-patch metrics, the example's digest; see
 * docs/FORMATS.md) written (collective: every rank calls it) and read back. */
#include "geosynth/mem.h"
#include "points/engine_impl.h"

gs_err points_write_checkpoint(gs_run *run, gs_points_synth_t s, uint64_t tex_digest)
{
    gs_points_synth_state st;
    GS_CALL(gs_points_synth_save(s, &st));
    gs_ckpt_t h = NULL;
    double *mf = NULL;
    uint64_t *mu = NULL;
    int64_t *pid = NULL;
    gs_err err = GS_OK;
    uint64_t nm = st.cursor ? st.cursor : 1;
    GS_TRY(err, gs_alloc_array((void **)&mf, nm, 4 * sizeof *mf, "checkpoint metrics"), done);
    GS_TRY(err, gs_alloc_array((void **)&mu, nm, 3 * sizeof *mu, "checkpoint metrics"), done);
    for (uint64_t k = 0; k < st.cursor; k++) {
        const gs_points_patch_metrics *m = &st.metrics[k];
        double f[4] = {m->best_dist, m->chosen_dist, m->pair_gap, m->warp_residual};
        uint64_t u[3] = {m->chosen, m->candidates | (uint64_t)m->continuations << 32,
                         m->pairs | (uint64_t)(m->warp | (uint64_t)m->rank << 2) << 32};
        memcpy(mf + 4 * k, f, sizeof f);
        memcpy(mu + 3 * k, u, sizeof u);
    }
    GS_TRY(err, gs_run_checkpoint_begin(run, &h), done);
    GS_TRY(err, gs_ckpt_set_u64(h, "/points", "cursor", st.cursor), done);
    GS_TRY(err, gs_ckpt_set_u64(h, "/points", "rng_seed", st.rng.seed), done);
    GS_TRY(err, gs_ckpt_set_u64(h, "/points", "rng_stream", st.rng.stream), done);
    GS_TRY(err, gs_ckpt_set_u64(h, "/points", "rng_counter", st.rng.counter), done);
    GS_TRY(err, gs_ckpt_set_u64(h, "/points", "rng_index", st.rng.index), done);
    GS_TRY(err, gs_ckpt_set_u64(h, "/points", "example_digest", tex_digest), done);
    GS_TRY(err, gs_ckpt_set_u64(h, "/points", "output_points", st.out.n), done);
    GS_TRY(err, gs_ckpt_set_u64(h, "/points", "total_patches", gs_points_synth_total(s)), done);
    if (st.out.n > 0) {
        gs_h5_shape sh = {GS_H5_F64, 2, {st.out.n, 6}};
        GS_TRY(err, gs_ckpt_write_whole(h, "/points/output", &sh, st.out.v, NULL), done);
        gs_h5_shape shp = {GS_H5_I64, 1, {st.out.n}};
        GS_TRY(err, gs_alloc_array((void **)&pid, st.out.n, sizeof *pid, "checkpoint"), done);
        for (size_t i = 0; i < st.out.n; i++)
            pid[i] = st.patch[i] == UINT32_MAX ? -1 : (int64_t)st.patch[i];
        GS_TRY(err, gs_ckpt_write_whole(h, "/points/output_patch", &shp, pid, NULL), done);
    }
    if (st.cursor > 0) {
        gs_h5_shape shf = {GS_H5_F64, 2, {st.cursor, 4}};
        gs_h5_shape shu = {GS_H5_U64, 2, {st.cursor, 3}};
        GS_TRY(err, gs_ckpt_write_whole(h, "/points/patch_dist", &shf, mf, NULL), done);
        GS_TRY(err, gs_ckpt_write_whole(h, "/points/patch_index", &shu, mu, NULL), done);
    }
    GS_TRY(err, gs_run_checkpoint_commit(run, &h, (int64_t)st.cursor), done);
done:
    if (h)
        gs_ckpt_discard(&h);
    gs_free(mf);
    gs_free(mu);
    gs_free(pid);
    gs_points_synth_state_free(&st);
    return err;
}

gs_err points_read_checkpoint(gs_run *run, uint64_t tex_digest, gs_points_synth_state *st)
{
    memset(st, 0, sizeof *st);
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_open(run, &h));
    double *mf = NULL;
    int64_t *pid = NULL;
    uint64_t *mu = NULL, saved_digest = 0, npts = 0;
    gs_err err = GS_OK;
    GS_TRY(err, gs_ckpt_get_u64(h, "/points", "cursor", &st->cursor), done);
    GS_TRY(err, gs_ckpt_get_u64(h, "/points", "rng_seed", &st->rng.seed), done);
    GS_TRY(err, gs_ckpt_get_u64(h, "/points", "rng_stream", &st->rng.stream), done);
    GS_TRY(err, gs_ckpt_get_u64(h, "/points", "rng_counter", &st->rng.counter), done);
    GS_TRY(err, gs_ckpt_get_u64(h, "/points", "rng_index", &st->rng.index), done);
    GS_TRY(err, gs_ckpt_get_u64(h, "/points", "example_digest", &saved_digest), done);
    GS_TRY(err, gs_ckpt_get_u64(h, "/points", "output_points", &npts), done);
    GS_TRY_CHECK(err, saved_digest == tex_digest, GS_ERR_ARG, done,
                 "%s: the example changed since this checkpoint was written (digest %016llx, "
                 "now %016llx): restore the input file or start a new run",
                 gs_ckpt_path(h), (unsigned long long)saved_digest,
                 (unsigned long long)tex_digest);
    GS_TRY_CHECK(err, st->rng.index <= 4 && st->cursor < ((uint64_t)1 << 40) &&
                          npts < ((uint64_t)1 << 36), GS_ERR_FORMAT, done,
                 "%s: /points state out of range (cursor %llu, rng index %llu, %llu points)",
                 gs_ckpt_path(h), (unsigned long long)st->cursor,
                 (unsigned long long)st->rng.index, (unsigned long long)npts);
    if (npts > 0) {
        GS_TRY(err, gs_points_reserve(&st->out, npts), done);
        gs_h5_shape sh = {GS_H5_F64, 2, {npts, 6}};
        GS_TRY(err, gs_ckpt_read_whole(h, "/points/output", &sh, st->out.v), done);
        st->out.n = npts;
        gs_h5_shape shp = {GS_H5_I64, 1, {npts}};
        GS_TRY(err, gs_alloc_array((void **)&pid, npts, sizeof *pid, "checkpoint"), done);
        GS_TRY(err, gs_alloc_array((void **)&st->patch, npts, sizeof *st->patch, "checkpoint"),
               done);
        GS_TRY(err, gs_ckpt_read_whole(h, "/points/output_patch", &shp, pid), done);
        for (uint64_t i = 0; i < npts; i++) {
            GS_TRY_CHECK(err, pid[i] >= -1 && pid[i] < (int64_t)st->cursor, GS_ERR_FORMAT, done,
                         "%s: /points/output_patch[%llu] = %lld, expected -1 .. %llu",
                         gs_ckpt_path(h), (unsigned long long)i, (long long)pid[i],
                         (unsigned long long)st->cursor);
            st->patch[i] = pid[i] < 0 ? UINT32_MAX : (uint32_t)pid[i];
        }
    }
    uint64_t nm = st->cursor ? st->cursor : 1;
    GS_TRY(err, gs_alloc_array((void **)&st->metrics, nm, sizeof *st->metrics, "metrics"), done);
    if (st->cursor > 0) {
        GS_TRY(err, gs_alloc_array((void **)&mf, nm, 4 * sizeof *mf, "checkpoint metrics"), done);
        GS_TRY(err, gs_alloc_array((void **)&mu, nm, 3 * sizeof *mu, "checkpoint metrics"), done);
        gs_h5_shape shf = {GS_H5_F64, 2, {st->cursor, 4}};
        gs_h5_shape shu = {GS_H5_U64, 2, {st->cursor, 3}};
        GS_TRY(err, gs_ckpt_read_whole(h, "/points/patch_dist", &shf, mf), done);
        GS_TRY(err, gs_ckpt_read_whole(h, "/points/patch_index", &shu, mu), done);
        for (uint64_t k = 0; k < st->cursor; k++) {
            gs_points_patch_metrics *m = &st->metrics[k];
            m->best_dist = mf[4 * k];
            m->chosen_dist = mf[4 * k + 1];
            m->pair_gap = mf[4 * k + 2];
            m->warp_residual = mf[4 * k + 3];
            m->chosen = mu[3 * k];
            m->candidates = (uint32_t)mu[3 * k + 1];
            m->continuations = (uint32_t)(mu[3 * k + 1] >> 32);
            m->pairs = (uint32_t)mu[3 * k + 2];
            m->warp = (uint32_t)(mu[3 * k + 2] >> 32 & 3);
            m->rank = (uint32_t)(mu[3 * k + 2] >> 34);
        }
    }
done:
    gs_free(mf);
    gs_free(mu);
    gs_free(pid);
    gs_ckpt_close(&h);
    if (err != GS_OK)
        gs_points_synth_state_free(st);
    return err;
}
