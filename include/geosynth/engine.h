/* The engine interface the CLI dispatches to.
 *
 * An engine is a name, a typed config table (which also gives
 * `geosynth ENGINE --help`) and a table of operations that the one run
 * driver (src/run/driver.c, gs_engine_drive) calls. The CLI loads and
 * validates the config on rank 0, broadcasts it, opens the run directory
 * (gs_run) and calls the driver. For `geosynth resume RUN_DIR` the CLI reads
 * the engine name and resolved config from RUN_DIR/checkpoint.h5 (or
 * start.ini) and does the same with resume = 1.
 *
 * The driver owns the run lifecycle: the phases (setup, synthesis, output;
 * each timed, one metrics.jsonl line each), the checkpoint cadence
 * (gs_run_checkpoint_due after every advance: run.checkpoint_every units,
 * run.checkpoint_seconds, USR1/TERM/INT), the stop with exit 9 after a
 * signal's checkpoint, agreement of every rank on the status after every
 * operation (gs_par_agree: an error on any rank is then an error on all,
 * reported once) and summary.json (gs_run_finish with the digest). Engines
 * keep only their algorithms behind these operations.
 */
#ifndef GEOSYNTH_ENGINE_H
#define GEOSYNTH_ENGINE_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/config.h"
#include "geosynth/json.h"
#include "geosynth/run.h"

/* The operations of an engine, in the order the driver calls them. "Collective"
 * means every rank of run->comm calls it with the same arguments; the driver
 * agrees on the returned status after each collective operation, so an engine
 * may fail on one rank only (a local error becomes everyone's, reported once
 * by its rank). An operation that fails on one rank while the others may be
 * waiting inside it (points: a rank failing in the middle of an exchange)
 * sets run->failed_alone before returning: the driver then ends every rank
 * at once (gs_fatal(err, 0): MPI_Abort) instead of waiting for agreement;
 * an error every rank already agreed inside the operation (gs_par_agree,
 * e.g. gs_run_check_memory) still ends the job cleanly, reported once:
 * gs_fatal treats an agreed error as collective. */
typedef struct gs_engine_ops {
    /* Collective, optional. A mode that does not follow the lifecycle below
     * (micro's gallery: many short complete runs and no checkpoint). Sets
     * *handled = 1 when it ran the whole run itself; 0: the driver goes on. */
    gs_err (*whole)(gs_run *run, const void *config, int resume, int *handled);
    /* Collective, phase "setup": reads or generates the inputs (rank 0 reads,
     * then broadcasts) and prepares every rank's state. *state is the
     * engine's own; it is passed to every later operation and freed by
     * destroy() even when setup fails half way. resume: restore() follows
     * (set-up may leave out what the checkpoint replaces, e.g. the start
     * state). phase: an open JSON object for members of the setup line of
     * metrics.jsonl. */
    gs_err (*setup)(gs_run *run, const void *config, int resume, void **state, gs_json *phase);
    /* Collective, phase "setup", resume only: restores the progress from
     * RUN_DIR/checkpoint.h5 (gs_run_checkpoint_open). */
    gs_err (*restore)(void *state, gs_run *run);
    /* Local: work units done so far (including before a resume: what
     * run.checkpoint_every counts) and in all (0: not known in advance, no
     * progress line from the driver); identical on every rank between two
     * collective operations. */
    void (*units)(const void *state, int64_t *done, int64_t *total);
    /* Collective, phase "synthesis": the next batch of work (a round, a
     * colour, a window of regions; it may ask gs_run_units_until_due how far
     * it may go). *finished = 1 (on every rank) when the synthesis is complete,
     * possibly without doing anything. The driver checks the checkpoint
     * cadence after each batch that did not finish. */
    gs_err (*advance)(void *state, gs_run *run, int *finished);
    /* Collective: writes RUN_DIR/checkpoint.h5 (gs_run_checkpoint_begin /
     * commit) with everything restore() needs. */
    gs_err (*save)(void *state, gs_run *run);
    /* Collective, end of phase "synthesis": members of its metrics.jsonl line. */
    gs_err (*synthesis_report)(void *state, gs_run *run, gs_json *phase);
    /* Collective, optional, phase "finish" (between synthesis and output):
     * work on the result that is neither synthesis nor output (points: the
     * relaxation and the trimming). */
    gs_err (*finish)(void *state, gs_run *run, gs_json *phase);
    /* Collective, phase "output": writes the output files (atomically), records
     * them and the quality metrics (gs_run_output, gs_run_metric_*), and
     * returns the digest of the result, identical on every rank. */
    gs_err (*output)(void *state, gs_run *run, gs_json *phase, uint64_t *digest);
    /* Collective (every rank calls it, also after an agreed error or a stop):
     * frees the state (NULL: nothing to free). */
    void (*destroy)(void *state);
} gs_engine_ops;

typedef struct gs_engine {
    const char *name;            /* subcommand, e.g. "field" */
    const char *summary;         /* one line for geosynth --help */
    const gs_cfg_table *config;  /* typed keys of the engine's config struct */
    size_t config_size;          /* sizeof that struct */
    size_t run_offset;           /* offsetof(struct, run): its gs_run_config */
    const gs_engine_ops *ops;    /* its operations, called by gs_engine_drive */
} gs_engine;

/* Collective: the whole run of an engine with ops: setup (+ restore on
 * resume), synthesis in advances with checkpoints when due, output, summary.
 * A stop by signal writes a checkpoint and returns GS_ERR_INTERRUPTED. An
 * error agreed by every rank sets run->failed_together. */
gs_err gs_engine_drive(const gs_engine *e, gs_run *run, void *config, int resume);

/* The registry of the engines built into the program is
 * include/geosynth/engines.h (src/cli: it names every engine). */

#endif
