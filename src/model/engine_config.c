/* model's configuration: the key table (`geosynth model --help`), its
 * validation and the parsers of the keys that hold lists (columns, pins).
 * See engine_impl.h. */
#include <stdio.h>
#include <string.h>

#include "geosynth/log.h"
#include "geosynth/parse.h"
#include "model/engine_impl.h"

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
int model_parse_column(const char *text, uint16_t *out, int cap, char *why, size_t why_len)
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
int model_parse_pins(const char *text, const gs_cfg_int3 size, uint16_t *pins, char *why,
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
        if (model_parse_pins(c->pins, c->size, NULL, why, sizeof why) < 0)
            gs_cfg_report(ctx, "model.pins", "%s", why);
    }
    if (strcmp(c->mirror, "none") && (c->pins[0] || c->border[0] || c->start_block > 0 ||
                                      strcmp(c->periodic, "none") || c->start[0] ||
                                      c->shape[0]))
        gs_cfg_report(ctx, "model.mirror",
                      "= %s cannot be combined with pins, border, start_block, start, periodic "
                      "or shape",
                      c->mirror);
    if (c->region_jitter > 0 && c->overlap != 0)
        gs_cfg_report(ctx, "model.region_jitter", "needs model.overlap = 0 (got %lld)",
                      (long long)c->overlap);
    if (c->region_jitter > 0 && (strchr(c->periodic, 'x') || strchr(c->periodic, 'y')))
        gs_cfg_report(ctx, "model.region_jitter", "not supported with a periodic x or y axis");
    for (int a = 0; a < 2 && c->region_jitter > 0; a++)
        if (c->region[a] > 0 && c->region[a] < c->size[a] &&
            c->region_jitter * 2 >= c->region[a])
            gs_cfg_report(ctx, "model.region_jitter",
                          "must be less than half the region edge %lld along %c",
                          (long long)c->region[a], "xy"[a]);
    for (int a = 0; a < 3; a++) {
        int64_t edge = c->region[a];
        if (edge > 0 && edge < c->size[a] && c->overlap >= edge)
            gs_cfg_report(ctx, "model.overlap",
                          "must be smaller than the region edge %lld along %c (model.region)",
                          (long long)edge, "xyz"[a]);
    }
    if (c->fix_xy_faces && (strchr(c->periodic, 'x') || strchr(c->periodic, 'y') ||
                            c->tileset[0] || c->sample[0]))
        gs_cfg_report(ctx, "model.fix_xy_faces",
                      "needs a lattice example (model.example) and no periodic x or y "
                      "(model.periodic = %s)", c->periodic);
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
    if (c->overlap3d > 0 && !strchr(c->periodic, 'z') && c->size[2] < c->overlap3d + 1)
        gs_cfg_report(ctx, "model.size",
                      "z = %lld: model.overlap3d = %lld needs at least %lld layers (the top "
                      "%lld show the last layer of patterns whole)",
                      (long long)c->size[2], (long long)c->overlap3d, (long long)c->overlap3d + 1,
                      (long long)c->overlap3d - 1);
    if (c->start_block > 0 && (c->start[0] || c->start_column[0]))
        gs_cfg_report(ctx, "model.start_block",
                      "cannot be combined with model.start or model.start_column");
    if (c->start[0] && c->start_column[0])
        gs_cfg_report(ctx, "model.start_column",
                      "cannot be combined with model.start = %s: give one start model", c->start);
    if (c->border[0]) {
        char why[160] = "";
        int n = model_parse_column(c->border, NULL, 0, why, sizeof why);
        if (n < 0)
            gs_cfg_report(ctx, "model.border", "%s", why);
        else if (n != c->size[2])
            gs_cfg_report(ctx, "model.border", "has %d labels: expected one per layer, %lld",
                          n, (long long)c->size[2]);
    }
    if (c->start_column[0]) {
        char why[160] = "";
        int n = model_parse_column(c->start_column, NULL, 0, why, sizeof why);
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
    GS_CFG_KEY_INT(model_config, region_jitter, "model.region_jitter", 0, MODEL_MAX_EXTENT, 0, "0",
                   "with model.overlap = 0: x and y region edges drawn per region around "
                   "the edge (+-J; staggered x cuts, staircase lines between rows of "
                   "regions: no region line crosses the output); 0 = a regular grid"),
    GS_CFG_KEY_INT(model_config, passes, "model.passes", -1, 1000, 0, "-1",
                   "keep sweeping until every cell was in this many accepted regions; -1 = "
                   "auto: two sweeps (model.max_passes 2) when the z faces are synthesized "
                   "(model.fix_z_faces), the second with model.sweep_keep = auto's tests, "
                   "else 1; configs/model/DEFAULTS.md"),
    GS_CFG_KEY_INT(model_config, max_passes, "model.max_passes", 1, 100000, 0, "4",
                   "sweeps at most (stops earlier once model.passes is reached)"),
    GS_CFG_KEY_INT(model_config, open_blocks, "model.open_blocks", 0, MODEL_MAX_EXTENT, 0, "0",
                   "from the second pass on (Merrell's modify in blocks): each region grows "
                   "along x and y over the structures it meets (columns non-empty above the "
                   "example's lowest layer holding an empty cell), up to this many cells per "
                   "axis, and only regions that interact with no region kept before them are "
                   "rebuilt (one colour), each kept only if its label mix per layer is no "
                   "further from the example's than before and found in at most 4 tries; "
                   "0 = off (every region of the pass's plan)"),
    GS_CFG_KEY_STRING(model_config, sweep_keep, "model.sweep_keep", "auto",
                      "from the second pass on: a rebuilt region is kept only if it is no "
                      "further from the example than the content it replaces by every test "
                      "named (comma-separated): mix (its label mix per layer), fill (its share "
                      "of non-empty cells per layer, the height profile), support (its "
                      "non-empty cells without a path to the ground inside the region or to a "
                      "non-empty cell next to it), windows (the share of its non-empty 3x3x3 "
                      "windows found in the example), land (with windows: a rebuild windows "
                      "rejects passes when its share of non-empty cells per layer is closer to "
                      "the example's); a region of such a pass gives up after 4 "
                      "tries, unsplit, and keeps its content; none = every rebuild kept; "
                      "auto = mix,support,windows when the z faces are synthesized (plus land "
                      "when the example's raised land is broad: a terrain's domes), else mix "
                      "with model.open_blocks > 0, else none; configs/model/DEFAULTS.md"),
    GS_CFG_KEY_REAL(model_config, open_blocks_largest, "model.open_blocks_largest", 0, 1000, 0,
                    "0",
                    "with model.open_blocks: a region is also dropped when it meets a "
                    "structure a region kept before it meets; a rebuilt region is kept only "
                    "if the structures it makes or joins (6-connected cells from the "
                    "example's ground layer up, as summary.json structure_max) hold at most "
                    "this many times the example's largest, else it tries again (within "
                    "model.open_blocks_tries); the kept regions run largest first; 0 = off"),
    GS_CFG_KEY_INT(model_config, open_blocks_tries, "model.open_blocks_tries", 1, 100000, 0, "4",
                   "with model.open_blocks: tries of a later sweep's region before it keeps its "
                   "content (a rebuild a keep test rejects counts as one with "
                   "model.open_blocks_largest)"),
    GS_CFG_KEY_INT(model_config, open_blocks_backtracks, "model.open_blocks_backtracks", -1,
                   100000000, 0, "-1",
                   "with model.open_blocks: undo budget per try of a later sweep's region; "
                   "-1 = model.backtracks"),
    GS_CFG_KEY_INT(model_config, attempts, "model.attempts", 1, 100000, 0, "20",
                   "tries per region before it keeps its old (consistent) content"),
    GS_CFG_KEY_INT(model_config, backtracks, "model.backtracks", 0, 100000000, 0, "1000",
                   "undo budget per try on a wipe-out (ac3 only); 0 = none, as in the paper"),
    GS_CFG_KEY_INT(model_config, backjump, "model.backjump", 0, 64, 0, "0",
                   "on a wipe-out undo back to the latest decision within this many cells "
                   "(each axis) of the emptied cell and refute it (ac3 with backtracks); 0 = "
                   "the latest decision (chronological)"),
    GS_CFG_KEY_INT(model_config, rewinds, "model.rewinds", 0, 1000, 0, "0",
                   "when a try's undo budget runs out: undo its latest 30% of decisions and go "
                   "on with a fresh budget, up to this many times, before the try fails (ac3 "
                   "with backtracks); 0 = the try fails"),
    GS_CFG_KEY_ENUM(model_config, order, "model.order",
                    "auto|entropy|scan|random|entropy_log|entropy_layers|entropy_columns", "auto",
                    "cell order: fewest candidates first, the author's scan (z fastest), "
                    "random, fewest candidates by binary order of magnitude with a fresh "
                    "random tie-break (entropy_log: fewer streaks, fewer retries on hard "
                    "examples), fewest candidates with ties to the lowest layer, then to "
                    "the cells nearest the region's decided shell (entropy_layers), or with "
                    "ties to the cells nearest the shell, then to the lowest layer "
                    "(entropy_columns: ring by ring in from the shell, each column from the "
                    "ground up); auto = entropy_columns when the z faces are synthesized "
                    "(model.fix_z_faces), else entropy; configs/model/DEFAULTS.md"),
    GS_CFG_KEY_ENUM(model_config, weights, "model.weights", "uniform|frequency", "uniform",
                    "label choice: uniform (author) or proportional to the example's counts"),
    GS_CFG_KEY_INT(model_config, resemblance, "model.resemblance", 0, 2, 0, "2",
                   "resemblance during synthesis (paper Sec. 3.3): window radius w (1 = 3x3x3, "
                   "2 = 5x5x5 example neighbourhoods matched against the decided cells); 0 = "
                   "off (labels drawn by model.weights)"),
    GS_CFG_KEY_INT(model_config, resemblance_slack, "model.resemblance_slack", 0, 64, 0, "0",
                   "resemblance threshold d0 above the minimum distance (0 = the paper's d0)"),
    GS_CFG_KEY_ENUM(model_config, resemblance_outside, "model.resemblance_outside",
                    "mismatch|half|match|background|wrap|auto", "auto",
                    "resemblance: what a neighbourhood cell past the example's faces scores "
                    "against a decided output cell: a mismatch (before #18 item 2: features near "
                    "the faces, like castle.txt's bushes, never win), half a match, a match "
                    "(the paper's distance over defined cells only: such neighbourhoods then win "
                    "too easily, castle 3x3x3 share 0.26-0.57), or background: a match when the "
                    "output cell holds the commonest label of the example's x/y faces at its "
                    "layer, else a mismatch; wrap: the example taken as a tile, a cell past its "
                    "x/y faces is the example's cell a period on (past its z faces a mismatch); "
                    "auto = half when the z faces are synthesized (model.fix_z_faces), else "
                    "mismatch; configs/model/DEFAULTS.md"),
    GS_CFG_KEY_REAL(model_config, frequency_weight, "model.frequency_weight", -1, 64, 0, "-1",
                    "resemblance: label-frequency soft constraint (paper Sec. 4.2, Eq. 6 "
                    "modified): a drawn neighbourhood weighs ((t*D + 1) / (n + 1))^beta for its "
                    "centre label, D = decided cells of the cell's layer in the region, n = "
                    "those with the label, t = its share of the example's layer at that "
                    "height; beta = this (0 = off); -1 = auto: 2 when the z faces are "
                    "synthesized (model.fix_z_faces), else 0; configs/model/DEFAULTS.md"),
    GS_CFG_KEY_BOOL(model_config, resemblance_layers, "model.resemblance_layers", "true",
                    "resemblance: a cell at height z draws only from the example's "
                    "neighbourhoods at the same height (output and example share the ground)"),
    GS_CFG_KEY_ENUM(model_config, ac, "model.ac", "ac3|ac4", "ac3",
                    "arc consistency algorithm (ac3 bitsets, ac4 support counts)"),
    GS_CFG_KEY_BOOL(model_config, fix_xy_faces, "model.fix_xy_faces", "false",
                    "true: each cell on the output's x = 0, x = max, y = 0, y = max faces takes "
                    "only labels found on the same face of the example (overlap3d: the start "
                    "column, the example's commonest column on its x/y faces, continues past "
                    "the output's sides and face windows must overlap it), so structure the "
                    "example keeps off its sides (a fortress wall ring) cannot run out through "
                    "the output's sides and must close inside; not with periodic x/y, tile sets "
                    "or samples (configs/model/DEFAULTS.md)"),
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
    GS_CFG_KEY_ENUM(model_config, start_column_from, "model.start_column_from",
                    "corner|commonest|faces|auto", "auto",
                    "the inferred start column (no model.start / start_column / start_block / "
                    "ground / overlap3d) prefers the example's corner column (the author's), "
                    "its commonest column, or its commonest column on its x/y faces (faces); "
                    "auto = faces when the z faces are synthesized (model.fix_z_faces), else "
                    "corner; configs/model/DEFAULTS.md"),
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
                   "overlap; the output holds each pattern's origin cell (and, along a "
                   "non-periodic z, the top pattern layer's N - 1 upper slices), so its k^3 "
                   "windows (k <= N) are example windows; z faces take the patterns of the example's "
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
    GS_CFG_KEY_BOOL(model_config, schedule_log, "model.schedule_log", "false",
                    "write schedule.jsonl: per region run, the rank that ran it, its place in that "
                    "rank's order, its CPU seconds and the regions it waited for (the records "
                    "behind the schedule_* metrics; analysis/model_schedule.py recomputes them)"),
    GS_CFG_RUN_KEYS(model_config, run, "model"),
};

const gs_cfg_table model_cfg_table =
    GS_CFG_TABLE("model", model_config, model_keys, model_validate);
