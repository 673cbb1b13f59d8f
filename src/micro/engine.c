/* The micro engine: stochastic microgeometry (Schroeder et al.) as a
 * geosynth subcommand,
 *     mpirun -np N geosynth micro -c configs/micro/X.ini
 * Config keys below (`geosynth micro --help`); the work model, rounds and
 * checkpoint units are described in engine_impl.h, the core in
 * include/geosynth/micro.h.
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

#define DIRECTIONS MICRO_DIRECTIONS
#define FUNCS MICRO_FUNCS

static const gs_cfg_key micro_keys[] = {
    GS_CFG_KEY_ENUM(micro_config, shape, "micro.shape", "file|sphere|disk|bar", "sphere",
                    "input surface: a mesh file (micro.mesh / micro.mesh_list) or a built-in shape "
                    "(sphere = planet, disk, bar = candy bar)"),
    GS_CFG_KEY_PATH(micro_config, mesh, "micro.mesh", "",
                    "triangle mesh (OBJ, PLY, STL, OFF) when micro.shape = file"),
    GS_CFG_KEY_PATH(micro_config, mesh_list, "micro.mesh_list", "",
                    "text file listing several meshes, one path per line (relative to the list), "
                    "instead of micro.mesh"),
    GS_CFG_KEY_REAL(micro_config, radius, "micro.radius", 0, 1e6, GS_CFG_OPEN_LO, "1",
                    "sphere / disk radius in model units"),
    GS_CFG_KEY_REAL_LIST(micro_config, bar_size, "micro.bar_size", 0, 1e6, GS_CFG_OPEN_LO,
                         "4, 2, 0.8", "bar edge lengths x, y, z in model units"),
    GS_CFG_KEY_REAL(micro_config, scale_units, "micro.scale_units", 0, 1e6, GS_CFG_OPEN_LO, "40",
                    "unit ratio u (paper's ScaleUnits): the model is scaled into a box of edge 2 u "
                    "distribution units; larger = finer features"),
    GS_CFG_KEY_REAL(micro_config, max_edge, "micro.max_edge", 0, 1e4, GS_CFG_OPEN_LO, "0.9",
                    "subdivide until every edge is <= this many distribution units (bins are 1 "
                    "unit wide)"),
    GS_CFG_KEY_ENUM(micro_config, dist, "micro.dist", "table|csv|image|random", "table",
                    "contact distributions from micro.table_pos/neg, micro.table_csv, micro.image "
                    "or random from micro.random_*"),
    GS_CFG_KEY_REAL_LIST(micro_config, table_pos, "micro.table_pos", 0, 1, 0,
                         "0.14, 0.085, 0.04, 0.005",
                         "positive region: probability of bins 0, 1, ... (with table_neg summing "
                         "to 1, or each to 1); default: discs, from an image"),
    GS_CFG_KEY_REAL_LIST(micro_config, table_neg, "micro.table_neg", 0, 1, 0,
                         "0.18, 0.14, 0.1, 0.08, 0.07, 0.055, 0.04, 0.027, 0.018, 0.015",
                         "negative region: probability of bins 0, 1, ..."),
    GS_CFG_KEY_PATH(micro_config, table_csv, "micro.table_csv", "",
                    "CSV table 'bin, positive, negative' per line when micro.dist = csv"),
    GS_CFG_KEY_PATH(micro_config, image, "micro.image", "",
                    "PNG/JPEG texture when micro.dist = image: thresholded to white (positive) "
                    "and black (negative)"),
    GS_CFG_KEY_INT(micro_config, image_threshold, "micro.image_threshold", 1, 255, 0, "128",
                   "grey level (0-255) from which a pixel is white"),
    GS_CFG_KEY_BOOL(micro_config, image_invert, "micro.image_invert", "no",
                    "swap white and black before thresholding"),
    GS_CFG_KEY_REAL(micro_config, image_units_per_pixel, "micro.image_units_per_pixel", 0, 1e4,
                    GS_CFG_OPEN_LO, "1", "distribution units per image pixel"),
    GS_CFG_KEY_INT(micro_config, max_bins, "micro.max_bins", 1, 16384, 0, "64",
                   "image acquisition: bins per region (larger distances count in the last bin)"),
    GS_CFG_KEY_INT(micro_config, random_min_bins, "micro.random_min_bins", 1, 16384, 0, "3",
                   "random distribution: fewest bins per region"),
    GS_CFG_KEY_INT(micro_config, random_max_bins, "micro.random_max_bins", 1, 16384, 0, "8",
                   "random distribution: most bins per region"),
    GS_CFG_KEY_REAL(micro_config, random_min_share, "micro.random_min_share", 0, 1, GS_CFG_OPEN_LO,
                    "0.3", "random distribution: smallest area share of the positive region"),
    GS_CFG_KEY_REAL(micro_config, random_max_share, "micro.random_max_share", 0, 1, GS_CFG_OPEN_LO,
                    "0.7", "random distribution: largest area share of the positive region (< 1)"),
    GS_CFG_KEY_BOOL(micro_config, random_per_instance, "micro.random_per_instance", "no",
                    "draw a new random distribution for every instance (else one for the run)"),
    GS_CFG_KEY_ENUM(micro_config, pos_direction, "micro.pos.direction", DIRECTIONS, "out",
                    "positive region: move vertices out, in or not at all"),
    GS_CFG_KEY_REAL(micro_config, pos_scale, "micro.pos.scale", 0, 100, 0, "0.02",
                    "positive region: scale k (offset = k f(|x|) times the half extent)"),
    GS_CFG_KEY_ENUM(micro_config, pos_func, "micro.pos.func", FUNCS, "sqrt",
                    "positive region: function f of the distance value"),
    GS_CFG_KEY_ENUM(micro_config, neg_direction, "micro.neg.direction", DIRECTIONS, "in",
                    "negative region: move vertices out, in or not at all"),
    GS_CFG_KEY_REAL(micro_config, neg_scale, "micro.neg.scale", 0, 100, 0, "0.02",
                    "negative region: scale k"),
    GS_CFG_KEY_ENUM(micro_config, neg_func, "micro.neg.func", FUNCS, "sqrt",
                    "negative region: function f of the distance value"),
    GS_CFG_KEY_BOOL(micro_config, capacity, "micro.capacity", "yes",
                    "accept a random placement only if the bins it forces still fit (no = the "
                    "paper as printed, more unassigned triangles)"),
    GS_CFG_KEY_BOOL(micro_config, correct, "micro.correct", "yes",
                    "correction pass: move the interface until the regions' true distances to it "
                    "(the realized contact distribution) match the target (no = the "
                    "reconstruction's regions as they are)"),
    GS_CFG_KEY_INT(micro_config, correct_rounds, "micro.correct_rounds", 0, 100000, 0, "300",
                   "correction pass: at most this many rounds (one fast march each)"),
    GS_CFG_KEY_REAL(micro_config, correct_target, "micro.correct_target", 0, 2, 0, "0.02",
                    "correction pass: stop once the realized L1/n is at most this"),
    GS_CFG_KEY_INT(micro_config, max_rejects_per_bin, "micro.max_rejects_per_bin", 0,
                   GS_CFG_INT_MAX, 0, "0", "stop a bin after this many rejected placements (0 = "
                   "no limit)"),
    GS_CFG_KEY_INT(micro_config, instances, "micro.instances", 1, 1000000, 0, "1",
                   "instances (seeds) per mesh; each gets RUN_DIR/instance-XXXX/"),
    GS_CFG_KEY_INT(micro_config, steps_per_round, "micro.steps_per_round", 1, 1000000, 0, "8",
                   "reconstruction steps (bins) per instance between checkpoint opportunities"),
    GS_CFG_KEY_INT(micro_config, verify_samples, "micro.verify_samples", 0, 4294967295.0, 0, "200",
                   "triangles whose 2K neighbourhood the verifier checks (0 = all)"),
    GS_CFG_KEY_INT(micro_config, preview, "micro.preview", 0, 4096, 0, "384",
                   "edge in pixels of RUN_DIR/instance-XXXX/preview.png, the displaced mesh in its "
                   "region colours (0 = none)"),
    GS_CFG_KEY_ENUM(micro_config, output_format, "micro.output_format", "ply|obj|both", "ply",
                    "displaced mesh format (PLY carries the vertex label)"),
    GS_CFG_KEY_BOOL(micro_config, explore, "micro.explore.enable", "no",
                    "parameter-space exploration (paper 5.1): instead of micro.instances, produce "
                    "micro.explore.count candidates with random parameters from the ranges below, "
                    "each with a thumbnail and its own config, and RUN_DIR/gallery/index.html"),
    GS_CFG_KEY_INT(micro_config, explore_count, "micro.explore.count", 1, 100000, 0, "12",
                   "gallery: number of candidates N"),
    GS_CFG_KEY_REAL_LIST(micro_config, explore_scale_units, "micro.explore.scale_units", 0, 1e6,
                         GS_CFG_OPEN_LO, "",
                         "gallery: range 'lo, hi' of the unit ratio u (one value: fixed; empty: "
                         "micro.scale_units); cost grows with u^2"),
    GS_CFG_KEY_REAL_LIST(micro_config, explore_pos_scale, "micro.explore.pos_scale", 0, 100, 0,
                         "0.005, 0.05", "gallery: range 'lo, hi' of the positive region's scale k "
                         "(one value: fixed)"),
    GS_CFG_KEY_REAL_LIST(micro_config, explore_neg_scale, "micro.explore.neg_scale", 0, 100, 0,
                         "0.005, 0.05", "gallery: range 'lo, hi' of the negative region's scale k "
                         "(one value: fixed)"),
    GS_CFG_KEY_STRING(micro_config, explore_pos_func, "micro.explore.pos_func",
                      "linear, sqrt, square, cbrt, step",
                      "gallery: functions f the positive region draws from (any of " FUNCS
                      ", comma-separated; one name: fixed)"),
    GS_CFG_KEY_STRING(micro_config, explore_neg_func, "micro.explore.neg_func",
                      "linear, sqrt, square, cbrt, step",
                      "gallery: functions f the negative region draws from"),
    GS_CFG_KEY_STRING(micro_config, explore_pos_direction, "micro.explore.pos_direction",
                      "out, in", "gallery: directions the positive region draws from (any of "
                      DIRECTIONS ", comma-separated; one name: fixed)"),
    GS_CFG_KEY_STRING(micro_config, explore_neg_direction, "micro.explore.neg_direction",
                      "in, out", "gallery: directions the negative region draws from"),
    GS_CFG_KEY_INT(micro_config, explore_thumbnail, "micro.explore.thumbnail", 16, 2048, 0, "256",
                   "gallery: thumbnail edge in pixels (PNG rendered off-screen with OSMesa)"),
    GS_CFG_RUN_KEYS(micro_config, run, "micro"),
};

static int set(const char *s)
{
    return s && s[0];
}

static void micro_validate(const void *vcfg, gs_cfg_ctx *ctx)
{
    const micro_config *c = vcfg;
    int file = !strcmp(c->shape, "file");
    if (file && set(c->mesh) == set(c->mesh_list))
        gs_cfg_report(ctx, set(c->mesh) ? "micro.mesh_list" : "micro.mesh",
                      "micro.shape = file needs exactly one of micro.mesh and micro.mesh_list");
    if (!file && set(c->mesh))
        gs_cfg_report(ctx, "micro.mesh", "is set but micro.shape = %s (use micro.shape = file)",
                      c->shape);
    if (!file && set(c->mesh_list))
        gs_cfg_report(ctx, "micro.mesh_list", "is set but micro.shape = %s (use micro.shape = file)",
                      c->shape);
    if (!strcmp(c->shape, "bar") && c->bar_size.n != 3)
        gs_cfg_report(ctx, "micro.bar_size", "expected 3 sizes (x, y, z), got %lld",
                      (long long)c->bar_size.n);
    if (!strcmp(c->dist, "table")) {
        if (c->table_pos.n + c->table_neg.n == 0) {
            gs_cfg_report(ctx, "micro.table_pos", "micro.dist = table needs micro.table_pos and/or "
                                                  "micro.table_neg");
        } else if (gs_micro_dist_check_sum(c->table_pos.v, (size_t)c->table_pos.n, c->table_neg.v,
                                           (size_t)c->table_neg.n, 0.01,
                                           "micro.table_pos + micro.table_neg") != GS_OK) {
            gs_cfg_report(ctx, "micro.table_pos", "%s", gs_error_message());
            gs_error_clear();
        }
    }
    if ((strcmp(c->dist, "csv") == 0) != set(c->table_csv))
        gs_cfg_report(ctx, "micro.table_csv", set(c->table_csv) ? "is set but micro.dist = %s"
                                                                : "required when micro.dist = csv%s",
                      set(c->table_csv) ? c->dist : "");
    if ((strcmp(c->dist, "image") == 0) != set(c->image))
        gs_cfg_report(ctx, "micro.image", set(c->image) ? "is set but micro.dist = %s"
                                                        : "required when micro.dist = image%s",
                      set(c->image) ? c->dist : "");
    if (c->random_min_bins > c->random_max_bins)
        gs_cfg_report(ctx, "micro.random_max_bins", "must be >= micro.random_min_bins = %lld",
                      (long long)c->random_min_bins);
    if (c->random_min_share > c->random_max_share)
        gs_cfg_report(ctx, "micro.random_max_share", "must be >= micro.random_min_share = %g",
                      c->random_min_share);
    if (c->random_max_share >= 1)
        gs_cfg_report(ctx, "micro.random_max_share", "must be < 1 (both regions need area)");
    if (c->random_per_instance && strcmp(c->dist, "random") != 0)
        gs_cfg_report(ctx, "micro.random_per_instance", "needs micro.dist = random (is %s)",
                      c->dist);
    micro_explore_validate(c, ctx);
}

const gs_cfg_table micro_cfg_table = GS_CFG_TABLE("micro", micro_config, micro_keys, micro_validate);

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

gs_err micro_json_write(gs_json *j, const char *path)
{
    gs_err err = GS_OK;
    if (j->failed) {
        err = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__, "%s: JSON too large", path);
    } else {
        size_t n = j->len;
        j->buf[n] = '\n';
        err = gs_file_write_atomic(path, j->buf, n + 1);
    }
    gs_json_free(j);
    return err;
}

void micro_result_json(gs_json *j, const micro_result *r)
{
    gs_json_u64(j, "triangles", r->ntris);
    gs_json_u64(j, "vertices", r->nverts);
    gs_json_u64(j, "bins_per_region", r->nbins);
    gs_json_u64(j, "violations", r->violations);
    gs_json_u64(j, "pairs_checked", r->pairs_checked);
    gs_json_f64(j, "max_excess", r->max_excess);
    gs_json_u64(j, "unassigned", r->unassigned);
    gs_json_f64(j, "unassigned_share", r->unassigned_share);
    gs_json_i64(j, "abs_bin_error", r->abs_error_sum);
    gs_json_i64(j, "max_bin_error", r->max_bin_error);
    gs_json_f64(j, "bin_error_share", r->error_share);
    gs_json_f64(j, "realized_l1", r->realized_l1);
    gs_json_u64(j, "realized_beyond", r->realized_beyond);
    gs_json_f64(j, "realized_pos_share", r->realized_pos_share);
    gs_json_f64(j, "recon_realized_l1", r->recon_realized_l1);
    gs_json_f64(j, "recon_unassigned_share", r->recon_unassigned_share);
    gs_json_u64(j, "correct_rounds", r->correct_rounds);
    gs_json_u64(j, "correct_flips", r->correct_flips);
    if (r->nbins <= MICRO_RESULT_BINS) {
        gs_json_begin_array(j, "target_count");
        for (uint64_t i = 0; i < 2 * r->nbins; i++)
            gs_json_i64(j, NULL, r->target[i]);
        gs_json_end_array(j);
        gs_json_begin_array(j, "realized_count");
        for (uint64_t i = 0; i < 2 * r->nbins; i++)
            gs_json_i64(j, NULL, r->realized[i]);
        gs_json_end_array(j);
    }
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
        gs_json_begin_array(mj, "target_count");
        for (uint64_t i = 0; i < 2 * r->nbins; i++)
            gs_json_i64(mj, NULL, r->target[i]);
        gs_json_end_array(mj);
        gs_json_begin_array(mj, "realized_count");
        for (uint64_t i = 0; i < 2 * r->nbins; i++)
            gs_json_i64(mj, NULL, r->realized[i]);
        gs_json_end_array(mj);
        gs_json_end_object(mj);
    }
    char path[PATH_MAX];
    gs_run_path(run, "instances.json", path, sizeof path);
    GS_CALL(write_instances_json(job, path));
    gs_run_output(run, "json", "instances", "instances.json", NULL);
    return GS_OK;
}

static gs_err end_phase(gs_run *run, gs_json *j)
{
    gs_json_end_object(j);
    gs_err err = gs_run_phase_end(run, j->failed ? NULL : j->buf);
    gs_json_free(j);
    GS_CALL(err);
    return GS_OK;
}

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

static gs_err micro_run(gs_run *run, void *vcfg, int resume)
{
    const micro_config *cfg = vcfg;
    micro_job job;
    memset(&job, 0, sizeof job);
    job.run = run;
    job.cfg = cfg;
    if (cfg->explore) {
        GS_CHECK(!resume, GS_ERR_ARG, "%s: a gallery run (micro.explore.enable) keeps no "
                 "checkpoint; run it again (each candidate is a short, complete run)", run->dir);
        GS_CALL(micro_explore_run(run, cfg));
        return GS_OK;
    }
    gs_regions_t queue = NULL;
    gs_err err = GS_OK;
    gs_json pj;
    gs_json_init(&pj);
    gs_log(GS_LOG_INFO, "surface: %s%s%s; distribution: %s; u = %g, max edge %g units; %lld "
           "instance%s per mesh",
           cfg->shape, set(cfg->mesh) ? " " : "", set(cfg->mesh) ? cfg->mesh
                                                                : set(cfg->mesh_list) ? cfg->mesh_list : "",
           cfg->dist, cfg->scale_units, cfg->max_edge, (long long)cfg->instances,
           cfg->instances > 1 ? "s" : "");

    gs_run_phase_begin(run, "setup");
    GS_TRY(err, micro_setup(&job), done);
    log_inputs(&job);
    gs_json_begin_object(&pj, NULL);
    gs_json_i64(&pj, "meshes", job.nmeshes);
    gs_json_i64(&pj, "instances", job.ninst);
    gs_json_i64(&pj, "units_total", micro_units_total(&job));
    GS_TRY(err, end_phase(run, &pj), done);

    gs_run_phase_begin(run, "synthesis");
    int64_t round = 0;
    if (resume) {
        GS_TRY(err, micro_ckpt_read(&job, &round), done);
        gs_log(GS_LOG_INFO, "resumed after round %lld: %lld of %lld steps done", (long long)round,
               (long long)micro_units_done(&job), (long long)micro_units_total(&job));
    }
    /* No checkpoint before the first due one (there used to be a small one
     * here, so every finished micro run left checkpoint.h5 behind while the
     * other engines' short runs left none): a run killed before its first
     * checkpoint restarts from start.ini (geosynth resume), like the others. */
    GS_TRY(err, micro_queue_create(run->comm, job.ninst, (uint64_t)cfg->run.seed, MICRO_DOMAIN_QUEUE,
                                   &queue),
           done);
    int64_t units = micro_units_done(&job), total = micro_units_total(&job);
    int64_t rounds_here = 0;
    gs_progress prog;
    gs_progress_begin(&prog, "reconstruction", (uint64_t)total);
    gs_progress_update(&prog, (uint64_t)units);
    while (units < total) {
        GS_TRY(err, gs_regions_run_pass(queue, (int)(round & 0x3fffffff), micro_slice_run,
                                        micro_slice_apply, &job),
               done);
        round++;
        rounds_here++;
        units = micro_units_done(&job);
        gs_progress_update(&prog, (uint64_t)units);
        int stop = 0;
        if (gs_run_checkpoint_due(run, units, &stop))
            GS_TRY(err, micro_ckpt_write(&job, units, round), done);
        if (stop) {
            gs_progress_end(&prog);
            err = gs_run_interrupted(run);
            goto done;
        }
    }
    gs_progress_end(&prog);
    gs_micro_recon_counters tot = {0};
    double recon_s = 0;
    for (int64_t i = 0; i < job.ninst; i++) {
        tot.forced += job.inst[i].cnt.forced;
        tot.random_accepted += job.inst[i].cnt.random_accepted;
        tot.random_rejected += job.inst[i].cnt.random_rejected;
        tot.filled += job.inst[i].cnt.filled;
        recon_s += job.inst[i].recon_seconds;
    }
    gs_regions_stats qs = gs_regions_get_stats(queue);
    gs_json_init(&pj);
    gs_json_begin_object(&pj, NULL);
    gs_json_i64(&pj, "rounds", rounds_here);
    gs_json_i64(&pj, "units", units);
    gs_json_u64(&pj, "forced", tot.forced);
    gs_json_u64(&pj, "random_accepted", tot.random_accepted);
    gs_json_u64(&pj, "random_rejected", tot.random_rejected);
    gs_json_u64(&pj, "filled", tot.filled);
    gs_json_f64(&pj, "recon_cpu_seconds", recon_s);
    gs_json_i64(&pj, "regions_computed_rank0", qs.computed);
    gs_json_f64(&pj, "exchange_seconds_rank0", qs.t_exchange);
    GS_TRY(err, end_phase(run, &pj), done);
    gs_regions_destroy(&queue);

    gs_run_phase_begin(run, "output");
    GS_TRY(err, micro_queue_pass(run->comm, job.ninst, (uint64_t)cfg->run.seed, MICRO_DOMAIN_OUTPUT,
                                 micro_output_run, micro_output_apply, &job),
           done);
    uint64_t *digests = gs_malloc((size_t)job.ninst * sizeof *digests);
    GS_TRY_CHECK(err, digests != NULL, GS_ERR_MEM, done, "instance digests");
    for (int64_t i = 0; i < job.ninst; i++)
        digests[i] = job.inst[i].res.digest;
    uint64_t digest = gs_digest_bytes(digests, (size_t)job.ninst * sizeof *digests);
    gs_free(digests);
    gs_json_init(&pj);
    gs_json_begin_object(&pj, NULL);
    err = report_results(&job, &pj);
    GS_TRY(err, gs_par_agree(run->comm, err), done);
    GS_TRY(err, end_phase(run, &pj), done);
    GS_TRY(err, gs_run_finish(run, digest), done);
done:
    gs_json_free(&pj);
    gs_regions_destroy(&queue);
    micro_job_free(&job);
    return err;
}

const gs_engine gs_engine_micro = {
    "micro",
    "stochastic microgeometry: displace a triangle mesh by labels reconstructed from two contact "
    "distributions (Schroeder et al.)",
    &micro_cfg_table,
    sizeof(micro_config),
    offsetof(micro_config, run),
    micro_run,
};
