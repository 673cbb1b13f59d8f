/* A run: its directory, phase timings, metrics and final summary.
 *
 * Every engine run (fresh or resumed) opens one gs_run. It owns RUN_DIR and
 * the two machine-readable files analysis and benchmark campaigns read:
 *   RUN_DIR/metrics.jsonl  one JSON object per finished phase (appended)
 *   RUN_DIR/summary.json   written atomically at the end: engine, program
 *                          version, rank count, seed, resolved config,
 *                          per-phase seconds (min/avg/max over ranks), peak
 *                          memory (max over ranks), quality metrics, outputs
 *                          and "digest" (hex of the 64-bit digest of the
 *                          engine's result and every output file, see
 *                          gs_run_outputs_digest).
 * Rank 0 writes the files; phase ends and finish are collective.
 */
#ifndef GEOSYNTH_RUN_H
#define GEOSYNTH_RUN_H

#include <mpi.h>
#include <stdint.h>

#include "geosynth/error.h"
#include "geosynth/h5.h"
#include "geosynth/json.h"

#define GS_RUN_MAX_PHASES 64

/* RUN_DIR/start.ini, written atomically by a fresh gs_run_open: a first line
 * "; geosynth ENGINE", then the resolved config. `geosynth resume RUN_DIR`
 * with no checkpoint (killed before the first one) starts the run again from
 * it, which gives the same output. */
#define GS_RUN_START_FILE "start.ini"

typedef struct gs_run_phase {
    char name[48];
    double start;
    double seconds;   /* this rank */
    double min, avg, max;
    double cpu_start, cpu_seconds; /* this rank's process CPU time (all its threads) */
    double cpu_sum, cpu_max;       /* over ranks */
} gs_run_phase;

typedef struct gs_run {
    MPI_Comm comm;
    int rank, size;
    char *dir;              /* absolute run directory */
    int lock_fd;            /* rank 0: DIR/.lock, flock'ed for the run's life (-1: none) */
    char engine[32];
    char *config_text;      /* resolved config (owned copy) */
    uint64_t seed;
    int resumed;            /* 1 when continuing from a checkpoint */
    double start;
    gs_run_phase phases[GS_RUN_MAX_PHASES];
    int nphases;
    int open_phase;         /* index of the running phase or -1 */
    double ckpt_seconds;    /* run.checkpoint_seconds (0 = off) */
    int64_t ckpt_every;     /* run.checkpoint_every units (0 = off) */
    double ckpt_last_time;  /* when the last checkpoint was written (rank 0's clock) */
    int64_t ckpt_last_units;
    int64_t ckpt_count;     /* checkpoints written by this process */
    gs_json metrics;        /* quality metrics for summary.json (rank 0) */
    struct gs_run_out *outs; /* output files written (rank 0), see gs_run_output */
    int nouts, cap_outs;
    uint64_t expect_digest; /* run.expect_digest, checked by gs_run_finish */
    int have_expect_digest; /* 1 when run.expect_digest was given */
    int failed_together;    /* set by an engine returning an error that every rank returned
                             * from the same collective (gs_par_agree): the CLI then ends
                             * the run collectively (rank 0 reports once), not by MPI_Abort */
    int failed_alone;       /* set by an engine operation returning an error the other ranks may
                             * not have returned (they may wait in a collective): the driver
                             * ends every rank with MPI_Abort (include/geosynth/engine.h) */
} gs_run;

/* Collective. Creates dir (and parents) on rank 0, checks it is writable,
 * agrees the status over comm. On error every rank returns the same code. */
gs_err gs_run_open(gs_run *run, MPI_Comm comm, const char *engine, const char *dir,
                   const char *config_text, uint64_t seed, int resumed);

/* Local: starts timing a phase. Phases may not nest. */
void gs_run_phase_begin(gs_run *run, const char *name);

/* Collective: ends the running phase, reduces its time over ranks and appends
 * a line to metrics.jsonl (rank 0): {"phase","seconds":{min,avg,max},
 * "mem_peak_bytes", plus the members of extra (a JSON object text, or NULL)}. */
gs_err gs_run_phase_end(gs_run *run, const char *extra_json);

/* Rank 0 records quality metrics that go into summary.json ("metrics"). */
void gs_run_metric_f64(gs_run *run, const char *key, double value);
void gs_run_metric_i64(gs_run *run, const char *key, int64_t value);
void gs_run_metric_str(gs_run *run, const char *key, const char *value);
/* Records an output file for summary.json "outputs" (docs/FORMATS.md):
 * kind one word of the vocabulary every engine shares (GS_RUN_OUTPUT_KINDS:
 * the file's format), role what it holds ("field", "contour", "lattice",
 * ...), path relative to the run dir, grid the sample or cell counts
 * {nx, ny, nz} of a grid output (NULL: none). gs_run_finish adds the
 * dimensions it reads from the written file's header: vertices and faces of
 * a mesh, points of a point cloud, width and height of an image. An unknown
 * kind is an internal error reported by gs_run_finish. */
#define GS_RUN_OUTPUT_KINDS "h5 xdmf vdb vox mesh points image preview csv json html text config"
void gs_run_output(gs_run *run, const char *kind, const char *role, const char *path,
                   const int64_t grid[3]);
/* Rank 0: the run digest, which covers every output file a user gets (#25):
 * XXH3 over engine_digest (the engine's digest of its result in memory) and,
 * for each output in the order recorded, its path and the digest of what the
 * file holds: an HDF5 file's contents (gs_h5_content_digest: without the
 * identity group and input paths), a .vdb file's bytes with OpenVDB's random
 * file UUID read as zeros, any other file's bytes. Left out, saying so in
 * summary.json ("digest_excluded"): reports ("json", "html": they hold
 * seconds measured by the run) and configs written for the user to re-run
 * ("config": they hold the run directory's path). Every other output
 * records its own "digest". GS_ERR_IO / GS_ERR_FORMAT naming an output that cannot be read. */
gs_err gs_run_outputs_digest(gs_run *run, uint64_t engine_digest, uint64_t *digest);
/* Rank 0: the "outputs" array of summary.json into j (member key). */
gs_err gs_run_outputs_json(const gs_run *run, gs_json *j, const char *key);
void gs_run_outputs_free(gs_run *run);

/* Path inside the run directory: writes "RUN_DIR/name" into out. */
void gs_run_path(const gs_run *run, const char *name, char *out, size_t out_len);

/* Local: sets the digest gs_run_finish must see (run.expect_digest: "" = no
 * check, else exactly 16 hex digits; anything else is GS_ERR_ARG naming the key). */
gs_err gs_run_expect_digest(gs_run *run, const char *hex);

/* Refuses a run whose engine estimates more memory per rank (bytes) than
 * its node has available for its ranks there (#25 item 4: a target far
 * beyond memory used to start and fail at its first large allocation, or be
 * killed later): GS_ERR_MEM naming the estimate, the ranks on the node, what
 * is available and hint (the keys that size it). Before any large
 * allocation. Collective; a no-op when the memory available is unknown. */
gs_err gs_run_check_memory(gs_run *run, double bytes, const char *hint);

/* Collective: writes summary.json with the digest and prints the RESULTS
 * section on rank 0. With run.expect_digest set, summary.json also records
 * "expect_digest" and "digest_verified"; a different digest is GS_ERR_ARG on
 * every rank (after summary.json is written), a match is logged "(verified)". */
gs_err gs_run_finish(gs_run *run, uint64_t digest);

/* Checkpoint cadence, set by the CLI from run.checkpoint_seconds and
 * run.checkpoint_every. */
void gs_run_set_checkpointing(gs_run *run, double seconds, int64_t every_units);

/* Collective: decides whether to write a checkpoint now, identically on
 * every rank. units_done counts the engine's work units (blocks, regions,
 * bins...) since the start of the run (including before a resume). Due when
 * run.checkpoint_every units passed since the last one, when
 * run.checkpoint_seconds elapsed on rank 0's clock, or when any rank got
 * SIGTERM/SIGINT/SIGUSR1; in that last case *stop is set to 1 and the
 * engine must write the checkpoint and return GS_ERR_INTERRUPTED (exit 9;
 * `geosynth resume RUN_DIR` continues). The test hook GS_STOP_AFTER_UNITS=N
 * in the environment behaves like a signal once units_done >= N (in a fresh
 * run only, so the resumed run can finish). */
int gs_run_checkpoint_due(gs_run *run, int64_t units_done, int *stop);

/* Collective: how many more work units may be done before
 * gs_run_checkpoint_due(run, units, ...) can become due by unit count
 * (run.checkpoint_every) or stop by the GS_STOP_AFTER_UNITS hook: >= 1, or
 * INT64_MAX when neither applies (rank 0 decides; the same on every rank).
 * Engines that run several colours between two checks use it to end at
 * the same boundary a check after every colour would have stopped at;
 * time and signals are still seen only at the next check. */
gs_err gs_run_units_until_due(gs_run *run, int64_t units_done, int64_t *units);

/* Collective: starts RUN_DIR/checkpoint.h5 (written to .tmp, committed with
 * gs_ckpt_commit) with this run's identity (engine, seed, resolved config). */
gs_err gs_run_checkpoint_begin(gs_run *run, gs_ckpt_t *out);

/* Collective: commits the checkpoint and records the time and units. */
gs_err gs_run_checkpoint_commit(gs_run *run, gs_ckpt_t *h, int64_t units_done);

/* Collective: opens RUN_DIR/checkpoint.h5 for reading, checking it belongs
 * to this run's engine. */
gs_err gs_run_checkpoint_open(gs_run *run, gs_ckpt_t *out);

/* Rank 0 of `geosynth resume DIR`, before anything reads DIR/checkpoint.h5:
 * takes DIR's lock (kept for the gs_run_open of DIR) and checks the whole
 * checkpoint (gs_ckpt_verify). A damaged one is renamed checkpoint.h5.damaged
 * and the previous checkpoint (checkpoint.prev.h5, kept by every commit)
 * takes its place, with a warning; with no good one left, GS_ERR_FORMAT
 * naming both problems. */
gs_err gs_run_resume_prepare(const char *dir);

/* Raises GS_ERR_INTERRUPTED with a message telling how to resume. */
gs_err gs_run_interrupted(const gs_run *run);

void gs_run_close(gs_run *run);

#endif
