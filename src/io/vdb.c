/* The gs_vdb_* interface (include/geosynth/vdb.h): dense fields here, the
 * rest forwarded to the OpenVDB plugin (src/plugins/vdb.cpp, loaded on first
 * use; include/geosynth/plugin.h says why). */
#include <string.h>

#include "geosynth/mem.h"
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

gs_err gs_vdb_read_dense(const char *path, const char *name, gs_vdb_dense *out)
{
    VDB_FN(f, read_dense);
    GS_CALL(f(path, name, out));
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
