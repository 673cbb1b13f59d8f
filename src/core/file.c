/* File helpers; see include/geosynth/file.h. */
#include "geosynth/file.h"
#include "geosynth/killpoint.h"

#include "geosynth/data.h"

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include "geosynth/data.h"
#include "geosynth/mem.h"

static gs_err fsync_dir_of(const char *path)
{
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash == dir)
        slash[1] = '\0';
    else if (slash)
        *slash = '\0';
    else
        snprintf(dir, sizeof dir, ".");
    int fd = open(dir, O_RDONLY | O_DIRECTORY);
    if (fd < 0)
        return GS_OK; /* best effort: some file systems refuse */
    fsync(fd);
    close(fd);
    return GS_OK;
}

gs_err gs_file_commit(const char *tmp, const char *path)
{
    int fd = open(tmp, O_RDONLY);
    GS_CHECK(fd >= 0, GS_ERR_IO, "%s: cannot reopen for fsync: %s", tmp, strerror(errno));
    int rc = fsync(fd);
    int saved = errno;
    close(fd);
    GS_CHECK(rc == 0, GS_ERR_IO, "%s: fsync failed: %s", tmp, strerror(saved));
    gs_kill_point("%s synced, not renamed", gs_kill_base(tmp));
    GS_CHECK(rename(tmp, path) == 0, GS_ERR_IO, "cannot rename %s to %s: %s", tmp, path,
             strerror(errno));
    gs_kill_point("%s renamed", gs_kill_base(path));
    return fsync_dir_of(path);
}

FILE *gs_fopen_new(const char *path)
{
    if (unlink(path) != 0 && errno != ENOENT)
        return NULL;
    int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0)
        return NULL;
    FILE *f = fdopen(fd, "wb");
    if (!f)
        close(fd);
    else
        gs_kill_point("%s created", gs_kill_base(path));
    return f;
}

FILE *gs_fopen_append(const char *path)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_APPEND | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0)
        return NULL;
    FILE *f = fdopen(fd, "ab");
    if (!f)
        close(fd);
    return f;
}

gs_err gs_atomic_begin(const char *path, gs_atomic_file *af)
{
    GS_CHECK(path && path[0], GS_ERR_ARG, "output path is empty");
    size_t n = strlen(path) + 5;
    char *tmp = gs_malloc(n);
    GS_CHECK(tmp, GS_ERR_MEM, "%s: cannot allocate path", path);
    snprintf(tmp, n, "%s.tmp", path);
    FILE *f = gs_fopen_new(tmp);
    if (!f) {
        int e = errno;
        gs_free(tmp);
        GS_RAISE(GS_ERR_IO, "cannot write %s (temporary file %s.tmp): %s", path, path,
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
    if (bad) {
        /* A buffered write failed earlier and its errno is gone: flush what
         * is left to learn why, or ask the file system whether it is full. */
        clearerr(af->f);
        struct statvfs sv;
        if (fflush(af->f) != 0)
            e = errno;
        else if (statvfs(af->tmp_path, &sv) == 0 && sv.f_bavail == 0)
            e = ENOSPC;
    }
    gs_kill_point("%s written, not flushed", gs_kill_base(af->tmp_path));
    if (!bad && fflush(af->f) != 0) {
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
    gs_err err = gs_file_commit(af->tmp_path, af->path);
    if (err) {
        gs_atomic_abort(af);
        return err;
    }
    GS_FREE(af->tmp_path);
    return GS_OK;
}

gs_err gs_file_write_atomic(const char *path, const void *data, size_t len)
{
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    if (len && fwrite(data, 1, len, af.f) != len) {
        int e = errno;
        gs_atomic_abort(&af);
        GS_RAISE(GS_ERR_IO, "%s: write of %zu bytes failed: %s", path, len, strerror(e));
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
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

gs_err gs_file_read_all(const char *path, size_t max_bytes, char **data, size_t *len)
{
    FILE *f = fopen(path, "rb");
    GS_CHECK(f != NULL, GS_ERR_IO, "cannot open %s: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fileno(f), &st) != 0 || S_ISDIR(st.st_mode)) {
        fclose(f);
        GS_RAISE(GS_ERR_IO, "%s: is a directory or cannot be examined", path);
    }
    size_t cap = 4096, n = 0;
    char *buf = gs_malloc(cap);
    if (!buf) {
        fclose(f);
        GS_RAISE(GS_ERR_MEM, "%s: cannot allocate read buffer", path);
    }
    for (;;) {
        if (n + 1 >= cap) {
            if (cap > max_bytes) {
                gs_free(buf);
                fclose(f);
                GS_RAISE(GS_ERR_ARG, "%s: larger than the %zu bytes allowed for this kind of file",
                         path, max_bytes);
            }
            char *nb = gs_realloc(buf, cap * 2);
            if (!nb) {
                gs_free(buf);
                fclose(f);
                GS_RAISE(GS_ERR_MEM, "%s: cannot allocate %zu bytes", path, cap * 2);
            }
            buf = nb;
            cap *= 2;
        }
        size_t got = fread(buf + n, 1, cap - 1 - n, f);
        n += got;
        if (got == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad || n > max_bytes) {
        gs_free(buf);
        GS_RAISE(bad ? GS_ERR_IO : GS_ERR_ARG, "%s: %s", path,
                 bad ? "read error" : "file too large");
    }
    buf[n] = '\0';
    *data = buf;
    if (len)
        *len = n;
    return GS_OK;
}

gs_err gs_mkdir_p(const char *path)
{
    char buf[PATH_MAX];
    GS_CHECK(strlen(path) > 0 && strlen(path) < sizeof buf, GS_ERR_ARG,
             "directory path '%s' is empty or too long", path);
    snprintf(buf, sizeof buf, "%s", path);
    for (char *p = buf + 1; *p; p++) {
        if (*p != '/')
            continue;
        *p = '\0';
        if (mkdir(buf, 0777) != 0 && errno != EEXIST)
            GS_RAISE(GS_ERR_IO, "cannot create directory %s: %s", buf, strerror(errno));
        *p = '/';
    }
    if (mkdir(buf, 0777) != 0 && errno != EEXIST)
        GS_RAISE(GS_ERR_IO, "cannot create directory %s: %s", buf, strerror(errno));
    struct stat st;
    GS_CHECK(stat(buf, &st) == 0 && S_ISDIR(st.st_mode), GS_ERR_IO,
             "%s exists and is not a directory", buf);
    return GS_OK;
}

gs_err gs_dir_check_writable(const char *dir)
{
    char probe[PATH_MAX];
    snprintf(probe, sizeof probe, "%s/.geosynth-write-probe-%ld", dir, (long)getpid());
    FILE *f = fopen(probe, "wb");
    GS_CHECK(f != NULL, GS_ERR_IO, "output directory %s is not writable: %s", dir,
             strerror(errno));
    fclose(f);
    remove(probe);
    return GS_OK;
}

void gs_path_normalize(char *s)
{
    size_t n = strlen(s), o = 0, i = 0;
    if (s[0] != '/') { /* relative: read as rooted, so writing never overtakes reading */
        memmove(s + 1, s, n + 1);
        s[0] = '/';
        n++;
    }
    while (i < n) {
        while (i < n && s[i] == '/')
            i++;
        size_t b = i;
        while (i < n && s[i] != '/')
            i++;
        size_t len = i - b;
        if (len == 0 || (len == 1 && s[b] == '.'))
            continue;
        if (len == 2 && s[b] == '.' && s[b + 1] == '.') {
            while (o > 0 && s[o - 1] != '/')
                o--;
            if (o > 0)
                o--; /* the slash */
            continue;
        }
        s[o++] = '/'; /* o < b: a '/' preceded this component */
        memmove(s + o, s + b, len);
        o += len;
    }
    if (o == 0)
        s[o++] = '/';
    s[o] = '\0';
}

gs_err gs_path_absolute(const char *path, const char *base_dir, char **out)
{
    char joined[PATH_MAX * 2];
    const char *data_rel = gs_data_relative(path);
    if (data_rel) {
        char root[PATH_MAX], why[200];
        GS_CHECK(gs_data_root(root, sizeof root, NULL, why, sizeof why), GS_ERR_IO, "%s: %s",
                 path, why);
        snprintf(joined, sizeof joined, "%s/%s", root, data_rel);
    } else if (path[0] == '/') {
        snprintf(joined, sizeof joined, "%s", path);
    } else {
        char cwd[PATH_MAX];
        const char *base = base_dir;
        if (!base || base[0] != '/') {
            GS_CHECK(getcwd(cwd, sizeof cwd) != NULL, GS_ERR_IO, "cannot get current directory");
            if (base && base[0]) {
                size_t l = strlen(cwd);
                snprintf(cwd + l, sizeof cwd - l, "/%s", base);
            }
            base = cwd;
        }
        snprintf(joined, sizeof joined, "%s/%s", base, path);
    }
    size_t n = strlen(joined);
    char *norm = gs_malloc(n + 2);
    GS_CHECK(norm != NULL, GS_ERR_MEM, "out of memory");
    memcpy(norm, joined, n + 1);
    gs_path_normalize(norm);
    *out = norm;
    return GS_OK;
}

int gs_file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

void gs_fput_markup(FILE *f, const char *s, int keep_newlines)
{
    for (; *s; s++) {
        switch (*s) {
        case '&': fputs("&amp;", f); break;
        case '<': fputs("&lt;", f); break;
        case '>': fputs("&gt;", f); break;
        case '"': fputs("&quot;", f); break;
        case '\'': fputs("&apos;", f); break;
        case '\n':
        case '\t':
            fputc(keep_newlines ? *s : '_', f);
            break;
        default:
            fputc((unsigned char)*s < 0x20 ? '_' : *s, f);
        }
    }
}

void gs_path_with_ext(const char *path, const char *ext, char *out, size_t len)
{
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    size_t stem = dot && (!slash || dot > slash) ? (size_t)(dot - path) : strlen(path);
    snprintf(out, len, "%.*s.%s", (int)stem, path, ext);
}
