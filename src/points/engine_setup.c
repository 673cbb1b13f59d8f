/* points driver, setup: the example texture read on rank 0 (PLY, a sampled
 * mesh) or generated on every rank (height map, chain mail, weave,
 * flowers), broadcast, its digest, the core's parameters from the config,
 * and the synthesis created (or left to the restore). See engine_impl.h. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/image.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/pointply.h"
#include "geosynth/partition.h"
#include "points/engine_impl.h"

/* Core parameters from the config; scale-dependent zeros from the box and
 * spacing (gs_points_params_complete). out_size left 0 when out_points is
 * used (set later from the example's density). */
static void params_from_config(const points_config *c, double lx, double ly, double spacing,
                               gs_points_params *p)
{
    memset(p, 0, sizeof *p);
    if (c->out_size.n == 2) {
        p->out_size[0] = c->out_size.v[0];
        p->out_size[1] = c->out_size.v[1];
    }
    p->field_step = c->field_step;
    p->patch_cells = (int)c->patch_cells;
    p->overlap_cells = (int)c->overlap_cells;
    p->extra_cells = (int)c->extra_cells;
    p->mls_radius = c->mls_radius;
    p->trunc = c->trunc;
    p->eps = c->eps;
    p->warp_margin = c->warp_margin;
    p->w_p = c->w_p;
    p->w_n = c->w_n;
    p->w_v = c->w_v;
    p->w_l = c->w_l;
    p->w_d = c->w_d;
    p->max_pair_dist = c->max_pair_dist;
    p->max_normal = c->max_normal;
    p->max_variation = c->max_variation;
    p->coherence_sigma = c->coherence_sigma;
    p->greedy_iterations = (int)c->greedy_iterations;
    p->cluster_max = (int)c->cluster_max;
    p->max_pairs = (int)c->max_pairs;
    p->variation_radius = c->variation_radius;
    p->tps_lambda = c->tps_lambda;
    p->warp_fade = c->warp_fade;
    p->warp_height_bound = c->warp_height_bound;
    p->blend = c->blend;
    p->ray_blend = c->ray_blend;
    p->blend_resample = c->blend_resample;
    p->blend_keep_outer = c->blend_keep_outer;
    p->blend_fill = c->blend_fill;
    p->blend_implicit = c->blend_implicit;
    p->drop_strip_specks = c->drop_strip_specks;
    p->strip_resample = c->strip_resample;
    p->objects = c->objects;
    p->warp_select = c->warp_select;
    p->warp_select_seams = c->warp_select_seams;
    p->relax_iterations = (int)c->relax_iterations;
    p->seed = (uint64_t)c->run.seed;
    gs_points_params_complete(lx, ly, spacing, p);
}

static gs_err read_heightmap(const char *path, int *w, int *h, float **out)
{
    gs_image img;
    GS_CALL(gs_image_read(path, &img));
    float *gray = NULL, *flip = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_image_to_gray(&img, &gray), done);
    GS_TRY(err, gs_alloc_array((void **)&flip, (size_t)img.width * img.height, sizeof *flip,
                               "height field"), done);
    /* Image row 0 is the top; the generator's row 0 is at y low. */
    for (int y = 0; y < img.height; y++)
        memcpy(flip + (size_t)y * img.width, gray + (size_t)(img.height - 1 - y) * img.width,
               (size_t)img.width * sizeof *flip);
    *w = img.width;
    *h = img.height;
    *out = flip;
    flip = NULL;
done:
    gs_free(gray);
    gs_free(flip);
    gs_image_destroy(&img);
    return err;
}

/* Builds the example texture (z up) from the config: a user example on rank
 * 0 alone (ms == NULL), a generated one on every rank (ms: the map hook's
 * state when there are several ranks, else NULL), each rank getting the
 * same points or the same error. */
static gs_err build_texture(const points_config *c, map_state *ms, gs_points_texture *tex)
{
    memset(tex, 0, sizeof *tex);
    if (kind_is_user(c)) {
        int up = up_axis(c);
        gs_err err = GS_OK;
        if (kind_is(c, "ply")) {
            gs_pointply ply;
            GS_CALL(gs_pointply_read(c->path, 1, &ply));
            err = gs_points_append(&tex->pts, (const gs_opoint *)ply.v, ply.n);
            gs_pointply_destroy(&ply);
            GS_CALL(err);
        } else {
            gs_mesh m;
            GS_CALL(gs_mesh_read(c->path, &m));
            err = gs_points_sample_mesh(m.pos, m.nverts, m.tris, m.ntris, c->spacing,
                                        (uint64_t)c->input_seed, c->path, &tex->pts);
            gs_mesh_destroy(&m);
            if (err != GS_OK) {
                gs_points_free(&tex->pts);
                GS_CALL(err);
            }
        }
        gs_points_permute_to_z(&tex->pts, up);
        memcpy(tex->box_lo, c->box_lo.v, sizeof tex->box_lo);
        memcpy(tex->box_hi, c->box_hi.v, sizeof tex->box_hi);
        gs_points_permute_vec_to_z(tex->box_lo, up);
        gs_points_permute_vec_to_z(tex->box_hi, up);
        tex->spacing = c->spacing;
        if (tex->spacing <= 0) {
            err = gs_points_estimate_spacing(&tex->pts, &tex->spacing);
            if (err != GS_OK) {
                gs_error_add_context("while estimating the spacing of %s (set input.spacing)",
                                     c->path);
                gs_points_texture_free(tex);
                GS_CALL(err);
            }
        }
        return GS_OK;
    }
    /* Generated examples: box [0, size], padding from the parameters. */
    gs_points_params p;
    params_from_config(c, c->size.v[0], c->size.v[1], c->spacing, &p);
    double pad = c->pad > 0 ? c->pad : 1.2 * gs_points_params_padding(&p);
    gs_points_gen_params gp = {{c->size.v[0], c->size.v[1]}, pad, c->spacing,
                               (uint64_t)c->input_seed, c->periodic, ms ? points_mpi_map : NULL, ms,
                               ms ? points_map_agree : NULL};
    if (kind_is(c, "heightfield")) {
        int w = 0, h = 0;
        float *img = NULL;
        gs_err err = read_heightmap(c->path, &w, &h, &img);
        if (ms)
            err = points_map_agree(ms, err); /* every rank reads the image */
        if (err == GS_OK)
            err = gs_points_gen_heightfield(&gp, w, h, NULL, img, c->height_scale, tex);
        gs_free(img);
        GS_CALL(err);
    } else if (kind_is(c, "chainmail")) {
        GS_CALL(gs_points_gen_chainmail(&gp, (int)c->cells, tex));
    } else if (kind_is(c, "weave")) {
        GS_CALL(gs_points_gen_weave(&gp, (int)c->cells, tex));
    } else {
        GS_CALL(gs_points_gen_flowers(&gp, (int)c->cells, tex));
    }
    return GS_OK;
}

/* What bcast_texture sends ahead of the points. */
typedef struct texture_header {
    uint64_t n; /* points */
    double box_lo[3], box_hi[3], spacing;
} texture_header;

/* Collective: rank 0's texture to every rank. */
static gs_err bcast_texture(MPI_Comm comm, int rank, gs_points_texture *tex)
{
    texture_header hdr = {0};
    if (rank == 0) {
        hdr.n = tex->pts.n;
        memcpy(hdr.box_lo, tex->box_lo, sizeof hdr.box_lo);
        memcpy(hdr.box_hi, tex->box_hi, sizeof hdr.box_hi);
        hdr.spacing = tex->spacing;
    }
    GS_CALL(GS_PAR_BCAST_VALUE(comm, &hdr, 0));
    size_t n = (size_t)hdr.n;
    if (rank != 0) {
        memset(tex, 0, sizeof *tex);
        memcpy(tex->box_lo, hdr.box_lo, sizeof hdr.box_lo);
        memcpy(tex->box_hi, hdr.box_hi, sizeof hdr.box_hi);
        tex->spacing = hdr.spacing;
    }
    /* agreed: a rank that cannot allocate must not leave rank 0 in the broadcast */
    GS_CALL(gs_par_agree(comm, rank != 0 ? gs_points_reserve(&tex->pts, n) : GS_OK));
    if (rank != 0)
        tex->pts.n = n;
    GS_CALL(gs_par_bcast_bytes(comm, tex->pts.v, n * sizeof(gs_opoint), 0));
    return GS_OK;
}

static uint64_t texture_digest(const gs_points_texture *tex)
{
    gs_digest d;
    if (!gs_digest_init(&d))
        return 0;
    gs_digest_update(&d, tex->pts.v, tex->pts.n * sizeof(gs_opoint));
    gs_digest_update(&d, tex->box_lo, sizeof tex->box_lo);
    gs_digest_update(&d, tex->box_hi, sizeof tex->box_hi);
    gs_digest_update(&d, &tex->spacing, sizeof tex->spacing);
    return gs_digest_final(&d);
}

void points_run_state_free(run_state *r)
{
    gs_points_synth_destroy(&r->synth);
    points_search_ctx_free(&r->sctx);
    gs_points_texture_free(&r->tex);
    gs_points_free(&r->out);
    gs_free(r->out_patch);
    gs_free(r->out_id);
    gs_free(r->choices);
}

/* points.choices: rank 0 reads the patches.csv (header "patch,chosen,...",
 * then rows k, source patch, ... for k = 0, 1, ...), every rank gets the
 * list. Collective; errors name the file and line. */
static gs_err read_choices(const char *path, uint64_t **out, size_t *n)
{
    FILE *f = fopen(path, "r");
    GS_CHECK(f != NULL, GS_ERR_IO, "points.choices: cannot open %s", path);
    char line[1024];
    uint64_t *v = NULL;
    size_t cap = 0, k = 0;
    long ln = 1;
    gs_err err = GS_OK;
    GS_TRY_CHECK(err, fgets(line, sizeof line, f) && !strncmp(line, "patch,chosen,", 13),
                 GS_ERR_FORMAT, done,
                 "points.choices: %s line 1: expected the header \"patch,chosen,...\" of a "
                 "patches.csv (output.patch_metrics)", path);
    while (fgets(line, sizeof line, f)) {
        ln++;
        unsigned long long a, b;
        char c;
        GS_TRY_CHECK(err, sscanf(line, "%llu,%llu%c", &a, &b, &c) == 3 && c == ',' && a == k,
                     GS_ERR_FORMAT, done,
                     "points.choices: %s line %ld: expected \"%zu,SOURCE_PATCH,...\"", path, ln,
                     k);
        if (k == cap) {
            cap = cap ? 2 * cap : 256;
            uint64_t *nv = gs_realloc(v, cap * sizeof *nv);
            GS_TRY_CHECK(err, nv != NULL, GS_ERR_MEM, done, "points.choices: out of memory");
            v = nv;
        }
        v[k++] = b;
    }
    GS_TRY_CHECK(err, k > 0, GS_ERR_FORMAT, done, "points.choices: %s has no patch", path);
done:
    fclose(f);
    if (err != GS_OK) {
        gs_free(v);
        return err;
    }
    *out = v;
    *n = k;
    return GS_OK;
}

gs_err points_load_choices(gs_run *run, const points_config *c, run_state *rs)
{
    if (!c->choices[0])
        return GS_OK;
    uint64_t *v = NULL, n = 0;
    size_t nl = 0;
    gs_err err = GS_OK;
    if (run->rank == 0) {
        err = read_choices(c->choices, &v, &nl);
        n = nl;
    }
    GS_CALL(points_agree(&rs->together, run->comm, err));
    GS_CALL(GS_PAR_BCAST_VALUE(run->comm, &n, 0));
    GS_CALL(gs_par_bcast_alloc(run->comm, (void **)&v, (size_t)n, sizeof *v, 0,
                               "points.choices"));
    rs->choices = v;
    rs->nchoices = (size_t)n;
    return GS_OK;
}

gs_err points_apply_choices(run_state *rs)
{
    if (!rs->choices)
        return GS_OK;
    gs_err err = gs_points_synth_set_choices(rs->synth, rs->choices, rs->nchoices);
    if (err != GS_OK) { /* the same list and run on every rank: the same error */
        rs->together = 1;
        gs_error_add_context("points.choices = %s", rs->c->choices);
    }
    return err;
}

gs_err points_phase_setup(gs_run *run, const points_config *c, run_state *rs, int resume,
                          gs_json *phase)
{
    gs_err err = GS_OK;
    GS_CALL(points_map_state_init(&rs->map, run->comm, &rs->fault, &rs->together));
    int user = kind_is_user(c);
    if (!user) {
        /* Every rank generates it (the dart throwing over the map hook). */
        rs->fault.armed = rs->fault.site == FAULT_GENERATE;
        err = build_texture(c, run->size > 1 ? &rs->map : NULL, &rs->tex);
        rs->fault.armed = 0;
        if (err != GS_OK && rs->together)
            return err; /* every rank returns it */
    } else if (run->rank == 0) {
        err = build_texture(c, NULL, &rs->tex);
    }
    if (!user || run->rank == 0) {
        if (err == GS_OK && rs->tex.pts.n == 0)
            err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                 "input: the example has no points");
        if (err == GS_OK && rs->tex.pts.n > ((size_t)1 << 28))
            err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                 "input: %zu example points, expected at most 2^28",
                                 rs->tex.pts.n);
    }
    GS_CALL(points_agree(&rs->together, run->comm, err));
    if (user)
        GS_CALL(bcast_texture(run->comm, run->rank, &rs->tex));
    gs_points_texture *t = &rs->tex;
    double lx = t->box_hi[0] - t->box_lo[0], ly = t->box_hi[1] - t->box_lo[1];
    params_from_config(c, lx, ly, t->spacing, &rs->params);
    /* Input checks with the config's words (identical on every rank). */
    size_t inside = 0;
    for (size_t i = 0; i < t->pts.n; i++) {
        const double *q = t->pts.v[i].p;
        inside += q[0] >= t->box_lo[0] && q[0] < t->box_hi[0] && q[1] >= t->box_lo[1] &&
                  q[1] < t->box_hi[1];
    }
    if (c->out_points > 0 && c->out_size.n == 0 && inside > 0) {
        double f = sqrt(c->out_points / (double)inside);
        rs->params.out_size[0] = lx * f;
        rs->params.out_size[1] = ly * f;
    }
    /* These checks see the same broadcast example and config on every rank
     * and allocate nothing, so a failure is collective. */
    err = gs_points_texture_check(t, gs_points_params_padding(&rs->params));
    if (err != GS_OK) {
        rs->together = 1;
        if (kind_is_user(c))
            gs_error_add_context("example %s with box input.box_lo = (%g, %g, %g), input.box_hi "
                                 "= (%g, %g, %g), up = %s", c->path, c->box_lo.v[0],
                                 c->box_lo.v[1], c->box_lo.v[2], c->box_hi.v[0], c->box_hi.v[1],
                                 c->box_hi.v[2], c->up);
        else
            gs_error_add_context("generated %s example with input.pad = %g", c->kind, c->pad);
        GS_CALL(err);
    }
    size_t npatch = 0;
    err = gs_points_patch_count(t, &rs->params, &npatch);
    if (err != GS_OK)
        rs->together = 1;
    GS_CALL(err);
    rs->tex_digest = texture_digest(t);
    const gs_points_params *p = &rs->params;
    double area_out = p->out_size[0] * p->out_size[1];
    double dens = inside / (lx * ly);
    double est_out = dens * area_out;
    gs_log(GS_LOG_INFO, "example: %s%s%s, %zu points (%zu inside the box), spacing %g",
           c->kind, c->path[0] ? " " : "", c->path, t->pts.n, inside, t->spacing);
    gs_log(GS_LOG_INFO, "box: [%g, %g] x [%g, %g] x [%g, %g] (z = height, up = %s)", t->box_lo[0],
           t->box_hi[0], t->box_lo[1], t->box_hi[1], t->box_lo[2], t->box_hi[2],
           kind_is_user(c) ? c->up : "z");
    gs_log(GS_LOG_INFO, "field step %g, patch %d cells, overlap %d, extra %d, MLS radius %g, "
           "eps %g, weights w_p %g w_n %g w_v %g w_l %g w_d %g",
           p->field_step, p->patch_cells, p->overlap_cells, p->extra_cells, p->mls_radius,
           p->eps, p->w_p, p->w_n, p->w_v, p->w_l, p->w_d);
    gs_log(GS_LOG_INFO, "output %g x %g (about %.0f points), %zu input patches over %d rank%s",
           p->out_size[0], p->out_size[1], est_out, npatch, run->size, run->size > 1 ? "s" : "");
    {
        /* example (points, grid, variation), D(T_in), this rank's bank share,
         * output grid (buckets grow by doubling) and its copies in the
         * relaxation, trimming and output (about 6 x 48 bytes per point). */
        double g = p->field_step, bz = t->box_hi[2] - t->box_lo[2];
        double nz = fmax(2, ceil(bz / g - 1e-9) + 1), nx = floor(lx / g) + 1, ny = floor(ly / g) + 1;
        double oc = p->overlap_cells, pc = p->patch_cells;
        double bank = npatch / (double)run->size * 4 * nz * (oc * oc + 2 * oc * (pc + 1 - oc)) * 4;
        double bytes = t->pts.n * 112.0 + nx * ny * nz * 16 + bank + est_out * 6 * 48.0;
        gs_log(GS_LOG_INFO, "memory estimate per rank: %.1f MiB (example %.1f, field %.1f, bank "
               "share %.1f, output %.1f)", bytes / 1048576.0, t->pts.n * 112.0 / 1048576.0,
               nx * ny * nz * 16 / 1048576.0, bank / 1048576.0, est_out * 288.0 / 1048576.0);
        GS_CALL(gs_run_check_memory(run, bytes, "points.out_size (or points.out_points)"));
    }
    int64_t lo, hi;
    GS_CALL(gs_partition((int64_t)npatch, run->size, run->rank, &lo, &hi));
    rs->sctx.comm = run->comm;
    rs->sctx.rank = run->rank;
    rs->sctx.size = run->size;
    rs->sctx.lo = lo;
    rs->sctx.hi = hi;
    rs->sctx.fault = &rs->fault;
    rs->sctx.together = &rs->together;
    GS_CALL(points_search_ctx_alloc(&rs->sctx));
    rs->share = (gs_points_synth_share){.first = (size_t)lo,
                                        .count = (size_t)(hi - lo),
                                        .fn = points_distributed_search,
                                        .user = &rs->sctx,
                                        .map = run->size > 1 ? points_mpi_map : NULL,
                                        .map_user = &rs->map};
    if (hi == lo) { /* more ranks than patches: an empty share still joins every search */
        rs->share.first = 0;
        rs->share.count = 0;
    }
    GS_CALL(points_load_choices(run, c, rs));
    if (!resume) { /* a resumed run's synthesis comes from the checkpoint (points_restore) */
        GS_CALL(gs_points_synth_create_share(t, p, &rs->share, &rs->synth));
        GS_CALL(points_apply_choices(rs));
    }
    gs_json_u64(phase, "input_points", t->pts.n);
    gs_json_u64(phase, "input_points_in_box", inside);
    gs_json_u64(phase, "input_patches", npatch);
    gs_json_i64(phase, "bank_share", hi - lo);
    if (!resume)
        gs_json_u64(phase, "patches", gs_points_synth_total(rs->synth));
    return GS_OK;
}
