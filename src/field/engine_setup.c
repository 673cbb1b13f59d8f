/* field driver, setup: rank 0 builds the example (generator, mesh, .vdb,
 * height map or HDF5 field), crops and quantizes it, and broadcasts the
 * quantized source; then every rank creates the synthesis (or leaves it to
 * the restore). See engine_impl.h. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/field_examples.h"
#include "geosynth/file.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "field/engine_impl.h"

/* Mesh vertices from world to sample units of field f. */
static void mesh_to_samples(gs_mesh *m, const gs_field *f)
{
    for (size_t v = 0; v < m->nverts; v++)
        for (int a = 0; a < 3; a++)
            m->pos[3 * v + a] = (float)((m->pos[3 * v + a] - f->origin[a]) / f->spacing);
}

/* The example is a height-map image (example.kind = file, .png/.jpg). */
int field_is_heightmap_example(const field_config *c)
{
    if (strcmp(c->kind, "file"))
        return 0;
    char ext[16];
    gs_path_ext(c->path, ext, sizeof ext);
    return !strcmp(ext, "png") || !strcmp(ext, "jpg") || !strcmp(ext, "jpeg");
}

/* Rank 0: builds the float example field (and its mesh when wanted). */
static gs_err build_example(const field_config *c, int want_mesh, field_source *src, gs_field **raw)
{
    if (strcmp(c->kind, "file")) {
        GS_CALL(gs_field_example_make(c->kind, c->size, (uint64_t)c->example_seed, raw));
        snprintf(src->desc, sizeof src->desc, "built-in example '%s', %lld^3 samples, seed %lld",
                 c->kind, (long long)c->size, (long long)c->example_seed);
        return GS_OK;
    }
    char ext[16];
    gs_path_ext(c->path, ext, sizeof ext);
    if (!strcmp(ext, "vdb")) {
        GS_CALL(gs_field_from_vdb(c->path, c->vdb_grid, raw));
        snprintf(src->desc, sizeof src->desc, "OpenVDB level set %s", c->path);
    } else if (!strcmp(ext, "h5") || !strcmp(ext, "hdf5")) {
        GS_CALL(gs_field_from_h5(c->path, c->dataset, raw));
        snprintf(src->desc, sizeof src->desc, "HDF5 field %s:%s", c->path, c->dataset);
    } else if (!strcmp(ext, "png") || !strcmp(ext, "jpg") || !strcmp(ext, "jpeg")) {
        GS_CALL(gs_field_from_heightmap(c->path, c->size, c->depth, c->height, raw));
        snprintf(src->desc, sizeof src->desc, "height map %s (relief %g of depth %lld samples)",
                 c->path, c->height, (long long)c->depth);
    } else if (!strcmp(ext, "obj") || !strcmp(ext, "ply") || !strcmp(ext, "stl") ||
               !strcmp(ext, "off")) {
        gs_mesh m;
        GS_CALL(gs_mesh_read(c->path, &m));
        int is_signed = !strcmp(c->sign, "signed");
        gs_err err = gs_field_from_mesh(&m, c->path, c->size, c->margin, is_signed, c->shell, raw);
        if (err) {
            gs_mesh_destroy(&m);
            gs_error_add_context("example.path with example.sign = %s%s", c->sign,
                                 is_signed ? " (use example.sign = unsigned for open meshes)" : "");
            GS_CALL(err);
        }
        snprintf(src->desc, sizeof src->desc, "%s mesh %s (%zu triangles), %s distance", ext,
                 c->path, m.ntris, c->sign);
        if (want_mesh && is_signed) {
            mesh_to_samples(&m, *raw);
            src->mesh = m;
            src->have_mesh = 1;
        } else {
            gs_mesh_destroy(&m);
        }
    } else {
        GS_RAISE(GS_ERR_ARG,
                 "example.path = %s: unknown extension '.%s': expected .obj .ply .stl .off (mesh), "
                 ".vdb, .png .jpg (height map) or .h5 (field)",
                 c->path, ext);
    }
    return GS_OK;
}

static gs_err build_source_rank0(const field_config *c, int want_mesh, field_source *src)
{
    gs_field *raw = NULL;
    GS_CALL(build_example(c, want_mesh, src, &raw));
    gs_err err = gs_field_crop(raw, (int64_t)1 << (c->iterations - 1), &src->f);
    gs_field_destroy(&raw);
    GS_CALL(err);
    double r = c->range * src->f->spacing;
    GS_CALL(gs_field_quantize(src->f, -r, r, &src->q));
    src->q->spacing = src->f->spacing;
    memcpy(src->q->origin, src->f->origin, sizeof src->q->origin);
    if (want_mesh && !src->have_mesh) {
        /* contour of the float source, in sample units */
        gs_field unit = *src->f;
        unit.spacing = 1, unit.origin[0] = unit.origin[1] = unit.origin[2] = 0;
        GS_CALL(gs_field_contour(&unit, 0.0, 0.0, &src->mesh));
        src->have_mesh = 1;
    }
    return GS_OK;
}

/* Collective: rank 0 builds, everyone receives the quantized source. */
static gs_err build_source(gs_run *run, const field_config *c, int want_mesh, field_source *src)
{
    gs_err err = GS_OK;
    if (run->rank == 0)
        err = build_source_rank0(c, want_mesh, src);
    GS_CALL(gs_par_agree(run->comm, err));
    struct {
        int64_t n[3];
        double lo, hi, spacing, origin[3];
    } hdr;
    memset(&hdr, 0, sizeof hdr);
    if (run->rank == 0) {
        const gs_qfield *q = src->q;
        hdr.n[0] = q->nx, hdr.n[1] = q->ny, hdr.n[2] = q->nz;
        hdr.lo = q->lo, hdr.hi = q->hi, hdr.spacing = q->spacing;
        memcpy(hdr.origin, q->origin, sizeof hdr.origin);
    }
    GS_CALL(GS_PAR_BCAST_VALUE(run->comm, &hdr, 0));
    if (run->rank != 0)
        err = gs_qfield_create(hdr.n[0], hdr.n[1], hdr.n[2], hdr.lo, hdr.hi, &src->q);
    /* agreed: a rank that cannot allocate must not leave rank 0 in the broadcast */
    GS_CALL(gs_par_agree(run->comm, err));
    if (run->rank != 0) {
        src->q->spacing = hdr.spacing;
        memcpy(src->q->origin, hdr.origin, sizeof hdr.origin);
    }
    int64_t n = src->q->nx * src->q->ny * src->q->nz;
    GS_CALL(gs_par_bcast_bytes(run->comm, src->q->q, (size_t)n, 0));
    return GS_OK;
}

void field_source_free(field_source *s)
{
    gs_qfield_destroy(&s->q);
    gs_field_destroy(&s->f);
    gs_mesh_destroy(&s->mesh);
}

gs_err field_setup_op(gs_run *run, const void *cfg_, int resume, void **state,
                      gs_json *phase)
{
    const field_config *c = cfg_;
    field_drive *d = gs_calloc(1, sizeof *d);
    GS_CHECK(d != NULL, GS_ERR_MEM, "field: out of memory for the run state");
    *state = d;
    d->c = c;
    d->ctx.ps_iteration = -1;
    /* the source's mesh: copied.ply, and the left panel of preview.png (a
     * height map's preview with output.geometry = contour showed an empty
     * source panel) */
    int want_mesh = !strcmp(c->geometry, "copy") || !strcmp(c->geometry, "both") || c->preview;
    gs_err err = GS_OK;
    GS_CHECK(!strcmp(c->height_match, "none") || field_is_heightmap_example(c), GS_ERR_ARG,
             "field.height_match = %s: expected none unless the example is a height map "
             "(example.kind = file, example.path .png or .jpg)", c->height_match);
    GS_CALL(build_source(run, c, want_mesh, &d->src));
    const gs_qfield *q = d->src.q;
    GS_CHECK(!strcmp(c->height_match, "none") || c->target[2] == q->nz, GS_ERR_ARG,
             "field.height_match = %s: expected field.target's z (%lld) equal to the example's "
             "depth (example.depth = %lld): a column's height is matched within its own depth",
             c->height_match, (long long)c->target[2], (long long)q->nz);
    d->src_digest = gs_digest_bytes(q->q, (size_t)(q->nx * q->ny * q->nz));
    gs_field_synth_config_default(&d->sc, q);
    d->sc.iterations = (int)c->iterations;
    for (int i = 0; i < d->sc.iterations; i++)
        d->sc.block[i] = (int)(i == d->sc.iterations - 1 ? c->block : c->coarse_block);
    memcpy(d->sc.target, c->target, sizeof d->sc.target);
    d->sc.seed = (uint64_t)c->run.seed;
    d->sc.mask_unsynthesized = c->mask_unsynthesized;
    d->sc.seed_weight = (int)lround(c->seed_weight * 256);
    if (c->seed_weight > 0 && d->sc.seed_weight < 1)
        d->sc.seed_weight = 1;
    d->sc.coarse_weight = (int)lround(c->coarse_weight * 256);
    if (c->coarse_weight > 0 && d->sc.coarse_weight < 1)
        d->sc.coarse_weight = 1;
    d->sc.seed_blocks = c->seed_blocks;
    d->sc.use_upper_bound = c->upper_bound;
    d->sc.copy_limit = c->copy_limit;
    d->sc.copy_limit_reach = (int)c->copy_limit_reach;
    d->sc.blend = (int)c->blend;
    d->sc.repeat_reach = (int)c->repeat_reach;
    d->sc.repeat_span = (int)c->repeat_span;
    d->sc.repeat_pairs = (int)c->repeat_pairs;
    d->sc.repeat_free = c->repeat_free;
    d->sc.seam_gradient = c->seam_gradient;
    d->sc.height_match = !strcmp(c->height_match, "both") ? 3 : !strcmp(c->height_match, "final") ? 2
                         : !strcmp(c->height_match, "coarse") ? 1 : 0;
    d->sc.seam_cut = c->seam_cut;
    d->sc.seam_columns = c->seam_columns;
    d->sc.complete_objects = c->complete_objects;
    d->sc.keep_volume = c->keep_volume;
    d->sc.object_spacing = c->object_spacing;
    d->sc.object_same = c->object_same;
    d->sc.object_continue = c->object_continue;
    d->sc.wrap = !strcmp(c->wrap, "xyz") ? 7 : !strcmp(c->wrap, "xy") ? 3 : 0;
    d->sc.region_blocks = (int)c->region_blocks;
    d->ctx.sharded = !strcmp(c->tree, "sharded") && run->size > 1;
    if (d->ctx.sharded)
        d->sc.tree_shards = run->size, d->sc.tree_shard = run->rank;
    d->sc.match = field_match_block;
    d->sc.match_ctx = &d->ctx;
    d->ctx.run = run;
    memcpy(d->ctx.target, c->target, sizeof d->ctx.target);
    int64_t nt = c->target[0] * c->target[1] * c->target[2];
    int L = 0;
    while ((1 << L) < c->block)
        L++;
    double ns = (double)(q->nx * q->ny * q->nz);
    /* source + (tree slab copy, pyramid 8L, nodes ~20) per sample of the tree's share */
    double share = d->ctx.sharded ? 1.0 / run->size + (double)c->block / (double)q->nz : 1.0;
    double est = ns + ns * (share < 1 ? share : 1) * (1 + 8.0 * L + 20.0) + (double)nt * (2 + 4);
    if (run->rank == 0) {
        gs_log(GS_LOG_INFO, "example: %s", d->src.desc);
        gs_log(GS_LOG_INFO, "source: %lldx%lldx%lld samples, spacing %g, quantized over [%g, %g]",
               (long long)q->nx, (long long)q->ny, (long long)q->nz, q->spacing, q->lo, q->hi);
        gs_log(GS_LOG_INFO, "target: %lldx%lldx%lld, %d iterations, blocks %d..%d, %s matching",
               (long long)c->target[0], (long long)c->target[1], (long long)c->target[2],
               d->sc.iterations, d->sc.block[0], d->sc.block[d->sc.iterations - 1],
               c->mask_unsynthesized ? "masked" : "whole-block (paper)");
        if (c->mask_unsynthesized)
            gs_log(GS_LOG_INFO, "unsynthesized samples weigh %d/256 (seeds, iteration 0) and "
                                "%d/256 (upsampled coarse result), iteration 0 seeded with "
                                "random %s", d->sc.seed_weight, d->sc.coarse_weight,
                   d->sc.seed_blocks ? "blocks" : "samples");
        gs_log(GS_LOG_INFO, "memory estimate per rank: %.1f MiB (source, pyramid, tree, target, "
                            "mask, provenance)%s", est / 1048576.0,
               d->ctx.sharded ? "; tree and pyramid sharded over the ranks" : "");
    }
    GS_CALL(gs_run_check_memory(run, est, "field.target (or field.block)"));
    GS_CALL(gs_alloc_array((void **)&d->ctx.prov, (size_t)nt, sizeof *d->ctx.prov,
                           "provenance map"));
    for (int64_t i = 0; i < nt; i++)
        d->ctx.prov[i] = -1;
    d->sc.prov = d->ctx.prov;
    if (!resume) /* a resumed run's synthesis comes from the checkpoint (field_restore) */
        err = gs_field_synth_create(q, &d->sc, &d->synth);
    GS_CALL(gs_par_agree(run->comm, err));
    d->ctx.synth = d->synth;
    for (int i = 0; i < d->sc.iterations; i++) {
        int64_t f = (int64_t)1 << (d->sc.iterations - 1 - i), cnt = 1;
        for (int a = 0; a < 3; a++) {
            int64_t T = c->target[a] / f, B = d->sc.block[i], np = 1;
            for (int64_t p = 0; p + B < T; p += B / 2)
                np++;
            cnt *= np;
        }
        d->total += cnt;
    }
    gs_json_begin_array(phase, "source");
    gs_json_i64(phase, NULL, q->nx);
    gs_json_i64(phase, NULL, q->ny);
    gs_json_i64(phase, NULL, q->nz);
    gs_json_end_array(phase);
    gs_json_begin_array(phase, "target");
    for (int a = 0; a < 3; a++)
        gs_json_i64(phase, NULL, c->target[a]);
    gs_json_end_array(phase);
    return GS_OK;
}
