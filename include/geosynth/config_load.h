/* Collective configuration loading (src/run/config_load.c); the tables and
 * the serial parser are in config.h.
 *
 * Rank 0 reads and validates the file and the overrides and prints every
 * problem to stderr ("error: FILE:LINE: ..."); the status is agreed
 * collectively; then rank 0 broadcasts the resolved text and every other
 * rank parses that text, so all ranks hold the identical struct (paths are
 * already absolute, so the ranks' working directories do not matter).
 */
#ifndef GEOSYNTH_CONFIG_LOAD_H
#define GEOSYNTH_CONFIG_LOAD_H

#include <mpi.h>

#include "geosynth/config.h"

/* Collective on comm: every rank calls it with the same table; path and
 * overrides are read on rank 0 only (other ranks may pass NULL / 0).
 * On success every rank's *out holds the config (free with
 * gs_config_free()) and, when resolved_text is not NULL, *resolved_text the
 * canonical text (gs_malloc'ed, identical bytes on every rank).
 * On failure *out and *resolved_text are unchanged and every rank returns
 * the same code: GS_ERR_ARG ("N problems in FILE", problems already printed
 * by rank 0), GS_ERR_IO (file missing or unreadable), GS_ERR_MPI, or
 * GS_ERR_INTERNAL if a rank could not reproduce rank 0's config from its
 * text. The caller ends with gs_fatal(code, 1). */
gs_err gs_config_load_collective(MPI_Comm comm, const gs_cfg_table *t, const char *path,
                                 const char *const *overrides, size_t noverrides, void *out,
                                 char **resolved_text);

/* The same from config text held by rank 0 (e.g. the resolved config stored
 * in a checkpoint, for `geosynth resume`); origin names it in messages. */
gs_err gs_config_text_collective(MPI_Comm comm, const gs_cfg_table *t, const char *text,
                                 const char *origin, const char *const *overrides,
                                 size_t noverrides, void *out, char **resolved_text);

#endif
