/* The micro engine's driver (src/micro/engine*.c): configuration, the
 * prepared inputs every rank holds, and the per-instance state.
 *
 * Work model. An instance is (mesh, seed): one reconstruction + one
 * displaced mesh. micro.instances = N seeds per mesh, M meshes (micro.mesh,
 * or micro.mesh_list, or one built-in shape): I = M * N instances, instance
 * id i uses mesh i / N and seed index i % N. Every rank prepares every mesh
 * (subdivision and dual graph are pure functions of the file), then the
 * instances run through the rank-0 work queue of gs_regions (one colour,
 * each instance a region) in ROUNDS: a round advances every unfinished
 * instance by micro.steps_per_round reconstruction steps (bins; the last
 * step is the neighbour fill) and shares the resulting gs_micro_state with
 * every rank, so rank 0 can checkpoint between rounds and any rank can take
 * the next slice. The reconstruction resumes bit-exactly from its state, so
 * the result does not depend on the round length, the rank count, or where
 * the run was stopped. Checkpoint units = steps summed over instances.
 * A final pass of the same queue displaces, verifies and writes each
 * instance's outputs (RUN_DIR/instance-XXXX/); the run digest is the digest
 * of the instance digests in instance order.
 *
 * Gallery (micro.explore.enable, engine_explore.c): the paper's
 * parameter-space exploration. Candidate i's parameters come from a Philox
 * stream keyed by (run.seed, i); its config is the run's resolved config
 * with those values (and its own run.seed), and it is produced by exactly
 * the code above, as a one-instance job on MPI_COMM_SELF (micro_setup, one
 * reconstruction slice to the end, the output pass), so `geosynth micro -c
 * candidate-XXX.ini` reproduces its digest. The candidates go over the ranks
 * through the rank-0 work queue of gs_regions, one region per candidate.
 */
#ifndef GEOSYNTH_MICRO_ENGINE_IMPL_H
#define GEOSYNTH_MICRO_ENGINE_IMPL_H

#include <stdint.h>

#include "geosynth/config.h"
#include "geosynth/json.h"
#include "geosynth/micro.h"
#include "geosynth/regions.h"
#include "geosynth/run.h"

/* Random stream domains of the driver (the core uses its own for steps). */
#define MICRO_DOMAIN_SEED 0x6d733031u    /* instance seeds */
#define MICRO_DOMAIN_DIST 0x6d733032u    /* random distributions */
#define MICRO_DOMAIN_VERIFY 0x6d733033u  /* verifier samples */
#define MICRO_DOMAIN_QUEUE 0x6d733034u   /* gs_regions (streams unused) */
#define MICRO_DOMAIN_OUTPUT 0x6d733035u
#define MICRO_DOMAIN_EXPLORE 0x6d733036u  /* gallery candidate parameters */
#define MICRO_DOMAIN_GALLERY 0x6d733037u  /* gs_regions of the gallery (streams unused) */

typedef struct micro_config {
    char *shape;
    char *mesh;
    char *mesh_list;
    double radius;
    gs_cfg_real_list bar_size;
    double scale_units;
    double max_edge;
    char *dist;
    gs_cfg_real_list table_pos, table_neg;
    char *table_csv;
    char *image;
    int64_t image_threshold;
    int image_invert;
    double image_units_per_pixel;
    int64_t max_bins;
    int64_t random_min_bins, random_max_bins;
    double random_min_share, random_max_share;
    int random_per_instance;
    char *pos_direction, *neg_direction;
    double pos_scale, neg_scale;
    char *pos_func, *neg_func;
    int capacity;
    int correct;
    int64_t correct_rounds;
    double correct_target;
    int correct_discs;
    int correct_boolean;
    int64_t max_rejects_per_bin;
    int64_t instances;
    int64_t steps_per_round;
    int64_t verify_samples;
    char *output_format;
    int64_t preview;
    /* [micro.explore]: the gallery (engine_explore.c) */
    int explore;
    int64_t explore_count;
    gs_cfg_real_list explore_scale_units, explore_pos_scale, explore_neg_scale;
    char *explore_pos_func, *explore_neg_func, *explore_pos_direction, *explore_neg_direction;
    int64_t explore_thumbnail;
    gs_run_config run;
} micro_config;

/* engine_config.c: the micro engine's config table. */
extern const gs_cfg_table micro_cfg_table;

/* engine_config.c: choice lists ("a, b c") of '|'-separated names. Parses s
 * into indices of names: returns the count (>= 1), 0 for a list with no
 * word, -1 for an unknown word (copied into bad), -2 for more than
 * MICRO_CHOICES_MAX words. micro_choice_name: the idx-th name. */
#define MICRO_CHOICES_MAX 32
int micro_choice_list(const char *s, const char *names, int idx[MICRO_CHOICES_MAX], char *bad,
                      size_t badlen);
void micro_choice_name(const char *names, int idx, char *out, size_t outlen);

/* One prepared input mesh (identical on every rank). */
typedef struct micro_mesh_in {
    char *source;         /* file path or shape description (gs_malloc'ed) */
    uint32_t ntris_in;    /* before subdivision */
    gs_micro_mesh m;      /* subdivided, with normals */
    gs_micro_dual dual;
    double half_extent;   /* model units */
    double upm;           /* distribution units per model unit */
    gs_micro_subdiv_stats sub;
    double max_edge_units, min_angle_deg;
} micro_mesh_in;

/* Histograms of up to this many bins per region travel in micro_result
 * (summary.json, gallery cards); larger ones are in micro.h5 only. */
#define MICRO_RESULT_BINS 64

/* What the output pass reports per instance (fixed layout: travels as bytes).
 * The realized figures come from src/measure (gs_measure_interface_dist): the
 * regions' true geodesic distance to their interface, histogrammed like the
 * target, never the labels' own values. */
typedef struct micro_result {
    uint64_t digest;
    uint64_t nverts, ntris, nbins;
    uint64_t pairs_checked, violations, unassigned;
    int64_t abs_error_sum, max_bin_error;
    double max_excess, unassigned_share, error_share;
    double seconds;
    double realized_l1;          /* sum |realized - target| / triangles */
    uint64_t realized_beyond;    /* triangles at distance >= K (counted in bin K-1) */
    double realized_pos_share;   /* triangles of the positive region / triangles */
    double recon_realized_l1;    /* the same of the reconstruction, before the correction pass */
    double recon_unassigned_share; /* triangles the reconstruction left to the fill */
    uint64_t correct_rounds, correct_flips;
    double outline_length;       /* the regions' coast in mesh.ply, units (gs_measure_outline) */
    double outline_roughness;    /* coast / coast opened at MICRO_OUTLINE_RHO; NaN: no coast */
    int64_t target[2 * MICRO_RESULT_BINS];   /* signed axis, first 2K used (K <= MICRO_RESULT_BINS) */
    int64_t realized[2 * MICRO_RESULT_BINS];
} micro_result;

/* engine_output.c: the realized contact distribution of a labelling (side of
 * each triangle's label) on mesh mi, into realized[2K] (signed axis) and
 * optionally tri_dist[n] (signed: > 0 in the positive region); returns the
 * L1 / n against the target through *l1. */
gs_err micro_realized(const struct micro_mesh_in *mi, const gs_micro_hist *h, const uint16_t *label,
                      const double *value, int64_t *realized, double *tri_dist, uint64_t *beyond, double *l1);

typedef struct micro_instance {
    int64_t id;
    uint32_t mesh;              /* index into job->meshes */
    uint64_t seed;              /* reconstruction seed */
    gs_micro_dist dist;
    gs_micro_hist hist;
    uint64_t input_digest;      /* mesh + histogram + seed + options */
    gs_micro_state st;          /* st.ntris == 0: not started */
    gs_micro_recon_counters cnt; /* summed over all slices */
    double recon_seconds;
    micro_result res;
} micro_instance;

typedef struct micro_job {
    gs_run *run;
    const micro_config *cfg;
    micro_mesh_in *meshes;
    uint32_t nmeshes;
    micro_instance *inst;
    int64_t ninst;
    gs_micro_recon_opts opts;
    gs_micro_correct_opts copts;  /* micro.correct (cfg->correct: on) */
    gs_micro_displace_params disp;
    uint32_t steps_per_round;    /* 0 = each slice runs to the end */
    int flat_output;             /* outputs straight into the run dir (gallery candidates) */
    int thumbnail;               /* > 0: also thumb.png of this many pixels per side */
} micro_job;

/* engine_setup.c. Collective: reads the inputs on rank 0, broadcasts them,
 * prepares meshes and instances on every rank. */
gs_err micro_setup(micro_job *job);
void micro_job_free(micro_job *job);

/* engine_queue.c. Collective on comm: a gs_regions work queue of items 0 .. n-1
 * (one colour; instances, candidates), and one pass of such a queue. */
gs_err micro_queue_create(MPI_Comm comm, int64_t n, uint64_t seed, uint32_t rng_domain,
                          gs_regions_t *queue);
gs_err micro_queue_pass(MPI_Comm comm, int64_t n, uint64_t seed, uint32_t rng_domain,
                        gs_region_run_fn run, gs_region_apply_fn apply, void *ctx);

/* engine_output.c: the output pass's checks of one instance as members of the
 * open JSON object j (instances.json, gallery/candidates.json). */
void micro_result_json(gs_json *j, const micro_result *r);
/* The target_count / realized_count arrays (signed axis) of r, when r carries
 * them (nbins <= MICRO_RESULT_BINS): the one writer of both for instances.json,
 * the gallery's candidates.json and the run metrics. */
void micro_result_counts_json(gs_json *j, const micro_result *r);

/* The realized L1/n a target must be met within (issue 20's bound). */
#define MICRO_REALIZED_L1_OK 0.05

/* The radius (distribution units) the outline roughness of every instance
 * is measured at: the gallery's smallest disc radius, so coasts of discs
 * the tables ask for are not cut (analysis/micro_outline.py's default). */
#define MICRO_OUTLINE_RHO 1.5

/* A warning naming what (an instance, a candidate) when r's realized contact
 * distribution misses its target by more than MICRO_REALIZED_L1_OK: the coast
 * bins of both sides and the worst bin, so a table no partition gives is not
 * missed silently; corrected = 0 (micro.correct = no) names that cause. */
void micro_result_warn(const micro_result *r, const char *what, int corrected);

/* Outline roughness over several results (instances or gallery candidates):
 * coasts summed, so the run figure is all coasts over all smoothed coasts,
 * and the worst one. */
typedef struct {
    double coast, smoothed, max; /* max NaN until a result with a coast */
} micro_outline_sum;
void micro_outline_init(micro_outline_sum *s);
void micro_outline_add(micro_outline_sum *s, const micro_result *r);
/* Rank 0: the run metrics outline_roughness, _max and outline_rho_units. */
void micro_outline_metrics(gs_run *run, const micro_outline_sum *s);
/* engine_output.c: writes j's text + '\n' to path atomically and frees j. */
gs_err micro_json_write(gs_json *j, const char *path);

/* engine_setup.c: names of the displacement choices. */
#define MICRO_DIRECTIONS "out|in|none"
#define MICRO_FUNCS "linear|sqrt|square|cbrt|step"
int micro_direction_of(const char *s);
gs_micro_func micro_func_of(const char *s);

/* engine_explore.c: the gallery run (from micro_whole in engine.c when micro.explore.enable). */
gs_err micro_explore_run(gs_run *run, const micro_config *cfg);

/* engine_state.c */
static inline int micro_instance_done(const micro_instance *in)
{
    return in->st.ntris && in->st.step >= 2 * in->st.nbins + 1;
}
int64_t micro_units_done(const micro_job *job);
int64_t micro_units_total(const micro_job *job);
/* gs_regions callbacks of one reconstruction round. */
gs_err micro_slice_run(void *ctx, int64_t id, int color, int pass, gs_rng *rng,
                       gs_region_out *out);
gs_err micro_slice_apply(void *ctx, int64_t id, const void *buf, size_t len);
/* Collective: RUN_DIR/checkpoint.h5 with every instance's state. */
gs_err micro_ckpt_write(micro_job *job, int64_t units, int64_t round);
/* Collective: restores every instance's state; *round = rounds done. */
gs_err micro_ckpt_read(micro_job *job, int64_t *round);

/* engine_output.c: gs_regions callbacks of the output pass. */
gs_err micro_output_run(void *ctx, int64_t id, int color, int pass, gs_rng *rng,
                        gs_region_out *out);
gs_err micro_output_apply(void *ctx, int64_t id, const void *buf, size_t len);
/* "instance-0007" */
void micro_instance_dir(int64_t id, char *out, size_t len);

#endif
