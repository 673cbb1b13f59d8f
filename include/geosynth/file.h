/* File helpers shared by every writer and reader.
 *
 * gs_file_write_atomic: writes PATH.tmp, fsyncs it, renames it over PATH and
 * fsyncs the directory, so PATH is either the old or the new content after a
 * crash at any moment. Every output geosynth writes goes through it (or the
 * same protocol in the HDF5 layer).
 */
#ifndef GEOSYNTH_FILE_H
#define GEOSYNTH_FILE_H

#include <stddef.h>

#include "geosynth/error.h"

gs_err gs_file_write_atomic(const char *path, const void *data, size_t len);

/* Renames tmp over path after fsyncing tmp, then fsyncs path's directory. */
gs_err gs_file_commit(const char *tmp, const char *path);

/* Reads a whole file (at most max_bytes; larger files are an error naming
 * the size). *data is gs_malloc'ed and NUL-terminated; caller frees with
 * gs_free. On error outputs are unchanged. */
gs_err gs_file_read_all(const char *path, size_t max_bytes, char **data, size_t *len);

/* Creates a directory and its parents (like mkdir -p). */
gs_err gs_mkdir_p(const char *path);

/* Checks that files can be created in dir (creates and removes a probe). */
gs_err gs_dir_check_writable(const char *dir);

/* Absolute, normalized version of path (relative to base_dir if relative
 * and base_dir != NULL, else to the current directory). gs_malloc'ed. */
gs_err gs_path_absolute(const char *path, const char *base_dir, char **out);

int gs_file_exists(const char *path);

#endif
