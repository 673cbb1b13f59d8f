/* Small file helpers shared by the format readers/writers in src/io/
 * (internal, not part of the public API).
 *
 * Atomic writes: gs_atomic_begin opens "<path>.tmp"; gs_atomic_commit flushes,
 * fsyncs, closes and renames it over path, so readers never see a half-written
 * file and a crash leaves the old file intact; gs_atomic_abort closes and
 * removes the temporary (use it on every error path after begin).
 */
#ifndef GEOSYNTH_IO_FILEIO_H
#define GEOSYNTH_IO_FILEIO_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "geosynth/error.h"

typedef struct gs_atomic_file {
    FILE *f;
    char *tmp_path;   /* gs_malloc'ed "<path>.tmp" */
    const char *path; /* borrowed */
} gs_atomic_file;

gs_err gs_atomic_begin(const char *path, gs_atomic_file *af);
gs_err gs_atomic_commit(gs_atomic_file *af);
void gs_atomic_abort(gs_atomic_file *af);

/* Writes len bytes atomically to path. */
gs_err gs_file_write_all(const char *path, const void *buf, size_t len);

/* Reads a whole file into *buf (gs_free) of *len bytes; refuses files larger
 * than max_len with GS_ERR_FORMAT. what names the kind of file in messages. */
gs_err gs_file_read_all(const char *path, size_t max_len, const char *what, uint8_t **buf,
                        size_t *len);

/* Lower-case extension of path without the dot ("" when none) into ext. */
void gs_path_ext(const char *path, char *ext, size_t ext_len);

#endif
