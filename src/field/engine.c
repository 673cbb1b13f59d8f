/* The `field` engine: distance-field geometry synthesis after Lagae, Dumont,
 * Dutré, "Geometry Synthesis" (2004), wired into geosynth.
 *
 *   mpirun -np N geosynth field -c configs/field/grid.ini
 *
 * Phases:
 *  setup      rank 0 builds the example (generator, mesh, .vdb, height map or
 *             HDF5 field; see include/geosynth/field_examples.h), crops it to a
 *             multiple of 2^(iterations-1) per axis and quantizes it over
 *             [-range, range] samples; the quantized source is broadcast, so
 *             every rank holds the identical bytes (OpenVDB is never run on
 *             two ranks). Then the synthesis is created, or restored from
 *             RUN_DIR/checkpoint.h5.
 *  synthesis  the core's multi-resolution synthesis (src/field/synth.c). Every
 *             rank holds the whole (small) target. Each iteration's block
 *             positions are cut into target regions (field.region_blocks)
 *             visited in wavefront colors; the core's visit order (colors,
 *             regions by id, raster inside) gives exactly the paper's raster
 *             order's result (see gs_field_region), so the region size never
 *             changes the output. A color with at least one region per rank
 *             runs on the gs_regions work queue: each rank synthesizes whole
 *             regions on private copies with its local tree, the results
 *             (source block per target block) are exchanged and applied in id
 *             order on every rank. Other colors (the first and last of the
 *             wavefront, coarse iterations with few regions, a color resumed
 *             in its middle) run block by block on every rank, and each
 *             query is first searched whole on every rank
 *             with a pop budget (FIELD_LOCAL_POPS; the same answer, or the
 *             same give-up, everywhere, no messages); only queries over the
 *             budget are distributed: the search
 *             tree's top-level subtrees are split over the ranks (gs_psearch,
 *             balanced by blocks per subtree), each rank searches its share
 *             with the bound shared between ranks (the tree search polls
 *             gs_psearch_bound), and the result is made exact: psearch gives
 *             the smallest distance, one MPI_Allreduce(MIN) gives the lowest
 *             block index among the ranks whose best has that distance. So
 *             each block gets exactly the serial answer of
 *             gs_field_tree_best_match and the output is bit-identical for any
 *             rank count (and to the core's serial synthesis).
 *             field.tree = sharded: each rank builds only the tree of one
 *             z-slab of every iteration's block positions (gs_field_tree_build_shard,
 *             split by count), so tree + pyramid memory per rank falls with
 *             the rank count; every query is then spread (one psearch
 *             candidate per rank: its slab, bound shared), regions run in
 *             order (a region needs the whole tree), and the quality measure
 *             searches the slabs together too. Same output.
 *             Checkpoint tests (a collective) run after every region color
 *             and every FIELD_UNIT_BATCH blocks in order. Checkpoints hold target, mask, iteration,
 *             cursor, match statistics and the provenance map; the only
 *             randomness (the seeds of iteration 0) is drawn from gs_rng keyed
 *             by run.seed when the synthesis is created, so it is part of the
 *             stored target, not a running RNG.
 *  output     field.h5 (+ field.xmf) with the float distance and the quantized
 *             levels, field.vdb, the contoured mesh (OpenVDB) and, with
 *             output.geometry = copy|both, the paper's copied geometry: the
 *             source surface copied along the provenance onto the contour's
 *             connectivity (a valid mesh, seams relaxed). Quality metrics go to
 *             summary.json. The digest is that of the final quantized target.
 *
 * Memory per rank: source 1 byte/sample + pyramid 8L bytes/sample + tree
 * (~20 bytes/node), the last two for the rank's slab only when sharded
 * (1/np + (B-1)/nz of the source, plus 1 byte/sample for the slab's copy);
 * target 2 bytes/sample + provenance 4 bytes/sample of the final target;
 * rank 0 also the float source (4 bytes/sample) and meshes. The largest
 * rank's tree + pyramid bytes are reported (tree_bytes_rank_max).
 */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/config.h"
#include "geosynth/digest.h"
#include "geosynth/engine.h"
#include "geosynth/field.h"
#include "geosynth/field_examples.h"
#include "geosynth/file.h"
#include "geosynth/h5.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/par.h"
#include "geosynth/partition.h"
#include "geosynth/preview.h"
#include "geosynth/psearch.h"
#include "geosynth/regions.h"
#include "geosynth/vdb.h"

typedef struct field_config {
    char *kind;
    char *path;
    int64_t size;
    int64_t example_seed;
    char *sign;
    double shell;
    double margin;
    char *vdb_grid;
    char *dataset;
    int64_t depth;
    double height;
    double range;
    int64_t iterations;
    int64_t block;
    int64_t coarse_block;
    int64_t target[3];
    int mask_unsynthesized;
    double seed_weight;
    double coarse_weight;
    int seed_blocks;
    int upper_bound;
    double copy_limit;
    int64_t blend;
    int64_t region_blocks;
    char *tree;
    char *geometry;
    char *mesh_format;
    double adaptivity;
    int64_t relax;
    double snap;
    int vdb;
    int preview;
    gs_run_config run;
} field_config;

static void validate_config(const void *cfg_, gs_cfg_ctx *ctx)
{
    const field_config *c = cfg_;
    int file = !strcmp(c->kind, "file");
    if (file && !c->path[0])
        gs_cfg_report(ctx, "example.path", "is required with example.kind = file (a mesh, .vdb, "
                                           "height-map image or HDF5 field)");
    if (!file && c->path[0])
        gs_cfg_report(ctx, "example.path",
                      "is only read with example.kind = file (example.kind = %s generates the "
                      "example)", c->kind);
    int64_t f = (int64_t)1 << (c->iterations - 1);
    for (int a = 0; a < 3; a++)
        if (c->target[a] % f != 0 || c->target[a] < c->block)
            gs_cfg_report(ctx, "field.target",
                          "axis %d = %lld: expected a multiple of 2^(iterations-1) = %lld and at "
                          "least field.block = %lld",
                          a, (long long)c->target[a], (long long)f, (long long)c->block);
    if (c->iterations > 1 && c->coarse_block * (f / 2) > c->target[0] && c->coarse_block * (f / 2) > c->target[1])
        gs_cfg_report(ctx, "field.coarse_block",
                      "%lld does not fit the target at the coarsest iteration (target / %lld)",
                      (long long)c->coarse_block, (long long)f);
}

static const gs_cfg_key field_keys[] = {
    GS_CFG_KEY_ENUM(field_config, kind, "example.kind", "file|" GS_EXAMPLE_KINDS, "grid",
                    "example geometry: a built-in generator, or file = example.path"),
    GS_CFG_KEY_PATH(field_config, path, "example.path", "",
                    "example file: mesh (.obj .ply .stl .off), .vdb level set, height map "
                    "(.png .jpg) or HDF5 field (.h5)"),
    GS_CFG_KEY_INT(field_config, size, "example.size", 8, 1024, 0, "64",
                   "source samples along the longest axis (mesh, generator, height map)"),
    GS_CFG_KEY_INT(field_config, example_seed, "example.seed", 0, GS_CFG_INT_MAX, 0, "1",
                   "seed of the built-in generators (independent of run.seed)"),
    GS_CFG_KEY_ENUM(field_config, sign, "example.sign", "signed|unsigned", "signed",
                    "mesh distance: signed needs a closed mesh; unsigned works for any mesh "
                    "(surface thickened by example.shell)"),
    GS_CFG_KEY_REAL(field_config, shell, "example.shell", 0, 8, 0, "1",
                    "unsigned meshes: half thickness of the solid shell, in samples"),
    GS_CFG_KEY_REAL(field_config, margin, "example.margin", 0, 64, 0, "2",
                    "mesh: samples of empty margin around the bounding box"),
    GS_CFG_KEY_STRING(field_config, vdb_grid, "example.vdb_grid", "",
                      ".vdb: float grid name (empty = the first level set, else the first float grid)"),
    GS_CFG_KEY_STRING(field_config, dataset, "example.dataset", "/field/distance",
                      "HDF5: float32 dataset {nz, ny, nx} holding the distance field"),
    GS_CFG_KEY_INT(field_config, depth, "example.depth", 4, 4096, 0, "32",
                   "height map: samples along z"),
    GS_CFG_KEY_REAL(field_config, height, "example.height", 0, 4096, GS_CFG_OPEN_LO, "16",
                    "height map: relief (black to white) in samples"),
    GS_CFG_KEY_REAL(field_config, range, "field.range", 0, 64, GS_CFG_OPEN_LO, "3",
                    "quantization: 256 levels over [-range, +range] samples of distance"),
    GS_CFG_KEY_INT(field_config, iterations, "field.iterations", 1, GS_FIELD_MAX_ITER, 0, "3",
                   "multi-resolution iterations (paper: 3)"),
    GS_CFG_KEY_INT(field_config, block, "field.block", 2, 32, GS_CFG_POW2, "16",
                   "block size of the last iteration (paper: 16)"),
    GS_CFG_KEY_INT(field_config, coarse_block, "field.coarse_block", 2, 32, GS_CFG_POW2, "8",
                   "block size of the earlier iterations (paper: 8)"),
    GS_CFG_KEY_INT3(field_config, target, "field.target", 2, 4096, 0, "128",
                    "target samples x y z (paper: 128^3 from a 64^3 source)"),
    GS_CFG_KEY_BOOL(field_config, mask_unsynthesized, "field.mask_unsynthesized", "yes",
                    "yes: only synthesized samples count in a match (faithful statistics); "
                    "no: the paper's whole blocks, its random seeds only breaking ties (at full weight "
                    "they outweigh the overlap)"),
    GS_CFG_KEY_REAL(field_config, seed_weight, "field.seed_weight", 0, 1, 0, "0",
                    "masked matching: weight of unsynthesized samples (seeds, coarse result) "
                    "against synthesized ones; 0 = ignored (copies the source), 1 = paper"),
    GS_CFG_KEY_REAL(field_config, coarse_weight, "field.coarse_weight", 0, 1, 0, "1",
                    "masked matching after the first iteration: weight of the upsampled coarse "
                    "result against synthesized samples; 1 = equal (paper), 0 = ignored "
                    "(multi-resolution then does nothing)"),
    GS_CFG_KEY_BOOL(field_config, seed_blocks, "field.seed_blocks", "no",
                    "iteration 0 starts from random source blocks instead of random samples"),
    GS_CFG_KEY_BOOL(field_config, upper_bound, "field.upper_bound", "yes",
                    "queue pruning after iteration 0 (paper eq. 3's role): each search starts "
                    "bounded by the exact distance of the neighbour's match continued; same "
                    "result, fewer queue entries"),
    GS_CFG_KEY_REAL(field_config, copy_limit, "field.copy_limit", 0, 1, 0, "0",
                    "no piece copied verbatim from one source offset grows past this share of "
                    "the source (its bounding box): the search then excludes that offset's "
                    "continuation; 0 = off (the paper: large verbatim copies); 0.25 in terrain, texture, "
                    "balls and fibers.ini"),
    GS_CFG_KEY_INT(field_config, blend, "field.blend", 0, 4, 0, "0",
                   "seam blending after the last iteration: samples within this many of a seam "
                   "between pieces copied from different source offsets fade from one piece into "
                   "the other (overlap blending); 0 = off (the paper: the pieces meet in steps); 2 "
                   "where copy_limit is set"),
    GS_CFG_KEY_INT(field_config, region_blocks, "field.region_blocks", 0, 4096, 0, "4",
                   "target regions run in parallel on the ranks: block positions (stride "
                   "block/2) per region along each axis; 0 = one region; any value gives the "
                   "paper's raster-order result, for any rank count"),
    GS_CFG_KEY_ENUM(field_config, tree, "field.tree", "whole|sharded", "whole",
                    "search tree per rank: whole = every rank holds the whole tree and pyramid "
                    "(fastest, target regions in parallel); sharded = each rank holds a z-slab "
                    "of them, so memory per rank falls with the rank count, and every match is "
                    "searched by all ranks together; same output"),
    GS_CFG_KEY_ENUM(field_config, geometry, "output.geometry", "contour|copy|both|none", "contour",
                    "output mesh: contour of the field (OpenVDB), the source's surface copied "
                    "along the provenance onto it (paper 5.3), both, or none"),
    GS_CFG_KEY_ENUM(field_config, mesh_format, "output.mesh_format", "obj|ply", "ply",
                    "file format of output meshes"),
    GS_CFG_KEY_REAL(field_config, adaptivity, "output.adaptivity", 0, 1, 0, "0",
                    "contour mesh adaptivity (0 = uniform)"),
    GS_CFG_KEY_INT(field_config, relax, "output.relax", 0, 1000, 0, "10",
                   "copied geometry: Laplacian relaxation iterations of seam vertices"),
    GS_CFG_KEY_REAL(field_config, snap, "output.snap", 0, 2, 0, "0.5",
                    "copied geometry: how far (samples) a contour vertex may move onto the copied "
                    "source surface"),
    GS_CFG_KEY_BOOL(field_config, vdb, "output.vdb", "yes", "also write field.vdb"),
    GS_CFG_KEY_BOOL(field_config, preview, "output.preview", "yes",
                    "write RUN_DIR/preview.png: the source's contour and the output's contour "
                    "side by side (whatever output.geometry is)"),
    GS_CFG_RUN_KEYS(field_config, run, "field"),
};

static const gs_cfg_table field_table =
    GS_CFG_TABLE("field", field_config, field_keys, validate_config);

/* ------------------------------------------------------------- example */

typedef struct field_source {
    gs_qfield *q;      /* quantized, cropped source (every rank) */
    gs_field *f;       /* float source, same crop (rank 0) */
    gs_mesh mesh;      /* source triangles in sample units (rank 0, copy mode) */
    int have_mesh;
    char desc[256];
} field_source;

/* Mesh vertices from world to sample units of field f. */
static void mesh_to_samples(gs_mesh *m, const gs_field *f)
{
    for (size_t v = 0; v < m->nverts; v++)
        for (int a = 0; a < 3; a++)
            m->pos[3 * v + a] = (float)((m->pos[3 * v + a] - f->origin[a]) / f->spacing);
}

/* The example is a height-map image (example.kind = file, .png/.jpg). */
static int is_heightmap_example(const field_config *c)
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
    if (run->rank != 0) {
        GS_CALL(gs_qfield_create(hdr.n[0], hdr.n[1], hdr.n[2], hdr.lo, hdr.hi, &src->q));
        src->q->spacing = hdr.spacing;
        memcpy(src->q->origin, hdr.origin, sizeof hdr.origin);
    }
    int64_t n = src->q->nx * src->q->ny * src->q->nz;
    GS_CALL(gs_par_bcast_bytes(run->comm, src->q->q, (size_t)n, 0));
    return GS_OK;
}

static void source_free(field_source *s)
{
    gs_qfield_destroy(&s->q);
    gs_field_destroy(&s->f);
    gs_mesh_destroy(&s->mesh);
}

/* ------------------------------------------------- distributed matching */

typedef struct match_ctx {
    gs_run *run;
    gs_field_synth_t synth;
    int64_t target[3];     /* final target size */
    int32_t *prov;         /* final-iteration provenance: source sample of each target sample */
    gs_psearch_t ps;
    int ps_iteration;      /* iteration the psearch handle was built for (-1: none) */
    int sharded;           /* field.tree = sharded: each rank holds one z-slab of the tree */
    gs_field_tree_t qtree; /* the quality measure's tree (sharded: this rank's slab) */
    gs_field_searcher_t qsearcher;
    /* per query */
    gs_field_tree_t tree;
    gs_field_searcher_t searcher;
    const gs_field_query *q;
    gs_field_search_opts opts;
    gs_field_match local;
    gs_psearch_t cur;
    int64_t queries;
    uint64_t pops;         /* queue pops of this rank's searches through the hook */
    int64_t local_queries; /* np > 1: queries answered by the local budgeted search */
} match_ctx;

/* Pop budget of the local try before a query is spread over the ranks. */
#define FIELD_LOCAL_POPS 20000
/* Blocks synthesized between two checkpoint tests (collective). */
#define FIELD_UNIT_BATCH 16

static void poll_bound(void *ctx_, uint64_t *bound)
{
    match_ctx *ctx = ctx_;
    double b = gs_psearch_bound(ctx->cur);
    if (isfinite(b) && b >= 0 && b < (double)*bound)
        *bound = (uint64_t)b;
}

static gs_err search_share(void *user, gs_psearch_t ps, int64_t lo, int64_t hi)
{
    match_ctx *ctx = user;
    ctx->cur = ps;
    int64_t t0 = lo, t1 = hi;
    if (ctx->sharded) {
        /* the unit is this rank's slab: its whole tree (none when the slab is empty) */
        if (!ctx->tree)
            return GS_OK;
        t0 = 0, t1 = gs_field_tree_top_count(ctx->tree);
    }
    double b = gs_psearch_bound(ps);
    uint64_t bound = isfinite(b) ? (uint64_t)b : UINT64_MAX;
    gs_field_search_opts o = ctx->opts;
    o.poll = poll_bound;
    o.poll_ctx = ctx;
    o.poll_every = 16;
    GS_CALL(gs_field_tree_search(ctx->searcher, t0, t1, ctx->q, &o, &bound, &ctx->local));
    if (ctx->local.found) {
        gs_psearch_offer(ps, (double)ctx->local.dist, lo);
        (void)gs_psearch_bound(ps); /* poll interval 1: sends the improvement now */
    }
    return GS_OK;
}

/* The synthesis' match hook: exact best match, spread over the ranks. */
static gs_err match_block(void *ctx_, gs_field_tree_t tree, gs_field_searcher_t searcher,
                          int iteration, const gs_field_query *q,
                          const gs_field_search_opts *opts, gs_field_match *out)
{
    match_ctx *ctx = ctx_;
    gs_run *run = ctx->run;
    ctx->queries++;
    int done = 0;
    if (ctx->sharded) {
        /* every rank holds one slab of the tree: always spread */
    } else if (run->size == 1) {
        GS_CALL(gs_field_tree_best_match(searcher, q, opts, out));
        done = 1;
    } else {
        /* Most masked queries finish in a few hundred pops: every rank runs
         * them whole (same answer everywhere, no messages), and only the
         * queries that exceed the budget -- the same ones on every rank --
         * are spread over the ranks. */
        gs_field_search_opts lo = opts ? *opts : (gs_field_search_opts){0};
        lo.max_pops = FIELD_LOCAL_POPS;
        uint64_t bound = UINT64_MAX;
        GS_CALL(gs_field_tree_search(searcher, 0, gs_field_tree_top_count(tree), q, &lo, &bound, out));
        done = out->found && !out->truncated;
        if (done)
            ctx->local_queries++;
    }
    if (!done) {
        if (ctx->ps_iteration != iteration) {
            /* candidates: the top-level subtrees weighted by their blocks, or
             * sharded one per rank (its slab) */
            gs_psearch_destroy(&ctx->ps);
            int64_t top = ctx->sharded ? run->size : gs_field_tree_top_count(tree);
            double *w = NULL;
            if (!ctx->sharded) {
                GS_CALL(gs_alloc_array((void **)&w, (size_t)top, sizeof *w, "subtree weights"));
                for (int64_t i = 0; i < top; i++)
                    w[i] = (double)gs_field_tree_top_blocks(tree, i);
            }
            gs_err err = gs_psearch_create(run->comm, top, w, &ctx->ps);
            gs_free(w);
            GS_CALL(err);
            gs_psearch_set_poll_interval(ctx->ps, 1);
            ctx->ps_iteration = iteration;
        }
        ctx->searcher = searcher;
        ctx->tree = tree;
        ctx->q = q;
        ctx->opts = opts ? *opts : (gs_field_search_opts){0};
        memset(&ctx->local, 0, sizeof ctx->local);
        gs_psearch_hit hit;
        GS_CALL(gs_psearch_best(ctx->ps, search_share, ctx, &hit));
        GS_CHECK(hit.index >= 0, GS_ERR_INTERNAL, "distributed block search found no block");
        /* psearch orders ties by subtree; the serial answer is the lowest block index */
        int64_t key = ctx->local.found && (double)ctx->local.dist == hit.dist ? ctx->local.index
                                                                              : INT64_MAX, best;
        GS_CALL(gs_par_min_i64(run->comm, key, &best));
        GS_CHECK(best != INT64_MAX, GS_ERR_INTERNAL, "distributed block search lost its best block");
        *out = ctx->local;
        out->found = 1;
        out->index = best;
        out->dist = (uint64_t)hit.dist;
        out->pops = ctx->local.pops; /* this rank's work */
        /* the same on every rank, also on one whose slab found nothing */
        out->known = gs_field_query_known(q);
    }
    ctx->pops += out->pops;
    return GS_OK;
}

/* Quality measure: every rank matches every output block with its whole
 * full-resolution tree or its slab of it, through match_block (its own key
 * for the psearch handle). */
#define QUALITY_ITERATION GS_FIELD_MAX_ITER
static gs_err quality_match(void *ctx_, const gs_field_query *q, gs_field_match *out)
{
    match_ctx *ctx = ctx_;
    return match_block(ctx, ctx->qtree, ctx->qsearcher, QUALITY_ITERATION, q, NULL, out);
}

/* ------------------------------------------------------ target regions */

/* Regions of one color on the gs_regions work queue: each rank synthesizes
 * its regions on private copies with the whole local tree, the results (one
 * source block per target block) are exchanged and applied in id order on
 * every rank. Same state as the serial order (gs_field_synth_run). */
/* ctx is the synthesis; gs_regions ids are its region indices. */
static gs_err field_region_run(void *synth, int64_t id, int color, int pass, gs_rng *rng,
                               gs_region_out *out)
{
    (void)color, (void)pass, (void)rng; /* the synthesis has no randomness after seeding */
    void *dst = NULL;
    GS_CALL(gs_region_out_reserve(out, gs_field_synth_region_bytes(synth, id), &dst));
    return gs_field_synth_region_run(synth, id, dst);
}

static gs_err field_region_apply(void *synth, int64_t id, const void *buf, size_t len)
{
    return gs_field_synth_region_apply(synth, id, buf, len);
}

#define FIELD_REGIONS_DOMAIN 0x46524547u /* "FREG" */

/* Seconds of this rank in region colors (gs_regions_stats, summed). */
typedef struct region_times {
    double compute, wait, exchange, apply;
    int64_t regions;
} region_times;

static gs_err run_color_regions(gs_run *run, gs_field_synth_t synth, int64_t first, int64_t n,
                                region_times *rt)
{
    gs_region *list = NULL;
    GS_CALL(gs_alloc_array((void **)&list, (size_t)n, sizeof *list, "colour regions"));
    for (int64_t i = 0; i < n; i++)
        list[i].id = first + i, list[i].color = 0;
    gs_regions_t rs = NULL;
    gs_err err = gs_regions_create(run->comm, list, n, (uint64_t)run->seed, FIELD_REGIONS_DOMAIN, &rs);
    gs_free(list);
    GS_CALL(err);
    err = gs_regions_run_pass(rs, 0, field_region_run, field_region_apply, synth);
    gs_regions_stats st = gs_regions_get_stats(rs);
    rt->compute += st.t_compute, rt->wait += st.t_wait;
    rt->exchange += st.t_exchange, rt->apply += st.t_apply;
    rt->regions += st.computed;
    gs_regions_destroy(&rs);
    return err;
}

static gs_err max_over_ranks(gs_run *run, unsigned long long v, unsigned long long *out)
{
    uint64_t m;
    GS_CALL(gs_par_max_u64(run->comm, (uint64_t)v, &m));
    *out = (unsigned long long)m;
    return GS_OK;
}

static int synth_finished(const gs_field_synth_state *st, int iterations)
{
    return st->iteration >= iterations ||
           (st->iteration == iterations - 1 && st->cursor >= st->blocks_in_iteration);
}

/* ---------------------------------------------------------- checkpoint */

static int64_t units_done(const gs_field_synth_state *st)
{
    int64_t u = 0;
    for (int i = 0; i < GS_FIELD_MAX_ITER; i++)
        u += st->stat_count[i];
    return u;
}

static gs_err write_u8_field(gs_ckpt_t h, gs_run *run, const char *path, const int64_t n[3],
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

static gs_err write_checkpoint(gs_run *run, match_ctx *ctx, uint64_t src_digest)
{
    const gs_field_synth_state *st = gs_field_synth_get_state(ctx->synth);
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_begin(run, &h));
    gs_err err = GS_OK;
    GS_TRY(err, gs_ckpt_set_i64(h, "/field", "iteration", st->iteration), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, "/field", "cursor", st->cursor), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, "/field", "blocks_in_iteration", st->blocks_in_iteration), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, "/field", "source_digest", src_digest), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, "/field", "units_done", (uint64_t)units_done(st)), fail);
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
    GS_TRY(err, write_u8_field(h, run, "/field/target", st->tn, GS_H5_U8, st->target), fail);
    GS_TRY(err, write_u8_field(h, run, "/field/mask", st->tn, GS_H5_U8, st->mask), fail);
    GS_TRY(err, write_u8_field(h, run, "/field/provenance", ctx->target, GS_H5_I32, ctx->prov), fail);
    if (st->matches && st->blocks_in_iteration > 0) {
        gs_h5_shape sm = {GS_H5_I64, 1, {(uint64_t)st->blocks_in_iteration}};
        GS_TRY(err, gs_ckpt_write_whole(h, "/field/matches", &sm, st->matches, NULL), fail);
    }
    GS_CALL(gs_run_checkpoint_commit(run, &h, units_done(st)));
    return GS_OK;
fail:
    gs_ckpt_discard(&h);
    return err;
}

static gs_err read_checkpoint(gs_run *run, const gs_qfield *src, const gs_field_synth_config *sc,
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

/* -------------------------------------------------------------- output */

static gs_err write_field_h5(gs_run *run, const gs_qfield *res, const gs_field *f,
                             const gs_qfield *src)
{
    char path[PATH_MAX];
    gs_run_path(run, "field.h5", path, sizeof path);
    gs_ckpt_meta meta = {"field", run->seed, run->config_text};
    gs_ckpt_t h = NULL;
    GS_CALL(gs_ckpt_create(run->comm, path, &meta, &h));
    int64_t n[3] = {res->nx, res->ny, res->nz};
    gs_err err = GS_OK;
    GS_TRY(err, write_u8_field(h, run, "/field/distance", n, GS_H5_F32, f->v), fail);
    GS_TRY(err, write_u8_field(h, run, "/field/levels", n, GS_H5_U8, res->q), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/distance", "spacing", f->spacing), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/distance", "origin_x", 0), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/distance", "origin_y", 0), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/distance", "origin_z", 0), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/levels", "lo", res->lo), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/levels", "hi", res->hi), fail);
    static const char order[] = "data[z][y][x]; x fastest, z up; sample (x, y, z) at spacing * (x, y, z)";
    GS_TRY(err, gs_ckpt_set_str(h, "/field/distance", "index_order", order), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/field/distance", "units",
                                "signed distance in the example's units (spacing per sample), "
                                "negative inside"),
           fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/field/levels", "index_order", order), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/field/levels", "units",
                                "quantized distance: level q is lo + q * (hi - lo) / 255"),
           fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/field", "up_axis", "z"), fail);
    /* the quantized (cropped) example, so that any measure of the output
     * against its example can be taken from this file alone */
    int64_t sn[3] = {src->nx, src->ny, src->nz};
    GS_TRY(err, write_u8_field(h, run, "/source/levels", sn, GS_H5_U8, src->q), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/source/levels", "lo", src->lo), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/source/levels", "hi", src->hi), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/source/levels", "index_order", order), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/source/levels", "units",
                                "quantized distance of the cropped example: lo + q * (hi - lo) / 255"),
           fail);
    GS_CALL(gs_ckpt_commit(&h));
    err = GS_OK;
    if (run->rank == 0) {
        gs_xdmf_grid g = {"field", GS_XDMF_NODE, {(uint64_t)n[2], (uint64_t)n[1], (uint64_t)n[0]},
                          {0, 0, 0}, {f->spacing, f->spacing, f->spacing}, 1};
        gs_xdmf_attr at[2] = {{"distance", "/field/distance", GS_H5_F32, 1},
                              {"levels", "/field/levels", GS_H5_U8, 1}};
        err = gs_xdmf_write(path, &g, at, 2);
        gs_run_output(run, "h5", "field", "field.h5", n);
        gs_run_output(run, "xdmf", "field", "field.xmf", n);
    }
    GS_CALL(gs_par_agree(run->comm, err));
    return GS_OK;
fail:
    gs_ckpt_discard(&h);
    return err;
}

/* Rank 0: the synthesized field redistanced into a proper level set (the
 * exact distance to its zero surface within field.range samples, OpenVDB
 * levelSetRebuild on a copy padded with its edge values so the surface stays
 * open at the box faces), written as field.vdb (grid `surface`, class level
 * set, background = band width, voxel size = sample spacing) when
 * output.vdb = yes; f->v receives the redistanced values. */
static gs_err redistance_rank0(gs_run *run, const field_config *c, gs_field *f)
{
    int pad = (int)ceil(c->range) + 1;
    gs_vdb_dense d, out;
    size_t n[3] = {(size_t)f->nx + 2 * (size_t)pad, (size_t)f->ny + 2 * (size_t)pad,
                   (size_t)f->nz + 2 * (size_t)pad};
    GS_CALL(gs_vdb_dense_alloc(&d, n[0], n[1], n[2]));
    d.voxel = f->spacing;
    for (int a = 0; a < 3; a++)
        d.origin[a] = -pad * f->spacing;
    d.background = (float)(c->range * f->spacing);
    for (size_t z = 0; z < n[2]; z++)
        for (size_t y = 0; y < n[1]; y++)
            for (size_t x = 0; x < n[0]; x++) {
                int64_t sx = (int64_t)x - pad, sy = (int64_t)y - pad, sz = (int64_t)z - pad;
                sx = sx < 0 ? 0 : sx >= f->nx ? f->nx - 1 : sx;
                sy = sy < 0 ? 0 : sy >= f->ny ? f->ny - 1 : sy;
                sz = sz < 0 ? 0 : sz >= f->nz ? f->nz - 1 : sz;
                d.v[x + n[0] * (y + n[1] * z)] = f->v[sx + f->nx * (sy + f->ny * sz)];
            }
    char path[PATH_MAX];
    gs_run_path(run, "field.vdb", path, sizeof path);
    gs_err err = gs_vdb_level_set(&d, pad, c->range, "surface", c->vdb ? path : NULL, &out);
    gs_vdb_dense_destroy(&d);
    GS_CALL(err);
    memcpy(f->v, out.v, (size_t)(f->nx * f->ny * f->nz) * sizeof *f->v);
    gs_vdb_dense_destroy(&out);
    if (c->vdb)
        gs_run_output(run, "vdb", "field", "field.vdb", (int64_t[3]){f->nx, f->ny, f->nz});
    return GS_OK;
}

/* Writes m (target sample units) in the world units of f, and the same as
 * glTF binary next to it (NAME.glb, with smooth normals). */
static gs_err write_world_mesh(const char *path, gs_mesh *m, const gs_field *f, const char *about)
{
    float *world = NULL, *unit = m->pos;
    GS_CALL(gs_alloc_array((void **)&world, 3 * m->nverts + 3, sizeof *world, "world mesh"));
    for (size_t v = 0; v < m->nverts; v++)
        for (int a = 0; a < 3; a++)
            world[3 * v + a] = (float)(f->origin[a] + unit[3 * v + a] * f->spacing);
    m->pos = world;
    const gs_mesh_meta meta = {"geosynth field", "the example's units (field.h5 /field/distance spacing)", about};
    gs_err err = gs_mesh_write_meta(path, m, NULL, NULL, &meta);
    if (err == GS_OK && m->ntris) {
        char glb[PATH_MAX];
        gs_path_with_ext(path, "glb", glb, sizeof glb);
        gs_mesh g = *m;
        g.normals = NULL;
        err = gs_mesh_compute_normals(&g);
        if (err == GS_OK)
            err = gs_mesh_write_glb(glb, &g, NULL, &meta);
        gs_free(g.normals);
    }
    m->pos = unit;
    gs_free(world);
    return err;
}

/* Rank 0: meshes. Fills the metrics object text. */
static gs_err write_geometry_rank0(gs_run *run, const field_config *c, const field_source *src,
                                   const gs_field *f, const int32_t *prov, gs_json *pm)
{
    char path[PATH_MAX], name[64];
    int contour = !strcmp(c->geometry, "contour") || !strcmp(c->geometry, "both");
    int copy = !strcmp(c->geometry, "copy") || !strcmp(c->geometry, "both");
    if (!contour && !copy && !c->preview)
        return GS_OK;
    /* the contour in sample units: contour.ply, the copy's connectivity and
     * the preview (also with output.geometry = none: a picture of every run) */
    gs_field unit = *f;
    unit.spacing = 1, unit.origin[0] = unit.origin[1] = unit.origin[2] = 0;
    gs_mesh base;
    GS_CALL(gs_field_contour(&unit, 0.0, copy ? 0.0 : c->adaptivity, &base));
    gs_err err = GS_OK;
    gs_mesh m;
    memset(&m, 0, sizeof m);
    if (c->preview) {
        /* The example next to the output's contour (also for output.geometry
         * = copy: the copy lies on it), each fitted to its own box. */
        gs_preview_panel panels[2] = {{&src->mesh, NULL}, {&base, NULL}};
        gs_run_path(run, "preview.png", path, sizeof path);
        int written;
        GS_TRY(err, gs_preview_write_optional(path, panels, 2, 512, &written), done);
        if (written)
            gs_run_output(run, "preview", "preview", "preview.png", NULL);
    }
    if (contour) {
        if (copy && c->adaptivity > 0)
            GS_TRY(err, gs_field_contour(&unit, 0.0, c->adaptivity, &m), done);
        gs_mesh *cm = copy && c->adaptivity > 0 ? &m : &base;
        snprintf(name, sizeof name, "contour.%s", c->mesh_format);
        gs_run_path(run, name, path, sizeof path);
        GS_TRY(err, write_world_mesh(path, cm, f, "the zero level set of the synthesized field (contoured by OpenVDB)"), done);
        gs_json_i64(pm, "contour_triangles", (int64_t)cm->ntris);
        gs_run_metric_i64(run, "contour_triangles", (int64_t)cm->ntris);
        gs_json_f64(pm, "contour_area", gs_mesh_area(cm) * f->spacing * f->spacing);
        const int glb = cm->ntris > 0;
        gs_mesh_destroy(&m);
        gs_run_output(run, "mesh", "contour", name, NULL);
        if (glb)
            gs_run_output(run, "mesh", "contour", "contour.glb", NULL);
    }
    if (copy) {
        const gs_qfield *q = src->q;
        int64_t sn[3] = {q->nx, q->ny, q->nz};
        gs_field_copy_stats st;
        GS_TRY(err, gs_field_copy_geometry(&src->mesh, sn, prov, &unit, &base, c->snap, (int)c->relax,
                                           &m, &st), done);
        snprintf(name, sizeof name, "copied.%s", c->mesh_format);
        gs_run_path(run, name, path, sizeof path);
        GS_TRY(err, write_world_mesh(path, &m, f, "the example's surface copied along the synthesis (copied geometry)"), done);
        gs_json_i64(pm, "copied_triangles", (int64_t)m.ntris);
        gs_run_metric_i64(run, "copied_triangles", (int64_t)m.ntris);
        gs_run_metric_i64(run, "copied_seam_vertices", st.seam_vertices);
        gs_json_i64(pm, "copied_seam_vertices", st.seam_vertices);
        double share = m.nverts ? (double)st.copied_vertices / (double)m.nverts : 0;
        gs_run_metric_f64(run, "copied_vertex_share", share);
        gs_json_f64(pm, "copied_vertex_share", share);
        gs_run_metric_f64(run, "copied_mean_shift", st.mean_shift);
        gs_run_metric_i64(run, "copied_pulled_back", st.pulled_back);
        gs_json_i64(pm, "copied_pulled_back", st.pulled_back);
        gs_json_f64(pm, "copied_mean_shift", st.mean_shift);
        gs_run_output(run, "mesh", "copied", name, NULL);
        if (m.ntris)
            gs_run_output(run, "mesh", "copied", "copied.glb", NULL);
    }
done:
    gs_mesh_destroy(&m);
    gs_mesh_destroy(&base);
    return err;
}

/* Copying, whole objects and distance steps (gs_field_geometry_measure) as
 * run metrics and in the output phase record. */
static void report_geometry(gs_run *run, const gs_field_geometry_report *g, gs_json *pm)
{
    const gs_measure_copy *cp = &g->copy;
    gs_run_metric_f64(run, "copy_matched_share", cp->matched_share);
    gs_run_metric_f64(run, "copy_large_share", cp->large_share);
    gs_run_metric_f64(run, "copy_largest_region_of_source", cp->largest_region_of_source);
    gs_run_metric_i64(run, "copy_largest_region", cp->largest_region);
    gs_run_metric_i64(run, "copy_regions", cp->regions);
    gs_run_metric_f64(run, "copy_completeness", cp->completeness);
    /* the source's exact periods: copying is measured modulo them */
    gs_run_metric_i64(run, "copy_source_periods", cp->periods);
    gs_run_metric_f64(run, "copy_source_shortest_period", cp->shortest_period);
    gs_run_metric_i64(run, "components_out", g->components_out);
    gs_run_metric_i64(run, "components_src", g->components_src);
    gs_run_metric_f64(run, "components_per_msample_out", g->components_per_msample_out);
    gs_run_metric_f64(run, "components_per_msample_src", g->components_per_msample_src);
    gs_run_metric_f64(run, "component_median_out", g->component_median_out);
    gs_run_metric_f64(run, "component_median_src", g->component_median_src);
    gs_run_metric_f64(run, "component_size_ks", g->component_size_ks);
    gs_run_metric_f64(run, "fragment_share_out", g->fragment_share_out);
    gs_run_metric_f64(run, "fragment_share_src", g->fragment_share_src);
    gs_run_metric_f64(run, "step_violations_out", g->step_violations_out);
    gs_run_metric_f64(run, "step_violations_src", g->step_violations_src);
    gs_json_f64(pm, "geometry_measure_seconds", g->seconds);
    gs_log(GS_LOG_INFO,
           "copying: %.3f of the output in exact unique %d^3 source windows, %.3f in regions of "
           "one offset larger than a block, largest region %.3f of the source, completeness %.3f%s",
           cp->matched_share, cp->window, cp->large_share, cp->largest_region_of_source,
           cp->completeness, cp->periods ? " (modulo the source's periods)" : "");
    gs_log(GS_LOG_INFO,
           "objects: %lld inside components (%.1f per 10^6 samples; source %lld, %.1f), median "
           "size %.0f (source %.0f), size KS %.3f, fragments %.3f (source %.3f); steps > 1.5 "
           "samples %.4f (source %.4f) (%.2f s)",
           (long long)g->components_out, g->components_per_msample_out,
           (long long)g->components_src, g->components_per_msample_src, g->component_median_out,
           g->component_median_src, g->component_size_ks, g->fragment_share_out,
           g->fragment_share_src, g->step_violations_out, g->step_violations_src, g->seconds);
}

/* ----------------------------------------------------------------- run */

/* ---- the run driver's operations (include/geosynth/engine.h) -------------- */

typedef struct field_drive {
    const field_config *c;
    field_source src;
    gs_field_synth_config sc;
    gs_field_synth_t synth;
    match_ctx ctx;
    uint64_t src_digest;
    gs_qfield *res;
    gs_field *resf;
    int64_t total;              /* blocks of every iteration */
    /* this process's synthesis statistics (a resumed run: since the resume) */
    int started;
    double t0;
    int64_t start_units;
    int64_t region_colors, serial_colors;
    region_times rt;
    double t_setup, t_order;
    unsigned long long tree_peak; /* bytes: this rank's tree + pyramid */
} field_drive;

static gs_err field_setup_op(gs_run *run, const void *cfg_, int resume, void **state,
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
    GS_CALL(build_source(run, c, want_mesh, &d->src));
    const gs_qfield *q = d->src.q;
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
    d->sc.blend = (int)c->blend;
    d->sc.region_blocks = (int)c->region_blocks;
    d->ctx.sharded = !strcmp(c->tree, "sharded") && run->size > 1;
    if (d->ctx.sharded)
        d->sc.tree_shards = run->size, d->sc.tree_shard = run->rank;
    d->sc.match = match_block;
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

static gs_err field_restore(void *state, gs_run *run)
{
    field_drive *d = state;
    gs_err err = read_checkpoint(run, d->src.q, &d->sc, &d->ctx, d->src_digest, &d->synth);
    GS_CALL(gs_par_agree(run->comm, err));
    d->ctx.synth = d->synth;
    return GS_OK;
}

static void field_units(const void *state, int64_t *done, int64_t *total)
{
    const field_drive *d = state;
    const gs_field_synth_state *st = gs_field_synth_get_state(d->synth);
    *done = units_done(st);
    *total = *done > d->total ? *done : d->total;
}

/* One colour's regions in parallel, or up to FIELD_UNIT_BATCH blocks of a
 * colour in order (each query spread over the ranks). */
static gs_err field_advance(void *state, gs_run *run, int *finished)
{
    field_drive *d = state;
    const gs_field_synth_state *st = gs_field_synth_get_state(d->synth);
    if (!d->started) {
        d->started = 1;
        d->t0 = gs_time_now();
        d->start_units = units_done(st);
    }
    *finished = st->iteration >= d->sc.iterations;
    if (*finished)
        return GS_OK;
    int64_t begin, end, r0, nr;
    const gs_field_region *regs;
    double ta = gs_time_now();
    GS_CALL(gs_field_synth_color(d->synth, &begin, &end, &regs, &r0, &nr, finished));
    double tb = gs_time_now();
    d->t_setup += tb - ta; /* a new iteration: level source, tree */
    if (*finished)
        return GS_OK;
    st = gs_field_synth_get_state(d->synth);
    gs_field_tree_t tr = gs_field_synth_tree(d->synth);
    if (tr) {
        gs_field_tree_info ti;
        gs_field_tree_get_info(tr, &ti);
        if (ti.tree_bytes + ti.pyramid_bytes > d->tree_peak)
            d->tree_peak = ti.tree_bytes + ti.pyramid_bytes;
    }
    if (run->size > 1 && nr >= run->size && st->cursor == begin && !d->ctx.sharded) {
        /* a color with a region for every rank: regions in parallel */
        GS_CALL(run_color_regions(run, d->synth, r0, nr, &d->rt));
        d->region_colors++;
    } else {
        /* one region (or fewer than ranks, or a color resumed in its
         * middle): the color's blocks in order, each query spread over
         * the ranks. Batches: the checkpoint test is a collective, and
         * most blocks take microseconds (identical batches on every rank) */
        int64_t left = end - st->cursor, n = left < FIELD_UNIT_BATCH ? left : FIELD_UNIT_BATCH;
        GS_CALL(gs_field_synth_run(d->synth, n, finished));
        d->serial_colors += n == left;
        d->t_order += gs_time_now() - tb;
    }
    st = gs_field_synth_get_state(d->synth);
    *finished = *finished || synth_finished(st, d->sc.iterations);
    return GS_OK;
}

static gs_err field_save(void *state, gs_run *run)
{
    field_drive *d = state;
    return write_checkpoint(run, &d->ctx, d->src_digest);
}

static gs_err field_synthesis_report(void *state, gs_run *run, gs_json *phase)
{
    field_drive *d = state;
    const gs_field_synth_state *st = gs_field_synth_get_state(d->synth);
    double syn_s = d->started ? gs_time_now() - d->t0 : 0;
    unsigned long long tree_peak_max = 0, pops_max = 0;
    GS_CALL(max_over_ranks(run, d->tree_peak, &tree_peak_max));
    GS_CALL(max_over_ranks(run, d->ctx.pops, &pops_max));
    if (run->rank == 0) {
        gs_log(GS_LOG_INFO, "search tree + pyramid per rank: %.1f MiB (largest rank), %s",
               (double)tree_peak_max / 1048576.0, d->ctx.sharded ? "sharded" : "whole");
        gs_run_metric_i64(run, "tree_bytes_rank_max", (int64_t)tree_peak_max);
    }
    const int64_t u = units_done(st), here = u - (d->started ? d->start_units : u);
    gs_json_str(phase, "tree", d->ctx.sharded ? "sharded" : "whole");
    gs_json_u64(phase, "tree_bytes_rank_max", tree_peak_max);
    gs_json_i64(phase, "blocks", u);
    gs_json_i64(phase, "blocks_this_run", here);
    gs_json_f64(phase, "blocks_per_second", syn_s > 0 ? (double)here / syn_s : 0.0);
    gs_json_i64(phase, "colors_in_regions", d->region_colors);
    gs_json_i64(phase, "colors_in_order", d->serial_colors);
    gs_json_begin_object(phase, "rank0_seconds");
    gs_json_f64(phase, "iteration_setup", d->t_setup);
    gs_json_f64(phase, "in_order", d->t_order);
    gs_json_f64(phase, "regions_compute", d->rt.compute);
    gs_json_f64(phase, "regions_wait", d->rt.wait);
    gs_json_f64(phase, "regions_exchange", d->rt.exchange);
    gs_json_f64(phase, "regions_apply", d->rt.apply);
    gs_json_end_object(phase);
    gs_json_i64(phase, "rank0_regions", d->rt.regions);
    gs_json_i64(phase, "queries_local", d->ctx.local_queries);
    gs_json_i64(phase, "queries_spread", run->size > 1 ? d->ctx.queries - d->ctx.local_queries : 0);
    gs_json_u64(phase, "search_pops_rank_max", pops_max);
    return GS_OK;
}

/* The result, redistanced (rank 0, broadcast), field.h5, the quality
 * measures with the distributed matcher, the meshes and pictures (rank 0). */
static gs_err field_output_op(void *state, gs_run *run, gs_json *phase, uint64_t *digest_out)
{
    field_drive *d = state;
    const field_config *c = d->c;
    const gs_qfield *q = d->src.q;
    const gs_field_synth_state *st = gs_field_synth_get_state(d->synth);
    gs_err err = GS_OK;
    GS_TRY(err, gs_field_synth_result(d->synth, &d->res), fail);
    d->res->spacing = q->spacing;
    GS_TRY(err, gs_qfield_dequantize(d->res, &d->resf), fail);
    uint64_t digest = gs_digest_bytes(d->res->q, (size_t)(d->res->nx * d->res->ny * d->res->nz));
    double step_synth = 0, step_redist = 0, t_redist = gs_time_now();
    if (run->rank == 0) {
        int64_t rn[3] = {d->resf->nx, d->resf->ny, d->resf->nz};
        step_synth = gs_field_step_violations(d->resf->v, rn, d->resf->spacing, 1.5);
        err = redistance_rank0(run, c, d->resf);
        step_redist = gs_field_step_violations(d->resf->v, rn, d->resf->spacing, 1.5);
    }
    GS_TRY(err, gs_par_agree(run->comm, err), fail);
    GS_TRY(err, gs_par_bcast_bytes(run->comm, d->resf->v,
                                   (size_t)(d->resf->nx * d->resf->ny * d->resf->nz) * sizeof *d->resf->v, 0),
           fail);
    t_redist = gs_time_now() - t_redist;
    GS_TRY(err, write_field_h5(run, d->res, d->resf, q), fail);
    /* quality: coherence needs the nearest source block of every output
     * block; every rank runs the measure with the distributed matcher of
     * the synthesis (match_block): sharded, each rank searches its slab of
     * the full-resolution tree; whole, each tries a query alone and the
     * long ones are spread over the ranks' subtrees. Same figures on every
     * rank and for any rank count. */
    gs_field_quality qm;
    memset(&qm, 0, sizeof qm);
    gs_err qerr = GS_OK;
    double tq = gs_time_now();
    qerr = gs_field_tree_build_shard(q, (int)c->block, d->ctx.sharded ? run->size : 1, run->rank,
                                     &d->ctx.qtree);
    if (!qerr && d->ctx.qtree)
        qerr = gs_field_searcher_create(d->ctx.qtree, &d->ctx.qsearcher);
    GS_TRY(err, gs_par_agree(run->comm, qerr), fail);
    GS_TRY(err, gs_field_quality_measure_with(d->res, q, (int)c->block, quality_match, &d->ctx, &qm), fail);
    double quality_s = gs_time_now() - tq;
    gs_err lerr = GS_OK;
    if (run->rank == 0) {
        double tg = gs_time_now();
        lerr = write_geometry_rank0(run, c, &d->src, d->resf, d->ctx.prov, phase);
        if (!lerr && is_heightmap_example(c)) {
            /* Figure 7c: the synthesized height map as the example was read */
            char hp[PATH_MAX];
            gs_run_path(run, "heightmap.png", hp, sizeof hp);
            lerr = gs_field_write_heightmap(d->resf, ((double)c->depth - c->height) / 2, c->height, hp);
            if (!lerr)
                gs_run_output(run, "image", "heightmap", "heightmap.png", NULL);
        }
        gs_json_f64(phase, "geometry_seconds", gs_time_now() - tg);
        gs_json_f64(phase, "redistance_seconds", t_redist);
        gs_run_metric_f64(run, "step_violations_synthesized", step_synth);
        gs_run_metric_f64(run, "step_violations_redistanced", step_redist);
        gs_log(GS_LOG_INFO, "redistanced into a level set (%.2f s): steps > 1.5 samples between "
                            "neighbours %.4f -> %.4f", t_redist, step_synth, step_redist);
        /* quality of the output against the source */
        for (int i = 0; i < d->sc.iterations; i++) {
            char k[64];
            double mean = st->stat_count[i] ? st->stat_sum[i] / (double)st->stat_count[i] : 0;
            snprintf(k, sizeof k, "match_mean_it%d", i);
            gs_run_metric_f64(run, k, mean);
            snprintf(k, sizeof k, "match_min_it%d", i);
            gs_run_metric_f64(run, k, st->stat_count[i] ? st->stat_min[i] : 0);
            snprintf(k, sizeof k, "match_max_it%d", i);
            gs_run_metric_f64(run, k, st->stat_max[i]);
            snprintf(k, sizeof k, "match_blocks_it%d", i);
            gs_run_metric_i64(run, k, st->stat_count[i]);
            /* search work: queue pops, and pushes (best-first, the upper
             * bound of eq. 3 cannot save pops, only the entries it keeps out
             * of the queue) */
            snprintf(k, sizeof k, "match_pops_it%d", i);
            gs_run_metric_i64(run, k, (int64_t)st->stat_pops[i]);
            snprintf(k, sizeof k, "match_pushes_it%d", i);
            gs_run_metric_i64(run, k, (int64_t)st->stat_pushes[i]);
        }
        int last = d->sc.iterations - 1;
        gs_run_metric_f64(run, "match_mean", st->stat_sum[last] / (double)(st->stat_count[last] ? st->stat_count[last] : 1));
        /* coarse guidance: share of the copied samples whose sign differs
         * from the upsampled coarse result they replace, over the share
         * expected between two unrelated samples of the source, 2 v (1 - v)
         * (v: its volume fraction): ~0 follows the coarse result, ~1 ignores it */
        {
            int64_t nq = q->nx * q->ny * q->nz, in = 0;
            for (int64_t i = 0; i < nq; i++)
                in += gs_qfield_value(q, q->q[i]) < 0;
            double v = (double)in / (double)nq, unrelated = 2 * v * (1 - v), worst = 0;
            for (int i = 1; i < d->sc.iterations; i++) {
                char k[64];
                double dep = st->stat_coarse_n[i] && unrelated > 0
                                 ? (double)st->stat_coarse_flips[i] / (double)st->stat_coarse_n[i] /
                                       unrelated
                                 : 0;
                snprintf(k, sizeof k, "coarse_departure_it%d", i);
                gs_run_metric_f64(run, k, dep);
                if (dep > worst)
                    worst = dep;
            }
            gs_run_metric_f64(run, "coarse_departure", worst);
        }
        gs_field_geometry_report gr;
        if (!lerr)
            lerr = gs_field_geometry_measure(d->res, q, (int)c->block, &gr);
        if (!lerr)
            report_geometry(run, &gr, phase);
        /* seconds: rank 0's mesh outputs, the quality measure (its trees included) */
        gs_json_f64(phase, "quality_seconds", quality_s);
        if (!lerr) {
            gs_run_metric_f64(run, "volume_fraction_out", qm.volume_fraction_out);
            gs_run_metric_f64(run, "volume_fraction_src", qm.volume_fraction_src);
            gs_run_metric_f64(run, "surface_per_volume_out", qm.surface_per_volume_out);
            gs_run_metric_f64(run, "surface_per_volume_src", qm.surface_per_volume_src);
            gs_run_metric_f64(run, "coherence", qm.coherence);
            gs_run_metric_i64(run, "coherence_blocks", qm.coherence_blocks);
            gs_run_metric_f64(run, "verbatim_share", qm.verbatim);
            gs_run_metric_i64(run, "verbatim_run", qm.longest_run);
            gs_log(GS_LOG_INFO,
                   "quality: volume fraction %.4f (source %.4f), surface/volume %.4f (source "
                   "%.4f), coherence %.2f, verbatim blocks %.3f (longest copied run %lld), "
                   "mean match %.2f (%.1f s)",
                   qm.volume_fraction_out, qm.volume_fraction_src, qm.surface_per_volume_out,
                   qm.surface_per_volume_src, qm.coherence, qm.verbatim, (long long)qm.longest_run,
                   st->stat_sum[last] / (double)(st->stat_count[last] ? st->stat_count[last] : 1),
                   gs_time_now() - tq);
        }
    }
    err = gs_par_agree(run->comm, lerr);
    *digest_out = digest;
fail:
    return err;
}

static void field_destroy(void *state)
{
    field_drive *d = state;
    if (!d)
        return;
    gs_field_searcher_destroy(&d->ctx.qsearcher);
    gs_field_tree_destroy(&d->ctx.qtree);
    gs_psearch_destroy(&d->ctx.ps);
    gs_field_synth_destroy(&d->synth);
    gs_free(d->ctx.prov);
    gs_qfield_destroy(&d->res);
    gs_field_destroy(&d->resf);
    source_free(&d->src);
    gs_free(d);
}

static const gs_engine_ops field_ops = {
    .setup = field_setup_op,
    .restore = field_restore,
    .units = field_units,
    .advance = field_advance,
    .save = field_save,
    .synthesis_report = field_synthesis_report,
    .output = field_output_op,
    .destroy = field_destroy,
};

const gs_engine gs_engine_field = {
    "field",
    "distance-field geometry synthesis from a mesh, level set, height map or built-in example "
    "(Lagae et al.)",
    &field_table,
    sizeof(field_config),
    offsetof(field_config, run),
    &field_ops,
};
