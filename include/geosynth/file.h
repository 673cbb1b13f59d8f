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
#include <stdio.h>

#include "geosynth/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Streaming atomic writes: gs_atomic_begin opens "PATH.tmp" for writing into
 * af->f; gs_atomic_commit flushes, fsyncs, closes and renames it over PATH
 * (then fsyncs the directory); gs_atomic_abort closes and removes the
 * temporary (call it on every error path after begin). */
typedef struct gs_atomic_file {
    FILE *f;
    char *tmp_path;   /* gs_malloc'ed "<path>.tmp" */
    const char *path; /* borrowed */
} gs_atomic_file;

gs_err gs_atomic_begin(const char *path, gs_atomic_file *af);

/* Opens path for writing as a new file, never through a symlink: whatever
 * is at path (a stale file, a planted symlink) is unlinked first, then
 * created with O_EXCL | O_NOFOLLOW. NULL with errno set on failure. Every
 * output and temporary file goes through it (or gs_fopen_append). */
FILE *gs_fopen_new(const char *path);
/* Opens path for appending (created when missing); refuses a symlink
 * (O_NOFOLLOW: ELOOP). */
FILE *gs_fopen_append(const char *path);
gs_err gs_atomic_commit(gs_atomic_file *af);
void gs_atomic_abort(gs_atomic_file *af);

/* Lower-case extension of path without the dot ("" when none) into ext. */
void gs_path_ext(const char *path, char *ext, size_t ext_len);
/* path with its extension (after the last '.' of the last component, if
 * any) replaced by ext, e.g. "run/mesh.ply" + "glb" -> "run/mesh.glb". */
void gs_path_with_ext(const char *path, const char *ext, char *out, size_t len);

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

/* Normalizes an absolute path in place, lexically: empty and "."
 * components dropped, ".." removes the previous one (never above "/"), no
 * trailing slash; "" or "/.." become "/" (a relative path is read as if it
 * began with "/"). Symlinks are not followed. The buffer needs
 * strlen(path) + 2 bytes. */
void gs_path_normalize(char *path);

/* Absolute, normalized version of path (relative to base_dir if relative
 * and base_dir != NULL, else to the current directory; "${data}/..." is
 * under the data root, geosynth/data.h). gs_malloc'ed. */
gs_err gs_path_absolute(const char *path, const char *base_dir, char **out);

int gs_file_exists(const char *path);
/* Writes s to f with & < > " ' as XML/HTML character references. Other
 * control characters become '_' (XML 1.0 text allows none); with
 * keep_newlines, '\n' and '\t' are written as they are (HTML <pre> text). */
void gs_fput_markup(FILE *f, const char *s, int keep_newlines);

#ifdef __cplusplus
}
#endif

#endif
