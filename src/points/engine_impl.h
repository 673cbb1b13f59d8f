/* The points engine's driver (src/points/engine*.c): the configuration, the
 * run state the driver's operations share, the parallel hooks' contexts
 * (distributed search, map, test faults). Private to src/points/engine*.c.
 *
 * The folder: engine.c (the operations table for the run driver, one patch
 * per advance, the finish phase, the synthesis report), engine_config.c
 * (keys, `geosynth points --help`, validation), engine_setup.c (the example
 * read or generated, broadcast, the synthesis created), engine_parallel.c
 * (the distributed search, the map hook, the agreement and the test-only
 * fault injection), engine_state.c (checkpoint write / read),
 * engine_output.c (points.ply, patches.csv, mesh, preview, the measures of
 * the output against the example); the paper's core is synth.c, search.c,
 * warp.c, tps.c, mls.c, seam.c, generate.c, sample.c, pointset.c. */
#ifndef GEOSYNTH_POINTS_ENGINE_IMPL_H
#define GEOSYNTH_POINTS_ENGINE_IMPL_H

#include <stdint.h>
#include <string.h>

#include "geosynth/config.h"
#include "geosynth/json.h"
#include "geosynth/measure.h"
#include "geosynth/pmap.h"
#include "geosynth/points.h"
#include "geosynth/run.h"

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
    double tps_lambda, warp_fade;
    int warp_height_bound;
    char *choices; /* points.choices: a patches.csv, "" = none */
    int blend, ray_blend, blend_resample, blend_keep_outer, blend_fill, blend_implicit,
        drop_strip_specks, strip_resample, warp_select, warp_select_seams, objects;
    /* [output] */
    int write_points;
    char *ply_format;
    int patch_csv;
    int64_t example_seam_shifts;
    int mesh;
    double mesh_voxel;
    int preview;
    double mesh_max_samples;
    gs_run_config run;
} points_config;

static inline int kind_is(const points_config *c, const char *k) { return !strcmp(c->kind, k); }

/* An example the user gives (read by rank 0), not one generated here. */
static inline int kind_is_user(const points_config *c)
{
    return kind_is(c, "ply") || kind_is(c, "mesh");
}

/* The axis normal to a user example's reference plane (input.up). */
static inline int up_axis(const points_config *c) { return c->up[0] - 'x'; }

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
    int *together;         /* set on a failure every rank returns (see points_agree) */
    /* Exchange buffers, sized by the rank count at set-up (points_search_ctx_alloc)
     * so a search allocates nothing before its exchange. */
    int64_t *all;          /* size x REC words */
    gs_points_cands *parts;
    int *counts;           /* counts, then displacements */
} search_ctx;

enum { SEARCH_REC = 2 + 2 * SEARCH_SLOTS }; /* int64 words per rank in the exchange */

/* The map hook over the ranks: gs_pmap (include/geosynth/pmap.h) with the
 * test faults "map-alloc" and "map-fn" and the agreement that remembers a
 * collective failure. */
typedef struct map_state {
    gs_pmap pm;
    fault_inject *fault;
    int *together; /* set on a failure every rank returns (see points_agree) */
} map_state;

/* Whole objects, from the output and the example alone. */
typedef struct objects_stats {
    double height_ks;                /* KS distance of output vs example heights */
    double example_height_ks_halves; /* the example's two halves (x) against each other */
    double height_max, example_height_max;
    uint64_t above_example_max;      /* output points above the example's highest */
    uint32_t fragments, example_fragments;     /* pieces (link 2 spacings), not border-cut */
    uint32_t small_fragments, example_small_fragments; /* of < GS_POINTS_SPECK_POINTS points */
    uint64_t small_fragment_points;
    double density[2], example_density[2]; /* pieces, specks per unit area (minus-sampling) */
    /* Nearest-neighbour spacing (points 2 spacings in from the border): of the
     * strip points [0] and the others [1] (gs_points_synth_in_strip), the
     * example's inside its box; shares closer than half the spacing and
     * farther than the link radius (2 spacings), KS against the example's. */
    uint64_t nn_points[2];
    double nn_close[2], nn_far[2], nn_ks[2], nn_median[2];
    double example_nn_close, example_nn_far, example_nn_median, example_nn_ks_halves;
} objects_stats;

typedef struct run_state {
    gs_points_texture tex;
    gs_points_params params;
    search_ctx sctx;
    gs_points_synth_t synth;
    gs_points out;
    uint32_t *out_patch;          /* out.n entries: each output point's patch id */
    int32_t *out_id;              /* the same as points.ply stores it (-1: none; rank 0) */
    uint64_t tex_digest;
    map_state map; /* the map hook's state */
    fault_inject fault;
    int together;  /* the error being returned is collective (see points_agree) */
    gs_points_seam_stats seam;    /* of the output (rank 0) */
    objects_stats obj;            /* whole objects: heights and fragments (rank 0) */
    gs_points_synth_share share;  /* this rank's bank share and the search/map hooks */
    const points_config *c;
    double dens_out;              /* output points per unit area */
    gs_points_seam_stats seam_ex; /* of the example, lines as far apart (seam_* only) */
    gs_measure_seams pseam;       /* seams from the output's patch ids (rank 0) */
    gs_measure_seams pseam_ex;    /* the same of the example cut into patch-sized cells */
    gs_measure_seams pseam_ex_all; /* the same pooled over shifted cuts (output.example_seam_shifts) */
    uint64_t *choices;            /* points.choices: each patch's source patch (every rank) */
    size_t nchoices;
} run_state;
/* engine_config.c: the points engine's config table. */
extern const gs_cfg_table points_cfg_table;

/* engine_setup.c. Collective: the example (rank 0 reads, or every rank
 * generates), broadcast, its digest, the synthesis (created unless resume). */
gs_err points_phase_setup(gs_run *run, const points_config *c, run_state *rs, int resume,
                          gs_json *phase);
void points_run_state_free(run_state *r);

/* engine_parallel.c: the test-only fault injection. Reads GS_FAIL_RANK /
 * GS_FAIL_POINTS_AT for this rank; fires (once) when armed at site; the
 * error it raises. */
gs_err points_fault_init(fault_inject *f, int rank);
int points_fault_fires(fault_inject *f, int site);
gs_err points_fault_raise(const fault_inject *f, int site, gs_err code);
/* points.choices (engine_setup.c): rank 0 reads the file, every rank gets
 * the list (collective); apply hands it to rs->synth (after create or
 * resume). */
gs_err points_load_choices(gs_run *run, const points_config *c, run_state *rs);
gs_err points_apply_choices(run_state *rs);
/* gs_par_agree that remembers a collective failure in *together (every rank
 * returned it from the same collective: the run may end without MPI_Abort). */
gs_err points_agree(int *together, MPI_Comm comm, gs_err local);
/* The distributed search's exchange buffers (sized by the rank count). */
gs_err points_search_ctx_alloc(search_ctx *c);
void points_search_ctx_free(search_ctx *c);
/* gs_points_search_fn: Psi_k over all ranks (collective, user: search_ctx). */
gs_err points_distributed_search(void *user, const gs_points_synth *s, const float *query,
                                 int mode, double eps, gs_points_cands *out);
/* The map hook over the ranks (gs_pmap with the test faults). */
gs_err points_map_state_init(map_state *m, MPI_Comm comm, fault_inject *fault, int *together);
/* gs_points_map_fn over the ranks (user: map_state). Collective. */
gs_err points_mpi_map(void *user, size_t n, size_t bytes, gs_points_range_fn fn, void *ctx,
                      void *out);
/* gs_points_gen_params.agree over the ranks (user: map_state). */
gs_err points_map_agree(void *user, gs_err local);

/* engine_state.c. Collective: RUN_DIR/checkpoint.h5 with the synthesis
 * state; the state read back (the example's digest must match). */
gs_err points_write_checkpoint(gs_run *run, gs_points_synth_t s, uint64_t tex_digest);
gs_err points_read_checkpoint(gs_run *run, uint64_t tex_digest, gs_points_synth_state *st);

/* engine_output.c. Collective: the output phase (files on rank 0, measures). */
gs_err points_output_op(void *state, gs_run *run, gs_json *phase, uint64_t *digest);

#endif
