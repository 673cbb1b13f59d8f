/* The field engine's driver (src/field/engine*.c): the configuration, the
 * prepared source every rank holds, the distributed matcher's context and the
 * run state the driver's operations share. Private to src/field/engine*.c.
 *
 * The folder: engine.c (the operations table for the run driver, the
 * advance by a colour or a batch of blocks, the synthesis report),
 * engine_config.c (keys, `geosynth field --help`, validation), engine_setup.c
 * (the example built on rank 0 and broadcast, the synthesis created),
 * engine_match.c (the exact best match spread over the ranks, target regions
 * of a colour on the work queue), engine_state.c (checkpoint write / read),
 * engine_output.c (field.h5, meshes, quality measures, pictures); the paper's
 * core is field.c, pyramid.c, tree.c, search.c, synth.c, geometry.c. */
#ifndef GEOSYNTH_FIELD_ENGINE_IMPL_H
#define GEOSYNTH_FIELD_ENGINE_IMPL_H

#include <stdint.h>

#include "geosynth/config.h"
#include "geosynth/field.h"
#include "geosynth/h5.h"
#include "geosynth/json.h"
#include "geosynth/mesh.h"
#include "geosynth/psearch.h"
#include "geosynth/run.h"

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
    int64_t copy_limit_reach;
    int64_t blend;
    int64_t repeat_reach;
    int64_t repeat_span;
    int64_t repeat_pairs;
    double repeat_free;
    int seam_gradient;
    char *height_match;
    int seam_cut;
    int seam_columns;
    int complete_objects;
    char *wrap;
    int keep_volume;
    double object_spacing;
    double object_same;
    int object_continue;
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

typedef struct field_source {
    gs_qfield *q;      /* quantized, cropped source (every rank) */
    gs_field *f;       /* float source, same crop (rank 0) */
    gs_mesh mesh;      /* source triangles in sample units (rank 0, copy mode) */
    int have_mesh;
    char desc[256];
} field_source;

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

/* Seconds of this rank in region colors (gs_regions_stats, summed). */
typedef struct region_times {
    double compute, wait, exchange, apply;
    int64_t regions;
} region_times;

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
/* engine_config.c: the field engine's config table. */
extern const gs_cfg_table field_cfg_table;

/* engine_setup.c. Collective: builds the source (rank 0) and broadcasts it,
 * prepares the synthesis (created, or left to field_restore when resume). */
gs_err field_setup_op(gs_run *run, const void *cfg_, int resume, void **state, gs_json *phase);
void field_source_free(field_source *s);
/* The example is a height-map image (example.kind = file, .png/.jpg). */
int field_is_heightmap_example(const field_config *c);

/* engine_match.c: the synthesis' match hook (gs_field_synth_config.match),
 * collective: the exact best match, spread over the ranks. */
gs_err field_match_block(void *ctx_, gs_field_tree_t tree, gs_field_searcher_t searcher,
                         int iteration, const gs_field_query *q,
                         const gs_field_search_opts *opts, gs_field_match *out);
/* The quality measure's matcher (collective), through field_match_block. */
gs_err field_quality_match(void *ctx_, const gs_field_query *q, gs_field_match *out);
/* Collective: the n regions first .. first + n - 1 of one colour on the
 * gs_regions work queue; adds this rank's seconds to *rt. */
gs_err field_run_color_regions(gs_run *run, gs_field_synth_t synth, int64_t first, int64_t n,
                               region_times *rt);

/* engine_state.c: a z-major 3D array of n (x fastest) into path of h, each
 * rank writing its share of z-slices (collective; checkpoint and field.h5). */
gs_err field_write_slabs(gs_ckpt_t h, gs_run *run, const char *path, const int64_t n[3],
                         gs_h5_type type, const void *data);
/* engine_state.c: blocks synthesized so far (checkpoint units). */
int64_t field_units_done(const gs_field_synth_state *st);
/* Collective: RUN_DIR/checkpoint.h5 with the synthesis state. */
gs_err field_write_checkpoint(gs_run *run, match_ctx *ctx, uint64_t src_digest);
/* Collective: the synthesis restored from RUN_DIR/checkpoint.h5 into *out. */
gs_err field_read_checkpoint(gs_run *run, const gs_qfield *src, const gs_field_synth_config *sc,
                             match_ctx *ctx, uint64_t src_digest, gs_field_synth_t *out);

/* engine_output.c. Collective: the output phase (see engine.c). */
gs_err field_output_op(void *state, gs_run *run, gs_json *phase, uint64_t *digest_out);

#endif
