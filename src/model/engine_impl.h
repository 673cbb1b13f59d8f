/* The model engine's driver (src/model/engine*.c): the configuration, the
 * engine state every rank holds (inputs, rules, lattice, the sweep's
 * position and statistics) and what the driver's operations share. Private
 * to src/model/engine*.c.
 *
 * The folder: engine.c (the operations table for the run driver, the
 * advance by a window of colours, the synthesis report), engine_config.c
 * (keys, `geosynth model --help`, validation), engine_setup.c (inputs read on
 * rank 0 and broadcast, rules, symmetries, ground, the start model),
 * engine_regions.c (the sweep: plans, regions on the work queue as a dataflow
 * over colours, windows, the per-rank time report), engine_state.c
 * (checkpoint write / read), engine_output.c (lattice files, mesh, pictures,
 * quality measures); the paper's core is synth.c, solver.c, rules.c,
 * lattice.c, symmetry.c, resemble.c, the tile sets and overlap*.c. */
#ifndef GEOSYNTH_MODEL_ENGINE_IMPL_H
#define GEOSYNTH_MODEL_ENGINE_IMPL_H

#include <stdint.h>

#include "geosynth/config.h"
#include "geosynth/h5.h"
#include "geosynth/json.h"
#include "geosynth/model.h"
#include "geosynth/model_io.h"
#include "geosynth/model_tiles.h"
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
    int fix_xy_faces;
    int preview;
    int64_t preview_size;
    int schedule_log;
    char *format;
    char *dataset;
    gs_cfg_int3 size;
    gs_cfg_int3 region;
    int64_t overlap;
    int64_t region_jitter;
    int64_t passes;
    int64_t max_passes;
    int64_t open_blocks;
    char *sweep_keep;
    double open_blocks_largest;
    int64_t open_blocks_backtracks;
    int64_t open_blocks_tries;
    int64_t attempts;
    int64_t backtracks;
    int64_t backjump;
    int64_t rewinds;
    char *order;
    char *weights;
    int64_t resemblance;
    int64_t resemblance_slack;
    double frequency_weight;
    int resemblance_layers;
    char *ac;
    char *fix_z_faces;
    char *start;
    char *start_column;
    char *start_column_from;
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

/* A region's record, then its labels. rank, seq and cpu_s are
 * bookkeeping for the schedule figures (model_sched): who ran it, as its
 * how-manyth region of the window, and the process CPU seconds of the run;
 * they never reach the lattice, so a region run twice (two ranks claimed it
 * at once) may differ there and the first record kept is used. */
typedef struct region_hdr {
    int32_t ok, attempts;
    uint64_t choices, backtracks;
    int32_t rank, seq;
    double cpu_s;
} region_hdr;

/* Load-independent figures of the sweep's schedule (engine_sched.c), summed
 * over windows (a window ends with every rank done): every figure divides
 * the regions' CPU seconds by a makespan in the same CPU seconds, so a
 * shared machine's waits for a core do not move it. */
typedef struct model_sched {
    double cpu;      /* the regions' CPU seconds (records kept on this rank) */
    double crit;     /* longest chain of dependent regions (conflicts) */
    double bound2;   /* max(crit, cpu / 2): no 2-rank schedule is shorter */
    double policy2;  /* the dataflow's pick rule simulated on 2 ranks */
    double replay;   /* this run's assignment and order, each rank on a core of its own */
    uint64_t windows;
} model_sched;

typedef struct model_engine {
    const model_config *cfg;
    gs_model_params params;
    uint16_t *pins;          /* hard constraints (NULL = none), lattice cells */
    float *shape;            /* soft target shape (NULL = none), lat nx*ny */
    uint8_t *structure;      /* model.shape: [nlabels] structure labels of the example */
    int keep_tests;          /* model.sweep_keep: KEEP_* bits (engine_regions.c) */
    uint64_t *keep_keys;     /* windows test: the example's non-empty 3x3x3 window keys,
                                sorted (nkeep_keys), made with the first later pass's plan */
    size_t nkeep_keys;
    int keep_w[3];
    uint8_t *repair_empty;   /* default mode (no overlap3d), example without floating
                                structure: [nlabels] 1 = empty (label 0); the repair after the
                                passes resynthesizes floating pieces (engine_regions.c) */
    int nstructure_labels;
    int full[3];             /* output extents (mirror: lat holds the lower half) */
    int *mirror_map[2];      /* label symmetry S of the x and y mirrors (NULL = none) */
    int *rotate_map;         /* model.rotate: R, the label turned by 90 degrees (NULL = none) */
    uint64_t *ground;        /* model.ground: [2][W] ground labels, labels only there */
    int outside;             /* model.resemblance_outside as decided (auto resolved): 0 mismatch,
                                1 half, 2 match, 3 background */
    double freq_beta;        /* model.frequency_weight as decided (auto resolved) */
    int start_commonest;     /* model.start_column_from as decided (auto resolved) */
    uint64_t *zface;         /* model.fix_z_faces = auto, synthesized: [2][W] the labels of
                                the example's bottom and top layers */
    uint64_t *xyface;        /* model.fix_xy_faces: [4][W] the labels on the example's
                                x = 0, x = nx-1, y = 0, y = ny-1 faces (not overlap3d) */
    uint16_t *outside_col;   /* model.fix_xy_faces with overlap3d: [lat nz] the start
                                column, taken to lie past the output's x/y faces */
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
    uint64_t open_largest; /* model.open_blocks_largest: most cells a structure a rebuilt
                              region makes or joins may hold (0 = no limit) */
    int open_ground;       /* model.open_blocks: the example's ground layer */
    int32_t *open_owner;   /* model.open_blocks_largest: per column, the region of the pass
                              that meets its structure (-1 none) */
    uint8_t *open_seen;    /* open_block_too_large's flood: lattice cells, all 0 between calls */
    int32_t *open_queue;   /* its cells reached (lattice cells); both made on first use */
    size_t buf_cells;
    gs_model_region *plan; /* regions of the current pass, index = id */
    size_t nplan;
    int ncolors;
    int32_t *region_status;   /* pass in progress: -1 not run, 0 failed, 1 accepted,
                                 2 kept as it was (rejected: Metropolis or a keep test) */
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
    int rank;               /* this process's rank (region records say who ran them) */
    int32_t window_seq;     /* regions this rank ran in the window in progress */
    region_hdr *rec;        /* [nplan] the pass in progress: each region's record here */
    model_sched sched;
    uint64_t windows_run;   /* windows run by this process (schedule.jsonl numbers them) */
    uint64_t example_digest;
} model_engine;

static inline size_t lattice_cells(const gs_model_lattice *l)
{
    return (size_t)l->nx * (size_t)l->ny * (size_t)l->nz;
}

/* Where each rank's synthesis time went (this process: a resumed run
 * counts since the resume), gathered on rank 0. */
enum {
    Q_REGIONS, Q_COMPUTE, Q_WAIT, Q_TAIL, Q_EXCHANGE, Q_APPLY, Q_FLOW, Q_WINDOW_SETUP, Q_OUTSIDE,
    Q_CPU, Q_DUPLICATES, Q_N
};

typedef struct queue_report_t {
    double sum[Q_N], max[Q_N]; /* over the ranks (rank 0) */
} queue_report_t;

typedef struct model_quality {
    size_t violations, rule_violations;
    double resemblance3, resemblance2;
    double run_out[3], run_ex[3];
    size_t quads, unit_faces;
    int labels_used, vox_renumbered;
    int has_figures;              /* an example lattice to compare with */
    gs_model_quality_figures fig; /* owned profile: gs_measure_profile_free */
} model_quality;

typedef struct model_drive {
    model_engine e;
    model_quality q;
    queue_report_t qr; /* the synthesis report's per-rank times, for the output's metrics */
    int started;       /* the first advance of this process ran */
    double cpu0, t0, base;
} model_drive;
/* engine_config.c: the model engine's config table. */
extern const gs_cfg_table model_cfg_table;
/* Parses "a, b c" into up to cap labels; returns the count or -1 with why. */
int model_parse_column(const char *text, uint16_t *out, int cap, char *why, size_t why_len);
/* Parses "x,y,z=label; ..." (spaces allowed) into pins (when not NULL).
 * Returns the count or -1 with why. */
int model_parse_pins(const char *text, const gs_cfg_int3 size, uint16_t *pins, char *why,
                     size_t why_len);

/* engine_setup.c. Collective: inputs, rules, symmetries, the start model
 * (a resumed run's lattice comes from model_read_checkpoint). */
gs_err model_setup(gs_run *run, model_engine *e, int resume);
void model_engine_free(model_engine *e);

/* engine_regions.c: the regions of pass e->pass (plan, status, attempts). */
gs_err model_make_plan(model_engine *e);
/* model.sweep_keep: "none" or a comma-separated list of mix, fill, support,
 * windows -> KEEP_* bits (open_blocks: mix at least) */
#define KEEP_AUTO_NAMES "mix,support,windows" /* model.sweep_keep = auto, synthesized z faces */
/* KEEP_OPEN: model.open_blocks' later sweeps (rebuilds optional, whatever the tests) */
/* KEEP_LAND: a rebuild the windows test rejects is kept when it brings the box's
 * non-empty share per layer (fill) closer to the example's */
enum { KEEP_MIX = 1, KEEP_FILL = 2, KEEP_SUPPORT = 4, KEEP_WINDOWS = 8, KEEP_OPEN = 16, KEEP_LAND = 32 };
/* model.sweep_keep = auto adds land when the example's raised land is at least
 * this broad (gs_measure_land_interior: its round hills and domes) */
#define KEEP_LAND_INTERIOR 0.5
gs_err model_parse_sweep_keep(const char *s, int open_blocks, int *tests);
/* Collective: the next batch of the synthesis (a new pass's plan, then one
 * window of colours); *finished once the passes are done. */
gs_err model_advance_window(gs_run *run, model_engine *e, int *finished);
/* engine_sched.c: adds the schedule figures of the window of regions
 * plan[first, first + n) (conflict CSR off / ids as gs_model_plan_conflicts
 * gives them, ids = plan ids) from their records e->rec. Local, the same
 * on every rank up to which duplicate record was kept. */
void model_sched_window(model_engine *e, size_t first, size_t n, const int64_t *off,
                        const int64_t *ids);
/* model.schedule_log, rank 0: appends the window's records to
 * RUN_DIR/schedule.jsonl, one JSON object per region (window = the count of
 * windows this process ran before; the first one starts the file). */
gs_err model_sched_log(gs_run *run, const model_engine *e, uint64_t window, size_t first,
                       size_t n, const int64_t *off, const int64_t *ids);

/* Collective: each rank's synthesis times gathered on rank 0, into q and the
 * open object j ("per_rank"). */
gs_err model_queue_report(gs_run *run, const model_engine *e, double cpu, queue_report_t *q,
                          gs_json *j);

/* engine_state.c: the HDF5 shape of a lattice (z, y, x; 4D: t first). */
gs_h5_shape model_lattice_shape(const gs_model_lattice *l);
/* Collective: RUN_DIR/checkpoint.h5 with the sweep's state; read back. */
gs_err model_write_checkpoint(gs_run *run, model_engine *e);
gs_err model_read_checkpoint(gs_run *run, model_engine *e);

/* engine_output.c. Collective: the output phase (files, checks, metrics). */
gs_err model_output_op(void *state, gs_run *run, gs_json *phase, uint64_t *digest);

#endif
