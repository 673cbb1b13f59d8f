/* The `model` engine: Merrell's model synthesis (src/model core) behind the
 * geosynth CLI, run over MPI ranks with colored regions.
 *
 *   mpirun -np N geosynth model -c configs/model/castle.ini
 *
 * Phases: setup (rank 0 reads the example and the optional start lattice and
 * broadcasts them; every rank learns the same rules and builds the same
 * start model), synthesis (pass after pass; the regions of a pass run on all
 * ranks through gs_regions as one dataflow over the colours of
 * gs_model_plan: a region starts once the regions of lower colours it
 * touches (gs_model_regions_interact) are applied, and every rank applies
 * each result after those; the outcome is exactly the core's serial driver
 * gs_model_synthesize, colours in order, regions in id order),
 * output (rank 0: lattice.h5 + lattice.xmf, lattice.vox, the merged-face
 * mesh, lattice.png when nz == 1, optionally Merrell's .txt; quality
 * metrics).
 *
 * 2D inputs as WaveFunctionCollapse users know them (model_tiles.h):
 * model.tileset (mxgmn tile set XML, optional model.subset / start_tile)
 * and model.sample (overlapping model: N x N patterns of a PNG, keys
 * overlap_n, symmetry, periodic_input) replace model.example; their rules
 * come from explicit pairs, the start model is a uniform layer of a tile
 * that may sit next to itself, and the output adds tiles.png (assembled
 * from the tile images) or image.png (pattern pixels); the violations metric
 * then comes from the tile-set / pattern checker. Periodic output and the
 * overlapping model's ground are not supported. Voxel (3D) tile sets
 * (MarkovJunior XML, DeBroglie JSON) run at any z: their ground, border and
 * fixed tiles (and model.border_tile) become pins, and the outputs add
 * tiles.vox; mesh.ply and preview.png show the assembled voxels.
 * model.overlap3d = N (3D overlapping model, overlap3d.c) turns the example's
 * N^3 windows into labels: the solver, regions and checkpoints see pattern
 * labels, the outputs the decoded lattice (each pattern's origin cell).
 *
 * Work units (checkpoint cadence, GS_STOP_AFTER_UNITS) are regions
 * finished; checkpoints are taken between colours, since regions of
 * neighbouring colours run concurrently: a window of colours (at most
 * MODEL_WINDOW_REGIONS regions) ends where a unit-based checkpoint or stop
 * would fall, so those land on the same colour as with one colour at a
 * time; time-based checkpoints and signals are seen at the window's end. The checkpoint (group /model) holds the lattice,
 * the per-cell count of accepted regions (coverage, which decides when the
 * sweep may stop), the position (pass, next colour), the per-region status
 * and attempt counters of the pass in progress and the statistics; a resumed
 * run continues with any rank count and ends with the same digest.
 *
 * Determinism: gs_model_region_run depends only on (lattice before the
 * colour, box, params, region id, pass); the gs_regions random stream is not
 * used. So the final lattice is identical for every rank count.
 */
#include <math.h>
#include <limits.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/config.h"
#include "geosynth/digest.h"
#include "geosynth/engine.h"
#include "geosynth/h5.h"
#include "geosynth/image.h"
#include "geosynth/json.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/model.h"
#include "geosynth/model_io.h"
#include "geosynth/model_tiles.h"
#include "geosynth/par.h"
#include "geosynth/parse.h"
#include "geosynth/regions.h"
#include "geosynth/run.h"

#define MODEL_MAX_EXTENT 1048576.0
/* model.overlap3d: most distinct N^3 windows (labels); the rules then take
 * 8 * L * L / 64 * 8 bytes (64 MiB) and the solver's candidate sets L / 8
 * bytes per cell */
#define MODEL_OVERLAP3D_MAX_PATTERNS 8192
#define MODEL_RNG_DOMAIN 0x6d6f646cu /* "modl": unused by the regions, kept distinct */
#define MODEL_VIOLATION_LIST 20
#define MODEL_PREVIEW_FRAMES 6 /* 4D preview: the first frames side by side */

typedef struct model_config {
    char *example;
    char *tileset;
    char *tile_folder;
    char *border_tile;
    char *subset;
    char *start_tile;
    char *sample;
    int64_t overlap_n;
    int64_t symmetry;
    int periodic_input;
    int ground;
    int tile_image;
    int preview;
    int64_t preview_size;
    char *format;
    char *dataset;
    gs_cfg_int3 size;
    gs_cfg_int3 region;
    int64_t overlap;
    int64_t passes;
    int64_t max_passes;
    int64_t attempts;
    int64_t backtracks;
    char *order;
    char *weights;
    int64_t resemblance;
    int64_t resemblance_slack;
    int resemblance_layers;
    char *ac;
    char *fix_z_faces;
    char *start;
    char *start_column;
    int64_t start_block;
    int64_t frames;
    int64_t overlap3d;
    char *resemblance_outside;
    int64_t split_depth;
    char *pins;
    char *border;
    char *mirror;
    char *mirror_x_pairs;
    char *mirror_y_pairs;
    char *rotate;
    char *shape;
    double shape_weight;
    double shape_mh;
    int64_t shape_slack;
    char *periodic;
    char *mesh;
    int vox;
    int txt;
    double voxel_size;
    gs_run_config run;
} model_config;

/* Copies the token at p (up to NUL or a character of stops) into tok,
 * truncated to 31 characters; returns where it ends. */
static const char *scan_token(const char *p, const char *stops, char tok[32])
{
    size_t k = 0;
    while (*p && !strchr(stops, *p)) {
        if (k + 1 < 32)
            tok[k++] = *p;
        p++;
    }
    tok[k] = '\0';
    return p;
}

/* Parses "a, b c" into up to cap labels; returns the count or -1 with why. */
static int parse_column(const char *text, uint16_t *out, int cap, char *why, size_t why_len)
{
    int n = 0;
    const char *p = text;
    while (*p) {
        while (*p == ' ' || *p == ',' || *p == '\t')
            p++;
        if (!*p)
            break;
        char tok[32];
        p = scan_token(p, " ,\t", tok);
        int64_t v;
        if (!gs_parse_i64(tok, 0, 65535, &v, why, why_len))
            return -1;
        if (n < cap)
            out[n] = (uint16_t)v;
        n++;
    }
    return n;
}

/* Parses "x,y,z=label; ..." (spaces allowed). Calls put(x, y, z, label)
 * for each entry when pins != NULL. Returns the count or -1 with why. */
static int parse_pins(const char *text, const gs_cfg_int3 size, uint16_t *pins, char *why,
                      size_t why_len)
{
    int n = 0;
    const char *p = text;
    while (*p) {
        while (*p == ' ' || *p == ';' || *p == '\t')
            p++;
        if (!*p)
            break;
        int64_t v[4];
        for (int k = 0; k < 4; k++) {
            while (*p == ' ')
                p++;
            char tok[32];
            p = scan_token(p, ",=; ", tok);
            int64_t hi = k < 3 ? size[k] - 1 : 65534;
            if (!gs_parse_i64(tok, 0, hi, &v[k], why, why_len)) {
                char tmp[160];
                static const char *const field[4] = {"x", "y", "z", "label"};
                snprintf(tmp, sizeof tmp, "entry %d, %s: %s", n + 1, field[k], why);
                snprintf(why, why_len, "%s", tmp);
                return -1;
            }
            while (*p == ' ')
                p++;
            char want = k < 2 ? ',' : (k == 2 ? '=' : 0);
            if (want) {
                if (*p != want) {
                    snprintf(why, why_len, "entry %d: expected 'x,y,z=label'", n + 1);
                    return -1;
                }
                p++;
            }
        }
        if (pins)
            pins[(size_t)v[0] + (size_t)size[0] * ((size_t)v[1] + (size_t)size[1] * (size_t)v[2])] =
                (uint16_t)v[3];
        n++;
    }
    return n;
}

static void model_validate(const void *cfgp, gs_cfg_ctx *ctx)
{
    const model_config *c = cfgp;
    int inputs = (c->example[0] != 0) + (c->tileset[0] != 0) + (c->sample[0] != 0);
    if (inputs != 1)
        gs_cfg_report(ctx, "model.example",
                      "%s: set exactly one of model.example (label lattice), model.tileset "
                      "(WFC tile set XML) and model.sample (overlapping model PNG)",
                      inputs ? "several inputs given" : "no input given");
    if (c->sample[0] && c->size[2] != 1)
        gs_cfg_report(ctx, "model.size",
                      "z = %lld: model.sample is a 2D input, expected z = 1",
                      (long long)c->size[2]);
    if (c->tile_folder[0] && !c->tileset[0])
        gs_cfg_report(ctx, "model.tile_folder", "only applies to model.tileset");
    if (c->border_tile[0] && !c->tileset[0])
        gs_cfg_report(ctx, "model.border_tile", "only applies to model.tileset");
    if (c->start_tile[0] && !c->tileset[0])
        gs_cfg_report(ctx, "model.start_tile", "only applies to model.tileset");
    if (c->subset[0] && !c->tileset[0])
        gs_cfg_report(ctx, "model.subset", "only applies to model.tileset");
    if (c->ground && !c->sample[0])
        gs_cfg_report(ctx, "model.ground", "true: expected model.sample (overlapping model)");
    if (c->ground && strchr(c->mirror, 'y'))
        gs_cfg_report(ctx, "model.ground", "true: not with model.mirror = %s (the bottom row is "
                      "mirrored to the top)", c->mirror);
    if (c->sample[0] && (c->start[0] || c->start_column[0]))
        gs_cfg_report(ctx, "model.start", "not supported with model.sample");
    if (c->tileset[0] || c->sample[0]) {
        /* These read the example lattice (its empty label 0, ground layer, label
         * frequencies by column); tile sets and samples have none. */
        const char *key = c->start_block > 0 ? "model.start_block"
                          : strcmp(c->mirror, "none") ? "model.mirror"
                          : c->shape[0]                ? "model.shape"
                          : c->border[0]               ? "model.border"
                                                       : NULL;
        if (key)
            gs_cfg_report(ctx, key, "only applies to model.example (a label lattice), not to %s",
                          c->tileset[0] ? "model.tileset" : "model.sample");
    }
    if (c->pins[0]) {
        char why[200] = "";
        if (parse_pins(c->pins, c->size, NULL, why, sizeof why) < 0)
            gs_cfg_report(ctx, "model.pins", "%s", why);
    }
    if (strcmp(c->mirror, "none") && (c->pins[0] || c->border[0] || c->start_block > 0 ||
                                      strcmp(c->periodic, "none") || c->start[0] ||
                                      c->shape[0]))
        gs_cfg_report(ctx, "model.mirror",
                      "= %s cannot be combined with pins, border, start_block, start, periodic "
                      "or shape",
                      c->mirror);
    for (int a = 0; a < 3; a++) {
        int64_t edge = c->region[a];
        if (edge > 0 && edge < c->size[a] && c->overlap >= edge)
            gs_cfg_report(ctx, "model.overlap",
                          "must be smaller than the region edge %lld along %c (model.region)",
                          (long long)edge, "xyz"[a]);
    }
    if (strchr(c->periodic, 'z') && !strcmp(c->fix_z_faces, "true"))
        gs_cfg_report(ctx, "model.periodic",
                      "= %s wraps z: needs model.fix_z_faces = false", c->periodic);
    if (c->frames > 1) {
        /* 4D: frames are stacked along z; these read or cut z as one axis */
        const char *key = c->tileset[0] || c->sample[0] ? "model.example"
                          : c->region[2] > 0 && c->region[2] < c->size[2] ? "model.region"
                          : strcmp(c->mirror, "none")  ? "model.mirror"
                          : strchr(c->periodic, 'z')   ? "model.periodic"
                          : !strcmp(c->fix_z_faces, "true") ? "model.fix_z_faces"
                          : c->start_block > 0         ? "model.start_block"
                          : c->start[0]                ? "model.start"
                          : c->pins[0]                 ? "model.pins"
                          : c->border[0]               ? "model.border"
                                                       : NULL;
        if (key)
            gs_cfg_report(ctx, key,
                          "not supported with model.frames = %lld (4D): needs a lattice example, "
                          "region z = 0 (whole frames), no mirror, no periodic z, "
                          "fix_z_faces auto or false, no start_block/start/pins/border",
                          (long long)c->frames);
    }
    if (!strcmp(c->rotate, "90")) {
        const char *why = c->size[0] != c->size[1] || (c->size[0] & 1)
                              ? "needs a square output of even x = y (model.size)"
                          : (c->region[0] > 0 && c->region[0] < c->size[0] / 2) ||
                                  (c->region[1] > 0 && c->region[1] < c->size[1] / 2)
                              ? "needs regions spanning the whole quarter in x and y (model.region "
                                "x, y = 0)"
                          : c->tileset[0] || c->sample[0] ? "needs a lattice example (model.example)"
                          : strcmp(c->mirror, "none") || c->pins[0] || c->border[0] ||
                                  c->start_block > 0 || c->start[0] || c->shape[0] ||
                                  strcmp(c->periodic, "none") || c->frames > 1
                              ? "cannot be combined with mirror, pins, border, start_block, start, "
                                "shape, periodic or frames"
                              : NULL;
        if (why)
            gs_cfg_report(ctx, "model.rotate", "= 90 %s", why);
    }
    if (c->overlap3d > 0) {
        /* these read or set example labels, which are patterns here */
        const char *key = !c->example[0]                 ? "model.example"
                          : c->frames > 1                ? "model.frames"
                          : strcmp(c->mirror, "none")    ? "model.mirror"
                          : strcmp(c->rotate, "none")    ? "model.rotate"
                          : c->shape[0]                  ? "model.shape"
                          : c->pins[0]                   ? "model.pins"
                          : c->border[0]                 ? "model.border"
                          : c->start[0]                  ? "model.start"
                          : c->start_column[0]           ? "model.start_column"
                          : c->start_block > 0           ? "model.start_block"
                          : !strcmp(c->fix_z_faces, "true") ? "model.fix_z_faces"
                                                         : NULL;
        /* fixed faces: the start column's uniform bottom pattern fixes the N-1
         * layers above it through the overlap, and so on up: the output would
         * be the start model (parliament: run lengths 30 of 30) */
        if (key)
            gs_cfg_report(ctx, key,
                          "not supported with model.overlap3d = %lld (3D overlapping model): "
                          "needs a 3D lattice example (model.example), no frames, mirror, rotate, "
                          "shape, pins, border, start, start_column or start_block, and "
                          "fix_z_faces auto or false (kept uniform faces would fix every layer "
                          "through the overlaps)",
                          (long long)c->overlap3d);
    }
    if (c->start_block > 0 && (c->start[0] || c->start_column[0]))
        gs_cfg_report(ctx, "model.start_block",
                      "cannot be combined with model.start or model.start_column");
    if (c->start[0] && c->start_column[0])
        gs_cfg_report(ctx, "model.start_column",
                      "cannot be combined with model.start = %s: give one start model", c->start);
    if (c->border[0]) {
        char why[160] = "";
        int n = parse_column(c->border, NULL, 0, why, sizeof why);
        if (n < 0)
            gs_cfg_report(ctx, "model.border", "%s", why);
        else if (n != c->size[2])
            gs_cfg_report(ctx, "model.border", "has %d labels: expected one per layer, %lld",
                          n, (long long)c->size[2]);
    }
    if (c->start_column[0]) {
        char why[160] = "";
        int n = parse_column(c->start_column, NULL, 0, why, sizeof why);
        if (n < 0)
            gs_cfg_report(ctx, "model.start_column", "%s", why);
        else if (n != c->size[2])
            gs_cfg_report(ctx, "model.start_column",
                          "has %d labels: expected one per layer, %lld (model.size z), bottom "
                          "first",
                          n, (long long)c->size[2]);
    }
}

static const gs_cfg_key model_keys[] = {
    GS_CFG_KEY_PATH(model_config, example, "model.example", "",
                    "example lattice: Merrell .txt, DeBroglie .csv, MagicaVoxel/Slab6 .vox, or "
                    "geosynth .h5 (or model.tileset / model.sample)"),
    GS_CFG_KEY_PATH(model_config, tileset, "model.tileset", "",
                    "tile set: WaveFunctionCollapse XML (2D, tile PNGs in the folder of the same "
                    "name, model.size z = 1), MarkovJunior XML (3D .vox tiles) or DeBroglie "
                    "voxSet .json (3D, with its constraints)"),
    GS_CFG_KEY_STRING(model_config, tile_folder, "model.tile_folder", "",
                      "MarkovJunior tile set: folder of the .vox tiles relative to the XML's "
                      "directory (e.g. Knots3D/3); \"\" = the XML's name"),
    GS_CFG_KEY_STRING(model_config, border_tile, "model.border_tile", "",
                      "voxel tile set: tile (\"name\" or \"name k\") on every cell of the "
                      "output's six faces (MarkovJunior's models put Empty there); \"\" = "
                      "the tile set's own border constraint, if any"),
    GS_CFG_KEY_STRING(model_config, subset, "model.subset", "",
                      "tile set subset name (<subsets> of the XML); \"\" = every tile"),
    GS_CFG_KEY_STRING(model_config, start_tile, "model.start_tile", "",
                      "tile set: tile (\"name\" or \"name k\") filling the start model; it "
                      "must sit next to itself; \"\" = the heaviest such tile"),
    GS_CFG_KEY_BOOL(model_config, tile_image, "model.tile_image", "true",
                    "tile set / sample: write the picture assembled from tile images "
                    "(tiles.png) or pattern pixels (image.png)"),
    GS_CFG_KEY_PATH(model_config, sample, "model.sample", "",
                    "sample PNG for the overlapping model (N x N patterns = labels); 2D"),
    GS_CFG_KEY_INT(model_config, overlap_n, "model.overlap_n", 2, 8, 0, "3",
                   "overlapping model: pattern edge N"),
    GS_CFG_KEY_INT(model_config, symmetry, "model.symmetry", 1, 8, 0, "8",
                   "overlapping model: pattern variants (1 as is, 2 + mirror, ... 8 all "
                   "rotations and mirrors)"),
    GS_CFG_KEY_BOOL(model_config, ground, "model.ground", "false",
                    "overlapping model (WFC samples.xml `ground`): the output's bottom row "
                    "takes the patterns of the sample's bottom row, and patterns found only "
                    "there appear nowhere else"),
    GS_CFG_KEY_BOOL(model_config, periodic_input, "model.periodic_input", "true",
                    "overlapping model: windows wrap around the sample's edges"),
    GS_CFG_KEY_ENUM(model_config, format, "model.format", "auto|txt|csv|vox|h5", "auto",
                    "example format; auto = from the file name extension"),
    GS_CFG_KEY_STRING(model_config, dataset, "model.dataset", "/model/labels",
                      "uint16 [nz x ny x nx] dataset read from an .h5 example or start model"),
    GS_CFG_KEY_INT3(model_config, size, "model.size", 1, MODEL_MAX_EXTENT, 0, "40x40x10",
                    "output size in cells, x y z (z up)"),
    GS_CFG_KEY_INT3(model_config, region, "model.region", 0, MODEL_MAX_EXTENT, 0, "0",
                    "region (block) edge per axis; 0 or >= the output extent = whole axis "
                    "(\"0\" = whole-grid mode)"),
    GS_CFG_KEY_INT(model_config, overlap, "model.overlap", -1, MODEL_MAX_EXTENT, 0, "-1",
                   "cells shared by neighbouring regions; -1 = half the region edge"),
    GS_CFG_KEY_INT(model_config, passes, "model.passes", 0, 1000, 0, "1",
                   "keep sweeping until every cell was in this many accepted regions"),
    GS_CFG_KEY_INT(model_config, max_passes, "model.max_passes", 1, 100000, 0, "4",
                   "sweeps at most (stops earlier once model.passes is reached)"),
    GS_CFG_KEY_INT(model_config, attempts, "model.attempts", 1, 100000, 0, "20",
                   "tries per region before it keeps its old (consistent) content"),
    GS_CFG_KEY_INT(model_config, backtracks, "model.backtracks", 0, 100000000, 0, "1000",
                   "undo budget per try on a wipe-out (ac3 only); 0 = none, as in the paper"),
    GS_CFG_KEY_ENUM(model_config, order, "model.order", "entropy|scan|random|entropy_log", "entropy",
                    "cell order: fewest candidates first, the author's scan (z fastest), "
                    "random, or fewest candidates by binary order of magnitude with a fresh "
                    "random tie-break (entropy_log: fewer streaks, fewer retries on hard "
                    "examples)"),
    GS_CFG_KEY_ENUM(model_config, weights, "model.weights", "uniform|frequency", "uniform",
                    "label choice: uniform (author) or proportional to the example's counts"),
    GS_CFG_KEY_INT(model_config, resemblance, "model.resemblance", 0, 2, 0, "2",
                   "resemblance during synthesis (paper Sec. 3.3): window radius w (1 = 3x3x3, "
                   "2 = 5x5x5 example neighbourhoods matched against the decided cells); 0 = "
                   "off (labels drawn by model.weights)"),
    GS_CFG_KEY_INT(model_config, resemblance_slack, "model.resemblance_slack", 0, 64, 0, "0",
                   "resemblance threshold d0 above the minimum distance (0 = the paper's d0)"),
    GS_CFG_KEY_ENUM(model_config, resemblance_outside, "model.resemblance_outside",
                    "mismatch|half|match|background", "mismatch",
                    "resemblance: what a neighbourhood cell past the example's faces scores "
                    "against a decided output cell: a mismatch (before #18 item 2: features near "
                    "the faces, like castle.txt's bushes, never win), half a match, a match "
                    "(the paper's distance over defined cells only: such neighbourhoods then win "
                    "too easily, castle 3x3x3 share 0.26-0.57), or background: a match when the "
                    "output cell holds the commonest label of the example's x/y faces at its "
                    "layer, else a mismatch; configs/model/DEFAULTS.md"),
    GS_CFG_KEY_BOOL(model_config, resemblance_layers, "model.resemblance_layers", "true",
                    "resemblance: a cell at height z draws only from the example's "
                    "neighbourhoods at the same height (output and example share the ground)"),
    GS_CFG_KEY_ENUM(model_config, ac, "model.ac", "ac3|ac4", "ac3",
                    "arc consistency algorithm (ac3 bitsets, ac4 support counts)"),
    GS_CFG_KEY_ENUM(model_config, fix_z_faces, "model.fix_z_faces", "auto|true|false", "auto",
                    "true: keep the bottom (ground) and top (empty) layers of the start model "
                    "(nz >= 3); false: synthesize them too; auto: true when the example's bottom "
                    "layer holds one label (Merrell's lattices), else (e.g. terrain with stone and "
                    "dirt at z = 0) synthesize them, limited to the labels of the example's own "
                    "bottom and top layers; tile sets, samples: true; periodic z: false"),
    GS_CFG_KEY_PATH(model_config, start, "model.start", "",
                    "start model lattice of the output size (consistent; any example format); "
                    "\"\" = inferred"),
    GS_CFG_KEY_STRING(model_config, start_column, "model.start_column", "",
                      "start model as one column of labels, bottom first, repeated over x and "
                      "y; \"\" = inferred"),
    GS_CFG_KEY_INT(model_config, split_depth, "model.split_depth", 0, 8, 0, "2",
                   "a region whose tries all fail is split into 2x2 sub-boxes and retried, up "
                   "to this many levels; 0 = keep the old content (as before)"),
    GS_CFG_KEY_STRING(model_config, pins, "model.pins", "",
                      "hard constraints: \"x,y,z=label; ...\" cells that must take a label "
                      "(active layers only, i.e. not the fixed ground/sky layers)"),
    GS_CFG_KEY_STRING(model_config, border, "model.border", "",
                      "hard constraint: one label per layer, bottom first (like "
                      "start_column), for every cell on the x and y faces of the active layers; "
                      "\"\" = none"),
    GS_CFG_KEY_ENUM(model_config, mirror, "model.mirror", "none|x|y|xy", "none",
                    "mirror-symmetric output: synthesizes the lower half with the transition "
                    "function restricted to pairs whose mirror image (labels mapped by the "
                    "label symmetry S, paper Sec. 4.1) is allowed, then mirrors it, S applied"),
    GS_CFG_KEY_ENUM(model_config, rotate, "model.rotate", "none|90", "none",
                    "rotation-symmetric output (paper Sec. 4.1, Figure 12): 90 = the same turned "
                    "by 90 degrees about z; the label symmetry R (which label is the turned "
                    "image of which) is learned from the example as the diagonal mirror then "
                    "the x mirror; synthesizes the lower-left quarter (rules T' = T and R.T, "
                    "its +x face joined to its +y face), then turns it three times, R applied"),
    GS_CFG_KEY_STRING(model_config, mirror_x_pairs, "model.mirror_x_pairs", "",
                      "label symmetry S of the x mirror as label pairs \"A B, C D\" (other "
                      "labels map to themselves); \"\" = learned from the example's adjacency"),
    GS_CFG_KEY_STRING(model_config, mirror_y_pairs, "model.mirror_y_pairs", "",
                      "label symmetry S of the y mirror as label pairs \"A B, C D\" (other "
                      "labels map to themselves); \"\" = learned from the example's adjacency"),
    GS_CFG_KEY_PATH(model_config, shape, "model.shape", "",
                    "soft constraint (paper Sec. 4.2): grey PNG/JPEG target shape seen from "
                    "above (white = structure belongs in the column, black = none), stretched "
                    "over x and y (row 0 = largest y); \"\" = none"),
    GS_CFG_KEY_REAL(model_config, shape_weight, "model.shape_weight", 0, 50, 0, "4",
                    "strength g of model.shape's constraint-weighted choice: structure labels "
                    "weigh exp(g*(2m-1)), the others exp(-g*(2m-1)), m = the target at the "
                    "column"),
    GS_CFG_KEY_REAL(model_config, shape_mh, "model.shape_mh", 0, 50, 0, "0.2",
                    "model.shape's Metropolis step (paper Sec. 4.2): a resampled region is "
                    "kept with probability min(1, exp(b*dE)), dE = change of the sum over "
                    "cells of (2m-1) per structure cell; b = this (0 = keep every region)"),
    GS_CFG_KEY_INT(model_config, shape_slack, "model.shape_slack", 0, 64, 0, "0",
                   "model.shape with resemblance: outside the target (m < 0.5) the choice also "
                   "weighs example neighbourhoods this much farther than the closest, so "
                   "proposals can end structure there"),
    GS_CFG_KEY_INT(model_config, frames, "model.frames", 1, 4096, 0, "1",
                   "time steps of a 4D output (paper Sec. 4.3): > 1 needs a 4D example (Merrell "
                   ".txt with an 'X Y Z T' extents line, or an .h5 [T, Z, Y, X] dataset); "
                   "transitions along time are learned from its frames like those in space; "
                   "writes frame_NNN.vox per frame and "
                   "lattice.xmf as a time series"),
    GS_CFG_KEY_INT(model_config, overlap3d, "model.overlap3d", 0, 4, 0, "0",
                   "3D overlapping model: N > 0 makes every NxNxN window lying inside the "
                   "example a label, neighbours along x/y/z agreeing on their (N-1)-thick "
                   "overlap; the output holds each pattern's origin cell, so its k^3 windows "
                   "(k <= N) are example windows; z faces take the patterns of the example's "
                   "bottom / top (model.fix_z_faces = auto); at most 8192 patterns; 0 = off "
                   "(labels = the example's labels)"),
    GS_CFG_KEY_INT(model_config, start_block, "model.start_block", 0, 4096, 0, "0",
                   "start model: N > 0 tiles a synthesized NxN block periodic in x and y "
                   "(regions then see the example's variety at their shells); 0 = one column"),
    GS_CFG_KEY_ENUM(model_config, periodic, "model.periodic", "none|x|y|xy|xyz", "none",
                    "output wraps along these axes (rules hold across the wrap; z needs "
                    "fix_z_faces = false)"),
    GS_CFG_KEY_ENUM(model_config, mesh, "model.mesh", "ply|obj|none", "ply",
                    "mesh of coloured voxel cubes with merged faces; mesh.glb (glTF binary) "
                    "is written next to it"),
    GS_CFG_KEY_BOOL(model_config, vox, "model.vox", "true",
                    "also write lattice.vox (MagicaVoxel)"),
    GS_CFG_KEY_BOOL(model_config, preview, "model.preview", "true",
                    "3D lattices: write preview.png, the example and the output side by side as "
                    "coloured cubes (colours as in lattice.vox)"),
    GS_CFG_KEY_INT(model_config, preview_size, "model.preview_size", 16, 2048, 0, "512",
                   "preview.png: pixels per panel side"),
    GS_CFG_KEY_BOOL(model_config, txt, "model.txt", "false",
                    "also write lattice.txt in Merrell's format (his editor scripts read it)"),
    GS_CFG_KEY_REAL(model_config, voxel_size, "model.voxel_size", 0, 1e9, GS_CFG_OPEN_LO, "1",
                    "edge of one cell in the mesh"),
    GS_CFG_RUN_KEYS(model_config, run, "model"),
};

static const gs_cfg_table model_table =
    GS_CFG_TABLE("model", model_config, model_keys, model_validate);

/* ---- engine state ----------------------------------------------------- */

typedef struct region_hdr {
    int32_t ok, attempts;
    uint64_t choices, backtracks;
} region_hdr;

typedef struct model_engine {
    const model_config *cfg;
    gs_model_params params;
    uint16_t *pins;          /* hard constraints (NULL = none), lattice cells */
    float *shape;            /* soft target shape (NULL = none), lat nx*ny */
    uint8_t *structure;      /* model.shape: [nlabels] structure labels of the example */
    int nstructure_labels;
    int full[3];             /* output extents (mirror: lat holds the lower half) */
    int *mirror_map[2];      /* label symmetry S of the x and y mirrors (NULL = none) */
    int *rotate_map;         /* model.rotate: R, the label turned by 90 degrees (NULL = none) */
    uint64_t *ground;        /* model.ground: [2][W] ground labels, labels only there */
    uint64_t *zface;         /* model.fix_z_faces = auto, synthesized: [2][W] the labels of
                                the example's bottom and top layers */
    gs_model_lattice example, lat, start;
    gs_model_palette pal;
    gs_model_tileset ts;     /* model.tileset (pixels on rank 0 only) */
    gs_model_patterns pats;  /* model.sample */
    gs_model_patterns3d p3;  /* model.overlap3d: e->example holds the pattern label of
                                each example window (p3.windows' copy), src the example */
    gs_model_lattice src, plat; /* overlap3d: the example's labels; after synthesis, the
                                   lattice of patterns (e->lat is decoded) */
    gs_model_rules_t rules;
    gs_model_resem_t resem;
    gs_model_solver_t solver;
    uint16_t *coverage;  /* accepted regions per cell (saturating) */
    uint16_t *buf;       /* one region's labels */
    size_t buf_cells;
    gs_model_region *plan; /* regions of the current pass, index = id */
    size_t nplan;
    int ncolors;
    int32_t *region_status;   /* pass in progress: -1 not run, 0 failed, 1 accepted */
    int32_t *region_attempts; /* pass in progress: tries used */
    gs_progress pass_prog;    /* regions of the pass in progress (rank 0 prints) */
    uint64_t pass_done;       /* its regions with a result */
    int pass_prog_open;
    /* sweep position and statistics (identical on every rank) */
    int pass, color, done;
    int64_t units;
    gs_model_stats stats;
    uint64_t region_cells; /* cells of all region runs */
    double synth_seconds;  /* synthesis wall time, summed over resumes */
    gs_regions_stats queue; /* this rank's region runs and waits, this process only */
    double t_windows;       /* this rank's seconds in run_window (set-up + dataflow) */
    uint64_t example_digest;
} model_engine;

static gs_err engine_params(const model_config *c, gs_model_params *p)
{
    gs_model_params_default(p);
    p->seed = (uint64_t)c->run.seed;
    for (int a = 0; a < 3; a++)
        p->region[a] = (int)c->region[a];
    p->overlap = (int)c->overlap;
    p->attempts = (int)c->attempts;
    p->min_changes = (int)c->passes;
    p->max_passes = (int)c->max_passes;
    p->fix_z_faces = strcmp(c->fix_z_faces, "false") != 0 && !strchr(c->periodic, 'z');
    p->backtracks = (int)c->backtracks;
    p->order = !strcmp(c->order, "scan")          ? GS_MODEL_ORDER_SCAN
               : !strcmp(c->order, "random")      ? GS_MODEL_ORDER_RANDOM
               : !strcmp(c->order, "entropy_log") ? GS_MODEL_ORDER_ENTROPY_LOG
                                                  : GS_MODEL_ORDER_ENTROPY;
    p->weights = !strcmp(c->weights, "frequency") ? GS_MODEL_WEIGHTS_FREQUENCY
                                                  : GS_MODEL_WEIGHTS_UNIFORM;
    p->ac = !strcmp(c->ac, "ac4") ? GS_MODEL_AC4 : GS_MODEL_AC3;
    p->split_depth = (int)c->split_depth;
    p->periodic[0] = strchr(c->periodic, 'x') != NULL;
    p->periodic[1] = strchr(c->periodic, 'y') != NULL;
    p->periodic[2] = strchr(c->periodic, 'z') != NULL;
    return GS_OK;
}

static size_t lattice_cells(const gs_model_lattice *l)
{
    return (size_t)l->nx * (size_t)l->ny * (size_t)l->nz;
}

/* Collective: rank 0's lattice (and its load status) to every rank. */
static gs_err bcast_lattice(MPI_Comm comm, gs_model_lattice *l, gs_err loaded)
{
    GS_CALL(gs_par_agree(comm, loaded));
    int dims[4] = {l->nx, l->ny, l->nz, l->frames};
    GS_CALL(GS_PAR_BCAST_VALUE(comm, &dims, 0));
    if (!l->labels)
        GS_CALL(gs_model_lattice_create(l, dims[0], dims[1], dims[2]));
    l->frames = dims[3];
    GS_CALL(gs_par_bcast_bytes(comm, l->labels, lattice_cells(l) * sizeof *l->labels, 0));
    return GS_OK;
}

/* Tile sets and patterns have no example lattice: the start model needs a
 * label that may sit next to itself along x and y. The 1x1x1 "example"
 * holds the heaviest such label (first on ties), which gs_model_initial
 * prefers. */
static gs_err pseudo_example(model_engine *e)
{
    const char *what = e->cfg->tileset[0] ? e->cfg->tileset : e->cfg->sample;
    int L = gs_model_rules_nlabels(e->rules), best = -1;
    for (int l = 1; l < L; l++) {
        if (!gs_model_rules_count(e->rules, l) || !gs_model_rules_allows(e->rules, 0, l, l) ||
            !gs_model_rules_allows(e->rules, 2, l, l))
            continue;
        if (best < 0 || gs_model_rules_count(e->rules, l) > gs_model_rules_count(e->rules, best))
            best = l;
    }
    if (e->cfg->start_tile[0]) {
        char want[80];
        snprintf(want, sizeof want, "%s%s", e->cfg->start_tile,
                 strchr(e->cfg->start_tile, ' ') ? "" : " 0");
        best = -1;
        for (int t = 0; t < e->ts.ntiles && best < 0; t++)
            if (!strcmp(e->ts.names[t], want))
                best = t + 1;
        GS_CHECK(best > 0, GS_ERR_ARG, "model.start_tile = %s: no such tile in %s%s%s",
                 e->cfg->start_tile, what, e->cfg->subset[0] ? " subset " : "", e->cfg->subset);
        GS_CHECK(gs_model_rules_allows(e->rules, 0, best, best) &&
                     gs_model_rules_allows(e->rules, 2, best, best),
                 GS_ERR_ARG,
                 "model.start_tile = %s: the tile may not sit next to itself along x and y in "
                 "%s, so it cannot fill the start model",
                 e->cfg->start_tile, what);
    }
    GS_CHECK(best > 0 || e->cfg->start[0], GS_ERR_ARG,
             "%s: no %s may sit next to itself along both x and y, so there is no trivial "
             "consistent start model; give one with model.start",
             what, e->cfg->tileset[0] ? "tile" : "pattern");
    /* a voxel tile set's ground lies under the start tile (gs_model_initial
     * then prefers that column) */
    int ground = e->ts.ground && e->cfg->size[2] > 1;
    GS_CALL(gs_model_lattice_create(&e->example, 1, 1, 1 + ground));
    e->example.labels[0] = (uint16_t)(ground ? e->ts.ground : best > 0 ? best : 1);
    if (ground)
        e->example.labels[1] = (uint16_t)(best > 0 ? best : 1);
    return GS_OK;
}

/* model.overlap3d (every rank, from the broadcast example): patterns,
 * their overlap rules; e->example becomes the lattice of the example's
 * window patterns (its bottom / top layers give the z face patterns, its
 * columns the start model's preference), the example itself moves to src. */
static gs_err overlap3d_setup(model_engine *e)
{
    const model_config *c = e->cfg;
    GS_CALL(gs_model_patterns3d_learn(&e->example, (int)c->overlap3d,
                                      MODEL_OVERLAP3D_MAX_PATTERNS, c->example, &e->p3));
    GS_CALL(gs_model_patterns3d_rules(&e->p3, &e->rules));
    e->params.support_empty = e->p3.support_empty; /* no floating structure: the example has none */
    e->src = e->example;
    memset(&e->example, 0, sizeof e->example);
    const gs_model_lattice *w = &e->p3.windows;
    GS_CALL(gs_model_lattice_create(&e->example, w->nx, w->ny, w->nz));
    memcpy(e->example.labels, w->labels, lattice_cells(w) * sizeof *w->labels);
    const int L = gs_model_rules_nlabels(e->rules);
    gs_log(GS_LOG_INFO,
           "overlap3d: %d distinct %dx%dx%d windows of the example's %zu (%dx%dx%d origins), "
           "%zu overlap pairs, rules %.1f MiB",
           e->p3.npatterns, e->p3.n, e->p3.n, e->p3.n, lattice_cells(w), w->nx, w->ny, w->nz,
           e->p3.npairs, 8.0 * L * (double)((L + 63) / 64) * 8 / 1048576.0);
    return GS_OK;
}

/* The rules are bit sets indexed by label id, sized by the largest id: one
 * id 65534 in a 4x4x6 example asked for 4 GB of transition sets. Ids are
 * not renumbered (outputs keep the example's ids), so a sparse set whose
 * rules would take more than 64 MiB and more than 64 times what the labels
 * present need with ids 1..k is refused here, naming the label and a cell
 * holding it. */
#define MODEL_SPARSE_RULES_MIB 64
static gs_err check_label_ids(const char *path, const gs_model_lattice *ex)
{
    size_t n = lattice_cells(ex), at = 0;
    uint8_t *seen = gs_calloc(65536, 1);
    GS_CHECK(seen, GS_ERR_MEM, "label set: cannot allocate");
    int maxl = 0, k = 0;
    for (size_t i = 0; i < n; i++) {
        int l = ex->labels[i];
        if (!seen[l]) {
            seen[l] = 1;
            k++;
        }
        if (l > maxl) {
            maxl = l;
            at = i;
        }
    }
    gs_free(seen);
    double need = (double)(maxl + 1) * GS_MODEL_DIRS * (double)((maxl + 64) / 64) * 8;
    double dense = (double)k * GS_MODEL_DIRS * (double)((k + 63) / 64) * 8;
    if (need <= MODEL_SPARSE_RULES_MIB * 1048576.0 || need <= 64 * dense)
        return GS_OK;
    const size_t plane = (size_t)ex->nx * (size_t)ex->ny;
    GS_RAISE(GS_ERR_FORMAT,
             "%s: label %d (at x %zu y %zu z %zu) among %d distinct labels: rules are sized by "
             "the largest label id, %.0f MiB here (more than %d MiB); renumber the labels "
             "densely (1, 2, 3, ...; 0 stays empty)",
             path, maxl, at % (size_t)ex->nx, at % plane / (size_t)ex->nx, at / plane, k,
             need / 1048576.0, MODEL_SPARSE_RULES_MIB);
}

static gs_err load_inputs(gs_run *run, model_engine *e)
{
    const model_config *c = e->cfg;
    gs_err err = GS_OK;
    if (c->tileset[0] || c->sample[0]) {
        /* Every rank parses the (small) input; only rank 0 needs tile images. */
        err = c->tileset[0] ? gs_model_tileset_load_any(c->tileset, c->subset, c->tile_folder,
                                                        run->rank == 0, &e->ts)
                            : gs_model_patterns_learn(c->sample, (int)c->overlap_n,
                                                      (int)c->symmetry, c->periodic_input,
                                                      &e->pats);
        if (!err && c->tileset[0] && e->ts.dim == 2 && c->size[2] != 1)
            err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                 "model.size z = %lld: %s is a 2D tile set, expected z = 1",
                                 (long long)c->size[2], c->tileset);
        /* tiles.png is assembled after the synthesis: refuse a picture the
         * PNG writer cannot take before spending the synthesis on it (tile
         * images are loaded on rank 0 only). */
        if (!err && c->tileset[0] && e->ts.dim == 2 && c->tile_image && e->ts.pixels &&
            (c->size[0] * e->ts.tile_w > GS_IMAGE_MAX_SIDE ||
             c->size[1] * e->ts.tile_h > GS_IMAGE_MAX_SIDE))
            err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                 "model.tile_image: model.size = %lldx%lld tiles of %s (%dx%d "
                                 "pixels each) make a tiles.png of %lldx%lld pixels, more than "
                                 "%d per side; set model.tile_image = false or a smaller "
                                 "model.size",
                                 (long long)c->size[0], (long long)c->size[1], c->tileset,
                                 e->ts.tile_w, e->ts.tile_h, (long long)c->size[0] * e->ts.tile_w,
                                 (long long)c->size[1] * e->ts.tile_h, GS_IMAGE_MAX_SIDE);
        GS_CALL(gs_par_agree(run->comm, err));
        GS_CALL(c->tileset[0] ? gs_model_tileset_rules(&e->ts, &e->rules)
                              : gs_model_patterns_rules(&e->pats, &e->rules));
        GS_CALL(pseudo_example(e));
    } else {
        if (run->rank == 0)
            err = gs_model_load(c->example, c->format, c->dataset, &e->example, &e->pal);
        if (run->rank == 0 && !err)
            err = check_label_ids(c->example, &e->example);
        GS_CALL(bcast_lattice(run->comm, &e->example, err));
        GS_CALL(GS_PAR_BCAST_VALUE(run->comm, &e->pal, 0));
        if (c->overlap3d > 0)
            GS_CALL(overlap3d_setup(e));
    }
    if (c->start[0]) {
        if (run->rank == 0) {
            err = gs_model_load(c->start, "auto", c->dataset, &e->start, NULL);
            if (!err && (e->start.nx != c->size[0] || e->start.ny != c->size[1] ||
                         e->start.nz != c->size[2]))
                err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                     "model.start = %s is %dx%dx%d: expected the output size "
                                     "model.size = %lldx%lldx%lld",
                                     c->start, e->start.nx, e->start.ny, e->start.nz,
                                     (long long)c->size[0], (long long)c->size[1],
                                     (long long)c->size[2]);
        }
        GS_CALL(bcast_lattice(run->comm, &e->start, err));
    }
    e->example_digest = gs_model_lattice_digest(&e->example);
    /* Pair lists by value (the struct has padding bytes), plus the weights. */
    const gs_model_pair *pairs = e->ts.npairs   ? e->ts.pairs
                                 : e->p3.npairs ? e->p3.pairs
                                                : e->pats.pairs;
    size_t np = e->ts.npairs ? e->ts.npairs : e->p3.npairs ? e->p3.npairs : e->pats.npairs;
    if (np) {
        uint64_t *keys = NULL;
        GS_CALL(gs_alloc_array((void **)&keys, np, sizeof *keys, "input digest"));
        for (size_t i = 0; i < np; i++)
            keys[i] = (uint64_t)pairs[i].dir << 32 | (uint64_t)pairs[i].a << 16 | pairs[i].b;
        e->example_digest ^= gs_digest_bytes(keys, np * sizeof *keys);
        gs_free(keys);
        int L = gs_model_rules_nlabels(e->rules);
        for (int l = 0; l < L; l++)
            e->example_digest = e->example_digest * 31 + gs_model_rules_count(e->rules, l);
    }
    return GS_OK;
}

/* model.ground start: one label per row, each next to itself along x, the
 * last row a ground pattern, no ground-only pattern above it, valid +y
 * transitions; the most frequent feasible label per row, top down. */
static gs_err ground_start(model_engine *e)
{
    gs_model_lattice *lat = &e->lat;
    const int L = gs_model_rules_nlabels(e->rules), ny = lat->ny;
    uint8_t *reach = NULL;
    GS_CALL(gs_alloc_array((void **)&reach, (size_t)ny * (size_t)L, 1, "ground start"));
    memset(reach, 0, (size_t)ny * (size_t)L);
    const uint64_t *g = e->params.ground, *only = e->params.ground_only;
#define GBIT(set, l) (((set)[(l) >> 6] >> ((l) & 63)) & 1)
    for (int y = ny - 1; y >= 0; y--)
        for (int l = 1; l < L; l++) {
            if (!gs_model_rules_count(e->rules, l) || !gs_model_rules_allows(e->rules, 0, l, l) ||
                (y == ny - 1 ? !GBIT(g, l) : GBIT(only, l)))
                continue;
            int ok = y == ny - 1;
            for (int m = 1; m < L && !ok; m++)
                ok = reach[(size_t)(y + 1) * L + m] && gs_model_rules_allows(e->rules, 2, l, m);
            reach[(size_t)y * L + l] = (uint8_t)ok;
        }
#undef GBIT
    int prev = -1;
    gs_err err = GS_OK;
    for (int y = 0; y < ny && !err; y++) {
        int best = -1;
        for (int l = 1; l < L; l++)
            if (reach[(size_t)y * L + l] && (prev < 0 || gs_model_rules_allows(e->rules, 2, prev, l)) &&
                (best < 0 || gs_model_rules_count(e->rules, l) > gs_model_rules_count(e->rules, best)))
                best = l;
        if (best < 0)
            err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                 "model.ground: no start model: no rows of one pattern each lead "
                                 "down to a ground pattern of %s that repeats along x",
                                 e->cfg->sample);
        for (int x = 0; x < lat->nx && !err; x++)
            for (int z = 0; z < lat->nz; z++)
                lat->labels[gs_model_lattice_index(lat, x, y, z)] = (uint16_t)best;
        prev = best;
    }
    gs_free(reach);
    return err;
}

/* Start model on every rank (deterministic, so no broadcast). */
static gs_err build_start(model_engine *e)
{
    const model_config *c = e->cfg;
    if (c->ground && !c->start[0])
        return ground_start(e);
    if (c->start[0]) {
        memcpy(e->lat.labels, e->start.labels, lattice_cells(&e->lat) * sizeof(uint16_t));
        size_t nv = gs_model_rules_violations(e->rules, &e->lat);
        GS_CHECK(nv == 0, GS_ERR_ARG,
                 "model.start = %s: %zu adjacent pairs never occur in the example %s; the start "
                 "model must be consistent (check it with geosynth model-check)",
                 c->start, nv, c->example);
        return GS_OK;
    }
    if (c->start_column[0]) {
        uint16_t *col = NULL;
        GS_CALL(gs_alloc_array((void **)&col, (size_t)e->lat.nz, sizeof *col, "start column"));
        char why[160];
        (void)parse_column(c->start_column, col, e->lat.nz, why, sizeof why);
        gs_err err = gs_model_initial(e->rules, &e->example, col, &e->lat);
        gs_free(col);
        if (err)
            gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    if (c->overlap3d > 0) {
        /* a column of layer-filling patterns, its bottom and top found at the
         * example's bottom and top (the z face masks; none with fix_z_faces =
         * false) */
        const size_t W = ((size_t)gs_model_rules_nlabels(e->rules) + 63) / 64;
        gs_err err = gs_model_initial_faces(e->rules, &e->example, NULL, e->zface,
                                            e->zface ? e->zface + W : NULL, &e->lat);
        if (err)
            gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    if (c->start_block > 0) {
        int tiled = 0;
        GS_CALL(gs_model_initial_tiled(e->rules, &e->example, &e->params, (int)c->start_block,
                                       &e->lat, &tiled));
        gs_log(GS_LOG_INFO, "start model: %s", tiled ? "periodic tile repeated"
                                                     : "tile failed, one column repeated");
        GS_CHECK(!(e->params.periodic[0] || e->params.periodic[1]) ||
                     gs_model_rules_violations_wrap(e->rules, &e->lat, e->params.periodic) == 0,
                 GS_ERR_ARG, "model.start_block = %lld must divide the periodic output extents",
                 (long long)c->start_block);
        return GS_OK;
    }
    return gs_model_initial(e->rules, &e->example, NULL, &e->lat);
}

static gs_err make_plan(model_engine *e)
{
    GS_FREE(e->plan);
    GS_FREE(e->region_status);
    GS_FREE(e->region_attempts);
    GS_CALL(gs_model_plan(&e->params, e->lat.nx, e->lat.ny, e->lat.nz, e->pass, &e->plan,
                          &e->nplan, &e->ncolors));
    for (size_t i = 0; i < e->nplan; i++)
        GS_CHECK(e->plan[i].id == i, GS_ERR_INTERNAL, "plan id %u at %zu", e->plan[i].id, i);
    GS_CALL(gs_alloc_array((void **)&e->region_status, e->nplan, sizeof(int32_t), "region status"));
    GS_CALL(gs_alloc_array((void **)&e->region_attempts, e->nplan, sizeof(int32_t),
                           "region attempts"));
    for (size_t i = 0; i < e->nplan; i++) {
        e->region_status[i] = -1;
        e->region_attempts[i] = 0;
    }
    if (!e->buf && e->nplan) {
        const gs_model_box *b = &e->plan[0].box;
        e->buf_cells = (size_t)(b->x1 - b->x0) * (size_t)(b->y1 - b->y0) * (size_t)(b->z1 - b->z0);
        GS_CALL(gs_alloc_array((void **)&e->buf, e->buf_cells, sizeof *e->buf, "region labels"));
    }
    return GS_OK;
}

static size_t box_cells(const gs_model_box *b)
{
    return (size_t)(b->x1 - b->x0) * (size_t)(b->y1 - b->y0) * (size_t)(b->z1 - b->z0);
}

static gs_err region_run(void *ctx, int64_t id, int color, int pass, gs_rng *rng,
                         gs_region_out *out)
{
    (void)color;
    (void)rng; /* the core keys its own streams by (seed, region id, pass, attempt) */
    model_engine *e = ctx;
    GS_CHECK(id >= 0 && (size_t)id < e->nplan, GS_ERR_INTERNAL, "region id %lld", (long long)id);
    const gs_model_region *r = &e->plan[id];
    size_t cells = box_cells(&r->box);
    GS_CHECK(cells <= e->buf_cells, GS_ERR_INTERNAL, "region %lld larger than the first",
             (long long)id);
    gs_model_region_result res;
    GS_CALL(gs_model_region_run(e->solver, &e->lat, &r->box, &e->params, r->id, (uint64_t)pass,
                                e->buf, &res));
    /* ok: 1 accepted, 2 partly resampled (apply, count as failed), 0 kept */
    /* ok: 1 accepted, 2 partly resampled (apply, count as failed), 0 kept,
     * 3 consistent but not accepted by the Metropolis step (kept) */
    region_hdr h = {res.ok ? 1 : res.partial ? 2 : res.mh_rejected ? 3 : 0, res.attempts,
                    res.choices, res.backtracks};
    GS_CALL(gs_region_out_append(out, &h, sizeof h));
    if (h.ok == 1 || h.ok == 2)
        GS_CALL(gs_region_out_append(out, e->buf, cells * sizeof *e->buf));
    return GS_OK;
}

static gs_err region_apply(void *ctx, int64_t id, const void *buf, size_t len)
{
    model_engine *e = ctx;
    const gs_model_region *r = &e->plan[id];
    const gs_model_box *b = &r->box;
    size_t cells = box_cells(b);
    region_hdr h;
    GS_CHECK(len >= sizeof h, GS_ERR_INTERNAL, "region %lld: %zu result bytes", (long long)id, len);
    memcpy(&h, buf, sizeof h);
    GS_CHECK(len == sizeof h + (h.ok == 1 || h.ok == 2 ? cells * sizeof(uint16_t) : 0),
             GS_ERR_INTERNAL,
             "region %lld: %zu result bytes for ok=%d", (long long)id, len, (int)h.ok);
    e->stats.regions++;
    e->stats.attempts += (uint64_t)h.attempts;
    e->stats.choices += h.choices;
    e->stats.backtracks += h.backtracks;
    e->region_cells += cells;
    if (e->region_status[id] < 0 && e->pass_prog_open)
        gs_progress_update(&e->pass_prog, ++e->pass_done);
    e->region_status[id] = h.ok == 1;
    e->region_attempts[id] = h.attempts;
    if (h.ok == 3) {
        e->stats.mh_rejected++;
        return GS_OK;
    }
    if (h.ok != 1) {
        e->stats.failed++;
        if (h.ok == 2)
            gs_model_region_apply(&e->lat, b, (const uint16_t *)((const char *)buf + sizeof h));
        return GS_OK;
    }
    e->stats.accepted++;
    gs_model_region_apply(&e->lat, b, (const uint16_t *)((const char *)buf + sizeof h));
    for (int z = b->z0; z < b->z1; z++)
        for (int y = b->y0; y < b->y1; y++)
            for (int x = b->x0; x < b->x1; x++) {
                uint16_t *cv = &e->coverage[gs_model_lattice_index(&e->lat, x, y, z)];
                if (*cv < UINT16_MAX)
                    (*cv)++;
            }
    return GS_OK;
}

/* Fewest accepted regions over the active cells (the core driver's rule). */
static uint64_t min_coverage(const model_engine *e)
{
    const gs_model_lattice *l = &e->lat;
    int fix = e->params.fix_z_faces && l->nz >= 3;
    uint64_t m = UINT64_MAX;
    for (int z = fix; z < (fix ? l->nz - 1 : l->nz); z++)
        for (int y = 0; y < l->ny; y++)
            for (int x = 0; x < l->nx; x++) {
                uint64_t cv = e->coverage[gs_model_lattice_index(l, x, y, z)];
                if (cv < m)
                    m = cv;
            }
    return m == UINT64_MAX ? 0 : m;
}

/* ---- checkpoint ----------------------------------------------------------- */

static gs_h5_shape lattice_shape(const gs_model_lattice *l)
{
    gs_h5_shape s = {GS_H5_U16, 3, {(uint64_t)l->nz, (uint64_t)l->ny, (uint64_t)l->nx}};
    if (l->frames > 1) { /* 4D: [t][z][y][x], the same bytes */
        gs_h5_shape s4 = {GS_H5_U16, 4, {(uint64_t)l->frames, (uint64_t)gs_model_frame_nz(l),
                                         (uint64_t)l->ny, (uint64_t)l->nx}};
        return s4;
    }
    return s;
}

static gs_err write_checkpoint(gs_run *run, model_engine *e)
{
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_begin(run, &h));
    gs_err err = GS_OK;
    gs_h5_shape ls = lattice_shape(&e->lat);
    const char *g = "/model";
    GS_TRY(err, gs_ckpt_write_whole(h, "/model/lattice", &ls, e->lat.labels, NULL), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/model/coverage", &ls, e->coverage, NULL), fail);
    if (e->nplan) {
        gs_h5_shape rs = {GS_H5_I32, 1, {e->nplan}};
        GS_TRY(err, gs_ckpt_write_whole(h, "/model/region_status", &rs, e->region_status, NULL),
               fail);
        GS_TRY(err,
               gs_ckpt_write_whole(h, "/model/region_attempts", &rs, e->region_attempts, NULL),
               fail);
    }
    GS_TRY(err, gs_ckpt_set_i64(h, g, "pass", e->pass), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, g, "color", e->color), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, g, "units", e->units), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, g, "nplan", (int64_t)e->nplan), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "example_digest", e->example_digest), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_regions", e->stats.regions), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_accepted", e->stats.accepted), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_failed", e->stats.failed), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_attempts", e->stats.attempts), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_choices", e->stats.choices), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_backtracks", e->stats.backtracks), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_region_cells", e->region_cells), fail);
    if (e->params.shape)
        GS_TRY(err, gs_ckpt_set_u64(h, g, "stat_mh_rejected", e->stats.mh_rejected), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, g, "synthesis_seconds", e->synth_seconds), fail);
    GS_CALL(gs_run_checkpoint_commit(run, &h, e->units));
    return GS_OK;
fail:
    gs_ckpt_discard(&h);
    return err;
}

static gs_err read_checkpoint(gs_run *run, model_engine *e)
{
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_open(run, &h));
    gs_err err = GS_OK;
    const char *g = "/model";
    int64_t pass = 0, color = 0, nplan = 0;
    uint64_t exd = 0;
    GS_TRY(err, gs_ckpt_get_u64(h, g, "example_digest", &exd), done);
    GS_TRY_CHECK(err, exd == e->example_digest, GS_ERR_ARG, done,
                 "%s: the example %s changed since the checkpoint was written (digest "
                 "%016llx, now %016llx): resume needs the same example",
                 gs_ckpt_path(h),
                 e->cfg->tileset[0] ? e->cfg->tileset
                 : e->cfg->sample[0] ? e->cfg->sample : e->cfg->example,
                 (unsigned long long)exd,
                 (unsigned long long)e->example_digest);
    GS_TRY(err, gs_ckpt_get_i64(h, g, "pass", &pass), done);
    GS_TRY(err, gs_ckpt_get_i64(h, g, "color", &color), done);
    GS_TRY(err, gs_ckpt_get_i64(h, g, "units", &e->units), done);
    GS_TRY(err, gs_ckpt_get_i64(h, g, "nplan", &nplan), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_regions", &e->stats.regions), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_accepted", &e->stats.accepted), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_failed", &e->stats.failed), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_attempts", &e->stats.attempts), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_choices", &e->stats.choices), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_backtracks", &e->stats.backtracks), done);
    GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_region_cells", &e->region_cells), done);
    if (e->params.shape)
        GS_TRY(err, gs_ckpt_get_u64(h, g, "stat_mh_rejected", &e->stats.mh_rejected), done);
    GS_TRY(err, gs_ckpt_get_f64(h, g, "synthesis_seconds", &e->synth_seconds), done);
    gs_h5_shape ls = lattice_shape(&e->lat);
    GS_TRY(err, gs_ckpt_read_whole(h, "/model/lattice", &ls, e->lat.labels), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/model/coverage", &ls, e->coverage), done);
    GS_TRY_CHECK(err, pass >= 0 && pass < e->params.max_passes && color >= 0, GS_ERR_FORMAT, done,
                 "%s: /model pass %lld colour %lld out of range", gs_ckpt_path(h),
                 (long long)pass, (long long)color);
    e->pass = (int)pass;
    e->color = (int)color;
    GS_TRY(err, make_plan(e), done);
    GS_TRY_CHECK(err, (int64_t)e->nplan == nplan && e->color < e->ncolors, GS_ERR_FORMAT, done,
                 "%s: pass %d has %zu regions in %d colours here, the checkpoint says %lld "
                 "regions, next colour %d",
                 gs_ckpt_path(h), e->pass, e->nplan, e->ncolors, (long long)nplan, e->color);
    if (e->nplan) {
        gs_h5_shape rs = {GS_H5_I32, 1, {e->nplan}};
        GS_TRY(err, gs_ckpt_read_whole(h, "/model/region_status", &rs, e->region_status), done);
        GS_TRY(err, gs_ckpt_read_whole(h, "/model/region_attempts", &rs, e->region_attempts),
               done);
    }
done:
    gs_ckpt_close(&h);
    return err;
}

/* ---- synthesis ------------------------------------------------------------ */

/* Colours run together at most this many regions at a time (one colour
 * alone may have more): bounds the results kept, the conflict lists
 * (gs_model_plan_conflicts, linear in the window) and how late a
 * time-based checkpoint or a signal is seen. */
#define MODEL_WINDOW_REGIONS 2048

/* Collective: runs colours e->color.. of pass e->pass on all ranks, as many
 * as fit a window (see MODEL_WINDOW_REGIONS) and end no later than a
 * unit-based checkpoint or stop would after one colour, as one dataflow
 * (gs_regions_set_conflicts): a region starts when the regions of earlier
 * colours it touches are done, not when the whole colour is. */
static gs_err run_window(gs_run *run, model_engine *e)
{
    double t0 = gs_time_now();
    int64_t budget = 0;
    GS_CALL(gs_run_units_until_due(run, e->units, &budget));
    size_t first = 0;
    while (first < e->nplan && (int)e->plan[first].color < e->color)
        first++;
    size_t last = first;
    int next = e->color;
    do {
        size_t end = last;
        while (end < e->nplan && (int)e->plan[end].color == next)
            end++;
        if (end > last && last > first && end - first > MODEL_WINDOW_REGIONS)
            break;
        last = end;
        next++;
    } while (next < e->ncolors && (int64_t)(last - first) < budget);
    size_t n = last - first;
    if (n == 0) {
        e->color = next;
        return GS_OK;
    }
    gs_region *list = NULL;
    int64_t *off = NULL, *ids = NULL;
    gs_regions_t s = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&list, n, sizeof *list, "colour regions"), done);
    for (size_t i = first; i < last; i++) {
        list[i - first].id = (int64_t)e->plan[i].id;
        list[i - first].color = (int)e->plan[i].color;
    }
    /* conflicts: interacting regions of lower colours (the plan is sorted
     * by colour) */
    GS_TRY(err, gs_model_plan_conflicts(&e->params, e->lat.nx, e->lat.ny, e->lat.nz,
                                        e->plan + first, n, &off, &ids),
           done);
    GS_TRY(err, gs_regions_create(run->comm, list, (int64_t)n, e->params.seed, MODEL_RNG_DOMAIN, &s),
           done);
    GS_TRY(err, gs_regions_set_conflicts(s, off, ids), done);
    GS_TRY(err, gs_regions_run_pass(s, e->pass, region_run, region_apply, e), done);
    gs_regions_stats qs = gs_regions_get_stats(s);
    e->queue.computed += qs.computed;
    e->queue.bytes += qs.bytes;
    e->queue.t_compute += qs.t_compute;
    e->queue.t_wait += qs.t_wait;
    e->queue.t_exchange += qs.t_exchange;
    e->queue.t_apply += qs.t_apply;
    e->queue.t_pass += qs.t_pass;
    e->queue.t_tail += qs.t_tail;
    e->queue.duplicates += qs.duplicates;
    e->units += (int64_t)n;
    e->color = next;
done:
    gs_regions_destroy(&s);
    gs_free(list);
    gs_free(off);
    gs_free(ids);
    e->t_windows += gs_time_now() - t0;
    return err;
}

/* Collective: the next batch of the synthesis (a new pass's plan, then one
 * window of colours, run_window); *finished once the passes are done. */
static gs_err advance_window(gs_run *run, model_engine *e, int *finished)
{
    *finished = e->done;
    if (e->done) {
        e->stats.passes = e->pass;
        return GS_OK;
    }
    if (!e->plan)
        GS_CALL(make_plan(e));
    if (e->color == 0)
        gs_log(GS_LOG_INFO, "pass %d: %zu regions in %d colours", e->pass + 1, e->nplan,
               e->ncolors);
    if (!e->pass_prog_open) { /* a new pass, or the one a checkpoint stopped in */
        char label[64];
        snprintf(label, sizeof label, "pass %d regions", e->pass + 1);
        gs_progress_begin(&e->pass_prog, label, (uint64_t)e->nplan);
        e->pass_done = 0;
        for (size_t i = 0; i < e->nplan; i++)
            e->pass_done += e->region_status[i] >= 0;
        gs_progress_update(&e->pass_prog, e->pass_done);
        e->pass_prog_open = 1;
    }
    GS_CALL(run_window(run, e));
    if (e->color >= e->ncolors) {
        gs_progress_end(&e->pass_prog);
        e->pass_prog_open = 0;
        uint64_t acc = 0, fail = 0;
        for (size_t i = 0; i < e->nplan; i++) {
            acc += e->region_status[i] == 1;
            fail += e->region_status[i] == 0;
        }
        e->stats.min_coverage = min_coverage(e);
        gs_log(GS_LOG_INFO,
               "pass %d done: %llu accepted, %llu failed; every cell in >= %llu accepted "
               "regions (goal %d)",
               e->pass + 1, (unsigned long long)acc, (unsigned long long)fail,
               (unsigned long long)e->stats.min_coverage, e->params.min_changes);
        e->pass++;
        e->color = 0;
        if (e->stats.min_coverage >= (uint64_t)e->params.min_changes ||
            e->pass >= e->params.max_passes)
            e->done = 1;
        else
            GS_CALL(make_plan(e));
    }
    *finished = e->done;
    if (e->done)
        e->stats.passes = e->pass;
    return GS_OK;
}

/* Where each rank's synthesis time went (this process: a resumed run
 * counts since the resume), gathered on rank 0. */
enum {
    Q_REGIONS, Q_COMPUTE, Q_WAIT, Q_TAIL, Q_EXCHANGE, Q_APPLY, Q_FLOW, Q_WINDOW_SETUP, Q_OUTSIDE,
    Q_CPU, Q_DUPLICATES, Q_N
};
static const char *const q_key[Q_N] = {
    "regions", "region_s", "wait_s", "tail_s", "exchange_s", "apply_s", "flow_s",
    "window_setup_s", "outside_windows_s", "cpu_s", "duplicates"};

typedef struct queue_report_t {
    double sum[Q_N], max[Q_N]; /* over the ranks (rank 0) */
} queue_report_t;

/* Collective. The ideal speed-up over one rank is the sum over the max of
 * the region seconds: robust to a shared machine's noise, unlike wall
 * time. Per rank: wait_s = nothing ready to run here (tail_s of it: every
 * region was claimed, the end of a pass), flow_s = in the dataflow passes,
 * window_setup_s = building the window's conflict lists and scheduler
 * (every rank does it, serial), outside_windows_s = the rest of the
 * synthesis phase (plans, coverage, checkpoints). */
static gs_err queue_report(gs_run *run, const model_engine *e, double cpu, queue_report_t *q,
                           gs_json *j)
{
    double mine[Q_N] = {(double)e->queue.computed, e->queue.t_compute, e->queue.t_wait,
                        e->queue.t_tail, e->queue.t_exchange, e->queue.t_apply, e->queue.t_pass,
                        e->t_windows - e->queue.t_pass, e->synth_seconds - e->t_windows, cpu,
                        (double)e->queue.duplicates};
    double *all = run->rank == 0 ? gs_calloc((size_t)run->size * Q_N, sizeof *all) : NULL;
    gs_err local = run->rank == 0 && !all
                       ? gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                        "cannot gather the per-rank times")
                       : GS_OK;
    GS_CALL(gs_par_agree(run->comm, local));
    GS_CALL(gs_par_gather_bytes(run->comm, mine, sizeof mine, all, 0));
    memset(q, 0, sizeof *q);
    if (run->rank != 0)
        return GS_OK;
    /* "per_rank": {key: [rank 0, rank 1, ...], ...} into the open object j */
    gs_json_begin_object(j, "per_rank");
    for (int k = 0; k < Q_N; k++) {
        gs_json_begin_array(j, q_key[k]);
        for (int r = 0; r < run->size; r++) {
            double v = all[(size_t)r * Q_N + k];
            q->sum[k] += v;
            q->max[k] = r == 0 || v > q->max[k] ? v : q->max[k];
            if (k == Q_REGIONS || k == Q_DUPLICATES)
                gs_json_i64(j, NULL, (int64_t)v);
            else
                gs_json_f64(j, NULL, round(v * 1e4) / 1e4);
        }
        gs_json_end_array(j);
    }
    gs_json_end_object(j);
    gs_free(all);
    return GS_OK;
}

/* ---- output --------------------------------------------------------------- */

/* The label table of lattice.h5: the labels the lattice uses, in increasing
 * order, with their colours (as lattice.vox and mesh.ply colour them) and
 * names (the tile's name and orientation for a tile set, the palette index
 * of a .vox example, else "label N"), and a colour per cell for ParaView. */
static gs_err write_label_table(gs_ckpt_t h, const model_engine *e)
{
    const size_t cells = lattice_cells(&e->lat);
    uint8_t *seen = gs_calloc(65536, 1);
    GS_CHECK(seen != NULL, GS_ERR_MEM, "label table: out of memory");
    size_t n = 0;
    for (size_t i = 0; i < cells; i++)
        seen[e->lat.labels[i]] = 1;
    for (int l = 1; l < 65536; l++)
        n += seen[l];
    uint16_t *id = NULL;
    uint8_t *rgb = NULL, *cell_rgb = NULL;
    char *names = NULL;
    gs_err err = GS_OK;
    size_t nn = n ? n : 1, names_len = 0, names_cap = 80 * nn + 1;
    GS_TRY(err, gs_alloc_array((void **)&id, nn, sizeof *id, "label table"), done);
    GS_TRY(err, gs_alloc_array((void **)&rgb, nn, 3, "label table"), done);
    GS_TRY(err, gs_alloc_array((void **)&names, names_cap, 1, "label table"), done);
    GS_TRY(err, gs_alloc_array((void **)&cell_rgb, cells, 3, "cell colours"), done);
    names[0] = '\0';
    n = 0;
    for (int l = 1; l < 65536; l++) {
        if (!seen[l])
            continue;
        id[n] = (uint16_t)l;
        gs_model_label_rgb(&e->pal, (uint16_t)l, rgb + 3 * n);
        const char *tile = e->cfg->tileset[0] && l <= e->ts.ntiles && e->ts.names ? e->ts.names[l - 1] : NULL;
        if (tile)
            names_len += (size_t)snprintf(names + names_len, names_cap - names_len, "%s\n", tile);
        else if (e->pal.from_file)
            names_len += (size_t)snprintf(names + names_len, names_cap - names_len, "palette %d\n", l);
        else
            names_len += (size_t)snprintf(names + names_len, names_cap - names_len, "label %d\n", l);
        n++;
    }
    if (names_len)
        names[names_len - 1] = '\0'; /* one name a line, no trailing newline */
    for (size_t i = 0; i < cells; i++) {
        uint16_t l = e->lat.labels[i];
        if (l)
            gs_model_label_rgb(&e->pal, l, cell_rgb + 3 * i);
        else
            cell_rgb[3 * i] = cell_rgb[3 * i + 1] = cell_rgb[3 * i + 2] = 255; /* empty: white */
    }
    gs_h5_write_opts opts = {4, 0};
    if (n) {
        gs_h5_shape is = {GS_H5_U16, 1, {(uint64_t)n}}, rs = {GS_H5_U8, 2, {(uint64_t)n, 3}};
        GS_TRY(err, gs_ckpt_write_whole(h, "/model/label_table/id", &is, id, &opts), done);
        GS_TRY(err, gs_ckpt_write_whole(h, "/model/label_table/rgb", &rs, rgb, &opts), done);
    } else {
        GS_TRY(err, gs_ckpt_group(h, "/model/label_table"), done);
    }
    GS_TRY(err, gs_ckpt_set_i64(h, "/model/label_table", "labels", (int64_t)n), done);
    GS_TRY(err, gs_ckpt_set_str(h, "/model/label_table", "names", names), done);
    GS_TRY(err, gs_ckpt_set_str(h, "/model/label_table", "index_order",
                                "row k: label id[k], colour rgb[k] (0-255), name = line k of @names; "
                                "label 0 (empty) is not listed"),
           done);
    const gs_h5_shape ls = lattice_shape(&e->lat);
    gs_h5_shape cs = {GS_H5_U8, ls.rank + 1, {0}};
    for (int i = 0; i < ls.rank; i++)
        cs.dims[i] = ls.dims[i];
    cs.dims[ls.rank] = 3;
    GS_TRY(err, gs_ckpt_write_whole(h, "/model/colour", &cs, cell_rgb, &opts), done);
    GS_TRY(err, gs_ckpt_set_str(h, "/model/colour", "index_order",
                                e->lat.frames > 1
                                    ? "colour[t][z][y][x][c]; c = red, green, blue (0-255); x "
                                      "fastest, z up, t = frame; the label's colour, empty cells white"
                                    : "colour[z][y][x][c]; c = red, green, blue (0-255); x fastest, z up; "
                                      "the label's colour, empty cells white"),
           done);
done:
    gs_free(seen);
    gs_free(id);
    gs_free(rgb);
    gs_free(names);
    gs_free(cell_rgb);
    return err;
}

static gs_err write_lattice_h5(gs_run *run, const model_engine *e, const char *path)
{
    gs_ckpt_meta meta = {"model", e->params.seed, run->config_text};
    gs_ckpt_t h = NULL;
    GS_CALL(gs_ckpt_create(MPI_COMM_NULL, path, &meta, &h));
    gs_h5_shape ls = lattice_shape(&e->lat);
    gs_h5_write_opts opts = {4, 0};
    gs_err err = GS_OK;
    char hex[17];
    gs_digest_hex(gs_model_lattice_digest(&e->lat), hex);
    GS_TRY(err, gs_ckpt_write_whole(h, "/model/labels", &ls, e->lat.labels, &opts), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model/labels", "index_order",
                                e->lat.frames > 1
                                    ? "labels[t][z][y][x]; x fastest, z up, t = frame (time step); "
                                      "0 = empty"
                                    : "labels[z][y][x]; x fastest, z up; 0 = empty"),
           fail);
    if (e->lat.frames > 1)
        GS_TRY(err, gs_ckpt_set_i64(h, "/model", "frames", e->lat.frames), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model/labels", "units", "label id (see /model/label_table)"), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model", "up_axis", "z"), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/model", "voxel_size", e->cfg->voxel_size), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model", "units",
                                "cell (x, y, z) is [x, x+1] x [y, y+1] x [z, z+1] times voxel_size "
                                "(model.voxel_size, the example's units per cell)"),
           fail);
    GS_TRY(err, write_label_table(h, e), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model", "digest", hex), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model", "example",
                                e->cfg->tileset[0] ? e->cfg->tileset
                                : e->cfg->sample[0] ? e->cfg->sample : e->cfg->example),
           fail);
    GS_TRY(err, gs_ckpt_commit(&h), fail);
    gs_xdmf_grid grid = {"model lattice", GS_XDMF_CELL,
                         {(uint64_t)gs_model_frame_nz(&e->lat), (uint64_t)e->lat.ny, (uint64_t)e->lat.nx},
                         {0, 0, 0},
                         {e->cfg->voxel_size, e->cfg->voxel_size, e->cfg->voxel_size},
                         (uint64_t)(e->lat.frames > 1 ? e->lat.frames : 1)};
    gs_xdmf_attr attr[2] = {{"label", "/model/labels", GS_H5_U16, 1},
                            {"colour", "/model/colour", GS_H5_U8, 3}};
    GS_CALL(gs_xdmf_write(path, &grid, attr, 2));
    return GS_OK;
fail:
    gs_ckpt_discard(&h);
    return err;
}

typedef struct model_quality {
    size_t violations, rule_violations;
    double resemblance3, resemblance2;
    double run_out[3], run_ex[3];
    size_t quads, unit_faces;
    int labels_used, vox_renumbered;
    int has_figures;              /* an example lattice to compare with */
    gs_model_quality_figures fig; /* owned profile: gs_measure_profile_free */
} model_quality;

/* The mesh (model.mesh), on the last rank: with 2 or more ranks it is
 * written while rank 0 checks the lattice and writes the other files
 * (every rank holds the whole lattice). */
static gs_err write_mesh(gs_run *run, const model_engine *e, int64_t counts[2])
{
    const model_config *c = e->cfg;
    counts[0] = counts[1] = 0;
    if (!strcmp(c->mesh, "none"))
        return GS_OK;
    gs_model_lattice vox = {0};
    gs_model_palette vpal = {{{0}}, 1};
    const gs_model_lattice *lat = &e->lat;
    const gs_model_palette *pal = &e->pal;
    double voxel = c->voxel_size;
    if (e->lat.frames > 1) { /* 4D: every frame, side by side along x */
        GS_CALL(gs_model_lattice_filmstrip(&e->lat, 1, 0, &vox));
        lat = &vox;
    } else if (e->ts.dim == 3) { /* the tiles' voxels, not one cube per tile */
        GS_CALL(gs_model_tileset_assemble(&e->ts, &e->lat, &vox, vpal.rgba));
        lat = &vox;
        pal = &vpal;
        voxel = c->voxel_size / e->ts.vx;
    }
    gs_model_quads quads = {NULL, 0, 0};
    gs_model_polymesh m;
    memset(&m, 0, sizeof m);
    gs_err err = gs_model_mesh_quads(lat, voxel, &quads);
    if (err == GS_OK)
        err = gs_model_mesh_weld(lat, &quads, voxel, &m);
    if (err == GS_OK) {
        counts[0] = (int64_t)quads.n;
        counts[1] = (int64_t)quads.unit_faces;
        char name[16], path[PATH_MAX];
        snprintf(name, sizeof name, "mesh.%s", c->mesh);
        gs_run_path(run, name, path, sizeof path);
        err = gs_model_write_mesh(path, &m, pal);
        if (err == GS_OK) {
            gs_run_path(run, "mesh.glb", path, sizeof path);
            err = gs_model_write_mesh(path, &m, pal);
        }
    }
    gs_model_polymesh_free(&m);
    gs_model_quads_free(&quads);
    gs_model_lattice_destroy(&vox);
    return err;
}

/* The result perr of writing preview.png: without a renderer here
 * (GS_ERR_LIB) the run is still good, so a warning; else perr, and a written
 * preview is listed in the outputs when record. */
static gs_err preview_written(gs_run *run, gs_err perr, int record)
{
    if (perr == GS_ERR_LIB) {
        gs_log(GS_LOG_WARN, "preview.png not written: %s (model.preview = false skips it)",
               gs_error_message());
        gs_error_clear();
        return GS_OK;
    }
    GS_CALL(perr);
    if (record)
        gs_run_output(run, "preview", "preview", "preview.png", NULL);
    return GS_OK;
}

/* Rank 0: every output file but the mesh, and the quality measures. */
static gs_err write_outputs(gs_run *run, const model_engine *e, model_quality *q)
{
    const model_config *c = e->cfg;
    char path[PATH_MAX];
    memset(q, 0, sizeof *q);
    gs_model_violation v[MODEL_VIOLATION_LIST];
    if (c->tileset[0])
        GS_CALL(gs_model_tileset_check(&e->ts, &e->lat, v, MODEL_VIOLATION_LIST, &q->violations));
    else if (c->sample[0])
        GS_CALL(gs_model_patterns_check(&e->pats, &e->lat, &q->violations));
    else /* overlap3d: e->example is the example's labels again, e->lat decoded */
        GS_CALL(gs_model_check(&e->example, &e->lat, v, MODEL_VIOLATION_LIST, &q->violations));
    for (size_t i = 0; i < q->violations && i < MODEL_VIOLATION_LIST && !c->sample[0]; i++)
        gs_log(GS_LOG_WARN, "violation: cell (%d, %d, %d) label %u, dir %d label %u", v[i].x,
               v[i].y, v[i].z, v[i].a, v[i].dir, v[i].b);
    q->rule_violations = c->overlap3d > 0
                             ? gs_model_patterns3d_check(&e->p3, &e->plat, e->params.periodic)
                             : gs_model_rules_violations_wrap(e->rules, &e->lat, e->params.periodic);
    if (!c->tileset[0] && !c->sample[0]) { /* no example lattice to compare with */
        GS_CALL(gs_model_quality(&e->example, &e->lat, &q->fig));
        q->has_figures = 1;
        q->resemblance3 = q->fig.w3.found_share;
        q->resemblance2 = q->fig.w2.found_share;
    }
    gs_model_run_lengths(&e->lat, q->run_out);
    gs_model_run_lengths(&e->example, q->run_ex);
    {
        uint8_t *seen = gs_calloc(65536, 1);
        GS_CHECK(seen != NULL, GS_ERR_MEM, "out of memory");
        for (size_t i = 0; i < lattice_cells(&e->lat); i++)
            seen[e->lat.labels[i]] = 1;
        for (int l = 1; l < 65536; l++)
            q->labels_used += seen[l];
        gs_free(seen);
    }

    int64_t dims[3] = {e->lat.nx, e->lat.ny, e->lat.nz};
    gs_run_path(run, "lattice.h5", path, sizeof path);
    GS_CALL(write_lattice_h5(run, e, path));
    gs_run_output(run, "h5", "lattice", "lattice.h5", dims);
    gs_run_output(run, "xdmf", "lattice", "lattice.xmf", dims);
    if (c->vox && e->lat.frames > 1) { /* 4D: one .vox per frame */
        gs_model_lattice fr = {0};
        int64_t fdims[3] = {e->lat.nx, e->lat.ny, gs_model_frame_nz(&e->lat)};
        for (int t = 0; t < e->lat.frames; t++) {
            char name[32];
            snprintf(name, sizeof name, "frame_%03d.vox", t);
            gs_run_path(run, name, path, sizeof path);
            GS_CALL(gs_model_lattice_frame(&e->lat, t, &fr));
            gs_err ferr = gs_model_write_vox(path, &fr, &e->pal, &q->vox_renumbered);
            gs_model_lattice_destroy(&fr);
            GS_CALL(ferr);
            gs_run_output(run, "vox", "frame", name, fdims);
        }
    } else if (c->vox) {
        gs_run_path(run, "lattice.vox", path, sizeof path);
        GS_CALL(gs_model_write_vox(path, &e->lat, &e->pal, &q->vox_renumbered));
        gs_run_output(run, "vox", "lattice", "lattice.vox", dims);
        if (q->vox_renumbered)
            gs_log(GS_LOG_WARN, "lattice.vox: labels above 255 renumbered 1..%d in order",
                   q->labels_used);
    }
    if (strcmp(c->mesh, "none")) {
        char name[16];
        snprintf(name, sizeof name, "mesh.%s", c->mesh);
        gs_run_output(run, "mesh", "lattice", name, NULL); /* written by write_mesh */
        gs_run_output(run, "mesh", "lattice", "mesh.glb", NULL);
    }
    if (e->lat.nz == 1) {
        gs_run_path(run, "lattice.png", path, sizeof path);
        GS_CALL(gs_model_write_png(path, &e->lat, &e->pal));
        gs_run_output(run, "image", "lattice", "lattice.png", NULL);
    }
    if (c->preview && e->lat.nz > 1 && !c->tileset[0] && !c->sample[0]) {
        gs_run_path(run, "preview.png", path, sizeof path);
        gs_err perr = GS_OK;
        if (e->lat.frames > 1) { /* 4D: the frames side by side, example and output */
            gs_model_lattice exs = {0}, outs = {0};
            GS_CALL(gs_model_lattice_filmstrip(&e->example, 1, MODEL_PREVIEW_FRAMES, &exs));
            perr = gs_model_lattice_filmstrip(&e->lat, 1, MODEL_PREVIEW_FRAMES, &outs);
            if (perr == GS_OK)
                perr = gs_model_write_preview(path, &exs, &outs, &e->pal, (int)c->preview_size);
            gs_model_lattice_destroy(&exs);
            gs_model_lattice_destroy(&outs);
        } else {
            perr = gs_model_write_preview(path, &e->example, &e->lat, &e->pal, (int)c->preview_size);
        }
        GS_CALL(preview_written(run, perr, 1));
    }
    if (e->ts.dim == 3 && c->tile_image) {
        char ppath[PATH_MAX];
        gs_run_path(run, "tiles.vox", path, sizeof path);
        gs_run_path(run, "preview.png", ppath, sizeof ppath);
        GS_CALL(preview_written(run, gs_model_tileset_write_voxels(&e->ts, &e->lat, path,
                                                                   c->preview ? ppath : NULL,
                                                                   (int)c->preview_size),
                                (int)c->preview));
        gs_run_output(run, "vox", "tiles", "tiles.vox", NULL); /* dimensions from the file */
    } else if (c->tileset[0] && c->tile_image) {
        gs_run_path(run, "tiles.png", path, sizeof path);
        GS_CALL(gs_model_tileset_write_png(path, &e->ts, &e->lat));
        gs_run_output(run, "image", "tiles", "tiles.png", NULL);
    }
    if (c->sample[0] && c->tile_image) {
        gs_run_path(run, "image.png", path, sizeof path);
        GS_CALL(gs_model_patterns_write_png(path, &e->pats, &e->lat));
        gs_run_output(run, "image", "patterns", "image.png", NULL);
    }
    if (c->txt) {
        gs_run_path(run, "lattice.txt", path, sizeof path);
        GS_CALL(gs_model_write_merrell_txt(path, &e->lat));
        gs_run_output(run, "text", "lattice", "lattice.txt", dims);
    }
    return GS_OK;
}

/* The quality figures of gs_model_quality into summary.json (docs/FORMATS.md). */
static void write_figures(gs_run *run, const gs_model_quality_figures *f)
{
    const gs_measure_windows *w[2] = {&f->w3, &f->w2};
    static const char *key[2][5] = {
        {"resemblance_3x3x3", "resemblance_3x3x3_with_empty", "completeness_3x3x3",
         "windows_3x3x3_nonempty", "windows_3x3x3_example_distinct"},
        {"resemblance_2x2x2", "resemblance_2x2x2_with_empty", "completeness_2x2x2",
         "windows_2x2x2_nonempty", "windows_2x2x2_example_distinct"}};
    for (int k = 0; k < 2; k++) {
        gs_run_metric_f64(run, key[k][0], w[k]->found_share);
        gs_run_metric_f64(run, key[k][1], w[k]->found_share_all);
        gs_run_metric_f64(run, key[k][2], w[k]->completeness);
        gs_run_metric_i64(run, key[k][3], (int64_t)w[k]->output_nonempty);
        gs_run_metric_i64(run, key[k][4], (int64_t)w[k]->example_distinct);
    }
    gs_run_metric_f64(run, "label_l1", f->label_l1);
    gs_run_metric_i64(run, "labels_example", f->labels_example);
    gs_run_metric_f64(run, "empty_share", f->empty_share);
    gs_run_metric_f64(run, "empty_share_example", f->empty_share_example);
    gs_run_metric_f64(run, "unsupported_share", f->unsupported_share);
    gs_run_metric_f64(run, "unsupported_share_example", f->unsupported_share_example);
    gs_run_metric_f64(run, "height_fill_mean_abs", f->profile.fill_mean_abs);
    gs_run_metric_f64(run, "height_label_l1_mean", f->profile.label_l1_mean);
    gs_run_metric_i64(run, "top_layer", f->profile.top_output);
    gs_run_metric_i64(run, "top_layer_example", f->profile.top_example);
    const double *arr[2] = {f->profile.fill_output, f->profile.fill_example};
    static const char *akey[2] = {"height_fill", "height_fill_example"};
    for (int k = 0; k < 2; k++) {
        gs_json_begin_array(&run->metrics, akey[k]);
        for (int z = 0; z < f->profile.nz; z++)
            gs_json_f64(&run->metrics, NULL, round(arr[k][z] * 1e4) / 1e4);
        gs_json_end_array(&run->metrics);
    }
}

static void engine_free(model_engine *e)
{
    gs_model_lattice_destroy(&e->example);
    gs_model_lattice_destroy(&e->lat);
    gs_model_lattice_destroy(&e->start);
    gs_model_rules_destroy(&e->rules);
    gs_model_resem_destroy(&e->resem);
    gs_model_tileset_destroy(&e->ts);
    gs_model_patterns_destroy(&e->pats);
    gs_model_patterns3d_destroy(&e->p3);
    gs_model_lattice_destroy(&e->src);
    gs_model_lattice_destroy(&e->plat);
    gs_model_solver_destroy(&e->solver);
    gs_free(e->coverage);
    gs_free(e->pins);
    gs_free(e->shape);
    gs_free(e->structure);
    gs_free(e->rotate_map);
    gs_free(e->mirror_map[0]);
    gs_free(e->mirror_map[1]);
    gs_free(e->ground);
    gs_free(e->zface);
    gs_free(e->buf);
    gs_free(e->plan);
    gs_free(e->region_status);
    gs_free(e->region_attempts);
}

/* Label symmetry S of each mirrored axis (given pairs or learned), the rules
 * restricted to S-symmetric pairs (paper Sec. 4.1: T' = S.T). */
static gs_err mirror_setup(model_engine *e)
{
    const model_config *c = e->cfg;
    const int L = gs_model_rules_nlabels(e->rules);
    const int *maps[3] = {NULL, NULL, NULL};
    for (int a = 0; a < 2; a++) {
        if (!e->params.mirror[a])
            continue;
        GS_CALL(gs_alloc_array((void **)&e->mirror_map[a], (size_t)L, sizeof(int), "label symmetry"));
        int *S = e->mirror_map[a];
        const char *pairs = a ? c->mirror_y_pairs : c->mirror_x_pairs;
        int exact = 1;
        if (pairs[0])
            GS_CALL(gs_model_rules_mirror_pairs(e->rules, a ? "model.mirror_y_pairs"
                                                            : "model.mirror_x_pairs",
                                                pairs, S));
        else
            GS_CALL(gs_model_rules_learn_mirror(e->rules, a, S, &exact));
        int moved = 0, lost = 0, present = 0;
        char list[512] = "";
        size_t len = 0;
        for (int l = 0; l < L; l++) {
            if (!gs_model_rules_count(e->rules, l))
                continue;
            present++;
            lost += S[l] < 0;
            if (S[l] > l) {
                moved += 2;
                if (len + 16 < sizeof list)
                    len += (size_t)snprintf(list + len, sizeof list - len, "%s%d<->%d",
                                            len ? " " : "", l, S[l]);
            }
        }
        gs_log(GS_LOG_INFO,
               "mirror %c: label symmetry S %s%s: %d of %d labels change (%s), %d fixed, %d "
               "without an image",
               "xy"[a], pairs[0] ? "from the config" : "learned from the example",
               exact ? "" : " (no exact involution: greedy)", moved, present, len ? list : "none",
               present - moved - lost, lost);
        maps[a] = S;
        e->params.mirror_map[a] = S;
    }
    if (e->mirror_map[0] && e->mirror_map[1]) {
        /* both mirrors: the corner quarter holds Sx(Sy l), which needs Sx Sy = Sy Sx */
        int *Sx = e->mirror_map[0], *Sy = e->mirror_map[1], bad = 0;
        for (int l = 0; l < L; l++)
            if (Sx[l] >= 0 && Sy[l] >= 0 && (Sy[Sx[l]] < 0 || Sx[Sy[l]] < 0 ||
                                              Sx[Sy[l]] != Sy[Sx[l]])) {
                Sx[l] = Sy[l] = -1;
                bad++;
            }
        if (bad)
            gs_log(GS_LOG_WARN, "mirror xy: %d labels whose x and y images do not commute left out",
                   bad);
    }
    size_t dropped = 0;
    GS_CALL(gs_model_rules_symmetrize(e->rules, e->params.mirror, maps, &dropped));
    gs_log(GS_LOG_INFO, "mirror: %zu transition pairs without an allowed mirror image removed",
           dropped);
    return GS_OK;
}

/* model.rotate = 90: R = Sx . Sdiag, both learned like the mirrors; a label
 * whose orbit under R does not close after 4 turns (or meets a label without
 * an image) gets none and leaves the model. */
static gs_err rotation_setup(model_engine *e)
{
    const int L = gs_model_rules_nlabels(e->rules);
    int *Sx = NULL, *Sd = NULL;
    gs_err err = GS_OK;
    GS_CALL(gs_alloc_array((void **)&e->rotate_map, (size_t)L, sizeof(int), "label rotation"));
    GS_TRY(err, gs_alloc_array((void **)&Sx, (size_t)L, sizeof(int), "label symmetry"), done);
    GS_TRY(err, gs_alloc_array((void **)&Sd, (size_t)L, sizeof(int), "label symmetry"), done);
    int ex = 1, ed = 1;
    GS_TRY(err, gs_model_rules_learn_mirror(e->rules, 0, Sx, &ex), done);
    GS_TRY(err, gs_model_rules_learn_mirror(e->rules, 3, Sd, &ed), done);
    if (!ed) { /* not exactly symmetric: the involution keeping most pairs */
        size_t kept = 0, total = 0;
        GS_TRY(err, gs_model_rules_learn_mirror_near(e->rules, &e->example, 3, Sd, &kept, &total),
               done);
        gs_log(GS_LOG_INFO, "rotate 90: no exact diagonal mirror in the example; the nearest keeps "
               "%zu of %zu pairs", kept, total);
    }
    int *R = e->rotate_map;
    for (int l = 0; l < L; l++)
        R[l] = Sd[l] >= 0 ? Sx[Sd[l]] : -1;
    int moved = 0, lost = 0, present = 0, fixed = 0;
    for (int l = 0; l < L; l++) {
        if (!gs_model_rules_count(e->rules, l))
            continue;
        int k = l, n = 0;
        while (n < 4 && k >= 0) {
            k = R[k];
            n++;
        }
        if (k != l) /* no closed orbit within four turns */
            R[l] = -1;
    }
    for (int l = 0; l < L; l++) {
        if (!gs_model_rules_count(e->rules, l))
            continue;
        present++;
        lost += R[l] < 0;
        moved += R[l] >= 0 && R[l] != l;
        fixed += R[l] == l;
    }
    size_t dropped = 0;
    GS_TRY(err, gs_model_rules_rotation(e->rules, R, &dropped), done);
    e->params.rotate_map = R;
    gs_log(GS_LOG_INFO,
           "rotate 90: label rotation R = Sx.Sdiag learned from the example%s: %d of %d labels "
           "turn into another, %d are their own image, %d without an image; %zu transition pairs "
           "without an allowed turned image removed",
           ex && ed ? "" : " (no exact involution: greedy)", moved, present, fixed, lost, dropped);
done:
    gs_free(Sx);
    gs_free(Sd);
    return err;
}

/* model.ground: label sets of the bottom row and of the patterns banned above
 * it (pattern i = label i + 1). */
static gs_err ground_setup(model_engine *e)
{
    const int L = gs_model_rules_nlabels(e->rules), W = (L + 63) / 64;
    GS_CALL(gs_alloc_array((void **)&e->ground, 2 * (size_t)W, 8, "ground patterns"));
    memset(e->ground, 0, 2 * (size_t)W * 8);
    int ng = 0, only = 0;
    for (int i = 0; i < e->pats.npatterns && i + 1 < L; i++) {
        if (!e->pats.bottom[i])
            continue;
        int l = i + 1;
        e->ground[l >> 6] |= (uint64_t)1 << (l & 63);
        ng++;
        if (e->pats.bottom[i] == e->pats.count[i]) {
            e->ground[W + (l >> 6)] |= (uint64_t)1 << (l & 63);
            only++;
        }
    }
    GS_CHECK(ng > 0, GS_ERR_ARG, "model.ground: %s has no pattern on its bottom row",
             e->cfg->sample);
    gs_log(GS_LOG_INFO, "ground: %d patterns of the sample's bottom row for the output's bottom "
           "row, %d of them found only there (banned above)", ng, only);
    e->params.ground = e->ground;
    e->params.ground_only = e->ground + W;
    return GS_OK;
}

/* model.fix_z_faces = auto (from the config and the example alone, so a
 * resumed run decides the same): an example lattice whose bottom layer holds
 * more than one label (a terrain of stone and dirt, a village's grass and
 * roads) gets its z faces synthesized, each limited to the labels of the
 * example's own face layer: fixing the bottom to the start model's one label
 * holds everything built on it to the start column (terrain3: flat, 2 of 4
 * labels; the village: no roads). A top layer of several labels alone (the
 * mountain reaches its example's ceiling) keeps the faces fixed: synthesizing
 * it there raised completeness 0.69 -> 0.93 but lowered the 3x3x3 share
 * 0.49 -> 0.45 and let peaks climb to z = 9 (example 6). */
static gs_err decide_z_faces(model_engine *e)
{
    const model_config *c = e->cfg;
    const gs_model_lattice *ex = &e->example;
    const int fours = ex->frames > 1, exfz = gs_model_frame_nz(ex);
    if (fours)
        e->params.fix_z_faces = 0; /* fixed faces would be the lattice's, not each frame's */
    const int o3 = c->overlap3d > 0; /* (fix_z_faces = true is refused with it) */
    if (strcmp(c->fix_z_faces, "auto") || c->tileset[0] || c->sample[0] ||
        strchr(c->periodic, 'z') || c->size[2] < 3 || exfz < 2)
        return GS_OK;
    const int L = gs_model_rules_nlabels(e->rules);
    const size_t W = ((size_t)L + 63) / 64, layer = (size_t)ex->nx * (size_t)ex->ny;
    GS_CALL(gs_alloc_array((void **)&e->zface, 2 * W, 8, "z face labels"));
    memset(e->zface, 0, 2 * W * 8);
    int distinct[2] = {0, 0};
    for (int f = 0; f < 2; f++)
        for (int t = 0; t < (fours ? ex->frames : 1); t++) {
            /* 4D: the bottom / top layer of every frame */
            const uint16_t *lab = ex->labels + (size_t)(t * exfz + (f ? exfz - 1 : 0)) * layer;
            uint64_t *m = e->zface + (size_t)f * W;
            for (size_t i = 0; i < layer; i++) {
                uint64_t bit = (uint64_t)1 << (lab[i] & 63);
                if (!(m[lab[i] >> 6] & bit))
                    distinct[f]++;
                m[lab[i] >> 6] |= bit;
            }
        }
    if (o3) { /* the top: patterns showing what the example's top layer shows (overlap3d.c) */
        memset(e->zface + W, 0, W * 8);
        distinct[1] = gs_model_patterns3d_top_mask(&e->p3, &e->src, e->zface + W);
    }
    /* 4D frames cannot keep fixed faces (only the lattice's lowest and
     * highest layers would stay): each frame's faces take the example's */
    /* overlap3d: one bottom pattern is a mask all the same (kept faces would
     * be the start column's, which need not be it) */
    if (distinct[0] == 1 && !fours && !o3) {
        gs_free(e->zface);
        e->zface = NULL;
        return GS_OK;
    }
    e->params.fix_z_faces = 0;
    e->params.zface[0] = e->zface;
    e->params.zface[1] = e->zface + W;
    gs_log(GS_LOG_INFO,
           "z faces synthesized (model.fix_z_faces = auto): the example's bottom layer holds %d "
           "labels, its top layer %d; each output face takes only those",
           distinct[0], distinct[1]);
    return GS_OK;
}

/* The start model must already keep to the face labels decide_z_faces allows. */
static gs_err check_z_faces(const model_engine *e)
{
    if (!e->zface)
        return GS_OK;
    const gs_model_lattice *l = &e->lat;
    const size_t W = ((size_t)gs_model_rules_nlabels(e->rules) + 63) / 64;
    const size_t layer = (size_t)l->nx * (size_t)l->ny;
    for (int f = 0; f < 2; f++) {
        const int z = f ? l->nz - 1 : 0;
        const uint64_t *m = e->zface + (size_t)f * W;
        for (size_t i = 0; i < layer; i++) {
            uint16_t a = l->labels[(size_t)z * layer + i];
            GS_CHECK((m[a >> 6] >> (a & 63)) & 1, GS_ERR_ARG,
                     "model.fix_z_faces = auto: the start model's %s layer (z = %d) holds label %u, "
                     "which the example's %s layer lacks; give model.start_column or set "
                     "model.fix_z_faces = true or false",
                     f ? "top" : "bottom", z, a, f ? "top" : "bottom");
        }
    }
    return GS_OK;
}

static gs_err setup(gs_run *run, model_engine *e, int resume)
{
    const model_config *c = e->cfg;
    GS_CALL(engine_params(c, &e->params));
    GS_CALL(load_inputs(run, e));
    const int frames = (int)c->frames, exframes = e->example.frames > 1 ? e->example.frames : 1;
    GS_CHECK(frames > 1 ? exframes > 1 : exframes == 1, GS_ERR_ARG,
             frames > 1 ? "model.frames = %d: the example %s has no frames (a 4D example is a "
                          "Merrell .txt whose extents line reads 'X Y Z T', or an .h5 dataset "
                          "[T, Z, Y, X])"
                        : "model.frames = %d: the example %s has %d frames: set model.frames > 1 "
                          "for a 4D output",
             frames, c->example, exframes);
    if (!e->rules)
        GS_CALL(gs_model_rules_learn(&e->example, &e->rules));
    GS_CALL(decide_z_faces(e));
    int L = gs_model_rules_nlabels(e->rules), present = 0;
    for (int l = 0; l < L; l++)
        present += gs_model_rules_count(e->rules, l) > 0;
    size_t cells = (size_t)c->size[0] * (size_t)c->size[1] * (size_t)c->size[2] * (size_t)frames;
    size_t rcells = 1;
    for (int a = 0; a < 3; a++) {
        int64_t ext = c->size[a];
        int64_t edge = c->region[a] <= 0 || c->region[a] >= ext ? ext : c->region[a];
        rcells *= (size_t)edge;
    }
    size_t W = ((size_t)L + 63) / 64;
    rcells *= (size_t)frames; /* 4D: a region spans every frame */
    double mem = (double)cells * 4 + (double)rcells * (double)(W * 8 + 48 + 2) +
                 8.0 * L * (double)W * 8 + (e->params.ac == GS_MODEL_AC4 ? 16.0 * L * rcells : 0);
    if (c->tileset[0] && e->ts.dim == 3)
        gs_log(GS_LOG_INFO,
               "tile set %s: %d tiles in %d orientations under %d symmetries, %zu allowed pairs, "
               "tiles %dx%dx%d voxels%s%s",
               c->tileset, e->ts.nbase, e->ts.ntiles, e->ts.group, e->ts.npairs, e->ts.vx,
               e->ts.vy, e->ts.vz, e->ts.ground ? ", ground" : "",
               e->ts.border || e->ts.nfixed ? ", border/fixed-tile constraints" : "");
    else if (c->tileset[0])
        gs_log(GS_LOG_INFO, "tile set %s%s%s: %d oriented tiles, %zu allowed pairs, tiles %dx%d px",
               c->tileset, c->subset[0] ? " subset " : "", c->subset, e->ts.ntiles, e->ts.npairs,
               e->ts.tile_w, e->ts.tile_h);
    if (c->sample[0])
        gs_log(GS_LOG_INFO, "sample %s: %d colours, %d patterns of %dx%d (symmetry %lld), %zu allowed pairs",
               c->sample, e->pats.ncolors, e->pats.npatterns, e->pats.n, e->pats.n,
               (long long)c->symmetry, e->pats.npairs);
    const gs_model_lattice *exl = c->overlap3d > 0 ? &e->src : &e->example;
    gs_log(GS_LOG_INFO, "example %s: %dx%dx%d, %d %s present (largest %d)%s", c->example,
           exl->nx, exl->ny, exl->nz, present, c->overlap3d > 0 ? "patterns" : "labels", L - 1,
           e->pal.from_file ? ", palette from the file" : "");
    gs_log(GS_LOG_INFO,
           "output %lldx%lldx%lld (%zu cells), region %lldx%lldx%lld (0 = whole axis), overlap "
           "%lld, passes %lld (max %lld), attempts %lld, backtracks %lld, order %s, weights "
           "%s, %s",
           (long long)c->size[0], (long long)c->size[1], (long long)c->size[2], cells,
           (long long)c->region[0], (long long)c->region[1], (long long)c->region[2],
           (long long)c->overlap, (long long)c->passes, (long long)c->max_passes,
           (long long)c->attempts, (long long)c->backtracks, c->order, c->weights, c->ac);
    gs_log(GS_LOG_INFO, "memory estimate per rank: %.1f MiB (lattice + coverage, solver, rules)",
           mem / 1048576.0);
    GS_CALL(gs_run_check_memory(run, mem, "model.size or model.region"));
    int dims[3] = {(int)c->size[0], (int)c->size[1], (int)c->size[2]};
    for (int a = 0; a < 3; a++) {
        e->full[a] = dims[a];
        if (a < 2 && strchr(c->mirror, "xy"[a])) {
            e->params.mirror[a] = 1;
            e->params.mirror_odd[a] = dims[a] & 1;
            dims[a] = (dims[a] + 1) / 2;
        }
    }
    dims[2] *= frames; /* 4D: the frames stacked along z */
    e->full[2] = dims[2];
    if (!strcmp(c->rotate, "90")) { /* the lower-left quarter */
        dims[0] /= 2;
        dims[1] /= 2;
        GS_CALL(rotation_setup(e));
    }
    if (e->params.mirror[0] || e->params.mirror[1])
        GS_CALL(mirror_setup(e));
    if (c->ground)
        GS_CALL(ground_setup(e));
    if (c->resemblance > 0 && !c->tileset[0] && !c->sample[0]) {
        GS_CALL(gs_model_resem_build(&e->example, (int)c->resemblance, (int)c->resemblance_slack,
                                     c->resemblance_layers, &e->resem));
        gs_model_resem_set_outside(e->resem, !strcmp(c->resemblance_outside, "mismatch") ? 0
                                             : !strcmp(c->resemblance_outside, "half")   ? 1
                                             : !strcmp(c->resemblance_outside, "match")  ? 2
                                                                                         : 3);
        e->params.resem = e->resem;
        gs_log(GS_LOG_INFO, "resemblance: %d distinct %dx%dx%d example neighbourhoods, slack %lld",
               gs_model_resem_patterns(e->resem), 2 * (int)c->resemblance + 1,
               2 * (int)c->resemblance + 1, 2 * (int)c->resemblance + 1,
               (long long)c->resemblance_slack);
    }
    GS_CALL(gs_model_lattice_create(&e->lat, dims[0], dims[1], dims[2]));
    e->lat.frames = frames;
    if (frames > 1)
        gs_log(GS_LOG_INFO, "4D: %d frames of %lldx%lldx%lld from the example's %d frames of "
               "%dx%dx%d (transitions along time learned from consecutive frames)",
               frames, (long long)c->size[0], (long long)c->size[1], (long long)c->size[2],
               exframes, e->example.nx, e->example.ny, gs_model_frame_nz(&e->example));
    if (c->shape[0]) {
        gs_image img = {0};
        float *grey = NULL;
        GS_CALL(gs_image_read(c->shape, &img));
        gs_err err = gs_image_to_gray(&img, &grey);
        int iw = img.width, ih = img.height;
        gs_image_destroy(&img);
        GS_CALL(err);
        err = gs_alloc_array((void **)&e->shape, (size_t)dims[0] * (size_t)dims[1],
                             sizeof *e->shape, "target shape");
        if (err) {
            gs_free(grey);
            return err;
        }
        for (int y = 0; y < dims[1]; y++)
            for (int x = 0; x < dims[0]; x++) {
                int ix = (int)(((int64_t)x * iw) / dims[0]);
                int iy = ih - 1 - (int)(((int64_t)y * ih) / dims[1]);
                e->shape[(size_t)x + (size_t)dims[0] * (size_t)y] = grey[(size_t)iy * iw + ix];
            }
        gs_free(grey);
        e->params.shape = e->shape;
        e->params.shape_weight = c->shape_weight;
        e->params.shape_mh = c->shape_mh;
        e->params.shape_slack = (int)c->shape_slack;
        const int nl = gs_model_rules_nlabels(e->rules);
        GS_CALL(gs_alloc_array((void **)&e->structure, (size_t)nl, 1, "structure labels"));
        GS_CALL(gs_model_structure_labels(&e->example, nl, e->structure, &e->nstructure_labels));
        GS_CHECK(e->nstructure_labels > 0, GS_ERR_ARG,
                 "model.shape: the example %s has no structure label (a label other than "
                 "empty, its top layer's commonest, and ground, the labels below the first "
                 "layer holding empty, stacked on or under another such label)",
                 c->example);
        e->params.structure = e->structure;
        gs_log(GS_LOG_INFO, "shape: %d structure labels of %d (stacked, neither empty nor "
               "ground); choice weight %g, Metropolis b %g", e->nstructure_labels, nl,
               c->shape_weight, c->shape_mh);
    }
    if (c->pins[0] || c->border[0]) {
        GS_CALL(gs_alloc_array((void **)&e->pins, cells, sizeof *e->pins, "pins"));
        for (size_t i = 0; i < cells; i++)
            e->pins[i] = GS_MODEL_FREE;
        int fix = e->params.fix_z_faces && dims[2] >= 3;
        uint16_t border[4096];
        char bwhy[160];
        GS_CHECK(!c->border[0] || (dims[2] <= 4096 &&
                                   parse_column(c->border, border, dims[2], bwhy, sizeof bwhy) ==
                                       dims[2]),
                 GS_ERR_ARG, "model.border: expected %d labels (at most 4096 layers)", dims[2]);
        for (int z = fix; c->border[0] && z < dims[2] - fix; z++)
            for (int y = 0; y < dims[1]; y++)
                for (int x = 0; x < dims[0]; x++)
                    if (x == 0 || y == 0 || x == dims[0] - 1 || y == dims[1] - 1)
                        e->pins[gs_model_lattice_index(&e->lat, x, y, z)] = border[z];
        char why[200];
        GS_CHECK(parse_pins(c->pins, c->size, e->pins, why, sizeof why) >= 0, GS_ERR_ARG,
                 "model.pins: %s", why);
        for (size_t i = 0; i < cells; i++)
            GS_CHECK(e->pins[i] == GS_MODEL_FREE || gs_model_rules_count(e->rules, e->pins[i]) > 0,
                     GS_ERR_ARG, "model.pins/model.border: label %u does not occur in the example %s",
                     e->pins[i], c->example);
        e->params.pins = e->pins;
    }
    if (c->border_tile[0]) {
        char want[80];
        snprintf(want, sizeof want, "%s%s", c->border_tile, strchr(c->border_tile, ' ') ? "" : " 0");
        int l = 0;
        for (int t = 0; t < e->ts.ntiles && !l; t++)
            if (!strcmp(e->ts.names[t], want))
                l = t + 1;
        GS_CHECK(l > 0 && e->ts.dim == 3, GS_ERR_ARG, "model.border_tile = %s: %s", c->border_tile,
                 e->ts.dim != 3 ? "only voxel (3D) tile sets take a border tile"
                                : "no such tile in the tile set");
        e->ts.border = l;
        e->ts.border_sides = 63u;
    }
    if (e->ts.border || e->ts.nfixed || (e->ts.ground && !e->params.fix_z_faces)) {
        if (!e->pins) {
            GS_CALL(gs_alloc_array((void **)&e->pins, cells, sizeof *e->pins, "pins"));
            for (size_t i = 0; i < cells; i++)
                e->pins[i] = GS_MODEL_FREE;
        }
        GS_CALL(gs_model_tileset_pins(&e->ts, c->tileset, dims, e->params.fix_z_faces, e->pins));
        e->params.pins = e->pins;
    }
    GS_CALL(gs_alloc_array((void **)&e->coverage, cells, sizeof *e->coverage, "coverage"));
    memset(e->coverage, 0, cells * sizeof *e->coverage);
    GS_CALL(gs_model_solver_create(e->rules, e->params.ac, &e->solver));
    if (!resume) { /* a resumed run's lattice comes from the checkpoint (model_restore) */
        GS_CALL(build_start(e));
        GS_CALL(check_z_faces(e));
    }
    return GS_OK;
}

/* ---- the run driver's operations (include/geosynth/engine.h) -------------- */

typedef struct model_drive {
    model_engine e;
    model_quality q;
    queue_report_t qr; /* the synthesis report's per-rank times, for the output's metrics */
    int started;       /* the first advance of this process ran */
    double cpu0, t0, base;
} model_drive;

static gs_err model_setup_op(gs_run *run, const void *cfgp, int resume, void **state,
                             gs_json *phase)
{
    model_drive *d = gs_calloc(1, sizeof *d);
    GS_CHECK(d != NULL, GS_ERR_MEM, "model: out of memory for the run state");
    *state = d;
    model_engine *e = &d->e;
    e->cfg = cfgp;
    GS_CALL(setup(run, e, resume));
    gs_json_begin_array(phase, "example");
    gs_json_i64(phase, NULL, e->example.nx);
    gs_json_i64(phase, NULL, e->example.ny);
    gs_json_i64(phase, NULL, e->example.nz);
    gs_json_end_array(phase);
    gs_json_i64(phase, "labels", gs_model_rules_nlabels(e->rules));
    gs_json_begin_array(phase, "output");
    gs_json_i64(phase, NULL, e->lat.nx);
    gs_json_i64(phase, NULL, e->lat.ny);
    gs_json_i64(phase, NULL, e->lat.nz);
    gs_json_end_array(phase);
    return GS_OK;
}

static gs_err model_restore(void *state, gs_run *run)
{
    model_engine *e = &((model_drive *)state)->e;
    GS_CALL(read_checkpoint(run, e));
    gs_log(GS_LOG_INFO, "resumed at pass %d, colour %d after %lld regions", e->pass + 1, e->color,
           (long long)e->units);
    return GS_OK;
}

/* Regions run, including before a resume; the passes needed are not known
 * in advance (each pass has its own progress line). */
static void model_units(const void *state, int64_t *done, int64_t *total)
{
    *done = ((const model_drive *)state)->e.units;
    *total = 0;
}

static gs_err model_advance(void *state, gs_run *run, int *finished)
{
    model_drive *d = state;
    model_engine *e = &d->e;
    if (!d->started) {
        d->started = 1;
        d->cpu0 = gs_cpu_now();
        d->t0 = gs_time_now();
        d->base = e->synth_seconds;
    }
    GS_CALL(advance_window(run, e, finished));
    e->synth_seconds = d->base + (gs_time_now() - d->t0);
    return GS_OK;
}

static gs_err model_save(void *state, gs_run *run)
{
    model_engine *e = &((model_drive *)state)->e;
    GS_CALL(GS_PAR_BCAST_VALUE(run->comm, &e->synth_seconds, 0));
    return write_checkpoint(run, e);
}

static gs_err model_synthesis_report(void *state, gs_run *run, gs_json *j)
{
    model_drive *d = state;
    const model_engine *e = &d->e;
    const double cells = (double)lattice_cells(&e->lat);
    gs_json_i64(j, "passes", e->stats.passes);
    gs_json_u64(j, "regions", e->stats.regions);
    gs_json_u64(j, "accepted", e->stats.accepted);
    gs_json_u64(j, "failed", e->stats.failed);
    gs_json_u64(j, "retries", e->stats.attempts - e->stats.regions);
    gs_json_u64(j, "rejected_attempts", e->stats.attempts - e->stats.accepted);
    gs_json_u64(j, "backtracks", e->stats.backtracks);
    gs_json_u64(j, "min_coverage", e->stats.min_coverage);
    gs_json_f64(j, "cells_per_second", e->synth_seconds > 0 ? cells / e->synth_seconds : 0.0);
    GS_CALL(queue_report(run, e, d->started ? gs_cpu_now() - d->cpu0 : 0, &d->qr, j));
    GS_CHECK(!j->failed, GS_ERR_MEM, "out of memory for the synthesis phase report");
    return GS_OK;
}

/* Collective: the mirrored half or the turned quarter into the full output. */
static gs_err expand_symmetry(model_engine *e)
{
    gs_err err = GS_OK;
    if (e->cfg->overlap3d > 0) {
        /* every rank: the patterns decode to their origin cells; the example's
         * labels come back for the checks, measures and preview */
        e->plat = e->lat;
        memset(&e->lat, 0, sizeof e->lat);
        GS_TRY(err, gs_model_patterns3d_decode(&e->p3, &e->plat, &e->lat), fail);
        gs_model_lattice_destroy(&e->example);
        e->example = e->src;
        memset(&e->src, 0, sizeof e->src);
    }
    if (e->params.mirror[0] || e->params.mirror[1]) {
        /* mirror the synthesized lower half into the full output */
        gs_model_lattice full = {0};
        GS_TRY(err, gs_model_lattice_create(&full, e->full[0], e->full[1], e->full[2]), fail);
        for (int z = 0; z < full.nz; z++)
            for (int y = 0; y < full.ny; y++)
                for (int x = 0; x < full.nx; x++) {
                    int hx = x < e->lat.nx ? x : full.nx - 1 - x;
                    int hy = y < e->lat.ny ? y : full.ny - 1 - y;
                    int l = e->lat.labels[gs_model_lattice_index(&e->lat, hx, hy, z)];
                    /* the mirrored half holds S(l) (Sec. 4.1) */
                    if (hy != y && e->mirror_map[1] && e->mirror_map[1][l] >= 0)
                        l = e->mirror_map[1][l];
                    if (hx != x && e->mirror_map[0] && e->mirror_map[0][l] >= 0)
                        l = e->mirror_map[0][l];
                    full.labels[gs_model_lattice_index(&full, x, y, z)] = (uint16_t)l;
                }
        gs_model_lattice_destroy(&e->lat);
        e->lat = full;
    }
    if (e->rotate_map) {
        /* turn the synthesized quarter three times into the full output:
         * the cell reached from quarter cell q by k turns holds R^k(label) */
        gs_model_lattice full = {0};
        GS_TRY(err, gs_model_lattice_create(&full, e->full[0], e->full[1], e->full[2]), fail);
        const int N = full.nx, h = e->lat.nx;
        for (int z = 0; z < full.nz; z++)
            for (int y = 0; y < full.ny; y++)
                for (int x = 0; x < full.nx; x++) {
                    int px = x, py = y, k = 0;
                    while (px >= h || py >= h) { /* turn back: (x, y) -> (y, N-1-x) */
                        int t = px;
                        px = py;
                        py = N - 1 - t;
                        k++;
                    }
                    int l = e->lat.labels[gs_model_lattice_index(&e->lat, px, py, z)];
                    for (int i = 0; i < k && e->rotate_map[l] >= 0; i++)
                        l = e->rotate_map[l];
                    full.labels[gs_model_lattice_index(&full, x, y, z)] = (uint16_t)l;
                }
        gs_model_lattice_destroy(&e->lat);
        e->lat = full;
    }
fail:
    return err;
}

/* Rank 0: the run's metrics and log lines. */
static void report_metrics(gs_run *run, model_drive *d)
{
    model_engine *e = &d->e;
    model_quality *q = &d->q;
    const double cells = (double)lattice_cells(&e->lat);
    if (run->rank == 0) {
        gs_run_metric_i64(run, "violations", (int64_t)q->violations);
        gs_run_metric_i64(run, "rule_violations", (int64_t)q->rule_violations);
        gs_run_metric_i64(run, "pins_unmet", (int64_t)gs_model_pins_unmet(&e->params, &e->lat));
        gs_run_metric_i64(run, "passes", e->stats.passes);
        gs_run_metric_i64(run, "regions", (int64_t)e->stats.regions);
        gs_run_metric_i64(run, "accepted_regions", (int64_t)e->stats.accepted);
        gs_run_metric_i64(run, "failed_regions", (int64_t)e->stats.failed);
        gs_run_metric_i64(run, "z_faces_fixed", e->params.fix_z_faces && e->lat.nz >= 3);
        if (e->cfg->overlap3d > 0) {
            gs_run_metric_i64(run, "overlap3d_patterns", e->p3.npatterns);
            gs_run_metric_i64(run, "overlap3d_pairs", (int64_t)e->p3.npairs);
        }
        gs_run_metric_i64(run, "retries", (int64_t)(e->stats.attempts - e->stats.regions));
        gs_run_metric_i64(run, "rejected_attempts",
                          (int64_t)(e->stats.attempts - e->stats.accepted));
        gs_run_metric_i64(run, "backtracks", (int64_t)e->stats.backtracks);
        gs_run_metric_i64(run, "min_coverage", (int64_t)e->stats.min_coverage);
        if (e->params.shape) { /* soft constraint: structure inside vs outside the target */
            const int nl = gs_model_rules_nlabels(e->rules);
            double sin = 0, sout = 0, sex = 0;
            gs_model_structure_shares(&e->lat, e->structure, nl, e->shape, &sin, &sout);
            const size_t ne = lattice_cells(&e->example); /* the example's own share */
            for (size_t i = 0; i < ne; i++)
                sex += e->example.labels[i] < nl && e->structure[e->example.labels[i]];
            sex = ne ? sex / (double)ne : 0;
            gs_run_metric_i64(run, "structure_labels", e->nstructure_labels);
            gs_run_metric_f64(run, "structure_share_inside", sin);
            gs_run_metric_f64(run, "structure_share_outside", sout);
            gs_run_metric_f64(run, "structure_share_example", sex);
            gs_run_metric_i64(run, "mh_rejected_regions", (int64_t)e->stats.mh_rejected);
            gs_log(GS_LOG_INFO, "shape: structure share inside the target %.3f, outside %.3f "
                   "(example %.3f); %llu regions not accepted by the Metropolis step", sin, sout,
                   sex, (unsigned long long)e->stats.mh_rejected);
        }
        if (q->has_figures)
            write_figures(run, &q->fig);
        static const char *axis_key[3][3] = {
            {"run_length_x", "run_length_x_example", "run_length_x_ratio"},
            {"run_length_y", "run_length_y_example", "run_length_y_ratio"},
            {"run_length_z", "run_length_z_example", "run_length_z_ratio"}};
        for (int a = 0; a < 3; a++) {
            gs_run_metric_f64(run, axis_key[a][0], q->run_out[a]);
            gs_run_metric_f64(run, axis_key[a][1], q->run_ex[a]);
            gs_run_metric_f64(run, axis_key[a][2],
                              q->run_ex[a] > 0 ? q->run_out[a] / q->run_ex[a] : 0.0);
        }
        gs_run_metric_f64(run, "synthesis_seconds", e->synth_seconds);
        /* this process's share (a resumed run: since the resume) */
        const double *qs = d->qr.sum, *qm = d->qr.max;
        gs_run_metric_f64(run, "region_seconds_total", qs[Q_COMPUTE]);
        gs_run_metric_f64(run, "region_seconds_max_rank", qm[Q_COMPUTE]);
        gs_run_metric_f64(run, "ideal_speedup", qm[Q_COMPUTE] > 0 ? qs[Q_COMPUTE] / qm[Q_COMPUTE] : 0);
        gs_run_metric_f64(run, "queue_wait_seconds_max_rank", qm[Q_WAIT]);
        gs_run_metric_f64(run, "tail_wait_seconds_max_rank", qm[Q_TAIL]);
        gs_run_metric_f64(run, "exchange_seconds_max_rank", qm[Q_EXCHANGE]);
        gs_run_metric_f64(run, "apply_seconds_max_rank", qm[Q_APPLY]);
        gs_run_metric_f64(run, "window_setup_seconds_max_rank", qm[Q_WINDOW_SETUP]);
        gs_run_metric_f64(run, "outside_windows_seconds_max_rank", qm[Q_OUTSIDE]);
        gs_run_metric_i64(run, "duplicate_regions", (int64_t)qs[Q_DUPLICATES]);
        gs_run_metric_f64(run, "synthesis_cpu_seconds_max_rank", qm[Q_CPU]);
        gs_log(GS_LOG_INFO,
               "regions: %.3f s of region runs over %d ranks (%.3f s on the busiest: ideal "
               "speed-up %.2f); per rank at most %.3f s waiting, %.3f s exchanging, %.3f s "
               "applying, %.3f s CPU",
               qs[Q_COMPUTE], run->size, qm[Q_COMPUTE],
               qm[Q_COMPUTE] > 0 ? qs[Q_COMPUTE] / qm[Q_COMPUTE] : 0, qm[Q_WAIT], qm[Q_EXCHANGE],
               qm[Q_APPLY], qm[Q_CPU]);
        gs_run_metric_f64(run, "cells_per_second", e->synth_seconds > 0 ? cells / e->synth_seconds : 0);
        gs_run_metric_f64(run, "region_cells_per_second",
                          e->synth_seconds > 0 ? (double)e->region_cells / e->synth_seconds : 0);
        gs_run_metric_i64(run, "labels_used", q->labels_used);
        gs_run_metric_i64(run, "mesh_quads", (int64_t)q->quads);
        gs_run_metric_i64(run, "mesh_unit_faces", (int64_t)q->unit_faces);
        gs_log(GS_LOG_INFO,
               "%d passes, %llu regions: %llu accepted, %llu failed, %llu retries; "
               "%.0f cells/s",
               e->stats.passes, (unsigned long long)e->stats.regions,
               (unsigned long long)e->stats.accepted, (unsigned long long)e->stats.failed,
               (unsigned long long)(e->stats.attempts - e->stats.regions),
               e->synth_seconds > 0 ? cells / e->synth_seconds : 0.0);
        gs_log(GS_LOG_INFO,
               "adjacency violations (independent checker): %zu; resemblance (non-empty "
               "windows found in the example) 3x3x3 %.3f, 2x2x2 %.3f; run lengths x/y/z %.2f/%.2f/%.2f (example %.2f/%.2f/%.2f)",
               q->violations, q->resemblance3, q->resemblance2, q->run_out[0], q->run_out[1],
               q->run_out[2], q->run_ex[0], q->run_ex[1], q->run_ex[2]);
    }
}

static gs_err model_output_op(void *state, gs_run *run, gs_json *phase, uint64_t *digest)
{
    model_drive *d = state;
    model_engine *e = &d->e;
    model_quality *q = &d->q;
    GS_CALL(expand_symmetry(e));
    int64_t mesh_counts[2] = {0, 0};
    gs_err err = GS_OK;
    if (run->rank == 0)
        err = write_outputs(run, e, q);
    if (err == GS_OK && run->rank == run->size - 1)
        err = write_mesh(run, e, mesh_counts);
    GS_CALL(gs_par_agree(run->comm, err));
    GS_CALL(GS_PAR_BCAST_VALUE(run->comm, &mesh_counts, run->size - 1));
    q->quads = (size_t)mesh_counts[0];
    q->unit_faces = (size_t)mesh_counts[1];
    gs_json_u64(phase, "violations", q->violations);
    gs_json_u64(phase, "quads", q->quads);
    gs_json_u64(phase, "unit_faces", q->unit_faces);
    if (run->rank == 0)
        report_metrics(run, d);
    *digest = gs_model_lattice_digest(&e->lat);
    return GS_OK;
}

static void model_destroy(void *state)
{
    model_drive *d = state;
    if (!d)
        return;
    gs_measure_profile_free(&d->q.fig.profile);
    engine_free(&d->e);
    gs_free(d);
}

static const gs_engine_ops model_ops = {
    .setup = model_setup_op,
    .restore = model_restore,
    .units = model_units,
    .advance = model_advance,
    .save = model_save,
    .synthesis_report = model_synthesis_report,
    .output = model_output_op,
    .destroy = model_destroy,
};

const gs_engine gs_engine_model = {
    "model",
    "model synthesis (Merrell 2007): label lattice from an example lattice",
    &model_table,
    sizeof(model_config),
    offsetof(model_config, run),
    &model_ops,
};
