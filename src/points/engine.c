/* The `points` engine: patch-based synthesis of geometry textures on
 * point-set surfaces (Duranleau and Poulin) behind `geosynth points -c X.ini`.
 *
 * Input (section [input]): an oriented point set (PLY with normals), a
 * triangle mesh sampled uniformly (Poisson disk), or one of the paper's
 * generated examples (height field from an image, chain mail, weave,
 * flowers). User geometry comes with its box B_Tin (input.box_lo/box_hi) and
 * the axis normal to its reference plane (input.up); the core works with z
 * up, so points are permuted cyclically to z-up and back for the output.
 *
 * Parallel model: every rank holds the whole synthesis state (output point
 * grid, RNG, metrics) and does the same deterministic steps; the search over
 * the input patches is distributed: each rank's patch bank holds only its
 * share [lo, hi) of gs_partition's split, each rank scans it and one
 * all-gather brings every candidate under (1 + eps) * global best, sorted by
 * (distance, index), to every rank (distributed_search). Each patch's distance is summed in a fixed order
 * independent of the partition, so Psi_k, the random pick and therefore the
 * output are bit-identical for any rank count.
 *
 * Rank 0 reads/generates the example and broadcasts it. Work units for
 * checkpoints are placed patches; checkpoint.h5 holds /points: cursor, RNG
 * state, the output points (bucket order), the per-patch metrics, and the
 * digest of the example (a resume refuses a changed example).
 *
 * Outputs in RUN_DIR: points.ply (x y z nx ny nz, doubles), optionally
 * mesh.ply (implicit function of the points on a dense grid, contoured by
 * OpenVDB), patches.csv (per-patch metrics); summary.json metrics: search
 * distances, warp residual, densities, search/warp/blend/other/relax times.
 *
 * Errors (STYLE.md: MPI code never hangs on error). A failure that every
 * rank learns in the same exchange (a status word travels in the search
 * all-gather and in the map all-gather; rank 0's set-up and output go
 * through gs_par_agree) is collective: every rank returns the same gs_err
 * (the failing one with its message, the others with "rank N failed: ...")
 * and the run ends cleanly with one report (gs_run.failed_together). Any
 * other failure is local to one rank (an allocation, a merge, the warp's
 * solve, the paste, between two exchanges): points_run ends it with
 * gs_fatal(err, 0) at once, before any clean-up collective, so MPI_Abort
 * stops every rank wherever it waits. No extra collective per patch.
 */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/config.h"
#include "geosynth/digest.h"
#include "geosynth/engine.h"
#include "geosynth/file.h"
#include "geosynth/h5.h"
#include "geosynth/image.h"
#include "geosynth/json.h"
#include "geosynth/log.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/par.h"
#include "geosynth/parse.h"
#include "geosynth/pmap.h"
#include "geosynth/pointply.h"
#include "geosynth/preview.h"
#include "geosynth/points.h"
#include "geosynth/partition.h"
#include "geosynth/run.h"
#include "geosynth/vdb.h"

_Static_assert(sizeof(gs_opoint) == 6 * sizeof(double), "gs_opoint must be 6 packed doubles");

typedef struct points_config {
    /* [input] */
    char *kind;
    char *path;
    gs_cfg_real_list size;
    int64_t cells;
    int periodic;
    double spacing;
    double height_scale;
    double pad;
    gs_cfg_real_list box_lo, box_hi;
    char *up;
    int64_t input_seed;
    /* [points] */
    gs_cfg_real_list out_size;
    double out_points;
    double field_step;
    int64_t patch_cells, overlap_cells, extra_cells;
    double mls_radius, trunc, eps, warp_margin;
    double w_p, w_n, w_v, w_l, w_d;
    double max_pair_dist, max_normal, max_variation, coherence_sigma, variation_radius;
    int64_t greedy_iterations, cluster_max, max_pairs, relax_iterations;
    double tps_lambda;
    int blend, ray_blend, warp_select, objects;
    /* [output] */
    int write_points;
    char *ply_format;
    int patch_csv;
    int mesh;
    double mesh_voxel;
    int preview;
    double mesh_max_samples;
    gs_run_config run;
} points_config;

#define PC points_config
static const gs_cfg_key points_keys[] = {
    GS_CFG_KEY_ENUM(PC, kind, "input.kind", "heightfield|chainmail|weave|flowers|ply|mesh",
                    "chainmail",
                    "example: a generated texture of the paper's kinds, an oriented point set "
                    "(ply) or a triangle mesh sampled uniformly (mesh)"),
    GS_CFG_KEY_PATH(PC, path, "input.path", "",
                    "ply: PLY with x y z nx ny nz; mesh: OBJ/PLY/STL/OFF; heightfield: "
                    "grey image (PNG/JPEG)"),
    GS_CFG_KEY_REAL_LIST(PC, size, "input.size", 0, 1e6, GS_CFG_OPEN_LO, "4, 4",
                         "generated examples: box extent along x and y"),
    GS_CFG_KEY_INT(PC, cells, "input.cells", 1, 64, 0, "4",
                   "generated examples: lattice cells (rings, threads, flower spacing) across x"),
    GS_CFG_KEY_BOOL(PC, periodic, "input.periodic", "false",
                    "chainmail/weave: rings and threads exactly on the lattice (a tileable "
                    "example); false = jittered off it with varying sizes, like the paper's"),
    GS_CFG_KEY_REAL(PC, spacing, "input.spacing", 0, 1e6, 0, "0.033",
                    "sampling spacing (Poisson-disk radius) of generated and mesh examples; "
                    "ply: 0 = estimate from the points"),
    GS_CFG_KEY_REAL(PC, height_scale, "input.height_scale", -1e6, 1e6, 0, "0.6",
                    "heightfield: height of a white pixel"),
    GS_CFG_KEY_REAL(PC, pad, "input.pad", 0, 1e6, 0, "0",
                    "generated examples: geometry beyond every side of the box (0 = 1.2 x what "
                    "the parameters need)"),
    GS_CFG_KEY_REAL_LIST(PC, box_lo, "input.box_lo", -1e300, 1e300, 0, "",
                         "ply/mesh: low corner x y z of the box B_Tin (geometry must continue "
                         "past its sides)"),
    GS_CFG_KEY_REAL_LIST(PC, box_hi, "input.box_hi", -1e300, 1e300, 0, "",
                         "ply/mesh: high corner x y z of the box B_Tin"),
    GS_CFG_KEY_ENUM(PC, up, "input.up", "x|y|z", "z",
                    "ply/mesh: axis normal to the reference plane (the texture's height axis)"),
    GS_CFG_KEY_INT(PC, input_seed, "input.seed", 0, GS_CFG_INT_MAX, 0, "2007",
                   "seed of the example's generation or mesh sampling (run.seed drives synthesis)"),
    GS_CFG_KEY_REAL_LIST(PC, out_size, "points.out_size", 0, 1e6, GS_CFG_OPEN_LO, "",
                         "output extent along the two plane axes (empty = from out_points, or "
                         "2 x the box)"),
    GS_CFG_KEY_REAL(PC, out_points, "points.out_points", 0, 1e9, 0, "0",
                    "wanted output points: scales the box so the output holds about this many "
                    "(0 = use out_size)"),
    GS_CFG_KEY_REAL(PC, field_step, "points.field_step", 0, 1e6, 0, "0",
                    "node spacing of the distance fields D (0 = max(1.5 spacing, box/40))"),
    GS_CFG_KEY_INT(PC, patch_cells, "points.patch_cells", 0, 1024, 0, "0",
                   "patch edge in field steps (0 = 0.4 x box side)"),
    GS_CFG_KEY_INT(PC, overlap_cells, "points.overlap_cells", 0, 1023, 0, "0",
                   "overlap strip width in field steps (0 = patch/4)"),
    GS_CFG_KEY_INT(PC, extra_cells, "points.extra_cells", 0, 1024, 0, "0",
                   "extra region w_E in field steps (0 = patch/4 rounded up)"),
    GS_CFG_KEY_REAL(PC, mls_radius, "points.mls_radius", 0, 1e6, 0, "0",
                    "radius of the MLS weights (0 = 3 spacing)"),
    GS_CFG_KEY_REAL(PC, trunc, "points.trunc", 0, 1e6, 0, "0",
                    "distance truncation of the fields (0 = 2 field steps)"),
    GS_CFG_KEY_REAL(PC, eps, "points.eps", 0, 100, 0, "0.1",
                    "candidate tolerance: patches within (1 + eps) x best are picked at random"),
    GS_CFG_KEY_REAL(PC, warp_margin, "points.warp_margin", 0, 1e6, 0, "0",
                    "extension of F_k before warping (0 = max(3 spacing, field step))"),
    GS_CFG_KEY_REAL(PC, w_p, "points.w_p", 0, 1e6, 0, "1", "pairing weight of positions (eq. 2)"),
    GS_CFG_KEY_REAL(PC, w_n, "points.w_n", 0, 1e6, 0, "1", "pairing weight of normals (table 1)"),
    GS_CFG_KEY_REAL(PC, w_v, "points.w_v", 0, 1e6, 0, "10",
                    "pairing weight of surface variation (table 1)"),
    GS_CFG_KEY_REAL(PC, w_l, "points.w_l", 0, 1e6, 0, "8", "pairing weight w_l (table 1)"),
    GS_CFG_KEY_REAL(PC, w_d, "points.w_d", 0, 1e6, 0, "6", "pairing weight w_d (table 1)"),
    GS_CFG_KEY_REAL(PC, max_pair_dist, "points.max_pair_dist", 0, 1e6, 0, "0",
                    "largest pair distance (0 = max(3 spacing, overlap/2))"),
    GS_CFG_KEY_REAL(PC, max_normal, "points.max_normal", 0, 1, 0, "0.5",
                    "largest normal difference (1 - n.n)/2 of a pair"),
    GS_CFG_KEY_REAL(PC, max_variation, "points.max_variation", 0, 1, 0, "0.1",
                    "largest surface-variation difference of a pair"),
    GS_CFG_KEY_REAL(PC, coherence_sigma, "points.coherence_sigma", 0, 1e6, 0, "0",
                    "width of the pairing coherence term (0 = overlap/2)"),
    GS_CFG_KEY_REAL(PC, variation_radius, "points.variation_radius", 0, 1e6, 0, "0",
                    "radius of the surface variation (0 = 2.5 spacing)"),
    GS_CFG_KEY_INT(PC, greedy_iterations, "points.greedy_iterations", 0, 100, 0, "3",
                   "greedy improvement passes of the pairing"),
    GS_CFG_KEY_INT(PC, cluster_max, "points.cluster_max", 1, 100000, 0, "12",
                   "points per cluster of the target set Q (at least)"),
    GS_CFG_KEY_INT(PC, max_pairs, "points.max_pairs", 4, 5000, 0, "48",
                   "clusters grow so |Q| stays near this (thin-plate spline size)"),
    GS_CFG_KEY_INT(PC, relax_iterations, "points.relax_iterations", 0, 100, 0, "1",
                   "relaxation passes over the output at the end"),
    GS_CFG_KEY_REAL(PC, tps_lambda, "points.tps_lambda", 0, 1e6, 0, "0",
                    "thin-plate spline smoothing (0 = interpolate)"),
    GS_CFG_KEY_BOOL(PC, warp_select, "points.warp_select", "true",
                    "each patch takes the spline of the pairs, the spline of their normal parts, "
                    "or no warp, whichever leaves it closest to the output in the overlap "
                    "(false = always the pairs' spline, the paper's)"),
    GS_CFG_KEY_BOOL(PC, blend, "points.blend", "true",
                    "blend the overlap strips onto the output (paper section 5.3); false pastes "
                    "the warped patch as it is (to measure what the blend does)"),
    GS_CFG_KEY_BOOL(PC, ray_blend, "points.ray_blend", "true",
                    "blend by ray intersection (paper fig. 3d); false = projection"),
    GS_CFG_KEY_BOOL(PC, objects, "points.objects", "true",
                    "paste the example's disconnected objects (flowers, rings: pieces no wider "
                    "than half a patch, whole in the example) whole or not at all, each by the "
                    "patch holding its centre; false = every point by its position (the paper: "
                    "objects cut at the seams)"),
    GS_CFG_KEY_BOOL(PC, write_points, "output.points", "true", "write RUN_DIR/points.ply"),
    GS_CFG_KEY_ENUM(PC, ply_format, "output.ply_format", "binary|ascii", "binary",
                    "points.ply encoding (both exact: doubles / 17 digits)"),
    GS_CFG_KEY_BOOL(PC, patch_csv, "output.patch_metrics", "true",
                    "write RUN_DIR/patches.csv (per-patch search distance, warp residual, ...)"),
    GS_CFG_KEY_BOOL(PC, mesh, "output.mesh", "false",
                    "also write RUN_DIR/mesh.ply (points -> implicit grid -> OpenVDB mesh)"),
    GS_CFG_KEY_BOOL(PC, preview, "output.preview", "true",
                    "write RUN_DIR/preview.png: the example and the output (up to twice the "
                    "example's extent) meshed and rendered side by side"),
    GS_CFG_KEY_REAL(PC, mesh_voxel, "output.mesh_voxel", 0.1, 100, 0, "1",
                    "mesh grid voxel in units of the input spacing"),
    GS_CFG_KEY_REAL(PC, mesh_max_samples, "output.mesh_max_samples", 1e3, 4e9, 0, "2e8",
                    "refuse a mesh grid with more samples than this (4 bytes each + 16 scratch)"),
    GS_CFG_RUN_KEYS(PC, run, "points"),
};
#undef PC

static int kind_is(const points_config *c, const char *k) { return !strcmp(c->kind, k); }

/* An example the user gives (read by rank 0), not one generated here. */
static int kind_is_user(const points_config *c) { return kind_is(c, "ply") || kind_is(c, "mesh"); }

static void points_validate(const void *vcfg, gs_cfg_ctx *ctx)
{
    const points_config *c = vcfg;
    int user = kind_is_user(c);
    if ((user || kind_is(c, "heightfield")) && !c->path[0])
        gs_cfg_report(ctx, "input.path", "is required for input.kind = %s", c->kind);
    if (user) {
        if (c->box_lo.n != 3)
            gs_cfg_report(ctx, "input.box_lo", "needs 3 numbers (x y z) for input.kind = %s, got %lld",
                          c->kind, (long long)c->box_lo.n);
        if (c->box_hi.n != 3)
            gs_cfg_report(ctx, "input.box_hi", "needs 3 numbers (x y z) for input.kind = %s, got %lld",
                          c->kind, (long long)c->box_hi.n);
        if (c->box_lo.n == 3 && c->box_hi.n == 3)
            for (int a = 0; a < 3; a++)
                if (!(c->box_hi.v[a] > c->box_lo.v[a]) && !(a == (c->up[0] - 'x') &&
                                                             c->box_hi.v[a] >= c->box_lo.v[a]))
                    gs_cfg_report(ctx, "input.box_hi", "must exceed input.box_lo on axis %c "
                                  "(%g <= %g)", 'x' + a, c->box_hi.v[a], c->box_lo.v[a]);
    } else {
        if (c->size.n != 2)
            gs_cfg_report(ctx, "input.size", "needs 2 numbers (x y), got %lld", (long long)c->size.n);
        if (c->spacing <= 0)
            gs_cfg_report(ctx, "input.spacing", "must be > 0 for generated examples");
    }
    if (kind_is(c, "mesh") && c->spacing <= 0)
        gs_cfg_report(ctx, "input.spacing", "must be > 0 to sample a mesh");
    if (c->out_size.n != 0 && c->out_size.n != 2)
        gs_cfg_report(ctx, "points.out_size", "needs 2 numbers or none, got %lld",
                      (long long)c->out_size.n);
    if (c->out_size.n && c->out_points > 0)
        gs_cfg_report(ctx, "points.out_points", "and points.out_size both set: give one of them");
    if (c->patch_cells && c->overlap_cells && c->overlap_cells >= c->patch_cells)
        gs_cfg_report(ctx, "points.overlap_cells", "must be below points.patch_cells = %lld",
                      (long long)c->patch_cells);
    if (c->patch_cells && c->patch_cells < 3)
        gs_cfg_report(ctx, "points.patch_cells", "must be 0 (auto) or >= 3");
}

static const gs_cfg_table points_table =
    GS_CFG_TABLE("points", points_config, points_keys, points_validate);

/* ------------------------------------------------------------------ input */

static int up_axis(const points_config *c) { return c->up[0] - 'x'; }

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
    p->blend = c->blend;
    p->ray_blend = c->ray_blend;
    p->objects = c->objects;
    p->warp_select = c->warp_select;
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

/* Every rank, with the map hook (see gs_points_gen_params) when there are
 * several; defined with the exchanges below. */
typedef struct map_state map_state;
static gs_err mpi_map(void *user, size_t n, size_t bytes, gs_points_range_fn fn, void *ctx,
                      void *out);
static gs_err map_agree(void *user, gs_err local);

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
                               (uint64_t)c->input_seed, c->periodic, ms ? mpi_map : NULL, ms,
                               ms ? map_agree : NULL};
    if (kind_is(c, "heightfield")) {
        int w = 0, h = 0;
        float *img = NULL;
        gs_err err = read_heightmap(c->path, &w, &h, &img);
        if (ms)
            err = map_agree(ms, err); /* every rank reads the image */
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
        GS_CALL(gs_points_reserve(&tex->pts, n));
        tex->pts.n = n;
    }
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

/* --------------------------------------------------------- fault injection */

/* Test-only hook (tests/e2e/mpi_errors_points.sh): GS_FAIL_RANK=R
 * GS_FAIL_POINTS_AT=SITE@K makes rank R fail at SITE while it places patch K
 * (0-based; default 1), to prove that no failure leaves a rank hung. SITE:
 *   map-alloc     the map exchange cannot allocate its buffers (before it)
 *   map-fn        a map callback (query nodes, warp + blend) fails
 *   search-scan   the scan of this rank's share fails (before the exchange)
 *   search-merge  the merge after the exchange fails (it allocates)
 *   step          after the step's last exchange (like a failed warp solve
 *                 or paste: local, between two exchanges)
 *   generate      (no @K) a local failure while every rank generates the
 *                 example, at the generator's first agreement (gen_agree)
 * Unset (the normal case) it costs one int test per exchange. */
enum { FAULT_NONE, FAULT_MAP_ALLOC, FAULT_MAP_FN, FAULT_SEARCH_SCAN, FAULT_SEARCH_MERGE,
       FAULT_STEP, FAULT_GENERATE };

typedef struct fault_inject {
    int site;       /* FAULT_*, FAULT_NONE when not injecting on this rank */
    uint64_t patch; /* the patch during which it fires */
    int armed;      /* set while this rank places that patch */
} fault_inject;

static const char *const fault_sites[] = {"",           "map-alloc", "map-fn", "search-scan",
                                          "search-merge", "step",      "generate"};

/* Reads GS_FAIL_RANK / GS_FAIL_POINTS_AT for this rank. */
static gs_err fault_init(fault_inject *f, int rank)
{
    memset(f, 0, sizeof *f);
    const char *at = getenv("GS_FAIL_POINTS_AT"), *r = getenv("GS_FAIL_RANK");
    if (!at || !at[0])
        return GS_OK;
    char why[128];
    int64_t fr = 0;
    GS_CHECK(!r || !r[0] || gs_parse_i64(r, 0, INT_MAX, &fr, why, sizeof why), GS_ERR_USAGE,
             "GS_FAIL_RANK = '%s': expected a rank (%s)", r, why);
    const char *k = strchr(at, '@');
    size_t len = k ? (size_t)(k - at) : strlen(at);
    int site = FAULT_NONE;
    for (int i = 1; i < (int)(sizeof fault_sites / sizeof *fault_sites); i++)
        if (strlen(fault_sites[i]) == len && !strncmp(at, fault_sites[i], len))
            site = i;
    GS_CHECK(site != FAULT_NONE, GS_ERR_USAGE, "GS_FAIL_POINTS_AT = '%s': expected SITE[@PATCH], "
             "SITE one of map-alloc map-fn search-scan search-merge step generate", at);
    int64_t patch = 1;
    GS_CHECK(!k || gs_parse_i64(k + 1, 0, INT64_MAX, &patch, why, sizeof why), GS_ERR_USAGE,
             "GS_FAIL_POINTS_AT = '%s': expected a patch index after '@' (%s)", at, why);
    if (fr == rank) {
        f->site = site;
        f->patch = (uint64_t)patch;
    }
    return GS_OK;
}

/* 1 when the injected failure fires here (and then never again). */
static int fault_fires(fault_inject *f, int site)
{
    if (!f || !f->armed || f->site != site)
        return 0;
    f->armed = 0;
    f->site = FAULT_NONE;
    return 1;
}

static gs_err fault_raise(const fault_inject *f, int site, gs_err code)
{
    if (site == FAULT_GENERATE)
        return gs_error_raise(code, __FILE__, __LINE__, __func__,
                              "points: injected failure at generate (GS_FAIL_POINTS_AT)");
    return gs_error_raise(code, __FILE__, __LINE__, __func__,
                          "points: injected failure at %s of patch %llu (GS_FAIL_POINTS_AT)",
                          fault_sites[site], (unsigned long long)f->patch);
}

/* gs_par_agree that remembers a collective failure in *together (every rank
 * returned it from the same collective: the run may end without MPI_Abort). */
static gs_err agree(int *together, MPI_Comm comm, gs_err local)
{
    gs_err err = gs_par_agree(comm, local);
    if (err != GS_OK)
        *together = 1;
    return err;
}

/* -------------------------------------------------------- distributed search */

/* Candidates a rank sends in the one exchange of a search; a rank with more
 * (rare: the mean |Psi_k| is 1 to 2) makes every rank gather again. */
#define SEARCH_SLOTS 32

typedef struct search_ctx {
    MPI_Comm comm;
    int rank, size;
    int64_t lo, hi;        /* this rank's share of the patches */
    double scale;          /* 1 + eps */
    gs_points_cands local; /* offers of this rank's scan */
    int oom;               /* an offer could not be stored (reported after the scan) */
    int64_t offers, regathers;
    fault_inject *fault;
    int *together;         /* set on a failure every rank returns (see agree) */
    /* Exchange buffers, sized by the rank count at set-up (search_ctx_alloc)
     * so a search allocates nothing before its exchange. */
    int64_t *all;          /* size x REC words */
    gs_points_cands *parts;
    int *counts;           /* counts, then displacements */
} search_ctx;

enum { SEARCH_REC = 2 + 2 * SEARCH_SLOTS }; /* int64 words per rank in the exchange */

static gs_err search_ctx_alloc(search_ctx *c)
{
    GS_CALL(gs_alloc_array((void **)&c->all, (size_t)c->size, SEARCH_REC * sizeof *c->all,
                           "search exchange"));
    GS_CALL(gs_alloc_array((void **)&c->parts, (size_t)c->size, sizeof *c->parts,
                           "search parts"));
    GS_CALL(gs_alloc_array((void **)&c->counts, (size_t)c->size, 2 * sizeof *c->counts,
                           "search parts"));
    return GS_OK;
}

static void search_ctx_free(search_ctx *c)
{
    gs_points_cands_free(&c->local);
    GS_FREE(c->all);
    GS_FREE(c->parts);
    GS_FREE(c->counts);
}

static double local_bound(void *user)
{
    search_ctx *c = user;
    return c->scale * c->local.best;
}

static void local_offer(void *user, double d, uint64_t index)
{
    search_ctx *c = user;
    gs_points_cands *o = &c->local;
    c->offers++;
    if (c->oom)
        return;
    if (o->n == o->cap) {
        size_t cap = o->cap ? 2 * o->cap : 64;
        gs_points_cand *v = gs_realloc(o->v, cap * sizeof *v);
        if (!v) {
            c->oom = 1;
            return;
        }
        o->v = v;
        o->cap = cap;
    }
    o->v[o->n].dist = d;
    o->v[o->n++].index = index;
    if (d < o->best)
        o->best = d;
}

/* gs_points_search_fn: Psi_k over all ranks (collective). Each rank scans
 * its share with its own running bound (every patch within (1 + eps) x its
 * best: a superset of its part of Psi_k, since its best is >= the global
 * one), then one MPI_Allgather of {status, count, SEARCH_SLOTS candidates}
 * per rank, and gs_points_search_merge keeps exactly the serial Psi_k. One
 * exchange per patch instead of psearch's four plus bound messages: on a
 * shared machine every exchange waits for the slowest rank, and the scan is
 * a small part of a step, so a shared bound saves less than it costs. */
static gs_err distributed_search(void *user, const gs_points_synth *s, const float *query,
                                 int mode, double eps, gs_points_cands *out)
{
    search_ctx *c = user;
    const gs_points_bank *bank = gs_points_synth_bank(s);
    c->scale = 1.0 + eps;
    c->local.n = 0;
    c->local.best = INFINITY;
    c->oom = 0;
    gs_err status = GS_OK;
    if (c->hi > c->lo)
        status = gs_points_search_scan(bank, query, mode, (uint64_t)c->lo, (uint64_t)c->hi,
                                       local_bound, local_offer, c);
    if (status == GS_OK && c->oom)
        status = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                "points: out of memory (search candidates)");
    if (status == GS_OK && fault_fires(c->fault, FAULT_SEARCH_SCAN))
        status = fault_raise(c->fault, FAULT_SEARCH_SCAN, GS_ERR_INTERNAL);
    /* Only what can survive the merge is sent. */
    size_t kept = 0;
    if (status == GS_OK)
        for (size_t i = 0; i < c->local.n; i++)
            if (c->local.v[i].dist <= c->scale * c->local.best)
                c->local.v[kept++] = c->local.v[i];
    c->local.n = kept;
    enum { REC = SEARCH_REC };
    int64_t mine[REC];
    memset(mine, 0, sizeof mine);
    mine[0] = (int64_t)status;
    mine[1] = (int64_t)kept;
    for (size_t i = 0; i < kept && i < SEARCH_SLOTS; i++) {
        memcpy(&mine[2 + 2 * i], &c->local.v[i].dist, sizeof(double));
        mine[3 + 2 * i] = (int64_t)c->local.v[i].index;
    }
    int64_t *all = c->all;
    gs_points_cands *parts = c->parts; /* views into more */
    gs_points_cand *more = NULL;
    int *counts = c->counts;
    gs_err err = GS_OK;
    GS_TRY(err, gs_par_allgather_bytes(c->comm, mine, sizeof mine, all), done);
    int failed = 0, overflow = 0;
    int64_t total = 0;
    for (int r = 0; r < c->size; r++) {
        failed |= all[(size_t)r * REC] != GS_OK;
        overflow |= all[(size_t)r * REC + 1] > SEARCH_SLOTS;
        total += all[(size_t)r * REC + 1];
    }
    if (failed) {
        err = agree(c->together, c->comm, status);
        goto done;
    }
    if (total > INT_MAX / (int64_t)sizeof *more) { /* every rank sees the same total */
        *c->together = 1;
        err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                             "points: %lld search candidates within (1 + %g) x best are too many "
                             "for one exchange: lower points.eps", (long long)total, eps);
        goto done;
    }
    GS_TRY(err, gs_alloc_array((void **)&more, total ? (size_t)total : 1, sizeof *more,
                               "search candidates"), done);
    int *displs = counts + c->size, off = 0;
    for (int r = 0; r < c->size; r++) {
        int64_t nr = all[(size_t)r * REC + 1];
        parts[r].v = more + off;
        parts[r].n = (size_t)nr;
        counts[r] = (int)nr * (int)sizeof *more;
        displs[r] = off * (int)sizeof *more;
        for (int64_t i = 0; i < nr && !overflow; i++) {
            memcpy(&more[off + i].dist, &all[(size_t)r * REC + 2 + 2 * i], sizeof(double));
            more[off + i].index = (uint64_t)all[(size_t)r * REC + 3 + 2 * i];
        }
        off += (int)nr;
    }
    if (overflow) { /* every rank saw it: all gather every candidate */
        c->regathers++;
        GS_TRY(err, gs_par_allgatherv_bytes(c->comm, c->local.v, more, counts, displs), done);
    }
    /* After the exchange a failure (the allocations of more and of the
     * merge) is local: points_run aborts every rank. */
    if (fault_fires(c->fault, FAULT_SEARCH_MERGE)) {
        err = fault_raise(c->fault, FAULT_SEARCH_MERGE, GS_ERR_MEM);
        goto done;
    }
    GS_TRY(err, gs_points_search_merge(parts, c->size, eps, out), done);
done:
    gs_free(more);
    return err;
}

/* The map hook over the ranks: gs_pmap (include/geosynth/pmap.h) with the
 * test faults "map-alloc" and "map-fn" and the agreement that remembers a
 * collective failure. */
struct map_state {
    gs_pmap pm;
    fault_inject *fault;
    int *together; /* set on a failure every rank returns (see agree) */
};

/* gs_points_gen_params.agree over the ranks (user: map_state). The
 * "generate" fault is a local failure of this rank at the generator's first
 * agreement. */
static gs_err map_agree(void *user, gs_err local)
{
    map_state *m = user;
    if (local == GS_OK && fault_fires(m->fault, FAULT_GENERATE))
        local = fault_raise(m->fault, FAULT_GENERATE, GS_ERR_INTERNAL);
    return agree(m->together, m->pm.comm, local);
}

static gs_err map_hook_computed(void *user, gs_err local)
{
    map_state *m = user;
    if (local == GS_OK && fault_fires(m->fault, FAULT_MAP_FN))
        local = fault_raise(m->fault, FAULT_MAP_FN, GS_ERR_INTERNAL);
    return local;
}

static gs_err map_hook_exchanging(void *user)
{
    map_state *m = user;
    if (fault_fires(m->fault, FAULT_MAP_ALLOC))
        return fault_raise(m->fault, FAULT_MAP_ALLOC, GS_ERR_MEM);
    return GS_OK;
}

static gs_err map_hook_agree(void *user, MPI_Comm comm, gs_err local)
{
    map_state *m = user;
    return agree(m->together, comm, local);
}

static gs_err map_state_init(map_state *m, MPI_Comm comm, fault_inject *fault, int *together)
{
    gs_pmap_hooks hooks = {m, map_hook_computed, map_hook_exchanging, map_hook_agree};
    m->fault = fault;
    m->together = together;
    return gs_pmap_init(&m->pm, comm, &hooks);
}

/* gs_points_map_fn over the ranks (user: map_state). Collective. */
static gs_err mpi_map(void *user, size_t n, size_t bytes, gs_points_range_fn fn, void *ctx,
                      void *out)
{
    map_state *m = user;
    return gs_pmap_run(&m->pm, n, bytes, fn, ctx, out);
}

/* ------------------------------------------------------------ checkpoints */

static gs_err write_checkpoint(gs_run *run, gs_points_synth_t s, uint64_t tex_digest)
{
    gs_points_synth_state st;
    GS_CALL(gs_points_synth_save(s, &st));
    gs_ckpt_t h = NULL;
    double *mf = NULL;
    uint64_t *mu = NULL;
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
    gs_points_synth_state_free(&st);
    return err;
}

static gs_err read_checkpoint(gs_run *run, uint64_t tex_digest, gs_points_synth_state *st)
{
    memset(st, 0, sizeof *st);
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_open(run, &h));
    double *mf = NULL;
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
    gs_ckpt_close(&h);
    if (err != GS_OK)
        gs_points_synth_state_free(st);
    return err;
}

/* ---------------------------------------------------------------- outputs */

static gs_err write_patch_csv(const char *path, const gs_points_patch_metrics *m, size_t n)
{
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    int ok = fprintf(af.f, "patch,chosen,candidates,best_dist,chosen_dist,pairs,pair_gap,"
                           "warp_residual,warp,rank,continuations\n") > 0;
    for (size_t k = 0; k < n && ok; k++)
        ok = fprintf(af.f, "%zu,%llu,%u,%.9g,%.9g,%u,%.9g,%.9g,%u,%u,%u\n", k,
                     (unsigned long long)m[k].chosen, m[k].candidates, m[k].best_dist,
                     m[k].chosen_dist, m[k].pairs, m[k].pair_gap, m[k].warp_residual,
                     m[k].warp, m[k].rank, m[k].continuations) > 0;
    if (!ok) {
        gs_atomic_abort(&af);
        GS_RAISE(GS_ERR_IO, "%s: write failed", path);
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
}

/* Mesh of the output (z-up points) written with the original axes. */
/* A z-up triangle mesh of pts: the implicit function of the points
 * (gs_points_implicit_grid) on a grid of `voxel`, contoured by OpenVDB, then
 * trimmed to the points' own extent: the grid reaches 2 R past the points,
 * where the function keeps the sign of the column above it (inside below a
 * height field), so contouring closed the solid with vertical walls along
 * the borders and a floor at the grid's bottom; triangles whose centroid
 * is outside the points' xy range or more than R below the lowest point are
 * dropped (the surface ends open at the borders, as the points do). */
static gs_err mesh_points(const gs_points *pts, double voxel, double R, double spacing,
                          double max_samples, gs_mesh *m)
{
    memset(m, 0, sizeof *m);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < pts->n; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], pts->v[i].p[a]);
            hi[a] = fmax(hi[a], pts->v[i].p[a]);
        }
    GS_CHECK(pts->n > 0, GS_ERR_ARG, "mesh: no points");
    double plo[3], phi[3];
    memcpy(plo, lo, sizeof plo);
    memcpy(phi, hi, sizeof phi);
    size_t dim[3];
    double samples = 1;
    for (int a = 0; a < 3; a++) {
        lo[a] -= 2 * R;
        hi[a] += 2 * R;
        dim[a] = (size_t)ceil((hi[a] - lo[a]) / voxel) + 1;
        samples *= (double)dim[a];
    }
    GS_CHECK(samples <= max_samples, GS_ERR_ARG,
             "output.mesh: the grid would have %zu x %zu x %zu = %.3g samples (%.1f GiB), above "
             "output.mesh_max_samples = %.3g: raise output.mesh_voxel or the limit, or set "
             "output.mesh = false", dim[0], dim[1], dim[2], samples, samples * 20 / 1073741824.0,
             max_samples);
    gs_log(GS_LOG_INFO, "mesh: implicit grid %zu x %zu x %zu, voxel %g (%.1f MiB)", dim[0], dim[1],
           dim[2], voxel, samples * 20 / 1048576.0);
    gs_vdb_dense d;
    GS_CALL(gs_vdb_dense_alloc(&d, dim[0], dim[1], dim[2]));
    memcpy(d.origin, lo, sizeof d.origin);
    d.voxel = voxel;
    d.background = (float)R;
    gs_err err = GS_OK;
    gs_points_grid_t g = NULL;
    gs_points nb = {0};
    GS_TRY(err, gs_points_implicit_grid(pts, R, lo, voxel, dim[0], dim[1], dim[2], d.v), done);
    GS_TRY(err, gs_vdb_dense_to_mesh(&d, 0.0, 0.0, m), done);
    /* Also dropped: triangles farther than max(2 voxels, 2 spacings) from
     * every point. Below an open piece of surface (a flower or a ring cut
     * at a seam) the column rule makes the solid continue down, and the
     * contour hung curtains under it, away from any point. */
    double near = fmax(2 * voxel, 2 * spacing);
    GS_TRY(err, gs_points_grid_create(plo, phi, near, &g), done);
    for (size_t i = 0; i < pts->n; i++)
        GS_TRY(err, gs_points_grid_add(g, &pts->v[i]), done);
    size_t kept = 0;
    for (size_t t = 0; t < m->ntris; t++) {
        const uint32_t *v = m->tris + 3 * t;
        double c[3] = {0, 0, 0};
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++)
                c[a] += m->pos[3 * (size_t)v[k] + a] / 3.0;
        if (c[0] < plo[0] || c[0] > phi[0] || c[1] < plo[1] || c[1] > phi[1] ||
            c[2] < plo[2] - R)
            continue;
        nb.n = 0;
        GS_TRY(err, gs_points_grid_query(g, c, near, &nb), done);
        if (nb.n == 0)
            continue;
        memmove(m->tris + 3 * kept++, v, 3 * sizeof *v);
    }
    m->ntris = kept;
done:
    gs_points_grid_destroy(&g);
    gs_points_free(&nb);
    gs_vdb_dense_destroy(&d);
    if (err != GS_OK)
        gs_mesh_destroy(m);
    return err;
}

static gs_err write_mesh(const points_config *c, const gs_points *pts, double spacing, double R,
                         const char *path, size_t *ntris)
{
    gs_mesh m;
    GS_CALL(mesh_points(pts, c->mesh_voxel * spacing, R, spacing, c->mesh_max_samples, &m));
    /* trimming to the points leaves vertices no triangle uses (4,619 of
     * 19,442 on quick.ini): readers keep them as loose points */
    gs_err err = gs_mesh_weld(&m, 0.0f);
    if (err) {
        gs_mesh_destroy(&m);
        return err;
    }
    /* Back to the example's axes: the inverse cyclic permutation (a rotation,
     * so triangle orientation is kept). */
    int up = up_axis(c);
    for (size_t i = 0; i < m.nverts && up != 2; i++) {
        float *v = m.pos + 3 * i, a = v[0], b = v[1], cc = v[2];
        if (up == 0) {
            v[0] = cc;
            v[1] = a;
            v[2] = b;
        } else {
            v[0] = b;
            v[1] = cc;
            v[2] = a;
        }
    }
    const gs_mesh_meta meta = {"geosynth points surface", "the example's units",
                               "surface reconstructed from the synthesized points (output.mesh)"};
    GS_TRY(err, gs_mesh_write_meta(path, &m, NULL, NULL, &meta), done);
    if (m.ntris) {
        char glb[PATH_MAX];
        gs_path_with_ext(path, "glb", glb, sizeof glb);
        GS_TRY(err, gs_mesh_write_glb(glb, &m, NULL, &meta), done);
    }
    *ntris = m.ntris;
done:
    gs_mesh_destroy(&m);
    return err;
}

/* RUN_DIR/preview.png: the example (inside its box) and the output
 * cropped to twice the example's extent, meshed (mesh_points) at 1.5
 * spacings at least and rendered side by side. *written = 0 without a
 * renderer (a warning, the run goes on). */
static gs_err write_preview(const points_config *c, const gs_points_texture *tex,
                            const gs_points *zup, double R, const char *path, int *written)
{
    *written = 0;
    gs_points ex = {0}, out = {0};
    gs_mesh me, mo;
    memset(&me, 0, sizeof me);
    memset(&mo, 0, sizeof mo);
    double bx = tex->box_hi[0] - tex->box_lo[0], by = tex->box_hi[1] - tex->box_lo[1];
    gs_err err = GS_OK;
    for (size_t i = 0; i < tex->pts.n; i++) {
        const double *p = tex->pts.v[i].p;
        if (p[0] >= tex->box_lo[0] && p[0] < tex->box_hi[0] && p[1] >= tex->box_lo[1] &&
            p[1] < tex->box_hi[1])
            GS_TRY(err, gs_points_append(&ex, &tex->pts.v[i], 1), done);
    }
    for (size_t i = 0; i < zup->n; i++) {
        const double *p = zup->v[i].p;
        if (p[0] < 2 * bx && p[1] < 2 * by)
            GS_TRY(err, gs_points_append(&out, &zup->v[i], 1), done);
    }
    double voxel = fmax(c->mesh_voxel, 1.5) * tex->spacing;
    GS_TRY(err, mesh_points(&ex, voxel, R, tex->spacing, c->mesh_max_samples, &me), done);
    GS_TRY(err, mesh_points(&out, voxel, R, tex->spacing, c->mesh_max_samples, &mo), done);
    gs_preview_panel panels[2] = {{&me, NULL}, {&mo, NULL}};
    err = gs_preview_write_optional(path, panels, 2, 512, written);
done:
    gs_points_free(&ex);
    gs_points_free(&out);
    gs_mesh_destroy(&me);
    gs_mesh_destroy(&mo);
    return err;
}

/* ------------------------------------------------------------------- run */

/* Whole objects, from the output and the example alone. */
typedef struct objects_stats {
    double height_ks;                /* KS distance of output vs example heights */
    double example_height_ks_halves; /* the example's two halves (x) against each other */
    double height_max, example_height_max;
    uint64_t above_example_max;      /* output points above the example's highest */
    uint32_t fragments, example_fragments;     /* components (link 2 spacings) */
    uint32_t small_fragments, example_small_fragments; /* of < SMALL_FRAGMENT points */
    uint64_t small_fragment_points;
    double example_area;
} objects_stats;

typedef struct run_state {
    gs_points_texture tex;
    gs_points_params params;
    search_ctx sctx;
    gs_points_synth_t synth;
    gs_points out;
    uint64_t tex_digest;
    map_state map; /* the map hook's state */
    fault_inject fault;
    int together;  /* the error being returned is collective (see agree) */
    gs_points_seam_stats seam;    /* of the output (rank 0) */
    objects_stats obj;            /* whole objects: heights and fragments (rank 0) */
    gs_points_synth_share share;  /* this rank's bank share and the search/map hooks */
    const points_config *c;
    double dens_out;              /* output points per unit area */
    gs_points_seam_stats seam_ex; /* of the example, lines as far apart (seam_* only) */
} run_state;

static void run_state_free(run_state *r)
{
    gs_points_synth_destroy(&r->synth);
    search_ctx_free(&r->sctx);
    gs_points_texture_free(&r->tex);
    gs_points_free(&r->out);
}

static gs_err phase_setup(gs_run *run, const points_config *c, run_state *rs, int resume,
                          gs_json *phase)
{
    gs_err err = GS_OK;
    GS_CALL(map_state_init(&rs->map, run->comm, &rs->fault, &rs->together));
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
    GS_CALL(agree(&rs->together, run->comm, err));
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
    GS_CALL(search_ctx_alloc(&rs->sctx));
    rs->share = (gs_points_synth_share){.first = (size_t)lo,
                                        .count = (size_t)(hi - lo),
                                        .fn = distributed_search,
                                        .user = &rs->sctx,
                                        .map = run->size > 1 ? mpi_map : NULL,
                                        .map_user = &rs->map};
    if (hi == lo) { /* more ranks than patches: an empty share still joins every search */
        rs->share.first = 0;
        rs->share.count = 0;
    }
    if (!resume) /* a resumed run's synthesis comes from the checkpoint (points_restore) */
        GS_CALL(gs_points_synth_create_share(t, p, &rs->share, &rs->synth));
    gs_json_u64(phase, "input_points", t->pts.n);
    gs_json_u64(phase, "input_points_in_box", inside);
    gs_json_u64(phase, "input_patches", npatch);
    gs_json_i64(phase, "bank_share", hi - lo);
    if (!resume)
        gs_json_u64(phase, "patches", gs_points_synth_total(rs->synth));
    return GS_OK;
}

/* One patch placed (the search is spread over the ranks). */
static gs_err synth_step(run_state *rs, int *finished)
{
    gs_points_synth_t s = rs->synth;
    *finished = gs_points_synth_cursor(s) >= gs_points_synth_total(s);
    if (*finished)
        return GS_OK;
    fault_inject *f = &rs->fault;
    f->armed = f->site != FAULT_NONE && gs_points_synth_cursor(s) == f->patch;
    GS_CALL(gs_points_synth_step(s));
    if (fault_fires(f, FAULT_STEP))
        GS_CALL(fault_raise(f, FAULT_STEP, GS_ERR_LIB));
    f->armed = 0;
    *finished = gs_points_synth_cursor(s) >= gs_points_synth_total(s);
    return GS_OK;
}

static gs_err points_synthesis_report(void *state, gs_run *run, gs_json *j)
{
    const run_state *rs = state;
    gs_points_synth_t s = rs->synth;
    gs_points_times tm = gs_points_synth_times(s);
    gs_json_u64(j, "patches_done", gs_points_synth_cursor(s));
    gs_json_f64(j, "search_seconds", tm.search);
    gs_json_f64(j, "warp_seconds", tm.warp);
    gs_json_f64(j, "blend_seconds", tm.blend);
    gs_json_f64(j, "other_seconds", tm.other);
    gs_json_i64(j, "candidates_offered_rank0", rs->sctx.offers);
    gs_json_i64(j, "search_regathers", rs->sctx.regathers);
    return GS_OK;
}

static int u64_cmp(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Distinct input patches among the chosen ones (0 on no memory). */
static size_t distinct_sources(const gs_points_patch_metrics *m, size_t n)
{
    uint64_t *v = gs_malloc(n ? n * sizeof *v : 1);
    if (!v)
        return 0;
    for (size_t k = 0; k < n; k++)
        v[k] = m[k].chosen;
    qsort(v, n, sizeof *v, u64_cmp);
    size_t d = 0;
    for (size_t k = 0; k < n; k++)
        d += k == 0 || v[k] != v[k - 1];
    gs_free(v);
    return d;
}

/* A component of fewer points than this is a speck (a few samples). */
#define SMALL_FRAGMENT 30

/* Components of pts (link radius r); with a box (lo/hi != NULL) only those
 * with a point inside it in xy count. */
static gs_err count_fragments(const gs_points *pts, double r, const double *lo, const double *hi,
                              uint32_t *all, uint32_t *small, uint64_t *small_points)
{
    uint32_t *label = NULL, nc = 0;
    uint64_t *sizes = NULL;
    uint8_t *in = NULL;
    gs_err err = GS_OK;
    *all = *small = 0;
    if (small_points)
        *small_points = 0;
    GS_TRY(err, gs_alloc_array((void **)&label, pts->n ? pts->n : 1, sizeof *label, "fragments"),
           done);
    GS_TRY(err, gs_measure_point_components((const double *)pts->v, 6, pts->n, r, label, &nc,
                                            &sizes), done);
    GS_TRY(err, gs_alloc_array((void **)&in, (size_t)nc + 1, 1, "fragments"), done);
    memset(in, lo ? 0 : 1, (size_t)nc + 1);
    for (size_t i = 0; lo && i < pts->n; i++) {
        const double *p = pts->v[i].p;
        if (p[0] >= lo[0] && p[0] < hi[0] && p[1] >= lo[1] && p[1] < hi[1])
            in[label[i]] = 1;
    }
    for (uint32_t c = 1; c <= nc; c++) {
        if (!in[c])
            continue;
        (*all)++;
        if (sizes[c] < SMALL_FRAGMENT) {
            (*small)++;
            if (small_points)
                *small_points += sizes[c];
        }
    }
done:
    gs_free(label);
    gs_free(sizes);
    gs_free(in);
    return err;
}

/* Heights (KS against the example's inside its box) and fragments. */
static gs_err object_measures(run_state *rs, const gs_points *zup)
{
    objects_stats *o = &rs->obj;
    memset(o, 0, sizeof *o);
    const gs_points_texture *t = &rs->tex;
    double *hx = NULL, *hy = NULL;
    size_t ny = 0;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&hx, zup->n ? zup->n : 1, sizeof *hx, "heights"), done);
    GS_TRY(err, gs_alloc_array((void **)&hy, t->pts.n ? t->pts.n : 1, sizeof *hy, "heights"), done);
    o->example_height_max = -INFINITY;
    for (size_t i = 0; i < t->pts.n; i++) {
        const double *p = t->pts.v[i].p;
        if (p[0] >= t->box_lo[0] && p[0] < t->box_hi[0] && p[1] >= t->box_lo[1] &&
            p[1] < t->box_hi[1]) {
            hy[ny++] = p[2];
            o->example_height_max = fmax(o->example_height_max, p[2]);
        }
    }
    o->height_max = -INFINITY;
    for (size_t i = 0; i < zup->n; i++) {
        hx[i] = zup->v[i].p[2];
        o->height_max = fmax(o->height_max, hx[i]);
        o->above_example_max += hx[i] > o->example_height_max;
    }
    GS_TRY(err, gs_measure_ks(hx, zup->n, hy, ny, &o->height_ks), done);
    {
        /* How far two pieces of the example itself differ: the scale a
         * height KS of the output is to be read against. */
        size_t na = 0, nb = 0;
        double mid = 0.5 * (t->box_lo[0] + t->box_hi[0]);
        for (size_t i = 0; i < t->pts.n; i++) {
            const double *p = t->pts.v[i].p;
            if (p[0] >= t->box_lo[0] && p[0] < t->box_hi[0] && p[1] >= t->box_lo[1] &&
                p[1] < t->box_hi[1]) {
                if (p[0] < mid)
                    hx[na++] = p[2];
                else
                    hy[nb++] = p[2];
            }
        }
        GS_TRY(err, gs_measure_ks(hx, na, hy, nb, &o->example_height_ks_halves), done);
    }
    double r = 2 * t->spacing;
    GS_TRY(err, count_fragments(zup, r, NULL, NULL, &o->fragments, &o->small_fragments,
                                &o->small_fragment_points), done);
    GS_TRY(err, count_fragments(&t->pts, r, t->box_lo, t->box_hi, &o->example_fragments,
                                &o->example_small_fragments, NULL), done);
    o->example_area = (t->box_hi[0] - t->box_lo[0]) * (t->box_hi[1] - t->box_lo[1]);
done:
    gs_free(hx);
    gs_free(hy);
    return err;
}

/* The seam measure of the output (z-up points) and of the example. */
static gs_err seam_measures(run_state *rs, const gs_points *zup)
{
    gs_points_lines seams = {0}, inside = {0}, ex = {0}, none = {0};
    double R = rs->params.mls_radius, band = rs->tex.spacing;
    gs_err err = GS_OK;
    GS_TRY(err, gs_points_synth_lines(rs->synth, 0, &seams), done);
    GS_TRY(err, gs_points_synth_lines(rs->synth, 1, &inside), done);
    GS_TRY(err, gs_points_synth_lines(rs->synth, 2, &ex), done);
    GS_TRY(err, gs_points_seam_measure(zup, R, band, &seams, &inside, &rs->seam), done);
    GS_TRY(err, gs_points_seam_measure(&rs->tex.pts, R, band, &ex, &none, &rs->seam_ex), done);
done:
    gs_points_lines_free(&seams);
    gs_points_lines_free(&inside);
    gs_points_lines_free(&ex);
    return err;
}

static void record_metrics(gs_run *run, const points_config *c, run_state *rs, double dens_out)
{
    gs_points_synth_t s = rs->synth;
    size_t nm;
    const gs_points_patch_metrics *m = gs_points_synth_metrics(s, &nm);
    double sd = 0, sdmax = 0, cd = 0, res = 0, resmax = 0, gap = 0, cand = 0, pairs = 0;
    size_t searched = 0, warped = 0, nwarp[3] = {0, 0, 0}, verbatim = 0;
    double expect_verbatim = 0;
    for (size_t k = 0; k < nm; k++) {
        cand += m[k].candidates;
        if (k == 0)
            continue; /* the seed patch: picked at random, no search */
        searched++;
        sd += m[k].best_dist;
        sdmax = fmax(sdmax, m[k].best_dist);
        cd += m[k].chosen_dist;
        /* The residual over every blended patch, warped or not (a mean over
         * the warped ones alone compared different patches with and without
         * the warp). */
        res += m[k].warp_residual;
        resmax = fmax(resmax, m[k].warp_residual);
        nwarp[m[k].warp < 3 ? m[k].warp : 0]++;
        verbatim += gs_points_synth_is_continuation(s, m, k, m[k].chosen);
        if (m[k].candidates > 0)
            expect_verbatim += (double)m[k].continuations / m[k].candidates;
        if (m[k].warp > 0) {
            warped++;
            gap += m[k].pair_gap;
            pairs += m[k].pairs;
        }
    }
    gs_points_times tm = gs_points_synth_times(s);
    double din = gs_points_synth_input_density(s);
    gs_run_metric_str(run, "input_kind", c->kind);
    gs_run_metric_i64(run, "input_points", (int64_t)rs->tex.pts.n);
    gs_run_metric_f64(run, "input_spacing", rs->tex.spacing);
    gs_run_metric_i64(run, "input_patches", (int64_t)gs_points_synth_input_patches(s));
    gs_run_metric_i64(run, "patches", (int64_t)nm);
    gs_run_metric_i64(run, "patches_searched", (int64_t)searched);
    gs_run_metric_i64(run, "patches_warped", (int64_t)warped);
    gs_run_metric_i64(run, "patches_warp_pairs", (int64_t)nwarp[1]);
    gs_run_metric_i64(run, "patches_warp_normal", (int64_t)nwarp[2]);
    gs_run_metric_i64(run, "patches_warp_none", (int64_t)nwarp[0]);
    gs_run_metric_f64(run, "out_size_x", rs->params.out_size[0]);
    gs_run_metric_f64(run, "out_size_y", rs->params.out_size[1]);
    gs_run_metric_i64(run, "output_points", (int64_t)rs->out.n);
    gs_run_metric_f64(run, "density_in", din);
    gs_run_metric_f64(run, "density_out", dens_out);
    gs_run_metric_f64(run, "density_ratio", din > 0 ? dens_out / din : 0);
    gs_run_metric_f64(run, "search_distance_mean", searched ? sd / searched : 0);
    gs_run_metric_f64(run, "search_distance_max", sdmax);
    gs_run_metric_f64(run, "chosen_distance_mean", searched ? cd / searched : 0);
    gs_run_metric_f64(run, "candidates_mean", nm ? cand / nm : 0);
    /* Variety: distinct source patches, and the share of patches that
     * continue a neighbour's source verbatim, against what a uniform pick
     * in each Psi_k gives (the mean of continuations / candidates). */
    gs_run_metric_i64(run, "source_patches", (int64_t)distinct_sources(m, nm));
    gs_run_metric_f64(run, "verbatim_share", searched ? (double)verbatim / searched : 0);
    gs_run_metric_f64(run, "verbatim_share_random", searched ? expect_verbatim / searched : 0);
    gs_run_metric_f64(run, "pairs_mean", warped ? pairs / warped : 0);
    gs_run_metric_f64(run, "pair_gap_mean", warped ? gap / warped : 0);
    gs_run_metric_f64(run, "warp_residual_mean", searched ? res / searched : 0);
    gs_run_metric_f64(run, "warp_residual_max", resmax);
    const gs_points_seam_stats *se = &rs->seam;
    gs_run_metric_f64(run, "seam_dist", se->seam_dist);
    gs_run_metric_f64(run, "seam_normal", se->seam_normal);
    gs_run_metric_f64(run, "seam_unmatched", se->seam_unmatched);
    gs_run_metric_f64(run, "inside_dist", se->inside_dist);
    gs_run_metric_f64(run, "inside_normal", se->inside_normal);
    gs_run_metric_f64(run, "inside_unmatched", se->inside_unmatched);
    gs_run_metric_f64(run, "seam_dist_ratio", se->inside_dist > 0 ? se->seam_dist / se->inside_dist : 0);
    gs_run_metric_f64(run, "example_line_dist", rs->seam_ex.seam_dist);
    gs_run_metric_f64(run, "example_line_normal", rs->seam_ex.seam_normal);
    gs_run_metric_f64(run, "example_line_unmatched", rs->seam_ex.seam_unmatched);
    const objects_stats *ob = &rs->obj;
    double area = rs->params.out_size[0] * rs->params.out_size[1];
    gs_run_metric_f64(run, "height_ks", ob->height_ks);
    gs_run_metric_f64(run, "example_height_ks_halves", ob->example_height_ks_halves);
    gs_run_metric_f64(run, "height_max", ob->height_max);
    gs_run_metric_f64(run, "example_height_max", ob->example_height_max);
    gs_run_metric_i64(run, "points_above_example_max", (int64_t)ob->above_example_max);
    gs_run_metric_i64(run, "fragments", ob->fragments);
    gs_run_metric_f64(run, "fragments_per_area", ob->fragments / area);
    gs_run_metric_f64(run, "example_fragments_per_area",
                      ob->example_area > 0 ? ob->example_fragments / ob->example_area : 0);
    gs_run_metric_i64(run, "small_fragments", ob->small_fragments);
    gs_run_metric_i64(run, "small_fragment_points", (int64_t)ob->small_fragment_points);
    gs_run_metric_f64(run, "small_fragments_per_area", ob->small_fragments / area);
    gs_run_metric_f64(run, "example_small_fragments_per_area",
                      ob->example_area > 0 ? ob->example_small_fragments / ob->example_area : 0);
    gs_run_metric_f64(run, "search_seconds", tm.search);
    gs_run_metric_f64(run, "warp_seconds", tm.warp);
    gs_run_metric_f64(run, "blend_seconds", tm.blend);
    gs_run_metric_f64(run, "other_seconds", tm.other);
    gs_run_metric_f64(run, "relax_seconds", tm.relax);
}

/* ---- the run driver's operations (include/geosynth/engine.h) -------------- */

/* An operation's status. A failure every rank returned from the same
 * collective (rs->together, see agree) is agreed by the driver; one that
 * may be this rank's alone (the others may be waiting in an exchange) ends
 * every rank at once (gs_run.failed_alone). */
static gs_err op_status(gs_run *run, const run_state *rs, gs_err err)
{
    if (err != GS_OK && err != GS_ERR_INTERRUPTED && !rs->together)
        run->failed_alone = 1;
    return err;
}

static gs_err points_setup_op(gs_run *run, const void *vcfg, int resume, void **state,
                              gs_json *phase)
{
    run_state *rs = gs_calloc(1, sizeof *rs);
    GS_CHECK(rs != NULL, GS_ERR_MEM, "points: out of memory for the run state");
    *state = rs;
    rs->c = vcfg;
    gs_err err = fault_init(&rs->fault, run->rank);
    if (err != GS_OK) { /* the same environment, so the same error, on every rank */
        rs->together = 1;
        return err;
    }
    return op_status(run, rs, phase_setup(run, rs->c, rs, resume, phase));
}

static gs_err points_restore(void *state, gs_run *run)
{
    run_state *rs = state;
    gs_points_synth_state st;
    gs_err err = read_checkpoint(run, rs->tex_digest, &st);
    if (err == GS_OK) {
        err = gs_points_synth_resume_share(&rs->tex, &rs->params, &rs->share, &st, &rs->synth);
        gs_points_synth_state_free(&st);
    }
    GS_CALL(op_status(run, rs, err));
    run->ckpt_last_units = (int64_t)gs_points_synth_cursor(rs->synth);
    gs_log(GS_LOG_INFO, "resumed at patch %llu of %llu",
           (unsigned long long)gs_points_synth_cursor(rs->synth),
           (unsigned long long)gs_points_synth_total(rs->synth));
    return GS_OK;
}

static void points_units(const void *state, int64_t *done, int64_t *total)
{
    const run_state *rs = state;
    *done = (int64_t)gs_points_synth_cursor(rs->synth);
    *total = (int64_t)gs_points_synth_total(rs->synth);
}

static gs_err points_advance(void *state, gs_run *run, int *finished)
{
    run_state *rs = state;
    return op_status(run, rs, synth_step(rs, finished));
}

static gs_err points_save(void *state, gs_run *run)
{
    run_state *rs = state;
    gs_err err = write_checkpoint(run, rs->synth, rs->tex_digest);
    GS_DEBUG("checkpoint at patch %llu", (unsigned long long)gs_points_synth_cursor(rs->synth));
    return op_status(run, rs, err);
}


/* Relaxation, trimming, back to the example's axes. */
static gs_err points_finish(void *state, gs_run *run, gs_json *phase)
{
    run_state *rs = state;
    GS_CALL(op_status(run, rs, gs_points_synth_finish(rs->synth, &rs->out)));
    gs_points_permute_from_z(&rs->out, kind_is_user(rs->c) ? up_axis(rs->c) : 2);
    double area = rs->params.out_size[0] * rs->params.out_size[1];
    rs->dens_out = rs->out.n / area;
    gs_json_u64(phase, "output_points", rs->out.n);
    gs_json_f64(phase, "relax_seconds", gs_points_synth_times(rs->synth).relax);
    return GS_OK;
}

static gs_err points_output_op(void *state, gs_run *run, gs_json *phase, uint64_t *digest)
{
    run_state *rs = state;
    const points_config *c = rs->c;
    *digest = gs_points_digest(&rs->out);
    gs_err local = GS_OK;
    size_t ntris = 0;
    if (run->rank == 0) {
        char path[PATH_MAX];
        gs_pointply_format fmt = strcmp(c->ply_format, "ascii") ? GS_POINTPLY_BINARY
                                                                : GS_POINTPLY_ASCII;
        if (c->write_points && local == GS_OK) {
            gs_run_path(run, "points.ply", path, sizeof path);
            local = gs_pointply_write(path, (const double *)rs->out.v, rs->out.n, 1, fmt);
            if (local == GS_OK)
                gs_run_output(run, "points", "points", "points.ply", NULL);
        }
        if (c->patch_csv && local == GS_OK) {
            size_t nm;
            const gs_points_patch_metrics *m = gs_points_synth_metrics(rs->synth, &nm);
            gs_run_path(run, "patches.csv", path, sizeof path);
            local = write_patch_csv(path, m, nm);
            if (local == GS_OK)
                gs_run_output(run, "csv", "patch_metrics", "patches.csv", NULL);
        }
        /* The measures and the mesh work on the z-up points; write_mesh
         * restores the axes. */
        gs_points zup = {0};
        if (local == GS_OK)
            local = gs_points_append(&zup, rs->out.v, rs->out.n);
        if (local == GS_OK) {
            gs_points_permute_to_z(&zup, kind_is_user(c) ? up_axis(c) : 2);
            local = seam_measures(rs, &zup);
            if (local == GS_OK)
                local = object_measures(rs, &zup);
        }
        if (c->mesh && local == GS_OK) {
            gs_run_path(run, "mesh.ply", path, sizeof path);
            local = write_mesh(c, &zup, rs->tex.spacing, rs->params.mls_radius, path, &ntris);
            if (local == GS_OK)
                gs_run_output(run, "mesh", "surface", "mesh.ply", NULL);
            if (local == GS_OK && ntris)
                gs_run_output(run, "mesh", "surface", "mesh.glb", NULL);
        }
        if (c->preview && local == GS_OK) {
            int written = 0;
            gs_run_path(run, "preview.png", path, sizeof path);
            local = write_preview(c, &rs->tex, &zup, rs->params.mls_radius, path, &written);
            if (local == GS_OK && written)
                gs_run_output(run, "preview", "preview", "preview.png", NULL);
        }
        gs_points_free(&zup);
        if (local == GS_OK)
            record_metrics(run, c, rs, rs->dens_out);
    }
    GS_CALL(agree(&rs->together, run->comm, local));
    gs_json_u64(phase, "mesh_triangles", ntris);
    gs_log(GS_LOG_INFO, "output: %zu points, density %.4g per unit area (example %.4g, ratio "
           "%.3f)", rs->out.n, rs->dens_out, gs_points_synth_input_density(rs->synth),
           rs->dens_out / gs_points_synth_input_density(rs->synth));
    return GS_OK;
}

static void points_destroy(void *state)
{
    run_state *rs = state;
    if (!rs)
        return;
    run_state_free(rs);
    gs_free(rs);
}

static const gs_engine_ops points_ops = {
    .setup = points_setup_op,
    .restore = points_restore,
    .units = points_units,
    .advance = points_advance,
    .save = points_save,
    .synthesis_report = points_synthesis_report,
    .finish = points_finish,
    .output = points_output_op,
    .destroy = points_destroy,
};

const gs_engine gs_engine_points = {
    "points",
    "patch-based geometry texture synthesis on point-set surfaces (Duranleau & Poulin)",
    &points_table,
    sizeof(points_config),
    offsetof(points_config, run),
    &points_ops,
};
