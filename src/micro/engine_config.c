/* micro's configuration: the key table (`geosynth micro --help`), its
 * validation (the gallery's micro.explore.* keys included) and the choice
 * lists those keys hold. Used by the driver (engine.c) and by the gallery
 * (engine_explore.c), which parses each candidate's config with the same
 * table. */
#include <stdio.h>
#include <string.h>

#include "geosynth/config.h"
#include "micro/engine_impl.h"

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
                   "random distribution: smallest depth R of the positive region in bins (units); the "
                   "distribution is measured (paper 5.3) from a Boolean model of discs of radii in "
                   "[R/2, R] on a torus of the surface's area, so both sides describe one partition"),
    GS_CFG_KEY_INT(micro_config, random_max_bins, "micro.random_max_bins", 1, 16384, 0, "8",
                   "random distribution: largest depth R of the positive region in bins (capped so "
                   "that 4 discs fit the positive area)"),
    GS_CFG_KEY_REAL(micro_config, random_min_share, "micro.random_min_share", 0, 1, GS_CFG_OPEN_LO,
                    "0.3", "random distribution: smallest area share of the positive region (the Boolean "
                    "model's coverage; its last disc may pass the drawn share)"),
    GS_CFG_KEY_REAL(micro_config, random_max_share, "micro.random_max_share", 0, 1, GS_CFG_OPEN_LO,
                    "0.7", "random distribution: largest area share of the positive region (< 1)"),
    GS_CFG_KEY_BOOL(micro_config, random_per_instance, "micro.random_per_instance", "no",
                    "draw a new random distribution for every instance (else one for the run)"),
    GS_CFG_KEY_ENUM(micro_config, pos_direction, "micro.pos.direction", MICRO_DIRECTIONS, "out",
                    "positive region: move vertices out, in or not at all"),
    GS_CFG_KEY_REAL(micro_config, pos_scale, "micro.pos.scale", 0, 100, 0, "0.02",
                    "positive region: scale k (offset = k f(|x|) times the half extent)"),
    GS_CFG_KEY_ENUM(micro_config, pos_func, "micro.pos.func", MICRO_FUNCS, "sqrt",
                    "positive region: function f of the distance value"),
    GS_CFG_KEY_ENUM(micro_config, neg_direction, "micro.neg.direction", MICRO_DIRECTIONS, "in",
                    "negative region: move vertices out, in or not at all"),
    GS_CFG_KEY_REAL(micro_config, neg_scale, "micro.neg.scale", 0, 100, 0, "0.02",
                    "negative region: scale k"),
    GS_CFG_KEY_ENUM(micro_config, neg_func, "micro.neg.func", MICRO_FUNCS, "sqrt",
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
    GS_CFG_KEY_BOOL(micro_config, correct_discs, "micro.correct_discs", "no",
                    "correction pass: start from separate discs sized by the positive table's "
                    "second differences (geodesic, farthest-point centres, then moved until the "
                    "round discs alone come closest to both tables) instead of the "
                    "reconstruction's regions (no = the reconstruction's regions)"),
    GS_CFG_KEY_BOOL(micro_config, correct_boolean, "micro.correct_boolean", "no",
                    "with micro.correct_discs: overlapping discs instead, a realization of a "
                    "Boolean model whose intensity and radius (radii in [a, 2a]) are fitted to "
                    "the tables (the random distributions' model), then moved to fit both"),
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
                      "gallery: functions f the positive region draws from (any of " MICRO_FUNCS
                      ", comma-separated; one name: fixed)"),
    GS_CFG_KEY_STRING(micro_config, explore_neg_func, "micro.explore.neg_func",
                      "linear, sqrt, square, cbrt, step",
                      "gallery: functions f the negative region draws from"),
    GS_CFG_KEY_STRING(micro_config, explore_pos_direction, "micro.explore.pos_direction",
                      "out, in", "gallery: directions the positive region draws from (any of "
                      MICRO_DIRECTIONS ", comma-separated; one name: fixed)"),
    GS_CFG_KEY_STRING(micro_config, explore_neg_direction, "micro.explore.neg_direction",
                      "in, out", "gallery: directions the negative region draws from"),
    GS_CFG_KEY_INT(micro_config, explore_thumbnail, "micro.explore.thumbnail", 16, 2048, 0, "256",
                   "gallery: thumbnail edge in pixels (PNG rendered off-screen with OSMesa)"),
    GS_CFG_RUN_KEYS(micro_config, run, "micro"),
};

/* ------------------------------------------------------ choice lists -- */

/* Index of the word w[0..n) among the '|'-separated names, or -1. */
static int choice_index(const char *names, const char *w, size_t n)
{
    int i = 0;
    for (const char *p = names;; i++) {
        const char *e = strchr(p, '|');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == n && strncmp(p, w, n) == 0)
            return i;
        if (!e)
            return -1;
        p = e + 1;
    }
}

void micro_choice_name(const char *names, int idx, char *out, size_t outlen)
{
    const char *p = names;
    for (int i = 0; i < idx && p; i++) {
        p = strchr(p, '|');
        p = p ? p + 1 : NULL;
    }
    const char *e = p ? strchr(p, '|') : NULL;
    size_t len = !p ? 0 : e ? (size_t)(e - p) : strlen(p);
    snprintf(out, outlen, "%.*s", (int)len, p ? p : "");
}

/* Parses "a, b c" into indices of names. Returns the count (>= 1), 0 for a
 * list with no word, -1 for an unknown word (copied into bad), -2 for more
 * than MICRO_CHOICES_MAX words. */
int micro_choice_list(const char *s, const char *names, int idx[MICRO_CHOICES_MAX], char *bad,
                      size_t badlen)
{
    int n = 0;
    for (const char *p = s; *p;) {
        while (*p == ',' || *p == ' ' || *p == '\t')
            p++;
        const char *e = p;
        while (*e && *e != ',' && *e != ' ' && *e != '\t')
            e++;
        if (e == p)
            break;
        int k = choice_index(names, p, (size_t)(e - p));
        if (k < 0) {
            snprintf(bad, badlen, "%.*s", (int)(e - p), p);
            return -1;
        }
        if (n == MICRO_CHOICES_MAX)
            return -2;
        idx[n++] = k;
        p = e;
    }
    return n;
}

/* ------------------------------------------------------- validation -- */

static void check_range(gs_cfg_ctx *ctx, const char *key, const gs_cfg_real_list *r)
{
    if (r->n > 2)
        gs_cfg_report(ctx, key, "expected a range 'lo, hi' or one fixed value, got %lld values",
                      (long long)r->n);
    else if (r->n == 2 && r->v[0] > r->v[1])
        gs_cfg_report(ctx, key, "range 'lo, hi' has lo = %g > hi = %g (write the smaller first)",
                      r->v[0], r->v[1]);
}

static void check_choices(gs_cfg_ctx *ctx, const char *key, const char *s, const char *names)
{
    int idx[MICRO_CHOICES_MAX];
    char bad[64];
    int n = micro_choice_list(s, names, idx, bad, sizeof bad);
    if (n == -1)
        gs_cfg_report(ctx, key, "unknown choice '%s': expected names from %s, separated by commas",
                      bad, names);
    else if (n == -2)
        gs_cfg_report(ctx, key, "more than %d choices", MICRO_CHOICES_MAX);
    else if (n == 0)
        gs_cfg_report(ctx, key, "expected at least one name from %s", names);
}

/* The gallery's keys (micro.explore.*, engine_explore.c). */
static void explore_validate(const micro_config *c, gs_cfg_ctx *ctx)
{
    check_range(ctx, "micro.explore.scale_units", &c->explore_scale_units);
    check_range(ctx, "micro.explore.pos_scale", &c->explore_pos_scale);
    check_range(ctx, "micro.explore.neg_scale", &c->explore_neg_scale);
    check_choices(ctx, "micro.explore.pos_func", c->explore_pos_func, MICRO_FUNCS);
    check_choices(ctx, "micro.explore.neg_func", c->explore_neg_func, MICRO_FUNCS);
    check_choices(ctx, "micro.explore.pos_direction", c->explore_pos_direction, MICRO_DIRECTIONS);
    check_choices(ctx, "micro.explore.neg_direction", c->explore_neg_direction, MICRO_DIRECTIONS);
    if (!c->explore)
        return;
    if (c->mesh_list && c->mesh_list[0])
        gs_cfg_report(ctx, "micro.mesh_list", "a gallery (micro.explore.enable = yes) explores one "
                                              "surface: use micro.mesh or a built-in shape");
    if (c->instances != 1)
        gs_cfg_report(ctx, "micro.instances",
                      "must be 1 with micro.explore.enable = yes (each candidate is one instance; "
                      "the gallery size is micro.explore.count)");
}

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
    explore_validate(c, ctx);
}

const gs_cfg_table micro_cfg_table = GS_CFG_TABLE("micro", micro_config, micro_keys, micro_validate);
