/* The engine interface the CLI dispatches to.
 *
 * An engine is a name, a typed config table (which also gives
 * `geosynth ENGINE --help`), and one collective entry point. The CLI loads
 * and validates the config on rank 0, broadcasts it, opens the run directory
 * (gs_run) and calls run(). For `geosynth resume RUN_DIR` the CLI reads the
 * engine name and resolved config from RUN_DIR/checkpoint.h5 and calls run()
 * with resume = 1; the engine then restores its state from that checkpoint.
 * The engine writes its outputs into run->dir and ends with gs_run_finish()
 * (which records the output digest).
 */
#ifndef GEOSYNTH_ENGINE_H
#define GEOSYNTH_ENGINE_H

#include <stddef.h>

#include "geosynth/config.h"
#include "geosynth/run.h"

typedef struct gs_engine {
    const char *name;            /* subcommand, e.g. "field" */
    const char *summary;         /* one line for geosynth --help */
    const gs_cfg_table *config;  /* typed keys of the engine's config struct */
    size_t config_size;          /* sizeof that struct */
    size_t run_offset;           /* offsetof(struct, run): its gs_run_config */
    /* Collective on run->comm. config points at the parsed struct. */
    gs_err (*run)(gs_run *run, void *config, int resume);
} gs_engine;

/* The registry of the engines built into the program is
 * include/geosynth/engines.h (src/cli: it names every engine). */

#endif
