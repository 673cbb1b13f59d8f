/* The plugins' entry points (include/geosynth/plugin.h): one function type
 * each, declared here for both sides, so the program's forwarders
 * (src/io/vdb.c, src/io/render.c) and the plugins (src/plugins/vdb.cpp,
 * render_gl.c) are checked against the same signature by the compiler.
 * gs_vdbp_X implements gs_vdb_X of include/geosynth/vdb.h;
 * gs_vdbp_library_version is OpenVDB's version (geosynth version). */
#ifndef GEOSYNTH_PLUGIN_API_H
#define GEOSYNTH_PLUGIN_API_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/render.h"
#include "geosynth/vdb.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef const char *gs_vdbp_library_version_fn(void);
typedef gs_err gs_vdbp_grid_from_dense_fn(const gs_vdb_dense *d, const char *name, float tolerance,
                                          gs_vdb_grid_t *out);
typedef gs_err gs_vdbp_grid_to_dense_fn(gs_vdb_grid_t g, gs_vdb_dense *out);
typedef void gs_vdbp_grid_destroy_fn(gs_vdb_grid_t *g);
typedef const char *gs_vdbp_grid_name_fn(gs_vdb_grid_t g);
typedef size_t gs_vdbp_grid_active_voxels_fn(gs_vdb_grid_t g);
typedef gs_err gs_vdbp_write_fn(const char *path, const gs_vdb_grid_t *grids, int n);
typedef gs_err gs_vdbp_read_fn(const char *path, const char *name, gs_vdb_grid_t *out);
typedef gs_err gs_vdbp_write_dense_fn(const char *path, const char *name, const gs_vdb_dense *d);
typedef gs_err gs_vdbp_read_dense_fn(const char *path, const char *name, gs_vdb_dense *out);
typedef gs_err gs_vdbp_mesh_to_distance_fn(const gs_mesh *m, const char *what,
                                           const gs_vdb_distance_opts *opts, gs_vdb_dense *out);
typedef gs_err gs_vdbp_dense_to_mesh_fn(const gs_vdb_dense *d, double isovalue, double adaptivity,
                                        gs_mesh *out);
typedef gs_err gs_vdbp_redistance_fn(const gs_vdb_dense *d, int pad, double half_width, size_t z0,
                                     size_t z1, float *out);
typedef gs_err gs_vdbp_level_set_write_fn(const gs_vdb_dense *d, int pad, double half_width,
                                          const char *name, const char *path);
/* Renders m (normals per vertex) through cam into rgba (W x H x 4, row 0 at
 * the bottom). */
typedef gs_err gs_renderp_draw_fn(const gs_mesh *m, const float *normals,
                                  const gs_render_camera *cam, const gs_render_opts *o, int W,
                                  int H, uint8_t *rgba);

gs_vdbp_library_version_fn gs_vdbp_library_version;
gs_vdbp_grid_from_dense_fn gs_vdbp_grid_from_dense;
gs_vdbp_grid_to_dense_fn gs_vdbp_grid_to_dense;
gs_vdbp_grid_destroy_fn gs_vdbp_grid_destroy;
gs_vdbp_grid_name_fn gs_vdbp_grid_name;
gs_vdbp_grid_active_voxels_fn gs_vdbp_grid_active_voxels;
gs_vdbp_write_fn gs_vdbp_write;
gs_vdbp_read_fn gs_vdbp_read;
gs_vdbp_write_dense_fn gs_vdbp_write_dense;
gs_vdbp_read_dense_fn gs_vdbp_read_dense;
gs_vdbp_mesh_to_distance_fn gs_vdbp_mesh_to_distance;
gs_vdbp_dense_to_mesh_fn gs_vdbp_dense_to_mesh;
gs_vdbp_redistance_fn gs_vdbp_redistance;
gs_vdbp_level_set_write_fn gs_vdbp_level_set_write;
gs_renderp_draw_fn gs_renderp_draw;

#ifdef __cplusplus
}
#endif
#endif
