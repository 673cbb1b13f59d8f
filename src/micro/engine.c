/* The micro engine: stochastic microgeometry (Schroeder et al.) as a
 * geosynth subcommand,
 *     mpirun -np N geosynth micro -c configs/micro/X.ini
 * This file holds the engine's operations for the run driver
 * (include/geosynth/engine.h, src/run/driver.c, which owns the phases,
 * checkpoint cadence, signals and the summary): set-up, restore, one
 * reconstruction round per advance, save, output. The folder: engine_config.c (keys, `geosynth micro --help`, validation),
 * engine_setup.c (inputs read on rank 0 and broadcast), engine_state.c
 * (reconstruction slices, checkpoints), engine_output.c (the output pass,
 * files, JSON), engine_queue.c (the work queue of every pass),
 * engine_explore.c (the gallery); the work model, rounds and checkpoint
 * units are described in engine_impl.h, the core in include/geosynth/micro.h.
 *
 * Phases: setup (read, subdivide, dual graphs, distribution, histograms),
 * synthesis (reconstruction rounds through the rank-0 work queue,
 * checkpointed between rounds), output (displacement, verifier, files per
 * instance, instances.json). The digest is the digest of the instance
 * digests in instance order, identical for any rank count and across
 * stop/resume. With micro.explore.enable the run is a gallery of random
 * candidates instead (engine_explore.c). */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/digest.h"
#include "geosynth/engine.h"
#include "geosynth/file.h"
#include "geosynth/json.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/regions.h"
#include "micro/engine_impl.h"

static int set(const char *s)
{
    return s && s[0];
}

/* Rank 0: the INPUT SUMMARY of the prepared job, with a memory estimate of
 * what the reconstruction will still allocate on every rank. */
static void log_inputs(const micro_job *job)
{
    const micro_config *c = job->cfg;
    uint64_t tris = 0, state_bytes = 0;
    for (uint32_t i = 0; i < job->nmeshes; i++) {
        const micro_mesh_in *mi = &job->meshes[i];
        gs_log(GS_LOG_INFO,
               "mesh %u: %s: %u -> %u triangles, %u vertices; half extent %g model units, %g "
               "distribution units per model unit; longest edge %.3f units (bound %g), min angle "
               "%.1f deg; %d uniform + %d bisection passes",
               i, mi->source, mi->ntris_in, mi->m.ntris, mi->m.nverts, mi->half_extent, mi->upm,
               mi->max_edge_units, c->max_edge, mi->min_angle_deg, mi->sub.uniform_passes,
               mi->sub.bisect_passes);
    }
    uint32_t kmax = 0;
    for (int64_t i = 0; i < job->ninst; i++) {
        uint64_t n = job->meshes[job->inst[i].mesh].m.ntris;
        tris += n;
        state_bytes += 34 * n + 16 * job->inst[i].hist.nbins;
        kmax = job->inst[i].hist.nbins > kmax ? job->inst[i].hist.nbins : kmax;
    }
    const gs_micro_dist *d = &job->inst[0].dist;
    double sp = 0, sn = 0;
    for (uint32_t k = 0; k < d->nbins; k++)
        sp += d->pos[k], sn += d->neg[k];
    gs_log(GS_LOG_INFO,
           "distribution (%s%s): %u bins per region (instance 0), positive share %.3f, negative "
           "%.3f; up to %u bins",
           c->dist, c->random_per_instance ? ", one per instance" : "", d->nbins,
           sp / (sp + sn), sn / (sp + sn), kmax);
    gs_log(GS_LOG_INFO,
           "%lld instance%s (%lld per mesh), %llu triangles in all; %u steps per round; "
           "reconstruction states ~%.1f MiB on every rank, plus ~%.1f MiB per running instance",
           (long long)job->ninst, job->ninst > 1 ? "s" : "", (long long)c->instances,
           (unsigned long long)tris, job->steps_per_round, (double)state_bytes / 1048576.0,
           (double)(100 * (tris / (uint64_t)job->ninst)) / 1048576.0);
}

static gs_err write_instances_json(const micro_job *job, const char *path)
{
    gs_json j;
    gs_json_init(&j);
    gs_json_begin_array(&j, NULL);
    for (int64_t i = 0; i < job->ninst; i++) {
        const micro_instance *in = &job->inst[i];
        const micro_result *r = &in->res;
        char hex[17], dir[64];
        gs_digest_hex(r->digest, hex);
        micro_instance_dir(i, dir, sizeof dir);
        gs_json_begin_object(&j, NULL);
        gs_json_i64(&j, "instance", i);
        gs_json_str(&j, "dir", dir);
        gs_json_str(&j, "mesh", job->meshes[in->mesh].source);
        gs_json_seed(&j, "seed", in->seed);
        micro_result_json(&j, r);
        gs_json_u64(&j, "forced", in->cnt.forced);
        gs_json_u64(&j, "random_accepted", in->cnt.random_accepted);
        gs_json_u64(&j, "random_rejected", in->cnt.random_rejected);
        gs_json_u64(&j, "filled", in->cnt.filled);
        gs_json_f64(&j, "recon_seconds", in->recon_seconds);
        gs_json_f64(&j, "output_seconds", r->seconds);
        gs_json_str(&j, "digest", hex);
        gs_json_end_object(&j);
    }
    gs_json_end_array(&j);
    return micro_json_write(&j, path);
}

/* Rank 0: per-instance log lines, run metrics, instances.json, outputs. */
static gs_err report_results(micro_job *job, gs_json *phase)
{
    gs_run *run = job->run;
    uint64_t violations = 0, pairs = 0, unassigned = 0, tris = 0;
    double share_max = 0, err_share_max = 0, excess_max = -INFINITY, rl1_max = 0, rl1_sum = 0;
    micro_outline_sum outline;
    micro_outline_init(&outline);
    int64_t bin_err_max = 0, abs_err = 0;
    for (int64_t i = 0; i < job->ninst; i++) {
        const micro_instance *in = &job->inst[i];
        const micro_result *r = &in->res;
        violations += r->violations;
        pairs += r->pairs_checked;
        unassigned += r->unassigned;
        tris += r->ntris;
        abs_err += r->abs_error_sum;
        share_max = fmax(share_max, r->unassigned_share);
        err_share_max = fmax(err_share_max, r->error_share);
        rl1_max = fmax(rl1_max, r->realized_l1);
        rl1_sum += r->realized_l1 * (double)r->ntris;
        excess_max = fmax(excess_max, r->max_excess);
        micro_outline_add(&outline, r);
        bin_err_max = r->max_bin_error > bin_err_max ? r->max_bin_error : bin_err_max;
        char hex[17];
        gs_digest_hex(r->digest, hex);
        gs_log(job->ninst <= 32 || i < 8 ? GS_LOG_INFO : GS_LOG_DEBUG,
               "instance %lld: %llu triangles, K=%llu: violations %llu of %llu pairs checked, "
               "unassigned %.3f%%, bin error %lld (max %lld per bin, %.3f%% of triangles), "
               "realized contact distribution L1/n %.4f against the target, digest %s",
               (long long)i, (unsigned long long)r->ntris, (unsigned long long)r->nbins,
               (unsigned long long)r->violations, (unsigned long long)r->pairs_checked,
               100 * r->unassigned_share, (long long)r->abs_error_sum, (long long)r->max_bin_error,
               100 * r->error_share, r->realized_l1, hex);
        char what[48];
        snprintf(what, sizeof what, "instance %lld", (long long)i);
        micro_result_warn(r, what, job->cfg->correct);
        if (run->rank == 0) {
            char dir[64], rel[128];
            micro_instance_dir(i, dir, sizeof dir);
            const char *fmt = job->cfg->output_format;
            if (strcmp(fmt, "obj") != 0) {
                snprintf(rel, sizeof rel, "%s/mesh.ply", dir);
                gs_run_output(run, "mesh", "instance", rel, NULL);
            }
            if (strcmp(fmt, "ply") != 0) {
                snprintf(rel, sizeof rel, "%s/mesh.obj", dir);
                gs_run_output(run, "mesh", "instance", rel, NULL);
            }
            snprintf(rel, sizeof rel, "%s/mesh.glb", dir);
            gs_run_output(run, "mesh", "instance", rel, NULL);
            snprintf(rel, sizeof rel, "%s/micro.h5", dir);
            gs_run_output(run, "h5", "labels", rel, NULL);
            if (job->thumbnail <= 0 && job->cfg->preview > 0) { /* written by the output pass */
                char full[PATH_MAX];
                snprintf(rel, sizeof rel, "%s/preview.png", dir);
                gs_run_path(run, rel, full, sizeof full);
                if (access(full, F_OK) == 0)
                    gs_run_output(run, "preview", "instance", rel, NULL);
            }
        }
    }
    if (violations)
        gs_log(GS_LOG_WARN, "the verifier found %llu distance-constraint violations (expected 0)",
               (unsigned long long)violations);
    double min_angle = 180, max_edge = 0;
    for (uint32_t i = 0; i < job->nmeshes; i++) {
        min_angle = fmin(min_angle, job->meshes[i].min_angle_deg);
        max_edge = fmax(max_edge, job->meshes[i].max_edge_units);
    }
    gs_json_u64(phase, "violations", violations);
    gs_json_u64(phase, "pairs_checked", pairs);
    gs_json_f64(phase, "unassigned_share_max", share_max);
    gs_json_i64(phase, "max_bin_error", bin_err_max);
    if (run->rank != 0)
        return GS_OK;
    gs_run_metric_i64(run, "instances", job->ninst);
    gs_run_metric_i64(run, "meshes", job->nmeshes);
    gs_run_metric_i64(run, "triangles", (int64_t)tris);
    gs_run_metric_f64(run, "min_angle_deg", min_angle);
    gs_run_metric_f64(run, "max_edge_units", max_edge);
    gs_run_metric_i64(run, "violations", (int64_t)violations);
    gs_run_metric_i64(run, "pairs_checked", (int64_t)pairs);
    gs_run_metric_f64(run, "max_excess", excess_max);
    gs_run_metric_f64(run, "unassigned_share", tris ? (double)unassigned / (double)tris : 0);
    gs_run_metric_f64(run, "unassigned_share_max", share_max);
    gs_run_metric_f64(run, "bin_error_share", tris ? (double)abs_err / (double)tris : 0);
    gs_run_metric_f64(run, "bin_error_share_max", err_share_max);
    gs_run_metric_i64(run, "max_bin_error", bin_err_max);
    /* The realized contact distribution (measured from the regions and the
     * surface, src/measure): L1 / n against the target, triangle-weighted
     * mean and worst instance, and instance 0's histograms (signed axis). */
    gs_run_metric_f64(run, "realized_l1", tris ? rl1_sum / (double)tris : 0);
    gs_run_metric_f64(run, "realized_l1_max", rl1_max);
    micro_outline_metrics(run, &outline);
    if (job->ninst > 0 && job->inst[0].res.nbins <= MICRO_RESULT_BINS) {
        const micro_result *r = &job->inst[0].res;
        gs_json *mj = &run->metrics;
        gs_json_begin_object(mj, "contact");
        gs_json_str(mj, "index", "signed axis: 0 = negative bin K-1 ... K-1 = negative bin 0, "
                                 "K = positive bin 0 ... 2K-1 = positive bin K-1");
        gs_json_u64(mj, "instance", 0);
        gs_json_u64(mj, "bins_per_region", r->nbins);
        gs_json_u64(mj, "triangles", r->ntris);
        gs_json_f64(mj, "realized_l1", r->realized_l1);
        gs_json_f64(mj, "unassigned_share", r->unassigned_share);
        gs_json_u64(mj, "realized_beyond", r->realized_beyond);
        micro_result_counts_json(mj, r);
        gs_json_end_object(mj);
    }
    char path[PATH_MAX];
    gs_run_path(run, "instances.json", path, sizeof path);
    GS_CALL(write_instances_json(job, path));
    gs_run_output(run, "json", "instances", "instances.json", NULL);
    return GS_OK;
}

/* The driver's state (include/geosynth/engine.h): the job, the work queue
 * of the reconstruction rounds and the round counters. */
typedef struct micro_drive {
    micro_job job;
    gs_regions_t queue; /* the rounds' queue, from the first advance to the report */
    int64_t round;      /* rounds done, including before a resume */
    int64_t rounds_here;
} micro_drive;

/* micro.explore.enable: the gallery, a run of many short complete runs
 * without checkpoints (engine_explore.c). */
static gs_err micro_whole(gs_run *run, const void *vcfg, int resume, int *handled)
{
    const micro_config *cfg = vcfg;
    *handled = cfg->explore;
    if (!cfg->explore)
        return GS_OK;
    GS_CHECK(!resume, GS_ERR_ARG, "%s: a gallery run (micro.explore.enable) keeps no "
             "checkpoint; run it again (each candidate is a short, complete run)", run->dir);
    return micro_explore_run(run, cfg);
}

static gs_err micro_setup_op(gs_run *run, const void *vcfg, int resume, void **state,
                             gs_json *phase)
{
    const micro_config *cfg = vcfg;
    micro_drive *d = gs_calloc(1, sizeof *d);
    GS_CHECK(d != NULL, GS_ERR_MEM, "micro: out of memory for the run state");
    *state = d;
    d->job.run = run;
    d->job.cfg = cfg;
    gs_log(GS_LOG_INFO, "surface: %s%s%s; distribution: %s; u = %g, max edge %g units; %lld "
           "instance%s per mesh",
           cfg->shape, set(cfg->mesh) ? " " : "", set(cfg->mesh) ? cfg->mesh
                                                                : set(cfg->mesh_list) ? cfg->mesh_list : "",
           cfg->dist, cfg->scale_units, cfg->max_edge, (long long)cfg->instances,
           cfg->instances > 1 ? "s" : "");
    GS_CALL(micro_setup(&d->job));
    log_inputs(&d->job);
    gs_json_i64(phase, "meshes", d->job.nmeshes);
    gs_json_i64(phase, "instances", d->job.ninst);
    gs_json_i64(phase, "units_total", micro_units_total(&d->job));
    return GS_OK;
}

static gs_err micro_restore(void *state, gs_run *run)
{
    micro_drive *d = state;
    GS_CALL(micro_ckpt_read(&d->job, &d->round));
    gs_log(GS_LOG_INFO, "resumed after round %lld: %lld of %lld steps done", (long long)d->round,
           (long long)micro_units_done(&d->job), (long long)micro_units_total(&d->job));
    return GS_OK;
}

static void micro_units(const void *state, int64_t *done, int64_t *total)
{
    const micro_drive *d = state;
    *done = micro_units_done(&d->job);
    *total = micro_units_total(&d->job);
}

/* One reconstruction round: every unfinished instance advances by up to
 * steps_per_round steps, instances spread over the ranks by the queue. No
 * checkpoint before the first due one (there used to be a small one at the
 * start, so every finished micro run left checkpoint.h5 behind while the
 * other engines' short runs left none): a run killed before its first
 * checkpoint restarts from start.ini (geosynth resume), like the others. */
static gs_err micro_advance(void *state, gs_run *run, int *finished)
{
    micro_drive *d = state;
    *finished = micro_units_done(&d->job) >= micro_units_total(&d->job);
    if (*finished)
        return GS_OK;
    if (!d->queue)
        GS_CALL(micro_queue_create(run->comm, d->job.ninst, (uint64_t)d->job.cfg->run.seed,
                                   MICRO_DOMAIN_QUEUE, &d->queue));
    GS_CALL(gs_regions_run_pass(d->queue, (int)(d->round & 0x3fffffff), micro_slice_run,
                                micro_slice_apply, &d->job));
    d->round++;
    d->rounds_here++;
    *finished = micro_units_done(&d->job) >= micro_units_total(&d->job);
    return GS_OK;
}

static gs_err micro_save(void *state, gs_run *run)
{
    micro_drive *d = state;
    return micro_ckpt_write(&d->job, micro_units_done(&d->job), d->round);
}

static gs_err micro_synthesis_report(void *state, gs_run *run, gs_json *pj)
{
    micro_drive *d = state;
    const micro_job *job = &d->job;
    gs_micro_recon_counters tot = {0};
    double recon_s = 0;
    for (int64_t i = 0; i < job->ninst; i++) {
        tot.forced += job->inst[i].cnt.forced;
        tot.random_accepted += job->inst[i].cnt.random_accepted;
        tot.random_rejected += job->inst[i].cnt.random_rejected;
        tot.filled += job->inst[i].cnt.filled;
        recon_s += job->inst[i].recon_seconds;
    }
    gs_regions_stats qs = {0};
    if (d->queue)
        qs = gs_regions_get_stats(d->queue);
    gs_json_i64(pj, "rounds", d->rounds_here);
    gs_json_i64(pj, "units", micro_units_done(job));
    gs_json_u64(pj, "forced", tot.forced);
    gs_json_u64(pj, "random_accepted", tot.random_accepted);
    gs_json_u64(pj, "random_rejected", tot.random_rejected);
    gs_json_u64(pj, "filled", tot.filled);
    gs_json_f64(pj, "recon_cpu_seconds", recon_s);
    gs_json_i64(pj, "regions_computed_rank0", qs.computed);
    gs_json_f64(pj, "exchange_seconds_rank0", qs.t_exchange);
    gs_regions_destroy(&d->queue);
    return GS_OK;
}

/* The output pass (displacement, verifier, files per instance through the
 * queue), then the reports; the digest is the digest of the instance
 * digests in instance order. */
static gs_err micro_output_op(void *state, gs_run *run, gs_json *pj, uint64_t *digest)
{
    micro_drive *d = state;
    micro_job *job = &d->job;
    GS_CALL(micro_queue_pass(run->comm, job->ninst, (uint64_t)job->cfg->run.seed,
                             MICRO_DOMAIN_OUTPUT, micro_output_run, micro_output_apply, job));
    uint64_t *digests = gs_malloc((size_t)job->ninst * sizeof *digests);
    GS_CHECK(digests != NULL, GS_ERR_MEM, "instance digests");
    for (int64_t i = 0; i < job->ninst; i++)
        digests[i] = job->inst[i].res.digest;
    *digest = gs_digest_bytes(digests, (size_t)job->ninst * sizeof *digests);
    gs_free(digests);
    return report_results(job, pj);
}

static void micro_destroy(void *state)
{
    micro_drive *d = state;
    if (!d)
        return;
    gs_regions_destroy(&d->queue);
    micro_job_free(&d->job);
    gs_free(d);
}

static const gs_engine_ops micro_ops = {
    .whole = micro_whole,
    .setup = micro_setup_op,
    .restore = micro_restore,
    .units = micro_units,
    .advance = micro_advance,
    .save = micro_save,
    .synthesis_report = micro_synthesis_report,
    .output = micro_output_op,
    .destroy = micro_destroy,
};

const gs_engine gs_engine_micro = {
    "micro",
    "stochastic microgeometry: displace a triangle mesh by labels reconstructed from two contact "
    "distributions (Schroeder et al.)",
    &micro_cfg_table,
    sizeof(micro_config),
    offsetof(micro_config, run),
    &micro_ops,
};
