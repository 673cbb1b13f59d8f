/* micro driver, reconstruction rounds and checkpoints: one gs_regions
 * region per instance advances its reconstruction by a slice of steps; the
 * new gs_micro_state travels to every rank (apply) so that rank 0 can write
 * it into RUN_DIR/checkpoint.h5 between rounds. See engine_impl.h.
 *
 * Checkpoint layout (besides /geosynth):
 *   /micro                       attrs units_done, round, instances
 *   /micro/instance-NNNNNN       attrs started, step, seed, input_digest,
 *                                rng_seed, rng_stream, rng_counter, rng_index,
 *                                forced, random_accepted, random_rejected,
 *                                filled, dijkstra_nodes, recon_seconds
 *     placed int64 [2K], value float64 [n], lo float64 [n], hi float64 [n],
 *     label uint16 [n]           (only when started: the core's state) */
#include <stdio.h>
#include <string.h>

#include "geosynth/h5.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "micro/engine_impl.h"

enum { HDR_WORDS = 14 };

int64_t micro_units_done(const micro_job *job)
{
    int64_t u = 0;
    for (int64_t i = 0; i < job->ninst; i++)
        u += job->inst[i].st.ntris ? job->inst[i].st.step : 0;
    return u;
}

int64_t micro_units_total(const micro_job *job)
{
    int64_t u = 0;
    for (int64_t i = 0; i < job->ninst; i++)
        u += 2 * (int64_t)job->inst[i].hist.nbins + 1;
    return u;
}

static size_t packed_size(uint64_t n, uint64_t K)
{
    size_t b = HDR_WORDS * 8 + 2 * K * 8 + 3 * n * 8 + n * 2;
    return (b + 7) & ~(size_t)7;
}

static uint64_t f64_bits(double x)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

static double bits_f64(uint64_t u)
{
    double x;
    memcpy(&x, &u, sizeof x);
    return x;
}

gs_err micro_slice_run(void *ctx, int64_t id, int color, int pass, gs_rng *rng, gs_region_out *out)
{
    (void)color, (void)pass, (void)rng; /* the core keys its own streams by (seed, step) */
    micro_job *job = ctx;
    micro_instance *in = &job->inst[id];
    if (micro_instance_done(in))
        return GS_OK;
    const micro_mesh_in *mi = &job->meshes[in->mesh];
    double t0 = gs_time_now();
    gs_micro_recon_t rec = NULL;
    if (in->st.ntris)
        GS_CALL(gs_micro_recon_resume(&mi->dual, &in->hist, &job->opts, &in->st, &rec));
    else
        GS_CALL(gs_micro_recon_create(&mi->dual, &in->hist, &job->opts, in->seed, &rec));
    int done = 0;
    gs_err err = gs_micro_recon_run(rec, job->steps_per_round, &done);
    if (err) {
        gs_micro_recon_destroy(&rec);
        GS_CALL(err);
    }
    const gs_micro_state *st = gs_micro_recon_state(rec);
    gs_micro_recon_counters c = gs_micro_recon_counters_get(rec);
    uint64_t n = st->ntris, K = st->nbins;
    void *dst = NULL;
    err = gs_region_out_reserve(out, packed_size(n, K), &dst);
    if (!err) {
        uint64_t h[HDR_WORDS] = {st->step,
                                 st->rng.seed,
                                 st->rng.stream,
                                 st->rng.counter,
                                 st->rng.index,
                                 in->cnt.forced + c.forced,
                                 in->cnt.random_accepted + c.random_accepted,
                                 in->cnt.random_rejected + c.random_rejected,
                                 in->cnt.filled + c.filled,
                                 in->cnt.dijkstra_nodes + c.dijkstra_nodes,
                                 n,
                                 K,
                                 f64_bits(in->recon_seconds + gs_time_now() - t0),
                                 st->seed};
        char *p = dst;
        memcpy(p, h, sizeof h), p += sizeof h;
        memcpy(p, st->placed, 2 * K * 8), p += 2 * K * 8;
        memcpy(p, st->value, n * 8), p += n * 8;
        memcpy(p, st->lo, n * 8), p += n * 8;
        memcpy(p, st->hi, n * 8), p += n * 8;
        memcpy(p, st->label, n * 2), p += n * 2;
        memset(p, 0, (size_t)((char *)dst + packed_size(n, K) - p));
    }
    gs_micro_recon_destroy(&rec);
    GS_CALL(err);
    return GS_OK;
}

/* Allocates in->st for the instance's mesh and histogram (if not yet). */
static gs_err state_ensure(micro_job *job, micro_instance *in)
{
    gs_micro_state *st = &in->st;
    if (st->ntris)
        return GS_OK;
    uint32_t n = job->meshes[in->mesh].m.ntris, K = in->hist.nbins;
    gs_micro_state t;
    memset(&t, 0, sizeof t);
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&t.placed, 2 * (size_t)K, sizeof *t.placed, "bin counters"), fail);
    GS_TRY(err, gs_alloc_array((void **)&t.value, n, sizeof *t.value, "triangle values"), fail);
    GS_TRY(err, gs_alloc_array((void **)&t.lo, n, sizeof *t.lo, "triangle ranges"), fail);
    GS_TRY(err, gs_alloc_array((void **)&t.hi, n, sizeof *t.hi, "triangle ranges"), fail);
    GS_TRY(err, gs_alloc_array((void **)&t.label, n, sizeof *t.label, "triangle labels"), fail);
    t.ntris = n;
    t.nbins = K;
    t.seed = in->seed;
    *st = t;
    return GS_OK;
fail:
    gs_micro_state_free(&t);
    return err;
}

gs_err micro_slice_apply(void *ctx, int64_t id, const void *buf, size_t len)
{
    micro_job *job = ctx;
    micro_instance *in = &job->inst[id];
    if (len == 0)
        return GS_OK; /* finished before this round */
    GS_CHECK(len >= HDR_WORDS * 8, GS_ERR_INTERNAL, "instance %lld: %zu result bytes", (long long)id, len);
    uint64_t h[HDR_WORDS];
    memcpy(h, buf, sizeof h);
    uint64_t n = job->meshes[in->mesh].m.ntris, K = in->hist.nbins;
    GS_CHECK(h[10] == n && h[11] == K && len == packed_size(n, K), GS_ERR_INTERNAL,
             "instance %lld: result for %llu triangles / %llu bins in %zu bytes, expected %llu / %llu",
             (long long)id, (unsigned long long)h[10], (unsigned long long)h[11], len,
             (unsigned long long)n, (unsigned long long)K);
    GS_CALL(state_ensure(job, in));
    gs_micro_state *st = &in->st;
    st->step = (uint32_t)h[0];
    st->rng = (gs_rng_state){h[1], h[2], h[3], h[4]};
    st->seed = h[13];
    in->cnt = (gs_micro_recon_counters){h[5], h[6], h[7], h[8], h[9]};
    in->recon_seconds = bits_f64(h[12]);
    const char *p = (const char *)buf + sizeof h;
    memcpy(st->placed, p, 2 * K * 8), p += 2 * K * 8;
    memcpy(st->value, p, n * 8), p += n * 8;
    memcpy(st->lo, p, n * 8), p += n * 8;
    memcpy(st->hi, p, n * 8), p += n * 8;
    memcpy(st->label, p, n * 2);
    return GS_OK;
}

static void group_of(int64_t id, char *out, size_t len)
{
    snprintf(out, len, "/micro/instance-%06lld", (long long)id);
}

static gs_err write_instance(gs_ckpt_t h, const micro_instance *in)
{
    char g[64], path[96];
    group_of(in->id, g, sizeof g);
    const gs_micro_state *st = &in->st;
    int started = st->ntris != 0;
    GS_CALL(gs_ckpt_set_i64(h, g, "started", started));
    GS_CALL(gs_ckpt_set_i64(h, g, "step", started ? st->step : 0));
    GS_CALL(gs_ckpt_set_u64(h, g, "seed", in->seed));
    GS_CALL(gs_ckpt_set_u64(h, g, "input_digest", in->input_digest));
    GS_CALL(gs_ckpt_set_u64(h, g, "rng_seed", st->rng.seed));
    GS_CALL(gs_ckpt_set_u64(h, g, "rng_stream", st->rng.stream));
    GS_CALL(gs_ckpt_set_u64(h, g, "rng_counter", st->rng.counter));
    GS_CALL(gs_ckpt_set_u64(h, g, "rng_index", st->rng.index));
    GS_CALL(gs_ckpt_set_u64(h, g, "forced", in->cnt.forced));
    GS_CALL(gs_ckpt_set_u64(h, g, "random_accepted", in->cnt.random_accepted));
    GS_CALL(gs_ckpt_set_u64(h, g, "random_rejected", in->cnt.random_rejected));
    GS_CALL(gs_ckpt_set_u64(h, g, "filled", in->cnt.filled));
    GS_CALL(gs_ckpt_set_u64(h, g, "dijkstra_nodes", in->cnt.dijkstra_nodes));
    GS_CALL(gs_ckpt_set_f64(h, g, "recon_seconds", in->recon_seconds));
    if (!started)
        return GS_OK;
    uint64_t n = st->ntris, K2 = 2 * (uint64_t)st->nbins;
    gs_h5_shape s_placed = {GS_H5_I64, 1, {K2}}, s_f64 = {GS_H5_F64, 1, {n}},
                s_label = {GS_H5_U16, 1, {n}};
    snprintf(path, sizeof path, "%s/placed", g);
    GS_CALL(gs_ckpt_write_whole(h, path, &s_placed, st->placed, NULL));
    snprintf(path, sizeof path, "%s/value", g);
    GS_CALL(gs_ckpt_write_whole(h, path, &s_f64, st->value, NULL));
    snprintf(path, sizeof path, "%s/lo", g);
    GS_CALL(gs_ckpt_write_whole(h, path, &s_f64, st->lo, NULL));
    snprintf(path, sizeof path, "%s/hi", g);
    GS_CALL(gs_ckpt_write_whole(h, path, &s_f64, st->hi, NULL));
    snprintf(path, sizeof path, "%s/label", g);
    GS_CALL(gs_ckpt_write_whole(h, path, &s_label, st->label, NULL));
    return GS_OK;
}

gs_err micro_ckpt_write(micro_job *job, int64_t units, int64_t round)
{
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_begin(job->run, &h));
    gs_err err = GS_OK;
    GS_TRY(err, gs_ckpt_set_i64(h, "/micro", "units_done", units), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, "/micro", "round", round), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, "/micro", "instances", job->ninst), fail);
    for (int64_t i = 0; i < job->ninst; i++)
        GS_TRY(err, write_instance(h, &job->inst[i]), fail);
    GS_TRY(err, gs_run_checkpoint_commit(job->run, &h, units), fail);
    return GS_OK;
fail:
    gs_ckpt_discard(&h);
    return err;
}

static gs_err read_instance(micro_job *job, gs_ckpt_t h, micro_instance *in)
{
    char g[64], path[96];
    group_of(in->id, g, sizeof g);
    const char *file = gs_ckpt_path(h);
    uint64_t dg = 0;
    int64_t started = 0, step = 0;
    GS_CALL(gs_ckpt_get_u64(h, g, "input_digest", &dg));
    GS_CHECK(dg == in->input_digest, GS_ERR_FORMAT,
             "%s: instance %lld was computed from other inputs (mesh, distribution, seed or "
             "reconstruction options changed since the checkpoint)",
             file, (long long)in->id);
    GS_CALL(gs_ckpt_get_i64(h, g, "started", &started));
    GS_CALL(gs_ckpt_get_i64(h, g, "step", &step));
    GS_CALL(gs_ckpt_get_u64(h, g, "forced", &in->cnt.forced));
    GS_CALL(gs_ckpt_get_u64(h, g, "random_accepted", &in->cnt.random_accepted));
    GS_CALL(gs_ckpt_get_u64(h, g, "random_rejected", &in->cnt.random_rejected));
    GS_CALL(gs_ckpt_get_u64(h, g, "filled", &in->cnt.filled));
    GS_CALL(gs_ckpt_get_u64(h, g, "dijkstra_nodes", &in->cnt.dijkstra_nodes));
    GS_CALL(gs_ckpt_get_f64(h, g, "recon_seconds", &in->recon_seconds));
    if (!started)
        return GS_OK;
    uint32_t K = in->hist.nbins;
    GS_CHECK(step >= 0 && step <= 2 * (int64_t)K + 1, GS_ERR_FORMAT,
             "%s: instance %lld at step %lld: expected [0, %u]", file, (long long)in->id,
             (long long)step, 2 * K + 1);
    GS_CALL(state_ensure(job, in));
    gs_micro_state *st = &in->st;
    GS_CALL(gs_ckpt_get_u64(h, g, "seed", &st->seed));
    GS_CALL(gs_ckpt_get_u64(h, g, "rng_seed", &st->rng.seed));
    GS_CALL(gs_ckpt_get_u64(h, g, "rng_stream", &st->rng.stream));
    GS_CALL(gs_ckpt_get_u64(h, g, "rng_counter", &st->rng.counter));
    GS_CALL(gs_ckpt_get_u64(h, g, "rng_index", &st->rng.index));
    st->step = (uint32_t)step;
    uint64_t n = st->ntris;
    gs_h5_shape s_placed = {GS_H5_I64, 1, {2 * (uint64_t)K}}, s_f64 = {GS_H5_F64, 1, {n}},
                s_label = {GS_H5_U16, 1, {n}};
    snprintf(path, sizeof path, "%s/placed", g);
    GS_CALL(gs_ckpt_read_whole(h, path, &s_placed, st->placed));
    snprintf(path, sizeof path, "%s/value", g);
    GS_CALL(gs_ckpt_read_whole(h, path, &s_f64, st->value));
    snprintf(path, sizeof path, "%s/lo", g);
    GS_CALL(gs_ckpt_read_whole(h, path, &s_f64, st->lo));
    snprintf(path, sizeof path, "%s/hi", g);
    GS_CALL(gs_ckpt_read_whole(h, path, &s_f64, st->hi));
    snprintf(path, sizeof path, "%s/label", g);
    GS_CALL(gs_ckpt_read_whole(h, path, &s_label, st->label));
    for (uint64_t j = 0; j < n; j++) {
        uint16_t l = st->label[j];
        GS_CHECK(l == GS_MICRO_UNASSIGNED || l == GS_MICRO_FILLED || l < 2 * K, GS_ERR_FORMAT,
                 "%s: instance %lld: triangle %llu has label %u: expected < %u", file,
                 (long long)in->id, (unsigned long long)j, l, 2 * K);
    }
    return GS_OK;
}

gs_err micro_ckpt_read(micro_job *job, int64_t *round)
{
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_open(job->run, &h));
    gs_err err = GS_OK;
    int64_t n = 0, r = 0;
    GS_TRY(err, gs_ckpt_get_i64(h, "/micro", "instances", &n), done);
    GS_TRY(err, gs_ckpt_get_i64(h, "/micro", "round", &r), done);
    GS_TRY_CHECK(err, n == job->ninst, GS_ERR_FORMAT, done,
                 "%s holds %lld instances, the config makes %lld", gs_ckpt_path(h), (long long)n,
                 (long long)job->ninst);
    for (int64_t i = 0; i < job->ninst; i++)
        GS_TRY(err, read_instance(job, h, &job->inst[i]), done);
    *round = r;
done:
    gs_ckpt_close(&h);
    return err;
}
