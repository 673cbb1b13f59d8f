/* micro driver, setup: input meshes (files through gs_mesh_read, or the
 * core's shapes), subdivision, dual graphs, the contact distribution (table,
 * CSV, image, random) and the instance list. Rank 0 reads every file and
 * broadcasts what it read; everything after that is computed identically on
 * every rank. See engine_impl.h. */
#include <stdlib.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/data.h"
#include "geosynth/digest.h"
#include "geosynth/file.h"
#include "geosynth/image.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/par.h"
#include "micro/engine_impl.h"

#define MESH_LIST_MAX_BYTES ((size_t)16 << 20)

/* Rank 0: the mesh paths listed in list_path (one per line, '#' comments,
 * relative to the list's directory or "${data}/..."), as absolute paths joined
 * by '\n'; every listed file must be readable. */
static gs_err read_mesh_list(const char *list_path, char **joined)
{
    char *text = NULL, *dir = NULL, *out = NULL;
    size_t len = 0, used = 0, cap = 0;
    GS_CALL(gs_file_read_all(list_path, MESH_LIST_MAX_BYTES, &text, &len));
    gs_err err = GS_OK;
    size_t dl = strlen(list_path);
    dir = gs_malloc(dl + 2);
    GS_TRY_CHECK(err, dir != NULL, GS_ERR_MEM, done, "mesh list path");
    memcpy(dir, list_path, dl + 1);
    char *slash = strrchr(dir, '/');
    if (slash)
        slash[slash == dir ? 1 : 0] = '\0';
    else
        strcpy(dir, ".");
    int line_no = 0, count = 0;
    for (char *line = text; line;) {
        char *nl = strchr(line, '\n');
        if (nl)
            *nl = '\0';
        line_no++;
        char *p = line;
        while (*p == ' ' || *p == '\t')
            p++;
        char *e = p + strlen(p);
        while (e > p && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r'))
            *--e = '\0';
        if (*p != '\0' && *p != '#') {
            char *abs = NULL;
            GS_TRY(err, gs_path_absolute(p, dir, &abs), done);
            if (access(abs, R_OK) != 0) { /* name the list and line, not only the file */
                char hint[3 * PATH_MAX];
                int why = errno;
                gs_data_missing_hint(abs, hint, sizeof hint);
                gs_free(abs);
                GS_TRY_CHECK(err, 0, GS_ERR_IO, done, "micro.mesh_list = %s, line %d: %s: %s%s%s",
                             list_path, line_no, p, strerror(why), hint[0] ? "; " : "", hint);
            }
            gs_err noted = gs_input_note("micro.mesh_list", abs); /* resume checks it (#25) */
            if (noted) {
                gs_free(abs);
                GS_TRY(err, noted, done);
            }
            size_t n = strlen(abs);
            if (used + n + 2 > cap) {
                size_t ncap = 2 * (used + n + 2) + 256;
                char *grown = gs_realloc(out, ncap);
                if (!grown) {
                    gs_free(abs);
                    GS_TRY_CHECK(err, 0, GS_ERR_MEM, done, "mesh list of %zu bytes", ncap);
                }
                out = grown;
                cap = ncap;
            }
            if (used)
                out[used++] = '\n';
            memcpy(out + used, abs, n + 1);
            used += n;
            gs_free(abs);
            count++;
        }
        line = nl ? nl + 1 : NULL;
    }
    GS_TRY_CHECK(err, count > 0, GS_ERR_ARG, done,
                 "micro.mesh_list = %s lists no mesh file (expected one path per line)", list_path);
    *joined = out;
    out = NULL;
done:
    gs_free(text);
    gs_free(dir);
    gs_free(out);
    return err;
}

/* Rank 0 reads one mesh file; every rank receives it. Collective. */
static gs_err load_mesh_file(MPI_Comm comm, int rank, const char *path, gs_micro_mesh *m)
{
    gs_err err = GS_OK;
    uint64_t sizes[2] = {0, 0};
    if (rank == 0) {
        gs_mesh gm;
        err = gs_mesh_read(path, &gm);
        if (!err) {
            err = gs_micro_mesh_from_mesh(&gm, m);
            gs_mesh_destroy(&gm);
        }
        if (err)
            gs_error_add_context("input mesh of micro.mesh / micro.mesh_list");
        else
            sizes[0] = m->nverts, sizes[1] = m->ntris;
    }
    GS_CALL(gs_par_agree(comm, err));
    GS_CALL(GS_PAR_BCAST_VALUE(comm, &sizes, 0));
    /* agreed: a rank that cannot allocate must not leave rank 0 in the broadcast */
    GS_CALL(gs_par_agree(comm, rank != 0 ? gs_micro_mesh_alloc(m, (uint32_t)sizes[0],
                                                               (uint32_t)sizes[1])
                                         : GS_OK));
    GS_CALL(gs_par_bcast_bytes(comm, m->pos, (size_t)sizes[0] * 3 * sizeof *m->pos, 0));
    GS_CALL(gs_par_bcast_bytes(comm, m->tris, (size_t)sizes[1] * 3 * sizeof *m->tris, 0));
    if (rank != 0) {
        for (uint64_t i = 0; i < 3 * sizes[1]; i++)
            GS_CHECK(m->tris[i] < m->nverts, GS_ERR_INTERNAL, "broadcast mesh is inconsistent");
    }
    GS_FREE(m->normals); /* file normals are not used: the surface's own are */
    return GS_OK;
}

static double mesh_area(const gs_micro_mesh *m)
{
    double a = 0;
    for (uint32_t t = 0; t < m->ntris; t++) {
        const float *p = m->pos + 3 * (size_t)m->tris[3 * (size_t)t];
        const float *q = m->pos + 3 * (size_t)m->tris[3 * (size_t)t + 1];
        const float *r = m->pos + 3 * (size_t)m->tris[3 * (size_t)t + 2];
        double u[3], v[3];
        for (int k = 0; k < 3; k++)
            u[k] = (double)q[k] - p[k], v[k] = (double)r[k] - p[k];
        double c0 = u[1] * v[2] - u[2] * v[1], c1 = u[2] * v[0] - u[0] * v[2],
               c2 = u[0] * v[1] - u[1] * v[0];
        a += 0.5 * sqrt(c0 * c0 + c1 * c1 + c2 * c2);
    }
    return a;
}

/* Subdivision, statistics, normals and dual graph of a loaded/generated mesh. */
static gs_err prepare_mesh(micro_mesh_in *mi, const micro_config *cfg, int subdivide)
{
    mi->half_extent = gs_micro_mesh_half_extent(&mi->m);
    GS_CHECK(mi->half_extent > 0 && isfinite(mi->half_extent), GS_ERR_ARG,
             "%s: the mesh has no extent (all vertices coincide)", mi->source);
    mi->upm = cfg->scale_units / mi->half_extent;
    double me_model = cfg->max_edge / mi->upm;
    if (subdivide) {
        /* Guard against a resolution no machine holds: an edge bound e gives
         * at least area / (e^2 sqrt(3)/4) triangles. */
        double est = mesh_area(&mi->m) / (me_model * me_model * 0.4330127);
        GS_CHECK(est < 1.5e9, GS_ERR_ARG,
                 "%s: micro.max_edge = %g with micro.scale_units = %g needs about %.3g triangles "
                 "(limit 1.5e9): raise micro.max_edge or lower micro.scale_units",
                 mi->source, cfg->max_edge, cfg->scale_units, est);
        GS_CALL(gs_micro_mesh_subdivide(&mi->m, me_model, &mi->sub));
    }
    double emax, amin;
    gs_micro_mesh_edge_stats(&mi->m, &emax, &amin);
    mi->max_edge_units = emax * mi->upm;
    mi->min_angle_deg = amin;
    GS_CALL(gs_micro_mesh_normals(&mi->m));
    GS_CALL(gs_micro_dual_build(&mi->m, mi->upm, &mi->dual));
    return GS_OK;
}

static char *dup_text(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = gs_malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

/* Collective: job->meshes, prepared. */
static gs_err setup_meshes(micro_job *job)
{
    const micro_config *cfg = job->cfg;
    MPI_Comm comm = job->run->comm;
    int rank = job->run->rank;
    if (strcmp(cfg->shape, "file") != 0) {
        job->meshes = gs_calloc(1, sizeof *job->meshes);
        GS_CHECK(job->meshes, GS_ERR_MEM, "mesh table");
        job->nmeshes = 1;
        micro_mesh_in *mi = job->meshes;
        char desc[160];
        double half;
        if (!strcmp(cfg->shape, "bar")) {
            const double *s = cfg->bar_size.v;
            snprintf(desc, sizeof desc, "bar %g x %g x %g", s[0], s[1], s[2]);
            half = fmax(s[0], fmax(s[1], s[2])) / 2;
        } else {
            snprintf(desc, sizeof desc, "%s of radius %g", cfg->shape, cfg->radius);
            half = cfg->radius;
        }
        mi->source = dup_text(desc);
        GS_CHECK(mi->source, GS_ERR_MEM, "mesh name");
        double me_model = cfg->max_edge * half / cfg->scale_units;
        if (!strcmp(cfg->shape, "sphere"))
            GS_CALL(gs_micro_mesh_sphere(&mi->m, cfg->radius, me_model));
        else if (!strcmp(cfg->shape, "disk"))
            GS_CALL(gs_micro_mesh_disk(&mi->m, cfg->radius, me_model));
        else
            GS_CALL(gs_micro_mesh_bar(&mi->m, cfg->bar_size.v[0], cfg->bar_size.v[1],
                                      cfg->bar_size.v[2], me_model));
        mi->ntris_in = mi->m.ntris;
        GS_CALL(prepare_mesh(mi, cfg, 0));
        return GS_OK;
    }
    char *joined = NULL;
    gs_err err = GS_OK;
    if (rank == 0) {
        if (cfg->mesh_list && cfg->mesh_list[0])
            err = read_mesh_list(cfg->mesh_list, &joined);
        else if (!(joined = dup_text(cfg->mesh)))
            err = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__, "mesh path");
    }
    GS_CALL(gs_par_agree(comm, err));
    GS_CALL(gs_par_bcast_string(comm, &joined, 0));
    uint32_t n = 1;
    for (const char *p = joined; *p; p++)
        n += *p == '\n';
    job->meshes = gs_calloc(n, sizeof *job->meshes);
    if (!job->meshes) {
        gs_free(joined);
        GS_RAISE(GS_ERR_MEM, "table of %u meshes", n);
    }
    job->nmeshes = n;
    char *p = joined;
    for (uint32_t i = 0; i < n && !err; i++) {
        char *nl = strchr(p, '\n');
        if (nl)
            *nl = '\0';
        micro_mesh_in *mi = &job->meshes[i];
        mi->source = dup_text(p);
        if (!mi->source)
            err = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__, "mesh path");
        if (!err)
            err = load_mesh_file(comm, rank, p, &mi->m);
        if (!err) {
            mi->ntris_in = mi->m.ntris;
            err = prepare_mesh(mi, cfg, 1);
        }
        p = nl ? nl + 1 : p + strlen(p);
    }
    gs_free(joined);
    if (err)
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    return err;
}

/* Rank 0: the distribution from an image file (paper 5.3). */
static gs_err dist_from_image_file(const micro_config *cfg, gs_micro_dist *d)
{
    gs_image img;
    GS_CALL(gs_image_read(cfg->image, &img));
    float *grey = NULL;
    uint8_t *pix = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_image_to_gray(&img, &grey), done);
    size_t n = (size_t)img.width * (size_t)img.height, white = 0;
    GS_TRY(err, gs_alloc_array((void **)&pix, n, 1, "image levels"), done);
    for (size_t i = 0; i < n; i++) {
        double v = floor((double)grey[i] * 255.0 + 0.5);
        uint8_t lv = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
        pix[i] = cfg->image_invert ? (uint8_t)(255 - lv) : lv;
        white += pix[i] >= cfg->image_threshold;
    }
    gs_log(GS_LOG_INFO, "image %s: %d x %d, %d channel%s, %d bit; %.1f%% white (positive) at "
           "threshold %lld%s",
           cfg->image, img.width, img.height, img.channels, img.channels > 1 ? "s" : "", img.bits,
           100.0 * (double)white / (double)n, (long long)cfg->image_threshold,
           cfg->image_invert ? " after inversion" : "");
    err = gs_micro_dist_from_image(d, (uint32_t)img.width, (uint32_t)img.height, pix,
                                   (uint8_t)cfg->image_threshold, cfg->image_units_per_pixel,
                                   (uint32_t)cfg->max_bins);
    if (err) {
        gs_error_add_context("micro.image = %s", cfg->image);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    }
done:
    gs_free(grey);
    gs_free(pix);
    gs_image_destroy(&img);
    return err;
}

/* A random distribution sized to mi's surface (gs_micro_dist_random). */
static gs_err dist_random(const micro_config *cfg, const micro_mesh_in *mi, uint64_t seed,
                          uint64_t stream, gs_micro_dist *d)
{
    gs_micro_dist_range r = {(uint32_t)cfg->random_min_bins, (uint32_t)cfg->random_max_bins,
                             cfg->random_min_share, cfg->random_max_share,
                             mesh_area(&mi->m) * mi->upm * mi->upm};
    gs_rng rng;
    gs_rng_init(&rng, seed, stream);
    GS_CALL(gs_micro_dist_random(d, &r, &rng));
    return GS_OK;
}

/* Collective: the run's distribution into *d (rank 0 reads files). */
static gs_err setup_dist(micro_job *job, gs_micro_dist *d)
{
    const micro_config *cfg = job->cfg;
    MPI_Comm comm = job->run->comm;
    const char *kind = cfg->dist;
    if (!strcmp(kind, "table")) {
        size_t K = (size_t)(cfg->table_pos.n > cfg->table_neg.n ? cfg->table_pos.n : cfg->table_neg.n);
        double *p = NULL, *q = NULL;
        gs_err err = GS_OK;
        GS_TRY(err, gs_alloc_array((void **)&p, K, sizeof *p, "table"), done);
        GS_TRY(err, gs_alloc_array((void **)&q, K, sizeof *q, "table"), done);
        for (int64_t k = 0; k < cfg->table_pos.n; k++)
            p[k] = cfg->table_pos.v[k];
        for (int64_t k = 0; k < cfg->table_neg.n; k++)
            q[k] = cfg->table_neg.v[k];
        GS_TRY(err, gs_micro_dist_create(d, (uint32_t)K, p, q), done);
    done:
        gs_free(p);
        gs_free(q);
        return err;
    }
    if (!strcmp(kind, "random")) {
        GS_CALL(dist_random(cfg, &job->meshes[0], (uint64_t)cfg->run.seed,
                            gs_rng_stream_id(MICRO_DOMAIN_DIST, 0, 0, 0), d));
        return GS_OK;
    }
    gs_err err = GS_OK;
    uint32_t K = 0;
    if (job->run->rank == 0) {
        if (!strcmp(kind, "csv")) {
            err = gs_micro_dist_read_csv(cfg->table_csv, d);
            if (!err) {
                err = gs_micro_dist_check_sum(d->pos, d->nbins, d->neg, d->nbins, 0.01,
                                              cfg->table_csv);
                if (err)
                    gs_micro_dist_free(d);
            }
            if (err)
                gs_error_add_context("micro.table_csv");
        } else {
            err = dist_from_image_file(cfg, d);
        }
        if (!err)
            K = d->nbins;
    }
    GS_CALL(gs_par_agree(comm, err));
    GS_CALL(GS_PAR_BCAST_VALUE(comm, &K, 0));
    if (job->run->rank != 0) {
        d->nbins = K;
        d->pos = d->neg = NULL;
    }
    /* allocated off rank 0 and agreed before each broadcast */
    GS_CALL(gs_par_bcast_alloc(comm, (void **)&d->pos, K, sizeof *d->pos, 0, "distribution"));
    GS_CALL(gs_par_bcast_alloc(comm, (void **)&d->neg, K, sizeof *d->neg, 0, "distribution"));
    return GS_OK;
}

int micro_direction_of(const char *s)
{
    return !strcmp(s, "out") ? 1 : !strcmp(s, "in") ? -1 : 0;
}

gs_micro_func micro_func_of(const char *s)
{
    static const char *names[] = {"linear", "sqrt", "square", "cbrt", "step"};
    for (int i = 0; i < 5; i++)
        if (!strcmp(s, names[i]))
            return (gs_micro_func)i;
    return GS_MICRO_LINEAR;
}

static uint64_t input_digest(const micro_job *job, const micro_instance *in)
{
    const gs_micro_mesh *m = &job->meshes[in->mesh].m;
    gs_digest dg;
    if (!gs_digest_init(&dg))
        return 0;
    gs_digest_update(&dg, m->pos, (size_t)m->nverts * 3 * sizeof *m->pos);
    gs_digest_update(&dg, m->tris, (size_t)m->ntris * 3 * sizeof *m->tris);
    gs_digest_update(&dg, &job->meshes[in->mesh].upm, sizeof(double));
    gs_digest_update(&dg, in->hist.count, 2 * (size_t)in->hist.nbins * sizeof *in->hist.count);
    gs_digest_update(&dg, &in->seed, sizeof in->seed);
    int64_t o[2] = {job->opts.capacity, (int64_t)job->opts.max_rejects_per_bin};
    gs_digest_update(&dg, o, sizeof o);
    return gs_digest_final(&dg);
}

gs_err micro_setup(micro_job *job)
{
    const micro_config *cfg = job->cfg;
    gs_micro_recon_defaults(&job->opts);
    job->opts.capacity = cfg->capacity;
    job->opts.max_rejects_per_bin = (uint64_t)cfg->max_rejects_per_bin;
    gs_micro_correct_defaults(&job->copts);
    job->copts.max_rounds = (uint32_t)cfg->correct_rounds;
    job->copts.target_l1 = cfg->correct_target;
    job->copts.disc_seed = cfg->correct_discs ? (cfg->correct_boolean ? 2 : 1) : 0;
    job->disp = (gs_micro_displace_params){
        {micro_direction_of(cfg->pos_direction), micro_direction_of(cfg->neg_direction)},
        {cfg->pos_scale, cfg->neg_scale},
        {micro_func_of(cfg->pos_func), micro_func_of(cfg->neg_func)}};
    job->steps_per_round = (uint32_t)cfg->steps_per_round;
    GS_CALL(setup_meshes(job));
    gs_micro_dist shared = {0};
    if (!cfg->random_per_instance)
        GS_CALL(setup_dist(job, &shared));
    int64_t per = cfg->instances;
    job->ninst = per * (int64_t)job->nmeshes;
    job->inst = gs_calloc((size_t)job->ninst, sizeof *job->inst);
    gs_err err = GS_OK;
    GS_TRY_CHECK(err, job->inst != NULL, GS_ERR_MEM, done, "table of %lld instances",
                 (long long)job->ninst);
    for (int64_t i = 0; i < job->ninst; i++) {
        micro_instance *in = &job->inst[i];
        in->id = i;
        in->mesh = (uint32_t)(i / per);
        in->seed = gs_rng_stream_id(MICRO_DOMAIN_SEED, (uint64_t)cfg->run.seed, (uint64_t)i, 0);
        if (cfg->random_per_instance)
            GS_TRY(err, dist_random(cfg, &job->meshes[i / per], (uint64_t)cfg->run.seed,
                                    gs_rng_stream_id(MICRO_DOMAIN_DIST, 1, (uint64_t)i, 0), &in->dist),
                   done);
        else
            GS_TRY(err, gs_micro_dist_create(&in->dist, shared.nbins, shared.pos, shared.neg), done);
        GS_TRY(err, gs_micro_hist_from_dist(&in->hist, &in->dist, job->meshes[in->mesh].m.ntris),
               done);
        in->input_digest = input_digest(job, in);
    }
done:
    gs_micro_dist_free(&shared);
    return err;
}

void micro_job_free(micro_job *job)
{
    for (uint32_t i = 0; i < job->nmeshes; i++) {
        micro_mesh_in *mi = &job->meshes[i];
        gs_free(mi->source);
        gs_micro_mesh_free(&mi->m);
        gs_micro_dual_free(&mi->dual);
    }
    GS_FREE(job->meshes);
    job->nmeshes = 0;
    for (int64_t i = 0; i < job->ninst && job->inst; i++) {
        micro_instance *in = &job->inst[i];
        gs_micro_dist_free(&in->dist);
        gs_micro_hist_free(&in->hist);
        gs_micro_state_free(&in->st);
    }
    GS_FREE(job->inst);
    job->ninst = 0;
}
