/* The gs_vdb_* interface (include/geosynth/vdb.h): dense fields here, the
 * rest forwarded to the OpenVDB plugin (src/plugins/vdb.cpp, loaded on first
 * use; include/geosynth/plugin.h says why). */
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "geosynth/file.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "geosynth/plugin.h"
#include "geosynth/vdb.h"
#include "plugins/plugin_api.h"

gs_err gs_vdb_dense_alloc(gs_vdb_dense *d, size_t nx, size_t ny, size_t nz)
{
    memset(d, 0, sizeof *d);
    size_t n;
    GS_CHECK(nx >= 1 && ny >= 1 && nz >= 1 && gs_mul_size(nx, ny, &n) && gs_mul_size(n, nz, &n) &&
                 n <= GS_VDB_MAX_SAMPLES,
             GS_ERR_ARG, "dense field of %zux%zux%zu samples: expected 1 to %zu samples", nx, ny,
             nz, GS_VDB_MAX_SAMPLES);
    void *v = NULL;
    GS_CALL(gs_alloc_array(&v, n, sizeof(float), "dense field"));
    d->v = v;
    d->nx = nx;
    d->ny = ny;
    d->nz = nz;
    d->voxel = 1.0;
    return GS_OK;
}

void gs_vdb_dense_destroy(gs_vdb_dense *d)
{
    if (!d)
        return;
    gs_free(d->v);
    memset(d, 0, sizeof *d);
}

/* Declares f, the plugin's gs_vdbp_<fn> (plugins/plugin_api.h), and looks
 * it up (POSIX: a data pointer from dlsym converts to a function pointer
 * through memcpy). */
#define VDB_FN(f, fn)                                                        \
    gs_vdbp_##fn##_fn *f;                                                    \
    do {                                                                     \
        void *sym_;                                                          \
        GS_CALL(gs_plugin_sym("vdb", "gs_vdbp_" #fn, &sym_));                \
        memcpy(&(f), &sym_, sizeof(f));                                      \
    } while (0)

/* VDB_FN for the entry points that return no gs_err: 0 (error cleared) when
 * the plugin cannot be loaded. */
static int vdb_fn_quiet(const char *sym, void *f, size_t size)
{
    void *p;
    if (gs_plugin_sym("vdb", sym, &p) != GS_OK) {
        gs_error_clear();
        return 0;
    }
    memcpy(f, &p, size);
    return 1;
}

gs_err gs_vdb_library_version(const char **version)
{
    VDB_FN(f, library_version);
    *version = f();
    return GS_OK;
}

gs_err gs_vdb_grid_from_dense(const gs_vdb_dense *d, const char *name, float tolerance,
                              gs_vdb_grid_t *out)
{
    VDB_FN(f, grid_from_dense);
    GS_CALL(f(d, name, tolerance, out));
    return GS_OK;
}

gs_err gs_vdb_grid_to_dense(gs_vdb_grid_t g, gs_vdb_dense *out)
{
    VDB_FN(f, grid_to_dense);
    GS_CALL(f(g, out));
    return GS_OK;
}

/* A grid exists only once the plugin is loaded, so the lookups of the three
 * grid accessors below cannot fail (a NULL grid needs no plugin). */
void gs_vdb_grid_destroy(gs_vdb_grid_t *g)
{
    gs_vdbp_grid_destroy_fn *f;
    if (g && *g && vdb_fn_quiet("gs_vdbp_grid_destroy", &f, sizeof f))
        f(g);
}

const char *gs_vdb_grid_name(gs_vdb_grid_t g)
{
    gs_vdbp_grid_name_fn *f;
    return g && vdb_fn_quiet("gs_vdbp_grid_name", &f, sizeof f) ? f(g) : "";
}

size_t gs_vdb_grid_active_voxels(gs_vdb_grid_t g)
{
    gs_vdbp_grid_active_voxels_fn *f;
    return g && vdb_fn_quiet("gs_vdbp_grid_active_voxels", &f, sizeof f) ? f(g) : 0;
}

gs_err gs_vdb_write(const char *path, const gs_vdb_grid_t *grids, int n)
{
    VDB_FN(f, write);
    GS_CALL(f(path, grids, n));
    return GS_OK;
}

gs_err gs_vdb_read(const char *path, const char *name, gs_vdb_grid_t *out)
{
    VDB_FN(f, read);
    GS_CALL(f(path, name, out));
    return GS_OK;
}

gs_err gs_vdb_write_dense(const char *path, const char *name, const gs_vdb_dense *d)
{
    VDB_FN(f, write_dense);
    GS_CALL(f(path, name, d));
    return GS_OK;
}

/* ------------------------------------------------ checking .vdb inputs
 *
 * OpenVDB trusts its input: crafted or truncated files abort it ("malloc():
 * corrupted top size"), crash it, or make it allocate gigabytes from a
 * string length (Transform::read). Two guards stand in front of it:
 * gs_vdb_check walks the file's structure (header, file metadata, every grid
 * descriptor, each grid's metadata and transform name) and refuses any
 * length or offset that runs past the file; then the read itself runs in a
 * forked child with a memory limit and a time limit, so whatever OpenVDB
 * does with the rest (topology, compressed buffers) ends as an error naming
 * the file. */

typedef struct vdb_rd {
    const unsigned char *d;
    size_t len, pos;
    const char *name;
    int grid; /* 1: len is the end of a grid's header */
} vdb_rd;

static gs_err rd_bytes(vdb_rd *r, size_t n, size_t end, const char *what, const unsigned char **p)
{
    GS_CHECK(r->pos <= end && end - r->pos >= n, GS_ERR_FORMAT,
             "%s: byte %zu: %s (%zu bytes) runs past the end of the %s (byte %zu): the file is "
             "truncated or damaged", r->name, r->pos, what, n,
             r->grid ? "grid's header" : "file", end);
    *p = r->d + r->pos;
    r->pos += n;
    return GS_OK;
}

static gs_err rd_u32(vdb_rd *r, size_t end, const char *what, uint32_t *v)
{
    const unsigned char *p = NULL;
    GS_CALL(rd_bytes(r, 4, end, what, &p));
    *v = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
    return GS_OK;
}

static gs_err rd_u64(vdb_rd *r, size_t end, const char *what, uint64_t *v)
{
    uint32_t lo, hi;
    GS_CALL(rd_u32(r, end, what, &lo));
    GS_CALL(rd_u32(r, end, what, &hi));
    *v = (uint64_t)hi << 32 | lo;
    return GS_OK;
}

/* A length-prefixed string; its text (cut to cap - 1, escaped) into out. */
static gs_err rd_str(vdb_rd *r, size_t end, const char *what, char *out, size_t cap)
{
    uint32_t n;
    const unsigned char *p;
    GS_CALL(rd_u32(r, end, what, &n));
    GS_CALL(rd_bytes(r, n, end, what, &p));
    size_t k = 0;
    for (uint32_t i = 0; i < n && k + 1 < cap; i++)
        out[k++] = p[i] >= 32 && p[i] < 127 ? (char)p[i] : '?';
    out[k] = '\0';
    return GS_OK;
}

/* A metadata map: count, then name, type name and sized value each. */
static gs_err rd_meta(vdb_rd *r, size_t end, const char *where)
{
    uint32_t count;
    GS_CALL(rd_u32(r, end, "the metadata count", &count));
    GS_CHECK(count <= (end - r->pos) / 12, GS_ERR_FORMAT,
             "%s: byte %zu: %s declares %u metadata items, more than the bytes left can hold",
             r->name, r->pos - 4, where, count);
    for (uint32_t i = 0; i < count; i++) {
        char nm[64], ty[64];
        uint32_t size;
        const unsigned char *p;
        GS_CALL(rd_str(r, end, "a metadata name", nm, sizeof nm));
        GS_CALL(rd_str(r, end, "a metadata type", ty, sizeof ty));
        GS_CALL(rd_u32(r, end, "a metadata size", &size));
        GS_CALL(rd_bytes(r, size, end, "a metadata value", &p));
    }
    return GS_OK;
}

gs_err gs_vdb_check(const void *data, size_t len, const char *name)
{
    vdb_rd r = {data, len, 0, name, 0};
    uint64_t magic;
    uint32_t version, major, minor;
    const unsigned char *p = NULL;
    GS_CHECK(len >= 8, GS_ERR_FORMAT, "%s: not a VDB file (%zu bytes)", name, len);
    GS_CALL(rd_u64(&r, len, "the magic number", &magic));
    GS_CHECK(magic == 0x56444220u, GS_ERR_FORMAT,
             "%s: not a VDB file (no OpenVDB magic number at byte 0)", name);
    GS_CALL(rd_u32(&r, len, "the file version", &version));
    GS_CHECK(version >= 219 && version <= 224, GS_ERR_FORMAT,
             "%s: VDB file format version %u: this geosynth reads versions 219 to 224 "
             "(OpenVDB 3 to 10); rewrite the file with a current OpenVDB", name, version);
    GS_CALL(rd_u32(&r, len, "the library version", &major));
    GS_CALL(rd_u32(&r, len, "the library version", &minor));
    GS_CALL(rd_bytes(&r, 1, len, "the grid-offsets flag", &p));
    GS_CHECK(p[0] == 1, GS_ERR_FORMAT,
             "%s: a VDB stream without grid offsets: not supported (write it as a file)", name);
    if (version < 222)
        GS_CALL(rd_bytes(&r, 1, len, "the compression flag", &p));
    GS_CALL(rd_bytes(&r, 36, len, "the file's UUID", &p));
    GS_CALL(rd_meta(&r, len, "the file"));
    uint32_t grids;
    GS_CALL(rd_u32(&r, len, "the grid count", &grids));
    GS_CHECK(grids <= 4096, GS_ERR_FORMAT, "%s: %u grids: at most 4096 are supported", name,
             grids);
    for (uint32_t g = 0; g < grids; g++) {
        char gname[128], gtype[128], parent[128];
        uint64_t gpos, bpos, epos;
        size_t at = r.pos;
        GS_CALL(rd_str(&r, len, "a grid name", gname, sizeof gname));
        GS_CALL(rd_str(&r, len, "a grid type", gtype, sizeof gtype));
        GS_CALL(rd_str(&r, len, "a grid's instance parent", parent, sizeof parent));
        GS_CALL(rd_u64(&r, len, "a grid offset", &gpos));
        GS_CALL(rd_u64(&r, len, "a grid offset", &bpos));
        GS_CALL(rd_u64(&r, len, "a grid offset", &epos));
        GS_CHECK(gpos >= r.pos && gpos <= bpos && bpos <= epos && epos <= len, GS_ERR_FORMAT,
                 "%s: byte %zu: grid %u ('%s') says it lies at bytes %llu, %llu to %llu, but "
                 "the file has %zu bytes and the grid's descriptor ends at byte %zu: the file "
                 "is truncated or damaged",
                 name, at, g, gname, (unsigned long long)gpos, (unsigned long long)bpos,
                 (unsigned long long)epos, len, r.pos);
        /* the grid's own header: compression, metadata, transform name */
        vdb_rd gr = {data, (size_t)bpos, (size_t)gpos, name, 1};
        uint32_t comp;
        char xf[64];
        if (version >= 222)
            GS_CALL(rd_u32(&gr, gr.len, "a grid's compression flags", &comp));
        GS_CALL(rd_meta(&gr, gr.len, "a grid"));
        if (!parent[0])
            GS_CALL(rd_str(&gr, gr.len, "a grid's transform type", xf, sizeof xf));
        r.pos = (size_t)epos; /* the next descriptor follows the grid */
    }
    return GS_OK;
}

/* Seconds and bytes the isolated reader may use (GS_VDB_READ_SECONDS,
 * GS_VDB_READ_MAX_MB; defaults 600 s and 80% of the memory available). */
static double read_seconds(void)
{
    const char *e = getenv("GS_VDB_READ_SECONDS");
    double v;
    return e && gs_parse_f64(e, 0.1, 1e7, &v, NULL, 0) ? v : 600.0;
}

static unsigned long long read_max_bytes(void)
{
    const char *e = getenv("GS_VDB_READ_MAX_MB");
    int64_t mb;
    if (e && gs_parse_i64(e, 16, (int64_t)1 << 40, &mb, NULL, 0))
        return (unsigned long long)mb << 20;
    unsigned long long avail = 0;
    FILE *f = fopen("/proc/meminfo", "r");
    char line[256];
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, "MemAvailable:", 13))
            avail = strtoull(line + 13, NULL, 10) << 10;
    if (f)
        fclose(f);
    return avail ? avail / 5 * 4 : 8ULL << 30;
}

static unsigned long long vm_size(void)
{
    unsigned long long pages = 0;
    FILE *f = fopen("/proc/self/statm", "r");
    if (f) {
        if (fscanf(f, "%llu", &pages) != 1)
            pages = 0;
        fclose(f);
    }
    return pages * (unsigned long long)sysconf(_SC_PAGESIZE);
}

typedef struct vdb_reply {
    int32_t err;
    uint32_t msglen;
    uint64_t nx, ny, nz;
    double origin[3], voxel;
    float background;
} vdb_reply;

static int write_all(int fd, const void *buf, size_t n)
{
    const char *p = buf;
    while (n) {
        ssize_t w = write(fd, p, n);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0)
            return 0;
        p += w;
        n -= (size_t)w;
    }
    return 1;
}

/* In the child: read, send the reply, exit (no atexit handlers, no MPI). */
_Noreturn static void child_read(int fd, const char *path, const char *name,
                                 unsigned long long max_bytes)
{
    struct rlimit rl;
    rl.rlim_cur = rl.rlim_max = (rlim_t)(vm_size() + max_bytes);
    setrlimit(RLIMIT_AS, &rl);
    gs_vdb_dense d;
    memset(&d, 0, sizeof d);
    vdb_reply rep;
    memset(&rep, 0, sizeof rep);
    gs_vdbp_read_dense_fn *f;
    void *sym;
    gs_err err = gs_plugin_sym("vdb", "gs_vdbp_read_dense", &sym);
    if (!err) {
        memcpy(&f, &sym, sizeof f);
        err = f(path, name, &d);
    }
    rep.err = (int32_t)err;
    const char *msg = err ? gs_error_message() : "";
    rep.msglen = (uint32_t)strlen(msg);
    rep.nx = d.nx;
    rep.ny = d.ny;
    rep.nz = d.nz;
    memcpy(rep.origin, d.origin, sizeof rep.origin);
    rep.voxel = d.voxel;
    rep.background = d.background;
    int ok = write_all(fd, &rep, sizeof rep) && write_all(fd, msg, rep.msglen);
    if (ok && !err)
        ok = write_all(fd, d.v, d.nx * d.ny * d.nz * sizeof(float));
    _exit(ok ? 0 : 3);
}

/* Reads n bytes from fd before the deadline; 0 at EOF/error, -1 on timeout. */
static int read_until(int fd, void *buf, size_t n, double deadline)
{
    char *p = buf;
    while (n) {
        double left = deadline - gs_time_now();
        if (left <= 0)
            return -1;
        struct pollfd pf = {fd, POLLIN, 0};
        int pr = poll(&pf, 1, left > 1e6 ? 1000000000 : (int)(left * 1000) + 1);
        if (pr < 0 && errno == EINTR)
            continue;
        if (pr == 0)
            continue;
        ssize_t r = read(fd, p, n);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            return 0;
        p += r;
        n -= (size_t)r;
    }
    return 1;
}

gs_err gs_vdb_read_dense(const char *path, const char *name, gs_vdb_dense *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(path && path[0], GS_ERR_ARG, "vdb path is empty");
    char *data = NULL;
    size_t len = 0;
    GS_CALL(gs_file_read_all(path, (size_t)1 << 36, &data, &len));
    gs_err err = gs_vdb_check(data, len, path);
    gs_free(data);
    GS_CALL(err);
    /* load the plugin here, so a missing plugin is reported as such */
    void *sym;
    GS_CALL(gs_plugin_sym("vdb", "gs_vdbp_read_dense", &sym));
    double secs = read_seconds();
    unsigned long long max_bytes = read_max_bytes();
    int fds[2];
    GS_CHECK(pipe(fds) == 0, GS_ERR_IO, "%s: cannot create a pipe for the VDB reader: %s", path,
             strerror(errno));
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        close(fds[0]);
        child_read(fds[1], path, name, max_bytes);
    }
    close(fds[1]);
    if (pid < 0) {
        close(fds[0]);
        GS_RAISE(GS_ERR_IO, "%s: cannot start the VDB reader: %s", path, strerror(errno));
    }
    double deadline = gs_time_now() + secs;
    vdb_reply rep;
    char msg[1024] = "";
    int got = read_until(fds[0], &rep, sizeof rep, deadline);
    if (got == 1) {
        size_t m = rep.msglen < sizeof msg - 1 ? rep.msglen : sizeof msg - 1;
        got = read_until(fds[0], msg, m, deadline);
        msg[m] = '\0';
        char skip[256];
        for (size_t left = rep.msglen - m; got == 1 && left;) {
            size_t k = left < sizeof skip ? left : sizeof skip;
            got = read_until(fds[0], skip, k, deadline);
            left -= k;
        }
    }
    if (got == 1 && rep.err == GS_OK) {
        err = gs_vdb_dense_alloc(out, (size_t)rep.nx, (size_t)rep.ny, (size_t)rep.nz);
        if (!err) {
            memcpy(out->origin, rep.origin, sizeof out->origin);
            out->voxel = rep.voxel;
            out->background = rep.background;
            got = read_until(fds[0], out->v, out->nx * out->ny * out->nz * sizeof(float),
                             deadline);
        }
    }
    close(fds[0]);
    if (got == -1)
        kill(pid, SIGKILL);
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
        ;
    if (err) {
        gs_vdb_dense_destroy(out);
        GS_CALL(err);
    }
    if (got == -1) {
        gs_vdb_dense_destroy(out);
        GS_RAISE(GS_ERR_FORMAT,
                 "%s: OpenVDB took more than %g s to read this file: stopped (a damaged or "
                 "crafted file? GS_VDB_READ_SECONDS raises the limit)", path, secs);
    }
    if (WIFSIGNALED(status) || got != 1) {
        gs_vdb_dense_destroy(out);
        if (WIFSIGNALED(status))
            GS_RAISE(GS_ERR_FORMAT,
                     "%s: OpenVDB died reading this file (signal %d, %s; memory limit %llu MiB): "
                     "the file is damaged or crafted", path, WTERMSIG(status),
                     strsignal(WTERMSIG(status)), max_bytes >> 20);
        GS_RAISE(GS_ERR_FORMAT, "%s: the VDB reader ended without an answer (exit status %d)",
                 path, WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    }
    if (rep.err != GS_OK) {
        gs_err code = rep.err > 0 && rep.err < 100 ? (gs_err)rep.err : GS_ERR_LIB;
        if (code == GS_ERR_MEM)
            GS_RAISE(GS_ERR_FORMAT,
                     "%s: reading it needs more than the %llu MiB allowed (GS_VDB_READ_MAX_MB): "
                     "%s", path, max_bytes >> 20, msg);
        GS_RAISE(code, "%s", msg);
    }
    return GS_OK;
}

gs_err gs_vdb_mesh_to_distance(const gs_mesh *m, const char *what,
                               const gs_vdb_distance_opts *opts, gs_vdb_dense *out)
{
    VDB_FN(f, mesh_to_distance);
    GS_CALL(f(m, what, opts, out));
    return GS_OK;
}

gs_err gs_vdb_dense_to_mesh(const gs_vdb_dense *d, double isovalue, double adaptivity,
                            gs_mesh *out)
{
    VDB_FN(f, dense_to_mesh);
    GS_CALL(f(d, isovalue, adaptivity, out));
    return GS_OK;
}

gs_err gs_vdb_redistance(const gs_vdb_dense *d, int pad, double half_width, size_t z0, size_t z1,
                         float *out)
{
    VDB_FN(f, redistance);
    GS_CALL(f(d, pad, half_width, z0, z1, out));
    return GS_OK;
}

gs_err gs_vdb_level_set_write(const gs_vdb_dense *d, int pad, double half_width, const char *name,
                              const char *path)
{
    VDB_FN(f, level_set_write);
    GS_CALL(f(d, pad, half_width, name, path));
    return GS_OK;
}
