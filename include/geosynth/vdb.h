/* OpenVDB bridge (src/plugins/vdb.cpp, the only C++ in geosynth, built as the
 * plugin geosynth-vdb.so and loaded on the first call that needs it, see
 * geosynth/plugin.h; the dense-field helpers are plain C in src/io/vdb.c).
 * A missing or broken plugin gives GS_ERR_LIB naming the files tried.
 *
 * Everything OpenVDB stays behind this C interface. Every C++ exception is
 * caught at the boundary and becomes a gs_err: GS_ERR_IO for file problems
 * (openvdb::IoError, missing file), GS_ERR_MEM for std::bad_alloc, GS_ERR_LIB
 * with e.what() for anything else. openvdb::initialize() runs once, on first
 * use (thread-safe). Not collective: call from the rank that owns the data.
 *
 * Dense fields (gs_vdb_dense): v[x + nx*(y + ny*z)], x fastest; sample
 * (i,j,k) sits at world position origin + voxel*(i,j,k) (OpenVDB voxel
 * centres, index space = our sample index). background is the value of every
 * point without data (inactive in the VDB tree). Distance fields are in world
 * units; signed ones are negative inside.
 *
 * .vdb files: written atomically (path.tmp + rename) with the dense box stored
 * as grid metadata (gs_dense_min/gs_dense_max), so write/read returns the same
 * box even where edge samples equal the background; grids from other tools
 * come back over their active-voxel bounding box. Only float grids with a
 * uniform, axis-aligned linear transform are read.
 */
#ifndef GEOSYNTH_VDB_H
#define GEOSYNTH_VDB_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"
#include "geosynth/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct gs_vdb_dense {
    size_t nx, ny, nz; /* samples per axis, x fastest */
    double origin[3];  /* world position of sample (0,0,0) */
    double voxel;      /* sample spacing, > 0 */
    float background;  /* value outside the data */
    float *v;          /* nx*ny*nz values (gs_malloc) */
} gs_vdb_dense;

/* OpenVDB's version as the plugin reports it, loading the plugin on first
 * use; GS_ERR_* (with the reason it cannot be loaded) when it is absent. */
gs_err gs_vdb_library_version(const char **version);

/* Allocates a zeroed dense field with origin 0, voxel 1, background 0.
 * Refuses more than GS_VDB_MAX_SAMPLES samples. On error *d is zeroed. */
#define GS_VDB_MAX_SAMPLES ((size_t)1 << 32)
gs_err gs_vdb_dense_alloc(gs_vdb_dense *d, size_t nx, size_t ny, size_t nz);
void gs_vdb_dense_destroy(gs_vdb_dense *d);

/* Opaque OpenVDB FloatGrid. */
typedef struct gs_vdb_grid *gs_vdb_grid_t;

/* Dense -> FloatGrid named name: samples within tolerance of d->background
 * become inactive (tolerance < 0 keeps every sample active). O(samples). */
gs_err gs_vdb_grid_from_dense(const gs_vdb_dense *d, const char *name, float tolerance,
                              gs_vdb_grid_t *out);
/* FloatGrid -> dense over its stored box (or active bounding box). */
gs_err gs_vdb_grid_to_dense(gs_vdb_grid_t g, gs_vdb_dense *out);
void gs_vdb_grid_destroy(gs_vdb_grid_t *g);
const char *gs_vdb_grid_name(gs_vdb_grid_t g);
size_t gs_vdb_grid_active_voxels(gs_vdb_grid_t g);

/* Writes n grids into one .vdb file (atomically). */
gs_err gs_vdb_write(const char *path, const gs_vdb_grid_t *grids, int n);
/* Reads the float grid called name, or when name is NULL the first level
 * set (grid class), else the first float grid. A missing name gives GS_ERR_ARG listing the grids in the file. */
gs_err gs_vdb_read(const char *path, const char *name, gs_vdb_grid_t *out);

/* Checks the structure of a .vdb file image (header, metadata, grid
 * descriptors and offsets, each grid's metadata and transform name) without
 * OpenVDB: every length and offset must lie inside the file. GS_ERR_FORMAT
 * naming the byte otherwise. */
gs_err gs_vdb_check(const void *data, size_t len, const char *name);

/* Convenience: dense <-> .vdb in one call (tolerance 0 on write).
 * gs_vdb_read_dense is the reader for input files: gs_vdb_check first, then
 * OpenVDB in a forked child limited to GS_VDB_READ_MAX_MB of memory (default
 * 80% of what is available) and GS_VDB_READ_SECONDS (default 600), so a
 * damaged file gives an error naming it, never an abort, crash or hang. */
gs_err gs_vdb_write_dense(const char *path, const char *name, const gs_vdb_dense *d);
gs_err gs_vdb_read_dense(const char *path, const char *name, gs_vdb_dense *out);

typedef struct gs_vdb_distance_opts {
    int samples;    /* samples along the longest axis of the box, in [4, 4096] */
    double margin;  /* world units added on every side of the mesh bounding box;
                       < 0 selects 10% of the longest bounding-box side */
    int is_signed;  /* 0: unsigned distance (any mesh); 1: signed (closed mesh) */
} gs_vdb_distance_opts;

/* Distance from every sample of a regular grid covering m's bounding box plus
 * margin: voxel = (longest side + 2 margin) / (samples - 1), origin = box min
 * - margin. Bands are chosen from an upper bound of the largest distance in
 * the box, so every sample holds a true distance (never the clamped
 * background; checked, GS_ERR_INTERNAL otherwise). A signed request on a mesh
 * that is not closed is refused with GS_ERR_ARG naming `what` and the edge
 * counts (see gs_mesh_require_closed). Cost: OpenVDB mesh-to-volume over the
 * box plus the band around it. */
gs_err gs_vdb_mesh_to_distance(const gs_mesh *m, const char *what,
                               const gs_vdb_distance_opts *opts, gs_vdb_dense *out);

/* Iso-surface of a dense field at isovalue (OpenVDB volumeToMesh, quads split
 * into two triangles along the shorter diagonal). adaptivity in [0, 1]
 * (0 = uniform). Triangles are oriented so their normals point towards
 * larger field values (outward for a signed distance). *out is a new mesh
 * (gs_mesh_destroy); an empty surface gives a mesh with 0 triangles. */
gs_err gs_vdb_dense_to_mesh(const gs_vdb_dense *d, double isovalue, double adaptivity,
                            gs_mesh *out);

/* Redistancing (the zero iso-surface meshed by OpenVDB volumeToMesh, the
 * mesh contour.ply has; then the distance to its triangles within
 * half_width voxels, >= 1, our own: each triangle's exact distance to the
 * samples of its bounding box, then ceil(half_width) + 1 layers in which a
 * sample tries the triangles its 26 neighbours took, all at once; signs are
 * the field's own, so the inside is unchanged), its magnitudes then lowered where they exceed a bound of the
 * distance to that surface (the distance to a zero crossing on an edge,
 * |b| + voxel from a neighbour of the same sign), so no neighbour step
 * exceeds one voxel; values beyond the band are +-half_width * voxel.
 * d is the whole field, unpadded; it is padded with `pad` copies of its edge
 * values on every side, so the surface is not closed at the box faces.
 * gs_vdb_redistance writes the redistanced planes [z0, z1) of d into out
 * (nx * ny * (z1 - z0) values), rebuilding only those planes plus a margin
 * (the bound's reach, ceil(half_width) + 1, and pad more): memory and time
 * grow with z1 - z0, and any split of the planes gives the same values as
 * one call over [0, nz) (tests/unit/test_vdb.c checks it). The work
 * indexes the samples of a piece's padded box ((nx + 2 pad) (ny + 2 pad)
 * times its planes with their margins) and its triangles with 32 bits: a
 * piece whose box holds more than GS_VDB_REDIST_MAX_SAMPLES samples (or
 * whose contour has that many triangles) is refused with GS_ERR_ARG, never
 * wrapped; the caller splits the planes into smaller pieces.
 * gs_vdb_level_set_write writes d (already redistanced) as a .vdb file: a
 * level set grid named `name` (class level set, background = half_width *
 * voxel, voxel size d->voxel, samples at +-background inactive, index space
 * starting at sample -pad) with a fog volume "density" beside it (OpenVDB
 * sdfToFogVolume: 0 outside, 1 inside, a ramp across the band; what
 * renderers' default volume shaders read) and grid metadata up_axis = "z"
 * and units on both. */
#define GS_VDB_REDIST_MAX_SAMPLES ((uint64_t)UINT32_MAX)
gs_err gs_vdb_redistance(const gs_vdb_dense *d, int pad, double half_width, size_t z0, size_t z1,
                         float *out);
gs_err gs_vdb_level_set_write(const gs_vdb_dense *d, int pad, double half_width, const char *name,
                              const char *path);

#ifdef __cplusplus
}
#endif
#endif
