/* micro driver, gallery: the paper's parameter-space exploration (5.1).
 *
 * micro.explore.enable = yes turns a micro run into a gallery of
 * micro.explore.count candidates. Candidate i draws, from the Philox stream
 * keyed by (run.seed, MICRO_DOMAIN_EXPLORE, i) and in this order: its own
 * run.seed, the unit ratio u, the scales k, functions f and directions of
 * the positive and then the negative region, each from its
 * micro.explore.* range or choice list. With micro.dist = random the
 * candidate's own run.seed also draws its distribution from the
 * micro.random_* ranges (the engine's random mode, unchanged). Nothing
 * depends on the rank, so the gallery is identical for any rank count.
 *
 * A candidate's config is the run's resolved config with those values as
 * overrides (parsed by the config table like any file, so it is exactly what
 * `geosynth micro -c` reads) and micro.explore.enable = no. It is produced by
 * the ordinary engine code as a one-instance job on MPI_COMM_SELF: setup,
 * one reconstruction slice to the end, the output pass (plus thumb.png).
 * Running the candidate's .ini alone therefore gives the same instance
 * digest. Candidates are spread over ranks by the rank-0 work queue
 * (gs_regions, one region per candidate); each result travels to every rank.
 *
 * Files, in RUN_DIR/gallery/:
 *   index.html                 grid of cards: thumbnail, parameters, digest,
 *                              the config text and a link to the .ini
 *                              (self-contained: inline CSS and script,
 *                              relative links only)
 *   candidates.json            per candidate: parameters, checks, digest
 *   candidate-XXX/             candidate-XXX.ini, mesh.ply (mesh.obj),
 *                              mesh.glb, micro.h5, thumb.png
 * The run digest (summary.json) is the digest of the candidate digests in
 * candidate order. Gallery runs write no checkpoint: each candidate is a
 * short complete run, and a gallery is rerun rather than resumed. */
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/digest.h"
#include "geosynth/file.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "micro/engine_impl.h"

/* --------------------------------------------------------- sampling -- */

/* One candidate's drawn parameters (fixed layout: travels as bytes). */
typedef struct micro_candidate {
    int64_t id;
    uint64_t seed;        /* the candidate's run.seed */
    double scale_units;   /* u */
    double scale[2];      /* k, positive and negative region */
    int32_t func[2];      /* index into MICRO_FUNCS */
    int32_t direction[2]; /* index into MICRO_DIRECTIONS */
} micro_candidate;

/* A value from a range (lo, hi), a fixed value, or the base when empty. One
 * draw in every case, so making one range fixed does not shift the others. */
static double draw_range(gs_rng *r, const gs_cfg_real_list *l, double base)
{
    double u = gs_rng_uniform(r);
    if (l->n == 0)
        return base;
    if (l->n == 1 || l->v[1] == l->v[0])
        return l->v[0];
    return l->v[0] + (l->v[1] - l->v[0]) * u;
}

static int32_t draw_choice(gs_rng *r, const char *list, const char *names)
{
    int idx[MICRO_CHOICES_MAX];
    char bad[64];
    int n = micro_choice_list(list, names, idx, bad, sizeof bad);
    uint64_t k = gs_rng_below(r, n > 0 ? (uint64_t)n : 1);
    return n > 0 ? idx[k] : 0; /* n > 0 after validation */
}

static void sample_candidate(const micro_config *cfg, int64_t id, micro_candidate *c)
{
    gs_rng r;
    gs_rng_init(&r, (uint64_t)cfg->run.seed, gs_rng_stream_id(MICRO_DOMAIN_EXPLORE, (uint64_t)id, 0, 0));
    memset(c, 0, sizeof *c);
    c->id = id;
    c->seed = gs_rng_below(&r, 1000000000u) + 1;
    c->scale_units = draw_range(&r, &cfg->explore_scale_units, cfg->scale_units);
    c->scale[0] = draw_range(&r, &cfg->explore_pos_scale, cfg->pos_scale);
    c->func[0] = draw_choice(&r, cfg->explore_pos_func, MICRO_FUNCS);
    c->direction[0] = draw_choice(&r, cfg->explore_pos_direction, MICRO_DIRECTIONS);
    c->scale[1] = draw_range(&r, &cfg->explore_neg_scale, cfg->neg_scale);
    c->func[1] = draw_choice(&r, cfg->explore_neg_func, MICRO_FUNCS);
    c->direction[1] = draw_choice(&r, cfg->explore_neg_direction, MICRO_DIRECTIONS);
}

static void candidate_name(int64_t id, char *out, size_t len)
{
    snprintf(out, len, "candidate-%03lld", (long long)id);
}

/* ------------------------------------------------ candidate configs -- */

typedef struct explore_job {
    gs_run *run;
    const micro_config *cfg;
    char gallery[PATH_MAX];
    struct explore_result *res; /* [count], filled by apply on every rank */
} explore_job;

/* What a candidate reports (fixed layout: travels as bytes). */
typedef struct explore_result {
    micro_candidate c;
    micro_result res;
    uint64_t ntris_in;
    double pos_share;    /* area share of the positive region */
    double recon_seconds, seconds;
} explore_result;

/* The candidate's config: the gallery's resolved config with the drawn
 * values as overrides, parsed by the table (so every check applies), into
 * *cc and its resolved text *body (gs_malloc'ed). */
static gs_err candidate_config(const explore_job *ej, const micro_candidate *c, const char *dir,
                               micro_config *cc, char **body)
{
    enum { NOV = 10 };
    char ov[NOV][PATH_MAX + 80], f[2][16], d[2][16];
    for (int s = 0; s < 2; s++) {
        micro_choice_name(MICRO_FUNCS, c->func[s], f[s], sizeof f[s]);
        micro_choice_name(MICRO_DIRECTIONS, c->direction[s], d[s], sizeof d[s]);
    }
    snprintf(ov[0], sizeof ov[0], "micro.explore.enable=no");
    snprintf(ov[1], sizeof ov[1], "micro.scale_units=%.17g", c->scale_units);
    snprintf(ov[2], sizeof ov[2], "micro.pos.scale=%.17g", c->scale[0]);
    snprintf(ov[3], sizeof ov[3], "micro.pos.func=%s", f[0]);
    snprintf(ov[4], sizeof ov[4], "micro.pos.direction=%s", d[0]);
    snprintf(ov[5], sizeof ov[5], "micro.neg.scale=%.17g", c->scale[1]);
    snprintf(ov[6], sizeof ov[6], "micro.neg.func=%s", f[1]);
    snprintf(ov[7], sizeof ov[7], "micro.neg.direction=%s", d[1]);
    snprintf(ov[8], sizeof ov[8], "run.seed=%llu", (unsigned long long)c->seed);
    snprintf(ov[9], sizeof ov[9], "run.output=%s/rerun", dir);
    const char *ovp[NOV];
    for (int i = 0; i < NOV; i++)
        ovp[i] = ov[i];
    gs_cfg_problems pr = GS_CFG_PROBLEMS_INIT;
    const char *text = ej->run->config_text;
    gs_err err = gs_config_parse_text(&micro_cfg_table, text, strlen(text), "<gallery config>",
                                      NULL, ovp, NOV, cc, &pr);
    if (err) {
        /* The ranges share the keys' bounds, so this is a geosynth bug. */
        err = gs_error_raise(GS_ERR_INTERNAL, __FILE__, __LINE__, __func__,
                             "candidate %lld: its config does not parse: %s", (long long)c->id,
                             pr.nkept ? pr.msg[0] : "?");
        gs_cfg_problems_free(&pr);
        return err;
    }
    GS_CALL(gs_config_resolved_text(&micro_cfg_table, cc, body));
    return GS_OK;
}

static gs_err write_candidate_ini(const explore_job *ej, const micro_candidate *c,
                                  const char *path, const char *body)
{
    char f[2][16], d[2][16];
    for (int s = 0; s < 2; s++) {
        micro_choice_name(MICRO_FUNCS, c->func[s], f[s], sizeof f[s]);
        micro_choice_name(MICRO_DIRECTIONS, c->direction[s], d[s], sizeof d[s]);
    }
    char head[1024];
    int n = snprintf(head, sizeof head,
                     "# geosynth micro gallery: candidate %lld of %lld (gallery run.seed %lld).\n"
                     "# The exact config of this candidate; this reproduces its mesh (the same\n"
                     "# digest as in ../candidates.json):\n"
                     "#   geosynth micro -c candidate-%03lld.ini [-o DIR]\n"
                     "# Drawn: u = %.6g; positive k = %.6g, f = %s, %s; negative k = %.6g, "
                     "f = %s, %s; run.seed = %llu\n",
                     (long long)c->id, (long long)ej->cfg->explore_count,
                     (long long)ej->cfg->run.seed, (long long)c->id, c->scale_units, c->scale[0],
                     f[0], d[0], c->scale[1], f[1], d[1], (unsigned long long)c->seed);
    size_t hl = (size_t)n < sizeof head ? (size_t)n : sizeof head - 1, bl = strlen(body);
    char *all = gs_malloc(hl + bl + 1);
    GS_CHECK(all, GS_ERR_MEM, "candidate config text");
    memcpy(all, head, hl);
    memcpy(all + hl, body, bl + 1);
    gs_err err = gs_file_write_atomic(path, all, hl + bl);
    gs_free(all);
    GS_CALL(err);
    return GS_OK;
}

/* gs_regions run callback: one whole candidate on this rank. */
static gs_err candidate_run(void *ctx, int64_t id, int color, int pass, gs_rng *rng,
                            gs_region_out *out)
{
    (void)color, (void)pass, (void)rng; /* parameters come from sample_candidate's stream */
    explore_job *ej = ctx;
    double t0 = gs_time_now();
    explore_result r;
    memset(&r, 0, sizeof r);
    sample_candidate(ej->cfg, id, &r.c);
    char name[32], dir[PATH_MAX + 40], path[PATH_MAX + 120];
    candidate_name(id, name, sizeof name);
    snprintf(dir, sizeof dir, "%s/%s", ej->gallery, name);
    snprintf(path, sizeof path, "%s/%s.ini", dir, name);
    micro_config cc;
    memset(&cc, 0, sizeof cc);
    char *body = NULL;
    micro_job job;
    memset(&job, 0, sizeof job);
    gs_run sub;
    memset(&sub, 0, sizeof sub);
    gs_err err = GS_OK;
    GS_TRY(err, gs_mkdir_p(dir), done);
    GS_TRY(err, candidate_config(ej, &r.c, dir, &cc, &body), done);
    GS_TRY(err, write_candidate_ini(ej, &r.c, path, body), done);
    /* A one-rank run of the candidate's config, writing into its directory. */
    sub.comm = MPI_COMM_SELF;
    sub.rank = 0;
    sub.size = 1;
    sub.dir = dir;
    snprintf(sub.engine, sizeof sub.engine, "micro");
    sub.config_text = body;
    sub.seed = (uint64_t)cc.run.seed;
    sub.open_phase = -1;
    job.run = &sub;
    job.cfg = &cc;
    job.flat_output = 1;
    job.thumbnail = (int)ej->cfg->explore_thumbnail;
    GS_TRY(err, micro_setup(&job), done);
    job.steps_per_round = 0; /* one slice to the end: nothing to checkpoint between */
    GS_TRY(err, micro_queue_pass(MPI_COMM_SELF, job.ninst, (uint64_t)cc.run.seed, MICRO_DOMAIN_QUEUE,
                                 micro_slice_run, micro_slice_apply, &job),
           done);
    GS_TRY(err, micro_queue_pass(MPI_COMM_SELF, job.ninst, (uint64_t)cc.run.seed,
                                 MICRO_DOMAIN_OUTPUT, micro_output_run, micro_output_apply, &job),
           done);
    const micro_instance *in = &job.inst[0];
    r.res = in->res;
    r.ntris_in = job.meshes[in->mesh].ntris_in;
    double sp = 0, sn = 0;
    for (uint32_t k = 0; k < in->dist.nbins; k++)
        sp += in->dist.pos[k], sn += in->dist.neg[k];
    r.pos_share = sp + sn > 0 ? sp / (sp + sn) : 0;
    r.recon_seconds = in->recon_seconds;
    r.seconds = gs_time_now() - t0;
    GS_TRY(err, gs_region_out_append(out, &r, sizeof r), done);
done:
    if (err) {
        gs_error_add_context("gallery candidate %lld (%s)", (long long)id, path);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    }
    micro_job_free(&job);
    gs_config_free(&micro_cfg_table, &cc);
    gs_free(body);
    return err;
}

static gs_err candidate_apply(void *ctx, int64_t id, const void *buf, size_t len)
{
    explore_job *ej = ctx;
    GS_CHECK(len == sizeof(explore_result), GS_ERR_INTERNAL, "candidate %lld: %zu result bytes",
             (long long)id, len);
    memcpy(&ej->res[id], buf, sizeof(explore_result));
    return GS_OK;
}

/* ------------------------------------------------------------ pages -- */

static const char PAGE_STYLE[] =
    "body{font:14px/1.4 system-ui,sans-serif;margin:1.5em;background:#f4f4f2;color:#222}"
    "h1{font-size:1.4em;margin:0 0 .3em}p.run{color:#555;margin:0 0 1em}"
    ".grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(270px,1fr));gap:14px}"
    ".card{background:#fff;border:1px solid #ddd;border-radius:6px;padding:8px}"
    ".card img{width:100%;height:auto;display:block;border-radius:4px;background:#262a34}"
    ".card h2{font-size:1.05em;margin:.4em 0 .2em}"
    "table.params{border-collapse:collapse;width:100%;font-size:12.5px}"
    "table.params th{text-align:left;font-weight:normal;color:#666;padding:1px 6px 1px 0}"
    "table.params td{font-family:ui-monospace,monospace;padding:1px 0}"
    "p.files{margin:.3em 0 0;font-size:12.5px}details{margin-top:.2em}pre{font-size:11px;max-height:22em;overflow:auto;background:#f7f7f7;"
    "padding:6px;border:1px solid #eee}code{font-size:12px}";

/* Counts the thumbnails that loaded into body data-loaded / data-failed (the
 * page test reads them from the DOM). */
static const char PAGE_SCRIPT[] =
    "function gsCount(){var im=document.querySelectorAll('.card img'),ok=0,bad=0;"
    "for(var i=0;i<im.length;i++){if(im[i].complete&&im[i].naturalWidth>0)ok++;"
    "else if(im[i].complete)bad++;}"
    "document.body.setAttribute('data-loaded',ok);document.body.setAttribute('data-failed',bad);}"
    "window.addEventListener('load',gsCount);";

static void html_param(FILE *f, const char *name, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static void html_param(FILE *f, const char *name, const char *fmt, ...)
{
    char v[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(v, sizeof v, fmt, ap);
    va_end(ap);
    fprintf(f, "<tr><th>%s</th><td>", name);
    gs_fput_markup(f, v, 1);
    fputs("</td></tr>\n", f);
}

/* Target (grey outline) and realized (filled: negative blue, positive sand)
 * contact histograms of a candidate as an inline SVG, signed axis left to
 * right (most negative bin first), each bar's height relative to the
 * largest count of either. */
static void html_contact_svg(FILE *f, const micro_result *r)
{
    uint64_t nb = 2 * r->nbins;
    if (r->nbins == 0 || r->nbins > MICRO_RESULT_BINS)
        return;
    int64_t top = 1;
    for (uint64_t i = 0; i < nb; i++) {
        top = r->target[i] > top ? r->target[i] : top;
        top = r->realized[i] > top ? r->realized[i] : top;
    }
    const double W = 250, H = 60, bw = W / (double)nb;
    fprintf(f, "<svg class=\"contact\" width=\"%.0f\" height=\"%.0f\" viewBox=\"0 0 %.0f %.0f\" "
               "role=\"img\"><title>contact histogram, signed axis: realized (filled) against the "
               "target (outline)</title>\n",
            W, H + 2, W, H + 2);
    for (uint64_t i = 0; i < nb; i++) {
        double hr = H * (double)r->realized[i] / (double)top, ht = H * (double)r->target[i] / (double)top;
        fprintf(f, "<rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" fill=\"%s\"/>",
                (double)i * bw + 0.5, H + 1 - hr, bw - 1, hr, i < r->nbins ? "#6896d6" : "#e8b270");
        fprintf(f, "<rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" fill=\"none\" "
                   "stroke=\"#333\" stroke-width=\"1\"/>\n",
                (double)i * bw + 0.5, H + 1 - ht, bw - 1, ht);
    }
    fputs("</svg>\n", f);
}

static gs_err write_index_html(const explore_job *ej, uint64_t digest, const char *path)
{
    const micro_config *cfg = ej->cfg;
    int64_t n = cfg->explore_count;
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    GS_CHECK(f, GS_ERR_MEM, "gallery page buffer");
    char hex[17];
    gs_digest_hex(digest, hex);
    fprintf(f, "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
               "<title>geosynth micro gallery: %lld candidates</title>\n<style>%s</style>\n"
               "</head>\n<body data-candidates=\"%lld\" data-loaded=\"0\" data-failed=\"0\">\n",
            (long long)n, PAGE_STYLE, (long long)n);
    fprintf(f, "<h1>Stochastic microgeometry: %lld candidates</h1>\n<p class=\"run\">", (long long)n);
    fputs("surface ", f);
    gs_fput_markup(f, !strcmp(cfg->shape, "file") ? cfg->mesh : cfg->shape, 1);
    fprintf(f, ", distribution %s, gallery seed %lld, digest <code>%s</code>. Each card: the "
               "drawn parameters and the config that reproduces it "
               "(<code>geosynth micro -c candidate-XXX/candidate-XXX.ini</code>).</p>\n"
               "<div class=\"grid\">\n",
            cfg->dist, (long long)cfg->run.seed, hex);
    for (int64_t i = 0; i < n; i++) {
        const explore_result *r = &ej->res[i];
        const micro_candidate *c = &r->c;
        char name[32], fn[2][16], dn[2][16], dh[17];
        candidate_name(i, name, sizeof name);
        for (int s = 0; s < 2; s++) {
            micro_choice_name(MICRO_FUNCS, c->func[s], fn[s], sizeof fn[s]);
            micro_choice_name(MICRO_DIRECTIONS, c->direction[s], dn[s], sizeof dn[s]);
        }
        gs_digest_hex(r->res.digest, dh);
        fprintf(f, "<div class=\"card\" id=\"%s\" data-digest=\"%s\">\n"
                   "<a href=\"%s/thumb.png\"><img src=\"%s/thumb.png\" width=\"%lld\" "
                   "height=\"%lld\" alt=\"%s\"></a>\n<h2>candidate %lld</h2>\n"
                   "<table class=\"params\">\n",
                name, dh, name, name, (long long)cfg->explore_thumbnail,
                (long long)cfg->explore_thumbnail, name, (long long)i);
        html_param(f, "unit ratio u", "%.4g", c->scale_units);
        html_param(f, "positive k, f, dir", "%.4g, %s, %s", c->scale[0], fn[0], dn[0]);
        html_param(f, "negative k, f, dir", "%.4g, %s, %s", c->scale[1], fn[1], dn[1]);
        html_param(f, "distribution", "K = %llu bins, positive share %.3f",
                   (unsigned long long)r->res.nbins, r->pos_share);
        html_param(f, "run.seed", "%llu", (unsigned long long)c->seed);
        html_param(f, "triangles", "%llu", (unsigned long long)r->res.ntris);
        html_param(f, "unassigned", "%.3f%%", 100 * r->res.unassigned_share);
        html_param(f, "realized L1/n", "%.4f (true distance to the interface vs target)",
                   r->res.realized_l1);
        html_param(f, "violations", "%llu", (unsigned long long)r->res.violations);
        html_param(f, "digest", "%s", dh);
        const char *mesh = strcmp(cfg->output_format, "obj") ? "mesh.ply" : "mesh.obj";
        fputs("</table>\n", f);
        html_contact_svg(f, &r->res);
        fprintf(f, "<p class=\"files\">files: <a href=\"%s/%s\">%s</a> &middot; "
                   "<a href=\"%s/micro.h5\">micro.h5</a></p>\n"
                   "<details><summary>config (<a href=\"%s/%s.ini\">%s.ini</a>)</summary><pre>",
                name, mesh, mesh, name, name, name, name);
        /* Rank 0 rebuilds the text from the drawn values: the same pure
         * function the candidate's rank wrote its .ini with. */
        micro_config cc;
        memset(&cc, 0, sizeof cc);
        char dir[PATH_MAX + 40], *body = NULL;
        snprintf(dir, sizeof dir, "%s/%s", ej->gallery, name);
        gs_err err = candidate_config(ej, c, dir, &cc, &body);
        gs_config_free(&micro_cfg_table, &cc);
        if (err) {
            fclose(f);
            free(buf); /* open_memstream's buffer is malloc'ed */
            gs_free(body);
            GS_CALL(err);
        }
        gs_fput_markup(f, body, 1);
        gs_free(body);
        fputs("</pre></details>\n</div>\n", f);
    }
    fprintf(f, "</div>\n<script>%s</script>\n</body></html>\n", PAGE_SCRIPT);
    int bad = ferror(f);
    fclose(f);
    gs_err err = GS_OK;
    if (bad)
        err = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__, "%s: page too large", path);
    else
        err = gs_file_write_atomic(path, buf, len);
    free(buf);
    GS_CALL(err);
    return GS_OK;
}

static gs_err write_candidates_json(const explore_job *ej, const char *path)
{
    gs_json j;
    gs_json_init(&j);
    gs_json_begin_array(&j, NULL);
    for (int64_t i = 0; i < ej->cfg->explore_count; i++) {
        const explore_result *r = &ej->res[i];
        char name[32], s[16], hex[17];
        candidate_name(i, name, sizeof name);
        gs_digest_hex(r->res.digest, hex);
        gs_json_begin_object(&j, NULL);
        gs_json_i64(&j, "candidate", i);
        gs_json_str(&j, "dir", name);
        gs_json_seed(&j, "seed", r->c.seed);
        gs_json_f64(&j, "scale_units", r->c.scale_units);
        static const char *side[2] = {"pos", "neg"};
        for (int k = 0; k < 2; k++) {
            char key[32];
            snprintf(key, sizeof key, "%s_scale", side[k]);
            gs_json_f64(&j, key, r->c.scale[k]);
            snprintf(key, sizeof key, "%s_func", side[k]);
            micro_choice_name(MICRO_FUNCS, r->c.func[k], s, sizeof s);
            gs_json_str(&j, key, s);
            snprintf(key, sizeof key, "%s_direction", side[k]);
            micro_choice_name(MICRO_DIRECTIONS, r->c.direction[k], s, sizeof s);
            gs_json_str(&j, key, s);
        }
        gs_json_f64(&j, "positive_share", r->pos_share);
        gs_json_u64(&j, "input_triangles", r->ntris_in);
        micro_result_json(&j, &r->res);
        gs_json_f64(&j, "recon_seconds", r->recon_seconds);
        gs_json_f64(&j, "seconds", r->seconds);
        gs_json_str(&j, "digest", hex);
        gs_json_end_object(&j);
    }
    gs_json_end_array(&j);
    GS_CALL(micro_json_write(&j, path));
    return GS_OK;
}

/* ------------------------------------------------------------- run -- */

gs_err micro_explore_run(gs_run *run, const micro_config *cfg)
{
    int64_t n = cfg->explore_count;
    explore_job ej;
    memset(&ej, 0, sizeof ej);
    ej.run = run;
    ej.cfg = cfg;
    gs_run_path(run, "gallery", ej.gallery, sizeof ej.gallery);
    gs_log(GS_LOG_INFO, "gallery: %lld candidates of %s%s%s, distribution %s, thumbnails %lld px, "
           "into %s",
           (long long)n, cfg->shape, !strcmp(cfg->shape, "file") ? " " : "",
           !strcmp(cfg->shape, "file") ? cfg->mesh : "", cfg->dist,
           (long long)cfg->explore_thumbnail, ej.gallery);
    gs_err err = GS_OK;
    if (run->rank == 0)
        err = gs_mkdir_p(ej.gallery);
    GS_CALL(gs_par_agree(run->comm, err));
    GS_CALL(gs_alloc_array((void **)&ej.res, (size_t)n, sizeof *ej.res, "gallery results"));

    gs_run_phase_begin(run, "gallery");
    double t0 = gs_time_now();
    GS_TRY(err, micro_queue_pass(run->comm, n, (uint64_t)cfg->run.seed, MICRO_DOMAIN_GALLERY,
                                 candidate_run, candidate_apply, &ej),
           done);
    double wall = gs_time_now() - t0;
    uint64_t *digests = NULL;
    GS_TRY(err, gs_alloc_array((void **)&digests, (size_t)n, sizeof *digests, "digests"), done);
    uint64_t violations = 0, tris = 0;
    double unassigned_max = 0, cpu = 0, rl1_max = 0, rl1_sum = 0;
    micro_outline_sum outline;
    micro_outline_init(&outline);
    for (int64_t i = 0; i < n; i++) {
        const explore_result *r = &ej.res[i];
        micro_outline_add(&outline, &r->res);
        rl1_max = fmax(rl1_max, r->res.realized_l1);
        rl1_sum += r->res.realized_l1 * (double)r->res.ntris;
        digests[i] = r->res.digest;
        violations += r->res.violations;
        tris += r->res.ntris;
        unassigned_max = fmax(unassigned_max, r->res.unassigned_share);
        cpu += r->seconds;
        char hex[17];
        gs_digest_hex(r->res.digest, hex);
        gs_log(n <= 32 || i < 8 ? GS_LOG_INFO : GS_LOG_DEBUG,
               "candidate %lld: u %.4g, k %.4g / %.4g, %llu triangles, K=%llu, unassigned %.3f%%, "
               "realized L1/n %.4f, violations %llu, %.2f s, digest %s",
               (long long)i, r->c.scale_units, r->c.scale[0], r->c.scale[1],
               (unsigned long long)r->res.ntris, (unsigned long long)r->res.nbins,
               100 * r->res.unassigned_share, r->res.realized_l1,
               (unsigned long long)r->res.violations, r->seconds, hex);
        char what[48];
        snprintf(what, sizeof what, "candidate %lld", (long long)i);
        micro_result_warn(&r->res, what, cfg->correct);
    }
    uint64_t digest = gs_digest_bytes(digests, (size_t)n * sizeof *digests);
    gs_free(digests);
    double per_min = wall > 0 ? 60.0 * (double)n / wall : 0;
    gs_log(GS_LOG_INFO, "gallery: %lld candidates in %.2f s on %d rank%s (%.1f candidates per "
           "minute), %llu violations",
           (long long)n, wall, run->size, run->size > 1 ? "s" : "", per_min,
           (unsigned long long)violations);
    if (run->rank == 0) {
        char path[PATH_MAX + 32];
        snprintf(path, sizeof path, "%s/candidates.json", ej.gallery);
        err = write_candidates_json(&ej, path);
        if (!err) {
            snprintf(path, sizeof path, "%s/index.html", ej.gallery);
            err = write_index_html(&ej, digest, path);
        }
        gs_run_metric_i64(run, "candidates", n);
        gs_run_metric_i64(run, "triangles", (int64_t)tris);
        gs_run_metric_i64(run, "violations", (int64_t)violations);
        gs_run_metric_f64(run, "unassigned_share_max", unassigned_max);
        gs_run_metric_f64(run, "realized_l1", tris ? rl1_sum / (double)tris : 0);
        gs_run_metric_f64(run, "realized_l1_max", rl1_max);
        micro_outline_metrics(run, &outline);
        gs_run_metric_f64(run, "gallery_seconds", wall);
        gs_run_metric_f64(run, "candidates_per_minute", per_min);
        gs_run_metric_f64(run, "candidate_cpu_seconds", cpu);
        /* every candidate's files, so that the run digest covers them (#25) */
        for (int64_t i = 0; i < n; i++) {
            static const struct { const char *file, *kind, *role; } files[] = {
                {"mesh.ply", "mesh", "instance"}, {"mesh.obj", "mesh", "instance"},
                {"mesh.glb", "mesh", "instance"}, {"micro.h5", "h5", "labels"},
                {"thumb.png", "preview", "instance"}, {NULL, "config", "candidate"}};
            char name[32], rel[96], full[PATH_MAX];
            candidate_name(i, name, sizeof name);
            for (size_t k = 0; k < sizeof files / sizeof files[0]; k++) {
                if (files[k].file)
                    snprintf(rel, sizeof rel, "gallery/%s/%s", name, files[k].file);
                else
                    snprintf(rel, sizeof rel, "gallery/%s/%s.ini", name, name);
                gs_run_path(run, rel, full, sizeof full);
                if (access(full, F_OK) == 0)
                    gs_run_output(run, files[k].kind, files[k].role, rel, NULL);
            }
        }
        gs_run_output(run, "html", "gallery", "gallery/index.html", NULL);
        gs_run_output(run, "json", "candidates", "gallery/candidates.json", NULL);
    }
    GS_TRY(err, gs_par_agree(run->comm, err), done);
    gs_json pj;
    gs_json_init(&pj);
    gs_json_begin_object(&pj, NULL);
    gs_json_i64(&pj, "candidates", n);
    gs_json_f64(&pj, "candidates_per_minute", per_min);
    gs_json_u64(&pj, "violations", violations);
    gs_json_end_object(&pj);
    err = gs_run_phase_end(run, pj.failed ? NULL : pj.buf);
    gs_json_free(&pj);
    GS_TRY(err, err, done);
    GS_TRY(err, gs_run_finish(run, digest), done);
done:
    gs_free(ej.res);
    return err;
}
