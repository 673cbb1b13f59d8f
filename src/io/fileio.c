/* File helpers for src/io; see fileio.h. */
#include "io/fileio.h"

#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/mem.h"

gs_err gs_atomic_begin(const char *path, gs_atomic_file *af)
{
    GS_CHECK(path && path[0], GS_ERR_ARG, "output path is empty");
    size_t n = strlen(path) + 5;
    char *tmp = gs_malloc(n);
    GS_CHECK(tmp, GS_ERR_MEM, "%s: cannot allocate path", path);
    snprintf(tmp, n, "%s.tmp", path);
    FILE *f = fopen(tmp, "wb");
    if (!f) {
        int e = errno;
        gs_free(tmp);
        GS_RAISE(GS_ERR_IO, "%s: cannot create temporary file %s.tmp: %s", path, path,
                 strerror(e));
    }
    af->f = f;
    af->tmp_path = tmp;
    af->path = path;
    return GS_OK;
}

void gs_atomic_abort(gs_atomic_file *af)
{
    if (af->f)
        fclose(af->f);
    if (af->tmp_path)
        remove(af->tmp_path);
    af->f = NULL;
    GS_FREE(af->tmp_path);
}

gs_err gs_atomic_commit(gs_atomic_file *af)
{
    int bad = ferror(af->f) != 0;
    int e = 0;
    if (!bad && fflush(af->f) != 0) {
        bad = 1;
        e = errno;
    }
    if (!bad && fsync(fileno(af->f)) != 0 && errno != EINVAL) {
        bad = 1;
        e = errno;
    }
    if (fclose(af->f) != 0 && !bad) {
        bad = 1;
        e = errno;
    }
    af->f = NULL;
    if (bad) {
        gs_atomic_abort(af);
        GS_RAISE(GS_ERR_IO, "%s: write failed: %s", af->path, e ? strerror(e) : "stream error");
    }
    if (rename(af->tmp_path, af->path) != 0) {
        e = errno;
        gs_atomic_abort(af);
        GS_RAISE(GS_ERR_IO, "%s: cannot rename temporary file into place: %s", af->path,
                 strerror(e));
    }
    GS_FREE(af->tmp_path);
    return GS_OK;
}

gs_err gs_file_write_all(const char *path, const void *buf, size_t len)
{
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    if (len && fwrite(buf, 1, len, af.f) != len) {
        int e = errno;
        gs_atomic_abort(&af);
        GS_RAISE(GS_ERR_IO, "%s: write of %zu bytes failed: %s", path, len, strerror(e));
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
}

gs_err gs_file_read_all(const char *path, size_t max_len, const char *what, uint8_t **buf,
                        size_t *len)
{
    GS_CHECK(path && path[0], GS_ERR_ARG, "%s path is empty", what);
    FILE *f = fopen(path, "rb");
    GS_CHECK(f, GS_ERR_IO, "%s: cannot open %s file: %s", path, what, strerror(errno));
    gs_err err = GS_OK;
    uint8_t *data = NULL;
    long size = -1;
    if (fseek(f, 0, SEEK_END) == 0)
        size = ftell(f);
    GS_TRY_CHECK(err, size >= 0 && fseek(f, 0, SEEK_SET) == 0, GS_ERR_IO, done,
                 "%s: cannot determine the file size (not a regular file?)", path);
    GS_TRY_CHECK(err, (unsigned long)size <= max_len, GS_ERR_FORMAT, done,
                 "%s: %ld bytes is larger than the %zu bytes accepted for a %s file", path,
                 size, max_len, what);
    data = gs_malloc((size_t)size + 1);
    GS_TRY_CHECK(err, data, GS_ERR_MEM, done, "%s: cannot allocate %ld bytes", path, size);
    GS_TRY_CHECK(err, fread(data, 1, (size_t)size, f) == (size_t)size, GS_ERR_IO, done,
                 "%s: read error", path);
    *buf = data;
    *len = (size_t)size;
    data = NULL;
done:
    gs_free(data);
    fclose(f);
    return err;
}

void gs_path_ext(const char *path, char *ext, size_t ext_len)
{
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    size_t i = 0;
    if (dot && (!slash || dot > slash))
        for (const char *p = dot + 1; *p && i + 1 < ext_len; p++)
            ext[i++] = (char)tolower((unsigned char)*p);
    if (ext_len)
        ext[i] = '\0';
}
