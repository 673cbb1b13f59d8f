/* Checkpoint files: atomic create/commit, validated open, peek, identity.
 * See include/geosynth/h5.h. */
#include "io/h5_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "geosynth/digest.h"
#include "geosynth/killpoint.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/version.h"

static int is_parallel(const struct gs_ckpt *h) { return h->comm != MPI_COMM_NULL; }

/* Turns a local status into one every rank of a parallel handle shares. */
static gs_err agree(const struct gs_ckpt *h, gs_err local)
{
    if (!is_parallel(h))
        return local;
    return gs_par_agree(h->comm, local);
}

static char *dup_str(const char *s)
{
    size_t n = strlen(s);
    char *d = gs_malloc(n + 1);
    if (d)
        memcpy(d, s, n + 1);
    return d;
}

static void free_handle(struct gs_ckpt *h)
{
    if (!h)
        return;
    if (h->reserve_fd >= 0)
        close(h->reserve_fd);
    gs_free(h->path);
    gs_free(h->tmp_path);
    gs_free(h->prev_path);
    gs_free(h->program_version);
    gs_free(h->config);
    gs_free(h);
}

static gs_err new_handle(MPI_Comm comm, const char *path, struct gs_ckpt **out)
{
    struct gs_ckpt *h = gs_calloc(1, sizeof *h);
    GS_CHECK(h, GS_ERR_MEM, "%s: out of memory for the file handle", path);
    h->file = -1;
    h->reserve_fd = -1;
    h->comm = comm;
    h->rank = 0;
    h->size = 1;
    if (comm != MPI_COMM_NULL) {
        if (gs_par_comm_rank(comm, &h->rank, &h->size) != GS_OK) {
            gs_free(h);
            GS_RAISE(GS_ERR_MPI, "%s: invalid communicator", path);
        }
    }
    h->path = dup_str(path);
    if (!h->path) {
        gs_free(h);
        GS_RAISE(GS_ERR_MEM, "%s: out of memory", path);
    }
    *out = h;
    return GS_OK;
}

static gs_err check_engine_name(const char *engine, const char *path)
{
    GS_CHECK(engine != NULL, GS_ERR_ARG, "%s: no engine name given", path);
    size_t n = strlen(engine);
    GS_CHECK(n >= 1 && n < GS_H5_ENGINE_MAX, GS_ERR_ARG,
             "%s: engine name '%s' must have 1 to %d characters", path, engine,
             GS_H5_ENGINE_MAX - 1);
    for (size_t i = 0; i < n; i++) {
        char c = engine[i];
        GS_CHECK((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_', GS_ERR_ARG,
                 "%s: engine name '%s' may contain only a-z, 0-9 and '_'", path, engine);
    }
    return GS_OK;
}

/* ---- writing -------------------------------------------------------------- */

/* Rank 0: removes a stale .tmp and proves the directory is writable, so the
 * error names the system's reason instead of HDF5's. */
static gs_err prepare_tmp(const char *tmp)
{
    if (unlink(tmp) != 0 && errno != ENOENT)
        GS_RAISE(GS_ERR_IO, "%s: cannot remove the stale temporary file: %s", tmp,
                 strerror(errno));
    int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW, 0644); /* no planted symlink */
    GS_CHECK(fd >= 0, GS_ERR_IO, "%s: cannot create: %s", tmp, strerror(errno));
    close(fd);
    return GS_OK;
}

static gs_err write_config(struct gs_ckpt *h, hid_t group)
{
    gs_err err = GS_OK;
    size_t len = strlen(h->config);
    hid_t type = H5Tcopy(H5T_C_S1);
    hid_t space = H5Screate(H5S_SCALAR);
    hid_t dset = -1, dxpl = H5Pcreate(H5P_DATASET_XFER);
    char d[256];
    GS_TRY_CHECK(err, type >= 0 && space >= 0 && dxpl >= 0, GS_ERR_LIB, done,
                 "%s: HDF5 type/space creation failed", h->tmp_path);
    H5Tset_size(type, len ? len : 1);
    H5Tset_strpad(type, H5T_STR_NULLPAD);
    dset = H5Dcreate2(group, "config", type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (dset < 0) {
        gs_h5_detail(d, sizeof d);
        GS_TRY_CHECK(err, 0, GS_ERR_IO, done, "%s: cannot create /geosynth/config (HDF5: %s)",
                     h->tmp_path, d);
    }
    if (is_parallel(h)) {
        H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE);
        if (h->rank != 0) /* rank 0 writes; the others take part in the collective */
            H5Sselect_none(space);
    }
    if (H5Dwrite(dset, type, space, space, dxpl, len ? h->config : "") < 0) {
        gs_h5_detail(d, sizeof d);
        GS_TRY_CHECK(err, 0, GS_ERR_IO, done, "%s: cannot write /geosynth/config (HDF5: %s)",
                     h->tmp_path, d);
    }
done:
    if (dset >= 0)
        H5Dclose(dset);
    if (dxpl >= 0)
        H5Pclose(dxpl);
    if (space >= 0)
        H5Sclose(space);
    if (type >= 0)
        H5Tclose(type);
    return err;
}

static gs_err write_identity(struct gs_ckpt *h)
{
    gs_err err = GS_OK;
    char d[256];
    int32_t fv = GS_FORMAT_VERSION;
    hid_t g = H5Gcreate2(h->file, "/geosynth", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (g < 0) {
        gs_h5_detail(d, sizeof d);
        GS_RAISE(GS_ERR_IO, "%s: cannot create /geosynth (HDF5: %s)", h->tmp_path, d);
    }
    GS_TRY(err, gs_h5_write_str_attr(g, "magic", "geosynth", h->tmp_path), done);
    GS_TRY(err, gs_h5_write_attr_raw(g, "format_version", H5T_STD_I32LE, H5T_NATIVE_INT32, &fv,
                                     h->tmp_path), done);
    GS_TRY(err, gs_h5_write_str_attr(g, "engine", h->engine, h->tmp_path), done);
    GS_TRY(err, gs_h5_write_str_attr(g, "program_version", h->program_version, h->tmp_path),
           done);
    GS_TRY(err, gs_h5_write_attr_raw(g, "seed", H5T_STD_U64LE, H5T_NATIVE_UINT64, &h->seed,
                                     h->tmp_path), done);
    GS_TRY(err, gs_h5_write_str_attr(g, "created", h->created, h->tmp_path), done);
    GS_TRY(err, write_config(h, g), done);
    /* The config is a scalar (unchunked) dataset, so no Fletcher32: its
     * digest, in the checksummed object header, proves it on read. */
    char hex[17];
    gs_digest_hex(gs_digest_bytes(h->config, strlen(h->config)), hex);
    GS_TRY(err, gs_h5_write_str_attr(g, "config_digest", hex, h->tmp_path), done);
done:
    H5Gclose(g);
    return err;
}

static gs_err fill_write_identity(struct gs_ckpt *h, const gs_ckpt_meta *meta)
{
    snprintf(h->engine, sizeof h->engine, "%s", meta->engine);
    h->seed = meta->seed;
    h->format_version = GS_FORMAT_VERSION;
    h->program_version = dup_str(GS_VERSION_STRING);
    h->config = dup_str(meta->config_text ? meta->config_text : "");
    GS_CHECK(h->program_version && h->config, GS_ERR_MEM, "%s: out of memory", h->path);
    if (h->rank == 0) {
        time_t now = time(NULL);
        struct tm tm;
        gmtime_r(&now, &tm);
        strftime(h->created, sizeof h->created, "%Y-%m-%dT%H:%M:%SZ", &tm);
    }
    /* Attribute values must be identical on all ranks: rank 0's clock wins. */
    if (is_parallel(h))
        GS_CALL(GS_PAR_BCAST_VALUE(h->comm, &h->created, 0));
    return GS_OK;
}

gs_err gs_ckpt_create(MPI_Comm comm, const char *path, const gs_ckpt_meta *meta,
                      gs_ckpt_t *out)
{
    gs_h5_quiet();
    GS_CHECK(path && path[0] && meta && out, GS_ERR_ARG,
             "gs_ckpt_create: path, meta and out are required");
    GS_CALL(check_engine_name(meta->engine, path));
    struct gs_ckpt *h = NULL;
    GS_CALL(new_handle(comm, path, &h));
    gs_err err = GS_OK, local = GS_OK;
    size_t n = strlen(path);
    h->tmp_path = gs_malloc(n + 5);
    GS_TRY_CHECK(err, h->tmp_path, GS_ERR_MEM, fail, "%s: out of memory", path);
    memcpy(h->tmp_path, path, n);
    memcpy(h->tmp_path + n, ".tmp", 5);
    GS_TRY(err, fill_write_identity(h, meta), fail);

    if (h->rank == 0)
        local = prepare_tmp(h->tmp_path);
    GS_TRY(err, agree(h, local), fail);

    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    if (is_parallel(h))
        H5Pset_fapl_mpio(fapl, comm, MPI_INFO_NULL);
    else
        H5Pset_fapl_sec2(fapl);
    /* The 1.10 format (superblock 3, object header 2, fixed-array chunk
     * indexes): every metadata block, chunk sizes included, carries a
     * checksum, so libhdf5 rejects damaged metadata before parsing it (see
     * gs_h5_precheck). The 1.8 format still indexes chunks with unchecksummed
     * v1 B-trees, whose damaged chunk sizes made libhdf5 malloc 4 GiB in the
     * fuzzer. Readable by HDF5 >= 1.10 (Debian's h5py included). */
    H5Pset_libver_bounds(fapl, H5F_LIBVER_V110, H5F_LIBVER_V110);
    h->file = H5Fcreate(h->tmp_path, H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
    H5Pclose(fapl);
    local = GS_OK;
    if (h->file < 0) {
        char d[256];
        gs_h5_detail(d, sizeof d);
        local = gs_error_raise(GS_ERR_IO, __FILE__, __LINE__, __func__,
                               "%s: cannot create the HDF5 file (HDF5: %s)", h->tmp_path, d);
    }
    GS_TRY(err, agree(h, local), fail_created);
    gs_kill_point("%s.tmp created", gs_kill_base(path));
    h->writing = 1;
    GS_TRY(err, gs_h5_reserve(h, strlen(h->config), "/geosynth"), fail_created);
    local = write_identity(h);
    GS_TRY(err, agree(h, local), fail_created);
    *out = h;
    return GS_OK;

fail_created:
    gs_ckpt_discard(&h);
    return err;
fail:
    free_handle(h);
    return err;
}

#define GS_H5_RESERVE_MARGIN ((uint64_t)256 << 10) /* metadata written later, at close */

gs_err gs_h5_reserve(struct gs_ckpt *h, uint64_t bytes, const char *what)
{
    gs_err local = GS_OK;
    if (h->rank == 0 && h->writing && !h->reserve_off) {
        /* All the file will hold so far, from byte 0 (what is allocated
         * already costs nothing): data + 1/64 for chunk checksums + 4 KiB of
         * metadata per object + a margin for what libhdf5 writes at close. */
        h->reserve_total += bytes + bytes / 64 + 4096;
        if (h->reserve_fd < 0)
            h->reserve_fd = open(h->tmp_path, O_WRONLY | O_NOFOLLOW | O_CLOEXEC);
        int rc = h->reserve_fd < 0 ? EOPNOTSUPP
                                   : posix_fallocate(h->reserve_fd, 0,
                                                     (off_t)(h->reserve_total + GS_H5_RESERVE_MARGIN));
        if (rc == EOPNOTSUPP || rc == EINVAL || rc == ENOSYS)
            h->reserve_off = 1;
        else if (rc != 0)
            local = gs_error_raise(GS_ERR_IO, __FILE__, __LINE__, __func__,
                                   "%s: no room to write %s (%llu bytes; the file needs about %llu): %s",
                                   h->tmp_path, what, (unsigned long long)bytes,
                                   (unsigned long long)h->reserve_total, strerror(rc));
    }
    GS_CALL(agree(h, local));
    return GS_OK;
}

gs_err gs_ckpt_keep_previous(gs_ckpt_t h, const char *prev_path)
{
    GS_CHECK(h && h->writing && prev_path, GS_ERR_ARG,
             "gs_ckpt_keep_previous: a file being written and a path are required");
    gs_free(h->prev_path);
    h->prev_path = dup_str(prev_path);
    GS_CHECK(h->prev_path, GS_ERR_MEM, "%s: out of memory", h->path);
    return GS_OK;
}

static gs_err dir_of(const char *path, char *dir, size_t len)
{
    const char *slash = strrchr(path, '/');
    if (!slash) {
        snprintf(dir, len, ".");
        return GS_OK;
    }
    size_t n = (size_t)(slash - path);
    if (n == 0)
        n = 1; /* "/x.h5" lives in "/" */
    GS_CHECK(n < len, GS_ERR_ARG, "%s: directory name too long", path);
    memcpy(dir, path, n);
    dir[n] = '\0';
    return GS_OK;
}

/* Rank 0: the file about to be replaced becomes prev_path (a hard link
 * renamed into place, so path itself never goes missing). */
static gs_err keep_previous(const struct gs_ckpt *h)
{
    char tmp[4096];
    GS_CHECK(snprintf(tmp, sizeof tmp, "%s.tmp", h->prev_path) < (int)sizeof tmp, GS_ERR_ARG,
             "%s: path too long", h->prev_path);
    if (unlink(tmp) != 0 && errno != ENOENT)
        GS_RAISE(GS_ERR_IO, "%s: cannot remove: %s", tmp, strerror(errno));
    if (link(h->path, tmp) != 0) {
        GS_CHECK(errno == ENOENT, GS_ERR_IO, "%s: cannot keep the previous file as %s: %s",
                 h->path, tmp, strerror(errno));
        return GS_OK; /* the first one: nothing to keep */
    }
    gs_kill_point("%s linked, not renamed", gs_kill_base(tmp));
    GS_CHECK(rename(tmp, h->prev_path) == 0, GS_ERR_IO, "%s: cannot rename %s over it: %s",
             h->prev_path, tmp, strerror(errno));
    return GS_OK;
}

/* Rank 0, after every rank closed the file: make the new file durable, put
 * it in place, make the rename durable. */
/* Cuts what gs_h5_reserve reserved past the file's end: to the end address
 * its superblock (version 2/3 at byte 0, as gs_ckpt_create writes) declares. */
static void trim_reserved(int fd)
{
    unsigned char sb[48];
    struct stat st;
    if (pread(fd, sb, sizeof sb, 0) != (ssize_t)sizeof sb || memcmp(sb, "\211HDF\r\n\032\n", 8) ||
        (sb[8] != 2 && sb[8] != 3) || sb[9] != 8 || fstat(fd, &st) != 0)
        return;
    uint64_t base = 0, eof = 0;
    for (int i = 7; i >= 0; i--) {
        base = base << 8 | sb[12 + i];
        eof = eof << 8 | sb[12 + 16 + i];
    }
    if (eof <= UINT64_MAX - base && base + eof < (uint64_t)st.st_size && ftruncate(fd, (off_t)(base + eof)) != 0) {
        /* the slack stays: harmless */
    }
}

static gs_err durable_rename(const struct gs_ckpt *h)
{
    int fd = open(h->tmp_path, h->reserve_fd >= 0 ? O_RDWR : O_RDONLY);
    if (fd >= 0 && h->reserve_fd >= 0)
        trim_reserved(fd);
    GS_CHECK(fd >= 0, GS_ERR_IO, "%s: cannot reopen for fsync: %s", h->tmp_path,
             strerror(errno));
    if (fsync(fd) != 0) {
        int e = errno;
        close(fd);
        GS_RAISE(GS_ERR_IO, "%s: fsync failed: %s", h->tmp_path, strerror(e));
    }
    close(fd);
    gs_kill_point("%s synced, not renamed", gs_kill_base(h->tmp_path));
    if (h->prev_path) {
        GS_CALL(keep_previous(h));
        gs_kill_point("%s: previous kept, new one not renamed", gs_kill_base(h->tmp_path));
    }
    GS_CHECK(rename(h->tmp_path, h->path) == 0, GS_ERR_IO, "%s: cannot rename %s over it: %s",
             h->path, h->tmp_path, strerror(errno));
    gs_kill_point("%s renamed", gs_kill_base(h->path));
    char dir[4096];
    GS_CALL(dir_of(h->path, dir, sizeof dir));
    int dfd = open(dir, O_RDONLY | O_DIRECTORY);
    GS_CHECK(dfd >= 0, GS_ERR_IO, "%s: cannot open directory %s for fsync: %s", h->path, dir,
             strerror(errno));
    /* Some file systems refuse fsync on directories (EINVAL): nothing more
     * can be done there. */
    if (fsync(dfd) != 0 && errno != EINVAL) {
        int e = errno;
        close(dfd);
        GS_RAISE(GS_ERR_IO, "%s: fsync of directory %s failed: %s", h->path, dir, strerror(e));
    }
    close(dfd);
    return GS_OK;
}

static gs_err barrier(const struct gs_ckpt *h)
{
    if (is_parallel(h))
        GS_CALL(gs_par_barrier(h->comm));
    return GS_OK;
}

gs_err gs_ckpt_commit(gs_ckpt_t *hp)
{
    GS_CHECK(hp && *hp && (*hp)->writing, GS_ERR_ARG,
             "gs_ckpt_commit: the handle is not a file being written");
    struct gs_ckpt *h = *hp;
    *hp = NULL;
    gs_err local = GS_OK, err;
    char d[256];
    if (H5Fflush(h->file, H5F_SCOPE_GLOBAL) < 0) {
        gs_h5_detail(d, sizeof d);
        local = gs_error_raise(GS_ERR_IO, __FILE__, __LINE__, __func__,
                               "%s: flush failed (HDF5: %s)", h->tmp_path, d);
    }
    if (H5Fclose(h->file) < 0 && local == GS_OK) {
        gs_h5_detail(d, sizeof d);
        local = gs_error_raise(GS_ERR_IO, __FILE__, __LINE__, __func__,
                               "%s: close failed (HDF5: %s)", h->tmp_path, d);
    }
    h->file = -1;
    gs_kill_point("%s closed", gs_kill_base(h->tmp_path));
    if (local == GS_OK)
        local = barrier(h); /* every rank's data is in the file before the fsync */
    err = agree(h, local);
    if (err == GS_OK) {
        local = h->rank == 0 ? durable_rename(h) : GS_OK;
        err = agree(h, local);
    }
    if (err != GS_OK && h->rank == 0)
        unlink(h->tmp_path); /* the previous file stays in place */
    free_handle(h);
    return err;
}

void gs_ckpt_discard(gs_ckpt_t *hp)
{
    if (!hp || !*hp)
        return;
    struct gs_ckpt *h = *hp;
    *hp = NULL;
    if (h->file >= 0) {
        /* The file is thrown away: empty it first, so that what libhdf5
         * still writes while closing finds room even on a full disk (one
         * rank failing a write inside H5Fclose leaves the others waiting). */
        if (h->writing && h->rank == 0 && h->tmp_path) {
            int fd = open(h->tmp_path, O_WRONLY | O_NOFOLLOW | O_CLOEXEC);
            if (fd >= 0) {
                if (ftruncate(fd, 0) != 0) {
                    /* nothing more to free */
                }
                close(fd);
            }
        }
        if (h->writing && is_parallel(h))
            gs_par_barrier_quiet(h->comm);
        H5Fclose(h->file);
    }
    H5Eclear2(H5E_DEFAULT);
    if (h->tmp_path) {
        if (is_parallel(h))
            gs_par_barrier_quiet(h->comm);
        if (h->rank == 0)
            unlink(h->tmp_path);
    }
    free_handle(h);
}

/* ---- reading ---------------------------------------------------------------- */

gs_err gs_h5_load_identity(struct gs_ckpt *h, const char *engine)
{
    const char *path = h->path;
    char why[300];
    gs_err err = GS_OK;
    GS_CHECK(gs_h5_exists(h->file, "/geosynth"), GS_ERR_FORMAT,
             "%s: not a geosynth file (no /geosynth group)", path);
    hid_t g = H5Gopen2(h->file, "/geosynth", H5P_DEFAULT);
    if (g < 0) {
        gs_h5_detail(why, sizeof why);
        GS_RAISE(GS_ERR_FORMAT, "%s: not a geosynth file (/geosynth is not a group; HDF5: %s)",
                 path, why);
    }
    char *s = NULL;
    int64_t fv = 0;
    if (gs_h5_read_str_attr(g, "magic", 64, &s, why, sizeof why) != 0)
        GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, done,
                     "%s: not a geosynth file (attribute /geosynth@magic: %s)", path, why);
    GS_TRY_CHECK(err, strcmp(s, "geosynth") == 0, GS_ERR_FORMAT, done,
                 "%s: not a geosynth file (/geosynth@magic is '%.40s', expected 'geosynth')",
                 path, s);
    GS_FREE(s);
    if (gs_h5_read_num_attr(g, "format_version", 'i', &fv, why, sizeof why) != 0)
        GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, done, "%s: attribute /geosynth@format_version: %s",
                     path, why);
    GS_TRY_CHECK(err, fv <= GS_FORMAT_VERSION, GS_ERR_FORMAT, done,
                 "%s was written by format version %lld; this geosynth reads up to %d: "
                 "upgrade geosynth",
                 path, (long long)fv, GS_FORMAT_VERSION);
    GS_TRY_CHECK(err, fv >= 1, GS_ERR_FORMAT, done,
                 "%s: invalid /geosynth@format_version %lld (expected 1..%d)", path,
                 (long long)fv, GS_FORMAT_VERSION);
    h->format_version = (int)fv;
    if (gs_h5_read_str_attr(g, "engine", GS_H5_ENGINE_MAX - 1, &s, why, sizeof why) != 0)
        GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, done, "%s: attribute /geosynth@engine: %s", path,
                     why);
    snprintf(h->engine, sizeof h->engine, "%s", s);
    GS_FREE(s);
    GS_TRY_CHECK(err, check_engine_name(h->engine, path) == GS_OK, GS_ERR_FORMAT, done,
                 "%s: invalid /geosynth@engine '%s'", path, h->engine);
    if (engine)
        GS_TRY_CHECK(err, strcmp(engine, h->engine) == 0, GS_ERR_FORMAT, done,
                     "%s is a '%s' checkpoint, expected '%s'", path, h->engine, engine);
    if (gs_h5_read_str_attr(g, "program_version", 256, &h->program_version, why, sizeof why))
        GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, done, "%s: attribute /geosynth@program_version: %s",
                     path, why);
    if (gs_h5_read_num_attr(g, "seed", 'u', &h->seed, why, sizeof why) != 0)
        GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, done, "%s: attribute /geosynth@seed: %s", path, why);
    if (gs_h5_read_str_attr(g, "created", sizeof h->created - 1, &s, why, sizeof why) != 0)
        GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, done, "%s: attribute /geosynth@created: %s", path,
                     why);
    snprintf(h->created, sizeof h->created, "%s", s);
    GS_FREE(s);
    if (gs_h5_read_str_dataset(g, "config", GS_H5_CONFIG_MAX, &h->config, why, sizeof why))
        GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, done, "%s: dataset /geosynth/config: %s", path, why);
    /* Files since #25 carry it (older ones have no checksums to check; an
     * attribute cannot vanish by damage: the object header is checksummed). */
    if (H5Aexists(g, "config_digest") > 0) {
        if (gs_h5_read_str_attr(g, "config_digest", 16, &s, why, sizeof why) != 0)
            GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, done, "%s: attribute /geosynth@config_digest: %s",
                         path, why);
        char hex[17];
        gs_digest_hex(gs_digest_bytes(h->config, strlen(h->config)), hex);
        GS_TRY_CHECK(err, strcmp(s, hex) == 0, GS_ERR_FORMAT, done,
                     "%s is damaged: the stored config (/geosynth/config) has digest %s, but "
                     "%s was written with it",
                     path, hex, s);
        GS_FREE(s);
    }
done:
    gs_free(s);
    H5Gclose(g);
    H5Eclear2(H5E_DEFAULT);
    return err;
}

static void close_file(struct gs_ckpt *h)
{
    if (h->file >= 0)
        H5Fclose(h->file);
    h->file = -1;
    H5Eclear2(H5E_DEFAULT);
}

gs_err gs_ckpt_open(MPI_Comm comm, const char *path, const char *engine, gs_ckpt_t *out)
{
    gs_h5_quiet();
    GS_CHECK(path && path[0] && out, GS_ERR_ARG, "gs_ckpt_open: path and out are required");
    struct gs_ckpt *h = NULL;
    GS_CALL(new_handle(comm, path, &h));
    gs_err err = GS_OK, local = GS_OK;
    if (!is_parallel(h)) {
        GS_TRY(err, gs_h5_open_serial(path, 1, &h->file), fail);
    } else {
        /* One rank looks at the raw bytes; then all open through MPI-IO. */
        if (h->rank == 0)
            local = gs_h5_precheck_path(path, 1);
        GS_TRY(err, agree(h, local), fail);
        hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
        H5Pset_fapl_mpio(fapl, comm, MPI_INFO_NULL);
        h->file = H5Fopen(path, H5F_ACC_RDONLY, fapl);
        H5Pclose(fapl);
        if (h->file < 0) {
            char d[256];
            gs_h5_detail(d, sizeof d);
            local = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                                   "%s: not a readable HDF5 file (HDF5: %s)", path, d);
        }
        GS_TRY(err, agree(h, local), fail);
    }
    local = gs_h5_load_identity(h, engine);
    GS_TRY(err, agree(h, local), fail);
    *out = h;
    return GS_OK;
fail:
    close_file(h);
    free_handle(h);
    return err;
}

gs_err gs_ckpt_open_image(const void *buf, size_t len, const char *name, const char *engine,
                          gs_ckpt_t *out)
{
    gs_h5_quiet();
    GS_CHECK(name && out && (buf || len == 0), GS_ERR_ARG,
             "gs_ckpt_open_image: name, buf and out are required");
    struct gs_ckpt *h = NULL;
    GS_CALL(new_handle(MPI_COMM_NULL, name, &h));
    gs_err err = GS_OK;
    GS_TRY(err, gs_h5_open_image(name, buf, len, 1, &h->file), fail);
    GS_TRY(err, gs_h5_load_identity(h, engine), fail);
    *out = h;
    return GS_OK;
fail:
    close_file(h);
    free_handle(h);
    return err;
}

gs_err gs_ckpt_close(gs_ckpt_t *hp)
{
    if (!hp || !*hp)
        return GS_OK;
    struct gs_ckpt *h = *hp;
    if (h->writing) {
        gs_ckpt_discard(hp);
        return GS_OK;
    }
    *hp = NULL;
    gs_err err = GS_OK;
    if (h->file >= 0 && H5Fclose(h->file) < 0) {
        char d[256];
        gs_h5_detail(d, sizeof d);
        err = gs_error_raise(GS_ERR_LIB, __FILE__, __LINE__, __func__,
                             "%s: close failed (HDF5: %s)", h->path, d);
    }
    free_handle(h);
    return err;
}

gs_err gs_ckpt_peek(const char *path, char *engine, size_t engine_len, char **config_text)
{
    GS_CHECK(engine && engine_len > 0, GS_ERR_ARG, "gs_ckpt_peek: engine buffer required");
    gs_ckpt_t h = NULL;
    GS_CALL(gs_ckpt_open(MPI_COMM_NULL, path, NULL, &h));
    gs_err err = GS_OK;
    char *cfg = NULL;
    GS_TRY_CHECK(err, strlen(h->engine) < engine_len, GS_ERR_ARG, done,
                 "%s: engine name '%s' does not fit in %zu bytes", path, h->engine, engine_len);
    if (config_text) {
        cfg = dup_str(h->config);
        GS_TRY_CHECK(err, cfg, GS_ERR_MEM, done, "%s: out of memory for the config text", path);
        *config_text = cfg;
    }
    snprintf(engine, engine_len, "%s", h->engine);
done:
    gs_ckpt_close(&h);
    return err;
}

const char *gs_ckpt_path(gs_ckpt_t h) { return h->path; }
const char *gs_ckpt_engine(gs_ckpt_t h) { return h->engine; }
const char *gs_ckpt_program_version(gs_ckpt_t h)
{
    return h->program_version ? h->program_version : "";
}
const char *gs_ckpt_config(gs_ckpt_t h) { return h->config ? h->config : ""; }
const char *gs_ckpt_created(gs_ckpt_t h) { return h->created; }
int gs_ckpt_format_version(gs_ckpt_t h) { return h->format_version; }
uint64_t gs_ckpt_seed(gs_ckpt_t h) { return h->seed; }
